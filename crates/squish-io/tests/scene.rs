//! Scene files: located errors for mistakes in the file, sequences (missing frames, changing
//! topology), transforms, per-vertex data, glTF sources posed per frame, parallel evaluation,
//! JSON dumps and timings.

#![allow(clippy::unwrap_used)]

mod common;

use std::path::{Path, PathBuf};

use glam::DVec3;
use squish::TriMesh;
use squish::mesh::shapes;
use squish::params::Params;
use squish_io::scene::*;
use squish_io::{GltfReadOptions, IoError, WeldMode, read_gltf, write_obj};

/// A temporary folder with a scene file and meshes.
struct Shot {
    dir: tempfile::TempDir,
}

impl Shot {
    fn new() -> Self {
        Self { dir: tempfile::tempdir().unwrap() }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    fn mesh(&self, name: &str, mesh: &TriMesh) -> &Self {
        write_obj(&self.path(name), mesh).unwrap();
        self
    }

    fn file(&self, name: &str, text: &str) -> &Self {
        std::fs::write(self.path(name), text).unwrap();
        self
    }

    fn load(&self, toml: &str) -> Result<Scene, IoError> {
        self.file("scene.toml", toml);
        Scene::load(&self.path("scene.toml"))
    }

    fn error(&self, toml: &str) -> String {
        match self.load(toml) {
            Ok(_) => panic!("the scene loaded, but an error was expected:\n{toml}"),
            Err(e) => {
                eprintln!("{e}");
                e.to_string()
            }
        }
    }
}

fn ball() -> TriMesh {
    shapes::icosphere(1.0, 1)
}

fn ground() -> TriMesh {
    shapes::grid(4.0, 4.0, 4, 4)
}

const HEADER: &str = r#"frames = { start = 1, end = 48 }

[[objects]]
name = "ball"
mesh = "ball.obj"

[[objects]]
name = "ground"
mesh = "ground.obj"
rigid = true
"#;

fn basic_shot() -> Shot {
    let shot = Shot::new();
    shot.mesh("ball.obj", &ball()).mesh("ground.obj", &ground());
    shot
}

/// Line number (1-based) of the first line of `text` containing `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap() + 1
}

// ---------------------------------------------------------------------------------------------
// Errors in the scene file

#[test]
fn misspelled_key_names_the_key_line_and_fix() {
    let shot = basic_shot();
    let toml = format!("{HEADER}stifness = 2.0\n");
    let err = shot.error(&toml);
    let line = line_of(&toml, "stifness");
    assert!(
        err.contains(&format!("scene.toml:{line}: [[objects]] \"ground\" stifness: unknown object parameter")),
        "{err}"
    );
    assert!(err.contains("did you mean \"stiffness\"?"), "{err}");

    // In an inline table, the column points at the key.
    let toml = format!("{HEADER}transform = {{ translat = [0, 0, 1] }}\n");
    let err = shot.error(&toml);
    let line = line_of(&toml, "translat");
    assert!(err.contains(&format!("scene.toml:{line}: column 15: unknown key \"translat\"")), "{err}");
    assert!(err.contains("transform"), "{err}");
    assert!(err.contains("did you mean \"translate\"?"), "{err}");

    // A key nothing resembles lists the valid ones.
    let err = shot.error(&format!("{HEADER}colour = 1\n"));
    assert!(err.contains("colour: unknown key; the table's keys are name, mesh"), "{err}");
    assert!(err.contains("and the object parameters rigid, stiffness"), "{err}");
    // A key close to one of the table's own keys says so.
    let err = shot.error(&format!("{HEADER}transfrom = {{ scale = 2 }}\n"));
    assert!(err.contains("did you mean \"transform\"?"), "{err}");
    // A former spelling names the key that replaced it.
    let err = shot.error(&format!("{HEADER}anisotropic_bulge = true\n"));
    assert!(err.contains("anisotropic_bulge: this key was renamed (did you mean \"anisotropy\"?)"), "{err}");

    // At the top level and in [[pairs]].
    let err = shot.error(&format!("frame = {{ start = 1, end = 2 }}\n{HEADER}"));
    assert!(err.contains("scene.toml:1: unknown key \"frame\"") && err.contains("did you mean \"frames\"?"), "{err}");
    let toml = format!("{HEADER}\n[[pairs]]\nobjects = [\"ball\", \"ground\"]\ncontact_tua = 0.5\n");
    let err = shot.error(&toml);
    let line = line_of(&toml, "contact_tua");
    assert!(err.contains(&format!("scene.toml:{line}: [[pairs]] #1 contact_tua: unknown pair parameter")), "{err}");
    assert!(err.contains("did you mean \"contact_tau\"?"), "{err}");
}

#[test]
fn wrong_values_name_the_key_and_line() {
    let shot = basic_shot();
    let toml = format!("{HEADER}stiffness = -1.0\n");
    let err = shot.error(&toml);
    let line = line_of(&toml, "stiffness = -1");
    assert!(
        err.contains(&format!("scene.toml:{line}: [[objects]] \"ground\" stiffness: -1: must be > 0 (k, default 1)")),
        "{err}"
    );

    let toml = format!("{HEADER}stiffness = [[1, 1.0], [10, 0.0]]\n");
    let err = shot.error(&toml);
    assert!(err.contains("0: must be > 0 (k, default 1) at the key on frame 10"), "{err}");

    let toml = format!("{HEADER}profile_v2 = 0.5\nprofile_v3 = 0.4\n");
    let err = shot.error(&toml);
    assert!(err.contains(&format!(":{}: ", line_of(&toml, "profile_v2"))), "{err}");
    assert!(err.contains("must increase strictly within (0.2, 1)"), "{err}");
    // Crossing keyed abscissas are caught at the frame where they cross.
    let err = shot.error(&format!("{HEADER}profile_v2 = [[1, 0.3], [48, 0.95]]\n"));
    assert!(err.contains("profile_v2") && err.contains("at frame"), "{err}");
    // The former spelling gets the keys that replaced it.
    let err = shot.error(&format!("{HEADER}profile = [0.5, 0.4, 0.9]\n"));
    assert!(err.contains("profile_v2, profile_v3 and profile_v4"), "{err}");

    let toml = format!("{HEADER}stiffness = \"soft\"\n");
    let err = shot.error(&toml);
    assert!(err.contains(&format!(":{}: [[objects]] \"ground\" stiffness:", line_of(&toml, "soft"))), "{err}");
    assert!(err.contains("expected a number > 0"), "{err}");

    let err = shot.error(&format!("{HEADER}stiffness = [[10, 1.0], [5, 2.0]]\n"));
    assert!(err.contains("increasing frame order"), "{err}");
    let err = shot.error(&format!("{HEADER}bulge = nan\n"));
    assert!(err.contains("bulge: NaN: must be ≥ 0"), "{err}");
    let err = shot.error(&format!("{HEADER}contact = 1\n"));
    assert!(err.contains("contact: unknown key; the table's keys are"), "{err}");
    let err = shot.error(&format!("{HEADER}region = \"hole\"\n"));
    assert!(err.contains("region: \"hole\"") && err.contains("did you mean \"whole\"?"), "{err}");
    let err = shot.error(&format!("{HEADER}region = {{ distance = 0.5 }}\n"));
    assert!(err.contains("write region = \"distance\" and region_distance"), "{err}");
    let err = shot.error(&format!("{HEADER}preserve_volume = [[1, true], [4, false]]\n"));
    assert!(err.contains("preserve_volume cannot be keyframed"), "{err}");
    let err = shot.error(&format!("{HEADER}transform = {{ scale = [[1, 1.0], [10, -1.0]] }}\n"));
    assert!(err.contains("scale on axis x goes from 1 at frame 1 to -1 at frame 10, passing through 0"), "{err}");
}

#[test]
fn frames_and_output_are_checked() {
    let shot = basic_shot();
    let toml = HEADER.replace("end = 48", "end = 0");
    let err = shot.error(&toml);
    assert!(err.contains("scene.toml:1:") && err.contains("end 0 is before start 1"), "{err}");

    let toml = format!("output = {{ dir = \"out\", format = \"fbx\" }}\n{HEADER}");
    let err = shot.error(&toml);
    assert!(err.contains("scene.toml:1:"), "{err}");
    assert!(err.contains("output: format = \"fbx\": expected \"obj\", \"ply\", \"glb\", \"gltf\" or \"pc2\""), "{err}");
    let err = shot.error(&format!("output = {{ format = \"plY\" }}\n{HEADER}"));
    assert!(err.contains("did you mean \"ply\"?"), "{err}");

    let err = shot.error("frames = { start = 1 }\n");
    assert!(err.contains("missing key \"end\""), "{err}");
    let err = shot.error("frames = { start = 1, end = 3 }\n");
    assert!(err.contains("no [[objects]]"), "{err}");
    let err = shot.error("frames = { start = 1, end = 3 \n");
    assert!(err.contains("scene.toml:1:") && err.contains("invalid TOML"), "{err}");
}

/// Issue 28: ranges at the ends of i64 panicked ("capacity overflow", an overflow in
/// `end − start`) or called 0..i64::MAX "-9223372036854775808 frames".
#[test]
fn extreme_frame_ranges_are_errors_not_panics() {
    let shot = basic_shot();
    let range =
        |start: &str, end: &str| HEADER.replace("start = 1, end = 48", &format!("start = {start}, end = {end}"));
    let err = shot.error(&range("-9223372036854775808", "9223372036854775807"));
    assert!(err.contains("[frames] end: 9223372036854775807 is beyond ±9007199254740992"), "{err}");
    let err = shot.error(&range("-9223372036854775808", "1"));
    assert!(err.contains("[frames] start: -9223372036854775808 is beyond ±9007199254740992"), "{err}");
    let err = shot.error(&range("-5000000000000000000", "5000000000000000000"));
    assert!(err.contains("is beyond ±9007199254740992"), "{err}");
    let err = shot.error(&range("0", "9000000000000000"));
    assert!(err.contains("9000000000000001 frames is more than the 1000000"), "{err}");
    let err = shot.error(&range("0", "9223372036854775807"));
    assert!(err.contains("9223372036854775807 is beyond") && !err.contains("-9223372036854775808 frames"), "{err}");
    // The largest accepted numbers load, and their length is right.
    let scene = shot.load(&range("9007199254740990", "9007199254740992")).unwrap();
    assert_eq!(scene.frame_range().len(), 3);
    assert_eq!(scene.frames().count(), 3);
}

/// Issue 28: `mesh = "."` said the folder does not exist.
#[test]
fn a_folder_given_as_mesh_is_named_as_such() {
    let shot = basic_shot();
    let err = shot.error(&HEADER.replace("mesh = \"ball.obj\"", "mesh = \".\""));
    assert!(err.contains("is a folder, not a mesh file") && !err.contains("does not exist"), "{err}");
}

#[test]
fn object_names_and_pairs_are_checked() {
    let shot = basic_shot();
    let toml = format!("{HEADER}\n[[objects]]\nname = \"ball\"\nmesh = \"ball.obj\"\n");
    let err = shot.error(&toml);
    let line = toml.lines().enumerate().filter(|(_, l)| l.contains("name = \"ball\"")).nth(1).unwrap().0 + 1;
    assert!(err.contains(&format!("scene.toml:{line}: [[objects]] \"ball\" name:")), "{err}");
    assert!(err.contains("\"ball\" is already used by object #1"), "{err}");

    let err = shot.error(&HEADER.replace("name = \"ball\"", "name = \"a/b\""));
    assert!(err.contains("contains '/'"), "{err}");

    let pair = |objects: &str, extra: &str| format!("{HEADER}\n[[pairs]]\nobjects = {objects}\n{extra}");
    let toml = pair("[\"bal\", \"ground\"]", "");
    let err = shot.error(&toml);
    assert!(err.contains(&format!("scene.toml:{}: [[pairs]] #1 objects:", line_of(&toml, "bal\""))), "{err}");
    assert!(err.contains("no object is named \"bal\" (did you mean \"ball\"?)"), "{err}");
    let err = shot.error(&pair("[\"ball\", \"moon\"]", ""));
    assert!(err.contains("no object is named \"moon\" (the objects are \"ball\", \"ground\")"), "{err}");
    let err = shot.error(&pair("[\"ball\", \"ball\"]", ""));
    assert!(err.contains("names the same object twice"), "{err}");
    let err = shot.error(&pair("[\"ball\", \"ground\"]", "\n[[pairs]]\nobjects = [\"ground\", \"ball\"]\n"));
    assert!(err.contains("already listed as pair #1"), "{err}");
    let err =
        shot.error(&pair("[\"ball\", \"ground\"]", "").replace("name = \"ball\"", "name = \"ball\"\nrigid = true"));
    assert!(err.contains("both \"ball\" and \"ground\" are rigid"), "{err}");
    let err = shot.error(&pair("[\"ball\", \"ground\"]", "contact_method = \"bal\"\n"));
    assert!(err.contains("did you mean \"ball\"?"), "{err}");
    let err = shot.error(&pair("[\"ball\", \"ground\"]", "contact_method = \"ball\"\nball_radius = 0.0\n"));
    assert!(err.contains("ball_radius: 0: must be > 0"), "{err}");
    let err = shot.error(&pair("[\"ball\", \"ground\"]", "contact_method = \"ball\"\n"));
    assert!(err.contains("needs ball_radius"), "{err}");
    let err = shot.error(&pair("[\"ball\", \"ground\"]", "contact_method = { ball = 0.3 }\n"));
    assert!(err.contains("write contact_method = \"ball\" and ball_radius"), "{err}");
    let err = shot.error(&pair("[\"ball\", \"ground\"]", "direction = [0, 0, 0]\n"));
    assert!(err.contains("direction") && err.contains("non-zero"), "{err}");
    let err = shot.error(&pair("[\"ball\", \"ground\"]", "direction = \"up\"\n"));
    assert!(err.contains("direction: \"up\"") && err.contains("\"auto\""), "{err}");
}

#[test]
fn missing_mesh_file_is_located() {
    let shot = Shot::new();
    shot.mesh("ground.obj", &ground());
    let err = shot.error(HEADER);
    assert!(err.contains(&format!("scene.toml:{}: [[objects]] \"ball\" mesh:", line_of(HEADER, "ball.obj"))), "{err}");
    assert!(err.contains("ball.obj does not exist"), "{err}");
}

// ---------------------------------------------------------------------------------------------
// Evaluation

#[test]
fn constant_scene_evaluates_parameters_and_pairs() {
    let shot = basic_shot();
    let toml = format!(
        "{HEADER}\n[[pairs]]\nobjects = [\"ball\", \"ground\"]\ncontact_tau = [[1, 0.0], [48, 0.94]]\ndirection = [[1, [0, 0, 2]], [48, [2, 0, 0]]]\ncontact_method = \"ball\"\nball_radius = 0.3\nenabled = [[1, true], [10, false]]\n"
    );
    let scene = shot.load(&toml).unwrap();
    assert_eq!(scene.frames().count(), 48);
    let f = scene.evaluate(24.5).unwrap();
    assert_eq!(f.objects.len(), 2);
    let b = &f.objects[0];
    assert_eq!(b.mesh, ball());
    assert_eq!(b.params, squish::ObjectParams::default(), "unset keys take the schema's defaults");
    assert!(f.objects[1].params.rigid);
    let p = &f.pairs[0];
    assert_eq!(p.objects, [0, 1]);
    assert!((p.params.contact_tau - 0.47).abs() < 1e-12);
    let d = p.params.direction.unwrap();
    assert!((d - DVec3::new(1.0, 0.0, 1.0)).length() < 1e-12, "{d}");
    assert_eq!(p.params.ball(), Some(0.3));
    assert!(!p.params.enabled);
    assert!(scene.evaluate(5.0).unwrap().pairs[0].params.enabled);
}

#[test]
fn transform_keys_move_the_mesh() {
    let shot = basic_shot();
    let toml = HEADER.replace(
        "mesh = \"ball.obj\"",
        "mesh = \"ball.obj\"\ntransform = { translate = [[1, [0, 0, 1]], [25, [0, 0, 0.5]]], rotate = [0, 0, 1, 90], scale = [[1, 1.0], [25, [2, 1, 1]]] }",
    );
    let scene = shot.load(&toml).unwrap();
    let rest = ball();
    let check = |frame: f64, scale: DVec3, translate: DVec3| {
        let mesh = scene.evaluate(frame).unwrap().objects.remove(0).mesh;
        assert_eq!(mesh.triangles, rest.triangles);
        for (p, q) in rest.positions.iter().zip(&mesh.positions) {
            let s = *p * scale;
            // 90° about z maps x to y and y to −x; applied after the scale, before the translation.
            let expected = DVec3::new(-s.y, s.x, s.z) + translate;
            assert!((expected - *q).length() < 1e-12, "frame {frame}: {q} != {expected}");
        }
    };
    check(1.0, DVec3::ONE, DVec3::Z);
    check(13.0, DVec3::new(1.5, 1.0, 1.0), DVec3::new(0.0, 0.0, 0.75));
    check(25.0, DVec3::new(2.0, 1.0, 1.0), DVec3::new(0.0, 0.0, 0.5));
    check(48.0, DVec3::new(2.0, 1.0, 1.0), DVec3::new(0.0, 0.0, 0.5));
}

#[test]
fn sequences_missing_frames_and_changing_topology() {
    let shot = Shot::new();
    shot.mesh("ground.obj", &ground());
    for f in 1..=8 {
        if f == 5 {
            continue;
        }
        let mut m = ball();
        m.map_positions(|p| p + DVec3::new(0.0, 0.0, f as f64));
        shot.mesh(&format!("ball_{f:04}.obj"), &m);
    }
    let toml = HEADER.replace("end = 48", "end = 8").replace("\"ball.obj\"", "\"ball_{frame:04}.obj\"");
    let scene = shot.load(&toml).unwrap();
    let z = |frame: f64| {
        let mesh = scene.evaluate(frame).unwrap().objects.remove(0).mesh;
        (mesh.positions[0] - ball().positions[0]).z
    };
    assert_eq!(z(3.0), 3.0);
    assert!((z(3.25) - 3.25).abs() < 1e-12, "sub-frames interpolate between files");
    let err = scene.evaluate(5.0).unwrap_err();
    let expected = shot.path("ball_0005.obj");
    assert_eq!(err.path(), expected);
    let text = err.to_string();
    assert!(text.contains("frame 5") && text.contains(&expected.display().to_string()), "{text}");
    assert_eq!(scene.missing_files(1..=8), vec![("ball".to_string(), 5, expected)]);

    // A frame with a different topology.
    shot.mesh("ball_0007.obj", &shapes::icosphere(1.0, 2));
    let err = scene.evaluate(7.0).unwrap_err().to_string();
    assert!(err.contains("ball_0007.obj") && err.contains("frame 7 of object \"ball\" has 162 vertices"), "{err}");
    assert!(err.contains("but frame 1"), "{err}");
    // Same counts, different triangles.
    let mut flipped = ball();
    flipped.triangles[0].swap(1, 2);
    shot.mesh("ball_0007.obj", &flipped);
    let err = scene.evaluate(7.0).unwrap_err().to_string();
    assert!(err.contains("different triangles"), "{err}");

    // A bad placeholder is located in the scene file.
    let err = shot.error(&toml.replace("{frame:04}", "{frame:4}"));
    assert!(err.contains(&format!(":{}: [[objects]] \"ball\" mesh:", line_of(&toml, "ball_"))), "{err}");
}

#[test]
fn bulge_maps_and_masks_are_checked_against_vertex_count() {
    let shot = basic_shot();
    let n = ball().num_vertices();
    let values: String = (0..n).map(|i| format!("{}\n", i as f64 / n as f64)).collect();
    shot.file("bulge.txt", &format!("# painted in Blender\n{values}"));
    shot.file("short.txt", "1\n2\n3\n");
    shot.file("bad.txt", "1\nx\n");
    let with = |key: &str| HEADER.replace("mesh = \"ball.obj\"", &format!("mesh = \"ball.obj\"\n{key}"));
    let scene = shot.load(&with("bulge_map = \"bulge.txt\"\nregion = \"mask\"\nregion_mask = \"bulge.txt\"")).unwrap();
    let f = scene.evaluate(1.0).unwrap();
    let map = f.objects[0].params.bulge_map.as_ref().unwrap();
    assert_eq!(map.len(), n);
    assert_eq!(map[1], 1.0 / n as f64);
    assert_eq!(f.objects[0].params.region, squish::params::RegionChoice::Mask);
    let mask = f.objects[0].params.region_mask.as_ref().unwrap();
    assert_eq!(mask.iter().filter(|&&m| m >= 0.5).count(), n - n.div_ceil(2));

    let err = shot.error(&with("bulge_map = \"short.txt\""));
    assert!(
        err.contains("short.txt") && err.contains(&format!("has 3 values, but object \"ball\" has {n} vertices")),
        "{err}"
    );
    let err = shot.error(&with("bulge_map = \"bad.txt\""));
    assert!(err.contains("bad.txt:2: \"x\" is not a finite number"), "{err}");
    let err = shot.error(&with("bulge_map = \"nothing.txt\""));
    assert!(err.contains("[[objects]] \"ball\" bulge_map:") && err.contains("nothing.txt does not exist"), "{err}");
    let err = shot.error(&with("region = \"mask\"\nregion_mask = { attribute = \"paint\" }"));
    assert!(err.contains("OBJ has no vertex attributes"), "{err}");
    shot.file("zeros.txt", &"0\n".repeat(n));
    let err = shot.error(&with("region = \"mask\"\nregion_mask = \"zeros.txt\""));
    assert!(err.contains("selects no vertex"), "{err}");
    let err = shot.error(&with("region = \"mask\""));
    assert!(err.contains("needs region_mask"), "{err}");
}

#[test]
fn ply_attribute_as_bulge_map() {
    let shot = basic_shot();
    let mesh = ball();
    let values: Vec<f64> = (0..mesh.num_vertices()).map(|i| i as f64).collect();
    squish_io::write_ply_with(
        &shot.path("ball.ply"),
        &mesh.positions,
        Some(&mesh.triangles),
        &[squish_io::VertexProperty::double("bulge", &values)],
        &squish_io::PlyWriteOptions::default(),
    )
    .unwrap();
    let toml = HEADER.replace("mesh = \"ball.obj\"", "mesh = \"ball.ply\"\nbulge_map = { attribute = \"bulge\" }");
    let scene = shot.load(&toml).unwrap();
    assert_eq!(scene.evaluate(1.0).unwrap().objects[0].params.bulge_map.as_deref(), Some(&values[..]));
    let err = shot.error(&toml.replace("\"bulge\" }", "\"bulgy\" }"));
    assert!(err.contains("no vertex property \"bulgy\"") && err.contains("\"bulge\""), "{err}");
}

// ---------------------------------------------------------------------------------------------
// glTF

fn gltf_scene(shot: &Shot, file: &Path, extra: &str) -> Scene {
    let toml = format!(
        "frames = {{ start = 1, end = 48, fps = 24 }}\n[[objects]]\nname = \"character\"\nmesh = {{ file = \"{}\"{extra} }}\n",
        file.display()
    );
    shot.load(&toml).unwrap()
}

#[test]
fn gltf_source_is_posed_per_frame() {
    let shot = Shot::new();
    for name in ["RiggedSimple", "CesiumMan"] {
        let Some(file) = common::shared_data(&format!("rigged/{name}.glb")) else { return };
        let scene = gltf_scene(&shot, &file, "");
        let a = scene.evaluate(1.0).unwrap().objects.remove(0).mesh;
        let b = scene.evaluate(13.0).unwrap().objects.remove(0).mesh;
        assert_eq!(a.num_vertices(), b.num_vertices(), "{name}");
        assert_eq!(a.triangles, b.triangles, "{name}");
        let moved = a.positions.iter().zip(&b.positions).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
        assert!(moved > 1e-3, "{name}: frames 1 and 13 have the same pose (max move {moved})");
        // Equal to posing the file directly at time (frame − start) / fps, welded (the default).
        let gltf = read_gltf(&file, &GltfReadOptions { weld: WeldMode::Exact }).unwrap();
        let node = gltf.instances()[0].node;
        let direct = gltf.posed_mesh(node, Some(0), 12.0 / 24.0).unwrap();
        assert_eq!(b, direct, "{name}");
        assert_eq!(scene.vertex_count(0), Some(direct.num_vertices()));

        // Start frame, repeat and weld = false.
        let scene = gltf_scene(&shot, &file, ", start_frame = 11, repeat = true, weld = false");
        let unwelded = read_gltf(&file, &GltfReadOptions::default()).unwrap();
        let duration = unwelded.animations[0].duration();
        let frame = 11.0 + 24.0 * (duration + 0.25);
        let got = scene.evaluate(frame).unwrap().objects.remove(0).mesh;
        let time = (24.0 * (duration + 0.25)) / 24.0 % duration;
        assert!((time - 0.25).abs() < 1e-9);
        let expected = unwelded.posed_mesh(node, Some(0), (frame - 11.0) / 24.0 % duration).unwrap();
        assert_eq!(got, expected, "{name}");
    }
}

/// `amplitude` scales every joint's turn from its rest rotation: on the bending cylinder (its
/// elbow turns about z from 0 to 150° over 1 s, linearly), half the amplitude at 1 s is the pose of
/// 0.5 s, 0 is the rest pose; it is refused where it means nothing.
#[test]
fn gltf_amplitude_scales_the_joint_rotations() {
    let shot = Shot::new();
    common::bending_cylinder(21, 12, |x| {
        let w = ((x + 0.3) / 0.6).clamp(0.0, 1.0);
        ([0.0, 1.0], [1.0 - w, w])
    })
    .write_glb(shot.dir.path(), "arm");
    let file = shot.path("arm.glb");
    let pose =
        |extra: &str, frame: f64| gltf_scene(&shot, &file, extra).evaluate(frame).unwrap().objects.remove(0).mesh;
    let distance = |a: &TriMesh, b: &TriMesh| {
        a.positions.iter().zip(&b.positions).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max)
    };
    // Frame 1 is time 0, frame 25 time 1 s.
    let half = pose(", amplitude = 0.5", 25.0);
    assert!(distance(&half, &pose("", 13.0)) < 1e-9, "{}", distance(&half, &pose("", 13.0)));
    assert!(distance(&half, &pose("", 25.0)) > 0.1);
    assert!(distance(&pose(", amplitude = 0", 25.0), &pose("", 1.0)) < 1e-12);
    assert_eq!(pose(", amplitude = 1", 19.0), pose("", 19.0));
    let toml = |extra: &str| {
        format!(
            "frames = {{ start = 1, end = 4 }}\n[[objects]]\nname = \"arm\"\nmesh = {{ file = \"{}\"{extra} }}\n",
            file.display()
        )
    };
    let err = shot.load(&toml(", amplitude = -1")).unwrap_err().to_string();
    assert!(err.contains("amplitude -1 must be a finite number ≥ 0"), "{err}");
    shot.mesh("ball.obj", &shapes::uv_sphere(1.0, 8, 6));
    let err = shot.load(&toml(", amplitude = 2").replace("arm.glb", "ball.obj")).unwrap_err().to_string();
    assert!(err.contains("\"amplitude\" only applies to .glb / .gltf meshes"), "{err}");
}

#[test]
fn gltf_names_are_checked() {
    let shot = Shot::new();
    let Some(file) = common::shared_data("rigged/Fox.glb") else { return };
    let toml = |extra: &str| {
        format!(
            "frames = {{ start = 1, end = 4 }}\n[[objects]]\nname = \"fox\"\nmesh = {{ file = \"{}\"{extra} }}\n",
            file.display()
        )
    };
    let err = shot.load(&toml("")).unwrap_err().to_string();
    assert!(err.contains("3 animations (\"Survey\", \"Walk\", \"Run\")"), "{err}");
    let err = shot.load(&toml(", animation = \"Wlak\"")).unwrap_err().to_string();
    assert!(err.contains("no animation is named \"Wlak\" (did you mean \"Walk\"?)"), "{err}");
    let err = shot.load(&toml(", animation = \"Walk\", node = \"nope\"")).unwrap_err().to_string();
    assert!(err.contains("no node is named \"nope\""), "{err}");
    let scene = shot.load(&toml(", animation = \"Walk\"")).unwrap();
    assert!(scene.evaluate(2.0).is_ok());
    let err = shot.load(&toml(", animation = \"Walk\", repeat = 1")).unwrap_err().to_string();
    assert!(err.contains("repeat"), "{err}");
}

// ---------------------------------------------------------------------------------------------
// Threads, JSON, timing

#[test]
fn parallel_evaluation_equals_sequential() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<Scene>();
    let shot = basic_shot();
    let mut toml = HEADER.replace(
        "mesh = \"ball.obj\"",
        "mesh = \"ball.obj\"\nstiffness = { keys = [[1, 0.5], [20, 2.0], [48, 1.0]], interpolation = \"smooth\" }\ntransform = { translate = [[1, [0, 0, 2]], [48, [0, 0, 0.5]]], rotate = [[1, [0, 0, 1, 0]], [48, [0, 0, 1, 360]]] }",
    );
    let file = common::shared_data("rigged/CesiumMan.glb");
    if let Some(file) = &file {
        toml.push_str(&format!("\n[[objects]]\nname = \"man\"\nmesh = \"{}\"\n", file.display()));
    }
    let scene = shot.load(&toml).unwrap();
    let frames: Vec<i64> = scene.frames().collect();
    let sequential: Vec<squish::OwnedFrame> = frames.iter().map(|&f| scene.evaluate(f as f64).unwrap()).collect();
    // Four threads taking interleaved frames, as a pool would.
    let mut parallel: Vec<Option<squish::OwnedFrame>> = vec![None; frames.len()];
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..4)
            .map(|t| {
                let scene = &scene;
                let frames = &frames;
                s.spawn(move || {
                    frames
                        .iter()
                        .enumerate()
                        .skip(t)
                        .step_by(4)
                        .map(|(i, &f)| (i, scene.evaluate(f as f64).unwrap()))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for h in handles {
            for (i, spec) in h.join().unwrap() {
                parallel[i] = Some(spec);
            }
        }
    });
    let parallel: Vec<squish::OwnedFrame> = parallel.into_iter().map(Option::unwrap).collect();
    assert_eq!(parallel, sequential);
    assert_ne!(sequential[0].objects[0].mesh, sequential[30].objects[0].mesh);
}

#[test]
fn json_dump_holds_every_resolved_parameter() {
    let shot = basic_shot();
    let toml = format!(
        "{HEADER}extent = 0.4\nprofile_v3 = {{ keys = [[1, 0.8], [48, 0.85]], interpolation = \"smooth\" }}\nanisotropy = true\nanisotropy_exponent = 3.0\n\n[[pairs]]\nobjects = [\"ball\", \"ground\"]\n"
    );
    let scene = shot.load(&toml).unwrap();
    let json: serde_json::Value = serde_json::from_str(&scene.to_json().unwrap()).unwrap();
    let ball = &json["objects"][0];
    let ground = &json["objects"][1];
    assert_eq!(json["frames"], serde_json::json!({ "start": 1, "end": 48, "fps": 24.0 }));
    assert_eq!(json["output"]["format"], "obj");
    assert_eq!(json["output"]["dir"], shot.path("out").display().to_string());
    assert_eq!(ball["mesh"], serde_json::json!({ "file": shot.path("ball.obj"), "weld": false }));
    // Every key of the schema, defaults included.
    for key in ["name", "mesh", "transform"].into_iter().chain(squish::ObjectParams::schema().iter().map(|i| i.key)) {
        assert!(ball.get(key).is_some(), "{key} missing from {ball}");
    }
    assert_eq!(ball["stiffness"], 1.0);
    assert_eq!(ball["extent"], "auto");
    assert_eq!(ground["extent"], 0.4);
    assert_eq!(ball["preserve_volume"], "auto");
    assert_eq!(ball["region"], "whole");
    assert_eq!(ground["profile_v3"]["interpolation"], "smooth");
    assert_eq!(ground["profile_v2"], 1.0 / 3.0);
    assert_eq!(
        (&ground["anisotropy"], &ground["anisotropy_exponent"]),
        (&serde_json::json!(true), &serde_json::json!(3.0))
    );
    assert_eq!(ball["transform"]["scale"], serde_json::json!([1.0, 1.0, 1.0]));
    assert_eq!(ball["transform"]["rotate"], serde_json::json!([0.0, 0.0, 1.0, 0.0]));
    let pair = &json["pairs"][0];
    assert_eq!(pair["direction"], "auto");
    assert_eq!(pair["contact_method"], "geometric");
    assert_eq!(pair["contact_tau"], 0.0);
    assert_eq!(pair["enabled"], true);

    // The dump reads back and loads to the same frames.
    let back: SceneDescription = serde_json::from_value(json).unwrap();
    let again = Scene::from_parsed(back, &shot.path("scene.json")).unwrap();
    assert_eq!(again.evaluate(10.0).unwrap(), scene.evaluate(10.0).unwrap());

    // Frame specs serialize too (e.g. for `squish run --dry-run`).
    let spec = serde_json::to_value(scene.evaluate(1.0).unwrap()).unwrap();
    assert_eq!(spec["objects"][1]["params"]["extent"], 0.4);
    assert_eq!(spec["pairs"][0]["params"]["contact_method"], "geometric");
}

#[test]
fn evaluation_is_cheap() {
    let shot = Shot::new();
    let big = shapes::icosphere(1.0, 5); // 10242 vertices
    assert!(big.num_vertices() > 10_000);
    shot.mesh("big.obj", &big);
    let toml = "frames = { start = 1, end = 100 }\n[[objects]]\nname = \"big\"\nmesh = \"big.obj\"\nstiffness = [[1, 1.0], [100, 2.0]]\ntransform = { translate = [[1, [0, 0, 0]], [100, [1, 2, 3]]], rotate = [0, 1, 0, 30], scale = 1.5 }\n";
    let scene = shot.load(toml).unwrap();
    let start = std::time::Instant::now();
    for f in scene.frames() {
        std::hint::black_box(scene.evaluate(f as f64).unwrap());
    }
    let per_frame = start.elapsed().as_secs_f64() / 100.0;
    eprintln!("static 10k-vertex object: {:.3} ms per frame", per_frame * 1e3);
    assert!(per_frame < 0.02, "{per_frame} s per frame");

    let Some(file) = common::shared_data("rigged/CesiumMan.glb") else { return };
    let scene = gltf_scene(&shot, &file, "");
    let start = std::time::Instant::now();
    for f in 1..=48 {
        std::hint::black_box(scene.evaluate(f as f64).unwrap());
    }
    let per_frame = start.elapsed().as_secs_f64() / 48.0;
    eprintln!("CesiumMan (2338 vertices, 19 joints) posed: {:.3} ms per frame", per_frame * 1e3);
    assert!(per_frame < 0.02, "{per_frame} s per frame");
}

#[test]
fn documented_example_parses() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/scene-format.md")).unwrap();
    let example = doc.split("## Example").nth(1).unwrap();
    let toml = example.split("```toml").nth(1).unwrap().split("```").next().unwrap();
    let description = SceneDescription::parse(toml, Path::new("/shots/example/scene.toml")).unwrap();
    assert_eq!(description.objects.len(), 3);
    assert_eq!(description.pairs.len(), 2);
    assert_eq!(description.objects[0].mesh.file(), Path::new("/shots/example/ball.obj"));
    assert_eq!(description.output.dir, Path::new("/shots/example/out"));
    assert!(matches!(&description.objects[1].mesh, MeshSource::Gltf(g) if g.repeat && g.weld == Weld::Exact));
    assert_eq!(description.objects[1].params["anisotropy"], toml::Value::Boolean(true));
    // The keyframe spellings shown in the text parse too.
    for line in doc.lines().filter(|l| l.starts_with("stiffness = ")) {
        let object =
            format!("frames = {{ start = 1, end = 48 }}\n[[objects]]\nname = \"a\"\nmesh = \"a.obj\"\n{line}\n");
        SceneDescription::parse(&object, Path::new("scene.toml")).unwrap();
    }
}

#[test]
fn gltf_attribute_is_averaged_over_welded_vertices() {
    use common::{F32, Fixture, U16};
    let shot = Shot::new();
    // A square as two triangles that do not share vertices: corners 0/3 and 2/4 coincide.
    let mut f = Fixture::new();
    let pos = f.accessor(F32, "VEC3", &[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 0., 0., 1., 1., 0., 0., 1., 0.]);
    let bulge = f.accessor(F32, "SCALAR", &[1., 2., 3., 5., 7., 11.]);
    let idx = f.accessor(U16, "SCALAR", &[0., 1., 2., 3., 4., 5.]);
    f.root = serde_json::json!({
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "name": "square", "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": pos, "_BULGE": bulge }, "indices": idx }] }],
    });
    f.write_glb(shot.dir.path(), "square");
    let toml = |extra: &str| {
        format!(
            "frames = {{ start = 1, end = 2 }}\n[[objects]]\nname = \"square\"\nmesh = {{ file = \"square.glb\"{extra} }}\nbulge_map = {{ attribute = \"BULGE\" }}\n"
        )
    };
    let scene = shot.load(&toml("")).unwrap();
    let map = scene.evaluate(1.0).unwrap().objects[0].params.bulge_map.clone().unwrap();
    // Welded vertices in first-occurrence order: 0 (with 3), 1, 2 (with 4), 5.
    assert_eq!(&map[..], &[3.0, 2.0, 5.0, 11.0]);
    let scene = shot.load(&toml(", weld = false")).unwrap();
    let map = scene.evaluate(1.0).unwrap().objects[0].params.bulge_map.clone().unwrap();
    assert_eq!(&map[..], &[1.0, 2.0, 3.0, 5.0, 7.0, 11.0]);
    let err = shot.error(&toml("").replace("\"BULGE\"", "\"SQUASH\""));
    assert!(err.contains("no vertex attribute \"SQUASH\"") && err.contains("\"_BULGE\""), "{err}");
}

#[test]
fn descriptions_from_json_are_checked_too() {
    let shot = basic_shot();
    let scene = shot.load(HEADER).unwrap();
    let mut description = scene.description().clone();
    description.objects[0].params.insert("stiffness".into(), toml::Value::Float(0.0));
    let err = Scene::from_parsed(description, &shot.path("scene.json")).unwrap_err().to_string();
    assert!(err.contains("scene.json:1: [[objects]] #1 stiffness: 0: must be > 0"), "{err}");
}
