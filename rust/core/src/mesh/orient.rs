//! Consistent face winding (libigl's `bfs_orient`): imported and hand-edited meshes often
//! carry flipped faces, whose vertex normals then point inward and would hide the bones
//! behind them from Blender's normal-weighted bone distance; and the outward vertex normals
//! that distance uses.

use glam::DVec3;
use rayon::prelude::*;

/// No neighbour across an edge.
const NONE: u32 = u32::MAX;

/// Orient `triangles` `(m, 3)` so that, within each *patch* (triangles connected through
/// manifold edges, i.e. edges used by exactly two triangles), every shared edge is walked
/// once in each direction.
///
/// Breadth-first from each patch's first triangle; a patch then keeps the winding of the
/// majority of its input triangles (which way is *outward* is the caller's decision: the
/// sign of the enclosed volume, say). Edges used by one or by three or more triangles do not
/// connect patches. A non-orientable patch (a Moebius strip) keeps the breadth-first winding,
/// consistent everywhere but along one cut. `n` is the vertex count (indices `>= n` are
/// ignored). Output: the oriented triangles (same order, a
/// flipped triangle is `[a, c, b]`) and how many were flipped. O(m x vertex degree).
pub fn orient_faces(n: usize, triangles: &[[u32; 3]]) -> (Vec<[u32; 3]>, usize) {
    let m = triangles.len();
    // Triangles around each vertex (CSR); indices >= n are ignored.
    let mut vstart = vec![0u32; n + 1];
    for t in triangles {
        for &i in t.iter().filter(|&&i| (i as usize) < n) {
            vstart[i as usize + 1] += 1;
        }
    }
    for v in 0..n {
        vstart[v + 1] += vstart[v];
    }
    let mut fill = vstart.clone();
    let mut around = vec![0u32; vstart[n] as usize];
    for (t, tri) in triangles.iter().enumerate() {
        for &i in tri.iter().filter(|&&i| (i as usize) < n) {
            around[fill[i as usize] as usize] = t as u32;
            fill[i as usize] += 1;
        }
    }
    drop(fill);
    // Per triangle edge k (from corner k to k + 1): the one other triangle on that edge, and
    // whether it walks the edge the same way (then exactly one of the two must be flipped);
    // `NONE` on boundary and non-manifold edges.
    let adj: Vec<[(u32, bool); 3]> = triangles
        .par_iter()
        .enumerate()
        .with_min_len(4096)
        .map(|(t, tri)| {
            std::array::from_fn(|k| {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if a as usize >= n || b as usize >= n {
                    return (NONE, false);
                }
                let (mut other, mut same, mut count) = (NONE, false, 0);
                for &u in &around[vstart[a as usize] as usize..vstart[a as usize + 1] as usize] {
                    let ut = triangles[u as usize];
                    if u as usize == t || !ut.contains(&b) {
                        continue;
                    }
                    count += 1;
                    if count > 1 {
                        // Non-manifold already: a triangle repeated many times would make this
                        // loop quadratic in the repeats.
                        break;
                    }
                    let p = ut.iter().position(|&i| i == a).unwrap_or(0);
                    (other, same) = (u, ut[(p + 1) % 3] == b);
                }
                if count == 1 {
                    (other, same)
                } else {
                    (NONE, false)
                }
            })
        })
        .collect();
    drop(around);

    // Breadth-first per patch; 0 = not reached, 1 = kept, 2 = flipped.
    let mut state = vec![0u8; m];
    let mut queue: Vec<u32> = Vec::new();
    let mut flipped = 0usize;
    for seed in 0..m {
        if state[seed] != 0 {
            continue;
        }
        queue.clear();
        queue.push(seed as u32);
        state[seed] = 1;
        let mut head = 0;
        while head < queue.len() {
            let t = queue[head] as usize;
            head += 1;
            for &(nb, same) in &adj[t] {
                if nb != NONE && state[nb as usize] == 0 {
                    let flip = (state[t] == 2) ^ same;
                    state[nb as usize] = if flip { 2 } else { 1 };
                    queue.push(nb);
                }
            }
        }
        let patch_flipped = queue.iter().filter(|&&t| state[t as usize] == 2).count();
        if 2 * patch_flipped > queue.len() {
            for &t in &queue {
                state[t as usize] = 3 - state[t as usize];
            }
            flipped += queue.len() - patch_flipped;
        } else {
            flipped += patch_flipped;
        }
    }
    let out = triangles
        .par_iter()
        .zip(state.par_iter())
        .with_min_len(4096)
        .map(|(t, &s)| if s == 2 { [t[0], t[2], t[1]] } else { *t })
        .collect();
    (out, flipped)
}

/// Unit area-weighted vertex normals (zero for vertices in no triangle), oriented outward
/// per piece: a piece whose signed volume is negative ([`piece_volumes`]) has its normals
/// flipped.
pub(crate) fn vertex_normals(wpos: &[DVec3], tris: &[[u32; 3]], labels: &[u32], npieces: usize) -> Vec<DVec3> {
    let mut n = vec![DVec3::ZERO; wpos.len()];
    for t in tris {
        let [a, b, c] = t.map(|i| wpos[i as usize]);
        let f = (b - a).cross(c - a);
        for &i in t {
            n[i as usize] += f;
        }
    }
    let vol = piece_volumes(wpos, tris, labels, npieces);
    n.par_iter_mut().zip(labels.par_iter()).with_min_len(4096).for_each(|(n, &l)| {
        let s = if vol[l as usize] < 0.0 { -1.0 } else { 1.0 };
        *n = (*n * s).normalize_or_zero();
    });
    n
}

/// Six times the signed volume each piece's triangles enclose (`labels` `(nw,)`: the piece of
/// each vertex, `< npieces`), about the corner of the piece's bounding box (exact for a closed
/// piece; for an open one it depends on that corner): positive when the triangles wind
/// outward.
pub(crate) fn piece_volumes(wpos: &[DVec3], tris: &[[u32; 3]], labels: &[u32], npieces: usize) -> Vec<f64> {
    let mut vol = vec![0.0f64; npieces];
    let mut lo = vec![DVec3::splat(f64::INFINITY); npieces];
    for (v, &l) in labels.iter().enumerate() {
        lo[l as usize] = lo[l as usize].min(wpos[v]);
    }
    for t in tris {
        let [a, b, c] = t.map(|i| wpos[i as usize]);
        let r = lo[labels[t[0] as usize] as usize];
        vol[labels[t[0] as usize] as usize] += (a - r).dot((b - r).cross(c - r));
    }
    vol
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::primitives::capped_cylinder;
    use std::collections::HashMap;

    /// Every edge used by two triangles is walked once each way.
    fn consistent(tris: &[[u32; 3]]) -> bool {
        let mut count: HashMap<(u32, u32), i32> = HashMap::new();
        for t in tris {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *count.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
            }
        }
        count.values().all(|&c| c.abs() <= 1)
    }

    #[test]
    fn flipped_faces_are_turned_back_and_the_majority_wins() {
        let (v, t) = capped_cylinder(0.5, 2.0, 12, 10);
        let n = v.len();
        assert!(consistent(&t));
        let mut bad = t.clone();
        for tri in bad.iter_mut().step_by(3) {
            tri.swap(1, 2);
        }
        assert!(!consistent(&bad));
        let (fixed, flipped) = orient_faces(n, &bad);
        assert_eq!(fixed, t);
        assert_eq!(flipped, t.len().div_ceil(3));
        // Already consistent: nothing changes; all inverted: stays inverted (the majority).
        assert_eq!(orient_faces(n, &t), (t.clone(), 0));
        let inverted: Vec<[u32; 3]> = t.iter().map(|x| [x[0], x[2], x[1]]).collect();
        assert_eq!(orient_faces(n, &inverted), (inverted.clone(), 0));
    }

    #[test]
    fn non_manifold_edges_and_separate_pieces_are_left_as_they_are() {
        // Three fins on one edge (0, 1): no fin is adjacent to another, so none is flipped.
        let fins = [[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        assert_eq!(orient_faces(5, &fins), (fins.to_vec(), 0));
        // Two separate triangles wound oppositely; a duplicate face pair (same edges twice).
        let two = [[0, 1, 2], [5, 4, 3], [6, 7, 8], [6, 7, 8]];
        assert_eq!(orient_faces(9, &two).1, 1);
        assert_eq!(orient_faces(0, &[]), (vec![], 0));
    }

    /// A triangle repeated many times (a fuzz input: 8192 copies made the edge search
    /// quadratic in the copies) makes its edges non-manifold; the rest orients as before.
    #[test]
    fn a_triangle_repeated_many_times_is_left_as_it_is() {
        let (v, t) = capped_cylinder(0.5, 2.0, 6, 8);
        let n = v.len();
        let mut bad = t.clone();
        bad[5].swap(1, 2);
        let start = bad.len();
        bad.extend(std::iter::repeat_n([n as u32, n as u32 + 1, n as u32 + 2], 50_000));
        let (fixed, flipped) = orient_faces(n + 3, &bad);
        assert_eq!(&fixed[..start], &t[..]);
        assert_eq!(&fixed[start..], &bad[start..]);
        assert_eq!(flipped, 1);
    }

    /// An open piece (a bowl, as a hat open at its rim) far from the origin of the frame gets
    /// outward normals whichever way it is wound: its signed volume is taken from a corner of
    /// its own box (from the origin, the missing lid's cone outweighed the bowl and flipped it).
    #[test]
    fn an_open_bowl_far_from_the_origin_gets_outward_normals() {
        let (r, centre, rings, segments) = (0.05, DVec3::new(0.0, 0.0, 0.5), 6u32, 16u32);
        let mut p = vec![centre - DVec3::Z * r];
        for k in 1..=rings {
            let polar = std::f64::consts::FRAC_PI_2 * k as f64 / rings as f64;
            for j in 0..segments {
                let a = std::f64::consts::TAU * j as f64 / segments as f64;
                p.push(centre + r * DVec3::new(polar.sin() * a.cos(), polar.sin() * a.sin(), -polar.cos()));
            }
        }
        let at = |k: u32, j: u32| 1 + (k - 1) * segments + j % segments;
        let mut t = Vec::new();
        for j in 0..segments {
            t.push([0, at(1, j + 1), at(1, j)]);
            for k in 1..rings {
                t.push([at(k, j), at(k, j + 1), at(k + 1, j + 1)]);
                t.push([at(k, j), at(k + 1, j + 1), at(k + 1, j)]);
            }
        }
        let flipped: Vec<[u32; 3]> = t.iter().map(|x| [x[0], x[2], x[1]]).collect();
        for tris in [t, flipped] {
            let n = vertex_normals(&p, &tris, &vec![0; p.len()], 1);
            for (v, (q, nv)) in p.iter().zip(&n).enumerate() {
                assert!(nv.dot(*q - centre) > 0.0, "vertex {v}: normal {nv} at {q}");
            }
        }
    }

    #[test]
    fn a_moebius_strip_is_consistent_but_along_one_cut() {
        // Strip of quads (2 triangles each) whose last edge is glued to the first, reversed.
        let n = 8u32;
        let mut tris = Vec::new();
        for i in 0..n {
            let (a, b) = (2 * i, 2 * i + 1);
            let (c, d) = if i + 1 == n { (1, 0) } else { (2 * i + 2, 2 * i + 3) };
            tris.push([a, c, b]);
            tris.push([b, c, d]);
        }
        let (out, _) = orient_faces(2 * n as usize, &tris);
        let mut count: HashMap<(u32, u32), i32> = HashMap::new();
        for t in &out {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *count.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
            }
        }
        assert_eq!(count.values().filter(|c| c.abs() == 2).count(), 1);
    }
}
