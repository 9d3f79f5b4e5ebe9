//! The base-colour texture of a glTF mesh (its first primitive's material,
//! `pbrMetallicRoughness.baseColorTexture`), as the encoded image the file holds, for viewers that
//! show the character as it was authored (`squish serve`). Only the image is read: samplers,
//! texture transforms and `TEXCOORD_n` sets other than the one the texture names are not.

use std::path::Path;

use serde_json::Value;

use crate::IoError;
use crate::gltf_binary::load_uri;
use crate::gltf_read::read_gltf_file;

/// An encoded image (PNG, JPEG …) as stored in a glTF file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GltfImage {
    /// The image's media type (`image/png`, `image/jpeg`), from the file or its signature.
    pub mime: String,
    pub bytes: Vec<u8>,
    /// The `TEXCOORD_n` set the texture reads.
    pub texcoord: u64,
}

/// The base-colour image of the mesh of node `node` of the glTF file at `path`, or `None` when
/// the node has no mesh or its first primitive no material with a base-colour texture. A texture
/// whose image cannot be read is an error naming it.
pub fn base_color_image(path: &Path, node: usize) -> Result<Option<GltfImage>, IoError> {
    let file = read_gltf_file(path, &crate::GltfReadOptions::default())?;
    let json: Value =
        serde_json::from_slice(&file.json).map_err(|e| IoError::format(path, format!("invalid glTF JSON: {e}")))?;
    let at = |key: &str, index: Option<u64>| index.and_then(|i| json.get(key)?.get(usize::try_from(i).ok()?));
    let mesh = json.get("nodes").and_then(|n| n.get(node)?.get("mesh")?.as_u64());
    let primitive = at("meshes", mesh).and_then(|m| m.get("primitives")?.get(0));
    let material = at("materials", primitive.and_then(|p| p.get("material")?.as_u64()));
    let Some(texture_info) = material.and_then(|m| m.get("pbrMetallicRoughness")?.get("baseColorTexture")) else {
        return Ok(None);
    };
    let texcoord = texture_info.get("texCoord").and_then(Value::as_u64).unwrap_or(0);
    let texture_index = texture_info.get("index").and_then(Value::as_u64);
    let element = format!("texture {}", texture_index.unwrap_or(0));
    let source = at("textures", texture_index).and_then(|t| t.get("source")?.as_u64());
    let Some(image) = at("images", source) else {
        return Err(IoError::element(path, element, "has no image; the file is corrupt (export it again)"));
    };
    let element = format!("image {}", source.unwrap_or(0));
    let bytes = if let Some(uri) = image.get("uri").and_then(Value::as_str) {
        load_uri(path, &element, uri)?
    } else {
        let view = at("bufferViews", image.get("bufferView").and_then(Value::as_u64));
        let range = view.and_then(|v| {
            let buffer = file.buffers.get(usize::try_from(v.get("buffer")?.as_u64()?).ok()?)?;
            let offset = usize::try_from(v.get("byteOffset").and_then(Value::as_u64).unwrap_or(0)).ok()?;
            let length = usize::try_from(v.get("byteLength")?.as_u64()?).ok()?;
            buffer.get(offset..offset.checked_add(length)?)
        });
        range
            .ok_or_else(|| IoError::element(path, element.clone(), "has neither a URI nor a readable buffer view"))?
            .to_vec()
    };
    let mime = match image.get("mimeType").and_then(Value::as_str) {
        Some(mime) => mime.to_string(),
        None if bytes.starts_with(&[0x89, b'P', b'N', b'G']) => "image/png".to_string(),
        None if bytes.starts_with(&[0xff, 0xd8]) => "image/jpeg".to_string(),
        None => "application/octet-stream".to_string(),
    };
    Ok(Some(GltfImage { mime, bytes, texcoord }))
}
