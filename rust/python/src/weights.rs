//! Bindings for `miniskeleton_core::weights` (heat, bilinear, inverse distance): skinning weights
//! as dense top-k arrays.

use crate::convert::{index_matrix, index_rows, indices, matrix, rows, unpacks_as, IndexRows, Indices};
use crate::error::{guarded, to_py};
use crate::options::{keyword, optional, read_options};
use miniskeleton_core::mesh::Symmetry;
use miniskeleton_core::weights::Influences;
use miniskeleton_core::weights::{bilinear_weights as core_bilinear, BilinearOptions, Falloff, INVERSE_POWER};
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

/// Top-k weights: indices int32 (n,k) (-1 unused), weights float32 (n,k); they unpack in that
/// order.
#[pyclass(name = "Influences", module = "miniskeleton_core", frozen, get_all)]
pub struct PyInfluences {
    indices: Py<PyArray2<i32>>,
    weights: Py<PyArray2<f32>>,
}
unpacks_as!(PyInfluences, indices, weights);

/// What a heat or voxel bind did (`HeatReport`, and `VoxelReport`'s own fields, None for heat):
/// pieces, fallback_pieces (saw no bone), rigid_pieces, boneless_pieces, spanning_pieces,
/// isolated_vertices, welded_vertices, flipped_faces, mirrored_vertices, side_bones_paired,
/// side_bones_unpaired, regularized, factorization_failed, timings (stage -> seconds); voxel:
/// grid (3 ints), solid_voxels, outside_bones.
#[pyclass(name = "WeightsReport", module = "miniskeleton_core", frozen, get_all)]
pub struct PyWeightsReport {
    pieces: usize,
    fallback_pieces: usize,
    rigid_pieces: usize,
    boneless_pieces: usize,
    spanning_pieces: usize,
    isolated_vertices: usize,
    welded_vertices: usize,
    flipped_faces: usize,
    mirrored_vertices: usize,
    side_bones_paired: usize,
    side_bones_unpaired: usize,
    regularized: bool,
    factorization_failed: bool,
    timings: Py<PyDict>,
    grid: Option<(usize, usize, usize)>,
    solid_voxels: Option<usize>,
    outside_bones: Option<usize>,
}

/// Top-k weights with their report: indices int32 (n,k) (-1 unused), weights float32 (n,k),
/// report (`WeightsReport`).
#[pyclass(name = "Weights", module = "miniskeleton_core", frozen, get_all)]
pub struct PyWeights {
    indices: Py<PyArray2<i32>>,
    weights: Py<PyArray2<f32>>,
    report: Py<PyWeightsReport>,
}

fn weights_result(py: Python<'_>, inf: Influences, report: PyWeightsReport) -> PyResult<PyWeights> {
    let PyInfluences { indices, weights } = to_influences(py, inf)?;
    Ok(PyWeights { indices, weights, report: Py::new(py, report)? })
}

fn to_influences(py: Python<'_>, inf: Influences) -> PyResult<PyInfluences> {
    let n = inf.n();
    let indices = matrix(py, inf.indices, n, inf.k)?.unbind();
    Ok(PyInfluences { indices, weights: matrix(py, inf.weights, n, inf.k)?.unbind() })
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
) -> PyResult<PyInfluences> {
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let h = rows::<f32, 3>(&bone_heads, "bone_heads")?;
    let t = rows::<f32, 3>(&bone_tails, "bone_tails")?;
    let opts = IdwOptions { power, max_influences: positive_k(max_influences)?, epsilon };
    let inf = guarded(py, || core_idw(&v, &h, &t, &opts))?;
    to_influences(py, inf)
}

/// Nearest-bone weights with joint blending (see `bilinear.rs`). Keywords: max_influences,
/// nearest, falloff ("gaussian" | "inverse_power"), sigma (gaussian), power (inverse_power);
/// each left out keeps `BilinearOptions::default()`.
#[pyfunction]
#[pyo3(signature = (vertices, bone_heads, bone_tails, parents=None, **options))]
pub fn bilinear_weights<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    parents: Option<Indices<'py>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<PyInfluences> {
    let v = rows::<f32, 3>(&vertices, "vertices")?;
    let h = rows::<f32, 3>(&bone_heads, "bone_heads")?;
    let t = rows::<f32, 3>(&bone_tails, "bone_tails")?;
    let p = match parents {
        Some(p) => indices(&p, "parents")?,
        None => vec![-1; h.len()],
    };
    // The falloff's name and its parameters, in any order: (name, sigma, power).
    let given = (None::<String>, None::<f32>, None::<f32>);
    let (mut opts, (name, sigma, power)) =
        read_options("bilinear_weights", options, (BilinearOptions::default(), given), |(o, f), key, value| {
            match key {
                "max_influences" => o.max_influences = positive_k(keyword(value, key)?)?,
                "nearest" => o.nearest = keyword(value, key)?,
                "falloff" => f.0 = Some(keyword(value, key)?),
                "sigma" => f.1 = optional(value, key, Ok)?,
                "power" => f.2 = Some(keyword(value, key)?),
                _ => return Ok(false),
            }
            Ok(true)
        })?;
    opts.falloff = match name.as_deref().map(str::to_ascii_lowercase).as_deref() {
        None | Some("gaussian") => Falloff::Gaussian { sigma },
        Some("inverse_power" | "power") => Falloff::InversePower { power: power.unwrap_or(INVERSE_POWER) },
        Some(other) => {
            return Err(PyValueError::new_err(format!("falloff must be 'gaussian' or 'inverse_power', got {other:?}")))
        }
    };
    let inf = guarded(py, || core_bilinear(&v, &h, &t, &p, &opts))?;
    to_influences(py, inf)
}

fn heat_report(py: Python<'_>, r: &HeatReport) -> PyResult<PyWeightsReport> {
    let timings = PyDict::new(py);
    for (name, secs) in &r.timings {
        timings.set_item(*name, *secs)?;
    }
    Ok(PyWeightsReport {
        pieces: r.pieces,
        fallback_pieces: r.fallback_pieces,
        rigid_pieces: r.rigid_pieces,
        boneless_pieces: r.boneless_pieces,
        spanning_pieces: r.spanning_pieces,
        isolated_vertices: r.isolated_vertices,
        welded_vertices: r.welded_vertices,
        flipped_faces: r.flipped_faces,
        mirrored_vertices: r.mirrored_vertices,
        side_bones_paired: r.side_bones_paired,
        side_bones_unpaired: r.side_bones_unpaired,
        regularized: r.regularized,
        factorization_failed: r.factorization_failed,
        timings: timings.unbind(),
        grid: None,
        solid_voxels: None,
        outside_bones: None,
    })
}

/// The heat keywords shared by `heat_weights*` and `heat_sources`, read into `HeatOptions`:
/// a keyword not given keeps `HeatOptions::default()`, `None` for an optional one is as not
/// given, and an unknown keyword is a `TypeError` naming it (as Python's own). The symmetry
/// plane is `symmetry_axis = 0` (default axis 0).
fn heat_options(function: &str, options: Option<&Bound<'_, PyDict>>) -> PyResult<HeatOptions> {
    let (mut opts, bones) =
        read_options(function, options, (HeatOptions::default(), BoneKeywords::default()), |(o, b), key, value| {
            match key {
                "max_influences" => o.max_influences = positive_k(keyword(value, key)?)?,
                "min_weight" => o.min_weight = keyword(value, key)?,
                "visibility" => o.visibility = keyword(value, key)?,
                "weld_tolerance" => o.weld_tolerance = keyword(value, key)?,
                "heat_constant" => o.heat_constant = keyword(value, key)?,
                "symmetry_tolerance" => o.mirror_tolerance = keyword(value, key)?,
                "parents" => o.parents = optional(value, key, |p: Indices| indices(&p, "parents"))?,
                _ => return b.read(key, value),
            }
            Ok(true)
        })?;
    (opts.symmetry, opts.curves) = bones.finish()?;
    Ok(opts)
}

/// The keywords the heat and voxel bindings share about the bones: `bone_mirror` with
/// `symmetry_axis` (0, 1 or 2; default 0), and bent bones as `curve_points` with `curve_bones`.
#[derive(Default)]
struct BoneKeywords {
    bone_mirror: Option<Vec<i32>>,
    symmetry_axis: usize,
    curve_points: Option<Vec<[f32; 3]>>,
    curve_bones: Option<Vec<u32>>,
}

impl BoneKeywords {
    /// Take `key` if it is one of these; `Ok(false)` if not.
    fn read(&mut self, key: &str, value: &Bound<'_, PyAny>) -> PyResult<bool> {
        match key {
            "bone_mirror" => self.bone_mirror = optional(value, key, |m: Indices| indices(&m, "bone_mirror"))?,
            "symmetry_axis" => self.symmetry_axis = keyword(value, key)?,
            "curve_points" => {
                self.curve_points = optional(value, key, |p: F32Rows| rows::<f32, 3>(&p, "curve_points"))?
            }
            "curve_bones" => self.curve_bones = optional(value, key, |j: Indices| indices(&j, "curve_bones"))?,
            _ => return Ok(false),
        }
        Ok(true)
    }

    /// The mirror across `x[symmetry_axis] = 0` and the bent bones, checked.
    fn finish(self) -> PyResult<(Option<Symmetry>, Option<BoneCurves>)> {
        if self.symmetry_axis > 2 {
            return Err(PyValueError::new_err("symmetry_axis must be 0, 1 or 2"));
        }
        let symmetry = self.bone_mirror.map(|mirror| Symmetry { axis: self.symmetry_axis, plane: 0.0, mirror });
        let curves = match (self.curve_points, self.curve_bones) {
            (None, None) => None,
            (Some(points), Some(bone)) => Some(BoneCurves { points, bone }),
            _ => return Err(PyValueError::new_err("curve_points and curve_bones go together")),
        };
        Ok((symmetry, curves))
    }
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
) -> PyResult<PyInfluences> {
    let opts = heat_options("heat_weights", options)?;
    let (inf, _) = solve_heat(py, &mesh_and_bones(&vertices, &triangles, &bone_heads, &bone_tails)?, &opts, progress)?;
    to_influences(py, inf)
}

/// As `heat_weights`, with its report: a `Weights` (indices, weights, report).
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
) -> PyResult<PyWeights> {
    let opts = heat_options("heat_weights_report", options)?;
    let inputs = mesh_and_bones(&vertices, &triangles, &bone_heads, &bone_tails)?;
    let (inf, report) = solve_heat(py, &inputs, &opts, progress)?;
    weights_result(py, inf, heat_report(py, &report)?)
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
/// its `Weights`, or the exception that mesh raised (`ValueError` for
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
            Ok((inf, report)) => Ok(Bound::new(py, weights_result(py, inf, heat_report(py, &report)?)?)?.into_any()),
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
) -> PyResult<PyInfluences> {
    let opts = heat_options("heat_sources", options)?;
    let (v, tri, h, t) = mesh_and_bones(&vertices, &triangles, &bone_heads, &bone_tails)?;
    let inf = guarded(py, || core_heat_sources(&v, &tri, &h, &t, &opts))?;
    to_influences(py, inf)
}

/// Debug and evaluation: `heat_weights_report` with the heat sources given, per vertex, as
/// top-k rows (`source_indices` (n,k), -1 unused; `source_weights` (n,k), each bone's share).
/// The keywords are those of `heat_weights_many`.
#[pyfunction]
#[pyo3(signature = (vertices, triangles, bone_heads, bone_tails, source_indices, source_weights, **options))]
pub fn heat_weights_from_sources<'py>(
    vertices: F32Rows<'py>,
    triangles: IndexRows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    source_indices: IndexRows<'py>,
    source_weights: F32Rows<'py>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<PyWeights> {
    let py = vertices.py();
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
    weights_result(py, inf, heat_report(py, &report)?)
}

/// Estimated peak bytes of one heat solve of `vertices` vertices and `bones` bones
/// (`weights::heat::heat_peak_bytes`), for refusing one that would not fit before it starts.
#[pyfunction]
pub fn heat_peak_bytes(vertices: usize, bones: usize) -> u64 {
    miniskeleton_core::weights::heat::heat_peak_bytes(vertices, bones)
}

/// Geodesic voxel binding (Dionne & de Lasa 2013): a `Weights` (indices, weights, report). `objects` (n,):
/// the object of each vertex when several meshes are stacked (an object whose pieces hold no
/// bone is a prop, bound rigidly); `bone_mirror` and `symmetry_axis` as for `heat_weights`.
/// Keywords: resolution, falloff, max_influences, bone_mirror, symmetry_axis, parents,
/// curve_points, curve_bones, objects; each left out keeps `VoxelOptions::default()`.
#[pyfunction]
#[pyo3(signature = (vertices, triangles, bone_heads, bone_tails, *, progress=None, **options))]
pub fn voxel_weights<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    triangles: IndexRows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    progress: Option<Py<PyAny>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<PyWeights> {
    let (v, tri, h, t) = mesh_and_bones(&vertices, &triangles, &bone_heads, &bone_tails)?;
    let opts = voxel_options("voxel_weights", options, &["resolution", "falloff", "max_influences", "objects"])?;
    let (inf, report) = with_progress(py, progress, |cb| core_voxel(&v, &tri, &h, &t, &opts, cb))?;
    weights_result(py, inf, voxel_report(py, &report)?)
}

/// The voxel keywords read into `VoxelOptions::default()`: `parents`, the bones' keywords
/// ([`BoneKeywords`]) and those of `own` among resolution, falloff, max_influences and objects.
fn voxel_options(function: &str, options: Option<&Bound<'_, PyDict>>, own: &[&str]) -> PyResult<VoxelOptions> {
    let (mut opts, bones) =
        read_options(function, options, (VoxelOptions::default(), BoneKeywords::default()), |(o, b), key, value| {
            match key {
                "parents" => o.parents = optional(value, key, |p: Indices| indices(&p, "parents"))?,
                _ if !own.contains(&key) => return b.read(key, value),
                "resolution" => o.resolution = keyword(value, key)?,
                "falloff" => o.falloff = keyword(value, key)?,
                "max_influences" => o.max_influences = positive_k(keyword(value, key)?)?,
                "objects" => o.objects = optional(value, key, |j: Indices| indices(&j, "objects"))?,
                _ => return Ok(false),
            }
            Ok(true)
        })?;
    (opts.symmetry, opts.curves) = bones.finish()?;
    Ok(opts)
}

fn voxel_report(py: Python<'_>, r: &VoxelReport) -> PyResult<PyWeightsReport> {
    let report = heat_report(py, &r.heat)?;
    let timings = report.timings.bind(py);
    for (name, secs) in &r.timings {
        timings.set_item(*name, *secs)?;
    }
    let [x, y, z] = r.grid;
    Ok(PyWeightsReport {
        grid: Some((x, y, z)),
        solid_voxels: Some(r.solid_voxels),
        outside_bones: Some(r.outside_bones),
        ..report
    })
}

/// Debug and evaluation: each vertex's k nearest bones by geodesic distance through the voxel
/// solid, a `VoxelDistances`.
#[pyfunction]
#[pyo3(signature = (vertices, triangles, bone_heads, bone_tails, *, k=8, **options))]
pub fn voxel_distances<'py>(
    py: Python<'py>,
    vertices: F32Rows<'py>,
    triangles: IndexRows<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    k: usize,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<PyVoxelDistances> {
    let (v, tri, h, t) = mesh_and_bones(&vertices, &triangles, &bone_heads, &bone_tails)?;
    let opts = voxel_options("voxel_distances", options, &["resolution"])?;
    let out = guarded(py, || core_voxel_distances(&v, &tri, &h, &t, k, &opts))?;
    let n = out.bones.len() / k.max(1);
    Ok(PyVoxelDistances {
        indices: matrix(py, out.bones, n, k)?.unbind(),
        geodesic: matrix(py, out.geodesic, n, k)?.unbind(),
        straight: matrix(py, out.euclid, n, k)?.unbind(),
        cosines: matrix(py, out.cos, n, k)?.unbind(),
    })
}

/// Each vertex's k nearest bones through the voxel solid: indices (n,k) int32 (-1 unused);
/// geodesic and straight distances (n,k) float32 in bbox diagonals; cosines (n,k) float32 of
/// the vertex normal and the direction from the bone.
#[pyclass(name = "VoxelDistances", module = "miniskeleton_core", frozen, get_all)]
pub struct PyVoxelDistances {
    indices: Py<PyArray2<i32>>,
    geodesic: Py<PyArray2<f32>>,
    straight: Py<PyArray2<f32>>,
    cosines: Py<PyArray2<f32>>,
}

/// What a transfer did: garment vertices matched on the body, inpainted, given their nearest
/// points' weights (`nearest`), and whether the solve was regularized.
#[pyclass(name = "TransferReport", module = "miniskeleton_core", frozen, get_all)]
pub struct PyTransferReport {
    matched: usize,
    inpainted: usize,
    nearest: usize,
    regularized: bool,
}

/// Transferred top-k weights: indices int32 (n,k), weights float32 (n,k), report
/// (`TransferReport`).
#[pyclass(name = "TransferredWeights", module = "miniskeleton_core", frozen, get_all)]
pub struct PyTransferredWeights {
    indices: Py<PyArray2<i32>>,
    weights: Py<PyArray2<f32>>,
    report: Py<PyTransferReport>,
}

/// Robust skin weights transfer (Abdrashitov et al. 2023): a body's weights onto a garment.
/// `body_indices` / `body_weights` (nb,k): the body's top-k weights. Returns a
/// `TransferredWeights`. Keywords: max_distance, max_angle, flipped,
/// max_influences; each left out keeps `TransferOptions::default()`.
#[pyfunction]
#[pyo3(signature = (body_vertices, body_triangles, body_indices, body_weights, vertices, triangles, **options))]
pub fn transfer_weights<'py>(
    body_vertices: F32Rows<'py>,
    body_triangles: IndexRows<'py>,
    body_indices: IndexRows<'py>,
    body_weights: F32Rows<'py>,
    vertices: F32Rows<'py>,
    triangles: IndexRows<'py>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<PyTransferredWeights> {
    let py = vertices.py();
    let opts = read_options("transfer_weights", options, TransferOptions::default(), |o, key, value| {
        match key {
            "max_distance" => o.max_distance = keyword(value, key)?,
            "max_angle" => o.max_angle = keyword(value, key)?,
            "flipped" => o.flipped = keyword(value, key)?,
            "max_influences" => o.max_influences = positive_k(keyword(value, key)?)?,
            _ => return Ok(false),
        }
        Ok(true)
    })?;
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
    let (inf, r) = guarded(py, || core_transfer(&bv, &bt, &body, &v, &t, &opts))?;
    let PyInfluences { indices, weights } = to_influences(py, inf)?;
    let report =
        PyTransferReport { matched: r.matched, inpainted: r.inpainted, nearest: r.nearest, regularized: r.regularized };
    Ok(PyTransferredWeights { indices, weights, report: Py::new(py, report)? })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyInfluences>()?;
    m.add_class::<PyWeights>()?;
    m.add_class::<PyWeightsReport>()?;
    m.add_class::<PyVoxelDistances>()?;
    m.add_class::<PyTransferredWeights>()?;
    m.add_class::<PyTransferReport>()?;
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
