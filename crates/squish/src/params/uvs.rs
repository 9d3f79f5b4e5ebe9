//! Texture coordinates of an object for method A's shared-parametrization mapping (§4.2.1).
//!
//! A mesh file's UVs are per face corner: a vertex on a UV seam has one UV per chart it borders,
//! while the deformer works on the welded mesh (one vertex per surface point). [`Uvs`] holds
//! either one UV per vertex (a layout without seams, e.g. a PLY's `u, v`) or three per triangle
//! in its corner order (an OBJ's `vt`, a glTF's `TEXCOORD_0` after welding its seams); the
//! mapping unfolds the charts it meets near the contact into one layout
//! (`contact::uv_mapping`, docs/decisions.md, "UV seams in the shared parametrization").

use glam::DVec2;

/// Texture coordinates of a mesh (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub enum Uvs {
    /// One UV per vertex: a layout without seams.
    PerVertex(Vec<DVec2>),
    /// Three UVs per triangle, in its corner order: a vertex on a seam has one per chart.
    PerCorner(Vec<[DVec2; 3]>),
}

impl Uvs {
    /// The UV of corner `k` of face `face`, whose vertices are `triangle`.
    #[inline]
    pub fn corner(&self, face: u32, triangle: [u32; 3], k: usize) -> DVec2 {
        match self {
            Self::PerVertex(uvs) => uvs[triangle[k] as usize],
            Self::PerCorner(corners) => corners[face as usize][k],
        }
    }

    /// What the UVs are counted against (`"vertices"` or `"triangles"`) and how many they hold.
    pub fn count(&self) -> (&'static str, usize) {
        match self {
            Self::PerVertex(uvs) => ("vertices", uvs.len()),
            Self::PerCorner(corners) => ("triangles", corners.len()),
        }
    }

    /// The count the UVs must have on a mesh of `vertices` vertices and `triangles` triangles.
    pub fn expected(&self, vertices: usize, triangles: usize) -> usize {
        match self {
            Self::PerVertex(_) => vertices,
            Self::PerCorner(_) => triangles,
        }
    }

    /// True if some vertex has different UVs at different corners (a seam). Per-vertex UVs
    /// have none.
    pub fn has_seams(&self, triangles: &[[u32; 3]], vertices: usize) -> bool {
        let Self::PerCorner(corners) = self else { return false };
        let mut first: Vec<Option<DVec2>> = vec![None; vertices];
        for (t, c) in triangles.iter().zip(corners) {
            for k in 0..3 {
                let slot = &mut first[t[k] as usize];
                match slot {
                    Some(uv) if uv.x.to_bits() != c[k].x.to_bits() || uv.y.to_bits() != c[k].y.to_bits() => {
                        return true;
                    }
                    Some(_) => {}
                    None => *slot = Some(c[k]),
                }
            }
        }
        false
    }

    /// Bitwise equality (0.0 and −0.0 differ; a NaN equals itself), for caches.
    pub fn same_bits(&self, other: &Self) -> bool {
        let bits = |q: &DVec2| [q.x.to_bits(), q.y.to_bits()];
        match (self, other) {
            (Self::PerVertex(a), Self::PerVertex(b)) => a.len() == b.len() && a.iter().map(bits).eq(b.iter().map(bits)),
            (Self::PerCorner(a), Self::PerCorner(b)) => {
                a.len() == b.len() && a.iter().flatten().map(bits).eq(b.iter().flatten().map(bits))
            }
            _ => false,
        }
    }
}

impl From<Vec<DVec2>> for Uvs {
    fn from(uvs: Vec<DVec2>) -> Self {
        Self::PerVertex(uvs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seams_are_corners_of_one_vertex_with_different_uvs() {
        let triangles = [[0, 1, 2], [0, 2, 3]];
        let (a, b, c, d) = (DVec2::ZERO, DVec2::X, DVec2::ONE, DVec2::Y);
        let smooth = Uvs::PerCorner(vec![[a, b, c], [a, c, d]]);
        assert!(!smooth.has_seams(&triangles, 4));
        let seam = Uvs::PerCorner(vec![[a, b, c], [a, DVec2::new(5.0, 5.0), d]]);
        assert!(seam.has_seams(&triangles, 4));
        assert_eq!(seam.corner(1, triangles[1], 1), DVec2::new(5.0, 5.0));
        let per_vertex = Uvs::from(vec![a, b, c, d]);
        assert!(!per_vertex.has_seams(&triangles, 4));
        assert_eq!(per_vertex.corner(1, triangles[1], 2), d);
        assert_eq!(per_vertex.count(), ("vertices", 4));
        assert_eq!(seam.count(), ("triangles", 2));
        assert!(seam.same_bits(&seam.clone()) && !seam.same_bits(&smooth) && !smooth.same_bits(&per_vertex));
    }
}
