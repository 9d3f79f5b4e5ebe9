//! Contacts between parts of one skinned mesh (issue 27): thigh against thigh, hand against hip,
//! arm against torso — the pairs of parts that are not a parent and a child — and what the
//! articulations (ch. 6) leave of a parent and child's fold, and folds within one part. Runs in
//! the self-contact stage, after the articulations, on their result; then what still crosses is
//! untangled ([`super::untangle`], `untangle = true`).
//!
//! At each frame the touching pairs beyond the rest pose's own intersections are found
//! ([`crate::skinning::PartContactSetup::touching`], three kinds: [`TouchingKind`]); each is
//! resolved as a contact between two
//! **disjoint working regions of the same mesh** (`region = "mask"` with a self-pair, see
//! `regions`): the faces of each part grown by [`MARGIN_RINGS`] rings of faces into its
//! neighbours (not into the other part), so the deformation has room beyond the part's seam,
//! then cut apart so that the two regions share no vertex. When every margin fails, the regions
//! are **grown from the intersection** instead ([`GROWN_RINGS`]): each side from the vertices of
//! its own intersecting faces, every vertex to the nearer side by edge rings (ties to neither),
//! which removes the parts' seams from the picture; a parent/child pair and a fold within a part
//! use these only. The contact definition of ch. 4 with the automatic direction runs between
//! them, its interior given by the winding number of the whole mesh (`inside_itself`: a flood
//! fill from the crossings leaks across the open seam), then ch. 5 on each side with the
//! object's parameters (profile, bulge, stiffness).
//!
//! **The seam between the two regions is open** (as the shared side of an articulation, ch. 6):
//! an intersection that runs across the seam between two parts (an arm entering the torso at the
//! armpit) reaches it by nature, so the vertices of either region next to the other region (or
//! next to the strip of vertices between them) are not a border for the contact stage nor fixed
//! for the deformation ([`crate::params::ObjectParams::contact_open_border`]); the far borders,
//! where a region is cut from the rest of the mesh, stay fixed borders. Each region's bulge
//! height solves its own swept volume to zero (App. C); the open seam moves the faces of the
//! strip between the regions too, so the object's volume is then restored exactly by offsetting
//! the pair's moved vertices along their normals by the root of smallest |h| of the whole
//! object's volume cubic.
//!
//! **Acceptance.** A pair's result is rejected (the next margin is tried) when a region's bulge
//! is taller than its extent (the extent clamped to a sliver by a border: the volume goes into a
//! spike), and undone when it leaves the object more self-intersecting faces beyond the rest
//! pose's than the object had before it: no pair makes a frame worse than its input.
//!
//! **Several pairs** run in *batches*, in parallel within a batch. A pair's *footprint* is the
//! vertices of its regions and their neighbours (what it reads and moves); the batches follow
//! the order of the part ids as a wavefront: a pair joins the next batch unless its footprint
//! (that of its first regions) meets the footprint of an earlier pair not yet applied. The pairs
//! of a batch run in parallel (rayon), every one on the batch's input (the earlier batches'
//! result, with one interior field for all of them); their results are then applied in order,
//! each kept or undone (above) on top of those applied before it. A pair whose wider margins or
//! grown regions reached vertices an earlier pair of its batch moved (its footprint, or its own
//! moved vertices' neighbours) read positions that are no longer there: it is set aside and runs
//! again in a later batch. So every pair sees what the pairs before it did wherever it looks, as
//! when they ran one after the other, and the results applied in one batch share no face: their
//! volume changes add up, each one's exact balance (below) holds for their sum. Which pairs form
//! a batch depends on the touching pairs and their results only, never on the thread count, so
//! the output is the same on any number of threads. *Decision:* a pair's regions are cut
//! regions whose own volume balance is exact, so there is no shared height to iterate on (the
//! Gauss–Seidel over one height per contact that the articulations use).
//!
//! **Onset (continuity).** A pair's result is applied in proportion to how far its parts
//! cross ([`ONSET_EDGES`], `part_pairs[].onset`): the summed lengths of the segments along which
//! its faces cross ([`crate::spatial::intersection_length`]; beyond the rest pose's, not
//! adjacent), over [`ONSET_EDGES`] mean edges, at most 1. A partial share is the pair's input
//! plus that share of the result's displacement, the object's volume then restored exactly
//! again (as over the seam, below). Chapter 4's displacement starts from zero with the depth
//! where two closed parts meet in a lens, but on a coarse skin folded into itself the mapping
//! (a ray along the pair's direction) can reach a far sheet, and the result appears with an
//! offset of a mean edge or more at the frame where the pair starts to touch; the crossing
//! length starts from zero with the crossing and grows continuously, so the share does. What a
//! share leaves crossing is the untangling's, whose steps ramp the same way. A pair that stops
//! touching is not run (zero displacement). Decision: docs/decisions.md, "A part pair's onset".
//!
//! **A pair is a job of the frame plan.** Its two regions run the stages of the contacts between
//! regions ([`ObjectContacts`]: chapter 4, chapter 5, the separation pass) as one object paired
//! with itself, without a nested frame: no results assembly, no quality pass of its own. Each
//! pair keeps the caches of those stages (its regions' sub-meshes, trees and factorizations)
//! per margin in a map ordered by part ids; a grown region's caches are rebuilt when its labels
//! change. The stages' times and work go to the pair's job and to the frame's breakdown; what
//! the pair does around them (its regions, the interior, the volume over the seam, its counts)
//! is `part_contacts`.
//!
//! **Failures** of a pair (an intersection reaching its region's far border: parts too small
//! for the contact; a rejected or undone result) leave that pair unresolved and are reported in
//! its [`PartPairStats::error`], never dropped silently; the other pairs and the frame go on.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::cache::ObjectCache;
use super::deformations::object_results;
use super::plan::Trace;
use super::{Frame, FrameObject, FramePair, ObjectContacts, PipelineError};
use crate::mesh::TriMesh;
use crate::params::{ObjectParams, PairParams, SkinParts, VertexFlags};
use crate::skinning::{FacesBeyond, PartContactSetup, RestIntersections, TouchingKind, TouchingPair};
use crate::spatial::IntersectingPairs;
use crate::stage::{Stage, StageTimes, StageWork, Work};

/// Rings of faces each side of a part pair takes from its neighbouring parts: the first, then
/// the wider ones tried in turn when a contact reaches a region's border (the intersection is
/// not closed inside the region).
pub const MARGIN_RINGS: [usize; 3] = [2, 6, 18];

/// Rings of the regions grown from the intersection, tried when the parts' regions fail. One
/// width: a wider one is not tried (docs/decisions.md, "Regions grown from the intersection").
pub const GROWN_RINGS: usize = 8;

/// A pair's result is applied in proportion to the length along which its parts cross, in mean
/// edge lengths, up to this length (see the module doc, "Onset").
pub const ONSET_EDGES: f64 = 12.0;

/// Figures of one touching part pair at one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PartPairStats {
    /// Index of the object, the two parts' ids and names.
    pub object: usize,
    pub part_ids: [u32; 2],
    pub parts: [String; 2],
    /// What touches: `parts`, `after articulation` (a parent and child), `within part` (a fold).
    #[serde(default)]
    pub kind: String,
    /// Intersecting face pairs that made the pair touch (input of this pair's resolution).
    pub touching_face_pairs: usize,
    /// Faces of the two parts that intersect the other part (beyond the rest pose's own
    /// intersections), before and after this pair's resolution.
    pub faces_before: usize,
    pub faces_after: usize,
    /// True if the contact stage found a contact; its area.
    pub in_contact: bool,
    pub contact_area: f64,
    /// Faces of the two working regions, and the margin they were grown by (the last tried).
    pub region_faces: [usize; 2],
    pub margin_rings: usize,
    /// True if the regions were grown from the intersection (see the module doc), not from the
    /// parts.
    #[serde(default)]
    pub grown_from_intersection: bool,
    /// Why the pair was left unresolved, if it was.
    pub error: Option<String>,
    /// The batch it was applied in (from 0; the pairs of a batch run in parallel on the same
    /// input), and how many times it ran (more than once when it had to wait for a later batch:
    /// its regions reached vertices an earlier pair of its batch moved).
    #[serde(default)]
    pub batch: usize,
    #[serde(default)]
    pub runs: usize,
    /// The share of its result applied ([`ONSET_EDGES`]): the length along which its parts
    /// cross, in mean edges, over [`ONSET_EDGES`], at most 1; `None` when it gave no result.
    #[serde(default)]
    pub onset: Option<f64>,
    pub time: Duration,
}

/// A touching pair's caches of the contact stages and the regions they were built for.
struct PairRegions {
    contacts: ObjectContacts,
    labels: Vec<f64>,
    region_faces: [usize; 2],
}

/// What an object's part contacts keep between frames.
#[derive(Default)]
pub(super) struct PartContactCache {
    setup: Option<PartContactSetup>,
    rest_intersections: Option<RestIntersections>,
    parts: Option<SkinParts>,
    /// Per vertex of the rest pose's connectivity: its neighbours ([`vertex_neighbours`]).
    neighbours: Vec<Vec<u32>>,
    /// The field behind the pairs' interior ([`inside_itself`]), built at the rest pose.
    interior: Option<std::sync::Arc<InteriorField>>,
    /// The object's connectivity caches, built at the rest pose, that every pair's contact
    /// stages start from.
    object: Option<ObjectCache>,
    regions: RegionEntries,
}

impl std::fmt::Debug for PartContactCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PartContactCache").field("pairs", &self.regions.len()).finish()
    }
}

/// The vertex labels of the two working regions of part pair `[a, b]` (1 and 2, 0 elsewhere):
/// each part's faces grown by `rings` rings of faces (never into the other part). A vertex of
/// one part's own faces goes to that part even when the other's margin reaches it; vertices both
/// parts own (their seam), or both margins reach and neither owns, get 0, so that the regions
/// share no vertex.
fn pair_labels(mesh: &TriMesh, parts: &SkinParts, [a, b]: [u32; 2], rings: usize) -> Vec<f64> {
    let n = mesh.num_vertices();
    let vertices_of = |faces: &[bool]| -> Vec<bool> {
        let mut vertices = vec![false; n];
        for (t, _) in mesh.triangles.iter().zip(faces).filter(|(_, in_)| **in_) {
            for &v in t {
                vertices[v as usize] = true;
            }
        }
        vertices
    };
    let own = |part: u32| -> Vec<bool> { parts.face_parts.iter().map(|&p| p == part).collect() };
    let grow = |own: u32, other: u32| -> Vec<bool> {
        let mut faces: Vec<bool> = parts.face_parts.iter().map(|&p| p == own).collect();
        for _ in 0..rings {
            let reached = vertices_of(&faces);
            for (f, t) in mesh.triangles.iter().enumerate() {
                if !faces[f] && parts.face_parts[f] != other && t.iter().any(|&v| reached[v as usize]) {
                    faces[f] = true;
                }
            }
        }
        vertices_of(&faces)
    };
    let (own_first, own_second) = (vertices_of(&own(a)), vertices_of(&own(b)));
    let (first, second) = (grow(a, b), grow(b, a));
    (0..n)
        .map(|v| match (own_first[v], own_second[v], first[v], second[v]) {
            (true, false, _, _) => 1.0,
            (false, true, _, _) => 2.0,
            (false, false, true, false) => 1.0,
            (false, false, false, true) => 2.0,
            _ => 0.0,
        })
        .collect()
}

/// The vertex labels of the two working regions of a touching pair grown from its intersection
/// (1 and 2, 0 elsewhere): side 1 starts from the vertices of the faces of `faces[·][0]`, side 2
/// from those of `faces[·][1]`; a breadth-first search over the mesh's edges gives each vertex
/// the side of the nearer start, up to `rings` edges away. Vertices as near to both (or starts
/// of both) get 0 and stop the search: the seam between the sides. `neighbours`: the mesh's
/// [`vertex_neighbours`].
fn intersection_labels(mesh: &TriMesh, neighbours: &[Vec<u32>], faces: &[[u32; 2]], rings: usize) -> Vec<f64> {
    let n = mesh.num_vertices();
    // Per vertex: which sides reach it first (bit 0: side 1, bit 1: side 2); 0 = not reached.
    let mut reached = vec![0u8; n];
    let mut layer: BTreeMap<u32, u8> = BTreeMap::new();
    for pair in faces {
        for (side, &f) in pair.iter().enumerate() {
            for &v in &mesh.triangles[f as usize] {
                *layer.entry(v).or_insert(0) |= 1 << side;
            }
        }
    }
    for _ in 0..=rings {
        for (&v, &sides) in &layer {
            reached[v as usize] = sides;
        }
        let mut next: BTreeMap<u32, u8> = BTreeMap::new();
        for (&v, &sides) in &layer {
            if sides == 3 {
                continue;
            }
            for &w in &neighbours[v as usize] {
                if reached[w as usize] == 0 {
                    *next.entry(w).or_insert(0) |= sides;
                }
            }
        }
        layer = next;
    }
    reached
        .iter()
        .map(|&sides| match sides {
            1 => 1.0,
            2 => 2.0,
            _ => 0.0,
        })
        .collect()
}

/// Per vertex: the vertices sharing an edge with it (an edge of two faces listed twice).
fn vertex_neighbours(mesh: &TriMesh) -> Vec<Vec<u32>> {
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); mesh.num_vertices()];
    for t in &mesh.triangles {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            neighbours[a as usize].push(b);
            neighbours[b as usize].push(a);
        }
    }
    neighbours
}

/// Per vertex: on the seam between the two working regions of `labels` (1 and 2): a vertex of
/// one region sharing a face with a vertex of the other, or with a vertex of neither (label 0)
/// that itself shares faces with both. That side is not a border for the contact stage.
fn seam_between(mesh: &TriMesh, labels: &[f64]) -> Vec<bool> {
    let n = mesh.num_vertices();
    let mut touches = vec![[false; 3]; n];
    for t in &mesh.triangles {
        for &v in t {
            for &w in t {
                touches[v as usize][labels[w as usize] as usize % 3] = true;
            }
        }
    }
    let strip: Vec<bool> = (0..n).map(|v| labels[v] == 0.0 && touches[v][1] && touches[v][2]).collect();
    let mut open = vec![false; n];
    for t in &mesh.triangles {
        for &v in t {
            let k = labels[v as usize] as usize;
            if k == 0 {
                continue;
            }
            if t.iter().any(|&w| strip[w as usize] || (labels[w as usize] != 0.0 && labels[w as usize] as usize != k)) {
                open[v as usize] = true;
            }
        }
    }
    open
}

/// The whole mesh's tree and winding clusters behind [`inside_itself`]: built once at the rest
/// pose, refitted to each mesh asked about (the same tree shape at every frame, so the far-field
/// approximation does not change with a rebuilt tree's clusters from one frame to the next).
#[derive(Clone)]
struct InteriorField {
    tree: crate::spatial::TriangleBvh,
    clusters: crate::spatial::WindingClusters,
}

/// Accuracy (β) of the fast winding number behind [`inside_itself`].
const INTERIOR_ACCURACY: f64 = 2.0;

/// Per vertex asked for (those of the cut regions): inside the object's own volume beyond its
/// own sheet — the generalized winding number of the whole mesh (fast,
/// [`crate::spatial::FastWinding`], over `field` refitted to `mesh`) above 1 in magnitude: ½ on
/// the surface, one more for each sheet of the object around the vertex. This is the contact
/// stage's interior of a part contact: across the open seam between the two regions an
/// intersection curve does not close, so a flood fill from the crossings cannot tell inside from
/// outside (the same reason as ch. 6's crease cut).
fn inside_itself(
    field: &mut std::sync::Arc<InteriorField>,
    mesh: &TriMesh,
) -> Result<VertexFlags, crate::spatial::SpatialError> {
    // The flags of an earlier mesh are dropped by now, so the field is refitted in place.
    let fitted = std::sync::Arc::make_mut(field);
    fitted.tree.refit(&mesh.positions)?;
    fitted.clusters.refresh(&fitted.tree);
    let field = std::sync::Arc::clone(field);
    let positions = mesh.positions.clone();
    Ok(VertexFlags::new(move |vertices| {
        let winding = crate::spatial::FastWinding::with_clusters(&field.tree, &field.clusters, INTERIOR_ACCURACY);
        let points: Vec<DVec3> = vertices.iter().filter_map(|&v| positions.get(v as usize).copied()).collect();
        let mut inside = winding.winding_numbers(&points).into_iter().map(|w| w.abs() > 1.0);
        vertices.iter().map(|&v| (v as usize) < positions.len() && inside.next().unwrap_or(false)).collect()
    }))
}

/// True if the two position lists are equal bit for bit.
fn same_bits(a: &[DVec3], b: &[DVec3]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(p, q)| p.to_array().map(f64::to_bits) == q.to_array().map(f64::to_bits))
}

/// The faces crossing beyond the rest pose's ([`RestIntersections::faces_beyond`]) of each mesh
/// the stage makes, each counted from the last one counted: from every intersecting face pair,
/// enumerated again where vertices moved ([`IntersectingPairs`]), or where their boxes overlap too
/// often for that (a fan), by a search where vertices moved ([`RestIntersections::
/// faces_beyond_after`]). The same faces either way.
struct Crossings<'r> {
    /// `None`: no rest pose to count from (no face crosses).
    rest: Option<&'r RestIntersections>,
    last: Option<FacesBeyond>,
    /// The intersecting pairs of the last mesh counted; `Err(())` once their enumeration went
    /// past its budget.
    pairs: Result<Option<IntersectingPairs>, ()>,
}

impl<'r> Crossings<'r> {
    /// Counts from `rest`, starting from `pairs` when the caller enumerated them already.
    fn new(rest: Option<&'r RestIntersections>, pairs: Option<IntersectingPairs>) -> Self {
        Self { rest, last: None, pairs: Ok(pairs) }
    }

    /// Every intersecting face pair of `mesh`, unless their enumeration is past its budget.
    fn pairs(&mut self, mesh: &TriMesh) -> Result<Option<&[[u32; 2]]>, crate::spatial::SpatialError> {
        let budget = crate::spatial::PAIRS_PER_FACE * mesh.num_triangles();
        let within = match &mut self.pairs {
            Err(()) => false,
            Ok(Some(pairs)) => pairs.update(mesh, budget)?,
            Ok(None) => match IntersectingPairs::new(mesh, budget)? {
                Some(pairs) => {
                    self.pairs = Ok(Some(pairs));
                    true
                }
                None => false,
            },
        };
        if !within {
            self.pairs = Err(());
        }
        Ok(self.pairs.as_ref().ok().and_then(Option::as_ref).map(IntersectingPairs::pairs))
    }

    fn faces(&mut self, mesh: &TriMesh) -> Result<Vec<u32>, crate::spatial::SpatialError> {
        let Some(rest) = self.rest else { return Ok(Vec::new()) };
        if let Some(pairs) = self.pairs(mesh)? {
            return Ok(rest.faces_beyond_in(pairs));
        }
        let counted = match &self.last {
            Some(last) => rest.faces_beyond_after(last, mesh)?,
            None => rest.counted(mesh)?,
        };
        let faces = counted.faces.clone();
        self.last = Some(counted);
        Ok(faces)
    }

    /// [`Self::faces`] with, per face, the summed length of the segments along which it crosses
    /// the faces it crosses ([`crate::spatial::intersection_length`]); `f64::INFINITY` when the
    /// pairs are past their budget (the faces are then searched, not their pairs).
    fn faces_with_lengths(&mut self, mesh: &TriMesh) -> Result<Vec<(u32, f64)>, crate::spatial::SpatialError> {
        let Some(rest) = self.rest else { return Ok(Vec::new()) };
        let Some(pairs) = self.pairs(mesh)? else {
            return Ok(self.faces(mesh)?.into_iter().map(|f| (f, f64::INFINITY)).collect());
        };
        let mut lengths: BTreeMap<u32, f64> = BTreeMap::new();
        for &[f, g] in pairs.iter().filter(|&&p| !rest.is_rest_pair(p)) {
            let length = crate::spatial::intersection_length(&mesh.corners(f as usize), &mesh.corners(g as usize));
            *lengths.entry(f).or_default() += length;
            *lengths.entry(g).or_default() += length;
        }
        Ok(lengths.into_iter().collect())
    }
}

/// The mean length of the edges of `mesh`'s triangles (an edge shared by two counted twice).
fn mean_edge(mesh: &TriMesh) -> f64 {
    let sum: f64 = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| mesh.positions[v as usize]))
        .map(|[a, b, c]| a.distance(b) + b.distance(c) + c.distance(a))
        .sum();
    sum / (3 * mesh.triangles.len().max(1)) as f64
}

/// `new` (the pair's result on `current`) with the object's volume brought back to `current`'s
/// exactly: the regions' heights keep their own swept volumes, but their open seams move, and
/// the faces of the strip between them with it. The moved vertices are offset along their unit
/// normals by the height h of the smallest |h| that is a root of the object's volume cubic
/// (App. C); `None` when neither direction has one.
fn restore_volume(current: &TriMesh, new: Vec<DVec3>) -> Option<Vec<DVec3>> {
    let moved: Vec<f64> = current.positions.iter().zip(&new).map(|(p, q)| if p != q { 1.0 } else { 0.0 }).collect();
    restore_volume_with(current, new, &moved)
}

/// [`restore_volume`] with the offset carried by the vertices of nonzero `carriers` (which need
/// not be those that moved), each offset by its carrier times the height along its normal.
fn restore_volume_with(current: &TriMesh, new: Vec<DVec3>, carriers: &[f64]) -> Option<Vec<DVec3>> {
    use crate::deform::{AffineDisplacement, VolumeCubic, solve_bulge_height, solve_dent_height};
    if current.positions == new {
        return Some(new);
    }
    if !carriers.iter().any(|&c| c != 0.0) {
        return None;
    }
    // Every vertex whose displacement is not zero: those that moved and the carriers.
    let moved: Vec<bool> =
        current.positions.iter().zip(&new).zip(carriers).map(|((p, q), &c)| c != 0.0 || p != q).collect();
    let normals =
        crate::mesh::vertex_normals(&TriMesh { positions: new.clone(), triangles: current.triangles.clone() });
    let constant: Vec<DVec3> = current.positions.iter().zip(&new).map(|(p, q)| *q - *p).collect();
    let reference = crate::mesh::vertex_centroid(&current.positions);
    let scale = constant.iter().map(|d| d.length()).fold(0.0, f64::max);
    let linear = normals.iter().zip(carriers).map(|(n, &c)| if c != 0.0 { c * *n } else { DVec3::ZERO }).collect();
    let displacement = AffineDisplacement { linear, constant, moved };
    let cubic = VolumeCubic::new(current, &displacement, reference).ok()?;
    let exact = |solution: crate::deform::HeightSolution| solution.exact.then_some(solution.height);
    let height = match (exact(solve_bulge_height(&cubic, scale)), exact(solve_dent_height(&cubic, scale))) {
        (Some(a), Some(b)) => {
            if a.abs() <= b.abs() {
                a
            } else {
                b
            }
        }
        (Some(h), None) | (None, Some(h)) => h,
        (None, None) => return None,
    };
    Some(
        new.iter()
            .zip(&normals)
            .zip(carriers)
            .map(|((q, n), &c)| if c != 0.0 { *q + height * (c * *n) } else { *q })
            .collect(),
    )
}

/// How many faces of parts `pair.parts` intersect a face of the other part (of the same part
/// for a fold within one), not adjacent, not a rest-pose pair: from the intersecting face pairs
/// of `mesh` when `crossings` has them, else searched.
fn crossing_faces(
    crossings: &mut Crossings,
    mesh: &TriMesh,
    parts: &SkinParts,
    setup: &PartContactSetup,
    pair: [u32; 2],
) -> Result<usize, crate::spatial::SpatialError> {
    let (of_pair, related) = pair_face_filters(parts, setup, pair);
    if let Some(pairs) = crossings.pairs(mesh)? {
        let admitted = pairs.iter().copied().filter(|&[f, g]| of_pair(f) && of_pair(g) && related(f, g));
        return Ok(crate::spatial::faces_of_pairs(admitted).len());
    }
    let faces = (0..mesh.num_triangles() as u32).filter(|&f| of_pair(f));
    Ok(crate::spatial::self_intersecting_faces(mesh, faces, related)?.len())
}

/// What counts for part pair `[a, b]`: a face of one of its parts, and two such faces of
/// different parts (of the same part for a fold within one), not adjacent, not crossing in the
/// rest pose.
fn pair_face_filters<'a>(
    parts: &'a SkinParts,
    setup: &'a PartContactSetup,
    [a, b]: [u32; 2],
) -> (impl Fn(u32) -> bool + Copy + 'a, impl Fn(u32, u32) -> bool + Copy + 'a) {
    let part = move |f: u32| parts.face_parts[f as usize];
    let of_pair = move |f: u32| part(f) == a || part(f) == b;
    let related = move |f: u32, g: u32| {
        (a == b || part(f) != part(g))
            && setup.rest_pairs().binary_search(&[f.min(g), f.max(g)]).is_err()
            && !setup.adjacent(f, g)
    };
    (of_pair, related)
}

/// The share of a part pair's result applied at `mesh` (its input): the summed lengths of the
/// segments along which its faces cross ([`pair_face_filters`]), over [`ONSET_EDGES`] mean
/// edges `edge`, at most 1; 1 when the object's crossing pairs are past their budget (not
/// enumerated).
fn onset_share(
    crossings: &mut Crossings,
    mesh: &TriMesh,
    parts: &SkinParts,
    setup: &PartContactSetup,
    pair: [u32; 2],
    edge: f64,
) -> Result<f64, crate::spatial::SpatialError> {
    let (of_pair, related) = pair_face_filters(parts, setup, pair);
    let Some(pairs) = crossings.pairs(mesh)? else { return Ok(1.0) };
    let length: f64 = pairs
        .iter()
        .filter(|&&[f, g]| of_pair(f) && of_pair(g) && related(f, g))
        .map(|&[f, g]| crate::spatial::intersection_length(&mesh.corners(f as usize), &mesh.corners(g as usize)))
        .sum();
    Ok((length / (ONSET_EDGES * edge)).min(1.0))
}

/// The intersecting face pairs of the whole object at the frame's input and at the stage's
/// input (after the articulations), when the caller enumerated them for its own counts: the
/// stage counts from them rather than enumerate them again.
pub(super) struct FramePairs<'p> {
    /// The pairs of the frame's input (sorted `[f, g]`, f < g).
    pub input: &'p [[u32; 2]],
    /// The pairs of the stage's input, to be enumerated again where vertices move.
    pub mesh: IntersectingPairs,
}

/// What [`resolve_part_contacts`] gives back for one object.
pub(super) struct PartContactResult {
    pub positions: Vec<DVec3>,
    /// Per vertex: moved by a part contact.
    pub moved: Vec<bool>,
    pub pairs: Vec<PartPairStats>,
    /// Faces intersecting beyond the rest pose's, in the stage's input and after the part
    /// contacts.
    pub self_intersecting_faces: [usize; 2],
    pub untangled: Untangled,
    /// The rest pose's caches (built at the first frame of a rest pose and its parts): their
    /// time and work.
    pub rest_caches: Spent,
    /// The search for the touching pairs (and the faces crossing before them): its time and work.
    pub search: Spent,
    /// Per pair (in the order of `pairs`): the time and work of the stages it ran, its own
    /// (`part_contacts`) and those of its contact stages.
    pub pair_stages: Vec<(StageTimes, StageWork)>,
    /// The work of the untangling.
    pub untangle_work: Work,
    /// The counts of the faces crossing in the input and the result.
    pub counts: Spent,
}

/// The time and work of a step.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Spent {
    pub time: Duration,
    pub work: Work,
}

/// What the untangling after the part contacts (the `untangle` key; docs/decisions.md, "Untangling what is left") did on an object at a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Untangled {
    /// Rounds of smoothing kept (0: none needed, or the result was not kept).
    pub rounds: usize,
    /// Faces crossing beyond the rest pose's before and after it.
    pub faces_before: usize,
    pub faces_after: usize,
    /// Its time, with its own counts of the crossing faces.
    pub time: Duration,
}

/// The key of a pair's regions in [`PartContactCache::regions`]: its parts, what touches,
/// whether the regions are grown from the intersection, their rings.
type RegionKey = ([u32; 2], TouchingKind, bool, usize);

/// One pair's regions, taken out of the cache while the pair runs.
type RegionEntries = BTreeMap<RegionKey, PairRegions>;

/// Takes `pair`'s regions out of `regions` (those of every margin it may try).
fn take_entries(regions: &mut RegionEntries, pair: &TouchingPair) -> RegionEntries {
    let first = (pair.parts, pair.kind, false, 0);
    let keys: Vec<RegionKey> =
        regions.range(first..).take_while(|(k, _)| (k.0, k.1) == (pair.parts, pair.kind)).map(|(k, _)| *k).collect();
    keys.into_iter().filter_map(|k| regions.remove(&k).map(|r| (k, r))).collect()
}

/// The vertices whose labels are not 0 and their neighbours, in order: what a pair reads and
/// writes on regions of these labels (its regions, and the strip between them).
fn footprint(labels: &[f64], neighbours: &[Vec<u32>]) -> Vec<u32> {
    let mut within = vec![false; labels.len()];
    for (v, _) in labels.iter().enumerate().filter(|(_, l)| **l != 0.0) {
        within[v] = true;
        for &w in &neighbours[v] {
            within[w as usize] = true;
        }
    }
    (0..labels.len() as u32).filter(|&v| within[v as usize]).collect()
}

/// The labels of `pair`'s regions for one try: grown from the intersection by `rings`, or its
/// parts' faces grown by `rings`.
fn region_labels(
    mesh: &TriMesh,
    parts: &SkinParts,
    neighbours: &[Vec<u32>],
    pair: &TouchingPair,
    (grown, rings): (bool, usize),
) -> Vec<f64> {
    if grown {
        intersection_labels(mesh, neighbours, &pair.faces, rings)
    } else {
        pair_labels(mesh, parts, pair.parts, rings)
    }
}

/// The regions `pair` tries, in order: its parts' margins (two parts apart only: a parent and
/// child share their articulation's seam, a fold has one part), then grown from the
/// intersection.
fn tries(pair: &TouchingPair) -> impl Iterator<Item = (bool, usize)> {
    let margins: &[usize] = if pair.kind == TouchingKind::Parts { &MARGIN_RINGS } else { &[] };
    margins.iter().map(|&r| (false, r)).chain(std::iter::once((true, GROWN_RINGS)))
}

/// The next batch of `remaining` (indices of pairs, in order): each pair in turn whose first
/// footprint meets none of the earlier remaining pairs' (in the batch or not), so that no pair
/// runs before an earlier one it shares vertices with; and the pairs left for later batches.
fn next_batch(footprints: &[Vec<u32>], remaining: &[usize], n: usize) -> (Vec<usize>, Vec<usize>) {
    let mut blocked = vec![false; n];
    let (mut batch, mut later) = (Vec::new(), Vec::new());
    for &k in remaining {
        if footprints[k].iter().any(|&v| blocked[v as usize]) {
            later.push(k);
        } else {
            batch.push(k);
        }
        for &v in &footprints[k] {
            blocked[v as usize] = true;
        }
    }
    (batch, later)
}

/// What every pair of a batch reads.
struct PairContext<'a> {
    index: usize,
    name: &'a str,
    /// The object after its articulations (the connectivity the regions are labelled on).
    mesh: &'a TriMesh,
    /// The batch's input.
    current: &'a TriMesh,
    parts: &'a SkinParts,
    params: &'a ObjectParams,
    neighbours: &'a [Vec<u32>],
    interior: &'a VertexFlags,
    object: &'a ObjectCache,
}

/// One pair's run on its batch's input.
struct PairRun {
    /// Its figures, but for the faces crossing before and after (counted by the caller).
    stats: PartPairStats,
    /// Its result, the object's volume restored, when it has one.
    candidate: Option<Vec<DVec3>>,
    /// The footprint of the regions it ran last.
    footprint: Vec<u32>,
    /// The times and work of the contact stages it ran.
    stages: Trace,
}

/// Runs one touching pair on `context.current`: its regions from the parts' margins in turn,
/// then grown from the intersection, until one gives a result (see the module doc).
fn run_pair(
    context: &PairContext,
    pair: &TouchingPair,
    first: &[f64],
    entries: &mut RegionEntries,
) -> Result<PairRun, PipelineError> {
    let PairContext { index, name, mesh, current, parts, params, neighbours, interior, object } = *context;
    // The pair's contact stages, traced apart from what the pair does around them.
    let mut stages = Trace::default();
    let mut s = PartPairStats {
        object: index,
        part_ids: pair.parts,
        parts: pair.parts.map(|k| parts.name(k).to_string()),
        kind: match pair.kind {
            TouchingKind::Parts => "parts",
            TouchingKind::AfterArticulation => "after articulation",
            TouchingKind::WithinPart(_) => "within part",
        }
        .to_string(),
        touching_face_pairs: pair.faces.len(),
        ..PartPairStats::default()
    };
    let mut candidate = None;
    let mut read = Vec::new();
    for (k, (grown, rings)) in tries(pair).enumerate() {
        // The first try's labels were computed for the batches.
        let labels = if k == 0 { first.to_vec() } else { region_labels(mesh, parts, neighbours, pair, (grown, rings)) };
        // Grown regions follow the intersection: when they change, the regions' caches are
        // updated for their new faces (the object's are kept).
        let faces_of =
            |k: f64| -> usize { mesh.triangles.iter().filter(|t| t.iter().all(|&v| labels[v as usize] == k)).count() };
        let entry = match entries.entry((pair.parts, pair.kind, grown, rings)) {
            std::collections::btree_map::Entry::Occupied(entry) => {
                let entry = entry.into_mut();
                if entry.labels != labels {
                    entry.region_faces = [faces_of(1.0), faces_of(2.0)];
                    entry.labels = labels;
                }
                entry
            }
            std::collections::btree_map::Entry::Vacant(entry) => {
                let region_faces = [faces_of(1.0), faces_of(2.0)];
                let contacts = ObjectContacts::with_object(object.connectivity());
                entry.insert(PairRegions { contacts, labels, region_faces })
            }
        };
        s.region_faces = entry.region_faces;
        read = footprint(&entry.labels, neighbours);
        s.margin_rings = rings;
        s.grown_from_intersection = grown;
        let mut region_params = params.clone().with_region_mask(entry.labels.clone());
        region_params.self_contact = Vec::new();
        region_params.self_contact_parts = None;
        region_params.contact_open_border = Some(seam_between(mesh, &entry.labels));
        region_params.contact_interior = Some(interior.clone());
        let frame = Frame {
            objects: vec![FrameObject { name, mesh: current, params: &region_params }],
            pairs: vec![FramePair { objects: [0, 0], params: PairParams::default() }],
        };
        let outcome = entry.contacts.contact(&frame, false, &mut stages).map_err(|e| e.automatic_wording()).and_then(
            |(level, _)| {
                let in_contact = level.contacts.iter().flatten().any(|c| !c.is_empty());
                let contact_area: f64 = level.contacts.iter().flatten().map(|c| c.contact_area).sum();
                let results = object_results(&frame, &entry.contacts.caches, &level.zones, level.outcomes);
                // A bulge taller than its extent: the extent was clamped to a sliver of the
                // region (its seam too close), so the volume went into a spike.
                match results.regions.iter().find(|r| r.applied_bulge_height.abs() > r.extent) {
                    Some(r) => Err(format!(
                        "region {}: a bulge of height {:.3e} over an extent of {:.3e}; a wider margin is needed",
                        r.region, r.applied_bulge_height, r.extent
                    )),
                    None => Ok((in_contact, contact_area, results.positions)),
                }
            },
        );
        match outcome {
            Ok((in_contact, contact_area, positions_out)) => {
                s.error = None;
                s.in_contact = in_contact;
                s.contact_area = contact_area;
                if let Some(new) = positions_out.into_iter().next() {
                    match restore_volume(current, new) {
                        Some(new) => candidate = Some(new),
                        None => s.error = Some("the object's volume cannot be restored over the seam".into()),
                    }
                }
                break;
            }
            // Too tight: the next, wider margin.
            Err(e) => s.error = Some(e),
        }
    }
    Ok(PairRun { stats: s, candidate, footprint: read, stages })
}

/// Resolves the touching part pairs of one object (see the module doc). `input` is the object
/// at this frame, `mesh` the object after its articulations, `rest` its rest pose, `params` its
/// parameters.
#[allow(clippy::too_many_arguments)]
pub(super) fn resolve_part_contacts(
    cache: &mut PartContactCache,
    index: usize,
    name: &str,
    input: &TriMesh,
    mesh: &TriMesh,
    rest: &TriMesh,
    params: &ObjectParams,
    parts: &SkinParts,
    frame_pairs: Option<FramePairs<'_>>,
) -> Result<PartContactResult, PipelineError> {
    let n = mesh.num_vertices();
    if parts.face_parts.len() != mesh.num_triangles() {
        return Err(PipelineError::invalid_region(
            name,
            format!(
                "the self-contact parts give {} face labels but the mesh has {} faces; give one part per face",
                parts.face_parts.len(),
                mesh.num_triangles()
            ),
        ));
    }
    let spatial = |source| PipelineError::Spatial { object: name.to_string(), source };
    // The work of this call is counted in laps of the enclosing span (given back at the end):
    // the rest pose's caches, the search, each pair, the untangling, the counts.
    let outer = Work::lap();
    let setup_start = Instant::now();
    let stale = cache.setup.as_ref().is_none_or(|s| !s.matches(rest)) || cache.parts.as_ref() != Some(parts);
    if stale {
        *cache = PartContactCache {
            setup: Some(PartContactSetup::new(rest).map_err(spatial)?),
            rest_intersections: Some(RestIntersections::new(rest).map_err(spatial)?),
            parts: Some(parts.clone()),
            neighbours: vertex_neighbours(rest),
            interior: None,
            object: None,
            regions: BTreeMap::new(),
        };
    }
    let mut rest_caches = Spent { time: setup_start.elapsed(), work: Work::lap() };
    let Some(setup) = cache.setup.as_mut() else {
        return Err(PipelineError::invalid_region(name, "no part contact setup".into()));
    };
    let search_start = Instant::now();
    let touching: Vec<TouchingPair> = setup.touching(mesh, parts).map_err(spatial)?;
    let rest_intersections = &cache.rest_intersections;
    let neighbours = &cache.neighbours;
    let (input_pairs, mesh_pairs) = match frame_pairs {
        Some(FramePairs { input, mesh }) => (Some(input), Some(mesh)),
        None => (None, None),
    };
    let mut crossings = Crossings::new(rest_intersections.as_ref(), mesh_pairs);
    // The length the pairs' onsets and the untangling's ramp are measured in.
    let edge = mean_edge(mesh);
    let mut faces_now = if touching.is_empty() { 0 } else { crossings.faces(mesh).map_err(spatial)?.len() };
    // The count of the stage's input starts from this one (the articulations moved few vertices).
    let first = crossings.last.clone();
    let mut positions = mesh.positions.clone();
    let mut moved = vec![false; n];
    let search = Spent { time: search_start.elapsed(), work: Work::lap() };
    // The object's connectivity at the rest pose, for the pairs: a rest pose's cache too.
    if !touching.is_empty() && cache.object.is_none() {
        let start = Instant::now();
        cache.object = Some(ObjectCache::new(name, rest)?);
        rest_caches.time += start.elapsed();
        rest_caches.work += Work::lap();
    }
    // The pairs run in batches of pairs whose footprints do not meet, in parallel, each on the
    // batch's input; their results are applied in the order of the pairs (see the module doc).
    let mut pair_stats: Vec<Option<PartPairStats>> = vec![None; touching.len()];
    let mut pair_stages: Vec<(StageTimes, StageWork)> = vec![Default::default(); touching.len()];
    // Per pair: its time over every run (a pair set aside runs again in a later batch).
    let mut time_of = vec![Duration::ZERO; touching.len()];
    // The interior flags of the positions they were computed at.
    let mut interior_of: Option<(Vec<DVec3>, VertexFlags)> = None;
    let first_labels: Vec<Vec<f64>> = touching
        .iter()
        .map(|pair| {
            tries(pair).next().map_or_else(Vec::new, |first| region_labels(mesh, parts, neighbours, pair, first))
        })
        .collect();
    let footprints: Vec<Vec<u32>> = first_labels.iter().map(|labels| footprint(labels, neighbours)).collect();
    let mut remaining: Vec<usize> = (0..touching.len()).collect();
    let mut runs_of = vec![0; touching.len()];
    let mut batch_index = 0;
    while !remaining.is_empty() {
        let prepared = Instant::now();
        let (batch, mut later) = next_batch(&footprints, &remaining, n);
        let current = TriMesh { positions: positions.clone(), triangles: mesh.triangles.clone() };
        let Some(setup) = cache.setup.as_ref() else { break };
        // The interior of the positions the last batch left, unless they changed since (pairs
        // undone or without contact leave them bit for bit).
        let kept = interior_of.take().filter(|(at, _)| same_bits(at, &current.positions));
        let interior = match kept {
            Some((_, flags)) => flags,
            None => {
                let field = match cache.interior.as_mut() {
                    Some(field) => field,
                    None => cache.interior.insert(std::sync::Arc::new(InteriorField {
                        tree: crate::spatial::TriangleBvh::new(rest).map_err(spatial)?,
                        clusters: crate::spatial::WindingClusters::default(),
                    })),
                };
                inside_itself(field, &current).map_err(spatial)?
            }
        };
        let mut faces_before = Vec::with_capacity(batch.len());
        for &k in &batch {
            faces_before
                .push(crossing_faces(&mut crossings, &current, parts, setup, touching[k].parts).map_err(spatial)?);
        }
        // What the batch shares goes to its first pair.
        let shared = (prepared.elapsed(), Work::lap());
        let mut taken: Vec<RegionEntries> =
            batch.iter().map(|&k| take_entries(&mut cache.regions, &touching[k])).collect();
        let Some(object) = cache.object.as_ref() else { break };
        let context = PairContext {
            index,
            name,
            mesh,
            current: &current,
            parts,
            params,
            neighbours,
            interior: &interior,
            object,
        };
        let runs: Vec<_> = batch
            .par_iter()
            .zip(taken.par_iter_mut())
            .map(|(&k, entries)| {
                let start = Instant::now();
                let (run, work) = Work::measure(|| run_pair(&context, &touching[k], &first_labels[k], entries));
                (run, start.elapsed(), work)
            })
            .collect();
        for entries in taken {
            cache.regions.extend(entries);
        }
        // Applied in order; a result next to what an earlier one of the batch moved waits for
        // a later batch, on the positions this one leaves.
        let (mut claimed, mut pending) = (vec![false; n], vec![false; n]);
        let mut applied = Vec::with_capacity(batch.len());
        for (position, ((&k, (run, time, work)), before)) in batch.iter().zip(runs).zip(faces_before).enumerate() {
            let committing = Instant::now();
            let PairRun { mut stats, candidate, footprint: read, stages } = run?;
            let Trace { stages: times, work: mut stage_work, .. } = stages;
            // The pair's own share of its time (`part_contacts`) is set once its time is known.
            stage_work[Stage::PartContacts] += work;
            if position == 0 {
                stage_work[Stage::PartContacts] += shared.1;
                time_of[k] += shared.0;
            }
            runs_of[k] += 1;
            let spent = &mut pair_stages[k];
            spent.0 += &times;
            spent.1 += &stage_work;
            time_of[k] += time;
            // Its run read positions an earlier pair of the batch moved, or will move when it
            // runs again, or it moved vertices next to theirs: it runs again in a later batch.
            let changed: Vec<usize> = match &candidate {
                Some(new) => (0..n).filter(|&v| current.positions[v] != new[v]).collect(),
                None => Vec::new(),
            };
            let next_to_claimed = |v: usize| claimed[v] || neighbours[v].iter().any(|&w| claimed[w as usize]);
            if read.iter().any(|&v| claimed[v as usize] || pending[v as usize])
                || changed.iter().any(|&v| next_to_claimed(v))
            {
                later.push(k);
                for &v in &read {
                    pending[v as usize] = true;
                }
                let lap = (committing.elapsed(), Work::lap());
                pair_stages[k].1[Stage::PartContacts] += lap.1;
                time_of[k] += lap.0;
                continue;
            }
            if let Some(new) = candidate {
                // Its onset: the result in proportion to how far its parts cross, the volume
                // restored again where that is a part of it.
                let input = TriMesh { positions: positions.clone(), triangles: mesh.triangles.clone() };
                let share =
                    onset_share(&mut crossings, &input, parts, setup, touching[k].parts, edge).map_err(spatial)?;
                stats.onset = Some(share);
                let mut trial = positions.clone();
                for &v in &changed {
                    trial[v] = if share < 1.0 { positions[v] + share * (new[v] - positions[v]) } else { new[v] };
                }
                let trial = if share < 1.0 { restore_volume(&input, trial) } else { Some(trial) };
                // Never worse than the pair's input: a result that leaves the object more
                // self-intersecting faces is undone.
                match trial {
                    None => {
                        stats.error = Some(format!(
                            "{:.0}% of the result (its onset) has no exact volume; undone",
                            100.0 * share
                        ));
                    }
                    Some(trial) => {
                        let candidate = TriMesh { positions: trial, triangles: mesh.triangles.clone() };
                        let faces = crossings.faces(&candidate).map_err(spatial)?.len();
                        if faces > faces_now {
                            stats.error = Some(format!(
                                "the result would leave {faces} self-intersecting faces instead of {faces_now}; undone"
                            ));
                        } else {
                            faces_now = faces;
                            for &v in &changed {
                                moved[v] |= candidate.positions[v] != positions[v];
                                claimed[v] = true;
                            }
                            positions = candidate.positions;
                        }
                    }
                }
            }
            stats.faces_before = before;
            stats.batch = batch_index;
            stats.runs = runs_of[k];
            let lap = (committing.elapsed(), Work::lap());
            pair_stages[k].1[Stage::PartContacts] += lap.1;
            time_of[k] += lap.0;
            pair_stats[k] = Some(stats);
            applied.push(k);
        }
        let after = TriMesh { positions: positions.clone(), triangles: mesh.triangles.clone() };
        for &k in &applied {
            let counting = Instant::now();
            let faces = crossing_faces(&mut crossings, &after, parts, setup, touching[k].parts).map_err(spatial)?;
            let lap = (counting.elapsed(), Work::lap());
            pair_stages[k].1[Stage::PartContacts] += lap.1;
            time_of[k] += lap.0;
            // Its own share: its time beyond its contact stages' (which may overlap in time:
            // the regions of a stage run in parallel).
            let times = &mut pair_stages[k].0;
            let staged: Duration =
                Stage::spans().filter(|&stage| stage != Stage::PartContacts).map(|stage| times[stage]).sum();
            times[Stage::PartContacts] = time_of[k].saturating_sub(staged);
            if let Some(s) = pair_stats[k].as_mut() {
                s.faces_after = faces;
                s.time = time_of[k];
            }
        }
        interior_of = Some((current.positions, interior));
        later.sort_unstable();
        remaining = later;
        batch_index += 1;
    }
    // Every pair ran (the first of each batch is never set aside).
    let (stats, pair_stages): (Vec<PartPairStats>, Vec<(StageTimes, StageWork)>) =
        pair_stats.into_iter().zip(pair_stages).filter_map(|(s, t)| s.map(|s| (s, t))).unzip();
    // What the contacts leave crossing (or could not treat: folds of a crumpled skin, chords of
    // a coarse one) is untangled, then the volume restored; kept only if fewer faces cross.
    let untangle_start = Instant::now();
    let mut untangled = Untangled { faces_before: faces_now, ..Untangled::default() };
    if let (Some(_), Some(setup)) = (rest_intersections, cache.setup.as_ref())
        && faces_now > 0
        && params.untangle
    {
        let before = TriMesh { positions: positions.clone(), triangles: mesh.triangles.clone() };
        let mut candidate = positions.clone();
        let mut weights = vec![0.0_f64; n];
        let mut rounds = 0;
        let mut result: Option<(Vec<DVec3>, usize)> = None;
        for _ in 0..super::untangle::PASSES {
            let crossing = |p: &[DVec3]| {
                crossings.faces_with_lengths(&TriMesh { positions: p.to_vec(), triangles: mesh.triangles.clone() })
            };
            let outcome = super::untangle::relax(
                &mesh.triangles,
                &mut candidate,
                neighbours,
                setup.position_ids(),
                edge,
                crossing,
            )
            .map_err(spatial)?;
            if outcome.rounds == 0 {
                break;
            }
            rounds += outcome.rounds;
            // The volume is restored away from the smoothed vertices (their own normals are
            // those of a crumpled fold: offsetting them would crumple it again), by every vertex
            // smoothed so far, each as much as it was.
            for (w, o) in weights.iter_mut().zip(&outcome.weights) {
                *w = w.max(*o);
            }
            let carriers = super::untangle::volume_carriers(neighbours, &weights);
            let Some(restored) = restore_volume_with(&before, candidate, &carriers) else { break };
            let restored_mesh = TriMesh { positions: restored, triangles: mesh.triangles.clone() };
            let faces = crossings.faces(&restored_mesh).map_err(spatial)?.len();
            candidate = restored_mesh.positions;
            result = Some((candidate.clone(), faces));
            if faces == 0 {
                break;
            }
        }
        // The last pass is kept unless it leaves more faces crossing than the contacts did.
        if let Some((restored, faces)) = result
            && faces <= faces_now
        {
            untangled.rounds = rounds;
            faces_now = faces;
            for (v, (p, q)) in positions.iter_mut().zip(&restored).enumerate() {
                if p != q {
                    moved[v] = true;
                    *p = *q;
                }
            }
        }
    }
    untangled.faces_after = faces_now;
    untangled.time = untangle_start.elapsed();
    let untangle_work = Work::lap();
    let counts_start = Instant::now();
    let result = TriMesh { positions, triangles: mesh.triangles.clone() };
    let after = crossings.faces(&result).map_err(spatial)?.len();
    let before = match (input_pairs, rest_intersections) {
        (Some(pairs), Some(rest)) => rest.faces_beyond_in(pairs).len(),
        (Some(_), None) => 0,
        (None, _) => {
            if first.is_some() {
                crossings.last = first;
            }
            crossings.faces(input).map_err(spatial)?.len()
        }
    };
    let self_intersecting_faces = [before, after];
    let counts = Spent { time: counts_start.elapsed(), work: Work::lap() };
    outer.record();
    Ok(PartContactResult {
        positions: result.positions,
        moved,
        pairs: stats,
        self_intersecting_faces,
        untangled,
        rest_caches,
        search,
        pair_stages,
        untangle_work,
        counts,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::Deformer;
    use crate::mesh::{shapes, signed_volume};
    use crate::skinning::{SkinWeights, parts_from_skin};

    /// Two capsules of one mesh skinned to sibling joints 1 and 2 (joint 0 their parent, with
    /// no vertex): the first along z at the origin, the second along z at x = 3 in the rest
    /// pose. `pose(x, turn)` moves the second to x and turns the first by `turn` radians about
    /// x (rigid skinning: every vertex has one joint).
    struct Siblings {
        rest: TriMesh,
        parts: SkinParts,
        count: usize,
    }

    impl Siblings {
        fn new() -> Self {
            let capsule = shapes::capsule(0.5, 3.0, 24, 8, 12);
            let count = capsule.num_vertices();
            let rest = Self::place(&capsule, 3.0, 0.0);
            let joints = (0..2 * count).map(|v| if v < count { [1, 0, 0, 0] } else { [2, 0, 0, 0] }).collect();
            let weights = SkinWeights::new(joints, vec![[1.0, 0.0, 0.0, 0.0]; 2 * count]).unwrap();
            let names = ["root", "first", "second"].map(String::from);
            let parts = parts_from_skin(&rest, &weights, &[None, Some(0), Some(0)], &names, 10);
            Self { rest, parts, count }
        }

        fn place(capsule: &TriMesh, x: f64, turn: f64) -> TriMesh {
            let n = capsule.num_vertices() as u32;
            let r = glam::DMat3::from_rotation_x(turn);
            let mut mesh = TriMesh { positions: capsule.positions.iter().map(|p| r * *p).collect(), ..capsule.clone() };
            mesh.positions.extend(capsule.positions.iter().map(|p| *p + DVec3::new(x, 0.0, 0.0)));
            mesh.triangles.extend(capsule.triangles.iter().map(|t| t.map(|v| v + n)));
            mesh
        }

        fn pose(&self, x: f64, turn: f64) -> TriMesh {
            let capsule = TriMesh {
                positions: self.rest.positions[..self.count].to_vec(),
                triangles: self.rest.triangles[..self.rest.num_triangles() / 2].to_vec(),
            };
            Self::place(&capsule, x, turn)
        }

        fn params(&self, rest: &TriMesh) -> ObjectParams {
            ObjectParams {
                self_contact_parts: Some(self.parts.clone()),
                rest_positions: Some(rest.positions.clone()),
                ..ObjectParams::default()
            }
        }

        fn run(&self, deformer: &mut Deformer, mesh: &TriMesh, params: &ObjectParams) -> super::super::FrameResult {
            let frame = Frame { objects: vec![FrameObject { name: "siblings", mesh, params }], pairs: vec![] };
            deformer.deform(&frame).unwrap()
        }
    }

    #[test]
    fn crossing_sibling_capsules_are_found_and_separated_with_the_volume_kept() {
        let s = Siblings::new();
        let posed = s.pose(0.8, std::f64::consts::FRAC_PI_2);
        let result = s.run(&mut Deformer::new(), &posed, &s.params(&s.rest));
        let pairs = &result.stats.part_pairs;
        assert_eq!(pairs.len(), 1, "{pairs:?}");
        let pair = &pairs[0];
        assert_eq!(pair.parts, ["first".to_string(), "second".to_string()]);
        assert!(pair.error.is_none(), "{pair:?}");
        assert!(pair.in_contact && pair.contact_area > 0.0);
        assert!(pair.faces_before > 0);
        assert_eq!(pair.faces_after, 0);
        let after = TriMesh { positions: result.positions[0].clone(), triangles: posed.triangles.clone() };
        assert!(crate::spatial::self_intersections(&after).unwrap().faces.is_empty());
        let (v0, v1) = (signed_volume(&posed), signed_volume(&after));
        assert!(((v1 - v0) / v0).abs() <= 1e-9, "{v0} → {v1}");
        assert!(result.stats.objects[0].deformed);
    }

    /// A pair's result is applied in proportion to how far its parts cross (its onset): the
    /// share reported is the summed length of the crossing segments between the two capsules
    /// (measured here over every face pair) over `ONSET_EDGES` mean edges, growing with the
    /// depth up to the whole result, and the object keeps its volume at every share.
    #[test]
    fn a_part_pair_applies_a_share_of_its_result_growing_with_its_crossing() {
        let s = Siblings::new();
        let params = ObjectParams { untangle: false, ..s.params(&s.rest) };
        let mut shares = Vec::new();
        for x in [0.99, 0.97, 0.9, 0.6] {
            let posed = s.pose(x, std::f64::consts::FRAC_PI_2);
            let result = s.run(&mut Deformer::new(), &posed, &params);
            let pair = &result.stats.part_pairs[0];
            let share = pair.onset.unwrap_or_else(|| panic!("{x}: no result {pair:?}"));
            let half = posed.num_triangles() / 2;
            let length: f64 = (0..half)
                .flat_map(|f| (half..2 * half).map(move |g| (f, g)))
                .map(|(f, g)| crate::spatial::intersection_length(&posed.corners(f), &posed.corners(g)))
                .sum();
            let expected = (length / (ONSET_EDGES * mean_edge(&posed))).min(1.0);
            assert!((share - expected).abs() <= 1e-9 * expected, "{x}: {share} against {expected}");
            let after = TriMesh { positions: result.positions[0].clone(), triangles: posed.triangles.clone() };
            let (v0, v1) = (signed_volume(&posed), signed_volume(&after));
            assert!(((v1 - v0) / v0).abs() <= 1e-9, "{x}: {v0} → {v1}");
            assert_ne!(after.positions, posed.positions, "{x}: {pair:?}");
            shares.push(share);
        }
        assert!(shares[0] > 0.0 && shares.windows(2).all(|w| w[0] < w[1] || w[1] == 1.0), "{shares:?}");
        assert!(shares[1] < 1.0 && shares[3] == 1.0, "{shares:?}");
    }

    /// Pushed through each other in small steps from touching, the capsules' output moves by at
    /// most twice their input's step: no result switches on at once.
    #[test]
    fn a_part_pair_starting_to_cross_moves_the_output_in_proportion_to_the_input() {
        let s = Siblings::new();
        let params = ObjectParams { untangle: false, ..s.params(&s.rest) };
        let mut deformer = Deformer::new();
        let mut last: Option<(TriMesh, Vec<DVec3>)> = None;
        let mut largest_ratio = 0.0_f64;
        for k in 0..=16 {
            let posed = s.pose(1.0 - 0.004 * k as f64, std::f64::consts::FRAC_PI_2);
            let result = s.run(&mut deformer, &posed, &params);
            let output = result.positions[0].clone();
            if let Some((input, before)) = &last {
                let input_step =
                    posed.positions.iter().zip(&input.positions).map(|(a, b)| a.distance(*b)).fold(0.0, f64::max);
                let output_step = output.iter().zip(before).map(|(a, b)| a.distance(*b)).fold(0.0, f64::max);
                largest_ratio = largest_ratio.max(output_step / input_step);
            }
            last = Some((posed, output));
        }
        assert!(largest_ratio <= 2.0, "an output step {largest_ratio}× the input's");
    }

    /// The rest pose's caches (its own crossings, the touching search's tree, the object's
    /// connectivity) are built at the first frame and counted in `setup`, not at the next.
    #[test]
    fn the_rest_pose_caches_are_setup_work_of_the_first_frame_only() {
        let s = Siblings::new();
        let posed = s.pose(0.8, std::f64::consts::FRAC_PI_2);
        let mut deformer = Deformer::new();
        let first = s.run(&mut deformer, &posed, &s.params(&s.rest));
        let second = s.run(&mut deformer, &posed, &s.params(&s.rest));
        let tests = |r: &crate::FrameResult| r.stats.work[Stage::Setup].triangle_tests;
        // The rest pose's crossings test every pair of faces whose boxes overlap, adjacent
        // ones included: at least one test per face.
        assert!(
            tests(&first) >= s.rest.num_triangles() as u64 + tests(&second),
            "{} {}",
            tests(&first),
            tests(&second)
        );
        assert_eq!(first.positions, second.positions);
    }

    #[test]
    fn a_part_pair_is_a_job_that_records_the_contact_stages_it_ran() {
        let s = Siblings::new();
        let posed = s.pose(0.8, std::f64::consts::FRAC_PI_2);
        let result = s.run(&mut Deformer::new(), &posed, &s.params(&s.rest));
        let jobs: Vec<_> = result.stats.jobs.iter().filter(|j| j.kind == super::super::JobKind::Parts).collect();
        assert_eq!(jobs.len(), 1, "{:?}", result.stats.jobs);
        let job = jobs[0];
        assert!(job.in_contact && job.error.is_none(), "{job:?}");
        // Chapter 4, chapter 5 and the separation pass run as stages of the job, not inside a
        // nested frame; its own share (regions, interior, volume over the seam) is
        // `part_contacts`; no quality pass of its own.
        for stage in [Stage::Intersection, Stage::Mapping, Stage::Parametrization, Stage::Deformation] {
            assert!(!job.stages[stage].is_zero(), "{stage}: {job:?}");
            assert!(!job.work[stage].is_zero() || stage == Stage::Deformation, "{stage}: {job:?}");
        }
        assert!(!job.stages[Stage::PartContacts].is_zero() && !job.work[Stage::PartContacts].is_zero());
        assert!(job.stages[Stage::Quality].is_zero() && job.work[Stage::Quality].is_zero(), "{job:?}");
        // The job's stages are within the frame's, and together within the pair's time.
        for stage in Stage::ALL {
            assert!(job.stages[stage] <= result.stats.stages[stage], "{stage}");
        }
        let staged: Duration = Stage::spans().map(|stage| job.stages[stage]).sum();
        assert!(
            staged <= result.stats.part_pairs[0].time + Duration::from_micros(1),
            "{staged:?} {:?} {:?}",
            result.stats.part_pairs[0].time,
            job.stages
        );
    }

    #[test]
    fn caches_kept_from_frame_to_frame_give_the_bits_of_fresh_ones() {
        // The counts too: the object's intersecting face pairs are kept from frame to frame and
        // enumerated again where vertices moved; they must be a fresh search's.
        let s = Siblings::new();
        let rest = RestIntersections::new(&s.rest).unwrap();
        let mut kept = Deformer::new();
        for (x, turn) in [(0.9, 1.5), (0.8, 1.6), (0.6, 1.4), (0.85, 1.55), (3.0, 0.0), (0.7, 1.5)] {
            let posed = s.pose(x, turn);
            let params = s.params(&s.rest);
            let reused = s.run(&mut kept, &posed, &params);
            let fresh = s.run(&mut Deformer::new(), &posed, &params);
            assert_eq!(reused.positions, fresh.positions, "x = {x}");
            let untimed = |r: &super::super::FrameResult| -> Vec<PartPairStats> {
                r.stats.part_pairs.iter().map(|p| PartPairStats { time: Duration::ZERO, ..p.clone() }).collect()
            };
            assert_eq!(untimed(&reused), untimed(&fresh), "x = {x}");
            let counted = reused.stats.objects[0].self_intersecting_faces.unwrap();
            assert_eq!(Some(counted), fresh.stats.objects[0].self_intersecting_faces, "x = {x}");
            let result = TriMesh { positions: reused.positions[0].clone(), triangles: posed.triangles.clone() };
            let searched = [rest.faces_beyond(&posed).unwrap().len(), rest.faces_beyond(&result).unwrap().len()];
            assert_eq!(counted, searched, "x = {x}");
            if x < 3.0 {
                assert!(reused.stats.part_pairs.iter().any(|p| p.in_contact), "x = {x}");
                assert!(counted[0] > 0, "x = {x}");
            }
        }
    }

    #[test]
    fn restoring_the_volume_brings_it_back_exactly() {
        let capsule = shapes::capsule(0.5, 3.0, 24, 8, 12);
        let v0 = signed_volume(&capsule);
        // A dent that loses volume, as a contact pushing one side in.
        let new: Vec<DVec3> = capsule
            .positions
            .iter()
            .map(|p| if p.x > 0.3 && p.z.abs() < 0.5 { *p - DVec3::new(0.1, 0.0, 0.0) } else { *p })
            .collect();
        let dented = TriMesh { positions: new.clone(), triangles: capsule.triangles.clone() };
        assert!((signed_volume(&dented) - v0).abs() > 1e-4);
        let restored = restore_volume(&capsule, new.clone()).unwrap();
        let v1 = signed_volume(&TriMesh { positions: restored.clone(), triangles: capsule.triangles.clone() });
        assert!(((v1 - v0) / v0).abs() <= 1e-12, "{v0} → {v1}");
        // Only the dented vertices move, and by less than the dent.
        for ((p, q), r) in capsule.positions.iter().zip(&new).zip(&restored) {
            if p == q {
                assert_eq!(q, r);
            } else {
                assert!((*r - *q).length() < 0.1);
            }
        }
    }

    #[test]
    fn regions_grown_from_the_intersection_are_disjoint_and_open_between_them() {
        let s = Siblings::new();
        let posed = s.pose(0.8, std::f64::consts::FRAC_PI_2);
        let mut setup = PartContactSetup::new(&s.rest).unwrap();
        let touching = setup.touching(&posed, &s.parts).unwrap();
        let labels = intersection_labels(&posed, &vertex_neighbours(&posed), &touching[0].faces, 4);
        // Every seed face of a side lies wholly in its region.
        for [f, g] in &touching[0].faces {
            assert!(posed.triangles[*f as usize].iter().all(|&v| labels[v as usize] == 1.0));
            assert!(posed.triangles[*g as usize].iter().all(|&v| labels[v as usize] == 2.0));
        }
        // The capsules are separate components: no seam between the sides, so nothing is open.
        assert!(!seam_between(&posed, &labels).iter().any(|&o| o));
        // On one capsule split in two halves by label, the vertices next to the other half are.
        let n = s.count;
        let mid = s.rest.positions[..n].iter().map(|p| p.z).sum::<f64>() / n as f64;
        let halves: Vec<f64> = (0..2 * n)
            .map(|v| {
                if v >= n {
                    0.0
                } else if s.rest.positions[v].z < mid {
                    1.0
                } else {
                    2.0
                }
            })
            .collect();
        let open = seam_between(&s.rest, &halves);
        assert!(open.iter().any(|&o| o));
        for (v, &o) in open.iter().enumerate() {
            if o {
                assert!(halves[v] != 0.0 && (s.rest.positions[v].z - mid).abs() < 0.5, "{v}");
            }
        }
    }

    /// docs/decisions.md, "Regions grown from the intersection": two parts apart try their
    /// margins, then one width of grown regions; the other kinds the grown width only.
    #[test]
    fn a_pair_tries_its_margins_then_one_width_grown_from_the_intersection() {
        let pair = |kind| TouchingPair { parts: [1, 2], kind, faces: vec![[0, 1]] };
        let parts: Vec<_> = tries(&pair(TouchingKind::Parts)).collect();
        let mut expected: Vec<_> = MARGIN_RINGS.iter().map(|&r| (false, r)).collect();
        expected.push((true, GROWN_RINGS));
        assert_eq!(parts, expected);
        for kind in [TouchingKind::AfterArticulation, TouchingKind::WithinPart(0)] {
            assert_eq!(tries(&pair(kind)).collect::<Vec<_>>(), [(true, GROWN_RINGS)], "{kind:?}");
        }
    }

    #[test]
    fn parts_that_touch_in_the_rest_pose_are_left_alone() {
        let s = Siblings::new();
        let posed = s.pose(0.8, std::f64::consts::FRAC_PI_2);
        // The same crossing in the rest pose: the asset's own.
        let result = s.run(&mut Deformer::new(), &posed, &s.params(&posed));
        assert!(result.stats.part_pairs.is_empty());
        assert_eq!(result.positions[0], posed.positions);
    }

    #[test]
    fn the_displacement_starts_from_zero_when_the_parts_start_to_touch() {
        let s = Siblings::new();
        let params = s.params(&s.rest);
        let mut deformer = Deformer::new();
        let mut largest = Vec::new();
        // Apart by 10⁻³, then sinking in (exact tangency is left out: see docs/decisions.md).
        for depth in [-1e-3, 0.005, 0.01, 0.02] {
            let posed = s.pose(1.0 - depth, std::f64::consts::FRAC_PI_2);
            let result = s.run(&mut deformer, &posed, &params);
            largest.push(result.stats.objects[0].max_displacement);
        }
        assert_eq!(largest[0], 0.0);
        // Bounded by a few times the depth, and growing with it.
        for (d, m) in [0.005, 0.01, 0.02].iter().zip(&largest[1..]) {
            assert!(*m <= 3.0 * d, "depth {d}: {m}");
        }
        assert!(largest[1] <= largest[3]);
    }

    /// A ball of one part crumpled by its skinning: its top vertex pulled through it and out of
    /// its far side, its faces crossing the far side's. The posed ball, the pulled vertex and the
    /// deformer's result.
    /// A ball of one part, its topmost vertex, and its parameters with self-contact parts.
    fn ball_of_one_part(subdivisions: u32) -> (TriMesh, usize, ObjectParams) {
        let rest = shapes::icosphere(1.0, subdivisions);
        let top =
            (0..rest.num_vertices()).max_by(|&a, &b| rest.positions[a].z.total_cmp(&rest.positions[b].z)).unwrap();
        let parts = SkinParts::from_face_labels(vec![0; rest.num_triangles()]);
        let params = ObjectParams {
            self_contact_parts: Some(parts),
            rest_positions: Some(rest.positions.clone()),
            ..ObjectParams::default()
        };
        (rest, top, params)
    }

    fn crumpled_ball(subdivisions: u32) -> (TriMesh, usize, crate::FrameResult) {
        let (rest, top, params) = ball_of_one_part(subdivisions);
        let mut posed = rest.clone();
        posed.positions[top] = DVec3::new(0.0, 0.0, -1.3);
        let frame = Frame { objects: vec![FrameObject { name: "ball", mesh: &posed, params: &params }], pairs: vec![] };
        let result = Deformer::new().deform(&frame).unwrap();
        (posed, top, result)
    }

    /// The untangling is continuous in the pose: one vertex of a ball pulled down through the
    /// ball's far side in steps of 10⁻³, from before its faces cross that side to well past it.
    /// No output step is more than a bounded multiple of the input step, where smoothing by a
    /// full step once the first face crosses jumped at the onset.
    #[test]
    fn untangling_a_fold_is_continuous_as_it_starts_to_cross() {
        let (rest, top, params) = ball_of_one_part(3);
        let mut deformer = Deformer::new();
        let mut last: Option<(f64, Vec<DVec3>)> = None;
        let (mut largest, mut crossed) = (0.0_f64, false);
        for k in 0..=60 {
            let z = -0.97 - 1e-3 * k as f64;
            let mut posed = rest.clone();
            posed.positions[top] = DVec3::new(0.031, 0.017, z);
            let frame =
                Frame { objects: vec![FrameObject { name: "ball", mesh: &posed, params: &params }], pairs: vec![] };
            let result = deformer.deform(&frame).unwrap();
            let stats = &result.stats.objects[0];
            crossed |= stats.self_intersecting_faces.is_some_and(|[before, _]| before > 0);
            assert_eq!(stats.self_intersecting_faces.map(|[_, after]| after), Some(0), "at z = {z}");
            let out = result.positions[0].clone();
            if let Some((z0, previous)) = &last {
                let step = out.iter().zip(previous).map(|(p, q)| p.distance(*q)).fold(0.0, f64::max);
                largest = largest.max(step / (z - z0).abs());
            }
            last = Some((z, out));
        }
        assert!(crossed, "the sweep never crossed the far side");
        assert!(largest <= 10.0, "an output step of {largest} times the input step");
    }

    /// A skin crumpled by its skinning: one vertex of a ball (one part) pulled through the ball
    /// and out of its far side, its faces crossing the far side's. No contact can push that
    /// apart; the untangling smooths it out, and the ball keeps its volume.
    #[test]
    fn a_fold_within_one_part_is_untangled_with_the_volume_kept() {
        let (posed, top, result) = crumpled_ball(3);
        let stats = &result.stats.objects[0];
        let [before, after] = stats.self_intersecting_faces.unwrap();
        assert!(before > 0);
        assert_eq!(after, 0, "{:?}", stats.untangled);
        let untangled = stats.untangled.unwrap();
        assert!(untangled.rounds > 0 && untangled.faces_before > 0 && untangled.faces_after == 0, "{untangled:?}");
        let out = TriMesh { positions: result.positions[0].clone(), triangles: posed.triangles.clone() };
        let (v0, v1) = (signed_volume(&posed), signed_volume(&out));
        assert!(((v1 - v0) / v0).abs() <= 1e-9, "{v0} → {v1}");
        // The pulled vertex is back inside the ball (untangled, not restored: smoothing stops
        // when nothing crosses); a band around the smoothed vertices carries the volume by a
        // small offset.
        assert!(out.positions[top].z > -0.9, "{:?}", out.positions[top]);
        let far = out.positions.iter().zip(&posed.positions).filter(|(_, p)| p.z < -0.5 && p.x.abs() > 0.5);
        for (q, p) in far {
            assert!((*q - *p).length() < 0.02, "{p} → {q}");
        }
    }

    /// The untangling's volume goes into a band around the fold: on a finer ball crumpled the
    /// same way, the vertices around its equator, farther from the fold than the smoothed rings,
    /// the gap and the band, keep their positions bit for bit, and the volume is still exact.
    #[test]
    fn untangling_moves_only_a_band_around_the_fold() {
        let (posed, _, result) = crumpled_ball(4);
        let stats = &result.stats.objects[0];
        assert_eq!(stats.self_intersecting_faces.unwrap()[1], 0, "{:?}", stats.untangled);
        let out = &result.positions[0];
        let out_mesh = TriMesh { positions: out.clone(), triangles: posed.triangles.clone() };
        let (v0, v1) = (signed_volume(&posed), signed_volume(&out_mesh));
        assert!(((v1 - v0) / v0).abs() <= 1e-9, "{v0} → {v1}");
        let mut equator = 0;
        for (v, (q, p)) in out.iter().zip(&posed.positions).enumerate() {
            if p.z.abs() < 0.2 {
                equator += 1;
                assert_eq!(q, p, "vertex {v} at the equator moved");
            }
        }
        assert!(equator > 100, "{equator}");
        let moved = out.iter().zip(&posed.positions).filter(|(q, p)| q != p).count();
        assert!(2 * moved < out.len(), "{moved} of {} vertices moved", out.len());
    }

    #[test]
    fn the_result_does_not_depend_on_the_thread_count() {
        let s = Siblings::new();
        let posed = s.pose(0.7, 1.2);
        let params = s.params(&s.rest);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| s.run(&mut Deformer::new(), &posed, &params).positions)
        };
        let one = run(1);
        assert_ne!(one[0], posed.positions);
        assert_eq!(one, run(2));
    }

    /// Capsules of one mesh, each skinned to its own joint (siblings under a root joint with no
    /// vertex), each along z turned by `turn` radians about x, then moved by `offset`; the rest
    /// pose has them 3 apart along y, none touching.
    fn capsules(placements: &[(DVec3, f64)]) -> (TriMesh, TriMesh, ObjectParams) {
        let capsule = shapes::capsule(0.5, 3.0, 24, 8, 12);
        let count = capsule.num_vertices();
        let place = |placements: &[(DVec3, f64)]| {
            let mut mesh = TriMesh { positions: Vec::new(), triangles: Vec::new() };
            for &(offset, turn) in placements {
                let first = mesh.num_vertices() as u32;
                let r = glam::DMat3::from_rotation_x(turn);
                mesh.positions.extend(capsule.positions.iter().map(|p| r * *p + offset));
                mesh.triangles.extend(capsule.triangles.iter().map(|t| t.map(|v| v + first)));
            }
            mesh
        };
        let rest_placements: Vec<(DVec3, f64)> =
            (0..placements.len()).map(|k| (DVec3::new(0.0, 3.0 * k as f64, 0.0), 0.0)).collect();
        let rest = place(&rest_placements);
        let joints = (0..rest.num_vertices()).map(|v| [(v / count + 1) as u32, 0, 0, 0]).collect();
        let weights = SkinWeights::new(joints, vec![[1.0, 0.0, 0.0, 0.0]; rest.num_vertices()]).unwrap();
        let names: Vec<String> = (0..=placements.len()).map(|j| format!("joint {j}")).collect();
        let parents: Vec<Option<usize>> = (0..=placements.len()).map(|j| (j > 0).then_some(0)).collect();
        let parts = parts_from_skin(&rest, &weights, &parents, &names, 10);
        let params = ObjectParams {
            self_contact_parts: Some(parts),
            rest_positions: Some(rest.positions.clone()),
            ..ObjectParams::default()
        };
        (place(placements), rest, params)
    }

    fn run_capsules(mesh: &TriMesh, params: &ObjectParams, threads: usize) -> crate::FrameResult {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let frame = Frame { objects: vec![FrameObject { name: "capsules", mesh, params }], pairs: vec![] };
        pool.install(|| Deformer::new().deform(&frame).unwrap())
    }

    #[test]
    fn pairs_apart_run_in_one_batch_each_as_if_alone() {
        use std::f64::consts::FRAC_PI_2;
        // Two crosses of two capsules each, 20 apart.
        let cross = |x: f64| [(DVec3::new(x, 0.0, 0.0), 0.0), (DVec3::new(x + 0.8, 0.0, 0.0), FRAC_PI_2)];
        let (posed, _, params) = capsules(&[cross(0.0), cross(20.0)].concat());
        let one = run_capsules(&posed, &params, 1);
        let pairs = &one.stats.part_pairs;
        assert_eq!(pairs.len(), 2, "{pairs:?}");
        for pair in pairs {
            assert_eq!((pair.batch, pair.runs), (0, 1), "{pair:?}");
            assert!(pair.error.is_none() && pair.faces_before > 0 && pair.faces_after == 0, "{pair:?}");
        }
        assert_eq!(one.positions, run_capsules(&posed, &params, 2).positions);
        let after = TriMesh { positions: one.positions[0].clone(), triangles: posed.triangles.clone() };
        let (v0, v1) = (signed_volume(&posed), signed_volume(&after));
        assert!(((v1 - v0) / v0).abs() <= 1e-9, "{v0} → {v1}");
        // The first cross comes out as it does when the second does not touch (its capsules
        // apart): the pairs of a batch do not see each other.
        let apart = [cross(0.0), [(DVec3::new(20.0, 0.0, 0.0), 0.0), (DVec3::new(23.0, 0.0, 0.0), FRAC_PI_2)]].concat();
        let (alone, _, _) = capsules(&apart);
        let alone = run_capsules(&alone, &params, 1);
        assert_eq!(alone.stats.part_pairs.len(), 1);
        let half = posed.num_vertices() / 2;
        let largest = one.positions[0][..half]
            .iter()
            .zip(&alone.positions[0][..half])
            .map(|(p, q)| p.distance(*q))
            .fold(0.0, f64::max);
        let moved =
            one.positions[0][..half].iter().zip(&posed.positions).map(|(p, q)| p.distance(*q)).fold(0.0, f64::max);
        assert!(moved > 0.05 && largest <= 1e-9 * moved, "{largest:e} of {moved}");
    }

    #[test]
    fn pairs_that_share_a_part_run_one_after_the_other() {
        use std::f64::consts::FRAC_PI_2;
        // A horizontal capsule through two upright ones: both pairs have the horizontal one.
        let placements = [
            (DVec3::new(-1.0, 0.0, 0.0), 0.0),
            (DVec3::new(0.0, 0.0, 0.0), FRAC_PI_2),
            (DVec3::new(1.0, 0.0, 0.0), 0.0),
        ];
        let (posed, _, params) = capsules(&placements);
        let one = run_capsules(&posed, &params, 1);
        let pairs = &one.stats.part_pairs;
        assert_eq!(pairs.len(), 2, "{pairs:?}");
        assert_eq!(pairs.iter().map(|p| p.part_ids).collect::<Vec<_>>(), [[0, 1], [1, 2]]);
        assert_eq!(pairs.iter().map(|p| p.batch).collect::<Vec<_>>(), [0, 1]);
        assert_eq!(one.positions, run_capsules(&posed, &params, 2).positions);
        let after = TriMesh { positions: one.positions[0].clone(), triangles: posed.triangles.clone() };
        let (v0, v1) = (signed_volume(&posed), signed_volume(&after));
        assert!(((v1 - v0) / v0).abs() <= 1e-9, "{v0} → {v1}");
    }

    #[test]
    fn an_automatic_articulation_that_fails_is_reported_not_fatal() {
        let s = Siblings::new();
        let posed = s.pose(0.8, std::f64::consts::FRAC_PI_2);
        let n = s.count as u32;
        // The two capsules as the two sides: they do not overlap, so there is no shared region.
        let articulation = crate::params::Articulation {
            name: "apart".into(),
            regions: [(0..n).collect(), (n..2 * n).collect()],
            joints: Some([DVec3::NEG_Z, DVec3::ZERO, DVec3::Z]),
            automatic: true,
            ..Default::default()
        };
        let mut params = s.params(&s.rest);
        params.self_contact = vec![articulation.clone()];
        let result = s.run(&mut Deformer::new(), &posed, &params);
        let stats = &result.stats.articulations;
        assert_eq!(stats.len(), 1);
        assert!(stats[0].error.as_deref().is_some_and(|e| e.contains("shared region")), "{stats:?}");
        // The part contact still ran.
        assert_eq!(result.stats.part_pairs[0].faces_after, 0);
        // Asked for explicitly, the same articulation fails the frame.
        params.self_contact[0].automatic = false;
        let frame =
            Frame { objects: vec![FrameObject { name: "siblings", mesh: &posed, params: &params }], pairs: vec![] };
        assert!(Deformer::new().deform(&frame).is_err());
    }
}
