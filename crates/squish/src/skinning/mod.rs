//! Skinning: linear blend skinning of a rest mesh by a skeleton pose ([`linear_blend_skinning`],
//! thesis §2.3.1), which produces the per-frame input meshes of an animated character, and the
//! self-contact of skinned articulations (thesis ch. 6): overlapping working regions and their
//! partition of unity ([`Articulation`](crate::params::Articulation), [`SharedRegion`]), the crease cut and the blended,
//! volume-preserving deformation ([`plan_articulation`], [`apply_articulations`]). One private
//! module per step, reached through the items below.

mod articulation;
mod lbs;
mod min_cut;
mod partition;
mod parts;
mod self_contact;

pub use articulation::{ArticulationError, articulation_direction, joints_direction, regions_from_skin_weights};
pub use lbs::{Skin, SkinError, SkinWeights, joint_matrices, linear_blend_skinning};
pub use partition::{Seed, SharedRegion};
pub use parts::{
    FacesBeyond, PartContactSetup, RestIntersections, TouchingKind, TouchingPair, dominant_joints, parts_from_skin,
};
pub use self_contact::{
    AppliedArticulations, ArticulationContact, ArticulationCrossings, ArticulationPlan, ArticulationSetup,
    ArticulationStats, CONTACT_THRESHOLD_FLOOR, FOLD_EXTENT_SCALE, GAP_FRACTION, SelfContactError,
    SelfIntersectionCounts, apply_articulations, articulation_crossings, articulation_interiors, contact_articulation,
    deform_articulation, plan_articulation, self_intersection_counts, self_intersection_counts_from_pairs,
};
