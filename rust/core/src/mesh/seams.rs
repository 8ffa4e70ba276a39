//! Meshes that meet along a seam: a character split into objects (a head and a body sharing
//! the neck's vertices) is one surface, and heat must flow across the cut as it does across
//! the split seams of one mesh ([`crate::mesh::weld`]); solved apart, the two copies of a seam
//! vertex get unrelated weights and the surface cracks open when posed.

use crate::mesh::weld::weld;
use crate::mesh::{validate_mesh, Frame};
use crate::{Error, Result};

/// Most meshes [`touching_meshes`] takes (far more objects than a scene holds; bounds the memory).
pub const MAX_MESHES: usize = 1 << 24;

/// Group meshes that share at least `min_shared` vertex positions (welded within `tolerance`
/// of the bounding-box diagonal of all of them, as [`crate::weights::heat::heat_weights`] welds),
/// transitively. Clothes over a body or a prop in a hand share no vertex and stay apart.
///
/// Inputs: `vertices` `(n, 3)` of all meshes stacked, `mesh_of` `(n,)` the mesh of each
/// vertex (`< meshes`), `triangles` `(m, 3)` of all meshes stacked (indices into `vertices`;
/// they set the diagonal, [`Frame::of_mesh`], so a stray loose vertex far away does not widen
/// the weld until clothes "touch" the body; empty: all vertices set it), `tolerance`
/// (relative, >= 0), `min_shared` (>= 1; a few, so that two objects that happen to touch at a
/// point are not merged).
/// Output: `(meshes,)` group of each mesh, numbered `0..` in order of each group's first mesh;
/// a mesh with no vertices is its own group.
///
/// Errors: `Shape` (lengths differ), `InvalidArgument` (more than [`MAX_MESHES`], mesh index,
/// tolerance, min_shared),
/// `NonFinite`, `BadIndex` (a triangle past the end of `vertices`).
pub fn touching_meshes(
    vertices: &[[f32; 3]],
    mesh_of: &[u32],
    meshes: usize,
    triangles: &[[u32; 3]],
    tolerance: f64,
    min_shared: usize,
) -> Result<Vec<u32>> {
    if mesh_of.len() != vertices.len() {
        return Err(Error::Shape(format!("{} mesh indices for {} vertices", mesh_of.len(), vertices.len())));
    }
    if meshes > MAX_MESHES {
        return Err(Error::InvalidArgument(format!("{meshes} meshes; at most {MAX_MESHES} are taken")));
    }
    if let Some(&m) = mesh_of.iter().find(|&&m| m as usize >= meshes) {
        return Err(Error::InvalidArgument(format!("mesh index {m}, but there are {meshes} meshes")));
    }
    if !(tolerance.is_finite() && tolerance >= 0.0) || min_shared == 0 {
        return Err(Error::InvalidArgument(format!(
            "tolerance must be >= 0 and min_shared >= 1, got {tolerance} and {min_shared}"
        )));
    }
    if vertices.is_empty() {
        return Ok((0..meshes as u32).collect());
    }
    validate_mesh(vertices, triangles, false)?;
    let (map, _) = weld(&Frame::of_mesh(vertices, triangles).normalize(vertices), tolerance);
    // (welded vertex, mesh), once each: which meshes reach each welded position.
    let mut at: Vec<(u32, u32)> = map.iter().copied().zip(mesh_of.iter().copied()).collect();
    at.sort_unstable();
    at.dedup();
    let mut shared: std::collections::HashMap<(u32, u32), usize> = Default::default();
    for run in at.chunk_by(|a, b| a.0 == b.0) {
        for (i, a) in run.iter().enumerate() {
            for b in &run[i + 1..] {
                *shared.entry((a.1, b.1)).or_default() += 1;
            }
        }
    }
    let mut parent: Vec<usize> = (0..meshes).collect();
    fn root(parent: &[usize], mut x: usize) -> usize {
        while parent[x] != x {
            x = parent[x];
        }
        x
    }
    let mut pairs: Vec<(u32, u32)> = shared.into_iter().filter(|&(_, n)| n >= min_shared).map(|(p, _)| p).collect();
    pairs.sort_unstable();
    for (a, b) in pairs {
        let (ra, rb) = (root(&parent, a as usize), root(&parent, b as usize));
        parent[ra.max(rb)] = ra.min(rb);
    }
    let mut label = vec![u32::MAX; meshes];
    let mut next = 0;
    let mut out = Vec::with_capacity(meshes);
    for m in 0..meshes {
        let r = root(&parent, m);
        if label[r] == u32::MAX {
            label[r] = next;
            next += 1;
        }
        out.push(label[r]);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::primitives::capped_cylinder;

    /// Vertices of a capped cylinder with z below / above `cut`, each half keeping the ring on
    /// the cut (as when a mesh is separated into two objects along an edge loop).
    fn halves(cut: f32) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
        let (v, _) = capped_cylinder(0.5, 4.0, 9, 12);
        let low = v.iter().copied().filter(|p| p[2] <= cut + 1e-6).collect();
        let high = v.iter().copied().filter(|p| p[2] >= cut - 1e-6).collect();
        (low, high)
    }

    fn stack(parts: &[Vec<[f32; 3]>]) -> (Vec<[f32; 3]>, Vec<u32>) {
        let v = parts.concat();
        let m = parts.iter().enumerate().flat_map(|(i, p)| std::iter::repeat_n(i as u32, p.len())).collect();
        (v, m)
    }

    #[test]
    fn halves_meet_clothes_and_points_do_not() {
        let (low, high) = halves(2.0);
        let apart: Vec<[f32; 3]> = high.iter().map(|p| [p[0] + 3.0, p[1], p[2]]).collect();
        // A sleeve: the lower half grown by 1 %, around it but touching nowhere.
        let sleeve: Vec<[f32; 3]> = low.iter().map(|p| [p[0] * 1.01, p[1] * 1.01, p[2]]).collect();
        // One shared point only: below min_shared.
        let point = vec![high[high.len() - 1], [9.0, 9.0, 9.0], [9.0, 9.5, 9.0]];
        let (v, m) = stack(&[low.clone(), apart, high.clone(), sleeve, point]);
        let g = touching_meshes(&v, &m, 6, &[], 1e-5, 3).unwrap();
        // Mesh 5 has no vertex: its own group.
        assert_eq!(g, vec![0, 1, 0, 2, 3, 4]);
        // Transitive: low - high - (a third part sharing the top cap's ring with high).
        let top: Vec<[f32; 3]> = high.iter().copied().filter(|p| p[2] >= 4.0 - 1e-6).collect();
        let (v, m) = stack(&[top, low.clone(), high]);
        assert_eq!(touching_meshes(&v, &m, 3, &[], 1e-5, 3).unwrap(), vec![0, 0, 0]);
        // Split seams inside one mesh count once: a mesh repeating its own vertices shares
        // nothing with itself.
        let (v, m) = stack(&[[low.clone(), low.clone()].concat()]);
        assert_eq!(touching_meshes(&v, &m, 1, &[], 1e-5, 3).unwrap(), vec![0]);
    }

    /// Shared positions are counted once per pair of meshes: exactly `min_shared` of them join two
    /// meshes, one fewer does not, and a point split into copies inside one mesh (a seam) is
    /// still one point.
    #[test]
    fn shared_points_are_counted_once_each() {
        let (low, high) = halves(2.0);
        let ring: Vec<[f32; 3]> = high.iter().copied().filter(|p| (p[2] - 2.0).abs() < 1e-6).collect();
        assert!(ring.len() >= 4);
        let far = |k: usize| (0..k).map(|i| [9.0 + i as f32, 9.0, 9.0]).collect::<Vec<_>>();
        for (shared, joined) in [(3, true), (2, false)] {
            let part = [ring[..shared].to_vec(), far(3)].concat();
            let (v, m) = stack(&[low.clone(), part]);
            let g = touching_meshes(&v, &m, 2, &[], 1e-5, 3).unwrap();
            assert_eq!(g[0] == g[1], joined, "{shared} shared points");
        }
        // One point of the cut ring, split three ways in the second mesh: one shared point.
        let split = [vec![ring[0]; 3], far(3)].concat();
        let (v, m) = stack(&[low, split]);
        assert_eq!(touching_meshes(&v, &m, 2, &[], 1e-5, 3).unwrap(), vec![0, 1]);
    }

    /// Triangles over every vertex but the last (only which vertices faces use matters here).
    fn fan(n: usize) -> Vec<[u32; 3]> {
        (1..n as u32 - 2).map(|i| [0, i, i + 1]).collect()
    }

    /// A stray loose vertex far away sets no scale when the triangles are given: the sleeve
    /// 1 % outside the body stays apart (without them the weld tolerance grows with the box
    /// and the sleeve is "touching").
    #[test]
    fn stray_vertex_does_not_merge_clothes_with_the_body() {
        let (low, _) = halves(2.0);
        let sleeve: Vec<[f32; 3]> = low.iter().map(|p| [p[0] * 1.01, p[1] * 1.01, p[2]]).collect();
        let body = [low.clone(), vec![[1e5, 0.0, 0.0]]].concat();
        let (v, m) = stack(&[sleeve, body]); // the stray vertex is the last
        assert_eq!(touching_meshes(&v, &m, 2, &[], 1e-5, 3).unwrap(), vec![0, 0]);
        assert_eq!(touching_meshes(&v, &m, 2, &fan(v.len()), 1e-5, 3).unwrap(), vec![0, 1]);
        let bad = [[0, 1, v.len() as u32]];
        assert!(matches!(touching_meshes(&v, &m, 2, &bad, 1e-5, 3), Err(Error::BadIndex { .. })));
    }

    #[test]
    fn bad_input_is_an_error() {
        let (low, _) = halves(2.0);
        let m = vec![0u32; low.len()];
        assert!(matches!(touching_meshes(&low, &m[1..], 1, &[], 1e-5, 3), Err(Error::Shape(_))));
        assert!(matches!(touching_meshes(&low, &m, 0, &[], 1e-5, 3), Err(Error::InvalidArgument(_))));
        assert!(matches!(touching_meshes(&low, &m, 1, &[], -1.0, 3), Err(Error::InvalidArgument(_))));
        assert!(matches!(touching_meshes(&low, &m, 1, &[], 1e-5, 0), Err(Error::InvalidArgument(_))));
        let mut nan = low.clone();
        nan[2][0] = f32::NAN;
        assert!(matches!(touching_meshes(&nan, &m, 1, &[], 1e-5, 3), Err(Error::NonFinite { .. })));
        assert_eq!(touching_meshes(&[], &[], 2, &[], 1e-5, 3).unwrap(), vec![0, 1]);
    }
}
