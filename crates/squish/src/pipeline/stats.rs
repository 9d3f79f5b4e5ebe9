//! The figures of a frame: per object, per region pair, per working region and per stage
//! ([`StageTimes`], keyed by [`crate::stage::Stage`]), with which part of its object each region
//! is. Every field is serialized; the fields added after the first release default when read.

use std::time::Duration;

use serde::{Deserialize, Serialize};

#[cfg(doc)]
use super::FramePair;
use crate::stage::{StageTimes, StageWork};

/// Figures of one object for one frame. For an object of several regions, the per-region
/// figures are in [`FrameStats::regions`]; here counts are summed over its regions and
/// `extent`, `bulge_height` and `applied_bulge_height` are those of its first deformed region.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectStats {
    pub name: String,
    pub vertices: usize,
    pub rigid: bool,
    /// True if the object was deformed (it had a non-empty contact zone).
    pub deformed: bool,
    /// Signed volume before and after. For an open mesh, `volume_after` is `volume_before` plus
    /// the signed volume swept by its displacement (`deform::swept_volume_change`), the volume
    /// an open mesh keeps (its own signed volume also changes by the strips its moving boundary
    /// sweeps, and depends on the origin).
    pub volume_before: f64,
    pub volume_after: f64,
    /// (after − before) / |before|.
    pub relative_volume_change: f64,
    /// Whether the volume was preserved (solved) for this object.
    pub preserve_volume: bool,
    /// φ_max used this frame.
    pub extent: f64,
    /// h_v and γ·h_v.
    pub bulge_height: f64,
    pub applied_bulge_height: f64,
    /// |𝒞| and |𝒟|.
    pub contact_vertices: usize,
    pub deformable_vertices: usize,
    /// Largest vertex displacement from the input.
    pub max_displacement: f64,
    /// Numeric fallbacks taken by the deformation stage (see `deform::FallbackCounters`).
    pub fallbacks: usize,
    /// Number of working regions this frame.
    #[serde(default)]
    pub regions: usize,
    /// Number of non-empty contact zones over its regions.
    #[serde(default)]
    pub zones: usize,
    /// True if the extent of one of its regions was clamped to fit the region.
    #[serde(default)]
    pub extent_clamped: bool,
    /// True if the parametrization domain of one of its regions reached the region's cut (see
    /// [`RegionStats::domain_reaches_cut`]): the result may then differ slightly from the whole
    /// object's.
    #[serde(default)]
    pub domain_reaches_cut: bool,
    /// For a skinned object with self-contact parts: its faces that intersect another of its
    /// faces beyond the rest pose's own intersections, in the input and after the self-contact
    /// stage ([`crate::skinning::RestIntersections`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub self_intersecting_faces: Option<[usize; 2]>,
    /// For a skinned object with self-contact parts: what the untangling after its contacts did
    /// ([`crate::pipeline::Untangled`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub untangled: Option<super::Untangled>,
}

/// Figures of one region pair for one frame (one entry per pair of overlapping regions of a
/// [`FramePair`], or one entry with `regions: None` when none overlap).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PairStats {
    pub objects: [String; 2],
    /// True if the meshes intersect (non-empty contact zones).
    pub in_contact: bool,
    /// Mapping direction d̂ and whether it was automatic (Eq. 4.1) or given.
    pub direction: [f64; 3],
    pub direction_automatic: bool,
    /// ε_c, m_𝒮, σ_𝒮 (Eq. 4.3).
    pub threshold: f64,
    pub mean_depth: f64,
    pub depth_std_dev: f64,
    /// Area of the contact zone on the potential contact surface 𝒮.
    pub contact_area: f64,
    pub intersection_points: usize,
    pub zone_vertices: [usize; 2],
    /// Numeric fallbacks taken by the contact stage.
    pub fallbacks: usize,
    /// Index of the [`FramePair`] this region pair comes from.
    #[serde(default)]
    pub pair: usize,
    /// The two regions (indices among each object's regions, see [`FrameStats::regions`]);
    /// `None` when no region of one object overlaps a region of the other.
    #[serde(default)]
    pub regions: Option<[usize; 2]>,
}

/// Figures of one working region for one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionStats {
    /// Index and name of its object.
    pub object: usize,
    pub name: String,
    /// Index among the object's regions.
    pub region: usize,
    /// True if the region is the whole object.
    pub whole: bool,
    pub vertices: usize,
    pub faces: usize,
    /// Vertices on the border where it was cut out of its object.
    pub cut_border_vertices: usize,
    /// True if its caches were built at this frame (new or changed face set).
    pub rebuilt: bool,
    /// The regions it is in contact with, as `[object, region]`.
    pub touching: Vec<[usize; 2]>,
    /// Non-empty contact zones (one per region pair in contact, when the object is not rigid).
    pub zones: usize,
    pub deformed: bool,
    /// φ_max used (after clamping).
    pub extent: f64,
    /// True if φ_max was clamped so that 𝒟 stays inside the region.
    pub extent_clamped: bool,
    /// True if the parametrization domain 𝒫 (within `domain_factor·φ_max` of ∂𝒞 along edges)
    /// reached the region's cut, so the cut limited it: the result then differs slightly from
    /// the whole object's. False otherwise, and the result is the whole object's up to round-off.
    pub domain_reaches_cut: bool,
    /// Vertices within the parametrization domain's radius.
    pub domain_vertices: usize,
    pub bulge_height: f64,
    pub applied_bulge_height: f64,
    pub contact_vertices: usize,
    pub deformable_vertices: usize,
    /// True if its factorizations eliminate in the nested-dissection order, kept because it
    /// needs fewer flops than AMD's for this region (see [`crate::linalg::FillOrder`]); false for
    /// AMD's order, always the one of automatic regions. Changes the time, not the result beyond
    /// round-off.
    #[serde(default)]
    pub nested_dissection: bool,
    /// Wall-clock time of its deformation (ch. 5).
    pub time: Duration,
}

/// Timings and quality figures of one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameStats {
    /// Wall-clock time of the whole frame.
    pub total: Duration,
    /// Per-stage times (summed over pairs and regions).
    pub stages: StageTimes,
    /// Per-stage counts of work (summed like the times; see [`crate::stage::Work`]).
    #[serde(default)]
    pub work: StageWork,
    pub objects: Vec<ObjectStats>,
    /// One entry per region pair (see [`PairStats`]); for objects of one region each, one entry
    /// per [`FramePair`] in order.
    pub pairs: Vec<PairStats>,
    /// Every working region, object by object.
    #[serde(default)]
    pub regions: Vec<RegionStats>,
    /// Every articulation with self-contact (ch. 6), object by object.
    #[serde(default)]
    pub articulations: Vec<crate::skinning::ArticulationStats>,
    /// Every touching pair of parts of a skinned object (issue 27), object by object.
    #[serde(default)]
    pub part_pairs: Vec<super::PartPairStats>,
    /// True if the frame was an edit of the previous one (only parameters of §5.4–5.5 changed,
    /// see [`super::DOWNSTREAM_KEYS`]): it reused that frame's contact stage and fields of
    /// §5.1–5.3, so its times and work counters are the edit's; every other figure is a full
    /// computation's.
    #[serde(default)]
    pub edit: bool,
    /// What the frame did not do that it was asked to (see [`super::FrameWarning`]).
    #[serde(default)]
    pub warnings: Vec<super::FrameWarning>,
    /// Per pair of objects: penetrations and intersecting faces before and after (the quality
    /// pass, see [`super::PairQuality`]); empty when the deformer leaves it out
    /// ([`super::Deformer::without_quality`]).
    #[serde(default)]
    pub quality: Vec<super::PairQuality>,
    /// The frame plan's jobs, level by level, with the stages each ran (see
    /// [`super::JobRecord`]).
    #[serde(default)]
    pub jobs: Vec<super::JobRecord>,
}

/// Which part of its object a working region is (same order as [`FrameStats::regions`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionSummary {
    pub object: usize,
    pub region: usize,
    /// True when the region is the whole object (the lists below are then empty).
    pub whole: bool,
    /// Its faces (object face ids, increasing).
    pub faces: Vec<u32>,
    /// Its vertices (object vertex ids, increasing): region vertex `i` is object vertex
    /// `vertices[i]` — the numbering of the region pairs' [`PairContact`](crate::contact::PairContact)s.
    pub vertices: Vec<u32>,
    /// Its vertices on the cut border (object vertex ids).
    pub cut_border: Vec<u32>,
}
