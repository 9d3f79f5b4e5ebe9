//! Working regions 𝒲 (thesis §4 intro, §4.5, §5.2.2, §7.1.2, §7.5): the parts of an object the
//! pipeline actually processes.
//!
//! A working region is a connected set of an object's faces, cut out as a [`SubMesh`]. Contact
//! (ch. 4) runs on pairs of regions, deformation (ch. 5) on each region with all its contact zones;
//! results are written back into the object's positions, and vertices outside every region are
//! returned bit for bit. Each object chooses its regions with [`ObjectParams::region`]
//! ([`RegionChoice`]):
//! - `whole` (default): the object is one region, exactly as without regions;
//! - `components`: every connected component is its own region — several meshes merged into one
//!   file (finger tips of a hand, Fig. 7.5–7.6), each moving its own way, each with its own
//!   mapping direction d̂ (§4.5: "they must be considered as several independent working
//!   regions");
//! - `mask`: the faces whose three vertices are selected by the per-vertex map
//!   [`ObjectParams::region_mask`] (painted, or from a file / glTF attribute); a vertex whose value
//!   rounds to k ≥ 1 is in mask k, every connected piece of a mask is its own region, and two masks
//!   may be adjacent (a palm and its fingers) but must not share a face;
//! - `distance` (with [`ObjectParams::region_distance`] `d`): automatic, "determined as a distance to the intersection region" (§4): the
//!   faces within an edge-path distance `g` of the object's intersection with the objects it is
//!   paired with, every connected piece its own region (so each finger of one hand mesh pressing
//!   a ball gets its own region as long as the bands around the tips stay apart).
//!
//! Every region pair gets one contact: its own d̂ and ε_c (§4.5, §7.1.2). When the bands around
//! several contacts of one mesh merge (fingers touching each other, a large extent), they share a
//! region, hence one d̂ and one ε_c per partner region; give such objects `components` or `mask`
//! to keep one region per finger, as the thesis does (Fig. 7.5–7.6: "each finger produces an
//! independent working region"; the ball or the palm is one region holding all the zones).
//!
//! # The automatic rule (`distance`)
//! 1. **Core**: the vertices of the faces that intersect a partner's faces (exact
//!    triangle–triangle tests) and the vertices inside a partner (exact winding number for a
//!    closed partner, fast generalized winding number ≥ ½ for an open one). Partners are the other
//!    objects of the object's pairs, taken whole.
//! 2. **Band width**: `g = max(d, domain_factor·φ̃)`, φ̃ being the object's fixed extent or an over-estimate of
//!    its automatic extent ([`super::automatic_extent`] with the sizes of the components the core
//!    touches, the sizes of the partner components near the core, and the core's area in place of
//!    the contact area). 𝒟 lies within φ_max of ∂𝒞 along the surface and ∂𝒞 lies in the core or
//!    next to it; edge paths are longer than geodesics: the cut is `domain_factor·φ̃` away (2·φ̃
//!    by default) — the radius of the parametrization domain 𝒫 (below) — so neither 𝒟 nor 𝒫
//!    reaches it. If 𝒟 still does (a coarse mesh, a contact zone far beyond the intersection),
//!    the deformation clamps the extent (below) and reports it.
//! 3. **Growth**: every face with a vertex within edge-path distance `g` of the core
//!    ([`edge_path_distances`]); pinches closed ([`close_pinches`]); split into connected pieces.
//!
//! The rule depends on this frame only (never on earlier frames), so results do not depend on the
//! frames processed before. A region's face set changes when faces cross the band's edge; its
//! caches are then rebuilt (below). The change moves the region's outer border, `domain_factor·φ̃`
//! away from the contact, beyond 𝒫: the result does not change (up to round-off).
//!
//! # Regions too small for the extent
//! A region's cut border (its vertices shared with faces outside it) must not move: faces outside
//! would deform without being part of the volume balance of App. C. So:
//! - an intersection reaching the cut is an error of the contact stage
//!   ([`crate::contact::ContactError::IntersectionReachesBorder`]), a contact zone reaching it an
//!   error of the pipeline ([`super::PipelineError::RegionTooSmall`]);
//! - a cut region lying wholly inside a closed object it is paired with (no edge crosses, so the
//!   contact stage sees nothing) is a [`super::PipelineError::RegionTooSmall`] too;
//! - when 𝒟 reaches the cut, the extent is **clamped** to 0.95 × the smallest φ on the cut (φ does
//!   not depend on φ_max, so the second solve gives the same φ and a 𝒟 that stops short of the
//!   cut), reported in [`super::RegionStats::extent_clamped`]. The clamp is a continuous function
//!   of the input, so animations stay continuous.
//!
//! With these, the volume of a closed object deformed on a region is preserved exactly.
//!
//! # Regions versus the whole object
//! The parametrization of §5.1 is solved on the domain 𝒫, the faces within 2·φ_max of ∂𝒞 along
//! edges ([`mod@crate::deform::parametrize`]), and a cut region uses the object's length scale h
//! (of the components it touches: heat time, slope confidence), not its own; the constraint
//! weights do not depend on the region either. So a region that holds 𝒫 gives the whole object's
//! result up to round-off: ≤ 1.1·10⁻¹⁵ on a ball pressing a slab (masks holding 𝒫, the automatic
//! band), ≤ 1.9·10⁻¹⁵ on the `press-100k` benchmark scene (tests). The band's width
//! (`domain_factor·φ̃` from the intersection, φ̃ ≥ φ_max) is the domain's radius measured from a
//! slightly smaller set, so the band holds 𝒫 in practice; when 𝒫 reaches a region's cut (a tight
//! mask, a coarse mesh), the region reports it ([`super::RegionStats::domain_reaches_cut`]) and its
//! φ differs (3.4·10⁻³ of the displacement for a mask of u ≤ 1.25 and φ_max = 0.8, 3.5·10⁻² for
//! φ_max = 0.5). A region that covers the whole object *is* the whole object: bit-identical
//! results.
//!
//! # Cost (thesis §7.5)
//! The linear systems factorize only their coupled rows (𝒫's for the heat and Poisson steps, 𝒟's
//! for the guide; [`crate::linalg::NumericFactor`]), so a whole object costs about what a band
//! around its contact costs there. What still grows with the region is linear work per frame
//! (assembly, refits, the domain's edge-path distances) and a new symbolic analysis whenever an
//! automatic band changes its faces. On `squish bench`'s `press-100k` (a ball pressing a
//! 100k-vertex sphere) the whole object and the automatic band run at the same speed (±10%, 1
//! thread); before the systems were restricted to their coupled rows the band was 3.6× faster.
//!
//! # Caches
//! Each region keeps its sub-mesh, topology, cut-border flags, triangle tree (refitted every frame)
//! and [`RegionSolver`] (symbolic analysis) while its face set stays the same; a region whose face
//! set changes is rebuilt (one symbolic analysis). A fresh and a reused deformer give bit-identical
//! results.

use glam::DVec3;
use rayon::prelude::*;

use super::{PipelineError, automatic_extent, size_from_areas};
use crate::deform::RegionSolver;
use crate::mesh::{
    Aabb3, SubMesh, Topology, TriMesh, close_pinches, cut_border, edge_path_distances, face_set_pieces,
    region_vertex_normals, vertex_areas,
};
use crate::params::{ObjectParams, RegionChoice};
use crate::spatial::{FastWinding, TriangleBvh, triangles_intersect};

/// Checks an object's region parameters against its vertex count: a mask needs one value per
/// vertex.
pub fn validate_region(params: &ObjectParams, vertices: usize) -> Result<(), String> {
    match (params.region, &params.region_mask) {
        (RegionChoice::Mask, Some(mask)) if mask.len() != vertices => Err(format!(
            "the region mask has {} values but the mesh has {vertices} vertices: give one value per vertex",
            mask.len()
        )),
        (RegionChoice::Mask, None) => Err("region = \"mask\" needs region_mask".to_string()),
        _ => Ok(()),
    }
}

/// The masks of a label map (see [`ObjectParams::region_mask`]): mask k holds the vertices whose
/// value rounds to k, for k = 1 … the largest label.
fn masks_of_labels(labels: &[f64]) -> Vec<Vec<bool>> {
    let label = |v: f64| if v.is_finite() && v >= 0.5 { v.round() as usize } else { 0 };
    let count = labels.iter().map(|&v| label(v)).max().unwrap_or(0);
    (1..=count).map(|k| labels.iter().map(|&v| label(v) == k).collect()).collect()
}

/// The connected components of an object (connectivity only).
#[derive(Debug)]
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
    fn of_faces(&self, faces: &[u32]) -> Vec<u32> {
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
    boxes: Vec<Aabb3>,
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
        let mut boxes = vec![Aabb3::EMPTY; n];
        for ((p, a), &c) in mesh.positions.iter().zip(&areas).zip(&components.vertex) {
            if c != u32::MAX {
                area[c as usize] += a;
                moment[c as usize] += *p * *a;
                boxes[c as usize].grow(*p);
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
        Self { area, centroid, spread, boxes, edge_length, edges, object_size }
    }

    /// Mean edge length of the union of `components` (the `h` of the heat step, §5.1).
    pub fn mean_edge_length(&self, components: &[u32]) -> f64 {
        let total: f64 = components.iter().map(|&c| self.edge_length[c as usize]).sum();
        let count: usize = components.iter().map(|&c| self.edges[c as usize]).sum();
        if count == 0 { 0.0 } else { total / count as f64 }
    }

    /// Area-weighted RMS radius of the union of `components` (see [`super::object_size`]); the
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
    fn size_bound(&self, components: &[u32]) -> f64 {
        components.iter().map(|&c| self.size_of(&[c])).fold(self.size_of(components), f64::max)
    }
}

/// The regions chosen for an object at one frame.
#[derive(Debug)]
pub(super) enum Selection {
    /// The whole object.
    Whole,
    /// Face sets (sorted parent face ids), disjoint.
    Pieces(Vec<Vec<u32>>),
}

/// The geometry of a partner object, for the automatic rule.
pub(super) struct Partner<'a> {
    pub mesh: &'a TriMesh,
    pub bvh: &'a TriangleBvh,
    pub closed: bool,
    pub figures: &'a ComponentFigures,
}

/// Chooses the regions of one object (see the module doc).
pub(super) fn select(
    mesh: &TriMesh,
    topology: &Topology,
    components: &Components,
    figures: &ComponentFigures,
    params: &ObjectParams,
    partners: &[Partner],
) -> Result<Selection, String> {
    let nf = mesh.num_triangles();
    let pieces = match params.region {
        RegionChoice::Whole => return Ok(Selection::Whole),
        RegionChoice::Components => {
            let mut pieces = vec![Vec::new(); components.count];
            for (f, &c) in components.face.iter().enumerate() {
                pieces[c as usize].push(f as u32);
            }
            pieces
        }
        RegionChoice::Mask => {
            let masks = masks_of_labels(params.region_mask.as_deref().unwrap_or_default());
            let mut owner = vec![u32::MAX; nf];
            let mut pieces = Vec::new();
            for (k, mask) in masks.iter().enumerate() {
                for piece in mask_pieces(mesh, topology, mask) {
                    for &f in &piece {
                        let other = owner[f as usize];
                        if other != u32::MAX {
                            return Err(format!(
                                "region masks {} and {} both hold face {f} (after closing pinches); \
                                 working regions of one object must not overlap",
                                other + 1,
                                k + 1
                            ));
                        }
                        owner[f as usize] = k as u32;
                    }
                    pieces.push(piece);
                }
            }
            pieces
        }
        RegionChoice::Distance => {
            distance_pieces(mesh, topology, components, figures, params, params.region_distance, partners)
        }
    };
    if pieces.len() == 1 && pieces[0].len() == nf {
        return Ok(Selection::Whole);
    }
    Ok(Selection::Pieces(pieces))
}

fn mask_pieces(mesh: &TriMesh, topology: &Topology, mask: &[bool]) -> Vec<Vec<u32>> {
    let mut selected: Vec<bool> =
        mesh.triangles.iter().map(|t| t.iter().all(|&v| mask.get(v as usize).copied().unwrap_or(false))).collect();
    close_pinches(mesh, topology, &mut selected);
    face_set_pieces(mesh, topology, &selected)
}

/// The automatic rule: core, band width, growth (module doc).
fn distance_pieces(
    mesh: &TriMesh,
    topology: &Topology,
    components: &Components,
    figures: &ComponentFigures,
    params: &ObjectParams,
    distance: f64,
    partners: &[Partner],
) -> Vec<Vec<u32>> {
    let n = mesh.num_vertices();
    let mut core = vec![false; n];
    for partner in partners {
        let bounds = partner.bvh.bounds();
        if !bounds.intersects(&crate::mesh::bounding_box(mesh)) {
            continue;
        }
        // Faces crossing the partner's surface.
        let crossing: Vec<bool> = (0..mesh.num_triangles())
            .into_par_iter()
            .with_min_len(256)
            .map(|f| {
                let corners = mesh.corners(f);
                let query = Aabb3::from_points(corners);
                if !query.intersects(&bounds) {
                    return false;
                }
                let mut hit = false;
                partner.bvh.for_each_face_in_box(&query, |g| {
                    if !hit {
                        hit = triangles_intersect(&corners, &partner.mesh.corners(g as usize));
                    }
                });
                hit
            })
            .collect();
        for (t, _) in mesh.triangles.iter().zip(&crossing).filter(|(_, c)| **c) {
            for &v in t {
                core[v as usize] = true;
            }
        }
        // Vertices inside the partner.
        let winding = (!partner.closed).then(|| FastWinding::new(partner.bvh, 2.0));
        let inside: Vec<bool> = mesh
            .positions
            .par_iter()
            .with_min_len(256)
            .map(|&p| {
                if !(bounds.min.cmple(p).all() && p.cmple(bounds.max).all()) {
                    return false;
                }
                match &winding {
                    None => partner.bvh.contains(p),
                    Some(w) => w.winding_number(p) >= 0.5,
                }
            })
            .collect();
        for (c, i) in core.iter_mut().zip(inside) {
            *c |= i;
        }
    }
    let sources: Vec<u32> = (0..n as u32).filter(|&v| core[v as usize]).collect();
    if sources.is_empty() {
        return Vec::new();
    }

    // Band width: the user's distance, widened to the domain radius for an over-estimate of the
    // extent.
    let extent = match params.extent {
        Some(extent) => extent,
        None => {
            let mut touched: Vec<u32> = sources.iter().map(|&v| components.vertex[v as usize]).collect();
            touched.retain(|&c| c != u32::MAX);
            touched.sort_unstable();
            touched.dedup();
            let size = figures.size_bound(&touched);
            let core_box = Aabb3::from_points(sources.iter().map(|&v| mesh.positions[v as usize]));
            let partner_size = partners
                .iter()
                .map(|p| {
                    let near: Vec<u32> = (0..p.figures.boxes.len() as u32)
                        .filter(|&c| p.figures.boxes[c as usize].intersects(&core_box))
                        .collect();
                    if near.is_empty() { 0.0 } else { p.figures.size_bound(&near) }
                })
                .fold(0.0, f64::max);
            let partner_size = if partner_size > 0.0 { partner_size } else { f64::INFINITY };
            let core_area: f64 = mesh
                .triangles
                .iter()
                .enumerate()
                .filter(|(_, t)| t.iter().any(|&v| core[v as usize]))
                .map(|(f, _)| {
                    let [a, b, c] = mesh.corners(f);
                    crate::mesh::triangle_area(a, b, c)
                })
                .sum();
            automatic_extent(size, partner_size, core_area)
        }
    };
    // The parametrization domain's radius, so that the band holds 𝒫 (see the module doc).
    let width = distance.max(params.domain_factor * extent);

    let mut selected = vec![false; mesh.num_triangles()];
    for (v, _) in edge_path_distances(mesh, topology, &sources, width) {
        for &f in topology.vertex_faces(v) {
            selected[f as usize] = true;
        }
    }
    close_pinches(mesh, topology, &mut selected);
    face_set_pieces(mesh, topology, &selected)
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
    /// Vertex normals of this frame, from all parent faces.
    pub normals: Vec<DVec3>,
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
}

impl RegionCache {
    fn whole(components: &Components) -> Self {
        Self { faces: None, sub: None, components: (0..components.count as u32).collect(), solver: None, rebuilt: true }
    }

    fn cut(parent: &TriMesh, topology: &Topology, components: &Components, faces: Vec<u32>) -> Result<Self, String> {
        let sub = SubMesh::from_faces(parent, faces.iter().copied());
        let sub_topology = Topology::new(&sub.mesh);
        sub_topology.check_manifold(&sub.mesh).map_err(|e| format!("the region's mesh is invalid: {e}"))?;
        let bvh = TriangleBvh::new(&sub.mesh).map_err(|e| e.to_string())?;
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
            sub: Some(Box::new(SubRegion { sub, topology: sub_topology, bvh, border, border_count, normals })),
            solver: None,
            rebuilt: true,
        })
    }

    /// Moves the cut-out region to the parent's positions of this frame.
    fn refresh(&mut self, parent: &TriMesh, topology: &Topology) -> Result<(), String> {
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

/// Replaces an object's regions by `selection`, reusing the caches of unchanged face sets and
/// building the others (in parallel), then moves every kept region to this frame's positions.
pub(super) fn update_regions(
    regions: &mut Vec<RegionCache>,
    selection: Selection,
    parent: &TriMesh,
    topology: &Topology,
    components: &Components,
) -> Result<(), String> {
    let mut old: Vec<Option<RegionCache>> = std::mem::take(regions).into_iter().map(Some).collect();
    let mut take = |faces: Option<&[u32]>| -> Option<RegionCache> {
        let slot = old.iter_mut().find(|r| r.as_ref().is_some_and(|r| r.faces.as_deref() == faces))?;
        let mut region = slot.take()?;
        region.rebuilt = false;
        Some(region)
    };
    let built: Vec<Result<RegionCache, String>> = match selection {
        Selection::Whole => vec![Ok(take(None).unwrap_or_else(|| RegionCache::whole(components)))],
        Selection::Pieces(pieces) => {
            let kept: Vec<(Vec<u32>, Option<RegionCache>)> = pieces
                .into_iter()
                .map(|faces| {
                    let cache = take(Some(&faces));
                    (faces, cache)
                })
                .collect();
            kept.into_par_iter()
                .map(|(faces, cache)| match cache {
                    Some(cache) => Ok(cache),
                    None => RegionCache::cut(parent, topology, components, faces),
                })
                .collect()
        }
    };
    *regions = built.into_iter().collect::<Result<_, _>>()?;
    regions.par_iter_mut().try_for_each(|r| r.refresh(parent, topology))
}

/// Wraps a region message into the pipeline's error.
pub(super) fn invalid(object: &str, reason: String) -> PipelineError {
    PipelineError::InvalidRegion { object: object.to_string(), reason }
}
