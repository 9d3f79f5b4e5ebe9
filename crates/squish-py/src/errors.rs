//! Rust errors as the package's Python exceptions (declared in `python/squish/_errors.py`, so
//! that they share the base `squish.SquishError` and are also `ValueError`s), and JSON reports as
//! Python objects. The shot machinery's errors ([`ShotError`], data) are worded here, once, in
//! Python's terms ([`PythonWords`]: `frames=range(3, 5)`, `threads=0`, `output=`,
//! `pair_direction=(0, 0, 1)`), and given their exception class by their kind.

use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use squish_shot::error::{ErrorKind, SettingValue, ShotError, Wording};

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

/// Python's names for the settings a message tells the user to change: the keyword arguments
/// of `Scene.run`, `Frame.deform` and the two-mesh calls.
pub struct PythonWords;

impl Wording for PythonWords {
    fn frames_option(&self) -> &'static str {
        "the frames= argument"
    }
    fn frames_given(&self, text: &str) -> String {
        // `Scene.run` reads a range, a list or a frame as the text `A:B` (inclusive): show the range.
        let pair = text
            .split_once(':')
            .and_then(|(a, b)| Some((a.trim().parse::<i64>().ok()?, b.trim().parse::<i64>().ok()?)));
        match pair {
            Some((a, b)) => format!("frames=range({a}, {})", b + 1),
            None => format!("frames={text:?}"),
        }
    }
    fn frames(&self, first: i64, last: i64) -> String {
        format!("frames=range({first}, {})", last + 1)
    }
    fn threads(&self, n: usize) -> String {
        format!("threads={n}")
    }
    fn output(&self) -> &'static str {
        "output="
    }
    fn place(&self) -> &'static str {
        "in Python"
    }
    fn parameter(&self, prefix: &str, key: &str, value: SettingValue) -> String {
        let value = match value {
            SettingValue::Vector([x, y, z]) => format!("({x:?}, {y:?}, {z:?})"),
            SettingValue::Word(word) => format!("\"{word}\""),
            SettingValue::Bool(true) => "True".to_string(),
            SettingValue::Bool(false) => "False".to_string(),
        };
        format!("{prefix}_{key}={value}")
    }
}

/// An error of the shot machinery, by its kind: bad input is `InputError`, a parameter
/// `ParameterError`, a stop `KeyboardInterrupt`, anything else `SquishError`; the message in
/// Python's words.
pub fn shot_error(error: ShotError) -> PyErr {
    let message = error.message(&PythonWords);
    match error.kind() {
        ErrorKind::Input => InputError::new_err(message),
        ErrorKind::Parameter => ParameterError::new_err(message),
        ErrorKind::Interrupted => PyKeyboardInterrupt::new_err(message),
        ErrorKind::Failure => SquishError::new_err(message),
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
