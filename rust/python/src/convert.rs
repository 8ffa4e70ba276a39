//! numpy <-> slice conversion. Any float/int array-like is accepted and cast; shapes are checked.

use numpy::ndarray::Array2;
use numpy::{AllowTypeChange, IntoPyArray, PyArray2, PyArrayLike1, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The row count `n` of an array of shape `(n, c)` that must be `(n, C)` (any shape when empty).
fn rows_of<const C: usize>((n, c): (usize, usize), name: &str) -> PyResult<usize> {
    if c != C && n != 0 {
        return Err(PyValueError::new_err(format!("{name} must have shape (n, {C}), got ({n}, {c})")));
    }
    Ok(n)
}

/// An (n, C) array as `Vec<[T; C]>`; `name` is used in the error message.
pub fn rows<T: numpy::Element + Copy + Default, const C: usize>(
    arr: &PyArrayLike2<'_, T, AllowTypeChange>,
    name: &str,
) -> PyResult<Vec<[T; C]>> {
    let view = arr.as_array();
    let n = rows_of::<C>(view.dim(), name)?;
    let mut out = vec![[T::default(); C]; n];
    for (i, row) in view.outer_iter().enumerate() {
        for (j, v) in row.iter().enumerate().take(C) {
            out[i][j] = *v;
        }
    }
    Ok(out)
}

/// An (n, C) array of indices (any integer array-like, read as i64).
pub type IndexRows<'py> = PyArrayLike2<'py, i64, AllowTypeChange>;

/// An (n, C) array of indices as `Vec<[u32; C]>`: a negative index, or one past u32, is an
/// error naming it (cast straight to u32, -1 would read as 4294967295 and 2^32 as 0).
pub fn index_rows<const C: usize>(arr: &IndexRows<'_>, name: &str) -> PyResult<Vec<[u32; C]>> {
    let view = arr.as_array();
    let n = rows_of::<C>(view.dim(), name)?;
    let mut out = vec![[0u32; C]; n];
    for ((i, j), &v) in view.indexed_iter() {
        out[i][j] = u32::try_from(v)
            .map_err(|_| PyValueError::new_err(format!("{name}[{i}, {j}] is {v}: indices must be in 0..2^32")))?;
    }
    Ok(out)
}

/// A 1-D array as a `Vec<T>`.
pub fn vector<T: numpy::Element + Copy>(arr: &PyArrayLike1<'_, T, AllowTypeChange>) -> Vec<T> {
    arr.as_array().iter().copied().collect()
}

/// A row-major buffer of `n * k` values as an (n, k) numpy array.
pub fn matrix<'py, T: numpy::Element>(
    py: Python<'py>,
    data: Vec<T>,
    n: usize,
    k: usize,
) -> PyResult<Bound<'py, PyArray2<T>>> {
    Array2::from_shape_vec((n, k), data).map(|a| a.into_pyarray(py)).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// `Vec<[T; C]>` as an (n, C) numpy array.
pub fn from_rows<'py, T: numpy::Element + Copy, const C: usize>(
    py: Python<'py>,
    data: &[[T; C]],
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let flat: Vec<T> = data.iter().flat_map(|r| r.iter().copied()).collect();
    matrix(py, flat, data.len(), C)
}
