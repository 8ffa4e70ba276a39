//! Linear blend skinning (LBS): deform a mesh by a weighted blend of bone transforms.
//!
//! Magnenat-Thalmann, Laperrière & Thalmann, "Joint-dependent local deformations for hand
//! animation and object grasping", Graphics Interface 1988; the formula is the one of
//! libigl's `igl::lbs_matrix` / Blender's armature modifier (linear, not dual quaternion):
//!
//! ```text
//! v'_i = sum_j w_ij * (M_j v_i) / sum_j w_ij
//! ```
//!
//! Weights are stored as dense top-k rows (what `influence` / `heat` produce and what the
//! Python side keeps in numpy): row `i` holds `k` bone indices and `k` weights.

use rayon::prelude::*;

use crate::{Error, Result};

/// Deform `vertices` by linear blend skinning.
///
/// * `vertices`: `n` rest-pose positions, world space (any unit; the output is in the same unit).
/// * `indices`, `weights`: dense top-`k` influence rows, `n * k` entries each, row-major
///   (`indices[i * k + s]` is the bone of slot `s` of vertex `i`). A slot is unused when its
///   index is `-1` or its weight is `0`. Any other index must be in `0..bone_matrices.len()`.
///   Weights must be finite and `>= 0`.
/// * `k`: slots per vertex. `k == 0` is allowed (then every vertex stays at rest).
/// * `bone_matrices`: one 4x4 affine matrix per bone, **row-major** as numpy gives it
///   (`m[row][col]`, translation in column 3, bottom row `[0, 0, 0, 1]`, which is not read),
///   mapping rest-pose world space to posed world space. For a Blender bone that is
///   `pose_bone.matrix @ bone.matrix_local.inverted()` (both in armature space, pre-multiplied
///   by the armature's world matrix as needed).
///
/// Returns the `n` posed positions
/// `v'_i = sum_s w_is (M_{j_is} v_i) / sum_s w_is` over the used slots of row `i`.
/// Rows that already sum to 1 get exactly the textbook `sum_s w_is M_{j_is} v_i`; rows with
/// another positive sum are normalised (so a row summing to 0.5 does not shrink the vertex
/// toward the origin); rows whose weights sum to 0 keep their rest position.
///
/// Errors: `Shape` when `indices`/`weights` are not `n * k` long; `InvalidArgument` for an
/// index outside `-1..bones` (checked on every slot, used or not, as it signals a caller bug)
/// or a negative weight; `NonFinite` (with the count of bad numbers) for NaN/inf in
/// vertices, weights or matrices. Runs in parallel over vertices (rayon).
pub fn lbs(
    vertices: &[[f32; 3]],
    indices: &[i32],
    weights: &[f32],
    k: usize,
    bone_matrices: &[[[f32; 4]; 4]],
) -> Result<Vec<[f32; 3]>> {
    let n = vertices.len();
    let expected =
        n.checked_mul(k).ok_or_else(|| Error::Shape(format!("{n} vertices times k = {k} slots overflows")))?;
    if indices.len() != expected {
        return Err(Error::Shape(format!(
            "indices has {} entries, expected n * k = {n} * {k} = {expected}",
            indices.len()
        )));
    }
    if weights.len() != expected {
        return Err(Error::Shape(format!(
            "weights has {} entries, expected n * k = {n} * {k} = {expected}",
            weights.len()
        )));
    }

    let bad_vertices = vertices.par_iter().map(|v| v.iter().filter(|c| !c.is_finite()).count()).sum::<usize>();
    if bad_vertices > 0 {
        return Err(Error::NonFinite { what: "vertex", count: bad_vertices });
    }
    let bad_weights = weights.par_iter().filter(|w| !w.is_finite()).count();
    if bad_weights > 0 {
        return Err(Error::NonFinite { what: "weight", count: bad_weights });
    }
    // Only the three affine rows are used, so only they have to be finite.
    let bad_matrices =
        bone_matrices.iter().map(|m| m[..3].iter().flatten().filter(|c| !c.is_finite()).count()).sum::<usize>();
    if bad_matrices > 0 {
        return Err(Error::NonFinite { what: "bone matrix", count: bad_matrices });
    }

    let bones = bone_matrices.len();
    if let Some(pos) = indices.iter().position(|&j| j < -1 || (j >= 0 && j as usize >= bones)) {
        return Err(Error::InvalidArgument(format!(
            "vertex {} slot {} refers to bone {}, but there are {bones} bone matrices \
             (use -1 for an unused slot)",
            pos / k,
            pos % k,
            indices[pos]
        )));
    }
    if let Some(pos) = weights.iter().position(|&w| w < 0.0) {
        return Err(Error::InvalidArgument(format!(
            "vertex {} slot {} has negative weight {}",
            pos / k,
            pos % k,
            weights[pos]
        )));
    }

    if k == 0 {
        return Ok(vertices.to_vec());
    }

    let out = vertices
        .par_iter()
        .zip(indices.par_chunks(k).zip(weights.par_chunks(k)))
        .map(|(v, (idx, w))| {
            let (x, y, z) = (v[0] as f64, v[1] as f64, v[2] as f64);
            let mut acc = [0.0f64; 3];
            let mut sum = 0.0f64;
            for (&j, &wj) in idx.iter().zip(w) {
                if j < 0 || wj == 0.0 {
                    continue;
                }
                let m = &bone_matrices[j as usize];
                let wj = wj as f64;
                for (r, a) in acc.iter_mut().enumerate() {
                    let row = &m[r];
                    *a += wj * (row[0] as f64 * x + row[1] as f64 * y + row[2] as f64 * z + row[3] as f64);
                }
                sum += wj;
            }
            if sum > 0.0 {
                [(acc[0] / sum) as f32, (acc[1] / sum) as f32, (acc[2] / sum) as f32]
            } else {
                *v
            }
        })
        .collect();
    Ok(out)
}
