//! The `[golden]` and `[hardware]` tables of a sweep specification: which
//! keys exist, how one value is checked, how a combination of values
//! becomes a [`GoldenConfig`] or an [`EngineConfig`], and the
//! `results.csv` column (with its unit) of each knob. Keys, units and
//! values come from the engines' knob tables (`crate::knobs`).
//!
//! Rules:
//! 1. `[golden]` takes every golden-model knob (`docs/golden.md`) except
//!    `reconstruction` (the method: `mark-aa` or `mark-general`) and
//!    `hole_fill` (the `hole_fills` axis: `none` or `epipolar`).
//! 2. Golden knobs apply to methods that accept them
//!    ([`Reconstruction::with_golden_config`](crate::methods::Reconstruction::with_golden_config))
//!    and, where the hardware has the same knob ([`shared_knobs`]),
//!    to `hardware` as functional knobs. `over_limit` and `warp_order` do
//!    not apply to `hardware` (it clips and warps in reverse order).
//! 3. `[hardware]` takes `preset` and every hardware knob
//!    (`docs/units.md`) except `supersample`, which is the trace's.
//! 4. A functional knob is set in `[golden]` or in `[hardware]`, not both.

use crate::golden::config::{GoldenConfig, KNOBS as GOLDEN_KNOBS};
use crate::run::hw_config::shared_knobs;
use crate::run::hw_config_toml;
use postwarp_rtl::config::{EngineConfig, KNOBS as HW_KNOBS, PRESETS};

/// The hardware knob a golden knob sets, if any: the same name, when both
/// engines have it ([`shared_knobs`]).
pub fn hardware_name(golden: &str) -> Option<&'static str> {
    shared_knobs().find(|n| *n == golden)
}

/// Keys `[golden]` accepts, in canonical order.
pub fn golden_keys() -> impl Iterator<Item = &'static str> {
    GOLDEN_KNOBS.iter().map(|k| k.name).filter(|k| !matches!(*k, "reconstruction" | "hole_fill"))
}

/// Keys `[hardware]` accepts, in canonical order (`preset` first).
pub fn hardware_keys() -> impl Iterator<Item = &'static str> {
    std::iter::once("preset").chain(HW_KNOBS.iter().map(|k| k.name).filter(|k| *k != "supersample"))
}

/// Why a `[golden]` key is refused, or `None` if it is a knob.
pub fn golden_key_error(key: &str) -> Option<String> {
    match key {
        "reconstruction" => Some("is the method: list `mark-aa` or `mark-general` in `methods`".into()),
        "hole_fill" => Some("is the hole fill: use the `hole_fills` axis (`none`, `epipolar`, `default`)".into()),
        k if golden_keys().any(|g| g == k) => None,
        _ => Some(format!("unknown golden knob (expected one of: {})", golden_keys().collect::<Vec<_>>().join(", "))),
    }
}

/// Why a `[hardware]` key is refused, or `None` if it is a knob.
pub fn hardware_key_error(key: &str) -> Option<String> {
    match key {
        "supersample" => Some("comes from the trace: set `supersample` on a generated trace instead".into()),
        k if hardware_keys().any(|h| h == k) => None,
        _ => {
            Some(format!("unknown hardware knob (expected one of: {})", hardware_keys().collect::<Vec<_>>().join(", ")))
        }
    }
}

/// A golden configuration from `(knob, value)` pairs over the defaults,
/// validated.
pub fn golden_config(values: &[(&str, &toml::Value)]) -> Result<GoldenConfig, String> {
    let mut cfg = GoldenConfig::default();
    for (k, v) in values {
        crate::knobs::set_toml(GOLDEN_KNOBS, &mut cfg, k, v)?;
    }
    cfg.validate()?;
    Ok(cfg)
}

/// Check one `[golden]` value.
pub fn check_golden(key: &str, v: &toml::Value) -> Result<(), String> {
    golden_config(&[(key, v)]).map(|_| ())
}

/// Check one `[hardware]` value's type (ranges that depend on other knobs
/// are checked per combination by [`hardware_config`]).
pub fn check_hardware(key: &str, v: &toml::Value) -> Result<(), String> {
    if key == "preset" {
        let name = v.as_str().ok_or_else(|| format!("expected a preset name in quotes ({})", PRESETS.join(", ")))?;
        return EngineConfig::preset(name).map(|_| ());
    }
    let mut c = EngineConfig::default();
    hw_config_toml::set(&mut c, key, v)?;
    Ok(())
}

/// The hardware configuration of one point: the preset (default
/// `mark1998`), then the `[hardware]` knobs, then the golden knobs the
/// hardware has ([`shared_knobs`]), then the trace's `supersample`;
/// validated.
pub fn hardware_config(
    preset: Option<&str>,
    hardware: &[(&str, &toml::Value)],
    golden: &[(&str, &toml::Value)],
    supersample: u32,
) -> Result<EngineConfig, String> {
    let mut c = EngineConfig::preset(preset.unwrap_or("mark1998"))?;
    for (k, v) in hardware {
        hw_config_toml::set(&mut c, k, v).map_err(|e| format!("{k}: {e}"))?;
    }
    for (k, v) in golden {
        if let Some(h) = hardware_name(k) {
            hw_config_toml::set(&mut c, h, v).map_err(|e| format!("{k}: {e}"))?;
        }
    }
    c.supersample = supersample;
    c.validate()?;
    crate::dram::check(&c)?;
    Ok(c)
}

/// The `results.csv` column of a knob: its name, with its unit appended
/// unless the name already says it or the knob has none (`1`, `bool`,
/// `text`, a choice `a|b`).
pub fn column(knob: &str, unit: &str) -> String {
    if unit == "1" || unit == "bool" || unit == "text" || unit.contains('|') {
        return knob.to_string();
    }
    let slug = unit.to_lowercase().replace("1/z", "inv_z").replace('/', "_per_").replace(' ', "_");
    if knob.ends_with(&slug) || knob.split('_').any(|w| w == slug) || (knob.contains("_per_") && slug.contains("_per_"))
    {
        return knob.to_string();
    }
    // `abuffer_fragments` + `fragments_per_pixel` = `abuffer_fragments_per_pixel`.
    if let Some((first, rest)) = slug.split_once("_per_") {
        if knob.ends_with(first) {
            return format!("{knob}_per_{rest}");
        }
    }
    format!("{knob}_{slug}")
}

/// Unit of a golden knob.
pub fn golden_unit(key: &str) -> &'static str {
    postwarp_rtl::knob::find(GOLDEN_KNOBS, key).map_or("", |k| k.unit)
}

/// Unit of a hardware knob (`preset`: a name).
pub fn hardware_unit(key: &str) -> &'static str {
    if key == "preset" {
        return postwarp_rtl::config::PRESETS_UNIT;
    }
    postwarp_rtl::knob::find(HW_KNOBS, key).map_or("", |k| k.unit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_carry_units_once() {
        let c = |k: &str, u: &str| column(k, u);
        assert_eq!(c("threshold", "ratio of E"), "threshold_ratio_of_e");
        assert_eq!(c("kernel_limit", "samples"), "kernel_limit_samples");
        assert_eq!(c("abuffer_fragments", "fragments/pixel"), "abuffer_fragments_per_pixel");
        assert_eq!(c("abuffer_fragments", "fragments/pixel"), "abuffer_fragments_per_pixel");
        assert_eq!(c("rel_tol", "fraction of 1/Z"), "rel_tol_fraction_of_inv_z");
        assert_eq!(c("dest_cache_bytes", "bytes"), "dest_cache_bytes");
        assert_eq!(c("clock_hz", "Hz"), "clock_hz");
        assert_eq!(c("rects_per_cycle", "rectangles/cycle"), "rects_per_cycle");
        assert_eq!(c("references_per_frame", "references"), "references_per_frame");
        assert_eq!(c("views", "views"), "views");
        assert_eq!(c("transform_latency", "cycles"), "transform_latency_cycles");
        assert_eq!(c("over_limit", "clip|allow"), "over_limit");
        assert_eq!(c("slope_tol", "1"), "slope_tol");
        assert_eq!(c("dram_backend", "ideal|dramsim3"), "dram_backend");
        assert_eq!(c("dram_address_mapping", "text"), "dram_address_mapping");
        // Every knob gets a distinct column.
        let mut all: Vec<String> = golden_keys().map(|k| column(k, golden_unit(k))).collect();
        all.extend(hardware_keys().map(|k| column(k, hardware_unit(k))));
        let n = all.len();
        all.sort();
        all.dedup();
        // Golden knobs the hardware shares under the same name share a column.
        let shared = shared_knobs().count();
        assert_eq!(all.len(), n - shared);
    }

    #[test]
    fn golden_values_are_checked_by_type_and_range() {
        assert!(check_golden("threshold", &toml::Value::Float(2.0)).is_ok());
        let e = check_golden("threshold", &toml::Value::String("x".into())).unwrap_err();
        assert!(e.starts_with("expected"), "{e}");
        let e = check_golden("threshold", &toml::Value::Float(-1.0)).unwrap_err();
        assert!(e.contains("expected 0.01 to 100"), "{e}");
        assert!(check_golden("over_limit", &toml::Value::String("allow".into())).is_ok());
        assert!(check_golden("over_limit", &toml::Value::String("sometimes".into())).is_err());
        assert!(golden_key_error("hole_fill").unwrap().contains("hole_fills"));
        assert!(golden_key_error("threshold").is_none());
        assert!(golden_key_error("treshold").unwrap().contains("unknown"));
    }

    #[test]
    fn hardware_configs_take_preset_knobs_golden_knobs_and_the_trace_supersample() {
        let t16 = toml::Value::Integer(16);
        let thr = toml::Value::Float(2.0);
        let frag = toml::Value::Integer(2);
        let over = toml::Value::String("allow".into());
        let c = hardware_config(
            Some("hmd2026"),
            &[("tile_size", &t16)],
            &[("threshold", &thr), ("abuffer_fragments", &frag), ("over_limit", &over)],
            1,
        )
        .unwrap();
        assert_eq!((c.tile_size, c.threshold, c.abuffer_fragments, c.supersample, c.views), (16, 2.0, 2, 1, 2));
        let e = hardware_config(None, &[("tile_size", &toml::Value::Integer(2))], &[], 2).unwrap_err();
        assert!(e.starts_with("kernel_limit"), "{e}");
        assert!(hardware_key_error("supersample").unwrap().contains("trace"));
        assert!(check_hardware("preset", &toml::Value::String("nope".into())).unwrap_err().contains("mark1998"));
        assert!(check_hardware("dest_cache_bytes", &toml::Value::Float(1.5)).is_err());
    }
}
