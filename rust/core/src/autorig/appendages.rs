//! Head appendages: ears, horns and antennae, long protrusions of the head in pairs.
//!
//! Inputs: the centre-line [`Tree`] and its [`Voxels`], the leaves the body already uses (feet,
//! hands, tail; not the head's own leaf, which may be an ear: a biped's head is its highest
//! leaf), the head as a ball (`centre`, `radius`, unit frame), the solid's [`protrusions`] off
//! that ball and the [`Body`] (its mirror plane). Output: pairs `[left, right]` of chains, each
//! its root, middle and tip (unit frame), longest pair first.
//!
//! Method: a free leaf whose path into the body (towards `hips`) enters the head's ball
//! ([`BALL`] of its radius) without running along a limb (the paths of the leaves taken: a
//! finger is no ear) grows from the head; the stretch outside the ball is the appendage. It
//! counts when it reaches at least [`REACH`] of the head's radius out of the ball, is thin beside
//! the head (its median radius at most [`THIN`] of the head's) and rises ([`RISE`]): a corner of
//! a wide, boxy head, a snout or a pair of eyes is not one. The tree has no branch to a short
//! appendage of a big head (a cow's horns and ears: TEASAR covers what lies within twice the
//! head's depth of its path), so the voxels outside the ball are read too: each part of them
//! that ends within [`OUT`] head radii (the neck runs on) is a protrusion, and counts when it is
//! [`LONG`] times as long as it is thick, thin beside the head and its tip rises [`LOW_RISE`]
//! above the head's centre (a snout, a jaw do not). Appendages pair across the mirror
//! plane, each with the one on the other side nearest its mirror image, within [`PAIR`] of
//! their length (ears may be posed apart); a lone one (a unicorn's horn, one ear of an
//! asymmetric pose) is left out. The chain runs from where the path leaves the ball to one
//! radius short of the leaf (a thin ear's tip voxel may lie outside its surface), its middle
//! joint at the sharpest bend near half way (`line.rs`); a protrusion's from the middle of its
//! base through the middle of its cross-section half way out to the middle of its far end.
//! [`snout`] is where a head bone ends when the head's path runs up one of them.
//!
//! Known limits: an appendage thinner than a voxel is lost with its voxels; ears lying along
//! the head (a lop-eared rabbit) merge with it; geometry cannot tell an ear from a horn, so
//! the pairs are named by length only (`embed.rs`).

use super::centreline::{neighbours, Tree};
use super::line::Line;
use super::parts::Body;
use super::voxels::Voxels;
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
/// The solid's parts off the head's ball that end within this many head radii beyond it are
/// its protrusions (the neck runs on).
const OUT: f64 = 4.0;
/// A protrusion is at least this many times as long as it is thick (a box's corner is not)...
const LONG: f64 = 3.0;
/// ...and its tip rises at least this many head radii above the head's centre (a snout, a
/// jaw, a beard do not).
const LOW_RISE: f64 = 0.5;

/// One appendage's joints: root (on the head's ball), middle, tip; unit frame.
pub(super) type Appendage = [DVec3; 3];

/// The paired appendages of the head (`centre`, `radius`), `[left, right]`, longest first.
/// `taken`: the leaves the body uses (`body.hips`, a node of the body, is where paths lead);
/// `protruding`: the [`protrusions`] off the same ball.
pub(super) fn head_appendages(
    tree: &Tree,
    body: &Body,
    taken: &[usize],
    (centre, radius): (DVec3, f64),
    protruding: &[Line],
) -> Vec<[Appendage; 2]> {
    let hips = body.hips;
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
        let side = body.side(tree.pos[l]);
        if side.abs() > 1e-9 {
            found.push((line, side.signum()));
        }
    }
    // The solid's own protrusions off the ball, which the tree may have left out.
    for line in protruding {
        let len = line.len();
        let tip = line.at(len);
        let near = found.iter().any(|(f, _)| (f.at(f.len()) - tip).length() < 0.5 * len.max(f.len()));
        let thick = line.median_radius(0.0, len);
        if near || len < LONG * thick || thick > THIN * radius || tip.z - centre.z < LOW_RISE * radius {
            continue;
        }
        let side = body.side(tip);
        if side.abs() > 1e-9 {
            found.push((line.clone(), side.signum()));
        }
    }
    let tip = |line: &Line| line.at(line.len());
    // Pairs, nearest mirror images first; each appendage in one pair at most.
    let mut candidates: Vec<(f64, usize, usize)> = Vec::new();
    for (i, (a, sa)) in found.iter().enumerate() {
        for (j, (b, sb)) in found.iter().enumerate() {
            if *sa > 0.0 && *sb < 0.0 {
                let d = (body.mirror(tip(a)) - tip(b)).length();
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

/// The tip of the head's snout: of the `protruding` parts off the head's ball round `centre`
/// ([`protrusions`]) that lie on the body's mirror plane within their own length and point
/// ahead (`forward`) more than up, the one reaching farthest ahead, its tip on the plane; without
/// one, the front of the solid `vox` ahead of the centre.
pub(super) fn snout(vox: &Voxels, body: &Body, centre: DVec3, forward: DVec3, protruding: &[Line]) -> DVec3 {
    protruding
        .iter()
        .map(|l| (l.at(l.len()), l.len()))
        .filter(|&(tip, len)| {
            let d = tip - centre;
            body.side(tip).abs() < len && d.dot(forward) > d.z.max(0.0)
        })
        .max_by(|a, b| (a.0 - centre).dot(forward).total_cmp(&(b.0 - centre).dot(forward)))
        .map_or_else(|| centre + forward * vox.reach(centre, forward, 1.0), |(tip, _)| body.onto_plane(tip))
}

/// The parts of the solid `vox` outside the ball [`BALL`] times `radius` round `centre` that end
/// within [`OUT`] radii beyond it (the neck and the body run on, out of that shell), each as a
/// line from the middle of its base on the ball through the middle of its cross-section half way
/// out to the middle of its far end, with its median depth as the radius (unit frame).
pub(super) fn protrusions(vox: &Voxels, (centre, radius): (DVec3, f64)) -> Vec<Line> {
    let (ball, outer) = (BALL * radius, (BALL + OUT) * radius);
    let step = vox.step;
    let lo = ((centre - DVec3::splat(outer) - vox.origin) / step).floor().max(DVec3::ZERO);
    let hi = ((centre + DVec3::splat(outer) - vox.origin) / step).ceil();
    let d = vox.dims;
    let hi = [hi.x.min(d[0] as f64 - 1.0), hi.y.min(d[1] as f64 - 1.0), hi.z.min(d[2] as f64 - 1.0)]
        .map(|x| x.max(0.0) as usize);
    let lo = [lo.x as usize, lo.y as usize, lo.z as usize];
    let dist = |v: usize| (vox.centre(v) - centre).length();
    let shell = |v: usize| vox.inside[v] && dist(v) > ball;
    let mut seen = vec![false; vox.inside.len()];
    let mut out = Vec::new();
    for k in lo[2]..=hi[2] {
        for j in lo[1]..=hi[1] {
            for i in lo[0]..=hi[0] {
                let s = vox.index([i, j, k]);
                if !shell(s) || dist(s) > outer || std::mem::replace(&mut seen[s], true) {
                    continue;
                }
                // One part of the shell, breadth first; it runs on when it reaches the outer sphere.
                let mut part = vec![s];
                let mut open = false;
                let mut at = 0;
                while at < part.len() {
                    let v = part[at];
                    at += 1;
                    for (w, _) in neighbours(vox, v) {
                        if !shell(w) || std::mem::replace(&mut seen[w], true) {
                            continue;
                        }
                        if dist(w) > outer {
                            open = true;
                            continue;
                        }
                        part.push(w);
                    }
                }
                if open {
                    continue;
                }
                let far = part.iter().map(|&v| dist(v)).fold(0.0, f64::max);
                if far - ball < 2.0 * step {
                    continue; // a bump
                }
                let mean_at = |r: f64| {
                    let near: Vec<DVec3> =
                        part.iter().filter(|&&v| (dist(v) - r).abs() <= step).map(|&v| vox.centre(v)).collect();
                    (!near.is_empty()).then(|| near.iter().copied().sum::<DVec3>() / near.len() as f64)
                };
                let (Some(root), Some(mid), Some(tip)) =
                    (mean_at(ball + 0.5 * step), mean_at(0.5 * (ball + far)), mean_at(far - step))
                else {
                    continue;
                };
                let mut depths: Vec<f64> = part.iter().map(|&v| vox.depth[v] as f64 * step).collect();
                depths.sort_by(f64::total_cmp);
                let r = depths[depths.len() / 2];
                out.push(Line::from_points([(root, r), (mid, r), (tip, r)].into_iter()));
            }
        }
    }
    out
}
