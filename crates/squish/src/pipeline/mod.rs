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
mod regions;
mod results;
mod self_contact;
mod separation;
mod setup;
mod stats;
mod untangle;
mod warnings;

use std::time::Instant;

use glam::DVec3;

pub use edits::{DOWNSTREAM_KEYS, is_downstream};
pub use error::PipelineError;
pub use part_contact::{MARGIN_RINGS, PartPairStats, Untangled};
pub use self_contact::SelfContactResult;
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
use crate::stage::{Stage, StageTimes, StageWork, Work};
use cache::ObjectCache;
use contacts::{RegionContacts, RegionInputs};
use edits::EditState;

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
#[derive(Default)]
pub struct Deformer {
    caches: Vec<Option<ObjectCache>>,
    /// Symbolic factorizations run since creation (one per deformed region unless its face set
    /// or connectivity changes): lets benchmarks check that frames reuse them.
    symbolic_analyses: usize,
    /// Per object: the caches of its articulations (ch. 6).
    self_contact: Vec<self_contact::SelfContactCache>,
    /// Whether to keep what edits reuse ([`Deformer::keep_for_edits`]).
    keep_edits: bool,
    /// What the last full frame left for edits.
    edits: Option<EditState>,
    /// Whether to leave out the separation pass ([`Deformer::without_separation`]).
    skip_separation: bool,
}

impl Deformer {
    /// A deformer with empty caches.
    pub fn new() -> Self {
        Self::default()
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
        self.skip_separation = true;
        self
    }

    /// Number of symbolic Cholesky analyses run by this deformer since it was created: one per
    /// deformed region on its first frame (and again only if its face set or connectivity
    /// changes).
    pub fn symbolic_analyses(&self) -> usize {
        self.symbolic_analyses
    }

    /// Deforms one frame. See the module doc.
    pub fn deform(&mut self, frame: &Frame) -> Result<FrameResult, PipelineError> {
        // The frame's own span of work: what its stages do not measure stays out of the spans of
        // another frame this thread may be computing (`Work`).
        Work::measure(|| self.deform_frame(frame)).0
    }

    fn deform_frame(&mut self, frame: &Frame) -> Result<FrameResult, PipelineError> {
        let start = Instant::now();
        if frame.pairs.iter().any(|p| !p.params.enabled) {
            let pairs = frame.pairs.iter().filter(|p| p.params.enabled).copied().collect();
            return self.deform(&Frame { objects: frame.objects.clone(), pairs });
        }
        if !frame.objects.iter().any(|o| self_contact::has_self_contact(o.params)) {
            self.self_contact.clear();
            return self.deform_pairs(frame, start, self.keep_edits);
        }
        // Self-contact reads the downstream parameters before the pairs: never an edit.
        self.edits = None;
        let (resolved, (articulations, part_pairs)) =
            self_contact::resolve_self_contacts(&mut self.self_contact, frame)?;
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
        let mut result = self.deform_pairs(&Frame { objects, pairs: frame.pairs.clone() }, start, false)?;
        self_contact::relative_to_input(&mut result.stats.objects, frame, &result.positions, &resolved);
        result.stats.articulations = articulations;
        result.stats.part_pairs = part_pairs;
        result.self_contact = resolved;
        result.stats.total = start.elapsed();
        Ok(result)
    }

    /// The contacts between objects of a frame, stage after stage: setup, working regions,
    /// contact definition (ch. 4), deformation (ch. 5), results; or, for an edit of the kept
    /// frame, §5.4–5.5 and the results. `start` is when the frame began; `keep`: keep what edits
    /// reuse.
    fn deform_pairs(&mut self, frame: &Frame, start: Instant, keep: bool) -> Result<FrameResult, PipelineError> {
        if keep && let Some(state) = self.edits.as_ref().filter(|state| state.is_edit(frame)) {
            setup::check_frame(frame)?;
            return self.edit(frame, state, start);
        }
        // A failed frame must not leave the state of an earlier one.
        self.edits = None;
        let mut stages = StageTimes::default();
        // Setup (ch. 3): the frame checked before any work, then every object's cache.
        let pairing = setup::check_frame(frame)?;
        let timer = Instant::now();
        let figures = setup::update_objects(&mut self.caches, frame, &pairing.needs_tree)?;
        stages[Stage::Setup] = timer.elapsed();

        // Working regions (§4.5).
        let timer = Instant::now();
        regions::update_working_regions(&mut self.caches, frame, &pairing.partners, &pairing.needs_tree, &figures)?;
        stages[Stage::Regions] = timer.elapsed();

        // Chapter 4 on every pair of overlapping regions; the zones are lent to chapter 5.
        let caches: Vec<&ObjectCache> = self.caches.iter().flatten().collect();
        let inputs = RegionInputs::new(&caches, frame);
        let sizes: Vec<Vec<f64>> = caches
            .iter()
            .zip(&figures)
            .map(|(c, f)| c.regions.iter().map(|r| f.size_of(&r.components)).collect())
            .collect();
        let region_pairs = contacts::region_pairs(frame, &caches);
        let mut contacts = contacts::contact_region_pairs(frame, &caches, &inputs, &region_pairs)?;
        let contained = warnings::contained_sides(frame, &caches, &region_pairs, &contacts);
        let closed: Vec<bool> = caches.iter().map(|c| c.closed).collect();
        let mut region_contacts = RegionContacts::gather(frame, &caches, &region_pairs, &mut contacts);
        drop(caches);

        // Chapter 5 on every region with zones.
        let mut outcomes = deformations::deform_regions(
            &mut self.caches,
            frame,
            &region_contacts,
            &figures,
            &sizes,
            &inputs.normals,
            keep,
        )?;
        self.symbolic_analyses += outcomes.iter().flatten().flatten().filter(|o| o.new_solver).count();
        region_contacts.give_back(&mut contacts);
        if keep {
            let kept =
                outcomes.iter_mut().map(|o| o.iter_mut().map(|o| o.as_mut().and_then(|o| o.kept.take())).collect());
            self.edits = Some(EditState::new(
                frame,
                contacts.clone(),
                region_pairs.clone(),
                kept.collect(),
                contained.clone(),
                closed.clone(),
            ));
        }

        // Work per stage: the contact stage's and chapter 5's (`Work`).
        let mut work = StageWork::default();
        contacts.iter().flatten().for_each(|c| work += &c.stats.work);
        outcomes.iter().flatten().flatten().for_each(|o| work += &o.deformation.stats.work);

        // The separation pass on the outputs (issue 29).
        let timer = Instant::now();
        let unseparated = if self.skip_separation {
            Vec::new()
        } else {
            let (_, warnings, separation_work) =
                separation::separate(frame, &self.caches, &region_pairs, &contacts, &mut outcomes)?;
            work[Stage::Separation] = separation_work;
            warnings
        };
        stages[Stage::Separation] += timer.elapsed();

        // Results: positions written back, figures per pair, object, region and stage.
        let pairs = results::pair_stats(frame, &region_pairs, &contacts, &mut stages);
        let objects = results::object_results(frame, &self.caches, &region_contacts, outcomes, &mut stages);
        let params: Vec<&PairParams> = region_pairs.iter().map(|rp| &frame.pairs[rp.pair].params).collect();
        let mut warnings = warnings::frame_warnings(&pairs, &contacts, &params, &contained, &objects.stats, &closed);
        warnings.extend(unseparated);
        Ok(FrameResult {
            positions: objects.positions,
            contacts,
            deformations: objects.deformations,
            regions: objects.summaries,
            self_contact: vec![None; frame.objects.len()],
            stats: FrameStats {
                total: start.elapsed(),
                stages,
                work,
                objects: objects.stats,
                pairs,
                regions: objects.regions,
                articulations: Vec::new(),
                part_pairs: Vec::new(),
                edit: false,
                warnings,
            },
        })
    }

    /// An edit of the kept frame (see `edits`): its contacts and region fields reused, §5.4–5.5
    /// and the results computed with this frame's parameters.
    fn edit(&self, frame: &Frame, state: &EditState, start: Instant) -> Result<FrameResult, PipelineError> {
        let mut contacts = state.contacts.clone();
        let caches: Vec<&ObjectCache> = self.caches.iter().flatten().collect();
        let mut region_contacts = RegionContacts::gather(frame, &caches, &state.region_pairs, &mut contacts);
        drop(caches);
        let mut outcomes = deformations::finish_kept_regions(&self.caches, frame, &region_contacts, &state.regions)?;
        region_contacts.give_back(&mut contacts);
        let mut work = StageWork::default();
        outcomes.iter().flatten().flatten().for_each(|o| work += &o.deformation.stats.work);
        let timer = Instant::now();
        let unseparated = if self.skip_separation {
            Vec::new()
        } else {
            let (_, warnings, separation_work) =
                separation::separate(frame, &self.caches, &state.region_pairs, &contacts, &mut outcomes)?;
            work[Stage::Separation] = separation_work;
            warnings
        };
        // The contact stage's times are the kept frame's: not this frame's work.
        let pairs = results::pair_stats(frame, &state.region_pairs, &contacts, &mut StageTimes::default());
        let mut stages = StageTimes::default();
        stages[Stage::Separation] += timer.elapsed();
        let objects = results::object_results(frame, &self.caches, &region_contacts, outcomes, &mut stages);
        let params: Vec<&PairParams> = state.region_pairs.iter().map(|rp| &frame.pairs[rp.pair].params).collect();
        let mut warnings =
            warnings::frame_warnings(&pairs, &contacts, &params, &state.contained, &objects.stats, &state.closed);
        warnings.extend(unseparated);
        Ok(FrameResult {
            positions: objects.positions,
            contacts,
            deformations: objects.deformations,
            regions: objects.summaries,
            self_contact: vec![None; frame.objects.len()],
            stats: FrameStats {
                total: start.elapsed(),
                stages,
                work,
                objects: objects.stats,
                pairs,
                regions: objects.regions,
                articulations: Vec::new(),
                part_pairs: Vec::new(),
                edit: true,
                warnings,
            },
        })
    }
}
