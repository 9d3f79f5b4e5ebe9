//! The unique mapping direction d̂ (thesis §4.2.2, Eq. 4.1, Appendix A).
//!
//! Over each intersection region ℐ_l (an [`EdgeRegion`]: faces cut by its boundary are split
//! into triangles whose corners are the exact points), the linearly interpolated, *unnormalized*
//! vertex-normal field n is integrated with the degree-2 edge-midpoint rule of App. A
//! ([`EdgeRegion::integrate`]; the normal at a boundary point is the lerp of its edge's end
//! normals, THESIS-NOTES item 1):
//! - m_l = ∫n, A_l = area, mean n̄_l = m_l / |m_l|;
//! - total variation Var(n_l) = ∫|n − μ_l|² / A_l with μ_l = m_l / A_l, the trace of the
//!   covariance. We integrate the centred field in a second pass rather than ∫|n|²/A − |μ|²: both
//!   are the same quadrature (exact for quadratics of a linear field), but the centred form has no
//!   cancellation, so a flat object gets a variation of ~1e-32 instead of ~1e-16.
//!
//! Eq. 4.1 (THESIS-NOTES item 2), oriented along the second object's normals:
//! d̂ = normalize(−n̄_a·Var(n_b) + n̄_b·Var(n_a)): the object whose normals vary least weighs most.
//! A flat object has Var = 0, so d̂ is its normal exactly. Fallbacks, in order:
//! - both variations zero, or the combination vanishes: d̂ = normalize(n̄_b − n̄_a) (both objects
//!   weigh the same);
//! - one region empty (see [`super::intersect`]): the other's mean, −n̄_a or n̄_b;
//! - both empty (only tips poking through): the mean over the intersection points of
//!   n_b − n_a, the two meshes' interpolated normals there;
//! - nothing left: [`ContactError::DirectionUndefined`].
//!
//! A user direction (`PairParams::direction`) overrides all of this.

use glam::DVec3;

use super::{ContactError, EdgeRegion, IntersectionPoint, Sample};
use crate::mesh::{Topology, TriMesh};

/// Integrals of the normal field over a region.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NormalStats {
    /// Area of the region.
    pub area: f64,
    /// m = ∫n (unnormalized interpolated normals).
    pub integral: DVec3,
    /// n̄ = m / |m| (zero when the region is empty or the normals cancel).
    pub mean: DVec3,
    /// Var(n) = ∫|n − m/A|² / A (0 for an empty region).
    pub variation: f64,
}

/// Where the mapping direction came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum DirectionSource {
    /// No intersection and no user direction: there is no direction (zero vector).
    #[default]
    None,
    /// Given by the user.
    User,
    /// Eq. 4.1 with the inverse variations as weights.
    Automatic,
    /// Both variations zero (or the weighted sum vanished): normalize(n̄_b − n̄_a).
    EqualWeights,
    /// Only ℐ_a was non-empty: −n̄_a.
    OnlyFirst,
    /// Only ℐ_b was non-empty: n̄_b.
    OnlySecond,
    /// Both regions empty: mean of n_b − n_a over the intersection points.
    IntersectionPoints,
}

impl DirectionSource {
    /// True unless the direction was given by the user.
    pub fn is_automatic(&self) -> bool {
        !matches!(self, Self::User | Self::None)
    }
}

/// Mean normal and total variation of `normals` (per vertex) over `region`.
pub fn normal_stats(region: &EdgeRegion, mesh: &TriMesh, topology: &Topology, normals: &[DVec3]) -> NormalStats {
    if region.is_empty() {
        return NormalStats::default();
    }
    let field = |s: Sample| region.interpolate(normals, s);
    let (area, integral) = region.integrate(mesh, topology, field, |n: DVec3| n);
    if area <= 0.0 {
        return NormalStats::default();
    }
    let mu = integral / area;
    let (_, spread) = region.integrate(mesh, topology, field, |n: DVec3| (n - mu).length_squared());
    NormalStats { area, integral, mean: integral.normalize_or_zero(), variation: (spread / area).max(0.0) }
}

/// The variation below which a region counts as flat when both are (relative to 1, the variation
/// scale of unit normals): only round-off lives there.
const FLAT: f64 = 1e-24;

/// d̂ from the two regions' statistics (Eq. 4.1 and the fallbacks of the module docs), or `None`
/// if both regions are empty.
pub fn direction_from_stats(
    a: &NormalStats,
    b: &NormalStats,
) -> Option<Result<(DVec3, DirectionSource), ContactError>> {
    let (has_a, has_b) = (a.area > 0.0 && a.mean != DVec3::ZERO, b.area > 0.0 && b.mean != DVec3::ZERO);
    let result = match (has_a, has_b) {
        (false, false) => return None,
        (true, false) => Ok((-a.mean, DirectionSource::OnlyFirst)),
        (false, true) => Ok((b.mean, DirectionSource::OnlySecond)),
        (true, true) => {
            let weighted = (-a.mean * b.variation + b.mean * a.variation).try_normalize();
            match weighted {
                Some(d) if a.variation > FLAT || b.variation > FLAT => Ok((d, DirectionSource::Automatic)),
                _ => match (b.mean - a.mean).try_normalize() {
                    Some(d) => Ok((d, DirectionSource::EqualWeights)),
                    None => Err(ContactError::DirectionUndefined),
                },
            }
        }
    };
    Some(result)
}

/// Last resort when both intersection regions are empty: the mean over the intersection points of
/// n_b − n_a (each mesh's interpolated normal there).
pub fn direction_from_points(
    points: &[IntersectionPoint],
    topologies: [&Topology; 2],
    meshes: [&TriMesh; 2],
    normals: [&[DVec3]; 2],
) -> Result<(DVec3, DirectionSource), ContactError> {
    let mut sum = DVec3::ZERO;
    for p in points {
        let l = usize::from(p.edge_side.min(1));
        let [i, j] = topologies[l].edge(p.edge);
        let n_edge = normals[l][i as usize].lerp(normals[l][j as usize], p.t);
        let tri = meshes[1 - l].triangles[p.face as usize];
        let n_face: DVec3 = (0..3).map(|k| normals[1 - l][tri[k] as usize] * p.bary[k]).sum();
        // n_b − n_a whichever side the edge is on.
        sum += if l == 0 { n_face - n_edge } else { n_edge - n_face };
    }
    sum.try_normalize().map(|d| (d, DirectionSource::IntersectionPoints)).ok_or(ContactError::DirectionUndefined)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes;

    /// Whole grid over [−1, 1]² as a region.
    fn whole(mesh: &TriMesh, topology: &Topology) -> EdgeRegion {
        EdgeRegion::from_inside(topology, vec![true; mesh.num_vertices()], |_, _, _| 0.5)
    }

    /// Normal fields linear in position have closed-form statistics, which the quadrature must
    /// reproduce exactly: over [−1, 1]², n = (k·x + t, 0, −1) has mean (t, 0, −1) and variation
    /// k²·⟨x²⟩ = k²/3.
    #[test]
    fn variations_and_direction_of_two_tilted_fields() {
        let mesh = shapes::grid(2.0, 2.0, 8, 8);
        let topology = Topology::new(&mesh);
        let region = whole(&mesh, &topology);
        let (k, t1, m, t2) = (0.3, 0.2, 0.5, -0.1);
        let na: Vec<DVec3> = mesh.positions.iter().map(|p| DVec3::new(k * p.x + t1, 0.0, -1.0)).collect();
        let nb: Vec<DVec3> = mesh.positions.iter().map(|p| DVec3::new(0.0, m * p.y + t2, 1.0)).collect();
        let sa = normal_stats(&region, &mesh, &topology, &na);
        let sb = normal_stats(&region, &mesh, &topology, &nb);
        assert!((sa.area - 4.0).abs() < 1e-12);
        assert!((sa.mean - DVec3::new(t1, 0.0, -1.0).normalize()).length() < 1e-12);
        assert!((sb.mean - DVec3::new(0.0, t2, 1.0).normalize()).length() < 1e-12);
        assert!((sa.variation - k * k / 3.0).abs() < 1e-12, "{}", sa.variation);
        assert!((sb.variation - m * m / 3.0).abs() < 1e-12, "{}", sb.variation);
        let (d, source) = direction_from_stats(&sa, &sb).unwrap().unwrap();
        assert_eq!(source, DirectionSource::Automatic);
        let expected = (-sa.mean * (m * m / 3.0) + sb.mean * (k * k / 3.0)).normalize();
        assert!((d - expected).length() < 1e-12, "{d} vs {expected}");
        // The less varying side (a: k < m) dominates: d̂ is closer to −n̄_a than to n̄_b.
        assert!(d.dot(-sa.mean) > d.dot(sb.mean));
    }

    #[test]
    fn a_flat_side_gives_its_normal_exactly_and_fallbacks() {
        let mesh = shapes::grid(2.0, 2.0, 8, 8);
        let topology = Topology::new(&mesh);
        let region = whole(&mesh, &topology);
        let tilted = DVec3::new(0.3, -0.2, 1.0).normalize();
        let flat = vec![tilted; mesh.num_vertices()];
        let curved: Vec<DVec3> = mesh.positions.iter().map(|p| DVec3::new(p.x, p.y, -1.0)).collect();
        let sb = normal_stats(&region, &mesh, &topology, &flat);
        assert!(sb.variation < 1e-24, "{}", sb.variation);
        let sa = normal_stats(&region, &mesh, &topology, &curved);
        let (d, _) = direction_from_stats(&sa, &sb).unwrap().unwrap();
        assert!((d - tilted).length() < 1e-12, "{d}");
        // Both flat: the average of −n̄_a and n̄_b.
        let other = DVec3::new(-0.1, 0.0, -1.0).normalize();
        let sa = normal_stats(&region, &mesh, &topology, &vec![other; mesh.num_vertices()]);
        let (d, source) = direction_from_stats(&sa, &sb).unwrap().unwrap();
        assert_eq!(source, DirectionSource::EqualWeights);
        assert!((d - (tilted - other).normalize()).length() < 1e-12);
        // One side empty: the other's mean.
        let empty = NormalStats::default();
        assert_eq!(direction_from_stats(&empty, &sb).unwrap().unwrap(), (sb.mean, DirectionSource::OnlySecond));
        assert_eq!(direction_from_stats(&sa, &empty).unwrap().unwrap(), (-sa.mean, DirectionSource::OnlyFirst));
        assert!(direction_from_stats(&empty, &empty).is_none());
        // Opposite flat sides that cancel: undefined.
        let sa = normal_stats(&region, &mesh, &topology, &vec![-tilted; mesh.num_vertices()]);
        let sb2 = normal_stats(&region, &mesh, &topology, &vec![-tilted; mesh.num_vertices()]);
        assert!(matches!(direction_from_stats(&sa, &sb2), Some(Err(ContactError::DirectionUndefined))));
    }
}
