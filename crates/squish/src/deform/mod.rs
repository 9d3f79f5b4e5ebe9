//! The deformation stage (thesis chapter 5, method B): given a working region and its contact
//! zones, move the zones onto the contact surface 𝒮 and displace the surrounding deformable region
//! 𝒟 along a smooth direction field with a volume-preserving bulge.
//!
//! Every vertex of 𝒟 moves by Eq. 5.1, `p′_i = p_i + 𝓗_{a_i,s_i}(u_i)·d_i`, built in four steps,
//! one private module each, each step a function with explicit inputs and outputs:
//! 1. [`parametrize()`] (§5.1, App. B): heat-method distance φ from ∂𝒞 with cut-face weights and
//!    least-squares edge constraints, `u = φ/φ_max`, 𝒟 = {u < 1} outside 𝒞;
//! 2. [`direction_field()`] (§5.2.2, Eq. 5.4): mapping directions (diffused when several zones
//!    push different ways) blended into the input normals; or method A's parallel-transport field
//!    ([`transport_field`], §5.2.1, [`DirectionFieldMethod::ParallelTransport`]);
//! 3. [`guide_fields`] (§5.3): signed amplitude a and slope s at ∂𝒞, diffused over 𝒟;
//! 4. [`ProfileSampler`] (§5.4.1), [`bulge_map`] (§5.5) and [`solve_bulge_height`] (§5.4.2,
//!    App. C): the per-vertex B-spline profile, the bulge map η and the bulge height h_v that
//!    preserves the volume.
//!
//! The automatic extent φ_max is [`automatic_extent`] (§7.1). The radial brush that paints the
//! bulge map along the profiles is [`radial_brush()`] (§5.5.1).
//!
//! Contact-zone vertices go to their targets p′_i on 𝒮; every other vertex outside 𝒟 is copied
//! bit for bit. The working region may be part of a larger closed object (a [`crate::SubMesh`]):
//! faces outside it do not move, so the region's volume change is the object's — provided 𝒟 stays
//! inside the region (vertices of its outer boundary are shared with outside faces; the stats
//! count those that moved). [`RegionSolver`] caches the region's pattern, symbolic analysis and numeric
//! factorizations across frames (three refactorizations per frame: heat, Poisson — reused by the
//! multi-zone direction diffusion — and the guide diffusion).
//!
//! Entry point: [`deform_region`]. It runs in two halves: [`region_fields`] (§5.1–5.3, the
//! factorizations) and [`deform_with_fields`] (§5.4–5.5 and the volume); a change of a parameter
//! of §5.4–5.5 only reruns the second on the same [`RegionFields`] (see its doc for the rule),
//! with the same bits as the whole chapter.

mod bulge;
mod contact_set;
mod direction_field;
mod error;
mod extent;
mod guide;
mod parametrize;
mod params;
mod profile;
mod radial_brush;
mod solver;
mod transport;
mod volume;

#[cfg(test)]
mod method_a_tests;
#[cfg(test)]
mod test_support;
#[cfg(test)]
mod tests;

use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;

pub use bulge::{AnisotropyParams, BulgeMap, anisotropic_bulge_map, bulge_map};
pub use contact_set::{ContactBoundaryPoint, ContactSet, NO_ZONE};
pub use direction_field::{DirectionField, DirectionParams, MIN_DIFFUSED_LENGTH, blend_weight, direction_field};
pub use error::DeformError;
pub(crate) use extent::size_from_areas;
pub use extent::{
    EXTENT_CONTACT_FACTOR, EXTENT_CONTACT_FLOOR, EXTENT_EDGE_FACTOR, EXTENT_SIZE_FACTOR, automatic_extent, object_size,
};
pub use guide::{GuideFields, GuideParams, MIN_SLOPE_U, guide_fields};
pub use parametrize::{Parametrization, ParametrizeParams, deformable_face_weights, parametrize};
pub use params::DeformParams;
pub use profile::{Profile, ProfileSample, ProfileSampler, ProfileShape, Wrinkles};
pub use radial_brush::{BrushFields, LateralPoint, RadialBrushError, RadialSelection, radial_brush, radial_falloff};
pub use solver::RegionSolver;
pub use transport::{MAX_CORRECTION, TransportField, transport_field};
pub use volume::{
    AffineDisplacement, HeightSolution, SweptTerms, VolumeCubic, solve_bulge_height, solve_dent_height,
    swept_volume_change,
};

use crate::contact::ContactZone;
use crate::mesh::{Topology, TriMesh, vertex_centroid, vertex_normals};
use crate::params::DirectionFieldMethod;
use crate::stage::{Stage, StageTimes, StageWork, Work};
use parametrize::parametrize_and_diffuse;

/// How often a documented fallback was taken.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FallbackCounters {
    /// Vertices of 𝒟 (and ∂𝒞 points) whose blended direction vanished ([`direction_field()`]).
    pub direction_blend: usize,
    /// 1 if the anisotropic bulge map fell back to uniform ([`bulge_map`]).
    pub bulge_map: usize,
    /// 1 if the volume cubic had no non-negative root ([`solve_bulge_height`]).
    pub volume_without_root: usize,
    /// Vertices next to ∂𝒞 whose slope division was clamped at u = 10⁻⁶ ([`guide_fields`]).
    pub clamped_slopes: usize,
}

/// Figures of one call of [`deform_region`].
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DeformStats {
    /// h_v: solved for volume preservation, or the user's `bulge_height`.
    pub bulge_height: f64,
    /// γ·h_v, the height actually applied.
    pub applied_bulge_height: f64,
    /// True if h_v preserves the volume exactly (a root of the cubic); false for the no-root
    /// fallback and when volume preservation is off.
    pub volume_exact: bool,
    /// ΔV(h_v) at γ = 1 (0 up to round-off when `volume_exact`).
    pub volume_residual: f64,
    /// Signed volume of the region before (relative to its centroid; the object's volume when the
    /// region is a closed mesh).
    pub volume_before: f64,
    /// Signed volume after, same reference point.
    pub volume_after: f64,
    /// |𝒟|.
    pub num_deformable: usize,
    /// |𝒞|.
    pub num_contact: usize,
    /// Boundary points of ∂𝒞.
    pub num_boundary_points: usize,
    /// Vertices on the region's outer boundary that moved (in 𝒞 or 𝒟). Should be 0: when the
    /// region is part of a larger mesh, these vertices are shared with faces outside the region,
    /// which then deform without being accounted for in the volume; pick a larger working region.
    pub outer_boundary_moved: usize,
    /// Numeric factorizations run by this call.
    pub numeric_factorizations: usize,
    /// Rows factorized by this call's heat, Poisson and guide factorizations, summed: the region's
    /// size each when factorized whole, fewer when rows outside 𝒫 or 𝒟 are decoupled and left out
    /// ([`crate::linalg::NumericFactor`]).
    #[serde(default)]
    pub factorized_rows: usize,
    /// Of those, the rows whose factor was recomputed (the others kept their values because their
    /// part of the system did not change, see [`crate::linalg::NumericFactor`]).
    #[serde(default)]
    pub recomputed_rows: usize,
    /// Symbolic analyses of coupled-row submatrices run by this call (0 while the coupled rows of
    /// every system stay the same).
    #[serde(default)]
    pub reduced_analyses: usize,
    /// Wall-clock time of each stage: [`Stage::Parametrization`], [`Stage::Directions`],
    /// [`Stage::Guide`], [`Stage::Deformation`] and, within them, [`Stage::Factorization`] and
    /// [`Stage::Analysis`] (the other stages are zero).
    pub timings: StageTimes,
    /// The work of the same stages ([`crate::stage::Work`]; each unit in the innermost stage:
    /// the factorizations' multiply-adds in [`Stage::Factorization`], not in the stage that
    /// asked for them).
    #[serde(default)]
    pub work: StageWork,
    /// Wall-clock time of the whole call.
    pub time: Duration,
    /// Fallback counters.
    pub fallbacks: FallbackCounters,
}

impl DeformStats {
    /// Adds the solving work of `other` (factorizations, their rows and analyses, the stages'
    /// times and work) to these figures.
    pub fn add_solve_counts(&mut self, other: &DeformStats) {
        self.numeric_factorizations += other.numeric_factorizations;
        self.factorized_rows += other.factorized_rows;
        self.recomputed_rows += other.recomputed_rows;
        self.reduced_analyses += other.reduced_analyses;
        self.timings += &other.timings;
        self.work += &other.work;
    }
}

/// The deformed region.
#[derive(Clone, Debug)]
pub struct RegionDeformation {
    /// New positions: targets on 𝒮 for 𝒞, Eq. 5.1 for 𝒟, the input (bit-identical) elsewhere.
    pub positions: Vec<DVec3>,
    /// The radial parameter u (0 in 𝒞, +∞ where no contact boundary is reachable and beyond the
    /// parametrization domain 𝒫).
    pub u: Vec<f64>,
    /// Per vertex: within the radius of the parametrization domain 𝒫 (edge-path distance from
    /// ∂𝒞, [`parametrize()`]).
    pub domain: Vec<bool>,
    /// The deformable region 𝒟.
    pub deformable: Vec<bool>,
    /// The contact region 𝒞 (union of the zones).
    pub contact: Vec<bool>,
    /// The displacement direction d (unit on 𝒟, the input normal elsewhere).
    pub directions: Vec<DVec3>,
    /// 𝓗_i(u_i) on 𝒟 (0 elsewhere): `p′_i = p_i + heights[i]·directions[i]`.
    pub heights: Vec<f64>,
    /// The amplitude field a (§5.3), diffused over 𝒟 (meaningful there).
    pub amplitude: Vec<f64>,
    /// The slope field s (§5.3), diffused over 𝒟 (meaningful there).
    pub slope: Vec<f64>,
    /// The bulge map η used (1 outside 𝒟).
    pub bulge_map: Vec<f64>,
    /// The affine displacement the positions were built from (`p′ = p + applied·linear +
    /// constant` on the moved vertices, see [`RegionPlan`]): what a correction re-solves the bulge
    /// height with ([`RegionDeformation::correct`]).
    pub displacement: AffineDisplacement,
    /// Figures and timings.
    pub stats: DeformStats,
}

/// How [`RegionDeformation::correct`] chooses the bulge height: the region's volume settings.
#[derive(Clone, Copy, Debug)]
pub struct HeightChoice {
    /// Solve h_v for the volume (else keep the applied height).
    pub preserve_volume: bool,
    /// γ: the applied height is γ·h_v.
    pub bulge: f64,
    /// The length scale of the root search (φ_max).
    pub extent: f64,
}

impl RegionDeformation {
    /// Adds `correction` (per region vertex) to the fixed part of the displacement and chooses
    /// the bulge height again (§5.4.2 with the correction as a fixed displacement, so the volume
    /// stays preserved): the positions become `p + γ·h_v·linear + constant + correction`.
    /// Vertices without a correction keep the bits they would have for the same height.
    /// `self.displacement` is left as it was (the correction is not accumulated into it), so a
    /// caller correcting again passes the whole correction.
    /// `terms`: the volume terms of the last correction of this region (at the first, chapter
    /// 5's from [`deform_with_fields_and_terms`], or empty), reused where the displacement did
    /// not change ([`SweptTerms`]: the same bits).
    pub fn correct(
        &mut self,
        mesh: &TriMesh,
        topology: &Topology,
        correction: &[DVec3],
        choice: HeightChoice,
        terms: &mut SweptTerms,
    ) -> Result<(), DeformError> {
        let n = mesh.num_vertices();
        DeformError::check_len("correction", n, correction.len())?;
        let reference = vertex_centroid(&mesh.positions);
        let cubic = VolumeCubic::swept_corrected(mesh, topology, &self.displacement, correction, reference, terms)?;
        // The corrected displacement, built in the terms.
        let displacement = terms.displacement();
        let old_applied = self.stats.applied_bulge_height;
        let (bulge_height, applied) = if choice.preserve_volume {
            let solution = solve_bulge_height(&cubic, choice.extent);
            self.stats.volume_exact = solution.exact;
            self.stats.volume_residual = solution.residual;
            self.stats.fallbacks.volume_without_root = usize::from(!solution.exact);
            (solution.height, choice.bulge * solution.height)
        } else {
            self.stats.volume_residual = cubic.eval(self.stats.bulge_height);
            (self.stats.bulge_height, old_applied)
        };
        for v in 0..n {
            if displacement.moved[v] {
                let linear = displacement.linear[v];
                self.positions[v] = mesh.positions[v] + applied * linear + displacement.constant[v];
                self.heights[v] += (applied - old_applied) * linear.dot(self.directions[v]);
            }
        }
        self.stats.bulge_height = bulge_height;
        self.stats.applied_bulge_height = applied;
        let (cones, moved) = terms.input_cones_and_moved(&mesh.triangles, &mesh.positions, reference);
        (self.stats.volume_before, self.stats.volume_after) =
            volumes_about_with(&mesh.triangles, cones, &self.positions, moved, reference);
        Ok(())
    }
}

/// The signed volumes of `before` and `after` on the region's faces relative to `reference`, in
/// one pass, from the cones of `before` (`before_cones`, per face, [`SweptTerms::input_cones`]):
/// a face none of whose vertices is marked in `moved` has the same cone in both (each sum gets
/// the same terms in the same order as two separate passes, so the same bits).
fn volumes_about_with(
    triangles: &[[u32; 3]],
    before_cones: &[f64],
    after: &[DVec3],
    moved: &[bool],
    reference: DVec3,
) -> (f64, f64) {
    let (mut sum_before, mut sum_after) = (0.0, 0.0);
    for (tri, &first) in triangles.iter().zip(before_cones) {
        sum_before += first;
        let still = tri.iter().all(|&v| !moved[v as usize]);
        sum_after += if still { first } else { volume::cone(after, tri, reference) };
    }
    (sum_before / 6.0, sum_after / 6.0)
}

/// Deforms one working region with all its contact zones (thesis ch. 5; see the module doc).
///
/// `mesh` is the region at this frame (positions may change every frame, connectivity may not),
/// `topology` its connectivity, `solver` the region's cache (build it once with
/// [`RegionSolver::new`]), `zones` its contact zones from chapter 4 (possibly none or empty).
/// Deterministic: the same input gives bit-identical output, with a fresh or a reused solver.
pub fn deform_region(
    mesh: &TriMesh,
    topology: &Topology,
    solver: &mut RegionSolver,
    zones: &[&ContactZone],
    params: &DeformParams,
) -> Result<RegionDeformation, DeformError> {
    deform_region_with(mesh, topology, solver, zones, params, &RegionOverrides::default())
}

/// [`deform_region`] with what the caller imposes or already has ([`RegionOverrides`]).
pub fn deform_region_with(
    mesh: &TriMesh,
    topology: &Topology,
    solver: &mut RegionSolver,
    zones: &[&ContactZone],
    params: &DeformParams,
    overrides: &RegionOverrides,
) -> Result<RegionDeformation, DeformError> {
    let fields = region_fields(mesh, topology, solver, zones, params, overrides)?;
    deform_with_fields(mesh, topology, zones, fields, params)
}

/// Chapter 5's last step on a region whose [`RegionFields`] are known (§5.4–5.5, App. C): the
/// bulge map, the profiles, the bulge height and the positions. With the fields of
/// [`region_fields`] for the same mesh, zones and parameters of §5.1–5.3, the result is
/// [`deform_region_with`]'s, bit for bit; the parameters it reads (see [`RegionFields`]) may
/// differ from the ones the fields were computed with.
pub fn deform_with_fields(
    mesh: &TriMesh,
    topology: &Topology,
    zones: &[&ContactZone],
    fields: RegionFields,
    params: &DeformParams,
) -> Result<RegionDeformation, DeformError> {
    deform_with_fields_and_terms(mesh, topology, zones, fields, params).map(|(deformation, _)| deformation)
}

/// [`deform_with_fields`] with the terms of its volume cubic: a later
/// [`RegionDeformation::correct`] given them expands only the faces around the vertices it
/// corrects (the same bits as from no terms).
pub fn deform_with_fields_and_terms(
    mesh: &TriMesh,
    topology: &Topology,
    zones: &[&ContactZone],
    fields: RegionFields,
    params: &DeformParams,
) -> Result<(RegionDeformation, SweptTerms), DeformError> {
    let start = Instant::now();
    let upstream_time = fields.stats.time;
    let plan = fields.plan(mesh, zones, params)?;
    let stage = Instant::now();
    let mut terms = SweptTerms::default();
    let cubic = plan.volume_cubic(mesh, topology, &mut terms)?;
    let (bulge_height, volume_exact, volume_residual) = if params.preserve_volume {
        let solution = solve_bulge_height(&cubic, params.extent);
        (solution.height, solution.exact, solution.residual)
    } else {
        (params.object.bulge_height, false, cubic.eval(params.object.bulge_height))
    };
    // `finish` adds its own time to the deformation stage: only the height solve is added here.
    let height_time = stage.elapsed();
    let mut deformation = plan.finish(mesh, bulge_height, params.object.bulge * bulge_height, &mut terms);
    let stats = &mut deformation.stats;
    stats.volume_exact = volume_exact;
    stats.volume_residual = volume_residual;
    stats.fallbacks.volume_without_root = usize::from(params.preserve_volume && !volume_exact);
    stats.timings[Stage::Deformation] += height_time;
    stats.time = upstream_time + start.elapsed();
    Ok((deformation, terms))
}

/// What a caller may impose on [`plan_region`] beyond [`DeformParams`] (chapter 6 needs it).
#[derive(Clone, Copy, Debug, Default)]
pub struct RegionOverrides<'a> {
    /// The mapping field d̄ per region vertex, used as given instead of the zones' directions
    /// (not normalized; §6.2.2 gives `(2β − 1)·d̂`). Blended direction field only.
    pub mapping_field: Option<&'a [DVec3]>,
    /// The region's vertex normals when the caller already has them: they must be
    /// [`vertex_normals`]`(mesh)` (the pipeline computes them once for the contact stage of a
    /// region processed whole). `None`: computed here.
    pub normals: Option<&'a [DVec3]>,
}

/// A region's deformation before its bulge height is chosen: every position is affine in the
/// bulge height h (`p′ = p + h·linear + constant`, see [`AffineDisplacement`]). [`deform_region`] solves h for
/// the region alone; chapter 6 blends the plans of two overlapping regions first and solves one h
/// for the blend ([`crate::skinning::plan_articulation`]).
#[derive(Clone, Debug)]
pub struct RegionPlan {
    /// The affine displacement of every region vertex.
    pub displacement: AffineDisplacement,
    /// The radial parameter u (0 in 𝒞, +∞ where no contact boundary is reachable and beyond the
    /// parametrization domain 𝒫).
    pub u: Vec<f64>,
    /// Per vertex: within the radius of the parametrization domain 𝒫 (edge-path distance from
    /// ∂𝒞, [`parametrize()`]).
    pub domain: Vec<bool>,
    /// The deformable region 𝒟.
    pub deformable: Vec<bool>,
    /// The contact region 𝒞.
    pub contact: Vec<bool>,
    /// The displacement direction d.
    pub directions: Vec<DVec3>,
    /// The part of 𝓗_i(u_i) that does not depend on h (on 𝒟).
    pub fixed_heights: Vec<f64>,
    /// The factor of h in 𝓗_i(u_i), η_i·N₂(t_i) (on 𝒟).
    pub bulge_weights: Vec<f64>,
    /// The amplitude field a (§5.3).
    pub amplitude: Vec<f64>,
    /// The slope field s (§5.3).
    pub slope: Vec<f64>,
    /// The bulge map η.
    pub bulge_map: Vec<f64>,
    /// Figures so far (the height, volume and total time are set by [`RegionPlan::finish`] and its
    /// caller).
    pub stats: DeformStats,
}

impl RegionPlan {
    /// ΔV(h) of the volume swept by the region's displacement ([`VolumeCubic::swept`], relative
    /// to the region's vertex centroid): the enclosed volume's change for a closed object. Its
    /// terms are left in `terms` (reused where they are of the same displacement,
    /// [`VolumeCubic::swept_with`]) for [`Self::finish`] and the corrections after.
    pub fn volume_cubic(
        &self,
        mesh: &TriMesh,
        topology: &Topology,
        terms: &mut SweptTerms,
    ) -> Result<VolumeCubic, DeformError> {
        VolumeCubic::swept_with(mesh, topology, &self.displacement, vertex_centroid(&mesh.positions), terms)
    }

    /// The positions for an applied height `applied` (γ·h_v): moved vertices get
    /// `p + applied·linear + constant`, the others are copied bit for bit.
    pub fn positions(&self, mesh: &TriMesh, applied: f64) -> Vec<DVec3> {
        let d = &self.displacement;
        let mut positions = mesh.positions.clone();
        for (v, p) in positions.iter_mut().enumerate() {
            if d.moved[v] {
                *p = mesh.positions[v] + applied * d.linear[v] + d.constant[v];
            }
        }
        positions
    }

    /// The deformation for the bulge height `bulge_height` (h_v) applied as `applied` (γ·h_v).
    /// The caller sets the volume figures of the stats that depend on how h_v was chosen.
    /// `terms`: those of [`Self::volume_cubic`] (or empty), which keep the input's cones.
    pub fn finish(self, mesh: &TriMesh, bulge_height: f64, applied: f64, terms: &mut SweptTerms) -> RegionDeformation {
        let stage = Instant::now();
        let positions = self.positions(mesh, applied);
        let heights = (0..positions.len())
            .map(|v| {
                if self.displacement.moved[v] && self.deformable[v] {
                    self.fixed_heights[v] + applied * self.bulge_weights[v]
                } else {
                    0.0
                }
            })
            .collect();
        let reference = vertex_centroid(&mesh.positions);
        let mut stats = self.stats;
        stats.bulge_height = bulge_height;
        stats.applied_bulge_height = applied;
        // Unmoved vertices keep their input bits (`positions`), so their faces' cones are shared.
        let cones = terms.input_cones(&mesh.triangles, &mesh.positions, reference);
        (stats.volume_before, stats.volume_after) =
            volumes_about_with(&mesh.triangles, cones, &positions, &self.displacement.moved, reference);
        stats.timings[Stage::Deformation] += stage.elapsed();
        RegionDeformation {
            positions,
            u: self.u,
            domain: self.domain,
            deformable: self.deformable,
            contact: self.contact,
            directions: self.directions,
            heights,
            amplitude: self.amplitude,
            slope: self.slope,
            bulge_map: self.bulge_map,
            displacement: self.displacement,
            stats,
        }
    }
}

/// Runs chapter 5 on a region up to, not including, the choice of the bulge height: contact set,
/// parametrization, direction field, guide fields, bulge map and profiles (see the module doc and
/// [`RegionPlan`]). [`deform_region`] is this plus the volume solve.
pub fn plan_region(
    mesh: &TriMesh,
    topology: &Topology,
    solver: &mut RegionSolver,
    zones: &[&ContactZone],
    params: &DeformParams,
    overrides: &RegionOverrides,
) -> Result<RegionPlan, DeformError> {
    region_fields(mesh, topology, solver, zones, params, overrides)?.plan(mesh, zones, params)
}

/// The fields of a region's deformation that §5.4–5.5 read, computed by §5.1–5.3 at one frame:
/// the contact set 𝒞, the radial parameter u, the domain 𝒫 and the deformable region 𝒟, the
/// directions d, and the amplitude and slope fields (a, s).
///
/// They depend on the mesh, the zones and the parameters of §5.1–5.3 only: the extent, the
/// domain radius, the length scale h, the constraint weight, the heat time factor, the domain
/// factor, the direction-field method and `normalize_diffused_direction`. They do not depend on
/// the parameters of §5.4–5.5 — the profile abscissas (`profile_v2`–`profile_v4`), the wrinkles,
/// `bulge`, `bulge_height`, `preserve_volume`, the painted `bulge_map` and the anisotropic map
/// (`anisotropy`, `anisotropy_exponent`, `anisotropy_offset`) — so a change of those alone is
/// [`RegionFields::plan`] (or [`deform_with_fields`]) on the same fields, with the same bits as
/// running the whole chapter again.
#[derive(Clone, Debug)]
pub struct RegionFields {
    /// The union 𝒞 of the zones.
    pub contact: ContactSet,
    /// The radial parameter u (0 in 𝒞, +∞ where undetermined).
    pub u: Vec<f64>,
    /// Per vertex: within the radius of the parametrization domain 𝒫.
    pub domain: Vec<bool>,
    /// The deformable region 𝒟.
    pub deformable: Vec<bool>,
    /// The displacement direction d.
    pub directions: Vec<DVec3>,
    /// The amplitude field a (§5.3).
    pub amplitude: Vec<f64>,
    /// The slope field s (§5.3).
    pub slope: Vec<f64>,
    /// Figures of §5.1–5.3: counts, factorizations, the stages' times, fallbacks (the time of
    /// the whole computation so far in `time`).
    pub stats: DeformStats,
}

/// Runs §5.1–5.3 on a region: contact set, parametrization, direction field and guide fields
/// ([`RegionFields`]). [`plan_region`] is this plus [`RegionFields::plan`].
pub fn region_fields(
    mesh: &TriMesh,
    topology: &Topology,
    solver: &mut RegionSolver,
    zones: &[&ContactZone],
    params: &DeformParams,
    overrides: &RegionOverrides,
) -> Result<RegionFields, DeformError> {
    // One span for the call, lapped at each stage (see `Work`).
    Work::measure(|| region_fields_measured(mesh, topology, solver, zones, params, overrides)).0
}

fn region_fields_measured(
    mesh: &TriMesh,
    topology: &Topology,
    solver: &mut RegionSolver,
    zones: &[&ContactZone],
    params: &DeformParams,
    overrides: &RegionOverrides,
) -> Result<RegionFields, DeformError> {
    let start = Instant::now();
    params.validate()?;
    solver.check_region(mesh, topology)?;
    let n = mesh.num_vertices();
    if let Some(map) = params.bulge_map.as_ref().filter(|map| map.len() != n) {
        return Err(DeformError::BulgeMapLength { expected: n, actual: map.len() });
    }
    if let Some((vertex, p)) = mesh.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(DeformError::NonFinitePosition { vertex, position: p.to_array() });
    }
    let factorizations_before = solver.numeric_factorizations();
    let factorized_rows_before = solver.factorized_rows();
    let recomputed_rows_before = solver.recomputed_rows();
    let reduced_analyses_before = solver.reduced_analyses();
    let factorization_time_before = solver.factorization_time();
    let analysis_time_before = solver.analysis_time();
    let flops_before = solver.factorization_flops();
    let analyzed_rows_before = solver.analyzed_rows();
    let mut timings = StageTimes::default();
    let mut work = StageWork::default();
    let mut fallbacks = FallbackCounters::default();
    Work::lap();

    // §5.1: parametrization.
    let stage = Instant::now();
    let contact = ContactSet::new(mesh, topology, zones)?;
    let parametrize_params = ParametrizeParams {
        extent: params.extent,
        domain_radius: params.domain_radius(),
        heat_time_factor: params.object.heat_time_factor,
        constraint_weight_factor: params.constraint_weight_factor,
        edge_length: params.edge_length,
    };
    // The blended field diffuses the zones' directions unless the caller gives d̄.
    let diffuse_directions =
        params.object.direction_field == DirectionFieldMethod::Blended && overrides.mapping_field.is_none();
    let parametrization =
        parametrize_and_diffuse(mesh, topology, solver, &contact, &parametrize_params, diffuse_directions)?;
    timings[Stage::Parametrization] = stage.elapsed();
    work[Stage::Parametrization] = Work::lap();

    // §5.2: directions.
    let stage = Instant::now();
    let computed_normals;
    let normals = match overrides.normals {
        Some(normals) => normals,
        None => {
            computed_normals = vertex_normals(mesh);
            &computed_normals
        }
    };
    let direction_params = DirectionParams {
        method: params.object.direction_field,
        normalize_diffused: params.object.normalize_diffused_direction,
        mapping_field: overrides.mapping_field,
    };
    let field = direction_field(mesh, solver, &contact, &parametrization, normals, &direction_params)?;
    fallbacks.direction_blend = field.fallbacks;
    timings[Stage::Directions] = stage.elapsed();
    work[Stage::Directions] = Work::lap();

    // §5.3: amplitude and slope.
    let stage = Instant::now();
    let guide = guide_fields(
        mesh,
        topology,
        solver,
        &contact,
        &parametrization,
        &field,
        &GuideParams { constraint_weight_factor: params.constraint_weight_factor },
    )?;
    fallbacks.clamped_slopes = guide.clamped_slopes;
    timings[Stage::Guide] = stage.elapsed();
    work[Stage::Guide] = Work::lap();
    work[Stage::Factorization].flops = solver.factorization_flops() - flops_before;
    work[Stage::Analysis].rows = solver.analyzed_rows() - analyzed_rows_before;

    timings[Stage::Factorization] = solver.factorization_time().saturating_sub(factorization_time_before);
    timings[Stage::Analysis] = solver.analysis_time().saturating_sub(analysis_time_before);
    let stats = DeformStats {
        num_deformable: parametrization.num_deformable(),
        num_contact: contact.num_inside(),
        num_boundary_points: contact.boundary.len(),
        // Every vertex of 𝒞 and of 𝒟 moves (§5.4).
        outer_boundary_moved: solver
            .outer_boundary()
            .iter()
            .zip(contact.vertex_zone.iter().zip(&parametrization.deformable))
            .filter(|(on_boundary, (zone, deformable))| {
                **on_boundary && (**zone != contact_set::NO_ZONE || **deformable)
            })
            .count(),
        numeric_factorizations: solver.numeric_factorizations() - factorizations_before,
        factorized_rows: solver.factorized_rows() - factorized_rows_before,
        recomputed_rows: solver.recomputed_rows() - recomputed_rows_before,
        reduced_analyses: solver.reduced_analyses() - reduced_analyses_before,
        timings,
        work,
        time: start.elapsed(),
        fallbacks,
        ..DeformStats::default()
    };
    Ok(RegionFields {
        contact,
        u: parametrization.u,
        domain: parametrization.in_domain,
        deformable: parametrization.deformable,
        directions: field.directions,
        amplitude: guide.amplitude,
        slope: guide.slope,
        stats,
    })
}

impl RegionFields {
    /// §5.4–5.5 on these fields: the bulge map η (painted × anisotropic) and the per-vertex
    /// profiles, as a [`RegionPlan`]. Reads, of `params`, only what §5.4–5.5 read (see the type's
    /// doc) and the extent (the anisotropic map's scale), which must be the one the fields were
    /// computed with; the mesh and zones must be theirs too.
    pub fn plan(
        self,
        mesh: &TriMesh,
        zones: &[&ContactZone],
        params: &DeformParams,
    ) -> Result<RegionPlan, DeformError> {
        let start = Instant::now();
        params.validate()?;
        let n = mesh.num_vertices();
        if let Some(map) = params.bulge_map.as_ref().filter(|map| map.len() != n) {
            return Err(DeformError::BulgeMapLength { expected: n, actual: map.len() });
        }
        if self.u.len() != n || self.contact.vertex_zone.len() != n {
            return Err(DeformError::StaleFactorization { stage: "region fields of another mesh" });
        }
        let Self { contact, u, domain, deformable, directions, amplitude, slope, mut stats } = self;
        let anisotropy = params.object.anisotropy.then_some(AnisotropyParams {
            exponent: params.object.anisotropy_exponent,
            offset: params.object.anisotropy_offset,
        });
        let eta = bulge_map(
            mesh,
            zones,
            &contact,
            &deformable,
            params.bulge_map.as_deref(),
            anisotropy.as_ref(),
            params.extent,
        );
        stats.fallbacks.bulge_map = usize::from(eta.fallback);

        let mut displacement = AffineDisplacement::none(n);
        let mut fixed_heights = vec![0.0; n];
        let mut bulge_weights = vec![0.0; n];
        // The profile samples (an inversion of f₁ per vertex of 𝒟, the costliest part of this
        // stage) are independent: computed in parallel, used in vertex order.
        let sampler = profile::ProfileSampler::new(&params.profile());
        let wrinkles = params.wrinkles();
        let samples: Vec<Option<profile::ProfileSample>> = (0..n)
            .into_par_iter()
            .with_min_len(1024)
            .map(|v| {
                (contact.vertex_zone[v] == contact_set::NO_ZONE && deformable[v])
                    .then(|| sampler.sample(&wrinkles, amplitude[v], slope[v], u[v]))
            })
            .collect();
        for v in 0..n {
            let zone = contact.vertex_zone[v];
            if zone != contact_set::NO_ZONE {
                displacement.moved[v] = true;
                displacement.constant[v] = zones[zone as usize].targets[v] - mesh.positions[v];
            } else if let Some(sample) = samples[v] {
                let d = directions[v];
                displacement.moved[v] = true;
                displacement.linear[v] = d * (eta.weights[v] * sample.bulge_weight);
                displacement.constant[v] = d * sample.fixed;
                fixed_heights[v] = sample.fixed;
                bulge_weights[v] = eta.weights[v] * sample.bulge_weight;
            }
        }
        stats.timings[Stage::Deformation] = start.elapsed();
        stats.time += start.elapsed();
        Ok(RegionPlan {
            displacement,
            u,
            domain,
            deformable,
            contact: contact.vertex_zone.iter().map(|&z| z != contact_set::NO_ZONE).collect(),
            directions,
            fixed_heights,
            bulge_weights,
            amplitude,
            slope,
            bulge_map: eta.weights,
            stats,
        })
    }
}
