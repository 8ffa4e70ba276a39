//! The character as a solid of voxels (Dionne & de Lasa 2013, section 3.1).
//!
//! Inputs: welded positions `wpos` `(nw,)` and triangles `tris` `(m, 3)` in the unit frame,
//! wound outward (per piece, [`outward`]); `resolution`, voxels along the longest side of their
//! bounding box. Output: the [`Grid`] (two voxels of padding all round) and its voxels' states
//! `(nx*ny*nz,)`: [`EMPTY`], [`INSIDE`] or [`SURFACE`].
//!
//! Method, as the paper's:
//! - interior: along each axis, a voxel votes "inside" when the first surface seen from its
//!   centre looking forward along the axis is a back face, or the first one looking backward is
//!   (the paper renders those with depth peeling; here every column of voxels is one ray through
//!   the BVH and each hit's facing is the sign of its outward normal along the axis). A voxel is
//!   inside when two of the three axes vote so. Faces, not parity, decide: pieces inside pieces
//!   (eyes in a head), pieces pushed into each other and a self-intersecting piece are solid
//!   throughout, and a hole in an open mesh spoils only the columns that look through it;
//! - boundary: every voxel a triangle overlaps is solid (the separating-axis triangle/box test
//!   of Akenine-Möller 2001), so thin shells and sheets (a wing membrane, a cape, a sleeve) are
//!   solid too, one voxel thick.
//!
//! Known limits: parts closer than a voxel merge (fingers pressed together share voxels, and
//! geodesic distance then crosses between them); faces wound against their piece's volume
//! (an inside-out sheet) vote like the piece's other side.

use crate::mesh::facing::looks_inside;
use crate::mesh::visibility::RayMesh;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Outside the solid.
pub(super) const EMPTY: u8 = 0;
/// Inside by the votes of the faces seen along the axes.
pub(super) const INSIDE: u8 = 1;
/// Overlapped by a triangle.
pub(super) const SURFACE: u8 = 2;
/// Empty voxels all round the geometry's bounding box.
const PADDING: usize = 2;

/// The lattice of the character's voxels, in the unit frame.
pub(super) use crate::mesh::lattice::Lattice as Grid;

impl Grid {
    /// The grid over the box `lo..hi` with `resolution` voxels along its longest side and
    /// [`PADDING`] empty voxels all round.
    pub fn new(lo: DVec3, hi: DVec3, resolution: usize) -> Grid {
        let size = (hi - lo).max(DVec3::ZERO);
        let step = size.max_element().max(1e-9) / resolution.max(1) as f64;
        let dims = [0, 1, 2].map(|a| (size[a] / step).ceil() as usize + 1 + 2 * PADDING);
        let origin = lo - DVec3::splat(PADDING as f64 * step);
        Grid { dims, origin, step }
    }

    /// Grid coordinates of `p` (voxel centres at whole numbers).
    #[inline]
    pub fn local(&self, p: DVec3) -> DVec3 {
        (p - self.origin) / self.step
    }

    /// The voxel whose cube holds `p`, clamped to the grid.
    #[inline]
    pub fn voxel_at(&self, p: DVec3) -> [usize; 3] {
        let g = self.local(p).round();
        [0, 1, 2].map(|a| (g[a].max(0.0) as usize).min(self.dims[a] - 1))
    }

    /// On the outer layer of the grid (no neighbour on some side).
    #[inline]
    pub fn on_border(&self, v: usize) -> bool {
        let c = self.coords(v);
        (0..3).any(|a| c[a] == 0 || c[a] + 1 == self.dims[a])
    }
}

/// `tris` wound outward: each piece's triangles flipped when they enclose a negative volume.
/// `labels` `(nw,)` is each vertex's piece, `volumes` `(pieces,)` from
/// [`piece_volumes`](crate::mesh::orient::piece_volumes).
pub(super) fn outward(tris: &[[u32; 3]], labels: &[u32], volumes: &[f64]) -> Vec<[u32; 3]> {
    tris.iter().map(|t| if volumes[labels[t[0] as usize] as usize] < 0.0 { [t[0], t[2], t[1]] } else { *t }).collect()
}

/// The voxels' states over `grid` (see the module doc). `rays` holds `tris` (outward) as
/// given to [`RayMesh::new`], so a hit's triangle index is an index into `tris`.
pub(super) fn voxelize(grid: &Grid, wpos: &[DVec3], tris: &[[u32; 3]], rays: &RayMesh) -> Vec<u8> {
    let normals: Vec<DVec3> = tris
        .par_iter()
        .with_min_len(4096)
        .map(|t| {
            let [a, b, c] = t.map(|i| wpos[i as usize]);
            (b - a).cross(c - a)
        })
        .collect();
    let mut votes = vec![0u8; grid.len()];
    for axis in 0..3 {
        axis_votes(grid, &normals, rays, axis, &mut votes);
    }
    let mut state: Vec<u8> = votes.iter().map(|&v| if v >= 2 { INSIDE } else { EMPTY }).collect();
    for v in surface_voxels(grid, wpos, tris) {
        state[v as usize] = SURFACE;
    }
    state
}

/// Add one vote to every voxel that looks inside along `axis` ([`looks_inside`]).
fn axis_votes(grid: &Grid, normals: &[DVec3], rays: &RayMesh, axis: usize, votes: &mut [u8]) {
    let dims = grid.dims;
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut dir = Vec3::ZERO;
    dir[axis] = 1.0;
    // Columns off the voxel centres by small irrational fractions, so that rays do not run
    // along the edges and faces of axis-aligned models.
    let columns: Vec<Vec<bool>> = (0..dims[a] * dims[b])
        .into_par_iter()
        .with_min_len(16)
        .map(|c| {
            let (ia, ib) = (c % dims[a], c / dims[a]);
            let mut p = grid.origin;
            p[a] += (ia as f64 + 0.0137) * grid.step;
            p[b] += (ib as f64 - 0.0219) * grid.step;
            p[axis] -= grid.step;
            let far = (dims[axis] + 1) as f64 * grid.step;
            let hits = rays.ray_hits_tagged(p.as_vec3(), dir, far as f32, |_| true);
            // Voxel t's centre lies at (t + 1) step along the ray.
            let mut inside = vec![false; dims[axis]];
            let mut next = 0usize;
            for (t, slot) in inside.iter_mut().enumerate() {
                let s = ((t + 1) as f64 * grid.step) as f32;
                while next < hits.len() && hits[next].0 <= s {
                    next += 1;
                }
                let behind = (next > 0).then(|| normals[hits[next - 1].1 as usize][axis]);
                let ahead = hits.get(next).map(|h| normals[h.1 as usize][axis]);
                *slot = looks_inside(behind, ahead);
            }
            inside
        })
        .collect();
    for (c, inside) in columns.into_iter().enumerate() {
        let (ia, ib) = (c % dims[a], c / dims[a]);
        for (t, _) in inside.iter().enumerate().filter(|(_, &i)| i) {
            let mut ijk = [0usize; 3];
            ijk[axis] = t;
            ijk[a] = ia;
            ijk[b] = ib;
            votes[grid.index(ijk)] += 1;
        }
    }
}

/// Indices of the voxels that some triangle overlaps.
fn surface_voxels(grid: &Grid, wpos: &[DVec3], tris: &[[u32; 3]]) -> Vec<u32> {
    // A hair larger than half a voxel, so a triangle on a voxel face marks both sides.
    let half = 0.5 * grid.step * (1.0 + 1e-6);
    let mut out: Vec<u32> = tris
        .par_iter()
        .with_min_len(1024)
        .fold(Vec::new, |mut acc, t| {
            let p = t.map(|i| wpos[i as usize]);
            let lo = grid.voxel_at(p[0].min(p[1]).min(p[2]));
            let hi = grid.voxel_at(p[0].max(p[1]).max(p[2]));
            for k in lo[2]..=hi[2] {
                for j in lo[1]..=hi[1] {
                    for i in lo[0]..=hi[0] {
                        let v = grid.index([i, j, k]);
                        if triangle_box_overlap(grid.centre(v), half, p) {
                            acc.push(v as u32);
                        }
                    }
                }
            }
            acc
        })
        .flatten_iter()
        .collect();
    out.par_sort_unstable();
    out.dedup();
    out
}

/// Does the triangle `t` overlap the cube of half side `h` centred on `c`? The separating-axis
/// test of Akenine-Möller ("Fast 3D triangle-box overlap testing", 2001): the three box
/// normals, the triangle's normal, and the nine cross products of box and triangle edges.
pub(super) fn triangle_box_overlap(c: DVec3, h: f64, t: [DVec3; 3]) -> bool {
    let v = t.map(|p| p - c);
    let lo = v[0].min(v[1]).min(v[2]);
    let hi = v[0].max(v[1]).max(v[2]);
    if lo.cmpgt(DVec3::splat(h)).any() || hi.cmplt(DVec3::splat(-h)).any() {
        return false;
    }
    let n = (v[1] - v[0]).cross(v[2] - v[0]);
    if n.dot(v[0]).abs() > h * n.abs().element_sum() {
        return false;
    }
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    for e in edges {
        for a in [DVec3::X, DVec3::Y, DVec3::Z] {
            let axis = a.cross(e);
            let p = v.map(|x| axis.dot(x));
            let r = h * axis.abs().element_sum();
            if p[0].min(p[1]).min(p[2]) > r || p[0].max(p[1]).max(p[2]) < -r {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::islands::connected_components;
    use crate::mesh::orient::{orient_faces, piece_volumes};
    use crate::primitives::add_box;

    fn solid(v32: &[[f32; 3]], t: &[[u32; 3]], resolution: usize) -> (Grid, Vec<u8>) {
        let v: Vec<DVec3> = v32.iter().map(|p| DVec3::from(p.map(f64::from))).collect();
        let (labels, np) = connected_components(v.len(), t);
        let (oriented, _) = orient_faces(v.len(), t);
        let tris = outward(&oriented, &labels, &piece_volumes(&v, &oriented, &labels, np));
        let lo = v.iter().fold(DVec3::splat(f64::INFINITY), |a, p| a.min(*p));
        let hi = v.iter().fold(DVec3::splat(f64::NEG_INFINITY), |a, p| a.max(*p));
        let grid = Grid::new(lo, hi, resolution);
        let rays = RayMesh::new(v32, &tris);
        let state = voxelize(&grid, &v, &tris, &rays);
        (grid, state)
    }

    fn state_at(grid: &Grid, state: &[u8], p: [f64; 3]) -> u8 {
        state[grid.index(grid.voxel_at(DVec3::from(p)))]
    }

    #[test]
    fn box_inside_outside_and_surface() {
        let (mut v, mut t) = (Vec::new(), Vec::new());
        add_box(&mut v, &mut t, [0.0; 3], [1.0, 0.5, 0.5]);
        let (grid, state) = solid(&v, &t, 20);
        assert_eq!(grid.step, 0.05);
        assert_eq!(state_at(&grid, &state, [0.5, 0.25, 0.25]), INSIDE);
        assert_eq!(state_at(&grid, &state, [0.0, 0.25, 0.25]), SURFACE);
        assert_eq!(state_at(&grid, &state, [1.08, 0.25, 0.25]), EMPTY);
        // Every voxel whose centre lies inside the box is solid, every other one is not
        // (surface voxels reach half a voxel out).
        for (v, &s) in state.iter().enumerate() {
            let c = grid.centre(v);
            let depth = (c.min(DVec3::new(1.0, 0.5, 0.5) - c)).min_element();
            if depth > 1e-9 {
                assert_ne!(s, EMPTY, "{c}");
            } else if depth < -0.5 * grid.step - 1e-9 {
                assert_eq!(s, EMPTY, "{c}");
            }
        }
    }

    /// Inside-out input (every face flipped), a box inside a box, and two boxes pushed into
    /// each other: all solid where a solid is meant.
    #[test]
    fn flipped_nested_and_intersecting_boxes_are_solid() {
        let (mut v, mut t) = (Vec::new(), Vec::new());
        add_box(&mut v, &mut t, [0.0; 3], [1.0, 1.0, 1.0]);
        add_box(&mut v, &mut t, [0.3; 3], [0.6; 3]);
        add_box(&mut v, &mut t, [0.8, 0.4, 0.4], [1.6, 0.6, 0.6]);
        let flipped: Vec<[u32; 3]> = t.iter().map(|x| [x[0], x[2], x[1]]).collect();
        for tris in [t, flipped] {
            let (grid, state) = solid(&v, &tris, 32);
            for p in [[0.1, 0.5, 0.5], [0.45, 0.45, 0.45], [0.9, 0.5, 0.5], [1.3, 0.5, 0.5], [0.7, 0.2, 0.8]] {
                assert_ne!(state_at(&grid, &state, p), EMPTY, "{p:?}");
            }
            assert_eq!(state_at(&grid, &state, [1.3, 0.9, 0.9]), EMPTY);
        }
    }

    /// A tube open at both ends (a sleeve) is solid inside: the columns along it see no face,
    /// the other two axes do.
    #[test]
    fn an_open_sleeve_is_solid_inside() {
        let (v, t) = crate::primitives::capped_cylinder(0.2, 1.0, 10, 24);
        // Drop the caps: triangles using the two pole vertices.
        let poles = [v.len() as u32 - 2, v.len() as u32 - 1];
        let t: Vec<[u32; 3]> = t.into_iter().filter(|x| !x.iter().any(|i| poles.contains(i))).collect();
        let (grid, state) = solid(&v, &t, 40);
        assert_ne!(state_at(&grid, &state, [0.0, 0.0, 0.5]), EMPTY);
        assert_ne!(state_at(&grid, &state, [0.1, 0.05, 0.2]), EMPTY);
        assert_eq!(state_at(&grid, &state, [0.0, 0.0, 1.04]), EMPTY);
    }

    #[test]
    fn triangle_box_overlap_is_exact_on_simple_cases() {
        let t = [DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, -1.0, 0.0), DVec3::new(0.0, 1.0, 0.0)];
        assert!(triangle_box_overlap(DVec3::ZERO, 0.1, t));
        assert!(triangle_box_overlap(DVec3::new(0.0, 0.0, 0.09), 0.1, t));
        assert!(!triangle_box_overlap(DVec3::new(0.0, 0.0, 0.11), 0.1, t));
        // Beside the slanted edge: inside the triangle's box but not across the edge.
        assert!(!triangle_box_overlap(DVec3::new(0.8, 0.7, 0.0), 0.1, t));
        assert!(triangle_box_overlap(DVec3::new(0.5, 0.0, 0.0), 0.1, t));
    }
}
