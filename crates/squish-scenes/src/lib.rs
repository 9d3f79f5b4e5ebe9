//! # Squish scenes — procedural and benchmark scenes, outside the core
//!
//! Scenes built from the core's own shapes, for `squish demo`, `squish bench`, the criterion
//! benchmarks and the pipeline's tests; none of them is part of the core library's API.
//! - [`procedural`]: small scenes of closed objects (a ball pressed into soft ground, crossed
//!   capsules, fingers, an arm folding at its elbow), each a function of the penetration depth or
//!   the angle, so that an animation is a sweep;
//! - [`bench`]: animated scenes at the sizes of the thesis' performance tables (ch. 7 §5,
//!   tables 7.1–7.3), each with the thesis row it is compared with;
//! - [`characters`]: rigged characters for whole-character self-contact (issue 36): a procedural
//!   humanoid in a squat, a crouch and with crossed arms, and CesiumMan subdivided to ≥ 15k
//!   vertices, posed by linear blend skinning;
//! - [`shots`]: issue 36's figures for a character's shot with `self_contact = "auto"` against
//!   plain skinning (jitter, locality, faces, volume, time) and the continuity check;
//! - [`timing`]: the timing of one region's factorizations, the reference a frame is measured
//!   against;
//! - [`work_guard`]: the bounds of the clock-free guard on each stage's work.

pub mod bench;
pub mod characters;
pub mod fem;
pub mod procedural;
pub mod shots;
pub mod timing;
pub mod work_guard;
