//! Queries on a [`TriangleBvh`]: segment and ray crossings (all, nearest, farthest), triangles in a
//! box or within a distance, and the closest point of the mesh.
//!
//! - Segment crossings serve the edge/face collision detection of thesis §4.1: "we search for all
//!   the faces intersecting an edge, but we only keep the closest face of each extremity". Hits
//!   are sorted along the segment, so these are the first and the last hit.
//! - The farthest ray hit is the matching of §4.2.2: "casting rays along d̂ (resp. −d̂) … and
//!   finding the most distant point on the opposite mesh"; the nearest hit is the usual ray cast.
//! - The closest point gives penetration depths (quality measure of the architecture notes).
//!
//! Every crossing is decided by the exact, symbolically perturbed test of `exact.rs`, so a query
//! through a shared edge or vertex reports one crossing (see the module docs of [`super`]).
//! Traversals keep their stack in a fixed array on the call stack ([`super::flat_bvh`]), so single
//! queries do not allocate unless they return a `Vec`.
//!
//! Determinism: hit lists are sorted by (parameter, face id); nearest/farthest/closest results
//! break ties by the smallest face id. Nearest and farthest crossings and the closest point take
//! one depth-first pass that visits the more promising child first, keeps the best (value, face
//! id) so far and prunes the boxes that cannot beat it (conservatively widened), so the answer
//! does not depend on the shape of the tree (timings: `docs/speed.md`).

use glam::DVec3;

use super::bvh::{SegmentProbe, TriangleBvh, box_distance_squared};
use super::closest::{barycentric_point, closest_point_on_triangle};
use super::exact::{Crossing, segment_triangle};
use super::flat_bvh::{Node, Visit};
use crate::mesh::Aabb3;
use crate::stage::Work;

/// A crossing of a query segment or ray with a triangle of the tree.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Hit {
    /// Face id in the mesh the tree was built from.
    pub face: u32,
    /// Segment queries: position along the segment in [0, 1] (0 at its start). Ray queries: the
    /// ray parameter, `point ≈ origin + t·dir` (the distance when `dir` is a unit vector).
    pub t: f64,
    /// Barycentric coordinates of the crossing on the face's corners, in the face's corner order.
    pub bary: [f64; 3],
    /// The crossing point, computed from `bary` on the face (so it lies on the mesh exactly up to
    /// round-off, which is what later stages that store barycentrics need).
    pub point: DVec3,
    /// The query passes from the face's front (the side its counter-clockwise normal points to) to
    /// its back: for a closed outward-oriented mesh, it enters the solid.
    pub entering: bool,
}

/// A ray `origin + t·dir` for `t ∈ [0, max_t]`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Ray {
    pub origin: DVec3,
    /// Direction; need not be unit length (hit parameters are then in units of `|dir|`).
    pub dir: DVec3,
    /// Largest parameter; `f64::INFINITY` for an unbounded ray.
    pub max_t: f64,
}

impl Ray {
    /// An unbounded ray.
    pub fn new(origin: DVec3, dir: DVec3) -> Self {
        Self { origin, dir, max_t: f64::INFINITY }
    }

    /// The same ray limited to `t ≤ max_t`.
    pub fn with_max_t(self, max_t: f64) -> Self {
        Self { max_t, ..self }
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + t * self.dir
    }
}

/// A triangle a segment crossed ([`TriangleBvh::segment_crossing_hint`]): the next, nearby
/// segment tries it first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CrossingHint(u32);

/// The closest point of a mesh to a query point.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ClosestPoint {
    /// Face id of the face holding the closest point (smallest id among ties).
    pub face: u32,
    /// Barycentric coordinates on that face.
    pub bary: [f64; 3],
    /// The closest point.
    pub point: DVec3,
    /// Its distance to the query point.
    pub distance: f64,
}

/// Order used to sort hits: along the query, then by face id.
#[inline]
pub(super) fn hit_order(x: &Hit, y: &Hit) -> std::cmp::Ordering {
    x.t.total_cmp(&y.t).then(x.face.cmp(&y.face))
}

impl TriangleBvh {
    #[inline]
    pub(super) fn make_hit(&self, leaf: usize, c: Crossing, t_scale: f64) -> Hit {
        Hit {
            face: self.faces[leaf],
            t: c.t * t_scale,
            bary: c.bary,
            point: barycentric_point(&self.corners[leaf], c.bary),
            entering: c.entering,
        }
    }

    /// Calls `f` for every crossing of the segment `[a, b]` with the triangles, in tree order (use
    /// [`Self::segment_hits`] for a sorted list). Allocation-free.
    pub fn for_each_segment_hit(&self, a: DVec3, b: DVec3, mut f: impl FnMut(Hit)) {
        self.for_each_crossing(a, b, |leaf, c| f(self.make_hit(leaf, c, 1.0)));
    }

    /// Core traversal: every leaf whose triangle the segment crosses, with the crossing.
    #[inline]
    fn for_each_crossing(&self, a: DVec3, b: DVec3, mut f: impl FnMut(usize, Crossing)) {
        Work::count_queries(1);
        let probe = SegmentProbe::new(a, b);
        self.bvh.traverse(|_, node| {
            if probe.clip(node.min, node.max).is_none() {
                return Visit::Prune;
            }
            if let Some(leaf) = node.item() {
                let leaf = leaf as usize;
                if let Some(c) = segment_triangle(a, b, &self.corners[leaf]) {
                    f(leaf, c);
                }
            }
            Visit::Continue
        });
    }

    /// All crossings of the segment `[a, b]`, written to `out` (cleared first) sorted by position
    /// along the segment, then face id. A segment through a shared edge or vertex of a manifold
    /// surface reports one crossing when it passes through the surface, none or two when it only
    /// grazes it; an endpoint exactly on a face counts as lying on the side `(1, ε, ε²)` points to;
    /// a segment lying in a face's plane does not cross that face. `out` is reused: no allocation
    /// once it has grown.
    pub fn segment_hits(&self, a: DVec3, b: DVec3, out: &mut Vec<Hit>) {
        out.clear();
        self.for_each_segment_hit(a, b, |h| out.push(h));
        out.sort_unstable_by(hit_order);
    }

    /// Number of crossings of the segment `[a, b]` (same rule as [`Self::segment_hits`]).
    pub fn segment_crossing_count(&self, a: DVec3, b: DVec3) -> usize {
        let mut n = 0;
        self.for_each_crossing(a, b, |_, _| n += 1);
        n
    }

    /// The ray as a segment `[origin, far]` long enough to cross the whole tree, and the ray
    /// parameter of `far`. `None` if the ray is empty or cannot reach the tree.
    pub(super) fn ray_as_segment(&self, ray: &Ray) -> Option<(DVec3, f64)> {
        if self.is_empty() || ray.max_t.is_nan() || ray.max_t < 0.0 || !ray.origin.is_finite() || !ray.dir.is_finite() {
            return None;
        }
        let len = ray.dir.length();
        if len == 0.0 || !len.is_finite() {
            return None;
        }
        // No point of the tree's box is farther from the origin than its farthest corner, so the
        // segment to 1.5 times that distance reaches past every triangle.
        let (lo, hi) = (self.bounds.min, self.bounds.max);
        let far_corner = (ray.origin - lo).abs().max((ray.origin - hi).abs()).length();
        let t_far = (1.5 * far_corner / len).min(ray.max_t);
        if t_far.is_nan() || t_far <= 0.0 || !t_far.is_finite() {
            return None;
        }
        Some((ray.at(t_far), t_far))
    }

    /// Calls `f` for every crossing of the ray (same rule as [`Self::segment_hits`]; the origin is
    /// the segment's start), in tree order. Allocation-free.
    pub fn for_each_ray_hit(&self, ray: &Ray, mut f: impl FnMut(Hit)) {
        if let Some((far, t_far)) = self.ray_as_segment(ray) {
            self.for_each_crossing(ray.origin, far, |leaf, c| f(self.make_hit(leaf, c, t_far)));
        }
    }

    /// All crossings of the ray, written to `out` (cleared first) sorted by ray parameter, then
    /// face id.
    pub fn ray_hits(&self, ray: &Ray, out: &mut Vec<Hit>) {
        out.clear();
        self.for_each_ray_hit(ray, |h| out.push(h));
        out.sort_unstable_by(hit_order);
    }

    /// The first crossing along the ray (smallest parameter, then smallest face id).
    pub fn ray_nearest(&self, ray: &Ray) -> Option<Hit> {
        let (far, t_far) = self.ray_as_segment(ray)?;
        self.extreme_crossing(ray.origin, far, false).map(|(leaf, c)| self.make_hit(leaf, c, t_far))
    }

    /// The last crossing along the ray (largest parameter, then smallest face id): the "most
    /// distant point on the opposite mesh" of the mapping (thesis §4.2.2).
    pub fn ray_farthest(&self, ray: &Ray) -> Option<Hit> {
        let (far, t_far) = self.ray_as_segment(ray)?;
        self.extreme_crossing(ray.origin, far, true).map(|(leaf, c)| self.make_hit(leaf, c, t_far))
    }

    /// The first crossing along the segment `[a, b]` (smallest position, then face id).
    pub fn segment_nearest(&self, a: DVec3, b: DVec3) -> Option<Hit> {
        self.extreme_crossing(a, b, false).map(|(leaf, c)| self.make_hit(leaf, c, 1.0))
    }

    /// The last crossing along the segment `[a, b]` (largest position, then smallest face id).
    pub fn segment_farthest(&self, a: DVec3, b: DVec3) -> Option<Hit> {
        self.extreme_crossing(a, b, true).map(|(leaf, c)| self.make_hit(leaf, c, 1.0))
    }

    /// Nearest (or farthest) crossing of `[a, b]`, ties to the smallest face id.
    ///
    /// One depth-first pass that keeps the best crossing so far and prunes the boxes lying
    /// entirely beyond it (before it, for the farthest). Children are visited in the order that
    /// reaches the answer first (the one entered first, or left last), so the best crossing is
    /// usually found at the first leaves and most of the tree is pruned. The best crossing is
    /// unique under the total order (t, face id), and the clipped box intervals are conservative,
    /// so the box of the answer is never pruned: the result does not depend on the tree's shape or
    /// on the order of the visit.
    fn extreme_crossing(&self, a: DVec3, b: DVec3, farthest: bool) -> Option<(usize, Crossing)> {
        Work::count_queries(1);
        let probe = SegmentProbe::new(a, b);
        let mut best: Option<(usize, Crossing)> = None;
        // A node's key: where the answer could be in its clipped interval, smaller is better
        // (the end of the interval for the farthest crossing, negated).
        let key = |node: &Node| probe.clip(node.min, node.max).map(|(lo, hi)| if farthest { -hi } else { lo });
        let hopeless = |best: &Option<(usize, Crossing)>, key: f64| match best {
            Some((_, bc)) => (farthest && -key < bc.t) || (!farthest && key > bc.t),
            None => false,
        };
        self.bvh.branch_and_bound(&mut best, key, hopeless, |best, leaf| {
            let leaf = leaf as usize;
            if let Some(c) = segment_triangle(a, b, &self.corners[leaf]) {
                let better = match best {
                    None => true,
                    Some((bl, bc)) => {
                        let by_t = if farthest { c.t.total_cmp(&bc.t).reverse() } else { c.t.total_cmp(&bc.t) };
                        by_t.then(self.faces[leaf].cmp(&self.faces[*bl])).is_lt()
                    }
                };
                if better {
                    *best = Some((leaf, c));
                }
            }
        });
        best
    }

    /// True if the segment `[a, b]` crosses the mesh at least once (same rule as
    /// [`Self::segment_hits`]); stops at the first crossing found.
    pub fn segment_crosses(&self, a: DVec3, b: DVec3) -> bool {
        self.segment_crossing_hint(a, b, None).is_some()
    }

    /// [`Self::segment_crosses`] for a run of nearby segments: `hint` is what the previous query
    /// returned (`None` at the start). A segment that crosses the triangle another one crossed
    /// is answered by that one exact test, without a traversal; the answer (`is_some`) is the
    /// same as [`Self::segment_crosses`] whatever the hint, since a triangle the segment crosses
    /// always lies in boxes the traversal would visit. Returns an opaque hint for the next query:
    /// `Some` exactly when the segment crosses the mesh.
    pub fn segment_crossing_hint(&self, a: DVec3, b: DVec3, hint: Option<CrossingHint>) -> Option<CrossingHint> {
        Work::count_queries(1);
        if let Some(CrossingHint(leaf)) = hint
            && let Some(corners) = self.corners.get(leaf as usize)
            && segment_triangle(a, b, corners).is_some()
        {
            return hint;
        }
        let probe = SegmentProbe::new(a, b);
        let mut found = None;
        self.bvh.traverse(|_, node| {
            if probe.clip(node.min, node.max).is_none() {
                return Visit::Prune;
            }
            if let Some(leaf) = node.item()
                && segment_triangle(a, b, &self.corners[leaf as usize]).is_some()
            {
                found = Some(CrossingHint(leaf));
                return Visit::Stop;
            }
            Visit::Continue
        });
        found
    }

    /// Calls `f` with the face id of every triangle whose bounding box overlaps `query` (touching
    /// counts), in tree order.
    pub fn for_each_face_in_box(&self, query: &Aabb3, mut f: impl FnMut(u32)) {
        Work::count_queries(1);
        self.bvh.for_each_in_box(query.min, query.max, |leaf| f(self.faces[leaf as usize]));
    }

    /// Face ids of the triangles whose bounding box overlaps `query`, sorted, written to `out`.
    pub fn faces_in_box(&self, query: &Aabb3, out: &mut Vec<u32>) {
        out.clear();
        self.for_each_face_in_box(query, |f| out.push(f));
        out.sort_unstable();
    }

    /// Face ids of the triangles at distance ≤ `radius` from `p` (exact closest-point distance),
    /// sorted, written to `out`.
    pub fn faces_within(&self, p: DVec3, radius: f64, out: &mut Vec<u32>) {
        self.leaves_within(p, radius, out);
        for leaf in out.iter_mut() {
            *leaf = self.faces[*leaf as usize];
        }
    }

    /// The leaves (indices into [`Self::faces`], see [`Self::leaf_corners`]) of the triangles at
    /// distance ≤ `radius` from `p`, sorted by face id: [`Self::faces_within`] without a search
    /// for each face's corners in a tree over some of a mesh's faces.
    pub fn leaves_within(&self, p: DVec3, radius: f64, out: &mut Vec<u32>) {
        Work::count_queries(1);
        out.clear();
        if !p.is_finite() {
            return;
        }
        let r2 = radius * radius;
        self.bvh.traverse(|_, node| {
            if box_distance_squared(node.min, node.max, p) > r2 || r2.is_nan() {
                return Visit::Prune;
            }
            if let Some(leaf) = node.item() {
                let t = &self.corners[leaf as usize];
                if (barycentric_point(t, closest_point_on_triangle(p, t)) - p).length_squared() <= r2 {
                    out.push(leaf);
                }
            }
            Visit::Continue
        });
        out.sort_unstable_by_key(|&leaf| self.faces[leaf as usize]);
    }

    /// The closest point of the mesh to `p` (`None` only for an empty tree).
    pub fn closest_point(&self, p: DVec3) -> Option<ClosestPoint> {
        self.closest_point_within(p, f64::INFINITY)
    }

    /// The closest point of the mesh to `p` if it is at distance ≤ `max_distance`.
    pub fn closest_point_within(&self, p: DVec3, max_distance: f64) -> Option<ClosestPoint> {
        Work::count_queries(1);
        if !p.is_finite() || max_distance.is_nan() || max_distance < 0.0 {
            return None;
        }
        let leaf_distance = |leaf: usize| {
            let t = &self.corners[leaf];
            let bary = closest_point_on_triangle(p, t);
            let point = barycentric_point(t, bary);
            ((point - p).length_squared(), bary, point)
        };
        // One pass, nearer child first, pruning the boxes farther than the best leaf so far.
        // Box distances carry round-off: a box is pruned only when it is farther than the best
        // distance widened by far more than that, so the answer's box is never pruned and the
        // minimum by (distance, face id) does not depend on the tree's shape.
        let max_d2 = max_distance * max_distance;
        let mut best: Option<(f64, u32, [f64; 3], DVec3)> = None;
        let hopeless = |best: &Option<(f64, u32, [f64; 3], DVec3)>, d2_box: f64| {
            d2_box > best.map_or(max_d2, |(d2, ..)| d2) * (1.0 + 1e-12)
        };
        let key = |node: &Node| Some(box_distance_squared(node.min, node.max, p));
        self.bvh.branch_and_bound(&mut best, key, hopeless, |best, leaf| {
            let leaf = leaf as usize;
            let (d2, bary, point) = leaf_distance(leaf);
            let face = self.faces[leaf];
            if best.is_none_or(|(bd, bf, _, _)| d2.total_cmp(&bd).then(face.cmp(&bf)).is_lt()) {
                *best = Some((d2, face, bary, point));
            }
        });
        let (d2, face, bary, point) = best?;
        (d2 <= max_d2).then(|| ClosestPoint { face, bary, point, distance: d2.sqrt() })
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::Lcg;
    use crate::mesh::{TriMesh, shapes};

    fn brute_force_hits(mesh: &TriMesh, a: DVec3, b: DVec3) -> Vec<(u32, f64)> {
        let mut v: Vec<(u32, f64)> = (0..mesh.num_triangles())
            .filter_map(|f| segment_triangle(a, b, &mesh.corners(f)).map(|c| (f as u32, c.t)))
            .collect();
        v.sort_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)));
        v
    }

    #[test]
    fn segment_through_a_sphere_hits_twice_on_the_mesh_and_near_the_sphere() {
        let r = 1.0;
        let level = 4;
        let mesh = shapes::icosphere(r, level);
        let tree = TriangleBvh::new(&mesh).unwrap();
        // Chord error of an icosphere: the sagitta of its longest edge.
        let max_edge = mesh
            .triangles
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .fold(0.0f64, |m, (i, j)| m.max((mesh.positions[i as usize] - mesh.positions[j as usize]).length()));
        let sagitta = r - (r * r - max_edge * max_edge / 4.0).sqrt();
        let mut hits = Vec::new();
        for (a, b) in [
            (DVec3::new(-2.0, 0.1, 0.2), DVec3::new(2.0, 0.1, 0.2)),
            (DVec3::new(0.3, -3.0, -0.4), DVec3::new(-0.2, 2.5, 0.3)),
            (DVec3::new(0.0, 0.0, -2.0), DVec3::new(0.0, 0.0, 2.0)),
        ] {
            tree.segment_hits(a, b, &mut hits);
            assert_eq!(hits.len(), 2, "{a} {b}: {hits:?}");
            assert!(hits[0].entering && !hits[1].entering);
            assert!(hits[0].t < hits[1].t);
            for h in &hits {
                let on_segment = a + h.t * (b - a);
                let corners = mesh.corners(h.face as usize);
                let on_triangle = barycentric_point(&corners, h.bary);
                assert!((on_segment - on_triangle).length() < 1e-12, "{on_segment} {on_triangle}");
                assert!((h.point - on_triangle).length() == 0.0);
                assert!(h.bary.iter().all(|&x| (0.0..=1.0).contains(&x)));
                // Inside the sphere, outside the inscribed polyhedron's inner sphere.
                let radius = on_triangle.length();
                assert!(radius <= r + 1e-12 && radius >= r - sagitta - 1e-12, "{radius}");
            }
            let brute = brute_force_hits(&mesh, a, b);
            assert_eq!(brute, hits.iter().map(|h| (h.face, h.t)).collect::<Vec<_>>());
        }
    }

    #[test]
    fn segments_through_grid_edges_and_vertices_cross_exactly_once() {
        // A 4 × 4 grid of unit cells in z = 0, triangulated along alternating diagonals.
        let mesh = shapes::grid(4.0, 4.0, 4, 4);
        let tree = TriangleBvh::new(&mesh).unwrap();
        let mut hits = Vec::new();
        let mut cases = Vec::new();
        // Through every vertex and every edge midpoint (including diagonals), vertically and
        // obliquely, in both directions.
        for j in 0..=8 {
            for i in 0..=8 {
                let p = DVec3::new(-2.0 + 0.5 * i as f64, -2.0 + 0.5 * j as f64, 0.0);
                for d in [DVec3::Z, DVec3::new(0.3, -0.2, 1.0), DVec3::new(1.0, 1.0, 1.0), DVec3::new(-1.0, 0.0, 1.0)] {
                    cases.push((p + d, p - d));
                    cases.push((p - d, p + d));
                }
            }
        }
        for (a, b) in cases {
            let p = 0.5 * (a + b);
            let on_boundary = p.x.abs() == 2.0 || p.y.abs() == 2.0;
            tree.segment_hits(a, b, &mut hits);
            if on_boundary {
                assert!(hits.len() <= 1, "{a} {b}: {hits:?}");
            } else {
                assert_eq!(hits.len(), 1, "{a} {b}: {hits:?}");
                let h = hits[0];
                assert!((h.t - 0.5).abs() < 1e-15);
                assert!((h.point - p).length() < 1e-15, "{} {p}", h.point);
                assert_eq!(h.entering, a.z > 0.0);
            }
        }
        // Segments in the grid's plane never cross it, even along its edges.
        tree.segment_hits(DVec3::new(-3.0, 0.0, 0.0), DVec3::new(3.0, 0.0, 0.0), &mut hits);
        assert!(hits.is_empty());
        tree.segment_hits(DVec3::new(-3.0, -3.0, 0.0), DVec3::new(3.0, 3.0, 0.0), &mut hits);
        assert!(hits.is_empty());
    }

    #[test]
    fn segments_through_the_vertices_of_a_sphere_cross_once_per_passage() {
        // [2v, 0] passes exactly through the vertex v (t = ½ is exact), where 5 or 6 faces meet
        // at different angles: one crossing, entering. [2v, −2v] also leaves through −v (also a
        // vertex, the icosphere being symmetric): two crossings.
        let mesh = shapes::icosphere(1.0, 3);
        let tree = TriangleBvh::new(&mesh).unwrap();
        let mut hits = Vec::new();
        for &v in &mesh.positions {
            tree.segment_hits(2.0 * v, DVec3::ZERO, &mut hits);
            assert_eq!(hits.len(), 1, "{v}: {hits:?}");
            assert!(hits[0].entering);
            assert_eq!(hits[0].point, v);
            assert_eq!(hits[0].bary.iter().filter(|&&b| b == 1.0).count(), 1);
            tree.segment_hits(2.0 * v, -2.0 * v, &mut hits);
            assert_eq!(hits.len(), 2, "{v}: {hits:?}");
            assert!(hits[0].entering && !hits[1].entering);
        }
        // Through edge midpoints (rounded, so near-degenerate rather than exact): still one.
        for t in &mesh.triangles {
            let m = 0.5 * (mesh.positions[t[0] as usize] + mesh.positions[t[1] as usize]);
            assert_eq!(tree.segment_crossing_count(3.0 * m, DVec3::ZERO), 1);
        }
    }

    /// A closed capsule with bumps: many crossings, some through shared vertices and edges.
    fn bumpy_capsule() -> TriMesh {
        let mut mesh = shapes::capsule(0.5, 1.5, 24, 8, 12);
        mesh.map_positions(|p| p + 0.1 * DVec3::new((7.0 * p.z).sin(), (5.0 * p.x).cos(), 0.0));
        mesh
    }

    #[test]
    fn nearest_farthest_and_any_crossing_agree_with_the_sorted_hit_list() {
        // Segments through a bumpy closed surface (many crossings, some through shared vertices
        // and edges of the grid-like capsule): the one-pass nearest/farthest searches must return
        // exactly the first/last of the sorted list, and `segment_crosses` its non-emptiness.
        let mesh = bumpy_capsule();
        let tree = TriangleBvh::new(&mesh).unwrap();
        let mut lcg = Lcg::from_state(12345);
        let mut next = || lcg.next_unit() * 3.0 - 1.5;
        let mut hits = Vec::new();
        let mut vertex_segments: Vec<(DVec3, DVec3)> =
            mesh.positions.iter().step_by(7).map(|&v| (2.0 * v, -1.5 * v + DVec3::new(0.0, 0.0, 0.3))).collect();
        vertex_segments
            .extend((0..400).map(|_| (DVec3::new(next(), next(), next()), DVec3::new(next(), next(), next()))));
        for (a, b) in vertex_segments {
            tree.segment_hits(a, b, &mut hits);
            assert_eq!(tree.segment_nearest(a, b), hits.first().copied());
            assert_eq!(tree.segment_farthest(a, b), hits.last().copied());
            assert_eq!(tree.segment_crosses(a, b), !hits.is_empty());
        }
    }

    #[test]
    fn a_crossing_hint_never_changes_the_answer() {
        // Runs of nearby segments (the visibility test's pattern) with the previous answer as the
        // hint, and every segment again with hints from unrelated triangles: always the answer
        // of `segment_crosses`, `Some` exactly when it is true, naming a triangle crossed.
        let mesh = bumpy_capsule();
        let tree = TriangleBvh::new(&mesh).unwrap();
        let mut lcg = Lcg::from_state(777);
        let mut next = || lcg.next_unit() * 3.0 - 1.5;
        let segments: Vec<(DVec3, DVec3)> = (0..300)
            .map(|k| {
                let a = DVec3::new(0.01 * k as f64 - 1.5, 0.2, 0.4 * (0.1 * k as f64).sin());
                (a, a + DVec3::new(0.2, -3.0, 0.1))
            })
            .chain((0..300).map(|_| (DVec3::new(next(), next(), next()), DVec3::new(next(), next(), next()))))
            .collect();
        let mut hint = None;
        let mut reused = 0;
        let mut hits = Vec::new();
        for &(a, b) in &segments {
            let found = tree.segment_crossing_hint(a, b, hint);
            assert_eq!(found.is_some(), tree.segment_crosses(a, b), "{a} {b}");
            if let Some(CrossingHint(leaf)) = found {
                assert!(segment_triangle(a, b, &tree.corners[leaf as usize]).is_some());
                reused += usize::from(found == hint);
            }
            tree.segment_hits(a, b, &mut hits);
            assert_eq!(found.is_some(), !hits.is_empty());
            hint = found.or(hint);
        }
        assert!(reused > 10, "the runs of nearby segments reuse their hint: {reused}");
        for leaf in (0..tree.len() as u32).step_by(37) {
            for &(a, b) in &segments {
                let found = tree.segment_crossing_hint(a, b, Some(CrossingHint(leaf)));
                assert_eq!(found.is_some(), tree.segment_crosses(a, b));
            }
        }
        // A hint of another tree (out of range here) is ignored.
        let (a, b) = segments[0];
        assert_eq!(
            tree.segment_crossing_hint(a, b, Some(CrossingHint(u32::MAX))).is_some(),
            tree.segment_crosses(a, b)
        );
    }

    #[test]
    fn crossing_counts_through_a_closed_box_are_even_along_its_edges() {
        // Rays along the cube's faces, edges and through its corners: the crossing count of a
        // segment whose ends are both outside a closed surface is always even.
        let mesh = shapes::cube(2.0, 2);
        let tree = TriangleBvh::new(&mesh).unwrap();
        for &y in &[-1.0, -0.5, 0.0, 0.5, 1.0] {
            for &z in &[-1.0, -0.5, 0.0, 0.5, 1.0] {
                let (a, b) = (DVec3::new(-3.0, y, z), DVec3::new(3.0, y, z));
                let n = tree.segment_crossing_count(a, b);
                assert_eq!(n % 2, 0, "{a} {b}: {n}");
                let interior = y.abs() < 1.0 && z.abs() < 1.0;
                if interior {
                    assert_eq!(n, 2);
                }
            }
        }
        // Through opposite corners.
        assert_eq!(tree.segment_crossing_count(DVec3::splat(-2.0), DVec3::splat(2.0)), 2);
    }

    #[test]
    fn farthest_hit_of_a_ray_through_a_sphere_is_the_far_side() {
        let mesh = shapes::icosphere(1.0, 3);
        let tree = TriangleBvh::new(&mesh).unwrap();
        let dir = DVec3::new(0.2, -0.1, 1.0).normalize();
        let ray = Ray::new(DVec3::new(0.1, 0.2, -3.0), dir);
        let near = tree.ray_nearest(&ray).unwrap();
        let far = tree.ray_farthest(&ray).unwrap();
        assert!(near.entering && !far.entering);
        assert!(near.point.z < 0.0 && far.point.z > 0.0);
        assert!(far.t > near.t + 1.2); // the chord is ≈ 1.44 long
        assert!((ray.at(far.t) - far.point).length() < 1e-12);
        let mut all = Vec::new();
        tree.ray_hits(&ray, &mut all);
        assert_eq!(all.len(), 2);
        assert_eq!(all[0], near);
        assert_eq!(all[1], far);
        // From inside, the only hit is the exit, both nearest and farthest.
        let inside = Ray::new(DVec3::new(0.1, 0.0, 0.0), dir);
        assert_eq!(tree.ray_nearest(&inside), tree.ray_farthest(&inside));
        assert!(!tree.ray_farthest(&inside).unwrap().entering);
        // Bounded rays stop at max_t; rays pointing away find nothing.
        assert!(tree.ray_nearest(&ray.with_max_t(1.0)).is_none());
        // (A shorter ray is a different segment: parameters agree up to round-off.)
        let cut = tree.ray_farthest(&ray.with_max_t(near.t + 0.1)).unwrap();
        assert_eq!(cut.face, near.face);
        assert!((cut.t - near.t).abs() < 1e-12 && (cut.point - near.point).length() < 1e-12);
        assert!(tree.ray_nearest(&Ray::new(ray.origin, -dir)).is_none());
        assert!(tree.ray_nearest(&Ray::new(ray.origin, DVec3::ZERO)).is_none());
    }

    #[test]
    fn refit_after_a_rigid_translation_translates_the_hits() {
        let mesh = shapes::capsule(0.5, 1.5, 24, 6, 4);
        let mut tree = TriangleBvh::new(&mesh).unwrap();
        let shift = DVec3::new(0.37, -1.25, 2.5);
        let segments: Vec<(DVec3, DVec3)> = (0..50)
            .map(|i| {
                let s = i as f64 * 0.37;
                (DVec3::new(s.sin(), s.cos(), -2.0), DVec3::new(-(s * 1.3).cos(), 0.5 * s.sin(), 2.0))
            })
            .collect();
        let before: Vec<Vec<Hit>> = segments
            .iter()
            .map(|&(a, b)| {
                let mut h = Vec::new();
                tree.segment_hits(a, b, &mut h);
                h
            })
            .collect();
        let moved: Vec<DVec3> = mesh.positions.iter().map(|p| *p + shift).collect();
        tree.refit(&moved).unwrap();
        let mut total = 0;
        for ((a, b), hits) in segments.iter().zip(&before) {
            let mut after = Vec::new();
            tree.segment_hits(*a + shift, *b + shift, &mut after);
            assert_eq!(after.len(), hits.len());
            for (x, y) in hits.iter().zip(&after) {
                assert_eq!(x.face, y.face);
                assert!((x.t - y.t).abs() < 1e-12);
                assert!((x.point + shift - y.point).length() < 1e-12);
            }
            total += hits.len();
        }
        assert!(total > 40);
    }

    #[test]
    fn closest_point_matches_brute_force_and_breaks_ties_by_face_id() {
        let mesh = shapes::icosphere(1.0, 2);
        let tree = TriangleBvh::new(&mesh).unwrap();
        for i in 0..200 {
            let s = i as f64;
            let p = DVec3::new((s * 0.7).sin(), (s * 1.3).cos(), (s * 0.31).sin()) * (0.3 + (i % 7) as f64 * 0.3);
            let cp = tree.closest_point(p).unwrap();
            let brute = (0..mesh.num_triangles())
                .map(|f| {
                    let t = mesh.corners(f);
                    ((barycentric_point(&t, closest_point_on_triangle(p, &t)) - p).length_squared(), f as u32)
                })
                .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)))
                .unwrap();
            assert_eq!(cp.face, brute.1);
            assert!((cp.distance - brute.0.sqrt()).abs() < 1e-15);
        }
        // At a vertex every incident face ties: the smallest id wins.
        let v = mesh.positions[5] * 2.0;
        let cp = tree.closest_point(v).unwrap();
        let smallest = (0..mesh.num_triangles() as u32).find(|&f| mesh.triangles[f as usize].contains(&5)).unwrap();
        assert_eq!(cp.face, smallest);
        assert!(tree.closest_point_within(DVec3::new(5.0, 0.0, 0.0), 1.0).is_none());
        assert!(tree.closest_point_within(DVec3::new(1.5, 0.0, 0.0), 0.6).is_some());
    }

    #[test]
    fn box_and_radius_queries_match_brute_force() {
        let mesh = shapes::icosphere(1.0, 3);
        let tree = TriangleBvh::new(&mesh).unwrap();
        let query = Aabb3 { min: DVec3::new(0.2, -0.3, -1.0), max: DVec3::new(0.9, 0.4, 0.1) };
        let mut got = Vec::new();
        tree.faces_in_box(&query, &mut got);
        let expected: Vec<u32> = (0..mesh.num_triangles())
            .filter(|&f| Aabb3::from_points(mesh.corners(f)).intersects(&query))
            .map(|f| f as u32)
            .collect();
        assert!(!expected.is_empty());
        assert_eq!(got, expected);
        let (p, r) = (DVec3::new(0.5, 0.5, 0.9), 0.4);
        tree.faces_within(p, r, &mut got);
        let expected: Vec<u32> = (0..mesh.num_triangles())
            .filter(|&f| {
                let t = mesh.corners(f);
                (barycentric_point(&t, closest_point_on_triangle(p, &t)) - p).length() <= r
            })
            .map(|f| f as u32)
            .collect();
        assert!(!expected.is_empty());
        assert_eq!(got, expected);
    }

    #[test]
    fn subset_trees_report_mesh_face_ids() {
        let mesh = shapes::icosphere(1.0, 2);
        let upper: Vec<u32> =
            (0..mesh.num_triangles() as u32).filter(|&f| mesh.corners(f as usize).iter().all(|p| p.z > 0.0)).collect();
        let tree = TriangleBvh::with_faces(&mesh, upper.iter().copied()).unwrap();
        let mut hits = Vec::new();
        tree.segment_hits(DVec3::new(0.1, 0.1, -2.0), DVec3::new(0.1, 0.1, 2.0), &mut hits);
        assert_eq!(hits.len(), 1);
        assert!(upper.contains(&hits[0].face));
        let full = TriangleBvh::new(&mesh).unwrap();
        let mut all = Vec::new();
        full.segment_hits(DVec3::new(0.1, 0.1, -2.0), DVec3::new(0.1, 0.1, 2.0), &mut all);
        assert_eq!(all[1], hits[0]);
    }
}
