//! Planting the legs of a walk or run at one moment of the cycle (see `footfalls` for the
//! method): each stance ankle fixed in the world, the body as high as every leg reaches, each
//! leg's two bones by IK from the posed hip and its foot and toe turned onto the ground.

use super::clip::Cadence;
use super::footfalls::{body_drop, foot_offset, foot_target, leaning_foot, leg_turns, Ground, PlantedLeg};
use super::pose::{posed_frames, to_wxyz, Poser};
use glam::{Quat, Vec3};

/// What planting the legs reads besides the pose: the rest heads, the hierarchy with riding
/// feet on their legs, the locations that move other trees' roots with the settled body, the
/// forward axis and the ground's height.
pub(super) struct Planting<'a> {
    pub(super) heads: &'a [[f32; 3]],
    pub(super) carried: &'a [i32],
    pub(super) locations: &'a [[f32; 3]],
    pub(super) fwd: Vec3,
    pub(super) ground: &'a Ground<'a>,
}

/// Plant the legs at cycle fraction `phi` (see `footfalls`): each ankle's target, the body's
/// offset (`base`: forward travel and the settle carried along the course, then up by the
/// terrain's mean height under the feet and down as far as the legs need), then each leg's two
/// bones by IK and its foot on the ground. Returns the root offset.
pub(super) fn plant_legs(
    poser: &mut Poser,
    ctx: &Planting,
    legs: &[PlantedLeg],
    phases: &[f32],
    c: &Cadence,
    phi: f32,
    (base, travel): (Vec3, f32),
) -> Vec3 {
    let fk = |poser: &Poser, offset: Vec3| {
        let local: Vec<[f32; 4]> = poser.q.iter().map(|&q| to_wxyz(q)).collect();
        posed_frames(ctx.heads, ctx.carried, &poser.rest, &local, ctx.locations, offset.to_array())
    };
    let right = ctx.fwd.cross(Vec3::Z).normalize();
    let aims: Vec<_> = legs
        .iter()
        .zip(phases)
        .map(|(leg, o)| {
            let step = foot_offset((phi + o).fract(), c.duty, c.stride, c.foot_lift, travel);
            (step, foot_target(leg, ctx.ground, step, ctx.fwd))
        })
        .collect();
    let ground = ctx.ground;
    let rise = aims.iter().map(|(_, (at, ..))| ground.terrain.height(*at, ground.level) - ground.level).sum::<f32>()
        / aims.len().max(1) as f32;
    let base = base + Vec3::Z * rise;
    let (_, hips0) = fk(poser, base);
    // each ankle's target, its foot's world turn and its toe's (an upright foot's toe stands on
    // the ground, turned to it)
    let (targets, leans): (Vec<Vec3>, Vec<(Quat, Quat)>) = legs
        .iter()
        .zip(&aims)
        .map(|(leg, (step, (at, heading, tilt)))| {
            let stand = *tilt * *heading;
            let (at, turn) = leaning_foot(leg, hips0[leg.upper], (*at, step.lift), (ctx.fwd, right), stand);
            (at, (turn, stand))
        })
        .unzip();
    let reach: Vec<_> = legs.iter().zip(&targets).map(|(leg, &t)| (leg, hips0[leg.upper], t)).collect();
    let offset = base + Vec3::Z * body_drop(&reach, c.drop);
    let turn_to = |poser: &mut Poser, b: usize, world: Quat, parent_turn: Quat| {
        let rq = poser.rest[b];
        poser.q[b] = (rq.inverse() * parent_turn.inverse() * world * rq).normalize();
        poser.touched[b] = true;
    };
    let parent_turn = |turns: &[Quat], b: usize| match ctx.carried[b] {
        p if p >= 0 => turns[p as usize],
        _ => Quat::IDENTITY,
    };
    for ((leg, &target), &(lean, toe_turn)) in legs.iter().zip(&targets).zip(&leans) {
        let (turns, posed) = fk(poser, offset);
        let pelvis = parent_turn(&turns, leg.upper);
        let (upper, lower) = leg_turns(leg, posed[leg.upper], target, pelvis);
        turn_to(poser, leg.upper, upper, pelvis);
        let (turns, _) = fk(poser, offset);
        turn_to(poser, leg.lower, lower, parent_turn(&turns, leg.lower));
        if let Some(foot) = leg.foot {
            let (turns, _) = fk(poser, offset);
            turn_to(poser, foot, lean, parent_turn(&turns, foot));
        }
        if let Some((toe, _)) = leg.toe {
            let (turns, _) = fk(poser, offset);
            turn_to(poser, toe, toe_turn, parent_turn(&turns, toe));
        }
    }
    offset
}
