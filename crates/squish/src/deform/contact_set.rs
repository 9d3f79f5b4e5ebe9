//! The union 𝒞 of a working region's contact zones (thesis ch. 5 intro: "a single working region
//! [...] considering the single or multiple contact zones"), with, for every boundary point of
//! ∂𝒞, the zone it comes from and that zone's data (p_ij, p′_ij, n′_ij, d̄_k).
//!
//! Decisions:
//! - The union is built from the zones' public data (inside flags, boundary points and their
//!   edges), after checking that every zone lives on this region's topology, so that a zone built
//!   for another mesh is an error rather than a panic.
//! - On an edge leaving the union, the boundary point is the farthest of the limits of the zones
//!   holding its inside end (as [`EdgeRegion::union`]); its *owner* is the zone reaching farthest
//!   (ties: the lowest zone index). Boundary points of a zone that lie inside another zone are not
//!   on ∂𝒞 and are dropped.
//! - A vertex inside several zones takes the target and normal of the lowest-indexed zone holding
//!   it (overlapping zones come from different pairs; the pipeline's skinning stage, ch. 6, is where
//!   they are reconciled).
//! - Zone directions are normalized; a zero or non-finite direction is an error.

use glam::DVec3;

use super::DeformError;
use crate::contact::{ContactZone, EdgeRegion};
use crate::linalg::EdgePoint;
use crate::mesh::{Topology, TriMesh};

/// Marks a vertex that is in no zone.
pub const NO_ZONE: u32 = u32::MAX;

/// A boundary point of the union ∂𝒞 with its owner zone's data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactBoundaryPoint {
    /// The point on its edge (inside vertex in 𝒞, outside vertex not, α from the inside end).
    pub point: EdgePoint,
    /// The zone the point comes from.
    pub zone: u32,
    /// p_ij, the point on the mesh.
    pub position: DVec3,
    /// p′_ij, its position on the contact surface 𝒮.
    pub target: DVec3,
    /// n′_ij, the unit normal of 𝒮 there, outward from this mesh.
    pub normal: DVec3,
}

/// The union 𝒞 of the contact zones of one working region.
#[derive(Clone, Debug)]
pub struct ContactSet {
    /// The union as an edge region (its points are the `boundary` points, in the same order).
    pub region: EdgeRegion,
    /// The boundary points of ∂𝒞 with their owner's data, in the order of `region.points()`.
    pub boundary: Vec<ContactBoundaryPoint>,
    /// Per vertex: the zone whose target it takes, or [`NO_ZONE`].
    pub vertex_zone: Vec<u32>,
    /// The zones' unit outward displacement directions d̄_k (§5.2.2).
    pub directions: Vec<DVec3>,
    /// The zones' unit mapping directions d̂_k (Eq. 5.6).
    pub mapping_directions: Vec<DVec3>,
}

/// Edge id → index of the zone's boundary point on it (u32::MAX: none), checked against the
/// topology.
fn zone_edge_points(zone_index: usize, zone: &ContactZone, topology: &Topology) -> Result<Vec<u32>, DeformError> {
    let invalid = |reason: String| DeformError::InvalidZone { zone: zone_index, reason };
    let region = &zone.region;
    let mut lookup = vec![u32::MAX; topology.num_edges()];
    if region.point_edges().len() != region.points().len() {
        return Err(invalid("its boundary points and their edges differ in number".into()));
    }
    for (k, (p, &e)) in region.points().iter().zip(region.point_edges()).enumerate() {
        if e as usize >= topology.num_edges() {
            return Err(invalid(format!(
                "boundary point {k} is on edge {e}, but the region has {} edges",
                topology.num_edges()
            )));
        }
        let [lo, hi] = topology.edge(e);
        if [p.inside.min(p.outside), p.inside.max(p.outside)] != [lo, hi] {
            return Err(invalid(format!(
                "boundary point {k} joins vertices {} and {}, but edge {e} joins {lo} and {hi}",
                p.inside, p.outside
            )));
        }
        if !region.inside()[p.inside as usize] || region.inside()[p.outside as usize] {
            return Err(invalid(format!("boundary point {k} does not join an inside vertex to an outside one")));
        }
        if !(0.0..=1.0).contains(&p.alpha) {
            return Err(invalid(format!("boundary point {k} has α = {} outside [0, 1]", p.alpha)));
        }
        if lookup[e as usize] != u32::MAX {
            return Err(invalid(format!("edge {e} carries two boundary points")));
        }
        lookup[e as usize] = k as u32;
    }
    Ok(lookup)
}

fn check_zone(zone_index: usize, zone: &ContactZone, n: usize) -> Result<(DVec3, DVec3), DeformError> {
    let invalid = |reason: String| DeformError::InvalidZone { zone: zone_index, reason };
    let region = &zone.region;
    if region.inside().len() != n {
        return Err(invalid(format!("its region has {} vertices, the working region {n}", region.inside().len())));
    }
    if zone.targets.len() != n || zone.normals.len() != n {
        return Err(invalid(format!(
            "it has {} targets and {} normals for {n} vertices (one per region vertex)",
            zone.targets.len(),
            zone.normals.len()
        )));
    }
    let m = region.points().len();
    if zone.boundary_positions.len() != m || zone.boundary_targets.len() != m || zone.boundary_normals.len() != m {
        return Err(invalid(format!(
            "it has {m} boundary points but {} positions, {} targets and {} normals",
            zone.boundary_positions.len(),
            zone.boundary_targets.len(),
            zone.boundary_normals.len()
        )));
    }
    for (v, &inside) in region.inside().iter().enumerate() {
        if inside && !(zone.targets[v].is_finite() && zone.normals[v].is_finite()) {
            return Err(invalid(format!("vertex {v} has a non-finite target or normal")));
        }
    }
    for k in 0..m {
        if !(zone.boundary_positions[k].is_finite()
            && zone.boundary_targets[k].is_finite()
            && zone.boundary_normals[k].is_finite())
        {
            return Err(invalid(format!("boundary point {k} has a non-finite position, target or normal")));
        }
    }
    let unit = |v: DVec3, what: &str| {
        let length = v.length();
        if length.is_finite() && length > 0.0 {
            Ok(v / length)
        } else {
            Err(invalid(format!("its {what} {v} is not a non-zero finite vector")))
        }
    };
    Ok((unit(zone.direction, "direction")?, unit(zone.mapping_direction, "mapping direction")?))
}

impl ContactSet {
    /// The union of `zones` on the region `mesh` (see the module doc). Empty zones are allowed.
    pub fn new(mesh: &TriMesh, topology: &Topology, zones: &[&ContactZone]) -> Result<Self, DeformError> {
        let n = mesh.num_vertices();
        let mut directions = Vec::with_capacity(zones.len());
        let mut mapping_directions = Vec::with_capacity(zones.len());
        let mut lookups = Vec::with_capacity(zones.len());
        let mut vertex_zone = vec![NO_ZONE; n];
        for (k, zone) in zones.iter().enumerate() {
            let (direction, mapping) = check_zone(k, zone, n)?;
            directions.push(direction);
            mapping_directions.push(mapping);
            lookups.push(zone_edge_points(k, zone, topology)?);
            for (v, &inside) in zone.region.inside().iter().enumerate() {
                if inside && vertex_zone[v] == NO_ZONE {
                    vertex_zone[v] = k as u32;
                }
            }
        }
        let inside: Vec<bool> = vertex_zone.iter().map(|&z| z != NO_ZONE).collect();

        // For an edge leaving the union from inside vertex i: the zone holding i whose limit on the
        // edge is farthest, with that limit.
        let owner = |e: u32, i: u32| -> Option<(usize, f64)> {
            let mut best: Option<(usize, f64)> = None;
            for (k, zone) in zones.iter().enumerate() {
                if !zone.region.contains(i) {
                    continue;
                }
                let point = lookups[k][e as usize];
                if point == u32::MAX {
                    continue;
                }
                let alpha = zone.region.points()[point as usize].alpha;
                if best.is_none_or(|(_, a)| alpha > a) {
                    best = Some((k, alpha));
                }
            }
            best
        };
        let region = EdgeRegion::from_inside(topology, inside, |e, i, _| owner(e, i).map_or(0.5, |(_, a)| a));
        let mut boundary = Vec::with_capacity(region.points().len());
        for (&point, &e) in region.points().iter().zip(region.point_edges()) {
            // The outside end is in no zone, so every zone holding the inside end has a point on
            // this edge: an owner always exists.
            let Some((k, _)) = owner(e, point.inside) else {
                return Err(DeformError::InvalidZone {
                    zone: vertex_zone[point.inside as usize] as usize,
                    reason: format!(
                        "vertex {} is inside but its edge {e} to an outside vertex has no boundary point",
                        point.inside
                    ),
                });
            };
            let index = lookups[k][e as usize] as usize;
            let zone = &zones[k];
            boundary.push(ContactBoundaryPoint {
                point,
                zone: k as u32,
                position: zone.boundary_positions[index],
                target: zone.boundary_targets[index],
                normal: zone.boundary_normals[index],
            });
        }
        Ok(Self { region, boundary, vertex_zone, directions, mapping_directions })
    }

    /// True if vertex `v` is in 𝒞.
    #[inline]
    pub fn contains(&self, v: u32) -> bool {
        self.vertex_zone[v as usize] != NO_ZONE
    }

    /// Number of vertices in 𝒞.
    pub fn num_inside(&self) -> usize {
        self.vertex_zone.iter().filter(|&&z| z != NO_ZONE).count()
    }

    /// The x, y and z components of each boundary point's zone direction (in the order of
    /// [`Self::boundary`]): the constraint values of the direction diffusion (§5.2.2).
    pub fn boundary_direction_components(&self) -> [Vec<f64>; 3] {
        std::array::from_fn(|axis| self.boundary.iter().map(|b| self.directions[b.zone as usize][axis]).collect())
    }

    /// True if some boundary point of ∂𝒞 belongs to a zone whose direction differs from the first
    /// owner's: the direction field then needs the diffusion of §5.2.2.
    pub fn has_several_directions(&self) -> bool {
        let mut owners = self.boundary.iter().map(|b| self.directions[b.zone as usize]);
        match owners.next() {
            Some(first) => owners.any(|d| d != first),
            None => false,
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::deform::test_support::plane_zone;
    use crate::mesh::shapes;

    #[test]
    fn union_of_two_overlapping_plane_zones_keeps_the_farthest_limits() {
        let mesh = shapes::icosphere(1.0, 3);
        let topology = Topology::new(&mesh);
        // Two half-spaces from below, tilted apart: their union is bounded by the farther plane.
        let a = plane_zone(&mesh, &topology, DVec3::new(0.3, 0.0, 1.0).normalize(), -0.7);
        let b = plane_zone(&mesh, &topology, DVec3::new(-0.3, 0.0, 1.0).normalize(), -0.7);
        let set = ContactSet::new(&mesh, &topology, &[&a.clone(), &b.clone()]).unwrap();
        let reference = a.region.union(&b.region, &topology);
        assert_eq!(set.region.inside(), reference.inside());
        assert_eq!(set.region.points(), reference.points());
        assert!(set.num_inside() > a.region.num_inside().max(b.region.num_inside()));
        for bp in &set.boundary {
            let zone = if bp.zone == 0 { &a } else { &b };
            let e = topology.edge_between(bp.point.inside, bp.point.outside).unwrap();
            let k = zone.region.point_on_edge(e).unwrap() as usize;
            assert_eq!(zone.region.points()[k].alpha, bp.point.alpha);
            assert_eq!(zone.boundary_targets[k], bp.target);
        }
        assert!(set.has_several_directions(), "the tilted planes push along different directions");
        // Two presses along the same direction (nested half-spaces) need no diffusion.
        let deeper = plane_zone(&mesh, &topology, DVec3::Z, -0.6);
        let shallow = plane_zone(&mesh, &topology, DVec3::Z, -0.8);
        let set = ContactSet::new(&mesh, &topology, &[&shallow, &deeper.clone()]).unwrap();
        assert!(!set.has_several_directions());
        assert_eq!(set.region.points(), deeper.region.points());
        assert!(set.boundary.iter().all(|b| b.zone == 1));
    }

    #[test]
    fn a_zone_of_another_mesh_is_an_error_not_a_panic() {
        let mesh = shapes::icosphere(1.0, 3);
        let topology = Topology::new(&mesh);
        let other = shapes::icosphere(1.0, 2);
        let other_topology = Topology::new(&other);
        let zone = plane_zone(&other, &other_topology, DVec3::Z, -0.7);
        let err = ContactSet::new(&mesh, &topology, &[&zone]).unwrap_err();
        assert!(matches!(err, DeformError::InvalidZone { zone: 0, .. }), "{err}");
        let mut zone = plane_zone(&mesh, &topology, DVec3::Z, -0.7);
        zone.direction = DVec3::ZERO;
        assert!(matches!(ContactSet::new(&mesh, &topology, &[&zone]), Err(DeformError::InvalidZone { .. })));
    }
}
