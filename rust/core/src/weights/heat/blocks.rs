//! The bones of the heat system solved in blocks of columns (the solve stage of
//! [`crate::weights::heat`]): each block's right-hand sides, solved against the one factor (or
//! the sources themselves when the factorization failed), clipped, rigid pieces and isolated
//! vertices set, mirrored columns averaged, then merged into each vertex's running top k.
//!
//! The weights of all bones at once are dense (vertices x bones, `f64`): on a mesh of millions
//! of vertices with hundreds of bones that is more than the factor. Blocks bound it
//! ([`BLOCK_BYTES`]); ranking by weight and then bone index makes the result independent of
//! the blocks.

use super::cholesky::Factor;
use super::memory::{block_width, zeroed};
use super::sources::{Shares, Source, Ties};
use crate::mesh::mirror::Symmetry;
use crate::weights::influence::weight_limit;
use crate::weights::influence::{cut_continuously, insert_ranked, normalize_pruned, Influences};
use crate::weights::symmetry::symmetrize_columns;
use rayon::prelude::*;
use std::time::Instant;

/// The bones in blocks of at most `cap` bones (0: as many `nw`-vertex columns as fit in
/// [`BLOCK_BYTES`], at least `threads`), in increasing order; with `mirror`, a bone and its
/// mirror partner share a block (symmetry averages their columns).
pub(crate) fn bone_blocks(b: usize, nw: usize, cap: usize, threads: usize, mirror: Option<&[i32]>) -> Vec<Vec<usize>> {
    let cap = if cap > 0 { cap } else { block_width(nw, threads) };
    let mut blocks: Vec<Vec<usize>> = Vec::new();
    let mut placed = vec![false; b];
    for j in 0..b {
        if placed[j] {
            continue;
        }
        let partner = mirror.and_then(|m| usize::try_from(m[j]).ok()).filter(|&m| m != j && m < b && !placed[m]);
        let unit: Vec<usize> = std::iter::once(j).chain(partner).collect();
        match blocks.last_mut() {
            Some(last) if last.len() + unit.len() <= cap => last.extend(&unit),
            _ => blocks.push(unit.clone()),
        }
        for u in unit {
            placed[u] = true;
        }
    }
    for block in &mut blocks {
        block.sort_unstable();
    }
    blocks
}

/// The non-zeros of the right-hand sides `M H P`, bone by bone: each vertex's heat `heat[v]`
/// (`M_ii H_ii`) shared among its source bones (`shares`), listed under each of them, so that
/// a block of bones reads its own and not every vertex's.
pub(crate) struct SourceColumns {
    /// `(b + 1,)` bone `j`'s entries are `start[j]..start[j + 1]`.
    start: Vec<usize>,
    /// The vertex of each entry, increasing within a bone.
    vertex: Vec<u32>,
    /// Its share of the vertex's heat.
    amount: Vec<f64>,
}

impl SourceColumns {
    /// The columns of `b` bones from `shares` and `heat` (`(nw,)`).
    pub(crate) fn new(shares: &Shares, heat: &[f64], b: usize) -> SourceColumns {
        let entries = || {
            heat.iter().enumerate().filter(|(_, &h)| h > 0.0).flat_map(move |(v, &h)| {
                shares
                    .row(v)
                    .filter(move |&(j, _)| (j as usize) < b)
                    .map(move |(j, divisor)| (j as usize, v, h / divisor))
            })
        };
        let mut start = vec![0usize; b + 1];
        entries().for_each(|(j, _, _)| start[j + 1] += 1);
        for j in 0..b {
            start[j + 1] += start[j];
        }
        let mut fill = start.clone();
        let (mut vertex, mut amount) = (vec![0u32; start[b]], vec![0.0f64; start[b]]);
        for (j, v, a) in entries() {
            (vertex[fill[j]], amount[fill[j]]) = (v as u32, a);
            fill[j] += 1;
        }
        SourceColumns { start, vertex, amount }
    }
}

/// The right-hand sides of the bones in `block`, column-major `(n, block.len())`, into `x` (its
/// memory reused from block to block): [`SourceColumns`] in row `place[v]` (`v` without
/// `place`).
fn source_columns(x: &mut Vec<f64>, nw: usize, sources: &SourceColumns, place: Option<&[usize]>, block: &[usize]) {
    let len = nw * block.len();
    if x.capacity() < len {
        *x = zeroed(len).expect("memory for a block of right-hand sides");
    } else {
        x.truncate(len);
        x.par_iter_mut().with_min_len(1 << 16).for_each(|w| *w = 0.0);
        x.resize(len, 0.0);
    }
    for (c, &j) in block.iter().enumerate() {
        let entries = sources.start[j]..sources.start[j + 1];
        for (&v, &a) in sources.vertex[entries.clone()].iter().zip(&sources.amount[entries]) {
            let v = v as usize;
            x[c * nw + place.map_or(v, |p| p[v])] += a;
        }
    }
}

/// Where the factorization failed: each vertex's source bones take their shares of it as
/// weights (with the sources found here, the nearest-bone weights), for the bones of `block`.
fn source_weights(x: &mut [f64], rows: &Rows, block: &[usize]) {
    let nw = x.len() / block.len().max(1);
    let col = block_columns(block);
    x.par_iter_mut().for_each(|w| *w = 0.0);
    for v in 0..nw {
        for (j, divisor) in rows.shares.row(v) {
            if let Some(c) = col(j) {
                x[c * nw + rows.row(v)] = 1.0 / divisor;
            }
        }
    }
}

/// Per welded vertex, what [`block_weights`] needs besides the right-hand sides: its source
/// (for its nearest bone), the bones that share its heat (when the factorization failed), its
/// mass (0: in no usable triangle, isolated), its piece, and each piece's rigid bone(s); and
/// the row of the blocks that holds it.
pub(crate) struct Rows<'a> {
    pub sources: &'a [Source],
    pub shares: &'a Shares,
    pub mass: &'a [f64],
    pub labels: &'a [u32],
    pub rigid: &'a [Option<Ties>],
    /// The rows of the blocks in the factor's elimination order ([`Factor::order`]: the
    /// vertex of each row, and each vertex's row), so that the solves read and write them in
    /// place; `None`: row `v` is vertex `v` (no factor, or no reordering).
    pub order: Option<(&'a [usize], &'a [usize])>,
}

impl Rows<'_> {
    /// The blocks' row of welded vertex `v`.
    pub(crate) fn row(&self, v: usize) -> usize {
        self.order.map_or(v, |(_, place)| place[v])
    }

    /// The welded vertex in the blocks' row `r`.
    fn vertex(&self, r: usize) -> usize {
        self.order.map_or(r, |(vertex, _)| vertex[r])
    }

    /// Each welded vertex's row, `None` for the identity.
    pub(crate) fn place(&self) -> Option<&[usize]> {
        self.order.map(|(_, place)| place)
    }
}

/// The weights of the bones of `block`, column-major `(n, block.len())`, into `x` (its memory
/// reused from block to block), and the seconds spent solving: solved against the factor `llt`
/// (without a factor, the sources' shares), then rigid pieces and isolated vertices at 100% on
/// their bone(s), then clipped to `[0, 1]` and averaged with the mirror images (`sym`: the
/// symmetry and the mirror map of the rows; a block holds every bone's mirror partner); without
/// `sym` [`RunningTopK::merge`] clips. The rows are in `rows.order`, which must be `llt`'s
/// elimination order.
pub(crate) fn block_weights(
    block: &[usize],
    sources: &SourceColumns,
    rows: &Rows,
    llt: Option<&Factor>,
    sym: Option<(&Symmetry, &[i32])>,
    x: &mut Vec<f64>,
) -> f64 {
    let nw = rows.sources.len();
    source_columns(x, nw, sources, rows.place(), block);
    let s = Instant::now();
    match llt {
        // One block of columns per worker, all solved at once: faer's supernodal solve is
        // BLAS-3 in the right-hand sides (a triangular solve and a matmul per supernode on the
        // whole block), so wider blocks stream the factor fewer times and run the dense kernels
        // more efficiently than narrower rounds or one call with faer's own parallelism.
        Some(llt) => {
            solve_live_columns(llt, x, nw);
            // The mirror averages clipped weights; without it the merge clips as it reads.
            if sym.is_some() {
                x.par_iter_mut().with_min_len(8192).for_each(|w| *w = clip(*w));
            }
        }
        None => source_weights(x, rows, block),
    }
    let secs = s.elapsed().as_secs_f64();
    // Rigid pieces and isolated vertices: 100% to one bone (or shared by exact ties).
    for v in 0..nw {
        let ties =
            if rows.mass[v] <= 0.0 { Some(rows.sources[v].nearest) } else { rows.rigid[rows.labels[v] as usize] };
        if let Some(t) = ties {
            for (col, &j) in block.iter().enumerate() {
                let on = t.bones[..t.count as usize].contains(&(j as u32));
                x[col * nw + rows.row(v)] = if on { 1.0 / t.count as f64 } else { 0.0 };
            }
        }
    }
    // Symmetry.
    if let Some((s, vm)) = sym {
        let col = block_columns(block);
        let local: Vec<i32> =
            block.iter().map(|&j| u32::try_from(s.mirror[j]).ok().and_then(&col).map_or(-1, |c| c as i32)).collect();
        symmetrize_columns(x, nw, vm, &local);
    }
    secs
}

/// A solved weight clipped to `[0, 1]`; non-finite (should not happen) counts as 0.
#[inline]
fn clip(w: f64) -> f64 {
    if w.is_finite() {
        w.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Solve `A X = B` for the column-major `(n, k)` block `x` against the factor, skipping the
/// columns of `B` that are zero (a bone no vertex has as its heat source: a hair strand above a
/// body, the rig's other meshes' bones), whose solution is zero: the columns that are not are
/// moved to the front, solved together, and moved back.
fn solve_live_columns(llt: &Factor, x: &mut [f64], nw: usize) {
    let k = x.len() / nw.max(1);
    let live: Vec<usize> = (0..k).filter(|&c| x[c * nw..(c + 1) * nw].iter().any(|&v| v != 0.0)).collect();
    if live.len() == k {
        llt.solve_ordered_columns(x, nw);
        return;
    }
    for (to, &from) in live.iter().enumerate() {
        x.copy_within(from * nw..(from + 1) * nw, to * nw);
    }
    llt.solve_ordered_columns(&mut x[..live.len() * nw], nw);
    for (to, &from) in live.iter().enumerate().rev() {
        x.copy_within(to * nw..(to + 1) * nw, from * nw);
    }
    let mut is_live = vec![false; k];
    for &c in &live {
        is_live[c] = true;
    }
    for c in (0..k).filter(|&c| !is_live[c]) {
        x[c * nw..(c + 1) * nw].fill(0.0);
    }
}

/// Bone `j`'s column in `block` (sorted), if it is there.
fn block_columns(block: &[usize]) -> impl Fn(u32) -> Option<usize> + '_ {
    move |j| block.binary_search(&(j as usize)).ok()
}

/// Rows merged together into the running top k: their state stays in the cache while the
/// block's columns stream past.
const MERGE_ROWS: usize = 1024;

/// Each welded vertex's `k` largest weights so far, over the blocks of bones merged: after
/// Blender's small-weight ramp ([`weight_limit`]), and unramped for the rows whose weights all
/// fall below the ramp. Ranked as [`top_k_row`](crate::weights::influence::top_k_row) ranks
/// them, whatever the order of the blocks.
pub(crate) struct RunningTopK {
    ramped: Influences,
    ramped_used: Vec<usize>,
    raw: Influences,
    raw_used: Vec<usize>,
}

impl RunningTopK {
    /// Each of `nw` vertices' largest `k` weights of `b` bones, and the `(k + 1)`-th when there
    /// is one (for [`cut_continuously`]).
    pub(crate) fn new(nw: usize, k: usize, b: usize) -> RunningTopK {
        let held = (k + 1).min(b.max(k));
        let (ramped, raw) = (Influences::empty(nw, held), Influences::empty(nw, held));
        RunningTopK { ramped, ramped_used: vec![0; nw], raw, raw_used: vec![0; nw] }
    }

    /// Merge the column-major `(n, block.len())` weights `x` of the bones of `block`, clipped
    /// to `[0, 1]`: rows in runs of [`MERGE_ROWS`], each run reading the block column by column.
    pub(crate) fn merge(&mut self, x: &[f64], block: &[usize], start: f32, end: f32) {
        let (k, nw) = (self.ramped.k, self.ramped_used.len());
        let rows =
            self.ramped.indices.par_chunks_mut(MERGE_ROWS * k).zip(self.ramped.weights.par_chunks_mut(MERGE_ROWS * k));
        let raw_rows =
            self.raw.indices.par_chunks_mut(MERGE_ROWS * k).zip(self.raw.weights.par_chunks_mut(MERGE_ROWS * k));
        rows.zip(self.ramped_used.par_chunks_mut(MERGE_ROWS))
            .zip(raw_rows.zip(self.raw_used.par_chunks_mut(MERGE_ROWS)))
            .enumerate()
            .for_each(|(run, (((idx, w), used), ((ridx, rw), rused)))| {
                let first = run * MERGE_ROWS;
                for (c, &j) in block.iter().enumerate() {
                    let column = &x[c * nw + first..c * nw + first + used.len()];
                    for (r, &value) in column.iter().enumerate() {
                        let (value, at) = (clip(value) as f32, r * k..(r + 1) * k);
                        let limited = weight_limit(value, start, end);
                        used[r] = insert_ranked(j as i32, limited, &mut idx[at.clone()], &mut w[at.clone()], used[r]);
                        // The unramped list serves only rows whose ramped one stays empty.
                        if used[r] == 0 {
                            rused[r] = insert_ranked(j as i32, value, &mut ridx[at.clone()], &mut rw[at], rused[r]);
                        }
                    }
                }
            });
    }

    /// Each row cut to its `k` largest ([`cut_continuously`]: a bone leaving them fades out),
    /// normalized and pruned ([`normalize_pruned`]); a row whose weights all fell below the
    /// ramp keeps them unramped, an empty row takes the vertex's nearest bone (the rows are
    /// the blocks' rows, in `rows.order`; so are the result's).
    pub(crate) fn finish(mut self, k: usize, min_weight: f32, rows: &Rows) -> Influences {
        let held = self.ramped.k;
        let raw = &self.raw;
        let (raw_used, ramped_used) = (&self.raw_used, &self.ramped_used);
        self.ramped
            .indices
            .par_chunks_mut(held)
            .zip(self.ramped.weights.par_chunks_mut(held))
            .enumerate()
            .with_min_len(1024)
            .for_each(|(r, (idx, w))| {
                let used = if ramped_used[r] > 0 {
                    ramped_used[r]
                } else if raw_used[r] > 0 {
                    let (ri, rw) = raw.row(r);
                    idx.copy_from_slice(ri);
                    w.copy_from_slice(rw);
                    raw_used[r]
                } else {
                    idx[0] = rows.sources[rows.vertex(r)].nearest.bones[0] as i32;
                    w[0] = 1.0;
                    return;
                };
                let kept = cut_continuously(idx, w, used, k);
                normalize_pruned(idx, w, kept, min_weight);
            });
        if held == k {
            return self.ramped;
        }
        let mut out = Influences::empty(ramped_used.len(), k);
        let rows = out.indices.par_chunks_mut(k).zip(out.weights.par_chunks_mut(k));
        rows.zip(self.ramped.indices.par_chunks(held).zip(self.ramped.weights.par_chunks(held)))
            .with_min_len(1024)
            .for_each(|((oi, ow), (i, w))| {
                oi.copy_from_slice(&i[..k]);
                ow.copy_from_slice(&w[..k]);
            });
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn source(bones: &[u32]) -> Source {
        let mut tied = [u32::MAX; crate::weights::heat::sources::MAX_TIES];
        tied[..bones.len()].copy_from_slice(bones);
        Source { bones: tied, count: bones.len() as u8, dist: 1.0, nearest: Ties::one(bones[0]), nearest_dist: 1.0 }
    }

    /// Pinocchio's `p_j,i = 1/k` for a vertex tied between k bones: they share its heat
    /// `M_ii H_ii`, so every row of the right-hand sides sums to that heat (and the solutions to
    /// 1, since `L 1 = 0`), however the bones fall into blocks.
    #[test]
    fn tied_bones_share_a_vertex_heat() {
        let sources = [source(&[0]), source(&[0, 2]), source(&[1, 2, 3]), source(&[3])];
        let sources = Shares::of_sources(&sources);
        let heat = [2.0, 3.0, 1.5, 0.0];
        let columns = SourceColumns::new(&sources, &heat, 4);
        for blocks in [vec![vec![0, 1, 2, 3]], vec![vec![0, 2], vec![1, 3]]] {
            let mut sum = [0.0; 4];
            for block in &blocks {
                let mut x = Vec::new();
                source_columns(&mut x, 4, &columns, None, block);
                for (c, column) in x.chunks(4).enumerate() {
                    assert_eq!(column.len(), 4, "column {c}");
                    sum.iter_mut().zip(column).for_each(|(s, w)| *s += w);
                }
            }
            assert_eq!(sum, heat);
        }
        let mut x = vec![9.0; 12];
        source_columns(&mut x, 4, &columns, None, &[2]);
        assert_eq!(x, vec![0.0, 1.5, 0.5, 0.0]);
        // In the factor's order: vertex v in row place[v].
        source_columns(&mut x, 4, &columns, Some(&[2, 0, 3, 1]), &[2]);
        assert_eq!(x, vec![1.5, 0.0, 0.0, 0.5]);
    }
}
