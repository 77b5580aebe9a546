//! Statistics: every number the hardware model reports, declared once.
//!
//! Job: hold the counters and histograms of one frame (or of a whole run) in
//! a fixed, deterministic order, each with a unit and a one-line description
//! (DRAMsim3's rule: a stat is declared once, with its kind, unit and
//! description, before it is used).
//!
//! API: [`StatKind`], [`StatDef`] (`const` tables of these live next to the
//! unit that owns the stats), [`Stats`]: `new(defs)`, `declare`, `defs`,
//! `inc`/`add_count`, `record`/`record_n` (histograms), `counter`,
//! `histogram`, `id` + `add_count_at`/`record_at` for hot loops, `add` (sum
//! another `Stats` into this one, e.g. per-frame values into run totals),
//! `reset`, `iter`. [`Histogram`] is an exact, sparse histogram of `u64`
//! values.
//!
//! Rules:
//! - Order is declaration order, everywhere (`defs`, `iter`), so reports are
//!   byte-for-byte reproducible.
//! - Only raw counts are stored. Ratios (hit rates, utilisation, bytes per
//!   sample, means) are derived when a report is made, never stored (gem5's
//!   formulas); [`Histogram::mean`] computes on demand.
//! - A histogram's `unit` is the unit of the recorded *values*; its bin
//!   counts are numbers of events.
//! - Using an undeclared name, or a counter as a histogram (or the reverse),
//!   is a programming error: `inc`, `record` and friends panic in every
//!   build (a debug-only check would silently drop counts from release
//!   reports). The `try_*` forms return a [`StatError`] instead.
//! - Declaring a name twice with the identical definition is a no-op; with a
//!   different definition it is an error ([`StatError::Conflict`]).
//! - `add(&other)` accumulates value by value; stats of `other` not yet
//!   declared here are declared (appended in `other`'s order), so run totals
//!   can start from `Stats::default()`.
//! - Counters saturate at `u64::MAX` rather than wrap.
//!
//! Not modelled: floating-point or signed stats, time series (per-cycle
//! traces); those belong to report code or debug tooling.

use std::collections::BTreeMap;
use std::fmt;

/// What a statistic holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StatKind {
    /// A count of events or of a quantity (`unit` says of what).
    Counter,
    /// The distribution of a per-event value (`unit` is the value's unit).
    Histogram,
}

/// The declaration of one statistic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StatDef {
    /// Dotted name, `unit_or_block.what` (e.g. `dram.bytes_read`).
    pub name: &'static str,
    /// Unit of the count, or of a histogram's values (e.g. `bytes`, `cycles`).
    pub unit: &'static str,
    /// One-line meaning.
    pub description: &'static str,
    /// Counter or histogram.
    pub kind: StatKind,
}

impl StatDef {
    /// A counter declaration.
    pub const fn counter(name: &'static str, unit: &'static str, description: &'static str) -> StatDef {
        StatDef { name, unit, description, kind: StatKind::Counter }
    }

    /// A histogram declaration.
    pub const fn histogram(name: &'static str, unit: &'static str, description: &'static str) -> StatDef {
        StatDef { name, unit, description, kind: StatKind::Histogram }
    }
}

/// Misuse of a [`Stats`] value.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StatError {
    /// The name was never declared.
    Unknown(String),
    /// The name is declared with the other kind.
    WrongKind {
        /// The stat's name.
        name: String,
        /// The kind it was declared with.
        declared: StatKind,
    },
    /// The name is already declared with a different definition.
    Conflict(String),
}

impl fmt::Display for StatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StatError::Unknown(name) => write!(f, "stat `{name}` is not declared"),
            StatError::WrongKind { name, declared } => write!(f, "stat `{name}` is declared as a {declared:?}"),
            StatError::Conflict(name) => write!(f, "stat `{name}` is already declared with a different definition"),
        }
    }
}

impl std::error::Error for StatError {}

/// An exact histogram of `u64` values: value → number of events.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Histogram {
    bins: BTreeMap<u64, u64>,
}

impl Histogram {
    /// Record one event of `value`.
    pub fn record(&mut self, value: u64) {
        self.record_n(value, 1);
    }

    /// Record `n` events of `value`.
    pub fn record_n(&mut self, value: u64, n: u64) {
        if n > 0 {
            let bin = self.bins.entry(value).or_insert(0);
            *bin = bin.saturating_add(n);
        }
    }

    /// Number of events of `value`.
    pub fn get(&self, value: u64) -> u64 {
        self.bins.get(&value).copied().unwrap_or(0)
    }

    /// `(value, events)` in increasing value order, non-empty bins only.
    pub fn bins(&self) -> impl Iterator<Item = (u64, u64)> + '_ {
        self.bins.iter().map(|(&v, &n)| (v, n))
    }

    /// Number of events.
    pub fn count(&self) -> u64 {
        self.bins.values().fold(0u64, |a, &n| a.saturating_add(n))
    }

    /// Sum of the recorded values (saturating).
    pub fn sum(&self) -> u64 {
        self.bins.iter().fold(0u64, |a, (&v, &n)| a.saturating_add(v.saturating_mul(n)))
    }

    /// Largest recorded value.
    pub fn max(&self) -> Option<u64> {
        self.bins.keys().next_back().copied()
    }

    /// Mean of the recorded values, derived on demand (never stored).
    pub fn mean(&self) -> Option<f64> {
        let count = self.count();
        (count > 0).then(|| self.sum() as f64 / count as f64)
    }

    /// Add every event of `other`.
    pub fn add(&mut self, other: &Histogram) {
        for (v, n) in other.bins() {
            self.record_n(v, n);
        }
    }
}

/// The value of one statistic.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StatValue {
    /// A counter's count.
    Counter(u64),
    /// A histogram.
    Histogram(Histogram),
}

impl StatValue {
    fn zero(kind: StatKind) -> StatValue {
        match kind {
            StatKind::Counter => StatValue::Counter(0),
            StatKind::Histogram => StatValue::Histogram(Histogram::default()),
        }
    }
}

/// Index of a declared stat in one [`Stats`] value, for hot loops (valid only
/// for the `Stats` that returned it, or one with the same declarations).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StatId(usize);

/// Declared statistics and their values, in declaration order.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    defs: Vec<StatDef>,
    values: Vec<StatValue>,
    index: BTreeMap<&'static str, usize>,
}

impl Stats {
    /// Declare every stat of `defs`, in order, all zero.
    ///
    /// # Panics
    /// If a name is declared twice with different definitions.
    pub fn new(defs: &[StatDef]) -> Stats {
        let mut stats = Stats::default();
        for &def in defs {
            stats.declare(def).unwrap_or_else(|e| panic!("{e}"));
        }
        stats
    }

    /// Declare one stat (zero). Identical re-declaration is a no-op.
    pub fn declare(&mut self, def: StatDef) -> Result<StatId, StatError> {
        if let Some(&i) = self.index.get(def.name) {
            return if self.defs[i] == def { Ok(StatId(i)) } else { Err(StatError::Conflict(def.name.to_string())) };
        }
        let i = self.defs.len();
        self.defs.push(def);
        self.values.push(StatValue::zero(def.kind));
        self.index.insert(def.name, i);
        Ok(StatId(i))
    }

    /// Every declared stat, in declaration order.
    pub fn defs(&self) -> &[StatDef] {
        &self.defs
    }

    /// `(definition, value)` of every stat, in declaration order.
    pub fn iter(&self) -> impl Iterator<Item = (&StatDef, &StatValue)> {
        self.defs.iter().zip(&self.values)
    }

    /// The id of a declared stat.
    pub fn id(&self, name: &str) -> Option<StatId> {
        self.index.get(name).map(|&i| StatId(i))
    }

    /// Zero every value; declarations stay.
    pub fn reset(&mut self) {
        for (def, value) in self.defs.iter().zip(&mut self.values) {
            *value = StatValue::zero(def.kind);
        }
    }

    /// Add 1 to counter `name`.
    ///
    /// # Panics
    /// If `name` is not a declared counter.
    pub fn inc(&mut self, name: &str) {
        self.add_count(name, 1);
    }

    /// Add `n` to counter `name`.
    ///
    /// # Panics
    /// If `name` is not a declared counter.
    pub fn add_count(&mut self, name: &str, n: u64) {
        self.try_add_count(name, n).unwrap_or_else(|e| panic!("{e}"));
    }

    /// Add `n` to counter `name`, or say why not.
    pub fn try_add_count(&mut self, name: &str, n: u64) -> Result<(), StatError> {
        let id = self.id(name).ok_or_else(|| StatError::Unknown(name.to_string()))?;
        self.try_add_count_at(id, n)
    }

    /// Add `n` to the counter with id `id`.
    ///
    /// # Panics
    /// If `id` is not a counter of this `Stats`.
    pub fn add_count_at(&mut self, id: StatId, n: u64) {
        self.try_add_count_at(id, n).unwrap_or_else(|e| panic!("{e}"));
    }

    fn try_add_count_at(&mut self, id: StatId, n: u64) -> Result<(), StatError> {
        match self.values.get_mut(id.0) {
            Some(StatValue::Counter(c)) => {
                *c = c.saturating_add(n);
                Ok(())
            }
            Some(StatValue::Histogram(_)) => {
                Err(StatError::WrongKind { name: self.defs[id.0].name.to_string(), declared: StatKind::Histogram })
            }
            None => Err(StatError::Unknown(format!("#{}", id.0))),
        }
    }

    /// Record one event of `value` in histogram `name`.
    ///
    /// # Panics
    /// If `name` is not a declared histogram.
    pub fn record(&mut self, name: &str, value: u64) {
        self.record_n(name, value, 1);
    }

    /// Record `n` events of `value` in histogram `name`.
    ///
    /// # Panics
    /// If `name` is not a declared histogram.
    pub fn record_n(&mut self, name: &str, value: u64, n: u64) {
        self.try_record_n(name, value, n).unwrap_or_else(|e| panic!("{e}"));
    }

    /// Record `n` events of `value` in histogram `name`, or say why not.
    pub fn try_record_n(&mut self, name: &str, value: u64, n: u64) -> Result<(), StatError> {
        let id = self.id(name).ok_or_else(|| StatError::Unknown(name.to_string()))?;
        self.try_record_at(id, value, n)
    }

    /// Record `n` events of `value` in the histogram with id `id`.
    ///
    /// # Panics
    /// If `id` is not a histogram of this `Stats`.
    pub fn record_at(&mut self, id: StatId, value: u64, n: u64) {
        self.try_record_at(id, value, n).unwrap_or_else(|e| panic!("{e}"));
    }

    fn try_record_at(&mut self, id: StatId, value: u64, n: u64) -> Result<(), StatError> {
        match self.values.get_mut(id.0) {
            Some(StatValue::Histogram(h)) => {
                h.record_n(value, n);
                Ok(())
            }
            Some(StatValue::Counter(_)) => {
                Err(StatError::WrongKind { name: self.defs[id.0].name.to_string(), declared: StatKind::Counter })
            }
            None => Err(StatError::Unknown(format!("#{}", id.0))),
        }
    }

    /// The value of counter `name`, or `None` if it is not a declared counter.
    pub fn counter(&self, name: &str) -> Option<u64> {
        match self.values.get(*self.index.get(name)?)? {
            StatValue::Counter(c) => Some(*c),
            StatValue::Histogram(_) => None,
        }
    }

    /// Histogram `name`, or `None` if it is not a declared histogram.
    pub fn histogram(&self, name: &str) -> Option<&Histogram> {
        match self.values.get(*self.index.get(name)?)? {
            StatValue::Histogram(h) => Some(h),
            StatValue::Counter(_) => None,
        }
    }

    /// Add every value of `other` into this one (e.g. a frame into the run
    /// totals). Stats of `other` not declared here are declared first.
    ///
    /// # Panics
    /// If a name is declared in both with different definitions.
    pub fn add(&mut self, other: &Stats) {
        for (def, value) in other.iter() {
            let id = self.declare(*def).unwrap_or_else(|e| panic!("{e}"));
            match (&mut self.values[id.0], value) {
                (StatValue::Counter(a), StatValue::Counter(b)) => *a = a.saturating_add(*b),
                (StatValue::Histogram(a), StatValue::Histogram(b)) => a.add(b),
                _ => unreachable!("identical definitions have identical kinds"),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEFS: &[StatDef] = &[
        StatDef::counter("unit.items", "items", "items processed"),
        StatDef::histogram("unit.size", "samples", "kernel side per kernel"),
        StatDef::counter("unit.stalls", "cycles", "cycles stalled"),
    ];

    #[test]
    fn declared_stats_start_at_zero_in_declaration_order() {
        let s = Stats::new(DEFS);
        let names: Vec<_> = s.defs().iter().map(|d| d.name).collect();
        assert_eq!(names, ["unit.items", "unit.size", "unit.stalls"]);
        assert_eq!(s.counter("unit.items"), Some(0));
        assert_eq!(s.histogram("unit.size").unwrap().count(), 0);
        assert_eq!(s.iter().count(), 3);
        assert_eq!(s.defs()[1].kind, StatKind::Histogram);
        assert_eq!(s.defs()[2].unit, "cycles");
    }

    #[test]
    fn incrementing_counters_and_recording_histograms() {
        let mut s = Stats::new(DEFS);
        s.inc("unit.items");
        s.add_count("unit.items", 4);
        s.record("unit.size", 2);
        s.record_n("unit.size", 4, 3);
        let stalls = s.id("unit.stalls").unwrap();
        s.add_count_at(stalls, 9);
        assert_eq!(s.counter("unit.items"), Some(5));
        assert_eq!(s.counter("unit.stalls"), Some(9));
        let h = s.histogram("unit.size").unwrap();
        assert_eq!((h.count(), h.sum(), h.max(), h.get(4)), (4, 14, Some(4), 3));
        assert_eq!(h.mean(), Some(3.5));
        assert_eq!(h.bins().collect::<Vec<_>>(), [(2, 1), (4, 3)]);
        s.reset();
        assert_eq!(s, Stats::new(DEFS));
    }

    #[test]
    fn accumulating_frames_into_totals() {
        let mut frame = Stats::new(DEFS);
        let mut total = Stats::default();
        for f in 1..=3u64 {
            frame.reset();
            frame.add_count("unit.items", f);
            frame.record("unit.size", f);
            total.add(&frame);
        }
        assert_eq!(total.defs(), DEFS);
        assert_eq!(total.counter("unit.items"), Some(6));
        assert_eq!(total.counter("unit.stalls"), Some(0));
        assert_eq!(total.histogram("unit.size").unwrap().bins().collect::<Vec<_>>(), [(1, 1), (2, 1), (3, 1)]);
    }

    #[test]
    fn adding_stats_from_another_unit_appends_its_declarations() {
        let mut a = Stats::new(&DEFS[..1]);
        a.inc("unit.items");
        let mut b = Stats::new(&[StatDef::counter("other.x", "bytes", "x")]);
        b.add_count("other.x", 3);
        a.add(&b);
        assert_eq!(a.defs().iter().map(|d| d.name).collect::<Vec<_>>(), ["unit.items", "other.x"]);
        assert_eq!((a.counter("unit.items"), a.counter("other.x")), (Some(1), Some(3)));
    }

    #[test]
    fn unknown_names_are_errors_in_try_forms_and_none_in_getters() {
        let mut s = Stats::new(DEFS);
        assert_eq!(s.try_add_count("unit.nope", 1), Err(StatError::Unknown("unit.nope".into())));
        assert_eq!(s.try_record_n("unit.nope", 1, 1), Err(StatError::Unknown("unit.nope".into())));
        assert_eq!(s.counter("unit.nope"), None);
        assert!(s.histogram("unit.nope").is_none());
        assert!(s.id("unit.nope").is_none());
    }

    #[test]
    fn wrong_kind_is_an_error() {
        let mut s = Stats::new(DEFS);
        assert_eq!(
            s.try_add_count("unit.size", 1),
            Err(StatError::WrongKind { name: "unit.size".into(), declared: StatKind::Histogram })
        );
        assert_eq!(
            s.try_record_n("unit.items", 1, 1),
            Err(StatError::WrongKind { name: "unit.items".into(), declared: StatKind::Counter })
        );
        assert_eq!(s.counter("unit.size"), None);
        assert!(s.histogram("unit.items").is_none());
    }

    #[test]
    #[should_panic(expected = "stat `unit.nope` is not declared")]
    fn incrementing_an_unknown_counter_panics() {
        Stats::new(DEFS).inc("unit.nope");
    }

    #[test]
    #[should_panic(expected = "is declared as a Counter")]
    fn recording_into_a_counter_panics() {
        Stats::new(DEFS).record("unit.items", 1);
    }

    #[test]
    fn redeclaring_identically_is_a_no_op_and_differently_a_conflict() {
        let mut s = Stats::new(DEFS);
        assert_eq!(s.declare(DEFS[0]), Ok(StatId(0)));
        assert_eq!(s.defs().len(), 3);
        let clash = StatDef::counter("unit.items", "bytes", "items processed");
        assert_eq!(s.declare(clash), Err(StatError::Conflict("unit.items".into())));
    }

    #[test]
    #[should_panic(expected = "different definition")]
    fn adding_conflicting_definitions_panics() {
        let mut a = Stats::new(DEFS);
        a.add(&Stats::new(&[StatDef::histogram("unit.items", "items", "x")]));
    }

    #[test]
    fn counters_saturate() {
        let mut s = Stats::new(DEFS);
        s.add_count("unit.items", u64::MAX);
        s.inc("unit.items");
        assert_eq!(s.counter("unit.items"), Some(u64::MAX));
    }
}
