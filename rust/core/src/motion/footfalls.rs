//! Planted feet for walk and run: where each foot is on every frame, the body's height that lets
//! the legs reach, and the leg rotations that put the feet there (a stage of `gait.rs`).
//!
//! Footfalls. A leg with phase `φ` (cycle fraction, duty factor `d`) is in stance for `φ < d`.
//! With the body travelling `S` (the stride) per cycle, a stance foot stays where it touched
//! down: relative to the body its ankle goes from `+dS/2` to `-dS/2` along forward, so in the
//! world it does not move. In swing it goes from `-dS/2` back to `+dS/2` relative to the body
//! and from one footfall to the next (`S`) in the world, eased so that it leaves and lands with
//! no speed, lifted by `h sin(π s)`. The gait phase is the distance travelled over `S`, so
//! stride and root motion agree. Without root motion the same feet slide back under a body
//! that stays (walking on the spot).
//!
//! Body height. Each leg allows the hip to be at most its reach above its foot target at the
//! target's horizontal distance; the body goes as high as every leg allows, never above rest
//! and never lower than a few per cent of a leg's reach.
//! Reach is the leg's rest hip-ankle distance, or 98 % of its two bones when they are bent at
//! rest. So stance feet stay on the ground the rest pose stands on, neither floating nor
//! sinking, and the body dips where the feet are far apart.
//!
//! Legs. Each leg's two bones above its foot (thigh and shin; an upper arm and forearm; an
//! insect's femur and tibia) are solved by two-bone IK ([`crate::posing::two_bone_ik`]) from its
//! posed hip to its target, the knee bending in the plane and towards the side it bent at rest
//! (turned with the pelvis). The bones below the ankle keep their rest orientation in the world,
//! in stance and in swing: toes and paws stay level with the ground, and a lifted foot is all
//! above the ground (a foot pitched about its ankle in swing dips its heel or its toe below the
//! ground when the ankle is lifted less than the foot is long). A leg without two such bones is
//! left to the swing-based posing of `gait.rs`.

use crate::motion::roles::{Limb, Roles};
use crate::posing::{frame_turn, two_bone_ik};
use glam::{Quat, Vec3};
use std::f32::consts::PI;

/// A leg set up for planting: its two IK bones, the bone below the ankle, and the rest joints.
#[derive(Debug, Clone)]
pub(crate) struct PlantedLeg {
    /// Upper and lower IK bones (thigh, shin).
    pub upper: usize,
    pub lower: usize,
    /// The bone whose head is the ankle (a foot, or a foot riding on the root), if any.
    pub foot: Option<usize>,
    /// Rest hip, knee and ankle.
    pub hip: Vec3,
    pub knee: Vec3,
    pub ankle: Vec3,
    /// Bone lengths and the reach that sets the body's height.
    pub l1: f32,
    pub l2: f32,
    pub reach: f32,
    /// Rest direction the knee bends towards (perpendicular to hip -> ankle).
    pub pole: Vec3,
}

/// The legs that can be planted (see the module doc), one entry per leg of `roles`. `swing` is
/// the index of each leg's first bone pointing down, `knee_sign` the sign its knee flexes about
/// `right` (for a leg straight at rest, which side the knee goes), `riders` the feet hanging off
/// the root as (foot, the leg bone it rides on).
pub(crate) fn planted_legs(
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    roles: &Roles,
    swing: &[usize],
    knee_sign: &[f32],
    right: Vec3,
) -> Vec<Option<PlantedLeg>> {
    let hv = |b: usize| Vec3::from(heads[b]);
    roles
        .legs
        .iter()
        .zip(swing.iter().zip(knee_sign))
        .map(|(limb, (&i0, &sign))| plan_leg(limb, i0, sign, roles, &hv, tails, right))
        .collect()
}

fn plan_leg(
    limb: &Limb,
    i0: usize,
    sign: f32,
    roles: &Roles,
    hv: &dyn Fn(usize) -> Vec3,
    tails: &[[f32; 3]],
    right: Vec3,
) -> Option<PlantedLeg> {
    let bones = &limb.bones;
    // The IK pair: the first bone pointing down and the next, with a foot below them. A leg
    // whose first bone pointing down is its forearm or shin (the upper arm above it slopes)
    // takes the bone above and keeps the last as its foot; a leg with one bone below its rising
    // first bone (an insect's femur then tibia) uses that pair, footless.
    let (i, j) = if bones.len() >= i0 + 3 {
        (i0, i0 + 1)
    } else if i0 >= 1 {
        (i0 - 1, i0)
    } else if bones.len() == i0 + 2 {
        (i0, i0 + 1)
    } else {
        return None;
    };
    let (upper, lower) = (bones[i], bones[j]);
    let rider = roles.riders.iter().find(|r| r[1] == lower).map(|r| r[0]);
    let foot = bones.get(j + 1).copied().or(rider);
    let hip = hv(upper);
    let knee = hv(lower);
    let ankle = match foot {
        Some(f) => hv(f),
        None => Vec3::from(tails[lower]),
    };
    let (l1, l2) = ((knee - hip).length(), (ankle - knee).length());
    let span = (ankle - hip).length();
    if !(l1 > 1e-6 * roles.height && l2 > 1e-6 * roles.height && span > 1e-6 * roles.height) {
        return None;
    }
    let dir = (ankle - hip) / span;
    let bent = (knee - hip) - dir * (knee - hip).dot(dir);
    let pole = if bent.length() > 0.02 * l1 {
        bent.normalize()
    } else {
        // Straight at rest: the knee goes opposite to where its flex turns the shin's end.
        let turned = right.cross(ankle - knee) * sign;
        let p = -(turned - dir * turned.dot(dir));
        p.try_normalize()?
    };
    let reach = span.max(0.98 * (l1 + l2)).min(l1 + l2);
    Some(PlantedLeg { upper, lower, foot, hip, knee, ankle, l1, l2, reach, pole })
}

/// Where a foot's ankle is at leg phase `ph`, relative to its rest place, for a body that has
/// travelled `travel` along `fwd`: forward offset and lift (see the module doc).
pub(crate) fn foot_offset(ph: f32, duty: f32, stride: f32, lift: f32, travel: f32) -> (f32, f32) {
    let stance = ph < duty;
    let (eased, up) = if stance {
        (0.0, 0.0)
    } else {
        let s = (ph - duty) / (1.0 - duty);
        (0.5 - 0.5 * (PI * s).cos(), (PI * s).sin())
    };
    (stride * (0.5 * duty - ph + eased) + travel, lift * up)
}

/// A leg lowers the body by at most this fraction of its reach; a foot further out is left
/// short of its target (it lifts off a little early or lands a little late), as a body sunk
/// further would fold a bent leg's knee or elbow into the ground.
const MAX_DROP: f32 = 0.06;

/// How far the body may go up (negative: down) so that every leg reaches its target, each leg
/// lowering it by at most [`MAX_DROP`] of its reach: `hips` are the posed hips before any
/// offset, `targets` the ankles, `travel` the body's forward offset. Never above 0 (the rest
/// height).
pub(crate) fn body_drop(legs: &[(&PlantedLeg, Vec3, Vec3)], fwd: Vec3, travel: f32) -> f32 {
    legs.iter()
        .map(|(leg, hip, target)| {
            let hip = *hip + fwd * travel;
            let mut flat = *target - hip;
            flat.z = 0.0;
            let h2 = leg.reach * leg.reach - flat.length_squared();
            let allowed = if h2 > 0.0 { target.z + h2.sqrt() } else { target.z };
            (allowed - hip.z).max(-MAX_DROP * leg.reach)
        })
        .fold(0.0f32, f32::min)
}

/// The world turns of a planted leg's two bones that put its ankle at `target` from the posed
/// hip `hip`, the pelvis having turned by `pelvis` (its knee's bend direction turns with it).
pub(crate) fn leg_turns(leg: &PlantedLeg, hip: Vec3, target: Vec3, pelvis: Quat) -> (Quat, Quat) {
    let pole = pelvis * leg.pole;
    let s = two_bone_ik(hip, target, leg.l1, leg.l2, pole);
    let upper = frame_turn(leg.knee - leg.hip, leg.pole, s.middle - hip, pole);
    let lower = frame_turn(leg.ankle - leg.knee, leg.pole, s.end - s.middle, pole);
    (upper, lower)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stance_foot_stays_put_in_the_world_and_a_swing_foot_lands_a_stride_ahead() {
        let (duty, stride, fpc) = (0.6, 1.3, 30.0);
        let at = |k: f32| {
            let ph = (k / fpc + 0.25).fract();
            foot_offset(ph, duty, stride, 0.1, stride * k / fpc)
        };
        // Frames 0..10 have phase 0.25..0.58: stance.
        let (x0, _) = at(0.0);
        for k in 1..10 {
            let (x, z) = at(k as f32);
            assert!((x - x0).abs() < 1e-5 && z == 0.0, "frame {k}: {x} vs {x0}");
        }
        // The next stance starts one stride further on.
        let (x1, _) = at(fpc * (1.0 - 0.25) + 1.0);
        assert!((x1 - (x0 + stride)).abs() < 1e-4, "{x1} vs {}", x0 + stride);
        // Continuous through lift-off and touch-down.
        for k in 0..300 {
            let a = at(k as f32 * 0.1);
            let b = at(k as f32 * 0.1 + 0.01);
            assert!((a.0 - b.0).abs() < 0.01 && (a.1 - b.1).abs() < 0.01, "{k}");
        }
    }

    #[test]
    fn the_body_drops_just_enough_for_a_far_foot() {
        let leg = PlantedLeg {
            upper: 0,
            lower: 1,
            foot: None,
            hip: Vec3::new(0.0, 0.0, 1.0),
            knee: Vec3::new(0.0, 0.0, 0.5),
            ankle: Vec3::ZERO,
            l1: 0.5,
            l2: 0.5,
            reach: 1.0,
            pole: Vec3::X,
        };
        let hip = leg.hip;
        assert_eq!(body_drop(&[(&leg, hip, Vec3::ZERO)], Vec3::X, 0.0), 0.0);
        let drop = body_drop(&[(&leg, hip, Vec3::new(0.3, 0.0, 0.0))], Vec3::X, 0.0);
        assert!((drop - ((1.0f32 - 0.09).sqrt() - 1.0)).abs() < 1e-5, "{drop}");
        // A foot far out lowers the body by at most MAX_DROP of the reach.
        let drop = body_drop(&[(&leg, hip, Vec3::new(0.6, 0.0, 0.0))], Vec3::X, 0.0);
        assert!((drop + MAX_DROP).abs() < 1e-6, "{drop}");
        // Travel carries the hip over the foot.
        assert!(body_drop(&[(&leg, hip, Vec3::new(0.3, 0.0, 0.0))], Vec3::X, 0.3).abs() < 1e-6);
    }
}
