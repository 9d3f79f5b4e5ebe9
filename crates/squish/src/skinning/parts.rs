//! The parts of a skinned mesh and the pairs of parts that touch at a frame (self-contact beyond
//! one articulation, issue 27).
//!
//! **Parts** ([`parts_from_skin`]). Each vertex's *dominant joint* is the joint of its largest
//! weight (ties: the smallest joint id); each face takes the joint most of its three vertices
//! have (a three-way tie: its first vertex's). The faces of one joint form its part; a part of
//! fewer than `min_faces` faces joins its parent joint's part, children before parents, so a
//! chain of small joints (fingers, toes) ends up in the first joint large enough. Parts are
//! numbered in the order of their joints and named after them. Parts may also be painted: one
//! label per face ([`SkinParts::from_face_labels`]).
//!
//! **Touching pairs** ([`PartContactSetup::touching`]). At a frame, two faces touch when they
//! intersect (exact closed-triangle test over one triangle tree of the posed mesh), except
//! - faces sharing a vertex — by *position in the rest pose*, so that faces across a UV or
//!   normal seam (duplicated vertices) count as neighbours: they always touch there;
//! - face pairs that already intersect in the rest pose (the asset's own self-intersections,
//!   computed once): the character is not to be repaired, only its animation.
//!
//! They are grouped by what touches ([`TouchingKind`]): two parts that are not parent and child;
//! a parent and a child (their fold is first the articulation's, ch. 6 — what it leaves is
//! resolved as a contact); or a **fold within one part** (a chest creasing under a raised
//! collarbone), where the two sheets of the fold are found by two-colouring the intersecting
//! faces (faces that cross are on opposite sides, faces sharing a vertex on the same side), each
//! connected cluster its own pair. Sorted by part pair, kind and face pair: the result does not
//! depend on the thread count.

use std::collections::BTreeMap;

use glam::DVec3;

use super::SkinWeights;
use crate::mesh::TriMesh;
use crate::params::SkinParts;
use crate::spatial::{SpatialError, TriangleBvh};

/// The dominant joint of every vertex (see the module doc); `None` for an unskinned vertex.
pub fn dominant_joints(weights: &SkinWeights) -> Vec<Option<u32>> {
    weights
        .joints()
        .iter()
        .zip(weights.weights())
        .map(|(joints, w)| {
            let mut best: Option<(f64, u32)> = None;
            for (&j, &wj) in joints.iter().zip(w) {
                if wj <= 0.0 {
                    continue;
                }
                best = match best {
                    Some((bw, bj)) if bw > wj || (bw == wj && bj < j) => Some((bw, bj)),
                    _ => Some((wj, j)),
                };
            }
            best.map(|(_, j)| j)
        })
        .collect()
}

/// The parts of a skinned mesh (see the module doc). `parents[j]` is joint j's parent within the
/// skin, `names[j]` its name; `min_faces` the smallest part kept on its own. Unskinned faces
/// (no vertex with a weight) join the root of the first joint.
pub fn parts_from_skin(
    mesh: &TriMesh,
    weights: &SkinWeights,
    parents: &[Option<usize>],
    names: &[String],
    min_faces: usize,
) -> SkinParts {
    let dominant = dominant_joints(weights);
    let joint_count = parents.len();
    let face_joint: Vec<usize> = mesh
        .triangles
        .iter()
        .map(|t| {
            let js: Vec<Option<u32>> = t.iter().map(|&v| dominant.get(v as usize).copied().flatten()).collect();
            let pick = if js[1] == js[2] { js[1].or(js[0]) } else { js[0].or(js[1]).or(js[2]) };
            pick.map_or(0, |j| (j as usize).min(joint_count.saturating_sub(1)))
        })
        .collect();
    // Joint of each joint's part after merging: children (deeper) first.
    let depth = |mut j: usize| {
        let mut d = 0;
        while let Some(p) = parents.get(j).copied().flatten() {
            d += 1;
            j = p;
            if d > joint_count {
                break;
            }
        }
        d
    };
    let mut order: Vec<usize> = (0..joint_count).collect();
    order.sort_by_key(|&j| (std::cmp::Reverse(depth(j)), j));
    let mut counts = vec![0usize; joint_count.max(1)];
    for &j in &face_joint {
        counts[j] += 1;
    }
    let mut target: Vec<usize> = (0..joint_count.max(1)).collect();
    for &j in &order {
        if counts[j] > 0
            && counts[j] < min_faces
            && let Some(p) = parents[j]
        {
            counts[p] += counts[j];
            counts[j] = 0;
            target[j] = p;
        }
    }
    let resolve = |mut j: usize| {
        while target[j] != j {
            j = target[j];
        }
        j
    };
    let kept: Vec<usize> = (0..joint_count.max(1)).filter(|&j| counts[j] > 0 && target[j] == j).collect();
    let mut index = vec![u32::MAX; joint_count.max(1)];
    for (k, &j) in kept.iter().enumerate() {
        index[j] = k as u32;
    }
    let face_parts = face_joint.iter().map(|&j| index[resolve(j)]).collect();
    let part_names = kept.iter().map(|&j| names.get(j).cloned().unwrap_or_else(|| format!("joint {j}"))).collect();
    let part_joints: Vec<usize> = kept.clone();
    // Parent/child parts: the part of a kept joint's nearest kept ancestor.
    let mut adjacent = Vec::new();
    for (k, &j) in part_joints.iter().enumerate() {
        let mut p = parents[j];
        while let Some(q) = p {
            if index[q] != u32::MAX && target[q] == q {
                let (a, b) = (index[q].min(k as u32), index[q].max(k as u32));
                adjacent.push([a, b]);
                break;
            }
            p = parents[q];
        }
    }
    adjacent.sort_unstable();
    adjacent.dedup();
    SkinParts { face_parts, names: part_names, parent_child: adjacent }
}

/// One part pair touching at a frame, or one fold within a part.
#[derive(Clone, Debug, PartialEq)]
pub struct TouchingPair {
    /// The two parts, `parts[0] <= parts[1]` (equal for a fold within one part).
    pub parts: [u32; 2],
    /// What touches: two parts, what a parent/child articulation left, or a fold of one part.
    pub kind: TouchingKind,
    /// The intersecting face pairs `[face of side 1, face of side 2]`, sorted: for two parts,
    /// side 1 is `parts[0]`; within a part, the sides of the fold (see the module doc).
    pub faces: Vec<[u32; 2]>,
}

/// What a [`TouchingPair`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum TouchingKind {
    /// Two parts that are not parent and child.
    Parts,
    /// A parent and a child part still intersecting after their articulation (ch. 6).
    AfterArticulation,
    /// Cluster k of a part's faces intersecting faces of the same part.
    WithinPart(u32),
}

/// What the part contacts of an object keep between frames: the rest pose's vertex welding and
/// self-intersections, and a triangle tree refitted per frame.
#[derive(Debug)]
pub struct PartContactSetup {
    triangles: Vec<[u32; 3]>,
    rest: Vec<DVec3>,
    /// Per vertex: the smallest vertex id at the same rest position.
    position_id: Vec<u32>,
    /// Face pairs `[f, g]` (f < g), not adjacent, that intersect in the rest pose, sorted.
    rest_pairs: Vec<[u32; 2]>,
    tree: TriangleBvh,
}

impl PartContactSetup {
    /// Builds the caches for a mesh of this connectivity at rest pose `rest`.
    pub fn new(rest: &TriMesh) -> Result<Self, SpatialError> {
        let mut first: BTreeMap<[u64; 3], u32> = BTreeMap::new();
        let position_id = rest
            .positions
            .iter()
            .enumerate()
            .map(|(v, p)| *first.entry([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]).or_insert(v as u32))
            .collect();
        let tree = TriangleBvh::new(rest)?;
        let mut setup = Self {
            triangles: rest.triangles.clone(),
            rest: rest.positions.clone(),
            position_id,
            rest_pairs: Vec::new(),
            tree,
        };
        setup.rest_pairs = setup.candidate_pairs();
        Ok(setup)
    }

    /// True if built for this connectivity and rest pose.
    pub fn matches(&self, rest: &TriMesh) -> bool {
        self.triangles == rest.triangles && self.rest == rest.positions
    }

    /// Face pairs of the rest pose excluded at every frame.
    pub fn rest_pairs(&self) -> &[[u32; 2]] {
        &self.rest_pairs
    }

    /// Per vertex: the smallest vertex id at the same rest position.
    pub fn position_ids(&self) -> &[u32] {
        &self.position_id
    }

    /// True if faces f and g share a vertex by rest position.
    pub fn adjacent(&self, f: u32, g: u32) -> bool {
        let (a, b) = (&self.triangles[f as usize], &self.triangles[g as usize]);
        a.iter().any(|&u| b.iter().any(|&w| self.position_id[u as usize] == self.position_id[w as usize]))
    }

    /// Intersecting face pairs of the tree's current positions, not adjacent; sorted `[f, g]`,
    /// f < g.
    fn candidate_pairs(&self) -> Vec<[u32; 2]> {
        self.tree.intersections_within(|f, g| !self.adjacent(f, g))
    }

    /// The part pairs and folds touching in `mesh` (this connectivity, any pose), beyond the
    /// rest pose's own intersections, sorted by parts and kind (see the module doc).
    pub fn touching(&mut self, mesh: &TriMesh, parts: &SkinParts) -> Result<Vec<TouchingPair>, SpatialError> {
        self.tree.refit(&mesh.positions)?;
        let mut grouped: BTreeMap<([u32; 2], TouchingKind), Vec<[u32; 2]>> = BTreeMap::new();
        let mut within: BTreeMap<u32, Vec<[u32; 2]>> = BTreeMap::new();
        for [f, g] in self.candidate_pairs() {
            if self.rest_pairs.binary_search(&[f, g]).is_ok() {
                continue;
            }
            let (pf, pg) = (parts.face_parts[f as usize], parts.face_parts[g as usize]);
            if pf == pg {
                within.entry(pf).or_default().push([f, g]);
                continue;
            }
            let kind = if parts.is_left_to_articulations(pf, pg) {
                TouchingKind::AfterArticulation
            } else {
                TouchingKind::Parts
            };
            let (key, pair) = if pf < pg { ([pf, pg], [f, g]) } else { ([pg, pf], [g, f]) };
            grouped.entry((key, kind)).or_default().push(pair);
        }
        for (part, pairs) in within {
            for (k, faces) in self.fold_sides(&pairs).into_iter().enumerate() {
                grouped.insert(([part, part], TouchingKind::WithinPart(k as u32)), faces);
            }
        }
        Ok(grouped
            .into_iter()
            .map(|((parts, kind), mut faces)| {
                faces.sort_unstable();
                TouchingPair { parts, kind, faces }
            })
            .collect())
    }

    /// The clusters of intersecting face pairs within one part, each with its pairs ordered
    /// `[side 1, side 2]`. A fold's two sheets are told apart by two-colouring the graph of its
    /// faces: faces that intersect are on opposite sides, faces sharing a vertex (by rest
    /// position) on the same side; a connected piece of that graph is a cluster. Breadth-first
    /// from the smallest face id, so the result is deterministic; a pair whose faces got the
    /// same side (the sheets meet at a crease within the cluster) is dropped from the seeds.
    fn fold_sides(&self, pairs: &[[u32; 2]]) -> Vec<Vec<[u32; 2]>> {
        let mut faces: Vec<u32> = pairs.iter().flatten().copied().collect();
        faces.sort_unstable();
        faces.dedup();
        let index = |f: u32| faces.binary_search(&f).unwrap_or(0);
        let mut crossing: Vec<Vec<usize>> = vec![Vec::new(); faces.len()];
        for &[f, g] in pairs {
            crossing[index(f)].push(index(g));
            crossing[index(g)].push(index(f));
        }
        // Faces of the clusters sharing a vertex, by rest position.
        let mut by_vertex: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
        for (i, &f) in faces.iter().enumerate() {
            for &v in &self.triangles[f as usize] {
                by_vertex.entry(self.position_id[v as usize]).or_default().push(i);
            }
        }
        let mut touching: Vec<Vec<usize>> = vec![Vec::new(); faces.len()];
        for group in by_vertex.values() {
            for &i in group {
                touching[i].extend(group.iter().copied().filter(|&j| j != i));
            }
        }
        let mut side: Vec<Option<(usize, bool)>> = vec![None; faces.len()];
        let mut clusters = 0;
        for start in 0..faces.len() {
            if side[start].is_some() {
                continue;
            }
            side[start] = Some((clusters, false));
            let mut queue = std::collections::VecDeque::from([start]);
            while let Some(i) = queue.pop_front() {
                let Some((_, s)) = side[i] else { continue };
                let next = crossing[i].iter().map(|&j| (j, !s)).chain(touching[i].iter().map(|&j| (j, s)));
                for (j, sj) in next {
                    if side[j].is_none() {
                        side[j] = Some((clusters, sj));
                        queue.push_back(j);
                    }
                }
            }
            clusters += 1;
        }
        let mut out: Vec<Vec<[u32; 2]>> = vec![Vec::new(); clusters];
        for &[f, g] in pairs {
            if let (Some((k, sf)), Some((_, sg))) = (side[index(f)], side[index(g)])
                && sf != sg
            {
                out[k].push(if sf { [g, f] } else { [f, g] });
            }
        }
        out.retain(|c| !c.is_empty());
        out
    }
}

/// The self-intersections of a rest pose, to count those of a posed mesh beyond them (the
/// asset's own are not the animation's).
#[derive(Clone, Debug)]
pub struct RestIntersections {
    /// Face pairs `[f, g]` (f < g) intersecting away from what they share in the rest pose.
    pairs: Vec<[u32; 2]>,
}

impl RestIntersections {
    pub fn new(rest: &TriMesh) -> Result<Self, SpatialError> {
        Ok(Self { pairs: crate::spatial::all_self_intersecting_pairs(rest)? })
    }

    /// Faces of `mesh` (the rest pose's connectivity) that intersect another face away from
    /// what they share, in a pair that does not intersect in the rest pose; sorted.
    pub fn faces_beyond(&self, mesh: &TriMesh) -> Result<Vec<u32>, SpatialError> {
        crate::spatial::self_intersecting_faces(mesh, 0..mesh.num_triangles() as u32, |f, g| {
            self.pairs.binary_search(&[f.min(g), f.max(g)]).is_err()
        })
    }

    /// [`Self::faces_beyond`] from `pairs`, every intersecting pair of faces of a mesh of the
    /// rest pose's connectivity ([`crate::spatial::IntersectingPairs`]): the faces of those that
    /// do not intersect in the rest pose, sorted; the same faces.
    pub fn faces_beyond_in(&self, pairs: &[[u32; 2]]) -> Vec<u32> {
        crate::spatial::faces_of_pairs(pairs.iter().copied().filter(|p| self.pairs.binary_search(p).is_err()))
    }

    /// True if faces `f < g` intersect in the rest pose.
    pub fn is_rest_pair(&self, pair: [u32; 2]) -> bool {
        self.pairs.binary_search(&pair).is_ok()
    }

    /// [`Self::faces_beyond`] of a whole mesh, kept to count again after some of its vertices
    /// move ([`Self::faces_beyond_after`]).
    pub fn counted(&self, mesh: &TriMesh) -> Result<FacesBeyond, SpatialError> {
        Ok(FacesBeyond { faces: self.faces_beyond(mesh)?, positions: mesh.positions.clone() })
    }

    /// [`Self::faces_beyond`] of `mesh`, the mesh `before` was counted on with some vertices
    /// moved: searched only where they can have changed
    /// ([`crate::spatial::self_intersecting_faces_after`]), the same faces.
    pub fn faces_beyond_after(&self, before: &FacesBeyond, mesh: &TriMesh) -> Result<FacesBeyond, SpatialError> {
        let all: Vec<u32> = (0..mesh.num_triangles() as u32).collect();
        let related = |f: u32, g: u32| self.pairs.binary_search(&[f.min(g), f.max(g)]).is_err();
        let faces =
            crate::spatial::self_intersecting_faces_after(mesh, &all, related, &before.positions, &before.faces)?;
        Ok(FacesBeyond { faces, positions: mesh.positions.clone() })
    }
}

/// The faces [`RestIntersections::faces_beyond`] found on a mesh, with the positions they were
/// found at.
#[derive(Clone, Debug)]
pub struct FacesBeyond {
    /// The faces, sorted.
    pub faces: Vec<u32>,
    positions: Vec<DVec3>,
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::mesh::shapes;

    /// Two capsules of one mesh: the first (joint 1) along z at x = 0, the second (joint 2) at
    /// x = `offset`; joint 0 is their common parent with no vertex of its own.
    fn two_capsules(offset: f64) -> (TriMesh, SkinWeights) {
        let a = shapes::capsule(0.5, 3.0, 16, 6, 8);
        let mut b = a.clone();
        for p in &mut b.positions {
            p.x += offset;
        }
        let n = a.num_vertices() as u32;
        let mut mesh = a.clone();
        mesh.positions.extend(&b.positions);
        mesh.triangles.extend(b.triangles.iter().map(|t| t.map(|v| v + n)));
        let joints = (0..2 * n).map(|v| if v < n { [1, 0, 0, 0] } else { [2, 0, 0, 0] }).collect();
        let weights = vec![[1.0, 0.0, 0.0, 0.0]; 2 * n as usize];
        (mesh, SkinWeights::new(joints, weights).unwrap())
    }

    fn names(k: usize) -> Vec<String> {
        (0..k).map(|j| format!("j{j}")).collect()
    }

    #[test]
    fn sibling_capsules_are_two_parts_with_a_common_parent() {
        let (mesh, weights) = two_capsules(3.0);
        let parts = parts_from_skin(&mesh, &weights, &[None, Some(0), Some(0)], &names(3), 10);
        assert_eq!(parts.names, vec!["j1".to_string(), "j2".to_string()]);
        let half = mesh.num_triangles() / 2;
        assert!(parts.face_parts[..half].iter().all(|&p| p == 0));
        assert!(parts.face_parts[half..].iter().all(|&p| p == 1));
        // Siblings: neither is the other's parent.
        assert!(parts.parent_child.is_empty());
    }

    #[test]
    fn small_parts_join_their_parent() {
        let (mesh, weights) = two_capsules(3.0);
        let half = mesh.num_triangles() / 2;
        // Joint 2 is a child of joint 1; with a minimum above its size it joins joint 1.
        let parts = parts_from_skin(&mesh, &weights, &[None, Some(0), Some(1)], &names(3), half + 1);
        assert!(parts.face_parts.iter().all(|&p| p == 0), "one part left");
        let parts = parts_from_skin(&mesh, &weights, &[None, Some(0), Some(1)], &names(3), half);
        assert_eq!(parts.parent_child, vec![[0, 1]]);
    }

    #[test]
    fn crossing_capsules_touch_and_rest_intersections_are_ignored() {
        let (rest, weights) = two_capsules(3.0);
        let parts = parts_from_skin(&rest, &weights, &[None, Some(0), Some(0)], &names(3), 10);
        let mut setup = PartContactSetup::new(&rest).unwrap();
        assert!(setup.rest_pairs().is_empty());
        assert!(setup.touching(&rest, &parts).unwrap().is_empty());
        let (posed, _) = two_capsules(0.8);
        let touching = setup.touching(&posed, &parts).unwrap();
        assert_eq!(touching.len(), 1);
        assert_eq!(touching[0].parts, [0, 1]);
        assert!(!touching[0].faces.is_empty());
        // The same overlap already in the rest pose is the asset's own.
        let mut setup = PartContactSetup::new(&posed).unwrap();
        assert!(!setup.rest_pairs().is_empty());
        assert!(setup.touching(&posed, &parts).unwrap().is_empty());
        assert_eq!(touching[0].kind, TouchingKind::Parts);
        // A parent and a child: reported as what their articulation leaves.
        let parts = SkinParts { parent_child: vec![[0, 1]], ..parts };
        let mut setup = PartContactSetup::new(&rest).unwrap();
        let left = setup.touching(&posed, &parts).unwrap();
        assert_eq!(left.len(), 1);
        assert_eq!(left[0].kind, TouchingKind::AfterArticulation);
        assert_eq!(left[0].faces, touching[0].faces);
    }

    #[test]
    fn counting_again_after_a_move_finds_the_faces_of_a_whole_search() {
        // Rest: the capsules overlap a little (the asset's own); then the second moves through
        // the first, a few vertices at a time, so faces start and stop crossing, far from and
        // next to the moved ones.
        let (rest, _) = two_capsules(0.95);
        let rest_intersections = RestIntersections::new(&rest).unwrap();
        assert!(!rest_intersections.pairs.is_empty());
        let half = rest.num_vertices() / 2;
        let mut mesh = rest.clone();
        let mut counted = rest_intersections.counted(&mesh).unwrap();
        assert!(counted.faces.is_empty());
        let mut seen_crossing = false;
        for step in 0..40 {
            // Each step moves one band of the second capsule's vertices (by index) toward the
            // first, and every few steps brings one band back out.
            let band = (step * 37) % half;
            for v in half + band..(half + band + 23).min(2 * half) {
                mesh.positions[v].x -= if step % 5 == 4 { -0.2 } else { 0.09 };
            }
            let incremental = rest_intersections.faces_beyond_after(&counted, &mesh).unwrap();
            let whole = rest_intersections.faces_beyond(&mesh).unwrap();
            assert_eq!(incremental.faces, whole, "step {step}");
            seen_crossing |= !whole.is_empty();
            counted = incremental;
        }
        assert!(seen_crossing);
        // Nothing moved: the same faces; everything moved: a whole search.
        assert_eq!(rest_intersections.faces_beyond_after(&counted, &mesh).unwrap().faces, counted.faces);
        let shifted =
            TriMesh { positions: mesh.positions.iter().map(|p| *p * 0.5).collect(), triangles: mesh.triangles.clone() };
        let after = rest_intersections.faces_beyond_after(&counted, &shifted).unwrap();
        assert_eq!(after.faces, rest_intersections.faces_beyond(&shifted).unwrap());
    }

    #[test]
    fn a_fold_within_one_part_is_split_into_its_two_sheets() {
        // The two crossing capsules as one part: one cluster, each pair across the two capsules.
        let (rest, _) = two_capsules(3.0);
        let (posed, _) = two_capsules(0.8);
        let one = SkinParts::from_face_labels(vec![0; rest.num_triangles()]);
        let mut setup = PartContactSetup::new(&rest).unwrap();
        let touching = setup.touching(&posed, &one).unwrap();
        assert_eq!(touching.len(), 1, "{touching:?}");
        assert_eq!(touching[0].kind, TouchingKind::WithinPart(0));
        let half = rest.num_triangles() as u32 / 2;
        let first_side_is_first_capsule = touching[0].faces[0][0] < half;
        for &[f, g] in &touching[0].faces {
            assert_eq!(f < half, first_side_is_first_capsule, "{f} {g}");
            assert_eq!(g < half, !first_side_is_first_capsule, "{f} {g}");
        }
        // Two separate crossings of one part are two clusters.
        let mut two = posed.clone();
        let n = two.num_vertices() as u32;
        two.positions.extend(posed.positions.iter().map(|p| *p + DVec3::new(0.0, 10.0, 0.0)));
        two.triangles.extend(posed.triangles.iter().map(|t| t.map(|v| v + n)));
        let mut rest_two = rest.clone();
        rest_two.positions.extend(rest.positions.iter().map(|p| *p + DVec3::new(0.0, 10.0, 0.0)));
        rest_two.triangles = two.triangles.clone();
        let one = SkinParts::from_face_labels(vec![0; two.num_triangles()]);
        let mut setup = PartContactSetup::new(&rest_two).unwrap();
        let kinds: Vec<TouchingKind> = setup.touching(&two, &one).unwrap().iter().map(|t| t.kind).collect();
        assert_eq!(kinds, vec![TouchingKind::WithinPart(0), TouchingKind::WithinPart(1)]);
    }
}
