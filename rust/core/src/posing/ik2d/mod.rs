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
//! * Baselines for comparison (benches/ik2d.rs, and `ik2d_solve(method=...)` in Python):
//!   [`solve_ccd_classic3d`] (textbook 3D CCD, Wang & Chen 1991 / Welman 1993) and
//!   [`solve_fabrik`] (Aristidou & Lasenby 2011).
//!
//! Files: `chain.rs` (the chain, its options and report, forward kinematics, the checks every
//! solver runs), `ccd.rs` (the CCD solvers and their Gauss-Newton polish), `baselines.rs` (the
//! two baselines).

mod baselines;
mod ccd;
mod chain;

pub use baselines::{solve_ccd_classic3d, solve_fabrik};
pub use ccd::{solve_ccd, solve_ccd_pure, solve_multi, solve_two_arm_grip};
pub use chain::{clamp_to_limits, forward, wrap_angle, Chain2d, SolveOptions, SolveReport, MAX_ITERATIONS};
