//! Mapping regions ℳ_a, ℳ_b and the matching of their points along ±d̂ (thesis §4.2.2).
//!
//! Each side l has a direction `toward_l` pointing at the other object: +d̂ for a, −d̂ for b
//! (d̂ is oriented along b's normals). Everything below is written once for both sides with it.
//!
//! 1. **Front-facing regions** (THESIS-NOTES item 9). g_l = n·toward_l at the vertices (g_a = n·d̂,
//!    g_b = n·(−d̂)); front-facing where g ≤ 0. F_l = [`EdgeRegion::sublevel_set`] of g, bounded
//!    by the interpolated contours of Hertzmann and Zorin, t = g_i / (g_i − g_j).
//!    ℬ_l = ℐ_l ∩ F_l ([`EdgeRegion::intersection`]): where a contour leaves ℐ_l the boundary is
//!    automatically closed by ℐ_l's own boundary, and ℬ_l = ℐ_l when there is no contour.
//! 2. **Projected regions** 𝒫_b(ℬ_a). The boundary of ℬ_a is the set of per-face segments joining
//!    the two boundary points of each face piece, plus the parts of genuine mesh-boundary edges
//!    inside ℬ_a (an open mesh). They are projected on the plane ⟂ d̂ ([`ProjectionPlane`]) and
//!    oriented so that ℬ_a lies on their left, into [`SegmentSlabs`]. A vertex v of b is inside
//!    𝒫_b(ℬ_a) iff it is front-facing (g_b ≤ 0) and its projection has a non-zero winding number
//!    with respect to the projected segments (a ray along +u in the plane; the exact,
//!    perturbed crossings make it half-open at shared segment ends). On an edge from an inside
//!    vertex i to an outside vertex j, α is the crossing of the projected edge with the segments
//!    nearest to i, or the contour point t = g_i / (g_i − g_j) if j is back-facing and that is
//!    nearer; if no crossing is found (round-off only) α = ½, counted.
//!    ℳ_b = 𝒫_b(ℬ_a) ∪ ℬ_b ([`EdgeRegion::union`]); ℳ_a = 𝒫_a(ℬ_b) ∪ ℬ_a likewise.
//! 3. **Matches.** Every vertex of ℳ_l is matched to the *farthest* crossing of the full line
//!    through it along toward_l with the other mesh (largest signed parameter along toward_l,
//!    negative allowed: a vertex with a gap in front of the other surface maps back to it), with
//!    the face, barycentric coordinates, point p″ and interpolated, normalized vertex normal n″
//!    there. Boundary points of ℳ_l that come from a projected segment already know their match:
//!    the point of the ℬ segment (a chord of one face of the other mesh) at the crossing's
//!    parameter — casting a line there would graze the other object's silhouette. Other boundary
//!    points (intersection and contour points) are cast from their interpolated position. A line
//!    that misses the other mesh (a numerical corner) falls back to the closest point, counted.
//!    Casts use [`TriangleBvh::ray_farthest_batch`](crate::spatial::TriangleBvh::ray_farthest_batch):
//!    parallel, results in input order.

use glam::{DVec2, DVec3};

use super::region::crossing_edges;
use super::{ContactError, ContactSide, EdgeRegion, Sample};
use crate::linalg::EdgePoint;
use crate::mesh::{Topology, TriMesh};
use crate::spatial::{CrossingHint, ProjectionPlane, Ray, SegmentSlabs};
use crate::stage::SharedWork;

/// Vertices per run of the visibility test: each run starts from no hint (see [`visible_part`]).
const VISIBILITY_RUN: usize = 256;

/// Marks a vertex outside a mapping region in [`SideMapping::vertex_slot`].
pub const NO_SLOT: u32 = u32::MAX;

/// How a match was found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum MatchKind {
    /// Farthest crossing of the line along ±d̂.
    #[default]
    Ray,
    /// A boundary point of a projected region: the corresponding point of the projected chord.
    Chord,
    /// Fallback: the line missed the other mesh; closest point instead.
    Closest,
    /// Shared-parametrization mapping (§4.2.1, [`super::map_regions_uv`]): located in the other
    /// mesh's UV space, or an intersection point (known on both meshes).
    Parametric,
}

/// The point of the other mesh matched to a point of this one (p″, n″ of §4.2.2–§4.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Match {
    /// Face of the other mesh holding the match.
    pub face: u32,
    /// Barycentric coordinates on that face.
    pub bary: [f64; 3],
    /// The matched point p″.
    pub point: DVec3,
    /// Unit normal of the other mesh there, n″ (interpolated vertex normals, normalized).
    pub normal: DVec3,
    /// How it was found.
    pub kind: MatchKind,
}

/// A segment of a region's boundary on its own mesh, as two points of one face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chord {
    /// The face holding the segment.
    pub face: u32,
    /// Barycentric coordinates of the segment's start and end on the face.
    pub bary: [[f64; 3]; 2],
}

/// The boundary of a region projected on the plane ⟂ d̂: 2D segments (region on their left) and
/// the chords they come from.
#[derive(Clone, Debug, Default)]
pub struct RegionOutline {
    pub segments: Vec<[DVec2; 2]>,
    pub chords: Vec<Chord>,
}

/// The mapping data of one side.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SideMapping {
    /// ℬ_l = ℐ_l ∩ {front-facing}.
    pub front: EdgeRegion,
    /// 𝒫_l(ℬ_other): the other side's ℬ projected on this mesh along d̂.
    pub projected: EdgeRegion,
    /// ℳ_l = 𝒫_l(ℬ_other) ∪ ℬ_l.
    pub region: EdgeRegion,
    /// The inside vertices of ℳ_l, increasing.
    pub vertices: Vec<u32>,
    /// Per mesh vertex: its index in `vertices`, or [`NO_SLOT`].
    pub vertex_slot: Vec<u32>,
    /// Match of each vertex of `vertices`.
    pub vertex_matches: Vec<Match>,
    /// Match of each boundary point of `region` (same order as `region.points()`).
    pub point_matches: Vec<Match>,
}

impl SideMapping {
    /// The match of a sample of ℳ (`None` for a vertex outside ℳ).
    pub fn sample_match(&self, sample: Sample) -> Option<&Match> {
        match sample {
            Sample::Vertex(v) => match self.vertex_slot.get(v as usize) {
                Some(&s) if s != NO_SLOT => self.vertex_matches.get(s as usize),
                _ => None,
            },
            Sample::Point(p) => self.point_matches.get(p as usize),
        }
    }
}

/// Counters of the mapping stage's numerical fallbacks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct MappingStats {
    /// Projected-region edges without a crossing found (cut at α = ½).
    pub midpoint_alphas: usize,
    /// Matches found by the closest-point fallback.
    pub closest_point_matches: usize,
    /// Mapping-region vertices that are flagged as working-region border vertices (the zone may
    /// then be cut by the working region).
    pub border_vertices: usize,
    /// Vertices removed from ℳ because another part of their own mesh hides them from the other
    /// object along the mapping direction (the visibility test of the mapping regions).
    pub occluded_vertices: usize,
}

/// Whether a part of `side`'s own mesh lies beyond `x` along `away` (x is then hidden from the
/// other object): `Some` (the triangle found, tried first by the next query: nearby hidden points
/// are usually hidden by the same one) or `None`. The segment starts a hair beyond x so that x's
/// own faces do not count.
fn occluder(
    side: &ContactSide,
    x: DVec3,
    away: DVec3,
    offset: f64,
    length: f64,
    hint: Option<CrossingHint>,
) -> Option<CrossingHint> {
    side.bvh.segment_crossing_hint(x + away * offset, x + away * length, hint)
}

/// The part of a mapping region that the other object can reach (thesis §4.5, Fig. 4.12 and its
/// discussion: "a subset of the mapping region is not reachable by the other one … it
/// contributes to the computation of ε_c, which is then biased. This subset should thus be
/// removed from the mapping region").
///
/// A point x of side l is matched along `toward` (+d̂ for a, −d̂ for b) to the other mesh, and
/// the other mesh matches its points back along −`toward` to the *farthest* point of l: so x can
/// only be reached if no part of its own mesh lies beyond it along −`toward`. Otherwise x sits on
/// a hidden layer (the belly above a foot that rests on the ground, the inside of a fold), whose
/// large gap to the other object would drag the statistics m_𝒮, σ_𝒮 of Eq. 4.3 far from the
/// actual contact. Hidden vertices leave the region; on an edge from a visible vertex to a hidden
/// one the boundary point is where the hiding layer's silhouette crosses the edge, found by
/// bisection to 2⁻⁴⁰ of the edge, so the region still moves continuously with the geometry.
/// Returns the region and the number of vertices removed.
pub fn visible_part(region: &EdgeRegion, side: &ContactSide, toward: DVec3) -> (EdgeRegion, usize) {
    use rayon::prelude::*;
    let bounds = side.bvh.bounds();
    let scale = bounds.diagonal().max(f64::MIN_POSITIVE);
    let (offset, away) = (1e-9 * scale, -toward);
    let length = |x: DVec3| (x - bounds.center()).length() + scale;
    let positions = &side.mesh.positions;
    let candidates: Vec<u32> = (0..positions.len() as u32).filter(|&v| region.contains(v)).collect();
    // Runs of VISIBILITY_RUN vertices, each from no hint: the hints, which change the work but not
    // the answers, are then the same whatever the threads (so is the work counted, `Work`).
    let work = SharedWork::default();
    let hidden: Vec<bool> = candidates
        .par_chunks(VISIBILITY_RUN)
        .flat_map_iter(|run| {
            work.measure(|| {
                let mut hint = None;
                run.iter()
                    .map(|&v| {
                        let x = positions[v as usize];
                        // A visible point drops the hint: the next ones are likely visible too.
                        hint = occluder(side, x, away, offset, length(x), hint);
                        hint.is_some()
                    })
                    .collect::<Vec<bool>>()
            })
        })
        .collect();
    work.record();
    let occluded = hidden.iter().filter(|&&h| h).count();
    if occluded == 0 {
        return (region.clone(), 0);
    }
    let mut inside = region.inside().to_vec();
    for (&v, &h) in candidates.iter().zip(&hidden) {
        if h {
            inside[v as usize] = false;
        }
    }
    let visible = EdgeRegion::from_inside(side.topology, inside, |e, i, j| {
        if region.contains(j) {
            // Both ends in ℳ, j hidden: bisect the visibility along the edge.
            let (pi, pj) = (positions[i as usize], positions[j as usize]);
            let (mut lo, mut hi) = (0.0f64, 1.0f64);
            let mut hint = None;
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                let x = pi.lerp(pj, mid);
                let found = occluder(side, x, away, offset, length(x), hint);
                hint = found.or(hint);
                if found.is_some() {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            0.5 * (lo + hi)
        } else {
            // j was already outside ℳ: keep ℳ's own boundary point.
            region.point_on_edge(e).map_or(0.5, |p| region.points()[p as usize].alpha)
        }
    });
    (visible, occluded)
}

/// The front-facing function g = n·toward at every vertex.
pub fn facing(normals: &[DVec3], toward: DVec3) -> Vec<f64> {
    normals.iter().map(|n| n.dot(toward)).collect()
}

/// Barycentric coordinates on a face (corners `tri`) of the boundary point `p` lying on the face's
/// edge `k` (corners k and k + 1).
fn point_bary(tri: [u32; 3], k: usize, p: &EdgePoint) -> [f64; 3] {
    let mut bary = [0.0; 3];
    let k1 = (k + 1) % 3;
    if tri[k] == p.inside {
        bary[k] = 1.0 - p.alpha;
        bary[k1] = p.alpha;
    } else {
        bary[k1] = 1.0 - p.alpha;
        bary[k] = p.alpha;
    }
    bary
}

/// The boundary of `region` projected on `plane`: the segment of every face piece between its two
/// boundary points, and the parts of mesh-boundary edges inside the region. Segments follow each
/// piece's counter-clockwise order (the region on their left seen from the faces' front); with
/// `reverse` they are flipped (for a region seen from its back in the plane's orientation).
pub fn region_outline(
    region: &EdgeRegion,
    mesh: &TriMesh,
    topology: &Topology,
    plane: &ProjectionPlane,
    reverse: bool,
) -> RegionOutline {
    let mut out = RegionOutline::default();
    if region.is_empty() {
        return out;
    }
    // Each boundary point is projected once so that the two faces sharing it produce exactly the
    // same 2D endpoint (the crossing rule of the segment tree relies on shared endpoints).
    let points_2d: Vec<DVec2> =
        (0..region.points().len() as u32).map(|p| plane.project(region.point_position(mesh, p))).collect();
    let inside = region.inside();
    let mut entries = [(Sample::Vertex(0), 0usize, [0.0; 3]); 4];
    for (f, &tri) in mesh.triangles.iter().enumerate() {
        if !tri.iter().any(|&v| inside[v as usize]) {
            continue;
        }
        let fe = topology.face_edges(f as u32);
        let mut len = 0;
        for k in 0..3 {
            if inside[tri[k] as usize] {
                let mut bary = [0.0; 3];
                bary[k] = 1.0;
                entries[len] = (Sample::Vertex(tri[k]), k, bary);
                len += 1;
            }
            if let Some(p) = region.point_on_edge(fe[k])
                && len < 4
            {
                entries[len] = (Sample::Point(p), k, point_bary(tri, k, &region.points()[p as usize]));
                len += 1;
            }
        }
        if len < 3 {
            continue;
        }
        for i in 0..len {
            let (s0, k0, b0) = entries[i];
            let (s1, _, b1) = entries[(i + 1) % len];
            // Two consecutive boundary points cut the face; any other pair runs along edge k0.
            let cut = matches!((s0, s1), (Sample::Point(_), Sample::Point(_)));
            if !cut && !topology.is_boundary_edge(fe[k0]) {
                continue;
            }
            let at = |s: Sample| match s {
                Sample::Vertex(v) => plane.project(mesh.positions[v as usize]),
                Sample::Point(p) => points_2d[p as usize],
            };
            let (q0, q1) = (at(s0), at(s1));
            if reverse {
                out.segments.push([q1, q0]);
                out.chords.push(Chord { face: f as u32, bary: [b1, b0] });
            } else {
                out.segments.push([q0, q1]);
                out.chords.push(Chord { face: f as u32, bary: [b0, b1] });
            }
        }
    }
    out
}

/// A projected region and, per boundary point, the outline segment and its parameter where the
/// point was found (`None` for contour points and fallbacks).
#[derive(Clone, Debug, Default)]
pub struct Projected {
    pub region: EdgeRegion,
    pub sources: Vec<Option<(u32, f64)>>,
    pub midpoint_alphas: usize,
}

/// 𝒫(ℬ) on `target`: its front-facing vertices (`g ≤ 0`) whose projection the outline winds
/// around, with α from the 2D crossings or the contour (see the module docs).
pub fn projected_region(
    outline: &RegionOutline,
    target_mesh: &TriMesh,
    target_topology: &Topology,
    g: &[f64],
    plane: &ProjectionPlane,
) -> Result<Projected, ContactError> {
    if outline.segments.is_empty() {
        return Ok(Projected { region: EdgeRegion::empty(target_topology), ..Default::default() });
    }
    let tree = SegmentSlabs::new(&outline.segments)?;
    let (mut lo, mut hi) = (DVec2::INFINITY, DVec2::NEG_INFINITY);
    for s in &outline.segments {
        lo = lo.min(s[0].min(s[1]));
        hi = hi.max(s[0].max(s[1]));
    }
    let far_x = hi.x + (hi.x - lo.x) + hi.x.abs() + 1.0;
    let projected: Vec<DVec2> = target_mesh.positions.iter().map(|&p| plane.project(p)).collect();
    let candidates: Vec<u32> = (0..projected.len() as u32)
        .filter(|&v| {
            let q = projected[v as usize];
            g[v as usize] <= 0.0 && q.cmpge(lo).all() && q.cmple(hi).all()
        })
        .collect();
    let rays: Vec<[DVec2; 2]> = candidates
        .iter()
        .map(|&v| {
            let q = projected[v as usize];
            [q, DVec2::new(far_x, q.y)]
        })
        .collect();
    let windings = tree.crossings_batch(&rays);
    let mut inside = vec![false; projected.len()];
    for (&v, hits) in candidates.iter().zip(windings.iter()) {
        let mut w = 0i32;
        for h in hits {
            let [s0, s1] = outline.segments[h.segment as usize];
            w += match (s1.y - s0.y).partial_cmp(&0.0) {
                Some(std::cmp::Ordering::Greater) => 1,
                Some(std::cmp::Ordering::Less) => -1,
                _ => 0,
            };
        }
        inside[v as usize] = w != 0;
    }
    // Edges leaving the region, in increasing edge id (the order of the region's points).
    let edges = target_topology.edges();
    let crossing = crossing_edges(target_topology, &inside);
    let mixed: Vec<(u32, u32, u32)> = crossing
        .iter()
        .map(|&e| {
            let [x, y] = edges[e as usize];
            if inside[x as usize] { (e, x, y) } else { (e, y, x) }
        })
        .collect();
    let queries: Vec<[DVec2; 2]> =
        mixed.iter().map(|&(_, i, j)| [projected[i as usize], projected[j as usize]]).collect();
    let crossings = tree.crossings_batch(&queries);
    let mut alphas = Vec::with_capacity(mixed.len());
    let mut sources = Vec::with_capacity(mixed.len());
    let mut midpoint_alphas = 0;
    for (&(_, i, j), hits) in mixed.iter().zip(crossings.iter()) {
        let (gi, gj) = (g[i as usize], g[j as usize]);
        let contour = (gj > 0.0).then(|| gi / (gi - gj));
        let (alpha, source) = match (hits.first(), contour) {
            (Some(h), Some(c)) if c < h.s => (c, None),
            (Some(h), _) => (h.s, Some((h.segment, h.t))),
            (None, Some(c)) => (c, None),
            (None, None) => {
                midpoint_alphas += 1;
                (0.5, None)
            }
        };
        alphas.push(alpha);
        sources.push(source);
    }
    let region = EdgeRegion::from_crossing_edges(target_topology, inside, &crossing, |e, _, _| {
        mixed.binary_search_by_key(&e, |m| m.0).map_or(0.5, |k| alphas[k])
    });
    debug_assert_eq!(region.points().len(), sources.len());
    Ok(Projected { region, sources, midpoint_alphas })
}

/// Unit interpolated normal of `mesh` at barycentric coordinates `bary` of face `face` (the face
/// normal if the interpolation vanishes).
pub fn normal_at(mesh: &TriMesh, normals: &[DVec3], face: u32, bary: [f64; 3]) -> DVec3 {
    let Some(tri) = mesh.triangles.get(face as usize) else { return DVec3::ZERO };
    let n: DVec3 = (0..3).map(|k| normals[tri[k] as usize] * bary[k]).sum();
    n.try_normalize().unwrap_or_else(|| {
        let [a, b, c] = tri.map(|v| mesh.positions[v as usize]);
        (b - a).cross(c - a).normalize_or_zero()
    })
}

/// Matches of `points` on `other` along the full lines through them in direction `toward`
/// (farthest crossing; closest point if the line misses). Returns the matches and the number of
/// closest-point fallbacks.
pub fn cast_matches(points: &[DVec3], other: &ContactSide, toward: DVec3) -> (Vec<Match>, usize) {
    let tree = other.match_tree();
    let bounds = tree.bounds();
    let (center, half) = (bounds.center(), 0.5 * bounds.diagonal());
    // Start every ray behind the other mesh's box (|p − c| + half-diagonal reaches past it, the
    // second half-diagonal is margin) so that the ray covers the whole line there.
    let rays: Vec<Ray> = points
        .iter()
        .map(|&p| {
            let back = (p - center).length() + 2.0 * half;
            Ray::new(p - toward * back, toward)
        })
        .collect();
    let hits = tree.ray_farthest_batch(&rays);
    let missed: Vec<usize> = (0..hits.len()).filter(|&k| hits[k].is_none()).collect();
    let closest = if missed.is_empty() {
        Vec::new()
    } else {
        tree.closest_point_batch(&missed.iter().map(|&k| points[k]).collect::<Vec<_>>())
    };
    let mut closest = closest.into_iter();
    let matches = hits
        .into_iter()
        .zip(points)
        .map(|(hit, &p)| match hit {
            Some(h) => Match {
                face: h.face,
                bary: h.bary,
                point: h.point,
                normal: normal_at(other.mesh, other.normals, h.face, h.bary),
                kind: MatchKind::Ray,
            },
            None => match closest.next().flatten() {
                Some(c) => Match {
                    face: c.face,
                    bary: c.bary,
                    point: c.point,
                    normal: normal_at(other.mesh, other.normals, c.face, c.bary),
                    kind: MatchKind::Closest,
                },
                // Only for an other mesh without faces, which cannot intersect anything.
                None => Match { face: u32::MAX, bary: [0.0; 3], point: p, normal: -toward, kind: MatchKind::Closest },
            },
        })
        .collect();
    (matches, missed.len())
}

/// The match of a projected-region boundary point: the point at parameter `t` of the chord of the
/// other mesh it was projected from.
fn chord_match(chord: &Chord, t: f64, other: &ContactSide) -> Match {
    let [b0, b1] = chord.bary;
    let bary = [0, 1, 2].map(|k| b0[k] + (b1[k] - b0[k]) * t);
    let tri = other.mesh.triangles[chord.face as usize];
    let point: DVec3 = (0..3).map(|k| other.mesh.positions[tri[k] as usize] * bary[k]).sum();
    Match {
        face: chord.face,
        bary,
        point,
        normal: normal_at(other.mesh, other.normals, chord.face, bary),
        kind: MatchKind::Chord,
    }
}

/// Front-facing region ℬ_l = ℐ_l ∩ {g ≤ 0} with its front-facing function g.
pub fn front_region(intersection: &EdgeRegion, side: &ContactSide, toward: DVec3) -> (EdgeRegion, Vec<f64>) {
    let g = facing(side.normals, toward);
    let front = EdgeRegion::sublevel_set(side.topology, &g);
    (intersection.intersection(&front, side.topology), g)
}

/// Mapping regions and matches of both sides (§4.2.2), from ℐ_a, ℐ_b and d̂. The two sides are
/// independent once both ℬ are known: they run concurrently (each one's batches are parallel too;
/// the result does not depend on the scheduling).
pub fn map_regions(
    sides: [&ContactSide; 2],
    intersections: [&EdgeRegion; 2],
    direction: DVec3,
) -> Result<([SideMapping; 2], MappingStats), ContactError> {
    let Some(plane) = ProjectionPlane::new(direction) else {
        return Err(ContactError::InvalidDirection { direction: direction.to_array() });
    };
    let toward = [direction, -direction];
    // Seen from the tip of d̂ (the plane's orientation), a's front-facing pieces show their back.
    let front_and_outline = |l: usize| {
        let (front, g) = front_region(intersections[l], sides[l], toward[l]);
        let outline = region_outline(&front, sides[l].mesh, sides[l].topology, &plane, l == 0);
        (front, g, outline)
    };
    let work = SharedWork::default();
    let ((front_a, g_a, outline_a), (front_b, g_b, outline_b)) =
        rayon::join(|| work.measure(|| front_and_outline(0)), || work.measure(|| front_and_outline(1)));
    let (a, b) = rayon::join(
        || work.measure(|| map_side(sides[0], sides[1], front_a, &g_a, &outline_b, &plane, toward[0])),
        || work.measure(|| map_side(sides[1], sides[0], front_b, &g_b, &outline_a, &plane, toward[1])),
    );
    work.record();
    let ((a, stats_a), (b, stats_b)) = (a?, b?);
    let stats = MappingStats {
        midpoint_alphas: stats_a.midpoint_alphas + stats_b.midpoint_alphas,
        closest_point_matches: stats_a.closest_point_matches + stats_b.closest_point_matches,
        border_vertices: stats_a.border_vertices + stats_b.border_vertices,
        occluded_vertices: stats_a.occluded_vertices + stats_b.occluded_vertices,
    };
    Ok(([a, b], stats))
}

/// ℳ on `side` and its matches on `other`: `front` is ℬ on this side with its front-facing
/// function `g`, `other_outline` the projected boundary of the other side's ℬ.
fn map_side(
    side: &ContactSide,
    other: &ContactSide,
    front: EdgeRegion,
    g: &[f64],
    other_outline: &RegionOutline,
    plane: &ProjectionPlane,
    toward: DVec3,
) -> Result<(SideMapping, MappingStats), ContactError> {
    let mut stats = MappingStats::default();
    let projected = projected_region(other_outline, side.mesh, side.topology, g, plane)?;
    stats.midpoint_alphas = projected.midpoint_alphas;
    let (region, occluded) = visible_part(&projected.region.union(&front, side.topology), side, toward);
    stats.occluded_vertices = occluded;
    let vertices: Vec<u32> = (0..side.mesh.num_vertices() as u32).filter(|&v| region.contains(v)).collect();
    let mut vertex_slot = vec![NO_SLOT; side.mesh.num_vertices()];
    for (k, &v) in vertices.iter().enumerate() {
        vertex_slot[v as usize] = k as u32;
    }
    if let Some(border) = side.border {
        stats.border_vertices = vertices.iter().filter(|&&v| border.get(v as usize).copied().unwrap_or(false)).count();
    }
    // Boundary points: from a projected chord when 𝒫's point is the one kept by the union.
    let chord_sources: Vec<Option<(u32, f64)>> = region
        .points()
        .iter()
        .zip(region.point_edges())
        .map(|(p, &e)| {
            let q = projected.region.point_on_edge(e)?;
            let qp = projected.region.points()[q as usize];
            (qp.inside == p.inside && qp.alpha == p.alpha).then_some(projected.sources[q as usize]).flatten()
        })
        .collect();
    let mut cast_positions: Vec<DVec3> = vertices.iter().map(|&v| side.mesh.positions[v as usize]).collect();
    let n_vertices = cast_positions.len();
    for (k, source) in chord_sources.iter().enumerate() {
        if source.is_none() {
            cast_positions.push(region.point_position(side.mesh, k as u32));
        }
    }
    let (mut vertex_matches, fallbacks) = cast_matches(&cast_positions, other, toward);
    stats.closest_point_matches = fallbacks;
    let mut cast_points = vertex_matches.split_off(n_vertices).into_iter();
    let point_matches: Vec<Match> = chord_sources
        .iter()
        .map(|source| match source {
            Some((segment, t)) => chord_match(&other_outline.chords[*segment as usize], *t, other),
            None => cast_points.next().unwrap_or_default(),
        })
        .collect();
    let mapping = SideMapping {
        front,
        projected: projected.region,
        region,
        vertices,
        vertex_slot,
        vertex_matches,
        point_matches,
    };
    Ok((mapping, stats))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::test_support::Owned;
    use crate::mesh::{shapes, vertex_normals};

    /// A layer hidden behind the contact (a second ball stacked right above the one dipped into
    /// the grid, as one mesh) is in the shadow of the intersection and front-facing, but the grid
    /// can only reach the lower ball: the hidden layer leaves ℳ and the statistics of Eq. 4.3 are
    /// those of the lower ball alone.
    #[test]
    fn layers_hidden_from_the_other_object_leave_the_mapping_region() {
        use crate::contact::contact_pair;
        use crate::params::PairParams;
        let h = 0.3;
        let lower = shapes::icosphere(1.0, 3);
        let mut stacked = lower.clone();
        let mut upper = shapes::icosphere(1.0, 3);
        upper.map_positions(|p| p + DVec3::new(0.0, 0.0, 2.5));
        stacked.append(&upper);
        let offset = DVec3::new(0.0, 0.0, 1.0 - h);
        let (single, double) = (Owned::new(lower, offset), Owned::new(stacked, offset));
        let grid = Owned::new(shapes::grid(4.0, 4.0, 40, 40), DVec3::ZERO);
        let params = PairParams::default();
        let alone = contact_pair(&single.side(), &grid.side(), &params).unwrap();
        let both = contact_pair(&double.side(), &grid.side(), &params).unwrap();
        let upper_start = single.mesh.num_vertices() as u32;
        let mapped_upper = both.sides[0].mapping.vertices.iter().filter(|&&v| v >= upper_start).count();
        assert_eq!(mapped_upper, 0, "vertices of the hidden ball in ℳ");
        assert!(both.stats.fallbacks.mapping.occluded_vertices > 0, "the hidden layer was in the shadow");
        assert!((alone.criterion.threshold - both.criterion.threshold).abs() < 1e-12);
        assert!((alone.contact_area - both.contact_area).abs() < 1e-12);
    }

    /// Seen along +z (d̂ = z, side a looks toward +z), the front-facing region of a sphere is its
    /// lower hemisphere, bounded by contour points on the equator up to the chord error.
    #[test]
    fn front_facing_region_of_a_sphere_is_the_lower_hemisphere() {
        let mesh = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&mesh);
        let normals = vertex_normals(&mesh);
        let g = facing(&normals, DVec3::Z);
        let front = EdgeRegion::sublevel_set(&topology, &g);
        for (v, p) in mesh.positions.iter().enumerate() {
            // Vertex normals of an icosphere are radial up to ~1e-3 rad: the classification can
            // differ from the sign of z only right at the equator.
            if p.z.abs() > 1e-2 {
                assert_eq!(front.contains(v as u32), p.z < 0.0, "vertex {v} at {p}");
            }
        }
        let edge = crate::mesh::mean_edge_length(&mesh, &topology);
        for p in 0..front.points().len() as u32 {
            let q = front.point_position(&mesh, p);
            assert!(q.z.abs() < edge * edge, "contour point at z = {}", q.z);
        }
        let area = front.area(&mesh, &topology);
        let half = 2.0 * std::f64::consts::PI;
        assert!((area - half).abs() < 0.01 * half, "{area} vs {half}");
    }

    /// A disk on a grid at height 0.5 projected along −z onto a parallel grid of another
    /// resolution is the same disk: boundary points on the circle up to the chord error, same
    /// area up to discretization, and the chord matches lie on the first grid above the points.
    #[test]
    fn projected_region_of_a_disk_onto_a_parallel_grid_is_the_same_disk() {
        let upper = Owned::new(shapes::grid(2.0, 2.0, 30, 30), DVec3::new(0.0, 0.0, 0.5));
        let lower = Owned::new(shapes::grid(2.0, 2.0, 47, 43), DVec3::ZERO);
        let r = 0.55;
        let center = DVec3::new(0.07, -0.04, 0.0);
        let dist: Vec<f64> =
            upper.mesh.positions.iter().map(|p| (p.truncate() - center.truncate()).length() - r).collect();
        let disk = EdgeRegion::sublevel_set(&upper.topology, &dist);
        let plane = ProjectionPlane::new(DVec3::Z).unwrap();
        // The upper grid's normals point +z (towards the viewer): no reversal.
        let outline = region_outline(&disk, &upper.mesh, &upper.topology, &plane, false);
        assert!(!outline.segments.is_empty());
        let g = vec![-1.0; lower.mesh.num_vertices()];
        let projected = projected_region(&outline, &lower.mesh, &lower.topology, &g, &plane).unwrap();
        assert_eq!(projected.midpoint_alphas, 0);
        let region = &projected.region;
        let h = 2.0 / 30.0;
        for (v, p) in lower.mesh.positions.iter().enumerate() {
            let d = (p.truncate() - center.truncate()).length() - r;
            if d.abs() > h * h {
                assert_eq!(region.contains(v as u32), d < 0.0, "vertex {v}");
            }
        }
        for (k, source) in projected.sources.iter().enumerate() {
            let q = region.point_position(&lower.mesh, k as u32);
            let d = (q.truncate() - center.truncate()).length() - r;
            assert!(d.abs() < h * h, "boundary point {k}: {d}");
            let (segment, t) = source.expect("every point comes from a crossing");
            let m = chord_match(&outline.chords[segment as usize], t, &upper.side());
            assert!((m.point.truncate() - q.truncate()).length() < 1e-12);
            assert!((m.point.z - 0.5).abs() < 1e-15);
        }
        let (a_disk, a_proj) = (disk.area(&upper.mesh, &upper.topology), region.area(&lower.mesh, &lower.topology));
        let exact = std::f64::consts::PI * r * r;
        assert!((a_disk - exact).abs() < 0.01 * exact && (a_proj - exact).abs() < 0.01 * exact, "{a_disk} {a_proj}");
        // Back-facing target vertices are excluded: the same disk seen by a grid facing away.
        let g_back = vec![1.0; lower.mesh.num_vertices()];
        let none = projected_region(&outline, &lower.mesh, &lower.topology, &g_back, &plane).unwrap();
        assert!(none.region.is_empty());
    }
}
