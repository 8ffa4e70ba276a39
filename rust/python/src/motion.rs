//! Bindings for motion: skeleton roles (`roles.rs`), procedural gaits (`gait.rs`) and where they
//! go (`course.rs`, `terrain.rs`).

use crate::convert::{from_rows, indices, rows, Indices};
use crate::error::guarded;
use crate::options::{keyword, optional, read_options};
use miniskeleton_core::motion::{detect_roles as core_detect, BodyPlan, Limb, Roles, Side};
use miniskeleton_core::motion::{steered_clip, Course, GaitParams, Motion, Skeleton, Skin, Steer, Terrain};
use numpy::ndarray::Array3;
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

type F32Rows<'py> = PyArrayLike2<'py, f32, AllowTypeChange>;

/// A leg or an arm: its bones from the body outwards, side ("L" | "R") and group (legs: 0 is the
/// front pair, counting backwards; arms: 0).
#[pyclass(name = "Limb", module = "miniskeleton_core", frozen, eq, get_all)]
#[derive(PartialEq)]
pub struct PyLimb {
    bones: Vec<usize>,
    side: &'static str,
    group: usize,
}

/// The roles of a skeleton's bones (see `detect_roles`).
#[pyclass(name = "Roles", module = "miniskeleton_core", frozen, get_all)]
pub struct PyRoles {
    root: usize,
    spine: Vec<usize>,
    neck: Vec<usize>,
    head: usize,
    head_extras: Vec<usize>,
    tail: Vec<usize>,
    legs: Py<PyTuple>,
    arms: Py<PyTuple>,
    plan: &'static str,
    up: [f32; 3],
    forward: [f32; 3],
    left: [f32; 3],
    ground: f32,
    height: f32,
    leg_length: f32,
    single_tree: bool,
    riders: Vec<(usize, usize)>,
    notes: Vec<String>,
}

fn limbs(py: Python<'_>, limbs: &[Limb]) -> PyResult<Py<PyTuple>> {
    let side = |s: Side| if s == Side::Left { "L" } else { "R" };
    let limbs = limbs
        .iter()
        .map(|l| Py::new(py, PyLimb { bones: l.bones.clone(), side: side(l.side), group: l.group }))
        .collect::<PyResult<Vec<_>>>()?;
    Ok(PyTuple::new(py, limbs)?.unbind())
}

fn roles(py: Python<'_>, r: &Roles) -> PyResult<PyRoles> {
    Ok(PyRoles {
        root: r.root,
        spine: r.spine.clone(),
        neck: r.neck.clone(),
        head: r.head,
        head_extras: r.head_extras.clone(),
        tail: r.tail.clone(),
        legs: limbs(py, &r.legs)?,
        arms: limbs(py, &r.arms)?,
        plan: match r.plan {
            BodyPlan::Biped => "biped",
            BodyPlan::Quadruped => "quadruped",
            BodyPlan::Multiped => "multiped",
            BodyPlan::Legless => "legless",
        },
        up: r.up,
        forward: r.forward,
        left: r.left,
        ground: r.ground,
        height: r.height,
        leg_length: r.leg_length,
        single_tree: r.single_tree,
        riders: r.riders.iter().map(|&[a, b]| (a, b)).collect(),
        notes: r.notes.clone(),
    })
}

/// A motion clip (see `make_motion`): rotations (frames, b, 4), root_offset (frames, 3),
/// animated (k,), locations (frames, b, 3), located (j,), moves_root, frames,
/// frames_per_cycle, roles.
#[pyclass(name = "MotionClip", module = "miniskeleton_core", frozen, get_all)]
pub struct PyMotionClip {
    rotations: Py<PyArray3<f32>>,
    root_offset: Py<PyArray2<f32>>,
    animated: Py<PyArray1<i32>>,
    locations: Py<PyArray3<f32>>,
    located: Py<PyArray1<i32>>,
    moves_root: bool,
    frames: usize,
    frames_per_cycle: f32,
    roles: Py<PyRoles>,
}

/// The arrays a [`Skeleton`] views, read from Python: heads, tails, parents, names.
type Bones = (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<i32>, Vec<String>);

fn bones(
    heads: &F32Rows<'_>,
    tails: &F32Rows<'_>,
    parents: &Indices<'_>,
    names: Option<Vec<String>>,
) -> PyResult<Bones> {
    Ok((
        rows::<f32, 3>(heads, "bone_heads")?,
        rows::<f32, 3>(tails, "bone_tails")?,
        indices(parents, "parents")?,
        names.unwrap_or_default(),
    ))
}

/// Roles of a skeleton's bones (+Z up), a `Roles`: root, spine, neck, head, head_extras, tail,
/// legs/arms (`Limb`s: bones, side 'L'/'R', group, 0 = front), plan, up/forward/left,
/// ground, height, leg_length, single_tree (moving the root bone moves the body), riders
/// ([(foot, leg bone)]: feet hanging off the root that ride on their leg), notes.
/// ValueError (saying what is missing) with no legs or head.
#[pyfunction]
#[pyo3(signature = (bone_heads, bone_tails, parents, names=None))]
pub fn detect_roles<'py>(
    py: Python<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    parents: Indices<'py>,
    names: Option<Vec<String>>,
) -> PyResult<PyRoles> {
    let (h, t, p, n) = bones(&bone_heads, &bone_tails, &parents, names)?;
    let r = guarded(py, move || core_detect(&Skeleton::new(&h, &t, &p, &n)))?;
    roles(py, &r)
}

/// Motion for a skeleton: 'HEAD_SHAKE', 'WALK' or 'RUN'. rest_matrices (b,3,3) or (b,9):
/// each bone's rest orientation in the same space as heads/tails (columns = bone X, Y, Z).
/// Returns a `MotionClip`: rotations (frames, b, 4) float32 local quaternions (w, x, y, z),
/// root_offset (frames, 3) float32 in the input space, animated (k,) int32 bone indices,
/// locations (frames, b, 3) float32 local locations in input units (Blender's
/// `pose_bone.location` times the armature's scale; zero but for `located`), located (j,)
/// int32 (the roles' riders), moves_root, frames, frames_per_cycle, roles (`Roles`).
/// joint_tails: the tails are an importer's invention; roles and motion read tails made from
/// the joints instead (`skeleton::joint_tails`). skin_points (p, 3) and skin_bones (p,) int32:
/// the character's skin at rest in the same space and the bone weighing most on each point (-1:
/// none); the feet stand on the ground its soles rest on (a body that does not stand level is
/// settled first) and arms hang clear of its body. Without them the bones alone are read.
/// path (p, 3): a polyline in the heads' space the walk or run follows (the clip covers its
/// length; `cycles` is read from it; an error with root_motion off). ground ((x, y), cell,
/// heights (ny, nx)): a height field, heights[j, i] at (x + i cell, y + j cell), NaN for a miss;
/// the feet stand on it, turned to its slope. Keywords: fps, cycles, duration, amplitude
/// (radians), stride, speed, root_motion (each left out keeps `GaitParams::default()`),
/// joint_tails, skin_points, skin_bones, path, ground (left out: off, none).
#[pyfunction]
#[pyo3(signature = (bone_heads, bone_tails, parents, rest_matrices, motion="WALK", *, names=None, **options))]
pub fn make_motion<'py>(
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    parents: Indices<'py>,
    rest_matrices: numpy::PyArrayLikeDyn<'py, f32, AllowTypeChange>,
    motion: &str,
    names: Option<Vec<String>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<PyMotionClip> {
    let py = bone_heads.py();
    let (heads, mut tails, parents, names) = bones(&bone_heads, &bone_tails, &parents, names)?;
    let (mut params, extra) = read_options(
        "make_motion",
        options,
        (GaitParams::default(), MotionKeywords::default()),
        |(p, x), key, value| {
            match key {
                "fps" => p.fps = keyword(value, key)?,
                "cycles" => p.cycles = keyword(value, key)?,
                "duration" => p.duration = keyword(value, key)?,
                "amplitude" => p.amplitude = keyword(value, key)?,
                "stride" => p.stride = keyword(value, key)?,
                "speed" => p.speed = keyword(value, key)?,
                "root_motion" => p.root_motion = keyword(value, key)?,
                _ => return x.read(key, value),
            }
            Ok(true)
        },
    )?;
    let MotionKeywords { joint_tails, skin_points, skin_bones, path, ground } = extra;
    params.motion = match motion.to_ascii_uppercase().as_str() {
        "HEAD_SHAKE" => Motion::HeadShake,
        "WALK" => Motion::Walk,
        "RUN" => Motion::Run,
        other => {
            return Err(PyValueError::new_err(format!("motion must be 'HEAD_SHAKE', 'WALK' or 'RUN', got {other:?}")))
        }
    };
    let view = rest_matrices.as_array();
    let flat: Vec<f32> = view.iter().copied().collect();
    if flat.len() != 9 * heads.len() || view.shape().first() != Some(&heads.len()) {
        return Err(PyValueError::new_err(format!(
            "rest_matrices must have shape ({n}, 3, 3) or ({n}, 9), got {:?}",
            view.shape(),
            n = heads.len()
        )));
    }
    let rest: Vec<[f32; 9]> = flat.chunks_exact(9).map(|c| c.try_into().unwrap()).collect();
    let (found, clip) = guarded(py, move || {
        if joint_tails {
            miniskeleton_core::skeleton::validate_parents(&parents, heads.len())?;
            tails = miniskeleton_core::skeleton::joint_tails(&heads, &tails, &parents);
        }
        let skeleton = Skeleton::new(&heads, &tails, &parents, &names);
        let roles = core_detect(&skeleton)?;
        let skin = Skin { points: &skin_points, bones: &skin_bones };
        let steer = Steer {
            course: path.as_deref().map(Course::new).transpose()?,
            terrain: match &ground {
                Some((origin, cell, size, heights)) => Terrain::field(*origin, *cell, *size, heights)?,
                None => Terrain::LEVEL,
            },
        };
        let clip = steered_clip(&skeleton, &rest, &roles, (&params, &steer), &skin)?;
        Ok((roles, clip))
    })?;
    let flat: Vec<f32> = clip.rotations.iter().flat_map(|q| q.iter().copied()).collect();
    let rot = Array3::from_shape_vec((clip.frames, clip.bone_count, 4), flat)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let flat: Vec<f32> = clip.locations.iter().flat_map(|l| l.iter().copied()).collect();
    let loc = Array3::from_shape_vec((clip.frames, clip.bone_count, 3), flat)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let bones = |b: &[usize]| PyArray1::from_vec(py, b.iter().map(|&b| b as i32).collect()).unbind();
    Ok(PyMotionClip {
        rotations: rot.into_pyarray(py).unbind(),
        root_offset: from_rows(py, &clip.root_offset)?.unbind(),
        animated: bones(&clip.animated),
        locations: loc.into_pyarray(py).unbind(),
        located: bones(&clip.located),
        moves_root: clip.moves_root,
        frames: clip.frames,
        frames_per_cycle: clip.frames_per_cycle,
        roles: Py::new(py, roles(py, &found)?)?,
    })
}

/// `make_motion`'s keywords beyond the gait's: made tails, the skin, the path and the ground,
/// each read as it arrives (`None` as not given).
#[derive(Default)]
struct MotionKeywords {
    joint_tails: bool,
    skin_points: Vec<[f32; 3]>,
    skin_bones: Vec<i32>,
    path: Option<Vec<[f32; 3]>>,
    ground: Option<HeightField>,
}

/// A height field as `Terrain::field` takes it: origin (x, y), cell, (nx, ny) and the heights,
/// row by row.
type HeightField = ([f32; 2], f32, (usize, usize), Vec<f32>);

impl MotionKeywords {
    /// Take `key` if it is one of these; `Ok(false)` if not.
    fn read(&mut self, key: &str, value: &Bound<'_, PyAny>) -> PyResult<bool> {
        match key {
            "joint_tails" => self.joint_tails = keyword(value, key)?,
            "skin_points" => {
                self.skin_points = optional(value, key, |p: F32Rows| rows::<f32, 3>(&p, key))?.unwrap_or_default()
            }
            "skin_bones" => self.skin_bones = optional(value, key, |b: Indices| indices(&b, key))?.unwrap_or_default(),
            "path" => self.path = optional(value, key, |p: F32Rows| rows::<f32, 3>(&p, key))?,
            "ground" => {
                self.ground = optional(value, key, |((x, y), cell, heights): ((f32, f32), f32, F32Rows)| {
                    let view = heights.as_array();
                    let (ny, nx) = view.dim();
                    Ok(([x, y], cell, (nx, ny), view.iter().copied().collect::<Vec<f32>>()))
                })?
            }
            _ => return Ok(false),
        }
        Ok(true)
    }
}

/// Add this area's functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyLimb>()?;
    m.add_class::<PyRoles>()?;
    m.add_class::<PyMotionClip>()?;
    m.add_function(wrap_pyfunction!(detect_roles, m)?)?;
    m.add_function(wrap_pyfunction!(make_motion, m)?)?;
    Ok(())
}
