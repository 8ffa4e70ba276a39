//! Bones of imported rigs reach their children.
//!
//! glTF (and FBX) store joints, not bones. Blender's importer gives every joint a tail along
//! the joint's local Y axis, which on a limb often points out of it: the Fox sample's upper
//! arm points forward while its leg goes down to the forearm's head. On such a rig a bone
//! really spans from its head to the heads of its children; [`child_segments`] lists those
//! spans, and [`crate::weights::heat`] uses the ones lying inside the mesh in place of head -> tail.
//! A bone with no children (a head, a tail tip, a hand) has no child to reach. When the rig's
//! tails are the importer's guesses (the bones with children do not point at them,
//! [`tails_aim_at_children`]), a leaf's tail may point anywhere too (the Fox's head bone points
//! up while its snout lies ahead), so it also continues its parent's line into the mesh
//! ([`leaf_continuation`]). When they point at their children, the joints' axes are the
//! author's bones (a rig made in Blender and exported), and a leaf's tail is trusted: a
//! dragon's head bone pointing forward into its face keeps the face, where the neck's line
//! would run up through the top of the head that the artist gave to the neck.
//!
//! A childless bone's segments are still inventions in part (an importer gives a root joint
//! with no child a 1-unit tail): where one runs into another bone, it ends at the first point
//! nearer to that bone than to its own head ([`end_before_other_bones`]). A round monster's
//! root joint, its 1-unit tail straight up through the head bone, otherwise ties with the head
//! bone over the whole head and takes half of it, eyes and ears included.

use super::pieces::{piece_contains_bone, PieceStats};
use crate::mesh::segment::closest_point_on_segment;
use crate::mesh::visibility::RayMesh;
use glam::DVec3;
use rayon::prelude::*;

/// Distance (unit frame) under which a child's head counts as starting at a bone's tail or head.
const REACH_TOLERANCE: f64 = 1e-5;
/// A childless bone's invented segment runs into another bone when it comes within this
/// fraction of its length of it ([`end_before_other_bones`]).
const MEET: f64 = 0.05;
/// A tail points at a child when its direction is within this cosine (about 8 degrees) of the
/// direction to the child's head ([`tails_aim_at_children`]).
const AIM_COS: f64 = 0.99;

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

/// Where an invented segment from `head` to `end` stops: where it runs into another bone
/// (comes within [`MEET`] times its length of one of the `others` segments), it ends at the
/// first point nearer to that bone than to `head`; elsewhere it keeps `end`.
///
/// Inputs: `head`, `end` and `others` in the unit frame. Output: the new end, on the segment.
/// Segments that meet `head` (within [`REACH_TOLERANCE`]: the parent's span or tail ending at
/// the joint, siblings starting there) share the joint and do not cut; nor does a bone that
/// starts at `end` (within [`MEET`] times the length: it continues the segment, as in a chain
/// of bones with no parents, Blender's lone B-Bones), nor one that passes near without meeting
/// (a foot joint beside the shin's end), as the nearest-bone rule already splits the vertices
/// between the two.
///
/// Method: the distance `g(t)` from `p(t) = head + t (end - head)` to the other segment and
/// `f(t) = g(t) - t |end - head|` are convex (a distance to a convex set along a line, minus
/// a linear term); their minima come from golden-section search, and the first zero of `f`
/// before its minimum from bisection.
pub(crate) fn end_before_other_bones(head: DVec3, end: DVec3, others: &[(DVec3, DVec3)]) -> DVec3 {
    let len = head.distance(end);
    if !(len > REACH_TOLERANCE) {
        return end;
    }
    let at = |t: f64| head + (end - head) * t;
    let mut stop = 1.0f64;
    for &(a, b) in others {
        if closest_point_on_segment(head, a, b).1 <= REACH_TOLERANCE || a.distance(end) <= MEET * len {
            continue;
        }
        let g = |t: f64| closest_point_on_segment(at(t), a, b).1;
        if g(convex_min(&g, 1.0)) > MEET * len {
            continue;
        }
        let f = |t: f64| g(t) - t * len + REACH_TOLERANCE;
        let tmin = convex_min(&f, stop);
        if f(tmin) >= 0.0 {
            continue;
        }
        // f(0) > 0 > f(tmin): the first crossing lies between.
        let (mut lo, mut hi) = (0.0f64, tmin);
        for _ in 0..60 {
            let m = 0.5 * (lo + hi);
            if f(m) > 0.0 {
                lo = m;
            } else {
                hi = m;
            }
        }
        stop = stop.min(lo);
    }
    at(stop)
}

/// Where the convex `f` is least on `[0, hi]`, by golden-section search (60 steps).
fn convex_min(f: &dyn Fn(f64) -> f64, hi: f64) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (0.0f64, hi);
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..60 {
        if f1 <= f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        }
    }
    let m = 0.5 * (lo + hi);
    // The ends too: golden-section search never evaluates them.
    [0.0, m, hi].into_iter().min_by(|&x, &y| f(x).total_cmp(&f(y))).unwrap_or(m)
}

/// Do the rig's tails carry its author's bone directions? True when most bones that have a
/// child away from their head point at one (head -> tail within [`AIM_COS`] of the direction
/// to that child's head): the importer kept the joints' axes, which the author's tool aimed
/// along the bones (Blender's own export: a leaf's tail is then the author's too). False when
/// no bone has such a child.
///
/// Inputs: bone `heads` / `tails` `(b,)`, `parents` `(b,)`, and `tol`, the distance under which
/// two points coincide.
pub fn tails_aim_at_children(heads: &[DVec3], tails: &[DVec3], parents: &[i32], tol: f64) -> bool {
    // Per bone: has it a child away from its head, and does its tail point at one of those?
    let (mut has_child, mut aimed) = (vec![false; heads.len()], vec![false; heads.len()]);
    for (c, &p) in parents.iter().enumerate() {
        let Ok(b) = usize::try_from(p) else { continue };
        let dir = (tails[b] - heads[b]).normalize_or_zero();
        if heads[c].distance(heads[b]) > tol && dir != DVec3::ZERO {
            has_child[b] = true;
            aimed[b] |= dir.dot((heads[c] - heads[b]).normalize()) >= AIM_COS;
        }
    }
    let counted = has_child.iter().filter(|&&c| c).count();
    2 * aimed.iter().filter(|&&a| a).count() > counted
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
/// [`leaf_continuation`] when that lies inside; a childless bone's segments then end before
/// the other bones ([`end_before_other_bones`]). Returns `(segments, bone of each segment)`.
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
    // Every candidate segment beside head -> tail: spans to children, then leaf continuations
    // (only when the tails are the importer's guesses, not the author's directions).
    let continue_leaves = !tails_aim_at_children(&heads, &tails, parents, REACH_TOLERANCE);
    let leaves = (0..bones.len())
        .filter(|&j| continue_leaves && childless[j] && parents[j] >= 0)
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
    // Childless bones' segments (head -> invented tail, continuations) end before the others.
    let cut: Vec<(DVec3, DVec3)> = (0..segs.len())
        .map(|s| {
            let j = owner[s] as usize;
            if !childless[j] {
                return segs[s];
            }
            let others: Vec<(DVec3, DVec3)> =
                segs.iter().zip(&owner).filter(|&(_, &o)| o as usize != j).map(|(g, _)| *g).collect();
            (segs[s].0, end_before_other_bones(segs[s].0, segs[s].1, &others))
        })
        .collect();
    (cut, owner)
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

    /// An invented segment from the origin up the z axis: cut halfway to a bone it runs
    /// into (on its line, or crossing it), never by one passing beside it without meeting
    /// it, nor by its parent ending at its head or a sibling starting there.
    #[test]
    fn an_invented_segment_ends_halfway_to_a_bone_it_runs_into() {
        let (head, end) = (DVec3::ZERO, DVec3::new(0.0, 0.0, 1.0));
        let on_line = (DVec3::new(0.0, 0.0, 0.5), DVec3::new(0.0, 0.0, 0.9));
        let e = end_before_other_bones(head, end, &[on_line]);
        assert!(e.distance(DVec3::new(0.0, 0.0, 0.25)) < 1e-4, "{e}");
        let across = (DVec3::new(-0.5, 0.0, 0.6), DVec3::new(0.5, 0.0, 0.6));
        let e = end_before_other_bones(head, end, &[across, on_line]);
        assert!(e.distance(DVec3::new(0.0, 0.0, 0.25)) < 1e-4, "the nearer cut wins: {e}");
        let e = end_before_other_bones(head, end, &[across]);
        assert!(e.distance(DVec3::new(0.0, 0.0, 0.3)) < 1e-4, "{e}");
        // Beside it (0.2 away at its end, a foot joint by a shin's end): no cut.
        let beside = (DVec3::new(0.2, 0.0, 1.0), DVec3::new(0.5, 0.0, 1.0));
        assert_eq!(end_before_other_bones(head, end, &[beside]), end);
        // The parent ending at the head, along the line or bent; a sibling from the head.
        let parent = (DVec3::new(0.0, 0.0, -1.0), head);
        let bent = (DVec3::new(-1.0, 0.0, -0.2), head);
        let sibling = (head, DVec3::new(0.3, 0.0, 0.9));
        assert_eq!(end_before_other_bones(head, end, &[parent, bent, sibling]), end);
        // The next bone of a chain, starting at its end or just short of it, bent or not.
        let next = (DVec3::new(0.0, 0.0, 1.01), DVec3::new(0.0, 0.0, 2.0));
        let bent_next = (end, DVec3::new(0.8, 0.0, 1.6));
        assert_eq!(end_before_other_bones(head, end, &[next, bent_next]), end);
    }

    /// Tails aimed at a child (a Blender-made rig) or not (joint axes anywhere, the Fox's).
    #[test]
    fn tails_that_point_at_children_are_the_authors() {
        let heads = [DVec3::ZERO, DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, 2.0)];
        let aimed = [heads[1], heads[2], DVec3::new(0.0, 0.0, 3.0)];
        let sideways = [DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 1.0), DVec3::new(0.0, 0.0, 3.0)];
        assert!(tails_aim_at_children(&heads, &aimed, &[-1, 0, 1], 1e-6));
        assert!(!tails_aim_at_children(&heads, &sideways, &[-1, 0, 1], 1e-6));
        // One of two aimed is no majority; no bone with a child is no evidence.
        let half = [aimed[0], sideways[1], aimed[2]];
        assert!(!tails_aim_at_children(&heads, &half, &[-1, 0, 1], 1e-6));
        assert!(!tails_aim_at_children(&heads, &aimed, &[-1, -1, -1], 1e-6));
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
