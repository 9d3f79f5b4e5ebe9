//! The smallest minimum s–t cut of a network with integer capacities, for the crease cut
//! (thesis §6.1.3, [`super::partition`]).
//!
//! **Contract.** [`Network`] holds arcs in pairs (`u → v` with capacity `c`, `v → u` with `c′`):
//! an undirected edge of capacity k is a pair (k, k), a one-way link a pair (c, 0).
//! [`Network::source_side`] runs a maximum flow from `source` to `sink` and returns the nodes
//! reachable from the source in its residual network. For every maximum flow that set is the
//! same — the source side of the smallest minimum cut, the intersection of all of them — so the
//! labels do not depend on the algorithm or the order of its augmentations, only on the network.
//!
//! **Algorithm.** Dinic's: a breadth-first level graph from the source, then blocking flows by a
//! depth-first search that keeps, per node, the arc it is at (so each phase costs O(V·E) at worst
//! and every arc is passed over once per phase when it is saturated or leads nowhere). The last
//! level graph, which no longer reaches the sink, is the residual reach.
//!
//! *Why not a crate's:* petgraph 0.8.3's `dinics`, used before, clears its visited map and
//! allocates a per-node cursor array for *each augmenting path*, O(V) per path; on the 15k-vertex
//! walk's articulations that made the crease cut most of the cut stage (docs/speed.md, "The crease
//! cut's max-flow"). Capacities are exact integers: the arithmetic has no round-off.

/// A flow network of arcs stored in pairs (an arc and its reverse).
#[derive(Clone, Debug, Default)]
pub struct Network {
    nodes: usize,
    /// Per arc: its head.
    head: Vec<u32>,
    /// Per arc: its residual capacity.
    residual: Vec<u64>,
    /// Per arc: its tail (to build the adjacency).
    tail: Vec<u32>,
}

/// Level of a node the breadth-first search has not reached.
const UNREACHED: u32 = u32::MAX;

impl Network {
    /// A network of `nodes` nodes without arcs.
    pub fn new(nodes: usize) -> Self {
        Self { nodes, ..Self::default() }
    }

    /// Adds the arc `u → v` of capacity `forward` and its reverse `v → u` of capacity `backward`.
    pub fn add_pair(&mut self, u: usize, v: usize, forward: u64, backward: u64) {
        debug_assert!(u < self.nodes && v < self.nodes);
        self.head.extend([v as u32, u as u32]);
        self.tail.extend([u as u32, v as u32]);
        self.residual.extend([forward, backward]);
    }

    /// Per node: reachable from `source` in the residual network of a maximum flow from `source`
    /// to `sink` (see the module doc).
    pub fn source_side(mut self, source: usize, sink: usize) -> Vec<bool> {
        let n = self.nodes;
        // Arcs by tail (compressed rows).
        let mut start = vec![0u32; n + 1];
        for &t in &self.tail {
            start[t as usize + 1] += 1;
        }
        for v in 0..n {
            start[v + 1] += start[v];
        }
        let mut arcs = vec![0u32; self.tail.len()];
        let mut fill = start.clone();
        for (a, &t) in self.tail.iter().enumerate() {
            arcs[fill[t as usize] as usize] = a as u32;
            fill[t as usize] += 1;
        }
        let mut level = vec![UNREACHED; n];
        let mut queue = Vec::with_capacity(n);
        let mut cursor = vec![0u32; n];
        // The arcs of the current path from the source.
        let mut path: Vec<u32> = Vec::new();
        loop {
            // Levels of the residual network from the source.
            level.fill(UNREACHED);
            level[source] = 0;
            queue.clear();
            queue.push(source as u32);
            let mut k = 0;
            while let Some(&u) = queue.get(k) {
                k += 1;
                for &a in &arcs[start[u as usize] as usize..start[u as usize + 1] as usize] {
                    let v = self.head[a as usize] as usize;
                    if self.residual[a as usize] > 0 && level[v] == UNREACHED {
                        level[v] = level[u as usize] + 1;
                        queue.push(v as u32);
                    }
                }
            }
            if level[sink] == UNREACHED {
                return level.iter().map(|&l| l != UNREACHED).collect();
            }
            // A blocking flow along the level graph.
            cursor.copy_from_slice(&start[..n]);
            path.clear();
            let mut u = source;
            loop {
                if u == sink {
                    let bottleneck = path.iter().map(|&a| self.residual[a as usize]).min().unwrap_or(0);
                    let mut first_saturated = path.len();
                    for (k, &a) in path.iter().enumerate() {
                        self.residual[a as usize] -= bottleneck;
                        self.residual[(a ^ 1) as usize] += bottleneck;
                        if self.residual[a as usize] == 0 && first_saturated == path.len() {
                            first_saturated = k;
                        }
                    }
                    // Back to the tail of the first arc the augmentation saturated.
                    path.truncate(first_saturated);
                    u = path.last().map_or(source, |&a| self.head[a as usize] as usize);
                    continue;
                }
                let end = start[u + 1];
                let mut advanced = false;
                while cursor[u] < end {
                    let a = arcs[cursor[u] as usize];
                    let v = self.head[a as usize] as usize;
                    if self.residual[a as usize] > 0 && level[v] == level[u] + 1 {
                        path.push(a);
                        u = v;
                        advanced = true;
                        break;
                    }
                    cursor[u] += 1;
                }
                if advanced {
                    continue;
                }
                // A dead end: no path to the sink through u in this phase.
                level[u] = UNREACHED;
                match path.pop() {
                    Some(a) => {
                        u = self.tail[a as usize] as usize;
                        cursor[u] += 1;
                    }
                    None => break,
                }
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use petgraph::Graph;
    use petgraph::algo::dinics;

    /// The smallest minimum cut's source side by petgraph's Dinic (the former implementation):
    /// every pair as two directed edges.
    fn reference(nodes: usize, pairs: &[(usize, usize, u64, u64)], source: usize, sink: usize) -> Vec<bool> {
        let mut graph = Graph::<(), u64>::new();
        let ids: Vec<_> = (0..nodes).map(|_| graph.add_node(())).collect();
        for &(u, v, f, b) in pairs {
            if f > 0 {
                graph.add_edge(ids[u], ids[v], f);
            }
            if b > 0 {
                graph.add_edge(ids[v], ids[u], b);
            }
        }
        let (_, flows) = dinics(&graph, ids[source], ids[sink]);
        let mut adjacency = vec![Vec::new(); nodes];
        for (e, raw) in graph.raw_edges().iter().enumerate() {
            let (u, v) = (raw.source().index(), raw.target().index());
            if flows[e] < raw.weight {
                adjacency[u].push(v);
            }
            if flows[e] > 0 {
                adjacency[v].push(u);
            }
        }
        let mut reached = vec![false; nodes];
        let mut stack = vec![source];
        reached[source] = true;
        while let Some(u) = stack.pop() {
            for &v in &adjacency[u] {
                if !reached[v] {
                    reached[v] = true;
                    stack.push(v);
                }
            }
        }
        reached
    }

    /// A small linear congruential generator (deterministic test data).
    fn next(state: &mut u64) -> u64 {
        *state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        *state >> 33
    }

    #[test]
    fn the_source_side_is_petgraphs_on_random_networks() {
        let mut state = 7;
        for trial in 0..200 {
            let nodes = 2 + (next(&mut state) % 40) as usize;
            let arcs = (next(&mut state) % (4 * nodes as u64)) as usize;
            let mut pairs = Vec::new();
            for _ in 0..arcs {
                let u = (next(&mut state) % nodes as u64) as usize;
                let v = (next(&mut state) % nodes as u64) as usize;
                if u == v {
                    continue;
                }
                // Undirected edges, one-way links and zero capacities, with repeated values (ties
                // between cuts).
                let c = next(&mut state) % 5;
                let b = if next(&mut state).is_multiple_of(2) { c } else { 0 };
                pairs.push((u, v, c, b));
            }
            let (source, sink) = (0, nodes - 1);
            let mut network = Network::new(nodes);
            for &(u, v, f, b) in &pairs {
                network.add_pair(u, v, f, b);
            }
            assert_eq!(network.source_side(source, sink), reference(nodes, &pairs, source, sink), "trial {trial}");
        }
    }

    #[test]
    fn a_chain_is_cut_at_its_weakest_link_nearest_the_source() {
        // 0 - 1 - 2 - 3 - 4 with capacities 5, 2, 7, 2: two minimum cuts (after 1 and after 3);
        // the smallest source side is {0, 1}.
        let mut network = Network::new(5);
        for (u, c) in [5, 2, 7, 2].into_iter().enumerate() {
            network.add_pair(u, u + 1, c, c);
        }
        assert_eq!(network.source_side(0, 4), [true, true, false, false, false]);
        // No arc at all: only the source is on its side.
        assert_eq!(Network::new(3).source_side(0, 2), [true, false, false]);
    }
}
