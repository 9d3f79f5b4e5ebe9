//! The separation pass (issue 29; docs/decisions.md, "Contact gap"): after chapter 5 has deformed
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
//!   O) wants `s·(g − d)·n`, n the unit direction out of O at its closest point;
//! - every vertex w of O at signed distance d < g of S wants S's face at w's closest point moved
//!   by `−s·(g − d)·n` (n out of S there), shared among the face's corners with barycentric
//!   weights `b_i/Σb_j²` (so that the point under w moves by exactly that);
//! - a vertex keeps the largest of the moves it is asked for (by length), and each move is
//!   spread over the vertices within [`SPREAD_EDGES`] mean edge lengths with the weight
//!   `(1 − (r/R)²)²`, again keeping the largest: no spike, and a move that is a continuous
//!   function of the geometry (0 where every distance is at least g).
//!
//! Inside/outside is the winding number of O for a closed whole object, and its generalized
//! winding number above ¼ for an open or cut one ([`FastWinding`]: ½ behind a flat sheet, −½ in
//! front); points farther than [`DEPTH_EDGES`] edge lengths inside an open surface are left alone
//! (they are behind it, not near the contact). Only vertices of deformed
//! regions move, never on a cut border (their faces outside would move out of the volume balance).
//!
//! **Volume.** The moves accumulate into a correction added to the fixed part of the region's
//! affine displacement, and the bulge height is solved again with it
//! ([`crate::deform::RegionDeformation::correct`], §5.4.2, App. C): the volume (swept volume for
//! an open region) stays exactly preserved. The new height moves 𝒟 a little, so the pass runs
//! again on the new outputs, until no move exceeds [`STOP_FRACTION`]·g or after [`MAX_ROUNDS`].
//! The faces still intersecting then are counted with the exact test and reported as a
//! [`WarningKind::Unseparated`] frame warning, never silently.
//!
//! Deterministic: every loop runs in vertex or region-pair order, ties of closest points go to
//! the smallest face id, and parallel maps collect in order.

use glam::DVec3;
use rayon::prelude::*;

use super::cache::ObjectCache;
use super::contacts::RegionPair;
use super::deformations::RegionOutcome;
use super::warnings::{FrameWarning, WarningKind};
use super::{Frame, PipelineError};
use crate::contact::PairContact;
use crate::deform::HeightChoice;
use crate::mesh::{Aabb3, TriMesh, face_normal_unnormalized};
use crate::spatial::{ClosestPoint, FastWinding, TriangleBvh};

/// Most rounds of moves and height solves per frame.
pub const MAX_ROUNDS: usize = 8;
/// The pass stops when no vertex is asked to move by more than this fraction of the gap.
pub const STOP_FRACTION: f64 = 0.01;
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
fn movable_vertices(
    object_vertices: usize,
    cache: &ObjectCache,
    outcomes: &[Option<RegionOutcome>],
) -> Vec<Option<(u32, u32)>> {
    let mut slot = vec![None; object_vertices];
    for (r, (region, outcome)) in cache.regions.iter().zip(outcomes).enumerate() {
        if outcome.is_none() {
            continue;
        }
        match region.sub.as_deref() {
            None => slot.iter_mut().enumerate().for_each(|(v, s)| *s = Some((r as u32, v as u32))),
            Some(sub) => {
                for (local, (&parent, &border)) in sub.sub.parent_vertex.iter().zip(&sub.border).enumerate() {
                    if !border {
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

/// One side's surface for distance queries: its faces' tree at the current positions.
struct Surface<'a> {
    bvh: TriangleBvh,
    mesh: &'a TriMesh,
    /// Inside/outside by winding number (a closed whole object) rather than by the closest face.
    closed: bool,
    /// Vertices of the side (sorted).
    vertices: Vec<u32>,
}

/// Generalized winding number above which a point is inside an open surface: behind a flat
/// sheet it is ½, in front −½, inside a bowl near its bottom close to 1.
const OPEN_INSIDE_WINDING: f64 = 0.25;
/// Accuracy (β) of the far-field winding numbers of open surfaces.
const WINDING_ACCURACY: f64 = 4.0;

impl Surface<'_> {
    /// Signed distance of `q` (negative inside), the unit direction out of the surface at the
    /// closest point, and the closest point; `None` when `q` is farther than `reach` outside or
    /// (open surfaces, whose inside is `winding`'s) deeper than `depth` inside.
    fn signed_distance(
        &self,
        winding: Option<&FastWinding>,
        q: DVec3,
        reach: f64,
        depth: f64,
    ) -> Option<(f64, DVec3, ClosestPoint)> {
        let inside_closed = self.closed && self.bvh.contains(q);
        let limit = if inside_closed { f64::INFINITY } else { reach.max(depth) };
        let cp = self.bvh.closest_point_within(q, limit)?;
        let d = cp.distance;
        let inside = match winding {
            Some(winding) if !self.closed => winding.winding_number(q) > OPEN_INSIDE_WINDING,
            _ => inside_closed,
        };
        if (inside && !self.closed && d > depth) || (!inside && d > reach) {
            return None;
        }
        let offset = q - cp.point;
        let out = if d > 0.0 && (offset / d).is_finite() {
            if inside { -offset / d } else { offset / d }
        } else {
            let corners = self.bvh.face_corners(cp.face)?;
            face_normal_unnormalized(corners[0], corners[1], corners[2]).normalize_or_zero()
        };
        Some((if inside { -d } else { d }, out, cp))
    }
}

/// Keeps in `slot` the longer of its move and `candidate`.
fn keep_longest(slot: &mut DVec3, candidate: DVec3) {
    if candidate.length_squared() > slot.length_squared() {
        *slot = candidate;
    }
}

/// Runs the pass on the outcomes of chapter 5 (see the module doc); returns, per region pair
/// (order of `region_pairs`), what it did, and the warnings for the pairs left intersecting.
pub(super) fn separate(
    frame: &Frame,
    caches: &[Option<ObjectCache>],
    region_pairs: &[RegionPair],
    contacts: &[Option<PairContact>],
    outcomes: &mut [Vec<Option<RegionOutcome>>],
) -> Result<(Vec<PairSeparation>, Vec<FrameWarning>), PipelineError> {
    let mut report = vec![PairSeparation::default(); region_pairs.len()];
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
        return Ok((report, Vec::new()));
    }
    let count = frame.objects.len();
    let slots: Vec<Vec<Option<(u32, u32)>>> = (0..count)
        .map(|i| match caches[i].as_ref() {
            Some(cache) => movable_vertices(frame.objects[i].mesh.num_vertices(), cache, &outcomes[i]),
            None => Vec::new(),
        })
        .collect();
    let edge_lengths: Vec<f64> = (0..count)
        .map(|i| caches[i].as_ref().map_or(0.0, |c| mean_edge_length(c, &frame.objects[i].mesh.positions)))
        .collect();
    // The whole correction so far, per object vertex.
    let mut corrections: Vec<Vec<DVec3>> =
        (0..count).map(|i| vec![DVec3::ZERO; frame.objects[i].mesh.num_vertices()]).collect();
    let meshes_at = |outcomes: &[Vec<Option<RegionOutcome>>]| -> Vec<TriMesh> {
        (0..count)
            .map(|i| {
                let object = frame.objects[i].mesh;
                let positions = match caches[i].as_ref() {
                    Some(cache) => object_positions(&object.positions, cache, &outcomes[i]),
                    None => object.positions.clone(),
                };
                TriMesh { positions, triangles: object.triangles.clone() }
            })
            .collect()
    };
    let mut rounds = 0;
    let mut meshes = meshes_at(outcomes);
    while rounds < MAX_ROUNDS {
        let mut moves: Vec<Vec<DVec3>> = slots.iter().map(|s| vec![DVec3::ZERO; s.len()]).collect();
        let mut largest = 0.0f64;
        let mut stop_below = f64::INFINITY;
        for &k in &active {
            let rp = &region_pairs[k];
            let Some(contact) = contacts[k].as_ref() else { continue };
            let Some(regions) = rp.regions else { continue };
            let objects = frame.pairs[rp.pair].objects;
            let gap = contact.gap;
            stop_below = stop_below.min(STOP_FRACTION * gap);
            let surfaces = [0, 1].map(|l| surface(&meshes[objects[l]], caches[objects[l]].as_ref(), regions[l]));
            let [Some(sa), Some(sb)] = surfaces else { continue };
            let surfaces = [sa, sb];
            let windings = [0, 1].map(|l| (!surfaces[l].closed).then(|| FastWinding::new(&surfaces[l].bvh, WINDING_ACCURACY)));
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
            let overlap = overlap_box(&surfaces[0].bvh.bounds(), &surfaces[1].bvh.bounds(), gap);
            let Some(overlap) = overlap else { continue };
            for l in 0..2 {
                if shares[l] == 0.0 {
                    continue;
                }
                let (own, other) = (&surfaces[l], &surfaces[1 - l]);
                let (own_winding, other_winding) = (windings[l].as_ref(), windings[1 - l].as_ref());
                let object = objects[l];
                let share = shares[l];
                // Own vertices near or inside the other side.
                let near: Vec<Option<(u32, DVec3)>> = own
                    .vertices
                    .par_iter()
                    .with_min_len(256)
                    .map(|&v| {
                        let p = own.mesh.positions[v as usize];
                        if slots[object][v as usize].is_none() || !inside_box(&overlap, p) {
                            return None;
                        }
                        let (d, out, _) = other.signed_distance(other_winding, p, gap, depth)?;
                        (d < gap).then(|| (v, share * (gap - d) * out))
                    })
                    .collect();
                for (v, m) in near.into_iter().flatten() {
                    keep_longest(&mut moves[object][v as usize], m);
                }
                // The other side's vertices near or inside this side move this side's faces.
                let poking: Vec<Option<([u32; 3], [f64; 3], DVec3)>> = other
                    .vertices
                    .par_iter()
                    .with_min_len(256)
                    .map(|&w| {
                        let p = other.mesh.positions[w as usize];
                        if !inside_box(&overlap, p) {
                            return None;
                        }
                        let (d, out, cp) = own.signed_distance(own_winding, p, gap, depth)?;
                        let corners = own.mesh.triangles[cp.face as usize];
                        (d < gap).then(|| (corners, cp.bary, -share * (gap - d) * out))
                    })
                    .collect();
                for (corners, bary, m) in poking.into_iter().flatten() {
                    let norm: f64 = bary.iter().map(|b| b * b).sum();
                    if norm <= 0.0 {
                        continue;
                    }
                    for (&c, &b) in corners.iter().zip(&bary) {
                        if b > 0.0 && slots[object][c as usize].is_some() {
                            keep_longest(&mut moves[object][c as usize], (b / norm) * m);
                        }
                    }
                }
            }
        }
        for m in moves.iter().flatten() {
            largest = largest.max(m.length());
        }
        if std::env::var_os("SQUISH_SEP_DEBUG").is_some() {
            let counts: Vec<usize> = moves.iter().map(|m| m.iter().filter(|x| **x != DVec3::ZERO).count()).collect();
            eprintln!("round {rounds}: largest {largest:.3e} stop {stop_below:.3e} moved {counts:?}");
        }
        if largest <= stop_below || largest == 0.0 {
            break;
        }
        rounds += 1;
        for i in 0..count {
            if moves[i].iter().all(|m| *m == DVec3::ZERO) {
                continue;
            }
            let Some(cache) = caches[i].as_ref() else { continue };
            let spread = spread_moves(cache, &meshes[i].positions, &moves[i], &slots[i], SPREAD_EDGES * edge_lengths[i]);
            for (c, s) in corrections[i].iter_mut().zip(&spread) {
                *c += *s;
            }
            correct_regions(frame, i, cache, &corrections[i], &mut outcomes[i])?;
        }
        meshes = meshes_at(outcomes);
    }
    let mut warnings = Vec::new();
    for &k in &active {
        let rp = &region_pairs[k];
        let Some(regions) = rp.regions else { continue };
        let objects = frame.pairs[rp.pair].objects;
        let surfaces = [0, 1].map(|l| surface(&meshes[objects[l]], caches[objects[l]].as_ref(), regions[l]));
        let [Some(sa), Some(sb)] = surfaces else { continue };
        let pairs = sa.bvh.intersections_with(&sb.bvh);
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

/// The surface of region `region` of an object at `mesh`'s positions.
fn surface<'a>(mesh: &'a TriMesh, cache: Option<&ObjectCache>, region: usize) -> Option<Surface<'a>> {
    let cache = cache?;
    let region_cache = cache.regions.get(region)?;
    let (bvh, vertices, closed) = match region_cache.faces.as_ref() {
        None => (TriangleBvh::new(mesh).ok()?, (0..mesh.num_vertices() as u32).collect(), cache.closed),
        Some(faces) => {
            let mut vertices: Vec<u32> = faces.iter().flat_map(|&f| mesh.triangles[f as usize]).collect();
            vertices.sort_unstable();
            vertices.dedup();
            (TriangleBvh::with_faces(mesh, faces.iter().copied()).ok()?, vertices, false)
        }
    };
    Some(Surface { bvh, mesh, closed, vertices })
}

fn inside_box(b: &Aabb3, p: DVec3) -> bool {
    p.cmpge(b.min).all() && p.cmple(b.max).all()
}

/// The intersection of two boxes widened by `margin`, if they overlap.
fn overlap_box(a: &Aabb3, b: &Aabb3, margin: f64) -> Option<Aabb3> {
    let min = a.min.max(b.min) - DVec3::splat(margin);
    let max = a.max.min(b.max) + DVec3::splat(margin);
    (min.cmple(max).all()).then_some(Aabb3 { min, max })
}

/// Each non-zero move spread over the movable vertices within `radius` (edge paths, Euclidean
/// distance at `positions`) with the weight `(1 − (r/R)²)²`, keeping the longest per vertex.
fn spread_moves(
    cache: &ObjectCache,
    positions: &[DVec3],
    moves: &[DVec3],
    slots: &[Option<(u32, u32)>],
    radius: f64,
) -> Vec<DVec3> {
    let mut spread = moves.to_vec();
    if radius <= 0.0 {
        return spread;
    }
    let mut seen = vec![u32::MAX; moves.len()];
    let mut stack = Vec::new();
    for (source, m) in moves.iter().enumerate() {
        if *m == DVec3::ZERO {
            continue;
        }
        let origin = positions[source];
        stack.clear();
        stack.push(source as u32);
        seen[source] = source as u32;
        while let Some(v) = stack.pop() {
            for w in cache.topology.vertex_neighbors(v) {
                if seen[w as usize] == source as u32 || slots[w as usize].is_none() {
                    continue;
                }
                seen[w as usize] = source as u32;
                let r = (positions[w as usize] - origin).length() / radius;
                if r >= 1.0 {
                    continue;
                }
                let weight = (1.0 - r * r).powi(2);
                keep_longest(&mut spread[w as usize], weight * *m);
                stack.push(w);
            }
        }
    }
    spread
}

/// Applies object `i`'s whole correction to its deformed regions, each solving its bulge height
/// again for its volume.
fn correct_regions(
    frame: &Frame,
    i: usize,
    cache: &ObjectCache,
    correction: &[DVec3],
    outcomes: &mut [Option<RegionOutcome>],
) -> Result<(), PipelineError> {
    let object = &frame.objects[i];
    let err = |source| PipelineError::Deform { object: object.name.to_string(), source };
    for (region, outcome) in cache.regions.iter().zip(outcomes.iter_mut()) {
        let Some(outcome) = outcome.as_mut() else { continue };
        let (mesh, topology, local) = match region.sub.as_deref() {
            None => (object.mesh, &cache.topology, correction.to_vec()),
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
        outcome.deformation.correct(mesh, topology, &local, choice).map_err(err)?;
    }
    Ok(())
}
