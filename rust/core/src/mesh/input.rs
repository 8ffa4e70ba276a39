//! Input checks for meshes and bones, with the errors that name the bad entry, and the
//! small conversions every algorithm shares (`[f32; 3]` to `DVec3`, bounding boxes).

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

#[cfg(test)]
mod tests {
    use super::*;

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
}
