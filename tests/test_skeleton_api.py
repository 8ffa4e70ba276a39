"""The skeleton API of miniskeleton_core from plain Python: fitting (centring, options, errors) and
left/right in bone names."""

import numpy as np
import pytest

import miniskeleton_core as msc


@pytest.fixture(scope="module")
def tube():
    return msc.capped_cylinder(0.5, 4.0, 40, 32)


def chain(n):
    return np.array([[i, i + 1] for i in range(n - 1)], dtype=np.uint32)


def test_fit_centres_a_limb_and_reports():
    # A limb: radius under 5 % of the diagonal (the fixture's tube, at 12 %, is a body, where a
    # joint off the centre keeps its place).
    v, t = msc.capped_cylinder(0.2, 4.0, 40, 32)
    rng = np.random.default_rng(3)
    start = np.array([[0.0, 0.0, 0.4 + 0.8 * i] for i in range(5)], dtype=np.float32)
    start[:, :2] += rng.uniform(-0.12, 0.12, size=(5, 2))
    rep = msc.fit_joints(v, t, start, chain(5))
    out = rep.joints
    assert out.shape == (5, 3) and out.dtype == np.float32
    assert np.abs(out[:, :2]).max() < 0.02, out
    np.testing.assert_allclose(out[:4, 2], start[:4, 2], atol=0.05)  # along the limb: kept
    assert rep.outside_after == 0 and rep.pieces == 1
    assert msc.points_inside(v, t, out).all()
    # The free end goes toward the tube's end only with tip (the default).
    assert out[4, 2] > start[4, 2] + 0.1
    kept = msc.fit_joints(v, t, start, chain(5), tip=False).joints
    assert abs(kept[4, 2] - start[4, 2]) < 0.01 and np.abs(kept[:, :2]).max() < 0.02
    # Joints pushed out of the tube are counted outside before and inside after.
    rep = msc.fit_joints(v, t, start + np.float32([0.35, 0.0, 0.0]), chain(5))
    out = rep.joints
    assert rep.outside_before == rep.outside_before_mask.sum() == 5
    assert rep.outside_after == rep.outside_after_mask.sum() == 0
    # ... unless they are farther outside than max_move: those keep their place.
    far = start + np.float32([0.35, 0.0, 0.0])
    far[0, 0] += 1.2
    rep = msc.fit_joints(v, t, far, chain(5))
    out = rep.joints
    assert rep.kept_outside == 1 and rep.outside_after == 1 and rep.outside_after_mask[0]
    np.testing.assert_array_equal(out[0], far[0])


def test_fixed_joints_stay_and_options_are_checked(tube):
    v, t = tube
    start = np.array([[0.3, 0.0, 0.5], [0.3, 0.0, 2.0], [0.3, 0.0, 3.5]], dtype=np.float32)
    out = msc.fit_joints(v, t, start, chain(3), movable=np.array([True, False, True])).joints
    np.testing.assert_array_equal(out[1], start[1])
    assert abs(out[0, 0]) < 0.3 - 0.01
    # rays / samples past 1024 would be allocated before any work (10^12 aborted the process)
    for bad in (dict(stub_ratio=-1.0), dict(max_move=0.0), dict(rays=2), dict(rays=10**12), dict(samples=10**12)):
        with pytest.raises(ValueError):
            msc.fit_joints(v, t, start, chain(3), **bad)
    with pytest.raises(ValueError):
        msc.fit_joints(v, t, start, np.array([[0, 7]], dtype=np.uint32))
    with pytest.raises(ValueError, match="go together"):
        msc.fit_joints(v, t, start, chain(3), symmetry_axis=0)   # no joint_mirror


# (name, its flip, its side): read off the add-on's Python rule (mesh_io.mirror_name), pattern by
# pattern in its order; the side is the one whose token the flip changes.
NAMES = [
    # a separator (. _ - space) and a letter at the end: L/l first, then R/r
    ("thigh.L", "thigh.R", "L"),
    ("thigh.R", "thigh.L", "R"),
    ("hand_l", "hand_r", "L"),
    ("Foot_R", "Foot_L", "R"),
    ("shin-r", "shin-l", "R"),
    ("ear l", "ear r", "L"),
    ("DEF-thigh.L", "DEF-thigh.R", "L"),
    ("ORG-hand.R", "ORG-hand.L", "R"),
    ("Ärm.L", "Ärm.R", "L"),
    # a letter and a separator at the start
    ("L_foot", "R_foot", "L"),
    ("r.arm", "l.arm", "R"),
    ("l ear", "r ear", "L"),
    # the end is looked at before the start
    ("l_foot.R", "l_foot.L", "R"),
    ("L_arm_right", "R_arm_right", "L"),
    # the first letter between two of . _ - (spaces do not count)
    ("leg_back_L_knee", "leg_back_R_knee", "L"),
    ("leg_front_R_hip", "leg_front_L_hip", "R"),
    ("Bip01_R_Thigh", "Bip01_L_Thigh", "R"),
    ("hand_L.001", "hand_R.001", "L"),
    ("a_L_b_R_c", "a_R_b_R_c", "L"),
    # the words Left, Right, left, right, LEFT, RIGHT in that order, first occurrence only
    ("LeftUpLeg", "RightUpLeg", "L"),
    ("mixamorig:LeftUpLeg", "mixamorig:RightUpLeg", "L"),
    ("mixamorig:RightHand", "mixamorig:LeftHand", "R"),
    ("b_LeftHand_011", "b_RightHand_011", "L"),
    ("left_arm", "right_arm", "L"),
    ("upper_right_arm", "upper_left_arm", "R"),
    ("LEFT_EYE", "RIGHT_EYE", "L"),
    ("Right_left", "Left_left", "R"),
    ("Left_Left", "Right_Left", "L"),
    ("Cleft", "Cright", "L"),
    # centre names: no side, no flip
    ("spine", "spine", None),
    ("Hips", "Hips", None),
    ("mixamorig:Spine1", "mixamorig:Spine1", None),
    ("tail.l1", "tail.l1", None),
    ("Bip01 L Thigh", "Bip01 L Thigh", None),
    ("LeFt_hand", "LeFt_hand", None),
    ("L", "L", None),
    ("", "", None),
]


@pytest.mark.parametrize("name, flipped, side", NAMES)
def test_mirror_name_flips_as_blender_does(name, flipped, side):
    assert msc.mirror_name(name) == flipped
    # the side (the one detect_roles reads) is that of the letter or word the flip changes
    changed = [a for a, b in zip(name, flipped) if a != b]
    assert (changed[0].upper() if changed else None) == side


def test_bone_mirror_indices_pair_by_name_and_agree_both_ways():
    names = ["hips", "thigh.L", "thigh.R", "b_LeftUpperArm_09", "b_RightUpperArm_06", "hand.L",
             "arm.L", "arm.R", "arm.R.001", "foot.L", "foot.R", "foot.R", "spine.001"]
    out = msc.bone_mirror_indices(names)
    assert out.dtype == np.int32 and out.shape == (13,)
    # hips and spine.001 are centre bones (themselves); thigh and the numbered upper arms pair up;
    # hand.L has no partner; arm.R.001 matches arm.L up to its number, but arm.L pairs with
    # arm.R; foot.L's partner is the last foot.R, so the first one has none.
    assert out.tolist() == [0, 2, 1, 4, 3, -1, 7, 6, -1, 11, -1, 9, 12]
    # two numbered bones on one stem: neither is the partner
    assert msc.bone_mirror_indices(("finger.L.001", "finger.L.002", "finger.R")).tolist() == [-1, -1, -1]
    assert msc.bone_mirror_indices([]).shape == (0,)
    with pytest.raises(TypeError):
        msc.bone_mirror_indices("thigh.L")   # a string is not a list of names
    with pytest.raises(TypeError):
        msc.mirror_name(None)
