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
//! Parts apart by at most [`MAX_GAP`] voxels (a kit-built robot's hands and feet) are joined to
//! the largest part by a line of voxels.
//!
//! Known limits: a part thinner than a voxel may vanish (no voxel centre inside it).

use crate::mesh::lattice::Lattice;
use crate::mesh::solid::Solid;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Parts of the solid at most this many voxels apart are joined by a line of voxels.
const MAX_GAP: usize = 4;

/// A regular grid over the unit frame.
pub(crate) struct Voxels {
    /// Dims, origin and step (unit frame); its addressing is the voxels' (through `Deref`).
    pub grid: Lattice,
    pub inside: Vec<bool>,
    /// Distance to the nearest outside voxel, in voxels (0 outside).
    pub depth: Vec<f32>,
}

impl std::ops::Deref for Voxels {
    type Target = Lattice;
    fn deref(&self) -> &Lattice {
        &self.grid
    }
}

impl Voxels {
    /// Is the voxel holding `p` inside (false off the grid)?
    pub fn inside_at(&self, p: DVec3) -> bool {
        let c = ((p - self.origin) / self.step).round();
        if c.min_element() < 0.0 {
            return false;
        }
        let (i, j, k) = (c.x as usize, c.y as usize, c.z as usize);
        i < self.dims[0] && j < self.dims[1] && k < self.dims[2] && self.inside[self.index([i, j, k])]
    }

    /// How far the solid goes on from `p` along the unit direction `dir`: the distance to the
    /// last inside point before the first outside one, in steps of half a voxel, at most `cap`.
    pub fn reach(&self, p: DVec3, dir: DVec3, cap: f64) -> f64 {
        let h = 0.5 * self.step;
        let mut t = 0.0;
        while t + h <= cap && self.inside_at(p + dir * (t + h)) {
            t += h;
        }
        t
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
        let mut inside: Vec<bool> = votes.iter().map(|&v| v >= 2).collect();
        bridge_gaps(&mut inside, dims, MAX_GAP);
        let depth = distance_transform(&inside, dims);
        Voxels { grid: Lattice { dims, origin, step }, inside, depth }
    }
}

/// Join parts of the solid to the largest one across gaps of at most `max_gap` voxels (a kit-built
/// model's feet or hands hang apart from its legs and arms): a breadth-first search from the
/// largest part through the outside finds each other part's nearest voxel, and the path back is
/// made inside. Repeated, so a chain of parts (foot, shin, thigh) joins link by link.
fn bridge_gaps(inside: &mut [bool], dims: [usize; 3], max_gap: usize) {
    let n = inside.len();
    let strides = [1isize, dims[0] as isize, (dims[0] * dims[1]) as isize];
    let step = |v: usize, axis: usize, dir: isize| -> Option<usize> {
        let c = [v % dims[0], (v / dims[0]) % dims[1], v / (dims[0] * dims[1])];
        let x = c[axis] as isize + dir;
        (x >= 0 && x < dims[axis] as isize).then(|| (v as isize + dir * strides[axis]) as usize)
    };
    for _ in 0..8 {
        // Parts (6-connected), the largest first.
        let mut label = vec![u32::MAX; n];
        let mut sizes = Vec::new();
        for s in 0..n {
            if !inside[s] || label[s] != u32::MAX {
                continue;
            }
            let id = sizes.len() as u32;
            label[s] = id;
            let mut stack = vec![s];
            let mut size = 0usize;
            while let Some(v) = stack.pop() {
                size += 1;
                for axis in 0..3 {
                    for dir in [-1, 1] {
                        if let Some(w) = step(v, axis, dir) {
                            if inside[w] && label[w] == u32::MAX {
                                label[w] = id;
                                stack.push(w);
                            }
                        }
                    }
                }
            }
            sizes.push(size);
        }
        if sizes.len() < 2 {
            return;
        }
        let main = (0..sizes.len()).max_by_key(|&i| sizes[i]).unwrap() as u32;
        // Breadth-first from the main part through the outside, up to `max_gap` steps.
        let mut dist = vec![u16::MAX; n];
        let mut parent = vec![usize::MAX; n];
        let mut frontier: Vec<usize> = (0..n).filter(|&v| label[v] == main).collect();
        for &v in &frontier {
            dist[v] = 0;
        }
        let mut reached: Vec<(u32, usize)> = Vec::new();
        for d in 1..=max_gap as u16 {
            let mut next = Vec::new();
            for &v in &frontier {
                for axis in 0..3 {
                    for dir in [-1, 1] {
                        let Some(w) = step(v, axis, dir) else { continue };
                        if dist[w] != u16::MAX {
                            continue;
                        }
                        dist[w] = d;
                        parent[w] = v;
                        if inside[w] {
                            reached.push((label[w], w));
                        } else {
                            next.push(w);
                        }
                    }
                }
            }
            frontier = next;
        }
        let mut joined = vec![false; sizes.len()];
        let mut any = false;
        for (part, w) in reached {
            if joined[part as usize] {
                continue;
            }
            joined[part as usize] = true;
            any = true;
            let mut x = parent[w];
            while x != usize::MAX && !inside[x] {
                inside[x] = true;
                x = parent[x];
            }
        }
        if !any {
            return;
        }
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
