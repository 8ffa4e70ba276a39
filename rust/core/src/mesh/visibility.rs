//! Ray casting against a triangle mesh, for the bone-heat visibility test and for skeleton
//! fitting (all hits along a ray).
//!
//! Built on parry3d: its bounding volume hierarchy ([`Bvh`], binned SAH build, one triangle per
//! leaf) is traversed with [`Bvh::traverse`] (early exit for the any-hit segment test, full
//! traversal to collect every hit along a ray) and the triangles are tested with parry's
//! ray/triangle intersection ([`local_ray_intersection_with_triangle`]).
//!
//! Robustness (the one addition to parry): its ray/triangle test is exact in real arithmetic
//! but not watertight in floating point, so a ray passing *exactly* through an edge shared by
//! two triangles (or through a vertex) can, after rounding, miss both, and a bone would "see"
//! a vertex through a closed surface. Every triangle is therefore stored grown about its
//! centroid by the relative amount [`GROW`] (a band of about `GROW` times its size along its
//! edges; the BVH boxes are those of the grown triangles, padded by [`GROW`] of the mesh size).
//! A rounding gap is a few ulps wide, far narrower than that band, so nothing leaks through a
//! shared edge or vertex; the price is that a ray grazing within that band of a silhouette edge
//! counts as a hit.

use crate::mesh::cotan::DEGENERATE_RATIO;
use glam::Vec3;
use parry3d::bounding_volume::Aabb;
use parry3d::partitioning::{Bvh, BvhBuildStrategy, BvhNode, TraversalAction};
use parry3d::query::details::local_ray_intersection_with_triangle;
use parry3d::query::{PointQuery, PointQueryWithLocation, Ray};
use parry3d::shape::Triangle;
use rayon::prelude::*;

/// For each triangle, whether an earlier one has the same three vertices (in any order): a
/// repeat adds hits at the distances its first copy already gives (merged by every caller that
/// counts crossings, ignored by the any-hit test), and a mesh of one triangle repeated a
/// million times would put them all in one leaf of the hierarchy, every ray testing each.
fn repeated_triangles(triangles: &[[u32; 3]]) -> Vec<bool> {
    // Each triangle's vertices in increasing order, then its index: sorted, the copies of a
    // triangle are adjacent, the first one first.
    let mut keyed: Vec<([u32; 3], u32)> = triangles
        .par_iter()
        .enumerate()
        .map(|(k, t)| {
            let mut s = *t;
            s.sort_unstable();
            (s, k as u32)
        })
        .collect();
    keyed.par_sort_unstable();
    let mut repeated = vec![false; triangles.len()];
    for w in keyed.windows(2) {
        if w[0].0 == w[1].0 {
            repeated[w[1].1 as usize] = true;
        }
    }
    repeated
}

/// Relative growth of every triangle about its centroid (and padding of the BVH boxes,
/// relative to the mesh's bounding-box diagonal), see the module notes.
pub const GROW: f32 = 1e-5;

/// A triangle mesh prepared for ray queries. Never fails to build: zero-area, degenerate,
/// non-finite and out-of-range triangles are dropped first, and if nothing is left every
/// query reports "nothing in the way".
pub struct RayMesh {
    bvh: Bvh,
    /// Kept triangles, grown by [`GROW`]; the BVH leaf data indexes this.
    tris: Vec<[Vec3; 3]>,
    /// Input index of every kept triangle.
    orig: Vec<u32>,
    /// `(leaves + 1,)`: BVH leaf `l` holds the kept triangles `starts[l]..starts[l + 1]`.
    starts: Vec<u32>,
}

impl RayMesh {
    /// Build the (grown) triangle list and parry's BVH over it.
    ///
    /// Inputs: `vertices` `(n, 3)` (any unit; queries use the same unit), `triangles` `(m, 3)`.
    pub fn new(vertices: &[[f32; 3]], triangles: &[[u32; 3]]) -> RayMesh {
        let n = vertices.len();
        let repeated = repeated_triangles(triangles);
        let (tris, orig): (Vec<[Vec3; 3]>, Vec<u32>) = triangles
            .par_iter()
            .enumerate()
            .with_min_len(4096)
            .filter_map(|(k, t)| {
                if repeated[k] || t.iter().any(|&i| i as usize >= n) {
                    return None;
                }
                let [a, b, c] = t.map(|i| Vec3::from_array(vertices[i as usize]));
                if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                    return None;
                }
                let (e1, e2) = (b - a, c - a);
                let twice_area = e1.cross(e2).length();
                let longest = e1.length_squared().max(e2.length_squared()).max((c - b).length_squared());
                if !(twice_area > (DEGENERATE_RATIO as f32) * longest && twice_area > f32::MIN_POSITIVE) {
                    return None;
                }
                let g = (a + b + c) * (1.0 / 3.0);
                Some(([a, b, c].map(|p| g + (p - g) * (1.0 + GROW)), k as u32))
            })
            .unzip();
        if tris.is_empty() || triangles.len() > u32::MAX as usize {
            return RayMesh { bvh: Bvh::new(), tris: Vec::new(), orig: Vec::new(), starts: vec![0] };
        }
        let starts = quad_leaves(triangles, &orig);
        let boxes: Vec<(Vec3, Vec3)> = starts
            .par_windows(2)
            .with_min_len(2048)
            .map(|w| {
                tris[w[0] as usize..w[1] as usize]
                    .iter()
                    .fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(l, h), [a, b, c]| {
                        (l.min(a.min(*b).min(*c)), h.max(a.max(*b).max(*c)))
                    })
            })
            .collect();
        let (lo, hi) =
            boxes.iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(l, h), (a, b)| {
                (l.min(*a), h.max(*b))
            });
        let pad = Vec3::splat((hi - lo).length() * GROW + f32::MIN_POSITIVE);
        let bvh = Bvh::from_iter(
            BvhBuildStrategy::Binned,
            boxes.iter().enumerate().map(|(i, (a, b))| (i, Aabb::new(*a - pad, *b + pad))),
        );
        RayMesh { bvh, tris, orig, starts }
    }

    /// The kept triangles of BVH leaf `leaf`.
    #[inline]
    fn leaf(&self, leaf: u32) -> std::ops::Range<u32> {
        self.starts[leaf as usize]..self.starts[leaf as usize + 1]
    }

    /// Number of triangles kept for ray casting.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// `true` if some triangle crosses the closed segment `from`-`to` (both ends included;
    /// shorten the segment yourself to ignore surfaces touching an end point).
    /// A zero-length or non-finite segment is never blocked. Triangles count grown by
    /// [`GROW`] (see the module notes).
    pub fn segment_blocked(&self, from: Vec3, to: Vec3) -> bool {
        self.segment_blocked_where(from, to, |_| true)
    }

    /// [`segment_blocked`](Self::segment_blocked) by the input triangles `t` with `keep(t)`
    /// only (`t` indexes the `triangles` given to [`RayMesh::new`]).
    pub fn segment_blocked_where(&self, from: Vec3, to: Vec3, keep: impl Fn(u32) -> bool) -> bool {
        let dir = to - from;
        if self.tris.is_empty() || !(dir.length_squared() > 0.0) || !from.is_finite() || !to.is_finite() {
            return false;
        }
        let ray = Ray::new(from, dir);
        let inv = dir.recip();
        let mut hit = false;
        self.bvh.traverse(|node| {
            if !node_hit(node, from, inv, 1.0) {
                return TraversalAction::Prune;
            }
            if let Some(leaf) = node.leaf_data() {
                if self.leaf(leaf).any(|i| keep(self.orig[i as usize]) && self.triangle_hit(i, &ray, 1.0).is_some()) {
                    hit = true;
                    return TraversalAction::EarlyExit;
                }
            }
            TraversalAction::Continue
        });
        hit
    }

    /// All hit distances along a ray, sorted ascending.
    ///
    /// Inputs: `origin`, `dir` (need not be unit length; zero -> no hits), `max_dist` in the
    /// mesh unit measured along the normalized direction. Output: distances in `[0, max_dist]`;
    /// a ray through a shared edge or vertex may report (nearly) the same distance twice.
    pub fn ray_hits(&self, origin: Vec3, dir: Vec3, max_dist: f32) -> Vec<f32> {
        self.ray_hits_where(origin, dir, max_dist, |_| true)
    }

    /// [`ray_hits`](Self::ray_hits) restricted to the input triangles `t` with `keep(t)`
    /// (`t` indexes the `triangles` given to [`RayMesh::new`]).
    pub fn ray_hits_where(&self, origin: Vec3, dir: Vec3, max_dist: f32, keep: impl Fn(u32) -> bool) -> Vec<f32> {
        self.ray_hits_tagged(origin, dir, max_dist, keep).into_iter().map(|h| h.0).collect()
    }

    /// [`ray_hits_where`](Self::ray_hits_where) with the input triangle of every hit:
    /// `(distance, triangle)` pairs sorted by distance.
    pub fn ray_hits_tagged(
        &self,
        origin: Vec3,
        dir: Vec3,
        max_dist: f32,
        keep: impl Fn(u32) -> bool,
    ) -> Vec<(f32, u32)> {
        let len = dir.length();
        let mut hits = Vec::new();
        if self.tris.is_empty() || !(len > 0.0) || !len.is_finite() || !origin.is_finite() || !(max_dist >= 0.0) {
            return hits;
        }
        let dir = dir / len;
        let (ray, inv, tmax) = (Ray::new(origin, dir), dir.recip(), max_dist.min(f32::MAX));
        self.bvh.traverse(|node| {
            if !node_hit(node, origin, inv, tmax) {
                return TraversalAction::Prune;
            }
            if let Some(leaf) = node.leaf_data() {
                for i in self.leaf(leaf) {
                    let k = self.orig[i as usize];
                    if keep(k) {
                        if let Some(t) = self.triangle_hit(i, &ray, tmax) {
                            hits.push((t, k));
                        }
                    }
                }
            }
            TraversalAction::Continue
        });
        hits.sort_by(|a, b| a.0.total_cmp(&b.0));
        hits
    }

    /// Ray-parity inside test: along how many of `dirs` does the ray from `p` cross the
    /// triangles `t` with `keep(t)` an odd number of times?
    ///
    /// Hits closer than `merge` (mesh unit) to the previous one along the same ray are counted
    /// once (a ray through a shared edge meets both grown neighbours at the same distance).
    /// For a closed surface every direction agrees (odd = inside) up to rays grazing an edge;
    /// callers take a majority over a few generic directions.
    pub fn odd_parity_count(&self, p: Vec3, dirs: &[Vec3], merge: f32, keep: impl Fn(u32) -> bool) -> usize {
        dirs.iter()
            .filter(|&&d| {
                let hits = self.ray_hits_where(p, d, f32::MAX, &keep);
                let mut count = 0usize;
                let mut last = f32::NEG_INFINITY;
                for t in hits {
                    if t - last > merge {
                        count += 1;
                    }
                    last = t;
                }
                count % 2 == 1
            })
            .count()
    }

    /// `true` if some kept triangle comes within `tol` (mesh unit) of `p`. A nearest-surface
    /// test pruned by the BVH boxes (parry's point/triangle distance), stopping at the first
    /// triangle close enough. A non-finite `p` or negative `tol` is never near.
    pub fn near_surface(&self, p: Vec3, tol: f32) -> bool {
        if self.tris.is_empty() || !p.is_finite() || !(tol >= 0.0) {
            return false;
        }
        let mut near = false;
        self.bvh.traverse(|node| {
            let gap = (node.mins() - p).max(p - node.maxs()).max(Vec3::ZERO);
            if gap.length_squared() > tol * tol {
                return TraversalAction::Prune;
            }
            if let Some(leaf) = node.leaf_data() {
                let close = |i: u32| {
                    let [a, b, c] = self.tris[i as usize];
                    Triangle::new(a, b, c).distance_to_local_point(p, true) <= tol
                };
                if self.leaf(leaf).any(close) {
                    near = true;
                    return TraversalAction::EarlyExit;
                }
            }
            TraversalAction::Continue
        });
        near
    }

    /// The point of the mesh nearest to `p`, if one lies within `max_dist` (mesh unit):
    /// `(input triangle, distance, barycentric coordinates of the point on that triangle)`.
    /// The BVH prunes every box farther than the best so far; triangles count grown by
    /// [`GROW`], so the coordinates may stray outside `[0, 1]` by that much (they sum to 1).
    pub fn nearest_point(&self, p: Vec3, max_dist: f32) -> Option<(u32, f32, [f32; 3])> {
        if self.tris.is_empty() || !p.is_finite() || !(max_dist >= 0.0) {
            return None;
        }
        let mut best: Option<(u32, f32, [f32; 3])> = None;
        let mut limit = max_dist;
        self.bvh.traverse(|node| {
            let gap = (node.mins() - p).max(p - node.maxs()).max(Vec3::ZERO);
            if gap.length() > limit {
                return TraversalAction::Prune;
            }
            if let Some(leaf) = node.leaf_data() {
                for i in self.leaf(leaf) {
                    let [a, b, c] = self.tris[i as usize];
                    let (proj, loc) = Triangle::new(a, b, c).project_local_point_and_get_location(p, false);
                    let d = (proj.point - p).length();
                    if d <= limit && best.is_none_or(|x| d < x.1) {
                        let bary = loc.barycentric_coordinates().unwrap_or([1.0 / 3.0; 3]);
                        best = Some((self.orig[i as usize], d, bary));
                        limit = d;
                    }
                }
            }
            TraversalAction::Continue
        });
        best
    }

    /// parry's two-sided ray/triangle test on kept triangle `i`, `t in [0, tmax]` (units of
    /// `ray.dir`).
    #[inline]
    fn triangle_hit(&self, i: u32, ray: &Ray, tmax: f32) -> Option<f32> {
        let [a, b, c] = self.tris[i as usize];
        let (hit, _) = local_ray_intersection_with_triangle(a, b, c, ray)?;
        (hit.time_of_impact >= 0.0 && hit.time_of_impact <= tmax).then_some(hit.time_of_impact)
    }
}

/// BVH leaves over the kept triangles (`orig`: their input indices into `triangles`), as the
/// start of each leaf plus the end: two consecutive triangles that share an edge (a quad split
/// in two, as Blender's and glTF's triangulations put them) make one leaf, any other triangle
/// a leaf of its own. A quad's box is hardly larger than its halves', so rays meet about the
/// same triangles while parry builds its tree over half as many boxes (the build was the
/// slowest step before the rays).
fn quad_leaves(triangles: &[[u32; 3]], orig: &[u32]) -> Vec<u32> {
    let shares_edge = |a: [u32; 3], b: [u32; 3]| a.iter().filter(|i| b.contains(i)).count() >= 2;
    let mut starts = Vec::with_capacity(orig.len() / 2 + 2);
    let mut k = 0usize;
    while k < orig.len() {
        starts.push(k as u32);
        let pair = k + 1 < orig.len() && shares_edge(triangles[orig[k] as usize], triangles[orig[k + 1] as usize]);
        k += if pair { 2 } else { 1 };
    }
    starts.push(orig.len() as u32);
    starts
}

/// Does `origin + t dir`, `t in [0, tmax]`, meet the node's box? (`inv = 1 / dir`; the slab
/// test of `Aabb::cast_local_ray` without its per-axis divisions.)
#[inline]
fn node_hit(node: &BvhNode, origin: Vec3, inv: Vec3, tmax: f32) -> bool {
    let t1 = (node.mins() - origin) * inv;
    let t2 = (node.maxs() - origin) * inv;
    // NaN (0 * inf) appears only when the origin lies on a slab plane of a parallel axis;
    // glam's min/max then return the other operand, which keeps the test conservative.
    let near = t1.min(t2).max_element().max(0.0);
    let far = t1.max(t2).min_element().min(tmax);
    near <= far
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::primitives::capped_cylinder;

    /// The unit cube's surface, 8 vertices and 12 triangles (also for other modules' tests).
    pub(crate) fn unit_cube() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let v: Vec<[f32; 3]> = (0..8).map(|i| [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32]).collect();
        let q = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
        let t = q.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        (v, t)
    }

    #[test]
    fn blocked_and_hits() {
        let (mut v, t) = unit_cube();
        v.push([f32::NAN, 0.0, 0.0]);
        v.push([0.5, 0.5, 1e-13]);
        let mut t2 = t.clone();
        t2.push([0, 0, 1]); // degenerate, dropped
        t2.push([0, 1, 99]); // out of range, dropped
        t2.push([0, 1, 8]); // not finite, dropped
        t2.push([0, 3, 9]); // a sliver across the bottom face (area / longest^2 ~ 1e-13), dropped
        let rm = RayMesh::new(&v, &t2);
        assert_eq!(rm.triangle_count(), 12);
        let inside = Vec3::splat(0.5);
        // A zero-length segment is never blocked, even on the surface.
        assert!(!rm.segment_blocked(Vec3::new(0.5, 0.5, 0.0), Vec3::new(0.5, 0.5, 0.0)));
        assert!(!rm.segment_blocked(inside, Vec3::new(0.5, 0.5, 0.9)));
        assert!(rm.segment_blocked(inside, Vec3::new(0.5, 0.5, 1.5)));
        assert!(rm.segment_blocked(Vec3::new(0.3, 0.2, -1.0), Vec3::new(0.3, 0.2, 3.0)));
        let hits = rm.ray_hits(Vec3::new(0.5, 0.4, -1.0), Vec3::new(0.0, 0.0, 2.0), 10.0);
        assert_eq!(hits.len(), 2);
        assert!((hits[0] - 1.0).abs() < 1e-5 && (hits[1] - 2.0).abs() < 1e-5);
        assert_eq!(rm.ray_hits(Vec3::new(0.5, 0.4, -1.0), Vec3::Z, 1.5).len(), 1);
        let empty = RayMesh::new(&v, &[[0, 0, 0]]);
        assert_eq!(empty.triangle_count(), 0);
        assert!(!empty.segment_blocked(inside, Vec3::splat(5.0)));
        assert!(empty.ray_hits(inside, Vec3::X, 1.0).is_empty());
    }

    /// A triangle repeated (in any vertex order) is kept once: the hits are those of the mesh
    /// without the repeats, and a ray no longer tests every copy.
    #[test]
    fn repeated_triangles_are_kept_once() {
        let (v, t) = unit_cube();
        let mut many = t.clone();
        many.extend(std::iter::repeat_n([0, 1, 3], 100_000));
        many.push([3, 0, 1]);
        many.push([2, 3, 0]);
        let (once, rm) = (RayMesh::new(&v, &t), RayMesh::new(&v, &many));
        assert_eq!(rm.triangle_count(), 12);
        let (o, d) = (Vec3::new(0.3, 0.2, -1.0), Vec3::new(0.01, 0.02, 1.0));
        assert_eq!(rm.ray_hits(o, d, 10.0), once.ray_hits(o, d, 10.0));
        // The first copy stays, with its own index.
        let tagged = rm.ray_hits_tagged(o, d, 10.0, |_| true);
        assert!(tagged.iter().all(|&(_, k)| (k as usize) < t.len()), "{tagged:?}");
    }

    /// Many random segments against a brute-force answer with the same triangle test.
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
        let mut blocked = 0;
        for _ in 0..500 {
            let a = Vec3::new(rnd(), rnd(), rnd());
            let b = Vec3::new(rnd(), rnd(), rnd());
            let ray = Ray::new(a, b - a);
            let brute: Vec<f32> =
                (0..rm.triangle_count() as u32).filter_map(|i| rm.triangle_hit(i, &ray, 1.0)).collect();
            assert_eq!(rm.segment_blocked(a, b), !brute.is_empty());
            blocked += !brute.is_empty() as usize;
            // All hits along the (normalized) ray.
            let len = (b - a).length();
            let mut all = rm.ray_hits(a, b - a, len);
            let mut want: Vec<f32> = brute.iter().map(|t| t * len).collect();
            want.sort_by(|x, y| x.total_cmp(y));
            all.dedup_by(|x, y| (*x - *y).abs() < 1e-4);
            want.dedup_by(|x, y| (*x - *y).abs() < 1e-4);
            assert_eq!(all.len(), want.len());
            assert!(all.iter().zip(&want).all(|(x, y)| (x - y).abs() < 1e-4 * len.max(1.0)));
        }
        assert!(blocked > 100 && blocked < 500, "{blocked}");
    }

    /// Segments aimed exactly through shared edges and vertices of closed meshes (cube face
    /// diagonals, cube corners, every vertex and edge midpoint of a capped cylinder) must be
    /// blocked: nothing leaks through a closed surface.
    #[test]
    fn no_leak_through_shared_edges_and_vertices() {
        let (v, t) = unit_cube();
        let rm = RayMesh::new(&v, &t);
        let c = Vec3::splat(0.5);
        for target in [
            Vec3::new(0.5, 0.5, -1.0), // through the diagonal of the z = 0 face
            Vec3::new(0.5, 0.5, 2.0),
            Vec3::new(-1.0, 0.5, 0.5),
            Vec3::new(0.5, 2.0, 0.5),
            Vec3::new(-1.0, -1.0, -1.0), // through a corner
            Vec3::new(2.0, 2.0, 2.0),
            Vec3::new(0.5, -1.0, -1.0), // through an edge of the cube
        ] {
            assert!(rm.segment_blocked(c, target), "leak towards {target}");
            assert!(!rm.ray_hits(c, target - c, 10.0).is_empty(), "no hit towards {target}");
        }
        let (cv, ct) = capped_cylinder(0.3, 2.0, 17, 12);
        let rm = RayMesh::new(&cv, &ct);
        let mut targets: Vec<Vec3> = cv.iter().map(|p| Vec3::from_array(*p)).collect();
        for tr in &ct {
            for k in 0..3 {
                targets.push(
                    0.5 * (Vec3::from_array(cv[tr[k] as usize]) + Vec3::from_array(cv[tr[(k + 1) % 3] as usize])),
                );
            }
        }
        for p in targets {
            // From the axis point at the same height (or the cap centre) outward, past the surface.
            let from = Vec3::new(0.0, 0.0, p.z.clamp(0.01, 1.99));
            let to = from + (p - from) * 3.0;
            assert!(rm.segment_blocked(from, to), "leak through {p}");
        }
    }

    /// Consecutive triangles sharing an edge pair up into one leaf, others stay alone (input
    /// indices through `orig`, so a dropped triangle in between breaks a pair); rays still see
    /// every triangle, paired or not, and a shuffled triangle list (fewer pairs) answers the same.
    #[test]
    fn quads_pair_into_leaves() {
        let t = [[0, 1, 2], [0, 2, 3], [4, 5, 6], [7, 8, 9], [7, 9, 10], [3, 2, 11]];
        assert_eq!(quad_leaves(&t, &[0, 1, 2, 3, 4, 5]), vec![0, 2, 3, 5, 6]);
        assert_eq!(quad_leaves(&t, &[0, 2, 3, 4]), vec![0, 1, 2, 4]);
        let (v, t) = unit_cube();
        let shuffled: Vec<[u32; 3]> = [0, 6, 1, 8, 3, 11, 5, 2, 9, 4, 10, 7].iter().map(|&k| t[k]).collect();
        let (paired, single) = (RayMesh::new(&v, &t), RayMesh::new(&v, &shuffled));
        assert_eq!(paired.starts.len(), 7); // six quads
        assert!(single.starts.len() > 9, "{:?}", single.starts);
        let c = Vec3::splat(0.5);
        for target in [Vec3::new(0.5, 0.5, -1.0), Vec3::new(2.0, 2.0, 2.0), Vec3::new(-1.0, 0.3, 0.6)] {
            assert!(paired.segment_blocked(c, target) && single.segment_blocked(c, target), "{target}");
            let (o, d) = (c - (target - c), target - c);
            assert!(paired.ray_hits(o, d, 10.0).len() >= 2, "{target}"); // in and out
            assert_eq!(paired.ray_hits(o, d, 10.0), single.ray_hits(o, d, 10.0), "{target}");
            assert!(!paired.segment_blocked(c, c + (target - c) * 0.2));
        }
    }

    /// Distance to the surface against a brute-force minimum over the cube's faces.
    #[test]
    fn near_surface_matches_the_distance_to_the_cube() {
        let (v, t) = unit_cube();
        let rm = RayMesh::new(&v, &t);
        let dist = |p: Vec3| {
            let outside = (-p).max(p - Vec3::ONE).max(Vec3::ZERO).length();
            let inside = p.min(Vec3::ONE - p).min_element();
            if outside > 0.0 {
                outside
            } else {
                inside
            }
        };
        for p in [
            Vec3::splat(0.5),
            Vec3::new(0.5, 0.5, 1.05),
            Vec3::new(0.1, 0.5, 0.5),
            Vec3::splat(1.2),
            Vec3::splat(-0.01),
        ] {
            let d = dist(p);
            assert!(rm.near_surface(p, d + 1e-3), "{p}: {d}");
            assert!(!rm.near_surface(p, d - 1e-3), "{p}: {d}");
        }
        assert!(!rm.near_surface(Vec3::splat(f32::NAN), 1.0));
        assert!(!RayMesh::new(&v, &[[0, 0, 0]]).near_surface(Vec3::ZERO, 1.0));
    }

    /// Parity inside test and hits restricted to some triangles.
    #[test]
    fn parity_and_filtered_hits() {
        let (v0, t0) = unit_cube();
        // Two cubes: the second shifted by 3 along x.
        let mut v = v0.clone();
        v.extend(v0.iter().map(|p| [p[0] + 3.0, p[1], p[2]]));
        let mut t = t0.clone();
        t.extend(t0.iter().map(|tr| tr.map(|i| i + 8)));
        let rm = RayMesh::new(&v, &t);
        let dirs: Vec<Vec3> = [[0.48f32, 0.62, 0.62], [-0.7, 0.31, 0.64], [0.21, -0.89, 0.4]]
            .iter()
            .map(|d| Vec3::from_array(*d).normalize())
            .collect();
        let first = |k: u32| k < 12;
        assert_eq!(rm.odd_parity_count(Vec3::splat(0.5), &dirs, 1e-4, first), 3);
        assert_eq!(rm.odd_parity_count(Vec3::new(3.5, 0.5, 0.5), &dirs, 1e-4, first), 0);
        assert_eq!(rm.odd_parity_count(Vec3::new(3.5, 0.5, 0.5), &dirs, 1e-4, |k| k >= 12), 3);
        // Through the shared diagonal of a face: one crossing, not two.
        assert_eq!(rm.odd_parity_count(Vec3::splat(0.5), &[Vec3::new(0.0, 0.0, -1.0)], 1e-4, first), 1);
        // Along +x from inside the first cube: 1 wall of the first, 2 of the second.
        let o = Vec3::new(0.5, 0.3, 0.6);
        let along = rm.ray_hits(o, Vec3::X, 10.0);
        assert_eq!(along.len(), 3);
        assert_eq!(rm.ray_hits_where(o, Vec3::X, 10.0, |k| k >= 12).len(), 2);
    }
}
