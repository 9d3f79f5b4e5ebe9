//! Parameter values ([`ParamValue`]) and the field types that convert to and from them
//! ([`ParamType`]).

use std::fmt;

use glam::DVec3;

use super::{ParamInfo, ParamKind};

/// A parameter's value as every entry point writes it: `true`, `0.5`, `[0, 0, 1]`, `"auto"`.
/// Infinity is the number `inf` (written as the word `"inf"` in JSON, which has no infinity).
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    Bool(bool),
    Number(f64),
    List(Vec<f64>),
    Word(String),
}

impl ParamValue {
    /// True if the value is the word `word`.
    pub fn is_word(&self, word: &str) -> bool {
        matches!(self, Self::Word(w) if w == word)
    }

    /// The kind of value, in words, for messages.
    pub fn describe(&self) -> &'static str {
        match self {
            Self::Bool(_) => "a boolean",
            Self::Number(_) => "a number",
            Self::List(_) => "a list of numbers",
            Self::Word(_) => "a word",
        }
    }
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            Self::Bool(b) => write!(f, "{b}"),
            Self::Number(x) => f.write_str(&super::number(*x)),
            Self::List(xs) if xs.len() > 8 => write!(f, "[{} values]", xs.len()),
            Self::List(xs) => {
                let parts: Vec<String> = xs.iter().map(|x| super::number(*x)).collect();
                write!(f, "[{}]", parts.join(", "))
            }
            Self::Word(w) => write!(f, "\"{w}\""),
        }
    }
}

impl serde::Serialize for ParamValue {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeSeq;
        let number =
            |x: f64| if x.is_finite() { NumberOrWord::Number(x) } else { NumberOrWord::Word(super::number(x)) };
        match self {
            Self::Bool(b) => s.serialize_bool(*b),
            Self::Number(x) => number(*x).serialize(s),
            Self::List(xs) => {
                let mut seq = s.serialize_seq(Some(xs.len()))?;
                for &x in xs {
                    seq.serialize_element(&number(x))?;
                }
                seq.end()
            }
            Self::Word(w) => s.serialize_str(w),
        }
    }
}

#[derive(serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
enum NumberOrWord {
    Number(f64),
    Word(String),
}

/// The forms a value is read from: serde's untagged derive over them (JSON, TOML).
#[derive(serde::Deserialize)]
#[serde(untagged)]
enum ValueForm {
    Bool(bool),
    Integer(i64),
    Number(f64),
    List(Vec<NumberOrWord>),
    Word(String),
}

impl<'de> serde::Deserialize<'de> for ParamValue {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let form = ValueForm::deserialize(d)
            .map_err(|_| serde::de::Error::custom("expected true/false, a number, a list of numbers or a word"))?;
        let number = |n: NumberOrWord| match n {
            NumberOrWord::Number(x) => Ok(x),
            NumberOrWord::Word(w) => match w.as_str() {
                "inf" => Ok(f64::INFINITY),
                "-inf" => Ok(f64::NEG_INFINITY),
                _ => Err(serde::de::Error::custom(format!("\"{w}\" in a list of numbers"))),
            },
        };
        Ok(match form {
            ValueForm::Bool(b) => Self::Bool(b),
            // Values are f64, exact for whole numbers up to 2⁵³: a larger integer would be
            // silently rounded (i64::MAX becomes 2⁶³), so it is refused with its own digits.
            ValueForm::Integer(i) if i.unsigned_abs() > 1 << 53 => {
                return Err(serde::de::Error::custom(format!(
                    "{i} is beyond ±9007199254740992 (2^53), where whole numbers stop being exact; use a smaller number"
                )));
            }
            ValueForm::Integer(i) => Self::Number(i as f64),
            ValueForm::Number(x) => Self::Number(x),
            ValueForm::List(xs) => Self::List(xs.into_iter().map(number).collect::<Result<_, D::Error>>()?),
            ValueForm::Word(w) if w == "inf" => Self::Number(f64::INFINITY),
            ValueForm::Word(w) => Self::Word(w),
        })
    }
}

/// A field type of a [`super::Params`] struct: its kind, and its conversion to and from
/// [`ParamValue`]. `from_value` errors say what was expected (the caller adds the key).
pub trait ParamType: Sized {
    const KIND: ParamKind;
    /// True for `Option` fields: `None` is written [`ParamInfo::word`].
    const OPTIONAL: bool = false;
    fn to_value(&self, info: &ParamInfo) -> ParamValue;
    fn from_value(value: &ParamValue, info: &ParamInfo) -> Result<Self, String>;
}

fn wrong(value: &ParamValue, info: &ParamInfo) -> String {
    format!("expected {}, not {}", info.expected(), value.describe())
}

impl ParamType for bool {
    const KIND: ParamKind = ParamKind::Bool;
    fn to_value(&self, _: &ParamInfo) -> ParamValue {
        ParamValue::Bool(*self)
    }
    fn from_value(value: &ParamValue, info: &ParamInfo) -> Result<Self, String> {
        match value {
            ParamValue::Bool(b) => Ok(*b),
            _ => Err(wrong(value, info)),
        }
    }
}

impl ParamType for f64 {
    const KIND: ParamKind = ParamKind::Number;
    fn to_value(&self, _: &ParamInfo) -> ParamValue {
        ParamValue::Number(*self)
    }
    fn from_value(value: &ParamValue, info: &ParamInfo) -> Result<Self, String> {
        match value {
            ParamValue::Number(x) => Ok(*x),
            _ => Err(wrong(value, info)),
        }
    }
}

impl ParamType for i64 {
    const KIND: ParamKind = ParamKind::Integer;
    fn to_value(&self, _: &ParamInfo) -> ParamValue {
        ParamValue::Number(*self as f64)
    }
    fn from_value(value: &ParamValue, info: &ParamInfo) -> Result<Self, String> {
        match value {
            // Whole numbers within ±2⁵³ convert exactly; others are not whole frames.
            ParamValue::Number(x) if x.fract() == 0.0 && x.abs() <= 9.007_199_254_740_992e15 => Ok(*x as i64),
            _ => Err(wrong(value, info)),
        }
    }
}

impl ParamType for String {
    const KIND: ParamKind = ParamKind::Text;
    fn to_value(&self, _: &ParamInfo) -> ParamValue {
        ParamValue::Word(self.clone())
    }
    fn from_value(value: &ParamValue, info: &ParamInfo) -> Result<Self, String> {
        match value {
            ParamValue::Word(w) => Ok(w.clone()),
            _ => Err(wrong(value, info)),
        }
    }
}

impl ParamType for std::path::PathBuf {
    const KIND: ParamKind = ParamKind::Text;
    fn to_value(&self, _: &ParamInfo) -> ParamValue {
        ParamValue::Word(self.to_string_lossy().into_owned())
    }
    fn from_value(value: &ParamValue, info: &ParamInfo) -> Result<Self, String> {
        match value {
            ParamValue::Word(w) => Ok(w.into()),
            _ => Err(wrong(value, info)),
        }
    }
}

impl ParamType for DVec3 {
    const KIND: ParamKind = ParamKind::Direction;
    fn to_value(&self, _: &ParamInfo) -> ParamValue {
        ParamValue::List(self.to_array().to_vec())
    }
    fn from_value(value: &ParamValue, info: &ParamInfo) -> Result<Self, String> {
        match value {
            ParamValue::List(xs) if xs.len() == 3 => Ok(DVec3::new(xs[0], xs[1], xs[2])),
            _ => Err(wrong(value, info)),
        }
    }
}

impl ParamType for [f64; 2] {
    const KIND: ParamKind = ParamKind::NumberPair;
    fn to_value(&self, _: &ParamInfo) -> ParamValue {
        ParamValue::List(self.to_vec())
    }
    fn from_value(value: &ParamValue, info: &ParamInfo) -> Result<Self, String> {
        match value {
            ParamValue::Number(x) => Ok([*x, *x]),
            ParamValue::List(xs) if xs.len() == 2 => Ok([xs[0], xs[1]]),
            _ => Err(wrong(value, info)),
        }
    }
}

impl ParamType for Vec<f64> {
    const KIND: ParamKind = ParamKind::PerVertex;
    fn to_value(&self, _: &ParamInfo) -> ParamValue {
        ParamValue::List(self.clone())
    }
    fn from_value(value: &ParamValue, info: &ParamInfo) -> Result<Self, String> {
        match value {
            ParamValue::List(xs) => Ok(xs.clone()),
            _ => Err(wrong(value, info)),
        }
    }
}

impl<T: ParamType> ParamType for Option<T> {
    const KIND: ParamKind = T::KIND;
    const OPTIONAL: bool = true;
    fn to_value(&self, info: &ParamInfo) -> ParamValue {
        match self {
            Some(v) => v.to_value(info),
            None => ParamValue::Word(info.word.to_string()),
        }
    }
    fn from_value(value: &ParamValue, info: &ParamInfo) -> Result<Self, String> {
        if value.is_word(info.word) { Ok(None) } else { T::from_value(value, info).map(Some) }
    }
}

/// Declares an enum of words (a [`ParamKind::Choice`]): the enum, its words, [`ParamType`], and
/// serde as the word.
#[macro_export]
#[doc(hidden)]
macro_rules! choice {
    ($(#[$meta:meta])* pub enum $name:ident { $($(#[$vmeta:meta])* $variant:ident = $word:literal),+ $(,)? }) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum $name { $($(#[$vmeta])* $variant),+ }

        impl $name {
            /// The words, in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($word),+];

            /// The word of this value.
            pub fn name(self) -> &'static str {
                match self { $(Self::$variant => $word),+ }
            }

            /// The value of a word.
            pub fn from_name(word: &str) -> Option<Self> {
                match word { $($word => Some(Self::$variant),)+ _ => None }
            }
        }

        impl $crate::params::ParamType for $name {
            const KIND: $crate::params::ParamKind = $crate::params::ParamKind::Choice(Self::NAMES);
            fn to_value(&self, _: &$crate::params::ParamInfo) -> $crate::params::ParamValue {
                $crate::params::ParamValue::Word(self.name().to_string())
            }
            fn from_value(value: &$crate::params::ParamValue, info: &$crate::params::ParamInfo) -> Result<Self, String> {
                match value {
                    $crate::params::ParamValue::Word(w) => Self::from_name(w).ok_or_else(|| {
                        let hint = $crate::params::did_you_mean(w, Self::NAMES)
                            .map(|s| format!(" (did you mean \"{s}\"?)"))
                            .unwrap_or_default();
                        format!("expected {}{hint}", info.expected())
                    }),
                    _ => Err(format!("expected {}, not {}", info.expected(), value.describe())),
                }
            }
        }

        impl serde::Serialize for $name {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.serialize_str(self.name())
            }
        }

        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let word = <String as serde::Deserialize>::deserialize(d)?;
                Self::from_name(&word).ok_or_else(|| {
                    serde::de::Error::custom(format!("unknown value \"{word}\"; use {}", $crate::params::quoted_or(Self::NAMES)))
                })
            }
        }
    };
}

crate::choice! {
    /// How the displacement direction field d is built (thesis §5.2).
    #[derive(Default)]
    pub enum DirectionFieldMethod {
        /// Method B (§5.2.2, Eq. 5.4): the mapping directions (diffused when there are several
        /// zones) blended with the input normals, `d = normalize(w(u)·d̄ + (1 − w(u))·n)`,
        /// `w = (1 − u²)⁶`.
        #[default]
        Blended = "blended",
        /// Method A (§5.2.1): the directions' tangent parts diffused over 𝒟 by parallel transport
        /// from the displacement directions at ∂𝒞 to the normals at ∂𝒟. Two more factorizations
        /// per frame.
        ParallelTransport = "parallel_transport",
    }
}
