//! Layers, read from the source text and the manifests (`docs/architecture.md`, "Layers"):
//!
//! - the workspace's crates point down: the core below squish-io and squish-render, those below
//!   squish-scenes (its characters read glTF skins), that below squish-shot, squish-shot below
//!   the command line and the Python module; and the Python module's dependencies hold neither
//!   the command line nor its server (axum, tokio);
//! - squish-shot's modules point down too: a module uses only modules of the layers below its own.

#[path = "../../squish/tests/layers/imports.rs"]
#[allow(dead_code)] // the cycle finder: the layers here are checked by order
mod imports;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The workspace's crates, bottom layer first.
const CRATE_LAYERS: [&[&str]; 6] = [
    &["squish-derive"],
    &["squish"],
    &["squish-io", "squish-render"],
    &["squish-scenes"],
    &["squish-shot"],
    &["squish-cli", "squish-py"],
];

/// squish-shot's modules, bottom layer first.
const MODULE_LAYERS: [&[&str]; 7] = [
    &["error"],
    &["files", "frame_quality", "interrupt", "report", "schema"],
    &["shot", "two_objects"],
    &["quality", "report_parts", "scene_shot"],
    &["outputs"],
    &["parts"],
    &["scene_run"],
];

/// What the Python module must not link: the command line and its server.
const NOT_IN_PYTHON: [&str; 3] = ["squish-cli", "axum", "tokio"];

fn crates_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The normal dependencies of a manifest (`[dependencies]` and every `[target.….dependencies]`;
/// not the dev-dependencies, which may reach up for tests).
fn dependencies(manifest: &str) -> BTreeSet<String> {
    let table: toml::Table = toml::from_str(manifest).unwrap_or_else(|e| panic!("{e}"));
    let mut names: BTreeSet<String> = table
        .get("dependencies")
        .and_then(toml::Value::as_table)
        .map(|d| d.keys().cloned().collect())
        .unwrap_or_default();
    for target in table.get("target").and_then(toml::Value::as_table).into_iter().flat_map(|t| t.values()) {
        if let Some(d) = target.get("dependencies").and_then(toml::Value::as_table) {
            names.extend(d.keys().cloned());
        }
    }
    names
}

/// Every workspace crate with its normal dependencies.
fn workspace() -> BTreeMap<String, BTreeSet<String>> {
    let root: toml::Table =
        toml::from_str(&read(&crates_dir().join("../Cargo.toml"))).unwrap_or_else(|e| panic!("{e}"));
    let members = root["workspace"]["members"].as_array().cloned().unwrap_or_default();
    members
        .iter()
        .filter_map(toml::Value::as_str)
        .map(|member| {
            let manifest = read(&crates_dir().join("..").join(member).join("Cargo.toml"));
            let table: toml::Table = toml::from_str(&manifest).unwrap_or_else(|e| panic!("{member}: {e}"));
            let name = table["package"]["name"].as_str().unwrap_or(member).to_string();
            (name, dependencies(&manifest))
        })
        .collect()
}

fn layer_of(layers: &[&[&str]], name: &str) -> Option<usize> {
    layers.iter().position(|layer| layer.contains(&name))
}

/// The uses of a workspace crate of the same layer or above, one message each.
fn upward_crates(crates: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    let mut violations = Vec::new();
    for (name, deps) in crates {
        let layer = layer_of(&CRATE_LAYERS, name).unwrap_or(usize::MAX);
        for dep in deps.iter().filter(|d| crates.contains_key(*d)) {
            let used = layer_of(&CRATE_LAYERS, dep).unwrap_or(usize::MAX);
            if used >= layer {
                violations.push(format!("{name} (layer {layer}) depends on {dep} (layer {used})"));
            }
        }
    }
    violations
}

/// What `start` links of `names`: its dependencies' closure within the workspace, and the
/// outside crates those name directly.
fn reached(crates: &BTreeMap<String, BTreeSet<String>>, start: &str, names: &[&str]) -> Vec<String> {
    let mut seen = BTreeSet::new();
    let mut todo = vec![start.to_string()];
    let mut found = BTreeSet::new();
    while let Some(name) = todo.pop() {
        if !seen.insert(name.clone()) {
            continue;
        }
        for dep in crates.get(&name).into_iter().flatten() {
            if names.contains(&dep.as_str()) {
                found.insert(format!("{name} → {dep}"));
            }
            if crates.contains_key(dep) {
                todo.push(dep.clone());
            }
        }
    }
    found.into_iter().collect()
}

#[test]
fn every_workspace_crate_has_a_layer_and_points_down() {
    let crates = workspace();
    let unplaced: Vec<&String> = crates.keys().filter(|c| layer_of(&CRATE_LAYERS, c).is_none()).collect();
    assert!(unplaced.is_empty(), "crates without a layer in this test: {unplaced:?}");
    assert!(crates["squish-cli"].contains("squish-shot") && crates["squish-py"].contains("squish-shot"));
    let violations = upward_crates(&crates);
    assert!(violations.is_empty(), "crates that do not point down:\n{}", violations.join("\n"));
}

#[test]
fn the_python_module_links_neither_the_command_line_nor_its_server() {
    let crates = workspace();
    let found = reached(&crates, "squish-py", &NOT_IN_PYTHON);
    assert!(found.is_empty(), "the Python module reaches: {found:?}");
    // The check sees what it looks for: the command line does link its server.
    assert!(!reached(&crates, "squish-cli", &NOT_IN_PYTHON).is_empty());
}

#[test]
fn a_crate_that_reaches_up_is_found() {
    // What the Python module did before squish-shot: it linked the command line's library.
    let crates: BTreeMap<String, BTreeSet<String>> = [
        ("squish-py", vec!["squish", "squish-cli"]),
        ("squish-cli", vec!["squish", "axum"]),
        ("squish-io", vec!["squish", "squish-shot"]),
        ("squish", vec![]),
        ("squish-shot", vec!["squish"]),
    ]
    .into_iter()
    .map(|(name, deps)| (name.to_string(), deps.into_iter().map(String::from).collect()))
    .collect();
    let violations = upward_crates(&crates);
    assert_eq!(violations.len(), 2, "{violations:#?}");
    assert_eq!(reached(&crates, "squish-py", &NOT_IN_PYTHON), ["squish-cli → axum", "squish-py → squish-cli"]);
}

#[test]
fn the_modules_of_squish_shot_point_down() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files: Vec<PathBuf> = imports::rust_files(&src).into_iter().filter(|f| !f.ends_with("lib.rs")).collect();
    let stem = |path: &Path| path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let modules: BTreeSet<String> = files.iter().map(|f| stem(f)).collect();
    let layered: BTreeSet<String> = MODULE_LAYERS.iter().flat_map(|l| l.iter().map(|m| m.to_string())).collect();
    assert_eq!(modules, layered, "the modules of src/ and the layers of this test differ: give a new module its layer");
    let mut violations = Vec::new();
    for file in &files {
        let module = stem(file);
        let layer = layer_of(&MODULE_LAYERS, &module).unwrap_or(usize::MAX);
        for used in imports::names_after(&read(file), "crate::").into_iter().filter(|u| modules.contains(u)) {
            let used_layer = layer_of(&MODULE_LAYERS, &used).unwrap_or(usize::MAX);
            if used != module && used_layer >= layer {
                violations.push(format!("{module} (layer {layer}) uses {used} (layer {used_layer})"));
            }
        }
    }
    assert!(violations.is_empty(), "modules that do not point down:\n{}", violations.join("\n"));
}
