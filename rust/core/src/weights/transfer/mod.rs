//! Skin weights copied from a body onto the clothes and accessories worn over it: Abdrashitov,
//! Raichstat, Monsen & Hill, "Robust Skin Weights Transfer via Weight Inpainting", SIGGRAPH
//! Asia 2023 Technical Communications.
//!
//! This module holds the entry point, its options and report; the stages are `matching`
//! (where the garment lies on the body) and `inpaint` (the rest, by a Laplacian solve).

mod inpaint;
mod matching;

use crate::mesh::cotan::triangle_cotangents;
use crate::mesh::islands::connected_components;
use crate::mesh::{validate_mesh, weld, Frame};
use crate::weights::influence::{insert_ranked, normalize_pruned, Influences};
use crate::{Error, Result};
use rayon::prelude::*;

/// Default [`TransferOptions::max_distance`] (the paper's 5 % of the diagonal).
pub const MAX_DISTANCE: f32 = 0.05;
/// Default [`TransferOptions::max_angle`] in degrees (the paper's 30).
pub const MAX_ANGLE: f32 = 30.0;

/// Options of [`transfer_weights`].
#[derive(Debug, Clone, PartialEq)]
pub struct TransferOptions {
    /// A garment vertex takes the body's weights where the body's surface is at most this far
    /// from it, relative to the body's bounding-box diagonal (>= 0). Default [`MAX_DISTANCE`].
    pub max_distance: f32,
    /// ... and where the garment's normal there is within this angle (degrees, 0..=180) of the
    /// body's (or of its opposite, see [`flipped`](Self::flipped)). Default [`MAX_ANGLE`].
    pub max_angle: f32,
    /// Normals pointing the opposite way match too: the inside of a garment with thickness,
    /// and open sheets whose winding says nothing of outside. Default true.
    pub flipped: bool,
    /// Bones kept per vertex (>= 1). Default 4.
    pub max_influences: usize,
    /// Weld distance of the garment's vertices, relative to its bbox diagonal. Default 1e-5.
    pub weld_tolerance: f32,
}

impl Default for TransferOptions {
    fn default() -> Self {
        TransferOptions {
            max_distance: MAX_DISTANCE,
            max_angle: MAX_ANGLE,
            flipped: true,
            max_influences: 4,
            weld_tolerance: 1e-5,
        }
    }
}

/// What [`transfer_weights`] did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TransferReport {
    /// Garment vertices (input) that took the body's weights where they lie on it.
    pub matched: usize,
    /// Garment vertices whose weights were inpainted.
    pub inpainted: usize,
    /// Garment vertices of pieces where no vertex matched: the weights of the nearest point of
    /// the body, whatever its distance and normal.
    pub nearest: usize,
    /// The inpainting system needed more regularization than the first attempt.
    pub regularized: bool,
}

/// Transfer skin weights from a body onto a garment (Abdrashitov et al. 2023).
///
/// Inputs: the body's `body_vertices` `(nb, 3)`, `body_triangles` `(mb, 3)` and weights
/// `body_weights` (`nb` rows of top-k influences, as the other methods return); the garment's
/// `vertices` `(n, 3)` and `triangles` `(m, 3)`, in the body's unit and space.
/// Output: [`Influences`] `(n, max_influences)`, every row non-empty and summing to 1, and a
/// [`TransferReport`].
///
/// Method:
/// 1. matching: each garment vertex's nearest point on the body; where it lies within
///    [`TransferOptions::max_distance`] and the garment's normal is within
///    [`TransferOptions::max_angle`] of the body's face normal there, the vertex takes the
///    body's weights at that point (barycentric interpolation of the triangle's vertices);
/// 2. inpainting: the other vertices' weights minimize `tr(W^T Q W)` with the matched rows
///    fixed, `Q = L + L M^-1 L` (`L` the cotangent stiffness, `M` the lumped mass of the
///    garment welded at split seams: Dirichlet plus Laplacian energy, as the paper), one sparse
///    Cholesky factor for every bone; a piece of the garment with no matched vertex takes each
///    vertex's nearest point's weights instead;
/// 3. clipped to `[0, 1]`, top k, normalized.
///
/// Known limits: the paper's optional smoothing of the inpainted region afterwards is not
/// done; a garment far from the body (a hat above the head) matches nowhere and takes its
/// nearest points' weights.
///
/// Errors: empty or non-finite meshes, bad indices, body weights of another row count or with
/// a negative or non-finite weight, options out of range.
pub fn transfer_weights(
    body_vertices: &[[f32; 3]],
    body_triangles: &[[u32; 3]],
    body_weights: &Influences,
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    opts: &TransferOptions,
) -> Result<(Influences, TransferReport)> {
    validate(body_vertices, body_triangles, body_weights, vertices, triangles, opts)?;
    let mut report = TransferReport::default();
    // The garment welded at split seams, in the body's unit frame.
    let body_frame = Frame::of_mesh(body_vertices, body_triangles);
    let garment_frame = Frame::of_mesh(vertices, triangles);
    let pos = body_frame.normalize(vertices);
    let (map, wpos) = weld(&pos, opts.weld_tolerance as f64 * garment_frame.diagonal / body_frame.diagonal);
    let tris: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| t.map(|i| map[i as usize]))
        .filter(|w| {
            w[0] != w[1]
                && w[1] != w[2]
                && w[0] != w[2]
                && triangle_cotangents(wpos[w[0] as usize], wpos[w[1] as usize], wpos[w[2] as usize]).is_some()
        })
        .collect();
    let body = matching::Body::new(body_vertices, body_triangles, body_weights, &body_frame);
    let matched = matching::match_vertices(&body, &wpos, &tris, opts);
    let (labels, npieces) = connected_components(wpos.len(), &tris);
    let mut any = vec![false; npieces];
    for (m, &l) in matched.iter().zip(&labels) {
        any[l as usize] |= m.is_some();
    }
    // Pieces that match nowhere: every vertex its nearest point's weights.
    let rows: Vec<Option<Vec<(u32, f64)>>> = matched
        .into_par_iter()
        .enumerate()
        .map(|(v, m)| m.or_else(|| (!any[labels[v] as usize]).then(|| body.nearest_weights(wpos[v]))))
        .collect();
    let solved = inpaint::inpaint(&wpos, &tris, &rows, &mut report.regularized);
    let k = opts.max_influences;
    let mut welded = Influences::empty(wpos.len(), k);
    welded.indices.par_chunks_mut(k).zip(welded.weights.par_chunks_mut(k)).zip(solved.par_iter()).for_each(
        |((idx, w), row)| {
            let mut used = 0;
            for &(j, x) in row {
                used = insert_ranked(j as i32, x.clamp(0.0, 1.0) as f32, idx, w, used);
            }
            normalize_pruned(idx, w, used, 1e-3);
        },
    );
    let mut out = Influences::empty(vertices.len(), k);
    for (i, &w) in map.iter().enumerate() {
        let (si, sw) = welded.row(w as usize);
        out.indices[i * k..(i + 1) * k].copy_from_slice(si);
        out.weights[i * k..(i + 1) * k].copy_from_slice(sw);
        match &rows[w as usize] {
            Some(_) if any[labels[w as usize] as usize] => report.matched += 1,
            Some(_) => report.nearest += 1,
            None => report.inpainted += 1,
        }
    }
    Ok((out, report))
}

/// Check the inputs and options of [`transfer_weights`].
fn validate(
    body_vertices: &[[f32; 3]],
    body_triangles: &[[u32; 3]],
    body_weights: &Influences,
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    opts: &TransferOptions,
) -> Result<()> {
    validate_mesh(body_vertices, body_triangles, true)?;
    validate_mesh(vertices, triangles, false)?;
    if body_weights.n() != body_vertices.len() || body_weights.weights.len() != body_weights.indices.len() {
        return Err(Error::Shape(format!(
            "body weights for {} vertices, but the body has {}",
            body_weights.n(),
            body_vertices.len()
        )));
    }
    if let Some(&w) = body_weights.weights.iter().find(|&&w| !(w.is_finite() && w >= 0.0)) {
        return Err(Error::InvalidArgument(format!("body weights must be finite and >= 0, got {w}")));
    }
    if !(opts.max_distance.is_finite() && opts.max_distance >= 0.0) {
        return Err(Error::InvalidArgument(format!("max_distance must be >= 0, got {}", opts.max_distance)));
    }
    if !(opts.max_angle.is_finite() && (0.0..=180.0).contains(&opts.max_angle)) {
        return Err(Error::InvalidArgument(format!("max_angle must be in [0, 180], got {}", opts.max_angle)));
    }
    if opts.max_influences == 0 {
        return Err(Error::InvalidArgument("max_influences must be >= 1".into()));
    }
    if !(opts.weld_tolerance.is_finite() && opts.weld_tolerance >= 0.0) {
        return Err(Error::InvalidArgument(format!("weld_tolerance must be >= 0, got {}", opts.weld_tolerance)));
    }
    Ok(())
}
