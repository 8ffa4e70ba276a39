//! Auto Rig on figures made of capped cylinders pushed into each other (a kit-built model): the
//! template found, the facing, the parts, every joint inside, and the refusals.

use glam::{DQuat, DVec3};
use miniskeleton_core::autorig::{auto_rig, AutoRigOptions, Template};
use miniskeleton_core::primitives::capped_cylinder;
use miniskeleton_core::skeleton::points_inside;
use miniskeleton_core::Error;

type Mesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// A capped cylinder of radius `r` from `a` to `b`, appended to `m`.
fn limb(m: &mut Mesh, a: [f64; 3], b: [f64; 3], r: f64) {
    let (a, b) = (DVec3::from_array(a), DVec3::from_array(b));
    let len = (b - a).length();
    let (v, t) = capped_cylinder(r as f32, len as f32, 12, 16);
    let rot = DQuat::from_rotation_arc(DVec3::Z, (b - a) / len);
    let base = m.0.len() as u32;
    m.0.extend(v.iter().map(|p| (a + rot * DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)).as_vec3().to_array()));
    m.1.extend(t.iter().map(|t| t.map(|i| i + base)));
}

/// A biped facing -Y (Rigify's way), 1.8 tall, arms in an A-pose, feet pointing forward.
fn biped() -> Mesh {
    let mut m = (Vec::new(), Vec::new());
    for s in [-1.0, 1.0] {
        limb(&mut m, [0.1 * s, 0.0, 0.95], [0.1 * s, 0.0, 0.05], 0.07); // leg
        limb(&mut m, [0.1 * s, 0.04, 0.04], [0.1 * s, -0.2, 0.04], 0.045); // foot
        limb(&mut m, [0.15 * s, 0.0, 1.45], [0.7 * s, 0.0, 1.05], 0.045); // arm
    }
    limb(&mut m, [0.0, 0.0, 0.85], [0.0, 0.0, 1.5], 0.17); // torso
    limb(&mut m, [0.0, 0.0, 1.45], [0.0, 0.0, 1.6], 0.06); // neck
    limb(&mut m, [0.0, 0.0, 1.58], [0.0, 0.0, 1.8], 0.11); // head
    m
}

/// A quadruped facing +X with a tail.
fn quadruped() -> Mesh {
    let mut m = (Vec::new(), Vec::new());
    for x in [-0.45, 0.45] {
        for y in [-0.15, 0.15] {
            limb(&mut m, [x, y, 0.75], [x, y, 0.0], 0.06);
        }
    }
    limb(&mut m, [-0.6, 0.0, 0.8], [0.6, 0.0, 0.8], 0.22); // body
    limb(&mut m, [0.5, 0.0, 0.85], [0.8, 0.0, 1.2], 0.09); // neck
    limb(&mut m, [0.75, 0.0, 1.2], [1.05, 0.0, 1.1], 0.11); // head
    limb(&mut m, [-0.6, 0.0, 0.85], [-1.1, 0.0, 0.6], 0.035); // tail
    m
}

fn transformed(m: &Mesh, f: impl Fn(DVec3) -> DVec3) -> Mesh {
    (
        m.0.iter().map(|p| f(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)).as_vec3().to_array()).collect(),
        m.1.clone(),
    )
}

fn bone<'a>(rig: &'a miniskeleton_core::autorig::AutoRig, name: &str) -> &'a miniskeleton_core::autorig::RigBone {
    rig.bones.iter().find(|b| b.name == name).unwrap_or_else(|| panic!("no bone {name}"))
}

fn all_joints_inside(m: &Mesh, rig: &miniskeleton_core::autorig::AutoRig) {
    let pts: Vec<[f32; 3]> = rig.bones.iter().flat_map(|b| [b.head, b.tail]).collect();
    let inside = points_inside(&m.0, &m.1, &pts).unwrap();
    let names: Vec<&str> = rig.bones.iter().flat_map(|b| [b.name.as_str(), b.name.as_str()]).collect();
    // heel.02 lies on the ground under the heel, as in Rigify's metarig.
    let out: Vec<&&str> =
        names.iter().zip(&inside).filter(|(n, i)| !**i && !n.starts_with("heel")).map(|(n, _)| n).collect();
    assert!(out.is_empty(), "joints outside: {out:?}");
}

#[test]
fn biped_gets_rigifys_human_bones_facing_its_toes() {
    let m = biped();
    let rig = auto_rig(&m.0, &m.1, &AutoRigOptions::default()).unwrap();
    assert_eq!(rig.template, Template::Biped);
    assert!((DVec3::from_array(rig.forward) - DVec3::NEG_Y).length() < 0.1, "{:?}", rig.forward);
    assert!((DVec3::from_array(rig.left) - DVec3::X).length() < 0.1, "{:?}", rig.left);
    for name in ["spine", "spine.003", "spine.006", "thigh.L", "toe.R", "heel.02.L", "upper_arm.L", "hand.R"] {
        bone(&rig, name);
    }
    // Parents come first and follow the metarig.
    for (i, b) in rig.bones.iter().enumerate() {
        assert!(b.parent < i as i32, "{}", b.name);
    }
    let parent = |n: &str| rig.bones[bone(&rig, n).parent as usize].name.clone();
    assert_eq!(parent("thigh.L"), "spine");
    assert_eq!(parent("upper_arm.R"), "shoulder.R");
    assert_eq!(parent("shoulder.L"), "spine.003");
    assert!(bone(&rig, "thigh.L").head[0] > 0.05 && bone(&rig, "thigh.R").head[0] < -0.05);
    assert!(bone(&rig, "hand.L").tail[0] > 0.5, "{:?}", bone(&rig, "hand.L").tail);
    assert!(bone(&rig, "spine.006").tail[2] > 1.65);
    // Exact mirror images.
    let (l, r) = (bone(&rig, "forearm.L"), bone(&rig, "forearm.R"));
    assert!((l.head[0] + r.head[0]).abs() < 1e-4 && (l.head[2] - r.head[2]).abs() < 1e-4);
    all_joints_inside(&m, &rig);
}

#[test]
fn quadruped_faces_its_head_and_keeps_its_tail() {
    let m = quadruped();
    let rig = auto_rig(&m.0, &m.1, &AutoRigOptions::default()).unwrap();
    assert_eq!(rig.template, Template::Quadruped);
    assert!((DVec3::from_array(rig.forward) - DVec3::X).length() < 0.1, "{:?}", rig.forward);
    assert!(rig.tail);
    assert!(bone(&rig, "front_thigh.L").head[0] > 0.2 && bone(&rig, "thigh.L").head[0] < -0.2);
    assert!(bone(&rig, "spine.011").tail[0] > 0.85, "{:?}", bone(&rig, "spine.011").tail);
    assert!(bone(&rig, "spine").tail[0] < -0.8, "{:?}", bone(&rig, "spine").tail);
    all_joints_inside(&m, &rig);
}

#[test]
fn any_facing_scale_and_place() {
    let m = quadruped();
    let turn = DQuat::from_rotation_z(0.65);
    let moved = transformed(&m, |p| turn * p * 37.0 + DVec3::new(100.0, -20.0, 5.0));
    let rig = auto_rig(&moved.0, &moved.1, &AutoRigOptions::default()).unwrap();
    assert!((DVec3::from_array(rig.forward) - turn * DVec3::X).length() < 0.1, "{:?}", rig.forward);
    all_joints_inside(&moved, &rig);
    // The facing can be given.
    let back = AutoRigOptions { forward: Some((turn * DVec3::NEG_X).to_array()), ..AutoRigOptions::default() };
    let rig = auto_rig(&moved.0, &moved.1, &back).unwrap();
    assert!((DVec3::from_array(rig.forward) - turn * DVec3::NEG_X).length() < 1e-6);
}

#[test]
fn a_biped_template_on_four_legs_and_a_quadruped_on_two_are_told() {
    let m = biped();
    let quad = AutoRigOptions { template: Template::Quadruped, ..AutoRigOptions::default() };
    match auto_rig(&m.0, &m.1, &quad) {
        Err(Error::Unsuitable(s)) => assert!(s.contains("2 feet"), "{s}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn shapes_that_are_not_standing_characters_are_refused() {
    // Lying on its side.
    let m = transformed(&biped(), |p| DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2) * p);
    assert!(matches!(auto_rig(&m.0, &m.1, &AutoRigOptions::default()), Err(Error::Unsuitable(_))));
    // A ball: no limb.
    let mut ball = (Vec::new(), Vec::new());
    limb(&mut ball, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.5);
    assert!(matches!(auto_rig(&ball.0, &ball.1, &AutoRigOptions::default()), Err(Error::Unsuitable(_))));
    // A flat square: no volume.
    let plane = (vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]], vec![[0, 1, 2], [0, 2, 3]]);
    match auto_rig(&plane.0, &plane.1, &AutoRigOptions::default()) {
        Err(Error::Unsuitable(s)) => assert!(s.contains("no volume"), "{s}"),
        other => panic!("{other:?}"),
    }
    // NaN, empty, out-of-range options.
    let mut nan = biped();
    nan.0[3][1] = f32::NAN;
    assert!(matches!(auto_rig(&nan.0, &nan.1, &AutoRigOptions::default()), Err(Error::NonFinite { .. })));
    assert!(matches!(auto_rig(&[], &[], &AutoRigOptions::default()), Err(Error::EmptyMesh(_))));
    let m = biped();
    let coarse = AutoRigOptions { resolution: 4, ..AutoRigOptions::default() };
    assert!(matches!(auto_rig(&m.0, &m.1, &coarse), Err(Error::InvalidArgument(_))));
    let up = AutoRigOptions { forward: Some([0.0, 0.0, 1.0]), ..AutoRigOptions::default() };
    assert!(matches!(auto_rig(&m.0, &m.1, &up), Err(Error::InvalidArgument(_))));
}
