//! Inside or outside by the faces seen along the axes (the voxelization rule of Dionne & de
//! Lasa 2013): looking along an axis, a point inside sees the back of a face ahead of it, or the
//! front of one behind it. A point is inside when two of the three axes say so.
//!
//! Unlike ray parity, this counts no crossings: pieces inside pieces and pieces pushed into each
//! other are inside throughout, and an open mesh (a sleeve, a hand open at the wrist) spoils
//! only the axes that look out through its holes. Faces must be wound outward (each piece
//! consistently, outward by its enclosed volume).

use crate::mesh::visibility::RayMesh;
use glam::{DVec3, Vec3};

/// Does an axis say inside? `behind`, `ahead`: the component along the axis of the outward
/// normal of the nearest face behind and ahead of the point (`None`: no face there).
#[inline]
pub fn looks_inside(behind: Option<f64>, ahead: Option<f64>) -> bool {
    behind.is_some_and(|n| n < 0.0) || ahead.is_some_and(|n| n > 0.0)
}

/// Is `p` inside the triangles `t` with `keep(t)` of `rays` (see the module doc)? `normals`:
/// each input triangle's outward normal (any length), `reach` the farthest a face can be (mesh
/// unit: the mesh's size).
pub fn inside_by_faces(rays: &RayMesh, normals: &[DVec3], p: DVec3, reach: f32, keep: impl Fn(u32) -> bool) -> bool {
    let mut votes = 0;
    for axis in 0..3 {
        let mut dir = Vec3::ZERO;
        dir[axis] = 1.0;
        let nearest = |d: Vec3| {
            let hits = rays.ray_hits_tagged(p.as_vec3(), d, reach, &keep);
            hits.first().map(|h| normals[h.1 as usize][axis] * d[axis] as f64)
        };
        // Along the axis: the backward ray's component is along its own direction.
        let behind = nearest(-dir).map(|n| -n);
        if looks_inside(behind, nearest(dir)) {
            votes += 1;
        }
    }
    votes >= 2
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit box wound outward, and the same without its top and bottom (a sleeve).
    #[test]
    fn a_box_and_an_open_sleeve_hold_their_middle() {
        let (v, t) = crate::mesh::visibility::tests::unit_cube();
        let rays = RayMesh::new(&v, &t);
        let p = |i: usize| DVec3::from(v[i].map(f64::from));
        // unit_cube winds inward: the outward normals are the other way round.
        let normals: Vec<DVec3> = t
            .iter()
            .map(|f| (p(f[2] as usize) - p(f[0] as usize)).cross(p(f[1] as usize) - p(f[0] as usize)))
            .collect();
        let mid = DVec3::splat(0.5);
        assert!(inside_by_faces(&rays, &normals, mid, 10.0, |_| true));
        assert!(!inside_by_faces(&rays, &normals, DVec3::new(1.5, 0.5, 0.5), 10.0, |_| true));
        // Without the two faces across z (a sleeve along z): x and y still say inside.
        let side = |k: u32| normals[k as usize].z.abs() < 1e-9;
        assert!(inside_by_faces(&rays, &normals, mid, 10.0, side));
        assert!(!inside_by_faces(&rays, &normals, DVec3::new(0.5, 0.5, 1.5), 10.0, side));
    }
}
