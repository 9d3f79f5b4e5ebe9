//! `squish params [--json] [--markdown LEVEL]`: the parameter schema ([`squish_shot::schema`]),
//! from the one declaration of every parameter.
//!
//! The text form is for people; `--json` for front ends and scripts (the schema rows of
//! [`squish::params::SchemaEntry`]); `--markdown LEVEL` prints the table that README.md and
//! docs/scene-format.md hold for that level (a test checks that they are the same).

use clap::{Args, ValueEnum};
use squish::params::{ParamKind, SchemaEntry};
use squish_shot::schema::{self, schema_json};

use crate::console::say;
use crate::error::CliError;

#[derive(Args, Debug)]
pub struct ParamsArgs {
    /// Print the schema as JSON (every key with its level, kind, unit, default, range, thesis
    /// symbol and section, meaning, whether it can be keyframed).
    #[arg(long, conflicts_with = "markdown")]
    pub json: bool,
    /// Print one level's parameters as the Markdown table of the docs.
    #[arg(long, value_enum, value_name = "LEVEL")]
    pub markdown: Option<Level>,
}

/// A group of parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Level {
    /// `[[objects]]`, `--set a.KEY` / `b.KEY`.
    Object,
    /// `[[pairs]]`, `--set pair.KEY`.
    Pair,
    /// `[[objects.self_contact]]`.
    Articulation,
    /// The scene file's `frames` and `output`.
    Scene,
}

impl From<Level> for schema::Level {
    fn from(level: Level) -> Self {
        match level {
            Level::Object => Self::Object,
            Level::Pair => Self::Pair,
            Level::Articulation => Self::Articulation,
            Level::Scene => Self::Scene,
        }
    }
}

impl Level {
    const ALL: [Self; 4] = [Self::Object, Self::Pair, Self::Articulation, Self::Scene];

    /// The schema rows of the level.
    pub fn entries(self) -> Vec<SchemaEntry> {
        schema::Level::from(self).entries()
    }

    fn title(self) -> &'static str {
        match self {
            Self::Object => "object parameters: [[objects]] in a scene, --set a.KEY / b.KEY, [a] / [b] in --params",
            Self::Pair => "pair parameters: [[pairs]] in a scene, --set pair.KEY, [pair] in --params",
            Self::Articulation => "articulation parameters: [[objects.self_contact]] in a scene",
            Self::Scene => "scene settings: the scene file's frames and output tables",
        }
    }
}

/// The type column: `number`, `"a" | "b"`, `vector or auto` …
fn kind_text(entry: &SchemaEntry) -> String {
    let info = entry.info;
    let base = match info.kind {
        ParamKind::Choice(words) => words.iter().map(|w| format!("`\"{w}\"`")).collect::<Vec<_>>().join(" \\| "),
        ParamKind::NumberPair => "number or `[a, b]`".to_string(),
        ParamKind::Direction => "vector `[x, y, z]`".to_string(),
        ParamKind::PerVertex => "per-vertex values".to_string(),
        kind => kind.name().to_string(),
    };
    if info.optional { format!("{base} or `\"{}\"`", info.word) } else { base }
}

/// The valid column: the range and the unit.
fn valid_text(entry: &SchemaEntry) -> String {
    let info = entry.info;
    let range = match info.kind {
        ParamKind::Number | ParamKind::Integer | ParamKind::NumberPair | ParamKind::PerVertex => {
            let text = info.range.describe();
            if text == "finite" && info.kind == ParamKind::PerVertex { String::new() } else { text }
        }
        ParamKind::Direction => "non-zero".to_string(),
        _ => String::new(),
    };
    match (range.is_empty(), info.unit.is_empty()) {
        (true, true) => String::new(),
        (true, false) => info.unit.to_string(),
        (false, true) => range,
        (false, false) => format!("{range}, {}", info.unit),
    }
}

/// The default column: the value, or how the word value is derived.
fn default_text(entry: &SchemaEntry) -> String {
    let info = entry.info;
    if info.required {
        return "required".to_string();
    }
    let value = match &entry.default {
        squish::params::ParamValue::Number(x) => format_number(*x),
        squish::params::ParamValue::Word(w) if info.kind == ParamKind::Text => format!("`\"{w}\"`"),
        v => format!("`{v}`"),
    };
    if info.optional && entry.default.is_word(info.word) && !info.auto.is_empty() {
        format!("{value}: {}", info.auto)
    } else {
        value
    }
}

/// A default as a person writes it: `1/3` stays `0.3333`.
fn format_number(x: f64) -> String {
    let text = squish::params::number(x);
    let short = format!("{x:.4}");
    let short = short.trim_end_matches('0').trim_end_matches('.').to_string();
    if text.len() > short.len() + 2 && x.is_finite() { format!("`{short}`") } else { format!("`{text}`") }
}

/// One level's parameters as the docs' Markdown table.
pub fn markdown(level: Level) -> String {
    let mut out =
        String::from("| key | type | default | valid | thesis | keys | meaning |\n|---|---|---|---|---|---|---|\n");
    for entry in level.entries() {
        let info = entry.info;
        let thesis = match (info.symbol.is_empty(), info.section.is_empty()) {
            (true, true) => String::new(),
            (false, true) => info.symbol.to_string(),
            (true, false) => info.section.to_string(),
            (false, false) => format!("{}, {}", info.symbol, info.section),
        };
        let keyed = if info.keyframable { "yes" } else { "" };
        out.push_str(&format!(
            "| `{}` | {} | {} | {} | {} | {} | {} |\n",
            info.path(),
            kind_text(&entry),
            default_text(&entry).replace('|', "\\|"),
            valid_text(&entry),
            thesis,
            keyed,
            info.summary.replace('|', "\\|"),
        ));
    }
    out
}

pub fn run(args: &ParamsArgs) -> Result<(), CliError> {
    if args.json {
        say!("{}", schema_json()?);
        return Ok(());
    }
    if let Some(level) = args.markdown {
        print!("{}", markdown(level));
        return Ok(());
    }
    for level in Level::ALL {
        say!("{}", level.title());
        for entry in level.entries() {
            let info = entry.info;
            let thesis = [info.symbol, info.section].iter().filter(|s| !s.is_empty()).copied().collect::<Vec<_>>();
            let keyed = if info.keyframable { ", keyframable" } else { "" };
            say!(
                "  {:<28} {}; default {}{}{keyed}",
                info.path(),
                kind_text(&entry).replace('`', "").replace("\\|", "|"),
                default_text(&entry).replace('`', ""),
                if valid_text(&entry).is_empty() { String::new() } else { format!("; {}", valid_text(&entry)) },
            );
            let thesis = if thesis.is_empty() { String::new() } else { format!(" ({})", thesis.join(", ")) };
            say!("  {:<28} {}{thesis}", "", info.summary);
        }
        say!("");
    }
    say!("`squish params --json` gives the same as JSON; docs/scene-format.md shows them in scene files.");
    Ok(())
}
