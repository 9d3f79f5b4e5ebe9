//! The adversarial corpus (issue 28, item 6): malformed and odd inputs across every format
//! (OBJ, PLY, glTF, GLB, scene TOML, parameter TOML, per-vertex text), every command (`info`,
//! `deform`, `contact`, `run`, `demo`, `bench`, `params`) and every scene key, each run through
//! the binary and checked for its exit code and for a message that names the file and line, or
//! the key, and the fix.
//!
//! Every case is a row of the table below: the files it writes, the command line, the exit code
//! and the words the message must hold (compared case-insensitively). Every case also checks that
//! nothing panicked, that the process finished within [`CASE_LIMIT`], and that an error is one
//! line (`error: …`) unless the row says the message lists several items.
//!
//! `SQUISH_CORPUS_SHOW=1 cargo test -p squish-cli --test adversarial_corpus -- --nocapture`
//! prints every case's message.

#![allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use glam::DVec3;
use squish::mesh::shapes;

const CASE_LIMIT: Duration = Duration::from_secs(60);

/// One row: files written into the case's folder (which also holds the shared meshes), the
/// arguments, the expected exit code and the words of the message.
struct Case {
    name: String,
    files: Vec<(String, Vec<u8>)>,
    args: Vec<String>,
    code: i32,
    words: Vec<String>,
    /// The message may take several lines (a list of missing files, a help text).
    multi_line: bool,
}

impl Case {
    fn new(name: impl Into<String>, args: &[&str], code: i32, words: &[&str]) -> Self {
        Self {
            name: name.into(),
            files: Vec::new(),
            args: args.iter().map(|a| a.to_string()).collect(),
            code,
            words: words.iter().map(|w| w.to_string()).collect(),
            multi_line: false,
        }
    }

    fn file(mut self, name: &str, bytes: impl Into<Vec<u8>>) -> Self {
        self.files.push((name.to_string(), bytes.into()));
        self
    }

    fn multi_line(mut self) -> Self {
        self.multi_line = true;
        self
    }
}

/// `squish info FILE` on `bytes`: exit 2, the message holds `words` (the file name and line
/// among them).
fn info(name: &str, file: &str, bytes: impl Into<Vec<u8>>, words: &[&str]) -> Case {
    Case::new(name, &["info", file], 2, words).file(file, bytes)
}

/// `squish deform` of the ball against `file`: exit 2 naming it.
fn deform_against(name: &str, file: &str, bytes: impl Into<Vec<u8>>, words: &[&str]) -> Case {
    Case::new(name, &["deform", "ball.obj", file, "-o", "out"], 2, words).file(file, bytes)
}

/// `squish deform ball slab --set SET`: exit 2, naming the key.
fn set(name: &str, set: &str, words: &[&str]) -> Case {
    Case::new(name, &["deform", "ball.obj", "slab.obj", "-o", "out", "--set", set], 2, words)
}

/// `squish contact ball slab --params params.toml` with `text`: exit 2.
fn params(name: &str, text: &str, words: &[&str]) -> Case {
    Case::new(name, &["contact", "ball.obj", "slab.obj", "-o", "out", "--params", "params.toml"], 2, words)
        .file("params.toml", text)
}

/// `squish run scene.toml --dry-run` with `text`: exit 2.
fn scene(name: &str, text: &str, words: &[&str]) -> Case {
    Case::new(name, &["run", "scene.toml", "--dry-run"], 2, words).file("scene.toml", text)
}

/// A scene of the ball on the slab with `top` after `frames`, `ball` and `slab` in the objects'
/// tables and `pair` in the pair's.
fn scene_text(top: &str, ball: &str, slab: &str, pair: &str) -> String {
    format!(
        "frames = {{ start = 1, end = 2 }}\n{top}\n[[objects]]\nname = \"ball\"\nmesh = \"ball.obj\"\n{ball}\n\n[[objects]]\nname = \"slab\"\nmesh = \"slab.obj\"\n{slab}\n\n[[pairs]]\nobjects = [\"ball\", \"slab\"]\n{pair}\n"
    )
}

const PLY_HEADER: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
const PLY_BODY: &str = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
const OBJ_TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

/// A minimal glTF document of one triangle whose buffer is `buffer` (a URI) of `length` bytes.
fn gltf_text(buffer: &str, length: usize, extra: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"uri":"{buffer}","byteLength":{length}}}],"bufferViews":[{{"buffer":0,"byteLength":36}}],"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}]{extra}}}"#
    )
}

fn cases() -> Vec<Case> {
    let mut cases = Vec::new();
    cases.extend(obj_cases());
    cases.extend(ply_cases());
    cases.extend(gltf_cases());
    cases.extend(set_cases());
    cases.extend(params_cases());
    cases.extend(scene_cases());
    cases.extend(command_cases());
    cases
}

fn obj_cases() -> Vec<Case> {
    let t = OBJ_TRIANGLE;
    vec![
        info("obj face past the vertices", "a.obj", format!("{t}f 1 2 4\n"), &["a.obj:4", "only 3", "export it again"]),
        info(
            "obj malformed coordinate",
            "a.obj",
            "v 0 0 0\nv 1 0 x\nv 0 1 0\nf 1 2 3\n",
            &["a.obj:2", "'x'", "expected a decimal number"],
        ),
        info("obj two-corner face", "a.obj", format!("{t}f 1 2\n"), &["a.obj:4", "at least 3"]),
        info("obj index zero", "a.obj", format!("{t}f 0 2 3\n"), &["a.obj:4", "indices start at 1"]),
        info(
            "obj nan coordinate",
            "a.obj",
            "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n",
            &["a.obj:2", "non-finite", "must be a finite number"],
        ),
        info(
            "obj inf coordinate",
            "a.obj",
            "v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n",
            &["a.obj:2", "(inf)", "finite number"],
        ),
        info(
            "obj overflowing coordinate",
            "a.obj",
            "v 1e400 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            &["a.obj:1", "1e400", "finite"],
        ),
        info("obj empty file", "a.obj", "", &["a.obj", "no faces", "'f' lines"]),
        info("obj vertices only", "a.obj", t, &["a.obj", "3 vertices, 0 faces", "'f' lines"]),
        info("obj lines only", "a.obj", format!("{t}l 1 2\n"), &["a.obj", "no faces"]),
        info(
            "obj texture index past the end",
            "a.obj",
            format!("{t}f 1/9 2/9 3/9\n"),
            &["a.obj:4", "texture coordinate 9", "export it again"],
        ),
        info(
            "obj relative index before the first",
            "a.obj",
            format!("{t}f -4 -2 -1\n"),
            &["a.obj:4", "-4", "before the first vertex"],
        ),
        info("obj two coordinates", "a.obj", "v 0 0\nf 1 1 1\n", &["a.obj:1", "no z coordinate", "three numbers"]),
        info(
            "obj index overflow",
            "a.obj",
            format!("{t}f 1 2 99999999999999999999\n"),
            &["a.obj:4", "99999999999999999999", "whole numbers"],
        ),
        info("obj word index", "a.obj", format!("{t}f a b c\n"), &["a.obj:4", "'a'", "v/vt/vn"]),
        info("obj malformed normal index", "a.obj", format!("{t}f 1//x 2 3\n"), &["a.obj:4", "normal index", "v//vn"]),
        info("obj binary junk", "a.obj", b"\xff\xfe\x00v 1 2 3\n".to_vec(), &["a.obj", "no faces"]),
        info(
            "obj normal past the end",
            "a.obj",
            format!("{t}vn 0 0 1\nf 1//2 2//2 3//2\n"),
            &["a.obj:5", "normal 2", "only 1"],
        ),
        info(
            "obj huge face of out-of-range corner",
            "a.obj",
            format!("{t}f 1 2 3 {}\n", "4 ".repeat(5000)),
            &["a.obj:4", "vertex 4"],
        ),
        info(
            "obj relative texture index zero",
            "a.obj",
            format!("{t}vt 0 0\nf 1/0 2/1 3/1\n"),
            &["a.obj:5", "index 0"],
        ),
        info(
            "obj comma decimal",
            "a.obj",
            "v 0 0 0\nv 1,5 0 0\nv 0 1 0\nf 1 2 3\n",
            &["a.obj:2", "'1,5'", "decimal number"],
        ),
        info("obj nan in exponent form", "a.obj", "v 0 0 0\nv 1 0 -NaN\nv 0 1 0\nf 1 2 3\n", &["a.obj:2", "finite"]),
        deform_against("obj truncated partner", "b.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n", &["b.obj:3", "vertex 3"]),
        deform_against("obj partner with no faces", "b.obj", t, &["b.obj", "no faces"]),
        Case::new("obj is a folder", &["info", "dir.obj"], 2, &["dir.obj", "folder"]).file("dir.obj/keep", ""),
        Case::new("obj missing file", &["info", "nope.obj"], 2, &["nope.obj", "check the path"]),
        Case::new("unknown extension", &["info", "a.stl"], 2, &["a.stl", ".obj, .ply, .gltf or .glb"])
            .file("a.stl", "solid"),
        Case::new("no extension", &["info", "mesh"], 2, &["mesh", "no extension", ".obj"]).file("mesh", t),
        Case::new(
            "deform first input missing",
            &["deform", "nope.obj", "slab.obj", "-o", "out"],
            2,
            &["nope.obj", "check the path"],
        ),
        Case::new(
            "contact second input missing",
            &["contact", "ball.obj", "nope.ply", "-o", "out"],
            2,
            &["nope.ply", "check the path"],
        ),
    ]
}

fn ply_cases() -> Vec<Case> {
    let h = PLY_HEADER;
    let b = PLY_BODY;
    vec![
        info(
            "ply face past the vertices",
            "a.ply",
            format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n"),
            &["a.ply:13", "vertex 5", "indices start at 0"],
        ),
        info(
            "ply truncated vertices",
            "a.ply",
            format!("{h}0 0 0\n1 0 0\n"),
            &["a.ply:12", "2 of 3", "export it again"],
        ),
        info(
            "ply more faces than declared",
            "a.ply",
            format!("{h}{b}3 0 1 2\n"),
            &["a.ply", "declares 1 face", "header line 7"],
        ),
        info("ply malformed value", "a.ply", format!("{h}0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n"), &["a.ply:11", "'y'", "'x'"]),
        info(
            "ply nan coordinate",
            "a.ply",
            format!("{h}0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"),
            &["a.ply:11", "non-finite", "finite number"],
        ),
        info("ply no vertex element", "a.ply", "ply\nformat ascii 2.0\nend_header\n", &["a.ply:3", "element vertex"]),
        info(
            "ply truncated binary",
            "a.ply",
            h.replace("ascii", "binary_little_endian") + "\0\0",
            &["a.ply", "byte", "truncated"],
        ),
        info("ply bad magic", "a.ply", "plx\n", &["a.ply:1", "first line must be 'ply'"]),
        info(
            "ply missing z",
            "a.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0\n1 0\n0 1\n3 0 1 2\n",
            &["a.ply:3", "'z'", "x, y and z"],
        ),
        info(
            "ply unknown type",
            "a.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty quux x\nend_header\n",
            &["a.ply:4", "'quux'", "expected char"],
        ),
        info("ply no end_header", "a.ply", h.replace("end_header\n", ""), &["a.ply", "end_header"]),
        info("ply two-corner face", "a.ply", format!("{h}0 0 0\n1 0 0\n0 1 0\n2 0 1\n"), &["a.ply:13", "at least 3"]),
        info(
            "ply huge vertex count",
            "a.ply",
            "ply\nformat ascii 1.0\nelement vertex 99999999999999\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
            &["a.ply:3", "99999999999999", "2^32"],
        ),
        info(
            "ply negative count",
            "a.ply",
            "ply\nformat ascii 1.0\nelement vertex -1\nend_header\n",
            &["a.ply:3", "'-1'", "element <name> <count>"],
        ),
        info(
            "ply negative index",
            "a.ply",
            format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n"),
            &["a.ply:13", "-1", "indices start at 0"],
        ),
        info(
            "ply list count over its type",
            "a.ply",
            format!("{h}0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n"),
            &["a.ply:13", "'300'", "uchar"],
        ),
        info(
            "ply unknown format",
            "a.ply",
            h.replace("ascii", "binary_middle_endian"),
            &["a.ply:2", "binary_middle_endian"],
        ),
        info("ply missing format line", "a.ply", "ply\nelement vertex 3\nend_header\n", &["a.ply", "format"]),
        info("ply float face index", "a.ply", format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1 1.5\n"), &["a.ply:13", "'1.5'"]),
        info(
            "ply fewer faces than declared",
            "a.ply",
            h.replace("face 1", "face 2") + b,
            &["a.ply", "1 of 2", "truncated"],
        ),
        info(
            "ply extra value on a vertex line",
            "a.ply",
            format!("{h}0 0 0 7\n1 0 0\n0 1 0\n3 0 1 2\n"),
            &["a.ply:10", "vertex 0"],
        ),
        info("ply empty file", "a.ply", "", &["a.ply", "empty", "'ply'"]),
        info(
            "ply list without count type",
            "a.ply",
            h.replace("list uchar int", "list int"),
            &["a.ply:8", "'vertex_indices'", "expected char"],
        ),
        info(
            "ply big-endian truncated",
            "a.ply",
            h.replace("ascii", "binary_big_endian") + "\0\0\0\0",
            &["a.ply", "byte", "truncated"],
        ),
        deform_against(
            "ply partner past the vertices",
            "b.ply",
            format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n"),
            &["b.ply:13", "vertex 9"],
        ),
        deform_against("ply partner truncated", "b.ply", h.to_string(), &["b.ply", "truncated"]),
    ]
}

fn gltf_cases() -> Vec<Case> {
    let triangle = base64_triangle();
    vec![
        info(
            "glb truncated header",
            "a.glb",
            b"glTF\x02\x00\x00\x00".to_vec(),
            &["a.glb", "12-byte GLB header", "export it again"],
        ),
        info(
            "glb bad magic",
            "a.glb",
            b"gltX\x02\x00\x00\x00\x0c\x00\x00\x00".to_vec(),
            &["a.glb", "magic bytes", "another format"],
        ),
        info(
            "glb length past the file",
            "a.glb",
            b"glTF\x02\x00\x00\x00\xff\xff\x00\x00".to_vec(),
            &["a.glb", "65535", "truncated"],
        ),
        info("glb version 1", "a.glb", b"glTF\x01\x00\x00\x00\x0c\x00\x00\x00".to_vec(), &["a.glb", "version"]),
        info("gltf invalid json", "a.gltf", "{", &["a.gltf", "invalid glTF JSON", "line 1"]),
        info(
            "gltf no meshes",
            "a.gltf",
            r#"{"asset":{"version":"2.0"}}"#,
            &["a.gltf", "empty", "at least one triangle"],
        ),
        info("gltf array document", "a.gltf", "[]", &["a.gltf", "not a glTF file"]),
        info(
            "gltf missing buffer file",
            "a.gltf",
            gltf_text("missing.bin", 36, ""),
            &["a.gltf", "missing.bin", "folder"],
        ),
        info(
            "gltf short data uri",
            "a.gltf",
            gltf_text("data:application/octet-stream;base64,AAAA", 36, ""),
            &["a.gltf", "buffer 0", "declares 36"],
        ),
        info(
            "gltf position accessor past the end",
            "a.gltf",
            r#"{"asset":{"version":"2.0"},"meshes":[{"primitives":[{"attributes":{"POSITION":7}}]}]}"#,
            &["a.gltf", "accessor 7", "export it again"],
        ),
        info(
            "gltf bad base64",
            "a.gltf",
            gltf_text("data:application/octet-stream;base64,@@@@", 36, ""),
            &["a.gltf", "base64", "export it again"],
        ),
        info(
            "gltf buffer path outside",
            "a.gltf",
            gltf_text("../../../../etc/none.bin", 36, ""),
            &["a.gltf", "none.bin"],
        ),
        info(
            "gltf two scenes of nothing",
            "a.gltf",
            r#"{"asset":{"version":"2.0"},"scenes":[{},{}]}"#,
            &["a.gltf", "`nodes`", "not glTF 2.0"],
        ),
        info(
            "gltf node cycle",
            "a.gltf",
            gltf_text(&triangle, 36, "")
                .replace(r#""nodes":[{"mesh":0}]"#, r#""nodes":[{"mesh":0,"children":[1]},{"children":[0]}]"#),
            &["a.gltf", "node"],
        ),
        info(
            "gltf accessor count over the view",
            "a.gltf",
            gltf_text(&triangle, 36, "").replace(r#""count":3"#, r#""count":300000000"#),
            &["a.gltf", "accessor"],
        ),
        info(
            "gltf wrong accessor type",
            "a.gltf",
            gltf_text(&triangle, 36, "").replace("VEC3", "VEC2"),
            &["a.gltf", "POSITION"],
        ),
        info(
            "gltf nan min",
            "a.gltf",
            gltf_text(&triangle, 36, "").replace("\"min\":[0,0,0]", "\"min\":[NaN,0,0]"),
            &["a.gltf", "JSON"],
        ),
        info(
            "gltf animation target past the nodes",
            "a.gltf",
            gltf_text(
                &triangle,
                36,
                r#","animations":[{"channels":[{"sampler":0,"target":{"node":9,"path":"translation"}}],"samplers":[{"input":0,"output":0}]}]"#,
            ),
            &["a.gltf", "animation 0 channel 0", "node 9", "export it again"],
        ),
        info("gltf version 1", "a.gltf", r#"{"asset":{"version":"1.0"},"meshes":[]}"#, &["a.gltf", "1.0", "glTF 2.0"]),
        Case::new("run on a glb", &["run", "a.glb"], 2, &["a.glb", "not a scene file", "squish deform"])
            .file("a.glb", b"glTF\x02\x00\x00\x00".to_vec()),
        Case::new("run on an obj", &["run", "ball.obj"], 2, &["ball.obj", "not a scene file", "squish deform"]),
    ]
}

/// One triangle's positions as a data URI.
fn base64_triangle() -> String {
    use base64::Engine;
    let floats: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
    format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(bytes))
}

fn set_cases() -> Vec<Case> {
    vec![
        set("set nan stiffness", "a.stiffness=nan", &["a.stiffness", "\"nan\"", "number > 0"]),
        set("set word stiffness", "a.stiffness=soft", &["a.stiffness", "\"soft\"", "number > 0"]),
        set("set maybe rigid", "a.rigid=maybe", &["a.rigid", "\"maybe\"", "true or false"]),
        set("set negative stiffness", "b.stiffness=-1", &["b.stiffness", "must be > 0"]),
        set("set zero stiffness", "b.stiffness=0", &["b.stiffness", "must be > 0"]),
        set("set inf stiffness", "a.stiffness=inf", &["a.stiffness"]),
        set("set unknown key", "a.stifness=2", &["stifness", "did you mean", "stiffness"]),
        set("set unknown prefix", "c.stiffness=2", &["\"c\"", "a.KEY, b.KEY or pair.KEY"]),
        set("set no prefix", "stiffness=2", &["stiffness", "a.stiffness, b.stiffness or pair.stiffness"]),
        set("set no equals", "a.stiffness", &["a.stiffness", "KEY=VALUE"]),
        set("set empty value", "a.stiffness=", &["a.stiffness", "number"]),
        set("set pair key on an object", "a.contact_tau=1", &["contact_tau"]),
        set("set object key on the pair", "pair.stiffness=1", &["pair", "stiffness"]),
        set("set bad choice", "pair.contact_method=balls", &["pair.contact_method", "did you mean", "ball"]),
        set("set zero direction", "pair.direction=0,0,0", &["pair.direction", "non-zero"]),
        set("set short direction", "pair.direction=1,0", &["pair.direction", "1,0"]),
        set("set nan direction", "pair.direction=nan,0,1", &["pair.direction", "nan,0,1"]),
        set("set negative ball radius", "pair.ball_radius=-2", &["pair.ball_radius", "> 0"]),
        set("set profile out of range", "a.profile_v2=1.5", &["a.profile_v2", "(0.2, 1)"]),
        set("set negative bulge", "b.bulge=-1", &["b.bulge", "≥ 0"]),
        set("set safeguard over 180", "pair.safeguard_angle=200", &["pair.safeguard_angle", "180"]),
        set("set renamed key", "a.profile.x2=0.3", &["profile", "profile_v2"]),
        set("set domain factor below 1", "a.domain_factor=0.5", &["a.domain_factor", "≥ 1"]),
        set("set bulge map file missing", "a.bulge_map=nomap.txt", &["--set a.bulge_map=nomap.txt", "check the path"]),
        set("set bulge map of wrong length", "a.bulge_map=1,2,3", &["a.bulge_map", "3 values", "one value per vertex"]),
        set("set region mask without mask", "a.region=mask", &["region_mask"]),
        set("set ball without radius", "pair.contact_method=ball", &["ball_radius"]),
        set("set huge integer", "a.stiffness=1e400", &["a.stiffness", "1e400"]),
        set("set unknown word for extent", "a.extent=big", &["a.extent", "\"big\"", "auto"]),
        set("set anisotropy offset at -1", "a.anisotropy_offset=-1", &["a.anisotropy_offset", "> -1"]),
        Case::new(
            "set bulge map of short file",
            &["deform", "ball.obj", "slab.obj", "-o", "out", "--set", "a.bulge_map=short.txt"],
            2,
            &["short.txt", "2", "vertices"],
        )
        .file("short.txt", "1\n2\n"),
        Case::new(
            "set bulge map with a word",
            &["deform", "ball.obj", "slab.obj", "-o", "out", "--set", "a.bulge_map=bad.txt"],
            2,
            &["bad.txt:2", "\"abc\"", "one number per line"],
        )
        .file("bad.txt", "1\nabc\n"),
    ]
}

fn params_cases() -> Vec<Case> {
    vec![
        params("params nan", "[a]\nstiffness = nan\n", &["params.toml", "a.stiffness", "> 0"]),
        params("params inf tau", "[pair]\ncontact_tau = inf\n", &["params.toml", "pair.contact_tau", "finite"]),
        params("params string number", "[a]\nstiffness = \"2\"\n", &["params.toml", "a.stiffness"]),
        params("params unknown table", "[c]\nstiffness = 2\n", &["params.toml", "\"c\""]),
        params("params value not table", "a = 3\n", &["params.toml", "\"a\"", "must be a table"]),
        params("params unknown key", "[b]\nrigd = true\n", &["params.toml", "rigd", "did you mean"]),
        params("params invalid toml", "[a\nstiffness = 1\n", &["params.toml:1", "invalid TOML", "`]`"]),
        params("params date", "[a]\nstiffness = 1979-05-27\n", &["params.toml", "a.stiffness", "date"]),
        params("params table value", "[a]\nstiffness = { x = 1 }\n", &["params.toml", "a.stiffness", "table"]),
        params("params list for a bool", "[a]\nrigid = [true]\n", &["params.toml", "a.rigid"]),
        params("params huge integer", "[a]\nstiffness = 9223372036854775807\n", &["params.toml", "2^53"]),
        params(
            "params both rigid",
            "[a]\nrigid = true\n[b]\nrigid = true\n",
            &["a.rigid", "b.rigid", "set one of them to false"],
        ),
        params("params keyframes in a file", "[a]\nstiffness = [[1, 2], [3, 4]]\n", &["params.toml", "a.stiffness"]),
        Case::new(
            "params file missing",
            &["deform", "ball.obj", "slab.obj", "--params", "none.toml"],
            2,
            &["none.toml", "cannot read parameters", "check the path"],
        ),
        Case::new(
            "params file is a folder",
            &["deform", "ball.obj", "slab.obj", "--params", "p.d"],
            2,
            &["p.d", "folder", "[pair]"],
        )
        .file("p.d/x", ""),
    ]
}

fn scene_cases() -> Vec<Case> {
    let base = |top: &str| scene_text(top, "", "", "");
    let ball = |extra: &str| scene_text("", extra, "", "");
    let pair = |extra: &str| scene_text("", "", "", extra);
    let mut cases = vec![
        scene(
            "scene no frames",
            &base("").replace("frames = { start = 1, end = 2 }\n", ""),
            &["scene.toml", "the top level", "add frames"],
        ),
        scene("scene frames without end", &base("").replace(", end = 2", ""), &["scene.toml:1", "\"end\"", "add end"]),
        scene("scene zero fps", &base("").replace("end = 2", "end = 2, fps = 0"), &["scene.toml:1", "fps", "> 0"]),
        scene("scene nan fps", &base("").replace("end = 2", "end = 2, fps = nan"), &["scene.toml:1", "fps", "> 0"]),
        scene(
            "scene end before start",
            &base("").replace("start = 1", "start = 3"),
            &["scene.toml:1", "end", "≥ start"],
        ),
        scene(
            "scene fractional start",
            &base("").replace("start = 1", "start = 1.5"),
            &["scene.toml:1", "start", "whole number"],
        ),
        scene(
            "scene i64 frames",
            &base("").replace("start = 1, end = 2", "start = -9223372036854775808, end = 9223372036854775807"),
            &["scene.toml:1", "2^53", "smaller number"],
        ),
        scene(
            "scene frames that overflow",
            &base("").replace("start = 1, end = 2", "start = -5000000000000000, end = 5000000000000000"),
            &["scene.toml:1", "frames"],
        ),
        scene(
            "scene frames a number",
            &base("").replace("frames = { start = 1, end = 2 }", "frames = 3"),
            &["scene.toml:1", "frames", "expected a table"],
        ),
        scene(
            "scene unknown output format",
            &base("output = { format = \"fbx\" }"),
            &["scene.toml:2", "format", "\"obj\""],
        ),
        scene("scene output dir a number", &base("output = { dir = 3 }"), &["scene.toml:2", "dir", "text"]),
        scene("scene unknown top key", &base("foo = 1"), &["scene.toml:2", "\"foo\"", "valid keys"]),
        scene("scene misspelt top key", &base("ouput = { dir = \"x\" }"), &["scene.toml:2", "ouput", "output"]),
        scene("scene preview tiny", &base("preview = { size = [1, 1] }"), &["scene.toml:2", "size", "16 to 8192"]),
        scene("scene preview bad up", &base("preview = { up = \"x\" }"), &["scene.toml:2", "up", "\"y\""]),
        scene(
            "scene preview camera without target",
            &base("preview = { camera = { eye = [1, 1, 1] } }"),
            &["scene.toml:2", "target"],
        ),
        scene("scene invalid toml", "frames = { start = 1, end = 2 \n", &["scene.toml:1", "invalid TOML"]),
        scene("scene empty", "", &["scene.toml", "frames"]),
        scene("scene no objects", "frames = { start = 1, end = 2 }\n", &["scene.toml", "objects"]),
        scene(
            "scene object without mesh",
            "frames = { start = 1, end = 2 }\n[[objects]]\nname = \"a\"\n",
            &["scene.toml", "\"a\"", "mesh"],
        ),
        scene(
            "scene object without name",
            "frames = { start = 1, end = 2 }\n[[objects]]\nmesh = \"ball.obj\"\n",
            &["scene.toml", "name"],
        ),
        scene(
            "scene name with a slash",
            &ball("").replace("name = \"ball\"", "name = \"a/b\""),
            &["scene.toml:4", "'/'", "use letters"],
        ),
        scene("scene empty name", &ball("").replace("name = \"ball\"", "name = \"\""), &["scene.toml:4", "name"]),
        scene(
            "scene duplicate name",
            &ball("").replace("name = \"slab\"", "name = \"ball\""),
            &["scene.toml", "already used", "unique"],
        ),
        scene(
            "scene mesh is a folder",
            &ball("").replace("mesh = \"ball.obj\"", "mesh = \".\""),
            &["scene.toml:5", "folder", "give a .obj"],
        ),
        scene(
            "scene mesh missing",
            &ball("").replace("mesh = \"ball.obj\"", "mesh = \"none.obj\""),
            &["scene.toml:5", "none.obj", "scene file's folder"],
        ),
        scene("scene mesh a number", &ball("").replace("mesh = \"ball.obj\"", "mesh = 3"), &["scene.toml:5", "mesh"]),
        scene(
            "scene mesh unknown extension",
            &ball("").replace("mesh = \"ball.obj\"", "mesh = \"ball.stl\""),
            &["scene.toml:5", "ball.stl", ".obj, .ply"],
        )
        .file("ball.stl", "solid x\n"),
        scene(
            "scene sequence missing",
            &ball("").replace("mesh = \"ball.obj\"", "mesh = \"b_{frame:04}.obj\""),
            &["b_0001.obj", "{frame}"],
        ),
        scene(
            "scene bad frame pattern",
            &ball("").replace("mesh = \"ball.obj\"", "mesh = \"b_{frame:x}.obj\""),
            &["scene.toml", "{frame"],
        ),
        scene(
            "scene node on an obj",
            &ball("").replace("mesh = \"ball.obj\"", "mesh = { file = \"ball.obj\", node = \"x\" }"),
            &["scene.toml:5", "node", "glTF"],
        ),
        scene(
            "scene unknown mesh key",
            &ball("").replace("mesh = \"ball.obj\"", "mesh = { file = \"ball.obj\", wield = true }"),
            &["scene.toml:5", "wield"],
        ),
        scene(
            "scene negative weld",
            &ball("").replace("mesh = \"ball.obj\"", "mesh = { file = \"ball.obj\", weld = -1 }"),
            &["scene.toml:5", "weld"],
        ),
        scene(
            "scene mesh file broken",
            &ball("").replace("mesh = \"ball.obj\"", "mesh = \"broken.obj\""),
            &["broken.obj:1"],
        )
        .file("broken.obj", "v 0 0\n"),
        scene(
            "scene translate two numbers",
            &ball("transform = { translate = [1, 2] }"),
            &["scene.toml:6", "translate", "[x, y, z]"],
        ),
        scene(
            "scene unknown transform key",
            &ball("transform = { spin = 3 }"),
            &["scene.toml:6", "\"spin\"", "translate, rotate, scale"],
        ),
        scene("scene zero scale", &ball("transform = { scale = 0 }"), &["scene.toml:6", "scale"]),
        scene("scene nan rotate", &ball("transform = { rotate = [nan, 0, 0] }"), &["scene.toml:6", "rotate"]),
        scene(
            "scene keys out of order",
            &ball("stiffness = [[2, 1], [1, 2]]"),
            &["scene.toml:6", "stiffness", "increasing frame order"],
        ),
        scene(
            "scene unknown interpolation",
            &ball("extent = { keys = [[1, 1]], interpolation = \"cubic\" }"),
            &["scene.toml:6", "cubic", "\"linear\""],
        ),
        scene("scene empty keys", &ball("extent = { keys = [] }"), &["scene.toml:6", "extent"]),
        scene("scene key not a pair", &ball("bulge = [[1]]"), &["scene.toml:6", "bulge"]),
        scene("scene keyframed rigid", &ball("rigid = [[1, true], [2, false]]"), &["scene.toml:6", "rigid"]),
        scene("scene key with nan", &ball("bulge = [[1, nan]]"), &["scene.toml:6", "bulge"]),
        scene(
            "scene bulge map missing",
            &ball("bulge_map = \"nomap.txt\""),
            &["scene.toml:6", "nomap.txt", "scene file's folder"],
        ),
        scene(
            "scene bulge map attribute missing",
            &ball("bulge_map = { attribute = \"paint\" }"),
            &["ball.obj", "bulge_map", "text file"],
        ),
        scene("scene bulge map short", &ball("bulge_map = \"short.txt\""), &["short.txt", "2"])
            .file("short.txt", "1\n2\n"),
        scene("scene region mask missing", &ball("region = \"mask\""), &["scene.toml:6", "region_mask"]),
        scene("scene profile renamed", &ball("profile = [0.3, 0.8, 0.9]"), &["scene.toml:6", "profile_v2"]),
        scene("scene anisotropy renamed", &ball("anisotropic_bulge = true"), &["scene.toml:6", "anisotropy"]),
        scene("scene profile out of order", &ball("profile_v2 = 0.9\nprofile_v3 = 0.5"), &["scene.toml", "profile_v"]),
        scene(
            "scene self contact without regions",
            &ball("[[objects.self_contact]]\nname = \"k\""),
            &["scene.toml", "\"k\"", "joints = "],
        ),
        scene(
            "scene self contact joints on an obj",
            &ball("[[objects.self_contact]]\nname = \"k\"\njoints = [\"a\", \"b\"]"),
            &["scene.toml", "\"k\"", "glTF"],
        ),
        scene(
            "scene self contact bad tau",
            &ball("[[objects.self_contact]]\nname = \"k\"\nmasks = [\"m.txt\", \"m.txt\"]\ncontact_tau = \"x\""),
            &["scene.toml", "contact_tau"],
        ),
        scene(
            "scene self contact unknown key",
            &ball("[[objects.self_contact]]\nname = \"k\"\nmasks = [\"m.txt\", \"m.txt\"]\nstifness = 2"),
            &["scene.toml", "stifness", "stiffness"],
        ),
        scene(
            "scene pair unknown object",
            &pair("").replace("[\"ball\", \"slab\"]", "[\"ball\", \"zz\"]"),
            &["scene.toml", "\"zz\"", "the objects are"],
        ),
        scene(
            "scene pair same object",
            &pair("").replace("[\"ball\", \"slab\"]", "[\"ball\", \"ball\"]"),
            &["scene.toml", "same object twice", "self_contact"],
        ),
        scene(
            "scene pair one object",
            &pair("").replace("[\"ball\", \"slab\"]", "[\"ball\"]"),
            &["scene.toml", "objects"],
        ),
        scene(
            "scene pair twice",
            &format!("{}\n[[pairs]]\nobjects = [\"slab\", \"ball\"]\n", pair("")),
            &["scene.toml", "pair"],
        ),
        scene(
            "scene pair without objects",
            &pair("").replace("objects = [\"ball\", \"slab\"]", ""),
            &["scene.toml", "objects"],
        ),
        scene("scene pair both rigid", &scene_text("", "rigid = true", "rigid = true", ""), &["scene.toml", "rigid"]),
        scene("scene tau a word", &pair("contact_tau = \"x\""), &["scene.toml", "contact_tau", "number"]),
        scene("scene zero direction", &pair("direction = [0, 0, 0]"), &["scene.toml", "direction", "non-zero"]),
        scene("scene ball without radius", &pair("contact_method = \"ball\""), &["scene.toml", "ball_radius"]),
        scene("scene unknown pair key", &pair("contact_taux = 1"), &["scene.toml", "contact_taux", "contact_tau"]),
        scene("scene unknown method", &pair("contact_method = \"magic\""), &["scene.toml", "magic", "\"geometric\""]),
        scene("scene enabled a number", &pair("enabled = 3"), &["scene.toml", "enabled", "true or false"]),
        scene("scene safeguard over 180", &pair("safeguard_angle = 181"), &["scene.toml", "safeguard_angle", "180"]),
        scene(
            "scene method A without its radius",
            &pair("mapping = \"shared_parametrization\"\ncontact_method = \"ball\""),
            &["scene.toml:14", "ball_radius", "needs"],
        ),
    ];
    // Every object parameter and every pair parameter with a value of the wrong kind: the
    // message names the key and what it expects.
    // Every object, pair and articulation parameter given a date (no parameter is one) and a
    // table that is not a key table: the message names the key and what to write.
    let articulation =
        |extra: &str| ball(&format!("[[objects.self_contact]]\nname = \"k\"\nmasks = [\"m.txt\", \"m.txt\"]\n{extra}"));
    let levels: [Level; 3] = [
        ("object", <squish::ObjectParams as squish::Params>::schema(), &ball, "scene.toml:6"),
        ("pair", <squish::PairParams as squish::Params>::schema(), &pair, "scene.toml:15"),
        ("articulation", <squish::ArticulationParams as squish::Params>::schema(), &articulation, "scene.toml:9"),
    ];
    for (level, schema, text, line) in levels {
        for info in schema {
            let expected =
                if info.kind == squish::params::ParamKind::PerVertex { "expected a text file" } else { "not a date" };
            cases.push(scene(
                &format!("scene {level} key {} a date", info.key),
                &text(&format!("{} = 1979-05-27", info.key)),
                &[line, info.key, expected],
            ));
            if info.kind != squish::params::ParamKind::PerVertex {
                cases.push(scene(
                    &format!("scene {level} key {} a table", info.key),
                    &text(&format!("{} = {{ x = 1 }}", info.key)),
                    &[line, info.key, "unknown key \"x\"", "keys = [[frame, value]"],
                ));
            }
        }
    }
    cases
}

/// A parameter level of the scene: its name, its schema, the scene text with a line added to its
/// table, and the line that table's parameters are on.
type Level<'a> = (&'a str, &'a [squish::params::ParamInfo], &'a dyn Fn(&str) -> String, &'a str);

fn command_cases() -> Vec<Case> {
    let deform = |extra: &[&str]| -> Vec<String> {
        let mut args: Vec<String> = ["deform", "ball.obj", "slab.obj"].iter().map(|s| s.to_string()).collect();
        args.extend(extra.iter().map(|s| s.to_string()));
        args
    };
    let with_args = |name: &str, args: Vec<String>, code: i32, words: &[&str]| {
        let mut case = Case::new(name, &[], code, words);
        case.args = args;
        case
    };
    let run_scene = scene_text("", "", "", "");
    vec![
        with_args(
            "deform -o an existing file",
            deform(&["-o", "taken"]),
            2,
            &["taken", "is a file", "give -o a folder"],
        )
        .file("taken", "x"),
        with_args("deform -o under a file", deform(&["-o", "taken/sub"]), 2, &["taken/sub", "a file is in the way"])
            .file("taken", "x"),
        Case::new(
            "run -o an existing file",
            &["run", "scene.toml", "-o", "taken"],
            2,
            &["taken", "is a file", "give -o a folder"],
        )
        .file("taken", "x")
        .file("scene.toml", run_scene.clone()),
        Case::new(
            "contact -o an existing file",
            &["contact", "ball.obj", "slab.obj", "-o", "taken"],
            2,
            &["taken", "is a file"],
        )
        .file("taken", "x"),
        with_args(
            "deform identical meshes",
            vec!["deform".into(), "ball.obj".into(), "ball.obj".into(), "-o".into(), "out".into()],
            2,
            &["--set pair.direction="],
        ),
        with_args(
            "contact identical meshes",
            vec!["contact".into(), "ball.obj".into(), "ball.obj".into(), "-o".into(), "out".into()],
            2,
            &["--set pair.direction="],
        ),
        with_args(
            "deform ball without a rigid object",
            deform(&["-o", "out", "--set", "pair.contact_method=ball", "--set", "pair.ball_radius=0.5"]),
            2,
            &["rigid", "--set"],
        ),
        with_args("deform unknown format", deform(&["-o", "out", "--format", "stl"]), 2, &["stl", "possible values"])
            .multi_line(),
        with_args(
            "deform unknown weld",
            deform(&["-o", "out", "--weld", "sometimes"]),
            2,
            &["sometimes", "possible values"],
        )
        .multi_line(),
        with_args("deform one input", vec!["deform".into(), "ball.obj".into()], 2, &["<B>", "usage"]).multi_line(),
        Case::new("run frames out of the scene", &["run", "scene.toml", "--frames", "5:9"], 2, &["scene.toml", "5"])
            .file("scene.toml", run_scene.clone()),
        Case::new("run frames reversed", &["run", "scene.toml", "--frames", "2:1"], 2, &["scene.toml", "2:1"])
            .file("scene.toml", run_scene.clone()),
        Case::new("run frames a word", &["run", "scene.toml", "--frames", "all"], 2, &["scene.toml", "\"all\""])
            .file("scene.toml", run_scene.clone()),
        Case::new(
            "run frames overflow",
            &["run", "scene.toml", "--frames", "9223372036854775807:"],
            2,
            &["scene.toml", "9223372036854775807"],
        )
        .file("scene.toml", run_scene.clone()),
        Case::new("run zero threads", &["run", "scene.toml", "--threads", "0"], 2, &["--threads 0", "at least 1"])
            .file("scene.toml", run_scene.clone()),
        Case::new("run preview frame outside", &["run", "scene.toml", "-o", "out", "--preview=99"], 2, &["99"])
            .file("scene.toml", run_scene.clone()),
        Case::new("run preview word", &["run", "scene.toml", "-o", "out", "--preview=abc"], 2, &["abc"])
            .file("scene.toml", run_scene.clone()),
        Case::new("run missing scene", &["run", "none.toml"], 2, &["none.toml"]),
        Case::new("run scene is a folder", &["run", "sc.d"], 2, &["sc.d", "it is a folder"]).file("sc.d/x", ""),
        Case::new(
            "run pc2 with glTF frames",
            &["run", "scene.toml", "--format", "fbx"],
            2,
            &["fbx", "possible values"],
        )
        .file("scene.toml", run_scene.clone())
        .multi_line(),
        Case::new(
            "bench unknown scene",
            &["bench", "--quick", "--scenes", "no_such_scene"],
            2,
            &["no_such_scene", "the scenes are"],
        ),
        Case::new(
            "bench unknown shot",
            &["bench", "--quick", "--shot", "no_such_scene"],
            2,
            &["no_such_scene", "one of"],
        ),
        Case::new("bench zero rounds", &["bench", "--rounds", "0"], 2, &["--rounds", "at least 1"]),
        Case::new("bench zero threads", &["bench", "--threads", "0"], 2, &["--threads", "at least 1"]),
        Case::new(
            "demo zero threads",
            &["demo", "--quick", "--threads", "0", "-o", "out"],
            2,
            &["--threads 0", "at least 1"],
        ),
        Case::new("demo -o an existing file", &["demo", "--quick", "-o", "taken"], 2, &["taken", "is a file"])
            .file("taken", "x"),
        Case::new("params unknown level", &["params", "--markdown", "objects"], 2, &["objects", "possible values"])
            .multi_line(),
        Case::new("unknown command", &["squash"], 2, &["squash", "usage"]).multi_line(),
        Case::new("info strict on nothing", &["info", "--strict", "ball.obj"], 2, &["--strict"]).multi_line(),
    ]
}

/// Writes the shared inputs: a ball 0.2 deep into a slab (OBJ and PLY).
fn write_shared(dir: &Path) {
    let mut ball = shapes::icosphere(0.6, 1);
    ball.map_positions(|p| p + DVec3::new(0.0, 0.0, 0.4));
    squish_io::write_mesh(&dir.join("ball.obj"), &ball).unwrap();
    let mut slab = shapes::cuboid(DVec3::new(2.0, 2.0, 0.5), 4);
    slab.map_positions(|p| p - DVec3::new(0.0, 0.0, 0.25));
    squish_io::write_mesh(&dir.join("slab.obj"), &slab).unwrap();
    let values: String = (0..ball.num_vertices()).map(|_| "1\n").collect();
    std::fs::write(dir.join("m.txt"), values).unwrap();
}

/// Runs one case in `dir`; returns what is wrong with it, if anything, and its message.
fn run_case(case: &Case, dir: &Path) -> (Option<String>, String) {
    for (name, bytes) in &case.files {
        let path = dir.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_squish"))
        .args(&case.args)
        .current_dir(dir)
        .env("SQUISH_DATA", dir.join("no-data"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > CASE_LIMIT {
            let _ = child.kill();
            return (Some(format!("took longer than {CASE_LIMIT:?}")), String::new());
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    let message = stderr.trim().to_string();
    let lower = message.to_lowercase();
    let mut problems = Vec::new();
    if status.code() != Some(case.code) {
        problems.push(format!("exit code {:?}, expected {}", status.code(), case.code));
    }
    if lower.contains("panicked") || lower.contains("backtrace") {
        problems.push("panicked".to_string());
    }
    for word in &case.words {
        if !lower.contains(&word.to_lowercase()) {
            problems.push(format!("no \"{word}\" in the message"));
        }
    }
    let error_lines: Vec<&str> = message
        .lines()
        .filter(|l| !l.starts_with("note:") && !l.starts_with("warning:") && !l.trim().is_empty())
        .collect();
    if !case.multi_line && error_lines.len() != 1 {
        problems.push(format!("{} lines, expected a one-line error", error_lines.len()));
    }
    if !case.multi_line && !error_lines.first().is_some_and(|l| l.starts_with("error: ")) {
        problems.push("the message does not start with \"error: \"".to_string());
    }
    ((!problems.is_empty()).then(|| problems.join("; ")), message)
}

#[test]
fn every_malformed_input_fails_with_its_code_and_a_message_naming_it_and_the_fix() {
    let root = tempfile::tempdir().unwrap();
    let shared = root.path().join("shared");
    std::fs::create_dir(&shared).unwrap();
    write_shared(&shared);
    let cases = cases();
    assert!(cases.len() >= 150, "the corpus has {} cases", cases.len());
    let show = std::env::var_os("SQUISH_CORPUS_SHOW").is_some();
    let mut failures = Vec::new();
    for (k, case) in cases.iter().enumerate() {
        let dir: PathBuf = root.path().join(format!("case{k:03}"));
        std::fs::create_dir(&dir).unwrap();
        for entry in std::fs::read_dir(&shared).unwrap() {
            let entry = entry.unwrap();
            std::fs::copy(entry.path(), dir.join(entry.file_name())).unwrap();
        }
        let (problem, message) = run_case(case, &dir);
        if show {
            println!("[{k:03}] {}: {message}", case.name);
        }
        if let Some(problem) = problem {
            failures.push(format!("{} ({:?}): {problem}\n    message: {message}", case.name, case.args));
        }
    }
    assert!(failures.is_empty(), "{} of {} cases failed:\n{}", failures.len(), cases.len(), failures.join("\n"));
}
