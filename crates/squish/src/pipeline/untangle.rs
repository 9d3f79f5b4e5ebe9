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
//! vertices within [`RELAX_RINGS`]`[0]` edges are smoothed by half an umbrella step per round,
//! the crossing faces found again after each round, until none is left; a fold that outlasts
//! [`RELAX_ROUNDS`] rounds at one width is given the next, wider one. Copies of a vertex at one
//! rest position (unwelded seams) take the mean of their moves: no crack. The caller restores
//! the object's volume exactly (App. C's cubic) on a band around the smoothed vertices
//! ([`volume_carriers`]): the vertices [`VOLUME_RINGS`] + 1 to [`VOLUME_RINGS`] +
//! [`VOLUME_BAND`] edges from them, each offset along its normal by the height times a bump
//! that is zero at both edges of the band (not the smoothed vertices themselves: a crumpled
//! fold's own normals would crumple it again). Where the restored result still crosses (the
//! band's bulge pressing a fold's sheets together again), it is smoothed and restored again
//! from there, up to [`PASSES`] passes, the band around every vertex smoothed so far; the
//! result with the fewest crossing faces is kept if fewer cross than before.
//!
//! **Local.** The rest of the object keeps its positions bit for bit: the volume the smoothing
//! takes goes into a bulge around the fold, as a contact's goes into its own (ch. 5), rather
//! than into an inflation of the whole character. Untangling changes the signed volume a lot
//! where the input crossed itself (the overlap of two sheets counts twice, as in ch. 6's
//! input); restoring it is this module's decision (docs/decisions.md, "Untangling what is
//! left"). Deterministic (vertex order, no parallel reduction). Discrete where it stops (a
//! round or a pass more or less when a crossing appears or vanishes). It extends the thesis
//! (not in it).

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

/// What [`relax`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Relaxed {
    pub rounds: usize,
    /// Faces `crossing` finds after the last round.
    pub faces_after: usize,
}

/// Smooths the vertices near the faces `crossing` finds until it finds none (see the module
/// doc). `neighbours[v]`: the vertices sharing an edge with v; `position_ids[v]`: the smallest
/// vertex id at v's rest position.
pub(super) fn relax(
    triangles: &[[u32; 3]],
    positions: &mut [DVec3],
    neighbours: &[Vec<u32>],
    position_ids: &[u32],
    mut crossing: impl FnMut(&[DVec3]) -> Result<Vec<u32>, SpatialError>,
) -> Result<Relaxed, SpatialError> {
    let mut faces = crossing(positions)?;
    let mut relaxed = Relaxed { rounds: 0, faces_after: faces.len() };
    for rings in RELAX_RINGS {
        for _ in 0..RELAX_ROUNDS {
            if faces.is_empty() {
                return Ok(relaxed);
            }
            let seeds: Vec<u32> = faces.iter().flat_map(|&f| triangles[f as usize]).collect();
            let movable = grow(neighbours, &seeds, rings);
            let mut moves = vec![DVec3::ZERO; positions.len()];
            for (v, around) in neighbours.iter().enumerate() {
                if !movable[v] || around.is_empty() {
                    continue;
                }
                let mean = around.iter().map(|&w| positions[w as usize]).sum::<DVec3>() / around.len() as f64;
                moves[v] = STEP * (mean - positions[v]);
            }
            same_move_at_same_position(&mut moves, position_ids);
            for (p, m) in positions.iter_mut().zip(&moves) {
                *p += *m;
            }
            relaxed.rounds += 1;
            faces = crossing(positions)?;
            relaxed.faces_after = faces.len();
        }
    }
    Ok(relaxed)
}

/// Per vertex, the share of the volume restoration it carries around the vertices `inner`:
/// zero within [`VOLUME_RINGS`] edges of them and beyond [`VOLUME_RINGS`] + [`VOLUME_BAND`];
/// between, sin(π k / ([`VOLUME_BAND`] + 1)) at k rings past the gap, a bump with no step at
/// either edge of the band.
pub(super) fn volume_carriers(neighbours: &[Vec<u32>], inner: &[bool]) -> Vec<f64> {
    let seeds: Vec<u32> = (0..inner.len() as u32).filter(|&v| inner[v as usize]).collect();
    let rings = rings_from(neighbours, &seeds, VOLUME_RINGS + VOLUME_BAND);
    rings
        .iter()
        .map(|&r| match r {
            Some(r) if r > VOLUME_RINGS => {
                let k = (r - VOLUME_RINGS) as f64;
                (std::f64::consts::PI * k / (VOLUME_BAND + 1) as f64).sin()
            }
            _ => 0.0,
        })
        .collect()
}

/// Per vertex: within `rings` edges of a vertex of `seeds`.
fn grow(neighbours: &[Vec<u32>], seeds: &[u32], rings: usize) -> Vec<bool> {
    rings_from(neighbours, seeds, rings).iter().map(Option::is_some).collect()
}

/// Per vertex: its distance in edges from the nearest vertex of `seeds`, `None` beyond `rings`.
fn rings_from(neighbours: &[Vec<u32>], seeds: &[u32], rings: usize) -> Vec<Option<usize>> {
    let mut reached = vec![None; neighbours.len()];
    let mut layer: Vec<u32> = seeds.to_vec();
    for &v in &layer {
        reached[v as usize] = Some(0);
    }
    for ring in 1..=rings {
        let mut next = Vec::new();
        for &v in &layer {
            for &w in &neighbours[v as usize] {
                if reached[w as usize].is_none() {
                    reached[w as usize] = Some(ring);
                    next.push(w);
                }
            }
        }
        layer = next;
    }
    reached
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

    /// A strip of triangles (i, i+1, i+2): its first vertex lifted far off the strip's plane is
    /// brought back toward it; vertices beyond the rings never move.
    #[test]
    fn relaxation_moves_only_the_rings_around_the_crossing_faces() {
        let n = 12u32;
        let triangles: Vec<[u32; 3]> = (0..n - 2).map(|i| [i, i + 1, i + 2]).collect();
        let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n as usize];
        for t in &triangles {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                neighbours[a as usize].push(b);
                neighbours[b as usize].push(a);
            }
        }
        let mut positions: Vec<DVec3> = (0..n).map(|i| DVec3::new(i as f64, (i % 2) as f64, 0.0)).collect();
        positions[0].z = 5.0;
        let start = positions.clone();
        let ids: Vec<u32> = (0..n).collect();
        // "Crossing" while vertex 0 stands more than 1 off the plane z = 0.
        let crossing = |p: &[DVec3]| Ok(if p[0].z > 1.0 { vec![0] } else { Vec::new() });
        let relaxed = relax(&triangles, &mut positions, &neighbours, &ids, crossing).unwrap();
        assert_eq!(relaxed.faces_after, 0);
        assert!(relaxed.rounds > 0);
        assert!(positions[0].z <= 1.0);
        // The crossing face 0–1–2 and two rings of vertices (an edge joins i and i + 2): up to
        // vertex 6, never beyond.
        for v in 7..n as usize {
            assert_eq!(positions[v], start[v], "{v}");
        }
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
    /// one, symmetric, zero at the gap and past the band, largest mid-band.
    #[test]
    fn volume_carriers_are_a_bump_over_the_band_past_the_gap() {
        let n = 2 * (VOLUME_RINGS + VOLUME_BAND) + 5;
        let neighbours: Vec<Vec<u32>> = (0..n as u32)
            .map(|v| [v.checked_sub(1), (v + 1 < n as u32).then_some(v + 1)].into_iter().flatten().collect())
            .collect();
        let centre = n / 2;
        let mut inner = vec![false; n];
        inner[centre] = true;
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
    }
}
