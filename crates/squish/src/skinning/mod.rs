//! Skinning. For now: linear blend skinning of a rest mesh by a skeleton pose ([`lbs`]), which
//! produces the per-frame input meshes of an animated character (thesis §2.3.1). The contact-aware
//! skinning of thesis ch. 6 (shared region, partition of unity, blending) will sit next to it.

pub mod lbs;

pub use lbs::{Skin, SkinError, SkinWeights, joint_matrices, linear_blend_skinning};
