//! Analytic two-bone IK: where the middle joint of a two-bone chain goes so that its end
//! reaches a target, by the law of cosines, bending towards a pole.
//!
//! Inputs
//!   root    3 position of the chain's first joint (a hip)
//!   target  3 where the chain's end should be (an ankle)
//!   l1, l2  lengths of the two bones (> 0)
//!   pole    3 direction the middle joint (a knee) bends towards; only its part
//!           perpendicular to root -> target counts
//! Output
//!   ([`TwoBone`]) the middle joint and the end. The end is the target when it lies within
//!   reach (`|l1 - l2| <= d <= l1 + l2`), else the nearest point of reach on the line from
//!   the root to the target: a chain can neither stretch nor fold through itself.
//!
//! Method: with `d = |target - root|` (clamped to reach), the middle joint lies
//! `a = (l1² - l2² + d²) / 2d` along the line and `h = √(l1² - a²)` off it, towards the pole
//! (the law of cosines). A pole along the
//! line (no perpendicular part) bends along any perpendicular. [`frame_turn`] gives the
//! rotation that turns a bone with its bend plane from rest to the solved pose.
//!
//! See also: `ik2d/` (iterative planar chains of any length for puppets).

use glam::{DMat3, DQuat, DVec3, Quat, Vec3};

/// A solved two-bone chain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoBone {
    /// The middle joint (a knee).
    pub middle: Vec3,
    /// The end of the chain (the target, or as near as reach allows).
    pub end: Vec3,
}

/// Solve a two-bone chain (see the module doc). Degenerate lengths (not finite or not positive)
/// leave the chain straight towards the target.
pub fn two_bone_ik(root: Vec3, target: Vec3, l1: f32, l2: f32, pole: Vec3) -> TwoBone {
    // In double precision: a leg nearly straight takes the square root of a small difference.
    let (root, target, pole) = (root.as_dvec3(), target.as_dvec3(), pole.as_dvec3());
    let (l1, l2) = (l1 as f64, l2 as f64);
    let to = target - root;
    let dist = to.length();
    let dir = if dist > 1e-12 { to / dist } else { perpendicular(pole) };
    if !(l1 > 0.0 && l2 > 0.0 && l1.is_finite() && l2.is_finite()) {
        return TwoBone { middle: (root + dir * l1.max(0.0)).as_vec3(), end: target.as_vec3() };
    }
    let lo = (l1 - l2).abs() * (1.0 + 1e-9);
    let hi = (l1 + l2) * (1.0 - 1e-9);
    let d = dist.clamp(lo.min(hi), hi);
    let along = (l1 * l1 - l2 * l2 + d * d) / (2.0 * d);
    let off = (l1 * l1 - along * along).max(0.0).sqrt();
    let side = pole - dir * pole.dot(dir);
    let side = if side.length_squared() > 1e-12 * pole.length_squared().max(1e-300) {
        side.normalize()
    } else {
        perpendicular(dir)
    };
    TwoBone { middle: (root + dir * along + side * off).as_vec3(), end: (root + dir * d).as_vec3() }
}

/// A unit vector perpendicular to `v` (any, when `v` is zero).
fn perpendicular(v: DVec3) -> DVec3 {
    v.normalize_or(DVec3::Z).any_orthonormal_vector()
}

/// The rotation that turns direction `from` into `to` and the bend direction `from_side` (its
/// part perpendicular to `from`) into `to_side` (likewise): the turn of a bone whose bend plane
/// goes with it. Falls back to the shortest arc when a side is along its direction.
pub fn frame_turn(from: Vec3, from_side: Vec3, to: Vec3, to_side: Vec3) -> Quat {
    let frame = |u: DVec3, s: DVec3| -> Option<DMat3> {
        let u = u.try_normalize()?;
        let w = (s - u * s.dot(u)).try_normalize()?;
        Some(DMat3::from_cols(u, w, u.cross(w)))
    };
    let (from, from_side, to, to_side) = (from.as_dvec3(), from_side.as_dvec3(), to.as_dvec3(), to_side.as_dvec3());
    let turn = match (frame(from, from_side), frame(to, to_side)) {
        (Some(a), Some(b)) => DQuat::from_mat3(&(b * a.transpose())).normalize(),
        _ => DQuat::from_rotation_arc(from.normalize_or(DVec3::Y), to.normalize_or(DVec3::Y)),
    };
    turn.as_quat()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reaches_a_target_within_reach_and_keeps_the_lengths() {
        let root = Vec3::new(0.0, 0.0, 1.0);
        for target in [Vec3::new(0.3, 0.1, 0.2), Vec3::new(-0.2, 0.0, 0.4), Vec3::new(0.0, 0.0, 0.05)] {
            let s = two_bone_ik(root, target, 0.5, 0.45, Vec3::X);
            assert!((s.end - target).length() < 1e-5, "{target:?}");
            assert!(((s.middle - root).length() - 0.5).abs() < 1e-5);
            assert!(((s.end - s.middle).length() - 0.45).abs() < 1e-5);
            // The knee bends towards the pole (+X) from the hip-ankle line.
            let dir = (target - root).normalize();
            let off = (s.middle - root) - dir * (s.middle - root).dot(dir);
            assert!(off.dot(Vec3::X) > 0.0, "{target:?}");
        }
    }

    #[test]
    fn out_of_reach_stops_straight_on_the_line() {
        let s = two_bone_ik(Vec3::ZERO, Vec3::new(0.0, 0.0, -3.0), 1.0, 1.0, Vec3::X);
        assert!((s.end - Vec3::new(0.0, 0.0, -2.0)).length() < 1e-4);
        assert!((s.middle - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-2);
        let s = two_bone_ik(Vec3::ZERO, Vec3::new(0.0, 0.0, -0.1), 1.0, 0.5, Vec3::X);
        assert!(((s.end - Vec3::ZERO).length() - 0.5).abs() < 1e-4, "folded to |l1 - l2|");
    }

    #[test]
    fn frame_turn_maps_direction_and_side() {
        let q = frame_turn(Vec3::Z, Vec3::X, Vec3::X, -Vec3::Z);
        assert!((q * Vec3::Z - Vec3::X).length() < 1e-6);
        assert!((q * Vec3::X + Vec3::Z).length() < 1e-6);
        // A side along the direction falls back to the shortest arc.
        let q = frame_turn(Vec3::Z, Vec3::Z, Vec3::X, Vec3::X);
        assert!((q * Vec3::Z - Vec3::X).length() < 1e-6);
    }
}
