//! Integration tests of the closed-form weighting methods (IDW, bilinear) and top-k.

mod common;
use common::assert_rows_sum_to_one;
use glam::DVec3;
use miniskeleton_core::mesh::closest_point_on_segment;
use miniskeleton_core::primitives::{bone_chain, capped_cylinder};
use miniskeleton_core::weights::{bilinear_weights, BilinearOptions, Falloff};
use miniskeleton_core::weights::{idw_weights, IdwOptions};
use miniskeleton_core::weights::{top_k_normalized, Influences};
use miniskeleton_core::Error;

/// Index of the nearest bone segment and the margin to the second nearest.
fn nearest_bone(p: [f32; 3], heads: &[[f32; 3]], tails: &[[f32; 3]]) -> (usize, f64) {
    let d = |a: [f32; 3]| DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
    let mut ds: Vec<(f64, usize)> = heads
        .iter()
        .zip(tails)
        .enumerate()
        .map(|(j, (h, t))| (closest_point_on_segment(d(p), d(*h), d(*t)).1, j))
        .collect();
    ds.sort_by(|a, b| a.0.total_cmp(&b.0));
    (ds[0].1, ds[1].0 - ds[0].0)
}

#[test]
fn idw_rows_sum_to_one_and_strongest_is_nearest() {
    let (v, _) = capped_cylinder(0.2, 2.0, 30, 12);
    let (h, t, _) = bone_chain(2.0, 5);
    let inf = idw_weights(&v, &h, &t, &IdwOptions::default()).unwrap();
    assert_eq!(inf.n(), v.len());
    assert_eq!(inf.k, 4);
    // More influences than bones: one column per bone (not n x max_influences slots).
    let many = idw_weights(&v, &h, &t, &IdwOptions { max_influences: 1 << 40, ..Default::default() }).unwrap();
    assert_eq!(many.k, h.len());
    assert_rows_sum_to_one(&inf);
    let mut checked = 0;
    for (i, p) in v.iter().enumerate() {
        let (near, margin) = nearest_bone(*p, &h, &t);
        if margin > 1e-3 {
            assert_eq!(inf.row(i).0[0], near as i32, "vertex {i}");
            checked += 1;
        }
    }
    assert!(checked > v.len() / 2);
}

#[test]
fn idw_power_and_errors() {
    let (v, _) = capped_cylinder(0.2, 2.0, 10, 8);
    let (h, t, _) = bone_chain(2.0, 3);
    // Higher power concentrates the weight on the nearest bone.
    let p2 = idw_weights(&v, &h, &t, &IdwOptions::default()).unwrap();
    let p6 = idw_weights(&v, &h, &t, &IdwOptions { power: 6.0, ..Default::default() }).unwrap();
    let mean_top = |inf: &Influences| (0..inf.n()).map(|i| inf.row(i).1[0]).sum::<f32>() / inf.n() as f32;
    assert!(mean_top(&p6) > mean_top(&p2) + 0.05);
    let mut bad = v.clone();
    bad[3][1] = f32::NAN;
    assert_eq!(idw_weights(&bad, &h, &t, &IdwOptions::default()), Err(Error::NonFinite { what: "vertex", count: 1 }));
    assert!(matches!(idw_weights(&[], &h, &t, &IdwOptions::default()), Err(Error::EmptyMesh(_))));
    assert!(matches!(idw_weights(&v, &[], &[], &IdwOptions::default()), Err(Error::NoBones(_))));
    assert!(idw_weights(&v, &h, &t, &IdwOptions { power: -1.0, ..Default::default() }).is_err());
}

#[test]
fn bilinear_rows_sum_to_one_and_strongest_is_nearest() {
    let (v, _) = capped_cylinder(0.2, 2.0, 30, 12);
    let (h, t, parents) = bone_chain(2.0, 5);
    for falloff in [Falloff::Gaussian { sigma: None }, Falloff::InversePower { power: 2.0 }] {
        let opts = BilinearOptions { falloff, ..Default::default() };
        let inf = bilinear_weights(&v, &h, &t, &parents, &opts).unwrap();
        assert_rows_sum_to_one(&inf);
        let mut checked = 0;
        for (i, p) in v.iter().enumerate() {
            let (near, margin) = nearest_bone(*p, &h, &t);
            if margin > 0.02 {
                assert_eq!(inf.row(i).0[0], near as i32, "vertex {i} {:?}", inf.row(i));
                checked += 1;
            }
        }
        assert!(checked > v.len() / 3, "{checked}");
    }
}

#[test]
fn bilinear_is_continuous_across_a_joint() {
    let (h, t, parents) = bone_chain(2.0, 4);
    let joint = t[1][2]; // bone 1 tail = bone 2 head
    let eps = 1e-4f32;
    let verts = [[0.2, 0.0, joint - eps], [0.2, 0.0, joint + eps], [0.0, -0.2, joint - eps], [0.0, -0.2, joint + eps]];
    let inf = bilinear_weights(&verts, &h, &t, &parents, &BilinearOptions::default()).unwrap();
    let d = inf.to_dense(4);
    for pair in [(0, 1), (2, 3)] {
        for j in 0..4 {
            let (a, b) = (d[pair.0 * 4 + j], d[pair.1 * 4 + j]);
            assert!((a - b).abs() < 1e-3, "bone {j}: {a} vs {b}");
        }
        // Both bones at the joint share it (nearly) equally.
        let (a, b) = (d[pair.0 * 4 + 1], d[pair.0 * 4 + 2]);
        assert!((a - b).abs() < 0.01 && a > 0.3, "{a} {b}");
    }
    // Without the neighbour blend (disconnected chain) the two sides would jump: check that
    // the connection matters by breaking it.
    let broken = [-1, -1, -1, -1];
    let inf = bilinear_weights(&verts, &h, &t, &broken, &BilinearOptions { nearest: 1, ..Default::default() }).unwrap();
    assert_ne!(inf.row(0).0[0], inf.row(1).0[0]);
}

#[test]
fn bilinear_rejects_bad_parents() {
    let (v, _) = capped_cylinder(0.2, 2.0, 5, 6);
    let (h, t, _) = bone_chain(2.0, 3);
    let o = BilinearOptions::default();
    assert!(matches!(bilinear_weights(&v, &h, &t, &[-1, 0], &o), Err(Error::Shape(_))));
    assert!(matches!(bilinear_weights(&v, &h, &t, &[-1, 0, 7], &o), Err(Error::InvalidArgument(_))));
    assert!(matches!(bilinear_weights(&v, &h, &t, &[-1, 1, 1], &o), Err(Error::InvalidArgument(_))));
}

#[test]
fn zero_length_bone_gives_no_nan() {
    let (v, _) = capped_cylinder(0.2, 2.0, 10, 8);
    let h = [[0.0, 0.0, 0.5], [0.0, 0.0, 1.0]];
    let t = [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]];
    for inf in [
        idw_weights(&v, &h, &t, &IdwOptions::default()).unwrap(),
        bilinear_weights(&v, &h, &t, &[-1, 0], &BilinearOptions::default()).unwrap(),
    ] {
        assert!(inf.weights.iter().all(|w| w.is_finite()));
        assert_rows_sum_to_one(&inf);
    }
}

#[test]
fn top_k_prunes_and_renormalizes() {
    let dense = [0.6, 0.3, 0.0999, 0.0001, 0.0, 0.0, 0.0, 0.0];
    let inf = top_k_normalized(&dense, 2, 4, 3, 1e-2);
    let (i, w) = inf.row(0);
    assert_eq!(i, &[0, 1, 2]);
    assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    let inf = top_k_normalized(&dense, 2, 4, 3, 0.2);
    assert_eq!(inf.row(0).0, &[0, 1, -1]);
    assert!((inf.row(0).1[0] - 2.0 / 3.0).abs() < 1e-6);
    assert_eq!(inf.row(1).0, &[-1, -1, -1], "all-zero row stays empty");
}
