//! Planar IK for shadow puppets: improved CCD, multi-effector strips, two-arm grip, baselines.

use std::f64::consts::PI;

use miniskeleton_core::posing::ik2d::{
    clamp_to_limits, forward, solve_ccd, solve_ccd_classic3d, solve_ccd_pure, solve_fabrik, solve_multi,
    solve_two_arm_grip, wrap_angle, Chain2d, SolveOptions, SolveReport, MAX_ITERATIONS,
};
use miniskeleton_core::{Error, Result};

type Solver = fn(&mut Chain2d, [f64; 2], SolveOptions) -> Result<SolveReport>;

/// xorshift64*: tiny deterministic RNG, no dependency.
struct Rng(u64);
impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [lo, hi).
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

fn tip(chain: &Chain2d) -> [f64; 2] {
    *forward(chain).unwrap().last().unwrap()
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// A chain of `b` bones with random lengths in [0.5, 1.5), straight, unlimited.
fn random_chain(rng: &mut Rng, b: usize) -> Chain2d {
    let lengths = (0..b).map(|_| rng.uniform(0.5, 1.5)).collect();
    Chain2d::straight([rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)], rng.uniform(-PI, PI), lengths)
}

/// A reachable target: forward kinematics of random angles.
fn random_target(rng: &mut Rng, chain: &Chain2d) -> [f64; 2] {
    let mut c = chain.clone();
    c.angles.iter_mut().for_each(|a| *a = rng.uniform(-PI, PI));
    tip(&c)
}

fn assert_within_limits(chain: &Chain2d) {
    for (i, (&a, l)) in chain.angles.iter().zip(&chain.limits).enumerate() {
        assert!(a.is_finite(), "joint {i} angle {a}");
        assert!(a > -PI && a <= PI, "joint {i} angle {a} not wrapped");
        assert!(a >= l[0].max(-PI) - 1e-12 && a <= l[1].min(PI) + 1e-12, "joint {i}: {a} outside {l:?}");
    }
}

/// Fuzz finding (`fuzz/`, target ik2d): limits beyond ±pi saturate at both ends, so a joint
/// limited to `[3.5, 3.5]` (beyond pi) ends at pi, the saturated bound, whatever the solver.
/// Before, the lower bound was left at 3.5 above the saturated upper one, and the angle came
/// out at pi or at 3.5 - 2 pi depending on which bound was nearer the start.
#[test]
fn limits_beyond_pi_saturate_at_both_ends() {
    assert_eq!(clamp_to_limits(0.0, [3.5, 3.5]), PI);
    assert_eq!(clamp_to_limits(-3.0, [-9.0, -4.0]), PI);
    let solvers: [Solver; 4] = [solve_ccd, solve_ccd_pure, solve_fabrik, solve_ccd_classic3d];
    for (k, solve) in solvers.iter().enumerate() {
        for target in [[1.0, 0.5], [-0.5, -0.3], [0.0, 2.0]] {
            let mut c = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0, 1.0]);
            c.limits[0] = [3.5, 3.5];
            solve(&mut c, target, SolveOptions::default()).unwrap();
            assert_eq!(c.angles[0], PI, "solver {k}, target {target:?}");
        }
    }
}

#[test]
fn forward_kinematics_known_pose() {
    let mut c = Chain2d::straight([1.0, 2.0], PI / 2.0, vec![1.0, 2.0, 0.5]);
    c.angles = vec![0.0, -PI / 2.0, -PI / 2.0];
    let p = forward(&c).unwrap();
    let expect = [[1.0, 2.0], [1.0, 3.0], [3.0, 3.0], [3.0, 2.5]];
    assert_eq!(p.len(), 4);
    for (a, b) in p.iter().zip(&expect) {
        assert!(dist(*a, *b) < 1e-12, "{a:?} != {b:?}");
    }
}

#[test]
fn angle_helpers() {
    assert_eq!(wrap_angle(PI), PI);
    assert!((wrap_angle(-PI) - PI).abs() < 1e-15);
    assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
    assert!((wrap_angle(-7.0) - (-7.0 + 2.0 * PI)).abs() < 1e-12);
    let lim = [0.0, 150f64.to_radians()];
    // -170 deg is 40 deg from 150 deg around the circle, 170 deg from 0.
    assert_eq!(clamp_to_limits((-170f64).to_radians(), lim), lim[1]);
    assert_eq!(clamp_to_limits((-10f64).to_radians(), lim), 0.0);
    assert_eq!(clamp_to_limits(1.0, lim), 1.0);
}

#[test]
fn random_reachable_targets_are_reached() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    for b in [2usize, 3, 5, 10] {
        let mut failures = 0;
        let trials = 200;
        for _ in 0..trials {
            let rest = random_chain(&mut rng, b);
            let target = random_target(&mut rng, &rest);
            let mut c = rest.clone();
            let opts = SolveOptions::for_chain(&c);
            let rep = solve_ccd(&mut c, target, opts).unwrap();
            let err = dist(tip(&c), target);
            assert!((err - rep.error).abs() < 1e-9, "reported {} but tip is {err} away", rep.error);
            assert_within_limits(&c);
            if !(rep.reached && err <= opts.tolerance) {
                failures += 1;
            }
        }
        assert_eq!(failures, 0, "{b} bones: {failures}/{trials} random reachable targets missed");
    }
}

#[test]
fn unreachable_target_gives_straight_chain_pointing_at_it() {
    let mut rng = Rng(7);
    for b in [1usize, 2, 3, 5, 10] {
        for _ in 0..20 {
            let mut c = random_chain(&mut rng, b);
            c.angles.iter_mut().for_each(|a| *a = rng.uniform(-2.0, 2.0));
            let reach = c.reach();
            let dir = rng.uniform(-PI, PI);
            let d = reach * rng.uniform(1.05, 3.0);
            let target = [c.base[0] + d * dir.cos(), c.base[1] + d * dir.sin()];
            let opts = SolveOptions::for_chain(&c);
            let rep = solve_ccd(&mut c, target, opts).unwrap();
            assert!(!rep.reached);
            assert!((rep.error - (d - reach)).abs() < 1e-9, "error {} vs {}", rep.error, d - reach);
            let p = forward(&c).unwrap();
            for i in 0..b {
                let bone = (p[i + 1][1] - p[i][1]).atan2(p[i + 1][0] - p[i][0]);
                assert!(wrap_angle(bone - dir).abs() < 1e-6, "bone {i} points {bone}, target {dir}");
            }
        }
    }
}

#[test]
fn collinear_starts_converge() {
    for b in [2usize, 3, 5, 10] {
        for base_angle in [0.0, 0.7, -2.0] {
            let lengths: Vec<f64> = (0..b).map(|i| 1.0 + 0.1 * i as f64).collect();
            let rest = Chain2d::straight([0.5, -0.25], base_angle, lengths);
            let reach = rest.reach();
            let (s, c) = f64::sin_cos(base_angle);
            // 60 % of reach straight ahead, and straight behind the base.
            for (name, k) in [("ahead", 0.6), ("behind", -0.5)] {
                let target = [0.5 + k * reach * c, -0.25 + k * reach * s];
                // Both with and without the Gauss-Newton polish: the bend-on-stall alone must
                // get the paper's CCD step out of the collinear saddle.
                for (variant, solve) in [("ccd", solve_ccd as Solver), ("pure", solve_ccd_pure)] {
                    let mut chain = rest.clone();
                    let opts = SolveOptions { max_iterations: 1000, tolerance: 1e-3 * reach };
                    let rep = solve(&mut chain, target, opts).unwrap();
                    let err = dist(tip(&chain), target);
                    assert!(
                        rep.reached && err <= opts.tolerance,
                        "{variant}, {b} bones, base {base_angle}, {name}: error {err} after {} passes",
                        rep.iterations
                    );
                    assert_within_limits(&chain);
                }
            }
        }
    }
}

#[test]
fn classic_ccd_stalls_on_collinear_start() {
    // Documents why the improved solver handles collinearity: the textbook CCD cannot move.
    let mut c = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0, 1.0, 1.0]);
    let opts = SolveOptions::for_chain(&c);
    let rep = solve_ccd_classic3d(&mut c, [1.8, 0.0], opts).unwrap();
    assert!(!rep.reached);
    assert!((rep.error - 1.2).abs() < 1e-9);
}

#[test]
fn joint_limits_hold_after_solving() {
    let mut rng = Rng(42);
    let elbow = [0.0, 150f64.to_radians()];
    let mut reached = 0;
    for _ in 0..300 {
        let mut c = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0, 0.9]);
        c.limits[1] = elbow;
        // Random target anywhere in (and a bit beyond) the disc of reach.
        let r = rng.uniform(0.0, 2.2);
        let a = rng.uniform(-PI, PI);
        let target = [r * a.cos(), r * a.sin()];
        let opts = SolveOptions::for_chain(&c);
        let rep = solve_ccd(&mut c, target, opts).unwrap();
        assert_within_limits(&c);
        assert!(c.angles[1] >= elbow[0] && c.angles[1] <= elbow[1]);
        // With a free shoulder the elbow range [0, 150] reaches the annulus
        // |1 + 0.9 e^{i 150deg}| <= r <= 1.9 (mirror poses are available by the shoulder).
        let inner = (1.0f64 + 0.9 * 150f64.to_radians().cos()).hypot(0.9 * 150f64.to_radians().sin());
        if r > inner + 0.01 && r < 1.89 {
            assert!(rep.reached, "r = {r}: error {}", rep.error);
            reached += 1;
        }
    }
    assert!(reached > 100);
}

/// Angles that start outside their limits (a rigger typed them, or tightened a limit) are
/// brought inside even when the tip already lies on the target, where no pass runs: the
/// single-effector and the multi-effector solver both leave every angle within its limits.
#[test]
fn angles_outside_their_limits_are_clamped_even_on_target() {
    let mut c = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0, 0.8, 0.6]);
    c.angles = vec![0.2, 1.2, -1.0];
    c.limits = vec![[-PI, PI], [-0.5, 0.5], [-0.5, 0.5]];
    let target = tip(&c);
    let opts = SolveOptions::for_chain(&c);
    let (mut single, mut multi) = (c.clone(), c.clone());
    let rep = solve_ccd(&mut single, target, opts).unwrap();
    assert_within_limits(&single);
    assert!((dist(tip(&single), target) - rep.error).abs() < 1e-9, "{rep:?}");
    let rep = solve_multi(&mut multi, &[(3, target, 1.0)], opts).unwrap();
    assert_within_limits(&multi);
    assert!((dist(tip(&multi), target) - rep.error).abs() < 1e-9, "{rep:?}");
}

/// Smallest tip distance to `target` over a dense grid of poses within the limits (2 bones).
fn brute_force_best(c: &Chain2d, target: [f64; 2]) -> f64 {
    let n = 1500;
    let mut best = f64::INFINITY;
    let mut t = c.clone();
    for i in 0..=n {
        t.angles[0] = c.limits[0][0] + (c.limits[0][1] - c.limits[0][0]) * i as f64 / n as f64;
        for j in 0..=n {
            t.angles[1] = c.limits[1][0] + (c.limits[1][1] - c.limits[1][0]) * j as f64 / n as f64;
            best = best.min(dist(tip(&t), target));
        }
    }
    best
}

#[test]
fn target_unreachable_within_limits_is_approached_as_closely_as_possible() {
    let cases = [
        // Inside the inner radius left by the elbow limit.
        ([-PI, PI], [0.0, 150f64.to_radians()], [0.2, 0.1]),
        // Shoulder limited to +-30 deg, target straight up.
        ([(-30f64).to_radians(), 30f64.to_radians()], [0.0, 150f64.to_radians()], [0.0, 1.5]),
        // Far away, but the elbow may not straighten: the closed-form straight pose is illegal.
        ([-PI, PI], [30f64.to_radians(), 150f64.to_radians()], [-3.0, 2.0]),
        // Shoulder limited, target behind.
        ([(-45f64).to_radians(), 45f64.to_radians()], [0.0, 120f64.to_radians()], [-1.0, -0.3]),
    ];
    for (k, (shoulder, elbow, target)) in cases.into_iter().enumerate() {
        let mut c = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0, 1.0]);
        c.limits = vec![shoulder, elbow];
        let best = brute_force_best(&c, target);
        let opts = SolveOptions::for_chain(&c);
        let rep = solve_ccd(&mut c, target, opts).unwrap();
        assert_within_limits(&c);
        assert!(!rep.reached, "case {k}");
        let err = dist(tip(&c), target);
        assert!((err - rep.error).abs() < 1e-9);
        assert!(err <= best + 1e-3, "case {k}: error {err}, brute-force best {best}");
    }
}

#[test]
fn zero_length_bones_give_finite_angles() {
    let mut rng = Rng(99);
    for lengths in [vec![1.0, 0.0, 1.0], vec![0.0, 1.0, 1.0], vec![1.0, 1.0, 0.0], vec![0.0, 0.0]] {
        for _ in 0..50 {
            let mut c = Chain2d::straight([0.0, 0.0], 0.3, lengths.clone());
            let target = random_target(&mut rng, &c);
            let reach = c.reach();
            let opts = SolveOptions { max_iterations: 200, tolerance: 1e-3 * reach.max(1.0) };
            let rep = solve_ccd(&mut c, target, opts).unwrap();
            assert!(rep.error.is_finite());
            assert_within_limits(&c);
            assert!(forward(&c).unwrap().iter().all(|p| p[0].is_finite() && p[1].is_finite()));
            assert!(rep.reached, "{lengths:?}: error {}", rep.error);
        }
        // Also an unreachable target and a target on the base.
        let mut c = Chain2d::straight([0.0, 0.0], 0.3, lengths.clone());
        let rep = solve_ccd(&mut c, [5.0, 5.0], SolveOptions::default()).unwrap();
        assert!(rep.error.is_finite() && !rep.reached);
        let rep = solve_ccd(&mut c, [0.0, 0.0], SolveOptions::default()).unwrap();
        assert!(rep.error.is_finite());
        assert_within_limits(&c);
    }
}

#[test]
fn multi_effector_strip_reaches_head_middle_and_tail() {
    let mut rng = Rng(2024);
    for b in [4usize, 8, 12] {
        for _ in 0..30 {
            let rest = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0; b]);
            // Targets from one random pose: jointly reachable. Keep the strip gently curved
            // (relative angles within +-60 deg) like a snake or dragon.
            let mut pose = rest.clone();
            pose.angles.iter_mut().for_each(|a| *a = rng.uniform(-1.0, 1.0));
            let p = forward(&pose).unwrap();
            let effectors = [(b / 3, p[b / 3], 1.0), (2 * b / 3, p[2 * b / 3], 1.0), (b, p[b], 2.0)];
            let mut c = rest.clone();
            let opts = SolveOptions { max_iterations: 200, tolerance: 1e-3 * c.reach() };
            let rep = solve_multi(&mut c, &effectors, opts).unwrap();
            let q = forward(&c).unwrap();
            let worst = effectors.iter().map(|&(j, t, _)| dist(q[j], t)).fold(0.0, f64::max);
            assert!((worst - rep.error).abs() < 1e-9);
            assert!(rep.reached && worst <= opts.tolerance, "{b} bones: worst {worst}, {rep:?}");
        }
    }
}

#[test]
fn multi_effector_single_tip_matches_solve_ccd() {
    let mut rng = Rng(5);
    let rest = random_chain(&mut rng, 5);
    let target = random_target(&mut rng, &rest);
    let (mut a, mut b) = (rest.clone(), rest.clone());
    let opts = SolveOptions::for_chain(&rest);
    let ra = solve_ccd(&mut a, target, opts).unwrap();
    let rb = solve_multi(&mut b, &[(5, target, 1.0)], opts).unwrap();
    assert_eq!(ra, rb);
    assert_eq!(a.angles, b.angles);
}

#[test]
fn multi_effector_conflicting_targets_give_least_squares_compromise() {
    // One bone, two equally weighted targets for its tip at +-90 deg: the best is between.
    let mut c = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0]);
    c.angles[0] = 1.0;
    let rep = solve_multi(&mut c, &[(1, [0.0, 1.0], 1.0), (1, [1.0, -1.0], 1.0)], SolveOptions::default()).unwrap();
    assert!(!rep.reached);
    // Procrustes: direction of the weighted sum of targets = (1, 0) -> angle 0.
    assert!(c.angles[0].abs() < 1e-9, "{}", c.angles[0]);
}

/// An effector of weight 0 (a strip's tail rod switched off) is not aimed for and does not
/// count in the report: its error and `reached` are over the effectors with positive weight.
#[test]
fn multi_effector_of_weight_zero_is_left_out_of_the_report() {
    let mut c = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0; 4]);
    let mut pose = c.clone();
    pose.angles = vec![0.3, -0.4, 0.5, 0.2];
    let middle = forward(&pose).unwrap()[2];
    let opts = SolveOptions::for_chain(&c);
    let rep = solve_multi(&mut c, &[(2, middle, 1.0), (4, [50.0, 50.0], 0.0)], opts).unwrap();
    let q = forward(&c).unwrap();
    assert!((rep.error - dist(q[2], middle)).abs() < 1e-12, "{rep:?}");
    assert!(rep.reached && rep.error <= opts.tolerance, "{rep:?}");
}

/// A solve never leaves the chain farther from its target than it found it: chains of 2 to 8
/// bones with limits on every joint but the first, started again from their own answer. Where
/// the target cannot be reached within the limits the solver stalls, bends the chain out of the
/// stall and gives up; it must return the best pose it saw, not the last one (that was up to
/// 0.87 farther). A puppet re-solved on every frame change must not creep away from its rod.
#[test]
fn a_solve_never_ends_farther_than_it_started() {
    let mut rng = Rng(4242);
    let mut stalled = 0;
    for k in 0..700 {
        let b = 2 + k % 7;
        let mut c = random_chain(&mut rng, b);
        for l in c.limits.iter_mut().skip(1) {
            let w = rng.uniform(0.2, 1.5);
            *l = [-w * rng.uniform(0.0, 1.0), w];
        }
        let angle = rng.uniform(-PI, PI);
        let r = c.reach() * rng.uniform(0.0, 1.6);
        let target = [c.base[0] + r * angle.cos(), c.base[1] + r * angle.sin()];
        let opts = SolveOptions::for_chain(&c);
        let first = solve_ccd(&mut c, target, opts).unwrap();
        let start = dist(tip(&c), target);
        let again = solve_ccd(&mut c, target, opts).unwrap();
        assert_within_limits(&c);
        assert!((dist(tip(&c), target) - again.error).abs() < 1e-9);
        assert!(again.error <= start + 1e-12, "case {k}: {start} -> {again:?} (first {first:?})");
        stalled += usize::from(!again.reached && again.iterations > 0);
    }
    assert!(stalled >= 70, "only {stalled} of 700 cases stalled: the test lost its point");
}

#[test]
fn two_arm_grip_follows_rotating_prop() {
    // Puppet torso: shoulders at (-0.3, 1.0) and (0.3, 1.0); arms hang down; a pole of
    // length 0.6 centred at (0, 0.6) is turned from -60 to +60 degrees.
    let arm = |x: f64| {
        let mut c = Chain2d::straight([x, 1.0], -PI / 2.0, vec![0.4, 0.35]);
        c.limits[1] = if x < 0.0 { [-150f64.to_radians(), 0.0] } else { [0.0, 150f64.to_radians()] };
        c
    };
    let (mut left, mut right) = (arm(-0.3), arm(0.3));
    let opts = SolveOptions { max_iterations: 200, tolerance: 1e-3 * 0.75 };
    let mut frames = 0;
    for step in -6..=6 {
        let a = (10.0 * step as f64).to_radians();
        let (s, c) = a.sin_cos();
        let centre = [0.0, 0.6];
        let grip_l = [centre[0] - 0.3 * c, centre[1] - 0.3 * s];
        let grip_r = [centre[0] + 0.3 * c, centre[1] + 0.3 * s];
        let (rl, rr) = solve_two_arm_grip(&mut left, &mut right, grip_l, grip_r, opts).unwrap();
        assert!(rl.reached && rr.reached, "prop at {a}: {rl:?} {rr:?}");
        assert!(dist(tip(&left), grip_l) <= opts.tolerance);
        assert!(dist(tip(&right), grip_r) <= opts.tolerance);
        assert_within_limits(&left);
        assert_within_limits(&right);
        frames += 1;
    }
    assert_eq!(frames, 13);
}

#[test]
fn baselines_reach_random_targets() {
    let mut rng = Rng(31337);
    for b in [2usize, 5] {
        let mut fabrik_ok = 0;
        let mut classic_ok = 0;
        for _ in 0..100 {
            let rest = random_chain(&mut rng, b);
            let target = random_target(&mut rng, &rest);
            let opts = SolveOptions::for_chain(&rest);
            let mut f = rest.clone();
            let rf = solve_fabrik(&mut f, target, opts).unwrap();
            assert!((dist(tip(&f), target) - rf.error).abs() < 1e-9);
            fabrik_ok += rf.reached as usize;
            let mut c = rest.clone();
            let rc = solve_ccd_classic3d(&mut c, target, opts).unwrap();
            assert!((dist(tip(&c), target) - rc.error).abs() < 1e-9);
            classic_ok += rc.reached as usize;
        }
        assert!(fabrik_ok >= 95, "{b} bones: FABRIK reached {fabrik_ok}/100");
        assert!(classic_ok >= 90, "{b} bones: classic CCD reached {classic_ok}/100");
    }
    // FABRIK on an unreachable target: straight toward it.
    let mut c = Chain2d::straight([0.0, 0.0], 1.0, vec![1.0, 1.0]);
    let rep = solve_fabrik(&mut c, [3.0, 0.0], SolveOptions::default()).unwrap();
    assert!((rep.error - 1.0).abs() < 1e-12);
    assert!((c.angles[0] + 1.0).abs() < 1e-12 && c.angles[1].abs() < 1e-12, "{:?}", c.angles);
}

#[test]
fn invalid_input_is_an_error_and_leaves_chain_untouched() {
    let good = Chain2d::straight([0.0, 0.0], 0.0, vec![1.0, 1.0]);
    let opts = SolveOptions::default();

    let mut c = good.clone();
    assert_eq!(solve_ccd(&mut c, [f64::NAN, f64::INFINITY], opts), Err(Error::NonFinite { what: "target", count: 2 }));
    assert_eq!(c, good);

    let mut c = good.clone();
    c.angles[1] = f64::NAN;
    let before = c.clone();
    assert!(matches!(solve_ccd(&mut c, [1.0, 1.0], opts), Err(Error::NonFinite { count: 1, .. })));
    assert!(c.angles[1].is_nan() && c.lengths == before.lengths);

    let mut c = good.clone();
    c.angles.pop();
    assert!(matches!(solve_fabrik(&mut c, [1.0, 1.0], opts), Err(Error::Shape(_))));
    assert!(matches!(forward(&c), Err(Error::Shape(_))));

    let mut c = good.clone();
    c.lengths[0] = -1.0;
    assert!(matches!(solve_ccd_classic3d(&mut c, [1.0, 1.0], opts), Err(Error::InvalidArgument(_))));

    let mut c = good.clone();
    c.limits[0] = [0.2, 0.1]; // min > max, however little
    assert!(matches!(solve_ccd(&mut c, [1.0, 1.0], opts), Err(Error::InvalidArgument(_))));
    c.limits[0] = [f64::NAN, 0.1];
    assert_eq!(solve_ccd(&mut c, [1.0, 1.0], opts), Err(Error::NonFinite { what: "joint limit", count: 1 }));

    // each finite, their sum not
    let mut c = Chain2d::straight([0.0, 0.0], 0.0, vec![f64::MAX, f64::MAX]);
    let err = solve_ccd(&mut c, [1.0, 1.0], opts).unwrap_err().to_string();
    assert!(err.contains("overflow"), "{err}");

    let mut c = Chain2d::straight([0.0, 0.0], 0.0, vec![]);
    assert!(matches!(solve_ccd(&mut c, [1.0, 1.0], opts), Err(Error::NoBones(_))));

    let mut c = good.clone();
    for tolerance in [f64::NAN, -1e-3] {
        let bad_opts = SolveOptions { max_iterations: 10, tolerance };
        assert!(matches!(solve_ccd(&mut c, [1.0, 1.0], bad_opts), Err(Error::InvalidArgument(_))));
    }

    let mut c = good.clone();
    for effs in [
        vec![],
        vec![(0usize, [1.0, 0.0], 1.0)],
        vec![(3, [1.0, 0.0], 1.0)],
        vec![(2, [1.0, 0.0], -1.0)],
        vec![(2, [1.0, 0.0], 0.0)],
    ] {
        assert!(matches!(solve_multi(&mut c, &effs, opts), Err(Error::InvalidArgument(_))), "{effs:?}");
    }
    assert!(matches!(solve_multi(&mut c, &[(2, [f64::NAN, 0.0], 1.0)], opts), Err(Error::NonFinite { .. })));
    assert_eq!(c, good);

    let (mut l, mut r) = (good.clone(), good.clone());
    r.lengths.push(1.0);
    assert!(solve_two_arm_grip(&mut l, &mut r, [1.0, 1.0], [1.0, 1.0], opts).is_err());
    assert_eq!(l, good);
}

/// `max_iterations` is bounded: the solvers run without Python's GIL, so a huge count (a typo,
/// a script's `10**12`) would hold Blender with no way to interrupt it. Above
/// `MAX_ITERATIONS` every solver is an error naming the bound and leaves the chain as it was;
/// at the bound a solve that never converges (tolerance 0) runs every pass, in well under a
/// second for a 16-bone chain.
#[test]
fn max_iterations_above_the_bound_is_an_error_for_every_solver() {
    assert_eq!(MAX_ITERATIONS, 10_000);
    let good = Chain2d::straight([0.0, 0.0], 0.3, vec![0.25; 16]);
    let target = [1.3, 2.1];
    let over = SolveOptions { max_iterations: MAX_ITERATIONS + 1, tolerance: 1e-3 };
    let huge = SolveOptions { max_iterations: usize::MAX, tolerance: 1e-3 };
    let solvers: [(&str, Solver); 4] = [
        ("ccd", solve_ccd),
        ("ccd_pure", solve_ccd_pure),
        ("classic3d", solve_ccd_classic3d),
        ("fabrik", solve_fabrik),
    ];
    for (name, solve) in solvers {
        for opts in [over, huge] {
            let mut c = good.clone();
            let err = solve(&mut c, target, opts).unwrap_err();
            assert_eq!(
                err,
                Error::InvalidArgument(format!("max_iterations must be at most 10000, got {}", opts.max_iterations)),
                "{name}"
            );
            assert_eq!(c, good, "{name}");
        }
    }
    let mut c = good.clone();
    assert!(matches!(solve_multi(&mut c, &[(16, target, 1.0)], over), Err(Error::InvalidArgument(_))));
    let (mut l, mut r) = (good.clone(), good.clone());
    assert!(matches!(solve_two_arm_grip(&mut l, &mut r, target, target, huge), Err(Error::InvalidArgument(_))));
    assert!(c == good && l == good && r == good);

    let at = SolveOptions { max_iterations: MAX_ITERATIONS, tolerance: 0.0 };
    let mut c = good.clone(); // the O(b^2)-per-pass baseline: the slowest pass there is
    let t0 = std::time::Instant::now();
    let rep = solve_ccd_classic3d(&mut c, target, at).unwrap();
    let took = t0.elapsed().as_secs_f64();
    assert_eq!(rep.iterations, MAX_ITERATIONS, "{rep:?}");
    assert!(took < 1.0, "{MAX_ITERATIONS} passes took {took:.3} s");
}
