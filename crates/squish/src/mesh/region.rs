//! Face sets of a mesh as working regions (thesis §4, §4.5, §7.5): the helpers the pipeline
//! uses to turn a selection of faces into well-formed [`super::SubMesh`]es.
//!
//! - [`face_set_pieces`]: the connected pieces of a face set (faces sharing an edge), each of
//!   which becomes its own working region;
//! - [`close_pinches`]: adds the faces around every vertex where the selection pinches (its
//!   selected faces form several fans), so that every piece is a manifold mesh;
//! - [`edge_path_distances`]: multi-source Dijkstra along edges, up to a limit — an upper bound
//!   of the geodesic distance, used to grow automatic regions;
//! - [`cut_border`]: the region vertices shared with faces outside it (where it was cut out);
//! - [`region_vertex_normals`]: vertex normals of region vertices computed from *all* their
//!   parent faces, so that a cut does not bend the normals along it.
//!
//! Every function works on the parent mesh's ids and is deterministic (sorted outputs).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::DVec3;

use super::{NO_FACE, Topology, TriMesh, face_normal_unnormalized};

/// The connected pieces of the selected faces (`selected[f]`), two faces being connected when
/// they share an edge. Each piece is sorted; pieces are in the order of their smallest face id.
/// After [`close_pinches`], faces sharing a vertex share a chain of edges too, so these are also
/// the pieces connected through vertices.
pub fn face_set_pieces(mesh: &TriMesh, topology: &Topology, selected: &[bool]) -> Vec<Vec<u32>> {
    let is_selected = |f: u32| f != NO_FACE && selected.get(f as usize).copied().unwrap_or(false);
    let mut label = vec![u32::MAX; mesh.num_triangles()];
    let mut pieces = Vec::new();
    let mut stack = Vec::new();
    for seed in 0..mesh.num_triangles() as u32 {
        if !is_selected(seed) || label[seed as usize] != u32::MAX {
            continue;
        }
        let id = pieces.len() as u32;
        let mut piece = vec![seed];
        label[seed as usize] = id;
        stack.push(seed);
        while let Some(f) = stack.pop() {
            for e in topology.face_edges(f) {
                for g in topology.edge_faces(e) {
                    if is_selected(g) && label[g as usize] == u32::MAX {
                        label[g as usize] = id;
                        piece.push(g);
                        stack.push(g);
                    }
                }
            }
        }
        piece.sort_unstable();
        pieces.push(piece);
    }
    pieces
}

/// Number of fans formed by the selected faces around `v` (faces adjacent through an edge at `v`
/// belong to the same fan). Assumes an edge-manifold mesh.
fn selected_fans(topology: &Topology, selected: &[bool], v: u32) -> usize {
    let is_selected = |f: u32| f != NO_FACE && selected.get(f as usize).copied().unwrap_or(false);
    let faces = topology.vertex_faces(v).iter().filter(|&&f| is_selected(f)).count();
    if faces == 0 {
        return 0;
    }
    let links = topology
        .vertex_edges(v)
        .iter()
        .filter(|&&e| topology.edge_face_count(e) == 2 && topology.edge_faces(e).iter().all(|&f| is_selected(f)))
        .count();
    // Around a manifold vertex the faces form a path or a cycle: each selected fan is a path
    // (faces − links = 1) unless the whole cycle is selected (faces = links).
    faces.saturating_sub(links).max(1)
}

/// Adds to `selected` every face around a vertex where the selected faces form two fans or more
/// (a pinch: the sub-mesh would be non-manifold there), until no pinch is left. Returns the
/// number of faces added. The parent must be edge-manifold (checked by the pipeline first).
pub fn close_pinches(mesh: &TriMesh, topology: &Topology, selected: &mut [bool]) -> usize {
    // Only a vertex with both selected and unselected faces can be a pinch.
    let mut seen = vec![0u8; mesh.num_vertices()];
    for (t, &s) in mesh.triangles.iter().zip(selected.iter()) {
        for &v in t {
            seen[v as usize] |= if s { 1 } else { 2 };
        }
    }
    let mut queue: Vec<u32> = (0..mesh.num_vertices() as u32).filter(|&v| seen[v as usize] == 3).rev().collect();
    let mut added = 0;
    while let Some(v) = queue.pop() {
        if selected_fans(topology, selected, v) < 2 {
            continue;
        }
        for &f in topology.vertex_faces(v) {
            if !selected[f as usize] {
                selected[f as usize] = true;
                added += 1;
                queue.extend(mesh.triangles[f as usize]);
            }
        }
    }
    added
}

#[derive(Clone, Copy, PartialEq)]
struct Visit {
    distance: f64,
    vertex: u32,
}

impl Eq for Visit {}

impl Ord for Visit {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: BinaryHeap is a max-heap; ties are broken by vertex id for determinism.
        other.distance.total_cmp(&self.distance).then_with(|| other.vertex.cmp(&self.vertex))
    }
}

impl PartialOrd for Visit {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Shortest edge-path distances from `sources` (distance 0), for every vertex at distance ≤
/// `limit`, as `(vertex, distance)` sorted by vertex. Edge paths are never shorter than the
/// geodesic distance on the surface, so every vertex returned is within `limit` along the surface
/// (and every vertex within `limit / c` geodesically is returned, c ≈ 1.1–1.3 on usual meshes).
pub fn edge_path_distances(mesh: &TriMesh, topology: &Topology, sources: &[u32], limit: f64) -> Vec<(u32, f64)> {
    let seeds: Vec<(u32, f64)> = sources.iter().map(|&s| (s, 0.0)).collect();
    edge_path_distance_field(mesh, topology, &seeds, limit)
        .into_iter()
        .enumerate()
        .filter(|(_, d)| d.is_finite())
        .map(|(v, d)| (v as u32, d))
        .collect()
}

/// Shortest edge-path distances from seeds with starting distances `(vertex, distance)` (a
/// vertex seeded twice keeps its smaller distance; seeds beyond `limit` or out of range are
/// ignored), one per vertex, `f64::INFINITY` beyond `limit`: the distance from points lying on
/// edges, such as the boundary points of a contact zone.
pub fn edge_path_distance_field(mesh: &TriMesh, topology: &Topology, seeds: &[(u32, f64)], limit: f64) -> Vec<f64> {
    let n = mesh.num_vertices();
    let mut distance = vec![f64::INFINITY; n];
    let mut heap = BinaryHeap::new();
    for &(s, d) in seeds {
        if (s as usize) < n && d <= limit && d < distance[s as usize] {
            distance[s as usize] = d;
            heap.push(Visit { distance: d, vertex: s });
        }
    }
    while let Some(Visit { distance: d, vertex: v }) = heap.pop() {
        if d > distance[v as usize] {
            continue;
        }
        let p = mesh.positions[v as usize];
        for w in topology.vertex_neighbors(v) {
            let candidate = d + (mesh.positions[w as usize] - p).length();
            if candidate <= limit && candidate < distance[w as usize] {
                distance[w as usize] = candidate;
                heap.push(Visit { distance: candidate, vertex: w });
            }
        }
    }
    distance
}

/// Per region vertex (`vertices`: parent ids): true when it is shared with a parent face outside
/// the region (`in_region[f]`), i.e. it lies on the border where the region was cut out.
pub fn cut_border(topology: &Topology, in_region: &[bool], vertices: &[u32]) -> Vec<bool> {
    vertices
        .iter()
        .map(|&v| topology.vertex_faces(v).iter().any(|&f| !in_region.get(f as usize).copied().unwrap_or(false)))
        .collect()
}

/// Unit area-weighted normals of the region vertices `vertices` (parent ids), from all their
/// parent faces: bit-identical to [`super::vertex_normals`] of the parent at those vertices (same
/// faces, same order of summation).
pub fn region_vertex_normals(mesh: &TriMesh, topology: &Topology, vertices: &[u32]) -> Vec<DVec3> {
    vertices
        .iter()
        .map(|&v| {
            let mut n = DVec3::ZERO;
            for &f in topology.vertex_faces(v) {
                let [a, b, c] = mesh.corners(f as usize);
                n += face_normal_unnormalized(a, b, c);
            }
            n.normalize_or_zero()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{SubMesh, shapes, vertex_normals};

    #[test]
    fn pieces_of_two_caps_are_two_regions() {
        let mesh = shapes::icosphere(1.0, 3);
        let topology = Topology::new(&mesh);
        let selected: Vec<bool> =
            (0..mesh.num_triangles()).map(|f| mesh.corners(f).iter().all(|p| p.z.abs() > 0.6)).collect();
        let pieces = face_set_pieces(&mesh, &topology, &selected);
        assert_eq!(pieces.len(), 2);
        let total: usize = pieces.iter().map(Vec::len).sum();
        assert_eq!(total, selected.iter().filter(|&&s| s).count());
        assert!(pieces[0][0] < pieces[1][0]);
    }

    #[test]
    fn pinched_selections_are_closed_into_manifolds() {
        // Two faces of a grid touching at one vertex only: a bow tie.
        let mesh = shapes::grid(2.0, 2.0, 4, 4);
        let topology = Topology::new(&mesh);
        let centre = mesh.positions.iter().position(|p| p.length() < 1e-12).unwrap() as u32;
        let fans = topology.vertex_faces(centre).to_vec();
        assert!(fans.len() >= 4);
        let mut selected = vec![false; mesh.num_triangles()];
        // Pick two faces of the one-ring that do not share an edge.
        let (f0, f1) = fans
            .iter()
            .flat_map(|&a| fans.iter().map(move |&b| (a, b)))
            .find(|&(a, b)| a < b && topology.face_edges(a).iter().all(|e| !topology.face_edges(b).contains(e)))
            .unwrap();
        selected[f0 as usize] = true;
        selected[f1 as usize] = true;
        assert_eq!(selected_fans(&topology, &selected, centre), 2);
        let before = SubMesh::from_faces(&mesh, [f0, f1]);
        assert!(!Topology::new(&before.mesh).is_manifold(&before.mesh));
        let added = close_pinches(&mesh, &topology, &mut selected);
        assert_eq!(added, fans.len() - 2);
        let faces = (0..mesh.num_triangles() as u32).filter(|&f| selected[f as usize]);
        let sub = SubMesh::from_faces(&mesh, faces);
        assert!(Topology::new(&sub.mesh).is_manifold(&sub.mesh));
        // A full one-ring is one fan, not a pinch.
        assert_eq!(selected_fans(&topology, &selected, centre), 1);
    }

    #[test]
    fn edge_path_distances_bound_the_geodesic_distance() {
        let mesh = shapes::grid(2.0, 2.0, 20, 20);
        let topology = Topology::new(&mesh);
        let source = mesh.positions.iter().position(|p| p.length() < 1e-12).unwrap() as u32;
        let reached = edge_path_distances(&mesh, &topology, &[source], 0.5);
        assert!(!reached.is_empty());
        for &(v, d) in &reached {
            let euclid = mesh.positions[v as usize].length();
            assert!(d >= euclid - 1e-12 && d <= 0.5, "{v}: {d} vs {euclid}");
        }
        // Every vertex within 0.5 / 1.42 (worst grid detour, √2 along a diagonal-free path) is
        // reached.
        for (v, p) in mesh.positions.iter().enumerate() {
            if p.length() < 0.5 / 1.42 {
                assert!(reached.binary_search_by_key(&(v as u32), |&(w, _)| w).is_ok(), "{v} at {p}");
            }
        }
    }

    #[test]
    fn region_normals_match_the_parent_and_borders_are_found() {
        let mesh = shapes::icosphere(1.0, 2);
        let topology = Topology::new(&mesh);
        let in_region: Vec<bool> = (0..mesh.num_triangles()).map(|f| mesh.corners(f)[0].z > 0.0).collect();
        let sub = SubMesh::from_faces(&mesh, (0..mesh.num_triangles() as u32).filter(|&f| in_region[f as usize]));
        let normals = region_vertex_normals(&mesh, &topology, &sub.parent_vertex);
        let all = vertex_normals(&mesh);
        for (local, &p) in sub.parent_vertex.iter().enumerate() {
            assert_eq!(normals[local].to_array().map(f64::to_bits), all[p as usize].to_array().map(f64::to_bits));
        }
        let border = cut_border(&topology, &in_region, &sub.parent_vertex);
        let sub_topology = Topology::new(&sub.mesh);
        let boundary = sub_topology.boundary_vertices();
        assert_eq!(border, boundary, "on a closed parent the cut border is the region's boundary");
        assert!(border.iter().any(|&b| b));
    }
}
