//! Connectivity of a triangle mesh: unique edges with their faces, vertex one-rings, boundary
//! edges and loops, manifoldness, closedness and connected components.
//!
//! Everything is stored in flat arrays (compressed rows for the per-vertex lists) so that the
//! structure is built once per working region and reused every frame: positions change between
//! frames, connectivity does not.

use super::{MeshError, TriMesh};

/// Marks a missing face on a boundary edge.
pub const NO_FACE: u32 = u32::MAX;

/// Connectivity of a [`TriMesh`].
#[derive(Clone, Debug)]
pub struct Topology {
    num_vertices: usize,
    /// Unique edges, each as `[lo, hi]` with `lo < hi`, sorted lexicographically.
    edges: Vec<[u32; 2]>,
    /// The (up to) two faces of each edge; [`NO_FACE`] for the missing one on a boundary edge.
    /// On a non-manifold edge the first two faces met are kept (see `edge_face_count`).
    edge_faces: Vec<[u32; 2]>,
    /// Number of faces incident to each edge (1 on the boundary, 2 inside, more if non-manifold).
    edge_face_count: Vec<u32>,
    /// `face_edges[f][k]` is the edge joining corners `k` and `k + 1` of face `f`.
    face_edges: Vec<[u32; 3]>,
    /// Compressed rows: the edges at each vertex, sorted by the other end's id.
    vertex_edge_offsets: Vec<u32>,
    vertex_edges: Vec<u32>,
    /// The other end of each entry of `vertex_edges` (one-ring walks read it without going
    /// through the edge list: Dijkstra over the parametrization domain, every frame).
    vertex_neighbors: Vec<u32>,
    /// Compressed rows: the faces at each vertex, in increasing face id.
    vertex_face_offsets: Vec<u32>,
    vertex_faces: Vec<u32>,
}

/// The faces around each vertex of `triangles` (`vertices` of them), in increasing face id, as
/// compressed rows: the faces of vertex `v` are `faces[offsets[v]..offsets[v + 1]]`.
pub(crate) fn faces_around_vertices(vertices: usize, triangles: &[[u32; 3]]) -> (Vec<u32>, Vec<u32>) {
    let mut offsets = vec![0u32; vertices + 1];
    for t in triangles {
        for &v in t {
            offsets[v as usize + 1] += 1;
        }
    }
    for i in 0..vertices {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut faces = vec![0u32; 3 * triangles.len()];
    for (f, t) in triangles.iter().enumerate() {
        for &v in t {
            faces[fill[v as usize] as usize] = f as u32;
            fill[v as usize] += 1;
        }
    }
    (offsets, faces)
}

impl Topology {
    /// Builds the connectivity. Works on any triangle soup whose indices are in range (checked by
    /// [`TriMesh::new`]); non-manifold configurations are recorded, not rejected.
    pub fn new(mesh: &TriMesh) -> Self {
        let nv = mesh.num_vertices();
        let nf = mesh.num_triangles();
        // Half-edges keyed by (lo, hi), then grouped into unique edges by sorting.
        let mut half: Vec<(u32, u32, u32, u8)> = Vec::with_capacity(3 * nf);
        for (f, t) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                half.push((a.min(b), a.max(b), f as u32, k as u8));
            }
        }
        half.sort_unstable();
        let mut edges = Vec::with_capacity(half.len() / 2 + 1);
        let mut edge_faces = Vec::with_capacity(half.len() / 2 + 1);
        let mut edge_face_count = Vec::with_capacity(half.len() / 2 + 1);
        let mut face_edges = vec![[u32::MAX; 3]; nf];
        for (lo, hi, f, k) in half {
            let is_new = edges.last().is_none_or(|e: &[u32; 2]| *e != [lo, hi]);
            if is_new {
                edges.push([lo, hi]);
                edge_faces.push([f, NO_FACE]);
                edge_face_count.push(1);
            } else {
                let e = edges.len() - 1;
                if edge_face_count[e] == 1 {
                    edge_faces[e][1] = f;
                }
                edge_face_count[e] += 1;
            }
            face_edges[f as usize][k as usize] = (edges.len() - 1) as u32;
        }

        let (vertex_edge_offsets, vertex_edges) = {
            let mut counts = vec![0u32; nv + 1];
            for e in &edges {
                counts[e[0] as usize + 1] += 1;
                counts[e[1] as usize + 1] += 1;
            }
            for i in 0..nv {
                counts[i + 1] += counts[i];
            }
            let mut fill = counts.clone();
            let mut list = vec![0u32; 2 * edges.len()];
            // Edges are sorted by (lo, hi): for a vertex v, edges where v is `hi` come in increasing
            // `lo`, then edges where v is `lo` in increasing `hi`, but the two groups interleave in
            // the loop below, so sort each row afterwards by the other end.
            for (ei, e) in edges.iter().enumerate() {
                for &v in e {
                    list[fill[v as usize] as usize] = ei as u32;
                    fill[v as usize] += 1;
                }
            }
            for v in 0..nv {
                let row = &mut list[counts[v] as usize..counts[v + 1] as usize];
                row.sort_unstable_by_key(|&ei| {
                    let e = edges[ei as usize];
                    if e[0] as usize == v { e[1] } else { e[0] }
                });
            }
            (counts, list)
        };
        let edge_list = &edges;
        let vertex_neighbors: Vec<u32> = (0..nv)
            .flat_map(|v| {
                let row = &vertex_edges[vertex_edge_offsets[v] as usize..vertex_edge_offsets[v + 1] as usize];
                row.iter().map(move |&e| {
                    let [a, b] = edge_list[e as usize];
                    if a as usize == v { b } else { a }
                })
            })
            .collect();

        let (vertex_face_offsets, vertex_faces) = faces_around_vertices(nv, &mesh.triangles);

        Self {
            num_vertices: nv,
            edges,
            edge_faces,
            edge_face_count,
            face_edges,
            vertex_edge_offsets,
            vertex_edges,
            vertex_neighbors,
            vertex_face_offsets,
            vertex_faces,
        }
    }

    /// Number of vertices of the mesh this topology was built from.
    pub fn num_vertices(&self) -> usize {
        self.num_vertices
    }

    /// Number of unique edges.
    pub fn num_edges(&self) -> usize {
        self.edges.len()
    }

    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.face_edges.len()
    }

    /// All unique edges as `[lo, hi]`, `lo < hi`.
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }

    /// Edge `e` as `[lo, hi]`.
    #[inline]
    pub fn edge(&self, e: u32) -> [u32; 2] {
        self.edges[e as usize]
    }

    /// The (up to two) faces of edge `e`; [`NO_FACE`] marks a missing one.
    #[inline]
    pub fn edge_faces(&self, e: u32) -> [u32; 2] {
        self.edge_faces[e as usize]
    }

    /// How many faces share edge `e`.
    #[inline]
    pub fn edge_face_count(&self, e: u32) -> u32 {
        self.edge_face_count[e as usize]
    }

    /// The edges of face `f`: entry `k` joins corners `k` and `k + 1`.
    #[inline]
    pub fn face_edges(&self, f: u32) -> [u32; 3] {
        self.face_edges[f as usize]
    }

    /// The edges at vertex `v`, sorted by the id of their other end.
    #[inline]
    pub fn vertex_edges(&self, v: u32) -> &[u32] {
        let v = v as usize;
        &self.vertex_edges[self.vertex_edge_offsets[v] as usize..self.vertex_edge_offsets[v + 1] as usize]
    }

    /// The faces at vertex `v`, in increasing order.
    #[inline]
    pub fn vertex_faces(&self, v: u32) -> &[u32] {
        let v = v as usize;
        &self.vertex_faces[self.vertex_face_offsets[v] as usize..self.vertex_face_offsets[v + 1] as usize]
    }

    /// The other end of edge `e` seen from `v` (which must be one of its ends).
    #[inline]
    pub fn other_vertex(&self, e: u32, v: u32) -> u32 {
        let [a, b] = self.edges[e as usize];
        if a == v { b } else { a }
    }

    /// The one-ring neighbours of `v`, in increasing id.
    pub fn vertex_neighbors(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        let v = v as usize;
        self.vertex_neighbors[self.vertex_edge_offsets[v] as usize..self.vertex_edge_offsets[v + 1] as usize]
            .iter()
            .copied()
    }

    /// The edge joining `a` and `b`, if any.
    pub fn edge_between(&self, a: u32, b: u32) -> Option<u32> {
        let row = self.vertex_edges(a);
        row.binary_search_by_key(&b, |&e| self.other_vertex(e, a)).ok().map(|i| row[i])
    }

    /// True if `e` has exactly one face.
    #[inline]
    pub fn is_boundary_edge(&self, e: u32) -> bool {
        self.edge_face_count[e as usize] == 1
    }

    /// All boundary edges (one face), in increasing id.
    pub fn boundary_edges(&self) -> Vec<u32> {
        (0..self.edges.len() as u32).filter(|&e| self.is_boundary_edge(e)).collect()
    }

    /// `true` for each vertex that lies on a boundary edge.
    pub fn boundary_vertices(&self) -> Vec<bool> {
        let mut on = vec![false; self.num_vertices];
        for e in self.boundary_edges() {
            let [a, b] = self.edge(e);
            on[a as usize] = true;
            on[b as usize] = true;
        }
        on
    }

    /// True if every edge has exactly two faces (no boundary, no non-manifold edge).
    pub fn is_closed(&self) -> bool {
        self.edge_face_count.iter().all(|&c| c == 2)
    }

    /// Edges with more than two faces.
    pub fn non_manifold_edges(&self) -> Vec<u32> {
        (0..self.edges.len() as u32).filter(|&e| self.edge_face_count[e as usize] > 2).collect()
    }

    /// Number of face fans around `v` (faces linked through edges that contain `v`); a manifold
    /// vertex has one fan, an isolated vertex none.
    pub fn vertex_fan_count(&self, v: u32) -> usize {
        let faces = self.vertex_faces(v);
        if faces.is_empty() {
            return 0;
        }
        // Union-find over the (few) faces of the one-ring.
        let mut parent: Vec<usize> = (0..faces.len()).collect();
        fn find(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for &e in self.vertex_edges(v) {
            let [f0, f1] = self.edge_faces(e);
            if f1 == NO_FACE || self.edge_face_count(e) > 2 {
                continue;
            }
            let (Ok(i0), Ok(i1)) = (faces.binary_search(&f0), faces.binary_search(&f1)) else { continue };
            let (r0, r1) = (find(&mut parent, i0), find(&mut parent, i1));
            parent[r0] = r1;
        }
        (0..faces.len()).filter(|&i| find(&mut parent, i) == i).count()
    }

    /// Checks edge-manifoldness, vertex-manifoldness (one fan per vertex) and consistent
    /// orientation (the two faces of an interior edge traverse it in opposite directions).
    pub fn check_manifold(&self, mesh: &TriMesh) -> Result<(), MeshError> {
        for (e, &count) in self.edge_face_count.iter().enumerate() {
            if count > 2 {
                let [v0, v1] = self.edges[e];
                return Err(MeshError::NonManifoldEdge { v0, v1, faces: count as usize });
            }
        }
        for v in 0..self.num_vertices as u32 {
            let fans = self.vertex_fan_count(v);
            if fans > 1 {
                return Err(MeshError::NonManifoldVertex { vertex: v, fans });
            }
        }
        for (e, faces) in self.edge_faces.iter().enumerate() {
            if faces[1] == NO_FACE {
                continue;
            }
            let [v0, v1] = self.edges[e];
            let dir = |f: u32| {
                let t = mesh.triangles[f as usize];
                (0..3).find(|&k| t[k] == v0 && t[(k + 1) % 3] == v1).is_some()
            };
            if dir(faces[0]) == dir(faces[1]) {
                return Err(MeshError::InconsistentOrientation {
                    t0: faces[0] as usize,
                    t1: faces[1] as usize,
                    v0,
                    v1,
                });
            }
        }
        Ok(())
    }

    /// True if [`Self::check_manifold`] passes.
    pub fn is_manifold(&self, mesh: &TriMesh) -> bool {
        self.check_manifold(mesh).is_ok()
    }

    /// Boundary loops as ordered vertex lists following the faces' orientation (each boundary
    /// edge is walked in the direction its face traverses it). Requires a manifold boundary;
    /// on a non-manifold boundary vertex the walk takes the first unused continuation.
    pub fn boundary_loops(&self, mesh: &TriMesh) -> Vec<Vec<u32>> {
        // For each boundary vertex, the boundary edge leaving it in face orientation.
        let mut next: Vec<Vec<u32>> = vec![Vec::new(); self.num_vertices];
        for e in self.boundary_edges() {
            let f = self.edge_faces(e)[0] as usize;
            let t = mesh.triangles[f];
            let [a, b] = self.edges[e as usize];
            let forward = (0..3).any(|k| t[k] == a && t[(k + 1) % 3] == b);
            let (from, to) = if forward { (a, b) } else { (b, a) };
            next[from as usize].push(to);
        }
        let mut loops = Vec::new();
        for start in 0..self.num_vertices {
            while let Some(mut to) = next[start].pop() {
                let mut lp = vec![start as u32];
                while to as usize != start {
                    lp.push(to);
                    match next[to as usize].pop() {
                        Some(n) => to = n,
                        None => break,
                    }
                }
                loops.push(lp);
            }
        }
        loops
    }

    /// Connected components of the faces (two faces are connected when they share a vertex).
    /// Returns the component of each face and the number of components; components are numbered
    /// in the order of their smallest face id. Isolated vertices do not form components.
    pub fn face_components(&self, mesh: &TriMesh) -> (Vec<u32>, usize) {
        let nf = mesh.num_triangles();
        let mut label = vec![u32::MAX; nf];
        // Each vertex's faces are scanned once: a fan of n faces around one vertex is O(n),
        // not O(n²).
        let mut vertex_done = vec![false; self.num_vertices];
        let mut count = 0u32;
        let mut stack = Vec::new();
        for seed in 0..nf {
            if label[seed] != u32::MAX {
                continue;
            }
            label[seed] = count;
            stack.push(seed as u32);
            while let Some(f) = stack.pop() {
                for &v in &mesh.triangles[f as usize] {
                    if std::mem::replace(&mut vertex_done[v as usize], true) {
                        continue;
                    }
                    for &g in self.vertex_faces(v) {
                        if label[g as usize] == u32::MAX {
                            label[g as usize] = count;
                            stack.push(g);
                        }
                    }
                }
            }
            count += 1;
        }
        (label, count as usize)
    }

    /// Connected components of the vertices through edges; isolated vertices are their own
    /// component. Returns the component of each vertex and the number of components.
    pub fn vertex_components(&self) -> (Vec<u32>, usize) {
        let nv = self.num_vertices;
        let mut label = vec![u32::MAX; nv];
        let mut count = 0u32;
        let mut stack = Vec::new();
        for seed in 0..nv {
            if label[seed] != u32::MAX {
                continue;
            }
            label[seed] = count;
            stack.push(seed as u32);
            while let Some(v) = stack.pop() {
                for w in self.vertex_neighbors(v) {
                    if label[w as usize] == u32::MAX {
                        label[w as usize] = count;
                        stack.push(w);
                    }
                }
            }
            count += 1;
        }
        (label, count as usize)
    }

    /// Euler characteristic V − E + F (counting only vertices used by a face).
    pub fn euler_characteristic(&self) -> i64 {
        let used = (0..self.num_vertices as u32).filter(|&v| !self.vertex_faces(v).is_empty()).count();
        used as i64 - self.edges.len() as i64 + self.face_edges.len() as i64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes;
    use glam::DVec3;

    fn two_triangles() -> TriMesh {
        // A unit square split along its diagonal 0–2.
        TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y], vec![[0, 1, 2], [0, 2, 3]])
            .unwrap()
    }

    #[test]
    fn square_edges_faces_and_boundary() {
        let mesh = two_triangles();
        let topo = Topology::new(&mesh);
        assert_eq!(topo.num_edges(), 5);
        assert_eq!(topo.boundary_edges().len(), 4);
        let diag = topo.edge_between(2, 0).unwrap();
        assert_eq!(topo.edge(diag), [0, 2]);
        assert_eq!(topo.edge_faces(diag), [0, 1]);
        assert!(topo.edge_between(1, 3).is_none());
        assert_eq!(topo.vertex_neighbors(0).collect::<Vec<_>>(), vec![1, 2, 3]);
        assert!(!topo.is_closed());
        assert!(topo.is_manifold(&mesh));
        let loops = topo.boundary_loops(&mesh);
        assert_eq!(loops.len(), 1);
        assert_eq!(loops[0].len(), 4);
        // Counter-clockwise seen from +z, like the faces.
        let mut lp = loops[0].clone();
        let start = lp.iter().position(|&v| v == 0).unwrap();
        lp.rotate_left(start);
        assert_eq!(lp, vec![0, 1, 2, 3]);
        for f in 0..2u32 {
            for (k, &e) in topo.face_edges(f).iter().enumerate() {
                let t = mesh.triangles[f as usize];
                let (a, b) = (t[k], t[(k + 1) % 3]);
                assert_eq!(topo.edge(e), [a.min(b), a.max(b)]);
            }
        }
    }

    #[test]
    fn closed_meshes_are_closed_with_euler_characteristic_two() {
        for mesh in [shapes::icosphere(1.0, 2), shapes::uv_sphere(1.0, 12, 8), shapes::cube(1.0, 3)] {
            let topo = Topology::new(&mesh);
            assert!(topo.is_closed());
            assert!(topo.is_manifold(&mesh));
            assert_eq!(topo.euler_characteristic(), 2);
            assert_eq!(topo.face_components(&mesh).1, 1);
            assert!(topo.boundary_loops(&mesh).is_empty());
        }
    }

    #[test]
    fn components_are_counted() {
        let mut mesh = shapes::icosphere(1.0, 1);
        let mut other = shapes::icosphere(1.0, 1);
        other.map_positions(|p| p + DVec3::new(5.0, 0.0, 0.0));
        mesh.append(&other);
        let topo = Topology::new(&mesh);
        let (labels, count) = topo.face_components(&mesh);
        assert_eq!(count, 2);
        assert_eq!(labels[0], 0);
        assert_eq!(*labels.last().unwrap(), 1);
        assert_eq!(topo.vertex_components().1, 2);
    }

    #[test]
    fn non_manifold_edge_is_detected() {
        // Three triangles sharing edge 0–1.
        let mesh = TriMesh::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::new(0.0, -1.0, 0.0)],
            vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
        )
        .unwrap();
        let topo = Topology::new(&mesh);
        assert_eq!(topo.non_manifold_edges().len(), 1);
        let err = topo.check_manifold(&mesh).unwrap_err();
        assert_eq!(err, MeshError::NonManifoldEdge { v0: 0, v1: 1, faces: 3 });
    }

    #[test]
    fn non_manifold_vertex_is_detected() {
        // Two triangles touching at vertex 0 only (a bow tie).
        let mesh =
            TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::Y, -DVec3::X, -DVec3::Y], vec![[0, 1, 2], [0, 3, 4]])
                .unwrap();
        let topo = Topology::new(&mesh);
        assert!(topo.non_manifold_edges().is_empty());
        assert_eq!(topo.check_manifold(&mesh).unwrap_err(), MeshError::NonManifoldVertex { vertex: 0, fans: 2 });
    }

    #[test]
    fn flipped_face_is_detected() {
        let mut mesh = two_triangles();
        mesh.triangles[1] = [0, 3, 2];
        let err = Topology::new(&mesh).check_manifold(&mesh).unwrap_err();
        assert!(matches!(err, MeshError::InconsistentOrientation { .. }));
    }
}
