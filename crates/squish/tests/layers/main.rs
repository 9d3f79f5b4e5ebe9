//! The core's layers point down only (`docs/architecture.md`, "Layers"): a module uses the modules
//! of the layers below its own, never one of its own layer or above; and within each module, the
//! submodules do not use each other in a circle. Read from the source text (see [`imports`]), so a
//! new module must be given a layer here.

mod imports;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use imports::{find_cycle, names_after, rust_files};

/// The modules of the crate root, bottom layer first.
const LAYERS: [&[&str]; 7] = [
    &["animation", "mesh", "params", "stage"],
    &["linalg"],
    &["spatial"],
    &["contact"],
    &["deform"],
    &["skinning"],
    &["pipeline"],
];

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&module))
}

/// The modules declared in `lib.rs`.
fn root_modules() -> BTreeSet<String> {
    read(&src().join("lib.rs"))
        .lines()
        .filter_map(|line| line.trim().strip_prefix("pub mod ").or_else(|| line.trim().strip_prefix("mod ")))
        .map(|rest| rest.trim_end_matches(';').trim().to_string())
        .collect()
}

/// The items `lib.rs` re-exports from its modules (`pub use pipeline::{Deformer, …}`), with their
/// module: `crate::Deformer` is a use of `pipeline`.
fn root_reexports() -> BTreeMap<String, String> {
    let lib = read(&src().join("lib.rs"));
    let mut items = BTreeMap::new();
    for line in lib.lines() {
        let Some(rest) = line.trim().strip_prefix("pub use ") else { continue };
        let Some((module, list)) = rest.split_once("::") else { continue };
        let list = list.trim_end_matches(';').trim_start_matches('{').trim_end_matches('}');
        for item in list.split(',') {
            items.insert(item.trim().to_string(), module.to_string());
        }
    }
    items
}

/// The files of a root module: `src/<module>.rs` or everything below `src/<module>/`.
fn module_files(module: &str) -> Vec<PathBuf> {
    let file = src().join(format!("{module}.rs"));
    if file.is_file() { vec![file] } else { rust_files(&src().join(module)) }
}

#[test]
fn every_module_of_the_crate_root_has_a_layer() {
    let modules = root_modules();
    let layered: BTreeSet<String> = LAYERS.iter().flat_map(|l| l.iter().map(|m| m.to_string())).collect();
    assert_eq!(modules, layered, "lib.rs's modules and the layers of this test differ: give a new module its layer");
}

/// The uses, in `sources` (`(module, file, text)`), of a module of the same layer or above
/// (`crate::x`, or an item the crate root re-exports from `x`), one message each.
fn upward_uses(
    sources: &[(String, String, String)],
    modules: &BTreeSet<String>,
    reexports: &BTreeMap<String, String>,
) -> Vec<String> {
    let mut violations = Vec::new();
    for (module, file, text) in sources {
        let Some(layer) = layer_of(module) else { continue };
        for name in names_after(text, "crate::") {
            let used = if modules.contains(&name) { Some(&name) } else { reexports.get(&name) };
            let Some(used) = used.filter(|used| *used != module) else { continue };
            let Some(used_layer) = layer_of(used) else { continue };
            if used_layer >= layer {
                violations.push(format!("{file} (`{module}`, layer {layer}) uses `{used}` (layer {used_layer})"));
            }
        }
    }
    violations
}

#[test]
fn no_module_uses_a_module_of_its_own_layer_or_above() {
    let modules = root_modules();
    let sources: Vec<(String, String, String)> = modules
        .iter()
        .flat_map(|module| {
            module_files(module).into_iter().map(move |file| (module.clone(), file.display().to_string(), read(&file)))
        })
        .collect();
    let violations = upward_uses(&sources, &modules, &root_reexports());
    assert!(violations.is_empty(), "modules that do not point down:\n{}", violations.join("\n"));
}

#[test]
fn uses_of_the_same_layer_or_above_are_found() {
    // What the layers forbid, as the code once had it: skinning calling the pipeline's extent
    // rule, and two modules of the bottom layer using each other.
    let source = |module: &str, text: &str| (module.to_string(), format!("{module}.rs"), text.to_string());
    let sources = [
        source("skinning", "let e = crate::pipeline::automatic_extent(r, r, a);"),
        source("stage", "use crate::{mesh::TriMesh, DVec3};"),
        source("deform", "use crate::{contact::ContactZone, mesh::TriMesh};\nfn f(d: &crate::Deformer) {}"),
    ];
    let modules = root_modules();
    let reexports = BTreeMap::from([("Deformer".to_string(), "pipeline".to_string())]);
    let found = upward_uses(&sources, &modules, &reexports);
    assert_eq!(found.len(), 3, "{found:#?}");
    assert!(
        found[0].contains("uses `pipeline`")
            && found[1].contains("uses `mesh`")
            && found[2].contains("uses `pipeline`")
    );
}

#[test]
fn the_submodules_of_a_module_do_not_use_each_other_in_a_circle() {
    for module in root_modules() {
        let dir = src().join(&module);
        if !dir.is_dir() {
            continue;
        }
        let stem = |path: &Path| path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let files: Vec<PathBuf> = rust_files(&dir).into_iter().filter(|f| f.parent() == Some(&dir)).collect();
        let submodules: BTreeSet<String> = files.iter().map(|f| stem(f)).filter(|s| s != "mod").collect();
        let mut graph = BTreeMap::new();
        for file in files.iter().filter(|f| stem(f) != "mod") {
            let text = read(file);
            let used: BTreeSet<String> = names_after(&text, "super::")
                .into_iter()
                .chain(names_after(&text, &format!("crate::{module}::")))
                .filter(|name| submodules.contains(name) && *name != stem(file))
                .collect();
            graph.insert(stem(file), used);
        }
        assert_eq!(find_cycle(&graph), None, "submodules of `{module}` that use each other in a circle");
    }
}

/// The submodules of `pipeline`, bottom first (`docs/architecture.md`, "Layers"): the frame plan's
/// stages point down to the stages and stores they run on, the driver (`mod.rs`) is above all.
const PIPELINE_ORDER: [&[&str]; 9] = [
    &["rim"],
    &["error", "stats", "plan", "cache", "untangle"],
    &["store", "regions"],
    &["setup", "contacts"],
    &["deformations", "warnings"],
    &["separation", "quality"],
    &["part_contact"],
    &["self_contact"],
    &["edits", "results"],
];

#[test]
fn the_pipelines_submodules_point_down_in_their_documented_order() {
    let dir = src().join("pipeline");
    let level = |name: &str| PIPELINE_ORDER.iter().position(|l| l.contains(&name));
    let mut violations = Vec::new();
    for file in rust_files(&dir).into_iter().filter(|f| f.parent() == Some(dir.as_path())) {
        let stem = file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        if stem == "mod" {
            continue;
        }
        let Some(own) = level(&stem) else {
            violations.push(format!("pipeline/{stem}.rs has no place in PIPELINE_ORDER: give it one"));
            continue;
        };
        for used in names_after(&read(&file), "super::").into_iter().filter(|u| *u != stem) {
            if let Some(other) = level(&used)
                && other >= own
            {
                violations.push(format!("pipeline/{stem}.rs (level {own}) uses `{used}` (level {other})"));
            }
        }
    }
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

#[test]
fn the_reader_finds_grouped_paths_and_skips_comments() {
    let source = "use crate::{mesh::{Topology, TriMesh}, spatial, DVec3};\n\
                  use super::guide::X; // crate::pipeline in a comment\n\
                  /// [`crate::skinning`] in a doc comment\n\
                  let y = crate::linalg::solve(super::super::z);";
    let names = |prefix| names_after(source, prefix).into_iter().collect::<Vec<_>>();
    assert_eq!(names("crate::"), ["DVec3", "linalg", "mesh", "spatial"]);
    assert_eq!(names("super::"), ["guide"]);
    let graph: BTreeMap<String, BTreeSet<String>> =
        [("a", "b"), ("b", "c"), ("c", "a")].map(|(x, y)| (x.to_string(), BTreeSet::from([y.to_string()]))).into();
    assert_eq!(find_cycle(&graph).map(|c| c.len()), Some(4));
}
