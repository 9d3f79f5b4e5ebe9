//! # squish-shot — shots of the Squish deformer, for every front end
//!
//! What the `squish` command (`crates/squish-cli`) and the Python module (`crates/squish-py`)
//! share so that they compute and write the same things, bit for bit:
//!
//! - [`scene_run`]: a scene file run into an output folder (`squish run`, `Scene.run`, each Ray
//!   task): [`scene_shot`] evaluates the scene's frames, [`shot`] computes them in parallel (one
//!   `Deformer` per worker), [`outputs`] writes them in the scene's format, [`report_parts`]
//!   writes this run's report part and merges every part of the folder into `report.json`, and
//!   [`parts`] merges the parts of a split shot's files holding every frame (glb, gltf, pc2);
//! - [`quality`], [`frame_quality`] and [`report`]: the figures of `report.json` and the quality
//!   plots;
//! - [`two_objects`]: one frame of two meshes (`squish deform` / `contact`, `squish.deform` /
//!   `contact`);
//! - [`schema`]: the parameter schema as JSON;
//! - [`interrupt`]: a stop request that lets the frames in progress finish;
//! - [`error`]: errors as data ([`ShotError`]), worded by each front end ([`error::Wording`]).
//!
//! Layers, bottom first (each module uses only those below it; `tests/module_graph.rs`):
//! `error` · `files`, `interrupt`, `report`, `schema` · `frame_quality` · `shot`,
//! `two_objects` · `quality`, `report_parts`, `scene_shot` · `outputs` · `parts` · `scene_run`.
//! Below the crate: `squish-io`, `squish-render` and the core; above it: the command line and
//! the Python module, which add only their arguments, printing, pictures and words.

pub mod error;
pub mod files;
pub mod frame_quality;
pub mod interrupt;
pub mod outputs;
pub mod parts;
pub mod quality;
pub mod report;
pub mod report_parts;
pub mod scene_run;
pub mod scene_shot;
pub mod schema;
pub mod shot;
pub mod two_objects;

pub use error::{ErrorKind, ShotError, Wording};
pub use interrupt::Interrupt;
