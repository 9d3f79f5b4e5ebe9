//! [`TriangleBvh`]: a bounding volume hierarchy over a mesh's triangles, built once per working
//! region and refitted when the vertices move.
//!
//! Thesis §4.1, implementation details: "The computation is accelerated by a 3D AABB tree built
//! once for each mesh at the selection of the working regions and then updated at each frame if the
//! surface is animated non-rigidly. This update consists in the refitting of the existing boxes
//! without changing the tree structure." The tree is our [`FlatBvh`] (binned SAH build, which is
//! deterministic: the same boxes give the same tree; one triangle per leaf, leaf `i` is triangle
//! `i` of [`TriangleBvh::faces`]); refitting rewrites the leaf boxes and recomputes the inner boxes
//! bottom-up, so the topology, and with it the traversal order, is kept. The queries themselves
//! live in [`super::queries`]: they visit children in the order that finds their answer first.
//!
//! The tree keeps its own copy of the corner positions of its triangles, so that queries read one
//! contiguous array and cannot be handed a mismatched mesh.

use glam::{BVec3, DVec3};

use super::SpatialError;
use super::flat_bvh::FlatBvh;
use crate::mesh::{Aabb3, MeshError, TriMesh};

/// A BVH over (a subset of) the triangles of a mesh. Results name triangles by their face id in
/// the mesh the tree was built from.
#[derive(Clone, Debug)]
pub struct TriangleBvh {
    pub(super) bvh: FlatBvh,
    /// Leaf `i` is face `faces[i]` of the mesh.
    pub(super) faces: Vec<u32>,
    /// Vertex indices of each leaf's triangle (to refit from new positions).
    pub(super) indices: Vec<[u32; 3]>,
    /// Corner positions of each leaf's triangle.
    pub(super) corners: Vec<[DVec3; 3]>,
    /// Number of vertices of the mesh (refit expects that many positions).
    pub(super) num_vertices: usize,
    /// Box of all the leaves.
    pub(super) bounds: Aabb3,
    /// The vertices the triangles use (increasing) and their positions at the last fit: a refit
    /// to the same positions, bit for bit (a static object's every frame), stops after comparing
    /// them instead of comparing every triangle's corners.
    fitted_vertices: Vec<u32>,
    fitted: Vec<DVec3>,
    /// What a refit of a few moved vertices walks, built at the first such refit.
    links: Option<Box<RefitLinks>>,
}

/// The links a partial refit follows from a moved vertex to the boxes it changes.
#[derive(Clone, Debug)]
struct RefitLinks {
    /// Per node its parent (`u32::MAX`: the root).
    parent: Vec<u32>,
    /// Per leaf its node.
    leaf_node: Vec<u32>,
    /// The leaves using each fitted vertex (position in `fitted_vertices`):
    /// `leaves[offsets[k]..offsets[k + 1]]`.
    offsets: Vec<u32>,
    leaves: Vec<u32>,
    /// Per node, whether the refit under way has it to recompute (all false between refits).
    marked: Vec<bool>,
}

impl RefitLinks {
    fn new(bvh: &FlatBvh, indices: &[[u32; 3]], fitted_vertices: &[u32]) -> Self {
        let (parent, leaf_node) = bvh.parents_and_leaves(indices.len());
        let slot = |v: u32| fitted_vertices.binary_search(&v).unwrap_or(0);
        let mut offsets = vec![0u32; fitted_vertices.len() + 1];
        for tri in indices {
            for &v in tri {
                offsets[slot(v) + 1] += 1;
            }
        }
        for k in 0..fitted_vertices.len() {
            offsets[k + 1] += offsets[k];
        }
        let mut next = offsets.clone();
        let mut leaves = vec![0u32; offsets[fitted_vertices.len()] as usize];
        for (leaf, tri) in indices.iter().enumerate() {
            for &v in tri {
                let k = slot(v);
                leaves[next[k] as usize] = leaf as u32;
                next[k] += 1;
            }
        }
        let marked = vec![false; parent.len()];
        Self { parent, leaf_node, offsets, leaves, marked }
    }
}

/// A refit touching at most one vertex in this many of the tree's follows the moved vertices to
/// their leaves and ancestors; more, and every box is recomputed.
const PARTIAL_REFIT: usize = 4;

/// A partial refit marking more than one node in this many of those it would sweep sweeps them
/// in index order rather than sorting the marked ones.
const SWEEP_DIRTY: usize = 16;

impl TriangleBvh {
    /// Builds the tree over all triangles of `mesh`. Fails on an out-of-range index or a
    /// non-finite coordinate; an empty mesh gives an empty tree (queries find nothing).
    pub fn new(mesh: &TriMesh) -> Result<Self, SpatialError> {
        Self::with_faces(mesh, 0..mesh.triangles.len() as u32)
    }

    /// The tree of `mesh`, a part cut out of the mesh this tree holds (its face `k` is this
    /// tree's face `parent_face[k]`), in this tree's shape ([`FlatBvh::pruned`]) instead of a new
    /// build: a pruned tree is as deep as this one at most and its boxes are `mesh`'s, so every
    /// query answers as on a tree built anew (they do not depend on the shape: closest points by
    /// (distance, face id), crossings and winding numbers exactly); only how many boxes they
    /// visit differs. `None` if a face of `parent_face` is not in this tree once.
    pub fn restricted(&self, mesh: &TriMesh, parent_face: &[u32]) -> Result<Option<Self>, SpatialError> {
        if parent_face.len() != mesh.triangles.len() {
            return Ok(None);
        }
        let mut local = vec![u32::MAX; self.faces.iter().map(|&f| f as usize + 1).max().unwrap_or(0)];
        for (k, &f) in parent_face.iter().enumerate() {
            match local.get_mut(f as usize) {
                Some(slot) if *slot == u32::MAX => *slot = k as u32,
                _ => return Ok(None),
            }
        }
        let mut bvh =
            self.bvh.pruned(|leaf| local.get(self.faces[leaf as usize] as usize).copied().filter(|&k| k != u32::MAX));
        if bvh.nodes().len() != (2 * mesh.triangles.len()).saturating_sub(1) {
            return Ok(None);
        }
        let faces = (0..mesh.triangles.len() as u32).collect();
        Self::with_tree(mesh, faces, |boxes| {
            bvh.refit(|leaf| boxes[leaf as usize]);
            bvh
        })
        .map(Some)
    }

    /// Builds the tree over the given faces of `mesh` (e.g. a working region), reporting results
    /// with these face ids. Duplicate ids are kept (and reported twice).
    pub fn with_faces(mesh: &TriMesh, faces: impl IntoIterator<Item = u32>) -> Result<Self, SpatialError> {
        Self::with_tree(mesh, faces.into_iter().collect(), FlatBvh::new)
    }

    /// The tree over `faces` of `mesh` whose hierarchy `tree` makes from the faces' boxes (in the
    /// order of `faces`): a new build, or a pruned tree refitted to them.
    fn with_tree(
        mesh: &TriMesh,
        faces: Vec<u32>,
        tree: impl FnOnce(&[(DVec3, DVec3)]) -> FlatBvh,
    ) -> Result<Self, SpatialError> {
        let nv = mesh.positions.len();
        let mut indices = Vec::with_capacity(faces.len());
        for &f in &faces {
            let tri = *mesh
                .triangles
                .get(f as usize)
                .ok_or(SpatialError::FaceOutOfRange { face: f, faces: mesh.triangles.len() })?;
            for &i in &tri {
                if i as usize >= nv {
                    return Err(
                        MeshError::IndexOutOfRange { triangle: f as usize, index: i as u64, vertices: nv }.into()
                    );
                }
            }
            indices.push(tri);
        }
        check_finite(&mesh.positions)?;
        let corners: Vec<[DVec3; 3]> = indices.iter().map(|t| t.map(|i| mesh.positions[i as usize])).collect();
        let boxes: Vec<(DVec3, DVec3)> = corners.iter().map(triangle_aabb).collect();
        let bvh = tree(&boxes);
        let bounds = bounds_of(&corners);
        // The vertices of the faces, sorted: marked, then read in order (no sort of 3 per face).
        let mut used = vec![false; nv];
        for &i in indices.iter().flatten() {
            used[i as usize] = true;
        }
        let fitted_vertices: Vec<u32> = (0..nv as u32).filter(|&v| used[v as usize]).collect();
        let fitted = fitted_vertices.iter().map(|&v| mesh.positions[v as usize]).collect();
        Ok(Self { bvh, faces, indices, corners, num_vertices: nv, bounds, fitted_vertices, fitted, links: None })
    }

    /// Moves the triangles to new vertex positions (same mesh connectivity, `positions.len()` equal
    /// to the mesh's vertex count) and refits the boxes, keeping the tree topology.
    pub fn refit(&mut self, positions: &[DVec3]) -> Result<(), SpatialError> {
        if positions.len() != self.num_vertices {
            return Err(SpatialError::PositionCount { expected: self.num_vertices, got: positions.len() });
        }
        check_finite(positions)?;
        // Only the leaves whose triangle moved (bit for bit) get a new box, and a tree none of
        // whose triangles moved since the last frame (a static ground, a prop at rest) is left
        // as is: the boxes are the same either way.
        let bits = |p: DVec3| p.to_array().map(f64::to_bits);
        let mut moved: Vec<u32> = Vec::new();
        for (k, (&v, p)) in self.fitted_vertices.iter().zip(self.fitted.iter_mut()).enumerate() {
            let now = positions[v as usize];
            if bits(now) != bits(*p) {
                *p = now;
                moved.push(k as u32);
            }
        }
        if moved.is_empty() {
            return Ok(());
        }
        if moved.len() * PARTIAL_REFIT > self.fitted.len() {
            for (tri, corners) in self.indices.iter().zip(self.corners.iter_mut()) {
                *corners = tri.map(|i| positions[i as usize]);
            }
            // Recomputes the boxes bottom-up without reordering nodes: the traversal order is kept.
            let corners = &self.corners;
            self.bvh.refit(|leaf| triangle_aabb(&corners[leaf as usize]));
        } else {
            // The moved vertices' leaves and their ancestors, children before parents: the other
            // boxes are already their triangles'.
            let links = self
                .links
                .get_or_insert_with(|| Box::new(RefitLinks::new(&self.bvh, &self.indices, &self.fitted_vertices)));
            let mut dirty: Vec<u32> = Vec::new();
            for &k in &moved {
                let k = k as usize;
                for &leaf in &links.leaves[links.offsets[k] as usize..links.offsets[k + 1] as usize] {
                    let mut node = links.leaf_node[leaf as usize];
                    // A leaf met again through another of its corners is already done.
                    if node != u32::MAX && links.marked[node as usize] {
                        continue;
                    }
                    self.corners[leaf as usize] = self.indices[leaf as usize].map(|i| positions[i as usize]);
                    while node != u32::MAX && !links.marked[node as usize] {
                        links.marked[node as usize] = true;
                        dirty.push(node);
                        node = links.parent[node as usize];
                    }
                }
            }
            // A node's children follow it: refitted down the indices, children come first. Many
            // marked boxes are swept in index order (which clears the marks); a few are sorted.
            let corners = &self.corners;
            let item_box = |leaf: u32| triangle_aabb(&corners[leaf as usize]);
            let last = dirty.iter().copied().max().unwrap_or(0) as usize;
            if dirty.len() * SWEEP_DIRTY > last {
                self.bvh.refit_marked(&mut links.marked[..=last], item_box);
            } else {
                for &node in &dirty {
                    links.marked[node as usize] = false;
                }
                dirty.sort_unstable_by(|a, b| b.cmp(a));
                self.bvh.refit_nodes(&dirty, item_box);
            }
        }
        self.bounds = self.bvh.nodes().first().map_or(Aabb3::EMPTY, |root| Aabb3 { min: root.min, max: root.max });
        Ok(())
    }

    /// The same tree over a mesh that numbers the faces and vertices otherwise: face `f` of this
    /// tree becomes `face_ids[f]`, vertex `v` becomes `vertex_ids[v]`, among `num_vertices`
    /// vertices (a region's tree moved into its object's numbering). The nodes, boxes and corner
    /// positions are kept, so every query answers as before with the new ids (queries whose ties
    /// are broken by face id then follow the new ids). `None` when an id is out of either map.
    pub fn relabeled(&self, face_ids: &[u32], vertex_ids: &[u32], num_vertices: usize) -> Option<Self> {
        let faces = self.faces.iter().map(|&f| face_ids.get(f as usize).copied()).collect::<Option<Vec<u32>>>()?;
        let map = |v: u32| vertex_ids.get(v as usize).copied().filter(|&w| (w as usize) < num_vertices);
        let indices = self.indices.iter().map(|t| Some([map(t[0])?, map(t[1])?, map(t[2])?])).collect::<Option<_>>()?;
        let mut fitted: Vec<(u32, DVec3)> =
            self.fitted_vertices.iter().zip(&self.fitted).map(|(&v, &p)| Some((map(v)?, p))).collect::<Option<_>>()?;
        fitted.sort_unstable_by_key(|&(v, _)| v);
        Some(Self {
            bvh: self.bvh.clone(),
            faces,
            indices,
            corners: self.corners.clone(),
            num_vertices,
            bounds: self.bounds,
            fitted_vertices: fitted.iter().map(|&(v, _)| v).collect(),
            fitted: fitted.iter().map(|&(_, p)| p).collect(),
            links: None,
        })
    }

    /// Number of triangles in the tree.
    pub fn len(&self) -> usize {
        self.faces.len()
    }

    /// True if the tree holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    /// Box of all the triangles ([`Aabb3::EMPTY`] for an empty tree).
    pub fn bounds(&self) -> Aabb3 {
        self.bounds
    }

    /// The face ids of the tree's triangles, in leaf order.
    pub fn faces(&self) -> &[u32] {
        &self.faces
    }

    /// Corner positions of mesh face `face`, if it is in the tree (linear search for subsets; use
    /// [`Self::leaf_corners`] in hot loops).
    pub fn face_corners(&self, face: u32) -> Option<[DVec3; 3]> {
        if self.faces.get(face as usize) == Some(&face) {
            return Some(self.corners[face as usize]);
        }
        self.faces.iter().position(|&f| f == face).map(|leaf| self.corners[leaf])
    }

    /// Corner positions of leaf `leaf` (index into [`Self::faces`]).
    pub fn leaf_corners(&self, leaf: usize) -> Option<[DVec3; 3]> {
        self.corners.get(leaf).copied()
    }

    /// Vertex indices of leaf `leaf` in the mesh.
    pub fn leaf_indices(&self, leaf: usize) -> Option<[u32; 3]> {
        self.indices.get(leaf).copied()
    }
}

fn check_finite(positions: &[DVec3]) -> Result<(), SpatialError> {
    for (v, p) in positions.iter().enumerate() {
        for value in p.to_array() {
            if !value.is_finite() {
                return Err(MeshError::NonFiniteCoordinate { vertex: v, value }.into());
            }
        }
    }
    Ok(())
}

fn bounds_of(corners: &[[DVec3; 3]]) -> Aabb3 {
    Aabb3::from_points(corners.iter().flatten().copied())
}

/// Exact box (min, max) of a triangle: min/max of coordinates involve no rounding, so tree pruning
/// can only be wrong through the traversal tests, which are made conservative instead.
#[inline]
pub(super) fn triangle_aabb(t: &[DVec3; 3]) -> (DVec3, DVec3) {
    (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
}

/// A segment `a + t (b − a)`, `t ∈ [0, 1]`, prepared for conservative slab tests against boxes.
#[derive(Clone, Copy, Debug)]
pub(super) struct SegmentProbe {
    a: DVec3,
    inv: DVec3,
    /// Every component of `inv` is finite: the plain vector slab test.
    regular: bool,
    /// Per axis: `inv` is finite there (the others have a zero or subnormal extent `d`).
    finite: BVec3,
    /// `|d|`, the reach of the segment along the axes where `inv` is not finite.
    reach: DVec3,
}

impl SegmentProbe {
    pub(super) fn new(a: DVec3, b: DVec3) -> Self {
        let d = b - a;
        let inv = DVec3::ONE / d;
        let finite = inv.is_finite_mask();
        Self { a, inv, regular: finite.all(), finite, reach: d.abs() }
    }

    /// Parameter interval `[t_in, t_out] ⊂ [0, 1]` (slightly widened) in which the segment may be
    /// inside the box, or `None` if it certainly misses it. Conservative: rounding can only add
    /// boxes, never drop one the exact segment touches.
    #[inline]
    pub(super) fn clip(&self, mins: DVec3, maxs: DVec3) -> Option<(f64, f64)> {
        let (lo, hi) = if self.regular {
            let t0 = (mins - self.a) * self.inv;
            let t1 = (maxs - self.a) * self.inv;
            // Plain comparisons (no NaN can occur with finite `inv` and finite boxes): they compile
            // to single min/max instructions, where `f64::min` handles NaN.
            let (min, max) = (|x: f64, y: f64| if x < y { x } else { y }, |x: f64, y: f64| if x > y { x } else { y });
            let near = [min(t0.x, t1.x), min(t0.y, t1.y), min(t0.z, t1.z)];
            let far = [max(t0.x, t1.x), max(t0.y, t1.y), max(t0.z, t1.z)];
            (max(max(near[0], near[1]), max(near[2], 0.0)), min(min(far[0], far[1]), min(far[2], 1.0)))
        } else {
            self.clip_parallel(mins, maxs)?
        };
        // Each slab bound carries at most three roundings (relative error ≤ 3·2⁻⁵³); widen by far
        // more than that (Ize 2013 shows a relative widening of this kind makes the test robust).
        let slack = 1e-12 * lo.abs().max(hi.abs());
        (lo - slack <= hi + slack).then_some((lo - slack, hi + slack))
    }

    /// The slab test for a segment parallel to a coordinate plane or axis (a zero or subnormal
    /// component: `(min − a)·inv` could be `0·∞`), on whole vectors: an axis without a finite
    /// `inv` only checks that the segment's reach there meets the box, the others clip as usual.
    /// Queries straight along an axis (box walls, vertical mappings) take this path for every
    /// node, so it must not fall back to a branchy loop. Same result as
    /// [`Self::clip_axis_by_axis`] (tested).
    #[inline]
    fn clip_parallel(&self, mins: DVec3, maxs: DVec3) -> Option<(f64, f64)> {
        let within = (self.a + self.reach).cmpge(mins) & (self.a - self.reach).cmple(maxs);
        if !(within | self.finite).all() {
            return None;
        }
        let t0 = (mins - self.a) * self.inv;
        let t1 = (maxs - self.a) * self.inv;
        // NaN (0·∞) only on the axes replaced by the select.
        let near = DVec3::select(self.finite, t0.min(t1), DVec3::NEG_INFINITY);
        let far = DVec3::select(self.finite, t0.max(t1), DVec3::INFINITY);
        // In the reference's order, so that even the sign of a zero is the same.
        Some((0.0f64.max(near.x).max(near.y).max(near.z), 1.0f64.min(far.x).min(far.y).min(far.z)))
    }

    /// The slab test axis by axis (the reference of [`Self::clip_parallel`]).
    #[cfg(test)]
    fn clip_axis_by_axis(&self, mins: DVec3, maxs: DVec3) -> Option<(f64, f64)> {
        let mut lo = 0.0f64;
        let mut hi = 1.0f64;
        for k in 0..3 {
            let (o, reach, inv) = (self.a[k], self.reach[k], self.inv[k]);
            if !inv.is_finite() {
                // Zero (or subnormal) extent along this axis: the segment stays within |d| of o.
                if o + reach < mins[k] || o - reach > maxs[k] {
                    return None;
                }
                continue;
            }
            let t0 = (mins[k] - o) * inv;
            let t1 = (maxs[k] - o) * inv;
            let (near, far) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
            lo = lo.max(near);
            hi = hi.min(far);
        }
        Some((lo, hi))
    }
}

#[inline]
pub(super) fn box_distance_squared(mins: DVec3, maxs: DVec3, p: DVec3) -> f64 {
    crate::mesh::Aabb3 { min: mins, max: maxs }.distance_squared_to(p)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::Lcg;
    use crate::mesh::shapes;

    fn leaf_node(tree: &TriangleBvh, leaf: usize) -> super::super::flat_bvh::Node {
        *tree.bvh.nodes().iter().find(|n| n.item() == Some(leaf as u32)).unwrap()
    }

    /// A cap cut out of a sphere whose tree was built at other positions: the tree pruned from
    /// the sphere's answers closest points, segment crossings and faces in boxes as a tree built
    /// on the cap, bit for bit.
    #[test]
    fn a_tree_restricted_to_a_cut_answers_as_a_new_one() {
        let mut sphere = shapes::icosphere(1.0, 4);
        let whole = TriangleBvh::new(&sphere).unwrap();
        for p in &mut sphere.positions {
            *p = DVec3::new(p.x * 1.3, p.y, p.z * 0.8 + 0.1 * p.x * p.x);
        }
        let faces: Vec<u32> =
            (0..sphere.num_triangles() as u32).filter(|&f| sphere.corners(f as usize)[0].z > 0.2).collect();
        let cap = crate::mesh::SubMesh::from_faces(&sphere, faces.iter().copied());
        let restricted = whole.restricted(&cap.mesh, &cap.parent_face).unwrap().unwrap();
        let built = TriangleBvh::new(&cap.mesh).unwrap();
        assert_ne!(restricted.bvh, built.bvh, "another shape");
        let mut rng = Lcg::from_state(3);
        let mut next = || 2.0 * rng.next_unit() - 1.0;
        let (mut a_faces, mut b_faces) = (Vec::new(), Vec::new());
        for _ in 0..400 {
            let (p, q) = (DVec3::new(next(), next(), next()) * 1.5, DVec3::new(next(), next(), next()) * 1.5);
            let key = |c: Option<crate::spatial::ClosestPoint>| {
                c.map(|c| (c.face, c.bary.map(f64::to_bits), c.distance.to_bits()))
            };
            assert_eq!(key(restricted.closest_point(p)), key(built.closest_point(p)));
            assert_eq!(key(restricted.closest_point_within(p, 0.3)), key(built.closest_point_within(p, 0.3)));
            assert_eq!(restricted.segment_crosses(p, q), built.segment_crosses(p, q));
            let query = Aabb3::from_points([p, p + DVec3::splat(0.4)]);
            restricted.faces_in_box(&query, &mut a_faces);
            built.faces_in_box(&query, &mut b_faces);
            assert_eq!(a_faces, b_faces);
        }
        // Faces it does not hold: no tree.
        assert!(built.restricted(&cap.mesh, &cap.parent_face).unwrap().is_none());
    }

    #[test]
    fn builds_are_deterministic_and_refit_keeps_the_topology() {
        let mesh = shapes::icosphere(1.0, 3);
        let a = TriangleBvh::new(&mesh).unwrap();
        let b = TriangleBvh::new(&mesh).unwrap();
        let order = |t: &TriangleBvh| t.bvh.nodes().iter().filter_map(|n| n.item()).collect::<Vec<u32>>();
        assert_eq!(order(&a), order(&b));
        assert_eq!(order(&a).len(), mesh.num_triangles());
        let mut moved = a.clone();
        let shifted: Vec<DVec3> = mesh.positions.iter().map(|p| *p * 1.5 + DVec3::new(3.0, -2.0, 1.0)).collect();
        moved.refit(&shifted).unwrap();
        assert_eq!(order(&moved), order(&a));
        assert!((moved.bounds().center() - DVec3::new(3.0, -2.0, 1.0)).length() < 1e-12);
        // Every leaf box in the refitted tree bounds its triangle.
        for (leaf, c) in moved.corners.iter().enumerate() {
            let node = leaf_node(&moved, leaf);
            for p in c {
                assert!(p.cmpge(node.min).all() && p.cmple(node.max).all());
            }
        }
    }

    #[test]
    fn refitting_moves_exactly_the_leaves_whose_triangles_moved() {
        let mesh = shapes::icosphere(1.0, 3);
        let mut tree = TriangleBvh::new(&mesh).unwrap();
        // Unchanged positions: nothing to do, same tree.
        let before = tree.clone();
        tree.refit(&mesh.positions).unwrap();
        assert_eq!(tree.corners, before.corners);
        // A few vertices move: every leaf box is its triangle's box.
        let mut moved = mesh.positions.clone();
        moved[7] += DVec3::new(0.0, 0.0, 0.3);
        moved[100] *= 1.2;
        moved[0].x = -moved[0].x;
        tree.refit(&moved).unwrap();
        for leaf in 0..tree.len() {
            let corners = tree.indices[leaf].map(|i| moved[i as usize]);
            assert_eq!(tree.corners[leaf], corners);
            let node = leaf_node(&tree, leaf);
            assert_eq!((node.min, node.max), triangle_aabb(&corners));
        }
        assert_eq!(tree.bounds(), Aabb3::from_points(moved.iter().copied()));
        let probe = TriangleBvh::new(&TriMesh { positions: moved, triangles: mesh.triangles.clone() }).unwrap();
        for k in 0..50 {
            let a = DVec3::new(2.0, 0.05 * k as f64 - 1.2, 0.3);
            assert_eq!(tree.segment_crossing_count(a, -a), probe.segment_crossing_count(a, -a));
        }
        // Back to the first positions, then the same again: the tree of the first positions.
        tree.refit(&mesh.positions).unwrap();
        tree.refit(&mesh.positions).unwrap();
        assert_eq!(tree.corners, before.corners);
        assert_eq!(tree.bounds(), before.bounds());
        // A sign-only change of a zero coordinate is a change (bit for bit).
        let (v, k) = (0..mesh.num_vertices())
            .flat_map(|v| (0..3).map(move |k| (v, k)))
            .find(|&(v, k)| mesh.positions[v][k] == 0.0)
            .unwrap();
        let mut signed = mesh.positions.clone();
        signed[v][k] = -signed[v][k];
        tree.refit(&signed).unwrap();
        let leaf = tree.indices.iter().position(|t| t.contains(&(v as u32))).unwrap();
        let corner = tree.indices[leaf].iter().position(|&i| i as usize == v).unwrap();
        assert_eq!(tree.corners[leaf][corner][k].to_bits(), signed[v][k].to_bits());
        // A tree over some faces ignores the vertices it does not use.
        let faces: Vec<u32> = (0..mesh.num_triangles() as u32).filter(|&f| f % 3 == 0).collect();
        let mut subset = TriangleBvh::with_faces(&mesh, faces.iter().copied()).unwrap();
        let unused = (0..mesh.num_vertices() as u32).find(|v| !subset.indices.iter().flatten().any(|i| i == v));
        let used = subset.indices[0][0] as usize;
        let mut elsewhere = mesh.positions.clone();
        if let Some(unused) = unused {
            elsewhere[unused as usize] += DVec3::splat(0.5);
            let kept = subset.clone();
            subset.refit(&elsewhere).unwrap();
            assert_eq!(subset.corners, kept.corners);
        }
        elsewhere[used] += DVec3::splat(0.5);
        subset.refit(&elsewhere).unwrap();
        assert_eq!(subset.corners[0][0], elsewhere[used]);
    }

    #[test]
    fn refitting_a_few_moved_vertices_gives_the_boxes_of_a_whole_refit() {
        let mesh = shapes::icosphere(1.0, 4);
        let faces: Vec<u32> = (0..mesh.num_triangles() as u32).filter(|&f| f % 5 != 0).collect();
        for mut tree in [TriangleBvh::new(&mesh).unwrap(), TriangleBvh::with_faces(&mesh, faces).unwrap()] {
            let mut rng = Lcg::new(7);
            let mut positions = mesh.positions.clone();
            for step in 0..40 {
                // Mostly a few vertices (their boxes sorted), sometimes a sixth of them (the
                // marked boxes swept), most of them (the whole refit) or none.
                let count = match step % 8 {
                    0 => positions.len(),
                    1 => 0,
                    2 => positions.len() / 6,
                    _ => 1 + step % 13,
                };
                for _ in 0..count {
                    let v = rng.next_index(positions.len());
                    positions[v] += 0.03 * DVec3::new(rng.next_signed(), rng.next_signed(), rng.next_signed());
                }
                tree.refit(&positions).unwrap();
                let mut whole = tree.clone();
                let corners = whole.corners.clone();
                whole.bvh.refit(|leaf| triangle_aabb(&corners[leaf as usize]));
                assert_eq!(tree.bvh.nodes(), whole.bvh.nodes(), "step {step}");
                for (leaf, tri) in tree.indices.iter().enumerate() {
                    assert_eq!(tree.corners[leaf], tri.map(|i| positions[i as usize]));
                }
                assert_eq!(tree.bounds(), bounds_of(&tree.corners));
            }
        }
    }

    #[test]
    fn tiny_trees_refit_too() {
        // One and two leaves (a root that is a leaf, a root with two leaves) move as well.
        let grid = shapes::grid(1.0, 1.0, 1, 1); // two triangles
        for faces in [vec![0u32], vec![0, 1]] {
            let mut tree = TriangleBvh::with_faces(&grid, faces.iter().copied()).unwrap();
            let up: Vec<DVec3> = grid.positions.iter().map(|p| *p + DVec3::new(5.0, 0.0, 3.0)).collect();
            tree.refit(&up).unwrap();
            let c = tree.leaf_corners(0).unwrap();
            let centroid = (c[0] + c[1] + c[2]) / 3.0;
            assert_eq!(tree.segment_crossing_count(centroid + DVec3::Z, centroid - DVec3::Z), 1);
            assert_eq!(
                tree.segment_crossing_count(
                    centroid + DVec3::Z - DVec3::new(5.0, 0.0, 3.0),
                    centroid - DVec3::Z - DVec3::new(5.0, 0.0, 3.0)
                ),
                0
            );
        }
    }

    #[test]
    fn invalid_input_is_an_error() {
        let mut mesh = shapes::icosphere(1.0, 0);
        let mut tree = TriangleBvh::new(&mesh).unwrap();
        assert!(matches!(tree.refit(&mesh.positions[1..]), Err(SpatialError::PositionCount { .. })));
        let mut bad = mesh.positions.clone();
        bad[3].y = f64::NAN;
        assert!(tree.refit(&bad).is_err());
        assert!(matches!(TriangleBvh::with_faces(&mesh, [0, 99]), Err(SpatialError::FaceOutOfRange { face: 99, .. })));
        mesh.triangles[2][1] = 500;
        assert!(TriangleBvh::new(&mesh).is_err());
        let empty = TriangleBvh::new(&TriMesh::default()).unwrap();
        assert!(empty.is_empty());
    }

    #[test]
    fn slab_test_handles_axis_aligned_and_flat_cases() {
        let (mins, maxs) = (DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0)); // a flat box
        let down = SegmentProbe::new(DVec3::new(0.5, 0.5, 1.0), DVec3::new(0.5, 0.5, -1.0));
        let (lo, hi) = down.clip(mins, maxs).unwrap();
        assert!(lo <= 0.5 && hi >= 0.5);
        let in_plane = SegmentProbe::new(DVec3::new(-1.0, 0.5, 0.0), DVec3::new(2.0, 0.5, 0.0));
        assert!(in_plane.clip(mins, maxs).is_some());
        let above = SegmentProbe::new(DVec3::new(-1.0, 0.5, 0.1), DVec3::new(2.0, 0.5, 0.1));
        assert!(above.clip(mins, maxs).is_none());
        let short = SegmentProbe::new(DVec3::new(0.5, 0.5, 1.0), DVec3::new(0.5, 0.5, 0.5));
        assert!(short.clip(mins, maxs).is_none());
        // Touching the box at the segment's end.
        let touch = SegmentProbe::new(DVec3::new(0.5, 0.5, 1.0), DVec3::new(0.5, 0.5, 0.0));
        assert!(touch.clip(mins, maxs).is_some());
    }

    #[test]
    fn the_vector_slab_test_of_axis_parallel_segments_is_the_axis_by_axis_one() {
        // Segments along an axis or in a coordinate plane (one or two zero or subnormal extents),
        // against boxes around, touching and missing them, on a coarse lattice so that endpoints
        // and box faces coincide often.
        let mut rng = Lcg::new(11);
        let coordinate = |rng: &mut Lcg| rng.next_index(9) as f64 * 0.25 - 1.0;
        let flat = [0.0, 1e-310, -1e-310];
        let (mut parallel, mut met) = (0, 0);
        for _ in 0..20_000 {
            let a = DVec3::new(coordinate(&mut rng), coordinate(&mut rng), coordinate(&mut rng));
            let mut d = DVec3::new(coordinate(&mut rng), coordinate(&mut rng), coordinate(&mut rng));
            for k in 0..3 {
                if rng.next_index(3) == 0 {
                    d[k] = flat[rng.next_index(3)];
                }
            }
            let probe = SegmentProbe::new(a, a + d);
            if probe.regular {
                continue;
            }
            parallel += 1;
            let p = DVec3::new(coordinate(&mut rng), coordinate(&mut rng), coordinate(&mut rng));
            let q = DVec3::new(coordinate(&mut rng), coordinate(&mut rng), coordinate(&mut rng));
            let (mins, maxs) = (p.min(q), p.max(q));
            let vector = probe.clip_parallel(mins, maxs);
            let reference = probe.clip_axis_by_axis(mins, maxs);
            assert_eq!(
                vector.map(|(lo, hi)| (lo.to_bits(), hi.to_bits())),
                reference.map(|(lo, hi)| (lo.to_bits(), hi.to_bits())),
                "segment {a} + t {d}, box {mins} – {maxs}"
            );
            met += usize::from(vector.is_some());
        }
        assert!(parallel > 5000 && met > 500 && met < parallel - 500, "{parallel} parallel, {met} met");
    }
}
