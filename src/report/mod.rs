//! Reports: `report.json` (keys other tools read: see `docs/report.md`) and
//! the printed table. Ratios and means are derived here from per-frame
//! counters and scores, never stored by the engines.
//!
//! `report.json` = `{"trace", "method", "config", "references", "frames":
//! [{"index", <metric keys>, "host_ms", <model counters>}], "mean": {...}}`.
//! Every byte is deterministic for a given trace and configuration except
//! the host-time fields (`host_ms`, `prepare_ms`).

pub mod csv;
pub mod images;
pub mod table;
pub mod timeline;

use serde_json::{Map, Value, json};

/// Metric keys in report order (the `Quality` fields).
pub fn metric_keys() -> Vec<&'static str> {
    crate::metrics::describe().iter().map(|d| d.key).collect()
}

/// Per-frame entry: `index`, every metric key (null without ground truth),
/// `host_ms`, then `extra` (model counters).
pub fn frame_entry(index: usize, quality: Option<&crate::metrics::Quality>, host_ms: f64, extra: Value) -> Value {
    let mut m = Map::new();
    m.insert("index".into(), json!(index));
    let q = quality.map(|q| serde_json::to_value(q).expect("Quality serializes"));
    for key in metric_keys() {
        let v = q.as_ref().and_then(|q| q.get(key).cloned()).unwrap_or(Value::Null);
        m.insert(key.into(), v);
    }
    m.insert("host_ms".into(), json!(host_ms));
    if let Value::Object(e) = extra {
        for (k, v) in e {
            m.insert(k, v);
        }
    }
    Value::Object(m)
}

/// Mean over frames of every numeric key present in all of them. Null
/// entries (non-finite values: a PSNR of +∞ for an identical frame, or a
/// metric with nothing to score) are skipped, so a mean PSNR is over the
/// frames with a finite PSNR; a key null in every frame is null. Histograms
/// (arrays) are summed element-wise instead and reported as totals under
/// the same key.
pub fn mean_entry(frames: &[Value]) -> Value {
    let mut out = Map::new();
    let Some(Value::Object(first)) = frames.first() else { return Value::Object(out) };
    for key in first.keys() {
        if key == "index" {
            continue;
        }
        let vals: Vec<&Value> = frames.iter().filter_map(|f| f.get(key)).collect();
        if vals.iter().all(|v| v.is_array()) {
            out.insert(key.clone(), sum_arrays(&vals));
            continue;
        }
        let nums: Vec<f64> = vals.iter().filter_map(|v| v.as_f64()).collect();
        let v = if nums.is_empty() { Value::Null } else { json!(nums.iter().sum::<f64>() / nums.len() as f64) };
        out.insert(key.clone(), v);
    }
    Value::Object(out)
}

fn sum_arrays(vals: &[&Value]) -> Value {
    let mut acc: Vec<Value> = Vec::new();
    for v in vals {
        let Value::Array(a) = v else { continue };
        if acc.len() < a.len() {
            acc.resize(a.len(), Value::Null);
        }
        for (i, x) in a.iter().enumerate() {
            acc[i] = match (&acc[i], x) {
                (Value::Null, Value::Array(_)) => sum_arrays(&[x]),
                (Value::Array(_), Value::Array(_)) => sum_arrays(&[&acc[i], x]),
                (a, b) => json!(a.as_f64().unwrap_or(0.0) + b.as_f64().unwrap_or(0.0)),
            };
        }
    }
    Value::Array(acc)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_skips_nulls_and_sums_histograms() {
        let frames = vec![
            json!({"index": 0, "psnr": 20.0, "x": null, "h": [1, 2], "k": [[1, 0], [2]]}),
            json!({"index": 1, "psnr": 30.0, "x": null, "h": [0, 1, 5], "k": [[1, 1], [0, 3]]}),
        ];
        let m = mean_entry(&frames);
        assert_eq!(m["psnr"], json!(25.0));
        assert_eq!(m["x"], Value::Null);
        assert_eq!(m["h"], json!([1.0, 3.0, 5.0]));
        assert_eq!(m["k"], json!([[2.0, 1.0], [2.0, 3.0]]));
        assert!(m.get("index").is_none());
    }
}
