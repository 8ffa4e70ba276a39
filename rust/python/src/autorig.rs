//! Bindings for Auto Rig (`autorig/`): a Rigify-style skeleton for a bare mesh.

use crate::convert::{from_rows, index_rows, rows, IndexRows};
use crate::error::guarded;
use miniskeleton_core::autorig::{self, AutoRigOptions, Template};
use numpy::{AllowTypeChange, PyArray1, PyArrayLike1, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Rig a bare mesh of a character (+Z up). template "AUTO" | "BIPED" | "QUADRUPED" | "CHAIN" |
/// "WINGED"; forward: None or a (3,) vector, the way the character faces; resolution: voxels
/// along the longest side. Returns a dict: template ("BIPED" | "QUADRUPED" | "CHAIN" |
/// "WINGED"), reason (str: why that template), names (list of str), heads
/// and tails (k,3) float32, parents (k,) int64 (-1 for the root), connected (k,) bool, forward
/// and left (3,) float32 (left: the `.L` side), tail (bool), and the centre-line tree the bones were
/// laid along: centre_points (c,3) float32, centre_edges (e,2) uint32. ValueError when the mesh cannot
/// be rigged, saying why.
#[pyfunction]
#[pyo3(signature = (vertices, triangles, *, template="AUTO", forward=None, resolution=96))]
pub fn auto_rig<'py>(
    py: Python<'py>,
    vertices: PyArrayLike2<'py, f32, AllowTypeChange>,
    triangles: IndexRows<'py>,
    template: &str,
    forward: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
    resolution: usize,
) -> PyResult<Bound<'py, PyDict>> {
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
    let d = PyDict::new(py);
    d.set_item("template", rig.template.name())?;
    d.set_item("reason", rig.reason.clone())?;
    d.set_item("names", rig.bones.iter().map(|b| b.name.clone()).collect::<Vec<_>>())?;
    d.set_item("heads", from_rows(py, &rig.bones.iter().map(|b| b.head).collect::<Vec<_>>())?)?;
    d.set_item("tails", from_rows(py, &rig.bones.iter().map(|b| b.tail).collect::<Vec<_>>())?)?;
    d.set_item("parents", PyArray1::from_vec(py, rig.bones.iter().map(|b| b.parent as i64).collect()))?;
    d.set_item("connected", PyArray1::from_vec(py, rig.bones.iter().map(|b| b.connected).collect()))?;
    d.set_item("forward", PyArray1::from_vec(py, rig.forward.map(|c| c as f32).to_vec()))?;
    d.set_item("left", PyArray1::from_vec(py, rig.left.map(|c| c as f32).to_vec()))?;
    d.set_item("tail", rig.tail)?;
    d.set_item("centre_points", from_rows(py, &rig.centre_points)?)?;
    d.set_item("centre_edges", from_rows(py, &rig.centre_edges)?)?;
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(auto_rig, m)?)?;
    Ok(())
}
