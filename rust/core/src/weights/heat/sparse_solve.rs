//! Solves of many sparse right-hand sides against one supernodal Cholesky factor, skipping in
//! the forward pass the columns that are still zero.
//!
//! Inputs
//!   symbolic  faer's supernodal structure of `L` (`P A P^T = L L^T`), supernodes in
//!             postorder (every supernode before its parent)
//!   values    its numerical values
//!   perm      `(n,)` faer's forward permutation `P` (`perm[k]` = the row eliminated `k`-th),
//!             or `None` for the identity
//!   x         `(n, k)` column-major right-hand sides `B`, overwritten with `X = A^-1 B`
//!
//! Method: `X = P^T L^-T L^-1 P B`, supernode by supernode as faer's own solve (a triangular
//! solve on the diagonal block and a product with the rows below it, BLAS-3 in the columns),
//! except that the forward pass `L y = P b` works on the columns that hold a non-zero in the
//! supernode's rows and skips the others, whose `y` there is exactly zero: a bone's right-hand
//! side is non-zero only where it is its vertices' heat source, and `y` is non-zero only at
//! the ancestors of those rows in the elimination tree (Gilbert & Peierls 1988). With a nested
//! dissection order that is one path of regions from a leaf to the root, so the forward pass
//! costs a fraction of the backward pass, which stays dense. `P` is applied column by column
//! in place (one column of scratch, not a copy of the block).
//!
//! The result equals faer's `LltRef::solve_in_place_with_conj` (the test checks it to 1e-12;
//! on the meshes measured it is the same bit for bit), without faer's permuted copy of the
//! whole block.
//!
//! Paper: Gilbert & Peierls 1988, "Sparse partial pivoting in time proportional to arithmetic
//! operations" (the reach of a sparse right-hand side). Known limits: the backward pass is dense
//! in every column; a column with a non-zero in a supernode is solved there in full.

use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{solve_lower_triangular_in_place, solve_upper_triangular_in_place};
use faer::reborrow::ReborrowMut;
use faer::sparse::linalg::cholesky::supernodal::{SupernodalLltRef, SymbolicSupernodalCholesky};
use faer::{Accum, MatMut, MatRef, Par};

/// `x <- A^-1 x` for the column-major `(n, k)` block `x` (see the module doc).
pub(crate) fn solve_sparse_columns(
    symbolic: &SymbolicSupernodalCholesky<usize>,
    values: &[f64],
    perm: Option<&[usize]>,
    x: &mut [f64],
    n: usize,
) {
    let k = x.len() / n.max(1);
    if k == 0 || n == 0 {
        return;
    }
    if let Some(p) = perm {
        gather_rows(x, n, p);
    }
    let llt = SupernodalLltRef::new(symbolic, values);
    let (mut gathered, mut below, mut live) = (Vec::new(), Vec::new(), Vec::with_capacity(k));
    for s in 0..symbolic.n_supernodes() {
        let node = llt.supernode(s);
        let (start, pattern, ls) = (node.start(), node.pattern(), node.val());
        let (c, r) = (ls.ncols(), pattern.len());
        live.clear();
        live.extend((0..k).filter(|&j| x[j * n + start..j * n + start + c].iter().any(|&v| v != 0.0)));
        if live.is_empty() {
            continue;
        }
        let (top, bot) = ls.split_at_row(c);
        let l = live.len();
        gathered.clear();
        for &j in &live {
            gathered.extend_from_slice(&x[j * n + start..j * n + start + c]);
        }
        let mut g = MatMut::from_column_major_slice_mut(&mut gathered, c, l);
        solve_lower_triangular_in_place(top, g.rb_mut(), Par::Seq);
        for (i, &j) in live.iter().enumerate() {
            x[j * n + start..j * n + start + c].copy_from_slice(&gathered[i * c..(i + 1) * c]);
        }
        if r > 0 {
            below.clear();
            below.resize(r * l, 0.0);
            let g = MatRef::from_column_major_slice(&gathered, c, l);
            matmul(MatMut::from_column_major_slice_mut(&mut below, r, l), Accum::Replace, bot, g, 1.0, Par::Seq);
            for (i, &j) in live.iter().enumerate() {
                let col = &mut x[j * n..(j + 1) * n];
                for (&row, &v) in pattern.iter().zip(&below[i * r..(i + 1) * r]) {
                    col[row] -= v;
                }
            }
        }
    }
    for s in (0..symbolic.n_supernodes()).rev() {
        let node = llt.supernode(s);
        let (start, pattern, ls) = (node.start(), node.pattern(), node.val());
        let (c, r) = (ls.ncols(), pattern.len());
        let (top, bot) = ls.split_at_row(c);
        if r > 0 {
            below.clear();
            for j in 0..k {
                let col = &x[j * n..(j + 1) * n];
                below.extend(pattern.iter().map(|&row| col[row]));
            }
        }
        let mut x_top = MatMut::from_column_major_slice_with_stride_mut(&mut x[start..], c, k, n);
        if r > 0 {
            let b = MatRef::from_column_major_slice(&below, r, k);
            matmul(x_top.rb_mut(), Accum::Add, bot.transpose(), b, -1.0, Par::Seq);
        }
        solve_upper_triangular_in_place(top.transpose(), x_top, Par::Seq);
    }
    if let Some(p) = perm {
        scatter_rows(x, n, p);
    }
}

/// Each `n`-row column of `cols` gathered through `from`: row `r` takes row `from[r]`.
fn gather_rows(cols: &mut [f64], n: usize, from: &[usize]) {
    let mut column = vec![0.0f64; n];
    for col in cols.chunks_exact_mut(n) {
        column.copy_from_slice(col);
        col.iter_mut().zip(from).for_each(|(y, &f)| *y = column[f]);
    }
}

/// Each `n`-row column of `cols` scattered through `to`: row `r` moves to row `to[r]`.
pub(crate) fn scatter_rows(cols: &mut [f64], n: usize, to: &[usize]) {
    let mut column = vec![0.0f64; n];
    for col in cols.chunks_exact_mut(n) {
        column.copy_from_slice(col);
        to.iter().zip(&column).for_each(|(&t, &y)| col[t] = y);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::cotan::{cotan_laplacian, stiffness_lower_csc};
    use crate::primitives::capped_cylinder;
    use crate::weights::heat::dissection::nested_dissection;
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::perm::PermRef;
    use faer::sparse::linalg::cholesky::{
        factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholeskyRaw, SymmetricOrdering,
    };
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
    use faer::{Conj, Side};
    use glam::DVec3;

    /// On a cylinder's `L + I`, supernodal and ordered by AMD or by nested dissection: columns
    /// that are zero, hold one non-zero, or are dense solve as faer's own solve does, and the
    /// zero column stays zero.
    #[test]
    fn sparse_columns_solve_as_faer_does() {
        let (v, t) = capped_cylinder(0.5, 4.0, 40, 24);
        let pos: Vec<DVec3> = v.iter().map(|p| DVec3::from(p.map(|c| c as f64))).collect();
        let n = pos.len();
        let csc = stiffness_lower_csc(n, &cotan_laplacian(&pos, &t).edges);
        let mut values = csc.values.clone();
        csc.diag_pos.iter().for_each(|&d| values[d] += 1.0);
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &csc.col_ptr, None, &csc.row_idx);
        let a = SparseColMatRef::new(pattern, &values);
        let forward = nested_dissection(&csc.col_ptr, &csc.row_idx, &pos);
        let mut inverse = vec![0usize; n];
        forward.iter().enumerate().for_each(|(k, &v)| inverse[v] = k);
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let orders = [SymmetricOrdering::Amd, SymmetricOrdering::Custom(PermRef::new_checked(&forward, &inverse, n))];
        for ordering in orders {
            let symbolic = factorize_symbolic_cholesky(pattern, Side::Lower, ordering, params).unwrap();
            let mut l = vec![0.0; symbolic.len_val()];
            let par = Par::Seq;
            let mut buf = MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()));
            let regularization = Default::default();
            let stack = MemStack::new(&mut buf);
            symbolic
                .factorize_numeric_llt(&mut l, a, Side::Lower, regularization, par, stack, Default::default())
                .unwrap();
            let k = 4;
            let mut b = vec![0.0; n * k];
            b[n + n / 3] = 2.0;
            b[2 * n + 7] = -1.0;
            b[3 * n..].iter_mut().enumerate().for_each(|(i, x)| *x = (i % 5) as f64 - 2.0);
            let mut want = b.clone();
            let mut buf = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(k, par));
            let mat = MatMut::from_column_major_slice_mut(&mut want, n, k);
            LltRef::new(&symbolic, &l).solve_in_place_with_conj(Conj::No, mat, par, MemStack::new(&mut buf));
            let SymbolicCholeskyRaw::Supernodal(supernodal) = symbolic.raw() else { panic!("forced supernodal") };
            let perm = symbolic.perm().map(|p| p.arrays().0);
            solve_sparse_columns(supernodal, &l, perm, &mut b, n);
            assert!(b[..n].iter().all(|&x| x == 0.0));
            for (got, want) in b.iter().zip(&want) {
                assert!((got - want).abs() <= 1e-12 * want.abs().max(1.0), "{got} against {want}");
            }
        }
    }
}
