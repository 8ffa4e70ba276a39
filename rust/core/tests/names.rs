//! Left and right in bone names (`skeleton::{mirror_name, name_side, bone_mirror_indices}`):
//! the add-on's former Python rule, by tables read off that rule.

use miniskeleton_core::skeleton::{bone_mirror_indices, mirror_name, name_side, Side};

const L: Option<Side> = Some(Side::Left);
const R: Option<Side> = Some(Side::Right);

/// (name, its flip, its side): suffixes, prefixes, letters between separators, words, and
/// names without a side.
const TABLE: [(&str, &str, Option<Side>); 40] = [
    // a separator and a letter at the end (Blender's .L / _l / -r / " L")
    ("thigh.L", "thigh.R", L),
    ("thigh.R", "thigh.L", R),
    ("hand_l", "hand_r", L),
    ("Foot_R", "Foot_L", R),
    ("shin-r", "shin-l", R),
    ("ear l", "ear r", L),
    ("DEF-thigh.L", "DEF-thigh.R", L),
    ("Ärm.L", "Ärm.R", L),
    (".L", ".R", L),
    ("x.L\n", "x.R\n", L), // Python's `$` ends before a final line feed
    // a letter and a separator at the start
    ("L_foot", "R_foot", L),
    ("r.arm", "l.arm", R),
    ("l ear", "r ear", L),
    ("L.", "R.", L),
    // the end before the start, left before right at each
    ("l_foot.R", "l_foot.L", R),
    ("R_hand.l", "R_hand.r", L),
    ("L_arm_right", "R_arm_right", L),
    // the first letter between two of . _ - (not spaces)
    ("leg_back_L_knee", "leg_back_R_knee", L),
    ("Bip01_R_Thigh", "Bip01_L_Thigh", R),
    ("hand_L.001", "hand_R.001", L),
    ("ORG-shin.R.001", "ORG-shin.L.001", R),
    ("_l_", "_r_", L),
    ("a_L_b_R_c", "a_R_b_R_c", L),
    // words: Left, Right, left, right, LEFT, RIGHT in that order, the first occurrence
    ("LeftUpLeg", "RightUpLeg", L),
    ("RightHand", "LeftHand", R),
    ("mixamorig:LeftUpLeg", "mixamorig:RightUpLeg", L),
    ("mixamorig:RightHand", "mixamorig:LeftHand", R),
    ("b_LeftHand_011", "b_RightHand_011", L),
    ("left_arm", "right_arm", L),
    ("upper_right_arm", "upper_left_arm", R),
    ("LEFT_EYE", "RIGHT_EYE", L),
    ("Right_left", "Left_left", R),
    ("Left_Left", "Right_Left", L),
    ("Cleft", "Cright", L), // inside a word too
    // no side
    ("spine", "spine", None),
    ("Hips", "Hips", None),
    ("tail.l1", "tail.l1", None),
    ("Bip01 L Thigh", "Bip01 L Thigh", None),
    ("LeFt_hand", "LeFt_hand", None),
    ("L", "L", None),
];

#[test]
fn names_flip_as_blender_flips_them_and_state_the_flipped_side() {
    for (name, flipped, side) in TABLE {
        assert_eq!(mirror_name(name), flipped, "{name:?}");
        assert_eq!(name_side(name), side, "{name:?}");
    }
}

#[test]
fn name_sides() {
    assert_eq!(name_side("thigh.L"), Some(Side::Left));
    assert_eq!(name_side("R_foot"), Some(Side::Right));
    assert_eq!(name_side("LeftUpLeg"), Some(Side::Left));
    assert_eq!(name_side("mixamorig:RightHand"), Some(Side::Right));
    assert_eq!(name_side("shin-r"), Some(Side::Right));
    assert_eq!(name_side("l ear"), Some(Side::Left));
    assert_eq!(name_side("spine"), None);
    assert_eq!(name_side("tail.l1"), None);
}

/// Names whose side the roles' former rule (`motion::name_side` before the one rule) read
/// otherwise: letters between separators had no side, the end's letter did not come before the
/// start's, and words were found in any case, `left` before `right`.
#[test]
fn where_the_former_roles_rule_read_another_side() {
    for (name, side, before) in [
        ("Bip01_L_Thigh", L, None),
        ("ValveBiped.Bip01_R_Calf", R, None),
        ("CC_Base_L_Thigh", L, None),
        ("leg_back_L_knee", L, None),
        ("thigh.L.001", L, None),
        ("Hand_L_end", L, None),
        ("l_foot.R", R, L),
        ("L_foot.r", R, L),
        ("Right_left", R, L),
        ("LeFt_hand", None, L),
        ("lEFT_arm", None, L),
    ] {
        assert_eq!(name_side(name), side, "{name:?} (before: {before:?})");
    }
}

#[test]
fn mirror_bones_by_name_agree_both_ways() {
    let names = [
        "hips",               // 0: centre, itself
        "thigh.L",            // 1 <-> 2
        "thigh.R",            //
        "b_LeftUpperArm_09",  // 3 <-> 4, their numbers differ
        "b_RightUpperArm_06", //
        "hand.L",             // 5: no partner
        "arm.L",              // 6 <-> 7
        "arm.R",              //
        "arm.R.001",          // 8: its flip arm.L.001 matches arm.L up to the number, but arm.L is arm.R's
        "foot.L",             // 9: the last foot.R
        "foot.R",             // 10: a duplicate name: foot.L's partner is the last one
        "foot.R",             // 11
        "spine.001",          // 12: centre
    ];
    assert_eq!(bone_mirror_indices(&names), [0, 2, 1, 4, 3, -1, 7, 6, -1, 11, -1, 9, 12]);
    // two numbered bones match one stem: no partner by number
    let owned: Vec<String> = ["finger.L.001", "finger.L.002", "finger.R"].map(String::from).to_vec();
    assert_eq!(bone_mirror_indices(&owned), [-1, -1, -1]);
    assert!(bone_mirror_indices::<&str>(&[]).is_empty());
}
