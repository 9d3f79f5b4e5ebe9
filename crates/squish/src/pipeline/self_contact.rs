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

use std::sync::Arc;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::part_contact::{FramePairs, PartContactCache, PartPairStats, resolve_part_contacts};
use super::plan::{JobKind, JobLevel, JobRecord, Trace};
use super::{Frame, FrameObject, ObjectParams, ObjectStats, PipelineError};
use crate::deform::DeformParams;
use crate::mesh::{Topology, TriMesh, signed_volume, vertex_normals};
use crate::params::VertexFlags;
use crate::skinning::{
    ArticulationContact, ArticulationPlan, ArticulationSetup, ArticulationStats, apply_articulations,
    articulation_crossings, articulation_interiors, contact_articulation, deform_articulation,
    self_intersection_counts_from_pairs,
};
use crate::spatial::{IntersectingPairs, SpatialError, TriangleBvh};
use crate::stage::{SharedWork, Stage, StageTimes, StageWork, Work};

/// What the deformer keeps about an object's self-contacts between frames.
#[derive(Debug, Default)]
pub(super) struct SelfContactCache {
    triangles: Vec<[u32; 3]>,
    topology: Option<Topology>,
    /// Tree over the whole object, refitted to each frame: shared by its articulations (and by
    /// their interior flags, which hold it while the frame runs).
    tree: Option<Arc<TriangleBvh>>,
    setups: Vec<Option<ArticulationSetup>>,
    /// The contacts between its parts (issue 27).
    parts: PartContactCache,
    /// With parts: the intersecting face pairs of the whole object at the last frame's input,
    /// their tree refitted to the next frame's rather than built again (at this frame's input
    /// once found, before its articulations).
    crossing_pairs: Option<IntersectingPairs>,
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

/// True if the object has self-contact to resolve: articulations or parts.
pub(super) fn has_self_contact(params: &ObjectParams) -> bool {
    !params.rigid && (!params.self_contact.is_empty() || params.self_contact_parts.is_some())
}

/// What the articulations of an object share at one frame: its rest pose and normals, and which
/// of its vertices lie inside another part (asked where chapter 4 needs them).
struct Prepared {
    rest: TriMesh,
    normals: Vec<DVec3>,
    interior: VertexFlags,
    closed: bool,
}

/// An articulation job: its object, its index among the object's articulations, and where it is.
enum ArticulationState {
    /// Its caches are ready.
    Ready,
    /// Its contact definition (ch. 4) is done, with the work of its crease cut.
    Contact(Box<ArticulationContact>, Box<StageWork>),
    /// Its deformation (ch. 5) is planned, with its work.
    Planned(Box<ArticulationPlan>, Work),
}

/// The plan's first level (see `plan`): every object with self-contact has its articulations
/// resolved as jobs — their caches, the crease cut and chapter 4 of every job in parallel, then
/// chapter 5 of every job in parallel, then per object the blend and the bulge heights — then its
/// part contacts. Returns, per object, its result (`None` for objects without self-contact); the
/// jobs, their figures and the stage times go to `trace`.
pub(super) fn resolve_self_contacts(
    caches: &mut Vec<SelfContactCache>,
    frame: &Frame,
    trace: &mut Trace,
) -> Result<Vec<Option<SelfContactResult>>, PipelineError> {
    let count = frame.objects.len();
    caches.resize_with(count, SelfContactCache::default);
    caches.truncate(count);
    if !frame.objects.iter().any(|o| has_self_contact(o.params)) {
        return Ok(vec![None; count]);
    }

    // Setup: each object's connectivity caches and rest pose, then every articulation's caches.
    let setup_start = Instant::now();
    for (cache, object) in caches.iter_mut().zip(&frame.objects) {
        if has_self_contact(object.params) {
            refresh_object(cache, object)?;
        }
    }
    let mut jobs: Vec<(usize, usize)> = Vec::new();
    for (i, object) in frame.objects.iter().enumerate() {
        if has_self_contact(object.params) {
            jobs.extend((0..object.params.self_contact.len()).map(|k| (i, k)));
        }
    }
    let records: Vec<usize> = jobs
        .iter()
        .map(|&(i, k)| {
            let name =
                format!("{}: articulation \"{}\"", frame.objects[i].name, frame.objects[i].params.self_contact[k].name);
            trace.push_job(JobRecord::new(JobLevel::SelfContact, JobKind::Articulation, name, [i, i]))
        })
        .collect();
    let rests: Vec<Option<TriMesh>> = caches
        .iter()
        .zip(&frame.objects)
        .map(|(_, o)| has_self_contact(o.params).then(|| rest_mesh(o)).transpose())
        .collect::<Result<_, _>>()?;
    let mut slots = setup_slots(caches, frame);
    let mut states: Vec<Result<ArticulationState, String>> = slots
        .par_iter_mut()
        .map(|(i, k, topology, slot)| {
            let object = &frame.objects[*i];
            let (Some(rest), Some(topology)) = (rests[*i].as_ref(), topology) else {
                return Ok(Err("no topology".to_string()));
            };
            let articulation = &object.params.self_contact[*k];
            let ready = match slot {
                Some(setup) if setup.matches(object.mesh, articulation) => setup.set_rest(rest, topology),
                _ => ArticulationSetup::new(object.mesh, topology, articulation, rest).map(|setup| {
                    **slot = Some(setup);
                }),
            };
            job_outcome(object, articulation, ready.map(|()| ArticulationState::Ready))
        })
        .collect::<Result<_, PipelineError>>()?;
    drop(slots);
    // With parts: the whole object's crossing pairs at the input, which the counts before and
    // after start from (`finish_object`), found before the articulations so that one none of
    // whose faces cross another skips its interior flags, its truncated regions and chapter 4.
    let pairs_start = Instant::now();
    let (input_pairs, pairs_work) = Work::measure(|| {
        caches
            .iter_mut()
            .zip(&frame.objects)
            .map(|(cache, object)| match object.params.self_contact_parts {
                Some(_) if has_self_contact(object.params) => {
                    crossing_pairs_at_input(cache.crossing_pairs.take(), object.mesh)
                        .map_err(|source| PipelineError::Spatial { object: object.name.to_string(), source })
                }
                _ => Ok(None),
            })
            .collect::<Result<Vec<_>, _>>()
    });
    let mut input_pairs = input_pairs?;
    let pairs_time = pairs_start.elapsed();
    trace.time(Stage::Quality, pairs_time);
    trace.work[Stage::Quality] += pairs_work;
    // Per object and articulation: some of its faces cross (unknown: true).
    let crossing: Vec<Vec<bool>> = caches
        .iter()
        .zip(&input_pairs)
        .map(|(cache, pairs)| {
            cache
                .setups
                .iter()
                .map(|setup| match (pairs, setup) {
                    (Some(pairs), Some(setup)) => faces_cross(pairs.pairs(), setup.faces()),
                    _ => true,
                })
                .collect()
        })
        .collect();

    // Each object's work counted in a span of its own, whatever thread runs it.
    let prepared: Vec<(Result<Option<Prepared>, PipelineError>, Work)> = caches
        .par_iter_mut()
        .zip(&frame.objects)
        .zip(rests)
        .enumerate()
        .map(|(i, ((cache, object), rest))| {
            Work::measure(|| {
                let Some(rest) = rest else { return Ok(None) };
                prepare(
                    cache,
                    object,
                    rest,
                    jobs.iter()
                        .zip(&states)
                        .filter(|((o, k), s)| *o == i && s.is_ok() && crossing[i].get(*k).copied().unwrap_or(true))
                        .map(|((_, k), _)| *k),
                )
                .map(Some)
            })
        })
        .collect();
    let mut setup_work = StageWork::default();
    for (_, work) in &prepared {
        setup_work[Stage::Setup] += *work;
    }
    let prepared: Vec<Option<Prepared>> = prepared.into_iter().map(|(p, _)| p).collect::<Result<_, PipelineError>>()?;
    let mut setup_times = StageTimes::default();
    setup_times[Stage::Setup] = setup_start.elapsed().saturating_sub(pairs_time);
    trace.add(&setup_times, &setup_work);

    // The crease cut and chapter 4 of every articulation, in parallel.
    let mut slots = setup_slots(caches, frame);
    states = slots
        .par_iter_mut()
        .zip(states)
        .map(|((i, k, topology, slot), state)| {
            let (object, articulation) = (&frame.objects[*i], &frame.objects[*i].params.self_contact[*k]);
            let (Ok(ArticulationState::Ready), Some(setup), Some(topology), Some(prepared)) =
                (&state, slot.as_mut(), topology, prepared[*i].as_ref())
            else {
                return Ok(state);
            };
            let crossing = crossing[*i].get(*k).copied().unwrap_or(true);
            // Its work beyond chapter 4's own stages (the crease cut, the truncated regions) is
            // the cut's.
            let (found, rest) = Work::measure(|| {
                contact_articulation(
                    object.mesh,
                    topology,
                    &prepared.normals,
                    &prepared.interior,
                    setup,
                    articulation,
                    crossing,
                )
            });
            let mut work = StageWork::default();
            work[Stage::CreaseCut] = rest;
            job_outcome(object, articulation, found.map(|c| ArticulationState::Contact(Box::new(c), Box::new(work))))
        })
        .collect::<Result<_, PipelineError>>()?;
    for (state, &job) in states.iter().zip(&records) {
        if let Ok(ArticulationState::Contact(c, cut_work)) = state {
            let mut times = StageTimes::default();
            // Like its work, the step's time beyond chapter 4's own stages is the cut's.
            times[Stage::CreaseCut] = c.time_beyond_contact();
            let mut work = **cut_work;
            if let Some(contact) = &c.contact {
                times += &contact.stats.timings;
                work += &contact.stats.work;
            }
            trace.add_to_job(job, &times, &work);
            trace.jobs[job].in_contact = c.in_contact();
        }
    }

    // Chapter 5 of every articulation in contact, up to its bulge height, in parallel.
    states = slots
        .par_iter_mut()
        .zip(states)
        .map(|((i, k, _, slot), state)| {
            let object = &frame.objects[*i];
            let articulation = &object.params.self_contact[*k];
            let found = match state {
                Ok(ArticulationState::Contact(found, _)) => found,
                Ok(_) => return Ok(Err("its caches were not ready".to_string())),
                Err(reason) => return Ok(Err(reason)),
            };
            let (Some(setup), Some(prepared)) = (slot.as_mut(), prepared[*i].as_ref()) else {
                return Ok(Err("its caches were not ready".to_string()));
            };
            // Any extent here is replaced by the articulation's own.
            let preserve = object.params.preserve_volume.unwrap_or(prepared.closed);
            let mut deform_params = DeformParams::of(object.params, 1.0, preserve);
            // One value per object vertex: each articulation gathers its regions' values.
            deform_params.bulge_map = object.params.bulge_map.clone();
            let (planned, work) =
                Work::measure(|| deform_articulation(*found, object.mesh, setup, articulation, &deform_params));
            job_outcome(object, articulation, planned.map(|p| ArticulationState::Planned(Box::new(p), work)))
        })
        .collect::<Result<_, PipelineError>>()?;
    drop(slots);

    // Per object: the blend over the shared regions and the bulge heights, then its part contacts.
    let mut results = Vec::with_capacity(count);
    let mut states = states.into_iter().zip(records).zip(&jobs).peekable();
    for (i, (cache, object)) in caches.iter_mut().zip(&frame.objects).enumerate() {
        let Some(prepared) = prepared[i].as_ref() else {
            results.push(None);
            continue;
        };
        let mut plans = Vec::new();
        let mut plan_jobs = Vec::new();
        while let Some(((state, job), &(o, k))) = states.next_if(|(_, (o, _))| *o == i) {
            let articulation = &object.params.self_contact[k];
            let (mut plan, work) = match state {
                Ok(ArticulationState::Planned(plan, work)) => (*plan, work),
                Ok(_) => (
                    inactive_plan(object.mesh.num_vertices(), articulation, "its caches were not ready".into()),
                    Work::ZERO,
                ),
                Err(reason) => (inactive_plan(object.mesh.num_vertices(), articulation, reason), Work::ZERO),
            };
            plan.stats.object = o;
            let mut times = StageTimes::default();
            times[Stage::Deformation] = plan.stats.deformation_time;
            times[Stage::Regions] = plan.stats.analysis_time;
            let mut stage_work = StageWork::default();
            stage_work[Stage::Deformation] = work;
            trace.add_to_job(job, &times, &stage_work);
            trace.jobs[job].error.clone_from(&plan.stats.error);
            plans.push(plan);
            plan_jobs.push(job);
        }
        cache.crossing_pairs = input_pairs[i].take();
        let (result, stats, part_pairs) = finish_object(i, cache, object, prepared, plans, &plan_jobs, trace)?;
        trace.articulations.extend(stats);
        trace.part_pairs.extend(part_pairs);
        results.push(Some(result));
    }
    Ok(results)
}

/// The articulations of every object as `(object, index, topology, cache slot)`, in job order.
type SetupSlot<'c> = (usize, usize, Option<&'c Topology>, &'c mut Option<ArticulationSetup>);

fn setup_slots<'c>(caches: &'c mut [SelfContactCache], frame: &Frame) -> Vec<SetupSlot<'c>> {
    let mut slots = Vec::new();
    for (i, (cache, object)) in caches.iter_mut().zip(&frame.objects).enumerate() {
        if !has_self_contact(object.params) {
            continue;
        }
        let SelfContactCache { topology, setups, .. } = cache;
        let topology = topology.as_ref();
        for (k, slot) in setups.iter_mut().enumerate() {
            slots.push((i, k, topology, slot));
        }
    }
    slots
}

/// A job's result, or the reason it was left inactive: an automatic articulation that fails is
/// reported, an explicit one fails the frame.
fn job_outcome<T>(
    object: &FrameObject,
    articulation: &crate::params::Articulation,
    outcome: Result<T, crate::skinning::SelfContactError>,
) -> Result<Result<T, String>, PipelineError> {
    match outcome {
        Ok(t) => Ok(Ok(t)),
        // An automatic articulation's regions are the pipeline's: no advice about working regions.
        Err(crate::skinning::SelfContactError::Contact(e)) if articulation.automatic => {
            Ok(Err(format!("contact between its two sides: {}", super::error::contact_automatic_wording(&e))))
        }
        Err(e) if articulation.automatic => Ok(Err(e.to_string())),
        Err(e) => Err(PipelineError::SelfContact {
            object: object.name.to_string(),
            articulation: articulation.name.clone(),
            source: Box::new(e),
        }),
    }
}

/// Brings an object's connectivity caches to this frame (rebuilt when its triangles change) and
/// sizes its articulation slots.
fn refresh_object(cache: &mut SelfContactCache, object: &FrameObject) -> Result<(), PipelineError> {
    let mesh = object.mesh;
    if cache.topology.is_none() || cache.triangles != mesh.triangles {
        let topology = mesh
            .check_for_deformation()
            .map_err(|source| PipelineError::Mesh { object: object.name.to_string(), source })?;
        *cache = SelfContactCache {
            triangles: mesh.triangles.clone(),
            topology: Some(topology),
            tree: None,
            setups: Vec::new(),
            parts: PartContactCache::default(),
            crossing_pairs: None,
        };
    }
    let count = object.params.self_contact.len();
    cache.setups.resize_with(count, || None);
    cache.setups.truncate(count);
    Ok(())
}

/// The object's rest pose: its rest positions, or the frame's own mesh when none is given.
fn rest_mesh(object: &FrameObject) -> Result<TriMesh, PipelineError> {
    let mesh = object.mesh;
    match &object.params.rest_positions {
        Some(rest) if rest.len() != mesh.num_vertices() => Err(PipelineError::PerVertexLength {
            object: object.name.to_string(),
            what: "the rest positions",
            expected: mesh.num_vertices(),
            actual: rest.len(),
        }),
        Some(rest) => Ok(TriMesh { positions: rest.clone(), triangles: mesh.triangles.clone() }),
        None => Ok(mesh.clone()),
    }
}

/// What an object's articulations share at this frame (see [`Prepared`]): the whole object's tree
/// refitted once, its normals, and the interior flags of the vertices of the articulations
/// `ready` (those whose caches are ready and whose faces cross: the others skip their truncated
/// regions, the only readers of the flags).
fn prepare(
    cache: &mut SelfContactCache,
    object: &FrameObject,
    rest: TriMesh,
    ready: impl Iterator<Item = usize>,
) -> Result<Prepared, PipelineError> {
    let mesh = object.mesh;
    let spatial = |source| PipelineError::Spatial { object: object.name.to_string(), source };
    let normals = vertex_normals(mesh);
    let setups: Vec<&ArticulationSetup> = ready.filter_map(|k| cache.setups.get(k)?.as_ref()).collect();
    let interior = if setups.is_empty() {
        VertexFlags::new(|asked| vec![false; asked.len()])
    } else {
        let tree = match cache.tree.as_mut() {
            Some(tree) => {
                Arc::make_mut(tree).refit(&mesh.positions).map_err(spatial)?;
                Arc::clone(tree)
            }
            None => Arc::clone(cache.tree.insert(Arc::new(TriangleBvh::new(mesh).map_err(spatial)?))),
        };
        articulation_interiors(mesh, &normals, tree, setups)
    };
    let closed = cache.topology.as_ref().is_some_and(Topology::is_closed);
    Ok(Prepared { rest, normals, interior, closed })
}

/// The intersecting face pairs of the whole object at the frame's input: `kept`'s (the last
/// frame's input, its tree refitted) enumerated again where vertices moved. `None` past the
/// budget of overlapping boxes (a fan): the counts then search faces instead.
fn crossing_pairs_at_input(
    kept: Option<IntersectingPairs>,
    input: &TriMesh,
) -> Result<Option<IntersectingPairs>, SpatialError> {
    let budget = crate::spatial::PAIRS_PER_FACE * input.num_triangles();
    match kept {
        Some(mut pairs) if pairs.num_vertices() == input.num_vertices() => {
            Ok(pairs.update(input, budget)?.then_some(pairs))
        }
        _ => IntersectingPairs::new(input, budget),
    }
}

/// The pairs of `at_input` ([`crossing_pairs_at_input`]) and those after the articulations,
/// enumerated again where they moved vertices; `None` past the budget.
fn whole_object_pairs(
    at_input: Option<IntersectingPairs>,
    after: &TriMesh,
) -> Result<Option<(IntersectingPairs, IntersectingPairs)>, SpatialError> {
    let Some(at_input) = at_input else { return Ok(None) };
    let budget = crate::spatial::PAIRS_PER_FACE * after.num_triangles();
    let mut at_after = at_input.clone();
    Ok(at_after.update(after, budget)?.then_some((at_input, at_after)))
}

/// True if some pair of `pairs` has both faces among `faces` (sorted).
fn faces_cross(pairs: &[[u32; 2]], faces: &[u32]) -> bool {
    pairs.iter().any(|&[f, g]| faces.binary_search(&f).is_ok() && faces.binary_search(&g).is_ok())
}

/// An object's articulations applied (the blend and the bulge heights, §6 and App. C), their
/// figures, then its part contacts (issue 27).
fn finish_object(
    index: usize,
    cache: &mut SelfContactCache,
    object: &FrameObject,
    prepared: &Prepared,
    mut plans: Vec<ArticulationPlan>,
    plan_jobs: &[usize],
    trace: &mut Trace,
) -> Result<(SelfContactResult, Vec<ArticulationStats>, Vec<PartPairStats>), PipelineError> {
    let (name, mesh, params) = (object.name, object.mesh, object.params);
    let n = mesh.num_vertices();
    let preserve = params.preserve_volume.unwrap_or(prepared.closed);
    let applied = loop {
        let applied = trace
            .run(Stage::Blend, || apply_articulations(mesh, &plans, preserve, params.bulge_height, params.bulge))
            .map_err(|source| PipelineError::Deform { object: name.to_string(), source })?;
        // A bulge taller than its articulation's extent: the volume cubic's smallest root is far
        // (no bulge of the region's size gives the volume back), so the volume would go into a
        // spike. That articulation is left without effect and the others' heights are solved
        // again (docs/decisions.md, "An articulation's bulge taller than its extent").
        let spikes: Vec<(usize, f64)> = plans
            .iter()
            .zip(&applied.heights)
            .enumerate()
            .filter(|(_, (plan, (h, _)))| {
                plan.stats.error.is_none() && plan.extent.is_finite() && (params.bulge * h).abs() > plan.extent
            })
            .map(|(k, (_, (h, _)))| (k, params.bulge * h))
            .collect();
        if spikes.is_empty() {
            break applied;
        }
        for (k, height) in spikes {
            let Some(articulation) = params.self_contact.get(k) else { continue };
            let reason = format!(
                "a bulge of height {height:.3e} over an extent of {:.3e} would put the volume into a spike; left without effect",
                plans[k].extent
            );
            let object_index = plans[k].stats.object;
            plans[k] = inactive_plan(n, articulation, reason.clone());
            plans[k].stats.object = object_index;
            if let Some(record) = plan_jobs.get(k).and_then(|&job| trace.jobs.get_mut(job)) {
                record.error = Some(reason);
            }
        }
    };
    let after = TriMesh { positions: applied.positions, triangles: mesh.triangles.clone() };
    let timer = Instant::now();
    let (counted, quality_work) = Work::measure(|| -> Result<_, PipelineError> {
        let spatial = |source| PipelineError::Spatial { object: name.to_string(), source };
        // Each articulation's faces crossing before and after. The intersecting face pairs of the input and of the result over the articulations'
        // faces, enumerated once each, give every articulation's counts; where the faces' boxes
        // overlap too often for that (a fan), each articulation searches its own faces, in
        // parallel, each task counting its work in a span of its own.
        let counted: Vec<bool> = plans
            .iter()
            .zip(&cache.setups)
            .map(|(plan, setup)| setup.is_some() && plan.stats.error.is_none())
            .collect();
        let mut faces: Vec<u32> = plans
            .iter()
            .zip(&cache.setups)
            .zip(&counted)
            .filter(|(_, c)| **c)
            .filter_map(|((_, setup), _)| setup.as_ref())
            .flat_map(|setup| setup.faces().iter().copied())
            .collect();
        faces.sort_unstable();
        faces.dedup();
        let work = SharedWork::default();
        // With parts, the pairs of the whole object, which the part contacts count from too;
        // else those of the articulations' faces.
        let frame_pairs = match params.self_contact_parts {
            Some(_) => whole_object_pairs(cache.crossing_pairs.take(), &after).map_err(spatial)?,
            None => None,
        };
        let articulation_pairs;
        let (pairs_before, pairs_after) = match &frame_pairs {
            Some((input, result)) => (Some(input.pairs()), Some(result.pairs())),
            None => {
                let budget = crate::spatial::PAIRS_PER_FACE * faces.len();
                let (before, after_pairs) = rayon::join(
                    || work.measure(|| crate::spatial::self_intersecting_pairs(mesh, &faces, budget)),
                    || work.measure(|| crate::spatial::self_intersecting_pairs(&after, &faces, budget)),
                );
                articulation_pairs = (before.map_err(spatial)?, after_pairs.map_err(spatial)?);
                (articulation_pairs.0.as_deref(), articulation_pairs.1.as_deref())
            }
        };
        let counts: Vec<Option<_>> = match (pairs_before, pairs_after) {
            (Some(before), Some(after_pairs)) => plans
                .iter()
                .zip(&cache.setups)
                .zip(&counted)
                .map(|((plan, setup), &counted)| {
                    setup.as_ref().filter(|_| counted).map(|setup| {
                        (
                            self_intersection_counts_from_pairs(mesh, setup, &plan.labels, before),
                            self_intersection_counts_from_pairs(&after, setup, &plan.labels, after_pairs),
                        )
                    })
                })
                .collect(),
            _ => plans
                .par_iter()
                .zip(&cache.setups)
                .zip(&counted)
                .map(|((plan, setup), &counted)| match setup {
                    Some(setup) if counted => work.measure(|| {
                        let before = articulation_crossings(mesh, setup, &plan.labels, None)?;
                        let after = articulation_crossings(&after, setup, &plan.labels, Some(&before))?;
                        Ok(Some((before.counts(), after.counts())))
                    }),
                    _ => Ok(None),
                })
                .collect::<Result<_, _>>()
                .map_err(spatial)?,
        };
        work.record();
        let mut contact = vec![false; n];
        let mut moved = vec![false; n];
        let mut cuts = Vec::with_capacity(plans.len());
        let mut stats = Vec::with_capacity(plans.len());
        for (((plan, &(height, exact)), setup), counts) in
            plans.into_iter().zip(&applied.heights).zip(&cache.setups).zip(counts)
        {
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
            } else if let (Some(setup), Some((before, after))) = (setup, counts) {
                s.self_intersecting_faces_before = before.all;
                s.self_intersecting_faces_after = after.all;
                s.self_intersecting_faces_across_before = before.across;
                s.self_intersecting_faces_across_after = after.across;
                cuts.push((setup.shared().vertices.clone(), plan.labels));
            }
            stats.push(s);
        }
        Ok((contact, moved, cuts, stats, frame_pairs))
    });
    let (contact, mut moved, cuts, stats, frame_pairs) = counted?;
    trace.time(Stage::Quality, timer.elapsed());
    trace.work[Stage::Quality] += quality_work;
    let (positions, part_pairs, self_intersecting_faces, untangled) = match &params.self_contact_parts {
        Some(parts) => {
            let (input_pairs, after_pairs) = frame_pairs.unzip();
            let given =
                input_pairs.as_ref().zip(after_pairs).map(|(input, mesh)| FramePairs { input: input.pairs(), mesh });
            let r = resolve_part_contacts(
                &mut cache.parts,
                index,
                name,
                mesh,
                &after,
                &prepared.rest,
                params,
                parts,
                given,
            )?;
            cache.crossing_pairs = input_pairs;
            // Each touching part pair is a job of the plan's first level (its figures in
            // `part_pairs`), with the stages it ran.
            for (pair, (times, work)) in r.pairs.iter().zip(&r.pair_stages) {
                let job_name = format!("{name}: parts \"{}\" – \"{}\" ({})", pair.parts[0], pair.parts[1], pair.kind);
                let mut record = JobRecord::new(JobLevel::SelfContact, JobKind::Parts, job_name, [index, index]);
                record.in_contact = pair.in_contact;
                record.error.clone_from(&pair.error);
                let job = trace.push_job(record);
                trace.add_to_job(job, times, work);
            }
            // What the pairs share (the search for touching pairs) and the counts of the faces
            // crossing before and after.
            let mut times = StageTimes::default();
            let mut work = StageWork::default();
            times[Stage::Setup] = r.rest_caches.time;
            work[Stage::Setup] = r.rest_caches.work;
            times[Stage::PartContacts] = r.search.time;
            work[Stage::PartContacts] = r.search.work;
            times[Stage::Untangle] = r.untangled.time;
            work[Stage::Untangle] = r.untangle_work;
            times[Stage::Quality] = r.counts.time;
            work[Stage::Quality] = r.counts.work;
            trace.add(&times, &work);
            for (m, p) in moved.iter_mut().zip(r.moved) {
                *m |= p;
            }
            (r.positions, r.pairs, Some(r.self_intersecting_faces), Some(r.untangled))
        }
        None => (after.positions, Vec::new(), None, None),
    };
    let result = SelfContactResult { positions, contact, moved, cuts, self_intersecting_faces, untangled };
    Ok((result, stats, part_pairs))
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
