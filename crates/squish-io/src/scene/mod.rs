//! Scene files: an animated shot described in TOML — which meshes, how they move, which
//! parameters (possibly keyframed), which pairs collide, which frames, where results go — and
//! its evaluation, frame by frame, into plain values for the deformer.
//!
//! ```text
//! Scene::load("shot.toml")          parse → check → resolve paths → load meshes once
//!   .frames()                       the scene's whole frames, start..=end
//!   .evaluate(frame) -> OwnedFrame  meshes posed and placed, parameters as numbers
//! ```
//!
//! Every frame is independent (the deformer is time-independent), so a [`Scene`] is immutable
//! after loading and `Send + Sync`: evaluate frames on any thread, in any order, or split the
//! range over machines with [`parse_frame_selection`]. The format is documented in
//! `docs/scene-format.md`.
//!
//! Errors are [`IoError`]s. Mistakes in the scene file are located: `shot.toml:12:1: unknown
//! key "stifness" in [[objects]] "ball" (did you mean "stiffness"?)`; problems with a mesh or
//! data file name that file (and the frame, for sequences).

mod articulations;
pub use articulations::{AutomaticArticulation, AutomaticSelfContact, JointPoints, automatic_self_contact};
mod diagnostics;
mod evaluate;
mod frames;
mod keys;
mod source;
mod tracks;
mod transform;
mod types;
mod validate;
mod vertex_data;

use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use frames::{FramePattern, FrameSelectionError, format_frame, parse_frame_selection};
pub use keys::Keyed;
pub use tracks::{ParamTracks, RawParams, Track, TrackError, names_vertex_data, param_value, toml_value};
pub use transform::{AxisAngle, Scale, Transform};
pub use types::{
    FrameRange, GltfSource, MeshSource, ObjectSpec, OutputFormat, OutputSpec, PairSpec, PreviewCamera, PreviewSpec,
    SceneDescription, SelfContactSpec, UpAxisName, VertexData, Weld,
};
pub use vertex_data::read_vertex_map;

use articulations::{ArticulationAssets, load_articulations};
use diagnostics::{Seg, SourceText};
use source::{GltfCache, SourceAssets, VertexNumbering, load_source};
use squish::params::{MappingMethod, ObjectParams, PairParams, ParamValue, Params, RegionChoice};
use vertex_data::{OwnGltf, load_vertex_values};

use crate::IoError;

/// A loaded scene: its description (paths absolute) and the assets every frame reads (meshes,
/// parsed glTF files, per-vertex data, the parameters' curves), loaded once.
#[derive(Debug)]
pub struct Scene {
    path: PathBuf,
    description: SceneDescription,
    assets: Vec<ObjectAssets>,
    /// Per pair: the indices of its two objects.
    pair_objects: Vec<[usize; 2]>,
    /// Per pair: its parameters over the shot.
    pair_params: Vec<ParamTracks<PairParams>>,
}

/// How an object read from a glTF node is posed at one frame ([`Scene::gltf_pose`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GltfFramePose {
    pub node: usize,
    pub animation: Option<usize>,
    /// Animation time in seconds.
    pub time: f64,
}

/// What an object's frames are made from.
#[derive(Debug)]
struct ObjectAssets {
    source: SourceAssets,
    numbering: VertexNumbering,
    /// Its parameters over the shot, per-vertex ones loaded.
    params: ParamTracks<ObjectParams>,
    /// `[[objects.self_contact]]`, in order, then the automatic ones (`self_contact = "auto"`).
    articulations: Vec<ArticulationAssets>,
    /// Their names, in the same order.
    articulation_names: Vec<String>,
    /// The parts of a skinned mesh with `self_contact = "auto"`.
    parts: Option<Arc<squish::params::SkinParts>>,
    /// The bind pose of a glTF mesh with articulations.
    rest_positions: Option<Arc<[glam::DVec3]>>,
    /// Its texture coordinates (or why it has none), read the first time a pair with the
    /// shared-parametrization mapping needs them ([`Scene::object_uvs`]).
    uvs: std::sync::OnceLock<Result<Arc<squish::params::Uvs>, String>>,
}

impl SceneDescription {
    /// Parses and checks a scene file's text without reading any other file. `path` is the
    /// scene file: messages name it, and relative paths are resolved against its folder.
    pub fn parse(text: &str, path: &Path) -> Result<Self, IoError> {
        let src = SourceText::parse(path, text)?;
        let mut description: SceneDescription = toml::from_str(text).map_err(|e| src.toml_error(&e))?;
        validate::validate(&description, &src)?;
        description.resolve_paths(&base_dir(path));
        Ok(description)
    }

    /// Makes every relative path absolute, relative to `base`.
    fn resolve_paths(&mut self, base: &Path) {
        let resolve = |p: &mut PathBuf| {
            if p.is_relative() {
                *p = base.join(&*p);
            }
        };
        resolve(&mut self.output.dir);
        for object in &mut self.objects {
            resolve(object.mesh.file_mut());
            for (key, value) in &mut object.params {
                let per_vertex = ObjectParams::info(key).is_some_and(|i| names_vertex_data(i, value));
                if let (true, Ok(mut data)) = (per_vertex, VertexData::from_value(value)) {
                    if let Some(file) = data.file_mut() {
                        resolve(file);
                    }
                    *value = toml::Value::try_from(&data).unwrap_or_else(|_| value.clone());
                }
            }
            for entry in object.self_contact.iter_mut() {
                for mask in entry.masks.iter_mut().flatten() {
                    if let Some(file) = mask.file_mut() {
                        resolve(file);
                    }
                }
            }
        }
    }
}

/// The folder relative paths of a scene start from: the scene file's folder, made absolute.
fn base_dir(scene: &Path) -> PathBuf {
    let dir = scene.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf())
}

impl Scene {
    /// Reads, checks and loads a scene file and everything it refers to.
    pub fn load(path: &Path) -> Result<Self, IoError> {
        let text = std::fs::read_to_string(path).map_err(|e| IoError::io(path, "read", e))?;
        Self::from_toml(&text, path)
    }

    /// As [`Scene::load`], with the scene's text given (`path` locates relative paths and
    /// names the scene in messages).
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, IoError> {
        let description = SceneDescription::parse(text, path)?;
        let src = SourceText::parse(path, text)?;
        Self::from_description(description, path, Some(&src))
    }

    /// Checks and loads an already parsed description (e.g. one read back from JSON; relative
    /// paths in it are taken from `path`'s folder). `path` names the scene in messages, which
    /// name keys but no lines.
    pub fn from_parsed(mut description: SceneDescription, path: &Path) -> Result<Self, IoError> {
        validate::validate(&description, &SourceText::detached(path))?;
        description.resolve_paths(&base_dir(path));
        Self::from_description(description, path, None)
    }

    fn from_description(description: SceneDescription, path: &Path, src: Option<&SourceText>) -> Result<Self, IoError> {
        let located = |i: usize, key: &'static str, message: String| match src {
            Some(src) => src.error_at_key(&[Seg::Key("objects"), Seg::Index(i), Seg::Key(key)], message),
            None => IoError::format(path, format!("[[objects]] #{}: {key}: {message}", i + 1)),
        };
        let base = base_dir(path);
        let missing = |file: &Path| {
            format!(
                "{} does not exist (relative paths start from the scene file's folder, {})",
                file.display(),
                base.display()
            )
        };
        let frames = (description.frames.start, description.frames.end);
        let mut cache = GltfCache::default();
        let mut assets = Vec::with_capacity(description.objects.len());
        for (i, object) in description.objects.iter().enumerate() {
            if !matches!(object.mesh, MeshSource::Sequence { .. }) && !object.mesh.file().is_file() {
                let file = object.mesh.file();
                let message = if file.is_dir() {
                    format!(
                        "{} is a folder, not a mesh file; give a .obj, .ply, .gltf or .glb file in it",
                        file.display()
                    )
                } else {
                    missing(file)
                };
                return Err(located(i, "mesh", message));
            }
            // Said at the scene's line rather than by the reader, which knows only the mesh file.
            if let Err(error) = crate::MeshFormat::from_path(object.mesh.file()) {
                return Err(located(i, "mesh", error.to_string()));
            }
            let (source, numbering) =
                load_source(&object.name, &object.mesh, frames, description.frames.fps, &mut cache)?;
            // The file an attribute without `file` is read from: the object's own mesh file.
            let own_file = match &source {
                SourceAssets::Sequence(seq) => seq.reference_path.clone(),
                _ => object.mesh.file().clone(),
            };
            let own_gltf = match &source {
                SourceAssets::Gltf(g) => {
                    g.scene.nodes[g.node].mesh.map(|mesh| OwnGltf { file: object.mesh.file(), mesh })
                }
                _ => None,
            };
            let load_data = |data: &VertexData, key: &'static str, what: &str| -> Result<Vec<f64>, IoError> {
                let (file, attribute) = match data {
                    VertexData::Text { file } => (file.clone(), None),
                    VertexData::Attribute { file, attribute } => {
                        (file.clone().unwrap_or_else(|| own_file.clone()), Some(attribute.as_str()))
                    }
                };
                if !file.is_file() {
                    return Err(located(i, key, missing(&file)));
                }
                load_vertex_values(&object.name, what, &file, attribute, &numbering, own_gltf.as_ref())
            };
            // Per-vertex parameters: their files, read once, in the object's numbering.
            let mut loaded = std::collections::BTreeMap::new();
            for (key, value) in &object.params {
                let Some(info) = ObjectParams::info(key).filter(|i| names_vertex_data(i, value)) else { continue };
                let data = VertexData::from_value(value).map_err(|m| located(i, info.key, m))?;
                loaded.insert(info.key, load_data(&data, info.key, info.key)?);
            }
            let params = ParamTracks::<ObjectParams>::parse(&object.params, ObjectSpec::TABLE_KEYS, |info, _| {
                Ok(loaded.remove(info.key).map(ParamValue::List))
            })
            .map_err(|e| located(i, "name", format!("{}: {}", e.key, e.message)))?;
            let first = params.at(frames.0 as f64).ok();
            if let Some(p) = first.filter(|p| p.region == RegionChoice::Mask)
                && let Some(mask) = &p.region_mask
                && !mask.iter().any(|&v| v >= 0.5)
            {
                return Err(located(
                    i,
                    "region_mask",
                    "the mask selects no vertex (every value is below 0.5); paint the region with values ≥ 0.5"
                        .to_string(),
                ));
            }
            let located_entry = |k: usize, key: &'static str, message: String| match src {
                Some(src) => src.error_at_key(
                    &[Seg::Key("objects"), Seg::Index(i), Seg::Key("self_contact"), Seg::Index(k), Seg::Key(key)],
                    message,
                ),
                None => IoError::format(
                    path,
                    format!("[[objects]] \"{}\" self_contact #{}: {key}: {message}", object.name, k + 1),
                ),
            };
            let located_auto = |message: String| match src {
                Some(src) => src.error_at_key(&[Seg::Key("objects"), Seg::Index(i), Seg::Key("self_contact")], message),
                None => IoError::format(path, format!("[[objects]] \"{}\": self_contact: {message}", object.name)),
            };
            let self_contact =
                load_articulations(object, &source, numbering.count, located_entry, located_auto, |mask| {
                    load_data(mask, "self_contact", "a self_contact mask")
                })?;
            assets.push(ObjectAssets {
                source,
                numbering,
                params,
                articulations: self_contact.articulations,
                articulation_names: self_contact.names,
                parts: self_contact.parts,
                rest_positions: self_contact.rest_positions,
                uvs: std::sync::OnceLock::new(),
            });
        }
        let index = |name: &str| description.objects.iter().position(|o| o.name == name);
        let mut pair_objects = Vec::with_capacity(description.pairs.len());
        let mut pair_params = Vec::with_capacity(description.pairs.len());
        for (p, pair) in description.pairs.iter().enumerate() {
            match (index(&pair.objects[0]), index(&pair.objects[1])) {
                (Some(a), Some(b)) => pair_objects.push([a, b]),
                _ => {
                    return Err(IoError::format(
                        path,
                        format!("[[pairs]] #{}: names an object that does not exist", p + 1),
                    ));
                }
            }
            let tracks = ParamTracks::<PairParams>::parse(&pair.params, PairSpec::TABLE_KEYS, |_, _| Ok(None))
                .map_err(|e| IoError::format(path, format!("[[pairs]] #{}: {}: {}", p + 1, e.key, e.message)))?;
            pair_params.push(tracks);
        }
        let scene = Self { path: path.to_path_buf(), description, assets, pair_objects, pair_params };
        // The shared parametrization's UVs are read now, so that a mesh without them fails at load.
        for (p, tracks) in scene.pair_params.iter().enumerate() {
            if tracks.at(frames.0 as f64).is_ok_and(|params| params.mapping == MappingMethod::SharedParametrization) {
                for object in scene.pair_objects[p] {
                    scene.object_uvs(object)?;
                }
            }
        }
        Ok(scene)
    }

    /// The texture coordinates of object `i` in its numbering, for the shared-parametrization
    /// mapping (thesis §4.2.1; per corner for OBJ `vt` and glTF `TEXCOORD_0`, per vertex for PLY
    /// `u, v`, carried through welding: `crate::document_uvs`), read once. An object without
    /// them is an error naming its file and what to give instead.
    pub fn object_uvs(&self, i: usize) -> Result<Arc<squish::params::Uvs>, IoError> {
        let (spec, assets) = (&self.description.objects[i], &self.assets[i]);
        let loaded = assets
            .uvs
            .get_or_init(|| source::source_uvs(&assets.source, spec.mesh.file(), &assets.numbering).map(Arc::new));
        loaded.clone().map_err(|reason| {
            IoError::format(
                &self.path,
                format!(
                    "[[objects]] \"{}\": the shared-parametrization mapping (pair mapping = \"shared_parametrization\", thesis §4.2.1) matches the meshes in UV space, but {}: {reason}; export the mesh with UVs or use mapping = \"unique_direction\"",
                    spec.name,
                    spec.mesh.file().display()
                ),
            )
        })
    }

    /// The scene file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The description, with defaults filled in and paths absolute.
    pub fn description(&self) -> &SceneDescription {
        &self.description
    }

    /// The scene's frame range.
    pub fn frame_range(&self) -> FrameRange {
        self.description.frames
    }

    /// The scene's whole frames, `start..=end`.
    pub fn frames(&self) -> RangeInclusive<i64> {
        self.description.frames.start..=self.description.frames.end
    }

    /// The output settings (absolute `dir`).
    pub fn output(&self) -> &OutputSpec {
        &self.description.output
    }

    /// Number of vertices of object `i` (the same on every frame).
    pub fn vertex_count(&self, i: usize) -> Option<usize> {
        self.assets.get(i).map(|a| a.numbering.count)
    }

    /// Sequence files missing for `frames`, as (object name, frame, expected path): a cheap
    /// check before starting a long job.
    pub fn missing_files(&self, frames: RangeInclusive<i64>) -> Vec<(String, i64, PathBuf)> {
        let mut missing = Vec::new();
        for (spec, assets) in self.description.objects.iter().zip(&self.assets) {
            if let SourceAssets::Sequence(seq) = &assets.source {
                for f in frames.clone() {
                    let p = seq.pattern.path(f);
                    if !p.is_file() {
                        missing.push((spec.name.clone(), f, p));
                    }
                }
            }
        }
        missing
    }

    /// How object `i`, read from a glTF node, is posed at `frame`: the node, the animation and
    /// its time (`None` for other sources). With [`Self::placement`], what writing the results
    /// back into the glTF file needs to take them into the node's own space.
    pub fn gltf_pose(&self, i: usize, frame: f64) -> Option<GltfFramePose> {
        match &self.assets.get(i)?.source {
            SourceAssets::Gltf(g) => Some(GltfFramePose { node: g.node, animation: g.animation, time: g.time(frame) }),
            _ => None,
        }
    }

    /// Object `i`'s `transform` at `frame` as an affine matrix (identity without one): the
    /// placement applied to its mesh after posing.
    pub fn placement(&self, i: usize, frame: f64) -> Result<glam::DMat4, IoError> {
        let Some(spec) = self.description.objects.get(i) else {
            return Err(IoError::format(&self.path, format!("object #{} does not exist", i + 1)));
        };
        if spec.transform.is_identity() {
            return Ok(glam::DMat4::IDENTITY);
        }
        let map = evaluate::transform_at(&spec.transform, frame)
            .map_err(|m| IoError::format(&self.path, format!("object \"{}\": {m}", spec.name)))?;
        // An affine map is known by where it takes the origin and the three unit vectors.
        let origin = map(glam::DVec3::ZERO);
        Ok(glam::DMat4::from_cols(
            (map(glam::DVec3::X) - origin).extend(0.0),
            (map(glam::DVec3::Y) - origin).extend(0.0),
            (map(glam::DVec3::Z) - origin).extend(0.0),
            origin.extend(1.0),
        ))
    }

    /// The resolved description as pretty JSON: every parameter of every table, the defaults of
    /// the ones the file leaves out included (it reads back to the same scene).
    pub fn to_json(&self) -> Result<String, IoError> {
        fn fill<P: Params>(raw: &mut RawParams) {
            for entry in squish::params::entries::<P>() {
                raw.entry(entry.info.key.to_string()).or_insert_with(|| toml_value(&entry.default));
            }
        }
        let mut description = self.description.clone();
        for object in &mut description.objects {
            fill::<ObjectParams>(&mut object.params);
            for entry in object.self_contact.iter_mut() {
                fill::<squish::ArticulationParams>(&mut entry.params);
            }
        }
        for pair in &mut description.pairs {
            fill::<PairParams>(&mut pair.params);
        }
        serde_json::to_string_pretty(&description)
            .map_err(|e| IoError::format(&self.path, format!("cannot write the scene as JSON: {e}")))
    }
}
