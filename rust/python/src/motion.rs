//! Bindings for motion: skeleton roles (`roles.rs`), procedural gaits (`gait.rs`) and where they
//! go (`course.rs`, `terrain.rs`).
#![allow(clippy::approx_constant)] // make_motion's amplitude=0.5236 rad (30 degrees) is a literal so Python's signature shows it

use crate::convert::{from_rows, indices, rows, Indices};
use crate::error::guarded;
use miniskeleton_core::motion::{detect_roles as core_detect, BodyPlan, Limb, Roles, Side};
use miniskeleton_core::motion::{steered_clip, Course, GaitParams, Motion, Skin, Steer, Terrain};
use numpy::ndarray::Array3;
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

type F32Rows<'py> = PyArrayLike2<'py, f32, AllowTypeChange>;

fn limbs<'py>(py: Python<'py>, limbs: &[Limb]) -> PyResult<Bound<'py, PyList>> {
    let out = PyList::empty(py);
    for l in limbs {
        let d = PyDict::new(py);
        d.set_item("bones", l.bones.clone())?;
        d.set_item("side", if l.side == Side::Left { "L" } else { "R" })?;
        d.set_item("group", l.group)?;
        out.append(d)?;
    }
    Ok(out)
}

fn roles_dict<'py>(py: Python<'py>, r: &Roles) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("root", r.root)?;
    d.set_item("spine", r.spine.clone())?;
    d.set_item("neck", r.neck.clone())?;
    d.set_item("head", r.head)?;
    d.set_item("head_extras", r.head_extras.clone())?;
    d.set_item("tail", r.tail.clone())?;
    d.set_item("legs", limbs(py, &r.legs)?)?;
    d.set_item("arms", limbs(py, &r.arms)?)?;
    let plan = match r.plan {
        BodyPlan::Biped => "biped",
        BodyPlan::Quadruped => "quadruped",
        BodyPlan::Multiped => "multiped",
        BodyPlan::Legless => "legless",
    };
    d.set_item("plan", plan)?;
    d.set_item("up", r.up)?;
    d.set_item("forward", r.forward)?;
    d.set_item("left", r.left)?;
    d.set_item("ground", r.ground)?;
    d.set_item("height", r.height)?;
    d.set_item("leg_length", r.leg_length)?;
    d.set_item("single_tree", r.single_tree)?;
    let riders: Vec<(usize, usize)> = r.riders.iter().map(|&[a, b]| (a, b)).collect();
    d.set_item("riders", riders)?;
    d.set_item("notes", r.notes.clone())?;
    Ok(d)
}

struct Skeleton {
    heads: Vec<[f32; 3]>,
    tails: Vec<[f32; 3]>,
    parents: Vec<i32>,
    names: Vec<String>,
}

fn skeleton(
    heads: &F32Rows<'_>,
    tails: &F32Rows<'_>,
    parents: &Indices<'_>,
    names: Option<Vec<String>>,
) -> PyResult<Skeleton> {
    Ok(Skeleton {
        heads: rows::<f32, 3>(heads, "bone_heads")?,
        tails: rows::<f32, 3>(tails, "bone_tails")?,
        parents: indices(parents, "parents")?,
        names: names.unwrap_or_default(),
    })
}

/// Roles of a skeleton's bones (+Z up): dict with root, spine, neck, head, head_extras, tail,
/// legs/arms ([{bones, side 'L'/'R', group}], group 0 = front), plan, up/forward/left,
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
) -> PyResult<Bound<'py, PyDict>> {
    let s = skeleton(&bone_heads, &bone_tails, &parents, names)?;
    let r = guarded(py, move || core_detect(&s.heads, &s.tails, &s.parents, &s.names))?;
    roles_dict(py, &r)
}

/// Motion for a skeleton: 'HEAD_SHAKE', 'WALK' or 'RUN'. rest_matrices (b,3,3) or (b,9):
/// each bone's rest orientation in the same space as heads/tails (columns = bone X, Y, Z).
/// Returns dict: rotations (frames, b, 4) float32 local quaternions (w, x, y, z),
/// root_offset (frames, 3) float32 in the input space, animated (k,) int32 bone indices,
/// locations (frames, b, 3) float32 local locations in input units (Blender's
/// `pose_bone.location` times the armature's scale; zero but for `located`), located (j,)
/// int32 (the roles' riders), moves_root, frames, frames_per_cycle, roles (as detect_roles).
/// joint_tails: the tails are an importer's invention; roles and motion read tails made from
/// the joints instead (`skeleton::joint_tails`). skin_points (p, 3) and skin_bones (p,) int32:
/// the character's skin at rest in the same space and the bone weighing most on each point (-1:
/// none); the feet stand on the ground its soles rest on (a body that does not stand level is
/// settled first) and arms hang clear of its body. Without them the bones alone are read.
/// path (p, 3): a polyline in the heads' space the walk or run follows (the clip covers its
/// length; `cycles` is read from it; an error with root_motion off). ground ((x, y), cell,
/// heights (ny, nx)): a height field, heights[j, i] at (x + i cell, y + j cell), NaN for a miss;
/// the feet stand on it, turned to its slope.
#[pyfunction]
#[pyo3(signature = (bone_heads, bone_tails, parents, rest_matrices, motion="WALK", *, names=None,
                    fps=24.0, cycles=2.0, duration=2.0, amplitude=0.5236, stride=1.0, speed=1.0,
                    root_motion=true, joint_tails=false, skin_points=None, skin_bones=None, path=None,
                    ground=None))]
#[allow(clippy::too_many_arguments)]
pub fn make_motion<'py>(
    py: Python<'py>,
    bone_heads: F32Rows<'py>,
    bone_tails: F32Rows<'py>,
    parents: Indices<'py>,
    rest_matrices: numpy::PyArrayLikeDyn<'py, f32, AllowTypeChange>,
    motion: &str,
    names: Option<Vec<String>>,
    fps: f32,
    cycles: f32,
    duration: f32,
    amplitude: f32,
    stride: f32,
    speed: f32,
    root_motion: bool,
    joint_tails: bool,
    skin_points: Option<F32Rows<'py>>,
    skin_bones: Option<Indices<'py>>,
    path: Option<F32Rows<'py>>,
    ground: Option<((f32, f32), f32, F32Rows<'py>)>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut s = skeleton(&bone_heads, &bone_tails, &parents, names)?;
    let skin_points = skin_points.as_ref().map(|p| rows::<f32, 3>(p, "skin_points")).transpose()?.unwrap_or_default();
    let skin_bones = skin_bones.as_ref().map(|b| indices::<i32>(b, "skin_bones")).transpose()?.unwrap_or_default();
    let motion = match motion.to_ascii_uppercase().as_str() {
        "HEAD_SHAKE" => Motion::HeadShake,
        "WALK" => Motion::Walk,
        "RUN" => Motion::Run,
        other => {
            return Err(PyValueError::new_err(format!("motion must be 'HEAD_SHAKE', 'WALK' or 'RUN', got {other:?}")))
        }
    };
    let view = rest_matrices.as_array();
    let flat: Vec<f32> = view.iter().copied().collect();
    if flat.len() != 9 * s.heads.len() || view.shape().first() != Some(&s.heads.len()) {
        return Err(PyValueError::new_err(format!(
            "rest_matrices must have shape ({n}, 3, 3) or ({n}, 9), got {:?}",
            view.shape(),
            n = s.heads.len()
        )));
    }
    let rest: Vec<[f32; 9]> = flat.chunks_exact(9).map(|c| c.try_into().unwrap()).collect();
    let params = GaitParams { motion, fps, cycles, duration, amplitude, stride, speed, root_motion };
    let path = path.as_ref().map(|p| rows::<f32, 3>(p, "path")).transpose()?;
    let ground = ground.map(|((x, y), cell, heights)| {
        let view = heights.as_array();
        let (ny, nx) = view.dim();
        ([x, y], cell, (nx, ny), view.iter().copied().collect::<Vec<f32>>())
    });
    let (roles, clip) = guarded(py, move || {
        if joint_tails {
            miniskeleton_core::skeleton::validate_parents(&s.parents, s.heads.len())?;
            s.tails = miniskeleton_core::skeleton::joint_tails(&s.heads, &s.tails, &s.parents);
        }
        let roles = core_detect(&s.heads, &s.tails, &s.parents, &s.names)?;
        let skin = Skin { points: &skin_points, bones: &skin_bones };
        let steer = Steer {
            course: path.as_deref().map(Course::new).transpose()?,
            terrain: match &ground {
                Some((origin, cell, size, heights)) => Terrain::field(*origin, *cell, *size, heights)?,
                None => Terrain::LEVEL,
            },
        };
        let clip = steered_clip(&s.heads, &s.tails, &s.parents, &rest, &roles, (&params, &steer), &skin)?;
        Ok((roles, clip))
    })?;
    let flat: Vec<f32> = clip.rotations.iter().flat_map(|q| q.iter().copied()).collect();
    let rot = Array3::from_shape_vec((clip.frames, clip.bone_count, 4), flat)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let d = PyDict::new(py);
    d.set_item("rotations", rot.into_pyarray(py))?;
    d.set_item("root_offset", from_rows(py, &clip.root_offset)?)?;
    let animated: Vec<i32> = clip.animated.iter().map(|&b| b as i32).collect();
    d.set_item("animated", PyArray1::from_vec(py, animated))?;
    let flat: Vec<f32> = clip.locations.iter().flat_map(|l| l.iter().copied()).collect();
    let loc = Array3::from_shape_vec((clip.frames, clip.bone_count, 3), flat)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    d.set_item("locations", loc.into_pyarray(py))?;
    let located: Vec<i32> = clip.located.iter().map(|&b| b as i32).collect();
    d.set_item("located", PyArray1::from_vec(py, located))?;
    d.set_item("moves_root", clip.moves_root)?;
    d.set_item("frames", clip.frames)?;
    d.set_item("frames_per_cycle", clip.frames_per_cycle)?;
    d.set_item("roles", roles_dict(py, &roles)?)?;
    Ok(d)
}

/// Add this area's functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(detect_roles, m)?)?;
    m.add_function(wrap_pyfunction!(make_motion, m)?)?;
    Ok(())
}
