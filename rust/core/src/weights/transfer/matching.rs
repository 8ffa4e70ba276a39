//! Where a garment lies on the body (Abdrashitov et al. 2023, section 3.1).
//!
//! Inputs: the body (vertices, triangles, top-k weights), the garment's welded vertices and
//! triangles in the body's unit frame (bounding box centred, diagonal 1). Output: per garment
//! vertex, the body's weights at its nearest point on the body when that point lies within
//! `max_distance` and the normals agree within `max_angle` (or its opposite, when `flipped`),
//! else `None`.
//!
//! Method: the nearest point comes from the BVH of the body's triangles
//! ([`RayMesh::nearest_point`]); the body's normal there is its triangle's, wound outward (each
//! piece consistently, [`orient_faces`], outward by its enclosed volume); the garment's is its
//! area-weighted vertex normal, outward the same way; the weights are the barycentric blend of
//! the triangle's three vertices' rows.

use super::TransferOptions;
use crate::mesh::islands::connected_components;
use crate::mesh::orient::{orient_faces, piece_volumes, vertex_normals};
use crate::mesh::visibility::RayMesh;
use crate::mesh::Frame;
use crate::weights::influence::Influences;
use glam::DVec3;
use rayon::prelude::*;

/// The body, ready for nearest-point queries.
pub(super) struct Body<'a> {
    rays: RayMesh,
    tris: &'a [[u32; 3]],
    /// Outward unit normal of every input triangle (zero for a degenerate one).
    normals: Vec<DVec3>,
    weights: &'a Influences,
}

impl<'a> Body<'a> {
    pub fn new(vertices: &[[f32; 3]], tris: &'a [[u32; 3]], weights: &'a Influences, frame: &Frame) -> Body<'a> {
        let pos = frame.normalize(vertices);
        let (labels, npieces) = connected_components(pos.len(), tris);
        let (oriented, _) = orient_faces(pos.len(), tris);
        let volumes = piece_volumes(&pos, &oriented, &labels, npieces);
        let normals = oriented
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| pos[i as usize]);
                let s = if volumes[labels[t[0] as usize] as usize] < 0.0 { -1.0 } else { 1.0 };
                ((b - a).cross(c - a) * s).normalize_or_zero()
            })
            .collect();
        let pos32: Vec<[f32; 3]> = pos.iter().map(|p| p.as_vec3().to_array()).collect();
        Body { rays: RayMesh::new(&pos32, tris), tris, normals, weights }
    }

    /// The body's weights at its point nearest to `p` (no limit): `(bone, weight)` pairs.
    pub fn nearest_weights(&self, p: DVec3) -> Vec<(u32, f64)> {
        self.nearest(p, f32::INFINITY).map_or_else(Vec::new, |(t, _, bary)| self.blend(t, bary))
    }

    fn nearest(&self, p: DVec3, max_dist: f32) -> Option<(u32, f32, [f32; 3])> {
        self.rays.nearest_point(p.as_vec3(), max_dist)
    }

    /// The barycentric blend of triangle `t`'s vertices' weights.
    fn blend(&self, t: u32, bary: [f32; 3]) -> Vec<(u32, f64)> {
        let mut out: Vec<(u32, f64)> = Vec::new();
        for (&v, &b) in self.tris[t as usize].iter().zip(&bary) {
            let (idx, w) = self.weights.row(v as usize);
            for (&j, &x) in idx.iter().zip(w) {
                if j >= 0 && x > 0.0 {
                    match out.iter_mut().find(|e| e.0 == j as u32) {
                        Some(e) => e.1 += (b.max(0.0) * x) as f64,
                        None => out.push((j as u32, (b.max(0.0) * x) as f64)),
                    }
                }
            }
        }
        out
    }
}

/// Per garment vertex (`wpos`, unit frame of the body; `tris` its triangles), the body's
/// weights where it lies on the body (see the module doc), else `None`.
pub(super) fn match_vertices(
    body: &Body,
    wpos: &[DVec3],
    tris: &[[u32; 3]],
    opts: &TransferOptions,
) -> Vec<Option<Vec<(u32, f64)>>> {
    let (labels, npieces) = connected_components(wpos.len(), tris);
    let (oriented, _) = orient_faces(wpos.len(), tris);
    let normals = vertex_normals(wpos, &oriented, &labels, npieces);
    let cos_max = (opts.max_angle as f64).to_radians().cos();
    wpos.par_iter()
        .zip(normals.par_iter())
        .map(|(&p, &n)| {
            let (t, _, bary) = body.nearest(p, opts.max_distance)?;
            let c = n.dot(body.normals[t as usize]);
            let agrees = n == DVec3::ZERO || c >= cos_max - 1e-9 || (opts.flipped && -c >= cos_max - 1e-9);
            agrees.then(|| body.blend(t, bary))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One body triangle in the z = 0 plane facing +z, weighted 1 on bone 0 at vertex 0 and on
    /// bone 1 at vertices 1 and 2.
    #[test]
    fn nearest_point_blends_the_triangle_and_respects_distance_and_normals() {
        let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.3, 0.3, -0.01]];
        let t = [[0u32, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]];
        let w = Influences { k: 1, indices: vec![0, 1, 1, 1], weights: vec![1.0, 1.0, 1.0, 1.0] };
        let frame = Frame { centre: DVec3::ZERO, diagonal: 1.0 };
        let body = Body::new(&v, &t, &w, &frame);
        let blend = body.nearest_weights(DVec3::new(0.25, 0.25, 0.5));
        let share = |j: u32| blend.iter().find(|e| e.0 == j).map_or(0.0, |e| e.1);
        assert!((share(0) - 0.5).abs() < 1e-4 && (share(1) - 0.5).abs() < 1e-4, "{blend:?}");
        assert!(body.nearest(DVec3::new(0.25, 0.25, 0.5), 0.1).is_none());
        assert!(body.nearest(DVec3::new(0.25, 0.25, 0.05), 0.1).is_some());
    }
}
