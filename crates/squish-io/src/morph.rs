//! A shot's frames as morph targets: each frame's displacement of a mesh, kept only where its
//! vertices move ([`SparseDisplacement`], what glTF 2.0 sparse accessors store), and the keys that
//! switch the frames' targets on and off ([`MorphKeys`]).
//!
//! Conventions:
//! - a displacement is rounded to `f32` once, the file's type; a vertex "moves" when its rounded
//!   displacement is not zero. Read back from a file it is the same, bit for bit, so the parts of
//!   a split shot merge into the file an unsplit run writes;
//! - a frame's target is on (weight 1) from its time until the next frame's, all others off
//!   (STEP keys). glTF holds the first key's value before it and the last one's after it, so a
//!   part of a shot gets a key that turns every target off at the frame before its first
//!   ([`MorphKeys::off_before`]) and at the frame after its last ([`MorphKeys::off_after`]):
//!   it shows nothing outside its frames.

use std::ops::Range;

use glam::DVec3;
use serde_json::{Value, json};

/// glTF's `FLOAT` component type.
const FLOAT: u64 = 5126;

/// The displacement of a mesh's vertices, kept where it is not zero (in `f32`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SparseDisplacement {
    /// The mesh's vertex count.
    pub count: usize,
    /// The vertices that move, increasing.
    pub indices: Vec<u32>,
    /// Their displacements, as the file stores them.
    pub values: Vec<[f32; 3]>,
}

impl SparseDisplacement {
    /// `dense` (one displacement per vertex) rounded to `f32`, keeping the vertices whose rounded
    /// displacement is not zero. `Err(v)`: vertex `v` is not finite in `f32`.
    pub fn from_dense(dense: &[DVec3]) -> Result<Self, usize> {
        let mut out = Self { count: dense.len(), ..Self::default() };
        for (v, d) in dense.iter().enumerate() {
            let rounded = d.as_vec3();
            if !rounded.is_finite() {
                return Err(v);
            }
            if rounded != glam::Vec3::ZERO {
                out.indices.push(v as u32);
                out.values.push(rounded.to_array());
            }
        }
        Ok(out)
    }

    /// One displacement per vertex, zero where none is kept (exact: `f32` to `f64`).
    pub fn dense(&self) -> Vec<DVec3> {
        let mut out = vec![DVec3::ZERO; self.count];
        for (&v, value) in self.indices.iter().zip(&self.values) {
            out[v as usize] = glam::Vec3::from_array(*value).as_dvec3();
        }
        out
    }

    /// The displacement of the vertices `range` (a primitive of a mesh), numbered from its start.
    pub fn slice(&self, range: Range<usize>) -> Self {
        let first = self.indices.partition_point(|&v| (v as usize) < range.start);
        let last = self.indices.partition_point(|&v| (v as usize) < range.end);
        Self {
            count: range.len(),
            indices: self.indices[first..last].iter().map(|&v| v - range.start as u32).collect(),
            values: self.values[first..last].to_vec(),
        }
    }

    /// True if no vertex moves.
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }
}

/// One frame of a shot as a morph target: its name (`extras.targetNames`: Blender's shape-key
/// name), its animation time in seconds, and its displacement from the mesh's base positions.
#[derive(Clone, Debug, PartialEq)]
pub struct MorphFrame {
    pub name: String,
    pub time: f64,
    pub displacement: SparseDisplacement,
}

/// The keys of a shot's morph weights besides its frames': every target off from `off_before`
/// until the first frame, and from `off_after` on (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MorphKeys {
    pub off_before: Option<f64>,
    pub off_after: Option<f64>,
}

impl MorphKeys {
    /// The animation times of every key: `off_before`, the frames', `off_after`; checks that they
    /// increase (`Err` says where they do not).
    pub(crate) fn times(&self, frames: &[MorphFrame]) -> Result<Vec<f64>, String> {
        let mut times: Vec<f64> = self.off_before.into_iter().collect();
        times.extend(frames.iter().map(|f| f.time));
        times.extend(self.off_after);
        if let Some(t) = times.iter().find(|t| !(t.is_finite() && **t >= 0.0)) {
            return Err(format!("animation time {t} is not a time ≥ 0 s"));
        }
        match times.windows(2).position(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater)) {
            Some(k) => Err(format!(
                "keys {k} and {} fall at animation times {} and {}: morph keys need increasing times (a looping animation repeats them; write per-frame files or a point cache instead)",
                k + 1,
                times[k],
                times[k + 1]
            )),
            None => Ok(times),
        }
    }

    /// Per key of [`Self::times`], the frame whose target is on (`None`: every target off).
    pub(crate) fn frame_on(&self, frames: usize) -> Vec<Option<usize>> {
        let mut on: Vec<Option<usize>> = self.off_before.map(|_| None).into_iter().collect();
        on.extend((0..frames).map(Some));
        on.extend(self.off_after.map(|_| None));
        on
    }
}

/// The accessor of a displacement (`VEC3`, float): sparse — the moving vertices' indices and
/// values, in buffer views made by `view`; an accessor without a buffer view holds zeros — when
/// that is smaller than storing every vertex, dense otherwise. When nothing moves it holds one
/// zero entry (a sparse accessor needs one, and readers such as the `gltf` crate's validation
/// refuse an accessor with neither a buffer view nor sparse data). `with_bounds`: `min`/`max`
/// over every vertex (required for `POSITION`).
pub(crate) fn sparse_accessor(
    displacement: &SparseDisplacement,
    with_bounds: bool,
    mut view: impl FnMut(&[u8]) -> usize,
) -> Value {
    let SparseDisplacement { count, indices, values } = displacement;
    let mut accessor = json!({ "componentType": FLOAT, "count": count, "type": "VEC3" });
    if with_bounds {
        // Every vertex's value: the kept ones, and zero when some vertex has none.
        let zero = (indices.len() < *count).then_some([0.0f32; 3]);
        let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for value in values.iter().chain(zero.as_ref()) {
            for c in 0..3 {
                min[c] = min[c].min(value[c]);
                max[c] = max[c].max(value[c]);
            }
        }
        if values.is_empty() && zero.is_none() {
            (min, max) = ([0.0; 3], [0.0; 3]);
        }
        accessor["min"] = json!(min);
        accessor["max"] = json!(max);
    }
    let (indices, values) = if indices.is_empty() { (&vec![0], &vec![[0.0; 3]]) } else { (indices, values) };
    let last = indices.last().copied().unwrap_or(0);
    let (index_type, index_size) = if last <= u32::from(u8::MAX) {
        (5121, 1)
    } else if last <= u32::from(u16::MAX) {
        (5123, 2)
    } else {
        (5125, 4)
    };
    let value_bytes: Vec<u8> = values.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    if indices.len() * (12 + index_size) < count * 12 {
        let index_bytes: Vec<u8> = match index_size {
            1 => indices.iter().map(|&i| i as u8).collect(),
            2 => indices.iter().flat_map(|&i| (i as u16).to_le_bytes()).collect(),
            _ => indices.iter().flat_map(|&i| i.to_le_bytes()).collect(),
        };
        let index_view = view(&index_bytes);
        let value_view = view(&value_bytes);
        accessor["sparse"] = json!({
            "count": indices.len(),
            "indices": { "bufferView": index_view, "componentType": index_type },
            "values": { "bufferView": value_view },
        });
    } else {
        let dense: Vec<u8> =
            displacement.dense().iter().flat_map(|d| d.as_vec3().to_array()).flat_map(f32::to_le_bytes).collect();
        accessor["bufferView"] = json!(view(&dense));
    }
    accessor
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_what_moves_in_f32_is_kept_and_reads_back_the_same() {
        let dense = vec![DVec3::ZERO, DVec3::new(1e-3, 0.0, 0.0), DVec3::splat(1e-50), DVec3::new(0.0, -2.0, 0.5)];
        let sparse = SparseDisplacement::from_dense(&dense).unwrap_or_default();
        // 1e-50 is zero in f32: that vertex does not move in the file.
        assert_eq!(sparse.indices, [1, 3]);
        assert_eq!(SparseDisplacement::from_dense(&sparse.dense()), Ok(sparse.clone()));
        let tail = sparse.slice(2..4);
        assert_eq!((tail.count, tail.indices.as_slice()), (2, &[1][..]));
        assert_eq!(SparseDisplacement::from_dense(&[DVec3::splat(1e300)]), Err(0));
    }

    #[test]
    fn off_keys_surround_the_frames() {
        let frame = |time| MorphFrame { name: String::new(), time, displacement: SparseDisplacement::default() };
        let frames = [frame(1.0), frame(1.5)];
        let keys = MorphKeys { off_before: Some(0.5), off_after: Some(2.0) };
        assert_eq!(keys.times(&frames), Ok(vec![0.5, 1.0, 1.5, 2.0]));
        assert_eq!(keys.frame_on(2), [None, Some(0), Some(1), None]);
        let late = MorphKeys { off_before: Some(1.0), off_after: None };
        assert!(late.times(&frames).is_err_and(|e| e.contains("increasing")));
    }
}
