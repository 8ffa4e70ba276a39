//! Bindings for skeleton tools: joint fitting and the inside test (`fit.rs`), and left/right in
//! bone names (`names.rs`).

use crate::convert::{from_rows, index_rows, indices, rows, vector, IndexRows, Indices};
use crate::error::guarded;
use miniskeleton_core::mesh::Symmetry;
use miniskeleton_core::skeleton::{self, FitOptions};
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike1, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Fit joints (j,3) into the mesh: each joint goes to the nearest point of its bones' centre
/// lines. bones (b,2) joint indices; movable (j,) bool (default all); symmetry_axis 0/1/2 with
/// joint_mirror (j,) mirror joint indices; max_move caps each joint's fitting move (fraction of the
/// mesh's bounding-box diagonal); stub_ratio and min_sections: see `FitOptions`. Returns
/// (joints (j,3) float32, report dict).
#[pyfunction]
#[pyo3(signature = (vertices, triangles, joints, bones, movable=None, *, symmetry_axis=None,
                    symmetry_plane=0.0, joint_mirror=None, rays=12, samples=5, rounds=12,
                    tolerance=1e-4, stiffness=0.05, tip=true, max_move=0.12, stub_ratio=0.5, min_sections=2))]
#[allow(clippy::too_many_arguments)]
pub fn fit_joints<'py>(
    py: Python<'py>,
    vertices: PyArrayLike2<'py, f32, AllowTypeChange>,
    triangles: IndexRows<'py>,
    joints: PyArrayLike2<'py, f32, AllowTypeChange>,
    bones: IndexRows<'py>,
    movable: Option<PyArrayLike1<'py, bool, AllowTypeChange>>,
    symmetry_axis: Option<usize>,
    symmetry_plane: f64,
    joint_mirror: Option<Indices<'py>>,
    rays: usize,
    samples: usize,
    rounds: usize,
    tolerance: f64,
    stiffness: f64,
    tip: bool,
    max_move: f64,
    stub_ratio: f64,
    min_sections: usize,
) -> PyResult<(Bound<'py, PyArray2<f32>>, Bound<'py, PyDict>)> {
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let t = index_rows::<u32, 3>(&triangles, "triangles")?;
    let j = rows::<f32, 3>(&joints, "joints")?;
    let b = index_rows::<u32, 2>(&bones, "bones")?;
    let mv = movable.map(|m| vector(&m)).unwrap_or_else(|| vec![true; j.len()]);
    let symmetry = match (symmetry_axis, joint_mirror) {
        (None, None) => None,
        (Some(axis), Some(m)) => Some(Symmetry { axis, plane: symmetry_plane, mirror: indices(&m, "joint_mirror")? }),
        _ => return Err(PyValueError::new_err("symmetry_axis and joint_mirror go together")),
    };
    let opts = FitOptions {
        symmetry,
        rays,
        samples,
        rounds,
        tolerance,
        stiffness,
        tip,
        max_move,
        stub_ratio,
        min_sections,
        ..FitOptions::default()
    };
    let (out, rep) = guarded(py, move || skeleton::fit_joints(&v, &t, &j, &b, &mv, &opts))?;
    let d = PyDict::new(py);
    d.set_item("outside_before", rep.count_outside_before())?;
    d.set_item("outside_after", rep.count_outside_after())?;
    d.set_item("outside_before_mask", PyArray1::from_vec(py, rep.outside_before.clone()))?;
    d.set_item("outside_after_mask", PyArray1::from_vec(py, rep.outside_after.clone()))?;
    d.set_item("kept_outside", rep.kept_outside.iter().filter(|&&k| k).count())?;
    d.set_item("rounds", rep.rounds)?;
    d.set_item("max_move", rep.max_move)?;
    d.set_item("open_edges", rep.open_edges)?;
    d.set_item("nonmanifold_edges", rep.nonmanifold_edges)?;
    d.set_item("pieces", rep.pieces)?;
    d.set_item("mirrored_surface", rep.mirrored_surface)?;
    d.set_item("off_plane_centre", rep.off_plane_centre)?;
    Ok((from_rows(py, &out)?, d))
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
    m.add_function(wrap_pyfunction!(fit_joints, m)?)?;
    m.add_function(wrap_pyfunction!(points_inside, m)?)?;
    m.add_function(wrap_pyfunction!(mirror_name, m)?)?;
    m.add_function(wrap_pyfunction!(bone_mirror_indices, m)?)?;
    Ok(())
}
