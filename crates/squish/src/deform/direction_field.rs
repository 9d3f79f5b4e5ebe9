//! The displacement direction field d (thesis §5.2), method B's blended field (§5.2.2, Eq. 5.4).
//!
//! 1. The mapping field d̄: with one zone direction (one zone, or several pushing the same way) it
//!    is that direction everywhere. With several, each component of d̄ is diffused harmonically
//!    with the least-squares constraints `d̄ = d̄_k` on the boundary points of ∂𝒞_k and natural
//!    conditions elsewhere: the matrix is the Poisson matrix `K_w + λCᵀC` of the parametrization,
//!    so its factorization is reused (three right-hand sides, no new factorization).
//! 2. `d_i = normalize(w(u_i)·d̄_i + (1 − w(u_i))·n_i)` on 𝒟, `w(u) = (1 − u²)⁶` (THESIS-NOTES
//!    item 10: d̄ at ∂𝒞, the normal n at ∂𝒟, a fast asymmetric transition), n the area-weighted
//!    vertex normals of the input.
//!
//! Decisions:
//! - `normalize_diffused` (default true, as in the thesis) divides the diffused d̄ by
//!   `max(|d̄|, 10⁻⁶)`: the thesis' normalization wherever d̄ has a direction, and a continuous
//!   fall-back towards the normal where zone directions cancel (a plain normalization would turn
//!   round-off into an arbitrary unit direction there, breaking symmetry). With `false`, d̄ keeps
//!   its diffused length, so d falls back to the normal where the directions cancel (skinning,
//!   ch. 6).
//! - At a boundary point of ∂𝒞 (u = 0, w = 1), `d_ij = normalize((1 − α)d̄_i + α d̄_j)`.
//! - **Short d̄ (better than the thesis).** When d̄ is not a unit vector (given by the caller, or
//!   diffused without normalization), the blend is `d = normalize(w·d̄ + (1 − w·|d̄|)·n)`, and at
//!   a boundary point `d_ij = normalize(d̄_ij + (1 − |d̄_ij|)·n_ij)` (d̄ and n interpolated). With
//!   |d̄| = 1 this is the thesis' blend; as |d̄| → 0 it tends to n *everywhere*, ∂𝒞 included.
//!   The thesis' `w·d̄ + (1 − w)·n` falls back to n only inside 𝒟: at ∂𝒞 (w = 1) it normalizes
//!   a vanishing d̄, whose sign flips across the crease of a skinned fold (d̄ = (2β − 1)·d̂), and
//!   the amplitudes measured along it jumped by the whole penetration there (a bent capsule:
//!   crease vertices pushed 0.45 radius into the limb).
//! - If the blend vanishes (d̄ opposite to n with w = ½, or a zero normal), d falls back to n, then
//!   to the owner zone's direction; such vertices are counted.
//! - Outside 𝒟, d is the normal (unused by the later stages).
//! - A caller may give d̄ itself ([`DirectionParams::mapping_field`]): it is used as given, not
//!   normalized. Chapter 6 (§6.2.2) does this with `(2β − 1)·d̂` over a shared region, so that d̄
//!   vanishes at the crease and d falls back to the normal there.
//!
//! Method A's field (§5.2.1: tangent-space diffusion with parallel transport) is
//! [`DirectionFieldMethod::ParallelTransport`], computed by [`transport_field`]; with it the
//! result's `mapping` holds the tangent parts B_i d̄_i and `boundary` the target directions at ∂𝒞.

use glam::DVec3;

use super::contact_set::ContactSet;
use super::parametrize::Parametrization;
use super::transport::{TransportField, transport_field};
use super::{DeformError, RegionSolver};
use crate::linalg::RightHandSide;
use crate::mesh::TriMesh;
use crate::params::DirectionFieldMethod;

/// Below this length the diffused field is not stretched to unit length (see the module doc).
pub const MIN_DIFFUSED_LENGTH: f64 = 1e-6;

/// Below this length a blended direction is considered vanished.
const MIN_BLEND_LENGTH: f64 = 1e-12;

/// The blending weight of the mapping field, `w(u) = (1 − u²)⁶` on `[0, 1]`.
#[inline]
pub fn blend_weight(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    let x = 1.0 - u * u;
    let x2 = x * x;
    x2 * x2 * x2
}

/// The direction field of one region for one frame.
#[derive(Clone, Debug)]
pub struct DirectionField {
    /// d̄ per vertex (unit, except where an unnormalized or cancelling diffusion left it shorter).
    pub mapping: Vec<DVec3>,
    /// d per vertex: the blended unit direction on 𝒟, the normal elsewhere.
    pub directions: Vec<DVec3>,
    /// d at each boundary point of ∂𝒞 (same order as [`ContactSet::boundary`]).
    pub boundary: Vec<DVec3>,
    /// True if d̄ was diffused (several zone directions).
    pub diffused: bool,
    /// Number of vertices of 𝒟 and boundary points where the blend vanished and fell back.
    pub fallbacks: usize,
}

impl From<TransportField> for DirectionField {
    /// The parallel-transport field as the rest of the deformation stage consumes it: d̄ holds
    /// the tangent parts B_i d̄_i.
    fn from(field: TransportField) -> Self {
        Self {
            mapping: field.tangents,
            directions: field.directions,
            boundary: field.boundary,
            diffused: true,
            fallbacks: field.fallbacks,
        }
    }
}

/// Options of the direction field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionParams<'a> {
    /// The method.
    pub method: DirectionFieldMethod,
    /// Normalize the diffused mapping field (see the module doc).
    pub normalize_diffused: bool,
    /// d̄ per vertex given by the caller, used as is (blended method only; see the module doc).
    pub mapping_field: Option<&'a [DVec3]>,
}

/// Computes d̄ and d (see the module doc). `normals` are the input's area-weighted vertex normals;
/// `parametrization` must come from [`super::parametrize::parametrize()`] on the same `solver` this frame when
/// several zone directions need a diffusion.
pub fn direction_field(
    mesh: &TriMesh,
    solver: &mut RegionSolver,
    contact: &ContactSet,
    parametrization: &Parametrization,
    normals: &[DVec3],
    params: &DirectionParams,
) -> Result<DirectionField, DeformError> {
    let n = mesh.num_vertices();
    DeformError::check_len("normals", n, normals.len())?;
    if let Some(field) = params.mapping_field {
        DeformError::check_len("given mapping field", n, field.len())?;
    }
    DeformError::check_len("contact set (vertices)", n, contact.vertex_zone.len())?;
    DeformError::check_len("parametrization (u)", n, parametrization.u.len())?;
    DeformError::check_len("parametrization (𝒟)", n, parametrization.deformable.len())?;
    if params.method == DirectionFieldMethod::ParallelTransport {
        return transport_field(mesh, solver, contact, parametrization, normals).map(DirectionField::from);
    }
    let first_direction = contact.boundary.first().map_or(DVec3::ZERO, |b| contact.directions[b.zone as usize]);
    let diffused = params.mapping_field.is_none() && contact.has_several_directions();
    let mapping = if let Some(field) = params.mapping_field {
        field.to_vec()
    } else if diffused {
        diffuse_mapping_directions(solver, contact, parametrization, params.normalize_diffused)?
    } else {
        vec![first_direction; n]
    };

    // A d̄ shorter than 1 (given, or diffused without normalization) gives the normal the weight
    // `1 − w·|d̄|` (see the module doc); a unit d̄ keeps the thesis' `1 − w` exactly.
    let unnormalized = params.mapping_field.is_some() || (diffused && !params.normalize_diffused);
    let mut fallbacks = 0;
    let boundary = contact
        .boundary
        .iter()
        .map(|b| {
            let p = b.point;
            let mut d = mapping[p.inside as usize] * (1.0 - p.alpha) + mapping[p.outside as usize] * p.alpha;
            if unnormalized {
                let normal = normals[p.inside as usize] * (1.0 - p.alpha) + normals[p.outside as usize] * p.alpha;
                d += (1.0 - d.length().min(1.0)) * normal;
            }
            if d.length() > MIN_BLEND_LENGTH {
                d.normalize()
            } else {
                fallbacks += 1;
                contact.directions[b.zone as usize]
            }
        })
        .collect();

    let mut directions = normals.to_vec();
    for v in 0..n {
        if !parametrization.deformable[v] {
            continue;
        }
        let w = blend_weight(parametrization.u[v]);
        let normal_weight = if unnormalized { 1.0 - w * mapping[v].length().min(1.0) } else { 1.0 - w };
        let blend = w * mapping[v] + normal_weight * normals[v];
        let length = blend.length();
        directions[v] = if length > MIN_BLEND_LENGTH {
            blend / length
        } else {
            fallbacks += 1;
            if normals[v].length() > MIN_BLEND_LENGTH { normals[v].normalize() } else { first_direction }
        };
    }
    Ok(DirectionField { mapping, directions, boundary, diffused, fallbacks })
}

/// Harmonic diffusion of the zones' directions from their boundary points (three right-hand
/// sides on the Poisson factorization).
fn diffuse_mapping_directions(
    solver: &mut RegionSolver,
    contact: &ContactSet,
    parametrization: &Parametrization,
    normalize: bool,
) -> Result<Vec<DVec3>, DeformError> {
    let poisson = solver.poisson(parametrization.generation, "direction diffusion")?;
    // Solved with the Poisson step when the parametrization was asked to (same bits).
    let solved;
    let columns: &[Vec<f64>] = match &parametrization.diffused_directions {
        Some(columns) => columns,
        None => {
            let [x, y, z] = contact.boundary_direction_components();
            let rhs = |values| RightHandSide { constraint_values: Some(values), ..Default::default() };
            solved =
                poisson.solve_many(&[rhs(&x), rhs(&y), rhs(&z)]).map_err(DeformError::solve("direction diffusion"))?;
            &solved
        }
    };
    let mut mapping: Vec<DVec3> =
        (0..columns[0].len()).map(|v| DVec3::new(columns[0][v], columns[1][v], columns[2][v])).collect();
    if normalize {
        for d in &mut mapping {
            *d /= d.length().max(MIN_DIFFUSED_LENGTH);
        }
    }
    Ok(mapping)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::deform::parametrize::{ParametrizeParams, parametrize, parametrize_and_diffuse};
    use crate::deform::test_support::plane_zone;
    use crate::mesh::{Topology, shapes, vertex_normals};

    fn setup(
        mesh: &TriMesh,
        topology: &Topology,
        solver: &mut RegionSolver,
        zones: &[&crate::contact::ContactZone],
        extent: f64,
        normalize_diffused: bool,
    ) -> (ContactSet, Parametrization, DirectionField) {
        let contact = ContactSet::new(mesh, topology, zones).unwrap();
        let params = ParametrizeParams::new(extent);
        let p = parametrize(mesh, topology, solver, &contact, &params).unwrap();
        let normals = vertex_normals(mesh);
        let options =
            DirectionParams { method: DirectionFieldMethod::Blended, normalize_diffused, mapping_field: None };
        let field = direction_field(mesh, solver, &contact, &p, &normals, &options).unwrap();
        (contact, p, field)
    }

    #[test]
    fn blend_weight_goes_from_one_to_zero_quickly() {
        assert_eq!(blend_weight(0.0), 1.0);
        assert_eq!(blend_weight(1.0), 0.0);
        assert!((blend_weight(0.5) - 0.75f64.powi(6)).abs() < 1e-15);
        assert!(blend_weight(0.3) < blend_weight(0.2));
    }

    #[test]
    fn one_zone_blends_its_direction_into_the_normals() {
        let mesh = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&mesh);
        let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
        let zone = plane_zone(&mesh, &topology, DVec3::Z, -0.85);
        let (_, p, field) = setup(&mesh, &topology, &mut solver, &[&zone], 0.8, true);
        assert!(!field.diffused);
        assert!(field.boundary.iter().all(|d| (*d - -DVec3::Z).length() < 1e-15));
        let normals = vertex_normals(&mesh);
        for (v, normal) in normals.iter().enumerate() {
            if !p.deformable[v] {
                continue;
            }
            let d = field.directions[v];
            assert!((d.length() - 1.0).abs() < 1e-12);
            let w = blend_weight(p.u[v]);
            // d lies between d̄ and n: closer to d̄ for small u, to n for u near 1.
            if w > 0.99 {
                assert!(d.dot(-DVec3::Z) > 0.99, "u = {}", p.u[v]);
            }
            if w < 0.01 {
                assert!(d.dot(*normal) > 0.99, "u = {}", p.u[v]);
            }
        }
        assert_eq!(field.fallbacks, 0);
    }

    #[test]
    fn several_zones_diffuse_their_directions_smoothly_on_one_factorization() {
        let mesh = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&mesh);
        let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
        // A plane from below (d̄ = −z) and one from the side (d̄ = −x).
        let bottom = plane_zone(&mesh, &topology, DVec3::Z, -0.9);
        let side = plane_zone(&mesh, &topology, DVec3::X, -0.9);
        let before = solver.numeric_factorizations();
        let (contact, _, field) = setup(&mesh, &topology, &mut solver, &[&bottom, &side], 1.5, true);
        assert_eq!(solver.numeric_factorizations() - before, 2, "heat + Poisson only: the diffusion reuses Poisson");
        assert!(field.diffused);
        let mut worst_boundary = 0.0f64;
        for (b, d) in contact.boundary.iter().zip(&field.boundary) {
            worst_boundary = worst_boundary.max((*d - contact.directions[b.zone as usize]).length());
        }
        let mut worst_edge = 0.0f64;
        for &[a, b] in topology.edges() {
            if contact.contains(a) || contact.contains(b) {
                continue;
            }
            worst_edge = worst_edge.max((field.mapping[a as usize] - field.mapping[b as usize]).length());
        }
        println!("d̄ vs zone direction at ∂𝒞: {worst_boundary:.2e}; largest change of d̄ along an edge: {worst_edge:.3}");
        assert!(worst_boundary < 0.02, "{worst_boundary}");
        // 90° over the ~0.66 between the contact circles, edges of ~0.08: about 0.17 per edge.
        assert!(worst_edge < 0.25, "{worst_edge}");
        // Between the zones d̄ turns from −z to −x: at the vertex midway it is about their bisector.
        let probe = crate::deform::test_support::nearest_vertex(&mesh, DVec3::new(-1.0, 0.0, -1.0).normalize());
        let d = field.mapping[probe];
        assert!(d.dot(DVec3::new(-1.0, 0.0, -1.0).normalize()) > 0.95, "{d}");

        // The diffusion solved in the Poisson step's pass (as `setup` does) and solved on its own
        // afterwards give the same bits.
        let params = ParametrizeParams::new(1.5);
        let alone = parametrize_and_diffuse(&mesh, &topology, &mut solver, &contact, &params, false).unwrap();
        assert!(alone.diffused_directions.is_none());
        let normals = vertex_normals(&mesh);
        let options =
            DirectionParams { method: DirectionFieldMethod::Blended, normalize_diffused: true, mapping_field: None };
        let separate = direction_field(&mesh, &mut solver, &contact, &alone, &normals, &options).unwrap();
        let bits = |v: &[DVec3]| v.iter().flat_map(|d| d.to_array().map(f64::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(&separate.mapping), bits(&field.mapping));
        assert_eq!(bits(&separate.directions), bits(&field.directions));
    }

    #[test]
    fn unnormalized_diffusion_shrinks_where_directions_cancel() {
        let mesh = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&mesh);
        let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
        let bottom = plane_zone(&mesh, &topology, DVec3::Z, -0.8);
        let top = plane_zone(&mesh, &topology, -DVec3::Z, -0.8);
        let zones = [&bottom, &top];
        let (_, _, raw) = setup(&mesh, &topology, &mut solver, &zones, 1.5, false);
        let (_, p, unit) = setup(&mesh, &topology, &mut solver, &zones, 1.5, true);
        let normals = vertex_normals(&mesh);
        let equator: Vec<usize> = (0..mesh.num_vertices()).filter(|&v| mesh.positions[v].z.abs() < 1e-9).collect();
        assert!(!equator.is_empty());
        for &v in &equator {
            assert!(raw.mapping[v].length() < 0.05, "unnormalized |d̄| at the equator: {}", raw.mapping[v].length());
            // Cancelling directions: the normalized field does not amplify round-off either.
            assert!(unit.mapping[v].length() < 1e-6, "{}", unit.mapping[v]);
            if p.deformable[v] {
                assert!((unit.directions[v] - normals[v]).length() < 1e-6);
            }
        }
        let near_bottom = crate::deform::test_support::nearest_vertex(&mesh, DVec3::new(0.6, 0.0, -0.8).normalize());
        assert!(raw.mapping[near_bottom].length() > 0.5);
        assert!((unit.mapping[near_bottom].length() - 1.0).abs() < 1e-12);
    }
}
