//! Left/right symmetry of points: the mirror plane, the image of a point, and which points are
//! each other's images.

use crate::{Error, Result};
use glam::DVec3;

/// Left/right symmetry across the plane `x[axis] = plane`, with the mirror partner of each
/// element (a bone for weights, a joint for fitting).
#[derive(Debug, Clone, PartialEq)]
pub struct Symmetry {
    /// Mirror axis: 0 = X, 1 = Y, 2 = Z.
    pub axis: usize,
    /// Coordinate of the mirror plane along `axis`, in input units.
    pub plane: f64,
    /// `(k,)`: the mirror partner of each element, itself for an element on the centre line,
    /// -1 for a side element with no partner (left on its own). See the algorithm taking it for
    /// what else it checks.
    pub mirror: Vec<i32>,
}

/// Mirror `p` across the plane `x[axis] = plane`.
#[inline]
pub fn mirror_point(p: DVec3, axis: usize, plane: f64) -> DVec3 {
    let mut q = p;
    q[axis] = 2.0 * plane - p[axis];
    q
}

/// Vertex mirror map.
///
/// Inputs: `points` `(n,)`, `axis` 0/1/2 (X/Y/Z), `plane` the coordinate of the mirror plane
/// along `axis`, `tolerance` (same unit) for matching a mirrored position.
/// Output `(n,)`: `m[v]` = the point nearest to the mirror image of `v` if it lies within
/// `tolerance`, else `-1`; made an involution (`m[m[v]] == v`; one-sided matches are dropped
/// to `-1`). Points on the plane map to themselves. Hash grid with cell `2 tolerance`:
/// O(n) expected. Errors: `axis > 2`.
pub fn mirror_map(points: &[DVec3], axis: usize, plane: f64, tolerance: f64) -> Result<Vec<i32>> {
    if axis > 2 {
        return Err(Error::InvalidArgument(format!("symmetry axis must be 0, 1 or 2, got {axis}")));
    }
    let tol = if tolerance.is_finite() && tolerance > 0.0 { tolerance } else { 0.0 };
    let cell = (2.0 * tol).max(1e-12);
    let inv = 1.0 / cell;
    let n = points.len();
    let bits = (usize::BITS - (2 * n.max(8)).leading_zeros()).min(40);
    let mask = (1u64 << bits) - 1;
    // Integer cell coordinates (saturating for far points): stepping a float cell coordinate by 1
    // stalls past 2^53, where a bone far from the origin next to a small tolerance put it.
    let cell_of = |p: DVec3| -> [i64; 3] { ((p * inv).floor()).to_array().map(|c| c as i64) };
    let key = |c: [i64; 3]| -> usize {
        let h = (c[0] as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (c[1] as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ (c[2] as u64).wrapping_mul(0x1656_67B1_9E37_79F9);
        ((h ^ (h >> 29)) & mask) as usize
    };
    let mut head = vec![u32::MAX; 1usize << bits];
    let mut next = vec![u32::MAX; n];
    for (i, p) in points.iter().enumerate() {
        let k = key(cell_of(*p));
        next[i] = head[k];
        head[k] = i as u32;
    }
    let tol2 = tol * tol;
    let mut map: Vec<i32> = points
        .iter()
        .map(|p| {
            let q = mirror_point(*p, axis, plane);
            let lo = cell_of(q - DVec3::splat(tol));
            let hi = cell_of(q + DVec3::splat(tol));
            let mut best = (f64::INFINITY, -1i32);
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        let mut i = head[key([x, y, z])];
                        while i != u32::MAX {
                            let d2 = (points[i as usize] - q).length_squared();
                            if d2 <= tol2 && (d2 < best.0 || (d2 == best.0 && (i as i32) < best.1)) {
                                best = (d2, i as i32);
                            }
                            i = next[i as usize];
                        }
                    }
                }
            }
            best.1
        })
        .collect();
    let snapshot = map.clone();
    for (v, m) in map.iter_mut().enumerate() {
        if *m >= 0 && snapshot[*m as usize] != v as i32 {
            *m = -1;
        }
    }
    Ok(map)
}
