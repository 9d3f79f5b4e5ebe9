//! Animation clips: channels driving node translation, rotation or scale through samplers.

use glam::{DQuat, DVec3};

use super::{AnimationError, NodeTransform, Sampler, Skeleton, Trs};

/// The property a channel drives, with its sampler.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum ChannelValues {
    Translation(Sampler<DVec3>),
    Rotation(Sampler<DQuat>),
    Scale(Sampler<DVec3>),
}

impl ChannelValues {
    fn times(&self) -> &[f64] {
        match self {
            Self::Translation(s) | Self::Scale(s) => s.times(),
            Self::Rotation(s) => s.times(),
        }
    }
}

/// One animated property of one node.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Channel {
    /// Target node id in the skeleton.
    pub node: usize,
    pub values: ChannelValues,
}

/// A named set of channels. Nodes and properties without a channel keep their rest value.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AnimationClip {
    pub name: String,
    pub channels: Vec<Channel>,
}

impl AnimationClip {
    /// Earliest and latest key time over all channels, `None` without channels.
    pub fn time_range(&self) -> Option<(f64, f64)> {
        self.channels.iter().fold(None, |range, c| {
            let times = c.values.times();
            let (lo, hi) = (times[0], times[times.len() - 1]);
            Some(match range {
                None => (lo, hi),
                Some((a, b)) => (lo.min(a), hi.max(b)),
            })
        })
    }

    /// Duration: the latest key time (the clip plays from time 0, as glTF viewers and Blender
    /// play it; keys may start later, in which case the first value holds until then).
    pub fn duration(&self) -> f64 {
        self.time_range().map_or(0.0, |(_, end)| end.max(0.0))
    }

    /// Checks that every channel targets a node of `skeleton`.
    pub fn check(&self, skeleton: &Skeleton) -> Result<(), AnimationError> {
        for (channel, c) in self.channels.iter().enumerate() {
            if c.node >= skeleton.len() {
                return Err(AnimationError::ChannelNodeOutOfRange { channel, node: c.node, nodes: skeleton.len() });
            }
        }
        Ok(())
    }

    /// Local transforms of every node of `skeleton` at `time`: rest transforms overridden by
    /// the channels (a later channel on the same property wins). An animated node whose rest
    /// transform is a matrix is decomposed first (glTF forbids animating matrix nodes; this is
    /// the most sensible reading of files that do).
    pub fn evaluate(&self, skeleton: &Skeleton, time: f64) -> Result<Vec<NodeTransform>, AnimationError> {
        self.check(skeleton)?;
        let mut pose = skeleton.rest_pose();
        for c in &self.channels {
            let mut trs: Trs = pose[c.node].to_trs();
            match &c.values {
                ChannelValues::Translation(s) => trs.translation = s.sample(time),
                ChannelValues::Rotation(s) => trs.rotation = s.sample(time),
                ChannelValues::Scale(s) => trs.scale = s.sample(time),
            }
            pose[c.node] = NodeTransform::Trs(trs);
        }
        Ok(pose)
    }
}

/// Evaluates `clip` on `skeleton` at `time` (see [`AnimationClip::evaluate`]).
pub fn evaluate(clip: &AnimationClip, skeleton: &Skeleton, time: f64) -> Result<Vec<NodeTransform>, AnimationError> {
    clip.evaluate(skeleton, time)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::animation::{Interpolation, SkeletonNode};
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn evaluate_overrides_only_animated_properties() {
        let rest = Trs { translation: DVec3::new(0.0, 1.0, 0.0), rotation: DQuat::IDENTITY, scale: DVec3::splat(2.0) };
        let skeleton = Skeleton::new(vec![
            SkeletonNode { name: "root".into(), parent: None, rest: NodeTransform::Trs(Trs::IDENTITY) },
            SkeletonNode { name: "arm".into(), parent: Some(0), rest: NodeTransform::Trs(rest) },
        ])
        .unwrap();
        let clip = AnimationClip {
            name: "bend".into(),
            channels: vec![Channel {
                node: 1,
                values: ChannelValues::Rotation(
                    Sampler::new_rotation(
                        vec![0.5, 1.5],
                        vec![DQuat::IDENTITY, DQuat::from_rotation_z(FRAC_PI_2)],
                        Interpolation::Linear,
                    )
                    .unwrap(),
                ),
            }],
        };
        assert_eq!(clip.time_range(), Some((0.5, 1.5)));
        assert_eq!(clip.duration(), 1.5);
        let pose = clip.evaluate(&skeleton, 1.5).unwrap();
        let trs = pose[1].to_trs();
        assert_eq!(trs.translation, rest.translation);
        assert_eq!(trs.scale, rest.scale);
        let world = skeleton.world_transforms(&pose);
        // x scaled by 2, rotated onto +y, offset by the rest translation.
        let p = world[1].transform_point3(DVec3::X);
        assert!((p - DVec3::new(0.0, 3.0, 0.0)).length() < 1e-12, "{p}");
        let bad =
            AnimationClip { name: String::new(), channels: vec![Channel { node: 7, ..clip.channels[0].clone() }] };
        assert!(matches!(bad.evaluate(&skeleton, 0.0), Err(AnimationError::ChannelNodeOutOfRange { node: 7, .. })));
    }
}
