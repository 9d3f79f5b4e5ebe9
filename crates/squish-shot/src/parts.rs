//! The files holding every frame (glb, gltf, pc2) of a shot split into parts — `--frames A:B`
//! runs on several machines, the Python module's Ray tasks — merged into the one file per object
//! that a single run writes: `<object>.A-B.<ext>` parts into `<object>.<ext>`.
//!
//! A part's frames are read back as written (morph targets' displacements and point caches'
//! positions are stored in `f32`, so reading gives the same bits), then written by the same
//! writers as an unsplit run: the merged file is that run's file, byte for byte. Parts are taken
//! by frame range (start, then end, then name), a frame held by several parts from the last of
//! them in that order, as report parts are ([`crate::report_parts`]). An object is merged once its
//! parts hold every frame of the scene; otherwise [`Merged::incomplete`] says which are missing.
//!
//! [`completed_frames`] lists the frames a folder already holds, for a re-run that skips them.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use glam::DVec3;
use squish_io::scene::{MeshSource, OutputFormat, OutputSpec};
use squish_io::{GltfDocument, MorphFrame, MorphKeys, Scene, SparseDisplacement};

use crate::error::ShotError;
use crate::outputs::{MorphTarget, frame_time, target_frame, write_morphs};
use crate::report_parts::{part_range, runs};

/// What [`merge_parts`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Merged {
    /// The merged files, one per object whose parts hold every frame.
    pub files: Vec<PathBuf>,
    /// Per object whose parts do not: its name and the frames missing, as `A:B` runs.
    pub incomplete: Vec<(String, Vec<String>)>,
}

/// A part of an object's file: its frames and path.
struct Part {
    frames: (i64, i64),
    path: PathBuf,
}

/// The parts `<name>.A-B.<ext>` of every object in `output.dir`, sorted (see the module
/// documentation).
fn parts_of(output: &OutputSpec, names: &[&str]) -> Result<Vec<Vec<Part>>, ShotError> {
    let ext = output.format.extension();
    let mut parts: Vec<Vec<Part>> = names.iter().map(|_| Vec::new()).collect();
    let entries = std::fs::read_dir(&output.dir).map_err(|e| ShotError::Parts {
        path: output.dir.clone(),
        message: format!("cannot list the folder to merge the parts: {e}"),
    })?;
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        for (k, name) in names.iter().enumerate() {
            if let Some(frames) = part_range(&file, name, ext) {
                parts[k].push(Part { frames, path: entry.path() });
            }
        }
    }
    for list in &mut parts {
        list.sort_by(|a, b| a.frames.cmp(&b.frames).then_with(|| a.path.cmp(&b.path)));
    }
    Ok(parts)
}

/// Merges the parts of every object's file holding every frame in `output.dir` into
/// `<object>.<ext>` (see the module documentation). Per-frame formats have nothing to merge.
pub fn merge_parts(scene: &Scene, output: &OutputSpec) -> Result<Merged, ShotError> {
    let mut merged = Merged::default();
    if output.format.per_frame() {
        return Ok(merged);
    }
    let objects = &scene.description().objects;
    let names: Vec<&str> = objects.iter().map(|o| o.name.as_str()).collect();
    let range = scene.frame_range();
    for (i, parts) in parts_of(output, &names)?.into_iter().enumerate() {
        if parts.is_empty() {
            continue;
        }
        // Each frame from the last part that holds it.
        let mut source: BTreeMap<i64, usize> = BTreeMap::new();
        for (k, part) in parts.iter().enumerate() {
            for f in part.frames.0..=part.frames.1 {
                source.insert(f, k);
            }
        }
        let done: Vec<i64> = source.keys().copied().collect();
        let missing = runs(&done, range.start, range.end);
        if !missing.is_empty() {
            merged.incomplete.push((names[i].to_string(), missing));
            continue;
        }
        let path = output.animated_path(names[i]);
        match output.format {
            OutputFormat::Pc2 => merge_caches(&path, &parts, &source, range.start)?,
            _ => merge_morphs(scene, i, &path, &parts, &source)?,
        }
        merged.files.push(path);
    }
    Ok(merged)
}

/// Point caches: each frame's positions from its part, as one cache from the scene's first frame.
fn merge_caches(path: &Path, parts: &[Part], source: &BTreeMap<i64, usize>, start: i64) -> Result<(), ShotError> {
    let mut read = Vec::with_capacity(parts.len());
    for part in parts {
        let cache = squish_io::read_pc2(&part.path)?;
        let frames = (part.frames.1 - part.frames.0 + 1) as usize;
        if cache.samples.len() != frames || cache.start_frame != part.frames.0 as f32 {
            return Err(parts_error(
                part,
                format!(
                    "holds {} samples from frame {}, not frames {}:{}; run those frames again",
                    cache.samples.len(),
                    cache.start_frame,
                    part.frames.0,
                    part.frames.1
                ),
            ));
        }
        read.push(cache);
    }
    let samples: Vec<Vec<DVec3>> =
        source.iter().map(|(&f, &k)| read[k].samples[(f - parts[k].frames.0) as usize].clone()).collect();
    squish_io::write_pc2(path, &samples, start as f64, 1.0)?;
    Ok(())
}

/// Morph targets: each frame's displacement from its part, written as one run writes them.
fn merge_morphs(
    scene: &Scene,
    i: usize,
    path: &Path,
    parts: &[Part],
    source: &BTreeMap<i64, usize>,
) -> Result<(), ShotError> {
    let document = match &scene.description().objects[i].mesh {
        MeshSource::Gltf(g) => Some(GltfDocument::read(&g.file)?),
        _ => None,
    };
    let node = scene.gltf_pose(i, scene.frame_range().start as f64).map(|p| p.node);
    // Read as the source's document when the parts are copies of it, else as positions over time
    // (a glTF source whose vertices could not be numbered as the file's is written that way).
    let mut over_time = None;
    let mut frames: Vec<BTreeMap<i64, SparseDisplacement>> = Vec::with_capacity(parts.len());
    let mut is_document = None;
    for part in parts {
        let as_document = match (&document, node) {
            (Some(document), Some(node)) => document.shot_frames(&part.path, node).ok(),
            _ => None,
        };
        let (read, document_part) = match as_document {
            Some(read) => (read, true),
            None => {
                let mesh = squish_io::read_animated_glb(&part.path)?;
                let read = mesh.frames.clone();
                over_time.get_or_insert(mesh);
                (read, false)
            }
        };
        if *is_document.get_or_insert(document_part) != document_part {
            return Err(parts_error(part, "is not written like the object's other parts; run its frames again".into()));
        }
        let mut by_frame = BTreeMap::new();
        for (name, displacement) in read {
            let frame = target_frame(document_part, &name)
                .ok_or_else(|| parts_error(part, format!("holds a morph target \"{name}\" that names no frame")))?;
            by_frame.insert(frame, displacement);
        }
        let expected: BTreeSet<i64> = (part.frames.0..=part.frames.1).collect();
        if by_frame.keys().copied().collect::<BTreeSet<i64>>() != expected {
            return Err(parts_error(
                part,
                format!(
                    "does not hold the targets of frames {}:{}; run those frames again",
                    part.frames.0, part.frames.1
                ),
            ));
        }
        frames.push(by_frame);
    }
    let morphs: Vec<MorphFrame> = source
        .iter()
        .map(|(&f, &k)| MorphFrame {
            name: crate::outputs::target_name(is_document == Some(true), f),
            time: frame_time(scene, i, f),
            displacement: frames[k][&f].clone(),
        })
        .collect();
    let target = match (&document, &over_time) {
        (Some(document), _) if is_document == Some(true) => MorphTarget::Document(document),
        (_, Some(mesh)) => MorphTarget::OverTime { base: &mesh.base, triangles: &mesh.triangles },
        _ => return Err(ShotError::Internal("no part to merge".into())),
    };
    write_morphs(scene, i, path, target, &morphs, MorphKeys::default())
}

fn parts_error(part: &Part, message: String) -> ShotError {
    ShotError::Parts { path: part.path.clone(), message }
}

/// The frames whose results are complete in `output.dir`: listed by a report part there, with
/// every object's file of the frame present — for a file holding every frame, the run's part
/// (`<object>.A-B.<ext>`, or `<object>.<ext>` for the whole shot). Files are written atomically,
/// so a file present is whole.
pub fn completed_frames(scene: &Scene, output: &OutputSpec) -> Vec<i64> {
    let names: Vec<&str> = scene.description().objects.iter().map(|o| o.name.as_str()).collect();
    let range = scene.frame_range();
    let ext = output.format.extension();
    let mut done = BTreeSet::new();
    let Ok(entries) = std::fs::read_dir(&output.dir) else { return Vec::new() };
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        let Some((a, b)) = part_range(&file, "report", "json") else { continue };
        // A part that cannot be read lists nothing: its frames are computed again.
        let Ok(text) = std::fs::read_to_string(entry.path()) else { continue };
        let Ok(part) = serde_json::from_str::<serde_json::Value>(&text) else { continue };
        let listed = part["per_frame"].as_array().into_iter().flatten().filter_map(|f| f["frame"].as_i64());
        for frame in listed {
            let present = |name: &&str| {
                if output.format.per_frame() {
                    return output.path_for(name, frame).is_file();
                }
                let whole = (a, b) == (range.start, range.end) && output.animated_path(name).is_file();
                whole || output.dir.join(format!("{name}.{a}-{b}.{ext}")).is_file()
            };
            if names.iter().all(present) {
                done.insert(frame);
            }
        }
    }
    done.into_iter().collect()
}
