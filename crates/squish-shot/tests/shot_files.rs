//! The files of a scene run from a glTF source:
//! - shots split into parts (`--frames A:B`, Ray tasks) in the formats holding every frame: each
//!   part shows nothing outside its frames, and the parts merge into the file an unsplit run
//!   writes, byte for byte and frame by frame. On a procedural skinned glTF (always), and on the
//!   glTF sample CesiumMan when `../shared/data` is present;
//! - OBJ and PLY frames carry the asset's UVs and normals.

#![allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report

#[path = "../../squish-io/tests/common/mod.rs"]
mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::DVec3;
use squish_io::scene::OutputFormat;
use squish_io::{GltfDocument, GltfReadOptions, GltfScene, Scene, read_gltf};
use squish_shot::Interrupt;
use squish_shot::outputs::frame_time;
use squish_shot::parts::completed_frames;
use squish_shot::scene_run::{RunPlan, RunRequest, SceneRun};

/// A run's outcome and every computed frame's output positions in the file's vertex order.
struct Run {
    run: SceneRun,
    file_positions: BTreeMap<i64, Vec<DVec3>>,
}

fn run(scene: &Scene, out: &Path, format: OutputFormat, frames: Option<(i64, i64)>) -> Run {
    let request = RunRequest {
        frames: frames.map(|(a, b)| a..=b),
        output_dir: Some(out.to_path_buf()),
        format: Some(format),
        threads: Some(2),
        allow_missing_files: false,
    };
    let plan = RunPlan::new(scene, &request).unwrap();
    let run = plan.run(None, true, &Interrupt::new()).unwrap();
    assert!(run.animated_error.is_none(), "{:?}", run.animated_error);
    assert!(run.failed_error().is_none() && run.interrupted_error().is_none());
    let numbering = &plan.numbering[0];
    let file_positions = run.outcome.kept.iter().map(|(&f, p)| (f, numbering.positions(&p[0]))).collect();
    Run { run, file_positions }
}

/// Runs `scene` whole into `dir/whole` and in `parts` into `dir/split` (format `format`); checks
/// that the last part merges the others into the whole run's file, byte for byte, and returns
/// both runs' outcomes (the whole run's, then the parts').
fn split_and_merge(scene: &Scene, dir: &Path, format: OutputFormat, parts: &[(i64, i64)]) -> (Run, Vec<Run>) {
    let (whole_dir, split_dir) = (dir.join("whole"), dir.join("split"));
    let whole = run(scene, &whole_dir, format, None);
    let name = &scene.description().objects[0].name;
    let file = format!("{name}.{}", format.extension());
    let mut runs = Vec::new();
    for (k, &part) in parts.iter().enumerate() {
        let r = run(scene, &split_dir, format, Some(part));
        assert!(split_dir.join(format!("{name}.{}-{}.{}", part.0, part.1, format.extension())).is_file());
        if k + 1 < parts.len() {
            assert!(r.run.merged.files.is_empty() && !r.run.merged.incomplete.is_empty(), "{:?}", r.run.merged);
            assert!(!split_dir.join(&file).exists());
        } else {
            assert_eq!(r.run.merged.files, [split_dir.join(&file)]);
        }
        runs.push(r);
    }
    let (a, b) = (std::fs::read(whole_dir.join(&file)).unwrap(), std::fs::read(split_dir.join(&file)).unwrap());
    assert!(a == b, "{file}: the merged parts ({} bytes) differ from the unsplit run's ({} bytes)", b.len(), a.len());
    // The folder holds every frame, for a re-run to skip.
    let range = scene.frame_range();
    let mut spec = scene.output().clone();
    (spec.dir, spec.format) = (split_dir, format);
    assert_eq!(completed_frames(scene, &spec), (range.start..=range.end).collect::<Vec<_>>());
    (whole, runs)
}

/// Object 0's mesh posed by the file's first animation at `frame`'s time (as a player samples it,
/// in `f32`).
fn posed_at(file: &GltfScene, scene: &Scene, frame: i64) -> Vec<DVec3> {
    let node = scene.gltf_pose(0, frame as f64).unwrap().node;
    let animations = file.animations.len();
    let animation = (animations > 0).then_some(0);
    file.posed_mesh(node, animation, frame_time(scene, 0, frame) as f32 as f64).unwrap().positions
}

fn largest_gap(a: &[DVec3], b: &[DVec3]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max)
}

/// The checks of a glTF shot split in `parts`: merged = unsplit; each frame of the merged asset,
/// played, is the deformed frame (to `f32`); each part shows the deformation on its frames and
/// nothing at the frames around them; a frame's morph target is the same whichever run wrote it.
fn check_gltf_split(scene: &Scene, dir: &Path, parts: &[(i64, i64)], tolerance: f64) {
    let (whole, runs) = split_and_merge(scene, dir, OutputFormat::Glb, parts);
    let name = &scene.description().objects[0].name;
    let source = read_gltf(&scene.description().objects[0].mesh.file().clone(), &GltfReadOptions::default()).unwrap();
    let merged_path = dir.join("split").join(format!("{name}.glb"));
    let merged = read_gltf(&merged_path, &GltfReadOptions::default()).unwrap();
    let (mut deformation, mut worst): (f64, f64) = (0.0, 0.0);
    for (&frame, deformed) in &whole.file_positions {
        let played = posed_at(&merged, scene, frame);
        let gap = largest_gap(&played, deformed);
        assert!(gap < tolerance, "frame {frame}: the merged asset plays {gap} away from the deformed frame");
        worst = worst.max(gap);
        deformation = deformation.max(largest_gap(deformed, &posed_at(&source, scene, frame)));
    }
    eprintln!(
        "note: {name}: the merged asset plays every frame within {worst:.2e} of the deformed frame (largest deformation {deformation:.3})"
    );
    assert!(deformation > 20.0 * tolerance, "the shot deforms: {deformation}");
    let range = scene.frame_range();
    let document = GltfDocument::read(scene.description().objects[0].mesh.file()).unwrap();
    let node = scene.gltf_pose(0, range.start as f64).unwrap().node;
    let whole_targets: BTreeMap<String, _> = document.shot_frames(&merged_path, node).unwrap().into_iter().collect();
    assert_eq!(whole_targets.len(), (range.end - range.start + 1) as usize);
    for (&(first, last), part) in parts.iter().zip(&runs) {
        let path = dir.join("split").join(format!("{name}.{first}-{last}.glb"));
        let file = read_gltf(&path, &GltfReadOptions::default()).unwrap();
        for (&frame, deformed) in &part.file_positions {
            let gap = largest_gap(&posed_at(&file, scene, frame), deformed);
            assert!(gap < tolerance, "part {first}:{last}, frame {frame}: played {gap} away");
        }
        // Around its frames, within the scene's, the part shows the asset as it is.
        for frame in [first - 1, last + 1].into_iter().filter(|f| (range.start..=range.end).contains(f)) {
            let gap = largest_gap(&posed_at(&file, scene, frame), &posed_at(&source, scene, frame));
            assert!(gap < 1e-9, "part {first}:{last} shows {gap} of deformation at frame {frame}");
        }
        for (target, displacement) in document.shot_frames(&path, node).unwrap() {
            assert!(whole_targets[&target] == displacement, "{target} differs between the part and the whole run");
        }
    }
}

/// A skinned cylinder bending at its elbow ([`common::bending_cylinder`]) with normals and UVs,
/// as `dir/arm.glb`, and a 13-frame scene of it at 12 fps (the bend's second), with the elbow's
/// self-contact.
fn bending_arm(dir: &Path) -> PathBuf {
    let (rings, segments) = (41, 16);
    let mut fixture = common::bending_cylinder(rings, segments, |x| {
        let w = ((x + 0.3) / 0.6).clamp(0.0, 1.0);
        ([0.0, 1.0], [1.0 - w, w])
    });
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let a = 2.0 * std::f64::consts::PI * s as f64 / segments as f64;
            normals.extend_from_slice(&[0.0, a.cos(), a.sin()]);
            uvs.extend_from_slice(&[s as f64 / segments as f64, r as f64 / (rings - 1) as f64]);
        }
    }
    normals.extend_from_slice(&[-1.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
    uvs.extend_from_slice(&[0.5, 0.0, 0.5, 1.0]);
    let normal = fixture.accessor(common::F32, "VEC3", &normals);
    let uv = fixture.accessor(common::F32, "VEC2", &uvs);
    let attributes = &mut fixture.root["meshes"][0]["primitives"][0]["attributes"];
    attributes["NORMAL"] = serde_json::json!(normal);
    attributes["TEXCOORD_0"] = serde_json::json!(uv);
    fixture.write_glb(dir, "arm");
    let scene = dir.join("arm.toml");
    std::fs::write(
        &scene,
        "frames = { start = 1, end = 13, fps = 12 }\n\n[[objects]]\nname = \"arm\"\nmesh = \"arm.glb\"\n\n\
         [[objects.self_contact]]\nname = \"elbow\"\njoints = [\"root\", \"elbow\"]\n",
    )
    .unwrap();
    scene
}

#[test]
fn a_split_gltf_shot_merges_into_the_unsplit_asset() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(&bending_arm(dir.path())).unwrap();
    check_gltf_split(&scene, &dir.path().join("glb"), &[(1, 4), (5, 9), (10, 13)], 1e-5);
    // Its targets hold only what moves: nothing before the elbow's sides touch (frame 10), then
    // the deformed region around the fold.
    let merged = dir.path().join("glb/split/arm.glb");
    let document = GltfDocument::read(&dir.path().join("arm.glb")).unwrap();
    let targets = document.shot_frames(&merged, 0).unwrap();
    let vertices = document.scene().meshes[0].positions.len();
    let moving: Vec<usize> = targets.iter().map(|(_, d)| d.indices.len()).collect();
    assert!(moving[..9].iter().all(|&m| m == 0), "{moving:?}");
    assert!(moving[9] > 0 && moving[9] < vertices, "{moving:?} of {vertices}");
    // Point caches split and merge the same way.
    split_and_merge(&scene, &dir.path().join("pc2"), OutputFormat::Pc2, &[(1, 6), (7, 7), (8, 13)]);
}

/// A part written again over a different split merges with the rest: parts are taken by frame
/// range, a frame from the last part holding it.
#[test]
fn overlapping_parts_merge_into_the_same_asset() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(&bending_arm(dir.path())).unwrap();
    let out = dir.path().join("out");
    run(&scene, &dir.path().join("whole"), OutputFormat::Glb, None);
    for part in [(1, 8), (6, 13)] {
        run(&scene, &out, OutputFormat::Glb, Some(part));
    }
    let (a, b) =
        (std::fs::read(dir.path().join("whole/arm.glb")).unwrap(), std::fs::read(out.join("arm.glb")).unwrap());
    assert!(a == b, "overlapping parts merge into the unsplit asset");
}

/// CesiumMan walking with `self_contact = "auto"` (examples/cesium_man.toml) over frames 19–27,
/// split in three.
#[test]
fn a_split_cesium_man_shot_merges_into_the_unsplit_asset() {
    let Some(file) = common::shared_data("rigged/CesiumMan.glb") else { return };
    let dir = tempfile::tempdir().unwrap();
    let example = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/cesium_man.toml"))
        .unwrap()
        .replace("frames = { start = 1, end = 48, fps = 24 }", "frames = { start = 19, end = 27, fps = 24 }")
        .replace("../../shared/data/rigged/CesiumMan.glb", &file.display().to_string());
    let path = dir.path().join("cesium_man.toml");
    std::fs::write(&path, example).unwrap();
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.frame_range().start, 19);
    check_gltf_split(&scene, dir.path(), &[(19, 21), (22, 24), (25, 27)], 2e-5);
}

/// OBJ and PLY frames of a glTF source carry its first UV set (v turned to their convention) and
/// normals recomputed for each frame.
#[test]
fn obj_and_ply_frames_of_a_gltf_source_keep_its_uvs_and_normals() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(&bending_arm(dir.path())).unwrap();
    let source = read_gltf(&dir.path().join("arm.glb"), &GltfReadOptions::default()).unwrap();
    let (uvs, vertices) = (source.meshes[0].texcoords.clone().unwrap(), source.meshes[0].positions.len());
    for format in [OutputFormat::Obj, OutputFormat::Ply] {
        let out = dir.path().join(format.extension());
        let computed = run(&scene, &out, format, Some((12, 12)));
        let deformed = &computed.file_positions[&12];
        let file = out.join(format!("arm/0012.{}", format.extension()));
        let (texcoords, normals): (Vec<[f64; 2]>, Vec<DVec3>) = match format {
            OutputFormat::Obj => {
                let obj = squish_io::ObjDocument::read(&file).unwrap();
                assert_eq!(&obj.mesh().positions, deformed);
                (obj.texcoords().0.to_vec(), obj.normals().to_vec())
            }
            _ => {
                let ply = squish_io::read_ply_data(&file).unwrap();
                assert_eq!(&ply.positions, deformed);
                let column = |name: &str| ply.property(name).unwrap().values.clone();
                let (u, v, x, y, z) = (column("u"), column("v"), column("nx"), column("ny"), column("nz"));
                (
                    (0..vertices).map(|k| [u[k], v[k]]).collect(),
                    (0..vertices).map(|k| DVec3::new(x[k], y[k], z[k])).collect(),
                )
            }
        };
        assert_eq!(texcoords.len(), vertices);
        for (k, (written, file)) in texcoords.iter().zip(&uvs).enumerate() {
            assert!((written[0] - file[0]).abs() < 1e-7 && (written[1] - (1.0 - file[1])).abs() < 1e-7, "uv {k}");
        }
        // Unit normals, facing out of the deformed surface: along the deformed mesh's own.
        let mesh = squish::TriMesh { positions: deformed.clone(), triangles: source.meshes[0].triangles.clone() };
        let expected = squish::mesh::vertex_normals(&mesh);
        assert_eq!(normals.len(), vertices);
        for (k, (n, e)) in normals.iter().zip(&expected).enumerate() {
            assert!((n.length() - 1.0).abs() < 1e-6 && n.dot(*e) > 0.9, "normal {k}: {n} vs {e}");
        }
    }
}
