//! Synthetic contact zones for the deformation tests, built the way the contact stage (ch. 4)
//! delivers them: a zone as an [`EdgeRegion`] with exact boundary points, per-vertex and
//! per-boundary-point targets on the contact surface 𝒮 and normals of 𝒮 outward from the mesh.

use glam::DVec3;

use crate::contact::{ContactZone, EdgeRegion};
use crate::mesh::{Topology, TriMesh};

/// A rigid half-space `{x : m·x < c}` (unit `m` pointing from the rigid body into the soft mesh)
/// pressing the mesh: 𝒞 = the mesh part with `m·x ≤ c`, exact boundary points where `m·x = c`,
/// targets = orthogonal projections onto the plane, normals of 𝒮 = −m (outward of the pressed
/// side), direction d̄ = −m, mapping direction d̂ = +m.
pub fn plane_zone(mesh: &TriMesh, topology: &Topology, m: DVec3, c: f64) -> ContactZone {
    let m = m.normalize();
    let values: Vec<f64> = mesh.positions.iter().map(|p| m.dot(*p) - c).collect();
    let region = EdgeRegion::sublevel_set(topology, &values);
    let project = |p: DVec3| p + (c - m.dot(p)) * m;
    let targets = mesh
        .positions
        .iter()
        .enumerate()
        .map(|(v, &p)| if region.contains(v as u32) { project(p) } else { p })
        .collect();
    let normals = (0..mesh.num_vertices()).map(|v| if region.contains(v as u32) { -m } else { DVec3::ZERO }).collect();
    let boundary_positions: Vec<DVec3> =
        (0..region.points().len() as u32).map(|k| region.point_position(mesh, k)).collect();
    let boundary_targets = boundary_positions.iter().map(|&p| project(p)).collect();
    let boundary_normals = vec![-m; boundary_positions.len()];
    ContactZone {
        region,
        targets,
        normals,
        boundary_positions,
        boundary_targets,
        boundary_normals,
        direction: -m,
        mapping_direction: m,
    }
}

/// A rigid sphere (centre `centre`, radius `radius`) pressing the mesh from above (+z): 𝒞 = the
/// mesh part inside the ball, targets = vertical projections onto the sphere's lower surface,
/// normals of 𝒮 = the sphere's normal flipped (facing the pressed side's outward +z), direction
/// d̄ = +z (the pressed side moves down), mapping direction d̂ = +z.
pub fn sphere_zone(mesh: &TriMesh, topology: &Topology, centre: DVec3, radius: f64) -> ContactZone {
    let values: Vec<f64> = mesh.positions.iter().map(|p| (*p - centre).length() - radius).collect();
    let region = EdgeRegion::sublevel_set(topology, &values);
    let lower = |p: DVec3| {
        let (dx, dy) = (p.x - centre.x, p.y - centre.y);
        let r2 = (dx * dx + dy * dy).min(radius * radius);
        DVec3::new(p.x, p.y, centre.z - (radius * radius - r2).sqrt())
    };
    let normal = |target: DVec3| (centre - target) / radius;
    let targets: Vec<DVec3> =
        mesh.positions.iter().enumerate().map(|(v, &p)| if region.contains(v as u32) { lower(p) } else { p }).collect();
    let normals = (0..mesh.num_vertices())
        .map(|v| if region.contains(v as u32) { normal(targets[v]) } else { DVec3::ZERO })
        .collect();
    let boundary_positions: Vec<DVec3> =
        (0..region.points().len() as u32).map(|k| region.point_position(mesh, k)).collect();
    let boundary_targets: Vec<DVec3> = boundary_positions.iter().map(|&p| lower(p)).collect();
    let boundary_normals = boundary_targets.iter().map(|&t| normal(t)).collect();
    ContactZone {
        region,
        targets,
        normals,
        boundary_positions,
        boundary_targets,
        boundary_normals,
        direction: DVec3::Z,
        mapping_direction: DVec3::Z,
    }
}

/// The index of the vertex nearest to `p` (tests only: linear scan).
pub fn nearest_vertex(mesh: &TriMesh, p: DVec3) -> usize {
    let mut best = (0, f64::INFINITY);
    for (v, q) in mesh.positions.iter().enumerate() {
        let d = (*q - p).length_squared();
        if d < best.1 {
            best = (v, d);
        }
    }
    best.0
}

/// A zone given by a level function (𝒞 = {f ≤ 0}, exact points where f = 0) whose targets are the
/// vertices' own positions (no displacement), for the stages that only need the zone's shape.
pub fn region_zone(mesh: &TriMesh, topology: &Topology, f: impl Fn(DVec3) -> f64, direction: DVec3) -> ContactZone {
    let values: Vec<f64> = mesh.positions.iter().map(|&p| f(p)).collect();
    zone_of_region(mesh, EdgeRegion::sublevel_set(topology, &values), direction)
}

/// A zone on `region` whose targets are the vertices' own positions, normals `direction`.
pub fn zone_of_region(mesh: &TriMesh, region: EdgeRegion, direction: DVec3) -> ContactZone {
    let boundary_positions: Vec<DVec3> =
        (0..region.points().len() as u32).map(|k| region.point_position(mesh, k)).collect();
    ContactZone {
        targets: mesh.positions.clone(),
        normals: vec![direction; mesh.num_vertices()],
        boundary_targets: boundary_positions.clone(),
        boundary_normals: vec![direction; boundary_positions.len()],
        boundary_positions,
        region,
        direction,
        mapping_direction: -direction,
    }
}

/// A seeded SplitMix64 generator for reproducible random tests.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// Uniform in [−1, 1).
    pub fn signed(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        2.0 * ((z >> 11) as f64 / (1u64 << 53) as f64) - 1.0
    }
}
