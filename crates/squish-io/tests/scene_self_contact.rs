//! `[[objects.self_contact]]` in scene files: parsing with and without the optional keys,
//! located errors (unknown keys, joint names, joints that are not consecutive, meshes without a
//! skin), and per-frame evaluation (regions from the skin weights, joint positions following the
//! animation and the object's transform, keyframed directions and parameters). The skinned mesh
//! is a procedural glTF cylinder written by the test.

#![allow(clippy::unwrap_used)]

mod common;

use std::path::PathBuf;

use common::*;
use glam::DVec3;
use squish::ArticulationParams;
use squish::mesh::shapes;
use squish::params::Articulation;
use squish_io::scene::*;
use squish_io::{IoError, write_obj};

/// [`bending_cylinder`] with 21 rings of 12 vertices. Vertices with x < −0.2 follow the root,
/// −0.2 < x < 0.2 blend root and elbow linearly, then the elbow alone up to x = 0.6, and the elbow
/// and the tip blend up to x = 1.
pub fn skinned_cylinder() -> Fixture {
    bending_cylinder(21, 12, |x| {
        if x <= 0.6 {
            let w = ((x + 0.2) / 0.4).clamp(0.0, 1.0);
            ([0.0, 1.0], [1.0 - w, w])
        } else {
            let w = ((x - 0.6) / 0.4).clamp(0.0, 1.0);
            ([1.0, 2.0], [1.0 - w, w])
        }
    })
}

/// A folder with the cylinder (`arm.glb`) and a ball (`ball.obj`).
struct Shot {
    dir: tempfile::TempDir,
}

impl Shot {
    fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        skinned_cylinder().write_glb(dir.path(), "arm");
        write_obj(&dir.path().join("ball.obj"), &shapes::icosphere(1.0, 1)).unwrap();
        Self { dir }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// A scene of frames 1–25 (the bend at 24 fps) with the arm and `entries` after its table.
    fn scene(&self, object_keys: &str, entries: &str) -> PathBuf {
        let text = format!(
            "frames = {{ start = 1, end = 25, fps = 24 }}\n\n[[objects]]\nname = \"arm\"\nmesh = \"arm.glb\"\n{object_keys}\n{entries}"
        );
        let path = self.path("scene.toml");
        std::fs::write(&path, text).unwrap();
        path
    }

    fn load(&self, object_keys: &str, entries: &str) -> Result<Scene, IoError> {
        Scene::load(&self.scene(object_keys, entries))
    }

    fn error(&self, object_keys: &str, entries: &str) -> String {
        match self.load(object_keys, entries) {
            Ok(_) => panic!("the scene loaded, but an error was expected:\n{entries}"),
            Err(e) => {
                eprintln!("{e}");
                e.to_string()
            }
        }
    }
}

const ELBOW: &str = "[[objects.self_contact]]\nname = \"elbow\"\njoints = [\"root\", \"elbow\"]\n";

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-5
}

fn joints(articulation: &Articulation) -> [DVec3; 3] {
    assert_eq!(articulation.params.direction, None, "the direction comes from the joints");
    articulation.joints.expect("joint positions")
}

#[test]
fn a_minimal_entry_takes_the_defaults_and_the_regions_of_the_skin() {
    let shot = Shot::new();
    let scene = shot.load("", ELBOW).unwrap();
    let entry = &scene.description().objects[0].self_contact[0];
    assert_eq!(entry.name, "elbow");
    assert!(entry.params.is_empty(), "no parameter given");

    let frame = scene.evaluate(1.0).unwrap();
    let object = &frame.objects[0];
    let n = object.mesh.num_vertices();
    assert_eq!(n, 21 * 12 + 2);
    let rest = object.params.rest_positions.as_deref().unwrap();
    assert_eq!(rest.len(), n);
    assert!(close(rest[0], DVec3::new(-1.0, 0.25, 0.0)));
    let [a] = object.params.self_contact.as_slice() else { panic!("one articulation") };
    assert_eq!(a.params, ArticulationParams::default());
    let [w1, w2] = &a.regions;
    // Region 1: the root's influence ≥ 0.05 (x < 0.18); region 2: the elbow's (x > −0.18).
    let xs = |r: &[u32]| r.iter().map(|&v| rest[v as usize].x).collect::<Vec<_>>();
    assert!(xs(w1).iter().all(|&x| x < 0.19) && xs(w1).contains(&-1.0));
    assert!(xs(w2).iter().all(|&x| x > -0.19) && xs(w2).contains(&1.0));
    let shared = w1.iter().filter(|v| w2.contains(v)).count();
    assert_eq!(shared, 3 * 12, "the blend rings x = −0.1, 0, 0.1 are in both");
    // At rest the joints are in a line along x.
    let q = joints(a);
    assert!(close(q[0], DVec3::new(-1.0, 0.0, 0.0)) && close(q[1], DVec3::ZERO) && close(q[2], DVec3::X), "{q:?}");
    // The description (and so report.json's scene) writes the entry back.
    let json = scene.to_json().unwrap();
    assert!(json.contains("\"self_contact\"") && json.contains("\"joints\""), "{json}");
}

#[test]
fn every_optional_key_is_read_and_keyframed() {
    let shot = Shot::new();
    let entry = r#"[[objects.self_contact]]
name = "elbow"
joints = ["root", "elbow"]
min_weight = 0.5
direction = [[1, [0, 1, 0]], [25, [1, 0, 0]]]
contact_tau = [[1, -1.0], [25, 0.5]]
stiffness = [2.0, 0.5]
extent = 0.3
cut_regional_weight = { keys = [[1, 0.0], [25, 2.0]], interpolation = "step" }
safeguard_angle = 70
contact_gap = 0.001
"#;
    let scene = shot.load("", entry).unwrap();
    let at = |f: f64| scene.evaluate(f).unwrap().objects[0].params.self_contact[0].clone();
    let a = at(13.0);
    let d = a.params.direction.expect("a given direction");
    assert!(close(d, DVec3::new(0.5, 0.5, 0.0)), "keyed direction, interpolated: {d}");
    assert_eq!(a.joints, None, "no joint positions when the direction is given");
    assert!((a.params.contact_tau - (-0.25)).abs() < 1e-12);
    assert_eq!(a.params.stiffness, [2.0, 0.5]);
    assert_eq!(a.params.extent, Some(0.3));
    assert_eq!(a.params.cut_regional_weight, 0.0, "step holds the first key");
    assert_eq!(at(25.0).params.cut_regional_weight, 2.0);
    assert_eq!(a.params.safeguard_angle, 70.0);
    assert_eq!(a.params.min_weight, 0.5);
    assert_eq!(a.params.contact_gap, Some(0.001));
    // A larger min_weight gives smaller regions that no longer overlap much.
    let [w1, w2] = &a.regions;
    let default = shot.load("", ELBOW).unwrap();
    let d = default.evaluate(1.0).unwrap();
    let [d1, d2] = &d.objects[0].params.self_contact[0].regions;
    assert!(w1.len() < d1.len() && w2.len() < d2.len());
    // A single stiffness applies to both sides; a keyed one interpolates per side.
    let scene = shot.load("", &format!("{ELBOW}stiffness = [[1, [1, 3]], [25, 2]]\n")).unwrap();
    let k = scene.evaluate(13.0).unwrap().objects[0].params.self_contact[0].params.stiffness;
    assert_eq!(k, [1.5, 2.5]);
}

#[test]
fn the_joints_follow_the_animation_and_the_object_transform() {
    let shot = Shot::new();
    let scene = shot.load("transform = { translate = [0, 0, 2] }", ELBOW).unwrap();
    let frame = scene.evaluate(25.0).unwrap();
    let q = joints(&frame.objects[0].params.self_contact[0]);
    let bent = DVec3::new(150f64.to_radians().cos(), 150f64.to_radians().sin(), 0.0);
    let up = DVec3::new(0.0, 0.0, 2.0);
    assert!(close(q[0], DVec3::new(-1.0, 0.0, 0.0) + up) && close(q[1], up) && close(q[2], bent + up), "{q:?}");
    // The mesh went through the same transform: the tip's cap centre is at the child joint's end.
    let tip = frame.objects[0].mesh.positions[21 * 12 + 1];
    assert!(close(tip, q[2]), "{tip} vs {}", q[2]);
}

#[test]
fn a_leaf_joint_extends_its_parent_bone() {
    // "tip" has no child joint: the end of its bone continues the elbow's bone at rest and moves
    // with the tip (here rigidly with the elbow, which turns by 150° at frame 25).
    let shot = Shot::new();
    let scene = shot.load("", "[[objects.self_contact]]\nname = \"wrist\"\njoints = [\"elbow\", \"tip\"]\n").unwrap();
    let bent = DVec3::new(150f64.to_radians().cos(), 150f64.to_radians().sin(), 0.0);
    let q = joints(&scene.evaluate(25.0).unwrap().objects[0].params.self_contact[0]);
    assert!(close(q[0], DVec3::ZERO) && close(q[1], bent) && close(q[2], 2.0 * bent), "{q:?}");
    let q = joints(&scene.evaluate(1.0).unwrap().objects[0].params.self_contact[0]);
    assert!(close(q[2], DVec3::new(2.0, 0.0, 0.0)), "{q:?}");
}

#[test]
fn unknown_keys_are_errors_naming_the_key() {
    let shot = Shot::new();
    let e = shot.error("", &format!("{ELBOW}stifness = 2\n"));
    assert!(e.contains("stifness: unknown articulation parameter") && e.contains("did you mean \"stiffness\""), "{e}");
    assert!(e.contains("scene.toml:10") && e.contains("[[objects]] \"arm\" self_contact \"elbow\""), "located: {e}");
    let e = shot.error("", &format!("{ELBOW}direction = \"joint\"\n"));
    assert!(e.contains("direction: \"joint\"") && e.contains("\"joints\""), "{e}");
}

#[test]
fn a_bad_joint_name_lists_the_joints() {
    let shot = Shot::new();
    let e = shot.error("", "[[objects.self_contact]]\nname = \"elbow\"\njoints = [\"root\", \"elbo\"]\n");
    for part in [
        "\"arm\"",
        "articulation \"elbow\"",
        "no joint named \"elbo\"",
        "did you mean \"elbow\"",
        "\"root\", \"elbow\", \"tip\"",
    ] {
        assert!(e.contains(part), "{part} in {e}");
    }
    assert!(e.contains("scene.toml:"), "located: {e}");
}

#[test]
fn joints_must_be_consecutive() {
    let shot = Shot::new();
    let e = shot.error("", "[[objects.self_contact]]\nname = \"arm\"\njoints = [\"root\", \"tip\"]\n");
    assert!(e.contains("not consecutive") && e.contains("the parent of \"tip\" is \"elbow\""), "{e}");
    assert!(e.contains("the children of \"root\" are \"elbow\""), "{e}");
    let e = shot.error("", "[[objects.self_contact]]\nname = \"arm\"\njoints = [\"elbow\", \"root\"]\n");
    assert!(e.contains("\"root\" is a root of the skin"), "{e}");
}

#[test]
fn entries_are_checked_when_the_scene_is_read() {
    let shot = Shot::new();
    let cases: &[(&str, &str, &[&str])] = &[
        ("", &format!("{ELBOW}{ELBOW}"), &["already used", "unique"]),
        ("rigid = true", ELBOW, &["rigid", "never deforms"]),
        ("", "[[objects.self_contact]]\nname = \"elbow\"\n", &["joints", "masks"]),
        ("", &format!("{ELBOW}masks = [\"a.txt\", \"b.txt\"]\n"), &["both joints and masks"]),
        ("", &format!("{ELBOW}min_weight = 0\n"), &["min_weight", "(0, 1]"]),
        ("", &format!("{ELBOW}stiffness = [1, 0]\n"), &["stiffness", "must be > 0"]),
        ("", &format!("{ELBOW}safeguard_angle = 95\n"), &["safeguard_angle", "(0, 90]"]),
        ("", &format!("{ELBOW}extent = -1\n"), &["extent", "must be > 0"]),
        ("", &format!("{ELBOW}contact_gap = -1\n"), &["contact_gap", "≥ 0"]),
        ("", &format!("{ELBOW}cut_regional_weight = -1\n"), &["cut_regional_weight", "≥ 0"]),
        ("", &format!("{ELBOW}direction = [0, 0, 0]\n"), &["direction", "non-zero"]),
        ("", &format!("{ELBOW}direction = [[1, [1, 0, 0]], [25, [-1, 0, 0]]]\n"), &["direction", "frame 13"]),
        ("", &format!("{ELBOW}safeguard_angle_degrees = 70\n"), &["renamed (did you mean \"safeguard_angle\""]),
    ];
    for (object_keys, entries, parts) in cases {
        let e = shot.error(object_keys, entries);
        for part in *parts {
            assert!(e.contains(part), "{part} in {e}");
        }
        assert!(e.contains("scene.toml"), "{e}");
    }
}

/// A scene with the ball (an OBJ) as the object.
fn ball_scene(shot: &Shot, entries: &str) -> Result<Scene, IoError> {
    let text =
        format!("frames = {{ start = 1, end = 3 }}\n\n[[objects]]\nname = \"ball\"\nmesh = \"ball.obj\"\n{entries}");
    let path = shot.path("ball.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path)
}

#[test]
fn masks_give_the_regions_of_any_mesh() {
    let shot = Shot::new();
    let n = shapes::icosphere(1.0, 1).num_vertices();
    let ball = shapes::icosphere(1.0, 1);
    let mask = |side: f64| -> String {
        ball.positions.iter().map(|p| if p.z * side > -0.2 { "1\n" } else { "0\n" }).collect()
    };
    std::fs::write(shot.path("top.txt"), mask(1.0)).unwrap();
    std::fs::write(shot.path("bottom.txt"), mask(-1.0)).unwrap();
    let entry =
        "[[objects.self_contact]]\nname = \"lips\"\nmasks = [\"top.txt\", \"bottom.txt\"]\ndirection = [0, 0, -2]\n";
    let scene = ball_scene(&shot, entry).unwrap();
    let frame = scene.evaluate(2.0).unwrap();
    let object = &frame.objects[0];
    assert_eq!(object.params.rest_positions, None, "an OBJ's rest pose is the frame's mesh");
    let a = &object.params.self_contact[0];
    assert_eq!((a.params.direction, a.joints), (Some(DVec3::new(0.0, 0.0, -2.0)), None));
    let [w1, w2] = &a.regions;
    assert!(w1.iter().all(|&v| ball.positions[v as usize].z > -0.2));
    assert!(w2.iter().all(|&v| ball.positions[v as usize].z < 0.2));
    assert!(w1.len() < n && w2.len() < n);

    // Joints need a skinned glTF; masks need a direction; an empty mask is an error.
    let e = ball_scene(&shot, "[[objects.self_contact]]\nname = \"x\"\njoints = [\"a\", \"b\"]\n").err().unwrap();
    assert!(e.to_string().contains("skinned glTF"), "{e}");
    let e = ball_scene(&shot, "[[objects.self_contact]]\nname = \"x\"\nmasks = [\"top.txt\", \"bottom.txt\"]\n")
        .err()
        .unwrap();
    assert!(e.to_string().contains("direction = [x, y, z]"), "{e}");
    std::fs::write(shot.path("none.txt"), "0\n".repeat(n)).unwrap();
    let e = ball_scene(
        &shot,
        "[[objects.self_contact]]\nname = \"x\"\nmasks = [\"top.txt\", \"none.txt\"]\ndirection = [0, 0, 1]\n",
    )
    .err()
    .unwrap();
    assert!(e.to_string().contains("mask 2 selects no vertex"), "{e}");
    let e = ball_scene(
        &shot,
        "[[objects.self_contact]]\nname = \"x\"\nmasks = [\"top.txt\", \"missing.txt\"]\ndirection = [0, 0, 1]\n",
    )
    .err()
    .unwrap();
    assert!(e.to_string().contains("missing.txt") && e.to_string().contains("does not exist"), "{e}");
}

#[test]
fn objects_without_self_contact_are_unchanged() {
    let shot = Shot::new();
    let scene = shot.load("", "").unwrap();
    let frame = scene.evaluate(1.0).unwrap();
    assert!(frame.objects[0].params.self_contact.is_empty());
    assert_eq!(frame.objects[0].params.rest_positions, None);
    assert!(!scene.to_json().unwrap().contains("self_contact"));
}

#[test]
fn the_documented_example_parses() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/scene-format.md")).unwrap();
    let section = doc.split("### `[[objects.self_contact]]`").nth(1).unwrap();
    let toml = section.split("```toml").nth(1).unwrap().split("```").next().unwrap();
    let text = format!("frames = {{ start = 1, end = 24 }}\n{toml}");
    let description = SceneDescription::parse(&text, std::path::Path::new("/shots/scene.toml")).unwrap();
    let [man, head] = description.objects.as_slice() else { panic!("two objects") };
    assert_eq!(man.self_contact.len(), 2);
    let params = |entry: &SelfContactSpec| {
        ParamTracks::<ArticulationParams>::parse(&entry.params, SelfContactSpec::TABLE_KEYS, |_, _| Ok(None))
            .unwrap()
            .at(1.0)
            .unwrap()
    };
    let elbow = params(&man.self_contact[1]);
    assert_eq!((elbow.stiffness, elbow.min_weight), ([1.0, 2.0], 0.1));
    assert_eq!(params(&head.self_contact[0]).direction, Some(DVec3::new(0.0, -1.0, 0.0)));
}

#[test]
fn auto_gives_the_parts_and_articulations_of_the_skeleton() {
    let shot = Shot::new();
    let scene = shot.load("self_contact = \"auto\"", "").unwrap();
    assert!(scene.description().objects[0].self_contact.auto);
    let frame = scene.evaluate(25.0).unwrap();
    let params = &frame.objects[0].params;
    let parts = params.self_contact_parts.as_ref().expect("parts");
    assert_eq!(parts.face_parts.len(), frame.objects[0].mesh.num_triangles());
    assert!(parts.names.len() >= 2, "{:?}", parts.names);
    // Consecutive parts along the chain are parent and child: left to the articulations.
    assert!(!parts.parent_child.is_empty());
    assert!(params.self_contact.iter().all(|a| a.automatic && a.joints.is_some()));
    assert!(params.rest_positions.is_some());
    // Written back as it reads.
    let json = scene.to_json().unwrap();
    assert!(json.contains("\"self_contact\": \"auto\"") || json.contains("\"self_contact\":\"auto\""), "{json}");
}

#[test]
fn auto_errors_name_the_key_and_the_fix() {
    let shot = Shot::new();
    let e = shot.error("self_contact = \"automatic\"", "");
    assert!(e.contains("self_contact") && e.contains("\"auto\""), "{e}");
    let e = shot.error("self_contact = \"auto\"\nrigid = true", "");
    assert!(e.contains("rigid") && e.contains("self_contact"), "{e}");
    let path = shot.path("ball.toml");
    std::fs::write(
        &path,
        "frames = { start = 1, end = 2 }\n[[objects]]\nname = \"ball\"\nmesh = \"ball.obj\"\nself_contact = \"auto\"\n",
    )
    .unwrap();
    let e = Scene::load(&path).err().unwrap().to_string();
    assert!(e.contains("skinned glTF"), "{e}");
}

/// `[objects.articulations."parent / child"]` sets the parameters of one automatic articulation
/// (constant or keyed), the others keep the defaults; a name that is not one of them, a bad key
/// and the table without `self_contact = "auto"` are errors naming them.
#[test]
fn auto_articulations_take_their_parameters_by_name() {
    let shot = Shot::new();
    let scene = shot.load("self_contact = \"auto\"", "").unwrap();
    let names: Vec<String> =
        scene.evaluate(1.0).unwrap().objects[0].params.self_contact.iter().map(|a| a.name.clone()).collect();
    assert!(!names.is_empty());
    let table = format!(
        "[objects.articulations.\"{}\"]\nstiffness = [1, 4]\ncontact_tau = {{ keys = [[1, -1], [25, 0.5]] }}\n",
        names[0]
    );
    let scene = shot.load("self_contact = \"auto\"", &table).unwrap();
    let frame = scene.evaluate(25.0).unwrap();
    let articulations = &frame.objects[0].params.self_contact;
    assert_eq!((articulations[0].params.stiffness, articulations[0].params.contact_tau), ([1.0, 4.0], 0.5));
    for other in &articulations[1..] {
        assert_eq!(other.params, squish::params::ArticulationParams::default());
    }
    // Written back as it reads.
    let json = scene.to_json().unwrap();
    assert!(json.contains("articulations"), "{json}");

    let e = shot.error("self_contact = \"auto\"", "[objects.articulations.\"elbo\"]\nstiffness = 2\n");
    assert!(e.contains("\"elbo\"") && e.contains(&names[0]), "{e}");
    let e = shot.error("self_contact = \"auto\"", &format!("[objects.articulations.\"{}\"]\nstifness = 2\n", names[0]));
    assert!(e.contains("stifness") && e.contains("stiffness"), "{e}");
    let e = shot.error("", "[objects.articulations.\"a / b\"]\nstiffness = 2\n");
    assert!(e.contains("self_contact = \"auto\""), "{e}");
}
