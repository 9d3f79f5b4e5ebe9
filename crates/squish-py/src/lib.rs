//! The native part of the Python package `squish` (`squish._squish`), thin over the core library
//! and the shot machinery it shares with the `squish` command (`squish-shot`).
//!
//! # Contract
//! - Meshes cross the boundary as NumPy arrays: float64 `(n, 3)` vertices and integer `(m, 3)`
//!   faces, copied once into the library's types ([`mesh`]); results come back as new float64
//!   arrays, in the input's vertex order.
//! - Parameters are dicts or keyword arguments whose keys are the schema's (`squish::params`);
//!   values are converted to [`squish::params::ParamValue`] and set through `Params::set`, so
//!   names, ranges and messages are the command line's ([`params`]).
//! - Errors are Python exceptions, never panics: `squish.ParameterError` (a `ValueError`) for a
//!   parameter, `squish.InputError` (a `ValueError`) for a mesh or a file, `squish.SquishError`
//!   for other failures; the message is the command line's one line, with Python's names for
//!   the settings it tells to change ([`errors`]).
//! - The GIL is released while computing; `threads=` bounds every thread a call uses; a scene run
//!   stopped by Ctrl-C finishes the frames in progress, writes its report, then raises
//!   `KeyboardInterrupt` ([`scene`]).

mod errors;
mod frame;
mod mesh;
mod params;
mod scene;
mod skin;

use pyo3::prelude::*;

/// Every parameter of the schema (object, pair, articulation, and the scene file's `frames` and
/// `output`) as a list of dicts: the rows of `squish params --json`.
#[pyfunction]
fn params_schema(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    let text = squish_shot::schema::schema_json().map_err(errors::shot_error)?;
    let schema = errors::json_to_python(py, &text)?;
    schema.get_item("parameters")
}

/// The `squish` version the module was built from.
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _squish(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(params_schema, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    m.add_class::<mesh::Mesh>()?;
    m.add_function(wrap_pyfunction!(mesh::read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::write_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::source_topology, m)?)?;
    m.add_function(wrap_pyfunction!(frame::deform, m)?)?;
    m.add_function(wrap_pyfunction!(frame::contact, m)?)?;
    m.add_class::<frame::Frame>()?;
    m.add_class::<skin::Skin>()?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<scene::ShotResult>()?;
    m.add_function(wrap_pyfunction!(scene::merge_reports, m)?)?;
    Ok(())
}
