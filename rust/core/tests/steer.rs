//! Walks steered along a course and over a terrain (`motion::steered_clip`), checked through
//! forward kinematics (`motion::posed_points`): stance feet stay put in the world through a
//! turn and stand on a slope, the body turns with the path and climbs the slope, in place
//! with a path is an error.

mod common;

use common::rigs::{biped, rest_of, spot, Rig};
use glam::{Quat, Vec3};
use miniskeleton_core::motion::{
    detect_roles, posed_points, steered_clip, Clip, Course, GaitParams, Motion, Roles, Skeleton, Skin, Steer, Terrain,
};
use std::f32::consts::PI;

/// A rig walked with `steer`: heads, tails, parents, rest, roles, clip.
type Steered = (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<i32>, Vec<[f32; 9]>, Roles, Clip);

fn walk((names, h, t, p): Rig, motion: Motion, steer: &Steer) -> Steered {
    let rest = rest_of(&h, &t);
    let roles = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    let params = GaitParams { motion, cycles: 4.0, ..Default::default() };
    let clip = steered_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &roles, (&params, steer), &Skin::NONE).unwrap();
    (h, t, p, rest, roles, clip)
}

/// Posed heads of every frame.
fn heads_over(s: &Steered) -> Vec<Vec<[f32; 3]>> {
    let (h, t, p, rest, _, clip) = s;
    let n = clip.bone_count;
    (0..clip.frames)
        .map(|f| {
            let (rot, loc) = (&clip.rotations[f * n..(f + 1) * n], &clip.locations[f * n..(f + 1) * n]);
            posed_points(h, t, p, rest, rot, loc, clip.root_offset[f]).0
        })
        .collect()
}

/// A half circle of radius `r` turning left from `start`, heading along `fwd`.
fn half_circle(start: Vec3, fwd: Vec3, r: f32) -> Vec<[f32; 3]> {
    let left = Vec3::Z.cross(fwd);
    let centre = start + left * r;
    (0..=200)
        .map(|i| i as f32 * PI / 200.0)
        .map(|a| (centre - left * (r * a.cos()) + fwd * (r * a.sin())).to_array())
        .collect()
}

/// Each foot's ankle (its last bone's head) per frame: (frames, legs).
fn ankles(s: &Steered, heads: &[Vec<[f32; 3]>]) -> Vec<Vec<Vec3>> {
    let roles = &s.4;
    heads.iter().map(|f| roles.legs.iter().map(|l| Vec3::from(f[*l.bones.last().unwrap()])).collect()).collect()
}

#[test]
fn stance_feet_stay_put_through_a_turn_and_the_body_heads_along_the_path() {
    for skel in [biped(), spot()] {
        let (names, h, t, p) = skel.clone();
        let roles = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
        let fwd = Vec3::from(roles.forward).with_z(0.0).normalize();
        let root = Vec3::from(h[roles.root]);
        let r = 2.0 * roles.height;
        let course = Course::new(&half_circle(root, fwd, r)).unwrap();
        let s = walk(skel, Motion::Walk, &Steer { course: Some(course), terrain: Terrain::LEVEL });
        let heads = heads_over(&s);
        let feet = ankles(&s, &heads);
        let l = s.4.leg_length;
        let clip = &s.5;
        assert!(clip.frames as f32 > 3.0 * clip.frames_per_cycle, "the clip covers the half circle");
        // the root ends half way round: across the circle's diameter from its start
        let end = Vec3::from(heads[clip.frames - 1][roles.root]);
        let across = (end - root).with_z(0.0).length();
        assert!((across - 2.0 * r).abs() < 0.1 * r, "{across} vs {}", 2.0 * r);
        // a foot that stands (lowest, frame after frame) does not slide
        for leg in 0..s.4.legs.len() {
            let low = feet.iter().map(|f| f[leg].z).fold(f32::MAX, f32::min);
            let mut worst = 0.0f32;
            for w in feet.windows(2) {
                if w[0][leg].z < low + 1e-3 * l && w[1][leg].z < low + 1e-3 * l {
                    worst = worst.max((w[1][leg] - w[0][leg]).length());
                }
            }
            assert!(worst < 0.01 * l, "leg {leg} slides {worst} in a frame (leg {l})");
        }
        // the root's turn follows the path's tangent where the body is
        let rot = |f: usize| {
            let n = clip.bone_count;
            let r = clip.rotations[f * n + roles.root];
            let rq = Quat::from_mat3(&glam::Mat3::from_cols_array(&s.3[roles.root]).transpose());
            rq * Quat::from_xyzw(r[1], r[2], r[3], r[0]) * rq.inverse()
        };
        for f in (0..clip.frames).step_by(5) {
            let heading = (rot(f) * fwd).with_z(0.0).normalize();
            let at = Vec3::from(heads[f][roles.root]).with_z(0.0);
            let centre = (root + Vec3::Z.cross(fwd) * r).with_z(0.0);
            let tangent = Vec3::Z.cross(at - centre).normalize();
            let off = heading.angle_between(tangent).to_degrees();
            assert!(off < 10.0, "frame {f}: heading {off} degrees off the path");
        }
    }
}

#[test]
fn feet_stand_on_a_slope_and_the_body_climbs_it() {
    let slope = 15f32.to_radians().tan();
    for skel in [biped(), spot()] {
        let (names, h, t, p) = skel.clone();
        let roles = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
        let fwd = Vec3::from(roles.forward).with_z(0.0).normalize();
        let root = Vec3::from(h[roles.root]);
        // a slope rising along forward from just ahead of the front feet
        let ahead = roles.height;
        let (nx, cell) = (120, roles.height / 10.0);
        let origin = root.with_z(0.0) - Vec3::new(1.0, 1.0, 0.0) * (nx as f32 * cell / 2.0);
        let ground = |q: Vec3| roles.ground + slope * ((q - root).dot(fwd) - ahead).max(0.0);
        let heights: Vec<f32> =
            (0..nx * nx).map(|i| ground(origin + Vec3::new((i % nx) as f32, (i / nx) as f32, 0.0) * cell)).collect();
        let terrain = Terrain::field([origin.x, origin.y], cell, (nx, nx), &heights).unwrap();
        let s = walk(skel, Motion::Walk, &Steer { course: None, terrain });
        let heads = heads_over(&s);
        let feet = ankles(&s, &heads);
        let l = s.4.leg_length;
        let rest_height: Vec<f32> =
            s.4.legs.iter().map(|leg| h[*leg.bones.last().unwrap()][2] - roles.ground).collect();
        // no ankle sinks below its height above the slope; some foot stands on it every frame
        for (f, ankle) in feet.iter().enumerate() {
            let above: Vec<f32> = ankle.iter().zip(&rest_height).map(|(a, r)| a.z - ground(*a) - r).collect();
            let least = above.iter().copied().fold(f32::MAX, f32::min);
            assert!(least > -0.03 * l && least < 0.05 * l, "frame {f}: feet {above:?} above the slope (leg {l})");
        }
        // the body climbs with it
        let last = s.5.frames - 1;
        let climbed = heads[last][roles.root][2] - root.z;
        let under = ground(Vec3::from(heads[last][roles.root])) - roles.ground;
        assert!(under > 0.2 * l && (climbed - under).abs() < 0.25 * under.max(l), "climbed {climbed}, ground {under}");
    }
}

#[test]
fn in_place_with_a_path_is_an_error() {
    let (names, h, t, p) = biped();
    let rest = rest_of(&h, &t);
    let roles = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    let steer = Steer { course: Some(Course::new(&[[0.0; 3], [5.0, 0.0, 0.0]]).unwrap()), terrain: Terrain::LEVEL };
    let params = GaitParams { root_motion: false, ..Default::default() };
    let err = steered_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &roles, (&params, &steer), &Skin::NONE).unwrap_err();
    assert!(err.to_string().contains("In Place"), "{err}");
}
