//! Mesh input validation and normalization to a unit-size frame.
//!
//! Every weighting algorithm first validates its slices here and then works in a frame
//! where the mesh's bounding box is centred at the origin and has diagonal 1, so that all
//! tolerances are relative and the results do not depend on the scene's unit.

use crate::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;

/// Count the points of an array that have a NaN / infinite coordinate.
///
/// Input: `points`, `(n, 3)`. Output: number of points (0..=n) with a non-finite coordinate,
/// so the error can say "3 vertices", which is what a rigger can look for.
pub fn count_non_finite(points: &[[f32; 3]]) -> usize {
    points.par_iter().with_min_len(4096).filter(|p| p.iter().any(|c| !c.is_finite())).count()
}

/// Validate a triangle mesh.
///
/// Inputs: `vertices` `(n, 3)` positions, `triangles` `(m, 3)` vertex indices.
/// Errors: [`Error::EmptyMesh`] if `n == 0` (or `m == 0` when `need_faces`),
/// [`Error::NonFinite`] with the number of bad vertices, [`Error::BadIndex`] for the
/// first triangle that refers past the end of `vertices`.
pub fn validate_mesh(vertices: &[[f32; 3]], triangles: &[[u32; 3]], need_faces: bool) -> Result<()> {
    if vertices.is_empty() {
        return Err(Error::EmptyMesh("the mesh has no vertices".into()));
    }
    if need_faces && triangles.is_empty() {
        return Err(Error::EmptyMesh("the mesh has no triangles".into()));
    }
    let bad = count_non_finite(vertices);
    if bad > 0 {
        return Err(Error::NonFinite { what: "vertex", count: bad });
    }
    let n = vertices.len();
    let first_bad = triangles.par_iter().with_min_len(4096).position_first(|t| t.iter().any(|&i| i as usize >= n));
    if let Some(ti) = first_bad {
        let index = triangles[ti].iter().copied().find(|&i| i as usize >= n).unwrap_or(0);
        return Err(Error::BadIndex { triangle: ti, index: index as i64, vertex_count: n });
    }
    Ok(())
}

/// Validate a bone list: `heads` and `tails` `(b, 3)` must have equal, non-zero length
/// and finite coordinates. Errors: [`Error::NoBones`], [`Error::Shape`], [`Error::NonFinite`].
pub fn validate_bones(heads: &[[f32; 3]], tails: &[[f32; 3]]) -> Result<()> {
    if heads.len() != tails.len() {
        return Err(Error::Shape(format!("{} bone heads but {} bone tails", heads.len(), tails.len())));
    }
    if heads.is_empty() {
        return Err(Error::NoBones("no bones: the bone list is empty".into()));
    }
    let bad = heads.iter().zip(tails).filter(|(h, t)| h.iter().chain(t.iter()).any(|c| !c.is_finite())).count();
    if bad > 0 {
        return Err(Error::NonFinite { what: "bone", count: bad });
    }
    Ok(())
}

/// Validate a parent list for `b` bones: `(b,)`, each `-1` (a root) or another bone's index,
/// and no cycle (walking up from any bone reaches a root). Errors: [`Error::Shape`] for the
/// length, [`Error::InvalidArgument`] naming the first bad bone.
pub fn validate_parents(parents: &[i32], b: usize) -> Result<()> {
    if parents.len() != b {
        return Err(Error::Shape(format!("{} parents for {b} bones", parents.len())));
    }
    for (i, &p) in parents.iter().enumerate() {
        if p < -1 || p >= b as i32 || p == i as i32 {
            return Err(Error::InvalidArgument(format!(
                "parent of bone {i} is {p}; it must be -1 or another bone's index (0..{b})"
            )));
        }
    }
    // 0 = not seen, 1 = on the current walk up, 2 = known to reach a root.
    let mut state = vec![0u8; b];
    for start in 0..b {
        let mut cur = start as i32;
        while cur >= 0 && state[cur as usize] == 0 {
            state[cur as usize] = 1;
            cur = parents[cur as usize];
        }
        if cur >= 0 && state[cur as usize] == 1 {
            return Err(Error::InvalidArgument(format!("bone {cur} is in a parent cycle")));
        }
        let mut cur = start as i32;
        while cur >= 0 && state[cur as usize] == 1 {
            state[cur as usize] = 2;
            cur = parents[cur as usize];
        }
    }
    Ok(())
}

/// Axis-aligned bounding box `(min, max)` of `points` `(n, 3)`; `(0, 0)` when empty.
pub fn bounding_box(points: &[[f32; 3]]) -> (DVec3, DVec3) {
    if points.is_empty() {
        return (DVec3::ZERO, DVec3::ZERO);
    }
    points
        .par_iter()
        .with_min_len(4096)
        .fold(
            || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| {
                let q = to_dvec(*p);
                (lo.min(q), hi.max(q))
            },
        )
        .reduce(|| (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |a, b| (a.0.min(b.0), a.1.max(b.1)))
}

/// `[f32; 3]` -> `DVec3`.
#[inline]
pub fn to_dvec(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_parents_are_errors() {
        validate_parents(&[-1, 0, 1, 1, -1, 4], 6).unwrap();
        assert!(matches!(validate_parents(&[-1, 0], 3), Err(Error::Shape(_))));
        assert!(matches!(validate_parents(&[-1, 1], 2), Err(Error::InvalidArgument(_))));
        assert!(matches!(validate_parents(&[-1, 2], 2), Err(Error::InvalidArgument(_))));
        assert!(matches!(validate_parents(&[-2, 0], 2), Err(Error::InvalidArgument(_))));
        // Cycles: two bones, three bones below a root, and one reached only through a chain.
        for parents in [vec![1, 0], vec![-1, 3, 1, 2], vec![-1, 0, 4, 2, 3, 2]] {
            let err = validate_parents(&parents, parents.len()).unwrap_err();
            assert!(err.to_string().contains("parent cycle"), "{parents:?}: {err}");
        }
    }

    #[test]
    fn validation_errors() {
        let v = [[0.0, 0.0, 0.0], [1.0, f32::NAN, 0.0], [0.0, 1.0, f32::INFINITY]];
        assert_eq!(
            validate_mesh(&v, &[[0, 1, 2]], true),
            Err(Error::NonFinite { what: "vertex", count: 2 }) // two vertices, one bad coordinate each
        );
        let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(validate_mesh(&v, &[[0, 1, 2]], true).is_ok());
        assert_eq!(
            validate_mesh(&v, &[[0, 1, 2], [0, 1, 7]], true),
            Err(Error::BadIndex { triangle: 1, index: 7, vertex_count: 3 })
        );
        assert!(matches!(validate_mesh(&[], &[], false), Err(Error::EmptyMesh(_))));
        assert!(matches!(validate_mesh(&v, &[], true), Err(Error::EmptyMesh(_))));
        assert!(matches!(validate_bones(&[], &[]), Err(Error::NoBones(_))));
        assert!(matches!(validate_bones(&v, &v[..2]), Err(Error::Shape(_))));
        // A bone with a NaN in its head, its tail or both counts once.
        let bad = [[0.0, 0.0, f32::NAN], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(validate_bones(&v, &v).is_ok());
        assert_eq!(validate_bones(&bad, &v), Err(Error::NonFinite { what: "bone", count: 1 }));
        assert_eq!(validate_bones(&v, &bad), Err(Error::NonFinite { what: "bone", count: 1 }));
        assert_eq!(validate_bones(&bad, &bad), Err(Error::NonFinite { what: "bone", count: 1 }));
    }

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
