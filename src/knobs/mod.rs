//! The knob tables of both engines (`postwarp_rtl::config::KNOBS` for the
//! hardware model, [`crate::golden::config::KNOBS`] for the golden model,
//! both [`postwarp_rtl::knob::Knob`] tables) meet files here: TOML and JSON
//! values to and from [`KnobValue`], set and get by name, a table's
//! `{name: value}` JSON object and its serde form; [`docs`] generates the
//! docs' knob tables.
//!
//! Rules:
//! 1. A file value is converted by the knob's [`Range`] kind, never by the
//!    field: integers must be non-negative, reals take integers too,
//!    choices and texts take strings. The error says what was expected; the
//!    caller names the file and the key.
//! 2. JSON is written in table order: integers as integers, reals as reals,
//!    choices and texts as strings, so `report.json`'s `config` objects
//!    keep their keys, order and types.
//! 3. Nothing here checks ranges: that is the configuration's `validate`
//!    (the table's ranges, then its rules between knobs).

pub mod docs;

use postwarp_rtl::knob::{Knob, KnobValue, Range, find, names};
use serde_json::{Map, Value};

/// The value of TOML `v` for knob `k` (rule 1).
pub fn from_toml<C>(k: &Knob<C>, v: &toml::Value) -> Result<KnobValue, String> {
    let r = match k.range {
        Range::Int { .. } | Range::PowerOfTwo { .. } => v
            .as_integer()
            .filter(|&n| n >= 0)
            .map(|n| KnobValue::Int(n as u64))
            .ok_or("expected a non-negative integer"),
        Range::Real { .. } => {
            v.as_float().or_else(|| v.as_integer().map(|n| n as f64)).map(KnobValue::Real).ok_or("expected a number")
        }
        Range::Bool => v.as_bool().map(KnobValue::Bool).ok_or("expected true or false"),
        Range::Choice(_) | Range::Text { .. } => {
            v.as_str().map(|s| KnobValue::Text(s.to_string())).ok_or("expected a string in quotes")
        }
    };
    r.map_err(str::to_string)
}

/// `v` as TOML writes it (integers above 2⁶³ saturate; no knob's range
/// reaches them).
pub fn to_toml(v: &KnobValue) -> toml::Value {
    match v {
        KnobValue::Int(n) => toml::Value::Integer(i64::try_from(*n).unwrap_or(i64::MAX)),
        KnobValue::Real(x) => toml::Value::Float(*x),
        KnobValue::Bool(b) => toml::Value::Boolean(*b),
        KnobValue::Text(s) => toml::Value::String(s.clone()),
    }
}

/// The value of JSON `v` for knob `k` (rule 1).
pub fn from_json<C>(k: &Knob<C>, v: &Value) -> Result<KnobValue, String> {
    let r = match k.range {
        Range::Int { .. } | Range::PowerOfTwo { .. } => {
            v.as_u64().map(KnobValue::Int).ok_or("expected a non-negative integer")
        }
        Range::Real { .. } => v.as_f64().map(KnobValue::Real).ok_or("expected a number"),
        Range::Bool => v.as_bool().map(KnobValue::Bool).ok_or("expected true or false"),
        Range::Choice(_) | Range::Text { .. } => {
            v.as_str().map(|s| KnobValue::Text(s.to_string())).ok_or("expected a string")
        }
    };
    r.map_err(str::to_string)
}

/// `v` in JSON (rule 2).
pub fn to_json(v: &KnobValue) -> Value {
    match v {
        KnobValue::Int(n) => Value::from(*n),
        KnobValue::Real(x) => Value::from(*x),
        KnobValue::Bool(b) => Value::Bool(*b),
        KnobValue::Text(s) => Value::String(s.clone()),
    }
}

/// The knob `name` of `table`, or the error listing the known ones.
pub fn knob<C>(table: &'static [Knob<C>], name: &str) -> Result<&'static Knob<C>, String> {
    find(table, name).ok_or_else(|| format!("unknown knob (known: {})", names(table)))
}

/// Set knob `name` of `c` from TOML value `v`.
pub fn set_toml<C>(table: &'static [Knob<C>], c: &mut C, name: &str, v: &toml::Value) -> Result<(), String> {
    let k = knob(table, name)?;
    (k.set)(c, from_toml(k, v)?)
}

/// Set knob `name` of `c` from JSON value `v`.
pub fn set_json<C>(table: &'static [Knob<C>], c: &mut C, name: &str, v: &Value) -> Result<(), String> {
    let k = knob(table, name)?;
    (k.set)(c, from_json(k, v)?)
}

/// `c` over `base` with every key of TOML table `t` set; errors start with
/// the key.
pub fn from_toml_table<C>(table: &'static [Knob<C>], mut base: C, t: &toml::Table) -> Result<C, String> {
    for (k, v) in t {
        set_toml(table, &mut base, k, v).map_err(|e| format!("{k}: {e}"))?;
    }
    Ok(base)
}

/// Every knob of `c` as `{name: value}`, in table order (rule 2).
pub fn to_json_map<C>(table: &[Knob<C>], c: &C) -> Map<String, Value> {
    table.iter().map(|k| (k.name.to_string(), to_json(&(k.get)(c)))).collect()
}

/// `base` with every key of JSON object `m` set; errors start with the key.
pub fn from_json_map<C>(table: &'static [Knob<C>], mut base: C, m: &Map<String, Value>) -> Result<C, String> {
    for (k, v) in m {
        set_json(table, &mut base, k, v).map_err(|e| format!("{k}: {e}"))?;
    }
    Ok(base)
}

/// Serialize `c` as its [`to_json_map`] (for a `Serialize` impl).
pub fn serialize<C, S: serde::Serializer>(table: &[Knob<C>], c: &C, s: S) -> Result<S::Ok, S::Error> {
    serde::Serialize::serialize(&to_json_map(table, c), s)
}

/// Deserialize an object of knobs over `C::default()`: missing keys keep
/// their defaults, unknown keys and values of the wrong type are refused
/// (for a `Deserialize` impl).
pub fn deserialize<'de, C: Default, D: serde::Deserializer<'de>>(
    table: &'static [Knob<C>],
    d: D,
) -> Result<C, D::Error> {
    let m: Map<String, Value> = serde::Deserialize::deserialize(d)?;
    from_json_map(table, C::default(), &m).map_err(serde::de::Error::custom)
}
