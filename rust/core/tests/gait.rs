//! Head shake, walk and run clips (`motion::motion_clip`) on the test rigs, checked through
//! forward kinematics (`motion::posed_points`): feet lift and stay above the ground, legs step
//! in their gait's order, arms swing against the legs, the head steadies, clips loop, bad
//! parameters are errors.

mod common;

use common::rigs::{
    biped, bone, bone_skin, creature, hexapod, ik_biped, ik_quadruped, rest_of, spot, t_pose_biped, Rig,
};
use glam::{Mat3, Quat, Vec3};
use miniskeleton_core::motion::{
    detect_roles, motion_clip, posed_points, BodyPlan, Clip, GaitParams, Motion, Roles, Side, Skeleton, Skin,
};

/// A test rig run through a motion: names, heads, tails, parents, rest matrices, roles, clip.
type Animated = (Vec<String>, Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<i32>, Vec<[f32; 9]>, Roles, Clip);

/// A clip's rotation (w, x, y, z) as a quaternion.
fn q(r: [f32; 4]) -> Quat {
    Quat::from_xyzw(r[1], r[2], r[3], r[0])
}

fn to_wxyz(q: Quat) -> [f32; 4] {
    [q.w, q.x, q.y, q.z]
}

/// A rest matrix of [`rest_of`] (row-major, orthonormal) as a rotation.
fn rest_quat(m: &[f32; 9]) -> Quat {
    Quat::from_mat3(&Mat3::from_cols_array(m).transpose()).normalize()
}

/// Each bone's rotation from rest to posed in the input space, for local rotations `local`
/// (w, x, y, z) in the bones' rest frames: its parent's, then its own turn about its rest
/// axes (Blender's pose maths, as `posed_points` applies it).
fn world_rotations(parents: &[i32], rest: &[[f32; 9]], local: &[[f32; 4]]) -> Vec<Quat> {
    let mut world: Vec<Option<Quat>> = vec![None; parents.len()];
    for b in 0..parents.len() {
        let mut path = Vec::new();
        let mut c = b as i32;
        while c >= 0 && world[c as usize].is_none() {
            path.push(c as usize);
            c = parents[c as usize];
        }
        for &x in path.iter().rev() {
            let above = if parents[x] >= 0 { world[parents[x] as usize].unwrap() } else { Quat::IDENTITY };
            let r = rest_quat(&rest[x]);
            world[x] = Some(above * r * q(local[x]).normalize() * r.inverse());
        }
    }
    world.into_iter().map(Option::unwrap).collect()
}

/// A test rig with its rest matrices and roles: names, heads, tails, parents, rest, roles.
type Prepared = (Vec<String>, Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<i32>, Vec<[f32; 9]>, Roles);

fn prepare((names, h, t, p): Rig) -> Prepared {
    let rest = rest_of(&h, &t);
    let roles = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    (names, h, t, p, rest, roles)
}

fn run(skel: Rig, motion: Motion) -> Animated {
    run_on(skel, motion, &Skin::NONE)
}

/// [`run`] with the character's skin.
fn run_on(skel: Rig, motion: Motion, skin: &Skin) -> Animated {
    let (names, h, t, p, rest, roles) = prepare(skel);
    let params = GaitParams { motion, cycles: 2.0, ..Default::default() };
    let clip = motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &roles, &params, skin).unwrap();
    (names, h, t, p, rest, roles, clip)
}

/// Foot tail heights per frame for each leg.
fn foot_heights(
    h: &[[f32; 3]],
    t: &[[f32; 3]],
    p: &[i32],
    rest: &[[f32; 9]],
    roles: &Roles,
    clip: &Clip,
) -> Vec<Vec<f32>> {
    let mut out = vec![Vec::new(); roles.legs.len()];
    for f in 0..clip.frames {
        let local = &clip.rotations[f * clip.bone_count..(f + 1) * clip.bone_count];
        let locations = &clip.locations[f * clip.bone_count..(f + 1) * clip.bone_count];
        let (_, pt) = posed_points(h, t, p, rest, local, locations, clip.root_offset[f]);
        for (i, l) in roles.legs.iter().enumerate() {
            out[i].push(pt[*l.bones.last().unwrap()][2]);
        }
    }
    out
}

/// Phase (fraction of a cycle) of the highest point of each foot in the first cycle.
fn peak_phase(z: &[f32], fpc: usize) -> f32 {
    let i = (0..fpc).max_by(|&a, &b| z[a].partial_cmp(&z[b]).unwrap()).unwrap();
    i as f32 / fpc as f32
}

fn circ(a: f32, b: f32) -> f32 {
    let d = (a - b).rem_euclid(1.0);
    d.min(1.0 - d)
}

fn check_walk(skel: Rig, motion: Motion) {
    let (_, h, t, p, rest, roles, clip) = run(skel, motion);
    let fpc = clip.frames_per_cycle as usize;
    assert_eq!(clip.frames, 2 * fpc + 1);
    // loops: first and last frame equal
    for b in 0..clip.bone_count {
        let (a, z) = (q(clip.rotation(0, b)), q(clip.rotation(clip.frames - 1, b)));
        assert!(a.dot(z).abs() > 0.9999, "bone {b} does not loop");
    }
    let z = foot_heights(&h, &t, &p, &rest, &roles, &clip);
    let l = roles.leg_length;
    for (i, zs) in z.iter().enumerate() {
        let lift = zs.iter().cloned().fold(f32::MIN, f32::max) - zs.iter().cloned().fold(f32::MAX, f32::min);
        assert!(lift > 0.05 * l, "leg {i} lifts only {lift}");
    }
    // no foot goes below its own rest height (feet need not all end at one height: a
    // Fox's front leg bones end at the wrist), and one foot is always on it
    let rest_z: Vec<f32> = roles.legs.iter().map(|l| t[*l.bones.last().unwrap()][2]).collect();
    for f in 0..clip.frames {
        for (i, zs) in z.iter().enumerate() {
            assert!(zs[f] >= rest_z[i] - 0.02 * l, "frame {f}: foot {i} is below its rest height: {}", zs[f]);
        }
        if motion == Motion::Walk {
            let touch = z.iter().zip(&rest_z).map(|(zs, r)| zs[f] - r).fold(f32::MAX, f32::min);
            assert!(touch < 0.05 * l, "frame {f}: every foot is off the ground ({touch})");
        }
    }
    // left and right of each group are half a cycle apart (biped, quadruped walk)
    let groups = roles.legs.iter().map(|l| l.group).max().unwrap() + 1;
    for g in 0..groups {
        let li = roles.legs.iter().position(|l| l.group == g && l.side == Side::Left).unwrap();
        let ri = roles.legs.iter().position(|l| l.group == g && l.side == Side::Right).unwrap();
        let d = circ(peak_phase(&z[li], fpc), peak_phase(&z[ri], fpc));
        if motion == Motion::Walk || roles.plan != BodyPlan::Quadruped {
            assert!((d - 0.5).abs() < 0.1, "group {g}: left/right peaks {d} of a cycle apart");
        } else {
            assert!(d < 0.2, "gallop group {g}: left/right peaks {d} apart");
        }
    }
    // root travels forward
    let last = Vec3::from(clip.root_offset[clip.frames - 1]);
    assert!(last.dot(Vec3::from(roles.forward)) > 0.5 * l);
}

#[test]
fn quadruped_walk_and_run() {
    check_walk(creature(), Motion::Walk);
    check_walk(creature(), Motion::Run);
}

#[test]
fn quadruped_whose_front_legs_end_higher_keeps_every_foot_above_the_ground() {
    // front leg bones ending at the wrist, 0.2 above the hind feet (as the Fox's do): the
    // body's bob must not pull a front foot down to the hind feet's height
    let (names, mut h, mut t, p) = creature();
    for (b, name) in names.iter().enumerate() {
        if name.starts_with("hand.") {
            h[b][2] += 0.2;
            t[b][2] += 0.2;
        }
        if name.starts_with("forearm.") {
            t[b][2] += 0.2;
        }
    }
    check_walk((names.clone(), h.clone(), t.clone(), p.clone()), Motion::Walk);
    check_walk((names, h, t, p), Motion::Run);
}

#[test]
fn a_foot_rising_from_the_ground_keeps_its_heel_on_it() {
    // the last bone of each leg stands up from the ground (a toe bone pointing up, a hoof's
    // leaf bone): its head is the lowest point, and a foot on the ground stays there
    let (names, h, mut t, p) = biped();
    for s in ["L", "R"] {
        let toe = bone(&names, &format!("toe.{s}"));
        t[toe] = [h[toe][0], h[toe][1], h[toe][2] + 0.1];
    }
    let a = run((names, h, t, p), Motion::Walk);
    let (h, roles) = (&a.1, &a.5);
    for (f, (ph, pt)) in posed_clip(&a).iter().enumerate() {
        let low = roles
            .legs
            .iter()
            .map(|l| *l.bones.last().unwrap())
            .map(|b| ph[b][2].min(pt[b][2]) - h[b][2])
            .fold(f32::MAX, f32::min);
        assert!(low.abs() < 0.01 * roles.leg_length, "frame {f}: the lowest foot is {low} off the ground");
    }
}

#[test]
fn feet_and_toes_stay_level_in_stance_and_in_swing() {
    // the bones below each planted ankle keep their rest direction in the world on every frame:
    // a foot pitched about its ankle in swing dipped its heel below the ground (RobotExpressive)
    for (skel, motion) in [(biped(), Motion::Walk), (biped(), Motion::Run), (creature(), Motion::Run)] {
        let a = run(skel, motion);
        let (names, h, t, roles) = (&a.0, &a.1, &a.2, &a.5);
        for (f, (ph, pt)) in posed_clip(&a).iter().enumerate() {
            for l in &roles.legs {
                let last = *l.bones.last().unwrap();
                let rest = (Vec3::from(t[last]) - Vec3::from(h[last])).normalize();
                let now = (Vec3::from(pt[last]) - Vec3::from(ph[last])).normalize();
                assert!(
                    rest.angle_between(now) < 1e-3,
                    "frame {f}: {} turned {}",
                    names[last],
                    rest.angle_between(now)
                );
            }
        }
    }
}

#[test]
fn quadruped_of_separate_trees_walks() {
    check_walk(spot(), Motion::Walk);
    check_walk(spot(), Motion::Run);
}

/// The lowest posed point of each leg's bones (its sole, for a skin along the bones) per frame.
fn leg_lows(a: &Animated) -> Vec<Vec<f32>> {
    let frames = posed_clip(a);
    a.5.legs
        .iter()
        .map(|l| {
            frames
                .iter()
                .map(|(ph, pt)| l.bones.iter().map(|&b| ph[b][2].min(pt[b][2])).fold(f32::MAX, f32::min))
                .collect()
        })
        .collect()
}

/// Spot's hind legs end 7.5 units above its front ones (of 70): with a skin along its bones
/// the body settles, pitching back and down, so that every foot stands on the front feet's
/// ground; without a skin each foot keeps its own height. Either way, no foot goes below.
#[test]
fn a_body_whose_hind_feet_rest_high_settles_onto_one_ground() {
    let (names, h, t, p) = spot();
    let (points, owners) = bone_skin(&h, &t, &p, 4, 0.0);
    let skin = Skin { points: &points, bones: &owners };
    for motion in [Motion::Walk, Motion::Run] {
        for (on_skin, a) in [(true, run_on(spot(), motion, &skin)), (false, run(spot(), motion))] {
            let roles = &a.5;
            let ground = -39.0;
            for (l, lows) in roles.legs.iter().zip(leg_lows(&a)) {
                let last = *l.bones.last().unwrap();
                let own = h[last][2].min(t[last][2]);
                let stands = if on_skin { ground } else { own };
                let low = lows.iter().cloned().fold(f32::MAX, f32::min);
                assert!(
                    (low - stands).abs() < 0.01 * roles.height,
                    "{motion:?} skin {on_skin}: {} stands at {low}, not {stands}",
                    names[last]
                );
            }
        }
    }
}

/// A run keeps a foot on the ground at least three quarters of its cycle: a gallop's four feet,
/// a biped's two, an insect's tripods.
#[test]
fn a_run_keeps_a_foot_on_the_ground_three_quarters_of_the_cycle() {
    for skel in [biped(), creature(), hexapod(), ik_quadruped()] {
        let a = run(skel, Motion::Run);
        let (h, t, roles, clip) = (&a.1, &a.2, &a.5, &a.6);
        let rests: Vec<f32> =
            roles.legs.iter().map(|l| l.bones.iter().map(|&b| h[b][2].min(t[b][2])).fold(f32::MAX, f32::min)).collect();
        let lows = leg_lows(&a);
        let down = (0..clip.frames)
            .filter(|&f| lows.iter().zip(&rests).any(|(z, r)| z[f] - r < 0.01 * roles.leg_length))
            .count();
        let share = down as f32 / clip.frames as f32;
        assert!(share >= 0.75, "{:?}: a foot on the ground {share} of the cycle", roles.plan);
    }
}

/// Feet, IK targets and poles off the root, hind feet from the hock: the feet walk with their
/// legs; each upright foot (a cannon bone) leans with its leg and its toe stays level.
#[test]
fn a_quadruped_exported_with_ik_walks_on_its_feet() {
    check_walk(ik_quadruped(), Motion::Walk);
    check_walk(ik_quadruped(), Motion::Run);
    let a = run(ik_quadruped(), Motion::Walk);
    let (names, h, t) = (&a.0, &a.1, &a.2);
    let frames = posed_clip(&a);
    let turned = |b: usize, f: usize| {
        let (ph, pt) = &frames[f];
        let rest = (Vec3::from(t[b]) - Vec3::from(h[b])).normalize();
        rest.angle_between((Vec3::from(pt[b]) - Vec3::from(ph[b])).normalize())
    };
    for s in ["L", "R"] {
        let [foot, toe] = ["HindFoot", "HindToe"].map(|n| bone(names, &format!("{n}.{s}")));
        assert!((0..frames.len()).all(|f| turned(toe, f) < 1e-3), "{s}: the hoof tips");
        assert!((0..frames.len()).any(|f| turned(foot, f) > 0.1), "{s}: the cannon bone never leans");
    }
}

#[test]
fn six_legs_walk_in_alternating_tripods() {
    let skel = hexapod();
    check_walk(skel.clone(), Motion::Walk);
    check_walk(skel.clone(), Motion::Run);
    let (names, h, t, p, rest, roles, clip) = run(skel, Motion::Walk);
    assert_eq!((roles.plan, roles.legs.len()), (BodyPlan::Multiped, 6));
    // a tripod: each leg steps with the other side's legs of the neighbouring pairs and half
    // a cycle from its own side's neighbours
    let z = foot_heights(&h, &t, &p, &rest, &roles, &clip);
    let fpc = clip.frames_per_cycle as usize;
    let peak = |pair: &str, side: &str| {
        let leg = roles.legs.iter().position(|l| l.bones.iter().any(|&b| names[b] == format!("{pair}_foot.{side}")));
        peak_phase(&z[leg.unwrap()], fpc)
    };
    for side in ["L", "R"] {
        let other = if side == "L" { "R" } else { "L" };
        assert!(circ(peak("front", side), peak("middle", other)) < 0.1, "front.{side} and middle.{other}");
        assert!(circ(peak("back", side), peak("middle", other)) < 0.1, "back.{side} and middle.{other}");
        assert!((circ(peak("front", side), peak("middle", side)) - 0.5).abs() < 0.1, "front.{side}, middle.{side}");
    }
    // (which legs' rising femurs lift them: the unit test of `leg_joints` in motion/gait.rs)
}

#[test]
fn biped_walk_and_run() {
    check_walk(biped(), Motion::Walk);
    check_walk(biped(), Motion::Run);
}

#[test]
fn an_imported_rigs_arms_swing_from_their_upper_arms_at_any_size() {
    // With invented tails every bone is a stub of one length: the arm swung from the
    // clavicle or from the upper arm as rounding (and so the rig's size) decided.
    let arm_bones_turned = |(names, h, t, p): Rig| -> Vec<String> {
        let (names, _, _, _, _, _, clip) = run((names, h, t, p), Motion::Walk);
        (0..clip.bone_count)
            .filter(|&b| names[b].contains("Arm") || names[b].starts_with("Shoulder"))
            .filter(|&b| most_turned(&clip, b) > 1e-3)
            .map(|b| names[b].clone())
            .collect()
    };
    let want = arm_bones_turned(ik_biped(false));
    assert_eq!(want, ["UpperArm.L", "LowerArm.L", "UpperArm.R", "LowerArm.R"]);
    for scale in [1.0f32, 1e-3, 0.37, 3.7, 1e3, 1e4, 1e6] {
        let (names, h, t, p) = ik_biped(true);
        let sc = |v: Vec<[f32; 3]>| v.into_iter().map(|x| (Vec3::from(x) * scale).to_array()).collect();
        assert_eq!(arm_bones_turned((names, sc(h), sc(t), p)), want, "scale {scale}");
    }
}

#[test]
fn a_clavicle_longer_on_one_side_still_stays_and_the_upper_arm_swings() {
    // Auto Rig on a round body can start one clavicle across the middle (q_Bunny's right one,
    // longer than its upper arm): the pair is read alike, so that arm hangs from its shoulder
    // joint as the other does, not from the spine.
    let (names, mut h, t, p) = t_pose_biped();
    let clav = bone(&names, "shoulder.R");
    h[clav] = [0.16, 0.0, 1.45];
    let a = run((names.clone(), h, t, p), Motion::Walk);
    for s in ["L", "R"] {
        let [clav, upper] = ["shoulder", "upper_arm"].map(|n| bone(&names, &format!("{n}.{s}")));
        assert!(most_turned(&a.6, clav) < 1e-4, "{s}: the clavicle swings");
        assert!(most_turned(&a.6, upper) > 0.1, "{s}: the upper arm does not swing");
    }
}

#[test]
fn feet_hanging_off_the_root_walk_with_their_legs() {
    for invented_tails in [false, true] {
        check_walk(ik_biped(invented_tails), Motion::Walk);
        check_walk(ik_biped(invented_tails), Motion::Run);
        let (names, h, t, p, rest, roles, clip) = run(ik_biped(invented_tails), Motion::Walk);
        let located: Vec<&str> = clip.located.iter().map(|&b| names[b].as_str()).collect();
        assert_eq!(located, ["Foot.L", "Foot.R"]);
        // the feet are turned and moved: listed once among the animated bones, in order
        assert!(clip.located.iter().all(|b| clip.animated.contains(b)));
        assert!(clip.animated.windows(2).all(|w| w[0] < w[1]), "{:?}", clip.animated);
        // in the rig's own hierarchy, rotation and location keys put every bone where it
        // is with the feet carried by the legs
        let mut carried = p.clone();
        for &[r, e] in &roles.riders {
            carried[r] = e as i32;
        }
        let n = clip.bone_count;
        let mut moved = 0.0f32;
        for f in 0..clip.frames {
            let local = &clip.rotations[f * n..(f + 1) * n];
            let locations = &clip.locations[f * n..(f + 1) * n];
            let (rh, rt) = posed_points(&h, &t, &p, &rest, local, locations, [0.0; 3]);
            // the same turns with each foot's turn taken relative to its leg instead
            let d = world_rotations(&p, &rest, local);
            let mut carried_local = local.to_vec();
            for &[r, e] in &roles.riders {
                let rq = rest_quat(&rest[r]);
                carried_local[r] = to_wxyz((rq.inverse() * d[e].inverse() * d[r] * rq).normalize());
            }
            let (ch, ct) = posed_points(&h, &t, &carried, &rest, &carried_local, &[], [0.0; 3]);
            for b in 0..n {
                let err =
                    (Vec3::from(rh[b]) - Vec3::from(ch[b])).length() + (Vec3::from(rt[b]) - Vec3::from(ct[b])).length();
                assert!(err < 1e-4 * roles.leg_length, "frame {f}, {}: {err}", names[b]);
            }
            for &b in &clip.located {
                moved = moved.max(Vec3::from(locations[b]).length());
            }
        }
        assert!(moved > 0.05 * roles.leg_length, "the feet never move: {moved}");
    }
}

/// Posed heads and tails of one frame.
type Posed = (Vec<[f32; 3]>, Vec<[f32; 3]>);

/// Posed heads and tails of every frame (root offset included).
fn posed_clip(a: &Animated) -> Vec<Posed> {
    let (_, h, t, p, rest, _, clip) = a;
    let n = clip.bone_count;
    (0..clip.frames)
        .map(|f| {
            let (rot, loc) = (&clip.rotations[f * n..(f + 1) * n], &clip.locations[f * n..(f + 1) * n]);
            posed_points(h, t, p, rest, rot, loc, clip.root_offset[f])
        })
        .collect()
}

/// The largest angle (radians) bone `b` turns from rest over the clip.
fn most_turned(clip: &Clip, b: usize) -> f32 {
    (0..clip.frames).map(|f| q(clip.rotation(f, b)).angle_between(Quat::IDENTITY)).fold(0.0, f32::max)
}

/// Pitch (radians, up from the forward axis) of a bone's direction.
fn pitch(head: [f32; 3], tail: [f32; 3], fwd: Vec3) -> f32 {
    let d = Vec3::from(tail) - Vec3::from(head);
    d.z.atan2(d.dot(fwd))
}

fn correlation(a: &[f32], b: &[f32]) -> f32 {
    let (ma, mb) = (a.iter().sum::<f32>() / a.len() as f32, b.iter().sum::<f32>() / b.len() as f32);
    let cov: f32 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f32 = a.iter().map(|x| (x - ma) * (x - ma)).sum();
    let vb: f32 = b.iter().map(|y| (y - mb) * (y - mb)).sum();
    cov / (va * vb).sqrt()
}

/// How the body moves, not only the feet: each hand swings against the foot of its side,
/// from the upper arm (the clavicle stays), elbows bend forward, feet stay near their rest
/// pitch (the ankle undoes the hip and knee), and the head steadies against the neck's bob.
#[test]
fn a_biped_walks_with_its_arms_against_its_legs_and_its_head_steady() {
    for (motion, skel) in [Motion::Walk, Motion::Run].into_iter().flat_map(|m| [(m, biped()), (m, t_pose_biped())]) {
        let a = run(skel, motion);
        let (names, h, t, roles) = (&a.0, &a.1, &a.2, &a.5);
        let fwd = Vec3::from(roles.forward);
        let frames = posed_clip(&a);
        for s in ["L", "R"] {
            let [hips, hand, foot] = ["hips", &format!("hand.{s}"), &format!("toe.{s}")].map(|n| bone(names, n));
            let along =
                |pts: &[[f32; 3]], b: usize, hips_h: [f32; 3]| (Vec3::from(pts[b]) - Vec3::from(hips_h)).dot(fwd);
            let hands: Vec<f32> = frames.iter().map(|(ph, pt)| along(pt, hand, ph[hips])).collect();
            let feet: Vec<f32> = frames.iter().map(|(ph, pt)| along(pt, foot, ph[hips])).collect();
            let c = correlation(&hands, &feet);
            assert!(c < -0.5, "{motion:?} {s}: hand and foot swing together ({c})");
            let [clav, upper, fore, foot] =
                ["shoulder", "upper_arm", "forearm", "foot"].map(|n| bone(names, &format!("{n}.{s}")));
            assert!(most_turned(&a.6, clav) < 1e-4, "{motion:?} {s}: the clavicle swings");
            assert!(most_turned(&a.6, upper) > 0.1, "{motion:?} {s}: the upper arm does not swing");
            // the forearm points further forward than the upper arm: the elbow bends forward
            for (f, (ph, pt)) in frames.iter().enumerate() {
                let bend = pitch(ph[upper], pt[upper], fwd) - pitch(ph[fore], pt[fore], fwd);
                assert!(bend < 0.0, "{motion:?} {s} frame {f}: the elbow bends backward ({bend})");
            }
            let rest = pitch(h[foot], t[foot], fwd);
            let worst = frames.iter().map(|(ph, pt)| (pitch(ph[foot], pt[foot], fwd) - rest).abs()).fold(0.0, f32::max);
            assert!(worst < 0.6, "{motion:?} {s}: the foot pitches {worst} rad from rest");
        }
        let [neck, head] = ["neck", "head"].map(|n| bone(names, n));
        let swing = |b: usize| {
            let ps: Vec<f32> = frames.iter().map(|(ph, pt)| pitch(ph[b], pt[b], fwd)).collect();
            ps.iter().cloned().fold(f32::MIN, f32::max) - ps.iter().cloned().fold(f32::MAX, f32::min)
        };
        assert!(
            swing(head) < swing(neck),
            "{motion:?}: the head bobs {} against the neck's {}",
            swing(head),
            swing(neck)
        );
        // the neck turns against the spine's sway: the head turns less from side to side
        // than the chest
        let (p, rest, clip) = (&a.3, &a.4, &a.6);
        let (n, right) = (clip.bone_count, fwd.cross(Vec3::from(roles.up)));
        let headings: Vec<(f32, f32)> = (0..clip.frames)
            .map(|f| {
                let d = world_rotations(p, rest, &clip.rotations[f * n..(f + 1) * n]);
                let yaw = |b: usize| (d[b] * fwd).dot(right).atan2((d[b] * fwd).dot(fwd));
                (yaw(bone(names, "chest")), yaw(head))
            })
            .collect();
        let range =
            |v: Vec<f32>| v.iter().cloned().fold(f32::MIN, f32::max) - v.iter().cloned().fold(f32::MAX, f32::min);
        let chest = range(headings.iter().map(|x| x.0).collect());
        let turned = range(headings.iter().map(|x| x.1).collect());
        assert!(chest > 0.0 && turned < 0.6 * chest, "{motion:?}: the head turns {turned}, the chest {chest}");
    }
}

/// T-posed arms walk and run hanging: each upper arm within 30 degrees of straight down on every
/// frame, the arm clear of the body beside it, a wider body's skin holding the arms further out.
#[test]
fn t_posed_arms_hang_clear_of_the_body() {
    let (names, h, t, p) = t_pose_biped();
    // a trunk 0.22 wide at every height (the shoulder joints are 0.18 out), on the spine bones
    let trunk: Vec<usize> = ["hips", "spine", "chest"].iter().map(|n| bone(&names, n)).collect();
    let (mut points, mut owners) = bone_skin(&h, &t, &p, 2, 0.0);
    for &b in &trunk {
        for k in 0..=10 {
            let z = h[b][2] + (t[b][2] - h[b][2]) * k as f32 / 10.0;
            for j in 0..12 {
                let a = j as f32 / 12.0 * std::f32::consts::TAU;
                points.push([0.22 * a.cos(), 0.15 * a.sin(), z]);
                owners.push(b as i32);
            }
        }
    }
    // and the hips' skin down to the thighs' middle, as wide
    for k in 0..=10 {
        for j in 0..12 {
            let a = j as f32 / 12.0 * std::f32::consts::TAU;
            points.push([0.22 * a.cos(), 0.15 * a.sin(), 0.75 + 0.025 * k as f32]);
            owners.push(trunk[0] as i32);
        }
    }
    let wide = Skin { points: &points, bones: &owners };
    for motion in [Motion::Walk, Motion::Run] {
        for (clear, a) in [
            (0.2, run((names.clone(), h.clone(), t.clone(), p.clone()), motion)),
            (0.22, run_on(t_pose_biped(), motion, &wide)),
        ] {
            for (f, (ph, pt)) in posed_clip(&a).iter().enumerate() {
                for s in ["L", "R"] {
                    let [upper, fore, hand] =
                        ["upper_arm", "forearm", "hand"].map(|n| bone(&names, &format!("{n}.{s}")));
                    let d = Vec3::from(pt[upper]) - Vec3::from(ph[upper]);
                    let hang = d.angle_between(Vec3::NEG_Z).to_degrees();
                    assert!(hang <= 30.0, "{motion:?} frame {f} {s}: the upper arm is {hang} degrees from hanging");
                    for end in [pt[fore], ph[hand], pt[hand]] {
                        assert!(end[0].abs() >= clear, "{motion:?} frame {f} {s}: the hand at {end:?} is in the body");
                    }
                }
            }
        }
    }
}

/// A leg starting with a pelvis bone (sideways from the hips) swings from the thigh, its
/// first bone pointing down; the pelvis bone stays.
#[test]
fn legs_swing_from_their_first_bone_pointing_down() {
    let (mut names, mut h, mut t, mut p) = biped();
    for s in ["L", "R"] {
        let thigh = bone(&names, &format!("thigh.{s}"));
        names.push(format!("pelvis.{s}"));
        h.push([0.0, 0.0, 1.0]);
        t.push(h[thigh]);
        p.push(bone(&names, "hips") as i32);
        p[thigh] = (names.len() - 1) as i32;
    }
    let a = run((names, h, t, p), Motion::Walk);
    let (names, roles, clip) = (&a.0, &a.5, &a.6);
    assert_eq!(roles.legs.len(), 2);
    for s in ["L", "R"] {
        let [pelvis, thigh] = ["pelvis", "thigh"].map(|n| bone(names, &format!("{n}.{s}")));
        assert!(roles.legs.iter().any(|l| l.bones[..2] == [pelvis, thigh]), "{:?}", roles.legs);
        let (pelvis, thigh) = (most_turned(clip, pelvis), most_turned(clip, thigh));
        assert!(pelvis < 1e-4, "{s}: the pelvis bone swings {pelvis}");
        assert!(thigh > 0.2, "{s}: the thigh swings only {thigh}");
    }
}

/// A running quadruped's tail lifts and comes back to rest, never below it (a low tail
/// swung down went through the ground): its own turns only ever raise its tip.
#[test]
fn a_running_tail_never_swings_down() {
    let a = run(creature(), Motion::Run);
    let (names, h, t, p, rest, roles, clip) = &a;
    let tip = *roles.tail.last().expect("the creature has a tail");
    let n = clip.bone_count;
    let mut lifted = 0.0f32;
    for f in 0..clip.frames {
        let rot = &clip.rotations[f * n..(f + 1) * n];
        let mut still = rot.to_vec();
        for &b in &roles.tail {
            still[b] = [1.0, 0.0, 0.0, 0.0];
        }
        let (_, with) = posed_points(h, t, p, rest, rot, &[], [0.0; 3]);
        let (_, without) = posed_points(h, t, p, rest, &still, &[], [0.0; 3]);
        let up = with[tip][2] - without[tip][2];
        assert!(up > -1e-4 * roles.leg_length, "frame {f}: {} swings down {up}", names[tip]);
        lifted = lifted.max(up);
    }
    assert!(lifted > 0.02 * roles.leg_length, "the tail never lifts: {lifted}");
}

#[test]
fn cadence_does_not_depend_on_units_beyond_reason() {
    let (.., cow) = run(spot(), Motion::Walk); // ~40 units per leg
    assert!(cow.frames_per_cycle <= 1.05 * 1.6 * 24.0 + 1.0, "{}", cow.frames_per_cycle);
}

#[test]
fn the_body_travels_as_fast_as_the_feet_push_it() {
    // the root moves one stride a cycle, the speed at which a foot on the ground sweeps back,
    // so planted feet barely move (a tenth of the stride, at most 0.15): at half that speed
    // they slid back 0.36 of it
    for motion in [Motion::Walk, Motion::Run] {
        let a = run(biped(), motion);
        let (roles, clip) = (&a.5, &a.6);
        let posed = posed_clip(&a);
        // A biped's timing (motion::gait): one stride is 1.3 leg lengths walking and 1.7
        // running, a foot is on the ground for the first 0.6 (walk) or 0.4 (run) of its cycle,
        // the left foot's cycle starts at 0 and the right's half a cycle later.
        let (legs_per_stride, duty) = if motion == Motion::Run { (1.7, 0.4) } else { (1.3, 0.6) };
        let stride = legs_per_stride * roles.leg_length;
        let fpc = clip.frames_per_cycle;
        let fwd = Vec3::from(roles.forward);
        let travel = Vec3::from(clip.root_offset[clip.frames - 1]).dot(fwd);
        assert!((travel - 2.0 * stride).abs() < 1e-3 * stride, "{travel} {stride}");
        for leg in &roles.legs {
            let offset = if leg.side == Side::Left { 0.0 } else { 0.5 };
            let foot = *leg.bones.last().unwrap();
            let planted = |f: usize| {
                let ph = (f as f32 / fpc + offset).fract();
                ph > 0.1 * duty && ph < 0.9 * duty
            };
            let x = |f: usize| Vec3::from(posed[f].1[foot]).dot(fwd);
            // the fastest a planted foot moves, over a whole stance (a bound on its slide)
            let speed = (0..clip.frames - 1)
                .filter(|&f| planted(f) && planted(f + 1))
                .map(|f| (x(f + 1) - x(f)).abs())
                .fold(0.0f32, f32::max);
            let slide = speed * duty * fpc;
            assert!(slide < 0.25 * stride, "{motion:?}: a planted foot slides {slide} of {stride}");
        }
    }
}

#[test]
fn run_is_faster_than_walk() {
    let (.., walk) = run(creature(), Motion::Walk);
    let (.., trot) = run(creature(), Motion::Run);
    assert!(trot.frames_per_cycle < 0.7 * walk.frames_per_cycle);
}

#[test]
fn head_shake_moves_head_not_feet() {
    let (names, h, t, p, rest, roles, clip) = run(creature(), Motion::HeadShake);
    assert!(!clip.moves_root);
    let named: Vec<&str> = clip.animated.iter().map(|&b| names[b].as_str()).collect();
    assert!(named.contains(&"head") && named.contains(&"neck") && named.contains(&"ear.L"));
    assert!(!named.iter().any(|n| n.contains("foot") || n.contains("hand") || n.contains("thigh")));
    // starts and ends at rest; turns the head in between
    let id = |f: usize| (0..clip.bone_count).all(|b| q(clip.rotation(f, b)).w.abs() > 0.99999);
    assert!(id(0) && id(clip.frames - 1));
    let z = foot_heights(&h, &t, &p, &rest, &roles, &clip);
    assert!(z.iter().all(|zs| zs.iter().all(|&v| (v - zs[0]).abs() < 1e-6)));
    let mut max_turn = 0.0f32;
    let jaw = bone(&names, "jaw");
    for f in 0..clip.frames {
        let local = &clip.rotations[f * clip.bone_count..(f + 1) * clip.bone_count];
        let (_, pt) = posed_points(&h, &t, &p, &rest, local, &[], [0.0; 3]);
        max_turn = max_turn.max((pt[jaw][0] - t[jaw][0]).abs());
    }
    assert!(max_turn > 0.1, "snout moves sideways only {max_turn}");
}

#[test]
fn bad_params() {
    let (_, h, t, p, rest, roles) = prepare(creature());
    let bad = GaitParams { fps: 0.0, ..Default::default() };
    assert!(motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &roles, &bad, &Skin::NONE).is_err());
    for motion in [Motion::HeadShake, Motion::Walk] {
        let nan = GaitParams { motion, amplitude: f32::NAN, ..Default::default() };
        let err =
            motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &roles, &nan, &Skin::NONE).unwrap_err().to_string();
        assert!(err.contains("amplitude"), "{err}");
    }
    // roles from another rig: every role is checked, not only the head and the legs
    let mut stale = roles.clone();
    stale.tail.push(h.len());
    let err = motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &stale, &GaitParams::default(), &Skin::NONE)
        .unwrap_err()
        .to_string();
    assert!(err.contains("not in the arrays"), "{err}");
    assert!(
        motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest[1..], &roles, &GaitParams::default(), &Skin::NONE).is_err()
    );
    // A NaN rest frame (one entry is enough) is refused, not keyed as NaN.
    for motion in [Motion::HeadShake, Motion::Walk] {
        let mut nan = rest.clone();
        nan[roles.head][4] = f32::NAN;
        let params = GaitParams { motion, ..Default::default() };
        let err =
            motion_clip(&Skeleton::new(&h, &t, &p, &[]), &nan, &roles, &params, &Skin::NONE).unwrap_err().to_string();
        assert!(err.contains("1 rest matrix(s) have NaN"), "{err}");
    }
    // Clips past Blender's last frame are refused before anything is allocated.
    for (motion, fps, duration, cycles) in
        [(Motion::HeadShake, 1e9, 1e9, 1.0), (Motion::HeadShake, 1e30, 1e30, 1.0), (Motion::Walk, 24.0, 2.0, 1e12)]
    {
        let long = GaitParams { motion, fps, duration, cycles, ..Default::default() };
        let err =
            motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &roles, &long, &Skin::NONE).unwrap_err().to_string();
        assert!(err.contains("frames"), "{err}");
    }
}

/// A rest frame scaled to near f32's limit (a fuzz input) is read as the same frame: scale is
/// normalised away, and its dot products no longer overflow into NaN keys.
#[test]
fn a_rest_frame_near_the_float_limit_keys_the_same_rotations() {
    let (_, h, t, p, rest, roles) = prepare(creature());
    for motion in [Motion::HeadShake, Motion::Walk] {
        let params = GaitParams { motion, ..Default::default() };
        let plain = motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &roles, &params, &Skin::NONE).unwrap();
        let mut huge = rest.clone();
        for b in [roles.head, roles.spine[0]] {
            huge[b] = huge[b].map(|x| x * 3e38);
        }
        let clip = motion_clip(&Skeleton::new(&h, &t, &p, &[]), &huge, &roles, &params, &Skin::NONE).unwrap();
        for (a, b) in plain.rotations.iter().zip(&clip.rotations) {
            assert!(b.iter().all(|c| c.is_finite()), "{motion:?}: {b:?}");
            assert!(q(*a).angle_between(q(*b)) < 1e-3, "{motion:?}: {a:?} vs {b:?}");
        }
    }
}

#[test]
fn a_head_shake_turns_neck_and_head_by_the_amplitude_and_its_cycle_is_one_shake() {
    let (_, h, t, p, rest, roles, clip) = run(creature(), Motion::HeadShake);
    let amp = GaitParams::default().amplitude;
    let head = most_turned(&clip, roles.head);
    let neck: f32 = roles.neck.iter().map(|&b| most_turned(&clip, b)).sum();
    assert!((head - 0.5 * amp).abs() < 0.05 * amp && (neck - 0.5 * amp).abs() < 0.05 * amp, "{head} {neck}");
    let cycles = GaitParams::default().cycles;
    assert_eq!(clip.frames_per_cycle * cycles, (clip.frames - 1) as f32);
    // with no neck, the head turns alone by the whole amplitude
    let neckless = Roles { neck: Vec::new(), ..roles.clone() };
    let params = GaitParams { motion: Motion::HeadShake, ..Default::default() };
    let alone = motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &neckless, &params, &Skin::NONE).unwrap();
    assert!((most_turned(&alone, roles.head) - amp).abs() < 0.05 * amp);
    // more shakes than Blender has frames is an error, not a clip of NaN (a fuzz finding:
    // 7.6e37 shakes overflowed the sine's phase)
    let skeleton = Skeleton::new(&h, &t, &p, &[]);
    for cycles in [2e6, 7.6e37] {
        let params = GaitParams { motion: Motion::HeadShake, cycles, ..Default::default() };
        let err = motion_clip(&skeleton, &rest, &roles, &params, &Skin::NONE).unwrap_err().to_string();
        assert!(err.contains("cycles must be at most"), "{err}");
    }
    let params = GaitParams { motion: Motion::HeadShake, cycles: 1e6, ..Default::default() };
    let fast = motion_clip(&skeleton, &rest, &roles, &params, &Skin::NONE).unwrap();
    assert!(fast.rotations.iter().flatten().all(|c| c.is_finite()));
}

#[test]
fn upright_ears_swing_sideways_in_a_head_shake() {
    // the robot's ears, made to stand straight up from its head: turned about the up axis
    // they would only spin about themselves
    let (names, h, mut t, p) = ik_biped(false);
    let ear = bone(&names, "Ear1.L");
    t[ear] = [h[ear][0], h[ear][1], h[ear][2] + 0.3];
    let (_, h, t, p, rest, roles, clip) = run((names, h, t, p), Motion::HeadShake);
    assert!(roles.head_extras.contains(&ear));
    let head = roles.head;
    let n = clip.bone_count;
    let mut swing = 0.0f32;
    for f in 0..clip.frames {
        // the ear's own turn alone (neck and head held still), as seen at its tip
        let mut local = clip.rotations[f * n..(f + 1) * n].to_vec();
        for &b in roles.neck.iter().chain([&head]) {
            local[b] = [1.0, 0.0, 0.0, 0.0];
        }
        let (_, pt) = posed_points(&h, &t, &p, &rest, &local, &[], [0.0; 3]);
        swing = swing.max((Vec3::from(pt[ear]) - Vec3::from(t[ear])).length());
    }
    let len = (Vec3::from(t[ear]) - Vec3::from(h[ear])).length();
    assert!(swing > 0.1 * len, "the ear's tip moves {swing} of its length {len}");
}

#[test]
fn straight_legs_fold_their_knees_backward() {
    // thigh and shin exactly in line: no bend in the rest pose tells the knee its way, and it
    // takes a human knee's (the foot goes back behind the knee in swing)
    let (names, mut h, mut t, p) = biped();
    for s in ["L", "R"] {
        let (thigh, shin) = (bone(&names, &format!("thigh.{s}")), bone(&names, &format!("shin.{s}")));
        t[thigh][1] = h[thigh][1];
        h[shin][1] = h[thigh][1];
        t[shin][1] = h[thigh][1];
    }
    let a = run((names, h, t, p), Motion::Walk);
    let (names, roles, posed) = (&a.0, &a.5, posed_clip(&a));
    let fwd = Vec3::from(roles.forward);
    for s in ["L", "R"] {
        let shin = bone(names, &format!("shin.{s}"));
        let most_bent = posed
            .iter()
            .map(|(ph, pt)| (Vec3::from(pt[shin]) - Vec3::from(ph[shin])).dot(fwd))
            .fold(0.0f32, |a, d| if d.abs() > a.abs() { d } else { a });
        assert!(most_bent < -0.05 * roles.leg_length, "shin.{s}: foot {most_bent} ahead of the knee");
    }
}

#[test]
fn sheared_rest_frames_give_the_motion_of_their_orthonormal_frames() {
    // an unevenly scaled armature's rest frames are not rotations: each is taken as the
    // rotation with its bone axis and the X axis made orthogonal to it
    let (_, h, t, p, rest, roles) = prepare(biped());
    let sheared: Vec<[f32; 9]> = rest
        .iter()
        .map(|m| {
            let m = Mat3::from_cols_array(m).transpose();
            Mat3::from_cols(m.x_axis + 0.4 * m.y_axis, m.y_axis * 1.7, m.z_axis).transpose().to_cols_array()
        })
        .collect();
    let a = motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &roles, &GaitParams::default(), &Skin::NONE).unwrap();
    let b =
        motion_clip(&Skeleton::new(&h, &t, &p, &[]), &sheared, &roles, &GaitParams::default(), &Skin::NONE).unwrap();
    for (x, y) in a.rotations.iter().zip(&b.rotations) {
        assert!(q(*x).dot(q(*y)).abs() > 1.0 - 1e-5, "{x:?} {y:?}");
    }
}

#[test]
fn any_fps_and_stride_give_a_whole_finite_cycle() {
    let (_, h, t, p, rest, roles) = prepare(creature());
    // a slideshow of 2 frames a second still has 8 frames a step cycle
    let slow = GaitParams { fps: 2.0, ..Default::default() };
    assert!(
        motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &roles, &slow, &Skin::NONE).unwrap().frames_per_cycle
            >= 8.0
    );
    // a stride longer than the legs can take swings them as far as they go, not to NaN
    for motion in [Motion::Walk, Motion::Run] {
        let long = GaitParams { motion, stride: 5.0, ..Default::default() };
        let clip = motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &roles, &long, &Skin::NONE).unwrap();
        assert!(clip.rotations.iter().flatten().all(|v| v.is_finite()));
        assert!(clip.root_offset.iter().flatten().all(|v| v.is_finite()));
    }
}

#[test]
fn fk_identity_is_rest() {
    let (_, h, t, p) = creature();
    let rest = rest_of(&h, &t);
    let id = vec![[1.0, 0.0, 0.0, 0.0]; h.len()];
    let (ph, pt) = posed_points(&h, &t, &p, &rest, &id, &[], [0.0; 3]);
    for b in 0..h.len() {
        assert!((Vec3::from(ph[b]) - Vec3::from(h[b])).length() < 1e-5);
        assert!((Vec3::from(pt[b]) - Vec3::from(t[b])).length() < 1e-5);
    }
}

/// The lowest root height of a clip, as a share of the leg's length (0: the rest height).
fn lowest_root(skel: Rig, motion: Motion) -> f32 {
    let (.., roles, clip) = run(skel, motion);
    clip.root_offset.iter().map(|o| o[2]).fold(f32::INFINITY, f32::min) / roles.leg_length
}

#[test]
fn a_body_on_four_legs_keeps_its_level_while_a_biped_sinks() {
    // On four legs a far foot lifts off early rather than pull the body down and bend the
    // other knees, walking and galloping; a biped's feet at double support and a runner's
    // springing legs lower it.
    // (a gallop sinks by at most 1 % of the reach, for its far feet to touch down)
    for (motion, most) in [(Motion::Walk, 1e-6), (Motion::Run, 0.0101)] {
        let quad = lowest_root(creature(), motion);
        assert!(quad >= -most, "{motion:?}: a quadruped sinks {quad} of its leg");
        let biped = lowest_root(biped(), motion);
        assert!(biped < -0.02, "{motion:?}: a biped stays up ({biped})");
    }
}
