//! What the [`super::Deformer`] keeps between frames: per object, everything that depends on its
//! connectivity only (topology, triangle tree, connected components, working regions), and per
//! working region its sub-mesh, topology, cut-border flags, triangle tree and [`RegionSolver`]
//! (pattern and symbolic analyses).
//!
//! An object's cache is rebuilt when its triangles change; a region's when its face set changes
//! (one symbolic analysis). Trees are refitted to each frame's positions. A fresh and a reused
//! deformer give bit-identical results: nothing here depends on an earlier frame's positions,
//! except the component figures reused for an object that did not move, bit for bit, which are
//! the same bits.

use std::sync::Arc;

use glam::DVec3;

use super::{FrameObject, PipelineError};
use crate::contact::ContactSide;
use crate::deform::{RegionSolver, size_from_areas};
use crate::mesh::{Aabb3, SubMesh, Topology, TriMesh, cut_border, region_vertex_normals, vertex_areas};
use crate::spatial::{TriangleBvh, WindingClusters};

/// What the deformer keeps about an object between frames: everything that depends on the
/// connectivity only.
pub(super) struct ObjectCache {
    /// The connectivity and what depends on it only, shared with the caches made from this one
    /// ([`Self::connectivity`]: every touching part pair of a skinned mesh starts from its
    /// object's).
    triangles: Arc<Vec<[u32; 3]>>,
    pub topology: Arc<Topology>,
    pub closed: bool,
    /// Tree over the whole object; refitted at the frames where it is used (`Whole` regions,
    /// partners of automatic regions), copied then if another cache shares it.
    pub bvh: Arc<TriangleBvh>,
    pub components: Arc<Components>,
    pub regions: Vec<RegionCache>,
    /// The separation pass's tree of the whole object, for the inside of its cut regions when it
    /// is closed (see [`SideTrees`]): kept between frames and refitted, whatever its regions'
    /// face sets do, so that a region cut again does not copy and refit the whole tree again.
    pub separation_whole: Option<Box<TriangleBvh>>,
    /// Each vertex's place in AMD's order of the whole object (its connectivity only), computed
    /// at the first automatic region's analysis: a region cut out again takes its order
    /// restricted to its rows instead of an ordering of its own.
    pub fill_ranks: std::sync::OnceLock<Result<Vec<usize>, crate::linalg::SolveError>>,
    /// The last frame's component figures and the positions they were computed from: an object
    /// that has not moved since, bit for bit (a static ground, a prop at rest), reuses them, which
    /// gives the same bits as computing them again.
    figures: Option<(Vec<DVec3>, ComponentFigures)>,
}

impl ObjectCache {
    /// Builds the caches of an object, checking that its mesh can be deformed.
    pub fn new(name: &str, mesh: &TriMesh) -> Result<Self, PipelineError> {
        let topology =
            mesh.check_for_deformation().map_err(|source| PipelineError::Mesh { object: name.to_string(), source })?;
        let bvh =
            TriangleBvh::new(mesh).map_err(|source| PipelineError::Spatial { object: name.to_string(), source })?;
        let components = Components::new(mesh, &topology);
        Ok(Self {
            triangles: Arc::new(mesh.triangles.clone()),
            closed: topology.is_closed(),
            topology: Arc::new(topology),
            bvh: Arc::new(bvh),
            components: Arc::new(components),
            regions: Vec::new(),
            separation_whole: None,
            fill_ranks: std::sync::OnceLock::new(),
            figures: None,
        })
    }

    /// A cache of the same object with what depends on its connectivity only (topology, tree,
    /// components) and no working region yet: what [`Self::new`] would build, without building
    /// it again (each touching part pair of one mesh starts from its object's).
    pub fn connectivity(&self) -> Self {
        Self {
            triangles: Arc::clone(&self.triangles),
            topology: Arc::clone(&self.topology),
            closed: self.closed,
            bvh: Arc::clone(&self.bvh),
            components: Arc::clone(&self.components),
            regions: Vec::new(),
            separation_whole: None,
            fill_ranks: std::sync::OnceLock::new(),
            figures: None,
        }
    }

    /// The figures of the object's components at `mesh`'s positions.
    pub fn figures(&mut self, mesh: &TriMesh) -> ComponentFigures {
        let bits = |p: &DVec3| p.to_array().map(f64::to_bits);
        if let Some((positions, figures)) = &self.figures
            && positions.len() == mesh.positions.len()
            && positions.iter().zip(&mesh.positions).all(|(a, b)| bits(a) == bits(b))
        {
            return figures.clone();
        }
        let figures = ComponentFigures::new(mesh, &self.topology, &self.components);
        let mut positions = self.figures.take().map(|(positions, _)| positions).unwrap_or_default();
        positions.clear();
        positions.extend_from_slice(&mesh.positions);
        self.figures = Some((positions, figures.clone()));
        figures
    }

    /// The connectivity the cache was built for, shared: a new cache (other triangles) has
    /// another.
    pub fn shared_triangles(&self) -> Arc<Vec<[u32; 3]>> {
        Arc::clone(&self.triangles)
    }

    /// True if `mesh` has the connectivity the cache was built for.
    pub fn matches(&self, mesh: &TriMesh) -> bool {
        *self.triangles == mesh.triangles && self.topology.num_vertices() == mesh.num_vertices()
    }

    /// The contact side of region `r`.
    pub fn side<'a>(
        &'a self,
        r: usize,
        object: &'a FrameObject,
        normals: Option<&'a [DVec3]>,
        name: &'a str,
        uvs: Option<&'a crate::params::Uvs>,
    ) -> Option<ContactSide<'a>> {
        let region = self.regions.get(r)?;
        let side = match region.sub.as_deref() {
            None => ContactSide::new(object.mesh, &self.topology, normals?, &self.bvh),
            Some(sub) => ContactSide::new(&sub.sub.mesh, &sub.topology, &sub.normals, &sub.bvh)
                .with_border(sub.contact_border())
                .with_interior_asked(
                    object.params.contact_interior.as_ref().map(|f| (f, sub.sub.parent_vertex.as_slice())),
                ),
        };
        Some(side.with_name(name).with_stiffness(crate::contact::Stiffness::of(object.params)).with_uvs(uvs))
    }

    /// For a cut region `r` and a partner region that is a whole closed object: the first vertex
    /// of `r` (object id) if it lies inside the partner.
    pub fn inside_whole_closed(&self, r: usize, other: &ObjectCache, other_r: usize) -> Option<u32> {
        let sub = self.regions.get(r)?.sub.as_deref()?;
        if !other.closed || other.regions.get(other_r)?.sub.is_some() {
            return None;
        }
        let p = *sub.sub.mesh.positions.first()?;
        other.bvh.contains(p).then(|| sub.sub.parent_vertex[0])
    }

    /// For whole regions that no edge crosses: true if `mesh` (this object, region `r`) has a
    /// vertex inside `other` (closed, region `other_r`), i.e. lies inside it.
    pub fn lies_inside(&self, r: usize, mesh: &TriMesh, other: &ObjectCache, other_r: usize) -> bool {
        let whole = |c: &ObjectCache, r: usize| c.regions.get(r).is_some_and(|region| region.sub.is_none());
        if !other.closed || !whole(self, r) || !whole(other, other_r) {
            return false;
        }
        mesh.triangles.first().is_some_and(|t| other.bvh.contains(mesh.positions[t[0] as usize]))
    }

    /// The bounding box of region `r` at this frame.
    pub fn region_bounds(&self, r: usize) -> Aabb3 {
        match self.regions[r].sub.as_deref() {
            None => self.bvh.bounds(),
            Some(sub) => sub.bvh.bounds(),
        }
    }
}

/// The connected components of an object (connectivity only).
#[derive(Clone, Debug)]
pub(super) struct Components {
    /// Component of each face.
    pub face: Vec<u32>,
    /// Component of each vertex (`u32::MAX` for a vertex without faces).
    pub vertex: Vec<u32>,
    pub count: usize,
}

impl Components {
    pub fn new(mesh: &TriMesh, topology: &Topology) -> Self {
        let (face, count) = topology.face_components(mesh);
        let mut vertex = vec![u32::MAX; mesh.num_vertices()];
        for (t, &c) in mesh.triangles.iter().zip(&face) {
            for &v in t {
                vertex[v as usize] = c;
            }
        }
        Self { face, vertex, count }
    }

    /// The components holding some of `faces`, sorted.
    pub fn of_faces(&self, faces: &[u32]) -> Vec<u32> {
        let mut found: Vec<u32> = faces.iter().map(|&f| self.face[f as usize]).collect();
        found.sort_unstable();
        found.dedup();
        found
    }
}

/// Per-frame figures of an object's components, for the automatic extent's sizes.
#[derive(Clone, Debug)]
pub(super) struct ComponentFigures {
    area: Vec<f64>,
    centroid: Vec<DVec3>,
    spread: Vec<f64>,
    /// Sum of the edge lengths and number of edges.
    edge_length: Vec<f64>,
    edges: Vec<usize>,
    object_size: f64,
}

impl ComponentFigures {
    pub fn new(mesh: &TriMesh, topology: &Topology, components: &Components) -> Self {
        let areas = vertex_areas(mesh);
        let object_size = size_from_areas(mesh, &areas);
        let n = components.count;
        let mut area = vec![0.0; n];
        let mut moment = vec![DVec3::ZERO; n];
        for ((p, a), &c) in mesh.positions.iter().zip(&areas).zip(&components.vertex) {
            if c != u32::MAX {
                area[c as usize] += a;
                moment[c as usize] += *p * *a;
            }
        }
        let centroid: Vec<DVec3> =
            moment.iter().zip(&area).map(|(m, &a)| if a > 0.0 { *m / a } else { DVec3::ZERO }).collect();
        let mut spread = vec![0.0; n];
        for ((p, a), &c) in mesh.positions.iter().zip(&areas).zip(&components.vertex) {
            if c != u32::MAX {
                spread[c as usize] += a * (*p - centroid[c as usize]).length_squared();
            }
        }
        let mut edge_length = vec![0.0; n];
        let mut edges = vec![0; n];
        for &[a, b] in topology.edges() {
            let c = components.vertex[a as usize] as usize;
            edge_length[c] += (mesh.positions[a as usize] - mesh.positions[b as usize]).length();
            edges[c] += 1;
        }
        Self { area, centroid, spread, edge_length, edges, object_size }
    }

    /// Mean edge length of the union of `components` (the `h` of the heat step, §5.1).
    pub fn mean_edge_length(&self, components: &[u32]) -> f64 {
        let total: f64 = components.iter().map(|&c| self.edge_length[c as usize]).sum();
        let count: usize = components.iter().map(|&c| self.edges[c as usize]).sum();
        if count == 0 { 0.0 } else { total / count as f64 }
    }

    /// Area-weighted RMS radius of the union of `components` (see [`crate::deform::object_size`]); the
    /// object's size when they are all of them.
    pub fn size_of(&self, components: &[u32]) -> f64 {
        if components.len() >= self.area.len() {
            return self.object_size;
        }
        let total: f64 = components.iter().map(|&c| self.area[c as usize]).sum();
        if total.is_nan() || total <= 0.0 {
            return 0.0;
        }
        let centre =
            components.iter().map(|&c| self.centroid[c as usize] * self.area[c as usize]).sum::<DVec3>() / total;
        // Parallel-axis theorem: each component's spread about its centroid plus its area times
        // the squared offset of its centroid.
        let spread: f64 = components
            .iter()
            .map(|&c| {
                self.spread[c as usize] + self.area[c as usize] * (self.centroid[c as usize] - centre).length_squared()
            })
            .sum();
        (spread / total).sqrt()
    }

    /// The largest of the union's size and the sizes of each component: an upper bound of the
    /// size of any region within `components`.
    pub fn size_bound(&self, components: &[u32]) -> f64 {
        components.iter().map(|&c| self.size_of(&[c])).fold(self.size_of(components), f64::max)
    }
}

/// A region cut out of its object, with its connectivity-only caches.
#[derive(Debug)]
pub(super) struct SubRegion {
    pub sub: SubMesh,
    pub topology: Topology,
    pub bvh: TriangleBvh,
    /// Per region vertex: on the cut border.
    pub border: Vec<bool>,
    pub border_count: usize,
    /// Per region vertex: the border for the contact stage when it differs from `border` (see
    /// [`crate::params::ObjectParams::contact_open_border`]).
    pub contact_border: Option<Vec<bool>>,
    /// Vertex normals of this frame, from all parent faces.
    pub normals: Vec<DVec3>,
}

impl SubRegion {
    /// The border the contact stage sees (`None`: no border).
    pub fn contact_border(&self) -> Option<&[bool]> {
        match &self.contact_border {
            Some(border) => border.iter().any(|&b| b).then_some(border.as_slice()),
            None => (self.border_count > 0).then_some(self.border.as_slice()),
        }
    }

    /// Removes the vertices `open` (per parent vertex) from the contact stage's border.
    pub fn open_contact_border(&mut self, open: Option<&[bool]>) {
        self.contact_border = open.map(|open| {
            self.border
                .iter()
                .zip(&self.sub.parent_vertex)
                .map(|(&b, &v)| b && !open.get(v as usize).copied().unwrap_or(false))
                .collect()
        });
    }
}

/// One working region of an object and its caches.
#[derive(Debug)]
pub(super) struct RegionCache {
    /// Sorted parent faces; `None` for the whole object.
    pub faces: Option<Vec<u32>>,
    /// The cut-out region; `None` for the whole object.
    pub sub: Option<Box<SubRegion>>,
    /// Components of the object it touches (for its size).
    pub components: Vec<u32>,
    pub solver: Option<RegionSolver>,
    /// True if built at this frame.
    pub rebuilt: bool,
    /// The separation pass's trees of this region (in the object's numbering), kept between
    /// frames so that each frame refits them instead of copying the cached trees again; they
    /// live and die with the region's face set.
    pub separation_trees: Option<Box<SideTrees>>,
}

impl RegionCache {
    pub fn whole(components: &Components) -> Self {
        Self {
            faces: None,
            sub: None,
            components: (0..components.count as u32).collect(),
            solver: None,
            rebuilt: true,
            separation_trees: None,
        }
    }

    /// The region of `parent`'s `faces`; its tree is `parent_tree` (the whole object's, any
    /// positions) pruned to them and fitted to the region.
    pub fn cut(
        parent: &TriMesh,
        parent_tree: &TriangleBvh,
        topology: &Topology,
        components: &Components,
        faces: Vec<u32>,
    ) -> Result<Self, String> {
        let sub = SubMesh::from_faces(parent, faces.iter().copied());
        let sub_topology = Topology::new(&sub.mesh);
        sub_topology.check_manifold(&sub.mesh).map_err(|e| format!("the region's mesh is invalid: {e}"))?;
        let bvh = match parent_tree.restricted(&sub.mesh, &sub.parent_face).map_err(|e| e.to_string())? {
            Some(tree) => tree,
            None => TriangleBvh::new(&sub.mesh).map_err(|e| e.to_string())?,
        };
        let mut in_region = vec![false; parent.num_triangles()];
        for &f in &faces {
            in_region[f as usize] = true;
        }
        let border = cut_border(topology, &in_region, &sub.parent_vertex);
        let border_count = border.iter().filter(|&&b| b).count();
        let normals = region_vertex_normals(parent, topology, &sub.parent_vertex);
        Ok(Self {
            components: components.of_faces(&faces),
            faces: Some(faces),
            sub: Some(Box::new(SubRegion {
                sub,
                topology: sub_topology,
                bvh,
                border,
                border_count,
                contact_border: None,
                normals,
            })),
            solver: None,
            rebuilt: true,
            separation_trees: None,
        })
    }

    /// Moves the cut-out region to the parent's positions of this frame.
    pub fn refresh(&mut self, parent: &TriMesh, topology: &Topology) -> Result<(), String> {
        if let Some(region) = self.sub.as_deref_mut()
            && !self.rebuilt
        {
            region.sub.update_positions(&parent.positions);
            region.bvh.refit(&region.sub.mesh.positions).map_err(|e| e.to_string())?;
            region.normals = region_vertex_normals(parent, topology, &region.sub.parent_vertex);
        }
        Ok(())
    }

    /// Number of faces (of the parent when whole).
    pub fn num_faces(&self, parent: &TriMesh) -> usize {
        self.faces.as_ref().map_or(parent.num_triangles(), Vec::len)
    }
}

/// The trees of one side (a region of an object) for the whole pass: taken from the object's
/// cached trees (no new build; a cut region's tree renumbered into the object's ids) and
/// refitted to the outputs at each round. Every query the pass makes of them answers the same
/// whatever the tree's shape (closest points and faces within a distance by (distance, face id),
/// crossings and winding numbers exactly, the inside of an open surface exactly near its
/// threshold), so a tree built at an earlier frame gives the bits of a fresh one. Kept in the
/// region's cache between frames ([`RegionCache::separation_trees`]); built, refitted and
/// queried by the separation pass (`separation`).
#[derive(Debug)]
pub(super) struct SideTrees {
    /// The region's faces (object face ids) at the current positions. A region cut out of a
    /// closed object and paired with another object has its inside from the whole object's
    /// tree, kept by the object ([`ObjectCache::separation_whole`]).
    pub bvh: TriangleBvh,
    /// Vertices of the side (sorted, object ids).
    pub vertices: Vec<u32>,
    /// The far-field clusters of `bvh` for the inside of an open side, refreshed each round
    /// where a pair needs them (buffers kept).
    pub clusters: WindingClusters,
    /// The side's rim ([`super::rim::RimEdge`]), found the first time a pass decides
    /// inside the side by its winding number.
    pub rim: std::sync::OnceLock<Vec<super::rim::RimEdge>>,
}
