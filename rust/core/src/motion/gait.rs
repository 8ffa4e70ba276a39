//! Procedural motion on a skeleton whose roles are known (`roles.rs`): a head shake, and walk
//! and run cycles for bipeds, quadrupeds and many-legged bodies. Produces per-frame local bone
//! rotations and a root offset that a caller turns into keyframes.
//!
//! Inputs
//!   skeleton      [`Skeleton`]: heads, tails #B by 3 rest bone end points, +Z up (world
//!                 space in the add-on); parents #B parent index, -1 for roots; names
//!   rest          #B rest orientations, row-major 3×3 whose columns are the bone's local
//!                 X, Y (along the bone), Z axes in the same space (Blender:
//!                 `armature.matrix_world.to_3x3() @ bone.matrix_local.to_3x3()`); scale is
//!                 normalised away
//!   roles         from [`crate::motion::roles::detect_roles`]
//!   params        [`GaitParams`]
//! Output
//!   [`Clip`]: `frames` × #B local rotations (w, x, y, z) in each bone's rest frame, i.e.
//!   Blender's `pose_bone.rotation_quaternion` (identity = rest), and `frames` root offsets in
//!   the input space (add to the root bone's head). Feet that hang off the root instead of
//!   their leg (`Roles::riders`) are posed as if on the leg, then given the local rotation and
//!   location (`pose_bone.location`, input units) that put them there in the real hierarchy.
//!
//! Method. Every rotation is "angle about a body axis" (up, forward or right = forward × up),
//! expressed in the bone's rest frame, so a chain rotated about one axis bends in one plane.
//! - Legs: planted by `footfalls` (each stance foot fixed in the world, the gait phase the
//!   distance travelled over the stride, two-bone IK from the posed hip, the body as high as
//!   every leg reaches; a body on four legs or more keeps it level, a far foot lifting early).
//!   A leg without two bones above a foot swings instead (per leg phase φ, duty factor d):
//!   the hip from +A to -A linearly during stance and back with a cosine in swing, the knee
//!   flexing by K sin(π s) in swing, the ankle keeping the foot level, each joint flexing the
//!   way that brings the limb's end closer to the joint above; A = asin(stride · d / 2L) for
//!   leg length L. An insect's rising femur lifts the leg in swing.
//! - Phases: biped L 0 / R ½; quadruped walk in diagonal pairs (front L 0, front R ½, back R
//!   0.15, back L 0.65: back legs offset); quadruped run as a rotary gallop (back L 0, back R
//!   0.1, front R 0.45, front L 0.55); more legs alternate by group (tripod-like).
//! - Cycle period from the leg length (pendulum scaling): walk 1.05 s · √(L / 0.9 m), run
//!   0.6 s · √(L / 0.9 m), the root clamped to [0.6, 1.6] (rigs not in metres), divided by
//!   `speed`; stride per cycle 1.3 L (biped walk), 1.1 L (quadruped walk), 1.7 L (biped run)
//!   or 1.8 L (gallop) times `stride`, a run's duty factor such that a foot is down at least
//!   75 % of the cycle.
//! - Body: spine yaw/roll sway (walk), pitch flexion (quadruped run) or twist and lean (biped
//!   run); neck/head bob at the step rate with the head steadied; tail sway with a lag; arms
//!   held out at rest hang clear of the body's skin (`skin`) and swing against the legs.
//! - Ground: every stance foot stands on the level ground of the lowest sole of the skin
//!   (`skin`), a body whose soles do not all rest on it settled first (`settle`), or on a
//!   terrain (`terrain`), turned to its slope, the body following the ground under the feet.
//! - Course ([`steered_clip`]): the gait is made along the straight line and mapped onto a path
//!   (`course`): the body carried rigidly at the distance of its legs' tops' centre (every tree
//!   turned about the main root's head), each foot at its own, so stance feet stay put through
//!   turns.
//! - Root: forward travel (optional) and the body's height from the planted legs' reach (with
//!   swinging legs only: the offset that keeps every foot at or above its own rest height and
//!   the lowest one on it); a tail carried below its rest height turns up at its base.
//! - Head shake: neck and head yaw A · env(u) · sin(2π c u) over the duration, with a smooth
//!   fade in and out (starts and ends at rest), the head taking half; ears and other head
//!   children swing after it with 35 % of the amplitude and a lag.
//!
//! Known limitations: the body stays upright on a slope; without a skin each foot keeps its own rest
//! height; rotations are about world-up-based axes, so a character lying down is animated as if
//! standing.

use crate::error::{Error, Result};
use crate::motion::clip::{frame_count, Cadence, Clip, GaitParams, Motion, Steer, MAX_FRAMES};
use crate::motion::course::{Course, Steering};
use crate::motion::footfalls::{planted_legs, stand_on, Ground, MAX_DROP};
use crate::motion::planting::{plant_legs, Planting};
use crate::motion::pose::{new_poser, posed_frames, rider_pose, to_wxyz, Poser};
use crate::motion::roles::{no_legs_message, BodyPlan, Limb, Roles, Side};
use crate::motion::settle::{settle, Settle};
use crate::motion::shake::head_shake;
use crate::motion::skin::{
    arm_radius, elbow_clearance, foot_extents, hang_angle, leg_soles, skin_reach, Body, Hanging, Skin,
};
use crate::skeleton::{validate_parents, Skeleton};
use glam::{Quat, Vec3};
use std::f32::consts::{PI, TAU};

/// +1 or -1: the rotation about `axis` of bone `b` that brings its tail closer to `pivot`.
fn flex_sign(heads: &[[f32; 3]], tails: &[[f32; 3]], b: usize, pivot: Vec3, axis: Vec3, default: f32) -> f32 {
    let (h, t) = (Vec3::from(heads[b]), Vec3::from(tails[b]));
    let d = (t - pivot).dot(axis.cross(t - h));
    let scale = (t - h).length() * (t - pivot).length();
    if d > 1e-3 * scale {
        -1.0
    } else if d < -1e-3 * scale {
        1.0
    } else {
        default
    }
}

/// The first bone of a limb that points mostly down (skips clavicles / pelvis bones).
fn swing_index(heads: &[[f32; 3]], tails: &[[f32; 3]], limb: &Limb) -> usize {
    limb.bones
        .iter()
        .position(|&b| {
            let d = Vec3::from(tails[b]) - Vec3::from(heads[b]);
            -d.z >= 0.5 * d.length()
        })
        .unwrap_or(0)
}

/// Phase offset of each leg (fraction of a cycle) for this body plan and gait.
fn leg_phases(roles: &Roles, motion: Motion) -> Vec<f32> {
    let front_groups = roles.legs.iter().map(|l| l.group).max().unwrap_or(0);
    roles
        .legs
        .iter()
        .map(|l| {
            let left = l.side == Side::Left;
            match (roles.plan, motion) {
                (BodyPlan::Biped, _) => {
                    if left {
                        0.0
                    } else {
                        0.5
                    }
                }
                (BodyPlan::Quadruped, Motion::Run) => match (l.group == 0, left) {
                    (false, true) => 0.0,
                    (false, false) => 0.1,
                    (true, false) => 0.45,
                    (true, true) => 0.55,
                },
                (BodyPlan::Quadruped, _) => match (l.group == 0, left) {
                    (true, true) => 0.0,
                    (true, false) => 0.5,
                    (false, false) => 0.15,
                    (false, true) => 0.65,
                },
                _ => {
                    let base = if l.group % 2 == 0 { 0.0 } else { 0.5 };
                    let drift = 0.05 * l.group as f32 / (front_groups.max(1)) as f32;
                    (base + if left { 0.0 } else { 0.5 } + drift).fract()
                }
            }
        })
        .collect()
}

fn check(skeleton: &Skeleton, rest: &[[f32; 9]], roles: &Roles, p: &GaitParams) -> Result<()> {
    let Skeleton { heads, tails, parents, .. } = *skeleton;
    let n = heads.len();
    if tails.len() != n || parents.len() != n || rest.len() != n {
        return Err(Error::Shape(format!(
            "{n} heads, {} tails, {} parents, {} rest matrices: one of each per bone",
            tails.len(),
            parents.len(),
            rest.len()
        )));
    }
    validate_parents(parents, n)?;
    let all = roles
        .spine
        .iter()
        .chain(&roles.neck)
        .chain(&roles.head_extras)
        .chain(&roles.tail)
        .chain(roles.legs.iter().flat_map(|l| &l.bones))
        .chain(roles.arms.iter().flat_map(|l| &l.bones))
        .chain([&roles.head, &roles.root]);
    if all.into_iter().any(|&b| b >= n) {
        return Err(Error::Shape("roles refer to bones that are not in the arrays".into()));
    }
    // A NaN rest frame would turn every key of its bone and of the bones below it into NaN.
    let bad = rest.iter().filter(|m| !m.iter().all(|x| x.is_finite())).count();
    if bad > 0 {
        return Err(Error::NonFinite { what: "rest matrix", count: bad });
    }
    if !(p.fps > 0.0 && p.fps.is_finite()) {
        return Err(Error::InvalidArgument(format!("fps must be positive, got {}", p.fps)));
    }
    if !(p.cycles > 0.0 && p.cycles.is_finite()) {
        return Err(Error::InvalidArgument(format!("cycles must be positive, got {}", p.cycles)));
    }
    if !(p.speed > 0.0 && p.speed.is_finite() && p.stride >= 0.0 && p.stride.is_finite()) {
        return Err(Error::InvalidArgument("speed must be positive and stride not negative".into()));
    }
    if p.motion == Motion::HeadShake && !(p.duration > 0.0 && p.duration.is_finite()) {
        return Err(Error::InvalidArgument(format!("duration must be positive, got {}", p.duration)));
    }
    // more shakes than Blender has frames mean nothing (and overflow the sine's phase)
    if p.motion == Motion::HeadShake && p.cycles > MAX_FRAMES as f32 {
        return Err(Error::InvalidArgument(format!(
            "cycles must be at most {MAX_FRAMES} for a head shake (Blender's last frame), got {}",
            p.cycles
        )));
    }
    if !p.amplitude.is_finite() {
        return Err(Error::InvalidArgument("amplitude must be finite".into()));
    }
    Ok(())
}

/// Make the motion (see the module doc), reading the character's `skin` for its soles and its
/// body's width beside the arms ([`Skin::NONE`]: the bones alone).
pub fn motion_clip(
    skeleton: &Skeleton,
    rest: &[[f32; 9]],
    roles: &Roles,
    params: &GaitParams,
    skin: &Skin,
) -> Result<Clip> {
    steered_clip(skeleton, rest, roles, (params, &Steer::default()), skin)
}

/// [`motion_clip`] steered (`steer`: along a course, over a terrain; see [`Steer`]). A course
/// without root motion (in place) or with a stride of 0 is an error.
pub fn steered_clip(
    skeleton: &Skeleton,
    rest: &[[f32; 9]],
    roles: &Roles,
    (params, steer): (&GaitParams, &Steer),
    skin: &Skin,
) -> Result<Clip> {
    check(skeleton, rest, roles, params)?;
    skin.check(skeleton.len())?;
    if steer.course.is_some() && params.motion != Motion::HeadShake {
        if !params.root_motion {
            return Err(Error::InvalidArgument(
                "a path needs the body to travel: in place walks on the spot, so leave In Place off with a path".into(),
            ));
        }
        if !(params.stride > 0.0) {
            return Err(Error::InvalidArgument("a path needs a stride above 0".into()));
        }
    }
    match params.motion {
        Motion::HeadShake => head_shake(skeleton, rest, roles, params),
        Motion::Walk | Motion::Run if roles.legs.is_empty() => Err(Error::NoBones(no_legs_message())),
        Motion::Walk | Motion::Run => gait(skeleton, rest, roles, params, steer, skin),
    }
}

/// A body on this many legs or more keeps its level, walking, and nearly so running
/// ([`LEVEL_RUN_DROP`]): whenever a far foot would pull it lower, other feet stand or the body
/// is in the air, so that foot lifts off a little early or lands a little late instead (a
/// horse's or a dog's back stays level as it walks, and highest in a gallop's flight). Sinking
/// the body for it bends every other leg's knee and folds the skin of the flank and rump with
/// the thighs (the gallop's gathered flight, hind legs forward under a body sunk for the front
/// feet just lifted behind). A biped's body sinks, up to [`MAX_DROP`]: at double support in a
/// walk, when both its feet are out (the low point of the inverted pendulum), and in a run's
/// stance, its legs giving.
const LEVEL_LEGS: usize = 4;
/// How far such a body sinks in a run, as a share of a leg's reach: enough for a far foot to
/// touch down and lift off on the ground (kept wholly level, a gallop's far feet hung just above
/// it, and the test creature's feet were down 72 % of the cycle, 75 wanted).
const LEVEL_RUN_DROP: f32 = 0.01;

/// The cadence follows a pendulum of the leg's length (assumed in metres; clamped so rigs in
/// other units, centimetres or a 60-unit cow, still get a plausible one); the stride a fixed
/// number of leg lengths.
fn cadence(roles: &Roles, p: &GaitParams, course: Option<&Course>) -> Result<Cadence> {
    let run = p.motion == Motion::Run;
    let quad = roles.plan == BodyPlan::Quadruped;
    let l = roles.leg_length.max(1e-6);
    let pendulum = (l / 0.9).sqrt().clamp(0.6, 1.6);
    let period = if run { 0.6 } else { 1.05 } * pendulum / p.speed;
    let fpc = (period * p.fps).round().max(8.0);
    // A run keeps a foot on the ground at least 75 % of the cycle: a gallop's four feet in
    // stance 0.3 of it each cover 0.8; two or six feet take turns, in stance 0.4 each. Its
    // stride is what the legs reach in that time with the body no lower than `MAX_DROP` (not
    // at all on four legs, `LEVEL_LEGS`: the far feet lift off early instead). A
    // quadruped's legs sweep less than a biped's (a horse's or a cow's thigh turns the skin of
    // its flank and chest with it).
    let duty = match (run, quad) {
        (false, true) => 0.65,
        (false, false) => 0.6,
        (true, true) => 0.3,
        (true, false) => 0.4,
    };
    let stride = match (run, quad) {
        (false, true) => 1.1,
        (false, false) => 1.3,
        (true, true) => 1.8,
        (true, false) => 1.7,
    } * l
        * p.stride;
    // along a course, as many cycles as cover it
    let cycles = course.map_or(p.cycles, |c| c.length() / stride.max(f32::MIN_POSITIVE));
    let frames = frame_count(cycles * fpc, 1.0)?;
    Ok(Cadence {
        fpc,
        frames,
        duty,
        stride,
        hip_amp: (stride * duty / (2.0 * l)).min(0.9).asin(),
        knee_amp: if run { 80f32 } else { 45.0 }.to_radians(),
        knee_stance: if run { 15f32 } else { 6.0 }.to_radians(),
        ankle_amp: if run { 30f32 } else { 20.0 }.to_radians(),
        lift_amp: if run { 35f32 } else { 25.0 }.to_radians(),
        foot_lift: if run { 0.15 } else { 0.08 } * l,
        drop: match (roles.legs.len() < LEVEL_LEGS, run) {
            (true, _) => MAX_DROP,
            (false, true) => LEVEL_RUN_DROP,
            (false, false) => 0.0,
        },
    })
}

/// A leg's swinging bone (hip), its knee and ankle as (bone, flex sign) if any, and the rising
/// bone before the hip that lifts the leg in swing, as (bone, sign of the turn about the forward
/// axis that raises its tail), if any.
struct LegJoints {
    hip: usize,
    knee: Option<(usize, f32)>,
    ankle: Option<(usize, f32)>,
    lift: Option<(usize, f32)>,
}

/// An arm as it hangs and swings: its upper arm and forearm, the turn that lowers the upper arm
/// from rest to hanging (`lower`, in the body's axes), the forearm's turn that then lines it up
/// with the upper arm (`straighten`, relative to the upper arm), the least bend of its elbow
/// (`bend`, radians: a long arm's hand kept off the ground), and its side.
struct ArmJoints {
    upper: usize,
    fore: Option<usize>,
    lower: Quat,
    straighten: Quat,
    bend: f32,
    side: Side,
}

/// The joints that bend in each leg, from its first bone pointing down; flex signs about `right`.
/// An insect's or a spider's leg rises from the body (femur) before it turns down (tibia): the
/// tibia swings, and it has no knee below it to fold, so the femur lifts the leg in swing
/// instead, turning about `fwd`.
fn leg_joints(heads: &[[f32; 3]], tails: &[[f32; 3]], roles: &Roles, (fwd, right): (Vec3, Vec3)) -> Vec<LegJoints> {
    let hv = |b: usize| Vec3::from(heads[b]);
    roles
        .legs
        .iter()
        .map(|limb| {
            let i0 = swing_index(heads, tails, limb);
            let bones = &limb.bones[i0..];
            let knee = bones.get(1).map(|&b| (b, flex_sign(heads, tails, b, hv(bones[0]), right, -1.0)));
            let ankle = bones.get(2).map(|&b| (b, flex_sign(heads, tails, b, hv(bones[1]), right, 1.0)));
            let lift = i0.checked_sub(1).map(|i| limb.bones[i]).and_then(|b| {
                let d = Vec3::from(tails[b]) - hv(b);
                let raise = fwd.cross(d).z;
                (d.z > RISING * d.length() && raise.abs() > RISING * d.length()).then_some((b, raise.signum()))
            });
            LegJoints { hip: bones[0], knee, ankle, lift }
        })
        .collect()
}

/// A bone before a leg's swinging bone lifts the leg when its tail is this much (a fraction of
/// its length) above its head and it points this much sideways (a femur rising out of an
/// insect's body; not a pelvis or a shoulder blade, which slope down or lie along the body).
const RISING: f32 = 0.2;

/// How each arm hangs: its upper arm is the longer of its first two bones, each measured to the
/// next bone's head (an imported rig's tails are stubs of one length, so the clavicle-or-upper-
/// arm choice went by rounding, and by scale), summed over the arms so that both sides choose
/// alike; the elbow the next. The arm is lowered from its
/// rest pose (a T- or A-pose) to hang from the shoulder, at the least angle from straight down
/// that keeps it, as thick as its skin and its forearm bent as the gait bends it, clear of the
/// body (`skin::hang_angle`);
/// an arm whose hand would then come lower than [`HAND_LIFT`] above the `ground` (its bones, or
/// the skin of the forearm and below: fingers, a prop held) bends its elbow forward until it
/// does not (`skin::elbow_clearance`).
fn arm_joints(
    (heads, tails, parents): (&[[f32; 3]], &[[f32; 3]], &[i32]),
    roles: &Roles,
    (skin, ground): (&Skin, f32),
    (up, fwd, right): (Vec3, Vec3, Vec3),
    run: bool,
) -> Vec<ArmJoints> {
    let hv = |b: usize| Vec3::from(heads[b]);
    // the arms' chains are read alike: a pair posed apart (a round body's one long clavicle)
    // takes the upper arm its two sides give together
    let span = |a: &Limb, k: usize| (hv(a.bones[k + 1]) - hv(a.bones[k])).length();
    let long = roles.arms.iter().filter(|a| a.bones.len() >= 3);
    let (first, second) = long.fold((0.0, 0.0), |(f, s), a| (f + span(a, 0), s + span(a, 1)));
    let upper_of = |a: &Limb| usize::from(a.bones.len() >= 3 && first < second);
    let body = Body::of(skin, roles, heads, tails);
    let shoulders: Vec<Vec3> = roles.arms.iter().map(|a| hv(a.bones[upper_of(a)])).collect();
    let mid = match shoulders.len() {
        0 | 1 => hv(roles.root),
        k => shoulders.iter().copied().sum::<Vec3>() / k as f32,
    };
    let left = up.cross(fwd).normalize_or(-right);
    roles
        .arms
        .iter()
        .map(|a| {
            let i0 = upper_of(a);
            let (upper, fore) = (a.bones[i0], a.bones.get(i0 + 1).copied());
            let shoulder = hv(upper);
            let elbow = fore.map_or(Vec3::from(tails[upper]), hv);
            let wrist = match (fore, a.bones.get(i0 + 2)) {
                (_, Some(&hand)) => hv(hand),
                (Some(f), None) => Vec3::from(tails[f]),
                (None, None) => elbow,
            };
            let chain = &a.bones[i0..];
            let reach = chain
                .iter()
                .flat_map(|&b| [hv(b), Vec3::from(tails[b])])
                .map(|p| (p - shoulder).length())
                .fold(0.0, f32::max);
            let tip = chain.last().map_or(wrist, |&b| Vec3::from(tails[b]));
            let mut owners = vec![false; heads.len()];
            for &b in &a.bones[i0 + 1..] {
                owners[b] = true;
            }
            let radius = arm_radius(skin, &owners, &[shoulder, elbow, wrist, tip]).min(0.1 * roles.height);
            let out = if a.side == Side::Left { left } else { -left };
            let fore_reach = chain.iter().skip(1).flat_map(|&b| [hv(b), Vec3::from(tails[b])]);
            let fore_reach = fore_reach.map(|p| (p - elbow).length()).fold(0.0, f32::max);
            let fore_reach = fore_reach.max(skin_reach(skin, &a.bones[i0 + 1..], parents, elbow));
            let lowest = ground + HAND_LIFT * roles.height + radius;
            let arm_lengths = ((elbow - shoulder).length(), fore_reach);
            let bend_at = |angle: f32| fore.map_or(0.0, |_| elbow_clearance(shoulder.z, angle, arm_lengths, lowest));
            let reach = reach.max(arm_lengths.0 + fore_reach);
            let hanging = Hanging { shoulder, upper: arm_lengths.0, reach, radius, out };
            let slab_margin = (HANG_SLAB * roles.height, HANG_MARGIN * roles.height);
            let flexed = |angle: f32| fore.map_or(0.0, |_| bend_at(angle).max(elbow_flex(run)));
            let angle = hang_angle(&body, &hanging, mid, (up, fwd), slab_margin, &flexed);
            let hang = -up * angle.cos() + out * angle.sin();
            let lower = Quat::from_rotation_arc((elbow - shoulder).normalize_or(hang), hang);
            let straighten = fore.map_or(Quat::IDENTITY, |_| {
                let along = lower * (wrist - elbow).normalize_or(elbow - shoulder);
                lower.inverse() * Quat::from_rotation_arc(along.normalize_or(hang), hang) * lower
            });
            let bend = bend_at(angle);
            ArmJoints { upper, fore, lower, straighten, bend, side: a.side }
        })
        .collect()
}

/// A hanging arm is tested against the body's skin within this share of the height above and
/// below each point along it, and kept this share of the height clear of it (`skin::hang_angle`);
/// its hand's skin no lower than this share of the height above the ground (a long-armed
/// character's fingers would drag).
const HANG_SLAB: f32 = 0.03;
const HANG_MARGIN: f32 = 0.01;
const HAND_LIFT: f32 = 0.06;

/// Pose the legs at cycle fraction `phi`: stance (hip sweeps back, knee barely bends) then
/// swing (hip forward, knee and ankle lift), the ankle keeping the foot level. Returns the
/// hip angles of the left and right legs, for the arms.
fn pose_legs(
    poser: &mut Poser,
    roles: &Roles,
    legs: &[LegJoints],
    phases: &[f32],
    c: &Cadence,
    phi: f32,
    (fwd, right): (Vec3, Vec3),
) -> (f32, f32) {
    let (mut left_hip, mut right_hip) = (0.0, 0.0);
    for (leg, (joints, &offset)) in roles.legs.iter().zip(legs.iter().zip(phases)) {
        let ph = (phi + offset).fract();
        let (theta, knee, ankle, lift) = if ph < c.duty {
            let s = ph / c.duty;
            (c.hip_amp * (1.0 - 2.0 * s), c.knee_stance * (PI * s).sin(), 0.0, 0.0)
        } else {
            let s = (ph - c.duty) / (1.0 - c.duty);
            let up = (PI * s).sin();
            (-c.hip_amp * (PI * s).cos(), c.knee_amp * up, c.ankle_amp * up, c.lift_amp * up)
        };
        if leg.side == Side::Left {
            left_hip = theta
        } else {
            right_hip = theta
        }
        if let Some((b, sign)) = joints.lift {
            poser.rotate(b, fwd, sign * lift);
        }
        poser.rotate(joints.hip, right, theta);
        let mut bend = theta;
        if let Some((b, sign)) = joints.knee {
            poser.rotate(b, right, sign * knee);
            bend += sign * knee;
        }
        if let Some((b, sign)) = joints.ankle {
            poser.rotate(b, right, -bend + sign * ankle);
        }
    }
    (left_hip, right_hip)
}

/// The elbow's bend forward (radians) at the middle of an arm's swing: a little walking, about
/// a right angle running.
fn elbow_flex(run: bool) -> f32 {
    if run { 75f32 } else { 12.0 }.to_radians()
}

/// Arms hang (`ArmJoints::lower`) and swing about the right axis against the leg of their side
/// (`hips`: the left and right legs' swing angles), the elbow bent forward: a little walking,
/// about a right angle running, and at least as far as keeps a long arm's hand off the ground,
/// the upper arm swung back included (the forearm then keeps its angle forward of hanging).
fn pose_arms(poser: &mut Poser, arms: &[ArmJoints], (left_hip, right_hip): (f32, f32), run: bool, right: Vec3) {
    for arm in arms {
        let leg = if arm.side == Side::Left { left_hip } else { right_hip };
        let swing = -if run { 0.8 } else { 0.6 } * leg;
        let upper = Quat::from_axis_angle(right, swing) * arm.lower;
        poser.turn(arm.upper, upper);
        if let Some(fore) = arm.fore {
            let flex = elbow_flex(run) + 0.3 * leg.abs();
            let flex = flex.max(arm.bend - swing.min(0.0));
            poser.turn(fore, arm.lower.inverse() * Quat::from_axis_angle(right, flex) * arm.lower * arm.straighten);
        }
    }
}

/// The body at cycle angle `w`: the `sway` spine bones yaw, roll and pitch (by gait and body
/// plan), the neck bobs, the head steadies, the tail swings.
fn pose_body(
    poser: &mut Poser,
    roles: &Roles,
    sway: &[usize],
    w: f32,
    run: bool,
    (up, fwd, right): (Vec3, Vec3, Vec3),
) {
    let quad = roles.plan == BodyPlan::Quadruped;
    let biped = roles.plan == BodyPlan::Biped;
    let per = |total: f32, count: usize| if count == 0 { 0.0 } else { total / count as f32 };
    let (yaw, roll, pitch) = match (run, quad, biped) {
        (false, _, true) => (5f32.to_radians() * w.sin(), 3f32.to_radians() * w.sin(), 0.0),
        (false, _, _) => (4f32.to_radians() * w.sin(), 2f32.to_radians() * w.sin(), 0.0),
        (true, true, _) => (0.0, 0.0, 8f32.to_radians() * w.sin()),
        (true, _, true) => (8f32.to_radians() * w.sin(), 0.0, -8f32.to_radians()),
        (true, _, _) => (3f32.to_radians() * w.sin(), 0.0, 4f32.to_radians() * w.sin()),
    };
    for &b in sway {
        poser.rotate(b, up, per(yaw, sway.len()));
        poser.rotate(b, fwd, per(roll, sway.len()));
        poser.rotate(b, right, per(pitch, sway.len()));
    }
    let bob = if run && quad {
        -10f32.to_radians() * (w + 0.5 * PI).sin()
    } else {
        (if run { 5f32 } else { 3.0 }).to_radians() * (2.0 * w).sin()
    };
    for &b in &roles.neck {
        poser.rotate(b, right, per(bob, roles.neck.len()));
        poser.rotate(b, up, per(-0.6 * yaw, roles.neck.len()));
    }
    poser.rotate(roles.head, right, -0.5 * bob - if run && biped { -0.5 * pitch } else { 0.0 });
    let nt = roles.tail.len().max(1) as f32;
    for (j, &b) in roles.tail.iter().enumerate() {
        let a = (if run { 12f32 } else { 10.0 }).to_radians() * (0.5 + 0.5 * j as f32 / nt) / nt * 3.0;
        let s = (w - 0.6 * (j + 1) as f32).sin();
        if run {
            // up and back to rest, never down: a low tail swung down went through the ground
            // (the Fox's tail tip 3.9 units below it, 5 % of its height)
            poser.rotate(b, right, -a * 0.5 * (1.0 + s))
        } else {
            poser.rotate(b, up, a * s)
        }
    }
}

/// A walk or run cycle (see the module doc): legs, arms and body posed frame by frame, the
/// body settled onto one ground and lifted so that no foot goes below it, feet riding on the
/// root carried by their legs.
fn gait(
    skeleton: &Skeleton,
    rest: &[[f32; 9]],
    roles: &Roles,
    p: &GaitParams,
    steer: &Steer,
    skin: &Skin,
) -> Result<Clip> {
    let Skeleton { heads, tails, parents, .. } = *skeleton;
    let n = heads.len();
    let run = p.motion == Motion::Run;
    let up = Vec3::from(roles.up);
    let fwd = Vec3::from(roles.forward);
    let right = fwd.cross(up).normalize();
    let hv = |b: usize| Vec3::from(heads[b]);
    let c = cadence(roles, p, steer.course.as_ref())?;
    let phases = leg_phases(roles, p.motion);
    let legs = leg_joints(heads, tails, roles, (fwd, right));
    // spine bones that sway: all but the root when there are others
    let sway: Vec<usize> = if roles.spine.len() > 1 {
        roles.spine.iter().copied().filter(|&b| b != roles.root).collect()
    } else {
        roles.spine.clone()
    };

    // Legs planted by IK (see `footfalls`); all or none, so the body's height has one rule.
    let swing_at: Vec<usize> = roles.legs.iter().map(|l| swing_index(heads, tails, l)).collect();
    let knee_signs: Vec<f32> = legs.iter().map(|j| j.knee.map_or(-1.0, |k| k.1)).collect();
    let planted = planted_legs(heads, tails, roles, &swing_at, &knee_signs, right);
    let planted: Option<Vec<_>> = planted.into_iter().collect();
    let mut planted = planted.filter(|legs| !legs.is_empty());
    // The ground is the lowest sole; a body whose soles rest above it is settled onto it.
    let soles = leg_soles(skin, roles, parents);
    let ground = soles.iter().flatten().copied().reduce(f32::min);
    let settled = match (&planted, ground) {
        (Some(plant), Some(ground)) => {
            let hips: Vec<Vec3> = plant.iter().map(|l| l.hip).collect();
            let gaps: Vec<f32> = soles.iter().map(|s| s.map_or(0.0, |s| s - ground)).collect();
            settle(&hips, &gaps, (fwd, up.cross(fwd)), roles.height)
        }
        _ => Settle::NONE,
    };
    let ground = ground.unwrap_or(roles.ground);
    if let Some(plant) = &mut planted {
        let ankles: Vec<Vec3> = plant.iter().map(|l| l.ankle).collect();
        let extents = foot_extents(skin, roles, parents, &soles, (&ankles, fwd));
        stand_on(plant, &roles.legs, &soles, &extents, (ground, fwd), &settled);
    }
    let arms = arm_joints((heads, tails, parents), roles, (skin, ground), (up, fwd, right), run);
    // The settle turns every tree the roles lie in about its root: the main root through the
    // root offset, the others (a rig of several trees) through their location.
    let mut tree_roots: Vec<usize> = Vec::new();
    if !settled.is_none() || steer.course.is_some() {
        let real_root = |mut b: usize| {
            while parents[b] >= 0 {
                b = parents[b] as usize;
            }
            b
        };
        let role_bones = roles.spine.iter().chain(&roles.neck).chain(&roles.tail).chain([&roles.head]);
        for b in
            role_bones.chain(roles.legs.iter().flat_map(|l| &l.bones)).chain(roles.arms.iter().flat_map(|a| &a.bones))
        {
            let r = real_root(*b);
            if !tree_roots.contains(&r) {
                tree_roots.push(r);
            }
        }
    }
    let settle_shift = |b: usize| settled.apply(hv(b)) - hv(b);
    let root_settle = settle_shift(roles.root);
    let tail_reach = roles.tail.first().map_or(0.0, |&base| {
        roles.tail.iter().map(|&b| (Vec3::from(tails[b]) - hv(base)).length()).fold(0.0, f32::max)
    });
    let tail_low = roles.tail.iter().map(|&b| heads[b][2].min(tails[b][2])).fold(f32::INFINITY, f32::min);

    let mut poser = new_poser(rest);
    let mut rotations = Vec::with_capacity(c.frames * n);
    let mut locations = vec![[0.0; 3]; c.frames * n];
    let mut root_offset = Vec::with_capacity(c.frames);
    // forward kinematics with the feet that ride on the root carried by their legs
    let mut carried = parents.to_vec();
    for &[r, e] in &roles.riders {
        carried[r] = e as i32;
    }
    // the other trees' roots, moved with the main one's by the settle
    let mut settle_at = vec![[0.0f32; 3]; n];
    let mut located: Vec<usize> = roles.riders.iter().map(|&[r, _]| r).collect();
    let others: Vec<usize> = tree_roots.iter().copied().filter(|&r| r != roles.root).collect();
    for &r in &others {
        settle_at[r] = (poser.rest[r].inverse() * (settle_shift(r) - root_settle)).to_array();
        located.push(r);
    }
    // The course carries the body at its distance (`course.rs`), turning every tree about the
    // main root's head; the ground under the feet is the terrain's (`terrain.rs`).
    let steering = Steering { course: steer.course.as_ref(), origin: hv(roles.root), fwd };
    let ground_at = Ground { terrain: &steer.terrain, level: ground, steering };
    let mut turned_at = settle_at.clone();
    // the body is carried at the distance of its legs' tops' centre (a quadruped's between its
    // shoulders and hips), which stays on the path
    let centre_ahead = roles.legs.iter().map(|l| (hv(l.bones[0]) - hv(roles.root)).dot(fwd)).sum::<f32>()
        / roles.legs.len().max(1) as f32;
    // Each foot's lowest point; without planted legs the body rises or sinks so that no foot
    // goes below its own rest height and the lowest one stays on it (feet need not end at one
    // height: the Fox's front leg bones end at the wrist, 6 units above its hind feet's).
    let feet: Vec<usize> = roles.legs.iter().map(|l| *l.bones.last().unwrap()).collect();
    let rest_low: Vec<f32> = feet.iter().map(|&b| heads[b][2].min(tails[b][2])).collect();
    for k in 0..c.frames {
        poser.q.fill(Quat::IDENTITY);
        let phi = k as f32 / c.fpc;
        let hips = pose_legs(&mut poser, roles, &legs, &phases, &c, phi, (fwd, right));
        pose_arms(&mut poser, &arms, hips, run, right);
        pose_body(&mut poser, roles, &sway, TAU * phi, run, (up, fwd, right));
        let travel = if p.root_motion { c.stride * phi } else { 0.0 };
        let body_at = travel + centre_ahead;
        let heading = steering.turn(body_at);
        if steer.course.is_some() {
            for &r in &others {
                let at = hv(roles.root) + heading * (settled.apply(hv(r)) - settled.apply(hv(roles.root))) - hv(r);
                turned_at[r] = (poser.rest[r].inverse() * at).to_array();
            }
        }
        let frame_at = &turned_at;
        // the straight-line root offset carried to the world at the body's distance
        let carry = |straight: Vec3| steering.carry(hv(roles.root) + straight, body_at) - hv(roles.root);
        let offset = match &planted {
            Some(plant) => {
                for limb in &roles.legs {
                    for &b in &limb.bones {
                        poser.q[b] = Quat::IDENTITY;
                    }
                }
                for &r in &tree_roots {
                    poser.pre_turn(r, heading * settled.turn);
                }
                let ctx = Planting { heads, carried: &carried, locations: frame_at, fwd, ground: &ground_at };
                let offset =
                    plant_legs(&mut poser, &ctx, plant, &phases, &c, phi, (carry(fwd * travel + root_settle), travel));
                // A tail that the body's dip and the spine's flexion carry below its own rest
                // height (a hanging tail nearly touches the ground) turns up at its base by the
                // angle that lifts it back.
                if let (Some(&base), true) = (roles.tail.first(), tail_reach > 0.0) {
                    let local: Vec<[f32; 4]> = poser.q.iter().map(|&q| to_wxyz(q)).collect();
                    let (turns, posed) =
                        posed_frames(heads, &carried, &poser.rest, &local, frame_at, offset.to_array());
                    let low = roles
                        .tail
                        .iter()
                        .map(|&b| (posed[b] + turns[b] * (Vec3::from(tails[b]) - hv(b))).z.min(posed[b].z))
                        .fold(f32::INFINITY, f32::min);
                    let tail_low = tail_low + steer.terrain.height(hv(roles.root) + offset, ground) - ground;
                    if low < tail_low {
                        poser.rotate(base, right, -((tail_low - low) / tail_reach).min(1.0).asin());
                    }
                }
                offset
            }
            None => {
                let local: Vec<[f32; 4]> = poser.q.iter().map(|&q| to_wxyz(q)).collect();
                let on_legs = posed_frames(heads, &carried, &poser.rest, &local, &[], [0.0; 3]);
                let posed_low = |b: usize| {
                    let tail = on_legs.1[b] + on_legs.0[b] * (Vec3::from(tails[b]) - hv(b));
                    on_legs.1[b].z.min(tail.z)
                };
                let lift =
                    feet.iter().zip(&rest_low).map(|(&b, &r)| r - posed_low(b)).fold(f32::NEG_INFINITY, f32::max);
                for &r in &tree_roots {
                    poser.pre_turn(r, heading);
                }
                let at = carry(fwd * travel);
                at + up * (lift + steer.terrain.height(hv(roles.root) + at, ground) - ground)
            }
        };
        root_offset.push(offset.to_array());
        let mut local: Vec<[f32; 4]> = poser.q.iter().map(|&q| to_wxyz(q)).collect();
        let frame_locations = &mut locations[k * n..(k + 1) * n];
        frame_locations.copy_from_slice(frame_at);
        if !roles.riders.is_empty() {
            let on_legs = posed_frames(heads, &carried, &poser.rest, &local, frame_at, [0.0; 3]);
            let real = posed_frames(heads, parents, &poser.rest, &local, frame_at, [0.0; 3]);
            for &[r, _] in &roles.riders {
                let (q, loc) = rider_pose(r, heads, parents, &poser.rest, (&on_legs.0, &on_legs.1), (&real.0, &real.1));
                local[r] = to_wxyz(q);
                frame_locations[r] = loc.to_array();
            }
        }
        rotations.extend(local);
    }
    let mut animated: Vec<usize> = (0..n).filter(|&b| poser.touched[b]).collect();
    located.sort_unstable();
    located.dedup();
    animated.extend(&located);
    animated.sort_unstable();
    animated.dedup();
    Ok(Clip {
        frames: c.frames,
        bone_count: n,
        rotations,
        root_offset,
        animated,
        locations,
        located,
        moves_root: true,
        frames_per_cycle: c.fpc,
    })
}

/// The motion tests' rigs (`tests/common/rigs.rs`), for the unit tests of private helpers below.
#[cfg(test)]
#[path = "../../tests/common/rigs.rs"]
#[allow(dead_code)]
mod test_rigs;

/// Private helpers only: the clips are tested through the public API in `tests/gait.rs`.
#[cfg(test)]
mod tests {
    use super::test_rigs::{biped, creature, hexapod, ik_biped, rest_of, spot, Rig};
    use super::*;
    use crate::motion::detect_roles;
    use crate::motion::pose::rest_quats;

    /// A test rig with its rest matrices and roles: names, heads, tails, parents, rest, roles.
    type Prepared = (Vec<String>, Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<i32>, Vec<[f32; 9]>, Roles);

    fn prepare((names, h, t, p): Rig) -> Prepared {
        let rest = rest_of(&h, &t);
        let roles = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
        (names, h, t, p, rest, roles)
    }

    #[test]
    fn only_an_insects_rising_femurs_lift_its_legs() {
        let lifting = |skel: Rig| {
            let (_, h, t, _, _, roles) = prepare(skel);
            let (fwd, up) = (Vec3::from(roles.forward), Vec3::from(roles.up));
            leg_joints(&h, &t, &roles, (fwd, fwd.cross(up).normalize())).iter().filter(|l| l.lift.is_some()).count()
        };
        assert_eq!(lifting(hexapod()), 6);
        for skel in [creature(), spot(), biped(), ik_biped(false), ik_biped(true)] {
            assert_eq!(lifting(skel), 0, "a pelvis, a shoulder or a thigh lifts no leg");
        }
    }

    #[test]
    fn a_rider_on_a_turning_root_is_put_where_its_leg_carries_it() {
        // rider_pose's contract with the root turned too (the gait keeps a rig's ground root
        // still, so the walk tests never turn it)
        let (names, h, _, p, rest, roles) = prepare(ik_biped(false));
        let rq = rest_quats(&rest);
        let mut carried = p.clone();
        for &[r, e] in &roles.riders {
            carried[r] = e as i32;
        }
        let mut local: Vec<[f32; 4]> = (0..h.len())
            .map(|b| to_wxyz(Quat::from_axis_angle(Vec3::new(0.3, -0.5, 0.8).normalize(), 0.1 + 0.05 * b as f32)))
            .collect();
        let on_legs = posed_frames(&h, &carried, &rq, &local, &[], [0.0; 3]);
        let real = posed_frames(&h, &p, &rq, &local, &[], [0.0; 3]);
        let mut locations = vec![[0.0; 3]; h.len()];
        for &[r, _] in &roles.riders {
            let (q, loc) = rider_pose(r, &h, &p, &rq, (&on_legs.0, &on_legs.1), (&real.0, &real.1));
            local[r] = to_wxyz(q);
            locations[r] = loc.to_array();
        }
        let (d, ph) = posed_frames(&h, &p, &rq, &local, &locations, [0.0; 3]);
        assert!(!roles.riders.is_empty());
        for &[r, _] in &roles.riders {
            assert!(d[r].dot(on_legs.0[r]).abs() > 1.0 - 1e-5, "{}", names[r]);
            assert!((ph[r] - on_legs.1[r]).length() < 1e-5, "{}", names[r]);
        }
    }
}
