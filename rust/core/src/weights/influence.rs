//! Sparse per-vertex bone influences (the top `k` bones per vertex), the output of every
//! weighting method and the input of linear blend skinning.

use rayon::prelude::*;

/// Dense top-`k` influences, row-major: row `v` is `indices[v*k .. v*k+k]` /
/// `weights[v*k .. v*k+k]`, sorted by decreasing weight. Unused slots have index `-1` and
/// weight `0`; every row with at least one used slot sums to 1.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Influences {
    /// Slots per vertex (>= 1).
    pub k: usize,
    /// `(n * k,)` bone indices, `-1` for unused.
    pub indices: Vec<i32>,
    /// `(n * k,)` weights in `[0, 1]`.
    pub weights: Vec<f32>,
}

impl Influences {
    /// Number of vertices (rows).
    pub fn n(&self) -> usize {
        self.indices.len().checked_div(self.k).unwrap_or(0)
    }

    /// `n` empty rows of `k` slots (`k` clamped to >= 1).
    pub fn empty(n: usize, k: usize) -> Influences {
        let k = k.max(1);
        Influences { k, indices: vec![-1; n * k], weights: vec![0.0; n * k] }
    }

    /// Row `v`: `(indices, weights)`, each of length `k`.
    pub fn row(&self, v: usize) -> (&[i32], &[f32]) {
        let r = v * self.k..(v + 1) * self.k;
        (&self.indices[r.clone()], &self.weights[r])
    }

    /// Expand to a dense `(n, b)` row-major matrix (indices `>= b` are ignored).
    pub fn to_dense(&self, b: usize) -> Vec<f32> {
        let mut d = vec![0.0f32; self.n() * b];
        for v in 0..self.n() {
            let (idx, w) = self.row(v);
            for (&i, &w) in idx.iter().zip(w) {
                if i >= 0 && (i as usize) < b {
                    d[v * b + i as usize] += w;
                }
            }
        }
        d
    }
}

/// Keep the `k` largest positive values of one row and normalize them.
///
/// `value(j)` for `j in 0..b` gives the row (NaN, negative and zero values are ignored).
/// Writes sorted `(index, weight)` pairs into `out_idx` / `out_w` (length `k >= 1`), unused
/// slots `-1` / `0`. After a first normalization to sum 1, entries below `min_weight` are
/// dropped (the largest one is always kept) and the rest renormalized. A row without any
/// positive value is left empty. Returns the number of used slots.
pub fn top_k_row(
    value: impl Fn(usize) -> f32,
    b: usize,
    min_weight: f32,
    out_idx: &mut [i32],
    out_w: &mut [f32],
) -> usize {
    let k = out_idx.len().min(out_w.len());
    out_idx.fill(-1);
    out_w.fill(0.0);
    if k == 0 {
        return 0;
    }
    let mut used = 0usize;
    for j in 0..b {
        used = insert_ranked(j as i32, value(j), &mut out_idx[..k], &mut out_w[..k], used);
    }
    normalize_pruned(&mut out_idx[..k], &mut out_w[..k], used, min_weight)
}

/// Insert `(j, w)` into the list of the `used` largest values so far, `idx` / `ws` (its
/// capacity is their length), kept in decreasing weight and, on equal weights, increasing
/// index, so the list does not depend on the order the values come in. NaN, infinite,
/// negative and zero values are ignored. Returns the new number of used slots.
#[inline]
pub fn insert_ranked(j: i32, w: f32, idx: &mut [i32], ws: &mut [f32], used: usize) -> usize {
    let k = idx.len().min(ws.len());
    if !(w > 0.0) || !w.is_finite() || k == 0 {
        return used;
    }
    let before = |a: (f32, i32), b: (f32, i32)| a.0 > b.0 || (a.0 == b.0 && a.1 < b.1);
    if used == k && !before((w, j), (ws[k - 1], idx[k - 1])) {
        return used;
    }
    let mut pos = if used < k { used } else { k - 1 };
    while pos > 0 && before((w, j), (ws[pos - 1], idx[pos - 1])) {
        ws[pos] = ws[pos - 1];
        idx[pos] = idx[pos - 1];
        pos -= 1;
    }
    ws[pos] = w;
    idx[pos] = j;
    (used + 1).min(k)
}

/// Keep the first `k` of the first `used` entries of a sorted list (from [`insert_ranked`])
/// so that a bone's kept weight falls continuously to 0 where it leaves the top `k`: with a
/// `(k + 1)`-th entry of weight `t`, a kept weight `w` below `2 t` becomes `2 (w - t)` (0 at
/// `t`, itself again at `2 t`), larger ones stay; the entries left at 0 and those past `k` are
/// cleared (`-1` / `0`). A plain cut keeps the first `k` as they are, and two neighbouring
/// vertices whose `k`-th and `(k + 1)`-th bones swap then differ by that whole weight: a seam
/// that LBS shears (Blender's Limit Total cuts so). The map is the same for every kept entry
/// and increasing, so swaps within the first `k` change nothing and the order stays. A list
/// whose first `k + 1` entries are all equal keeps its first `k` as they are (nothing would be
/// left). Returns the slots kept; normalize with [`normalize_pruned`].
pub fn cut_continuously(idx: &mut [i32], ws: &mut [f32], used: usize, k: usize) -> usize {
    if used <= k {
        return used;
    }
    let next = ws[k];
    let kept = if ws[0] > next {
        ws[..k].iter_mut().filter(|w| **w < 2.0 * next).for_each(|w| *w = 2.0 * (*w - next));
        ws[..k].iter().take_while(|&&w| w > 0.0).count()
    } else {
        k
    };
    for s in kept..used {
        ws[s] = 0.0;
        idx[s] = -1;
    }
    kept
}

/// Normalize the first `used` entries of a sorted list (from [`insert_ranked`]) to sum 1,
/// drop those below `min_weight` (never the first; the others from the first that falls
/// below), set the dropped slots to `-1` / `0` and renormalize. Returns the slots kept.
pub fn normalize_pruned(idx: &mut [i32], ws: &mut [f32], used: usize, min_weight: f32) -> usize {
    if used == 0 {
        return 0;
    }
    let sum: f32 = ws[..used].iter().sum();
    let keep = 1 + ws[1..used].iter().take_while(|&&w| w / sum >= min_weight).count();
    for s in keep..used {
        ws[s] = 0.0;
        idx[s] = -1;
    }
    let sum: f32 = ws[..keep].iter().sum();
    ws[..keep].iter_mut().for_each(|w| *w /= sum);
    keep
}

/// Top-`k` influences of a dense weight matrix.
///
/// Inputs: `dense` `(n, b)` row-major non-negative weights (values past the end of a short
/// slice count as 0; NaN / negative count as 0), `k` slots per vertex (clamped to >= 1),
/// `min_weight` pruning threshold *relative to the row's kept total*: the `k` largest
/// positive entries are normalized to sum 1, entries below `min_weight` dropped (never the
/// largest), the rest renormalized to sum 1 (so a row with any positive value always keeps
/// at least its argmax bone at weight <= 1). A row with no positive value stays empty
/// (`-1` / `0`): the caller decides what such a vertex gets.
/// Output: [`Influences`] with `n` rows. Parallel over rows.
pub fn top_k_normalized(dense: &[f32], n: usize, b: usize, k: usize, min_weight: f32) -> Influences {
    let mut out = Influences::empty(n, k);
    let k = out.k;
    out.indices.par_chunks_mut(k).zip(out.weights.par_chunks_mut(k)).enumerate().with_min_len(1024).for_each(
        |(v, (idx, w))| {
            let base = v * b;
            top_k_row(|j| dense.get(base + j).copied().unwrap_or(0.0), b, min_weight, idx, w);
        },
    );
    out
}

/// Blender's small-weight ramp (`heat_limit_weight`): 0 below `end`, linear from 0 to
/// `start` on `[end, start)`, identity above; non-positive and NaN give 0.
#[inline]
pub fn weight_limit(w: f32, start: f32, end: f32) -> f32 {
    if !(w > 0.0) || w < end {
        0.0
    } else if w < start {
        start * (w - end) / (start - end)
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_largest_and_normalizes() {
        #[rustfmt::skip]
        let dense = [
            0.1, 0.5, 0.0, 0.3, 0.2, // -> 1, 3, 4 (top 3)
            0.0, 0.0, 0.0, 0.0, 0.0, // empty
            f32::NAN, -1.0, 2.0, 0.0, 1e-6, // -> 2 only after pruning
            0.25, 0.25, 0.25, 0.25, 0.0, // ties -> lowest indices
        ];
        let inf = top_k_normalized(&dense, 4, 5, 3, 1e-3);
        assert_eq!(inf.n(), 4);
        let (i, w) = inf.row(0);
        assert_eq!(i, &[1, 3, 4]);
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        assert!((w[0] - 0.5 / 1.0).abs() < 1e-6);
        assert_eq!(inf.row(1).0, &[-1, -1, -1]);
        assert_eq!(inf.row(2), (&[2, -1, -1][..], &[1.0, 0.0, 0.0][..]));
        assert_eq!(inf.row(3).0, &[0, 1, 2]);
        let d = inf.to_dense(5);
        assert!((d[1] - 0.5).abs() < 1e-6 && d[0] == 0.0);
        // k = 0 is clamped to 1.
        let inf = top_k_normalized(&dense, 4, 5, 0, 0.0);
        assert_eq!(inf.k, 1);
        assert_eq!(inf.row(0), (&[1][..], &[1.0][..]));
    }

    /// The ranked list does not depend on the order the values come in: equal weights rank by
    /// bone index whether the bones come up or down (blocks of bones, mirrored pairs).
    #[test]
    fn equal_weights_rank_by_index_in_any_order() {
        for order in [[1, 3, 0, 2, 4], [4, 3, 2, 1, 0], [2, 4, 0, 3, 1]] {
            let (mut idx, mut ws, mut used) = ([-1; 3], [0.0; 3], 0);
            for j in order {
                let w = if j == 4 { 0.5 } else { 0.25 };
                used = insert_ranked(j, w, &mut idx, &mut ws, used);
            }
            assert_eq!((used, idx, ws), (3, [4, 0, 1], [0.5, 0.25, 0.25]), "order {order:?}");
        }
    }

    /// The continuous cut: a bone leaving the top k fades out instead of jumping. Across a
    /// line where the 2nd and 3rd bones of three swap (k = 2), the plain cut's weights jump by
    /// 0.34 (the 3rd bone's share), the continuous cut's by 0.07.
    #[test]
    fn a_bone_leaving_the_top_k_fades_out() {
        let cut = |values: [f32; 3]| {
            let (mut idx, mut ws, mut used) = ([-1; 3], [0.0; 3], 0);
            for (j, &w) in values.iter().enumerate() {
                used = insert_ranked(j as i32, w, &mut idx, &mut ws, used);
            }
            let kept = cut_continuously(&mut idx, &mut ws, used, 2);
            normalize_pruned(&mut idx, &mut ws, kept, 0.0);
            let mut dense = [0.0f32; 3];
            for s in 0..kept {
                dense[idx[s] as usize] = ws[s];
            }
            (kept, dense)
        };
        let (before, after) = (cut([0.5, 0.26, 0.24]), cut([0.5, 0.24, 0.26]));
        assert_eq!((before.0, after.0), (2, 2));
        let jump = (0..3).map(|j| (before.1[j] - after.1[j]).abs()).fold(0.0f32, f32::max);
        assert!(jump < 0.1, "{before:?} {after:?}");
        assert_eq!(before.1[2], 0.0);
        // 0.5 >= 2 x 0.24 stays, 0.26 -> 2 (0.26 - 0.24).
        assert!((before.1[0] - 0.5 / 0.54).abs() < 1e-5, "{before:?}");
        // Fewer entries than k: unchanged; all equal: the first k as they are.
        assert_eq!(cut([0.5, 0.5, 0.0]), (2, [0.5, 0.5, 0.0]));
        assert_eq!(cut([0.3, 0.3, 0.3]), (2, [0.5, 0.5, 0.0]));
        // The (k + 1)-th equal to the k-th: the k-th goes.
        assert_eq!(cut([0.6, 0.2, 0.2]), (1, [1.0, 0.0, 0.0]));
    }

    /// The pruning threshold is relative to the kept total, so it does not depend on the
    /// scale of the raw values (inverse distances, unnormalized heat): a weight that is 1e-3
    /// of a large total is dropped, and two weights below 1e-3 that share a small total stay.
    #[test]
    fn pruning_is_relative_to_the_total() {
        let dense = [4.0, 0.003, 0.0, 0.0005, 0.0004, 0.0];
        let inf = top_k_normalized(&dense, 2, 3, 3, 1e-3);
        assert_eq!(inf.row(0), (&[0, -1, -1][..], &[1.0, 0.0, 0.0][..]));
        let (i, w) = inf.row(1);
        assert_eq!(i, &[0, 1, -1]);
        assert!((w[0] - 5.0 / 9.0).abs() < 1e-6 && (w[1] - 4.0 / 9.0).abs() < 1e-6, "{w:?}");
    }
}
