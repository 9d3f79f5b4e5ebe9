//! What the separation pass knows of a point's generalized winding number about an open side
//! between two evaluations, so that it evaluates it again only when that knowledge no longer
//! settles which side of the surface the point is on (docs/decisions.md, "Separation pass: the
//! side of an open surface carried between rounds").
//!
//! **Why it holds.** The solid angle Ω(q) = 4π·w(q) of a triangulated surface S is smooth off S
//! and its gradient depends only on S's *rim* ∂S, the edges whose faces do not cancel (an edge
//! two faces cross in opposite directions cancels; one face, or two in the same direction, do
//! not): ∇Ω(q) = ∮_∂S (x − q) × dl / |x − q|³ (the Biot–Savart law of a current on ∂S), so
//! |∇w(q)| ≤ L / (4π r²), L the rim's length (with multiplicity) and r the distance from q to the
//! rim. Moving S's inside while its rim stays put does not change w at a point it does not pass
//! through; moving the rim by δ changes it by at most L·δ / (4π r²) (the area the rim sweeps,
//! seen from q). So if a point and the surface move along straight paths during which the point
//! stays off the surface (its distance at the start exceeds the two moves) and farther than r
//! from the rim, w changes by at most L·(own move + rim move) / (4π r²).
//!
//! **What is kept.** Per querying point: the last value computed ([`WindingKnown::value`], the
//! fast approximation's, exact near the threshold), the drift bound accumulated since
//! ([`WindingKnown::drift`]) and a lower bound of its distance to the rim ([`WindingKnown::rim`]).
//! The decision (w above the threshold) is settled when the value, widened by the drift and by
//! the fast approximation's error allowance [`WINDING_ALLOWANCE`], stays on one side; that is the
//! decision a fresh evaluation gives whenever the fast value is within that allowance of the true
//! one (the assumption that already makes the decision independent of the far-field clusters),
//! so the pass's answers, and its bits, are those of evaluating at every round.
//!
//! Conventions: object vertex ids; a rim edge's ends in increasing id, its multiplicity the
//! absolute sum of its faces' orientations.

use std::f64::consts::PI;

use glam::DVec3;

use crate::spatial::FlatBvh;

/// An edge of a side's rim: its two ends (object vertex ids, increasing) and how many times its
/// faces cross it in the same direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct RimEdge {
    pub ends: [u32; 2],
    pub multiplicity: f64,
}

/// The rim of the faces `faces` of `triangles`: every edge whose faces' orientations do not sum
/// to zero, in increasing order of its ends.
pub(super) fn rim_of(triangles: &[[u32; 3]], faces: &[u32]) -> Vec<RimEdge> {
    let mut halves: Vec<([u32; 2], i32)> = faces
        .iter()
        .flat_map(|&f| {
            let [a, b, c] = triangles[f as usize];
            [[a, b], [b, c], [c, a]]
        })
        .map(|[a, b]| if a < b { ([a, b], 1) } else { ([b, a], -1) })
        .collect();
    halves.sort_unstable();
    let mut rim = Vec::new();
    let mut k = 0;
    while k < halves.len() {
        let ends = halves[k].0;
        let mut sum = 0;
        while k < halves.len() && halves[k].0 == ends {
            sum += halves[k].1;
            k += 1;
        }
        if sum != 0 {
            rim.push(RimEdge { ends, multiplicity: f64::from(sum.abs()) });
        }
    }
    rim
}

/// What a querying point knows of its generalized winding number about one open side (see the
/// module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct WindingKnown {
    /// The winding number last computed at the point.
    pub value: f64,
    /// A bound of how far the winding number may have moved since.
    pub drift: f64,
    /// A lower bound of the point's distance to the side's rim (infinite without a rim).
    pub rim: f64,
}

/// The error allowed to the fast winding number where it decides alone: the margin within which
/// the exact sum decides instead (the separation pass's `WINDING_MARGIN`).
pub(super) const WINDING_ALLOWANCE: f64 = 0.05;

/// Relative slack of the drift and distance bounds (far above their round-off).
const SLACK: f64 = 1e-9;

impl WindingKnown {
    /// Whether the point is above `threshold`, when what is known settles it.
    pub fn settled(&self, threshold: f64) -> Option<bool> {
        let widening = self.drift + WINDING_ALLOWANCE;
        if self.value + widening < threshold {
            Some(false)
        } else if self.value - widening > threshold {
            Some(true)
        } else {
            None
        }
    }
}

/// How one side's rim moved in one step (a round, or between two passes), for
/// [`RimMove::carry`].
#[derive(Clone, Copy, Debug)]
pub(super) struct RimMove {
    /// The largest move of a rim vertex.
    pub largest: f64,
    /// A bound of the rim's length (with multiplicity) all along the straight paths of its
    /// vertices: each edge's length now plus its two ends' moves.
    pub length: f64,
    /// The largest move of any vertex of the side's object (a bound of every point of the
    /// surface's move).
    pub surface: f64,
}

impl RimMove {
    /// The move of the rim `rim` whose vertices are now at `positions` and moved by `moved` (per
    /// object vertex; `None`: nothing moved), the object's largest move `surface`.
    pub fn new(rim: &[RimEdge], positions: &[DVec3], moved: Option<&[f64]>, surface: f64) -> Self {
        let step = |v: u32| moved.map_or(0.0, |m| m[v as usize]);
        let mut largest = 0.0f64;
        let mut length = 0.0;
        for e in rim {
            let [a, b] = e.ends;
            largest = largest.max(step(a)).max(step(b));
            length += e.multiplicity * ((positions[a as usize] - positions[b as usize]).length() + step(a) + step(b));
        }
        Self { largest, length, surface }
    }

    /// What `known` (at a point whose distance to the surface was at least `clearance` before
    /// the step, and which moved by `own`) still knows after the step: `None` once the point may
    /// have met the surface or its rim.
    pub fn carry(&self, known: WindingKnown, clearance: f64, own: f64) -> Option<WindingKnown> {
        if own == 0.0 && self.largest == 0.0 && self.surface == 0.0 {
            return Some(known);
        }
        let off_surface = clearance - (self.surface + own) * (1.0 + SLACK) > 0.0;
        let rim = known.rim - (self.largest + own) * (1.0 + SLACK);
        if !off_surface || rim.is_nan() || rim <= 0.0 {
            return None;
        }
        let drift = if rim.is_finite() { self.length * (self.largest + own) / (4.0 * PI * rim * rim) } else { 0.0 };
        Some(WindingKnown { value: known.value, drift: (known.drift + drift) * (1.0 + SLACK), rim })
    }
}

/// A side's rim at the current positions, for the distance from a point to it.
pub(super) struct RimTree {
    segments: Vec<[DVec3; 2]>,
    tree: FlatBvh,
}

impl RimTree {
    /// The rim `rim` at `positions`.
    pub fn new(rim: &[RimEdge], positions: &[DVec3]) -> Self {
        let segments: Vec<[DVec3; 2]> = rim.iter().map(|e| e.ends.map(|v| positions[v as usize])).collect();
        let boxes: Vec<(DVec3, DVec3)> = segments.iter().map(|[a, b]| (a.min(*b), a.max(*b))).collect();
        Self { tree: FlatBvh::new(&boxes), segments }
    }

    /// The distance from `q` to the rim (infinite without one), a little under rather than over.
    pub fn distance(&self, q: DVec3) -> f64 {
        let mut best = f64::INFINITY;
        let box_distance = |min: DVec3, max: DVec3| (q - q.clamp(min, max)).length();
        self.tree.branch_and_bound(
            &mut best,
            |node| Some(box_distance(node.min, node.max)),
            |best, key| key >= *best,
            |best, item| {
                let [a, b] = self.segments[item as usize];
                *best = best.min(segment_distance(q, a, b));
            },
        );
        best * (1.0 - SLACK)
    }
}

/// The distance from `q` to the segment `[a, b]`.
fn segment_distance(q: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 { ((q - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
    (q - (a + t * ab)).length()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::Lcg;
    use crate::mesh::{TriMesh, shapes};
    use crate::spatial::generalized_winding_number;

    /// A closed mesh has no rim; a grid's rim is its border, once per edge; a grid with one face
    /// flipped adds that face's inner edges twice over (its neighbours cross them the same way).
    #[test]
    fn the_rim_is_the_edges_whose_faces_do_not_cancel() {
        let ball = shapes::icosphere(1.0, 2);
        let all: Vec<u32> = (0..ball.num_triangles() as u32).collect();
        assert!(rim_of(&ball.triangles, &all).is_empty());
        let grid = shapes::grid(1.0, 1.0, 4, 4);
        let all: Vec<u32> = (0..grid.num_triangles() as u32).collect();
        let rim = rim_of(&grid.triangles, &all);
        assert_eq!(rim.len(), 16);
        assert!(rim.iter().all(|e| e.multiplicity == 1.0 && e.ends[0] < e.ends[1]));
        let mut flipped = grid.triangles.clone();
        let inner = (0..flipped.len())
            .find(|&f| {
                let t = flipped[f];
                !rim.iter().any(|e| t.contains(&e.ends[0]) && t.contains(&e.ends[1]))
            })
            .unwrap();
        flipped[inner].swap(1, 2);
        let rim_flipped = rim_of(&flipped, &all);
        assert_eq!(rim_flipped.len(), 19);
        assert_eq!(rim_flipped.iter().filter(|e| e.multiplicity == 2.0).count(), 3);
    }

    /// The bound holds: a bumped open sheet whose inside moves far while its rim moves a little,
    /// and points that move a little and stay off it. After each step the true winding number is
    /// within the carried drift of the one before, and a point the knowledge settles gets the
    /// decision a fresh evaluation gives.
    #[test]
    fn the_winding_number_stays_within_the_carried_drift() {
        let base = shapes::grid(2.0, 2.0, 12, 12);
        let faces: Vec<u32> = (0..base.num_triangles() as u32).collect();
        let rim = rim_of(&base.triangles, &faces);
        let on_rim: Vec<bool> = {
            let mut on = vec![false; base.num_vertices()];
            for e in &rim {
                on[e.ends[0] as usize] = true;
                on[e.ends[1] as usize] = true;
            }
            on
        };
        let mut rng = Lcg::new(53);
        let random_unit = |rng: &mut Lcg| DVec3::new(rng.next_signed(), rng.next_signed(), rng.next_signed());
        let (mut carried, mut settled) = (0, 0);
        for trial in 0..40 {
            let bump = 0.3 * (trial as f64 / 40.0);
            let shape = |p: DVec3, h: f64| DVec3::new(p.x, p.y, h * (1.0 - p.x * p.x) * (1.0 - p.y * p.y));
            let before: Vec<DVec3> = base.positions.iter().map(|&p| shape(p, bump)).collect();
            let after: Vec<DVec3> = base
                .positions
                .iter()
                .zip(&on_rim)
                .map(|(&p, &rim)| shape(p, bump + 0.2) + if rim { 0.01 * random_unit(&mut rng) } else { DVec3::ZERO })
                .collect();
            let moved: Vec<f64> = before.iter().zip(&after).map(|(a, b)| (*a - *b).length()).collect();
            let surface = moved.iter().copied().fold(0.0, f64::max);
            let step = RimMove::new(&rim, &after, Some(&moved), surface);
            let mesh_at = |positions: &[DVec3]| TriMesh::new(positions.to_vec(), base.triangles.clone()).unwrap();
            let (mesh_before, mesh_after) = (mesh_at(&before), mesh_at(&after));
            let tree = RimTree::new(&rim, &before);
            for _ in 0..50 {
                let q = DVec3::new(1.4 * rng.next_signed(), 1.4 * rng.next_signed(), 0.9 * rng.next_signed());
                let own = 0.02 * random_unit(&mut rng);
                let w0 = generalized_winding_number(&mesh_before, q);
                let known = WindingKnown { value: w0, drift: 0.0, rim: tree.distance(q) };
                let clearance = 0.9 * (q.z - bump).abs().min(q.z.abs());
                let Some(now) = step.carry(known, clearance, own.length()) else { continue };
                carried += 1;
                let w1 = generalized_winding_number(&mesh_after, q + own);
                assert!((w1 - w0).abs() <= now.drift, "trial {trial} at {q}: {w0} → {w1}, drift {}", now.drift);
                if let Some(above) = now.settled(0.25) {
                    settled += 1;
                    assert_eq!(above, w1 > 0.25);
                }
            }
        }
        assert!(carried > 300 && settled > 200, "{carried} carried, {settled} settled");
    }

    /// The distance to the rim is the least over its segments, and no more.
    #[test]
    fn the_distance_to_the_rim_is_the_nearest_segments() {
        let grid = shapes::grid(2.0, 1.0, 9, 5);
        let faces: Vec<u32> = (0..grid.num_triangles() as u32).collect();
        let rim = rim_of(&grid.triangles, &faces);
        let tree = RimTree::new(&rim, &grid.positions);
        let mut rng = Lcg::new(7);
        for _ in 0..500 {
            let q = DVec3::new(2.0 * rng.next_signed(), 2.0 * rng.next_signed(), rng.next_signed());
            let brute = rim
                .iter()
                .map(|e| segment_distance(q, grid.positions[e.ends[0] as usize], grid.positions[e.ends[1] as usize]))
                .fold(f64::INFINITY, f64::min);
            let d = tree.distance(q);
            assert!(d <= brute && d >= brute * (1.0 - 1e-8), "{d} against {brute}");
        }
        assert_eq!(RimTree::new(&[], &grid.positions).distance(DVec3::ZERO), f64::INFINITY);
    }
}
