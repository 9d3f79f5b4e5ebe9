//! The bulge map η (thesis §5.5): a per-vertex factor on the bulge ordinate `γ·η_i·h_v`, relative
//! (h_v absorbs its scale when the volume is preserved). η = painted × anisotropic, each optional:
//! a user-painted map (§5.5.1, default 1) and the automatic anisotropic map of Eq. 5.6 (§5.5.2).
//!
//! Anisotropic map: `η_i = Σ_k Σ_{j∈𝒞_k} A_j |p′_j − p_j| P_j(p_i)` over every zone k, with
//! `P_j(x) = max(0, d̂_k·(x − e_j)/|x − e_j| + ψ)^ω / |x − e_j|`, `A_j` a third of the area around j
//! and d̂_k the zone's mapping direction. Decisions:
//! - **Emitter on 𝒮.** e_j is the contact vertex's position on the contact surface, p′_j, not its
//!   input position p_j: with p_j, a plane pressed along its normal gets `d̂·(x − p_j) = 0` at
//!   every vertex of the plane, η ≡ 0 and no bulge at all; with p′_j (inside the dent) both sides
//!   of a normal press get a positive η decreasing with the distance, and a tilted d̂ pushes the
//!   bulge forward. For Eq. 5.6 to place the bulge, d̂ must point from 𝒮 towards the side's
//!   deformable region, which depends on the shapes, not on the pair's order (a flattened ball
//!   has its 𝒟 behind 𝒮, a dented plane in front of it): each zone's d̂ is therefore oriented by
//!   the sign of the area-weighted mean of d̂·(x_i − c) over 𝒟, c the emitters' centroid on 𝒮. The
//!   sign only changes when 𝒟 is balanced on both sides of 𝒮, where Eq. 5.6 has no preferred
//!   side anyway.
//! - **Scale.** The sum is divided by `Σ A_j |p′_j − p_j|` and multiplied by the extent φ_max: a
//!   dimensionless weighted mean of the emitters' fields, O(1) near the contact, continuous in the
//!   zones (a normalization by the maximum over 𝒟 would jump when the maximizing vertex enters 𝒞).
//! - **Singularity.** An emitter closer than 10⁻¹² extents to the vertex contributes nothing.
//! - **Cost.** |𝒟|·|𝒞| evaluations (about 2.5 million on a 10k-vertex sphere), exact (no
//!   truncation, which would break continuity), spread over the vertices of 𝒟 with rayon; each
//!   vertex sums its emitters in a fixed order, so the result is deterministic.
//! - **Fallbacks** (counted in the stats): when no contact vertex is displaced (Σ A_j|p′_j − p_j| =
//!   0) or η vanishes on all of 𝒟 (every vertex behind every emitter, ψ ≤ 0), the anisotropic
//!   factor is 1 (a uniform bulge) instead of a bulge that cannot be placed.

use glam::DVec3;
use rayon::prelude::*;

use super::contact_set::ContactSet;
use crate::contact::ContactZone;
use crate::mesh::{TriMesh, vertex_areas};

/// η on 𝒟 below this maximum counts as vanished (see the module doc).
const VANISHED_BULGE_MAP: f64 = 1e-12;

/// ω and ψ of Eq. 5.6.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnisotropyParams {
    /// ω: balance of the directional and positional terms (default 2).
    pub exponent: f64,
    /// ψ: offset of the directional term (default 0).
    pub offset: f64,
}

/// The bulge map of one region for one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct BulgeMap {
    /// η per vertex (meaningful on 𝒟; 1 elsewhere).
    pub weights: Vec<f64>,
    /// True if the anisotropic map fell back to 1.
    pub fallback: bool,
}

/// One emitter of Eq. 5.6: its position on 𝒮, its zone's mapping direction and its weight.
#[derive(Clone, Copy, Debug)]
struct Emitter {
    position: DVec3,
    direction: DVec3,
    weight: f64,
}

/// The anisotropic map of Eq. 5.6 on the vertices of `deformable` (1 elsewhere); see the module
/// doc. Returns the map and whether it fell back to 1. (Zone data beyond the mesh's vertices is
/// ignored; [`super::deform_region`] validates the zones first.)
pub fn anisotropic_bulge_map(
    mesh: &TriMesh,
    zones: &[&ContactZone],
    contact: &ContactSet,
    deformable: &[bool],
    params: &AnisotropyParams,
    extent: f64,
) -> (Vec<f64>, bool) {
    let n = mesh.num_vertices();
    let areas = vertex_areas(mesh);
    let mut emitters = Vec::new();
    let mut total = 0.0;
    for (k, zone) in zones.iter().enumerate() {
        let direction = contact.mapping_directions.get(k).copied().unwrap_or(DVec3::ZERO);
        let first = emitters.len();
        let (mut centroid, mut zone_weight) = (DVec3::ZERO, 0.0);
        for (j, &inside) in zone.region.inside().iter().enumerate().take(n.min(zone.targets.len())) {
            if !inside {
                continue;
            }
            let weight = areas[j] * (zone.targets[j] - mesh.positions[j]).length();
            if weight > 0.0 {
                emitters.push(Emitter { position: zone.targets[j], direction, weight });
                centroid += weight * zone.targets[j];
                zone_weight += weight;
                total += weight;
            }
        }
        // Orient d̂ from 𝒮 towards this side's deformable region (see the module doc): the sign of
        // the area-weighted mean height of 𝒟 above the zone's emitters along d̂.
        if zone_weight > 0.0 {
            let centroid = centroid / zone_weight;
            let height: f64 = (0..n)
                .filter(|&i| deformable.get(i).copied().unwrap_or(false))
                .map(|i| areas[i] * direction.dot(mesh.positions[i] - centroid))
                .sum();
            if height < 0.0 {
                for e in &mut emitters[first..] {
                    e.direction = -e.direction;
                }
            }
        }
    }
    let uniform = || (vec![1.0; n], true);
    if !(total.is_finite() && total > 0.0) {
        return uniform();
    }
    let scale = extent / total;
    let min_distance = 1e-12 * extent;
    let (omega, psi) = (params.exponent, params.offset);
    // Each vertex sums its emitters in a fixed order, so the parallel loop is deterministic.
    let mut eta = vec![1.0; n];
    let in_region = |i: usize| deformable.get(i).copied().unwrap_or(false);
    eta.par_iter_mut().enumerate().filter(|(i, _)| in_region(*i)).for_each(|(i, value)| {
        let x = mesh.positions[i];
        let mut sum = 0.0;
        for e in &emitters {
            let offset = x - e.position;
            let r = offset.length();
            if r <= min_distance {
                continue;
            }
            let directional = (e.direction.dot(offset) / r + psi).max(0.0);
            let lobe = if omega == 2.0 { directional * directional } else { directional.powf(omega) };
            sum += e.weight * lobe / r;
        }
        *value = sum * scale;
    });
    let largest = eta.iter().enumerate().filter(|(i, _)| in_region(*i)).fold(0.0f64, |m, (_, e)| m.max(*e));
    if !(largest.is_finite() && largest > VANISHED_BULGE_MAP) {
        return uniform();
    }
    (eta, false)
}

/// η = painted × anisotropic (each optional) on the region's vertices.
pub fn bulge_map(
    mesh: &TriMesh,
    zones: &[&ContactZone],
    contact: &ContactSet,
    deformable: &[bool],
    painted: Option<&[f64]>,
    anisotropy: Option<&AnisotropyParams>,
    extent: f64,
) -> BulgeMap {
    let (mut weights, fallback) = match anisotropy {
        Some(params) => anisotropic_bulge_map(mesh, zones, contact, deformable, params, extent),
        None => (vec![1.0; mesh.num_vertices()], false),
    };
    if let Some(painted) = painted {
        for (w, p) in weights.iter_mut().zip(painted) {
            *w *= p;
        }
    }
    BulgeMap { weights, fallback }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::deform::test_support::sphere_zone;
    use crate::mesh::{Topology, shapes};

    const PARAMS: AnisotropyParams = AnisotropyParams { exponent: 2.0, offset: 0.0 };

    /// A grid pressed from above by a rigid sphere; 𝒟 = the grid vertices within `reach` of the
    /// contact's axis, outside the zone.
    fn pressed_grid(mapping: DVec3) -> (TriMesh, ContactZone, ContactSet, Vec<bool>) {
        let mesh = shapes::grid(3.0, 3.0, 60, 60);
        let topology = Topology::new(&mesh);
        let mut zone = sphere_zone(&mesh, &topology, DVec3::new(0.0, 0.0, 0.45), 0.5);
        zone.mapping_direction = mapping;
        let contact = ContactSet::new(&mesh, &topology, &[&zone]).unwrap();
        let deformable =
            (0..mesh.num_vertices()).map(|v| !contact.contains(v as u32) && mesh.positions[v].length() < 1.2).collect();
        (mesh, zone, contact, deformable)
    }

    #[test]
    fn a_normal_press_bulges_on_every_side_decreasing_with_distance() {
        let (mesh, zone, contact, deformable) = pressed_grid(DVec3::Z);
        let (eta, fallback) = anisotropic_bulge_map(&mesh, &[&zone], &contact, &deformable, &PARAMS, 1.0);
        assert!(!fallback);
        let at = |p: DVec3| eta[crate::deform::test_support::nearest_vertex(&mesh, p)];
        // Emitters on 𝒮 (below the grid plane): positive on all sides, although d̂·(x − p_j) = 0
        // for every pair of grid vertices.
        for direction in [DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y] {
            let (near, far) = (at(0.35 * direction), at(0.9 * direction));
            assert!(near > 0.0 && far > 0.0, "{direction}: {near}, {far}");
            assert!(near > 2.0 * far, "η decreases away from the contact: {near} vs {far}");
        }
        // Rotational symmetry of a normal press, up to the grid's discretization.
        let (east, north) = (at(0.5 * DVec3::X), at(0.5 * DVec3::Y));
        assert!((east - north).abs() < 0.05 * east, "{east} vs {north}");
    }

    #[test]
    fn a_tilted_mapping_direction_puts_the_bulge_in_front() {
        let (mesh, zone, contact, deformable) = pressed_grid(DVec3::new(0.5, 0.0, 1.0).normalize());
        let (eta, _) = anisotropic_bulge_map(&mesh, &[&zone], &contact, &deformable, &PARAMS, 1.0);
        let (mut front, mut back) = (0.0, 0.0);
        for v in 0..mesh.num_vertices() {
            if deformable[v] {
                if mesh.positions[v].x > 0.0 { front += eta[v] } else { back += eta[v] }
            }
        }
        println!("η summed in front: {front:.3}, behind: {back:.3}");
        assert!(front > 2.0 * back, "front {front}, back {back}");
    }

    #[test]
    fn the_map_does_not_depend_on_the_orientation_of_the_pair() {
        // d̂ is oriented along the second object's normals, so swapping the pair flips it; the
        // map orients each zone's d̂ towards its own 𝒟 and must give the same result.
        let (mesh, zone, contact, deformable) = pressed_grid(DVec3::Z);
        let (up, _) = anisotropic_bulge_map(&mesh, &[&zone], &contact, &deformable, &PARAMS, 1.0);
        let (mesh, zone, contact, deformable) = pressed_grid(-DVec3::Z);
        let (down, fallback) = anisotropic_bulge_map(&mesh, &[&zone], &contact, &deformable, &PARAMS, 1.0);
        assert!(!fallback);
        assert_eq!(up, down);
    }

    #[test]
    fn a_flattened_side_bulges_behind_the_contact_surface() {
        // A soft sphere flattened by a rigid plane at z = c: its 𝒟 lies above 𝒮 (z > c), the
        // opposite side of a dented plane. With d̂ along the plane's normal pointing into the
        // sphere (+z) or out of it (−z), η is positive around the contact either way.
        let mesh = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&mesh);
        for mapping in [DVec3::Z, -DVec3::Z] {
            let mut zone = crate::deform::test_support::plane_zone(&mesh, &topology, DVec3::Z, -0.8);
            zone.mapping_direction = mapping;
            let contact = ContactSet::new(&mesh, &topology, &[&zone]).unwrap();
            let deformable: Vec<bool> =
                (0..mesh.num_vertices()).map(|v| !contact.contains(v as u32) && mesh.positions[v].z < 0.0).collect();
            let (eta, fallback) = anisotropic_bulge_map(&mesh, &[&zone], &contact, &deformable, &PARAMS, 1.0);
            assert!(!fallback, "{mapping}");
            let positive = (0..mesh.num_vertices()).filter(|&v| deformable[v] && eta[v] > 0.0).count();
            let total = deformable.iter().filter(|&&d| d).count();
            assert!(positive * 10 >= total * 9, "{mapping}: η > 0 on {positive} of {total} vertices of 𝒟");
        }
    }

    #[test]
    fn without_penetration_the_map_falls_back_to_uniform() {
        let (mesh, mut zone, contact, deformable) = pressed_grid(DVec3::Z);
        zone.targets = mesh.positions.clone();
        let (eta, fallback) = anisotropic_bulge_map(&mesh, &[&zone], &contact, &deformable, &PARAMS, 1.0);
        assert!(fallback && eta.iter().all(|&x| x == 1.0));
        // A painted map multiplies.
        let painted: Vec<f64> =
            (0..mesh.num_vertices()).map(|v| if mesh.positions[v].x < 0.0 { 0.0 } else { 2.0 }).collect();
        let map = bulge_map(&mesh, &[&zone], &contact, &deformable, Some(&painted), None, 1.0);
        assert_eq!(map.weights, painted);
    }
}
