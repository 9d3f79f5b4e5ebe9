//! Least-squares edge constraints and the pinning of unreachable vertices (thesis App. B §2).
//!
//! A boundary condition along a polyline crossing mesh edges is a set of linear constraints
//! `c·v = (1 − α)v_i + αv_j = b` (α = 0: a plain vertex constraint). They are soft: we minimize
//! `½vᵀAv + ½λ‖Cv − b‖²` for the operator `A` (PSD: `K`, `M + tK`, …), whose normal equations
//! are `(A + λCᵀC)v = λCᵀb + f` (with an optional load `f`, e.g. `−div X`). The thesis writes
//! `(L + βCᵀC)v = βCᵀb` with β = −100 because its `L` is negative; with our `A` positive,
//! `λ = +100·s`, where `s` is the operator's [`Operator::constraint_scale`] (1 for `K`, `t` for
//! `M + tK`) so that constraint rows stay about 10× the operator rows at every mesh scale.
//! Each constraint adds `λ·cᵀc` to `(i, i)`, `(i, j)`, `(j, j)` — all in the region's pattern —
//! and `λ·b·c` to the right-hand side.
//!
//! Robustness: a vertex is *unreachable* when nothing determines its value — all its faces have
//! weight 0 (a zero row), or its connected component (through faces of positive weight) holds no
//! constraint and no mass. Such vertices make the matrix singular, so they are pinned: +1 on their
//! diagonal (always in the pattern, so the pattern never changes) and a caller-given default in
//! their right-hand side rows. A pinned component is decoupled from the rest (it shares no face of
//! positive weight nor constraint with it) and `K·1 = 0`, so it takes exactly the default value.
//!
//! Negligible links: a vertex held only by a constraint coefficient `c` gets its value as
//! `(b − c_j v_j)/c`, which amplifies round-off by `1/c`; a boundary point that slid to within
//! round-off of the far vertex (α = 1 − 10⁻¹⁵) would give such a vertex an arbitrary value. So a
//! coefficient below [`NEGLIGIBLE_CONSTRAINT_COEFFICIENT`] (10⁻⁸, error ≤ ~10⁻⁸ of the values)
//! does not count as determining its vertex, and a face whose weight is below
//! [`NEGLIGIBLE_FACE_WEIGHT`] (10⁻¹⁶, the square: near a cut, weights are products of two such
//! coefficients) does not connect its vertices. The entries are still assembled; a vertex left
//! undetermined is pinned, and its tiny couplings move its neighbours by less than ~10⁻⁸.
//!
//! Determination is judged per group of components linked by constraints: a component is anchored
//! by a vertex with positive mass or by a constraint whose vertices lie in it (or that touches a
//! single vertex); components linked only by two-vertex constraints across them are determined
//! when the group is anchored or has at least as many such links as components (generically
//! enough; a hand-made rank-deficient set of links is not detected and would fail to factorize,
//! which is reported as [`SolveError::NotPositiveDefinite`]).

use super::{Operator, SolveError, SymmetricMatrix};

/// The thesis' constraint weight factor (App. B): `λ = 100 × operator scale`.
pub const DEFAULT_CONSTRAINT_WEIGHT_FACTOR: f64 = 100.0;

/// A constraint coefficient below this does not determine its vertex (see the module doc).
pub const NEGLIGIBLE_CONSTRAINT_COEFFICIENT: f64 = 1e-8;

/// A face whose weight is below this does not connect its vertices when judging which vertices
/// are determined (see the module doc); its entries are still assembled.
pub const NEGLIGIBLE_FACE_WEIGHT: f64 = 1e-16;

/// A soft linear constraint `(1 − alpha)·v_i + alpha·v_j = value` on edge `(i, j)`.
/// With `alpha = 0` (or `i == j`) it constrains vertex `i` alone; `j` is then ignored.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EdgeConstraint {
    pub i: u32,
    pub j: u32,
    pub alpha: f64,
    pub value: f64,
}

impl EdgeConstraint {
    /// `(1 − alpha)·v_i + alpha·v_j = value`.
    pub fn on_edge(i: u32, j: u32, alpha: f64, value: f64) -> Self {
        Self { i, j, alpha, value }
    }

    /// `v_i = value`.
    pub fn vertex(i: u32, value: f64) -> Self {
        Self { i, j: i, alpha: 0.0, value }
    }
}

/// Parameters of the constraint assembly.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConstraintParams {
    /// `λ = weight_factor × operator scale`. Default [`DEFAULT_CONSTRAINT_WEIGHT_FACTOR`] (100).
    pub weight_factor: f64,
}

impl Default for ConstraintParams {
    fn default() -> Self {
        Self { weight_factor: DEFAULT_CONSTRAINT_WEIGHT_FACTOR }
    }
}

impl ConstraintParams {
    /// With another weight factor.
    pub fn with_weight_factor(mut self, weight_factor: f64) -> Self {
        self.weight_factor = weight_factor;
        self
    }
}

/// One constraint resolved on the pattern: its nonzero coefficients and where `cᵀc` goes.
#[derive(Clone, Copy, Debug)]
struct ConstraintRow {
    i: u32,
    ci: f64,
    /// Second vertex, or `u32::MAX` for a single-vertex constraint.
    j: u32,
    cj: f64,
    /// Slot of `(i, j)` in the pattern (unused for a single-vertex constraint).
    edge_slot: usize,
}

const NO_VERTEX: u32 = u32::MAX;

/// The constrained system matrix `A + λCᵀC + pins` of one operator and one constraint set, and
/// what is needed to build any number of right-hand sides for it (one per set of constraint
/// values: the pipeline diffuses the three direction components, or `a` and `s`, on one matrix).
#[derive(Clone, Debug)]
pub struct ConstrainedSystem {
    matrix: SymmetricMatrix,
    weight: f64,
    rows: Vec<ConstraintRow>,
    values: Vec<f64>,
    pinned: Vec<u32>,
    /// False after a failed reassembly, until the next success.
    assembled: bool,
    // Scratch of the reachability analysis, kept to reassemble without allocating.
    union_find: Vec<u32>,
    component: Vec<u32>,
    group: Vec<Group>,
}

#[derive(Clone, Copy, Debug, Default)]
struct Group {
    anchored: bool,
    components: u32,
    links: u32,
}

/// Root of `v` in the union-find forest `parent` (path halving).
pub(crate) fn find(parent: &mut [u32], mut v: u32) -> u32 {
    while parent[v as usize] != v {
        let grand = parent[parent[v as usize] as usize];
        parent[v as usize] = grand;
        v = grand;
    }
    v
}

/// Resets `parent` to the union-find forest of the operator's vertices joined through faces of
/// weight ≥ [`NEGLIGIBLE_FACE_WEIGHT`] (the components the operator alone connects).
pub(crate) fn union_through_faces(parent: &mut Vec<u32>, operator: &Operator) {
    let pattern = operator.pattern();
    parent.clear();
    parent.extend(0..pattern.num_vertices() as u32);
    for (tri, &w) in pattern.triangles().iter().zip(operator.face_weights()) {
        if w >= NEGLIGIBLE_FACE_WEIGHT {
            let r0 = find(parent, tri[0]);
            for &v in &tri[1..] {
                let r = find(parent, v);
                if r != r0 {
                    parent[r as usize] = r0;
                }
            }
        }
    }
}

impl ConstrainedSystem {
    /// Assembles `A + λCᵀC`, pins unreachable vertices. `λ = params.weight_factor ×
    /// operator.constraint_scale()`.
    pub fn new(
        operator: &Operator,
        constraints: &[EdgeConstraint],
        params: &ConstraintParams,
    ) -> Result<Self, SolveError> {
        let mut system = Self {
            matrix: operator.matrix().clone(),
            weight: 0.0,
            rows: Vec::with_capacity(constraints.len()),
            values: Vec::with_capacity(constraints.len()),
            pinned: Vec::new(),
            assembled: false,
            union_find: Vec::new(),
            component: Vec::new(),
            group: Vec::new(),
        };
        system.reassemble(operator, constraints, params)?;
        Ok(system)
    }

    /// Reassembles in place for a new operator (same pattern) and/or constraints: a new frame.
    /// After an error the system refuses to build right-hand sides until a successful reassembly.
    pub fn reassemble(
        &mut self,
        operator: &Operator,
        constraints: &[EdgeConstraint],
        params: &ConstraintParams,
    ) -> Result<(), SolveError> {
        self.assembled = false;
        if !operator.matrix().same_pattern(&self.matrix) {
            return Err(SolveError::PatternMismatch);
        }
        if !(params.weight_factor.is_finite() && params.weight_factor > 0.0) {
            return Err(SolveError::InvalidWeightFactor { factor: params.weight_factor });
        }
        let pattern = std::sync::Arc::clone(operator.pattern());
        let n = pattern.num_vertices();
        self.weight = params.weight_factor * operator.constraint_scale();
        self.rows.clear();
        self.values.clear();
        for (k, c) in constraints.iter().enumerate() {
            if !c.alpha.is_finite() || !c.value.is_finite() {
                return Err(SolveError::NonFiniteConstraint { constraint: k, alpha: c.alpha, value: c.value });
            }
            for v in [c.i, c.j] {
                if v as usize >= n {
                    return Err(SolveError::VertexOutOfRange { what: "constraint", vertex: v, vertices: n });
                }
            }
            let row = if c.i == c.j || c.alpha == 0.0 {
                ConstraintRow { i: c.i, ci: 1.0, j: NO_VERTEX, cj: 0.0, edge_slot: 0 }
            } else if c.alpha == 1.0 {
                ConstraintRow { i: c.j, ci: 1.0, j: NO_VERTEX, cj: 0.0, edge_slot: 0 }
            } else {
                let edge_slot =
                    pattern.slot(c.i, c.j).ok_or(SolveError::ConstraintNotOnEdge { constraint: k, i: c.i, j: c.j })?;
                ConstraintRow { i: c.i, ci: 1.0 - c.alpha, j: c.j, cj: c.alpha, edge_slot }
            };
            self.rows.push(row);
            self.values.push(c.value);
        }

        self.matrix.values_mut().copy_from_slice(operator.matrix().values());
        let lambda = self.weight;
        for row in &self.rows {
            let values = self.matrix.values_mut();
            values[pattern.diag_slot(row.i)] += lambda * row.ci * row.ci;
            if row.j != NO_VERTEX {
                values[pattern.diag_slot(row.j)] += lambda * row.cj * row.cj;
                values[row.edge_slot] += lambda * row.ci * row.cj;
            }
        }

        self.find_unreachable(operator);
        for &v in &self.pinned {
            let slot = pattern.diag_slot(v);
            self.matrix.values_mut()[slot] += 1.0;
        }
        self.assembled = true;
        Ok(())
    }

    /// Fills `self.pinned` with the vertices nothing determines (see the module doc).
    ///
    /// With a mass term every vertex of a non-negligible face has mass, so its component is
    /// anchored whichever it is: each vertex can stay its own component (the faces' vertices are
    /// anchored one by one). Constraints between two of them then count as links between
    /// anchored groups instead of anchors inside one component: anchored either way, and the
    /// groups that stay unanchored (vertices without such a face) are the same. The same
    /// vertices are pinned, without the union-find over the faces (tested against it).
    fn find_unreachable(&mut self, operator: &Operator) {
        self.find_unreachable_with(operator, operator.mass_coefficient() > 0.0);
    }

    /// [`Self::find_unreachable`], with every vertex its own component (`vertex_components`,
    /// valid with a mass term) or the components through the faces.
    fn find_unreachable_with(&mut self, operator: &Operator, vertex_components: bool) {
        let pattern = operator.pattern();
        let n = pattern.num_vertices();
        if vertex_components {
            self.union_find.clear();
            self.union_find.extend(0..n as u32);
        } else {
            // Components through faces of non-negligible weight.
            union_through_faces(&mut self.union_find, operator);
        }
        let parent = &mut self.union_find;
        // Freeze the component of every vertex; component roots are their own parents, so the same
        // union-find then groups components through constraint links.
        let component = &mut self.component;
        component.clear();
        for v in 0..n as u32 {
            component.push(find(parent, v));
        }
        let group = &mut self.group;
        group.clear();
        group.resize(n, Group::default());
        for v in 0..n {
            if component[v] == v as u32 {
                group[v].components = 1;
            }
        }
        // A mass term anchors every vertex of a non-negligible face (they all have mass).
        if operator.mass_coefficient() > 0.0 {
            for (tri, &w) in pattern.triangles().iter().zip(operator.face_weights()) {
                if w >= NEGLIGIBLE_FACE_WEIGHT {
                    for &v in tri {
                        group[component[v as usize] as usize].anchored = true;
                    }
                }
            }
        }
        for row in &self.rows {
            let holds_i = row.ci.abs() >= NEGLIGIBLE_CONSTRAINT_COEFFICIENT;
            let holds_j = row.j != NO_VERTEX && row.cj.abs() >= NEGLIGIBLE_CONSTRAINT_COEFFICIENT;
            let (anchor, link) = match (holds_i, holds_j) {
                (true, true) if component[row.i as usize] == component[row.j as usize] => (Some(row.i), None),
                (true, true) => (None, Some((row.i, row.j))),
                (true, false) => (Some(row.i), None),
                (false, true) => (Some(row.j), None),
                // Coefficients summing to 1 cannot both be negligible.
                (false, false) => (None, None),
            };
            if let Some(v) = anchor {
                let g = find(parent, component[v as usize]);
                group[g as usize].anchored = true;
            }
            if let Some((i, j)) = link {
                let (gi, gj) = (find(parent, component[i as usize]), find(parent, component[j as usize]));
                if gi == gj {
                    group[gi as usize].links += 1;
                } else {
                    parent[gj as usize] = gi;
                    let merged = group[gj as usize];
                    let g = &mut group[gi as usize];
                    g.anchored |= merged.anchored;
                    g.components += merged.components;
                    g.links += merged.links + 1;
                }
            }
        }
        self.pinned.clear();
        for v in 0..n as u32 {
            let g = group[find(parent, v) as usize];
            if !(g.anchored || g.links >= g.components) {
                self.pinned.push(v);
            }
        }
    }

    /// The assembled matrix `A + λCᵀC + pins`.
    pub fn matrix(&self) -> &SymmetricMatrix {
        &self.matrix
    }

    /// The constraint weight λ used.
    pub fn weight(&self) -> f64 {
        self.weight
    }

    /// Number of constraints.
    pub fn num_constraints(&self) -> usize {
        self.rows.len()
    }

    /// The pinned (unreachable) vertices, in increasing id.
    pub fn pinned_vertices(&self) -> &[u32] {
        &self.pinned
    }

    /// The right-hand side for the constraints' own values: `λCᵀb + load`, with pinned rows set to
    /// `pin_value`. `load` is an optional per-vertex term (e.g. `−div X` of the Poisson step).
    pub fn rhs_into(&self, load: Option<&[f64]>, pin_value: f64, out: &mut [f64]) -> Result<(), SolveError> {
        self.rhs_with_values_into(&self.values, load, pin_value, out)
    }

    /// The right-hand side for other constraint values (one per constraint, same order), on the
    /// same matrix.
    pub fn rhs_with_values_into(
        &self,
        values: &[f64],
        load: Option<&[f64]>,
        pin_value: f64,
        out: &mut [f64],
    ) -> Result<(), SolveError> {
        if !self.assembled {
            return Err(SolveError::NotAssembled);
        }
        let n = self.matrix.dimension();
        if values.len() != self.rows.len() {
            return Err(SolveError::DimensionMismatch {
                what: "constraint values",
                expected: self.rows.len(),
                actual: values.len(),
            });
        }
        if out.len() != n {
            return Err(SolveError::DimensionMismatch { what: "right-hand side", expected: n, actual: out.len() });
        }
        if let Some((index, &value)) = values.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            return Err(SolveError::NonFiniteValue { what: "constraint values", index, value });
        }
        if !pin_value.is_finite() {
            return Err(SolveError::NonFiniteValue { what: "pin value", index: 0, value: pin_value });
        }
        match load {
            Some(load) => {
                if load.len() != n {
                    return Err(SolveError::DimensionMismatch { what: "load", expected: n, actual: load.len() });
                }
                if let Some((index, &value)) = load.iter().enumerate().find(|(_, x)| !x.is_finite()) {
                    return Err(SolveError::NonFiniteValue { what: "load", index, value });
                }
                out.copy_from_slice(load);
            }
            None => out.fill(0.0),
        }
        for (row, &b) in self.rows.iter().zip(values) {
            out[row.i as usize] += self.weight * b * row.ci;
            if row.j != NO_VERTEX {
                out[row.j as usize] += self.weight * b * row.cj;
            }
        }
        for &v in &self.pinned {
            out[v as usize] = pin_value;
        }
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::{SparsePattern, cotangent_stiffness};
    use crate::mesh::{Topology, TriMesh, shapes};
    use glam::DVec3;

    #[test]
    fn constraints_add_lambda_ct_c_and_lambda_b_c() {
        let mesh = shapes::grid(1.0, 1.0, 3, 3);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let op = Operator::stiffness(&mesh, &pattern, None).unwrap();
        let constraints = [EdgeConstraint::on_edge(5, 6, 0.25, 2.0), EdgeConstraint::vertex(0, -1.0)];
        let system = ConstrainedSystem::new(&op, &constraints, &ConstraintParams::default()).unwrap();
        assert_eq!(system.weight(), 100.0);
        assert!(system.pinned_vertices().is_empty());
        let k = cotangent_stiffness(&mesh, &pattern, None).unwrap();
        let delta = |i, j| system.matrix().get(i, j) - k.get(i, j);
        assert!((delta(5, 5) - 100.0 * 0.75 * 0.75).abs() < 1e-12);
        assert!((delta(6, 6) - 100.0 * 0.25 * 0.25).abs() < 1e-12);
        assert!((delta(5, 6) - 100.0 * 0.75 * 0.25).abs() < 1e-12);
        assert!((delta(6, 5) - 100.0 * 0.75 * 0.25).abs() < 1e-12);
        assert!((delta(0, 0) - 100.0).abs() < 1e-12);
        let mut rhs = vec![0.0; mesh.num_vertices()];
        system.rhs_into(None, 0.0, &mut rhs).unwrap();
        assert!((rhs[5] - 100.0 * 2.0 * 0.75).abs() < 1e-12);
        assert!((rhs[6] - 100.0 * 2.0 * 0.25).abs() < 1e-12);
        assert!((rhs[0] + 100.0).abs() < 1e-12);
        assert_eq!(rhs.iter().filter(|&&x| x != 0.0).count(), 3);
        // The heat operator scales λ by its time.
        let heat = Operator::heat(&mesh, &pattern, None, 0.01).unwrap();
        let system = ConstrainedSystem::new(&heat, &constraints, &ConstraintParams::default()).unwrap();
        assert!((system.weight() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn the_sign_convention_makes_the_system_positive_definite() {
        // With K positive semi-definite, +λ (not the thesis' −100 for its negative L) gives a
        // positive definite matrix: vᵀ(K + λCᵀC)v > 0 for all v ≠ 0 once a constraint anchors.
        let mesh = shapes::icosphere(1.0, 1);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let op = Operator::stiffness(&mesh, &pattern, None).unwrap();
        let system =
            ConstrainedSystem::new(&op, &[EdgeConstraint::vertex(3, 1.0)], &ConstraintParams::default()).unwrap();
        let ones = vec![1.0; mesh.num_vertices()];
        let a1 = system.matrix().apply(&ones).unwrap();
        let energy: f64 = a1.iter().sum();
        assert!((energy - 100.0).abs() < 1e-9, "1ᵀA1 = {energy}: only the constraint sees constants");
    }

    #[test]
    fn invalid_constraints_are_errors() {
        let mesh = shapes::grid(1.0, 1.0, 2, 2);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let op = Operator::stiffness(&mesh, &pattern, None).unwrap();
        let p = ConstraintParams::default();
        let far = (1..9).find(|&v| topology.edge_between(0, v).is_none()).unwrap();
        assert!(matches!(
            ConstrainedSystem::new(&op, &[EdgeConstraint::on_edge(0, far, 0.5, 1.0)], &p),
            Err(SolveError::ConstraintNotOnEdge { constraint: 0, .. })
        ));
        assert!(matches!(
            ConstrainedSystem::new(&op, &[EdgeConstraint::vertex(0, 0.0), EdgeConstraint::vertex(9, 0.0)], &p),
            Err(SolveError::VertexOutOfRange { vertex: 9, .. })
        ));
        assert!(matches!(
            ConstrainedSystem::new(&op, &[EdgeConstraint::on_edge(0, 1, f64::NAN, 0.0)], &p),
            Err(SolveError::NonFiniteConstraint { .. })
        ));
        assert!(matches!(
            ConstrainedSystem::new(&op, &[], &p.with_weight_factor(-1.0)),
            Err(SolveError::InvalidWeightFactor { .. })
        ));
        // A failed reassembly leaves the system unusable until the next success.
        let mut system = ConstrainedSystem::new(&op, &[EdgeConstraint::vertex(0, 1.0)], &p).unwrap();
        assert!(system.reassemble(&op, &[EdgeConstraint::vertex(99, 1.0)], &p).is_err());
        let mut rhs = vec![0.0; 9];
        assert_eq!(system.rhs_into(None, 0.0, &mut rhs), Err(SolveError::NotAssembled));
        system.reassemble(&op, &[EdgeConstraint::vertex(1, 1.0)], &p).unwrap();
        assert!(system.rhs_into(None, 0.0, &mut rhs).is_ok());
        // α = 1 is a vertex constraint on j: no edge needed.
        assert!(ConstrainedSystem::new(&op, &[EdgeConstraint::on_edge(0, far, 1.0, 1.0)], &p).is_ok());
    }

    fn two_spheres() -> TriMesh {
        let mut mesh = shapes::icosphere(1.0, 1);
        let mut other = shapes::icosphere(1.0, 1);
        other.map_positions(|p| p + DVec3::new(3.0, 0.0, 0.0));
        mesh.append(&other);
        mesh
    }

    #[test]
    fn unconstrained_components_and_zero_rows_are_pinned() {
        let mesh = two_spheres();
        let half = mesh.num_vertices() as u32 / 2;
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let op = Operator::stiffness(&mesh, &pattern, None).unwrap();
        let system =
            ConstrainedSystem::new(&op, &[EdgeConstraint::vertex(0, 1.0)], &ConstraintParams::default()).unwrap();
        assert_eq!(system.pinned_vertices(), (half..2 * half).collect::<Vec<_>>().as_slice());

        // Faces of weight 0 disconnect their vertices: with every face of vertex 5 at weight 0,
        // vertex 5 is pinned even though its sphere is constrained.
        let mut weights = vec![1.0; mesh.num_triangles()];
        for (f, t) in mesh.triangles.iter().enumerate() {
            if t.contains(&5) {
                weights[f] = 0.0;
            }
        }
        let op = Operator::stiffness(&mesh, &pattern, Some(&weights)).unwrap();
        let constraints = [EdgeConstraint::vertex(0, 1.0), EdgeConstraint::vertex(half, 2.0)];
        let system = ConstrainedSystem::new(&op, &constraints, &ConstraintParams::default()).unwrap();
        assert_eq!(system.pinned_vertices(), &[5]);

        // A mass term determines every vertex with mass: only the zero row remains pinned.
        let op = Operator::heat(&mesh, &pattern, Some(&weights), 0.1).unwrap();
        let system = ConstrainedSystem::new(&op, &[], &ConstraintParams::default()).unwrap();
        assert_eq!(system.pinned_vertices(), &[5]);
    }

    #[test]
    fn with_a_mass_term_the_pinned_vertices_are_those_of_the_components_rule() {
        // Random face weights (0, round-off sized or 1) on two spheres and random constraints
        // (single vertices, links inside and across components, negligible coefficients): the
        // heat operator's shortcut (no union-find over the faces) pins exactly the vertices the
        // general rule pins (the stiffness operator takes the general rule itself).
        let mesh = two_spheres();
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let mut lcg = crate::linalg::test_support::Lcg::from_state(99);
        let edges = topology.edges().to_vec();
        let mut pinned_cases = 0;
        for case in 0..60 {
            let zero_fraction = 0.2 + 0.7 * (case % 4) as f64 / 3.0;
            let weights: Vec<f64> = (0..mesh.num_triangles())
                .map(|_| {
                    let x = lcg.next_unit();
                    if x < zero_fraction {
                        0.0
                    } else if x < zero_fraction + 0.05 {
                        1e-20
                    } else {
                        1.0
                    }
                })
                .collect();
            let constraints: Vec<EdgeConstraint> = (0..(case % 7))
                .map(|k| {
                    let [i, j] = edges[(lcg.next_unit() * edges.len() as f64) as usize % edges.len()];
                    let alpha = [0.0, 0.5, 1e-12, 1.0 - 1e-12, 0.3][k % 5];
                    EdgeConstraint::on_edge(i, j, alpha, 1.0)
                })
                .collect();
            for op in [
                Operator::heat(&mesh, &pattern, Some(&weights), 0.05).unwrap(),
                Operator::stiffness(&mesh, &pattern, Some(&weights)).unwrap(),
            ] {
                let system = ConstrainedSystem::new(&op, &constraints, &ConstraintParams::default()).unwrap();
                // The general rule: components through the faces, whatever the operator.
                let mut general = ConstrainedSystem::new(&op, &constraints, &ConstraintParams::default()).unwrap();
                general.find_unreachable_with(&op, false);
                assert_eq!(system.pinned_vertices(), general.pinned_vertices(), "case {case}");
                pinned_cases += usize::from(!system.pinned_vertices().is_empty());
            }
        }
        assert!(pinned_cases > 20, "the cases pin vertices: {pinned_cases}");
    }

    #[test]
    fn vertices_held_only_by_round_off_sized_coefficients_are_pinned() {
        // A zone whose boundary points slid to within 1e-15 of the outside vertices: the inside
        // vertices next to the cut keep faces of weight ~1e-30 and constraint coefficients
        // ~1e-15, which cannot determine a value in floating point.
        let mesh = shapes::grid(1.0, 1.0, 10, 10);
        let topology = Topology::new(&mesh);
        let inside: Vec<bool> = mesh.positions.iter().map(|p| p.length() < 0.15).collect();
        let mut points = Vec::new();
        for &[a, b] in topology.edges() {
            if inside[a as usize] != inside[b as usize] {
                let (i, o) = if inside[a as usize] { (a, b) } else { (b, a) };
                points.push(crate::linalg::EdgePoint { inside: i, outside: o, alpha: 1.0 - 1e-15 });
            }
        }
        let weights = crate::linalg::cut_face_weights(&mesh, &topology, &inside, &points).unwrap();
        let constraints: Vec<EdgeConstraint> =
            points.iter().map(|p| EdgeConstraint::on_edge(p.inside, p.outside, p.alpha, 1.0)).collect();
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let op = Operator::stiffness(&mesh, &pattern, Some(&weights)).unwrap();
        let mut solver = crate::linalg::ConstrainedSolver::new(
            &crate::linalg::SymbolicFactor::analyze(&pattern).unwrap(),
            &op,
            &constraints,
            &ConstraintParams::default(),
        )
        .unwrap();
        let pinned = solver.system().pinned_vertices().to_vec();
        let centre = 60u32;
        assert!(pinned.contains(&centre));
        assert!(pinned.len() >= 3, "{pinned:?}");
        assert!(pinned.iter().all(|&v| inside[v as usize]));
        let v = solver.solve(&crate::linalg::RightHandSide { pin_value: -2.0, ..Default::default() }).unwrap();
        for (i, x) in v.iter().enumerate() {
            let expected = if pinned.contains(&(i as u32)) { -2.0 } else { 1.0 };
            assert!((x - expected).abs() < 1e-9, "vertex {i}: {x}, expected {expected}");
        }
    }

    #[test]
    fn components_linked_by_constraints_are_judged_together() {
        let mesh = two_spheres();
        let half = mesh.num_vertices() as u32 / 2;
        // Make (0, half) an edge of the pattern by building it on a mesh with one extra face.
        let mut bridged = mesh.clone();
        bridged.triangles.push([0, half, half + 1]);
        let bridged_topology = Topology::new(&bridged);
        let bridged_pattern = SparsePattern::shared(&bridged, &bridged_topology).unwrap();
        let mut weights = vec![1.0; bridged.num_triangles()];
        *weights.last_mut().unwrap() = 0.0; // the bridge face is not part of the domain
        let op = Operator::stiffness(&bridged, &bridged_pattern, Some(&weights)).unwrap();
        let p = ConstraintParams::default();
        // One link between two free components leaves one degree of freedom: both pinned.
        let link = EdgeConstraint::on_edge(0, half, 0.5, 1.0);
        let system = ConstrainedSystem::new(&op, &[link], &p).unwrap();
        assert_eq!(system.pinned_vertices().len(), mesh.num_vertices());
        // A link plus an anchor on one side determines both.
        let system = ConstrainedSystem::new(&op, &[link, EdgeConstraint::vertex(1, 0.0)], &p).unwrap();
        assert!(system.pinned_vertices().is_empty());
        // Two independent links determine both constants too.
        let system = ConstrainedSystem::new(&op, &[link, EdgeConstraint::on_edge(0, half, 0.25, 3.0)], &p).unwrap();
        assert!(system.pinned_vertices().is_empty());
    }
}
