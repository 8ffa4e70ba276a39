//! Planar IK benchmark: improved CCD vs. the paper's plain CCD step vs. classic 3D CCD vs. FABRIK.
//!
//! For chains of 2, 3, 5 and 10 bones, `TARGETS` random reachable targets each (forward
//! kinematics of uniformly random joint angles, random bone lengths in [0.5, 1.5)), every solve
//! starting from the same rest pose (base at the origin, every relative angle 0.1 rad), to a
//! tolerance of 1e-3 of the chain length with at most 200 passes, no joint limits (FABRIK and
//! the classic CCD do not enforce limits during iterations). Prints a markdown table.
//!
//! Run: `cargo bench -p miniskeleton-core --bench ik2d`. Deterministic (xorshift RNG).

use std::f64::consts::PI;
use std::hint::black_box;
use std::time::Instant;

use miniskeleton_core::posing::ik2d::{
    forward, solve_ccd, solve_ccd_classic3d, solve_ccd_pure, solve_fabrik, Chain2d, SolveOptions, SolveReport,
};
use miniskeleton_core::Result;

const TARGETS: usize = 2000;
const REPEATS: usize = 5;

/// xorshift64*.
struct Rng(u64);
impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

type Solver = fn(&mut Chain2d, [f64; 2], SolveOptions) -> Result<SolveReport>;

fn main() {
    let methods: [(&str, Solver); 4] = [
        ("improved CCD (ours)", solve_ccd),
        ("paper CCD step only", solve_ccd_pure),
        ("classic 3D CCD", solve_ccd_classic3d),
        ("FABRIK", solve_fabrik),
    ];
    println!("{TARGETS} random reachable targets per chain length, tolerance 1e-3 x chain length, max 200 passes; time = best of {REPEATS} runs\n");
    println!("| bones | method | mean iterations | mean µs / solve | failure rate |");
    println!("|---:|---|---:|---:|---:|");
    for b in [2usize, 3, 5, 10] {
        let mut rng = Rng(0x1234_5678_9ABC_DEF0 ^ b as u64);
        let mut cases = Vec::with_capacity(TARGETS);
        for _ in 0..TARGETS {
            let lengths: Vec<f64> = (0..b).map(|_| rng.uniform(0.5, 1.5)).collect();
            let mut rest = Chain2d::straight([0.0, 0.0], 0.0, lengths);
            rest.angles.iter_mut().for_each(|a| *a = 0.1);
            let mut posed = rest.clone();
            posed.angles.iter_mut().for_each(|a| *a = rng.uniform(-PI, PI));
            let target = *forward(&posed).unwrap().last().unwrap();
            let opts = SolveOptions { max_iterations: 200, tolerance: 1e-3 * rest.reach() };
            cases.push((rest, target, opts));
        }
        for (name, solve) in methods {
            let mut best_secs = f64::INFINITY;
            let mut chains: Vec<Chain2d> = Vec::new();
            let mut reports: Vec<SolveReport> = Vec::new();
            for _ in 0..REPEATS {
                chains = cases.iter().map(|c| c.0.clone()).collect();
                reports.clear();
                reports.reserve(TARGETS);
                let t0 = Instant::now();
                for (chain, (_, target, opts)) in chains.iter_mut().zip(&cases) {
                    reports.push(solve(black_box(chain), black_box(*target), *opts).unwrap());
                }
                best_secs = best_secs.min(t0.elapsed().as_secs_f64());
            }
            // Failure: judged independently from the final angles, not from the report.
            let failures = chains
                .iter()
                .zip(&cases)
                .filter(|(chain, (_, t, opts))| {
                    let tip = *forward(chain).unwrap().last().unwrap();
                    let d = (tip[0] - t[0]).hypot(tip[1] - t[1]);
                    d.is_nan() || d > opts.tolerance
                })
                .count();
            let iters = reports.iter().map(|r| r.iterations).sum::<usize>() as f64 / TARGETS as f64;
            println!(
                "| {b} | {name} | {iters:.2} | {:.2} | {:.2} % |",
                best_secs * 1e6 / TARGETS as f64,
                100.0 * failures as f64 / TARGETS as f64
            );
        }
    }
}
