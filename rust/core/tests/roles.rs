//! Skeleton roles (`motion::detect_roles`) on the test rigs: bipeds, quadrupeds, six legs, rigs
//! of separate trees and IK-exported game rigs, tails, arms and what is neither, errors.

mod common;

use common::rigs::{
    biped, biped_bones, bone, creature, ik_biped, ik_quadruped, rest_of, skeleton_of, spot, BoneSpec, Rig,
};
use glam::Vec3;
use miniskeleton_core::motion::{detect_roles, motion_clip, BodyPlan, GaitParams, Motion, Roles, Side, Skeleton, Skin};
use miniskeleton_core::Error;

#[test]
fn quadruped_made_of_separate_trees() {
    let (names, h, t, p) = spot();
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!(r.plan, BodyPlan::Quadruped);
    assert_eq!(names[r.root], "body_root");
    assert_eq!(named(&names, &r.spine), ["body_root", "body_spine", "body_back"]);
    assert_eq!(named(&names, &r.neck), ["neck_root", "neck_mid"]);
    assert_eq!(names[r.head], "head");
    assert_eq!(named(&names, &r.tail), ["tail", "tail_leaf"]);
    assert_eq!(leg(&names, &r, Side::Left, 0)[0], "leg_front_L_hip");
    assert_eq!(leg(&names, &r, Side::Right, 0)[0], "leg_front_R_hip");
    assert_eq!(leg(&names, &r, Side::Left, 1)[..3], ["leg_back_L_hip", "leg_back_L_knee", "leg_back_L_ankle"]);
    assert!((Vec3::from(r.forward) - Vec3::Y).length() < 1e-2, "{:?}", r.forward);
    assert!(!r.single_tree);
    // without names the head is still found at the front end
    let r2 = detect_roles(&Skeleton::new(&h, &t, &p, &[])).unwrap();
    assert_eq!(r2.legs.len(), 4);
    assert!(["head", "neck_mid"].contains(&names[r2.head].as_str()), "{}", names[r2.head]);
}

#[test]
fn the_leg_length_is_the_reach_of_the_shortest_legs() {
    // The test Spot's hind hooves rest 7.5 units above its front ones (as Spot's mesh stands):
    // its hind legs reach 31.5 from their hips, its front legs 37 from the chest. The stride is
    // one for all four legs, so it scales by what the shorter legs reach (a mean of 34.25 made
    // the auto-rigged Spot's hind thighs swing 49 degrees in a walk and fold its flanks).
    let (names, h, t, p) = spot();
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    let reach = |group: usize| {
        let l = r.legs.iter().find(|l| l.group == group).expect("leg");
        let low = l.bones.iter().map(|&b| h[b][2].min(t[b][2])).fold(f32::INFINITY, f32::min);
        h[l.bones[0]][2] - low
    };
    let (front, hind) = (reach(0), reach(1));
    assert!((front - 37.0).abs() < 1e-3 && (hind - 31.5).abs() < 1e-3, "{front} {hind}");
    assert!((r.leg_length - hind).abs() < 1e-3, "{} (hind legs {hind}, front {front})", r.leg_length);
}

fn named(names: &[String], ids: &[usize]) -> Vec<String> {
    ids.iter().map(|&i| names[i].clone()).collect()
}

fn leg(names: &[String], r: &Roles, side: Side, group: usize) -> Vec<String> {
    let l = r.legs.iter().find(|l| l.side == side && l.group == group).expect("leg");
    named(names, &l.bones)
}

#[test]
fn quadruped_roles() {
    let (names, h, t, p) = creature();
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!(r.plan, BodyPlan::Quadruped);
    assert_eq!(named(&names, &r.spine), ["spine", "chest"]);
    assert_eq!(named(&names, &r.neck), ["neck"]);
    assert_eq!(names[r.head], "head");
    assert_eq!(named(&names, &r.head_extras).len(), 3);
    assert_eq!(named(&names, &r.tail), ["tail.001", "tail.002", "tail.003"]);
    assert_eq!(leg(&names, &r, Side::Left, 0), ["upper_arm.L", "forearm.L", "hand.L"]);
    assert_eq!(leg(&names, &r, Side::Right, 0), ["upper_arm.R", "forearm.R", "hand.R"]);
    assert_eq!(leg(&names, &r, Side::Left, 1), ["thigh.L", "shin.L", "foot.L"]);
    assert_eq!(leg(&names, &r, Side::Right, 1), ["thigh.R", "shin.R", "foot.R"]);
    assert!(r.arms.is_empty());
    assert!((Vec3::from(r.forward) - Vec3::NEG_Y).length() < 1e-3, "{:?}", r.forward);
    assert!((Vec3::from(r.left) - Vec3::X).length() < 1e-3);
    assert!(r.notes.is_empty(), "{:?}", r.notes);
    assert!(r.single_tree);
}

/// The creature's tail dropped to the ground or curled up above its head stays its tail: a
/// tail reaching the ground is no leg, and the head end of the body is found by the names on
/// the way to it (a plume rising above the head, named without "tail") or by a tail's own
/// name (head bones named without a head word).
#[test]
fn a_tail_on_the_ground_or_above_the_head_stays_the_tail() {
    const TAIL: [&str; 3] = ["tail.001", "tail.002", "tail.003"];
    // The roles' tail and head with the tail's joints (tail1, tail2, tail3) moved and bones
    // renamed.
    let tailed = |joints: [[f32; 3]; 3], rename: &[(&str, &str)]| {
        let (mut names, mut h, mut t, p) = creature();
        for (k, name) in TAIL.iter().enumerate() {
            let b = bone(&names, name);
            if k > 0 {
                h[b] = joints[k - 1];
            }
            t[b] = joints[k];
        }
        for (from, to) in rename {
            let k = bone(&names, from);
            names[k] = to.to_string();
        }
        let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
        assert_eq!(r.plan, BodyPlan::Quadruped, "{rename:?}");
        (named(&names, &r.tail), names[r.head].clone())
    };
    let tail = TAIL.map(String::from).to_vec();
    let base = [0.0, 0.85, 1.08];
    assert_eq!(tailed([base, [0.0, 1.10, 0.6], [0.0, 1.25, 0.03]], &[]), (tail.clone(), "head".into()));
    let up = [base, [0.0, 1.0, 1.6], [0.0, 0.9, 2.1]];
    let plume = [("tail.001", "plume.001"), ("tail.002", "plume.002"), ("tail.003", "plume.003")];
    let (_, head) = tailed(up, &plume);
    assert_eq!(head, "head");
    let unnamed = [("neck", "n1"), ("head", "n2"), ("jaw", "n3")];
    assert_eq!(tailed(up, &unnamed), (tail, "n2".into()));
    // Hanging straight down under the hips (2 cm back over its 0.5 m), the chain is a
    // flap, not a tail: a tail points back by more than 5 % of the height.
    let flap = [[0.0, 0.56, 0.8], [0.0, 0.565, 0.65], [0.0, 0.57, 0.5]];
    assert_eq!(tailed(flap, &[]), (vec![], "head".into()));
}

/// A pair of cape panels (one long bone each, hanging off the chest like a pair of arms)
/// are no arms: an arm is a chain of two bones or more, with a partner on the other side.
#[test]
fn hanging_single_bones_are_not_arms() {
    let (mut names, mut h, mut t, mut p) = creature();
    let chest = bone(&names, "chest") as i32;
    for (side, x) in [("L", 0.15), ("R", -0.15)] {
        names.push(format!("cape.{side}"));
        h.push([x, -0.2, 1.1]);
        t.push([x, -0.2, 0.5]);
        p.push(chest);
    }
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert!(r.arms.is_empty(), "{:?}", r.arms);
    assert_eq!(r.plan, BodyPlan::Quadruped);
    // Nor is a chain on one side only (a bag's strap): arms come in pairs.
    let (mut names, mut h, mut t, mut p) = creature();
    for (k, (a, b)) in
        [([0.2, -0.3, 1.05], [0.25, -0.3, 0.8]), ([0.25, -0.3, 0.8], [0.25, -0.2, 0.5])].into_iter().enumerate()
    {
        names.push(format!("strap.00{k}"));
        h.push(a);
        t.push(b);
        p.push(if k == 0 { chest } else { names.len() as i32 - 2 });
    }
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert!(r.arms.is_empty(), "{:?}", r.arms);
}

/// The creature with each leg's bones moved by `dy` along Y (forward is -Y).
fn creature_with_legs_moved(dy: [(&str, f32); 4]) -> Rig {
    let (names, mut h, mut t, p) = creature();
    for (leg, d) in dy {
        let (kind, side) = leg.split_once('.').unwrap();
        let bones = if kind == "front" { ["upper_arm", "forearm", "hand"] } else { ["thigh", "shin", "foot"] };
        for b in bones {
            let i = bone(&names, &format!("{b}.{side}"));
            h[i][1] += d;
            t[i][1] += d;
        }
    }
    (names, h, t, p)
}

#[test]
fn quadruped_in_mid_stride_keeps_a_front_and_a_back_pair() {
    // The horse scan's rough rig: hips above the feet, each pair's tops apart by more
    // than the 0.15 h that groups legs (h = 1.8 here), the pairs much further apart.
    let (names, h, t, p) =
        creature_with_legs_moved([("front.L", -0.35), ("front.R", 0.0), ("back.L", 0.0), ("back.R", 0.30)]);
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!(r.plan, BodyPlan::Quadruped);
    assert_eq!(leg(&names, &r, Side::Left, 0)[0], "upper_arm.L");
    assert_eq!(leg(&names, &r, Side::Right, 0)[0], "upper_arm.R");
    assert_eq!(leg(&names, &r, Side::Left, 1)[0], "thigh.L");
    assert_eq!(leg(&names, &r, Side::Right, 1)[0], "thigh.R");
    // Four legs evenly along the body (left, right, left, right) are no two pairs.
    let (names, h, t, p) =
        creature_with_legs_moved([("front.L", -0.5), ("front.R", 0.0), ("back.L", -0.5), ("back.R", 0.0)]);
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!(r.plan, BodyPlan::Multiped);
}

#[test]
fn six_legs_make_three_groups_front_to_back() {
    // The creature with a middle pair of legs (its hind legs moved 0.5 forward, off the
    // spine): the tops of each pair lie within 0.15 h, the pairs 0.5 apart (h ~ 1.85).
    let (mut names, mut h, mut t, mut p) = creature();
    let spine = bone(&names, "spine") as i32;
    for s in ["L", "R"] {
        let mut parent = spine;
        for b in ["thigh", "shin", "foot"] {
            let i = bone(&names, &format!("{b}.{s}"));
            let (mut head, mut tail) = (h[i], t[i]);
            head[1] -= 0.5;
            tail[1] -= 0.5;
            names.push(format!("mid_{b}.{s}"));
            h.push(head);
            t.push(tail);
            p.push(parent);
            parent = names.len() as i32 - 1;
        }
    }
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!((r.plan, r.legs.len()), (BodyPlan::Multiped, 6));
    for (group, top) in [(0, "upper_arm"), (1, "mid_thigh"), (2, "thigh")] {
        for side in [Side::Left, Side::Right] {
            let first = &leg(&names, &r, side, group)[0];
            assert!(first.starts_with(top), "group {group} {side:?}: {first}");
        }
    }
}

#[test]
fn quadruped_roles_without_names_and_turned() {
    // same creature rotated 90° about Z (faces +X), names hidden
    let (names, h, t, p) = creature();
    let rot = |q: [f32; 3]| [-q[1], q[0], q[2]];
    let h: Vec<_> = h.into_iter().map(rot).collect();
    let t: Vec<_> = t.into_iter().map(rot).collect();
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &[])).unwrap();
    assert_eq!(r.plan, BodyPlan::Quadruped);
    assert!((Vec3::from(r.forward) - Vec3::X).length() < 1e-3, "{:?}", r.forward);
    assert_eq!(named(&names, &r.spine), ["spine", "chest"]);
    assert_eq!(names[r.head], "head");
    assert_eq!(leg(&names, &r, Side::Left, 0)[0], "upper_arm.L");
    assert_eq!(leg(&names, &r, Side::Right, 1)[0], "thigh.R");
}

#[test]
fn biped_roles() {
    let (names, h, t, p) = biped();
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!(r.plan, BodyPlan::Biped);
    assert_eq!(named(&names, &r.spine), ["hips", "spine", "chest"]);
    assert_eq!(named(&names, &r.neck), ["neck"]);
    assert_eq!(names[r.head], "head");
    assert_eq!(leg(&names, &r, Side::Left, 0), ["thigh.L", "shin.L", "foot.L", "toe.L"]);
    assert_eq!(leg(&names, &r, Side::Right, 0)[0], "thigh.R");
    assert_eq!(r.arms.len(), 2);
    let la = r.arms.iter().find(|a| a.side == Side::Left).unwrap();
    assert_eq!(named(&names, &la.bones)[..3], ["shoulder.L", "upper_arm.L", "forearm.L"]);
    assert!((Vec3::from(r.forward) - Vec3::NEG_Y).length() < 1e-3, "{:?}", r.forward);
    assert!((r.leg_length - 0.98).abs() < 1e-3, "{}", r.leg_length);
    // without names too
    let r2 = detect_roles(&Skeleton::new(&h, &t, &p, &[])).unwrap();
    assert_eq!(names[r2.head], "head");
    assert_eq!(r2.legs.len(), 2);
}

/// Legs are long (their chain drops at least a fifth of the height) and arms reach a fifth
/// of it: a biped's two short flaps hanging from the hips toward the ground (a tabard)
/// and two short pouch chains on the chest are neither legs nor arms.
#[test]
fn short_flaps_and_pouches_are_neither_legs_nor_arms() {
    let mut b = biped_bones();
    for (s, x) in [("L", 1.0f32), ("R", -1.0)] {
        let f = |n: &str| format!("{n}.{s}");
        b.extend([
            (f("flap"), [0.15 * x, -0.1, 0.4], [0.15 * x, -0.1, 0.28], Some("hips".into())),
            (f("flap_end"), [0.15 * x, -0.1, 0.28], [0.15 * x, -0.1, 0.15], Some(f("flap"))),
            (f("pouch"), [0.1 * x, -0.1, 1.35], [0.2 * x, -0.1, 1.3], Some("chest".into())),
            (f("pouch_end"), [0.2 * x, -0.1, 1.3], [0.26 * x, -0.1, 1.25], Some(f("pouch"))),
        ]);
    }
    let (names, h, t, p) = skeleton_of(&b);
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!(r.plan, BodyPlan::Biped);
    assert_eq!(r.legs.len(), 2);
    assert_eq!(leg(&names, &r, Side::Left, 0)[0], "thigh.L");
    assert_eq!(r.arms.len(), 2);
    assert!(r.arms.iter().all(|a| names[a.bones[1]].starts_with("upper_arm")), "{:?}", r.arms);
}

#[test]
fn ik_exported_biped_feet_ride_on_their_legs_and_t_posed_arms_are_arms() {
    for invented_tails in [false, true] {
        let (names, h, t, p) = ik_biped(invented_tails);
        let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
        assert_eq!(r.plan, BodyPlan::Biped);
        assert_eq!(leg(&names, &r, Side::Left, 0), ["UpperLeg.L", "LowerLeg.L", "Foot.L"]);
        assert_eq!(leg(&names, &r, Side::Right, 0), ["UpperLeg.R", "LowerLeg.R", "Foot.R"]);
        let riders: Vec<[String; 2]> = r.riders.iter().map(|&[a, b]| [names[a].clone(), names[b].clone()]).collect();
        assert_eq!(riders.len(), 2, "{riders:?}");
        for s in ["L", "R"] {
            assert!(riders.contains(&[format!("Foot.{s}"), format!("LowerLeg.{s}")]), "{riders:?}");
        }
        assert!(r.notes.iter().any(|n| n.contains("Foot.L")), "{:?}", r.notes);
        // the arms rise 0.23 above the shoulder over a reach of 2.1: arms, so the spine
        // reaches the torso they hang from and the neck is the neck alone (not the torso)
        assert_eq!(r.arms.len(), 2);
        let la = r.arms.iter().find(|a| a.side == Side::Left).unwrap();
        assert_eq!(named(&names, &la.bones)[..3], ["Shoulder.L", "UpperArm.L", "LowerArm.L"]);
        assert_eq!(named(&names, &r.spine), ["Root", "Body", "Hips", "Abdomen", "Torso"]);
        assert_eq!(named(&names, &r.neck), ["Neck"]);
        assert_eq!(names[r.head], "Head");
        assert!(r.head_extras.iter().all(|&b| names[b].starts_with("Ear")));
        assert!((Vec3::from(r.forward) - Vec3::NEG_Y).length() < 1e-3, "{:?}", r.forward);
    }
}

#[test]
fn rigs_with_feet_on_their_legs_have_no_riders() {
    for (names, h, t, p) in [biped(), creature(), spot()] {
        assert!(detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap().riders.is_empty());
    }
    // a narrow biped, arms out, whose feet hang off the hips (the root) level with the shins'
    // ends: they ride on their shins, and nothing on the head, whose end is too high to be a
    // leg's
    let mut b: Vec<BoneSpec> = vec![
        ("hips".into(), [0.0, 0.0, 1.0], [0.0, 0.0, 1.2], None),
        ("spine".into(), [0.0, 0.0, 1.2], [0.0, 0.0, 1.5], Some("hips".into())),
        ("neck".into(), [0.0, 0.0, 1.5], [0.0, 0.0, 1.6], Some("spine".into())),
        ("head".into(), [0.0, 0.0, 1.6], [0.0, 0.0, 1.8], Some("neck".into())),
    ];
    for (s, x) in [("L", 1.0f32), ("R", -1.0)] {
        let f = |n: &str| format!("{n}.{s}");
        b.extend([
            (f("thigh"), [0.1 * x, 0.0, 1.0], [0.1 * x, 0.0, 0.5], Some("hips".into())),
            (f("shin"), [0.1 * x, 0.0, 0.5], [0.1 * x, 0.0, 0.0], Some(f("thigh"))),
            (f("arm"), [0.2 * x, 0.0, 1.45], [0.5 * x, 0.0, 1.45], Some("spine".into())),
            (f("hand"), [0.5 * x, 0.0, 1.45], [0.7 * x, 0.0, 1.45], Some(f("arm"))),
            (f("foot"), [0.1 * x, -0.02, 0.0], [0.1 * x, -0.2, 0.0], Some("hips".into())),
        ]);
    }
    let (names, h, t, p) = skeleton_of(&b);
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    let mut riders: Vec<[String; 2]> = r.riders.iter().map(|&[a, b]| [names[a].clone(), names[b].clone()]).collect();
    riders.sort();
    assert_eq!(riders, [["foot.L", "shin.L"], ["foot.R", "shin.R"]].map(|r| r.map(String::from)));
    assert_eq!(names[r.head], "head");
}

/// A quadruped exported from an IK set-up: its feet start at the hock and wrist off the ground
/// root, beside IK targets and before knee poles also off the root, and its shins' tails are
/// invented. The feet ride on their shins and forearms (not the IK targets at the same joints,
/// nor the tail), so the hind legs are legs, not arms.
#[test]
fn an_ik_exported_quadrupeds_feet_ride_on_their_legs() {
    let (names, h, t, p) = ik_quadruped();
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!(r.plan, BodyPlan::Quadruped, "{:?}", r.legs);
    assert!(r.arms.is_empty(), "{:?}", r.arms);
    for s in ["L", "R"] {
        let side = if s == "L" { Side::Left } else { Side::Right };
        assert_eq!(
            leg(&names, &r, side, 0),
            ["UpperArm", "ForeArm", "FrontFoot", "FrontToe"].map(|n| format!("{n}.{s}"))
        );
        assert_eq!(leg(&names, &r, side, 1), ["Thigh", "Shin", "HindFoot", "HindToe"].map(|n| format!("{n}.{s}")));
    }
    let mut riders: Vec<String> = r.riders.iter().map(|&[a, _]| names[a].clone()).collect();
    riders.sort();
    assert_eq!(riders, ["FrontFoot.L", "FrontFoot.R", "HindFoot.L", "HindFoot.R"]);
    assert_eq!(names[r.head], "Head");
    assert_eq!(names[r.tail[0]], "Tail");
}

#[test]
fn thousands_of_hair_bones_leave_the_roles_as_they_were() {
    // 400 strands of 10 bones hanging off the head: the mirror-plane scan samples the
    // 8000+ bone ends (it compares every pair) and still finds the body's plane
    let (mut names, mut h, mut t, mut p) = biped();
    let plain = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    let head = bone(&names, "head") as i32;
    for k in 0..400 {
        let x = 0.1 * ((k as f32 * 0.618).fract() - 0.5);
        for j in 0..10 {
            let z = 1.78 - 0.01 * j as f32;
            names.push(format!("hair{k}_{j}"));
            h.push([x, 0.05 + 0.01 * j as f32, z]);
            t.push([x, 0.06 + 0.01 * j as f32, z - 0.01]);
            p.push(if j == 0 { head } else { h.len() as i32 - 2 });
        }
    }
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!(named(&names, &r.spine), named(&names, &plain.spine));
    assert_eq!(r.legs.len(), 2);
    assert_eq!(leg(&names, &r, Side::Left, 0), leg(&names, &plain, Side::Left, 0));
    assert_eq!(r.arms.len(), 2);
    assert_eq!(names[r.head], "head");
    assert!((Vec3::from(r.forward) - Vec3::from(plain.forward)).length() < 1e-3, "{:?}", r.forward);
}

/// A small separate tree starting where the body's root starts (a skirt or a belly flap
/// rigged on its own) joins the body, not the body it: the weaker tree is joined first, so
/// the body's root stays the root whatever the bones' order.
#[test]
fn a_small_tree_at_the_roots_head_joins_the_body() {
    let (plain_names, h, t, p) = biped();
    let plain = detect_roles(&Skeleton::new(&h, &t, &p, &plain_names)).unwrap();
    let mut b = biped_bones();
    let hips = b[0].1; // the body's root, listed first
    b.extend([
        ("skirt0".into(), hips, [0.0, 0.1, 0.85], None),
        ("skirt1".into(), [0.0, 0.1, 0.85], [0.0, 0.15, 0.7], Some("skirt0".into())),
    ]);
    let (names, h, t, p) = skeleton_of(&b);
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!(names[r.root], "hips");
    assert_eq!(named(&names, &r.spine), named(&plain_names, &plain.spine));
    assert_eq!(leg(&names, &r, Side::Left, 0), leg(&plain_names, &plain, Side::Left, 0));
    assert_eq!(names[r.head], "head");
}

/// A body with a neck and a head and no legs (a blob, a bust): legless roles; a walk or run is
/// refused with "no legs", a head shake turns the head.
#[test]
fn a_legless_body_shakes_its_head_but_does_not_walk() {
    let h = vec![[0.0, 0.0, 1.0], [0.0, 0.0, 2.0], [0.0, 0.0, 2.5]];
    let t = vec![[0.0, 0.0, 2.0], [0.0, 0.0, 2.5], [0.0, 0.0, 3.0]];
    let names: Vec<String> = ["body", "neck", "head"].map(String::from).to_vec();
    let parents = [-1, 0, 1];
    let r = detect_roles(&Skeleton::new(&h, &t, &parents, &names)).unwrap();
    assert_eq!(r.plan, BodyPlan::Legless);
    assert!(r.legs.is_empty());
    assert_eq!(names[r.head], "head");
    let rest = rest_of(&h, &t);
    for motion in [Motion::Walk, Motion::Run] {
        let params = GaitParams { motion, ..GaitParams::default() };
        let err = motion_clip(&Skeleton::new(&h, &t, &parents, &[]), &rest, &r, &params, &Skin::NONE).unwrap_err();
        assert!(err.to_string().contains("no legs"), "{err}");
    }
    let params = GaitParams { motion: Motion::HeadShake, ..GaitParams::default() };
    let clip = motion_clip(&Skeleton::new(&h, &t, &parents, &[]), &rest, &r, &params, &Skin::NONE).unwrap();
    assert!(clip.animated.contains(&r.head));
    let turn = (0..clip.frames).map(|f| clip.rotation(f, r.head)[0].abs()).fold(1.0f32, f32::min);
    assert!(turn < 0.995, "the head turns (half of 30 degrees): min |w| {turn}");
}

#[test]
fn no_head_is_a_clear_error() {
    // a hip bone with two legs and nothing else
    let h = vec![[-0.2, 0.0, 1.0], [-0.2, 0.0, 1.0], [0.2, 0.0, 1.0]];
    let t = vec![[0.2, 0.0, 1.0], [-0.2, 0.0, 0.0], [0.2, 0.0, 0.0]];
    let err = detect_roles(&Skeleton::new(&h, &t, &[-1, 0, 0], &[])).unwrap_err();
    assert!(err.to_string().contains("no head"), "{err}");
}

#[test]
fn bad_input_is_rejected() {
    assert!(detect_roles(&Skeleton::new(&[], &[], &[], &[])).is_err());
    let h = vec![[0.0; 3], [0.0, 0.0, 1.0]];
    let t = vec![[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]];
    assert!(matches!(detect_roles(&Skeleton::new(&h, &t, &[1, 0], &[])), Err(Error::InvalidArgument(_))));
    assert!(matches!(detect_roles(&Skeleton::new(&h, &t, &[-1], &[])), Err(Error::Shape(_))));
    let nan = vec![[f32::NAN; 3], [0.0; 3]];
    assert!(matches!(detect_roles(&Skeleton::new(&nan, &t, &[-1, 0], &[])), Err(Error::NonFinite { .. })));
}

/// Legs' names are read by the one left/right rule (`skeleton::name_side`): a biped (its head
/// above its hips, so forward is not known from the head) whose legs are named for the other
/// side in the 3ds Max style, `Bip01_R_thigh` on the left, is turned round to face +Y so that
/// its names are right. (The roles' former rule read no side in `_R_`.)
#[test]
fn legs_named_with_a_side_letter_between_underscores_set_the_side() {
    let rename = |n: &str| match n.rsplit_once('.') {
        Some((bone, side)) if ["thigh", "shin", "foot", "toe"].contains(&bone) => {
            format!("Bip01_{}_{bone}", if side == "L" { "R" } else { "L" })
        }
        _ => n.to_string(),
    };
    let b: Vec<BoneSpec> =
        biped_bones().into_iter().map(|(n, h, t, p)| (rename(&n), h, t, p.as_deref().map(rename))).collect();
    let (names, h, t, p) = skeleton_of(&b);
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert!((Vec3::from(r.forward) - Vec3::Y).length() < 1e-3, "{:?}", r.forward);
    assert!(r.notes.iter().any(|n| n.contains("taken from the .L/.R bone names")), "{:?}", r.notes);
    assert_eq!(leg(&names, &r, Side::Left, 0), ["Bip01_L_thigh", "Bip01_L_shin", "Bip01_L_foot", "Bip01_L_toe"]);
}

#[test]
fn a_tail_the_hierarchy_starts_from_is_no_spine() {
    // Rigify's quadruped and cat metarigs run the spine chain from the tail's tip: the tip is
    // the root and the hips its descendant
    let (names, mut h, mut t, mut p) = creature();
    let tail: Vec<usize> = ["tail.001", "tail.002", "tail.003"].iter().map(|n| bone(&names, n)).collect();
    let spine = bone(&names, "spine");
    for &b in &tail {
        std::mem::swap(&mut h[b], &mut t[b]);
    }
    p[tail[2]] = -1;
    p[tail[1]] = tail[2] as i32;
    p[tail[0]] = tail[1] as i32;
    p[spine] = tail[0] as i32;
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!(r.plan, BodyPlan::Quadruped);
    assert!(r.spine.contains(&spine) && !tail.iter().any(|b| r.spine.contains(b)), "{:?}", named(&names, &r.spine));
    assert_eq!((names[r.head].as_str(), r.legs.len()), ("head", 4));
    // the walk turns no tail bone: each carries the whole body
    let rest = rest_of(&h, &t);
    let params = GaitParams { motion: Motion::Walk, ..Default::default() };
    let clip = motion_clip(&Skeleton::new(&h, &t, &p, &[]), &rest, &r, &params, &Skin::NONE).unwrap();
    assert!(!tail.iter().any(|b| clip.animated.contains(b)), "{:?}", named(&names, &clip.animated));
}

#[test]
fn a_mane_reaching_above_the_head_is_not_the_head() {
    // a neck bone's child rising higher than the head (Rigify's horse mane, a crest)
    let (mut names, mut h, mut t, mut p) = creature();
    let neck = bone(&names, "neck");
    names.push("mane".into());
    h.push([0.0, -0.6, 1.25]);
    t.push([0.0, -0.6, 2.0]);
    p.push(neck as i32);
    let r = detect_roles(&Skeleton::new(&h, &t, &p, &names)).unwrap();
    assert_eq!(names[r.head], "head");
    assert_eq!(named(&names, &r.neck), ["neck"]);
}

/// A T-posed biped lies nearly in one vertical plane: mirrored front to back across it, it
/// matches itself about as well as mirrored left to right, and better once a hand holds a prop
/// forward and the torso bends aside. The skeleton here is Auto Rig's for such a character
/// (the shared q_Bunny: its torso's centre line wanders towards the carrot it holds), rounded:
/// its roles read the right hand as the head and both legs on one side, so its run skated.
/// The sagittal plane lies between the legs; the plane they lie in does not.
#[test]
fn a_t_posed_biped_holding_a_prop_faces_its_feet() {
    let b: Vec<BoneSpec> = vec![
        ("spine".into(), [0.0, 0.18, 0.83], [0.0, 0.18, 1.06], None),
        ("spine.001".into(), [0.0, 0.18, 1.06], [0.14, 0.18, 1.27], Some("spine".into())),
        ("spine.002".into(), [0.14, 0.18, 1.27], [0.22, 0.18, 1.53], Some("spine.001".into())),
        ("spine.003".into(), [0.22, 0.18, 1.53], [0.37, 0.18, 1.79], Some("spine.002".into())),
        ("spine.004".into(), [0.37, 0.18, 1.79], [0.35, 0.17, 1.81], Some("spine.003".into())),
        ("spine.005".into(), [0.35, 0.17, 1.81], [0.15, 0.19, 1.87], Some("spine.004".into())),
        ("spine.006".into(), [0.15, 0.19, 1.87], [0.14, -0.18, 2.37], Some("spine.005".into())),
        ("thigh.L".into(), [0.35, 0.20, 0.83], [0.34, 0.23, 0.46], Some("spine".into())),
        ("shin.L".into(), [0.34, 0.23, 0.46], [0.33, 0.28, 0.12], Some("thigh.L".into())),
        ("foot.L".into(), [0.33, 0.28, 0.12], [0.36, 0.11, 0.06], Some("shin.L".into())),
        ("toe.L".into(), [0.36, 0.11, 0.06], [0.36, -0.15, 0.02], Some("foot.L".into())),
        ("heel.02.L".into(), [0.23, 0.36, 0.0], [0.43, 0.36, 0.0], Some("foot.L".into())),
        ("thigh.R".into(), [-0.36, 0.19, 0.83], [-0.35, 0.22, 0.46], Some("spine".into())),
        ("shin.R".into(), [-0.35, 0.22, 0.46], [-0.34, 0.27, 0.12], Some("thigh.R".into())),
        ("foot.R".into(), [-0.34, 0.27, 0.12], [-0.36, 0.10, 0.06], Some("shin.R".into())),
        ("toe.R".into(), [-0.36, 0.10, 0.06], [-0.36, -0.16, 0.02], Some("foot.R".into())),
        ("heel.02.R".into(), [-0.24, 0.35, 0.0], [-0.44, 0.35, 0.0], Some("foot.R".into())),
        ("shoulder.L".into(), [0.42, 0.17, 1.81], [0.73, 0.17, 1.81], Some("spine.003".into())),
        ("upper_arm.L".into(), [0.80, 0.18, 1.81], [1.79, 0.13, 1.83], Some("shoulder.L".into())),
        ("forearm.L".into(), [1.79, 0.13, 1.83], [1.86, -0.42, 1.70], Some("upper_arm.L".into())),
        ("hand.L".into(), [1.86, -0.42, 1.70], [2.08, -0.61, 1.80], Some("forearm.L".into())),
        ("shoulder.R".into(), [0.25, 0.18, 1.79], [-0.63, 0.15, 1.72], Some("spine.003".into())),
        ("upper_arm.R".into(), [-0.81, 0.17, 1.81], [-1.39, 0.16, 1.81], Some("shoulder.R".into())),
        ("forearm.R".into(), [-1.39, 0.16, 1.81], [-1.73, 0.12, 1.83], Some("upper_arm.R".into())),
        ("hand.R".into(), [-1.73, 0.12, 1.83], [-2.11, 0.20, 1.93], Some("forearm.R".into())),
    ];
    let (names, h, t, p) = skeleton_of(&b);
    for named_bones in [&names[..], &[]] {
        let r = detect_roles(&Skeleton::new(&h, &t, &p, named_bones)).unwrap();
        assert_eq!(r.plan, BodyPlan::Biped);
        assert_eq!(names[r.head], "spine.006");
        assert_eq!(leg(&names, &r, Side::Left, 0)[..3], ["thigh.L", "shin.L", "foot.L"]);
        assert_eq!(leg(&names, &r, Side::Right, 0)[..3], ["thigh.R", "shin.R", "foot.R"]);
        assert!((Vec3::from(r.forward) - Vec3::NEG_Y).length() < 0.05, "{:?}", r.forward);
        let mut hands: Vec<&str> = r.arms.iter().map(|a| names[*a.bones.last().unwrap()].as_str()).collect();
        hands.sort();
        assert_eq!(hands, ["hand.L", "hand.R"]);
    }
}
