//! Geodesic voxel binding and weight transfer on generated meshes: every vertex weighted, the
//! right bones, pieces of all kinds bound without repair, cancellation, scale, bad input.

mod common;
use common::assert_rows_sum_to_one;
use miniskeleton_core::primitives::{add_box, bone_chain, capped_cylinder};
use miniskeleton_core::weights::{heat_weights, HeatOptions};
use miniskeleton_core::weights::{transfer_weights, voxel_weights, Influences, TransferOptions, VoxelOptions};
use miniskeleton_core::Error;

/// On the 4-bone chain along the cylinder (`bone_chain(4.0, 4)`), away from the joints each
/// vertex's strongest bone is the one at its height.
fn strongest_bone_is_the_one_at_its_height(v: &[[f32; 3]], inf: &Influences) {
    for (p, i) in v.iter().zip(0..) {
        let along = (p[2] - 0.1) / 0.95;
        let frac = along - along.floor();
        if (0.25..0.75).contains(&frac) && (0.0..4.0).contains(&along) {
            assert_eq!(inf.row(i).0[0], along.floor() as i32, "vertex at z = {}", p[2]);
        }
    }
}

#[test]
fn a_cylinder_chain_follows_its_bones() {
    let (v, t) = capped_cylinder(0.3, 4.0, 41, 16);
    let (h, tl, _) = bone_chain(4.0, 4);
    let (inf, report) = voxel_weights(&v, &t, &h, &tl, &VoxelOptions::default(), None).unwrap();
    assert_rows_sum_to_one(&inf);
    assert!(report.solid_voxels > 0 && report.outside_bones == 0);
    strongest_bone_is_the_one_at_its_height(&v, &inf);
}

/// Where every vertex sees its bone and nothing is shared (falloff 0), the voxel sources are
/// heat's (the nearest visible bone, ties sharing) and so is the heat term's distance (the
/// normal-weighted one): the weights are heat's, to single precision (the voxel stages' plain
/// distance in the heat term instead differs by 1e-4 here).
#[test]
fn with_no_falloff_a_body_that_sees_its_bones_binds_as_heat() {
    let (v, t) = capped_cylinder(0.3, 4.0, 41, 16);
    let (h, tl, _) = bone_chain(4.0, 4);
    let opts = VoxelOptions { falloff: 0.0, ..Default::default() };
    let (voxel, _) = voxel_weights(&v, &t, &h, &tl, &opts, None).unwrap();
    let (heat, _) = heat_weights(&v, &t, &h, &tl, &HeatOptions::default(), None).unwrap();
    let dense = |inf: &Influences, i: usize| {
        let mut row = [0.0f32; 4];
        let (idx, w) = inf.row(i);
        idx.iter().zip(w).filter(|(&j, _)| j >= 0).for_each(|(&j, &x)| row[j as usize] += x);
        row
    };
    let worst = (0..v.len())
        .flat_map(|i| dense(&voxel, i).into_iter().zip(dense(&heat, i)).map(|(a, b)| (a - b).abs()))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-6, "largest difference from heat's weights: {worst}");
}

/// A mesh with no faces (a point cloud) has no solid: each vertex takes its nearest bone by the
/// straight line.
#[test]
fn a_mesh_without_faces_takes_the_straight_distances() {
    let (v, _) = capped_cylinder(0.3, 4.0, 41, 16);
    let (h, tl, _) = bone_chain(4.0, 4);
    let (inf, _) = voxel_weights(&v, &[], &h, &tl, &VoxelOptions::default(), None).unwrap();
    assert_rows_sum_to_one(&inf);
    strongest_bone_is_the_one_at_its_height(&v, &inf);
}

/// A body (a box standing up) in several objects: a hat above it that does not touch it, an
/// eye inside it, an open sleeve around it, and two boxes pushed into each other across its
/// foot. Every vertex weighted; the hat and eye rigid on the top bone.
#[test]
fn pieces_of_every_kind_bind_without_repair() {
    let (mut v, mut t, mut objects) = (Vec::new(), Vec::new(), Vec::new());
    let mut add = |v: &mut Vec<[f32; 3]>, t: &mut Vec<[u32; 3]>, lo, hi, obj: u32| {
        let n = v.len();
        add_box(v, t, lo, hi);
        objects.extend(std::iter::repeat_n(obj, v.len() - n));
    };
    add(&mut v, &mut t, [-0.3, -0.3, 0.0], [0.3, 0.3, 4.0], 0); // body
    add(&mut v, &mut t, [-0.3, -0.3, 4.05], [0.3, 0.3, 4.4], 1); // hat
    add(&mut v, &mut t, [0.1, -0.25, 3.5], [0.2, -0.15, 3.6], 2); // eye
    add(&mut v, &mut t, [-0.6, -0.2, 0.1], [0.6, 0.2, 0.5], 3); // two boxes, one object
    add(&mut v, &mut t, [-0.2, -0.6, 0.2], [0.2, 0.6, 0.7], 3);
    // An open sleeve (a square tube without ends) around the middle.
    let o = v.len() as u32;
    for z in [1.5f32, 2.5] {
        for (x, y) in [(-0.35, -0.35), (0.35, -0.35), (0.35, 0.35), (-0.35, 0.35)] {
            v.push([x, y, z]);
            objects.push(4);
        }
    }
    for s in 0..4u32 {
        let (a, b) = (o + s, o + (s + 1) % 4);
        t.push([a, b, b + 4]);
        t.push([a, b + 4, a + 4]);
    }
    let (h, tl, parents) = bone_chain(4.0, 4);
    let opts = VoxelOptions { objects: Some(objects.clone()), parents: Some(parents), ..Default::default() };
    let (inf, report) = voxel_weights(&v, &t, &h, &tl, &opts, None).unwrap();
    assert_rows_sum_to_one(&inf);
    assert!(report.heat.rigid_pieces >= 2, "{report:?}");
    for (i, &o) in objects.iter().enumerate() {
        let (idx, w) = inf.row(i);
        match o {
            1 | 2 => assert_eq!((idx[0], w[0]), (3, 1.0), "object {o}"),
            3 => assert_eq!(idx[0], 0, "object {o}"),
            4 => assert!(idx[0] == 1 || idx[0] == 2, "sleeve: {idx:?} {w:?}"),
            _ => {}
        }
    }
    // The sleeve is solved, not rigid: its bottom and top follow different bones.
    let sleeve: Vec<usize> = (0..objects.len()).filter(|&i| objects[i] == 4).collect();
    assert_ne!(inf.row(sleeve[0]).0[0], inf.row(sleeve[7]).0[0]);
}

#[test]
fn the_same_weights_at_any_scale() {
    let (v, t) = capped_cylinder(0.3, 4.0, 21, 12);
    let (h, tl, _) = bone_chain(4.0, 3);
    let (base, _) = voxel_weights(&v, &t, &h, &tl, &VoxelOptions::default(), None).unwrap();
    for s in [1e-3f32, 1e3] {
        let scale = |p: &Vec<[f32; 3]>| p.iter().map(|x| x.map(|c| c * s)).collect::<Vec<_>>();
        let (inf, _) = voxel_weights(&scale(&v), &t, &scale(&h), &scale(&tl), &VoxelOptions::default(), None).unwrap();
        assert_eq!(inf.indices, base.indices, "scale {s}");
        for (a, b) in inf.weights.iter().zip(&base.weights) {
            assert!((a - b).abs() < 1e-4, "scale {s}");
        }
    }
}

#[test]
fn progress_false_cancels_and_bad_options_are_errors() {
    let (v, t) = capped_cylinder(0.3, 4.0, 21, 12);
    let (h, tl, _) = bone_chain(4.0, 3);
    let stop = |_: f32| false;
    assert_eq!(voxel_weights(&v, &t, &h, &tl, &VoxelOptions::default(), Some(&stop)).unwrap_err(), Error::Cancelled);
    for bad in [
        VoxelOptions { resolution: 8, ..Default::default() },
        VoxelOptions { falloff: 2.0, ..Default::default() },
        VoxelOptions { falloff: f32::NAN, ..Default::default() },
        VoxelOptions { max_influences: 0, ..Default::default() },
    ] {
        assert!(matches!(voxel_weights(&v, &t, &h, &tl, &bad, None), Err(Error::InvalidArgument(_))), "{bad:?}");
    }
    let short = VoxelOptions { objects: Some(vec![0; 3]), ..Default::default() };
    assert!(matches!(voxel_weights(&v, &t, &h, &tl, &short, None), Err(Error::Shape(_))));
    let mut nan = v.clone();
    nan[3][1] = f32::NAN;
    assert!(matches!(voxel_weights(&nan, &t, &h, &tl, &VoxelOptions::default(), None), Err(Error::NonFinite { .. })));
}

/// A sleeve just over a weighted cylinder takes its weights where it lies on it; a ring far
/// from it (in the same garment, connected) is inpainted; a separate piece away from the body
/// takes its nearest point's weights.
#[test]
fn transfer_copies_where_the_garment_lies_and_inpaints_the_rest() {
    let (bv, bt) = capped_cylinder(0.3, 4.0, 41, 16);
    let (h, tl, _) = bone_chain(4.0, 4);
    let (body, _) = voxel_weights(&bv, &bt, &h, &tl, &VoxelOptions::default(), None).unwrap();
    // The garment: a cylinder of radius 0.32 over the body, its top ring flared out to 1.0.
    let (mut gv, gt) = capped_cylinder(0.32, 3.0, 31, 16);
    let rings = 31;
    for p in gv.iter_mut().take(rings * 16).skip((rings - 3) * 16) {
        p[0] *= 3.0;
        p[1] *= 3.0;
    }
    let (inf, report) = transfer_weights(&bv, &bt, &body, &gv, &gt, &TransferOptions::default()).unwrap();
    assert_rows_sum_to_one(&inf);
    assert!(report.matched > 400 && report.inpainted >= 32 && report.nearest == 0, "{report:?}");
    // Matched vertices carry the body's strongest bone at their height.
    for (i, p) in gv.iter().enumerate().take(20 * 16) {
        let along = ((p[2] - 0.1) / 0.95).floor().clamp(0.0, 3.0) as i32;
        let frac = (p[2] - 0.1) / 0.95 - along as f32;
        if (0.3..0.7).contains(&frac) {
            assert_eq!(inf.row(i).0[0], along, "z = {}", p[2]);
        }
    }
    // A separate box far away: its nearest point's weights (the bottom bone).
    let (mut fv, mut ft) = (Vec::new(), Vec::new());
    add_box(&mut fv, &mut ft, [3.0, 3.0, -1.0], [3.2, 3.2, -0.8]);
    let (far, report) = transfer_weights(&bv, &bt, &body, &fv, &ft, &TransferOptions::default()).unwrap();
    assert_eq!((report.matched, report.nearest), (0, 8));
    assert!((0..8).all(|i| far.row(i).0[0] == 0));
    // Body weights of another length are an error.
    let short = Influences::empty(3, 4);
    assert!(matches!(transfer_weights(&bv, &bt, &short, &gv, &gt, &TransferOptions::default()), Err(Error::Shape(_))));
}

#[test]
fn a_bone_across_a_gap_finer_than_a_voxel_does_not_take_what_cannot_see_it() {
    // Two boxes side by side, 0.005 apart (a twentieth of a voxel: one solid across the gap),
    // each with its bone; box A's bone runs close to the gap, so the near corners of box B are
    // nearer to it in a straight line, through the gap, than to their own bone.
    let (mut v, mut t) = (Vec::new(), Vec::new());
    add_box(&mut v, &mut t, [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
    add_box(&mut v, &mut t, [1.005, 0.0, 0.0], [2.005, 1.0, 1.0]);
    let heads = [[0.9, 0.5, 0.1], [1.9, 0.5, 0.1]];
    let tails = [[0.9, 0.5, 0.9], [1.9, 0.5, 0.9]];
    let opts = VoxelOptions { resolution: 16, ..Default::default() };
    let (inf, _) = voxel_weights(&v, &t, &heads, &tails, &opts, None).unwrap();
    assert_rows_sum_to_one(&inf);
    for (i, p) in v.iter().enumerate() {
        let (idx, w) = inf.row(i);
        let own = if p[0] < 1.002 { 0 } else { 1 };
        assert_eq!(idx[0], own, "vertex {i} at {p:?}: {idx:?} {w:?}");
    }
}
