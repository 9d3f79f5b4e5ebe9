//! The scene description: what the scene file says, as typed values with every path resolved
//! (see `docs/scene-format.md` for the file format).
//!
//! The scene's own structure (frames, output, objects with their meshes, transforms and
//! articulations, pairs) is read by serde derives; the deformer's parameters in each table are
//! kept as written ([`RawParams`]) and read through the library's schema ([`super::tracks`]).
//! Values with several spellings (a file name or a table, `true` or a distance) read through
//! an untagged form whose catch-all variant turns anything else into a message that says what
//! to write. Every form writes back to one that reads again, so that a resolved scene can be
//! dumped as JSON, inspected, and loaded again. Unknown keys are errors everywhere, so that a
//! typo never silently falls back to a default.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize, Serializer};
use toml::Value;

use super::tracks::RawParams;
use super::transform::Transform;

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
    /// How preview pictures are taken (`preview = { camera, size, up }`). Default: framed on
    /// the contact, 640 × 480, the up axis from the files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preview: Option<PreviewSpec>,
}

/// `preview = { camera = { eye, target, up, fov }, size = [w, h], up = "y" }`: the pictures of
/// `squish run --preview`. Every key is optional; command-line options win over it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PreviewSpec {
    /// A fixed camera instead of the one framed on the contact.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<PreviewCamera>,
    /// Picture size in pixels, `[width, height]` (each 16 to 8192).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<[u32; 2]>,
    /// The world's up axis, `"y"` or `"z"`. Default: y when an object is read from glTF, else z.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<UpAxisName>,
}

/// A camera: where the eye is, what it looks at, which way is up, the vertical field of view.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PreviewCamera {
    pub eye: [f64; 3],
    pub target: [f64; 3],
    /// Default: the world's up axis.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<[f64; 3]>,
    /// Vertical field of view in degrees, in (0, 180). Default 35.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fov: Option<f64>,
}

/// An up axis by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum UpAxisName {
    Y,
    Z,
}

impl PreviewSpec {
    /// What is wrong with these values, if anything (a message naming the key).
    pub fn problem(&self) -> Option<String> {
        if let Some([w, h]) = self.size
            && !((16..=8192).contains(&w) && (16..=8192).contains(&h))
        {
            return Some(format!("preview.size [{w}, {h}]: each side must be 16 to 8192 pixels"));
        }
        let camera = self.camera?;
        let finite = |v: [f64; 3]| v.iter().all(|x| x.is_finite());
        if !finite(camera.eye) || !finite(camera.target) || camera.up.is_some_and(|u| !finite(u)) {
            return Some("preview.camera: eye, target and up must be finite [x, y, z]".into());
        }
        if camera.eye == camera.target {
            return Some("preview.camera: eye and target are the same point; the camera needs a direction".into());
        }
        if camera.up.is_some_and(|u| u == [0.0; 3]) {
            return Some("preview.camera.up is [0, 0, 0]; give a direction".into());
        }
        if camera.fov.is_some_and(|f| !(f > 0.0 && f < 180.0)) {
            return Some(format!("preview.camera.fov {}: give degrees between 0 and 180", camera.fov.unwrap_or(0.0)));
        }
        None
    }
}

/// `frames = { start = 1, end = 48, fps = 24 }`: an inclusive range of whole frames.
#[derive(Clone, Copy, Debug, PartialEq, squish::params::Params)]
#[params(level = Scene, table = "frames")]
pub struct FrameRange {
    /// The shot's first frame.
    #[param(required)]
    pub start: i64,
    /// The shot's last frame (inclusive, ≥ start).
    #[param(required)]
    pub end: i64,
    /// Frames per second, which turn frames into the time of glTF animations.
    #[param(unit = "frames per second", range = "(0, inf)")]
    pub fps: f64,
}

impl Default for FrameRange {
    fn default() -> Self {
        Self { start: 1, end: 1, fps: 24.0 }
    }
}

impl FrameRange {
    /// Number of frames (0 for an empty range; saturates beyond `usize`).
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
#[derive(Clone, Debug, PartialEq, squish::params::Params)]
#[params(level = Scene, table = "output")]
pub struct OutputSpec {
    /// The folder results are written to, relative to the scene file's folder.
    #[param]
    pub dir: PathBuf,
    /// The format of the results: one OBJ or PLY per object and frame, or one animated GLB per
    /// object.
    #[param]
    pub format: OutputFormat,
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self { dir: PathBuf::from("out"), format: OutputFormat::default() }
    }
}

squish::choice! {
    /// The format of the results.
    #[derive(Default)]
    pub enum OutputFormat {
        /// One `.obj` per object and frame.
        #[default]
        Obj = "obj",
        /// One binary `.ply` per object and frame.
        Ply = "ply",
        /// One animated `.glb` per object (all frames): a glTF source's whole document with the
        /// deformation as per-frame morph targets, an OBJ/PLY source's positions.
        Glb = "glb",
        /// As `glb`, as a `.gltf` JSON file.
        Gltf = "gltf",
        /// One point cache `.pc2` per object (all frames, the source file's vertex order), for
        /// Blender's Mesh Cache modifier, Maya and 3ds Max.
        Pc2 = "pc2",
    }
}

impl OutputFormat {
    /// The file extension.
    pub fn extension(self) -> &'static str {
        match self {
            Self::Obj => "obj",
            Self::Ply => "ply",
            Self::Glb => "glb",
            Self::Gltf => "gltf",
            Self::Pc2 => "pc2",
        }
    }

    /// True if every frame is a file of its own (OBJ, PLY); false for one file per object
    /// holding every frame (GLB, glTF, PC2).
    pub fn per_frame(self) -> bool {
        matches!(self, Self::Obj | Self::Ply)
    }
}

/// An `[[objects]]` entry: its own keys, and the object parameters of the library's schema
/// (`stiffness`, `extent`, `bulge` …, constant or keyframed) in `params`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectSpec {
    /// Unique; used in output paths.
    pub name: String,
    /// Where the mesh of each frame comes from.
    pub mesh: MeshSource,
    /// Placement applied to the mesh of every frame (after glTF posing).
    #[serde(default)]
    pub transform: Transform,
    /// Articulations whose two sides may fold onto each other (`[[objects.self_contact]]`,
    /// thesis ch. 6), resolved before the pairs; or `self_contact = "auto"` on a skinned glTF
    /// mesh: the articulations of its skeleton and the contacts between its parts (issue 27).
    /// Default none.
    #[serde(default, skip_serializing_if = "SelfContactList::is_none")]
    pub self_contact: SelfContactList,
    /// With `self_contact = "auto"`: the parameters of automatic articulations, by name
    /// (`[objects.articulations."parent / child"]`, articulation keys, constant or keyframed);
    /// the others keep the defaults.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub articulations: std::collections::BTreeMap<String, RawParams>,
    /// Every other key: the object's parameters, as written.
    #[serde(flatten)]
    pub params: RawParams,
}

impl ObjectSpec {
    /// The keys of the table that are not parameters.
    pub const TABLE_KEYS: &[&str] = &["name", "mesh", "transform", "self_contact", "articulations"];
}

/// An `[[objects.self_contact]]` entry: one articulation of the object (a knee, an elbow, lips)
/// whose two sides, region 1 (parent side) and region 2 (child side), may fold onto each other;
/// and the articulation parameters of the library's schema in `params`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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
    /// Every other key: the articulation's parameters, as written.
    #[serde(flatten)]
    pub params: RawParams,
}

/// The `self_contact` key of an object: `"auto"`, or a list of `[[objects.self_contact]]`
/// entries (dereferences to the entries; none with `"auto"`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SelfContactList {
    /// `self_contact = "auto"`: articulations from the skeleton and contacts between parts.
    pub auto: bool,
    pub entries: Vec<SelfContactSpec>,
}

impl SelfContactList {
    /// Neither `"auto"` nor any entry.
    pub fn is_none(&self) -> bool {
        !self.auto && self.entries.is_empty()
    }
}

impl std::ops::Deref for SelfContactList {
    type Target = Vec<SelfContactSpec>;
    fn deref(&self) -> &Self::Target {
        &self.entries
    }
}

impl std::ops::DerefMut for SelfContactList {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.entries
    }
}

impl From<Vec<SelfContactSpec>> for SelfContactList {
    fn from(entries: Vec<SelfContactSpec>) -> Self {
        Self { auto: false, entries }
    }
}

impl Serialize for SelfContactList {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.auto { s.serialize_str("auto") } else { self.entries.serialize(s) }
    }
}

impl<'de> Deserialize<'de> for SelfContactList {
    /// `"auto"` or an array of tables. A visitor rather than an untagged form: the entries are
    /// read by toml's own deserializer, so that an error names its key.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = SelfContactList;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("\"auto\" or [[objects.self_contact]] entries")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<SelfContactList, E> {
                if v == "auto" {
                    Ok(SelfContactList { auto: true, entries: Vec::new() })
                } else {
                    Err(E::custom(format!(
                        "self_contact = \"{v}\" is not a choice; write self_contact = \"auto\" (a skinned glTF mesh) or [[objects.self_contact]] entries"
                    )))
                }
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, seq: A) -> Result<SelfContactList, A::Error> {
                let entries = Vec::<SelfContactSpec>::deserialize(serde::de::value::SeqAccessDeserializer::new(seq))?;
                Ok(SelfContactList { auto: false, entries })
            }
        }
        d.deserialize_any(V)
    }
}

impl SelfContactSpec {
    /// The keys of the table that are not parameters.
    pub const TABLE_KEYS: &[&str] = &["name", "joints", "masks"];
}

/// A `[[pairs]]` entry: two objects that may collide, and the pair parameters of the library's
/// schema in `params`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairSpec {
    /// The names of the two objects.
    pub objects: [String; 2],
    /// Every other key: the pair's parameters, as written.
    #[serde(flatten)]
    pub params: RawParams,
}

impl PairSpec {
    /// The keys of the table that are not parameters.
    pub const TABLE_KEYS: &[&str] = &["objects"];
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
    /// Every joint turns this many times as far from its rest rotation as the clip says
    /// (`GltfScene::with_amplified_rotations`). Default 1: the clip as is.
    pub amplitude: f64,
}

/// Welding of a mesh's vertices by position.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(try_from = "WeldForm")]
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

/// The spellings of `weld`: `true`, `false` or a distance.
#[derive(Deserialize)]
#[serde(untagged)]
enum WeldForm {
    Flag(bool),
    Distance(f64),
    Other(serde::de::IgnoredAny),
}

impl TryFrom<WeldForm> for Weld {
    type Error = String;
    fn try_from(form: WeldForm) -> Result<Self, String> {
        match form {
            WeldForm::Flag(b) => Ok(if b { Weld::Exact } else { Weld::Off }),
            WeldForm::Distance(v) if v.is_finite() && v >= 0.0 => {
                Ok(if v == 0.0 { Weld::Exact } else { Weld::Within(v) })
            }
            WeldForm::Distance(v) => Err(format!("weld distance {v} must be a finite number ≥ 0")),
            WeldForm::Other(_) => Err("weld is true, false, or a distance ≥ 0 under which vertices merge".into()),
        }
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
    amplitude: Option<f64>,
}

/// True if `path` names a glTF file.
fn is_gltf(path: &Path) -> bool {
    matches!(path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).as_deref(), Some("glb") | Some("gltf"))
}

impl MeshSource {
    fn from_table(t: MeshTable) -> Result<Self, String> {
        let text = t.file.to_string_lossy();
        let sequence = text.contains("{frame");
        if is_gltf(&t.file) {
            if sequence {
                return Err("a glTF mesh cannot be a {frame} sequence; animate it inside the file".into());
            }
            let amplitude = t.amplitude.unwrap_or(1.0);
            if !(amplitude.is_finite() && amplitude >= 0.0) {
                return Err(format!(
                    "amplitude {amplitude} must be a finite number ≥ 0 (1 plays the animation as is, 2 turns every joint twice as far)"
                ));
            }
            return Ok(Self::Gltf(GltfSource {
                file: t.file,
                node: t.node,
                animation: t.animation,
                weld: t.weld.unwrap_or(Weld::Exact),
                start_frame: t.start_frame,
                repeat: t.repeat,
                amplitude,
            }));
        }
        let gltf_only = [
            ("node", t.node.is_some()),
            ("animation", t.animation.is_some()),
            ("start_frame", t.start_frame.is_some()),
            ("repeat", t.repeat),
            ("amplitude", t.amplitude.is_some()),
        ];
        if let Some((key, _)) = gltf_only.iter().find(|(_, set)| *set) {
            return Err(format!(
                "\"{key}\" only applies to .glb / .gltf meshes; remove it or point `file` at a glTF file"
            ));
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
    /// A file name or a table. A visitor rather than an untagged form: the table is read by
    /// toml's own deserializer, so that an error names its key (`repeat = 1`).
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = MeshSource;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a file name (\"ball.obj\", \"ball_{frame:04}.obj\", \"walk.glb\") or { file = …, node = …, animation = …, weld = … }")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<MeshSource, E> {
                let table = MeshTable {
                    file: PathBuf::from(v),
                    node: None,
                    animation: None,
                    weld: None,
                    start_frame: None,
                    repeat: false,
                    amplitude: None,
                };
                MeshSource::from_table(table).map_err(E::custom)
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<MeshSource, A::Error> {
                let table = MeshTable::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                MeshSource::from_table(table).map_err(serde::de::Error::custom)
            }
        }
        d.deserialize_any(V)
    }
}
/// Per-vertex values: a text file with one number per line, or a vertex attribute of a PLY or
/// glTF file (`file` absent: the object's own mesh file).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged, try_from = "Value")]
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

    /// The file named, to change (a relative path made absolute).
    pub fn file_mut(&mut self) -> Option<&mut PathBuf> {
        match self {
            Self::Text { file } => Some(file),
            Self::Attribute { file, .. } => file.as_mut(),
        }
    }

    /// Reads `"map.txt"` or `{ file = "mesh.ply", attribute = "name" }`.
    pub fn from_value(v: &Value) -> Result<Self, String> {
        const EXPECTED: &str =
            "a text file with one number per vertex (\"map.txt\") or { file = \"mesh.ply\", attribute = \"name\" }";
        match v {
            Value::String(text) => {
                let file = PathBuf::from(text);
                let ext = file.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
                if matches!(ext.as_deref(), Some("ply" | "glb" | "gltf" | "obj")) {
                    return Err(format!(
                        "\"{text}\" is a mesh file: name the vertex attribute to read, {{ file = \"{text}\", attribute = \"…\" }}"
                    ));
                }
                Ok(Self::Text { file })
            }
            Value::Table(_) => {
                let t = VertexDataTable::deserialize(v.clone()).map_err(|e| e.message().to_string())?;
                match (t.file, t.attribute) {
                    (file, Some(attribute)) => Ok(Self::Attribute { file, attribute }),
                    (Some(file), None) => Ok(Self::Text { file }),
                    (None, None) => Err("give `file` (a text file), `attribute`, or both".to_string()),
                }
            }
            _ => Err(format!("expected {EXPECTED}")),
        }
    }
}

impl TryFrom<Value> for VertexData {
    type Error = String;
    fn try_from(v: Value) -> Result<Self, String> {
        Self::from_value(&v)
    }
}
