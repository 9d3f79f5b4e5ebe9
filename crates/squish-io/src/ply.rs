//! Stanford PLY: ASCII, binary little endian and binary big endian.
//!
//! Reading takes `x`, `y`, `z` from the `vertex` element (any scalar type, in any position among
//! other properties), the `vertex_indices` (or `vertex_index`) list of the `face` element (any
//! count and index types), and fan-triangulates polygons. Every other scalar vertex property
//! (colours, labels, normals, …) is returned by [`read_ply_data`]; other elements and list
//! properties are skipped. The file's vertex order and count are kept exactly.
//!
//! Writing is binary little endian with `double` coordinates by default: exact, compact, and
//! read by Blender, MeshLab, CloudCompare and Houdini; ASCII is available for inspection.
//! Extra per-vertex scalar properties (`uchar` RGB colours, an `int` label, a `float` parameter …)
//! and point clouds (no `face` element) serve the contact debug exports.

use std::io::Write;
use std::path::{Path, PathBuf};

use glam::DVec3;
use squish::TriMesh;

use crate::{IoError, write_atomically};

/// PLY body encodings.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PlyFormat {
    Ascii,
    #[default]
    BinaryLittleEndian,
    BinaryBigEndian,
}

impl PlyFormat {
    fn header_name(self) -> &'static str {
        match self {
            Self::Ascii => "ascii",
            Self::BinaryLittleEndian => "binary_little_endian",
            Self::BinaryBigEndian => "binary_big_endian",
        }
    }
}

/// PLY scalar types.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScalarType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl ScalarType {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    /// The classic PLY type name, the one every reader knows.
    pub fn ply_name(self) -> &'static str {
        match self {
            Self::I8 => "char",
            Self::U8 => "uchar",
            Self::I16 => "short",
            Self::U16 => "ushort",
            Self::I32 => "int",
            Self::U32 => "uint",
            Self::F32 => "float",
            Self::F64 => "double",
        }
    }

    /// Size in bytes.
    pub fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn is_float(self) -> bool {
        matches!(self, Self::F32 | Self::F64)
    }

    /// Range of an integer type.
    fn int_range(self) -> (f64, f64) {
        match self {
            Self::I8 => (i8::MIN as f64, i8::MAX as f64),
            Self::U8 => (0.0, u8::MAX as f64),
            Self::I16 => (i16::MIN as f64, i16::MAX as f64),
            Self::U16 => (0.0, u16::MAX as f64),
            Self::I32 => (i32::MIN as f64, i32::MAX as f64),
            Self::U32 => (0.0, u32::MAX as f64),
            Self::F32 => (f32::MIN as f64, f32::MAX as f64),
            Self::F64 => (f64::MIN, f64::MAX),
        }
    }
}

/// A per-vertex scalar property. Values are held as `f64`, which represents every PLY scalar
/// type exactly; `ty` is the type in the file.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexProperty {
    pub name: String,
    pub ty: ScalarType,
    pub values: Vec<f64>,
}

impl VertexProperty {
    /// A property from values of any numeric type.
    pub fn new(name: impl Into<String>, ty: ScalarType, values: Vec<f64>) -> Self {
        Self { name: name.into(), ty, values }
    }

    /// An `int` property (e.g. a label).
    pub fn int(name: impl Into<String>, values: &[i32]) -> Self {
        Self::new(name, ScalarType::I32, values.iter().map(|&v| v as f64).collect())
    }

    /// A `float` property (e.g. a parameter `u` in [0, 1]).
    pub fn float(name: impl Into<String>, values: &[f32]) -> Self {
        Self::new(name, ScalarType::F32, values.iter().map(|&v| v as f64).collect())
    }

    /// A `double` property.
    pub fn double(name: impl Into<String>, values: &[f64]) -> Self {
        Self::new(name, ScalarType::F64, values.to_vec())
    }

    /// `red`, `green`, `blue` `uchar` properties: the names and type that Blender, MeshLab and
    /// CloudCompare read as vertex colours.
    pub fn rgb(colors: &[[u8; 3]]) -> Vec<Self> {
        ["red", "green", "blue"]
            .iter()
            .enumerate()
            .map(|(c, name)| Self::new(*name, ScalarType::U8, colors.iter().map(|rgb| rgb[c] as f64).collect()))
            .collect()
    }
}

/// Everything [`read_ply_data`] gets from a file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlyData {
    pub positions: Vec<DVec3>,
    /// Fan-triangulated faces; empty for a point cloud.
    pub triangles: Vec<[u32; 3]>,
    /// Scalar vertex properties other than x, y, z, in file order.
    pub properties: Vec<VertexProperty>,
}

impl PlyData {
    /// The property with this name.
    pub fn property(&self, name: &str) -> Option<&VertexProperty> {
        self.properties.iter().find(|p| p.name == name)
    }

    /// RGB colours from `red`, `green`, `blue` (or `r`, `g`, `b`) `uchar` properties.
    pub fn colors(&self) -> Option<Vec<[u8; 3]>> {
        let channel = |a: &str, b: &str| self.property(a).or_else(|| self.property(b));
        let (r, g, b) = (channel("red", "r")?, channel("green", "g")?, channel("blue", "b")?);
        Some(r.values.iter().zip(&g.values).zip(&b.values).map(|((r, g), b)| [*r as u8, *g as u8, *b as u8]).collect())
    }
}

/// Options of the PLY writers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlyWriteOptions {
    /// Body encoding. Default: binary little endian.
    pub format: PlyFormat,
    /// Type of x, y, z: `F64` (default, exact) or `F32` (half the size, for tools that only
    /// read `float`; rounds to ~7 significant digits).
    pub position_type: ScalarType,
}

impl Default for PlyWriteOptions {
    fn default() -> Self {
        Self { format: PlyFormat::BinaryLittleEndian, position_type: ScalarType::F64 }
    }
}

impl PlyWriteOptions {
    /// ASCII with double coordinates.
    pub fn ascii() -> Self {
        Self { format: PlyFormat::Ascii, ..Self::default() }
    }

    /// Sets the format.
    pub fn with_format(mut self, format: PlyFormat) -> Self {
        self.format = format;
        self
    }
}

// ---------------------------------------------------------------------------------------------
// Reading

/// Reads a PLY mesh (see the module documentation). A file without faces is an error here;
/// read point clouds with [`read_ply_data`].
pub fn read_ply(path: &Path) -> Result<TriMesh, IoError> {
    let data = read_ply_data(path)?;
    if data.triangles.is_empty() && !data.positions.is_empty() {
        return Err(IoError::format(
            path,
            format!(
                "no faces ({} vertices, 0 faces): this is a point cloud, not a mesh; export the mesh with its faces",
                data.positions.len()
            ),
        ));
    }
    TriMesh::new(data.positions, data.triangles).map_err(|e| IoError::mesh(path, e))
}

/// Reads positions, triangles (possibly none) and extra scalar vertex properties.
pub fn read_ply_data(path: &Path) -> Result<PlyData, IoError> {
    let bytes = std::fs::read(path).map_err(|e| IoError::io(path, "open", e))?;
    parse_ply(path, &bytes)
}

#[derive(Clone, Debug)]
enum PropertyKind {
    Scalar(ScalarType),
    List { count: ScalarType, item: ScalarType },
}

#[derive(Clone, Debug)]
struct PropertyDecl {
    name: String,
    kind: PropertyKind,
}

#[derive(Clone, Debug)]
struct ElementDecl {
    name: String,
    count: u64,
    properties: Vec<PropertyDecl>,
    line: usize,
}

struct Header {
    format: PlyFormat,
    elements: Vec<ElementDecl>,
    /// Byte offset of the body.
    body_start: usize,
    /// Number of header lines (the body's first line is `lines + 1`).
    lines: usize,
}

fn parse_header(path: &Path, bytes: &[u8]) -> Result<Header, IoError> {
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut format = None;
    let mut elements: Vec<ElementDecl> = Vec::new();
    loop {
        if pos >= bytes.len() {
            return Err(IoError::line(
                path,
                line_no,
                "the header has no 'end_header' line; the file is truncated or not a PLY file",
            ));
        }
        let end = bytes[pos..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |e| pos + e);
        let raw = &bytes[pos..end];
        pos = (end + 1).min(bytes.len());
        line_no += 1;
        let text = String::from_utf8_lossy(raw.strip_suffix(b"\r").unwrap_or(raw)).into_owned();
        let mut tokens = text.split_whitespace();
        let keyword = tokens.next().unwrap_or("");
        if line_no == 1 {
            if keyword != "ply" {
                return Err(IoError::line(path, 1, "not a PLY file: the first line must be 'ply'"));
            }
            continue;
        }
        match keyword {
            "format" => {
                let name = tokens.next().unwrap_or("");
                format = Some(match name {
                    "ascii" => PlyFormat::Ascii,
                    "binary_little_endian" => PlyFormat::BinaryLittleEndian,
                    "binary_big_endian" => PlyFormat::BinaryBigEndian,
                    _ => {
                        return Err(IoError::line(
                            path,
                            line_no,
                            format!(
                                "unknown PLY format '{name}'; expected ascii, binary_little_endian or binary_big_endian"
                            ),
                        ));
                    }
                });
            }
            "comment" | "obj_info" | "" => {}
            "element" => {
                let name = tokens.next().unwrap_or("");
                let count_text = tokens.next().unwrap_or("");
                let count = count_text.parse::<u64>().map_err(|_| {
                    IoError::line(
                        path,
                        line_no,
                        format!(
                            "element '{name}' has a malformed count '{count_text}'; expected 'element <name> <count>'"
                        ),
                    )
                })?;
                if name.is_empty() {
                    return Err(IoError::line(
                        path,
                        line_no,
                        "element without a name; expected 'element <name> <count>'",
                    ));
                }
                elements.push(ElementDecl { name: name.to_string(), count, properties: Vec::new(), line: line_no });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(IoError::line(
                        path,
                        line_no,
                        "property declared before any element; put it after an 'element' line",
                    ));
                };
                let first = tokens.next().unwrap_or("");
                let unknown = |t: &str| {
                    IoError::line(
                        path,
                        line_no,
                        format!(
                            "unknown property type '{t}'; expected char, uchar, short, ushort, int, uint, float, double (or int8 … float64)"
                        ),
                    )
                };
                let kind = if first == "list" {
                    let count_name = tokens.next().unwrap_or("");
                    let item_name = tokens.next().unwrap_or("");
                    let count = ScalarType::parse(count_name).ok_or_else(|| unknown(count_name))?;
                    let item = ScalarType::parse(item_name).ok_or_else(|| unknown(item_name))?;
                    if count.is_float() {
                        return Err(IoError::line(
                            path,
                            line_no,
                            format!("list count type '{count_name}' is a float type; list counts must be integers"),
                        ));
                    }
                    PropertyKind::List { count, item }
                } else {
                    PropertyKind::Scalar(ScalarType::parse(first).ok_or_else(|| unknown(first))?)
                };
                let Some(name) = tokens.next() else {
                    return Err(IoError::line(path, line_no, "property without a name"));
                };
                element.properties.push(PropertyDecl { name: name.to_string(), kind });
            }
            "end_header" => break,
            other => {
                return Err(IoError::line(
                    path,
                    line_no,
                    format!(
                        "unexpected header line starting with '{other}'; expected format, comment, element, property or end_header"
                    ),
                ));
            }
        }
    }
    let Some(format) = format else {
        return Err(IoError::line(
            path,
            line_no,
            "the header has no 'format' line (e.g. 'format binary_little_endian 1.0')",
        ));
    };
    Ok(Header { format, elements, body_start: pos, lines: line_no })
}

/// Where a body value is, to name it in errors.
struct ValueSite<'a> {
    element: &'a str,
    record: u64,
    count: u64,
    property: &'a str,
}

impl ValueSite<'_> {
    fn describe(&self) -> String {
        format!("{} {} of {}, property '{}'", self.element, self.record, self.count, self.property)
    }
}

/// The body as a source of values.
enum Body<'a> {
    /// One record per line, as the PLY specification requires; tokens of the current line.
    Ascii {
        lines: std::slice::Split<'a, u8, fn(&u8) -> bool>,
        line_no: usize,
        tokens: Vec<String>,
        next: usize,
    },
    Binary {
        data: &'a [u8],
        pos: usize,
        big_endian: bool,
        base: usize,
    },
}

fn is_newline(b: &u8) -> bool {
    *b == b'\n'
}

impl<'a> Body<'a> {
    /// ASCII: moves to the next non-empty line (the next record). Returns false at the end.
    fn start_record(&mut self) -> bool {
        match self {
            Body::Ascii { lines, line_no, tokens, next } => {
                for line in lines.by_ref() {
                    *line_no += 1;
                    let text = String::from_utf8_lossy(line);
                    let t: Vec<String> = text.split_whitespace().map(str::to_string).collect();
                    if !t.is_empty() {
                        *tokens = t;
                        *next = 0;
                        return true;
                    }
                }
                false
            }
            Body::Binary { .. } => true,
        }
    }

    /// ASCII: true if the current record line has unread tokens.
    fn leftover_tokens(&self) -> usize {
        match self {
            Body::Ascii { tokens, next, .. } => tokens.len() - *next,
            Body::Binary { .. } => 0,
        }
    }

    fn error(&self, path: &Path, message: String) -> IoError {
        match self {
            Body::Ascii { line_no, .. } => IoError::line(path, *line_no, message),
            Body::Binary { pos, base, .. } => IoError::offset(path, (*base + *pos) as u64, message),
        }
    }

    fn read(&mut self, path: &Path, ty: ScalarType, site: &ValueSite) -> Result<f64, IoError> {
        match self {
            Body::Ascii { tokens, next, .. } => {
                let Some(token) = tokens.get(*next) else {
                    return Err(self.error(
                        path,
                        format!(
                            "{}: the line ends too early; each record must be one line with all its values",
                            site.describe()
                        ),
                    ));
                };
                *next += 1;
                let value = if ty.is_float() {
                    token.parse::<f64>().ok().map(|v| if ty == ScalarType::F32 { v as f32 as f64 } else { v })
                } else {
                    token.parse::<i64>().ok().map(|v| v as f64).filter(|v| {
                        let (lo, hi) = ty.int_range();
                        *v >= lo && *v <= hi
                    })
                };
                match value {
                    Some(v) => Ok(v),
                    None => {
                        let token = token.clone();
                        Err(self.error(
                            path,
                            format!("{}: malformed value '{token}' for type {}", site.describe(), ty.ply_name()),
                        ))
                    }
                }
            }
            Body::Binary { data, pos, big_endian, .. } => {
                let size = ty.size();
                let Some(raw) = data.get(*pos..*pos + size) else {
                    return Err(self.error(
                        path,
                        format!("{}: unexpected end of data; the file is truncated (export it again)", site.describe()),
                    ));
                };
                let mut b = [0u8; 8];
                b[..size].copy_from_slice(raw);
                if *big_endian {
                    b[..size].reverse();
                }
                *pos += size;
                Ok(match ty {
                    ScalarType::I8 => b[0] as i8 as f64,
                    ScalarType::U8 => b[0] as f64,
                    ScalarType::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
                    ScalarType::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
                    ScalarType::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    ScalarType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    ScalarType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    ScalarType::F64 => f64::from_le_bytes(b),
                })
            }
        }
    }
}

/// Every element of a PLY file, column by column, with the header kept verbatim: what
/// [`PlyDocument::write_with_positions`] writes back with new positions.
///
/// Values are held as `f64`, which represents every PLY scalar type exactly, so a file written
/// back holds the same values in the same types, encoding and order (ASCII numbers are written
/// in their shortest round-trip form, which may differ in spelling from the input's, e.g. `0.50`
/// becomes `0.5`).
#[derive(Clone, Debug, PartialEq)]
pub struct PlyDocument {
    path: PathBuf,
    /// The header bytes, from `ply` to the end of the `end_header` line.
    header: Vec<u8>,
    format: PlyFormat,
    /// Every element, in file order.
    pub elements: Vec<PlyElement>,
}

/// An element of a PLY file (`vertex`, `face`, `edge`, `material` …) and its values.
#[derive(Clone, Debug, PartialEq)]
pub struct PlyElement {
    pub name: String,
    pub count: usize,
    pub properties: Vec<PlyProperty>,
}

/// A property and its values, one per record.
#[derive(Clone, Debug, PartialEq)]
pub struct PlyProperty {
    pub name: String,
    pub values: PlyColumn,
}

/// A property's values.
#[derive(Clone, Debug, PartialEq)]
pub enum PlyColumn {
    /// One scalar per record.
    Scalar { ty: ScalarType, values: Vec<f64> },
    /// One list per record: record `r` holds `items[offsets[r]..offsets[r + 1]]`.
    List { count_ty: ScalarType, item_ty: ScalarType, offsets: Vec<usize>, items: Vec<f64> },
}

impl PlyColumn {
    /// The scalar values, if this is a scalar property.
    pub fn scalars(&self) -> Option<&[f64]> {
        match self {
            Self::Scalar { values, .. } => Some(values),
            Self::List { .. } => None,
        }
    }

    /// The list of record `r`, if this is a list property.
    pub fn list(&self, r: usize) -> Option<&[f64]> {
        match self {
            Self::List { offsets, items, .. } => Some(&items[*offsets.get(r)?..*offsets.get(r + 1)?]),
            Self::Scalar { .. } => None,
        }
    }
}

impl PlyElement {
    /// The property with this name.
    pub fn property(&self, name: &str) -> Option<&PlyProperty> {
        self.properties.iter().find(|p| p.name == name)
    }
}

/// The vertex properties that deformation recomputes; every other value is written back as read.
const POSITION_NAMES: [&str; 3] = ["x", "y", "z"];
const NORMAL_NAMES: [&str; 3] = ["nx", "ny", "nz"];

impl PlyDocument {
    /// Reads a PLY file (see the module documentation for what a mesh needs).
    pub fn read(path: &Path) -> Result<Self, IoError> {
        let bytes = std::fs::read(path).map_err(|e| IoError::io(path, "open", e))?;
        parse_document(path, &bytes)
    }

    /// The file read.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The body encoding of the file.
    pub fn format(&self) -> PlyFormat {
        self.format
    }

    /// The element with this name (the first, if several share it).
    pub fn element(&self, name: &str) -> Option<&PlyElement> {
        self.elements.iter().find(|e| e.name == name)
    }

    fn vertex_element(&self) -> Option<usize> {
        self.elements.iter().position(|e| e.name == "vertex")
    }

    /// True if the vertices carry normals (`nx`, `ny`, `nz`), which writing recomputes.
    pub fn has_normals(&self) -> bool {
        self.element("vertex").is_some_and(|v| NORMAL_NAMES.iter().all(|n| v.property(n).is_some()))
    }

    /// Positions, fan-triangulated faces (empty for a point cloud) and the other scalar vertex
    /// properties, as [`read_ply_data`] returns them.
    pub fn data(&self) -> PlyData {
        let mut data = PlyData::default();
        if let Some(vertex) = self.element("vertex") {
            let column = |name: &str| vertex.property(name).and_then(|p| p.values.scalars());
            if let (Some(x), Some(y), Some(z)) = (column("x"), column("y"), column("z")) {
                data.positions = x.iter().zip(y).zip(z).map(|((x, y), z)| DVec3::new(*x, *y, *z)).collect();
            }
            for p in &vertex.properties {
                if let PlyColumn::Scalar { ty, values } = &p.values
                    && !POSITION_NAMES.contains(&p.name.as_str())
                {
                    data.properties.push(VertexProperty { name: p.name.clone(), ty: *ty, values: values.clone() });
                }
            }
        }
        if let Some(face) = self.element("face")
            && let Some(indices) = face.properties.iter().find(|p| is_index_list_name(&p.name))
        {
            for r in 0..face.count {
                let polygon = indices.values.list(r).unwrap_or(&[]);
                for i in 1..polygon.len().saturating_sub(1) {
                    data.triangles.push([polygon[0] as u32, polygon[i] as u32, polygon[i + 1] as u32]);
                }
            }
        }
        data
    }

    /// The mesh of the file (checked by [`TriMesh::new`]); a file without faces is an error.
    pub fn mesh(&self) -> Result<TriMesh, IoError> {
        let data = self.data();
        if data.triangles.is_empty() && !data.positions.is_empty() {
            return Err(IoError::format(
                &self.path,
                format!(
                    "no faces ({} vertices, 0 faces): this is a point cloud, not a mesh; export the mesh with its faces",
                    data.positions.len()
                ),
            ));
        }
        TriMesh::new(data.positions, data.triangles).map_err(|e| IoError::mesh(&self.path, e))
    }

    /// Writes the file back to `path` (atomically) with new vertex positions, in the file's
    /// encoding, header and element order; vertex normals (`nx`, `ny`, `nz`), if present, are
    /// recomputed from the new positions (area-weighted face normals). Every other value is
    /// written as read.
    pub fn write_with_positions(&self, path: &Path, positions: &[DVec3]) -> Result<(), IoError> {
        let Some(vertex) = self.vertex_element() else {
            return Err(IoError::invalid_input(path, "the PLY document has no vertex element"));
        };
        let count = self.elements[vertex].count;
        if positions.len() != count {
            return Err(IoError::invalid_input(
                path,
                format!("{} positions for the {count} vertices of {}", positions.len(), self.path.display()),
            ));
        }
        if let Some(v) = positions.iter().position(|p| !p.is_finite()) {
            return Err(IoError::invalid_input(path, format!("vertex {v} has a non-finite coordinate")));
        }
        let normals = if self.has_normals() {
            let triangles = self.data().triangles;
            Some(squish::mesh::vertex_normals(&TriMesh { positions: positions.to_vec(), triangles }))
        } else {
            None
        };
        // Which vertex column takes which new value: (property index, source, axis).
        let overrides: Vec<Option<(bool, usize)>> = self.elements[vertex]
            .properties
            .iter()
            .map(|p| {
                let axis = |names: [&str; 3]| names.iter().position(|n| *n == p.name);
                match (axis(POSITION_NAMES), axis(NORMAL_NAMES), &normals) {
                    (Some(a), _, _) => Some((false, a)),
                    (None, Some(a), Some(_)) => Some((true, a)),
                    _ => None,
                }
            })
            .collect();
        for (p, o) in self.elements[vertex].properties.iter().zip(&overrides) {
            if let (Some(_), PlyColumn::Scalar { ty, .. }) = (o, &p.values)
                && !ty.is_float()
            {
                return Err(IoError::invalid_input(
                    path,
                    format!(
                        "vertex property '{}' of {} is an integer ({}); deformed coordinates need float or double",
                        p.name,
                        self.path.display(),
                        ty.ply_name()
                    ),
                ));
            }
        }
        let value = |e: usize, p: usize, r: usize| -> f64 {
            if e == vertex
                && let Some((is_normal, axis)) = overrides[p]
            {
                let v = if is_normal { normals.as_ref().map_or(DVec3::ZERO, |n| n[r]) } else { positions[r] };
                // A vertex on no face keeps the normal it had.
                if !is_normal || v != DVec3::ZERO {
                    return v[axis];
                }
            }
            match &self.elements[e].properties[p].values {
                PlyColumn::Scalar { values, .. } => values[r],
                PlyColumn::List { .. } => 0.0,
            }
        };
        write_atomically(path, |w| {
            w.write_all(&self.header)?;
            let big = self.format == PlyFormat::BinaryBigEndian;
            let mut record: Vec<u8> = Vec::new();
            let mut line = String::new();
            for (e, element) in self.elements.iter().enumerate() {
                for r in 0..element.count {
                    record.clear();
                    line.clear();
                    for (p, property) in element.properties.iter().enumerate() {
                        match &property.values {
                            PlyColumn::Scalar { ty, .. } => {
                                let v = value(e, p, r);
                                match self.format {
                                    PlyFormat::Ascii => push_ascii(&mut line, *ty, v),
                                    _ => push_binary(&mut record, *ty, v, big),
                                }
                            }
                            PlyColumn::List { count_ty, item_ty, .. } => {
                                let items = property.values.list(r).unwrap_or(&[]);
                                match self.format {
                                    PlyFormat::Ascii => {
                                        push_ascii(&mut line, *count_ty, items.len() as f64);
                                        for &v in items {
                                            push_ascii(&mut line, *item_ty, v);
                                        }
                                    }
                                    _ => {
                                        push_binary(&mut record, *count_ty, items.len() as f64, big);
                                        for &v in items {
                                            push_binary(&mut record, *item_ty, v, big);
                                        }
                                    }
                                }
                            }
                        }
                    }
                    if self.format == PlyFormat::Ascii {
                        line.pop();
                        line.push('\n');
                        w.write_all(line.as_bytes())?;
                    } else {
                        w.write_all(&record)?;
                    }
                }
            }
            Ok(())
        })
    }
}

fn parse_ply(path: &Path, bytes: &[u8]) -> Result<PlyData, IoError> {
    Ok(parse_document(path, bytes)?.data())
}

fn parse_document(path: &Path, bytes: &[u8]) -> Result<PlyDocument, IoError> {
    let header = parse_header(path, bytes)?;
    let Some(vertex_decl) = header.elements.iter().find(|e| e.name == "vertex") else {
        return Err(IoError::line(
            path,
            header.lines,
            "the header declares no 'vertex' element; a PLY mesh needs 'element vertex <count>' with x, y, z properties",
        ));
    };
    for axis in POSITION_NAMES {
        match vertex_decl.properties.iter().find(|p| p.name == axis) {
            Some(PropertyDecl { kind: PropertyKind::Scalar(_), .. }) => {}
            Some(_) => {
                return Err(IoError::line(
                    path,
                    vertex_decl.line,
                    format!("vertex property '{axis}' is a list; coordinates must be scalar properties"),
                ));
            }
            None => {
                return Err(IoError::line(
                    path,
                    vertex_decl.line,
                    format!("the vertex element has no '{axis}' property; vertices need x, y and z"),
                ));
            }
        }
    }
    if let Some(face) = header.elements.iter().find(|e| e.name == "face")
        && !face.properties.iter().any(is_face_index_list)
    {
        return Err(IoError::line(
            path,
            face.line,
            "the face element has no 'vertex_indices' (or 'vertex_index') list property; faces need one",
        ));
    }
    let vertex_count = usize::try_from(vertex_decl.count).unwrap_or(usize::MAX);
    if vertex_decl.count > u32::MAX as u64 {
        return Err(IoError::line(
            path,
            vertex_decl.line,
            format!("{} vertices is more than the 2^32 − 1 this library indexes", vertex_decl.count),
        ));
    }

    let body_bytes = &bytes[header.body_start..];
    let mut body = match header.format {
        PlyFormat::Ascii => Body::Ascii {
            lines: body_bytes.split(is_newline as fn(&u8) -> bool),
            line_no: header.lines,
            tokens: Vec::new(),
            next: 0,
        },
        PlyFormat::BinaryLittleEndian | PlyFormat::BinaryBigEndian => Body::Binary {
            data: body_bytes,
            pos: 0,
            big_endian: header.format == PlyFormat::BinaryBigEndian,
            base: header.body_start,
        },
    };

    // Reservations are capped so that a corrupt count cannot allocate gigabytes up front.
    const RESERVE_CAP: usize = 1 << 22;
    let mut elements = Vec::with_capacity(header.elements.len());
    let mut vertex_seen = false;
    let mut face_seen = false;
    for element in &header.elements {
        // The first `vertex` and `face` elements are the mesh; later ones are kept as data.
        let is_vertex = element.name == "vertex" && !vertex_seen;
        let is_face = element.name == "face" && !face_seen;
        vertex_seen |= element.name == "vertex";
        face_seen |= element.name == "face";
        let reserve = usize::try_from(element.count).unwrap_or(usize::MAX).min(RESERVE_CAP);
        let mut columns: Vec<PlyColumn> = element
            .properties
            .iter()
            .map(|p| match p.kind {
                PropertyKind::Scalar(ty) => PlyColumn::Scalar { ty, values: Vec::with_capacity(reserve) },
                PropertyKind::List { count, item } => {
                    let mut offsets = Vec::with_capacity(reserve + 1);
                    offsets.push(0);
                    PlyColumn::List { count_ty: count, item_ty: item, offsets, items: Vec::new() }
                }
            })
            .collect();
        // Only the first index list of the face element is the polygon (others are data).
        let polygon_list = is_face.then(|| element.properties.iter().position(is_face_index_list)).flatten();
        for record in 0..element.count {
            if !body.start_record() {
                return Err(body.error(
                    path,
                    format!(
                        "the file ends after {record} of {} {} records; it is truncated (export it again)",
                        element.count, element.name
                    ),
                ));
            }
            for (k, (p, column)) in element.properties.iter().zip(&mut columns).enumerate() {
                let site = ValueSite { element: &element.name, record, count: element.count, property: &p.name };
                match column {
                    PlyColumn::Scalar { ty, values } => {
                        let v = body.read(path, *ty, &site)?;
                        if is_vertex && POSITION_NAMES.contains(&p.name.as_str()) && !v.is_finite() {
                            return Err(body.error(
                                path,
                                format!(
                                    "{}: non-finite coordinate ({v}); every coordinate must be a finite number",
                                    site.describe()
                                ),
                            ));
                        }
                        values.push(v);
                    }
                    PlyColumn::List { count_ty, item_ty, offsets, items } => {
                        let n = body.read(path, *count_ty, &site)?;
                        if n < 0.0 {
                            return Err(body.error(path, format!("{}: negative list length {n}", site.describe())));
                        }
                        let start = items.len();
                        for _ in 0..n as u64 {
                            items.push(body.read(path, *item_ty, &site)?);
                        }
                        offsets.push(items.len());
                        if polygon_list == Some(k) {
                            let polygon = &items[start..];
                            if polygon.len() < 3 {
                                return Err(body.error(
                                    path,
                                    format!("face {record} has {} vertices; a face needs at least 3", polygon.len()),
                                ));
                            }
                            if let Some(&v) =
                                polygon.iter().find(|&&v| v < 0.0 || v.fract() != 0.0 || v >= vertex_count as f64)
                            {
                                return Err(body.error(
                                    path,
                                    format!("face {record} refers to vertex {v}, but the file has {vertex_count} vertices (indices start at 0)"),
                                ));
                            }
                        }
                    }
                }
            }
            if body.leftover_tokens() > 0 {
                return Err(body.error(
                    path,
                    format!(
                        "{} {record} has {} more values than the header's properties describe; the header and the data disagree",
                        element.name,
                        body.leftover_tokens()
                    ),
                ));
            }
        }
        elements.push(PlyElement {
            name: element.name.clone(),
            count: element.count as usize,
            properties: element
                .properties
                .iter()
                .zip(columns)
                .map(|(p, values)| PlyProperty { name: p.name.clone(), values })
                .collect(),
        });
    }
    check_body_ends(path, &header, &mut body)?;
    Ok(PlyDocument {
        path: path.to_path_buf(),
        header: bytes[..header.body_start].to_vec(),
        format: header.format,
        elements,
    })
}

fn is_index_list_name(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

/// After the declared records the body must end: more data means the header's counts are too
/// small, and reading only what they declare would drop the rest without a word. The extra data
/// is read as records of the last element, to say how many the header should declare. A final
/// line end after binary data (some writers add one) is not data.
fn check_body_ends(path: &Path, header: &Header, body: &mut Body) -> Result<(), IoError> {
    let at = body.error(path, String::new());
    let remaining = match body {
        Body::Ascii { .. } => usize::from(body.start_record()),
        Body::Binary { data, pos, .. } => {
            let rest = data.get(*pos..).unwrap_or(&[]);
            if matches!(rest, [] | [b'\n'] | [b'\r', b'\n']) { 0 } else { rest.len() }
        }
    };
    if remaining == 0 {
        return Ok(());
    }
    let location = match at {
        IoError::Line { line, .. } => format!("after line {line}"),
        IoError::Offset { offset, .. } => format!("after byte {offset}"),
        _ => String::new(),
    };
    let Some(last) = header.elements.last() else {
        return Err(body.error(
            path,
            "the header declares no element but the file has data after 'end_header'; the header is wrong (export the file again)"
                .to_string(),
        ));
    };
    // Count whole extra records of the last element; a record that does not parse stops it.
    let is_ascii = matches!(body, Body::Ascii { .. });
    // The check above already started the first ASCII record.
    let mut started = is_ascii;
    let mut extra = 0u64;
    let mut complete = false;
    'records: while extra <= u32::MAX as u64 {
        if is_ascii && !std::mem::take(&mut started) && !body.start_record() {
            complete = true;
            break;
        }
        for p in &last.properties {
            let site =
                ValueSite { element: &last.name, record: last.count + extra, count: last.count, property: &p.name };
            let ok = match p.kind {
                PropertyKind::Scalar(ty) => body.read(path, ty, &site).is_ok(),
                PropertyKind::List { count, item } => match body.read(path, count, &site) {
                    Ok(n) if n >= 0.0 => (0..n as u64).all(|_| body.read(path, item, &site).is_ok()),
                    _ => false,
                },
            };
            if !ok {
                break 'records;
            }
        }
        if body.leftover_tokens() > 0 {
            break;
        }
        extra += 1;
        if let Body::Binary { data, pos, .. } = body
            && *pos >= data.len()
        {
            complete = true;
            break;
        }
    }
    let fix = format!(
        "fix the count on header line {} or export the file again; reading only the declared records would drop the rest",
        last.line
    );
    let message = if complete && extra > 0 {
        format!(
            "the header declares {} {} records but the body holds {} ({extra} more {location}); {fix}",
            last.count,
            last.name,
            last.count + extra
        )
    } else {
        format!(
            "the body has data {location}, past the {} {} records the header declares (the last element); {fix}",
            last.count, last.name
        )
    };
    Err(IoError::Format { path: path.to_path_buf(), message })
}

fn is_face_index_list(p: &PropertyDecl) -> bool {
    matches!(p.kind, PropertyKind::List { .. }) && is_index_list_name(&p.name)
}

// ---------------------------------------------------------------------------------------------
// Writing

/// Writes a mesh as PLY, atomically.
pub fn write_ply(path: &Path, mesh: &TriMesh, options: &PlyWriteOptions) -> Result<(), IoError> {
    mesh.check_structure().map_err(|e| IoError::mesh(path, e))?;
    write_ply_with(path, &mesh.positions, Some(&mesh.triangles), &[], options)
}

/// Writes a point cloud (a `vertex` element only) with optional per-vertex properties.
pub fn write_point_cloud_ply(
    path: &Path,
    points: &[DVec3],
    properties: &[VertexProperty],
    options: &PlyWriteOptions,
) -> Result<(), IoError> {
    write_ply_with(path, points, None, properties, options)
}

/// Writes positions, optional triangles and per-vertex scalar properties (see
/// [`VertexProperty::rgb`] for colours), atomically. Checks everything before writing a byte:
/// one value per vertex, values representable in their type, unique names, indices in range.
pub fn write_ply_with(
    path: &Path,
    positions: &[DVec3],
    triangles: Option<&[[u32; 3]]>,
    properties: &[VertexProperty],
    options: &PlyWriteOptions,
) -> Result<(), IoError> {
    check_for_writing(path, positions, triangles, properties, options)?;
    write_atomically(path, |w| write_body(w, positions, triangles, properties, options))
}

fn check_for_writing(
    path: &Path,
    positions: &[DVec3],
    triangles: Option<&[[u32; 3]]>,
    properties: &[VertexProperty],
    options: &PlyWriteOptions,
) -> Result<(), IoError> {
    if !options.position_type.is_float() {
        return Err(IoError::invalid_input(path, "PLY positions must be written as float or double"));
    }
    if let Some(v) = positions.iter().position(|p| !p.is_finite()) {
        return Err(IoError::invalid_input(path, format!("vertex {v} has a non-finite coordinate")));
    }
    if positions.len() > i32::MAX as usize {
        return Err(IoError::invalid_input(path, "more vertices than PLY 'int' indices can address"));
    }
    if let Some(tris) = triangles
        && let Some((t, &bad)) = tris
            .iter()
            .enumerate()
            .find_map(|(t, tri)| tri.iter().find(|&&i| i as usize >= positions.len()).map(|i| (t, i)))
    {
        return Err(IoError::invalid_input(
            path,
            format!("triangle {t} refers to vertex {bad}, but there are {} vertices", positions.len()),
        ));
    }
    let mut names: Vec<&str> = vec!["x", "y", "z"];
    for p in properties {
        if p.name.is_empty() || p.name.chars().any(char::is_whitespace) {
            return Err(IoError::invalid_input(
                path,
                format!("property name '{}' must be non-empty without spaces", p.name),
            ));
        }
        if names.contains(&p.name.as_str()) {
            return Err(IoError::invalid_input(
                path,
                format!("property '{}' is given twice (x, y, z are the positions)", p.name),
            ));
        }
        names.push(&p.name);
        if p.values.len() != positions.len() {
            return Err(IoError::invalid_input(
                path,
                format!("property '{}' has {} values for {} vertices", p.name, p.values.len(), positions.len()),
            ));
        }
        let (lo, hi) = p.ty.int_range();
        if let Some((v, &value)) = p.values.iter().enumerate().find(|(_, v)| {
            if p.ty.is_float() {
                v.is_finite() && (**v < lo || **v > hi)
            } else {
                !(**v >= lo && **v <= hi && v.fract() == 0.0)
            }
        }) {
            return Err(IoError::invalid_input(
                path,
                format!("property '{}' value {value} at vertex {v} does not fit type {}", p.name, p.ty.ply_name()),
            ));
        }
    }
    Ok(())
}

fn write_body(
    w: &mut dyn Write,
    positions: &[DVec3],
    triangles: Option<&[[u32; 3]]>,
    properties: &[VertexProperty],
    options: &PlyWriteOptions,
) -> std::io::Result<()> {
    let pos_ty = options.position_type;
    writeln!(w, "ply")?;
    writeln!(w, "format {} 1.0", options.format.header_name())?;
    writeln!(w, "comment written by Squish")?;
    writeln!(w, "element vertex {}", positions.len())?;
    for axis in ["x", "y", "z"] {
        writeln!(w, "property {} {axis}", pos_ty.ply_name())?;
    }
    for p in properties {
        writeln!(w, "property {} {}", p.ty.ply_name(), p.name)?;
    }
    if let Some(tris) = triangles {
        writeln!(w, "element face {}", tris.len())?;
        writeln!(w, "property list uchar int vertex_indices")?;
    }
    writeln!(w, "end_header")?;
    match options.format {
        PlyFormat::Ascii => {
            let mut line = String::new();
            for (v, p) in positions.iter().enumerate() {
                line.clear();
                for c in p.to_array() {
                    push_ascii(&mut line, pos_ty, c);
                }
                for prop in properties {
                    push_ascii(&mut line, prop.ty, prop.values[v]);
                }
                line.pop();
                line.push('\n');
                w.write_all(line.as_bytes())?;
            }
            for [a, b, c] in triangles.unwrap_or(&[]) {
                writeln!(w, "3 {a} {b} {c}")?;
            }
        }
        PlyFormat::BinaryLittleEndian | PlyFormat::BinaryBigEndian => {
            let big = options.format == PlyFormat::BinaryBigEndian;
            let mut record = Vec::new();
            for (v, p) in positions.iter().enumerate() {
                record.clear();
                for c in p.to_array() {
                    push_binary(&mut record, pos_ty, c, big);
                }
                for prop in properties {
                    push_binary(&mut record, prop.ty, prop.values[v], big);
                }
                w.write_all(&record)?;
            }
            for tri in triangles.unwrap_or(&[]) {
                record.clear();
                record.push(3u8);
                for &i in tri {
                    push_binary(&mut record, ScalarType::I32, i as f64, big);
                }
                w.write_all(&record)?;
            }
        }
    }
    Ok(())
}

fn push_ascii(line: &mut String, ty: ScalarType, value: f64) {
    use std::fmt::Write as _;
    // Shortest round-trip formatting of the value in its own type: exact on reading back.
    let _ = match ty {
        ScalarType::F32 => write!(line, "{} ", value as f32),
        ScalarType::F64 => write!(line, "{value} "),
        _ => write!(line, "{} ", value as i64),
    };
}

fn push_binary(out: &mut Vec<u8>, ty: ScalarType, value: f64, big: bool) {
    macro_rules! put {
        ($v:expr) => {
            if big { out.extend_from_slice(&$v.to_be_bytes()) } else { out.extend_from_slice(&$v.to_le_bytes()) }
        };
    }
    match ty {
        ScalarType::I8 => put!(value as i8),
        ScalarType::U8 => put!(value as u8),
        ScalarType::I16 => put!(value as i16),
        ScalarType::U16 => put!(value as u16),
        ScalarType::I32 => put!(value as i32),
        ScalarType::U32 => put!(value as u32),
        ScalarType::F32 => put!(value as f32),
        ScalarType::F64 => put!(value),
    }
}
