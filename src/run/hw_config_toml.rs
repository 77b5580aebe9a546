//! Hardware configuration files: TOML with the knob names of
//! `postwarp_rtl::config::KNOBS` as keys, over a preset.
//!
//! Rules: every key optional; an unknown key, a value of the wrong type or
//! an invalid value is rejected with a message naming the file and the knob;
//! `preset = "NAME"` in the file picks the base (default `mark1998`).

use anyhow::{Context, anyhow, bail};
use postwarp_rtl::config::{EngineConfig, KNOBS};
use std::path::Path;

/// Set knob `key` of `c` from a TOML value; the error says what was
/// expected (the caller names the file and the key).
pub fn set(c: &mut EngineConfig, key: &str, v: &toml::Value) -> Result<(), String> {
    let int = || v.as_integer().filter(|&n| n >= 0).map(|n| n as u64).ok_or("expected a non-negative integer");
    let u32v = || int().and_then(|n| u32::try_from(n).map_err(|_| "expected an integer below 2^32"));
    let real = || v.as_float().or_else(|| v.as_integer().map(|n| n as f64)).ok_or("expected a number");
    match key {
        "supersample" => c.supersample = u32v()?,
        "max_fragments" => c.max_fragments = u32v()?,
        "kernel_limit" => c.kernel_limit = u32v()?,
        "rects_per_cycle" => c.rects_per_cycle = u32v()?,
        "transform_latency" => c.transform_latency = u32v()?,
        "transform_throughput" => c.transform_throughput = u32v()?,
        "tile_size" => c.tile_size = u32v()?,
        "dest_cache_bytes" => c.dest_cache_bytes = int()?,
        "source_cache_bytes" => c.source_cache_bytes = int()?,
        "dram_peak_bytes_per_cycle" => c.dram_peak_bytes_per_cycle = int()?,
        "dram_latency_cycles" => c.dram_latency_cycles = int()?,
        "dram_burst_bytes" => c.dram_burst_bytes = int()?,
        "dram_max_outstanding" => c.dram_max_outstanding = u32v()?,
        "clock_hz" => c.clock_hz = int()?,
        "target_frame_rate_hz" => c.target_frame_rate_hz = real()?,
        "display_width" => c.display_width = u32v()?,
        "display_height" => c.display_height = u32v()?,
        "views" => c.views = u32v()?,
        "references_per_frame" => c.references_per_frame = u32v()?,
        "threshold" => c.threshold = real()?,
        "slope_tol" => c.slope_tol = real()?,
        "rel_tol" => c.rel_tol = real()?,
        "better_margin" => c.better_margin = real()?,
        "hole_far_distance" => c.hole_far_distance = u32v()?,
        "hole_far_offset" => c.hole_far_offset = u32v()?,
        "hole_max_distance" => c.hole_max_distance = u32v()?,
        "hole_fill_per_cycle" => c.hole_fill_per_cycle = u32v()?,
        _ => return Err(format!("unknown knob (known: {})", KNOBS.iter().map(|k| k.0).collect::<Vec<_>>().join(", "))),
    }
    Ok(())
}

/// The configuration of `--config FILE` / `--preset NAME` (at most one
/// given; neither: `mark1998`), validated.
pub fn load(config: Option<&Path>, preset: Option<&str>) -> anyhow::Result<EngineConfig> {
    let cfg = match (config, preset) {
        (Some(_), Some(_)) => bail!("give --config or --preset, not both (a config file may name `preset = \"...\"`)"),
        (None, p) => EngineConfig::preset(p.unwrap_or("mark1998")).map_err(|e| anyhow!(e))?,
        (Some(path), None) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
            return from_text(&text, path);
        }
    };
    cfg.validate().map_err(|e| anyhow!("hardware configuration: {e}"))?;
    Ok(cfg)
}

/// The configuration in file `path`'s `text`, validated; errors name the file.
pub fn from_text(text: &str, path: &Path) -> anyhow::Result<EngineConfig> {
    let cfg = parse(text).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    cfg.validate().map_err(|e| anyhow!("{}: hardware configuration: {e}", path.display()))?;
    Ok(cfg)
}

/// Parse a configuration file's text (not yet validated).
pub fn parse(text: &str) -> anyhow::Result<EngineConfig> {
    let table: toml::Table = toml::from_str(text)?;
    let base = match table.get("preset") {
        None => "mark1998",
        Some(v) => v.as_str().ok_or_else(|| anyhow!("preset: expected a preset name in quotes"))?,
    };
    let mut c = EngineConfig::preset(base).map_err(|e| anyhow!("preset: {e}"))?;
    for (k, v) in &table {
        if k != "preset" {
            set(&mut c, k, v).map_err(|e| anyhow!("{k}: {e}"))?;
        }
    }
    Ok(c)
}

/// Every knob as `{name: value}`, in [`KNOBS`] order, for `report.json`.
pub fn to_json(c: &EngineConfig) -> serde_json::Value {
    let mut m = serde_json::Map::new();
    let text = format!("{c:?}");
    for (name, _, _) in KNOBS {
        // Field values from the Debug form: `name: value`.
        let start = text.find(&format!("{name}: ")).expect("every knob is a field") + name.len() + 2;
        let rest = &text[start..];
        let end = rest.find([',', ' ', '}']).unwrap_or(rest.len());
        let raw = &rest[..end];
        let v: serde_json::Value = serde_json::from_str(raw).unwrap_or(serde_json::Value::String(raw.into()));
        m.insert(name.to_string(), v);
    }
    serde_json::Value::Object(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_override_a_preset_and_name_bad_knobs() {
        let c = parse("preset = \"hmd2026\"\ntile_size = 16\nthreshold = 2\n").unwrap();
        assert_eq!((c.tile_size, c.threshold, c.views), (16, 2.0, 2));
        let e = parse("tile_sise = 16").unwrap_err().to_string();
        assert!(e.starts_with("tile_sise: unknown knob"), "{e}");
        let e = parse("tile_size = -1").unwrap_err().to_string();
        assert!(e.starts_with("tile_size: expected a non-negative"), "{e}");
        let e = parse("preset = \"nope\"").unwrap_err().to_string();
        assert!(e.contains("mark1998"), "{e}");
    }

    #[test]
    fn every_knob_is_settable_and_reported() {
        let mut c = EngineConfig::default();
        for (name, _, _) in KNOBS {
            set(&mut c, name, &toml::Value::Integer(1)).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        let j = to_json(&EngineConfig::default());
        assert_eq!(j.as_object().unwrap().len(), KNOBS.len());
        assert_eq!(j["dest_cache_bytes"], 589_824);
        assert_eq!(j["threshold"], 1.4);
    }
}
