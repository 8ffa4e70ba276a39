//! Inverse-distance weighting of bones: the fast, always-defined fallback method.

use crate::mesh::segment::closest_point_on_segment;
use crate::mesh::{bones_in_frame, validate_bones, validate_mesh, Frame};
use crate::weights::influence::{top_k_row, Influences};
use crate::{Error, Result};
use rayon::prelude::*;

/// Options of [`idw_weights`].
#[derive(Debug, Clone, PartialEq)]
pub struct IdwOptions {
    /// Exponent `p` of the inverse distance (>= 0; 0 gives uniform weights). Default 2.
    pub power: f32,
    /// Bones kept per vertex (>= 1; the result has min(this, bones) columns). Default 4.
    pub max_influences: usize,
    /// Distance offset `eps`, relative to the mesh bounding-box diagonal (>= 0); keeps vertices
    /// lying on a bone finite. Default 1e-4.
    pub epsilon: f32,
}

impl Default for IdwOptions {
    fn default() -> Self {
        IdwOptions { power: 2.0, max_influences: 4, epsilon: 1e-4 }
    }
}

/// Inverse-distance bone weights (Shepard 1968 applied to bone segments).
///
/// Inputs: `vertices` `(n, 3)`, bone `heads` / `tails` `(b, 3)` in the same unit.
/// Weights: `w_b = (d_b + eps)^-p / sum_j (d_j + eps)^-p` with `d_b` the distance from the
/// vertex to bone segment `b` and `eps = epsilon * bbox diagonal` (computed as
/// `((d_min + eps) / (d_b + eps))^p` so that no power overflows); then the `max_influences`
/// largest are kept and renormalized to sum 1 ([`top_k_row`], no further pruning).
/// Scale-free: distances are measured in units of the mesh's bounding-box diagonal.
/// Output: [`Influences`] with `n` rows, every row non-empty, strongest bone = nearest segment.
/// Errors: empty mesh, non-finite input, no bones / mismatched bone arrays, bad options.
pub fn idw_weights(
    vertices: &[[f32; 3]],
    heads: &[[f32; 3]],
    tails: &[[f32; 3]],
    opts: &IdwOptions,
) -> Result<Influences> {
    validate_mesh(vertices, &[], false)?;
    validate_bones(heads, tails)?;
    if !(opts.power.is_finite() && opts.power >= 0.0) {
        return Err(Error::InvalidArgument(format!("power must be finite and >= 0, got {}", opts.power)));
    }
    if !(opts.epsilon.is_finite() && opts.epsilon >= 0.0) {
        return Err(Error::InvalidArgument(format!("epsilon must be finite and >= 0, got {}", opts.epsilon)));
    }
    if opts.max_influences == 0 {
        return Err(Error::InvalidArgument("max_influences must be >= 1".into()));
    }
    let frame = Frame::of_points(vertices);
    let bones = bones_in_frame(&frame, heads, tails);
    let b = bones.len();
    let eps = opts.epsilon as f64;
    let p = opts.power as f64;
    let mut out = Influences::empty(vertices.len(), opts.max_influences.min(b));
    let k = out.k;
    out.indices
        .par_chunks_mut(k)
        .zip(out.weights.par_chunks_mut(k))
        .zip(vertices.par_iter())
        .with_min_len(512)
        .for_each(|((idx, w), v)| {
            let x = frame.to_unit(*v);
            let dist = |j: usize| closest_point_on_segment(x, bones[j].0, bones[j].1).1;
            let dmin = (0..b).map(dist).fold(f64::INFINITY, f64::min) + eps;
            top_k_row(
                |j| {
                    let d = dist(j) + eps;
                    if d <= 0.0 {
                        1.0
                    } else if p == 2.0 {
                        let r = dmin / d;
                        (r * r) as f32
                    } else {
                        (dmin / d).powf(p) as f32
                    }
                },
                b,
                0.0,
                idx,
                w,
            );
        });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_bone_dominates_and_rows_sum_to_one() {
        let heads = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let tails = [[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]];
        let verts = [[0.3, 0.0, 0.2], [0.3, 0.0, 1.8], [0.0, 0.0, 0.5]];
        let inf = idw_weights(&verts, &heads, &tails, &IdwOptions::default()).unwrap();
        assert_eq!(inf.row(0).0[0], 0);
        assert_eq!(inf.row(1).0[0], 1);
        assert_eq!(inf.row(2).0[0], 0);
        assert!(inf.row(2).1[0] > 0.999); // on the bone
        for v in 0..3 {
            assert!((inf.row(v).1.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        }
        let bad = IdwOptions { max_influences: 0, ..Default::default() };
        assert!(idw_weights(&verts, &heads, &tails, &bad).is_err());
    }

    /// The documented formula, offset included: a vertex 1e-4 and 3e-4 diagonals from two
    /// bones (eps = 1e-4 diagonals) gets `(2e-4)^-p : (4e-4)^-p`, 0.8 for p = 2 and 2/3 for
    /// p = 1; without the offset it would be 0.9 and 0.75.
    #[test]
    fn weights_follow_the_formula_with_its_offset() {
        let verts = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.0, 0.0]]; // bbox diagonal 1
        let heads = [[0.5, 1e-4, -1.0], [0.5, -3e-4, -1.0]];
        let tails = [[0.5, 1e-4, 1.0], [0.5, -3e-4, 1.0]];
        for (power, expected) in [(2.0, 0.8), (1.0, 2.0 / 3.0)] {
            let inf = idw_weights(&verts, &heads, &tails, &IdwOptions { power, ..Default::default() }).unwrap();
            let (idx, w) = inf.row(2);
            assert_eq!(idx[0], 0);
            assert!((w[0] - expected).abs() < 1e-3, "p = {power}: {w:?}");
        }
    }
}
