//! A binary bounding volume hierarchy in one flat array, built for the queries of the contact
//! stage (thesis ch. 7 §5.1: "the spatial searches of Chapter 4 … could be sped up using
//! state-of-the-art techniques").
//!
//! Nodes are stored depth first: a node's left child follows it, its right child is linked, and a
//! subtree is a contiguous range of nodes. Each leaf holds one item (a triangle), named by its
//! index. Layout and order are ours, so the queries can visit children in the order that finds
//! their answer first — the nearest or farthest crossing of a line, the closest point — and prune
//! the rest, where a fixed left-first order (parry's traversal) visits several times as many nodes
//! and triangles (`docs/speed.md`).
//!
//! **Build.** Top-down binned surface-area heuristic (16 bins along the longest axis of the
//! centroids), a median split when the heuristic cannot separate the items, and always a median
//! split below depth [`MEDIAN_DEPTH`], which bounds the depth by `MEDIAN_DEPTH + log₂ n` (the fixed
//! traversal stacks rely on it). Deterministic: the same boxes give the same tree. A subtree over
//! m items has 2m − 1 nodes, so every subtree's place in the array is known once its node is
//! split: subtrees over at least [`PARALLEL_BUILD`] items are built side by side (`rayon::join`)
//! into their own ranges, the same tree whatever the thread count.
//!
//! **Refit.** New item boxes, then every inner box as the union of its children's, children
//! before parents (reverse storage order); or, when few items moved, the boxes of their leaves
//! and of those leaves' ancestors only, in the same order. The topology, and with it every
//! traversal order, is kept.

use glam::DVec3;

/// Below this depth every split is a median split (see the module doc).
const MEDIAN_DEPTH: usize = 48;

/// Bins of the surface-area heuristic.
const BINS: usize = 16;

/// Items below which a node's two subtrees are built one after the other rather than side by
/// side (below it the fork costs more than it saves).
const PARALLEL_BUILD: usize = 4096;

/// Capacity of the fixed traversal stacks before they spill to the heap. A depth-first stack holds
/// at most one pending node per level plus one, and our meshes' trees are 20–40 deep (the depth is
/// at most `MEDIAN_DEPTH + 32` below 2³² items). Small, because the array is initialized per query.
pub(crate) const STACK: usize = 64;

/// One node: its box, and either its right child (inner node; the left child is the next node) or
/// its item (leaf).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Node {
    pub min: DVec3,
    pub max: DVec3,
    link: u32,
    leaf: bool,
}

impl Node {
    /// The item of a leaf.
    #[inline]
    pub fn item(&self) -> Option<u32> {
        self.leaf.then_some(self.link)
    }

    /// The children of an inner node at index `index`.
    #[inline]
    pub fn children(&self, index: usize) -> Option<[usize; 2]> {
        (!self.leaf).then_some([index + 1, self.link as usize])
    }

    /// True if this node's box and `other`'s overlap (touching counts).
    #[inline]
    pub fn overlaps(&self, other: &Node) -> bool {
        self.min.cmple(other.max).all() && other.min.cmple(self.max).all()
    }

    /// True if this node's box overlaps the box `[min, max]` (touching counts).
    #[inline]
    pub fn overlaps_box(&self, min: DVec3, max: DVec3) -> bool {
        self.min.cmple(max).all() && min.cmple(self.max).all()
    }
}

/// What a traversal does after visiting a node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Visit {
    /// Visit the node's children.
    Continue,
    /// Skip them.
    Prune,
    /// End the traversal.
    Stop,
}

/// The traversals' stack: a fixed array (no allocation per query), spilling to the heap only past
/// its capacity, which the depth bound makes unreachable for single-tree traversals.
pub(crate) struct Stack<T: Copy + Default> {
    items: [T; STACK],
    len: usize,
    spill: Vec<T>,
}

impl<T: Copy + Default> Stack<T> {
    #[inline]
    pub fn new() -> Self {
        Self { items: [T::default(); STACK], len: 0, spill: Vec::new() }
    }

    #[inline]
    pub fn push(&mut self, item: T) {
        match self.items.get_mut(self.len) {
            Some(slot) if self.spill.is_empty() => {
                *slot = item;
                self.len += 1;
            }
            _ => self.spill.push(item),
        }
    }

    #[inline]
    pub fn pop(&mut self) -> Option<T> {
        if let Some(item) = self.spill.pop() {
            return Some(item);
        }
        self.len = self.len.checked_sub(1)?;
        Some(self.items[self.len])
    }
}

/// The hierarchy (see the module doc).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct FlatBvh {
    nodes: Vec<Node>,
}

/// An item being sorted into the tree.
#[derive(Clone, Copy)]
struct Item {
    index: u32,
    min: DVec3,
    max: DVec3,
    centroid: DVec3,
}

impl FlatBvh {
    /// Builds the tree over `boxes` (item `i` has the box `boxes[i]` = (min, max)).
    pub fn new(boxes: &[(DVec3, DVec3)]) -> Self {
        let mut items: Vec<Item> = boxes
            .iter()
            .enumerate()
            .map(|(i, &(min, max))| Item { index: i as u32, min, max, centroid: 0.5 * (min + max) })
            .collect();
        let placeholder = Node { min: DVec3::ZERO, max: DVec3::ZERO, link: 0, leaf: true };
        let mut nodes = vec![placeholder; (2 * items.len()).saturating_sub(1)];
        if !items.is_empty() {
            let mut bins = vec![0u8; items.len()];
            build(&mut nodes, 0, &mut items, &mut bins, 0);
        }
        Self { nodes }
    }

    /// The nodes, root first.
    #[inline]
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The index one past the last node of the subtree rooted at every node (a subtree is a
    /// contiguous range of nodes).
    pub fn subtree_ends(&self) -> Vec<usize> {
        let mut end = vec![0; self.nodes.len()];
        for i in (0..self.nodes.len()).rev() {
            end[i] = match self.nodes[i].children(i) {
                Some([_, right]) => end[right],
                None => i + 1,
            };
        }
        end
    }

    /// The tree of the items `new_item` keeps (`Some(new id)`), in this tree's shape: an inner
    /// node with one kept side is replaced by that side, one with none dropped. Depth first as
    /// built, so a subtree is still a contiguous range; the depth is at most this tree's. Boxes
    /// are copied and must be refitted ([`Self::refit`]) to the kept items' boxes.
    pub fn pruned(&self, new_item: impl Fn(u32) -> Option<u32>) -> Self {
        // Per node, its kept items (a leaf: its new id, u32::MAX if dropped) and how many: a
        // subtree of k kept items becomes 2k − 1 nodes, so every link is known when written.
        let n = self.nodes.len();
        let mut leaf_item = vec![u32::MAX; n];
        let mut kept = vec![0usize; n];
        for i in (0..n).rev() {
            kept[i] = match self.nodes[i].children(i) {
                Some([left, right]) => kept[left] + kept[right],
                None => {
                    leaf_item[i] = new_item(self.nodes[i].link).unwrap_or(u32::MAX);
                    usize::from(leaf_item[i] != u32::MAX)
                }
            };
        }
        fn emit(tree: &FlatBvh, i: usize, kept: &[usize], leaf_item: &[u32], out: &mut Vec<Node>) {
            let node = tree.nodes[i];
            match node.children(i) {
                None => out.push(Node { link: leaf_item[i], ..node }),
                Some([left, right]) if kept[right] == 0 => emit(tree, left, kept, leaf_item, out),
                Some([left, right]) if kept[left] == 0 => emit(tree, right, kept, leaf_item, out),
                Some([left, right]) => {
                    out.push(Node { link: (out.len() + 2 * kept[left]) as u32, ..node });
                    emit(tree, left, kept, leaf_item, out);
                    emit(tree, right, kept, leaf_item, out);
                }
            }
        }
        let mut nodes = Vec::with_capacity((2 * kept.first().copied().unwrap_or(0)).saturating_sub(1));
        if kept.first().is_some_and(|&k| k > 0) {
            emit(self, 0, &kept, &leaf_item, &mut nodes);
        }
        Self { nodes }
    }

    /// New boxes for the items (`item_box(i)` = (min, max)); inner boxes are recomputed.
    pub fn refit(&mut self, item_box: impl Fn(u32) -> (DVec3, DVec3)) {
        for i in (0..self.nodes.len()).rev() {
            self.refit_node(i, &item_box);
        }
    }

    /// Node `i`'s box from its children's (an inner node) or its item's (a leaf).
    #[inline]
    fn refit_node(&mut self, i: usize, item_box: &impl Fn(u32) -> (DVec3, DVec3)) {
        let (min, max) = match self.nodes[i].children(i) {
            Some([left, right]) => {
                let (l, r) = (&self.nodes[left], &self.nodes[right]);
                (l.min.min(r.min), l.max.max(r.max))
            }
            None => item_box(self.nodes[i].link),
        };
        self.nodes[i].min = min;
        self.nodes[i].max = max;
    }

    /// Per node its parent (`u32::MAX` for the root), and per item its leaf node.
    pub fn parents_and_leaves(&self, items: usize) -> (Vec<u32>, Vec<u32>) {
        let mut parent = vec![u32::MAX; self.nodes.len()];
        let mut leaf_of = vec![u32::MAX; items];
        for (i, node) in self.nodes.iter().enumerate() {
            match node.children(i) {
                Some([left, right]) => {
                    parent[left] = i as u32;
                    parent[right] = i as u32;
                }
                None => {
                    if let Some(slot) = leaf_of.get_mut(node.link as usize) {
                        *slot = i as u32;
                    }
                }
            }
        }
        (parent, leaf_of)
    }

    /// [`Self::refit`] of the nodes `dirty` only (sorted by decreasing index, so children come
    /// before their parents): the boxes of a full refit when every other node's box is already
    /// its items' (the boxes are minima and maxima, exact in any order).
    pub fn refit_nodes(&mut self, dirty: &[u32], item_box: impl Fn(u32) -> (DVec3, DVec3)) {
        for &i in dirty {
            self.refit_node(i as usize, &item_box);
        }
    }

    /// [`Self::refit`] of the nodes marked in `marked` only (by index; a prefix of the nodes
    /// holding every marked one), in decreasing index order so that children come before their
    /// parents, clearing the marks: the boxes of a full refit when every other node's box is
    /// already its items' (the boxes are minima and maxima, exact in any order).
    pub fn refit_marked(&mut self, marked: &mut [bool], item_box: impl Fn(u32) -> (DVec3, DVec3)) {
        for i in (0..marked.len()).rev() {
            if marked[i] {
                marked[i] = false;
                self.refit_node(i, &item_box);
            }
        }
    }

    /// Depth-first traversal, left child first: `visit(index, node)` decides whether to descend.
    #[inline]
    pub fn traverse(&self, mut visit: impl FnMut(usize, &Node) -> Visit) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = Stack::<u32>::new();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let i = i as usize;
            let node = &self.nodes[i];
            match visit(i, node) {
                Visit::Stop => return,
                Visit::Prune => {}
                Visit::Continue => {
                    if let Some([left, right]) = node.children(i) {
                        stack.push(right as u32);
                        stack.push(left as u32);
                    }
                }
            }
        }
    }

    /// Depth-first branch and bound for a best item: `key(node)` is a node's most promising cost
    /// (smaller first; `None`: the node cannot hold an answer), `hopeless(state, key)` says whether
    /// a key can no longer beat the best found so far, `leaf(state, item)` evaluates an item. The
    /// more promising child is visited first, so the best item is usually reached at once and the
    /// rest of the tree pruned.
    pub fn branch_and_bound<S>(
        &self,
        state: &mut S,
        key: impl Fn(&Node) -> Option<f64>,
        hopeless: impl Fn(&S, f64) -> bool,
        mut leaf: impl FnMut(&mut S, u32),
    ) {
        let Some(root) = self.nodes.first().and_then(&key) else { return };
        let mut stack = Stack::<(u32, f64)>::new();
        stack.push((0, root));
        while let Some((i, cost)) = stack.pop() {
            if hopeless(state, cost) {
                continue;
            }
            let i = i as usize;
            let node = &self.nodes[i];
            match node.children(i) {
                None => leaf(state, node.link),
                Some(children) => {
                    let keys = children.map(|c| key(&self.nodes[c]));
                    // Push the less promising child first so that the better one is popped next.
                    let order = match keys {
                        [Some(x), Some(y)] if y < x => [0, 1],
                        _ => [1, 0],
                    };
                    for k in order {
                        if let Some(cost) = keys[k]
                            && !hopeless(state, cost)
                        {
                            stack.push((children[k] as u32, cost));
                        }
                    }
                }
            }
        }
    }

    /// The items whose box overlaps `[min, max]` (touching counts), in tree order.
    pub fn for_each_in_box(&self, min: DVec3, max: DVec3, mut f: impl FnMut(u32)) {
        self.traverse(|_, node| {
            if !node.overlaps_box(min, max) {
                return Visit::Prune;
            }
            if let Some(item) = node.item() {
                f(item);
            }
            Visit::Continue
        });
    }

    /// Every pair (item of `self`, item of `other`) whose boxes overlap, by one joint descent of
    /// the two trees.
    pub fn for_each_overlapping_pair(&self, other: &FlatBvh, mut f: impl FnMut(u32, u32)) {
        self.descend_pairs(other, false, |i, j| {
            f(i, j);
            true
        });
    }

    /// Every pair of distinct items whose boxes overlap, each once (`f(i, j)`, in no particular
    /// order of `i` and `j`), by one descent of the tree against itself, until `f` returns false.
    pub fn for_each_overlapping_pair_within(&self, f: impl FnMut(u32, u32) -> bool) {
        self.descend_pairs(self, true, f);
    }

    /// The joint descent of [`Self::for_each_overlapping_pair`], until `f` returns false; `within`:
    /// `other` is `self`, and a subtree against itself gives each pair of its items once.
    fn descend_pairs(&self, other: &FlatBvh, within: bool, mut f: impl FnMut(u32, u32) -> bool) {
        if self.nodes.is_empty() || other.nodes.is_empty() {
            return;
        }
        let mut stack = Stack::<(u32, u32)>::new();
        stack.push((0, 0));
        while let Some((i, j)) = stack.pop() {
            let (i, j) = (i as usize, j as usize);
            let (a, b) = (&self.nodes[i], &other.nodes[j]);
            if within && i == j {
                // A subtree against itself: each child against itself, and the two against each other.
                if let Some([l, r]) = a.children(i) {
                    stack.push((l as u32, r as u32));
                    stack.push((r as u32, r as u32));
                    stack.push((l as u32, l as u32));
                }
                continue;
            }
            if !a.overlaps(b) {
                continue;
            }
            match (a.children(i), b.children(j)) {
                (None, None) => {
                    if !f(a.link, b.link) {
                        return;
                    }
                }
                (Some([l, r]), None) => {
                    stack.push((r as u32, j as u32));
                    stack.push((l as u32, j as u32));
                }
                (None, Some([l, r])) => {
                    stack.push((i as u32, r as u32));
                    stack.push((i as u32, l as u32));
                }
                (Some([al, ar]), Some([bl, br])) => {
                    // Descend the larger box first (the usual rule: it shrinks the pairs fastest).
                    let size = |n: &Node| (n.max - n.min).max_element();
                    if size(a) >= size(b) {
                        stack.push((ar as u32, j as u32));
                        stack.push((al as u32, j as u32));
                    } else {
                        stack.push((i as u32, br as u32));
                        stack.push((i as u32, bl as u32));
                    }
                }
            }
        }
    }
}

/// The smaller of each coordinate (of finite coordinates: the boxes are of finite triangles;
/// one comparison each, where `DVec3::min` also orders NaNs).
#[inline]
fn lower(a: DVec3, b: DVec3) -> DVec3 {
    DVec3::new(if b.x < a.x { b.x } else { a.x }, if b.y < a.y { b.y } else { a.y }, if b.z < a.z { b.z } else { a.z })
}

/// The larger of each coordinate (see [`lower`]).
#[inline]
fn upper(a: DVec3, b: DVec3) -> DVec3 {
    DVec3::new(if b.x > a.x { b.x } else { a.x }, if b.y > a.y { b.y } else { a.y }, if b.z > a.z { b.z } else { a.z })
}

/// Writes the subtree over `items` into `nodes` (its 2·`items.len()` − 1 nodes, in depth-first
/// order, the first at index `base` of the whole array). `bins` is scratch of the same length
/// (each item's bin during a split).
fn build(nodes: &mut [Node], base: usize, items: &mut [Item], bins: &mut [u8], depth: usize) {
    // The node's box and the bounds of the centroids, in one pass.
    let (mut min, mut max) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for item in items.iter() {
        min = lower(min, item.min);
        max = upper(max, item.max);
        lo = lower(lo, item.centroid);
        hi = upper(hi, item.centroid);
    }
    if let [item] = items {
        nodes[0] = Node { min, max, link: item.index, leaf: true };
        return;
    }
    let middle = split(items, bins, [lo, hi], depth);
    // The left subtree's 2·middle − 1 nodes follow this one; the right one starts after them.
    let (node, children) = nodes.split_at_mut(1);
    node[0] = Node { min, max, link: (base + 2 * middle) as u32, leaf: false };
    let (left_nodes, right_nodes) = children.split_at_mut(2 * middle - 1);
    let parallel = middle.min(items.len() - middle) >= PARALLEL_BUILD;
    let (left, right) = items.split_at_mut(middle);
    let (left_bins, right_bins) = bins.split_at_mut(middle);
    let mut left_build = move || build(left_nodes, base + 1, left, left_bins, depth + 1);
    let mut right_build = move || build(right_nodes, base + 2 * middle, right, right_bins, depth + 1);
    if parallel {
        rayon::join(left_build, right_build);
    } else {
        left_build();
        right_build();
    }
}

/// Reorders `items` (whose centroids lie within `[lo, hi]`) and returns the size of the left
/// part (≥ 1 and < `items.len()`); `bins` is scratch of the same length.
fn split(items: &mut [Item], bins: &mut [u8], [lo, hi]: [DVec3; 2], depth: usize) -> usize {
    let n = items.len();
    let extent = hi - lo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let median = |items: &mut [Item]| {
        items.sort_unstable_by(|p, q| p.centroid[axis].total_cmp(&q.centroid[axis]).then(p.index.cmp(&q.index)));
        n / 2
    };
    let width = extent[axis];
    if depth >= MEDIAN_DEPTH || !(width > 0.0 && width.is_finite()) {
        return median(items);
    }
    let (start, bins_per_width) = (lo[axis], BINS as f64);
    let mut count = [0usize; BINS];
    let mut bin_min = [DVec3::INFINITY; BINS];
    let mut bin_max = [DVec3::NEG_INFINITY; BINS];
    for (item, bin) in items.iter().zip(bins.iter_mut()) {
        let b = (((item.centroid[axis] - start) / width * bins_per_width) as usize).min(BINS - 1);
        *bin = b as u8;
        count[b] += 1;
        bin_min[b] = lower(bin_min[b], item.min);
        bin_max[b] = upper(bin_max[b], item.max);
    }
    let half_area = |min: DVec3, max: DVec3| {
        let d = (max - min).max(DVec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    };
    // Sweep from the right, then from the left: the cost of splitting before bin s.
    let mut right_area = [0.0; BINS];
    let mut right_count = [0usize; BINS];
    let (mut rmin, mut rmax, mut rc) = (DVec3::INFINITY, DVec3::NEG_INFINITY, 0);
    for s in (1..BINS).rev() {
        rmin = lower(rmin, bin_min[s]);
        rmax = upper(rmax, bin_max[s]);
        rc += count[s];
        right_area[s] = half_area(rmin, rmax);
        right_count[s] = rc;
    }
    let mut best: Option<(f64, usize)> = None;
    let (mut lmin, mut lmax, mut lc) = (DVec3::INFINITY, DVec3::NEG_INFINITY, 0);
    for s in 1..BINS {
        lmin = lower(lmin, bin_min[s - 1]);
        lmax = upper(lmax, bin_max[s - 1]);
        lc += count[s - 1];
        if lc == 0 || right_count[s] == 0 {
            continue;
        }
        let cost = half_area(lmin, lmax) * lc as f64 + right_area[s] * right_count[s] as f64;
        if best.is_none_or(|(c, _)| cost < c) {
            best = Some((cost, s));
        }
    }
    let Some((_, s)) = best else { return median(items) };
    // In-place partition, items of bins < s first (deterministic: a fixed sequence of swaps).
    let s = s as u8;
    let mut middle = 0;
    for i in 0..n {
        if bins[i] < s {
            items.swap(i, middle);
            bins.swap(i, middle);
            middle += 1;
        }
    }
    middle
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::Lcg;

    fn random_boxes(n: usize, seed: u64) -> Vec<(DVec3, DVec3)> {
        let mut lcg = Lcg::from_state(seed);
        let mut next = || lcg.next_unit();
        (0..n)
            .map(|_| {
                let c = DVec3::new(next(), next(), next()) * 10.0;
                let h = DVec3::new(next(), next(), next()) * 0.3;
                (c - h, c + h)
            })
            .collect()
    }

    fn check_boxes(tree: &FlatBvh, boxes: &[(DVec3, DVec3)]) {
        let ends = tree.subtree_ends();
        let mut seen = vec![0; boxes.len()];
        for (i, node) in tree.nodes().iter().enumerate() {
            // Every item below a node lies in its box, and the box is the exact union.
            let (mut min, mut max) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            for below in &tree.nodes()[i..ends[i]] {
                if let Some(item) = below.item() {
                    min = min.min(boxes[item as usize].0);
                    max = max.max(boxes[item as usize].1);
                }
            }
            assert_eq!((node.min, node.max), (min, max), "node {i}");
            if let Some(item) = node.item() {
                seen[item as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "every item in exactly one leaf");
    }

    #[test]
    fn the_tree_holds_every_item_once_in_exact_boxes_and_refits() {
        for n in [1, 2, 3, 17, 1000] {
            let boxes = random_boxes(n, n as u64);
            let mut tree = FlatBvh::new(&boxes);
            assert_eq!(tree.nodes().len(), 2 * n - 1);
            check_boxes(&tree, &boxes);
            let moved: Vec<(DVec3, DVec3)> = boxes.iter().map(|&(a, b)| (a * 2.0 + 1.0, b * 2.0 + 1.0)).collect();
            tree.refit(|i| moved[i as usize]);
            check_boxes(&tree, &moved);
        }
        assert!(FlatBvh::new(&[]).nodes().is_empty());
        // Identical boxes (no spread to split on) still give a balanced tree.
        let same = vec![(DVec3::ZERO, DVec3::ONE); 1024];
        let tree = FlatBvh::new(&same);
        check_boxes(&tree, &same);
        let mut depth = vec![0usize; tree.nodes().len()];
        for i in 0..tree.nodes().len() {
            if let Some([l, r]) = tree.nodes()[i].children(i) {
                depth[l] = depth[i] + 1;
                depth[r] = depth[i] + 1;
            }
        }
        assert_eq!(depth.iter().max(), Some(&10));
    }

    #[test]
    fn box_queries_and_overlapping_pairs_match_brute_force() {
        let (a, b) = (random_boxes(500, 1), random_boxes(300, 2));
        let (ta, tb) = (FlatBvh::new(&a), FlatBvh::new(&b));
        let overlap = |p: &(DVec3, DVec3), q: &(DVec3, DVec3)| p.0.cmple(q.1).all() && q.0.cmple(p.1).all();
        let mut pairs = Vec::new();
        ta.for_each_overlapping_pair(&tb, |i, j| pairs.push((i, j)));
        pairs.sort_unstable();
        let mut brute = Vec::new();
        for (i, p) in a.iter().enumerate() {
            for (j, q) in b.iter().enumerate() {
                if overlap(p, q) {
                    brute.push((i as u32, j as u32));
                }
            }
        }
        assert_eq!(pairs, brute);
        assert!(!pairs.is_empty());
        let query = (DVec3::splat(3.0), DVec3::splat(5.0));
        let mut found = Vec::new();
        ta.for_each_in_box(query.0, query.1, |i| found.push(i));
        found.sort_unstable();
        let brute: Vec<u32> = (0..a.len() as u32).filter(|&i| overlap(&a[i as usize], &query)).collect();
        assert_eq!(found, brute);
    }

    #[test]
    fn the_same_boxes_give_the_same_tree() {
        let boxes = random_boxes(700, 9);
        assert_eq!(FlatBvh::new(&boxes), FlatBvh::new(&boxes));
    }

    /// A pruned tree holds every kept item once, under its new id, in exact boxes once refitted,
    /// 2k − 1 nodes for k items, and is no deeper than the tree it came from.
    #[test]
    fn a_pruned_tree_holds_the_kept_items_once() {
        let boxes = random_boxes(3000, 5);
        let tree = FlatBvh::new(&boxes);
        let depth = |t: &FlatBvh| {
            let mut d = vec![0usize; t.nodes().len()];
            for i in 0..t.nodes().len() {
                if let Some([l, r]) = t.nodes()[i].children(i) {
                    d[l] = d[i] + 1;
                    d[r] = d[i] + 1;
                }
            }
            d.into_iter().max().unwrap_or(0)
        };
        for keep_every in [1, 2, 3, 7, 2999, 5000] {
            // Kept items renumbered in reverse, so that new ids differ from old ones.
            let kept: Vec<u32> = (0..3000).filter(|i| i % keep_every == 0).collect();
            let new_id = |i: u32| kept.iter().position(|&k| k == i).map(|p| (kept.len() - 1 - p) as u32);
            let mut pruned = tree.pruned(new_id);
            let new_boxes: Vec<(DVec3, DVec3)> = kept.iter().rev().map(|&i| boxes[i as usize]).collect();
            assert_eq!(pruned.nodes().len(), 2 * kept.len() - 1, "every {keep_every}");
            pruned.refit(|i| new_boxes[i as usize]);
            check_boxes(&pruned, &new_boxes);
            assert!(depth(&pruned) <= depth(&tree));
        }
        assert!(tree.pruned(|_| None).nodes().is_empty());
    }

    /// Enough items that the top splits build their subtrees side by side: the same nodes on one
    /// thread and on four, every item once in exact boxes.
    #[test]
    fn subtrees_built_side_by_side_give_the_tree_of_one_thread() {
        let boxes = random_boxes(8 * PARALLEL_BUILD + 3, 41);
        let on = |threads: usize| {
            rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| FlatBvh::new(&boxes))
        };
        let (one, four) = (on(1), on(4));
        assert_eq!(one, four);
        check_boxes(&four, &boxes);
        // The root's children are both large enough to have been built apart.
        let [left, right] = four.nodes()[0].children(0).unwrap();
        let ends = four.subtree_ends();
        assert!((ends[left] - left).min(ends[right] - right) >= 2 * PARALLEL_BUILD - 1);
    }
}
