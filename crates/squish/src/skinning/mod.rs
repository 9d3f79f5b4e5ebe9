//! Skinning: linear blend skinning of a rest mesh by a skeleton pose ([`lbs`], thesis §2.3.1),
//! which produces the per-frame input meshes of an animated character, and the self-contact of
//! skinned articulations (thesis ch. 6): overlapping working regions and their partition of unity
//! ([`articulation`], [`partition`]), the crease cut and the blended, volume-preserving
//! deformation ([`self_contact`]).

pub mod articulation;
pub mod lbs;
pub mod partition;
pub mod self_contact;

pub use articulation::{ArticulationError, articulation_direction, joints_direction, regions_from_skin_weights};
pub use lbs::{Skin, SkinError, SkinWeights, joint_matrices, linear_blend_skinning};
pub use partition::{Seed, SharedRegion};
pub use self_contact::{
    AppliedArticulations, ArticulationPlan, ArticulationSetup, ArticulationStats, SelfContactError,
    SelfIntersectionCounts, apply_articulations, plan_articulation, self_intersection_counts,
};
