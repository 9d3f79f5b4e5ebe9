//! The library's entry point: one frame of a scene in, deformed meshes and [`FrameStats`] out
//! (thesis ch. 3's pipeline, figure 3.1, method B).
//!
//! A [`Frame`] lists objects (meshes with [`ObjectParams`]) and the pairs of objects that may
//! touch (with [`PairParams`]). Every object is divided into **working regions** 𝒲
//! ([`ObjectParams::region`], [`RegionChoice`]; default: the whole object — see `regions` for
//! the choices). [`Deformer::deform`] runs the stages of [`Stage::ALL`], one private module each, each
//! a function with explicit inputs and outputs:
//! 0. `self_contact` (ch. 6): the articulations of skinned objects, first;
//! 1. `setup` (ch. 3): the frame's pairs and parameters checked, each object's cache brought to
//!    this frame (connectivity-only caches, refitted trees, component figures);
//! 2. `regions` (§4.5): each object's working regions chosen and their caches updated;
//! 3. `contacts` (ch. 4): every [`FramePair`] expanded into the pairs of its objects' regions
//!    whose boxes overlap (a hand of five finger regions against a ball is one `FramePair`; a pair
//!    of one object with itself pairs its distinct regions: fingers on their own palm), and the
//!    contact definition run on each, in parallel — intersection regions, mapping direction,
//!    mapping regions, potential contact surface, contact zones — each region pair with its own
//!    d̂ and ε_c;
//! 4. `deformations` (ch. 5): every region of a non-rigid object with zones deformed with all of
//!    them (regions in parallel; several zones are diffused into one direction field, §5.2.2, and
//!    the anisotropic bulge map sums over them, Eq. 5.6);
//! 5. `separation` (issue 29): the outputs of every region pair with a contact gap pushed apart
//!    until no triangle of one crosses the other, each region's bulge height solved again so
//!    that its volume stays preserved;
//! 6. `results`: the regions written back into each object's positions (vertices outside every
//!    region are returned bit for bit), and the per-stage times and quality figures, per object,
//!    per region and per region pair ([`FrameStats`]).
//!
//! Every frame is computed from scratch: the result never depends on the frames processed before.
//! What the [`Deformer`] keeps between frames is only what does not depend on positions — each
//! object's topology, each region's sub-mesh, topology, triangle tree (refitted) and sparse-matrix
//! pattern with its symbolic factorization — so a frame costs numeric work only (plus a rebuild
//! for a region whose face set changed). The same input gives bit-identical output with a fresh or
//! a reused deformer, whatever the thread count.
//!
//! A deformer asked to [`Deformer::keep_for_edits`] also keeps the last frame's contact stage
//! and each region's fields of §5.1–5.3, and computes a frame that differs from it only by
//! parameters of §5.4–5.5 ([`DOWNSTREAM_KEYS`]) from them: an interactive edit of the profile,
//! the bulge or the bulge map, with the same bits as a full computation (see `edits`).

mod cache;
mod contacts;
mod deformations;
mod edits;
mod error;
mod part_contact;
mod plan;
mod quality;
mod regions;
mod results;
mod rim;
mod self_contact;
mod separation;
mod setup;
mod stats;
mod store;
mod untangle;
mod warnings;

use std::time::Instant;

use glam::DVec3;

pub use edits::{DOWNSTREAM_KEYS, is_downstream};
pub use error::PipelineError;
pub use part_contact::{MARGIN_RINGS, PartPairStats, Untangled};
pub use plan::{JobKind, JobLevel, JobRecord};
pub use quality::PairQuality;
pub use self_contact::SelfContactResult;
pub use separation::STOP_FRACTION;
pub use stats::{FrameStats, ObjectStats, PairStats, RegionStats, RegionSummary};
pub use warnings::{FrameWarning, RESIDUAL_PENETRATION_TOLERANCE, WarningKind, pair_warnings};

use crate::contact::PairContact;
use crate::deform::RegionDeformation;
#[cfg(doc)]
use crate::deform::automatic_extent;
use crate::mesh::TriMesh;
#[cfg(doc)]
use crate::params::RegionChoice;
use crate::params::{ObjectParams, PairParams};
use crate::stage::{Stage, Work};
use cache::ObjectCache;
use contacts::{RegionPair, RegionZones};
use edits::EditState;
use plan::Trace;
use separation::{Seeds, SeparationSeed};
use store::FrameStore;

/// One object of a frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameObject<'a> {
    /// Name used in messages and reports.
    pub name: &'a str,
    /// The mesh at this frame. Its triangles must stay the same from frame to frame for the
    /// deformer's caches to be reused (they are rebuilt otherwise).
    pub mesh: &'a TriMesh,
    /// Its parameters at this frame (including its working regions).
    pub params: &'a ObjectParams,
}

/// A pair of objects that may be in contact. It stands for every pair of their working regions
/// whose boxes overlap (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FramePair {
    /// Indices of the two objects in [`Frame::objects`]. The mapping direction is oriented along
    /// the second object's normals. Both indices may be the same object when it has several
    /// explicit regions ([`RegionChoice::allows_self_contact`]): its distinct regions are paired.
    pub objects: [usize; 2],
    /// Contact parameters (τ, direction, safeguard angle), shared by its region pairs. A pair
    /// with `enabled = false` is left out of the frame (its objects are still processed).
    pub params: PairParams,
}

/// Everything the deformer needs for one frame.
#[derive(Clone, Debug, Default)]
pub struct Frame<'a> {
    pub objects: Vec<FrameObject<'a>>,
    pub pairs: Vec<FramePair>,
}

/// An object of a frame, owned: what [`FrameObject`] borrows.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OwnedObject {
    /// Name used in messages and reports.
    pub name: String,
    /// The mesh at this frame (see [`FrameObject::mesh`]).
    pub mesh: TriMesh,
    /// Its parameters at this frame.
    pub params: ObjectParams,
}

/// A frame that owns its objects: what a scene evaluates to, what a shot's workers and the
/// procedural scenes hold. [`OwnedFrame::frame`] is the deformer's borrowed view of it.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct OwnedFrame {
    pub objects: Vec<OwnedObject>,
    /// Every pair, disabled ones included (the deformer leaves those out).
    pub pairs: Vec<FramePair>,
}

impl OwnedFrame {
    /// The deformer's view of this frame.
    pub fn frame(&self) -> Frame<'_> {
        Frame {
            objects: self
                .objects
                .iter()
                .map(|o| FrameObject { name: &o.name, mesh: &o.mesh, params: &o.params })
                .collect(),
            pairs: self.pairs.clone(),
        }
    }

    /// The object called `name`.
    pub fn object_mut(&mut self, name: &str) -> Option<&mut OwnedObject> {
        self.objects.iter_mut().find(|o| o.name == name)
    }

    /// The names of a pair's two objects.
    pub fn pair_names(&self, pair: &FramePair) -> [&str; 2] {
        pair.objects.map(|i| self.objects.get(i).map_or("?", |o| o.name.as_str()))
    }
}

/// The result of one frame.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// Deformed positions per object (same order and count as the input; vertices outside the
    /// deformed regions are bit-identical to the input).
    pub positions: Vec<Vec<DVec3>>,
    /// The contact definition of each region pair, in the order of [`FrameStats::pairs`] (`None`
    /// for region pairs whose boxes are apart). Vertex and face ids are those of the regions
    /// (see [`RegionSummary::vertices`]); for objects of one region each, one entry per
    /// [`FramePair`] in object ids.
    pub contacts: Vec<Option<PairContact>>,
    /// The deformation of each object (`None` when it was not deformed), per object vertex: for
    /// an object of several regions, the regions' results written into object-sized arrays
    /// (outside the regions: u = +∞, zero direction and height, η = 1; stats summed).
    pub deformations: Vec<Option<RegionDeformation>>,
    /// The working regions, in the order of [`FrameStats::regions`].
    pub regions: Vec<RegionSummary>,
    /// Per object: the result of its articulations' self-contact (ch. 6), `None` without any.
    pub self_contact: Vec<Option<SelfContactResult>>,
    /// Timings and quality figures.
    pub stats: FrameStats,
}

impl FrameResult {
    /// The deformed mesh of object `i` (its input triangles with the new positions).
    pub fn mesh(&self, frame: &Frame, i: usize) -> TriMesh {
        TriMesh { positions: self.positions[i].clone(), triangles: frame.objects[i].mesh.triangles.clone() }
    }
}

/// Runs the pipeline frame after frame, keeping connectivity-only caches (see the module doc).
pub struct Deformer {
    /// The contacts between objects (level 2 of the plan) and their caches.
    objects: ObjectContacts,
    /// Per object: the caches of its self-contacts (ch. 6).
    self_contact: Vec<self_contact::SelfContactCache>,
    /// Whether to keep what edits reuse ([`Deformer::keep_for_edits`]).
    keep_edits: bool,
    /// What the last full frame left for edits.
    edits: Option<EditState>,
    /// The quality pass's trees; `None` when it is left out ([`Deformer::without_quality`]).
    quality: Option<quality::QualityCache>,
}

impl Default for Deformer {
    /// With the quality pass (as [`Deformer::new`]).
    fn default() -> Self {
        Self {
            objects: ObjectContacts::default(),
            self_contact: Vec::new(),
            keep_edits: false,
            edits: None,
            quality: Some(quality::QualityCache::default()),
        }
    }
}

/// The stages of the contacts between regions, and what they keep between frames: each object's
/// cache (its working regions with their sub-meshes, trees and factorizations). The frame's
/// contacts between objects run through one; so does each touching part pair of a skinned
/// object (`part_contact`), on its two regions of one mesh.
#[derive(Default)]
pub(super) struct ObjectContacts {
    caches: Vec<Option<ObjectCache>>,
    /// Symbolic factorizations run since creation (one per deformed region unless its face set
    /// or connectivity changes): lets benchmarks check that frames reuse them.
    symbolic_analyses: usize,
    /// Whether to leave out the separation pass ([`Deformer::without_separation`]).
    skip_separation: bool,
    /// What the last separation pass left for the next one (`separation::SeparationSeed`).
    separation_seed: Option<SeparationSeed>,
    /// Whether the separation pass leaves no seed (a touching part pair of a skinned mesh, whose
    /// regions change from frame to frame).
    without_seeds: bool,
}

impl ObjectContacts {
    /// Stages for one object whose connectivity caches are `object`'s (see
    /// [`ObjectCache::connectivity`]).
    fn with_object(object: ObjectCache) -> Self {
        Self { caches: vec![Some(object)], without_seeds: true, ..Self::default() }
    }
}

impl Deformer {
    /// A deformer with empty caches.
    pub fn new() -> Self {
        Self::default()
    }

    /// Leaves out the quality pass ([`PairQuality`]: penetrations and intersecting faces
    /// before and after, and the residual-penetration warning): for timings of the method alone.
    pub fn without_quality(mut self) -> Self {
        self.quality = None;
        self
    }

    /// Keeps, from now on, what a frame that differs from the last one only by parameters of
    /// §5.4–5.5 reuses ([`DOWNSTREAM_KEYS`]; the module doc): such a frame then costs the
    /// profile, bulge map and volume only, with the same result. Off by default (a shot computed
    /// frame by frame would pay for copies it never uses).
    pub fn keep_for_edits(mut self) -> Self {
        self.keep_edits = true;
        self
    }

    /// Leaves out the separation pass (`separation`, issue 29): the outputs of chapter 5 as
    /// they are, for comparisons (the thesis' method with the contact gap's targets only).
    pub fn without_separation(mut self) -> Self {
        self.objects.skip_separation = true;
        self
    }

    /// Number of symbolic Cholesky analyses run by this deformer since it was created: one per
    /// deformed region on its first frame (and again only if its face set or connectivity
    /// changes).
    pub fn symbolic_analyses(&self) -> usize {
        self.objects.symbolic_analyses
    }

    /// Deforms one frame: the frame plan (`plan`) level by level, then the results. See the
    /// module doc.
    pub fn deform(&mut self, frame: &Frame) -> Result<FrameResult, PipelineError> {
        // The frame's own span of work: what its stages do not measure stays out of the spans of
        // another frame this thread may be computing (`Work`).
        Work::measure(|| self.deform_frame(frame)).0
    }

    fn deform_frame(&mut self, frame: &Frame) -> Result<FrameResult, PipelineError> {
        let start = Instant::now();
        let frame = frame.without_disabled_pairs();
        let mut trace = Trace::default();
        let self_contact = frame.objects.iter().any(|o| self_contact::has_self_contact(o.params));
        if !self_contact {
            self.self_contact.clear();
        }
        // A failed frame must not leave the state of an earlier one; self-contact reads the
        // downstream parameters before the pairs: never an edit.
        let edit = self.edits.take().filter(|state| self.keep_edits && !self_contact && state.is_edit(&frame));

        // Level 1 of the plan: the self-contacts of skinned objects (ch. 6), on the input.
        let resolved = self_contact::resolve_self_contacts(&mut self.self_contact, &frame, &mut trace)?;
        let meshes: Vec<Option<TriMesh>> = resolved
            .iter()
            .zip(&frame.objects)
            .map(|(r, o)| {
                r.as_ref().map(|r| TriMesh { positions: r.positions.clone(), triangles: o.mesh.triangles.clone() })
            })
            .collect();
        let objects = frame
            .objects
            .iter()
            .zip(&meshes)
            .map(|(o, m)| FrameObject { mesh: m.as_ref().unwrap_or(o.mesh), ..*o })
            .collect();
        let between = Frame { objects, pairs: frame.pairs.clone() };

        // Level 2: the contacts between objects (ch. 4–5, the separation pass), or an edit of
        // the kept frame's.
        let level = match edit {
            Some(state) => {
                let level = self.objects.edit(&between, &state, &mut trace);
                self.edits = Some(state);
                level?
            }
            None => {
                let keep = self.keep_edits && !self_contact;
                let (level, kept) = self.objects.contact(&between, keep, &mut trace)?;
                self.edits = kept;
                level
            }
        };
        results::assemble(&frame, &between, &self.objects.caches, level, resolved, self.quality.as_mut(), trace, start)
    }
}

impl ObjectContacts {
    /// The contacts between objects, stage after stage: setup, working regions, their region
    /// pairs as jobs, the contact definition of every job (ch. 4), the deformation of every
    /// region with zones (ch. 5), the separation pass. `keep`: keep what edits reuse, given back
    /// with the level.
    fn contact(
        &mut self,
        frame: &Frame,
        keep: bool,
        trace: &mut Trace,
    ) -> Result<(ObjectsLevel, Option<EditState>), PipelineError> {
        // Setup (ch. 3): the frame checked before any work, then every object's cache.
        let pairing = setup::check_frame(frame)?;
        let figures =
            trace.run(Stage::Setup, || setup::update_objects(&mut self.caches, frame, &pairing.needs_tree))?;

        // Working regions (§4.5), then the jobs: every pair of their regions whose boxes overlap.
        let caches = &mut self.caches;
        let (store, region_pairs) = trace.run(Stage::Regions, || {
            regions::update_working_regions(caches, frame, &pairing.partners, &pairing.needs_tree, &figures)?;
            let caches: Vec<&ObjectCache> = caches.iter().flatten().collect();
            let store = FrameStore::new(&caches, frame, figures);
            let region_pairs = contacts::region_pairs(frame, &caches);
            Ok::<_, PipelineError>((store, region_pairs))
        })?;
        let caches: Vec<&ObjectCache> = self.caches.iter().flatten().collect();
        let jobs = contacts::job_records(frame, &store, &region_pairs, trace);

        // Chapter 4 on every job, in parallel.
        let contacts = contacts::contact_region_pairs(frame, &caches, &store, &region_pairs, &jobs, trace)?;
        let contained = warnings::contained_sides(frame, &caches, &region_pairs, &contacts);
        let regions: Vec<usize> = caches.iter().map(|c| c.regions.len()).collect();
        drop(caches);

        // Chapter 5 on every region with zones, in parallel.
        let zones = RegionZones::gather(frame, &regions, &region_pairs, &contacts);
        let mut outcomes = deformations::deform_regions(&mut self.caches, frame, &zones, &store, keep)?;
        deformations::record(&outcomes, trace);
        self.symbolic_analyses += outcomes.iter().flatten().flatten().filter(|o| o.new_solver).count();
        let summary = zones.summary();
        let mut kept_state = None;
        if keep {
            let kept = outcomes
                .iter_mut()
                .map(|o| o.iter_mut().map(|o| o.as_mut().and_then(|o| o.kept.take())).collect())
                .collect();
            kept_state = Some(EditState::new(
                frame,
                contacts.clone(),
                region_pairs.clone(),
                kept,
                contained.clone(),
                store.closed.clone(),
            ));
        }

        // The separation pass on the outputs (issue 29).
        let unseparated = self.separate(frame, &region_pairs, &contacts, &mut outcomes, false, trace)?;
        let level = ObjectsLevel {
            region_pairs,
            contacts,
            outcomes,
            zones: summary,
            contained,
            closed: store.closed,
            unseparated,
            edit: false,
        };
        Ok((level, kept_state))
    }

    /// An edit of the kept frame (see `edits`): its jobs' contacts and its regions' fields
    /// reused, §5.4–5.5 and the separation pass run with this frame's parameters.
    fn edit(&mut self, frame: &Frame, state: &EditState, trace: &mut Trace) -> Result<ObjectsLevel, PipelineError> {
        setup::check_frame(frame)?;
        let regions: Vec<usize> = self.caches.iter().flatten().map(|c| c.regions.len()).collect();
        let zones = RegionZones::gather(frame, &regions, &state.region_pairs, &state.contacts);
        let mut outcomes = deformations::finish_kept_regions(&self.caches, frame, &zones, &state.regions)?;
        deformations::record(&outcomes, trace);
        let summary = zones.summary();
        let unseparated = self.separate(frame, &state.region_pairs, &state.contacts, &mut outcomes, true, trace)?;
        Ok(ObjectsLevel {
            region_pairs: state.region_pairs.clone(),
            contacts: state.contacts.clone(),
            outcomes,
            zones: summary,
            contained: state.contained.clone(),
            closed: state.closed.clone(),
            unseparated,
            edit: true,
        })
    }

    /// The separation pass (unless left out), timed as its own stage; its warnings. `edit`: the
    /// frame is an edit of the kept one, whose inputs are those of the last pass.
    fn separate(
        &mut self,
        frame: &Frame,
        region_pairs: &[RegionPair],
        contacts: &[Option<PairContact>],
        outcomes: &mut [Vec<Option<deformations::RegionOutcome>>],
        edit: bool,
        trace: &mut Trace,
    ) -> Result<Vec<FrameWarning>, PipelineError> {
        if self.skip_separation {
            return Ok(Vec::new());
        }
        // The last pass's seed, taken: a pass that fails leaves none.
        let last = self.separation_seed.take();
        let mut next = None;
        let seeds = Seeds { from: last.as_ref(), kept: (!self.without_seeds).then_some(&mut next), same_inputs: edit };
        let (_, warnings) = trace.run(Stage::Separation, || {
            separation::separate(frame, &mut self.caches, region_pairs, contacts, outcomes, seeds)
        })?;
        self.separation_seed = next;
        Ok(warnings)
    }
}

/// What the contacts between objects left for the results: the jobs with their contacts, every
/// region's deformation, and what the warnings read.
struct ObjectsLevel {
    region_pairs: Vec<RegionPair>,
    contacts: Vec<Option<PairContact>>,
    outcomes: Vec<Vec<Option<deformations::RegionOutcome>>>,
    zones: contacts::ZoneSummary,
    contained: Vec<Option<[usize; 2]>>,
    closed: Vec<bool>,
    unseparated: Vec<FrameWarning>,
    edit: bool,
}

impl<'a> Frame<'a> {
    /// The frame without its disabled pairs (see [`FramePair::params`]).
    fn without_disabled_pairs(&self) -> Frame<'a> {
        Frame {
            objects: self.objects.clone(),
            pairs: self.pairs.iter().filter(|p| p.params.enabled).copied().collect(),
        }
    }
}
