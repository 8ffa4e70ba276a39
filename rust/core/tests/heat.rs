//! Integration tests of bone-heat weights (Baran & Popovic 2007) on generated meshes.

mod common;
use common::assert_rows_sum_to_one;
use miniskeleton_core::mesh::Symmetry;
use miniskeleton_core::primitives::{bone_chain, capped_cylinder, split_flat};
use miniskeleton_core::weights::Influences;
use miniskeleton_core::weights::{heat_sources, heat_weights, heat_weights_many, heat_weights_with_sources};
use miniskeleton_core::weights::{BoneCurves, HeatOptions, HeatReport, MeshRef};
use miniskeleton_core::Error;
use std::sync::atomic::{AtomicUsize, Ordering};

type Mesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);
type Bones = (Vec<[f32; 3]>, Vec<[f32; 3]>);

fn heat(m: &Mesh, b: &Bones, opts: &HeatOptions) -> (Influences, HeatReport) {
    heat_weights(&m.0, &m.1, &b.0, &b.1, opts, None).expect("heat_weights")
}

fn max_abs_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

fn cylinder() -> (Mesh, Bones) {
    let m = capped_cylinder(0.15, 2.0, 41, 16);
    let (h, t, _) = bone_chain(2.0, 4);
    (m, (h, t))
}

/// Horizontal cylinder along X from -1 to 1 (mirror-symmetric in X) and a 4-bone chain.
fn horizontal() -> (Mesh, Bones) {
    let (v, t) = capped_cylinder(0.15, 2.0, 41, 16);
    let v = v.iter().map(|p| [p[2] - 1.0, p[1], p[0]]).collect();
    let (h, tl, _) = bone_chain(2.0, 4);
    let sw = |p: &[f32; 3]| [p[2] - 1.0, p[1], p[0]];
    ((v, t), (h.iter().map(sw).collect(), tl.iter().map(sw).collect()))
}

#[test]
fn rows_sum_to_one_and_middle_of_bone_is_dominant() {
    // Heat decays over about one radius from a joint (1D analysis: w = 1 - exp(-s / r) / 2 per
    // joint), so use bones ~6 radii long: the middle then keeps ~1 - exp(-3) ~ 0.95.
    let m = capped_cylinder(0.08, 2.0, 41, 16);
    let (h, t, _) = bone_chain(2.0, 4);
    let b = (h, t);
    let (inf, rep) = heat(&m, &b, &HeatOptions::default());
    assert_eq!(inf.n(), m.0.len());
    assert_rows_sum_to_one(&inf);
    assert_eq!((rep.pieces, rep.fallback_pieces, rep.rigid_pieces), (1, 0, 0));
    assert!(!rep.factorization_failed && !rep.regularized);
    // Surface vertices around the middle of every bone.
    for j in 0..4 {
        let zmid = 0.5 * (b.0[j][2] + b.1[j][2]);
        let mut n = 0;
        for (v, p) in m.0.iter().enumerate() {
            let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
            if (p[2] - zmid).abs() < 0.03 && r > 0.07 {
                let d = inf.to_dense(4);
                assert!(d[v * 4 + j] > 0.9, "bone {j} vertex {v}: {}", d[v * 4 + j]);
                n += 1;
            }
        }
        assert!(n >= 16, "found {n} vertices near the middle of bone {j}");
    }
    // And the weight of bone 0 decreases monotonically up the side.
    let d = inf.to_dense(4);
    let side: Vec<f32> = (0..41).map(|ring| d[(ring * 16) * 4]).collect();
    assert!(side.windows(2).skip(3).all(|w| w[1] <= w[0] + 1e-4), "{side:?}");
}

#[test]
fn symmetric_mesh_and_skeleton_give_symmetric_weights() {
    let (m, b) = horizontal();
    // Bones: 0 <-> 3, 1 <-> 2 (mirrored, reversed direction).
    let mirror_bone = [3usize, 2, 1, 0];
    // Vertex mirror by position.
    let find = |p: [f32; 3]| {
        m.0.iter().position(|q| (q[0] + p[0]).abs() < 1e-5 && (q[1] - p[1]).abs() < 1e-5 && (q[2] - p[2]).abs() < 1e-5)
    };
    let vm: Vec<usize> = m.0.iter().map(|p| find(*p).expect("mirror vertex")).collect();
    let check = |inf: &Influences, tol: f32| {
        let d = inf.to_dense(4);
        let mut worst = 0.0f32;
        for v in 0..m.0.len() {
            for j in 0..4 {
                worst = worst.max((d[v * 4 + j] - d[vm[v] * 4 + mirror_bone[j]]).abs());
            }
        }
        assert!(worst < tol, "asymmetry {worst}");
        worst
    };
    let (plain, _) = heat(&m, &b, &HeatOptions::default());
    assert_rows_sum_to_one(&plain);
    check(&plain, 1e-3);
    let sym = HeatOptions {
        symmetry: Some(Symmetry { axis: 0, plane: 0.0, mirror: vec![3, 2, 1, 0] }),
        mirror_tolerance: 1e-4,
        ..Default::default()
    };
    let (avg, rep) = heat(&m, &b, &sym);
    assert_rows_sum_to_one(&avg);
    check(&avg, 1e-5);
    assert_eq!(rep.mirrored_vertices, m.0.len(), "every vertex has its twin");
    // The same mesh and bones moved off the plane: no twin, nothing averaged, and the report says so.
    let shift = |p: &[f32; 3]| [p[0] + 0.31, p[1], p[2]]; // not a multiple of the ring spacing
    let (vs, hs, ts): (Vec<_>, Vec<_>, Vec<_>) =
        (m.0.iter().map(shift).collect(), b.0.iter().map(shift).collect(), b.1.iter().map(shift).collect());
    let (_, rep) = heat_weights(&vs, &m.1, &hs, &ts, &sym, None).unwrap();
    assert!(rep.mirrored_vertices < m.0.len() / 10, "{} twins", rep.mirrored_vertices);
    // A bad mirror map is an error.
    let bad = HeatOptions {
        symmetry: Some(Symmetry { axis: 0, plane: 0.0, mirror: vec![3, 2, 2, 0] }),
        mirror_tolerance: 1e-4,
        ..Default::default()
    };
    assert!(heat_weights(&m.0, &m.1, &b.0, &b.1, &bad, None).is_err());
}

/// Bones whose names carry no side come as centre bones (their own mirror). Off the plane they
/// are side bones: averaging each with its own mirror image gave both ends of the limb half of
/// each end bone. Paired by place instead, they get the weights of the named pairs.
#[test]
fn side_bones_given_as_centre_bones_are_paired_by_place() {
    // Two arms from the middle outward, as a rig's left and right bones run.
    let (m, _) = horizontal();
    let x = |x: f32| [x, 0.0, 0.0];
    let b = (vec![x(-0.05), x(-0.5), x(0.05), x(0.5)], vec![x(-0.5), x(-0.95), x(0.5), x(0.95)]);
    let sym = |bone_mirror: Vec<i32>| HeatOptions {
        symmetry: Some(Symmetry { axis: 0, plane: 0.0, mirror: bone_mirror }),
        mirror_tolerance: 1e-4,
        ..Default::default()
    };
    let (named, rep) = heat(&m, &b, &sym(vec![2, 3, 0, 1]));
    assert_eq!((rep.side_bones_paired, rep.side_bones_unpaired), (0, 0));
    let (unnamed, rep) = heat(&m, &b, &sym(vec![0, 1, 2, 3]));
    assert_eq!((rep.side_bones_paired, rep.side_bones_unpaired), (4, 0));
    assert_eq!(max_abs_diff(&named.to_dense(4), &unnamed.to_dense(4)), 0.0);
    let end = (0..m.0.len()).min_by(|&i, &j| m.0[i][0].total_cmp(&m.0[j][0])).unwrap();
    let w = unnamed.to_dense(4);
    assert!(w[end * 4 + 1] > 0.9, "the end vertex's own bone: {:?}", &w[end * 4..end * 4 + 4]);
}

#[test]
fn two_pieces_one_without_bones_are_all_weighted() {
    let (mut m, b) = cylinder();
    // Second, equally large cylinder next to the first, no bone inside.
    let (v2, t2) = capped_cylinder(0.15, 2.0, 41, 16);
    let base = m.0.len() as u32;
    m.0.extend(v2.iter().map(|p| [p[0] + 1.0, p[1], p[2]]));
    m.1.extend(t2.iter().map(|t| t.map(|i| i + base)));
    // A small third piece (a 'button') far from any bone, and an isolated vertex.
    let (v3, t3) = capped_cylinder(0.02, 0.02, 2, 6);
    let base = m.0.len() as u32;
    m.0.extend(v3.iter().map(|p| [p[0] - 0.6, p[1], p[2] + 1.2]));
    m.1.extend(t3.iter().map(|t| t.map(|i| i + base)));
    let button = base as usize..m.0.len();
    m.0.push([0.0, 3.0, 0.1]);
    let (inf, rep) = heat(&m, &b, &HeatOptions::default());
    assert_eq!(inf.n(), m.0.len());
    assert_rows_sum_to_one(&inf);
    assert_eq!(rep.pieces, 3);
    assert_eq!(rep.fallback_pieces, 2);
    assert_eq!(rep.rigid_pieces, 1);
    assert_eq!(rep.isolated_vertices, 1);
    // The button is rigid: every vertex 100% on one bone (the one at its height, bone 2).
    for v in button.clone() {
        assert_eq!(inf.row(v), (&[2, -1, -1, -1][..], &[1.0, 0.0, 0.0, 0.0][..]));
    }
    // The isolated vertex at z = 0.1 takes bone 0.
    assert_eq!(inf.row(m.0.len() - 1).0[0], 0);
    // The bone-less cylinder still varies smoothly with height (not one bone everywhere).
    let far: std::collections::HashSet<i32> =
        (base as usize - 41 * 16 - 2..base as usize).map(|v| inf.row(v).0[0]).collect();
    assert!(far.len() >= 3, "{far:?}");
    // Without the accessory rule the button is still rigid: it sees no bone and is smaller
    // than its nearest bone; the big cylinder, which sees none either, is not.
    let (inf2, rep2) = heat(&m, &b, &HeatOptions { rigid_accessories: false, ..Default::default() });
    assert_eq!((rep2.fallback_pieces, rep2.rigid_pieces), (2, 1));
    for v in button {
        assert_eq!(inf2.row(v), (&[2, -1, -1, -1][..], &[1.0, 0.0, 0.0, 0.0][..]));
    }
}

/// A piece sees a bone when any of its vertices does: a skirt hanging outside the tube from
/// its top rim (one piece with it, listed last) sees no bone through the wall, and the piece
/// is still solved by heat, not counted as a fallback.
#[test]
fn a_piece_with_some_vertices_that_see_a_bone_is_no_fallback() {
    let (mut m, b) = cylinder();
    let (rings, segments) = (41u32, 16u32);
    let rim = |j: u32| (rings - 1) * segments + j % segments;
    let skirt = m.0.len() as u32;
    for j in 0..segments {
        let a = std::f32::consts::TAU * j as f32 / segments as f32;
        m.0.push([0.25 * a.cos(), 0.25 * a.sin(), 1.7]);
    }
    let at = |j: u32| skirt + j % segments;
    for j in 0..segments {
        m.1.push([rim(j), at(j + 1), rim(j + 1)]);
        m.1.push([rim(j), at(j), at(j + 1)]);
    }
    let (inf, rep) = heat(&m, &b, &HeatOptions::default());
    assert_rows_sum_to_one(&inf);
    assert_eq!((rep.pieces, rep.fallback_pieces, rep.rigid_pieces), (1, 0, 0), "{rep:?}");
    // The skirt takes the top bone's heat through the rim.
    assert!((skirt as usize..m.0.len()).all(|v| inf.row(v).0[0] == 3));
}

#[test]
fn flat_shaded_split_mesh_matches_welded_twin() {
    let (m, b) = cylinder();
    let (inf, _) = heat(&m, &b, &HeatOptions::default());
    let split = split_flat(&m.0, &m.1).unwrap();
    let (sinf, rep) = heat(&split, &b, &HeatOptions::default());
    assert_eq!(rep.welded_vertices, split.0.len() - m.0.len());
    assert_eq!(rep.pieces, 1);
    let d = inf.to_dense(4);
    let sd = sinf.to_dense(4);
    let mut worst = 0.0f32;
    for (ti, tri) in m.1.iter().enumerate() {
        for (k, &v) in tri.iter().enumerate() {
            let (v, sv) = (v as usize, 3 * ti + k);
            worst = worst.max(max_abs_diff(&d[v * 4..v * 4 + 4], &sd[sv * 4..sv * 4 + 4]));
        }
    }
    assert!(worst < 1e-5, "split vs welded differ by {worst}");
}

#[test]
fn scale_invariance() {
    let (m, b) = cylinder();
    let (base, _) = heat(&m, &b, &HeatOptions::default());
    let d0 = base.to_dense(4);
    for s in [1e-3f32, 1e3] {
        let sc = |v: &Vec<[f32; 3]>| v.iter().map(|p| p.map(|c| c * s)).collect::<Vec<_>>();
        let ms = (sc(&m.0), m.1.clone());
        let bs = (sc(&b.0), sc(&b.1));
        let (inf, _) = heat(&ms, &bs, &HeatOptions::default());
        let diff = max_abs_diff(&d0, &inf.to_dense(4));
        assert!(diff < 1e-4, "scale {s}: {diff}");
    }
}

#[test]
fn a_stray_vertex_far_away_does_not_change_weights() {
    // Tolerances are relative to the surface's size, not to that of every vertex: a loose
    // point 1e5 away would otherwise make the weld distance 1 and merge the whole cylinder.
    let (m, b) = cylinder();
    let (base, _) = heat(&m, &b, &HeatOptions::default());
    let mut stray = m.clone();
    stray.0.push([1e5, 0.0, 0.0]);
    let (inf, rep) = heat(&stray, &b, &HeatOptions::default());
    assert_eq!((rep.isolated_vertices, rep.welded_vertices), (1, 0));
    assert_rows_sum_to_one(&inf);
    let nb = m.0.len() * 4;
    let diff = max_abs_diff(&base.to_dense(4), &inf.to_dense(4)[..nb]);
    assert!(diff < 1e-5, "{diff}");
}

#[test]
fn flipped_faces_do_not_change_weights() {
    // Half the tube wound inside out (as after joining a mirrored part without recalculating
    // normals), and scattered single faces: its normals would point inward and hide the bones.
    let (m, b) = cylinder();
    let (base, _) = heat(&m, &b, &HeatOptions::default());
    let d0 = base.to_dense(4);
    let flip = |t: &[u32; 3]| [t[0], t[2], t[1]];
    let upper = |t: &[u32; 3]| t.iter().map(|&i| m.0[i as usize][2]).sum::<f32>() > 3.0;
    let half: Vec<[u32; 3]> = m.1.iter().map(|t| if upper(t) { flip(t) } else { *t }).collect();
    let scattered: Vec<[u32; 3]> = m.1.iter().enumerate().map(|(i, t)| if i % 7 == 0 { flip(t) } else { *t }).collect();
    for (name, tris, flipped) in
        [("upper half", half, m.1.iter().filter(|t| upper(t)).count()), ("every 7th", scattered, m.1.len().div_ceil(7))]
    {
        let (inf, rep) = heat(&(m.0.clone(), tris), &b, &HeatOptions::default());
        assert_eq!(rep.flipped_faces, flipped, "{name}");
        let diff = max_abs_diff(&d0, &inf.to_dense(4));
        assert!(diff < 1e-5, "{name}: {diff}");
    }
}

#[test]
fn degenerate_and_duplicate_faces_do_not_change_weights() {
    let (m, b) = cylinder();
    let (base, _) = heat(&m, &b, &HeatOptions::default());
    // Duplicate every face: L and M double, the solution is unchanged.
    let mut dup = m.clone();
    dup.1.extend(m.1.iter().copied());
    // Zero-area faces: repeated index, and a collinear (sliver-free, flat) triangle.
    dup.1.push([0, 0, 1]);
    dup.1.push([5, 5, 5]);
    let n = dup.0.len() as u32;
    dup.0.extend([[0.0, 0.0, 1.0], [0.01, 0.0, 1.0], [0.02, 0.0, 1.0]]);
    dup.1.push([n, n + 1, n + 2]);
    let (inf, rep) = heat(&dup, &b, &HeatOptions::default());
    assert_rows_sum_to_one(&inf);
    assert_eq!(rep.isolated_vertices, 3);
    let nb = m.0.len() * 4;
    let diff = max_abs_diff(&base.to_dense(4), &inf.to_dense(4)[..nb]);
    assert!(diff < 1e-5, "{diff}");
}

#[test]
fn bone_outside_the_mesh_and_zero_length_bone() {
    let (m, mut b) = cylinder();
    // Bone 4: entirely outside, 0.1 beside the cylinder (nearer to the +X side than the axis
    // chain); bone 5: zero length, inside.
    b.0.push([0.25, 0.0, 0.5]);
    b.1.push([0.25, 0.0, 1.5]);
    b.0.push([0.0, 0.0, 1.0]);
    b.1.push([0.0, 0.0, 1.0]);
    for normal_distance in [true, false] {
        let (inf, rep) = heat(&m, &b, &HeatOptions { normal_distance, ..Default::default() });
        assert!(!rep.factorization_failed);
        assert_rows_sum_to_one(&inf);
        let d = inf.to_dense(6);
        assert!(d.iter().all(|w| w.is_finite()));
        let near_side = (0..m.0.len()).filter(|&v| m.0[v][0] > 0.14 && (0.7..1.3).contains(&m.0[v][2]));
        assert!(near_side.clone().count() > 0);
        for v in near_side {
            if normal_distance {
                // A bone in front of the surface (outside the body) is no heat source for it.
                assert!(d[v * 6 + 4] < 0.01, "vertex {v}: {}", d[v * 6 + 4]);
            } else {
                // Plain distance: the outside bone is visible from the near side only.
                assert!(d[v * 6 + 4] > 0.05, "vertex {v}: {}", d[v * 6 + 4]);
            }
        }
        let far_side = (0..m.0.len()).filter(|&v| m.0[v][0] < -0.14 && (0.7..1.3).contains(&m.0[v][2]));
        for v in far_side {
            assert!(d[v * 6 + 4] < d[v * 6 + 2].max(d[v * 6 + 1]), "vertex {v}");
        }
    }
}

#[test]
fn bad_inputs_are_errors() {
    let (m, b) = cylinder();
    let o = HeatOptions::default();
    let mut nan = m.0.clone();
    nan[0][0] = f32::NAN;
    nan[7][2] = f32::INFINITY;
    nan[9][1] = f32::NAN;
    assert_eq!(
        heat_weights(&nan, &m.1, &b.0, &b.1, &o, None).unwrap_err(),
        Error::NonFinite { what: "vertex", count: 3 }
    );
    assert!(matches!(heat_weights(&[], &[], &b.0, &b.1, &o, None), Err(Error::EmptyMesh(_))));
    let mut bad = m.1.clone();
    bad[4][1] = 1_000_000;
    assert!(matches!(
        heat_weights(&m.0, &bad, &b.0, &b.1, &o, None),
        Err(Error::BadIndex { triangle: 4, index: 1_000_000, .. })
    ));
    assert!(matches!(heat_weights(&m.0, &m.1, &[], &[], &o, None), Err(Error::NoBones(_))));
    assert!(matches!(heat_weights(&m.0, &m.1, &b.0, &b.1[..2], &o, None), Err(Error::Shape(_))));
    let mut nb = b.0.clone();
    nb[1][1] = f32::NAN;
    assert!(matches!(heat_weights(&m.0, &m.1, &nb, &b.1, &o, None), Err(Error::NonFinite { what: "bone", count: 1 })));
    let zero_k = HeatOptions { max_influences: 0, ..Default::default() };
    assert!(matches!(heat_weights(&m.0, &m.1, &b.0, &b.1, &zero_k, None), Err(Error::InvalidArgument(_))));
}

#[test]
fn progress_is_reported_and_cancel_works() {
    let (m, b) = cylinder();
    let calls = AtomicUsize::new(0);
    let last = std::sync::Mutex::new(-1.0f32);
    let ok = |f: f32| {
        calls.fetch_add(1, Ordering::Relaxed);
        let mut l = last.lock().unwrap();
        assert!(f >= *l && (0.0..=1.0).contains(&f));
        *l = f;
        true
    };
    heat_weights(&m.0, &m.1, &b.0, &b.1, &HeatOptions::default(), Some(&ok)).unwrap();
    assert!(calls.load(Ordering::Relaxed) >= 5);
    assert_eq!(*last.lock().unwrap(), 1.0);
    let cancel_midway = |f: f32| f < 0.5;
    assert_eq!(
        heat_weights(&m.0, &m.1, &b.0, &b.1, &HeatOptions::default(), Some(&cancel_midway)).unwrap_err(),
        Error::Cancelled
    );
}

#[test]
fn points_without_faces_take_the_nearest_bone() {
    let (_, b) = cylinder();
    let pts = vec![[0.1, 0.0, 0.1], [0.0, 0.1, 1.9]];
    let (inf, rep) = heat_weights(&pts, &[], &b.0, &b.1, &HeatOptions::default(), None).unwrap();
    assert_eq!(rep.pieces, 0);
    assert_eq!(inf.row(0).0[0], 0);
    assert_eq!(inf.row(1).0[0], 3);
    assert_rows_sum_to_one(&inf);
}

#[test]
fn points_on_the_mirror_plane_of_two_bones_share_them() {
    // Two upright bones mirrored across x = 0. A point without faces on that plane is as near
    // to one as to the other: it shares them, as Blender's bone heat shares a tie (rather than
    // the first at 1.0); points beside the plane take their own side's bone.
    let heads = vec![[-0.5, 0.0, 0.0], [0.5, 0.0, 0.0]];
    let tails = vec![[-0.5, 0.0, 1.0], [0.5, 0.0, 1.0]];
    let pts = vec![[0.0, 0.0, 0.5], [0.0, 0.3, 2.0], [0.01, 0.0, 0.5], [-0.01, 0.0, 0.5]];
    let (inf, rep) = heat_weights(&pts, &[], &heads, &tails, &HeatOptions::default(), None).unwrap();
    assert_eq!(rep.isolated_vertices, 4);
    let dense = inf.to_dense(2);
    for v in 0..2 {
        assert_eq!((dense[v * 2], dense[v * 2 + 1]), (0.5, 0.5), "point {v}");
    }
    assert_eq!((dense[4], dense[5]), (0.0, 1.0));
    assert_eq!((dense[6], dense[7]), (1.0, 0.0));
}

#[test]
fn visibility_off_still_works() {
    let (m, b) = cylinder();
    let (a, _) = heat(&m, &b, &HeatOptions::default());
    let (c, _) = heat(&m, &b, &HeatOptions { visibility: false, ..Default::default() });
    // A convex tube around its own axis chain: every nearest bone is visible anyway.
    assert!(max_abs_diff(&a.to_dense(4), &c.to_dense(4)) < 1e-5);
}

/// Axis-aligned box `centre +- half` appended to `m`: 12 outward triangles, or 10 without
/// the top (+Z) face when `open`. Returns the new vertex range.
fn add_box(m: &mut Mesh, centre: [f32; 3], half: [f32; 3], open: bool) -> std::ops::Range<usize> {
    let base = m.0.len() as u32;
    for i in 0..8 {
        let s = |bit: usize, k: usize| if (i >> bit) & 1 == 1 { centre[k] + half[k] } else { centre[k] - half[k] };
        m.0.push([s(0, 0), s(1, 1), s(2, 2)]);
    }
    let mut quads = vec![[0, 2, 3, 1], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    if !open {
        quads.push([4, 5, 7, 6]);
    }
    for q in quads {
        m.1.push([base + q[0], base + q[1], base + q[2]]);
        m.1.push([base + q[0], base + q[2], base + q[3]]);
    }
    base as usize..m.0.len()
}

fn is_rigid_on(inf: &Influences, verts: std::ops::Range<usize>, bone: i32) -> bool {
    verts.into_iter().all(|v| inf.row(v).0[0] == bone && inf.row(v).1[0] == 1.0)
}

#[test]
fn weight_ramp_is_continuous_and_drops_small_weights() {
    use miniskeleton_core::weights::weight_limit;
    let (s, e) = (0.05, 0.025);
    assert_eq!(weight_limit(0.02, s, e), 0.0);
    assert_eq!(weight_limit(f32::NAN, s, e), 0.0);
    assert!(weight_limit(0.025, s, e).abs() < 1e-7);
    assert!((weight_limit(0.0375, s, e) - 0.025).abs() < 1e-7);
    assert!((weight_limit(0.05 - 1e-7, s, e) - 0.05).abs() < 1e-5);
    assert_eq!(weight_limit(0.3, s, e), 0.3);
    // Monotone and continuous on a fine grid.
    let g: Vec<f32> = (0..=1000).map(|i| weight_limit(i as f32 * 1e-4, s, e)).collect();
    assert!(g.windows(2).all(|w| w[1] >= w[0] && w[1] - w[0] < 3e-4));
    assert_eq!(weight_limit(0.01, 0.0, 0.0), 0.01);

    // On a mesh: fewer influences per vertex than without the ramp, rows still sum to 1.
    let (m, b) = cylinder();
    let count = |inf: &Influences| inf.weights.iter().filter(|w| **w > 0.0).count();
    let (ramped, _) = heat(&m, &b, &HeatOptions::default());
    let off = HeatOptions { weight_limit_start: 0.0, weight_limit_end: 0.0, ..Default::default() };
    let (plain, _) = heat(&m, &b, &off);
    assert_rows_sum_to_one(&ramped);
    assert!(count(&ramped) < count(&plain), "{} vs {}", count(&ramped), count(&plain));
    // Bad limits are errors.
    for (s, e) in [(0.02, 0.05), (1.0, 0.5), (0.05, -0.1), (f32::NAN, 0.0)] {
        let o = HeatOptions { weight_limit_start: s, weight_limit_end: e, ..Default::default() };
        assert!(matches!(heat_weights(&m.0, &m.1, &b.0, &b.1, &o, None), Err(Error::InvalidArgument(_))));
    }
}

/// A closed prop that sees bones and is pierced by a bone's tip, an open tray with a bone
/// lying inside it, and a body: the prop is rigid on its nearest bone, the others are not.
#[test]
fn accessory_without_a_bone_inside_is_rigid() {
    let (mut m, (mut h, mut t)) = cylinder();
    // Bone 4: an 'arm' outside the body, visible from everywhere around it.
    h.push([0.3, 0.0, 1.0]);
    t.push([0.62, 0.0, 1.0]);
    // Prop around the arm's tip (only the tail sample is inside it).
    let prop = add_box(&mut m, [0.68, 0.0, 1.0], [0.07, 0.05, 0.05], false);
    // Open tray (no lid) with bone 5 inside along its length.
    let tray = add_box(&mut m, [-0.6, 0.0, 1.0], [0.2, 0.05, 0.05], true);
    h.push([-0.75, 0.0, 1.0]);
    t.push([-0.45, 0.0, 1.0]);
    let b = (h, t);
    let (inf, rep) = heat(&m, &b, &HeatOptions::default());
    assert_rows_sum_to_one(&inf);
    assert_eq!((rep.pieces, rep.boneless_pieces, rep.rigid_pieces), (3, 1, 1), "{rep:?}");
    assert!(is_rigid_on(&inf, prop.clone(), 4));
    // The tray holds bone 5: heat weights (its vertices are dominated by bone 5, not rigid
    // by rule; the body keeps its smooth weights).
    assert!(tray.clone().all(|v| inf.row(v).0[0] == 5));
    let body_bones: std::collections::HashSet<i32> = (0..41 * 16).map(|v| inf.row(v).0[0]).collect();
    assert!(body_bones.len() >= 4, "{body_bones:?}");
    // Switched off: no piece is bound rigidly by rule.
    let (inf2, rep2) = heat(&m, &b, &HeatOptions { rigid_accessories: false, ..Default::default() });
    assert_rows_sum_to_one(&inf2);
    assert_eq!((rep2.rigid_pieces, rep2.boneless_pieces), (0, 0));
}

/// The largest piece is the body, never an accessory: here the skeleton was placed beside it
/// (no bone inside it) and a small sleeve holds a bone; the body is still solved by heat, its
/// weights led by the bones beside it.
#[test]
fn the_largest_piece_is_never_bound_rigidly_as_an_accessory() {
    let (_, (h, t)) = cylinder();
    let mut m: Mesh = (Vec::new(), Vec::new());
    let body = add_box(&mut m, [0.5, 0.0, 1.0], [0.2, 0.2, 0.2], false);
    add_box(&mut m, [0.0, 0.0, 0.3], [0.05, 0.05, 0.3], false);
    let (inf, rep) = heat(&m, &(h, t), &HeatOptions::default());
    assert_rows_sum_to_one(&inf);
    assert_eq!((rep.pieces, rep.boneless_pieces, rep.rigid_pieces), (2, 1, 0), "{rep:?}");
    let firsts: std::collections::HashSet<i32> = body.map(|v| inf.row(v).0[0]).collect();
    assert!(firsts.len() >= 2 && firsts.contains(&1) && firsts.contains(&2), "{firsts:?}");
}

/// A mesh that is only a prop (no bone inside any of its pieces) moves as one body on the
/// bone nearest to its centre of mass, whatever the bones its vertices see.
#[test]
fn prop_mesh_is_one_rigid_body() {
    let (_, (h, t)) = cylinder();
    let mut m: Mesh = (Vec::new(), Vec::new());
    // Two pieces (a 'carrot' and its 'leaf') beside bone 1 (z 0.5..1.0), both outside the chain.
    let body = add_box(&mut m, [0.2, 0.0, 0.8], [0.05, 0.05, 0.15], false);
    let leaf = add_box(&mut m, [0.2, 0.0, 1.02], [0.01, 0.03, 0.05], false);
    let (inf, rep) = heat(&m, &(h, t), &HeatOptions::default());
    assert_eq!((rep.pieces, rep.boneless_pieces, rep.rigid_pieces), (2, 2, 2), "{rep:?}");
    assert!(is_rigid_on(&inf, body, 1));
    assert!(is_rigid_on(&inf, leaf, 1));
}

/// A prop rides the bone nearest its centre of mass, that of its volume: a solid block beside
/// bone 1 and a thin wide plate beside bone 2 (most of the prop's surface, little of its
/// volume) both follow bone 1.
#[test]
fn a_prop_rides_the_bone_nearest_the_centre_of_its_volume() {
    let (_, (h, t)) = cylinder();
    let mut m: Mesh = (Vec::new(), Vec::new());
    let block = add_box(&mut m, [0.3, 0.0, 0.75], [0.1, 0.1, 0.1], false);
    let plate = add_box(&mut m, [0.35, 0.0, 1.35], [0.2, 0.2, 0.005], false);
    let (inf, rep) = heat(&m, &(h, t), &HeatOptions::default());
    assert_eq!((rep.pieces, rep.boneless_pieces, rep.rigid_pieces), (2, 2, 2), "{rep:?}");
    assert!(is_rigid_on(&inf, block, 1) && is_rigid_on(&inf, plate, 1));
}

/// A grid sheet in the plane y = `y` from `(x0, z0)` to `(x1, z1)`, `nx` by `nz` vertices,
/// appended to `m` (an open piece, like a wing membrane). Returns the new vertex range.
fn add_sheet(
    m: &mut Mesh,
    (x0, z0): (f32, f32),
    (x1, z1): (f32, f32),
    y: f32,
    (nx, nz): (usize, usize),
) -> std::ops::Range<usize> {
    let base = m.0.len();
    for k in 0..nz {
        for i in 0..nx {
            let (u, w) = (i as f32 / (nx - 1) as f32, k as f32 / (nz - 1) as f32);
            m.0.push([x0 + u * (x1 - x0), y, z0 + w * (z1 - z0)]);
        }
    }
    let at = |i: usize, k: usize| (base + k * nx + i) as u32;
    for k in 0..nz - 1 {
        for i in 0..nx - 1 {
            m.1.push([at(i, k), at(i + 1, k), at(i + 1, k + 1)]);
            m.1.push([at(i, k), at(i + 1, k + 1), at(i, k + 1)]);
        }
    }
    base..m.0.len()
}

/// A body with an arm of 3 bones held out sideways, a thin membrane hanging under the arm (no
/// bone inside, most of it nearer to the other arm bones than to the middle one) and a small
/// bead beside the last arm bone: the membrane is no rigid accessory, it blends along the
/// chain, each arm bone leading the part below it; the bead, owned by the bone it sits by,
/// stays rigid on it.
#[test]
fn a_membrane_along_a_chain_blends_and_a_bead_by_one_bone_stays_rigid() {
    let (mut m, (mut h, mut t)) = cylinder();
    for k in 0..3 {
        let x = 0.2 + 0.3 * k as f32;
        h.push([x, 0.0, 1.6]);
        t.push([x + 0.3, 0.0, 1.6]);
    }
    let sheet = add_sheet(&mut m, (0.2, 1.2), (1.1, 1.55), 0.0, (31, 8));
    let bead = add_box(&mut m, [0.95, 0.0, 1.68], [0.03, 0.03, 0.03], false);
    let b = (h, t);
    let (inf, rep) = heat(&m, &b, &HeatOptions::default());
    assert_rows_sum_to_one(&inf);
    assert_eq!((rep.pieces, rep.boneless_pieces, rep.rigid_pieces, rep.spanning_pieces), (3, 2, 1, 1), "{rep:?}");
    assert!(is_rigid_on(&inf, bead, 6));
    // Along the membrane the leading bone goes 4, 5, 6 from the body out, and weights blend.
    let lead = |v: usize| inf.row(v).0[0];
    let column = |i: usize| sheet.start + 4 * 31 + i; // a row of the sheet, half way down
    assert_eq!((lead(column(3)), lead(column(15)), lead(column(27))), (4, 5, 6));
    let shared = sheet.clone().filter(|&v| inf.row(v).1[0] < 0.9).count();
    assert!(shared > 31, "{shared} of {} membrane vertices blend two bones", sheet.len());
    // Switched off, nothing is rigid and the membrane is still weighted.
    let (off, rep) = heat(&m, &b, &HeatOptions { rigid_accessories: false, ..Default::default() });
    assert_rows_sum_to_one(&off);
    assert_eq!((rep.rigid_pieces, rep.spanning_pieces), (0, 0));
}

/// An imported-style rig (tails invented by the importer, nothing connected) in a thin upright
/// cylinder: a root below the mesh, a bone whose tail is a short sideways stub while its child
/// starts 0.9 higher, and that child. Returns (mesh, bones, parents).
fn imported_rig() -> (Mesh, Bones, Vec<i32>) {
    let m = capped_cylinder(0.08, 2.0, 41, 16);
    let heads = vec![[0.0, 0.0, -0.5], [0.0, 0.0, 0.1], [0.0, 0.0, 1.0]];
    let tails = vec![[0.3, 0.0, -0.5], [0.05, 0.0, 0.1], [0.0, 0.0, 1.9]];
    (m, (heads, tails), vec![-1, 0, 1])
}

/// Mean weight of `bone` over the vertices with `z` in `[lo, hi]`.
fn mean_weight(m: &Mesh, inf: &Influences, bone: i32, lo: f32, hi: f32) -> f32 {
    let rows: Vec<usize> = (0..m.0.len()).filter(|&v| (lo..=hi).contains(&m.0[v][2])).collect();
    let sum: f32 = rows
        .iter()
        .map(|&v| {
            let (idx, w) = inf.row(v);
            idx.iter().zip(w).filter(|(j, _)| **j == bone).map(|(_, w)| *w).sum::<f32>()
        })
        .sum();
    sum / rows.len() as f32
}

#[test]
fn imported_bones_reach_their_children_inside_the_mesh() {
    let (m, b, parents) = imported_rig();
    let (tails, _) = heat(&m, &b, &HeatOptions::default());
    let opts = HeatOptions { parents: Some(parents), ..HeatOptions::default() };
    let (reach, _) = heat(&m, &b, &opts);
    assert_rows_sum_to_one(&reach);
    // Between bone 1's head and its child's head the limb is bone 1's.
    let (with, without) = (mean_weight(&m, &reach, 1, 0.4, 0.7), mean_weight(&m, &tails, 1, 0.4, 0.7));
    assert!(with > 0.9, "bone 1 reaching its child: {with}");
    assert!(without < 0.8, "bone 1 as its invented stub: {without}");
    // The root's span up to bone 1 runs mostly outside the mesh: not used, so the root (below
    // the mesh, its tail sideways) leads no vertex, while taking that span would give it the
    // bottom cap.
    for v in 0..m.0.len() {
        let (idx, w) = reach.row(v);
        let lead = idx[w.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap().0];
        assert_ne!(lead, 0, "vertex {v} at z {} led by the root", m.0[v][2]);
    }
    // Bad parents are errors.
    for bad in [vec![-1, 0], vec![-1, 1, 1], vec![-1, 0, 3]] {
        let opts = HeatOptions { parents: Some(bad), ..HeatOptions::default() };
        assert!(heat_weights(&m.0, &m.1, &b.0, &b.1, &opts, None).is_err());
    }
}

/// A reaching bone's child spans *replace* its invented head -> tail: an importer's tail that
/// points back down the limb (along the joint's local Y) must not claim the parent's part.
#[test]
fn a_reaching_bone_drops_its_invented_tail() {
    let m = capped_cylinder(0.08, 2.0, 41, 16);
    let heads = vec![[0.0, 0.0, 0.1], [0.0, 0.0, 1.0], [0.0, 0.0, 1.8]];
    let tails = vec![[0.05, 0.0, 0.1], [0.0, 0.0, 0.6], [0.0, 0.0, 1.9]];
    let b = (heads, tails);
    let opts = HeatOptions { parents: Some(vec![-1, 0, 1]), ..HeatOptions::default() };
    let (reach, _) = heat(&m, &b, &opts);
    let (tails, _) = heat(&m, &b, &HeatOptions::default());
    assert_rows_sum_to_one(&reach);
    let (with, without) = (mean_weight(&m, &reach, 0, 0.55, 0.85), mean_weight(&m, &tails, 0, 0.55, 0.85));
    assert!(with > 0.8, "bone 0 reaching bone 1 keeps its part: {with}");
    assert!(without < 0.2, "head -> tail, bone 1 points down into it: {without}");
    assert!(mean_weight(&m, &reach, 1, 1.2, 1.6) > 0.8);
}

/// A childless bone whose invented tail points sideways (as the Fox's head bone points up while
/// its snout lies ahead) also continues its parent's line when the rig's tails are guesses
/// (here the parent's tail is a sideways stub, not aimed at its child): the limb beyond the
/// joint is its own, not shared half and half with the parent, whose end is just as near.
#[test]
fn a_childless_bone_continues_its_parent_line() {
    let m = capped_cylinder(0.3, 2.0, 41, 16);
    let heads = vec![[0.0, 0.0, 0.1], [0.0, 0.0, 1.0]];
    let tails = vec![[0.05, 0.0, 0.1], [0.25, 0.0, 1.0]];
    let b = (heads, tails);
    let opts = HeatOptions { parents: Some(vec![-1, 0]), ..HeatOptions::default() };
    let (reach, _) = heat(&m, &b, &opts);
    // The same bones as plain head -> tail, the parent reaching its child.
    let plain = (b.0.clone(), vec![[0.0, 0.0, 1.0], [0.25, 0.0, 1.0]]);
    let (tails, _) = heat(&m, &plain, &HeatOptions::default());
    assert_rows_sum_to_one(&reach);
    let (with, without) = (mean_weight(&m, &reach, 1, 1.4, 2.0), mean_weight(&m, &tails, 1, 1.4, 2.0));
    assert!(with > 0.95, "the leaf continuing its parent's line: {with}");
    assert!(without < with - 0.1, "the leaf as its sideways tail: {without}");
    // The parent keeps its own part.
    assert!(mean_weight(&m, &reach, 0, 0.2, 0.7) > 0.9);
}

/// When the rig's tails point at their children (the author's bones, as a rig made in Blender
/// and exported keeps them), a leaf's tail is the author's too: no continuation, the leaf is
/// its head -> tail, and the weights are those of the plain bones.
#[test]
fn a_leaf_of_a_rig_with_aimed_tails_keeps_its_own_tail() {
    let m = capped_cylinder(0.3, 2.0, 41, 16);
    let b = (vec![[0.0, 0.0, 0.1], [0.0, 0.0, 1.0]], vec![[0.0, 0.0, 1.0], [0.25, 0.0, 1.0]]);
    let opts = HeatOptions { parents: Some(vec![-1, 0]), ..HeatOptions::default() };
    let (reach, _) = heat(&m, &b, &opts);
    let (tails, _) = heat(&m, &b, &HeatOptions::default());
    assert_eq!((&reach.indices, &reach.weights), (&tails.indices, &tails.weights));
}

/// A root joint with no children, given a long invented tail that runs straight up through
/// another bone (a round monster's body joint and its head bone, both roots), ends halfway to
/// that bone: the head bone leads its own part instead of tying with the root over it, and the
/// root keeps the bottom.
#[test]
fn an_invented_tail_that_runs_into_another_bone_ends_before_it() {
    let m = capped_cylinder(0.2, 2.0, 41, 16);
    let heads = vec![[0.0, 0.0, 0.0], [0.0, 0.0, 0.8], [0.0, 0.0, 1.4]];
    let tails = vec![[0.0, 0.0, 1.6], [0.0, 0.0, 1.4], [0.0, 0.0, 2.0]];
    let b = (heads, tails);
    let opts = HeatOptions { parents: Some(vec![-1, -1, 1]), ..HeatOptions::default() };
    let (reach, _) = heat(&m, &b, &opts);
    let (plain, _) = heat(&m, &b, &HeatOptions::default());
    assert_rows_sum_to_one(&reach);
    let (with, without) = (mean_weight(&m, &reach, 1, 0.95, 1.25), mean_weight(&m, &plain, 1, 0.95, 1.25));
    assert!(with > 0.9 && without < 0.6, "the head bone's part, the root's tail cut: {with}, or not: {without}");
    assert!(mean_weight(&m, &reach, 0, 0.0, 0.2) > 0.9);
}

/// A bone whose tail starts a connected child and which has a child elsewhere too (a chest with
/// its neck at its tail and shoulders beside it, as CesiumMan's) stands for head -> tail as well
/// as for its span to that child: the span alone would hand the chest's upper part to the neck
/// and the shoulders.
#[test]
fn a_connected_bone_with_a_side_child_keeps_its_head_to_tail() {
    let m = capped_cylinder(0.08, 2.0, 41, 16);
    let heads = vec![[0.0, 0.0, 0.1], [0.0, 0.0, 1.0], [0.03, 0.0, 0.3]];
    let tails = vec![[0.0, 0.0, 1.0], [0.0, 0.0, 1.9], [0.3, 0.0, 0.3]];
    let b = (heads, tails);
    let opts = HeatOptions { parents: Some(vec![-1, 0, 0]), ..HeatOptions::default() };
    let (reach, _) = heat(&m, &b, &opts);
    assert_rows_sum_to_one(&reach);
    let chest = mean_weight(&m, &reach, 0, 0.5, 0.85);
    assert!(chest > 0.8, "the chest's upper part: {chest}");
    assert!(mean_weight(&m, &reach, 1, 1.2, 1.8) > 0.8);
}

/// Random rigs (bones anywhere, inside or outside, any valid parent list) on a mesh of two
/// pieces: reaching children never fails and every row sums to 1.
#[test]
fn random_imported_rigs_always_give_weights() {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f32 / (1u64 << 53) as f32
    };
    let (mut v, mut t) = capped_cylinder(0.2, 2.0, 21, 12);
    let (v2, t2) = capped_cylinder(0.1, 0.5, 6, 8);
    let base = v.len() as u32;
    v.extend(v2.iter().map(|p| [p[0] + 1.0, p[1], p[2]]));
    t.extend(t2.iter().map(|f| f.map(|i| i + base)));
    let mut cycles = 0;
    for _ in 0..40 {
        let b = 1 + (next() * 8.0) as usize;
        let mut point = || [next() * 2.0 - 0.5, next() * 0.6 - 0.3, next() * 2.6 - 0.3];
        let heads: Vec<[f32; 3]> = (0..b).map(|_| point()).collect();
        let tails: Vec<[f32; 3]> = heads.iter().map(|h| [h[0] + 0.1, h[1], h[2] + 0.05]).collect();
        // Parents: a random forest in a random bone order (each bone's parent, if any, comes
        // earlier in that order, so there is no cycle).
        let mut order: Vec<usize> = (0..b).collect();
        for k in (1..b).rev() {
            order.swap(k, ((next() * (k + 1) as f32) as usize).min(k));
        }
        let mut parents = vec![-1i32; b];
        for k in 1..b {
            let j = (next() * (k + 1) as f32) as usize; // k: a root
            if j < k {
                parents[order[k]] = order[j] as i32;
            }
        }
        let opts = HeatOptions { parents: Some(parents.clone()), ..HeatOptions::default() };
        let (inf, _) =
            heat_weights(&v, &t, &heads, &tails, &opts, None).unwrap_or_else(|e| panic!("parents {parents:?}: {e}"));
        assert_rows_sum_to_one(&inf);
        assert!(inf.indices.iter().all(|&j| j < b as i32));
        // Closing a cycle (the first root under one of its descendants) is a clear error.
        let root = order[0];
        let below_root = |mut c: usize| loop {
            match parents[c] {
                -1 => return false,
                p if p as usize == root => return true,
                p => c = p as usize,
            }
        };
        if let Some(k) = (1..b).rev().find(|&k| below_root(order[k])) {
            parents[root] = order[k] as i32;
            let opts = HeatOptions { parents: Some(parents.clone()), ..HeatOptions::default() };
            let cycle = heat_weights(&v, &t, &heads, &tails, &opts, None);
            assert!(matches!(cycle, Err(Error::InvalidArgument(_))), "parents {parents:?}");
            cycles += 1;
        }
    }
    assert!(cycles >= 10, "only {cycles} cycles tried");
}

#[test]
fn bent_bones_are_their_polylines() {
    // A tube along Z (radius 0.15) and two bones on its axis.
    let m = capped_cylinder(0.15, 2.0, 41, 16);
    let b: Bones = (vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]], vec![[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]]);
    let (plain, _) = heat(&m, &b, &HeatOptions::default());
    let bent = |points: Vec<[f32; 3]>, bone: Vec<u32>| HeatOptions {
        curves: Some(BoneCurves { points, bone }),
        ..HeatOptions::default()
    };
    // Points on the straight bone change nothing.
    let (straight, _) = heat(&m, &b, &bent(vec![[0.0, 0.0, 0.25], [0.0, 0.0, 0.5], [0.0, 0.0, 0.75]], vec![0; 3]));
    assert!(max_abs_diff(&plain.to_dense(2), &straight.to_dense(2)) < 1e-6);
    // Bone 1 bent towards +x: just above the joint, the +x side is more on bone 1.
    let (curved, _) = heat(&m, &b, &bent(vec![[0.1, 0.0, 1.5]], vec![1]));
    assert_rows_sum_to_one(&curved);
    let side = |inf: &Influences, sign: f32| {
        let rows: Vec<usize> =
            (0..m.0.len()).filter(|&v| (1.0..=1.3).contains(&m.0[v][2]) && m.0[v][0] * sign > 0.1).collect();
        let w: f32 = rows.iter().map(|&v| inf.to_dense(2)[v * 2 + 1]).sum();
        w / rows.len() as f32
    };
    assert!((side(&plain, 1.0) - side(&plain, -1.0)).abs() < 1e-4);
    assert!(side(&curved, 1.0) > side(&curved, -1.0) + 0.05, "{} {}", side(&curved, 1.0), side(&curved, -1.0));
    // Bad curves are errors.
    let err = |o: HeatOptions| heat_weights(&m.0, &m.1, &b.0, &b.1, &o, None).unwrap_err();
    assert!(matches!(err(bent(vec![[0.0; 3]], vec![])), Error::Shape(_)));
    assert!(matches!(err(bent(vec![[0.0; 3]], vec![2])), Error::InvalidArgument(_)));
    assert!(matches!(err(bent(vec![[f32::NAN, 0.0, 0.0]], vec![0])), Error::NonFinite { count: 1, .. }));
}

/// A coat over the body in the same mesh (a second, larger closed shell around the first, as
/// clothes joined into a character are) is weighted as it would be alone: the body beneath
/// hides every bone from it except the chain's two ends, which poke out of the body, and heat
/// from those few coat vertices alone would spread over the whole coat. The body is unchanged.
#[test]
fn a_coat_over_the_body_is_weighted_as_it_would_be_alone() {
    let body = capped_cylinder(0.15, 2.0, 41, 16);
    let coat: Mesh = {
        let (v, t) = capped_cylinder(0.2, 2.4, 49, 16);
        (v.iter().map(|p| [p[0], p[1], p[2] - 0.2]).collect(), t)
    };
    // Four bones from z = -0.1 to 2.1: both ends outside the body, inside the coat.
    let zs: Vec<f32> = (0..=4).map(|i| -0.1 + 0.55 * i as f32).collect();
    let bones: Bones = ((0..4).map(|i| [0.0, 0.0, zs[i]]).collect(), (0..4).map(|i| [0.0, 0.0, zs[i + 1]]).collect());
    let mut both = body.clone();
    let base = both.0.len() as u32;
    both.0.extend(&coat.0);
    both.1.extend(coat.1.iter().map(|t| t.map(|i| i + base)));

    let (inf, rep) = heat(&both, &bones, &HeatOptions::default());
    assert_eq!((rep.pieces, rep.fallback_pieces, rep.rigid_pieces), (2, 0, 0));
    assert_rows_sum_to_one(&inf);
    let dense = inf.to_dense(4);
    let (n_body, n) = (base as usize, both.0.len());
    let rows = |d: &[f32], r: std::ops::Range<usize>| d[r.start * 4..r.end * 4].to_vec();
    let (body_alone, _) = heat(&body, &bones, &HeatOptions::default());
    assert!(max_abs_diff(&rows(&dense, 0..n_body), &body_alone.to_dense(4)) < 1e-4);
    let (coat_alone, _) = heat(&coat, &bones, &HeatOptions::default());
    let coat_alone = coat_alone.to_dense(4);
    let joined = rows(&dense, n_body..n);
    let l1 = |v: usize| (0..4).map(|b| (joined[v * 4 + b] - coat_alone[v * 4 + b]).abs()).sum::<f32>();
    let mean = (0..coat.0.len()).map(l1).sum::<f32>() / coat.0.len() as f32;
    assert!(mean < 0.02, "mean L1 to the coat alone {mean}");
    // Along its side the coat follows the bone at its height.
    for (v, p) in coat.0.iter().enumerate() {
        let b = (0..4).find(|&b| (zs[b] + 0.1..zs[b + 1] - 0.1).contains(&p[2]));
        if let (Some(b), true) = (b, p[0].hypot(p[1]) > 0.19) {
            assert!(joined[v * 4 + b] > 0.6, "coat vertex {v} at z {} has {} on bone {b}", p[2], joined[v * 4 + b]);
        }
    }
}

/// Bones are solved in blocks when their dense weights would not fit the memory budget; the
/// blocks (and the order they come in) change nothing: symmetry pairs share a block, rigid
/// pieces and the per-vertex top k are the same.
#[test]
fn bones_solved_in_blocks_give_the_same_weights() {
    let (mut m, (mut h, mut t)) = horizontal();
    h.push([0.0, 0.3, 0.0]); // an 'arm' outside the body, and a prop around its tip
    t.push([0.0, 0.62, 0.0]);
    add_box(&mut m, [0.0, 0.68, 0.0], [0.05, 0.07, 0.05], false);
    let b = (h, t);
    let sym = Some(Symmetry { axis: 0, plane: 0.0, mirror: vec![3, 2, 1, 0, 4] });
    for symmetry in [None, sym] {
        let whole =
            HeatOptions { symmetry: symmetry.clone(), mirror_tolerance: 1e-4, max_influences: 3, ..Default::default() };
        let (all, rep) = heat(&m, &b, &whole);
        assert_eq!(rep.rigid_pieces, 1, "{rep:?}");
        for block_bones in [1, 2, 3] {
            let (blocks, _) = heat(&m, &b, &HeatOptions { block_bones, ..whole.clone() });
            assert_eq!(blocks, all, "{block_bones} bones at a time, symmetry {:?}", symmetry.is_some());
        }
    }
}

/// Bones no vertex has as its heat source (far outside the mesh) change nothing: the other
/// bones keep their weights exactly and these get none (their solves are skipped, and the
/// solved columns go back to their own bones).
#[test]
fn bones_no_vertex_sees_change_nothing() {
    let (m, (h, t)) = cylinder();
    let (plain, _) = heat(&m, &(h.clone(), t.clone()), &HeatOptions::default());
    let far = |i: usize| ([3.0 + i as f32, 0.0, 0.5], [3.0 + i as f32, 0.0, 1.5]);
    // bones 0..4 of the chain at 0, 2, 3, 5; far ones at 1, 4, 6
    let order = [Some(0), None, Some(1), Some(2), None, Some(3), None];
    let (mut hh, mut tt) = (Vec::new(), Vec::new());
    for (i, o) in order.iter().enumerate() {
        let (a, b) = o.map_or_else(|| far(i), |j| (h[j], t[j]));
        hh.push(a);
        tt.push(b);
    }
    let (mixed, _) = heat(&m, &(hh, tt), &HeatOptions::default());
    let to_chain = |j: i32| if j < 0 { -1 } else { order[j as usize].map_or(99, |c| c as i32) };
    for v in 0..plain.n() {
        let (pi, pw) = plain.row(v);
        let (mi, mw) = mixed.row(v);
        assert_eq!(mi.iter().map(|&j| to_chain(j)).collect::<Vec<_>>(), pi, "vertex {v}");
        assert_eq!(mw, pw, "vertex {v}");
    }
}

#[test]
fn many_meshes_in_one_call_get_what_one_call_each_gives_and_fail_alone() {
    let (m, b) = cylinder();
    let moved =
        |dz: f32, s: f32| -> Mesh { (m.0.iter().map(|p| [p[0] * s, p[1] * s, p[2] * s + dz]).collect(), m.1.clone()) };
    let meshes = [moved(0.0, 0.3), moved(0.8, 0.3), m.clone(), moved(1.6, 0.3)];
    let bad_tris = [[0, 1, 10_000]];
    let opts = HeatOptions { max_influences: 3, ..HeatOptions::default() };
    let mut refs: Vec<MeshRef> = meshes.iter().map(|x| (&x.0[..], &x.1[..])).collect();
    let many = heat_weights_many(&refs, &b.0, &b.1, &opts);
    assert_eq!(many.len(), meshes.len());
    for (x, got) in meshes.iter().zip(&many) {
        let (want, _) = heat(x, &b, &opts);
        let (inf, _) = got.as_ref().expect("a good mesh is solved");
        assert_eq!((&inf.indices, &inf.weights), (&want.indices, &want.weights));
    }
    refs[1] = (&meshes[1].0[..], &bad_tris[..]);
    let out = heat_weights_many(&refs, &b.0, &b.1, &opts);
    assert!(matches!(out[1], Err(Error::BadIndex { index: 10_000, .. })), "{:?}", out[1].as_ref().err());
    for k in [0, 2, 3] {
        assert_eq!(out[k].as_ref().unwrap().0.weights, many[k].as_ref().unwrap().0.weights);
    }
}

/// The report without its timings, to compare two runs.
fn untimed(r: &HeatReport) -> HeatReport {
    HeatReport { timings: Vec::new(), ..r.clone() }
}

/// Heat with the caller's sources, given the sources heat finds itself, is heat itself, bit
/// for bit: on split seams (welded copies add up), with pieces that fall back, a rigid button
/// and an isolated vertex, with symmetry, imported bones, no visibility test, and vertices
/// tied between three bones (heat / 3 each).
#[test]
fn the_sources_heat_finds_given_back_give_the_same_weights() {
    let (m, b) = cylinder();
    let split = split_flat(&m.0, &m.1).unwrap();
    let mut pieces = m.clone();
    let (v2, t2) = capped_cylinder(0.15, 2.0, 41, 16);
    let base = pieces.0.len() as u32;
    pieces.0.extend(v2.iter().map(|p| [p[0] + 1.0, p[1], p[2]]));
    pieces.1.extend(t2.iter().map(|t| t.map(|i| i + base)));
    add_box(&mut pieces, [-0.6, 0.0, 1.2], [0.02, 0.02, 0.02], false);
    pieces.0.push([0.0, 3.0, 0.1]);
    let (hm, hb) = horizontal();
    let sym = HeatOptions {
        symmetry: Some(Symmetry { axis: 0, plane: 0.0, mirror: vec![3, 2, 1, 0] }),
        ..Default::default()
    };
    let (im, ib, parents) = imported_rig();
    let imported = HeatOptions { parents: Some(parents), ..Default::default() };
    // Bone 1 three times: its vertices tie between the three copies.
    let triple =
        (vec![b.0[0], b.0[1], b.0[1], b.0[1], b.0[2], b.0[3]], vec![b.1[0], b.1[1], b.1[1], b.1[1], b.1[2], b.1[3]]);
    let unseen = HeatOptions { visibility: false, max_influences: 2, ..Default::default() };
    let cases: [(&str, &Mesh, &Bones, HeatOptions); 7] = [
        ("cylinder", &m, &b, HeatOptions::default()),
        ("split", &split, &b, HeatOptions::default()),
        ("pieces", &pieces, &b, HeatOptions::default()),
        ("symmetry", &hm, &hb, sym),
        ("imported", &im, &ib, imported),
        ("no visibility", &m, &b, unseen),
        ("three ties", &m, &triple, HeatOptions::default()),
    ];
    for (name, m, b, opts) in cases {
        let (want, want_report) = heat(m, b, &opts);
        let sources = heat_sources(&m.0, &m.1, &b.0, &b.1, &opts).unwrap();
        assert_eq!((sources.n(), sources.k), (m.0.len(), 4), "{name}");
        let (got, report) = heat_weights_with_sources(&m.0, &m.1, &b.0, &b.1, &sources, &opts, None).unwrap();
        assert_eq!((&got.indices, &got.weights), (&want.indices, &want.weights), "{name}");
        assert_eq!(untimed(&report), untimed(&want_report), "{name}");
        let names: Vec<&str> = report.timings.iter().map(|t| t.0).collect();
        assert_eq!(names, want_report.timings.iter().map(|t| t.0).collect::<Vec<_>>(), "{name}");
        if name == "three ties" {
            let tied = (0..sources.n()).filter(|&v| sources.row(v).0[..3] == [1, 2, 3]).count();
            assert!(tied > 100, "{tied} vertices tied between the copies of bone 1");
        }
        if name == "pieces" {
            assert_eq!((report.fallback_pieces, report.rigid_pieces, report.isolated_vertices), (2, 1, 1));
        }
    }
}

/// The caller's sources set the heat: every vertex a source of bone 0 alone gives bone 0
/// everywhere; every vertex half bone 0 and half bone 2 gives those two halves everywhere
/// (`L 1 = 0`). Bad sources are errors.
#[test]
fn given_sources_set_where_the_heat_comes_from() {
    let (m, b) = cylinder();
    let n = m.0.len();
    let opts = HeatOptions::default();
    let one = Influences { k: 1, indices: vec![0; n], weights: vec![1.0; n] };
    let (inf, _) = heat_weights_with_sources(&m.0, &m.1, &b.0, &b.1, &one, &opts, None).unwrap();
    assert!((0..n).all(|v| inf.row(v) == (&[0, -1, -1, -1][..], &[1.0, 0.0, 0.0, 0.0][..])));
    let halves = Influences { k: 2, indices: [0, 2].repeat(n), weights: vec![0.5; 2 * n] };
    let (inf, _) = heat_weights_with_sources(&m.0, &m.1, &b.0, &b.1, &halves, &opts, None).unwrap();
    let dense = inf.to_dense(4);
    assert!(dense.chunks(4).all(|r| (r[0] - 0.5).abs() < 1e-5 && (r[2] - 0.5).abs() < 1e-5), "{:?}", &dense[..8]);
    let bad = |indices: Vec<i32>, weights: Vec<f32>| {
        let k = indices.len() / n.max(1);
        heat_weights_with_sources(&m.0, &m.1, &b.0, &b.1, &Influences { k: k.max(1), indices, weights }, &opts, None)
    };
    assert!(matches!(bad(vec![0; n - 1], vec![1.0; n - 1]), Err(Error::Shape(_))));
    assert!(matches!(bad(vec![4; n], vec![1.0; n]), Err(Error::InvalidArgument(_))));
    assert!(matches!(bad(vec![0; n], vec![-1.0; n]), Err(Error::InvalidArgument(_))));
    assert!(matches!(bad(vec![0; n], vec![f32::NAN; n]), Err(Error::InvalidArgument(_))));
}
