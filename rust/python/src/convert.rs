//! numpy <-> slice conversion. Any float/int array-like is accepted and cast; shapes are checked,
//! and indices must be whole numbers in range.

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

/// Indices of any numeric array-like, read as f64 so that a float index such as 1.7 is an error
/// rather than numpy's silent cast to 1 (and -1 or 2^32 are not wrapped into range).
pub type IndexRows<'py> = PyArrayLike2<'py, f64, AllowTypeChange>;
/// A 1-D array-like of indices, read as [`IndexRows`] are.
pub type Indices<'py> = PyArrayLike1<'py, f64, AllowTypeChange>;

/// An integer type indices are converted to, with its range as said in errors.
pub trait Index: TryFrom<i64> + Copy + Default {
    const RANGE: &'static str;
}
impl Index for u32 {
    const RANGE: &'static str = "0..2^32";
}
impl Index for i32 {
    const RANGE: &'static str = "-2^31..2^31";
}

/// `v` as a whole number of type `T`, or an error naming `name` at `at` and the value given
/// (`at` is only formatted on error: it is called once per index of a large mesh).
fn index<T: Index>(v: f64, name: &str, at: impl FnOnce() -> String) -> PyResult<T> {
    let whole = v.is_finite() && v.fract() == 0.0 && v.abs() < 2f64.powi(63);
    let out = if whole { T::try_from(v as i64).ok() } else { None };
    out.ok_or_else(|| {
        PyValueError::new_err(format!("{name}{} is {v}: indices must be whole numbers in {}", at(), T::RANGE))
    })
}

/// An (n, C) array of indices as `Vec<[T; C]>`; a value that is not a whole number in `T`'s
/// range is an error naming its place.
pub fn index_rows<T: Index, const C: usize>(arr: &IndexRows<'_>, name: &str) -> PyResult<Vec<[T; C]>> {
    rows_of::<C>(arr.as_array().dim(), name)?;
    let flat = index_matrix::<T>(arr, name)?;
    Ok(flat.chunks_exact(C).map(|row| std::array::from_fn(|j| row[j])).collect())
}

/// An (n, k) array of indices, row after row, checked as [`index_rows`] checks.
pub fn index_matrix<T: Index>(arr: &IndexRows<'_>, name: &str) -> PyResult<Vec<T>> {
    arr.as_array().indexed_iter().map(|((i, j), &v)| index(v, name, || format!("[{i}, {j}]"))).collect()
}

/// A 1-D array of indices as `Vec<T>`, checked as [`index_rows`] checks.
pub fn indices<T: Index>(arr: &Indices<'_>, name: &str) -> PyResult<Vec<T>> {
    arr.as_array().iter().enumerate().map(|(i, &v)| index(v, name, || format!("[{i}]"))).collect()
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

/// `#[pymethods]` for a frozen result class whose named fields also unpack and index in order,
/// as a `NamedTuple`'s do (`indices, weights = heat_weights(...)`): `__iter__`, `__len__` and
/// `__getitem__`.
macro_rules! unpacks_as {
    ($ty:ty, $($field:ident),+) => {
        #[pymethods]
        impl $ty {
            fn __iter__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyIterator>> {
                self.fields(py)?.as_any().try_iter()
            }

            fn __len__(&self) -> usize {
                [$(stringify!($field)),+].len()
            }

            fn __getitem__<'py>(&self, py: Python<'py>, index: isize) -> PyResult<Bound<'py, PyAny>> {
                self.fields(py)?.as_any().get_item(index)
            }
        }

        impl $ty {
            fn fields<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
                pyo3::types::PyTuple::new(py, [$(self.$field.clone_ref(py).into_any()),+])
            }
        }
    };
}
pub(crate) use unpacks_as;
