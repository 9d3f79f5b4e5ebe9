//! The deformer at its defaults against the FEM + IPC references of `data/fem/`
//! (docs/plausibility.md): every step of 5–20% approach, contact side compared.
//!
//! `cargo test -p squish-scenes --test fem_comparison` checks the targets;
//! `cargo test -p squish-scenes --test fem_comparison -- --ignored --nocapture` prints the table
//! of docs/plausibility.md. `SQUISH_FEM_DIR` reads the references from another folder.
#![allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report

use std::path::{Path, PathBuf};

use glam::DVec3;
use squish::params::ObjectParams;
use squish::pipeline::Deformer;
use squish_scenes::fem::{FemReference, StepComparison};

/// The references' folder.
fn references_dir() -> PathBuf {
    std::env::var_os("SQUISH_FEM_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/fem"))
}

/// The `v` lines of an OBJ file.
fn vertices(path: &Path) -> Vec<DVec3> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let xs: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            DVec3::new(xs[0], xs[1], xs[2])
        })
        .collect()
}

/// The reference in `dir`.
fn load(dir: &Path) -> FemReference {
    let read = |name: &str| {
        std::fs::read_to_string(dir.join(name)).unwrap_or_else(|e| panic!("{}/{name}: {e}", dir.display()))
    };
    let reference = read("reference.txt");
    let summary = read("summary.csv");
    let bodies: Vec<&str> = if dir.join("rest_B.obj").exists() { vec!["A", "B"] } else { vec!["A"] };
    let rest = bodies.iter().map(|b| squish_io::read_mesh(&dir.join(format!("rest_{b}.obj"))).unwrap()).collect();
    let caps: Vec<String> = bodies.iter().map(|b| read(&format!("cap_{b}.txt"))).collect();
    let caps: Vec<&str> = caps.iter().map(String::as_str).collect();
    let steps = summary.lines().filter(|l| !l.trim().is_empty()).count() - 1;
    let positions = (1..=steps)
        .map(|k| bodies.iter().map(|b| vertices(&dir.join(format!("step_{k:03}_{b}.obj")))).collect())
        .collect();
    let name = dir.file_name().unwrap().to_string_lossy();
    FemReference::parse(&name, &reference, &summary, rest, &caps, positions).unwrap()
}

/// Every reference of the folder, by name.
fn references() -> Vec<FemReference> {
    let dir = references_dir();
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.join("reference.txt").exists())
        .collect();
    dirs.sort();
    dirs.iter().map(|d| load(d)).collect()
}

/// The deformer on step `k` of `reference` with the objects' parameters `params` and the pair's
/// contact gap `gap` (`None`: the default).
fn run(reference: &FemReference, k: usize, params: &dyn Fn(usize) -> ObjectParams, gap: Option<f64>) -> StepComparison {
    let mut scene = reference.input(k, params);
    for pair in &mut scene.pairs {
        pair.params.contact_gap = gap;
    }
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    let contact = result.deformations[0].as_ref().map(|d| d.contact.clone()).unwrap_or_default();
    reference.compare(k, &result.positions, &contact)
}

/// The steps of 5–20% approach.
fn compared_steps(reference: &FemReference) -> Vec<usize> {
    let r = reference.min_radius();
    (0..reference.steps.len()).filter(|&k| (0.045..=0.205).contains(&(reference.steps[k].approach() / r))).collect()
}

/// One table row: approach, Hausdorff per body, contact radius, bulge and spread of A.
fn row(c: &StepComparison) -> String {
    let h: Vec<String> = c.hausdorff.iter().map(|h| format!("{:.2}%", 100.0 * h)).collect();
    let spread: Vec<String> = c.spread.iter().map(|s| format!("{:.3} ({:.3})", s[0], s[1])).collect();
    format!(
        "| {:.1}% | {} | {:.3} ({:.3}, {:+.1}%) | {:.4} ({:.4}) | {} |",
        100.0 * c.relative_approach,
        h.join(" | "),
        c.contact_radius[0],
        c.contact_radius[1],
        100.0 * c.contact_radius_error(),
        c.bulge[0][0],
        c.bulge[0][1],
        spread.join(" | "),
    )
}

/// The table of docs/plausibility.md. `SQUISH_FEM_EXTENT` sets every object's extent (world
/// units; the references' smaller radius is 1), `SQUISH_FEM_GAP` the pair's contact gap (0: the
/// thesis' coincident surfaces).
#[test]
#[ignore = "prints the comparison table of docs/plausibility.md"]
fn fem_table() {
    let number = |key: &str| std::env::var(key).ok().map(|v| v.parse::<f64>().unwrap());
    let (extent, gap) = (number("SQUISH_FEM_EXTENT"), number("SQUISH_FEM_GAP"));
    for reference in references() {
        println!("\n{} (extent {extent:?}, gap {gap:?})", reference.name);
        let bodies: Vec<&str> = ["A", "B"][..reference.bodies.len()].to_vec();
        let hausdorff: Vec<String> = bodies.iter().map(|b| format!("Hausdorff {b}")).collect();
        let spread: Vec<String> = bodies.iter().map(|b| format!("spread {b} (FEM)")).collect();
        println!(
            "| approach | {} | contact radius (FEM, error) | bulge A (FEM) | {} |",
            hausdorff.join(" | "),
            spread.join(" | ")
        );
        for k in compared_steps(&reference) {
            let params = |_: usize| {
                let p = ObjectParams::default();
                match extent {
                    Some(e) => p.with_extent(e),
                    None => p,
                }
            };
            println!("{}", row(&run(&reference, k, &params, gap)));
        }
    }
}
