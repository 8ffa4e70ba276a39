//! The planar chain the solvers share (conventions in the module docs of [`super`]): its
//! options and report, angle wrapping and limits, forward kinematics, and the checks and
//! position helpers every solver runs.

use std::f64::consts::{PI, TAU};

use crate::{Error, Result};

/// A planar serial chain (one puppet limb). See the module docs for the conventions.
#[derive(Debug, Clone, PartialEq)]
pub struct Chain2d {
    /// Position of joint 0 (the fixed root pin), solver-plane units.
    pub base: [f64; 2],
    /// Absolute direction (radians, from +X, counter-clockwise) that `angles[0]` is relative to,
    /// usually the parent piece's orientation.
    pub base_angle: f64,
    /// Bone lengths, `(b,)`, `>= 0`. A zero-length bone is allowed (it is skipped by CCD).
    pub lengths: Vec<f64>,
    /// Relative joint angles, `(b,)`, radians.
    pub angles: Vec<f64>,
    /// Per-joint `[min, max]` bounds of `angles`, `(b,)`, radians.
    pub limits: Vec<[f64; 2]>,
}

impl Chain2d {
    /// A straight chain (all relative angles 0) with no joint limits.
    pub fn straight(base: [f64; 2], base_angle: f64, lengths: Vec<f64>) -> Self {
        let b = lengths.len();
        Chain2d { base, base_angle, lengths, angles: vec![0.0; b], limits: vec![[-PI, PI]; b] }
    }

    /// Total length `sum(lengths)`: the largest distance from the base the tip can reach.
    pub fn reach(&self) -> f64 {
        self.lengths.iter().sum()
    }
}

/// The most passes a solve may be asked for ([`SolveOptions::max_iterations`]): every solver
/// returns [`Error::InvalidArgument`] above it. The solvers run without Python's GIL and
/// cannot be interrupted, so the bound keeps one call short: 10 000 passes of a puppet limb
/// take milliseconds, and a solve that has not converged in a few hundred passes (200 by
/// default) will not in millions.
pub const MAX_ITERATIONS: usize = 10_000;

/// When to stop iterating.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    /// Largest number of passes (one CCD sweep tip-to-root, or one FABRIK forward+backward),
    /// `0 ..= MAX_ITERATIONS`.
    pub max_iterations: usize,
    /// Absolute distance (chain units) at which an effector counts as on its target.
    /// Callers typically use `1e-3 * chain.reach()` ([`SolveOptions::for_chain`]).
    pub tolerance: f64,
}

impl Default for SolveOptions {
    /// 200 passes, tolerance 1e-3 (absolute).
    fn default() -> Self {
        SolveOptions { max_iterations: 200, tolerance: 1e-3 }
    }
}

impl SolveOptions {
    /// 200 passes and a tolerance of `1e-3 * chain.reach()`.
    pub fn for_chain(chain: &Chain2d) -> Self {
        SolveOptions { max_iterations: 200, tolerance: 1e-3 * chain.reach() }
    }
}

/// What a solver did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveReport {
    /// Passes performed (0 when the chain already was on target or was set in closed form).
    pub iterations: usize,
    /// Final distance from the end effector to the target, chain units (for [`solve_multi`],
    /// the largest distance over the effectors with positive weight). For an unreachable target
    /// with a straight chain this is `distance(base, target) - reach`.
    pub error: f64,
    /// `error <= tolerance`.
    pub reached: bool,
}

/// Wrap an angle (radians) to `(-pi, pi]`. Non-finite input is returned as is.
pub fn wrap_angle(a: f64) -> f64 {
    if (-PI < a) && (a <= PI) {
        return a;
    }
    let r = a.rem_euclid(TAU); // [0, 2pi)
    if r > PI {
        r - TAU
    } else {
        r
    }
}

/// Bring a relative joint angle (radians) into its `[min, max]` limits, circularly: the angle is
/// wrapped to `(-pi, pi]` and, when outside the limits, moved to the bound nearest on the
/// circle (so `-170 deg` with limits `[0, 150] deg` becomes `150 deg`, not `0`).
pub fn clamp_to_limits(angle: f64, limits: [f64; 2]) -> f64 {
    let a = wrap_angle(angle);
    // Both bounds saturate at ±pi: `[3.5, 3.5]` is `[pi, pi]` (a lower bound left above pi
    // made the interval empty and the answer depend on which bound was nearer).
    let lo = limits[0].clamp(-PI, PI);
    let hi = limits[1].clamp(-PI, PI);
    if lo <= -PI && hi >= PI {
        return a;
    }
    if lo <= a && a <= hi {
        return a;
    }
    let d_lo = wrap_angle(lo - a).abs();
    let d_hi = wrap_angle(a - hi).abs();
    // A bound at -pi is the angle pi in the (-pi, pi] convention.
    wrap_angle(if d_lo <= d_hi { lo } else { hi })
}

/// Forward kinematics: the `b + 1` joint positions `p_0 = base, ..., p_b = end effector`
/// (formula in the module docs). Errors on an invalid chain (shape, NaN, negative length).
pub fn forward(chain: &Chain2d) -> Result<Vec<[f64; 2]>> {
    check_chain(chain)?;
    let mut p = Vec::with_capacity(chain.lengths.len() + 1);
    fk_into(chain, &mut p);
    Ok(p)
}

/// Forward kinematics into `out` (cleared first). Chain must be valid.
pub(super) fn fk_into(chain: &Chain2d, out: &mut Vec<[f64; 2]>) {
    out.clear();
    let mut p = chain.base;
    let mut theta = chain.base_angle;
    out.push(p);
    for (&l, &a) in chain.lengths.iter().zip(&chain.angles) {
        theta += a;
        let (s, c) = theta.sin_cos();
        p = [p[0] + l * c, p[1] + l * s];
        out.push(p);
    }
}

/// Relative angles from joint positions (`b + 1` points), clamped to the limits. Each child is
/// measured against its parent's clamped direction, so absolute bone directions are kept where
/// the limits allow. A bone whose end points coincide keeps its parent's direction.
pub(super) fn positions_to_angles(chain: &mut Chain2d, p: &[[f64; 2]]) {
    let mut parent = chain.base_angle;
    for i in 0..chain.lengths.len() {
        let d = sub(p[i + 1], p[i]);
        let rel = if d[0] == 0.0 && d[1] == 0.0 { 0.0 } else { wrap_angle(d[1].atan2(d[0]) - parent) };
        let rel = clamp_to_limits(rel, chain.limits[i]);
        chain.angles[i] = rel;
        parent += rel;
    }
}

pub(super) fn clamp_all(chain: &mut Chain2d) {
    for (a, &l) in chain.angles.iter_mut().zip(&chain.limits) {
        *a = clamp_to_limits(*a, l);
    }
}

pub(super) fn check_chain(chain: &Chain2d) -> Result<()> {
    let b = chain.lengths.len();
    if b == 0 {
        return Err(Error::NoBones("the IK chain has no bones".into()));
    }
    if chain.angles.len() != b || chain.limits.len() != b {
        return Err(Error::Shape(format!(
            "chain has {b} lengths, {} angles and {} limits; they must match",
            chain.angles.len(),
            chain.limits.len()
        )));
    }
    let bad = chain.base.iter().filter(|x| !x.is_finite()).count()
        + usize::from(!chain.base_angle.is_finite())
        + chain.lengths.iter().filter(|x| !x.is_finite()).count()
        + chain.angles.iter().filter(|x| !x.is_finite()).count();
    if bad > 0 {
        return Err(Error::NonFinite { what: "IK chain", count: bad });
    }
    let nan_limits = chain.limits.iter().flatten().filter(|x| x.is_nan()).count();
    if nan_limits > 0 {
        return Err(Error::NonFinite { what: "joint limit", count: nan_limits });
    }
    if let Some(i) = chain.lengths.iter().position(|&l| l < 0.0) {
        return Err(Error::InvalidArgument(format!("bone {i} has negative length {}", chain.lengths[i])));
    }
    if !chain.reach().is_finite() {
        return Err(Error::InvalidArgument("the bone lengths overflow: their sum is not finite".into()));
    }
    if let Some(i) = chain.limits.iter().position(|l| l[0] > l[1]) {
        return Err(Error::InvalidArgument(format!(
            "joint {i} has limits [{}, {}] with min > max",
            chain.limits[i][0], chain.limits[i][1]
        )));
    }
    Ok(())
}

pub(super) fn check_point(p: [f64; 2], what: &'static str) -> Result<()> {
    let bad = p.iter().filter(|x| !x.is_finite()).count();
    if bad > 0 {
        return Err(Error::NonFinite { what, count: bad });
    }
    Ok(())
}

pub(super) fn check_opts(opts: SolveOptions) -> Result<()> {
    if !opts.tolerance.is_finite() || opts.tolerance < 0.0 {
        return Err(Error::InvalidArgument(format!("tolerance must be finite and >= 0, got {}", opts.tolerance)));
    }
    if opts.max_iterations > MAX_ITERATIONS {
        return Err(Error::InvalidArgument(format!(
            "max_iterations must be at most {MAX_ITERATIONS}, got {}",
            opts.max_iterations
        )));
    }
    Ok(())
}

#[inline]
pub(super) fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

#[inline]
pub(super) fn norm(a: [f64; 2]) -> f64 {
    a[0].hypot(a[1])
}

#[inline]
pub(super) fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    let d = sub(a, b);
    d[0] * d[0] + d[1] * d[1]
}

#[cfg(test)]
mod tests {
    //! Reading angles back from positions; the solvers' behaviour is tested in tests/ik2d.rs.
    use super::*;

    #[test]
    fn a_zero_length_bone_keeps_its_parents_direction_when_read_back_from_positions() {
        let mut chain = Chain2d::straight([0.0, 0.0], 0.3, vec![1.0, 0.0, 1.0]);
        chain.limits = vec![[-PI, PI], [-0.1, 0.1], [-PI, PI]];
        let p = [[0.0, 0.0], [0.0, 1.0], [0.0, 1.0], [1.0, 1.0]];
        positions_to_angles(&mut chain, &p);
        assert_eq!(chain.angles[1], 0.0);
        let back = forward(&chain).unwrap();
        for (a, b) in back.iter().zip(&p) {
            assert!(dist2(*a, *b) < 1e-24, "{back:?}");
        }
    }

    #[test]
    fn a_bone_read_back_past_its_parents_limit_keeps_its_own_direction() {
        // the first bone is clamped from 0.5 to 0.2 rad; the second still points at 0.5 rad
        let mut chain = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0, 1.0]);
        chain.limits = vec![[-0.2, 0.2], [-PI, PI]];
        let (c, s) = (0.5f64.cos(), 0.5f64.sin());
        positions_to_angles(&mut chain, &[[0.0, 0.0], [c, s], [2.0 * c, 2.0 * s]]);
        assert!((chain.angles[0] - 0.2).abs() < 1e-12 && (chain.angles[0] + chain.angles[1] - 0.5).abs() < 1e-12);
    }
}
