//! Bindings for `miniskeleton_core::primitives`: generated test meshes and bone chains.

use crate::convert::from_rows;
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Most rings, segments or bones a generator makes (16M vertices at most; bounds the memory).
const MAX_COUNT: usize = 4096;

fn at_most(count: usize, name: &str) -> PyResult<usize> {
    if count > MAX_COUNT {
        return Err(PyValueError::new_err(format!("{name} must be at most {MAX_COUNT}, got {count}")));
    }
    Ok(count)
}

/// A triangle mesh for Python: vertices float32 (n,3), triangles uint32 (m,3).
type MeshArrays<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<u32>>);
/// A bone chain for Python: heads float32 (b,3), tails float32 (b,3), parents int32 (b,).
type ChainArrays<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<i32>>);

/// Closed capped cylinder along +Z: (vertices float32 (n,3), triangles uint32 (m,3)).
#[pyfunction]
#[pyo3(signature = (radius=0.5, height=4.0, rings=32, segments=32))]
pub fn capped_cylinder<'py>(
    py: Python<'py>,
    radius: f32,
    height: f32,
    rings: usize,
    segments: usize,
) -> PyResult<MeshArrays<'py>> {
    let (rings, segments) = (at_most(rings, "rings")?.max(1), at_most(segments, "segments")?.max(3));
    let (v, t) = miniskeleton_core::primitives::capped_cylinder(radius, height, rings, segments);
    Ok((from_rows(py, &v)?, from_rows(py, &t)?))
}

/// Straight chain of equal bones along +Z: (heads (b,3), tails (b,3), parents int32 (b,)).
#[pyfunction]
#[pyo3(signature = (height=4.0, bones=4))]
pub fn bone_chain<'py>(py: Python<'py>, height: f32, bones: usize) -> PyResult<ChainArrays<'py>> {
    let (h, t, p) = miniskeleton_core::primitives::bone_chain(height, at_most(bones, "bones")?.max(1));
    Ok((from_rows(py, &h)?, from_rows(py, &t)?, PyArray1::from_vec(py, p)))
}

/// Flat-shaded copy: every triangle gets its own three vertices (like a glTF import of a flat
/// mesh). ValueError for an index past the vertices, naming the triangle.
#[pyfunction]
pub fn split_flat<'py>(
    py: Python<'py>,
    vertices: numpy::PyArrayLike2<'py, f32, numpy::AllowTypeChange>,
    triangles: crate::convert::IndexRows<'py>,
) -> PyResult<MeshArrays<'py>> {
    let v = crate::convert::rows::<f32, 3>(&vertices, "vertices")?;
    let t = crate::convert::index_rows::<u32, 3>(&triangles, "triangles")?;
    let (sv, st) = miniskeleton_core::primitives::split_flat(&v, &t).map_err(crate::error::to_py)?;
    Ok((from_rows(py, &sv)?, from_rows(py, &st)?))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(capped_cylinder, m)?)?;
    m.add_function(wrap_pyfunction!(bone_chain, m)?)?;
    m.add_function(wrap_pyfunction!(split_flat, m)?)?;
    Ok(())
}
