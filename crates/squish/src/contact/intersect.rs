//! Collision detection and intersection regions ℐ_a, ℐ_b (thesis §4.1).
//!
//! Every edge of each working region is intersected with the faces of the other one, both ways
//! ([`mutual_edge_crossings`]: one joint traversal of the two triangle trees, the same exact,
//! symbolically perturbed crossings as querying each edge, in parallel, results in edge order). Every crossing is kept as an
//! [`IntersectionPoint`]: its location on the crossed edge (edge id and parameter t) and on the
//! crossed face (face id and barycentric coordinates), i.e. "pairs of barycentric coordinates on
//! both surfaces".
//!
//! **Tags.** For each crossed edge, each end is tagged from its *closest* crossing along the edge
//! (the first hit for the edge's start, the last hit for its end): *interior* if the end lies
//! behind that face of the other mesh, *exterior* otherwise. [`Hit::entering`]
//! says that the segment goes from the face's front to its back, so the start is exterior when
//! the first hit is entering and the end is interior when the last hit is entering.
//!
//! **Conflicts.** The thesis lets "the last edge considered have the final say" when two edges of a
//! vertex disagree (§4.1, discussion), which depends on the edge order. We decide instead, and
//! deterministically: if the other mesh is closed, by its winding number at the vertex (exact
//! ray parity, [`TriangleBvh::contains`](crate::spatial::TriangleBvh::contains)); otherwise by the majority of the vertex's tagged edges,
//! ties going to *exterior* (the conservative choice: a smaller region).
//!
//! **Flood fill.** The interior tag spreads through edges *without* crossings, never into a vertex
//! tagged exterior. ℐ_l is then the [`EdgeRegion`] of the interior vertices with, on each edge
//! from an interior vertex i to an exterior vertex j, α = the crossing nearest to i. An edge
//! joining an interior and an exterior vertex without any crossing can only come from a conflict
//! decided against the edge's own evidence; it is cut at its midpoint and counted.
//!
//! **Not representable.** Crossings on an edge whose two ends end up exterior (a thin tip of the
//! other object poking through between the two vertices) or interior cannot be expressed with one
//! point per edge: they are counted and dropped. If a whole side has no interior vertex, ℐ_l is
//! empty there and the mapping direction falls back on the other side's integrals
//! ([`super::direction`]).
//!
//! **Given interior.** A caller may decide which vertices are inside the other side
//! ([`ContactSide::interior`]); tags and flood fill are then skipped for that side and ℐ is those
//! vertices — the parts of them connected to a crossed edge, a part no crossing reaches being
//! inside something else — bounded on each crossed edge by its crossing nearest to the inside
//! vertex as above.
//! Self-contact needs it (ch. 6): its two sides are the two halves of one closed mesh cut along
//! the crease, so each intersection curve ends near the cut instead of closing, and a flood fill
//! leaks around its end into the whole side.
//!
//! **Working-region borders.** A working region cut out of a bigger mesh has "border" vertices
//! (flagged by the caller). If ℐ_l reaches one of them, the intersection is not closed inside the
//! region and the result would depend on where the region was cut: this is
//! [`ContactError::IntersectionReachesBorder`], naming the object and the vertex. Genuine
//! boundaries of open meshes (not flagged) are fine.

use glam::DVec3;
use rayon::prelude::*;

use super::{ContactError, ContactSide, EdgeRegion};
use crate::params::VertexFlags;
use crate::spatial::{BatchHits, EdgeCrossings, EdgeSource, Hit, mutual_edge_crossings};
use crate::stage::SharedWork;

/// One crossing of an edge of one working region with a face of the other.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct IntersectionPoint {
    /// The side whose edge is crossed: 0 for the first object of the pair (a), 1 for b. The face
    /// belongs to the other side.
    pub edge_side: u8,
    /// The crossed edge (index into the edge side's [`Topology::edges`](crate::mesh::Topology)).
    pub edge: u32,
    /// Position along the edge, from its first vertex (`edges[edge][0]`, t = 0) to its second.
    pub t: f64,
    /// The crossed face of the other side.
    pub face: u32,
    /// Barycentric coordinates on that face, in its corner order.
    pub bary: [f64; 3],
    /// The point (computed on the face).
    pub position: DVec3,
    /// The edge goes from the face's front to its back.
    pub entering: bool,
}

/// Counters of the cases the intersection stage had to decide or could not represent.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct IntersectionStats {
    /// Vertices whose edges disagreed, decided by the other mesh's winding number.
    pub conflicts_by_winding: usize,
    /// Vertices whose edges disagreed, decided by a majority of their edges (open other mesh).
    pub conflicts_by_majority: usize,
    /// Edges joining an interior and an exterior vertex without a crossing (cut at the midpoint).
    pub edges_without_crossing: usize,
    /// Crossed edges whose two ends are on the same side (crossings not representable).
    pub unrepresentable_edges: usize,
}

/// Result of the intersection stage.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Intersection {
    /// All crossings: the edges of a against the faces of b, then the edges of b against the
    /// faces of a, in edge order and along each edge.
    pub points: Vec<IntersectionPoint>,
    /// ℐ_a and ℐ_b.
    pub regions: [EdgeRegion; 2],
    /// Decided and dropped cases.
    pub stats: IntersectionStats,
}

/// Vertex tag from the crossed edges.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Tag {
    None,
    Interior,
    Exterior,
}

/// Computes the intersection points and regions ℐ_a, ℐ_b of two working regions (§4.1).
///
/// Returns an empty [`Intersection`] (no point, empty regions) when they do not intersect.
/// Errors: [`ContactError::IntersectionReachesBorder`] when a region reaches a flagged border.
pub fn intersect(a: &ContactSide, b: &ContactSide) -> Result<Intersection, ContactError> {
    // Both directions in one joint traversal of the two trees (bit-identical to querying every
    // edge of each side against the other's tree).
    let [crossings_a, crossings_b] = mutual_edge_crossings(
        EdgeSource { tree: a.bvh, positions: &a.mesh.positions, topology: a.topology },
        EdgeSource { tree: b.bvh, positions: &b.mesh.positions, topology: b.topology },
    );
    let hits = [EdgeHits::new(a.topology.num_edges(), crossings_a), EdgeHits::new(b.topology.num_edges(), crossings_b)];
    let mut result = Intersection::default();
    for (l, edge_hits) in hits.iter().enumerate() {
        for (&e, list) in edge_hits.tested.iter().zip(edge_hits.batch.iter()) {
            for h in list {
                result.points.push(IntersectionPoint {
                    edge_side: l as u8,
                    edge: e,
                    t: h.t,
                    face: h.face,
                    bary: h.bary,
                    position: h.point,
                    entering: h.entering,
                });
            }
        }
    }
    if result.points.is_empty() {
        result.regions = [EdgeRegion::empty(a.topology), EdgeRegion::empty(b.topology)];
        return Ok(result);
    }
    let mut stats = IntersectionStats::default();
    let region_a = intersection_region(a, b, &hits[0], &mut stats)?;
    let region_b = intersection_region(b, a, &hits[1], &mut stats)?;
    result.regions = [region_a, region_b];
    result.stats = stats;
    Ok(result)
}

/// Marks an edge without crossing in [`EdgeHits::slot`].
const UNTESTED: u32 = u32::MAX;

/// The crossings of the edges of one side with the faces of the other.
struct EdgeHits {
    /// Per edge: its index in `tested`, or [`UNTESTED`].
    slot: Vec<u32>,
    /// The edges with at least one crossing, increasing.
    tested: Vec<u32>,
    /// Their crossings, sorted along each edge.
    batch: BatchHits,
}

impl EdgeHits {
    /// Indexes the crossings of a side with `num_edges` edges.
    fn new(num_edges: usize, crossings: EdgeCrossings) -> Self {
        let mut slot = vec![UNTESTED; num_edges];
        for (k, &e) in crossings.edges.iter().enumerate() {
            if let Some(s) = slot.get_mut(e as usize) {
                *s = k as u32;
            }
        }
        Self { slot, tested: crossings.edges, batch: crossings.hits }
    }

    /// The crossings of edge `e`, sorted along it.
    fn get(&self, e: usize) -> &[Hit] {
        match self.slot.get(e) {
            Some(&s) if s != UNTESTED => self.batch.get(s as usize),
            _ => &[],
        }
    }
}

/// The interior of a side decided by the caller ([`super::ContactSide::interior`]).
#[derive(Clone, Copy, Debug)]
pub enum Interior<'a> {
    /// One flag per vertex of the side.
    Flags(&'a [bool]),
    /// Flags of the object's vertices, asked for the side's vertices `v` (as `parent[v]`) that
    /// the intersection stage reaches: those on a crossing edge and, through flagged vertices,
    /// their neighbours. The answers are those of asking every vertex (the flags are a function
    /// of the vertex), for the cost of the few near the intersection.
    Asked { flags: &'a VertexFlags, parent: &'a [u32] },
}

impl Interior<'_> {
    /// The number of vertices it answers for.
    pub fn len(&self) -> usize {
        match self {
            Self::Flags(flags) => flags.len(),
            Self::Asked { parent, .. } => parent.len(),
        }
    }

    /// True if it answers for no vertex.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The flags of the side's vertices `vertices`, in their order.
    pub fn of(&self, vertices: &[u32]) -> Vec<bool> {
        match self {
            Self::Flags(flags) => vertices.iter().map(|&v| flags.get(v as usize).copied().unwrap_or(false)).collect(),
            Self::Asked { flags, parent } => {
                let objects: Vec<u32> = vertices.iter().filter_map(|&v| parent.get(v as usize).copied()).collect();
                let answers = flags.of(&objects);
                let mut answers = answers.into_iter();
                vertices.iter().map(|&v| parent.get(v as usize).is_some() && answers.next().unwrap_or(false)).collect()
            }
        }
    }
}

/// ℐ on `side`, from the crossings of its edges with `other`'s faces.
fn intersection_region(
    side: &ContactSide,
    other: &ContactSide,
    hits: &EdgeHits,
    stats: &mut IntersectionStats,
) -> Result<EdgeRegion, ContactError> {
    let topology = side.topology;
    let edges = topology.edges();
    let nv = topology.num_vertices();
    let inside = match side.interior {
        Some(given) => touching_crossings(side, hits, given),
        None => match flood_interior(side, other, hits, stats) {
            Some(inside) => inside,
            None => return Ok(EdgeRegion::empty(topology)),
        },
    };
    if let Some(border) = side.border
        && let Some(v) = (0..nv).find(|&v| inside[v] && border.get(v).copied().unwrap_or(false))
    {
        return Err(ContactError::IntersectionReachesBorder { object: side.display_name(), vertex: v as u32 });
    }
    for (&e, list) in hits.tested.iter().zip(hits.batch.iter()) {
        let [lo, hi] = edges[e as usize];
        if !list.is_empty() && inside[lo as usize] == inside[hi as usize] {
            stats.unrepresentable_edges += 1;
        }
    }
    let mut without_crossing = 0;
    let region = EdgeRegion::from_inside(topology, inside, |e, i, _| {
        let list = hits.get(e as usize);
        match (list.first(), list.last()) {
            (Some(first), Some(last)) => {
                if i == edges[e as usize][0] {
                    first.t
                } else {
                    1.0 - last.t
                }
            }
            _ => {
                without_crossing += 1;
                0.5
            }
        }
    });
    stats.edges_without_crossing += without_crossing;
    Ok(region)
}

/// The given interior vertices that are connected (through interior vertices) to an edge that
/// crosses the other side: a part of the given set that no crossing reaches lies inside
/// something else than the other side (a thigh inside the other thigh, when the given flags are
/// "inside another part of the same body"), and is dropped. The flags are asked for only the
/// vertices this reaches, ring by ring: the crossing edges' ends, then the neighbours of the
/// vertices found inside (a set that does not depend on the order they are asked in).
fn touching_crossings(side: &ContactSide, hits: &EdgeHits, given: Interior) -> Vec<bool> {
    let nv = side.topology.num_vertices();
    let edges = side.topology.edges();
    let mut inside = vec![false; nv];
    // Per vertex: its flag was asked for.
    let mut asked = vec![false; nv];
    let mut ring: Vec<u32> = Vec::new();
    for (&e, list) in hits.tested.iter().zip(hits.batch.iter()) {
        if list.is_empty() {
            continue;
        }
        for v in edges[e as usize] {
            if !asked[v as usize] {
                asked[v as usize] = true;
                ring.push(v);
            }
        }
    }
    while !ring.is_empty() {
        ring.sort_unstable();
        let flags = given.of(&ring);
        let mut next = Vec::new();
        for (&v, flagged) in ring.iter().zip(flags) {
            if !flagged {
                continue;
            }
            inside[v as usize] = true;
            for w in side.topology.vertex_neighbors(v) {
                if !asked[w as usize] {
                    asked[w as usize] = true;
                    next.push(w);
                }
            }
        }
        ring = next;
    }
    inside
}

/// The interior vertices of `side` from the tags of its crossed edges and a flood fill (see the
/// module doc); `None` when no edge is crossed.
fn flood_interior(
    side: &ContactSide,
    other: &ContactSide,
    hits: &EdgeHits,
    stats: &mut IntersectionStats,
) -> Option<Vec<bool>> {
    let topology = side.topology;
    let edges = topology.edges();
    let nv = topology.num_vertices();
    let mut votes = vec![[0u32; 2]; nv]; // [interior, exterior]
    let mut any = false;
    for (&e, list) in hits.tested.iter().zip(hits.batch.iter()) {
        let (Some(first), Some(last)) = (list.first(), list.last()) else { continue };
        any = true;
        let [lo, hi] = edges[e as usize];
        // The start lies in front of its closest face (exterior) when the edge enters through it.
        votes[lo as usize][usize::from(first.entering)] += 1;
        // The end lies behind its closest face (interior) when the edge entered through it.
        votes[hi as usize][usize::from(!last.entering)] += 1;
    }
    if !any {
        return None;
    }
    let mut tags: Vec<Tag> = votes
        .iter()
        .map(|&[i, x]| match (i > 0, x > 0) {
            (true, false) => Tag::Interior,
            (false, true) => Tag::Exterior,
            _ => Tag::None,
        })
        .collect();
    let conflicts: Vec<u32> = (0..nv as u32).filter(|&v| votes[v as usize].iter().all(|&n| n > 0)).collect();
    if !conflicts.is_empty() {
        if other.topology.is_closed() {
            let work = SharedWork::default();
            let inside: Vec<bool> = conflicts
                .par_iter()
                .map(|&v| work.measure(|| other.bvh.contains(side.mesh.positions[v as usize])))
                .collect();
            work.record();
            for (&v, inside) in conflicts.iter().zip(inside) {
                tags[v as usize] = if inside { Tag::Interior } else { Tag::Exterior };
            }
            stats.conflicts_by_winding += conflicts.len();
        } else {
            for &v in &conflicts {
                let [i, x] = votes[v as usize];
                tags[v as usize] = if i > x { Tag::Interior } else { Tag::Exterior };
            }
            stats.conflicts_by_majority += conflicts.len();
        }
    }

    // Flood fill through uncrossed edges, never into an exterior vertex.
    let mut inside: Vec<bool> = tags.iter().map(|&t| t == Tag::Interior).collect();
    let mut stack: Vec<u32> = (0..nv as u32).filter(|&v| inside[v as usize]).collect();
    while let Some(v) = stack.pop() {
        for &e in topology.vertex_edges(v) {
            if !hits.get(e as usize).is_empty() {
                continue;
            }
            let w = topology.other_vertex(e, v);
            if !inside[w as usize] && tags[w as usize] != Tag::Exterior {
                inside[w as usize] = true;
                stack.push(w);
            }
        }
    }
    Some(inside)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::test_support::{Owned, sphere_in_grid};
    use crate::mesh::TriMesh;

    /// A unit sphere dipped into a grid: ℐ on the sphere is exactly the set of vertices below the
    /// plane, ℐ on the grid exactly the grid vertices inside the (polyhedral) sphere, and every
    /// boundary point lies on the intersection curve.
    #[test]
    fn tags_and_flood_fill_on_a_sphere_dipped_into_a_plane() {
        let (sphere, grid) = sphere_in_grid(0.2, 4, 60);
        let inter = intersect(&sphere.side(), &grid.side()).unwrap();
        let [is, ig] = &inter.regions;
        assert!(!inter.points.is_empty());
        for v in 0..sphere.mesh.num_vertices() {
            assert_eq!(is.contains(v as u32), sphere.mesh.positions[v].z < 0.0, "sphere vertex {v}");
        }
        let mut n_inside = 0;
        for v in 0..grid.mesh.num_vertices() {
            let inside = sphere.bvh.contains(grid.mesh.positions[v]);
            assert_eq!(ig.contains(v as u32), inside, "grid vertex {v}");
            n_inside += usize::from(inside);
        }
        assert!(n_inside > 100, "{n_inside}");
        assert_eq!(inter.stats, IntersectionStats::default());
        // Boundary points of ℐ_sphere lie on the plane, those of ℐ_grid on the sphere mesh.
        for p in 0..is.points().len() as u32 {
            assert!(is.point_position(&sphere.mesh, p).z.abs() < 1e-12);
        }
        for p in 0..ig.points().len() as u32 {
            let q = ig.point_position(&grid.mesh, p);
            assert!(sphere.bvh.closest_point(q).unwrap().distance < 1e-12);
        }
    }

    /// Interior flags asked for the vertices the intersection reaches give the intersection of
    /// flags given for every vertex, and are asked for few of them: two overlapping spheres, each
    /// flagged inside the other and, as a decoy, inside "something else" on its far side (a
    /// patch no crossing reaches, dropped either way).
    #[test]
    fn interior_flags_asked_where_needed_give_those_of_every_vertex() {
        use std::sync::Arc;
        use std::sync::atomic::{AtomicUsize, Ordering};
        let centres = [DVec3::ZERO, DVec3::new(1.2, 0.0, 0.0)];
        let spheres = centres.map(|c| Owned::new(crate::mesh::shapes::icosphere(1.0, 3), c));
        let flags_of = |l: usize| -> Vec<bool> {
            let (own, other) = (centres[l], centres[1 - l]);
            spheres[l]
                .mesh
                .positions
                .iter()
                .map(|&p| (p - other).length() < 1.0 || (p - own).dot(own - other) > 0.8 * (own - other).length())
                .collect()
        };
        let given = [flags_of(0), flags_of(1)];
        let asked = Arc::new(AtomicUsize::new(0));
        let lazy = [0, 1].map(|l| {
            let (flags, asked) = (given[l].clone(), Arc::clone(&asked));
            crate::params::VertexFlags::new(move |vertices| {
                asked.fetch_add(vertices.len(), Ordering::Relaxed);
                vertices.iter().map(|&v| flags[v as usize]).collect()
            })
        });
        let identity: Vec<u32> = (0..spheres[0].mesh.num_vertices() as u32).collect();
        let full = intersect(
            &spheres[0].side().with_interior(Some(&given[0])),
            &spheres[1].side().with_interior(Some(&given[1])),
        )
        .unwrap();
        let by_asking = intersect(
            &spheres[0].side().with_interior_asked(Some((&lazy[0], &identity))),
            &spheres[1].side().with_interior_asked(Some((&lazy[1], &identity))),
        )
        .unwrap();
        assert!(!full.points.is_empty() && full.regions.iter().all(|r| r.num_inside() > 0));
        assert_eq!(full, by_asking);
        // The decoys are flagged but never reached.
        for (l, region) in full.regions.iter().enumerate() {
            let flagged = given[l].iter().filter(|&&f| f).count();
            assert!(region.num_inside() < flagged, "side {l}: {} of {flagged}", region.num_inside());
        }
        let total = 2 * spheres[0].mesh.num_vertices();
        let asked = asked.load(Ordering::Relaxed);
        assert!(asked < total / 2, "asked {asked} of {total}");
    }

    #[test]
    fn disjoint_meshes_give_empty_regions() {
        let (sphere, mut grid) = sphere_in_grid(0.2, 3, 10);
        grid.translate(DVec3::new(0.0, 0.0, -1.0));
        let inter = intersect(&sphere.side(), &grid.side()).unwrap();
        assert!(inter.points.is_empty());
        assert!(inter.regions.iter().all(EdgeRegion::is_empty));
    }

    #[test]
    fn reaching_a_cut_border_is_an_error_naming_the_object_and_vertex() {
        // The grid is a 1 × 1 piece "cut out of a bigger plane": its boundary vertices are border
        // vertices. A sphere wider than the piece makes the intersection reach them.
        // The sphere's section by the plane has radius 0.6: it leaves the 1 × 1 piece near the
        // middle of its sides and passes inside its corners.
        let sphere = Owned::new(crate::mesh::shapes::icosphere(1.0, 3), DVec3::new(0.0, 0.0, 0.8));
        let grid = Owned::new(crate::mesh::shapes::grid(1.0, 1.0, 10, 10), DVec3::ZERO);
        let border = grid.topology.boundary_vertices();
        let err = intersect(&sphere.side(), &grid.side().with_name("floor").with_border(Some(&border))).unwrap_err();
        match &err {
            ContactError::IntersectionReachesBorder { object, vertex } => {
                assert_eq!(object, "floor");
                assert!(border[*vertex as usize]);
            }
            other => panic!("unexpected {other}"),
        }
        assert!(err.to_string().contains("larger working region"), "{err}");
        // The same open grid without border flags (a genuine open mesh) is fine.
        let inter = intersect(&sphere.side(), &grid.side()).unwrap();
        let region = &inter.regions[1];
        assert!(region.num_inside() < grid.mesh.num_vertices());
        assert!((0..border.len()).any(|v| border[v] && region.contains(v as u32)));
    }

    /// A vertex whose edges disagree: v = origin, the centre of a fan in the plane z = 0, lies
    /// inside cube 2 (its −x and −y edges leave it: interior votes) while its +x and +y edges
    /// first enter cubes 3 and 1 (exterior votes). Tie. With the three cubes (a closed, if
    /// self-intersecting, mesh) the winding number decides: interior. With an extra open triangle
    /// far away the other mesh is open: the majority rule applies and the tie goes to exterior.
    #[test]
    fn conflicting_tags_are_decided_by_winding_or_majority() {
        let fan = TriMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, -DVec3::X, -DVec3::Y],
            triangles: vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]],
        };
        let mut cubes = TriMesh::default();
        for center in [DVec3::new(0.0, 0.7, 0.03), DVec3::new(0.3, 0.02, 0.03), DVec3::new(0.6, 0.02, 0.03)] {
            let mut cube = crate::mesh::shapes::cube(1.0, 1);
            cube.map_positions(|p| p + center);
            cubes.append(&cube);
        }
        let a = Owned::new(fan, DVec3::ZERO);
        let closed = Owned::new(cubes.clone(), DVec3::ZERO);
        assert!(closed.topology.is_closed());
        let inter = intersect(&a.side(), &closed.side()).unwrap();
        assert!(inter.regions[0].contains(0));
        assert!(inter.stats.conflicts_by_winding >= 1 && inter.stats.conflicts_by_majority == 0, "{:?}", inter.stats);
        let mut open = cubes;
        let far = open.positions.len() as u32;
        open.positions.extend([DVec3::new(10.0, 0.0, 0.0), DVec3::new(11.0, 0.0, 0.0), DVec3::new(10.0, 1.0, 0.0)]);
        open.triangles.push([far, far + 1, far + 2]);
        let open = Owned::new(open, DVec3::ZERO);
        let inter = intersect(&a.side(), &open.side()).unwrap();
        assert!(!inter.regions[0].contains(0));
        assert!(inter.stats.conflicts_by_majority >= 1 && inter.stats.conflicts_by_winding == 0, "{:?}", inter.stats);
    }

    /// A small sphere centred on a grid edge: that edge goes in and out of the sphere (both ends
    /// exterior, not representable: counted), no grid vertex is inside, so ℐ on the grid is empty
    /// while ℐ on the sphere is its lower half.
    #[test]
    fn a_tip_between_vertices_leaves_one_side_empty() {
        let grid = Owned::new(crate::mesh::shapes::grid(1.0, 1.0, 10, 10), DVec3::ZERO);
        let [i, j] = grid.topology.edge(grid.topology.vertex_edges(60)[0]);
        let mid = grid.mesh.positions[i as usize].lerp(grid.mesh.positions[j as usize], 0.5);
        let sphere = Owned::new(crate::mesh::shapes::icosphere(0.02, 3), mid + DVec3::new(0.0, 0.0, 0.001));
        let inter = intersect(&sphere.side(), &grid.side()).unwrap();
        assert!(inter.regions[1].is_empty());
        assert!(inter.stats.unrepresentable_edges >= 1, "{:?}", inter.stats);
        for v in 0..sphere.mesh.num_vertices() {
            assert_eq!(inter.regions[0].contains(v as u32), sphere.mesh.positions[v].z < 0.0);
        }
    }
}
