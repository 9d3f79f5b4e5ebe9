//! Generic box trees for primitives other than mesh triangles: [`AabbTree`] over arbitrary boxes,
//! [`PointTree`] over points (radius and nearest queries), and [`SegmentTree2`] over 2D segments
//! (exact crossing queries).
//!
//! - Ball testing (method A, thesis §4.4.1) needs the vertices within a ball radius r_s of a point:
//!   [`PointTree::within_radius`].
//! - The mapping regions of §4.2.2 are bounded by intersecting, "in the plane orthogonal to d̂",
//!   the projected contour segments with the projected mesh edges, "accelerated by a 2D AABB-tree":
//!   [`SegmentTree2`] with [`ProjectionPlane`]. Its crossing test is exact and symbolically
//!   perturbed like the 3D one, so a contour passing exactly through a projected vertex crosses
//!   exactly one of the edges there.
//!
//! All three use our [`FlatBvh`] (2D boxes are flat in z), with the same conventions as
//! [`super::TriangleBvh`]: deterministic build, refit without changing the topology, sorted
//! results.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::SpatialError;
use super::batch::Batch;
use super::bvh::{SegmentProbe, box_distance_squared};
use super::exact::segment_segment_2d;
use super::flat_bvh::{FlatBvh, Node, Visit};
use crate::mesh::Aabb3;

/// A BVH over boxes; results name boxes by their index in the input slice.
#[derive(Clone, Debug)]
pub struct AabbTree {
    bvh: FlatBvh,
    boxes: Vec<Aabb3>,
}

fn check_boxes(boxes: &[Aabb3]) -> Result<(), SpatialError> {
    for (index, b) in boxes.iter().enumerate() {
        if !(b.min.is_finite() && b.max.is_finite() && b.min.cmple(b.max).all()) {
            return Err(SpatialError::InvalidBox { index, min: b.min.to_array(), max: b.max.to_array() });
        }
    }
    Ok(())
}

impl AabbTree {
    /// Builds the tree. Boxes must be finite with `min ≤ max`.
    pub fn new(boxes: &[Aabb3]) -> Result<Self, SpatialError> {
        check_boxes(boxes)?;
        let leaves: Vec<(DVec3, DVec3)> = boxes.iter().map(|b| (b.min, b.max)).collect();
        Ok(Self { bvh: FlatBvh::new(&leaves), boxes: boxes.to_vec() })
    }

    /// Replaces the boxes (same count) and refits, keeping the tree topology.
    pub fn refit(&mut self, boxes: &[Aabb3]) -> Result<(), SpatialError> {
        if boxes.len() != self.boxes.len() {
            return Err(SpatialError::ItemCount { expected: self.boxes.len(), got: boxes.len() });
        }
        check_boxes(boxes)?;
        self.boxes.copy_from_slice(boxes);
        let boxes = &self.boxes;
        self.bvh.refit(|i| (boxes[i as usize].min, boxes[i as usize].max));
        Ok(())
    }

    /// Number of boxes.
    pub fn len(&self) -> usize {
        self.boxes.len()
    }

    /// True if the tree holds no box.
    pub fn is_empty(&self) -> bool {
        self.boxes.is_empty()
    }

    /// The boxes, in input order.
    pub fn boxes(&self) -> &[Aabb3] {
        &self.boxes
    }

    /// Depth-first traversal of the tree's nodes (a leaf's [`Node::item`] is its box index).
    pub(crate) fn traverse(&self, mut visit: impl FnMut(&Node) -> Visit) {
        self.bvh.traverse(|_, node| visit(node));
    }

    /// Calls `f` with every box overlapping `query` (touching counts), in tree order.
    pub fn for_each_overlapping(&self, query: &Aabb3, f: impl FnMut(u32)) {
        self.bvh.for_each_in_box(query.min, query.max, f);
    }

    /// Boxes overlapping `query` (touching counts), sorted, written to `out`.
    pub fn overlapping(&self, query: &Aabb3, out: &mut Vec<u32>) {
        out.clear();
        self.for_each_overlapping(query, |i| out.push(i));
        out.sort_unstable();
    }

    /// Calls `f` with every box at distance ≤ `radius` from `p` (and its squared distance).
    pub fn for_each_within_distance(&self, p: DVec3, radius: f64, mut f: impl FnMut(u32, f64)) {
        let r2 = radius * radius;
        self.bvh.traverse(|_, node| {
            let d2 = box_distance_squared(node.min, node.max, p);
            if d2.is_nan() || d2 > r2 {
                return Visit::Prune;
            }
            if let Some(leaf) = node.item() {
                f(leaf, d2);
            }
            Visit::Continue
        });
    }

    /// Boxes at distance ≤ `radius` from `p`, sorted, written to `out`.
    pub fn within_distance(&self, p: DVec3, radius: f64, out: &mut Vec<u32>) {
        out.clear();
        self.for_each_within_distance(p, radius, |i, _| out.push(i));
        out.sort_unstable();
    }

    /// Overlapping pairs `[box of self, box of other]`, sorted (parallel).
    pub fn overlapping_pairs(&self, other: &AabbTree) -> Vec<[u32; 2]> {
        let mut pairs: Vec<[u32; 2]> = (0..self.len())
            .into_par_iter()
            .with_min_len(64)
            .fold(Vec::new, |mut v, i| {
                other.for_each_overlapping(&self.boxes[i], |j| v.push([i as u32, j]));
                v
            })
            .flatten_iter()
            .collect();
        pairs.par_sort_unstable();
        pairs
    }

    /// Overlapping pairs `[i, j]`, `i < j`, among the tree's own boxes, sorted (parallel).
    pub fn self_overlapping_pairs(&self) -> Vec<[u32; 2]> {
        let mut pairs: Vec<[u32; 2]> = (0..self.len())
            .into_par_iter()
            .with_min_len(64)
            .fold(Vec::new, |mut v, i| {
                self.for_each_overlapping(&self.boxes[i], |j| {
                    if j as usize > i {
                        v.push([i as u32, j]);
                    }
                });
                v
            })
            .flatten_iter()
            .collect();
        pairs.par_sort_unstable();
        pairs
    }
}

/// A BVH over points, for radius (ball) and nearest-point queries.
#[derive(Clone, Debug)]
pub struct PointTree {
    tree: AabbTree,
    points: Vec<DVec3>,
}

impl PointTree {
    /// Builds the tree over finite points.
    pub fn new(points: &[DVec3]) -> Result<Self, SpatialError> {
        let boxes: Vec<Aabb3> = points.iter().map(|&p| Aabb3 { min: p, max: p }).collect();
        Ok(Self { tree: AabbTree::new(&boxes)?, points: points.to_vec() })
    }

    /// Moves the points (same count) and refits.
    pub fn refit(&mut self, points: &[DVec3]) -> Result<(), SpatialError> {
        let boxes: Vec<Aabb3> = points.iter().map(|&p| Aabb3 { min: p, max: p }).collect();
        self.tree.refit(&boxes)?;
        self.points.copy_from_slice(points);
        Ok(())
    }

    /// The points, in input order.
    pub fn points(&self) -> &[DVec3] {
        &self.points
    }

    /// Calls `f(index, squared distance)` for every point with `|p − center| ≤ radius`.
    pub fn for_each_within_radius(&self, center: DVec3, radius: f64, mut f: impl FnMut(u32, f64)) {
        let r2 = radius * radius;
        self.tree.for_each_within_distance(center, radius, |i, _| {
            let d2 = (self.points[i as usize] - center).length_squared();
            if d2 <= r2 {
                f(i, d2);
            }
        });
    }

    /// Indices of the points with `|p − center| ≤ radius`, sorted, written to `out`.
    pub fn within_radius(&self, center: DVec3, radius: f64, out: &mut Vec<u32>) {
        out.clear();
        self.for_each_within_radius(center, radius, |i, _| out.push(i));
        out.sort_unstable();
    }

    /// The point nearest to `p` and its distance (smallest index among ties); `None` if empty.
    pub fn nearest(&self, p: DVec3) -> Option<(u32, f64)> {
        if !p.is_finite() {
            return None;
        }
        // Nearer boxes first, pruning those farther than the best point (widened: the answer's
        // box is never pruned, so ties go to the smallest index whatever the tree's shape).
        let mut best: Option<(f64, u32)> = None;
        let key = |node: &Node| Some(box_distance_squared(node.min, node.max, p));
        let hopeless = |best: &Option<(f64, u32)>, d2_box: f64| best.is_some_and(|(d2, _)| d2_box > d2 * (1.0 + 1e-12));
        self.tree.bvh.branch_and_bound(&mut best, key, hopeless, |best, i| {
            let d2 = (self.points[i as usize] - p).length_squared();
            if best.is_none_or(|(bd, bi)| d2.total_cmp(&bd).then(i.cmp(&bi)).is_lt()) {
                *best = Some((d2, i));
            }
        });
        best.map(|(d2, i)| (i, d2.sqrt()))
    }
}

/// A crossing of a query segment with a stored 2D segment.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Segment2Hit {
    /// Index of the stored segment.
    pub segment: u32,
    /// Position along the query segment, in [0, 1].
    pub s: f64,
    /// Position along the stored segment, in [0, 1] (0 at its first point).
    pub t: f64,
}

/// A BVH over 2D segments with exact crossing queries.
#[derive(Clone, Debug)]
pub struct SegmentTree2 {
    tree: AabbTree,
    segments: Vec<[DVec2; 2]>,
}

fn segment_box(s: &[DVec2; 2]) -> Aabb3 {
    let (lo, hi) = (s[0].min(s[1]), s[0].max(s[1]));
    Aabb3 { min: lo.extend(0.0), max: hi.extend(0.0) }
}

impl SegmentTree2 {
    /// Builds the tree over finite segments.
    pub fn new(segments: &[[DVec2; 2]]) -> Result<Self, SpatialError> {
        let boxes: Vec<Aabb3> = segments.iter().map(segment_box).collect();
        Ok(Self { tree: AabbTree::new(&boxes)?, segments: segments.to_vec() })
    }

    /// Moves the segments (same count) and refits.
    pub fn refit(&mut self, segments: &[[DVec2; 2]]) -> Result<(), SpatialError> {
        let boxes: Vec<Aabb3> = segments.iter().map(segment_box).collect();
        self.tree.refit(&boxes)?;
        self.segments.copy_from_slice(segments);
        Ok(())
    }

    /// The segments, in input order.
    pub fn segments(&self) -> &[[DVec2; 2]] {
        &self.segments
    }

    /// Calls `f` for every crossing of the query segment `[p, q]` with a stored segment, in tree
    /// order. Exact; a query through a shared endpoint of stored segments crosses exactly one of
    /// them when it passes through their chain, collinear overlaps are not crossings (the query is
    /// perturbed as `p + η_p (1, ε)`, `q + η_q (1, ε)`, `η_q ≪ η_p`).
    pub fn for_each_crossing(&self, p: DVec2, q: DVec2, mut f: impl FnMut(Segment2Hit)) {
        // The 3D probe in the plane z = 0 (the boxes are flat there).
        let probe = SegmentProbe::new(p.extend(0.0), q.extend(0.0));
        self.tree.bvh.traverse(|_, node| {
            if probe.clip(node.min, node.max).is_none() {
                return Visit::Prune;
            }
            if let Some(i) = node.item() {
                let [u, v] = self.segments[i as usize];
                if let Some(c) = segment_segment_2d(p, q, u, v) {
                    f(Segment2Hit { segment: i, s: c.s, t: c.t });
                }
            }
            Visit::Continue
        });
    }

    /// All crossings of `[p, q]`, sorted along the query then by segment index, written to `out`.
    pub fn crossings(&self, p: DVec2, q: DVec2, out: &mut Vec<Segment2Hit>) {
        out.clear();
        self.for_each_crossing(p, q, |h| out.push(h));
        out.sort_unstable_by(|x, y| x.s.total_cmp(&y.s).then(x.segment.cmp(&y.segment)));
    }

    /// [`Self::crossings`] for each query segment `[p, q]`, in parallel; results in input order.
    pub fn crossings_batch(&self, queries: &[[DVec2; 2]]) -> Batch<Segment2Hit> {
        Batch::gather(queries, |&[p, q], out| self.crossings(p, q, out))
    }

    /// Stored segments whose box overlaps the 2D box `[min, max]`, sorted, written to `out`.
    pub fn overlapping(&self, min: DVec2, max: DVec2, out: &mut Vec<u32>) {
        self.tree.overlapping(&Aabb3 { min: min.extend(0.0), max: max.extend(0.0) }, out);
    }
}

/// Coordinates in a plane orthogonal to a direction d̂ (the "plane orthogonal to d̂" of thesis
/// §4.2.2), with a basis that depends only on d̂ so that every projection is reproducible.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProjectionPlane {
    /// First basis vector (unit, orthogonal to d̂).
    pub u: DVec3,
    /// Second basis vector, `d̂ × u`, so that `(u, v, d̂)` is right-handed: 2D orientations are
    /// counter-clockwise when seen from the tip of d̂.
    pub v: DVec3,
}

impl ProjectionPlane {
    /// The plane orthogonal to `d` (normalized here); `None` if `d` is zero or not finite.
    pub fn new(d: DVec3) -> Option<Self> {
        let d = d.try_normalize()?;
        // The axis least aligned with d gives a well-conditioned first basis vector.
        let a = d.abs();
        let axis = if a.x <= a.y && a.x <= a.z {
            DVec3::X
        } else if a.y <= a.z {
            DVec3::Y
        } else {
            DVec3::Z
        };
        let u = axis.cross(d).normalize();
        Some(Self { u, v: d.cross(u) })
    }

    /// 2D coordinates of `p` in the plane.
    #[inline]
    pub fn project(&self, p: DVec3) -> DVec2 {
        DVec2::new(p.dot(self.u), p.dot(self.v))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::Lcg;

    fn lcg(seed: u64) -> impl FnMut() -> f64 {
        let mut lcg = Lcg::from_state(seed);
        move || lcg.next_signed()
    }

    #[test]
    fn box_tree_overlap_and_distance_queries_match_brute_force() {
        let mut rnd = lcg(3);
        let boxes: Vec<Aabb3> = (0..500)
            .map(|_| {
                let c = DVec3::new(rnd(), rnd(), rnd()) * 5.0;
                let h = DVec3::new(rnd().abs(), rnd().abs(), rnd().abs()) * 0.4;
                Aabb3 { min: c - h, max: c + h }
            })
            .collect();
        let tree = AabbTree::new(&boxes).unwrap();
        let query = Aabb3 { min: DVec3::splat(-1.0), max: DVec3::new(2.0, 1.0, 0.5) };
        let mut got = Vec::new();
        tree.overlapping(&query, &mut got);
        let expected: Vec<u32> = (0..500).filter(|&i| boxes[i].intersects(&query)).map(|i| i as u32).collect();
        assert!(!expected.is_empty());
        assert_eq!(got, expected);
        let p = DVec3::new(0.5, -0.5, 1.0);
        tree.within_distance(p, 1.5, &mut got);
        let expected: Vec<u32> = (0..500)
            .filter(|&i| box_distance_squared(boxes[i].min, boxes[i].max, p) <= 2.25)
            .map(|i| i as u32)
            .collect();
        assert_eq!(got, expected);
        let pairs = tree.self_overlapping_pairs();
        let mut brute = Vec::new();
        for i in 0..500 {
            for j in i + 1..500 {
                if boxes[i].intersects(&boxes[j]) {
                    brute.push([i as u32, j as u32]);
                }
            }
        }
        assert_eq!(pairs, brute);
        assert!(AabbTree::new(&[Aabb3::EMPTY]).is_err());
    }

    #[test]
    fn point_tree_radius_and_nearest() {
        let mut rnd = lcg(9);
        let points: Vec<DVec3> = (0..2000).map(|_| DVec3::new(rnd(), rnd(), rnd())).collect();
        let mut tree = PointTree::new(&points).unwrap();
        let c = DVec3::new(0.1, 0.2, -0.3);
        let mut got = Vec::new();
        tree.within_radius(c, 0.3, &mut got);
        let expected: Vec<u32> = (0..2000).filter(|&i| (points[i] - c).length() <= 0.3).map(|i| i as u32).collect();
        assert!(expected.len() > 5);
        assert_eq!(got, expected);
        let (i, d) = tree.nearest(c).unwrap();
        let brute = (0..2000).min_by(|&a, &b| (points[a] - c).length().total_cmp(&(points[b] - c).length())).unwrap();
        assert_eq!(i as usize, brute);
        assert_eq!(d, (points[brute] - c).length());
        // Refit after a translation.
        let moved: Vec<DVec3> = points.iter().map(|p| *p + DVec3::X).collect();
        tree.refit(&moved).unwrap();
        tree.within_radius(c + DVec3::X, 0.3, &mut got);
        assert_eq!(got, expected);
        // Duplicate points tie: smallest index.
        let dup = PointTree::new(&[DVec3::ONE, DVec3::ZERO, DVec3::ZERO]).unwrap();
        assert_eq!(dup.nearest(DVec3::splat(-0.1)).unwrap().0, 1);
    }

    #[test]
    fn segment_tree_crossings_through_a_polyline_vertex_count_once() {
        // A closed square polygon: a line through it crosses it exactly twice, even through
        // corners or along sides.
        let corners = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(1.0, 1.0), DVec2::new(0.0, 1.0)];
        let segments: Vec<[DVec2; 2]> = (0..4).map(|k| [corners[k], corners[(k + 1) % 4]]).collect();
        let tree = SegmentTree2::new(&segments).unwrap();
        let mut hits = Vec::new();
        for (p, q) in [
            (DVec2::new(-1.0, 0.5), DVec2::new(2.0, 0.5)),
            (DVec2::new(-1.0, -1.0), DVec2::new(2.0, 2.0)), // through two corners
            (DVec2::new(-1.0, 0.0), DVec2::new(2.0, 0.0)),  // along a side
            (DVec2::new(0.5, -1.0), DVec2::new(0.5, 2.0)),
            (DVec2::new(1.0, -1.0), DVec2::new(1.0, 2.0)),
        ] {
            tree.crossings(p, q, &mut hits);
            assert_eq!(hits.len() % 2, 0, "{p} {q}: {hits:?}");
            for h in &hits {
                let [u, v] = segments[h.segment as usize];
                assert!((p + h.s * (q - p) - (u + h.t * (v - u))).length() < 1e-15);
            }
        }
        tree.crossings(DVec2::new(-1.0, 0.5), DVec2::new(2.0, 0.5), &mut hits);
        assert_eq!(hits.len(), 2);
        let batch = tree.crossings_batch(&[
            [DVec2::new(-1.0, 0.5), DVec2::new(2.0, 0.5)],
            [DVec2::new(5.0, 5.0), DVec2::new(6.0, 5.0)],
        ]);
        assert_eq!(batch.get(0), &hits[..]);
        assert!(batch.get(1).is_empty() && batch.len() == 2);
        assert_eq!(hits[0].segment, 3);
        assert!((hits[0].s - 1.0 / 3.0).abs() < 1e-15);
        // From the inside to the outside: one crossing, whatever the exit point.
        for q in [DVec2::new(2.0, 0.5), DVec2::new(2.0, 2.0), DVec2::new(1.0, -1.0)] {
            tree.crossings(DVec2::new(0.5, 0.5), q, &mut hits);
            assert_eq!(hits.len(), 1, "{q}: {hits:?}");
        }
    }

    #[test]
    fn projection_plane_is_orthonormal_and_right_handed() {
        for d in [DVec3::Z, DVec3::new(0.3, -2.0, 0.1), DVec3::new(-1.0, 1.0, 1.0)] {
            let plane = ProjectionPlane::new(d).unwrap();
            let dn = d.normalize();
            assert!(plane.u.dot(dn).abs() < 1e-15 && plane.v.dot(dn).abs() < 1e-15);
            assert!((plane.u.cross(plane.v) - dn).length() < 1e-15);
            let p = DVec3::new(0.4, 0.5, -0.6);
            let back = plane.u * plane.project(p).x + plane.v * plane.project(p).y + dn * p.dot(dn);
            assert!((back - p).length() < 1e-15);
        }
        assert!(ProjectionPlane::new(DVec3::ZERO).is_none());
    }
}
