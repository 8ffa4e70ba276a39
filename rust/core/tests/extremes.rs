//! Film-scale and hostile extremes of bone heat (issue #55): each gets a correct result or one
//! clear error, in bounded time and memory.

mod common;
use common::assert_rows_sum_to_one;
use miniskeleton_core::primitives::{bone_chain, capped_cylinder};
use miniskeleton_core::weights::heat::heat_peak_bytes;
use miniskeleton_core::weights::{heat_weights, HeatOptions, Influences};
use miniskeleton_core::Error;

fn heat(v: &[[f32; 3]], t: &[[u32; 3]], h: &[[f32; 3]], tl: &[[f32; 3]]) -> Result<Influences, Error> {
    heat_weights(v, t, h, tl, &HeatOptions::default(), None).map(|(inf, _)| inf)
}

/// Each vertex's largest weight and its bone.
fn dominant(inf: &Influences) -> Vec<(i32, f32)> {
    (0..inf.n()).map(|v| (inf.row(v).0[0], inf.row(v).1[0])).collect()
}

/// The largest difference of one bone's weight at one vertex between `a` and `b`.
fn max_weight_difference(a: &Influences, b: &Influences, bones: usize) -> f32 {
    let dense = |inf: &Influences, v: usize| {
        let mut w = vec![0.0f32; bones];
        let (i, x) = inf.row(v);
        i.iter().zip(x).filter(|(&j, _)| j >= 0).for_each(|(&j, &x)| w[j as usize] += x);
        w
    };
    (0..a.n()).flat_map(|v| dense(a, v).into_iter().zip(dense(b, v)).map(|(x, y)| (x - y).abs())).fold(0.0, f32::max)
}

/// A thousand bones along a cylinder: every vertex weighted, led by a bone within the
/// cylinder's radius of its own height (heat spreads about a radius).
#[test]
fn a_thousand_bones_bind() {
    let (v, t) = capped_cylinder(0.05, 4.0, 1001, 12);
    let (h, tl, _) = bone_chain(4.0, 1000);
    let inf = heat(&v, &t, &h, &tl).expect("a thousand bones bind");
    assert_rows_sum_to_one(&inf);
    let height = |j: usize| 0.5 * (h[j][2] + tl[j][2]);
    let mut leading = vec![false; 1000];
    for (p, (j, _)) in v.iter().zip(dominant(&inf)) {
        leading[j as usize] = true;
        // The chain runs from 0.1 to 3.9: the caps' vertices belong to its ends.
        assert!((height(j as usize) - p[2].clamp(0.1, 3.9)).abs() < 0.05, "vertex at {p:?} led by bone {j}");
    }
    let led = leading.iter().filter(|&&l| l).count();
    // A ring of vertices every 4 mm, a bone every 3.8 mm: most bones lead a ring (856 of 1000).
    assert!(led > 800, "{led} bones leading somewhere");
}

/// Coordinates scaled to 1e30 and to 1e-30 (mesh and bones alike) give the weights of the
/// unscaled rig: Heat works in the mesh's unit frame.
#[test]
fn coordinates_at_1e30_and_1e_minus_30_weigh_as_at_1() {
    let (v, t) = capped_cylinder(0.15, 2.0, 41, 16);
    let (h, tl, _) = bone_chain(2.0, 4);
    let base = heat(&v, &t, &h, &tl).unwrap();
    for s in [1e30f32, 1e-30] {
        let scale = |p: &Vec<[f32; 3]>| p.iter().map(|q| q.map(|c| c * s)).collect::<Vec<_>>();
        let inf = heat(&scale(&v), &t, &scale(&h), &scale(&tl)).unwrap_or_else(|e| panic!("scale {s}: {e}"));
        assert_rows_sum_to_one(&inf);
        let d = max_weight_difference(&base, &inf, h.len());
        assert!(d < 1e-3, "scale {s}: weights differ by {d}");
    }
}

/// A body with one of its triangles repeated a million times binds as the body alone, but for
/// that triangle's million-fold stiffness in the Laplacian.
#[test]
fn a_triangle_repeated_a_million_times_binds_as_once() {
    let (v, t) = capped_cylinder(0.15, 2.0, 41, 16);
    let (h, tl, _) = bone_chain(2.0, 4);
    let mut many = t.clone();
    many.extend(std::iter::repeat_n(t[100], 1_000_000));
    let once = heat(&v, &t, &h, &tl).unwrap();
    let repeated = heat(&v, &many, &h, &tl).expect("the repeats bind");
    let d = max_weight_difference(&once, &repeated, h.len());
    assert!(d < 0.01, "weights differ by {d}");
}

/// Every bone at one point (heads and tails all equal): one clear error, or weights that sum
/// to one at every vertex.
#[test]
fn every_bone_at_one_point_is_answered() {
    let (v, t) = capped_cylinder(0.15, 2.0, 41, 16);
    let p = [[0.0f32, 0.0, 1.0]; 6];
    match heat(&v, &t, &p, &p) {
        Ok(inf) => assert_rows_sum_to_one(&inf),
        Err(e) => assert!(matches!(e, Error::InvalidArgument(_) | Error::NoBones(_)), "{e}"),
    }
}

/// Ten million vertices and 200 bones are estimated above what this kind of machine holds, so
/// the Auto Weights operator refuses them before solving (its default limit is three quarters
/// of the physical memory, 18 GB on 24 GB).
#[test]
fn ten_million_vertices_are_estimated_past_a_workstation() {
    let (one, ten) = (heat_peak_bytes(1_000_000, 200), heat_peak_bytes(10_000_000, 200));
    assert!(one < 2_400_000_000, "{one}");
    assert!(ten > 18_000_000_000, "{ten}");
}
