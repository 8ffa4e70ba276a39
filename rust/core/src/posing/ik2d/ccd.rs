//! The CCD solvers: one effector ([`solve_ccd`], [`solve_ccd_pure`]), several on one chain
//! ([`solve_multi`]), two arms on a prop's grips ([`solve_two_arm_grip`]), and their shared core
//! (the closed-form planar step, bends out of a stall, the damped Gauss-Newton polish).

use super::chain::{
    check_chain, check_opts, check_point, clamp_all, clamp_to_limits, dist2, fk_into, norm, sub, wrap_angle, Chain2d,
    SolveOptions, SolveReport,
};
use crate::{Error, Result};

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

#[cfg(test)]
mod tests {
    //! The private steps of the CCD core; the solvers' behaviour is tested in tests/ik2d.rs.
    use std::f64::consts::PI;

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
