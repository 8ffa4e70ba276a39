//! The test rigs of the motion tests (`roles.rs`, `gait.rs`): hand-written skeletons as arrays
//! of bone names, heads, tails and parents, +Z up. Plain data and glam only, so that the core's
//! own unit tests can include this file too (`#[path]` in `motion/gait.rs`).

use glam::{Mat3, Vec3};

/// A test rig: bone names, heads, tails, parent indices (-1: root).
pub type Rig = (Vec<String>, Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<i32>);
/// One bone of a hand-written rig: name, head, tail, parent's name (`None`: root).
pub type BoneSpec = (String, [f32; 3], [f32; 3], Option<String>);

/// The index of the bone called `name`.
pub fn bone(names: &[String], name: &str) -> usize {
    names.iter().position(|n| n == name).unwrap()
}

/// The add-on's generated quadruped (scripts/creature.py), faces -Y.
pub fn creature() -> Rig {
    let mut joints: Vec<(&str, [f32; 3])> = vec![
        ("hips", [0.0, 0.55, 1.00]),
        ("spine", [0.0, 0.05, 1.05]),
        ("chest", [0.0, -0.45, 1.08]),
        ("neck", [0.0, -0.75, 1.38]),
        ("head", [0.0, -0.95, 1.58]),
        ("snout", [0.0, -1.30, 1.50]),
        ("tail1", [0.0, 0.85, 1.08]),
        ("tail2", [0.0, 1.15, 1.20]),
        ("tail3", [0.0, 1.40, 1.22]),
        ("ear.L", [0.12, -0.92, 1.85]),
        ("ear.R", [-0.12, -0.92, 1.85]),
    ];
    let sides: [(&str, f32); 2] = [("L", 0.24), ("R", -0.24)];
    let mut owned: Vec<(String, [f32; 3])> = joints.drain(..).map(|(a, p)| (a.to_string(), p)).collect();
    for (s, x) in sides {
        for (j, p) in [
            ("shoulder", [x, -0.45, 0.95]),
            ("elbow", [x, -0.48, 0.55]),
            ("wrist", [x, -0.45, 0.12]),
            ("fronttoe", [x, -0.60, 0.05]),
            ("hip", [x, 0.55, 0.92]),
            ("knee", [x, 0.62, 0.55]),
            ("ankle", [x, 0.52, 0.12]),
            ("hindtoe", [x, 0.38, 0.05]),
        ] {
            owned.push((format!("{j}.{s}"), p));
        }
    }
    let jp = |name: &str| owned.iter().find(|(n, _)| n == name).unwrap().1;
    let mut bones: Vec<(String, String, String, Option<String>)> = vec![
        ("spine", "hips", "spine", None),
        ("chest", "spine", "chest", Some("spine")),
        ("neck", "chest", "neck", Some("chest")),
        ("head", "neck", "head", Some("neck")),
        ("jaw", "head", "snout", Some("head")),
        ("tail.001", "hips", "tail1", Some("spine")),
        ("tail.002", "tail1", "tail2", Some("tail.001")),
        ("tail.003", "tail2", "tail3", Some("tail.002")),
        ("ear.L", "head", "ear.L", Some("head")),
        ("ear.R", "head", "ear.R", Some("head")),
    ]
    .into_iter()
    .map(|(a, b, c, d)| (a.into(), b.into(), c.into(), d.map(String::from)))
    .collect();
    for s in ["L", "R"] {
        let f = |x: &str| format!("{x}.{s}");
        bones.extend([
            (f("upper_arm"), f("shoulder"), f("elbow"), Some("chest".to_string())),
            (f("forearm"), f("elbow"), f("wrist"), Some(f("upper_arm"))),
            (f("hand"), f("wrist"), f("fronttoe"), Some(f("forearm"))),
            (f("thigh"), f("hip"), f("knee"), Some("spine".to_string())),
            (f("shin"), f("knee"), f("ankle"), Some(f("thigh"))),
            (f("foot"), f("ankle"), f("hindtoe"), Some(f("shin"))),
        ]);
    }
    let names: Vec<String> = bones.iter().map(|b| b.0.clone()).collect();
    let idx = |n: &str| bone(&names, n) as i32;
    let heads = bones.iter().map(|b| jp(&b.1)).collect();
    let tails = bones.iter().map(|b| jp(&b.2)).collect();
    let parents = bones.iter().map(|b| b.3.as_deref().map_or(-1, idx)).collect();
    (names, heads, tails, parents)
}

/// A hand-written rig as arrays, parents looked up by name.
pub fn skeleton_of(b: &[BoneSpec]) -> Rig {
    let names: Vec<String> = b.iter().map(|x| x.0.clone()).collect();
    let idx = |n: &str| bone(&names, n) as i32;
    let parents = b.iter().map(|x| x.3.as_deref().map_or(-1, idx)).collect();
    (names.clone(), b.iter().map(|x| x.1).collect(), b.iter().map(|x| x.2).collect(), parents)
}

/// A simple human, facing -Y, arms down: hips root, 3 spine bones, neck, head,
/// clavicle/upper arm/forearm/hand, thigh/shin/foot/toe.
pub fn biped() -> Rig {
    skeleton_of(&biped_bones())
}

/// The bones of [`biped`], to extend.
pub fn biped_bones() -> Vec<BoneSpec> {
    let mut b: Vec<BoneSpec> = vec![
        ("hips".into(), [0.0, 0.0, 1.0], [0.0, 0.0, 1.1], None),
        ("spine".into(), [0.0, 0.0, 1.1], [0.0, 0.0, 1.3], Some("hips".into())),
        ("chest".into(), [0.0, 0.0, 1.3], [0.0, 0.0, 1.5], Some("spine".into())),
        ("neck".into(), [0.0, 0.0, 1.5], [0.0, 0.0, 1.6], Some("chest".into())),
        ("head".into(), [0.0, 0.0, 1.6], [0.0, 0.0, 1.8], Some("neck".into())),
    ];
    for (s, x) in [("L", 1.0f32), ("R", -1.0)] {
        let f = |n: &str| format!("{n}.{s}");
        b.extend([
            (f("shoulder"), [0.02 * x, 0.0, 1.45], [0.18 * x, 0.0, 1.45], Some("chest".into())),
            (f("upper_arm"), [0.18 * x, 0.0, 1.45], [0.2 * x, 0.0, 1.17], Some(f("shoulder"))),
            (f("forearm"), [0.2 * x, 0.0, 1.17], [0.21 * x, -0.02, 0.92], Some(f("upper_arm"))),
            (f("hand"), [0.21 * x, -0.02, 0.92], [0.21 * x, -0.02, 0.75], Some(f("forearm"))),
            (f("thigh"), [0.1 * x, 0.0, 1.0], [0.1 * x, -0.02, 0.52], Some("hips".into())),
            (f("shin"), [0.1 * x, -0.02, 0.52], [0.1 * x, 0.0, 0.08], Some(f("thigh"))),
            (f("foot"), [0.1 * x, 0.0, 0.08], [0.1 * x, -0.14, 0.02], Some(f("shin"))),
            (f("toe"), [0.1 * x, -0.14, 0.02], [0.1 * x, -0.2, 0.02], Some(f("foot"))),
        ]);
    }
    b
}

/// A six-legged insect facing -Y, Z up: abdomen (root) -> thorax -> head, and three pairs
/// of legs off the thorax, each a femur rising outward and a tibia down to the ground, with
/// a short foot.
pub fn hexapod() -> Rig {
    let mut b: Vec<BoneSpec> = vec![
        ("abdomen".into(), [0.0, 0.7, 0.5], [0.0, 0.3, 0.5], None),
        ("thorax".into(), [0.0, 0.3, 0.5], [0.0, -0.3, 0.5], Some("abdomen".into())),
        ("head".into(), [0.0, -0.3, 0.5], [0.0, -0.55, 0.55], Some("thorax".into())),
    ];
    for (s, x) in [("L", 1.0f32), ("R", -1.0)] {
        for (pair, y) in [("front", -0.25f32), ("middle", 0.0), ("back", 0.25)] {
            let f = |n: &str| format!("{pair}_{n}.{s}");
            b.extend([
                (f("femur"), [0.08 * x, y, 0.5], [0.35 * x, y, 0.6], Some("thorax".into())),
                (f("tibia"), [0.35 * x, y, 0.6], [0.5 * x, y, 0.05], Some(f("femur"))),
                (f("foot"), [0.5 * x, y, 0.05], [0.55 * x, y, 0.0], Some(f("tibia"))),
            ]);
        }
    }
    skeleton_of(&b)
}

/// A game-style biped exported from an IK set-up (the structure of the Quaternius and
/// RobotExpressive rigs, not their data): a ground root carrying the feet and knee pole
/// targets, a body bone carrying the legs and a hips -> torso -> neck -> head chain, long
/// ears, T-posed arms whose clavicle and fingers rise a little. The leg chains stop at the
/// ankle; with `invented_tails`, every bone has a tiny tail along its direction (glTF stores
/// joints only: RobotExpressive imports so), and the shins end at the knee.
/// Faces -Y, Z up.
pub fn ik_biped(invented_tails: bool) -> Rig {
    let mut b: Vec<BoneSpec> = vec![
        ("Root".into(), [0.0, 0.2, 0.0], [0.0, 0.2, 0.35], None),
        ("Body".into(), [0.0, 0.05, 0.95], [0.0, 0.05, 1.2], Some("Root".into())),
        ("Hips".into(), [0.0, 0.25, 0.8], [0.0, 0.3, 1.1], Some("Body".into())),
        ("Abdomen".into(), [0.0, 0.3, 1.1], [0.0, 0.27, 1.4], Some("Hips".into())),
        ("Torso".into(), [0.0, 0.27, 1.4], [0.0, 0.2, 1.7], Some("Abdomen".into())),
        ("Neck".into(), [0.0, 0.1, 1.95], [0.0, -0.05, 2.05], Some("Torso".into())),
        ("Head".into(), [0.0, -0.05, 2.05], [0.0, -0.2, 2.4], Some("Neck".into())),
    ];
    for (s, x) in [("L", 1.0f32), ("R", -1.0)] {
        let f = |n: &str| format!("{n}.{s}");
        let knee = [0.35 * x, 0.2, 0.55];
        let ankle = [0.35 * x, 0.25, 0.13];
        let shin_end = if invented_tails { [0.35 * x, 0.2, 0.4] } else { ankle };
        b.extend([
            (f("Ear1"), [0.24 * x, -0.2, 2.3], [0.36 * x, -0.2, 2.6], Some("Head".into())),
            (f("Ear2"), [0.36 * x, -0.2, 2.6], [0.42 * x, -0.2, 3.05], Some(f("Ear1"))),
            (f("Ear3"), [0.42 * x, -0.2, 3.05], [0.43 * x, -0.35, 3.5], Some(f("Ear2"))),
            (f("Shoulder"), [0.17 * x, 0.22, 1.65], [0.37 * x, 0.22, 1.82], Some("Torso".into())),
            (f("UpperArm"), [0.37 * x, 0.22, 1.82], [1.2 * x, 0.18, 1.82], Some(f("Shoulder"))),
            (f("LowerArm"), [1.2 * x, 0.18, 1.82], [1.74 * x, 0.16, 1.85], Some(f("UpperArm"))),
            (f("Middle1"), [1.74 * x, 0.16, 1.85], [2.0 * x, 0.15, 1.88], Some(f("LowerArm"))),
            (f("Middle2"), [2.0 * x, 0.15, 1.88], [2.23 * x, 0.15, 1.86], Some(f("Middle1"))),
            (f("UpperLeg"), [0.34 * x, 0.22, 0.97], knee, Some("Body".into())),
            (f("LowerLeg"), knee, shin_end, Some(f("UpperLeg"))),
            (f("Foot"), [0.35 * x, 0.28, 0.04], [0.35 * x, -0.07, 0.04], Some("Root".into())),
            (f("PoleTarget"), [0.35 * x, -1.6, 0.6], [0.35 * x, -1.6, 0.95], Some("Root".into())),
        ]);
    }
    if invented_tails {
        for bone in &mut b {
            let (h, t) = (Vec3::from(bone.1), Vec3::from(bone.2));
            bone.2 = (h + 0.006 * (t - h).normalize()).to_array();
        }
    }
    skeleton_of(&b)
}

/// A generated rig with the structure of Spot the cow's hand-made one (not its data): seven
/// separate root trees meeting at shared joints (chest, hips, skull), glTF-style "_leaf"
/// bones pointing straight down, legs about 40 units long, facing +Y, Z up.
pub fn spot() -> Rig {
    let chest = [0.0, 0.0, -2.0];
    let hips = [0.0, -20.0, 0.0];
    let skull = [0.0, 19.0, 10.0];
    let down = |p: [f32; 3], d: f32| [p[0], p[1], p[2] - d];
    let mut rows: Vec<(String, i32, [f32; 3], [f32; 3])> = Vec::new();
    let mut add = |name: &str, parent: i32, h: [f32; 3], t: [f32; 3]| -> i32 {
        rows.push((name.to_string(), parent, h, t));
        rows.len() as i32 - 1
    };
    let root = add("neck_root", -1, chest, [0.0, 13.0, 6.0]);
    let mid = add("neck_mid", root, [0.0, 13.0, 6.0], skull);
    for (side, x) in [("L", -1.0f32), ("R", 1.0)] {
        let horn = add(&format!("horn_{side}"), mid, skull, [6.5 * x, 25.0, 24.5]);
        add(&format!("horn_{side}_leaf"), horn, [6.5 * x, 25.0, 24.5], [6.5 * x, 25.0, 8.0]);
    }
    let head = add("head", mid, skull, [0.0, 30.0, 1.0]);
    for (side, x) in [("L", -1.0f32), ("R", 1.0)] {
        let m = add(&format!("mouth_corner_{side}"), head, [0.0, 30.0, 1.0], [9.0 * x, 30.0, -3.0]);
        add(&format!("mouth_corner_{side}_leaf"), m, [9.0 * x, 30.0, -3.0], [9.0 * x, 30.0, -13.0]);
    }
    for (side, x) in [("L", -1.0f32), ("R", 1.0)] {
        let e = add(&format!("ear_{side}"), mid, skull, [13.0 * x, 20.0, 18.0]);
        add(&format!("ear_{side}_leaf"), e, [13.0 * x, 20.0, 18.0], [13.0 * x, 20.0, 2.5]);
    }
    let tail = add("tail", -1, hips, [0.0, -31.0, 2.0]);
    add("tail_leaf", tail, [0.0, -31.0, 2.0], down([0.0, -31.0, 2.0], 11.5));
    // (upper end, knee, ankle) per pair: front knees bend forward, hind hocks backward
    let legs = [
        ("back", hips, [7.5, -24.0, -8.5], [9.0, -26.0, -15.0], [8.5, -29.5, -23.0]),
        ("front", chest, [8.5, 2.5, -14.5], [9.5, 0.5, -23.5], [9.5, -1.5, -30.5]),
    ];
    for (end, root_joint, hip, knee, ankle) in legs {
        for (side, x) in [("L", -1.0f32), ("R", 1.0)] {
            let hip = [hip[0] * x, hip[1], hip[2]];
            let knee = [knee[0] * x, knee[1], knee[2]];
            let ankle = [ankle[0] * x, ankle[1], ankle[2]];
            let h = add(&format!("leg_{end}_{side}_hip"), -1, root_joint, hip);
            let k = add(&format!("leg_{end}_{side}_knee"), h, hip, knee);
            let a = add(&format!("leg_{end}_{side}_ankle"), k, knee, ankle);
            add(&format!("leg_{end}_{side}_ankle_leaf"), a, ankle, down(ankle, 8.5));
        }
    }
    let body = add("body_root", -1, chest, [0.0, -5.0, -2.5]);
    let spine = add("body_spine", body, [0.0, -5.0, -2.5], [0.0, -10.0, -2.5]);
    let back = add("body_back", spine, [0.0, -10.0, -2.5], hips);
    add("body_back_leaf", back, hips, down(hips, 10.0));
    (
        rows.iter().map(|r| r.0.clone()).collect(),
        rows.iter().map(|r| r.2).collect(),
        rows.iter().map(|r| r.3).collect(),
        rows.iter().map(|r| r.1).collect(),
    )
}

/// Rest matrices of a rig for `motion_clip`: Y along the bone, X and Z from a fixed skew vector
/// (the roll arbitrary but fixed), row-major.
pub fn rest_of(h: &[[f32; 3]], t: &[[f32; 3]]) -> Vec<[f32; 9]> {
    h.iter()
        .zip(t)
        .map(|(a, b)| {
            let y = (Vec3::from(*b) - Vec3::from(*a)).normalize();
            let x = y.cross(Vec3::new(0.3, 0.2, 0.9).normalize()).normalize();
            let z = x.cross(y);
            Mat3::from_cols(x, y, z).transpose().to_cols_array()
        })
        .collect()
}

/// [`biped`] in a T-pose: clavicles, arms and hands held out level along X.
pub fn t_pose_biped() -> Rig {
    let mut b = biped_bones();
    for bone in b.iter_mut() {
        let x = if bone.0.ends_with(".L") { 1.0 } else { -1.0 };
        let at = |r: f32| [r * x, 0.0, 1.45];
        match bone.0.trim_end_matches(".L").trim_end_matches(".R") {
            "shoulder" => (bone.1, bone.2) = (at(0.02), at(0.18)),
            "upper_arm" => (bone.1, bone.2) = (at(0.18), at(0.46)),
            "forearm" => (bone.1, bone.2) = (at(0.46), at(0.71)),
            "hand" => (bone.1, bone.2) = (at(0.71), at(0.88)),
            _ => {}
        }
    }
    skeleton_of(&b)
}

/// A game-style quadruped exported from an IK set-up (the structure of the held-out rigs of
/// this kind, not their data): a ground root carrying each foot (from the hock or the wrist
/// down, with its toe), an IK target at each hock and wrist and a pole before each knee; the
/// leg chains stop at the hock and wrist, and every leaf's tail continues its parent's line for
/// half its span (the tails an importer invents, read through `skeleton::joint_tails`). Faces
/// -Y, Z up, about 0.8 tall.
pub fn ik_quadruped() -> Rig {
    let mut b: Vec<BoneSpec> = vec![
        ("Root".into(), [0.0, 0.0, 0.0], [0.0, 0.2, 0.0], None),
        ("Hips".into(), [0.0, 0.30, 0.55], [0.0, 0.05, 0.57], Some("Root".into())),
        ("Spine".into(), [0.0, 0.05, 0.57], [0.0, -0.20, 0.58], Some("Hips".into())),
        ("Chest".into(), [0.0, -0.20, 0.58], [0.0, -0.30, 0.62], Some("Spine".into())),
        ("Neck".into(), [0.0, -0.30, 0.62], [0.0, -0.42, 0.78], Some("Chest".into())),
        ("Head".into(), [0.0, -0.42, 0.78], [0.0, -0.60, 0.74], Some("Neck".into())),
        ("Tail".into(), [0.0, 0.42, 0.56], [0.0, 0.65, 0.45], Some("Hips".into())),
    ];
    for (s, x) in [("L", 0.12f32), ("R", -0.12)] {
        let f = |n: &str| format!("{n}.{s}");
        let leaf = |parent_head: [f32; 3], head: [f32; 3]| {
            let (p, h) = (Vec3::from(parent_head), Vec3::from(head));
            (h + (h - p) * 0.5).to_array()
        };
        let (hip, stifle, hock) = ([x, 0.30, 0.50], [x, 0.20, 0.32], [x, 0.36, 0.16]);
        let (shoulder, elbow, wrist) = ([x, -0.22, 0.50], [x, -0.16, 0.30], [x, -0.22, 0.12]);
        b.extend([
            (f("Thigh"), hip, stifle, Some("Hips".into())),
            (f("Shin"), stifle, leaf(hip, stifle), Some(f("Thigh"))),
            (f("HindFoot"), hock, [x, 0.34, 0.03], Some("Root".into())),
            (f("HindToe"), [x, 0.34, 0.03], [x, 0.27, 0.0], Some(f("HindFoot"))),
            (f("UpperArm"), shoulder, elbow, Some("Chest".into())),
            (f("ForeArm"), elbow, leaf(shoulder, elbow), Some(f("UpperArm"))),
            (f("FrontFoot"), wrist, [x, -0.22, 0.03], Some("Root".into())),
            (f("FrontToe"), [x, -0.22, 0.03], [x, -0.30, 0.0], Some(f("FrontFoot"))),
            (f("IK_Hind"), hock, [x, 0.46, 0.16], Some("Root".into())),
            (f("IK_Front"), wrist, [x, -0.12, 0.12], Some("Root".into())),
            (f("Pole_Hind"), [x, -0.05, 0.32], [x, -0.10, 0.32], Some("Root".into())),
            (f("Pole_Front"), [x, 0.10, 0.30], [x, 0.15, 0.30], Some("Root".into())),
        ]);
    }
    skeleton_of(&b)
}

/// Skin points along every bone of a rig, `per_bone` of them from head to tail, each owned by
/// its bone, and one `below` under each leaf bone's tail (a sole or a hoof), owned by that leaf:
/// points and owners for `motion::Skin`.
pub fn bone_skin(
    h: &[[f32; 3]],
    t: &[[f32; 3]],
    parents: &[i32],
    per_bone: usize,
    below: f32,
) -> (Vec<[f32; 3]>, Vec<i32>) {
    let (mut points, mut owners) = (Vec::new(), Vec::new());
    for b in 0..h.len() {
        for k in 0..per_bone {
            let s = k as f32 / (per_bone.max(2) - 1) as f32;
            points.push((Vec3::from(h[b]).lerp(Vec3::from(t[b]), s)).to_array());
            owners.push(b as i32);
        }
        if !parents.contains(&(b as i32)) {
            points.push([t[b][0], t[b][1], t[b][2] - below]);
            owners.push(b as i32);
        }
    }
    (points, owners)
}
