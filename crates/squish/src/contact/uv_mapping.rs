//! The shared-parametrization mapping (thesis §4.2.1, method A; Fig. 4.1 and the algorithm box of
//! §4.5, "Region mapping ▷ §2.1"), selected per pair with
//! [`MappingMethod::SharedParametrization`](super::MappingMethod::SharedParametrization).
//!
//! Both working regions carry per-vertex UVs ([`ContactSide::with_uvs`]). Every intersection point
//! q_k of §4.1 is known on both meshes (on an edge of one, a face of the other), hence in both
//! parametrizations: q_{k,own} and q_{k,other}. For each side (own → other):
//! 1. **Affine fit.** A (2 × 3: a 2 × 2 linear part and a translation; the thesis' "3 × 4" is the
//!    same map for 3D parameters) minimizes Σ_k ‖q_{k,other} − A q_{k,own}‖² over all pairs, on
//!    centred data. Decision for degenerate inputs: when the points are (nearly) collinear — the
//!    normal matrix has a reciprocal condition number below 10⁻¹⁰ — a similarity (rotation,
//!    uniform scale, translation) is fitted instead, and with a single distinct point a
//!    translation ([`AffineFit`]).
//! 2. **Harmonic correction.** The residuals e_k = q_{k,other} − A q_{k,own} at the intersection
//!    points lying on this side's edges — the exact boundary points of ℐ_own — are least-squares
//!    edge constraints `(1 − α)g_i + αg_j = e_k` (App. B) of a harmonic diffusion of the 2D field
//!    g over ℐ_own and its exterior one-ring. The stiffness is cut-face weighted by the area inside
//!    ℐ (App. B), so g varies continuously as ℐ's boundary crosses vertices. The system is built
//!    on the sub-mesh of the faces touching ℐ (small: only the intersection region is factorized).
//! 3. **Location.** Each interior vertex i goes to A q_{i,own} + g_i in the other's UV space, which
//!    is located in the other mesh by a 2D box tree over its UV triangles (the faces touching ℐ_other
//!    and their one-ring: the mapping is between intersection regions). The containing triangle
//!    and its barycentric coordinates give p″_i and n″_i (interpolated vertex normals). A target
//!    outside every UV triangle (a seam, a chart border) falls back to the nearest UV triangle and
//!    is counted.
//!
//! The mapping regions are the intersection regions: ℳ = ℐ (§4.2.1, "the mapping regions ℳ_l
//! correspond to the intersection regions ℐ_l"). The boundary points of ℐ are intersection points,
//! matched exactly to their point on the other mesh (displacement 0: the mapped region meets the
//! unmapped surface without a step).
//!
//! **Known limits** (§4.2.1 discussion). The map is a bijection between the two intersection
//! regions, so (1) for deep collisions, and more so when one object is rigid, a large region is
//! squeezed onto a small one: the potential contact surface gets under-sampled and stretched
//! (Fig. 4.2); (2) the mapping can never reach beyond the intersection regions, which is wrong for
//! objects that must have slid into place (a foot sunk into the ground, Fig. 4.3) and gives
//! distorted, seemingly incomplete mappings there; (3) it is asymmetric — the diffusion depends on
//! which mesh is mapped onto which — and (4) it depends on the UV layout (seams, islands, mirrored
//! or overlapping charts all break it; only the faces near ℐ_other are searched, which avoids
//! picking a far-away chart that reuses the same UV space).
//!
//! **Which mapping when.** Use the unique mapping direction (method B, default) in general: it
//! needs no UVs, extends the mapping regions beyond ℐ and follows the apparent motion. Use the
//! shared parametrization for shallow contacts between objects whose UVs are continuous and
//! similarly scaled around the contact (e.g. a tool with a matched parametrization, or to
//! reproduce method A), and when the relative motion is not a translation along one direction
//! (sliding contacts where d̂ would be ill-defined).

use glam::{DMat2, DVec2, DVec3};
use rayon::prelude::*;

use super::intersect::IntersectionPoint;
use super::mapping::{Match, MatchKind, MappingStats, NO_SLOT, SideMapping, normal_at};
use super::surface::surface_sample;
use super::zone::ZoneResult;
use super::{ContactError, ContactSide, EdgeRegion, Sample};
use crate::linalg::{
    ConstrainedSolver, ConstraintParams, EdgeConstraint, Operator, RightHandSide, SparsePattern, SymbolicFactor,
    cut_face_weights,
};
use crate::mesh::{Aabb3, SubMesh, Topology, TriMesh};
use crate::spatial::{AabbTree, closest_point_on_triangle};

/// Checks that both sides have UVs (their lengths are checked by [`ContactSide::validate`]).
pub(crate) fn check_uvs(sides: [&ContactSide; 2]) -> Result<(), ContactError> {
    for side in sides {
        if side.uvs.is_none() {
            return Err(ContactError::MissingUvs { object: side.display_name() });
        }
    }
    Ok(())
}

/// A 2D affine map `q ↦ linear·q + translation` between two UV spaces.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UvAffine {
    pub linear: DMat2,
    pub translation: DVec2,
}

impl Default for UvAffine {
    fn default() -> Self {
        Self { linear: DMat2::IDENTITY, translation: DVec2::ZERO }
    }
}

impl UvAffine {
    /// The image of `q`.
    #[inline]
    pub fn apply(&self, q: DVec2) -> DVec2 {
        self.linear * q + self.translation
    }
}

/// Which model [`fit_affine`] could determine from the point pairs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum AffineFit {
    /// A full affine map (three or more points in general position).
    #[default]
    Affine,
    /// Collinear points: rotation, uniform scale and translation.
    Similarity,
    /// One distinct point (or none): a translation.
    Translation,
}

/// Least-squares map A with `to ≈ A·from` over the pairs `(from, to)` (module docs, step 1).
pub fn fit_affine(pairs: &[(DVec2, DVec2)]) -> (UvAffine, AffineFit) {
    if pairs.is_empty() {
        return (UvAffine::default(), AffineFit::Translation);
    }
    let count = pairs.len() as f64;
    let mean_from = pairs.iter().map(|p| p.0).sum::<DVec2>() / count;
    let mean_to = pairs.iter().map(|p| p.1).sum::<DVec2>() / count;
    // Centred moments: S = Σ x xᵀ, T = Σ y xᵀ.
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    let mut t = DMat2::ZERO;
    for &(from, to) in pairs {
        let (x, y) = (from - mean_from, to - mean_to);
        sxx += x.x * x.x;
        sxy += x.x * x.y;
        syy += x.y * x.y;
        t += DMat2::from_cols(y * x.x, y * x.y);
    }
    let trace = sxx + syy;
    let det = sxx * syy - sxy * sxy;
    let translation_only = |linear: DMat2| UvAffine { linear, translation: mean_to - linear * mean_from };
    if !(trace > 0.0) || !trace.is_finite() {
        return (translation_only(DMat2::IDENTITY), AffineFit::Translation);
    }
    if det > 1e-10 * trace * trace {
        let s = DMat2::from_cols(DVec2::new(sxx, sxy), DVec2::new(sxy, syy));
        return (translation_only(t * s.inverse()), AffineFit::Affine);
    }
    // Similarity: y = a·x with a complex, a = Σ conj(x) y / Σ |x|².
    let (mut re, mut im) = (0.0, 0.0);
    for &(from, to) in pairs {
        let (x, y) = (from - mean_from, to - mean_to);
        re += x.x * y.x + x.y * y.y;
        im += x.x * y.y - x.y * y.x;
    }
    let (re, im) = (re / trace, im / trace);
    (translation_only(DMat2::from_cols(DVec2::new(re, im), DVec2::new(-im, re))), AffineFit::Similarity)
}

/// Point location in the UV space of one mesh: a 2D box tree over its UV triangles.
#[derive(Clone, Debug)]
struct UvLocator {
    faces: Vec<u32>,
    tree: Option<AabbTree>,
    /// A length scale of the UV space (diagonal of the triangles' box), to start nearest searches.
    scale: f64,
}

fn uv_corners(mesh: &TriMesh, uvs: &[DVec2], face: u32) -> [DVec2; 3] {
    mesh.triangles[face as usize].map(|v| uvs[v as usize])
}

/// Barycentric coordinates of `q` in the 2D triangle `t` (`None` if it is degenerate).
fn barycentric_2d(q: DVec2, t: &[DVec2; 3]) -> Option<[f64; 3]> {
    let area = (t[1] - t[0]).perp_dot(t[2] - t[0]);
    if !(area.abs() > 0.0) || !area.is_finite() {
        return None;
    }
    let b1 = (q - t[0]).perp_dot(t[2] - t[0]) / area;
    let b2 = (t[1] - t[0]).perp_dot(q - t[0]) / area;
    Some([1.0 - b1 - b2, b1, b2])
}

impl UvLocator {
    fn new(mesh: &TriMesh, uvs: &[DVec2], faces: Vec<u32>) -> Result<Self, ContactError> {
        let faces: Vec<u32> = faces
            .into_iter()
            .filter(|&f| barycentric_2d(DVec2::ZERO, &uv_corners(mesh, uvs, f)).is_some())
            .collect();
        if faces.is_empty() {
            return Ok(Self { faces, tree: None, scale: 1.0 });
        }
        let boxes: Vec<Aabb3> = faces
            .iter()
            .map(|&f| {
                let c = uv_corners(mesh, uvs, f);
                Aabb3 { min: c[0].min(c[1]).min(c[2]).extend(0.0), max: c[0].max(c[1]).max(c[2]).extend(0.0) }
            })
            .collect();
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for b in &boxes {
            lo = lo.min(b.min);
            hi = hi.max(b.max);
        }
        let scale = (hi - lo).length().max(f64::MIN_POSITIVE);
        Ok(Self { faces, tree: Some(AabbTree::new(&boxes)?), scale })
    }

    /// The face and barycentric coordinates of `q`: the containing UV triangle (the most interior
    /// one, then the smallest face id), or the nearest one (`true`: a fallback).
    fn locate(&self, mesh: &TriMesh, uvs: &[DVec2], q: DVec2) -> Option<(u32, [f64; 3], bool)> {
        let tree = self.tree.as_ref()?;
        let mut best: Option<(f64, u32, [f64; 3])> = None;
        let point = Aabb3 { min: q.extend(0.0), max: q.extend(0.0) };
        tree.for_each_overlapping(&point, |leaf| {
            let face = self.faces[leaf as usize];
            if let Some(b) = barycentric_2d(q, &uv_corners(mesh, uvs, face)) {
                let score = b[0].min(b[1]).min(b[2]);
                if score >= -1e-12 && best.is_none_or(|(s, f, _)| score > s || (score == s && face < f)) {
                    best = Some((score, face, b));
                }
            }
        });
        if let Some((_, face, bary)) = best {
            return Some((face, bary, false));
        }
        // Nearest UV triangle: grow the search radius until something is found, then search again
        // within the best distance so that the answer does not depend on the tree's shape.
        let p = q.extend(0.0);
        let nearest_within = |radius: f64| {
            let mut best: Option<(f64, u32, [f64; 3])> = None;
            tree.for_each_within_distance(p, radius, |leaf, _| {
                let face = self.faces[leaf as usize];
                let t = uv_corners(mesh, uvs, face).map(|c| c.extend(0.0));
                let b = closest_point_on_triangle(p, &t);
                let d = (t[0] * b[0] + t[1] * b[1] + t[2] * b[2] - p).length();
                if best.is_none_or(|(bd, f, _)| d < bd || (d == bd && face < f)) {
                    best = Some((d, face, b));
                }
            });
            best
        };
        let mut radius = 1e-3 * self.scale;
        for _ in 0..80 {
            if let Some((d, _, _)) = nearest_within(radius) {
                let (_, face, bary) = nearest_within(d * (1.0 + 1e-9) + f64::MIN_POSITIVE)?;
                return Some((face, bary, true));
            }
            radius *= 2.0;
        }
        None
    }
}

/// The UV side of the shared-parametrization mapping of one side: where its samples of ℳ = ℐ go in
/// the other mesh's UV space, and how to locate more points there.
#[derive(Clone, Debug)]
pub struct SideParametrization {
    /// A: this side's UVs → the other's.
    pub affine: UvAffine,
    /// Which model A is.
    pub fit: AffineFit,
    /// Per vertex of ℳ (order of [`SideMapping::vertices`]): A q_i + g_i.
    pub vertex_targets: Vec<DVec2>,
    /// Per boundary point of ℳ: its exact location in the other's UV space (an intersection
    /// point), or A q + g interpolated if it could not be paired with one.
    pub point_targets: Vec<DVec2>,
    /// max_k ‖e_k‖ = max ‖q_{k,other} − A q_{k,own}‖ over all intersection points (0 when the two
    /// parametrizations are related by an affine map there).
    pub affine_residual: f64,
    /// Boundary points of ℳ constrained by an intersection point (the others had none).
    pub constrained_points: usize,
    /// Targets located by the nearest-triangle fallback.
    pub location_fallbacks: usize,
    locator: UvLocator,
}

impl SideParametrization {
    /// The UV target (in the other's space) of a sample of ℳ.
    pub fn target(&self, mapping: &SideMapping, sample: Sample) -> Option<DVec2> {
        match sample {
            Sample::Vertex(v) => match mapping.vertex_slot.get(v as usize) {
                Some(&s) if s != NO_SLOT => self.vertex_targets.get(s as usize).copied(),
                _ => None,
            },
            Sample::Point(p) => self.point_targets.get(p as usize).copied(),
        }
    }

    /// The match on `other` of a UV location in its space (`true`: nearest-triangle fallback).
    pub fn locate(&self, other: &ContactSide, q: DVec2) -> (Match, bool) {
        let located = other.uvs.and_then(|uvs| self.locator.locate(other.mesh, uvs, q));
        match located {
            Some((face, bary, fallback)) => {
                let tri = other.mesh.triangles[face as usize];
                let point = (0..3).map(|k| other.mesh.positions[tri[k] as usize] * bary[k]).sum();
                let normal = normal_at(other.mesh, other.normals, face, bary);
                (Match { face, bary, point, normal, kind: MatchKind::Parametric }, fallback)
            }
            None => (Match { face: u32::MAX, kind: MatchKind::Parametric, ..Match::default() }, true),
        }
    }

    /// The match of the point at parameter `t` ∈ [0, 1] between two samples of ℳ (their UV targets
    /// interpolated linearly, then located; `true`: a fallback).
    pub fn match_between(&self, mapping: &SideMapping, other: &ContactSide, from: Sample, to: Sample, t: f64) -> (Match, bool) {
        let q = match (self.target(mapping, from), self.target(mapping, to)) {
            (Some(a), Some(b)) => a.lerp(b, t),
            (Some(a), None) | (None, Some(a)) => a,
            (None, None) => return (Match { face: u32::MAX, kind: MatchKind::Parametric, ..Match::default() }, true),
        };
        self.locate(other, q)
    }
}

/// The shared-parametrization data of a pair, per side [a, b].
#[derive(Clone, Debug)]
pub struct SharedParametrization {
    pub sides: [SideParametrization; 2],
}

/// UV of an intersection point on side `l` (on its edge or on its face).
fn point_uv(p: &IntersectionPoint, l: usize, side: &ContactSide, uvs: &[DVec2]) -> DVec2 {
    if p.edge_side as usize == l {
        let [i, j] = side.topology.edge(p.edge);
        uvs[i as usize].lerp(uvs[j as usize], p.t)
    } else {
        let tri = side.mesh.triangles[p.face as usize];
        (0..3).map(|k| uvs[tri[k] as usize] * p.bary[k]).sum()
    }
}

/// For each boundary point of ℐ (side `l`), the intersection point it was made from: the crossing
/// of its edge nearest to its inside vertex, if its α agrees.
fn boundary_sources(region: &EdgeRegion, l: usize, topology: &Topology, points: &[IntersectionPoint]) -> Vec<Option<usize>> {
    // The points of this side's edges, sorted by (edge, position along it).
    let mut order: Vec<usize> = (0..points.len()).filter(|&k| points[k].edge_side as usize == l).collect();
    order.sort_by(|&x, &y| points[x].edge.cmp(&points[y].edge).then(points[x].t.total_cmp(&points[y].t)).then(x.cmp(&y)));
    region
        .points()
        .iter()
        .zip(region.point_edges())
        .map(|(bp, &e)| {
            let start = order.partition_point(|&k| points[k].edge < e);
            let end = order.partition_point(|&k| points[k].edge <= e);
            if start == end {
                return None;
            }
            let from_lo = topology.edge(e)[0] == bp.inside;
            let k = if from_lo { order[start] } else { order[end - 1] };
            let alpha = if from_lo { points[k].t } else { 1.0 - points[k].t };
            ((alpha - bp.alpha).abs() <= 1e-9).then_some(k)
        })
        .collect()
}

/// The faces of `side` touching ℐ or its one-ring (all faces if ℐ is empty).
fn faces_near(side: &ContactSide, region: &EdgeRegion) -> Vec<u32> {
    let inside = region.inside();
    let mut near = inside.to_vec();
    for (v, &i) in inside.iter().enumerate() {
        if i {
            for w in side.topology.vertex_neighbors(v as u32) {
                near[w as usize] = true;
            }
        }
    }
    let faces: Vec<u32> = (0..side.mesh.num_triangles() as u32)
        .filter(|&f| side.mesh.triangles[f as usize].iter().any(|&v| near[v as usize]))
        .collect();
    if faces.is_empty() { (0..side.mesh.num_triangles() as u32).collect() } else { faces }
}

/// The harmonic 2D field g over ℐ and its exterior one-ring with the constraints
/// `(1 − α)g_i + αg_j = e` (module docs, step 2). Returns g per vertex of the side's mesh (0 away
/// from ℐ).
fn diffuse_residuals(
    side: &ContactSide,
    region: &EdgeRegion,
    constraints: &[(u32, u32, f64, DVec2)],
) -> Result<Vec<DVec2>, ContactError> {
    let n = side.mesh.num_vertices();
    let mut g = vec![DVec2::ZERO; n];
    if constraints.is_empty() {
        return Ok(g);
    }
    let err = |e: crate::linalg::SolveError| ContactError::UvMapping {
        object: side.display_name(),
        reason: format!("the harmonic correction of the UV residuals failed: {e}"),
    };
    let outside = region.complement();
    let inside_weights = cut_face_weights(side.mesh, side.topology, outside.inside(), outside.points()).map_err(err)?;
    let sub = SubMesh::from_faces(
        side.mesh,
        inside_weights.iter().enumerate().filter(|(_, w)| **w > 0.0).map(|(f, _)| f as u32),
    );
    let weights: Vec<f64> = sub.parent_face.iter().map(|&f| inside_weights[f as usize]).collect();
    let topology = Topology::new(&sub.mesh);
    let pattern = SparsePattern::shared(&sub.mesh, &topology).map_err(err)?;
    let symbolic = SymbolicFactor::analyze(&pattern).map_err(err)?;
    let operator = Operator::stiffness(&sub.mesh, &pattern, Some(&weights)).map_err(err)?;
    let mut local = Vec::with_capacity(constraints.len());
    let mut values = [Vec::with_capacity(constraints.len()), Vec::with_capacity(constraints.len())];
    for &(i, j, alpha, e) in constraints {
        let (li, lj) = (sub.local_vertex[i as usize], sub.local_vertex[j as usize]);
        if li == crate::mesh::NOT_IN_SUBMESH || lj == crate::mesh::NOT_IN_SUBMESH {
            continue;
        }
        local.push(EdgeConstraint::on_edge(li, lj, alpha, 0.0));
        values[0].push(e.x);
        values[1].push(e.y);
    }
    let mut solver =
        ConstrainedSolver::new(&symbolic, &operator, &local, &ConstraintParams::default()).map_err(err)?;
    let columns = solver
        .solve_many(&[
            RightHandSide { constraint_values: Some(&values[0]), ..Default::default() },
            RightHandSide { constraint_values: Some(&values[1]), ..Default::default() },
        ])
        .map_err(err)?;
    for (k, &v) in sub.parent_vertex.iter().enumerate() {
        g[v as usize] = DVec2::new(columns[0][k], columns[1][k]);
    }
    Ok(g)
}

/// One side of [`map_regions_uv`].
fn map_side_uv(
    l: usize,
    sides: [&ContactSide; 2],
    intersections: [&EdgeRegion; 2],
    points: &[IntersectionPoint],
) -> Result<(SideMapping, MappingStats, SideParametrization), ContactError> {
    let (side, other) = (sides[l], sides[1 - l]);
    let missing = |s: &ContactSide| ContactError::MissingUvs { object: s.display_name() };
    let uvs = side.uvs.ok_or_else(|| missing(side))?;
    let other_uvs = other.uvs.ok_or_else(|| missing(other))?;
    let region = intersections[l];

    // 1. Affine fit over all intersection points.
    let pairs: Vec<(DVec2, DVec2)> =
        points.iter().map(|p| (point_uv(p, l, side, uvs), point_uv(p, 1 - l, other, other_uvs))).collect();
    let (affine, fit) = fit_affine(&pairs);
    let affine_residual = pairs.iter().map(|&(a, b)| (b - affine.apply(a)).length()).fold(0.0, f64::max);

    // 2. Residuals at the boundary points of ℐ, diffused.
    let sources = boundary_sources(region, l, side.topology, points);
    let constraints: Vec<(u32, u32, f64, DVec2)> = region
        .points()
        .iter()
        .zip(&sources)
        .filter_map(|(bp, s)| s.map(|k| (bp.inside, bp.outside, bp.alpha, pairs[k].1 - affine.apply(pairs[k].0))))
        .collect();
    let g = diffuse_residuals(side, region, &constraints)?;

    // 3. Targets and their location on the other mesh.
    let vertices: Vec<u32> = (0..side.mesh.num_vertices() as u32).filter(|&v| region.contains(v)).collect();
    let mut vertex_slot = vec![NO_SLOT; side.mesh.num_vertices()];
    for (k, &v) in vertices.iter().enumerate() {
        vertex_slot[v as usize] = k as u32;
    }
    let vertex_targets: Vec<DVec2> = vertices.iter().map(|&v| affine.apply(uvs[v as usize]) + g[v as usize]).collect();
    let point_targets: Vec<DVec2> = region
        .points()
        .iter()
        .zip(&sources)
        .map(|(bp, s)| match s {
            Some(k) => pairs[*k].1,
            None => {
                let q = uvs[bp.inside as usize].lerp(uvs[bp.outside as usize], bp.alpha);
                affine.apply(q) + g[bp.inside as usize].lerp(g[bp.outside as usize], bp.alpha)
            }
        })
        .collect();
    let locator = UvLocator::new(other.mesh, other_uvs, faces_near(other, intersections[1 - l]))?;
    let mut param = SideParametrization {
        affine,
        fit,
        vertex_targets,
        point_targets,
        affine_residual,
        constrained_points: constraints.len(),
        location_fallbacks: 0,
        locator,
    };
    let located: Vec<(Match, bool)> = param.vertex_targets.par_iter().map(|&q| param.locate(other, q)).collect();
    let mut fallbacks = located.iter().filter(|(_, f)| *f).count();
    let vertex_matches: Vec<Match> = located.into_iter().map(|(m, _)| m).collect();
    let point_matches: Vec<Match> = sources
        .iter()
        .zip(&param.point_targets)
        .map(|(s, &q)| match s {
            // An intersection point lies on a face of the other side exactly when it is on an edge
            // of this side.
            Some(k) => {
                let p = &points[*k];
                Match {
                    face: p.face,
                    bary: p.bary,
                    point: p.position,
                    normal: normal_at(other.mesh, other.normals, p.face, p.bary),
                    kind: MatchKind::Parametric,
                }
            }
            None => {
                let (m, fallback) = param.locate(other, q);
                fallbacks += usize::from(fallback);
                m
            }
        })
        .collect();
    param.location_fallbacks = fallbacks;
    let mut stats = MappingStats { closest_point_matches: fallbacks, ..MappingStats::default() };
    if let Some(border) = side.border {
        stats.border_vertices = vertices.iter().filter(|&&v| border.get(v as usize).copied().unwrap_or(false)).count();
    }
    let mapping = SideMapping {
        front: region.clone(),
        projected: EdgeRegion::empty(side.topology),
        region: region.clone(),
        vertices,
        vertex_slot,
        vertex_matches,
        point_matches,
    };
    Ok((mapping, stats, param))
}

/// The shared-parametrization mapping of a pair (module docs): ℳ_l = ℐ_l with matches located in
/// UV space, for both sides (in parallel), plus the UV data needed to match more points later.
pub fn map_regions_uv(
    sides: [&ContactSide; 2],
    intersections: [&EdgeRegion; 2],
    points: &[IntersectionPoint],
) -> Result<([SideMapping; 2], MappingStats, SharedParametrization), ContactError> {
    check_uvs(sides)?;
    let (a, b) = rayon::join(
        || map_side_uv(0, sides, intersections, points),
        || map_side_uv(1, sides, intersections, points),
    );
    let ((ma, sa, pa), (mb, sb, pb)) = (a?, b?);
    let stats = MappingStats {
        closest_point_matches: sa.closest_point_matches + sb.closest_point_matches,
        border_vertices: sa.border_vertices + sb.border_vertices,
        ..MappingStats::default()
    };
    Ok(([ma, mb], stats, SharedParametrization { sides: [pa, pb] }))
}

/// Recomputes the boundary points of a zone found by the geometric criterion in UV space (the
/// criterion casts them along ±d̂, which is not how the shared parametrization matches points):
/// a point at α on the edge from i to its far end (j if j ∈ ℳ, else ℳ's boundary point) gets the
/// interpolated UV target located on the other mesh. End points (α = 0 or at the far end) were
/// reused exactly by the criterion and are left alone. Updates the zone's area on 𝒮.
#[allow(clippy::too_many_arguments)]
pub(crate) fn rematch_zone(
    result: &mut ZoneResult,
    side: &ContactSide,
    other: &ContactSide,
    mapping: &SideMapping,
    param: &SideParametrization,
    toward: DVec3,
    k_own: f64,
    k_other: f64,
) {
    let zone = &mut result.zone;
    let region = &zone.region;
    for (k, (bp, &e)) in region.points().iter().zip(region.point_edges()).enumerate() {
        let end = if mapping.vertex_slot.get(bp.outside as usize).is_some_and(|&s| s != NO_SLOT) {
            Some((Sample::Vertex(bp.outside), 1.0))
        } else {
            mapping.region.point_on_edge(e).and_then(|p| {
                let point = mapping.region.points()[p as usize];
                (point.inside == bp.inside).then_some((Sample::Point(p), point.alpha))
            })
        };
        let Some((to, span)) = end else { continue };
        if bp.alpha <= 0.0 || bp.alpha >= span || span <= 0.0 {
            continue;
        }
        let (m, fallback) = param.match_between(mapping, other, Sample::Vertex(bp.inside), to, bp.alpha / span);
        result.closest_point_matches += usize::from(fallback);
        let p = zone.boundary_positions[k];
        let n = region.interpolate(side.normals, Sample::Point(k as u32)).normalize_or_zero();
        let s = surface_sample(p, n, &m, toward, k_own, k_other);
        zone.boundary_targets[k] = s.target;
        zone.boundary_normals[k] = s.surface_normal;
    }
    let (targets, boundary_targets) = (&zone.targets, &zone.boundary_targets);
    result.area_on_surface = region.area_with(side.mesh, side.topology, |s| match s {
        Sample::Vertex(v) => targets[v as usize],
        Sample::Point(p) => boundary_targets[p as usize],
    });
}
