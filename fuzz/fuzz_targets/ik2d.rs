//! Planar IK (every solver of `posing::ik2d`) and the legs' two-bone IK on any chain, limits,
//! targets and options. When a solver succeeds: angles finite and inside their limits.
#![no_main]

use arbitrary::{Result, Unstructured};
use glam::Vec3;
use libfuzzer_sys::fuzz_target;
use miniskeleton_core::posing::ik2d::{self, Chain2d, SolveOptions, MAX_ITERATIONS};
use miniskeleton_core::posing::{frame_turn, two_bone_ik};
use miniskeleton_core::{Error, Result as CoreResult};
use miniskeleton_fuzz::{number, or_default, point};
use std::f64::consts::PI;

fn f(u: &mut Unstructured) -> Result<f64> {
    Ok(number(u)? as f64)
}

fn chain(u: &mut Unstructured) -> Result<Chain2d> {
    let b = if u.ratio(1u8, 16)? { u.int_in_range(0usize..=300)? } else { u.int_in_range(0usize..=8)? };
    let mut c = Chain2d::straight([f(u)?, f(u)?], f(u)?, (0..b).map(|_| or_default(u, 1.0, f)).collect::<Result<_>>()?);
    for i in 0..b {
        c.angles[i] = or_default(u, 0.0, f)?;
        if u.arbitrary()? {
            c.limits[i] = [f(u)?, f(u)?];
        }
    }
    if u.ratio(1u8, 16)? {
        c.angles.pop();
    }
    Ok(c)
}

fn check(c: &Chain2d, r: CoreResult<ik2d::SolveReport>) {
    match r {
        Ok(rep) => {
            assert!(!rep.error.is_nan(), "error {}", rep.error);
            for (i, (&a, l)) in c.angles.iter().zip(&c.limits).enumerate() {
                assert!(a.is_finite(), "angle {i} is {a}");
                // Bounds saturate at ±pi and angles are in (-pi, pi]: a bound at -pi is the angle pi.
                let (lo, hi) = (l[0].clamp(-PI, PI), l[1].clamp(-PI, PI));
                let at_minus_pi = lo <= -PI && a >= PI - 1e-12;
                assert!(at_minus_pi || (a >= lo - 1e-9 && a <= hi + 1e-9), "angle {i} = {a} outside {l:?}");
            }
        }
        Err(Error::Internal(e)) => panic!("internal error: {e}"),
        Err(_) => {}
    }
}

fn run(u: &mut Unstructured) -> Result<()> {
    let mut c = chain(u)?;
    let target = [f(u)?, f(u)?];
    let opts = SolveOptions {
        max_iterations: or_default(u, 200, |u| u.int_in_range(0..=MAX_ITERATIONS + 1))?,
        tolerance: or_default(u, 1e-3, f)?,
    };
    match u.int_in_range(0u8..=7)? {
        0 => {
            let r = ik2d::solve_ccd(&mut c, target, opts);
            check(&c, r);
        }
        1 => {
            let r = ik2d::solve_ccd_pure(&mut c, target, opts);
            check(&c, r);
        }
        2 => {
            let r = ik2d::solve_fabrik(&mut c, target, opts);
            check(&c, r);
        }
        3 => {
            let r = ik2d::solve_ccd_classic3d(&mut c, target, opts);
            check(&c, r);
        }
        4 => {
            let b = c.lengths.len();
            let effs = (0..u.int_in_range(0usize..=4)?)
                .map(|_| Ok((u.int_in_range(0..=b + 1)?, [f(u)?, f(u)?], or_default(u, 1.0, f)?)))
                .collect::<Result<Vec<_>>>()?;
            let r = ik2d::solve_multi(&mut c, &effs, opts);
            check(&c, r);
        }
        5 => {
            let mut right = chain(u)?;
            let other = [f(u)?, f(u)?];
            match ik2d::solve_two_arm_grip(&mut c, &mut right, target, other, opts) {
                Ok((a, b)) => {
                    check(&c, Ok(a));
                    check(&right, Ok(b));
                }
                Err(e) => check(&c, Err(e)),
            }
        }
        6 => {
            if let Ok(p) = ik2d::forward(&c) {
                assert_eq!(p.len(), c.lengths.len() + 1);
            }
        }
        _ => {
            let v = |u: &mut Unstructured| -> Result<Vec3> { Ok(Vec3::from(point(u)?)) };
            let (root, tgt, pole) = (v(u)?, v(u)?, v(u)?);
            let (l1, l2) = (number(u)?, number(u)?);
            let leg = two_bone_ik(root, tgt, l1, l2, pole);
            let _ = leg.middle;
            let q = frame_turn(v(u)?, v(u)?, v(u)?, v(u)?);
            if q.is_finite() {
                assert!((q.length() - 1.0).abs() < 1e-3, "turn {q:?}");
            }
        }
    }
    Ok(())
}

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});
