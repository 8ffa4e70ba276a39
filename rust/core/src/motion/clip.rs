//! What a motion is asked for and what it gives: the kind of motion and its parameters
//! ([`GaitParams`]), where a walk goes ([`Steer`]), the clip of per-frame local rotations,
//! locations and root offsets ([`Clip`]), and the timing the gait and the head shake share
//! (frame counts) or the gait and planting (a walk's cadence).

use crate::error::{Error, Result};
use crate::motion::course::Course;
use crate::motion::terrain::Terrain;

/// Which motion to make.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Motion {
    HeadShake,
    Walk,
    Run,
}

/// Motion parameters. Angles in radians, times in seconds.
#[derive(Debug, Clone, Copy)]
pub struct GaitParams {
    pub motion: Motion,
    /// Frames per second of the scene.
    pub fps: f32,
    /// Gait cycles (WALK/RUN, rounded to whole frames) or shakes (HEAD_SHAKE).
    pub cycles: f32,
    /// HEAD_SHAKE length in seconds.
    pub duration: f32,
    /// HEAD_SHAKE yaw amplitude (radians, neck and head together).
    pub amplitude: f32,
    /// Stride multiplier (1 = the natural stride for the leg length).
    pub stride: f32,
    /// Cadence multiplier (1 = the natural cadence for the leg length).
    pub speed: f32,
    /// Move the root forward (else the character walks on the spot).
    pub root_motion: bool,
}

impl Default for GaitParams {
    fn default() -> Self {
        GaitParams {
            motion: Motion::Walk,
            fps: 24.0,
            cycles: 2.0,
            duration: 2.0,
            amplitude: 30f32.to_radians(),
            stride: 1.0,
            speed: 1.0,
            root_motion: true,
        }
    }
}

/// Where a walk or run goes: along a course (`course.rs`; None: straight on along forward) and
/// over a terrain (`terrain.rs`; level: the ground the feet rest on). With a course the clip
/// covers its length (`cycles` is read from it) and needs root motion.
#[derive(Debug, Clone, Default)]
pub struct Steer {
    pub course: Option<Course>,
    pub terrain: Terrain,
}

/// Generated motion: `frames` frames, frame 0 first.
#[derive(Debug, Clone)]
pub struct Clip {
    pub frames: usize,
    pub bone_count: usize,
    /// frames × bone_count local rotations (w, x, y, z); identity for bones not animated.
    pub rotations: Vec<[f32; 4]>,
    /// Root offset per frame in the input space (forward travel and vertical bob).
    pub root_offset: Vec<[f32; 3]>,
    /// Bones whose rotation this motion sets (sorted).
    pub animated: Vec<usize>,
    /// frames × bone_count local locations (Blender's `pose_bone.location` times the input's
    /// scale); zero except for `located` bones.
    pub locations: Vec<[f32; 3]>,
    /// Bones whose location this motion sets: the feet riding on the root (`Roles::riders`).
    pub located: Vec<usize>,
    /// Whether `root_offset` is used (false for the head shake).
    pub moves_root: bool,
    /// Frames per gait cycle (HEAD_SHAKE: frames per shake).
    pub frames_per_cycle: f32,
}

impl Clip {
    pub fn rotation(&self, frame: usize, bone: usize) -> [f32; 4] {
        self.rotations[frame * self.bone_count + bone]
    }
}

/// Most frames in a clip: Blender's last frame (`MAXFRAME`), so any clip fits a scene.
pub const MAX_FRAMES: usize = 1_048_574;

/// `count` frames (rounded, at least `min`) plus the closing frame; an error past [`MAX_FRAMES`]
/// (a huge fps, duration or cycles, or a tiny speed), before anything is allocated.
pub(super) fn frame_count(count: f32, min: f32) -> Result<usize> {
    let c = count.round().max(min);
    if !(c < MAX_FRAMES as f32) {
        return Err(Error::InvalidArgument(format!(
            "the clip would have {c} frames; at most {MAX_FRAMES} (Blender's last frame): lower the fps, duration or cycles, or raise the speed"
        )));
    }
    Ok(c as usize + 1)
}

/// Timing and amplitudes of a walk or run.
pub(super) struct Cadence {
    /// Frames per cycle, and in the clip.
    pub(super) fpc: f32,
    pub(super) frames: usize,
    /// Share of a cycle a foot is on the ground.
    pub(super) duty: f32,
    /// Ground covered per cycle, in the skeleton's units.
    pub(super) stride: f32,
    pub(super) hip_amp: f32,
    pub(super) knee_amp: f32,
    pub(super) knee_stance: f32,
    pub(super) ankle_amp: f32,
    /// A rising femur's lift in swing (`LegJoints::lift`).
    pub(super) lift_amp: f32,
    /// How high a planted leg's ankle rises in swing, in the skeleton's units.
    pub(super) foot_lift: f32,
    /// The share of a leg's reach the body may sink so that a far foot reaches its target.
    pub(super) drop: f32,
}
