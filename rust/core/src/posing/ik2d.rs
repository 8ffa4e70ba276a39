//! Planar inverse kinematics for digital shadow puppets (Chinese shadow play, 皮影戏).
//!
//! A shadow puppet is a set of flat pieces pinned together, moved in the picture plane only,
//! so its limbs are planar serial chains. The solver works in its own XY plane; the add-on
//! maps that plane to Blender's XZ picture plane.
//!
//! Conventions, shared by every function here:
//!
//! * A [`Chain2d`] with `b` bones has `b + 1` joint positions `p_0 .. p_b`; `p_0 = base` is fixed
//!   and `p_b` is the end effector (the hand, the tip of a dragon's tail...).
//! * `angles[i]` is joint `i`'s angle relative to its parent bone (to `base_angle` for
//!   `i = 0`), counter-clockwise, radians, wrapped to `(-pi, pi]`. Forward kinematics:
//!   `theta_i = base_angle + angles[0] + ... + angles[i]`,
//!   `p_{i+1} = p_i + lengths[i] * (cos theta_i, sin theta_i)`.
//! * `limits[i] = [min, max]` bounds `angles[i]`, radians, `min <= max`, inside `[-pi, pi]`
//!   (values beyond `±pi` saturate, so `[-inf, inf]` or `[-pi, pi]` mean "no limit").
//! * Lengths are in any unit (Blender metres); tolerances and errors are in the same unit.
//! * On `Err` the chain is left untouched. Every solver leaves angles inside their limits.
//! * Every solver runs at most [`MAX_ITERATIONS`] passes: a larger
//!   [`SolveOptions::max_iterations`] is [`Error::InvalidArgument`], not clamped.
//!
//! Solvers:
//!
//! * [`solve_ccd`]: the improved planar CCD of the shadow-puppet paper (Beijing University of
//!   Technology, digital shadow-play animation): per joint one closed-form planar angle
//!   `atan2(cross_z(e - j, t - j), dot(e - j, t - j))` and a clamp to the joint limits, plus
//!   what the paper leaves open: collinear stagnation, unreachable targets, zero-length bones,
//!   and a Gauss-Newton polish step when CCD crawls near the workspace boundary
//!   ([`solve_ccd_pure`] is the same without the polish).
//! * [`solve_multi`]: the same CCD for several weighted effectors on one chain (strip puppets:
//!   snake, dragon), each joint taking the closed-form weighted 2D Procrustes rotation.
//! * [`solve_two_arm_grip`]: both hands of a puppet on the grip points of a held prop.
//! * Baselines for comparison (benches/ik2d.rs): [`solve_ccd_classic3d`] (textbook 3D CCD,
//!   Wang & Chen 1991 / Welman 1993) and [`solve_fabrik`] (Aristidou & Lasenby 2011).

use std::f64::consts::{PI, TAU};

use glam::{DQuat, DVec3};

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

/// Improved planar CCD for one end effector (the tip, joint `b`).
///
/// Each pass visits joints from the last to the root and turns joint `i` (pivot `j = p_i`,
/// tip `e = p_b`, target `t`) by the single planar angle that puts `e` on the ray from `j`
/// to `t`: `delta = atan2(cross_z(e - j, t - j), dot(e - j, t - j))` (cosine from the dot
/// product, turning direction from the sign of the 2D cross product: no `acos`, no axis),
/// then clamps `angles[i]` to `limits[i]` ([`clamp_to_limits`]). Only the tip is updated
/// inside a pass (the pivots of the remaining joints do not move), so a pass is `O(b)`;
/// positions are recomputed from the angles after every pass so no drift builds up.
///
/// Addition (not in the paper): plain CCD crawls near the boundary of the workspace (target
/// near full reach or near the inner radius: 6 % of random 2-bone targets need more than 200
/// passes). When a pass removes less than 75 % of the squared error, it is followed by one
/// damped Gauss-Newton (Levenberg-Marquardt) step on the joint angles, kept only if it lowers
/// the error; this brings the mean to about 4 passes with no failures (benches/ik2d.rs).
/// [`solve_ccd_pure`] is the same solver without it.
///
/// Cases the paper leaves open:
/// * unreachable (`|t - base| > reach`): when the straight pose toward `t` is within the limits
///   the chain is set to it in closed form (`iterations = 0`, `error = |t - base| - reach`,
///   `reached = false` unless that is within tolerance); otherwise CCD runs and the closest
///   pose found within the limits is returned.
/// * collinear / stagnation (target on the bones' line ahead, or straight behind, where every
///   `delta` is 0 or `pi`; or any pass improving the squared error by less than 0.1 %): the
///   non-root joints are bent by a deterministic, limit-respecting amount, the root turned back
///   by half the total bend (a curl that keeps the tip's direction), and CCD resumes; after
///   a few unsuccessful bends it stops at the best pose seen (a true local optimum, e.g. a
///   target blocked by the limits or inside the inner radius of the workspace).
/// * zero-length bones: their joint is skipped (no NaN); `atan2(0, 0) = 0` covers a tip lying
///   on a pivot.
///
/// Input angles are first clamped to their limits. Errors: invalid chain, non-finite target,
/// negative or NaN tolerance, `max_iterations` above [`MAX_ITERATIONS`].
pub fn solve_ccd(chain: &mut Chain2d, target: [f64; 2], opts: SolveOptions) -> Result<SolveReport> {
    ccd_single(chain, target, opts, true)
}

/// [`solve_ccd`] without the Gauss-Newton polish: only the paper's per-joint CCD step (plus the
/// unreachable, collinear and zero-length handling). Kept for comparison (benches/ik2d.rs) and
/// for callers who want the textbook behaviour; it needs many more passes near the boundary
/// of the workspace.
pub fn solve_ccd_pure(chain: &mut Chain2d, target: [f64; 2], opts: SolveOptions) -> Result<SolveReport> {
    ccd_single(chain, target, opts, false)
}

fn ccd_single(chain: &mut Chain2d, target: [f64; 2], opts: SolveOptions, polish: bool) -> Result<SolveReport> {
    check_chain(chain)?;
    check_point(target, "target")?;
    check_opts(opts)?;
    clamp_all(chain);

    let b = chain.lengths.len();
    let reach = chain.reach();
    let to = [target[0] - chain.base[0], target[1] - chain.base[1]];
    let dist = norm(to);
    if dist > reach && dist > 0.0 {
        let root = wrap_angle(to[1].atan2(to[0]) - chain.base_angle);
        let fits = clamp_to_limits(root, chain.limits[0]) == root
            && chain.limits[1..].iter().all(|&l| clamp_to_limits(0.0, l) == 0.0);
        if fits {
            chain.angles[0] = root;
            chain.angles[1..].iter_mut().for_each(|a| *a = 0.0);
            let mut p = Vec::with_capacity(b + 1);
            fk_into(chain, &mut p);
            let error = dist2(p[b], target).sqrt();
            return Ok(SolveReport { iterations: 0, error, reached: error <= opts.tolerance });
        }
    }
    Ok(ccd_core(chain, &[Effector { joint: b, target, weight: 1.0 }], opts, polish))
}

/// Multi-effector planar CCD, for strip puppets (snake, dragon, ribbon) whose head, middle and
/// tail are all pinned to targets.
///
/// `effectors[k] = (joint, target, weight)`: joint position `p_joint` (`1 ..= b`; the base
/// `p_0` cannot move) should reach `target`, with importance `weight >= 0`. Each joint `i`,
/// visited tip-to-root, turns by the angle minimising `sum_k w_k |R(delta) a_k - c_k|^2` over
/// the effectors beyond it (`joint > i`), `a_k = e_k - p_i`, `c_k = t_k - p_i`: the planar
/// orthogonal Procrustes solution `delta = atan2(sum w_k cross_z(a_k, c_k), sum w_k dot(a_k, c_k))`,
/// then is clamped to its limits. With one tip effector this is exactly [`solve_ccd`]'s step.
/// Stagnation and slow passes are handled as in [`solve_ccd`] (bend on stall, Gauss-Newton
/// polish on the weighted sum of squares); there is no closed-form unreachable case; conflicting
/// targets end at the weighted least-squares compromise, `reached = false`.
///
/// The report's `error` is the largest distance over effectors with positive weight.
/// Errors: invalid chain/options (`max_iterations` above [`MAX_ITERATIONS`]), empty effector
/// list, joint index 0 or `> b`, non-finite target, negative/non-finite weight, all weights zero.
pub fn solve_multi(
    chain: &mut Chain2d,
    effectors: &[(usize, [f64; 2], f64)],
    opts: SolveOptions,
) -> Result<SolveReport> {
    check_chain(chain)?;
    check_opts(opts)?;
    let b = chain.lengths.len();
    if effectors.is_empty() {
        return Err(Error::InvalidArgument("no effectors given".into()));
    }
    let mut effs = Vec::with_capacity(effectors.len());
    let mut total_weight = 0.0;
    for (k, &(joint, target, weight)) in effectors.iter().enumerate() {
        if joint == 0 || joint > b {
            return Err(Error::InvalidArgument(format!(
                "effector {k} is on joint {joint}, but a chain of {b} bones has movable joints 1..={b}"
            )));
        }
        check_point(target, "effector target")?;
        if !weight.is_finite() || weight < 0.0 {
            return Err(Error::InvalidArgument(format!(
                "effector {k} has weight {weight}; weights must be finite and >= 0"
            )));
        }
        total_weight += weight;
        effs.push(Effector { joint, target, weight });
    }
    if total_weight <= 0.0 {
        return Err(Error::InvalidArgument("all effector weights are zero".into()));
    }
    clamp_all(chain);
    Ok(ccd_core(chain, &effs, opts, true))
}

/// Prop-holding puppet: put the tip of `left` on `prop_grip_left` and the tip of `right` on
/// `prop_grip_right` (world points of the held prop, e.g. both ends of a pole at the prop's
/// current position and rotation), each with [`solve_ccd`]. The arms share no joints, so the
/// two solves are independent; both chains and targets are validated before either chain is
/// changed. Returns `(left report, right report)`.
pub fn solve_two_arm_grip(
    left: &mut Chain2d,
    right: &mut Chain2d,
    prop_grip_left: [f64; 2],
    prop_grip_right: [f64; 2],
    opts: SolveOptions,
) -> Result<(SolveReport, SolveReport)> {
    check_chain(left)?;
    check_chain(right)?;
    check_point(prop_grip_left, "left grip")?;
    check_point(prop_grip_right, "right grip")?;
    check_opts(opts)?;
    let l = solve_ccd(left, prop_grip_left, opts)?;
    let r = solve_ccd(right, prop_grip_right, opts)?;
    Ok((l, r))
}

/// Baseline: textbook CCD in 3D (Wang & Chen 1991; Welman 1993), as a general 3D IK library
/// would run it on the chain embedded at `z = 0`.
///
/// Each pass, tip-to-root: `u = normalize(e - j)`, `v = normalize(t - j)`, axis `u x v`,
/// angle `acos(u . v)`, rotation by the unit quaternion `(axis, angle)` applied to every joint
/// position beyond `j` (`O(b^2)` per pass). A zero cross product (collinear) skips the joint.
/// Afterwards the positions are projected back into the plane: relative angles come from
/// `atan2` of the bone directions, clamped to the limits (limits are not enforced during the
/// iterations, which is what this baseline lacks), and the reported error is recomputed from
/// those angles. No special case for unreachable targets.
pub fn solve_ccd_classic3d(chain: &mut Chain2d, target: [f64; 2], opts: SolveOptions) -> Result<SolveReport> {
    check_chain(chain)?;
    check_point(target, "target")?;
    check_opts(opts)?;
    let b = chain.lengths.len();
    let mut p2 = Vec::with_capacity(b + 1);
    fk_into(chain, &mut p2);
    let mut p: Vec<DVec3> = p2.iter().map(|q| DVec3::new(q[0], q[1], 0.0)).collect();
    let t = DVec3::new(target[0], target[1], 0.0);
    let mut iterations = 0;
    if p[b].distance(t) > opts.tolerance {
        for it in 1..=opts.max_iterations {
            iterations = it;
            for i in (0..b).rev() {
                let j = p[i];
                let u = p[b] - j;
                let v = t - j;
                let (lu, lv) = (u.length(), v.length());
                if lu <= 1e-300 || lv <= 1e-300 {
                    continue;
                }
                let (u, v) = (u / lu, v / lv);
                let axis = u.cross(v);
                let s = axis.length();
                if s <= 1e-15 {
                    continue;
                }
                let angle = u.dot(v).clamp(-1.0, 1.0).acos();
                let q = DQuat::from_axis_angle(axis / s, angle);
                for pk in p[i + 1..].iter_mut() {
                    *pk = j + q * (*pk - j);
                }
            }
            if p[b].distance(t) <= opts.tolerance {
                break;
            }
        }
    }
    for (q2, q3) in p2.iter_mut().zip(&p) {
        *q2 = [q3.x, q3.y];
    }
    Ok(settle_positions(chain, &mut p2, target, iterations, opts.tolerance))
}

/// Baseline: FABRIK, Forward And Backward Reaching Inverse Kinematics (Aristidou & Lasenby,
/// "FABRIK: A fast, iterative solver for the Inverse Kinematics problem", Graphical Models
/// 73(5), 2011), on joint positions.
///
/// Unreachable targets (`|t - base| > reach`) get the straight chain toward `t` in one step.
/// Otherwise each pass sets `p_b = t` and walks to the root placing `p_i` at distance
/// `lengths[i]` from `p_{i+1}` on the segment toward the old `p_i`, then sets `p_0 = base` and
/// walks back out; it stops when `|p_b - t| <= tolerance`. The positions are then converted
/// to relative angles (`atan2` of bone directions; a zero-length bone keeps its parent's
/// direction) and clamped to the limits, which FABRIK itself does not know about; the
/// reported error is recomputed from the clamped angles.
pub fn solve_fabrik(chain: &mut Chain2d, target: [f64; 2], opts: SolveOptions) -> Result<SolveReport> {
    check_chain(chain)?;
    check_point(target, "target")?;
    check_opts(opts)?;
    let b = chain.lengths.len();
    let mut p = Vec::with_capacity(b + 1);
    fk_into(chain, &mut p);
    let base = chain.base;
    let reach = chain.reach();
    let to = sub(target, base);
    let dist = norm(to);
    let mut iterations = 0;
    if dist > reach {
        let d = if dist > 0.0 { [to[0] / dist, to[1] / dist] } else { [1.0, 0.0] };
        for i in 0..b {
            let l = chain.lengths[i];
            p[i + 1] = [p[i][0] + l * d[0], p[i][1] + l * d[1]];
        }
        iterations = 1;
    } else if dist2(p[b], target).sqrt() > opts.tolerance {
        // Fallback direction for coincident joints: the base direction.
        let fallback = [chain.base_angle.cos(), chain.base_angle.sin()];
        for it in 1..=opts.max_iterations {
            iterations = it;
            // Forward reaching: tip to root.
            p[b] = target;
            for i in (0..b).rev() {
                p[i] = reach_toward(p[i + 1], p[i], chain.lengths[i], fallback);
            }
            // Backward reaching: root to tip.
            p[0] = base;
            for i in 0..b {
                p[i + 1] = reach_toward(p[i], p[i + 1], chain.lengths[i], fallback);
            }
            if dist2(p[b], target).sqrt() <= opts.tolerance {
                break;
            }
        }
    }
    Ok(settle_positions(chain, &mut p, target, iterations, opts.tolerance))
}

// ---------------------------------------------------------------------------------------------
// Internals.

/// FABRIK's step: the point at distance `l` from `anchor` toward `toward` (along `fallback`
/// when the two coincide).
fn reach_toward(anchor: [f64; 2], toward: [f64; 2], l: f64, fallback: [f64; 2]) -> [f64; 2] {
    let d = sub(toward, anchor);
    let r = norm(d);
    let dir = if r > 1e-300 { [d[0] / r, d[1] / r] } else { fallback };
    [anchor[0] + l * dir[0], anchor[1] + l * dir[1]]
}

/// End of the position-based baselines: joint positions `p` -> clamped relative angles on
/// `chain`, `p` recomputed from them, and the report with the error of that final pose.
fn settle_positions(
    chain: &mut Chain2d,
    p: &mut Vec<[f64; 2]>,
    target: [f64; 2],
    iterations: usize,
    tolerance: f64,
) -> SolveReport {
    positions_to_angles(chain, p);
    fk_into(chain, p);
    let error = dist2(p[p.len() - 1], target).sqrt();
    SolveReport { iterations, error, reached: error <= tolerance }
}

/// One effector of the CCD core.
#[derive(Clone, Copy)]
struct Effector {
    joint: usize,
    target: [f64; 2],
    weight: f64,
}

/// A pass whose weighted squared error improves by less than this fraction counts as stalled.
const STALL_RATIO: f64 = 1e-3;
/// How many times a stalled CCD is bent before it settles for the best pose seen.
const MAX_PERTURBATIONS: usize = 8;

/// CCD on validated input with angles already within limits. Returns the best pose seen.
fn ccd_core(chain: &mut Chain2d, effs: &[Effector], opts: SolveOptions, polish: bool) -> SolveReport {
    let b = chain.lengths.len();
    let mut pos: Vec<[f64; 2]> = Vec::with_capacity(b + 1);
    fk_into(chain, &mut pos);
    let (mut f, err) = evaluate(&pos, effs);
    if err <= opts.tolerance {
        return SolveReport { iterations: 0, error: err, reached: true };
    }
    let mut best_angles = chain.angles.clone();
    let (mut best_f, mut best_err) = (f, err);
    let mut epos: Vec<[f64; 2]> = effs.iter().map(|e| pos[e.joint]).collect();
    let mut perturbations = 0;
    let mut iterations = 0;

    for it in 1..=opts.max_iterations {
        iterations = it;
        for i in (0..b).rev() {
            if chain.lengths[i] == 0.0 {
                continue;
            }
            let j = pos[i];
            let (mut sc, mut sd) = (0.0, 0.0);
            for (e, ep) in effs.iter().zip(&epos) {
                if e.joint <= i {
                    continue;
                }
                let a = sub(*ep, j);
                let c = sub(e.target, j);
                sc += e.weight * (a[0] * c[1] - a[1] * c[0]);
                sd += e.weight * (a[0] * c[0] + a[1] * c[1]);
            }
            if sc == 0.0 && sd == 0.0 {
                continue;
            }
            let delta = sc.atan2(sd);
            let old = chain.angles[i];
            let new = clamp_to_limits(old + delta, chain.limits[i]);
            let d = wrap_angle(new - old);
            chain.angles[i] = new;
            if d == 0.0 {
                continue;
            }
            let (s, c) = d.sin_cos();
            for (e, ep) in effs.iter().zip(epos.iter_mut()) {
                if e.joint > i {
                    let a = sub(*ep, j);
                    *ep = [j[0] + c * a[0] - s * a[1], j[1] + s * a[0] + c * a[1]];
                }
            }
        }
        fk_into(chain, &mut pos);
        for (e, ep) in effs.iter().zip(epos.iter_mut()) {
            *ep = pos[e.joint];
        }
        let (mut f_new, mut err_new) = evaluate(&pos, effs);
        if polish && err_new > opts.tolerance && f_new > SLOW_RATIO * f {
            // CCD is crawling (typically near the workspace boundary or a limit): one damped
            // Gauss-Newton step on the same objective.
            if let Some((fp, ep)) = lm_step(chain, effs, &mut pos, f_new) {
                f_new = fp;
                err_new = ep;
                for (e, ep) in effs.iter().zip(epos.iter_mut()) {
                    *ep = pos[e.joint];
                }
            }
        }
        if f_new < best_f {
            best_f = f_new;
            best_err = err_new;
            best_angles.copy_from_slice(&chain.angles);
        }
        if err_new <= opts.tolerance {
            return SolveReport { iterations, error: err_new, reached: true };
        }
        if f_new > f * (1.0 - STALL_RATIO) {
            if perturbations >= MAX_PERTURBATIONS {
                break;
            }
            perturb(chain, perturbations);
            perturbations += 1;
            fk_into(chain, &mut pos);
            for (e, ep) in effs.iter().zip(epos.iter_mut()) {
                *ep = pos[e.joint];
            }
            f = evaluate(&pos, effs).0;
        } else {
            f = f_new;
        }
    }
    chain.angles.copy_from_slice(&best_angles);
    SolveReport { iterations, error: best_err, reached: best_err <= opts.tolerance }
}

/// A CCD pass that leaves more than this fraction of the weighted squared error triggers a
/// Gauss-Newton polish step ([`lm_step`]).
const SLOW_RATIO: f64 = 0.25;

/// One Levenberg-Marquardt step on `F = sum_k w_k |t_k - e_k|^2` over all joint angles, from the
/// pose in `chain` / `pos` (whose objective is `f`). Planar Jacobian: effector `k` moves by
/// `perp(e_k - p_i)` per radian of joint `i` when `joint_k > i`. With `J' = W^(1/2) J`,
/// `r' = W^(1/2) r` the damped step is `dtheta = J'^T (J' J'^T + lambda^2 I)^(-1) r'`
/// (a `2m x 2m` solve, `m` effectors), each component capped at 0.5 rad, then the angles are
/// clamped to their limits. Tries three dampings; keeps the first pose that lowers `F`
/// (updating `chain` and `pos`, returning the new `(F, worst distance)`), else restores the pose
/// and returns `None`.
fn lm_step(chain: &mut Chain2d, effs: &[Effector], pos: &mut Vec<[f64; 2]>, f: f64) -> Option<(f64, f64)> {
    let b = chain.lengths.len();
    let m2 = 2 * effs.len();
    // J' row-major, m2 x b; r' (m2).
    let mut jac = vec![0.0; m2 * b];
    let mut r = vec![0.0; m2];
    for (k, e) in effs.iter().enumerate() {
        let sw = e.weight.sqrt();
        let ek = pos[e.joint];
        r[2 * k] = sw * (e.target[0] - ek[0]);
        r[2 * k + 1] = sw * (e.target[1] - ek[1]);
        for i in 0..e.joint {
            let a = sub(ek, pos[i]);
            jac[2 * k * b + i] = -sw * a[1];
            jac[(2 * k + 1) * b + i] = sw * a[0];
        }
    }
    let mut jjt = vec![0.0; m2 * m2];
    for x in 0..m2 {
        for y in 0..=x {
            let v: f64 = (0..b).map(|i| jac[x * b + i] * jac[y * b + i]).sum();
            jjt[x * m2 + y] = v;
            jjt[y * m2 + x] = v;
        }
    }
    let scale = (0..m2).map(|x| jjt[x * m2 + x]).sum::<f64>() / m2 as f64;
    if scale.is_nan() || scale <= 0.0 {
        return None;
    }
    let saved = chain.angles.clone();
    for mu in [1e-6, 1e-3, 1e-1] {
        let mut a = jjt.clone();
        for x in 0..m2 {
            a[x * m2 + x] += mu * scale;
        }
        // A failed solve keeps the pose the step started from (restored below).
        let Some(y) = solve_dense(&mut a, r.clone(), m2) else { break };
        let mut step: Vec<f64> = (0..b).map(|i| (0..m2).map(|x| jac[x * b + i] * y[x]).sum()).collect();
        let biggest = step.iter().fold(0.0f64, |acc, v| acc.max(v.abs()));
        if biggest > 0.5 {
            step.iter_mut().for_each(|v| *v *= 0.5 / biggest);
        }
        for i in 0..b {
            chain.angles[i] = clamp_to_limits(saved[i] + step[i], chain.limits[i]);
        }
        fk_into(chain, pos);
        let (fp, ep) = evaluate(pos, effs);
        if fp < f {
            return Some((fp, ep));
        }
    }
    chain.angles.copy_from_slice(&saved);
    fk_into(chain, pos);
    None
}

/// Solve the small dense system `a x = rhs` (`n x n`, row-major) by Gaussian elimination with
/// partial pivoting; `None` when singular or non-finite. Hand-written on purpose: `n` is twice
/// the effectors (2 to 8), and faer's dense Cholesky in its place made 9000 IK solves
/// 0.42 -> 0.75 s (its set-up outweighs a few dozen flops; this runs in Blender's
/// frame-change handler).
fn solve_dense(a: &mut [f64], mut rhs: Vec<f64>, n: usize) -> Option<Vec<f64>> {
    for col in 0..n {
        let piv = (col..n).max_by(|&x, &y| a[x * n + col].abs().total_cmp(&a[y * n + col].abs()))?;
        let pv = a[piv * n + col];
        if !pv.is_finite() || pv.abs() <= 1e-300 {
            return None;
        }
        if piv != col {
            for c in 0..n {
                a.swap(piv * n + c, col * n + c);
            }
            rhs.swap(piv, col);
        }
        for row in col + 1..n {
            let factor = a[row * n + col] / pv;
            if factor != 0.0 {
                for c in col..n {
                    a[row * n + c] -= factor * a[col * n + c];
                }
                rhs[row] -= factor * rhs[col];
            }
        }
    }
    for col in (0..n).rev() {
        let mut v = rhs[col];
        for c in col + 1..n {
            v -= a[col * n + c] * rhs[c];
        }
        rhs[col] = v / a[col * n + col];
    }
    rhs.iter().all(|v| v.is_finite()).then_some(rhs)
}

/// Curl the chain out of a stall: bend every non-root joint (with a non-zero bone on either
/// side) by a deterministic angle `d` (alternating sign and growing with the perturbation
/// count; per joint the sign the limits allow), and turn the root back by half the total bend
/// so the tip stays roughly in the same direction. This breaks the collinear saddles where
/// every CCD step is 0 or pi (a bend of the last joint alone would be undone by the next pass).
fn perturb(chain: &mut Chain2d, count: usize) {
    let b = chain.lengths.len();
    if b < 2 {
        return;
    }
    let magnitude = (0.6 / (b as f64 - 1.0).sqrt()).min(0.5) * (1.0 + 0.25 * (count / 2) as f64);
    let sign = if count.is_multiple_of(2) { 1.0 } else { -1.0 };
    let mut total = 0.0;
    for i in 1..b {
        if chain.lengths[i] == 0.0 && chain.lengths[i - 1] == 0.0 {
            continue;
        }
        let old = chain.angles[i];
        let lim = chain.limits[i];
        let plus = clamp_to_limits(old + sign * magnitude, lim);
        let minus = clamp_to_limits(old - sign * magnitude, lim);
        let (dp, dm) = (wrap_angle(plus - old), wrap_angle(minus - old));
        let new = if dp.abs() >= 0.5 * magnitude || dp.abs() >= dm.abs() { plus } else { minus };
        total += wrap_angle(new - old);
        chain.angles[i] = new;
    }
    chain.angles[0] = clamp_to_limits(chain.angles[0] - 0.5 * total, chain.limits[0]);
}

/// Weighted sum of squared effector distances, and the largest distance among effectors with
/// positive weight.
fn evaluate(pos: &[[f64; 2]], effs: &[Effector]) -> (f64, f64) {
    let mut f = 0.0;
    let mut worst = 0.0f64;
    for e in effs {
        let d2 = dist2(pos[e.joint], e.target);
        f += e.weight * d2;
        if e.weight > 0.0 {
            worst = worst.max(d2);
        }
    }
    (f, worst.sqrt())
}

/// Forward kinematics into `out` (cleared first). Chain must be valid.
fn fk_into(chain: &Chain2d, out: &mut Vec<[f64; 2]>) {
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
fn positions_to_angles(chain: &mut Chain2d, p: &[[f64; 2]]) {
    let mut parent = chain.base_angle;
    for i in 0..chain.lengths.len() {
        let d = sub(p[i + 1], p[i]);
        let rel = if d[0] == 0.0 && d[1] == 0.0 { 0.0 } else { wrap_angle(d[1].atan2(d[0]) - parent) };
        let rel = clamp_to_limits(rel, chain.limits[i]);
        chain.angles[i] = rel;
        parent += rel;
    }
}

fn clamp_all(chain: &mut Chain2d) {
    for (a, &l) in chain.angles.iter_mut().zip(&chain.limits) {
        *a = clamp_to_limits(*a, l);
    }
}

fn check_chain(chain: &Chain2d) -> Result<()> {
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

fn check_point(p: [f64; 2], what: &'static str) -> Result<()> {
    let bad = p.iter().filter(|x| !x.is_finite()).count();
    if bad > 0 {
        return Err(Error::NonFinite { what, count: bad });
    }
    Ok(())
}

fn check_opts(opts: SolveOptions) -> Result<()> {
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
fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

#[inline]
fn norm(a: [f64; 2]) -> f64 {
    a[0].hypot(a[1])
}

#[inline]
fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    let d = sub(a, b);
    d[0] * d[0] + d[1] * d[1]
}

#[cfg(test)]
mod tests {
    //! The private steps of the CCD core; the solvers' behaviour is tested in tests/ik2d.rs.
    use super::*;

    #[test]
    fn a_stall_bend_goes_the_way_the_limits_allow_and_alternates() {
        // knees that bend one way only: asked to bend the other, each bends its own way
        let mut chain = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0; 4]);
        chain.limits = vec![[-PI, PI], [0.0, 2.0], [0.0, 2.0], [0.0, 2.0]];
        perturb(&mut chain, 1); // an odd count bends by a negative angle where it can
        assert!(chain.angles[1..].iter().all(|&a| a > 0.1), "{:?}", chain.angles);
        assert!((chain.angles[0] + 0.5 * chain.angles[1..].iter().sum::<f64>()).abs() < 1e-12);
        // free joints: successive bends curl the chain one way, then the other
        let bend = |count| {
            let mut free = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0; 4]);
            perturb(&mut free, count);
            free.angles[1]
        };
        assert!(bend(0) > 0.1 && bend(1) < -0.1, "{} {}", bend(0), bend(1));
        // and further every second time, out of a saddle the first bends fell back into
        assert!(bend(2) > 1.2 * bend(0) && bend(3) < 1.2 * bend(1), "{} {}", bend(2), bend(3));
    }

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

    #[test]
    fn a_gauss_newton_step_turns_no_joint_more_than_half_a_radian() {
        // nearly straight, with the target well off to the side: the undamped step is long
        let mut chain = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0, 1.0]);
        chain.angles = vec![0.0, 0.02];
        let effs = [Effector { joint: 2, target: [0.3, 1.6], weight: 1.0 }];
        let mut pos = Vec::new();
        fk_into(&chain, &mut pos);
        let f = evaluate(&pos, &effs).0;
        let before = chain.angles.clone();
        let (f_new, _) = lm_step(&mut chain, &effs, &mut pos, f).expect("the step lowers the error");
        assert!(f_new < f);
        for (a, b) in chain.angles.iter().zip(&before) {
            assert!((a - b).abs() <= 0.5 + 1e-12, "{:?} -> {:?}", before, chain.angles);
        }
    }
}
