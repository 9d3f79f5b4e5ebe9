//! Linear blend skinning (thesis §2.3.1, "skeletal subspace deformation"):
//! `p'_i = Σ_j w_ij M_j p_i` with `M_j = world(joint j) · inverse_bind(j)`, up to four joint
//! influences per vertex (the glTF `JOINTS_0` / `WEIGHTS_0` layout).

use glam::{DMat4, DVec3};
use rayon::prelude::*;

/// What is wrong with skin data. Every variant names the element at fault.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SkinError {
    #[error("{joints} joint rows but {weights} weight rows; give one row of each per vertex")]
    RowCount { joints: usize, weights: usize },
    #[error("vertex {vertex} has weight {value}; weights must be finite and non-negative")]
    InvalidWeight { vertex: usize, value: f64 },
    #[error("{positions} rest positions but skin weights for {weights} vertices; they must match")]
    VertexCount { positions: usize, weights: usize },
    #[error("vertex {vertex} is influenced by joint {joint}, but the skin has only {joints} joints")]
    JointOutOfRange { vertex: usize, joint: u32, joints: usize },
    #[error("the skin has {joints} joints but {matrices} inverse bind matrices; give one per joint")]
    InverseBindCount { joints: usize, matrices: usize },
    #[error("skin joint {joint} is node {node}, but the pose has only {nodes} nodes")]
    JointNodeOutOfRange { joint: usize, node: usize, nodes: usize },
}

/// Up to four joint influences per vertex.
///
/// Weights are normalized on construction: a vertex whose weights sum to `s > 0` has them all
/// divided by `s` (files store f32 or 8/16-bit quantized weights that only approximately sum to
/// one; skinning with unnormalized weights scales the vertex about the origin). A vertex whose
/// weights are all zero is *unskinned*: [`linear_blend_skinning`] leaves it at its rest position
/// rather than collapsing it to the origin. Negative weights down to −1e−6 (quantization noise)
/// are clamped to zero; below that they are an error.
///
/// Deserialization goes through [`SkinWeights::new`].
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "SkinWeightsParts")]
pub struct SkinWeights {
    joints: Vec<[u32; 4]>,
    weights: Vec<[f64; 4]>,
}

#[derive(serde::Deserialize)]
struct SkinWeightsParts {
    joints: Vec<[u32; 4]>,
    weights: Vec<[f64; 4]>,
}

impl TryFrom<SkinWeightsParts> for SkinWeights {
    type Error = SkinError;
    fn try_from(parts: SkinWeightsParts) -> Result<Self, Self::Error> {
        Self::new(parts.joints, parts.weights)
    }
}

impl SkinWeights {
    /// Checks and normalizes (see the type's documentation).
    pub fn new(joints: Vec<[u32; 4]>, mut weights: Vec<[f64; 4]>) -> Result<Self, SkinError> {
        if joints.len() != weights.len() {
            return Err(SkinError::RowCount { joints: joints.len(), weights: weights.len() });
        }
        for (vertex, row) in weights.iter_mut().enumerate() {
            for w in row.iter_mut() {
                if !w.is_finite() || *w < -1e-6 {
                    return Err(SkinError::InvalidWeight { vertex, value: *w });
                }
                *w = w.max(0.0);
            }
            let sum: f64 = row.iter().sum();
            if sum > 0.0 {
                for w in row.iter_mut() {
                    *w /= sum;
                }
            }
        }
        Ok(Self { joints, weights })
    }

    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.joints.len()
    }

    /// True if there is no vertex.
    pub fn is_empty(&self) -> bool {
        self.joints.is_empty()
    }

    /// Joint indices (into [`Skin::joints`]) per vertex.
    pub fn joints(&self) -> &[[u32; 4]] {
        &self.joints
    }

    /// Normalized weights per vertex.
    pub fn weights(&self) -> &[[f64; 4]] {
        &self.weights
    }

    /// The weights of the vertices `indices` (e.g. to follow a vertex welding or a sub-mesh).
    /// Returns `None` if an index is out of range.
    pub fn select(&self, indices: &[u32]) -> Option<Self> {
        let mut joints = Vec::with_capacity(indices.len());
        let mut weights = Vec::with_capacity(indices.len());
        for &i in indices {
            joints.push(*self.joints.get(i as usize)?);
            weights.push(*self.weights.get(i as usize)?);
        }
        Some(Self { joints, weights })
    }

    /// Appends another set (e.g. when merging mesh primitives).
    pub fn append(&mut self, other: &SkinWeights) {
        self.joints.extend_from_slice(&other.joints);
        self.weights.extend_from_slice(&other.weights);
    }
}

/// A skin: the skeleton nodes acting as joints and their inverse bind matrices (the inverse of
/// each joint's world transform in the pose in which the mesh was bound).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Skin {
    /// Skeleton node id of each joint; [`SkinWeights`] index into this list.
    pub joints: Vec<usize>,
    /// One matrix per joint.
    pub inverse_bind: Vec<DMat4>,
}

impl Skin {
    /// Builds a skin; without inverse bind matrices they are identities (glTF's default).
    pub fn new(joints: Vec<usize>, inverse_bind: Option<Vec<DMat4>>) -> Result<Self, SkinError> {
        let inverse_bind = inverse_bind.unwrap_or_else(|| vec![DMat4::IDENTITY; joints.len()]);
        if inverse_bind.len() != joints.len() {
            return Err(SkinError::InverseBindCount { joints: joints.len(), matrices: inverse_bind.len() });
        }
        Ok(Self { joints, inverse_bind })
    }
}

/// Skinning matrices `M_j = world[joints[j]] · inverse_bind[j]` for a pose's world transforms.
pub fn joint_matrices(skin: &Skin, world: &[DMat4]) -> Result<Vec<DMat4>, SkinError> {
    if skin.inverse_bind.len() != skin.joints.len() {
        return Err(SkinError::InverseBindCount { joints: skin.joints.len(), matrices: skin.inverse_bind.len() });
    }
    skin.joints
        .iter()
        .zip(&skin.inverse_bind)
        .enumerate()
        .map(|(joint, (&node, inverse_bind))| match world.get(node) {
            Some(w) => Ok(*w * *inverse_bind),
            None => Err(SkinError::JointNodeOutOfRange { joint, node, nodes: world.len() }),
        })
        .collect()
}

/// Below this many vertices the thread hand-off costs more than it saves.
const PARALLEL_MIN_VERTICES: usize = 8192;

/// Skinned positions `Σ_j w_ij M_j p_i`. Vertices with all-zero weights keep their rest position
/// (see [`SkinWeights`]). Influences with zero weight are ignored, whatever their joint index.
///
/// Deterministic: each vertex is computed alone, in a fixed order of its four influences, so
/// the parallel and serial paths give identical bits.
pub fn linear_blend_skinning(
    rest_positions: &[DVec3],
    weights: &SkinWeights,
    joint_matrices: &[DMat4],
) -> Result<Vec<DVec3>, SkinError> {
    if rest_positions.len() != weights.len() {
        return Err(SkinError::VertexCount { positions: rest_positions.len(), weights: weights.len() });
    }
    for (vertex, (joints, ws)) in weights.joints.iter().zip(&weights.weights).enumerate() {
        for (&joint, &w) in joints.iter().zip(ws) {
            if w != 0.0 && joint as usize >= joint_matrices.len() {
                return Err(SkinError::JointOutOfRange { vertex, joint, joints: joint_matrices.len() });
            }
        }
    }
    let skin_vertex = |i: usize| -> DVec3 {
        let p = rest_positions[i];
        let mut out = DVec3::ZERO;
        let mut any = false;
        for (&joint, &w) in weights.joints[i].iter().zip(&weights.weights[i]) {
            if w != 0.0 {
                out += w * joint_matrices[joint as usize].transform_point3(p);
                any = true;
            }
        }
        if any { out } else { p }
    };
    let n = rest_positions.len();
    Ok(if n >= PARALLEL_MIN_VERTICES {
        (0..n).into_par_iter().map(skin_vertex).collect()
    } else {
        (0..n).map(skin_vertex).collect()
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::animation::{
        AnimationClip, Channel, ChannelValues, Interpolation, NodeTransform, Sampler, Skeleton, SkeletonNode, Trs,
    };
    use crate::mesh::shapes;
    use glam::DQuat;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn weights_are_normalized_and_zero_rows_kept() {
        let w = SkinWeights::new(vec![[0, 1, 0, 0], [0; 4]], vec![[1.0, 3.0, 0.0, 0.0], [0.0; 4]]).unwrap();
        assert_eq!(w.weights()[0], [0.25, 0.75, 0.0, 0.0]);
        assert_eq!(w.weights()[1], [0.0; 4]);
        assert!(matches!(
            SkinWeights::new(vec![[0; 4]], vec![[-0.5, 1.0, 0.0, 0.0]]),
            Err(SkinError::InvalidWeight { vertex: 0, .. })
        ));
        assert!(matches!(SkinWeights::new(vec![[0; 4]], vec![]), Err(SkinError::RowCount { .. })));
        assert!(serde_json::from_str::<SkinWeights>(r#"{"joints":[[0,0,0,0]],"weights":[]}"#).is_err());
        let json = serde_json::to_string(&w).unwrap();
        assert_eq!(serde_json::from_str::<SkinWeights>(&json).unwrap(), w);
    }

    #[test]
    fn errors_name_the_vertex_and_joint() {
        let w = SkinWeights::new(vec![[0, 5, 0, 0]], vec![[0.5, 0.5, 0.0, 0.0]]).unwrap();
        let err = linear_blend_skinning(&[DVec3::ZERO], &w, &[DMat4::IDENTITY]).unwrap_err();
        assert_eq!(err, SkinError::JointOutOfRange { vertex: 0, joint: 5, joints: 1 });
        let skin = Skin::new(vec![0, 3], None).unwrap();
        assert!(matches!(
            joint_matrices(&skin, &[DMat4::IDENTITY]),
            Err(SkinError::JointNodeOutOfRange { joint: 1, node: 3, .. })
        ));
        assert!(matches!(Skin::new(vec![0], Some(vec![])), Err(SkinError::InverseBindCount { .. })));
    }

    /// A cylinder along +z from 0 to 2 with two bones: bone 0 at the origin, bone 1 at z = 1.
    /// Vertices below z = 0.8 follow bone 0, above z = 1.2 bone 1, linear blend in between.
    /// Bending bone 1 by 90° about x must rotate the upper part rigidly about (0, 0, 1).
    #[test]
    fn two_bone_cylinder_bent_90_degrees() {
        let mut mesh = shapes::capsule(0.2, 1.6, 16, 4, 16);
        mesh.map_positions(|p| p + DVec3::new(0.0, 0.0, 1.0));
        let weights: Vec<[f64; 4]> = mesh
            .positions
            .iter()
            .map(|p| {
                let t = ((p.z - 0.8) / 0.4).clamp(0.0, 1.0);
                [1.0 - t, t, 0.0, 0.0]
            })
            .collect();
        let weights = SkinWeights::new(vec![[0, 1, 0, 0]; mesh.positions.len()], weights).unwrap();
        let bone1_rest = Trs { translation: DVec3::new(0.0, 0.0, 1.0), ..Trs::IDENTITY };
        let skeleton = Skeleton::new(vec![
            SkeletonNode { name: "bone0".into(), parent: None, rest: NodeTransform::Trs(Trs::IDENTITY) },
            SkeletonNode { name: "bone1".into(), parent: Some(0), rest: NodeTransform::Trs(bone1_rest) },
        ])
        .unwrap();
        // Bound in the rest pose: inverse bind = inverse of the rest world transforms.
        let inverse_bind = skeleton.rest_world_transforms().iter().map(|m| m.inverse()).collect();
        let skin = Skin::new(vec![0, 1], Some(inverse_bind)).unwrap();

        // The rest pose reproduces the mesh.
        let rest_world = skeleton.rest_world_transforms();
        let rest =
            linear_blend_skinning(&mesh.positions, &weights, &joint_matrices(&skin, &rest_world).unwrap()).unwrap();
        for (a, b) in rest.iter().zip(&mesh.positions) {
            assert!((*a - *b).length() < 1e-12);
        }

        let clip = AnimationClip {
            name: "bend".into(),
            channels: vec![Channel {
                node: 1,
                values: ChannelValues::Rotation(
                    Sampler::new_rotation(
                        vec![0.0, 1.0],
                        vec![DQuat::IDENTITY, DQuat::from_rotation_x(FRAC_PI_2)],
                        Interpolation::Linear,
                    )
                    .unwrap(),
                ),
            }],
        };
        let world = skeleton.world_transforms(&clip.evaluate(&skeleton, 1.0).unwrap());
        let bent = linear_blend_skinning(&mesh.positions, &weights, &joint_matrices(&skin, &world).unwrap()).unwrap();
        let mut tip_count = 0;
        for (p, q) in mesh.positions.iter().zip(&bent) {
            let expected = if p.z >= 1.2 {
                tip_count += 1;
                // +90° about the x axis through (0, 0, 1) maps (y, z − 1) to (−(z − 1), y).
                DVec3::new(p.x, -(p.z - 1.0), 1.0 + p.y)
            } else if p.z <= 0.8 {
                *p
            } else {
                continue;
            };
            assert!((*q - expected).length() < 1e-12, "{p} → {q}, expected {expected}");
        }
        assert!(tip_count > 50);
        // The very tip (0, 0, 2) ends at (0, −1, 1).
        let tip = mesh.positions.iter().position(|p| (*p - DVec3::new(0.0, 0.0, 2.0)).length() < 1e-12).unwrap();
        assert!((bent[tip] - DVec3::new(0.0, -1.0, 1.0)).length() < 1e-12);

        // Serial and parallel paths agree bit for bit.
        let many: Vec<DVec3> =
            (0..PARALLEL_MIN_VERTICES + 10).map(|i| mesh.positions[i % mesh.positions.len()]).collect();
        let many_weights = weights
            .select(&(0..many.len() as u32).map(|i| i % mesh.positions.len() as u32).collect::<Vec<_>>())
            .unwrap();
        let jm = joint_matrices(&skin, &world).unwrap();
        let par = linear_blend_skinning(&many, &many_weights, &jm).unwrap();
        for (i, q) in par.iter().enumerate() {
            assert_eq!(*q, bent[i % mesh.positions.len()]);
        }
    }
}
