//! What a character's skin says about its rest pose, for the gaits (a stage of `gait.rs`):
//! where each foot's sole is, how wide the body is beside a hanging arm, and how thick the arm.
//!
//! Inputs
//!   points  #P by 3 skin points at rest (a mesh's vertices, any subset), the skeleton's space
//!           and unit, +Z up
//!   bones   #P index of the bone that weighs most on each point (-1: none)
//! Both empty: no skin. Then nothing is settled (each foot keeps its own rest height) and the
//! body beside an arm is read from the bones.
//!
//! Method.
//! - A leg's sole is the lowest skin point of the bones of the leg and of every bone below them:
//!   the hoof under a bone that ends at the fetlock, the paw under a wrist, the mesh under a bone
//!   that stops short of the ground.
//! - A hanging arm's clearance ([`hang_angle`]) is the least angle from straight down at which
//!   the arm, as thick as the skin around its forearm and hand, passes outside the torso's skin
//!   (the spine's and neck's points) at every height its forearm and hand reach, seen along the
//!   body's sides; an arm so long that its hand would reach the ground bends its elbow forward
//!   instead ([`elbow_clearance`]).
//!
//! Known limits: the owner is one bone per point; a leg that owns no skin point has no sole.

use crate::error::{Error, Result};
use crate::motion::roles::Roles;
use glam::{Quat, Vec3};

/// Skin points and the bone that weighs most on each (see the module doc).
#[derive(Debug, Clone, Copy, Default)]
pub struct Skin<'a> {
    pub points: &'a [[f32; 3]],
    pub bones: &'a [i32],
}

impl Skin<'_> {
    /// No skin: the motion reads the bones alone.
    pub const NONE: Skin<'static> = Skin { points: &[], bones: &[] };

    /// An error naming the first bad entry: lengths that differ, a bone index out of
    /// `0..bone_count` (or -1), a point that is not finite.
    pub fn check(&self, bone_count: usize) -> Result<()> {
        if self.points.len() != self.bones.len() {
            return Err(Error::Shape(format!(
                "{} skin points and {} skin bones: one bone per point",
                self.points.len(),
                self.bones.len()
            )));
        }
        if let Some(i) = self.bones.iter().position(|&b| b < -1 || b >= bone_count as i32) {
            return Err(Error::Shape(format!(
                "skin_bones[{i}] is {}: a bone index below {bone_count}, or -1",
                self.bones[i]
            )));
        }
        let bad = self.points.iter().filter(|p| !p.iter().all(|c| c.is_finite())).count();
        if bad > 0 {
            return Err(Error::NonFinite { what: "skin point", count: bad });
        }
        Ok(())
    }

    /// The points owned by any bone for which `owned` is true.
    fn owned_by<'s>(&'s self, owned: &'s [bool]) -> impl Iterator<Item = Vec3> + 's {
        self.points
            .iter()
            .zip(self.bones)
            .filter(move |(_, &b)| b >= 0 && owned.get(b as usize).copied().unwrap_or(false))
            .map(|(p, _)| Vec3::from(*p))
    }
}

/// Per bone: whether it is one of `tops` or below one in `parents`.
fn below(tops: impl IntoIterator<Item = usize>, parents: &[i32]) -> Vec<bool> {
    let n = parents.len();
    let mut mark = vec![false; n];
    for b in tops {
        if b < n {
            mark[b] = true;
        }
    }
    // parents before children is not promised: walk up from each bone
    (0..n)
        .map(|b| {
            let mut cur = b as i32;
            let mut steps = 0;
            while cur >= 0 && steps <= n {
                if mark[cur as usize] {
                    return true;
                }
                cur = parents[cur as usize];
                steps += 1;
            }
            false
        })
        .collect()
}

/// Per leg of `roles`, the height (z) of its sole: the lowest skin point of its bones and the
/// bones below them in `parents`; None when the leg owns no skin point.
pub(crate) fn leg_soles(skin: &Skin, roles: &Roles, parents: &[i32]) -> Vec<Option<f32>> {
    roles
        .legs
        .iter()
        .map(|leg| {
            let owned = below(leg.bones.iter().copied(), parents);
            skin.owned_by(&owned).map(|p| p.z).reduce(f32::min)
        })
        .collect()
}

/// Per leg of `roles` with a sole (`soles`, [`leg_soles`]), its rest ankle in `ankles`: how
/// far its foot's underside reaches behind and ahead of the ankle along `fwd` (heel, toes), read
/// from the leg's skin points in the lower half between its sole and its ankle; None without
/// such points.
pub(crate) fn foot_extents(
    skin: &Skin,
    roles: &Roles,
    parents: &[i32],
    soles: &[Option<f32>],
    (ankles, fwd): (&[Vec3], Vec3),
) -> Vec<Option<(f32, f32)>> {
    roles
        .legs
        .iter()
        .zip(soles.iter().zip(ankles))
        .map(|(leg, (sole, ankle))| {
            let (sole, ankle) = ((*sole)?, *ankle);
            let low = sole + 0.5 * (ankle.z - sole).max(0.0);
            let owned = below(leg.bones.iter().copied(), parents);
            let along = skin.owned_by(&owned).filter(|p| p.z <= low).map(|p| (p - ankle).dot(fwd));
            along.fold(None, |r: Option<(f32, f32)>, d| {
                let (behind, ahead) = r.unwrap_or((f32::MIN, f32::MIN));
                Some((behind.max(-d), ahead.max(d)))
            })
        })
        .collect()
}

/// The torso beside the arms: skin points of the spine and neck bones (or, without skin, the
/// ends of those bones, each standing for a ball of `BONE_BODY` of the height). A hand hangs
/// beside the thigh, as a person's does, not out of its way.
pub(crate) struct Body {
    points: Vec<Vec3>,
    /// How far beyond a point the body reaches (0 for skin points).
    pad: f32,
}

/// Without skin, a bone end stands for a ball this wide (fraction of the height).
const BONE_BODY: f32 = 0.06;

impl Body {
    pub(crate) fn of(skin: &Skin, roles: &Roles, heads: &[[f32; 3]], tails: &[[f32; 3]]) -> Body {
        // the spine's and neck's own points, not the head's, arms' or legs' below them
        let mut own = vec![false; heads.len()];
        for &b in roles.spine.iter().chain(&roles.neck) {
            own[b] = true;
        }
        let points: Vec<Vec3> = skin.owned_by(&own).collect();
        if !points.is_empty() {
            return Body { points, pad: 0.0 };
        }
        let ends = own.iter().enumerate().filter(|(_, &o)| o).flat_map(|(b, _)| [heads[b], tails[b]]);
        Body { points: ends.map(Vec3::from).collect(), pad: BONE_BODY * roles.height }
    }
}

/// The thickness of an arm: the distance from its bones `chain` (consecutive points: shoulder,
/// elbow, wrist, fingertips) within which three quarters of the skin points owned by `owners`
/// (the forearm and hand) lie; 0 without such points.
pub(crate) fn arm_radius(skin: &Skin, owners: &[bool], chain: &[Vec3]) -> f32 {
    let mut d: Vec<f32> = skin
        .owned_by(owners)
        .map(|p| {
            chain
                .windows(2)
                .map(|s| {
                    let (a, ab) = (s[0], s[1] - s[0]);
                    let t = ((p - a).dot(ab) / ab.length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
                    (p - (a + t * ab)).length()
                })
                .fold(f32::INFINITY, f32::min)
        })
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    let k = (d.len() * 3 / 4).min(d.len() - 1);
    *d.select_nth_unstable_by(k, |a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal)).1
}

/// How far from `from` the skin of the bones `tops`, and of every bone below them in `parents`,
/// reaches: the farthest such point (a hand's fingers, a prop it holds); 0 without such points.
pub(crate) fn skin_reach(skin: &Skin, tops: &[usize], parents: &[i32], from: Vec3) -> f32 {
    let owned = below(tops.iter().copied(), parents);
    skin.owned_by(&owned).map(|p| (p - from).length()).fold(0.0, f32::max)
}

/// How an arm hangs: from its shoulder, its elbow `upper` away, reaching `reach` to the
/// fingertips (or to what the hand holds), `radius` thick.
pub(crate) struct Hanging {
    pub shoulder: Vec3,
    pub upper: f32,
    pub reach: f32,
    pub radius: f32,
    /// Unit direction out of the body on the arm's side (horizontal).
    pub out: Vec3,
}

/// Least and most angles from straight down a hanging arm takes (radians): arms at the sides
/// hang a little out; a body too wide for the most is left at it.
pub(crate) const HANG_MIN: f32 = 8.0 * std::f32::consts::PI / 180.0;
pub(crate) const HANG_MAX: f32 = 40.0 * std::f32::consts::PI / 180.0;

/// The least angle from straight down (radians, [`HANG_MIN`] to [`HANG_MAX`]) at which the arm
/// `arm` hangs clear of `body`, its forearm bent forward at the elbow by `bend(angle)` (radians;
/// a long arm bends further to keep its hand off the ground): at each of 12 points from half its
/// reach (about the elbow) to its end (the upper arm meets the torso at the armpit), the arm's
/// outer reach less its radius lies beyond the body's widest point on that side within `slab`
/// above or below it and within the arm's thickness plus `slab` ahead or behind it, by
/// `margin`. `mid` is a point on the body's middle plane, `(up, fwd)` the body's axes.
pub(crate) fn hang_angle(
    body: &Body,
    arm: &Hanging,
    mid: Vec3,
    (up, fwd): (Vec3, Vec3),
    (slab, margin): (f32, f32),
    bend: &dyn Fn(f32) -> f32,
) -> f32 {
    let side = |p: Vec3| (p - mid).dot(arm.out);
    let right = fwd.cross(up);
    let step = 1f32.to_radians();
    let mut a = HANG_MIN;
    while a < HANG_MAX {
        let dir = -up * a.cos() + arm.out * a.sin();
        let elbow = arm.shoulder + dir * arm.upper;
        let fore = Quat::from_axis_angle(right, bend(a)) * dir;
        let clear = (0..12).all(|k| {
            let along = arm.reach * (0.5 + 0.5 * k as f32 / 11.0);
            let q = if along <= arm.upper { arm.shoulder + dir * along } else { elbow + fore * (along - arm.upper) };
            let wide = body
                .points
                .iter()
                .filter(|p| (p.z - q.z).abs() <= slab && (**p - q).dot(fwd).abs() <= arm.radius + slab)
                .map(|&p| side(p) + body.pad)
                .fold(f32::NEG_INFINITY, f32::max);
            side(q) - arm.radius >= wide + margin
        });
        if clear {
            return a;
        }
        a += step;
    }
    HANG_MAX
}

/// How far (radians) an elbow bends its forearm forward so that the hand of an arm hanging
/// `angle` out from straight down keeps its lowest point at `lowest` or above: the shoulder at
/// height `shoulder_z`, the upper arm `upper` long, the forearm and hand reaching `fore` from the
/// elbow (a long-armed character's hands would drag on the ground). 0 when the straight arm
/// clears it; at most a right angle.
pub(crate) fn elbow_clearance(shoulder_z: f32, angle: f32, (upper, fore): (f32, f32), lowest: f32) -> f32 {
    let elbow_z = shoulder_z - upper * angle.cos();
    let drop = fore * angle.cos();
    if drop <= f32::MIN_POSITIVE || elbow_z - drop >= lowest {
        return 0.0;
    }
    ((elbow_z - lowest) / drop).clamp(0.0, 1.0).acos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wider_body_lifts_the_arm_further_out() {
        let (up, fwd) = (Vec3::Z, Vec3::NEG_Y);
        let arm = Hanging { shoulder: Vec3::new(0.2, 0.0, 1.4), upper: 0.3, reach: 0.7, radius: 0.04, out: Vec3::X };
        let body_of = |w: f32| {
            let mut points = Vec::new();
            for k in 0..=40 {
                let z = 0.7 + 0.02 * k as f32;
                for j in 0..16 {
                    let t = j as f32 / 16.0 * std::f32::consts::TAU;
                    points.push(Vec3::new(w * t.cos(), 0.1 * t.sin(), z));
                }
            }
            Body { points, pad: 0.0 }
        };
        let straight = |_: f32| 0.0;
        let narrow = hang_angle(&body_of(0.12), &arm, Vec3::ZERO, (up, fwd), (0.03, 0.01), &straight);
        let wide = hang_angle(&body_of(0.25), &arm, Vec3::ZERO, (up, fwd), (0.03, 0.01), &straight);
        assert_eq!(narrow, HANG_MIN, "a slim body: the least angle");
        assert!(wide > narrow + 5f32.to_radians() && wide < HANG_MAX, "{wide}");
        // the arm at that angle is clear of the wide body at its hand
        let hand = arm.shoulder + (-up * wide.cos() + Vec3::X * wide.sin()) * arm.reach;
        assert!(hand.x - arm.radius >= 0.25 + 0.01 - 1e-4, "{hand}");
    }

    #[test]
    fn a_forearm_bent_forward_clears_a_belly_the_straight_arm_passes_behind() {
        let (up, fwd) = (Vec3::Z, Vec3::NEG_Y);
        let arm = Hanging { shoulder: Vec3::new(0.2, 0.0, 1.4), upper: 0.3, reach: 0.7, radius: 0.04, out: Vec3::X };
        // a slim torso, and a belly ahead of it (0.15 to 0.3 forward, 0.32 to each side) at the
        // height of the elbow and below
        let mut points = Vec::new();
        for k in 0..=40 {
            let z = 0.7 + 0.02 * k as f32;
            for j in 0..16 {
                let t = j as f32 / 16.0 * std::f32::consts::TAU;
                points.push(Vec3::new(0.12 * t.cos(), 0.1 * t.sin(), z));
                if (0.85..=1.1).contains(&z) {
                    points.push(Vec3::new(0.32 * t.cos(), -0.225 + 0.075 * t.sin(), z));
                }
            }
        }
        let body = Body { points, pad: 0.0 };
        let angle = |bend: f32| hang_angle(&body, &arm, Vec3::ZERO, (up, fwd), (0.03, 0.01), &|_| bend);
        let (straight, bent) = (angle(0.0), angle(70f32.to_radians()));
        assert_eq!(straight, HANG_MIN, "the straight arm hangs behind the belly");
        assert!(bent > straight + 5f32.to_radians(), "{bent}");
        // at that angle the bent forearm's end is beside the belly, not in it
        let dir = -up * bent.cos() + Vec3::X * bent.sin();
        let fore = Quat::from_axis_angle(fwd.cross(up), 70f32.to_radians()) * dir;
        let end = arm.shoulder + dir * arm.upper + fore * (arm.reach - arm.upper);
        assert!(end.y < -0.15 && end.x - arm.radius >= 0.32, "{end}");
    }

    #[test]
    fn a_prop_held_in_the_hand_and_the_fingers_count_in_the_hands_reach() {
        // bones: 0 upper arm, 1 forearm, 2 hand, 3 finger (child of the hand), 4 spine
        let parents = [4, 0, 1, 2, -1];
        let points = [[0.0, 0.0, 0.0], [0.0, -0.9, 0.0], [0.0, 0.0, -0.5], [3.0, 0.0, 0.0]];
        let skin = Skin { points: &points, bones: &[1, 2, 3, 4] };
        let from = Vec3::ZERO;
        // the forearm and below: the prop 0.9 away (the hand's), the finger's point 0.5; not the spine's
        assert_eq!(skin_reach(&skin, &[1], &parents, from), 0.9);
        assert_eq!(skin_reach(&skin, &[3], &parents, from), 0.5);
        assert_eq!(skin_reach(&Skin::NONE, &[1], &parents, from), 0.0);
    }

    #[test]
    fn a_long_arm_bends_its_elbow_to_keep_the_hand_off_the_ground() {
        // shoulder 1.0 up, upper arm 0.4, forearm and hand 0.5: hanging straight down, the hand
        // reaches 0.1; kept at 0.3 or above, the forearm turns up until its end is there
        let bend = elbow_clearance(1.0, 0.0, (0.4, 0.5), 0.3);
        assert!((0.6 - 0.5 * bend.cos() - 0.3).abs() < 1e-5, "{bend}");
        assert_eq!(elbow_clearance(1.0, 0.0, (0.4, 0.5), 0.05), 0.0, "a hand clear of the ground");
        // an elbow at the ground itself: a right angle, no more
        assert_eq!(elbow_clearance(1.0, 0.0, (1.0, 0.5), 0.3), std::f32::consts::FRAC_PI_2);
        // hanging out, the same arm reaches less far down and bends less
        assert!(elbow_clearance(1.0, 0.5, (0.4, 0.5), 0.3) < bend);
    }
}
