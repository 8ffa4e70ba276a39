//! Bindings for skeleton tools: joint fitting and the inside test (`fit.rs`), and left/right in
//! bone names (`names.rs`).

use crate::convert::{from_rows, index_rows, indices, rows, vector, IndexRows, Indices};
use crate::error::guarded;
use crate::options::{keyword, optional, read_options};
use miniskeleton_core::mesh::Symmetry;
use miniskeleton_core::skeleton::{self, FitOptions};
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike1, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Fit joints (j,3) into the mesh: each joint goes to the nearest point of its bones' centre
/// lines. bones (b,2) joint indices; movable (j,) bool (default all); symmetry_axis 0/1/2 with
/// joint_mirror (j,) mirror joint indices; max_move caps each joint's fitting move (fraction of the
/// mesh's bounding-box diagonal); stub_ratio and min_sections: see `FitOptions`. Keywords:
/// symmetry_axis, symmetry_plane, joint_mirror, rays, samples, rounds, tolerance, stiffness, tip,
/// max_move, stub_ratio, min_sections; each left out keeps `FitOptions::default()`. Returns a
/// `FitResult`.
#[pyfunction]
#[pyo3(signature = (vertices, triangles, joints, bones, movable=None, **options))]
pub fn fit_joints<'py>(
    py: Python<'py>,
    vertices: PyArrayLike2<'py, f32, AllowTypeChange>,
    triangles: IndexRows<'py>,
    joints: PyArrayLike2<'py, f32, AllowTypeChange>,
    bones: IndexRows<'py>,
    movable: Option<PyArrayLike1<'py, bool, AllowTypeChange>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<PyFitResult> {
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let t = index_rows::<u32, 3>(&triangles, "triangles")?;
    let j = rows::<f32, 3>(&joints, "joints")?;
    let b = index_rows::<u32, 2>(&bones, "bones")?;
    let mv = movable.map(|m| vector(&m)).unwrap_or_else(|| vec![true; j.len()]);
    // The mirror's keywords: (axis, plane, joint_mirror).
    let mirror = (None::<usize>, 0.0f64, None::<Vec<i32>>);
    let (mut opts, (axis, plane, joint_mirror)) =
        read_options("fit_joints", options, (FitOptions::default(), mirror), |(o, m), key, value| {
            match key {
                "symmetry_axis" => m.0 = optional(value, key, Ok)?,
                "symmetry_plane" => m.1 = keyword(value, key)?,
                "joint_mirror" => m.2 = optional(value, key, |j: Indices| indices(&j, "joint_mirror"))?,
                "rays" => o.rays = keyword(value, key)?,
                "samples" => o.samples = keyword(value, key)?,
                "rounds" => o.rounds = keyword(value, key)?,
                "tolerance" => o.tolerance = keyword(value, key)?,
                "stiffness" => o.stiffness = keyword(value, key)?,
                "tip" => o.tip = keyword(value, key)?,
                "max_move" => o.max_move = keyword(value, key)?,
                "stub_ratio" => o.stub_ratio = keyword(value, key)?,
                "min_sections" => o.min_sections = keyword(value, key)?,
                _ => return Ok(false),
            }
            Ok(true)
        })?;
    opts.symmetry = match (axis, joint_mirror) {
        (None, None) => None,
        (Some(axis), Some(mirror)) => Some(Symmetry { axis, plane, mirror }),
        _ => return Err(PyValueError::new_err("symmetry_axis and joint_mirror go together")),
    };
    let (out, rep) = guarded(py, move || skeleton::fit_joints(&v, &t, &j, &b, &mv, &opts))?;
    Ok(PyFitResult {
        joints: from_rows(py, &out)?.unbind(),
        outside_before: rep.count_outside_before(),
        outside_after: rep.count_outside_after(),
        outside_before_mask: PyArray1::from_vec(py, rep.outside_before.clone()).unbind(),
        outside_after_mask: PyArray1::from_vec(py, rep.outside_after.clone()).unbind(),
        kept_outside: rep.kept_outside.iter().filter(|&&k| k).count(),
        rounds: rep.rounds,
        max_move: rep.max_move,
        open_edges: rep.open_edges,
        nonmanifold_edges: rep.nonmanifold_edges,
        pieces: rep.pieces,
        mirrored_surface: rep.mirrored_surface,
        off_plane_centre: rep.off_plane_centre,
    })
}

/// The fitted joints (j,3) float32 and what the fit did: outside_before / outside_after (joints
/// outside the mesh, with their (j,) bool masks), kept_outside, rounds, max_move, open_edges,
/// nonmanifold_edges, pieces, mirrored_surface (None without symmetry), off_plane_centre.
#[pyclass(name = "FitResult", module = "miniskeleton_core", frozen, get_all)]
pub struct PyFitResult {
    joints: Py<PyArray2<f32>>,
    outside_before: usize,
    outside_after: usize,
    outside_before_mask: Py<PyArray1<bool>>,
    outside_after_mask: Py<PyArray1<bool>>,
    kept_outside: usize,
    rounds: usize,
    max_move: f64,
    open_edges: usize,
    nonmanifold_edges: usize,
    pieces: usize,
    mirrored_surface: Option<f64>,
    off_plane_centre: usize,
}

/// Which points (p,3) are inside the closed mesh (ray parity, majority of 7 directions): (p,) bool.
#[pyfunction]
pub fn points_inside<'py>(
    py: Python<'py>,
    vertices: PyArrayLike2<'py, f32, AllowTypeChange>,
    triangles: IndexRows<'py>,
    points: PyArrayLike2<'py, f32, AllowTypeChange>,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let t = index_rows::<u32, 3>(&triangles, "triangles")?;
    let p = rows::<f32, 3>(&points, "points")?;
    let out = guarded(py, move || skeleton::points_inside(&v, &t, &p))?;
    Ok(PyArray1::from_vec(py, out))
}

/// Blender's left/right flip of a bone name: `thigh.L` -> `thigh.R`, `R_foot` -> `L_foot`,
/// `leg_back_L_knee` -> `leg_back_R_knee`, `mixamorig:LeftArm` -> `mixamorig:RightArm`; the name
/// itself when it states no side. The first token of these, in this order: a separator (. _ -
/// space) and L/l at the end, then R/r; L/l and a separator at the start, then R/r; a letter
/// between two of . _ -; the first Left, Right, left, right, LEFT or RIGHT.
#[pyfunction]
pub fn mirror_name(name: &str) -> String {
    skeleton::mirror_name(name)
}

/// Each bone's mirror bone by name, (b,) int32: the index of the bone named `mirror_name(name)`
/// (the last such with duplicate names), or else of the one bone whose name matches it up to a
/// trailing number (b_LeftUpperArm_09 <-> b_RightUpperArm_06); the bone itself for a centre bone
/// (a name the flip leaves as it is); -1 for a side bone without a partner. Pairs agree both
/// ways.
#[pyfunction]
pub fn bone_mirror_indices<'py>(py: Python<'py>, names: Vec<String>) -> Bound<'py, PyArray1<i32>> {
    PyArray1::from_vec(py, skeleton::bone_mirror_indices(&names))
}

/// Add this area's functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyFitResult>()?;
    m.add_function(wrap_pyfunction!(fit_joints, m)?)?;
    m.add_function(wrap_pyfunction!(points_inside, m)?)?;
    m.add_function(wrap_pyfunction!(mirror_name, m)?)?;
    m.add_function(wrap_pyfunction!(bone_mirror_indices, m)?)?;
    Ok(())
}
