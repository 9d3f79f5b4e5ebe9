//! Structure-aware fuzzing of the mesh readers (OBJ, PLY, glTF/GLB) on the stable toolchain
//! (issue 28; `cargo fuzz` needs nightly, which cannot be installed here).
//!
//! Each case is a file built by a seeded generator that knows the format's grammar — OBJ
//! statements with every corner spelling and index kind, PLY headers with every scalar type,
//! list layout and encoding and bodies that agree with them or not, glTF documents with
//! accessors, skins, morph targets, animations and node trees, as `.glb`, embedded or external
//! `.gltf` — then mutated (a field of the JSON replaced, bytes flipped, inserted, cut). It is read
//! as the command line reads it, and an `Ok` mesh goes through the analyses of `squish info`.
//! A case fails if it panics, takes longer than [`CASE_LIMIT`], or the process's peak resident
//! memory passes [`MEMORY_LIMIT`]; the input is then written to `tests/fuzz-corpus/<target>/`
//! as `crash-<seed>.<ext>` and the test fails naming it.
//!
//! - `cargo test -p squish-io --test fuzz_readers` replays the corpus and a few hundred cases per
//!   target (seconds).
//! - `SQUISH_FUZZ_SECONDS=600 cargo test --release -p squish-io --test fuzz_readers -- --ignored
//!   --nocapture long_obj` runs one target for ten minutes (`long_ply`, `long_gltf` the others);
//!   `SQUISH_FUZZ_SEED=N` changes the seeds (default: the clock), and the summary line gives the
//!   case count, so a run can be reproduced.
//! - One regression test per failure found stays below (`regression_*`), reading its corpus file.

#![allow(clippy::unwrap_used)]

mod common;

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::{F32, Fixture, I8, I16, U8, U16, U32};
use fastrand::Rng;
use serde_json::{Value, json};
use squish::mesh::Topology;
use squish_io::{GltfReadOptions, WeldMode, read_gltf, read_mesh_with, read_ply_data};

/// Longest time one case may take (reading and analysing a file of at most a few hundred KB).
const CASE_LIMIT: Duration = Duration::from_secs(20);
/// Largest peak resident memory of the test process.
const MEMORY_LIMIT_KB: u64 = 3 << 20;
const MEMORY_LIMIT: &str = "3 GiB";

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Obj,
    Ply,
    Gltf,
}

impl Target {
    fn name(self) -> &'static str {
        match self {
            Self::Obj => "obj",
            Self::Ply => "ply",
            Self::Gltf => "gltf",
        }
    }
}

/// One generated input: the main file's extension and bytes, and an optional side file (an
/// external glTF buffer) with its name.
struct Case {
    extension: &'static str,
    bytes: Vec<u8>,
    side: Option<(&'static str, Vec<u8>)>,
}

fn corpus_dir(target: Target) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus").join(target.name())
}

/// Reads the file as the command line does and runs `squish info`'s analyses on the mesh; true
/// if a mesh was read.
fn exercise(target: Target, path: &Path) -> bool {
    let mut read = false;
    match target {
        Target::Obj | Target::Ply => {
            if target == Target::Ply {
                let _ = read_ply_data(path);
            }
            for weld in [WeldMode::Off, WeldMode::Exact] {
                if let Ok(mesh) = read_mesh_with(path, weld) {
                    analyse(&mesh);
                    read = true;
                }
            }
        }
        Target::Gltf => {
            for weld in [WeldMode::Off, WeldMode::Exact] {
                let Ok(scene) = read_gltf(path, &GltfReadOptions { weld }) else { continue };
                if let Ok(mesh) = scene.merged_mesh() {
                    analyse(&mesh);
                    read = true;
                }
                for animation in 0..scene.animations.len() {
                    for time in [0.0, 0.37, 1e9] {
                        let _ = scene.posed_meshes(Some(animation), time);
                    }
                }
            }
        }
    }
    read
}

/// The analyses of `squish info`, which must accept any mesh a reader returns.
fn analyse(mesh: &squish::TriMesh) {
    mesh.check_structure().expect("a reader returned a mesh with out-of-range indices");
    let topology = Topology::new(mesh);
    let _ = topology.check_manifold(mesh);
    let _ = topology.face_components(mesh);
    let _ = topology.boundary_loops(mesh);
    let _ = (0..mesh.num_triangles()).filter(|&t| mesh.degeneracy(t).is_some()).count();
    let _ = squish::spatial::self_intersections(mesh);
}

/// Peak resident memory of this process, in KB (0 where `/proc` is missing).
fn peak_memory_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or(0)
}

/// Writes the case into `dir` and runs it on a worker thread; `Ok(true)` if a mesh was read,
/// `Err` describes a panic, a case over the time limit or memory over its limit.
fn run_case(target: Target, case: &Case, dir: &Path) -> Result<bool, String> {
    let path = dir.join(format!("case.{}", case.extension));
    std::fs::write(&path, &case.bytes).unwrap();
    if let Some((name, bytes)) = &case.side {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let (send, receive) = mpsc::channel();
    let worker_path = path.clone();
    std::thread::spawn(move || {
        let outcome = std::panic::catch_unwind(|| exercise(target, &worker_path));
        let _ = send.send(outcome.ok());
    });
    let read = match receive.recv_timeout(CASE_LIMIT) {
        Ok(Some(read)) => read,
        Ok(None) => return Err("panicked".to_string()),
        Err(_) => return Err(format!("took longer than {CASE_LIMIT:?}")),
    };
    if peak_memory_kb() > MEMORY_LIMIT_KB {
        return Err(format!("pushed the peak resident memory past {MEMORY_LIMIT}"));
    }
    Ok(read)
}

/// Keeps a failing case in the corpus and returns the message for the test's failure.
fn keep_failure(target: Target, seed: u64, case: &Case, why: &str) -> String {
    let dir = corpus_dir(target);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("crash-{seed}.{}", case.extension));
    std::fs::write(&path, &case.bytes).unwrap();
    if let Some((name, bytes)) = &case.side {
        std::fs::write(dir.join(format!("crash-{seed}-{name}")), bytes).unwrap();
    }
    format!("{} case with seed {seed} {why}; kept as {}", target.name(), path.display())
}

/// Replays every corpus file of `target`.
fn replay_corpus(target: Target) -> usize {
    let work = tempfile::tempdir().unwrap();
    let mut files: Vec<PathBuf> =
        std::fs::read_dir(corpus_dir(target)).map(|d| d.map(|e| e.unwrap().path()).collect()).unwrap_or_default();
    files.sort();
    let mut count = 0;
    for file in files {
        let Some(extension) = file.extension().and_then(|e| e.to_str()) else { continue };
        let extension: &'static str = match extension {
            "obj" => "obj",
            "ply" => "ply",
            "gltf" => "gltf",
            "glb" => "glb",
            _ => continue,
        };
        let case = Case { extension, bytes: std::fs::read(&file).unwrap(), side: None };
        if let Err(why) = run_case(target, &case, work.path()) {
            panic!("corpus file {} {why}", file.display());
        }
        count += 1;
    }
    count
}

/// Generates and runs cases until `cases` are done or `seconds` have passed; returns the count
/// and how many of them were read as meshes.
fn fuzz(target: Target, cases: u64, seconds: f64, base_seed: u64) -> (u64, u64) {
    let work = tempfile::tempdir().unwrap();
    let start = Instant::now();
    let mut done = 0u64;
    let mut meshes = 0u64;
    while done < cases && start.elapsed().as_secs_f64() < seconds {
        let seed = base_seed.wrapping_add(done.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let mut rng = Rng::with_seed(seed);
        let case = match target {
            Target::Obj => obj_case(&mut rng),
            Target::Ply => ply_case(&mut rng),
            Target::Gltf => gltf_case(&mut rng),
        };
        match run_case(target, &case, work.path()) {
            Ok(read) => meshes += u64::from(read),
            Err(why) => panic!("{}", keep_failure(target, seed, &case, &why)),
        }
        done += 1;
    }
    (done, meshes)
}

fn long_run(target: Target) {
    let seconds: f64 = std::env::var("SQUISH_FUZZ_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(600.0);
    let seed: u64 = std::env::var("SQUISH_FUZZ_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or_else(|| {
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(1, |d| d.as_nanos() as u64)
    });
    let start = Instant::now();
    let replayed = replay_corpus(target);
    let (cases, meshes) = fuzz(target, u64::MAX, seconds, seed);
    println!(
        "fuzz {}: {cases} generated cases ({meshes} read as meshes) and {replayed} corpus files in {:.1} min (seed {seed}), no failure; peak memory {} MB",
        target.name(),
        start.elapsed().as_secs_f64() / 60.0,
        peak_memory_kb() / 1024
    );
}

const SHORT_CASES: u64 = 120;

/// The corpus and [`SHORT_CASES`] generated cases of `target` (seed 28), at least a tenth of
/// them read as meshes (else the generator no longer reaches the analyses).
fn short_run(target: Target) {
    replay_corpus(target);
    let (cases, meshes) = fuzz(target, SHORT_CASES, f64::INFINITY, 28);
    assert_eq!(cases, SHORT_CASES);
    assert!(meshes >= SHORT_CASES / 10, "only {meshes} of {cases} generated files were meshes: the generator is off");
}

#[test]
fn short_obj() {
    short_run(Target::Obj);
}

#[test]
fn short_ply() {
    short_run(Target::Ply);
}

#[test]
fn short_gltf() {
    short_run(Target::Gltf);
}

#[test]
#[ignore = "long fuzzing run: SQUISH_FUZZ_SECONDS=600 cargo test --release -p squish-io --test fuzz_readers -- --ignored long_obj"]
fn long_obj() {
    long_run(Target::Obj);
}

#[test]
#[ignore = "long fuzzing run: SQUISH_FUZZ_SECONDS=600 cargo test --release -p squish-io --test fuzz_readers -- --ignored long_ply"]
fn long_ply() {
    long_run(Target::Ply);
}

#[test]
#[ignore = "long fuzzing run: SQUISH_FUZZ_SECONDS=600 cargo test --release -p squish-io --test fuzz_readers -- --ignored long_gltf"]
fn long_gltf() {
    long_run(Target::Gltf);
}

// ---------------------------------------------------------------------------------------------
// Regressions: one per failure the fuzzing found.

/// Found by `short_obj` (seed 28): OBJ `f` lines of thousands of random corners (fanned into
/// long faces that all share their first corner and cross each other) made `squish info`'s
/// self-intersection test quadratic; 640 000 faces took minutes. Now the test stops at each
/// face's first intersecting partner and skips the faces that share a vertex.
#[test]
fn regression_obj_long_random_faces() {
    let mut rng = Rng::with_seed(28);
    let mut text = String::new();
    for _ in 0..1000 {
        text.push_str(&format!("v {} {} {}\n", rng.f64(), rng.f64(), rng.f64()));
    }
    for _ in 0..5 {
        text.push('f');
        for _ in 0..20_000 {
            text.push_str(&format!(" {}", rng.usize(1..=1000)));
        }
        text.push('\n');
    }
    let dir = tempfile::tempdir().unwrap();
    let case = Case { extension: "obj", bytes: text.into_bytes(), side: None };
    assert_eq!(run_case(Target::Obj, &case, dir.path()), Ok(true));
}

/// Runs the corpus file `name` of `target` as a case.
fn run_corpus_file(target: Target, name: &str) -> Result<bool, String> {
    let bytes = std::fs::read(corpus_dir(target).join(name)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let extension = if name.ends_with(".glb") { "glb" } else { target.name() };
    run_case(target, &Case { extension, bytes, side: None }, dir.path())
}

/// Found by `short_ply`: a PLY of 27 vertices and 624 polygons of up to 300 corners (nearly
/// every pair of faces shares a vertex) kept the first search over the pairs that share none
/// busy skipping candidates; its corpus file is replayed by `short_ply`, and read here alone.
#[test]
fn regression_ply_few_vertices_many_faces() {
    assert_eq!(run_corpus_file(Target::Ply, "crash-few-vertices-many-faces.ply"), Ok(true));
}

/// Found by `long_ply` (seed 5078689693977255278): 10 vertices and 35 000 triangles, so that
/// edges hold a thousand faces each and nearly every face has copies at the same three
/// positions; the search over faces sharing no vertex visited every face for each open one.
/// Copies are now searched once (they coincide, so they intersect each other).
#[test]
fn regression_ply_ten_vertices_books() {
    assert_eq!(run_corpus_file(Target::Ply, "crash-ten-vertices-books.ply"), Ok(true));
}

/// Found by `long_gltf` (seed 15178484154088650513): a POSITION attribute naming an accessor
/// past the file's accessors panicked inside the `gltf` crate's validation (an unchecked index in
/// gltf-json 1.4.1). The reader now checks it first and names the mesh, primitive and index.
#[test]
fn regression_gltf_position_accessor_out_of_range() {
    let path = corpus_dir(Target::Gltf).join("crash-position-accessor-out-of-range.glb");
    let e = read_gltf(&path, &GltfReadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("POSITION attribute refers to accessor") && e.contains("mesh 0 primitive 0"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Shared pieces

/// Whether a case may hold malformed or out-of-range values: a third of the cases do; the others
/// are valid files of random shape, which reach the mesh analyses.
fn wild(rng: &mut Rng) -> bool {
    rng.u8(0..3) == 0
}

/// A number as text: ordinary, or (`wild`) extreme, special or malformed.
fn number_text(rng: &mut Rng, wild: bool) -> String {
    if !wild {
        return if rng.bool() { format!("{}", rng.i32(-4..5)) } else { format!("{:.3}", rng.f64() * 4.0 - 2.0) };
    }
    match rng.u8(0..20) {
        0 => ["nan", "NaN", "inf", "-inf", "infinity"][rng.usize(0..5)].to_string(),
        1 => ["1e308", "-1e308", "1e999", "4.9e-324", "1e-320", "-0", "0x10", "1.2.3", "", "+", "e5", "1e"]
            [rng.usize(0..12)]
        .to_string(),
        2 => format!("{}", rng.i64(..)),
        3 => format!("{:e}", f64::from_bits(rng.u64(..))),
        4..=9 => format!("{}", rng.i32(-4..5)),
        _ => format!("{:.3}", rng.f64() * 4.0 - 2.0),
    }
}

/// An index as text for a file of `n` vertices (1-based or relative; `wild`: valid or not).
fn obj_index(rng: &mut Rng, n: usize, wild: bool) -> String {
    let n = n.max(1) as i64;
    match if wild { rng.u8(0..16) } else { rng.u8(4..16) } {
        0 => "0".to_string(),
        1 => format!("{}", n + rng.i64(1..10)),
        2 => format!("-{}", n + rng.i64(1..10)),
        3 => ["99999999999999999999", "-99999999999999999999", "4294967296", "4294967295", "x", "1.5", ""]
            [rng.usize(0..7)]
        .to_string(),
        4..=6 => format!("-{}", rng.i64(1..=n)),
        _ => format!("{}", rng.i64(1..=n)),
    }
}

/// Flips, inserts, removes, duplicates or cuts a few bytes (or none).
fn mutate_bytes(rng: &mut Rng, bytes: &mut Vec<u8>) {
    let edits = match rng.u8(0..4) {
        0 | 1 => 0,
        2 => 1,
        _ => rng.usize(2..8),
    };
    for _ in 0..edits {
        if bytes.is_empty() {
            bytes.push(rng.u8(..));
            continue;
        }
        let at = rng.usize(0..bytes.len());
        match rng.u8(0..6) {
            0 => bytes[at] ^= 1 << rng.u8(0..8),
            1 => bytes[at] = rng.u8(..),
            2 => bytes.insert(at, rng.u8(..)),
            3 => {
                bytes.remove(at);
            }
            4 => {
                let end = (at + rng.usize(1..64)).min(bytes.len());
                let copy = bytes[at..end].to_vec();
                let to = rng.usize(0..=bytes.len());
                bytes.splice(to..to, copy);
            }
            _ => bytes.truncate(at),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// OBJ

fn obj_case(rng: &mut Rng) -> Case {
    let wild = wild(rng);
    let mut text = String::new();
    let lines = match rng.u8(0..10) {
        0 => 0,
        1 => rng.usize(500..3000),
        _ => rng.usize(1..80),
    };
    let mut vertices = 0usize;
    // Texture coordinates and normals written so far: corners refer to them within range unless
    // the file is wild (an index out of range is an error the reader must name).
    let (mut texcoords, mut normals) = (0usize, 0usize);
    let newline = if rng.u8(0..8) == 0 { "\r\n" } else { "\n" };
    for _ in 0..lines {
        match if wild { rng.u8(0..20) } else { rng.u8(0..16) } {
            0..=7 => {
                let count = match if wild { rng.u8(0..10) } else { 9 } {
                    0 => rng.usize(0..3),
                    1 => rng.usize(4..8),
                    _ => 3,
                };
                text.push('v');
                for _ in 0..count {
                    text.push(' ');
                    text.push_str(&number_text(rng, wild));
                }
                vertices += 1;
            }
            8..=12 if wild || vertices > 0 => {
                let corners = match rng.u8(0..12) {
                    0 if wild => rng.usize(0..3),
                    1 => rng.usize(500..5_000),
                    2 | 3 => rng.usize(4..12),
                    _ => 3,
                };
                text.push(if rng.u8(0..10) == 0 { 'l' } else { 'f' });
                for _ in 0..corners {
                    text.push(' ');
                    text.push_str(&obj_index(rng, vertices, wild));
                    let (t, n) = if wild { (4, 4) } else { (texcoords, normals) };
                    match rng.u8(0..6) {
                        0 if t > 0 => text.push_str(&format!("/{}", obj_index(rng, t, wild))),
                        1 if n > 0 => text.push_str(&format!("//{}", obj_index(rng, n, wild))),
                        2 if t > 0 && n > 0 => {
                            text.push_str(&format!("/{}/{}", obj_index(rng, t, wild), obj_index(rng, n, wild)))
                        }
                        _ => {}
                    }
                }
            }
            8..=12 => {}
            13 => {
                text.push_str(&format!("vt {} {}", number_text(rng, wild), number_text(rng, wild)));
                texcoords += 1;
            }
            14 => {
                text.push_str(&format!(
                    "vn {} {} {}",
                    number_text(rng, wild),
                    number_text(rng, wild),
                    number_text(rng, wild)
                ));
                normals += 1;
            }
            15 => text.push_str(
                ["# comment", "o thing", "g a b", "s off", "usemtl m", "mtllib x.mtl", "", "   "][rng.usize(0..8)],
            ),
            16 => text.push_str("v 0 0 \\"),
            17 => text.push_str("f 1 2 3 # trailing"),
            18 => {
                let junk: String = (0..rng.usize(0..40)).map(|_| rng.char('!'..='~')).collect();
                text.push_str(&junk);
            }
            _ => text.push_str(&format!("vp {}", number_text(rng, wild))),
        }
        text.push_str(newline);
    }
    if !wild && vertices > 0 {
        text.push_str(&format!(
            "f {} {} {}\n",
            obj_index(rng, vertices, false),
            obj_index(rng, vertices, false),
            obj_index(rng, vertices, false)
        ));
    }
    let mut bytes = text.into_bytes();
    if wild && rng.u8(0..10) == 0 {
        bytes.extend_from_slice(&[0xFF, 0xFE, 0x80, b'\n']);
    }
    if wild {
        mutate_bytes(rng, &mut bytes);
    }
    Case { extension: "obj", bytes, side: None }
}

// ---------------------------------------------------------------------------------------------
// PLY

const PLY_TYPES: [&str; 16] = [
    "char", "uchar", "short", "ushort", "int", "uint", "float", "double", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "float32", "float64",
];

#[derive(Clone)]
enum PlyProperty {
    Scalar(&'static str, String),
    List(&'static str, &'static str, String),
}

fn ply_case(rng: &mut Rng) -> Case {
    let wild = wild(rng);
    let format = ["ascii", "binary_little_endian", "binary_big_endian"][rng.usize(0..3)];
    let vertices = match rng.u8(0..10) {
        0 => 0,
        1 => rng.usize(200..3000),
        _ => rng.usize(1..30),
    };
    let faces = match rng.u8(0..10) {
        0 => 0,
        1 => rng.usize(200..3000),
        _ => rng.usize(1..40),
    };
    let mut vertex_props: Vec<PlyProperty> = Vec::new();
    for axis in ["x", "y", "z"] {
        if !wild || rng.u8(0..40) != 0 {
            let ty =
                if !wild || rng.bool() { ["float", "double"][rng.usize(0..2)] } else { PLY_TYPES[rng.usize(0..16)] };
            vertex_props.push(PlyProperty::Scalar(ty, axis.to_string()));
        }
    }
    for k in 0..rng.usize(0..3) {
        vertex_props.push(if rng.u8(0..4) == 0 {
            PlyProperty::List(PLY_TYPES[rng.usize(0..6)], PLY_TYPES[rng.usize(0..16)], format!("extra{k}"))
        } else {
            PlyProperty::Scalar(
                PLY_TYPES[rng.usize(0..16)],
                ["red", "green", "nx", "label", "s"][rng.usize(0..5)].to_string(),
            )
        });
    }
    rng.shuffle(&mut vertex_props);
    let index_name = if rng.u8(0..10) == 0 { "vertex_index" } else { "vertex_indices" };
    let count_type = if wild && rng.u8(0..12) == 0 {
        PLY_TYPES[rng.usize(0..16)]
    } else {
        ["uchar", "ushort", "int", "uint"][rng.usize(0..4)]
    };
    let item_type = if wild && rng.bool() {
        PLY_TYPES[rng.usize(0..16)]
    } else {
        ["int", "uint", "int32", "uint32"][rng.usize(0..4)]
    };
    let mut face_props = vec![PlyProperty::List(count_type, item_type, index_name.to_string())];
    if rng.u8(0..4) == 0 {
        face_props.insert(rng.usize(0..2), PlyProperty::Scalar(PLY_TYPES[rng.usize(0..16)], "flags".to_string()));
    }
    let mut elements: Vec<(String, usize, Vec<PlyProperty>)> =
        vec![("vertex".to_string(), vertices, vertex_props), ("face".to_string(), faces, face_props)];
    if rng.u8(0..5) == 0 {
        elements.push(("edge".to_string(), rng.usize(0..5), vec![PlyProperty::Scalar("int", "vertex1".to_string())]));
    }
    if rng.u8(0..8) == 0 {
        elements.swap(0, 1);
    }
    // The declared counts: usually the body's, sometimes off or absurd.
    let declared: Vec<String> = elements
        .iter()
        .map(|(_, n, _)| match if wild { rng.u8(0..14) } else { 13 } {
            0 => format!("{}", n + rng.usize(1..3)),
            1 => format!("{}", n.saturating_sub(rng.usize(1..3))),
            2 => ["4294967295", "18446744073709551615", "99999999999999999999", "-1", "x"][rng.usize(0..5)].to_string(),
            _ => format!("{n}"),
        })
        .collect();
    let mut out = format!("ply\nformat {format} 1.0\ncomment fuzz\n").into_bytes();
    for ((name, _, props), count) in elements.iter().zip(&declared) {
        out.extend_from_slice(format!("element {name} {count}\n").as_bytes());
        for p in props {
            let line = match p {
                PlyProperty::Scalar(t, n) => format!("property {t} {n}\n"),
                PlyProperty::List(c, t, n) => format!("property list {c} {t} {n}\n"),
            };
            out.extend_from_slice(line.as_bytes());
        }
    }
    out.extend_from_slice(b"end_header\n");
    for (name, count, props) in &elements {
        for _ in 0..*count {
            let mut fields: Vec<(&str, f64)> = Vec::new();
            for p in props {
                match p {
                    PlyProperty::Scalar(t, _) => fields.push((t, ply_value(rng, vertices, false, wild))),
                    PlyProperty::List(c, t, n) => {
                        let len = if n.starts_with("vertex_ind") {
                            match rng.u8(0..12) {
                                0 if wild => rng.usize(0..3),
                                1 => rng.usize(4..300),
                                2 | 3 => rng.usize(4..8),
                                _ => 3,
                            }
                        } else {
                            rng.usize(0..4)
                        };
                        fields.push((c, len as f64));
                        for _ in 0..len {
                            fields.push((t, ply_value(rng, vertices, name == "face", wild)));
                        }
                    }
                }
            }
            write_ply_record(&mut out, format, &fields);
        }
    }
    if wild {
        mutate_bytes(rng, &mut out);
    }
    Case { extension: "ply", bytes: out, side: None }
}

/// A value for a property: an index into the vertices (`wild`: mostly valid) or a coordinate.
fn ply_value(rng: &mut Rng, vertices: usize, index: bool, wild: bool) -> f64 {
    if index && (!wild || rng.u8(0..12) != 0) {
        return rng.usize(0..vertices.max(1)) as f64;
    }
    match if wild { rng.u8(0..16) } else { 15 } {
        0 => f64::NAN,
        1 => f64::INFINITY,
        2 => -1.0,
        3 => 1e300,
        _ => (rng.f64() * 4.0 - 2.0 * 1000.0).round() / 1000.0,
    }
}

fn write_ply_record(out: &mut Vec<u8>, format: &str, fields: &[(&str, f64)]) {
    if format == "ascii" {
        let text: Vec<String> = fields.iter().map(|(_, v)| format!("{v}")).collect();
        out.extend_from_slice(text.join(" ").as_bytes());
        out.push(b'\n');
        return;
    }
    let big = format == "binary_big_endian";
    for &(ty, v) in fields {
        let mut bytes: Vec<u8> = match ty {
            "char" | "int8" => vec![v as i8 as u8],
            "uchar" | "uint8" => vec![v as u8],
            "short" | "int16" => (v as i16).to_le_bytes().to_vec(),
            "ushort" | "uint16" => (v as u16).to_le_bytes().to_vec(),
            "int" | "int32" => (v as i32).to_le_bytes().to_vec(),
            "uint" | "uint32" => (v as u32).to_le_bytes().to_vec(),
            "float" | "float32" => (v as f32).to_le_bytes().to_vec(),
            _ => v.to_le_bytes().to_vec(),
        };
        if big {
            bytes.reverse();
        }
        out.extend_from_slice(&bytes);
    }
}

// ---------------------------------------------------------------------------------------------
// glTF / GLB

fn gltf_case(rng: &mut Rng) -> Case {
    let wild = wild(rng);
    let mut f = Fixture::new();
    let vertices = match rng.u8(0..10) {
        0 => 0,
        1 => rng.usize(100..2000),
        _ => rng.usize(1..40),
    };
    let positions: Vec<f64> =
        (0..3 * vertices).map(|_| if wild && rng.u8(0..60) == 0 { f64::NAN } else { rng.f64() * 2.0 - 1.0 }).collect();
    let position_type = if rng.u8(0..5) == 0 { [I8, U8, I16, U16][rng.usize(0..4)] } else { F32 };
    let pos = f.accessor_ex(position_type, "VEC3", &positions, position_type != F32);
    let index_count = 3 * rng.usize(1..60) + if wild && rng.u8(0..10) == 0 { rng.usize(1..3) } else { 0 };
    let index_values: Vec<f64> = (0..index_count)
        .map(|_| {
            if wild && rng.u8(0..30) == 0 { rng.usize(0..100_000) as f64 } else { rng.usize(0..vertices.max(1)) as f64 }
        })
        .collect();
    let index_type = [U8, U16, U32][rng.usize(0..3)];
    let idx = f.accessor(index_type, "SCALAR", &index_values);
    let mut attributes = json!({ "POSITION": pos });
    if rng.bool() {
        let normals: Vec<f64> = (0..3 * vertices).map(|_| rng.f64()).collect();
        attributes["NORMAL"] = json!(f.accessor(F32, "VEC3", &normals));
    }
    if rng.bool() {
        let uvs: Vec<f64> = (0..2 * vertices).map(|_| rng.f64()).collect();
        attributes["TEXCOORD_0"] = json!(f.accessor(F32, "VEC2", &uvs));
    }
    let joints = rng.usize(1..5);
    let skinned = rng.u8(0..3) == 0;
    if skinned {
        let j: Vec<f64> = (0..4 * vertices).map(|_| rng.usize(0..joints + 1) as f64).collect();
        let w: Vec<f64> = (0..4 * vertices).map(|_| rng.f64()).collect();
        attributes["JOINTS_0"] = json!(f.accessor([U8, U16][rng.usize(0..2)], "VEC4", &j));
        attributes["WEIGHTS_0"] = json!(f.accessor(F32, "VEC4", &w));
    }
    let mode = if rng.u8(0..5) == 0 { if wild { rng.u32(0..8) } else { rng.u32(4..7) } } else { 4 };
    let mut primitive = json!({ "attributes": attributes, "mode": mode });
    if !wild || rng.u8(0..8) != 0 {
        primitive["indices"] = json!(idx);
    }
    if rng.u8(0..4) == 0 {
        let delta: Vec<f64> = (0..3 * vertices).map(|_| rng.f64() * 0.1).collect();
        primitive["targets"] = json!([{ "POSITION": f.accessor(F32, "VEC3", &delta) }]);
    }
    // A node tree: the mesh node and a chain of joints, sometimes with a cycle or a bad child.
    let mut nodes = vec![json!({ "name": "mesh", "mesh": 0 })];
    for k in 0..joints {
        let mut node = json!({ "name": format!("joint{k}") });
        match rng.u8(0..4) {
            0 => {
                node["matrix"] =
                    json!((0..16).map(|i| if i % 5 == 0 { 1.0 } else { rng.f64() * 0.1 }).collect::<Vec<f64>>())
            }
            1 => node["rotation"] = json!([rng.f64(), rng.f64(), rng.f64(), rng.f64()]),
            _ => node["translation"] = json!([rng.f64(), 0.0, 0.0]),
        }
        if k + 1 < joints {
            node["children"] = json!([k + 2]);
        }
        nodes.push(node);
    }
    if wild && rng.u8(0..10) == 0 {
        nodes[joints]["children"] = json!([1]);
    }
    let mut scene_nodes = vec![0];
    if joints > 0 {
        scene_nodes.push(1);
    }
    f.root = json!({
        "scene": 0,
        "scenes": [{ "nodes": scene_nodes }],
        "nodes": nodes,
        "meshes": [{ "name": "m", "primitives": [primitive] }],
    });
    if skinned {
        let mut ibm = Vec::new();
        for _ in 0..joints {
            ibm.extend_from_slice(&glam::DMat4::IDENTITY.to_cols_array());
        }
        let ibm = f.accessor(F32, "MAT4", &ibm);
        f.root["skins"] = json!([{ "joints": (1..=joints).collect::<Vec<usize>>(), "inverseBindMatrices": ibm }]);
        f.root["nodes"][0]["skin"] = json!(0);
    }
    if rng.bool() {
        let keys = rng.usize(0..5);
        let times: Vec<f64> = (0..keys).map(|k| k as f64 * 0.5 + if rng.u8(0..10) == 0 { -1.0 } else { 0.0 }).collect();
        let input = f.accessor(F32, "SCALAR", &times);
        let interpolation = ["LINEAR", "STEP", "CUBICSPLINE"][rng.usize(0..3)];
        let per_key = if interpolation == "CUBICSPLINE" { 3 } else { 1 };
        let rotations: Vec<f64> = (0..4 * keys * per_key).map(|_| rng.f64()).collect();
        let output = f.accessor(F32, "VEC4", &rotations);
        let weights: Vec<f64> = (0..keys * per_key).map(|_| rng.f64()).collect();
        let weights = f.accessor(F32, "SCALAR", &weights);
        f.root["animations"] = json!([{
            "samplers": [
                { "input": input, "output": output, "interpolation": interpolation },
                { "input": input, "output": weights, "interpolation": interpolation },
            ],
            "channels": [
                { "sampler": 0, "target": { "node": rng.usize(0..=joints), "path": "rotation" } },
                { "sampler": 1, "target": { "node": 0, "path": "weights" } },
            ],
        }]);
    }
    if wild && rng.u8(0..6) == 0 {
        f.accessors[0]["sparse"] = json!({
            "count": rng.usize(0..4),
            "indices": { "bufferView": idx, "componentType": index_type },
            "values": { "bufferView": 0 },
        });
    }
    for _ in 0..if wild { rng.usize(0..4) } else { 0 } {
        mutate_json(rng, &mut f);
    }
    let container = rng.u8(0..4);
    let mut case = match container {
        0 => {
            let path = f.write_gltf_embedded(&std::env::temp_dir(), &format!("fuzz-{}", rng.u64(..)));
            let bytes = std::fs::read(&path).unwrap();
            let _ = std::fs::remove_file(&path);
            Case { extension: "gltf", bytes, side: None }
        }
        1 => {
            let dir = tempfile::tempdir().unwrap();
            let path = f.write_gltf_external(dir.path(), "case", "case.bin");
            Case { extension: "gltf", bytes: std::fs::read(&path).unwrap(), side: Some(("case.bin", f.buffer.clone())) }
        }
        _ => Case { extension: "glb", bytes: f.glb_bytes(), side: None },
    };
    if wild && rng.u8(0..3) == 0 {
        mutate_bytes(rng, &mut case.bytes);
    }
    if wild && container >= 2 && rng.u8(0..6) == 0 {
        // The GLB container's own fields: length, chunk lengths and types.
        let at = [8usize, 12, 16][rng.usize(0..3)];
        if case.bytes.len() >= at + 4 {
            let value = [0u32, 1, 3, u32::MAX, 0x7FFF_FFFF, rng.u32(..)][rng.usize(0..6)];
            case.bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
        }
    }
    case
}

/// Replaces one value somewhere in the document (an accessor's count, a view's offset, a node's
/// child …) by a value of another kind or range.
fn mutate_json(rng: &mut Rng, f: &mut Fixture) {
    let replacement = match rng.u8(0..10) {
        0 => json!(-1),
        1 => json!(u32::MAX),
        2 => json!(1e300),
        3 => json!(null),
        4 => json!("x"),
        5 => json!([]),
        6 => json!(rng.usize(0..8)),
        7 => json!(rng.usize(0..100_000)),
        8 => json!({}),
        _ => json!(0.5),
    };
    let target: &mut Value = match rng.u8(0..3) {
        0 if !f.accessors.is_empty() => {
            let i = rng.usize(0..f.accessors.len());
            &mut f.accessors[i]
        }
        1 if !f.views.is_empty() => {
            let i = rng.usize(0..f.views.len());
            &mut f.views[i]
        }
        _ => &mut f.root,
    };
    // A random path down the tree, as a JSON pointer.
    let mut pointer = String::new();
    let mut node: &Value = target;
    for _ in 0..6 {
        let keys: Vec<String> = match node {
            Value::Object(map) => map.keys().cloned().collect(),
            Value::Array(items) => (0..items.len()).map(|i| i.to_string()).collect(),
            _ => break,
        };
        if keys.is_empty() || rng.u8(0..4) == 0 {
            break;
        }
        let key = keys[rng.usize(0..keys.len())].clone();
        let next = match node {
            Value::Object(map) => map.get(&key),
            Value::Array(items) => key.parse::<usize>().ok().and_then(|i| items.get(i)),
            _ => None,
        };
        let Some(next) = next else { break };
        node = next;
        pointer.push('/');
        pointer.push_str(&key.replace('~', "~0").replace('/', "~1"));
    }
    // The document itself stays an object (the fixture adds its buffers and asset to it).
    if pointer.is_empty() {
        return;
    }
    if let Some(slot) = target.pointer_mut(&pointer) {
        *slot = replacement;
    }
}
