//! Bindings for `miniskeleton_core::primitives`: generated test meshes and bone chains.

use crate::convert::{from_rows, unpacks_as};
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

/// A triangle mesh: vertices float32 (n,3), triangles uint32 (m,3); they unpack in that order.
#[pyclass(name = "TriangleMesh", module = "miniskeleton_core", frozen, get_all)]
pub struct PyTriangleMesh {
    vertices: Py<PyArray2<f32>>,
    triangles: Py<PyArray2<u32>>,
}
unpacks_as!(PyTriangleMesh, vertices, triangles);

fn triangle_mesh(py: Python<'_>, v: &[[f32; 3]], t: &[[u32; 3]]) -> PyResult<PyTriangleMesh> {
    Ok(PyTriangleMesh { vertices: from_rows(py, v)?.unbind(), triangles: from_rows(py, t)?.unbind() })
}

/// A bone chain: heads float32 (b,3), tails float32 (b,3), parents int32 (b,); they unpack in
/// that order.
#[pyclass(name = "BoneChain", module = "miniskeleton_core", frozen, get_all)]
pub struct PyBoneChain {
    heads: Py<PyArray2<f32>>,
    tails: Py<PyArray2<f32>>,
    parents: Py<PyArray1<i32>>,
}
unpacks_as!(PyBoneChain, heads, tails, parents);

/// Closed capped cylinder along +Z: (vertices float32 (n,3), triangles uint32 (m,3)).
#[pyfunction]
#[pyo3(signature = (radius=0.5, height=4.0, rings=32, segments=32))]
pub fn capped_cylinder<'py>(
    py: Python<'py>,
    radius: f32,
    height: f32,
    rings: usize,
    segments: usize,
) -> PyResult<PyTriangleMesh> {
    let (rings, segments) = (at_most(rings, "rings")?.max(1), at_most(segments, "segments")?.max(3));
    let (v, t) = miniskeleton_core::primitives::capped_cylinder(radius, height, rings, segments);
    triangle_mesh(py, &v, &t)
}

/// Straight chain of equal bones along +Z: (heads (b,3), tails (b,3), parents int32 (b,)).
#[pyfunction]
#[pyo3(signature = (height=4.0, bones=4))]
pub fn bone_chain(py: Python<'_>, height: f32, bones: usize) -> PyResult<PyBoneChain> {
    let (h, t, p) = miniskeleton_core::primitives::bone_chain(height, at_most(bones, "bones")?.max(1));
    let (heads, tails) = (from_rows(py, &h)?.unbind(), from_rows(py, &t)?.unbind());
    Ok(PyBoneChain { heads, tails, parents: PyArray1::from_vec(py, p).unbind() })
}

/// Flat-shaded copy: every triangle gets its own three vertices (like a glTF import of a flat
/// mesh). ValueError for an index past the vertices, naming the triangle.
#[pyfunction]
pub fn split_flat<'py>(
    py: Python<'py>,
    vertices: numpy::PyArrayLike2<'py, f32, numpy::AllowTypeChange>,
    triangles: crate::convert::IndexRows<'py>,
) -> PyResult<PyTriangleMesh> {
    let v = crate::convert::rows::<f32, 3>(&vertices, "vertices")?;
    let t = crate::convert::index_rows::<u32, 3>(&triangles, "triangles")?;
    let (sv, st) = miniskeleton_core::primitives::split_flat(&v, &t).map_err(crate::error::to_py)?;
    triangle_mesh(py, &sv, &st)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyTriangleMesh>()?;
    m.add_class::<PyBoneChain>()?;
    m.add_function(wrap_pyfunction!(capped_cylinder, m)?)?;
    m.add_function(wrap_pyfunction!(bone_chain, m)?)?;
    m.add_function(wrap_pyfunction!(split_flat, m)?)?;
    Ok(())
}
