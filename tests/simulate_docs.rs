//! The hardware model's documentation against what the code produces:
//! every knob of `postwarp_rtl::config::KNOBS` is in `docs/units.md`.
//! (Every `report.json` key is checked against its described unit, and
//! `docs/report.md`'s key lists against the tables, by
//! `tests/report_docs.rs`; the whole knob table, generated from `KNOBS`,
//! by `tests/knob_table.rs`.)

use postwarp_rtl::config::KNOBS;
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn every_knob_is_documented() {
    let doc = std::fs::read_to_string(root().join("docs/units.md")).unwrap();
    for k in KNOBS {
        let (name, unit) = (k.name, k.unit);
        // A choice `a|b` is written `a\|b` inside a Markdown table.
        let cell = unit.replace('|', "\\|");
        assert!(doc.contains(&format!("| `{name}` | {cell} |")), "docs/units.md lacks the knob row `{name}` ({unit})");
    }
}
