//! Forward kinematics of a posed skeleton, and the poser the motions write their turns with.
//!
//! Inputs
//!   heads, tails  #B by 3 rest bone end points; parents #B (-1 for roots)
//!   rest          #B rest orientations (row-major 3x3, columns = bone X, Y, Z), made unit
//!                 quaternions by [`rest_quats`]
//!   local         #B local rotations (w, x, y, z) in each bone's rest frame; locations #B
//!                 (or none) moving a head along its rest axes, as Blender's `pose_bone.location`
//! Output
//!   posed heads and tails ([`posed_points`]), or each bone's world turn from rest and posed
//!   head ([`posed_frames`]), bones visited parents first.
//!
//! A foot hanging off the root but carried by its leg (`Roles::riders`) gets the local rotation
//! and location that put it where the leg carries it ([`rider_pose`]).

use glam::{Mat3, Quat, Vec3};

/// Rest orientations as unit quaternions (columns orthonormalised, Y = bone axis kept).
pub(super) fn rest_quats(rest: &[[f32; 9]]) -> Vec<Quat> {
    rest.iter()
        .map(|m| {
            // Row-major in. Entries near f32's limit would overflow the dot products below:
            // scale them down.
            let mut m = Mat3::from_cols_array(m).transpose();
            let largest = m.abs().to_cols_array().into_iter().fold(0.0, f32::max);
            if largest > 1e18 {
                m *= 1.0 / largest;
            }
            let y = m.y_axis.normalize_or(Vec3::Y);
            let mut x = m.x_axis - y * m.x_axis.dot(y);
            if x.length_squared() < 1e-12 {
                x = y.any_orthonormal_vector();
            }
            let x = x.normalize();
            let z = x.cross(y);
            Quat::from_mat3(&Mat3::from_cols(x, y, z)).normalize()
        })
        .collect()
}

pub(super) fn to_wxyz(q: Quat) -> [f32; 4] {
    [q.w, q.x, q.y, q.z]
}

/// Posed bone heads and tails by forward kinematics: `local` are the local rotations
/// (w, x, y, z) per bone, `locations` (empty, or one per bone) move a bone's head along its
/// rest axes as Blender's `pose_bone.location` does, `root_offset` is added to every root's
/// head. Shapes as the inputs.
pub fn posed_points(
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    parents: &[i32],
    rest: &[[f32; 9]],
    local: &[[f32; 4]],
    locations: &[[f32; 3]],
    root_offset: [f32; 3],
) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let (delta, ph) = posed_frames(heads, parents, &rest_quats(rest), local, locations, root_offset);
    let pt = (0..heads.len())
        .map(|b| (ph[b] + delta[b] * (Vec3::from(tails[b]) - Vec3::from(heads[b]))).to_array())
        .collect();
    (ph.iter().map(|p| p.to_array()).collect(), pt)
}

/// Forward kinematics as rigid motions: each bone's world rotation from rest and posed head.
pub(super) fn posed_frames(
    heads: &[[f32; 3]],
    parents: &[i32],
    rq: &[Quat],
    local: &[[f32; 4]],
    locations: &[[f32; 3]],
    root_offset: [f32; 3],
) -> (Vec<Quat>, Vec<Vec3>) {
    let n = heads.len();
    let mut delta = vec![Quat::IDENTITY; n];
    let mut ph = vec![Vec3::ZERO; n];
    for b in preorder(parents) {
        let q = Quat::from_xyzw(local[b][1], local[b][2], local[b][3], local[b][0]).normalize();
        let moved = Vec3::from(heads[b]) + locations.get(b).map_or(Vec3::ZERO, |&l| rq[b] * Vec3::from(l));
        let (pd, head) = match parents[b] {
            p if p >= 0 => {
                let p = p as usize;
                (delta[p], ph[p] + delta[p] * (moved - Vec3::from(heads[p])))
            }
            _ => (Quat::IDENTITY, moved + Vec3::from(root_offset)),
        };
        delta[b] = pd * rq[b] * q * rq[b].inverse();
        ph[b] = head;
    }
    (delta, ph)
}

/// Local rotation and location (in its rest frame, input units) that put `rider` -- a foot
/// hanging off the root (`Roles::riders`) -- where its leg carries it: `delta`/`ph` are the
/// frames with the rider on its leg, `real` those of the input hierarchy. Blender's pose
/// maths: posed head = parent's motion applied to (rest head + rest rotation · location).
pub(super) fn rider_pose(
    rider: usize,
    heads: &[[f32; 3]],
    parents: &[i32],
    rq: &[Quat],
    (delta, ph): (&[Quat], &[Vec3]),
    (real_delta, real_ph): (&[Quat], &[Vec3]),
) -> (Quat, Vec3) {
    let (pd, from) = match parents[rider] {
        p if p >= 0 => {
            let p = p as usize;
            (real_delta[p], real_ph[p] + real_delta[p] * (Vec3::from(heads[rider]) - Vec3::from(heads[p])))
        }
        _ => (Quat::IDENTITY, Vec3::from(heads[rider])),
    };
    let inv = rq[rider].inverse();
    let rotation = inv * pd.inverse() * delta[rider] * rq[rider];
    let location = inv * (pd.inverse() * (ph[rider] - from));
    (rotation.normalize(), location)
}

pub(super) fn preorder(parents: &[i32]) -> Vec<usize> {
    let n = parents.len();
    let mut kids = vec![Vec::new(); n];
    for (b, &p) in parents.iter().enumerate() {
        if p >= 0 {
            kids[p as usize].push(b);
        }
    }
    let mut out = Vec::with_capacity(n);
    let mut stack: Vec<usize> = (0..n).filter(|&b| parents[b] < 0).collect();
    while let Some(b) = stack.pop() {
        out.push(b);
        stack.extend(&kids[b]);
    }
    out
}

pub(super) struct Poser {
    pub(super) rest: Vec<Quat>,
    pub(super) q: Vec<Quat>,
    pub(super) touched: Vec<bool>,
}

impl Poser {
    /// Rotate bone `b` by `angle` about the world `axis` (expressed in its rest frame).
    pub(super) fn rotate(&mut self, b: usize, axis: Vec3, angle: f32) {
        let local = self.rest[b].inverse() * axis;
        self.q[b] *= Quat::from_axis_angle(local.normalize(), angle);
        self.touched[b] = true;
    }

    /// Set bone `b`'s turn relative to its parent to `world` (in the rest pose's axes).
    pub(super) fn turn(&mut self, b: usize, world: Quat) {
        self.q[b] = (self.rest[b].inverse() * world * self.rest[b]).normalize();
        self.touched[b] = true;
    }

    /// Turn bone `b` by `world` (in the rest pose's axes) after its own turn.
    pub(super) fn pre_turn(&mut self, b: usize, world: Quat) {
        self.q[b] = (self.rest[b].inverse() * world * self.rest[b] * self.q[b]).normalize();
        self.touched[b] = true;
    }
}

pub(super) fn new_poser(rest: &[[f32; 9]]) -> Poser {
    let rest = rest_quats(rest);
    let n = rest.len();
    Poser { rest, q: vec![Quat::IDENTITY; n], touched: vec![false; n] }
}
