//! The I/O crate's modules do not use each other in a circle (`docs/architecture.md`, "Layers"):
//! neither the modules of the crate root (`crate::x`) nor the submodules of a folder module such
//! as `scene/` (`super::x`, `crate::scene::x`). Read from the source text with the core's reader.

#[path = "../../squish/tests/layers/imports.rs"]
mod imports;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

fn stem(path: &Path) -> String {
    path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The modules directly in `dir` (files other than `mod.rs` / `lib.rs`, and folders, whose text is
/// that of every file below them), each to the sibling modules it names after one of `prefixes`.
fn graph_of(dir: &Path, prefixes: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let mut sources: Vec<(String, String)> = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())).flatten() {
        let path = entry.path();
        if path.is_dir() {
            let text: Vec<String> = imports::rust_files(&path).iter().map(|f| read(f)).collect();
            sources.push((stem(&path), text.join("\n")));
        } else if path.extension().is_some_and(|e| e == "rs") && !matches!(stem(&path).as_str(), "mod" | "lib") {
            sources.push((stem(&path), read(&path)));
        }
    }
    let modules: BTreeSet<String> = sources.iter().map(|(name, _)| name.clone()).collect();
    sources
        .iter()
        .map(|(name, text)| {
            let used = prefixes
                .iter()
                .flat_map(|p| imports::names_after(text, p))
                .filter(|used| modules.contains(used) && used != name)
                .collect();
            (name.clone(), used)
        })
        .collect()
}

#[test]
fn the_scene_modules_form_no_circle() {
    let graph = graph_of(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src/scene"), &["super::", "crate::scene::"]);
    assert!(graph.get("tracks").is_some_and(|used| used.contains("keys")), "the reader sees the modules: {graph:?}");
    assert_eq!(imports::find_cycle(&graph), None, "modules of squish-io's scene/ that use each other in a circle");
}

#[test]
fn the_modules_of_the_crate_root_form_no_circle() {
    let graph = graph_of(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"), &["crate::"]);
    assert!(graph.get("gltf_document").is_some_and(|used| used.contains("gltf_read")), "{graph:?}");
    assert!(graph.get("scene").is_some_and(|used| used.contains("gltf_binary")), "{graph:?}");
    assert_eq!(imports::find_cycle(&graph), None, "modules of squish-io that use each other in a circle");
}

#[test]
fn a_circle_is_found() {
    // What `scene/` had before: `keys` used `types` for the transform's values, `types` used
    // `keys` for `Keyed`.
    let graph: BTreeMap<String, BTreeSet<String>> = [("keys", "types"), ("types", "keys"), ("tracks", "keys")]
        .map(|(a, b)| (a.to_string(), BTreeSet::from([b.to_string()])))
        .into();
    assert_eq!(imports::find_cycle(&graph).map(|c| c.len()), Some(3));
}
