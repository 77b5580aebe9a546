//! Hardware configuration files: TOML with the knob names of
//! `postwarp_rtl::config::KNOBS` as keys, over a preset.
//!
//! Rules: every key optional; an unknown key, a value of the wrong type or
//! an invalid value is rejected with a message naming the file and the knob;
//! `preset = "NAME"` in the file picks the base (default `mark1998`).

use anyhow::{anyhow, bail};
use postwarp_rtl::config::{EngineConfig, KNOBS, current_knob_name};
use std::path::Path;

/// Set knob `key` of `c` from a TOML value; the error says what was
/// expected (the caller names the file and the key).
pub fn set(c: &mut EngineConfig, key: &str, v: &toml::Value) -> Result<(), String> {
    let int = || v.as_integer().filter(|&n| n >= 0).map(|n| n as u64).ok_or("expected a non-negative integer");
    let u32v = || int().and_then(|n| u32::try_from(n).map_err(|_| "expected an integer below 2^32"));
    let real = || v.as_float().or_else(|| v.as_integer().map(|n| n as f64)).ok_or("expected a number");
    let boolean = || v.as_bool().ok_or("expected true or false");
    let text = || v.as_str().map(str::to_string).ok_or("expected a string in quotes");
    match key {
        "supersample" => c.supersample = u32v()?,
        "abuffer_fragments" => c.abuffer_fragments = u32v()?,
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
        "dram_backend" => c.dram_backend = text()?,
        "dram_config" => c.dram_config = text()?,
        "dram_address_mapping" => c.dram_address_mapping = text()?,
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
        "packer_pixels_per_cycle" => c.packer_pixels_per_cycle = u32v()?,
        "tile_prefetch_distance" => c.tile_prefetch_distance = u32v()?,
        "composite_miss_queue" => c.composite_miss_queue = u32v()?,
        "fallback_fill" => c.fallback_fill = boolean()?,
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
            let text = crate::io_util::read_text(path, "hardware configuration (TOML)")?;
            return from_text(&text, path);
        }
    };
    cfg.validate().map_err(|e| anyhow!("hardware configuration: {e}"))?;
    crate::dram::check(&cfg).map_err(|e| anyhow!("hardware configuration: {e}"))?;
    Ok(cfg)
}

/// The configuration in file `path`'s `text`, validated; errors name the file.
pub fn from_text(text: &str, path: &Path) -> anyhow::Result<EngineConfig> {
    let cfg = parse(text).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    cfg.validate().map_err(|e| anyhow!("{}: hardware configuration: {e}", path.display()))?;
    crate::dram::check(&cfg).map_err(|e| anyhow!("{}: hardware configuration: {e}", path.display()))?;
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
        if k == "preset" {
            continue;
        }
        let name = current_knob_name(k);
        if name != k && table.contains_key(name) {
            bail!("{k}: is the old name of `{name}`, which the file also sets; keep `{name}` only");
        }
        set(&mut c, name, v).map_err(|e| anyhow!("{k}: {e}"))?;
    }
    Ok(c)
}

/// The value of knob `key` of `c` (a name of [`KNOBS`]).
pub fn get(c: &EngineConfig, key: &str) -> Option<toml::Value> {
    use toml::Value as V;
    let i = |n: u64| V::Integer(i64::try_from(n).unwrap_or(i64::MAX));
    Some(match key {
        "supersample" => i(c.supersample.into()),
        "abuffer_fragments" => i(c.abuffer_fragments.into()),
        "kernel_limit" => i(c.kernel_limit.into()),
        "rects_per_cycle" => i(c.rects_per_cycle.into()),
        "transform_latency" => i(c.transform_latency.into()),
        "transform_throughput" => i(c.transform_throughput.into()),
        "tile_size" => i(c.tile_size.into()),
        "dest_cache_bytes" => i(c.dest_cache_bytes),
        "source_cache_bytes" => i(c.source_cache_bytes),
        "dram_peak_bytes_per_cycle" => i(c.dram_peak_bytes_per_cycle),
        "dram_latency_cycles" => i(c.dram_latency_cycles),
        "dram_burst_bytes" => i(c.dram_burst_bytes),
        "dram_max_outstanding" => i(c.dram_max_outstanding.into()),
        "dram_backend" => V::String(c.dram_backend.clone()),
        "dram_config" => V::String(c.dram_config.clone()),
        "dram_address_mapping" => V::String(c.dram_address_mapping.clone()),
        "clock_hz" => i(c.clock_hz),
        "target_frame_rate_hz" => V::Float(c.target_frame_rate_hz),
        "display_width" => i(c.display_width.into()),
        "display_height" => i(c.display_height.into()),
        "views" => i(c.views.into()),
        "references_per_frame" => i(c.references_per_frame.into()),
        "threshold" => V::Float(c.threshold),
        "slope_tol" => V::Float(c.slope_tol),
        "rel_tol" => V::Float(c.rel_tol),
        "better_margin" => V::Float(c.better_margin),
        "hole_far_distance" => i(c.hole_far_distance.into()),
        "hole_far_offset" => i(c.hole_far_offset.into()),
        "hole_max_distance" => i(c.hole_max_distance.into()),
        "hole_fill_per_cycle" => i(c.hole_fill_per_cycle.into()),
        "packer_pixels_per_cycle" => i(c.packer_pixels_per_cycle.into()),
        "tile_prefetch_distance" => i(c.tile_prefetch_distance.into()),
        "composite_miss_queue" => i(c.composite_miss_queue.into()),
        "fallback_fill" => V::Boolean(c.fallback_fill),
        _ => return None,
    })
}

fn json_of(v: &toml::Value) -> serde_json::Value {
    match v {
        toml::Value::Integer(n) => serde_json::Value::from(*n),
        toml::Value::Float(x) => serde_json::Value::from(*x),
        toml::Value::Boolean(b) => serde_json::Value::Bool(*b),
        toml::Value::String(t) => serde_json::Value::String(t.clone()),
        other => serde_json::Value::String(other.to_string()),
    }
}

/// Every knob as `{name: value}`, in [`KNOBS`] order, for `report.json`.
pub fn to_json_map(c: &EngineConfig) -> serde_json::Map<String, serde_json::Value> {
    KNOBS
        .iter()
        .map(|(name, _, _)| (name.to_string(), json_of(&get(c, name).expect("every knob has a value"))))
        .collect()
}

/// [`to_json_map`] as a value.
pub fn to_json(c: &EngineConfig) -> serde_json::Value {
    serde_json::Value::Object(to_json_map(c))
}

/// The configuration a `config` object of `report.json` describes (knobs
/// absent from it keep `mark1998`'s values).
pub fn from_json_map(m: &serde_json::Map<String, serde_json::Value>) -> anyhow::Result<EngineConfig> {
    let mut c = EngineConfig::default();
    for (k, v) in m {
        let t = match v {
            serde_json::Value::Number(n) if n.is_i64() || n.is_u64() => {
                toml::Value::Integer(n.as_i64().ok_or_else(|| anyhow!("{k}: {n} is too large"))?)
            }
            serde_json::Value::Number(n) => toml::Value::Float(n.as_f64().unwrap_or(f64::NAN)),
            serde_json::Value::Bool(b) => toml::Value::Boolean(*b),
            serde_json::Value::String(t) => toml::Value::String(t.clone()),
            other => bail!("{k}: {other} is not a number, a boolean or a string"),
        };
        set(&mut c, current_knob_name(k), &t).map_err(|e| anyhow!("{k}: {e}"))?;
    }
    Ok(c)
}

/// `c` as a configuration file `--config` reads back to `c`: every knob in
/// [`KNOBS`] order, each after a comment with its unit and description.
pub fn dump(c: &EngineConfig, header: &str) -> String {
    let mut s = String::new();
    for line in header.lines() {
        s.push_str(&format!("# {line}\n"));
    }
    s.push_str("# Every knob of the hardware model (docs/units.md); `postwarp simulate --config FILE` reads it.\n");
    for (name, unit, desc) in KNOBS {
        let v = get(c, name).expect("every knob has a value");
        s.push_str(&format!("\n# {desc} ({unit})\n{name} = {v}\n"));
    }
    s
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
    fn a_renamed_knob_loads_under_its_old_name_but_not_under_both() {
        assert_eq!(parse("max_fragments = 2").unwrap().abuffer_fragments, 2);
        assert_eq!(parse("abuffer_fragments = 1").unwrap().abuffer_fragments, 1);
        let e = parse("max_fragments = 2\nabuffer_fragments = 1").unwrap_err().to_string();
        assert!(e.contains("old name of `abuffer_fragments`"), "{e}");
        assert!(to_json_map(&EngineConfig::default()).keys().all(|k| k != "max_fragments"));
    }

    #[test]
    fn every_knob_is_settable_and_reported() {
        let mut c = EngineConfig::default();
        for (name, unit, _) in KNOBS {
            let v = match *unit {
                "bool" => toml::Value::Boolean(false),
                "ideal|dramsim3" | "name|path" | "text" => toml::Value::String("x".into()),
                _ => toml::Value::Integer(1),
            };
            set(&mut c, name, &v).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        assert!(!c.fallback_fill);
        assert_eq!(set(&mut c, "fallback_fill", &toml::Value::Integer(1)), Err("expected true or false".into()));
        let j = to_json(&EngineConfig::default());
        assert_eq!(j.as_object().unwrap().len(), KNOBS.len());
        assert_eq!(j["dest_cache_bytes"], 1_048_576);
        assert_eq!(j["threshold"], 1.4);
        assert_eq!(j["target_frame_rate_hz"], 30.0);
        assert_eq!(j["dram_backend"], "ideal");
        assert_eq!(set(&mut c, "dram_backend", &toml::Value::Integer(1)), Err("expected a string in quotes".into()));
    }

    #[test]
    fn string_knobs_read_and_round_trip() {
        let c = parse(
            "dram_backend = \"ideal\"\ndram_config = \"DDR4_8Gb_x8_3200\"\ndram_address_mapping = \"robabgrachco\"\n",
        )
        .unwrap();
        assert_eq!((c.dram_config.as_str(), c.dram_address_mapping.as_str()), ("DDR4_8Gb_x8_3200", "robabgrachco"));
        assert_eq!(from_json_map(&to_json_map(&c)).unwrap(), c);
        assert_eq!(parse(&dump(&c, "x")).unwrap(), c);
        let e = from_text("dram_backend = \"ramulator\"", Path::new("h.toml")).unwrap_err().to_string();
        assert!(e.contains("h.toml") && e.contains("dram_backend = \"ramulator\""), "{e}");
        let e = from_text("dram_backend = \"dramsim3\"\ndram_config = \"DDR9\"", Path::new("h.toml"));
        let e = e.unwrap_err().to_string();
        if crate::dram::HAS_DRAMSIM3 {
            assert!(e.contains("dram_config = \"DDR9\""), "{e}");
        } else {
            assert!(e.contains("--features dramsim3"), "{e}");
        }
    }

    #[test]
    fn a_dumped_configuration_reads_back_exactly_with_every_knob() {
        for preset in postwarp_rtl::config::PRESETS {
            let mut c = EngineConfig::preset(preset).unwrap();
            c.target_frame_rate_hz = 72.5;
            c.rel_tol = 0.1 + 0.2;
            let text = dump(&c, "made by a test\nsecond line");
            assert!(text.starts_with("# made by a test\n# second line\n"), "{text}");
            for (name, unit, _) in KNOBS {
                assert!(text.contains(&format!("\n{name} = ")), "{name} missing");
                assert!(text.contains(&format!("({unit})\n{name} = ")), "{name}: no unit comment");
            }
            assert_eq!(parse(&text).unwrap(), c, "{preset}");
            assert_eq!(from_json_map(&to_json_map(&c)).unwrap(), c);
        }
    }
}
