//! The self-contact stage of a frame (thesis ch. 6): every object with articulations
//! ([`ObjectParams::self_contact`]) has them resolved first, in parallel over objects and
//! articulations, with one volume-preserving bulge height per articulation solved on the whole
//! object ([`crate::skinning::plan_articulation`], [`crate::skinning::apply_articulations`]). The contacts between objects (ch. 4–5) then run on
//! the result.
//!
//! *Decision (ordering):* a skinned character that folds onto itself and also touches another
//! object is first made free of its own folds, then deformed by the other object. The two stages
//! see consistent inputs (the second one's input has no self-intersection at the articulations),
//! and each stage preserves the volume of its own input, so the whole frame does too.
//!
//! The rest pose on which β is computed is [`ObjectParams::rest_positions`] (a skinned mesh's
//! bind pose), or the frame's own mesh when none is given: β then follows the frame, which keeps
//! every frame independent of the others.

use glam::DVec3;
use rayon::prelude::*;

use super::part_contact::{PartContactCache, PartPairStats, resolve_part_contacts};
use super::{Frame, ObjectParams, ObjectStats, PipelineError};
use crate::deform::DeformParams;
use crate::mesh::{Topology, TriMesh, signed_volume, vertex_normals};
use crate::skinning::{
    ArticulationPlan, ArticulationSetup, ArticulationStats, apply_articulations, plan_articulation,
    self_intersection_counts,
};

/// What the deformer keeps about an object's articulations between frames.
#[derive(Debug, Default)]
pub(super) struct SelfContactCache {
    triangles: Vec<[u32; 3]>,
    topology: Option<Topology>,
    setups: Vec<Option<ArticulationSetup>>,
    /// The contacts between its parts (issue 27).
    parts: PartContactCache,
}

/// The self-contact result of one object at one frame.
#[derive(Clone, Debug)]
pub struct SelfContactResult {
    /// The object's positions after its articulations (the input to the contacts between
    /// objects).
    pub positions: Vec<DVec3>,
    /// Per vertex: in a contact zone of one of its articulations.
    pub contact: Vec<bool>,
    /// Per vertex: moved by one of its articulations.
    pub moved: Vec<bool>,
    /// Per articulation: ℛ's vertices (object ids) and their crease-cut label (true = 𝒲̄₁).
    pub cuts: Vec<(Vec<u32>, Vec<bool>)>,
    /// With self-contact parts: the faces intersecting beyond the rest pose's, in the input and
    /// after this stage (see [`ObjectStats::self_intersecting_faces`]).
    pub self_intersecting_faces: Option<[usize; 2]>,
    /// With self-contact parts: what the untangling did.
    pub untangled: Option<super::Untangled>,
}

/// The figures of a frame's self-contact stage: per articulation and per touching part pair.
pub(super) type SelfContactStats = (Vec<ArticulationStats>, Vec<PartPairStats>);

/// True if the object has self-contact to resolve: articulations or parts.
pub(super) fn has_self_contact(params: &ObjectParams) -> bool {
    !params.rigid && (!params.self_contact.is_empty() || params.self_contact_parts.is_some())
}

/// Runs the articulations, then the part contacts, of every object that has some. Returns, per
/// object, its result (`None` for objects without self-contact) and the figures.
pub(super) fn resolve_self_contacts(
    caches: &mut Vec<SelfContactCache>,
    frame: &Frame,
) -> Result<(Vec<Option<SelfContactResult>>, SelfContactStats), PipelineError> {
    let count = frame.objects.len();
    caches.resize_with(count, SelfContactCache::default);
    caches.truncate(count);
    let results: Vec<Option<(SelfContactResult, SelfContactStats)>> = caches
        .par_iter_mut()
        .zip(&frame.objects)
        .enumerate()
        .map(|(i, (cache, object))| {
            if !has_self_contact(object.params) {
                return Ok(None);
            }
            resolve_object(i, cache, object.name, object.mesh, object.params).map(Some)
        })
        .collect::<Result<_, _>>()?;
    let (mut articulations, mut part_pairs) = (Vec::new(), Vec::new());
    let results = results
        .into_iter()
        .map(|r| {
            r.map(|(result, (a, p))| {
                articulations.extend(a);
                part_pairs.extend(p);
                result
            })
        })
        .collect();
    Ok((results, (articulations, part_pairs)))
}

fn resolve_object(
    index: usize,
    cache: &mut SelfContactCache,
    name: &str,
    mesh: &TriMesh,
    params: &ObjectParams,
) -> Result<(SelfContactResult, SelfContactStats), PipelineError> {
    let n = mesh.num_vertices();
    let error = |articulation: &str, source| PipelineError::SelfContact {
        object: name.to_string(),
        articulation: articulation.to_string(),
        source: Box::new(source),
    };
    if cache.topology.is_none() || cache.triangles != mesh.triangles {
        let topology =
            mesh.check_for_deformation().map_err(|source| PipelineError::Mesh { object: name.to_string(), source })?;
        *cache = SelfContactCache {
            triangles: mesh.triangles.clone(),
            topology: Some(topology),
            setups: Vec::new(),
            parts: PartContactCache::default(),
        };
    }
    let Some(topology) = cache.topology.as_ref() else {
        return Err(PipelineError::InvalidRegion { object: name.to_string(), reason: "no topology".into() });
    };
    let rest = match &params.rest_positions {
        Some(rest) if rest.len() != n => {
            return Err(PipelineError::PerVertexLength {
                object: name.to_string(),
                what: "the rest positions",
                expected: n,
                actual: rest.len(),
            });
        }
        Some(rest) => TriMesh { positions: rest.clone(), triangles: mesh.triangles.clone() },
        None => mesh.clone(),
    };
    let closed = topology.is_closed();
    let articulations = &params.self_contact;
    cache.setups.resize_with(articulations.len(), || None);
    cache.setups.truncate(articulations.len());
    let normals = vertex_normals(mesh);
    // Any extent here is replaced by the articulation's own.
    let mut deform_params = DeformParams::of(params, 1.0, params.preserve_volume.unwrap_or(closed));
    // One value per object vertex: each articulation gathers its regions' values.
    deform_params.bulge_map = params.bulge_map.clone();
    let plans: Vec<ArticulationPlan> = cache
        .setups
        .par_iter_mut()
        .zip(articulations)
        .map(|(slot, articulation)| {
            let planned = (|| {
                let setup = match slot {
                    Some(setup) if setup.matches(mesh, articulation) => {
                        setup.set_rest(&rest, topology)?;
                        setup
                    }
                    _ => slot.insert(ArticulationSetup::new(mesh, topology, articulation, &rest)?),
                };
                plan_articulation(mesh, topology, &normals, setup, articulation, &deform_params)
            })();
            let mut plan = match planned {
                Ok(plan) => plan,
                Err(e) if articulation.automatic => inactive_plan(n, articulation, e.to_string()),
                Err(e) => return Err(error(&articulation.name, e)),
            };
            plan.stats.object = index;
            Ok(plan)
        })
        .collect::<Result<_, _>>()?;
    let preserve = params.preserve_volume.unwrap_or(closed);
    let applied = apply_articulations(mesh, &plans, preserve, params.bulge_height, params.bulge)
        .map_err(|source| PipelineError::Deform { object: name.to_string(), source })?;
    let after = TriMesh { positions: applied.positions, triangles: mesh.triangles.clone() };
    let mut contact = vec![false; n];
    let mut moved = vec![false; n];
    let mut cuts = Vec::with_capacity(plans.len());
    let mut stats = Vec::with_capacity(plans.len());
    for ((plan, &(height, exact)), setup) in plans.into_iter().zip(&applied.heights).zip(&cache.setups) {
        for v in 0..n {
            contact[v] |= plan.contact[v];
            moved[v] |= plan.displacement.moved[v];
        }
        let mut s = plan.stats;
        s.bulge_height = height;
        s.applied_bulge_height = params.bulge * height;
        s.volume_exact = exact;
        if s.error.is_some() {
            // Left inactive: nothing cut, nothing to count.
            cuts.push((Vec::new(), Vec::new()));
        } else if let Some(setup) = setup {
            let spatial = |source| PipelineError::Spatial { object: name.to_string(), source };
            let before = self_intersection_counts(mesh, setup, &plan.labels).map_err(spatial)?;
            let after = self_intersection_counts(&after, setup, &plan.labels).map_err(spatial)?;
            s.self_intersecting_faces_before = before.all;
            s.self_intersecting_faces_after = after.all;
            s.self_intersecting_faces_across_before = before.across;
            s.self_intersecting_faces_across_after = after.across;
            cuts.push((setup.shared().vertices.clone(), plan.labels));
        }
        stats.push(s);
    }
    let (positions, part_pairs, self_intersecting_faces, untangled) = match &params.self_contact_parts {
        Some(parts) => {
            let r = resolve_part_contacts(&mut cache.parts, index, name, mesh, &after, &rest, params, parts)?;
            for (m, p) in moved.iter_mut().zip(r.moved) {
                *m |= p;
            }
            (r.positions, r.pairs, Some(r.self_intersecting_faces), Some(r.untangled))
        }
        None => (after.positions, Vec::new(), None, None),
    };
    let result = SelfContactResult { positions, contact, moved, cuts, self_intersecting_faces, untangled };
    Ok((result, (stats, part_pairs)))
}

/// The plan of an automatic articulation that failed at this frame: no displacement, the reason
/// in its figures.
fn inactive_plan(n: usize, articulation: &crate::params::Articulation, reason: String) -> ArticulationPlan {
    ArticulationPlan {
        displacement: crate::deform::AffineDisplacement::none(n),
        extent: f64::NAN,
        labels: Vec::new(),
        contact: vec![false; n],
        stats: ArticulationStats {
            name: articulation.name.clone(),
            error: Some(reason),
            ..ArticulationStats::default()
        },
    }
}

/// Makes the figures of the objects with articulations relative to the frame's input, not to the
/// self-contact stage's output that the contacts between objects started from: the volume before,
/// the relative volume change, the largest displacement, and whether the object was deformed.
pub(super) fn relative_to_input(
    stats: &mut [ObjectStats],
    frame: &Frame,
    positions: &[Vec<DVec3>],
    resolved: &[Option<SelfContactResult>],
) {
    for ((stats, object), (positions, r)) in stats.iter_mut().zip(&frame.objects).zip(positions.iter().zip(resolved)) {
        if r.is_none() {
            continue;
        }
        stats.volume_before = signed_volume(object.mesh);
        if stats.volume_before != 0.0 {
            stats.relative_volume_change = (stats.volume_after - stats.volume_before) / stats.volume_before.abs();
        }
        stats.max_displacement =
            object.mesh.positions.iter().zip(positions).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        stats.deformed |= r.as_ref().is_some_and(|r| r.moved.iter().any(|&m| m));
        stats.self_intersecting_faces = r.as_ref().and_then(|r| r.self_intersecting_faces);
        stats.untangled = r.as_ref().and_then(|r| r.untangled);
    }
}
