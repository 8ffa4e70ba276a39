//! A triangle mesh read as a solid: the union of its pieces.
//!
//! Game and kit-built models are made of closed parts pushed into each other (a robot's
//! limbs, a bunny's ears and tail). Ray parity over all their triangles at once calls the
//! overlap "outside", and a ray from inside the body stops at a part's surface buried in it.
//! Here every piece (connected after welding, so split seams do not cut it) is crossed on its
//! own, and a ray reports only where it enters or leaves the union of the pieces: for a mesh
//! in one piece, exactly its own hits.

use crate::mesh::islands::connected_components;
use crate::mesh::visibility::RayMesh;
use crate::mesh::weld::weld;
use glam::{DVec3, Vec3};

/// Fixed, irrational directions for the parity test.
#[allow(clippy::approx_constant)] // rounded unit vectors, not the constant 1/sqrt(2)
pub const PARITY_DIRS: [[f32; 3]; 7] = [
    [0.5773, 0.6123, 0.5402],
    [-0.7071, 0.3162, 0.6325],
    [0.1313, -0.9121, 0.3884],
    [0.8017, -0.2672, -0.5345],
    [-0.3015, -0.4264, -0.8528],
    [-0.6547, 0.7276, -0.2041],
    [0.2182, 0.1091, -0.9698],
];

/// Ray queries against the union of a mesh's pieces.
pub struct Solid {
    /// Every triangle, for the ray casts.
    pub rays: RayMesh,
    /// Piece of every input triangle.
    piece: Vec<u32>,
    /// Number of pieces (labels are `< pieces`).
    pieces: usize,
    /// Hits closer than this along one ray count once (a ray through a shared edge meets both
    /// neighbours); also the widest gap between two pieces that still counts as closed.
    merge: f32,
}

impl Solid {
    /// Build from `vertices` `(n, 3)` (the unit frame of the mesh, or any unit with `weld` and
    /// `merge` in it) and `triangles` `(m, 3)` (indices validated); vertices within `weld`
    /// join pieces.
    pub fn new(vertices: &[[f32; 3]], triangles: &[[u32; 3]], weld_distance: f64, merge: f32) -> Solid {
        // The pieces (a weld and a search, one thread) and the ray hierarchy side by side.
        let ((piece, pieces), rays) =
            rayon::join(|| pieces_of(vertices, triangles, weld_distance), || RayMesh::new(vertices, triangles));
        Solid { rays, piece, pieces, merge }
    }

    /// Number of pieces.
    pub fn pieces(&self) -> usize {
        self.pieces
    }

    /// Distances in `[0, max_dist]` along the ray from `origin` (direction `dir`, any length)
    /// where it enters or leaves the union of the pieces, ascending.
    ///
    /// Per piece, its own hits (merged within `merge`) give the stretches of the ray inside it:
    /// an odd count means the origin is inside that piece. The union of the stretches is swept
    /// in order; pieces that touch (one ends where the next begins, within `merge`) leave no gap.
    pub fn hits(&self, origin: Vec3, dir: Vec3, max_dist: f32) -> Vec<f32> {
        let mut tagged = self.rays.ray_hits_tagged(origin, dir, max_dist, |_| true);
        if self.pieces <= 1 {
            return merged(tagged.into_iter().map(|h| h.0), self.merge);
        }
        tagged.sort_by(|a, b| self.piece[a.1 as usize].cmp(&self.piece[b.1 as usize]).then(a.0.total_cmp(&b.0)));
        // Stretches as events (distance, +1 enter / -1 leave); `depth` counts the pieces the
        // origin is inside.
        let mut events: Vec<(f32, i32)> = Vec::with_capacity(tagged.len());
        let mut depth = 0i32;
        let mut i = 0;
        while i < tagged.len() {
            let p = self.piece[tagged[i].1 as usize];
            let mut j = i;
            while j < tagged.len() && self.piece[tagged[j].1 as usize] == p {
                j += 1;
            }
            let h = merged(tagged[i..j].iter().map(|h| h.0), self.merge);
            let inside = h.len() % 2 == 1;
            depth += inside as i32;
            for (k, &t) in h.iter().enumerate() {
                // Inside: leave, enter, leave, ...; outside: enter, leave, ...
                let enter = (k % 2 == 1) == inside;
                events.push((t, if enter { 1 } else { -1 }));
            }
            i = j;
        }
        // Enter before leave at one distance, so touching pieces leave no gap.
        events.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
        let mut out: Vec<f32> = Vec::new();
        for (t, step) in events {
            let was_inside = depth > 0;
            depth += step;
            if was_inside != (depth > 0) {
                // A leave followed by an enter within `merge`: no gap, drop both.
                // (Crossings alternate, so the last one before an enter is a leave.)
                if depth > 0 && out.last().is_some_and(|&l| t - l <= self.merge) {
                    out.pop();
                } else {
                    out.push(t);
                }
            }
        }
        out
    }

    /// Ray-parity inside test: the union is crossed an odd number of times along a majority
    /// of [`PARITY_DIRS`] (reliable for closed pieces, approximate for open ones).
    pub fn inside(&self, p: DVec3, max_dist: f32) -> bool {
        let odd = PARITY_DIRS
            .iter()
            .filter(|d| self.hits(p.as_vec3(), Vec3::from_array(**d), max_dist).len() % 2 == 1)
            .count();
        2 * odd > PARITY_DIRS.len()
    }
}

/// Sorted distances with those closer than `merge` to the previous kept one dropped.
fn merged(sorted: impl Iterator<Item = f32>, merge: f32) -> Vec<f32> {
    let mut out: Vec<f32> = Vec::new();
    for t in sorted {
        if out.last().is_none_or(|&l| t - l > merge) {
            out.push(t);
        }
    }
    out
}

/// The piece of every triangle of `vertices` / `triangles` once vertices within
/// `weld_distance` are joined (numbered in the order the triangles reach them), and their count.
fn pieces_of(vertices: &[[f32; 3]], triangles: &[[u32; 3]], weld_distance: f64) -> (Vec<u32>, usize) {
    let pos: Vec<DVec3> = vertices.iter().map(|p| Vec3::from_array(*p).as_dvec3()).collect();
    let (map, welded) = weld(&pos, weld_distance);
    let tris: Vec<[u32; 3]> = triangles.iter().map(|t| t.map(|i| map[i as usize])).collect();
    let (labels, _) = connected_components(welded.len(), &tris);
    // Renumber to the pieces triangles use.
    let mut renumber = vec![u32::MAX; welded.len()];
    let mut pieces = 0u32;
    let piece = tris
        .iter()
        .map(|t| {
            let l = labels[t[0] as usize] as usize;
            if renumber[l] == u32::MAX {
                renumber[l] = pieces;
                pieces += 1;
            }
            renumber[l]
        })
        .collect();
    (piece, pieces as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::primitives::{add_box, capped_cylinder, split_flat};

    #[test]
    fn overlapping_boxes_are_one_solid() {
        // Two boxes overlapping on x in [0.4, 0.6]; a third one apart.
        let (mut v, mut t) = (Vec::new(), Vec::new());
        add_box(&mut v, &mut t, [0.0, 0.0, 0.0], [0.6, 0.2, 0.2]);
        add_box(&mut v, &mut t, [0.4, 0.05, 0.05], [1.0, 0.15, 0.15]);
        add_box(&mut v, &mut t, [1.5, 0.0, 0.0], [1.7, 0.2, 0.2]);
        let s = Solid::new(&v, &t, 1e-6, 1e-6);
        assert_eq!(s.pieces(), 3);
        // Along x through the overlap: enter 0, leave 1 (the buried faces at 0.4 and 0.6 are
        // not reported), then the third box.
        let h = s.hits(Vec3::new(-1.0, 0.1, 0.1), Vec3::X, 10.0);
        assert_eq!(h.len(), 4, "{h:?}");
        for (a, b) in h.iter().zip([1.0, 2.0, 2.5, 2.7]) {
            assert!((a - b).abs() < 1e-4, "{h:?}");
        }
        // From inside the overlap: leave at 1 - 0.5, then the third box.
        let h = s.hits(Vec3::new(0.5, 0.1, 0.1), Vec3::X, 10.0);
        assert_eq!(h.len(), 3, "{h:?}");
        assert!((h[0] - 0.5).abs() < 1e-4);
        // The overlap is inside (plain parity over all triangles says outside).
        assert!(s.inside(DVec3::new(0.5, 0.1, 0.1), 10.0));
        assert!(s.inside(DVec3::new(0.2, 0.1, 0.1), 10.0) && s.inside(DVec3::new(0.8, 0.1, 0.1), 10.0));
        assert!(!s.inside(DVec3::new(1.2, 0.1, 0.1), 10.0) && !s.inside(DVec3::new(0.8, 0.19, 0.1), 10.0));
    }

    #[test]
    fn inside_takes_the_majority_of_directions() {
        // A unit box without its top: from above the opening 3 of the 7 directions go in and
        // cross a wall once (odd), the other 4 miss; the majority says outside.
        let (mut v, mut t) = (Vec::new(), Vec::new());
        add_box(&mut v, &mut t, [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
        t.drain(2..4); // z = hi
        let s = Solid::new(&v, &t, 1e-6, 1e-6);
        let above = DVec3::new(0.5, 0.5, 1.2);
        let odd = PARITY_DIRS.iter().filter(|d| s.hits(above.as_vec3(), Vec3::from_array(**d), 10.0).len() % 2 == 1);
        assert_eq!(odd.count(), 3);
        assert!(!s.inside(above, 10.0));
        assert!(s.inside(DVec3::new(0.5, 0.5, 0.5), 10.0));
    }

    #[test]
    fn touching_pieces_leave_no_gap_and_one_piece_is_its_own_hits() {
        let (mut v, mut t) = (Vec::new(), Vec::new());
        add_box(&mut v, &mut t, [0.0, 0.0, 0.0], [0.5, 0.2, 0.2]);
        add_box(&mut v, &mut t, [0.5, 0.02, 0.02], [1.0, 0.18, 0.18]);
        // Two pieces (no shared vertex) face to face at x = 0.5: the ray passes through.
        let s = Solid::new(&v, &t, 1e-6, 1e-6);
        assert_eq!(s.pieces(), 2);
        let h = s.hits(Vec3::new(-1.0, 0.07, 0.13), Vec3::X, 10.0);
        assert_eq!(h.len(), 2, "{h:?}");
        // A hair's gap between them (under the merge distance) is no gap either.
        let (mut v, mut t) = (Vec::new(), Vec::new());
        add_box(&mut v, &mut t, [0.0, 0.0, 0.0], [0.5, 0.2, 0.2]);
        add_box(&mut v, &mut t, [0.5000005, 0.02, 0.02], [1.0, 0.18, 0.18]);
        let s = Solid::new(&v, &t, 1e-6, 1e-6);
        let h = s.hits(Vec3::new(-1.0, 0.07, 0.13), Vec3::X, 10.0);
        assert_eq!(h.len(), 2, "{h:?}");
        // A flat-shaded cylinder (every triangle its own vertices) welds into one piece.
        let (cv, ct) = capped_cylinder(0.5, 2.0, 8, 12);
        let (cv, ct) = split_flat(&cv, &ct).unwrap();
        let one = Solid::new(&cv, &ct, 1e-6, 1e-6);
        assert_eq!(one.pieces(), 1);
        let (o, d) = (Vec3::new(0.1, -0.05, -1.0), Vec3::new(0.01, 0.02, 1.0));
        assert_eq!(one.hits(o, d, 10.0), merged(one.rays.ray_hits(o, d, 10.0).into_iter(), 1e-6));
    }
}
