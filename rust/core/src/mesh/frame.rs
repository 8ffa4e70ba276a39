//! The unit frame: every algorithm works where the mesh's bounding box is centred at the origin
//! and has diagonal 1, so that all tolerances are relative and the results do not depend on the
//! scene's unit.

use super::input::{bounding_box, to_dvec};
use glam::DVec3;
use rayon::prelude::*;

/// A similarity frame: `unit = (p - centre) / diagonal`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Bounding-box centre in input units.
    pub centre: DVec3,
    /// Bounding-box diagonal in input units (> 0; 1 for a mesh collapsed to a point).
    pub diagonal: f64,
}

impl Frame {
    /// Frame of the bounding box of `points` `(n, 3)`. A zero-size box gets diagonal 1.
    pub fn of_points(points: &[[f32; 3]]) -> Frame {
        let (lo, hi) = bounding_box(points);
        let d = (hi - lo).length();
        Frame { centre: (lo + hi) * 0.5, diagonal: if d.is_finite() && d > 0.0 { d } else { 1.0 } }
    }

    /// Frame of the vertices the `triangles` use (indices already validated), so that loose
    /// vertices -- a stray point left far from the model -- do not set the scale of every
    /// tolerance (weld distance, max move). All vertices when no triangle has any extent.
    pub fn of_mesh(vertices: &[[f32; 3]], triangles: &[[u32; 3]]) -> Frame {
        let mut used = vec![false; vertices.len()];
        for t in triangles {
            for &i in t {
                used[i as usize] = true;
            }
        }
        let on_faces: Vec<[f32; 3]> = vertices.iter().zip(&used).filter(|(_, &u)| u).map(|(p, _)| *p).collect();
        let (lo, hi) = bounding_box(&on_faces);
        let d = (hi - lo).length();
        if d.is_finite() && d > 0.0 {
            Frame { centre: (lo + hi) * 0.5, diagonal: d }
        } else {
            Frame::of_points(vertices)
        }
    }

    /// Input units -> unit frame.
    #[inline]
    pub fn to_unit(&self, p: [f32; 3]) -> DVec3 {
        (to_dvec(p) - self.centre) / self.diagonal
    }

    /// Unit frame -> input units.
    #[inline]
    pub fn from_unit(&self, p: DVec3) -> DVec3 {
        p * self.diagonal + self.centre
    }

    /// Map every point to the unit frame (parallel). Output `(n,)` of `DVec3`.
    pub fn normalize(&self, points: &[[f32; 3]]) -> Vec<DVec3> {
        points.par_iter().with_min_len(4096).map(|p| self.to_unit(*p)).collect()
    }
}

/// Bones `(b,)` as `(head, tail)` segments in `frame`'s unit coordinates.
pub fn bones_in_frame(frame: &Frame, heads: &[[f32; 3]], tails: &[[f32; 3]]) -> Vec<(DVec3, DVec3)> {
    heads.iter().zip(tails).map(|(h, t)| (frame.to_unit(*h), frame.to_unit(*t))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_unit() {
        let v = [[10.0, 10.0, 10.0], [13.0, 14.0, 10.0]];
        let f = Frame::of_points(&v);
        assert!((f.diagonal - 5.0).abs() < 1e-12);
        let u = f.normalize(&v);
        assert!(((u[1] - u[0]).length() - 1.0).abs() < 1e-12);
        assert!((f.from_unit(u[1]) - to_dvec(v[1])).length() < 1e-9);
        assert_eq!(Frame::of_points(&[[1.0, 1.0, 1.0]]).diagonal, 1.0);
    }

    #[test]
    fn mesh_frame_ignores_loose_vertices() {
        let v = [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 4.0, 0.0], [1e6, 0.0, 0.0]];
        let f = Frame::of_mesh(&v, &[[0, 1, 2]]);
        assert!((f.diagonal - 5.0).abs() < 1e-12 && (f.centre - DVec3::new(1.5, 2.0, 0.0)).length() < 1e-12);
        // No faces, or faces without extent: every vertex counts.
        assert_eq!(Frame::of_mesh(&v, &[]), Frame::of_points(&v));
        assert_eq!(Frame::of_mesh(&v, &[[0, 0, 0]]), Frame::of_points(&v));
    }
}
