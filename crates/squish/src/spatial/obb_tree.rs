//! A hierarchy of oriented bounding boxes over small planar items (triangles, quadrilaterals),
//! for the overlap queries of [`super::self_intersections`] on arbitrary geometry.
//!
//! Axis-aligned boxes bound long thin items badly: the box of a sliver lying diagonally is a
//! square, so a sheet cut into parallel diagonal slivers makes every box overlap every other and
//! an axis-aligned tree quadratic. An oriented box follows the items it holds (Gottschalk, Lin,
//! Manocha 1996), so parallel slivers are separated at every level. The axes of a node are
//! found without an eigen-decomposition: the direction between two far-apart points (a
//! diameter estimate), the direction to the point farthest from that line, and their cross
//! product; each node splits its items at the median of their centroids along its first axis.
//!
//! Every node also records the vertex ids shared by all its items (up to three, the ids of an
//! item being its face's): a query can then skip a whole subtree whose items all share a vertex
//! with the query item — a fan of a hundred thousand triangles around one vertex is one subtree
//! skipped, not a hundred thousand leaves visited.
//!
//! Conservative: boxes are widened by a margin far above the round-off of their computation, and
//! the separating-axis test skips near-degenerate cross-product axes, so two items that touch
//! are never reported apart (spurious overlaps only cost an exact test). Deterministic: the
//! build depends on the items only (ties broken by item index).

use glam::DVec3;

/// Marks an empty slot of [`Node::common`].
const NO_ID: u32 = u32::MAX;
/// Items per leaf.
const LEAF_SIZE: usize = 2;

/// An oriented box: the points x with |(x − center)·axes[k]| ≤ half[k].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Obb {
    center: DVec3,
    axes: [DVec3; 3],
    half: [f64; 3],
    /// Radius of the sphere around `center` that holds the box (a cheap first test).
    radius: f64,
}

impl Obb {
    /// The box of `points` with the given orthonormal `axes`, widened by `margin`.
    fn fitted(points: impl Iterator<Item = DVec3>, axes: [DVec3; 3], margin: f64) -> Self {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in points {
            for k in 0..3 {
                let t = p.dot(axes[k]);
                lo[k] = lo[k].min(t);
                hi[k] = hi[k].max(t);
            }
        }
        let mid = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
        let center = axes[0] * mid[0] + axes[1] * mid[1] + axes[2] * mid[2];
        let half = [0, 1, 2].map(|k| 0.5 * (hi[k] - lo[k]) + margin);
        // Widened by the margin too, so that it is never below the box's true radius.
        let radius = (half[0] * half[0] + half[1] * half[1] + half[2] * half[2]).sqrt() * (1.0 + 1e-9) + margin;
        Self { center, axes, half, radius }
    }

    /// Half of the box's surface area, for choosing between candidate frames.
    fn surface(&self) -> f64 {
        let [x, y, z] = self.half;
        x * y + y * z + z * x
    }

    /// The box of one planar item: axes along its longest edge, in its plane, and its normal.
    pub(crate) fn of_item(points: &[DVec3], margin: f64) -> Self {
        let mut longest = DVec3::ZERO;
        for (i, &p) in points.iter().enumerate() {
            for &q in &points[i + 1..] {
                if (q - p).length_squared() > longest.length_squared() {
                    longest = q - p;
                }
            }
        }
        let mut normal = DVec3::ZERO;
        for w in points.windows(3) {
            let n = (w[1] - w[0]).cross(w[2] - w[0]);
            if n.length_squared() > normal.length_squared() {
                normal = n;
            }
        }
        Self::fitted(points.iter().copied(), frame(longest, normal), margin)
    }

    /// True unless a separating axis proves the boxes disjoint: the 15 axes of Gottschalk et
    /// al., in the formulation of Ericson (*Real-Time Collision Detection*, §4.4.1), with a
    /// small term added to every |cos| so that the cross-product axes of nearly parallel edges,
    /// whose directions round-off decides, can only keep a pair.
    pub(crate) fn overlaps(&self, other: &Obb) -> bool {
        const EPS: f64 = 1e-9;
        let d = other.center - self.center;
        let reach = self.radius + other.radius;
        if d.length_squared() > reach * reach {
            return false;
        }
        let (a, b) = (&self.half, &other.half);
        let mut r = [[0.0; 3]; 3];
        let mut abs = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = self.axes[i].dot(other.axes[j]);
                abs[i][j] = r[i][j].abs() + EPS;
            }
        }
        let t = [d.dot(self.axes[0]), d.dot(self.axes[1]), d.dot(self.axes[2])];
        for i in 0..3 {
            if t[i].abs() > a[i] + b[0] * abs[i][0] + b[1] * abs[i][1] + b[2] * abs[i][2] {
                return false;
            }
        }
        for j in 0..3 {
            let tj = t[0] * r[0][j] + t[1] * r[1][j] + t[2] * r[2][j];
            if tj.abs() > a[0] * abs[0][j] + a[1] * abs[1][j] + a[2] * abs[2][j] + b[j] {
                return false;
            }
        }
        for i in 0..3 {
            let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
            for j in 0..3 {
                let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
                let ra = a[i1] * abs[i2][j] + a[i2] * abs[i1][j];
                let rb = b[j1] * abs[i][j2] + b[j2] * abs[i][j1];
                if (t[i2] * r[i1][j] - t[i1] * r[i2][j]).abs() > ra + rb {
                    return false;
                }
            }
        }
        true
    }
}

/// An orthonormal frame whose first axis is along `first` and third along `normal` made
/// perpendicular to it (any perpendicular when `normal` is parallel to `first` or zero).
fn frame(first: DVec3, normal: DVec3) -> [DVec3; 3] {
    let u = first.try_normalize().unwrap_or(DVec3::X);
    let w = perpendicular(u, normal).unwrap_or_else(|| u.any_orthonormal_vector());
    [u, w.cross(u), w]
}

/// One item of the tree: a planar polygon of up to four points, the id of what it belongs to
/// (a face) and that face's vertex ids (for [`ObbTree::query`]'s skipping rule).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Item {
    pub points: [DVec3; 4],
    pub len: u8,
    pub owner: u32,
    pub ids: [u32; 3],
}

impl Item {
    pub(crate) fn points(&self) -> &[DVec3] {
        &self.points[..self.len as usize]
    }

    fn centroid(&self) -> DVec3 {
        self.points().iter().copied().sum::<DVec3>() / self.len as f64
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    obb: Obb,
    /// Vertex ids every item below contains ([`NO_ID`] for an empty slot).
    common: [u32; 3],
    /// Leaf: items `first..first + count` of [`ObbTree::order`]; inner: `count == 0` and the
    /// children are `first` and `first + 1`.
    first: u32,
    count: u32,
}

/// The tree (see the module docs).
pub(crate) struct ObbTree {
    items: Vec<Item>,
    boxes: Vec<Obb>,
    order: Vec<u32>,
    nodes: Vec<Node>,
}

impl ObbTree {
    /// Builds the tree; `margin` widens every box (see the module docs).
    pub(crate) fn new(items: Vec<Item>, margin: f64) -> Self {
        let boxes: Vec<Obb> = items.iter().map(|i| Obb::of_item(i.points(), margin)).collect();
        let centroids: Vec<DVec3> = items.iter().map(Item::centroid).collect();
        let mut order: Vec<u32> = (0..items.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * items.len() / LEAF_SIZE + 1);
        if !items.is_empty() {
            nodes.push(placeholder());
            let mut stack = vec![(0usize, 0usize, items.len())];
            let mut points: Vec<DVec3> = Vec::with_capacity(items.len());
            while let Some((node, start, end)) = stack.pop() {
                let range = &mut order[start..end];
                // The first axis from the items' centroids (a quarter of the points), the second
                // and the extents from all points: collinear centroids (a stack of parallel
                // slivers) leave the second axis to the items' own extent.
                points.clear();
                points.extend(range.iter().map(|&i| centroids[i as usize]));
                let all = range.iter().flat_map(|&i| items[i as usize].points().iter().copied());
                // Two candidate frames, the smaller box kept: the spread of the centroids, and
                // the items' own mean direction (a stack of parallel slivers, whose centroids
                // spread across them, is bounded tightly only along them).
                let spread = spread_axes(&points, all.clone());
                let first = boxes[range[0] as usize].axes[0];
                let mean: DVec3 = range
                    .iter()
                    .map(|&i| {
                        let d = boxes[i as usize].axes[0];
                        if d.dot(first) < 0.0 { -d } else { d }
                    })
                    .sum();
                let along = spread_axes_from(mean.try_normalize().unwrap_or(first), points[0], all.clone());
                let (a, b) = (Obb::fitted(all.clone(), spread, margin), Obb::fitted(all, along, margin));
                let obb = if b.surface() < a.surface() { b } else { a };
                // Split along the frame's axis of largest centroid spread.
                let axis = (0..3)
                    .map(|k| {
                        let (lo, hi) = points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
                            let t = c.dot(obb.axes[k]);
                            (lo.min(t), hi.max(t))
                        });
                        (hi - lo, k)
                    })
                    .fold((f64::NEG_INFINITY, 0), |best, x| if x.0 > best.0 { x } else { best })
                    .1;
                let split_axis = obb.axes[axis];
                let common = common_ids(range.iter().map(|&i| &items[i as usize]));
                if range.len() <= LEAF_SIZE {
                    nodes[node] = Node { obb, common, first: start as u32, count: range.len() as u32 };
                    continue;
                }
                let mid = range.len() / 2;
                let key = |i: &u32| (centroids[*i as usize].dot(split_axis), *i);
                range.select_nth_unstable_by(mid, |a, b| {
                    let (ka, kb) = (key(a), key(b));
                    ka.0.total_cmp(&kb.0).then(ka.1.cmp(&kb.1))
                });
                let left = nodes.len();
                nodes.push(placeholder());
                nodes.push(placeholder());
                nodes[node] = Node { obb, common, first: left as u32, count: 0 };
                stack.push((left, start, start + mid));
                stack.push((left + 1, start + mid, end));
            }
        }
        Self { items, boxes, order, nodes }
    }

    pub(crate) fn items(&self) -> &[Item] {
        &self.items
    }

    /// Calls `visit` with every item whose box overlaps the box of item `query`, skipping the
    /// subtrees whose items all contain a vertex of `skip_ids` (ids equal to `keep` excepted);
    /// stops as soon as `visit` returns true, and returns whether it did.
    pub(crate) fn query(&self, query: u32, skip_ids: [u32; 3], keep: u32, mut visit: impl FnMut(u32) -> bool) -> bool {
        let Some(root) = self.nodes.first() else { return false };
        let q = &self.boxes[query as usize];
        let skipped = |common: &[u32; 3]| common.iter().any(|&c| c != NO_ID && c != keep && skip_ids.contains(&c));
        let mut stack = Vec::with_capacity(64);
        if !skipped(&root.common) && root.obb.overlaps(q) {
            stack.push(0u32);
        }
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            if node.count > 0 {
                let items = &self.order[node.first as usize..(node.first + node.count) as usize];
                for &i in items {
                    if i != query && self.boxes[i as usize].overlaps(q) && visit(i) {
                        return true;
                    }
                }
                continue;
            }
            for child in [node.first, node.first + 1] {
                let c = &self.nodes[child as usize];
                if !skipped(&c.common) && c.obb.overlaps(q) {
                    stack.push(child);
                }
            }
        }
        false
    }
}

fn placeholder() -> Node {
    let obb = Obb { center: DVec3::ZERO, axes: [DVec3::X, DVec3::Y, DVec3::Z], half: [0.0; 3], radius: 0.0 };
    Node { obb, common: [NO_ID; 3], first: 0, count: 0 }
}

/// The ids contained in every item (at most three).
fn common_ids<'a>(mut items: impl Iterator<Item = &'a Item>) -> [u32; 3] {
    let Some(first) = items.next() else { return [NO_ID; 3] };
    let mut common = first.ids;
    for item in items {
        for c in &mut common {
            if *c != NO_ID && !item.ids.contains(c) {
                *c = NO_ID;
            }
        }
        if common == [NO_ID; 3] {
            break;
        }
    }
    common
}

/// Axes that follow the spread of a node: a diameter estimate of its `centroids` (the farthest
/// from the first, then the farthest from that), the direction to the one of its `points`
/// farthest from that line, and their cross product. O(points).
fn spread_axes(centroids: &[DVec3], points: impl Iterator<Item = DVec3>) -> [DVec3; 3] {
    let Some(&start) = centroids.first() else { return [DVec3::X, DVec3::Y, DVec3::Z] };
    let farthest = |from: DVec3| {
        centroids.iter().fold((from, 0.0), |(best, d), &p| {
            let e = (p - from).length_squared();
            if e > d { (p, e) } else { (best, d) }
        })
    };
    let (a, _) = farthest(start);
    let (b, _) = farthest(a);
    let u = (b - a).try_normalize().unwrap_or(DVec3::X);
    spread_axes_from(u, a, points)
}

/// A frame whose first axis is `u` and whose third points from the line through `a` along `u`
/// toward the farthest of `points`.
fn spread_axes_from(u: DVec3, a: DVec3, points: impl Iterator<Item = DVec3>) -> [DVec3; 3] {
    let (c, _) = points.fold((a, 0.0), |(best, d), p| {
        let r = p - a;
        let e = (r - u * r.dot(u)).length_squared();
        if e > d { (p, e) } else { (best, d) }
    });
    frame(u, c - a)
}

/// The part of `v` perpendicular to the unit vector `u`, normalized; `None` when it is lost in
/// round-off (v nearly parallel to u, or zero).
fn perpendicular(u: DVec3, v: DVec3) -> Option<DVec3> {
    let p = v - u * v.dot(u);
    if p.length_squared() > 1e-20 * v.length_squared() {
        // Once more: the first subtraction leaves a component along u of the order of its
        // round-off relative to |v|, which is large relative to a small |p|.
        let p = p.normalize();
        (p - u * p.dot(u)).try_normalize()
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle(points: [DVec3; 3], owner: u32) -> Item {
        Item {
            points: [points[0], points[1], points[2], DVec3::ZERO],
            len: 3,
            owner,
            ids: [3 * owner, 3 * owner + 1, 3 * owner + 2],
        }
    }

    /// Parallel diagonal slivers 0.01 apart: an oriented box separates each from its neighbours
    /// beyond the next one, where axis-aligned boxes (squares) would overlap them all.
    #[test]
    fn diagonal_slivers_overlap_only_their_neighbours() {
        let dir = DVec3::new(1.0, 1.0, 0.0).normalize();
        let across = DVec3::new(-1.0, 1.0, 0.0).normalize();
        let items: Vec<Item> = (0..200)
            .map(|i| {
                let o = across * (0.01 * i as f64);
                triangle([o, o + dir * 2.0, o + dir + across * 0.004], i)
            })
            .collect();
        let tree = ObbTree::new(items, 1e-9);
        for q in 0..200u32 {
            let mut seen = Vec::new();
            tree.query(q, [u32::MAX; 3], u32::MAX, |i| {
                seen.push(i);
                false
            });
            assert!(seen.iter().all(|&i| i.abs_diff(q) <= 1), "{q}: {seen:?}");
        }
    }

    /// Every pair of items that truly intersect is visited (conservative boxes), and subtrees
    /// whose items all share a skipped vertex are not.
    #[test]
    fn overlapping_items_are_never_missed_and_shared_vertices_skip_subtrees() {
        let mut rng = 12345u64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut items = Vec::new();
        for i in 0..300 {
            let c = DVec3::new(next(), next(), next()) * 4.0;
            let p = [c, c + DVec3::new(next(), next(), next()) - 0.5, c + DVec3::new(next(), next(), next()) - 0.5];
            items.push(triangle(p, i));
        }
        let tree = ObbTree::new(items.clone(), 1e-9);
        for q in 0..items.len() as u32 {
            let mut seen = vec![false; items.len()];
            tree.query(q, [u32::MAX; 3], u32::MAX, |i| {
                seen[i as usize] = true;
                false
            });
            for (i, item) in items.iter().enumerate() {
                let t1 = [item.points[0], item.points[1], item.points[2]];
                let t2 = [items[q as usize].points[0], items[q as usize].points[1], items[q as usize].points[2]];
                if i as u32 != q && crate::spatial::triangles_intersect(&t1, &t2) {
                    assert!(seen[i], "pair ({q}, {i}) intersects but was not visited");
                }
            }
        }
        // A fan: every item contains vertex 7; skipping 7 visits nothing.
        let fan: Vec<Item> = (0..100)
            .map(|i| {
                let a = i as f64 * 0.05;
                let (p, q) = (DVec3::new(a.cos(), a.sin(), 0.0), DVec3::new((a + 0.05).cos(), (a + 0.05).sin(), 0.0));
                Item { points: [DVec3::ZERO, p, q, DVec3::ZERO], len: 3, owner: i, ids: [7, 100 + i, 101 + i] }
            })
            .collect();
        let tree = ObbTree::new(fan, 1e-9);
        let mut visits = 0;
        tree.query(50, [7, 150, 151], u32::MAX, |_| {
            visits += 1;
            false
        });
        assert_eq!(visits, 0);
        // Keeping 7 (a star's own vertex) no longer skips them: they all touch at the apex, and
        // only a subtree that also shares 150 or 151 with item 50 may be skipped.
        let mut seen = vec![false; 100];
        tree.query(50, [7, 150, 151], 7, |i| {
            seen[i as usize] = true;
            false
        });
        assert!((0..100).all(|i| seen[i] || [49, 50, 51].contains(&i)), "{seen:?}");
    }
}
