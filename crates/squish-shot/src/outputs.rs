//! The result files of `squish run`, per object, in the scene's output format:
//!
//! - `obj` / `ply`: one file per frame. When the source is a file of the same format (a static
//!   file or a sequence), each frame's file is a copy of the source (of that frame's file, for a
//!   sequence) with the deformed positions and normals: UVs, materials, groups, colours and
//!   extra properties are kept. A glTF source gives its node's mesh with its first UV set and
//!   its normals, recomputed per frame ([`squish_io::GltfDocument::write_converted`]); other
//!   sources give positions and faces;
//! - `glb` / `gltf`: one file per object with every frame. A glTF source's whole document (rig,
//!   materials, textures, the original animation) with the deformation as one morph target per
//!   frame, keyed on the frames' animation times ([`squish_io::GltfDocument::write_animated`]);
//!   the scene's `transform` is taken off, so the result lives where the asset does. Other
//!   sources give their positions over time: the input at the scene's first frame as the base
//!   mesh, each frame's displacement from it as a target ([`squish_io::write_animated_glb`]).
//!   Targets hold only the vertices that move (sparse accessors);
//! - `pc2`: one point cache per object with every frame, in the source file's vertex order and
//!   the scene's space.
//!
//! Files holding every frame are written when every frame asked for is done, from what each
//! frame left as it was computed (a target's displacement, a cache's positions); a `--frames A:B`
//! part names them `<object>.A-B.<ext>` so that the parts of a split shot do not overwrite each
//! other, and keys every target off at the frame before `A` and the frame after `B` (within the
//! scene's frames), so that a part shows nothing outside its frames. [`crate::parts`] merges the
//! parts into the file one run writes. A frame's target is the same, bit for bit, whatever run
//! computed it.

use std::collections::BTreeMap;
use std::ops::RangeInclusive;
use std::path::PathBuf;
use std::sync::Mutex;

use glam::DVec3;
use squish_io::scene::{FramePattern, MeshSource, OutputFormat, OutputSpec};
use squish_io::{
    GltfDocument, MeshDocument, MeshFormat, MorphAnimation, MorphFrame, MorphKeys, Scene, SparseDisplacement,
};

use crate::error::ShotError;
use crate::scene_shot::{FileNumbering, SceneShot};
use crate::shot::ShotSource;
use squish::pipeline::OwnedFrame;

/// Where an object's results are written into.
enum Target {
    /// The source document, the same for every frame.
    Document(Box<MeshDocument>),
    /// Each frame's own file of a sequence.
    Sequence(FramePattern),
    /// A glTF node's mesh written as OBJ or PLY, with its UVs and normals.
    Converted { document: Box<GltfDocument>, node: usize },
    /// Positions and faces only.
    Plain,
}

/// What a file holding every frame keeps of one computed frame of an object.
enum Sample {
    /// A morph target's displacement (glTF and GLB).
    Displacement(SparseDisplacement),
    /// Positions in the file's vertex order (a point cache).
    Positions(Vec<DVec3>),
}

/// The writers of a shot's result files.
pub struct ShotOutputs<'a> {
    scene: &'a Scene,
    output: &'a OutputSpec,
    numbering: &'a [FileNumbering],
    targets: Vec<Target>,
    /// The frames this run computes, and whether they are a part of the shot.
    frames: RangeInclusive<i64>,
    part: Option<(i64, i64)>,
    /// Objects whose deformation is written as positions over time: the base mesh (the input at
    /// the scene's first frame, in the file's vertex order).
    bases: Vec<Option<Vec<DVec3>>>,
    /// Per computed frame and object, what the files holding every frame need.
    samples: Mutex<BTreeMap<i64, Vec<Sample>>>,
}

/// The morph-target name of frame `frame`: for a glTF source's document (`squish_0012`), for
/// positions over time (`frame_0012`).
pub fn target_name(document: bool, frame: i64) -> String {
    let prefix = if document { "squish_" } else { "frame_" };
    format!("{prefix}{}", squish_io::scene::format_frame(frame, 4))
}

/// The frame of a target named by [`target_name`].
pub fn target_frame(document: bool, name: &str) -> Option<i64> {
    let prefix = if document { "squish_" } else { "frame_" };
    name.strip_prefix(prefix)?.parse().ok()
}

/// The animation time of `frame` for object `i`: the glTF animation's time for a glTF node, else
/// the time from the scene's first frame.
pub fn frame_time(scene: &Scene, i: usize, frame: i64) -> f64 {
    match scene.gltf_pose(i, frame as f64) {
        Some(pose) => pose.time,
        None => (frame - scene.frame_range().start) as f64 / scene.frame_range().fps,
    }
}

/// The keys that turn every target of object `i` off around frames `first..=last`: at the frame
/// before and the frame after, when those are frames of the scene (glTF holds the first and last
/// keys beyond them). A time that the animation's mapping does not place strictly before (after)
/// the frames — a looping clip — is replaced by the animation's start (one frame later).
pub fn part_keys(scene: &Scene, i: usize, first: i64, last: i64) -> MorphKeys {
    let range = scene.frame_range();
    let (start, end) = (frame_time(scene, i, first), frame_time(scene, i, last));
    let off_before = (first > range.start && start > 0.0).then(|| {
        let before = frame_time(scene, i, first - 1);
        if (0.0..start).contains(&before) { before } else { 0.0 }
    });
    let off_after = (last < range.end).then(|| {
        let after = frame_time(scene, i, last + 1);
        if after > end { after } else { end + 1.0 / range.fps }
    });
    MorphKeys { off_before, off_after }
}

impl<'a> ShotOutputs<'a> {
    /// The writers for `scene`'s objects computing `frames`; `part`: the shot's part they are
    /// (`--frames`), `None` for the whole shot.
    pub fn new(
        scene: &'a Scene,
        output: &'a OutputSpec,
        numbering: &'a [FileNumbering],
        frames: RangeInclusive<i64>,
        part: Option<(i64, i64)>,
    ) -> Result<Self, ShotError> {
        let mut targets = Vec::new();
        for (i, (spec, n)) in scene.description().objects.iter().zip(numbering).enumerate() {
            let source_format = MeshFormat::from_path(spec.mesh.file()).ok();
            let same_format = matches!(
                (output.format, source_format),
                (OutputFormat::Obj, Some(MeshFormat::Obj))
                    | (OutputFormat::Ply, Some(MeshFormat::Ply))
                    | (OutputFormat::Glb | OutputFormat::Gltf, Some(MeshFormat::Gltf | MeshFormat::Glb))
            );
            let target = match (&spec.mesh, same_format && n.note.is_none()) {
                (MeshSource::File { file, .. }, true) => Target::Document(Box::new(MeshDocument::read(file)?)),
                (MeshSource::Gltf(g), true) => Target::Document(Box::new(MeshDocument::read(&g.file)?)),
                (MeshSource::Sequence { pattern, .. }, true) => {
                    let text = pattern.to_string_lossy();
                    Target::Sequence(
                        FramePattern::parse(&text)
                            .map_err(|message| ShotError::Pattern { pattern: text.into_owned(), message })?,
                    )
                }
                (MeshSource::Gltf(g), false) if output.format.per_frame() && n.note.is_none() => {
                    let node = scene.gltf_pose(i, scene.frame_range().start as f64).map(|p| p.node);
                    match node {
                        Some(node) => Target::Converted { document: Box::new(GltfDocument::read(&g.file)?), node },
                        None => Target::Plain,
                    }
                }
                _ => Target::Plain,
            };
            targets.push(target);
        }
        let over_time = |t: &Target| !matches!(t, Target::Document(d) if matches!(**d, MeshDocument::Gltf(_)));
        let animated_mesh = matches!(output.format, OutputFormat::Glb | OutputFormat::Gltf);
        let bases = if animated_mesh && targets.iter().any(over_time) {
            let start = SceneShot { scene }.frame(scene.frame_range().start)?;
            targets
                .iter()
                .zip(&start.objects)
                .zip(numbering)
                .map(|((t, o), n)| over_time(t).then(|| n.positions(&o.mesh.positions)))
                .collect()
        } else {
            vec![None; targets.len()]
        };
        Ok(Self { scene, output, numbering, targets, frames, part, bases, samples: Mutex::new(BTreeMap::new()) })
    }

    /// The file of object `name` holding every frame.
    pub fn shot_path(&self, name: &str) -> PathBuf {
        let whole = self.output.animated_path(name);
        let suffix = self.part.map_or_else(String::new, |(a, b)| format!(".{a}-{b}"));
        whole.with_file_name(format!("{name}{suffix}.{}", self.output.format.extension()))
    }

    /// Writes one frame's files (per-frame formats), or keeps what the files holding every frame
    /// need of it (called on the shot's workers).
    pub fn write_frame(&self, frame: i64, shot: &OwnedFrame, positions: &[Vec<DVec3>]) -> Result<(), ShotError> {
        if !self.output.format.per_frame() {
            let samples = self.samples_of(frame, shot, positions)?;
            if let Ok(mut kept) = self.samples.lock() {
                kept.insert(frame, samples);
            }
            return Ok(());
        }
        for (i, ((object, p), n)) in shot.objects.iter().zip(positions).zip(self.numbering).enumerate() {
            let path = self.output.path_for(&object.name, frame);
            match &self.targets[i] {
                Target::Document(document) => document.write_with_positions(&path, &n.positions(p))?,
                Target::Sequence(pattern) => {
                    let document = MeshDocument::read(&pattern.path(frame))?;
                    document.write_with_positions(&path, &n.positions(p))?;
                }
                Target::Converted { document, node } => {
                    document.write_converted(&path, Some(*node), &n.positions(p))?
                }
                Target::Plain => squish_io::write_mesh(&path, &n.file_mesh(p))?,
            }
        }
        Ok(())
    }

    /// What the files holding every frame keep of a computed frame, per object.
    fn samples_of(&self, frame: i64, shot: &OwnedFrame, positions: &[Vec<DVec3>]) -> Result<Vec<Sample>, ShotError> {
        let displacement_error = |v: usize| {
            ShotError::Internal(format!("frame {frame}: vertex {v} moves by an amount not finite in 32-bit floats"))
        };
        let mut samples = Vec::with_capacity(positions.len());
        for (i, ((object, p), n)) in shot.objects.iter().zip(positions).zip(self.numbering).enumerate() {
            let file_positions = n.positions(p);
            let sample = match (self.output.format, self.gltf_document(i), &self.bases[i]) {
                (OutputFormat::Pc2, ..) => Sample::Positions(file_positions),
                (_, Some(gltf), _) => {
                    // Only the vertices the deformer moved get a displacement.
                    let moved: Vec<bool> = p.iter().zip(&object.mesh.positions).map(|(a, b)| a != b).collect();
                    let moved = match &n.vertex_map {
                        Some(map) => map.iter().map(|&v| moved[v as usize]).collect(),
                        None => moved,
                    };
                    Sample::Displacement(self.morph_displacement(gltf, i, frame, &file_positions, &moved)?)
                }
                (_, None, Some(base)) => {
                    let delta: Vec<DVec3> = file_positions.iter().zip(base).map(|(a, b)| *a - *b).collect();
                    Sample::Displacement(SparseDisplacement::from_dense(&delta).map_err(displacement_error)?)
                }
                (_, None, None) => return Err(ShotError::Internal(format!("object #{}: no base mesh", i + 1))),
            };
            samples.push(sample);
        }
        Ok(samples)
    }

    /// Object `i`'s glTF source document, when its frames are written into it.
    fn gltf_document(&self, i: usize) -> Option<&GltfDocument> {
        match &self.targets[i] {
            Target::Document(document) => match document.as_ref() {
                MeshDocument::Gltf(gltf) => Some(gltf),
                _ => None,
            },
            _ => None,
        }
    }

    /// Object `i`'s deformation at `frame` (`posed`: the scene's space) as a displacement of its
    /// glTF node's mesh in its own space: the object's placement taken off, then its pose.
    fn morph_displacement(
        &self,
        document: &GltfDocument,
        i: usize,
        frame: i64,
        posed: &[DVec3],
        moved: &[bool],
    ) -> Result<SparseDisplacement, ShotError> {
        let Some(pose) = self.scene.gltf_pose(i, frame as f64) else {
            return Err(ShotError::Internal(format!("object #{}: not read from a glTF node", i + 1)));
        };
        // Results are in the scene's space: take the object's placement off.
        let placement = self.scene.placement(i, frame as f64)?.inverse();
        let posed: Vec<DVec3> = posed.iter().map(|q| placement.transform_point3(*q)).collect();
        Ok(document.morph_displacement(pose.node, pose.animation, pose.time, &posed, moved)?)
    }

    /// Writes the files holding every frame (`glb`, `gltf`, `pc2`) from what the computed
    /// frames left, in frame order; returns their paths.
    pub fn write_shot(&self) -> Result<Vec<PathBuf>, ShotError> {
        let mut written = Vec::new();
        let kept = std::mem::take(
            &mut *self.samples.lock().map_err(|_| ShotError::Internal("a frame's writer panicked".into()))?,
        );
        let (first, last) = (*self.frames.start(), *self.frames.end());
        for (i, spec) in self.scene.description().objects.iter().enumerate() {
            let path = self.shot_path(&spec.name);
            let frames = kept.iter().filter_map(|(&f, samples)| samples.get(i).map(|s| (f, s)));
            match (self.output.format, &self.targets[i], &self.bases[i]) {
                (OutputFormat::Obj | OutputFormat::Ply, ..) => continue,
                (OutputFormat::Pc2, ..) => {
                    let positions: Vec<Vec<DVec3>> = frames
                        .filter_map(|(_, s)| match s {
                            Sample::Positions(p) => Some(p.clone()),
                            Sample::Displacement(_) => None,
                        })
                        .collect();
                    squish_io::write_pc2(&path, &positions, first as f64, 1.0)?;
                }
                (_, _, base) => {
                    let document = self.gltf_document(i);
                    let morphs: Vec<MorphFrame> = frames
                        .filter_map(|(frame, s)| match s {
                            Sample::Displacement(d) => Some(MorphFrame {
                                name: target_name(document.is_some(), frame),
                                time: frame_time(self.scene, i, frame),
                                displacement: d.clone(),
                            }),
                            Sample::Positions(_) => None,
                        })
                        .collect();
                    let keys = part_keys(self.scene, i, first, last);
                    let target = match (document, base) {
                        (Some(document), _) => MorphTarget::Document(document),
                        (None, Some(base)) => MorphTarget::OverTime { base, triangles: &self.numbering[i].triangles },
                        (None, None) => {
                            return Err(ShotError::Internal(format!("object \"{}\": no base mesh", spec.name)));
                        }
                    };
                    write_morphs(self.scene, i, &path, target, &morphs, keys)?;
                }
            }
            written.push(path);
        }
        Ok(written)
    }
}

/// What an object's frames are written into as morph targets.
pub(crate) enum MorphTarget<'a> {
    /// Its glTF source's document (node and animation from the scene).
    Document(&'a GltfDocument),
    /// A mesh of its own: positions over time from `base`.
    OverTime { base: &'a [DVec3], triangles: &'a [[u32; 3]] },
}

/// Writes object `i`'s frames `morphs` as morph targets into `path` (see [`MorphTarget`]).
pub(crate) fn write_morphs(
    scene: &Scene,
    i: usize,
    path: &std::path::Path,
    target: MorphTarget,
    morphs: &[MorphFrame],
    keys: MorphKeys,
) -> Result<(), ShotError> {
    let name = &scene.description().objects[i].name;
    match target {
        MorphTarget::Document(document) => {
            let Some(pose) = scene.gltf_pose(i, scene.frame_range().start as f64) else {
                return Err(ShotError::Internal(format!("object \"{name}\": not read from a glTF node")));
            };
            let animation = MorphAnimation { node: pose.node, animation: pose.animation, frames: morphs, keys };
            document.write_animated(path, &animation)?;
        }
        MorphTarget::OverTime { base, triangles } => {
            squish_io::write_animated_glb(path, name, triangles, base, morphs, keys)?
        }
    }
    Ok(())
}
