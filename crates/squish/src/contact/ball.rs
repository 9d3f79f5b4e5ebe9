//! Contact zones by ball testing and ball sliding (thesis §4.4.1, method A; algorithm box of §4.5,
//! "Contact zone extraction ▷ §4.1"). Replaces the geometric criterion of [`super::zone`] when
//! [`ContactMethod::Ball`](super::ContactMethod::Ball) is chosen; the output is the same
//! [`ContactZone`], so the deformation stage is unchanged.
//!
//! **Scope.** Rigid–elastic pairs only (§4.4.1: "limited to the asymmetric case"): the potential
//! contact surface 𝒮 is the rigid surface, p′_i = p″_i (the match of §4.2) and the normal of 𝒮 is
//! the rigid surface's normal at the match. Two elastic objects are
//! [`ContactError::BallTestingNeedsOneRigid`]. The rigid side gets an empty zone (it does not
//! deform).
//!
//! **The projected surface.** Every vertex of the elastic working region enters a
//! point tree at its *projected* position P′: its match p″ on the rigid surface if it is a
//! candidate, its own position otherwise. Candidates are the vertices of ℳ ∩ ℐ (mapped and inside
//! the rigid object). Decision: vertices of ℳ outside ℐ have a gap to the rigid surface; they keep
//! their position in the tree (they are part of the elastic surface the ball rolls against, not of
//! the part pushed onto 𝒮), and they cannot enter 𝒞, which keeps the zone inside the intersection
//! as §4.4.1 requires. A vertex enters ℐ where it crosses the rigid surface, i.e. where p″ = p,
//! so the switch from p to p″ is continuous.
//!
//! **Ball test.** The projected points are held in a box tree (the point tree of §4.4.1) whose
//! ball queries stop at the first blocker. For a candidate i, m_i = −n′_i is the rigid normal at its match, oriented into the
//! elastic object; the ball has centre c_i = p′_i + r_s m_i. The hyperplane of normal m_i through
//! l_i = p′_i + λ_i m_i, with λ_i = max(0, max_{w ∈ ring(i) ∪ {i}} (P′_w − p′_i)·m_i) the smallest
//! non-negative offset that puts the one-ring on its rejection side (Fig. 4.8b), excludes every
//! point with (P′ − l_i)·m_i ≤ 0. i ∈ 𝒞 iff no other tree point is strictly inside the ball and
//! strictly in front of the hyperplane. Larger r_s → smaller zones (Fig. 4.10).
//!
//! **Ball sliding.** On every edge from i ∈ 𝒞 to j ∉ 𝒞 the ball centre, the hyperplane normal and
//! its reference point are interpolated linearly from i's to the far end's: j's own when j ∈ ℳ
//! (end at α = 1), otherwise the boundary point of ℳ on the edge (end at its α_ℳ, with λ_i kept).
//! α_ij is the smallest α at which some tree point P′ (other than i and j, whose exclusion is the
//! one-ring exclusion at both ends) satisfies ‖P′ − c(α)‖² < ρ(α)² and (P′ − l(α))·m(α) > 0; both
//! are quadratics in α, so the first α is found exactly from their roots (the blocking set is a
//! union of intervals between roots; the first interval whose midpoint blocks starts at α_ij).
//!
//! **Sag compensation (decision).** The thesis slides a ball of constant radius r_s along the
//! straight segment between the end centres. Over a convex rigid surface that segment cuts inside
//! the offset surface the centres come from, by about (R + r_s)φ²/8 mid-edge (R the surface's
//! radius of curvature, φ the angle between the end normals): the ball sinks into the rigid
//! surface and pokes out of the elastic one, so it is blocked in the middle of an edge whose ends
//! are free (the thesis notes these "false detections", Fig. 4.9). Such interior blocks cannot be
//! represented by one boundary point per edge: when the far vertex becomes free the boundary jumps
//! from mid-edge to the next edge (measured: area jumps of ~4× the smooth rate at r_s = 2, see the
//! continuity test). We keep the linear centre c(α) but give the ball the radius ρ(α) that keeps it
//! tangent to the rigid surface interpolated between the end points p′ with the end normals m,
//! to second order in the edge length: the plane through lerp(p′) with normal m(α)/‖m(α)‖ is at
//! distance r_s‖m(α)‖ from c(α), and the interpolated surface lies above that chord by
//! α(1 − α)(Δp′·Δm)/2, so ρ² = r_s²‖m(α)‖² − r_s α(1 − α)(Δp′·Δm) — still a quadratic in α (exact
//! roots), equal to r_s² at both ends (the vertex tests are unchanged), smaller over convex
//! and larger over concave rigid surfaces. [`BallSetup::compensate_sag`] = `false` restores the
//! thesis' constant radius.
//! Candidates are the tree points within the ball that bounds both end balls (the smallest ball
//! holding the axis-aligned box of §4.4.1 is not needed: this one is smaller and as conservative).
//! α is then clamped to the limit of ℳ ∩ ℐ on the edge ("we clamp α as required to ensure that the
//! contact zone stays within the intersection"). If nothing blocks, α is that limit.
//!
//! **Exact boundary points.** A point at α = 0 or at the far end reuses that sample as is; any
//! other point is recomputed like the geometric criterion does: p(α) on the edge is matched on
//! the rigid mesh (the farthest hit along the mapping direction, or, with the shared
//! parametrization, the location of its interpolated UV target), p′_ij = p″ and n′_ij from §4.3.
//! Zones may have several components that split and merge as the geometry moves.
//!
//! **Which criterion when.** Ball testing needs one rigid object and a ball that fits inside the
//! elastic one (r_s below its local thickness); it is local — each contact of a palm on a cushion
//! is judged on its own geometry (§4.4.2 discussion) — fills saddle-like fits and concavities
//! without transferring the discontinuities of 𝒮 to 𝒞, and its knob is a length that reads as a
//! stiffness. The geometric criterion (default) handles elastic–elastic pairs symmetrically, its
//! τ is scale-free, and it is cheaper, but ε_c is one threshold for the whole pair. Use ball
//! testing for rigid tools and props pressing soft objects, especially with several separate
//! contacts or curved fits; the geometric criterion otherwise.
//!
//! **Cost.** One radius query per candidate (stopping at the first blocker) and one per sliding
//! edge, in parallel (rayon); no allocation inside the queries. The thesis reports ball testing/sliding as method A's bottleneck
//! (ch. 7 §5.1); here it is about as cheap as the ray casts of the mapping (see the timing test).

use glam::DVec3;
use rayon::prelude::*;

use super::mapping::{Match, NO_SLOT, SideMapping, cast_matches};
use super::surface::{SideSurface, SurfaceSample, surface_sample};
use super::uv_mapping::{SharedParametrization, SideParametrization};
use super::zone::ZoneResult;
use super::{ContactError, ContactSide, ContactZone, EdgeRegion, Sample};
use crate::mesh::Aabb3;
use crate::spatial::{AabbTree, Visit};
use crate::stage::{SharedWork, Work};

/// A box tree over points with an early-exit ball query (a [`crate::spatial::PointTree`] cannot
/// stop its traversal, and a blocked ball can stop at its first blocker).
struct Points<'a> {
    tree: AabbTree,
    points: &'a [DVec3],
}

impl<'a> Points<'a> {
    fn new(points: &'a [DVec3]) -> Result<Self, ContactError> {
        let boxes: Vec<Aabb3> = points.iter().map(|&p| Aabb3 { min: p, max: p }).collect();
        Ok(Self { tree: AabbTree::new(&boxes)?, points })
    }

    /// Calls `f(index, point)` for every point with `|p − centre| ≤ radius` until `f` returns true.
    fn visit(&self, centre: DVec3, radius: f64, mut f: impl FnMut(u32, DVec3) -> bool) {
        Work::count_queries(1);
        let r2 = radius * radius;
        self.tree.traverse(|node| {
            let gap = (node.min - centre).max(centre - node.max).max(DVec3::ZERO);
            if gap.length_squared() > r2 || gap.is_nan() {
                return Visit::Prune;
            }
            if let Some(leaf) = node.item() {
                let p = self.points[leaf as usize];
                if (p - centre).length_squared() <= r2 && f(leaf, p) {
                    return Visit::Stop;
                }
            }
            Visit::Continue
        });
    }
}

/// Which side of a pair is the elastic one for ball testing (exactly one side must be rigid).
pub(crate) fn elastic_side(a: &ContactSide, b: &ContactSide) -> Result<usize, ContactError> {
    match (a.stiffness.is_rigid(), b.stiffness.is_rigid()) {
        (true, false) => Ok(1),
        (false, true) => Ok(0),
        (true, true) => Err(ContactError::BothRigid),
        (false, false) => Err(ContactError::BallTestingNeedsOneRigid),
    }
}

/// Per-side constants of ball testing.
#[derive(Clone, Copy, Debug)]
pub struct BallSetup<'a> {
    /// r_s, world units.
    pub radius: f64,
    /// The elastic side's direction toward the rigid object: +d̂ for a, −d̂ for b.
    pub toward: DVec3,
    /// d̂.
    pub mapping_direction: DVec3,
    /// With the shared-parametrization mapping: the elastic side's UV targets, used to recompute
    /// the boundary points (`None`: cast along `toward`).
    pub parametrization: Option<&'a SideParametrization>,
    /// Compensate the sag of the linearly interpolated ball centres (module docs). `true` in the
    /// pipeline; `false` is the thesis' formula as printed.
    pub compensate_sag: bool,
}

/// What ball testing did, for reports and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct BallStats {
    /// Vertices of ℳ ∩ ℐ tested with a ball.
    pub candidates: usize,
    /// Of those, the ones in 𝒞.
    pub in_zone: usize,
    /// Edges leaving 𝒞 on which the ball slid.
    pub slid_edges: usize,
    /// Of those, the edges where no point blocked the ball before the limit of ℳ ∩ ℐ (the zone
    /// was clamped to the intersection).
    pub clamped: usize,
}

/// A ball-tested zone with its figures.
#[derive(Clone, Debug)]
pub struct BallZone {
    pub result: ZoneResult,
    pub stats: BallStats,
}

/// The far end of a sliding edge: j's sample (at α = 1) or ℳ's boundary point on the edge.
#[derive(Clone, Copy, Debug)]
enum End {
    Vertex { slot: usize },
    Point { index: u32, alpha: f64 },
}

/// Ball data of one end: point on 𝒮, centre, hyperplane normal and reference point.
#[derive(Clone, Copy, Debug)]
struct BallEnd {
    target: DVec3,
    centre: DVec3,
    normal: DVec3,
    reference: DVec3,
}

/// A ball sliding on an edge: its start, its change to the far end, and ρ(τ)² = r² + lin·τ +
/// quad·τ² (module docs: the sag compensation).
#[derive(Clone, Copy, Debug)]
struct Sliding {
    start: BallEnd,
    delta: BallEnd,
    r2: f64,
    lin: f64,
    quad: f64,
}

impl Sliding {
    fn new(start: BallEnd, finish: BallEnd, r: f64, compensate: bool) -> Self {
        let delta = BallEnd {
            target: finish.target - start.target,
            centre: finish.centre - start.centre,
            normal: finish.normal - start.normal,
            reference: finish.reference - start.reference,
        };
        let (lin, quad) = if compensate {
            let k = delta.target.dot(delta.normal);
            (2.0 * r * r * start.normal.dot(delta.normal) - r * k, r * r * delta.normal.length_squared() + r * k)
        } else {
            (0.0, 0.0)
        };
        Self { start, delta, r2: r * r, lin, quad }
    }

    /// An upper bound of ρ(τ) on [0, 1].
    fn max_radius(&self) -> f64 {
        let k = self.delta.target.dot(self.delta.normal).abs();
        if self.lin == 0.0 && self.quad == 0.0 { self.r2.sqrt() } else { (self.r2 + 0.25 * self.r2.sqrt() * k).sqrt() }
    }
}

/// The result of sliding on one edge.
#[derive(Clone, Copy, Debug)]
struct Slide {
    edge: u32,
    inside: u32,
    end: Option<End>,
    alpha: f64,
    clamped: bool,
}

/// Roots of a·t² + b·t + c in the open interval (0, hi), appended to `out` (at most two).
fn push_roots(a: f64, b: f64, c: f64, hi: f64, out: &mut [f64; 6], len: &mut usize) {
    let mut push = |t: f64| {
        if t.is_finite() && t > 0.0 && t < hi && *len < out.len() {
            out[*len] = t;
            *len += 1;
        }
    };
    if a == 0.0 {
        if b != 0.0 {
            push(-c / b);
        }
        return;
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return;
    }
    let q = -0.5 * (b + disc.sqrt().copysign(b));
    if q != 0.0 {
        push(q / a);
        push(c / q);
    } else {
        push(0.0);
    }
}

/// The smallest τ in [0, τ_max] at which `p` blocks the sliding ball (inside the ball and in
/// front of the hyperplane), if any (τ ∈ [0, 1] from the start to the far end).
fn first_block(p: DVec3, sliding: &Sliding, tau_max: f64) -> Option<f64> {
    let (start, delta) = (&sliding.start, &sliding.delta);
    // q1(τ) = ‖p − c(τ)‖² − ρ(τ)²; reject at once if its minimum on the range is ≥ 0.
    let d = p - start.centre;
    let (a1, b1, c1) = (
        delta.centre.length_squared() - sliding.quad,
        -2.0 * d.dot(delta.centre) - sliding.lin,
        d.length_squared() - sliding.r2,
    );
    let q1 = |t: f64| (a1 * t + b1) * t + c1;
    let vertex = if a1 > 0.0 { (-b1 / (2.0 * a1)).clamp(0.0, tau_max) } else { 0.0 };
    if q1(vertex) >= 0.0 && q1(0.0) >= 0.0 && q1(tau_max) >= 0.0 {
        return None;
    }
    // q2(τ) = (p − l(τ))·m(τ), l and m linear.
    let e = p - start.reference;
    let (a2, b2, c2) = (
        -delta.reference.dot(delta.normal),
        e.dot(delta.normal) - delta.reference.dot(start.normal),
        e.dot(start.normal),
    );
    let q2 = |t: f64| (a2 * t + b2) * t + c2;
    let blocks = |t: f64| q1(t) < 0.0 && q2(t) > 0.0;
    let mut breaks = [0.0; 6];
    let mut len = 0;
    push_roots(a1, b1, c1, tau_max, &mut breaks, &mut len);
    push_roots(a2, b2, c2, tau_max, &mut breaks, &mut len);
    breaks[len] = tau_max;
    len += 1;
    let breaks = &mut breaks[..len];
    breaks.sort_unstable_by(f64::total_cmp);
    // The blocking set is a union of intervals between consecutive breakpoints: the first
    // interval whose interior blocks starts at the answer.
    let mut lo = 0.0;
    for &hi in breaks.iter() {
        if hi > lo && blocks(0.5 * (lo + hi)) {
            return Some(lo);
        }
        lo = hi;
    }
    (tau_max == 0.0 && blocks(0.0)).then_some(0.0)
}

/// Ball-tested contact zone of the elastic `side` against the rigid `other` (module docs).
/// `mapping` and `surface` are the elastic side's (ℳ, matches, and 𝒮 with k̄ = 0 on this side),
/// `intersection` its ℐ.
pub fn ball_zone(
    side: &ContactSide,
    other: &ContactSide,
    mapping: &SideMapping,
    surface: &SideSurface,
    intersection: &EdgeRegion,
    setup: &BallSetup,
) -> Result<BallZone, ContactError> {
    let r = setup.radius;
    if !(r.is_finite() && r > 0.0) {
        return Err(ContactError::from(crate::params::ParamError::new(
            "ball_radius",
            Some(crate::params::number(r)),
            "the ball radius r_s is a finite positive length in scene units",
        )));
    }
    let r2 = r * r;
    let (mesh, topology) = (side.mesh, side.topology);
    let nv = mesh.num_vertices();
    let samples = &surface.vertex_samples;
    let candidates = mapping.region.intersection(intersection, topology);
    let slot_of = |v: u32| -> Option<usize> {
        let s = mapping.vertex_slot[v as usize];
        (s != NO_SLOT).then_some(s as usize)
    };

    // The projected surface and, per vertex of ℳ, its ball normal and hyperplane offset λ.
    let mut projected = mesh.positions.clone();
    for (&v, s) in mapping.vertices.iter().zip(samples) {
        if candidates.contains(v) {
            projected[v as usize] = s.target;
        }
    }
    let inward: Vec<DVec3> = samples.iter().map(|s| -s.surface_normal).collect();
    let lambdas: Vec<f64> = mapping
        .vertices
        .par_iter()
        .zip(samples.par_iter().zip(&inward))
        .map(|(&v, (s, &m))| {
            let mut lambda = (projected[v as usize] - s.target).dot(m).max(0.0);
            for w in topology.vertex_neighbors(v) {
                lambda = lambda.max((projected[w as usize] - s.target).dot(m));
            }
            lambda
        })
        .collect();
    let ball_of = |target: DVec3, normal: DVec3, lambda: f64| BallEnd {
        target,
        centre: target + r * normal,
        normal,
        reference: target + lambda * normal,
    };
    let tree = Points::new(&projected)?;

    // Ball testing.
    let tested: Vec<u32> = mapping.vertices.iter().copied().filter(|&v| candidates.contains(v)).collect();
    let work = SharedWork::default();
    let free: Vec<bool> = tested
        .par_iter()
        .map(|&i| {
            work.measure(|| {
                let Some(k) = slot_of(i) else { return false };
                let ball = ball_of(samples[k].target, inward[k], lambdas[k]);
                let mut blocked = false;
                tree.visit(ball.centre, r, |w, p| {
                    blocked = w != i
                        && (p - ball.centre).length_squared() < r2
                        && (p - ball.reference).dot(ball.normal) > 0.0;
                    blocked
                });
                !blocked
            })
        })
        .collect();
    let mut inside = vec![false; nv];
    for (&v, &f) in tested.iter().zip(&free) {
        inside[v as usize] = f;
    }

    // Ball sliding on the edges leaving 𝒞, in increasing edge id (the order of the zone's points).
    let leaving: Vec<(u32, u32, u32)> = topology
        .edges()
        .iter()
        .enumerate()
        .filter(|(_, [x, y])| inside[*x as usize] != inside[*y as usize])
        .map(|(e, &[x, y])| if inside[x as usize] { (e as u32, x, y) } else { (e as u32, y, x) })
        .collect();
    let slides: Vec<Slide> = leaving
        .par_iter()
        .map(|&(e, i, j)| {
            work.measure(|| {
                let unreachable = Slide { edge: e, inside: i, end: None, alpha: 0.0, clamped: false };
                let Some(ki) = slot_of(i) else { return unreachable };
                // Limit of ℳ ∩ ℐ on the edge, from i.
                let limit = if candidates.contains(j) {
                    1.0
                } else {
                    candidates.point_on_edge(e).map_or(0.0, |p| candidates.points()[p as usize].alpha)
                };
                let end = match slot_of(j) {
                    Some(kj) => Some(End::Vertex { slot: kj }),
                    None => mapping.region.point_on_edge(e).and_then(|p| {
                        let point = mapping.region.points()[p as usize];
                        (point.inside == i).then_some(End::Point { index: p, alpha: point.alpha })
                    }),
                };
                let Some(end) = end else { return unreachable };
                let (end_sample, end_normal, end_lambda, span) = match end {
                    End::Vertex { slot } => (&samples[slot], inward[slot], lambdas[slot], 1.0),
                    End::Point { index, alpha } => {
                        let Some(s) = surface.point_samples.get(index as usize) else { return unreachable };
                        (s, -s.surface_normal, lambdas[ki], alpha)
                    }
                };
                if span <= 0.0 {
                    return Slide { end: Some(end), ..unreachable };
                }
                let tau_max = (limit / span).clamp(0.0, 1.0);
                let start = ball_of(samples[ki].target, inward[ki], lambdas[ki]);
                let finish = ball_of(end_sample.target, end_normal, end_lambda);
                let sliding = Sliding::new(start, finish, r, setup.compensate_sag);
                let half = 0.5 * tau_max * sliding.delta.centre.length();
                let mut first: Option<f64> = None;
                let centre = start.centre + 0.5 * tau_max * sliding.delta.centre;
                tree.visit(centre, sliding.max_radius() + half, |w, p| {
                    if w != i
                        && w != j
                        && let Some(t) = first_block(p, &sliding, first.unwrap_or(tau_max))
                        && first.is_none_or(|f| t < f)
                    {
                        first = Some(t);
                    }
                    first == Some(0.0)
                });
                let tau = first.unwrap_or(tau_max).min(tau_max);
                Slide { edge: e, inside: i, end: Some(end), alpha: tau * span, clamped: first.is_none() }
            })
        })
        .collect();
    work.record();
    let stats = BallStats {
        candidates: tested.len(),
        in_zone: free.iter().filter(|&&f| f).count(),
        slid_edges: slides.len(),
        clamped: slides.iter().filter(|s| s.clamped).count(),
    };

    let region = EdgeRegion::from_inside(topology, inside, |e, _, _| {
        slides.binary_search_by_key(&e, |s| s.edge).map_or(0.0, |k| slides[k].alpha)
    });
    debug_assert_eq!(region.points().len(), slides.len());

    // Exact boundary points: reuse the end samples, recompute the others.
    let mut boundary: Vec<SurfaceSample> = Vec::with_capacity(slides.len());
    let mut recompute: Vec<usize> = Vec::new();
    for (k, s) in slides.iter().enumerate() {
        let alpha = region.points()[k].alpha;
        let reuse = match (s.end, slot_of(s.inside)) {
            (_, Some(ki)) if alpha == 0.0 => Some(samples[ki]),
            (Some(End::Vertex { slot }), _) if alpha == 1.0 => Some(samples[slot]),
            (Some(End::Point { index, alpha: a }), _) if alpha == a => {
                surface.point_samples.get(index as usize).copied()
            }
            _ => None,
        };
        if reuse.is_none() {
            recompute.push(k);
        }
        boundary.push(reuse.unwrap_or_default());
    }
    let positions: Vec<DVec3> = recompute.iter().map(|&k| region.point_position(mesh, k as u32)).collect();
    let (matches, closest_point_matches) = match setup.parametrization {
        None => cast_matches(&positions, other, setup.toward),
        Some(param) => {
            let mut fallbacks = 0;
            let matches: Vec<Match> = recompute
                .iter()
                .map(|&k| {
                    let s = &slides[k];
                    let alpha = region.points()[k].alpha;
                    let (to, span) = match s.end {
                        Some(End::Vertex { .. }) => (Sample::Vertex(region.points()[k].outside), 1.0),
                        Some(End::Point { index, alpha }) => (Sample::Point(index), alpha),
                        None => (Sample::Vertex(s.inside), 1.0),
                    };
                    let t = if span > 0.0 { alpha / span } else { 0.0 };
                    let (m, fallback) = param.match_between(mapping, other, Sample::Vertex(s.inside), to, t);
                    fallbacks += usize::from(fallback);
                    m
                })
                .collect();
            (matches, fallbacks)
        }
    };
    for ((&k, p), m) in recompute.iter().zip(positions).zip(&matches) {
        let n = region.interpolate(side.normals, Sample::Point(k as u32)).normalize_or_zero();
        boundary[k] = surface_sample(p, n, m, setup.toward, 0.0, 1.0);
    }

    let mut targets = mesh.positions.clone();
    let mut normals = vec![DVec3::ZERO; nv];
    for (&v, s) in mapping.vertices.iter().zip(samples) {
        if region.contains(v) {
            targets[v as usize] = s.target;
            normals[v as usize] = s.surface_normal;
        }
    }
    let boundary_positions: Vec<DVec3> =
        (0..region.points().len() as u32).map(|p| region.point_position(mesh, p)).collect();
    let boundary_targets: Vec<DVec3> = boundary.iter().map(|s| s.target).collect();
    let boundary_normals: Vec<DVec3> = boundary.iter().map(|s| s.surface_normal).collect();
    let area_on_surface = region.area_with(mesh, topology, |s| match s {
        Sample::Vertex(v) => targets[v as usize],
        Sample::Point(p) => boundary_targets[p as usize],
    });
    let area_on_mesh = region.area(mesh, topology);
    Ok(BallZone {
        result: ZoneResult {
            zone: ContactZone {
                region,
                targets,
                normals,
                boundary_positions,
                boundary_targets,
                boundary_normals,
                direction: -setup.toward,
                mapping_direction: setup.mapping_direction,
            },
            area_on_surface,
            area_on_mesh,
            closest_point_matches,
        },
        stats,
    })
}

/// An empty zone of `side` (the rigid side of a ball-tested pair).
fn empty_zone(side: &ContactSide, toward: DVec3, mapping_direction: DVec3) -> ZoneResult {
    let nv = side.mesh.num_vertices();
    ZoneResult {
        zone: ContactZone {
            region: EdgeRegion::empty(side.topology),
            targets: side.mesh.positions.clone(),
            normals: vec![DVec3::ZERO; nv],
            boundary_positions: Vec::new(),
            boundary_targets: Vec::new(),
            boundary_normals: Vec::new(),
            direction: -toward,
            mapping_direction,
        },
        area_on_surface: 0.0,
        area_on_mesh: 0.0,
        closest_point_matches: 0,
    }
}

/// Both zones of a ball-tested pair: the elastic side's by [`ball_zone`], an empty one on the
/// rigid side. `direction` is d̂ (toward = +d̂ on a, −d̂ on b).
#[allow(clippy::too_many_arguments)]
pub(crate) fn ball_zones(
    sides: [&ContactSide; 2],
    mappings: &[SideMapping; 2],
    surfaces: &[SideSurface; 2],
    intersections: [&EdgeRegion; 2],
    elastic: usize,
    radius: f64,
    direction: DVec3,
    shared: Option<&SharedParametrization>,
) -> Result<[ZoneResult; 2], ContactError> {
    let toward = [direction, -direction];
    let rigid = 1 - elastic;
    let setup = BallSetup {
        radius,
        toward: toward[elastic],
        mapping_direction: direction,
        parametrization: shared.map(|s| &s.sides[elastic]),
        compensate_sag: true,
    };
    let zone = ball_zone(
        sides[elastic],
        sides[rigid],
        &mappings[elastic],
        &surfaces[elastic],
        intersections[elastic],
        &setup,
    )?
    .result;
    let empty = empty_zone(sides[rigid], toward[rigid], direction);
    Ok(if elastic == 0 { [zone, empty] } else { [empty, zone] })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::super::test_support::{Owned, sphere_center, sphere_in_grid};
    use super::super::{PairContact, Stiffness, contact_pair};
    use super::*;
    use crate::mesh::{TriMesh, shapes};
    use crate::params::PairParams;
    use crate::stage::Stage;
    use std::time::Instant;

    fn ball(r: f64) -> PairParams {
        PairParams::default().with_ball(r)
    }

    fn run(a: &Owned, b: &Owned, params: &PairParams) -> PairContact {
        // The thesis' 𝒮 is checked here: the contact gap (tested with the pipeline, in
        // tests/pipeline/gap.rs) is 0 unless a test asks for one.
        let params = PairParams { contact_gap: params.contact_gap.or(Some(0.0)), ..*params };
        contact_pair(&a.side(), &b.side(), &params).unwrap()
    }

    /// Rigid unit sphere (a) dipped h into an elastic grid (b).
    fn rigid_sphere_in_grid(h: f64, level: u32, n: u32) -> (Owned, Owned) {
        let (sphere, grid) = sphere_in_grid(h, level, n);
        (sphere.with_stiffness(Stiffness::Rigid), grid)
    }

    /// Fig. 4.10: the zone shrinks as r_s grows, as the analytic ball-rolling area 2πh/(1 + r_s)
    /// (module docs of the test), and every target lies on the rigid sphere.
    #[test]
    fn areas_shrink_as_the_ball_grows_and_targets_lie_on_the_sphere() {
        let h = 0.2;
        let (sphere, grid) = rigid_sphere_in_grid(h, 5, 80);
        let center = sphere_center(h);
        let longest = sphere
            .topology
            .edges()
            .iter()
            .map(|&[i, j]| (sphere.mesh.positions[i as usize] - sphere.mesh.positions[j as usize]).length())
            .fold(0.0, f64::max);
        let inner = 1.0 - longest * longest / 2.0;
        let mut previous = f64::INFINITY;
        let intersection_area = {
            let c = run(&sphere, &grid, &ball(1e-3));
            c.sides[1].zone_area_on_surface
        };
        println!(
            "r_s → 0: area {intersection_area:.4} (the whole intersection cap: 2πh = {:.4})",
            2.0 * std::f64::consts::PI * h
        );
        for r in [0.05, 0.1, 0.2, 0.4, 0.8, 1.6, 3.2] {
            let contact = run(&sphere, &grid, &ball(r));
            assert!(contact.sides[0].zone.is_empty(), "the rigid side has no zone");
            let zone = &contact.sides[1].zone;
            let area = contact.contact_area;
            assert_eq!(area, contact.sides[1].zone_area_on_surface);
            // The ball tangent to the sphere at angle θ from its bottom touches the plane z = 0
            // when cos θ = (1 − h + r)/(1 + r): the zone is the cap of area 2π(1 − cos θ).
            let analytic = 2.0 * std::f64::consts::PI * h / (1.0 + r);
            println!(
                "r_s = {r:4.2}: area on 𝒮 {area:.4}, analytic {analytic:.4} (ratio {:.3}), {} zone vertices, {} boundary points",
                area / analytic,
                zone.region.num_inside(),
                zone.region.points().len()
            );
            assert!(area < previous, "the area must decrease as r_s grows: {area} after {previous}");
            assert!((area / analytic - 1.0).abs() < 0.05, "r_s = {r}: {area} vs {analytic}");
            previous = area;
            for v in 0..grid.mesh.num_vertices() as u32 {
                if zone.region.contains(v) {
                    let d = (zone.targets[v as usize] - center).length();
                    assert!(d >= inner - 1e-9 && d <= 1.0 + 1e-9, "target of {v} at {d} from the centre");
                    // n′ is the sphere's normal, outward from the plane (into the sphere).
                    let n = zone.normals[v as usize];
                    assert!(n.dot(center - zone.targets[v as usize]) > 0.99 * d, "{n}");
                }
            }
            for (k, t) in zone.boundary_targets.iter().enumerate() {
                let d = (*t - center).length();
                assert!(d >= inner - 1e-9 && d <= 1.0 + 1e-9, "boundary point {k} at {d} from the centre");
                assert!(zone.boundary_positions[k].z.abs() < 1e-12);
                // Inside the intersection: the boundary point is inside the sphere.
                assert!((zone.boundary_positions[k] - center).length() <= 1.0 + 1e-9);
            }
            // Displacement along −d̂ = −z (the plane's normal), the zone's direction is +z.
            assert!((zone.direction - DVec3::Z).length() < 1e-12);
        }
    }

    /// The zone boundary moves continuously: 200 positions 10⁻⁴ of the sphere's diameter apart,
    /// sideways and down, across many vertex crossings; the contact area changes by at most a
    /// constant times the step.
    #[test]
    fn the_zone_moves_continuously_with_the_sphere() {
        let h = 0.2;
        let step = 1e-4 * 2.0;
        let motion = DVec3::new(1.0, 0.5, -0.7).normalize() * step;
        for r in [0.5, 2.0] {
            let (mut sphere, grid) = rigid_sphere_in_grid(h, 5, 80);
            // (area, area with the thesis' constant radius, zone flags) at the previous position.
            let mut previous: Option<(f64, f64, Vec<bool>)> = None;
            let (mut worst, mut worst_literal, mut total, mut crossings) = (0.0f64, 0.0f64, 0.0f64, 0);
            for _ in 0..200 {
                let contact = run(&sphere, &grid, &ball(r));
                let side = &contact.sides[1];
                let literal = ball_zone(
                    &grid.side(),
                    &sphere.side(),
                    &side.mapping,
                    &side.surface,
                    &side.intersection,
                    &BallSetup {
                        radius: r,
                        toward: -contact.direction,
                        mapping_direction: contact.direction,
                        parametrization: None,
                        compensate_sag: false,
                    },
                )
                .unwrap()
                .result
                .area_on_surface;
                let inside = side.zone.region.inside().to_vec();
                if let Some((area, area_literal, flags)) = &previous {
                    let ratio = (contact.contact_area - area).abs() / step;
                    worst = worst.max(ratio);
                    worst_literal = worst_literal.max((literal - area_literal).abs() / step);
                    total += ratio;
                    crossings += usize::from(*flags != inside);
                }
                previous = Some((contact.contact_area, literal, inside));
                sphere.translate(motion);
            }
            let mean = total / 199.0;
            // Smooth rate: d(2πh/(1 + r))/dh = 2π/(1 + r) per unit of depth, times the downward
            // component 0.57 of the motion (2.2 for r = 0.5, 1.1 for r = 2). A vertex entering or
            // leaving the zone with its fan (~(3/80)² ≈ 1.4·10⁻³ of area) would be a ratio of ~7,
            // and a jump of a boundary point across an edge far more.
            let smooth = 2.0 * std::f64::consts::PI / (1.0 + r) * 0.7 / 1.0f64.hypot(0.5).hypot(0.7);
            println!(
                "ball sliding continuity, r_s = {r}: max |Δarea|/step = {worst:.3}, mean {mean:.3} (smooth rate {smooth:.3}); \
                 with the thesis' constant radius {worst_literal:.3}; zone vertex sets changed at {crossings} of 199 steps"
            );
            assert!(crossings >= 20, "the motion must move the zone across vertices ({crossings})");
            assert!(worst <= 1.5 * smooth, "the contact area jumped: {worst} × step");
        }
    }

    /// Ball testing needs exactly one rigid object.
    #[test]
    fn ball_testing_needs_one_rigid_object() {
        let (sphere, grid) = sphere_in_grid(0.2, 3, 30);
        let err = contact_pair(&sphere.side(), &grid.side(), &ball(0.5)).unwrap_err();
        assert!(matches!(err, ContactError::BallTestingNeedsOneRigid), "{err}");
        let message = err.to_string();
        assert!(
            message.contains("one rigid object") && message.contains("contact_method = \"geometric\""),
            "{message}"
        );
        let rigid = sphere.clone_with(Stiffness::Rigid);
        let both = grid.clone_with(Stiffness::Rigid);
        assert!(matches!(contact_pair(&rigid.side(), &both.side(), &ball(0.5)), Err(ContactError::BothRigid)));
        // The rigid side may be either one: the zone is always on the elastic side.
        let swapped = contact_pair(&grid.side(), &rigid.side(), &ball(0.5)).unwrap();
        assert!(!swapped.sides[0].zone.is_empty() && swapped.sides[1].zone.is_empty());
        let straight = contact_pair(&rigid.side(), &grid.side(), &ball(0.5)).unwrap();
        let (x, y) = (&swapped.sides[0].zone.region, &straight.sides[1].zone.region);
        assert!(x.inside() == y.inside(), "the pair order changed the zone's vertices");
        let worst = x.points().iter().zip(y.points()).map(|(p, q)| (p.alpha - q.alpha).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "the pair order moved a boundary point by {worst}");
        assert!((swapped.contact_area - straight.contact_area).abs() < 1e-9);
        // And invalid radii are rejected before any work.
        assert!(contact_pair(&rigid.side(), &grid.side(), &ball(-1.0)).is_err());
    }

    /// Same input, bit-identical zones, whatever the number of threads.
    #[test]
    fn ball_testing_is_deterministic() {
        let (sphere, grid) = rigid_sphere_in_grid(0.25, 4, 60);
        let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let r1 = single.install(|| run(&sphere, &grid, &ball(0.4)));
        let r2 = run(&sphere, &grid, &ball(0.4));
        let r3 = run(&sphere, &grid, &ball(0.4));
        for r in [&r2, &r3] {
            let (z1, z2) = (&r1.sides[1].zone, &r.sides[1].zone);
            assert_eq!(z1.region, z2.region);
            assert_eq!(z1.targets, z2.targets);
            assert_eq!(z1.normals, z2.normals);
            assert_eq!(z1.boundary_targets, z2.boundary_targets);
            assert_eq!(z1.boundary_normals, z2.boundary_normals);
            assert_eq!(r1.contact_area.to_bits(), r.contact_area.to_bits());
        }
    }

    /// Two separate rigid bumps (one rigid object) give a zone of two components, and each is the
    /// zone of a single bump: the ball test is local (§4.4.2 discussion: "the ball-testing
    /// criterion is much more local").
    #[test]
    fn two_bumps_give_two_independent_components() {
        let bump = |x: f64| {
            let mut s = shapes::icosphere(0.5, 4);
            s.map_positions(|p| p + DVec3::new(x, 0.013, 0.5 - 0.15));
            s
        };
        let mut both = bump(-0.7);
        both.append(&bump(0.7));
        let grid = Owned::new(shapes::grid(3.0, 2.0, 120, 80), DVec3::ZERO);
        let zone_of = |mesh: TriMesh| {
            let rigid = Owned::new(mesh, DVec3::ZERO).with_stiffness(Stiffness::Rigid);
            let contact = run(&rigid, &grid, &ball(0.3));
            contact.sides[1].zone.clone()
        };
        let (pair, left, right) = (zone_of(both), zone_of(bump(-0.7)), zone_of(bump(0.7)));
        let mut seen = vec![false; grid.mesh.num_vertices()];
        let mut components = 0;
        for v in 0..grid.mesh.num_vertices() as u32 {
            if !pair.region.contains(v) || seen[v as usize] {
                continue;
            }
            components += 1;
            let mut stack = vec![v];
            seen[v as usize] = true;
            while let Some(x) = stack.pop() {
                for w in grid.topology.vertex_neighbors(x) {
                    if pair.region.contains(w) && !seen[w as usize] {
                        seen[w as usize] = true;
                        stack.push(w);
                    }
                }
            }
        }
        println!(
            "two bumps: {components} components, {} zone vertices = {} + {}",
            pair.region.num_inside(),
            left.region.num_inside(),
            right.region.num_inside()
        );
        assert_eq!(components, 2);
        for v in 0..grid.mesh.num_vertices() as u32 {
            assert_eq!(pair.region.contains(v), left.region.contains(v) || right.region.contains(v), "vertex {v}");
        }
    }

    /// Timings on a ~10k-vertex elastic region (the thesis: ball testing/sliding is method A's
    /// bottleneck, Table 7.1).
    #[test]
    fn timings_for_a_ten_thousand_vertex_elastic_region() {
        // A 10k-vertex grid (ℳ ≈ 1.5k vertices), and a 40k-vertex grid pressed deeper so that
        // about 10k vertices are mapped and ball-tested.
        let cases = [(0.25, 100, [0.1, 0.5, 2.0].as_slice()), (0.5, 200, [0.5].as_slice())];
        for (depth, cells, radii) in cases {
            let sphere = Owned::new(shapes::icosphere(1.0, 5), DVec3::new(0.013, -0.021, 1.0 - depth))
                .with_stiffness(Stiffness::Rigid);
            let grid = Owned::new(shapes::grid(3.0, 3.0, cells, cells), DVec3::ZERO);
            for &r in radii {
                let mut best = f64::INFINITY;
                let mut zone_time = f64::INFINITY;
                let mut last = None;
                for _ in 0..5 {
                    let start = Instant::now();
                    let contact = run(&sphere, &grid, &ball(r));
                    best = best.min(start.elapsed().as_secs_f64());
                    zone_time = zone_time.min(contact.stats.timings[Stage::ContactZone].as_secs_f64());
                    last = Some(contact);
                }
                let contact = last.unwrap();
                let geometric = {
                    let start = Instant::now();
                    let c = run(&sphere, &grid, &PairParams::default());
                    (start.elapsed().as_secs_f64(), c.stats.timings[Stage::ContactZone].as_secs_f64())
                };
                println!(
                    "r_s = {r}: {} grid vertices, ℳ {} vertices, 𝒞 {} vertices / {} boundary points: contact_pair \
                     {:.1} ms, of which surface, ball testing and sliding {:.1} ms (geometric criterion: {:.1} ms, surface and zones \
                     {:.2} ms)",
                    grid.mesh.num_vertices(),
                    contact.stats.counts.mapping_vertices[1],
                    contact.stats.counts.zone_vertices[1],
                    contact.stats.counts.zone_boundary_points[1],
                    best * 1e3,
                    zone_time * 1e3,
                    geometric.0 * 1e3,
                    geometric.1 * 1e3
                );
                assert!(best < 2.0);
            }
        }
    }
}
