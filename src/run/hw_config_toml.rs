//! Hardware configuration files: TOML with the knob names of
//! `postwarp_rtl::config::KNOBS` as keys, over a preset; and the `config`
//! object of `report.json`. Values go through the knob table generically
//! (`crate::knobs`), so a new knob needs no code here.
//!
//! Rules: every key optional; an unknown key, a value of the wrong type or
//! an invalid value is rejected with a message naming the file and the knob;
//! `preset = "NAME"` in the file picks the base (default `mark1998`); a
//! renamed knob ([`RENAMED_KNOBS`](postwarp_rtl::config::RENAMED_KNOBS))
//! loads under its old name, but not under both.

use anyhow::{anyhow, bail};
use postwarp_rtl::config::{EngineConfig, KNOBS, current_knob_name};
use postwarp_rtl::knob::get_by_name;
use std::path::Path;

/// Set knob `key` of `c` from a TOML value; the error says what was
/// expected (the caller names the file and the key).
pub fn set(c: &mut EngineConfig, key: &str, v: &toml::Value) -> Result<(), String> {
    crate::knobs::set_toml(KNOBS, c, key, v)
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
    get_by_name(KNOBS, c, key).map(|v| crate::knobs::to_toml(&v))
}

/// Every knob as `{name: value}`, in [`KNOBS`] order, for `report.json`.
pub fn to_json_map(c: &EngineConfig) -> serde_json::Map<String, serde_json::Value> {
    crate::knobs::to_json_map(KNOBS, c)
}

/// [`to_json_map`] as a value.
pub fn to_json(c: &EngineConfig) -> serde_json::Value {
    serde_json::Value::Object(to_json_map(c))
}

/// The configuration a `config` object of `report.json` describes (knobs
/// absent from it keep `mark1998`'s values; old names are read as the
/// current ones), refused unless it validates: a run never writes an
/// invalid one, and the rates and budget made from it would divide by
/// zero (`supersample = 0`).
pub fn from_json_map(m: &serde_json::Map<String, serde_json::Value>) -> anyhow::Result<EngineConfig> {
    let mut c = EngineConfig::default();
    for (k, v) in m {
        crate::knobs::set_json(KNOBS, &mut c, current_knob_name(k), v).map_err(|e| anyhow!("{k}: {e}"))?;
    }
    c.validate().map_err(|e| anyhow!("{e}"))?;
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
    for k in KNOBS {
        let v = crate::knobs::to_toml(&(k.get)(c));
        s.push_str(&format!("\n# {} ({})\n{} = {v}\n", k.description, k.unit, k.name));
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
        for k in KNOBS {
            let (name, unit) = (k.name, k.unit);
            let v = match unit {
                "bool" => toml::Value::Boolean(false),
                "ideal|dramsim3" | "name|path" | "text" | "float|fixed" | "Q format" => toml::Value::String("x".into()),
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
            for k in KNOBS {
                let (name, unit) = (k.name, k.unit);
                assert!(text.contains(&format!("\n{name} = ")), "{name} missing");
                assert!(text.contains(&format!("({unit})\n{name} = ")), "{name}: no unit comment");
            }
            assert_eq!(parse(&text).unwrap(), c, "{preset}");
            assert_eq!(from_json_map(&to_json_map(&c)).unwrap(), c);
        }
    }

    #[test]
    fn a_report_config_that_does_not_validate_is_refused_with_its_knob() {
        let mut m = to_json_map(&EngineConfig::default());
        m.insert("supersample".into(), 0.into());
        let e = from_json_map(&m).unwrap_err().to_string();
        assert!(e.contains("supersample"), "{e}");
        m.insert("supersample".into(), 2.into());
        assert_eq!(from_json_map(&m).unwrap(), EngineConfig::default());
    }
}
