//! Settling a body whose feet do not all rest on one ground (a stage of `gait.rs`): a rig whose
//! hind hooves rest above the ground its front hooves stand on (Spot the cow's rest pose) is
//! first turned and lowered so that every foot reaches the ground, each leg standing to it as it
//! stood at rest; a walk or run then keeps it so.
//!
//! Inputs
//!   hips       #L rest hip (the head of the upper IK bone) of each planted leg, +Z up
//!   gaps       #L how far each leg's sole rests above the ground (the lowest sole), >= 0, same
//!              unit
//!   fwd, left  the body's unit horizontal axes
//!   height     the skeleton's height (gaps below `FLAT` of it count as none)
//! Output
//!   [`Settle`]: a turn about the hips' centroid (pitch about the right axis, roll about the
//!   forward one) and a drop, which carry each hip down by its leg's gap, as nearly as one rigid
//!   motion can (the rest is left to the legs' IK).
//!
//! Method: least squares for dz_i = -gap_i = d + a x_i + b y_i, with (x_i, y_i) the hip's offset
//! from the centroid along `fwd` and `left`, and a ridge on a and b as if each hip had company a
//! twentieth of the height away at the same height (two legs side by side fix no pitch, legs in a
//! row no roll, a foot a little ahead of the other no steep pitch); pitch = asin(a), roll =
//! asin(b), each at most [`MAX_TURN`].
//!
//! Known limits: the ground is a level plane; a gap the turn cannot take (one leg of four raised
//! at rest) is left to that leg, which reaches down if it can.

use glam::{Mat3, Quat, Vec3};

/// Gaps below this share of the height are noise: nothing is settled.
const FLAT: f32 = 0.005;
/// The most the body pitches or rolls to settle (radians).
const MAX_TURN: f32 = 15.0 * std::f32::consts::PI / 180.0;
/// The ridge on the slopes, as a spread of the hips per share of the height.
const RIDGE: f32 = 0.05;

/// A rigid motion of the rest body: turn `turn` about `centre`, then down by `drop` (negative: up).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Settle {
    pub turn: Quat,
    pub centre: Vec3,
    pub drop: f32,
}

impl Settle {
    /// The rest pose as it is.
    pub(crate) const NONE: Settle = Settle { turn: Quat::IDENTITY, centre: Vec3::ZERO, drop: 0.0 };

    /// Where the settled body puts the rest point `p`.
    pub(crate) fn apply(&self, p: Vec3) -> Vec3 {
        self.centre + self.turn * (p - self.centre) - Vec3::Z * self.drop
    }

    /// Whether it moves anything.
    pub(crate) fn is_none(&self) -> bool {
        self.drop == 0.0 && self.turn == Quat::IDENTITY
    }
}

/// The settle of the module doc.
pub(crate) fn settle(hips: &[Vec3], gaps: &[f32], (fwd, left): (Vec3, Vec3), height: f32) -> Settle {
    if hips.is_empty() || hips.len() != gaps.len() || gaps.iter().all(|&g| g <= FLAT * height) {
        return Settle::NONE;
    }
    let centre = hips.iter().copied().sum::<Vec3>() / hips.len() as f32;
    // normal equations of [1 x y] p = -gap
    let mut ata = Mat3::ZERO;
    let mut atb = Vec3::ZERO;
    for (&h, &g) in hips.iter().zip(gaps) {
        let r = Vec3::new(1.0, (h - centre).dot(fwd), (h - centre).dot(left));
        ata += Mat3::from_cols(r * r.x, r * r.y, r * r.z);
        atb += r * -g;
    }
    // a slope is read over hips at least a twentieth of the height apart: two feet side by
    // side, one a little ahead, give no pitch from a small difference of their soles
    let ridge = hips.len() as f32 * (RIDGE * height).powi(2);
    ata.y_axis.y += ridge;
    ata.z_axis.z += ridge;
    if ata.determinant().abs() <= f32::MIN_POSITIVE {
        return Settle::NONE;
    }
    let p = ata.inverse() * atb;
    let pitch = p.y.clamp(-1.0, 1.0).asin().clamp(-MAX_TURN, MAX_TURN);
    let roll = p.z.clamp(-1.0, 1.0).asin().clamp(-MAX_TURN, MAX_TURN);
    let right = fwd.cross(Vec3::Z).normalize_or(left * -1.0);
    // about `right` a point ahead rises by x sin(pitch); about `fwd` one on the left by y sin(roll)
    let turn = Quat::from_axis_angle(right, pitch) * Quat::from_axis_angle(fwd, roll);
    Settle { turn, centre, drop: -p.x }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hind_legs_resting_high_tip_the_body_back_onto_them() {
        let (fwd, left) = (Vec3::Y, -Vec3::X);
        // front hips at y = +1, hind at y = -1; the hind feet rest 0.1 above the ground
        let hips = [
            Vec3::new(0.3, 1.0, 1.0),
            Vec3::new(-0.3, 1.0, 1.0),
            Vec3::new(0.3, -1.0, 1.0),
            Vec3::new(-0.3, -1.0, 1.0),
        ];
        let s = settle(&hips, &[0.0, 0.0, 0.1, 0.1], (fwd, left), 1.5);
        for (h, want) in hips.iter().zip([0.0, 0.0, -0.1, -0.1]) {
            let dz = s.apply(*h).z - h.z;
            assert!((dz - want).abs() < 2e-3, "{h}: {dz} (want {want})");
        }
        // a biped standing with its right foot on a step rolls towards it and sinks, and does not
        // pitch though its right foot is a little ahead: both hips come down, the right further
        let hips = [Vec3::new(0.1, 0.0, 1.0), Vec3::new(-0.1, -0.02, 1.0)];
        let s = settle(&hips, &[0.0, 0.02], (Vec3::NEG_Y, Vec3::X), 1.8);
        let (left, right) = (s.apply(hips[0]).z - 1.0, s.apply(hips[1]).z - 1.0);
        assert!(right < left && left <= 0.0 && right > -0.02 && (left + right + 0.02).abs() < 1e-4, "{left} {right}");
        let ahead = |p: Vec3| (s.apply(p + Vec3::NEG_Y) - s.apply(p)).z;
        assert!(ahead(hips[0]).abs() < 0.02, "pitched {}", ahead(hips[0]));
        // level feet: nothing moves
        assert!(settle(&hips, &[0.0, 0.001], (Vec3::NEG_Y, Vec3::X), 1.8).is_none());
    }
}
