//! The centre-line tree of a voxel solid (TEASAR).
//!
//! Input: [`Voxels`] with their depth. Output [`Tree`]: nodes with a position and a radius (unit
//! frame) and undirected edges, a tree whose leaves are the solid's extremities (feet, hands,
//! head, tail, ears...) and whose paths run through the middle of the limbs.
//!
//! Method (Sato, Bitter, Kaufman et al. 2000, "TEASAR: tree-structure extraction algorithm for
//! accurate and robust skeletons"): in the largest connected part of the inside voxels
//! (26-neighbours), the root is the voxel farthest (along the inside) from the deepest one.
//! Dijkstra from the root twice: by length, and by length times a penalty that is large near
//! the surface (`1 + 5000 (1 - depth / max depth)^16`), whose shortest paths keep to the middle.
//! Then, until every voxel is covered: the uncovered voxel farthest from the root by length is
//! an extremity; its penalized path back to the tree joins the tree, and every voxel within
//! `2 depth + 1` of a path voxel is covered. Branches shorter than the solid is deep where they
//! join are pruned (bumps, not limbs), and the positions are smoothed along the tree.
//!
//! Known limits: a limb that touches the body (an arm against the side) is one with it; a limb
//! thinner than a voxel is lost with its voxels.

use super::voxels::Voxels;
use glam::DVec3;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// The penalty's scale and power (TEASAR's values).
const PENALTY_SCALE: f64 = 5000.0;
const PENALTY_POWER: i32 = 16;
/// Voxels within `COVER_SCALE * depth + COVER_ADD` of a path are covered by it.
const COVER_SCALE: f64 = 2.0;
const COVER_ADD: f64 = 1.0;
/// A leaf branch is kept when longer than `PRUNE_SCALE` times the depth where it joins, plus
/// `PRUNE_ADD` voxels.
const PRUNE_SCALE: f64 = 1.5;
const PRUNE_ADD: f64 = 2.0;
/// Most extremities followed (a noisy surface would add a branch per bump).
const MAX_BRANCHES: usize = 400;

/// An undirected tree of centre points.
#[derive(Debug, Clone)]
pub(crate) struct Tree {
    /// Unit frame.
    pub pos: Vec<DVec3>,
    /// Distance to the surface (unit frame).
    pub radius: Vec<f64>,
    pub adj: Vec<Vec<usize>>,
}

impl Tree {
    /// The node farthest from the surface (the middle of the body); 0 for an empty tree.
    pub fn deepest(&self) -> usize {
        (0..self.pos.len()).max_by(|&a, &b| self.radius[a].total_cmp(&self.radius[b])).unwrap_or(0)
    }

    pub fn leaves(&self) -> Vec<usize> {
        (0..self.pos.len()).filter(|&i| self.adj[i].len() == 1).collect()
    }

    /// The nodes of the path from `a` to `b`, both included.
    pub fn path(&self, a: usize, b: usize) -> Vec<usize> {
        let parent = self.parents_from(b);
        let mut out = vec![a];
        let mut x = a;
        while x != b {
            x = parent[x];
            if x == usize::MAX {
                return vec![a];
            }
            out.push(x);
        }
        out
    }

    /// The length of the path from `a` to `b`.
    pub fn path_length(&self, a: usize, b: usize) -> f64 {
        self.path(a, b).windows(2).map(|w| (self.pos[w[1]] - self.pos[w[0]]).length()).sum()
    }

    /// Distances along the tree from `a` to every node (`INFINITY` where unreached).
    pub fn distances_from(&self, a: usize) -> Vec<f64> {
        let mut dist = vec![f64::INFINITY; self.pos.len()];
        dist[a] = 0.0;
        let mut stack = vec![a];
        while let Some(x) = stack.pop() {
            for &y in &self.adj[x] {
                if dist[y].is_infinite() {
                    dist[y] = dist[x] + (self.pos[y] - self.pos[x]).length();
                    stack.push(y);
                }
            }
        }
        dist
    }

    /// Where the paths between `a`, `b` and `c` meet.
    pub fn median(&self, a: usize, b: usize, c: usize) -> usize {
        let ab = self.path(a, b);
        let on_ac: std::collections::HashSet<usize> = self.path(a, c).into_iter().collect();
        *ab.iter().rev().find(|n| on_ac.contains(n)).unwrap_or(&a)
    }

    fn parents_from(&self, root: usize) -> Vec<usize> {
        let mut parent = vec![usize::MAX; self.pos.len()];
        parent[root] = root;
        let mut stack = vec![root];
        while let Some(x) = stack.pop() {
            for &y in &self.adj[x] {
                if parent[y] == usize::MAX {
                    parent[y] = x;
                    stack.push(y);
                }
            }
        }
        parent
    }
}

/// The centre-line tree of the largest inside part of `vox`; `None` when nothing is inside.
pub(crate) fn centre_tree(vox: &Voxels) -> Option<Tree> {
    let n = vox.inside.len();
    let part = largest_part(vox)?;
    let deepest = *part.iter().max_by(|&&a, &&b| vox.depth[a].total_cmp(&vox.depth[b]))?;
    let (from_deepest, _) = dijkstra(vox, deepest, |_| 1.0);
    let root = *part.iter().max_by(|&&a, &&b| from_deepest[a].total_cmp(&from_deepest[b]))?;
    let max_depth = vox.depth[deepest] as f64;
    let (length, _) = dijkstra(vox, root, |_| 1.0);
    let (_, parent) = dijkstra(vox, root, |v| {
        let t = 1.0 - vox.depth[v] as f64 / max_depth;
        1.0 + PENALTY_SCALE * t.powi(PENALTY_POWER)
    });

    let mut order = part.clone();
    order.sort_by(|&a, &b| length[b].total_cmp(&length[a]));
    let mut covered = vec![false; n];
    let mut on_tree = vec![false; n];
    on_tree[root] = true;
    let mut edges: Vec<(usize, usize)> = Vec::new();
    let mut branches = 0;
    cover(vox, root, &mut covered);
    for &target in &order {
        if covered[target] || branches >= MAX_BRANCHES {
            continue;
        }
        branches += 1;
        let mut x = target;
        while !on_tree[x] {
            on_tree[x] = true;
            cover(vox, x, &mut covered);
            let p = parent[x];
            if p == usize::MAX || p == x {
                break;
            }
            edges.push((x, p));
            x = p;
        }
    }
    // Compact the tree.
    let mut id = vec![usize::MAX; n];
    let mut tree = Tree { pos: Vec::new(), radius: Vec::new(), adj: Vec::new() };
    for v in (0..n).filter(|&v| on_tree[v]) {
        id[v] = tree.pos.len();
        tree.pos.push(vox.centre(v));
        tree.radius.push(vox.depth[v] as f64 * vox.step);
        tree.adj.push(Vec::new());
    }
    for (a, b) in edges {
        tree.adj[id[a]].push(id[b]);
        tree.adj[id[b]].push(id[a]);
    }
    let tree = prune(tree, vox.step);
    Some(smooth(tree, 4))
}

/// Inside voxels of the largest 26-connected part.
fn largest_part(vox: &Voxels) -> Option<Vec<usize>> {
    let n = vox.inside.len();
    let mut label = vec![u32::MAX; n];
    let mut best: Vec<usize> = Vec::new();
    for s in 0..n {
        if !vox.inside[s] || label[s] != u32::MAX {
            continue;
        }
        label[s] = s as u32;
        let mut part = vec![s];
        let mut i = 0;
        while i < part.len() {
            let v = part[i];
            i += 1;
            for (w, _) in neighbours(vox, v) {
                if label[w] == u32::MAX {
                    label[w] = s as u32;
                    part.push(w);
                }
            }
        }
        if part.len() > best.len() {
            best = part;
        }
    }
    (!best.is_empty()).then_some(best)
}

/// Inside 26-neighbours of `v` with the edge length (voxels).
pub(super) fn neighbours(vox: &Voxels, v: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
    let [i, j, k] = vox.coords(v);
    let d = vox.dims;
    (0..27usize).filter_map(move |c| {
        let (di, dj, dk) = ((c % 3) as isize - 1, ((c / 3) % 3) as isize - 1, (c / 9) as isize - 1);
        if di == 0 && dj == 0 && dk == 0 {
            return None;
        }
        let (x, y, z) = (i as isize + di, j as isize + dj, k as isize + dk);
        if x < 0 || y < 0 || z < 0 || x >= d[0] as isize || y >= d[1] as isize || z >= d[2] as isize {
            return None;
        }
        let w = vox.index([x as usize, y as usize, z as usize]);
        vox.inside[w].then(|| (w, ((di * di + dj * dj + dk * dk) as f64).sqrt()))
    })
}

/// Shortest paths from `source` over inside voxels, an edge costing its length times
/// `weight(to)`: (distance, parent) per voxel (`INFINITY` / `usize::MAX` when unreached).
fn dijkstra(vox: &Voxels, source: usize, weight: impl Fn(usize) -> f64) -> (Vec<f64>, Vec<usize>) {
    let n = vox.inside.len();
    let mut dist = vec![f64::INFINITY; n];
    let mut parent = vec![usize::MAX; n];
    let mut heap = BinaryHeap::new();
    dist[source] = 0.0;
    parent[source] = source;
    heap.push(Reverse((Ordered(0.0), source)));
    while let Some(Reverse((Ordered(d), v))) = heap.pop() {
        if d > dist[v] {
            continue;
        }
        for (w, len) in neighbours(vox, v) {
            let nd = d + len * weight(w);
            if nd < dist[w] {
                dist[w] = nd;
                parent[w] = v;
                heap.push(Reverse((Ordered(nd), w)));
            }
        }
    }
    (dist, parent)
}

/// Mark every inside voxel within the cover radius of `v`.
fn cover(vox: &Voxels, v: usize, covered: &mut [bool]) {
    let r = COVER_SCALE * vox.depth[v] as f64 + COVER_ADD;
    let ri = r.ceil() as isize;
    let [i, j, k] = vox.coords(v);
    let d = vox.dims;
    for dk in -ri..=ri {
        let z = k as isize + dk;
        if z < 0 || z >= d[2] as isize {
            continue;
        }
        for dj in -ri..=ri {
            let y = j as isize + dj;
            if y < 0 || y >= d[1] as isize {
                continue;
            }
            for di in -ri..=ri {
                let x = i as isize + di;
                if x < 0 || x >= d[0] as isize || ((di * di + dj * dj + dk * dk) as f64) > r * r {
                    continue;
                }
                covered[vox.index([x as usize, y as usize, z as usize])] = true;
            }
        }
    }
}

/// Remove leaf branches shorter than the depth where they join, until none is left.
fn prune(mut t: Tree, step: f64) -> Tree {
    let mut alive = vec![true; t.pos.len()];
    loop {
        let mut changed = false;
        for leaf in 0..t.pos.len() {
            if !alive[leaf] || t.adj[leaf].iter().filter(|&&y| alive[y]).count() != 1 {
                continue;
            }
            // Walk to the junction.
            let mut branch = vec![leaf];
            let (mut prev, mut x) = (leaf, t.adj[leaf].iter().copied().find(|&y| alive[y]).unwrap());
            let mut length = (t.pos[x] - t.pos[prev]).length();
            loop {
                let next: Vec<usize> = t.adj[x].iter().copied().filter(|&y| alive[y] && y != prev).collect();
                if next.len() != 1 {
                    break;
                }
                branch.push(x);
                length += (t.pos[next[0]] - t.pos[x]).length();
                prev = x;
                x = next[0];
            }
            let degree = t.adj[x].iter().filter(|&&y| alive[y]).count();
            if degree < 3 {
                continue; // the whole tree is one path
            }
            if length < PRUNE_SCALE * t.radius[x] + PRUNE_ADD * step {
                for b in branch {
                    alive[b] = false;
                }
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let mut id = vec![usize::MAX; t.pos.len()];
    let mut out = Tree { pos: Vec::new(), radius: Vec::new(), adj: Vec::new() };
    for v in (0..t.pos.len()).filter(|&v| alive[v]) {
        id[v] = out.pos.len();
        out.pos.push(t.pos[v]);
        out.radius.push(t.radius[v]);
        out.adj.push(Vec::new());
    }
    for v in 0..t.pos.len() {
        if alive[v] {
            let adj = std::mem::take(&mut t.adj[v]);
            out.adj[id[v]] = adj.into_iter().filter(|&y| alive[y]).map(|y| id[y]).collect();
        }
    }
    out
}

/// Average each path node with its two neighbours, `rounds` times (leaves and junctions stay).
fn smooth(mut t: Tree, rounds: usize) -> Tree {
    for _ in 0..rounds {
        let next: Vec<DVec3> = (0..t.pos.len())
            .map(|v| match t.adj[v].as_slice() {
                [a, b] => (t.pos[v] * 2.0 + t.pos[*a] + t.pos[*b]) / 4.0,
                _ => t.pos[v],
            })
            .collect();
        t.pos = next;
    }
    t
}

/// `f64` ordered for the heap (no NaN here).
#[derive(Clone, Copy, PartialEq)]
struct Ordered(f64);
impl Eq for Ordered {}
impl PartialOrd for Ordered {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Ordered {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}
