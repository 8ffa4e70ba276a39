//! Weight inpainting (Abdrashitov et al. 2023, section 3.2): the weights of the vertices that
//! did not match, from those that did, by a smooth interpolation over the garment.
//!
//! Inputs: welded positions `wpos` `(nw,)` and triangles `tris` `(m, 3)`; `rows` `(nw,)`, the
//! known vertices' `(bone, weight)` rows, `None` for the unknown ones (every connected piece
//! of the garment holds a known vertex, or its unknowns stay empty). Output: every vertex's
//! row, the known ones as given.
//!
//! Method: the unknown weights `W_U` of each bone minimize `tr(W^T Q W)` with the known ones
//! fixed, `Q = L + L M^-1 L` (cotangent stiffness `L`, lumped mass `M`: Dirichlet plus
//! Laplacian energy, smooth across the boundary between known and unknown), so
//! `Q_UU W_U = -Q_UK W_K`; `Q_UU` is factored once (faer's sparse Cholesky with AMD ordering,
//! retried with more regularization on a non-positive pivot) and solved for every bone the
//! known rows use. If no factor exists, each unknown vertex takes the row of its nearest known
//! vertex along the edges.

use crate::mesh::cotan::cotan_laplacian;
use crate::weights::heat::cholesky::{factor_first, symbolic_factor};
use faer::sparse::SymbolicSparseColMatRef;
use glam::DVec3;
use std::collections::VecDeque;

/// Diagonal regularizations tried in turn, relative to the diagonal.
const REGULARIZATION: [f64; 3] = [1e-12, 1e-8, 1e-4];

/// Every vertex's row (see the module doc); `regularized` is set when the first attempt to
/// factor failed.
pub(super) fn inpaint(
    wpos: &[DVec3],
    tris: &[[u32; 3]],
    rows: &[Option<Vec<(u32, f64)>>],
    regularized: &mut bool,
) -> Vec<Vec<(u32, f64)>> {
    let nw = wpos.len();
    let mut out: Vec<Vec<(u32, f64)>> = rows.iter().map(|r| r.clone().unwrap_or_default()).collect();
    let unknown: Vec<usize> = (0..nw).filter(|&v| rows[v].is_none()).collect();
    if unknown.is_empty() {
        return out;
    }
    let cot = cotan_laplacian(wpos, tris);
    // L as full rows, diagonal included.
    let mut lap: Vec<Vec<(usize, f64)>> = (0..nw).map(|v| vec![(v, 0.0)]).collect();
    for &(i, j, w) in &cot.edges {
        let (i, j) = (i as usize, j as usize);
        add(&mut lap[i], j, -w);
        add(&mut lap[j], i, -w);
        lap[i][0].1 += w;
        lap[j][0].1 += w;
    }
    // Q = L + L M^-1 L, the rows of the unknown vertices.
    let q_row = |i: usize| -> Vec<(usize, f64)> {
        let mut row = lap[i].clone();
        for &(k, lik) in &lap[i] {
            if cot.mass[k] > 0.0 {
                for &(j, lkj) in &lap[k] {
                    add(&mut row, j, lik * lkj / cot.mass[k]);
                }
            }
        }
        row
    };
    let mut slot = vec![usize::MAX; nw];
    for (s, &v) in unknown.iter().enumerate() {
        slot[v] = s;
    }
    let mut bones: Vec<u32> = rows.iter().flatten().flatten().map(|e| e.0).collect();
    bones.sort_unstable();
    bones.dedup();
    let nu = unknown.len();
    let col = |j: u32| bones.binary_search(&j).unwrap_or(0);
    // Lower triangle of Q_UU by columns, diagonal first; right-hand sides -Q_UK W_K.
    let mut col_ptr = vec![0usize; nu + 1];
    let (mut row_idx, mut values, mut diag_pos) = (Vec::new(), Vec::new(), vec![0usize; nu]);
    let mut rhs = vec![0.0f64; nu * bones.len()];
    for (s, &v) in unknown.iter().enumerate() {
        let row = q_row(v);
        col_ptr[s] = row_idx.len();
        diag_pos[s] = row_idx.len();
        row_idx.push(s);
        values.push(row.iter().find(|e| e.0 == v).map_or(0.0, |e| e.1));
        let mut lower: Vec<(usize, f64)> =
            row.iter().filter(|e| slot[e.0] != usize::MAX && slot[e.0] > s).map(|e| (slot[e.0], e.1)).collect();
        lower.sort_by_key(|e| e.0);
        for (r, x) in lower {
            row_idx.push(r);
            values.push(x);
        }
        for &(j, qij) in row.iter().filter(|e| slot[e.0] == usize::MAX) {
            for &(b, w) in rows[j].as_deref().unwrap_or_default() {
                rhs[col(b) * nu + s] -= qij * w;
            }
        }
    }
    col_ptr[nu] = row_idx.len();
    let pattern = SymbolicSparseColMatRef::new_checked(nu, nu, &col_ptr, None, &row_idx);
    let factor = symbolic_factor(pattern, None).and_then(|sym| {
        factor_first(sym, pattern, &REGULARIZATION, |r| {
            let mut vals = values.clone();
            for &d in &diag_pos {
                vals[d] *= 1.0 + r;
            }
            vals
        })
    });
    match factor {
        Some((f, attempt)) => {
            *regularized = attempt > 0;
            f.solve_columns(&mut rhs, nu);
            for (s, &v) in unknown.iter().enumerate() {
                out[v] = (0..bones.len())
                    .filter_map(|c| {
                        let x = rhs[c * nu + s];
                        (x.is_finite() && x > 0.0).then_some((bones[c], x))
                    })
                    .collect();
            }
        }
        None => {
            *regularized = true;
            nearest_known(tris, nw, &mut out, rows);
        }
    }
    out
}

/// Add `x` to entry `j` of a sparse row (appended when missing).
fn add(row: &mut Vec<(usize, f64)>, j: usize, x: f64) {
    match row.iter_mut().find(|e| e.0 == j) {
        Some(e) => e.1 += x,
        None => row.push((j, x)),
    }
}

/// The fallback: each unknown vertex takes the row of its nearest known vertex along the
/// edges (breadth-first from all known vertices at once).
fn nearest_known(tris: &[[u32; 3]], nw: usize, out: &mut [Vec<(u32, f64)>], rows: &[Option<Vec<(u32, f64)>>]) {
    let mut nbrs: Vec<Vec<u32>> = vec![Vec::new(); nw];
    for t in tris {
        for k in 0..3 {
            nbrs[t[k] as usize].push(t[(k + 1) % 3]);
            nbrs[t[(k + 1) % 3] as usize].push(t[k]);
        }
    }
    let mut from: Vec<Option<usize>> = (0..nw).map(|v| rows[v].is_some().then_some(v)).collect();
    let mut queue: VecDeque<usize> = (0..nw).filter(|&v| rows[v].is_some()).collect();
    while let Some(v) = queue.pop_front() {
        for &u in &nbrs[v] {
            if from[u as usize].is_none() {
                from[u as usize] = from[v];
                queue.push_back(u as usize);
            }
        }
    }
    for v in 0..nw {
        if rows[v].is_none() {
            if let Some(src) = from[v] {
                out[v] = out[src].clone();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strip of quads along x: the first column known on bone 0, the last on bone 1; the
    /// inpainted middle goes smoothly from one to the other, each row summing to 1.
    #[test]
    fn a_strip_blends_from_one_known_end_to_the_other() {
        let (nx, ny) = (11, 3);
        let wpos: Vec<DVec3> =
            (0..ny).flat_map(|y| (0..nx).map(move |x| DVec3::new(x as f64 * 0.1, y as f64 * 0.1, 0.0))).collect();
        let id = |x: usize, y: usize| (y * nx + x) as u32;
        let mut tris = Vec::new();
        for y in 0..ny - 1 {
            for x in 0..nx - 1 {
                tris.push([id(x, y), id(x + 1, y), id(x + 1, y + 1)]);
                tris.push([id(x, y), id(x + 1, y + 1), id(x, y + 1)]);
            }
        }
        let rows: Vec<Option<Vec<(u32, f64)>>> = (0..nx * ny)
            .map(|v| match v % nx {
                0 => Some(vec![(0, 1.0)]),
                x if x == nx - 1 => Some(vec![(1, 1.0)]),
                _ => None,
            })
            .collect();
        let mut reg = false;
        let out = inpaint(&wpos, &tris, &rows, &mut reg);
        let w1 = |v: usize| out[v].iter().find(|e| e.0 == 1).map_or(0.0, |e| e.1);
        let mut last = -1.0;
        for x in 0..nx {
            let v = nx + x;
            let sum: f64 = out[v].iter().map(|e| e.1).sum();
            assert!((sum - 1.0).abs() < 1e-6, "row {x} sums to {sum}");
            assert!(w1(v) >= last - 1e-9, "not monotone at {x}");
            last = w1(v);
        }
        assert!((w1(nx + 5) - 0.5).abs() < 0.05, "{}", w1(nx + 5));
    }
}
