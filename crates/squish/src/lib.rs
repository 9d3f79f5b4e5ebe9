//! # Squish — a time-independent deformer for elastic contacts
//!
//! The core library: pure computation on triangle meshes in `f64`, no file formats and no UI.
//! It implements the thesis *Time-independent geometrical deformation for elastic contacts*
//! (Brunel 2022; method A: Brunel, Bénard, Guennebaud, Barla 2020; method B: Brunel, Bénard,
//! Guennebaud, SIGGRAPH 2021): meshes that intersect at one frame go in, meshes in clean contact
//! with a volume-preserving bulge come out, and no frame depends on another.
//!
//! Modules follow the pipeline (see `docs/architecture.md`):
//! - [`mesh`]: triangle meshes, topology, geometry, working regions, procedural shapes;
//! - [`linalg`]: cotangent Laplacian with cut-face weights, least-squares edge constraints,
//!   sparse Cholesky with symbolic reuse (thesis App. B);
//! - [`spatial`]: bounding volume hierarchies, ray and segment queries, exact triangle tests;
//! - [`contact`]: intersection, mapping, potential contact surface and contact zones (ch. 4);
//! - [`deform`]: radial parametrization, direction field, amplitude/slope fields, profile curve,
//!   volume-preserving bulge and bulge maps of one working region (ch. 5);
//! - [`animation`], [`skinning`]: skeletal animation evaluation and linear blend skinning;
//! - [`params`]: the one declaration of every user-facing parameter and its schema.

// `#[derive(Params)]` names this crate `::squish`, inside it as outside.
extern crate self as squish;

pub mod animation;
pub mod contact;
pub mod deform;
pub mod linalg;
pub mod mesh;
pub mod params;
pub mod pipeline;
pub mod skinning;
pub mod spatial;
pub mod stage;

pub use glam::DVec3;
pub use mesh::{MeshError, SubMesh, Topology, TriMesh};
pub use params::{ArticulationParams, ObjectParams, PairParams, ParamError, Params};
pub use pipeline::{Deformer, Frame, FrameObject, FramePair, FrameResult, FrameStats, OwnedFrame, OwnedObject};
