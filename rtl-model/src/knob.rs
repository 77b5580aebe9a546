//! Declarative knob tables: one declaration per knob gives its field, name,
//! unit, description, default and valid range, and the table [`Knob`] that
//! reads, writes and checks it by name.
//!
//! Job: [`knob_table!`] declares a plain configuration struct (public
//! fields, the knob names) with its `Default` and a `&[Knob<Cfg>]` table in
//! field order; [`check_all`] checks every knob against its own [`Range`]
//! in one loop, and [`CrossRule`] names each check that involves more than
//! one knob. The `postwarp` crate maps TOML and JSON onto [`KnobValue`]
//! generically and generates the docs' knob tables from the table, so a
//! knob is declared in exactly one place. Both engines use it
//! (`config::EngineConfig`, and the golden model's `GoldenConfig` in the
//! `postwarp` crate).
//!
//! Rules:
//! 1. A knob's field type implements [`KnobType`] (`u32`, `u64`, `f64`,
//!    `bool`, `String`, and enums declared with [`knob_choice!`]; a string
//!    field's choices are declared with [`knob_names!`]); `set`
//!    fails only on a value of the wrong type or width (the message says
//!    what was expected; the caller names the knob and the file).
//! 2. [`Knob::check`] is the only range check of a value: its message is
//!    `name = value: expected …`, value as TOML writes it.
//! 3. Integers are non-negative ([`KnobValue::Int`] is a `u64`); reals
//!    must be finite.
//!
//! Throughput/latency: not applicable (configuration).

use std::fmt;

/// A knob's value, independent of the field's Rust type.
#[derive(Clone, Debug, PartialEq)]
pub enum KnobValue {
    /// A non-negative integer.
    Int(u64),
    /// A real number.
    Real(f64),
    /// A flag.
    Bool(bool),
    /// A string (also the value of a choice).
    Text(String),
}

impl fmt::Display for KnobValue {
    /// As TOML writes it (strings in quotes).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            KnobValue::Int(n) => write!(f, "{n}"),
            KnobValue::Real(x) => write!(f, "{x}"),
            KnobValue::Bool(b) => write!(f, "{b}"),
            KnobValue::Text(s) => write!(f, "\"{s}\""),
        }
    }
}

/// The values a knob accepts.
#[derive(Clone, Copy, Debug)]
pub enum Range {
    /// An integer from `min` to `max`, both included.
    Int {
        /// Smallest value.
        min: u64,
        /// Largest value.
        max: u64,
    },
    /// A power of two from `min` to `max`, both included.
    PowerOfTwo {
        /// Smallest value.
        min: u64,
        /// Largest value.
        max: u64,
    },
    /// A finite real from `min` (excluded if `min_open`) to `max`
    /// (included; `f64::INFINITY` = no upper bound).
    Real {
        /// Lower bound.
        min: f64,
        /// The lower bound itself is refused.
        min_open: bool,
        /// Upper bound.
        max: f64,
    },
    /// `true` or `false`.
    Bool,
    /// One of these strings.
    Choice(&'static [&'static str]),
    /// A string that `check` accepts; `valid` says which, in words.
    Text {
        /// What is accepted, for messages and docs.
        valid: &'static str,
        /// The check.
        check: fn(&str) -> bool,
    },
}

/// One knob of configuration type `C`.
pub struct Knob<C: 'static> {
    /// The knob's name (= the field's name).
    pub name: &'static str,
    /// Unit (`1` for a ratio without one, `bool`, `text`, `a|b` for a
    /// choice).
    pub unit: &'static str,
    /// One line: what it is.
    pub description: &'static str,
    /// Valid values.
    pub range: Range,
    /// The field's value.
    pub get: fn(&C) -> KnobValue,
    /// Set the field (rule 1).
    pub set: fn(&mut C, KnobValue) -> Result<(), String>,
}

impl<C> fmt::Debug for Knob<C> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Knob").field("name", &self.name).field("unit", &self.unit).finish_non_exhaustive()
    }
}

/// `unit` after a number in a message: plain if one word, else in
/// parentheses; nothing for `1`.
fn unit_suffix(unit: &str) -> String {
    match unit {
        "1" | "bool" | "text" => String::new(),
        u if u.contains(' ') => format!(" ({u})"),
        u => format!(" {u}"),
    }
}

/// The quoted, comma-separated list of `names`.
pub fn quoted_list(names: &[&str]) -> String {
    names.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ")
}

impl<C> Knob<C> {
    /// What the knob accepts, in words (the part of a message after
    /// `expected`).
    pub fn expected(&self) -> String {
        let u = unit_suffix(self.unit);
        match self.range {
            Range::Int { min, max } => format!("{min} to {max}{u}"),
            Range::PowerOfTwo { min, max } => format!("a power of two from {min} to {max}{u}"),
            Range::Real { min, min_open, max } => match (min_open && min == 0.0, max == f64::INFINITY) {
                (true, true) => format!("a positive number{u}"),
                (true, false) => format!("a positive number up to {max}{u}"),
                (false, true) => format!("a finite number {} {min}{u}", if min_open { ">" } else { ">=" }),
                (false, false) if min_open => format!("above {min}, up to {max}{u}"),
                (false, false) => format!("{min} to {max}{u}"),
            },
            Range::Bool => "true or false".into(),
            Range::Choice(names) => format!("one of {}", quoted_list(names)),
            Range::Text { valid, .. } => valid.into(),
        }
    }

    /// Whether `v` is in the range (rule 2), else `name = v: expected …`.
    pub fn check(&self, v: &KnobValue) -> Result<(), String> {
        let ok = match (&self.range, v) {
            (Range::Int { min, max }, KnobValue::Int(n)) => (min..=max).contains(&n),
            (Range::PowerOfTwo { min, max }, KnobValue::Int(n)) => n.is_power_of_two() && (min..=max).contains(&n),
            (Range::Real { min, min_open, max }, KnobValue::Real(x)) => {
                x.is_finite() && (if *min_open { x > min } else { x >= min }) && x <= max
            }
            (Range::Bool, KnobValue::Bool(_)) => true,
            (Range::Choice(names), KnobValue::Text(s)) => names.contains(&s.as_str()),
            (Range::Text { check, .. }, KnobValue::Text(s)) => check(s.as_str()),
            _ => false,
        };
        if ok { Ok(()) } else { Err(format!("{} = {v}: expected {}", self.name, self.expected())) }
    }
}

/// A rule between knobs: checked after every knob's own range.
pub struct CrossRule<C: 'static> {
    /// Short name of the rule.
    pub name: &'static str,
    /// The rule in words, for the docs.
    pub rule: &'static str,
    /// The check; the message starts with the first knob named.
    pub check: fn(&C) -> Result<(), String>,
}

/// The knob of `table` called `name`.
pub fn find<C>(table: &'static [Knob<C>], name: &str) -> Option<&'static Knob<C>> {
    table.iter().find(|k| k.name == name)
}

/// The names of `table`, comma-separated.
pub fn names<C>(table: &[Knob<C>]) -> String {
    table.iter().map(|k| k.name).collect::<Vec<_>>().join(", ")
}

/// Set knob `name` of `c` to `v`; the error says what was expected (the
/// caller adds the knob's name and the file).
pub fn set_by_name<C>(table: &'static [Knob<C>], c: &mut C, name: &str, v: KnobValue) -> Result<(), String> {
    match find(table, name) {
        Some(k) => (k.set)(c, v),
        None => Err(format!("unknown knob (known: {})", names(table))),
    }
}

/// The value of knob `name` of `c`.
pub fn get_by_name<C>(table: &'static [Knob<C>], c: &C, name: &str) -> Option<KnobValue> {
    find(table, name).map(|k| (k.get)(c))
}

/// Every knob of `c` against its own range, then every rule, in order;
/// the first failure's message.
pub fn check_all<C>(table: &[Knob<C>], rules: &[CrossRule<C>], c: &C) -> Result<(), String> {
    for k in table {
        k.check(&(k.get)(c))?;
    }
    for r in rules {
        (r.check)(c)?;
    }
    Ok(())
}

/// A field type a knob can have (rule 1).
pub trait KnobType: Sized {
    /// The field's value.
    fn to_knob(&self) -> KnobValue;
    /// The field from a value; the error says what was expected.
    fn from_knob(v: KnobValue) -> Result<Self, String>;
}

impl KnobType for u64 {
    fn to_knob(&self) -> KnobValue {
        KnobValue::Int(*self)
    }
    fn from_knob(v: KnobValue) -> Result<Self, String> {
        match v {
            KnobValue::Int(n) => Ok(n),
            _ => Err("expected a non-negative integer".into()),
        }
    }
}

impl KnobType for u32 {
    fn to_knob(&self) -> KnobValue {
        KnobValue::Int((*self).into())
    }
    fn from_knob(v: KnobValue) -> Result<Self, String> {
        u32::try_from(u64::from_knob(v)?).map_err(|_| "expected an integer below 2^32".into())
    }
}

impl KnobType for f64 {
    fn to_knob(&self) -> KnobValue {
        KnobValue::Real(*self)
    }
    fn from_knob(v: KnobValue) -> Result<Self, String> {
        match v {
            KnobValue::Real(x) => Ok(x),
            KnobValue::Int(n) => Ok(n as f64),
            _ => Err("expected a number".into()),
        }
    }
}

impl KnobType for bool {
    fn to_knob(&self) -> KnobValue {
        KnobValue::Bool(*self)
    }
    fn from_knob(v: KnobValue) -> Result<Self, String> {
        match v {
            KnobValue::Bool(b) => Ok(b),
            _ => Err("expected true or false".into()),
        }
    }
}

impl KnobType for String {
    fn to_knob(&self) -> KnobValue {
        KnobValue::Text(self.clone())
    }
    fn from_knob(v: KnobValue) -> Result<Self, String> {
        match v {
            KnobValue::Text(s) => Ok(s),
            _ => Err("expected a string in quotes".into()),
        }
    }
}

/// `"a|b|c"` from string literals, at compile time (the unit of a choice).
#[macro_export]
macro_rules! bar_joined {
    ($first:literal $(, $rest:literal)* $(,)?) => {
        concat!($first $(, "|", $rest)*)
    };
}

/// The values of a choice knob kept as a string field: `NAMES` (a
/// `&[&str]`) and `UNIT` (`a|b`), from one list of literals.
#[macro_export]
macro_rules! knob_names {
    ($(#[$meta:meta])* $vis:vis $names:ident, $unit:ident = $($text:literal),+ $(,)?) => {
        $(#[$meta])*
        $vis const $names: &[&str] = &[$($text),+];
        /// The values, `|`-separated (the unit of a key taking them).
        $vis const $unit: &str = $crate::bar_joined!($($text),+);
    };
}

/// A plain enum whose values are a choice knob's: the enum, `ALL` (the
/// variants in order), `NAMES` (their names), `UNIT` (`a|b`), `name()` and
/// its [`KnobType`]. Attributes (docs, derives) pass through.
#[macro_export]
macro_rules! knob_choice {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $text:literal ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        $vis enum $name {
            $( $(#[$vmeta])* $variant ),+
        }

        impl $name {
            /// Every value, in order.
            pub const ALL: &'static [$name] = &[$($name::$variant),+];
            /// The names of [`Self::ALL`], as configuration files write them.
            pub const NAMES: &'static [&'static str] = &[$($text),+];
            /// The unit of a knob of this type: the names, `|`-separated.
            pub const UNIT: &'static str = $crate::bar_joined!($($text),+);

            /// The value's name.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $text),+
                }
            }
        }

        impl $crate::knob::KnobType for $name {
            fn to_knob(&self) -> $crate::knob::KnobValue {
                $crate::knob::KnobValue::Text(self.name().to_string())
            }
            fn from_knob(v: $crate::knob::KnobValue) -> Result<Self, String> {
                let expected = || format!("expected one of {}", $crate::knob::quoted_list(Self::NAMES));
                match v {
                    $($crate::knob::KnobValue::Text(s) if s == $text => Ok($name::$variant),)+
                    $crate::knob::KnobValue::Text(s) => Err(format!("{}, not \"{s}\"", expected())),
                    _ => Err(expected()),
                }
            }
        }
    };
}

/// Declare a configuration struct and its knob table at once.
///
/// ```ignore
/// knob_table! {
///     /// Docs of the struct.
///     #[derive(Clone, Debug, PartialEq)]
///     pub struct Cfg in KNOBS {
///         /// Optional further docs of the field.
///         tile_size: u32 = 8; Range::Int { min: 1, max: 256 }, "samples", "side of a tile";
///     }
/// }
/// ```
///
/// Each entry: `field: type = default; range, unit, description;`. The
/// field's doc comment is the description, then the further docs; the
/// table (`pub const KNOBS: &[Knob<Cfg>]`) lists the knobs in field order;
/// `Default` gives every field its default.
#[macro_export]
macro_rules! knob_table {
    (
        $(#[$smeta:meta])*
        $vis:vis struct $name:ident in $table:ident {
            $(
                $(#[$fmeta:meta])*
                $field:ident : $ty:ty = $default:expr ; $range:expr , $unit:expr , $desc:literal ;
            )*
        }
    ) => {
        $(#[$smeta])*
        $vis struct $name {
            $(
                #[doc = $desc]
                #[doc = ""]
                $(#[$fmeta])*
                pub $field: $ty,
            )*
        }

        impl Default for $name {
            /// Every knob at its declared default.
            fn default() -> Self {
                $name { $($field: $default),* }
            }
        }

        /// Every knob, in field order: name, unit, description, range,
        /// get and set (`knob::Knob`).
        $vis const $table: &[$crate::knob::Knob<$name>] = &[
            $(
                $crate::knob::Knob {
                    name: stringify!($field),
                    unit: $unit,
                    description: $desc,
                    range: $range,
                    get: |c: &$name| $crate::knob::KnobType::to_knob(&c.$field),
                    set: |c: &mut $name, v: $crate::knob::KnobValue| {
                        c.$field = $crate::knob::KnobType::from_knob(v)?;
                        Ok(())
                    },
                },
            )*
        ];
    };
}
