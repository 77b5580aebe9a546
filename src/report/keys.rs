//! The description of every `report.json` key, declared once beside the
//! struct that writes it (DRAMsim3's `InitStat` style): its unit, its
//! meaning, and how it is reduced over frames. `docs/report.md`'s key
//! lists are generated from these tables ([`markdown_table`]) and a test
//! compares them; the reduction of `total` and `mean` ([`total`], [`mean`])
//! is driven by them, so a key's `total` and `mean` mean the same thing in
//! every report.
//!
//! Rules (one meaning of `total` and `mean` for every key):
//! 1. [`Reduce::Sum`] (counters, histograms, host times): `total` is the
//!    sum over frames (lists and maps element by element, missing elements
//!    0); `mean` is that sum divided by the number of frames.
//! 2. [`Reduce::Max`] (peaks): `total` and `mean` are the largest value of
//!    any frame.
//! 3. [`Reduce::Mean`] (scores: PSNR, SSIM, shares of one frame): no
//!    `total`; `mean` is the mean over the frames where the value is a
//!    number (`null`, e.g. a PSNR of +∞ or a frame without ground truth, is
//!    left out); `null` if no frame has one.
//! 4. [`Reduce::Derived`] (ratios and rates of counters): computed from the
//!    frame's counters in a frame, and from the summed counters in `total`
//!    and `mean` (so a rate in `mean` is the ratio of totals, never a mean
//!    of per-frame ratios).
//! 5. [`Reduce::Once`] (identifiers, per-frame facts such as `index`):
//!    neither in `total` nor in `mean`.

use serde_json::{Map, Number, Value};

/// How a key is reduced over frames (module rules).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reduce {
    /// Rule 1.
    Sum,
    /// Rule 2.
    Max,
    /// Rule 3.
    Mean,
    /// Rule 4.
    Derived,
    /// Rule 5.
    Once,
}

impl Reduce {
    /// The docs' column text.
    pub fn describe(self) -> &'static str {
        match self {
            Reduce::Sum => "sum / sum ÷ frames",
            Reduce::Max => "max / max",
            Reduce::Mean => "— / mean of frames with a value",
            Reduce::Derived => "from the totals",
            Reduce::Once => "—",
        }
    }
}

/// What a key holds.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// A number, string or bool.
    Scalar,
    /// An array of numbers (or of arrays), reduced element by element.
    List,
    /// An object whose keys are data (e.g. `"2x3"`), values numbers.
    Map,
    /// An object whose keys are described by this table.
    Struct(fn() -> Vec<KeyDoc>),
}

/// One key: name, unit, reduction, shape, meaning.
#[derive(Clone, Copy, Debug)]
pub struct KeyDoc {
    /// The JSON key.
    pub key: &'static str,
    /// Unit ("—" where there is none: names, objects; "bool").
    pub unit: &'static str,
    /// How `total` and `mean` reduce it.
    pub reduce: Reduce,
    /// What it holds.
    pub shape: Shape,
    /// One line: what it is.
    pub meaning: &'static str,
}

/// A scalar key.
pub const fn scalar(key: &'static str, unit: &'static str, reduce: Reduce, meaning: &'static str) -> KeyDoc {
    KeyDoc { key, unit, reduce, shape: Shape::Scalar, meaning }
}

/// A nested object described by `keys`.
pub const fn nested(key: &'static str, reduce: Reduce, keys: fn() -> Vec<KeyDoc>, meaning: &'static str) -> KeyDoc {
    KeyDoc { key, unit: "—", reduce, shape: Shape::Struct(keys), meaning }
}

/// The row of `key` in `keys`.
pub fn find<'a>(keys: &'a [KeyDoc], key: &str) -> Option<&'a KeyDoc> {
    keys.iter().find(|k| k.key == key)
}

fn add(a: &Value, b: &Value) -> Value {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => match (x.as_u64(), y.as_u64()) {
            (Some(x), Some(y)) => Value::from(x.saturating_add(y)),
            _ => Number::from_f64(x.as_f64().unwrap_or(0.0) + y.as_f64().unwrap_or(0.0))
                .map_or(Value::Null, Value::Number),
        },
        (Value::Array(x), Value::Array(y)) => {
            let n = x.len().max(y.len());
            Value::Array(
                (0..n)
                    .map(|i| match (x.get(i), y.get(i)) {
                        (Some(p), Some(q)) => add(p, q),
                        (Some(p), None) | (None, Some(p)) => p.clone(),
                        (None, None) => Value::Null,
                    })
                    .collect(),
            )
        }
        (Value::Object(x), Value::Object(y)) => {
            let mut m = x.clone();
            for (k, v) in y {
                let s = match m.get(k) {
                    Some(p) => add(p, v),
                    None => v.clone(),
                };
                m.insert(k.clone(), s);
            }
            Value::Object(m)
        }
        (Value::Null, v) | (v, Value::Null) => v.clone(),
        (a, _) => a.clone(),
    }
}

fn larger(a: &Value, b: &Value) -> Value {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            if y.as_f64().unwrap_or(f64::NEG_INFINITY) > x.as_f64().unwrap_or(f64::NEG_INFINITY) {
                b.clone()
            } else {
                a.clone()
            }
        }
        (Value::Array(x), Value::Array(y)) => Value::Array(
            (0..x.len().max(y.len()))
                .map(|i| match (x.get(i), y.get(i)) {
                    (Some(p), Some(q)) => larger(p, q),
                    (Some(p), None) | (None, Some(p)) => p.clone(),
                    (None, None) => Value::Null,
                })
                .collect(),
        ),
        (Value::Null, v) | (v, Value::Null) => v.clone(),
        (a, _) => a.clone(),
    }
}

/// Every number in `v` divided by `n` (arrays and objects element-wise).
fn divide(v: &Value, n: f64) -> Value {
    match v {
        Value::Number(x) => Number::from_f64(x.as_f64().unwrap_or(0.0) / n).map_or(Value::Null, Value::Number),
        Value::Array(a) => Value::Array(a.iter().map(|x| divide(x, n)).collect()),
        Value::Object(o) => Value::Object(o.iter().map(|(k, x)| (k.clone(), divide(x, n))).collect()),
        other => other.clone(),
    }
}

fn values<'a>(frames: &[&'a Value], key: &str) -> Vec<&'a Value> {
    frames.iter().filter_map(|f| f.get(key)).filter(|v| !v.is_null()).collect()
}

/// `total` of `frames` (objects described by `keys`): rules 1 and 2.
pub fn total(frames: &[&Value], keys: &[KeyDoc]) -> Map<String, Value> {
    let mut out = Map::new();
    for k in keys {
        let vals = values(frames, k.key);
        if vals.is_empty() {
            continue;
        }
        let v = match (k.shape, k.reduce) {
            (Shape::Struct(sub), _) if k.reduce != Reduce::Once => {
                let m = total(&vals, &sub());
                if m.is_empty() {
                    continue;
                }
                Value::Object(m)
            }
            (_, Reduce::Sum) => vals.iter().skip(1).fold(vals[0].clone(), |a, b| add(&a, b)),
            (_, Reduce::Max) => vals.iter().skip(1).fold(vals[0].clone(), |a, b| larger(&a, b)),
            _ => continue,
        };
        out.insert(k.key.to_string(), v);
    }
    out
}

/// `mean` of `frames` (objects described by `keys`): rules 1 to 3; `n` is
/// the number of frames.
pub fn mean(frames: &[&Value], keys: &[KeyDoc], n: usize) -> Map<String, Value> {
    let mut out = Map::new();
    for k in keys {
        let vals = values(frames, k.key);
        let v = match (k.shape, k.reduce) {
            (_, Reduce::Once | Reduce::Derived) => continue,
            (Shape::Struct(_), _) if vals.is_empty() => continue,
            (Shape::Struct(sub), _) => Value::Object(mean(&vals, &sub(), n)),
            (_, Reduce::Sum) if !vals.is_empty() => {
                divide(&vals.iter().skip(1).fold(vals[0].clone(), |a, b| add(&a, b)), n.max(1) as f64)
            }
            (_, Reduce::Max) if !vals.is_empty() => vals.iter().skip(1).fold(vals[0].clone(), |a, b| larger(&a, b)),
            (_, Reduce::Mean) => {
                let nums: Vec<f64> = vals.iter().filter_map(|v| v.as_f64()).collect();
                if nums.is_empty() {
                    Value::Null
                } else {
                    Number::from_f64(nums.iter().sum::<f64>() / nums.len() as f64).map_or(Value::Null, Value::Number)
                }
            }
            _ => Value::Null,
        };
        out.insert(k.key.to_string(), v);
    }
    out
}

/// Every key path under `v` that `keys` does not describe, or describes
/// without a unit (for the documentation test). Map keys are data and are
/// not checked; arrays are walked into.
pub fn undescribed(v: &Value, keys: &[KeyDoc], path: &str, out: &mut Vec<String>) {
    let Value::Object(m) = v else { return };
    for (k, child) in m {
        let p = if path.is_empty() { k.clone() } else { format!("{path}.{k}") };
        match find(keys, k) {
            None => out.push(p),
            Some(d) if d.unit.is_empty() || d.meaning.is_empty() => out.push(p),
            Some(d) => {
                if let Shape::Struct(sub) = d.shape {
                    let sub = sub();
                    match child {
                        Value::Array(items) => {
                            for (i, it) in items.iter().enumerate() {
                                undescribed(it, &sub, &format!("{p}[{i}]"), out);
                            }
                        }
                        _ => undescribed(child, &sub, &p, out),
                    }
                }
            }
        }
    }
}

/// `keys` as a Markdown table (key, unit, total / mean, meaning), nested
/// objects as `parent.child` rows after their parent.
pub fn markdown_table(keys: &[KeyDoc]) -> String {
    let mut s = String::from("| key | unit | total / mean | meaning |\n|---|---|---|---|\n");
    fn rows(s: &mut String, keys: &[KeyDoc], prefix: &str) {
        for k in keys {
            let name = format!("{prefix}{}", k.key);
            let reduce = match (k.shape, k.reduce) {
                (_, Reduce::Once) => Reduce::Once.describe(),
                (Shape::Struct(_), _) => "per key below",
                (_, r) => r.describe(),
            };
            s.push_str(&format!("| `{name}` | {} | {reduce} | {} |\n", k.unit, k.meaning));
            if let Shape::Struct(sub) = k.shape {
                rows(s, &sub(), &format!("{name}."));
            }
        }
    }
    rows(&mut s, keys, "");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn sub() -> Vec<KeyDoc> {
        vec![scalar("hits", "accesses", Reduce::Sum, "h"), scalar("rate", "fraction", Reduce::Derived, "r")]
    }

    fn keys() -> Vec<KeyDoc> {
        vec![
            scalar("index", "—", Reduce::Once, "i"),
            scalar("cycles", "cycles", Reduce::Sum, "c"),
            scalar("peak", "tiles", Reduce::Max, "p"),
            scalar("psnr", "dB", Reduce::Mean, "q"),
            KeyDoc { key: "hist", unit: "pixels", reduce: Reduce::Sum, shape: Shape::List, meaning: "h" },
            KeyDoc { key: "by_size", unit: "rects", reduce: Reduce::Sum, shape: Shape::Map, meaning: "m" },
            nested("cache", Reduce::Sum, sub, "c"),
        ]
    }

    #[test]
    fn totals_and_means_follow_one_rule_per_key() {
        let a = json!({"index": 0, "cycles": 10, "peak": 3, "psnr": 20.0, "hist": [1, 2], "by_size": {"1x1": 2},
                       "cache": {"hits": 4, "rate": 0.5}});
        let b = json!({"index": 1, "cycles": 30, "peak": 7, "psnr": null, "hist": [0, 1, 5], "by_size": {"2x1": 1},
                       "cache": {"hits": 6, "rate": 0.25}});
        let t = Value::Object(total(&[&a, &b], &keys()));
        assert_eq!(
            t,
            json!({"cycles": 40, "peak": 7, "hist": [1, 3, 5], "by_size": {"1x1": 2, "2x1": 1}, "cache": {"hits": 10}})
        );
        let m = Value::Object(mean(&[&a, &b], &keys(), 2));
        assert_eq!(
            m,
            json!({"cycles": 20.0, "peak": 7, "psnr": 20.0, "hist": [0.5, 1.5, 2.5], "by_size": {"1x1": 1.0, "2x1": 0.5},
                   "cache": {"hits": 5.0}})
        );
        let mut missing = Vec::new();
        undescribed(&json!({"cycles": 1, "bogus": 2, "cache": {"hits": 1, "nope": 0}}), &keys(), "", &mut missing);
        assert_eq!(missing, ["bogus", "cache.nope"]);
        assert!(markdown_table(&keys()).contains("| `cache.hits` | accesses | sum / sum ÷ frames | h |"));
    }
}
