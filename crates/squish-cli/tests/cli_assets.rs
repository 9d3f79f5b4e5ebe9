//! Issue 23 end to end: results that go back into the asset they came from (OBJ with UVs and
//! materials, glTF characters), point caches checked against the per-frame files, previews of
//! single frames, `info` on glTF, and the bad inputs that must stay clear errors (exit 2).

#![allow(clippy::unwrap_used)]

#[path = "../../squish-io/tests/common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use glam::DVec3;
use squish::mesh::shapes;

fn squish() -> Command {
    Command::new(env!("CARGO_BIN_EXE_squish"))
}

fn ok(output: &Output) -> String {
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    String::from_utf8_lossy(&output.stdout).into_owned()
}

fn bad_input(output: &Output) -> String {
    assert_eq!(output.status.code(), Some(2), "{}", String::from_utf8_lossy(&output.stdout));
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// An icosphere as OBJ with spherical UVs (`v/vt/vn` corners), a material library and groups.
fn textured_ball(path: &Path, centre: DVec3) {
    let sphere = shapes::icosphere(1.0, 3);
    let mut text = String::from("# ball\nmtllib ball.mtl\no Ball\n");
    for p in &sphere.positions {
        let q = *p + centre;
        text += &format!("v {} {} {}\n", q.x, q.y, q.z);
    }
    for p in &sphere.positions {
        text += &format!("vt {} {}\n", 0.5 + p.x.atan2(p.y) / std::f64::consts::TAU, 0.5 + 0.5 * p.z);
    }
    for p in &sphere.positions {
        text += &format!("vn {} {} {}\n", p.x, p.y, p.z);
    }
    text += "g skin\nusemtl rubber\ns 1\n";
    for t in &sphere.triangles {
        let [a, b, c] = t.map(|v| v + 1);
        text += &format!("f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}\n");
    }
    std::fs::write(path, text).unwrap();
    std::fs::write(path.with_file_name("ball.mtl"), "newmtl rubber\nKd 0.8 0.2 0.2\n").unwrap();
}

fn lines_without_positions(path: &Path) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with("v ") && !l.starts_with("vn "))
        .map(str::to_string)
        .collect()
}

#[test]
fn deform_keeps_uvs_materials_and_groups_and_draws_a_preview() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("ball.obj"), dir.path().join("ground.obj"));
    textured_ball(&a, DVec3::new(0.0, 0.0, 0.8));
    let mut ground = shapes::cuboid(DVec3::new(4.0, 4.0, 0.5), 10);
    ground.map_positions(|p| p - DVec3::new(0.0, 0.0, 0.25));
    squish_io::write_mesh(&b, &ground).unwrap();
    let out = dir.path().join("out");
    let stdout = ok(&squish()
        .arg("deform")
        .arg(&a)
        .arg(&b)
        .arg("-o")
        .arg(&out)
        .args(["--set", "b.rigid=true", "--preview", "--size", "320x200"])
        .output()
        .unwrap());
    assert!(stdout.contains("preview.png"), "{stdout}");
    let written = out.join("ball.obj");
    assert_eq!(lines_without_positions(&written), lines_without_positions(&a));
    // The material library comes along.
    assert_eq!(std::fs::read(out.join("ball.mtl")).unwrap(), std::fs::read(dir.path().join("ball.mtl")).unwrap());
    let (before, after) = (squish_io::read_mesh(&a).unwrap(), squish_io::read_mesh(&written).unwrap());
    assert_eq!(before.triangles, after.triangles);
    assert!(before.positions.iter().zip(&after.positions).any(|(p, q)| (*p - *q).length() > 1e-3), "the ball deformed");
    let picture = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(out.join("preview.png")).unwrap()));
    let info = picture.read_info().unwrap();
    // Four 320 × 200 pictures in a 2 × 2 grid with 4-pixel gaps.
    assert_eq!((info.info().width, info.info().height), (644, 404));
}

#[test]
fn contact_draws_a_preview() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("ball.obj"), dir.path().join("other.ply"));
    textured_ball(&a, DVec3::new(0.0, 0.0, 1.6));
    squish_io::write_mesh(&b, &shapes::icosphere(1.0, 3)).unwrap();
    let out = dir.path().join("out");
    ok(&squish().arg("contact").arg(&a).arg(&b).arg("-o").arg(&out).arg("--preview").output().unwrap());
    assert!(out.join("preview.png").is_file());
}

/// A 12-frame shot of a textured ball pressed into a slab, in `format`.
fn run_press(dir: &Path, format: &str, extra: &[&str]) -> PathBuf {
    if !dir.join("ball.obj").exists() {
        textured_ball(&dir.join("ball.obj"), DVec3::ZERO);
        let mut ground = shapes::cuboid(DVec3::new(4.0, 4.0, 0.5), 8);
        ground.map_positions(|p| p - DVec3::new(0.0, 0.0, 0.25));
        squish_io::write_mesh(&dir.join("ground.ply"), &ground).unwrap();
        std::fs::write(
            dir.join("scene.toml"),
            r#"frames = { start = 1, end = 12, fps = 24 }
output = { dir = "out", format = "obj" }
preview = { size = [200, 150], up = "z" }

[[objects]]
name = "ball"
mesh = "ball.obj"
transform = { translate = [[1, [0, 0, 1.1]], [12, [0, 0, 0.8]]] }

[[objects]]
name = "ground"
mesh = "ground.ply"
rigid = true

[[pairs]]
objects = ["ball", "ground"]
"#,
        )
        .unwrap();
    }
    let out = dir.join(format!("out_{format}"));
    ok(&squish()
        .arg("run")
        .arg(dir.join("scene.toml"))
        .arg("-o")
        .arg(&out)
        .args(["--format", format])
        .args(extra)
        .output()
        .unwrap());
    out
}

#[test]
fn point_caches_hold_the_per_frame_files() {
    let dir = tempfile::tempdir().unwrap();
    let per_frame = run_press(dir.path(), "obj", &["--preview=12"]);
    let cache = run_press(dir.path(), "pc2", &[]);
    // The per-frame OBJs are copies of the source with UVs and materials.
    assert_eq!(
        lines_without_positions(&per_frame.join("ball/0012.obj")),
        lines_without_positions(&dir.path().join("ball.obj"))
    );
    // The scene's preview size applies.
    let picture =
        png::Decoder::new(std::io::BufReader::new(std::fs::File::open(per_frame.join("preview/0012.png")).unwrap()));
    assert_eq!(picture.read_info().unwrap().info().width, 200);
    for object in ["ball", "ground"] {
        let pc2 = squish_io::read_pc2(&cache.join(format!("{object}.pc2"))).unwrap();
        assert_eq!((pc2.start_frame, pc2.sample_rate, pc2.samples.len()), (1.0, 1.0, 12));
        let bytes = std::fs::read(cache.join(format!("{object}.pc2"))).unwrap();
        assert_eq!(&bytes[..12], b"POINTCACHE2\0");
        for (k, sample) in pc2.samples.iter().enumerate() {
            let file = per_frame.join(object).join(format!("{:04}.obj", k + 1));
            let mesh = squish_io::read_mesh(&file).unwrap();
            assert_eq!(sample.len(), mesh.num_vertices());
            for (p, q) in sample.iter().zip(&mesh.positions) {
                assert_eq!(p.to_array(), q.as_vec3().as_dvec3().to_array(), "{object} frame {}", k + 1);
            }
        }
    }
}

#[test]
fn run_refuses_meshes_given_as_scenes() {
    let dir = tempfile::tempdir().unwrap();
    let glb = common::square_fixture(common::U32, 4).write_glb(dir.path(), "character");
    let err = bad_input(&squish().arg("run").arg(&glb).output().unwrap());
    assert!(err.contains("is a glTF file, not a scene file") && err.contains("squish deform"), "{err}");
    assert!(!err.contains("UTF-8"), "{err}");
}

#[test]
fn bad_texture_indices_are_input_errors() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nf 1/1 2/1 3/9\nf 1/1 3/1 4/1\n").unwrap();
    let ok_mesh = dir.path().join("ok.ply");
    squish_io::write_mesh(&ok_mesh, &shapes::icosphere(1.0, 1)).unwrap();
    let err = bad_input(
        &squish().arg("deform").arg(&bad).arg(&ok_mesh).arg("-o").arg(dir.path().join("o")).output().unwrap(),
    );
    assert!(err.contains("bad.obj:6:") && err.contains("texture coordinate 9"), "{err}");
}

#[test]
fn info_welds_gltf_seams_and_counts_attributes() {
    let dir = tempfile::tempdir().unwrap();
    // The square's two triangles, one vertex duplicated along a seam.
    let mut f = common::Fixture::new();
    let pos =
        f.accessor(common::F32, "VEC3", &[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 0., 0., 1., 1., 0., 0., 1., 0.]);
    let uv = f.accessor(common::F32, "VEC2", &[0.; 12]);
    f.root = serde_json::json!({
        "scenes": [{ "nodes": [0] }], "nodes": [{ "mesh": 0 }], "materials": [{ "name": "m" }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": pos, "TEXCOORD_0": uv }, "material": 0 }] }],
    });
    let path = f.write_glb(dir.path(), "seam");
    let json: serde_json::Value =
        serde_json::from_str(&ok(&squish().arg("info").arg(&path).arg("--json").output().unwrap())).unwrap();
    assert_eq!(
        (json["welded"].as_bool(), json["file_vertices"].as_u64(), json["vertices"].as_u64()),
        (Some(true), Some(6), Some(4))
    );
    assert_eq!((json["attributes"]["uv_sets"].as_u64(), json["attributes"]["materials"].as_u64()), (Some(1), Some(1)));
    let text = ok(&squish().arg("info").arg(&path).output().unwrap());
    assert!(text.contains("welded") && text.contains("6 file vertices → 4"), "{text}");
    let json: serde_json::Value =
        serde_json::from_str(&ok(&squish().args(["info", "--weld", "never", "--json"]).arg(&path).output().unwrap()))
            .unwrap();
    assert_eq!(json["vertices"].as_u64(), Some(6));
}

#[test]
fn cesium_man_plays_back_with_its_rig_and_the_deformation() {
    let Some(_) = common::shared_data("rigged/CesiumMan.glb") else { return };
    let scene = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/cesium_man.toml"));
    let dir = tempfile::tempdir().unwrap();
    ok(&squish()
        .arg("run")
        .arg(scene)
        .arg("-o")
        .arg(dir.path())
        .args(["--format", "glb", "--frames", "1:4"])
        .output()
        .unwrap());
    let output = dir.path().join("cesium_man.1-4.glb");
    // The gltf crate validates it; our reader finds the rig, the material and the four targets.
    gltf::Gltf::from_slice(&std::fs::read(&output).unwrap()).unwrap();
    let doc = squish_io::GltfDocument::read(&output).unwrap();
    let counts = doc.attribute_counts();
    assert_eq!((counts.skins, counts.materials, counts.uv_sets, counts.morph_targets), (1, 1, 1, 4));
}
