//! The template skeleton laid along the body's centre lines, with Rigify's metarig names.
//!
//! Inputs: the [`Tree`], the [`Body`] (its parts and directions) and the mesh's vertices (unit
//! frame). Output: the bones `(name, head, tail, parent, connected)`, unit frame, in the order
//! and with the parenting of Rigify's `basic_human` and `basic_quadruped` metarigs.
//!
//! Method: each limb is the tree's path from where it joins the body to its leaf. A limb starts
//! where the path becomes a tube (its radius falls to that of the limb's middle), its inner
//! joints sit at the usual proportions along it (Rigify's metarigs) moved to the sharpest bend
//! within a window of there when the path bends more than a threshold (`line.rs`; a knee, a
//! hock); a biped's ankle is where the leg comes down to the foot's height and its toes reach
//! the front of the foot's vertices. The spine runs from the hips' junction along the path to
//! the head: chest and neck split it at the shoulders' height and at the narrowest point below
//! the head, whose bone ends one head radius past its centre (its base and centre in the middle
//! of the solid across them). Pairs are made exactly mirrored
//! across the mesh's vertical mirror plane.

use super::appendages::{head_appendages, protrusions, snout, Appendage};
use super::bones::{hip, leg_line, limb_points, spine_names, straightness, Bone, Builder, TAIL_MIN};
use super::centreline::Tree;
use super::chain;
use super::line::Line;
use super::parts::{Body, Template};
use super::voxels::Voxels;
use crate::mesh::solid::Solid;
use crate::skeleton::fit::{fit_in, Fitted};
use crate::skeleton::sections::inside;
use crate::skeleton::FitOptions;
use glam::DVec3;

/// A pair whose joints differ from each other's mirror images by more than this (unit frame)
/// is posed, not symmetric, and is not averaged.
const ASYMMETRY: f64 = 0.02;
/// Fit Skeleton moves a joint at most this far (unit frame) when settling.
const SETTLE_MOVE: f64 = 0.03;
/// A biped's ankle lies at this fraction of the hip's height above the ground...
const ANKLE: f64 = 0.08;
/// ...or higher, up to this fraction, where the leg turns onto a long, flat foot.
const HEEL: f64 = 0.25;
/// The head's appendages, pair by pair, longest first (`appendages.rs`).
const EAR_NAMES: [&str; 3] = ["ear", "horn", "antenna"];
/// A quadruped leg's root lies at most this many times the torso's depth off the mirror plane...
const ROOT_IN: f64 = 0.4;
/// ...and this share of the way up from the leg's path at the hip's height to the spine's.
const ROOT_RAISE: f64 = 0.75;

/// The bones for `body`, unit frame: laid along the tree (`vox`: the solid it runs through),
/// mirrored, then settled into the mesh by Fit Skeleton (`mesh`: the mesh in the unit frame
/// and its solid): each joint moves to the middle of its bones' cross-sections, at most
/// [`SETTLE_MOVE`], and joints outside (a centre joint projected onto the mirror plane between
/// a pair of horns) are pulled in.
pub(crate) fn embed(tree: &Tree, vox: &Voxels, body: &Body, vertices: &[DVec3], mesh: &Fitted) -> Vec<Bone> {
    let mut b = Builder { bones: Vec::new() };
    match body.template {
        Template::Quadruped => quadruped(&mut b, tree, vox, body),
        Template::Chain | Template::Winged => chain::chain(&mut b, tree, body),
        _ => biped(&mut b, tree, vox, body, vertices),
    }
    if !body.symmetric {
        settle(&mut b.bones, mesh);
        return b.bones;
    }
    let symmetric = mirror(&mut b.bones, body, None);
    settle(&mut b.bones, mesh);
    mirror(&mut b.bones, body, Some(symmetric));
    ear_tips_inside(&mut b.bones, mesh.solid);
    b.bones
}

/// An ear's tip (its chain's last tail) outside the mesh moves back along its bone, a tenth of
/// it at a time, to the first point inside: a thin ear's end voxel can lie past its surface,
/// farther out than settling pulls a joint in.
fn ear_tips_inside(bones: &mut [Bone], solid: &Solid) {
    let steps = 10;
    let tips: Vec<usize> = (0..bones.len())
        .filter(|&i| EAR_NAMES.iter().any(|e| bones[i].name.starts_with(e)) && bones[i].name.ends_with(".001"))
        .collect();
    if tips.is_empty() {
        return;
    }
    let inside: Vec<bool> = tips
        .iter()
        .flat_map(|&i| (0..steps).map(move |k| (i, k)))
        .map(|(i, k)| inside(solid, bones[i].tail.lerp(bones[i].head, k as f64 / steps as f64)))
        .collect();
    for (n, &i) in tips.iter().enumerate() {
        if let Some(k) = (0..steps).find(|&k| inside[n * steps + k]) {
            bones[i].tail = bones[i].tail.lerp(bones[i].head, k as f64 / steps as f64);
        }
    }
}

/// Move the joints with Fit Skeleton ([`fit_in`], on Auto Rig's own solid; heel markers stay
/// on the ground).
fn settle(bones: &mut [Bone], mesh: &Fitted) {
    // Joints: a bone starting on its parent's tail (connected, or a chain Rigify joins by
    // position: the neck) or head (the tail) shares that joint.
    let mut joints: Vec<[f32; 3]> = Vec::new();
    let mut ends: Vec<[u32; 2]> = Vec::new();
    let mut tail_joint = vec![0u32; bones.len()];
    let mut head_joint = vec![0u32; bones.len()];
    for (i, b) in bones.iter().enumerate() {
        let head = match b.parent {
            Some(p) if b.connected || (b.head - bones[p].tail).length() < 1e-9 => tail_joint[p],
            // Rigify's tail starts on the torso's root.
            Some(p) if (b.head - bones[p].head).length() < 1e-9 => head_joint[p],
            _ => {
                joints.push(b.head.as_vec3().to_array());
                joints.len() as u32 - 1
            }
        };
        head_joint[i] = head;
        joints.push(b.tail.as_vec3().to_array());
        tail_joint[i] = joints.len() as u32 - 1;
        ends.push([head, tail_joint[i]]);
    }
    let mut movable = vec![true; joints.len()];
    for (b, e) in bones.iter().zip(&ends) {
        if b.name.starts_with("heel") {
            movable[e[0] as usize] = false;
            movable[e[1] as usize] = false;
        }
    }
    let opts = FitOptions { max_move: SETTLE_MOVE, ..FitOptions::default() };
    let Ok((moved, _)) = fit_in(mesh, &joints, &ends, &movable, &opts) else {
        return;
    };
    let p = |j: u32| DVec3::from_array(moved[j as usize].map(f64::from));
    for (b, e) in bones.iter_mut().zip(&ends) {
        b.head = p(e[0]);
        b.tail = p(e[1]);
    }
}

fn biped(b: &mut Builder, tree: &Tree, vox: &Voxels, body: &Body, vertices: &[DVec3]) {
    let (fwd, left, ground) = (body.forward, body.left, body.ground);
    // Hips: half a leg's radius above the crotch, when the crotch is found.
    let lines = [0, 1].map(|k| leg_line(tree, body.hips, body.feet[k]));
    let hip_z = body.crotch.map(|c| c.z + 0.5 * lines[0].radius(lines[0].nearest(c)));
    let nodes = tree.path(body.hips, body.head);
    let spine = match (body.crotch, hip_z) {
        (Some(c), Some(z)) => {
            // The torso from the crotch up: the tree's nodes above the hips after the root.
            let kept: Vec<usize> = nodes.iter().copied().filter(|&n| tree.pos[n].z > z).collect();
            let r0 = kept.first().map_or(0.0, |&n| tree.radius[n]);
            Line::from_points(
                std::iter::once((DVec3::new(c.x, c.y, z), r0))
                    .chain(kept.iter().map(|&n| (tree.pos[n], tree.radius[n]))),
            )
        }
        _ => Line::new(tree, &nodes),
    };
    // Legs.
    let legs: Vec<_> = ["L", "R"]
        .iter()
        .zip(lines)
        .map(|(side, line)| {
            let (s_hip, hip) = hip(&line, hip_z);
            (side, line, s_hip, hip)
        })
        .collect();
    // Arms first: the shoulders' height splits chest from neck.
    let mut arms = Vec::new();
    if let (Some(hands), Some(chest)) = (body.hands, body.chest) {
        let lines = hands.map(|h| Line::new(tree, &tree.path(chest, h)));
        // Both arms leave the torso as far from the mirror plane, the farther of where their
        // tubes start (however the hands are posed: an arm thick in its middle, a sleeve or a
        // held prop, reads its tube's start inside the torso).
        let off = |p: DVec3| body.side(p).abs();
        let starts = lines.each_ref().map(|l| l.tube_start(0.0).max(0.15 * l.len()));
        let reach = off(lines[0].at(starts[0])).max(off(lines[1].at(starts[1])));
        for (k, side) in ["L", "R"].iter().enumerate() {
            let line = &lines[k];
            let len = line.len();
            let s_sh = (0..=100)
                .map(|i| starts[k] + (0.5 * len - starts[k]).max(0.0) * i as f64 / 100.0)
                .find(|&s| off(line.at(s)) >= reach)
                .unwrap_or(starts[k].max(0.5 * len));
            let s_wr = s_sh + 0.75 * (len - s_sh);
            let s_el = line.bend_near(s_sh + 0.52 * (s_wr - s_sh), s_sh, s_wr);
            let s_hand = s_wr + 0.45 * (len - s_wr);
            arms.push((side, [line.at(s_sh), line.at(s_el), line.at(s_wr), line.at(s_hand)]));
        }
    }
    let len = spine.len();
    let top_z = spine.p.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max);
    let s_sh = if arms.is_empty() {
        spine.at_height(spine.p[0].z + 0.7 * (top_z - spine.p[0].z)).unwrap_or(0.7 * len)
    } else {
        let z = arms.iter().map(|(_, j)| j[0].z).sum::<f64>() / arms.len() as f64;
        spine.at_height(z).unwrap_or(0.7 * len)
    };
    // Head: its base is the narrowest point in the first half of the way from the shoulders to
    // the end of the path, its centre the widest point past that (not an ear or a horn: they
    // are thinner than the head they grow from).
    let samples = 60;
    let at = |k: usize, a: f64, c: f64| a + (c - a) * k as f64 / samples as f64;
    let s_hb = (0..=samples)
        .map(|k| at(k, s_sh, s_sh + 0.5 * (len - s_sh)))
        .min_by(|&x, &y| spine.radius(x).total_cmp(&spine.radius(y)))
        .unwrap_or(s_sh)
        .max(s_sh + 0.02 * len)
        .min(len);
    let s_hc = (0..=samples)
        .map(|k| at(k, s_hb, len))
        .max_by(|&x, &y| spine.radius(x).total_cmp(&spine.radius(y)))
        .unwrap_or(len);
    let r_head = spine.radius(s_hc);
    let s_nb = s_sh + 0.37 * (s_hb - s_sh);
    let s_nb = s_nb.min(s_hb - 0.02 * len).max(0.6 * s_sh);
    let top = vertices.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max);
    // The head's centre is the middle of the solid across it: the path to the head's leaf can
    // end in a corner of a wide head, off its middle.
    let head_centre = middle_across(vox, spine.at(s_hc), body.left);
    let head_top = head_centre + DVec3::Z * r_head.min(top - head_centre.z);
    let fr = [0.0, 0.23, 0.44, 0.70, 1.0];
    let mut pts: Vec<DVec3> = fr.iter().map(|f| spine.at(f * s_nb)).collect();
    pts.push(spine.at(0.5 * (s_nb + s_hb)));
    // The head's base, too, is the middle of the solid across the neck there.
    pts.push(middle_across(vox, spine.at(s_hb), body.left));
    pts.push(head_top);
    b.chain(&spine_names(0, 7), &pts, None, false);
    // spine.004 (the neck) starts its own rig in Rigify's metarig.
    b.bones[4].connected = false;
    let taken: Vec<usize> = body.feet.iter().copied().chain(body.hands.into_iter().flatten()).collect();
    let ball = (spine.at(s_hc), r_head);
    let pairs = head_appendages(tree, body, &taken, ball, &protrusions(vox, ball));
    ears(b, &pairs, "spine.006");

    for (side, line, s_hip, hip) in legs {
        let foot_z = ground + ANKLE * (hip.z - ground);
        let s_ank = line.crossings(foot_z).find(|&s| s >= s_hip).unwrap_or(0.92 * line.len());
        // A long, flat foot (a rabbit's): the leg's path comes down to the back of the foot and
        // runs along it; the ankle is where it turns from down to along, not where it crosses
        // the ankle's usual height far along the foot.
        let s_ank = line.turn_down_to_along(s_hip, s_ank, ground + HEEL * (hip.z - ground)).unwrap_or(s_ank);
        let ankle = line.at(s_ank);
        let s_knee = line.bend_near(s_hip + 0.53 * (s_ank - s_hip), s_hip, s_ank);
        let mut knee = line.at(s_knee);
        // A straight leg still bends a little forward, so IK knows which way the knee goes.
        knee += fwd * 0.02 * (hip - ankle).length() * straightness(hip, knee, ankle);
        let sign = if *side == "L" { 1.0 } else { -1.0 };
        let reach = 0.3 * (hip.z - ground);
        let foot: Vec<DVec3> = vertices
            .iter()
            .copied()
            .filter(|p| {
                p.z < ankle.z && {
                    let d = *p - ankle;
                    DVec3::new(d.x, d.y, 0.0).length() < reach && sign * d.dot(left) > -0.5 * reach
                }
            })
            .collect();
        let ahead = foot.iter().map(|p| (*p - ankle).dot(fwd)).fold(0.0, f64::max);
        let behind = foot.iter().map(|p| (*p - ankle).dot(fwd)).fold(0.0, f64::min);
        let ankle_flat = DVec3::new(ankle.x, ankle.y, ground);
        let lift = ankle.z - ground;
        let toe_tip = ankle_flat + fwd * (0.9 * ahead) + DVec3::Z * (0.2 * lift);
        let ball = ankle_flat + fwd * (0.62 * 0.9 * ahead) + DVec3::Z * (0.2 * lift);
        let names: Vec<String> = ["thigh", "shin", "foot", "toe"].iter().map(|n| format!("{n}.{side}")).collect();
        b.chain(&names, &[hip, knee, ankle, ball, toe_tip], Some("spine"), false);
        let heel = ankle_flat + fwd * (0.8 * behind);
        let w = line.radius(s_ank).max(0.01);
        b.add(
            &format!("heel.02.{side}"),
            heel - left * sign * w,
            heel + left * sign * w,
            Some(&format!("foot.{side}")),
            false,
        );
    }

    let neck_base = spine.at(s_nb);
    for (side, j) in arms {
        let sign = if *side == "L" { 1.0 } else { -1.0 };
        let mut elbow = j[1];
        elbow -= fwd * 0.02 * (j[0] - j[2]).length() * straightness(j[0], j[1], j[2]);
        let base = neck_base + (j[0] - neck_base) * 0.1 + left * sign * 1e-3;
        let clavicle_tail = neck_base + (j[0] - neck_base) * 0.85;
        let shoulder = format!("shoulder.{side}");
        b.add(&shoulder, base, clavicle_tail, Some("spine.003"), false);
        let names: Vec<String> = ["upper_arm", "forearm", "hand"].iter().map(|n| format!("{n}.{side}")).collect();
        b.chain(&names, &[j[0], elbow, j[2], j[3]], Some(&shoulder), false);
    }
}

fn quadruped(b: &mut Builder, tree: &Tree, vox: &Voxels, body: &Body) {
    let (fwd, left) = (body.forward, body.left);
    let chest = body.chest.unwrap_or(body.head);
    // The torso starts above the hind legs' hip joints (the tree's junction of the hind legs
    // can lie well in front of them, under the belly).
    let legs = [0, 1, 2, 3].map(|k| leg_line(tree, if k < 2 { body.hips } else { chest }, body.feet[k]));
    let hips_along = (0..2).map(|k| hip(&legs[k], None).1.dot(fwd)).sum::<f64>() / 2.0;
    let junction = tree.pos[body.hips];
    let root = junction + fwd * (hips_along - junction.dot(fwd)).min(0.0);
    let nodes = tree.path(body.hips, body.head);
    let spine = Line::from_points(std::iter::once((root, tree.radius[body.hips])).chain(
        nodes.iter().filter(|&&n| tree.pos[n].dot(fwd) > root.dot(fwd)).map(|&n| (tree.pos[n], tree.radius[n])),
    ));
    let len = spine.len();
    let s_f = spine.nearest(tree.pos[chest]).max(0.2 * len).min(0.8 * len);
    // Neck and head: the head is the widest point of the last part; its base the narrowest
    // point between the chest and it.
    let s_nb = s_f + 0.1 * (len - s_f);
    // Torso: five bones from the hips to the neck's start, on the straight line between them
    // (a wide body's centre line is a sheet's, and wanders; Fit Skeleton centres them after).
    let (a, c) = (spine.at(0.0), spine.at(s_nb));
    let pts: Vec<DVec3> = (0..=5).map(|k| a.lerp(c, k as f64 / 5.0)).collect();
    let samples = 60;
    let at = |k: usize, a: f64, c: f64| a + (c - a) * k as f64 / samples as f64;
    let s_hc = (0..=samples)
        .map(|k| at(k, s_nb + 0.4 * (len - s_nb), len))
        .max_by(|&x, &y| spine.radius(x).total_cmp(&spine.radius(y)))
        .unwrap_or(len);
    let s_hb = (0..=samples)
        .map(|k| at(k, s_nb, s_hc))
        .min_by(|&x, &y| spine.radius(x).total_cmp(&spine.radius(y)))
        .unwrap_or(s_nb)
        .max(s_nb + 0.1 * (len - s_nb))
        .min(s_hc - 0.05 * (len - s_nb));
    let taken: Vec<usize> = body.feet.iter().copied().chain(body.tail).collect();
    let ball = (spine.at(s_hc), spine.radius(s_hc));
    let protruding = protrusions(vox, ball);
    let pairs = head_appendages(tree, body, &taken, ball, &protruding);
    // The path to the head's leaf may end in a horn or an ear (the head's farthest point); the
    // head then ends at its snout.
    let leaf = spine.at(len);
    let head_end = if pairs.iter().flatten().any(|c| (c[2] - leaf).length() < (c[2] - c[0]).length()) {
        snout(vox, body, ball.0, fwd, &protruding)
    } else {
        spine.at((len - spine.radius(len)).max(s_hc + 0.05 * (len - s_nb)))
    };
    b.chain(&spine_names(4, 5), &pts, None, false);
    // The neck starts its own rig in Rigify (not connected), where the torso ends.
    let neck = [pts[5], spine.at(0.5 * (s_nb + s_hb)), spine.at(s_hb), head_end];
    b.chain(&spine_names(9, 3), &neck, Some("spine.008"), false);
    ears(b, &pairs, "spine.011");
    // Tail: from the torso's root, as in Rigify's metarig, back along the tree to the tip.
    if let Some(tail) = body.tail {
        let nodes = tree.path(body.hips, tail);
        let line = Line::from_points(std::iter::once((root, tree.radius[body.hips])).chain(
            nodes.iter().filter(|&&n| tree.pos[n].dot(fwd) < root.dot(fwd)).map(|&n| (tree.pos[n], tree.radius[n])),
        ));
        let l = line.len();
        let s1 = l - line.radius(l);
        // A tail that ends about where the torso starts is a rump, not a tail.
        if s1 > TAIL_MIN * (pts[5] - root).length() {
            let pts: Vec<DVec3> = (0..=4).map(|k| line.at(s1 * k as f64 / 4.0)).collect();
            let names: Vec<String> =
                (0..4).map(|k| if k == 3 { "spine".into() } else { format!("spine.{:03}", 3 - k) }).collect();
            b.chain(&names, &pts, Some("spine.004"), false);
        }
    }
    // Legs: hind then front.
    let parts = [(0, "", "spine.004", [0.29, 0.62, 0.85]), (2, "front_", "spine.008", [0.33, 0.67, 0.84])];
    for (first, prefix, parent, fr) in parts {
        let roots = side_roots([&legs[first], &legs[first + 1]], fr[0], body, &spine, vox);
        for (k, side) in ["L", "R"].iter().enumerate() {
            let line = &legs[first + k];
            let (s_hip, hip) = roots[k];
            let bend = if first == 0 { -1.0 } else { 1.0 };
            let pts = limb_points(line, s_hip, hip, &fr, fwd * bend);
            let names: Vec<String> =
                ["thigh", "shin", "foot", "toe"].iter().map(|n| format!("{prefix}{n}.{side}")).collect();
            if first == 0 {
                b.chain(&names, &pts, Some(parent), false);
            } else {
                let sign = if *side == "L" { 1.0 } else { -1.0 };
                // The shoulder blade: from above the spine where the leg joins, down to the leg.
                let s_sh = spine.nearest(hip);
                let top = spine.at(s_sh) + DVec3::Z * 0.6 * spine.radius(s_sh);
                let base = top + left * sign * 0.3 * (hip - spine.at(s_sh)).dot(left).abs();
                let shoulder = format!("shoulder.{side}");
                b.add(&shoulder, base, hip, Some(parent), false);
                b.chain(&names, &pts, Some(&shoulder), false);
            }
        }
    }
}

/// The head's appendage `pairs` (`appendages.rs`) as two-bone chains under the head bone
/// `head`, named as on Rigify's horse metarig (`ear.L` -> `ear.L.001`); a second and third pair,
/// which geometry cannot tell from the first, `horn` and `antenna`.
fn ears(b: &mut Builder, pairs: &[[Appendage; 2]], head: &str) {
    for (pair, base) in pairs.iter().zip(EAR_NAMES) {
        for (chain, side) in pair.iter().zip(["L", "R"]) {
            let names = [format!("{base}.{side}"), format!("{base}.{side}.001")];
            b.chain(&names, chain, Some(head), false);
        }
    }
}

/// `p` moved along the unit direction `dir` to the middle of the solid's chord through it (as
/// far as the solid goes from `p` each way, at most the unit frame's size).
fn middle_across(vox: &Voxels, p: DVec3, dir: DVec3) -> DVec3 {
    p + dir * (0.5 * (vox.reach(p, dir, 1.0) - vox.reach(p, -dir, 1.0)))
}

/// A pair of legs' root joints (the thigh's and the upper arm's heads) and their arc lengths,
/// at the body's sides: each at [`hip`]'s place along the body on its leg's line, raised
/// [`ROOT_RAISE`] of the way from there to the spine's height if it lies below it, and off the
/// mirror plane as far as the leg's line is a share `fr` of the way on to its foot (the upper
/// leg, which a rigger lines the root up above; at most [`ROOT_IN`] times the torso's depth
/// there, the `spine`'s radius), the farther of the pair. The leg's path runs up from the foot
/// to the spine's junction on the mirror plane, so its own point at the hip's height can lie
/// near the plane (the two roots can cross it) and low in the chest: the chest and the rump
/// between the roots would then be the legs' and swing with them. The rule moves roots out and
/// up, never in or down: a [`hip`] already further out stays as far out (Spot's); where the
/// move would take a root out of the solid `vox` (a lizard's splayed legs, Rigify's quadruped's
/// thin ones), both stay at their [`hip`]s.
fn side_roots(lines: [&Line; 2], fr: f64, body: &Body, spine: &Line, vox: &Voxels) -> [(f64, DVec3); 2] {
    let hips = lines.map(|l| hip(l, None));
    let upper = (0..2)
        .map(|k| {
            let (l, (s, at)) = (lines[k], hips[k]);
            let depth = spine.radius(spine.nearest(at));
            body.side(l.at(s + fr * (l.len() - s))).abs().min(ROOT_IN * depth)
        })
        .fold(0.0, f64::max);
    let reach = hips.iter().map(|h| body.side(h.1).abs()).fold(upper, f64::max);
    let out = [0, 1].map(|k| {
        let (s, p) = hips[k];
        let sign = if k == 0 { 1.0 } else { -1.0 };
        let spine_z = spine.at(spine.nearest(p)).z;
        (s, p + body.left * (sign * reach - body.side(p)) + DVec3::Z * ROOT_RAISE * (spine_z - p.z).max(0.0))
    });
    if out.iter().all(|r| vox.inside_at(r.1)) {
        out
    } else {
        hips
    }
}

/// Make pairs exact mirror images and centre bones lie on the body's mirror plane (found from
/// its legs; the spine's own path may wander into an ear or a horn) -- where the pose is
/// symmetric: a limb whose root or end strays more than [`ASYMMETRY`] from its twin's mirror
/// image (a hind leg stepping back) keeps its own joints, and so does a centre joint that far off the plane (a
/// head turned aside).
fn mirror(bones: &mut [Bone], body: &Body, decided: Option<Symmetric>) -> Symmetric {
    let twin = |bones: &[Bone], i: usize| {
        let name = twin_name(&bones[i].name)?;
        bones.iter().position(|b| b.name == name)
    };
    // The limb of a side bone: its first side ancestor's name.
    let limb = |bones: &[Bone], mut i: usize| {
        while let Some(p) = bones[i].parent.filter(|&p| side_of(&bones[p].name).is_some()) {
            i = p;
        }
        bones[i].name.clone()
    };
    // A limb strays when its root or its end (a bone with no side child) is away from its
    // twin's image; inner joints may differ by where each side's bend was found.
    let decided = decided.unwrap_or_else(|| {
        let mut straying: Vec<String> = Vec::new();
        for i in 0..bones.len() {
            let side_child =
                |b: &Bone| b.parent == Some(i) && side_of(&b.name).is_some() && !b.name.starts_with("heel");
            let is_end = !bones.iter().any(side_child);
            let is_root = bones[i].parent.is_none_or(|p| side_of(&bones[p].name).is_none());
            if let Some(j) = twin(bones, i).filter(|_| is_end || is_root) {
                let mut off: f64 = 0.0;
                if is_root {
                    off = off.max((bones[i].head - body.mirror(bones[j].head)).length());
                }
                if is_end {
                    off = off.max((bones[i].tail - body.mirror(bones[j].tail)).length());
                }
                if off > ASYMMETRY {
                    straying.push(limb(bones, i));
                }
            }
        }
        let on_plane = bones
            .iter()
            .map(|b| {
                let torso = torso_ends(&b.name, body.template);
                let near = [b.head, b.tail].map(|p| side_of(&b.name).is_none() && body.side(p).abs() <= ASYMMETRY);
                [near[0] || torso[0], near[1] || torso[1]]
            })
            .collect();
        Symmetric { straying, on_plane }
    });
    for i in 0..bones.len() {
        match side_of(&bones[i].name) {
            None => {
                for (p, on) in [&mut bones[i].head, &mut bones[i].tail].into_iter().zip(decided.on_plane[i]) {
                    if on {
                        *p = body.onto_plane(*p);
                    }
                }
            }
            Some(true) => {
                if let Some(j) = twin(bones, i).filter(|_| !decided.straying.contains(&limb(bones, i))) {
                    let head = (bones[i].head + body.mirror(bones[j].head)) * 0.5;
                    let tail = (bones[i].tail + body.mirror(bones[j].tail)) * 0.5;
                    bones[i].head = head;
                    bones[i].tail = tail;
                    bones[j].head = body.mirror(head);
                    bones[j].tail = body.mirror(tail);
                }
            }
            Some(false) => {}
        }
    }
    // Connected children start where their parents end.
    for i in 0..bones.len() {
        if let (true, Some(p)) = (bones[i].connected, bones[i].parent) {
            bones[i].head = bones[p].tail;
        }
    }
    decided
}

/// Which ends (head, tail) of bone `name` are the torso's joints, from the hips to the neck's
/// base, in a biped's or quadruped's skeleton: they lie on the mirror plane wherever the
/// centre line runs (a wide torso's centre line is a sheet's and wanders towards a prop held
/// out to one side); the neck and head keep their own place when turned aside.
fn torso_ends(name: &str, template: Template) -> [bool; 2] {
    let (first, last) = match template {
        Template::Biped => (0, 3),
        Template::Quadruped => (4, 8),
        _ => return [false, false],
    };
    let k = match name.strip_prefix("spine") {
        Some("") => 0,
        Some(rest) => match rest.strip_prefix('.').and_then(|d| d.parse::<usize>().ok()) {
            Some(k) => k,
            None => return [false, false],
        },
        None => return [false, false],
    };
    if (first..=last).contains(&k) {
        [true, true]
    } else if k == last + 1 || (template == Template::Quadruped && k == first - 1) {
        // the neck starts where the torso ends, a quadruped's tail where it starts
        [true, false]
    } else {
        [false, false]
    }
}

/// What [`mirror`] decided, kept for its second pass after settling: the limbs posed
/// asymmetrically, and the centre joints (per bone: head, tail) on the plane.
struct Symmetric {
    straying: Vec<String>,
    on_plane: Vec<[bool; 2]>,
}

/// `Some(true)` for a left bone, `Some(false)` for a right one, `None` on the centre line: the
/// side is the name's last part, or the one before a chain's number (`ear.L.001`).
fn side_of(name: &str) -> Option<bool> {
    let stem = match name.rsplit_once('.') {
        Some((stem, n)) if !n.is_empty() && n.bytes().all(|c| c.is_ascii_digit()) => stem,
        _ => name,
    };
    if stem.ends_with(".L") {
        Some(true)
    } else if stem.ends_with(".R") {
        Some(false)
    } else {
        None
    }
}

/// The right twin's name of a left bone (`thigh.L` -> `thigh.R`, `ear.L.001` -> `ear.R.001`).
fn twin_name(name: &str) -> Option<String> {
    if side_of(name) != Some(true) {
        return None;
    }
    let at = name.rfind(".L")?;
    Some(format!("{}.R{}", &name[..at], &name[at + 2..]))
}
