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
//! the object's volume exactly on the vertices farther than [`VOLUME_RINGS`] edges from the
//! smoothed ones (App. C's cubic, their normals: a crumpled fold's own normals would crumple it
//! again) and keeps the result only if fewer faces cross.
//!
//! Untangling changes the signed volume a lot where the input crossed itself (the overlap of two
//! sheets counts twice, as in ch. 6's input), so the offset of the rest of the object is that
//! change spread over its whole area: a slight inflation of the whole character
//! (docs/self-contact.md gives its size). Deterministic (vertex order, no parallel reduction).
//! Discrete where it stops (a round more or less when a crossing appears or vanishes). It
//! extends the thesis (not in it).

use glam::DVec3;

use crate::spatial::SpatialError;

/// Rounds of smoothing per width.
pub const RELAX_ROUNDS: usize = 12;
/// Rings of vertices around the crossing faces that are smoothed: the first width, then the
/// wider ones when a fold outlasts a width's rounds.
pub const RELAX_RINGS: [usize; 3] = [2, 4, 8];
/// Rings of vertices around the smoothed ones that do not carry the volume restoration.
pub const VOLUME_RINGS: usize = 3;
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

/// Per vertex: farther than `rings` edges from every vertex of `inner` (and not in it).
pub(super) fn away_from(neighbours: &[Vec<u32>], inner: &[bool], rings: usize) -> Vec<bool> {
    let seeds: Vec<u32> = (0..inner.len() as u32).filter(|&v| inner[v as usize]).collect();
    grow(neighbours, &seeds, rings).iter().map(|&near| !near).collect()
}

/// Per vertex: within `rings` edges of a vertex of `seeds`.
fn grow(neighbours: &[Vec<u32>], seeds: &[u32], rings: usize) -> Vec<bool> {
    let mut reached = vec![false; neighbours.len()];
    let mut layer: Vec<u32> = seeds.to_vec();
    for &v in &layer {
        reached[v as usize] = true;
    }
    for _ in 0..rings {
        let mut next = Vec::new();
        for &v in &layer {
            for &w in &neighbours[v as usize] {
                if !reached[w as usize] {
                    reached[w as usize] = true;
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

    #[test]
    fn away_from_excludes_the_inner_vertices_and_their_rings() {
        let neighbours: Vec<Vec<u32>> =
            (0..6u32).map(|v| [v.checked_sub(1), (v < 5).then_some(v + 1)].into_iter().flatten().collect()).collect();
        let inner = [false, false, true, false, false, false];
        assert_eq!(away_from(&neighbours, &inner, 1), vec![true, false, false, false, true, true]);
    }
}
