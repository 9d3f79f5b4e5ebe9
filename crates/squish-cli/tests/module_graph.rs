//! The command line's modules do not use each other in a circle (`docs/architecture.md`,
//! "Layers"): read from the source text with the core's reader of `crate::` paths. (The crates'
//! own layers — the command line above squish-shot — are checked by squish-shot's
//! `tests/layers.rs`.)

#[path = "../../squish/tests/layers/imports.rs"]
mod imports;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

#[test]
fn the_modules_of_the_command_line_form_no_circle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files = imports::rust_files(&src);
    let stem = |path: &Path| path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let modules: BTreeSet<String> = files.iter().map(|f| stem(f)).collect();
    let mut graph = BTreeMap::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let used: BTreeSet<String> = imports::names_after(&text, "crate::")
            .into_iter()
            .filter(|name| modules.contains(name) && *name != stem(file))
            .collect();
        graph.insert(stem(file), used);
    }
    assert!(
        graph.get("cmd_run").is_some_and(|used| used.contains("preview")),
        "the reader sees the modules: {graph:?}"
    );
    assert_eq!(imports::find_cycle(&graph), None, "modules of the command line that use each other in a circle");
}
