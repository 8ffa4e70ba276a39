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
//! Ground. A stance foot stands on the ground: its ankle at the ground's height plus the ankle's
//! rest height above the foot's sole (the lowest skin point of the leg, `skin.rs`; without skin,
//! above the ankle's own rest height, so the foot keeps it). A body whose feet do not all rest
//! on one ground is settled first (`settle.rs`), and the feet stand where the settled body puts
//! them. The ground is the level plane at the lowest sole, or a terrain (`terrain.rs`): a foot
//! stands on the surface under it, turned to its normal; [`foot_target`] is where a foot goes,
//! the one place that reads the ground. On a course (`course.rs`) the gait is made along the
//! straight line and each foot mapped at its own distance, so a stance foot stays put through a
//! turn.
//!
//! Body height. Each leg allows the hip to be at most its reach above its foot target at the
//! target's horizontal distance; the body goes as high as every leg allows, never above the
//! settled rest height (over the terrain under the feet) and never lower than a few per cent of a leg's reach.
//! Reach is the leg's rest hip-ankle distance, or 98 % of its two bones when they are bent at
//! rest. So stance feet stay on the ground, neither floating nor sinking, and the body dips
//! where the feet are far apart.
//!
//! Legs. Each leg's two bones above its foot (thigh and shin; an upper arm and forearm; an
//! insect's femur and tibia) are solved by two-bone IK ([`crate::posing::two_bone_ik`]) from its
//! posed hip to its target, the knee bending in the plane and towards the side it bent at rest
//! (turned with the pelvis). The bones below the ankle keep their rest orientation in the world,
//! in stance and in swing: toes and paws stay level with the ground, and a lifted foot is all
//! above the ground (a foot pitched about its ankle in swing dips its heel or its toe below the
//! ground when the ankle is lifted less than the foot is long). An upright foot under a high
//! ankle (a cannon bone above a hoof, a hind paw's long foot) leans with the leg about its toe's
//! head instead, and folds back in swing ([`leaning_foot`]), its toe level: the thigh then
//! swings less. A leg without two such bones is left to the swing-based posing of `gait.rs`.

use crate::motion::course::Steering;
use crate::motion::roles::{Limb, Roles};
use crate::motion::settle::Settle;
use crate::motion::terrain::Terrain;
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
    /// An upright foot's toe (a hoof below a cannon bone, a paw below a hind foot) and the toe's
    /// rest head: the foot turns about it as the leg swings (`FOOT_TILT`), the toe staying level.
    pub toe: Option<(usize, Vec3)>,
    /// Rest hip, knee and ankle.
    pub hip: Vec3,
    pub knee: Vec3,
    pub ankle: Vec3,
    /// Where the ankle stands at rest once the body is settled (`settle.rs`), and its height
    /// above the ground it stands on ([`stand_on`]; until then above its own rest height).
    pub stand: Vec3,
    pub ankle_height: f32,
    /// How far the foot reads the ground behind and ahead of its ankle ([`footing`]): at least
    /// [`FOOTPRINT`] of the leg, and as far as its skin reaches (heel, toes; [`stand_on`]).
    pub print: (f32, f32),
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

/// The shorter bone of a leg's IK pair is at least this share of the longer one, or the next
/// pair down is taken ([`plan_leg`]).
const BALANCED_PAIR: f32 = 0.4;

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
    let (mut i, mut j) = if bones.len() >= i0 + 3 {
        (i0, i0 + 1)
    } else if i0 >= 1 {
        (i0 - 1, i0)
    } else if bones.len() == i0 + 2 {
        (i0, i0 + 1)
    } else {
        return None;
    };
    // A pair with one bone much shorter than the other (a horse's short shoulder blade above
    // its upper arm) swings the short one through half a turn as the leg reaches: the next pair
    // down takes its place when it is less lopsided.
    let span = |k: usize| match bones.get(k + 1) {
        Some(&next) => (hv(next) - hv(bones[k])).length(),
        None => (Vec3::from(tails[bones[k]]) - hv(bones[k])).length(),
    };
    let balance = |k: usize| span(k).min(span(k + 1)) / span(k).max(span(k + 1)).max(f32::MIN_POSITIVE);
    if balance(i) < BALANCED_PAIR && j + 1 < bones.len() && balance(j) > balance(i) {
        (i, j) = (j, j + 1);
    }
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
    // an upright foot (a cannon bone standing on its hoof, under a hock well off the ground)
    // turns about its toe's head
    let toe = match (foot, bones.get(j + 2)) {
        (Some(_), Some(&toe)) => {
            let down = hv(toe) - ankle;
            let upright = -down.z >= UPRIGHT * down.length() && down.length() > 1e-6 * roles.height;
            (upright && ankle.z - roles.ground >= HIGH_ANKLE * roles.height).then_some((toe, hv(toe)))
        }
        _ => None,
    };
    let print = FOOTPRINT * (l1 + l2);
    Some(PlantedLeg {
        upper,
        lower,
        foot,
        toe,
        hip,
        knee,
        ankle,
        stand: ankle,
        ankle_height: 0.0,
        print: (print, print),
        l1,
        l2,
        reach,
        pole,
    })
}

/// A foot is upright when its toe's head lies below its ankle within 45 degrees of straight down
/// (a cannon bone, a dog's hind foot) and its ankle stands this share of the height off the
/// ground or more (a hock, a horse's knee); a human foot is not, whose ball lies forward of its
/// ankle, or, in a rig whose toe joint sits under the ankle (CesiumMan's), whose ankle is low:
/// leaning about the ball, its heel would go into the ground.
const UPRIGHT: f32 = 0.7;
const HIGH_ANKLE: f32 = 0.15;

/// How much of a leg's swing about the hip (the angle of the hip-to-toe line, from its rest
/// angle) an upright foot takes, turning about its toe: all of it, so the cannon bone keeps its
/// rest angle to that line and the hip-to-ankle line turns as the hip-to-toe line does; the
/// thigh then swings less than a leg whose foot stays upright, and folds the hip's skin less.
const FOOT_TILT: f32 = 1.0;
/// How much of a swinging foot's lift an upright foot takes by folding back at the ankle (the
/// hock or the wrist flexing), the rest lifting the ankle: a leg that lifted its hoof by the
/// ankle alone folds the knee up and swings the thigh far forward (a horse's femur through 80
/// degrees in a gallop).
const FOOT_FOLD: f32 = 0.9;

/// Where a planted leg's ankle goes when its upright foot stands on its toe's head (the toe's
/// rest head carried as the ankle is to `ankle_at`): the foot leans with the leg from the posed
/// hip `hip` ([`FOOT_TILT`]) and, lifted `lift` in swing, folds back ([`FOOT_FOLD`]); and the
/// foot's world turn, after the turn `heading` that stands the rest foot on the ground (the
/// course's turn at its distance, then the ground's tilt). A leg with no upright foot:
/// `ankle_at` as it is, and that turn. `(fwd, right)`: the body's
/// straight-line axes.
pub(crate) fn leaning_foot(
    leg: &PlantedLeg,
    hip: Vec3,
    (ankle_at, lift): (Vec3, f32),
    (fwd, right): (Vec3, Vec3),
    heading: Quat,
) -> (Vec3, Quat) {
    let Some((_, toe)) = leg.toe else { return (ankle_at, heading) };
    let toe_at = ankle_at + heading * (toe - leg.ankle);
    let (fwd_now, right_now) = (heading * fwd, heading * right);
    let angle = |d: Vec3, fwd: Vec3| d.dot(fwd).atan2(-d.z);
    let length = (leg.ankle - toe).length().max(f32::MIN_POSITIVE);
    let fold = (1.0 - FOOT_FOLD * lift.max(0.0) / length).clamp(-1.0, 1.0).acos();
    let lean = FOOT_TILT * (angle(toe_at - hip, fwd_now) - angle(toe - leg.hip, fwd));
    let turn = Quat::from_axis_angle(right_now, lean - fold) * heading;
    (toe_at + turn * (leg.ankle - toe), turn)
}

/// Stand `legs` (of `limbs`, one each) on a level ground at height `ground`, the body settled
/// by `settle`: each ankle stands where the settled body carries it, at its rest height above
/// its leg's sole (`soles`, per leg; None: the ankle keeps its own rest height), and reads the
/// ground as far behind and ahead as its foot extends (`extents`, per leg, from
/// `skin::foot_extents`). Along `fwd`,
/// each leg stands as far ahead of its hip as the legs of its group do on average: a scan in
/// mid-stride (one front hoof ahead, the other behind) walks from a square stance, and a rig
/// standing square keeps its own.
pub(crate) fn stand_on(
    legs: &mut [PlantedLeg],
    limbs: &[Limb],
    soles: &[Option<f32>],
    extents: &[Option<(f32, f32)>],
    (ground, fwd): (f32, Vec3),
    settle: &Settle,
) {
    let ahead = |leg: &PlantedLeg| (leg.ankle - leg.hip).dot(fwd);
    let groups = limbs.iter().map(|l| l.group).max().map_or(0, |g| g + 1);
    let mut mean = vec![(0.0f32, 0usize); groups];
    for (leg, limb) in legs.iter().zip(limbs) {
        mean[limb.group].0 += ahead(leg);
        mean[limb.group].1 += 1;
    }
    for (((leg, limb), sole), extent) in legs.iter_mut().zip(limbs).zip(soles).zip(extents) {
        let (sum, count) = mean[limb.group];
        let square = leg.ankle + fwd * (sum / count.max(1) as f32 - ahead(leg));
        leg.stand = settle.apply(square);
        leg.ankle_height = match sole {
            Some(sole) => leg.ankle.z - sole,
            None => leg.ankle.z - ground,
        };
        if let Some((behind, ahead)) = extent {
            // a skin reaching further than the leg is long is not its foot (nor is one so far
            // out that the distance overflows)
            let most = FOOT_MOST * (leg.l1 + leg.l2);
            let fit = |r: f32| if r.is_finite() { r.min(most) } else { 0.0 };
            leg.print = (leg.print.0.max(fit(*behind)), leg.print.1.max(fit(*ahead)));
        }
    }
}

/// The ground a foot stands on: the terrain (`terrain.rs`; `level` is the level ground's
/// height) and the map from the straight-line gait to the world (`course.rs`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ground<'a> {
    pub terrain: &'a Terrain,
    pub level: f32,
    pub steering: Steering<'a>,
}

/// Where a foot is in its cycle, from [`foot_offset`]: its distance `ahead` of its standing
/// place (straight-line gait), its `lift` (`up`: the share of the full lift, sin π s in swing),
/// and in swing where it lifted off (`from`), where it lands (`to`, a stride on) and how far it
/// has gone between them (`eased`, 0 to 1; 0 in stance, where `from` = `to` = `ahead`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Step {
    pub ahead: f32,
    pub lift: f32,
    pub up: f32,
    pub from: f32,
    pub to: f32,
    pub eased: f32,
}

/// How far ahead and behind the ankle a foot reads the ground, as a share of the leg's two
/// bones (and half as far to each side): about a foot's length.
const FOOTPRINT: f32 = 0.25;
/// The furthest a foot's skin counts ahead of or behind its ankle ([`stand_on`]), as a share of
/// the leg's two bones.
const FOOT_MOST: f32 = 1.0;
/// How much further than its footprint a lifted foot clears the ground ahead and behind (a
/// biped's toes reach about 0.4 of its leg ahead of the ankle).
const SWING_CLEAR: f32 = 2.0;

/// The plane a foot stands on at distance `a` along `fwd` (straight-line gait) of `leg`'s
/// standing place: fitted (least squares) to the ground at 5 x 3 points over its footprint
/// (`leg.print` behind and ahead, [`FOOTPRINT`] / 2 to each side), then raised to clear the
/// ground at [`CLEAR_ALONG`] x 3 points over it (a foot across a step's edge rests on the edge,
/// not in it). Returns the world point under the ankle (on the plane) and the plane's unit
/// normal.
fn footing(leg: &PlantedLeg, ground: &Ground, a: f32, fwd: Vec3) -> (Vec3, Vec3) {
    let map = &ground.steering;
    let print = FOOTPRINT * (leg.l1 + leg.l2);
    let side = fwd.cross(Vec3::Z).normalize_or(Vec3::X);
    let centre = map.place(leg.stand + fwd * a);
    let heading = map.turn(map.distance(leg.stand + fwd * a)) * fwd;
    let right = heading.cross(Vec3::Z).normalize_or(side);
    // a sample as (along, across, height) about the centre, in the foot's heading, from its
    // share u of the way from heel to toe and v of the way across
    let sample = |u: f32, v: f32| {
        let along = -leg.print.0 + u * (leg.print.0 + leg.print.1);
        let p = map.place(leg.stand + fwd * (a + along) + side * (v * print));
        let d = p - centre;
        (d.dot(heading), d.dot(right), ground.terrain.height(p, ground.level))
    };
    let samples: [(f32, f32, f32); 15] =
        std::array::from_fn(|k| sample((k % 5) as f32 * 0.25, (k / 5) as f32 * 0.5 - 0.5));
    let n = samples.len() as f32;
    let mean = samples.iter().fold(Vec3::ZERO, |m, &(x, y, z)| m + Vec3::new(x, y, z)) / n;
    let (mut sxx, mut sxz, mut syy, mut syz) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for &(x, y, z) in &samples {
        let (x, y, z) = (x - mean.x, y - mean.y, z - mean.z);
        (sxx, sxz, syy, syz) = (sxx + x * x, sxz + x * z, syy + y * y, syz + y * z);
    }
    let (gx, gy) = (sxz / sxx.max(f32::MIN_POSITIVE), syz / syy.max(f32::MIN_POSITIVE));
    let plane = |x: f32, y: f32| mean.z + gx * (x - mean.x) + gy * (y - mean.y);
    let last = (CLEAR_ALONG - 1) as f32;
    let rise = (0..3 * CLEAR_ALONG)
        .map(|k| sample((k % CLEAR_ALONG) as f32 / last, (k / CLEAR_ALONG) as f32 * 0.5 - 0.5))
        .map(|(x, y, z)| z - plane(x, y))
        .fold(0.0f32, f32::max);
    let normal = (Vec3::Z - heading * gx - right * gy).normalize();
    (centre.with_z(plane(0.0, 0.0) + rise), normal)
}

/// How many points along a foot's footprint, heel to toe, its plane clears ([`footing`]): the
/// ground between two of them can rise above the plane by the plane's slope times their
/// spacing at most.
const CLEAR_ALONG: usize = 17;

/// Where `leg`'s ankle goes (the one place that reads the ground): its standing place moved
/// `step.ahead` along `fwd`, mapped to the world through the course at the foot's own distance,
/// at its ankle height above the ground it stands on ([`footing`]) along that ground's normal,
/// lifted by `step.lift`. In swing the ground under it is the higher of the footing there and
/// the blend from where it lifted off to where it lands, the normal the blend of those two, and
/// as it lifts, the ground [`SWING_CLEAR`] footprints ahead and behind.
/// Returns the target, the foot's heading turn (about +Z: the course's turn at the foot's
/// distance) and its tilt (+Z onto the normal).
pub(crate) fn foot_target(leg: &PlantedLeg, ground: &Ground, step: Step, fwd: Vec3) -> (Vec3, Quat, Quat) {
    let map = &ground.steering;
    let turn = map.turn(map.distance(leg.stand + fwd * step.ahead));
    let (mut under, mut normal) = footing(leg, ground, step.ahead, fwd);
    if step.eased > 0.0 {
        let ((a, na), (b, nb)) = (footing(leg, ground, step.from, fwd), footing(leg, ground, step.to, fwd));
        under.z = under.z.max(a.z + (b.z - a.z) * step.eased);
        normal = na.lerp(nb, step.eased).normalize_or(Vec3::Z);
    }
    if step.up > 0.0 {
        // lifted, the foot clears the ground further ahead and behind (its toes and heel)
        let reach = SWING_CLEAR * FOOTPRINT * (leg.l1 + leg.l2);
        let high = (0..=8)
            .map(|k| map.place(leg.stand + fwd * (step.ahead + reach * (k as f32 / 4.0 - 1.0))))
            .map(|p| ground.terrain.height(p, ground.level))
            .fold(f32::MIN, f32::max);
        under.z += (high - under.z).max(0.0) * step.up;
    }
    let tilt = Quat::from_rotation_arc(Vec3::Z, normal);
    let target = under + normal * leg.ankle_height + Vec3::Z * step.lift;
    (target, turn, tilt)
}

/// Where a foot's ankle is at leg phase `ph`, relative to its rest place, for a body that has
/// travelled `travel` along `fwd` (see the module doc and [`Step`]).
pub(crate) fn foot_offset(ph: f32, duty: f32, stride: f32, lift: f32, travel: f32) -> Step {
    let stance = ph < duty;
    let (eased, up) = if stance {
        (0.0, 0.0)
    } else {
        let s = (ph - duty) / (1.0 - duty);
        (0.5 - 0.5 * (PI * s).cos(), (PI * s).sin())
    };
    let ahead = stride * (0.5 * duty - ph + eased) + travel;
    let from = ahead - stride * eased;
    let to = if stance { ahead } else { from + stride };
    Step { ahead, lift: lift * up, up, from, to, eased }
}

/// A leg lowers the body by at most this fraction of its reach (in a run, and in a biped's
/// walk; see `gait.rs`' `WALK_LEVEL`); a foot further out is left short of its target (it lifts
/// off a little early or lands a little late), as a body sunk further would fold a bent leg's
/// knee or elbow into the ground.
pub(crate) const MAX_DROP: f32 = 0.06;

/// How far the body may go up (negative: down) so that every leg reaches its target, each leg
/// lowering it by at most `most` of its reach (at most [`MAX_DROP`]): the legs with their
/// posed hips (the body settled and carried forward) and their ankles' targets. Never above 0
/// (the settled rest height).
pub(crate) fn body_drop(legs: &[(&PlantedLeg, Vec3, Vec3)], most: f32) -> f32 {
    legs.iter()
        .map(|(leg, hip, target)| {
            let mut flat = *target - *hip;
            flat.z = 0.0;
            let h2 = leg.reach * leg.reach - flat.length_squared();
            let allowed = if h2 > 0.0 { target.z + h2.sqrt() } else { target.z };
            (allowed - hip.z).max(-most * leg.reach)
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
            let s = foot_offset(ph, duty, stride, 0.1, stride * k / fpc);
            (s.ahead, s.lift)
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

    fn test_leg() -> PlantedLeg {
        PlantedLeg {
            upper: 0,
            lower: 1,
            foot: None,
            hip: Vec3::new(0.0, 0.0, 1.0),
            knee: Vec3::new(0.0, 0.0, 0.5),
            ankle: Vec3::ZERO,
            toe: None,
            stand: Vec3::ZERO,
            ankle_height: 0.0,
            print: (0.25, 0.25),
            l1: 0.5,
            l2: 0.5,
            reach: 1.0,
            pole: Vec3::X,
        }
    }

    #[test]
    fn a_foot_across_a_steps_edge_rests_on_the_edge_not_in_it() {
        // a step 0.15 high whose edge runs across +X, 0.3 ahead of the ankle, on 0.01 cells
        let (cell, nx, ny, edge) = (0.01f32, 201usize, 41usize, 0.3f32);
        let heights: Vec<f32> =
            (0..nx * ny).map(|i| if (i % nx) as f32 * cell - 1.0 > edge { 0.15 } else { 0.0 }).collect();
        let terrain = Terrain::field([-1.0, -0.2], cell, (nx, ny), &heights).unwrap();
        let ground = Ground {
            terrain: &terrain,
            level: 0.0,
            steering: Steering { course: None, origin: Vec3::ZERO, fwd: Vec3::X },
        };
        // the foot's toes reach 0.4 ahead of its ankle, its heel 0.25 behind
        let mut leg = test_leg();
        leg.print = (0.25, 0.4);
        let (under, normal) = footing(&leg, &ground, 0.0, Vec3::X);
        let sole = |x: f32| under.z - normal.x * x / normal.z;
        let worst = (0..=650)
            .map(|k| -0.25 + k as f32 * 0.001)
            .map(|x| terrain.height(Vec3::new(x, 0.0, 0.0), 0.0) - sole(x))
            .fold(f32::MIN, f32::max);
        // the ground rises above the sole by at most the sole's slope over a sample spacing
        assert!(worst <= 0.01, "the step's edge is {worst} above the sole");
        assert!(normal.x < 0.0 && under.z > 0.0, "the foot tilts up onto the step: {normal} {under}");
    }

    #[test]
    fn the_body_drops_just_enough_for_a_far_foot() {
        let leg = test_leg();
        let hip = leg.hip;
        assert_eq!(body_drop(&[(&leg, hip, Vec3::ZERO)], MAX_DROP), 0.0);
        let drop = body_drop(&[(&leg, hip, Vec3::new(0.3, 0.0, 0.0))], MAX_DROP);
        assert!((drop - ((1.0f32 - 0.09).sqrt() - 1.0)).abs() < 1e-5, "{drop}");
        // A foot far out lowers the body by at most MAX_DROP of the reach.
        let drop = body_drop(&[(&leg, hip, Vec3::new(0.6, 0.0, 0.0))], MAX_DROP);
        assert!((drop + MAX_DROP).abs() < 1e-6, "{drop}");
        // A hip carried over the foot needs no drop.
        assert!(body_drop(&[(&leg, hip + Vec3::new(0.3, 0.0, 0.0), Vec3::new(0.3, 0.0, 0.0))], MAX_DROP).abs() < 1e-6);
    }
}
