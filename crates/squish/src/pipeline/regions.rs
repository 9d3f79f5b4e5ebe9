//! Working regions 𝒲 (thesis §4 intro, §4.5, §5.2.2, §7.1.2, §7.5): the parts of an object the
//! pipeline actually processes, and the working-region stage of a frame
//! ([`update_working_regions`]): each object's regions chosen by the rule of its
//! [`RegionChoice`] (below), then their caches reused when the face set is the same
//! or built (in parallel) when it changed, and moved to this frame's positions.
//!
//! A working region is a connected set of an object's faces, cut out as a [`SubMesh`](crate::SubMesh). Contact
//! (ch. 4) runs on pairs of regions, deformation (ch. 5) on each region with all its contact zones;
//! results are written back into the object's positions, and vertices outside every region are
//! returned bit for bit. Each object chooses its regions with [`ObjectParams::region`] ([`RegionChoice`]):
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
//!    its automatic extent ([`automatic_extent`] with the size and mean edge length of the
//!    components the core touches, and the core's area in place of the contact area: the
//!    extent grows with the area). 𝒟 lies within φ_max of ∂𝒞 along the surface and ∂𝒞 lies in the core or
//!    next to it; edge paths are longer than geodesics: the cut is `domain_factor·φ̃` away (2·φ̃
//!    by default) — the radius of the parametrization domain 𝒫 (below) — so neither 𝒟 nor 𝒫
//!    reaches it. If 𝒟 still does (a coarse mesh, a contact zone far beyond the intersection),
//!    the deformation clamps the extent (below) and reports it.
//! 3. **Growth**: every face with a vertex within edge-path distance `g` of the core
//!    ([`edge_path_distances`]); pinches closed ([`close_pinches`]); split into connected pieces.
//!
//! The rule depends on this frame only (never on earlier frames), so results do not depend on the
//! frames processed before. A region's face set changes when faces cross the band's edge; its
//! caches are then rebuilt (one symbolic analysis). The change moves the region's outer border, `domain_factor·φ̃`
//! away from the contact, beyond 𝒫: the result does not change (up to round-off).
//!
//! # Regions too small for the extent
//! A region's cut border (its vertices shared with faces outside it) must not move: faces outside
//! would deform without being part of the volume balance of App. C. So:
//! - an intersection reaching the cut is an error of the contact stage
//!   ([`crate::contact::ContactError::IntersectionReachesBorder`]), a contact zone reaching it an
//!   error of the pipeline ([`PipelineError::RegionTooSmall`]);
//! - a cut region lying wholly inside a closed object it is paired with (no edge crosses, so the
//!   contact stage sees nothing) is a [`PipelineError::RegionTooSmall`] too;
//! - when 𝒟 reaches the cut, the extent is **clamped** to 0.95 × the smallest φ on the cut (φ does
//!   not depend on φ_max, so the second solve gives the same φ and a 𝒟 that stops short of the
//!   cut), reported in [`RegionStats::extent_clamped`]. The clamp is a continuous function
//!   of the input, so animations stay continuous.
//!
//! With these, the volume of a closed object deformed on a region is preserved exactly.
//!
//! # Regions versus the whole object
//! The parametrization of §5.1 is solved on the domain 𝒫, the faces within `domain_factor`·φ_max
//! of ∂𝒞 along edges ([`crate::deform::parametrize()`]), and a cut region uses the object's length
//! scale h (of the components it touches: heat time, slope confidence), not its own; the
//! constraint weights do not depend on the region either. So a region that holds 𝒫 gives the
//! whole object's result up to round-off. The band's width (`domain_factor·φ̃` from the
//! intersection, φ̃ ≥ φ_max) is the domain's radius measured from a slightly smaller set, so the
//! band holds 𝒫 in practice; when 𝒫 reaches a region's cut (a tight mask, a coarse mesh), the
//! region reports it ([`RegionStats::domain_reaches_cut`]) and its φ differs. A region that covers
//! the whole object *is* the whole object: bit-identical results. (Measured differences:
//! `docs/speed.md`, working regions.)
//!
//! # Cost (thesis §7.5)
//! The linear systems factorize only their coupled rows (𝒫's for the heat and Poisson steps, 𝒟's
//! for the guide; [`crate::linalg::NumericFactor`]), so a whole object costs about what a band
//! around its contact costs there. What still grows with the region is linear work per frame
//! (assembly, refits, the domain's edge-path distances) and a new symbolic analysis whenever an
//! automatic band changes its faces (timings: `docs/speed.md`).
//!

use rayon::prelude::*;

#[cfg(doc)]
use super::RegionStats;
use super::cache::{ComponentFigures, Components, ObjectCache, RegionCache};
use super::{Frame, PipelineError};
use crate::deform::automatic_extent;
use crate::mesh::{Aabb3, Topology, TriMesh, close_pinches, edge_path_distances, face_set_pieces};
use crate::params::{ObjectParams, RegionChoice};
use crate::spatial::{FastWinding, TriangleBvh, triangles_intersect};
use crate::stage::SharedWork;

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

/// The regions chosen for an object at one frame.
#[derive(Debug)]
enum Selection {
    /// The whole object.
    Whole,
    /// Face sets (sorted parent face ids), disjoint.
    Pieces(Vec<Vec<u32>>),
}

/// The geometry of a partner object, for the automatic rule.
struct Partner<'a> {
    pub mesh: &'a TriMesh,
    pub bvh: &'a TriangleBvh,
    pub closed: bool,
}

/// Chooses the regions of one object (see the module doc).
fn select(
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

/// The automatic rule: core, band width, growth (see [`WorkingRegion`]).
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
        // Faces crossing the partner's surface (each task's work measured, see `Work`).
        let work = SharedWork::default();
        let crossing: Vec<bool> = (0..mesh.num_triangles())
            .into_par_iter()
            .with_min_len(256)
            .map(|f| {
                work.measure(|| {
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
                work.measure(|| {
                    if !(bounds.min.cmple(p).all() && p.cmple(bounds.max).all()) {
                        return false;
                    }
                    match &winding {
                        None => partner.bvh.contains(p),
                        Some(w) => w.winding_number(p) >= 0.5,
                    }
                })
            })
            .collect();
        work.record();
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
            let edge_length = figures.mean_edge_length(&touched);
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
            automatic_extent(size, core_area, edge_length)
        }
    };
    // The parametrization domain's radius, so that the band holds 𝒫 (see [`WorkingRegion`]).
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

/// Replaces an object's regions by `selection`, reusing the caches of unchanged face sets and
/// building the others (in parallel), then moves every kept region to this frame's positions.
fn update_regions(
    regions: &mut Vec<RegionCache>,
    selection: Selection,
    parent: &TriMesh,
    parent_tree: &TriangleBvh,
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
                    None => RegionCache::cut(parent, parent_tree, topology, components, faces),
                })
                .collect()
        }
    };
    *regions = built.into_iter().collect::<Result<_, _>>()?;
    regions.par_iter_mut().try_for_each(|r| r.refresh(parent, topology))
}

/// The working-region stage (§4.5): chooses every object's regions (in parallel; the automatic
/// rule looks at each object's `partners`, the objects it is paired with, taken whole), then
/// updates their caches. `refitted`: per object, whether the setup refitted its whole-object
/// tree this frame (an object whose selection turns out whole needs it for the contact stage).
pub(super) fn update_working_regions(
    caches: &mut [Option<ObjectCache>],
    frame: &Frame,
    partners: &[Vec<usize>],
    refitted: &[bool],
    figures: &[ComponentFigures],
) -> Result<(), PipelineError> {
    let work = SharedWork::default();
    let selections: Vec<Selection> = {
        let caches: Vec<&ObjectCache> = caches.iter().flatten().collect();
        (0..frame.objects.len())
            .into_par_iter()
            .map(|i| {
                work.measure(|| {
                    let object = &frame.objects[i];
                    let others: Vec<Partner> = partners[i]
                        .iter()
                        .map(|&j| Partner {
                            mesh: frame.objects[j].mesh,
                            bvh: &caches[j].bvh,
                            closed: caches[j].closed,
                        })
                        .collect();
                    let cache = caches[i];
                    select(object.mesh, &cache.topology, &cache.components, &figures[i], object.params, &others)
                        .map_err(|reason| PipelineError::invalid_region(object.name, reason))
                })
            })
            .collect::<Result<_, _>>()?
    };
    work.record();
    caches.par_iter_mut().zip(selections).zip(&frame.objects).zip(refitted).try_for_each(
        |(((cache, selection), object), &refitted)| -> Result<(), PipelineError> {
            let Some(cache) = cache.as_mut() else { return Ok(()) };
            // A selection may be the whole object without `WorkingRegion::Whole`.
            if matches!(selection, Selection::Whole) && !refitted {
                std::sync::Arc::make_mut(&mut cache.bvh)
                    .refit(&object.mesh.positions)
                    .map_err(|source| PipelineError::Spatial { object: object.name.to_string(), source })?;
            }
            let ObjectCache { regions, topology, components, bvh, .. } = cache;
            update_regions(regions, selection, object.mesh, bvh, topology, components)
                .map_err(|reason| PipelineError::invalid_region(object.name, reason))?;
            let open = object.params.contact_open_border.as_deref();
            for sub in regions.iter_mut().filter_map(|r| r.sub.as_deref_mut()) {
                sub.open_contact_border(open);
            }
            Ok(())
        },
    )
}
