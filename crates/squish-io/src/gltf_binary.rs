//! The binary side of glTF: the GLB container, buffers (GLB chunk, external files next to the
//! `.gltf`, base64 `data:` URIs) and accessors (every component type, normalized integers,
//! strides, matrix column padding, sparse substitution).
//!
//! The `gltf` crate's own accessor readers assume valid data and may panic on a truncated or
//! corrupt file; here every offset, length and count is checked before use (and before any
//! allocation sized by the file), and the error names the accessor, buffer or byte offset.

use std::path::Path;

use base64::Engine as _;
use gltf::json::validation::Checked;

use crate::IoError;

const GLB_JSON: u32 = 0x4E4F_534A;
const GLB_BIN: u32 = 0x004E_4942;

fn u32_at(bytes: &[u8], offset: usize) -> Option<u32> {
    let b = bytes.get(offset..offset + 4)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits a GLB container into its JSON chunk and optional BIN chunk.
pub(crate) fn split_glb<'a>(path: &Path, bytes: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>), IoError> {
    let truncated = |offset: usize, what: &str| {
        IoError::offset(path, offset as u64, format!("the file ends inside {what}; it is truncated (export it again)"))
    };
    let (Some(version), Some(length)) = (u32_at(bytes, 4), u32_at(bytes, 8)) else {
        return Err(truncated(bytes.len(), "the 12-byte GLB header"));
    };
    if version != 2 {
        return Err(IoError::offset(
            path,
            4,
            format!("GLB version {version}; only glTF 2.0 is supported (re-export as glTF 2.0)"),
        ));
    }
    let length = length as usize;
    if length > bytes.len() {
        return Err(IoError::offset(
            path,
            bytes.len() as u64,
            format!(
                "the GLB header declares {length} bytes but the file has {}; it is truncated (export it again)",
                bytes.len()
            ),
        ));
    }
    let bytes = &bytes[..length];
    let mut offset = 12usize;
    let mut json = None;
    let mut bin = None;
    while offset < bytes.len() {
        let (Some(chunk_length), Some(chunk_type)) = (u32_at(bytes, offset), u32_at(bytes, offset + 4)) else {
            return Err(truncated(offset, "a chunk header"));
        };
        let start = offset + 8;
        let end = start.checked_add(chunk_length as usize).filter(|&e| e <= bytes.len());
        let Some(end) = end else {
            return Err(IoError::offset(
                path,
                offset as u64,
                format!(
                    "chunk of {chunk_length} bytes runs past the end of the file ({} bytes); it is truncated",
                    bytes.len()
                ),
            ));
        };
        match chunk_type {
            GLB_JSON if json.is_none() => json = Some(&bytes[start..end]),
            GLB_BIN if bin.is_none() && json.is_some() => bin = Some(&bytes[start..end]),
            // Unknown chunks must be ignored (glTF 2.0 §4.4.3.3).
            _ => {}
        }
        offset = end;
        if json.is_none() {
            return Err(IoError::offset(path, 12, "the first GLB chunk is not JSON; the file is corrupt"));
        }
    }
    match json {
        Some(json) => Ok((json, bin)),
        None => Err(truncated(12, "the GLB header (no JSON chunk)")),
    }
}

pub(crate) fn load_buffers(
    path: &Path,
    document: &gltf::Document,
    bin: Option<&[u8]>,
) -> Result<Vec<Vec<u8>>, IoError> {
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let element = format!("buffer {}", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => match bin {
                Some(b) => b.to_vec(),
                None => {
                    return Err(IoError::element(
                        path,
                        element,
                        "refers to the GLB binary chunk, but the file has none (a .gltf buffer needs a 'uri')",
                    ));
                }
            },
            gltf::buffer::Source::Uri(uri) => load_uri(path, &element, uri)?,
        };
        if data.len() < buffer.length() {
            return Err(IoError::element(
                path,
                element,
                format!(
                    "has {} bytes but the file declares {}; the data is truncated (export it again)",
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

pub(crate) fn load_uri(path: &Path, element: &str, uri: &str) -> Result<Vec<u8>, IoError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((header, payload)) = rest.split_once(',') else {
            return Err(IoError::element(path, element, "malformed data URI (no ',')"));
        };
        if !header.ends_with(";base64") {
            return Err(IoError::element(
                path,
                element,
                "data URI is not base64-encoded; re-export with embedded (base64) buffers",
            ));
        }
        return base64::engine::general_purpose::STANDARD.decode(payload.trim()).map_err(|e| {
            IoError::element(
                path,
                element,
                format!("invalid base64 in the data URI: {e}; the file is corrupt (export it again)"),
            )
        });
    }
    if let Some((scheme, _)) = uri.split_once(':')
        && scheme.len() > 1
        && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
    {
        return Err(IoError::element(
            path,
            element,
            format!("URI '{uri}' has scheme '{scheme}:'; only files next to the .gltf and data: URIs are read"),
        ));
    }
    let relative = percent_decode(uri);
    let full = path.parent().unwrap_or(Path::new(".")).join(relative);
    // Named from the .gltf: the user knows that file, and the buffer's path is relative to it.
    std::fs::read(&full).map_err(|e| {
        IoError::element(
            path,
            element,
            format!(
                "cannot read its file {}: {e}; buffer files are read from the .gltf's folder (copy it there, or export a .glb)",
                full.display()
            ),
        )
    })
}

/// Decodes `%XX` escapes (URIs in glTF are percent-encoded, e.g. spaces as `%20`).
pub(crate) fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && let Some(v) = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(v);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Decoded accessor values: `count × components` numbers, with normalized integers mapped to
/// [0, 1] or [−1, 1] as glTF specifies.
pub(crate) struct AccessorData {
    pub(crate) components: usize,
    pub(crate) values: Vec<f64>,
}

impl AccessorData {
    pub(crate) fn count(&self) -> usize {
        self.values.len() / self.components.max(1)
    }
    pub(crate) fn rows<const N: usize>(&self) -> impl Iterator<Item = [f64; N]> + '_ {
        self.values.chunks_exact(N).map(|c| {
            let mut a = [0.0; N];
            a.copy_from_slice(c);
            a
        })
    }
}

/// A validated document and its loaded buffers: what accessors are read from.
pub(crate) struct BufferData<'a> {
    pub(crate) path: &'a Path,
    pub(crate) document: &'a gltf::Document,
    pub(crate) buffers: &'a [Vec<u8>],
}

fn component_size(ct: gltf::json::accessor::ComponentType) -> usize {
    use gltf::json::accessor::ComponentType as C;
    match ct {
        C::I8 | C::U8 => 1,
        C::I16 | C::U16 => 2,
        C::U32 | C::F32 => 4,
    }
}

fn decode_component(bytes: &[u8], ct: gltf::json::accessor::ComponentType, normalized: bool) -> f64 {
    use gltf::json::accessor::ComponentType as C;
    let v = match ct {
        C::I8 => bytes[0] as i8 as f64,
        C::U8 => bytes[0] as f64,
        C::I16 => i16::from_le_bytes([bytes[0], bytes[1]]) as f64,
        C::U16 => u16::from_le_bytes([bytes[0], bytes[1]]) as f64,
        C::U32 => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
        C::F32 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
    };
    if !normalized {
        return v;
    }
    match ct {
        C::I8 => (v / 127.0).max(-1.0),
        C::U8 => v / 255.0,
        C::I16 => (v / 32767.0).max(-1.0),
        C::U16 => v / 65535.0,
        C::U32 => v / u32::MAX as f64,
        C::F32 => v,
    }
}

impl<'a> BufferData<'a> {
    fn err(&self, element: impl Into<String>, message: impl Into<String>) -> IoError {
        IoError::element(self.path, element, message)
    }

    /// The bytes of buffer view `view`, checked against its buffer.
    fn view_bytes(&self, view: usize, element: &str) -> Result<(&'a [u8], Option<usize>), IoError> {
        let json = self.document.as_json();
        let Some(v) = json.buffer_views.get(view) else {
            return Err(self.err(element, format!("refers to buffer view {view}, which does not exist")));
        };
        let buffer = v.buffer.value();
        let Some(data) = self.buffers.get(buffer) else {
            return Err(
                self.err(element, format!("buffer view {view} refers to buffer {buffer}, which does not exist"))
            );
        };
        let start = v.byte_offset.map_or(0, |o| o.0);
        let end = start.checked_add(v.byte_length.0);
        match end.filter(|&e| e <= data.len() as u64) {
            Some(end) => Ok((&data[start as usize..end as usize], v.byte_stride.map(|s| s.0))),
            None => Err(self.err(
                element,
                format!(
                    "buffer view {view} (bytes {start}..{}) runs past the end of buffer {buffer} ({} bytes); the file is truncated or corrupt",
                    start.saturating_add(v.byte_length.0),
                    data.len()
                ),
            )),
        }
    }

    /// Reads accessor `index`; `what` says what it is for (in errors).
    pub(crate) fn accessor(&self, index: usize, what: &str) -> Result<AccessorData, IoError> {
        use gltf::json::accessor::Type as T;
        let element = format!("accessor {index} ({what})");
        let Some(acc) = self.document.as_json().accessors.get(index) else {
            return Err(self.err(element, "does not exist"));
        };
        let (Checked::Valid(ct), Checked::Valid(ty)) = (&acc.component_type, &acc.type_) else {
            return Err(self.err(element, "has an invalid componentType or type"));
        };
        let ct = ct.0;
        let ty = *ty;
        let size = component_size(ct);
        let (columns, rows) = match ty {
            T::Scalar => (1, 1),
            T::Vec2 => (1, 2),
            T::Vec3 => (1, 3),
            T::Vec4 => (1, 4),
            T::Mat2 => (2, 2),
            T::Mat3 => (3, 3),
            T::Mat4 => (4, 4),
        };
        let components = columns * rows;
        // Matrix columns start on 4-byte boundaries (glTF §3.6.2.4), which pads small types.
        let column_stride = if columns > 1 { (rows * size).div_ceil(4) * 4 } else { rows * size };
        let element_size = columns * column_stride;
        let count = acc.count.0;
        // Where the elements are, checked before anything is allocated: a corrupt count must not
        // allocate gigabytes.
        let count = usize::try_from(count).unwrap_or(usize::MAX);
        let dense = match acc.buffer_view {
            Some(view) => {
                let (bytes, stride) = self.view_bytes(view.value(), &element)?;
                let stride = stride.unwrap_or(element_size);
                if stride < element_size {
                    return Err(self.err(
                        element,
                        format!("byteStride {stride} is smaller than an element ({element_size} bytes)"),
                    ));
                }
                let offset = acc.byte_offset.map_or(0, |o| o.0) as usize;
                let needed = match count {
                    0 => Some(0),
                    _ => (count - 1)
                        .checked_mul(stride)
                        .and_then(|x| x.checked_add(offset))
                        .and_then(|x| x.checked_add(element_size)),
                };
                if needed.is_none_or(|n| n > bytes.len()) {
                    return Err(self.err(
                        element,
                        format!(
                            "{count} elements of {element_size} bytes (stride {stride}, offset {offset}) do not fit in buffer view {} ({} bytes); the file is truncated or corrupt",
                            view.value(),
                            bytes.len()
                        ),
                    ));
                }
                Some((&bytes[offset.min(bytes.len())..], stride))
            }
            None => {
                // Only sparse data (or nothing): zeros. Bound the size, since no data backs it.
                if count.saturating_mul(components) > (1 << 24) {
                    return Err(self.err(
                        element,
                        format!("count {count} is implausibly large for an accessor without data; the file is corrupt"),
                    ));
                }
                None
            }
        };
        let mut values = vec![0.0f64; count * components];
        let decode_into =
            |values: &mut [f64], bytes: &[u8], stride: usize, n: usize, dest: &mut dyn FnMut(usize) -> usize| {
                for i in 0..n {
                    let base = i * stride;
                    let d = dest(i);
                    for c in 0..columns {
                        for r in 0..rows {
                            let at = base + c * column_stride + r * size;
                            values[d * components + c * rows + r] =
                                decode_component(&bytes[at..at + size], ct, acc.normalized);
                        }
                    }
                }
            };
        if let Some((bytes, stride)) = dense {
            decode_into(&mut values, bytes, stride, count, &mut |i| i);
        }
        if let Some(sparse) = &acc.sparse {
            let n = sparse.count.0 as usize;
            let index_ct = match &sparse.indices.component_type {
                Checked::Valid(c) => c.0,
                Checked::Invalid => return Err(self.err(element, "sparse indices have an invalid componentType")),
            };
            let index_size = component_size(index_ct);
            let (index_bytes, _) = self.view_bytes(sparse.indices.buffer_view.value(), &element)?;
            let index_offset = sparse.indices.byte_offset.0 as usize;
            let (value_bytes, _) = self.view_bytes(sparse.values.buffer_view.value(), &element)?;
            let value_offset = sparse.values.byte_offset.0 as usize;
            let fits = |bytes: &[u8], offset: usize, each: usize| {
                n.checked_mul(each).and_then(|x| x.checked_add(offset)).is_some_and(|e| e <= bytes.len())
            };
            if !fits(index_bytes, index_offset, index_size) || !fits(value_bytes, value_offset, element_size) {
                return Err(self.err(
                    element,
                    format!("sparse data ({n} entries) runs past its buffer view; the file is truncated or corrupt"),
                ));
            }
            let mut targets = Vec::with_capacity(n);
            for i in 0..n {
                let at = index_offset + i * index_size;
                let t = decode_component(&index_bytes[at..at + index_size], index_ct, false) as usize;
                if t >= count {
                    return Err(self.err(element, format!("sparse index {t} is out of range (count {count})")));
                }
                targets.push(t);
            }
            decode_into(&mut values, &value_bytes[value_offset..], element_size, n, &mut |i| targets[i]);
        }
        Ok(AccessorData { components, values })
    }

    /// Reads an accessor and checks its number of components.
    pub(crate) fn accessor_with(
        &self,
        index: usize,
        what: &str,
        components: usize,
        type_name: &str,
    ) -> Result<AccessorData, IoError> {
        let data = self.accessor(index, what)?;
        if data.components != components {
            return Err(self.err(
                format!("accessor {index} ({what})"),
                format!("has {} components per element; {what} must be {type_name}", data.components),
            ));
        }
        Ok(data)
    }
}
