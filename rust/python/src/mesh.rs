//! Bindings for `miniskeleton_core::mesh`: welding points, which meshes meet along a seam, and
//! Catmull-Clark limit positions.

use crate::convert::{from_rows, index_rows, indices, rows, unpacks_as, IndexRows, Indices};
use crate::error::guarded;
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

type F32Rows<'py> = PyArrayLike2<'py, f32, AllowTypeChange>;
/// Welded points: map int32 (n,), the welded point of each point; welded float64 (k,3); they
/// unpack in that order.
#[pyclass(name = "WeldedPoints", module = "miniskeleton_core", frozen, get_all)]
pub struct PyWeldedPoints {
    map: Py<PyArray1<i32>>,
    welded: Py<PyArray2<f64>>,
}
unpacks_as!(PyWeldedPoints, map, welded);

/// Weld points (n,3) (float64, or anything cast to it) closer than `tolerance`: an absolute
/// distance in the points' own units. Returns (map (n,) int32, the welded point of each point;
/// welded (k,3) float64). Greedy in input order: a point joins a welded point within `tolerance`
/// of it, else it becomes a new one; a welded point is the first point of its cluster, unchanged
/// (not a mean), and clusters do not chain (a point near another member but farther than
/// `tolerance` from the first starts a new one). Welded points lie more than `tolerance` apart;
/// a point within `tolerance` of two of them joins one fixed by the grid, not always the first.
/// `tolerance` <= 0 or not finite: exact duplicates only. Non-finite points never weld.
#[pyfunction]
pub fn weld_points<'py>(
    py: Python<'py>,
    points: PyArrayLike2<'py, f64, AllowTypeChange>,
    tolerance: f64,
) -> PyResult<PyWeldedPoints> {
    let p = rows::<f64, 3>(&points, "points")?;
    if p.len() > i32::MAX as usize {
        return Err(PyValueError::new_err(format!("{} points: at most 2^31 - 1", p.len())));
    }
    let (map, welded) = guarded(py, move || Ok(miniskeleton_core::mesh::weld::weld_points(&p, tolerance)))?;
    let map = PyArray1::from_vec(py, map.into_iter().map(|w| w as i32).collect()).unbind();
    Ok(PyWeldedPoints { map, welded: from_rows(py, &welded)?.unbind() })
}

/// Which meshes meet along a seam: `vertices` (n,3) of all meshes stacked, `mesh_of` (n,) the
/// mesh of each vertex, `triangles` (m,3) of all meshes stacked (optional: the bbox of the
/// vertices they use is the scale, so a stray loose vertex does not widen the weld); meshes
/// sharing at least `min_shared` welded positions (within `tolerance` of that bbox diagonal),
/// transitively, get one group. Returns (meshes,) int32 group ids, numbered in order of each
/// group's first mesh.
#[pyfunction]
#[pyo3(signature = (vertices, mesh_of, meshes, *, triangles=None, tolerance=1e-5, min_shared=3))]
pub fn touching_meshes<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    mesh_of: Indices<'py>,
    meshes: usize,
    triangles: Option<IndexRows<'py>>,
    tolerance: f64,
    min_shared: usize,
) -> PyResult<Bound<'py, numpy::PyArray1<i32>>> {
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let m = indices(&mesh_of, "mesh_of")?;
    let tri = match &triangles {
        Some(t) => index_rows::<u32, 3>(t, "triangles")?,
        None => Vec::new(),
    };
    let groups =
        guarded(py, move || miniskeleton_core::mesh::touching_meshes(&v, &m, meshes, &tri, tolerance, min_shared))?;
    Ok(numpy::PyArray1::from_vec(py, groups.into_iter().map(|g| g as i32).collect()))
}

/// Catmull-Clark limit positions (n, 3) float32 of a polygon mesh's vertices: where a cage's
/// vertices lie on the smooth surface of its Subdivision Surface modifier. `face_sizes` (f,)
/// corners per face, `face_vertices` their vertex indices face after face; `keep_corners`:
/// a boundary vertex of one face stays put (Blender's "Keep Corners"). Creases are not read;
/// loose and non-manifold vertices stay where they are.
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, face_vertices, *, keep_corners=false))]
pub fn catmull_clark_limit<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    face_sizes: Indices<'py>,
    face_vertices: Indices<'py>,
    keep_corners: bool,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let (sizes, corners) = (indices(&face_sizes, "face_sizes")?, indices(&face_vertices, "face_vertices")?);
    let limit = guarded(py, move || miniskeleton_core::mesh::limit_positions(&v, &sizes, &corners, keep_corners))?;
    from_rows(py, &limit)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyWeldedPoints>()?;
    m.add_function(wrap_pyfunction!(weld_points, m)?)?;
    m.add_function(wrap_pyfunction!(touching_meshes, m)?)?;
    m.add_function(wrap_pyfunction!(catmull_clark_limit, m)?)?;
    Ok(())
}
