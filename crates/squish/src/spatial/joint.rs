//! Every crossing of the edges of each of two meshes with the faces of the other, by one joint
//! traversal of their two triangle trees (thesis §4.1; ch. 7 §5.1 suggests "joint BVH traversal
//! and batch intersection tests instead of testing each segment at a time").
//!
//! Querying each edge of one mesh against the other's tree costs a root-to-leaves descent per
//! edge, and most edges near the other surface descend deep without crossing anything (a hat
//! around an egg, a bunny's base on a jelly). The joint traversal visits only the pairs of
//! overlapping boxes; at each pair of overlapping triangle boxes it tests the edges the first
//! triangle owns against the second triangle and the other way round. Each edge is owned by one
//! of its faces (the first one of [`Topology::edge_faces`] that is in the tree), so it is tested
//! once against each face; an edge crossing a face shares a point with it, so their boxes (exact:
//! min/max of coordinates) overlap and the pair is visited. The crossings are the same exact,
//! symbolically perturbed tests as [`TriangleBvh::segment_hits`], sorted the same way, so the
//! result is identical to querying every edge, whatever the trees' shapes and the thread count.
//! Edges whose faces are all missing from their own tree (a tree over a subset of the faces) are
//! queried one by one.

use glam::DVec3;
use rayon::prelude::*;

use super::batch::BatchHits;
use super::bvh::TriangleBvh;
use super::exact::segment_triangle;
use super::queries::{Hit, hit_order};
use crate::mesh::{NO_FACE, Topology};
use crate::stage::{SharedWork, Work};

/// One mesh of [`mutual_edge_crossings`]: its triangle tree, vertex positions and connectivity.
#[derive(Clone, Copy, Debug)]
pub struct EdgeSource<'a> {
    pub tree: &'a TriangleBvh,
    pub positions: &'a [DVec3],
    pub topology: &'a Topology,
}

/// The crossings of one mesh's edges with the other mesh's faces.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EdgeCrossings {
    /// The edges (topology edge ids) with at least one crossing, increasing.
    pub edges: Vec<u32>,
    /// The crossings of `edges[i]` are `hits.get(i)`, sorted along the edge (from its first
    /// vertex) then by face id, exactly as [`TriangleBvh::segment_hits`] returns them.
    pub hits: BatchHits,
}

/// Crossings found, as (edge id, crossing) pairs.
type Found = Vec<(u32, Hit)>;

/// Marks "no owned edge" in a leaf's list.
const NO_EDGE: u32 = u32::MAX;

/// Leaf pairs per parallel task.
const CHUNK: usize = 256;

/// Which edges each leaf of a tree owns.
enum Ownership<'a> {
    /// The tree holds every face of the mesh, leaf `f` being face `f` (a whole working region,
    /// the usual case): every edge is owned by its first face, read on demand.
    Whole(&'a Topology),
    /// Per leaf, the edges its face owns ([`NO_EDGE`] for none).
    Listed(Vec<[u32; 3]>),
}

impl Ownership<'_> {
    #[inline]
    fn owned(&self, leaf: u32) -> Option<[u32; 3]> {
        match self {
            Self::Whole(topology) => (leaf < topology.num_faces() as u32).then(|| {
                topology.face_edges(leaf).map(|e| if topology.edge_faces(e)[0] == leaf { e } else { NO_EDGE })
            }),
            Self::Listed(per_leaf) => per_leaf.get(leaf as usize).copied(),
        }
    }
}

/// Which edges each leaf of `source.tree` owns; and the edges no leaf owns.
fn owned_edges<'a>(source: &EdgeSource<'a>) -> (Ownership<'a>, Vec<u32>) {
    let topology = source.topology;
    let faces = source.tree.faces();
    let num_faces = topology.num_faces();
    if faces.len() == num_faces && faces.iter().enumerate().all(|(leaf, &f)| leaf as u32 == f) {
        // Every edge has a first face, which is in the tree: no orphans.
        return (Ownership::Whole(topology), Vec::new());
    }
    let mut in_tree = vec![false; num_faces];
    for &f in faces {
        if let Some(slot) = in_tree.get_mut(f as usize) {
            *slot = true;
        }
    }
    let owner = |e: u32| -> u32 {
        topology
            .edge_faces(e)
            .into_iter()
            .find(|&f| f != NO_FACE && in_tree.get(f as usize) == Some(&true))
            .unwrap_or(NO_FACE)
    };
    // A face listed twice in the tree owns its edges at its first leaf only.
    let mut claimed = vec![false; num_faces];
    let per_leaf = faces
        .iter()
        .map(|&f| {
            if f as usize >= num_faces || std::mem::replace(&mut claimed[f as usize], true) {
                return [NO_EDGE; 3];
            }
            topology.face_edges(f).map(|e| if owner(e) == f { e } else { NO_EDGE })
        })
        .collect();
    let orphans = (0..topology.num_edges() as u32).filter(|&e| owner(e) == NO_FACE).collect();
    (Ownership::Listed(per_leaf), orphans)
}

/// False when the segment's box and the triangle's box are disjoint (then they cannot meet, even
/// under the exact test's symbolic perturbation: touching boxes are kept). Most pairs of leaves
/// whose boxes overlap have edges that miss the other face's box.
#[inline]
fn segment_may_meet_triangle(p: DVec3, q: DVec3, t: &[DVec3; 3]) -> bool {
    let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
    p.min(q).cmple(hi).all() && p.max(q).cmpge(lo).all()
}

/// The segment of edge `e`.
#[inline]
fn segment(source: &EdgeSource, e: u32) -> Option<(DVec3, DVec3)> {
    let [i, j] = source.topology.edges()[e as usize];
    Some((*source.positions.get(i as usize)?, *source.positions.get(j as usize)?))
}

/// Sorts `(edge, hit)` pairs by edge then along the edge and groups them. (Each pair of leaves is
/// visited once and each edge tested from one leaf, so there is nothing to deduplicate; a face
/// listed twice in a tree is reported twice, as by [`TriangleBvh::segment_hits`].)
fn group(mut found: Found) -> EdgeCrossings {
    found.sort_unstable_by(|x, y| x.0.cmp(&y.0).then_with(|| hit_order(&x.1, &y.1)));
    let mut edges = Vec::new();
    let mut offsets = vec![0];
    let mut hits = Vec::with_capacity(found.len());
    for (e, hit) in found {
        if edges.last() != Some(&e) {
            if !edges.is_empty() {
                offsets.push(hits.len());
            }
            edges.push(e);
        }
        hits.push(hit);
    }
    if !edges.is_empty() {
        offsets.push(hits.len());
    }
    EdgeCrossings { edges, hits: BatchHits::from_parts(offsets, hits) }
}

/// [`EdgeCrossings`] of `a`'s edges with `b`'s faces and of `b`'s edges with `a`'s faces (see the
/// module doc). Positions must be those the trees were built or refitted with.
pub fn mutual_edge_crossings(a: EdgeSource, b: EdgeSource) -> [EdgeCrossings; 2] {
    let ((owned_a, orphans_a), (owned_b, orphans_b)) = (owned_edges(&a), owned_edges(&b));
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    a.tree.bvh.for_each_overlapping_pair(&b.tree.bvh, |la, lb| pairs.push((la, lb)));
    let test = |edge_side: &EdgeSource, owned: &[u32; 3], face_side: &EdgeSource, leaf: u32, out: &mut Found| {
        let corners = &face_side.tree.corners[leaf as usize];
        for &e in owned.iter().filter(|&&e| e != NO_EDGE) {
            if let Some((p, q)) = segment(edge_side, e)
                && segment_may_meet_triangle(p, q, corners)
                && let Some(c) = segment_triangle(p, q, corners)
            {
                out.push((e, face_side.tree.make_hit(leaf as usize, c, 1.0)));
            }
        }
    };
    let work = SharedWork::default();
    let chunks: Vec<(Found, Found)> = pairs
        .par_chunks(CHUNK)
        .map(|chunk| {
            work.measure(|| {
                let (mut on_a, mut on_b) = (Vec::new(), Vec::new());
                for &(la, lb) in chunk {
                    if let (Some(oa), Some(ob)) = (owned_a.owned(la), owned_b.owned(lb)) {
                        test(&a, &oa, &b, lb, &mut on_a);
                        test(&b, &ob, &a, la, &mut on_b);
                    }
                }
                (on_a, on_b)
            })
        })
        .collect();
    // One joint descent of the two trees, and the chunks' exact tests.
    Work::count_queries(1);
    work.record();
    let (mut found_a, mut found_b) = (Vec::new(), Vec::new());
    for (on_a, on_b) in chunks {
        found_a.extend(on_a);
        found_b.extend(on_b);
    }
    // Edges no leaf owns: one query each (only for trees over a subset of the faces).
    let mut scratch = Vec::new();
    for (edge_side, orphans, face_side, found) in
        [(&a, &orphans_a, &b, &mut found_a), (&b, &orphans_b, &a, &mut found_b)]
    {
        for &e in orphans {
            if let Some((p, q)) = segment(edge_side, e) {
                face_side.tree.segment_hits(p, q, &mut scratch);
                found.extend(scratch.iter().map(|h| (e, *h)));
            }
        }
    }
    [group(found_a), group(found_b)]
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::mesh::{TriMesh, shapes};

    /// The reference: every edge queried against the other tree.
    fn one_by_one(edges_of: &TriMesh, topology: &Topology, tree: &TriangleBvh) -> EdgeCrossings {
        let mut found = Vec::new();
        let mut hits = Vec::new();
        for (e, &[i, j]) in topology.edges().iter().enumerate() {
            tree.segment_hits(edges_of.positions[i as usize], edges_of.positions[j as usize], &mut hits);
            found.extend(hits.iter().map(|h| (e as u32, *h)));
        }
        group(found)
    }

    fn check(a: &TriMesh, b: &TriMesh, tree_a: &TriangleBvh, tree_b: &TriangleBvh) -> usize {
        let (ta, tb) = (Topology::new(a), Topology::new(b));
        let sa = EdgeSource { tree: tree_a, positions: &a.positions, topology: &ta };
        let sb = EdgeSource { tree: tree_b, positions: &b.positions, topology: &tb };
        let [ca, cb] = mutual_edge_crossings(sa, sb);
        assert_eq!(ca, one_by_one(a, &ta, tree_b));
        assert_eq!(cb, one_by_one(b, &tb, tree_a));
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            assert_eq!(pool.install(|| mutual_edge_crossings(sa, sb)), [ca.clone(), cb.clone()]);
        }
        ca.hits.total() + cb.hits.total()
    }

    #[test]
    fn joint_crossings_equal_edge_by_edge_queries() {
        // Spheres overlapping, a sphere through a box whose grid shares coordinates with it
        // (crossings exactly through vertices and edges), an open grid through a capsule.
        let sphere = shapes::icosphere(1.0, 3);
        let mut shifted = shapes::icosphere(0.7, 4);
        shifted.map_positions(|p| p + DVec3::new(0.9, 0.2, -0.1));
        let mut cube = shapes::cube(1.5, 6);
        cube.map_positions(|p| p + DVec3::new(0.75, 0.0, 0.0));
        let grid = shapes::grid(3.0, 3.0, 12, 12);
        let capsule = shapes::capsule(0.5, 1.0, 12, 4, 4);
        let mut total = 0;
        for (a, b) in [(&sphere, &shifted), (&sphere, &cube), (&grid, &capsule), (&capsule, &grid)] {
            total += check(a, b, &TriangleBvh::new(a).unwrap(), &TriangleBvh::new(b).unwrap());
        }
        assert!(total > 500, "{total}");
        // Apart: nothing.
        let mut far = sphere.clone();
        far.map_positions(|p| p + DVec3::new(5.0, 0.0, 0.0));
        assert_eq!(check(&sphere, &far, &TriangleBvh::new(&sphere).unwrap(), &TriangleBvh::new(&far).unwrap()), 0);
    }

    #[test]
    fn trees_over_some_faces_still_test_every_edge() {
        // The first tree holds every other face (some edges lose both faces), the second a
        // face twice: the result is still that of querying every edge.
        let sphere = shapes::icosphere(1.0, 2);
        let mut other = shapes::icosphere(0.8, 3);
        other.map_positions(|p| p + DVec3::new(0.6, 0.1, 0.0));
        let tree_a = TriangleBvh::with_faces(&sphere, (0..sphere.num_triangles() as u32).step_by(2)).unwrap();
        let mut faces: Vec<u32> = (0..other.num_triangles() as u32).collect();
        faces.push(5);
        let tree_b = TriangleBvh::with_faces(&other, faces).unwrap();
        assert!(check(&sphere, &other, &tree_a, &tree_b) > 20);
    }
}
