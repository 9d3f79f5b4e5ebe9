//! Radial parametrization of the deformable region (thesis §5.1, App. B): a smoothed geodesic
//! distance φ from the contact boundary ∂𝒞 by the heat method, `u = φ/φ_max`, and the deformable
//! region 𝒟 = {u < 1} outside 𝒞.
//!
//! Steps (THESIS-NOTES item 4), all on the domain 𝒲 \ 𝒞:
//! 1. heat step `(M_w + tK_w)v = 0`, `t = heat_time_factor·h²` (h: the region's mean edge length),
//!    with the least-squares edge constraints `(1 − α_ij)v_i + α_ij v_j = 1` on every boundary point
//!    of ∂𝒞 and `v = 0` vertex constraints on the region's outer boundary vertices outside 𝒞, if it
//!    has any (Dirichlet on ∂𝒲, as the thesis recommends over Neumann);
//! 2. `X = −∇v/|∇v|` on every face with `w_f > 0` and `|∇v| > 0` (0 elsewhere);
//! 3. Poisson `K_w φ = −div_w X` (our convention `div(grad u) = −K u`, so this is the thesis'
//!    `Δφ = ∇·X` and φ grows away from ∂𝒞 since X points away from the heat source), with the
//!    least-squares constraints `φ = 0` on the same ∂𝒞 points and natural conditions elsewhere.
//!
//! `w_f` is the area fraction of face f outside 𝒞 (cut-face weights, App. B), so the operators and
//! the divergence vary continuously when ∂𝒞 crosses a vertex.
//!
//! Decisions:
//! - **u near ∂𝒞.** The least-squares constraints leave φ slightly negative at some vertices just
//!   outside ∂𝒞. Such a vertex is still in 𝒟 with `u = 0` (φ is clamped at 0), so it moves by
//!   𝓗(0) like its neighbours: excluding it (the literal `0 < u`) would leave it behind, a jump.
//! - **Unreachable vertices.** A vertex outside 𝒞 that the Poisson system leaves undetermined (a
//!   component of the region that 𝒞 does not touch) gets `φ = u = +∞`: it is not in 𝒟.
//! - Inside 𝒞, `u` is reported as 0 (φ keeps the solver's extrapolated value).
//! - A region without contact boundary (no zone, or a zone covering whole components) has no 𝒟:
//!   no system is solved.

use glam::DVec3;

use super::contact_set::ContactSet;
use super::{DeformError, RegionSolver};
use crate::linalg::{
    ConstraintParams, EdgeConstraint, RightHandSide, cut_face_weights, face_gradients, integrated_divergence,
};
use crate::mesh::{Topology, TriMesh, mean_edge_length};

/// Parameters of the parametrization.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParametrizeParams {
    /// φ_max, the deformation extent (world units).
    pub extent: f64,
    /// `t = heat_time_factor·h²`.
    pub heat_time_factor: f64,
    /// Least-squares constraint weight factor (λ = factor × operator scale).
    pub constraint_weight_factor: f64,
}

/// The radial parametrization of one region for one frame.
#[derive(Clone, Debug)]
pub struct Parametrization {
    /// Per face: the area fraction outside 𝒞 (the domain's cut-face weights).
    pub outside_weights: Vec<f64>,
    /// The heat-step solution v (empty when there is no contact boundary).
    pub heat: Vec<f64>,
    /// φ, the smoothed geodesic distance from ∂𝒞 (+∞ where undetermined).
    pub distance: Vec<f64>,
    /// `u = max(φ, 0)/φ_max` outside 𝒞, 0 inside 𝒞, +∞ where undetermined.
    pub u: Vec<f64>,
    /// The deformable region 𝒟: outside 𝒞 with `u < 1`.
    pub deformable: Vec<bool>,
    /// Generation of the Poisson factorization left in the solver (0: none).
    pub(crate) generation: u64,
}

impl Parametrization {
    /// Number of vertices in 𝒟.
    pub fn num_deformable(&self) -> usize {
        self.deformable.iter().filter(|&&d| d).count()
    }
}

/// Computes φ, u and 𝒟 for the region `mesh` with contact set `contact` (see the module doc).
/// Leaves the Poisson factorization in `solver` for the direction diffusion.
pub fn parametrize(
    mesh: &TriMesh,
    topology: &Topology,
    solver: &mut RegionSolver,
    contact: &ContactSet,
    params: &ParametrizeParams,
) -> Result<Parametrization, DeformError> {
    solver.check_region(mesh, topology)?;
    if !(params.extent.is_finite() && params.extent > 0.0) {
        return Err(DeformError::InvalidExtent { extent: params.extent });
    }
    let n = mesh.num_vertices();
    DeformError::check_len("contact set (vertices)", n, contact.vertex_zone.len())?;
    let outside_weights = cut_face_weights(mesh, topology, contact.region.inside(), contact.region.points())
        .map_err(DeformError::solve("cut-face weights"))?;
    if contact.boundary.is_empty() {
        let u: Vec<f64> = (0..n).map(|v| if contact.contains(v as u32) { 0.0 } else { f64::INFINITY }).collect();
        return Ok(Parametrization {
            outside_weights,
            heat: Vec::new(),
            distance: u.clone(),
            u,
            deformable: vec![false; n],
            generation: 0,
        });
    }
    let h = mean_edge_length(mesh, topology);
    if !(h.is_finite() && h > 0.0) {
        return Err(DeformError::DegenerateRegion { mean_edge_length: h });
    }
    let constraint_params = ConstraintParams::default().with_weight_factor(params.constraint_weight_factor);

    // 1. Heat step: v = 1 on ∂𝒞, v = 0 on the outer boundary outside 𝒞; Poisson: φ = 0 on ∂𝒞.
    let mut constraints: Vec<EdgeConstraint> = contact
        .boundary
        .iter()
        .map(|b| EdgeConstraint::on_edge(b.point.inside, b.point.outside, b.point.alpha, 1.0))
        .collect();
    for (v, &on_boundary) in solver.outer_boundary().iter().enumerate() {
        if on_boundary && !contact.contains(v as u32) {
            constraints.push(EdgeConstraint::vertex(v as u32, 0.0));
        }
    }
    let poisson_constraints: Vec<EdgeConstraint> =
        constraints[..contact.boundary.len()].iter().map(|c| EdgeConstraint { value: 0.0, ..*c }).collect();
    let time = params.heat_time_factor * h * h;
    let generation = solver.factorize_distance_systems(
        mesh,
        &outside_weights,
        time,
        &constraints,
        &poisson_constraints,
        &constraint_params,
    )?;
    // Undetermined vertices (inside 𝒞, no kept face) take the source value.
    let heat = solver
        .heat(generation)?
        .solve(&RightHandSide { pin_value: 1.0, ..Default::default() })
        .map_err(DeformError::solve("heat"))?;

    // 2. Normalized, reversed gradient on the kept faces.
    let mut field = face_gradients(mesh, &heat).map_err(DeformError::solve("heat gradient"))?;
    for (x, &w) in field.iter_mut().zip(&outside_weights) {
        *x = if w > 0.0 { -x.normalize_or_zero() } else { DVec3::ZERO };
    }

    // 3. Poisson: K_w φ = −div_w X with φ = 0 on ∂𝒞 (factorized together with the heat step).
    let mut load =
        integrated_divergence(mesh, &field, Some(&outside_weights)).map_err(DeformError::solve("divergence"))?;
    for x in &mut load {
        *x = -*x;
    }
    let poisson = solver.poisson(generation, "Poisson")?;
    let mut distance = poisson
        .solve(&RightHandSide { load: Some(&load), ..Default::default() })
        .map_err(DeformError::solve("Poisson"))?;
    for &v in poisson.system().pinned_vertices() {
        if !contact.contains(v) {
            distance[v as usize] = f64::INFINITY;
        }
    }

    let mut u = vec![0.0; n];
    let mut deformable = vec![false; n];
    for v in 0..n {
        if contact.contains(v as u32) {
            continue;
        }
        u[v] = distance[v].max(0.0) / params.extent;
        deformable[v] = u[v] < 1.0;
    }
    Ok(Parametrization { outside_weights, heat, distance, u, deformable, generation })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::deform::test_support::region_zone;
    use crate::mesh::shapes;
    use glam::{DMat3, DQuat};

    fn params(extent: f64) -> ParametrizeParams {
        ParametrizeParams { extent, heat_time_factor: 10.0, constraint_weight_factor: 100.0 }
    }

    /// A grid and the parametrization from a disc zone of radius `r` at `centre`.
    fn disc_parametrization(
        mesh: &TriMesh,
        topology: &Topology,
        solver: &mut RegionSolver,
        centre: DVec3,
        r: f64,
        extent: f64,
    ) -> Parametrization {
        let zone = region_zone(mesh, topology, |p| (p - centre).length() - r, DVec3::Z);
        let contact = ContactSet::new(mesh, topology, &[zone]).unwrap();
        parametrize(mesh, topology, solver, &contact, &params(extent)).unwrap()
    }

    #[test]
    fn distance_from_a_circle_on_a_flat_grid_is_nearly_euclidean() {
        let mesh = shapes::grid(3.0, 3.0, 60, 60);
        let topology = Topology::new(&mesh);
        let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
        let (centre, r) = (DVec3::new(0.03, -0.02, 0.0), 0.31);
        let p = disc_parametrization(&mesh, &topology, &mut solver, centre, r, 0.8);
        let mut worst = 0.0f64;
        let mut inside_d = 0;
        for (v, q) in mesh.positions.iter().enumerate() {
            let exact = (*q - centre).length() - r;
            if (0.1..0.8).contains(&exact) {
                worst = worst.max((p.distance[v] - exact).abs() / exact);
            }
            if p.deformable[v] {
                inside_d += 1;
                assert!(exact > -1e-9 && exact < 0.85, "vertex {v} at distance {exact} is in 𝒟");
            }
        }
        println!("largest relative error of φ on the annulus 0.1..0.8: {worst:.4}; |𝒟| = {inside_d}");
        assert!(worst < 0.04, "relative distance error {worst}");
        // φ grows away from ∂𝒞 (the Poisson sign).
        let near = mesh.positions.iter().position(|q| ((*q - centre).length() - r - 0.1).abs() < 0.02).unwrap();
        let far = mesh.positions.iter().position(|q| ((*q - centre).length() - r - 0.6).abs() < 0.02).unwrap();
        assert!(p.u[far] > p.u[near] + 0.4);
    }

    #[test]
    fn u_is_continuous_while_the_zone_slides_across_vertices() {
        let mesh = shapes::grid(2.0, 2.0, 40, 40);
        let topology = Topology::new(&mesh);
        let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
        let (step, extent) = (1e-3, 0.6);
        let mut previous: Option<Parametrization> = None;
        let mut worst_ratio = 0.0f64;
        let mut changes_of_c = 0;
        let mut previous_inside = None;
        for k in 0..200 {
            let centre = DVec3::new(-0.1 + k as f64 * step, 0.37 * k as f64 * step, 0.0);
            let p = disc_parametrization(&mesh, &topology, &mut solver, centre, 0.3, extent);
            let inside: Vec<bool> = p.u.iter().zip(&p.deformable).map(|(&u, &d)| u == 0.0 && !d).collect();
            if let Some(prev) = &previous {
                for v in 0..mesh.num_vertices() {
                    // Compare φ wherever it is defined in both frames (outside 𝒞 in both).
                    let was_inside = previous_inside.as_ref().is_some_and(|i: &Vec<bool>| i[v]);
                    if prev.u[v].is_finite() && p.u[v].is_finite() && !inside[v] && !was_inside {
                        let change = (p.u[v] - prev.u[v]).abs() * extent;
                        worst_ratio = worst_ratio.max(change / step);
                    }
                }
            }
            if previous_inside.as_ref().is_some_and(|i| *i != inside) {
                changes_of_c += 1;
            }
            previous_inside = Some(inside);
            previous = Some(p);
        }
        println!("largest |Δφ| / step while sliding: {worst_ratio:.3}; 𝒞 changed {changes_of_c} times");
        assert!(changes_of_c >= 10, "the sweep must move ∂𝒞 across vertices ({changes_of_c})");
        assert!(worst_ratio < 3.0, "φ jumped: |Δφ| = {worst_ratio} × step");
    }

    #[test]
    fn parametrization_is_invariant_under_rigid_motions() {
        let mesh = shapes::icosphere(1.0, 3);
        let topology = Topology::new(&mesh);
        let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
        let level = |p: DVec3| p.dot(DVec3::new(0.2, -0.1, 1.0).normalize()) + 0.71;
        let zone = region_zone(&mesh, &topology, level, -DVec3::Z);
        let contact = ContactSet::new(&mesh, &topology, &[zone]).unwrap();
        let reference = parametrize(&mesh, &topology, &mut solver, &contact, &params(0.9)).unwrap();

        let rotation = DMat3::from_quat(DQuat::from_euler(glam::EulerRot::XYZ, 0.4, -1.1, 2.3));
        let shift = DVec3::new(3.0, -7.0, 11.0);
        let mut moved = mesh.clone();
        moved.map_positions(|p| rotation * p + shift);
        let moved_level = |p: DVec3| level(rotation.transpose() * (p - shift));
        let zone = region_zone(&moved, &topology, moved_level, -(rotation * DVec3::Z));
        let contact = ContactSet::new(&moved, &topology, &[zone]).unwrap();
        let result = parametrize(&moved, &topology, &mut solver, &contact, &params(0.9)).unwrap();
        assert_eq!(result.deformable, reference.deformable);
        let worst = result.u.iter().zip(&reference.u).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "u changed by {worst} under a rigid motion");
        assert!(reference.num_deformable() > 50);
        assert_eq!(solver.symbolic_analyses(), 1);
    }
}
