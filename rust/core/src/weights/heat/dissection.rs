//! Nested dissection ordering of a mesh's vertices, for the sparse Cholesky factor of the heat
//! system on large meshes.
//!
//! Inputs
//!   col_ptr, row_idx  the lower (or full) sparse pattern of an `n x n` symmetric matrix whose
//!                     graph is the mesh's edges (column `j` holds rows `i >= j`)
//!   positions         `(n,)` vertex positions (any frame), for the geometric cuts
//! Output
//!   `(n,)` the elimination order: `order[k]` is the vertex eliminated `k`-th (faer's forward
//!   permutation)
//!
//! Method (George 1973; Lipton, Rose & Tarjan 1979): split the vertices by a small separator
//! into two halves with no edge between them, order each half the same way, and the separator
//! last; a region in several connected pieces is split into them for free. Each split tries a
//! plane through the region's median vertex across the side of its box whose plane crosses the
//! fewest edges among a sample of the vertices (Miller, Teng, Thurston & Vavasis 1998: a
//! surface in space is cut along a curve; a long tube is cut along its length, not across) and the middle level of a
//! breadth-first search from a pseudo-peripheral vertex (the graph's own cut, for a surface
//! folded so that a plane crosses it often), and keeps the smaller separator of the two that
//! leaves both halves at least a quarter of the region. Regions of at most [`LEAF`] vertices
//! are ordered by that search (nearby vertices together, a band of fill).
//!
//! On a surface mesh of `n` vertices the separators have `O(sqrt n)` vertices and the factor
//! `O(n log n)` entries, against the faster-growing fill of minimum degree orderings at
//! millions of vertices. Its cost is a few passes over the edges per level of the dissection.
//!
//! Known limits: the cut is not refined (no Kernighan-Lin / Fiduccia-Mattheyses pass as in
//! METIS), so separators are up to a few times larger than the best; below
//! [`DISSECTION_MIN`] vertices approximate minimum degree gives as small a factor and is used
//! instead (`cholesky`). One thread.

use glam::DVec3;

/// Meshes of at least this many (welded) vertices are ordered by nested dissection, smaller
/// ones by AMD: on capped cylinders of 103k vertices both factors take as long, at 206k the
/// dissection's is 0.6x AMD's, at 1M 0.4x (fewer entries: 87M against 119M).
pub(crate) const DISSECTION_MIN: usize = 200_000;

/// Regions of at most this many vertices are not split further.
pub(crate) const LEAF: usize = 64;

/// Vertices of a region sampled to choose the axis of its plane cut.
const SAMPLE: usize = 1 << 15;

/// The symmetric adjacency (both directions, no diagonal) of a lower pattern, as CSR.
struct Graph {
    start: Vec<usize>,
    adj: Vec<u32>,
}

impl Graph {
    fn of_lower(n: usize, col_ptr: &[usize], row_idx: &[usize]) -> Graph {
        let mut deg = vec![0usize; n + 1];
        for j in 0..n {
            for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
                if i != j {
                    deg[i] += 1;
                    deg[j] += 1;
                }
            }
        }
        let mut start = vec![0usize; n + 1];
        for v in 0..n {
            start[v + 1] = start[v] + deg[v];
        }
        let mut fill = start.clone();
        let mut adj = vec![0u32; start[n]];
        for j in 0..n {
            for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
                if i != j {
                    adj[fill[i]] = j as u32;
                    fill[i] += 1;
                    adj[fill[j]] = i as u32;
                    fill[j] += 1;
                }
            }
        }
        Graph { start, adj }
    }

    #[inline]
    fn neighbours(&self, v: u32) -> &[u32] {
        &self.adj[self.start[v as usize]..self.start[v as usize + 1]]
    }
}

/// The working state: which region each vertex is in (by a stamp), and scratch for searches.
struct Work<'a> {
    graph: Graph,
    positions: &'a [DVec3],
    /// `(n,)` the stamp of the region a vertex is in now.
    region: Vec<u32>,
    /// `(n,)` breadth-first level (scratch), valid where `seen == stamp`.
    level: Vec<u32>,
    /// `(n,)` scratch marks (by stamp) of the searches and of the plane cut's sides.
    seen: Vec<u32>,
    /// `(n,)` scratch marks of the plane cut's separator.
    flag: Vec<u32>,
    stamps: u32,
}

/// A region to order and where its vertices go in the order.
struct Task {
    verts: Vec<u32>,
    stamp: u32,
    /// First position of the order it fills (`verts.len()` of them).
    at: usize,
}

/// The nested dissection order (see the module doc).
pub(crate) fn nested_dissection(col_ptr: &[usize], row_idx: &[usize], positions: &[DVec3]) -> Vec<usize> {
    let n = positions.len();
    let mut w = Work {
        graph: Graph::of_lower(n, col_ptr, row_idx),
        positions,
        region: vec![0; n],
        level: vec![0; n],
        seen: vec![0; n],
        flag: vec![0; n],
        stamps: 1,
    };
    let mut order = vec![usize::MAX; n];
    let mut tasks = vec![Task { verts: (0..n as u32).collect(), stamp: 0, at: 0 }];
    while let Some(task) = tasks.pop() {
        w.split(task, &mut order, &mut tasks);
    }
    order
}

impl Work<'_> {
    fn stamp(&mut self) -> u32 {
        self.stamps += 1;
        self.stamps
    }

    /// Breadth-first search from `from` inside region `stamp`: the vertices reached, in order,
    /// their levels in `self.level`, and the number of levels.
    fn search(&mut self, from: u32, stamp: u32) -> (Vec<u32>, u32) {
        let mark = self.stamp();
        let mut queue = vec![from];
        self.seen[from as usize] = mark;
        self.level[from as usize] = 0;
        let mut head = 0;
        while head < queue.len() {
            let v = queue[head];
            head += 1;
            let next = self.level[v as usize] + 1;
            for k in self.graph.start[v as usize]..self.graph.start[v as usize + 1] {
                let u = self.graph.adj[k] as usize;
                if self.region[u] == stamp && self.seen[u] != mark {
                    self.seen[u] = mark;
                    self.level[u] = next;
                    queue.push(u as u32);
                }
            }
        }
        let levels = queue.last().map_or(0, |&v| self.level[v as usize] + 1);
        (queue, levels)
    }

    /// Order `task`'s region: a leaf in search order, a region in pieces as its pieces, else
    /// both halves of the best separator (pushed as tasks) and the separator last.
    fn split(&mut self, task: Task, order: &mut [usize], tasks: &mut Vec<Task>) {
        let Task { verts, stamp, at } = task;
        if verts.is_empty() {
            return;
        }
        let (reached, _) = self.search(verts[0], stamp);
        if reached.len() < verts.len() {
            // Several pieces: each on its own, no separator needed.
            let mut at = at;
            let mut rest = verts;
            let mut piece = reached;
            loop {
                let s = self.stamp();
                piece.iter().for_each(|&v| self.region[v as usize] = s);
                let len = piece.len();
                tasks.push(Task { verts: piece, stamp: s, at });
                at += len;
                rest.retain(|&v| self.region[v as usize] == stamp);
                if rest.is_empty() {
                    return;
                }
                piece = self.search(rest[0], stamp).0;
            }
        }
        if verts.len() <= LEAF {
            for (k, &v) in reached.iter().enumerate() {
                order[at + k] = v as usize;
            }
            return;
        }
        // Pseudo-peripheral start: search again from the last vertex reached.
        let far = *reached.last().unwrap_or(&verts[0]);
        let (reached, levels) = self.search(far, stamp);
        let by_level = self.level_cut(&reached, levels);
        let by_plane = self.plane_cut(&verts, stamp);
        let quarter = verts.len() / 4;
        let balanced = |c: &Cut| c.sides[0].len().min(c.sides[1].len()) >= quarter;
        let best = match (by_level, by_plane) {
            (Some(a), Some(b)) => {
                let pick_b = match (balanced(&a), balanced(&b)) {
                    (true, true) | (false, false) => b.separator.len() < a.separator.len(),
                    (a_ok, _) => !a_ok,
                };
                if pick_b {
                    b
                } else {
                    a
                }
            }
            (Some(a), None) => a,
            (None, Some(b)) => b,
            (None, None) => {
                for (k, &v) in reached.iter().enumerate() {
                    order[at + k] = v as usize;
                }
                return;
            }
        };
        let Cut { sides: [a, b], separator } = best;
        let end = at + verts.len();
        for (k, &v) in separator.iter().enumerate() {
            order[end - separator.len() + k] = v as usize;
            self.region[v as usize] = u32::MAX;
        }
        let (sa, sb) = (self.stamp(), self.stamp());
        a.iter().for_each(|&v| self.region[v as usize] = sa);
        b.iter().for_each(|&v| self.region[v as usize] = sb);
        let b_at = at + a.len();
        tasks.push(Task { verts: a, stamp: sa, at });
        tasks.push(Task { verts: b, stamp: sb, at: b_at });
    }

    /// The middle level of the search whose `levels` levels are in `self.level`: the vertices
    /// before it, after it, and the level itself. `None` for fewer than 3 levels.
    fn level_cut(&self, reached: &[u32], levels: u32) -> Option<Cut> {
        if levels < 3 {
            return None;
        }
        let mut count = vec![0usize; levels as usize];
        reached.iter().for_each(|&v| count[self.level[v as usize] as usize] += 1);
        let half = reached.len() / 2;
        let mut sum = 0;
        let mut mid = 1;
        for (l, &c) in count.iter().enumerate() {
            sum += c;
            if sum > half {
                mid = l;
                break;
            }
        }
        let mid = (mid as u32).clamp(1, levels - 2);
        let mut cut = Cut::default();
        for &v in reached {
            let l = self.level[v as usize];
            match l.cmp(&mid) {
                std::cmp::Ordering::Less => cut.sides[0].push(v),
                std::cmp::Ordering::Equal => cut.separator.push(v),
                std::cmp::Ordering::Greater => cut.sides[1].push(v),
            }
        }
        Some(cut)
    }

    /// The plane across one side of the region's box through its median vertex
    /// ([`plane_cut_on`](Self::plane_cut_on)), on the side whose plane crosses the fewest edges
    /// among at most [`SAMPLE`] of the region's vertices ([`crossings`](Self::crossings)).
    /// `None` when every vertex lies on one point.
    fn plane_cut(&mut self, verts: &[u32], stamp: u32) -> Option<Cut> {
        let p = self.positions;
        let (lo, hi) = verts.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(p[v as usize]), hi.max(p[v as usize]))
        });
        let size = hi - lo;
        let axes: Vec<usize> = (0..3).filter(|&a| size[a] > 0.0).collect();
        let sample: Vec<u32> = verts.iter().step_by(verts.len().div_ceil(SAMPLE).max(1)).copied().collect();
        let axis = axes.iter().copied().min_by_key(|&a| (self.crossings(&sample, stamp, a), a))?;
        Some(self.plane_cut_on(verts, stamp, axis))
    }

    /// How many of `sample`'s vertices have a neighbour in the region across the plane through
    /// the sample's median on `axis`.
    fn crossings(&self, sample: &[u32], stamp: u32, axis: usize) -> usize {
        let p = self.positions;
        let mut c: Vec<f64> = sample.iter().map(|&v| p[v as usize][axis]).collect();
        let mid = c.len() / 2;
        let (_, &mut m, _) = c.select_nth_unstable_by(mid, f64::total_cmp);
        let below = |v: u32| p[v as usize][axis] < m;
        sample
            .iter()
            .filter(|&&v| {
                self.graph.neighbours(v).iter().any(|&u| self.region[u as usize] == stamp && below(u) != below(v))
            })
            .count()
    }

    /// A plane across `axis` through the region's median vertex: the separator is the side's
    /// vertices with a neighbour across (the smaller such side).
    fn plane_cut_on(&mut self, verts: &[u32], stamp: u32, axis: usize) -> Cut {
        let p = self.positions;
        // Ranked by (coordinate, index): the lower half is the first half of the ranking.
        let mut keyed: Vec<(f64, u32)> = verts.iter().map(|&v| (p[v as usize][axis], v)).collect();
        let mid = keyed.len() / 2;
        keyed.select_nth_unstable_by(mid, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mark = self.stamp();
        for &(_, v) in &keyed[..mid] {
            self.seen[v as usize] = mark;
        }
        let lower = |w: &Self, v: u32| w.seen[v as usize] == mark;
        // Boundary vertices of each side: those with a neighbour in the region on the other side.
        let mut boundary = [Vec::new(), Vec::new()];
        for &(_, v) in &keyed {
            let side = usize::from(!lower(self, v));
            let across = self
                .graph
                .neighbours(v)
                .iter()
                .any(|&u| self.region[u as usize] == stamp && lower(self, u) != (side == 0));
            if across {
                boundary[side].push(v);
            }
        }
        let s = if boundary[0].len() <= boundary[1].len() { 0 } else { 1 };
        let sep = self.stamp();
        for &v in &boundary[s] {
            self.flag[v as usize] = sep;
        }
        let mut cut = Cut::default();
        for &(_, v) in &keyed {
            if self.flag[v as usize] == sep {
                cut.separator.push(v);
            } else {
                cut.sides[usize::from(!lower(self, v))].push(v);
            }
        }
        cut
    }
}

/// A split of a region: two sides with no edge between them, and the separator.
#[derive(Default)]
struct Cut {
    sides: [Vec<u32>; 2],
    separator: Vec<u32>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::cotan::{cotan_laplacian, stiffness_lower_csc};
    use crate::primitives::capped_cylinder;

    /// The order is a permutation, and no edge joins the two sides of any split: checked on a
    /// cylinder and on two cylinders (pieces), through the factor's fill being that of the
    /// dissection (a separator last).
    #[test]
    fn the_order_is_a_permutation() {
        for (rings, segments) in [(2, 3), (40, 24), (120, 60)] {
            let (v, t) = capped_cylinder(0.5, 4.0, rings, segments);
            let pos: Vec<DVec3> = v.iter().map(|p| DVec3::from(p.map(|c| c as f64))).collect();
            let cot = cotan_laplacian(&pos, &t);
            let csc = stiffness_lower_csc(pos.len(), &cot.edges);
            let order = nested_dissection(&csc.col_ptr, &csc.row_idx, &pos);
            let mut seen = vec![false; pos.len()];
            for &o in &order {
                assert!(!seen[o], "vertex {o} twice");
                seen[o] = true;
            }
            assert!(seen.iter().all(|&s| s));
        }
    }
}
