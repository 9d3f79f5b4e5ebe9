//! The state of a `squish serve` session and its computation: the loaded scene, the page's edits
//! (parameter values and keys over the scene's own, painted bulge maps, the current frame) and
//! one deformer that keeps what fast edits reuse ([`squish::Deformer::keep_for_edits`], thesis
//! §5.4–5.5): a change of a downstream parameter at the same frame is an edit, bit-identical to a
//! full computation; anything else is a full frame.
//!
//! Edits are kept as the scene file writes them (a TOML value per key: a constant or
//! `{ keys = [[frame, value], …] }`), read through the scene layer's own tracks, so that the
//! exported scene file ([`super::export`]) gives `squish run` the same parameters bit for bit.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::Serialize;
use squish::params::{ArticulationParams, MappingMethod, ParamValue, Params};
use squish::pipeline::FrameResult;
use squish::{Deformer, ObjectParams, PairParams, TriMesh};
use squish_io::Scene;
use squish_io::scene::{ObjectSpec, PairSpec, ParamTracks, RawParams, param_value, toml_value};
use toml::Value;

use squish::pipeline::OwnedFrame;
use squish_shot::frame_quality::{self, ObjectQuality, PairQuality};

/// What a parameter edit applies to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Target {
    Object(usize),
    Pair(usize),
    /// Articulation `[object, k]`: the object's `[[objects.self_contact]]` entries in order, then
    /// those of `self_contact = "auto"`.
    Articulation([usize; 2]),
}

/// The page's edits over the scene, as the scene file writes them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Edits {
    /// The frame shown.
    pub frame: i64,
    /// Per object: its edited parameter keys (constant or keyframed), over the scene's values.
    pub objects: Vec<RawParams>,
    /// Per pair: its edited parameter keys.
    pub pairs: Vec<RawParams>,
    /// Per object and articulation: its edited parameter keys.
    pub articulations: Vec<Vec<RawParams>>,
    /// Per object: a painted bulge map (η per vertex, §5.5.1), over the scene's.
    pub painted: Vec<Option<Vec<f64>>>,
}

/// The loaded scene and the page's edits.
pub struct Session {
    pub scene: Scene,
    /// The folder the server may read and write in: the scene file's.
    pub folder: PathBuf,
    pub edits: Edits,
    /// Per object, its articulations as the scene evaluates them: name and whether
    /// `self_contact = "auto"` found it (fixed for the scene).
    pub articulations: Vec<Vec<(String, bool)>>,
    /// Per object read from a glTF node, its base-colour texture (for the page's view).
    pub textures: Vec<Option<squish_io::GltfImage>>,
}

/// A frame computed for the page.
pub struct Computed {
    pub shot: OwnedFrame,
    pub result: FrameResult,
    pub objects: Vec<ObjectQuality>,
    pub pairs: Vec<PairQuality>,
}

impl Session {
    pub fn new(scene: Scene, folder: PathBuf) -> Self {
        let objects = scene.description().objects.len();
        let pairs = scene.description().pairs.len();
        let frame = *scene.frames().start();
        let articulations: Vec<Vec<(String, bool)>> = match scene.evaluate(frame as f64) {
            Ok(spec) => spec
                .objects
                .iter()
                .map(|o| o.params.self_contact.iter().map(|a| (a.name.clone(), a.automatic)).collect())
                .collect(),
            Err(_) => vec![Vec::new(); objects],
        };
        let edits = Edits {
            frame,
            objects: vec![RawParams::new(); objects],
            pairs: vec![RawParams::new(); pairs],
            articulations: articulations.iter().map(|a| vec![RawParams::new(); a.len()]).collect(),
            painted: vec![None; objects],
        };
        let textures = (0..objects)
            .map(|i| {
                let pose = scene.gltf_pose(i, frame as f64)?;
                let file = scene.description().objects[i].mesh.file();
                // A texture that cannot be read leaves the object untextured, with a note.
                squish_io::base_color_image(file, pose.node)
                    .map_err(|e| eprintln!("note: {e}; the object is drawn without its texture"))
                    .ok()
                    .flatten()
            })
            .collect();
        Self { scene, folder, edits, articulations, textures }
    }

    /// The frame `edits` ask for: the scene's frame with every edit applied. Errors name the
    /// object or pair and the key.
    pub fn frame(&self, edits: &Edits) -> Result<OwnedFrame, String> {
        let range = self.scene.frames();
        if !range.contains(&edits.frame) {
            return Err(format!(
                "frame {} is outside the scene's frames {}–{}",
                edits.frame,
                range.start(),
                range.end()
            ));
        }
        let mut spec = self.scene.evaluate(edits.frame as f64).map_err(|e| e.to_string())?;
        let at = edits.frame as f64;
        for (i, object) in spec.objects.iter_mut().enumerate() {
            let raw = edits.objects.get(i).cloned().unwrap_or_default();
            apply::<ObjectParams>(&mut object.params, &raw, at)
                .map_err(|m| format!("object \"{}\": {m}", object.name))?;
            if let Some(Some(map)) = edits.painted.get(i) {
                object.params.bulge_map = Some(map.clone());
            }
            for (k, articulation) in object.params.self_contact.iter_mut().enumerate() {
                let Some(raw) = edits.articulations.get(i).and_then(|a| a.get(k)) else { continue };
                apply::<ArticulationParams>(&mut articulation.params, raw, at)
                    .map_err(|m| format!("object \"{}\", articulation \"{}\": {m}", object.name, articulation.name))?;
            }
        }
        for i in 0..spec.pairs.len() {
            let raw = edits.pairs.get(i).cloned().unwrap_or_default();
            let [a, b] = spec.pair_names(&spec.pairs[i]).map(str::to_string);
            apply::<PairParams>(&mut spec.pairs[i].params, &raw, at)
                .map_err(|m| format!("pair (\"{a}\", \"{b}\"): {m}"))?;
            // A pair switched to the shared parametrization here reads its objects' UVs now.
            if spec.pairs[i].params.mapping == MappingMethod::SharedParametrization {
                for object in spec.pairs[i].objects {
                    if spec.objects[object].params.uvs.is_none() {
                        let uvs = self.scene.object_uvs(object).map_err(|e| e.to_string())?;
                        spec.objects[object].params.uvs = Some((*uvs).clone());
                    }
                }
            }
        }
        Ok(spec)
    }

    /// Sets `key` of `target` to `value` at the current frame: the constant value, or with
    /// `keyframe`, a key at the current frame (a constant becomes a curve of that one key).
    /// Checked at once: on error nothing changes.
    pub fn set(&mut self, target: Target, key: &str, value: &ParamValue, keyframe: bool) -> Result<(), String> {
        let frame = self.edits.frame;
        let scene_value = self.scene_value(target, key);
        let table = self.table(target)?;
        let mut raw = table.clone();
        let written = toml_value(value);
        let new = if keyframe {
            // A key joins the curve edited so far, or the scene file's.
            let curve = raw.get(key).cloned().or(scene_value);
            let mut keys: Vec<Value> = match curve.as_ref().and_then(|v| v.get("keys")).and_then(Value::as_array) {
                Some(keys) => keys.clone(),
                None => Vec::new(),
            };
            keys.retain(|k| {
                k.as_array().and_then(|k| k.first()).and_then(Value::as_float_or_int) != Some(frame as f64)
            });
            keys.push(Value::Array(vec![Value::Integer(frame), written]));
            keys.sort_by(|a, b| {
                let at = |k: &Value| k.as_array().and_then(|k| k.first()).and_then(Value::as_float_or_int);
                at(a).unwrap_or(0.0).total_cmp(&at(b).unwrap_or(0.0))
            });
            let mut table = curve.and_then(|c| c.as_table().cloned()).unwrap_or_default();
            table.insert("keys".into(), Value::Array(keys));
            Value::Table(table)
        } else {
            written
        };
        raw.insert(key.to_string(), new);
        match target {
            Target::Object(_) => check::<ObjectParams>(&raw, ObjectSpec::TABLE_KEYS)?,
            Target::Pair(_) => check::<PairParams>(&raw, PairSpec::TABLE_KEYS)?,
            Target::Articulation(_) => check::<ArticulationParams>(&raw, &[])?,
        }
        *self.table(target)? = raw;
        Ok(())
    }

    /// Removes the key of `key` at the current frame (the last key removed: back to the scene
    /// file's value). Keys the scene file set are edited the same way: the edit starts from them.
    pub fn unkey(&mut self, target: Target, key: &str) -> Result<(), String> {
        let frame = self.edits.frame as f64;
        let scene_value = self.scene_value(target, key);
        let table = self.table(target)?;
        let Some(raw) = table.get(key).cloned().or(scene_value) else {
            return Err(format!("{key} has no key at frame {frame}"));
        };
        let Some(mut keys) = raw.get("keys").and_then(Value::as_array).cloned() else {
            return Err(format!("{key} has no key at frame {frame}"));
        };
        let before = keys.len();
        keys.retain(|k| k.as_array().and_then(|k| k.first()).and_then(Value::as_float_or_int) != Some(frame));
        if keys.len() == before {
            return Err(format!("{key} has no key at frame {frame}"));
        }
        if keys.is_empty() {
            table.remove(key);
        } else {
            let mut edited = raw.as_table().cloned().unwrap_or_default();
            edited.insert("keys".into(), Value::Array(keys));
            table.insert(key.to_string(), Value::Table(edited));
        }
        Ok(())
    }

    /// Back to the scene file's value of `key` (its default when the file does not set it).
    pub fn revert(&mut self, target: Target, key: &str) -> Result<(), String> {
        self.table(target)?.remove(key);
        Ok(())
    }

    /// The scene file's value of `key` (as written), if it sets it.
    fn scene_value(&self, target: Target, key: &str) -> Option<Value> {
        let description = self.scene.description();
        match target {
            Target::Object(i) => description.objects.get(i).and_then(|o| o.params.get(key)).cloned(),
            Target::Pair(i) => description.pairs.get(i).and_then(|p| p.params.get(key)).cloned(),
            Target::Articulation([i, k]) => self.scene_articulation(i, k).and_then(|raw| raw.get(key)).cloned(),
        }
    }

    /// The scene file's table of articulation `k` of object `i`: its `[[objects.self_contact]]`
    /// entry's parameters, or for an automatic one its `[objects.articulations."name"]` table.
    fn scene_articulation(&self, i: usize, k: usize) -> Option<&RawParams> {
        let object = self.scene.description().objects.get(i)?;
        let (name, automatic) = self.articulations.get(i)?.get(k)?;
        if *automatic { object.articulations.get(name) } else { object.self_contact.get(k).map(|e| &e.params) }
    }

    fn table(&mut self, target: Target) -> Result<&mut RawParams, String> {
        let (tables, i, what) = match target {
            Target::Object(i) => (&mut self.edits.objects, i, "object"),
            Target::Pair(i) => (&mut self.edits.pairs, i, "pair"),
            Target::Articulation([i, k]) => {
                let objects = self.edits.articulations.len();
                let list = self
                    .edits
                    .articulations
                    .get_mut(i)
                    .ok_or_else(|| format!("no object {i}: the scene has {objects}"))?;
                let count = list.len();
                return list.get_mut(k).ok_or_else(|| format!("no articulation {k} of object {i}: it has {count}"));
            }
        };
        let count = tables.len();
        tables.get_mut(i).ok_or_else(|| format!("no {what} {i}: the scene has {count}"))
    }

    /// The edits' value of every key of every articulation as the page shows it, per object.
    pub fn articulation_values(&self, frame: &OwnedFrame) -> Vec<Vec<ShownValues>> {
        frame
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| {
                o.params
                    .self_contact
                    .iter()
                    .enumerate()
                    .map(|(k, a)| {
                        shown(
                            &a.params,
                            self.scene_articulation(i, k),
                            self.edits.articulations.get(i).and_then(|e| e.get(k)),
                        )
                    })
                    .collect()
            })
            .collect()
    }

    /// The edits' value of every key as the page shows it: per object and pair, key → the
    /// value at the current frame and the frames of its keys (none for a constant).
    pub fn values(&self, frame: &OwnedFrame) -> (Vec<ShownValues>, Vec<ShownValues>) {
        let objects = frame
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| {
                let scene = self.scene.description().objects.get(i).map(|s| &s.params);
                shown(&o.params, scene, self.edits.objects.get(i))
            })
            .collect();
        let pairs = frame
            .pairs
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let scene = self.scene.description().pairs.get(i).map(|s| &s.params);
                shown(&p.params, scene, self.edits.pairs.get(i))
            })
            .collect();
        (objects, pairs)
    }
}

/// Every parameter of one object or pair as the page shows it, by key.
pub type ShownValues = BTreeMap<String, ShownValue>;

/// A parameter's value as the page shows it.
#[derive(Clone, Debug, Serialize)]
pub struct ShownValue {
    pub value: ParamValue,
    /// The frames of its keys (empty for a constant).
    pub keys: Vec<f64>,
    /// True if the page changed it (from the scene file's).
    pub edited: bool,
}

fn shown<P: Params>(params: &P, scene: Option<&RawParams>, edits: Option<&RawParams>) -> ShownValues {
    P::schema()
        .iter()
        .filter_map(|info| {
            let value = params.get(info.key)?;
            // Per-vertex values are shown as the overlay, not as a control.
            if matches!(value, ParamValue::List(ref xs) if xs.len() > 3) {
                return None;
            }
            let edited = edits.and_then(|e| e.get(info.key));
            let raw = edited.or_else(|| scene.and_then(|s| s.get(info.key)));
            let keys = raw.and_then(key_frames).unwrap_or_default();
            Some((info.key.to_string(), ShownValue { value, keys, edited: edited.is_some() }))
        })
        .collect()
}

/// The frames of a keyframed value (`{ keys = [[frame, value], …] }`).
fn key_frames(raw: &Value) -> Option<Vec<f64>> {
    let keys = raw.get("keys")?.as_array()?;
    Some(keys.iter().filter_map(|k| k.as_array()?.first()?.as_float_or_int()).collect())
}

trait FloatOrInt {
    fn as_float_or_int(&self) -> Option<f64>;
}

impl FloatOrInt for Value {
    fn as_float_or_int(&self) -> Option<f64> {
        self.as_float().or_else(|| self.as_integer().map(|i| i as f64))
    }
}

/// Reads `raw` as the scene layer does (kinds, ranges at every key, keyframability).
fn check<P: Params>(raw: &RawParams, table_keys: &[&str]) -> Result<(), String> {
    ParamTracks::<P>::parse(raw, table_keys, |_, v| param_value(v).map(Some))
        .map(|_| ())
        .map_err(|e| format!("{}: {}", e.key, e.message))
}

/// Sets every key of `raw` at `frame` on `params`, then checks the conditions between them.
fn apply<P: Params>(params: &mut P, raw: &RawParams, frame: f64) -> Result<(), String> {
    if raw.is_empty() {
        return Ok(());
    }
    let tracks = ParamTracks::<P>::parse(raw, &[], |_, v| param_value(v).map(Some))
        .map_err(|e| format!("{}: {}", e.key, e.message))?;
    for key in raw.keys() {
        if let Some(track) = tracks.get(key) {
            params.set(key, &track.at(frame)).map_err(|e| e.to_string())?;
        }
    }
    params.validate().map_err(|e| e.to_string())
}

/// Computes `frame` on `deformer` and measures it.
pub fn compute(deformer: &mut Deformer, shot: OwnedFrame) -> Result<Computed, String> {
    let frame = shot.frame();
    let result = deformer.deform(&frame).map_err(|e| e.to_string())?;
    let (objects, pairs) = frame_quality::measure(&frame, &result);
    drop(frame);
    Ok(Computed { shot, result, objects, pairs })
}

/// A brush stroke on a bulge map (§5.5.1): the operation's magnitude is 1 at the brush's middle
/// and fades smoothly (C¹) to 0 at its edge. The local brush acts within `radius` of `center`
/// ((1 − (d/r)²)²); the radial brush along the profiles of the deformation, from ∂𝒞 to ∂𝒟, over
/// an arc of ±`radius` of the isoline of u through `center` ((1 − (2ν − 1)²)²,
/// [`squish::deform::radial_brush`]).
#[derive(Clone, Copy, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stroke {
    /// `local` when absent (the format before the radial brush).
    #[serde(default)]
    pub kind: BrushKind,
    pub center: [f64; 3],
    pub radius: f64,
    pub operation: BrushOperation,
    /// The value set, added or subtracted (for `smooth`: how much of the neighbours' mean).
    pub strength: f64,
}

/// The thesis' two brushes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BrushKind {
    #[default]
    Local,
    Radial,
}

/// What a brush does to η (the thesis' set, add, subtract and smooth).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BrushOperation {
    Set,
    Add,
    Subtract,
    Smooth,
}

/// Largest η a brush paints (the map scales the bulge; beyond this it only makes spikes).
pub const MAX_PAINTED_ETA: f64 = 10.0;

/// The fields of a computed frame the radial brush follows, per object (`None`: not deformed).
#[derive(Clone, Debug, Default)]
pub struct BrushFrame {
    /// The frame they were computed at.
    pub frame: i64,
    pub objects: Vec<Option<ObjectBrushFields>>,
}

/// One object's radial parameter u, contact zone and deformable region, per vertex.
#[derive(Clone, Debug)]
pub struct ObjectBrushFields {
    pub u: Vec<f64>,
    pub contact: Vec<bool>,
    pub deformable: Vec<bool>,
}

impl BrushFrame {
    pub fn of(computed: &Computed, frame: i64) -> Self {
        let objects = computed
            .result
            .deformations
            .iter()
            .map(|d| {
                d.as_ref().map(|d| ObjectBrushFields {
                    u: d.u.clone(),
                    contact: d.contact.clone(),
                    deformable: d.deformable.clone(),
                })
            })
            .collect();
        Self { frame, objects }
    }
}

impl Stroke {
    pub fn check(&self) -> Result<(), String> {
        if !self.center.iter().all(|x| x.is_finite()) {
            return Err("paint: center must be three finite numbers".into());
        }
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return Err(format!("paint: radius = {} must be a positive number", self.radius));
        }
        if !(self.strength.is_finite() && (0.0..=MAX_PAINTED_ETA).contains(&self.strength)) {
            return Err(format!("paint: strength = {} must be in [0, {MAX_PAINTED_ETA}]", self.strength));
        }
        Ok(())
    }

    /// The brush's magnitude per vertex of `mesh` (the object at this frame's input positions);
    /// the radial brush needs the object's `fields` at this frame.
    pub fn magnitudes(&self, mesh: &TriMesh, fields: Option<&ObjectBrushFields>) -> Result<Vec<f64>, String> {
        let center = DVec3::from_array(self.center);
        match self.kind {
            BrushKind::Local => Ok(mesh
                .positions
                .iter()
                .map(|p| {
                    let t = p.distance_squared(center) / (self.radius * self.radius);
                    if t < 1.0 { (1.0 - t) * (1.0 - t) } else { 0.0 }
                })
                .collect()),
            BrushKind::Radial => {
                let fields = fields.ok_or(
                    "radial brush: the object has no deformable region at this frame (no contact); paint at a frame with contact or use the local brush",
                )?;
                let topology = squish::mesh::Topology::new(mesh);
                let fields = squish::deform::BrushFields {
                    u: &fields.u,
                    contact: &fields.contact,
                    deformable: &fields.deformable,
                };
                squish::deform::radial_brush(mesh, &topology, &fields, center, self.radius)
                    .map(|s| s.weights)
                    .map_err(|e| e.to_string())
            }
        }
    }

    /// Paints `map` (η per vertex) with the brush's `magnitudes` per vertex.
    pub fn paint(&self, mesh: &TriMesh, magnitudes: &[f64], map: &mut [f64]) {
        let mean = (self.operation == BrushOperation::Smooth).then(|| neighbour_means(mesh, map));
        for (v, (&w, eta)) in magnitudes.iter().zip(map.iter_mut()).enumerate() {
            if w == 0.0 {
                continue;
            }
            let painted = match self.operation {
                BrushOperation::Set => *eta + w * (self.strength - *eta),
                BrushOperation::Add => *eta + w * self.strength,
                BrushOperation::Subtract => *eta - w * self.strength,
                BrushOperation::Smooth => {
                    let m = mean.as_ref().map_or(*eta, |m| m[v]);
                    *eta + w * self.strength.min(1.0) * (m - *eta)
                }
            };
            *eta = painted.clamp(0.0, MAX_PAINTED_ETA);
        }
    }
}

/// The mean of each vertex's neighbours' values.
fn neighbour_means(mesh: &TriMesh, values: &[f64]) -> Vec<f64> {
    let mut sum = vec![0.0; values.len()];
    let mut count = vec![0u32; values.len()];
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            if a < values.len() && b < values.len() {
                sum[a] += values[b];
                sum[b] += values[a];
                count[a] += 1;
                count[b] += 1;
            }
        }
    }
    sum.iter().zip(&count).zip(values).map(|((s, &c), &v)| if c == 0 { v } else { s / f64::from(c) }).collect()
}

/// `path` made relative to `folder` when inside it (for a scene file that moves with its folder).
pub fn relative_to(path: &Path, folder: &Path) -> PathBuf {
    path.strip_prefix(folder).map(Path::to_path_buf).unwrap_or_else(|_| path.to_path_buf())
}
