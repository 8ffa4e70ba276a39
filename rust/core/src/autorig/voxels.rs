//! The solid of a mesh as voxels, with each inside voxel's distance to the outside.
//!
//! Inputs: a [`Solid`] in the unit frame and its bounding box `lo`, `hi`; `resolution` voxels
//! along the longest side. Output [`Voxels`]: a grid with one voxel of padding all round,
//! `inside` `(nx*ny*nz,)` and `depth` `(nx*ny*nz,)` (distance from the voxel's centre to the
//! nearest outside voxel's centre, in voxels; 0 outside).
//!
//! Method: every column of voxels along X, along Y and along Z is one ray through the solid
//! ([`Solid::hits`], the union of the pieces); a voxel is inside along that axis when its centre
//! lies between an entry and the exit that follows. A voxel is inside when two of the three
//! axes say so, so a hole in an open mesh spoils only the columns through it. The depth is the
//! exact Euclidean distance transform of Felzenszwalb & Huttenlocher (2012, "Distance
//! transforms of sampled functions"), one separable pass per axis.
//!
//! Known limits: a part thinner than a voxel may vanish (no voxel centre inside it).

use crate::mesh::solid::Solid;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// A regular grid over the unit frame.
pub(crate) struct Voxels {
    pub dims: [usize; 3],
    /// Centre of voxel (0, 0, 0).
    pub origin: DVec3,
    /// Side of a voxel (unit frame).
    pub step: f64,
    pub inside: Vec<bool>,
    /// Distance to the nearest outside voxel, in voxels (0 outside).
    pub depth: Vec<f32>,
}

impl Voxels {
    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    #[inline]
    pub fn coords(&self, v: usize) -> [usize; 3] {
        let i = v % self.dims[0];
        let j = (v / self.dims[0]) % self.dims[1];
        [i, j, v / (self.dims[0] * self.dims[1])]
    }

    #[inline]
    pub fn centre(&self, v: usize) -> DVec3 {
        let [i, j, k] = self.coords(v);
        self.origin + DVec3::new(i as f64, j as f64, k as f64) * self.step
    }

    /// Build from the solid over the box `lo..hi` (unit frame).
    pub fn new(solid: &Solid, lo: DVec3, hi: DVec3, resolution: usize) -> Voxels {
        let size = hi - lo;
        let step = size.max_element().max(1e-9) / resolution as f64;
        let dims = [0, 1, 2].map(|a| (size[a] / step).ceil() as usize + 3);
        let origin = lo - DVec3::splat(step);
        let n = dims[0] * dims[1] * dims[2];
        let mut votes = vec![0u8; n];
        for axis in 0..3 {
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut dir = Vec3::ZERO;
            dir[axis] = 1.0;
            // Columns off the voxel grid's exact lines by an irrational fraction, so rays do not
            // run along the edges of axis-aligned models.
            let columns: Vec<(usize, usize, Vec<f32>)> = (0..dims[a] * dims[b])
                .into_par_iter()
                .map(|c| {
                    let (ia, ib) = (c % dims[a], c / dims[a]);
                    let mut p = origin;
                    p[a] += (ia as f64 + 0.0137) * step;
                    p[b] += (ib as f64 - 0.0219) * step;
                    p[axis] -= step;
                    let far = (dims[axis] as f64 + 2.0) * step;
                    (ia, ib, solid.hits(p.as_vec3(), dir, far as f32))
                })
                .collect();
            for (ia, ib, hits) in columns {
                for pair in hits.chunks_exact(2) {
                    // Voxel centres at distance (t + 1) * step from the ray's start.
                    let first = ((pair[0] as f64 / step) - 1.0).ceil().max(0.0) as usize;
                    let last = ((pair[1] as f64 / step) - 1.0).floor();
                    if last < 0.0 {
                        continue;
                    }
                    let last = (last as usize).min(dims[axis] - 1);
                    for t in first..=last {
                        let mut ijk = [0usize; 3];
                        ijk[axis] = t;
                        ijk[a] = ia;
                        ijk[b] = ib;
                        votes[(ijk[2] * dims[1] + ijk[1]) * dims[0] + ijk[0]] += 1;
                    }
                }
            }
        }
        let inside: Vec<bool> = votes.iter().map(|&v| v >= 2).collect();
        let depth = distance_transform(&inside, dims);
        Voxels { dims, origin, step, inside, depth }
    }
}

/// Exact Euclidean distance (in voxels) from every inside voxel to the nearest outside one.
fn distance_transform(inside: &[bool], dims: [usize; 3]) -> Vec<f32> {
    const INF: f64 = 1e20;
    let mut f: Vec<f64> = inside.iter().map(|&i| if i { INF } else { 0.0 }).collect();
    let strides = [1, dims[0], dims[0] * dims[1]];
    for axis in 0..3 {
        let len = dims[axis];
        let stride = strides[axis];
        let starts: Vec<usize> = (0..f.len()).filter(|&v| (v / stride).is_multiple_of(len)).collect();
        let lines: Vec<(usize, Vec<f64>)> = starts
            .par_iter()
            .map(|&s| {
                let line: Vec<f64> = (0..len).map(|t| f[s + t * stride]).collect();
                (s, lower_envelope(&line))
            })
            .collect();
        for (s, line) in lines {
            for (t, d) in line.into_iter().enumerate() {
                f[s + t * stride] = d;
            }
        }
    }
    f.iter().map(|&d| d.sqrt() as f32).collect()
}

/// One pass of the squared distance transform: `d[q] = min_p (q - p)^2 + f[p]`.
fn lower_envelope(f: &[f64]) -> Vec<f64> {
    let n = f.len();
    let mut v = vec![0usize; n];
    let mut z = vec![0f64; n + 1];
    let mut k = 0usize;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    let sect = |q: usize, p: usize| ((f[q] + (q * q) as f64) - (f[p] + (p * p) as f64)) / (2.0 * (q as f64 - p as f64));
    for q in 1..n {
        let mut s = sect(q, v[k]);
        while s <= z[k] {
            k -= 1;
            s = sect(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    let mut d = vec![0f64; n];
    k = 0;
    for (q, dq) in d.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let dx = q as f64 - v[k] as f64;
        *dq = dx * dx + f[v[k]];
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn envelope_is_brute_force() {
        let f = [0.0, 1e20, 1e20, 4.0, 1e20, 0.0, 1e20];
        let d = lower_envelope(&f);
        for (q, dq) in d.iter().enumerate() {
            let brute =
                f.iter().enumerate().map(|(p, fp)| (q as f64 - p as f64).powi(2) + fp).fold(f64::INFINITY, f64::min);
            assert!((dq - brute).abs() < 1e-9, "{q}: {dq} vs {brute}");
        }
    }
}
