//! The pipeline's tests, through the library's public API: whole frames on procedural scenes and
//! the shared meshes (`frames`), working regions and many contacts (`regions`), and the
//! self-contact stage inside a frame (`self_contact`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod edits;
mod frames;
mod gap;
mod open_meshes;
mod regions;
mod self_contact;
mod warnings;
