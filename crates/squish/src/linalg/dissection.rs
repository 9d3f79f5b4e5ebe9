//! A nested-dissection fill-reducing order from the graph alone (thesis ch. 7 §5.2: the
//! factorizations dominate a frame), the alternative to AMD that [`super::SymbolicFactor`] keeps
//! when it needs fewer flops.
//!
//! **Why.** AMD's greedy choices are poor on closed, round surfaces: a factorization in AMD order
//! costs more flops than in this order there. AMD is better on flat grids and on the faces of a
//! cube, where level sets of breadth-first searches make long separators. Neither wins
//! everywhere, so the analysis computes both and keeps the one with fewer flops (measurements in
//! `docs/speed.md`).
//!
//! **Algorithm** (George's automatic nested dissection, on one connected part at a time): a
//! pseudo-peripheral vertex (the first reached vertex of the deepest level of a breadth-first
//! search from the part's first vertex in the key order, then of one from it if that went
//! deeper: [`PERIPHERAL_SEARCHES`]), its level structure, and the level that minimizes
//! `size / min(vertices before, vertices after)` among the levels leaving at least a quarter of
//! the part on each side. Of that level, only the vertices with a neighbour in the next one
//! separate; the others join the near side. The order is: the near side, the far side, the
//! separator (each side dissected the same way down to [`LEAF_SIZE`] vertices). Parts that are
//! not connected are ordered one after the other. Leaves and separators are ordered by the key
//! the caller gives (the AMD position, so a leaf keeps AMD's local order).
//!
//! **Depends on the connectivity only** (not on positions): the order, and so every factor's
//! bits, is the same whatever frame a region is first analyzed at.

/// Parts of at most this many vertices are not dissected further (their order is the key's): a
/// compromise between the flops of the factor and the cost of the order (`docs/speed.md`).
pub(super) const LEAF_SIZE: usize = 64;

/// Breadth-first searches in quest of a pseudo-peripheral vertex, after the first (more searches
/// cost more than they save: `docs/speed.md`).
const PERIPHERAL_SEARCHES: usize = 1;

const NONE: u32 = u32::MAX;

/// The nested-dissection order (`order[new] = old`) of the symmetric graph whose lower triangle is
/// `col_ptr`, `row_idx` (`n` columns, rows ≥ their column; the diagonal is ignored), with ties
/// and leaves ordered by `key` (a permutation of `0..n`: `key[v]` is `v`'s rank).
pub(super) fn nested_dissection_order(n: usize, col_ptr: &[usize], row_idx: &[usize], key: &[usize]) -> Vec<usize> {
    let graph = Graph::from_lower(n, col_ptr, row_idx);
    let mut work = Work::new(n);
    let mut order = Vec::with_capacity(n);
    // Depth-first: a part's near side, then its far side, then its separator.
    enum Task {
        Dissect(Vec<u32>),
        Emit(Vec<u32>),
    }
    let mut all: Vec<u32> = (0..n as u32).collect();
    all.sort_unstable_by_key(|&v| key[v as usize]);
    let mut tasks = vec![Task::Dissect(all)];
    while let Some(task) = tasks.pop() {
        match task {
            Task::Emit(vertices) => order.extend(vertices.iter().map(|&v| v as usize)),
            Task::Dissect(part) if part.len() <= LEAF_SIZE => order.extend(part.iter().map(|&v| v as usize)),
            Task::Dissect(part) => match work.split(&graph, &part) {
                Split::Components(components) => tasks.extend(components.into_iter().rev().map(Task::Dissect)),
                Split::Separated { near, far, separator } => {
                    tasks.push(Task::Emit(separator));
                    tasks.push(Task::Dissect(far));
                    tasks.push(Task::Dissect(near));
                }
                Split::Leaf => order.extend(part.iter().map(|&v| v as usize)),
            },
        }
    }
    order
}

/// Adjacency lists (compressed rows), without the diagonal.
struct Graph {
    ptr: Vec<usize>,
    adjacent: Vec<u32>,
}

impl Graph {
    fn from_lower(n: usize, col_ptr: &[usize], row_idx: &[usize]) -> Self {
        let mut degree = vec![0usize; n + 1];
        for j in 0..n {
            for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
                if i != j {
                    degree[i + 1] += 1;
                    degree[j + 1] += 1;
                }
            }
        }
        for v in 0..n {
            degree[v + 1] += degree[v];
        }
        let ptr = degree;
        let mut fill = ptr.clone();
        let mut adjacent = vec![0u32; ptr[n]];
        for j in 0..n {
            for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
                if i != j {
                    adjacent[fill[i]] = j as u32;
                    fill[i] += 1;
                    adjacent[fill[j]] = i as u32;
                    fill[j] += 1;
                }
            }
        }
        Self { ptr, adjacent }
    }

    fn neighbours(&self, v: u32) -> &[u32] {
        &self.adjacent[self.ptr[v as usize]..self.ptr[v as usize + 1]]
    }
}

enum Split {
    /// The part is not connected: its components, in the order of their first vertex.
    Components(Vec<Vec<u32>>),
    Separated {
        near: Vec<u32>,
        far: Vec<u32>,
        separator: Vec<u32>,
    },
    /// No level separates it (a path of two levels, a clique…).
    Leaf,
}

/// Scratch memory of the dissection, sized once.
struct Work {
    /// The part being split: `member[v] == stamp`.
    member: Vec<u32>,
    /// Visited by the current search: `visited[v] == search`.
    visited: Vec<u32>,
    level: Vec<u32>,
    stamp: u32,
    search: u32,
    queue: Vec<u32>,
}

impl Work {
    fn new(n: usize) -> Self {
        Self {
            member: vec![NONE; n],
            visited: vec![NONE; n],
            level: vec![0; n],
            stamp: 0,
            search: 0,
            queue: Vec::new(),
        }
    }

    /// Breadth-first search of the part from `start`; leaves the visited vertices in `queue`, in
    /// the order of the search, and their levels in `level`.
    fn search_from(&mut self, graph: &Graph, start: u32) {
        self.search += 1;
        self.queue.clear();
        self.queue.push(start);
        self.visited[start as usize] = self.search;
        self.level[start as usize] = 0;
        let mut head = 0;
        while head < self.queue.len() {
            let v = self.queue[head];
            head += 1;
            let next = self.level[v as usize] + 1;
            for &w in graph.neighbours(v) {
                let w_index = w as usize;
                if self.member[w_index] == self.stamp && self.visited[w_index] != self.search {
                    self.visited[w_index] = self.search;
                    self.level[w_index] = next;
                    self.queue.push(w);
                }
            }
        }
    }

    /// `part` is ordered by key.
    fn split(&mut self, graph: &Graph, part: &[u32]) -> Split {
        self.stamp += 1;
        for &v in part {
            self.member[v as usize] = self.stamp;
        }
        self.search_from(graph, part[0]);
        if self.queue.len() < part.len() {
            return Split::Components(self.components(graph, part));
        }
        // A pseudo-peripheral vertex: the first reached vertex of the deepest level (a vertex at
        // distance `depth` has an eccentricity ≥ `depth`, so the last search is the one kept).
        let mut depth = self.level[self.queue[self.queue.len() - 1] as usize];
        for _ in 0..PERIPHERAL_SEARCHES {
            let candidate = self.queue.iter().copied().find(|&v| self.level[v as usize] == depth);
            let Some(candidate) = candidate else { break };
            self.search_from(graph, candidate);
            let candidate_depth = self.level[self.queue[self.queue.len() - 1] as usize];
            if candidate_depth <= depth {
                break;
            }
            depth = candidate_depth;
        }
        let depth = depth as usize;
        if depth < 2 {
            return Split::Leaf;
        }
        let mut count = vec![0usize; depth + 1];
        for &v in &self.queue {
            count[self.level[v as usize] as usize] += 1;
        }
        // The separating level: the smallest `size / min(before, after)` with both ≥ n/4.
        let total = part.len();
        let (mut best, mut best_cost) = (None, f64::INFINITY);
        let mut before = 0;
        for (l, &size) in count.iter().enumerate() {
            let after = total - before - size;
            if l > 0 && l < depth && 4 * before.min(after) >= total {
                let cost = size as f64 / before.min(after) as f64;
                if cost < best_cost {
                    (best, best_cost) = (Some(l), cost);
                }
            }
            before += size;
        }
        let Some(best) = best.map(|l| l as u32) else { return Split::Leaf };
        let (mut near, mut far, mut separator) = (Vec::new(), Vec::new(), Vec::new());
        for &v in part {
            let l = self.level[v as usize];
            if l > best {
                far.push(v);
            } else if l < best
                || !graph
                    .neighbours(v)
                    .iter()
                    .any(|&w| self.member[w as usize] == self.stamp && self.level[w as usize] == best + 1)
            {
                near.push(v);
            } else {
                separator.push(v);
            }
        }
        Split::Separated { near, far, separator }
    }

    /// The connected components of the part (whose vertices are marked), each in key order.
    fn components(&mut self, graph: &Graph, part: &[u32]) -> Vec<Vec<u32>> {
        // One search per component, numbered from `first`: a vertex's search is its component.
        let first = self.search + 1;
        let mut count = 0;
        for &v in part {
            let visited = self.visited[v as usize];
            if visited < first || visited == NONE {
                self.search_from(graph, v);
                count += 1;
            }
        }
        let mut components: Vec<Vec<u32>> = vec![Vec::new(); count];
        for &v in part {
            components[(self.visited[v as usize] - first) as usize].push(v);
        }
        components
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::SparsePattern;
    use crate::mesh::{Topology, shapes};

    fn order_of(mesh: &crate::TriMesh) -> (Vec<usize>, usize) {
        let topology = Topology::new(mesh);
        let pattern = SparsePattern::shared(mesh, &topology).expect("pattern");
        let n = pattern.num_vertices();
        let key: Vec<usize> = (0..n).collect();
        (nested_dissection_order(n, pattern.col_ptr(), pattern.row_idx(), &key), n)
    }

    #[test]
    fn the_order_is_a_permutation_and_separators_come_after_what_they_separate() {
        for mesh in [shapes::icosphere(1.0, 3), shapes::grid(1.0, 1.0, 30, 17), shapes::cube(1.0, 6)] {
            let (order, n) = order_of(&mesh);
            assert_permutation(&order, n, "mesh");
            // The first split: no edge joins its two sides, each holds a quarter of the
            // vertices, and its separator closes the order.
            let topology = Topology::new(&mesh);
            let pattern = SparsePattern::shared(&mesh, &topology).expect("pattern");
            let graph = Graph::from_lower(n, pattern.col_ptr(), pattern.row_idx());
            let all: Vec<u32> = (0..n as u32).collect();
            let Split::Separated { near, far, separator } = Work::new(n).split(&graph, &all) else {
                panic!("{n} vertices: the first split separates")
            };
            let mut side = vec![0u8; n];
            near.iter().for_each(|&v| side[v as usize] = 1);
            far.iter().for_each(|&v| side[v as usize] = 2);
            for &v in &near {
                assert!(
                    graph.neighbours(v).iter().all(|&w| side[w as usize] != 2),
                    "{n} vertices: {v} touches the far side"
                );
            }
            assert!(
                4 * near.len().min(far.len()) >= n,
                "{n} vertices: {} | {} | {}",
                near.len(),
                separator.len(),
                far.len()
            );
            let mut last: Vec<usize> = order[n - separator.len()..].to_vec();
            let mut expected: Vec<usize> = separator.iter().map(|&v| v as usize).collect();
            last.sort_unstable();
            expected.sort_unstable();
            assert_eq!(last, expected, "{n} vertices: the separator comes last");
        }
    }

    /// The lower triangle (with the diagonal) of the graph with these edges.
    fn lower(n: usize, edges: &[(usize, usize)]) -> (Vec<usize>, Vec<usize>) {
        let mut columns: Vec<Vec<usize>> = (0..n).map(|j| vec![j]).collect();
        for &(a, b) in edges {
            columns[a.min(b)].push(a.max(b));
        }
        let mut col_ptr = vec![0];
        let mut row_idx = Vec::new();
        for mut column in columns {
            column.sort_unstable();
            column.dedup();
            row_idx.extend(column);
            col_ptr.push(row_idx.len());
        }
        (col_ptr, row_idx)
    }

    fn assert_permutation(order: &[usize], n: usize, what: &str) {
        let mut seen = vec![false; n];
        for &v in order {
            assert!(v < n && !seen[v], "{what}: vertex {v} out of range or twice");
            seen[v] = true;
        }
        assert_eq!(order.len(), n, "{what}");
    }

    #[test]
    fn odd_graphs_give_permutations() {
        // Empty, isolated vertices, a long path (one-vertex separators), a star (two levels: no
        // separating level), a clique larger than a leaf.
        let key = |n: usize| (0..n).rev().collect::<Vec<_>>();
        let path: Vec<(usize, usize)> = (1..500).map(|v| (v - 1, v)).collect();
        let star: Vec<(usize, usize)> = (1..300).map(|v| (0, v)).collect();
        let clique: Vec<(usize, usize)> = (0..80).flat_map(|a| (a + 1..80).map(move |b| (a, b))).collect();
        let mut isolated = path.clone();
        isolated.retain(|&(a, _)| a % 7 != 0);
        for (what, n, edges) in [
            ("empty", 0, Vec::new()),
            ("isolated", 500, isolated),
            ("path", 500, path.clone()),
            ("star", 300, star),
            ("clique", 80, clique),
        ] {
            let (col_ptr, row_idx) = lower(n, &edges);
            let order = nested_dissection_order(n, &col_ptr, &row_idx, &key(n));
            assert_permutation(&order, n, what);
        }
        // A path is dissected at single vertices: its factor has no fill beyond what the order
        // must have (each column of L holds at most log₂ n + 1 rows, against n for a bad order).
        let (col_ptr, row_idx) = lower(500, &path);
        let order = nested_dissection_order(500, &col_ptr, &row_idx, &key(500));
        let flops = crate::linalg::symbolic::factorization_flops(500, &col_ptr, &row_idx, &order);
        assert!(flops < 500.0 * 10.0 * 10.0, "path: {flops} flops");
    }

    #[test]
    fn disconnected_parts_are_ordered_one_after_the_other() {
        // Two separate grids: the first one's vertices (by key) all come before the second's
        // only if dissection treats components separately.
        let a = shapes::grid(1.0, 1.0, 12, 12);
        let mut b = shapes::grid(1.0, 1.0, 12, 12);
        b.map_positions(|p| p + glam::DVec3::X * 3.0);
        let offset = a.num_vertices() as u32;
        let mut mesh = a.clone();
        mesh.positions.extend(b.positions);
        mesh.triangles.extend(b.triangles.iter().map(|t| t.map(|v| v + offset)));
        let (order, n) = order_of(&mesh);
        let first_of_second = order.iter().position(|&v| v >= offset as usize).expect("second grid");
        assert_eq!(first_of_second, offset as usize);
        assert_eq!(order.len(), n);
    }

    #[test]
    fn a_sphere_is_dissected_with_fewer_flops_than_amd_and_a_grid_is_not() {
        // The reason for the dissection (module doc): AMD's greedy order is poor on round closed
        // surfaces. On flat grids the level-set separators are long and AMD stays better, which
        // is why the analysis keeps the cheaper of the two.
        let flops = |mesh: &crate::TriMesh| {
            let topology = Topology::new(mesh);
            let pattern = SparsePattern::shared(mesh, &topology).expect("pattern");
            let n = pattern.num_vertices();
            let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
            let amd = crate::linalg::symbolic::amd_order(pattern.structure()).expect("AMD");
            let mut rank = vec![0; n];
            for (r, &v) in amd.iter().enumerate() {
                rank[v] = r;
            }
            let dissection = nested_dissection_order(n, col_ptr, row_idx, &rank);
            let of = |order: &[usize]| crate::linalg::symbolic::factorization_flops(n, col_ptr, row_idx, order);
            (of(&dissection), of(&amd))
        };
        let (dissection, amd) = flops(&shapes::icosphere(1.0, 4));
        assert!(dissection < 0.8 * amd, "icosphere: {dissection:.3e} flops against AMD's {amd:.3e}");
        let (dissection, amd) = flops(&shapes::grid(1.0, 1.0, 60, 60));
        assert!(dissection > amd, "grid: {dissection:.3e} flops against AMD's {amd:.3e}");
    }
}
