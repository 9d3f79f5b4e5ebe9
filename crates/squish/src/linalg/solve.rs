//! Constrained solves on a working region: factor once, solve many right-hand sides, refactor in
//! place for the next frame (thesis App. B, §5.1, §5.3; ch. 7 §5.2 for why reuse matters), plus a
//! one-shot harmonic solve.

use std::sync::Arc;

use super::{
    ConstrainedSystem, ConstraintParams, EdgeConstraint, NumericFactor, Operator, SolveError, SparsePattern,
    SymbolicFactor,
};
use crate::mesh::{Topology, TriMesh};

/// One right-hand side of a [`ConstrainedSolver`]: `λCᵀb + load`, pinned rows set to `pin_value`.
#[derive(Clone, Copy, Debug, Default)]
pub struct RightHandSide<'a> {
    /// One value `b` per constraint (same order); `None` = the constraints' own `value`s.
    pub constraint_values: Option<&'a [f64]>,
    /// Per-vertex load added to the right-hand side (e.g. `−div X` for the Poisson step).
    pub load: Option<&'a [f64]>,
    /// Value of the pinned (unreachable) vertices.
    pub pin_value: f64,
}

/// A factorized constrained system `(A + λCᵀC + pins) v = rhs` on a region.
#[derive(Debug)]
pub struct ConstrainedSolver {
    system: ConstrainedSystem,
    factor: NumericFactor,
    rhs: Vec<f64>,
}

impl ConstrainedSolver {
    /// Assembles and factorizes on the region's shared symbolic analysis.
    pub fn new(
        symbolic: &Arc<SymbolicFactor>,
        operator: &Operator,
        constraints: &[EdgeConstraint],
        params: &ConstraintParams,
    ) -> Result<Self, SolveError> {
        let system = ConstrainedSystem::new(operator, constraints, params)?;
        let factor = NumericFactor::factorize_new(symbolic, system.matrix())?;
        Ok(Self { system, factor, rhs: Vec::new() })
    }

    /// Reassembles and refactorizes in place for a new operator and/or constraints on the same
    /// pattern (the next frame): the symbolic analysis and all storage are reused. After an error
    /// the solver refuses to solve until a successful update.
    pub fn update(
        &mut self,
        operator: &Operator,
        constraints: &[EdgeConstraint],
        params: &ConstraintParams,
    ) -> Result<(), SolveError> {
        // A failed reassembly leaves the system unassembled, so solves fail at the rhs stage.
        self.system.reassemble(operator, constraints, params)?;
        self.factor.factorize(self.system.matrix())
    }

    /// The numeric factor (its layout and analysis counts).
    pub fn factor(&self) -> &NumericFactor {
        &self.factor
    }

    /// The assembled system (matrix, weight λ, pinned vertices).
    pub fn system(&self) -> &ConstrainedSystem {
        &self.system
    }

    /// Solves for one right-hand side.
    pub fn solve(&mut self, rhs: &RightHandSide<'_>) -> Result<Vec<f64>, SolveError> {
        let mut out = self.solve_many(std::slice::from_ref(rhs))?;
        Ok(out.pop().unwrap_or_default())
    }

    /// Solves for several right-hand sides with one multi-column triangular solve.
    pub fn solve_many(&mut self, rhs: &[RightHandSide<'_>]) -> Result<Vec<Vec<f64>>, SolveError> {
        let n = self.system.matrix().dimension();
        self.rhs.clear();
        self.rhs.resize(n * rhs.len(), 0.0);
        for (column, r) in self.rhs.chunks_exact_mut(n.max(1)).zip(rhs) {
            match r.constraint_values {
                Some(values) => self.system.rhs_with_values_into(values, r.load, r.pin_value, column)?,
                None => self.system.rhs_into(r.load, r.pin_value, column)?,
            }
        }
        self.factor.solve_columns_in_place(&mut self.rhs, rhs.len())?;
        Ok(self.rhs.chunks_exact(n.max(1)).take(rhs.len()).map(<[f64]>::to_vec).collect())
    }
}

/// One-shot harmonic interpolation: minimizes the (face-weighted) Dirichlet energy `½vᵀKv` with
/// the soft constraints (`λ = 100`), Neumann elsewhere; unreachable vertices get `pin_value`.
pub fn solve_harmonic(
    mesh: &TriMesh,
    topology: &Topology,
    face_weights: Option<&[f64]>,
    constraints: &[EdgeConstraint],
    pin_value: f64,
) -> Result<Vec<f64>, SolveError> {
    let pattern = SparsePattern::shared(mesh, topology)?;
    let symbolic = SymbolicFactor::analyze(&pattern)?;
    let operator = Operator::stiffness(mesh, &pattern, face_weights)?;
    let mut solver = ConstrainedSolver::new(&symbolic, &operator, constraints, &ConstraintParams::default())?;
    solver.solve(&RightHandSide { pin_value, ..Default::default() })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::{circle_cut, level_set_cut};
    use crate::linalg::{cut_face_weights, face_gradients, integrated_divergence};
    use crate::mesh::{mean_edge_length, shapes};
    use glam::DVec3;

    fn linear(p: DVec3) -> f64 {
        2.0 * p.x - 3.0 * p.y + 1.0
    }

    /// A flat grid whose kept domain is a disk: removed side = outside the circle, constraints
    /// sampling `linear` at the crossings of the circle. Returns the largest error at the vertices
    /// that are not pinned, at those on the kept side, and the number of pinned vertices.
    fn disk_with_linear_boundary(weight_factor: f64) -> (f64, f64, usize) {
        let mesh = shapes::grid(2.0, 2.0, 30, 30);
        let topology = Topology::new(&mesh);
        let centre = DVec3::new(0.1, -0.05, 0.0);
        let (removed, points) = level_set_cut(&mesh, &topology, |p| (p - centre).length() - 0.6);
        let weights = cut_face_weights(&mesh, &topology, &removed, &points).unwrap();
        let constraints: Vec<EdgeConstraint> = points
            .iter()
            .map(|p| {
                let at =
                    (1.0 - p.alpha) * mesh.positions[p.inside as usize] + p.alpha * mesh.positions[p.outside as usize];
                EdgeConstraint::on_edge(p.inside, p.outside, p.alpha, linear(at))
            })
            .collect();
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let symbolic = SymbolicFactor::analyze(&pattern).unwrap();
        let operator = Operator::stiffness(&mesh, &pattern, Some(&weights)).unwrap();
        let params = ConstraintParams::default().with_weight_factor(weight_factor);
        let mut solver = ConstrainedSolver::new(&symbolic, &operator, &constraints, &params).unwrap();
        let v = solver.solve(&RightHandSide { pin_value: -7.0, ..Default::default() }).unwrap();
        let pinned = solver.system().pinned_vertices();
        let (mut worst, mut worst_kept) = (0.0f64, 0.0f64);
        for (i, p) in mesh.positions.iter().enumerate() {
            if pinned.binary_search(&(i as u32)).is_ok() {
                assert_eq!(v[i], -7.0);
            } else {
                let error = (v[i] - linear(*p)).abs();
                worst = worst.max(error);
                if !removed[i] {
                    worst_kept = worst_kept.max(error);
                }
            }
        }
        (worst, worst_kept, pinned.len())
    }

    #[test]
    fn harmonic_solve_reproduces_a_linear_function_from_a_closed_curve_of_edge_points() {
        // Linear functions are discrete-harmonic on a flat mesh (K f = 0 at every full one-ring)
        // and satisfy every edge constraint exactly. Only the soft constraints' weight stands
        // between the least-squares solution and f: along the cut the weighted rows carry the
        // boundary flux of f, which the constraints balance with a residual O(1/λ). With a
        // near-hard weight, f is reproduced at every vertex of the domain.
        let (error, _, pinned) = disk_with_linear_boundary(1e9);
        assert!(pinned > 100, "the removed outside of the disk is pinned ({pinned})");
        assert!(error < 1e-6, "max error {error}");
        // With the thesis' weight the error is the O(1/λ) constraint residual: small on the kept
        // side (values span about ±3 here), larger at the removed vertices next to the cut, which
        // only the constraints determine; it shrinks in proportion to λ.
        let (error_100, kept_100, _) = disk_with_linear_boundary(100.0);
        let (error_10k, _, _) = disk_with_linear_boundary(1e4);
        assert!(kept_100 < 5e-3, "λ = 100: max error on the kept side {kept_100}");
        assert!(error_100 < 0.1, "λ = 100: max error {error_100}");
        assert!(error_10k < error_100 / 50.0, "λ = 1e4: {error_10k} vs {error_100}");
    }

    #[test]
    fn heat_method_on_a_flat_grid_gives_euclidean_distances() {
        // §5.1: heat step (M + tK)v with the source as a constraint, X = −∇v/|∇v|, then
        // K φ = −div X with φ = 0 at the source.
        let mesh = shapes::grid(2.0, 2.0, 60, 60);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let symbolic = SymbolicFactor::analyze(&pattern).unwrap();
        let h = mean_edge_length(&mesh, &topology);
        let centre = (0..mesh.num_vertices())
            .min_by(|&a, &b| mesh.positions[a].length().total_cmp(&mesh.positions[b].length()))
            .unwrap() as u32;
        let source = [EdgeConstraint::vertex(centre, 1.0)];
        let params = ConstraintParams::default();

        let heat = Operator::heat(&mesh, &pattern, None, 10.0 * h * h).unwrap();
        let v = ConstrainedSolver::new(&symbolic, &heat, &source, &params)
            .unwrap()
            .solve(&RightHandSide::default())
            .unwrap();
        let x: Vec<DVec3> = face_gradients(&mesh, &v).unwrap().iter().map(|g| -g.normalize_or_zero()).collect();
        let minus_div: Vec<f64> = integrated_divergence(&mesh, &x, None).unwrap().iter().map(|d| -d).collect();

        let stiffness = Operator::stiffness(&mesh, &pattern, None).unwrap();
        let zero_at_source = [EdgeConstraint::vertex(centre, 0.0)];
        let phi = ConstrainedSolver::new(&symbolic, &stiffness, &zero_at_source, &params)
            .unwrap()
            .solve(&RightHandSide { load: Some(&minus_div), ..Default::default() })
            .unwrap();
        let origin = mesh.positions[centre as usize];
        let mut worst = 0.0f64;
        for (i, p) in mesh.positions.iter().enumerate() {
            let d = (*p - origin).length();
            if (0.2..0.8).contains(&d) {
                worst = worst.max((phi[i] - d).abs() / d);
            }
        }
        assert!(worst < 0.05, "largest relative distance error {worst}");
    }

    #[test]
    fn several_right_hand_sides_share_one_factorization() {
        let mesh = shapes::grid(1.0, 1.0, 10, 10);
        let topology = Topology::new(&mesh);
        let (removed, points) = circle_cut(&mesh, &topology, DVec3::ZERO, 0.2);
        let weights = cut_face_weights(&mesh, &topology, &removed, &points).unwrap();
        let constraints: Vec<EdgeConstraint> =
            points.iter().map(|p| EdgeConstraint::on_edge(p.inside, p.outside, p.alpha, 1.0)).collect();
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let symbolic = SymbolicFactor::analyze(&pattern).unwrap();
        let op = Operator::stiffness(&mesh, &pattern, Some(&weights)).unwrap();
        let mut solver = ConstrainedSolver::new(&symbolic, &op, &constraints, &ConstraintParams::default()).unwrap();
        let twos = vec![2.0; constraints.len()];
        let columns = solver
            .solve_many(&[
                RightHandSide::default(),
                RightHandSide { constraint_values: Some(&twos), ..Default::default() },
            ])
            .unwrap();
        // Constant boundary values give constant solutions (K·1 = 0, constraints satisfied).
        let pinned = solver.system().pinned_vertices().to_vec();
        for (i, (a, b)) in columns[0].iter().zip(&columns[1]).enumerate() {
            if pinned.binary_search(&(i as u32)).is_err() {
                assert!((a - 1.0).abs() < 1e-10 && (b - 2.0).abs() < 1e-10, "vertex {i}: {a}, {b}");
            }
        }
        // The one-shot function agrees.
        let one_shot = solve_harmonic(&mesh, &topology, Some(&weights), &constraints, 0.0).unwrap();
        assert_eq!(one_shot, solver.solve(&RightHandSide::default()).unwrap());
    }

    #[test]
    fn a_mesh_with_an_unconstrained_component_is_solved_with_pins() {
        let mut mesh = shapes::icosphere(1.0, 2);
        let mut other = shapes::icosphere(0.5, 2);
        other.map_positions(|p| p + DVec3::new(4.0, 0.0, 0.0));
        let first = mesh.num_vertices();
        mesh.append(&other);
        let topology = Topology::new(&mesh);
        // Constraints on the first sphere only: north pole 1, south pole 0.
        let north = (0..first).max_by(|&a, &b| mesh.positions[a].z.total_cmp(&mesh.positions[b].z)).unwrap();
        let south = (0..first).min_by(|&a, &b| mesh.positions[a].z.total_cmp(&mesh.positions[b].z)).unwrap();
        let constraints = [EdgeConstraint::vertex(north as u32, 1.0), EdgeConstraint::vertex(south as u32, 0.0)];
        let v = solve_harmonic(&mesh, &topology, None, &constraints, 0.25).unwrap();
        for (i, value) in v.iter().enumerate() {
            if i < first {
                assert!((-1e-9..=1.0 + 1e-9).contains(value), "maximum principle at {i}: {value}");
            } else {
                assert!((value - 0.25).abs() < 1e-12, "pinned component at {i}: {value}");
            }
        }
        assert!(v[north] > 0.95 && v[south] < 0.05);
    }

    #[test]
    fn updating_a_solver_equals_building_a_new_one() {
        let mesh = shapes::capsule(0.5, 1.0, 16, 6, 4);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let symbolic = SymbolicFactor::analyze(&pattern).unwrap();
        let params = ConstraintParams::default();
        let c1 = [EdgeConstraint::vertex(0, 1.0)];
        let c2 = [EdgeConstraint::on_edge(3, topology.vertex_neighbors(3).next().unwrap(), 0.3, 2.0)];
        let op1 = Operator::heat(&mesh, &pattern, None, 0.01).unwrap();
        let mut moved = mesh.clone();
        moved.map_positions(|p| DVec3::new(1.2 * p.x, p.y, 0.9 * p.z));
        let op2 = Operator::heat(&moved, &pattern, None, 0.02).unwrap();
        let mut solver = ConstrainedSolver::new(&symbolic, &op1, &c1, &params).unwrap();
        solver.update(&op2, &c2, &params).unwrap();
        let updated = solver.solve(&RightHandSide::default()).unwrap();
        let fresh =
            ConstrainedSolver::new(&symbolic, &op2, &c2, &params).unwrap().solve(&RightHandSide::default()).unwrap();
        for (a, b) in updated.iter().zip(&fresh) {
            assert!((a - b).abs() < 1e-12);
        }
    }
}
