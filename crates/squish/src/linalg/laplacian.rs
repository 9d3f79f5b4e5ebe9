//! The cotangent stiffness matrix with cut-face weights, the lumped mass matrix, and their linear
//! combinations ("operators") on a region's [`SparsePattern`] (thesis App. B §1–2, §5.1).
//!
//! Sign convention: the stiffness `K = −L` is **positive** semi-definite (the thesis' `L` is
//! negative): `K_ij = −½(w_f cot α_ij + w_g cot β_ij)` for `i ≠ j`, where α_ij, β_ij are the angles
//! opposite edge `ij` in its faces `f`, `g`, and `K_ii = −Σ_j K_ij`. Each face contributes its own
//! PSD element matrix `w_f · A_f ∇φ_i·∇φ_j` with a null space of constants, so `K·1 = 0` and
//! `vᵀKv ≥ 0` for any face weights `w_f ≥ 0`.
//!
//! Cut-face weighting (App. B): `w_f ∈ [0, 1]` is the fraction of face `f`'s area on the kept side
//! of the domain boundary (see [`super::cut_face_weights`]). Because the hat-function gradients
//! are constant on a face, `w_f · A_f ∇φ_i·∇φ_j` is the exact integral over the kept part of the
//! face: the weighted matrix is the P1 stiffness of the true, cut domain. The lumped mass matrix is
//! weighted the same way (a third of the kept area per corner).

use std::sync::Arc;

use glam::DVec3;

use super::{SolveError, SparsePattern, SymmetricMatrix};
use crate::mesh::TriMesh;

/// Checks a per-face weight array: one weight per face, each finite and in [0, 1].
pub(crate) fn check_face_weights(weights: Option<&[f64]>, num_faces: usize) -> Result<(), SolveError> {
    let Some(weights) = weights else { return Ok(()) };
    if weights.len() != num_faces {
        return Err(SolveError::DimensionMismatch { what: "face weights", expected: num_faces, actual: weights.len() });
    }
    match weights.iter().position(|w| !(0.0..=1.0).contains(w)) {
        Some(face) => Err(SolveError::InvalidFaceWeight { face, weight: weights[face] }),
        None => Ok(()),
    }
}

/// Weight of face `f`: 1 when no weights are given.
#[inline]
pub(crate) fn face_weight(weights: Option<&[f64]>, f: usize) -> f64 {
    weights.map_or(1.0, |w| w[f])
}

/// The cotangents of the three corner angles of a face and its unnormalized normal (length twice
/// the area), or [`SolveError::DegenerateFace`] when the face is too thin for cotangents to be
/// meaningful (same threshold as [`TriMesh::check_for_deformation`]).
pub(crate) fn face_cotangents(p: [DVec3; 3], face: usize) -> Result<([f64; 3], DVec3), SolveError> {
    let edge = [p[1] - p[0], p[2] - p[1], p[0] - p[2]];
    let normal = edge[0].cross(-edge[2]);
    let twice_area = normal.length();
    let longest_squared = edge.iter().map(|e| e.length_squared()).fold(0.0, f64::max);
    if twice_area.is_nan() || twice_area <= 1e-12 * longest_squared || twice_area.is_infinite() {
        return Err(SolveError::DegenerateFace { face, twice_area, longest_edge: longest_squared.sqrt() });
    }
    // Corner k sits between the outgoing edge k and the incoming edge k + 2.
    let cot = std::array::from_fn(|k| -edge[k].dot(edge[(k + 2) % 3]) / twice_area);
    Ok((cot, normal))
}

fn check_mesh_matches(mesh: &TriMesh, pattern: &SparsePattern) -> Result<(), SolveError> {
    if mesh.num_vertices() != pattern.num_vertices() {
        return Err(SolveError::DimensionMismatch {
            what: "mesh vertices",
            expected: pattern.num_vertices(),
            actual: mesh.num_vertices(),
        });
    }
    if mesh.triangles.as_slice() != pattern.triangles() {
        return Err(SolveError::PatternMismatch);
    }
    Ok(())
}

/// Adds `scale · K` (cotangent stiffness with optional face weights) into `values` on `pattern`.
/// Faces of weight 0 are skipped entirely, so a degenerate face outside the domain is harmless;
/// a face repeating a vertex has zero area and is reported by [`face_cotangents`].
fn add_stiffness(
    values: &mut [f64],
    mesh: &TriMesh,
    pattern: &SparsePattern,
    face_weights: Option<&[f64]>,
    scale: f64,
) -> Result<(), SolveError> {
    for (f, tri) in mesh.triangles.iter().enumerate() {
        let w = face_weight(face_weights, f);
        if w == 0.0 {
            continue;
        }
        let (cot, _) = face_cotangents(mesh.corners(f), f)?;
        let slots = pattern.face_edge_slots(f);
        for k in 0..3 {
            // Edge k joins corners k and k + 1; its opposite corner is k + 2.
            let half_cot = 0.5 * scale * w * cot[(k + 2) % 3];
            values[slots[k]] -= half_cot;
            values[pattern.diag_slot(tri[k])] += half_cot;
            values[pattern.diag_slot(tri[(k + 1) % 3])] += half_cot;
        }
    }
    Ok(())
}

/// The cotangent stiffness matrix `K` (positive semi-definite), with optional per-face weights
/// `w_f ∈ [0, 1]` (cut-face weighting, App. B; `None` = all 1 = the plain cotangent matrix).
pub fn cotangent_stiffness(
    mesh: &TriMesh,
    pattern: &Arc<SparsePattern>,
    face_weights: Option<&[f64]>,
) -> Result<SymmetricMatrix, SolveError> {
    check_mesh_matches(mesh, pattern)?;
    check_face_weights(face_weights, mesh.num_triangles())?;
    let mut k = SymmetricMatrix::zeros(pattern);
    add_stiffness(k.values_mut(), mesh, pattern, face_weights, 1.0)?;
    Ok(k)
}

/// The lumped (barycentric) mass matrix as a diagonal: a third of each face's kept area
/// `w_f · A_f` goes to each of its corners.
pub fn lumped_mass(mesh: &TriMesh, face_weights: Option<&[f64]>) -> Result<Vec<f64>, SolveError> {
    check_face_weights(face_weights, mesh.num_triangles())?;
    let mut mass = vec![0.0; mesh.num_vertices()];
    add_mass(&mut mass, mesh, face_weights);
    Ok(mass)
}

fn add_mass(mass: &mut [f64], mesh: &TriMesh, face_weights: Option<&[f64]>) {
    for (f, tri) in mesh.triangles.iter().enumerate() {
        let w = face_weight(face_weights, f);
        if w == 0.0 {
            continue;
        }
        let [a, b, c] = mesh.corners(f);
        let third = w * (b - a).cross(c - a).length() / 6.0;
        for &v in tri {
            mass[v as usize] += third;
        }
    }
}

/// A symmetric operator `a·M + b·K` on a region's pattern, before constraints are added: the
/// left-hand side of the heat step (`M + tK`), of the Poisson and harmonic problems (`K`).
///
/// It remembers what the constraint stage needs: the coefficient of `K` (which sets the constraint
/// weight, see [`Operator::constraint_scale`]), the mass diagonal (vertices with mass are never
/// singular) and the face weights (which faces connect their vertices).
#[derive(Clone, Debug)]
pub struct Operator {
    matrix: SymmetricMatrix,
    mass_coefficient: f64,
    stiffness_coefficient: f64,
    /// `mass_coefficient · M_ii`, empty when the mass coefficient is zero.
    mass_diagonal: Vec<f64>,
    /// The face weights used (all 1 when none were given).
    face_weights: Vec<f64>,
}

impl Operator {
    /// `a·M + b·K` with face weights (`None` = all 1). Both coefficients finite, `≥ 0`, not both 0.
    pub fn new(
        mesh: &TriMesh,
        pattern: &Arc<SparsePattern>,
        face_weights: Option<&[f64]>,
        mass_coefficient: f64,
        stiffness_coefficient: f64,
    ) -> Result<Self, SolveError> {
        let mut op = Self {
            matrix: SymmetricMatrix::zeros(pattern),
            mass_coefficient: 0.0,
            stiffness_coefficient: 0.0,
            mass_diagonal: Vec::new(),
            face_weights: Vec::new(),
        };
        op.reassemble(mesh, face_weights, mass_coefficient, stiffness_coefficient)?;
        Ok(op)
    }

    /// The stiffness `K` alone (Poisson, harmonic diffusion).
    pub fn stiffness(
        mesh: &TriMesh,
        pattern: &Arc<SparsePattern>,
        face_weights: Option<&[f64]>,
    ) -> Result<Self, SolveError> {
        Self::new(mesh, pattern, face_weights, 0.0, 1.0)
    }

    /// The backward-Euler heat step `M + tK` (§5.1, `t = 10h²` in the thesis).
    pub fn heat(
        mesh: &TriMesh,
        pattern: &Arc<SparsePattern>,
        face_weights: Option<&[f64]>,
        time: f64,
    ) -> Result<Self, SolveError> {
        Self::new(mesh, pattern, face_weights, 1.0, time)
    }

    /// Recomputes the values in place for new positions, weights or coefficients on the same
    /// pattern (a new frame): no allocation once the buffers have their size.
    pub fn reassemble(
        &mut self,
        mesh: &TriMesh,
        face_weights: Option<&[f64]>,
        mass_coefficient: f64,
        stiffness_coefficient: f64,
    ) -> Result<(), SolveError> {
        let valid = |c: f64| c.is_finite() && c >= 0.0;
        if !valid(mass_coefficient)
            || !valid(stiffness_coefficient)
            || (mass_coefficient == 0.0 && stiffness_coefficient == 0.0)
        {
            return Err(SolveError::InvalidCoefficients { mass: mass_coefficient, stiffness: stiffness_coefficient });
        }
        let pattern = Arc::clone(self.matrix.pattern());
        check_mesh_matches(mesh, &pattern)?;
        check_face_weights(face_weights, mesh.num_triangles())?;
        self.mass_coefficient = mass_coefficient;
        self.stiffness_coefficient = stiffness_coefficient;
        self.face_weights.clear();
        match face_weights {
            Some(w) => self.face_weights.extend_from_slice(w),
            None => self.face_weights.resize(mesh.num_triangles(), 1.0),
        }
        self.matrix.fill_zero();
        if stiffness_coefficient > 0.0 {
            add_stiffness(self.matrix.values_mut(), mesh, &pattern, face_weights, stiffness_coefficient)?;
        }
        self.add_mass_term(mesh, face_weights, mass_coefficient)
    }

    /// Reassembles `a·M + b·K` reusing `stiffness`, an operator `K` alone with the same face
    /// weights on the same pattern (the Poisson system of the same frame): its values are scaled
    /// by `b` instead of summing the cotangents again. The result equals [`Self::reassemble`]'s
    /// up to round-off (`b·Σ` instead of `Σ b·`).
    pub fn reassemble_from_stiffness(
        &mut self,
        mesh: &TriMesh,
        stiffness: &Operator,
        mass_coefficient: f64,
        stiffness_coefficient: f64,
    ) -> Result<(), SolveError> {
        let valid = |c: f64| c.is_finite() && c >= 0.0;
        if !(valid(mass_coefficient) && valid(stiffness_coefficient) && stiffness_coefficient > 0.0) {
            return Err(SolveError::InvalidCoefficients { mass: mass_coefficient, stiffness: stiffness_coefficient });
        }
        if stiffness.mass_coefficient != 0.0 || stiffness.stiffness_coefficient != 1.0 {
            return Err(SolveError::InvalidCoefficients {
                mass: stiffness.mass_coefficient,
                stiffness: stiffness.stiffness_coefficient,
            });
        }
        if !self.matrix.same_pattern(&stiffness.matrix) {
            return Err(SolveError::PatternMismatch);
        }
        check_mesh_matches(mesh, self.matrix.pattern())?;
        let face_weights = stiffness.face_weights.as_slice();
        check_face_weights(Some(face_weights), mesh.num_triangles())?;
        self.mass_coefficient = mass_coefficient;
        self.stiffness_coefficient = stiffness_coefficient;
        self.face_weights.clear();
        self.face_weights.extend_from_slice(face_weights);
        for (value, &k) in self.matrix.values_mut().iter_mut().zip(stiffness.matrix.values()) {
            *value = stiffness_coefficient * k;
        }
        self.add_mass_term(mesh, Some(face_weights), mass_coefficient)
    }

    /// Sets `mass_diagonal` to `a·M_ii` (empty when `a = 0`) and adds it to the matrix.
    fn add_mass_term(
        &mut self,
        mesh: &TriMesh,
        face_weights: Option<&[f64]>,
        mass_coefficient: f64,
    ) -> Result<(), SolveError> {
        self.mass_diagonal.clear();
        if mass_coefficient > 0.0 {
            self.mass_diagonal.resize(mesh.num_vertices(), 0.0);
            add_mass(&mut self.mass_diagonal, mesh, face_weights);
            for m in &mut self.mass_diagonal {
                *m *= mass_coefficient;
            }
            self.matrix.add_diagonal(&self.mass_diagonal, 1.0)?;
        }
        Ok(())
    }

    /// The assembled matrix `a·M + b·K`.
    pub fn matrix(&self) -> &SymmetricMatrix {
        &self.matrix
    }

    /// The pattern the operator lives on.
    pub fn pattern(&self) -> &Arc<SparsePattern> {
        self.matrix.pattern()
    }

    /// Coefficient `a` of the mass matrix.
    pub fn mass_coefficient(&self) -> f64 {
        self.mass_coefficient
    }

    /// Coefficient `b` of the stiffness matrix.
    pub fn stiffness_coefficient(&self) -> f64 {
        self.stiffness_coefficient
    }

    /// `a·M_ii` per vertex, or an empty slice when the operator has no mass term.
    pub fn mass_diagonal(&self) -> &[f64] {
        &self.mass_diagonal
    }

    /// The face weights the operator was assembled with (all 1 if none were given).
    pub fn face_weights(&self) -> &[f64] {
        &self.face_weights
    }

    /// The scale `s` of the operator's rows that sets the constraint weight `λ = 100·s`
    /// (App. B: constraint rows about 10× the operator rows).
    ///
    /// Rule: `s` is the coefficient of `K` when there is one. Cotangents are scale-free, so the
    /// rows of `K` have a norm of a few units on any mesh, about 10× the rows of `cᵀc` (entries
    /// ≤ 1): `λ = 100` is the thesis' β. In the heat step `M + tK` with `t = 10h²`, the `tK` part
    /// (rows ≈ 4t = 40h²) dominates `M` (rows ≈ h²), so `s = t` keeps the same ratio whatever
    /// the mesh size. For a pure mass operator (`b = 0`) the rows are `a·M_ii`, so `s` is their
    /// mean over vertices with mass (1 if none has mass).
    pub fn constraint_scale(&self) -> f64 {
        if self.stiffness_coefficient > 0.0 {
            return self.stiffness_coefficient;
        }
        let (sum, count) =
            self.mass_diagonal.iter().filter(|&&m| m > 0.0).fold((0.0, 0usize), |(s, c), &m| (s + m, c + 1));
        if count == 0 { 1.0 } else { sum / count as f64 }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::{Lcg, cut_icosphere};
    use crate::mesh::{Topology, face_areas, shapes, vertex_areas};

    /// Symmetry is structural (one stored value per edge), so check what the values mean: the
    /// quadratic form is the weighted Dirichlet energy `Σ_f w_f A_f |∇v|²` computed independently
    /// from face gradients, and constants are in the null space.
    fn assert_dirichlet_energy_and_constant_null_space(mesh: &TriMesh, weights: Option<&[f64]>, k: &SymmetricMatrix) {
        let n = k.dimension();
        let scale = (0..n as u32).map(|v| k.diagonal(v).abs()).fold(0.0, f64::max);
        let mut rng = Lcg::new(3);
        let v: Vec<f64> = (0..n).map(|_| rng.next_signed()).collect();
        let kv = k.apply(&v).unwrap();
        let quadratic: f64 = v.iter().zip(&kv).map(|(a, b)| a * b).sum();
        let areas = face_areas(mesh);
        let energy: f64 = crate::linalg::face_gradients(mesh, &v)
            .unwrap()
            .iter()
            .enumerate()
            .map(|(f, g)| weights.map_or(1.0, |w| w[f]) * areas[f] * g.length_squared())
            .sum();
        assert!((quadratic - energy).abs() < 1e-10 * energy, "vᵀKv = {quadratic}, energy {energy}");
        let ones = vec![1.0; n];
        let k1 = k.apply(&ones).unwrap();
        for (v, r) in k1.iter().enumerate() {
            assert!(r.abs() < 1e-12 * scale, "row {v} sums to {r}");
        }
    }

    fn assert_positive_semi_definite(k: &SymmetricMatrix, seed: u64) {
        let mut rng = Lcg::new(seed);
        let n = k.dimension();
        for _ in 0..20 {
            let v: Vec<f64> = (0..n).map(|_| rng.next_signed()).collect();
            let kv = k.apply(&v).unwrap();
            let energy: f64 = v.iter().zip(&kv).map(|(a, b)| a * b).sum();
            let norm: f64 = v.iter().map(|x| x * x).sum();
            assert!(energy >= -1e-12 * norm, "vᵀKv = {energy}");
        }
    }

    #[test]
    fn stiffness_is_the_dirichlet_energy_psd_with_constant_null_space_on_a_sphere() {
        let mesh = shapes::icosphere(1.3, 2);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let k = cotangent_stiffness(&mesh, &pattern, None).unwrap();
        assert_dirichlet_energy_and_constant_null_space(&mesh, None, &k);
        assert_positive_semi_definite(&k, 7);
        // Off-diagonals of a well-shaped sphere are negative, the diagonal positive.
        for v in 0..mesh.num_vertices() as u32 {
            assert!(k.diagonal(v) > 0.0);
        }
    }

    #[test]
    fn stiffness_is_the_dirichlet_energy_psd_with_constant_null_space_on_a_cut_region() {
        let (mesh, weights) = cut_icosphere();
        assert!(weights.iter().any(|&w| w > 0.0 && w < 1.0));
        assert!(weights.contains(&0.0));
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let k = cotangent_stiffness(&mesh, &pattern, Some(&weights)).unwrap();
        assert_dirichlet_energy_and_constant_null_space(&mesh, Some(&weights), &k);
        assert_positive_semi_definite(&k, 11);
    }

    #[test]
    fn unit_weights_give_the_plain_cotangent_matrix() {
        let mesh = shapes::capsule(0.5, 1.0, 12, 4, 3);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let plain = cotangent_stiffness(&mesh, &pattern, None).unwrap();
        let ones = vec![1.0; mesh.num_triangles()];
        let weighted = cotangent_stiffness(&mesh, &pattern, Some(&ones)).unwrap();
        assert_eq!(plain.values(), weighted.values());
        // And the plain matrix is the textbook formula, checked edge by edge.
        for (e, &[i, j]) in topology.edges().iter().enumerate() {
            let mut expected = 0.0;
            for f in topology.edge_faces(e as u32) {
                if f == crate::mesh::NO_FACE {
                    continue;
                }
                let t = mesh.triangles[f as usize];
                let o = *t.iter().find(|&&v| v != i && v != j).unwrap();
                let (po, pi, pj) = (mesh.positions[o as usize], mesh.positions[i as usize], mesh.positions[j as usize]);
                let (u, w) = (pi - po, pj - po);
                expected -= 0.5 * u.dot(w) / u.cross(w).length();
            }
            assert!((plain.get(i, j) - expected).abs() < 1e-12, "edge {e}");
        }
    }

    #[test]
    fn mass_is_the_weighted_barycentric_area() {
        let mesh = shapes::icosphere(2.0, 2);
        let mass = lumped_mass(&mesh, None).unwrap();
        let areas = vertex_areas(&mesh);
        for (m, a) in mass.iter().zip(&areas) {
            assert!((m - a).abs() < 1e-14);
        }
        let weights: Vec<f64> = (0..mesh.num_triangles()).map(|f| (f % 5) as f64 / 4.0).collect();
        let total: f64 = lumped_mass(&mesh, Some(&weights)).unwrap().iter().sum();
        let expected: f64 = face_areas(&mesh).iter().zip(&weights).map(|(a, w)| a * w).sum();
        assert!((total - expected).abs() < 1e-12);
    }

    #[test]
    fn heat_operator_is_mass_plus_t_stiffness_and_scales_constraints_by_t() {
        let mesh = shapes::grid(2.0, 1.0, 6, 3);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let t = 0.03;
        let heat = Operator::heat(&mesh, &pattern, None, t).unwrap();
        let mut expected = cotangent_stiffness(&mesh, &pattern, None).unwrap();
        for x in expected.values_mut() {
            *x *= t;
        }
        expected.add_diagonal(&lumped_mass(&mesh, None).unwrap(), 1.0).unwrap();
        for (a, b) in heat.matrix().values().iter().zip(expected.values()) {
            assert!((a - b).abs() < 1e-15);
        }
        assert_eq!(heat.constraint_scale(), t);
        assert_eq!(Operator::stiffness(&mesh, &pattern, None).unwrap().constraint_scale(), 1.0);
        let mass_only = Operator::new(&mesh, &pattern, None, 2.0, 0.0).unwrap();
        let mean_mass = 2.0 * vertex_areas(&mesh).iter().sum::<f64>() / mesh.num_vertices() as f64;
        assert!((mass_only.constraint_scale() - mean_mass).abs() < 1e-14);
        assert!(matches!(Operator::new(&mesh, &pattern, None, 0.0, 0.0), Err(SolveError::InvalidCoefficients { .. })));
    }

    #[test]
    fn heat_from_the_stiffness_operator_matches_a_full_assembly() {
        let (mesh, mut weights) = cut_icosphere();
        let pattern = SparsePattern::shared(&mesh, &Topology::new(&mesh)).unwrap();
        let mut rnd = Lcg::new(5);
        for w in &mut weights {
            *w *= rnd.next_unit();
        }
        let time = 0.037;
        let full = Operator::heat(&mesh, &pattern, Some(&weights), time).unwrap();
        let stiffness = Operator::stiffness(&mesh, &pattern, Some(&weights)).unwrap();
        let mut reused = Operator::stiffness(&mesh, &pattern, None).unwrap();
        reused.reassemble_from_stiffness(&mesh, &stiffness, 1.0, time).unwrap();
        for (a, b) in reused.matrix().values().iter().zip(full.matrix().values()) {
            assert!((a - b).abs() <= 1e-14 * b.abs().max(1.0), "{a} vs {b}");
        }
        assert_eq!(reused.mass_diagonal(), full.mass_diagonal());
        assert_eq!(reused.face_weights(), full.face_weights());
        assert_eq!(reused.constraint_scale(), full.constraint_scale());
        // Only a stiffness-only operator with unit coefficient can be reused, on the same pattern.
        assert!(reused.clone().reassemble_from_stiffness(&mesh, &full, 1.0, time).is_err());
        assert!(reused.clone().reassemble_from_stiffness(&mesh, &stiffness, 1.0, 0.0).is_err());
        let other = SparsePattern::shared(&mesh, &Topology::new(&mesh)).unwrap();
        let mut elsewhere = Operator::stiffness(&mesh, &other, None).unwrap();
        assert!(elsewhere.reassemble_from_stiffness(&mesh, &stiffness, 1.0, time).is_err());
    }

    #[test]
    fn bad_inputs_are_errors() {
        let mut mesh = shapes::grid(1.0, 1.0, 2, 2);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let mut weights = vec![1.0; mesh.num_triangles()];
        weights[3] = f64::NAN;
        assert!(matches!(
            cotangent_stiffness(&mesh, &pattern, Some(&weights)),
            Err(SolveError::InvalidFaceWeight { face: 3, .. })
        ));
        assert!(matches!(
            cotangent_stiffness(&mesh, &pattern, Some(&weights[..2])),
            Err(SolveError::DimensionMismatch { .. })
        ));
        // Collapse face 0 onto a line: an error while it has weight, ignored at weight 0.
        let t = mesh.triangles[0];
        mesh.positions[t[2] as usize] = 0.5 * (mesh.positions[t[0] as usize] + mesh.positions[t[1] as usize]);
        assert!(matches!(cotangent_stiffness(&mesh, &pattern, None), Err(SolveError::DegenerateFace { face: 0, .. })));
        let weights: Vec<f64> = mesh.triangles.iter().map(|tri| if tri.contains(&t[2]) { 0.0 } else { 1.0 }).collect();
        assert!(cotangent_stiffness(&mesh, &pattern, Some(&weights)).is_ok());
    }
}
