//! Radial parametrization of the deformable region (thesis §5.1, App. B): a smoothed geodesic
//! distance φ from the contact boundary ∂𝒞 by the heat method, `u = φ/φ_max`, and the deformable
//! region 𝒟 = {u < 1} outside 𝒞.
//!
//! Steps (THESIS-NOTES item 4), all on the domain 𝒫 \ 𝒞 (below):
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
//! - **The domain 𝒫 (decision; the thesis solves on the whole working region 𝒲).** Both solves are
//!   global, so where 𝒲 ends changes φ inside 𝒟 a little (the Poisson step integrates −div X over
//!   all of 𝒲): an automatic working region cut around the contact gave results 1.7·10⁻⁵ of the
//!   displacement away from the whole object's. 𝒫 is the set of faces outside 𝒞 whose three
//!   vertices lie within `domain_radius` R (default 2 φ_max) of ∂𝒞 along edges (Dijkstra seeded
//!   at the ends of ∂𝒞's edges with their distance to the boundary point). Edge paths are never
//!   shorter than geodesics, so every vertex of 𝒫 is within R on the surface, and every vertex
//!   within φ_max of ∂𝒞 has full weight unless edge paths are 1.6× longer than geodesics. The
//!   faces' cut-face weights are multiplied by a smoothstep of their farthest vertex's distance, 1
//!   up to 0.8 R and 0 from R on (the same mechanism as the faces inside 𝒞: same pattern, same
//!   symbolic factorization; the factorizations leave the decoupled rows out); vertices of no
//!   weighted face are undetermined (φ = +∞). The result depends only on the mesh within R, so a
//!   region holding that part gives the whole object's φ up to round-off.
//!   **Why 2 φ_max:** the fading faces insulate, which bends X near them; on a grid with
//!   φ_max = 12 edges the largest error of φ in 𝒟 against the exact distance is 1.9% of φ_max
//!   with R = 1.5 φ_max, 0.73% with 2 φ_max, 0.48% with 2.5 φ_max, 0.44% on the whole grid (test
//!   `the_domain_holds_the_deformable_region_and_barely_changes_phi`).
//!   **Why a fade, not a cut:** the edge-path distances move continuously with ∂𝒞 but a face set
//!   does not; with a hard border at 1.5 φ_max (and a Dirichlet condition on it) φ inside 𝒟
//!   jumped by 4.4× the step of a zone sliding across a grid, with the fade by 1.3×. The fading
//!   faces insulate (a natural condition), so the heat step sees no Dirichlet condition there.
//!   `f64::INFINITY` solves on all of 𝒲.
//! - **h.** The heat time uses the given length scale (the pipeline passes the object's mean edge
//!   length, for whole and cut regions alike) or the region's mean edge length; it is returned in
//!   [`Parametrization::edge_length`] for the later stages.
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
use crate::contact::EdgeRegion;
use crate::linalg::{
    ConstraintParams, EdgeConstraint, RightHandSide, cut_face_weights, face_gradients, integrated_divergence,
};
use crate::mesh::{Topology, TriMesh, edge_path_distance_bound, edge_path_distance_field, mean_edge_length};

/// Parameters of the parametrization.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParametrizeParams {
    /// φ_max, the deformation extent (world units).
    pub extent: f64,
    /// The radius of the domain 𝒫 (world units, edge-path distance from ∂𝒞; see the module doc);
    /// `f64::INFINITY` solves on the whole region.
    pub domain_radius: f64,
    /// `t = heat_time_factor·h²`.
    pub heat_time_factor: f64,
    /// h, the length scale of the heat time (and, through [`Parametrization::edge_length`], of the
    /// later stages); `None`: the region's mean edge length.
    pub edge_length: Option<f64>,
    /// Least-squares constraint weight factor (λ = factor × operator scale).
    pub constraint_weight_factor: f64,
}

impl ParametrizeParams {
    /// The defaults for the extent φ_max: the domain within 2 φ_max, `t = 10h²`, λ factor 100,
    /// the region's mean edge length.
    pub fn new(extent: f64) -> Self {
        Self {
            extent,
            domain_radius: crate::ObjectParams::default().domain_factor * extent,
            heat_time_factor: 10.0,
            constraint_weight_factor: crate::linalg::DEFAULT_CONSTRAINT_WEIGHT_FACTOR,
            edge_length: None,
        }
    }
}

/// The radial parametrization of one region for one frame.
#[derive(Clone, Debug)]
pub struct Parametrization {
    /// Per face: the domain's cut-face weights, the area fraction outside 𝒞 for the faces of 𝒫
    /// and 0 for the others.
    pub outside_weights: Vec<f64>,
    /// Per vertex: within the domain radius of ∂𝒞 along edges. 𝒫's faces are those with three
    /// such vertices outside 𝒞; vertices of no such face have φ = u = +∞.
    pub in_domain: Vec<bool>,
    /// The heat-step solution v (empty when there is no contact boundary).
    pub heat: Vec<f64>,
    /// φ, the smoothed geodesic distance from ∂𝒞 (+∞ where undetermined).
    pub distance: Vec<f64>,
    /// `u = max(φ, 0)/φ_max` outside 𝒞, 0 inside 𝒞, +∞ where undetermined.
    pub u: Vec<f64>,
    /// The deformable region 𝒟: outside 𝒞 with `u < 1`.
    pub deformable: Vec<bool>,
    /// h, the length scale used (the region's mean edge length unless given).
    pub edge_length: f64,
    /// Generation of the Poisson factorization left in the solver (0: none).
    pub(crate) generation: u64,
    /// The harmonic diffusion of the zones' directions from ∂𝒞 (x, y and z columns, unnormalized,
    /// §5.2.2), solved in the Poisson step's pass over the factor when the region has several
    /// zone directions; `None` otherwise (the direction field then solves it itself).
    pub(crate) diffused_directions: Option<[Vec<f64>; 3]>,
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
    parametrize_and_diffuse(mesh, topology, solver, contact, params, true)
}

/// [`parametrize`]; with `diffuse_directions` and several zone directions, the direction
/// diffusion's three right-hand sides (which need only ∂𝒞 and the zones' directions, not φ) share
/// the Poisson solve's pass over the factor: one pass fewer per region and frame, and the same
/// bits as solving them later (a column's solve does not depend on the columns beside it).
pub(crate) fn parametrize_and_diffuse(
    mesh: &TriMesh,
    topology: &Topology,
    solver: &mut RegionSolver,
    contact: &ContactSet,
    params: &ParametrizeParams,
    diffuse_directions: bool,
) -> Result<Parametrization, DeformError> {
    solver.check_region(mesh, topology)?;
    if !(params.extent.is_finite() && params.extent > 0.0) {
        return Err(DeformError::InvalidExtent { extent: params.extent });
    }
    if params.domain_radius.is_nan() || params.domain_radius < params.extent {
        return Err(DeformError::InvalidParameter {
            name: "domain radius",
            value: params.domain_radius,
            hint: "the parametrization domain must hold the deformable region: radius ≥ φ_max (default 2 φ_max)",
        });
    }
    let n = mesh.num_vertices();
    DeformError::check_len("contact set (vertices)", n, contact.vertex_zone.len())?;
    let mut outside_weights = cut_face_weights(mesh, topology, contact.region.inside(), contact.region.points())
        .map_err(DeformError::solve("cut-face weights"))?;
    let h = params.edge_length.unwrap_or_else(|| mean_edge_length(mesh, topology));
    if !(h.is_finite() && h > 0.0) {
        return Err(DeformError::DegenerateRegion { mean_edge_length: h });
    }
    if contact.boundary.is_empty() {
        let u: Vec<f64> = (0..n).map(|v| if contact.contains(v as u32) { 0.0 } else { f64::INFINITY }).collect();
        return Ok(Parametrization {
            outside_weights,
            in_domain: vec![false; n],
            heat: Vec::new(),
            distance: u.clone(),
            u,
            deformable: vec![false; n],
            edge_length: h,
            generation: 0,
            diffused_directions: None,
        });
    }
    let constraint_params = ConstraintParams::default().with_weight_factor(params.constraint_weight_factor);

    let in_domain = restrict_to_domain(
        mesh,
        topology,
        contact,
        params.domain_radius,
        &mut outside_weights,
        &mut solver.domain_bound_cooldown,
    );

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
    let mut rhs = vec![RightHandSide { load: Some(&load), ..Default::default() }];
    let components =
        (diffuse_directions && contact.has_several_directions()).then(|| contact.boundary_direction_components());
    rhs.extend(
        components
            .iter()
            .flatten()
            .map(|values| RightHandSide { constraint_values: Some(values), ..Default::default() }),
    );
    let mut columns = poisson.solve_many(&rhs).map_err(DeformError::solve("Poisson"))?.into_iter();
    let mut distance = columns.next().unwrap_or_default();
    let diffused_directions = match (columns.next(), columns.next(), columns.next()) {
        (Some(x), Some(y), Some(z)) => Some([x, y, z]),
        _ => None,
    };
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
    Ok(Parametrization {
        outside_weights,
        in_domain,
        heat,
        distance,
        u,
        deformable,
        edge_length: h,
        generation,
        diffused_directions,
    })
}

/// Fraction of the domain radius where the faces' weights start fading out.
const DOMAIN_TAPER_START: f64 = 0.8;

/// Frames a region skips the breadth-first bound of [`restrict_to_domain`] after it failed.
const DOMAIN_BOUND_COOLDOWN: u32 = 8;

/// Restricts the cut-face weights to the domain 𝒫 (see the module doc): a face whose farthest
/// vertex lies at edge-path distance d from ∂𝒞 (seeded at the ends of ∂𝒞's edges with their
/// distance to the boundary point) keeps its weight up to `0.8·radius`, fades out smoothly to 0
/// at `radius` and has weight 0 beyond. Returns, per vertex, whether it is within `radius`.
///
/// When every vertex ∂𝒞 reaches lies within `0.8·radius` (a domain larger than the region: a
/// small contact on a sphere or a ground plane), no face fades and the distances only tell which
/// vertices are reached: the bounds of a breadth-first search
/// ([`crate::mesh::edge_path_distance_bound`]) then give the same weights and flags, bit for
/// bit, at about a third of Dijkstra's cost. A search that fails (some vertex farther) is wasted,
/// so after a failure the region skips it for [`DOMAIN_BOUND_COOLDOWN`] frames (`cooldown`, kept
/// in its solver): that choice follows earlier frames, but the result is the same either way.
fn restrict_to_domain(
    mesh: &TriMesh,
    topology: &Topology,
    contact: &ContactSet,
    radius: f64,
    weights: &mut [f64],
    cooldown: &mut u32,
) -> Vec<bool> {
    let n = mesh.num_vertices();
    if radius.is_infinite() {
        return vec![true; n];
    }
    let seeds: Vec<(u32, f64)> = contact
        .boundary
        .iter()
        .flat_map(|b| {
            let (i, o) = (b.point.inside, b.point.outside);
            [
                (i, (mesh.positions[i as usize] - b.position).length()),
                (o, (mesh.positions[o as usize] - b.position).length()),
            ]
        })
        .collect();
    let start = DOMAIN_TAPER_START * radius;
    let bound = if *cooldown == 0 {
        let bound = edge_path_distance_bound(mesh, topology, &seeds, start);
        if bound.is_none() {
            *cooldown = DOMAIN_BOUND_COOLDOWN;
        }
        bound
    } else {
        *cooldown -= 1;
        None
    };
    let distance = bound.unwrap_or_else(|| edge_path_distance_field(mesh, topology, &seeds, radius));
    for (tri, w) in mesh.triangles.iter().zip(weights.iter_mut()) {
        let farthest = tri.iter().map(|&v| distance[v as usize]).fold(0.0, f64::max);
        if farthest > start {
            // smoothstep from 1 at `start` to 0 at `radius` (0 beyond, and for unreached faces).
            let x = ((radius - farthest) / (radius - start)).clamp(0.0, 1.0);
            *w *= x * x * (3.0 - 2.0 * x);
        }
    }
    distance.iter().map(|d| d.is_finite()).collect()
}

/// The per-face area fraction inside 𝒟 = (outside 𝒞) ∩ {u < 1} — the diffusion domain of the guide fields (§5.3) and of the
/// parallel-transport field (§5.2.1): cut-face weights of edge regions, so that nothing jumps when
/// ∂𝒟 crosses a vertex.
pub fn deformable_face_weights(
    mesh: &TriMesh,
    topology: &Topology,
    contact: &ContactSet,
    parametrization: &Parametrization,
) -> Result<Vec<f64>, DeformError> {
    DeformError::check_len("parametrization (u)", topology.num_vertices(), parametrization.u.len())?;
    DeformError::check_len("contact set (vertices)", topology.num_vertices(), contact.region.inside().len())?;
    let level: Vec<f64> = parametrization.u.iter().map(|&u| u - 1.0).collect();
    let below_one = EdgeRegion::sublevel_set(topology, &level);
    let deformable = contact.region.complement().intersection(&below_one, topology);
    let removed = deformable.complement();
    cut_face_weights(mesh, topology, removed.inside(), removed.points()).map_err(DeformError::solve("𝒟 face weights"))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::deform::test_support::region_zone;
    use crate::mesh::shapes;
    use glam::{DMat3, DQuat};

    fn params(extent: f64) -> ParametrizeParams {
        ParametrizeParams::new(extent)
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
        let contact = ContactSet::new(mesh, topology, &[&zone]).unwrap();
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
    fn the_breadth_first_bound_of_a_large_domain_gives_dijkstras_weights_bit_for_bit() {
        // A disc contact on a grid, with domains larger than the grid (the bound succeeds) and
        // smaller (it fails and Dijkstra runs): weights and flags equal those of Dijkstra alone.
        let mesh = shapes::grid(4.0, 4.0, 40, 40);
        let topology = Topology::new(&mesh);
        let zone = region_zone(&mesh, &topology, |p| (p - DVec3::new(0.6, -0.3, 0.0)).length() - 0.45, DVec3::Z);
        let contact = ContactSet::new(&mesh, &topology, &[&zone]).unwrap();
        let base: Vec<f64> = (0..mesh.num_triangles()).map(|f| 0.5 + 0.01 * (f % 7) as f64).collect();
        for (radius, bounded) in [(20.0, true), (6.0, true), (3.0, false), (1.2, false)] {
            let (mut by_bound, mut by_dijkstra) = (base.clone(), base.clone());
            let mut cooldown = 0;
            let flags_bound = restrict_to_domain(&mesh, &topology, &contact, radius, &mut by_bound, &mut cooldown);
            assert_eq!(cooldown == 0, bounded, "radius {radius}");
            let mut skip = 1;
            let flags_dijkstra = restrict_to_domain(&mesh, &topology, &contact, radius, &mut by_dijkstra, &mut skip);
            assert_eq!(skip, 0);
            assert_eq!(flags_bound, flags_dijkstra, "radius {radius}");
            let bits = |w: &[f64]| w.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&by_bound), bits(&by_dijkstra), "radius {radius}");
            assert_eq!(by_bound == base, bounded, "radius {radius}: faded faces");
        }
        // After a failure the bound waits DOMAIN_BOUND_COOLDOWN frames, then tries again.
        let mut cooldown = 0;
        let mut weights = base.clone();
        restrict_to_domain(&mesh, &topology, &contact, 1.2, &mut weights, &mut cooldown);
        assert_eq!(cooldown, DOMAIN_BOUND_COOLDOWN);
        for left in (0..DOMAIN_BOUND_COOLDOWN).rev() {
            restrict_to_domain(&mesh, &topology, &contact, 20.0, &mut base.clone(), &mut cooldown);
            assert_eq!(cooldown, left);
        }
        restrict_to_domain(&mesh, &topology, &contact, 20.0, &mut base.clone(), &mut cooldown);
        assert_eq!(cooldown, 0);
    }

    #[test]
    fn the_domain_holds_the_deformable_region_and_barely_changes_phi() {
        let mesh = shapes::grid(4.0, 4.0, 80, 80);
        let topology = Topology::new(&mesh);
        let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
        let (centre, r, extent) = (DVec3::new(0.03, -0.02, 0.0), 0.31, 0.6);
        let zone = region_zone(&mesh, &topology, |p| (p - centre).length() - r, DVec3::Z);
        let contact = ContactSet::new(&mesh, &topology, &[&zone]).unwrap();
        let solve = |solver: &mut RegionSolver, domain_radius: f64| {
            let params = ParametrizeParams { domain_radius, ..params(extent) };
            parametrize(&mesh, &topology, solver, &contact, &params).unwrap()
        };
        let factor = crate::ObjectParams::default().domain_factor;
        let local = solve(&mut solver, factor * extent);
        let whole = solve(&mut solver, f64::INFINITY);
        let (mut worst, mut beyond, mut edge_changes) = (0.0f64, 0, 0);
        let (mut error_local, mut error_whole) = (0.0f64, 0.0f64);
        for (v, q) in mesh.positions.iter().enumerate() {
            let exact = (*q - centre).length() - r;
            if (0.05..extent).contains(&exact) {
                error_local = error_local.max((local.distance[v] - exact).abs() / extent);
                error_whole = error_whole.max((whole.distance[v] - exact).abs() / extent);
            }
            if whole.deformable[v] || local.deformable[v] {
                // φ in 𝒟 moves by a small fraction of φ_max, so 𝒟 changes only at its edge.
                let change = (local.distance[v] - whole.distance[v]).abs() / extent;
                worst = worst.max(change);
                if whole.deformable[v] != local.deformable[v] {
                    assert!((whole.u[v] - 1.0).abs() <= change + 1e-12, "vertex {v} at {exact:.3}");
                    edge_changes += 1;
                }
            }
            if exact > factor * extent + 1e-9 {
                // Beyond the radius (edge paths are longer than straight lines): undetermined.
                assert!(!local.in_domain[v] && local.u[v] == f64::INFINITY, "vertex {v} at {exact:.3}");
                beyond += 1;
            }
        }
        println!(
            "φ in 𝒟 with a domain of {factor} φ_max vs the whole grid: {worst:.2e} of φ_max; {edge_changes} of {} vertices \
             of 𝒟 changed membership; {beyond} vertices beyond the radius",
            whole.num_deformable()
        );
        println!(
            "largest |φ − exact| on 𝒟's annulus / φ_max: {error_local:.2e} (domain), {error_whole:.2e} (whole grid)"
        );
        assert!(worst < 0.01 && beyond > 1000 && edge_changes * 50 <= whole.num_deformable(), "{worst}, {beyond}");
        assert!(whole.in_domain.iter().all(|&d| d));
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
        let mut worst_in_d = 0.0f64;
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
                        if p.u[v] < 1.0 && prev.u[v] < 1.0 {
                            worst_in_d = worst_in_d.max(change / step);
                        }
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
        println!(
            "largest |Δφ| / step while sliding: {worst_ratio:.3} ({worst_in_d:.3} in 𝒟); 𝒞 changed {changes_of_c} times"
        );
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
        let contact = ContactSet::new(&mesh, &topology, &[&zone]).unwrap();
        let reference = parametrize(&mesh, &topology, &mut solver, &contact, &params(0.9)).unwrap();

        let rotation = DMat3::from_quat(DQuat::from_euler(glam::EulerRot::XYZ, 0.4, -1.1, 2.3));
        let shift = DVec3::new(3.0, -7.0, 11.0);
        let mut moved = mesh.clone();
        moved.map_positions(|p| rotation * p + shift);
        let moved_level = |p: DVec3| level(rotation.transpose() * (p - shift));
        let zone = region_zone(&moved, &topology, moved_level, -(rotation * DVec3::Z));
        let contact = ContactSet::new(&moved, &topology, &[&zone]).unwrap();
        let result = parametrize(&moved, &topology, &mut solver, &contact, &params(0.9)).unwrap();
        assert_eq!(result.deformable, reference.deformable);
        let worst = result.u.iter().zip(&reference.u).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "u changed by {worst} under a rigid motion");
        assert!(reference.num_deformable() > 50);
        assert_eq!(solver.symbolic_analyses(), 1);
    }
}
