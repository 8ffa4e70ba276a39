//! Helpers shared by the integration tests. Each test crate uses some of them only.
#![allow(dead_code)]

pub mod rigs;

use miniskeleton_core::weights::Influences;

/// Every vertex has a bone, its weights sum to 1 and each lies in [0, 1]; an unused slot
/// (index -1) has weight 0.
pub fn assert_rows_sum_to_one(inf: &Influences) {
    for v in 0..inf.n() {
        let (idx, w) = inf.row(v);
        assert!(idx[0] >= 0, "vertex {v} has no bone");
        let s: f32 = w.iter().sum();
        assert!((s - 1.0).abs() < 1e-5, "vertex {v} sums to {s}");
        for (&i, &x) in idx.iter().zip(w) {
            assert!(i >= 0 || x == 0.0, "vertex {v}: weight {x} in an unused slot");
            assert!(x.is_finite() && (0.0..=1.0).contains(&x), "vertex {v}: weight {x}");
        }
    }
}
