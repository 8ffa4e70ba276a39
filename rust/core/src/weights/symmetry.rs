//! Left/right symmetry of skinning weights: bone mirror maps checked and completed by place,
//! and weights averaged with their mirror images. The point mirror maps are in
//! [`crate::mesh::mirror`].

use crate::mesh::mirror::{mirror_map, mirror_point};
use crate::{Error, Result};
use glam::DVec3;

/// Check a bone mirror map: `(b,)`, entries in `0..b` forming an involution, or `-1` for a
/// side bone with no partner (its weights are not averaged). Errors otherwise.
pub fn validate_bone_mirror(bone_mirror: &[i32], b: usize) -> Result<()> {
    if bone_mirror.len() != b {
        return Err(Error::Shape(format!("bone_mirror has {} entries for {} bones", bone_mirror.len(), b)));
    }
    for (i, &m) in bone_mirror.iter().enumerate() {
        if m == -1 {
            continue;
        }
        if m < 0 || m as usize >= b || bone_mirror[m as usize] != i as i32 {
            return Err(Error::InvalidArgument(format!("bone_mirror must pair bones both ways (bone {i} -> {m})")));
        }
    }
    Ok(())
}

/// A bone given as a centre bone (its own mirror) with an end farther than this from the plane
/// (fraction of the skeleton's bounding-box diagonal) is a side bone whose name carries no side.
pub const CENTRE_BONE_OFF_PLANE: f64 = 0.01;

/// Side bones among the bones given as centre bones, found by place: a bone that is its own
/// mirror in `bone_mirror` but has an end farther than [`CENTRE_BONE_OFF_PLANE`] of the
/// skeleton's diagonal from the plane `x[axis] = plane` would have its weights averaged with their
/// own mirror image, splitting a limb's weights between both sides. Each such bone is paired
/// with the one whose midpoint [`mirror_map`] matches to its own (within that distance, both
/// ways) when both their ends are mirror images within it too, or else left unpaired (`-1`,
/// its weights not averaged).
/// Output: the resolved map (an involution as before) and (bones paired, bones left unpaired).
/// Errors: `axis > 2`.
pub fn pair_side_bones_by_place(
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    bone_mirror: &[i32],
    axis: usize,
    plane: f64,
) -> Result<(Vec<i32>, usize, usize)> {
    let ends: Vec<[DVec3; 2]> =
        heads.iter().zip(tails).map(|(h, t)| [DVec3::from(h.map(f64::from)), DVec3::from(t.map(f64::from))]).collect();
    let lo = ends.iter().flatten().fold(DVec3::splat(f64::INFINITY), |a, p| a.min(*p));
    let hi = ends.iter().flatten().fold(DVec3::splat(f64::NEG_INFINITY), |a, p| a.max(*p));
    let tol = CENTRE_BONE_OFF_PLANE * (hi - lo).length();
    let side: Vec<usize> = (0..ends.len())
        .filter(|&i| bone_mirror.get(i) == Some(&(i as i32)) && ends[i].iter().any(|p| (p[axis] - plane).abs() > tol))
        .collect();
    let mids: Vec<DVec3> = side.iter().map(|&i| (ends[i][0] + ends[i][1]) * 0.5).collect();
    let partner = mirror_map(&mids, axis, plane, tol)?;
    // The farther of bone i's two mirrored ends from bone j's (symmetric in i and j).
    let gap = |i: usize, j: usize| -> f64 {
        (0..2).map(|e| (mirror_point(ends[i][e], axis, plane) - ends[j][e]).length()).fold(0.0, f64::max)
    };
    let mut out = bone_mirror.to_vec();
    let mut paired = 0;
    for (k, &i) in side.iter().enumerate() {
        let j = usize::try_from(partner[k]).ok().filter(|&m| m != k).map(|m| side[m]);
        out[i] = match j {
            Some(j) if gap(i, j) <= tol => {
                paired += 1;
                j as i32
            }
            _ => -1,
        };
    }
    Ok((out, paired, side.len() - paired))
}

/// Symmetric averaging of dense weights, in place.
///
/// Inputs: `cols` `(b, n)` **column-major** (bone `j`'s weights are `cols[j*n .. j*n+n]`),
/// `vertex_mirror` `(n,)` from [`mirror_map`] (involution, `-1` = unmatched),
/// `bone_mirror` `(b,)` (involution, see [`validate_bone_mirror`]).
/// Output: `w[v][j] <- 0.5 (w[v][j] + w[m(v)][m(j)])` for every matched vertex; unmatched
/// vertices keep their weights. Because both maps are involutions the update pairs entries
/// and can be done in place.
pub fn symmetrize_columns(cols: &mut [f64], n: usize, vertex_mirror: &[i32], bone_mirror: &[i32]) {
    let b = bone_mirror.len();
    if cols.len() < n * b || vertex_mirror.len() < n {
        return;
    }
    for j in 0..b {
        let mj = bone_mirror[j];
        if mj < 0 || (mj as usize) < j || mj as usize >= b {
            continue;
        }
        let mj = mj as usize;
        if mj == j {
            let col = &mut cols[j * n..(j + 1) * n];
            for v in 0..n {
                let mv = vertex_mirror[v];
                if mv > v as i32 && (mv as usize) < n {
                    let avg = 0.5 * (col[v] + col[mv as usize]);
                    col[v] = avg;
                    col[mv as usize] = avg;
                }
            }
        } else {
            let (left, right) = cols.split_at_mut(mj * n);
            let cj = &mut left[j * n..(j + 1) * n];
            let cm = &mut right[..n];
            for v in 0..n {
                let mv = vertex_mirror[v];
                if mv >= 0 && (mv as usize) < n {
                    let avg = 0.5 * (cj[v] + cm[mv as usize]);
                    cj[v] = avg;
                    cm[mv as usize] = avg;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirror_and_average() {
        let p = [
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(1.0 + 1e-9, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.5, 0.0, 0.0),
        ];
        let m = mirror_map(&p, 0, 0.0, 1e-6).unwrap();
        assert_eq!(m, vec![1, 0, 2, -1]);
        assert!(mirror_map(&p, 3, 0.0, 1e-6).is_err());
        // Two points within tolerance of one's mirror image: the nearer pairs with it, the
        // other's one-sided match is dropped, so the map stays an involution.
        let crowded = [DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.0 + 6e-7, 0.0, 0.0), DVec3::new(1.0 - 3e-7, 0.0, 0.0)];
        assert_eq!(mirror_map(&crowded, 0, 0.0, 1e-6).unwrap(), vec![2, -1, 0]);
        // bones: 0 <-> 1, 2 centre.
        let bm = [1, 0, 2];
        validate_bone_mirror(&bm, 3).unwrap();
        assert!(validate_bone_mirror(&[1, 1, 2], 3).is_err());
        validate_bone_mirror(&[-1, 1, 2], 3).unwrap();
        assert!(validate_bone_mirror(&[-2, 1, 2], 3).is_err());
        let n = 4;
        let mut cols = vec![
            1.0, 0.0, 0.5, 0.3, // bone 0
            0.2, 0.8, 0.5, 0.7, // bone 1
            0.0, 0.4, 1.0, 0.0, // bone 2
        ];
        symmetrize_columns(&mut cols, n, &m, &bm);
        // v0/b0 pairs with v1/b1: (1.0 + 0.8) / 2
        assert!((cols[0] - 0.9).abs() < 1e-12 && (cols[4 + 1] - 0.9).abs() < 1e-12);
        // centre vertex 2: b0 pairs with its own b1
        assert!((cols[2] - 0.5).abs() < 1e-12 && (cols[4 + 2] - 0.5).abs() < 1e-12);
        // centre bone 2, v0 with v1
        assert!((cols[8] - 0.2).abs() < 1e-12 && (cols[9] - 0.2).abs() < 1e-12);
        // unmatched vertex 3 unchanged
        assert_eq!((cols[3], cols[7], cols[11]), (0.3, 0.7, 0.0));
        // a side bone with no partner (-1) is left as it is
        let before = cols.clone();
        symmetrize_columns(&mut cols, n, &m, &[-1, -1, 2]);
        assert_eq!(&cols[..8], &before[..8]);
    }

    #[test]
    fn points_far_from_the_origin_are_matched_without_stalling() {
        // 1e20 / (2 * 0.01) is past 2^53: a float cell coordinate stepped by 1 never moved on.
        let p = [DVec3::new(-0.5, 0.0, 1e20), DVec3::new(0.5, 0.0, 1e20), DVec3::new(0.7, 0.0, 1e20)];
        assert_eq!(mirror_map(&p, 0, 0.0, 0.01).unwrap(), vec![1, 0, -1]);
    }

    #[test]
    fn side_bones_named_without_a_side_are_paired_by_place() {
        // A spine on the plane, two arms mirrored, a lone ear off the plane, and two clavicles
        // starting on the plane (one end off it is enough), all "centre" by name.
        let heads =
            [[0.0, 0.0, 0.0], [0.2, 0.0, 1.0], [-0.2, 0.0, 1.0], [0.1, 0.0, 1.5], [0.0, 0.0, 1.2], [0.0, 0.0, 1.2]];
        let tails =
            [[0.0, 0.0, 1.5], [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0], [0.2, 0.0, 1.8], [0.3, 0.0, 1.3], [-0.3, 0.0, 1.3]];
        let (m, paired, alone) = pair_side_bones_by_place(&heads, &tails, &[0, 1, 2, 3, 4, 5], 0, 0.0).unwrap();
        assert_eq!(m, vec![0, 2, 1, -1, 5, 4]);
        assert_eq!((paired, alone), (4, 1));
        validate_bone_mirror(&m, 6).unwrap();
        // Named pairs and unpaired side bones are left as they are.
        let (m, paired, alone) = pair_side_bones_by_place(&heads, &tails, &[0, 2, 1, -1, 5, 4], 0, 0.0).unwrap();
        assert_eq!((m, paired, alone), (vec![0, 2, 1, -1, 5, 4], 0, 0));
        // Midpoints mirror images but the bones are not (one slopes down and out, the other up
        // and out): both stay unpaired.
        let heads = [[0.0, 0.0, 0.0], [0.3, 0.0, 1.2], [-0.3, 0.0, 0.8]];
        let tails = [[0.0, 0.0, 1.5], [0.7, 0.0, 0.8], [-0.7, 0.0, 1.2]];
        let (m, paired, alone) = pair_side_bones_by_place(&heads, &tails, &[0, 1, 2], 0, 0.0).unwrap();
        assert_eq!((m, paired, alone), (vec![0, -1, -1], 0, 2));
    }
}
