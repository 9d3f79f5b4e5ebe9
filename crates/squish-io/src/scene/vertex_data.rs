//! Per-vertex values (bulge maps, region masks): a text file with one number per line, a PLY
//! vertex property, or a glTF vertex attribute (`_NAME`, as Blender exports custom attributes).
//!
//! Values may be given per object vertex, or per file vertex when the mesh was welded (glTF
//! seam copies each carry a value); the latter are averaged over each welded vertex. Any other
//! count is an error naming the data file and both counts.

use std::path::Path;

use gltf::json::validation::Checked;

use super::source::{VertexNumbering, to_object_vertices};
use crate::gltf_binary::{BufferData, load_buffers, split_glb};
use crate::{IoError, MeshFormat, read_ply_data};

/// Where an attribute is read from when its file is the object's own glTF: the mesh index.
pub(crate) struct OwnGltf<'a> {
    pub(crate) file: &'a Path,
    pub(crate) mesh: usize,
}

/// Per-vertex values of `data` for a mesh read from `mesh_file` outside a scene (the command
/// line's `--set a.bulge_map=…`): `count` is the mesh's vertices and `file_to_vertex` the weld
/// map from the file's vertices, if it was welded. An attribute without a file is read from
/// `mesh_file`. `what` names the parameter in messages.
pub fn read_vertex_map(
    data: &super::VertexData,
    mesh_file: &Path,
    count: usize,
    file_to_vertex: Option<&[u32]>,
    what: &str,
) -> Result<Vec<f64>, IoError> {
    let numbering = VertexNumbering {
        count,
        file_count: file_to_vertex.map_or(count, <[u32]>::len),
        file_to_vertex: file_to_vertex.map(<[u32]>::to_vec),
    };
    let object = mesh_file.file_stem().map_or_else(|| "mesh".into(), |s| s.to_string_lossy().into_owned());
    let (file, attribute) = match data {
        super::VertexData::Text { file } => (file.as_path(), None),
        super::VertexData::Attribute { file, attribute } => {
            (file.as_deref().unwrap_or(mesh_file), Some(attribute.as_str()))
        }
    };
    load_vertex_values(&object, what, file, attribute, &numbering, None)
}

/// Reads per-vertex values for `object` and maps them to its vertices. `what` names the
/// parameter ("bulge_map", "region mask").
pub(crate) fn load_vertex_values(
    object: &str,
    what: &str,
    file: &Path,
    attribute: Option<&str>,
    numbering: &VertexNumbering,
    own_gltf: Option<&OwnGltf>,
) -> Result<Vec<f64>, IoError> {
    let values = match attribute {
        None => read_text_values(file)?,
        Some(name) => match MeshFormat::from_path(file)? {
            MeshFormat::Ply => {
                let data = read_ply_data(file)?;
                match data.property(name) {
                    Some(p) => p.values.clone(),
                    None => {
                        let names: Vec<String> = data.properties.iter().map(|p| format!("\"{}\"", p.name)).collect();
                        let list = if names.is_empty() { "none".to_string() } else { names.join(", ") };
                        return Err(IoError::format(
                            file,
                            format!(
                                "has no vertex property \"{name}\" (for {what} of object \"{object}\"); its extra vertex properties: {list}"
                            ),
                        ));
                    }
                }
            }
            MeshFormat::Gltf | MeshFormat::Glb => {
                let mesh = own_gltf.filter(|o| o.file == file).map(|o| o.mesh);
                read_gltf_attribute(file, mesh, name)?
            }
            MeshFormat::Obj => {
                return Err(IoError::format(
                    file,
                    format!(
                        "OBJ has no vertex attributes (for {what} of object \"{object}\"); use a text file with one number per line, or a PLY / glTF attribute"
                    ),
                ));
            }
        },
    };
    if let Some(v) = values.iter().position(|x| !x.is_finite()) {
        return Err(IoError::format(
            file,
            format!("the value of vertex {v} is not finite (for {what} of object \"{object}\")"),
        ));
    }
    to_object_vertices(&values, numbering).ok_or_else(|| {
        let file_count = if numbering.file_to_vertex.is_some() && numbering.file_count != numbering.count {
            format!(" ({} in its mesh file before welding)", numbering.file_count)
        } else {
            String::new()
        };
        IoError::format(
            file,
            format!(
                "has {} values, but object \"{object}\" has {} vertices{file_count}; {what} needs one value per vertex, in the mesh's vertex order",
                values.len(),
                numbering.count
            ),
        )
    })
}

/// One number per line; blank lines and `#` comments are skipped.
fn read_text_values(path: &Path) -> Result<Vec<f64>, IoError> {
    let text = std::fs::read_to_string(path).map_err(|e| IoError::io(path, "read", e))?;
    let mut values = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let content = line.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        match content.parse::<f64>() {
            Ok(x) if x.is_finite() => values.push(x),
            _ => {
                return Err(IoError::line(
                    path,
                    i + 1,
                    format!("\"{content}\" is not a finite number; write one number per line, one line per vertex"),
                ));
            }
        }
    }
    Ok(values)
}

/// The scalar vertex attribute `name` (or `_name`) of a glTF mesh: `mesh`, or the file's only
/// mesh. The primitives' values are concatenated, as the reader concatenates their vertices.
fn read_gltf_attribute(path: &Path, mesh: Option<usize>, name: &str) -> Result<Vec<f64>, IoError> {
    let bytes = std::fs::read(path).map_err(|e| IoError::io(path, "open", e))?;
    let (json, bin) = if bytes.starts_with(b"glTF") { split_glb(path, &bytes)? } else { (&bytes[..], None) };
    let root = gltf::json::Root::from_slice(json)
        .map_err(|e| IoError::format(path, format!("invalid glTF JSON: {e}; the file is corrupt or not glTF 2.0")))?;
    // Only the JSON and the buffers are used (accessors are bounds-checked by `BufferData`), so
    // the document needs no validation beyond what the mesh reader already did.
    let document = gltf::Document::from_json_without_validation(root);
    let buffers = load_buffers(path, &document, bin)?;
    let data = BufferData { path, document: &document, buffers: &buffers };
    let json = document.as_json();
    let mesh = match mesh {
        Some(m) => m,
        None if json.meshes.len() == 1 => 0,
        None => {
            return Err(IoError::format(
                path,
                format!(
                    "has {} meshes; an attribute file other than the object's own mesh must hold one mesh",
                    json.meshes.len()
                ),
            ));
        }
    };
    let Some(m) = json.meshes.get(mesh) else {
        return Err(IoError::element(path, format!("mesh {mesh}"), "does not exist"));
    };
    let wanted = [name.to_string(), format!("_{name}")];
    let mut values = Vec::new();
    for (p, primitive) in m.primitives.iter().enumerate() {
        let element = format!("mesh {mesh} primitive {p}");
        let found = primitive.attributes.iter().find_map(|(semantic, index)| match semantic {
            Checked::Valid(s) if wanted.contains(&s.to_string()) => Some(index.value()),
            _ => None,
        });
        let Some(index) = found else {
            let available: Vec<String> = primitive
                .attributes
                .keys()
                .filter_map(|s| match s {
                    Checked::Valid(s) => Some(format!("\"{}\"", s.to_string())),
                    Checked::Invalid => None,
                })
                .collect();
            return Err(IoError::element(
                path,
                element,
                format!(
                    "has no vertex attribute \"{name}\" (custom attributes are exported as \"_NAME\"); its attributes: {}",
                    available.join(", ")
                ),
            ));
        };
        let acc = data.accessor(index, &format!("attribute {name} of {element}"))?;
        if acc.components != 1 {
            return Err(IoError::element(
                path,
                format!("accessor {index} (attribute {name} of {element})"),
                format!("has {} components per vertex; export a scalar (float) attribute", acc.components),
            ));
        }
        let positions = primitive.attributes.iter().find_map(|(s, i)| match s {
            Checked::Valid(gltf::json::mesh::Semantic::Positions) => json.accessors.get(i.value()).map(|a| a.count.0),
            _ => None,
        });
        if let Some(n) = positions
            && n as usize != acc.values.len()
        {
            return Err(IoError::element(
                path,
                element,
                format!("attribute {name} has {} values for {n} vertices; the file is corrupt", acc.values.len()),
            ));
        }
        values.extend_from_slice(&acc.values);
    }
    Ok(values)
}
