//! Which extremities of the centre-line tree are feet, hands, head and tail, and which way the
//! body faces.
//!
//! Inputs: the [`Tree`] and the mesh's vertices (unit frame, +Z up), the template asked for and
//! an optional facing. Output [`Body`]: the leaves playing each part, the junctions where the
//! legs and arms join the body, and the facing and left directions.
//!
//! Method, by geometry only:
//! - **feet** are leaves within [`GROUND_BAND`] of the height above the lowest vertex whose
//!   path up into the body climbs: over its first [`LEG_WALK`] of the height it rises at least
//!   [`LEG_SLOPE`] of the way (a figure lying down has no such leaf);
//! - leaves whose paths meet below [`SHIN`] of the height (a toe and a heel) are one foot;
//! - two or three feet make a biped, four or more a quadruped (its four lowest);
//! - a biped's left-right axis joins its feet; it faces where its toes point (the foot's
//!   lowest vertices lie ahead of the ankle); its hands are the leaves farthest out to each side
//!   and its head the highest other leaf;
//! - a quadruped's body axis is the long axis of its four feet, whose two pairs are its hind
//!   and front legs; the front is the end whose body rises higher (the head and neck); its head
//!   is the most forward leaf, its tail the most backward leaf behind the hind legs on a long
//!   enough branch.

use super::centreline::Tree;
use super::line::Line;
use super::voxels::Voxels;
use crate::{Error, Result};
use glam::DVec3;

/// Feet end within this fraction of the height above the lowest vertex.
const GROUND_BAND: f64 = 0.2;
/// A leg's path, over its first this fraction of the height...
const LEG_WALK: f64 = 0.3;
/// ...climbs at least this fraction of the way it goes.
const LEG_SLOPE: f64 = 0.5;
/// Legs are compared where they cross this fraction of the height (shins, not toes or heels).
const SHIN: f64 = 0.15;
/// A hand lies at least this fraction of the height to the side of the body's middle.
const HAND_REACH: f64 = 0.12;
/// A tail's branch is at least this fraction of the hind-to-front distance.
const TAIL_LENGTH: f64 = 0.25;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Template {
    /// Decide from the number of feet.
    Auto,
    Biped,
    Quadruped,
}

/// The parts found in the tree (node indices) and the body's directions.
#[derive(Debug, Clone)]
pub(crate) struct Body {
    pub template: Template,
    /// Biped: [left, right]; quadruped: [hind left, hind right, front left, front right].
    pub feet: Vec<usize>,
    /// Biped: [left, right], when both are found.
    pub hands: Option<[usize; 2]>,
    pub head: usize,
    pub tail: Option<usize>,
    /// Where the legs join (biped: one; quadruped: hind, front).
    pub hips: usize,
    pub chest: Option<usize>,
    /// Biped: the point between the legs where the body closes over them (the crotch), when
    /// the legs' paths show it; the tree's own junction can sit far higher when a flat torso
    /// lets each leg's path run up it on its own.
    pub crotch: Option<DVec3>,
    /// The mirror plane: `p . left = plane`, midway between the legs where they are shins (the
    /// legs are the most reliably symmetric part; a hand's pose or a prop is not).
    pub plane: f64,
    pub forward: DVec3,
    pub left: DVec3,
    /// Lowest vertex height (unit frame).
    pub ground: f64,
}

fn horizontal(v: DVec3) -> DVec3 {
    DVec3::new(v.x, v.y, 0.0)
}

/// Find the body's parts. `forward`: the facing asked for (horizontal, any length), if any.
pub(crate) fn find_body(
    tree: &Tree,
    vox: &Voxels,
    vertices: &[DVec3],
    template: Template,
    forward: Option<DVec3>,
) -> Result<Body> {
    let ground = vertices.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
    let top = vertices.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max);
    let height = top - ground;
    let leaves = tree.leaves();
    let centre = tree.deepest();
    let mut low: Vec<usize> =
        leaves.iter().copied().filter(|&l| tree.pos[l].z - tree.radius[l] < ground + GROUND_BAND * height).collect();
    low.sort_by(|&a, &b| tree.pos[a].z.total_cmp(&tree.pos[b].z));
    if low.is_empty() {
        return Err(Error::Unsuitable(
            "no ground contact: no limb reaches down to the lowest part of the mesh (Auto Rig takes a \
             character standing upright, +Z up, on its feet)"
                .into(),
        ));
    }
    // One foot per leg: leaves whose paths meet below the shins (a toe and a heel) are one
    // foot, the lowest of them (`low` is sorted by height).
    let mut legs_seen = Vec::new();
    let mut feet: Vec<usize> = Vec::new();
    for &l in &low {
        if !climbs(tree, l, centre, height) {
            continue;
        }
        let path = tree.path(l, centre);
        let leg = path.iter().copied().find(|&n| tree.pos[n].z >= ground + SHIN * height).unwrap_or(centre);
        if !legs_seen.contains(&leg) {
            legs_seen.push(leg);
            feet.push(l);
        }
    }
    if feet.len() < 2 {
        return Err(Error::Unsuitable(format!(
            "not standing upright: {} limb(s) reach the ground but {} rise(s) from it (Auto Rig takes a \
             character standing on its feet, +Z up)",
            low.len(),
            feet.len()
        )));
    }
    let template = match template {
        Template::Auto if feet.len() >= 4 => Template::Quadruped,
        Template::Auto => Template::Biped,
        t => t,
    };
    match template {
        Template::Quadruped if feet.len() < 4 => Err(Error::Unsuitable(format!(
            "found {} feet on the ground; a quadruped needs 4 (try the Biped template)",
            feet.len()
        ))),
        Template::Quadruped => quadruped(tree, vertices, &feet[..4], forward, ground, height),
        _ => biped(tree, vox, vertices, [feet[0], feet[1]], forward, ground, height),
    }
}

/// Does the path from leaf `l` towards `centre` rise like a leg: over its first
/// [`LEG_WALK`] of the height, it climbs at least [`LEG_SLOPE`] of the way it goes?
fn climbs(tree: &Tree, l: usize, centre: usize, height: f64) -> bool {
    let path = tree.path(l, centre);
    let start = tree.pos[l].z;
    let mut walked = 0.0;
    let mut rise: f64 = 0.0;
    for w in path.windows(2) {
        walked += (tree.pos[w[1]] - tree.pos[w[0]]).length();
        rise = rise.max(tree.pos[w[1]].z - start);
        if walked >= LEG_WALK * height {
            break;
        }
    }
    walked > 0.0 && rise >= LEG_SLOPE * walked.max(0.5 * LEG_WALK * height)
}

fn biped(
    tree: &Tree,
    vox: &Voxels,
    vertices: &[DVec3],
    feet: [usize; 2],
    forward: Option<DVec3>,
    ground: f64,
    height: f64,
) -> Result<Body> {
    // Across the legs where they are shins (a foot's leaf may be its toe or its heel).
    let shin = |f: usize| point_at_height(tree, f, ground + SHIN * height).unwrap_or(tree.pos[f]);
    let across = horizontal(shin(feet[0]) - shin(feet[1]));
    if across.length() < 1e-9 {
        return Err(Error::Unsuitable("the two feet are at the same place".into()));
    }
    let across = across.normalize();
    let facing = match forward {
        Some(f) => f,
        None => {
            // Toes point forward: each foot's lowest vertices lie ahead of its ankle.
            let side = DVec3::Z.cross(across);
            let mut lead = 0.0;
            for &f in &feet {
                let ankle = point_at_height(tree, f, ground + 0.15 * height).unwrap_or(tree.pos[f]);
                let near: Vec<DVec3> = vertices
                    .iter()
                    .copied()
                    .filter(|p| p.z < ground + 0.04 * height && horizontal(*p - ankle).length() < 0.15 * height)
                    .collect();
                if !near.is_empty() {
                    let c = near.iter().sum::<DVec3>() / near.len() as f64;
                    lead += horizontal(c - ankle).dot(side);
                }
            }
            if lead >= 0.0 {
                side
            } else {
                -side
            }
        }
    };
    let (forward, left) = frame(facing)?;
    let feet = if shin(feet[0]).dot(left) >= shin(feet[1]).dot(left) { feet } else { [feet[1], feet[0]] };
    let mid = (tree.pos[feet[0]] + tree.pos[feet[1]]) * 0.5;
    let taken = |l: usize| feet.contains(&l);
    let leaves = tree.leaves();
    let side_most = |sign: f64| {
        leaves
            .iter()
            .copied()
            .filter(|&l| !taken(l) && tree.pos[l].z > ground + 0.3 * height)
            .map(|l| (l, sign * (tree.pos[l] - mid).dot(left)))
            .filter(|&(_, s)| s > HAND_REACH * height)
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(l, _)| l)
    };
    let hands = match (side_most(1.0), side_most(-1.0)) {
        (Some(a), Some(b)) if a != b => Some([a, b]),
        _ => None,
    };
    let head = leaves
        .iter()
        .copied()
        .filter(|&l| !taken(l) && hands.is_none_or(|h| !h.contains(&l)))
        .max_by(|&a, &b| tree.pos[a].z.total_cmp(&tree.pos[b].z))
        .or_else(|| (0..tree.pos.len()).max_by(|&a, &b| tree.pos[a].z.total_cmp(&tree.pos[b].z)))
        .unwrap_or(0);
    let hips = tree.median(feet[0], feet[1], head);
    let chest = hands.map(|h| tree.median(h[0], h[1], head));
    let crotch = crotch(tree, vox, feet, ground, tree.pos[hips].z);
    let plane = (shin(feet[0]) + shin(feet[1])).dot(left) * 0.5;
    Ok(Body {
        crotch,
        plane,
        template: Template::Biped,
        feet: feet.to_vec(),
        hands,
        head,
        tail: None,
        hips,
        chest,
        forward,
        left,
        ground,
    })
}

fn quadruped(
    tree: &Tree,
    vertices: &[DVec3],
    feet: &[usize],
    forward: Option<DVec3>,
    ground: f64,
    height: f64,
) -> Result<Body> {
    let shin = |f: usize| point_at_height(tree, f, ground + SHIN * height).unwrap_or(tree.pos[f]);
    let q: Vec<DVec3> = feet.iter().map(|&f| horizontal(shin(f))).collect();
    let mean = q.iter().sum::<DVec3>() / 4.0;
    // Long axis of the four feet (2x2 covariance).
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in &q {
        let d = *p - mean;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let axis = DVec3::new(angle.cos(), angle.sin(), 0.0);
    let mut order: Vec<usize> = (0..4).collect();
    order.sort_by(|&a, &b| q[a].dot(axis).total_cmp(&q[b].dot(axis)));
    let (back, front) = ([feet[order[0]], feet[order[1]]], [feet[order[2]], feet[order[3]]]);
    let s_back = (q[order[0]] + q[order[1]]).dot(axis) * 0.5;
    let s_front = (q[order[2]] + q[order[3]]).dot(axis) * 0.5;
    let facing = match forward {
        Some(f) => f,
        None => {
            // The head and neck rise above the body; the tail seldom does.
            let top = |beyond: &dyn Fn(f64) -> bool| {
                vertices.iter().filter(|p| beyond(p.dot(axis))).map(|p| p.z).fold(f64::NEG_INFINITY, f64::max)
            };
            if top(&|s| s > s_front) >= top(&|s| s < s_back) {
                axis
            } else {
                -axis
            }
        }
    };
    let (forward, left) = frame(facing)?;
    let (hind, front) = if axis.dot(forward) > 0.0 { (back, front) } else { (front, back) };
    let by_side = |pair: [usize; 2]| {
        if tree.pos[pair[0]].dot(left) >= tree.pos[pair[1]].dot(left) {
            pair
        } else {
            [pair[1], pair[0]]
        }
    };
    let (hind, front) = (by_side(hind), by_side(front));
    let plane = feet.iter().map(|&f| shin(f).dot(left)).sum::<f64>() / 4.0;
    let hips = tree.median(hind[0], hind[1], front[0]);
    let chest = tree.median(front[0], front[1], hind[0]);
    let all = [hind[0], hind[1], front[0], front[1]];
    let leaves = tree.leaves();
    let free: Vec<usize> = leaves.iter().copied().filter(|l| !all.contains(l)).collect();
    let along = |n: usize| tree.pos[n].dot(forward);
    let head = free
        .iter()
        .copied()
        .filter(|&l| along(l) > along(chest))
        .max_by(|&a, &b| along(a).total_cmp(&along(b)))
        .or_else(|| {
            // No limb there (a facing given against a blunt end): the tree's most forward point.
            (0..tree.pos.len()).filter(|&n| along(n) > along(chest)).max_by(|&a, &b| along(a).total_cmp(&along(b)))
        })
        .ok_or_else(|| Error::Unsuitable("no head: nothing reaches forward beyond the front legs".into()))?;
    let span = (tree.pos[chest] - tree.pos[hips]).length();
    let tail = free
        .iter()
        .copied()
        .filter(|&l| l != head && along(l) < along(hips))
        .filter(|&l| {
            let len = Line::new(tree, &tree.path(hips, l)).len();
            len > TAIL_LENGTH * span && (tree.pos[l] - tree.pos[hips]).dot(left).abs() < 0.5 * len
        })
        .min_by(|&a, &b| along(a).total_cmp(&along(b)));
    Ok(Body {
        template: Template::Quadruped,
        feet: all.to_vec(),
        hands: None,
        head,
        tail,
        crotch: None,
        plane,
        hips,
        chest: Some(chest),
        forward,
        left,
        ground,
    })
}

/// Forward (horizontal, unit) and left (`up x forward`).
fn frame(facing: DVec3) -> Result<(DVec3, DVec3)> {
    let f = horizontal(facing);
    if !(f.length() > 1e-9) {
        return Err(Error::InvalidArgument("the facing direction must have a horizontal part".into()));
    }
    let f = f.normalize();
    Ok((f, DVec3::Z.cross(f)))
}

/// First point on the path from leaf `l` into the tree (towards the deepest node) at height `z`.
fn point_at_height(tree: &Tree, l: usize, z: f64) -> Option<DVec3> {
    let line = Line::new(tree, &tree.path(l, tree.deepest()));
    line.at_height(z).map(|s| line.at(s))
}

/// The lowest point, midway between the two legs' paths, that is inside the solid: where the
/// body closes over the legs. Searched from the ground up to `top`, a voxel at a time.
fn crotch(tree: &Tree, vox: &Voxels, feet: [usize; 2], ground: f64, top: f64) -> Option<DVec3> {
    let legs = feet.map(|f| Line::new(tree, &tree.path(f, tree.deepest())));
    let at = |line: &Line, z: f64| line.at_height(z).map(|s| line.at(s));
    let mut z = ground.max(tree.pos[feet[0]].z).max(tree.pos[feet[1]].z) + vox.step;
    while z < top {
        if let (Some(a), Some(b)) = (at(&legs[0], z), at(&legs[1], z)) {
            let mid = (a + b) * 0.5;
            if vox.inside_at(mid) {
                return Some(mid);
            }
        }
        z += 0.5 * vox.step;
    }
    None
}
