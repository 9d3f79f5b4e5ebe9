//! The parallel-transport direction field (thesis §5.2.1, method A; algorithm box of §5.6,
//! "Direction field computation ▷ §2.1"), selected with
//! [`DirectionFieldMethod::ParallelTransport`](super::DirectionFieldMethod::ParallelTransport). A
//! drop-in replacement for the blended field of [`direction_field`](super::direction_field()):
//! same inputs, and [`direction_field`](super::direction_field()) turns its result into the same
//! [`DirectionField`](super::DirectionField).
//!
//! Every unit direction d_i is stored as its tangent part in a frame B_i = [t_i b_i] of the vertex's
//! tangent plane, d̄_i = B_iᵀ d_i, and d_i = B_i d̄_i + √(1 − ‖d̄_i‖²) n_i (Eq. 5.2). Tangent vectors
//! are complex numbers x + iy in their vertex's frame.
//!
//! 1. **Frames (decision).** B_i is the basis of [`ProjectionPlane::new`]`(n_i)`: t_i = a × n_i
//!    normalized, with a the coordinate axis least aligned with n_i, and b_i = n_i × t_i. Any
//!    choice works — the connection Laplacian is gauge-covariant, so the final directions do not
//!    depend on it (up to round-off); this one is deterministic and rigid-motion consistent
//!    per vertex.
//! 2. **Transport.** R_{i←j} is the minimal rotation taking n_j to n_i; R̄_{i←j} = B_iᵀ R_{i←j} B_j
//!    is the unit complex r_ij = (R t_j)·t_i + i (R t_j)·b_i, so that r_ij z_j is z_j expressed in
//!    i's frame (Knöppel et al. 2013, §2). The connection Laplacian A has the cotangent stiffness
//!    K of 𝒟 on its diagonal and K_ij r_ij off it (A_ij = −w_ij r_ij, Hermitian: A_ji = conj(A_ij));
//!    its energy is Σ_ij w_ij |z_i − r_ij z_j|². K is cut-face weighted by the area inside 𝒟 =
//!    (outside 𝒞) ∩ {u < 1} (App. B), so the domain moves continuously with ∂𝒞 and ∂𝒟.
//! 3. **Constraints** (least squares, App. B: λ = 100, rows `λ c^H c`, right-hand side `λ c^H b`):
//!    - at each point p_ij of ∂𝒞 (α from the inside vertex i), in the frame of p_ij obtained by
//!      transporting B_i to the interpolated normal n_ij: `(1 − α) z_i + α r_{p←j} z_j = b_ij`,
//!      which includes the transports from i (the identity, by the choice of frame) and from j
//!      to the point;
//!    - at each point of ∂𝒟 (the u = 1 crossing of an edge from a vertex of 𝒟 to one beyond it)
//!      the same row with b = 0 (d̄ = B^T n = 0: the direction is the normal), and z_v = 0 at the
//!      vertices of 𝒟 on the region's outer boundary.
//! 4. **Targets at ∂𝒞.** d_ij = (p_ij − p′_ij)/‖p_ij − p′_ij‖ (§5.2.1). Decisions: the vector is
//!    flipped when it points against the zone's outward direction d̄_k (a boundary point with a gap
//!    moves outward; the thesis assumes penetration), and d_ij = normalize(v + ε d̄_k) with
//!    ε = 10⁻³ × the region's mean edge length, so that where the depth vanishes (an intersection
//!    point of a ball-tested zone, p = p′) the target tends continuously to d̄_k instead of being
//!    undefined. With the unique mapping direction p − p′ is parallel to d̄_k, so d_ij = d̄_k
//!    exactly.
//! 5. **Arcsin remapping (Eq. 5.2–5.3).** Targets are encoded as angle vectors
//!    θ·(x + iy)/|x + iy|, θ = atan2(|B^T d|, d·n) — the thesis' arcsin(‖d̄‖) for directions in the
//!    outer hemisphere, extended continuously past 90° instead of folding them back — diffused,
//!    and decoded as d = B (sin|a| â) + cos|a| n, which is Eq. 5.2–5.3 (cos|a| = √(1 − sin²|a|)
//!    for |a| ≤ π/2; beyond, the sign keeps the decoded direction equal to the encoded one).
//! 6. **u/u′ correction — our reading.** The harmonic diffusion varies fastest near ∂𝒞 (in a disc
//!    contact its profile is logarithmic), like the harmonic parametrization u′ (0 on ∂𝒞, 1 on
//!    ∂𝒟, same domain and same kind of constraints), whereas u (§5.1) is uniform. The stated intent
//!    is to "remap the diffused projected direction according to the uniform parametrization":
//!    for a radial field a′ ≈ a_𝒞 (1 − u′) we want a_𝒞 (1 − u), i.e. a = ((1 − u)/(1 − u′))·a′.
//!    The printed factor u/u′ cannot be meant literally: at ∂𝒞 it tends to the ratio of the normal
//!    derivatives of u and u′ (not 1), breaking the constraint d = d_ij, and since u′ > u inside it
//!    is < 1, pushing the field *faster* towards the normals — the opposite of the stated goal. It
//!    is the same formula written with the distances from ∂𝒟 (1 − u, 1 − u′). Decision: the
//!    factor multiplies the diffused angle (before the sine; the thesis' Eq. 5.3 value is the same
//!    to first order and this keeps ‖d̄‖ ≤ 1), is capped at 8 (it tends to a finite ratio of
//!    derivatives at ∂𝒟, where a′ → 0 anyway), and the angle at π.
//! 7. Outside 𝒟 the direction is the input normal (as for the blended field); at ∂𝒞 the result's
//!    `boundary` holds the targets d_ij, and `mapping` the tangent parts B_i d̄_i.
//!
//! **Which field when.** The blended field (default) is cheap — no solve with one zone direction,
//! the Poisson factorization reused with several — and w(u) fixes how fast it reaches the
//! normals. The transport field follows the surface's change of orientation between ∂𝒞 and ∂𝒟
//! (the bean-shaped case of the chapter's introduction) and honours a different displacement
//! direction at every point of ∂𝒞, which is what the shared-parametrization mapping produces (its
//! displacements are not along one d̂); it costs two more factorizations, one of them complex
//! (about 4× a real one). With a unique mapping direction both give nearly the same surface (the
//! Fig. 7.14 test measures 10⁻³ between them for a sphere 0.3 deep in a slab).
//!
//! **Cost and caching.** Two factorizations per frame on the region's pattern: the complex
//! connection Laplacian (faer's sparse LLᴴ with `c64` scalars) and the real one of u′. The complex
//! symbolic analysis (AMD ordering on the same pattern) is done once per region and cached in the
//! [`RegionSolver`] with the numeric storage, like the real systems; so is the u′ solver.
//! Undetermined vertices (no face in 𝒟 and no constraint) are handled by a 10⁻⁹ diagonal shift
//! (cotangent and constraint weights are scale-free, so this is a relative 10⁻⁹): they get 0, the
//! other vertices move by ~10⁻⁹ of their value, and the matrix is always definite.

use std::time::Instant;

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::{Conj, MatMut, Par, Side, c64};
use glam::DVec3;

use super::contact_set::ContactSet;
use super::parametrize::{Parametrization, deformable_face_weights};
use super::{DeformError, RegionSolver};
use crate::linalg::{
    ConstrainedSolver, ConstraintParams, DEFAULT_CONSTRAINT_WEIGHT_FACTOR, EdgeConstraint, Operator, RightHandSide,
    SolveError, SparsePattern,
};
use crate::mesh::{Topology, TriMesh};
use crate::spatial::ProjectionPlane;

/// Largest u/u′ correction factor (see the module doc).
pub const MAX_CORRECTION: f64 = 8.0;

/// Diagonal shift that makes undetermined vertices harmless (see the module doc).
const DIAGONAL_SHIFT: f64 = 1e-9;

/// Below this depth (× the mean edge length) the target at ∂𝒞 blends into the zone direction.
const TARGET_BLEND: f64 = 1e-3;

/// The cached systems of the transport field on one region (inside [`RegionSolver`]).
pub struct TransportCache {
    topology: Topology,
    symbolic: SymbolicCholesky<usize>,
    values: Vec<c64>,
    l_values: Vec<c64>,
    rhs: Vec<c64>,
    factorize_buffer: MemBuffer,
    solve_buffer: MemBuffer,
    stiffness: Option<Operator>,
    harmonic: Option<ConstrainedSolver>,
}

impl std::fmt::Debug for TransportCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TransportCache")
            .field("dimension", &self.symbolic.nrows())
            .field("factor_len", &self.l_values.len())
            .finish()
    }
}

fn buffer(req: StackReq) -> Result<MemBuffer, DeformError> {
    MemBuffer::try_new(req).map_err(|_| DeformError::Solve {
        stage: "parallel-transport diffusion",
        source: SolveError::Analysis { reason: "out of memory for the factorization scratch".into() },
    })
}

impl TransportCache {
    fn new(mesh: &TriMesh, pattern: &SparsePattern) -> Result<Self, DeformError> {
        let symbolic = factorize_symbolic_cholesky(
            pattern.structure(),
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| DeformError::Solve {
            stage: "parallel-transport diffusion",
            source: SolveError::Analysis { reason: format!("{e:?}") },
        })?;
        let factorize_buffer = buffer(symbolic.factorize_numeric_llt_scratch::<c64>(Par::Seq, Default::default()))?;
        let solve_buffer = buffer(symbolic.solve_in_place_scratch::<c64>(1, Par::Seq))?;
        Ok(Self {
            topology: Topology::new(mesh),
            values: vec![c64::new(0.0, 0.0); pattern.nnz()],
            l_values: vec![c64::new(0.0, 0.0); symbolic.len_val()],
            rhs: Vec::new(),
            symbolic,
            factorize_buffer,
            solve_buffer,
            stiffness: None,
            harmonic: None,
        })
    }
}

/// A tangent frame: t, b = n × t, and the normal n.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub t: DVec3,
    pub b: DVec3,
    pub n: DVec3,
}

impl Frame {
    /// The frame of a unit normal (module doc, step 1); a zero normal gets the z-up frame.
    pub fn of_normal(n: DVec3) -> Self {
        match ProjectionPlane::new(n) {
            Some(plane) => Self { t: plane.u, b: plane.v, n: n.normalize() },
            None => Self { t: DVec3::X, b: DVec3::Y, n: DVec3::Z },
        }
    }

    /// The frame transported to the unit normal `n` by the minimal rotation.
    pub fn transported_to(&self, n: DVec3) -> Self {
        let t = rotate(self.t, self.n, n);
        Self { t, b: n.cross(t), n }
    }

    /// Complex coordinates of the tangent part of `v`.
    #[inline]
    pub fn coordinates(&self, v: DVec3) -> c64 {
        c64::new(v.dot(self.t), v.dot(self.b))
    }

    /// The unit complex r with `r·z` = a vector given in frame `from`, transported here.
    pub fn rotation_from(&self, from: &Frame) -> c64 {
        let r = self.coordinates(rotate(from.t, from.n, self.n));
        let length = r.norm();
        if length > 0.0 && length.is_finite() { r / length } else { c64::new(1.0, 0.0) }
    }

    /// The angle vector of a unit direction (module doc, step 5): θ·(x + iy)/|x + iy|.
    pub fn encode(&self, d: DVec3) -> c64 {
        let z = self.coordinates(d);
        let s = z.norm();
        if s > 0.0 { z * (s.atan2(d.dot(self.n)) / s) } else { c64::new(0.0, 0.0) }
    }

    /// The unit direction of an angle vector (Eq. 5.2–5.3), angle capped at π.
    pub fn decode(&self, a: c64) -> DVec3 {
        let theta = a.norm();
        if theta == 0.0 || !theta.is_finite() {
            return self.n;
        }
        let unit = a / theta;
        let theta = theta.min(std::f64::consts::PI);
        let tangent = self.t * unit.re + self.b * unit.im;
        (tangent * theta.sin() + self.n * theta.cos()).normalize_or(self.n)
    }
}

/// The minimal rotation taking the unit vector `from` to the unit vector `to`, applied to `x`
/// (Rodrigues with the unnormalized axis v = from × to); the identity for opposite vectors.
#[inline]
fn rotate(x: DVec3, from: DVec3, to: DVec3) -> DVec3 {
    let c = from.dot(to);
    if 1.0 + c <= 1e-12 || c.is_nan() {
        return x;
    }
    let v = from.cross(to);
    x * c + v.cross(x) + v * (v.dot(x) / (1.0 + c))
}

/// One least-squares row `c_i z_i + c_j z_j = b` (j = i for a vertex row).
#[derive(Clone, Copy, Debug)]
struct Row {
    i: u32,
    ci: c64,
    j: u32,
    cj: c64,
    b: c64,
}

/// The transport field of one region for one frame, with what the tests inspect.
#[derive(Clone, Debug)]
pub struct TransportField {
    /// d per vertex: unit on 𝒟, the input normal elsewhere.
    pub directions: Vec<DVec3>,
    /// B_i d̄_i per vertex (the tangent part of d on 𝒟, zero elsewhere).
    pub tangents: Vec<DVec3>,
    /// The corrected angle vectors per vertex (complex, in each vertex's frame), where solved.
    pub angles: Vec<c64>,
    /// The harmonic parametrization u′ (0 on ∂𝒞, 1 on ∂𝒟; empty without a solve).
    pub harmonic_u: Vec<f64>,
    /// The frames B_i.
    pub frames: Vec<Frame>,
    /// The target direction d_ij at each point of ∂𝒞 (order of [`ContactSet::boundary`]).
    pub boundary: Vec<DVec3>,
    /// The points of ∂𝒟 that were constrained, as (vertex in 𝒟, vertex beyond, α).
    pub outer_points: Vec<(u32, u32, f64)>,
    /// ∂𝒞 targets that could not be encoded (a target opposite to the normal).
    pub fallbacks: usize,
}

impl TransportField {
    /// The field's direction at the point `(1 − α) p_i + α p_j` of an edge: both ends' angle
    /// vectors transported to the point's frame (B_i transported to the interpolated normal),
    /// interpolated and decoded. `normals` are the vertex normals the field was built with.
    pub fn direction_at(&self, normals: &[DVec3], i: u32, j: u32, alpha: f64) -> DVec3 {
        let (fi, fj) = (&self.frames[i as usize], &self.frames[j as usize]);
        let n = normals[i as usize].lerp(normals[j as usize], alpha).try_normalize().unwrap_or(fi.n);
        let fp = fi.transported_to(n);
        let z = self.angles[i as usize] * (1.0 - alpha) + fp.rotation_from(fj) * self.angles[j as usize] * alpha;
        fp.decode(z)
    }
}

/// The target direction at a point of ∂𝒞 (module doc, step 4).
fn boundary_target(position: DVec3, target: DVec3, zone_direction: DVec3, epsilon: f64) -> DVec3 {
    let v = position - target;
    let v = if v.dot(zone_direction) < 0.0 { -v } else { v };
    (v + zone_direction * epsilon).try_normalize().unwrap_or(zone_direction)
}

/// Computes the parallel-transport direction field (module doc). `parametrization` must come
/// from [`super::parametrize::parametrize()`] this frame; `normals` are the input's unit vertex normals.
pub fn transport_field(
    mesh: &TriMesh,
    solver: &mut RegionSolver,
    contact: &ContactSet,
    parametrization: &Parametrization,
    normals: &[DVec3],
) -> Result<TransportField, DeformError> {
    let n = mesh.num_vertices();
    DeformError::check_len("normals", n, normals.len())?;
    DeformError::check_len("contact set (vertices)", n, contact.vertex_zone.len())?;
    DeformError::check_len("parametrization (u)", n, parametrization.u.len())?;
    DeformError::check_len("parametrization (𝒟)", n, parametrization.deformable.len())?;
    let frames: Vec<Frame> = normals.iter().map(|&v| Frame::of_normal(v)).collect();
    let mut field = TransportField {
        directions: normals.to_vec(),
        tangents: vec![DVec3::ZERO; n],
        angles: vec![c64::new(0.0, 0.0); n],
        harmonic_u: Vec::new(),
        frames,
        boundary: Vec::new(),
        outer_points: Vec::new(),
        fallbacks: 0,
    };
    if contact.boundary.is_empty() || !parametrization.deformable.iter().any(|&d| d) {
        field.boundary = contact.boundary.iter().map(|b| zone_direction_of(contact, b.zone)).collect();
        return Ok(field);
    }
    let start = Instant::now();
    let mut analyses = 0;
    let mut cache = match solver.transport.take() {
        Some(cache) => cache,
        None => {
            analyses = 1;
            Box::new(TransportCache::new(mesh, solver.shared_analysis().0)?)
        }
    };
    let result = solve(mesh, solver, &mut cache, contact, parametrization, normals, &mut field);
    solver.transport = Some(cache);
    solver.record_factorizations(if result.is_ok() { 2 } else { 0 }, start.elapsed(), analyses);
    result?;
    Ok(field)
}

fn solve(
    mesh: &TriMesh,
    solver: &RegionSolver,
    cache: &mut TransportCache,
    contact: &ContactSet,
    parametrization: &Parametrization,
    normals: &[DVec3],
    field: &mut TransportField,
) -> Result<(), DeformError> {
    const STAGE: &str = "parallel-transport diffusion";
    let n = mesh.num_vertices();
    let (pattern, symbolic) = solver.shared_analysis();
    let (u, deformable) = (&parametrization.u, &parametrization.deformable);
    let frames = &field.frames;
    let weights = deformable_face_weights(mesh, &cache.topology, contact, parametrization)?;
    let h = parametrization.edge_length;
    let epsilon = TARGET_BLEND * if h.is_finite() { h } else { 0.0 };

    // Constraint rows (complex) and the matching rows of u′ (real).
    let mut rows: Vec<Row> = Vec::new();
    let mut harmonic_rows: Vec<EdgeConstraint> = Vec::new();
    let edge_row = |i: u32, j: u32, alpha: f64, target: Option<DVec3>| -> (Row, bool) {
        let (fi, fj) = (&frames[i as usize], &frames[j as usize]);
        let normal = normals[i as usize].lerp(normals[j as usize], alpha).try_normalize().unwrap_or(fi.n);
        let fp = fi.transported_to(normal);
        let (b, fallback) = match target {
            Some(d) => (fp.encode(d), d.dot(fp.n) < 0.0 && fp.coordinates(d).norm() < 1e-12),
            None => (c64::new(0.0, 0.0), false),
        };
        (Row { i, ci: c64::new(1.0 - alpha, 0.0), j, cj: fp.rotation_from(fj) * alpha, b }, fallback)
    };
    for b in &contact.boundary {
        let target = boundary_target(b.position, b.target, zone_direction_of(contact, b.zone), epsilon);
        let (row, fallback) = edge_row(b.point.inside, b.point.outside, b.point.alpha, Some(target));
        field.fallbacks += usize::from(fallback);
        field.boundary.push(target);
        rows.push(row);
        harmonic_rows.push(EdgeConstraint::on_edge(b.point.inside, b.point.outside, b.point.alpha, 0.0));
    }
    // ∂𝒟: where u crosses 1 on an edge from 𝒟 to a vertex beyond it (not in 𝒞).
    for &[x, y] in cache.topology.edges() {
        let (dx, dy) = (deformable[x as usize], deformable[y as usize]);
        if dx == dy {
            continue;
        }
        let (i, j) = if dx { (x, y) } else { (y, x) };
        if contact.contains(j) {
            continue;
        }
        let (ui, uj) = (u[i as usize], u[j as usize]);
        let alpha = (1.0 - ui) / (uj - ui);
        let alpha = if alpha.is_finite() { alpha.clamp(0.0, 1.0) } else { 0.0 };
        field.outer_points.push((i, j, alpha));
        rows.push(edge_row(i, j, alpha, None).0);
        harmonic_rows.push(EdgeConstraint::on_edge(i, j, alpha, 1.0));
    }
    for (v, &on_boundary) in solver.outer_boundary().iter().enumerate() {
        if on_boundary && deformable[v] {
            let zero = c64::new(0.0, 0.0);
            rows.push(Row { i: v as u32, ci: c64::new(1.0, 0.0), j: v as u32, cj: zero, b: zero });
            harmonic_rows.push(EdgeConstraint::vertex(v as u32, 1.0));
        }
    }

    // The cut-face-weighted stiffness of 𝒟, shared by both systems.
    match &mut cache.stiffness {
        Some(operator) => operator.reassemble(mesh, Some(&weights), 0.0, 1.0),
        None => Operator::new(mesh, pattern, Some(&weights), 0.0, 1.0).map(|operator| {
            cache.stiffness = Some(operator);
        }),
    }
    .map_err(DeformError::solve(STAGE))?;
    let Some(operator) = cache.stiffness.as_ref() else {
        return Err(DeformError::Solve { stage: STAGE, source: SolveError::NotAssembled });
    };
    let k = operator.matrix().values();

    // Complex connection Laplacian: off-diagonal K_ij r_ij, diagonal K_ii + shift, then the rows.
    let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
    for lo in 0..n {
        let diag = col_ptr[lo];
        cache.values[diag] = c64::new(k[diag] + DIAGONAL_SHIFT, 0.0);
        for slot in diag + 1..col_ptr[lo + 1] {
            let hi = row_idx[slot];
            cache.values[slot] =
                if k[slot] == 0.0 { c64::new(0.0, 0.0) } else { frames[hi].rotation_from(&frames[lo]) * k[slot] };
        }
    }
    let lambda = DEFAULT_CONSTRAINT_WEIGHT_FACTOR * operator.constraint_scale();
    cache.rhs.clear();
    cache.rhs.resize(n, c64::new(0.0, 0.0));
    for row in &rows {
        let (i, j) = (row.i as usize, row.j as usize);
        cache.values[pattern.diag_slot(row.i)] += row.ci.conj() * row.ci * lambda;
        cache.rhs[i] += row.ci.conj() * row.b * lambda;
        if i != j {
            cache.values[pattern.diag_slot(row.j)] += row.cj.conj() * row.cj * lambda;
            cache.rhs[j] += row.cj.conj() * row.b * lambda;
            let Some(slot) = pattern.slot(row.i, row.j) else {
                return Err(DeformError::Solve {
                    stage: STAGE,
                    source: SolveError::ConstraintNotOnEdge { constraint: 0, i: row.i, j: row.j },
                });
            };
            // The stored lower entry is A[hi][lo] += λ conj(c_hi) c_lo.
            let entry = if i > j { row.ci.conj() * row.cj } else { row.cj.conj() * row.ci };
            cache.values[slot] += entry * lambda;
        }
    }
    if let Some((index, value)) = cache.values.iter().enumerate().find(|(_, v)| !(v.re.is_finite() && v.im.is_finite()))
    {
        return Err(DeformError::Solve {
            stage: STAGE,
            source: SolveError::NonFiniteValue { what: "transport matrix", index, value: value.re + value.im },
        });
    }
    let a = SparseColMatRef::new(pattern.structure(), &cache.values);
    cache
        .symbolic
        .factorize_numeric_llt::<c64>(
            &mut cache.l_values,
            a,
            Side::Lower,
            LltRegularization::default(),
            Par::Seq,
            MemStack::new(&mut cache.factorize_buffer),
            Default::default(),
        )
        .map_err(|_| {
            let (vertex, min_diagonal) = (0..n)
                .map(|v| (v as u32, cache.values[col_ptr[v]].re))
                .fold((0, f64::INFINITY), |b, x| if x.1 < b.1 { x } else { b });
            DeformError::Solve {
                stage: STAGE,
                source: SolveError::NotPositiveDefinite { pivot: 0, dimension: n, vertex, min_diagonal },
            }
        })?;
    let llt = LltRef::new(&cache.symbolic, &cache.l_values);
    llt.solve_in_place_with_conj(
        Conj::No,
        MatMut::from_column_major_slice_mut(&mut cache.rhs, n, 1),
        Par::Seq,
        MemStack::new(&mut cache.solve_buffer),
    );

    // u′: the same stiffness with 0 on ∂𝒞 and 1 on ∂𝒟.
    let params = ConstraintParams::default();
    match &mut cache.harmonic {
        Some(harmonic) => harmonic.update(operator, &harmonic_rows, &params),
        None => ConstrainedSolver::new(symbolic, operator, &harmonic_rows, &params).map(|harmonic| {
            cache.harmonic = Some(harmonic);
        }),
    }
    .map_err(DeformError::solve(STAGE))?;
    let Some(harmonic) = cache.harmonic.as_mut() else {
        return Err(DeformError::Solve { stage: STAGE, source: SolveError::NotFactorized });
    };
    let u_prime =
        harmonic.solve(&RightHandSide { pin_value: 1.0, ..Default::default() }).map_err(DeformError::solve(STAGE))?;

    // Correction, decoding.
    for v in 0..n {
        let correction = if deformable[v] || contact.contains(v as u32) {
            let (distance, harmonic_distance) = (1.0 - u[v].min(1.0), 1.0 - u_prime[v]);
            distance / harmonic_distance.max(distance / MAX_CORRECTION)
        } else {
            1.0
        };
        let correction = if correction.is_finite() { correction } else { 1.0 };
        let angle = cache.rhs[v] * correction;
        field.angles[v] = angle;
        if deformable[v] {
            let d = frames[v].decode(angle);
            field.directions[v] = d;
            field.tangents[v] = d - frames[v].n * d.dot(frames[v].n);
        }
    }
    field.harmonic_u = u_prime;
    Ok(())
}

fn zone_direction_of(contact: &ContactSet, zone: u32) -> DVec3 {
    contact.directions.get(zone as usize).copied().unwrap_or(DVec3::ZERO)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::contact::ContactZone;
    use crate::deform::parametrize::{ParametrizeParams, parametrize};
    use crate::deform::test_support::{plane_zone, region_zone};
    use crate::deform::{DeformParams, deform_region};
    use crate::mesh::{shapes, vertex_normals};
    use crate::params::DirectionFieldMethod;

    fn field_for(
        mesh: &TriMesh,
        topology: &Topology,
        solver: &mut RegionSolver,
        zones: &[&ContactZone],
        extent: f64,
    ) -> (ContactSet, Parametrization, TransportField) {
        let contact = ContactSet::new(mesh, topology, zones).unwrap();
        let params = ParametrizeParams::new(extent);
        let p = parametrize(mesh, topology, solver, &contact, &params).unwrap();
        let normals = vertex_normals(mesh);
        let field = transport_field(mesh, solver, &contact, &p, &normals).unwrap();
        (contact, p, field)
    }

    #[test]
    fn frames_encode_decode_and_transport_consistently() {
        let normals =
            [DVec3::Z, DVec3::new(0.3, -0.2, 0.9).normalize(), DVec3::new(-0.7, 0.1, -0.7).normalize(), -DVec3::X];
        for &n in &normals {
            let f = Frame::of_normal(n);
            assert!(
                (f.t.length() - 1.0).abs() < 1e-15 && f.t.dot(n).abs() < 1e-15 && (f.b - n.cross(f.t)).length() < 1e-15
            );
            for d in
                [n, DVec3::new(0.2, 0.5, 0.3).normalize(), (n + f.t * 0.3).normalize(), (f.b - n * 0.4).normalize()]
            {
                let back = f.decode(f.encode(d));
                assert!((back - d).length() < 1e-14, "{d} → {back}");
            }
            // The angle of the encoding is the angle to the normal, beyond 90° too.
            let d = (f.t - n * 0.5).normalize();
            assert!((f.encode(d).norm() - d.dot(n).acos()).abs() < 1e-14);
        }
        for &a in &normals[..3] {
            for &b in &normals[..3] {
                let (fa, fb) = (Frame::of_normal(a), Frame::of_normal(b));
                let (r_ab, r_ba) = (fa.rotation_from(&fb), fb.rotation_from(&fa));
                assert!((r_ab * r_ba - c64::new(1.0, 0.0)).norm() < 1e-14, "transport back and forth");
                // Transport maps b's tangent vector to the rotated 3D vector.
                let w = fb.t * 0.3 + fb.b * 0.8;
                let z = r_ab * c64::new(0.3, 0.8);
                let rotated = rotate(w, b, a);
                assert!((fa.t * z.re + fa.b * z.im - rotated).length() < 1e-14);
            }
        }
    }

    /// On a flat grid the transport is trivial and the diffused angle is exactly the harmonic
    /// parametrization's profile, θ₀(1 − u′): the u/u′ correction must turn it into the uniform
    /// θ₀(1 − u) (our reading of §5.2.1, module doc step 6). The direction satisfies its
    /// constraint at ∂𝒞 and is the normal at ∂𝒟.
    #[test]
    fn on_a_flat_grid_the_corrected_angle_is_uniform_in_u() {
        let mesh = shapes::grid(3.0, 3.0, 60, 60);
        let topology = Topology::new(&mesh);
        let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
        let dir = DVec3::new(0.6, 0.0, 0.8);
        let centre = DVec3::new(0.02, -0.03, 0.0);
        let mut zone = region_zone(&mesh, &topology, |p| (p - centre).length() - 0.4, dir);
        for v in 0..mesh.num_vertices() {
            if zone.region.contains(v as u32) {
                zone.targets[v] = mesh.positions[v] - 0.05 * dir;
            }
        }
        for (t, p) in zone.boundary_targets.iter_mut().zip(&zone.boundary_positions) {
            *t = *p - 0.05 * dir;
        }
        let (contact, p, field) = field_for(&mesh, &topology, &mut solver, &[&zone], 0.8);
        let theta = 0.6f64.atan2(0.8);
        let (mut worst, mut uncorrected, mut count) = (0.0f64, 0.0f64, 0);
        for v in 0..mesh.num_vertices() {
            if !p.deformable[v] {
                continue;
            }
            count += 1;
            let angle = field.angles[v].norm();
            worst = worst.max((angle - theta * (1.0 - p.u[v])).abs());
            uncorrected = uncorrected.max((angle - theta * (1.0 - field.harmonic_u[v])).abs() - 0.0);
            // The tangent part points along the target's (x), never sideways.
            assert!(field.tangents[v].y.abs() < 1e-9 && field.tangents[v].x >= 0.0, "{}", field.tangents[v]);
            assert!((field.directions[v].length() - 1.0).abs() < 1e-12);
        }
        let diffused_vs_uniform = (0..mesh.num_vertices())
            .filter(|&v| p.deformable[v])
            .map(|v| (field.harmonic_u[v] - p.u[v]).abs())
            .fold(0.0, f64::max);
        println!(
            "flat grid, |𝒟| = {count}: max |angle − θ₀(1 − u)| = {worst:.2e}; the harmonic u′ differs from u by up to {diffused_vs_uniform:.3}"
        );
        assert!(worst < 1e-6, "{worst}");
        assert!(diffused_vs_uniform > 0.05, "the correction must matter in this test");
        let _ = uncorrected;
        // Constraints: the target at ∂𝒞, the normal at ∂𝒟.
        let normals = vertex_normals(&mesh);
        let (mut at_c, mut at_d) = (0.0f64, 0.0f64);
        for (b, target) in contact.boundary.iter().zip(&field.boundary) {
            assert!((*target - dir).length() < 1e-12, "p − p′ is along the zone direction");
            let d = field.direction_at(&normals, b.point.inside, b.point.outside, b.point.alpha);
            at_c = at_c.max(d.angle_between(*target));
        }
        for &(i, j, alpha) in &field.outer_points {
            at_d = at_d.max(field.direction_at(&normals, i, j, alpha).angle_between(DVec3::Z));
        }
        println!(
            "largest angle to the target at ∂𝒞 {:.3}°, to the normal at ∂𝒟 {:.3}°",
            at_c.to_degrees(),
            at_d.to_degrees()
        );
        assert!(at_c.to_degrees() < 1.0 && at_d.to_degrees() < 1.0);
    }

    /// On a sphere pressed from below, the constraints at ∂𝒞 point straight down, i.e. along the
    /// meridians in every tangent plane: parallel transport keeps the diffused field meridional (a
    /// wrong rotation would twist it around the axis), and the angle decreases from ∂𝒞 to ∂𝒟.
    #[test]
    fn on_a_sphere_the_transported_field_stays_meridional() {
        let mesh = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&mesh);
        let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
        let zone = plane_zone(&mesh, &topology, DVec3::Z, -0.8);
        let (_, p, field) = field_for(&mesh, &topology, &mut solver, &[&zone], 1.2);
        let (mut twist, mut largest, mut count) = (0.0f64, 0.0f64, 0);
        for v in 0..mesh.num_vertices() {
            if !p.deformable[v] || field.tangents[v].length() < 1e-3 {
                continue;
            }
            count += 1;
            let x = mesh.positions[v];
            let azimuthal = DVec3::Z.cross(x).normalize_or_zero();
            twist = twist.max(field.tangents[v].dot(azimuthal).abs());
            largest = largest.max(field.tangents[v].length());
            // Pointing towards the bottom pole (the contact), like the constraints.
            assert!(field.tangents[v].z < 0.0, "vertex {v}: {}", field.tangents[v]);
        }
        println!(
            "sphere: {count} vertices of 𝒟 with a tangent part (largest {largest:.3}); largest azimuthal component {twist:.2e} ({:.2}% of it)",
            100.0 * twist / largest
        );
        assert!(count > 100 && largest > 0.3);
        // Without the transport rotations (r_ij = 1) the field points every which way (it fails
        // the assertion above).
        assert!(twist < 0.02 * largest, "{twist}");
    }

    /// The field through `deform_region`: bit-identical with a fresh or a reused solver, and two
    /// extra factorizations per frame (plus one complex symbolic analysis per region).
    #[test]
    fn deform_region_with_the_transport_field_is_deterministic() {
        let mesh = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&mesh);
        let zone = plane_zone(&mesh, &topology, DVec3::new(0.2, 0.1, 1.0), -0.75);
        let params = DeformParams::new(0.9).with_direction_field(DirectionFieldMethod::ParallelTransport);
        let mut reused = RegionSolver::new(&mesh, &topology).unwrap();
        let first = deform_region(&mesh, &topology, &mut reused, &[&zone], &params).unwrap();
        assert_eq!(first.stats.numeric_factorizations, 5, "heat, Poisson, transport, u′, guide");
        let again = deform_region(&mesh, &topology, &mut reused, &[&zone], &params).unwrap();
        assert_eq!(reused.symbolic_analyses(), 2, "the real analysis and the complex one, once each");
        let mut fresh = RegionSolver::new(&mesh, &topology).unwrap();
        let third = deform_region(&mesh, &topology, &mut fresh, &[&zone], &params).unwrap();
        for other in [&again, &third] {
            assert_eq!(first.positions, other.positions);
            assert_eq!(first.directions, other.directions);
        }
        let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let fourth = single.install(|| {
            let mut s = RegionSolver::new(&mesh, &topology).unwrap();
            deform_region(&mesh, &topology, &mut s, &[&zone], &params).unwrap()
        });
        assert_eq!(first.positions, fourth.positions);
        assert!(first.stats.volume_exact);
    }
}
