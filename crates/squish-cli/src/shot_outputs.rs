//! The result files of `squish run`, per object, in the scene's output format:
//!
//! - `obj` / `ply`: one file per frame. When the source is a file of the same format (a static
//!   file or a sequence), each frame's file is a copy of the source (of that frame's file, for a
//!   sequence) with the deformed positions and normals: UVs, materials, groups, colours and
//!   extra properties are kept. Other sources give positions and faces;
//! - `glb` / `gltf`: one file per object with every frame. A glTF source's whole document (rig,
//!   materials, textures, the original animation) with the deformation as one morph target per
//!   frame, keyed on the frames' animation times ([`squish_io::GltfDocument::write_animated`]);
//!   the scene's `transform` is taken off, so the result lives where the asset does. Other
//!   sources give positions over time;
//! - `pc2`: one point cache per object with every frame, in the source file's vertex order and
//!   the scene's space.
//!
//! Files holding every frame are written when every frame asked for is done; a `--frames A:B`
//! part names them `<object>.A-B.<ext>` so that the parts of a split shot do not overwrite each
//! other.

use std::path::{Path, PathBuf};

use glam::DVec3;
use squish_io::scene::{FramePattern, MeshSource, OutputFormat, OutputSpec};
use squish_io::{GltfDocument, MeshDocument, MeshFormat, MorphAnimation, Scene};

use crate::error::CliError;
use crate::scene_shot::FileNumbering;
use crate::shot::ShotOutcome;
use squish::pipeline::OwnedFrame;

/// Where an object's results are written into.
enum Target {
    /// The source document, the same for every frame.
    Document(Box<MeshDocument>),
    /// Each frame's own file of a sequence.
    Sequence(FramePattern),
    /// Positions and faces only.
    Plain,
}

/// The writers of a shot's result files.
pub struct ShotOutputs<'a> {
    scene: &'a Scene,
    output: &'a OutputSpec,
    numbering: &'a [FileNumbering],
    targets: Vec<Target>,
    /// Suffix of the files holding every frame of a part (`.A-B`), empty for the whole shot.
    part: String,
}

impl<'a> ShotOutputs<'a> {
    /// The writers for `scene`'s objects; `part` is the frame range of a `--frames` part.
    pub fn new(
        scene: &'a Scene,
        output: &'a OutputSpec,
        numbering: &'a [FileNumbering],
        part: Option<(i64, i64)>,
    ) -> Result<Self, CliError> {
        let mut targets = Vec::new();
        for (spec, n) in scene.description().objects.iter().zip(numbering) {
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
                    Target::Sequence(FramePattern::parse(&text).map_err(|m| CliError::input(format!("{}: {m}", text)))?)
                }
                _ => Target::Plain,
            };
            targets.push(target);
        }
        let part = part.map_or_else(String::new, |(a, b)| format!(".{a}-{b}"));
        Ok(Self { scene, output, numbering, targets, part })
    }

    /// The file of object `name` holding every frame.
    pub fn shot_path(&self, name: &str) -> PathBuf {
        let whole = self.output.animated_path(name);
        let ext = self.output.format.extension();
        whole.with_file_name(format!("{name}{}.{ext}", self.part))
    }

    /// Writes one frame's files (per-frame formats only).
    pub fn write_frame(&self, frame: i64, shot: &OwnedFrame, positions: &[Vec<DVec3>]) -> Result<(), CliError> {
        if !self.output.format.per_frame() {
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
                Target::Plain => squish_io::write_mesh(&path, &n.file_mesh(p))?,
            }
        }
        Ok(())
    }

    /// Writes the files holding every frame (`glb`, `gltf`, `pc2`) from the kept outputs, in
    /// frame order; returns their paths.
    pub fn write_shot(&self, first: &OwnedFrame, outcome: &ShotOutcome) -> Result<Vec<PathBuf>, CliError> {
        let mut written = Vec::new();
        let frames: Vec<i64> = outcome.kept.keys().copied().collect();
        for (i, (object, n)) in first.objects.iter().zip(self.numbering).enumerate() {
            let samples: Vec<Vec<DVec3>> = outcome.kept.values().map(|positions| n.positions(&positions[i])).collect();
            let path = self.shot_path(&object.name);
            match self.output.format {
                OutputFormat::Pc2 => {
                    let start = frames.first().copied().unwrap_or(0) as f64;
                    squish_io::write_pc2(&path, &samples, start, 1.0)?;
                }
                OutputFormat::Glb | OutputFormat::Gltf => match &self.targets[i] {
                    Target::Document(document) => match document.as_ref() {
                        MeshDocument::Gltf(gltf) => self.write_morph_animation(gltf, i, &path, &frames, samples)?,
                        _ => self.write_positions_over_time(&path, &object.name, n, &samples)?,
                    },
                    _ => self.write_positions_over_time(&path, &object.name, n, &samples)?,
                },
                OutputFormat::Obj | OutputFormat::Ply => continue,
            }
            written.push(path);
        }
        Ok(written)
    }

    fn write_positions_over_time(
        &self,
        path: &Path,
        name: &str,
        n: &FileNumbering,
        samples: &[Vec<DVec3>],
    ) -> Result<(), CliError> {
        squish_io::write_animated_glb(path, name, &n.triangles, samples, self.scene.frame_range().fps)?;
        Ok(())
    }

    /// The deformation of object `i` (read from a glTF node) as morph targets of its document.
    fn write_morph_animation(
        &self,
        document: &GltfDocument,
        i: usize,
        path: &Path,
        frames: &[i64],
        samples: Vec<Vec<DVec3>>,
    ) -> Result<(), CliError> {
        let mut times = Vec::with_capacity(frames.len());
        let mut posed = Vec::with_capacity(frames.len());
        let mut pose = None;
        for (&frame, sample) in frames.iter().zip(samples) {
            let Some(p) = self.scene.gltf_pose(i, frame as f64) else {
                return Err(CliError::failure(format!("object #{}: not read from a glTF node", i + 1)));
            };
            pose = Some(p);
            // Results are in the scene's space: take the object's placement off.
            let placement = self.scene.placement(i, frame as f64)?.inverse();
            posed.push(sample.iter().map(|q| placement.transform_point3(*q)).collect());
            times.push(p.time);
        }
        let Some(pose) = pose else { return Ok(()) };
        let names: Vec<String> =
            frames.iter().map(|f| format!("squish_{}", squish_io::scene::format_frame(*f, 4))).collect();
        let animation =
            MorphAnimation { node: pose.node, animation: pose.animation, times: &times, frames: &posed, names: &names };
        document.write_animated(path, &animation)?;
        Ok(())
    }
}
