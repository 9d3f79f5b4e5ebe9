//! Structure-aware fuzzing of the text a user types (issue 28, item 5), on the stable toolchain
//! like the readers' harness (`crates/squish-io/tests/fuzz_readers.rs`):
//!
//! - `scene`: scene files built by a seeded generator that knows the format — frames, output,
//!   preview, objects with every mesh source (file, sequence, glTF table), transforms and
//!   parameters constant, keyed or as key tables, self-contact articulations, pairs — with wild
//!   values (NaN, infinities, huge integers, wrong types, unknown keys, renamed keys, empty
//!   tables) and text mutations (lines dropped, doubled, cut, bytes flipped). Each is parsed as
//!   `squish run` parses it; a scene that loads is evaluated at a few frames (and half frames),
//!   its first frame deformed on small meshes, `--frames` selections read against it and the
//!   resolved scene serialized.
//! - `set`: `--set KEY=VALUE` lists and `--params` files over every schema key (and misspelt,
//!   renamed and unknown ones), prefixes and value spellings; settings that are accepted are
//!   completed on two small meshes and deformed as `squish deform` does.
//!
//! A case fails if it panics, takes longer than [`fuzz::CASE_LIMIT`] or pushes the process's
//! peak resident memory past [`fuzz::MEMORY_LIMIT`]; the input is then kept under
//! `tests/fuzz-corpus/<target>/crash-<seed>.txt` and the test fails naming it.
//!
//! - `cargo test -p squish-cli --test fuzz_inputs` replays the corpus and a few hundred cases per
//!   target (seconds).
//! - `SQUISH_FUZZ_SECONDS=600 cargo test -p squish-cli --test fuzz_inputs -- --ignored
//!   --nocapture long_scene` (or `long_set`) runs one target for ten minutes;
//!   `SQUISH_FUZZ_SEED=N` fixes the seeds (default: the clock), printed in the summary line.

#![allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report

#[path = "../../squish-io/tests/common/fuzz.rs"]
mod fuzz;

use std::path::{Path, PathBuf};
use std::time::Instant;

use fastrand::Rng;
use glam::DVec3;
use squish::mesh::shapes;
use squish::params::{ArticulationParams, ObjectParams, PairParams, Params};
use squish::pipeline::Deformer;
use squish_cli::input::{InputMesh, WeldChoice};
use squish_cli::params::pair_settings;
use squish_io::Scene;
use squish_shot::scene_shot::SceneShot;
use squish_shot::shot::ShotSource;
use squish_shot::two_objects::deform_pair;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Scene,
    Set,
}

impl Target {
    fn name(self) -> &'static str {
        match self {
            Self::Scene => "scene",
            Self::Set => "set",
        }
    }
}

fn corpus_dir(target: Target) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus").join(target.name())
}

/// An OBJ of `mesh` with one `vt` per vertex (its x, y): the shared parametrization reads them.
fn write_obj_with_uvs(path: &Path, mesh: &squish::TriMesh) {
    let mut text = String::new();
    for p in &mesh.positions {
        text += &format!("v {:?} {:?} {:?}\nvt {:?} {:?}\n", p.x, p.y, p.z, p.x, p.y);
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| v + 1);
        text += &format!("f {a}/{a} {b}/{b} {c}/{c}\n");
    }
    std::fs::write(path, text).unwrap();
}

/// The files every case may refer to: a ball, a slab, a three-frame sequence (with UVs, so that
/// the shared parametrization can run), a per-vertex text file and a mesh that is not one.
fn write_assets(dir: &Path) {
    let ball = shapes::icosphere(0.6, 1);
    write_obj_with_uvs(&dir.join("ball.obj"), &ball);
    let mut slab = shapes::cuboid(DVec3::new(2.0, 2.0, 0.5), 4);
    slab.map_positions(|p| p - DVec3::new(0.0, 0.0, 0.25));
    let uv = |axis: usize| slab.positions.iter().map(|p| p[axis]).collect::<Vec<f64>>();
    let properties = [squish_io::VertexProperty::double("u", &uv(0)), squish_io::VertexProperty::double("v", &uv(1))];
    let options = squish_io::PlyWriteOptions::default();
    squish_io::write_ply_with(&dir.join("slab.ply"), &slab.positions, Some(&slab.triangles), &properties, &options)
        .unwrap();
    for frame in 1..=3 {
        let mut moved = ball.clone();
        moved.map_positions(|p| p + DVec3::new(0.0, 0.0, 0.1 * f64::from(frame)));
        write_obj_with_uvs(&dir.join(format!("seq_{frame:04}.obj")), &moved);
    }
    let values: String = (0..ball.num_vertices()).map(|v| format!("{}\n", (v % 3) as f64 * 0.5)).collect();
    std::fs::write(dir.join("ball_map.txt"), values).unwrap();
    std::fs::write(dir.join("short_map.txt"), "1\n2\n").unwrap();
    std::fs::write(dir.join("junk.obj"), "v 1 2\nf 1 2 9\n").unwrap();
}

/// Parses a scene as `squish run` does and, if it loads, exercises what a run does with it.
fn exercise_scene(dir: &Path, text: &str) -> bool {
    let path = dir.join("scene.toml");
    let Ok(scene) = Scene::from_toml(text, &path) else { return false };
    let range = scene.frame_range();
    let frames = scene.frames();
    let (start, end) = (*frames.start(), *frames.end());
    for selection in ["1:2", ":", "0", "-3:", "2:1", "9223372036854775807", ":-9223372036854775808"] {
        let _ = squish_io::parse_frame_selection(selection, &range);
    }
    let _ = scene.missing_files(start..=end.min(start.saturating_add(4)));
    let _ = scene.to_json();
    let middle = start / 2 + end / 2;
    for frame in [start, middle, end, start.saturating_sub(1), end.saturating_add(1)] {
        let _ = scene.evaluate(frame as f64);
        let _ = scene.evaluate(frame as f64 + 0.5);
        for i in 0..scene.description().objects.len() {
            let _ = scene.placement(i, frame as f64);
        }
    }
    if let Ok(shot) = (SceneShot { scene: &scene }).frame(start) {
        let _ = Deformer::new().deform(&shot.frame());
    }
    true
}

/// Reads `--params` and `--set` as `squish deform` does and, if accepted, deforms the ball
/// against the slab with them.
fn exercise_set(dir: &Path, text: &str) -> bool {
    let (file, sets) = split_set_case(text);
    let params = file.map(|f| {
        let path = dir.join("params.toml");
        std::fs::write(&path, f).unwrap();
        path
    });
    let Ok(mut settings) = pair_settings(params.as_deref(), &sets) else { return false };
    let Ok(a) = InputMesh::read(&dir.join("ball.obj"), WeldChoice::Auto) else { return false };
    let Ok(b) = InputMesh::read(&dir.join("slab.ply"), WeldChoice::Auto) else { return false };
    let inputs = [a, b];
    if settings.complete(&inputs).is_err() {
        return false;
    }
    let _ =
        deform_pair(["ball", "slab"], [&inputs[0].mesh, &inputs[1].mesh], &settings.parameters(), &mut Deformer::new());
    true
}

/// A `set` case's text: `--set` values one per line, then optionally `---` and a parameters file.
fn split_set_case(text: &str) -> (Option<&str>, Vec<String>) {
    let (sets, file) = match text.split_once("\n---\n") {
        Some((sets, file)) => (sets, Some(file)),
        None => (text, None),
    };
    (file, sets.lines().map(str::to_string).collect())
}

/// Runs one case on a worker thread; `Ok(true)` if it was accepted, `Err` says how it failed.
fn run_case(target: Target, text: &str, dir: &Path) -> Result<bool, String> {
    let (dir, text) = (dir.to_path_buf(), text.to_string());
    fuzz::guarded(move || match target {
        Target::Scene => exercise_scene(&dir, &text),
        Target::Set => exercise_set(&dir, &text),
    })
}

fn keep_failure(target: Target, seed: u64, text: &str, why: &str) -> String {
    let dir = corpus_dir(target);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("crash-{seed}.txt"));
    std::fs::write(&path, text).unwrap();
    format!("{} case with seed {seed} {why}; kept as {}", target.name(), path.display())
}

fn replay_corpus(target: Target, work: &Path) -> usize {
    let mut files: Vec<PathBuf> =
        std::fs::read_dir(corpus_dir(target)).map(|d| d.map(|e| e.unwrap().path()).collect()).unwrap_or_default();
    files.sort();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        if let Err(why) = run_case(target, &text, work) {
            panic!("corpus file {} {why}", file.display());
        }
    }
    files.len()
}

/// Generates and runs cases until `cases` are done or `seconds` have passed: (cases, accepted).
fn fuzz(target: Target, work: &Path, cases: u64, seconds: f64, base_seed: u64) -> (u64, u64) {
    let start = Instant::now();
    let (mut done, mut accepted) = (0u64, 0u64);
    while done < cases && start.elapsed().as_secs_f64() < seconds {
        let seed = fuzz::case_seed(base_seed, done);
        let mut rng = Rng::with_seed(seed);
        let text = match target {
            Target::Scene => scene_case(&mut rng),
            Target::Set => set_case(&mut rng),
        };
        match run_case(target, &text, work) {
            Ok(ok) => accepted += u64::from(ok),
            Err(why) => panic!("{}", keep_failure(target, seed, &text, &why)),
        }
        done += 1;
    }
    (done, accepted)
}

fn long_run(target: Target) {
    let (seconds, seed) = fuzz::long_run_settings();
    let work = tempfile::tempdir().unwrap();
    write_assets(work.path());
    let start = Instant::now();
    let replayed = replay_corpus(target, work.path());
    let (cases, accepted) = fuzz(target, work.path(), u64::MAX, seconds, seed);
    println!(
        "fuzz {}: {cases} generated cases ({accepted} accepted) and {replayed} corpus files in {:.1} min (seed {seed}), no failure; peak memory {} MB",
        target.name(),
        start.elapsed().as_secs_f64() / 60.0,
        fuzz::peak_memory_kb() / 1024
    );
}

const SHORT_CASES: u64 = 150;

/// The corpus and [`SHORT_CASES`] generated cases (seed 28), at least a tenth of them accepted
/// (else the generator no longer reaches past the parser).
fn short_run(target: Target) {
    let work = tempfile::tempdir().unwrap();
    write_assets(work.path());
    replay_corpus(target, work.path());
    let (cases, accepted) = fuzz(target, work.path(), SHORT_CASES, f64::INFINITY, 28);
    assert_eq!(cases, SHORT_CASES);
    assert!(accepted >= SHORT_CASES / 10, "only {accepted} of {cases} cases were accepted: the generator is off");
}

#[test]
fn short_scene() {
    short_run(Target::Scene);
}

#[test]
fn short_set() {
    short_run(Target::Set);
}

#[test]
#[ignore = "long fuzzing run: SQUISH_FUZZ_SECONDS=600 cargo test -p squish-cli --test fuzz_inputs -- --ignored --nocapture long_scene"]
fn long_scene() {
    long_run(Target::Scene);
}

#[test]
#[ignore = "long fuzzing run: SQUISH_FUZZ_SECONDS=600 cargo test -p squish-cli --test fuzz_inputs -- --ignored --nocapture long_set"]
fn long_set() {
    long_run(Target::Set);
}

// ---------------------------------------------------------------------------------------------
// Generators

/// A third of the cases are wild: values of any kind anywhere, and mutated text.
fn wild(rng: &mut Rng) -> bool {
    rng.u8(0..3) == 0
}

/// A TOML value that may be anything: the cases the parsers must refuse with a message.
fn wild_value(rng: &mut Rng) -> String {
    const VALUES: [&str; 34] = [
        "nan",
        "-nan",
        "inf",
        "-inf",
        "\"inf\"",
        "\"nan\"",
        "0",
        "-0.0",
        "1e308",
        "-1e308",
        "1e-320",
        "9223372036854775807",
        "-9223372036854775808",
        "9007199254740993",
        "\"\"",
        "\"auto\"",
        "\"none\"",
        "\"é\u{202e}\"",
        "true",
        "false",
        "[]",
        "[[]]",
        "[1]",
        "[1, 2, 3]",
        "[0, 0, 0]",
        "[[1, 2], [0, 3]]",
        "[[1, 2], [1, 3]]",
        "[[1, nan]]",
        "{}",
        "{ keys = [] }",
        "{ keys = [[1, 1], [2, 2]], interpolation = \"cubic\" }",
        "1979-05-27T07:32:00Z",
        "[\"a\", 1]",
        "{ file = \"ball.obj\" }",
    ];
    VALUES[rng.usize(0..VALUES.len())].to_string()
}

/// A plausible value for a parameter of `kind`, or (wild) anything.
fn param_value(rng: &mut Rng, info: &squish::params::ParamInfo, wild: bool) -> String {
    use squish::params::ParamKind;
    if wild && rng.u8(0..3) == 0 {
        return wild_value(rng);
    }
    let number = |rng: &mut Rng| -> String {
        match rng.u8(0..8) {
            0 => "0".into(),
            1 => format!("{}", rng.i32(-3..4)),
            _ => format!("{:.3}", rng.f64() * 2.0),
        }
    };
    let plain = match info.kind {
        ParamKind::Bool => ["true", "false"][rng.usize(0..2)].to_string(),
        ParamKind::Number | ParamKind::Integer => number(rng),
        ParamKind::Direction => format!("[{}, {}, {}]", number(rng), number(rng), number(rng)),
        ParamKind::NumberPair => format!("[{}, {}]", number(rng), number(rng)),
        ParamKind::PerVertex => match rng.u8(0..4) {
            0 => "\"ball_map.txt\"".into(),
            1 => "\"short_map.txt\"".into(),
            2 => "{ attribute = \"bulge\" }".into(),
            _ => "[1, 0, 1]".into(),
        },
        ParamKind::Choice(words) => format!("\"{}\"", words[rng.usize(0..words.len())]),
        ParamKind::Text => "\"out\"".into(),
    };
    if info.optional && rng.u8(0..4) == 0 {
        return format!("\"{}\"", info.word);
    }
    // Keyframed, where the key allows it.
    if info.keyframable && rng.u8(0..5) == 0 {
        return if rng.bool() {
            format!("[[1, {plain}], [3, {plain}]]")
        } else {
            let interpolation = ["linear", "smooth", "step", "bezier"][rng.usize(0..4)];
            format!("{{ keys = [[1, {plain}], [2, {plain}]], interpolation = \"{interpolation}\" }}")
        };
    }
    plain
}

/// A key of `P`, sometimes misspelt, renamed or unknown.
fn param_key<P: Params>(rng: &mut Rng, wild: bool) -> (String, Option<&'static squish::params::ParamInfo>) {
    let schema = P::schema();
    let info = &schema[rng.usize(0..schema.len())];
    if wild && rng.u8(0..6) == 0 {
        let key = match rng.u8(0..5) {
            0 => format!("{}s", info.key),
            1 => info.key.replace('_', ""),
            2 => "profile".to_string(),
            3 => "contact_method.ball".to_string(),
            _ => String::new(),
        };
        return (key, None);
    }
    (info.key.to_string(), Some(info))
}

/// `key = value` lines of parameters of `P`.
fn param_lines<P: Params>(rng: &mut Rng, wild: bool, count: std::ops::Range<usize>) -> String {
    let mut text = String::new();
    for _ in 0..rng.usize(count) {
        let (key, info) = param_key::<P>(rng, wild);
        let value = match info {
            Some(info) => param_value(rng, info, wild),
            None => wild_value(rng),
        };
        let key = if key.is_empty() || key.contains('.') { format!("\"{key}\"") } else { key };
        text.push_str(&format!("{key} = {value}\n"));
    }
    text
}

fn scene_case(rng: &mut Rng) -> String {
    let wild = wild(rng);
    let mut text = String::new();
    let (start, end) = match rng.u8(0..12) {
        0 if wild => (i64::MIN, i64::MAX),
        1 if wild => (-5_000_000_000_000_000_000, 5_000_000_000_000_000_000),
        2 if wild => (5, 1),
        3 => (0, 0),
        4 => (-3, 2),
        _ => (1, rng.i64(1..5)),
    };
    match rng.u8(0..12) {
        0 if wild => text.push_str("frames = 3\n"),
        1 if wild => text.push_str(&format!("frames = {{ start = {start} }}\n")),
        2 if wild => {
            text.push_str(&format!("frames = {{ start = {start}, end = {end}, fps = {} }}\n", wild_value(rng)))
        }
        _ => text.push_str(&format!("frames = {{ start = {start}, end = {end}, fps = 24 }}\n")),
    }
    if rng.bool() {
        let format = ["obj", "ply", "glb", "gltf", "pc2", "fbx", ""][rng.usize(0..if wild { 7 } else { 5 })];
        let dir = ["out", ".", "", "a/b/../c", "/dev/null"][rng.usize(0..if wild { 5 } else { 2 })];
        text.push_str(&format!("output = {{ dir = \"{dir}\", format = \"{format}\" }}\n"));
    }
    if rng.u8(0..4) == 0 {
        let size = if wild { wild_value(rng) } else { "[64, 48]".to_string() };
        let up = ["\"y\"", "\"z\"", "\"x\"", "1"][rng.usize(0..if wild { 4 } else { 2 })];
        text.push_str(&format!(
            "preview = {{ size = {size}, up = {up}, camera = {{ eye = [3, 3, 3], target = [0, 0, 0], fov = {} }} }}\n",
            if wild { wild_value(rng) } else { "35".into() }
        ));
    }
    if wild && rng.u8(0..6) == 0 {
        text.push_str(&format!("unknown_key = {}\n", wild_value(rng)));
    }
    let objects = match rng.u8(0..10) {
        0 if wild => 0,
        1 => 1,
        2 => 3,
        _ => 2,
    };
    let names = ["ball", "slab", "ball2", "", "a/b", "ball"];
    for k in 0..objects {
        let name = if wild && rng.u8(0..8) == 0 { names[rng.usize(0..names.len())] } else { names[k] };
        text.push_str("\n[[objects]]\n");
        text.push_str(&format!("name = \"{name}\"\n"));
        let mesh = match rng.u8(0..12) {
            0 => "\"seq_{frame:04}.obj\"".to_string(),
            1 => "{ file = \"ball.obj\", weld = true }".to_string(),
            2 if wild => "\".\"".to_string(),
            3 if wild => "\"missing.obj\"".to_string(),
            4 if wild => "\"junk.obj\"".to_string(),
            5 if wild => "\"seq_{frame:0}.obj\"".to_string(),
            6 if wild => "{ file = \"ball.obj\", node = \"x\", animation = 3 }".to_string(),
            7 if wild => wild_value(rng),
            _ if k == 1 => "\"slab.ply\"".to_string(),
            _ => "\"ball.obj\"".to_string(),
        };
        text.push_str(&format!("mesh = {mesh}\n"));
        if rng.bool() {
            let translate = match rng.u8(0..6) {
                0 if wild => wild_value(rng),
                1 => "[0, 0, 0.3]".to_string(),
                _ => format!("[[{start}, [0, 0, 0.6]], [{}, [0, 0, 0.2]]]", start.saturating_add(2)),
            };
            let rotate = if rng.u8(0..3) == 0 { ", rotate = [0, 0, 30]" } else { "" };
            let scale = if wild && rng.bool() { format!(", scale = {}", wild_value(rng)) } else { String::new() };
            text.push_str(&format!("transform = {{ translate = {translate}{rotate}{scale} }}\n"));
        }
        text.push_str(&param_lines::<ObjectParams>(rng, wild, 0..4));
        if rng.u8(0..6) == 0 {
            text.push_str("\n[[objects.self_contact]]\n");
            text.push_str(&format!("name = \"knee{}\"\n", rng.u8(0..2)));
            match rng.u8(0..3) {
                0 => text.push_str("joints = [\"thigh\", \"shin\"]\n"),
                1 => text.push_str("masks = [\"ball_map.txt\", \"ball_map.txt\"]\n"),
                _ => text.push_str(&format!("masks = {}\n", wild_value(rng))),
            }
            text.push_str(&param_lines::<ArticulationParams>(rng, wild, 0..3));
        }
    }
    let pairs = match rng.u8(0..8) {
        0 => 0,
        1 if wild => 3,
        _ => 1,
    };
    for _ in 0..pairs {
        text.push_str("\n[[pairs]]\n");
        let objects = match rng.u8(0..10) {
            0 if wild => "[\"ball\", \"ball\"]".to_string(),
            1 if wild => "[\"ball\", \"nobody\"]".to_string(),
            2 if wild => "[\"ball\"]".to_string(),
            3 if wild => wild_value(rng),
            _ => "[\"ball\", \"slab\"]".to_string(),
        };
        text.push_str(&format!("objects = {objects}\n"));
        text.push_str(&param_lines::<PairParams>(rng, wild, 0..4));
    }
    if wild {
        mutate_text(rng, &mut text);
    }
    text
}

/// Line-level and byte-level mutations: a line dropped, doubled or cut, a byte changed.
fn mutate_text(rng: &mut Rng, text: &mut String) {
    for _ in 0..rng.usize(0..3) {
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        if lines.is_empty() {
            return;
        }
        let at = rng.usize(0..lines.len());
        match rng.u8(0..5) {
            0 => {
                lines.remove(at);
            }
            1 => {
                let line = lines[at].clone();
                lines.insert(at, line);
            }
            2 => {
                let cut = rng.usize(0..=lines[at].len());
                let cut = (0..=cut).rev().find(|&c| lines[at].is_char_boundary(c)).unwrap_or(0);
                lines[at].truncate(cut);
            }
            3 => {
                let junk: String = (0..rng.usize(1..8)).map(|_| rng.char(' '..='~')).collect();
                let position = rng.usize(0..=lines[at].len());
                let position = (0..=position).rev().find(|&c| lines[at].is_char_boundary(c)).unwrap_or(0);
                lines[at].insert_str(position, &junk);
            }
            _ => {
                let other = rng.usize(0..lines.len());
                lines.swap(at, other);
            }
        }
        *text = lines.join("\n");
        text.push('\n');
    }
}

fn set_case(rng: &mut Rng) -> String {
    let wild = wild(rng);
    let mut lines = Vec::new();
    for _ in 0..rng.usize(0..5) {
        let prefix = match rng.u8(0..12) {
            0 if wild => "c",
            1 if wild => "",
            2 if wild => "a.b",
            3..=5 => "b",
            6 | 7 => "pair",
            _ => "a",
        };
        let (key, info) =
            if prefix == "pair" { param_key::<PairParams>(rng, wild) } else { param_key::<ObjectParams>(rng, wild) };
        let value = match info {
            Some(info) => param_value(rng, info, wild),
            None => wild_value(rng),
        };
        // --set spells vectors without brackets, words without quotes; both are accepted.
        let value = if rng.bool() { value.trim_matches('"').to_string() } else { value };
        let line = match rng.u8(0..14) {
            0 if wild => format!("{prefix}.{key}"),
            1 if wild => format!("{prefix}{key}={value}"),
            2 if wild => format!("={value}"),
            3 if wild => format!("{prefix}.{key}=={value}"),
            _ => format!("{prefix}.{key}={value}"),
        };
        lines.push(line);
    }
    let mut text = lines.join("\n");
    if rng.u8(0..3) == 0 {
        text.push_str("\n---\n");
        for table in ["a", "b", "pair"] {
            if rng.u8(0..3) == 0 {
                continue;
            }
            text.push_str(&format!("[{table}]\n"));
            if table == "pair" {
                text.push_str(&param_lines::<PairParams>(rng, wild, 0..4));
            } else {
                text.push_str(&param_lines::<ObjectParams>(rng, wild, 0..4));
            }
        }
        if wild && rng.u8(0..3) == 0 {
            text.push_str(&format!("c = {}\n", wild_value(rng)));
        }
        if wild {
            let mut file = text.split_off(text.find("\n---\n").unwrap() + 5);
            mutate_text(rng, &mut file);
            text.push_str(&file);
        }
    }
    text
}
