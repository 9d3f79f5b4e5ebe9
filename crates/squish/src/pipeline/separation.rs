//! The separation pass (issue 29; docs/decisions.md, "Separation pass"): after chapter 5 has deformed
//! every region, the outputs of each region pair in contact are pushed apart until no triangle of
//! one crosses a triangle of the other, with the volume of every region still preserved.
//!
//! **Why.** The contact gap ([`crate::contact::gap`]) backs the zones' targets off the contact
//! surface 𝒮 (§4.3), but only the zone's vertices go to targets: a triangle between them is a
//! chord that still cuts a curved or finer partner, the partner's vertices poke through it, and the
//! bulge of 𝒟 (§5.4, Eq. 5.5) grows, around the contact, into whatever is there. Nothing in
//! chapters 4–5 sees the partner's output.
//!
//! **Rule.** Per region pair with a non-zero gap g (the pair's [`PairContact::gap`]) and per
//! deformable side S of share s (its partner's relative stiffness k̄ of §4.3, the share of δ it
//! moves, renormalized over the sides this pass can move), against the other side O's output surface:
//! - every vertex v of S within the pairs' boxes at signed distance d < g of O (negative inside
//!   O) wants `s·(g − d)·n`, n the unit direction out of O at its closest point — and the same
//!   for the closest point of every other face of O near v, at the signed distance d plus its
//!   extra distance (so that the moves stay continuous as v crosses from one face's reach to
//!   another's, or through the surface);
//! - every vertex w of O at signed distance d < g of S wants S's face at w's closest point (and
//!   likewise every face near w) moved by `−s·(g − d)·n` (n out of S there), shared among the
//!   face's corners with barycentric weights `b_i/Σb_j²` (the point under w moves by that);
//! - a vertex takes the mean of the moves it is asked for weighted by their length to the 4th
//!   power (close to the longest, yet continuous: a maximum would switch direction where two
//!   moves cross in length), and each move is spread over the vertices within [`SPREAD_EDGES`]
//!   mean edge lengths with the weight `(1 − (r/R)²)²`, blended the same way: no spike, and a
//!   move that is a continuous function of the geometry (0 where every distance is at least g).
//!
//! Inside/outside is the winding number of O's object when it is closed (whole or cut; not for
//! two regions of one object), and the generalized winding number of O above ¼ otherwise
//! ([`FastWinding`]: ½ behind a flat sheet, −½ in front); points farther than [`DEPTH_EDGES`]
//! edge lengths inside an open surface are left alone (they are behind it, not near the
//! contact). What a vertex learns of its winding number about an open surface is carried to the
//! next rounds and passes with a bound on how far it can move ([`super::rim`]): it is evaluated
//! again only when that no longer settles the side. Only vertices of deformed regions move —
//! those of the parametrization domain 𝒫 or the contact set (§5.1), never on a cut border (their
//! faces outside would move out of the volume balance).
//!
//! **Volume.** The moves accumulate into a correction added to the fixed part of the region's
//! affine displacement, and the bulge height is solved again with it
//! ([`crate::deform::RegionDeformation::correct`], §5.4.2, App. C): the volume (swept volume for
//! an open region) stays exactly preserved. The new height moves 𝒟 a little, so the pass runs
//! again on the new outputs, until no move exceeds [`STOP_FRACTION`]·g or after [`MAX_ROUNDS`].
//! The faces still intersecting then are counted with the exact test and reported as a
//! [`WarningKind::Unseparated`] frame warning, never silently.
//!
//! **From the last pass.** A pass starts from the last pass's first distance bounds on the same
//! deformer ([`SeparationSeed`]: an edit's from its kept frame's, a frame's from the frame
//! before) when they are distances to the same surfaces, lowered by how far every vertex moved
//! between the two passes' starts: it queries fewer vertices and gets the same answers, so the
//! same bits.
//!
//! Deterministic: every loop runs in vertex or region-pair order, the faces near a point come
//! sorted, and parallel maps collect in order. Continuous: every move is a continuous function
//! of the outputs of chapter 5 (measured: the largest step of a vertex between frames of a
//! sliding contact is unchanged, `tests/pipeline/gap.rs`), up to the stopping rule (a round
//! more or less moves a vertex by at most ~[`STOP_FRACTION`]·g). Its time is its own stage,
//! [`crate::stage::Stage::Separation`]. It extends the thesis' §4.3–§5.4 (not in it).

use std::sync::{Arc, Mutex, OnceLock};

use glam::DVec3;
use rayon::prelude::*;

use super::cache::{ObjectCache, SideTrees};
use super::contacts::RegionPair;
use super::deformations::RegionOutcome;
use super::rim::{RimMove, RimTree, WINDING_ALLOWANCE, WindingKnown, rim_of};
use super::warnings::{FrameWarning, WarningKind};
use super::{Frame, PipelineError};
use crate::contact::PairContact;
use crate::deform::{HeightChoice, SweptTerms};
use crate::mesh::{Aabb3, Topology, TriMesh, face_normal_unnormalized};
use crate::spatial::{FastWinding, TriangleBvh, WindingClusters, closest_point_on_triangle};
use crate::stage::{SharedWork, Work};

/// Most rounds of moves and height solves per frame.
pub const MAX_ROUNDS: usize = 8;
/// The pass stops when no vertex is asked to move by more than this fraction of the gap: at the
/// default gap (a tenth of a mean edge) half a hundredth of an edge, what a round more or less
/// changes between two frames (docs/decisions.md, "Separation pass").
pub const STOP_FRACTION: f64 = 0.05;
/// Radius of the spread of a move, in mean edge lengths of the moved object.
pub const SPREAD_EDGES: f64 = 2.0;
/// Depth, in mean edge lengths of the pair, beyond which a point behind an open surface is not
/// considered inside it.
pub const DEPTH_EDGES: f64 = 4.0;

/// What the pass did on one region pair.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct PairSeparation {
    /// Rounds of moves applied.
    pub rounds: usize,
    /// Faces of the two sides still intersecting the other after the pass (distinct faces summed).
    pub remaining_faces: usize,
}

/// Where each object vertex may be moved: its region and local index (`None`: not movable).
/// Movable: in the parametrization domain 𝒫 or the contact set of a deformed region (what
/// chapter 5 may move there; a region holding 𝒫 then gives the whole object's result), not on a
/// cut border.
fn movable_vertices(
    object_vertices: usize,
    cache: &ObjectCache,
    outcomes: &[Option<RegionOutcome>],
) -> Vec<Option<(u32, u32)>> {
    let mut slot = vec![None; object_vertices];
    for (r, (region, outcome)) in cache.regions.iter().zip(outcomes).enumerate() {
        let Some(outcome) = outcome else { continue };
        let d = &outcome.deformation;
        let may_move = |local: usize| d.domain[local] || d.contact[local];
        match region.sub.as_deref() {
            None => {
                for (v, s) in slot.iter_mut().enumerate() {
                    if may_move(v) {
                        *s = Some((r as u32, v as u32));
                    }
                }
            }
            Some(sub) => {
                for (local, (&parent, &border)) in sub.sub.parent_vertex.iter().zip(&sub.border).enumerate() {
                    if !border && may_move(local) {
                        slot[parent as usize] = Some((r as u32, local as u32));
                    }
                }
            }
        }
    }
    slot
}

/// The current positions of an object: its input with its deformed regions written in.
fn object_positions(input: &[DVec3], cache: &ObjectCache, outcomes: &[Option<RegionOutcome>]) -> Vec<DVec3> {
    let mut positions = input.to_vec();
    for (region, outcome) in cache.regions.iter().zip(outcomes) {
        let Some(outcome) = outcome else { continue };
        match region.sub.as_deref() {
            None => positions.clone_from(&outcome.deformation.positions),
            Some(sub) => sub.sub.scatter(&outcome.deformation.positions, &mut positions),
        }
    }
    positions
}

/// Mean edge length of an object at `positions`.
fn mean_edge_length(cache: &ObjectCache, positions: &[DVec3]) -> f64 {
    let edges = cache.topology.edges();
    let total: f64 = edges.iter().map(|&[a, b]| (positions[a as usize] - positions[b as usize]).length()).sum();
    if edges.is_empty() { 0.0 } else { total / edges.len() as f64 }
}

impl SideTrees {
    /// The trees of region `region` of an object at `positions`.
    fn new(cache: &ObjectCache, region: usize, positions: &[DVec3], mesh: &TriMesh) -> Option<Self> {
        let region_cache = cache.regions.get(region)?;
        let (mut bvh, vertices) = match (region_cache.faces.as_ref(), region_cache.sub.as_deref()) {
            (None, _) => (TriangleBvh::clone(&cache.bvh), (0..positions.len() as u32).collect()),
            (Some(_), Some(sub)) => {
                let bvh = sub.bvh.relabeled(&sub.sub.parent_face, &sub.sub.parent_vertex, positions.len())?;
                (bvh, sub.sub.parent_vertex.clone())
            }
            (Some(faces), None) => {
                let mut vertices: Vec<u32> = faces.iter().flat_map(|&f| mesh.triangles[f as usize]).collect();
                vertices.sort_unstable();
                vertices.dedup();
                let bvh = TriangleBvh::with_faces(mesh, faces.iter().copied()).ok()?;
                (bvh, vertices)
            }
        };
        bvh.refit(positions).ok()?;
        Some(Self { bvh, vertices, clusters: WindingClusters::default(), rim: Default::default() })
    }
}

/// One side's surface for distance queries, in one region pair: its trees at the current
/// positions and how its inside is decided.
struct Surface<'a> {
    trees: &'a SideTrees,
    /// The whole object's tree at the same positions, for the inside of a region cut out of a
    /// closed object (`None`: the side's own tree is the whole object's, or its inside is not
    /// the object's).
    whole: Option<&'a TriangleBvh>,
    positions: &'a [DVec3],
    triangles: &'a [[u32; 3]],
    /// The object's connectivity.
    topology: &'a Topology,
    /// Inside/outside by the object's winding number (a closed object) rather than by the
    /// generalized one of the surface.
    closed: bool,
    /// The inside of an open surface in this round (`None` for a closed one).
    open: Option<&'a OpenSide>,
}

/// A point of a surface near a query: its face, its barycentric coordinates there, the query's
/// signed distance to it (negative inside) and the unit direction out of the surface there.
#[derive(Clone, Copy, Debug)]
struct Near {
    face: u32,
    bary: [f64; 3],
    distance: f64,
    out: DVec3,
}

/// Generalized winding number above which a point is inside an open surface: behind a flat
/// sheet it is ½, in front −½, inside a bowl near its bottom close to 1.
const OPEN_INSIDE_WINDING: f64 = 0.25;
/// Length, in gaps, below which the direction out of a surface leans to its face's normal.
const NORMAL_BLEND: f64 = 0.25;
/// Vertices per run of the inside walk ([`Surface::inside_flags`]).
const INSIDE_RUN: usize = 256;
/// Accuracy (β) of the far-field winding numbers of open surfaces.
const WINDING_ACCURACY: f64 = 4.0;
/// Within this of [`OPEN_INSIDE_WINDING`], the exact generalized winding number decides: far
/// above the far field's error at [`WINDING_ACCURACY`] (8·10⁻³ at worst on a sphere, see
/// [`FastWinding`]).
const WINDING_MARGIN: f64 = WINDING_ALLOWANCE;

impl Surface<'_> {
    /// Whether `q` is behind the open surface, with the winding number that decided it: its
    /// generalized winding number above [`OPEN_INSIDE_WINDING`], the fast approximation's unless
    /// it is within [`WINDING_MARGIN`] of the threshold, where the exact sum decides (so that the
    /// answer does not depend on the tree's clusters).
    fn winding_side(&self, winding: &FastWinding, q: DVec3) -> (bool, f64) {
        let w = winding.winding_number(q);
        if (w - OPEN_INSIDE_WINDING).abs() > WINDING_MARGIN {
            return (w > OPEN_INSIDE_WINDING, w);
        }
        let exact = self.trees.bvh.generalized_winding_number(q);
        (exact > OPEN_INSIDE_WINDING, exact)
    }

    /// Whether `q` is behind the open surface ([`Self::winding_side`]): from what is known of
    /// its winding number when that settles it ([`WindingKnown`]), else evaluated, and `known`
    /// set to what was learnt.
    fn behind_open_known(&self, open: &OpenSide, q: DVec3, known: &mut Option<WindingKnown>) -> bool {
        if let Some(behind) = known.and_then(|k| k.settled(OPEN_INSIDE_WINDING)) {
            return behind;
        }
        let (behind, value) = self.winding_side(&open.winding(&self.trees.bvh), q);
        *known = Some(WindingKnown { value, drift: 0.0, rim: open.rim.distance(q) });
        behind
    }

    /// Per vertex of `candidates` (sorted object vertex ids of a mesh with `topology`, at
    /// `positions`): inside this surface, when it is closed (all false otherwise). Each run of
    /// [`INSIDE_RUN`] candidates walks the edges between its vertices, adding the winding number's
    /// change along each edge ([`TriangleBvh::winding_change`]), from the vertices known to be
    /// outside (`outside`, per candidate: winding number 0) and from one ray cast per piece that
    /// none reaches: the same answers as a ray cast per vertex, exactly, for a short segment each.
    /// Runs in parallel.
    fn inside_flags(
        &self,
        positions: &[DVec3],
        topology: &Topology,
        candidates: &[u32],
        outside: &[bool],
    ) -> Vec<bool> {
        if !self.closed {
            return vec![false; candidates.len()];
        }
        let tree = self.whole.unwrap_or(&self.trees.bvh);
        // Candidate index of each vertex (u32::MAX: not a candidate).
        let mut index = vec![u32::MAX; positions.len()];
        for (k, &v) in candidates.iter().enumerate() {
            index[v as usize] = k as u32;
        }
        let work = SharedWork::default();
        let flags = candidates
            .par_chunks(INSIDE_RUN)
            .enumerate()
            .flat_map_iter(|(r, run)| {
                let first = r * INSIDE_RUN;
                work.measure(|| {
                    // Winding number per vertex of the run (None: not reached yet).
                    let mut winding: Vec<Option<i32>> =
                        outside[first..first + run.len()].iter().map(|&o| o.then_some(0)).collect();
                    let slot = |v: u32| {
                        let k = index[v as usize] as usize;
                        (k >= first && k < first + run.len()).then(|| k - first)
                    };
                    let mut queue: Vec<usize> = (0..run.len()).filter(|&k| winding[k].is_some()).collect();
                    // From the known vertices first, then from a ray cast at the first vertex
                    // none reached, until every one is reached.
                    let mut root = 0;
                    loop {
                        while let Some(k) = queue.pop() {
                            let (v, w) = (run[k], winding[k].unwrap_or(0));
                            for u in topology.vertex_neighbors(v) {
                                if let Some(j) = slot(u)
                                    && winding[j].is_none()
                                {
                                    let change = tree.winding_change(positions[v as usize], positions[u as usize]);
                                    winding[j] = Some(w + change);
                                    queue.push(j);
                                }
                            }
                        }
                        while root < run.len() && winding[root].is_some() {
                            root += 1;
                        }
                        let Some(&v) = run.get(root) else { break };
                        winding[root] = Some(tree.winding_number(positions[v as usize]));
                        queue.push(root);
                    }
                    winding.into_iter().map(|w| w.is_some_and(|w| w != 0)).collect::<Vec<bool>>()
                })
            })
            .collect();
        work.record();
        flags
    }

    /// The points of the surface that `q` should clear: the closest point of every face within
    /// `d₀ + reach − s₀` of `q` (d₀ its distance to the surface, s₀ = ±d₀ its signed distance,
    /// negative inside), each at the signed distance `s₀ + (d_f − d₀)`. The closest face is at
    /// s₀; a face at d_f enters with a zero move (`reach − s_f = 0`), so the moves are continuous
    /// in `q`, across faces and through the surface; a point on the bisector of a fold weighs on
    /// both faces. Empty when `q` is farther than `reach` outside or (open surfaces, whose inside
    /// is `winding`'s) deeper than `depth` inside. `leaves`: scratch space.
    ///
    /// Returned with bounds of `q`'s distance to the surface ([`DistanceBounds`]). `known`: the
    /// bounds known before. A point of an open surface's depth band (at most `depth` away) known
    /// to be farther than `reach` has an empty answer in front of the surface, so its side is
    /// asked first and its closest point only when it is behind (the same answer; `known` is then
    /// returned).
    fn near(
        &self,
        q: DVec3,
        inside_closed: bool,
        known: DistanceBounds,
        reach: Reach,
        leaves: &mut Vec<u32>,
    ) -> (Vec<Near>, DistanceBounds) {
        let Reach { gap: reach, depth } = reach;
        let open = self.open.filter(|_| !self.closed);
        let in_band = known.lower > reach * (1.0 + BOUND_SLACK) && known.upper < depth * (1.0 - BOUND_SLACK);
        let mut learnt = known.winding;
        // True once this point is known to be behind the open surface.
        let known_behind = match open.filter(|_| in_band) {
            Some(open) if !self.behind_open_known(open, q, &mut learnt) => {
                return (Vec::new(), DistanceBounds { winding: learnt, ..known });
            }
            Some(_) => true,
            None => false,
        };
        let bvh = &self.trees.bvh;
        // A closed surface's inside is known: outside, only faces within `reach` matter.
        let limit = match (self.closed, inside_closed) {
            (true, true) => f64::INFINITY,
            (true, false) => reach,
            (false, _) => reach.max(depth),
        };
        // Searched a little farther than needed: the distance found bounds the next rounds'.
        let search = limit + reach;
        let Some(cp) = bvh.closest_point_within(q, search) else {
            return (Vec::new(), DistanceBounds { lower: search, upper: f64::INFINITY, winding: learnt });
        };
        let lower = if self.closed && inside_closed { 0.0 } else { cp.distance };
        if cp.distance > limit {
            return (Vec::new(), DistanceBounds { lower, upper: cp.distance, winding: learnt });
        }
        let inside = match open {
            Some(open) => known_behind || self.behind_open_known(open, q, &mut learnt),
            None => inside_closed,
        };
        let bound = DistanceBounds { lower, upper: cp.distance, winding: learnt };
        let d0 = cp.distance;
        if (inside && !self.closed && d0 > depth) || (!inside && d0 > reach) {
            return (Vec::new(), bound);
        }
        let s0 = if inside { -d0 } else { d0 };
        bvh.leaves_within(q, d0 + reach - s0, leaves);
        let near = leaves
            .iter()
            .filter_map(|&leaf| {
                let corners = bvh.leaf_corners(leaf as usize)?;
                let face = bvh.faces()[leaf as usize];
                let bary = closest_point_on_triangle(q, &corners);
                let point = bary[0] * corners[0] + bary[1] * corners[1] + bary[2] * corners[2];
                // Out of the surface: along the offset from the point (continuous across faces),
                // tilted toward the face's normal within `reach·NORMAL_BLEND` of the surface,
                // where the offset's direction is round-off.
                let normal = face_normal_unnormalized(corners[0], corners[1], corners[2]).normalize_or_zero();
                let offset = if inside { point - q } else { q - point };
                let out = (offset + NORMAL_BLEND * reach * normal).normalize_or_zero();
                let distance = s0 + ((q - point).length() - d0).max(0.0);
                Some(Near { face, bary, distance, out })
            })
            .collect();
        (near, bound)
    }
}

/// What a querying vertex knows of its distance to a surface between rounds: a lower bound while
/// it is outside (0 when unknown or inside a closed surface) and an upper bound (infinite when
/// unknown), each moved after a round by how far the vertex and the surface moved; and, about an
/// open surface, what it knows of its winding number ([`WindingKnown`], carried by
/// [`RimMove::carry`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct DistanceBounds {
    lower: f64,
    upper: f64,
    winding: Option<WindingKnown>,
}

impl DistanceBounds {
    const UNKNOWN: Self = Self { lower: 0.0, upper: f64::INFINITY, winding: None };
}

/// What a pass leaves for the next pass on the same deformer (an edit of its frame, or the next
/// frame): the objects' positions at its start and the distance bounds its first round's queries
/// found, with what those bounds are distances to (each side's object connectivity and region
/// faces). The next pass starts from these bounds lowered by how far every vertex moved between
/// the two starts ([`RoundMoves`], as between rounds), so its first round queries only the
/// vertices they no longer keep out of reach: the same answers, the same bits.
#[derive(Clone, Debug)]
pub(super) struct SeparationSeed {
    /// The region pairs the pass worked on.
    active: Vec<usize>,
    /// Per active pair: its frame pair, and per side its object's connectivity and its region's
    /// faces (`None`: the whole object).
    sides: Vec<(usize, [SeedSide; 2])>,
    /// Per object: its positions at the start of the pass.
    positions: Vec<Vec<DVec3>>,
    /// Per active pair and direction: the bounds after the first round's queries.
    bounds: Vec<[Vec<DistanceBounds>; 2]>,
    /// Per object: the mean edge length of its input (for a pass on the same inputs, an edit).
    edge_lengths: Vec<f64>,
}

/// One side of an active pair in a [`SeparationSeed`]: what its surface is made of.
#[derive(Clone, Debug)]
struct SeedSide {
    object: usize,
    region: usize,
    triangles: Arc<Vec<[u32; 3]>>,
    faces: Option<Vec<u32>>,
}

impl SeedSide {
    fn of(frame: &Frame, caches: &[Option<ObjectCache>], pair: usize, regions: [usize; 2], l: usize) -> Option<Self> {
        let object = frame.pairs.get(pair)?.objects[l];
        let cache = caches.get(object)?.as_ref()?;
        let region = regions[l];
        Some(Self {
            object,
            region,
            triangles: cache.shared_triangles(),
            faces: cache.regions.get(region)?.faces.clone(),
        })
    }

    fn same(&self, other: &Self) -> bool {
        self.object == other.object
            && self.region == other.region
            && Arc::ptr_eq(&self.triangles, &other.triangles)
            && self.faces == other.faces
    }
}

impl SeparationSeed {
    /// The sides of every active pair (`None` if one has no cache or region).
    fn sides_of(
        frame: &Frame,
        caches: &[Option<ObjectCache>],
        pairs: PassPairs<'_>,
    ) -> Option<Vec<(usize, [SeedSide; 2])>> {
        pairs
            .active
            .iter()
            .map(|&k| {
                let rp = &pairs.region_pairs[k];
                let regions = rp.regions?;
                let [a, b] = [0, 1].map(|l| SeedSide::of(frame, caches, rp.pair, regions, l));
                Some((rp.pair, [a?, b?]))
            })
            .collect()
    }

    /// True if the seed was left by a pass over the same region pairs (`active`), on the same
    /// surfaces (`sides`, [`Self::sides_of`]) and object sizes.
    fn fits(&self, active: &[usize], sides: &[(usize, [SeedSide; 2])], positions: &[Vec<DVec3>]) -> bool {
        let same_sizes = self.positions.len() == positions.len()
            && self.positions.iter().zip(positions).all(|(a, b)| a.len() == b.len());
        same_sizes
            && self.active == active
            && sides.len() == self.sides.len()
            && sides.iter().zip(&self.sides).all(|((p, s), (q, t))| p == q && s[0].same(&t[0]) && s[1].same(&t[1]))
    }
}

/// The seeds of one pass: the last pass's, which it starts from when it fits, and where it
/// leaves its own.
pub(super) struct Seeds<'a> {
    /// The last pass's seed.
    pub from: Option<&'a SeparationSeed>,
    /// Where to leave this pass's seed (`None`: it leaves none).
    pub kept: Option<&'a mut Option<SeparationSeed>>,
    /// The objects' inputs are those of the last pass, bit for bit (an edit of its frame).
    pub same_inputs: bool,
}

/// Lowers every active pair's distance bounds after its objects moved (`moved`, per object; `None`:
/// it did not move): a vertex's distance to a surface shrinks at most by how far both moved (see
/// [`RoundMoves`]); the upper bounds rise by as much.
fn lower_bounds(
    frame: &Frame,
    region_pairs: &[RegionPair],
    active: &[usize],
    trees: &[Vec<Option<SideTrees>>],
    bounds: &mut [[Vec<DistanceBounds>; 2]],
    moved: &[Option<RoundMoves>],
    positions: &[Vec<DVec3>],
) {
    for (&k, pair_bounds) in active.iter().zip(bounds) {
        let objects = frame.pairs[region_pairs[k].pair].objects;
        let regions = region_pairs[k].regions;
        for (l, direction) in pair_bounds.iter_mut().enumerate() {
            let (querying, target) = (objects[l], objects[1 - l]);
            let surface = moved[target].as_ref();
            let vertex_moved = moved[querying].as_ref().map(|m| &m.by_vertex);
            let at = &positions[querying];
            // How the target side's rim moved, for what the vertices know of their winding
            // numbers about it (`None`: no rim known, nothing is carried).
            let rim = regions.and_then(|r| trees.get(target)?.get(r[1 - l])?.as_ref()?.rim.get()).map(|rim| {
                let by_vertex = surface.map(|s| s.by_vertex.as_slice());
                RimMove::new(rim, &positions[target], by_vertex, surface.map_or(0.0, |s| s.largest))
            });
            for (v, bound) in direction.iter_mut().enumerate() {
                let own = vertex_moved.map_or(0.0, |m| m[v]);
                if let Some(known) = bound.winding {
                    bound.winding = rim.and_then(|rim| rim.carry(known, bound.lower, own));
                }
                if bound.lower > 0.0 {
                    bound.lower = match surface {
                        Some(surface) => surface.lowered(bound.lower, own, at[v]),
                        None => bound.lower - own * (1.0 + BOUND_SLACK),
                    };
                }
                bound.upper += (surface.map_or(0.0, |s| s.largest) + own) * (1.0 + BOUND_SLACK);
            }
        }
    }
}

/// The moves asked of one vertex, blended by [`Blend::result`].
#[derive(Clone, Copy, Debug, Default)]
struct Blend {
    weight: f64,
    sum: DVec3,
}

impl Blend {
    /// Adds a move, weighted by its length to the power [`BLEND_POWER`].
    fn add(&mut self, candidate: DVec3) {
        let w = candidate.length_squared().powi(BLEND_POWER / 2);
        if w > 0.0 && w.is_finite() {
            self.weight += w;
            self.sum += w * candidate;
        }
    }

    /// The weighted mean of the moves (zero without any): close to the longest when one
    /// dominates, and a continuous function of them all (a plain maximum would switch direction
    /// when two moves of different directions cross in length).
    fn result(&self) -> DVec3 {
        if self.weight > 0.0 { self.sum / self.weight } else { DVec3::ZERO }
    }
}

/// Power of a move's length in its blending weight ([`Blend`]).
const BLEND_POWER: i32 = 4;

/// Runs the pass on the outcomes of chapter 5 (see the module doc); returns, per region pair
/// (order of `region_pairs`), what it did, and the warnings for the pairs left intersecting. Its
/// work ([`Work`]: its rounds, distance queries and exact tests) is recorded in the caller's span.
/// The side trees of the regions in `caches` are taken for the pass and put back after it (see
/// [`SideTrees`]).
pub(super) fn separate(
    frame: &Frame,
    caches: &mut [Option<ObjectCache>],
    region_pairs: &[RegionPair],
    contacts: &[Option<PairContact>],
    outcomes: &mut [Vec<Option<RegionOutcome>>],
    seeds: Seeds<'_>,
) -> Result<(Vec<PairSeparation>, Vec<FrameWarning>), PipelineError> {
    // The region pairs the pass works on: a gap, two regions, and a side it may move.
    let active: Vec<usize> = (0..region_pairs.len())
        .filter(|&k| {
            if !contacts[k].as_ref().is_some_and(|c| c.gap > 0.0) {
                return false;
            }
            let Some(regions) = region_pairs[k].regions else { return false };
            let objects = frame.pairs[region_pairs[k].pair].objects;
            (0..2).any(|l| outcomes[objects[l]].get(regions[l]).is_some_and(Option::is_some))
        })
        .collect();
    if active.is_empty() {
        return Ok((vec![PairSeparation::default(); region_pairs.len()], Vec::new()));
    }
    // The trees kept by the regions' caches (None where a side has none yet).
    let mut trees: Vec<Vec<Option<SideTrees>>> = caches
        .iter_mut()
        .map(|c| {
            c.as_mut()
                .map_or(Vec::new(), |c| c.regions.iter_mut().map(|r| r.separation_trees.take().map(|t| *t)).collect())
        })
        .collect();
    let mut wholes: Vec<Option<TriangleBvh>> =
        caches.iter_mut().map(|c| c.as_mut().and_then(|c| c.separation_whole.take()).map(|t| *t)).collect();
    let pairs = PassPairs { region_pairs, contacts, active: &active };
    let result =
        separate_with(frame, caches, pairs, outcomes, PassTrees { sides: &mut trees, wholes: &mut wholes }, seeds);
    for ((cache, trees), whole) in caches.iter_mut().zip(trees).zip(wholes) {
        if let Some(cache) = cache.as_mut() {
            for (region, side) in cache.regions.iter_mut().zip(trees) {
                region.separation_trees = side.map(Box::new);
            }
            cache.separation_whole = whole.map(Box::new);
        }
    }
    result
}

/// The region pairs of one pass: all of the frame's, their contacts, and those it works on.
#[derive(Clone, Copy)]
struct PassPairs<'a> {
    region_pairs: &'a [RegionPair],
    contacts: &'a [Option<PairContact>],
    active: &'a [usize],
}

/// The trees of one pass: every region's (`sides[object][region]`) and every object's whole tree
/// (`wholes[object]`), built where missing.
struct PassTrees<'a> {
    sides: &'a mut [Vec<Option<SideTrees>>],
    wholes: &'a mut [Option<TriangleBvh>],
}

/// [`separate`] with the trees of every region and object (built where missing).
fn separate_with(
    frame: &Frame,
    caches: &[Option<ObjectCache>],
    pairs: PassPairs<'_>,
    outcomes: &mut [Vec<Option<RegionOutcome>>],
    pass_trees: PassTrees<'_>,
    mut seeds: Seeds<'_>,
) -> Result<(Vec<PairSeparation>, Vec<FrameWarning>), PipelineError> {
    let PassPairs { region_pairs, contacts, active } = pairs;
    let PassTrees { sides: trees, wholes } = pass_trees;
    let mut report = vec![PairSeparation::default(); region_pairs.len()];
    let count = frame.objects.len();
    let slots: Vec<Vec<Option<(u32, u32)>>> = (0..count)
        .map(|i| match caches[i].as_ref() {
            Some(cache) => movable_vertices(frame.objects[i].mesh.num_vertices(), cache, &outcomes[i]),
            None => Vec::new(),
        })
        .collect();
    let edge_lengths: Vec<f64> = match seeds.from.filter(|s| seeds.same_inputs && s.edge_lengths.len() == count) {
        Some(seed) => seed.edge_lengths.clone(),
        None => (0..count)
            .map(|i| caches[i].as_ref().map_or(0.0, |c| mean_edge_length(c, &frame.objects[i].mesh.positions)))
            .collect(),
    };
    // The whole correction so far, per object vertex.
    let mut corrections: Vec<Vec<DVec3>> =
        (0..count).map(|i| vec![DVec3::ZERO; frame.objects[i].mesh.num_vertices()]).collect();
    let positions_at = |i: usize, outcomes: &[Vec<Option<RegionOutcome>>]| -> Vec<DVec3> {
        let object = frame.objects[i].mesh;
        match caches[i].as_ref() {
            Some(cache) => object_positions(&object.positions, cache, &outcomes[i]),
            None => object.positions.clone(),
        }
    };
    let mut positions: Vec<Vec<DVec3>> = (0..count).map(|i| positions_at(i, outcomes)).collect();
    // A side whose inside is its closed object's (paired with another object, see `surface`)
    // needs the whole object's tree; one paired with its own object only does not, and is not
    // given one to refit at every round.
    let mut closed_inside: Vec<Vec<bool>> = trees.iter().map(|t| vec![false; t.len()]).collect();
    for &k in active {
        let Some(regions) = region_pairs[k].regions else { continue };
        let objects = frame.pairs[region_pairs[k].pair].objects;
        for l in 0..2 {
            if objects[0] != objects[1]
                && let Some(flag) = closed_inside[objects[l]].get_mut(regions[l])
            {
                *flag = true;
            }
        }
    }
    // The trees of every side of an active pair: the region's kept trees or new ones, refitted
    // to this frame's outputs and after each round; and the whole object's tree of an object
    // with a cut region whose inside is the object's (a whole region's own tree is the whole
    // object's), kept by the object whatever its regions do.
    let mut fitted: Vec<Vec<bool>> = trees.iter().map(|t| vec![false; t.len()]).collect();
    let mut needs_whole = vec![false; count];
    for &k in active {
        let Some(regions) = region_pairs[k].regions else { continue };
        let objects = frame.pairs[region_pairs[k].pair].objects;
        for l in 0..2 {
            let (i, r) = (objects[l], regions[l]);
            let (Some(cache), Some(false)) = (caches[i].as_ref(), fitted[i].get(r).copied()) else { continue };
            fitted[i][r] = true;
            let cut = cache.regions.get(r).is_some_and(|region| region.faces.is_some());
            needs_whole[i] |= cache.closed && closed_inside[i][r] && cut;
            let side = &mut trees[i][r];
            let refitted = side.as_mut().is_some_and(|t| t.bvh.refit(&positions[i]).is_ok());
            if !refitted {
                *side = SideTrees::new(cache, r, &positions[i], frame.objects[i].mesh);
            }
        }
    }
    for (i, whole) in wholes.iter_mut().enumerate() {
        let Some(cache) = caches[i].as_ref().filter(|_| needs_whole[i]) else {
            *whole = None;
            continue;
        };
        if whole.as_mut().is_none_or(|t| t.refit(&positions[i]).is_err()) {
            let mut tree = TriangleBvh::clone(&cache.bvh);
            *whole = tree.refit(&positions[i]).is_ok().then_some(tree);
        }
    }
    // Per active region pair and direction l (side l's vertices against side 1 − l): bounds of
    // each querying vertex's distance to the surface it queries (see `query_direction`).
    let mut bounds: Vec<[Vec<DistanceBounds>; 2]> = active
        .iter()
        .map(|&k| {
            let objects = frame.pairs[region_pairs[k].pair].objects;
            objects.map(|i| vec![DistanceBounds::UNKNOWN; frame.objects[i].mesh.num_vertices()])
        })
        .collect();
    // The last pass's first-round bounds, lowered by how far every vertex moved between the two
    // passes' starts.
    // What this pass's bounds are distances to, found once for the seed it starts from and the
    // one it leaves.
    let mut sides = (seeds.from.is_some() || seeds.kept.is_some())
        .then(|| SeparationSeed::sides_of(frame, caches, pairs))
        .flatten();
    if let (Some(seed), Some(sides)) = (seeds.from, sides.as_ref())
        && seed.fits(active, sides, &positions)
    {
        let moved: Vec<Option<RoundMoves>> = (0..count)
            .map(|i| caches[i].as_ref().map(|c| RoundMoves::new(&c.topology, &seed.positions[i], &positions[i])))
            .collect();
        bounds.clone_from(&seed.bounds);
        lower_bounds(frame, region_pairs, active, trees, &mut bounds, &moved, &positions);
    }
    let mut start_positions = seeds.kept.is_some().then(|| positions.clone());
    // Per object and region: the volume terms of its last correction, at first chapter 5's.
    let mut volume_terms: Vec<Vec<SweptTerms>> = outcomes
        .iter_mut()
        .map(|o| {
            o.iter_mut().map(|o| o.as_mut().map(|o| std::mem::take(&mut o.volume_terms)).unwrap_or_default()).collect()
        })
        .collect();
    // The sides some active pair sees as open (their inside is the generalized winding number).
    let mut open_sides: Vec<(usize, usize)> = Vec::new();
    for &k in active {
        let Some(regions) = region_pairs[k].regions else { continue };
        let objects = frame.pairs[region_pairs[k].pair].objects;
        for l in 0..2 {
            let closed = caches[objects[l]].as_ref().is_some_and(|c| c.closed) && objects[0] != objects[1];
            if !closed && !open_sides.contains(&(objects[l], regions[l])) {
                open_sides.push((objects[l], regions[l]));
            }
        }
    }
    // Per object: the moves asked of its vertices in a round, and the spread's buffers.
    let mut asks: Vec<Blends> = slots.iter().map(|s| Blends::new(s.len())).collect();
    let mut spreads: Vec<Blends> = slots.iter().map(|s| Blends::new(s.len())).collect();
    let mut rounds = 0;
    while rounds < MAX_ROUNDS {
        let mut opens = Vec::new();
        for &(i, r) in &open_sides {
            if let Some(side) = trees[i].get_mut(r).and_then(Option::as_mut) {
                let rim = side.rim.get_or_init(|| rim_of(&frame.objects[i].mesh.triangles, side.bvh.faces()));
                opens.push(OpenSide {
                    side: (i, r),
                    rim: RimTree::new(rim, &positions[i]),
                    buffers: Mutex::new(Some(std::mem::take(&mut side.clusters))),
                    clusters: OnceLock::new(),
                });
            }
        }
        let mut largest = 0.0f64;
        let mut stop_below = f64::INFINITY;
        for (a, &k) in active.iter().enumerate() {
            let rp = &region_pairs[k];
            let Some(contact) = contacts[k].as_ref() else { continue };
            let Some(regions) = rp.regions else { continue };
            let objects = frame.pairs[rp.pair].objects;
            let gap = contact.gap;
            stop_below = stop_below.min(STOP_FRACTION * gap);
            let surfaces = [0, 1].map(|l| {
                surface(
                    frame,
                    caches,
                    Surfaces { trees, wholes, opens: &opens },
                    &positions,
                    objects[l],
                    regions[l],
                    objects,
                )
            });
            let [Some(sa), Some(sb)] = surfaces else { continue };
            let surfaces = [sa, sb];
            let movable = |l: usize| outcomes[objects[l]].get(regions[l]).is_some_and(Option::is_some);
            // A side moves the share of δ its partner's relative stiffness gives it (§4.3).
            let k_bar = [contact.sides[0].relative_stiffness, contact.sides[1].relative_stiffness];
            let weights = [0, 1].map(|l| if movable(l) { k_bar[1 - l].max(0.0) } else { 0.0 });
            let total = weights[0] + weights[1];
            if total <= 0.0 {
                continue;
            }
            let shares = weights.map(|w| w / total);
            let depth = DEPTH_EDGES * edge_lengths[objects[0]].max(edge_lengths[objects[1]]);
            let reach = Reach { gap, depth };
            // Direction l: side l's vertices against side 1 − l. It gives side l's own moves
            // (its movable vertices) and side 1 − l's moves from the vertices poking into it, so
            // each direction is asked once for both; it asks only the movable vertices when it
            // is needed for the own moves alone.
            let pair_bounds = &mut bounds[a];
            let answers: [Vec<(u32, Vec<Near>)>; 2] = std::array::from_fn(|l| {
                let (own_moves, poking) = (shares[l] > 0.0, shares[1 - l] > 0.0);
                if !own_moves && !poking {
                    return Vec::new();
                }
                let object = objects[l];
                let filter = |v: u32| poking || slots[object][v as usize].is_some();
                query_direction(&surfaces[l], filter, &surfaces[1 - l], reach, &mut pair_bounds[l])
            });
            for l in 0..2 {
                if shares[l] == 0.0 {
                    continue;
                }
                let own = &surfaces[l];
                let object = objects[l];
                let share = shares[l];
                // Own vertices near or inside the other side.
                for (v, near) in &answers[l] {
                    if slots[object][*v as usize].is_none() {
                        continue;
                    }
                    for n in near.iter().filter(|n| n.distance < gap) {
                        asks[object].add(*v, share * (gap - n.distance) * n.out);
                    }
                }
                // The other side's vertices near or inside this side move this side's faces.
                for (_, near) in &answers[1 - l] {
                    for n in near.iter().filter(|n| n.distance < gap) {
                        let (corners, bary) = (own.triangles[n.face as usize], n.bary);
                        let m = -share * (gap - n.distance) * n.out;
                        let norm: f64 = bary.iter().map(|b| b * b).sum();
                        if norm <= 0.0 {
                            continue;
                        }
                        for (&c, &b) in corners.iter().zip(&bary) {
                            if b > 0.0 && slots[object][c as usize].is_some() {
                                asks[object].add(c, (b / norm) * m);
                            }
                        }
                    }
                }
            }
        }
        for open in opens {
            let (i, r) = open.side;
            let clusters = open.into_clusters();
            if let Some(side) = trees[i].get_mut(r).and_then(Option::as_mut) {
                side.clusters = clusters;
            }
        }
        if rounds == 0
            && let (Some(kept), Some(positions), Some(sides)) =
                (seeds.kept.as_deref_mut(), start_positions.take(), sides.take())
        {
            *kept = Some(SeparationSeed {
                active: active.to_vec(),
                sides,
                positions,
                bounds: bounds.clone(),
                edge_lengths: edge_lengths.clone(),
            });
        }
        let moves: Vec<Vec<(u32, DVec3)>> = asks.iter_mut().map(Blends::take).collect();
        for (_, m) in moves.iter().flatten() {
            largest = largest.max(m.length());
        }
        if largest <= stop_below || largest == 0.0 {
            break;
        }
        rounds += 1;
        Work::count_rounds(1);
        // Each object's correction and height solves, and how far its vertices moved this round
        // (for the distance bounds): objects are independent, so in parallel.
        let work = SharedWork::default();
        let moved: Vec<Option<RoundMoves>> = (0..count)
            .into_par_iter()
            .zip(outcomes.par_iter_mut())
            .zip(corrections.par_iter_mut())
            .zip(volume_terms.par_iter_mut())
            .zip(positions.par_iter_mut())
            .zip(trees.par_iter_mut())
            .zip(wholes.par_iter_mut())
            .zip(spreads.par_iter_mut())
            .map(|(((((((i, outcomes), correction), terms), positions), trees), whole), spread)| {
                work.measure(|| {
                    if moves[i].iter().all(|(_, m)| *m == DVec3::ZERO) {
                        return Ok(None);
                    }
                    let Some(cache) = caches[i].as_ref() else { return Ok(None) };
                    let radius = SPREAD_EDGES * edge_lengths[i];
                    for (v, s) in spread_moves(cache, positions, &moves[i], &slots[i], radius, spread) {
                        correction[v as usize] += s;
                    }
                    correct_regions(frame, i, cache, correction, outcomes, terms)?;
                    let new_positions = object_positions(&frame.objects[i].mesh.positions, cache, outcomes);
                    let round_moves = RoundMoves::new(&cache.topology, positions, &new_positions);
                    *positions = new_positions;
                    for tree in trees.iter_mut().flatten().map(|side| &mut side.bvh).chain(whole.as_mut()) {
                        tree.refit(positions).map_err(|source| PipelineError::Spatial {
                            object: frame.objects[i].name.to_string(),
                            source,
                        })?;
                    }
                    Ok(Some(round_moves))
                })
            })
            .collect::<Result<_, PipelineError>>()?;
        work.record();
        lower_bounds(frame, region_pairs, active, trees, &mut bounds, &moved, &positions);
    }
    let mut warnings = Vec::new();
    for &k in active {
        let rp = &region_pairs[k];
        let Some(regions) = rp.regions else { continue };
        let objects = frame.pairs[rp.pair].objects;
        let surfaces = [0, 1].map(|l| {
            surface(frame, caches, Surfaces { trees, wholes, opens: &[] }, &positions, objects[l], regions[l], objects)
        });
        let [Some(sa), Some(sb)] = surfaces else { continue };
        let pairs = sa.trees.bvh.intersections_with(&sb.trees.bvh);
        let distinct = |side: usize| {
            let mut faces: Vec<u32> = pairs.iter().map(|p| p[side]).collect();
            faces.sort_unstable();
            faces.dedup();
            faces.len()
        };
        let remaining = distinct(0) + distinct(1);
        report[k] = PairSeparation { rounds, remaining_faces: remaining };
        if remaining > 0 {
            let names = objects.map(|i| frame.objects[i].name);
            warnings.push(FrameWarning {
                kind: WarningKind::Unseparated,
                pair: Some(k),
                object: None,
                message: format!(
                    "pair (\"{}\", \"{}\"): {remaining} faces still intersect the other object after {rounds} rounds of \
                     the separation pass; a larger pair.contact_gap, a smaller pair.contact_tau or a finer mesh on the \
                     deformed side separate more",
                    names[0], names[1]
                ),
            });
        }
    }
    Ok((report, warnings))
}

/// The surface of region `region` of `object` in the pair of `objects`, at `positions`. Its inside
/// is its closed object's unless the pair is of one object's regions (every point of one region
/// is on or in the object: its inside is then the region's own).
fn surface<'a>(
    frame: &'a Frame,
    caches: &'a [Option<ObjectCache>],
    Surfaces { trees, wholes, opens }: Surfaces<'a>,
    positions: &'a [Vec<DVec3>],
    object: usize,
    region: usize,
    objects: [usize; 2],
) -> Option<Surface<'a>> {
    let cache = caches[object].as_ref()?;
    let cut = cache.regions.get(region).is_some_and(|r| r.faces.is_some());
    let closed = cache.closed && objects[0] != objects[1];
    let open = opens.iter().find(|o| o.side == (object, region)).filter(|_| !closed);
    Some(Surface {
        trees: trees.get(object)?.get(region)?.as_ref()?,
        whole: wholes.get(object).and_then(Option::as_ref).filter(|_| cut),
        positions: &positions[object],
        triangles: &frame.objects[object].mesh.triangles,
        topology: &cache.topology,
        closed,
        open,
    })
}

/// What the sides' surfaces are made of in one round: the sides' trees, the whole objects' trees
/// and the open sides' insides.
#[derive(Clone, Copy)]
struct Surfaces<'a> {
    trees: &'a [Vec<Option<SideTrees>>],
    wholes: &'a [Option<TriangleBvh>],
    opens: &'a [OpenSide],
}

/// The inside of an open side (object, region) in one round: its rim at the round's positions,
/// and its far-field clusters, refreshed the first time a point's side must be evaluated (most
/// rounds settle every point from what it knows, [`super::rim`]).
struct OpenSide {
    side: (usize, usize),
    rim: RimTree,
    /// The side's cluster buffers, taken for the round and given back by [`Self::into_clusters`].
    buffers: Mutex<Option<WindingClusters>>,
    clusters: OnceLock<WindingClusters>,
}

impl OpenSide {
    /// The side's fast winding numbers, `tree` being the side's tree at the round's positions.
    fn winding<'a>(&'a self, tree: &'a TriangleBvh) -> FastWinding<'a> {
        let clusters = self.clusters.get_or_init(|| {
            let mut clusters = self.buffers.lock().ok().and_then(|mut b| b.take()).unwrap_or_default();
            clusters.refresh(tree);
            clusters
        });
        FastWinding::with_clusters(tree, clusters, WINDING_ACCURACY)
    }

    /// The cluster buffers, for the next round.
    fn into_clusters(self) -> WindingClusters {
        match self.clusters.into_inner() {
            Some(clusters) => clusters,
            None => self.buffers.into_inner().ok().flatten().unwrap_or_default(),
        }
    }
}

/// The distances of one region pair: its gap (the reach of the moves outside a surface) and the
/// depth beyond which a point behind an open surface is left alone.
#[derive(Clone, Copy, Debug)]
struct Reach {
    gap: f64,
    depth: f64,
}

/// Relative slack of the distance bounds (far above the round-off of a distance).
const BOUND_SLACK: f64 = 1e-9;

/// The fraction of a round's largest move below which an object's faces count as slow
/// ([`RoundMoves`]).
const SLOW_FRACTION: f64 = 0.25;

/// How far an object's vertices moved in one round, in the form the distance bounds use.
///
/// A face all of whose corners moved at most `slow_limit` moved at most that far everywhere (its
/// points are convex combinations of its corners), so a point's distance to such faces shrank at
/// most by `slow_limit`. Every other face has a corner that moved farther, and its three corners
/// are that vertex and two of its neighbours: it lies in `fast_box`, the box of the new positions
/// of the fast vertices and their neighbours. A point's distance to the moved surface is
/// therefore at least the smaller of its old distance less `slow_limit` and its distance to
/// `fast_box`; and at least its old distance less the largest move. The larger of the two
/// bounds is kept: far tighter where the largest moves are near the contact and the point is
/// not.
struct RoundMoves {
    /// Per vertex: the length of its move.
    by_vertex: Vec<f64>,
    /// The largest move.
    largest: f64,
    /// [`SLOW_FRACTION`] of the largest move.
    slow_limit: f64,
    /// The box of the new positions of every vertex moved farther than `slow_limit` and of
    /// their neighbours (empty if none).
    fast_box: Aabb3,
}

impl RoundMoves {
    fn new(topology: &Topology, before: &[DVec3], after: &[DVec3]) -> Self {
        let by_vertex: Vec<f64> = after.iter().zip(before).map(|(a, b)| (*a - *b).length()).collect();
        let largest = by_vertex.iter().copied().fold(0.0, f64::max);
        let slow_limit = SLOW_FRACTION * largest;
        let mut fast_box = Aabb3::EMPTY;
        for (v, _) in by_vertex.iter().enumerate().filter(|(_, m)| **m > slow_limit) {
            fast_box.grow(after[v]);
            for w in topology.vertex_neighbors(v as u32) {
                fast_box.grow(after[w as usize]);
            }
        }
        Self { by_vertex, largest, slow_limit, fast_box }
    }

    /// A lower bound of the distance from a point now at `at`, which moved by `own` this round,
    /// to this object's surface, `previous` bounding it before the round (see the type's doc).
    fn lowered(&self, previous: f64, own: f64, at: DVec3) -> f64 {
        let whole = previous - (self.largest + own) * (1.0 + BOUND_SLACK);
        let slow = previous - (self.slow_limit + own) * (1.0 + BOUND_SLACK);
        let fast = self.fast_box.distance_to(at) * (1.0 - BOUND_SLACK);
        whole.max(slow.min(fast))
    }
}

/// The queries of one direction: every vertex of `querying` that `filter` accepts and that may be
/// within reach of `target` (sorted), with its points of `target` to clear ([`Surface::near`]).
///
/// A vertex farther than the reach of every move from `target` asks nothing, and stays so while
/// it and the surface move less than the margin: `bounds` (per vertex of the querying object)
/// keeps a lower bound of each vertex's distance to `target` while outside it (0 when unknown or
/// inside), lowered by the caller after each round by how far the vertex and the surface moved
/// ([`RoundMoves::lowered`]: the surface's slow faces by their largest move, its fast ones by their box),
/// so the later rounds query only the vertices it no longer keeps out of reach. Skipped vertices
/// are exactly those whose answer is empty (a bound above the reach, a surface that did not pass
/// through them), so the result is the one of querying all of them. An open surface's depth band
/// keeps its vertices asking; one whose bounds put it beyond the gap and within the depth
/// (`bounds` keeps an upper bound too, raised after each round by how far both moved) asks its
/// side first ([`Surface::near`]): in front, its answer is empty without its closest point.
fn query_direction(
    querying: &Surface,
    filter: impl Fn(u32) -> bool,
    target: &Surface,
    reach: Reach,
    bounds: &mut [DistanceBounds],
) -> Vec<(u32, Vec<Near>)> {
    // Outside a closed surface only its faces within the gap matter; an open one's inside is
    // decided by the winding number up to `depth` behind it.
    let margin = if target.closed { reach.gap } else { reach.gap.max(reach.depth) };
    let limit = margin * (1.0 + BOUND_SLACK);
    let b = target.trees.bvh.bounds();
    let within = Aabb3 { min: b.min - DVec3::splat(margin), max: b.max + DVec3::splat(margin) };
    let candidates: Vec<u32> = querying
        .trees
        .vertices
        .iter()
        .copied()
        .filter(|&v| {
            bounds[v as usize].lower <= limit && filter(v) && inside_box(&within, querying.positions[v as usize])
        })
        .collect();
    let outside: Vec<bool> = candidates.iter().map(|&v| bounds[v as usize].lower > 0.0).collect();
    let inside = target.inside_flags(querying.positions, querying.topology, &candidates, &outside);
    let work = SharedWork::default();
    let answers: Vec<(Vec<Near>, DistanceBounds)> = candidates
        .par_iter()
        .zip(&inside)
        .with_min_len(256)
        .map_init(Vec::new, |leaves, (&v, &inside)| {
            let q = querying.positions[v as usize];
            let known = bounds[v as usize];
            work.measure(|| target.near(q, inside, known, reach, leaves))
        })
        .collect();
    work.record();
    candidates
        .into_iter()
        .zip(answers)
        .filter_map(|(v, (near, bound))| {
            bounds[v as usize] = bound;
            (!near.is_empty()).then_some((v, near))
        })
        .collect()
}

fn inside_box(b: &Aabb3, p: DVec3) -> bool {
    p.cmpge(b.min).all() && p.cmple(b.max).all()
}

/// Each non-zero move of `moves` (sorted by vertex) spread over the movable vertices within
/// `radius` (edge paths, Euclidean distance at `positions`) with the weight `(1 − (r/R)²)²`,
/// blended per vertex with its own ([`Blend`]); the vertices reached, in increasing order.
/// `spread`: buffers kept between rounds.
fn spread_moves(
    cache: &ObjectCache,
    positions: &[DVec3],
    moves: &[(u32, DVec3)],
    slots: &[Option<(u32, u32)>],
    radius: f64,
    spread: &mut Blends,
) -> Vec<(u32, DVec3)> {
    if radius <= 0.0 {
        return moves.to_vec();
    }
    let mut stack = Vec::new();
    for &(source, m) in moves {
        if m == DVec3::ZERO {
            continue;
        }
        spread.add(source, m);
        let origin = positions[source as usize];
        let stamp = spread.next_stamp();
        stack.clear();
        stack.push(source);
        spread.seen[source as usize] = stamp;
        while let Some(v) = stack.pop() {
            for w in cache.topology.vertex_neighbors(v) {
                if spread.seen[w as usize] == stamp || slots[w as usize].is_none() {
                    continue;
                }
                spread.seen[w as usize] = stamp;
                let r = (positions[w as usize] - origin).length() / radius;
                if r >= 1.0 {
                    continue;
                }
                spread.add(w, (1.0 - r * r).powi(2) * m);
                stack.push(w);
            }
        }
    }
    spread.take()
}

/// The moves asked of every vertex of one object ([`Blend`] per vertex), with the vertices asked
/// so far: a round's work grows with the vertices asked, not with the object. `seen`: per vertex,
/// the last spread source that reached it ([`spread_moves`]).
struct Blends {
    blends: Vec<Blend>,
    touched: Vec<u32>,
    seen: Vec<u32>,
    stamp: u32,
}

impl Blends {
    fn new(vertices: usize) -> Self {
        Self { blends: vec![Blend::default(); vertices], touched: Vec::new(), seen: Vec::new(), stamp: 0 }
    }

    /// Asks vertex `v` for the move `m`.
    fn add(&mut self, v: u32, m: DVec3) {
        let blend = &mut self.blends[v as usize];
        let first = blend.weight <= 0.0;
        blend.add(m);
        if first && blend.weight > 0.0 {
            self.touched.push(v);
        }
    }

    /// The blended move of every vertex asked (sorted by vertex; the others' are zero), the
    /// asks cleared.
    fn take(&mut self) -> Vec<(u32, DVec3)> {
        self.touched.sort_unstable();
        let moves = self.touched.iter().map(|&v| (v, self.blends[v as usize].result())).collect();
        for &v in &self.touched {
            self.blends[v as usize] = Blend::default();
        }
        self.touched.clear();
        moves
    }

    /// A new mark for [`Self::seen`] (the marks restart, cleared, when they run out).
    fn next_stamp(&mut self) -> u32 {
        if self.seen.len() != self.blends.len() || self.stamp == u32::MAX {
            self.seen.clear();
            self.seen.resize(self.blends.len(), 0);
            self.stamp = 0;
        }
        self.stamp += 1;
        self.stamp
    }
}

/// Applies object `i`'s whole correction to its deformed regions, each solving its bulge height
/// again for its volume (`terms`: per region, its volume terms of the last round).
fn correct_regions(
    frame: &Frame,
    i: usize,
    cache: &ObjectCache,
    correction: &[DVec3],
    outcomes: &mut [Option<RegionOutcome>],
    terms: &mut [SweptTerms],
) -> Result<(), PipelineError> {
    let object = &frame.objects[i];
    let err = |source| PipelineError::Deform { object: object.name.to_string(), source };
    for ((region, outcome), terms) in cache.regions.iter().zip(outcomes.iter_mut()).zip(terms) {
        let Some(outcome) = outcome.as_mut() else { continue };
        let (mesh, topology, local) = match region.sub.as_deref() {
            None => (object.mesh, &*cache.topology, correction.to_vec()),
            Some(sub) => {
                let mut local = sub.sub.gather(correction);
                for (c, &border) in local.iter_mut().zip(&sub.border) {
                    if border {
                        *c = DVec3::ZERO;
                    }
                }
                (&sub.sub.mesh, &sub.topology, local)
            }
        };
        if local.iter().all(|c| *c == DVec3::ZERO) {
            continue;
        }
        let choice = HeightChoice {
            preserve_volume: object.params.preserve_volume.unwrap_or(true),
            bulge: object.params.bulge,
            extent: outcome.extent,
        };
        outcome.deformation.correct(mesh, topology, &local, choice, terms).map_err(err)?;
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::Lcg;
    use crate::mesh::shapes;

    fn distance_to_mesh(mesh: &TriMesh, positions: &[DVec3], q: DVec3) -> f64 {
        mesh.triangles
            .iter()
            .map(|t| {
                let corners = t.map(|v| positions[v as usize]);
                let b = closest_point_on_triangle(q, &corners);
                (b[0] * corners[0] + b[1] * corners[1] + b[2] * corners[2]).distance(q)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// A point of an open surface's depth band known to be farther than the gap asks the
    /// surface's side first and its closest point only when behind it: the answer is the same,
    /// bit for bit, in front of the surface (empty), behind it within the depth band, and beyond
    /// it, and the bounds returned hold the distance. A bowl (a bumped grid), points all around
    /// it, lower bounds anywhere between the gap and the distance, upper ones up to 0.2 above it.
    #[test]
    fn a_point_known_beyond_the_gap_of_an_open_surface_gets_the_same_answer() {
        let mut mesh = shapes::grid(2.0, 2.0, 16, 16);
        for p in &mut mesh.positions {
            p.z = 0.4 * (p.x * p.x + p.y * p.y);
        }
        let topology = Topology::new(&mesh);
        let bvh = TriangleBvh::new(&mesh).unwrap();
        let trees = SideTrees {
            bvh,
            vertices: (0..mesh.num_vertices() as u32).collect(),
            clusters: WindingClusters::default(),
            rim: Default::default(),
        };
        let all: Vec<u32> = (0..mesh.num_triangles() as u32).collect();
        let open = OpenSide {
            side: (0, 0),
            rim: RimTree::new(&rim_of(&mesh.triangles, &all), &mesh.positions),
            buffers: Mutex::new(None),
            clusters: OnceLock::new(),
        };
        let surface = Surface {
            trees: &trees,
            whole: None,
            positions: &mesh.positions,
            triangles: &mesh.triangles,
            topology: &topology,
            closed: false,
            open: Some(&open),
        };
        let winding = open.winding(&trees.bvh);
        let reach = Reach { gap: 0.05, depth: 0.3 };
        let key = |near: &[Near]| -> Vec<(u32, [u64; 3], u64, [u64; 3])> {
            near.iter()
                .map(|n| (n.face, n.bary.map(f64::to_bits), n.distance.to_bits(), n.out.to_array().map(f64::to_bits)))
                .collect()
        };
        let mut rng = Lcg::new(37);
        let (mut leaves, mut behind, mut skipped) = (Vec::new(), 0, 0);
        for _ in 0..2000 {
            let q = DVec3::new(1.2 * rng.next_signed(), 1.2 * rng.next_signed(), 0.4 + 0.8 * rng.next_signed());
            let distance = distance_to_mesh(&mesh, &mesh.positions, q);
            let least = reach.gap * (1.0 + 1e-6);
            if distance <= least {
                continue;
            }
            let lower = least + (distance - least) * 0.5 * (rng.next_signed() + 1.0);
            let upper = distance + 0.1 * (rng.next_signed() + 1.0);
            let bounds = DistanceBounds { lower, upper, winding: None };
            let unknown = DistanceBounds::UNKNOWN;
            let (asked, learnt) = surface.near(q, false, unknown, reach, &mut leaves);
            let (known, kept) = surface.near(q, false, bounds, reach, &mut leaves);
            assert_eq!(key(&asked), key(&known), "at {q}, {distance} from the bowl");
            // What the first query learnt of the side settles it, with the same answer.
            let (settled, _) =
                surface.near(q, false, DistanceBounds { winding: learnt.winding, ..bounds }, reach, &mut leaves);
            assert_eq!(key(&asked), key(&settled), "at {q}, from what was learnt");
            assert!(kept.lower <= distance * (1.0 + 1e-12) && kept.upper >= distance * (1.0 - 1e-12));
            if surface.winding_side(&winding, q).0 {
                behind += usize::from(!asked.is_empty());
            } else {
                skipped += usize::from(upper < reach.depth);
            }
        }
        assert!(behind > 50 && skipped > 100, "{behind} answered behind, {skipped} in front within the band");
    }

    /// The spread of a round's moves does not depend on what the buffers kept from the rounds
    /// before: the same moves spread with used buffers and with new ones give the same bits, and
    /// a vertex reaches only movable vertices within the radius.
    #[test]
    fn a_spread_with_kept_buffers_is_a_spread_with_new_ones() {
        let mesh = shapes::icosphere(1.0, 3);
        let cache = ObjectCache::new("ball", &mesh).unwrap();
        let n = mesh.num_vertices();
        let slots: Vec<Option<(u32, u32)>> =
            (0..n).map(|v| (mesh.positions[v].z > -0.2).then_some((0, v as u32))).collect();
        let mut rng = Lcg::new(41);
        let mut kept = Blends::new(n);
        for round in 0..6 {
            let mut asks = Blends::new(n);
            for _ in 0..(5 + 7 * round) {
                let v = (rng.next_signed().abs() * n as f64) as u32 % n as u32;
                asks.add(v, 0.01 * DVec3::new(rng.next_signed(), rng.next_signed(), rng.next_signed()));
            }
            let moves = asks.take();
            let radius = 0.3;
            let with_kept = spread_moves(&cache, &mesh.positions, &moves, &slots, radius, &mut kept);
            let fresh = spread_moves(&cache, &mesh.positions, &moves, &slots, radius, &mut Blends::new(n));
            let bits =
                |m: &[(u32, DVec3)]| m.iter().map(|(v, d)| (*v, d.to_array().map(f64::to_bits))).collect::<Vec<_>>();
            assert_eq!(bits(&with_kept), bits(&fresh), "round {round}");
            assert!(with_kept.windows(2).all(|w| w[0].0 < w[1].0));
            for (v, _) in &with_kept {
                let near = moves
                    .iter()
                    .any(|(s, _)| (mesh.positions[*s as usize] - mesh.positions[*v as usize]).length() < radius);
                assert!(near && (slots[*v as usize].is_some() || moves.iter().any(|(s, _)| s == v)));
            }
        }
    }

    /// The distance bounds after a round never exceed the true distance, whatever the moves:
    /// a ball whose cap moves far (the contact) and whose rest moves a little (the bulge), and
    /// query points that moved too. Away from the cap they stay well above the old bound (the
    /// whole surface's largest move taken off), which is what saves the queries.
    #[test]
    fn the_bounds_after_a_round_never_exceed_the_distance_and_stay_high_away_from_the_contact() {
        let mesh = shapes::icosphere(1.0, 3);
        let topology = Topology::new(&mesh);
        let mut rng = Lcg::new(29);
        let random_unit = |rng: &mut Lcg| DVec3::new(rng.next_signed(), rng.next_signed(), rng.next_signed());
        let (mut tighter, mut far) = (0, 0);
        for trial in 0..20 {
            let cap = 0.4 * trial as f64 / 20.0 + 0.05;
            let after: Vec<DVec3> = mesh
                .positions
                .iter()
                .map(|&p| {
                    let big = if p.z > 1.0 - cap { 0.3 * random_unit(&mut rng) } else { DVec3::ZERO };
                    p + big + 0.01 * random_unit(&mut rng)
                })
                .collect();
            let moves = RoundMoves::new(&topology, &mesh.positions, &after);
            assert!(moves.slow_limit < moves.largest);
            for _ in 0..100 {
                let q = 2.5 * random_unit(&mut rng);
                let step = 0.05 * random_unit(&mut rng);
                let previous = distance_to_mesh(&mesh, &mesh.positions, q);
                let now = distance_to_mesh(&mesh, &after, q + step);
                let bound = moves.lowered(previous, step.length(), q + step);
                assert!(bound <= now, "trial {trial}: bound {bound} above the distance {now}");
                let old = previous - (moves.largest + step.length()) * (1.0 + BOUND_SLACK);
                assert!(bound >= old);
                if q.z < 0.0 && previous > 0.3 {
                    far += 1;
                    tighter += usize::from(bound > old + 0.5 * moves.largest);
                }
            }
        }
        assert!(far > 100 && tighter * 10 >= far * 9, "{tighter} of {far} far points kept a tighter bound");
    }
}
