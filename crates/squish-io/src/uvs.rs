//! Texture coordinates of a mesh file, for method A's shared-parametrization mapping (thesis
//! §4.2.1; [`squish::params::Uvs`]), in the numbering of [`MeshDocument::mesh`]'s triangles:
//!
//! - OBJ: the `vt` of every face corner (polygons fan-triangulated as the mesh is), per corner;
//! - PLY: the vertex properties `u, v`, `s, t`, `texture_u, texture_v` or `texture_s, texture_t`
//!   (per vertex), or a face list `texcoord` of two numbers per corner (per corner);
//! - glTF: `TEXCOORD_0`, per corner of the merged mesh (v pointing down the image, as stored).
//!
//! Welding for processing keeps every corner's UV ([`welded_uvs`]): a welded vertex on a UV
//! seam has one UV per chart, which the mapping unfolds (docs/decisions.md, "UV seams in the
//! shared parametrization").

use glam::DVec2;
use squish::params::Uvs;

use crate::{MeshDocument, ObjDocument, PlyDocument};

/// The texture coordinates of a mesh file (module docs), or why it has none usable: a message
/// naming what is missing, for the caller to give when the mapping needs them.
pub fn document_uvs(document: &MeshDocument) -> Result<Uvs, String> {
    match document {
        MeshDocument::Obj(obj) => obj_uvs(obj),
        MeshDocument::Ply(ply) => ply_uvs(ply),
        MeshDocument::Gltf(gltf) => gltf
            .scene()
            .merged_corner_uvs()
            .map(Uvs::PerCorner)
            .ok_or_else(|| "a mesh primitive of the file has no TEXCOORD_0".to_string()),
    }
}

fn obj_uvs(obj: &ObjDocument) -> Result<Uvs, String> {
    let (values, corners) = obj.texcoords();
    if values.is_empty() {
        return Err("the file has no texture coordinates ('vt' lines)".to_string());
    }
    let mut uvs = Vec::with_capacity(obj.mesh().num_triangles());
    for (f, face) in corners.iter().enumerate() {
        let uv = |k: usize| -> Result<DVec2, String> {
            let index = face[k].ok_or_else(|| {
                format!("face {} has a corner without a texture coordinate (write every corner as v/vt)", f + 1)
            })?;
            values
                .get(index as usize)
                .map(|&q| DVec2::from_array(q))
                .ok_or_else(|| format!("face {} refers to a missing 'vt'", f + 1))
        };
        for i in 1..face.len().saturating_sub(1) {
            uvs.push([uv(0)?, uv(i)?, uv(i + 1)?]);
        }
    }
    Ok(Uvs::PerCorner(uvs))
}

/// The vertex property pairs a PLY file's UVs go by.
const PLY_UV_NAMES: [[&str; 2]; 4] = [["u", "v"], ["s", "t"], ["texture_u", "texture_v"], ["texture_s", "texture_t"]];

fn ply_uvs(ply: &PlyDocument) -> Result<Uvs, String> {
    if let Some(vertex) = ply.element("vertex") {
        for [u, v] in PLY_UV_NAMES {
            let column = |name: &str| vertex.property(name).and_then(|p| p.values.scalars());
            if let (Some(us), Some(vs)) = (column(u), column(v)) {
                return Ok(Uvs::PerVertex(us.iter().zip(vs).map(|(&u, &v)| DVec2::new(u, v)).collect()));
            }
        }
    }
    let face = ply.element("face");
    let corners = face.and_then(|f| f.property("texcoord"));
    let indices =
        face.and_then(|f| f.properties.iter().find(|p| p.name == "vertex_indices" || p.name == "vertex_index"));
    if let (Some(face), Some(corners), Some(indices)) = (face, corners, indices) {
        let mut uvs = Vec::new();
        for r in 0..face.count {
            let polygon = indices.values.list(r).unwrap_or(&[]);
            let texcoord = corners.values.list(r).unwrap_or(&[]);
            if texcoord.len() != 2 * polygon.len() {
                return Err(format!(
                    "face {r}: texcoord has {} numbers for {} corners; give two per corner",
                    texcoord.len(),
                    polygon.len()
                ));
            }
            let uv = |k: usize| DVec2::new(texcoord[2 * k], texcoord[2 * k + 1]);
            for i in 1..polygon.len().saturating_sub(1) {
                uvs.push([uv(0), uv(i), uv(i + 1)]);
            }
        }
        return Ok(Uvs::PerCorner(uvs));
    }
    Err("the file has no texture coordinates (vertex properties u, v or s, t, or a face list texcoord)".to_string())
}

/// UVs of a file's mesh (`file_triangles`) carried onto the mesh welded by `vertex_map` (file
/// vertex → welded vertex): per corner, with the triangles that welding collapsed dropped as
/// [`crate::weld_positions`] drops them.
pub fn welded_uvs(uvs: &Uvs, file_triangles: &[[u32; 3]], vertex_map: &[u32]) -> Uvs {
    let kept = file_triangles.iter().enumerate().filter(|(_, t)| {
        let w = t.map(|v| vertex_map.get(v as usize).copied().unwrap_or(v));
        w[0] != w[1] && w[1] != w[2] && w[0] != w[2]
    });
    Uvs::PerCorner(kept.map(|(f, t)| [0, 1, 2].map(|k| uvs.corner(f as u32, *t, k))).collect())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::{WeldMode, weld_positions};

    #[test]
    fn obj_corners_follow_the_fan_triangulation_and_partial_uvs_are_refused() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";
        let obj = ObjDocument::parse(Path::new("quad.obj"), text.as_bytes()).unwrap();
        let Uvs::PerCorner(uvs) = obj_uvs(&obj).unwrap() else { panic!("per corner") };
        assert_eq!(obj.mesh().triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(uvs, vec![[DVec2::ZERO, DVec2::X, DVec2::ONE], [DVec2::ZERO, DVec2::ONE, DVec2::Y]]);
        let partial =
            ObjDocument::parse(Path::new("p.obj"), b"v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2 3\n").unwrap();
        assert!(obj_uvs(&partial).unwrap_err().contains("face 1"), "{:?}", obj_uvs(&partial));
        let none = ObjDocument::parse(Path::new("n.obj"), b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n").unwrap();
        assert!(obj_uvs(&none).unwrap_err().contains("'vt'"));
    }

    #[test]
    fn welding_keeps_each_corners_uv_and_drops_collapsed_triangles() {
        // A quad whose diagonal is a seam: vertices 0/3 and 2/4 are copies with other UVs.
        let positions =
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
                .map(glam::DVec3::from_array);
        let triangles = [[0, 1, 2], [3, 4, 5], [0, 3, 5]];
        let per_vertex: Vec<DVec2> = (0..6).map(|k| DVec2::new(k as f64, 0.5)).collect();
        let welded = weld_positions(&positions, &triangles, WeldMode::Exact);
        assert_eq!(welded.collapsed_triangles, 1);
        let Uvs::PerCorner(corners) = welded_uvs(&Uvs::PerVertex(per_vertex.clone()), &triangles, &welded.vertex_map)
        else {
            panic!("per corner")
        };
        assert_eq!(corners.len(), welded.triangles.len());
        assert_eq!(corners[1], [3, 4, 5].map(|v| per_vertex[v]));
        let uvs = Uvs::PerCorner(corners);
        assert!(uvs.has_seams(&welded.triangles, welded.positions.len()));
    }
}
