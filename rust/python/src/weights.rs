//! Bindings for `miniskeleton_core::weights` (heat, bilinear, inverse distance): skinning weights
//! as dense top-k arrays.

use crate::convert::{index_matrix, index_rows, indices, matrix, rows, IndexRows, Indices};
use crate::error::{guarded, to_py};
use miniskeleton_core::mesh::Symmetry;
use miniskeleton_core::weights::Influences;
use miniskeleton_core::weights::{bilinear_weights as core_bilinear, BilinearOptions, Falloff};
use miniskeleton_core::weights::{heat_sources as core_heat_sources, heat_weights as core_heat};
use miniskeleton_core::weights::{
    heat_weights_many as core_heat_many, heat_weights_with_sources as core_heat_from_sources,
};
use miniskeleton_core::weights::{idw_weights as core_idw, IdwOptions};
use miniskeleton_core::weights::{transfer_weights as core_transfer, TransferOptions};
use miniskeleton_core::weights::{
    voxel_distances as core_voxel_distances, voxel_weights as core_voxel, VoxelOptions, VoxelReport,
};
use miniskeleton_core::weights::{BoneCurves, HeatOptions, HeatReport, MeshRef};
use numpy::{AllowTypeChange, PyArray2, PyArrayLike2};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Mutex;

type F32Rows<'py> = PyArrayLike2<'py, f32, AllowTypeChange>;
type Pair<'py> = (Bound<'py, PyArray2<i32>>, Bound<'py, PyArray2<f32>>);
/// Top-k weights with their report: bone indices int32 (n,k), weights float32 (n,k), report dict.
type PairAndReport<'py> = (Bound<'py, PyArray2<i32>>, Bound<'py, PyArray2<f32>>, Bound<'py, PyDict>);

fn to_pair<'py>(py: Python<'py>, inf: Influences) -> PyResult<Pair<'py>> {
    let n = inf.n();
    Ok((matrix(py, inf.indices, n, inf.k)?, matrix(py, inf.weights, n, inf.k)?))
}

fn positive_k(max_influences: usize) -> PyResult<usize> {
    if max_influences == 0 {
        return Err(PyValueError::new_err("max_influences must be at least 1"));
    }
    Ok(max_influences)
}

/// Inverse-distance weights: w_b = (d_b + eps)^-p / sum_k (d_k + eps)^-p, top-k, renormalized.
#[pyfunction]
#[pyo3(signature = (vertices, bone_heads, bone_tails, *, max_influences=4, power=2.0, epsilon=1e-4))]
pub fn idw_weights<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    max_influences: usize,
    power: f32,
    epsilon: f32,
) -> PyResult<Pair<'py>> {
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let h = rows::<f32, 3>(&bone_heads, "bone_heads")?;
    let t = rows::<f32, 3>(&bone_tails, "bone_tails")?;
    let opts = IdwOptions { power, max_influences: positive_k(max_influences)?, epsilon };
    let inf = guarded(py, || core_idw(&v, &h, &t, &opts))?;
    to_pair(py, inf)
}

/// Nearest-bone weights with joint blending (see `bilinear.rs`).
#[pyfunction]
#[pyo3(signature = (vertices, bone_heads, bone_tails, parents=None, *, max_influences=4, nearest=3,
                    falloff="gaussian", sigma=None, power=2.0))]
#[allow(clippy::too_many_arguments)]
pub fn bilinear_weights<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    parents: Option<Indices<'py>>,
    max_influences: usize,
    nearest: usize,
    falloff: &str,
    sigma: Option<f32>,
    power: f32,
) -> PyResult<Pair<'py>> {
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let h = rows::<f32, 3>(&bone_heads, "bone_heads")?;
    let t = rows::<f32, 3>(&bone_tails, "bone_tails")?;
    let p = match parents {
        Some(p) => indices(&p, "parents")?,
        None => vec![-1; h.len()],
    };
    let falloff = match falloff.to_ascii_lowercase().as_str() {
        "gaussian" => Falloff::Gaussian { sigma },
        "inverse_power" | "power" => Falloff::InversePower { power },
        other => {
            return Err(PyValueError::new_err(format!("falloff must be 'gaussian' or 'inverse_power', got {other:?}")))
        }
    };
    let opts = BilinearOptions { nearest, falloff, max_influences: positive_k(max_influences)? };
    let inf = guarded(py, || core_bilinear(&v, &h, &t, &p, &opts))?;
    to_pair(py, inf)
}

fn report_dict<'py>(py: Python<'py>, r: &HeatReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("pieces", r.pieces)?;
    d.set_item("fallback_pieces", r.fallback_pieces)?;
    d.set_item("rigid_pieces", r.rigid_pieces)?;
    d.set_item("boneless_pieces", r.boneless_pieces)?;
    d.set_item("spanning_pieces", r.spanning_pieces)?;
    d.set_item("isolated_vertices", r.isolated_vertices)?;
    d.set_item("welded_vertices", r.welded_vertices)?;
    d.set_item("flipped_faces", r.flipped_faces)?;
    d.set_item("mirrored_vertices", r.mirrored_vertices)?;
    d.set_item("side_bones_paired", r.side_bones_paired)?;
    d.set_item("side_bones_unpaired", r.side_bones_unpaired)?;
    d.set_item("regularized", r.regularized)?;
    d.set_item("factorization_failed", r.factorization_failed)?;
    let t = PyDict::new(py);
    for (name, secs) in &r.timings {
        t.set_item(*name, *secs)?;
    }
    d.set_item("timings", t)?;
    Ok(d)
}

/// The heat keywords shared by `heat_weights*` and `heat_sources`, read into `HeatOptions`:
/// a keyword not given keeps `HeatOptions::default()`, `None` for an optional one is as not
/// given, and an unknown keyword is a `TypeError` naming it (as Python's own). The symmetry
/// plane is `symmetry_axis = 0` (default axis 0).
fn heat_options(function: &str, options: Option<&Bound<'_, PyDict>>) -> PyResult<HeatOptions> {
    let mut opts = HeatOptions::default();
    let (mut bone_mirror, mut symmetry_axis) = (None, 0usize);
    let (mut curve_points, mut curve_bones) = (None, None);
    for (key, value) in options.into_iter().flat_map(|d| d.iter()) {
        let key: String = key.extract()?;
        let value = &value;
        match key.as_str() {
            "max_influences" => opts.max_influences = positive_k(keyword(value, &key)?)?,
            "min_weight" => opts.min_weight = keyword(value, &key)?,
            "visibility" => opts.visibility = keyword(value, &key)?,
            "weld_tolerance" => opts.weld_tolerance = keyword(value, &key)?,
            "heat_constant" => opts.heat_constant = keyword(value, &key)?,
            "bone_mirror" => bone_mirror = optional(value, &key, |m: Indices| indices(&m, "bone_mirror"))?,
            "symmetry_axis" => symmetry_axis = keyword(value, &key)?,
            "symmetry_tolerance" => opts.mirror_tolerance = keyword(value, &key)?,
            "parents" => opts.parents = optional(value, &key, |p: Indices| indices(&p, "parents"))?,
            "curve_points" => curve_points = optional(value, &key, |p: F32Rows| rows::<f32, 3>(&p, "curve_points"))?,
            "curve_bones" => curve_bones = optional(value, &key, |j: Indices| indices(&j, "curve_bones"))?,
            _ => return Err(PyTypeError::new_err(format!("{function}() got an unexpected keyword argument '{key}'"))),
        }
    }
    if symmetry_axis > 2 {
        return Err(PyValueError::new_err("symmetry_axis must be 0, 1 or 2"));
    }
    opts.symmetry = bone_mirror.map(|mirror| Symmetry { axis: symmetry_axis, plane: 0.0, mirror });
    opts.curves = match (curve_points, curve_bones) {
        (None, None) => None,
        (Some(points), Some(bone)) => Some(BoneCurves { points, bone }),
        _ => return Err(PyValueError::new_err("curve_points and curve_bones go together")),
    };
    Ok(opts)
}

/// The keyword argument `value` of `key` as a `T`; a `TypeError` names the keyword, as pyo3
/// names the arguments of a signature.
fn keyword<'a, 'py, T: FromPyObject<'a, 'py>>(value: &'a Bound<'py, PyAny>, key: &str) -> PyResult<T> {
    value.extract::<T>().map_err(|e| {
        let e: PyErr = e.into();
        if e.is_instance_of::<PyTypeError>(value.py()) {
            PyTypeError::new_err(format!("argument '{key}': {}", e.value(value.py())))
        } else {
            e
        }
    })
}

/// An optional keyword argument: `None` (as not given), or `value` read as a `T` and converted.
fn optional<'a, 'py, T: FromPyObject<'a, 'py>, U>(
    value: &'a Bound<'py, PyAny>,
    key: &str,
    convert: impl FnOnce(T) -> PyResult<U>,
) -> PyResult<Option<U>> {
    if value.is_none() {
        return Ok(None);
    }
    keyword(value, key).and_then(convert).map(Some)
}

/// The four positional arrays of the single-mesh heat functions.
type MeshAndBones = (Vec<[f32; 3]>, Vec<[u32; 3]>, Vec<[f32; 3]>, Vec<[f32; 3]>);

fn mesh_and_bones(
    vertices: &F32Rows<'_>,
    triangles: &IndexRows<'_>,
    bone_heads: &F32Rows<'_>,
    bone_tails: &F32Rows<'_>,
) -> PyResult<MeshAndBones> {
    Ok((
        rows::<f32, 3>(vertices, "vertices")?,
        index_rows::<u32, 3>(triangles, "triangles")?,
        rows::<f32, 3>(bone_heads, "bone_heads")?,
        rows::<f32, 3>(bone_tails, "bone_tails")?,
    ))
}

/// Bone-heat weights (Baran & Popovic 2007) on the welded surface; returns (indices, weights).
/// The keywords are those of `heat_weights_report`.
#[pyfunction]
#[pyo3(signature = (vertices, triangles, bone_heads, bone_tails, *, progress=None, **options))]
pub fn heat_weights<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    triangles: IndexRows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    progress: Option<Py<PyAny>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Pair<'py>> {
    let opts = heat_options("heat_weights", options)?;
    let (inf, _) = solve_heat(py, &mesh_and_bones(&vertices, &triangles, &bone_heads, &bone_tails)?, &opts, progress)?;
    to_pair(py, inf)
}

/// As `heat_weights`, plus a report dict (pieces, fallback_pieces, rigid_pieces, timings, ...).
#[pyfunction]
#[pyo3(signature = (vertices, triangles, bone_heads, bone_tails, *, progress=None, **options))]
pub fn heat_weights_report<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    triangles: IndexRows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    progress: Option<Py<PyAny>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<PairAndReport<'py>> {
    let opts = heat_options("heat_weights_report", options)?;
    let inputs = mesh_and_bones(&vertices, &triangles, &bone_heads, &bone_tails)?;
    let (inf, report) = solve_heat(py, &inputs, &opts, progress)?;
    let (i, w) = to_pair(py, inf)?;
    Ok((i, w, report_dict(py, &report)?))
}

/// `heat_weights` of the core with a Python progress callable (see [`with_progress`]).
fn solve_heat(
    py: Python<'_>,
    (v, tri, h, t): &MeshAndBones,
    opts: &HeatOptions,
    progress: Option<Py<PyAny>>,
) -> PyResult<(Influences, HeatReport)> {
    with_progress(py, progress, |cb| core_heat(v, tri, h, t, opts, cb))
}

/// Run `solve` without the GIL, handing it a Python progress callable as a core callback,
/// called with the GIL re-acquired; returning False cancels. An exception the callable raises
/// stops the solve too and is re-raised as itself, not as Cancelled.
fn with_progress<T: Send>(
    py: Python<'_>,
    progress: Option<Py<PyAny>>,
    solve: impl FnOnce(Option<&(dyn Fn(f32) -> bool + Sync)>) -> miniskeleton_core::Result<T> + Send,
) -> PyResult<T> {
    if let Some(cb) = &progress {
        if !cb.bind(py).is_callable() {
            return Err(PyTypeError::new_err("progress must be a callable taking the fraction done"));
        }
    }
    let raised: Mutex<Option<PyErr>> = Mutex::new(None);
    let callback = progress.map(|cb| {
        let raised = &raised;
        move |f: f32| -> bool {
            Python::attach(|py| match cb.call1(py, (f,)).and_then(|r| Ok(r.is_none(py) || r.is_truthy(py)?)) {
                Ok(go_on) => go_on,
                Err(e) => {
                    raised.lock().unwrap_or_else(|p| p.into_inner()).get_or_insert(e);
                    false
                }
            })
        }
    });
    let solved = guarded(py, || solve(callback.as_ref().map(|c| c as &(dyn Fn(f32) -> bool + Sync))));
    if let Some(e) = raised.into_inner().unwrap_or_else(|p| p.into_inner()) {
        return Err(e);
    }
    solved
}

/// `heat_weights_report` of several independent meshes with the same bones and options, solved
/// in parallel in one call (for many small meshes, where a call per mesh costs more than its
/// solve). `meshes`: [(vertices (n,3), triangles (m,3))]. Returns one entry per mesh, in order:
/// the tuple (indices, weights, report), or the exception that mesh raised (`ValueError` for
/// bad input, `RuntimeError` for a panic in its solve, caught per mesh in the core), returned
/// rather than raised so that the other meshes' results stand.
#[pyfunction]
#[pyo3(signature = (meshes, bone_heads, bone_tails, **options))]
pub fn heat_weights_many<'py>(
    py: Python<'py>,
    meshes: Vec<(F32Rows<'py>, IndexRows<'py>)>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Vec<Bound<'py, PyAny>>> {
    let opts = heat_options("heat_weights_many", options)?;
    let parsed = meshes
        .iter()
        .map(|(v, t)| Ok((rows::<f32, 3>(v, "vertices")?, index_rows::<u32, 3>(t, "triangles")?)))
        .collect::<PyResult<Vec<_>>>()?;
    let h = rows::<f32, 3>(&bone_heads, "bone_heads")?;
    let t = rows::<f32, 3>(&bone_tails, "bone_tails")?;
    let views: Vec<MeshRef> = parsed.iter().map(|(v, t)| (&v[..], &t[..])).collect();
    let solved = guarded(py, || Ok(core_heat_many(&views, &h, &t, &opts)))?;
    solved
        .into_iter()
        .map(|r| match r {
            Ok((inf, report)) => {
                let (i, w) = to_pair(py, inf)?;
                Ok((i, w, report_dict(py, &report)?).into_pyobject(py)?.into_any())
            }
            Err(e) => Ok(to_py(e).into_value(py).into_bound(py).into_any()),
        })
        .collect()
}

/// Debug and evaluation: the heat sources `heat_weights` finds, per vertex as top-k rows
/// (indices (n,4) int32, -1 unused; weights (n,4) float32, each bone's share of the vertex's
/// heat). The keywords are those of `heat_weights_many`.
#[pyfunction]
#[pyo3(signature = (vertices, triangles, bone_heads, bone_tails, **options))]
pub fn heat_sources<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    triangles: IndexRows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Pair<'py>> {
    let opts = heat_options("heat_sources", options)?;
    let (v, tri, h, t) = mesh_and_bones(&vertices, &triangles, &bone_heads, &bone_tails)?;
    let inf = guarded(py, || core_heat_sources(&v, &tri, &h, &t, &opts))?;
    to_pair(py, inf)
}

/// Debug and evaluation: `heat_weights_report` with the heat sources given, per vertex, as
/// top-k rows (`source_indices` (n,k), -1 unused; `source_weights` (n,k), each bone's share).
/// The keywords are those of `heat_weights_many`.
#[pyfunction]
#[pyo3(signature = (vertices, triangles, bone_heads, bone_tails, source_indices, source_weights, **options))]
#[allow(clippy::too_many_arguments)]
pub fn heat_weights_from_sources<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    triangles: IndexRows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    source_indices: IndexRows<'py>,
    source_weights: F32Rows<'py>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<PairAndReport<'py>> {
    let opts = heat_options("heat_weights_from_sources", options)?;
    let (v, tri, h, t) = mesh_and_bones(&vertices, &triangles, &bone_heads, &bone_tails)?;
    let (shape, k) = (source_indices.as_array().dim(), source_weights.as_array().dim());
    if shape != k {
        return Err(PyValueError::new_err(format!(
            "source_indices and source_weights must have one shape, got {shape:?} and {k:?}"
        )));
    }
    let sources = Influences {
        k: shape.1,
        indices: index_matrix::<i32>(&source_indices, "source_indices")?,
        weights: source_weights.as_array().iter().copied().collect(),
    };
    let (inf, report) = guarded(py, || core_heat_from_sources(&v, &tri, &h, &t, &sources, &opts, None))?;
    let (i, w) = to_pair(py, inf)?;
    Ok((i, w, report_dict(py, &report)?))
}

/// Estimated peak bytes of one heat solve of `vertices` vertices and `bones` bones
/// (`weights::heat::heat_peak_bytes`), for refusing one that would not fit before it starts.
#[pyfunction]
pub fn heat_peak_bytes(vertices: usize, bones: usize) -> u64 {
    miniskeleton_core::weights::heat::heat_peak_bytes(vertices, bones)
}

/// Geodesic voxel binding (Dionne & de Lasa 2013): (indices, weights, report). `objects` (n,):
/// the object of each vertex when several meshes are stacked (an object whose pieces hold no
/// bone is a prop, bound rigidly); `bone_mirror` and `symmetry_axis` as for `heat_weights`.
#[pyfunction]
#[pyo3(signature = (vertices, triangles, bone_heads, bone_tails, *, progress=None, resolution=64, falloff=0.02,
                    max_influences=4, bone_mirror=None, symmetry_axis=0, parents=None, curve_points=None,
                    curve_bones=None, objects=None))]
#[allow(clippy::too_many_arguments)]
pub fn voxel_weights<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    triangles: IndexRows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    progress: Option<Py<PyAny>>,
    resolution: usize,
    falloff: f32,
    max_influences: usize,
    bone_mirror: Option<Indices<'py>>,
    symmetry_axis: usize,
    parents: Option<Indices<'py>>,
    curve_points: Option<F32Rows<'py>>,
    curve_bones: Option<Indices<'py>>,
    objects: Option<Indices<'py>>,
) -> PyResult<PairAndReport<'py>> {
    let (v, tri, h, t) = mesh_and_bones(&vertices, &triangles, &bone_heads, &bone_tails)?;
    if symmetry_axis > 2 {
        return Err(PyValueError::new_err("symmetry_axis must be 0, 1 or 2"));
    }
    let opts = VoxelOptions {
        resolution,
        falloff,
        max_influences: positive_k(max_influences)?,
        symmetry: bone_mirror
            .map(|m| Ok::<_, PyErr>(Symmetry { axis: symmetry_axis, plane: 0.0, mirror: indices(&m, "bone_mirror")? }))
            .transpose()?,
        parents: parents.map(|p| indices(&p, "parents")).transpose()?,
        curves: bone_curves(curve_points, curve_bones)?,
        objects: objects.map(|o| indices(&o, "objects")).transpose()?,
        ..Default::default()
    };
    let (inf, report) = with_progress(py, progress, |cb| core_voxel(&v, &tri, &h, &t, &opts, cb))?;
    let (i, w) = to_pair(py, inf)?;
    Ok((i, w, voxel_report_dict(py, &report)?))
}

/// Bent bones from the optional `curve_points` / `curve_bones` pair.
fn bone_curves(points: Option<F32Rows<'_>>, bones: Option<Indices<'_>>) -> PyResult<Option<BoneCurves>> {
    match (points, bones) {
        (None, None) => Ok(None),
        (Some(p), Some(b)) => {
            Ok(Some(BoneCurves { points: rows::<f32, 3>(&p, "curve_points")?, bone: indices(&b, "curve_bones")? }))
        }
        _ => Err(PyValueError::new_err("curve_points and curve_bones go together")),
    }
}

fn voxel_report_dict<'py>(py: Python<'py>, r: &VoxelReport) -> PyResult<Bound<'py, PyDict>> {
    let d = report_dict(py, &r.heat)?;
    d.set_item("grid", r.grid.to_vec())?;
    d.set_item("solid_voxels", r.solid_voxels)?;
    d.set_item("outside_bones", r.outside_bones)?;
    let t = d.get_item("timings")?.expect("report_dict sets timings");
    let t = t.cast::<PyDict>()?;
    for (name, secs) in &r.timings {
        t.set_item(*name, *secs)?;
    }
    Ok(d)
}

/// Debug and evaluation: each vertex's k nearest bones by geodesic distance through the voxel
/// solid: (indices (n,k) int32, -1 unused; geodesic, straight distances (n,k) float32, bbox
/// diagonals; cosines (n,k) float32 of the vertex normal and the direction from the bone).
#[pyfunction]
#[pyo3(signature = (vertices, triangles, bone_heads, bone_tails, *, k=8, resolution=64, parents=None,
                    curve_points=None, curve_bones=None))]
#[allow(clippy::too_many_arguments)]
pub fn voxel_distances<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    triangles: IndexRows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    k: usize,
    resolution: usize,
    parents: Option<Indices<'py>>,
    curve_points: Option<F32Rows<'py>>,
    curve_bones: Option<Indices<'py>>,
) -> PyResult<VoxelQuad<'py>> {
    let (v, tri, h, t) = mesh_and_bones(&vertices, &triangles, &bone_heads, &bone_tails)?;
    let opts = VoxelOptions {
        resolution,
        parents: parents.map(|p| indices(&p, "parents")).transpose()?,
        curves: bone_curves(curve_points, curve_bones)?,
        ..Default::default()
    };
    let out = guarded(py, || core_voxel_distances(&v, &tri, &h, &t, k, &opts))?;
    let n = out.bones.len() / k.max(1);
    Ok((
        matrix(py, out.bones, n, k)?,
        matrix(py, out.geodesic, n, k)?,
        matrix(py, out.euclid, n, k)?,
        matrix(py, out.cos, n, k)?,
    ))
}

type VoxelQuad<'py> =
    (Bound<'py, PyArray2<i32>>, Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<f32>>);

/// Robust skin weights transfer (Abdrashitov et al. 2023): a body's weights onto a garment.
/// `body_indices` / `body_weights` (nb,k): the body's top-k weights. Returns (indices, weights,
/// report: matched, inpainted, nearest, regularized).
#[pyfunction]
#[pyo3(signature = (body_vertices, body_triangles, body_indices, body_weights, vertices, triangles, *,
                    max_distance=0.05, max_angle=30.0, flipped=true, max_influences=4))]
#[allow(clippy::too_many_arguments)]
pub fn transfer_weights<'py>(
    py: Python<'py>,
    body_vertices: F32Rows<'py>,
    body_triangles: IndexRows<'py>,
    body_indices: IndexRows<'py>,
    body_weights: F32Rows<'py>,
    vertices: F32Rows<'py>,
    triangles: IndexRows<'py>,
    max_distance: f32,
    max_angle: f32,
    flipped: bool,
    max_influences: usize,
) -> PyResult<PairAndReport<'py>> {
    let bv = rows::<f32, 3>(&body_vertices, "body_vertices")?;
    let bt = index_rows::<u32, 3>(&body_triangles, "body_triangles")?;
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let t = index_rows::<u32, 3>(&triangles, "triangles")?;
    let (shape, k) = (body_indices.as_array().dim(), body_weights.as_array().dim());
    if shape != k {
        return Err(PyValueError::new_err(format!(
            "body_indices and body_weights must have one shape, got {shape:?} and {k:?}"
        )));
    }
    let body = Influences {
        k: shape.1,
        indices: index_matrix::<i32>(&body_indices, "body_indices")?,
        weights: body_weights.as_array().iter().copied().collect(),
    };
    let opts = TransferOptions {
        max_distance,
        max_angle,
        flipped,
        max_influences: positive_k(max_influences)?,
        ..Default::default()
    };
    let (inf, r) = guarded(py, || core_transfer(&bv, &bt, &body, &v, &t, &opts))?;
    let (i, w) = to_pair(py, inf)?;
    let d = PyDict::new(py);
    d.set_item("matched", r.matched)?;
    d.set_item("inpainted", r.inpainted)?;
    d.set_item("nearest", r.nearest)?;
    d.set_item("regularized", r.regularized)?;
    Ok((i, w, d))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(voxel_weights, m)?)?;
    m.add_function(wrap_pyfunction!(transfer_weights, m)?)?;
    m.add_function(wrap_pyfunction!(voxel_distances, m)?)?;
    m.add_function(wrap_pyfunction!(heat_peak_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(idw_weights, m)?)?;
    m.add_function(wrap_pyfunction!(bilinear_weights, m)?)?;
    m.add_function(wrap_pyfunction!(heat_weights, m)?)?;
    m.add_function(wrap_pyfunction!(heat_weights_report, m)?)?;
    m.add_function(wrap_pyfunction!(heat_weights_many, m)?)?;
    m.add_function(wrap_pyfunction!(heat_sources, m)?)?;
    m.add_function(wrap_pyfunction!(heat_weights_from_sources, m)?)?;
    Ok(())
}
