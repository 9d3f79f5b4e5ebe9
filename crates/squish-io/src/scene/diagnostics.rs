//! Error messages about the scene file itself: every one names the file, the line and column,
//! the key, and the fix.
//!
//! The text is parsed twice: once by serde into the typed description, once into toml's spanned
//! document tree, which maps any byte offset back to the key path that contains it (so that a
//! serde message can say *where* — "in [[objects]] "ball"") and any key path to its line (so that
//! checks made after deserialization, such as duplicate names, can point at the key).
//!
//! Errors are [`IoError::Line`] with the column first in the message, so that they print as
//! `scene.toml:12:1: unknown key …`, the `file:line:column:` form editors jump to.

use std::path::Path;

use toml::Spanned;
use toml::de::{DeTable, DeValue};

use squish::params::did_you_mean;

use crate::IoError;

/// A step of a key path: a table key or an array index.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Seg<'a> {
    Key(&'a str),
    Index(usize),
}

/// The scene file's text and its spanned document tree.
pub(crate) struct SourceText<'a> {
    pub(crate) path: &'a Path,
    text: &'a str,
    root: Option<Spanned<DeTable<'a>>>,
}

impl<'a> SourceText<'a> {
    /// Parses the document tree; a syntax error is returned located.
    pub(crate) fn parse(path: &'a Path, text: &'a str) -> Result<Self, IoError> {
        let mut source = Self { path, text, root: None };
        match DeTable::parse(text) {
            Ok(root) => source.root = Some(root),
            Err(e) => {
                let offset = e.span().map_or(0, |s| s.start);
                let message = format!("invalid TOML: {}", e.message().trim_end());
                return Err(source.error_at(offset, message));
            }
        }
        Ok(source)
    }

    /// A source without text (a description built in code or read from JSON): errors name
    /// the keys but no line.
    pub(crate) fn detached(path: &'a Path) -> Self {
        Self { path, text: "", root: None }
    }

    /// 1-based line and column (in characters) of a byte offset.
    pub(crate) fn line_col(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let before = &self.text[..floor_char_boundary(self.text, offset)];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        let column = before[line_start..].chars().count() + 1;
        (line, column)
    }

    /// An error located at a byte offset: `file:line: message`, with `column N: ` first when the
    /// place is not at the start of its line (e.g. a key inside an inline table).
    pub(crate) fn error_at(&self, offset: usize, message: impl std::fmt::Display) -> IoError {
        let (line, column) = self.line_col(offset);
        let text = if column > 1 { format!("column {column}: {message}") } else { message.to_string() };
        IoError::line(self.path, line, text)
    }

    /// An error located at the key `path` (or, if that key is absent, at the nearest enclosing
    /// table that is present), prefixed with the key's description.
    pub(crate) fn error_at_key(&self, path: &[Seg], message: impl std::fmt::Display) -> IoError {
        self.error_at(self.locate(path), format_args!("{}: {message}", self.describe(path)))
    }

    /// Byte offset of the key `path` (its key, not its value), or of the nearest ancestor found.
    pub(crate) fn locate(&self, path: &[Seg]) -> usize {
        let Some(root) = &self.root else { return 0 };
        let mut offset = 0;
        let mut value: Option<&DeValue> = None;
        let mut table: Option<&DeTable> = Some(root.get_ref());
        for seg in path {
            match (seg, table, value) {
                (Seg::Key(k), Some(t), _) => match t.get_key_value(*k) {
                    Some((key, v)) => {
                        offset = key.span().start;
                        value = Some(v.get_ref());
                        table = v.get_ref().as_table();
                    }
                    None => return offset,
                },
                (Seg::Index(i), _, Some(DeValue::Array(a))) => match a.get(*i) {
                    Some(v) => {
                        value = Some(v.get_ref());
                        table = v.get_ref().as_table();
                        // A table element: point at its first key (an array-of-tables element's
                        // own span may start at its header or its first key, depending on form).
                        offset = table.and_then(|t| t.keys().map(|k| k.span().start).min()).unwrap_or(v.span().start);
                    }
                    None => return offset,
                },
                _ => return offset,
            }
        }
        offset
    }

    /// The key path whose value contains `offset`, as deep as it goes.
    pub(crate) fn path_at(&self, offset: usize) -> Vec<Seg<'_>> {
        let mut path = Vec::new();
        let Some(root) = &self.root else { return path };
        walk_table(root.get_ref(), offset, &mut path);
        if !path.is_empty() {
            return path;
        }
        // Tables opened by a header (`[output]`, `[[objects]]`) do not span their keys in the
        // tree: find the last header before the offset in the text, then walk inside it (for
        // inline tables on the line).
        let Some(header) =
            self.text[..floor_char_boundary(self.text, offset)].lines().map(str::trim).rfind(|l| l.starts_with('['))
        else {
            return path;
        };
        let array = header.starts_with("[[");
        let name = header.trim_start_matches('[').split(']').next().unwrap_or("").trim();
        if array && let Some((outer, inner)) = name.split_once('.') {
            return self.nested_path_at(offset, outer.trim(), inner.trim());
        }
        let Some(entry) = root.get_ref().get(name) else { return path };
        path.push(Seg::Key(name));
        let table = if array {
            let before = &self.text[..floor_char_boundary(self.text, offset)];
            let count = before
                .lines()
                .map(str::trim)
                .filter(|l| {
                    l.starts_with("[[") && l.trim_start_matches('[').split(']').next().map(str::trim) == Some(name)
                })
                .count();
            let index = count.saturating_sub(1);
            path.push(Seg::Index(index));
            entry.get_ref().as_array().and_then(|a| a.get(index)).and_then(|e| e.get_ref().as_table())
        } else {
            entry.get_ref().as_table()
        };
        if let Some(table) = table {
            walk_table(table, offset, &mut path);
        }
        path
    }

    /// The path of `offset` under a nested array-of-tables header `[[outer.inner]]` (as
    /// `[[objects.self_contact]]`): the last `[[outer]]` entry before `offset`, and the entry of
    /// its `inner` array opened by the last such header since.
    fn nested_path_at<'s>(&'s self, offset: usize, outer: &'s str, inner: &'s str) -> Vec<Seg<'s>> {
        let mut path = Vec::new();
        let Some(root) = &self.root else { return path };
        let before = &self.text[..floor_char_boundary(self.text, offset)];
        let header_of = |l: &str| -> Option<String> {
            let l = l.trim();
            if !l.starts_with("[[") {
                return None;
            }
            let name = l.trim_start_matches('[').split(']').next()?;
            Some(name.split('.').map(str::trim).collect::<Vec<_>>().join("."))
        };
        let (mut outer_count, mut inner_count) = (0usize, 0usize);
        let nested = format!("{outer}.{inner}");
        for line in before.lines() {
            match header_of(line) {
                Some(h) if h == outer => {
                    outer_count += 1;
                    inner_count = 0;
                }
                Some(h) if h == nested => inner_count += 1,
                _ => {}
            }
        }
        let (Some(o), Some(k)) = (outer_count.checked_sub(1), inner_count.checked_sub(1)) else { return path };
        path.extend([Seg::Key(outer), Seg::Index(o), Seg::Key(inner), Seg::Index(k)]);
        let table = root
            .get_ref()
            .get(outer)
            .and_then(|v| v.get_ref().as_array())
            .and_then(|a| a.get(o))
            .and_then(|v| v.get_ref().as_table())
            .and_then(|t| t.get(inner))
            .and_then(|v| v.get_ref().as_array())
            .and_then(|a| a.get(k))
            .and_then(|v| v.get_ref().as_table());
        if let Some(table) = table {
            walk_table(table, offset, &mut path);
        }
        path
    }

    /// Describes a key path for messages: `[[objects]] "ball" transform.translate`,
    /// `[[pairs]] #2 direction`, `[frames] end`.
    pub(crate) fn describe(&self, path: &[Seg]) -> String {
        let mut out = String::new();
        let mut rest = path;
        if let [Seg::Key(section), Seg::Index(i), tail @ ..] = path {
            out = match (*section, self.object_name(*i)) {
                ("objects", Some(name)) => format!("[[objects]] \"{name}\""),
                _ => format!("[[{section}]] #{}", i + 1),
            };
            rest = tail;
        } else if let [Seg::Key(section), tail @ ..] = path {
            if tail.is_empty() {
                return (*section).to_string();
            }
            out = format!("[{section}]");
            rest = tail;
        }
        let mut entry_name = String::new();
        if let ([Seg::Key("objects"), Seg::Index(i), ..], [Seg::Key("self_contact"), Seg::Index(k), tail @ ..]) =
            (path, rest)
            && let Some(name) = self.self_contact_name(*i, *k)
        {
            entry_name = format!(" self_contact \"{name}\"");
            rest = tail;
        }
        let out = out + &entry_name;
        let keys: Vec<String> = rest
            .iter()
            .map(|s| match s {
                Seg::Key(k) => (*k).to_string(),
                Seg::Index(i) => format!("[{i}]"),
            })
            .collect();
        let keys = keys.join(".").replace(".[", "[");
        match (out.is_empty(), keys.is_empty()) {
            (true, true) => "the top level".to_string(),
            (true, false) => keys,
            (false, true) => out,
            (false, false) => format!("{out} {keys}"),
        }
    }

    /// The `name` of `[[objects]]` number `i`, as written.
    fn self_contact_name(&self, i: usize, k: usize) -> Option<&str> {
        let root = self.root.as_ref()?;
        let object = root.get_ref().get("objects")?.get_ref().as_array()?.get(i)?;
        let entry = object.get_ref().as_table()?.get("self_contact")?.get_ref().as_array()?.get(k)?;
        entry.get_ref().as_table()?.get("name")?.get_ref().as_str()
    }

    fn object_name(&self, i: usize) -> Option<&str> {
        let root = self.root.as_ref()?;
        let object = root.get_ref().get("objects")?.get_ref().as_array()?.get(i)?;
        object.get_ref().as_table()?.get("name")?.get_ref().as_str()
    }

    /// Turns a toml/serde error into a located message in the scene's words: unknown keys and
    /// values get a "did you mean", and every message says which table and key it is about.
    pub(crate) fn toml_error(&self, error: &toml::de::Error) -> IoError {
        let offset = error.span().map_or(0, |s| s.start);
        // An error without a place is about the whole file (a missing top-level key): offset 0
        // would name whatever table the file starts with.
        let path = if error.span().is_some() { self.path_at(offset) } else { Vec::new() };
        let place = self.describe(&path);
        let message = error.message().trim_end();
        let text = if let Some((name, expected)) = parse_unknown(message, "unknown field `") {
            let known: Vec<&str> = expected.iter().map(String::as_str).collect();
            let hint = match did_you_mean(&name, &known) {
                Some(s) => format!(" (did you mean \"{s}\"?)"),
                None if known.is_empty() => String::new(),
                None => format!("; valid keys: {}", known.join(", ")),
            };
            format!("unknown key \"{name}\" in {place}{hint}")
        } else if let Some((name, expected)) = parse_unknown(message, "unknown variant `") {
            let known: Vec<&str> = expected.iter().map(String::as_str).collect();
            let quoted: Vec<String> = known.iter().map(|k| format!("\"{k}\"")).collect();
            let hint = match did_you_mean(&name, &known) {
                Some(s) => format!(" (did you mean \"{s}\"?)"),
                None => String::new(),
            };
            format!("{place}: unknown value \"{name}\"; use {}{hint}", or_list(&quoted))
        } else if let Some(found) =
            message.strip_prefix("invalid type: ").and_then(|m| m.strip_suffix(", expected a map"))
        {
            format!(
                "{place}: expected a table {{ key = value, … }}, not {found}; see docs/scene-format.md for its keys"
            )
        } else if let Some(rest) = message.strip_prefix("missing field `") {
            let name = rest.split('`').next().unwrap_or(rest);
            format!("{place}: missing key \"{name}\"; add {name} = …")
        } else {
            format!("{place}: {message}")
        };
        self.error_at(offset, text)
    }
}

fn walk_table<'s>(table: &'s DeTable<'_>, offset: usize, path: &mut Vec<Seg<'s>>) {
    if let Some((k, v)) = table.iter().find(|(_, v)| contains(v, offset)) {
        path.push(Seg::Key(k.get_ref()));
        walk_value(v.get_ref(), offset, path);
    }
}

fn walk_value<'s>(value: &'s DeValue<'_>, offset: usize, path: &mut Vec<Seg<'s>>) {
    match value {
        DeValue::Table(t) => walk_table(t, offset, path),
        DeValue::Array(a) => {
            if let Some((i, v)) = a.iter().enumerate().find(|(_, v)| contains(v, offset)) {
                path.push(Seg::Index(i));
                walk_value(v.get_ref(), offset, path);
            }
        }
        _ => {}
    }
}

fn contains(v: &Spanned<DeValue>, offset: usize) -> bool {
    let span = v.span();
    span.start <= offset && offset < span.end.max(span.start + 1)
}

fn floor_char_boundary(text: &str, i: usize) -> usize {
    let mut i = i.min(text.len());
    while i > 0 && !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// Parses serde's ``unknown field `x`, expected one of `a`, `b` `` (or `expected `a` or `b``,
/// `expected `a``, `there are no fields`) into the name and the expected names.
fn parse_unknown(message: &str, prefix: &str) -> Option<(String, Vec<String>)> {
    let rest = message.strip_prefix(prefix)?;
    let end = rest.find('`')?;
    let name = rest[..end].to_string();
    let expected = rest[end + 1..].split('`').skip(1).step_by(2).map(str::to_string).collect();
    Some((name, expected))
}

/// "a", "a or b", "a, b or c".
pub(crate) fn or_list(items: &[String]) -> String {
    match items {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_messages_parse() {
        let (n, e) = parse_unknown("unknown field `stifness`, expected one of `name`, `stiffness`", "unknown field `")
            .expect("parses");
        assert_eq!(n, "stifness");
        assert_eq!(e, vec!["name", "stiffness"]);
        let (_, e) = parse_unknown("unknown field `x`, expected `a` or `b`", "unknown field `").expect("parses");
        assert_eq!(e, vec!["a", "b"]);
    }
}
