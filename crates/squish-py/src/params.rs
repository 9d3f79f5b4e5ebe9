//! Parameters from Python: dicts and keyword arguments whose keys are the schema's, values as
//! [`ParamValue`]s, set through [`Params::set`] and checked by [`Params::validate`], so that the
//! keys, ranges and messages are those of the command line and the scene files.
//!
//! Values: `True`/`False`; an int or a float; a string, read as `--set` reads its text (`"auto"`,
//! `"ball"`, `"inf"`, `"0,0,1"`); a sequence or NumPy array of numbers (a direction `[x, y, z]`, a
//! pair `[a, b]`, one value per vertex).
//! Errors name the key with its prefix (`a.stiffness`, `pair.contact_tau`), as `--set` does.

use numpy::{PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};
use squish::params::{ParamError, ParamInfo, ParamKind, ParamValue, Params, unknown_key};

use crate::errors::parameter_error;

/// A Python value as a parameter value for `info`'s key. A string is read as the command line
/// reads `--set` text ([`ParamInfo::parse`]), with its messages.
fn param_value(value: &Bound<'_, PyAny>, info: &ParamInfo) -> Result<ParamValue, ParamError> {
    let key = info.key;
    let wrong = |what: String| ParamError::new(key, None, what);
    if value.is_instance_of::<PyBool>() {
        return Ok(ParamValue::Bool(value.extract::<bool>().map_err(|e| wrong(e.to_string()))?));
    }
    if value.is_instance_of::<PyInt>() || value.is_instance_of::<PyFloat>() {
        let x: f64 = value.extract().map_err(|e: PyErr| wrong(e.to_string()))?;
        return Ok(ParamValue::Number(x));
    }
    if value.is_instance_of::<PyString>() {
        let text: String = value.extract().map_err(|e: PyErr| wrong(e.to_string()))?;
        return info.parse(&text).map_err(wrong);
    }
    // NumPy scalars (np.float64, np.int32, np.bool_) convert like Python's.
    if let Ok(item) = value.call_method0("item")
        && !value.hasattr("__len__").unwrap_or(false)
    {
        return param_value(&item, info);
    }
    if let Ok(array) = value.extract::<PyReadonlyArray1<'_, f64>>() {
        return Ok(ParamValue::List(array.as_array().to_vec()));
    }
    let numbers = value.py().import("numpy").and_then(|np| np.call_method1("asarray", (value, "float64")));
    match numbers.as_ref().map(|a| a.extract::<PyReadonlyArray1<'_, f64>>()) {
        Ok(Ok(array)) if array.ndim() == 1 => Ok(ParamValue::List(array.as_array().to_vec())),
        _ => Err(wrong(format!(
            "cannot read {} as a parameter value; give True/False, a number, a word or a list of numbers",
            value.repr().map_or_else(|_| "the value".to_string(), |r| r.to_string())
        ))),
    }
}

/// Sets every `(key, value)` of `items` on `params`; errors name the key as `prefix.key`.
pub fn apply<P: Params>(params: &mut P, prefix: &str, items: &Bound<'_, PyDict>) -> PyResult<()> {
    for (key, value) in items.iter() {
        let key: String = key
            .extract()
            .map_err(|_| parameter_error(ParamError::new(prefix, None, "parameter names must be strings")))?;
        let Some(info) = P::info(&key) else {
            return Err(parameter_error(unknown_key::<P>(&key).with_prefix(prefix)));
        };
        let value = param_value(&value, info).map_err(|e| parameter_error(e.with_prefix(prefix)))?;
        params.set(&key, &value).map_err(|e| parameter_error(e.with_prefix(prefix)))?;
    }
    Ok(())
}

/// Refuses a key given both in a parameters dict (`dict_name`) and as a keyword argument
/// (`keyword(key)`): which one was meant is not for us to guess.
pub fn refuse_twice(
    prefix: &str,
    dict: Option<&Bound<'_, PyDict>>,
    dict_name: &str,
    kwargs: &[(String, Bound<'_, PyAny>)],
    keyword: impl Fn(&str) -> String,
) -> PyResult<()> {
    let Some(dict) = dict else { return Ok(()) };
    for (key, value) in kwargs {
        if let Ok(Some(first)) = dict.get_item(key) {
            let repr = |v: &Bound<'_, PyAny>| v.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
            let message = format!(
                "given twice: {dict_name}['{key}'] = {} and {} = {}; give it once",
                repr(&first),
                keyword(key),
                repr(value)
            );
            return Err(parameter_error(ParamError::new(&format!("{prefix}.{key}"), None, message)));
        }
    }
    Ok(())
}

/// `P` from its defaults, a dict (may be `None`) and keyword arguments (may be `None`), validated.
/// A key in both is an error ([`refuse_twice`]).
pub fn from_python<P: Params>(
    prefix: &str,
    dict: Option<&Bound<'_, PyDict>>,
    kwargs: Option<&Bound<'_, PyDict>>,
) -> PyResult<P> {
    let keywords: Vec<(String, Bound<'_, PyAny>)> = kwargs
        .into_iter()
        .flat_map(|k| k.iter())
        .filter_map(|(key, value)| Some((key.extract::<String>().ok()?, value)))
        .collect();
    refuse_twice(prefix, dict, "params", &keywords, str::to_string)?;
    let mut params = P::default();
    for items in [dict, kwargs].into_iter().flatten() {
        apply(&mut params, prefix, items)?;
    }
    params.validate().map_err(|e| parameter_error(e.with_prefix(prefix)))?;
    Ok(params)
}

/// Checks that every per-vertex parameter of `params` has one value per vertex.
pub fn check_per_vertex<P: Params>(params: &P, prefix: &str, vertex_count: usize) -> PyResult<()> {
    for info in P::schema().iter().filter(|i| i.kind == ParamKind::PerVertex) {
        if let Some(ParamValue::List(values)) = params.get(info.key)
            && values.len() != vertex_count
        {
            let message = format!(
                "has {} values but the mesh has {vertex_count} vertices; give one value per vertex",
                values.len()
            );
            return Err(parameter_error(ParamError::new(&info.qualified(prefix), None, message)));
        }
    }
    Ok(())
}
