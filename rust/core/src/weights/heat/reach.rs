//! Bones of imported rigs reach their children.
//!
//! glTF (and FBX) store joints, not bones. Blender's importer gives every joint a tail along
//! the joint's local Y axis, which on a limb often points out of it: the Fox sample's upper
//! arm points forward while its leg goes down to the forearm's head. On such a rig a bone
//! really spans from its head to the heads of its children; [`child_segments`] lists those
//! spans, and [`crate::weights::heat`] uses the ones lying inside the mesh in place of head -> tail.
//! A bone with no children (a head, a tail tip, a hand) has no child to reach; its invented
//! tail may point anywhere (the Fox's head bone points up while its snout lies ahead), so it
//! also continues its parent's line into the mesh ([`leaf_continuation`]).

use super::pieces::{piece_contains_bone, PieceStats};
use crate::mesh::visibility::RayMesh;
use glam::DVec3;
use rayon::prelude::*;

/// Distance (unit frame) under which a child's head counts as starting at a bone's tail or head.
const REACH_TOLERANCE: f64 = 1e-5;

/// The continuation of a childless bone's parent line: from the bone's head along
/// `head - parent head`, as long as the bone itself, cut where the ray first meets the mesh.
///
/// Inputs: the mesh's rays `rm`, the bone's `head` and `tail`, its parent's head `parent_head`
/// (unit frame). Output: the segment's end (it starts at `head`), or `None` when the two heads
/// coincide or the head lies on the surface (the line leaves the mesh at once).
pub(crate) fn leaf_continuation(rm: &RayMesh, head: DVec3, tail: DVec3, parent_head: DVec3) -> Option<DVec3> {
    let dir = (head - parent_head).normalize_or_zero();
    let len = head.distance(tail);
    if dir == DVec3::ZERO || !(len > REACH_TOLERANCE) {
        return None;
    }
    let hit = rm.ray_hits(head.as_vec3(), dir.as_vec3(), len as f32).first().map_or(len, |&t| t as f64);
    (hit > REACH_TOLERANCE).then(|| head + dir * hit.min(len))
}

/// Spans from bones to children that do not start at the bone's tail.
///
/// Inputs: bone `heads` / `tails` `(b,)`, `parents` `(b,)` (validated, `-1` for roots), and
/// `tol`, the distance under which two points coincide. Output: `(spans, tail_child)`:
/// `spans` lists `(bone, child head)` for every child whose head lies farther than `tol`
/// from both the bone's tail and its head (a child at the same head adds no extent), in
/// bone order; `tail_child[b]` says some child of `b` starts at its tail (a connected chain,
/// whose head -> tail segment is real).
pub fn child_segments(heads: &[DVec3], tails: &[DVec3], parents: &[i32], tol: f64) -> (Vec<(usize, DVec3)>, Vec<bool>) {
    let mut spans = Vec::new();
    let mut tail_child = vec![false; heads.len()];
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); heads.len()];
    for (c, &p) in parents.iter().enumerate() {
        if p >= 0 {
            children[p as usize].push(c);
        }
    }
    for (b, kids) in children.iter().enumerate() {
        for &c in kids {
            if heads[c].distance(tails[b]) <= tol {
                tail_child[b] = true;
            } else if heads[c].distance(heads[b]) > tol {
                spans.push((b, heads[c]));
            }
        }
    }
    (spans, tail_child)
}

/// The segments standing for the bones on an imported rig (see [`crate::weights::heat::HeatOptions::parents`]):
/// per bone, its spans to children ([`child_segments`]) that lie inside a
/// piece of the mesh (as in [`piece_contains_bone`]), plus head -> tail when a child starts
/// at the tail or no span is inside, plus for a bone with a parent and no children its
/// [`leaf_continuation`] when that lies inside. Returns `(segments, bone of each segment)`.
pub(crate) fn reach_segments(
    rm: &RayMesh,
    bones: &[(DVec3, DVec3)],
    parents: &[i32],
    pieces: &[PieceStats],
    labels: &[u32],
    tris: &[[u32; 3]],
) -> (Vec<(DVec3, DVec3)>, Vec<u32>) {
    let heads: Vec<DVec3> = bones.iter().map(|s| s.0).collect();
    let tails: Vec<DVec3> = bones.iter().map(|s| s.1).collect();
    let (spans, tail_child) = child_segments(&heads, &tails, parents, REACH_TOLERANCE);
    let mut childless = vec![true; bones.len()];
    for &p in parents.iter().filter(|&&p| p >= 0) {
        childless[p as usize] = false;
    }
    // Every candidate segment beside head -> tail: spans to children, then leaf continuations.
    let leaves = (0..bones.len())
        .filter(|&j| childless[j] && parents[j] >= 0)
        .filter_map(|j| leaf_continuation(rm, heads[j], tails[j], heads[parents[j] as usize]).map(|end| (j, end)));
    let extra: Vec<(usize, DVec3)> = spans.iter().copied().chain(leaves).collect();
    let inside: Vec<bool> = extra
        .par_iter()
        .map(|&(j, c)| {
            let seg = [(heads[j], c)];
            pieces.iter().enumerate().any(|(i, p)| p.active && piece_contains_bone(rm, i as u32, p, &seg, labels, tris))
        })
        .collect();
    let (mut segs, mut owner) = (Vec::new(), Vec::new());
    for j in 0..bones.len() {
        let mine: Vec<DVec3> =
            spans.iter().zip(&inside).filter(|(s, &ins)| s.0 == j && ins).map(|(s, _)| s.1).collect();
        if mine.is_empty() || tail_child[j] {
            segs.push(bones[j]);
            owner.push(j as u32);
        }
        for c in mine {
            segs.push((heads[j], c));
            owner.push(j as u32);
        }
    }
    for (&(j, end), _) in extra[spans.len()..].iter().zip(&inside[spans.len()..]).filter(|(_, &ins)| ins) {
        segs.push((heads[j], end));
        owner.push(j as u32);
    }
    (segs, owner)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::validate_parents;

    #[test]
    fn a_leaf_continues_its_parent_line_up_to_the_surface() {
        let (v, t) = crate::mesh::visibility::tests::unit_cube();
        let rm = RayMesh::new(&v, &t);
        let (parent, head) = (DVec3::new(0.5, 0.5, 0.0), DVec3::new(0.5, 0.5, 0.5));
        // A sideways invented tail of length 0.2: the line goes up 0.2, inside the cube.
        let b = leaf_continuation(&rm, head, head + DVec3::new(0.2, 0.0, 0.0), parent).unwrap();
        assert!(b.distance(DVec3::new(0.5, 0.5, 0.7)) < 1e-6, "{b}");
        // Length 2: cut where the line leaves the cube (z = 1).
        let b = leaf_continuation(&rm, head, head + DVec3::new(0.0, 2.0, 0.0), parent).unwrap();
        assert!(b.distance(DVec3::new(0.5, 0.5, 1.0)) < 1e-5, "{b}");
        // No line (heads coincide), no length, or a head on the surface: nothing.
        assert!(leaf_continuation(&rm, head, head + DVec3::X, head).is_none());
        assert!(leaf_continuation(&rm, head, head, parent).is_none());
        let top = DVec3::new(0.5, 0.5, 1.0);
        assert!(leaf_continuation(&rm, top, top + DVec3::X, parent).is_none());
    }

    #[test]
    fn spans_skip_connected_and_coincident_children() {
        // 0: root at the origin with an invented tail along +y; 1 starts away from it (span);
        // 2 starts at 1's tail (connected); 3 starts at 1's head (no extent).
        let heads = [DVec3::ZERO, DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, 2.0), DVec3::new(0.0, 0.0, 1.0)];
        let tails = [
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 0.0, 2.0),
            DVec3::new(0.0, 0.0, 3.0),
            DVec3::new(1.0, 0.0, 1.0),
        ];
        let parents = [-1, 0, 1, 1];
        validate_parents(&parents, 4).unwrap();
        let (spans, tail_child) = child_segments(&heads, &tails, &parents, 1e-6);
        assert_eq!(spans, vec![(0, heads[1])]);
        assert_eq!(tail_child, vec![false, true, false, false]);
    }
}
