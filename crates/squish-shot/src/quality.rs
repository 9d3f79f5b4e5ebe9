//! Quality figures of a shot — what a TD checks before sending a shot to render — and the
//! report that carries them (`report.json`, `quality.svg`, `quality.png`).
//!
//! Per frame and object: the relative volume change, the contact area, the largest displacement
//! from the input, and the largest vertex displacement from the previous frame's *output* with,
//! for reference, the same for the *input* (both include the input's own motion, so their ratio
//! is what tells a jump: ≈ 1 when the result follows the input smoothly). Per frame and pair:
//! the deepest penetration of either mesh into the other before and after deformation (closed
//! meshes only). Per frame and articulation with self-contact (thesis ch. 6): whether its sides
//! touch, the self-intersecting faces of its regions before and after, the contact area, the
//! bulge height and the time. Per shot: the worst of each, the total and per-frame times, frames
//! per second, and per articulation the self-intersecting faces summed over the frames.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

use serde::Serialize;
use squish::stage::Stage;
use squish_render::{Plot, Series, encode_png, grid, plot_image, svg_line_plot};

use crate::error::ShotError;
use crate::files::{write_bytes, write_text};
use crate::frame_quality::{ObjectQuality, PairQuality};
use crate::report::FrameReport;
use crate::shot::{FrameRecord, ShotOutcome};

/// Figures of one articulation (`[[objects.self_contact]]`) at one frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ArticulationQuality {
    pub name: String,
    /// The object's name.
    pub object: String,
    /// True if the two sides were in contact at this frame.
    pub in_contact: bool,
    /// Self-intersecting faces among the faces of the two regions (exact triangle–triangle
    /// tests), in the input and in the result.
    pub self_intersecting_faces_before: usize,
    pub self_intersecting_faces_after: usize,
    /// Of those, the faces of pairs joining the articulation's two sides (the rest lie within
    /// one side: another fold of the body).
    pub self_intersecting_faces_across_before: usize,
    pub self_intersecting_faces_across_after: usize,
    pub contact_area: f64,
    /// h_v solved for volume preservation, γ·h_v applied, and whether h_v solves the volume
    /// equation exactly.
    pub bulge_height: f64,
    pub applied_bulge_height: f64,
    pub volume_exact: bool,
    /// φ_max used, and whether it was clamped to keep the deformation inside the regions.
    pub extent: f64,
    pub extent_clamped: bool,
    /// |𝒲₁|, |𝒲₂| and |ℛ| (vertices).
    pub region_vertices: [usize; 2],
    pub shared_vertices: usize,
    /// d̂ at this frame.
    pub direction: [f64; 3],
    /// Wall-clock times: crease cut, contact, deformation, whole articulation.
    pub cut_ms: f64,
    pub contact_ms: f64,
    pub deformation_ms: f64,
    pub time_ms: f64,
}

/// The articulations' figures of a computed frame.
pub fn articulation_figures(record: &FrameRecord) -> Vec<ArticulationQuality> {
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    record
        .stats
        .articulations
        .iter()
        .map(|a| ArticulationQuality {
            name: a.name.clone(),
            object: record.objects.get(a.object).map_or_else(|| format!("#{}", a.object), |o| o.name.clone()),
            in_contact: a.in_contact,
            self_intersecting_faces_before: a.self_intersecting_faces_before,
            self_intersecting_faces_after: a.self_intersecting_faces_after,
            self_intersecting_faces_across_before: a.self_intersecting_faces_across_before,
            self_intersecting_faces_across_after: a.self_intersecting_faces_across_after,
            contact_area: a.contact_area,
            bulge_height: a.bulge_height,
            applied_bulge_height: a.applied_bulge_height,
            volume_exact: a.volume_exact,
            extent: a.extent,
            extent_clamped: a.extent_clamped,
            region_vertices: a.region_vertices,
            shared_vertices: a.shared_vertices,
            direction: a.direction,
            cut_ms: ms(a.cut_time),
            contact_ms: ms(a.contact_time),
            deformation_ms: ms(a.deformation_time),
            time_ms: ms(a.total_time),
        })
        .collect()
}

/// Figures of one touching part pair of a skinned object (`self_contact = "auto"`) at one frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PartPairQuality {
    /// The object's name and the two parts' names.
    pub object: String,
    pub parts: [String; 2],
    /// What touches: `parts`, `after articulation` (a parent and child), `within part` (a fold).
    pub kind: String,
    /// Faces of the two parts intersecting the other part (beyond the rest pose's), before and
    /// after this pair's resolution.
    pub faces_before: usize,
    pub faces_after: usize,
    pub in_contact: bool,
    pub contact_area: f64,
    /// Why the pair was left unresolved, if it was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The batch of pairs it ran in (in parallel with the others of its batch, from 0), and how
    /// many times it ran (more than once when it had to wait for an earlier pair's result).
    pub batch: usize,
    pub runs: usize,
    pub time_ms: f64,
}

/// The part pairs' figures of a computed frame.
pub fn part_pair_figures(record: &FrameRecord) -> Vec<PartPairQuality> {
    let object = |k: usize| record.objects.get(k).map_or_else(|| format!("#{k}"), |o| o.name.clone());
    record
        .stats
        .part_pairs
        .iter()
        .map(|p| PartPairQuality {
            object: object(p.object),
            parts: p.parts.clone(),
            kind: p.kind.clone(),
            faces_before: p.faces_before,
            faces_after: p.faces_after,
            in_contact: p.in_contact,
            contact_area: p.contact_area,
            error: p.error.clone(),
            batch: p.batch,
            runs: p.runs,
            time_ms: p.time.as_secs_f64() * 1e3,
        })
        .collect()
}

/// An object with self-contact parts over a shot: its faces intersecting beyond the rest pose's,
/// in the input and after the self-contact stage.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SelfContactSummary {
    pub object: String,
    pub frames: usize,
    /// Summed over the frames.
    pub faces_input: usize,
    pub faces_output: usize,
    /// Frames where the output has more than the input.
    pub frames_worse: usize,
    /// The frame with the most left, if any are left.
    pub worst_output: Option<Extreme>,
    /// Part pairs resolved (summed over the frames), the largest number in one frame, and the
    /// pairs left unresolved.
    pub part_pairs: usize,
    pub max_part_pairs: usize,
    pub part_pairs_failed: usize,
}

impl SelfContactSummary {
    /// One entry per object with figures, in order of first appearance.
    pub fn of(records: &[FrameRecord]) -> Vec<Self> {
        let mut out: Vec<Self> = Vec::new();
        for r in records {
            for o in &r.stats.objects {
                let Some([input, output]) = o.self_intersecting_faces else { continue };
                let s = entry(
                    &mut out,
                    |s| s.object == o.name,
                    || Self {
                        object: o.name.clone(),
                        frames: 0,
                        faces_input: 0,
                        faces_output: 0,
                        frames_worse: 0,
                        worst_output: None,
                        part_pairs: 0,
                        max_part_pairs: 0,
                        part_pairs_failed: 0,
                    },
                );
                s.frames += 1;
                s.faces_input += input;
                s.faces_output += output;
                s.frames_worse += usize::from(output > input);
                if output > 0 {
                    keep_max(&mut s.worst_output, output as f64, r.frame, || o.name.clone());
                }
            }
            let figures = part_pair_figures(r);
            for s in &mut out {
                let mine: Vec<&PartPairQuality> = figures.iter().filter(|p| p.object == s.object).collect();
                s.part_pairs += mine.len();
                s.max_part_pairs = s.max_part_pairs.max(mine.len());
                s.part_pairs_failed += mine.iter().filter(|p| p.error.is_some()).count();
            }
        }
        out
    }

    /// One line for people.
    pub fn line(&self) -> String {
        let reduction =
            if self.faces_input > 0 { 100.0 * (1.0 - self.faces_output as f64 / self.faces_input as f64) } else { 0.0 };
        let worse = match self.frames_worse {
            0 => "no frame worse than its input".to_string(),
            1 => "1 frame worse than its input".to_string(),
            n => format!("{n} frames worse than their input"),
        };
        let mut line = format!(
            "{}: self-contact removed {reduction:.1}% of the faces crossing beyond the rest pose ({} → {} over {} frames; {worse}), from {} contacts between parts (at most {} in a frame)",
            self.object, self.faces_input, self.faces_output, self.frames, self.part_pairs, self.max_part_pairs,
        );
        if self.part_pairs_failed > 0 {
            let _ =
                write!(line, ", {} of them without effect (report.json: part_pairs[].error)", self.part_pairs_failed);
        }
        match &self.worst_output {
            Some(w) => {
                let _ = write!(line, "; left: at most {} faces, at frame {}", w.value, w.frame);
            }
            None => line.push_str("; none left"),
        }
        line
    }
}

/// The element of `list` that `matches`, appended from `make` if there is none (keeps the order of
/// first appearance).
fn entry<T>(list: &mut Vec<T>, matches: impl Fn(&T) -> bool, make: impl FnOnce() -> T) -> &mut T {
    let i = match list.iter().position(matches) {
        Some(i) => i,
        None => {
            list.push(make());
            list.len() - 1
        }
    };
    &mut list[i]
}

/// One articulation over a shot.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ArticulationSummary {
    pub object: String,
    pub name: String,
    pub frames: usize,
    pub frames_in_contact: usize,
    /// Self-intersecting faces of the regions, summed over the frames, before and after; and
    /// those of pairs joining the two sides.
    pub self_intersecting_faces_before: usize,
    pub self_intersecting_faces_after: usize,
    pub self_intersecting_faces_across_before: usize,
    pub self_intersecting_faces_across_after: usize,
    /// The frame with the most self-intersecting faces left, if any are left.
    pub worst_after: Option<Extreme>,
    /// Frames whose bulge height does not solve the volume equation exactly.
    pub frames_volume_inexact: usize,
    pub total_time_ms: f64,
    pub mean_time_ms: f64,
    pub max_time_ms: f64,
}

impl ArticulationSummary {
    /// Sums the articulations of every record, in order of first appearance.
    pub fn of(records: &[FrameRecord]) -> Vec<Self> {
        let mut out: Vec<Self> = Vec::new();
        for r in records {
            for a in articulation_figures(r) {
                let s = entry(
                    &mut out,
                    |s| s.object == a.object && s.name == a.name,
                    || Self {
                        object: a.object.clone(),
                        name: a.name.clone(),
                        frames: 0,
                        frames_in_contact: 0,
                        self_intersecting_faces_before: 0,
                        self_intersecting_faces_after: 0,
                        self_intersecting_faces_across_before: 0,
                        self_intersecting_faces_across_after: 0,
                        worst_after: None,
                        frames_volume_inexact: 0,
                        total_time_ms: 0.0,
                        mean_time_ms: 0.0,
                        max_time_ms: 0.0,
                    },
                );
                s.frames += 1;
                s.frames_in_contact += usize::from(a.in_contact);
                s.self_intersecting_faces_before += a.self_intersecting_faces_before;
                s.self_intersecting_faces_after += a.self_intersecting_faces_after;
                s.self_intersecting_faces_across_before += a.self_intersecting_faces_across_before;
                s.self_intersecting_faces_across_after += a.self_intersecting_faces_across_after;
                if a.self_intersecting_faces_after > 0 {
                    keep_max(&mut s.worst_after, a.self_intersecting_faces_after as f64, r.frame, || {
                        format!("{}/{}", a.object, a.name)
                    });
                }
                s.frames_volume_inexact += usize::from(a.in_contact && !a.volume_exact);
                s.total_time_ms += a.time_ms;
                s.max_time_ms = s.max_time_ms.max(a.time_ms);
            }
        }
        for s in &mut out {
            if s.frames > 0 {
                s.mean_time_ms = s.total_time_ms / s.frames as f64;
            }
        }
        out
    }

    /// One line for people.
    pub fn line(&self) -> String {
        let mut line = format!(
            "{}/{}: self-intersecting faces {} → {} ({} → {} across the joint) over {} frame{} (in contact on {}), \
             {:.1} ms per frame (max {:.1})",
            self.object,
            self.name,
            self.self_intersecting_faces_before,
            self.self_intersecting_faces_after,
            self.self_intersecting_faces_across_before,
            self.self_intersecting_faces_across_after,
            self.frames,
            if self.frames == 1 { "" } else { "s" },
            self.frames_in_contact,
            self.mean_time_ms,
            self.max_time_ms
        );
        if let Some(w) = &self.worst_after {
            let _ = write!(line, "; most left: {} at frame {}", w.value, w.frame);
        }
        if self.frames_volume_inexact > 0 {
            let _ = write!(line, "; volume not exact on {} frame(s)", self.frames_volume_inexact);
        }
        line
    }
}

/// A worst value and where it happened.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Extreme {
    pub value: f64,
    pub frame: i64,
    /// The object or pair ("a/b").
    pub at: String,
}

fn keep_max(slot: &mut Option<Extreme>, value: f64, frame: i64, at: impl FnOnce() -> String) {
    if value.is_finite() && slot.as_ref().is_none_or(|e| value > e.value) {
        *slot = Some(Extreme { value, frame, at: at() });
    }
}

/// Whole-shot figures.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShotSummary {
    pub frames_requested: usize,
    pub frames_computed: usize,
    /// Largest |relative volume change| of a deformed object.
    pub max_volume_change: Option<Extreme>,
    /// Largest residual penetration (world units) and largest ratio residual / input.
    pub max_residual_penetration: Option<Extreme>,
    pub max_penetration_ratio: Option<Extreme>,
    /// Most faces of one object intersecting the other after deformation (a pair's larger count;
    /// `pair.contact_gap` keeps it at 0), and the same for the inputs.
    pub max_intersecting_faces_after: Option<Extreme>,
    pub max_intersecting_faces_before: Option<Extreme>,
    /// Largest frame-to-frame output step, and largest ratio of a frame's largest output step to
    /// its largest input step (all objects), i.e. how much more the result moved than the input.
    pub max_output_step: Option<Extreme>,
    pub max_step_ratio: Option<Extreme>,
    /// Sum of the frames' own times, and the batch's wall-clock time.
    pub total_frame_time_s: f64,
    pub wall_time_s: f64,
    pub mean_frame_ms: f64,
    pub max_frame_ms: f64,
    /// Frames computed per second of wall-clock time.
    pub frames_per_second: f64,
    pub threads: usize,
    /// Per articulation with self-contact: totals over the shot.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub articulations: Vec<ArticulationSummary>,
    /// Per skinned object with self-contact parts: totals over the shot.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub self_contact: Vec<SelfContactSummary>,
    /// Objects whose working regions were too tight on some frames.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub tight_regions: Vec<TightRegionSummary>,
}

/// An object whose working region limited the deformation on some frames: its extent was
/// clamped so that 𝒟 stays inside, or its parametrization domain reached the region's cut (the
/// result then differs slightly from the whole object's).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TightRegionSummary {
    pub object: String,
    /// Frames with a clamped extent, and with the parametrization domain cut by the region.
    pub extent_clamped_frames: usize,
    pub domain_cut_frames: usize,
    /// The first such frame.
    pub first_frame: i64,
}

impl TightRegionSummary {
    /// The objects with a tight region over the records, in object order.
    pub fn of(records: &[FrameRecord]) -> Vec<Self> {
        let mut out: Vec<Self> = Vec::new();
        for r in records {
            for o in &r.stats.objects {
                if !(o.extent_clamped || o.domain_reaches_cut) {
                    continue;
                }
                let entry = entry(
                    &mut out,
                    |e| e.object == o.name,
                    || Self {
                        object: o.name.clone(),
                        extent_clamped_frames: 0,
                        domain_cut_frames: 0,
                        first_frame: r.frame,
                    },
                );
                entry.extent_clamped_frames += usize::from(o.extent_clamped);
                entry.domain_cut_frames += usize::from(o.domain_reaches_cut);
                entry.first_frame = entry.first_frame.min(r.frame);
            }
        }
        out
    }

    /// One line for people.
    pub fn line(&self) -> String {
        format!(
            "{}: working region too tight (extent clamped on {} frame{}, parametrization domain cut on {}; \
             first at frame {}): the result differs from the whole object's; widen `region` or lower `extent`",
            self.object,
            self.extent_clamped_frames,
            if self.extent_clamped_frames == 1 { "" } else { "s" },
            self.domain_cut_frames,
            self.first_frame
        )
    }
}

/// The largest output and input steps of a frame over its objects, and their ratio.
pub fn frame_steps(record: &FrameRecord) -> (Option<f64>, Option<f64>, Option<f64>) {
    let outputs: Vec<f64> = record.objects.iter().filter_map(|o| o.output_step).collect();
    let inputs: Vec<f64> = record.objects.iter().filter_map(|o| o.input_step).collect();
    if outputs.is_empty() || inputs.is_empty() {
        return (None, None, None);
    }
    let out = outputs.iter().copied().fold(0.0, f64::max);
    let inp = inputs.iter().copied().fold(0.0, f64::max);
    (Some(out), Some(inp), (inp > 0.0).then(|| out / inp))
}

impl ShotSummary {
    /// The articulations the console lists, one line each: those of objects with explicit
    /// articulations. An object with `self_contact = "auto"` has one line for all its
    /// self-contacts ([`SelfContactSummary::line`]); its joints' figures stay in report.json.
    pub fn articulations_to_show(&self) -> impl Iterator<Item = &ArticulationSummary> {
        self.articulations.iter().filter(|a| !self.self_contact.iter().any(|s| s.object == a.object))
    }

    /// The summary of an outcome.
    pub fn of(outcome: &ShotOutcome) -> Self {
        let mut s = Self {
            frames_requested: outcome.frames.clone().count(),
            frames_computed: outcome.records.len(),
            max_volume_change: None,
            max_residual_penetration: None,
            max_penetration_ratio: None,
            max_intersecting_faces_after: None,
            max_intersecting_faces_before: None,
            max_output_step: None,
            max_step_ratio: None,
            total_frame_time_s: 0.0,
            wall_time_s: outcome.wall.as_secs_f64(),
            mean_frame_ms: 0.0,
            max_frame_ms: 0.0,
            frames_per_second: 0.0,
            threads: outcome.threads,
            articulations: ArticulationSummary::of(&outcome.records),
            self_contact: SelfContactSummary::of(&outcome.records),
            tight_regions: TightRegionSummary::of(&outcome.records),
        };
        for r in &outcome.records {
            let ms = r.stats.total.as_secs_f64() * 1e3;
            s.total_frame_time_s += ms * 1e-3;
            s.max_frame_ms = s.max_frame_ms.max(ms);
            for o in r.objects.iter().filter(|o| o.deformed) {
                keep_max(&mut s.max_volume_change, o.relative_volume_change.abs(), r.frame, || o.name.clone());
            }
            for o in &r.objects {
                if let Some(step) = o.output_step {
                    keep_max(&mut s.max_output_step, step, r.frame, || o.name.clone());
                }
            }
            for p in &r.pairs {
                let at = || format!("{}/{}", p.objects[0], p.objects[1]);
                if let Some(after) = p.penetration_after {
                    keep_max(&mut s.max_residual_penetration, after, r.frame, at);
                }
                if let Some(ratio) = p.penetration_ratio {
                    keep_max(&mut s.max_penetration_ratio, ratio, r.frame, at);
                }
                let faces = |f: [usize; 2]| f[0].max(f[1]) as f64;
                keep_max(&mut s.max_intersecting_faces_before, faces(p.intersecting_faces_before), r.frame, at);
                keep_max(&mut s.max_intersecting_faces_after, faces(p.intersecting_faces_after), r.frame, at);
            }
            if let (_, _, Some(ratio)) = frame_steps(r) {
                let at = r
                    .objects
                    .iter()
                    .filter(|o| o.output_step.is_some())
                    .max_by(|a, b| a.output_step.partial_cmp(&b.output_step).unwrap_or(std::cmp::Ordering::Equal))
                    .map_or_else(String::new, |o| o.name.clone());
                keep_max(&mut s.max_step_ratio, ratio, r.frame, || at);
            }
        }
        if s.frames_computed > 0 {
            s.mean_frame_ms = 1e3 * s.total_frame_time_s / s.frames_computed as f64;
        }
        if s.wall_time_s > 0.0 {
            s.frames_per_second = s.frames_computed as f64 / s.wall_time_s;
        }
        s
    }

    /// One line for people: volume, penetration, steps, time.
    pub fn one_line(&self) -> String {
        let mut line = format!(
            "{} frame{} in {:.1} s ({:.2} frames/s, {} thread{})",
            self.frames_computed,
            if self.frames_computed == 1 { "" } else { "s" },
            self.wall_time_s,
            self.frames_per_second,
            self.threads,
            if self.threads == 1 { "" } else { "s" }
        );
        let _ = write!(line, "; {}", self.figures());
        line
    }

    /// The quality figures in words.
    pub fn figures(&self) -> String {
        let volume = self.max_volume_change.as_ref().map_or(0.0, |e| e.value);
        let mut text = format!("max |ΔV/V| {volume:.1e}");
        match &self.max_penetration_ratio {
            Some(p) => {
                let _ = write!(text, ", residual penetration ≤ {} of the input's", percent(p.value));
            }
            None => text.push_str(", no penetration measured"),
        }
        if let Some(faces) = &self.max_intersecting_faces_after {
            let _ = write!(text, ", ≤ {} intersecting faces after", faces.value);
        }
        if let Some(step) = &self.max_step_ratio {
            let _ = write!(text, ", largest step {:.2}× the input's (frame {})", step.value, step.frame);
        }
        text
    }
}

/// A ratio as a percentage with enough digits to tell small values from zero.
pub fn percent(ratio: f64) -> String {
    let p = 100.0 * ratio;
    if p == 0.0 || p >= 1.0 {
        format!("{p:.1}%")
    } else if p >= 0.01 {
        format!("{p:.2}%")
    } else {
        format!("{p:.0e}%")
    }
}

/// One frame of `report.json`.
#[derive(Serialize)]
pub struct FrameEntry<'a> {
    frame: i64,
    time_ms: f64,
    /// Largest output step over the objects, largest input step, and their ratio.
    max_output_step: Option<f64>,
    max_input_step: Option<f64>,
    step_ratio: Option<f64>,
    objects: &'a [ObjectQuality],
    pairs: &'a [PairQuality],
    #[serde(skip_serializing_if = "Vec::is_empty")]
    articulations: Vec<ArticulationQuality>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    part_pairs: Vec<PartPairQuality>,
    /// Per object with self-contact parts: faces intersecting beyond the rest pose's, in the
    /// input and after the self-contact stage.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    self_intersecting_faces: Vec<(String, [usize; 2])>,
    stats: FrameReport,
}

impl<'a> FrameEntry<'a> {
    /// The entry of a computed frame.
    pub fn of(record: &'a FrameRecord) -> Self {
        let (max_output_step, max_input_step, step_ratio) = frame_steps(record);
        FrameEntry {
            frame: record.frame,
            time_ms: record.stats.total.as_secs_f64() * 1e3,
            max_output_step,
            max_input_step,
            step_ratio,
            objects: &record.objects,
            pairs: &record.pairs,
            articulations: articulation_figures(record),
            part_pairs: part_pair_figures(record),
            self_intersecting_faces: record
                .stats
                .objects
                .iter()
                .filter_map(|o| o.self_intersecting_faces.map(|f| (o.name.clone(), f)))
                .collect(),
            stats: FrameReport::from(&record.stats),
        }
    }
}

/// How a run ended.
#[derive(Serialize)]
pub struct RunStatus {
    /// "complete", "interrupted" or "failed" (a frame failed; the others were computed).
    pub status: &'static str,
    /// Frames asked for but not computed (failed, or not reached), as "A:B" runs for `--frames`.
    pub missing_frames: Vec<String>,
    /// The first failed frame and its error (also in `failed_frames`).
    pub failed_frame: Option<i64>,
    pub error: Option<String>,
    /// Every failed frame with its error, in frame order.
    pub failed_frames: Vec<FailedFrame>,
}

/// A frame that failed and its one-line error.
#[derive(Serialize)]
pub struct FailedFrame {
    pub frame: i64,
    pub error: String,
}

impl RunStatus {
    pub fn of(outcome: &ShotOutcome) -> Self {
        let status = if outcome.failed() {
            "failed"
        } else if outcome.interrupted && !outcome.complete() {
            "interrupted"
        } else {
            "complete"
        };
        let first = outcome.failures.first();
        Self {
            status,
            missing_frames: outcome.missing_runs().iter().map(|r| format!("{}:{}", r.start(), r.end())).collect(),
            failed_frame: first.map(|f| f.frame),
            error: first.map(|f| f.error.to_string()),
            failed_frames: outcome
                .failures
                .iter()
                .map(|f| FailedFrame { frame: f.frame, error: f.error.to_string() })
                .collect(),
        }
    }
}

/// `report.json`: what was run and how it went.
#[derive(Serialize)]
struct Report<'a, S: Serialize> {
    squish_version: &'static str,
    /// The scene as resolved (defaults filled in, paths absolute).
    scene: &'a S,
    frames: FramesInfo,
    run: RunStatus,
    outputs: &'a serde_json::Value,
    summary: ShotSummary,
    per_frame: Vec<FrameEntry<'a>>,
}

#[derive(Serialize)]
struct FramesInfo {
    start: i64,
    end: i64,
    computed: usize,
}

/// Writes `dir/<report_name>` (the JSON report), `dir/quality.svg` and `dir/quality.png`;
/// returns the summary.
pub fn write_report<S: Serialize>(
    dir: &Path,
    report_name: &str,
    scene: &S,
    outputs: &serde_json::Value,
    outcome: &ShotOutcome,
) -> Result<ShotSummary, ShotError> {
    let summary = ShotSummary::of(outcome);
    let per_frame = outcome.records.iter().map(FrameEntry::of).collect();
    let report = Report {
        squish_version: env!("CARGO_PKG_VERSION"),
        scene,
        frames: FramesInfo {
            start: *outcome.frames.start(),
            end: *outcome.frames.end(),
            computed: outcome.records.len(),
        },
        run: RunStatus::of(outcome),
        outputs,
        summary: summary.clone(),
        per_frame,
    };
    write_text(&dir.join(report_name), &serde_json::to_string_pretty(&report)?)?;
    if !outcome.records.is_empty() {
        let plots = quality_plots(&outcome.records);
        write_text(&dir.join("quality.svg"), &stacked_svg(&plots, 2))?;
        let images: Vec<_> = plots.iter().map(plot_image).collect();
        let refs: Vec<_> = images.iter().collect();
        let png = encode_png(&grid(&refs, 2, 0, [255, 255, 255, 255]))
            .map_err(|e| ShotError::Internal(format!("quality plot: {e}")))?;
        write_bytes(&dir.join("quality.png"), &png)?;
    }
    Ok(summary)
}

/// The per-frame curves: volume change, penetration ratio, step ratio, contact area, time.
pub fn quality_plots(records: &[FrameRecord]) -> Vec<Plot> {
    let names: Vec<String> =
        records.first().map(|r| r.objects.iter().map(|o| o.name.clone()).collect()).unwrap_or_default();
    let pair_names: Vec<String> = records
        .first()
        .map(|r| r.pairs.iter().map(|p| format!("{}/{}", p.objects[0], p.objects[1])).collect())
        .unwrap_or_default();
    let per_object = |value: &dyn Fn(&ObjectQuality) -> Option<f64>| -> Vec<Series> {
        names
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let points = records
                    .iter()
                    .map(|r| (r.frame as f64, r.objects.get(i).and_then(value).unwrap_or(f64::NAN)))
                    .collect();
                Series::new(name.clone(), points)
            })
            .collect()
    };
    // Pairs are matched by name: disabled pairs are missing from some frames.
    let per_pair = |value: &dyn Fn(&PairQuality) -> Option<f64>| -> Vec<Series> {
        pair_names
            .iter()
            .map(|name| {
                let points = records
                    .iter()
                    .map(|r| {
                        let v = r
                            .pairs
                            .iter()
                            .find(|p| format!("{}/{}", p.objects[0], p.objects[1]) == *name)
                            .and_then(value);
                        (r.frame as f64, v.unwrap_or(f64::NAN))
                    })
                    .collect();
                Series::new(name.clone(), points)
            })
            .collect()
    };
    let plot = |title: &str, y: &str, series: Vec<Series>| {
        let mut p = Plot::new(title).with_labels("frame", y).with_size(640, 340);
        p.series = series;
        p
    };
    let times = records.iter().map(|r| (r.frame as f64, r.stats.total.as_secs_f64() * 1e3)).collect();
    // The frame, then each stage that is a span of its own and took time in some frame.
    let stage_series =
        Stage::spans().filter(|&s| records.iter().any(|r| r.stats.stages[s] > Duration::ZERO)).map(|s| {
            let points = records.iter().map(|r| (r.frame as f64, r.stats.stages[s].as_secs_f64() * 1e3)).collect();
            Series::new(s.name(), points)
        });
    vec![
        plot(
            "relative volume change",
            "(V after - V before) / V",
            per_object(&|o| o.deformed.then_some(o.relative_volume_change)),
        ),
        plot("residual penetration / input penetration", "ratio", per_pair(&|p| p.penetration_ratio)),
        plot("frame-to-frame step: output / input", "ratio", per_object(&|o| o.step_ratio)),
        plot("contact area", "area", per_pair(&|p| Some(p.contact_area))),
        plot("time per frame", "ms", std::iter::once(Series::new("frame", times)).chain(stage_series).collect()),
    ]
}

/// Several SVG plots in one document, `columns` per row.
fn stacked_svg(plots: &[Plot], columns: usize) -> String {
    let (w, h) = plots.iter().fold((0, 0), |(w, h), p| (w.max(p.width), h.max(p.height)));
    let rows = plots.len().div_ceil(columns.max(1));
    let cols = columns.min(plots.len()).max(1);
    let (total_w, total_h) = (w as usize * cols, h as usize * rows);
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{total_w}\" height=\"{total_h}\" viewBox=\"0 0 {total_w} {total_h}\">\n<rect width=\"{total_w}\" height=\"{total_h}\" fill=\"white\"/>\n"
    );
    for (k, plot) in plots.iter().enumerate() {
        let (x, y) = ((k % columns.max(1)) * w as usize, (k / columns.max(1)) * h as usize);
        // Each plot is a standalone <svg>; nested, it only needs its place.
        let inner = svg_line_plot(plot);
        svg.push_str(&inner.replacen("<svg ", &format!("<svg x=\"{x}\" y=\"{y}\" "), 1));
    }
    svg.push_str("</svg>\n");
    svg
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn tight_regions_are_counted_per_object() {
        let record = |frame: i64, clamped: bool, cut: bool| FrameRecord {
            frame,
            stats: squish::pipeline::FrameStats {
                objects: vec![
                    squish::pipeline::ObjectStats { name: "ball".into(), ..Default::default() },
                    squish::pipeline::ObjectStats {
                        name: "ground".into(),
                        extent_clamped: clamped,
                        domain_reaches_cut: cut,
                        ..Default::default()
                    },
                ],
                ..Default::default()
            },
            objects: Vec::new(),
            pairs: Vec::new(),
            support: Vec::new(),
        };
        let records = [record(3, false, false), record(4, false, true), record(5, true, true), record(6, false, true)];
        let tight = TightRegionSummary::of(&records);
        assert_eq!(tight.len(), 1);
        let t = &tight[0];
        assert_eq!(
            (t.object.as_str(), t.extent_clamped_frames, t.domain_cut_frames, t.first_frame),
            ("ground", 1, 3, 4)
        );
        assert!(t.line().contains("ground") && t.line().contains("widen `region`"), "{}", t.line());
        assert!(TightRegionSummary::of(&records[..1]).is_empty());
    }

    #[test]
    fn percentages_keep_small_values_visible() {
        assert_eq!(percent(0.123), "12.3%");
        assert_eq!(percent(0.00123), "0.12%");
        assert_eq!(percent(1.7e-6), "2e-4%");
        assert_eq!(percent(0.0), "0.0%");
    }

    #[test]
    fn stacked_svg_places_every_plot() {
        let plots = vec![Plot::new("a"), Plot::new("b"), Plot::new("c")];
        let svg = stacked_svg(&plots, 2);
        assert_eq!(svg.matches("<svg ").count(), 4);
        assert!(svg.contains("<svg x=\"800\" y=\"0\" "), "{svg}");
        assert!(svg.contains("<svg x=\"0\" y=\"500\" "));
        assert!(svg.trim_end().ends_with("</svg>"));
    }
}
