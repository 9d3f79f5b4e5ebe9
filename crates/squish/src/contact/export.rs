//! Debug data of a pair's contact definition, for inspection in a viewer: per mesh, a label per
//! vertex and the exact boundary points of ℐ, ℳ and 𝒞. No file format here — the CLI writes them
//! (PLY colours, JSON points).

use glam::DVec3;

use super::{EdgeRegion, PairContact};
use crate::mesh::TriMesh;

/// Vertex label: outside every region.
pub const LABEL_OUTSIDE: u8 = 0;
/// Vertex label: in the intersection region ℐ (and not in ℳ or 𝒞).
pub const LABEL_INTERSECTION: u8 = 1;
/// Vertex label: in the mapping region ℳ (and not in 𝒞).
pub const LABEL_MAPPING: u8 = 2;
/// Vertex label: in the contact zone 𝒞.
pub const LABEL_CONTACT: u8 = 3;

/// Which region's boundary a point belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum BoundaryKind {
    Intersection,
    Mapping,
    Contact,
}

/// An exact boundary point on a mesh edge.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DebugPoint {
    pub kind: BoundaryKind,
    /// Its position on the mesh.
    pub position: DVec3,
    /// The edge's inside and outside vertices and α from the inside one.
    pub inside: u32,
    pub outside: u32,
    pub alpha: f64,
}

/// Debug data of one side.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DebugSide {
    /// Per vertex: [`LABEL_OUTSIDE`], [`LABEL_INTERSECTION`], [`LABEL_MAPPING`] or
    /// [`LABEL_CONTACT`]; the contact zone wins over the mapping region, which wins over the
    /// intersection region.
    pub labels: Vec<u8>,
    /// Boundary points of ℐ, then ℳ, then 𝒞.
    pub points: Vec<DebugPoint>,
}

fn push_points(out: &mut Vec<DebugPoint>, region: &EdgeRegion, mesh: &TriMesh, kind: BoundaryKind) {
    for (k, p) in region.points().iter().enumerate() {
        out.push(DebugPoint {
            kind,
            position: region.point_position(mesh, k as u32),
            inside: p.inside,
            outside: p.outside,
            alpha: p.alpha,
        });
    }
}

/// Labels and boundary points of both sides; `meshes` are the working-region meshes the result
/// was computed on, [a, b].
pub fn debug_export(result: &PairContact, meshes: [&TriMesh; 2]) -> [DebugSide; 2] {
    [0, 1].map(|l| {
        let side = &result.sides[l];
        let mesh = meshes[l];
        let n = mesh.num_vertices();
        let label = |v: u32| {
            let has = |r: &EdgeRegion| r.inside().get(v as usize).copied().unwrap_or(false);
            if has(&side.zone.region) {
                LABEL_CONTACT
            } else if has(&side.mapping.region) {
                LABEL_MAPPING
            } else if has(&side.intersection) {
                LABEL_INTERSECTION
            } else {
                LABEL_OUTSIDE
            }
        };
        let labels = (0..n as u32).map(label).collect();
        let mut points = Vec::new();
        push_points(&mut points, &side.intersection, mesh, BoundaryKind::Intersection);
        push_points(&mut points, &side.mapping.region, mesh, BoundaryKind::Mapping);
        push_points(&mut points, &side.zone.region, mesh, BoundaryKind::Contact);
        DebugSide { labels, points }
    })
}
