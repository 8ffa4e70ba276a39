//! Bindings for posing: linear blend skinning (`lbs.rs`) and planar IK (`ik2d.rs`).

use crate::convert::{from_rows, index_matrix, rows, vector, IndexRows};
use crate::error::guarded;
use miniskeleton_core::posing::ik2d::{self, Chain2d, SolveOptions, SolveReport};
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike1, PyArrayLike2, PyArrayLike3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Linear blend skinning v' = sum_j w_j M_j v; bone_matrices (b,4,4) row-major rest->posed.
#[pyfunction]
pub fn lbs<'py>(
    py: Python<'py>,
    vertices: PyArrayLike2<'py, f32, AllowTypeChange>,
    indices: IndexRows<'py>,
    weights: PyArrayLike2<'py, f32, AllowTypeChange>,
    bone_matrices: PyArrayLike3<'py, f32, AllowTypeChange>,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let (idx, w) = (indices.as_array(), weights.as_array());
    if idx.dim() != w.dim() || idx.dim().0 != v.len() {
        return Err(PyValueError::new_err(format!(
            "indices {:?} and weights {:?} must both be (n, k) with n = {} vertices",
            idx.dim(),
            w.dim(),
            v.len()
        )));
    }
    let k = idx.dim().1;
    let idx: Vec<i32> = index_matrix(&indices, "indices")?;
    let w: Vec<f32> = w.iter().copied().collect();
    let m = bone_matrices.as_array();
    if m.dim().1 != 4 || m.dim().2 != 4 {
        return Err(PyValueError::new_err(format!("bone_matrices must be (b, 4, 4), got {:?}", m.dim())));
    }
    let mats: Vec<[[f32; 4]; 4]> =
        m.outer_iter().map(|mm| std::array::from_fn(|r| std::array::from_fn(|c| mm[[r, c]]))).collect();
    let out = guarded(py, || miniskeleton_core::posing::lbs(&v, &idx, &w, k, &mats))?;
    from_rows(py, &out)
}

fn chain(
    lengths: &PyArrayLike1<'_, f64, AllowTypeChange>,
    angles: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
    base: (f64, f64),
    base_angle: f64,
    limits: Option<PyArrayLike2<'_, f64, AllowTypeChange>>,
) -> PyResult<Chain2d> {
    let mut c = Chain2d::straight([base.0, base.1], base_angle, vector(lengths));
    if let Some(a) = angles {
        c.angles = vector(&a);
    }
    if let Some(l) = limits {
        c.limits = rows::<f64, 2>(&l, "limits")?;
    }
    if c.angles.len() != c.lengths.len() || c.limits.len() != c.lengths.len() {
        return Err(PyValueError::new_err("lengths, angles and limits must have one entry per bone"));
    }
    Ok(c)
}

fn report<'py>(py: Python<'py>, r: &SolveReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("iterations", r.iterations)?;
    d.set_item("error", r.error)?;
    d.set_item("reached", r.reached)?;
    Ok(d)
}

fn options(c: &Chain2d, max_iterations: usize, tolerance: Option<f64>) -> SolveOptions {
    let mut o = SolveOptions::for_chain(c);
    o.max_iterations = max_iterations;
    if let Some(t) = tolerance {
        o.tolerance = t;
    }
    o
}

/// Planar IK for one chain. method: "ccd" (improved CCD, default), "ccd_pure" (the paper's
/// step only), "ccd_classic3d", "fabrik". Returns (relative angles (b,), report dict).
/// `max_iterations` above `ik2d::MAX_ITERATIONS` (10 000) is a ValueError: the solve runs
/// without the GIL and could not be interrupted.
#[pyfunction]
#[pyo3(signature = (lengths, target, angles=None, *, base=(0.0, 0.0), base_angle=0.0, limits=None,
                    max_iterations=200, tolerance=None, method="ccd"))]
#[allow(clippy::too_many_arguments)]
pub fn ik2d_solve<'py>(
    py: Python<'py>,
    lengths: PyArrayLike1<'py, f64, AllowTypeChange>,
    target: (f64, f64),
    angles: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
    base: (f64, f64),
    base_angle: f64,
    limits: Option<PyArrayLike2<'py, f64, AllowTypeChange>>,
    max_iterations: usize,
    tolerance: Option<f64>,
    method: &str,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyDict>)> {
    let mut c = chain(&lengths, angles, base, base_angle, limits)?;
    let opts = options(&c, max_iterations, tolerance);
    let solver = match method {
        "ccd" => ik2d::solve_ccd,
        "ccd_pure" => ik2d::solve_ccd_pure,
        "ccd_classic3d" => ik2d::solve_ccd_classic3d,
        "fabrik" => ik2d::solve_fabrik,
        other => return Err(PyValueError::new_err(format!("unknown IK method {other:?}"))),
    };
    let (angles, r) = guarded(py, move || {
        let r = solver(&mut c, [target.0, target.1], opts)?;
        Ok((c.angles, r))
    })?;
    Ok((PyArray1::from_vec(py, angles), report(py, &r)?))
}

/// Several effectors on one chain (strip puppets): effectors = [(joint 1..=b, (x, y), weight)].
/// `max_iterations` is bounded as in `ik2d_solve`.
#[pyfunction]
#[pyo3(signature = (lengths, effectors, angles=None, *, base=(0.0, 0.0), base_angle=0.0, limits=None,
                    max_iterations=200, tolerance=None))]
#[allow(clippy::too_many_arguments)]
pub fn ik2d_solve_multi<'py>(
    py: Python<'py>,
    lengths: PyArrayLike1<'py, f64, AllowTypeChange>,
    effectors: Vec<(usize, (f64, f64), f64)>,
    angles: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
    base: (f64, f64),
    base_angle: f64,
    limits: Option<PyArrayLike2<'py, f64, AllowTypeChange>>,
    max_iterations: usize,
    tolerance: Option<f64>,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyDict>)> {
    let mut c = chain(&lengths, angles, base, base_angle, limits)?;
    let opts = options(&c, max_iterations, tolerance);
    let effs: Vec<_> = effectors.into_iter().map(|(j, (x, y), w)| (j, [x, y], w)).collect();
    let (angles, r) = guarded(py, move || {
        let r = ik2d::solve_multi(&mut c, &effs, opts)?;
        Ok((c.angles, r))
    })?;
    Ok((PyArray1::from_vec(py, angles), report(py, &r)?))
}

/// Joint positions (b+1, 2) of a planar chain: base, then each bone's tip.
#[pyfunction]
#[pyo3(signature = (lengths, angles, *, base=(0.0, 0.0), base_angle=0.0))]
pub fn ik2d_forward<'py>(
    py: Python<'py>,
    lengths: PyArrayLike1<'py, f64, AllowTypeChange>,
    angles: PyArrayLike1<'py, f64, AllowTypeChange>,
    base: (f64, f64),
    base_angle: f64,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let c = chain(&lengths, Some(angles), base, base_angle, None)?;
    let pts = guarded(py, move || ik2d::forward(&c))?;
    from_rows(py, &pts)
}

/// Add this area's functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(lbs, m)?)?;
    m.add_function(wrap_pyfunction!(ik2d_solve, m)?)?;
    m.add_function(wrap_pyfunction!(ik2d_solve_multi, m)?)?;
    m.add_function(wrap_pyfunction!(ik2d_forward, m)?)?;
    Ok(())
}
