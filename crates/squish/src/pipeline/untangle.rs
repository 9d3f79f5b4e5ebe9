//! Untangling what the self-contacts leave crossing (issue 27; docs/decisions.md, "Untangling
//! what is left").
//!
//! **Why.** Linear blend skinning does not only press two parts together (what ch. 4–6 and the
//! part contacts treat as contacts): it also *crumples* the skin where a joint turns far, a
//! lowered arm collapsing the shoulder and the armpit into folds whose sheets cross a few edges
//! from each other. There is no inside to push out of there — the ch. 4 contact finds no vertex
//! of one sheet inside the other, or only a few, and a coarse skin's chords keep crossing after
//! a contact that was found (docs/self-contact.md: where the faces were).
//!
//! **Rule** ([`relax`]). Around the faces still crossing (beyond the rest pose's own), the
//! vertices within [`RELAX_RINGS`]`[0]` edges are smoothed, each by its share of half an umbrella
//! step per round ([`crossing_weights`]: its faces' intersection lengths over [`RAMP_EDGES`] mean
//! edges, at most 1, the largest within the rings), the crossing faces found again after each
//! round, until none is left; a fold that outlasts [`RELAX_ROUNDS`] rounds at one width is given
//! the next, wider one. Copies of a vertex at one
//! rest position (unwelded seams) take the mean of their moves: no crack. The caller restores
//! the object's volume exactly (App. C's cubic) on a band around the smoothed vertices
//! ([`volume_carriers`]): the vertices [`VOLUME_RINGS`] + 1 to [`VOLUME_RINGS`] +
//! [`VOLUME_BAND`] edges from them, each offset along its normal by the height times a bump
//! that is zero at both edges of the band, scaled by the share the smoothed vertices took (not
//! the smoothed vertices themselves: a crumpled fold's own normals would crumple it again).
//! Where the restored result still crosses (the band's bulge pressing a fold's sheets together
//! again), it is smoothed and restored again from there, up to [`PASSES`] passes, the band
//! around every vertex smoothed so far; the last pass is kept unless more faces cross than
//! before.
//!
//! **Continuous in the pose.** A crossing starts with an intersection of length zero, so every
//! share, every move and every carrier starts from zero with it; the rounds stop where every
//! share is zero (stopping changes nothing); the widths follow the round count, not the state.
//! What is left discrete: a pass kept or not (only when it would add crossing faces), and an
//! intersection jumping where the contacts' result jumps.
//!
//! **Local.** The rest of the object keeps its positions bit for bit: the volume the smoothing
//! takes goes into a bulge around the fold, as a contact's goes into its own (ch. 5), rather
//! than into an inflation of the whole character. Untangling changes the signed volume a lot
//! where the input crossed itself (the overlap of two sheets counts twice, as in ch. 6's
//! input); restoring it is this module's decision (docs/decisions.md, "Untangling what is
//! left"). Deterministic (vertex order, no parallel reduction). It extends the thesis (not in
//! it).

use glam::DVec3;

use crate::spatial::SpatialError;

/// Rounds of smoothing per width.
pub const RELAX_ROUNDS: usize = 12;
/// Rings of vertices around the crossing faces that are smoothed: the first width, then the
/// wider ones when a fold outlasts a width's rounds.
pub const RELAX_RINGS: [usize; 3] = [2, 4, 8];
/// Rings of vertices around the smoothed ones that do not carry the volume restoration.
pub const VOLUME_RINGS: usize = 3;
/// Rings of vertices past [`VOLUME_RINGS`] that carry it; the rest of the object keeps its
/// positions.
pub const VOLUME_BAND: usize = 6;
/// Passes of smoothing then restoring the volume: a pass whose restored result still crosses
/// is smoothed again from there.
pub const PASSES: usize = 3;
/// The fraction of the umbrella step taken per round.
const STEP: f64 = 0.5;

/// The summed intersection length (see [`crossing_weights`]) over which a vertex's smoothing
/// ramps from nothing to a full step, in mean edge lengths.
pub const RAMP_EDGES: f64 = 2.0;

/// What [`relax`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Relaxed {
    pub rounds: usize,
    /// Faces `crossing` finds after the last round.
    pub faces_after: usize,
    /// Per vertex: the largest share of a step it took in a round (0: it never moved).
    pub weights: Vec<f64>,
}

/// Per vertex, the share of a full smoothing step it takes for the crossing faces `faces`
/// (face, summed intersection length of its crossing pairs): the lengths of its faces summed,
/// over [`RAMP_EDGES`] mean edges `edge`, at most 1; then the largest of these within `rings`
/// edges. A crossing starts from a length of zero, so the step starts from zero with it.
pub(super) fn crossing_weights(
    triangles: &[[u32; 3]],
    neighbours: &[Vec<u32>],
    faces: &[(u32, f64)],
    edge: f64,
    rings: usize,
) -> Vec<f64> {
    let mut weights = vec![0.0; neighbours.len()];
    for &(f, length) in faces {
        for v in triangles[f as usize] {
            weights[v as usize] += length;
        }
    }
    for w in weights.iter_mut().filter(|w| **w > 0.0) {
        *w = (*w / (RAMP_EDGES * edge)).min(1.0);
    }
    spread_max(neighbours, &mut weights, rings);
    weights
}

/// Every value becomes the largest within `rings` edges of it (each ring read from the last).
fn spread_max(neighbours: &[Vec<u32>], values: &mut [f64], rings: usize) {
    let mut active: Vec<u32> = (0..values.len() as u32).filter(|&v| values[v as usize] > 0.0).collect();
    for _ in 0..rings {
        let raised: Vec<(u32, f64)> = active
            .iter()
            .flat_map(|&v| neighbours[v as usize].iter().map(move |&u| (u, v)))
            .filter(|&(u, v)| values[v as usize] > values[u as usize])
            .map(|(u, v)| (u, values[v as usize]))
            .collect();
        active.clear();
        for (u, value) in raised {
            if value > values[u as usize] {
                values[u as usize] = value;
                active.push(u);
            }
        }
        active.sort_unstable();
        active.dedup();
    }
}

/// Smooths the vertices near the faces `crossing` finds until it finds none (see the module
/// doc). `crossing` gives each crossing face with the summed length of its crossing pairs
/// (`f64::INFINITY` when unknown: a full step). `neighbours[v]`: the vertices sharing an edge
/// with v; `position_ids[v]`: the smallest vertex id at v's rest position; `edge`: the mean
/// edge length.
pub(super) fn relax(
    triangles: &[[u32; 3]],
    positions: &mut [DVec3],
    neighbours: &[Vec<u32>],
    position_ids: &[u32],
    edge: f64,
    mut crossing: impl FnMut(&[DVec3]) -> Result<Vec<(u32, f64)>, SpatialError>,
) -> Result<Relaxed, SpatialError> {
    let mut faces = crossing(positions)?;
    let mut relaxed = Relaxed { rounds: 0, faces_after: faces.len(), weights: vec![0.0; positions.len()] };
    for rings in RELAX_RINGS {
        for _ in 0..RELAX_ROUNDS {
            if faces.is_empty() {
                return Ok(relaxed);
            }
            let weights = crossing_weights(triangles, neighbours, &faces, edge, rings);
            let mut moves = vec![DVec3::ZERO; positions.len()];
            for (v, around) in neighbours.iter().enumerate() {
                if weights[v] == 0.0 || around.is_empty() {
                    continue;
                }
                let mean = around.iter().map(|&w| positions[w as usize]).sum::<DVec3>() / around.len() as f64;
                moves[v] = STEP * weights[v] * (mean - positions[v]);
            }
            same_move_at_same_position(&mut moves, position_ids);
            for (p, m) in positions.iter_mut().zip(&moves) {
                *p += *m;
            }
            for (kept, w) in relaxed.weights.iter_mut().zip(&weights) {
                *kept = kept.max(*w);
            }
            relaxed.rounds += 1;
            faces = crossing(positions)?;
            relaxed.faces_after = faces.len();
        }
    }
    Ok(relaxed)
}

/// Per vertex, the share of the volume restoration it carries around the smoothed vertices,
/// `weights` the share of a step each took ([`Relaxed::weights`]): the largest over them of
/// their weight times sin(π k / ([`VOLUME_BAND`] + 1)) at k rings past a gap of [`VOLUME_RINGS`]
/// (a bump with no step at either edge of the band), less the largest weight within the gap.
/// Zero near the smoothed vertices and beyond the band; continuous in the weights, so a fold
/// that starts to be smoothed starts to carry volume from zero.
pub(super) fn volume_carriers(neighbours: &[Vec<u32>], weights: &[f64]) -> Vec<f64> {
    let reach = VOLUME_RINGS + VOLUME_BAND;
    let mut carriers = vec![0.0_f64; weights.len()];
    // Each seed's rings in turn, `stamp` marking the vertices its breadth-first search reached;
    // the maximum does not depend on the order.
    let mut stamp = vec![u32::MAX; weights.len()];
    for (seed, &w) in weights.iter().enumerate() {
        if w <= 0.0 {
            continue;
        }
        let mut layer = vec![seed as u32];
        stamp[seed] = seed as u32;
        for ring in 1..=reach {
            let mut next = Vec::new();
            for &v in &layer {
                for &u in &neighbours[v as usize] {
                    if stamp[u as usize] != seed as u32 {
                        stamp[u as usize] = seed as u32;
                        next.push(u);
                    }
                }
            }
            if ring > VOLUME_RINGS {
                let k = (ring - VOLUME_RINGS) as f64;
                let bump = w * (std::f64::consts::PI * k / (VOLUME_BAND + 1) as f64).sin();
                for &u in &next {
                    carriers[u as usize] = carriers[u as usize].max(bump);
                }
            }
            layer = next;
        }
    }
    let mut gap = weights.to_vec();
    spread_max(neighbours, &mut gap, VOLUME_RINGS);
    for (c, g) in carriers.iter_mut().zip(&gap) {
        *c = (*c - g).max(0.0);
    }
    carriers
}

/// Vertices at one rest position (copies along a seam) get the mean of their moves.
fn same_move_at_same_position(moves: &mut [DVec3], position_ids: &[u32]) {
    let mut sum = vec![(DVec3::ZERO, 0u32); moves.len()];
    for (v, m) in moves.iter().enumerate() {
        let id = position_ids.get(v).map_or(v, |&id| id as usize);
        sum[id].0 += *m;
        sum[id].1 += 1;
    }
    for (v, m) in moves.iter_mut().enumerate() {
        let id = position_ids.get(v).map_or(v, |&id| id as usize);
        let (s, n) = sum[id];
        if n > 1 {
            *m = s / n as f64;
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// A strip of triangles (i, i+1, i+2) with vertex i at (i, i mod 2, 0).
    fn strip(n: u32) -> (Vec<[u32; 3]>, Vec<Vec<u32>>, Vec<DVec3>) {
        let triangles: Vec<[u32; 3]> = (0..n - 2).map(|i| [i, i + 1, i + 2]).collect();
        let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n as usize];
        for t in &triangles {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                if !neighbours[a as usize].contains(&b) {
                    neighbours[a as usize].push(b);
                    neighbours[b as usize].push(a);
                }
            }
        }
        let positions = (0..n).map(|i| DVec3::new(i as f64, (i % 2) as f64, 0.0)).collect();
        (triangles, neighbours, positions)
    }

    /// "Crossing" while vertex 0 stands more than 1 off the plane z = 0, by as much as it does.
    fn lifted(p: &[DVec3]) -> Result<Vec<(u32, f64)>, SpatialError> {
        Ok(if p[0].z > 1.0 { vec![(0, p[0].z - 1.0)] } else { Vec::new() })
    }

    /// The strip's first vertex lifted far off the strip's plane is brought back toward it;
    /// vertices beyond the rings never move. (Mean edge 0.01: the crossing's length saturates
    /// the step until the vertex is within 0.02 of the plane.)
    #[test]
    fn relaxation_moves_only_the_rings_around_the_crossing_faces() {
        let n = 12u32;
        let (triangles, neighbours, mut positions) = strip(n);
        positions[0].z = 5.0;
        let start = positions.clone();
        let ids: Vec<u32> = (0..n).collect();
        let relaxed = relax(&triangles, &mut positions, &neighbours, &ids, 0.01, lifted).unwrap();
        assert_eq!(relaxed.faces_after, 0);
        assert!(relaxed.rounds > 0);
        assert!(positions[0].z <= 1.0);
        // The crossing face 0–1–2 and two rings of vertices (an edge joins i and i + 2): up to
        // vertex 6, never beyond.
        for v in 7..n as usize {
            assert_eq!(positions[v], start[v], "{v}");
            assert_eq!(relaxed.weights[v], 0.0, "{v}");
        }
    }

    /// The smoothing is continuous in the crossing: as the crossing's length goes to zero, so
    /// does every move, in proportion (no step when a crossing appears).
    #[test]
    fn relaxation_starts_from_zero_with_the_crossing() {
        let n = 12u32;
        let (triangles, neighbours, flat) = strip(n);
        let ids: Vec<u32> = (0..n).collect();
        let largest_move = |lift: f64| {
            let mut positions = flat.clone();
            positions[0].z = lift;
            let start = positions.clone();
            relax(&triangles, &mut positions, &neighbours, &ids, 1.0, lifted).unwrap();
            positions.iter().zip(&start).map(|(p, q)| p.distance(*q)).fold(0.0, f64::max)
        };
        assert_eq!(largest_move(1.0), 0.0);
        let moves: Vec<f64> = [1e-6, 1e-4, 1e-2].map(|d| largest_move(1.0 + d)).to_vec();
        for (d, m) in [1e-6, 1e-4, 1e-2].iter().zip(&moves) {
            assert!(*m > 0.0 && *m <= 2.0 * d, "a crossing of {d} moved a vertex by {m}");
        }
    }

    /// A crossing's weight ramps with its length up to a full step, and spreads unchanged over
    /// the rings.
    #[test]
    fn crossing_weights_ramp_with_the_length_and_spread_over_the_rings() {
        let (triangles, neighbours, _) = strip(12);
        let half = crossing_weights(&triangles, &neighbours, &[(0, 0.5 * RAMP_EDGES)], 1.0, 1);
        let full = crossing_weights(&triangles, &neighbours, &[(0, 3.0 * RAMP_EDGES)], 1.0, 1);
        // Face 0 is 0–1–2; one ring more reaches vertices 3 and 4 (i ± 1, i ± 2 are neighbours).
        for v in 0..5 {
            assert_eq!(half[v], 0.5, "{v}");
            assert_eq!(full[v], 1.0, "{v}");
        }
        assert!(half[5..].iter().chain(&full[5..]).all(|&w| w == 0.0));
    }

    #[test]
    fn copies_at_one_rest_position_move_together() {
        let mut moves = vec![DVec3::X, DVec3::Y, DVec3::Z];
        same_move_at_same_position(&mut moves, &[0, 1, 0]);
        assert_eq!(moves[0], moves[2]);
        assert_eq!(moves[0], DVec3::new(0.5, 0.0, 0.5));
        assert_eq!(moves[1], DVec3::Y);
    }

    /// On a path of vertices, the carriers are the band's vertices on both sides of the inner
    /// one, symmetric, zero at the gap and past the band, largest mid-band, and in proportion to
    /// the inner vertex's weight.
    #[test]
    fn volume_carriers_are_a_bump_over_the_band_past_the_gap() {
        let n = 2 * (VOLUME_RINGS + VOLUME_BAND) + 5;
        let neighbours: Vec<Vec<u32>> = (0..n as u32)
            .map(|v| [v.checked_sub(1), (v + 1 < n as u32).then_some(v + 1)].into_iter().flatten().collect())
            .collect();
        let centre = n / 2;
        let mut inner = vec![0.0; n];
        inner[centre] = 1.0;
        let w = volume_carriers(&neighbours, &inner);
        for (v, &weight) in w.iter().enumerate() {
            let rings = v.abs_diff(centre);
            if rings <= VOLUME_RINGS || rings > VOLUME_RINGS + VOLUME_BAND {
                assert_eq!(weight, 0.0, "vertex {v}, {rings} rings");
            } else {
                assert!(weight > 0.0 && weight <= 1.0, "vertex {v}: {weight}");
            }
        }
        for k in 1..=VOLUME_BAND {
            assert_eq!(w[centre + VOLUME_RINGS + k], w[centre - VOLUME_RINGS - k], "symmetric");
        }
        let edge = w[centre + VOLUME_RINGS + 1];
        let middle = w[centre + VOLUME_RINGS + VOLUME_BAND.div_ceil(2)];
        assert!(edge < middle && edge < 0.5, "{edge} {middle}");
        // A weaker inner vertex: the same bump, scaled; a second one, weak, in the first one's
        // band takes from it only what its own gap covers, in proportion to its weight.
        inner[centre] = 0.25;
        let scaled = volume_carriers(&neighbours, &inner);
        for (a, b) in scaled.iter().zip(&w) {
            assert!((a - 0.25 * b).abs() < 1e-15);
        }
        inner[centre] = 1.0;
        let other = centre + VOLUME_RINGS + 2;
        inner[other] = 1e-9;
        let both = volume_carriers(&neighbours, &inner);
        for (v, (a, b)) in both.iter().zip(&w).enumerate() {
            assert!((a - b).abs() <= 2e-9, "vertex {v}: {a} against {b}");
        }
    }
}
