//! The quality pass of a frame, after its results (thesis §7.2's figures): for every pair of
//! objects, the deepest penetration of either mesh into the other before (the frame's input) and
//! after (the output) — closed meshes only, an open mesh has no inside — and how many faces of
//! each intersect a face of the other (exact triangle–triangle test, any mesh); an output that
//! still penetrates deeper than [`RESIDUAL_PENETRATION_TOLERANCE`] of the input is a
//! [`WarningKind::ResidualPenetration`] warning.
//!
//! The triangle trees of each object's input and output are kept between frames
//! ([`QualityCache`]) and refitted: building two trees per object and frame would cost as much as
//! a third of the deformation. Nothing here changes a result.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::warnings::{FrameWarning, RESIDUAL_PENETRATION_TOLERANCE, WarningKind};
use super::{Frame, PairStats};
use crate::mesh::{Topology, TriMesh};
use crate::spatial::TriangleBvh;

/// The quality figures of one pair of objects at one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PairQuality {
    /// Index of the pair among the frame's pairs (disabled pairs left out) and its objects.
    pub pair: usize,
    pub objects: [String; 2],
    /// True if one of its region pairs is in contact; the largest contact area among them.
    pub in_contact: bool,
    pub contact_area: f64,
    /// Deepest vertex of either mesh inside the other, before (input) and after (output); `None`
    /// when a mesh is not closed (inside is undefined).
    pub penetration_before: Option<f64>,
    pub penetration_after: Option<f64>,
    /// `penetration_after / penetration_before` (`None` when there was no penetration).
    pub penetration_ratio: Option<f64>,
    /// Faces of each object that intersect a face of the other (exact test, touching counts),
    /// before (input) and after (output).
    pub intersecting_faces_before: [usize; 2],
    pub intersecting_faces_after: [usize; 2],
}

/// The quality pass's triangle trees of each object, kept between frames.
#[derive(Default)]
pub(super) struct QualityCache {
    objects: Vec<Option<ObjectTrees>>,
}

struct ObjectTrees {
    triangles: Vec<[u32; 3]>,
    closed: bool,
    input: TriangleBvh,
    output: TriangleBvh,
}

impl QualityCache {
    /// Brings the trees of object `i` to `mesh` (input) and `output`: refitted when its
    /// triangles are the same, built otherwise; `None` when they cannot be built.
    fn update(&mut self, i: usize, mesh: &TriMesh, output: &[DVec3]) -> Option<&ObjectTrees> {
        if self.objects.len() <= i {
            self.objects.resize_with(i + 1, || None);
        }
        let slot = &mut self.objects[i];
        if slot.as_ref().is_some_and(|t| t.triangles == mesh.triangles) {
            let trees = slot.as_mut()?;
            if trees.input.refit(&mesh.positions).is_err() || trees.output.refit(output).is_err() {
                *slot = None;
            }
        } else {
            let closed = Topology::new(mesh).is_closed();
            let output_mesh = TriMesh { positions: output.to_vec(), triangles: mesh.triangles.clone() };
            *slot = match (TriangleBvh::new(mesh), TriangleBvh::new(&output_mesh)) {
                (Ok(input), Ok(output)) => {
                    Some(ObjectTrees { triangles: mesh.triangles.clone(), closed, input, output })
                }
                _ => None,
            };
        }
        slot.as_ref()
    }
}

/// Distinct faces of each tree that intersect a face of the other.
fn intersecting_faces(a: &TriangleBvh, b: &TriangleBvh) -> [usize; 2] {
    if !a.bounds().intersects(&b.bounds()) {
        return [0, 0];
    }
    let pairs = a.intersections_with(b);
    let mut faces: [Vec<u32>; 2] = [pairs.iter().map(|p| p[0]).collect(), pairs.iter().map(|p| p[1]).collect()];
    faces.iter_mut().for_each(|f| {
        f.sort_unstable();
        f.dedup();
    });
    faces.map(|f| f.len())
}

/// Deepest vertex of either point set inside the other tree's closed mesh.
fn deepest(a: &[DVec3], tree_a: &TriangleBvh, b: &[DVec3], tree_b: &TriangleBvh) -> f64 {
    if !tree_a.bounds().intersects(&tree_b.bounds()) {
        return 0.0;
    }
    tree_b.penetration_depths(a).into_iter().chain(tree_a.penetration_depths(b)).fold(0.0, f64::max)
}

/// The figures of every pair of `frame` (its input) against `positions` (its output), and the
/// residual-penetration warnings, naming the first region pair of each pair in `pairs`.
pub(super) fn measure(
    frame: &Frame,
    positions: &[Vec<DVec3>],
    pairs: &[PairStats],
    cache: &mut QualityCache,
) -> (Vec<PairQuality>, Vec<FrameWarning>) {
    let mut figures = Vec::with_capacity(frame.pairs.len());
    let mut warnings = Vec::new();
    for (p, pair) in frame.pairs.iter().enumerate() {
        let [a, b] = pair.objects;
        let (mesh_a, mesh_b) = (frame.objects[a].mesh, frame.objects[b].mesh);
        let (out_a, out_b) = (&positions[a], &positions[b]);
        let closed_a = cache.update(a, mesh_a, out_a).is_some_and(|t| t.closed);
        let closed_b = cache.update(b, mesh_b, out_b).is_some_and(|t| t.closed);
        let trees = (&cache.objects[a], &cache.objects[b]);
        let (before, after) = match (closed_a && closed_b, trees) {
            (true, (Some(ta), Some(tb))) if a != b => (
                Some(deepest(&mesh_a.positions, &ta.input, &mesh_b.positions, &tb.input)),
                Some(deepest(out_a, &ta.output, out_b, &tb.output)),
            ),
            _ => (None, None),
        };
        let (faces_before, faces_after) = match trees {
            (Some(ta), Some(tb)) if a != b => {
                (intersecting_faces(&ta.input, &tb.input), intersecting_faces(&ta.output, &tb.output))
            }
            _ => ([0, 0], [0, 0]),
        };
        let region_pairs = pairs.iter().enumerate().filter(|(_, s)| s.pair == p);
        let first = region_pairs.clone().next().map(|(k, _)| k);
        let objects = [a, b].map(|i| frame.objects[i].name.to_string());
        if let (Some(before), Some(after), Some(k)) = (before, after, first)
            && above_tolerance(before, after)
        {
            warnings.push(residual_penetration(k, &objects, before, after));
        }
        figures.push(PairQuality {
            pair: p,
            in_contact: region_pairs.clone().any(|(_, s)| s.in_contact),
            contact_area: region_pairs.map(|(_, s)| s.contact_area).fold(0.0, f64::max),
            objects,
            penetration_before: before,
            penetration_after: after,
            penetration_ratio: match (before, after) {
                (Some(b), Some(a)) if b > 0.0 => Some(a / b),
                _ => None,
            },
            intersecting_faces_before: faces_before,
            intersecting_faces_after: faces_after,
        });
    }
    (figures, warnings)
}

/// True if a residual penetration `after` is above the tolerance of the input's `before`.
fn above_tolerance(before: f64, after: f64) -> bool {
    after > RESIDUAL_PENETRATION_TOLERANCE * before && after > 0.0
}

/// The warning of a pair whose output still penetrates `after` deep, against `before` in the
/// input (region pair `k`).
fn residual_penetration(k: usize, names: &[String; 2], before: f64, after: f64) -> FrameWarning {
    FrameWarning {
        kind: WarningKind::ResidualPenetration,
        pair: Some(k),
        object: None,
        message: format!(
            "pair (\"{}\", \"{}\"): the output still penetrates {after:.3e} deep, {:.0}% of the input's {before:.3e} \
             (tolerance {:.0}%); a smaller pair.contact_tau, a larger extent or a rigid side resolve more",
            names[0],
            names[1],
            100.0 * after / before.max(f64::MIN_POSITIVE),
            100.0 * RESIDUAL_PENETRATION_TOLERANCE
        ),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::mesh::shapes;
    use crate::spatial::penetration_depths;

    #[test]
    fn penetrations_with_kept_trees_match_the_direct_measure() {
        let mut cache = QualityCache::default();
        let a = shapes::icosphere(1.0, 2);
        let mut b = a.clone();
        for depth in [0.3, 0.5, -0.1] {
            b.positions = a.positions.iter().map(|p| *p + DVec3::new(0.0, 0.0, 2.0 - depth)).collect();
            let direct = penetration_depths(&a, &b)
                .unwrap()
                .into_iter()
                .chain(penetration_depths(&b, &a).unwrap())
                .fold(0.0, f64::max);
            let ta = cache.update(0, &a, &a.positions).map(|t| t.input.clone()).unwrap();
            let tb = cache.update(1, &b, &b.positions).map(|t| t.input.clone()).unwrap();
            assert_eq!(deepest(&a.positions, &ta, &b.positions, &tb), direct, "depth {depth}");
        }
        // The rule of the warning: above the tolerance of the input's depth only.
        assert!(!above_tolerance(1.0, 0.1) && !above_tolerance(0.0, 0.0) && above_tolerance(1.0, 0.11));
        let names = ["a".to_string(), "b".to_string()];
        assert!(residual_penetration(0, &names, 1.0, 0.11).message.contains("11%"));
        // An open mesh has trees (its faces are counted) but no inside.
        let mut open = a.clone();
        open.triangles.pop();
        assert!(cache.update(2, &open, &open.positions).is_some_and(|t| !t.closed));
    }
}
