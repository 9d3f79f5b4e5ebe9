//! Regions of a mesh bounded by exact points on its edges.
//!
//! The thesis defines every region that must evolve continuously over an animation — the
//! intersection regions ℐ (§4.1), the front-facing regions ℬ and mapping regions ℳ (§4.2.2), the
//! contact zones 𝒞 (§4.4) — not on vertices but by a boundary that crosses mesh edges at exact
//! points. An [`EdgeRegion`] stores exactly that: which vertices are inside, and for every edge
//! joining an inside vertex `i` to an outside vertex `j` one boundary point
//! `(1 − α)·p_i + α·p_j` (α measured from the inside end, so α → 0 when the boundary reaches the
//! inside vertex and α → 1 when it reaches the outside one).
//!
//! Within a face the boundary is the straight segment joining the points of its two mixed edges,
//! so the part of a face inside the region is the polygon of its inside corners and boundary
//! points (a triangle or a quad). [`EdgeRegion::pieces`] enumerates these polygons and
//! [`EdgeRegion::integrate`] integrates fields over them with the degree-2 edge-midpoint rule of
//! Appendix A (see `THESIS-NOTES.md` item 1: on a triangle of area A, ∫f ≈ A/3 Σ_k f(m_k) with m_k
//! the edge midpoints; quads are split into two triangles). Because boundary points move
//! continuously with the geometry, so do areas and integrals over the region.
//!
//! Set operations ([`EdgeRegion::intersection`], [`EdgeRegion::union`],
//! [`EdgeRegion::complement`]) keep the edge-point representation, which is how ℬ = ℐ ∩ {front
//! facing} and ℳ = 𝒫(ℬ′) ∪ ℬ are formed.

use std::ops::{Add, Mul};
use std::sync::OnceLock;

use glam::DVec3;

use crate::linalg::EdgePoint;
use crate::mesh::{Topology, TriMesh};

/// Marks an edge without boundary point.
const NO_POINT: u32 = u32::MAX;

/// [`EdgeRegion::from_inside`] finds the boundary edges from the inside vertices' edges when
/// fewer than one vertex in this many is inside, else by scanning every edge of the mesh (the
/// break-even point, measured: `docs/speed.md`).
const SPARSE_REGION_FRACTION: usize = 8;

/// A corner of a region piece: a mesh vertex inside the region, or one of its boundary points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sample {
    /// An inside vertex (its id).
    Vertex(u32),
    /// A boundary point (its index in [`EdgeRegion::points`]).
    Point(u32),
}

/// A region of a mesh: inside vertices plus one exact boundary point per edge leaving it.
#[derive(Clone, Debug, Default)]
pub struct EdgeRegion {
    inside: Vec<bool>,
    /// Boundary points, in increasing edge id.
    points: Vec<EdgePoint>,
    /// The edge of each boundary point.
    point_edges: Vec<u32>,
    /// For each edge, the index of its boundary point or [`NO_POINT`].
    edge_points: Vec<u32>,
    /// The faces with an inside vertex, increasing, found by the first [`Self::pieces`]: a
    /// region is integrated several times per frame (the criterion's mean and spread, the
    /// typical penetration, the normal statistics), and the scan over every face of the mesh
    /// was most of each pass on a large mesh with a small region.
    touched_faces: OnceLock<Vec<u32>>,
}

/// Regions are equal when their vertices and boundary points are (the face cache is derived).
impl PartialEq for EdgeRegion {
    fn eq(&self, other: &Self) -> bool {
        self.inside == other.inside
            && self.points == other.points
            && self.point_edges == other.point_edges
            && self.edge_points == other.edge_points
    }
}

/// The edges joining an inside vertex to an outside one, in increasing edge id (the order of a
/// region's boundary points). A small region of a large mesh (a contact on a palm, a ground, a
/// body; fewer than 1/[`SPARSE_REGION_FRACTION`] of the vertices inside) finds them among its
/// vertices' edges, each once from its inside end, and sorts them; a larger one scans every edge.
pub(crate) fn crossing_edges(topology: &Topology, inside: &[bool]) -> Vec<u32> {
    let edges = topology.edges();
    let crossing = |[a, b]: [u32; 2]| inside[a as usize] != inside[b as usize];
    let count = inside.iter().filter(|&&x| x).count();
    if count * SPARSE_REGION_FRACTION < inside.len() {
        let mut mixed: Vec<u32> = (0..inside.len() as u32)
            .filter(|&v| inside[v as usize])
            .flat_map(|v| topology.vertex_edges(v).iter().copied())
            .filter(|&e| crossing(edges[e as usize]))
            .collect();
        mixed.sort_unstable();
        mixed
    } else {
        (0..edges.len() as u32).filter(|&e| crossing(edges[e as usize])).collect()
    }
}

impl EdgeRegion {
    /// The empty region of a mesh.
    pub fn empty(topology: &Topology) -> Self {
        Self {
            inside: vec![false; topology.num_vertices()],
            points: Vec::new(),
            point_edges: Vec::new(),
            edge_points: vec![NO_POINT; topology.num_edges()],
            touched_faces: OnceLock::new(),
        }
    }

    /// A region from inside flags and a rule giving the boundary parameter α on every edge
    /// that joins an inside vertex to an outside one: `alpha(edge, inside_vertex, outside_vertex)`,
    /// called once per such edge in increasing edge id. α is clamped to [0, 1]; a non-finite α is
    /// replaced by 0.5.
    pub fn from_inside(topology: &Topology, inside: Vec<bool>, alpha: impl FnMut(u32, u32, u32) -> f64) -> Self {
        let crossing = crossing_edges(topology, &inside);
        Self::from_crossing_edges(topology, inside, &crossing, alpha)
    }

    /// [`Self::from_inside`] for a caller that already has [`crossing_edges`]`(topology, &inside)`
    /// (it needed them to compute the α's).
    pub(crate) fn from_crossing_edges(
        topology: &Topology,
        inside: Vec<bool>,
        crossing: &[u32],
        mut alpha: impl FnMut(u32, u32, u32) -> f64,
    ) -> Self {
        debug_assert_eq!(inside.len(), topology.num_vertices());
        debug_assert_eq!(crossing, crossing_edges(topology, &inside));
        let mut region = Self {
            inside,
            points: Vec::new(),
            point_edges: Vec::new(),
            edge_points: vec![NO_POINT; topology.num_edges()],
            touched_faces: OnceLock::new(),
        };
        let mut add = |region: &mut Self, e: u32, [a, b]: [u32; 2]| {
            let (i, j) = if region.inside[a as usize] { (a, b) } else { (b, a) };
            let raw = alpha(e, i, j);
            let alpha = if raw.is_finite() { raw.clamp(0.0, 1.0) } else { 0.5 };
            region.edge_points[e as usize] = region.points.len() as u32;
            region.points.push(EdgePoint { inside: i, outside: j, alpha });
            region.point_edges.push(e);
        };
        let edges = topology.edges();
        for &e in crossing {
            add(&mut region, e, edges[e as usize]);
        }
        region
    }

    /// The sub-level set {f ≤ 0} of a piecewise-linear vertex function, bounded by the exact
    /// zero crossings t = f_i / (f_i − f_j) (the interpolated contours of Hertzmann and Zorin
    /// used for front-facing regions, §4.2.2).
    pub fn sublevel_set(topology: &Topology, values: &[f64]) -> Self {
        let inside = values.iter().map(|&f| f <= 0.0).collect();
        Self::from_inside(topology, inside, |_, i, j| {
            let (fi, fj) = (values[i as usize], values[j as usize]);
            fi / (fi - fj)
        })
    }

    /// Inside flags per vertex.
    pub fn inside(&self) -> &[bool] {
        &self.inside
    }

    /// True if vertex `v` is inside.
    #[inline]
    pub fn contains(&self, v: u32) -> bool {
        self.inside[v as usize]
    }

    /// Number of inside vertices.
    pub fn num_inside(&self) -> usize {
        self.inside.iter().filter(|&&x| x).count()
    }

    /// True if no vertex is inside (the region then has no area: a boundary needs an inside end).
    pub fn is_empty(&self) -> bool {
        !self.inside.iter().any(|&x| x)
    }

    /// Boundary points, in increasing edge id.
    pub fn points(&self) -> &[EdgePoint] {
        &self.points
    }

    /// The edge carrying each boundary point.
    pub fn point_edges(&self) -> &[u32] {
        &self.point_edges
    }

    /// The index of the boundary point on edge `e`, if it is a boundary edge of the region.
    #[inline]
    pub fn point_on_edge(&self, e: u32) -> Option<u32> {
        let p = self.edge_points[e as usize];
        (p != NO_POINT).then_some(p)
    }

    /// Position of a boundary point on the mesh.
    #[inline]
    pub fn point_position(&self, mesh: &TriMesh, point: u32) -> DVec3 {
        let p = self.points[point as usize];
        mesh.positions[p.inside as usize].lerp(mesh.positions[p.outside as usize], p.alpha)
    }

    /// Position of a sample on the mesh.
    #[inline]
    pub fn sample_position(&self, mesh: &TriMesh, sample: Sample) -> DVec3 {
        match sample {
            Sample::Vertex(v) => mesh.positions[v as usize],
            Sample::Point(p) => self.point_position(mesh, p),
        }
    }

    /// Linear interpolation of a vertex attribute at a sample.
    #[inline]
    pub fn interpolate<T>(&self, values: &[T], sample: Sample) -> T
    where
        T: Copy + Add<Output = T> + Mul<f64, Output = T>,
    {
        match sample {
            Sample::Vertex(v) => values[v as usize],
            Sample::Point(p) => {
                let p = self.points[p as usize];
                values[p.inside as usize] * (1.0 - p.alpha) + values[p.outside as usize] * p.alpha
            }
        }
    }

    /// The region's complement: outside vertices become inside and every boundary point is kept,
    /// re-expressed from its new inside end (α ↦ 1 − α). The complement of the complement is the
    /// region itself.
    pub fn complement(&self) -> Self {
        Self {
            inside: self.inside.iter().map(|&x| !x).collect(),
            points: self
                .points
                .iter()
                .map(|p| EdgePoint { inside: p.outside, outside: p.inside, alpha: 1.0 - p.alpha })
                .collect(),
            point_edges: self.point_edges.clone(),
            edge_points: self.edge_points.clone(),
            touched_faces: OnceLock::new(),
        }
    }

    /// Boundary parameter of edge `e` seen from vertex `from`, which must be inside: how far the
    /// region extends along the edge (1 when the other end is inside too).
    fn extent_from(&self, e: u32, from: u32) -> f64 {
        match self.point_on_edge(e) {
            Some(p) => {
                let p = self.points[p as usize];
                debug_assert_eq!(p.inside, from);
                p.alpha
            }
            None => 1.0,
        }
    }

    /// Intersection of two regions of the same mesh: vertices inside both; on an edge leaving
    /// the intersection, the boundary point is the nearer of the two regions' limits.
    /// (An edge whose ends are both inside is taken as fully inside, even if each region covers
    /// only part of it from opposite ends.)
    pub fn intersection(&self, other: &Self, topology: &Topology) -> Self {
        let inside = self.inside.iter().zip(&other.inside).map(|(&a, &b)| a && b).collect();
        Self::from_inside(topology, inside, |e, i, _| self.extent_from(e, i).min(other.extent_from(e, i)))
    }

    /// Union of two regions of the same mesh: vertices inside either; on an edge leaving the
    /// union, the boundary point is the farther of the limits of the regions holding its inside
    /// end.
    pub fn union(&self, other: &Self, topology: &Topology) -> Self {
        let inside = self.inside.iter().zip(&other.inside).map(|(&a, &b)| a || b).collect();
        Self::from_inside(topology, inside, |e, i, _| {
            let a = if self.contains(i) { self.extent_from(e, i) } else { 0.0 };
            let b = if other.contains(i) { other.extent_from(e, i) } else { 0.0 };
            a.max(b)
        })
    }

    /// Calls `f(face, polygon)` for every face with a part inside the region, with the polygon
    /// of that part (3 or 4 samples, in the face's counter-clockwise order).
    pub fn pieces(&self, mesh: &TriMesh, topology: &Topology, mut f: impl FnMut(u32, &[Sample])) {
        let mut polygon = [Sample::Vertex(0); 4];
        // The region belongs to one connectivity (its edges index `topology`'s).
        debug_assert_eq!(mesh.triangles.len(), topology.num_faces());
        let faces = self.touched_faces.get_or_init(|| {
            (0..mesh.triangles.len() as u32)
                .filter(|&f| mesh.triangles[f as usize].iter().any(|&v| self.inside[v as usize]))
                .collect()
        });
        for &face in faces {
            let tri = &mesh.triangles[face as usize];
            let edges = topology.face_edges(face);
            let mut len = 0;
            for k in 0..3 {
                if self.inside[tri[k] as usize] {
                    polygon[len] = Sample::Vertex(tri[k]);
                    len += 1;
                }
                if let Some(p) = self.point_on_edge(edges[k])
                    && len < 4
                {
                    polygon[len] = Sample::Point(p);
                    len += 1;
                }
            }
            if len >= 3 {
                f(face, &polygon[..len]);
            }
        }
    }

    /// Calls `f(face, [s0, s1, s2])` for every triangle of the region's pieces (quads split along
    /// their first diagonal).
    pub fn triangles(&self, mesh: &TriMesh, topology: &Topology, mut f: impl FnMut(u32, [Sample; 3])) {
        self.pieces(mesh, topology, |face, poly| {
            for k in 1..poly.len() - 1 {
                f(face, [poly[0], poly[k], poly[k + 1]]);
            }
        });
    }

    /// Area of the region on the mesh.
    pub fn area(&self, mesh: &TriMesh, topology: &Topology) -> f64 {
        let mut area = 0.0;
        self.triangles(mesh, topology, |_, [a, b, c]| {
            let (pa, pb, pc) =
                (self.sample_position(mesh, a), self.sample_position(mesh, b), self.sample_position(mesh, c));
            area += 0.5 * (pb - pa).cross(pc - pa).length();
        });
        area
    }

    /// Area of the region measured on displaced positions: `position(sample)` gives where each
    /// sample goes (e.g. its point on the contact surface 𝒮).
    pub fn area_with(&self, mesh: &TriMesh, topology: &Topology, position: impl Fn(Sample) -> DVec3) -> f64 {
        let mut area = 0.0;
        self.triangles(mesh, topology, |_, [a, b, c]| {
            let (pa, pb, pc) = (position(a), position(b), position(c));
            area += 0.5 * (pb - pa).cross(pc - pa).length();
        });
        area
    }

    /// ∫ integrand(field) over the region with the degree-2 edge-midpoint rule (App. A): each
    /// piece triangle of area A contributes A/3 Σ_k integrand((field(a_k) + field(b_k))/2) over its
    /// three edges. `field` gives the value at every sample (linear inside a piece triangle).
    /// Returns (area, integral). Exact for integrands quadratic in a linear field.
    pub fn integrate<V, R>(
        &self,
        mesh: &TriMesh,
        topology: &Topology,
        field: impl Fn(Sample) -> V,
        integrand: impl Fn(V) -> R,
    ) -> (f64, R)
    where
        V: Copy + Add<Output = V> + Mul<f64, Output = V>,
        R: Default + Add<Output = R> + Mul<f64, Output = R>,
    {
        let mut area = 0.0;
        let mut total = R::default();
        self.triangles(mesh, topology, |_, samples| {
            let [pa, pb, pc] = samples.map(|s| self.sample_position(mesh, s));
            let a = 0.5 * (pb - pa).cross(pc - pa).length();
            if a == 0.0 {
                return;
            }
            let v = samples.map(&field);
            let mut sum = R::default();
            for k in 0..3 {
                sum = sum + integrand((v[k] + v[(k + 1) % 3]) * 0.5);
            }
            area += a;
            total = std::mem::take(&mut total) + sum * (a / 3.0);
        });
        (area, total)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes;

    fn grid() -> (TriMesh, Topology) {
        let mesh = shapes::grid(2.0, 2.0, 20, 20);
        let topo = Topology::new(&mesh);
        (mesh, topo)
    }

    /// Disc of radius r around the origin as the sub-level set of |p| − r.
    fn disc(mesh: &TriMesh, topo: &Topology, r: f64, center: DVec3) -> EdgeRegion {
        let f: Vec<f64> = mesh.positions.iter().map(|p| (*p - center).length() - r).collect();
        EdgeRegion::sublevel_set(topo, &f)
    }

    #[test]
    fn small_and_large_regions_find_the_same_boundary_in_edge_order() {
        // Discs of every size on a sphere (few inside vertices: from the vertices' edges; many:
        // the scan of all edges), against the scan done here: the same points, in the same
        // order, and `alpha` called once per boundary edge in increasing edge id.
        let mesh = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&mesh);
        for radius in [0.0, 0.05, 0.3, 0.8, 1.2, 1.9, 2.5] {
            let inside: Vec<bool> = mesh.positions.iter().map(|p| (*p - DVec3::Z).length() < radius).collect();
            let mut calls = Vec::new();
            let region = EdgeRegion::from_inside(&topology, inside.clone(), |e, i, j| {
                calls.push((e, i, j));
                0.25 + 0.5 * ((e % 5) as f64 / 5.0)
            });
            let expected: Vec<(u32, u32, u32)> = topology
                .edges()
                .iter()
                .enumerate()
                .filter(|(_, [a, b])| inside[*a as usize] != inside[*b as usize])
                .map(|(e, &[a, b])| if inside[a as usize] { (e as u32, a, b) } else { (e as u32, b, a) })
                .collect();
            assert_eq!(calls, expected, "radius {radius}");
            assert_eq!(region.point_edges(), expected.iter().map(|c| c.0).collect::<Vec<_>>());
            for (k, &(e, i, j)) in expected.iter().enumerate() {
                assert_eq!(region.point_on_edge(e), Some(k as u32));
                let p = region.points()[k];
                assert_eq!((p.inside, p.outside), (i, j));
                assert_eq!(p.alpha, 0.25 + 0.5 * ((e % 5) as f64 / 5.0));
            }
            let on_edges = (0..topology.num_edges() as u32).filter(|&e| region.point_on_edge(e).is_some()).count();
            assert_eq!(on_edges, expected.len());
        }
    }

    #[test]
    fn disc_area_approaches_pi_r_squared() {
        let (mesh, topo) = grid();
        let r = 0.6;
        let region = disc(&mesh, &topo, r, DVec3::ZERO);
        let area = region.area(&mesh, &topo);
        let exact = std::f64::consts::PI * r * r;
        // Inscribed polygon through points on the circle: slightly less than the disc.
        assert!(area < exact && area > 0.99 * exact, "{area} vs {exact}");
        for p in 0..region.points().len() as u32 {
            let q = region.point_position(&mesh, p);
            // Boundary points interpolate the distance linearly along an edge: within chord error.
            assert!((q.length() - r).abs() < 5e-3, "{}", q.length());
        }
    }

    #[test]
    fn region_and_complement_partition_the_area() {
        let (mesh, topo) = grid();
        let region = disc(&mesh, &topo, 0.55, DVec3::new(0.13, -0.07, 0.0));
        let complement = region.complement();
        let total = region.area(&mesh, &topo) + complement.area(&mesh, &topo);
        assert!((total - 4.0).abs() < 1e-12, "{total}");
        let back = complement.complement();
        assert_eq!(back.inside(), region.inside());
        for (p, q) in back.points().iter().zip(region.points()) {
            assert_eq!((p.inside, p.outside), (q.inside, q.outside));
            assert!((p.alpha - q.alpha).abs() < 1e-15);
        }
    }

    #[test]
    fn area_is_continuous_when_the_boundary_crosses_vertices() {
        // Slide a disc across the grid in steps much smaller than an edge: boundary points cross
        // vertices many times, the area must change by at most a constant times the step.
        let (mesh, topo) = grid();
        let step = 1e-4;
        let mut previous = None;
        let mut crossings = 0;
        let mut previous_inside = None;
        for k in 0..1000 {
            let center = DVec3::new(k as f64 * step, 0.3 * k as f64 * step, 0.0);
            let region = disc(&mesh, &topo, 0.5, center);
            let area = region.area(&mesh, &topo);
            if let Some(prev) = previous {
                let change: f64 = area - prev;
                // Moving a convex region by `step` changes its area by at most perimeter × step.
                assert!(change.abs() <= 4.0 * step, "step {k}: area jumped by {change}");
            }
            if previous_inside.is_some_and(|n| n != region.num_inside()) {
                crossings += 1;
            }
            previous = Some(area);
            previous_inside = Some(region.num_inside());
        }
        assert!(crossings >= 10, "the sweep must make the boundary cross vertices ({crossings})");
    }

    #[test]
    fn intersection_and_union_of_discs() {
        let (mesh, topo) = grid();
        let a = disc(&mesh, &topo, 0.5, DVec3::new(-0.2, 0.0, 0.0));
        let b = disc(&mesh, &topo, 0.5, DVec3::new(0.2, 0.0, 0.0));
        let (area_a, area_b) = (a.area(&mesh, &topo), b.area(&mesh, &topo));
        let inter = a.intersection(&b, &topo).area(&mesh, &topo);
        let union = a.union(&b, &topo).area(&mesh, &topo);
        // Inclusion–exclusion holds up to the discretization of the lens corners.
        assert!((area_a + area_b - inter - union).abs() < 0.01, "{area_a} {area_b} {inter} {union}");
        // Exact lens area of two unit-radius-0.5 discs 0.4 apart.
        let (r, d): (f64, f64) = (0.5, 0.4);
        let lens = 2.0 * r * r * (d / (2.0 * r)).acos() - 0.5 * d * (4.0 * r * r - d * d).sqrt();
        assert!((inter - lens).abs() < 0.01 * lens, "{inter} vs {lens}");
        assert!(inter < area_a.min(area_b) && union > area_a.max(area_b));
    }

    #[test]
    fn midpoint_quadrature_is_exact_for_quadratics_of_linear_fields() {
        let (mesh, topo) = grid();
        let region = disc(&mesh, &topo, 0.7, DVec3::ZERO);
        // Field x (linear); integrate x² over each piece triangle exactly, compare with a fine
        // sub-sampled reference on the same piece triangles.
        let field = |s: Sample| region.sample_position(&mesh, s).x;
        let (area, integral) = region.integrate(&mesh, &topo, field, |x: f64| x * x);
        let mut reference = 0.0;
        region.triangles(&mesh, &topo, |_, s| {
            let [a, b, c] = s.map(|s| region.sample_position(&mesh, s));
            // Exact ∫x² over a triangle: A/6 (xa² + xb² + xc² + xa xb + xb xc + xc xa).
            let area = 0.5 * (b - a).cross(c - a).length();
            reference += area / 6.0 * (a.x * a.x + b.x * b.x + c.x * c.x + a.x * b.x + b.x * c.x + c.x * a.x);
        });
        assert!((integral - reference).abs() < 1e-14, "{integral} vs {reference}");
        assert!((area - region.area(&mesh, &topo)).abs() < 1e-14);
        // And the mean of a constant vector field is that vector.
        let (_, v) = region.integrate(&mesh, &topo, |_| DVec3::Z, |n: DVec3| n);
        assert!((v / area - DVec3::Z).length() < 1e-12);
    }
}
