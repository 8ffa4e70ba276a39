//! Bone-heat benchmark on generated capped cylinders (plain `std::time`, no harness).
//! Run: `cargo bench -p miniskeleton-core --bench heat` (`HEAT_BENCH_MAX=<vertices>` skips the
//! larger sizes, `HEAT_BENCH_REPEATS=<n>` takes the best of n runs instead of 2).

use miniskeleton_core::primitives::{bone_chain, capped_cylinder};
use miniskeleton_core::weights::{bilinear_weights, BilinearOptions};
use miniskeleton_core::weights::{heat_weights, HeatOptions};
use miniskeleton_core::weights::{idw_weights, IdwOptions};
use std::time::Instant;

fn main() {
    // (rings, segments, bones): ~6.5k, 26k, 103k, 206k vertices.
    let sizes = [(81, 80, 10), (161, 160, 20), (321, 320, 40), (454, 454, 40)];
    let only: Option<usize> = std::env::var("HEAT_BENCH_MAX").ok().and_then(|s| s.parse().ok());
    let repeats: usize = std::env::var("HEAT_BENCH_REPEATS").ok().and_then(|s| s.parse().ok()).unwrap_or(2).max(1);
    println!("threads: {}", rayon::current_num_threads());
    for &(rings, segs, nb) in &sizes {
        let height = 2.0;
        let (v, t) = capped_cylinder(0.15, height, rings, segs);
        if only.is_some_and(|m| v.len() > m) {
            continue;
        }
        let (h, tl, _) = bone_chain(height, nb);
        let opts = HeatOptions::default();
        // Warm-up on the smallest run only matters for the thread pool; take the best run.
        let mut best = f64::INFINITY;
        let mut timings = Vec::new();
        for _ in 0..repeats {
            let s = Instant::now();
            let (inf, rep) = heat_weights(&v, &t, &h, &tl, &opts, None).expect("heat");
            let e = s.elapsed().as_secs_f64();
            assert_eq!(inf.n(), v.len());
            if e < best {
                best = e;
                timings = rep.timings.clone();
            }
        }
        let get = |k: &str| timings.iter().find(|(n, _)| *n == k).map_or(0.0, |x| x.1);
        println!(
            "heat {:>7} verts {:>7} tris {:>3} bones: total {:.3} s | factor+solve {:.3} s (symbolic {:.3} [overlapped with visibility], factor {:.3}, solve {:.3}) | total / (sym+f+s) {:.2}",
            v.len(),
            t.len(),
            nb,
            best,
            get("symbolic") + get("factor") + get("solve"),
            get("symbolic"),
            get("factor"),
            get("solve"),
            best / (get("symbolic") + get("factor") + get("solve")),
        );
        let detail: Vec<String> = timings.iter().map(|(n, s)| format!("{n} {:.3}", s)).collect();
        println!("     stages: {}", detail.join(", "));
        if (rings, segs, nb) == sizes[sizes.len() - 1] {
            let (_, _, parents) = bone_chain(height, nb);
            let s = Instant::now();
            let inf = idw_weights(&v, &h, &tl, &IdwOptions::default()).expect("idw");
            let e_idw = s.elapsed().as_secs_f64();
            let s = Instant::now();
            let inf2 = bilinear_weights(&v, &h, &tl, &parents, &BilinearOptions::default()).expect("bilinear");
            let e_bil = s.elapsed().as_secs_f64();
            assert_eq!((inf.n(), inf2.n()), (v.len(), v.len()));
            println!("idw      {:>7} verts {:>3} bones: {:.3} s", v.len(), nb, e_idw);
            println!("bilinear {:>7} verts {:>3} bones: {:.3} s", v.len(), nb, e_bil);
        }
    }
}
