//! The generic entry points (`read_mesh`, `write_mesh`), OBJ files from the shared data, and
//! atomic replacement through the public writers.

#![allow(clippy::unwrap_used)]

mod common;

use std::path::Path;

use glam::DVec3;
use squish::mesh::shapes;
use squish::{Topology, TriMesh};
use squish_io::*;

#[test]
fn bunny_3301_is_one_closed_manifold_component() {
    let Some(path) = common::shared_data("meshes/bunny_3301.obj") else { return };
    let mesh = read_mesh(&path).unwrap();
    assert_eq!(mesh.num_vertices(), 3301);
    assert_eq!(mesh.num_triangles(), 6598);
    let topology = mesh.check_for_deformation().unwrap();
    assert!(topology.is_closed());
    assert_eq!(topology.face_components(&mesh).1, 1);
    assert_eq!(topology.euler_characteristic(), 2);
}

#[test]
fn every_shared_obj_keeps_its_vertex_count() {
    let Some(dir) = common::shared_data("meshes") else { return };
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let Some(stem) = path.file_stem().map(|s| s.to_string_lossy().into_owned()) else { continue };
        let Some(count) = stem.rsplit('_').next().and_then(|c| c.parse::<usize>().ok()) else { continue };
        let mesh = read_mesh(&path).unwrap();
        assert_eq!(mesh.num_vertices(), count, "{}", path.display());
    }
}

#[test]
fn write_and_read_every_format() {
    let dir = tempfile::tempdir().unwrap();
    let mut mesh = shapes::capsule(0.3, 1.0 / 3.0, 12, 4, 3);
    mesh.positions[5] = DVec3::new(1e-12, -1.0 / 3.0, 1e6 / 7.0);
    for ext in ["obj", "ply", "gltf", "glb", "OBJ", "Ply"] {
        let path = dir.path().join(format!("capsule.{ext}"));
        write_mesh(&path, &mesh).unwrap();
        let back = read_mesh(&path).unwrap();
        assert_eq!(back.triangles, mesh.triangles, "{ext}");
        let lossy = matches!(ext, "gltf" | "glb");
        for (a, b) in back.positions.iter().zip(&mesh.positions) {
            let expected = if lossy { b.as_vec3().as_dvec3() } else { *b };
            assert_eq!(a.to_array().map(f64::to_bits), expected.to_array().map(f64::to_bits), "{ext}");
        }
        assert_eq!(back.num_vertices(), mesh.num_vertices());
    }
}

#[test]
fn unknown_extension_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["mesh.stl", "mesh", "mesh.fbx"] {
        let path = dir.path().join(name);
        let e = read_mesh(&path).unwrap_err();
        assert!(matches!(e, IoError::UnsupportedExtension { .. }));
        let s = e.to_string();
        assert!(s.contains(name) && s.contains(".obj, .ply, .gltf or .glb"), "{s}");
        let e = write_mesh(&path, &shapes::cube(1.0, 1)).unwrap_err();
        assert!(matches!(e, IoError::UnsupportedExtension { .. }));
        assert!(!path.exists());
    }
}

#[test]
fn invalid_mesh_is_not_written_and_old_file_survives() {
    let dir = tempfile::tempdir().unwrap();
    let good = shapes::cube(1.0, 1);
    let mut bad = good.clone();
    bad.positions[3].y = f64::NAN;
    let mut huge = good.clone();
    huge.positions[0].x = 1e300; // fine in OBJ/PLY, beyond f32 for glTF
    for ext in ["obj", "ply", "gltf", "glb"] {
        let path = dir.path().join(format!("keep.{ext}"));
        write_mesh(&path, &good).unwrap();
        let before = std::fs::read(&path).unwrap();
        let e = write_mesh(&path, &bad).unwrap_err();
        assert!(e.to_string().contains(&format!("keep.{ext}")) && e.to_string().contains("vertex 3"), "{e}");
        if matches!(ext, "gltf" | "glb") {
            let e = write_mesh(&path, &huge).unwrap_err();
            assert!(e.to_string().contains("32-bit"), "{e}");
        }
        let e = write_mesh(&path, &TriMesh::default()).unwrap_err();
        assert!(e.to_string().contains("empty"), "{e}");
        assert_eq!(std::fs::read(&path).unwrap(), before);
    }
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 4, "no temporary file left: {names:?}");
}

#[test]
fn missing_files_name_the_path() {
    for name in ["missing.obj", "missing.ply", "missing.gltf", "missing.glb"] {
        let path = Path::new("/nonexistent-dir").join(name);
        let e = read_mesh(&path).unwrap_err();
        assert!(matches!(e, IoError::Io { .. }));
        let s = e.to_string();
        assert!(s.contains(name) && s.contains("check the path"), "{s}");
    }
}

#[test]
fn weld_on_read_merges_duplicates() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("seam.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 4 5 6\n").unwrap();
    assert_eq!(read_mesh(&path).unwrap().num_vertices(), 6);
    let welded = read_mesh_with(&path, WeldMode::Exact).unwrap();
    assert_eq!(welded.num_vertices(), 4);
    assert_eq!(Topology::new(&welded).boundary_edges().len(), 4);
}
