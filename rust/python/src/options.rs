//! Keyword arguments into the core's option structs: each function that takes options reads its
//! `**options` into the core's `Default` value, so the defaults have one home (the core) and
//! Python's keywords keep their names. An unknown keyword is a `TypeError` naming it, as
//! Python's own; `None` for an optional keyword is as not given.

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// `options` (the `**options` of `function`) read into `into`: `set(into, key, value)` takes a
/// keyword it knows and returns `Ok(false)` for one it does not.
pub fn read_options<T>(
    function: &str,
    options: Option<&Bound<'_, PyDict>>,
    mut into: T,
    mut set: impl FnMut(&mut T, &str, &Bound<'_, PyAny>) -> PyResult<bool>,
) -> PyResult<T> {
    for (key, value) in options.into_iter().flat_map(|d| d.iter()) {
        let key: String = key.extract()?;
        if !set(&mut into, &key, &value)? {
            return Err(PyTypeError::new_err(format!("{function}() got an unexpected keyword argument '{key}'")));
        }
    }
    Ok(into)
}

/// The keyword argument `value` of `key` as a `T`; a `TypeError` names the keyword, as pyo3
/// names the arguments of a signature.
pub fn keyword<'a, 'py, T: FromPyObject<'a, 'py>>(value: &'a Bound<'py, PyAny>, key: &str) -> PyResult<T> {
    value.extract::<T>().map_err(|e| {
        let e: PyErr = e.into();
        if e.is_instance_of::<PyTypeError>(value.py()) {
            PyTypeError::new_err(format!("argument '{key}': {}", e.value(value.py())))
        } else {
            e
        }
    })
}

/// An optional keyword argument: `None` (as not given), or `value` read as a `T` and converted.
pub fn optional<'a, 'py, T: FromPyObject<'a, 'py>, U>(
    value: &'a Bound<'py, PyAny>,
    key: &str,
    convert: impl FnOnce(T) -> PyResult<U>,
) -> PyResult<Option<U>> {
    if value.is_none() {
        return Ok(None);
    }
    keyword(value, key).and_then(convert).map(Some)
}
