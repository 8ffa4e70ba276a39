//! A body read along its spine: legless bodies (a snake, a worm, a fish, a blob with a head) and
//! winged ones (a bird, a dragon, a moth), for the Chain and Winged templates.
//!
//! Inputs: the [`Tree`], the [`Voxels`] and their vertical [`Mirror`] plane, the mesh's vertices (unit frame, +Z up), the feet of
//! the legs found (none, a pair, or two pairs: `body`'s legs that hold the body up), the template
//! asked for (`Auto`: Winged when the body has wings, else Chain or a refusal), an optional
//! facing. Output: a [`Body`] whose [`Axial`] holds the spine's nodes from the tail end to the
//! head end, the wing tips and the paired side chains (fins, flippers, tentacles, arms), and
//! `reason`, why this template.
//!
//! Method, by geometry only:
//! - the mirror plane is midway between the legs when there are legs, else the solid's own
//!   vertical mirror plane (`symmetry`); a body that mirrors badly (under [`SYMMETRIC`] of its
//!   voxels, a snake lying in curves) has no side pairs and its spine is the tree's longest path;
//! - leaves within [`ON_PLANE`] of the plane are the ends of the spine (and of unpaired fins);
//!   a leaf off it pairs with the leaf nearest its mirror image, within [`PAIR`];
//! - the spine joins the two plane leaves farthest apart along the tree (a blob with one such
//!   leaf: that leaf and the plane node farthest from it);
//! - the head is the upper end when the ends differ in height by [`HEAD_RISE`] of their
//!   distance, else the thicker end (a head is a bulb, a tail tapers);
//! - wings are the side pair spanning widest, when tip to tip they span [`WING_SPAN`] times the
//!   body's height or more ([`WING_SPAN_LEGGED`] on legs: arms held out in a T-pose span once
//!   to 1.6 times the height) and their tips are off the ground;
//! - the spine's ends are pushed out along it to the surface (a blunt snout or a rump is no
//!   leaf of the tree).
//!
//! Known limits: the plane is vertical (a figure lying on its side reads as a chain of limbs); a body with long arms
//! spread wider than [`WING_SPAN`] times its height (a chibi in T-pose) reads as winged.

use super::centreline::Tree;
use super::parts::{end_thickness, frame, Axial, Body, Template};
use super::symmetry::Mirror;
use super::voxels::Voxels;
use crate::{Error, Result};
use glam::DVec3;

/// A body mirrors well when this share of its voxels has a mirror image inside.
pub(crate) const SYMMETRIC: f64 = 0.7;
/// A leaf this close to the mirror plane (unit frame: the diagonal is 1) lies on it.
pub(crate) const ON_PLANE: f64 = 0.04;
/// Two leaves pair when one lies this close to the other's mirror image (unit frame).
const PAIR: f64 = 0.12;
/// The spine stands when its ends differ in height by this share of their distance: the upper
/// end is the head.
const HEAD_RISE: f64 = 0.25;
/// Wings span at least this many times the body's height, tip to tip.
const WING_SPAN: f64 = 1.4;
/// ... and this many times on a body standing on its legs (a chibi's T-posed arms span 1.6
/// times its height; a standing bird's wings twice or more).
const WING_SPAN_LEGGED: f64 = 1.8;
/// A body without limbs or a neck is a round blob unless it is this many times its greatest
/// depth from end to end (a snake is 20 times, a fish 9 times, a capsule twice as long as wide 4 times).
const BLOB: f64 = 4.5;
/// A neck: somewhere along the middle of the spine, the body is this share of the widest parts
/// on both sides of it.
const NECK: f64 = 0.7;
/// A side chain's tip lies at least this many times the body's depth where it joins from the
/// spine (it sticks out of the body; the rim of a cylinder's cap does not).
const STICK_OUT: f64 = 1.5;
/// Side chains shorter than this share of the spine are bumps, not fins.
const MIN_FIN: f64 = 0.08;
/// Wing tips are in the air: at least this share of the height above the ground (limbs resting
/// on the ground are legs, fins or flippers).
const RESTING: f64 = 0.1;

/// Read `tree` as a chain or winged body (`template`: `Chain`, `Winged`, or `Auto` for a
/// legless body: Chain, or a refusal; `forward`: the way the character faces, if given).
/// `legs`: the feet of the legs that hold the body up; `ground` and `height`: the body's lowest
/// point and its height.
pub(crate) fn axial_body(
    tree: &Tree,
    vox: &Voxels,
    mirror: &Mirror,
    vertices: &[DVec3],
    legs: &[usize],
    (template, forward): (Template, Option<DVec3>),
    (ground, height): (f64, f64),
) -> Result<Body> {
    let leaves = tree.leaves();
    if leaves.len() < 2 {
        return Err(Error::Unsuitable("no limbs and no long axis: the shape is a round blob".into()));
    }
    let plane = legs_plane(tree, legs).unwrap_or(*mirror);
    let symmetric = plane.score >= SYMMETRIC;
    let free: Vec<usize> = leaves.iter().copied().filter(|l| !legs.contains(l)).collect();
    let on_plane: Vec<usize> =
        free.iter().copied().filter(|&l| !symmetric || plane.distance(tree.pos[l]).abs() < ON_PLANE).collect();
    let pairs = if symmetric { side_pairs(tree, &free, &plane) } else { Vec::new() };
    // The spine's ends: the two points on the plane farthest apart along the tree (a leaf, or
    // the last node before a blunt end: TEASAR makes no leaf of an end within twice the
    // body's depth of a path, such as a fish's snout).
    let mut candidates = on_plane.clone();
    candidates
        .extend((0..tree.pos.len()).filter(|&n| !symmetric || plane.distance(tree.pos[n]).abs() < 1.5 * vox.step));
    if candidates.len() < 2 {
        return Err(Error::Unsuitable("no spine: nothing of the body lies on its mirror plane".into()));
    }
    let farthest = |from: usize| {
        let d = tree.distances_from(from);
        candidates.iter().copied().filter(|&c| d[c].is_finite()).max_by(|&a, &b| d[a].total_cmp(&d[b]))
    };
    let start = tree.deepest();
    let a = farthest(start).unwrap_or(start);
    let b = farthest(a).unwrap_or(a);
    let spine_len = tree.path_length(a, b);
    // Head: the upper end of a standing spine, else the thicker end.
    let (pa, pb) = (tree.pos[a], tree.pos[b]);
    let chord = (pb - pa).length();
    let rise = pb.z - pa.z;
    let head_is_b = if rise.abs() >= HEAD_RISE * chord {
        rise > 0.0
    } else {
        let reach = 0.3 * spine_len;
        end_thickness(tree, b, reach) >= end_thickness(tree, a, reach)
    };
    let (tail_end, head_end) = if head_is_b { (a, b) } else { (b, a) };
    let spine = tree.path(tail_end, head_end);
    let flat = DVec3::new(pb.x - pa.x, pb.y - pa.y, 0.0).length();
    let upright = flat < 0.5 * rise.abs();

    // Side chains: paired leaves on branches off the spine, long enough to be limbs.
    let on_spine = |n: usize| spine.contains(&n);
    let branch = |l: usize| {
        let path = tree.path(l, head_end);
        let j = path.iter().copied().find(|&n| on_spine(n)).unwrap_or(head_end);
        (j, tree.path_length(l, j))
    };
    let limbs: Vec<[usize; 2]> = pairs
        .iter()
        .copied()
        .filter(|p| {
            p.iter().all(|&l| {
                let (j, len) = branch(l);
                !on_spine(l)
                    && len >= MIN_FIN * spine_len
                    && (tree.pos[l] - tree.pos[j]).length() >= STICK_OUT * tree.radius[j]
            })
        })
        .collect();
    let radii: Vec<f64> = {
        let path = tree.path(a, b);
        let cut = path.len() / 6;
        path[cut..path.len() - cut].iter().map(|&n| tree.radius[n]).collect()
    };
    // A neck narrows between wider parts on both sides (a head on a body).
    let neck = (1..radii.len().saturating_sub(1)).any(|k| {
        let before = radii[..k].iter().copied().fold(0.0, f64::max);
        let after = radii[k + 1..].iter().copied().fold(0.0, f64::max);
        radii[k] < NECK * before.min(after)
    });
    let extent = (end_tip(tree, vox, &tree.path(a, b)) - end_tip(tree, vox, &tree.path(b, a))).length();
    if limbs.is_empty() && !neck && extent < BLOB * tree.radius[tree.deepest()] {
        return Err(Error::Unsuitable(
            "no legs, no limbs and no long axis: a round blob (Auto Rig needs legs, wings, side limbs or a \
             body longer than it is thick)"
                .into(),
        ));
    }
    let span = |p: &[usize; 2]| {
        let d = tree.pos[p[0]] - tree.pos[p[1]];
        DVec3::new(d.x, d.y, 0.0).length()
    };
    let wings = limbs
        .iter()
        .copied()
        .filter(|p| span(p) >= if legs.is_empty() { WING_SPAN } else { WING_SPAN_LEGGED } * height)
        .filter(|p| p.iter().all(|&l| tree.pos[l].z - tree.radius[l] > ground + RESTING * height))
        .max_by(|x, y| span(x).total_cmp(&span(y)));
    let template = match template {
        Template::Winged if wings.is_none() => {
            return Err(Error::Unsuitable(format!(
                "no wings: no pair of limbs spreads {WING_SPAN} times the body's height from tip to tip ({WING_SPAN_LEGGED} \
                 on legs)"
            )))
        }
        Template::Winged => Template::Winged,
        Template::Auto if wings.is_some() => Template::Winged,
        _ => Template::Chain,
    };
    if template == Template::Winged && !legs.is_empty() && legs.len() != 2 && legs.len() != 4 {
        return Err(Error::Unsuitable(format!("found {} legs; a winged body has 0, 2 or 4", legs.len())));
    }

    // Facing: from the tail end to the head end, or, for a standing spine, toward the side the
    // body bulges to (a belly, a face).
    let asked_forward = forward.is_some();
    let facing = match forward {
        Some(f) => f,
        None if !upright => {
            DVec3::new(tree.pos[head_end].x - tree.pos[tail_end].x, tree.pos[head_end].y - tree.pos[tail_end].y, 0.0)
        }
        None => {
            let side = DVec3::Z.cross(plane.normal);
            let mid = spine.iter().map(|&n| tree.pos[n].dot(side)).sum::<f64>() / spine.len() as f64;
            let bulge = vertices.iter().map(|p| p.dot(side) - mid).sum::<f64>();
            if bulge >= 0.0 {
                side
            } else {
                -side
            }
        }
    };
    let (forward, left) = frame(facing)?;
    // A symmetric body's left is its mirror plane's normal (turned to the facing's left).
    let sign = if plane.normal.dot(left) >= 0.0 { 1.0 } else { -1.0 };
    let (forward, left) = if symmetric && !asked_forward {
        ((plane.normal * sign).cross(DVec3::Z), plane.normal * sign)
    } else {
        (forward, left)
    };
    let offset = sign * plane.offset;
    let sided = |p: [usize; 2]| if tree.pos[p[0]].dot(left) >= tree.pos[p[1]].dot(left) { p } else { [p[1], p[0]] };
    let along = |n: usize| spine.iter().position(|&s| s == n).unwrap_or(0);
    let mut fins: Vec<[usize; 2]> = limbs.iter().copied().filter(|p| Some(*p) != wings).map(sided).collect();
    fins.sort_by_key(|p| std::cmp::Reverse(along(branch(p[0]).0)));
    let feet = match legs.len() {
        2 => sided([legs[0], legs[1]]).to_vec(),
        4 => {
            let ahead = |p: [usize; 2]| (tree.pos[p[0]] + tree.pos[p[1]]).dot(forward);
            let (mut hind, mut front) = (sided([legs[0], legs[1]]), sided([legs[2], legs[3]]));
            if ahead(hind) > ahead(front) {
                std::mem::swap(&mut hind, &mut front);
            }
            vec![hind[0], hind[1], front[0], front[1]]
        }
        _ => Vec::new(),
    };
    let what = |n: usize, one: &str| format!("{n} {one}{}", if n == 1 { "" } else { "s" });
    let reason = match template {
        Template::Winged => format!(
            "wings spread {:.1} times its height{}",
            wings.map_or(0.0, |w| span(&w)) / height,
            if feet.is_empty() {
                ", no legs".to_string()
            } else {
                format!(", {} hold the body up", what(feet.len(), "leg"))
            }
        ),
        _ => format!(
            "no legs hold the body up{}",
            if fins.is_empty() { String::new() } else { format!("; {} side chains", fins.len()) }
        ),
    };
    Ok(Body {
        template,
        reason,
        feet,
        hands: None,
        head: head_end,
        tail: Some(tail_end),
        hips: spine[0],
        chest: None,
        crotch: None,
        plane: offset,
        symmetric,
        forward,
        left,
        ground,
        axial: Some(Axial {
            tips: [end_tip(tree, vox, &spine), end_tip(tree, vox, &rev(&spine))],
            spine,
            upright,
            wings: wings.map(sided),
            fins,
        }),
    })
}

/// The plane midway between the legs (perpendicular to the line joining each pair's feet), or
/// `None` without legs.
fn legs_plane(tree: &Tree, legs: &[usize]) -> Option<Mirror> {
    if legs.len() < 2 {
        return None;
    }
    let pairs: Vec<[usize; 2]> = legs.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
    let across = pairs.iter().map(|p| {
        let d = tree.pos[p[0]] - tree.pos[p[1]];
        DVec3::new(d.x, d.y, 0.0)
    });
    let first = across.clone().next()?;
    let normal = across.map(|d| if d.dot(first) >= 0.0 { d } else { -d }).sum::<DVec3>().normalize_or_zero();
    if normal == DVec3::ZERO {
        return None;
    }
    let offset = legs.iter().map(|&l| tree.pos[l].dot(normal)).sum::<f64>() / legs.len() as f64;
    Some(Mirror { normal, offset, score: 1.0 })
}

/// Leaves off the plane paired with the leaf nearest their mirror image (each leaf's best match,
/// both ways, within [`PAIR`]).
fn side_pairs(tree: &Tree, leaves: &[usize], plane: &Mirror) -> Vec<[usize; 2]> {
    let off: Vec<usize> = leaves.iter().copied().filter(|&l| plane.distance(tree.pos[l]).abs() >= ON_PLANE).collect();
    let best = |l: usize| {
        let image = plane.reflect(tree.pos[l]);
        off.iter()
            .copied()
            .filter(|&m| m != l && plane.distance(tree.pos[m]) * plane.distance(tree.pos[l]) < 0.0)
            .map(|m| (m, (tree.pos[m] - image).length()))
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .filter(|&(_, d)| d < PAIR)
            .map(|(m, _)| m)
    };
    off.iter()
        .copied()
        .filter(|&l| plane.distance(tree.pos[l]) > 0.0)
        .filter_map(|l| best(l).filter(|&m| best(m) == Some(l)).map(|m| [l, m]))
        .collect()
}

fn rev(v: &[usize]) -> Vec<usize> {
    v.iter().rev().copied().collect()
}

/// Where the body ends beyond the first node of `path`: from it, along the path's direction
/// there (over its first few nodes), to the last point inside the voxels (in half-voxel steps:
/// a joint there stays inside the mesh).
fn end_tip(tree: &Tree, vox: &Voxels, path: &[usize]) -> DVec3 {
    let end = tree.pos[path[0]];
    let back = tree.pos[path[path.len().min(4) - 1]];
    let dir = (end - back).normalize_or_zero();
    if dir == DVec3::ZERO {
        return end;
    }
    end + dir * vox.reach(end, dir, f64::INFINITY)
}
