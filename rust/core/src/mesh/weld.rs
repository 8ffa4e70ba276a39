//! Weld coincident vertices (split seams of glTF / flat-shaded imports) with a spatial hash grid.

use glam::DVec3;

/// Weld vertices whose positions are within `tolerance` of each other.
///
/// Inputs: `positions` `(n,)` points (any unit), `tolerance` in the same unit (`<= 0` welds
/// exact duplicates only).
/// Outputs: `(map, welded)` where `map` `(n,)` sends each input vertex to its welded index and
/// `welded` `(w,)` holds one position per welded vertex, `w <= n`.
///
/// Greedy and deterministic: vertices are visited in order; each joins an existing
/// welded vertex (deterministically chosen) whose *representative
/// position* (its first input vertex, kept unchanged) lies within `tolerance`, otherwise it
/// starts a new one. Uniform grid with cell size `4 * tolerance` hashed into an open table, so
/// the cost is O(n) expected.
///
/// No chaining: a vertex within `tolerance` of a welded vertex's other members but not of its
/// representative starts a new one. Representatives lie more than `tolerance` apart, so a vertex
/// can lie within `tolerance` of two; which one it joins is then fixed by the grid, not always
/// the first. A non-finite position never welds (it starts a welded vertex of its own).
pub fn weld(positions: &[DVec3], tolerance: f64) -> (Vec<u32>, Vec<DVec3>) {
    let n = positions.len();
    let tol = if tolerance.is_finite() && tolerance > 0.0 { tolerance } else { 0.0 };
    let tol2 = tol * tol;
    let cell = (4.0 * tol).max(1e-12);
    let inv = 1.0 / cell;
    let bits = (usize::BITS - (2 * n.max(8)).leading_zeros()).min(40);
    let mask = (1u64 << bits) - 1;
    let mut head = vec![u32::MAX; 1usize << bits];
    let mut next: Vec<u32> = Vec::with_capacity(n / 2 + 1);
    let mut welded: Vec<DVec3> = Vec::with_capacity(n / 2 + 1);
    let mut map = Vec::with_capacity(n);

    #[inline]
    fn bucket(c: [i64; 3], mask: u64) -> usize {
        let h = (c[0] as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (c[1] as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ (c[2] as u64).wrapping_mul(0x1656_67B1_9E37_79F9);
        ((h ^ (h >> 29)) & mask) as usize
    }

    for p in positions {
        // Range of cells the tolerance ball can touch, per axis (1 or 2 cells).
        let lo = ((*p - DVec3::splat(tol)) * inv).floor();
        let hi = ((*p + DVec3::splat(tol)) * inv).floor();
        let (lo, hi) = ([lo.x as i64, lo.y as i64, lo.z as i64], [hi.x as i64, hi.y as i64, hi.z as i64]);
        let mut found = u32::MAX;
        'search: for cx in lo[0]..=hi[0] {
            for cy in lo[1]..=hi[1] {
                for cz in lo[2]..=hi[2] {
                    let mut w = head[bucket([cx, cy, cz], mask)];
                    while w != u32::MAX {
                        if (welded[w as usize] - *p).length_squared() <= tol2 {
                            found = found.min(w);
                            break;
                        }
                        w = next[w as usize];
                    }
                    if found != u32::MAX && lo == hi {
                        break 'search;
                    }
                }
            }
        }
        if found == u32::MAX {
            found = welded.len() as u32;
            let c = (*p * inv).floor();
            let b = bucket([c.x as i64, c.y as i64, c.z as i64], mask);
            welded.push(*p);
            next.push(head[b]);
            head[b] = found;
        }
        map.push(found);
    }
    (map, welded)
}

/// [`weld`] of plain `[x, y, z]` points (the Python binding's `weld_points`): the same `map`,
/// and the welded points as arrays.
pub fn weld_points(points: &[[f64; 3]], tolerance: f64) -> (Vec<u32>, Vec<[f64; 3]>) {
    let positions: Vec<DVec3> = points.iter().map(|&p| DVec3::from_array(p)).collect();
    let (map, welded) = weld(&positions, tolerance);
    (map, welded.iter().map(|w| w.to_array()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welds_duplicates_and_near_points_only() {
        let p = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0 + 1e-7, 0.0, 0.0),
            DVec3::new(0.5, 0.0, 0.0),
        ];
        let (map, w) = weld(&p, 1e-5);
        assert_eq!(map, vec![0, 1, 0, 1, 2]);
        assert_eq!(w.len(), 3);
        let (map, w) = weld(&p, 0.0);
        assert_eq!(map, vec![0, 1, 0, 2, 3]);
        assert_eq!(w.len(), 4);
    }
}
