//! The peak memory of one heat solve, estimated before it starts, so that a caller can refuse a
//! solve that would not fit instead of being killed by the system; the size of the blocks of
//! bones that bounds it ([`BLOCK_BYTES`]); and large zeroed buffers written first in parallel
//! ([`zeroed`]).
//!
//! Inputs
//!   vertices  vertices of the mesh (welded or not: the estimate takes them all)
//!   bones     bones solved for (a block of them has at least one column per worker thread)
//! Output
//!   bytes at the solve's peak, above what the caller held before the call
//!
//! Method: `vertices x PER_VERTEX` for the cotangent Laplacian, its sparse Cholesky factor and
//! the mesh's tables (BVH, welding, sources), growing as `log2(vertices) / 20` past a million
//! vertices (a surface's factor has `O(n log n)` entries), plus twice one block of dense
//! right-hand sides ([`bone_blocks`](super::blocks::bone_blocks): the block and its solution
//! being ranked). `PER_VERTEX` is fitted on capped cylinders of 100k, 400k and 1M vertices with
//! 40 and 200 bones (`bench/heat_memory.py`) and rounded up: the measured peaks are 90-96 % of
//! the estimate.
//!
//! Known limits: beyond 1M vertices the growth is the `n log n` rule, not a measurement; meshes
//! far from a surface (a volume's tetrahedra surfaces, dense sliver fans) fill their factor
//! more.

use rayon::prelude::*;

/// Bytes of dense weights (`f64`, vertices x bones) solved at once: the bones go in blocks of
/// at most this much (but at least one column per thread), so memory stays bounded on a mesh
/// of millions of vertices with hundreds of bones (1M x 300 would take 2.4 GB at once). Meshes
/// up to 206k vertices and 160 bones (or 1M and 33) are one block; wider blocks read the
/// factor fewer times but were no faster at 1M vertices with 200 bones.
pub const BLOCK_BYTES: usize = 256 << 20;

/// Bones in a block by default: as many `nw`-vertex columns as fit in [`BLOCK_BYTES`], at
/// least `threads` (one column per thread).
pub(crate) fn block_width(nw: usize, threads: usize) -> usize {
    (BLOCK_BYTES / (8 * nw.max(1))).max(threads).max(1)
}

/// Bytes per vertex of everything but the bones' right-hand sides, up to a million vertices.
const PER_VERTEX: f64 = 1700.0;

/// Estimated peak bytes of a heat solve of `vertices` vertices and `bones` bones (module doc).
pub fn heat_peak_bytes(vertices: usize, bones: usize) -> u64 {
    let threads = rayon::current_num_threads().max(1);
    let n = vertices as f64;
    let growth = (n.max(2.0).log2() / 20.0).max(1.0);
    let columns = bones.min(block_width(vertices, threads));
    (n * PER_VERTEX * growth + 2.0 * 8.0 * n * columns as f64) as u64
}

/// `len` zeros, or `None` when they do not fit. The pages are first written by the worker
/// threads in parallel: zeroed memory from the allocator (`vec![0.0; len]`) maps the kernel's
/// shared zero page and takes a copy-on-write fault, with a TLB flush on every core, on each
/// page's first write, and a serial `resize` faults every page on one thread.
pub(crate) fn zeroed(len: usize) -> Option<Vec<f64>> {
    let mut v = Vec::new();
    v.try_reserve_exact(len).ok()?;
    v.par_extend(rayon::iter::repeat_n(0.0, len).with_min_len(1 << 16));
    Some(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grows_with_vertices_and_bones_up_to_one_block() {
        let (small, large) = (heat_peak_bytes(100_000, 200), heat_peak_bytes(1_000_000, 200));
        assert!(large > 4 * small && small > heat_peak_bytes(100_000, 40));
        // At a million vertices 200 bones need more than one block: the peak is one block's.
        let blocked = heat_peak_bytes(1_000_000, 1_000);
        assert_eq!(blocked, large);
        assert!(blocked > 2 * BLOCK_BYTES as u64);
        // Past a million vertices the factor grows faster than linearly.
        assert!(heat_peak_bytes(10_000_000, 1) > 10 * heat_peak_bytes(1_000_000, 1));
        assert_eq!(heat_peak_bytes(0, 0), 0);
    }

    #[test]
    fn zeroed_is_all_zeros_of_its_length() {
        for len in [0, 1, 70_000, 300_001] {
            let v = zeroed(len).unwrap();
            assert_eq!((v.len(), v.capacity()), (len, len));
            assert!(v.iter().all(|&x| x == 0.0));
        }
        assert!(zeroed(usize::MAX / 8).is_none());
    }
}
