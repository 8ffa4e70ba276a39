//! Head appendages: ears, horns and antennae, long protrusions of the head in pairs.
//!
//! Inputs: the centre-line [`Tree`], the leaves the body already uses (feet, hands, tail; not
//! the head's own leaf, which may be an ear: a biped's head is its highest leaf), the head as a
//! ball (`centre`, `radius`, unit frame) and the mirror plane (`p . left = plane`). Output: pairs
//! `[left, right]` of chains, each its root, middle and tip (unit frame), longest pair first.
//!
//! Method: a free leaf whose path into the body (towards `hips`) enters the head's ball
//! ([`BALL`] of its radius) without running along a limb (the paths of the leaves taken: a
//! finger is no ear) grows from the head; the stretch outside the ball is the appendage. It
//! counts when it reaches at least [`REACH`] of the head's radius out of the ball, is thin beside
//! the head (its median radius at most [`THIN`] of the head's) and rises ([`RISE`]): a corner of
//! a wide, boxy head, a snout or a pair of eyes is not one. Appendages pair across the mirror
//! plane, each with the one on the other side nearest its mirror image, within [`PAIR`] of
//! their length (ears may be posed apart); a lone one (a unicorn's horn, one ear of an
//! asymmetric pose) is left out. The chain runs from where the path leaves the ball to one
//! radius short of the leaf (a thin ear's tip voxel may lie outside its surface), its middle
//! joint at the sharpest bend near half way (`line.rs`).
//!
//! Known limits: an appendage thinner than a voxel is lost with its voxels (a cow's flat ears
//! at the default resolution); ears lying along the head (a lop-eared rabbit) merge with it;
//! geometry cannot tell an ear from a horn, so the pairs are named by length only (`embed.rs`).

use super::centreline::Tree;
use super::line::Line;
use glam::DVec3;

/// The head's ball, this many times the head's radius: what the path of an appendage leaves.
const BALL: f64 = 1.5;
/// An appendage reaches at least this many head radii out of the ball.
const REACH: f64 = 1.0;
/// ...and is at most this share of the head's radius thick (median over its length).
const THIN: f64 = 0.6;
/// ...and its tip rises at least this many head radii above the head's centre (one above the
/// head's top: ears, horns and antennae rise; eyes and a snout do not).
const RISE: f64 = 2.0;
/// Two appendages pair when one's tip lies within this share of the longer one's length of the
/// other's mirror image.
const PAIR: f64 = 0.6;

/// One appendage's joints: root (on the head's ball), middle, tip; unit frame.
pub(super) type Appendage = [DVec3; 3];

/// The paired appendages of the head (`centre`, `radius`), `[left, right]`, longest first.
/// `taken`: the leaves the body uses; `hips`: a node of the body, where paths lead.
pub(super) fn head_appendages(
    tree: &Tree,
    taken: &[usize],
    hips: usize,
    (centre, radius): (DVec3, f64),
    (left, plane): (DVec3, f64),
) -> Vec<[Appendage; 2]> {
    let ball = BALL * radius;
    // The limbs' nodes: an appendage does not run along an arm (a finger is no ear).
    let limbs: std::collections::HashSet<usize> = taken.iter().flat_map(|&t| tree.path(t, hips)).collect();
    // (chain's line from its root to the leaf, side: +1 left / -1 right)
    let mut found: Vec<(Line, f64)> = Vec::new();
    for l in tree.leaves() {
        if taken.contains(&l) {
            continue;
        }
        let path = tree.path(l, hips);
        let Some(inside) = path.iter().position(|&n| (tree.pos[n] - centre).length() <= ball) else {
            continue;
        };
        if inside < 2 || path[..inside].iter().any(|n| limbs.contains(n)) {
            continue;
        }
        // From the ball's surface (the last node outside, and the crossing before it) to the leaf.
        let (a, b) = (tree.pos[path[inside]], tree.pos[path[inside - 1]]);
        let (da, db) = ((a - centre).length(), (b - centre).length());
        let t = if db > da { ((ball - da) / (db - da)).clamp(0.0, 1.0) } else { 0.0 };
        let root = (a.lerp(b, t), tree.radius[path[inside]]);
        let line = Line::from_points(
            std::iter::once(root).chain(path[..inside].iter().rev().map(|&n| (tree.pos[n], tree.radius[n]))),
        );
        let len = line.len();
        let tip_out = (tree.pos[l] - centre).length() - ball;
        let rise = tree.pos[l].z - centre.z;
        if len < REACH * radius
            || tip_out < REACH * radius
            || line.median_radius(0.0, len) > THIN * radius
            || rise < RISE * radius
        {
            continue;
        }
        let side = tree.pos[l].dot(left) - plane;
        if side.abs() > 1e-9 {
            found.push((line, side.signum()));
        }
    }
    let reflect = |p: DVec3| p - left * (2.0 * (p.dot(left) - plane));
    let tip = |line: &Line| line.at(line.len());
    // Pairs, nearest mirror images first; each appendage in one pair at most.
    let mut candidates: Vec<(f64, usize, usize)> = Vec::new();
    for (i, (a, sa)) in found.iter().enumerate() {
        for (j, (b, sb)) in found.iter().enumerate() {
            if *sa > 0.0 && *sb < 0.0 {
                let d = (reflect(tip(a)) - tip(b)).length();
                if d <= PAIR * a.len().max(b.len()) {
                    candidates.push((d, i, j));
                }
            }
        }
    }
    candidates.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut used = vec![false; found.len()];
    let mut pairs: Vec<([usize; 2], f64)> = Vec::new();
    for (_, i, j) in candidates {
        if !used[i] && !used[j] {
            used[i] = true;
            used[j] = true;
            pairs.push(([i, j], found[i].0.len() + found[j].0.len()));
        }
    }
    pairs.sort_by(|x, y| y.1.total_cmp(&x.1));
    pairs
        .iter()
        .map(|(p, _)| {
            p.map(|k| {
                let line = &found[k].0;
                let len = line.len();
                let end = (len - line.radius(len)).max(0.5 * len);
                let mid = line.bend_near(0.5 * end, 0.0, end);
                [line.at(0.0), line.at(mid), line.at(end)]
            })
        })
        .collect()
}
