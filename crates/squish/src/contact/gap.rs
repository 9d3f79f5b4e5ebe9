//! The contact gap (issue 29; docs/decisions.md, "Contact gap"): the two contact zones' targets
//! backed off from the potential contact surface 𝒮 (§4.3) so that the outputs do not interleave.
//!
//! **Why.** The thesis sends the vertices of 𝒞_a and 𝒞_b onto the same surface 𝒮. Their
//! triangles are chords of 𝒮 between different sets of points: on a curved 𝒮 the chords of the
//! concave side cross the convex side's (by about h²/8ρ, h the edge length, ρ the radius of
//! curvature), and on a flat one coincident triangles touch, so an exact triangle–triangle test
//! finds as many intersecting faces after the deformation as before.
//!
//! **Contract.** [`apply_gap`] moves each target of a zone (vertices inside 𝒞 and its exact
//! boundary points) by `−share·gap·n′`, n′ the unit normal of 𝒮 there oriented outward from
//! that side's mesh: each side stops short of 𝒮 on its own side. The share of a side is the
//! relative stiffness of its partner — the share of δ it moves (§4.3) — so a rigid side keeps its
//! surface and its partner leaves the whole gap. The gap used is
//! `min(gap, P)`, P the typical penetration depth of the pair ([`super::zone::typical_penetration`]):
//! P is 0 at the first touch and continuous, so the targets do not jump when a contact starts.
//! The deformation (chapter 5) is built from the targets as given (amplitudes at ∂𝒞, volume), so
//! the volume stays preserved exactly.
//!
//! The automatic gap is [`PAIR_GAP_FRACTION`] of [`zone_edge_length`], the mean length of the edges
//! touching a zone, on the coarser side: it must exceed the chords' departure from 𝒮, which grows
//! with h, while staying invisible.

use super::ContactZone;
use crate::mesh::{Topology, TriMesh};

/// The automatic gap as a fraction of the coarser zone's mean edge length.
pub const PAIR_GAP_FRACTION: f64 = 0.1;

/// Mean length of the edges of `mesh` (with its `topology`) with an end inside `zone` (0 for an
/// empty zone).
pub fn zone_edge_length(mesh: &TriMesh, topology: &Topology, zone: &ContactZone) -> f64 {
    let (mut total, mut count) = (0.0, 0usize);
    for &[i, j] in topology.edges() {
        if zone.region.contains(i) || zone.region.contains(j) {
            total += (mesh.positions[i as usize] - mesh.positions[j as usize]).length();
            count += 1;
        }
    }
    if count == 0 { 0.0 } else { total / count as f64 }
}

/// The gap of a pair: `requested` (`None`: automatic, [`PAIR_GAP_FRACTION`] of the larger of the
/// two zones' edge lengths `edge_lengths`) bounded by the typical penetration depth `penetration`.
pub fn effective_gap(requested: Option<f64>, edge_lengths: [f64; 2], penetration: f64) -> f64 {
    let gap = requested.unwrap_or(PAIR_GAP_FRACTION * edge_lengths[0].max(edge_lengths[1]));
    gap.min(penetration).max(0.0)
}

/// Backs the targets of `zone` off 𝒮 by `distance` along −n′ (see the module doc).
pub fn apply_gap(zone: &mut ContactZone, distance: f64) {
    if distance == 0.0 {
        return;
    }
    let inside = zone.region.inside();
    for ((target, normal), &is_inside) in zone.targets.iter_mut().zip(&zone.normals).zip(inside) {
        if is_inside {
            *target -= distance * *normal;
        }
    }
    for (target, normal) in zone.boundary_targets.iter_mut().zip(&zone.boundary_normals) {
        *target -= distance * *normal;
    }
}
