//! The docs' knob tables, generated from the knob tables: the hardware
//! model's in `docs/units.md` (every preset's value, the valid range, and
//! the rules between knobs) and the golden model's in `docs/golden.md`.
//! `tests/knob_table.rs` fails when a page differs and rewrites it with
//! `UPDATE_DOCS=1` (through [`crate::report::docs::splice`], as
//! `docs/report.md`'s key lists are).

use crate::golden::config::{GoldenConfig, KNOBS as GOLDEN_KNOBS};
use crate::run::hw_config::{fixed_golden_knobs, shared_knobs};
use postwarp_rtl::config::{CROSS_RULES, EngineConfig, KNOBS as HW_KNOBS, PRESETS};
use postwarp_rtl::knob::{Knob, KnobValue, Range};

/// Marks around the generated part of `docs/units.md`.
pub const HW_BEGIN: &str = "<!-- BEGIN knob table: generated from rtl-model/src/config.rs by tests/knob_table.rs (UPDATE_DOCS=1 cargo test --test suite knob_table::) -->";
/// End mark.
pub const HW_END: &str = "<!-- END knob table -->";
/// Marks around the generated part of `docs/golden.md`.
pub const GOLDEN_BEGIN: &str = "<!-- BEGIN knob table: generated from src/golden/config.rs by tests/knob_table.rs (UPDATE_DOCS=1 cargo test --test suite knob_table::) -->";
/// End mark.
pub const GOLDEN_END: &str = "<!-- END knob table -->";

/// `|` escaped for a Markdown table cell.
fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

/// An integer, powers of two from 2³⁰ on as powers.
fn int(n: u64) -> String {
    const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    if n.is_power_of_two() && n >= 1 << 30 {
        let e: String = n.trailing_zeros().to_string().chars().map(|d| SUP[d as usize - '0' as usize]).collect();
        return format!("2{e}");
    }
    n.to_string()
}

/// A value as the docs write it (bytes with their KiB or MiB).
fn value<C>(k: &Knob<C>, v: &KnobValue) -> String {
    match v {
        KnobValue::Int(n) if k.unit == "bytes" && *n >= 1 << 20 && n % (1 << 20) == 0 => {
            format!("{n} ({} MiB)", n >> 20)
        }
        KnobValue::Int(n) if k.unit == "bytes" && *n >= 1 << 10 && n % (1 << 10) == 0 => {
            format!("{n} ({} KiB)", n >> 10)
        }
        KnobValue::Int(n) => n.to_string(),
        KnobValue::Real(x) => format!("{x:?}"),
        other => other.to_string(),
    }
}

/// The valid values of a knob, for a table cell.
fn valid<C>(k: &Knob<C>) -> String {
    match k.range {
        Range::Int { min, max } => format!("{}–{}", int(min), int(max)),
        Range::PowerOfTwo { min, max } => format!("a power of two, {}–{}", int(min), int(max)),
        Range::Real { min, min_open, max } => {
            let lo = if min_open { format!("> {min}") } else { format!("≥ {min}") };
            match (min_open, max == f64::INFINITY) {
                (false, false) => format!("{min}–{max}"),
                (_, true) => lo,
                (true, false) => format!("{lo}, ≤ {max}"),
            }
        }
        Range::Bool => "true, false".into(),
        Range::Choice(names) => postwarp_rtl::knob::quoted_list(names),
        Range::Text { valid, .. } => valid.into(),
    }
}

/// The generated part of `docs/units.md`: one row per hardware knob with
/// each preset's value, then the rules between knobs.
pub fn hardware() -> String {
    let presets: Vec<EngineConfig> = PRESETS.iter().map(|p| EngineConfig::preset(p).expect("presets exist")).collect();
    let mut s = String::from("| knob | unit |");
    for (i, p) in PRESETS.iter().enumerate() {
        s.push_str(&format!(" {p}{} |", if i == 0 { " (default)" } else { "" }));
    }
    s.push_str(" valid | meaning |\n|---|---|");
    s.push_str(&"---|".repeat(PRESETS.len()));
    s.push_str("---|---|\n");
    for k in HW_KNOBS {
        s.push_str(&format!("| `{}` | {} |", k.name, cell(k.unit)));
        for c in &presets {
            s.push_str(&format!(" {} |", cell(&value(k, &(k.get)(c)))));
        }
        s.push_str(&format!(" {} | {} |\n", cell(&valid(k)), cell(k.description)));
    }
    s.push_str("\nRules between knobs (`CROSS_RULES`), checked after every knob's own range, in this order:\n\n");
    for r in CROSS_RULES {
        s.push_str(&format!("- `{}`: {}.\n", r.name, r.rule));
    }
    s.push_str(
        "\nThe functional knobs drive the golden model too (`src/run/hw_config.rs`, `golden_config_for`): \
         the knobs both tables have are copied by name, the others are fixed.\n\n\
         | golden knob | set to |\n|---|---|\n",
    );
    let shared: Vec<String> = shared_knobs().map(|n| format!("`{n}`")).collect();
    s.push_str(&format!("| {} | the same hardware knobs |\n", shared.join(", ")));
    for (name, v) in fixed_golden_knobs() {
        let v = match v {
            KnobValue::Text(t) => t,
            other => other.to_string(),
        };
        s.push_str(&format!("| `{name}` | `{v}` |\n"));
    }
    s
}

/// The generated part of `docs/golden.md`: one row per golden knob.
pub fn golden() -> String {
    let d = GoldenConfig::default();
    let mut s = String::from("| key | unit | default | valid | meaning |\n|---|---|---|---|---|\n");
    for k in GOLDEN_KNOBS {
        s.push_str(&format!(
            "| `{}` | {} | {} | {} | {} |\n",
            k.name,
            cell(k.unit),
            cell(&value(k, &(k.get)(&d))),
            cell(&valid(k)),
            cell(k.description)
        ));
    }
    s
}

/// `page` (`docs/units.md` if `hardware_page`, else `docs/golden.md`) with
/// its generated part replaced, or `None` if the marks are missing.
pub fn regenerate(page: &str, hardware_page: bool) -> Option<String> {
    if hardware_page {
        crate::report::docs::splice(page, HW_BEGIN, HW_END, &hardware())
    } else {
        crate::report::docs::splice(page, GOLDEN_BEGIN, GOLDEN_END, &golden())
    }
}
