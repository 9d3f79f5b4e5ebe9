//! Issue 36's figures for a character's shot ([`crate::characters::CharacterShot`]): each frame
//! run with `self_contact = "auto"` on a deformer kept over the shot, against plain skinning
//! (the input: without self-contact the character is not deformed).
//!
//! Per frame ([`FrameFigures`]): the time of the deformer's frame, the share of vertices moved
//! (farther than 1e-5 of the first input frame's height from their input position), the faces
//! intersecting another face beyond the bind pose's own before (plain skinning) and after, and
//! ΔV/V (the output's signed volume against the input's). Per shot: the excess acceleration of
//! every inner frame, `max_v |O[t+1] − 2O[t] + O[t−1]| − |I[t+1] − 2I[t] + I[t−1]|` in mean edge
//! lengths of the first input frame, exactly as `motion_quality.py` (next to the repository, in
//! `shared/tools`) computes it from OBJ folders — including its mean edge, taken over each
//! face's first edge ([`excess_acceleration`]).
//!
//! [`step_ratios`] is the continuity check: a pose swept in small steps, the output's largest
//! vertex step over the input's at each step. A continuous deformation keeps the ratios
//! bounded as the steps shrink; a discrete switch shows as a ratio that grows like 1/step.

use std::time::Instant;

use glam::DVec3;
use squish::mesh::TriMesh;
use squish::pipeline::{Deformer, OwnedFrame};
use squish::skinning::RestIntersections;

use crate::characters::{AutoSelfContact, CharacterShot};

/// One frame's figures.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameFigures {
    pub frame: usize,
    /// The deformer's time for this frame, ms.
    pub ms: f64,
    /// Share of the vertices moved (see the module doc), 0–1.
    pub moved: f64,
    /// Faces self-intersecting beyond the bind pose's own: plain skinning, output.
    pub faces_before: usize,
    pub faces_after: usize,
    /// (V_out − V_in) / V_in.
    pub volume_change: f64,
    /// Largest |O − I|, in mean edges.
    pub offset: f64,
}

/// A shot's figures.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShotFigures {
    pub name: String,
    pub vertices: usize,
    pub frames: Vec<FrameFigures>,
    /// Excess acceleration of the frames 1 ..= n − 2 (mean edges).
    pub excess_acceleration: Vec<f64>,
    /// The first input frame's mean edge (over each face's first edge) and height.
    pub mean_edge: f64,
    pub height: f64,
}

fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

impl ShotFigures {
    pub fn median_acceleration(&self) -> f64 {
        median(&self.excess_acceleration)
    }
    pub fn max_acceleration(&self) -> f64 {
        self.excess_acceleration.iter().copied().fold(f64::NAN, f64::max)
    }
    /// Frames whose excess acceleration is above `limit` (issue 36: 0.25).
    pub fn frames_above(&self, limit: f64) -> usize {
        self.excess_acceleration.iter().filter(|&&a| a > limit).count()
    }
    pub fn median_moved(&self) -> f64 {
        median(&self.frames.iter().map(|f| f.moved).collect::<Vec<_>>())
    }
    /// Frames whose input crosses itself beyond the rest pose (the shot's frames in contact;
    /// a pose coming from rest has none at first).
    pub fn frames_in_contact(&self) -> usize {
        self.frames.iter().filter(|f| f.faces_before > 0).count()
    }
    /// The median excess acceleration over the inner frames in contact.
    pub fn median_acceleration_in_contact(&self) -> f64 {
        let values: Vec<f64> = self
            .excess_acceleration
            .iter()
            .enumerate()
            .filter(|&(t, _)| self.frames.get(t + 1).is_some_and(|f| f.faces_before > 0))
            .map(|(_, &a)| a)
            .collect();
        median(&values)
    }
    /// The median share of vertices moved over the frames in contact.
    pub fn median_moved_in_contact(&self) -> f64 {
        median(&self.frames.iter().filter(|f| f.faces_before > 0).map(|f| f.moved).collect::<Vec<_>>())
    }
    pub fn faces(&self) -> (usize, usize) {
        (self.frames.iter().map(|f| f.faces_before).sum(), self.frames.iter().map(|f| f.faces_after).sum())
    }
    /// Frames with more faces after than before.
    pub fn frames_worse(&self) -> usize {
        self.frames.iter().filter(|f| f.faces_after > f.faces_before).count()
    }
    pub fn max_volume_change(&self) -> f64 {
        self.frames.iter().map(|f| f.volume_change.abs()).fold(0.0, f64::max)
    }
    pub fn mean_ms(&self) -> f64 {
        self.frames.iter().map(|f| f.ms).sum::<f64>() / self.frames.len().max(1) as f64
    }
    pub fn max_ms(&self) -> f64 {
        self.frames.iter().map(|f| f.ms).fold(0.0, f64::max)
    }
}

/// motion_quality.py's mean edge: the mean length of each face's first edge (corners 0 → 1).
pub fn first_edge_mean(mesh: &TriMesh) -> f64 {
    let sum: f64 = mesh
        .triangles
        .iter()
        .map(|&[a, b, _]| (mesh.positions[a as usize] - mesh.positions[b as usize]).length())
        .sum();
    sum / mesh.triangles.len().max(1) as f64
}

/// motion_quality.py's height: the largest extent of the bounding box along x, y or z.
pub fn height(positions: &[DVec3]) -> f64 {
    let (lo, hi) = positions.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    (hi - lo).max_element().max(0.0)
}

/// The excess acceleration of frames 1 ..= n − 2 (motion_quality.py), in units of `edge`.
pub fn excess_acceleration(inputs: &[Vec<DVec3>], outputs: &[Vec<DVec3>], edge: f64) -> Vec<f64> {
    (1..inputs.len().saturating_sub(1))
        .map(|t| {
            let (i, o) =
                ((&inputs[t - 1], &inputs[t], &inputs[t + 1]), (&outputs[t - 1], &outputs[t], &outputs[t + 1]));
            (0..i.1.len())
                .map(|v| {
                    let ao = (o.2[v] - 2.0 * o.1[v] + o.0[v]).length();
                    let ai = (i.2[v] - 2.0 * i.1[v] + i.0[v]).length();
                    ao - ai
                })
                .fold(f64::NEG_INFINITY, f64::max)
                / edge
        })
        .collect()
}

/// Share of the vertices farther than `1e-5 · height` from their input position.
pub fn moved_share(input: &[DVec3], output: &[DVec3], height: f64) -> f64 {
    let moved = input.iter().zip(output).filter(|(i, o)| (**o - **i).length() > 1e-5 * height).count();
    moved as f64 / input.len().max(1) as f64
}

/// Runs `shot` frame by frame with `self_contact = "auto"` on one deformer (no quality pass)
/// and measures it against plain skinning. `each(figures, input, output)` sees every frame as
/// it is done (e.g. to write it out). `frames` limits the run to the first frames (`None`: all).
pub fn measure(
    shot: &CharacterShot,
    frames: Option<usize>,
    mut each: impl FnMut(&FrameFigures, &TriMesh, &TriMesh) -> Result<(), String>,
) -> Result<ShotFigures, String> {
    let auto = shot.character.auto_self_contact();
    let rest = RestIntersections::new(&shot.character.rest).map_err(|e| e.to_string())?;
    let count = frames.unwrap_or(shot.frames).min(shot.frames);
    let mut deformer = Deformer::new().without_quality();
    let mut figures =
        ShotFigures { name: shot.name.to_string(), vertices: shot.character.rest.num_vertices(), ..Default::default() };
    let (mut inputs, mut outputs) = (Vec::with_capacity(count), Vec::with_capacity(count));
    for k in 0..count {
        let world = shot.world(k as f64);
        let object = shot.character.object(&world, Some(&auto))?;
        let input = object.mesh.clone();
        if k == 0 {
            figures.mean_edge = first_edge_mean(&input);
            figures.height = height(&input.positions);
        }
        let frame = OwnedFrame { objects: vec![object], pairs: Vec::new() };
        let start = Instant::now();
        let result = deformer.deform(&frame.frame()).map_err(|e| format!("{} frame {k}: {e}", shot.name))?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let output = TriMesh { positions: result.positions[0].clone(), triangles: input.triangles.clone() };
        let faces = |mesh: &TriMesh| rest.faces_beyond(mesh).map(|f| f.len()).map_err(|e| e.to_string());
        let volume_in = squish::mesh::signed_volume(&input);
        let offset = input.positions.iter().zip(&output.positions).map(|(i, o)| (*o - *i).length()).fold(0.0, f64::max);
        figures.frames.push(FrameFigures {
            frame: k,
            ms,
            moved: moved_share(&input.positions, &output.positions, figures.height),
            faces_before: faces(&input)?,
            faces_after: faces(&output)?,
            volume_change: (squish::mesh::signed_volume(&output) - volume_in) / volume_in,
            offset: offset / figures.mean_edge,
        });
        if let Some(last) = figures.frames.last() {
            each(last, &input, &output)?;
        }
        inputs.push(input.positions);
        outputs.push(output.positions);
    }
    figures.excess_acceleration = excess_acceleration(&inputs, &outputs, figures.mean_edge);
    Ok(figures)
}

/// The continuity check: `shot` swept from frame `from` to frame `to` in `steps` equal steps on
/// one deformer with `self_contact = "auto"` (`None`: plain skinning, ratios 1), and at each
/// step the output's largest vertex displacement over the input's:
/// `max_v |O_{k+1} − O_k| / max_v |I_{k+1} − I_k|`. The first entry is the step from `from`.
pub fn step_ratios(
    shot: &CharacterShot,
    from: f64,
    to: f64,
    steps: usize,
    auto: Option<&AutoSelfContact>,
) -> Result<Vec<f64>, String> {
    let mut deformer = Deformer::new().without_quality();
    let mut previous: Option<(Vec<DVec3>, Vec<DVec3>)> = None;
    let mut ratios = Vec::with_capacity(steps);
    for k in 0..=steps {
        let frame = from + (to - from) * k as f64 / steps.max(1) as f64;
        let object = shot.character.object(&shot.world(frame), auto)?;
        let input = object.mesh.positions.clone();
        let owned = OwnedFrame { objects: vec![object], pairs: Vec::new() };
        let output = deformer.deform(&owned.frame()).map_err(|e| format!("{} at frame {frame}: {e}", shot.name))?;
        let output = output.positions[0].clone();
        if let Some((pi, po)) = &previous {
            let step = |a: &[DVec3], b: &[DVec3]| a.iter().zip(b).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
            ratios.push(step(&output, po) / step(&input, pi).max(f64::MIN_POSITIVE));
        }
        previous = Some((input, output));
    }
    Ok(ratios)
}

/// The table's header (markdown), for [`table_row`]. "In contact": over the frames whose input
/// crosses itself beyond the rest pose.
pub const TABLE_HEADER: &str = "| shot | vertices | frames (in contact) | excess acc. median (in contact) | max | frames > 0.25 | moved median (in contact) | faces before → after | frames worse | max ΔV/V | ms/frame mean | max |\n|---|---|---|---|---|---|---|---|---|---|---|---|";

/// One markdown row of a shot's figures.
pub fn table_row(f: &ShotFigures) -> String {
    let (before, after) = f.faces();
    format!(
        "| {} | {} | {} ({}) | {:.2} ({:.2}) | {:.2} | {}/{} | {:.0}% ({:.0}%) | {} → {} | {} | {:.1e} | {:.0} | {:.0} |",
        f.name,
        f.vertices,
        f.frames.len(),
        f.frames_in_contact(),
        f.median_acceleration(),
        f.median_acceleration_in_contact(),
        f.max_acceleration(),
        f.frames_above(0.25),
        f.excess_acceleration.len(),
        100.0 * f.median_moved(),
        100.0 * f.median_moved_in_contact(),
        before,
        after,
        f.frames_worse(),
        f.max_volume_change(),
        f.mean_ms(),
        f.max_ms()
    )
}
