//! Generated test meshes and skeletons (cargo tests, benches, and the Python test-suite).

use std::f32::consts::TAU;

use crate::{Error, Result};

/// A triangle mesh by value: `(vertices (n, 3), triangles (m, 3))`.
pub type Mesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// A closed box `[lo, hi]` appended to `(v, t)`: 8 vertices and 12 triangles wound outward
/// (indices offset by the vertices already in `v`), so several boxes make a mesh of pieces.
pub fn add_box(v: &mut Vec<[f32; 3]>, t: &mut Vec<[u32; 3]>, lo: [f32; 3], hi: [f32; 3]) {
    let o = v.len() as u32;
    for k in 0..8 {
        v.push([
            if k & 1 == 0 { lo[0] } else { hi[0] },
            if k & 2 == 0 { lo[1] } else { hi[1] },
            if k & 4 == 0 { lo[2] } else { hi[2] },
        ]);
    }
    for f in [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]] {
        t.push([o + f[0], o + f[1], o + f[2]]);
        t.push([o + f[0], o + f[2], o + f[3]]);
    }
}

/// Closed, watertight capped cylinder along +Z, outward-facing triangles.
///
/// Inputs: `radius`, `height` (any unit; non-finite or non-positive -> 1), `rings` vertex
/// rings from `z = 0` to `z = height` (clamped to >= 2), `segments` vertices per ring
/// (clamped to >= 3). Output `(vertices, triangles)`: `rings * segments + 2` vertices (the
/// rings, then the bottom and top cap centres) and `2 * segments * rings` triangles (side
/// quads split in two, plus a triangle fan per cap).
pub fn capped_cylinder(radius: f32, height: f32, rings: usize, segments: usize) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let pos = |x: f32| if x.is_finite() && x > 0.0 { x } else { 1.0 };
    let (radius, height) = (pos(radius), pos(height));
    let rings = rings.max(2);
    let s = segments.max(3);
    let mut v = Vec::with_capacity(rings * s + 2);
    for i in 0..rings {
        let z = height * i as f32 / (rings - 1) as f32;
        for j in 0..s {
            let a = TAU * j as f32 / s as f32;
            v.push([radius * a.cos(), radius * a.sin(), z]);
        }
    }
    let bottom = v.len() as u32;
    v.push([0.0, 0.0, 0.0]);
    let top = v.len() as u32;
    v.push([0.0, 0.0, height]);
    let idx = |i: usize, j: usize| (i * s + j % s) as u32;
    let mut t = Vec::with_capacity(2 * s * rings);
    for i in 0..rings - 1 {
        for j in 0..s {
            let (a, b, c, d) = (idx(i, j), idx(i, j + 1), idx(i + 1, j + 1), idx(i + 1, j));
            t.push([a, b, c]);
            t.push([a, c, d]);
        }
    }
    for j in 0..s {
        t.push([bottom, idx(0, j + 1), idx(0, j)]);
        t.push([top, idx(rings - 1, j), idx(rings - 1, j + 1)]);
    }
    (v, t)
}

/// Straight chain of `bones` (clamped to >= 1) equal bones along +Z from `0.025 height` to
/// `0.975 height`, i.e. slightly inside the caps of [`capped_cylinder`] of the same height.
/// Output `(heads, tails, parents)`, `parents[i] = i - 1` (`-1` for the root).
pub fn bone_chain(height: f32, bones: usize) -> (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<i32>) {
    let bones = bones.max(1);
    let (z0, z1) = (0.025 * height, 0.975 * height);
    let len = (z1 - z0) / bones as f32;
    let heads = (0..bones).map(|i| [0.0, 0.0, z0 + len * i as f32]).collect();
    let tails = (0..bones).map(|i| [0.0, 0.0, z0 + len * (i + 1) as f32]).collect();
    let parents = (0..bones as i32).map(|i| i - 1).collect();
    (heads, tails, parents)
}

/// Flat-shaded copy: every triangle gets its own three vertices, like a glTF export of a
/// flat-shaded mesh.
///
/// Inputs: `vertices` `(n, 3)`, `triangles` `(m, 3)` indices into `vertices`.
/// Output `(vertices, triangles)` with `3 m` vertices, the corners of triangle `i` at
/// `3i, 3i+1, 3i+2`, and triangle `i = [3i, 3i+1, 3i+2]`.
///
/// Errors: [`Error::BadIndex`] for the first triangle with an index `>= n` (no corner is
/// made up for it), [`Error::InvalidArgument`] when `3 m` does not fit a `u32` index.
pub fn split_flat(vertices: &[[f32; 3]], triangles: &[[u32; 3]]) -> Result<Mesh> {
    let n = vertices.len();
    if triangles.len() > u32::MAX as usize / 3 {
        return Err(Error::InvalidArgument(format!(
            "{} triangles: their 3 vertices each do not fit u32 indices",
            triangles.len()
        )));
    }
    if let Some(ti) = triangles.iter().position(|t| t.iter().any(|&i| i as usize >= n)) {
        let index = triangles[ti].iter().copied().find(|&i| i as usize >= n).unwrap_or(0);
        return Err(Error::BadIndex { triangle: ti, index: index as i64, vertex_count: n });
    }
    let v = triangles.iter().flat_map(|tri| tri.map(|i| vertices[i as usize])).collect();
    let t = (0..triangles.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    Ok((v, t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cylinder_is_closed_and_outward() {
        let (v, t) = capped_cylinder(1.0, 2.0, 4, 8);
        assert_eq!(v.len(), 34);
        assert_eq!(t.len(), 2 * 8 * 4);
        // Closed: every undirected edge is used exactly twice, once per direction.
        let mut edges = std::collections::HashMap::new();
        for tri in &t {
            for k in 0..3 {
                *edges.entry((tri[k], tri[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &c) in &edges {
            assert_eq!(c, 1);
            assert_eq!(edges.get(&(b, a)), Some(&1));
        }
        // Outward: signed volume is positive and close to pi r^2 h (8-gon: 2 sqrt2 r^2 h).
        let vol: f32 = t
            .iter()
            .map(|tri| {
                let [a, b, c] = tri.map(|i| glam::Vec3::from_array(v[i as usize]));
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        assert!((vol - 2.0 * 2f32.sqrt() * 2.0).abs() < 1e-4, "{vol}");
        let (h, tl, p) = bone_chain(2.0, 3);
        assert_eq!((h.len(), tl.len(), p), (3, 3, vec![-1, 0, 1]));
        assert_eq!(h[1], tl[0]);
        let (sv, st) = split_flat(&v, &t).unwrap();
        assert_eq!((sv.len(), st.len()), (3 * t.len(), t.len()));
        assert_eq!(sv[3 * 5 + 2], v[t[5][2] as usize]);
        assert_eq!(st[5], [15, 16, 17]);
    }

    #[test]
    fn split_flat_refuses_an_index_past_the_vertices() {
        let (v, mut t) = capped_cylinder(1.0, 2.0, 2, 3);
        let n = v.len();
        t[4][1] = n as u32;
        assert_eq!(split_flat(&v, &t), Err(Error::BadIndex { triangle: 4, index: n as i64, vertex_count: n }));
        t[4][1] = u32::MAX;
        t[6][0] = n as u32 + 1;
        assert_eq!(split_flat(&v, &t), Err(Error::BadIndex { triangle: 4, index: u32::MAX as i64, vertex_count: n }));
        assert_eq!(split_flat(&[], &[[0, 0, 0]]), Err(Error::BadIndex { triangle: 0, index: 0, vertex_count: 0 }));
        assert_eq!(split_flat(&[], &[]), Ok((vec![], vec![])));
    }
}
