//! The scene description: what the scene file says, as typed values with every default filled
//! in and every path resolved (see `docs/scene-format.md` for the file format).
//!
//! Each type reads the spellings a person writes (a bare number or a table, `"auto"` or a
//! vector …) and writes one canonical form that reads back to the same value, so that a
//! resolved scene can be dumped as JSON, inspected, and loaded again. Unknown keys are errors
//! everywhere (`deny_unknown_fields`), so that a typo never silently falls back to a default.

use std::fmt;
use std::path::PathBuf;

use glam::DVec3;
use serde::de::{self, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use squish::animation::{KeyValue, Keyframed};

use super::diagnostics::did_you_mean;

/// A whole scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDescription {
    /// The frames of the shot.
    pub frames: FrameRange,
    /// Where and how results are written.
    #[serde(default)]
    pub output: OutputSpec,
    /// The meshes (`[[objects]]`).
    #[serde(default)]
    pub objects: Vec<ObjectSpec>,
    /// Which objects collide (`[[pairs]]`).
    #[serde(default)]
    pub pairs: Vec<PairSpec>,
}

/// `frames = { start = 1, end = 48, fps = 24 }`: an inclusive range of whole frames.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameRange {
    pub start: i64,
    /// Inclusive.
    pub end: i64,
    /// Frames per second, to turn frames into glTF animation time. Default 24.
    #[serde(default = "default_fps")]
    pub fps: f64,
}

fn default_fps() -> f64 {
    24.0
}

impl FrameRange {
    /// Number of frames.
    pub fn len(&self) -> usize {
        // In i128: `end − start + 1` of two i64 can overflow i64.
        usize::try_from(self.end as i128 - self.start as i128 + 1).unwrap_or(if self.is_empty() {
            0
        } else {
            usize::MAX
        })
    }

    /// True if the range holds no frame (`end < start`, rejected when a scene loads).
    pub fn is_empty(&self) -> bool {
        self.end < self.start
    }

    /// True if `frame` (possibly fractional) lies within `[start, end]`.
    pub fn contains(&self, frame: f64) -> bool {
        frame >= self.start as f64 && frame <= self.end as f64
    }
}

/// `output = { dir = "out", format = "obj" }`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Output folder (relative to the scene file's folder when read). Default `out`.
    #[serde(default = "default_output_dir")]
    pub dir: PathBuf,
    /// Default `obj`.
    #[serde(default)]
    pub format: OutputFormat,
}

fn default_output_dir() -> PathBuf {
    PathBuf::from("out")
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self { dir: default_output_dir(), format: OutputFormat::default() }
    }
}

/// The format of the results.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OutputFormat {
    /// One `.obj` per object and frame.
    #[default]
    Obj,
    /// One binary `.ply` per object and frame.
    Ply,
    /// One animated `.glb` per object (all frames).
    Glb,
}

impl OutputFormat {
    /// The file extension.
    pub fn extension(self) -> &'static str {
        match self {
            Self::Obj => "obj",
            Self::Ply => "ply",
            Self::Glb => "glb",
        }
    }

    /// True if every frame is a file of its own (OBJ, PLY); false for one animated file per
    /// object (GLB).
    pub fn per_frame(self) -> bool {
        !matches!(self, Self::Glb)
    }
}

/// An `[[objects]]` entry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// Unique; used in output paths.
    pub name: String,
    /// Where the mesh of each frame comes from.
    pub mesh: MeshSource,
    /// A rigid object is never deformed (it deforms the other object of its pairs).
    #[serde(default)]
    pub rigid: bool,
    /// Relative stiffness k̄ (> 0): the stiffer object of a pair deforms less. Default 1.
    #[serde(default = "one")]
    pub stiffness: Keyframed<f64>,
    /// Extent of the deformation φ_max (> 0, scene units). `None`: automatic.
    #[serde(default)]
    pub extent: Option<Keyframed<f64>>,
    /// Bulge factor γ: 0 no bulge, 1 volume preserved, > 1 exaggerated. Default 1.
    #[serde(default = "one")]
    pub bulge: Keyframed<f64>,
    /// Bulge height used when volume preservation is off (open meshes). Default 0.
    #[serde(default)]
    pub bulge_height: Keyframed<f64>,
    /// Whether the bulge preserves the enclosed volume. Default `auto` (closed meshes only).
    #[serde(default)]
    pub preserve_volume: PreserveVolume,
    /// Abscissas of the profile curve's control points v2, v3, v4, and wrinkles.
    #[serde(default)]
    pub profile: Profile,
    /// Procedural anisotropic bulge map (thesis §5.5.2). Default off.
    #[serde(default)]
    pub anisotropy: Anisotropy,
    /// Painted bulge map η, one value per vertex. `None`: uniform.
    #[serde(default)]
    pub bulge_map: Option<VertexData>,
    /// The part of the mesh that may deform. Default the whole mesh.
    #[serde(default)]
    pub region: Region,
    /// Placement applied to the mesh of every frame (after glTF posing).
    #[serde(default)]
    pub transform: Transform,
    /// Articulations whose two sides may fold onto each other (`[[objects.self_contact]]`,
    /// thesis ch. 6), resolved before the pairs. Default none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub self_contact: Vec<SelfContactSpec>,
}

/// An `[[objects.self_contact]]` entry: one articulation of the object (a knee, an elbow, lips)
/// whose two sides, region 1 (parent side) and region 2 (child side), may fold onto each other.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelfContactSpec {
    /// Unique within the object; names the articulation in messages and reports.
    pub name: String,
    /// Two consecutive joints of the object's skin, by glTF node name: the parent joint (whose
    /// bone is region 1) and its child, the articulation (whose bone and descendants are
    /// region 2). Exactly one of `joints` and `masks`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joints: Option<[String; 2]>,
    /// The two regions as per-vertex masks (values ≥ 0.5 select a vertex).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub masks: Option<[VertexData; 2]>,
    /// With `joints`: the skinning weight from which a vertex belongs to a side, in (0, 1].
    /// `None`: [`DEFAULT_MIN_WEIGHT`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_weight: Option<f64>,
    /// The mapping direction d̂: from the joints' positions at each frame (default), or given.
    #[serde(default)]
    pub direction: SelfContactDirection,
    /// τ of the contact criterion. Default −1 (the thesis' value for skinning).
    #[serde(default = "minus_one")]
    pub contact_tau: Keyframed<f64>,
    /// Pseudo-stiffnesses k₁, k₂ of the two sides (a number gives both). Default 1, 1.
    #[serde(default)]
    pub stiffness: Keyframed<StiffnessPair>,
    /// φ_max (> 0, scene units). `None`: automatic.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extent: Option<Keyframed<f64>>,
    /// Weight (≥ 0) of the regional term of the crease cut's energy. Default 1.
    #[serde(default = "one")]
    pub cut_regional_weight: Keyframed<f64>,
    /// Angle (degrees, in (0, 90]) beyond which a point cannot be in contact. Default 80.
    #[serde(default = "eighty")]
    pub safeguard_angle: Keyframed<f64>,
    /// Distance (≥ 0, scene units) left between the two sides where they touch. `None`:
    /// automatic.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_gap: Option<Keyframed<f64>>,
}

/// Default of [`SelfContactSpec::min_weight`].
pub const DEFAULT_MIN_WEIGHT: f64 = 0.05;

fn minus_one() -> Keyframed<f64> {
    Keyframed::constant(-1.0)
}

fn eighty() -> Keyframed<f64> {
    Keyframed::constant(80.0)
}

/// `direction = "joints" | [x, y, z] | keys of [x, y, z]` of an articulation.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum SelfContactDirection {
    /// From the world positions of the parent joint, the joint, and the end of the child bone
    /// at each frame (see `docs/scene-format.md`).
    #[default]
    Joints,
    /// Given, from region 1 toward region 2 (normalized at each frame; must not vanish).
    Fixed(Keyframed<DVec3>),
}

impl Serialize for SelfContactDirection {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Joints => s.serialize_str("joints"),
            Self::Fixed(k) => k.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for SelfContactDirection {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = SelfContactDirection;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"joints\", a vector [x, y, z], or keys [[frame, [x, y, z]], …]")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<SelfContactDirection, E> {
                match v {
                    "joints" => Ok(SelfContactDirection::Joints),
                    _ => Err(unknown_word(v, &["joints"], "\"joints\" or a vector [x, y, z]")),
                }
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<SelfContactDirection, A::Error> {
                Ok(SelfContactDirection::Fixed(Keyframed::deserialize(de::value::SeqAccessDeserializer::new(seq))?))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<SelfContactDirection, A::Error> {
                Ok(SelfContactDirection::Fixed(Keyframed::deserialize(de::value::MapAccessDeserializer::new(map))?))
            }
        }
        d.deserialize_any(V)
    }
}

/// The pseudo-stiffnesses `[k1, k2]` of an articulation's two sides; reads from a number (both
/// sides) or `[k1, k2]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StiffnessPair(pub [f64; 2]);

impl Default for StiffnessPair {
    fn default() -> Self {
        Self([1.0, 1.0])
    }
}

impl KeyValue for StiffnessPair {
    const COMPONENTS: usize = 2;
    const DESCRIPTION: &'static str = "a stiffness (a number, or [k1, k2] for the two sides)";
    fn component(&self, i: usize) -> f64 {
        self.0[i]
    }
    fn from_components(mut f: impl FnMut(usize) -> f64) -> Self {
        Self([f(0), f(1)])
    }
}

impl Serialize for StiffnessPair {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.0.serialize(s)
    }
}

impl<'de> Deserialize<'de> for StiffnessPair {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = StiffnessPair;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or [k1, k2]")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<StiffnessPair, E> {
                Ok(StiffnessPair([v as f64; 2]))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<StiffnessPair, E> {
                Ok(StiffnessPair([v as f64; 2]))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<StiffnessPair, E> {
                Ok(StiffnessPair([v; 2]))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<StiffnessPair, A::Error> {
                let k = <[f64; 2]>::deserialize(de::value::SeqAccessDeserializer::new(seq))?;
                Ok(StiffnessPair(k))
            }
        }
        d.deserialize_any(V)
    }
}

fn one() -> Keyframed<f64> {
    Keyframed::constant(1.0)
}

/// Where an object's mesh comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshSource {
    /// One `.obj` / `.ply` for every frame.
    File { file: PathBuf, weld: Weld },
    /// One file per frame: a path with `{frame}` or `{frame:0N}` in it.
    Sequence { pattern: PathBuf, weld: Weld },
    /// A `.glb` / `.gltf` node, posed per frame by its animation (skinning and morph targets).
    Gltf(GltfSource),
}

impl MeshSource {
    /// The file (for a sequence: the pattern).
    pub fn file(&self) -> &PathBuf {
        match self {
            Self::File { file, .. } | Self::Sequence { pattern: file, .. } => file,
            Self::Gltf(g) => &g.file,
        }
    }

    /// The welding of the mesh's vertices.
    pub fn weld(&self) -> Weld {
        match self {
            Self::File { weld, .. } | Self::Sequence { weld, .. } => *weld,
            Self::Gltf(g) => g.weld,
        }
    }

    pub(crate) fn file_mut(&mut self) -> &mut PathBuf {
        match self {
            Self::File { file, .. } | Self::Sequence { pattern: file, .. } => file,
            Self::Gltf(g) => &mut g.file,
        }
    }
}

/// A glTF mesh source.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GltfSource {
    pub file: PathBuf,
    /// Name of the node instancing the mesh; `None` when the file has one mesh node.
    pub node: Option<String>,
    /// Name of the animation; `None`: the file's only animation, or the rest pose if it has
    /// none.
    pub animation: Option<String>,
    /// Default `true` for glTF (exporters split vertices along UV seams).
    pub weld: Weld,
    /// The scene frame at which animation time 0 plays; `None`: `frames.start`.
    pub start_frame: Option<f64>,
    /// Loop the animation (time modulo its duration). Default false: hold the last pose.
    pub repeat: bool,
}

/// Welding of a mesh's vertices by position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Weld {
    /// Keep the file's vertices.
    Off,
    /// Merge vertices with identical positions.
    Exact,
    /// Merge vertices closer than this distance.
    Within(f64),
}

impl Weld {
    /// The reader's welding mode.
    pub fn mode(self) -> crate::WeldMode {
        match self {
            Self::Off => crate::WeldMode::Off,
            Self::Exact => crate::WeldMode::Exact,
            Self::Within(d) => crate::WeldMode::Within(d),
        }
    }
}

impl Serialize for Weld {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Off => s.serialize_bool(false),
            Self::Exact => s.serialize_bool(true),
            Self::Within(d) => s.serialize_f64(*d),
        }
    }
}

impl<'de> Deserialize<'de> for Weld {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Weld;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("true, false, or a distance ≥ 0 under which vertices merge")
            }
            fn visit_bool<E: de::Error>(self, v: bool) -> Result<Weld, E> {
                Ok(if v { Weld::Exact } else { Weld::Off })
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Weld, E> {
                self.visit_f64(v as f64)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Weld, E> {
                self.visit_f64(v as f64)
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Weld, E> {
                if v.is_finite() && v >= 0.0 {
                    Ok(if v == 0.0 { Weld::Exact } else { Weld::Within(v) })
                } else {
                    Err(E::custom(format!("weld distance {v} must be a finite number ≥ 0")))
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// The table form of `mesh`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshTable {
    file: PathBuf,
    node: Option<String>,
    animation: Option<String>,
    weld: Option<Weld>,
    start_frame: Option<f64>,
    #[serde(default)]
    repeat: bool,
}

/// True if `path` names a glTF file.
fn is_gltf(path: &std::path::Path) -> bool {
    matches!(path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).as_deref(), Some("glb") | Some("gltf"))
}

impl MeshSource {
    fn from_table<E: de::Error>(t: MeshTable) -> Result<Self, E> {
        let text = t.file.to_string_lossy();
        let sequence = text.contains("{frame");
        if is_gltf(&t.file) {
            if sequence {
                return Err(E::custom("a glTF mesh cannot be a {frame} sequence; animate it inside the file"));
            }
            return Ok(Self::Gltf(GltfSource {
                file: t.file,
                node: t.node,
                animation: t.animation,
                weld: t.weld.unwrap_or(Weld::Exact),
                start_frame: t.start_frame,
                repeat: t.repeat,
            }));
        }
        let gltf_only = [
            ("node", t.node.is_some()),
            ("animation", t.animation.is_some()),
            ("start_frame", t.start_frame.is_some()),
            ("repeat", t.repeat),
        ];
        if let Some((key, _)) = gltf_only.iter().find(|(_, set)| *set) {
            return Err(E::custom(format!(
                "\"{key}\" only applies to .glb / .gltf meshes; remove it or point `file` at a glTF file"
            )));
        }
        let weld = t.weld.unwrap_or(Weld::Off);
        Ok(if sequence { Self::Sequence { pattern: t.file, weld } } else { Self::File { file: t.file, weld } })
    }
}

impl Serialize for MeshSource {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        match self {
            Self::File { file, weld } | Self::Sequence { pattern: file, weld } => {
                let mut m = s.serialize_map(Some(2))?;
                m.serialize_entry("file", file)?;
                m.serialize_entry("weld", weld)?;
                m.end()
            }
            Self::Gltf(g) => g.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for MeshSource {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = MeshSource;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a file name (\"ball.obj\", \"ball_{frame:04}.obj\", \"walk.glb\") or { file = …, node = …, animation = …, weld = … }")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<MeshSource, E> {
                MeshSource::from_table(MeshTable {
                    file: PathBuf::from(v),
                    node: None,
                    animation: None,
                    weld: None,
                    start_frame: None,
                    repeat: false,
                })
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<MeshSource, A::Error> {
                MeshSource::from_table(MeshTable::deserialize(de::value::MapAccessDeserializer::new(map))?)
            }
        }
        d.deserialize_any(V)
    }
}

/// `preserve_volume = "auto" | true | false`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PreserveVolume {
    /// On for closed meshes, off for open ones (decided from the geometry).
    #[default]
    Auto,
    On,
    Off,
}

impl Serialize for PreserveVolume {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Auto => s.serialize_str("auto"),
            Self::On => s.serialize_bool(true),
            Self::Off => s.serialize_bool(false),
        }
    }
}

impl<'de> Deserialize<'de> for PreserveVolume {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = PreserveVolume;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"auto\", true or false")
            }
            fn visit_bool<E: de::Error>(self, v: bool) -> Result<PreserveVolume, E> {
                Ok(if v { PreserveVolume::On } else { PreserveVolume::Off })
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<PreserveVolume, E> {
                match v {
                    "auto" => Ok(PreserveVolume::Auto),
                    "true" | "on" | "yes" => Ok(PreserveVolume::On),
                    "false" | "off" | "no" => Ok(PreserveVolume::Off),
                    _ => Err(unknown_word(v, &["auto"], "\"auto\", true or false")),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// An error for an unknown word, with a did-you-mean among `words`.
fn unknown_word<E: de::Error>(v: &str, words: &[&str], expected: &str) -> E {
    match did_you_mean(v, words) {
        Some(s) => E::custom(format!("unknown value \"{v}\"; use {expected} (did you mean \"{s}\"?)")),
        None => E::custom(format!("unknown value \"{v}\"; use {expected}")),
    }
}

/// The profile curve's editable abscissas (thesis Fig. 5.4: defaults 1/3, 5/6, 11/12) and an
/// added sinusoid for wrinkles (§7.3.1).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Profile {
    #[serde(default = "default_v2")]
    pub v2: Keyframed<f64>,
    #[serde(default = "default_v3")]
    pub v3: Keyframed<f64>,
    #[serde(default = "default_v4")]
    pub v4: Keyframed<f64>,
    #[serde(default)]
    pub wrinkle_amplitude: Keyframed<f64>,
    /// Wrinkles per unit of the radial parametrization u (≥ 0).
    #[serde(default)]
    pub wrinkle_frequency: Keyframed<f64>,
}

/// Default abscissa of v2.
pub const DEFAULT_V2: f64 = 1.0 / 3.0;
/// Default abscissa of v3.
pub const DEFAULT_V3: f64 = 5.0 / 6.0;
/// Default abscissa of v4.
pub const DEFAULT_V4: f64 = 11.0 / 12.0;

fn default_v2() -> Keyframed<f64> {
    Keyframed::constant(DEFAULT_V2)
}
fn default_v3() -> Keyframed<f64> {
    Keyframed::constant(DEFAULT_V3)
}
fn default_v4() -> Keyframed<f64> {
    Keyframed::constant(DEFAULT_V4)
}

impl Default for Profile {
    fn default() -> Self {
        Self {
            v2: default_v2(),
            v3: default_v3(),
            v4: default_v4(),
            wrinkle_amplitude: Keyframed::constant(0.0),
            wrinkle_frequency: Keyframed::constant(0.0),
        }
    }
}

/// The derived table form of [`Profile`] (the custom impl below adds the list form).
#[derive(Deserialize)]
#[serde(deny_unknown_fields, remote = "Profile")]
struct ProfileTable {
    #[serde(default = "default_v2")]
    v2: Keyframed<f64>,
    #[serde(default = "default_v3")]
    v3: Keyframed<f64>,
    #[serde(default = "default_v4")]
    v4: Keyframed<f64>,
    #[serde(default)]
    wrinkle_amplitude: Keyframed<f64>,
    #[serde(default)]
    wrinkle_frequency: Keyframed<f64>,
}

/// `anisotropy = true | false | [[frame, bool], …] | { enabled, exponent, offset }`: the
/// procedural bulge map of thesis Eq. 5.6, with ω = `exponent` and ψ = `offset`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Anisotropy {
    pub enabled: Keyframed<bool>,
    /// ω (> 0), default 2.
    pub exponent: Keyframed<f64>,
    /// ψ (> −1), default 0.
    pub offset: Keyframed<f64>,
}

impl Default for Anisotropy {
    fn default() -> Self {
        Self { enabled: Keyframed::constant(false), exponent: default_exponent(), offset: Keyframed::constant(0.0) }
    }
}

fn default_exponent() -> Keyframed<f64> {
    Keyframed::constant(2.0)
}

fn enabled() -> Keyframed<bool> {
    Keyframed::constant(true)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AnisotropyTable {
    #[serde(default = "enabled")]
    enabled: Keyframed<bool>,
    #[serde(default = "default_exponent")]
    exponent: Keyframed<f64>,
    #[serde(default)]
    offset: Keyframed<f64>,
}

impl<'de> Deserialize<'de> for Anisotropy {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Anisotropy;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("true, false, [[frame, true/false], …] or { exponent = 2.0, offset = 0.0 }")
            }
            fn visit_bool<E: de::Error>(self, v: bool) -> Result<Anisotropy, E> {
                Ok(Anisotropy { enabled: Keyframed::constant(v), ..Anisotropy::default() })
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Anisotropy, A::Error> {
                let enabled = Keyframed::<bool>::deserialize(de::value::SeqAccessDeserializer::new(seq))?;
                Ok(Anisotropy { enabled, ..Anisotropy::default() })
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Anisotropy, A::Error> {
                let t = AnisotropyTable::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(Anisotropy { enabled: t.enabled, exponent: t.exponent, offset: t.offset })
            }
        }
        d.deserialize_any(V)
    }
}

impl<'de> Deserialize<'de> for Profile {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Profile;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("[v2, v3, v4] (three abscissas) or { v2 = …, v3 = …, v4 = …, wrinkle_amplitude = …, wrinkle_frequency = … }")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Profile, A::Error> {
                let mut v: Vec<Keyframed<f64>> = Vec::new();
                while let Some(x) = seq.next_element()? {
                    v.push(x);
                }
                let [v2, v3, v4]: [Keyframed<f64>; 3] = v.try_into().map_err(|v: Vec<_>| {
                    de::Error::custom(format!(
                        "profile takes three abscissas [v2, v3, v4] (each a number or [[frame, value], …]), not {}",
                        v.len()
                    ))
                })?;
                Ok(Profile { v2, v3, v4, ..Profile::default() })
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Profile, A::Error> {
                ProfileTable::deserialize(de::value::MapAccessDeserializer::new(map))
            }
        }
        d.deserialize_any(V)
    }
}

/// Per-vertex values: a text file with one number per line, or a vertex attribute of a PLY or
/// glTF file (`file` absent: the object's own mesh file).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum VertexData {
    Text { file: PathBuf },
    Attribute { file: Option<PathBuf>, attribute: String },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct VertexDataTable {
    file: Option<PathBuf>,
    attribute: Option<String>,
}

impl VertexData {
    /// The file named, if any.
    pub fn file(&self) -> Option<&PathBuf> {
        match self {
            Self::Text { file } => Some(file),
            Self::Attribute { file, .. } => file.as_ref(),
        }
    }

    pub(crate) fn file_mut(&mut self) -> Option<&mut PathBuf> {
        match self {
            Self::Text { file } => Some(file),
            Self::Attribute { file, .. } => file.as_mut(),
        }
    }
}

impl<'de> Deserialize<'de> for VertexData {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = VertexData;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a text file with one number per vertex (\"map.txt\") or { file = \"mesh.ply\", attribute = \"name\" }")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<VertexData, E> {
                let file = PathBuf::from(v);
                let ext = file.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
                if matches!(ext.as_deref(), Some("ply" | "glb" | "gltf" | "obj")) {
                    return Err(E::custom(format!(
                        "\"{v}\" is a mesh file: name the vertex attribute to read, {{ file = \"{v}\", attribute = \"…\" }}"
                    )));
                }
                Ok(VertexData::Text { file })
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<VertexData, A::Error> {
                let t = VertexDataTable::deserialize(de::value::MapAccessDeserializer::new(map))?;
                match (t.file, t.attribute) {
                    (file, Some(attribute)) => Ok(VertexData::Attribute { file, attribute }),
                    (Some(file), None) => Ok(VertexData::Text { file }),
                    (None, None) => Err(de::Error::custom("give `file` (a text file), `attribute`, or both")),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// The part of an object that may deform (the working region 𝒲).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Region {
    /// The whole mesh.
    #[default]
    Whole,
    /// The vertices whose mask value is ≥ 0.5.
    Mask(VertexData),
    /// An automatic band: the vertices within this distance of the intersection (> 0).
    Distance(Keyframed<f64>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RegionTable {
    mask: Option<VertexData>,
    mask_attribute: Option<String>,
    distance: Option<Keyframed<f64>>,
}

impl<'de> Deserialize<'de> for Region {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Region;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"whole\", { mask = \"mask.txt\" }, { mask_attribute = \"name\" } or { distance = 0.5 }")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Region, E> {
                match v {
                    "whole" => Ok(Region::Whole),
                    _ => Err(unknown_word(
                        v,
                        &["whole"],
                        "\"whole\", { mask = \"mask.txt\" }, { mask_attribute = \"name\" } or { distance = 0.5 }",
                    )),
                }
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Region, A::Error> {
                let t = RegionTable::deserialize(de::value::MapAccessDeserializer::new(map))?;
                match (t.mask, t.mask_attribute, t.distance) {
                    (Some(mask), None, None) => Ok(Region::Mask(mask)),
                    (None, Some(attribute), None) => Ok(Region::Mask(VertexData::Attribute { file: None, attribute })),
                    (None, None, Some(d)) => Ok(Region::Distance(d)),
                    _ => Err(de::Error::custom("give exactly one of mask, mask_attribute or distance")),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// `transform = { translate, rotate, scale }`, each keyframable; applied as T·R·S.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Transform {
    #[serde(default)]
    pub translate: Keyframed<DVec3>,
    /// Axis and angle in degrees, `[x, y, z, degrees]`.
    #[serde(default)]
    pub rotate: Keyframed<AxisAngle>,
    /// Uniform (`2.0`) or per axis (`[sx, sy, sz]`).
    #[serde(default)]
    pub scale: Keyframed<Scale>,
}

impl Default for Transform {
    fn default() -> Self {
        Self {
            translate: Keyframed::constant(DVec3::ZERO),
            rotate: Keyframed::constant(AxisAngle::default()),
            scale: Keyframed::constant(Scale::default()),
        }
    }
}

impl Transform {
    /// True if the transform is the identity at every frame.
    pub fn is_identity(&self) -> bool {
        *self == Self::default()
    }
}

/// A rotation as `[x, y, z, degrees]`. Keys interpolate axis and angle per component (the axis
/// is normalized when used), so a key at 0° and one at 720° about the same axis spin twice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisAngle {
    pub axis: DVec3,
    pub degrees: f64,
}

impl Default for AxisAngle {
    fn default() -> Self {
        Self { axis: DVec3::Z, degrees: 0.0 }
    }
}

impl KeyValue for AxisAngle {
    const COMPONENTS: usize = 4;
    const DESCRIPTION: &'static str = "an axis and an angle in degrees [x, y, z, degrees]";
    fn component(&self, i: usize) -> f64 {
        if i < 3 { self.axis[i] } else { self.degrees }
    }
    fn from_components(mut f: impl FnMut(usize) -> f64) -> Self {
        Self { axis: DVec3::new(f(0), f(1), f(2)), degrees: f(3) }
    }
}

impl Serialize for AxisAngle {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        [self.axis.x, self.axis.y, self.axis.z, self.degrees].serialize(s)
    }
}

impl<'de> Deserialize<'de> for AxisAngle {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let [x, y, z, degrees] = <[f64; 4]>::deserialize(d)?;
        Ok(Self { axis: DVec3::new(x, y, z), degrees })
    }
}

/// A scale per axis; reads from a number (uniform) or `[sx, sy, sz]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale(pub DVec3);

impl Default for Scale {
    fn default() -> Self {
        Self(DVec3::ONE)
    }
}

impl KeyValue for Scale {
    const COMPONENTS: usize = 3;
    const DESCRIPTION: &'static str = "a scale (a number, or [sx, sy, sz])";
    fn component(&self, i: usize) -> f64 {
        self.0[i]
    }
    fn from_components(mut f: impl FnMut(usize) -> f64) -> Self {
        Self(DVec3::new(f(0), f(1), f(2)))
    }
}

impl Serialize for Scale {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.0.to_array().serialize(s)
    }
}

impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Scale;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or [sx, sy, sz]")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Scale, E> {
                Ok(Scale(DVec3::splat(v as f64)))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Scale, E> {
                Ok(Scale(DVec3::splat(v as f64)))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Scale, E> {
                Ok(Scale(DVec3::splat(v)))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Scale, A::Error> {
                let [x, y, z] = <[f64; 3]>::deserialize(de::value::SeqAccessDeserializer::new(seq))?;
                Ok(Scale(DVec3::new(x, y, z)))
            }
        }
        d.deserialize_any(V)
    }
}

/// A `[[pairs]]` entry: two objects that may collide.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairSpec {
    /// The names of the two objects.
    pub objects: [String; 2],
    /// Whether the pair is processed (keyframable, steps). Default true.
    #[serde(default = "enabled")]
    pub enabled: Keyframed<bool>,
    /// Apparent stiffness τ of the geometric contact criterion (Eq. 4.3). Default 0.
    #[serde(default)]
    pub contact_tau: Keyframed<f64>,
    /// Mapping direction d̂. Default automatic.
    #[serde(default)]
    pub direction: Direction,
    /// How the contact zone is found. Default geometric (method B).
    #[serde(default)]
    pub contact_method: ContactMethod,
}

/// `direction = "auto" | [x, y, z] | keys of [x, y, z]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Direction {
    /// Computed from the geometry at each frame (thesis §4.2.2).
    #[default]
    Auto,
    /// Given (normalized at each frame; must not vanish).
    Fixed(Keyframed<DVec3>),
}

impl Serialize for Direction {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Auto => s.serialize_str("auto"),
            Self::Fixed(k) => k.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for Direction {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Direction;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"auto\", a vector [x, y, z], or keys [[frame, [x, y, z]], …]")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Direction, E> {
                match v {
                    "auto" => Ok(Direction::Auto),
                    _ => Err(unknown_word(v, &["auto"], "\"auto\" or a vector [x, y, z]")),
                }
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Direction, A::Error> {
                Ok(Direction::Fixed(Keyframed::deserialize(de::value::SeqAccessDeserializer::new(seq))?))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Direction, A::Error> {
                Ok(Direction::Fixed(Keyframed::deserialize(de::value::MapAccessDeserializer::new(map))?))
            }
        }
        d.deserialize_any(V)
    }
}

/// `contact_method = "geometric" | { ball = radius }`.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum ContactMethod {
    /// Method B (thesis §4.4.2): symmetric, elastic–elastic or rigid–elastic.
    #[default]
    Geometric,
    /// Method A (§4.4.1): ball testing with this radius r_s (> 0); rigid–elastic only.
    Ball { radius: Keyframed<f64> },
}

impl Serialize for ContactMethod {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        match self {
            Self::Geometric => s.serialize_str("geometric"),
            Self::Ball { radius } => {
                let mut m = s.serialize_map(Some(1))?;
                m.serialize_entry("ball", radius)?;
                m.end()
            }
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BallTable {
    ball: Keyframed<f64>,
}

impl<'de> Deserialize<'de> for ContactMethod {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ContactMethod;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"geometric\" or { ball = radius }")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<ContactMethod, E> {
                match v {
                    "geometric" => Ok(ContactMethod::Geometric),
                    "ball" => Err(E::custom("the ball method needs its radius: contact_method = { ball = 0.3 }")),
                    _ => Err(unknown_word(v, &["geometric", "ball"], "\"geometric\" or { ball = radius }")),
                }
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<ContactMethod, A::Error> {
                let t = BallTable::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(ContactMethod::Ball { radius: t.ball })
            }
        }
        d.deserialize_any(V)
    }
}
