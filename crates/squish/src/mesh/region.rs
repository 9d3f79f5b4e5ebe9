//! Face sets of a mesh as working regions (thesis §4, §4.5, §7.5): the helpers the pipeline
//! uses to turn a selection of faces into well-formed [`super::SubMesh`]es.
//!
//! - [`face_set_pieces`]: the connected pieces of a face set (faces sharing an edge), each of
//!   which becomes its own working region;
//! - [`close_pinches`]: adds the faces around every vertex where the selection pinches (its
//!   selected faces form several fans), so that every piece is a manifold mesh;
//! - [`edge_path_distances`]: multi-source Dijkstra along edges, up to a limit — an upper bound
//!   of the geodesic distance, used to grow automatic regions; [`edge_path_distance_bound`]:
//!   upper bounds of those distances by a breadth-first search, when they all stay within a limit;
//! - [`cut_border`]: the region vertices shared with faces outside it (where it was cut out);
//! - [`region_vertex_normals`]: vertex normals of region vertices computed from *all* their
//!   parent faces, so that a cut does not bend the normals along it.
//!
//! Every function works on the parent mesh's ids and is deterministic (sorted outputs).

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
/// vertex seeded twice keeps its smaller distance; a negative distance counts as 0; seeds beyond
/// `limit` or out of range are ignored), one per vertex, `f64::INFINITY` beyond `limit`: the
/// distance from points lying on edges, such as the boundary points of a contact zone.
pub fn edge_path_distance_field(mesh: &TriMesh, topology: &Topology, seeds: &[(u32, f64)], limit: f64) -> Vec<f64> {
    let n = mesh.num_vertices();
    let mut distance = vec![f64::INFINITY; n];
    let mut start = Vec::with_capacity(seeds.len());
    for &(s, d) in seeds {
        // A distance cannot be negative: such a seed starts at 0 (−0 is kept as is).
        let d = if d < 0.0 { 0.0 } else { d };
        if (s as usize) < n && d <= limit && d < distance[s as usize] {
            distance[s as usize] = d;
            start.push((d, s));
        }
    }
    match BucketQueue::for_mesh(mesh, topology, &start) {
        Some(queue) => settle(queue, mesh, topology, &mut distance, limit, &start),
        None => settle(RadixQueue::default(), mesh, topology, &mut distance, limit, &start),
    }
    distance
}

/// Upper bounds of [`edge_path_distance_field`]`(mesh, topology, seeds, ·)` when every vertex the
/// seeds reach is within `limit` of them, found without Dijkstra: the length of the path a
/// breadth-first search from the seeds follows (one square root per vertex instead of one per
/// edge, no priority queue), `f64::INFINITY` for the vertices it does not reach (not connected to
/// a seed, as in the field). `None` as soon as a bound exceeds `limit`, or at once when a vertex
/// lies farther than `limit` from the seeds' bounding box (no edge path is shorter).
///
/// Each bound is at least the field's value: along the search's path s → … → v, the field's
/// Dijkstra offers every vertex its settled neighbour's distance plus the same edge length, the
/// same rounded sums or smaller ones (rounding is monotone). So with `Some`, the field is finite
/// on exactly the same vertices, all within `limit` (for any field limit ≥ `limit`).
pub fn edge_path_distance_bound(
    mesh: &TriMesh,
    topology: &Topology,
    seeds: &[(u32, f64)],
    limit: f64,
) -> Option<Vec<f64>> {
    let n = mesh.num_vertices();
    if limit.is_nan() {
        return None;
    }
    // NaN (from a NaN position) counts as beyond.
    let beyond = |x: f64, limit: f64| x.is_nan() || x > limit;
    let (mut low, mut high) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for &(s, _) in seeds {
        if let Some(&p) = mesh.positions.get(s as usize) {
            (low, high) = (low.min(p), high.max(p));
        }
    }
    let limit_squared = limit * limit;
    for &p in &mesh.positions {
        // Distance to the box: 0 inside it.
        let outside = (low - p).max(p - high).max(DVec3::ZERO);
        if beyond(outside.length_squared(), limit_squared) {
            return None;
        }
    }
    let mut bound = vec![f64::INFINITY; n];
    let mut queue: Vec<u32> = Vec::with_capacity(n);
    for &(s, d) in seeds {
        // The field's rules for seeds (negative counts as 0, the smaller of two wins).
        let d = if d < 0.0 { 0.0 } else { d };
        if (s as usize) < n && d < bound[s as usize] {
            if bound[s as usize] == f64::INFINITY {
                queue.push(s);
            }
            bound[s as usize] = d;
        }
    }
    if queue.iter().any(|&s| beyond(bound[s as usize], limit)) {
        return None;
    }
    let mut head = 0;
    while let Some(&v) = queue.get(head) {
        head += 1;
        let (p, d) = (mesh.positions[v as usize], bound[v as usize]);
        for w in topology.vertex_neighbors(v) {
            if bound[w as usize] == f64::INFINITY {
                let reached = d + (mesh.positions[w as usize] - p).length();
                if beyond(reached, limit) {
                    return None;
                }
                bound[w as usize] = reached;
                queue.push(w);
            }
        }
    }
    Some(bound)
}

/// A priority queue of `(distance, vertex)` whose pops never decrease, as Dijkstra needs.
trait MonotoneQueue {
    fn push(&mut self, distance: f64, vertex: u32);
    fn pop(&mut self) -> Option<(f64, u32)>;
}

/// Dijkstra from the `start` entries (already in `distance`) on `queue`: a popped vertex that is
/// not stale lowers its neighbours' distances and pushes them.
fn settle(
    mut queue: impl MonotoneQueue,
    mesh: &TriMesh,
    topology: &Topology,
    distance: &mut [f64],
    limit: f64,
    start: &[(f64, u32)],
) {
    for &(d, s) in start {
        queue.push(d, s);
    }
    while let Some((d, v)) = queue.pop() {
        if d > distance[v as usize] {
            continue;
        }
        let p = mesh.positions[v as usize];
        for w in topology.vertex_neighbors(v) {
            // A neighbour already at distance ≤ d cannot improve (edge lengths are ≥ 0): skip its
            // square root. Most of them are the settled vertices v was reached from.
            if distance[w as usize] <= d {
                continue;
            }
            let candidate = d + (mesh.positions[w as usize] - p).length();
            if candidate <= limit && candidate < distance[w as usize] {
                distance[w as usize] = candidate;
                queue.push(candidate, w);
            }
        }
    }
}

/// Dial's bucket queue: buckets of width Δ a hair below the mesh's shortest edge, kept in a ring
/// covering the longest edge. Every candidate pushed from a vertex of bucket k is at least one
/// shortest edge farther, so it lands in a later bucket, and no vertex of a bucket can lower
/// another of the same bucket: the vertices of a bucket are final in any order, and each final
/// distance is the minimum of the same candidates as in a strictly ordered Dijkstra — the same
/// bits (tested against the binary heap). O(1) per entry with no reordering, so faster than the radix queue
/// (`docs/speed.md`). `None` (then [`RadixQueue`]) for a mesh with a
/// zero-length edge, whose longest edge or seed spread is more than a few times its vertex count
/// of shortest edges, or whose distances could reach 2³⁰ buckets.
struct BucketQueue {
    width: f64,
    buckets: Vec<Vec<(f64, u32)>>,
    /// The bucket being emptied (absolute index; its slot is `current % buckets.len()`).
    current: u64,
    draining: Vec<(f64, u32)>,
    len: usize,
}

impl BucketQueue {
    fn for_mesh(mesh: &TriMesh, topology: &Topology, start: &[(f64, u32)]) -> Option<Self> {
        let (mut shortest, mut longest) = (f64::INFINITY, 0.0f64);
        for &[i, j] in topology.edges() {
            let squared = (mesh.positions[j as usize] - mesh.positions[i as usize]).length_squared();
            shortest = shortest.min(squared);
            longest = longest.max(squared);
        }
        // The margin keeps "one shortest edge farther" a whole bucket farther after rounding.
        let width = shortest.sqrt() * (1.0 - 1e-6);
        let (low, high) = start.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &(d, _)| (lo.min(d), hi.max(d)));
        let span = longest.sqrt().max(if start.is_empty() { 0.0 } else { high - low });
        let slots = (span / width).floor() + 3.0;
        // The farthest distance a path can reach, in buckets: the margin of 10⁻⁶ bucket per edge
        // must stay far above the rounding of `distance / width` (relative 2⁻⁵³), so the bucket
        // indices stay below 2³⁰.
        let farthest = (high + mesh.num_vertices() as f64 * longest.sqrt()) / width;
        let usable = width > 0.0
            && width.is_finite()
            && slots.is_finite()
            && slots <= (4 * mesh.num_vertices() + 64) as f64
            && farthest < f64::from(1u32 << 30);
        if !usable {
            return None;
        }
        let current = if start.is_empty() { 0 } else { Self::index(low, width) };
        Some(Self { width, buckets: vec![Vec::new(); slots as usize], current, draining: Vec::new(), len: 0 })
    }

    #[inline]
    fn index(distance: f64, width: f64) -> u64 {
        // Non-negative (−0 and +0 give 0); truncation is the floor.
        (distance.max(0.0) / width) as u64
    }
}

impl MonotoneQueue for BucketQueue {
    #[inline]
    fn push(&mut self, distance: f64, vertex: u32) {
        // The bucket invariant the exactness rests on (checked in the test profile).
        let index = Self::index(distance, self.width);
        debug_assert!(index >= self.current && index < self.current + self.buckets.len() as u64);
        let slots = self.buckets.len() as u64;
        self.buckets[(index % slots) as usize].push((distance, vertex));
        self.len += 1;
    }

    fn pop(&mut self) -> Option<(f64, u32)> {
        if let Some(entry) = self.draining.pop() {
            return Some(entry);
        }
        if self.len == 0 {
            return None;
        }
        let slots = self.buckets.len() as u64;
        // The next non-empty bucket (at most a ring away); its entries are drained while later
        // buckets fill.
        loop {
            let slot = (self.current % slots) as usize;
            if !self.buckets[slot].is_empty() {
                std::mem::swap(&mut self.draining, &mut self.buckets[slot]);
                self.len -= self.draining.len();
                self.current += 1;
                return self.draining.pop();
            }
            self.current += 1;
        }
    }
}

/// A monotone priority queue of `(distance, vertex)` for Dijkstra (a radix heap on the bits of
/// the distances): the keys popped never decrease, and every key pushed is at least the last
/// popped one. Non-negative finite `f64`s order like their bit patterns, so an entry lives in the
/// bucket of the highest bit where its key differs from the last key popped; a pop empties the
/// lowest non-empty bucket into lower ones. Amortized O(1) per entry instead of a binary heap's
/// O(log n). The distances
/// Dijkstra computes do not depend on the order in which equal keys are popped, so the result is
/// the binary heap's, bit for bit.
struct RadixQueue {
    buckets: [Vec<(u64, u32)>; 65],
    last: u64,
    len: usize,
}

impl Default for RadixQueue {
    fn default() -> Self {
        Self { buckets: std::array::from_fn(|_| Vec::new()), last: 0, len: 0 }
    }
}

impl RadixQueue {
    #[inline]
    fn key(distance: f64) -> u64 {
        // +0 for ±0 (the sign bit of −0 would sort it last); distances are never negative.
        if distance <= 0.0 { 0 } else { distance.to_bits() }
    }

    #[inline]
    fn bucket(&self, key: u64) -> usize {
        (u64::BITS - (key ^ self.last).leading_zeros()) as usize
    }
}

impl MonotoneQueue for RadixQueue {
    fn push(&mut self, distance: f64, vertex: u32) {
        // Dijkstra only pushes keys ≥ the last popped one; clamp anything else (NaN-free input)
        // to keep the queue's invariant.
        let key = Self::key(distance).max(self.last);
        let b = self.bucket(key);
        self.buckets[b].push((key, vertex));
        self.len += 1;
    }

    fn pop(&mut self) -> Option<(f64, u32)> {
        if self.len == 0 {
            return None;
        }
        if self.buckets[0].is_empty() {
            let i = self.buckets.iter().position(|b| !b.is_empty())?;
            let moved = std::mem::take(&mut self.buckets[i]);
            self.last = moved.iter().map(|&(k, _)| k).min()?;
            for &(k, v) in &moved {
                let b = self.bucket(k);
                self.buckets[b].push((k, v));
            }
            // Give the emptied bucket its storage back.
            let mut moved = moved;
            moved.clear();
            self.buckets[i] = moved;
        }
        let (key, vertex) = self.buckets[0].pop()?;
        self.len -= 1;
        Some((f64::from_bits(key), vertex))
    }
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

    /// The textbook Dijkstra with a binary heap, to check the radix queue against.
    fn reference_distances(mesh: &TriMesh, topology: &Topology, seeds: &[(u32, f64)], limit: f64) -> Vec<f64> {
        use std::cmp::Reverse;
        use std::collections::BinaryHeap;
        let mut distance = vec![f64::INFINITY; mesh.num_vertices()];
        let mut heap = BinaryHeap::new();
        for &(s, d) in seeds {
            if d <= limit && d < distance[s as usize] {
                distance[s as usize] = d;
                heap.push(Reverse((d.to_bits(), s)));
            }
        }
        while let Some(Reverse((bits, v))) = heap.pop() {
            let d = f64::from_bits(bits);
            if d > distance[v as usize] {
                continue;
            }
            for w in topology.vertex_neighbors(v) {
                let candidate = d + (mesh.positions[w as usize] - mesh.positions[v as usize]).length();
                if candidate <= limit && candidate < distance[w as usize] {
                    distance[w as usize] = candidate;
                    heap.push(Reverse((candidate.to_bits(), w)));
                }
            }
        }
        distance
    }

    #[test]
    fn the_bucket_and_radix_queues_give_the_binary_heaps_distances_bit_for_bit() {
        // The bucket queue's invariant (every push lands in a later bucket) is also asserted by
        // the queue itself in the test profile: buckets wider than the shortest edge fail here.
        let mut mesh = shapes::icosphere(1.0, 4);
        // Uneven edge lengths.
        mesh.map_positions(|p| DVec3::new(p.x * 3.0, p.y, p.z * 0.4 + 0.1 * (7.0 * p.x).sin()));
        let topology = Topology::new(&mesh);
        // The same mesh with one edge 10⁻⁹ long: too many buckets, the radix queue runs.
        let mut pinched = mesh.clone();
        let [i, j] = topology.edges()[100];
        pinched.positions[j as usize] = pinched.positions[i as usize] + DVec3::splat(1e-9);
        let seeds: Vec<(u32, f64)> = [(0u32, 0.0), (17, 0.013), (17, 0.011), (400, 0.25), (401, -0.0)].to_vec();
        // Seeds so far out that the bucket indices would lose the margin to rounding: radix too.
        assert!(BucketQueue::for_mesh(&mesh, &topology, &[(1e12, 0)]).is_none());
        // Negative starting distances count as 0.
        let negative = [(0u32, -0.5), (1, -0.1), (2, 0.0)];
        let clamped = [(0u32, 0.0), (1, 0.0), (2, 0.0)];
        assert_eq!(
            edge_path_distance_field(&mesh, &topology, &negative, 1.0).iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
            reference_distances(&mesh, &topology, &clamped, 1.0).iter().map(|d| d.to_bits()).collect::<Vec<_>>()
        );
        for (mesh, bucketed) in [(&mesh, true), (&pinched, false)] {
            assert_eq!(BucketQueue::for_mesh(mesh, &topology, &[(0.0, 0)]).is_some(), bucketed);
            for limit in [0.3, 1.0, 2.5, f64::INFINITY] {
                let fast = edge_path_distance_field(mesh, &topology, &seeds, limit);
                let reference = reference_distances(mesh, &topology, &seeds, limit);
                assert_eq!(
                    fast.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
                    reference.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
                    "limit {limit}, bucketed {bucketed}"
                );
                assert!(fast.iter().filter(|d| d.is_finite()).count() > 10);
            }
        }
        // Seeds spread far beyond the longest edge (a window of buckets wider than one edge).
        let far: Vec<(u32, f64)> =
            (0..mesh.num_vertices() as u32).step_by(97).map(|v| (v, f64::from(v) * 1e-3)).collect();
        for limit in [0.5, f64::INFINITY] {
            let fast = edge_path_distance_field(&mesh, &topology, &far, limit);
            let reference = reference_distances(&mesh, &topology, &far, limit);
            assert_eq!(
                fast.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
                reference.iter().map(|d| d.to_bits()).collect::<Vec<_>>()
            );
        }
        // A regular grid: many equal edge lengths and equal distances.
        let grid = shapes::grid(2.0, 2.0, 30, 30);
        let grid_topology = Topology::new(&grid);
        let centre: Vec<(u32, f64)> = vec![(480, 0.0), (481, 0.0)];
        let fast = edge_path_distance_field(&grid, &grid_topology, &centre, 1.3);
        let reference = reference_distances(&grid, &grid_topology, &centre, 1.3);
        assert_eq!(
            fast.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
            reference.iter().map(|d| d.to_bits()).collect::<Vec<_>>()
        );
    }

    #[test]
    fn breadth_first_bounds_are_at_least_the_distances_and_reach_the_same_vertices() {
        let mut sphere = shapes::icosphere(1.0, 3);
        sphere.map_positions(|p| DVec3::new(p.x * 2.0, p.y, p.z * 0.5 + 0.1 * (5.0 * p.x).sin()));
        // Two components: the second one holds no seed and stays unreached.
        let mut two = sphere.clone();
        let offset = two.num_vertices() as u32;
        two.positions.extend(sphere.positions.iter().map(|&p| p + DVec3::new(0.0, 0.0, 1.5)));
        two.triangles.extend(sphere.triangles.iter().map(|t| t.map(|v| v + offset)));
        let seeds: Vec<(u32, f64)> = vec![(0, 0.0), (5, 0.02), (5, 0.01), (40, -0.3), (100, 0.05)];
        for mesh in [&sphere, &two] {
            let topology = Topology::new(mesh);
            let field = edge_path_distance_field(mesh, &topology, &seeds, f64::INFINITY);
            let farthest = field.iter().copied().filter(|d| d.is_finite()).fold(0.0, f64::max);
            // Limits the search passes (any field limit at least as large gives the same finite set).
            for limit in [farthest * 2.0, farthest * 10.0] {
                let bound = edge_path_distance_bound(mesh, &topology, &seeds, limit).expect("within the limit");
                let limited = edge_path_distance_field(mesh, &topology, &seeds, limit);
                for v in 0..mesh.num_vertices() {
                    assert_eq!(bound[v].is_finite(), limited[v].is_finite(), "vertex {v}");
                    assert!(bound[v] >= limited[v] || (bound[v].is_infinite() && limited[v].is_infinite()));
                    assert!(bound[v] <= limit || bound[v].is_infinite());
                }
                assert!(bound.iter().any(|d| d.is_infinite()) == std::ptr::eq(mesh, &two));
            }
            // Below the farthest distance the search must fail (some bound exceeds the limit).
            assert!(edge_path_distance_bound(mesh, &topology, &seeds, farthest * 0.99).is_none());
            // Far below: the box check refuses at once.
            assert!(edge_path_distance_bound(mesh, &topology, &seeds, 1e-3).is_none());
        }
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
