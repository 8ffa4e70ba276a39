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
//!   [`LEG_SLOPE`] of the way (a figure lying down has no such leaf), through a tube, not a
//!   sheet: above the foot the solid across the path is at most [`MEMBRANE`] times as wide as
//!   it is thick (`section`; a wing's membrane hanging to the ground, a cape, is no leg);
//! - leaves whose paths meet below [`SHIN`] of the height (a toe and a heel) are one foot;
//! - two or three feet make a biped, four or more a quadruped (its four lowest);
//! - a biped's left-right axis joins its feet; it faces where its toes point (the foot's
//!   lowest vertices lie ahead of the ankle); its hands are the leaves farthest out to each side
//!   and its head the highest other leaf;
//! - a quadruped's body axis is the long axis of its four feet, whose two pairs are its hind
//!   and front legs; the front is the end whose body rises higher (the head and neck); its head
//!   is the most forward leaf, its tail the most backward leaf behind the hind legs on a long
//!   enough branch.

use super::axial;
use super::centreline::Tree;
use super::line::Line;
use super::parts::{end_thickness, frame, horizontal, Body, Template};
use super::section;
use super::symmetry::{mirror_plane, Mirror};
use super::voxels::Voxels;
use crate::{Error, Result};
use glam::DVec3;

/// Feet end within this fraction of the height above the lowest vertex.
const GROUND_BAND: f64 = 0.2;
/// A leg's path, over its first this fraction of the height...
const LEG_WALK: f64 = 0.3;
/// ...climbs at least this fraction of the way it goes.
const LEG_SLOPE: f64 = 0.5;
/// A leg is a tube: across its path above the foot, the solid is at most this many times as wide
/// as it is thick (the median over the path; limbs read 1 to 2, a membrane its width over its
/// thickness, 3 and more).
const MEMBRANE: f64 = 2.5;
/// Legs are compared where they cross this fraction of the height (shins, not toes or heels).
const SHIN: f64 = 0.15;
/// A hand lies at least this fraction of the height to the side of the body's middle.
const HAND_REACH: f64 = 0.12;
/// A tail's branch is at least this fraction of the hind-to-front distance.
const TAIL_LENGTH: f64 = 0.25;
/// Legs hold the body up: nothing but the feet touches the ground within this share of the
/// distance between a pair of feet (horizontally) of the feet's centre.
const UNDER: f64 = 0.25;
/// What lies within this fraction of the height above the lowest vertex touches the ground.
const CONTACT: f64 = 0.04;
/// A foot reaches this fraction of the height beyond its leg (toes, a heel, a boot).
const FOOT: f64 = 0.08;
/// A head and neck rise above the tail by at least this fraction of the height, or the
/// thicker end is the head.
const RISE: f64 = 0.05;

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
    let feet = feet(tree, vox, ground, height);
    let mirror = mirror_plane(vox);
    // Legs that hold the body up, in pairs (a quadruped's pairs found along the tree).
    let pairs: Vec<[usize; 2]> = match feet.len() {
        0 | 1 => Vec::new(),
        2 | 3 => biped_pair(tree, &feet, &mirror, ground, height).into_iter().collect(),
        _ => pair_feet(tree, &feet[..4], &mirror).to_vec(),
    };
    let pairs = if pairs.iter().all(|&p| sides(tree, p, &mirror, ground, height)) { pairs } else { Vec::new() };
    let legs: Vec<usize> = pairs.iter().flatten().copied().collect();
    let legs = if lifted(tree, vox, &legs, ground, height) { legs } else { Vec::new() };
    let n_legs = legs.len();
    let needs = |what: &str| {
        Error::Unsuitable(format!(
            "{what}: {} limb(s) reach the ground and rise from it (the Biped template takes a character \
             standing on its feet, +Z up; Chain and Winged take bodies without legs)",
            feet.len(),
        ))
    };
    let legged = |t: Template| match t {
        Template::Quadruped => {
            quadruped(tree, vertices, &pair_feet(tree, &feet[..4], &mirror), forward, ground, height)
        }
        _ => biped(tree, vox, vertices, [feet[0], feet[1]], forward, ground, height),
    };
    let mut body = match template {
        Template::Quadruped if feet.len() < 4 => {
            return Err(Error::Unsuitable(format!(
                "found {} feet on the ground; a quadruped needs 4 (try the Biped template)",
                feet.len()
            )))
        }
        Template::Biped if feet.len() < 2 => return Err(needs("not standing upright")),
        Template::Biped | Template::Quadruped => legged(template)?,
        Template::Chain => {
            axial::axial_body(tree, vox, &mirror, vertices, &[], (Template::Chain, forward), (ground, height))?
        }
        Template::Winged => {
            axial::axial_body(tree, vox, &mirror, vertices, &legs, (Template::Winged, forward), (ground, height))?
        }
        Template::Auto => {
            let winged =
                axial::axial_body(tree, vox, &mirror, vertices, &legs, (Template::Winged, forward), (ground, height));
            match winged {
                Ok(b) => b,
                Err(_) if n_legs >= 4 => legged(Template::Quadruped)?,
                Err(_) if n_legs >= 2 => legged(Template::Biped)?,
                Err(_) => {
                    axial::axial_body(tree, vox, &mirror, vertices, &[], (Template::Auto, forward), (ground, height))?
                }
            }
        }
    };
    if body.reason.is_empty() {
        body.reason = match (template, body.template) {
            (Template::Auto, Template::Quadruped) => "4 legs hold the body up".into(),
            (Template::Auto, Template::Biped) => "2 legs hold the body up".into(),
            _ => "asked for".into(),
        };
    }
    Ok(body)
}

/// Leaves that reach the ground and rise from it like legs, through a tube, one per leg (a toe
/// and a heel whose paths meet below the shins are one foot, the lowest), lowest first.
fn feet(tree: &Tree, vox: &Voxels, ground: f64, height: f64) -> Vec<usize> {
    let centre = tree.deepest();
    let mut low: Vec<usize> =
        tree.leaves().into_iter().filter(|&l| tree.pos[l].z - tree.radius[l] < ground + GROUND_BAND * height).collect();
    low.sort_by(|&a, &b| tree.pos[a].z.total_cmp(&tree.pos[b].z));
    let mut legs_seen = Vec::new();
    let mut feet: Vec<usize> = Vec::new();
    for &l in &low {
        if !climbs(tree, l, centre, height) {
            continue;
        }
        let path = tree.path(l, centre);
        if section::flatness(tree, vox, &path, FOOT * height, LEG_WALK * height).is_some_and(|f| f > MEMBRANE) {
            continue;
        }
        let leg = shin(tree, &path, ground, height);
        if !legs_seen.contains(&leg) {
            legs_seen.push(leg);
            feet.push(l);
        }
    }
    feet
}

/// A biped's two feet among two or three: of those on opposite sides of the mirror plane, the
/// two nearest each other's mirror images (the lowest two when the body does not mirror well).
fn biped_pair(tree: &Tree, feet: &[usize], mirror: &Mirror, ground: f64, height: f64) -> Option<[usize; 2]> {
    if mirror.score < axial::SYMMETRIC {
        return Some([feet[0], feet[1]]);
    }
    let mut best: Option<([usize; 2], f64)> = None;
    for i in 0..feet.len() {
        for j in i + 1..feet.len() {
            let p = [feet[i], feet[j]];
            let d = (mirror.reflect(tree.pos[p[0]]) - tree.pos[p[1]]).length();
            if sides(tree, p, mirror, ground, height) && best.is_none_or(|b| d < b.1) {
                best = Some((p, d));
            }
        }
    }
    best.map(|b| b.0)
}

/// Do the feet `pair` stand on opposite sides of the mirror plane, their legs off it: where a
/// leg crosses the shins, the plane passes at least half the leg's depth from its centre (a
/// moth's abdomen on the plane is no leg; a winged biped's legs are near the plane for its
/// span, not for their thickness)? Always when the body does not mirror well.
fn sides(tree: &Tree, pair: [usize; 2], mirror: &Mirror, ground: f64, height: f64) -> bool {
    let leg = pair.map(|f| shin(tree, &tree.path(f, tree.deepest()), ground, height));
    let d = leg.map(|n| mirror.distance(tree.pos[n]));
    mirror.score < axial::SYMMETRIC || (d[0] * d[1] < 0.0 && (0..2).all(|i| d[i].abs() >= 0.5 * tree.radius[leg[i]]))
}

/// Where the `path` from a foot up into the body first reaches the shins ([`SHIN`] of the
/// height), or the path's end.
fn shin(tree: &Tree, path: &[usize], ground: f64, height: f64) -> usize {
    path.iter().copied().find(|&n| tree.pos[n].z >= ground + SHIN * height).unwrap_or(path[path.len() - 1])
}

/// Four feet in two pairs, the left and right legs of the hind and the front: of the three ways
/// to pair them, the one whose feet lie nearest to each other's mirror images across the body's
/// vertical mirror plane (a lizard's splayed legs stand wider apart than front from back). A
/// body that does not mirror well pairs the feet whose paths along the tree are shortest.
fn pair_feet(tree: &Tree, feet: &[usize], mirror: &Mirror) -> [[usize; 2]; 2] {
    let d = |a: usize, b: usize| {
        if mirror.score >= axial::SYMMETRIC {
            (mirror.reflect(tree.pos[a]) - tree.pos[b]).length()
        } else {
            tree.path_length(a, b)
        }
    };
    let ways = [[[0, 1], [2, 3]], [[0, 2], [1, 3]], [[0, 3], [1, 2]]];
    let best = ways
        .iter()
        .min_by(|x, y| {
            let cost = |w: &[[usize; 2]; 2]| d(feet[w[0][0]], feet[w[0][1]]) + d(feet[w[1][0]], feet[w[1][1]]);
            cost(x).total_cmp(&cost(y))
        })
        .unwrap();
    best.map(|p| p.map(|i| feet[i]))
}

/// Do the legs ending at `feet` (in pairs) hold the body up: does nothing of the body touch the
/// ground under its middle (within [`UNDER`] of the stance's width, horizontally, of the feet's
/// centre), feet aside (what lies within [`FOOT`] of a leg's path below the shins)? A fish
/// resting on its fins, a cone on flippers or a moth on its abdomen touch the ground there; a
/// lizard's belly, a biped's crotch, a quadruped's belly do not.
/// The ground band is [`CONTACT`] of the height, or two voxels, above the lowest vertex.
fn lifted(tree: &Tree, vox: &Voxels, feet: &[usize], ground: f64, height: f64) -> bool {
    if feet.is_empty() {
        return false;
    }
    // Under the middle: around the feet's centre, within a share of the stance's width.
    let middle = feet.iter().map(|&f| tree.pos[f]).sum::<DVec3>() / feet.len() as f64;
    let reach = UNDER
        * feet
            .chunks(2)
            .map(|p| horizontal(tree.pos[p[0]] - tree.pos[p[p.len() - 1]]).length())
            .fold(f64::INFINITY, f64::min);
    let band = ground + (CONTACT * height).max(2.0 * vox.step);
    // The feet: each foot's path up to the shins (not where it dips into a body resting low),
    // and what lies
    // within their depth and a foot's reach of them, horizontally (a boot, toes, a heel).
    let shin = ground + SHIN * height;
    let soles: Vec<usize> = feet
        .iter()
        .flat_map(|&f| tree.path(f, tree.deepest()).into_iter().take_while(|&n| tree.pos[n].z < shin))
        .chain(feet.iter().copied())
        .collect();
    !(0..vox.inside.len()).filter(|&v| vox.inside[v]).any(|v| {
        let p = vox.centre(v);
        p.z < band
            && horizontal(p - middle).length() <= reach
            && soles.iter().all(|&n| horizontal(p - tree.pos[n]).length() > tree.radius[n] + FOOT * height)
    })
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
        reason: String::new(),
        symmetric: true,
        axial: None,
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
    pairs: &[[usize; 2]; 2],
    forward: Option<DVec3>,
    ground: f64,
    height: f64,
) -> Result<Body> {
    let shin = |f: usize| point_at_height(tree, f, ground + SHIN * height).unwrap_or(tree.pos[f]);
    let mid = |p: [usize; 2]| horizontal(shin(p[0]) + shin(p[1])) * 0.5;
    // The body's axis runs from one pair of legs to the other.
    let axis = (mid(pairs[1]) - mid(pairs[0])).normalize_or(DVec3::X);
    let (back, front) = (pairs[0], pairs[1]);
    let s_back = mid(back).dot(axis);
    let s_front = mid(front).dot(axis);
    let feet: Vec<usize> = pairs.iter().flatten().copied().collect();
    let facing = match forward {
        Some(f) => f,
        None => {
            // The head and neck rise above the body; the tail seldom does. A long, low body
            // (a lizard) holds its head as low as its tail: then its head is the thicker end.
            let top = |beyond: &dyn Fn(f64) -> bool| {
                vertices.iter().filter(|p| beyond(p.dot(axis))).map(|p| p.z).fold(f64::NEG_INFINITY, f64::max)
            };
            let rise = top(&|s| s > s_front) - top(&|s| s < s_back);
            let ahead = if rise.abs() > RISE * height {
                rise > 0.0
            } else {
                let end = |sign: f64| {
                    let beyond = |n: usize| {
                        sign * (horizontal(tree.pos[n]).dot(axis) - if sign > 0.0 { s_front } else { s_back })
                    };
                    let far = (0..tree.pos.len()).max_by(|&a, &b| beyond(a).total_cmp(&beyond(b))).unwrap_or(0);
                    end_thickness(tree, far, beyond(far))
                };
                end(1.0) >= end(-1.0)
            };
            if ahead {
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
        reason: String::new(),
        symmetric: true,
        axial: None,
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
