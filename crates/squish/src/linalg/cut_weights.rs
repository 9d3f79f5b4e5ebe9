//! Cut-face weights (thesis App. B §2, "adequately weighted cotangent coefficients" of §5.1): for
//! every face, the fraction of its area on the kept side of a domain boundary that runs along
//! mesh edges, such as the contact-zone boundary ∂𝒞.
//!
//! The boundary is given by a per-vertex side flag (`inside` = removed side, e.g. inside 𝒞) and
//! by its exact points on the edges joining an inside vertex `i` to an outside vertex `j`, each as
//! an [`EdgePoint`] `(1 − α)p_i + αp_j` with α measured from the inside vertex.
//!
//! Per face: 1 if its three corners are outside, 0 if all are inside, otherwise the area of the
//! polygon made of its outside corners and the two boundary points on its mixed edges, divided by
//! the face area. Area ratios inside a triangle are affine invariants, so the ratio is computed
//! from the α's alone, exactly and without cancellation:
//! - one outside corner `o`: the kept triangle has sides `(1 − α)` of the two edges at `o`, so the
//!   ratio is `(1 − α_io)(1 − α_jo)`;
//! - one inside corner `i`: the removed triangle at `i` has ratio `α_io · α_ip`, the kept part
//!   `1 − α_io · α_ip`.
//!
//! Continuity when the boundary crosses a vertex (what App. B is about): as the point on edge
//! `(i, j)` slides to `j` (α → 1) and `j` then switches to the inside with α → 0 on its other
//! mixed edges, every formula above takes the same value on both sides of the switch, so the
//! weights (hence the stiffness matrix) vary continuously.
//!
//! A mixed edge without an [`EdgePoint`] uses α = [`DEFAULT_CUT_ALPHA`] = ½ (the edge midpoint):
//! the least surprising guess, symmetric in the two vertices.

use super::SolveError;
use crate::mesh::{Topology, TriMesh};

/// α used on a mixed edge for which no boundary point was given: the edge midpoint.
pub const DEFAULT_CUT_ALPHA: f64 = 0.5;

/// A point of the domain boundary on the edge joining an inside (removed-side) vertex to an
/// outside (kept-side) vertex: `(1 − alpha)·p_inside + alpha·p_outside`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EdgePoint {
    /// The vertex on the removed side (e.g. inside the contact zone 𝒞).
    pub inside: u32,
    /// The vertex on the kept side.
    pub outside: u32,
    /// Position along the edge from `inside` (0) to `outside` (1); clamped to [0, 1].
    pub alpha: f64,
}

/// Per-face fraction of the area on the kept (outside) side, in [0, 1]; see the module doc.
///
/// `inside` has one flag per vertex (true = removed side). Errors: a point whose vertices are not
/// joined by an edge, whose sides disagree with `inside`, with a non-finite α, or two points on
/// the same edge.
pub fn cut_face_weights(
    mesh: &TriMesh,
    topology: &Topology,
    inside: &[bool],
    points: &[EdgePoint],
) -> Result<Vec<f64>, SolveError> {
    let n = mesh.num_vertices();
    if inside.len() != n {
        return Err(SolveError::DimensionMismatch { what: "inside flags", expected: n, actual: inside.len() });
    }
    if topology.num_vertices() != n || topology.num_faces() != mesh.num_triangles() {
        return Err(SolveError::DimensionMismatch {
            what: "topology (vertices)",
            expected: n,
            actual: topology.num_vertices(),
        });
    }
    // Position of the boundary point on each edge measured from its `lo` end (NaN: none given),
    // and the point that set it, to report duplicates.
    let mut from_lo = vec![f64::NAN; topology.num_edges()];
    let mut source = vec![usize::MAX; topology.num_edges()];
    for (k, p) in points.iter().enumerate() {
        for v in [p.inside, p.outside] {
            if v as usize >= n {
                return Err(SolveError::VertexOutOfRange { what: "boundary point", vertex: v, vertices: n });
            }
        }
        let (inside_flag, outside_flag) = (inside[p.inside as usize], inside[p.outside as usize]);
        if !inside_flag || outside_flag {
            return Err(SolveError::EdgePointSides {
                point: k,
                inside: p.inside,
                outside: p.outside,
                inside_flag,
                outside_flag,
            });
        }
        if !p.alpha.is_finite() {
            return Err(SolveError::NonFiniteEdgePoint { point: k, alpha: p.alpha });
        }
        let e = topology.edge_between(p.inside, p.outside).ok_or(SolveError::EdgePointNotOnEdge {
            point: k,
            inside: p.inside,
            outside: p.outside,
        })? as usize;
        if source[e] != usize::MAX {
            let [v0, v1] = topology.edges()[e];
            return Err(SolveError::DuplicateEdgePoint { first: source[e], second: k, v0, v1 });
        }
        let alpha = p.alpha.clamp(0.0, 1.0);
        from_lo[e] = if p.inside < p.outside { alpha } else { 1.0 - alpha };
        source[e] = k;
    }

    // α of the boundary point on edge `e` joining inside vertex `i` to outside vertex `o`,
    // measured from `i`.
    let alpha_from_inside = |e: u32, i: u32| {
        let t = from_lo[e as usize];
        if t.is_nan() {
            DEFAULT_CUT_ALPHA
        } else if i == topology.edge(e)[0] {
            t
        } else {
            1.0 - t
        }
    };

    let weights = mesh
        .triangles
        .iter()
        .enumerate()
        .map(|(f, tri)| {
            let out = tri.map(|v| !inside[v as usize]);
            let edges = topology.face_edges(f as u32);
            let outside_count = out.iter().filter(|&&o| o).count();
            match outside_count {
                3 => 1.0,
                0 => 0.0,
                1 => {
                    // Corner k is outside; edges k (to corner k+1) and k+2 (from corner k+2).
                    let k = out.iter().position(|&o| o).unwrap_or(0);
                    let a1 = alpha_from_inside(edges[k], tri[(k + 1) % 3]);
                    let a2 = alpha_from_inside(edges[(k + 2) % 3], tri[(k + 2) % 3]);
                    (1.0 - a1) * (1.0 - a2)
                }
                _ => {
                    let k = out.iter().position(|&o| !o).unwrap_or(0);
                    let a1 = alpha_from_inside(edges[k], tri[k]);
                    let a2 = alpha_from_inside(edges[(k + 2) % 3], tri[k]);
                    1.0 - a1 * a2
                }
            }
        })
        .collect();
    Ok(weights)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::{circle_cut, plane_cut};
    use crate::linalg::{SparsePattern, cotangent_stiffness};
    use crate::mesh::{shapes, triangle_area};
    use glam::DVec3;

    /// Area of a planar polygon in 3D (fan from the first vertex).
    fn polygon_area(points: &[DVec3]) -> f64 {
        let mut twice = DVec3::ZERO;
        for k in 1..points.len().saturating_sub(1) {
            twice += (points[k] - points[0]).cross(points[k + 1] - points[0]);
        }
        0.5 * twice.length()
    }

    #[test]
    fn weights_are_the_kept_area_ratio_of_the_cut_polygon() {
        let mut mesh = shapes::icosphere(1.0, 2);
        // Jiggle so no face is special.
        mesh.map_positions(|p| p + 0.03 * DVec3::new((7.0 * p.y).sin(), (5.0 * p.z).cos(), (3.0 * p.x).sin()));
        let topology = Topology::new(&mesh);
        let (inside, points) = plane_cut(&mesh, &topology, DVec3::new(0.3, 0.2, 1.0).normalize(), 0.25);
        let weights = cut_face_weights(&mesh, &topology, &inside, &points).unwrap();
        let point_on = |a: u32, b: u32| {
            let (i, o) = if inside[a as usize] { (a, b) } else { (b, a) };
            let p = points.iter().find(|p| p.inside == i && p.outside == o).unwrap();
            (1.0 - p.alpha) * mesh.positions[i as usize] + p.alpha * mesh.positions[o as usize]
        };
        let mut mixed = 0;
        for (f, tri) in mesh.triangles.iter().enumerate() {
            // The kept polygon: walk the corners, emitting outside corners and crossing points.
            let mut polygon = Vec::new();
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if !inside[a as usize] {
                    polygon.push(mesh.positions[a as usize]);
                }
                if inside[a as usize] != inside[b as usize] {
                    polygon.push(point_on(a, b));
                }
            }
            let [a, b, c] = mesh.corners(f);
            let expected = polygon_area(&polygon) / triangle_area(a, b, c);
            assert!((weights[f] - expected).abs() < 1e-12, "face {f}: {} vs {expected}", weights[f]);
            if expected > 0.0 && expected < 1.0 {
                mixed += 1;
            }
        }
        assert!(mixed > 10);
    }

    #[test]
    fn missing_points_default_to_the_edge_midpoint() {
        let mesh = shapes::grid(1.0, 1.0, 1, 1);
        let topology = Topology::new(&mesh);
        // Vertex 0 inside; faces [0,1,2] and [0,2,3] each have one inside corner.
        let inside = [true, false, false, false];
        let weights = cut_face_weights(&mesh, &topology, &inside, &[]).unwrap();
        assert_eq!(weights, vec![0.75, 0.75]);
        let given = [EdgePoint { inside: 0, outside: 1, alpha: 0.2 }];
        let weights = cut_face_weights(&mesh, &topology, &inside, &given).unwrap();
        assert!((weights[0] - (1.0 - 0.2 * 0.5)).abs() < 1e-15);
    }

    #[test]
    fn inconsistent_points_are_errors() {
        let mesh = shapes::grid(1.0, 1.0, 2, 2);
        let topology = Topology::new(&mesh);
        let mut inside = vec![false; mesh.num_vertices()];
        inside[4] = true;
        let point = |inside, outside, alpha| EdgePoint { inside, outside, alpha };
        let err = |points: &[EdgePoint]| cut_face_weights(&mesh, &topology, &inside, points).unwrap_err();
        assert!(matches!(err(&[point(1, 4, 0.5)]), SolveError::EdgePointSides { point: 0, .. }));
        assert!(matches!(err(&[point(4, 99, 0.5)]), SolveError::VertexOutOfRange { vertex: 99, .. }));
        let far = (0..9).find(|&v| v != 4 && topology.edge_between(4, v).is_none());
        if let Some(far) = far {
            assert!(matches!(err(&[point(4, far, 0.5)]), SolveError::EdgePointNotOnEdge { .. }));
        }
        assert!(matches!(err(&[point(4, 1, f64::NAN)]), SolveError::NonFiniteEdgePoint { .. }));
        assert!(matches!(
            err(&[point(4, 1, 0.5), point(4, 1, 0.4)]),
            SolveError::DuplicateEdgePoint { first: 0, second: 1, .. }
        ));
    }

    /// Largest change of the weights and of the stiffness values between two cuts.
    fn max_changes(
        mesh: &TriMesh,
        topology: &Topology,
        a: &(Vec<bool>, Vec<EdgePoint>),
        b: &(Vec<bool>, Vec<EdgePoint>),
    ) -> (f64, f64) {
        let pattern = SparsePattern::shared(mesh, topology).unwrap();
        let wa = cut_face_weights(mesh, topology, &a.0, &a.1).unwrap();
        let wb = cut_face_weights(mesh, topology, &b.0, &b.1).unwrap();
        let ka = cotangent_stiffness(mesh, &pattern, Some(&wa)).unwrap();
        let kb = cotangent_stiffness(mesh, &pattern, Some(&wb)).unwrap();
        let dw = wa.iter().zip(&wb).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        let dk = ka.values().iter().zip(kb.values()).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        (dw, dk)
    }

    #[test]
    fn weights_and_stiffness_are_continuous_when_the_boundary_slides_across_vertices() {
        // A straight boundary (slanted so that vertices switch one at a time) moves in small steps:
        // its crossings slide along the edges, reach vertices, and those vertices switch side.
        let mesh = shapes::grid(2.0, 2.0, 8, 8);
        let topology = Topology::new(&mesh);
        let h = 2.0 / 8.0;
        let normal = DVec3::new(0.3f64.cos(), 0.3f64.sin(), 0.0);
        let step = h / 200.0;
        let start = -0.37;
        let mut previous = plane_cut(&mesh, &topology, normal, start);
        let mut switches = 0;
        let (mut worst_w, mut worst_k) = (0.0f64, 0.0f64);
        for s in 1..=600 {
            let current = plane_cut(&mesh, &topology, normal, start + s as f64 * step);
            switches += previous.0.iter().zip(&current.0).filter(|(a, b)| a != b).count();
            let (dw, dk) = max_changes(&mesh, &topology, &previous, &current);
            worst_w = worst_w.max(dw / step);
            worst_k = worst_k.max(dk / step);
            previous = current;
        }
        assert!(switches >= 10, "the sweep must move the boundary across vertices ({switches})");
        // Crossings move by at most 1/(h·sin 0.3) ≈ 3.4/h per unit move, and weights are products
        // of two (1 − α) factors: Lipschitz with a constant below 10/h. A jump at a vertex switch
        // would be O(1) in one step, i.e. O(200/h) per unit move.
        assert!(worst_w < 10.0 / h, "weights change {worst_w} per unit move");
        assert!(worst_k < 10.0 / h, "stiffness changes {worst_k} per unit move");
    }

    #[test]
    fn weights_are_continuous_when_a_circle_sweeps_over_vertices() {
        // A disk-shaped zone (the level set of a piecewise-linear function, as the contact stage
        // makes it) moves across the grid. Continuity: refining the step tenfold divides the
        // largest one-step change by about ten; a jump would not shrink.
        let mesh = shapes::grid(2.0, 2.0, 8, 8);
        let topology = Topology::new(&mesh);
        let h = 2.0 / 8.0;
        let sweep = |step: f64, count: usize| {
            let at = |s: usize| circle_cut(&mesh, &topology, DVec3::new(-0.3 + s as f64 * step, 0.07, 0.0), 0.55);
            let mut previous = at(0);
            let (mut switches, mut worst) = (0, 0.0f64);
            for s in 1..=count {
                let current = at(s);
                switches += previous.0.iter().zip(&current.0).filter(|(a, b)| a != b).count();
                worst = worst.max(max_changes(&mesh, &topology, &previous, &current).0);
                previous = current;
            }
            (switches, worst)
        };
        let (switches, coarse) = sweep(h / 100.0, 200);
        let (_, fine) = sweep(h / 1000.0, 2000);
        assert!(switches >= 4, "the sweep must move the boundary across vertices ({switches})");
        assert!(coarse < 0.1, "largest one-step change {coarse}");
        assert!(fine < coarse / 5.0, "refined step: {fine} vs {coarse}");
    }

    #[test]
    fn sliding_a_point_onto_a_vertex_matches_switching_the_vertex() {
        // One boundary point at α → 1 on (i, j) equals j inside with α = 0 on its other edges.
        let mesh = shapes::grid(1.0, 1.0, 2, 2);
        let topology = Topology::new(&mesh);
        let (i, j) = (4u32, 5u32); // centre and its +x neighbour
        let mut inside = vec![false; 9];
        inside[i as usize] = true;
        let mut points: Vec<EdgePoint> =
            topology.vertex_neighbors(i).map(|o| EdgePoint { inside: i, outside: o, alpha: 0.3 }).collect();
        for p in &mut points {
            if p.outside == j {
                p.alpha = 1.0;
            }
        }
        let before = cut_face_weights(&mesh, &topology, &inside, &points).unwrap();
        inside[j as usize] = true;
        points.retain(|p| p.outside != j);
        points.extend(topology.vertex_neighbors(j).filter(|&o| !inside[o as usize]).map(|o| EdgePoint {
            inside: j,
            outside: o,
            alpha: 0.0,
        }));
        let after = cut_face_weights(&mesh, &topology, &inside, &points).unwrap();
        for (a, b) in before.iter().zip(&after) {
            assert!((a - b).abs() < 1e-15, "{before:?}\n{after:?}");
        }
    }
}
