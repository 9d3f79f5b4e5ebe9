//! The one declaration of every parameter a user can set, and the schema derived from it.
//!
//! Three structs hold the deformer's parameters, each declared once with `#[derive(Params)]`
//! (crate `squish-derive`): [`ObjectParams`] (per object: stiffness, extent, bulge, profile …),
//! [`PairParams`] (per pair of objects: τ, mapping direction, method A or B …) and
//! [`ArticulationParams`] (per articulation of a skinned object, thesis ch. 6). Each field's doc
//! comment is its meaning, its `#[param(…)]` attribute its thesis symbol and section, unit, valid
//! range and whether it can be keyframed, and the struct's `Default` its default. From that one
//! declaration come [`Params::schema`] (what `squish params` prints and the docs are checked
//! against) and typed access by key ([`Params::get`], [`Params::set`]), through which every entry
//! point — the command line's `--set`, parameter files, scene files (keyframed values included),
//! report.json, the Python module, the Blender add-on and the browser page — reads and writes
//! parameters. No entry point lists the parameters again.
//!
//! # Conventions
//! - One name per parameter wherever a user types it: the field's name (`snake_case`, no dots, so
//!   that it is also a Python keyword argument and a Blender property name). Former spellings are
//!   kept in [`ParamInfo::renamed_from`] for "did you mean" messages only.
//! - A value is a [`ParamValue`]: a boolean, a number, a list of numbers (a direction, a pair of
//!   stiffnesses, one value per vertex) or a word (a choice, or the word — usually `auto` — of an
//!   optional value the library derives). Infinity is written `inf`.
//! - Ranges are checked when a value is set, and again by [`Params::validate`] (which also checks
//!   conditions between fields, such as the profile's abscissas in order). An error names the key,
//!   the value, what is valid and the default: `stiffness = -1: must be > 0 (k, default 1)`.
//! - Defaults are the thesis' values (ch. 7 §1.3 and the figures), the same at every level except
//!   where the thesis says otherwise: τ is 0 between objects (§4.4.2) but −1 at articulations, the
//!   value of every skinning figure (Figs. 7.7, 7.8, 7.13); the safeguard angle is 80° at both.

mod articulation;
mod object;
mod pair;
mod suggest;
mod uvs;
mod value;

pub use articulation::Articulation;
pub use articulation::ArticulationParams;
pub use articulation::SkinParts;
pub use object::{MIN_PROFILE_ABSCISSA, ObjectParams, RegionChoice, VertexFlags};
pub use pair::{ContactMethod, MappingMethod, PairParams};
pub use squish_derive::Params;
pub use suggest::did_you_mean;
pub use uvs::Uvs;
pub use value::{DirectionFieldMethod, ParamType, ParamValue};

use std::fmt;

/// Which entity a parameter belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Level {
    /// The scene as a whole (declared by the scene-file layer: frames, output).
    Scene,
    /// One object (`--set a.KEY`, `[a]`, `[[objects]]`).
    Object,
    /// A pair of objects (`--set pair.KEY`, `[pair]`, `[[pairs]]`).
    Pair,
    /// An articulation of a skinned object (`[[objects.self_contact]]`).
    Articulation,
}

impl Level {
    /// The level's name in docs and the schema.
    pub fn name(self) -> &'static str {
        match self {
            Self::Scene => "scene",
            Self::Object => "object",
            Self::Pair => "pair",
            Self::Articulation => "articulation",
        }
    }
}

/// The kind of value a parameter holds (from its field's type).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    /// `true` or `false`.
    Bool,
    /// A real number.
    Number,
    /// A whole number.
    Integer,
    /// A non-zero vector `[x, y, z]` (a direction: its length does not matter).
    Direction,
    /// Two numbers `[a, b]`, or one number for both.
    NumberPair,
    /// One of a few words.
    Choice(&'static [&'static str]),
    /// One number per vertex of the object (a painted map).
    PerVertex,
    /// A text (a file or folder name).
    Text,
}

impl ParamKind {
    /// The kind's name in the schema: `bool`, `number`, `integer`, `vector`, `pair`, `choice`,
    /// `per_vertex`, `text`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Bool => "bool",
            Self::Number => "number",
            Self::Integer => "integer",
            Self::Direction => "vector",
            Self::NumberPair => "pair",
            Self::Choice(_) => "choice",
            Self::PerVertex => "per_vertex",
            Self::Text => "text",
        }
    }

    /// The words of a choice (empty for other kinds).
    pub fn choices(self) -> &'static [&'static str] {
        match self {
            Self::Choice(words) => words,
            _ => &[],
        }
    }

    /// True if values of this kind interpolate between keys (numbers, vectors, pairs); booleans
    /// and choices only step.
    pub fn interpolates(self) -> bool {
        matches!(self, Self::Number | Self::Direction | Self::NumberPair)
    }
}

/// The valid values of a number, or of each component of a list: an interval whose ends may be
/// infinite, with infinity itself valid only where the interval includes it (`[1, inf]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub min: f64,
    pub min_inclusive: bool,
    pub max: f64,
    pub max_inclusive: bool,
}

impl Range {
    /// Every finite number.
    pub const FINITE: Self =
        Self { min: f64::NEG_INFINITY, min_inclusive: false, max: f64::INFINITY, max_inclusive: false };

    /// True if `x` lies in the interval (NaN never does).
    pub fn contains(&self, x: f64) -> bool {
        let above = if self.min_inclusive { x >= self.min } else { x > self.min };
        let below = if self.max_inclusive { x <= self.max } else { x < self.max };
        above && below
    }

    /// The interval in words: `finite`, `> 0`, `≥ 1 (inf allowed)`, `in (0, 90]`.
    pub fn describe(&self) -> String {
        let lower_open = self.min == f64::NEG_INFINITY;
        let upper_open = self.max == f64::INFINITY;
        let inf_note = if upper_open && self.max_inclusive { " (inf allowed)" } else { "" };
        match (lower_open, upper_open) {
            (true, true) => "finite".to_string(),
            (false, true) => {
                format!("{} {}{inf_note}", if self.min_inclusive { "≥" } else { ">" }, number(self.min))
            }
            (true, false) => format!("{} {}", if self.max_inclusive { "≤" } else { "<" }, number(self.max)),
            (false, false) => format!(
                "in {}{}, {}{}",
                if self.min_inclusive { '[' } else { '(' },
                number(self.min),
                number(self.max),
                if self.max_inclusive { ']' } else { ')' }
            ),
        }
    }

    /// The interval in the notation of `#[param(range = …)]`: `(0, inf)`.
    pub fn notation(&self) -> String {
        let end = |x: f64| {
            if x.is_infinite() { if x > 0.0 { "inf".to_string() } else { "-inf".to_string() } } else { number(x) }
        };
        format!(
            "{}{}, {}{}",
            if self.min_inclusive { '[' } else { '(' },
            end(self.min),
            end(self.max),
            if self.max_inclusive { ']' } else { ')' }
        )
    }
}

/// A number as a person writes it (`1`, `0.5`, `inf`).
pub fn number(x: f64) -> String {
    if x == f64::INFINITY {
        "inf".to_string()
    } else if x == f64::NEG_INFINITY {
        "-inf".to_string()
    } else {
        format!("{x}")
    }
}

/// Everything known about one parameter: the schema's row. Built by `#[derive(Params)]` from the
/// field's declaration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamInfo {
    /// The name a user types.
    pub key: &'static str,
    /// The table of a file that holds it (`frames`, `output`), or `""` for the deformer's
    /// parameters (set on an object, a pair or an articulation).
    pub table: &'static str,
    pub level: Level,
    pub kind: ParamKind,
    /// True if the parameter may be left to the library (`None`), written [`ParamInfo::word`].
    pub optional: bool,
    /// How an unset optional value is written (`auto`, or `joints`, `uniform`, `none`).
    pub word: &'static str,
    /// `""` (no unit), `scene units`, `degrees` …
    pub unit: &'static str,
    /// Valid numbers (of each component for lists).
    pub range: Range,
    /// The thesis' symbol (`k`, `φ_max`, `τ`), if it has one.
    pub symbol: &'static str,
    /// The thesis section (`§4.3`).
    pub section: &'static str,
    /// One-line meaning (the doc comment's first paragraph).
    pub summary: &'static str,
    /// The whole doc comment.
    pub doc: &'static str,
    /// How the value written [`ParamInfo::word`] is derived.
    pub auto: &'static str,
    /// True if scene files may key it on frames.
    pub keyframable: bool,
    /// True if a file must give it (it has no default).
    pub required: bool,
    /// Former names, for "did you mean" messages.
    pub renamed_from: &'static [&'static str],
}

impl ParamInfo {
    /// Checks a value against the kind and range, without converting it. The message says what
    /// is valid.
    pub fn check(&self, value: &ParamValue) -> Result<(), String> {
        if self.optional && value.is_word(self.word) {
            return Ok(());
        }
        let range = |x: f64| -> Result<(), String> {
            if self.range.contains(x) { Ok(()) } else { Err(format!("must be {}", self.range.describe())) }
        };
        match (self.kind, value) {
            (ParamKind::Number | ParamKind::Integer, ParamValue::Number(x)) => range(*x),
            (ParamKind::NumberPair | ParamKind::PerVertex, ParamValue::Number(x)) => range(*x),
            (ParamKind::NumberPair | ParamKind::PerVertex, ParamValue::List(xs)) => {
                xs.iter().try_for_each(|&x| range(x))
            }
            (ParamKind::Direction, ParamValue::List(xs)) => {
                if xs.len() == 3 && xs.iter().all(|x| x.is_finite()) && xs.iter().any(|&x| x != 0.0) {
                    Ok(())
                } else {
                    Err("must be a non-zero vector of three finite numbers".to_string())
                }
            }
            _ => Ok(()),
        }
    }

    /// The values that are valid, in words: `a number > 0`, `true or false`,
    /// `"geometric" or "ball"`, `a non-zero vector x,y,z or "auto"`.
    pub fn expected(&self) -> String {
        let base = match self.kind {
            ParamKind::Bool => "true or false".to_string(),
            ParamKind::Number => format!("a number {}", self.range.describe()),
            ParamKind::Integer => format!("a whole number {}", self.range.describe()),
            ParamKind::Direction => "a non-zero vector x,y,z".to_string(),
            ParamKind::NumberPair => format!("a number or two [a, b], {}", self.range.describe()),
            ParamKind::Choice(words) => quoted_or(words),
            ParamKind::PerVertex => "one number per vertex".to_string(),
            ParamKind::Text => "a text".to_string(),
        };
        if self.optional { format!("{base} or \"{}\"", self.word) } else { base }
    }

    /// Parses a value typed as text (`--set`, a form field): words, numbers, `x,y,z` lists.
    pub fn parse(&self, text: &str) -> Result<ParamValue, String> {
        let text = text.trim();
        let unexpected = || format!("cannot read \"{text}\" as {}", self.expected());
        if self.optional && text == self.word {
            return Ok(ParamValue::Word(text.to_string()));
        }
        let parse_number = |s: &str| -> Option<f64> {
            match s.trim() {
                "inf" | "+inf" | "infinity" => Some(f64::INFINITY),
                "-inf" | "-infinity" => Some(f64::NEG_INFINITY),
                s => s.parse::<f64>().ok().filter(|x| !x.is_nan()),
            }
        };
        let list = |s: &str| -> Option<Vec<f64>> {
            let s = s.trim().trim_start_matches('[').trim_end_matches(']');
            s.split(',').map(parse_number).collect()
        };
        match self.kind {
            ParamKind::Bool => match text.to_ascii_lowercase().as_str() {
                "true" | "yes" | "on" | "1" => Ok(ParamValue::Bool(true)),
                "false" | "no" | "off" | "0" => Ok(ParamValue::Bool(false)),
                _ => Err(unexpected()),
            },
            ParamKind::Number | ParamKind::Integer => parse_number(text).map(ParamValue::Number).ok_or_else(unexpected),
            ParamKind::Direction | ParamKind::NumberPair | ParamKind::PerVertex => {
                if !text.contains(',')
                    && self.kind != ParamKind::Direction
                    && let Some(x) = parse_number(text)
                {
                    return Ok(ParamValue::Number(x));
                }
                list(text).map(ParamValue::List).ok_or_else(unexpected)
            }
            ParamKind::Choice(words) => {
                if words.contains(&text) {
                    Ok(ParamValue::Word(text.to_string()))
                } else {
                    let hint =
                        did_you_mean(text, words).map(|w| format!(" (did you mean \"{w}\"?)")).unwrap_or_default();
                    Err(format!("\"{text}\" is not {}{hint}", self.expected()))
                }
            }
            ParamKind::Text => Ok(ParamValue::Word(text.to_string())),
        }
    }

    /// The full key as typed with a prefix (`a.stiffness`); the bare key without one.
    pub fn qualified(&self, prefix: &str) -> String {
        if prefix.is_empty() { self.key.to_string() } else { format!("{prefix}.{}", self.key) }
    }

    /// The key with its table, as a scene file nests it: `frames.start`, `stiffness`.
    pub fn path(&self) -> String {
        self.qualified(self.table)
    }
}

/// `"a"`, `"a" or "b"`, `"a", "b" or "c"`.
pub fn quoted_or(words: &[&str]) -> String {
    let quoted: Vec<String> = words.iter().map(|w| format!("\"{w}\"")).collect();
    match quoted.as_slice() {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

/// A parameter that cannot be set or is invalid. Displays as one line naming the key, the value,
/// what is valid and, where it helps, the default or the key meant: `a.stiffness = -1: must be > 0
/// (k, default 1)`, `a.stifness: unknown object parameter (did you mean "a.stiffness"?)`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{key}{}: {message}{}", value.as_ref().map(|v| format!(" = {v}")).unwrap_or_default(), self.hint())]
pub struct ParamError {
    /// The key as the user typed it, with its prefix if any (`a.stiffness`, `pair.contact_tau`).
    pub key: String,
    /// The value given, as written back (`None` for unknown keys and conditions between keys).
    pub value: Option<String>,
    /// What is wrong and what to write instead.
    pub message: String,
    /// The key meant, with the prefix of [`ParamError::key`] (`a.stiffness`).
    pub suggestion: Option<String>,
}

impl ParamError {
    /// An error about a value or a condition (no key to suggest).
    pub fn new(key: &str, value: Option<String>, message: impl Into<String>) -> Self {
        Self { key: key.to_string(), value, message: message.into(), suggestion: None }
    }

    /// The same error with the key (and the key suggested) prefixed (`stiffness` → `a.stiffness`).
    pub fn with_prefix(mut self, prefix: &str) -> Self {
        if !prefix.is_empty() {
            self.key = format!("{prefix}.{}", self.key);
            self.suggestion = self.suggestion.map(|s| format!("{prefix}.{s}"));
        }
        self
    }

    /// An error about a condition between keys of one struct (no single value to blame).
    pub fn condition(key: &str, message: impl Into<String>) -> Self {
        Self::new(key, None, message)
    }

    /// ` (did you mean "a.stiffness"?)` when a key is suggested, else nothing.
    pub fn hint(&self) -> String {
        self.suggestion.as_ref().map(|s| format!(" (did you mean \"{s}\"?)")).unwrap_or_default()
    }
}

/// A struct of parameters declared with `#[derive(Params)]`; see the module doc.
pub trait Params: Default + Clone + fmt::Debug {
    /// The level of its keys.
    const LEVEL: Level;

    /// Every parameter, in declaration order.
    fn schema() -> &'static [ParamInfo];

    /// The value of `key`, `None` for a key that is not one of its parameters.
    fn get(&self, key: &str) -> Option<ParamValue>;

    /// Sets the field of `key` without checking its range. `Ok(false)` for an unknown key; `Err`
    /// with what was expected when the value has the wrong kind. Use [`Params::set`].
    #[doc(hidden)]
    fn set_field(&mut self, key: &str, value: &ParamValue) -> Result<bool, String>;

    /// Conditions between fields (checked by [`Params::validate`] after the ranges).
    fn check_fields(&self) -> Result<(), ParamError>;

    /// The row of `key`.
    fn info(key: &str) -> Option<&'static ParamInfo> {
        Self::schema().iter().find(|info| info.key == key)
    }

    /// Sets `key` to `value`, checking its kind and range. Errors name the key and say what is
    /// valid; an unknown key gets a "did you mean" among the parameters (and their former names).
    fn set(&mut self, key: &str, value: &ParamValue) -> Result<(), ParamError> {
        let info = Self::info(key).ok_or_else(|| unknown_key::<Self>(key))?;
        let invalid =
            |message: String| ParamError::new(key, Some(value.to_string()), with_default::<Self>(info, message));
        info.check(value).map_err(invalid)?;
        match self.set_field(key, value) {
            Ok(true) => Ok(()),
            Ok(false) => Err(unknown_key::<Self>(key)),
            Err(message) => Err(invalid(message)),
        }
    }

    /// Parses `text` for `key` ([`ParamInfo::parse`]) and sets it.
    fn set_text(&mut self, key: &str, text: &str) -> Result<(), ParamError> {
        let info = Self::info(key).ok_or_else(|| unknown_key::<Self>(key))?;
        let value =
            info.parse(text).map_err(|message| ParamError::new(key, None, with_default::<Self>(info, message)))?;
        self.set(key, &value)
    }

    /// Checks every parameter's range and the conditions between them.
    fn validate(&self) -> Result<(), ParamError> {
        for info in Self::schema() {
            if let Some(value) = self.get(info.key) {
                info.check(&value).map_err(|message| {
                    ParamError::new(info.key, Some(value.to_string()), with_default::<Self>(info, message))
                })?;
            }
        }
        self.check_fields()
    }

    /// Every parameter's value, in declaration order.
    fn values(&self) -> Vec<(&'static str, ParamValue)> {
        Self::schema().iter().filter_map(|info| Some((info.key, self.get(info.key)?))).collect()
    }

    /// The default of `key`, from the struct's `Default`.
    fn default_value(key: &str) -> Option<ParamValue> {
        Self::default().get(key)
    }
}

/// The message of an invalid value, followed by the thesis symbol and the default:
/// `must be > 0 (k, default 1)`.
fn with_default<P: Params>(info: &ParamInfo, message: String) -> String {
    let default = P::default_value(info.key).map(|v| v.to_string()).unwrap_or_default();
    match (info.symbol.is_empty(), default.is_empty()) {
        (true, true) => message,
        (true, false) => format!("{message} (default {default})"),
        (false, true) => format!("{message} ({})", info.symbol),
        (false, false) => format!("{message} ({}, default {default})", info.symbol),
    }
}

/// An unknown key, with the key meant: a former name, a near spelling, or the list.
pub fn unknown_key<P: Params>(key: &str) -> ParamError {
    let schema = P::schema();
    let keys: Vec<&str> = schema.iter().map(|i| i.key).collect();
    let what = match schema.first().map_or("", |i| i.table) {
        "" => format!("unknown {} parameter", P::LEVEL.name()),
        table => format!("unknown key in [{table}]"),
    };
    if let Some(info) = schema.iter().find(|i| i.renamed_from.contains(&key)) {
        let mut e = ParamError::new(key, None, "this key was renamed");
        e.suggestion = Some(info.key.to_string());
        return e;
    }
    match did_you_mean(key, &keys) {
        Some(k) => ParamError { suggestion: Some(k.to_string()), ..ParamError::new(key, None, what) },
        None => ParamError::new(key, None, format!("{what}; the keys are {}", keys.join(", "))),
    }
}

/// A row of the schema as front ends read it (`squish params --json`, the Python module, the
/// Blender add-on, the browser page): the parameter's declaration and its default.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SchemaEntry {
    #[serde(flatten)]
    pub info: &'static ParamInfo,
    /// The default, from the struct's `Default` (for an optional value derived by the library,
    /// its word: `auto`).
    pub default: ParamValue,
}

/// The schema rows of one struct of parameters.
pub fn entries<P: Params>() -> Vec<SchemaEntry> {
    let defaults = P::default();
    P::schema().iter().filter_map(|info| Some(SchemaEntry { info, default: defaults.get(info.key)? })).collect()
}

/// Every parameter of the deformer (object, pair, articulation), in that order.
pub fn schema_entries() -> Vec<SchemaEntry> {
    let mut all = entries::<ObjectParams>();
    all.extend(entries::<PairParams>());
    all.extend(entries::<ArticulationParams>());
    all
}

impl serde::Serialize for ParamInfo {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("key", self.key)?;
        m.serialize_entry("path", &self.path())?;
        m.serialize_entry("level", &self.level)?;
        m.serialize_entry("kind", self.kind.name())?;
        if let ParamKind::Choice(words) = self.kind {
            m.serialize_entry("choices", words)?;
        }
        m.serialize_entry("optional", &self.optional)?;
        if self.optional {
            m.serialize_entry("word", self.word)?;
            m.serialize_entry("auto", self.auto)?;
        }
        m.serialize_entry("unit", self.unit)?;
        if matches!(self.kind, ParamKind::Number | ParamKind::Integer | ParamKind::NumberPair | ParamKind::PerVertex) {
            let r = self.range;
            let range = RangeEntry {
                min: ParamValue::Number(r.min),
                min_inclusive: r.min_inclusive,
                max: ParamValue::Number(r.max),
                max_inclusive: r.max_inclusive,
                text: r.describe(),
            };
            m.serialize_entry("range", &range)?;
        }
        m.serialize_entry("symbol", self.symbol)?;
        m.serialize_entry("section", self.section)?;
        m.serialize_entry("summary", self.summary)?;
        m.serialize_entry("doc", self.doc)?;
        m.serialize_entry("keyframable", &self.keyframable)?;
        m.serialize_entry("required", &self.required)?;
        m.serialize_entry("renamed_from", self.renamed_from)?;
        m.end()
    }
}

/// The range as the schema writes it: its ends (infinite ones as `"inf"`), whether each is
/// included, and its description.
#[derive(serde::Serialize)]
struct RangeEntry {
    min: ParamValue,
    min_inclusive: bool,
    max: ParamValue,
    max_inclusive: bool,
    text: String,
}

/// Every parameter of the deformer (object, pair, articulation), in that order.
pub fn schema() -> Vec<&'static ParamInfo> {
    ObjectParams::schema().iter().chain(PairParams::schema()).chain(ArticulationParams::schema()).collect()
}

/// `Serialize` of a [`Params`] struct: a map of its parameters' values (what
/// `#[derive(Params)]` writes).
pub fn serialize_params<P: Params, S: serde::Serializer>(params: &P, serializer: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let values = params.values();
    let mut map = serializer.serialize_map(Some(values.len()))?;
    for (key, value) in &values {
        match (P::info(key).map(|i| i.kind), value) {
            // Whole numbers as integers (frames), which JSON and TOML readers expect.
            (Some(ParamKind::Integer), ParamValue::Number(x)) => map.serialize_entry(key, &(*x as i64))?,
            _ => map.serialize_entry(key, value)?,
        }
    }
    map.end()
}

/// `Deserialize` of a [`Params`] struct: a map of values over the defaults; unknown keys and
/// invalid values are errors naming the key.
pub fn deserialize_params<'de, P: Params, D: serde::Deserializer<'de>>(deserializer: D) -> Result<P, D::Error> {
    use serde::Deserialize;
    let map = std::collections::BTreeMap::<String, ParamValue>::deserialize(deserializer)?;
    let mut params = P::default();
    for (key, value) in &map {
        params.set(key, value).map_err(serde::de::Error::custom)?;
    }
    if let Some(info) = P::schema().iter().find(|i| i.required && !map.contains_key(i.key)) {
        return Err(serde::de::Error::missing_field(info.key));
    }
    params.check_fields().map_err(serde::de::Error::custom)?;
    Ok(params)
}

#[cfg(test)]
mod tests;
