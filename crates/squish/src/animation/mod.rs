//! Skeletons and animation clips: node hierarchies with rest transforms, keyframed channels on
//! node translation / rotation / scale, their evaluation at any time and the world transforms of
//! a pose.
//!
//! This is the skeletal side of the "skinning" input of the pipeline (thesis §2.3.1 and ch. 6):
//! a frame of an animated character is obtained by evaluating a clip at a time, composing the
//! node transforms from the roots down, and skinning the rest mesh with
//! [`crate::skinning::linear_blend_skinning`]. Everything here is pure computation in `f64`; file formats (glTF)
//! live in `squish-io`, which converts into these types.
//!
//! Conventions follow glTF 2.0 (so that files convert without reinterpretation):
//! - a local transform is `T · R · S` (translation, unit-quaternion rotation, scale) or a matrix;
//! - a node's world transform is `world(parent) · local(node)`;
//! - samplers interpolate LINEAR (slerp along the shortest arc for rotations), STEP, or
//!   CUBICSPLINE (Hermite with per-key in/out tangents, rotations normalized afterwards), and
//!   clamp to the first / last key outside their time range;
//! - [`Keyframed`] parameters are keyed on scene frames (linear, smooth or step) for the
//!   deformer's animated settings.

mod clip;
mod keyframes;
mod sampler;
mod skeleton;
mod transform;

pub use clip::{AnimationClip, Channel, ChannelValues, evaluate};
pub use keyframes::{KeyInterpolation, KeyTrack, KeyValue, KeyframeError, Keyframed};
pub use sampler::{Interpolation, Keyframe, Sampler, slerp_shortest};
pub use skeleton::{Skeleton, SkeletonNode};
pub use transform::{NodeTransform, Trs};

/// What is wrong with a skeleton, a sampler or a clip. Every variant names the element at fault.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AnimationError {
    #[error("node {node} has parent {parent}, but the skeleton has only {nodes} nodes (valid parents are 0..{nodes})")]
    ParentOutOfRange { node: usize, parent: usize, nodes: usize },
    #[error("node {node} is its own ancestor (the parent links form a cycle); a skeleton must be a forest")]
    Cycle { node: usize },
    #[error("the sampler has no keyframe; give at least one time and value")]
    EmptySampler,
    #[error("sampler key {key} has a non-finite time or value; every key must be a finite number")]
    NonFinite { key: usize },
    #[error("sampler key {key} has time {time}, earlier than the previous key's {previous}; key times must increase")]
    TimesNotIncreasing { key: usize, previous: f64, time: f64 },
    #[error("the sampler has {times} key times but {values} values; {interpolation} needs {expected}")]
    ValueCount { times: usize, values: usize, expected: usize, interpolation: &'static str },
    #[error("sampler key {key} has a zero-length rotation quaternion; rotations must be unit quaternions")]
    ZeroRotation { key: usize },
    #[error("channel {channel} targets node {node}, but the skeleton has only {nodes} nodes")]
    ChannelNodeOutOfRange { channel: usize, node: usize, nodes: usize },
}
