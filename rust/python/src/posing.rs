//! Bindings for posing: linear blend skinning (`lbs.rs`) and planar IK (`ik2d/`): a chain, the
//! solver's options and its solution as classes.

use crate::convert::{from_rows, index_matrix, rows, vector, IndexRows};
use crate::error::guarded;
use miniskeleton_core::posing::ik2d::{self, Chain2d, SolveOptions, SolveReport};
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike1, PyArrayLike2, PyArrayLike3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

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

/// A planar chain (one puppet limb), the core's `Chain2d`: lengths (b,), relative joint angles
/// (b,) radians (default 0), base (x, y), base_angle radians, limits (b, 2) radians (default
/// none). Checked when solved.
#[pyclass(name = "Chain2d", module = "miniskeleton_core", frozen)]
pub struct PyChain2d(Chain2d);

#[pymethods]
impl PyChain2d {
    #[new]
    #[pyo3(signature = (lengths, angles=None, *, base=(0.0, 0.0), base_angle=0.0, limits=None))]
    fn new(
        lengths: PyArrayLike1<'_, f64, AllowTypeChange>,
        angles: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
        base: (f64, f64),
        base_angle: f64,
        limits: Option<PyArrayLike2<'_, f64, AllowTypeChange>>,
    ) -> PyResult<Self> {
        Ok(PyChain2d(chain(&lengths, angles, base, base_angle, limits)?))
    }

    #[getter]
    fn lengths<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.0.lengths)
    }

    #[getter]
    fn angles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.0.angles)
    }

    #[getter]
    fn base(&self) -> (f64, f64) {
        (self.0.base[0], self.0.base[1])
    }

    #[getter]
    fn base_angle(&self) -> f64 {
        self.0.base_angle
    }

    #[getter]
    fn limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        from_rows(py, &self.0.limits)
    }
}

/// How to solve: at most max_iterations passes (above `ik2d::MAX_ITERATIONS`, 10 000, a
/// ValueError: the solve runs without the GIL and could not be interrupted), tolerance (chain
/// units; default 1e-3 of the chain's reach), method "ccd" (improved CCD), "ccd_pure" (the
/// paper's step only), "ccd_classic3d" or "fabrik" (the baselines).
#[pyclass(module = "miniskeleton_core", frozen, get_all)]
pub struct Ik2dOptions {
    max_iterations: usize,
    tolerance: Option<f64>,
    method: String,
}

#[pymethods]
impl Ik2dOptions {
    #[new]
    #[pyo3(signature = (*, max_iterations=200, tolerance=None, method="ccd"))]
    fn new(max_iterations: usize, tolerance: Option<f64>, method: &str) -> Self {
        Ik2dOptions { max_iterations, tolerance, method: method.to_owned() }
    }
}

impl Ik2dOptions {
    /// The core's options for chain `c` and the method; without options, the core's defaults
    /// (`SolveOptions::for_chain`) and the improved CCD.
    fn for_chain(options: Option<&Ik2dOptions>, c: &Chain2d) -> (SolveOptions, String) {
        let mut o = SolveOptions::for_chain(c);
        let Some(options) = options else { return (o, "ccd".to_owned()) };
        o.max_iterations = options.max_iterations;
        if let Some(t) = options.tolerance {
            o.tolerance = t;
        }
        (o, options.method.clone())
    }
}

/// What a solve found: the chain's relative angles (b,) radians, the passes it ran, the final
/// distance from the effector to its target (the largest over the effectors for
/// `ik2d_solve_multi`) and whether that is within the tolerance.
#[pyclass(module = "miniskeleton_core", frozen, get_all)]
pub struct Ik2dSolution {
    angles: Py<PyArray1<f64>>,
    iterations: usize,
    error: f64,
    reached: bool,
}

impl Ik2dSolution {
    fn new(py: Python<'_>, angles: Vec<f64>, r: SolveReport) -> Self {
        let angles = PyArray1::from_vec(py, angles).unbind();
        Ik2dSolution { angles, iterations: r.iterations, error: r.error, reached: r.reached }
    }
}

/// Planar IK for one chain from its angles toward target (x, y).
#[pyfunction]
#[pyo3(signature = (chain, target, options=None))]
pub fn ik2d_solve(
    py: Python<'_>,
    chain: &PyChain2d,
    target: (f64, f64),
    options: Option<Py<Ik2dOptions>>,
) -> PyResult<Ik2dSolution> {
    let mut c = chain.0.clone();
    let (opts, method) = Ik2dOptions::for_chain(options.as_ref().map(|o| o.get()), &c);
    let solver = match method.as_str() {
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
    Ok(Ik2dSolution::new(py, angles, r))
}

/// Several effectors on one chain (strip puppets): effectors = [(joint 1..=b, (x, y), weight)],
/// solved by the improved CCD (options.method must be "ccd").
#[pyfunction]
#[pyo3(signature = (chain, effectors, options=None))]
pub fn ik2d_solve_multi(
    py: Python<'_>,
    chain: &PyChain2d,
    effectors: Vec<(usize, (f64, f64), f64)>,
    options: Option<Py<Ik2dOptions>>,
) -> PyResult<Ik2dSolution> {
    let mut c = chain.0.clone();
    let (opts, method) = Ik2dOptions::for_chain(options.as_ref().map(|o| o.get()), &c);
    if method != "ccd" {
        return Err(PyValueError::new_err(format!("ik2d_solve_multi solves by CCD only, not {method:?}")));
    }
    let effs: Vec<_> = effectors.into_iter().map(|(j, (x, y), w)| (j, [x, y], w)).collect();
    let (angles, r) = guarded(py, move || {
        let r = ik2d::solve_multi(&mut c, &effs, opts)?;
        Ok((c.angles, r))
    })?;
    Ok(Ik2dSolution::new(py, angles, r))
}

/// Joint positions (b+1, 2) of a planar chain: base, then each bone's tip.
#[pyfunction]
pub fn ik2d_forward<'py>(py: Python<'py>, chain: &PyChain2d) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let c = chain.0.clone();
    let pts = guarded(py, move || ik2d::forward(&c))?;
    from_rows(py, &pts)
}

/// Add this area's functions and classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyChain2d>()?;
    m.add_class::<Ik2dOptions>()?;
    m.add_class::<Ik2dSolution>()?;
    m.add_function(wrap_pyfunction!(lbs, m)?)?;
    m.add_function(wrap_pyfunction!(ik2d_solve, m)?)?;
    m.add_function(wrap_pyfunction!(ik2d_solve_multi, m)?)?;
    m.add_function(wrap_pyfunction!(ik2d_forward, m)?)?;
    Ok(())
}
