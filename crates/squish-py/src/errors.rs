//! Rust errors as the package's Python exceptions (declared in `python/squish/_errors.py`, so
//! that they share the base `squish.SquishError` and are also `ValueError`s), and JSON reports as
//! Python objects.

use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use squish_cli::error::CliError;

pyo3::import_exception!(squish._errors, SquishError);
pyo3::import_exception!(squish._errors, ParameterError);
pyo3::import_exception!(squish._errors, InputError);

/// A parameter that cannot be set: its one-line message (`a.stiffness = -1: must be > 0 (k,
/// default 1)`).
pub fn parameter_error(error: squish::ParamError) -> PyErr {
    ParameterError::new_err(error.to_string())
}

/// A mesh or file problem.
pub fn input_error(message: impl ToString) -> PyErr {
    InputError::new_err(message.to_string())
}

/// An error of the command line's machinery, by its exit code: bad input (2) is `InputError`,
/// a stop (130) `KeyboardInterrupt`, anything else `SquishError`.
pub fn cli_error(error: CliError) -> PyErr {
    match error.exit_code() {
        2 => InputError::new_err(error.to_string()),
        130 => PyKeyboardInterrupt::new_err(error.to_string()),
        _ => SquishError::new_err(error.to_string()),
    }
}

/// A frame the pipeline refused: parameters (including per-vertex values of the wrong length)
/// are `ParameterError`, the rest (meshes) `InputError`.
pub fn pipeline_error(error: squish::pipeline::PipelineError) -> PyErr {
    use squish::pipeline::PipelineError;
    match error {
        PipelineError::Parameter { .. } | PipelineError::PerVertexLength { .. } => {
            ParameterError::new_err(error.to_string())
        }
        _ => InputError::new_err(error.to_string()),
    }
}

/// A file problem of squish-io.
pub fn io_error(error: squish_io::IoError) -> PyErr {
    InputError::new_err(error.to_string())
}

/// A serialization failure (never expected: every report is plain data).
pub fn json_error(error: serde_json::Error) -> PyErr {
    SquishError::new_err(format!("could not serialize JSON: {error}"))
}

/// JSON text as Python objects (dicts, lists, numbers, strings), with Python's own reader.
pub fn json_to_python<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

/// A serializable value as Python objects.
pub fn to_python<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(json_error)?;
    json_to_python(py, &text)
}
