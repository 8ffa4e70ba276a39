//! Bindings for Auto Rig (`autorig/`): a Rigify-style skeleton for a bare mesh.

use crate::convert::{from_rows, index_rows, rows, IndexRows};
use crate::error::guarded;
use miniskeleton_core::autorig::{self, AutoRigOptions, Template};
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike1, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Auto Rig's skeleton: template ("BIPED" | "QUADRUPED" | "CHAIN" | "WINGED") and reason (why
/// that template), names (k,), heads and tails (k, 3) float32, parents (k,) int64 (-1 for the
/// root), connected (k,) bool, forward and left (3,) float32 (left: the `.L` side), tail (whether
/// it has one), and the centre-line tree the bones were laid along: centre_points (c, 3) float32,
/// centre_edges (e, 2) uint32.
#[pyclass(name = "AutoRig", module = "miniskeleton_core", frozen, get_all)]
pub struct PyAutoRig {
    template: String,
    reason: String,
    names: Vec<String>,
    heads: Py<PyArray2<f32>>,
    tails: Py<PyArray2<f32>>,
    parents: Py<PyArray1<i64>>,
    connected: Py<PyArray1<bool>>,
    forward: Py<PyArray1<f32>>,
    left: Py<PyArray1<f32>>,
    tail: bool,
    centre_points: Py<PyArray2<f32>>,
    centre_edges: Py<PyArray2<u32>>,
}

/// Rig a bare mesh of a character (+Z up). template "AUTO" | "BIPED" | "QUADRUPED" | "CHAIN" |
/// "WINGED"; forward: None or a (3,) vector, the way the character faces; resolution: voxels
/// along the longest side. Returns an `AutoRig`. ValueError when the mesh cannot be rigged,
/// saying why.
#[pyfunction]
#[pyo3(signature = (vertices, triangles, *, template="AUTO", forward=None, resolution=96))]
pub fn auto_rig<'py>(
    py: Python<'py>,
    vertices: PyArrayLike2<'py, f32, AllowTypeChange>,
    triangles: IndexRows<'py>,
    template: &str,
    forward: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
    resolution: usize,
) -> PyResult<PyAutoRig> {
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let t = index_rows::<u32, 3>(&triangles, "triangles")?;
    let template = match template {
        "AUTO" => Template::Auto,
        "BIPED" => Template::Biped,
        "QUADRUPED" => Template::Quadruped,
        "CHAIN" => Template::Chain,
        "WINGED" => Template::Winged,
        other => {
            return Err(PyValueError::new_err(format!(
                "template must be AUTO, BIPED, QUADRUPED, CHAIN or WINGED, got {other:?}"
            )))
        }
    };
    let forward = match forward {
        None => None,
        Some(f) => {
            let f = f.as_array();
            if f.len() != 3 {
                return Err(PyValueError::new_err(format!("forward must have shape (3,), got ({},)", f.len())));
            }
            Some([f[0], f[1], f[2]])
        }
    };
    let opts = AutoRigOptions { template, forward, resolution };
    let rig = guarded(py, move || autorig::auto_rig(&v, &t, &opts))?;
    Ok(PyAutoRig {
        template: rig.template.name().to_owned(),
        reason: rig.reason.clone(),
        names: rig.bones.iter().map(|b| b.name.clone()).collect(),
        heads: from_rows(py, &rig.bones.iter().map(|b| b.head).collect::<Vec<_>>())?.unbind(),
        tails: from_rows(py, &rig.bones.iter().map(|b| b.tail).collect::<Vec<_>>())?.unbind(),
        parents: PyArray1::from_vec(py, rig.bones.iter().map(|b| b.parent as i64).collect()).unbind(),
        connected: PyArray1::from_vec(py, rig.bones.iter().map(|b| b.connected).collect()).unbind(),
        forward: PyArray1::from_vec(py, rig.forward.map(|c| c as f32).to_vec()).unbind(),
        left: PyArray1::from_vec(py, rig.left.map(|c| c as f32).to_vec()).unbind(),
        tail: rig.tail,
        centre_points: from_rows(py, &rig.centre_points)?.unbind(),
        centre_edges: from_rows(py, &rig.centre_edges)?.unbind(),
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyAutoRig>()?;
    m.add_function(wrap_pyfunction!(auto_rig, m)?)?;
    Ok(())
}
