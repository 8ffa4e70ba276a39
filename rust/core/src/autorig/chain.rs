//! The Chain and Winged templates laid along a spine, with the names and parents of Rigify's
//! shark and bird metarigs.
//!
//! Inputs: the [`Tree`] and a [`Body`] with its `Axial` part (the spine's nodes from tail to
//! head, wing tips, paired side chains, legs' feet). Output: bones added to the [`Builder`]
//! (unit frame), parents first:
//! - Chain (`shark.py`): torso `spine.003` (the root) → `spine.008` → `spine.004` →
//!   `spine.005`, head `spine.006` → `spine.007`, a tail `spine.002` → `spine.001` → `spine`
//!   leaving the root backwards; each pair of side chains (fins, flippers, tentacles) two bones
//!   `side_fin.L` → `side_fin.001.L` (the next pairs `chest_fin`, `back_fin`, ...), from the
//!   head back, under the spine bone nearest to where they join;
//! - Winged (`bird.py`): torso `spine.003` → `spine.004` → `spine.005` → `spine.006`, neck and
//!   head `neck.001` → `neck.002` → `head`, a tail as the chain's; wings `shoulder.L` →
//!   `Wing.L` → `Wing.001.L` → `Wing.002.L` → `Wing.003.L` (upper arm, forearm, hand, tip);
//!   two legs `thigh`, `shin`, `foot`, `toe` (.L/.R), or four as the quadruped's (`front_thigh`
//!   ...).
//!
//! Method: the spine's line is split at the shares of [`Proportions`] (the root where the legs
//! join when there are legs; the neck at the narrowest point near its share, or just past the
//! wings); limbs start where their path from the spine becomes a tube and their inner joints
//! sit at the shares of [`WING`], [`LEG`] and [`FRONT_LEG`], moved to the sharpest bend near
//! each (`embed::limb_points`).

use super::bones::{hip, leg_line, limb_points, spine_names, Builder, MIN_BONE, TAIL_MIN};
use super::centreline::Tree;
use super::line::Line;
use super::parts::{Body, Template};
use glam::DVec3;

/// Where a spine is split, as shares of its length from the tail end.
struct Proportions {
    /// The torso's root (`spine.003`); the tail runs back from here to the tail end.
    root: f64,
    /// The torso's end: the head's base (chain) or the neck's base (winged).
    neck: f64,
}

/// A fish or snake: the shark metarig's root at 40 % of the length, its head the last 20 %.
const CHAIN_LYING: Proportions = Proportions { root: 0.4, neck: 0.8 };
/// A standing blob (its lower end is no tail): the head the top 30 %.
const CHAIN_STANDING: Proportions = Proportions { root: 0.0, neck: 0.7 };
/// A winged body without legs, lying or flying: a short tail, the neck's base past the wings.
const WINGED_LYING: Proportions = Proportions { root: 0.3, neck: 0.75 };
const WINGED_STANDING: Proportions = Proportions { root: 0.0, neck: 0.75 };
/// The neck's base is searched this share of the length either side of its proportion for the
/// narrowest point.
const NECK_WINDOW: f64 = 0.1;
/// The neck's base lies this share of the way from where the wings join to the head's end.
const WING_NECK: f64 = 0.15;
/// Wing joints (forearm, hand, tip bone's start) at these shares of the wing past its shoulder.
const WING: [f64; 3] = [0.3, 0.62, 0.85];
/// Leg joints (knee, ankle, ball), as the quadruped's hind and front legs.
const LEG: [f64; 3] = [0.29, 0.62, 0.85];
const FRONT_LEG: [f64; 3] = [0.33, 0.67, 0.84];
/// Side-chain base names, from the head back (after these, `fin.005`, `fin.006`, ...).
const FIN_NAMES: [&str; 5] = ["side_fin", "chest_fin", "back_fin", "mid_fin", "tail_fin"];

/// Lay the chain or winged template of `body` along `tree`.
pub(super) fn chain(b: &mut Builder, tree: &Tree, body: &Body) {
    let Some(axial) = &body.axial else { return };
    let spine = Line::from_points(
        std::iter::once((axial.tips[0], 0.0))
            .chain(axial.spine.iter().map(|&n| (tree.pos[n], tree.radius[n])))
            .chain(std::iter::once((axial.tips[1], 0.0))),
    );
    let len = spine.len();
    let winged = body.template == Template::Winged;
    let props = match (winged, axial.upright) {
        (false, false) => CHAIN_LYING,
        (false, true) => CHAIN_STANDING,
        (true, false) => WINGED_LYING,
        (true, true) => WINGED_STANDING,
    };
    // Where limbs join the spine (arc length): the nearest spine node of their path.
    let joins = |leaf: usize| {
        let path = tree.path(leaf, *axial.spine.last().unwrap());
        let j = path.iter().copied().find(|n| axial.spine.contains(n)).unwrap_or(axial.spine[0]);
        (j, spine.nearest(tree.pos[j]))
    };
    let legs_at = (!body.feet.is_empty()).then(|| {
        let hind = &body.feet[..2];
        hind.iter().map(|&f| joins(f).1).sum::<f64>() / 2.0
    });
    let s_root = legs_at.unwrap_or(props.root * len).clamp(0.0, 0.6 * len);
    let s_neck = match axial.wings.filter(|_| winged) {
        Some(w) => {
            let s_w = (joins(w[0]).1 + joins(w[1]).1) / 2.0;
            s_w + WING_NECK * (len - s_w)
        }
        None => narrowest(&spine, props.neck * len, NECK_WINDOW * len),
    }
    .max(s_root + 0.2 * (len - s_root))
    .min(len - 0.1 * (len - s_root));
    let tip = (len - 0.5 * spine.radius(len)).max(s_neck + 0.05 * len).min(len);
    let torso: Vec<DVec3> = (0..=4).map(|k| spine.at(s_root + (s_neck - s_root) * k as f64 / 4.0)).collect();
    let torso_names: Vec<String> = if winged {
        spine_names(3, 4)
    } else {
        ["spine.003", "spine.008", "spine.004", "spine.005"].map(String::from).to_vec()
    };
    b.chain(&torso_names, &torso, None, false);
    let last = torso_names[3].clone();
    if winged {
        // Neck and head (the bird's neck.001, neck.002, head): the head from the narrowest
        // point past the neck's base.
        let s_hb = narrowest(&spine, s_neck + 0.5 * (tip - s_neck), 0.35 * (tip - s_neck));
        let pts = [spine.at(s_neck), spine.at(0.5 * (s_neck + s_hb)), spine.at(s_hb), spine.at(tip)];
        b.chain(&["neck.001", "neck.002", "head"].map(String::from), &pts, Some(&last), false);
    } else {
        let pts = [spine.at(s_neck), spine.at(0.5 * (s_neck + tip)), spine.at(tip)];
        b.chain(&["spine.006", "spine.007"].map(String::from), &pts, Some(&last), false);
    }
    // Tail: from the root back to the tail end, as in Rigify's metarigs (from the root's head).
    let tail_tip = 0.5 * spine.radius(0.0);
    if s_root - tail_tip > TAIL_MIN * (s_neck - s_root) {
        let pts: Vec<DVec3> = (0..=3).map(|k| spine.at(s_root - (s_root - tail_tip) * k as f64 / 3.0)).collect();
        b.chain(&["spine.002", "spine.001", "spine"].map(String::from), &pts, Some("spine.003"), false);
    }
    let torso_bones: Vec<&str> = torso_names.iter().map(String::as_str).collect();
    let spine_bones: Vec<String> = b.bones.iter().map(|x| x.name.clone()).collect();
    let (fwd, left) = (body.forward, body.left);
    // Legs.
    let leg_parts: &[(usize, &str, [f64; 3])] = if body.feet.len() == 4 {
        &[(0, "", LEG), (2, "front_", FRONT_LEG)]
    } else if body.feet.len() == 2 {
        &[(0, "", LEG)]
    } else {
        &[]
    };
    for &(first, prefix, fr) in leg_parts {
        for (k, side) in ["L", "R"].iter().enumerate() {
            let foot = body.feet[first + k];
            let line = leg_line(tree, joins(foot).0, foot);
            let (s_hip, hip_at) = hip(&line, None);
            let bend = if first == 0 { -1.0 } else { 1.0 };
            let pts = limb_points(&line, s_hip, hip_at, &fr, fwd * bend);
            let names: Vec<String> =
                ["thigh", "shin", "foot", "toe"].iter().map(|n| format!("{prefix}{n}.{side}")).collect();
            let parent = nearest_bone(b, &torso_bones, pts[0]);
            b.chain(&names, &pts, Some(&parent), false);
        }
    }
    // Wings: a shoulder from the spine to where the wing becomes a tube, then four bones.
    if let Some(w) = axial.wings.filter(|_| winged) {
        for (k, side) in ["L", "R"].iter().enumerate() {
            let (j, _) = joins(w[k]);
            let line = Line::new(tree, &tree.path(j, w[k]));
            let s0 = line.tube_start(0.0).max(0.15 * line.len());
            let pts = limb_points(&line, s0, line.at(s0), &WING, -fwd);
            let base = line.at(0.0) + (pts[0] - line.at(0.0)) * 0.1 + left * (if k == 0 { 1e-3 } else { -1e-3 });
            let parent = nearest_bone(b, &torso_bones, pts[0]);
            let shoulder = format!("shoulder.{side}");
            b.add(&shoulder, base, pts[0], Some(&parent), false);
            let names: Vec<String> =
                ["Wing", "Wing.001", "Wing.002", "Wing.003"].iter().map(|n| format!("{n}.{side}")).collect();
            b.chain(&names, &pts, Some(&shoulder), false);
        }
    }
    // Side chains: two bones each, under the spine bone nearest to where they join.
    let spine_refs: Vec<&str> = spine_bones.iter().map(String::as_str).collect();
    for (i, pair) in axial.fins.iter().enumerate() {
        let base = FIN_NAMES.get(i).map_or_else(|| format!("fin.{i:03}"), |n| n.to_string());
        for (k, side) in ["L", "R"].iter().enumerate() {
            let (j, _) = joins(pair[k]);
            let line = Line::new(tree, &tree.path(j, pair[k]));
            let l = line.len();
            let s0 = line.tube_start(0.0).min(0.5 * l);
            let end = (l - 0.5 * line.radius(l)).max(s0 + 2.0 * MIN_BONE);
            let pts = [line.at(s0), line.at(0.5 * (s0 + end)), line.at(end)];
            let parent = nearest_bone(b, &spine_refs, pts[0]);
            let names = [format!("{base}.{side}"), format!("{base}.001.{side}")];
            b.chain(&names, &pts, Some(&parent), false);
        }
    }
}

/// The arc length of the narrowest point of `line` within `half` of `s` (`s` itself when the
/// window is empty).
fn narrowest(line: &Line, s: f64, half: f64) -> f64 {
    let samples = 40;
    (0..=samples)
        .map(|k| (s - half + 2.0 * half * k as f64 / samples as f64).clamp(0.0, line.len()))
        .min_by(|&x, &y| line.radius(x).total_cmp(&line.radius(y)))
        .unwrap_or(s)
}

/// The name of the bone among `names` whose segment is nearest to `p`.
fn nearest_bone(b: &Builder, names: &[&str], p: DVec3) -> String {
    b.bones
        .iter()
        .filter(|x| names.contains(&x.name.as_str()))
        .map(|x| {
            let ab = x.tail - x.head;
            let t = ((p - x.head).dot(ab) / ab.length_squared().max(1e-30)).clamp(0.0, 1.0);
            (x.name.clone(), (x.head + ab * t - p).length())
        })
        .min_by(|a, c| a.1.total_cmp(&c.1))
        .map_or_else(|| names[0].to_string(), |(n, _)| n)
}
