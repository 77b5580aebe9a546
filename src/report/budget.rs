//! `budget` of `report.json` (`postwarp simulate`): the SRAM and arithmetic
//! budget of the configuration (`postwarp_rtl::budget`, `docs/budget.md`)
//! as JSON, and its key table. The units and descriptions are the ones
//! declared once in `postwarp_rtl::budget` (`STORE_FIELDS`, `OP_FIELDS`,
//! `DATAPATH_FIELDS`, `TOTAL_FIELDS`).

use super::keys::{KeyDoc, Reduce, Shape, nested, scalar};
use postwarp_rtl::budget::{
    AREA_CONSTANTS, Budget, DATAPATH_FIELDS, OP_FIELDS, Ops, STORE_FIELDS, Sizes, TOTAL_FIELDS,
};
use serde_json::{Value, json};
use std::fmt::Write as _;

fn ops(o: &Ops) -> Value {
    json!({"mul": o.mul, "add": o.add, "recip": o.recip, "sqrt": o.sqrt, "cmp": o.cmp})
}

/// `b` as the report's `budget` object.
pub fn to_json(b: &Budget) -> Value {
    let t = &b.totals;
    json!({
        "process_node": b.process_node,
        "derived_width_samples": b.sizes.derived.0,
        "derived_height_samples": b.sizes.derived.1,
        "reference_line_samples": b.sizes.reference_line,
        "stores": b.stores.iter().map(|s| json!({
            "name": s.name,
            "unit": s.unit,
            "kind": s.kind.name(),
            "entries": s.entries,
            "bits_per_entry": s.bits_per_entry,
            "bytes": s.bytes,
            "area_mm2": s.area_mm2,
            "holds": s.holds,
        })).collect::<Vec<_>>(),
        "datapaths": b.datapaths.iter().map(|d| json!({
            "unit": d.unit,
            "function": d.function,
            "item": d.item,
            "items_per_cycle": d.items_per_cycle,
            "format": d.format.name(),
            "per_item": ops(&d.per_item),
            "instances": ops(&d.instances),
            "area_mm2": d.area_mm2,
        })).collect::<Vec<_>>(),
        "totals": {
            "store_bytes": t.store_bytes,
            "sram_bytes": t.sram_bytes,
            "register_bytes": t.register_bytes,
            "instances": ops(&t.instances),
            "sram_area_mm2": t.sram_area_mm2,
            "register_area_mm2": t.register_area_mm2,
            "logic_area_mm2": t.logic_area_mm2,
            "area_mm2": t.area_mm2,
        },
        "area_constants": AREA_CONSTANTS.iter().map(|(name, value, unit, source)| json!({
            "name": name, "value": value, "unit": unit, "source": source,
        })).collect::<Vec<_>>(),
    })
}

/// The destination tile cache's bytes per sample from a report's
/// `budget`: its per-sample planes' `bits_per_entry` (stores named
/// `dest_cache.plane…` and `dest_cache.real`, `postwarp_rtl::budget::dest_planes`)
/// over 8.
pub fn dest_bytes_per_sample(budget: &Value) -> Option<f64> {
    let stores = budget.get("stores")?.as_array()?;
    let bits: f64 = stores
        .iter()
        .filter(|s| s["name"].as_str().is_some_and(|n| n.starts_with("dest_cache.plane") || n == "dest_cache.real"))
        .filter_map(|s| s["bits_per_entry"].as_f64())
        .sum();
    (bits > 0.0).then_some(bits / 8.0)
}

/// The sizes of a trace: its derived frame (display times `supersample`)
/// and its largest reference's longer side (samples).
pub fn trace_sizes(t: &crate::trace::Trace, supersample: u32) -> Sizes {
    let d = &t.display;
    let line = t.references.iter().map(|r| r.camera.intrinsics.width.max(r.camera.intrinsics.height)).max();
    Sizes {
        derived: (d.width * supersample, d.height * supersample),
        reference_line: line.unwrap_or(d.width.max(d.height)) * supersample,
    }
}

fn table(fields: &'static [(&'static str, &'static str, &'static str)]) -> Vec<KeyDoc> {
    fields.iter().map(|(k, u, d)| scalar(k, u, Reduce::Once, d)).collect()
}

fn op_keys() -> Vec<KeyDoc> {
    table(OP_FIELDS)
}

fn store_keys() -> Vec<KeyDoc> {
    table(STORE_FIELDS)
}

fn datapath_keys() -> Vec<KeyDoc> {
    DATAPATH_FIELDS
        .iter()
        .map(|&(k, u, d)| match k {
            "per_item" | "instances" => {
                KeyDoc { key: k, unit: u, reduce: Reduce::Once, shape: Shape::Struct(op_keys), meaning: d }
            }
            _ => scalar(k, u, Reduce::Once, d),
        })
        .collect()
}

fn total_keys() -> Vec<KeyDoc> {
    TOTAL_FIELDS
        .iter()
        .map(|&(k, u, d)| match k {
            "instances" => KeyDoc { key: k, unit: u, reduce: Reduce::Once, shape: Shape::Struct(op_keys), meaning: d },
            _ => scalar(k, u, Reduce::Once, d),
        })
        .collect()
}

fn constant_keys() -> Vec<KeyDoc> {
    vec![
        scalar("name", "—", Reduce::Once, "the constant"),
        scalar("value", "see unit", Reduce::Once, "its value"),
        scalar("unit", "—", Reduce::Once, "its unit"),
        scalar("source", "—", Reduce::Once, "where it comes from (published figure, or estimate)"),
    ]
}

/// Keys of `budget`.
pub fn keys() -> Vec<KeyDoc> {
    vec![
        scalar("process_node", "—", Reduce::Once, "the process node of the area constants"),
        scalar(
            "derived_width_samples",
            "samples",
            Reduce::Once,
            "derived frame width the frame-sized stores are sized for",
        ),
        scalar(
            "derived_height_samples",
            "samples",
            Reduce::Once,
            "derived frame height the frame-sized stores are sized for",
        ),
        scalar(
            "reference_line_samples",
            "samples",
            Reduce::Once,
            "longest reference line the line buffer holds (the trace's largest reference side)",
        ),
        nested("stores", Reduce::Once, store_keys, "one object per on-chip store"),
        nested(
            "datapaths",
            Reduce::Once,
            datapath_keys,
            "one object per datapath: operators per item and instantiated",
        ),
        nested("totals", Reduce::Once, total_keys, "sums over the stores and datapaths"),
        nested("area_constants", Reduce::Once, constant_keys, "every constant of the area estimate, with its source"),
    ]
}

/// `b` as text: the sizes, one line per store, one per datapath, the
/// totals (what `postwarp simulate --budget` and `postwarp size` print).
pub fn text(b: &Budget) -> String {
    let mut s = String::new();
    let t = &b.totals;
    let _ = writeln!(
        s,
        "on-chip stores ({}x{} derived samples, reference lines of {} samples; docs/budget.md):",
        b.sizes.derived.0, b.sizes.derived.1, b.sizes.reference_line
    );
    let _ = writeln!(s, "{:<34} {:<9} {:>10} {:>6} {:>12}", "store", "kind", "entries", "bits", "bytes");
    for st in &b.stores {
        let _ = writeln!(
            s,
            "{:<34} {:<9} {:>10} {:>6} {:>12}",
            st.name,
            st.kind.name(),
            st.entries,
            st.bits_per_entry,
            st.bytes
        );
    }
    let _ = writeln!(s, "datapaths (operators per item x items per cycle = instantiated):");
    let _ = writeln!(
        s,
        "{:<13} {:<64} {:>6} {:>5} {:>5} {:>5} {:>5} {:>5} {:>5}",
        "unit", "function", "format", "items", "mul", "add", "recip", "sqrt", "cmp"
    );
    for d in &b.datapaths {
        let p = &d.per_item;
        let _ = writeln!(
            s,
            "{:<13} {:<64} {:>6} {:>5} {:>5} {:>5} {:>5} {:>5} {:>5}",
            d.unit,
            d.function,
            d.format.name(),
            d.items_per_cycle,
            p.mul,
            p.add,
            p.recip,
            p.sqrt,
            p.cmp
        );
    }
    let i = &t.instances;
    let _ = writeln!(
        s,
        "operators instantiated: {} mul, {} add, {} recip, {} sqrt, {} cmp",
        i.mul, i.add, i.recip, i.sqrt, i.cmp
    );
    let _ = writeln!(
        s,
        "SRAM total: {} bytes ({:.1} KiB) in SRAM + {} bytes in registers = {} bytes on chip; area estimate {:.2} mm² at {} \
         ({:.2} SRAM + {:.2} registers + {:.2} operators)",
        t.sram_bytes,
        t.sram_bytes as f64 / 1024.0,
        t.register_bytes,
        t.store_bytes,
        t.area_mm2,
        b.process_node,
        t.sram_area_mm2,
        t.register_area_mm2,
        t.logic_area_mm2,
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use postwarp_rtl::budget::{dest_planes, widths};
    use postwarp_rtl::config::EngineConfig;

    #[test]
    fn dest_bytes_per_sample_sums_the_destination_planes() {
        let cfg = EngineConfig::default();
        let bits: u32 = dest_planes(&widths(&cfg)).iter().map(|p| p.2).sum();
        assert_eq!(dest_bytes_per_sample(&to_json(&Budget::of(&cfg))), Some(f64::from(bits) / 8.0));
        assert_eq!(dest_bytes_per_sample(&Value::Null), None, "a report written before the budget");
    }
}
