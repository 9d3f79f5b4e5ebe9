//! The per-region solver cache (thesis ch. 7 §5.2: the factorizations dominate a frame).
//!
//! A [`RegionSolver`] is built once per working region (its connectivity) and reused by every
//! frame. It owns the region's [`SparsePattern`] and its one symbolic Cholesky analysis, and three
//! numeric factorizations that are refactorized in place each frame (no symbolic analysis, no
//! allocation of `L` after the first frame):
//! - **heat**: `M_w + tK_w + λCᵀC + λ·(outer-boundary rows)` (§5.1 step 1); its `tK_w` is the
//!   Poisson system's `K_w` scaled (same face weights), not a second sum of cotangents;
//! - **Poisson**: `K_w + λCᵀC` (§5.1 step 3). With the same ∂𝒞 constraint rows, this is exactly
//!   the matrix of the multi-contact direction diffusion of §5.2.2 (only the right-hand side
//!   differs), so that diffusion reuses this factorization as the thesis says ("reusing the matrix
//!   factorized for solving the second Poisson problem");
//! - **guide**: `K_𝒟 + λ·diag(ω)` for the amplitude and slope diffusions of §5.3, which share one
//!   factorization (two right-hand sides). Its vertex constraints have individual weights ω (see
//!   [`super::guide`]), which [`ConstrainedSolver`] does not offer, so this system is assembled
//!   here on the same pattern and symbolic analysis. When 𝒟 lies within the parametrized domain
//!   (its coupled rows among the heat system's, and not many fewer), it is factorized on the heat
//!   system's rows, reusing their analysis of the same frame (the region's own analysis when the
//!   heat system was factorized whole).
//!
//! The Poisson factorization carries the *generation* of the parametrization that made it, so a
//! later stage cannot silently use the factorization of another frame.

use std::sync::Arc;
use std::time::{Duration, Instant};

use super::DeformError;
use crate::linalg::constraints::{find, union_through_faces};
use crate::linalg::{
    ConstrainedSolver, ConstraintParams, EdgeConstraint, FillOrder, NEGLIGIBLE_CONSTRAINT_COEFFICIENT, NumericFactor,
    Operator, SolveError, SparsePattern, SymbolicFactor, SymmetricMatrix,
};
use crate::mesh::{Topology, TriMesh};
use crate::stage::SharedWork;

/// The cached linear systems of one working region; see the module doc.
#[derive(Debug)]
pub struct RegionSolver {
    pattern: Arc<SparsePattern>,
    symbolic: Arc<SymbolicFactor>,
    outer_boundary: Vec<bool>,
    heat_operator: Option<Operator>,
    heat: Option<ConstrainedSolver>,
    poisson_operator: Option<Operator>,
    poisson: Option<ConstrainedSolver>,
    guide_operator: Option<Operator>,
    guide: Option<WeightedSystem>,
    generation: u64,
    poisson_generation: u64,
    symbolic_analyses: usize,
    numeric_factorizations: usize,
    factorized_rows: usize,
    recomputed_rows: usize,
    /// Multiply-adds of the factorizations so far (their [`crate::stage::Work`]).
    factorization_flops: u64,
    factorization_time: Duration,
    /// Frames to go before the parametrization tries the breadth-first bound of its domain again
    /// (see `parametrize::restrict_to_domain`): set after it failed. Only the time depends on
    /// it; the result is the same bits either way.
    pub(crate) domain_bound_cooldown: u32,
    /// The parallel-transport direction field's systems (method A, §5.2.1), built on first use.
    pub(crate) transport: Option<Box<super::transport::TransportCache>>,
}

impl RegionSolver {
    /// Builds the pattern and runs the symbolic analysis of the region `mesh` (once per region),
    /// in the order of fewer flops ([`FillOrder::FewerFlops`]).
    pub fn new(mesh: &TriMesh, topology: &Topology) -> Result<Self, DeformError> {
        Self::with_fill_order(mesh, topology, FillOrder::FewerFlops)
    }

    /// [`Self::new`] with the given kind of fill-reducing order.
    pub fn with_fill_order(mesh: &TriMesh, topology: &Topology, fill_order: FillOrder) -> Result<Self, DeformError> {
        Self::with_analysis(mesh, topology, |pattern| SymbolicFactor::analyze_in(pattern, fill_order))
    }

    /// [`Self::new`] in the order of `rank` (per region vertex; see
    /// [`SymbolicFactor::analyze_in_rank_order`]): a region cut out of an object, in the object's
    /// order.
    pub fn with_rank_order(mesh: &TriMesh, topology: &Topology, rank: &[usize]) -> Result<Self, DeformError> {
        Self::with_analysis(mesh, topology, |pattern| SymbolicFactor::analyze_in_rank_order(pattern, rank))
    }

    fn with_analysis(
        mesh: &TriMesh,
        topology: &Topology,
        analyze: impl FnOnce(&Arc<SparsePattern>) -> Result<Arc<SymbolicFactor>, SolveError>,
    ) -> Result<Self, DeformError> {
        check_topology(mesh, topology)?;
        let pattern = SparsePattern::shared(mesh, topology).map_err(DeformError::solve("symbolic analysis"))?;
        let symbolic = analyze(&pattern).map_err(DeformError::solve("symbolic analysis"))?;
        Ok(Self {
            pattern,
            symbolic,
            outer_boundary: topology.boundary_vertices(),
            heat_operator: None,
            heat: None,
            poisson_operator: None,
            poisson: None,
            guide_operator: None,
            guide: None,
            generation: 0,
            poisson_generation: 0,
            domain_bound_cooldown: 0,
            symbolic_analyses: 1,
            numeric_factorizations: 0,
            factorized_rows: 0,
            recomputed_rows: 0,
            factorization_flops: 0,
            factorization_time: Duration::ZERO,
            transport: None,
        })
    }

    /// True if the region's analysis kept the nested-dissection order (see [`FillOrder`]).
    pub fn uses_nested_dissection(&self) -> bool {
        self.symbolic.uses_nested_dissection()
    }

    /// The region's pattern and real symbolic analysis (for the transport field's systems).
    pub(crate) fn shared_analysis(&self) -> (&Arc<SparsePattern>, &Arc<SymbolicFactor>) {
        (&self.pattern, &self.symbolic)
    }

    /// Counts factorizations run outside this type (the transport field's).
    pub(crate) fn record_factorizations(&mut self, count: usize, time: Duration, symbolic_analyses: usize) {
        self.numeric_factorizations += count;
        self.factorization_time += time;
        self.symbolic_analyses += symbolic_analyses;
    }

    /// Number of symbolic analyses run by this solver (1: the one of [`Self::new`]).
    pub fn symbolic_analyses(&self) -> usize {
        self.symbolic_analyses
    }

    /// Number of numeric factorizations run so far (three per frame with a contact).
    pub fn numeric_factorizations(&self) -> usize {
        self.numeric_factorizations
    }

    /// Rows factorized so far by the heat, Poisson and guide systems, summed over their
    /// factorizations: the region's size for a whole factorization, the coupled rows alone when
    /// the rest of the region is decoupled ([`crate::linalg::NumericFactor`]).
    pub fn factorized_rows(&self) -> usize {
        self.factorized_rows
    }

    /// Rows (columns of `L`) the heat, Poisson and guide factorizations actually recomputed so
    /// far: the factorized rows when a system changed everywhere, only the changed ones and their
    /// elimination-tree ancestors when the rest kept its values (an object that does not move;
    /// see [`crate::linalg::NumericFactor::recomputed_columns`]).
    pub fn recomputed_rows(&self) -> usize {
        self.recomputed_rows
    }

    /// Multiply-adds of the heat, Poisson and guide factorizations so far (`Σ c_j²` over the
    /// columns each recomputed, [`NumericFactor::recomputed_flops`]).
    pub fn factorization_flops(&self) -> u64 {
        self.factorization_flops
    }

    /// Rows of the coupled-row submatrices analyzed so far (see [`Self::reduced_analyses`]).
    pub fn analyzed_rows(&self) -> u64 {
        self.factors().map(NumericFactor::analyzed_rows).sum()
    }

    /// Symbolic analyses of coupled-row submatrices run so far by the heat, Poisson and guide
    /// systems (one each time a system's set of coupled rows changes; the region's own analysis
    /// is [`Self::symbolic_analyses`]).
    pub fn reduced_analyses(&self) -> usize {
        self.factors().map(NumericFactor::reduced_analyses).sum()
    }

    /// Time spent in those analyses so far (part of [`Self::factorization_time`]).
    pub fn analysis_time(&self) -> Duration {
        self.factors().map(NumericFactor::analysis_time).sum()
    }

    /// The heat, Poisson and guide factors built so far.
    fn factors(&self) -> impl Iterator<Item = &NumericFactor> {
        [
            self.heat.as_ref().map(ConstrainedSolver::factor),
            self.poisson.as_ref().map(ConstrainedSolver::factor),
            self.guide.as_ref().map(|g| &g.factor),
        ]
        .into_iter()
        .flatten()
    }

    /// Total time spent assembling constraints into and numerically factorizing the systems,
    /// summed over the systems (the heat and Poisson factorizations run concurrently, so this can
    /// exceed the wall-clock time of a frame's parametrization).
    pub fn factorization_time(&self) -> Duration {
        self.factorization_time
    }

    /// Number of vertices of the region.
    pub fn num_vertices(&self) -> usize {
        self.pattern.num_vertices()
    }

    /// The region's vertices on its outer boundary (an open mesh or a region cut from a larger
    /// one), fixed by its connectivity.
    pub fn outer_boundary(&self) -> &[bool] {
        &self.outer_boundary
    }

    /// Checks that `mesh` and `topology` are the region this solver was built for.
    pub fn check_region(&self, mesh: &TriMesh, topology: &Topology) -> Result<(), DeformError> {
        check_topology(mesh, topology)?;
        if mesh.num_vertices() != self.pattern.num_vertices() || mesh.triangles.as_slice() != self.pattern.triangles() {
            return Err(DeformError::RegionMismatch {
                vertices: mesh.num_vertices(),
                faces: mesh.num_triangles(),
                solver_vertices: self.pattern.num_vertices(),
                solver_faces: self.pattern.num_faces(),
            });
        }
        Ok(())
    }

    /// Assembles and factorizes the heat step `M_w + tK_w + λCᵀC` (with `heat_constraints`) and
    /// the Poisson system `K_w + λCᵀC` (with `poisson_constraints`) for a new parametrization.
    /// Neither matrix depends on the other's solution, so the two factorizations run concurrently
    /// (`rayon::join`; each is sequential and deterministic). Returns the new generation, to be
    /// checked by [`Self::poisson`].
    pub(crate) fn factorize_distance_systems(
        &mut self,
        mesh: &TriMesh,
        face_weights: &[f64],
        time: f64,
        heat_constraints: &[EdgeConstraint],
        poisson_constraints: &[EdgeConstraint],
        params: &ConstraintParams,
    ) -> Result<u64, DeformError> {
        self.generation += 1;
        self.poisson_generation = 0;
        let pattern = Arc::clone(&self.pattern);
        // Both share K_w (same face weights): the heat step scales the Poisson values by t.
        let poisson_operator = assemble(&mut self.poisson_operator, mesh, &pattern, face_weights, 0.0, 1.0)
            .map_err(DeformError::solve("Poisson"))?;
        // (On the first frame too, so that a frame's bits do not depend on the frames before it.)
        let heat_operator = self.heat_operator.get_or_insert_with(|| poisson_operator.clone());
        heat_operator
            .reassemble_from_stiffness(mesh, poisson_operator, 1.0, time)
            .map_err(DeformError::solve("heat"))?;
        let heat_operator = &*heat_operator;
        let symbolic = &self.symbolic;
        let (heat, poisson) = (&mut self.heat, &mut self.poisson);
        let timed = |slot: &mut Option<ConstrainedSolver>, operator: &Operator, constraints: &[EdgeConstraint]| {
            let start = Instant::now();
            let result = refactorize(slot, symbolic, operator, constraints, params);
            (result, start.elapsed())
        };
        let work = SharedWork::default();
        let ((heat_result, heat_time), (poisson_result, poisson_time)) = rayon::join(
            || work.measure(|| timed(heat, heat_operator, heat_constraints)),
            || work.measure(|| timed(poisson, poisson_operator, poisson_constraints)),
        );
        work.record();
        self.factorization_time += heat_time + poisson_time;
        self.numeric_factorizations += 2;
        for solver in [&self.heat, &self.poisson].into_iter().flatten() {
            self.factorized_rows += solver.factor().factorized_rows();
            self.recomputed_rows += solver.factor().recomputed_columns();
            self.factorization_flops += solver.factor().recomputed_flops();
        }
        heat_result.map_err(DeformError::solve("heat"))?;
        poisson_result.map_err(DeformError::solve("Poisson"))?;
        self.poisson_generation = self.generation;
        Ok(self.generation)
    }

    /// The heat-step factorization of the last [`Self::factorize_distance_systems`].
    pub(crate) fn heat(&mut self, generation: u64) -> Result<&mut ConstrainedSolver, DeformError> {
        if generation == 0 || generation != self.poisson_generation {
            return Err(DeformError::StaleFactorization { stage: "heat" });
        }
        self.heat.as_mut().ok_or(DeformError::StaleFactorization { stage: "heat" })
    }

    /// The Poisson factorization of parametrization `generation`, for the direction diffusion.
    pub(crate) fn poisson(
        &mut self,
        generation: u64,
        stage: &'static str,
    ) -> Result<&mut ConstrainedSolver, DeformError> {
        if generation == 0 || generation != self.poisson_generation {
            return Err(DeformError::StaleFactorization { stage });
        }
        self.poisson.as_mut().ok_or(DeformError::StaleFactorization { stage })
    }

    /// Assembles and factorizes the guide system `K_𝒟 + λ·diag(ω)` (`weighted`: `(vertex, ω)`
    /// pairs; the stiffness weights `face_weights` are the area fractions inside 𝒟).
    ///
    /// With the `generation` of the current parametrization, a guide system coupling only rows
    /// that the heat system of that parametrization couples (𝒟 lies within the parametrized
    /// domain) is factorized on the heat system's rows, whose analysis is already made
    /// ([`NumericFactor::factorize_within`]); 0 (or a stale generation) analyzes its own rows.
    pub(crate) fn factorize_guide(
        &mut self,
        mesh: &TriMesh,
        face_weights: &[f64],
        weighted: &[(u32, f64)],
        lambda: f64,
        generation: u64,
    ) -> Result<&mut WeightedSystem, DeformError> {
        let pattern = Arc::clone(&self.pattern);
        let operator = assemble(&mut self.guide_operator, mesh, &pattern, face_weights, 0.0, 1.0)
            .map_err(DeformError::solve("guide"))?;
        let system = match &mut self.guide {
            Some(system) => system,
            None => self.guide.insert(WeightedSystem::new(&self.symbolic).map_err(DeformError::solve("guide"))?),
        };
        let current = generation != 0 && generation == self.poisson_generation;
        let within = self.heat.as_ref().filter(|_| current).map(ConstrainedSolver::factor);
        let start = Instant::now();
        let result = system.factorize(operator, weighted, lambda, within);
        self.factorization_time += start.elapsed();
        self.numeric_factorizations += 1;
        self.factorized_rows += system.factor.factorized_rows();
        self.recomputed_rows += system.factor.recomputed_columns();
        self.factorization_flops += system.factor.recomputed_flops();
        result.map_err(DeformError::solve("guide"))?;
        self.guide.as_mut().ok_or(DeformError::Solve { stage: "guide", source: SolveError::NotFactorized })
    }
}

fn check_topology(mesh: &TriMesh, topology: &Topology) -> Result<(), DeformError> {
    if topology.num_vertices() != mesh.num_vertices() || topology.num_faces() != mesh.num_triangles() {
        return Err(DeformError::TopologyMismatch {
            vertices: mesh.num_vertices(),
            faces: mesh.num_triangles(),
            topology_vertices: topology.num_vertices(),
            topology_faces: topology.num_faces(),
        });
    }
    Ok(())
}

/// Reassembles the cached operator in place (or builds it on the first frame).
fn assemble<'a>(
    slot: &'a mut Option<Operator>,
    mesh: &TriMesh,
    pattern: &Arc<SparsePattern>,
    face_weights: &[f64],
    mass: f64,
    stiffness: f64,
) -> Result<&'a Operator, SolveError> {
    match slot {
        Some(operator) => operator.reassemble(mesh, Some(face_weights), mass, stiffness)?,
        None => *slot = Some(Operator::new(mesh, pattern, Some(face_weights), mass, stiffness)?),
    }
    slot.as_ref().ok_or(SolveError::NotAssembled)
}

/// Refactorizes the cached constrained solver in place (or builds it on the first frame).
fn refactorize(
    slot: &mut Option<ConstrainedSolver>,
    symbolic: &Arc<SymbolicFactor>,
    operator: &Operator,
    constraints: &[EdgeConstraint],
    params: &ConstraintParams,
) -> Result<(), SolveError> {
    match slot {
        Some(solver) => solver.update(operator, constraints, params),
        None => {
            *slot = Some(ConstrainedSolver::new(symbolic, operator, constraints, params)?);
            Ok(())
        }
    }
}

/// `K + λ·Σ_j ω_j e_j e_jᵀ + pins`: harmonic diffusion with individually weighted soft vertex
/// constraints, Neumann elsewhere.
///
/// Pinning (as in [`crate::linalg::ConstrainedSystem`]): a vertex whose component — through faces
/// of weight ≥ [`crate::linalg::NEGLIGIBLE_FACE_WEIGHT`] — holds no constraint of weight ≥
/// [`NEGLIGIBLE_CONSTRAINT_COEFFICIENT`] is undetermined; it gets +1 on its diagonal and the value
/// 0 (these are vertices outside 𝒟, or a component of 𝒟 whose constraints all faded out).
#[derive(Debug)]
pub(crate) struct WeightedSystem {
    matrix: SymmetricMatrix,
    factor: NumericFactor,
    /// `λ·ω` of each constraint as assembled by the last factorization (0: not assembled, on a
    /// pinned vertex).
    assembled: Vec<f64>,
    pinned: Vec<bool>,
    parent: Vec<u32>,
    anchored: Vec<bool>,
    rhs: Vec<f64>,
}

impl WeightedSystem {
    fn new(symbolic: &Arc<SymbolicFactor>) -> Result<Self, SolveError> {
        Ok(Self {
            matrix: SymmetricMatrix::zeros(symbolic.pattern()),
            factor: NumericFactor::new(symbolic)?,
            assembled: Vec::new(),
            pinned: Vec::new(),
            parent: Vec::new(),
            anchored: Vec::new(),
            rhs: Vec::new(),
        })
    }

    fn factorize(
        &mut self,
        operator: &Operator,
        weighted: &[(u32, f64)],
        lambda: f64,
        within: Option<&NumericFactor>,
    ) -> Result<(), SolveError> {
        let pattern = Arc::clone(operator.pattern());
        let n = pattern.num_vertices();
        if !operator.matrix().same_pattern(&self.matrix) {
            return Err(SolveError::PatternMismatch);
        }
        for (k, &(v, w)) in weighted.iter().enumerate() {
            if v as usize >= n {
                return Err(SolveError::VertexOutOfRange { what: "guide constraint", vertex: v, vertices: n });
            }
            if !(w.is_finite() && w >= 0.0) {
                return Err(SolveError::NonFiniteConstraint { constraint: k, alpha: 0.0, value: w });
            }
        }
        // Components through non-negligible faces; anchored if they hold a non-negligible weight.
        union_through_faces(&mut self.parent, operator);
        let parent = &mut self.parent;
        self.anchored.clear();
        self.anchored.resize(n, false);
        for &(v, w) in weighted {
            if w >= NEGLIGIBLE_CONSTRAINT_COEFFICIENT {
                let root = find(parent, v);
                self.anchored[root as usize] = true;
            }
        }
        self.pinned.clear();
        for v in 0..n as u32 {
            let root = find(parent, v);
            self.pinned.push(!self.anchored[root as usize]);
        }

        let values = self.matrix.values_mut();
        values.copy_from_slice(operator.matrix().values());
        self.assembled.clear();
        for &(v, w) in weighted {
            let lambda_w = if self.pinned[v as usize] { 0.0 } else { lambda * w };
            values[pattern.diag_slot(v)] += lambda_w;
            self.assembled.push(lambda_w);
        }
        for (v, &pinned) in self.pinned.iter().enumerate() {
            if pinned {
                values[pattern.diag_slot(v as u32)] += 1.0;
            }
        }
        self.factor.factorize_within(&self.matrix, within)
    }

    /// Solves for several sets of constraint values: `values[c][k]` is the value of constraint `k`
    /// (in the order of the `weighted` list given to the factorization) for column `c`. Pinned
    /// vertices get 0.
    pub(crate) fn solve(&mut self, weighted: &[(u32, f64)], values: &[&[f64]]) -> Result<Vec<Vec<f64>>, SolveError> {
        let n = self.matrix.dimension();
        if weighted.len() != self.assembled.len() {
            return Err(SolveError::DimensionMismatch {
                what: "guide constraints",
                expected: self.assembled.len(),
                actual: weighted.len(),
            });
        }
        self.rhs.clear();
        self.rhs.resize(n * values.len(), 0.0);
        for (column, column_values) in self.rhs.chunks_exact_mut(n.max(1)).zip(values) {
            if column_values.len() != weighted.len() {
                return Err(SolveError::DimensionMismatch {
                    what: "guide constraint values",
                    expected: weighted.len(),
                    actual: column_values.len(),
                });
            }
            for ((&(v, _), &lambda_w), &value) in weighted.iter().zip(&self.assembled).zip(column_values.iter()) {
                column[v as usize] += lambda_w * value;
            }
        }
        self.factor.solve_columns_in_place(&mut self.rhs, values.len())?;
        Ok(self.rhs.chunks_exact(n.max(1)).take(values.len()).map(<[f64]>::to_vec).collect())
    }

    /// Per vertex: true if it was pinned (undetermined) in the last factorization.
    #[cfg(test)]
    pub(crate) fn pinned(&self) -> &[bool] {
        &self.pinned
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::ConstraintParams;
    use crate::mesh::shapes;

    #[test]
    fn weighted_constraints_pull_in_proportion_to_their_weight() {
        // Two weak vertex constraints on a closed sphere with values 0 and 1: when λ is small the
        // diffusion wins and the solution is nearly constant, the weighted mean of the values.
        // A heavier constraint pulls it towards its value; a zero-weight one does nothing.
        let mesh = shapes::icosphere(1.0, 2);
        let topology = Topology::new(&mesh);
        let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
        let weights = vec![1.0; mesh.num_triangles()];
        let (north, south) = (0u32, 3u32);
        let mean = |solver: &mut RegionSolver, w: &[(u32, f64)]| {
            let system = solver.factorize_guide(&mesh, &weights, w, 1e-4, 0).unwrap();
            let columns = system.solve(w, &[&[0.0, 1.0]]).unwrap();
            columns[0].iter().sum::<f64>() / mesh.num_vertices() as f64
        };
        let balanced = mean(&mut solver, &[(north, 1.0), (south, 1.0)]);
        let heavy = mean(&mut solver, &[(north, 1.0), (south, 4.0)]);
        let gone = mean(&mut solver, &[(north, 1.0), (south, 0.0)]);
        assert!((balanced - 0.5).abs() < 0.01, "{balanced}");
        assert!((heavy - 0.8).abs() < 0.01, "{heavy} vs the weighted mean 0.8");
        assert!(gone.abs() < 1e-12, "a zero weight must not constrain ({gone})");
        assert_eq!(solver.symbolic_analyses(), 1);
        assert_eq!(solver.numeric_factorizations(), 3);
    }

    #[test]
    fn the_guide_system_factorizes_on_the_heat_systems_rows_when_they_hold_its_own() {
        // A cap parametrized (faces below z = −0.4) and a slightly smaller 𝒟 (below z = −0.5).
        let mesh = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&mesh);
        let below = |z: f64| -> Vec<f64> {
            let inside = |t: &[u32; 3]| t.iter().all(|&v| mesh.positions[v as usize].z < z);
            mesh.triangles.iter().map(|t| if inside(t) { 1.0 } else { 0.0 }).collect()
        };
        let (domain, deformable) = (below(-0.4), below(-0.5));
        let bottom = (0..mesh.num_vertices() as u32)
            .min_by(|&a, &b| mesh.positions[a as usize].z.total_cmp(&mesh.positions[b as usize].z));
        let bottom = bottom.unwrap();
        let constraints = [EdgeConstraint::on_edge(bottom, bottom, 0.0, 1.0)];
        let weighted = [(bottom, 1.0)];
        let params = ConstraintParams::default();
        let solve_guide = |generation: u64| {
            let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
            let current = solver.factorize_distance_systems(&mesh, &domain, 0.01, &constraints, &constraints, &params);
            let current = current.unwrap();
            let heat_rows = solver.heat.as_ref().unwrap().factor().factorized_rows();
            let analyses = solver.reduced_analyses();
            // 0: none; 1: the current parametrization's; 2: another one's (stale).
            let generation = [0, current, current + 1][generation as usize];
            let system = solver.factorize_guide(&mesh, &deformable, &weighted, 100.0, generation).unwrap();
            let x = system.solve(&weighted, &[&[2.0]]).unwrap().remove(0);
            let guide_rows = system.factor.factorized_rows();
            (x, heat_rows, guide_rows, solver.reduced_analyses() - analyses)
        };
        let (own, heat_rows, own_rows, own_analyses) = solve_guide(0);
        let (within, _, within_rows, within_analyses) = solve_guide(1);
        let (stale, _, stale_rows, stale_analyses) = solve_guide(2);
        assert_eq!((stale_rows, stale_analyses), (own_rows, 1), "a stale heat factorization is not used");
        assert_eq!(stale, own);
        assert!(own_rows < heat_rows && heat_rows < mesh.num_vertices() / 2, "{own_rows} {heat_rows}");
        assert_eq!((own_analyses, within_rows, within_analyses), (1, heat_rows, 0));
        let difference = own.iter().zip(&within).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(difference < 1e-12 && (within[bottom as usize] - 2.0).abs() < 1e-3, "{difference}");
    }

    #[test]
    fn vertices_without_anchored_component_are_pinned_to_zero() {
        let mesh = shapes::icosphere(1.0, 2);
        let topology = Topology::new(&mesh);
        let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
        // Only faces touching vertex 0 are in the domain; the constraint sits elsewhere.
        let weights: Vec<f64> = mesh.triangles.iter().map(|t| if t.contains(&0) { 1.0 } else { 0.0 }).collect();
        let w = [(5u32, 1.0)];
        let system = solver.factorize_guide(&mesh, &weights, &w, 100.0, 0).unwrap();
        let x = system.solve(&w, &[&[3.0]]).unwrap().remove(0);
        assert!((x[5] - 3.0).abs() < 1e-12);
        assert_eq!(x[0], 0.0);
        assert!(system.pinned()[0] && !system.pinned()[5]);
    }
}
