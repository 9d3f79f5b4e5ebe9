//! Test helper: the shared sample meshes, read from their OBJ `v`/`f` lines (the library has no
//! file formats; `squish-io` reads OBJ for real).

use glam::DVec3;

use crate::mesh::TriMesh;

/// Loads the `v`/`f` lines of an OBJ file (polygons fanned into triangles), or `None` if absent.
pub(crate) fn load_obj(path: &str) -> Option<TriMesh> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut mesh = TriMesh::default();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f64> = it.take(3).map(|x| x.parse().ok()).collect::<Option<_>>()?;
                mesh.positions.push(DVec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let ids: Vec<u32> = it
                    .map(|x| x.split('/').next().and_then(|i| i.parse::<u32>().ok()).map(|i| i - 1))
                    .collect::<Option<_>>()?;
                for k in 1..ids.len().saturating_sub(1) {
                    mesh.triangles.push([ids[0], ids[k], ids[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Some(mesh)
}

/// The 3301-vertex Stanford bunny of the shared data, or `None` (with a message) if absent.
pub(crate) fn bunny() -> Option<TriMesh> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/meshes/bunny_3301.obj");
    let mesh = load_obj(path);
    if mesh.is_none() {
        eprintln!("skipping: {path} not found");
    }
    mesh
}
