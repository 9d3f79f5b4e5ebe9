//! Point caches in the PC2 format (3ds Max's Point Cache 2): the positions of a mesh's vertices
//! at every sample of a shot, read by Blender's Mesh Cache modifier, Maya (`cacheFile -pc2`) and
//! 3ds Max's Point Cache modifier. The mesh itself (faces, UVs, materials) stays in the asset;
//! the cache only moves its vertices, so it must list them in the asset's vertex order.
//!
//! Layout, little endian: the 12 bytes `POINTCACHE2\0`, `i32` version 1, `i32` number of points,
//! `f32` start frame, `f32` sample rate (frames per sample: 1 is one sample per frame), `i32`
//! number of samples; then for each sample, `f32` x, y, z of every point.

use std::path::Path;

use glam::DVec3;

use crate::{IoError, write_atomically};

const MAGIC: &[u8; 12] = b"POINTCACHE2\0";
const HEADER_BYTES: usize = 32;

/// A point cache: samples of every point's position.
#[derive(Clone, Debug, PartialEq)]
pub struct PointCache {
    /// The frame of the first sample.
    pub start_frame: f32,
    /// Frames between samples (1: one sample per frame).
    pub sample_rate: f32,
    /// Per sample, one position per point (as `f32` in the file).
    pub samples: Vec<Vec<DVec3>>,
}

/// Writes `samples` (one position per vertex, the same number each time) as a PC2 file,
/// atomically. Coordinates are rounded to `f32`, the format's type.
pub fn write_pc2(path: &Path, samples: &[Vec<DVec3>], start_frame: f64, sample_rate: f64) -> Result<(), IoError> {
    let points = samples.first().map_or(0, Vec::len);
    if let Some((k, s)) = samples.iter().enumerate().find(|(_, s)| s.len() != points) {
        return Err(IoError::invalid_input(
            path,
            format!(
                "sample {k} has {} vertices but sample 0 has {points}; a point cache needs the same vertices, in the same order, at every frame (write per-frame files for meshes whose vertex count changes)",
                s.len()
            ),
        ));
    }
    let too_many = |what: &str, n: usize| {
        IoError::invalid_input(path, format!("{n} {what} do not fit the 32-bit counts of a PC2 file"))
    };
    let points32 = i32::try_from(points).map_err(|_| too_many("vertices", points))?;
    let samples32 = i32::try_from(samples.len()).map_err(|_| too_many("samples", samples.len()))?;
    if !(start_frame.is_finite() && sample_rate.is_finite() && sample_rate > 0.0) {
        return Err(IoError::invalid_input(
            path,
            format!("start frame {start_frame} and sample rate {sample_rate} must be finite, the rate positive"),
        ));
    }
    for (k, sample) in samples.iter().enumerate() {
        if let Some(v) = sample.iter().position(|p| !p.as_vec3().is_finite()) {
            return Err(IoError::invalid_input(
                path,
                format!("sample {k} vertex {v} ({}) is not finite in 32-bit floats, which PC2 uses", sample[v]),
            ));
        }
    }
    write_atomically(path, |w| {
        w.write_all(MAGIC)?;
        w.write_all(&1i32.to_le_bytes())?;
        w.write_all(&points32.to_le_bytes())?;
        w.write_all(&(start_frame as f32).to_le_bytes())?;
        w.write_all(&(sample_rate as f32).to_le_bytes())?;
        w.write_all(&samples32.to_le_bytes())?;
        let mut record = Vec::with_capacity(12 * points);
        for sample in samples {
            record.clear();
            for p in sample {
                for c in p.as_vec3().to_array() {
                    record.extend_from_slice(&c.to_le_bytes());
                }
            }
            w.write_all(&record)?;
        }
        Ok(())
    })
}

/// Reads a PC2 file, checking its header against its size.
pub fn read_pc2(path: &Path) -> Result<PointCache, IoError> {
    let bytes = std::fs::read(path).map_err(|e| IoError::io(path, "open", e))?;
    if bytes.len() < HEADER_BYTES || &bytes[..12] != MAGIC {
        return Err(IoError::offset(path, 0, "not a PC2 file: it does not start with the 32-byte POINTCACHE2 header"));
    }
    let int = |at: usize| i32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let float = |at: usize| f32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let version = int(12);
    if version != 1 {
        return Err(IoError::offset(path, 12, format!("PC2 version {version}; only version 1 exists")));
    }
    let (points, samples) = (int(16), int(28));
    let (Ok(points), Ok(samples)) = (usize::try_from(points), usize::try_from(samples)) else {
        return Err(IoError::offset(path, 16, format!("negative counts ({points} points, {samples} samples)")));
    };
    let expected =
        points.checked_mul(samples).and_then(|n| n.checked_mul(12)).and_then(|n| n.checked_add(HEADER_BYTES));
    if expected != Some(bytes.len()) {
        return Err(IoError::offset(
            path,
            bytes.len() as u64,
            format!(
                "the header announces {samples} samples of {points} points, but the file has {} bytes",
                bytes.len()
            ),
        ));
    }
    let samples = (0..samples)
        .map(|s| {
            (0..points)
                .map(|p| {
                    let at = HEADER_BYTES + 12 * (s * points + p);
                    DVec3::new(float(at) as f64, float(at + 4) as f64, float(at + 8) as f64)
                })
                .collect()
        })
        .collect();
    Ok(PointCache { start_frame: float(20), sample_rate: float(24), samples })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn header_layout_and_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.pc2");
        let samples = vec![vec![DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO], vec![DVec3::X, DVec3::new(0.5, -0.25, 8.0)]];
        write_pc2(&path, &samples, 12.0, 1.0).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(bytes.len(), 32 + 2 * 2 * 12);
        assert_eq!(&bytes[..12], b"POINTCACHE2\0");
        assert_eq!(bytes[12..16], 1i32.to_le_bytes());
        assert_eq!(bytes[16..20], 2i32.to_le_bytes());
        assert_eq!(bytes[20..24], 12f32.to_le_bytes());
        assert_eq!(bytes[24..28], 1f32.to_le_bytes());
        assert_eq!(bytes[28..32], 2i32.to_le_bytes());
        assert_eq!(bytes[32..36], 1f32.to_le_bytes());
        let back = read_pc2(&path).unwrap();
        assert_eq!(back, PointCache { start_frame: 12.0, sample_rate: 1.0, samples });
    }

    #[test]
    fn different_vertex_counts_are_refused_without_writing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.pc2");
        let err = write_pc2(&path, &[vec![DVec3::ZERO; 3], vec![DVec3::ZERO; 4]], 1.0, 1.0).unwrap_err();
        assert!(err.to_string().contains("sample 1 has 4 vertices but sample 0 has 3"), "{err}");
        assert!(!path.exists());
        std::fs::write(&path, b"POINTCACHE2\0garbage").unwrap();
        assert!(read_pc2(&path).unwrap_err().to_string().contains("header"));
    }
}
