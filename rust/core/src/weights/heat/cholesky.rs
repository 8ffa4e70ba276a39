//! Sparse Cholesky factorization of the heat system with faer: symbolic analysis (a given
//! nested dissection order or AMD, elimination tree, supernodes) once, numeric `A = L L^T`
//! retried with more diagonal regularization when a pivot is not positive, and solves of many
//! right-hand sides against the one factor, split across the rayon pool (a supernodal factor's
//! by [`solve_sparse_columns`], whose forward pass skips the columns that are still zero).

use super::memory::zeroed;
use super::sparse_solve::{scatter_rows, solve_sparse_columns};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use rayon::prelude::*;

/// A numeric Cholesky factor `A = L L^T` (faer, supernodal or simplicial, AMD ordering).
pub(crate) struct Factor {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
}

impl Factor {
    /// The elimination order `P` as (forward, inverse): `forward[k]` is the row eliminated
    /// `k`-th, `inverse[v]` the place of row `v`; `None` for the identity.
    pub(crate) fn order(&self) -> Option<(&[usize], &[usize])> {
        self.symbolic.perm().map(|p| p.arrays())
    }

    /// Solve `A X = B` in place for the column-major `(n, k)` block `cols`, columns split
    /// across the rayon pool (each worker solves sequentially: many cheap supernodes make
    /// fine-grained parallelism inside one solve a loss): a supernodal factor by
    /// [`solve_sparse_columns`] (in place, no copy of the block), a simplicial one (small
    /// matrices) by faer's own solve.
    pub(crate) fn solve_columns(&self, cols: &mut [f64], n: usize) {
        self.solve(cols, n, false);
    }

    /// [`Factor::solve_columns`] for a block whose rows are already in elimination order
    /// ([`Factor::order`]): `P A P^T Y = P B`, `Y = P X`. A caller that builds its right-hand
    /// sides and reads its solutions in that order skips two gathers through `P` a column.
    pub(crate) fn solve_ordered_columns(&self, cols: &mut [f64], n: usize) {
        self.solve(cols, n, true);
    }

    fn solve(&self, cols: &mut [f64], n: usize, ordered: bool) {
        let k = cols.len() / n.max(1);
        if k == 0 {
            return;
        }
        let threads = rayon::current_num_threads().max(1);
        let per = k.div_ceil(threads).max(1);
        let order = self.order();
        cols.par_chunks_mut(per * n).for_each(|chunk| {
            if let SymbolicCholeskyRaw::Supernodal(supernodal) = self.symbolic.raw() {
                let perm = if ordered { None } else { order.map(|(fwd, _)| fwd) };
                solve_sparse_columns(supernodal, &self.values, perm, chunk, n);
                return;
            }
            let kc = chunk.len() / n;
            let llt = LltRef::<usize, f64>::new(&self.symbolic, &self.values);
            let req = self.symbolic.solve_in_place_scratch::<f64>(kc, Par::Seq);
            let Ok(mut buf) = MemBuffer::try_new(req) else {
                // Out of memory for scratch: NaN is clipped to 0 and those vertices fall back
                // to their nearest bone (never a crash).
                chunk.fill(f64::NAN);
                return;
            };
            // faer's simplicial solve applies `P` itself: back to the rows' own order first.
            let (fwd, inv) = order.filter(|_| ordered).unzip();
            if let Some(fwd) = fwd {
                scatter_rows(chunk, n, fwd);
            }
            llt.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(chunk, n, kc),
                Par::Seq,
                MemStack::new(&mut buf),
            );
            if let Some(inv) = inv {
                scatter_rows(chunk, n, inv);
            }
        });
    }
}

/// Symbolic analysis (AMD ordering, elimination tree, supernodes) of the lower pattern.
pub(crate) fn symbolic_factor(
    a: SymbolicSparseColMatRef<'_, usize>,
    order: Option<&[usize]>,
) -> Option<SymbolicCholesky<usize>> {
    let Some(fwd) = order else {
        return factorize_symbolic_cholesky(a, Side::Lower, SymmetricOrdering::Amd, Default::default()).ok();
    };
    let mut inv = vec![0usize; fwd.len()];
    fwd.iter().enumerate().for_each(|(k, &v)| inv[v] = k);
    let perm = PermRef::new_checked(fwd, &inv, fwd.len());
    factorize_symbolic_cholesky(a, Side::Lower, SymmetricOrdering::Custom(perm), Default::default()).ok()
}

/// Numeric factor of the matrix with lower pattern `pattern` (analysed as `symbolic`) and the
/// values `values(r)`, for each regularization `r` of `regularizations` in turn until one
/// factors: that factor and the index of its `r`, or `None` when every attempt fails (a
/// non-positive pivot, or out of memory).
pub(crate) fn factor_first(
    symbolic: SymbolicCholesky<usize>,
    pattern: SymbolicSparseColMatRef<'_, usize>,
    regularizations: &[f64],
    values: impl Fn(f64) -> Vec<f64>,
) -> Option<(Factor, usize)> {
    let mut symbolic = symbolic;
    for (attempt, &r) in regularizations.iter().enumerate() {
        let vals = values(r);
        match numeric_factor(symbolic, SparseColMatRef::new(pattern, &vals)) {
            Ok(f) => return Some((f, attempt)),
            Err(s) => symbolic = s,
        }
    }
    None
}

/// Numeric factorization; `None` on a non-positive pivot or allocation failure.
// The Err hands the symbolic factorization back for a retry; boxing it would allocate on the
// out-of-memory path (and `Factor`, the Ok side, is as large anyway).
#[allow(clippy::result_large_err)]
fn numeric_factor(
    symbolic: SymbolicCholesky<usize>,
    a: SparseColMatRef<'_, usize, f64>,
) -> std::result::Result<Factor, SymbolicCholesky<usize>> {
    let par = Par::rayon(0);
    let Some(mut values) = zeroed(symbolic.len_val()) else { return Err(symbolic) };
    let req = symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default());
    let Ok(mut buf) = MemBuffer::try_new(req) else { return Err(symbolic) };
    let ok = symbolic
        .factorize_numeric_llt::<f64>(
            &mut values,
            a,
            Side::Lower,
            LltRegularization { dynamic_regularization_delta: 0.0, dynamic_regularization_epsilon: 0.0 },
            par,
            MemStack::new(&mut buf),
            Default::default(),
        )
        .is_ok();
    if ok {
        Ok(Factor { symbolic, values })
    } else {
        Err(symbolic)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lower pattern of a full symmetric 3 x 3 matrix, column by column (diagonal first).
    const COL_PTR: [usize; 4] = [0, 3, 5, 6];
    const ROW_IDX: [usize; 6] = [0, 1, 2, 1, 2, 2];

    /// [[d, 2, 0], [2, d, 1], [0, 1, d]] as lower values in the order of `ROW_IDX`.
    fn values(d: f64) -> Vec<f64> {
        vec![d, 2.0, 0.0, d, 1.0, d]
    }

    #[test]
    fn retries_with_more_regularization_until_a_factor_exists_then_solves() {
        let pattern = SymbolicSparseColMatRef::new_checked(3, 3, &COL_PTR, None, &ROW_IDX);
        // d = 1 is indefinite, d = 2 singular (second pivot 2 - 2 * 2 / 2 = 0), d = 4 positive definite.
        let regs = [1.0, 2.0, 4.0];
        let symbolic = symbolic_factor(pattern, None).unwrap();
        let (factor, attempt) = factor_first(symbolic, pattern, &regs, values).expect("the third one factors");
        assert_eq!(attempt, 2);
        // Two right-hand sides of known solutions x1 = (1, 2, 3) and x2 = (-1, 0, 0.5) for d = 4.
        let a = [[4.0, 2.0, 0.0], [2.0, 4.0, 1.0], [0.0, 1.0, 4.0]];
        let xs = [[1.0, 2.0, 3.0], [-1.0, 0.0, 0.5]];
        let mut cols: Vec<f64> =
            xs.iter().flat_map(|x| (0..3).map(move |i| (0..3).map(|j| a[i][j] * x[j]).sum::<f64>())).collect();
        factor.solve_columns(&mut cols, 3);
        for (got, want) in cols.iter().zip(xs.iter().flatten()) {
            assert!((got - want).abs() < 1e-12, "{cols:?}");
        }
    }

    /// In elimination order or not, a cylinder's `L + I` (small: faer factors it simplicial;
    /// larger: supernodal) solves to the same columns, moved through the order.
    #[test]
    fn ordered_columns_solve_as_the_vertex_ordered_ones() {
        use crate::mesh::cotan::{cotan_laplacian, stiffness_lower_csc};
        use crate::primitives::capped_cylinder;
        use glam::DVec3;
        for (rings, segments) in [(6, 8), (200, 200)] {
            let (v, t) = capped_cylinder(0.5, 4.0, rings, segments);
            let pos: Vec<DVec3> = v.iter().map(|p| DVec3::from(p.map(|c| c as f64))).collect();
            let n = pos.len();
            let csc = stiffness_lower_csc(n, &cotan_laplacian(&pos, &t).edges);
            let pattern = SymbolicSparseColMatRef::new_checked(n, n, &csc.col_ptr, None, &csc.row_idx);
            let symbolic = symbolic_factor(pattern, None).unwrap();
            let with_identity = |_: f64| {
                let mut values = csc.values.clone();
                csc.diag_pos.iter().for_each(|&d| values[d] += 1.0);
                values
            };
            let (factor, _) = factor_first(symbolic, pattern, &[0.0], with_identity).unwrap();
            let supernodal = matches!(factor.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_));
            assert_eq!(supernodal, rings > 6, "{rings} rings");
            let (forward, _) = factor.order().expect("AMD reorders a cylinder");
            let b: Vec<f64> = (0..3 * n).map(|i| ((i * 7) % 11) as f64 - 5.0).collect();
            let mut x = b.clone();
            factor.solve_columns(&mut x, n);
            let mut y: Vec<f64> = b.chunks(n).flat_map(|col| forward.iter().map(|&v| col[v])).collect();
            factor.solve_ordered_columns(&mut y, n);
            for (xc, yc) in x.chunks(n).zip(y.chunks(n)) {
                for (k, &v) in forward.iter().enumerate() {
                    assert!((yc[k] - xc[v]).abs() <= 1e-12 * xc[v].abs().max(1.0), "{} against {}", yc[k], xc[v]);
                }
            }
        }
    }

    #[test]
    fn no_factor_when_every_regularization_fails() {
        let pattern = SymbolicSparseColMatRef::new_checked(3, 3, &COL_PTR, None, &ROW_IDX);
        let symbolic = symbolic_factor(pattern, None).unwrap();
        assert!(factor_first(symbolic, pattern, &[0.0, 1.0, -3.0], values).is_none());
    }
}
