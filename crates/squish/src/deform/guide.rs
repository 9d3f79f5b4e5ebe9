//! The guiding amplitude and slope fields a and s (thesis §5.3): the value `𝓗(0) = −a` and the
//! slope `𝓗′(0) = s` of each vertex's profile, estimated on ∂𝒞, averaged onto the vertices next to
//! it and diffused over 𝒟.
//!
//! Decisions:
//! - **Signed amplitudes.** `a_ij = ‖p_ij − p′_ij‖·clamp(cos θ / ½, −1, 1)`, θ the angle between
//!   `p_ij − p′_ij` and `d_ij`, the direction at the boundary point (the diffused d̄ interpolated
//!   there, normalized) — [`boundary_amplitude_of`]. Within 60° of d_ij it is the thesis'
//!   `‖p_ij − p′_ij‖` with a sign: `a > 0` is a penetration the zone pushes back, `a < 0` a gap it
//!   closes by moving outward (the thesis' norm loses the sign). With a single mapping direction
//!   the target lies along d_ij and `−a·d_ij = p′_ij − p_ij` exactly. Towards 90° it fades to 0
//!   continuously (a sign switch would jump). Not the plain projection `(p_ij − p′_ij)·d_ij`: it
//!   shortens the amplitude wherever d_ij leaves the target's direction — at a fold's crease
//!   (ch. 6), where d̄ = (2β − 1)d̂ is short and d_ij turns to the normal, the vertices next to
//!   ∂𝒞 would move half as far as their contact neighbours and thin faces turn over (measured on
//!   the bent capsule: `docs/decisions.md`).
//! - **Vertex values.** Every vertex j outside 𝒞 on a boundary edge ij gets `a_j = Σ_i α_ij a_ij /
//!   Σ_i α_ij` (α from the inside vertex, so the points nearest to j weigh most), likewise s_j.
//! - **Soft, fading constraints (continuity).** a_j and s_j are least-squares vertex constraints of
//!   weight `λ·ω_j` with `ω_j = min(1, Σ_i α_ij)`, not hard constraints: when all the boundary
//!   points of j slide to α → 0 (their inside vertices are about to leave 𝒞, and j stops being next
//!   to ∂𝒞), j's constraint fades out instead of switching from constrained to free, which would
//!   make the fields jump. λ = `constraint_weight_factor` (the stiffness scale is 1, App. B).
//! - **Diffusion domain.** Harmonic diffusion over 𝒟 with natural (Neumann) conditions on ∂𝒟 and
//!   ∂𝒞: the stiffness is weighted by the area fraction of each face inside 𝒟 = (outside 𝒞) ∩
//!   {u < 1}, built as edge regions (`sublevel_set(u − 1) ∩ complement(𝒞)`), so nothing jumps when
//!   ∂𝒟 crosses a vertex. Vertices nothing determines (outside 𝒟) are pinned to 0.
//! - **Slope (THESIS-NOTES item 6).** For a boundary edge ij with j outside 𝒞: the target point
//!   `q = p_ij − a_j·d_ij` (offset from 𝒮 by the vertex amplitude, as the thesis does for
//!   stability), plane 1 through q with normal `n′_ij`, plane 2 through p_j with normal
//!   `n̄ = normalize(d_ij × (e_ij × d_ij))` (the plane holding d_ij that is most orthogonal to the
//!   edge `e_ij = p_j − p_i`). `p̃_j = p_j + λ₁n′ + λ₂n̄` is the minimum-norm least-squares point of
//!   both plane equations, `(AAᵀ + ε²I)λ = (n′·(q − p_j), 0)` with `A = [n′; n̄]` and ε² = 10⁻⁶: the
//!   exact intersection closest to p_j when the planes cross, their midway when they are parallel,
//!   continuous in between (a damped pseudo-inverse). Then `s_ij = ((p̃_j − p_j)·d_j + a_j)/u_j` from
//!   `p̃_j = p_j + (−a_j + u_j s_ij)d_j`, with a_j the vertex amplitude (its α-weighted average,
//!   the amplitude constraint at j) and d_j the blended direction at j. a and s then share one
//!   factorization and one two-column solve. (The diffused a_j differs from the average by the
//!   O(1/λ) residual of the soft constraint; using it would cost a second solve.)
//! - **Small u.** The division uses `max(u_j, 10⁻⁶)`: continuous, bounded, and a vertex that close
//!   to ∂𝒞 moves by `−a_j + u_j s_j`, insensitive to s_j. The numerator vanishes with the distance
//!   to ∂𝒞 as well (q is offset by a_j for that reason), so s stays O(1) as u_j → 0.
//! - **Slope confidence.** In practice the estimate is ill-conditioned for a vertex very close to
//!   ∂𝒞: the numerator is a small difference of plane offsets divided by a small u_j, and single
//!   vertices spiked to 25× the typical slope just before entering 𝒞, which the diffusion spread
//!   to their neighbours as frame-to-frame jumps of 10× the input's motion. Each vertex value is
//!   therefore blended toward the confidence-weighted mean slope, with the confidence
//!   `smoothstep(dist_j / h)` (h the mean edge length, dist_j = u_j·φ_max): a vertex a full edge
//!   from ∂𝒞 keeps its own estimate, one on ∂𝒞 takes the mean. Both are continuous, so the field
//!   stays continuous; the slope still matches 𝒮 along ∂𝒞 through the confident vertices.
//!   The blend only ever *lowers* a slope (`min(s_j, blended)`): the spikes it exists for are too
//!   steep, while raising a shallow estimate next to ∂𝒞 toward a steep mean folded faces when the
//!   direction field tilts far from the normal (a capsule 0.4 deep in a sphere, transported field
//!   38° off the normal: 2 faces flipped; see `method_a_tests`). Still continuous (min of two
//!   continuous functions).
//! - A boundary point whose 𝒮 normal is zero gets `s_ij = 0`.

use glam::DVec3;

use super::contact_set::ContactSet;
use super::direction_field::DirectionField;
use super::parametrize::{Parametrization, deformable_face_weights};
use super::{DeformError, RegionSolver};
use crate::linalg::SolveError;
use crate::mesh::{Topology, TriMesh};

/// u below which the slope division is clamped (see the module doc).
pub const MIN_SLOPE_U: f64 = 1e-6;

/// Damping ε² of the two-plane least-squares solve.
const PLANE_DAMPING: f64 = 1e-6;

/// Parameters of the guide fields.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuideParams {
    /// λ of the soft vertex constraints (App. B: 100).
    pub constraint_weight_factor: f64,
}

/// A vertex next to ∂𝒞 with its averaged value and constraint weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundaryVertex {
    /// The vertex (outside 𝒞).
    pub vertex: u32,
    /// `ω = min(1, Σ_i α_ij)`.
    pub weight: f64,
    /// `Σ_i α_ij x_ij / Σ_i α_ij` (the plain mean when every α is 0).
    pub value: f64,
}

/// The amplitude and slope fields of one region for one frame.
#[derive(Clone, Debug)]
pub struct GuideFields {
    /// a per vertex (diffused over 𝒟; 0 where undetermined).
    pub amplitude: Vec<f64>,
    /// s per vertex (diffused over 𝒟; 0 where undetermined).
    pub slope: Vec<f64>,
    /// a_ij per boundary point of ∂𝒞.
    pub boundary_amplitude: Vec<f64>,
    /// s_ij per boundary point of ∂𝒞.
    pub boundary_slope: Vec<f64>,
    /// The constrained vertices with their averaged amplitude.
    pub amplitude_constraints: Vec<BoundaryVertex>,
    /// The constrained vertices with their averaged slope.
    pub slope_constraints: Vec<BoundaryVertex>,
    /// Per face: the area fraction inside 𝒟.
    pub deformable_weights: Vec<f64>,
    /// Number of boundary vertices whose slope division was clamped (u < 10⁻⁶).
    pub clamped_slopes: usize,
}

/// Below this cosine between `p − p′` and the direction at a boundary point, the amplitude fades
/// from the whole distance ‖p − p′‖ to 0 (see [`boundary_amplitude_of`]).
pub const FULL_AMPLITUDE_COSINE: f64 = 0.5;

/// The amplitude a_ij of a boundary point whose target is `p′ = p − offset` and whose
/// direction is the unit `d` (see the module doc, "Signed amplitudes"):
/// `‖offset‖ · clamp(cos θ / c, −1, 1)` with θ the angle between `offset` and `d` and
/// c = [`FULL_AMPLITUDE_COSINE`]. Within 60° of d it is the thesis' ‖p − p′‖ with the sign of
/// the penetration; towards 90° it fades continuously to 0 (a sign switch at 90° would jump).
/// With a single mapping direction, offset ∥ d and this is `offset·d` exactly.
pub fn boundary_amplitude_of(offset: DVec3, d: DVec3) -> f64 {
    let length = offset.length();
    if length == 0.0 || !length.is_finite() {
        return offset.dot(d);
    }
    length * (offset.dot(d) / (length * FULL_AMPLITUDE_COSINE)).clamp(-1.0, 1.0)
}

/// The α-weighted averages of per-boundary-point `values` onto the outside vertices of ∂𝒞, in
/// increasing vertex id, with their constraint weights `min(1, Σα)` (points on vertices beyond
/// `num_vertices` are ignored).
pub fn boundary_averages(num_vertices: usize, contact: &ContactSet, values: &[f64]) -> Vec<BoundaryVertex> {
    let mut alpha_sum = vec![0.0; num_vertices];
    let mut weighted_sum = vec![0.0; num_vertices];
    let mut plain_sum = vec![0.0; num_vertices];
    let mut count = vec![0u32; num_vertices];
    for (b, &x) in contact.boundary.iter().zip(values) {
        let j = b.point.outside as usize;
        if j >= num_vertices {
            continue;
        }
        alpha_sum[j] += b.point.alpha;
        weighted_sum[j] += b.point.alpha * x;
        plain_sum[j] += x;
        count[j] += 1;
    }
    (0..num_vertices)
        .filter(|&j| count[j] > 0)
        .map(|j| {
            let value =
                if alpha_sum[j] > 0.0 { weighted_sum[j] / alpha_sum[j] } else { plain_sum[j] / count[j] as f64 };
            BoundaryVertex { vertex: j as u32, weight: alpha_sum[j].min(1.0), value }
        })
        .collect()
}

/// The slope estimate `s_ij` at one boundary edge (see the module doc).
#[allow(clippy::too_many_arguments)]
pub fn boundary_slope(
    p_i: DVec3,
    p_j: DVec3,
    boundary_position: DVec3,
    surface_normal: DVec3,
    boundary_direction: DVec3,
    vertex_direction: DVec3,
    vertex_amplitude: f64,
    vertex_u: f64,
) -> f64 {
    let n1 = surface_normal.normalize_or_zero();
    if n1 == DVec3::ZERO {
        return 0.0;
    }
    let d = boundary_direction;
    let q = boundary_position - vertex_amplitude * d;
    let n2 = d.cross((p_j - p_i).cross(d)).normalize_or_zero();
    let rho = n1.dot(q - p_j);
    let c = n1.dot(n2);
    let g = n2.length_squared();
    let det = (1.0 + PLANE_DAMPING) * (g + PLANE_DAMPING) - c * c;
    let lambda1 = rho * (g + PLANE_DAMPING) / det;
    let lambda2 = -rho * c / det;
    let offset = lambda1 * n1 + lambda2 * n2;
    (offset.dot(vertex_direction) + vertex_amplitude) / vertex_u.max(MIN_SLOPE_U)
}

/// C¹ step from 0 at x ≤ 0 to 1 at x ≥ 1.
fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// Blends each vertex slope toward the confidence-weighted mean of all of them, by how far the
/// vertex lies from ∂𝒞 (see the module doc, "Slope confidence").
fn confident_slopes(parametrization: &Parametrization, constraints: &mut [BoundaryVertex]) {
    let h = parametrization.edge_length;
    if h.is_nan() || h <= 0.0 {
        return;
    }
    let confidence: Vec<f64> = constraints
        .iter()
        .map(|c| {
            let d = parametrization.distance.get(c.vertex as usize).copied().unwrap_or(0.0);
            if d.is_finite() { smoothstep(d / h) } else { 0.0 }
        })
        .collect();
    let (mut sum, mut total) = (0.0, 0.0);
    for (c, &k) in constraints.iter().zip(&confidence) {
        sum += c.weight * k * c.value;
        total += c.weight * k;
    }
    if total.is_nan() || total <= 0.0 {
        return;
    }
    let mean = sum / total;
    for (c, &k) in constraints.iter_mut().zip(&confidence) {
        c.value = c.value.min(k * c.value + (1.0 - k) * mean);
    }
}

/// Computes a and s over 𝒟 (see the module doc).
pub fn guide_fields(
    mesh: &TriMesh,
    topology: &Topology,
    solver: &mut RegionSolver,
    contact: &ContactSet,
    parametrization: &Parametrization,
    field: &DirectionField,
    params: &GuideParams,
) -> Result<GuideFields, DeformError> {
    let n = mesh.num_vertices();
    DeformError::check_len("contact set (vertices)", n, contact.vertex_zone.len())?;
    DeformError::check_len("parametrization (u)", n, parametrization.u.len())?;
    DeformError::check_len("direction field", n, field.directions.len())?;
    DeformError::check_len("boundary directions", contact.boundary.len(), field.boundary.len())?;
    let boundary_amplitude: Vec<f64> = contact
        .boundary
        .iter()
        .zip(&field.boundary)
        .map(|(b, d)| boundary_amplitude_of(b.position - b.target, *d))
        .collect();
    let amplitude_constraints = boundary_averages(n, contact, &boundary_amplitude);
    let deformable_weights = deformable_face_weights(mesh, topology, contact, parametrization)?;
    if amplitude_constraints.is_empty() {
        return Ok(GuideFields {
            amplitude: vec![0.0; n],
            slope: vec![0.0; n],
            boundary_amplitude,
            boundary_slope: Vec::new(),
            amplitude_constraints,
            slope_constraints: Vec::new(),
            deformable_weights,
            clamped_slopes: 0,
        });
    }
    // The vertex amplitude a_j of every boundary vertex (its averaged value, the constraint of the
    // amplitude diffusion).
    let mut vertex_amplitude = vec![0.0; n];
    for c in &amplitude_constraints {
        vertex_amplitude[c.vertex as usize] = c.value;
    }
    let mut clamped_slopes = 0;
    let boundary_slope: Vec<f64> = contact
        .boundary
        .iter()
        .zip(&field.boundary)
        .map(|(b, &d)| {
            let (i, j) = (b.point.inside as usize, b.point.outside as usize);
            boundary_slope(
                mesh.positions[i],
                mesh.positions[j],
                b.position,
                b.normal,
                d,
                field.directions[j],
                vertex_amplitude[j],
                parametrization.u[j],
            )
        })
        .collect();
    let mut slope_constraints = boundary_averages(n, contact, &boundary_slope);
    confident_slopes(parametrization, &mut slope_constraints);
    for c in &slope_constraints {
        if parametrization.u[c.vertex as usize] < MIN_SLOPE_U {
            clamped_slopes += 1;
        }
    }
    // Both fields on one factorization, in one two-column solve.
    let weighted: Vec<(u32, f64)> = amplitude_constraints.iter().map(|c| (c.vertex, c.weight)).collect();
    let amplitude_values: Vec<f64> = amplitude_constraints.iter().map(|c| c.value).collect();
    let slope_values: Vec<f64> = slope_constraints.iter().map(|c| c.value).collect();
    let system = solver.factorize_guide(
        mesh,
        &deformable_weights,
        &weighted,
        params.constraint_weight_factor,
        parametrization.generation,
    )?;
    let columns =
        system.solve(&weighted, &[&amplitude_values, &slope_values]).map_err(DeformError::solve("guide diffusion"))?;
    let [amplitude, slope]: [Vec<f64>; 2] =
        columns.try_into().map_err(|columns: Vec<Vec<f64>>| DeformError::Solve {
            stage: "guide diffusion",
            source: SolveError::DimensionMismatch { what: "solution columns", expected: 2, actual: columns.len() },
        })?;
    Ok(GuideFields {
        amplitude,
        slope,
        boundary_amplitude,
        boundary_slope,
        amplitude_constraints,
        slope_constraints,
        deformable_weights,
        clamped_slopes,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::contact::{ContactZone, EdgeRegion};
    use crate::deform::direction_field::{DirectionParams, direction_field};
    use crate::deform::parametrize::{ParametrizeParams, parametrize};
    use crate::deform::test_support::plane_zone;
    use crate::mesh::{shapes, vertex_normals};
    use crate::params::DirectionFieldMethod;

    fn run(mesh: &TriMesh, zones: &[&ContactZone], extent: f64) -> (ContactSet, Parametrization, GuideFields) {
        let topology = Topology::new(mesh);
        let mut solver = RegionSolver::new(mesh, &topology).unwrap();
        let contact = ContactSet::new(mesh, &topology, zones).unwrap();
        let params = ParametrizeParams::new(extent);
        let p = parametrize(mesh, &topology, &mut solver, &contact, &params).unwrap();
        let options =
            DirectionParams { method: DirectionFieldMethod::Blended, normalize_diffused: true, mapping_field: None };
        let field = direction_field(mesh, &mut solver, &contact, &p, &vertex_normals(mesh), &options).unwrap();
        let guide = guide_fields(
            mesh,
            &topology,
            &mut solver,
            &contact,
            &p,
            &field,
            &GuideParams { constraint_weight_factor: 100.0 },
        )
        .unwrap();
        (contact, p, guide)
    }

    #[test]
    fn boundary_amplitudes_are_the_distance_near_the_direction_and_fade_continuously_to_zero() {
        let d = DVec3::Z;
        // Along d: the signed projection, exactly.
        assert_eq!(boundary_amplitude_of(DVec3::new(0.0, 0.0, 0.3), d), 0.3);
        assert_eq!(boundary_amplitude_of(DVec3::new(0.0, 0.0, -0.3), d), -0.3);
        // Within 60°: the whole distance, with the sign of the projection.
        for degrees in [0.0f64, 20.0, 45.0, 59.9] {
            let (s, c) = degrees.to_radians().sin_cos();
            let a = boundary_amplitude_of(0.3 * DVec3::new(s, 0.0, c), d);
            assert!((a - 0.3).abs() < 1e-12, "{degrees}°: {a}");
            let b = boundary_amplitude_of(0.3 * DVec3::new(s, 0.0, -c), d);
            assert!((b + 0.3).abs() < 1e-12, "{degrees}°: {b}");
        }
        // Continuous through 90° (0 there) and through 60°.
        let at = |degrees: f64| {
            let (s, c) = degrees.to_radians().sin_cos();
            boundary_amplitude_of(0.3 * DVec3::new(s, 0.0, c), d)
        };
        assert!(at(90.0).abs() < 1e-12);
        for x in [60.0, 90.0] {
            assert!((at(x + 1e-6) - at(x - 1e-6)).abs() < 1e-6, "jump at {x}°");
        }
        assert!(at(75.0) > 0.0 && at(75.0) < 0.3 && at(105.0) < 0.0);
        assert_eq!(boundary_amplitude_of(DVec3::ZERO, d), 0.0);
    }

    #[test]
    fn a_rigid_plane_gives_zero_amplitude_and_the_slope_of_the_sphere_at_the_contact_circle() {
        let mesh = shapes::uv_sphere(1.0, 64, 48);
        let topology = Topology::new(&mesh);
        let c = -0.8;
        let zone = plane_zone(&mesh, &topology, DVec3::Z, c);
        let extent = 0.6;
        let (_, p, guide) = run(&mesh, &[&zone], extent);
        assert!(guide.boundary_amplitude.iter().all(|a| a.abs() < 1e-14), "boundary points lie on the plane");
        let a_max = guide.amplitude.iter().fold(0.0f64, |m, a| m.max(a.abs()));
        assert!(a_max < 1e-12, "{a_max}");
        // The sphere rises above the plane at rate r_c per unit of geodesic distance, and
        // u = distance/extent: s ≈ r_c·extent (d = −z is outward, so moving down is positive).
        let expected = (1.0 - c * c).sqrt() * extent;
        let mut worst = 0.0f64;
        for v in 0..mesh.num_vertices() {
            if p.deformable[v] && p.u[v] < 0.5 {
                worst = worst.max((guide.slope[v] - expected).abs() / expected);
            }
        }
        println!("largest relative deviation of s from r_c·extent on u < 0.5: {worst:.3}");
        assert!(worst < 0.15, "{worst}");
        assert_eq!(guide.clamped_slopes, 0);
    }

    #[test]
    fn signed_amplitudes_follow_the_penetration_and_the_gap() {
        let mesh = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&mesh);
        for offset in [0.05, -0.03] {
            // Targets pushed inwards (penetration a > 0) or outwards (a gap, a < 0) by `offset`
            // along the zone's direction d̄ = −z.
            let mut zone = plane_zone(&mesh, &topology, DVec3::Z, -0.85);
            for t in &mut zone.boundary_targets {
                *t += offset * DVec3::Z;
            }
            for t in &mut zone.targets {
                *t += offset * DVec3::Z;
            }
            let (_, p, guide) = run(&mesh, &[&zone], 0.7);
            for a in &guide.boundary_amplitude {
                assert!((a - offset).abs() < 1e-12, "{a} vs {offset}");
            }
            for v in 0..mesh.num_vertices() {
                if p.deformable[v] {
                    assert!((guide.amplitude[v] - offset).abs() < 1e-9, "{} vs {offset}", guide.amplitude[v]);
                }
            }
        }
    }

    #[test]
    fn boundary_weights_fade_with_alpha() {
        let mesh = shapes::grid(1.0, 1.0, 10, 10);
        let topology = Topology::new(&mesh);
        // A zone holding the centre vertex only, its boundary points at α from it.
        let centre = crate::deform::test_support::nearest_vertex(&mesh, DVec3::ZERO) as u32;
        for alpha in [0.5, 0.1, 1e-3, 0.0] {
            let mut inside = vec![false; mesh.num_vertices()];
            inside[centre as usize] = true;
            let region = EdgeRegion::from_inside(&topology, inside, |_, _, _| alpha);
            let zone = crate::deform::test_support::zone_of_region(&mesh, region, DVec3::Z);
            let contact = ContactSet::new(&mesh, &topology, &[&zone]).unwrap();
            let values: Vec<f64> = (0..contact.boundary.len()).map(|k| k as f64).collect();
            let averages = boundary_averages(mesh.num_vertices(), &contact, &values);
            assert_eq!(averages.len(), contact.boundary.len(), "one boundary point per neighbour");
            for (c, b) in averages.iter().zip(&contact.boundary) {
                assert_eq!(c.vertex, b.point.outside);
                assert_eq!(c.weight, alpha.min(1.0));
            }
        }
    }

    #[test]
    fn slope_of_parallel_planes_is_finite_bounded_and_continuous() {
        // An edge along d leaves plane 2 undefined: only the surface plane counts.
        let (pi, pj) = (DVec3::ZERO, DVec3::new(0.0, 0.0, 0.1));
        let along = boundary_slope(pi, pj, DVec3::new(0.0, 0.0, 0.05), DVec3::Z, DVec3::Z, DVec3::Z, 0.0, 0.1);
        assert!((along - -0.5).abs() < 1e-5, "p̃ on the surface plane 0.05 below p_j: {along}");
        // A surface normal orthogonal to d makes the planes parallel. Exactly parallel: p̃ midway
        // between them (no motion along d), so s = a/u. Nearly parallel: finite, bounded by the
        // damping (|p̃ − p_j| ≤ |ρ|/(2ε)), and continuous through the parallel configuration.
        let slope = |tilt: f64| {
            let normal = DVec3::new(1.0, 0.0, tilt).normalize();
            boundary_slope(DVec3::ZERO, DVec3::X * 0.1, DVec3::X * 0.05, normal, DVec3::Z, DVec3::Z, 0.01, 0.1)
        };
        assert!((slope(0.0) - 0.1).abs() < 1e-9, "{}", slope(0.0));
        let bound = (0.05 / (2.0 * PLANE_DAMPING.sqrt()) + 0.01) / 0.1;
        let mut previous = slope(-1e-5);
        for k in -100..=100 {
            let s = slope(k as f64 * 1e-7);
            assert!(s.is_finite() && s.abs() <= bound, "{s}");
            assert!((s - previous).abs() < 0.1, "{k}: {previous} → {s}");
            previous = s;
        }
    }
}
