//! Cotangent Laplacian (stiffness) and lumped mass matrix of a triangle mesh.
//!
//! Pinkall & Polthier 1993 / Meyer et al. 2003: for a piecewise-linear function `u`,
//! `u^T L u = sum_edges w_ij (u_i - u_j)^2` with `w_ij = (cot alpha_ij + cot beta_ij) / 2`,
//! the angles opposite the edge in its (one or two) triangles. `L` is symmetric positive
//! semidefinite with the constants per connected component as its null space.
//! The lumped ("barycentric") mass gives each vertex a third of the area of its triangles.

use glam::DVec3;
use rayon::prelude::*;

/// Largest cotangent magnitude kept. A sliver triangle whose largest |cot| exceeds this has all
/// three of its cotangents scaled by the same factor, which keeps its 3x3 stiffness block
/// positive semidefinite (clamping each cotangent independently would not).
pub const COT_CLAMP: f64 = 1e4;

/// A triangle is degenerate (skipped) when twice its area is below this fraction of its
/// longest squared edge, or when it repeats a vertex.
pub const DEGENERATE_RATIO: f64 = 1e-12;

/// Off-diagonal cotangent weights and lumped mass.
#[derive(Debug, Clone, Default)]
pub struct CotanLaplacian {
    /// One entry `(i, j, w)` with `i < j` per edge *per triangle* (not summed): the full
    /// stiffness is `L = sum w (e_i - e_j)(e_i - e_j)^T`, so `L_ij = -sum w`, `L_ii = sum_j -L_ij`.
    pub edges: Vec<(u32, u32, f64)>,
    /// `(n,)` lumped mass: a third of the area of every non-degenerate incident triangle
    /// (squared input length unit). Zero for vertices in no usable triangle.
    pub mass: Vec<f64>,
    /// Number of triangles skipped as degenerate (zero area, repeated index, out of range).
    pub skipped: usize,
}

/// Twice the area and the clamped cotangents of the angles at `a`, `b`, `c` (in that order),
/// or `None` if the triangle is degenerate (see [`DEGENERATE_RATIO`]).
#[inline]
pub fn triangle_cotangents(a: DVec3, b: DVec3, c: DVec3) -> Option<(f64, [f64; 3])> {
    let (ab, ac, bc) = (b - a, c - a, c - b);
    let twice_area = ab.cross(ac).length();
    let longest = ab.length_squared().max(ac.length_squared()).max(bc.length_squared());
    if !(twice_area > DEGENERATE_RATIO * longest) || !(twice_area > f64::MIN_POSITIVE) {
        return None;
    }
    let mut cot = [ab.dot(ac) / twice_area, (-ab).dot(bc) / twice_area, (-ac).dot(-bc) / twice_area];
    let big = cot.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if big > COT_CLAMP {
        let s = COT_CLAMP / big;
        cot.iter_mut().for_each(|c| *c *= s);
    }
    Some((twice_area, cot))
}

/// Cotangent weights and lumped mass of a triangle mesh.
///
/// Inputs: `positions` `(n,)`, `triangles` `(m, 3)`. Degenerate triangles (zero area,
/// repeated vertex, index out of range) are skipped and counted; duplicate faces simply
/// contribute twice (consistently to stiffness and mass). Output: see [`CotanLaplacian`].
pub fn cotan_laplacian(positions: &[DVec3], triangles: &[[u32; 3]]) -> CotanLaplacian {
    let n = positions.len();
    let per_tri: Vec<Option<(f64, [f64; 3])>> = triangles
        .par_iter()
        .with_min_len(2048)
        .map(|t| {
            if t.iter().any(|&i| i as usize >= n) || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return None;
            }
            triangle_cotangents(positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize])
        })
        .collect();
    let mut mass = vec![0.0f64; n];
    let mut edges = Vec::with_capacity(3 * triangles.len());
    let mut skipped = 0usize;
    for (t, r) in triangles.iter().zip(&per_tri) {
        let Some((twice_area, cot)) = r else {
            skipped += 1;
            continue;
        };
        let third = twice_area / 6.0;
        for k in 0..3 {
            mass[t[k] as usize] += third;
            // Edge opposite corner k joins the other two corners.
            let (i, j) = (t[(k + 1) % 3], t[(k + 2) % 3]);
            edges.push((i.min(j), i.max(j), 0.5 * cot[k]));
        }
    }
    CotanLaplacian { edges, mass, skipped }
}

/// Lower triangle (diagonal included) of a symmetric `n x n` sparse matrix in compressed
/// sparse column form, diagonal entry first in every column, rows sorted.
#[derive(Debug, Clone)]
pub struct LowerCsc {
    /// Matrix size.
    pub n: usize,
    /// `(n + 1,)` column starts.
    pub col_ptr: Vec<usize>,
    /// `(nnz,)` row indices.
    pub row_idx: Vec<usize>,
    /// `(nnz,)` values.
    pub values: Vec<f64>,
    /// `(n,)` position of the diagonal entry of each column in `values` (= `col_ptr[j]`).
    pub diag_pos: Vec<usize>,
}

/// Assemble the stiffness matrix `L` of [`CotanLaplacian::edges`] as a [`LowerCsc`].
///
/// `L_ij = -sum w` over the entries of edge `{i, j}`, `L_ii = sum_j sum w`. Every column has an
/// explicit diagonal (possibly 0). O(E log E) with a parallel sort.
pub fn stiffness_lower_csc(n: usize, edges: &[(u32, u32, f64)]) -> LowerCsc {
    let mut keyed: Vec<(u64, f64)> =
        edges.par_iter().with_min_len(4096).map(|&(i, j, w)| (((i as u64) << 32) | j as u64, w)).collect();
    keyed.par_sort_unstable_by_key(|e| e.0);

    let mut diag = vec![0.0f64; n];
    for &(key, w) in &keyed {
        diag[(key >> 32) as usize] += w;
        diag[(key & 0xFFFF_FFFF) as usize] += w;
    }
    // Unique off-diagonals per column (column = smaller index, row = larger).
    let mut col_ptr = vec![0usize; n + 1];
    let mut row_idx = Vec::with_capacity(n + keyed.len() / 2);
    let mut values = Vec::with_capacity(n + keyed.len() / 2);
    let mut diag_pos = vec![0usize; n];
    let mut k = 0usize;
    for col in 0..n {
        col_ptr[col] = row_idx.len();
        diag_pos[col] = row_idx.len();
        row_idx.push(col);
        values.push(diag[col]);
        while k < keyed.len() && (keyed[k].0 >> 32) as usize == col {
            let key = keyed[k].0;
            let mut w = 0.0;
            while k < keyed.len() && keyed[k].0 == key {
                w += keyed[k].1;
                k += 1;
            }
            row_idx.push((key & 0xFFFF_FFFF) as usize);
            values.push(-w);
        }
    }
    col_ptr[n] = row_idx.len();
    LowerCsc { n, col_ptr, row_idx, values, diag_pos }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regular tetrahedron surface: every cotangent is cot 60deg.
    #[test]
    fn tetrahedron_weights_mass_and_null_space() {
        let p = [
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, -1.0, -1.0),
            DVec3::new(-1.0, 1.0, -1.0),
            DVec3::new(-1.0, -1.0, 1.0),
        ];
        let t = [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2], [1, 1, 2]];
        let c = cotan_laplacian(&p, &t);
        assert_eq!(c.skipped, 1);
        assert_eq!(c.edges.len(), 12);
        let cot60 = 1.0 / 3f64.sqrt();
        let area = 3f64.sqrt() / 4.0 * 8.0; // side sqrt(8)
        for m in &c.mass {
            assert!((m - area).abs() < 1e-12, "mass {m}"); // 3 triangles * area / 3
        }
        let csc = stiffness_lower_csc(4, &c.edges);
        for col in 0..4 {
            let (s, e) = (csc.col_ptr[col], csc.col_ptr[col + 1]);
            assert_eq!(csc.row_idx[s], col);
            assert!((csc.values[s] - 3.0 * cot60).abs() < 1e-12);
            for k in s + 1..e {
                assert!((csc.values[k] + cot60).abs() < 1e-12);
            }
        }
        assert_eq!(csc.col_ptr[4], 4 + 6);
    }

    /// Linear precision: on a flat mesh, `L u = 0` at every interior vertex for any linear `u`
    /// (each cotangent weight in its place and with its sign), on a jittered grid with obtuse
    /// angles, where a cotangent's sign matters.
    #[test]
    fn flat_mesh_linear_functions_are_harmonic_inside() {
        let k = 6usize;
        let mut seed = 12345u64;
        let mut jitter = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.7
        };
        let inside = |i: usize, j: usize| i > 0 && j > 0 && i < k - 1 && j < k - 1;
        let mut p = Vec::new();
        for j in 0..k {
            for i in 0..k {
                let (dx, dy) = if inside(i, j) { (jitter(), jitter()) } else { (0.0, 0.0) };
                p.push(DVec3::new(i as f64 + dx, j as f64 + dy, 0.0));
            }
        }
        let mut t = Vec::new();
        for j in 0..k - 1 {
            for i in 0..k - 1 {
                let a = (j * k + i) as u32;
                let (b, c, d) = (a + 1, a + k as u32 + 1, a + k as u32);
                // Alternate the diagonals so that corners of every kind are obtuse somewhere.
                if (i + j) % 2 == 0 {
                    t.extend([[a, b, c], [a, c, d]]);
                } else {
                    t.extend([[a, b, d], [b, c, d]]);
                }
            }
        }
        let obtuse = t.iter().filter_map(|x| triangle_cotangents(p[x[0] as usize], p[x[1] as usize], p[x[2] as usize]));
        let obtuse: Vec<[bool; 3]> = obtuse.map(|(_, c)| c.map(|c| c < 0.0)).collect();
        for corner in 0..3 {
            assert!(obtuse.iter().any(|o| o[corner]), "no obtuse angle at corner {corner}");
        }
        let c = cotan_laplacian(&p, &t);
        assert_eq!(c.skipped, 0);
        let csc = stiffness_lower_csc(p.len(), &c.edges);
        for f in [|q: DVec3| q.x, |q: DVec3| q.y, |q: DVec3| 2.0 * q.x - 3.0 * q.y + 1.0] {
            let u: Vec<f64> = p.iter().map(|&q| f(q)).collect();
            let mut lu = vec![0.0; p.len()];
            for col in 0..csc.n {
                for e in csc.col_ptr[col]..csc.col_ptr[col + 1] {
                    let (row, v) = (csc.row_idx[e], csc.values[e]);
                    lu[row] += v * u[col];
                    if row != col {
                        lu[col] += v * u[row];
                    }
                }
            }
            for (v, r) in lu.iter().enumerate() {
                if inside(v % k, v / k) {
                    assert!(r.abs() < 1e-12, "(L u) at interior vertex {v} is {r}");
                }
            }
        }
    }

    #[test]
    fn sliver_is_clamped_not_indefinite() {
        let (_, cot) = triangle_cotangents(DVec3::ZERO, DVec3::X, DVec3::new(0.5, 1e-7, 0.0)).unwrap();
        assert!(cot.iter().all(|c| c.abs() <= COT_CLAMP * (1.0 + 1e-12)));
        assert!(cot[0] * cot[1] + cot[1] * cot[2] + cot[2] * cot[0] >= 0.0);
        assert!(triangle_cotangents(DVec3::ZERO, DVec3::X, DVec3::X * 2.0).is_none());
        // Degenerate below DEGENERATE_RATIO of the longest squared edge, at any scale.
        for s in [1e-6, 1.0, 1e6] {
            let thin = |h: f64| triangle_cotangents(DVec3::ZERO, DVec3::X * s, DVec3::new(0.5, h, 0.0) * s);
            assert!(thin(1e-13).is_none() && thin(1e-11).is_some(), "scale {s}");
        }
    }
}
