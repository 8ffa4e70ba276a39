//! Ray casting against a triangle mesh, for the bone-heat visibility test and for skeleton
//! fitting (all hits along a ray).
//!
//! A small self-contained bounding volume hierarchy (median split on the longest centroid
//! axis, up to 4 triangles per leaf) with any-hit segment queries and Moller & Trumbore 1997
//! ray/triangle tests. (parry3d's `TriMesh` needs its `alloc` feature, which the crate does
//! not enable; this BVH is also tailored for the any-hit query that the heat solver needs.)

use crate::cotan::DEGENERATE_RATIO;
use glam::Vec3;
use rayon::prelude::*;

const LEAF_SIZE: usize = 4;
/// Barycentric tolerance of the ray/triangle test.
const BARY_EPS: f32 = 1e-5;

#[derive(Clone, Copy, Debug)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// Leaf: first triangle; inner: node count of the left subtree (preorder layout: the left
    /// child is at `self + 1`, the right one at `self + 1 + first`).
    first: u32,
    /// Leaf: triangle count (> 0); inner: 0.
    count: u32,
}

/// A triangle mesh prepared for ray queries. Never fails to build: zero-area, degenerate,
/// non-finite and out-of-range triangles are dropped first, and if nothing is left every
/// query reports "nothing in the way".
pub struct RayMesh {
    nodes: Vec<Node>,
    /// Per kept triangle (in BVH order): vertex 0, edge 0->1, edge 0->2.
    tris: Vec<[Vec3; 3]>,
}

impl RayMesh {
    /// Build the BVH.
    ///
    /// Inputs: `vertices` `(n, 3)` (any unit; queries use the same unit), `triangles` `(m, 3)`.
    /// O(m log m), parallel over subtrees.
    pub fn new(vertices: &[[f32; 3]], triangles: &[[u32; 3]]) -> RayMesh {
        let n = vertices.len();
        let tris: Vec<[Vec3; 3]> = triangles
            .par_iter()
            .with_min_len(4096)
            .filter_map(|t| {
                if t.iter().any(|&i| i as usize >= n) {
                    return None;
                }
                let [a, b, c] = t.map(|i| Vec3::from_array(vertices[i as usize]));
                if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                    return None;
                }
                let (e1, e2) = (b - a, c - a);
                let twice_area = e1.cross(e2).length();
                let longest = e1
                    .length_squared()
                    .max(e2.length_squared())
                    .max((c - b).length_squared());
                (twice_area > (DEGENERATE_RATIO as f32) * longest && twice_area > f32::MIN_POSITIVE)
                    .then_some([a, e1, e2])
            })
            .collect();
        let m = tris.len();
        if m == 0 || m > u32::MAX as usize / 2 {
            return RayMesh { nodes: Vec::new(), tris: Vec::new() };
        }
        // Per-triangle boxes and centroids.
        let boxes: Vec<(Vec3, Vec3, Vec3)> = tris
            .par_iter()
            .with_min_len(4096)
            .map(|t| {
                let (a, b, c) = (t[0], t[0] + t[1], t[0] + t[2]);
                (a.min(b).min(c), a.max(b).max(c), (a + b + c) * (1.0 / 3.0))
            })
            .collect();
        let mut sizes = std::collections::HashMap::new();
        subtree_nodes(m, &mut sizes);
        let mut nodes = vec![Node { min: Vec3::ZERO, max: Vec3::ZERO, first: 0, count: 0 }; sizes[&m]];
        let mut order: Vec<u32> = (0..m as u32).collect();
        build(&mut nodes, &mut order, 0, &boxes, &sizes);
        let tris = order.par_iter().with_min_len(4096).map(|&i| tris[i as usize]).collect();
        RayMesh { nodes, tris }
    }

    /// Number of triangles kept for ray casting.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// `true` if some triangle crosses the closed segment `from`-`to` (both ends included;
    /// shorten the segment yourself to ignore surfaces touching an end point).
    /// A zero-length or non-finite segment is never blocked.
    pub fn segment_blocked(&self, from: Vec3, to: Vec3) -> bool {
        let dir = to - from;
        if self.nodes.is_empty() || !(dir.length_squared() > 0.0) || !from.is_finite() || !to.is_finite() {
            return false;
        }
        let mut hit = false;
        self.traverse(from, dir, 1.0, |t| {
            hit = t.is_some();
            hit
        });
        hit
    }

    /// All hit distances along a ray, sorted ascending.
    ///
    /// Inputs: `origin`, `dir` (need not be unit length; zero -> no hits), `max_dist` in the
    /// mesh unit measured along the normalized direction. Output: distances in `[0, max_dist]`;
    /// a ray through a shared edge or vertex may report (nearly) the same distance twice.
    pub fn ray_hits(&self, origin: Vec3, dir: Vec3, max_dist: f32) -> Vec<f32> {
        let len = dir.length();
        let mut hits = Vec::new();
        if self.nodes.is_empty() || !(len > 0.0) || !len.is_finite() || !origin.is_finite() || !(max_dist >= 0.0) {
            return hits;
        }
        self.traverse(origin, dir / len, max_dist.min(f32::MAX), |t| {
            if let Some(t) = t {
                hits.push(t);
            }
            false
        });
        hits.sort_by(|a, b| a.total_cmp(b));
        hits
    }

    /// Visit every triangle hit by `origin + t dir`, `t in [0, tmax]`; `visit(Some(t))` per hit
    /// (`visit(None)` never happens); stop as soon as `visit` returns true.
    fn traverse(&self, origin: Vec3, dir: Vec3, tmax: f32, mut visit: impl FnMut(Option<f32>) -> bool) {
        let inv = dir.recip();
        let mut stack = [0u32; 64];
        let mut sp = 1usize;
        stack[0] = 0;
        while sp > 0 {
            sp -= 1;
            let at = stack[sp];
            let node = &self.nodes[at as usize];
            if !slab(node.min, node.max, origin, inv, tmax) {
                continue;
            }
            if node.count > 0 {
                let s = node.first as usize;
                for tri in &self.tris[s..s + node.count as usize] {
                    if let Some(t) = ray_triangle(origin, dir, tri, tmax) {
                        if visit(Some(t)) {
                            return;
                        }
                    }
                }
            } else if sp + 2 <= stack.len() {
                stack[sp] = at + 1 + node.first;
                stack[sp + 1] = at + 1;
                sp += 2;
            }
        }
    }
}

/// Number of nodes of the subtree over `m` triangles (median splits, leaves <= LEAF_SIZE),
/// memoized: only O(log m) distinct sizes occur.
fn subtree_nodes(m: usize, memo: &mut std::collections::HashMap<usize, usize>) -> usize {
    if let Some(&c) = memo.get(&m) {
        return c;
    }
    let c = if m <= LEAF_SIZE { 1 } else { 1 + subtree_nodes(m / 2, memo) + subtree_nodes(m - m / 2, memo) };
    memo.insert(m, c);
    c
}

/// Build the subtree over `order` (global offset `offset`) into `nodes` in preorder:
/// `nodes[0]` is the root, then the left subtree, then the right one.
fn build(
    nodes: &mut [Node],
        order: &mut [u32],
    offset: usize,
    boxes: &[(Vec3, Vec3, Vec3)],
    sizes: &std::collections::HashMap<usize, usize>,
) {
    let m = order.len();
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let (mut clo, mut chi) = (lo, hi);
    for &i in order.iter() {
        let (a, b, c) = boxes[i as usize];
        lo = lo.min(a);
        hi = hi.max(b);
        clo = clo.min(c);
        chi = chi.max(c);
    }
    // Pad by a relative epsilon so that rounding never lets a ray slip past a box.
    let pad = (hi - lo).max_element() * 1e-4 + 1e-30;
    nodes[0].min = lo - Vec3::splat(pad);
    nodes[0].max = hi + Vec3::splat(pad);
    if m <= LEAF_SIZE {
        nodes[0].first = offset as u32;
        nodes[0].count = m as u32;
        return;
    }
    let ext = chi - clo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z { 0 } else if ext.y >= ext.z { 1 } else { 2 };
    let mid = m / 2;
    order.select_nth_unstable_by(mid, |&a, &b| boxes[a as usize].2[axis].total_cmp(&boxes[b as usize].2[axis]));
    let nl = sizes[&mid];
    nodes[0].first = nl as u32;
    nodes[0].count = 0;
    let (_, rest) = nodes.split_at_mut(1);
    let (nleft, nright) = rest.split_at_mut(nl);
    let (ol, or) = order.split_at_mut(mid);
    if m > 8192 {
        rayon::join(
            || build(nleft, ol, offset, boxes, sizes),
            || build(nright, or, offset + mid, boxes, sizes),
        );
    } else {
        build(nleft, ol, offset, boxes, sizes);
        build(nright, or, offset + mid, boxes, sizes);
    }
}

/// Ray/box slab test for `t in [0, tmax]`.
#[inline]
fn slab(min: Vec3, max: Vec3, origin: Vec3, inv: Vec3, tmax: f32) -> bool {
    let t1 = (min - origin) * inv;
    let t2 = (max - origin) * inv;
    // NaN (0 * inf) appears only when the origin lies on a slab plane of a parallel axis;
    // min/max of glam propagate the other operand, which keeps the test conservative.
    let tnear = t1.min(t2).max_element().max(0.0);
    let tfar = t1.max(t2).min_element().min(tmax);
    tnear <= tfar
}

/// Moller & Trumbore 1997, two-sided, `t in [0, tmax]`. The triangle is grown by `BARY_EPS` in
/// barycentric terms so that a ray through a shared edge or vertex can never slip between
/// the two triangles (a watertight answer matters more than an exact silhouette here).
#[inline]
fn ray_triangle(origin: Vec3, dir: Vec3, tri: &[Vec3; 3], tmax: f32) -> Option<f32> {
    let [a, e1, e2] = *tri;
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() <= f32::MIN_POSITIVE {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - a;
    let u = s.dot(p) * inv;
    if !(-BARY_EPS..=1.0 + BARY_EPS).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    if v < -BARY_EPS || u + v > 1.0 + BARY_EPS {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t >= 0.0 && t <= tmax).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_cube() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let v: Vec<[f32; 3]> = (0..8)
            .map(|i| [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32])
            .collect();
        let q = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
        let t = q.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        (v, t)
    }

    #[test]
    fn blocked_and_hits() {
        let (v, t) = unit_cube();
        let mut t2 = t.clone();
        t2.push([0, 0, 1]); // degenerate, dropped
        t2.push([0, 1, 99]); // out of range, dropped
        let rm = RayMesh::new(&v, &t2);
        assert_eq!(rm.triangle_count(), 12);
        let inside = Vec3::splat(0.5);
        assert!(!rm.segment_blocked(inside, Vec3::new(0.5, 0.5, 0.9)));
        assert!(rm.segment_blocked(inside, Vec3::new(0.5, 0.5, 1.5)));
        assert!(rm.segment_blocked(Vec3::new(0.3, 0.2, -1.0), Vec3::new(0.3, 0.2, 3.0)));
        let hits = rm.ray_hits(Vec3::new(0.5, 0.4, -1.0), Vec3::new(0.0, 0.0, 2.0), 10.0);
        assert_eq!(hits.len(), 2);
        assert!((hits[0] - 1.0).abs() < 1e-5 && (hits[1] - 2.0).abs() < 1e-5);
        assert_eq!(rm.ray_hits(Vec3::new(0.5, 0.4, -1.0), Vec3::Z, 1.5).len(), 1);
        let empty = RayMesh::new(&v, &[[0, 0, 0]]);
        assert!(!empty.segment_blocked(inside, Vec3::splat(5.0)));
        assert!(empty.ray_hits(inside, Vec3::X, 1.0).is_empty());
    }

    /// Many random segments against a brute-force answer.
    #[test]
    fn bvh_matches_brute_force() {
        let (v0, t0) = unit_cube();
        // Several shifted cubes so the tree has depth.
        let mut v = Vec::new();
        let mut t = Vec::new();
        for k in 0..20u32 {
            let off = [(k % 5) as f32 * 1.3, (k / 5) as f32 * 1.1, (k % 3) as f32 * 0.7];
            let base = v.len() as u32;
            v.extend(v0.iter().map(|p| [p[0] + off[0], p[1] + off[1], p[2] + off[2]]));
            t.extend(t0.iter().map(|tr| tr.map(|i| i + base)));
        }
        let rm = RayMesh::new(&v, &t);
        let mut seed = 12345u32;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32 * 7.0 - 1.0
        };
        for _ in 0..500 {
            let a = Vec3::new(rnd(), rnd(), rnd());
            let b = Vec3::new(rnd(), rnd(), rnd());
            let brute = t.iter().any(|tr| {
                let [p, q, r] = tr.map(|i| Vec3::from_array(v[i as usize]));
                ray_triangle(a, b - a, &[p, q - p, r - p], 1.0).is_some()
            });
            assert_eq!(rm.segment_blocked(a, b), brute);
        }
    }
}
