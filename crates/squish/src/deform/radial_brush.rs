//! The radial brush of the painted bulge map (thesis §5.5.1, "Radial brush", Figures 5.7–5.9):
//! a brush that changes η alike along the profiles, i.e. along ∇u from ∂𝒞 to ∂𝒟, rather than
//! in a disc around the brush centre.
//!
//! **Contract.** [`radial_brush`] takes a mesh (the object at the painted frame), its radial
//! parameter u, contact zone 𝒞 and deformable region 𝒟 per vertex ([`BrushFields`], as
//! [`super::RegionDeformation`] reports them), a brush centre and a radius, and returns the
//! selected region 𝒵 with its parametrization ν and the brush's magnitude per vertex
//! `w(ν) = (1 − (2ν − 1)²)²` ([`radial_falloff`]: 1 halfway between the lateral boundaries, 0 on
//! them, C¹), 0 outside 𝒵. The caller applies `w` to its operation (set, add, subtract, smooth).
//! Errors are one-line messages that say what to do (usually: use the local brush).
//!
//! **Steps** (u is piecewise linear on the faces):
//! 1. The centre is projected on the closest face; u there is the level `c`, which must lie in
//!    (0, 1) (the centre is in 𝒟).
//! 2. The isoline u = c is followed on the faces (a vertex with `u ≥ c` counts as above, so every
//!    face the isoline enters has exactly two crossed edges) both ways until its arc length from
//!    the centre is the radius: two points.
//! 3. From each, a path is traced along +∇u and −∇u, face by face, until it enters a face without
//!    a vertex of 𝒟 (past ∂𝒟, or inside 𝒞) or leaves the mesh; its crossings of edges are the
//!    lateral boundaries ∂𝒵₁ (from the point on the −n×∇u side) and ∂𝒵₂.
//! 4. 𝒵 is the set of vertices of 𝒟 reachable from the centre's isoline faces along edges that
//!    no lateral boundary crosses (a vertex a boundary passes through is on it, not in 𝒵).
//! 5. ν is harmonic on 𝒵 (cotangent stiffness with cut-face weights: faces crossed by a lateral
//!    boundary count by the area on 𝒵's side, App. B) with the least-squares constraints
//!    `(1 − α)ν_i + αν_j = 0` at the points of ∂𝒵₁ and `= 1` at those of ∂𝒵₂ (λ = 100, App. B),
//!    and natural (Neumann) conditions on ∂𝒞 and ∂𝒟.
//!
//! **Decisions** (docs/decisions.md):
//! - The brush's width is the isoline's arc length (a geodesic along the isoline, as the thesis'
//!   Figure 5.7 draws it); an isoline that ends on the mesh's border stops there.
//! - Where u is flat (clamped at 0 next to ∂𝒞) or where the gradients of two faces meet head on,
//!   the path goes straight on (the previous direction unfolded across the edge).
//! - The thesis limits the brush to a single contact zone: the part of 𝒟 ∪ 𝒞 connected to the
//!   centre must hold one connected set of contact vertices, else [`RadialBrushError::SeveralZones`].
//!   Several zones whose deformable regions are apart are fine (each is painted on its own).
//! - A radius below the longest edge of the centre's face, or one whose two ends would meet
//!   around the contact (twice the radius ≥ the isoline's length), is refused, as is a selection
//!   that the lateral boundaries do not close (a path that could not cross 𝒟).

use std::collections::VecDeque;

use glam::DVec3;

use crate::linalg::{EdgeConstraint, EdgePoint, SolveError, cut_face_weights, solve_harmonic};
use crate::mesh::{NO_FACE, SubMesh, Topology, TriMesh};
use crate::spatial::closest_point_on_triangle;

/// The fields of the deformation the radial brush follows, one entry per mesh vertex.
#[derive(Clone, Copy, Debug)]
pub struct BrushFields<'a> {
    /// The radial parameter u (0 in 𝒞, in [0, 1) on 𝒟, ≥ 1 or +∞ beyond).
    pub u: &'a [f64],
    /// The contact zone 𝒞.
    pub contact: &'a [bool],
    /// The deformable region 𝒟.
    pub deformable: &'a [bool],
}

/// A point of a lateral boundary on the mesh edge `(i, j)`: `(1 − alpha)·p_i + alpha·p_j`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LateralPoint {
    pub i: u32,
    pub j: u32,
    pub alpha: f64,
    pub position: DVec3,
}

/// The region a radial brush stroke selects and its magnitude.
#[derive(Clone, Debug)]
pub struct RadialSelection {
    /// The brush centre projected on the surface, its face and its u (the isoline's level).
    pub centre: DVec3,
    pub centre_face: u32,
    pub level: f64,
    /// The ends of the isoline arcs of the brush's radius: on ∂𝒵₁ and ∂𝒵₂.
    pub ends: [DVec3; 2],
    /// The lateral boundaries ∂𝒵₁ (ν = 0) and ∂𝒵₂ (ν = 1), from ∂𝒞 to ∂𝒟.
    pub lateral: [Vec<LateralPoint>; 2],
    /// Per vertex: in 𝒵.
    pub selected: Vec<bool>,
    /// ν per vertex where it was solved (𝒵 and the vertices of its faces), before clamping to
    /// [0, 1]; NaN elsewhere.
    pub nu: Vec<f64>,
    /// The brush's magnitude per vertex: `w(ν)` on 𝒵, 0 elsewhere.
    pub weights: Vec<f64>,
}

/// Why a radial brush stroke cannot be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RadialBrushError {
    #[error("radial brush: {what} has {actual} entries but the mesh has {expected} vertices")]
    LengthMismatch { what: &'static str, expected: usize, actual: usize },
    #[error("radial brush: the centre must be finite and the radius ({radius}) a positive number")]
    InvalidBrush { radius: f64 },
    #[error(
        "radial brush: the object has no deformable region at this frame (no contact); paint at a frame with contact or use the local brush"
    )]
    NoDeformableRegion,
    #[error(
        "radial brush: the brush centre is outside the deformable region 𝒟 (u = {u}); paint where the overlay \"radial parameter u\" shows u between 0 and 1"
    )]
    CentreOutside { u: f64 },
    #[error(
        "radial brush: the deformable region under the brush surrounds {zones} contact zones; the radial brush follows one zone's profiles (thesis §5.5.1): use the local brush"
    )]
    SeveralZones { zones: usize },
    #[error(
        "radial brush: the radius {radius} is below the mesh's edges at the brush centre ({edge}); use a radius of at least {edge}"
    )]
    RadiusBelowEdges { radius: f64, edge: f64 },
    #[error(
        "radial brush: the radius {radius} covers the whole isoline of u around the contact (length {length}); use a radius below {half} or the local brush"
    )]
    RadiusAroundContact { radius: f64, length: f64, half: f64 },
    #[error(
        "radial brush: the path along ∇u from the brush's edge did not cross the deformable region ({reason}); use the local brush"
    )]
    OpenSelection { reason: &'static str },
    #[error("radial brush: the solve of ν failed: {0}")]
    Solve(#[from] SolveError),
}

/// The radial brush's fall-off `w(ν) = (1 − (2ν − 1)²)²` (§5.5.1), ν clamped to [0, 1].
pub fn radial_falloff(nu: f64) -> f64 {
    let x = 2.0 * nu.clamp(0.0, 1.0) - 1.0;
    let t = 1.0 - x * x;
    t * t
}

/// The selected region of a radial brush stroke at `centre` of `radius` (see the module doc).
pub fn radial_brush(
    mesh: &TriMesh,
    topology: &Topology,
    fields: &BrushFields<'_>,
    centre: DVec3,
    radius: f64,
) -> Result<RadialSelection, RadialBrushError> {
    let n = mesh.num_vertices();
    for (what, actual) in [
        ("u", fields.u.len()),
        ("the contact flags", fields.contact.len()),
        ("the deformable flags", fields.deformable.len()),
    ] {
        if actual != n {
            return Err(RadialBrushError::LengthMismatch { what, expected: n, actual });
        }
    }
    if topology.num_vertices() != n || topology.num_faces() != mesh.num_triangles() {
        return Err(RadialBrushError::LengthMismatch {
            what: "the topology",
            expected: n,
            actual: topology.num_vertices(),
        });
    }
    if !(radius.is_finite() && radius > 0.0 && centre.is_finite()) {
        return Err(RadialBrushError::InvalidBrush { radius });
    }
    if !fields.deformable.contains(&true) {
        return Err(RadialBrushError::NoDeformableRegion);
    }
    let walker = Walker { mesh, topology, fields };

    // 1. The centre on the surface and its level.
    let (face, point, level) = walker.project(centre);
    if !(level > 0.0 && level < 1.0) {
        return Err(RadialBrushError::CentreOutside { u: level });
    }
    walker.check_single_zone(face)?;
    let longest = mesh
        .corners(face as usize)
        .iter()
        .enumerate()
        .fold(0.0f64, |m, (k, &a)| m.max(a.distance(mesh.corners(face as usize)[(k + 1) % 3])));
    if radius < longest {
        return Err(RadialBrushError::RadiusBelowEdges { radius, edge: longest });
    }

    // 2. The isoline both ways.
    let gradient = walker.gradient(face);
    let along = walker.normal(face).cross(gradient);
    let whole = walker.isoline(face, point, level, along, f64::INFINITY);
    if whole.closed && 2.0 * radius >= whole.length {
        return Err(RadialBrushError::RadiusAroundContact { radius, length: whole.length, half: whole.length / 2.0 });
    }
    let arcs = [walker.isoline(face, point, level, -along, radius), walker.isoline(face, point, level, along, radius)];

    // 3. The lateral boundaries.
    let mut lateral: [Vec<Crossing>; 2] = [Vec::new(), Vec::new()];
    for (side, arc) in arcs.iter().enumerate() {
        let mut down = walker.trace(arc.end_face, arc.end, -1.0)?;
        let up = walker.trace(arc.end_face, arc.end, 1.0)?;
        down.reverse();
        down.extend(up);
        lateral[side] = down;
    }

    // 4. 𝒵: the vertices of 𝒟 on the centre's side of both boundaries.
    let mut cut = vec![false; topology.num_edges()];
    let mut on_boundary = vec![false; n];
    for c in lateral.iter().flatten() {
        cut[c.edge as usize] = true;
        if let Some(v) = c.through {
            on_boundary[v as usize] = true;
        }
    }
    let open = |v: u32| fields.deformable[v as usize] && !on_boundary[v as usize];
    let mut selected = vec![false; n];
    let mut queue = VecDeque::new();
    for arc in &arcs {
        for &(f, at) in &arc.faces {
            if at < radius / 2.0 {
                for v in mesh.triangles[f as usize] {
                    if open(v) && !selected[v as usize] {
                        selected[v as usize] = true;
                        queue.push_back(v);
                    }
                }
            }
        }
    }
    while let Some(v) = queue.pop_front() {
        for &e in topology.vertex_edges(v) {
            let w = topology.other_vertex(e, v);
            if !cut[e as usize] && open(w) && !selected[w as usize] {
                selected[w as usize] = true;
                queue.push_back(w);
            }
        }
    }
    // A boundary that does not close the region lets the selection around it: both ends of one
    // of its edges are then selected.
    if lateral.iter().flatten().any(|c| {
        let [a, b] = topology.edge(c.edge);
        selected[a as usize] && selected[b as usize]
    }) {
        return Err(RadialBrushError::OpenSelection { reason: "the lateral boundaries do not close the selection" });
    }

    // 5. ν and the magnitude.
    let nu = solve_nu(mesh, topology, &selected, &lateral)?;
    let weights = selected.iter().zip(&nu).map(|(&s, &v)| if s { radial_falloff(v) } else { 0.0 }).collect();
    let as_points = |cs: &[Crossing]| {
        cs.iter()
            .map(|c| {
                let [i, j] = topology.edge(c.edge);
                LateralPoint { i, j, alpha: c.alpha, position: c.position }
            })
            .collect()
    };
    Ok(RadialSelection {
        centre: point,
        centre_face: face,
        level,
        ends: [arcs[0].end, arcs[1].end],
        lateral: [as_points(&lateral[0]), as_points(&lateral[1])],
        selected,
        nu,
        weights,
    })
}

/// ν: harmonic on 𝒵 with ν = 0 on the first lateral boundary and 1 on the second (module doc,
/// step 5), on the faces that touch 𝒵.
fn solve_nu(
    mesh: &TriMesh,
    topology: &Topology,
    selected: &[bool],
    lateral: &[Vec<Crossing>; 2],
) -> Result<Vec<f64>, RadialBrushError> {
    let faces =
        (0..mesh.num_triangles() as u32).filter(|&f| mesh.triangles[f as usize].iter().any(|&v| selected[v as usize]));
    let sub = SubMesh::from_faces(mesh, faces);
    let local_topology = Topology::new(&sub.mesh);
    let removed: Vec<bool> = sub.parent_vertex.iter().map(|&v| !selected[v as usize]).collect();
    let mut points = Vec::new();
    let mut constraints = Vec::new();
    let mut pointed = vec![false; topology.num_edges()];
    for (value, boundary) in [0.0, 1.0].into_iter().zip(lateral) {
        for c in boundary {
            let [a, b] = topology.edge(c.edge);
            let (sa, sb) = (selected[a as usize], selected[b as usize]);
            if !(sa || sb) {
                continue;
            }
            let (la, lb) = (sub.local_vertex[a as usize], sub.local_vertex[b as usize]);
            constraints.push(EdgeConstraint::on_edge(la, lb, c.alpha, value));
            if sa != sb && !pointed[c.edge as usize] {
                pointed[c.edge as usize] = true;
                // α from the removed (unselected) end.
                points.push(if sb {
                    EdgePoint { inside: la, outside: lb, alpha: c.alpha }
                } else {
                    EdgePoint { inside: lb, outside: la, alpha: 1.0 - c.alpha }
                });
            }
        }
    }
    let weights = cut_face_weights(&sub.mesh, &local_topology, &removed, &points)?;
    let local = solve_harmonic(&sub.mesh, &local_topology, Some(&weights), &constraints, 0.5)?;
    let mut nu = vec![f64::NAN; mesh.num_vertices()];
    sub.scatter(&local, &mut nu);
    Ok(nu)
}

/// How far the projected brush centre is moved towards its face's centroid (barycentric).
const INSIDE_NUDGE: f64 = 1e-8;

/// A path crossing an edge within this fraction of an end passes through that vertex.
const THROUGH_VERTEX: f64 = 1e-9;

/// A crossing of a traced path with a mesh edge: `(1 − alpha)·p_lo + alpha·p_hi` on `edge`.
#[derive(Clone, Copy, Debug)]
struct Crossing {
    edge: u32,
    alpha: f64,
    position: DVec3,
    /// The vertex the path passes through, if it crosses the edge at an end (the vertex is then
    /// on the boundary: it joins both sides, so it is left out of 𝒵).
    through: Option<u32>,
}

/// A walk along an isoline of u.
struct Isoline {
    /// The faces visited and the arc length from the centre where the walk entered each.
    faces: Vec<(u32, f64)>,
    end: DVec3,
    end_face: u32,
    length: f64,
    /// True if the walk came back to its first face (the isoline is a loop of `length`).
    closed: bool,
}

struct Walker<'a> {
    mesh: &'a TriMesh,
    topology: &'a Topology,
    fields: &'a BrushFields<'a>,
}

impl Walker<'_> {
    fn corners(&self, f: u32) -> [DVec3; 3] {
        self.mesh.corners(f as usize)
    }

    fn normal(&self, f: u32) -> DVec3 {
        let [a, b, c] = self.corners(f);
        (b - a).cross(c - a).normalize_or_zero()
    }

    fn values(&self, f: u32) -> [f64; 3] {
        self.mesh.triangles[f as usize].map(|v| self.fields.u[v as usize])
    }

    /// True if face `f` has a vertex of 𝒟 (the band the paths cross).
    fn in_band(&self, f: u32) -> bool {
        self.mesh.triangles[f as usize].iter().any(|&v| self.fields.deformable[v as usize])
    }

    /// ∇u on face `f` (zero if a value is not finite or the face is degenerate).
    fn gradient(&self, f: u32) -> DVec3 {
        let [a, b, c] = self.corners(f);
        let u = self.values(f);
        if !u.iter().all(|x| x.is_finite()) {
            return DVec3::ZERO;
        }
        let area2 = (b - a).cross(c - a);
        let double_area = area2.length();
        if double_area <= 0.0 {
            return DVec3::ZERO;
        }
        let n = area2 / double_area;
        (u[0] * n.cross(c - b) + u[1] * n.cross(a - c) + u[2] * n.cross(b - a)) / double_area
    }

    /// The closest point of the surface to `p`: its face (smallest id among ties), the point and
    /// u there (+∞ if a corner's u is not finite).
    fn project(&self, p: DVec3) -> (u32, DVec3, f64) {
        let mut best = (0u32, DVec3::ZERO, [0.0; 3], f64::INFINITY);
        for f in 0..self.mesh.num_triangles() as u32 {
            let t = self.corners(f);
            let bary = closest_point_on_triangle(p, &t);
            let q = bary[0] * t[0] + bary[1] * t[1] + bary[2] * t[2];
            let d = q.distance_squared(p);
            if d < best.3 {
                best = (f, q, bary, d);
            }
        }
        let (f, _, bary, _) = best;
        // A hair inside the face, so that the isoline through the point is a segment of this
        // face even when the point is a vertex or on an edge.
        let bary = bary.map(|b| (1.0 - INSIDE_NUDGE) * b + INSIDE_NUDGE / 3.0);
        let t = self.corners(f);
        let q = bary[0] * t[0] + bary[1] * t[1] + bary[2] * t[2];
        let u = self.values(f);
        let level = if u.iter().all(|x| x.is_finite()) {
            bary[0] * u[0] + bary[1] * u[1] + bary[2] * u[2]
        } else {
            f64::INFINITY
        };
        (f, q, level)
    }

    /// The part of 𝒟 ∪ 𝒞 connected to face `f` must hold one connected set of contact vertices.
    fn check_single_zone(&self, f: u32) -> Result<(), RadialBrushError> {
        let fields = self.fields;
        let n = fields.u.len();
        let in_region = |v: u32| fields.deformable[v as usize] || fields.contact[v as usize];
        let mut seen = vec![false; n];
        let mut queue: VecDeque<u32> =
            self.mesh.triangles[f as usize].iter().copied().filter(|&v| in_region(v)).collect();
        for &v in &queue {
            seen[v as usize] = true;
        }
        let mut zone_of = vec![u32::MAX; n];
        let mut zones = 0;
        while let Some(v) = queue.pop_front() {
            if fields.contact[v as usize] && zone_of[v as usize] == u32::MAX {
                // A new zone: flood its contact vertices.
                let mut zone = vec![v];
                zone_of[v as usize] = zones;
                while let Some(c) = zone.pop() {
                    for w in self.topology.vertex_neighbors(c) {
                        if fields.contact[w as usize] && zone_of[w as usize] == u32::MAX {
                            zone_of[w as usize] = zones;
                            zone.push(w);
                        }
                    }
                }
                zones += 1;
            }
            for w in self.topology.vertex_neighbors(v) {
                if in_region(w) && !seen[w as usize] {
                    seen[w as usize] = true;
                    queue.push_back(w);
                }
            }
        }
        if zones > 1 { Err(RadialBrushError::SeveralZones { zones: zones as usize }) } else { Ok(()) }
    }

    /// The crossing of the isoline u = `level` with the edge `k` of face `f` (corners k, k + 1),
    /// if the edge straddles it (`u ≥ level` counts as above): the point and α from corner k.
    fn level_crossing(&self, f: u32, k: usize, level: f64) -> Option<(DVec3, f64)> {
        let tri = self.mesh.triangles[f as usize];
        let (a, b) = (tri[k] as usize, tri[(k + 1) % 3] as usize);
        let (ua, ub) = (self.fields.u[a], self.fields.u[b]);
        if (ua >= level) == (ub >= level) {
            return None;
        }
        let alpha = if ub.is_finite() && ua.is_finite() { ((level - ua) / (ub - ua)).clamp(0.0, 1.0) } else { 0.0 };
        let alpha = if ua.is_finite() { alpha } else { 1.0 };
        Some((self.mesh.positions[a].lerp(self.mesh.positions[b], alpha), alpha))
    }

    /// Walks the isoline u = `level` from `start` in face `first`, leaving the face on the side
    /// of `toward`, until the arc length is `max_length`, the mesh's border or the first face.
    fn isoline(&self, first: u32, start: DVec3, level: f64, toward: DVec3, max_length: f64) -> Isoline {
        let mut walk = Isoline { faces: vec![(first, 0.0)], end: start, end_face: first, length: 0.0, closed: false };
        let crossings: Vec<(usize, DVec3)> =
            (0..3).filter_map(|k| self.level_crossing(first, k, level).map(|(p, _)| (k, p))).collect();
        let Some(&(mut exit_k, mut exit)) =
            crossings.iter().max_by(|a, b| (a.1 - start).dot(toward).total_cmp(&(b.1 - start).dot(toward)))
        else {
            return walk;
        };
        let back = crossings.iter().find(|c| c.0 != exit_k).map(|c| c.1);
        let (mut face, mut from) = (first, start);
        for _ in 0..=self.mesh.num_triangles() {
            let step = from.distance(exit);
            if walk.length + step >= max_length {
                let t = if step > 0.0 { (max_length - walk.length) / step } else { 0.0 };
                walk.end = from.lerp(exit, t);
                walk.end_face = face;
                walk.length = max_length;
                return walk;
            }
            walk.length += step;
            walk.end = exit;
            walk.end_face = face;
            let edge = self.topology.face_edges(face)[exit_k];
            let next = self.other_face(edge, face);
            if next == NO_FACE {
                return walk;
            }
            if next == first {
                walk.closed = true;
                walk.length += back.map_or(0.0, |b| b.distance(start));
                return walk;
            }
            let Some((k, q)) = (0..3)
                .filter(|&k| self.topology.face_edges(next)[k] != edge)
                .find_map(|k| self.level_crossing(next, k, level).map(|(p, _)| (k, p)))
            else {
                return walk;
            };
            walk.faces.push((next, walk.length));
            (face, from, exit_k, exit) = (next, exit, k, q);
        }
        walk
    }

    fn other_face(&self, edge: u32, face: u32) -> u32 {
        let [a, b] = self.topology.edge_faces(edge);
        if a == face { b } else { a }
    }

    /// The path along `sign`·∇u from `start` in face `first` until it enters a face outside the
    /// band or leaves the mesh: its edge crossings in order.
    fn trace(&self, first: u32, start: DVec3, sign: f64) -> Result<Vec<Crossing>, RadialBrushError> {
        let mut crossings = Vec::new();
        let (mut face, mut p) = (first, start);
        let mut entry: Option<usize> = None;
        let mut previous: Option<DVec3> = None;
        let limit = self.mesh.num_triangles() + 8;
        for _ in 0..limit {
            let n = self.normal(face);
            let corners = self.corners(face);
            // The gradient's way, unless it is flat or leads straight back through the entry edge.
            let g = sign * self.gradient(face);
            let mut d = g.normalize_or_zero();
            if let (Some(k), Some(prev)) = (entry, previous) {
                let inward = inward_normal(&corners, k, n);
                if d == DVec3::ZERO || d.dot(inward) <= 0.0 {
                    d = prev;
                }
            }
            if d == DVec3::ZERO {
                return Err(RadialBrushError::OpenSelection { reason: "u is flat at the brush's edge" });
            }
            let Some((k, t)) = exit_edge(&corners, n, p, d, entry) else {
                return Err(RadialBrushError::OpenSelection { reason: "a path could not leave a face" });
            };
            let tri = self.mesh.triangles[face as usize];
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let q = corners[k].lerp(corners[(k + 1) % 3], t);
            let edge = self.topology.face_edges(face)[k];
            // α along the edge from its lower vertex id.
            let alpha = if a < b { t } else { 1.0 - t };
            let through = if t <= THROUGH_VERTEX {
                Some(a)
            } else if t >= 1.0 - THROUGH_VERTEX {
                Some(b)
            } else {
                None
            };
            crossings.push(Crossing { edge, alpha, position: q, through });
            let next = self.other_face(edge, face);
            if next == NO_FACE || !self.in_band(next) {
                return Ok(crossings);
            }
            // The direction unfolded across the edge into the next face.
            let along = (corners[(k + 1) % 3] - corners[k]).normalize_or_zero();
            let out = -inward_normal(&corners, k, n);
            let next_corners = self.corners(next);
            let next_k = (0..3).find(|&j| self.topology.face_edges(next)[j] == edge).unwrap_or(0);
            let next_in = inward_normal(&next_corners, next_k, self.normal(next));
            previous = Some((d.dot(along) * along + d.dot(out) * next_in).normalize_or_zero());
            (face, p, entry) = (next, q, Some(next_k));
        }
        Err(RadialBrushError::OpenSelection { reason: "the path did not reach ∂𝒞 and ∂𝒟" })
    }
}

/// The unit in-plane normal of edge `k` (corners k, k + 1) of a face pointing into the face.
fn inward_normal(corners: &[DVec3; 3], k: usize, n: DVec3) -> DVec3 {
    let (a, b, opposite) = (corners[k], corners[(k + 1) % 3], corners[(k + 2) % 3]);
    let m = n.cross(b - a).normalize_or_zero();
    if m.dot(opposite - a) >= 0.0 { m } else { -m }
}

/// Where the ray `p + s·d` (in the face's plane) leaves the face: the edge `k` (not `entry`) and
/// the position `t` along it from corner k. Of the edges the ray meets within their ends, the
/// farthest (a ray through a corner leaves by the edge across, not the one at the corner).
fn exit_edge(corners: &[DVec3; 3], n: DVec3, p: DVec3, d: DVec3, entry: Option<usize>) -> Option<(usize, f64)> {
    const SLACK: f64 = 1e-9;
    let mut best: Option<(usize, f64, f64)> = None;
    for k in 0..3 {
        if Some(k) == entry {
            continue;
        }
        let (a, b) = (corners[k], corners[(k + 1) % 3]);
        let e = b - a;
        let denominator = d.cross(e).dot(n);
        if denominator == 0.0 {
            continue;
        }
        let s = (a - p).cross(e).dot(n) / denominator;
        let t = (a - p).cross(d).dot(n) / denominator;
        let scale = e.length().max(f64::MIN_POSITIVE);
        if s >= -SLACK * scale && (-SLACK..=1.0 + SLACK).contains(&t) && best.is_none_or(|(_, bs, _)| s > bs) {
            best = Some((k, s, t.clamp(0.0, 1.0)));
        }
    }
    best.map(|(k, _, t)| (k, t))
}

#[cfg(test)]
#[path = "radial_brush_tests.rs"]
mod tests;
