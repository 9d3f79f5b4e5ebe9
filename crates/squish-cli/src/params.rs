//! Parameters from the command line: `--params FILE.toml` and `--set KEY=VALUE`.
//!
//! The keys are the library's own field names ([`ObjectParams`], [`PairParams`]) with a prefix
//! naming what they apply to: `a.` and `b.` for the two objects, `pair.` for the pair. Nested
//! fields use dots (`a.profile.x2=0.4`). The command line never re-declares a parameter: values
//! are merged into the serialized defaults and deserialized back, so every field of the library
//! is settable and an unknown key is an error that lists the valid ones.
//!
//! Values: numbers, `true`/`false`, comma-separated vectors (`0,1,0`), `auto`/`none` for
//! optional values left to the library (an automatic extent or mapping direction), or JSON.

use std::path::Path;

use serde_json::{Map, Value};
use squish::ObjectParams;
use squish::contact::PairParams;

use crate::error::CliError;

/// Parameters of a two-object command (`contact`, `deform`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PairSettings {
    pub a: ObjectParams,
    pub b: ObjectParams,
    pub pair: PairParams,
}

/// Reads `--params` (if any), then applies every `--set`, in order.
pub fn pair_settings(params_file: Option<&Path>, sets: &[String]) -> Result<PairSettings, CliError> {
    let defaults = PairSettings::default();
    let mut values = Map::new();
    values.insert("a".into(), to_json(&defaults.a)?);
    values.insert("b".into(), to_json(&defaults.b)?);
    values.insert("pair".into(), to_json(&defaults.pair)?);
    let mut root = Value::Object(values);
    if let Some(path) = params_file {
        let text = std::fs::read_to_string(path)
            .map_err(|e| CliError::input(format!("cannot read parameters {}: {e}", path.display())))?;
        let table: toml::Table = toml::from_str(&text)
            .map_err(|e| CliError::input(format!("{}: {}", path.display(), e.to_string().trim())))?;
        let file_values = serde_json::to_value(table)?;
        merge(&mut root, &file_values, "", &path.display().to_string())?;
    }
    for set in sets {
        let (key, value) = set
            .split_once('=')
            .ok_or_else(|| CliError::input(format!("--set {set}: expected KEY=VALUE, e.g. --set a.extent=0.4")))?;
        let path: Vec<&str> = key.trim().split('.').collect();
        set_path(&mut root, &path, parse_value(value.trim()), &format!("--set {set}"))?;
    }
    let take = |name: &str| root.get(name).cloned().unwrap_or(Value::Null);
    Ok(PairSettings {
        a: from_json(take("a"), "a")?,
        b: from_json(take("b"), "b")?,
        pair: from_json(take("pair"), "pair")?,
    })
}

fn to_json<T: serde::Serialize>(value: &T) -> Result<Value, CliError> {
    Ok(serde_json::to_value(value)?)
}

fn from_json<T: serde::de::DeserializeOwned>(value: Value, prefix: &str) -> Result<T, CliError> {
    serde_json::from_value(value).map_err(|e| CliError::input(format!("parameters of \"{prefix}\": {e}")))
}

/// A command-line value as JSON.
pub fn parse_value(text: &str) -> Value {
    match text {
        "auto" | "none" | "null" => return Value::Null,
        "true" => return Value::Bool(true),
        "false" => return Value::Bool(false),
        _ => {}
    }
    if let Ok(number) = text.parse::<f64>()
        && let Some(n) = serde_json::Number::from_f64(number)
    {
        return Value::Number(n);
    }
    if text.contains(',') && !text.starts_with('[') {
        let parts: Vec<Value> = text.split(',').map(|p| parse_value(p.trim())).collect();
        return Value::Array(parts);
    }
    serde_json::from_str(text).unwrap_or_else(|_| Value::String(text.to_string()))
}

/// Sets `root[path] = value`, refusing keys that the defaults do not have.
fn set_path(root: &mut Value, path: &[&str], value: Value, context: &str) -> Result<(), CliError> {
    let mut node = root;
    for (depth, key) in path.iter().enumerate() {
        let Value::Object(map) = node else {
            return Err(CliError::input(format!("{context}: \"{}\" has no fields", path[..depth].join("."))));
        };
        if !map.contains_key(*key) {
            let mut valid: Vec<&String> = map.keys().collect();
            valid.sort();
            let valid: Vec<String> = valid.iter().map(|k| format!("{}{k}", prefix_of(&path[..depth]))).collect();
            return Err(CliError::input(format!(
                "{context}: unknown key \"{}\"; valid keys here: {}",
                path[..=depth].join("."),
                valid.join(", ")
            )));
        }
        if depth + 1 == path.len() {
            map.insert((*key).to_string(), value);
            return Ok(());
        }
        // Optional sub-structures left at `null` become objects when a field of them is set.
        let child = map.get_mut(*key).ok_or_else(|| CliError::input(format!("{context}: bad key")))?;
        node = child;
    }
    Err(CliError::input(format!("{context}: empty key")))
}

fn prefix_of(path: &[&str]) -> String {
    if path.is_empty() { String::new() } else { format!("{}.", path.join(".")) }
}

/// Merges a parameters file (tables `[a]`, `[b]`, `[pair]`) into the defaults.
fn merge(root: &mut Value, file: &Value, prefix: &str, source: &str) -> Result<(), CliError> {
    let Value::Object(entries) = file else { return Ok(()) };
    for (key, value) in entries {
        let path = if prefix.is_empty() { key.clone() } else { format!("{prefix}.{key}") };
        let is_table = matches!(value, Value::Object(_));
        let existing_is_table = path_value(root, &path).is_some_and(Value::is_object);
        if is_table && existing_is_table {
            merge(root, value, &path, source)?;
        } else {
            let parts: Vec<&str> = path.split('.').collect();
            set_path(root, &parts, value.clone(), source)?;
        }
    }
    Ok(())
}

fn path_value<'v>(root: &'v Value, path: &str) -> Option<&'v Value> {
    path.split('.').try_fold(root, |node, key| node.get(key))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_applies_values_to_the_library_structures() {
        let sets: Vec<String> = [
            "b.rigid=true",
            "a.extent=0.4",
            "pair.contact_tau=0.5",
            "pair.direction=0,1,0",
            "a.bulge=1.5",
            "a.profile.x2=0.4",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let settings = pair_settings(None, &sets).unwrap();
        assert!(settings.b.rigid);
        assert_eq!(settings.a.extent, Some(0.4));
        assert_eq!(settings.pair.contact_tau, 0.5);
        assert_eq!(settings.pair.direction, Some(glam::DVec3::Y));
        assert_eq!(settings.a.bulge, 1.5);
        assert_eq!(settings.a.profile.x2, 0.4);
        let settings = pair_settings(None, &["a.extent=auto".into()]).unwrap();
        assert_eq!(settings.a.extent, None);
        // Method A's choices and working regions, as words or JSON.
        let sets: Vec<String> = [
            "b.direction_field=parallel_transport",
            r#"pair.contact_method={"ball":{"radius":0.3}}"#,
            "pair.mapping=shared_parametrization",
            "a.region=components",
            r#"b.region={"distance":0.5}"#,
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let settings = pair_settings(None, &sets).unwrap();
        assert_eq!(settings.b.direction_field, squish::deform::DirectionFieldMethod::ParallelTransport);
        assert_eq!(settings.pair.contact_method, squish::contact::ContactMethod::Ball { radius: 0.3 });
        assert_eq!(settings.pair.mapping, squish::contact::MappingMethod::SharedParametrization);
        assert_eq!(settings.a.region, squish::pipeline::WorkingRegion::Components);
        assert_eq!(settings.b.region, squish::pipeline::WorkingRegion::Distance(0.5));
    }

    #[test]
    fn unknown_keys_and_bad_values_are_errors() {
        let err = pair_settings(None, &["a.extnet=0.4".into()]).unwrap_err().to_string();
        assert!(err.contains("a.extnet") && err.contains("a.extent"), "{err}");
        let err = pair_settings(None, &["c.extent=0.4".into()]).unwrap_err().to_string();
        assert!(err.contains("\"c\""), "{err}");
        let err = pair_settings(None, &["a.stiffness=soft".into()]).unwrap_err().to_string();
        assert!(err.contains("parameters of \"a\""), "{err}");
        let err = pair_settings(None, &["a.extent".into()]).unwrap_err().to_string();
        assert!(err.contains("KEY=VALUE"), "{err}");
    }

    #[test]
    fn a_parameters_file_is_merged_then_overridden_by_set() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("params.toml");
        std::fs::write(&path, "[a]\nextent = 0.3\nbulge = 2.0\n[a.profile]\nx2 = 0.45\n[pair]\ncontact_tau = -0.5\n")
            .unwrap();
        let settings = pair_settings(Some(&path), &["a.bulge=0.5".into()]).unwrap();
        assert_eq!(settings.a.extent, Some(0.3));
        assert_eq!(settings.a.bulge, 0.5);
        assert_eq!(settings.a.profile.x2, 0.45);
        assert_eq!(settings.pair.contact_tau, -0.5);
        std::fs::write(&path, "[a]\nstifness = 2\n").unwrap();
        let err = pair_settings(Some(&path), &[]).unwrap_err().to_string();
        assert!(err.contains("stifness") && err.contains("params.toml"), "{err}");
    }
}
