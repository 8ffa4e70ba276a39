//! Baselines the CCD solvers are measured against (benches/ik2d.rs): textbook 3D CCD and
//! FABRIK, both on joint positions, read back into clamped relative angles at the end.

use glam::{DQuat, DVec3};

use super::chain::{
    check_chain, check_opts, check_point, dist2, fk_into, norm, positions_to_angles, sub, Chain2d, SolveOptions,
    SolveReport,
};
use crate::Result;

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
