//! The knob tables of both engines (`postwarp_rtl::config::KNOBS`,
//! `postwarp::golden::config::KNOBS`) against what they promise: every
//! default is inside its own range, a value just outside a range is refused
//! with a message naming the knob, every knob set by name reads back by
//! name, through TOML and JSON too, the golden choices' command-line names
//! are the table's, and the docs' knob tables are the generated ones
//! (`UPDATE_DOCS=1 cargo test --test suite knob_table::` rewrites them).

use postwarp::golden::config::{GoldenConfig, KNOBS as GOLDEN_KNOBS, OverLimit, Reconstruction, WarpOrder};
use postwarp::knobs::docs;
use postwarp_rtl::config::{EngineConfig, KNOBS as HW_KNOBS, PRESETS};
use postwarp_rtl::knob::{Knob, KnobValue, Range};
use std::path::PathBuf;

/// Values just outside `k`'s range that its type can hold (`u32` knobs
/// above `u32::MAX` are refused by `set`, tested apart).
fn outside<C>(k: &Knob<C>) -> Vec<KnobValue> {
    let mut v = Vec::new();
    match k.range {
        Range::Int { min, max } | Range::PowerOfTwo { min, max } => {
            if min > 0 {
                v.push(KnobValue::Int(min - 1));
            }
            v.push(KnobValue::Int(max + 1));
            if matches!(k.range, Range::PowerOfTwo { .. }) && max > 2 {
                v.push(KnobValue::Int(max - 1));
            }
        }
        Range::Real { min, min_open, max } => {
            let lo = if min_open { min } else { min - min.abs().max(1.0) * 1e-9 };
            v.push(KnobValue::Real(lo));
            v.push(KnobValue::Real(if max.is_finite() { max + max.abs().max(1.0) * 1e-9 } else { f64::INFINITY }));
            v.push(KnobValue::Real(f64::NAN));
        }
        Range::Choice(_) => v.push(KnobValue::Text("nonsense".into())),
        Range::Text { .. } | Range::Bool => {}
    }
    v
}

/// One value inside `k`'s range, different from `now` where the range
/// allows it.
fn other_inside<C>(k: &Knob<C>, now: &KnobValue) -> KnobValue {
    match (k.range, now) {
        (Range::Int { min, max }, KnobValue::Int(n)) => KnobValue::Int(if *n < max { n + 1 } else { min }),
        (Range::PowerOfTwo { min, max }, KnobValue::Int(n)) => KnobValue::Int(if n * 2 <= max { n * 2 } else { min }),
        (Range::Real { min, max, .. }, KnobValue::Real(x)) => {
            let y = (x + 0.5).min(max);
            KnobValue::Real(if y != *x { y } else { (min + max) / 2.0 })
        }
        (Range::Bool, KnobValue::Bool(b)) => KnobValue::Bool(!b),
        (Range::Choice(names), KnobValue::Text(s)) => {
            KnobValue::Text(names.iter().find(|n| **n != s).unwrap_or(&names[0]).to_string())
        }
        (_, v) => v.clone(),
    }
}

fn each_table_checks<C: Default + Clone + PartialEq + std::fmt::Debug>(table: &'static [Knob<C>], what: &str) {
    let d = C::default();
    for k in table {
        assert!(!k.unit.is_empty() && !k.description.is_empty(), "{what} {}: no unit or description", k.name);
        // The default is inside its own range.
        assert_eq!(k.check(&(k.get)(&d)), Ok(()), "{what} {}: default outside its range", k.name);
        // Just outside: refused, naming the knob, in check and through set + check.
        for v in outside(k) {
            let e = k.check(&v).expect_err(&format!("{what} {} accepted {v}", k.name));
            assert!(e.starts_with(&format!("{} = ", k.name)), "{what}: {e}");
            let mut c = d.clone();
            match (k.set)(&mut c, v.clone()) {
                Ok(()) => {
                    let e = k.check(&(k.get)(&c)).expect_err(&format!("{what} {} stored {v} and passed", k.name));
                    assert!(e.starts_with(&format!("{} = ", k.name)), "{what}: {e}");
                }
                Err(e) => assert!(e.starts_with("expected"), "{what} {}: {e}", k.name),
            }
        }
        // Set by name, get by name.
        let v = other_inside(k, &(k.get)(&d));
        let mut c = d.clone();
        postwarp_rtl::knob::set_by_name(table, &mut c, k.name, v.clone()).unwrap();
        assert_eq!(postwarp_rtl::knob::get_by_name(table, &c, k.name), Some(v.clone()), "{what} {}", k.name);
        assert_eq!(k.check(&v), Ok(()), "{what} {}: {v}", k.name);
        // And through TOML and JSON, the way files are read.
        let mut t = d.clone();
        postwarp::knobs::set_toml(table, &mut t, k.name, &postwarp::knobs::to_toml(&v)).unwrap();
        assert_eq!(t, c, "{what} {}: TOML", k.name);
        let mut j = d.clone();
        postwarp::knobs::set_json(table, &mut j, k.name, &postwarp::knobs::to_json(&v)).unwrap();
        assert_eq!(j, c, "{what} {}: JSON", k.name);
    }
    let e = postwarp_rtl::knob::set_by_name(table, &mut d.clone(), "no_such_knob", KnobValue::Int(1)).unwrap_err();
    assert!(e.starts_with("unknown knob (known: "), "{e}");
}

#[test]
fn hardware_knobs_keep_their_ranges_and_round_trip() {
    each_table_checks(HW_KNOBS, "hardware");
    for p in PRESETS {
        assert_eq!(EngineConfig::preset(p).unwrap().validate(), Ok(()), "{p}");
    }
}

#[test]
fn golden_knobs_keep_their_ranges_and_round_trip() {
    each_table_checks(GOLDEN_KNOBS, "golden");
    assert_eq!(GoldenConfig::default().validate(), Ok(()));
}

#[test]
fn u32_knobs_refuse_values_past_32_bits_naming_the_knob() {
    let big = toml::Value::Integer(1 << 32);
    let mut c = EngineConfig::default();
    let e = postwarp::run::hw_config_toml::set(&mut c, "tile_size", &big).unwrap_err();
    assert_eq!(e, "expected an integer below 2^32");
    let e = postwarp::run::hw_config_toml::parse("tile_size = 4294967296").unwrap_err().to_string();
    assert!(e.starts_with("tile_size: expected an integer below 2^32"), "{e}");
    let e = GoldenConfig::from_toml("hole_far_offset = 4294967296").unwrap_err();
    assert!(e.starts_with("hole_far_offset: expected an integer below 2^32"), "{e}");
}

#[test]
fn golden_files_are_read_through_the_table() {
    let c = GoldenConfig::from_toml("threshold = 2\nover_limit = \"allow\"\nwarp_order = \"forward\"\n").unwrap();
    assert_eq!((c.threshold, c.over_limit, c.warp_order), (2.0, OverLimit::Allow, WarpOrder::Forward));
    let e = GoldenConfig::from_toml("treshold = 2").unwrap_err();
    assert!(e.starts_with("treshold: unknown knob (known: over_limit, "), "{e}");
    let e = GoldenConfig::from_toml("reconstruction = \"mesh\"").unwrap_err();
    assert_eq!(e, "reconstruction: expected one of \"aa-rect\", \"general\", not \"mesh\"");
    let e = GoldenConfig::from_toml("kernel_limit = 1.5").unwrap_err();
    assert_eq!(e, "kernel_limit: expected a non-negative integer");
    // The serde form is the table's object, and reads back.
    let j = serde_json::to_value(&c).unwrap();
    let keys: Vec<&str> = j.as_object().unwrap().keys().map(String::as_str).collect();
    assert_eq!(keys, GOLDEN_KNOBS.iter().map(|k| k.name).collect::<Vec<_>>());
    assert_eq!((j["threshold"].clone(), j["over_limit"].clone()), (serde_json::json!(2.0), serde_json::json!("allow")));
    assert_eq!(j["kernel_limit"], serde_json::json!(4));
    assert_eq!(serde_json::from_value::<GoldenConfig>(j).unwrap(), c);
    assert!(serde_json::from_value::<GoldenConfig>(serde_json::json!({"colour": 1})).is_err());
}

/// The choices' command-line names (clap, from the variant names) are the
/// table's.
#[test]
fn golden_choices_have_the_same_names_on_the_command_line() {
    use clap::ValueEnum;
    fn names<T: ValueEnum>() -> Vec<String> {
        T::value_variants().iter().map(|v| v.to_possible_value().unwrap().get_name().to_string()).collect()
    }
    assert_eq!(names::<OverLimit>(), OverLimit::NAMES);
    assert_eq!(names::<WarpOrder>(), WarpOrder::NAMES);
    assert_eq!(names::<Reconstruction>(), Reconstruction::NAMES);
    assert_eq!(OverLimit::UNIT, "clip|allow");
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn check_page(file: &str, hardware: bool) {
    let path = root().join(file);
    let page = std::fs::read_to_string(&path).unwrap();
    let want = docs::regenerate(&page, hardware).unwrap_or_else(|| panic!("{file} lacks the generated-part marks"));
    if std::env::var_os("UPDATE_DOCS").is_some() {
        std::fs::write(&path, &want).unwrap();
        return;
    }
    assert!(
        page == want,
        "{file}'s knob table differs from the knob table; run UPDATE_DOCS=1 cargo test --test suite knob_table::"
    );
}

#[test]
fn the_docs_knob_tables_are_the_generated_ones() {
    check_page("docs/units.md", true);
    check_page("docs/golden.md", false);
    // Every knob has its row.
    let units = docs::hardware();
    assert!(HW_KNOBS.iter().all(|k| units.contains(&format!("| `{}` |", k.name))));
    let golden = docs::golden();
    assert!(GOLDEN_KNOBS.iter().all(|k| golden.contains(&format!("| `{}` |", k.name))));
}

#[test]
fn the_golden_configuration_of_a_hardware_one_copies_every_shared_knob_and_fixes_the_rest() {
    use postwarp::run::hw_config::{golden_config_for, shared_knobs};
    use postwarp_rtl::knob::{find, get_by_name, set_by_name};
    let shared: Vec<&str> = shared_knobs().collect();
    // The knobs both engines have, by name (a knob added to both tables
    // joins this list; one dropped from either leaves it).
    assert_eq!(
        shared,
        [
            "kernel_limit",
            "abuffer_fragments",
            "threshold",
            "slope_tol",
            "rel_tol",
            "better_margin",
            "hole_far_distance",
            "hole_far_offset",
            "hole_max_distance",
            "fallback_fill",
            "arith",
            "q_ref_coord",
            "q_ref_inv_z",
            "q_numerator",
            "q_denominator",
            "q_reciprocal",
            "recip_table_bits",
            "recip_iterations",
            "q_position",
            "q_inv_z",
            "q_slope",
            "q_corner",
            "q_colour",
            "q_hole_weight"
        ]
    );
    for name in &shared {
        let mut hw = EngineConfig::default();
        let k = find(HW_KNOBS, name).expect("a hardware knob");
        let v = other_inside(k, &(k.get)(&hw));
        set_by_name(HW_KNOBS, &mut hw, name, v.clone()).expect("a value of the knob's type");
        let g = golden_config_for(&hw);
        assert_eq!(get_by_name(GOLDEN_KNOBS, &g, name), Some(v), "{name} copied");
        let untouched = golden_config_for(&EngineConfig::default());
        for other in shared.iter().filter(|o| *o != name) {
            assert_eq!(get_by_name(GOLDEN_KNOBS, &g, other), get_by_name(GOLDEN_KNOBS, &untouched, other), "{other}");
        }
    }
    // One declaration (`shared_knobs.rs`): the same unit, description,
    // range and default in both tables.
    for name in &shared {
        let (h, g) = (find(HW_KNOBS, name).unwrap(), find(GOLDEN_KNOBS, name).unwrap());
        assert_eq!((h.unit, h.description), (g.unit, g.description), "{name}");
        assert_eq!(format!("{:?}", h.range), format!("{:?}", g.range), "{name}");
        assert_eq!((h.get)(&EngineConfig::default()), (g.get)(&GoldenConfig::default()), "{name} default");
    }
    let g = golden_config_for(&EngineConfig::default());
    assert_eq!(
        (g.over_limit, g.hole_fill, g.warp_order, g.reconstruction),
        (OverLimit::Clip, true, WarpOrder::Reverse, Reconstruction::AaRect)
    );
}
