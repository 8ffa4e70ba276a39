//! The head shake: the neck and head turn about the up axis, a sine of `cycles` periods over
//! `duration` seconds with amplitude `amplitude` (radians), eased in and out over the first and
//! last 15 % (smoothstep); half the turn shared by the neck bones, the rest on the head (all of
//! it without a neck); head extras (jaw, ears) swing back by 0.35 of it a radian later, about
//! forward for an upright one, else about up. The root stays.

use super::clip::{frame_count, Clip, GaitParams};
use super::pose::{new_poser, to_wxyz};
use crate::error::Result;
use crate::motion::roles::Roles;
use crate::skeleton::Skeleton;
use glam::{Quat, Vec3};
use std::f32::consts::TAU;

pub(super) fn head_shake(skeleton: &Skeleton, rest: &[[f32; 9]], roles: &Roles, p: &GaitParams) -> Result<Clip> {
    let Skeleton { heads, tails, .. } = *skeleton;
    let n = heads.len();
    let frames = frame_count(p.duration * p.fps, 2.0)?;
    let up = Vec3::from(roles.up);
    let fwd = Vec3::from(roles.forward);
    let mut poser = new_poser(rest);
    let mut rotations = Vec::with_capacity(frames * n);
    let neck_share = if roles.neck.is_empty() { 0.0 } else { 0.5 / roles.neck.len() as f32 };
    let head_share = if roles.neck.is_empty() { 1.0 } else { 0.5 };
    for k in 0..frames {
        poser.q.fill(Quat::IDENTITY);
        let u = k as f32 / (frames - 1) as f32;
        let env = smoothstep(0.0, 0.15, u) * smoothstep(0.0, 0.15, 1.0 - u);
        let yaw = p.amplitude * env * (TAU * p.cycles * u).sin();
        for &b in &roles.neck {
            poser.rotate(b, up, yaw * neck_share);
        }
        poser.rotate(roles.head, up, yaw * head_share);
        let lag = 0.35 * p.amplitude * env * (TAU * p.cycles * u - 1.0).sin();
        for &b in &roles.head_extras {
            let d = (Vec3::from(tails[b]) - Vec3::from(heads[b])).normalize_or_zero();
            let axis = if d.dot(up).abs() > 0.7 { fwd } else { up };
            poser.rotate(b, axis, -lag);
        }
        rotations.extend(poser.q.iter().map(|&q| to_wxyz(q)));
    }
    let animated = (0..n).filter(|&b| poser.touched[b]).collect();
    Ok(Clip {
        frames,
        bone_count: n,
        rotations,
        root_offset: vec![[0.0; 3]; frames],
        animated,
        locations: vec![[0.0; 3]; frames * n],
        located: Vec::new(),
        moves_root: false,
        frames_per_cycle: (frames - 1) as f32 / p.cycles,
    })
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}
