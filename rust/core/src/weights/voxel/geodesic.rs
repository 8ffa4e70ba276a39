//! Geodesic distances from the bones through the solid voxels (Dionne & de Lasa 2013,
//! section 3.2), the `k` nearest bones of every voxel at once.
//!
//! Inputs: the [`Grid`] and its voxels' states (see `grid`), the segments standing for the
//! bones `segs` `(s,)` and the bone of each `owner` `(s,)`, in the unit frame; `k`, the bones
//! kept per voxel. Output [`Labels`]: per voxel reached, its `k` nearest bones by the length of
//! the shortest path through solid voxels (unit frame), ascending.
//!
//! Method:
//! - seeds ([`seeds`]): every solid voxel that a bone's segment passes through (its centre
//!   within half a voxel diagonal of the segment) starts at its centre's exact distance to the
//!   segment. A bone with no solid voxel on its segments (outside the mesh: a root on the
//!   ground) starts at the solid voxels nearest to it, at their distance, as if reaching into
//!   the solid by the shortest straight line;
//! - one multi-label Dijkstra sweep over the 26-connected voxels (steps of 1, sqrt 2 and
//!   sqrt 3 voxels): a voxel keeps at most `k` labels (bone, distance), each final when it
//!   leaves the queue, so every voxel gets exactly its `k` nearest bones along 26-connected
//!   paths (within about 8 % of the Euclidean length of a straight path) for `k` times the cost
//!   of one sweep, however many bones there are;
//! - parts of the solid that no bone reaches (a hat above the head, a prop apart from the
//!   hand) continue the sweep through the empty voxels from the parts already reached, without
//!   changing those: they take the bones of what is nearest to them through the air.
//!
//! The paper sweeps every bone on its own (in parallel); the `k` nearest are all the weights
//! need, and one sweep for all bones does not grow with the rig.

use super::grid::{Grid, EMPTY};
use crate::mesh::segment::closest_point_on_segment;
use crate::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;

/// No label in this slot.
const NONE: u32 = u32::MAX;
/// No row of labels for this voxel yet.
const UNSEEN: u32 = u32::MAX;
/// Most labels a voxel keeps.
pub(super) const MAX_LABELS: usize = 8;

/// One voxel's labels, in one cache line: bones, their distances, and which are final (bit
/// `s` of `settled`).
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Row {
    bone: [u32; MAX_LABELS],
    dist: [f32; MAX_LABELS],
    settled: u32,
}

const EMPTY_ROW: Row = Row { bone: [NONE; MAX_LABELS], dist: [f32::INFINITY; MAX_LABELS], settled: 0 };

/// Each reached voxel's nearest bones, `k` slots per voxel.
pub(super) struct Labels {
    pub k: usize,
    /// `(grid.len(),)` the row of each voxel, [`UNSEEN`] for a voxel never reached.
    row_of: Vec<u32>,
    rows: Vec<Row>,
}

impl Labels {
    /// Empty labels over `voxels`, with rows laid out in voxel order for the voxels in
    /// `first` (neighbours' rows lie close in memory); other voxels get theirs when reached.
    fn new(voxels: usize, k: usize, first: &[bool]) -> Labels {
        let mut row_of = vec![UNSEEN; voxels];
        let mut count = 0u32;
        for (r, _) in row_of.iter_mut().zip(first).filter(|(_, &f)| f) {
            *r = count;
            count += 1;
        }
        Labels { k: k.clamp(1, MAX_LABELS), row_of, rows: vec![EMPTY_ROW; count as usize] }
    }

    /// No labels over `voxels` (a mesh with no solid).
    pub fn none(voxels: usize) -> Labels {
        Labels::new(voxels, 1, &[])
    }

    /// The settled labels of voxel `v` as `(bone, distance)`, in no order.
    pub fn of(&self, v: usize) -> impl Iterator<Item = (u32, f32)> + '_ {
        let r = self.row_of[v];
        let row = if r == UNSEEN { &EMPTY_ROW } else { &self.rows[r as usize] };
        (0..self.k).filter(move |s| row.settled & (1 << s) != 0).map(move |s| (row.bone[s], row.dist[s]))
    }

    /// Has voxel `v` a settled label?
    pub fn reached(&self, v: usize) -> bool {
        let r = self.row_of[v];
        r != UNSEEN && self.rows[r as usize].settled != 0
    }

    fn row(&mut self, v: usize) -> &mut Row {
        if self.row_of[v] == UNSEEN {
            self.row_of[v] = self.rows.len() as u32;
            self.rows.push(EMPTY_ROW);
        }
        &mut self.rows[self.row_of[v] as usize]
    }

    /// Offer bone `j` at distance `d` to voxel `v`: true when it became (or improved) one of
    /// the voxel's unsettled labels, to be queued.
    #[inline]
    fn offer(&mut self, v: usize, j: u32, d: f32) -> bool {
        let k = self.k;
        let row = self.row(v);
        if let Some(s) = row.bone[..k].iter().position(|&b| b == j) {
            if row.settled & (1 << s) != 0 || d >= row.dist[s] {
                return false;
            }
            row.dist[s] = d;
            return true;
        }
        // A free slot, else the farthest unsettled one if `d` beats it (that bone then cannot
        // be among the k nearest: k others are nearer).
        let slot = row.bone[..k].iter().position(|&b| b == NONE).or_else(|| {
            (0..k).filter(|&s| row.settled & (1 << s) == 0).max_by(|&a, &b| row.dist[a].total_cmp(&row.dist[b]))
        });
        match slot {
            Some(s) if d < row.dist[s] => {
                row.bone[s] = j;
                row.dist[s] = d;
                true
            }
            _ => false,
        }
    }

    /// Settle `j` at `d` in voxel `v` if that is still its current unsettled label.
    fn settle(&mut self, v: usize, j: u32, d: f32) -> bool {
        let r = self.row_of[v];
        if r == UNSEEN {
            return false;
        }
        let k = self.k;
        let row = &mut self.rows[r as usize];
        let Some(s) = row.bone[..k].iter().position(|&b| b == j) else { return false };
        if row.settled & (1 << s) != 0 || row.dist[s] != d {
            return false;
        }
        row.settled |= 1 << s;
        true
    }
}

/// A queued label: distance, voxel, bone.
type Entry = (f32, u32, u32);

/// Dial's bucket queue: buckets one voxel step wide. A step is at least one voxel long, so
/// nothing popped from a bucket can improve another label of the same bucket; each bucket is
/// sorted when its turn comes, so labels settle in the order of Dijkstra's.
struct Buckets {
    width: f32,
    buckets: Vec<Vec<Entry>>,
    current: usize,
    cursor: usize,
}

impl Buckets {
    fn new(width: f32) -> Buckets {
        Buckets { width, buckets: Vec::new(), current: 0, cursor: 0 }
    }

    fn push(&mut self, e: Entry) {
        let b = ((e.0 / self.width) as usize).max(self.current + (self.cursor > 0) as usize);
        if b >= self.buckets.len() {
            self.buckets.resize_with(b + 1, Vec::new);
        }
        self.buckets[b].push(e);
    }

    fn pop(&mut self) -> Option<Entry> {
        loop {
            let bucket = self.buckets.get_mut(self.current)?;
            if self.cursor == 0 {
                bucket.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
            }
            if let Some(&e) = bucket.get(self.cursor) {
                self.cursor += 1;
                return Some(e);
            }
            *bucket = Vec::new();
            self.current += 1;
            self.cursor = 0;
        }
    }
}

/// The `k` nearest bones of every voxel (see the module doc). `k` is clamped to
/// `1..=`[`MAX_LABELS`] and to the number of bones.
/// Also returns the number of bones that start outside the solid.
pub(super) fn nearest_bones(
    grid: &Grid,
    state: &[u8],
    segs: &[(DVec3, DVec3)],
    owner: &[u32],
    k: usize,
    cancelled: &dyn Fn() -> bool,
) -> Result<(Labels, usize)> {
    let (seeded, outside) = seeds(grid, state, segs, owner);
    let bones = owner.iter().map(|&j| j as usize + 1).max().unwrap_or(1);
    let k = k.min(bones).clamp(1, MAX_LABELS);
    let inner: Vec<bool> = (0..grid.len()).map(|v| !grid.on_border(v)).collect();
    let solid_mask: Vec<bool> = (0..grid.len()).map(|v| state[v] != EMPTY && inner[v]).collect();
    let mut labels = Labels::new(grid.len(), k, &solid_mask);
    let steps = neighbour_steps(grid);
    let mut heap = Buckets::new(grid.step as f32);
    for &(v, j, d) in &seeded {
        if labels.offer(v as usize, j, d) {
            heap.push((d, v, j));
        }
    }
    let solid = |v: usize| solid_mask[v];
    sweep(&mut labels, &mut heap, &steps, &solid, None, cancelled)?;
    // Solid voxels no bone reached: on through the air from the voxels reached, which stay as
    // they are, until each of those has as many labels as there are bones (up to k).
    let unreached: Vec<bool> = (0..grid.len()).map(|v| state[v] != EMPTY && !labels.reached(v)).collect();
    let pending = unreached.iter().filter(|&&u| u).count();
    if pending > 0 {
        let mut bones: Vec<u32> = seeded.iter().map(|s| s.1).collect();
        bones.sort_unstable();
        bones.dedup();
        let first: Vec<bool> = (0..grid.len()).map(|v| labels.reached(v)).collect();
        let mut heap = Buckets::new(grid.step as f32);
        let open = |v: usize| !first[v] && inner[v];
        for (v, _) in first.iter().enumerate().filter(|&(v, &r)| r && inner[v]) {
            let from: Vec<(u32, f32)> = labels.of(v).collect();
            for &(off, len) in &steps {
                let u = (v as isize + off) as usize;
                if open(u) {
                    for &(j, d) in &from {
                        let du = d + len;
                        if labels.offer(u, j, du) {
                            heap.push((du, u as u32, j));
                        }
                    }
                }
            }
        }
        let stop = Until { voxels: &unreached, labels: bones.len().min(k), pending };
        sweep(&mut labels, &mut heap, &steps, &open, Some(stop), cancelled)?;
    }
    Ok((labels, outside))
}

/// Stop a sweep once every voxel marked in `voxels` (`pending` of them) has `labels` settled
/// labels.
struct Until<'a> {
    voxels: &'a [bool],
    labels: usize,
    pending: usize,
}

/// Dijkstra's loop over the voxels `open` allows, from the queued labels (until `until`).
fn sweep(
    labels: &mut Labels,
    heap: &mut Buckets,
    steps: &[(isize, f32)],
    open: &dyn Fn(usize) -> bool,
    mut until: Option<Until>,
    cancelled: &dyn Fn() -> bool,
) -> Result<()> {
    let mut pops = 0usize;
    while let Some((d, v, j)) = heap.pop() {
        pops += 1;
        if pops.is_multiple_of(1 << 18) && cancelled() {
            return Err(Error::Cancelled);
        }
        if !labels.settle(v as usize, j, d) {
            continue;
        }
        if let Some(u) = until.as_mut().filter(|u| u.voxels[v as usize]) {
            if labels.of(v as usize).count() == u.labels {
                u.pending -= 1;
                if u.pending == 0 {
                    return Ok(());
                }
            }
        }
        for &(off, len) in steps {
            let u = (v as isize + off) as usize;
            if open(u) {
                let du = d + len;
                if labels.offer(u, j, du) {
                    heap.push((du, u as u32, j));
                }
            }
        }
    }
    Ok(())
}

/// The 26 neighbours as (index offset, length in the unit frame).
fn neighbour_steps(grid: &Grid) -> Vec<(isize, f32)> {
    let (nx, nxy) = (grid.dims[0] as isize, (grid.dims[0] * grid.dims[1]) as isize);
    let mut out = Vec::with_capacity(26);
    for dz in -1isize..=1 {
        for dy in -1isize..=1 {
            for dx in -1isize..=1 {
                let n = dx.abs() + dy.abs() + dz.abs();
                if n > 0 {
                    out.push((dz * nxy + dy * nx + dx, ((n as f64).sqrt() * grid.step) as f32));
                }
            }
        }
    }
    out
}

/// The seeds of the sweep as (voxel, bone, distance), see the module doc, and the number of
/// bones that start outside the solid.
fn seeds(grid: &Grid, state: &[u8], segs: &[(DVec3, DVec3)], owner: &[u32]) -> (Vec<(u32, u32, f32)>, usize) {
    let reach = 0.5 * 3f64.sqrt() * grid.step;
    let solid = |v: usize| state[v] != EMPTY && !grid.on_border(v);
    let mut per_seg: Vec<Vec<(u32, u32, f32)>> = segs
        .par_iter()
        .zip(owner.par_iter())
        .map(|(&(h, t), &j)| {
            let mut out = Vec::new();
            let n = ((t - h).length() / (0.5 * grid.step)).ceil().max(1.0) as usize;
            for s in 0..=n {
                let c = grid.voxel_at(h + (t - h) * (s as f64 / n as f64));
                for dz in 0..3 {
                    for dy in 0..3 {
                        for dx in 0..3 {
                            let q = [c[0] + dx, c[1] + dy, c[2] + dz];
                            if q.iter().zip(grid.dims).any(|(&x, d)| x == 0 || x > d) {
                                continue;
                            }
                            let v = grid.index([q[0] - 1, q[1] - 1, q[2] - 1]);
                            if !solid(v) {
                                continue;
                            }
                            let d = closest_point_on_segment(grid.centre(v), h, t).1;
                            if d <= reach {
                                out.push((v as u32, j, d as f32));
                            }
                        }
                    }
                }
            }
            out
        })
        .collect();
    // Bones with no voxel on their segments: the solid voxels nearest to them.
    let nb = owner.iter().map(|&j| j as usize + 1).max().unwrap_or(0);
    let mut has = vec![false; nb];
    for (seeds, &j) in per_seg.iter().zip(owner) {
        has[j as usize] |= !seeds.is_empty();
    }
    let outside: Vec<u32> = (0..nb as u32).filter(|&j| !has[j as usize] && owner.contains(&j)).collect();
    if !outside.is_empty() {
        let solid_voxels: Vec<usize> = (0..grid.len()).filter(|&v| solid(v)).collect();
        let extra: Vec<Vec<(u32, u32, f32)>> = outside
            .par_iter()
            .map(|&j| {
                let mine: Vec<(DVec3, DVec3)> =
                    segs.iter().zip(owner).filter(|&(_, &o)| o == j).map(|(s, _)| *s).collect();
                let dist = |v: usize| {
                    let c = grid.centre(v);
                    mine.iter().map(|&(h, t)| closest_point_on_segment(c, h, t).1).fold(f64::INFINITY, f64::min)
                };
                let d: Vec<f64> = solid_voxels.iter().map(|&v| dist(v)).collect();
                let near = d.iter().copied().fold(f64::INFINITY, f64::min) + grid.step;
                solid_voxels
                    .iter()
                    .zip(&d)
                    .filter(|(_, &x)| x <= near)
                    .map(|(&v, &x)| (v as u32, j, x as f32))
                    .collect()
            })
            .collect();
        per_seg.extend(extra);
    }
    (per_seg.into_iter().flatten().collect(), outside.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::weights::voxel::grid::{INSIDE, SURFACE};

    /// A solid slab of voxels `dims` with every non-border voxel solid.
    fn slab(dims: [usize; 3], step: f64) -> (Grid, Vec<u8>) {
        let grid = Grid { dims, origin: DVec3::ZERO, step };
        let state = (0..grid.len()).map(|v| if grid.on_border(v) { EMPTY } else { INSIDE }).collect();
        (grid, state)
    }

    #[test]
    fn distances_grow_along_a_bar_and_keep_the_k_nearest() {
        let (grid, state) = slab([40, 5, 5], 0.1);
        // Three bones along x: [0.2, 1.0], [1.0, 2.0], [2.0, 3.7].
        let y = DVec3::new(0.0, 0.2, 0.2);
        let segs = [
            (DVec3::new(0.2, 0.0, 0.0) + y, DVec3::new(1.0, 0.0, 0.0) + y),
            (DVec3::new(1.0, 0.0, 0.0) + y, DVec3::new(2.0, 0.0, 0.0) + y),
            (DVec3::new(2.0, 0.0, 0.0) + y, DVec3::new(3.7, 0.0, 0.0) + y),
        ];
        let (labels, outside) = nearest_bones(&grid, &state, &segs, &[0, 1, 2], 2, &|| false).unwrap();
        assert_eq!(outside, 0);
        let at = |x: usize| {
            let mut l: Vec<(u32, f32)> = labels.of(grid.index([x, 2, 2])).collect();
            l.sort_by(|a, b| a.1.total_cmp(&b.1));
            l
        };
        // On bone 0 at x = 0.5: bone 0 at 0, bone 1 at 0.5 (along the bar); bone 2 not kept.
        let l = at(5);
        assert_eq!(l.len(), 2);
        assert_eq!((l[0].0, l[1].0), (0, 1));
        assert!(l[0].1 < 1e-6 && (l[1].1 - 0.5).abs() < 1e-5, "{l:?}");
        // At x = 3.0 (on bone 2): bone 2, then bone 1 at 1.0.
        let l = at(30);
        assert_eq!((l[0].0, l[1].0), (2, 1));
        assert!((l[1].1 - 1.0).abs() < 1e-5, "{l:?}");
        // Off the bar's axis by one voxel, 1.0 along it from bone 2: the 26-connected path
        // stays within 8 % of the straight line.
        let (labels, _) = nearest_bones(&grid, &state, &segs, &[0, 1, 2], 3, &|| false).unwrap();
        let off: Vec<(u32, f32)> = labels.of(grid.index([10, 1, 3])).collect();
        let d0 = off.iter().find(|l| l.0 == 2).unwrap().1;
        let exact = (1.0f32 + 0.02).sqrt();
        assert!(d0 >= exact - 1e-4 && d0 <= 1.08 * exact, "{d0} vs {exact}");
    }

    #[test]
    fn walls_make_paths_go_round_and_unreached_parts_go_through_the_air() {
        // A U: two bars along y joined at y = 0, with a wall (empty) between them; a loose
        // block beyond the right bar, one empty voxel away.
        let grid = Grid { dims: [14, 12, 4], origin: DVec3::ZERO, step: 1.0 };
        let mut state = vec![EMPTY; grid.len()];
        for (v, s) in state.iter_mut().enumerate() {
            let [x, y, z] = grid.coords(v);
            if grid.on_border(v) || z != 1 && z != 2 {
                continue;
            }
            let left = (1..=2).contains(&x) && y <= 10;
            let right = (6..=7).contains(&x) && y <= 10;
            let bottom = y <= 2 && (1..=7).contains(&x);
            let loose = (9..=10).contains(&x) && (4..=6).contains(&y);
            if left || right || bottom || loose {
                *s = if loose { SURFACE } else { INSIDE };
            }
        }
        let seg = (DVec3::new(1.5, 8.0, 1.5), DVec3::new(1.5, 10.0, 1.5));
        let (labels, _) = nearest_bones(&grid, &state, &[seg], &[0], 1, &|| false).unwrap();
        // Top of the right bar: down the left bar, across the bottom and up, never across.
        let d = labels.of(grid.index([6, 10, 1])).next().unwrap().1;
        assert!(d > 8.0 + 4.0 + 8.0 - 3.0, "{d}");
        // The loose block is reached through the one empty voxel beside the right bar.
        let near = labels.of(grid.index([7, 5, 1])).next().unwrap().1;
        let loose = labels.of(grid.index([9, 5, 1])).next().unwrap().1;
        assert!(loose > near + 1.0 && loose <= near + 2.0 + 1e-4, "{near} {loose}");
    }

    #[test]
    fn a_bone_outside_starts_at_the_nearest_voxels() {
        let (grid, state) = slab([10, 10, 10], 0.1);
        // Below the slab (z = -0.3), under voxel (5, 5, 1).
        let seg = (DVec3::new(0.5, 0.5, -0.3), DVec3::new(0.5, 0.5, -0.2));
        let (labels, outside) = nearest_bones(&grid, &state, &[seg], &[0], 1, &|| false).unwrap();
        assert_eq!(outside, 1);
        let d = labels.of(grid.index([5, 5, 1])).next().unwrap().1;
        assert!((d - 0.3).abs() < 1e-5, "{d}");
    }
}
