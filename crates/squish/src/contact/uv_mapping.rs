//! The shared-parametrization mapping (thesis §4.2.1, method A; Fig. 4.1 and the algorithm box of
//! §4.5, "Region mapping ▷ §2.1"), selected per pair with
//! [`MappingMethod::SharedParametrization`](super::MappingMethod::SharedParametrization).
//!
//! Both working regions carry UVs ([`ContactSide::with_uvs`]), per vertex or per triangle corner
//! ([`Uvs`]). **Seams.** Per-corner UVs are first unfolded into one layout per vertex over the
//! faces the mapping reads (those touching ℐ and its one-ring, and those holding intersection
//! points): a breadth-first walk over the faces from the lowest face id, where a face reached
//! across an edge whose two corners carry the same UVs on both faces keeps its neighbour's chart,
//! and a face reached across a seam is placed by the 2D similarity (rotation, uniform scale,
//! translation; with a reflection when the two charts are mirrored) that takes the edge's UVs in
//! its chart onto the edge as its neighbour was placed ([`unfold`]). The charts thus meet as the
//! surface does, and the steps below run on one continuous parametrization whatever the seams
//! (docs/decisions.md, "UV seams in the shared parametrization"). UVs without seams are used as
//! they are, bit for bit. Every intersection point
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

use std::collections::VecDeque;
use std::sync::Arc;

use glam::{DMat2, DVec2, DVec3};
use rayon::prelude::*;

use super::intersect::IntersectionPoint;
use super::mapping::{MappingStats, Match, MatchKind, NO_SLOT, SideMapping, normal_at};
use super::surface::surface_sample;
use super::zone::ZoneResult;
use super::{ContactError, ContactSide, EdgeRegion, Sample};
use crate::linalg::{
    ConstrainedSolver, ConstraintParams, EdgeConstraint, Operator, RightHandSide, SparsePattern, SymbolicFactor,
    cut_face_weights,
};
use crate::mesh::{Aabb3, NO_FACE, SubMesh, Topology, TriMesh};
use crate::params::Uvs;
use crate::spatial::{AabbTree, closest_point_on_triangle};
use crate::stage::SharedWork;

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
    if trace <= 0.0 || !trace.is_finite() {
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

/// Point location in the UV space of one mesh: a 2D box tree over its UV triangles, in the
/// unfolded layout (one UV per vertex) it was built on.
#[derive(Clone, Debug)]
struct UvLocator {
    uvs: Arc<[DVec2]>,
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
    if area == 0.0 || !area.is_finite() {
        return None;
    }
    let b1 = (q - t[0]).perp_dot(t[2] - t[0]) / area;
    let b2 = (t[1] - t[0]).perp_dot(q - t[0]) / area;
    Some([1.0 - b1 - b2, b1, b2])
}

impl UvLocator {
    fn new(mesh: &TriMesh, uvs: Arc<[DVec2]>, faces: Vec<u32>) -> Result<Self, ContactError> {
        let faces: Vec<u32> =
            faces.into_iter().filter(|&f| barycentric_2d(DVec2::ZERO, &uv_corners(mesh, &uvs, f)).is_some()).collect();
        if faces.is_empty() {
            return Ok(Self { uvs, faces, tree: None, scale: 1.0 });
        }
        let boxes: Vec<Aabb3> = faces
            .iter()
            .map(|&f| {
                let c = uv_corners(mesh, &uvs, f);
                Aabb3 { min: c[0].min(c[1]).min(c[2]).extend(0.0), max: c[0].max(c[1]).max(c[2]).extend(0.0) }
            })
            .collect();
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for b in &boxes {
            lo = lo.min(b.min);
            hi = hi.max(b.max);
        }
        let scale = (hi - lo).length().max(f64::MIN_POSITIVE);
        let tree = Some(AabbTree::new(&boxes)?);
        Ok(Self { uvs, faces, tree, scale })
    }

    /// The face and barycentric coordinates of `q`: the containing UV triangle (the most interior
    /// one, then the smallest face id), or the nearest one (`true`: a fallback).
    fn locate(&self, mesh: &TriMesh, q: DVec2) -> Option<(u32, [f64; 3], bool)> {
        let tree = self.tree.as_ref()?;
        let uvs = &self.uvs[..];
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
    /// The harmonic correction g per vertex of the mesh (0 away from ℐ and its one-ring).
    pub correction: Vec<DVec2>,
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
        let located = self.locator.locate(other.mesh, q);
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
    pub fn match_between(
        &self,
        mapping: &SideMapping,
        other: &ContactSide,
        from: Sample,
        to: Sample,
        t: f64,
    ) -> (Match, bool) {
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
fn boundary_sources(
    region: &EdgeRegion,
    l: usize,
    topology: &Topology,
    points: &[IntersectionPoint],
) -> Vec<Option<usize>> {
    // The points of this side's edges, sorted by (edge, position along it).
    let mut order: Vec<usize> = (0..points.len()).filter(|&k| points[k].edge_side as usize == l).collect();
    order.sort_by(|&x, &y| {
        points[x].edge.cmp(&points[y].edge).then(points[x].t.total_cmp(&points[y].t)).then(x.cmp(&y))
    });
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

/// The faces of side `l` the mapping reads UVs on: those touching ℐ_l or its one-ring, and those
/// holding an intersection point (a point on an edge of the other side lies on a face of this one).
fn layout_faces(side: &ContactSide, l: usize, region: &EdgeRegion, points: &[IntersectionPoint]) -> Vec<u32> {
    let mut faces = faces_near(side, region);
    faces.extend(points.iter().filter(|p| p.edge_side as usize != l).map(|p| p.face));
    faces.sort_unstable();
    faces.dedup();
    faces
}

/// Twice the signed area of a UV triangle.
fn uv_area(c: &[DVec2; 3]) -> f64 {
    (c[1] - c[0]).perp_dot(c[2] - c[0])
}

/// The 2D similarity taking `from` onto `to` (two points each), with a reflection when `mirror`;
/// `None` when `from`'s two points coincide.
fn similarity(from: [DVec2; 2], to: [DVec2; 2], mirror: bool) -> Option<UvAffine> {
    let (d_from, d_to) = (from[1] - from[0], to[1] - to[0]);
    let length = d_from.length_squared();
    if length == 0.0 || !length.is_finite() {
        return None;
    }
    // As complex numbers: to = z·from + t, or z·conj(from) + t with a reflection.
    let source = if mirror { DVec2::new(d_from.x, -d_from.y) } else { d_from };
    let z = DVec2::new(d_to.x * source.x + d_to.y * source.y, d_to.y * source.x - d_to.x * source.y) / length;
    let linear = if mirror {
        DMat2::from_cols(DVec2::new(z.x, z.y), DVec2::new(z.y, -z.x))
    } else {
        DMat2::from_cols(DVec2::new(z.x, z.y), DVec2::new(-z.y, z.x))
    };
    Some(UvAffine { linear, translation: to[0] - linear * from[0] })
}

/// One UV per vertex of `side` over `faces` (module docs, "Seams"): per-vertex UVs as they are;
/// per-corner UVs unfolded across their seams. Vertices of no face of `faces` get NaN.
pub(crate) fn unfold(side: &ContactSide, uvs: &Uvs, faces: &[u32]) -> Arc<[DVec2]> {
    let corners = match uvs {
        Uvs::PerVertex(values) => return Arc::from(values.as_slice()),
        Uvs::PerCorner(corners) => corners,
    };
    let (mesh, topology) = (side.mesh, side.topology);
    let mut layout = vec![DVec2::NAN; mesh.num_vertices()];
    let mut in_domain = vec![false; mesh.num_triangles()];
    for &f in faces {
        in_domain[f as usize] = true;
    }
    // Per face: not reached yet, or its chart's map into the layout (`None`: as it is).
    let mut placed: Vec<Option<Option<UvAffine>>> = vec![None; mesh.num_triangles()];
    let apply = |map: &Option<UvAffine>, q: DVec2| map.as_ref().map_or(q, |m| m.apply(q));
    let mut queue = VecDeque::new();
    for &seed in faces {
        if placed[seed as usize].is_some() {
            continue;
        }
        placed[seed as usize] = Some(None);
        queue.push_back(seed);
        while let Some(f) = queue.pop_front() {
            let map = placed[f as usize].unwrap_or_default();
            let tri = mesh.triangles[f as usize];
            let own = corners[f as usize];
            let here = own.map(|q| apply(&map, q));
            for k in 0..3 {
                if layout[tri[k] as usize].is_nan() {
                    layout[tri[k] as usize] = here[k];
                }
            }
            // Orientation of this face as placed: a neighbour across a seam is placed with the same.
            let placed_sign = uv_area(&here).signum();
            for (k, &e) in topology.face_edges(f).iter().enumerate() {
                for g in topology.edge_faces(e) {
                    if g == NO_FACE || g == f || !in_domain[g as usize] || placed[g as usize].is_some() {
                        continue;
                    }
                    let (i, j) = (tri[k], tri[(k + 1) % 3]);
                    let other_tri = mesh.triangles[g as usize];
                    let corner_of = |v: u32| other_tri.iter().position(|&w| w == v);
                    let (Some(ki), Some(kj)) = (corner_of(i), corner_of(j)) else { continue };
                    let theirs = corners[g as usize];
                    let same = |a: DVec2, b: DVec2| a.x.to_bits() == b.x.to_bits() && a.y.to_bits() == b.y.to_bits();
                    let map_g = if same(theirs[ki], own[k]) && same(theirs[kj], own[(k + 1) % 3]) {
                        map
                    } else {
                        let mirror = uv_area(&theirs).signum() * placed_sign < 0.0;
                        // A degenerate seam edge in UV space keeps the neighbour's map.
                        similarity([theirs[ki], theirs[kj]], [here[k], here[(k + 1) % 3]], mirror).or(map)
                    };
                    placed[g as usize] = Some(map_g);
                    queue.push_back(g);
                }
            }
        }
    }
    Arc::from(layout)
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
    let mut solver = ConstrainedSolver::new(&symbolic, &operator, &local, &ConstraintParams::default()).map_err(err)?;
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
    layouts: [&Arc<[DVec2]>; 2],
) -> Result<(SideMapping, MappingStats, SideParametrization), ContactError> {
    let (side, other) = (sides[l], sides[1 - l]);
    let (uvs, other_uvs) = (&layouts[l][..], &layouts[1 - l][..]);
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
    let locator = UvLocator::new(other.mesh, layouts[1 - l].clone(), faces_near(other, intersections[1 - l]))?;
    let mut param = SideParametrization {
        affine,
        fit,
        vertex_targets,
        point_targets,
        affine_residual,
        constrained_points: constraints.len(),
        location_fallbacks: 0,
        correction: g,
        locator,
    };
    let work = SharedWork::default();
    let located: Vec<(Match, bool)> =
        param.vertex_targets.par_iter().map(|&q| work.measure(|| param.locate(other, q))).collect();
    work.record();
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
    let work = SharedWork::default();
    let layout = |l: usize| {
        let side = sides[l];
        let uvs = side.uvs.ok_or_else(|| ContactError::MissingUvs { object: side.display_name() })?;
        Ok::<_, ContactError>(unfold(side, uvs, &layout_faces(side, l, intersections[l], points)))
    };
    let (layout_a, layout_b) = rayon::join(|| work.measure(|| layout(0)), || work.measure(|| layout(1)));
    let layouts = [&layout_a?, &layout_b?];
    let (a, b) = rayon::join(
        || work.measure(|| map_side_uv(0, sides, intersections, points, layouts)),
        || work.measure(|| map_side_uv(1, sides, intersections, points, layouts)),
    );
    work.record();
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

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::super::intersect::intersect;
    use super::super::test_support::{Owned, distance_to};
    use super::super::{PairContact, Stiffness, contact_pair};
    use super::*;
    use crate::mesh::shapes;
    use crate::params::{MappingMethod, PairParams};

    /// A working region with UVs: `uvs` per vertex, `map` as given to the contact (per vertex, or
    /// per corner with seams).
    struct WithUvs {
        owned: Owned,
        uvs: Vec<DVec2>,
        map: Uvs,
    }

    impl WithUvs {
        fn new(owned: Owned, uvs: Vec<DVec2>) -> Self {
            Self { owned, map: Uvs::PerVertex(uvs.clone()), uvs }
        }

        fn side(&self) -> ContactSide<'_> {
            self.owned.side().with_uvs(Some(&self.map))
        }

        /// The same UVs cut along the line x = `x0`: the faces right of it get theirs through
        /// `chart` (another chart of the texture), so every vertex on the line has two UVs.
        fn with_seam(mut self, x0: f64, chart: impl Fn(DVec2) -> DVec2) -> Self {
            let mesh = &self.owned.mesh;
            let corners = mesh
                .triangles
                .iter()
                .map(|t| {
                    let right = t.iter().map(|&v| mesh.positions[v as usize].x).sum::<f64>() / 3.0 > x0;
                    t.map(|v| if right { chart(self.uvs[v as usize]) } else { self.uvs[v as usize] })
                })
                .collect();
            self.map = Uvs::PerCorner(corners);
            assert!(self.map.has_seams(&mesh.triangles, mesh.num_vertices()));
            self
        }
    }

    const OFFSET: DVec2 = DVec2::new(0.013, -0.021);

    /// The analytic tip surface z = −0.3 + 1.2‖xy − offset‖².
    fn tip_height(x: f64, y: f64) -> f64 {
        let d = DVec2::new(x, y) - OFFSET;
        -0.3 + 1.2 * d.length_squared()
    }

    /// A rigid rounded tip pressing down: the paraboloid z = −0.3 + 1.2 r² as a grid whose faces
    /// look down (the solid is above it), with UVs `uv(x, y)`.
    fn tip(uv: impl Fn(DVec2) -> DVec2) -> WithUvs {
        let mut mesh = shapes::grid(2.4, 2.4, 60, 60);
        mesh.map_positions(|p| DVec3::new(p.x + OFFSET.x, p.y + OFFSET.y, tip_height(p.x + OFFSET.x, p.y + OFFSET.y)));
        for t in &mut mesh.triangles {
            t.swap(1, 2);
        }
        let uvs = mesh.positions.iter().map(|p| uv(p.truncate())).collect();
        WithUvs::new(Owned::new(mesh, DVec3::ZERO).with_stiffness(Stiffness::Rigid), uvs)
    }

    /// The elastic plane z = 0 with uv = (x, y).
    fn plane() -> WithUvs {
        let mesh = shapes::grid(2.4, 2.4, 60, 60);
        let uvs = mesh.positions.iter().map(|p| p.truncate()).collect();
        WithUvs::new(Owned::new(mesh, DVec3::ZERO), uvs)
    }

    fn shared(a: &WithUvs, b: &WithUvs) -> ([SideMapping; 2], MappingStats, SharedParametrization) {
        let inter = intersect(&a.side(), &b.side()).unwrap();
        assert!(inter.points.len() > 50);
        map_regions_uv([&a.side(), &b.side()], [&inter.regions[0], &inter.regions[1]], &inter.points).unwrap()
    }

    fn assert_close(x: DMat2, y: DMat2, tolerance: f64) {
        let d = (x - y).to_cols_array().iter().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(d <= tolerance, "{x} vs {y}");
    }

    #[test]
    fn affine_fit_recovers_a_known_map_and_degenerate_inputs_fall_back() {
        let linear = DMat2::from_cols(DVec2::new(1.3, -0.1), DVec2::new(0.2, 0.9));
        let translation = DVec2::new(0.5, -0.2);
        let pts = [DVec2::new(0.1, 0.2), DVec2::new(-0.4, 0.3), DVec2::new(0.7, -0.5), DVec2::new(0.2, 0.9)];
        let pairs: Vec<_> = pts.iter().map(|&p| (p, linear * p + translation)).collect();
        let (a, fit) = fit_affine(&pairs);
        assert_eq!(fit, AffineFit::Affine);
        assert_close(a.linear, linear, 1e-13);
        assert!((a.translation - translation).length() < 1e-13);
        // Collinear points: a similarity that maps them exactly when they are related by one.
        let rotation = DMat2::from_angle(0.4) * 1.5;
        let line: Vec<_> =
            (0..5).map(|k| DVec2::new(k as f64, 2.0 * k as f64)).map(|p| (p, rotation * p + translation)).collect();
        let (a, fit) = fit_affine(&line);
        assert_eq!(fit, AffineFit::Similarity);
        assert_close(a.linear, rotation, 1e-12);
        let (a, fit) = fit_affine(&[(DVec2::ONE, DVec2::new(3.0, 4.0))]);
        assert_eq!(fit, AffineFit::Translation);
        assert!((a.apply(DVec2::ONE) - DVec2::new(3.0, 4.0)).length() < 1e-15);
        assert_eq!(fit_affine(&[]).1, AffineFit::Translation);
    }

    /// Plane (uv = xy) against a rounded tip whose UVs are an affine image of xy: the affine fit
    /// recovers that map exactly, the residuals vanish, every match lies on the other mesh, and the
    /// mapping is the vertical projection (uv = xy on the plane).
    #[test]
    fn an_affine_uv_relation_is_recovered_exactly() {
        let linear = DMat2::from_cols(DVec2::new(1.3, -0.1), DVec2::new(0.2, 0.9));
        let translation = DVec2::new(0.5, -0.2);
        let (tip, plane) = (tip(|q| linear * q + translation), plane());
        let (mappings, stats, param) = shared(&tip, &plane);
        assert_eq!(stats.closest_point_matches, 0, "every target is inside a UV triangle");
        let on_plane = &param.sides[1];
        assert_eq!(on_plane.fit, AffineFit::Affine);
        assert_close(on_plane.affine.linear, linear, 1e-12);
        assert!((on_plane.affine.translation - translation).length() < 1e-12);
        let on_tip = &param.sides[0];
        assert_close(on_tip.affine.linear, linear.inverse(), 1e-12);
        println!(
            "affine residuals: plane → tip {:.1e}, tip → plane {:.1e}; constrained boundary points {} and {}",
            on_plane.affine_residual, on_tip.affine_residual, on_plane.constrained_points, on_tip.constrained_points
        );
        assert!(on_plane.affine_residual < 1e-12 && on_tip.affine_residual < 1e-12);
        for (l, (side, other)) in [(&tip, &plane), (&plane, &tip)].into_iter().enumerate() {
            let mapping = &mappings[l];
            assert!(mapping.vertices.len() > 100);
            for (&v, m) in mapping.vertices.iter().zip(&mapping.vertex_matches) {
                let p = side.owned.mesh.positions[v as usize];
                assert_eq!(m.kind, MatchKind::Parametric);
                assert!(distance_to(&other.owned, m.point) < 1e-12, "match off the other mesh");
                assert!(
                    (m.point.truncate() - p.truncate()).length() < 1e-10,
                    "not a vertical projection: {p} → {}",
                    m.point
                );
            }
            for m in &mapping.point_matches {
                assert!(distance_to(&other.owned, m.point) < 1e-12);
            }
        }
    }

    /// Another chart of a texture: rotated, scaled and moved, and mirrored when `mirror`.
    fn chart(mirror: bool) -> impl Fn(DVec2) -> DVec2 {
        move |q: DVec2| {
            let q = if mirror { DVec2::new(-q.x, q.y) } else { q };
            DMat2::from_angle(0.7) * q * 1.7 + DVec2::new(3.0, -1.0)
        }
    }

    /// Per-corner UVs cut along a line (a seam, the two halves in different charts, mirrored or
    /// not) unfold into one layout that is a similarity image of the uncut one: the charts meet
    /// as the surface does.
    #[test]
    fn unfolding_joins_the_charts_of_a_seam() {
        for mirror in [false, true] {
            let plane = plane().with_seam(0.0, chart(mirror));
            let side = plane.side();
            let faces: Vec<u32> = (0..plane.owned.mesh.num_triangles() as u32).collect();
            let layout = unfold(&side, &plane.map, &faces);
            let pairs: Vec<(DVec2, DVec2)> = plane.uvs.iter().copied().zip(layout.iter().copied()).collect();
            let (map, fit) = fit_affine(&pairs);
            let residual = pairs.iter().map(|&(a, b)| (b - map.apply(a)).length()).fold(0.0, f64::max);
            let m = map.linear;
            println!("seam (mirrored: {mirror}): unfolded layout = similarity of the uncut UVs to {residual:.1e}");
            assert_eq!(fit, AffineFit::Affine);
            assert!(residual < 1e-12, "the charts do not meet: {residual}");
            // A similarity: equal columns' lengths, orthogonal columns.
            assert!((m.x_axis.length() - m.y_axis.length()).abs() < 1e-12 && m.x_axis.dot(m.y_axis).abs() < 1e-12);
        }
        // Without seams the layout is the UVs, bit for bit.
        let plane = plane();
        let corners =
            Uvs::PerCorner(plane.owned.mesh.triangles.iter().map(|t| t.map(|v| plane.uvs[v as usize])).collect());
        let faces: Vec<u32> = (0..plane.owned.mesh.num_triangles() as u32).collect();
        let layout = unfold(&plane.side(), &corners, &faces);
        assert!(
            layout
                .iter()
                .zip(&plane.uvs)
                .all(|(a, b)| a.x.to_bits() == b.x.to_bits() && a.y.to_bits() == b.y.to_bits())
        );
    }

    /// A seam through the contact (on either mesh, its charts mirrored or not) gives the mapping
    /// of the same UVs without the seam; picking one of a seam vertex's UVs instead (no unfolding)
    /// does not.
    #[test]
    fn a_seam_through_the_contact_maps_as_without_it() {
        let linear = DMat2::from_cols(DVec2::new(1.3, -0.1), DVec2::new(0.2, 0.9));
        let translation = DVec2::new(0.5, -0.2);
        let relation = move |q: DVec2| linear * q + translation;
        let (tip_plain, plane_plain) = (tip(relation), plane());
        let (reference, ..) = shared(&tip_plain, &plane_plain);
        for mirror in [false, true] {
            for (tip_seam, plane_seam) in [(false, true), (true, false), (true, true)] {
                let t = if tip_seam { tip(relation).with_seam(0.02, chart(mirror)) } else { tip(relation) };
                let p = if plane_seam { plane().with_seam(0.0, chart(!mirror)) } else { plane() };
                let (mappings, stats, _) = shared(&t, &p);
                assert_eq!(stats.closest_point_matches, 0, "every target lies in a UV triangle");
                let mut worst = 0.0f64;
                for (m, r) in mappings.iter().zip(&reference) {
                    assert_eq!(m.vertices, r.vertices);
                    for (a, b) in m
                        .vertex_matches
                        .iter()
                        .zip(&r.vertex_matches)
                        .chain(m.point_matches.iter().zip(&r.point_matches))
                    {
                        worst = worst.max((a.point - b.point).length());
                    }
                }
                println!(
                    "seam on the tip {tip_seam}, on the plane {plane_seam}, mirrored {mirror}: largest difference of a match {worst:.1e}"
                );
                assert!(worst < 1e-9, "{worst}");
            }
        }
        // One UV per vertex taken from its first corner: the faces across the seam span both
        // charts, and the matches land far from the vertical projection.
        let seam = plane().with_seam(0.0, chart(false));
        let Uvs::PerCorner(corners) = &seam.map else { unreachable!() };
        let mut first = vec![DVec2::NAN; seam.uvs.len()];
        for (t, c) in seam.owned.mesh.triangles.iter().zip(corners) {
            for k in 0..3 {
                if first[t[k] as usize].is_nan() {
                    first[t[k] as usize] = c[k];
                }
            }
        }
        let naive = WithUvs::new(Owned::new(seam.owned.mesh.clone(), DVec3::ZERO), first);
        let (mappings, ..) = shared(&tip_plain, &naive);
        let worst = mappings[1]
            .vertices
            .iter()
            .zip(&mappings[1].vertex_matches)
            .map(|(&v, m)| (m.point.truncate() - naive.owned.mesh.positions[v as usize].truncate()).length())
            .fold(0.0, f64::max);
        println!("one UV per seam vertex instead: a match {worst:.3} away from the vertical projection");
        assert!(worst > 0.05, "{worst}");
    }

    /// A tilted plane (uv = its own in-plane coordinates) against the tip (uv = world xy): the uv
    /// relation is the linear map diag(cos β, 1), so the mapping is the vertical projection onto
    /// the tip, i.e. onto the analytic paraboloid up to the chord error of its mesh.
    #[test]
    fn a_tilted_plane_maps_onto_the_tip_to_chord_error() {
        let beta: f64 = 0.3;
        let (tip, mut plane) = (tip(|q| q), plane());
        // Rotation about y: (x′, y′, 0) ↦ (x′ cos β, y′, −x′ sin β); the UVs stay (x′, y′).
        plane.owned = Owned::new(
            {
                let mut mesh = plane.owned.mesh.clone();
                mesh.map_positions(|p| DVec3::new(p.x * beta.cos(), p.y, -p.x * beta.sin()));
                mesh
            },
            DVec3::ZERO,
        );
        let (mappings, _, param) = shared(&tip, &plane);
        let on_plane = &param.sides[1];
        assert_close(on_plane.affine.linear, DMat2::from_diagonal(DVec2::new(beta.cos(), 1.0)), 1e-12);
        assert!(on_plane.affine.translation.length() < 1e-12);
        let h = 2.4 / 60.0;
        // Linear interpolation of a quadratic with Hessian 2.4·I over right triangles of legs h
        // errs by at most 2.4·(√2 h)²/8 = 0.6 h², from above (the paraboloid is convex).
        let chord = 0.6 * h * h;
        let mut worst = 0.0f64;
        for (&v, m) in mappings[1].vertices.iter().zip(&mappings[1].vertex_matches) {
            let p = plane.owned.mesh.positions[v as usize];
            assert!((m.point.truncate() - p.truncate()).length() < 1e-10);
            let error = m.point.z - tip_height(p.x, p.y);
            assert!(error >= -1e-12 && error <= chord + 1e-12, "vertex {v}: {error} vs chord error {chord}");
            worst = worst.max(error);
        }
        println!(
            "tilted plane → tip: {} vertices, largest distance to the analytic paraboloid {worst:.2e} (chord bound {chord:.2e})",
            mappings[1].vertices.len()
        );
    }

    /// UVs related by a non-affine map: the affine part leaves residuals e_k at the intersection
    /// points; the harmonic correction g, interpolated at ℐ's boundary points, cancels them (up to
    /// the least-squares slack), and every match still lies on the other mesh.
    #[test]
    fn a_curved_uv_relation_is_corrected_at_the_intersection_boundary() {
        let (tip, plane) = (tip(|q| DVec2::new(q.x + 0.4 * q.y * q.y, q.y - 0.2 * q.x * q.x)), plane());
        let inter = intersect(&tip.side(), &plane.side()).unwrap();
        let (mappings, stats, param) =
            map_regions_uv([&tip.side(), &plane.side()], [&inter.regions[0], &inter.regions[1]], &inter.points)
                .unwrap();
        let (mapping, on_plane) = (&mappings[1], &param.sides[1]);
        let sources = boundary_sources(&mapping.region, 1, &plane.owned.topology, &inter.points);
        let (mut before, mut after) = (0.0f64, 0.0f64);
        for ((bp, source), target) in mapping.region.points().iter().zip(&sources).zip(&on_plane.point_targets) {
            let Some(_) = source else { continue };
            let q = plane.uvs[bp.inside as usize].lerp(plane.uvs[bp.outside as usize], bp.alpha);
            let g = on_plane.correction[bp.inside as usize].lerp(on_plane.correction[bp.outside as usize], bp.alpha);
            before = before.max((on_plane.affine.apply(q) - *target).length());
            after = after.max((on_plane.affine.apply(q) + g - *target).length());
        }
        println!(
            "curved uv relation: max |e_k| at ℐ's boundary {before:.3e} → {after:.3e} after the harmonic correction ({} constrained points, {} fallbacks)",
            on_plane.constrained_points, stats.closest_point_matches
        );
        assert!(before > 1e-3, "the relation is not affine: {before}");
        assert!(after < 0.1 * before, "the correction must cancel the residuals: {after} vs {before}");
        for m in &mapping.vertex_matches {
            assert!(distance_to(&tip.owned, m.point) < 1e-12);
        }
    }

    fn run(a: &WithUvs, b: &WithUvs, params: &PairParams) -> PairContact {
        // The thesis' 𝒮 is checked here: the contact gap (tested with the pipeline, in
        // tests/pipeline/gap.rs) is 0 unless a test asks for one.
        let params = PairParams { contact_gap: params.contact_gap.or(Some(0.0)), ..*params };
        contact_pair(&a.side(), &b.side(), &params).unwrap()
    }

    /// The whole contact definition with the shared parametrization: with the geometric criterion
    /// and with ball testing, ℳ = ℐ, zone targets on the tip, and bit-identical repeated runs.
    #[test]
    fn contact_with_the_shared_parametrization_is_consistent_and_deterministic() {
        let (tip, plane) = (tip(|q| DVec2::new(2.0 * q.x + 0.1, 2.0 * q.y)), plane());
        let shared = PairParams::default().with_mapping(MappingMethod::SharedParametrization);
        for params in [shared, shared.with_ball(0.3)] {
            let first = run(&tip, &plane, &params);
            let zone = &first.sides[1].zone;
            assert!(!zone.is_empty(), "{params:?}");
            assert_eq!(first.sides[1].mapping.region, first.sides[1].intersection, "ℳ = ℐ");
            for (v, t) in zone.targets.iter().enumerate() {
                if zone.region.contains(v as u32) {
                    assert!((t.z - tip_height(t.x, t.y)).abs() < 2e-3, "{t}");
                }
            }
            for t in &zone.boundary_targets {
                assert!(distance_to(&tip.owned, *t) < 1e-12, "{t}");
            }
            let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
            for again in [run(&tip, &plane, &params), single.install(|| run(&tip, &plane, &params))] {
                let z = &again.sides[1].zone;
                assert_eq!(z.region, zone.region);
                assert_eq!(z.targets, zone.targets);
                assert_eq!(z.boundary_targets, zone.boundary_targets);
                assert_eq!(z.boundary_normals, zone.boundary_normals);
                assert_eq!(again.sides[1].mapping, first.sides[1].mapping);
            }
            println!(
                "{:?}: zone {} vertices, area on 𝒮 {:.4}",
                params.contact_method,
                zone.region.num_inside(),
                first.contact_area
            );
        }
    }

    #[test]
    fn the_shared_parametrization_needs_uvs() {
        let (tip, plane) = (tip(|q| q), plane());
        let params = PairParams::default().with_mapping(MappingMethod::SharedParametrization);
        let err = contact_pair(&tip.side().with_name("finger"), &plane.owned.side().with_name("ground"), &params)
            .unwrap_err();
        assert!(matches!(&err, ContactError::MissingUvs { object } if object == "ground"), "{err}");
        assert!(err.to_string().contains("UVs"), "{err}");
        // UVs of the wrong length are an input mismatch.
        let short = Uvs::PerVertex(plane.uvs[..10].to_vec());
        let err = contact_pair(&tip.side(), &plane.owned.side().with_uvs(Some(&short)), &params).unwrap_err();
        assert!(matches!(err, ContactError::InputMismatch { what: "the UVs", .. }), "{err}");
    }
}
