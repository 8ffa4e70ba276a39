//! Linear blend skinning: identity, pure translation, rotation blend, validation.

use miniskeleton_core::posing::lbs;
use miniskeleton_core::Error;

const IDENTITY: [[f32; 4]; 4] =
    [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];

/// Row-major rotation about +Z by `deg` degrees, with translation `t` in column 3.
fn rot_z(deg: f32, t: [f32; 3]) -> [[f32; 4]; 4] {
    let (s, c) = deg.to_radians().sin_cos();
    [[c, -s, 0.0, t[0]], [s, c, 0.0, t[1]], [0.0, 0.0, 1.0, t[2]], [0.0, 0.0, 0.0, 1.0]]
}

fn close(a: [f32; 3], b: [f32; 3], tol: f32) -> bool {
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= tol)
}

/// A small grid mesh with 2-bone weights varying over it.
fn grid() -> (Vec<[f32; 3]>, Vec<i32>, Vec<f32>) {
    let mut v = Vec::new();
    let mut idx = Vec::new();
    let mut w = Vec::new();
    for i in 0..10 {
        for j in 0..7 {
            v.push([i as f32 * 0.3 - 1.0, j as f32 * 0.2, (i * j) as f32 * 0.01]);
            let a = i as f32 / 9.0;
            idx.extend_from_slice(&[0, 1]);
            w.extend_from_slice(&[1.0 - a, a]);
        }
    }
    (v, idx, w)
}

#[test]
fn identity_matrices_leave_mesh_unchanged() {
    let (v, idx, w) = grid();
    let out = lbs(&v, &idx, &w, 2, &[IDENTITY, IDENTITY]).unwrap();
    assert_eq!(out.len(), v.len());
    for (a, b) in out.iter().zip(&v) {
        assert!(close(*a, *b, 1e-6), "{a:?} != {b:?}");
    }
}

#[test]
fn translated_bone_translates_fully_weighted_vertices() {
    let (v, idx, w) = grid();
    let t = [0.5, -2.0, 3.25];
    let mut moved = IDENTITY;
    moved[0][3] = t[0];
    moved[1][3] = t[1];
    moved[2][3] = t[2];
    // Bone 1 translated, bone 0 at rest.
    let out = lbs(&v, &idx, &w, 2, &[IDENTITY, moved]).unwrap();
    let mut checked_full = 0;
    for i in 0..v.len() {
        let a = w[2 * i + 1];
        let expect = [v[i][0] + a * t[0], v[i][1] + a * t[1], v[i][2] + a * t[2]];
        assert!(close(out[i], expect, 1e-5), "vertex {i}: {:?} != {expect:?}", out[i]);
        if a == 1.0 {
            checked_full += 1;
            assert!(close(out[i], [v[i][0] + t[0], v[i][1] + t[1], v[i][2] + t[2]], 1e-5));
        }
    }
    assert!(checked_full > 0);
}

#[test]
fn half_half_blend_of_two_rotations_gives_chord_midpoint() {
    // (1,0,0) rotated by +45 and -45 degrees about Z lands on (cos45, ±sin45, 0); LBS averages
    // the two images, so the result is the chord midpoint (cos45, 0, 0) (the "candy wrapper"
    // shrink), not the arc midpoint (1, 0, 0).
    let v = vec![[1.0f32, 0.0, 0.0], [2.0, 0.0, 1.0]];
    let idx = vec![0, 1, 1, 0];
    let w = vec![0.5, 0.5, 0.5, 0.5];
    let out = lbs(&v, &idx, &w, 2, &[rot_z(45.0, [0.0; 3]), rot_z(-45.0, [0.0; 3])]).unwrap();
    let c = 45f32.to_radians().cos();
    assert!(close(out[0], [c, 0.0, 0.0], 1e-6), "{:?}", out[0]);
    assert!(close(out[1], [2.0 * c, 0.0, 1.0], 1e-6), "{:?}", out[1]);
}

#[test]
fn single_rotation_with_translation_is_row_major() {
    // 90 degrees about Z then +1 in X: (1,0,0) -> (0,1,0) + (1,0,0) = (1,1,0).
    let out = lbs(&[[1.0, 0.0, 0.0]], &[0], &[1.0], 1, &[rot_z(90.0, [1.0, 0.0, 0.0])]).unwrap();
    assert!(close(out[0], [1.0, 1.0, 0.0], 1e-6), "{:?}", out[0]);
}

#[test]
fn unused_slots_zero_rows_and_normalisation() {
    let m = rot_z(0.0, [1.0, 2.0, 3.0]);
    let v = vec![[0.0f32, 0.0, 0.0], [5.0, 5.0, 5.0], [1.0, 1.0, 1.0]];
    // Row 0: one used slot (-1 in the other). Row 1: all weights zero -> rest.
    // Row 2: weights sum to 0.5 -> normalised, still fully translated.
    let idx = vec![0, -1, 0, 0, 0, -1];
    let w = vec![1.0, 0.7, 0.0, 0.0, 0.5, 0.0];
    let out = lbs(&v, &idx, &w, 2, &[m]).unwrap();
    assert!(close(out[0], [1.0, 2.0, 3.0], 1e-6), "{:?}", out[0]);
    assert!(close(out[1], [5.0, 5.0, 5.0], 0.0), "{:?}", out[1]);
    assert!(close(out[2], [2.0, 3.0, 4.0], 1e-6), "{:?}", out[2]);
}

#[test]
fn bad_index_is_an_error() {
    let v = vec![[0.0f32; 3]; 2];
    let w = vec![1.0, 0.0, 1.0, 0.0];
    for bad in [2, 7, -2] {
        let idx = vec![0, -1, bad, -1];
        match lbs(&v, &idx, &w, 2, &[IDENTITY, IDENTITY]) {
            Err(Error::InvalidArgument(msg)) => assert!(msg.contains(&bad.to_string()), "{msg}"),
            other => panic!("index {bad}: expected InvalidArgument, got {other:?}"),
        }
    }
}

#[test]
fn shape_and_non_finite_errors() {
    let v = vec![[0.0f32; 3]; 3];
    let idx = vec![0; 6];
    let w = vec![0.5; 6];
    assert!(matches!(lbs(&v, &idx[..5], &w, 2, &[IDENTITY]), Err(Error::Shape(_))));
    assert!(matches!(lbs(&v, &idx, &w[..4], 2, &[IDENTITY]), Err(Error::Shape(_))));

    let mut vn = v.clone();
    vn[1][2] = f32::NAN;
    vn[2][0] = f32::INFINITY;
    assert_eq!(lbs(&vn, &idx, &w, 2, &[IDENTITY]), Err(Error::NonFinite { what: "vertex", count: 2 }));
    let mut wn = w.clone();
    wn[3] = f32::NAN;
    assert_eq!(lbs(&v, &idx, &wn, 2, &[IDENTITY]), Err(Error::NonFinite { what: "weight", count: 1 }));
    let mut m = IDENTITY;
    m[0][3] = f32::NEG_INFINITY;
    assert_eq!(lbs(&v, &idx, &w, 2, &[m]), Err(Error::NonFinite { what: "bone matrix", count: 1 }));
    let mut wneg = w.clone();
    wneg[0] = -0.1;
    assert!(matches!(lbs(&v, &idx, &wneg, 2, &[IDENTITY]), Err(Error::InvalidArgument(_))));
}

#[test]
fn empty_inputs() {
    assert_eq!(lbs(&[], &[], &[], 4, &[IDENTITY]).unwrap(), Vec::<[f32; 3]>::new());
    // k = 0: nothing influences anything, vertices stay at rest.
    let v = vec![[1.0f32, 2.0, 3.0]];
    assert_eq!(lbs(&v, &[], &[], 0, &[]).unwrap(), v);
}
