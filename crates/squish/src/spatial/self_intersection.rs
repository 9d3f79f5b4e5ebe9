//! Faces of a mesh that intersect other faces of the same mesh (self-intersections), and face
//! pairs of two meshes that intersect.
//!
//! The collision detection of thesis §4.1 is correct only for "manifolds with boundaries without
//! self-intersections" (§4.1, Discussion), so `squish info` reports the self-intersecting face
//! count of its inputs. Two faces that share a vertex or an edge always touch there; they are
//! reported only when they intersect elsewhere ([`triangles_intersect_away_from_shared`]: a
//! fold-over across a shared edge, a face piercing a neighbour of its fan). Sharing is by
//! position, as in that test: corners at the same coordinates are the same vertex. Zero-area
//! faces are never reported (mesh validation reports them as degenerate). Faces of two different
//! meshes are reported whenever they share a point.
//!
//! **Any geometry in near-linear time** (issue 28: a 100 000-triangle fan took minutes). The
//! result is the set of faces that intersect some other face, so each face stops at its first
//! intersecting partner (and marks it too): a soup where everything intersects costs one test
//! per face. The pairs that remain to test are split by what they share, each kind found
//! without visiting the others:
//! - *no shared vertex*: a tree of oriented boxes over the faces ([`super::obb_tree`]), which
//!   separates long thin faces that axis-aligned boxes cannot, and skips every subtree whose
//!   faces all share a vertex with the query (a fan is one skipped subtree);
//! - *exactly one shared vertex v*: such faces intersect away from v iff their wedges at v
//!   overlap (their intersection is convex and holds v, so if it holds another point it holds
//!   the segment to it), so they are found around v: each face's wedge, cut to directions at
//!   v (unit vectors), is bounded by the quadrilateral {½a, ½b, b, a} between radii ½ and
//!   cos 45° (wedges wider than 75° are halved), which two faces' quadrilaterals share iff
//!   their wedges share a direction — and which, unlike the wedges, do not all touch at v;
//! - *two or three shared vertices* (a shared edge): they overlap iff they are coplanar on the
//!   same side of the edge, so the faces around each edge are sorted by their angle about it
//!   and only faces of equal angle (up to a bound on its round-off) are tested.
//!
//! Every test is the exact [`triangles_intersect_away_from_shared`]; the trees and angles only
//! choose candidates, conservatively. Small stars and edges (≤ [`SMALL`] faces) test all their
//! pairs. The result is sorted and does not depend on the thread count.
//!
//! **Every intersecting pair, for many counts of one mesh** ([`self_intersecting_pairs`],
//! [`IntersectingPairs`]). The test of a pair depends on its two triangles only, so the faces the
//! search finds among any subset of faces, for any relation, are the faces of the intersecting
//! pairs within that subset that the relation admits. Where one mesh is counted many ways (each
//! articulation's faces, each part pair's parts, the faces beyond the rest pose's), the pairs are
//! enumerated once — every pair of faces whose axis-aligned boxes overlap, tested exactly — and
//! every count filters them; after some vertices move, only the pairs of a face with a moved
//! corner are tested again. Past a budget of overlapping boxes per face (a fan: quadratic), the
//! enumeration gives up and the callers fall back on the face search.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use super::SpatialError;
use super::aabb_tree::AabbTree;
use super::bvh::TriangleBvh;
use super::exact::cross_exact;
use super::obb_tree::{Item, ObbTree};
#[cfg(any(test, doc))]
use super::tri_tri::triangles_intersect_away_from_shared;
use super::tri_tri::{intersect, intersect_away_from_shared, triangles_intersect};
use crate::mesh::{Aabb3, MeshError, TriMesh, faces_around_vertices};
use crate::stage::{SharedWork, Work};

/// Stars and edges with at most this many faces test all their pairs.
const SMALL: usize = 24;
/// Candidates a face visits in the first pass over unshared pairs before it waits for the
/// second.
const UNSHARED_BUDGET: usize = 64;
/// A large star whose open faces are at most this many tests them against the whole star
/// instead of building a tree.
const FEW_OPEN: usize = 64;
/// Relative margin of the boxes (far above their round-off, see [`super::obb_tree`]).
const MARGIN: f64 = 1e-9;

/// Self-intersections of a mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct SelfIntersections {
    /// Faces that intersect another face away from what they share, sorted, without repetition.
    pub faces: Vec<u32>,
}

/// Self-intersections of `mesh` (see the module docs for the rule on adjacent faces).
pub fn self_intersections(mesh: &TriMesh) -> Result<SelfIntersections, SpatialError> {
    let faces = search(mesh, 0..mesh.num_triangles() as u32, &|_, _| true, true)?;
    Ok(SelfIntersections { faces })
}

/// The faces among `faces` (duplicates ignored) that intersect another face among them for
/// which `related(f, g)` holds — a symmetric relation, e.g. "the two faces are on different
/// sides of a fold". Sorted mesh face ids. Errors: a face or vertex index out of range, a
/// non-finite coordinate.
pub fn self_intersecting_faces(
    mesh: &TriMesh,
    faces: impl IntoIterator<Item = u32>,
    related: impl Fn(u32, u32) -> bool + Sync,
) -> Result<Vec<u32>, SpatialError> {
    search(mesh, faces, &related, false)
}

/// Every pair `[f, g]` (`f < g`, sorted) of faces among `faces` (duplicates ignored) that
/// intersect away from what they share: the pairs whose faces [`self_intersecting_faces`] finds,
/// so that the faces it finds among any subset, for any relation, are those of the pairs within
/// it (the test of a pair depends on its two triangles only). `None` when more than `budget`
/// pairs of faces have overlapping boxes (a fan, a soup): the face search, which stops at a
/// face's first partner, is then the way that stays near-linear. Errors as
/// [`self_intersecting_faces`].
pub fn self_intersecting_pairs(
    mesh: &TriMesh,
    faces: &[u32],
    budget: usize,
) -> Result<Option<Vec<[u32; 2]>>, SpatialError> {
    let mut faces = faces.to_vec();
    faces.sort_unstable();
    faces.dedup();
    let tree = TriangleBvh::with_faces(mesh, faces.iter().copied())?;
    Ok(pairs_within(&tree, budget))
}

/// Every pair `[f, g]` (`f < g`, sorted) of faces of `mesh` that intersect away from what they
/// share: [`self_intersecting_pairs`] of all its faces, whatever the number of overlapping boxes
/// (for a mesh searched once, such as a rest pose). Each pair of faces is tested once, and only
/// with [`super::triangles_intersect_away_from_shared`]: adjacent faces always touch, and the
/// closed test of the shared corners is the slow one of exact arithmetic.
/// Errors: a non-finite coordinate.
pub fn all_self_intersecting_pairs(mesh: &TriMesh) -> Result<Vec<[u32; 2]>, SpatialError> {
    let tree = TriangleBvh::new(mesh)?;
    Ok(pairs_within(&tree, usize::MAX).unwrap_or_default())
}

/// The intersecting pairs of a tree's faces (see [`self_intersecting_pairs`]), or `None` past
/// `budget` pairs of overlapping boxes.
fn pairs_within(tree: &TriangleBvh, budget: usize) -> Option<Vec<[u32; 2]>> {
    let candidates = overlapping_leaf_pairs(tree, budget)?;
    Work::count_queries(tree.len() as u64);
    Some(intersecting_leaf_pairs(tree, &candidates, intersect_away_from_shared))
}

/// Every pair of leaves of `tree` whose boxes overlap, or `None` past `budget` of them.
fn overlapping_leaf_pairs(tree: &TriangleBvh, budget: usize) -> Option<Vec<[u32; 2]>> {
    let mut candidates: Vec<[u32; 2]> = Vec::new();
    let mut within_budget = true;
    tree.bvh.for_each_overlapping_pair_within(|i, j| {
        within_budget = candidates.len() < budget;
        if within_budget {
            candidates.push([i, j]);
        }
        within_budget
    });
    within_budget.then_some(candidates)
}

/// Pairs of faces with overlapping boxes, per face enumerated, past which self-contact's counts
/// search face by face rather than enumerate the intersecting pairs (a fan, a soup): the budget
/// its callers give [`self_intersecting_pairs`] and [`IntersectingPairs`].
pub const PAIRS_PER_FACE: usize = 64;

/// The distinct faces of `pairs`, sorted.
pub fn faces_of_pairs(pairs: impl IntoIterator<Item = [u32; 2]>) -> Vec<u32> {
    let mut faces: Vec<u32> = pairs.into_iter().flatten().collect();
    faces.sort_unstable();
    faces.dedup();
    faces
}

/// The candidate leaf pairs of `tree` that pass `test` (intersect away from what they share, or
/// touch), as sorted face pairs `[f, g]`, f < g. Their exact tests run in parallel, their work
/// counted on the caller.
fn intersecting_leaf_pairs(
    tree: &TriangleBvh,
    candidates: &[[u32; 2]],
    test: fn(&[DVec3; 3], &[DVec3; 3]) -> bool,
) -> Vec<[u32; 2]> {
    let work = SharedWork::default();
    let mut pairs: Vec<[u32; 2]> = candidates
        .par_iter()
        .with_min_len(256)
        .filter(|&&[i, j]| work.measure(|| test(&tree.corners[i as usize], &tree.corners[j as usize])))
        .map(|&[i, j]| {
            let (f, g) = (tree.faces[i as usize], tree.faces[j as usize]);
            [f.min(g), f.max(g)]
        })
        .collect();
    work.record();
    pairs.par_sort_unstable();
    pairs
}

/// Every intersecting pair of faces of a mesh ([`self_intersecting_pairs`] of all its faces),
/// with the tree and positions they were found at, to enumerate them again after vertices move:
/// the pairs of two unmoved faces are kept, those of a face with a moved corner tested again
/// against the faces its box overlaps, the same pairs as a whole enumeration.
#[derive(Clone, Debug)]
pub struct IntersectingPairs {
    tree: TriangleBvh,
    positions: Vec<DVec3>,
    pairs: Vec<[u32; 2]>,
}

impl IntersectingPairs {
    /// The pairs of `mesh`, or `None` past `budget` pairs of faces with overlapping boxes (see
    /// [`self_intersecting_pairs`]).
    pub fn new(mesh: &TriMesh, budget: usize) -> Result<Option<Self>, SpatialError> {
        let tree = TriangleBvh::new(mesh)?;
        Ok(pairs_within(&tree, budget).map(|pairs| Self { tree, positions: mesh.positions.clone(), pairs }))
    }

    /// The pairs, sorted `[f, g]` with f < g.
    pub fn pairs(&self) -> &[[u32; 2]] {
        &self.pairs
    }

    /// The vertex count of the mesh they were found on.
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }

    /// The pairs of `mesh` (the connectivity these were found on, other positions); false past
    /// `budget` candidate pairs to test (the pairs are then still those of the last positions
    /// counted; enumerate some other way).
    /// Errors: another vertex count, a non-finite coordinate.
    pub fn update(&mut self, mesh: &TriMesh, budget: usize) -> Result<bool, SpatialError> {
        if mesh.positions.len() != self.positions.len() {
            return Err(SpatialError::PositionCount { expected: self.positions.len(), got: mesh.positions.len() });
        }
        let moved: Vec<bool> = mesh.positions.iter().zip(&self.positions).map(|(p, q)| p != q).collect();
        let moved_faces: Vec<u32> = (0..self.tree.len() as u32)
            .filter(|&leaf| self.tree.indices[leaf as usize].iter().any(|&v| moved[v as usize]))
            .collect();
        if moved_faces.is_empty() {
            return Ok(true);
        }
        // The tree follows every call (its boxes are its triangles' at any positions); the pairs
        // and positions only a call within the budget.
        self.tree.refit(&mesh.positions)?;
        let tree = &self.tree;
        // Leaf of each face (the tree holds every face once).
        let mut leaf_of = vec![u32::MAX; mesh.triangles.len()];
        for (leaf, &f) in tree.faces.iter().enumerate() {
            leaf_of[f as usize] = leaf as u32;
        }
        let face_moved = |leaf: u32| tree.indices[leaf as usize].iter().any(|&v| moved[v as usize]);
        let candidates: Option<Vec<[u32; 2]>> = if 2 * moved_faces.len() > tree.len() {
            overlapping_leaf_pairs(tree, budget)
        } else {
            let mut all = Vec::new();
            let mut within_budget = true;
            for &m in &moved_faces {
                let (min, max) = super::bvh::triangle_aabb(&tree.corners[m as usize]);
                tree.bvh.for_each_in_box(min, max, |other| {
                    // A pair of two moved faces is found from its smaller leaf only.
                    if other != m && (!face_moved(other) || m < other) {
                        all.push([m, other]);
                    }
                });
                if all.len() > budget {
                    within_budget = false;
                    break;
                }
            }
            within_budget.then_some(all)
        };
        let Some(candidates) = candidates else { return Ok(false) };
        Work::count_queries(moved_faces.len() as u64);
        let found = intersecting_leaf_pairs(tree, &candidates, intersect_away_from_shared);
        let whole = 2 * moved_faces.len() > tree.len();
        let mut pairs: Vec<[u32; 2]> = if whole {
            found
        } else {
            let unmoved = |f: u32| !face_moved(leaf_of[f as usize]);
            let mut kept: Vec<[u32; 2]> =
                self.pairs.iter().copied().filter(|&[f, g]| unmoved(f) && unmoved(g)).collect();
            kept.extend(found);
            kept
        };
        pairs.par_sort_unstable();
        pairs.dedup();
        self.positions.clone_from(&mesh.positions);
        self.pairs = pairs;
        Ok(true)
    }
}

/// [`self_intersecting_faces`] of `mesh` among `faces`, given `found`: what the same search
/// (same faces, same `related`, which must not depend on positions) found on the same
/// connectivity at the positions `before`. The same faces as a whole search, found by searching
/// only where they can have changed: a pair of faces that both kept their corners intersects as
/// before, so the search runs among the faces with a moved corner, the faces whose boxes touch
/// theirs, and `found`; a pair with a face outside these is a pair of unmoved faces of which one
/// intersected nothing, which still holds. A move of most of the faces searches them whole.
pub fn self_intersecting_faces_after(
    mesh: &TriMesh,
    faces: &[u32],
    related: impl Fn(u32, u32) -> bool + Sync,
    before: &[DVec3],
    found: &[u32],
) -> Result<Vec<u32>, SpatialError> {
    if before.len() != mesh.positions.len() {
        return search(mesh, faces.iter().copied(), &related, false);
    }
    let triangle = |f: u32| {
        mesh.triangles.get(f as usize).ok_or(SpatialError::FaceOutOfRange { face: f, faces: mesh.triangles.len() })
    };
    let mut touched = Vec::new();
    for &f in faces {
        let moved = triangle(f)?.iter().any(|&v| before.get(v as usize) != mesh.positions.get(v as usize));
        if moved {
            touched.push(f);
        }
    }
    if touched.is_empty() {
        return Ok(found.to_vec());
    }
    if 2 * touched.len() > faces.len() {
        return search(mesh, faces.iter().copied(), &related, false);
    }
    let corners = |f: u32| -> Result<[DVec3; 3], SpatialError> {
        let t = triangle(f)?;
        let mut c = [DVec3::ZERO; 3];
        for (c, &v) in c.iter_mut().zip(t) {
            *c = *mesh.positions.get(v as usize).ok_or(MeshError::IndexOutOfRange {
                triangle: f as usize,
                index: v as u64,
                vertices: mesh.positions.len(),
            })?;
        }
        Ok(c)
    };
    let face_box = |f: u32| corners(f).map(Aabb3::from_points);
    let boxes: Vec<Aabb3> = touched.iter().map(|&f| face_box(f)).collect::<Result<_, _>>()?;
    let tree = AabbTree::new(&boxes)?;
    Work::count_queries(faces.len() as u64);
    let mut candidates: Vec<u32> = touched;
    candidates.extend_from_slice(found);
    for &f in faces {
        let mut near = false;
        tree.for_each_overlapping(&face_box(f)?, |_| near = true);
        if near {
            candidates.push(f);
        }
    }
    search(mesh, candidates, &related, false)
}

/// [`self_intersecting_faces`]; with `merge_copies` (only for a relation that holds for every
/// pair), faces at the same three positions are searched once: they coincide, so they intersect
/// each other, and a copy intersects whatever its original does. A mesh of a few vertices and
/// many faces then has only as many faces to search as distinct triples.
fn search(
    mesh: &TriMesh,
    faces: impl IntoIterator<Item = u32>,
    related: &(impl Fn(u32, u32) -> bool + Sync),
    merge_copies: bool,
) -> Result<Vec<u32>, SpatialError> {
    let mut faces: Vec<u32> = faces.into_iter().collect();
    faces.sort_unstable();
    faces.dedup();
    let nv = mesh.positions.len();
    for &f in &faces {
        let tri = mesh
            .triangles
            .get(f as usize)
            .ok_or(SpatialError::FaceOutOfRange { face: f, faces: mesh.triangles.len() })?;
        if let Some(&i) = tri.iter().find(|&&i| i as usize >= nv) {
            return Err(MeshError::IndexOutOfRange { triangle: f as usize, index: i as u64, vertices: nv }.into());
        }
    }
    for (v, p) in mesh.positions.iter().enumerate() {
        if let Some(value) = p.to_array().into_iter().find(|x| !x.is_finite()) {
            return Err(MeshError::NonFiniteCoordinate { vertex: v, value }.into());
        }
    }
    let set = FaceSet::new(mesh, &faces, merge_copies);
    // Each face stops at its first intersecting partner, which depends on the threads' schedule:
    // the work counted is one query per face searched (its tests are not counted).
    Work::count_queries(set.len() as u64);
    let found: Vec<AtomicBool> = (0..set.len()).map(|_| AtomicBool::new(false)).collect();
    for &(k, _) in &set.copies {
        found[k as usize].store(true, Ordering::Relaxed);
    }
    let search = Search { set: &set, found: &found, related };
    // Unshared pairs first with a budget per face (a soup where everything intersects is done
    // here), then the shared ones, then the unshared again for the faces still open (a mesh of
    // few vertices and many faces, where nearly every candidate shares a vertex, is mostly
    // settled by the shared pairs).
    let tree = search.unshared_tree();
    let settled: Vec<AtomicBool> = (0..set.len()).map(|_| AtomicBool::new(false)).collect();
    search.unshared(&tree, Some(UNSHARED_BUDGET), &settled);
    search.around_edges();
    search.around_vertices();
    search.unshared(&tree, None, &settled);
    let mut result: Vec<u32> =
        set.face.iter().zip(&found).filter(|(_, f)| f.load(Ordering::Relaxed)).map(|(&f, _)| f).collect();
    result.extend(set.copies.iter().map(|&(_, f)| f));
    result.sort_unstable();
    Ok(result)
}

/// The non-degenerate faces to search, with their corners and position ids.
struct FaceSet {
    /// Mesh face id of each face.
    face: Vec<u32>,
    corners: Vec<[DVec3; 3]>,
    /// Position ids of the corners (equal coordinates, equal id).
    ids: Vec<[u32; 3]>,
    /// Faces around each position id, in compressed rows.
    star_offsets: Vec<u32>,
    star_faces: Vec<u32>,
    /// Largest coordinate magnitude: the scale of the main tree's margin.
    scale: f64,
    /// Faces left out as copies of a searched face at the same three positions: (the searched
    /// face's index, the copy's mesh face id).
    copies: Vec<(u32, u32)>,
}

impl FaceSet {
    fn new(mesh: &TriMesh, faces: &[u32], merge_copies: bool) -> Self {
        // -0.0 and 0.0 are the same position (as `==` in the exact test says).
        let key = |p: DVec3| (p + DVec3::ZERO).to_array().map(f64::to_bits);
        let mut id_of: HashMap<[u64; 3], u32> = HashMap::new();
        let mut vertex_id = vec![u32::MAX; mesh.positions.len()];
        let mut face = Vec::new();
        let mut corners = Vec::new();
        let mut ids = Vec::new();
        let mut scale = 0.0f64;
        let mut searched: HashMap<[u32; 3], u32> = HashMap::new();
        let mut copies = Vec::new();
        for &f in faces {
            let tri = mesh.triangles[f as usize];
            let c = tri.map(|v| mesh.positions[v as usize]);
            if cross_exact(c[0], c[1], c[2]) == [0.0; 3] {
                continue;
            }
            let t = tri.map(|v| {
                let slot = &mut vertex_id[v as usize];
                if *slot == u32::MAX {
                    let next = id_of.len() as u32;
                    *slot = *id_of.entry(key(mesh.positions[v as usize])).or_insert(next);
                }
                *slot
            });
            if merge_copies {
                let mut sorted = t;
                sorted.sort_unstable();
                if let Some(&k) = searched.get(&sorted) {
                    copies.push((k, f));
                    continue;
                }
                searched.insert(sorted, face.len() as u32);
            }
            scale = c.iter().fold(scale, |m, p| m.max(p.abs().max_element()));
            face.push(f);
            corners.push(c);
            ids.push(t);
        }
        let (star_offsets, star_faces) = faces_around_vertices(id_of.len(), &ids);
        Self { face, corners, ids, star_offsets, star_faces, scale, copies }
    }

    fn len(&self) -> usize {
        self.face.len()
    }

    fn star(&self, id: usize) -> &[u32] {
        &self.star_faces[self.star_offsets[id] as usize..self.star_offsets[id + 1] as usize]
    }

    fn shared(&self, a: u32, b: u32) -> usize {
        let (ia, ib) = (self.ids[a as usize], self.ids[b as usize]);
        ia.iter().filter(|i| ib.contains(i)).count()
    }

    /// The triangle of face `k` as one tree item.
    fn triangle_item(&self, k: u32) -> Item {
        let c = self.corners[k as usize];
        Item { points: [c[0], c[1], c[2], c[0]], len: 3, owner: k, ids: self.ids[k as usize] }
    }
}

struct Search<'a, R> {
    set: &'a FaceSet,
    found: &'a [AtomicBool],
    related: &'a R,
}

impl<R: Fn(u32, u32) -> bool + Sync> Search<'_, R> {
    fn is_found(&self, k: u32) -> bool {
        self.found[k as usize].load(Ordering::Relaxed)
    }

    /// Tests faces `a` and `b` (exactly) and marks both if they intersect; true if they do.
    fn test(&self, a: u32, b: u32, shared: usize) -> bool {
        let set = self.set;
        if !(self.related)(set.face[a as usize], set.face[b as usize]) {
            return false;
        }
        let (ta, tb) = (&set.corners[a as usize], &set.corners[b as usize]);
        let hit = if shared == 0 { intersect(ta, tb) } else { intersect_away_from_shared(ta, tb) };
        if hit {
            self.found[a as usize].store(true, Ordering::Relaxed);
            self.found[b as usize].store(true, Ordering::Relaxed);
        }
        hit
    }

    /// The tree of the faces for [`Self::unshared`].
    fn unshared_tree(&self) -> ObbTree {
        let set = self.set;
        let items: Vec<Item> = (0..set.len() as u32).map(|k| set.triangle_item(k)).collect();
        ObbTree::new(items, MARGIN * set.scale.max(f64::MIN_POSITIVE))
    }

    /// Pairs that share no vertex, each open face visiting at most `budget` candidates; a face
    /// whose query visited all of its candidates is marked in `settled` and not queried again.
    fn unshared(&self, tree: &ObbTree, budget: Option<usize>, settled: &[AtomicBool]) {
        let set = self.set;
        (0..set.len() as u32).into_par_iter().with_min_len(64).for_each(|q| {
            if self.is_found(q) || settled[q as usize].load(Ordering::Relaxed) {
                return;
            }
            let mut left = budget.unwrap_or(usize::MAX);
            let stopped = tree.query(q, set.ids[q as usize], u32::MAX, |s| {
                left = left.saturating_sub(1);
                (set.shared(q, s) == 0 && self.test(q, s, 0)) || left == 0
            });
            if !stopped {
                settled[q as usize].store(true, Ordering::Relaxed);
            }
        });
    }

    /// Pairs that share exactly one vertex, around it.
    fn around_vertices(&self) {
        let set = self.set;
        let ids = set.star_offsets.len() - 1;
        (0..ids).into_par_iter().with_min_len(256).for_each(|v| {
            let star = set.star(v);
            if star.len() < 2 {
                return;
            }
            if star.len() <= SMALL {
                for (i, &a) in star.iter().enumerate() {
                    for &b in &star[i + 1..] {
                        if !(self.is_found(a) && self.is_found(b)) && set.shared(a, b) == 1 {
                            self.test(a, b, 1);
                        }
                    }
                }
                return;
            }
            let open: Vec<u32> = star.iter().copied().filter(|&k| !self.is_found(k)).collect();
            if open.len() <= FEW_OPEN {
                for &a in &open {
                    for &b in star {
                        if a != b && !self.is_found(a) && set.shared(a, b) == 1 {
                            self.test(a, b, 1);
                        }
                    }
                }
                return;
            }
            let mut items = Vec::with_capacity(star.len() + star.len() / 4);
            for &k in star {
                wedge_items(set, k, v as u32, &mut items);
            }
            let first_item: Vec<u32> = {
                let mut first = Vec::with_capacity(star.len() + 1);
                let mut last = u32::MAX;
                for (i, item) in items.iter().enumerate() {
                    if item.owner != last {
                        first.push(i as u32);
                        last = item.owner;
                    }
                }
                first.push(items.len() as u32);
                first
            };
            let tree = ObbTree::new(items, MARGIN);
            let items = tree.items();
            first_item.par_windows(2).with_min_len(64).for_each(|w| {
                let q = items[w[0] as usize].owner;
                for item in w[0]..w[1] {
                    if self.is_found(q) {
                        return;
                    }
                    let visit = |i: u32| {
                        let s = items[i as usize].owner;
                        s != q && set.shared(q, s) == 1 && self.test(q, s, 1)
                    };
                    if tree.query(item, set.ids[q as usize], v as u32, visit) {
                        return;
                    }
                }
            });
        });
    }

    /// Pairs that share an edge (two or three vertices), around each edge.
    fn around_edges(&self) {
        let set = self.set;
        let mut pages: Vec<([u32; 2], u32)> = Vec::with_capacity(3 * set.len());
        for (k, t) in set.ids.iter().enumerate() {
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                pages.push(([a.min(b), a.max(b)], k as u32));
            }
        }
        pages.par_sort_unstable();
        let groups: Vec<&[([u32; 2], u32)]> = pages.chunk_by(|x, y| x.0 == y.0).filter(|g| g.len() >= 2).collect();
        groups.par_iter().with_min_len(256).for_each(|group| {
            let faces: Vec<u32> = group.iter().map(|p| p.1).collect();
            if faces.len() <= SMALL {
                for (i, &a) in faces.iter().enumerate() {
                    for &b in &faces[i + 1..] {
                        if !(self.is_found(a) && self.is_found(b)) {
                            self.test(a, b, set.shared(a, b));
                        }
                    }
                }
                return;
            }
            self.book(group[0].0, &faces);
        });
    }

    /// Many faces around one edge: only faces at the same angle about it can overlap.
    fn book(&self, edge: [u32; 2], faces: &[u32]) {
        let set = self.set;
        let position = |face: u32, id: u32| {
            let k = face as usize;
            set.corners[k][set.ids[k].iter().position(|&i| i == id).unwrap_or(0)]
        };
        let (v, w) = (position(faces[0], edge[0]), position(faces[0], edge[1]));
        let axis = (w - v).normalize_or_zero();
        let x0 = axis.any_orthonormal_vector();
        let y0 = axis.cross(x0);
        // (angle, its round-off bound, face): the bound grows as the third corner nears the
        // edge's line, where the angle is ill-conditioned.
        let mut around: Vec<(f64, f64, u32)> = faces
            .iter()
            .map(|&f| {
                let k = f as usize;
                let third = (0..3).find(|&c| !edge.contains(&set.ids[k][c])).unwrap_or(0);
                let d = set.corners[k][third] - v;
                let q = d - axis * d.dot(axis);
                let bound = 1e-9 * (d.length() + v.length()) / q.length().max(f64::MIN_POSITIVE) + 1e-12;
                (q.dot(y0).atan2(q.dot(x0)), bound, f)
            })
            .collect();
        around.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2)));
        let widest = around.iter().map(|a| a.1).fold(0.0, f64::max);
        let n = around.len();
        for i in 0..n {
            let (angle, bound, a) = around[i];
            // Neighbours up the circle (wrapping once past π), while they may be at the same angle.
            for step in 1..n {
                let (other, other_bound, b) = around[(i + step) % n];
                let gap = if i + step < n { other - angle } else { other + std::f64::consts::TAU - angle };
                if gap > bound + widest {
                    break;
                }
                if gap <= bound + other_bound && !(self.is_found(a) && self.is_found(b)) {
                    self.test(a, b, set.shared(a, b));
                }
            }
        }
    }
}

/// The items bounding the wedge of face `k` at its corner of position id `v` (see the module
/// docs): one quadrilateral, or two for a wedge wider than 75°.
fn wedge_items(set: &FaceSet, k: u32, v: u32, items: &mut Vec<Item>) {
    let c = set.corners[k as usize];
    let ids = set.ids[k as usize];
    let at = ids.iter().position(|&i| i == v).unwrap_or(0);
    let (p, pa, pb) = (c[at], c[(at + 1) % 3], c[(at + 2) % 3]);
    let (a, b) = ((pa - p).normalize_or_zero(), (pb - p).normalize_or_zero());
    let mut push = |a: DVec3, b: DVec3| {
        items.push(Item { points: [a * 0.5, b * 0.5, b, a], len: 4, owner: k, ids });
    };
    if a.dot(b) >= 0.25 {
        push(a, b);
    } else {
        // The bisector, from the normal so that it stays defined when a and b are nearly opposite.
        let normal = a.cross(b);
        let mid = normal.cross(a - b).normalize_or_zero();
        push(a, mid);
        push(mid, b);
    }
}

/// Intersecting face pairs `[face of a, face of b]` of two meshes (touching counts), sorted.
pub fn mesh_intersections(a: &TriMesh, b: &TriMesh) -> Result<Vec<[u32; 2]>, SpatialError> {
    Ok(TriangleBvh::new(a)?.intersections_with(&TriangleBvh::new(b)?))
}

impl TriangleBvh {
    /// Intersecting pairs `[face of self, face of other]` (closed triangles: touching counts),
    /// sorted.
    pub fn intersections_with(&self, other: &TriangleBvh) -> Vec<[u32; 2]> {
        // The leaf pairs whose boxes overlap, by one joint descent of the two trees (a query per
        // face of `self` costs its whole size even when the meshes barely overlap), then the
        // exact tests in parallel.
        let mut candidates: Vec<[u32; 2]> = Vec::new();
        self.bvh.for_each_overlapping_pair(&other.bvh, |i, j| candidates.push([i, j]));
        let work = SharedWork::default();
        let mut pairs: Vec<[u32; 2]> = candidates
            .par_iter()
            .with_min_len(256)
            .filter(|&&[i, j]| {
                work.measure(|| triangles_intersect(&self.corners[i as usize], &other.corners[j as usize]))
            })
            .map(|&[i, j]| [self.faces[i as usize], other.faces[j as usize]])
            .collect();
        Work::count_queries(1);
        work.record();
        pairs.par_sort_unstable();
        pairs.dedup();
        pairs
    }
}

impl TriangleBvh {
    /// Intersecting pairs `[f, g]` (f < g, closed triangles: touching counts) of the tree's own
    /// faces that `keep(f, g)` admits, sorted: the pairs of [`Self::intersections_with`] the tree
    /// itself with f < g that `keep` admits, testing only those (adjacent faces always touch, and
    /// their exact tests are the slow ones).
    pub fn intersections_within(&self, keep: impl Fn(u32, u32) -> bool) -> Vec<[u32; 2]> {
        let mut candidates: Vec<[u32; 2]> = Vec::new();
        self.bvh.for_each_overlapping_pair_within(|i, j| {
            let (f, g) = (self.faces[i as usize], self.faces[j as usize]);
            if f != g && keep(f.min(g), f.max(g)) {
                candidates.push([i, j]);
            }
            true
        });
        let mut pairs = intersecting_leaf_pairs(self, &candidates, triangles_intersect);
        Work::count_queries(1);
        pairs.dedup();
        pairs
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::mesh::shapes;
    use crate::spatial::test_meshes::bunny;
    use glam::DVec3;

    /// A seeded generator of numbers in [0, 1).
    fn xorshift(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The faces in some intersecting pair, by testing every pair.
    fn brute_force(mesh: &TriMesh) -> Vec<u32> {
        let n = mesh.num_triangles();
        let mut faces = Vec::new();
        for i in 0..n {
            if (0..n).any(|j| j != i && triangles_intersect_away_from_shared(&mesh.corners(i), &mesh.corners(j))) {
                faces.push(i as u32);
            }
        }
        faces
    }

    #[test]
    fn clean_closed_meshes_have_no_self_intersection() {
        for mesh in [
            shapes::icosphere(1.0, 4),
            shapes::cube(2.0, 5),
            shapes::capsule(0.5, 2.0, 24, 6, 5),
            shapes::grid(1.0, 1.0, 7, 5),
        ] {
            let found = self_intersections(&mesh).unwrap();
            assert!(found.faces.is_empty(), "{:?}", &found.faces[..found.faces.len().min(5)]);
        }
    }

    #[test]
    fn bunny_has_no_self_intersection() {
        let Some(mesh) = bunny() else {
            return;
        };
        assert!(mesh.num_triangles() > 6000);
        let found = self_intersections(&mesh).unwrap();
        assert_eq!(found.faces.len(), 0, "{:?}", &found.faces[..found.faces.len().min(5)]);
    }

    #[test]
    fn two_overlapping_spheres_in_one_mesh_report_exactly_the_crossing_faces() {
        let mut mesh = shapes::icosphere(1.0, 2);
        let mut other = shapes::icosphere(0.8, 2);
        other.map_positions(|p| p + DVec3::new(1.1, 0.2, 0.1));
        mesh.append(&other);
        let found = self_intersections(&mesh).unwrap();
        let expected = brute_force(&mesh);
        assert!(!expected.is_empty());
        assert_eq!(found.faces, expected);
        let n0 = 320;
        assert!(found.faces.iter().any(|&f| f < n0) && found.faces.iter().any(|&f| f >= n0));
        // The two-mesh version finds pairs between exactly those faces.
        let a = shapes::icosphere(1.0, 2);
        let between = mesh_intersections(&a, &other).unwrap();
        let mut faces: Vec<u32> = between.iter().flat_map(|&[f, g]| [f, g + n0]).collect();
        faces.sort_unstable();
        faces.dedup();
        assert_eq!(faces, expected);
        // Restricted to a relation: faces of the first sphere with faces of the second only.
        let across =
            self_intersecting_faces(&mesh, 0..mesh.num_triangles() as u32, |f, g| (f < n0) != (g < n0)).unwrap();
        assert_eq!(across, expected);
        let within =
            self_intersecting_faces(&mesh, 0..mesh.num_triangles() as u32, |f, g| (f < n0) == (g < n0)).unwrap();
        assert!(within.is_empty(), "{within:?}");
    }

    #[test]
    fn searching_again_after_a_move_finds_the_faces_of_a_whole_search() {
        // Two spheres of one mesh; the faces searched are every other face, the relation "one
        // face of each sphere"; the second sphere moves a few vertices at a time through the
        // first and back.
        let mut mesh = shapes::icosphere(1.0, 2);
        let mut other = shapes::icosphere(0.8, 2);
        other.map_positions(|p| p + DVec3::new(2.0, 0.0, 0.0));
        mesh.append(&other);
        let n0 = 320u32;
        let faces: Vec<u32> = (0..mesh.num_triangles() as u32).filter(|f| f % 2 == 0).collect();
        let related = |f: u32, g: u32| (f < n0) != (g < n0);
        let whole = |m: &TriMesh| self_intersecting_faces(m, faces.iter().copied(), related).unwrap();
        let mut before = (mesh.positions.clone(), whole(&mesh));
        assert!(before.1.is_empty());
        let first = mesh.positions.len() / 2;
        let mut seen = false;
        for step in 0..30usize {
            let start = first + (step * 29) % (mesh.positions.len() - first - 10);
            for p in &mut mesh.positions[start..start + 10] {
                p.x -= if step % 6 == 5 { -0.5 } else { 0.35 };
            }
            let found = self_intersecting_faces_after(&mesh, &faces, related, &before.0, &before.1).unwrap();
            let expected = whole(&mesh);
            assert_eq!(found, expected, "step {step}");
            seen |= !expected.is_empty();
            before = (mesh.positions.clone(), found);
        }
        assert!(seen);
    }

    #[test]
    fn fold_over_and_duplicate_faces_are_reported() {
        // A grid with one vertex pushed across its neighbours in the plane: the faces around it
        // fold over the adjacent ones.
        let mut mesh = shapes::grid(4.0, 4.0, 4, 4);
        let center = 12; // (2, 2) in a 5 × 5 vertex grid
        assert_eq!(mesh.positions[center], DVec3::ZERO);
        mesh.positions[center] = DVec3::new(1.5, 0.3, 0.0);
        let found = self_intersections(&mesh).unwrap();
        assert_eq!(found.faces, brute_force(&mesh));
        assert!(!found.faces.is_empty());
        // The same mesh lifted out of the plane at that vertex is clean (no overlap).
        let mut lifted = shapes::grid(4.0, 4.0, 4, 4);
        lifted.positions[center].z = 0.7;
        assert!(self_intersections(&lifted).unwrap().faces.is_empty());
        // A duplicated face intersects its twin.
        let mut twin = shapes::icosphere(1.0, 1);
        let t = twin.triangles[3];
        twin.triangles.push(t);
        let found = self_intersections(&twin).unwrap();
        assert_eq!(found.faces, vec![3, twin.num_triangles() as u32 - 1]);
    }

    /// A seeded soup of random triangles, including fans around shared vertices, duplicated
    /// positions under other ids, books of faces on one edge and collinear edges: the faces
    /// found are exactly the brute force's.
    #[test]
    fn random_soups_match_the_brute_force() {
        let mut next = xorshift(0x5EED);
        for round in 0..12 {
            let mut positions: Vec<DVec3> = (0..40)
                .map(|_| DVec3::new((next() * 4.0).round(), (next() * 4.0).round(), (next() * 2.0).round()) * 0.5)
                .collect();
            // Copies of some positions under new ids (coincident vertices).
            for i in 0..8 {
                positions.push(positions[i * 3]);
            }
            let nv = positions.len();
            let mut pick = || (next() * nv as f64) as u32 % nv as u32;
            let mut triangles: Vec<[u32; 3]> = (0..60).map(|_| [pick(), pick(), pick()]).collect();
            // A big fan (a star over SMALL) and a big book (an edge over SMALL).
            let apex = pick();
            for _ in 0..30 {
                triangles.push([apex, pick(), pick()]);
            }
            let (u, v) = (pick(), pick());
            for _ in 0..30 {
                triangles.push([u, v, pick()]);
            }
            triangles.retain(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
            let mesh = TriMesh::new(positions, triangles).unwrap();
            let found = self_intersections(&mesh).unwrap();
            assert_eq!(found.faces, brute_force(&mesh), "round {round}");
        }
    }

    /// The enumerated pairs are the brute force's, and the faces of the pairs within any subset,
    /// for any relation, are those the face search finds; too many overlapping boxes give None.
    #[test]
    fn enumerated_pairs_give_the_faces_of_every_search() {
        let mut next = xorshift(0xC0FFEE);
        let mut two_spheres = shapes::icosphere(1.0, 2);
        let mut other = shapes::icosphere(0.8, 2);
        other.map_positions(|p| p + DVec3::new(1.2, 0.1, 0.0));
        two_spheres.append(&other);
        for round in 0..8 {
            let mesh = if round == 0 {
                two_spheres.clone()
            } else {
                let positions: Vec<DVec3> = (0..30)
                    .map(|_| DVec3::new((next() * 4.0).round(), (next() * 4.0).round(), (next() * 2.0).round()) * 0.5)
                    .collect();
                let mut pick = || (next() * 30.0) as u32 % 30;
                let mut triangles: Vec<[u32; 3]> = (0..80).map(|_| [pick(), pick(), pick()]).collect();
                triangles.retain(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
                TriMesh::new(positions, triangles).unwrap()
            };
            let n = mesh.num_triangles() as u32;
            let all: Vec<u32> = (0..n).collect();
            let pairs = self_intersecting_pairs(&mesh, &all, usize::MAX).unwrap().unwrap();
            let brute: Vec<[u32; 2]> = (0..n)
                .flat_map(|f| (f + 1..n).map(move |g| [f, g]))
                .filter(|&[f, g]| {
                    triangles_intersect_away_from_shared(&mesh.corners(f as usize), &mesh.corners(g as usize))
                })
                .collect();
            assert_eq!(pairs, brute, "round {round}");
            assert!(!pairs.is_empty(), "round {round}");
            // Without a budget, and tested away from the shared corners only: the same pairs as
            // the closed test and then that one (touching at a shared corner is no intersection).
            assert_eq!(all_self_intersecting_pairs(&mesh).unwrap(), brute, "round {round}");
            let closed_then_away: Vec<[u32; 2]> = (0..n)
                .flat_map(|f| (f + 1..n).map(move |g| [f, g]))
                .filter(|&[f, g]| {
                    let (a, b) = (mesh.corners(f as usize), mesh.corners(g as usize));
                    triangles_intersect(&a, &b) && triangles_intersect_away_from_shared(&a, &b)
                })
                .collect();
            assert_eq!(closed_then_away, brute, "round {round}");
            for k in 0..6u32 {
                let subset: Vec<u32> = (0..n).filter(|f| (f * 7 + k) % 5 != 0 || k == 0).collect();
                let related = |f: u32, g: u32| k.is_multiple_of(2) || f.is_multiple_of(3) != g.is_multiple_of(3);
                let searched = self_intersecting_faces(&mesh, subset.iter().copied(), related).unwrap();
                let member = |f: u32| subset.binary_search(&f).is_ok();
                let from_pairs =
                    faces_of_pairs(pairs.iter().copied().filter(|&[f, g]| member(f) && member(g) && related(f, g)));
                assert_eq!(from_pairs, searched, "round {round}, subset {k}");
            }
        }
        // A fan: every face's box overlaps every other's near the apex; a budget of 10 per face is
        // exceeded.
        let count = 400u32;
        let mut fan = TriMesh { positions: vec![DVec3::ZERO], triangles: Vec::new() };
        fan.positions.extend((0..count).map(|i| {
            let a = std::f64::consts::TAU * f64::from(i) / f64::from(count);
            DVec3::new(a.cos(), a.sin(), 0.0)
        }));
        fan.triangles.extend((0..count).map(|i| [0, 1 + i, 1 + (i + 1) % count]));
        let faces: Vec<u32> = (0..count).collect();
        assert!(self_intersecting_pairs(&fan, &faces, 10 * faces.len()).unwrap().is_none());
        assert_eq!(self_intersecting_pairs(&fan, &faces, usize::MAX).unwrap(), Some(Vec::new()));
    }

    #[test]
    fn pairs_enumerated_again_after_a_move_are_those_of_a_whole_enumeration() {
        // Two spheres of one mesh, the second moved a few vertices at a time through the first
        // and back, and now and then as a whole.
        let mut mesh = shapes::icosphere(1.0, 2);
        let mut other = shapes::icosphere(0.8, 2);
        other.map_positions(|p| p + DVec3::new(1.9, 0.0, 0.0));
        mesh.append(&other);
        let mut pairs = IntersectingPairs::new(&mesh, usize::MAX).unwrap().unwrap();
        let first = mesh.positions.len() / 2;
        let mut seen = false;
        for step in 0..30usize {
            if step % 10 == 9 {
                for p in &mut mesh.positions[first..] {
                    p.y += 0.05;
                }
            } else {
                let start = first + (step * 29) % (mesh.positions.len() - first - 10);
                for p in &mut mesh.positions[start..start + 10] {
                    p.x -= if step % 6 == 5 { -0.5 } else { 0.35 };
                }
            }
            assert!(pairs.update(&mesh, usize::MAX).unwrap());
            let whole = IntersectingPairs::new(&mesh, usize::MAX).unwrap().unwrap();
            assert_eq!(pairs.pairs(), whole.pairs(), "step {step}");
            seen |= !whole.pairs().is_empty();
        }
        assert!(seen);
        // Past the budget: false, and the next update within it is still exact.
        mesh.positions[first] += DVec3::new(-0.3, 0.0, 0.0);
        assert!(!pairs.update(&mesh, 0).unwrap());
        mesh.positions[first + 1] += DVec3::new(-0.3, 0.0, 0.0);
        assert!(pairs.update(&mesh, usize::MAX).unwrap());
        assert_eq!(pairs.pairs(), IntersectingPairs::new(&mesh, usize::MAX).unwrap().unwrap().pairs());
    }

    /// Issue 28: shapes that made the analysis quadratic give the right answer: a flat fan, an
    /// n-gon fanned from one corner, the fan with its apex duplicated per face (coincident
    /// vertices), diagonal slivers and a folded fan.
    #[test]
    fn fans_slivers_and_coincident_vertices() {
        let n = 3000;
        let ring = |i: usize| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            DVec3::new(a.cos(), a.sin(), 0.0)
        };
        let mut fan = TriMesh { positions: vec![DVec3::ZERO], triangles: Vec::new() };
        fan.positions.extend((0..n).map(ring));
        fan.triangles.extend((0..n as u32).map(|i| [0, 1 + i, 1 + (i + 1) % n as u32]));
        assert!(self_intersections(&fan).unwrap().faces.is_empty());
        let ngon = TriMesh {
            positions: (0..n).map(ring).collect(),
            triangles: (1..n as u32 - 1).map(|i| [0, i, i + 1]).collect(),
        };
        assert!(self_intersections(&ngon).unwrap().faces.is_empty());
        let mut soup = TriMesh { positions: Vec::new(), triangles: Vec::new() };
        for t in &fan.triangles {
            let base = soup.positions.len() as u32;
            soup.positions.extend(t.map(|v| fan.positions[v as usize]));
            soup.triangles.push([base, base + 1, base + 2]);
        }
        assert!(self_intersections(&soup).unwrap().faces.is_empty());
        // One rim vertex pulled across its neighbours folds its two faces over theirs.
        let mut folded = fan.clone();
        folded.positions[1 + n / 2] = ring(n / 2 + 3);
        let found = self_intersections(&folded).unwrap().faces;
        assert!(found.contains(&(n as u32 / 2)) && found.len() <= 8, "{found:?}");
        // A sheet of parallel diagonal strips, two triangles each.
        let strips = 2000;
        let (along, across) = (DVec3::new(1.0, 1.0, 0.3).normalize(), DVec3::new(-1.0, 1.0, 0.0).normalize());
        let mut sheet = TriMesh { positions: Vec::new(), triangles: Vec::new() };
        for i in 0..=strips {
            let o = across * (i as f64 / strips as f64);
            sheet.positions.push(o);
            sheet.positions.push(o + along);
        }
        for i in 0..strips as u32 {
            sheet.triangles.push([2 * i, 2 * i + 2, 2 * i + 1]);
            sheet.triangles.push([2 * i + 1, 2 * i + 2, 2 * i + 3]);
        }
        assert!(self_intersections(&sheet).unwrap().faces.is_empty());
    }
}
