"""Shadow puppets in real Blender: templates, locks and limits, live rod-driven IK (Rust
ik2d), prop grip, strip multi-effector, bake, part images and the Shadow Theatre preset."""

from __future__ import annotations

import importlib
import math

import bpy
import numpy as np
import pytest
from mathutils import Vector

from testkit import blender_session
from testkit import builders as B

R = importlib.import_module("bl_ext.user_default.miniskeleton.puppet.rig")
L = importlib.import_module("bl_ext.user_default.miniskeleton.puppet.live")
T = importlib.import_module("bl_ext.user_default.miniskeleton.puppet.templates")
K = importlib.import_module("bl_ext.user_default.miniskeleton.common.keys")

HUMAN_BONES = {"abdomen", "chest", "neck", "head", "skirt"} | {
    f"{b}.{s}" for b in ("upper_arm", "forearm", "hand", "thigh", "shin", "foot") for s in "LR"}
RODS = {"THREE_ROD": {"neck", "hand.L", "hand.R"},
        "FIVE_ROD": {"neck", "hand.L", "hand.R", "foot.L", "foot.R"},
        "PROP": {"neck", "grip.L", "grip.R"},
        "STRIP": {"head", "middle", "tail"},
        "QUADRUPED": {"body", "head"}}
ARM = ("upper_arm.R", "forearm.R", "hand.R")
LEG = ("thigh.L", "shin.L")


def settle():
    """Two depsgraph updates: the handler solves on the first, the pose evaluates on the second."""
    bpy.context.view_layer.update()
    bpy.context.view_layer.update()


def add(kind, **props):
    assert bpy.ops.object.miniskeleton_add_puppet(type=kind, **props) == {"FINISHED"}
    rig = R.puppet_rig(bpy.context.active_object)
    assert rig is not None
    settle()
    return rig, R.puppet_rods(rig)


def tip_world(rig, bone):
    return rig.matrix_world @ rig.pose.bones[bone].tail


def head_world(rig, bone):
    return rig.matrix_world @ rig.pose.bones[bone].head


def move_rod(rod, x, z):
    rod.matrix_world.translation = Vector((x, 0.0, z))
    settle()


def reach(rig, names):
    return sum(rig.data.bones[n].length for n in names)


def random_reachable(rig, names, rng, n):
    """World tips of ``names`` for n random in-limit poses (so every target is reachable),
    computed by Blender itself with live solving off."""
    rig[R.LIVE_KEY] = False
    out = []
    for _ in range(n):
        for name in names:
            pb = rig.pose.bones[name]
            pb.rotation_euler.z = rng.uniform(pb.ik_min_z, pb.ik_max_z)
        bpy.context.view_layer.update()
        out.append(tip_world(rig, names[-1]).copy())
    rig[R.LIVE_KEY] = True
    return out


def assert_in_plane(rig, euler=True):
    """Every bone's rotation axis stays the picture-plane normal: its Z axis is still -Y."""
    for pb in rig.pose.bones:
        z = pb.matrix.col[2].xyz
        assert abs(z.dot(Vector((0, -1, 0))) - 1) < 1e-6, (pb.name, tuple(z))
        if euler:
            assert abs(pb.rotation_euler.x) < 1e-9, pb.name


def pose_of(rig, names=None):
    """{bone: rotation_euler} of ``rig``'s bones (those in ``names`` when given)."""
    return {pb.name: tuple(pb.rotation_euler) for pb in rig.pose.bones if names is None or pb.name in names}


def assert_legs_hang_down(rig):
    for side in "LR":
        d = tip_world(rig, f"shin.{side}") - head_world(rig, f"thigh.{side}")
        assert d.normalized().dot(Vector((0, 0, -1))) > 1 - 1e-6, side


def world_centre(ob):
    """Mean world position of a mesh object's vertices."""
    return sum((ob.matrix_world @ v.co for v in ob.data.vertices), Vector()) / len(ob.data.vertices)


def assert_within_limits(rig, eps=1e-6):
    for pb in rig.pose.bones:
        assert pb.ik_min_z - eps <= pb.rotation_euler.z <= pb.ik_max_z + eps, (
            pb.name, math.degrees(pb.rotation_euler.z), math.degrees(pb.ik_min_z), math.degrees(pb.ik_max_z))


# ---------------------------------------------------------------------------- templates


@pytest.mark.parametrize("kind", T.KINDS)
def test_template_builds_with_bones_rods_locks_and_parts(kind):
    rig, rods = add(kind)
    tpl = T.template(kind)
    names = {b.name for b in rig.data.bones}
    if kind in ("THREE_ROD", "FIVE_ROD", "PROP"):
        assert names == HUMAN_BONES and len(names) == 17
        assert rig.data.bones["abdomen"].parent is None
        for child, parent in (("chest", "abdomen"), ("neck", "chest"), ("head", "neck"),
                              ("upper_arm.L", "chest"), ("forearm.L", "upper_arm.L"), ("hand.L", "forearm.L"),
                              ("thigh.R", "abdomen"), ("shin.R", "thigh.R"), ("foot.R", "shin.R")):
            assert rig.data.bones[child].parent.name == parent
    assert set(rods) == RODS[kind]
    for role, rod in rods.items():
        assert rod[R.ROLE_KEY] == role and R.puppet_rig(rod) == rig
        # a rod moves in the picture plane and turns about its normal only
        assert tuple(rod.lock_location) == (False, True, False) and tuple(rod.lock_rotation) == (True, False, True)
    main = rods[tpl.main_rod().role]
    assert rig.parent == main                    # the main rod carries the figure
    # the main rod is active and alone selected: G moves the whole puppet at once
    assert bpy.context.active_object == main and bpy.context.selected_objects == [main]
    if kind == "PROP":
        staff = rig["miniskeleton_prop"]
        assert rods["grip.L"].parent == staff and rods["grip.R"].parent == staff

    for b in tpl.bones:
        bone, pb = rig.data.bones[b.name], rig.pose.bones[b.name]
        # Everything lies in the XZ picture plane; local Z is the plane's normal (toward -Y).
        assert abs(bone.head_local.y) < 1e-6 and abs(bone.tail_local.y) < 1e-6
        assert (bone.matrix_local.col[2].xyz - Vector((0, -1, 0))).length < 1e-6
        assert pb.rotation_mode == "XYZ"
        assert bone.use_connect == b.connected, b.name
        expected = {"plane": (True, True, False), "plane+twist": (True, False, False),
                    "fixed": (True, True, True)}[b.dof]
        assert tuple(pb.lock_rotation) == expected, b.name
        # Blender's own IK (a rigger's constraint) gets the same locks and limits.
        assert (pb.lock_ik_x, pb.lock_ik_y, pb.lock_ik_z) == expected, b.name
        assert pb.use_ik_limit_z
        limits = (0.0, 0.0) if b.dof == "fixed" else b.limits
        assert math.isclose(math.degrees(pb.ik_min_z), limits[0], abs_tol=1e-4)
        assert math.isclose(math.degrees(pb.ik_max_z), limits[1], abs_tol=1e-4)
        assert pb.use_ik_limit_y == (b.dof == "plane+twist"), b.name
        assert pb[R.SEED_KEY] == pytest.approx(b.seed), b.name     # where the live solve starts
        if b.dof == "plane+twist":
            assert math.isclose(math.degrees(pb.ik_min_y), b.twist[0], abs_tol=1e-4)
            assert math.isclose(math.degrees(pb.ik_max_y), b.twist[1], abs_tol=1e-4)
    if kind != "STRIP" and kind != "QUADRUPED":
        assert tuple(rig.pose.bones["forearm.R"].lock_rotation) == (True, True, False)   # 1 DOF
        assert tuple(rig.pose.bones["head"].lock_rotation) == (True, False, False)       # 2 DOF
        assert tuple(rig.pose.bones["abdomen"].lock_rotation) == (True, False, False)    # 2 DOF
        assert rig.pose.bones["forearm.R"].ik_min_z == 0.0       # an elbow does not bend backwards

    parts = [ob for ob in bpy.data.objects if ob.get(R.PART_KEY)]
    assert sorted(ob.parent_bone for ob in parts) == sorted(names)
    assert all(ob.parent == rig and ob.parent_type == "BONE" and len(ob.data.polygons) == 1 for ob in parts)
    for ob in parts:
        assert ob.hide_select, ob.name             # a click in the viewport picks a rod, not a part
        # a picture painted on a part covers it exactly
        uv = np.array([d.uv[:] for d in ob.data.uv_layers["UVMap"].data])
        assert uv.min(axis=0) == pytest.approx((0, 0)) and uv.max(axis=0) == pytest.approx((1, 1)), ob.name
        # The part sits on its bone: its centre is near the bone's segment.
        c = world_centre(ob)
        h, t = head_world(rig, ob.parent_bone), tip_world(rig, ob.parent_bone)
        seg = t - h
        s = max(0.0, min(1.0, (c - h).dot(seg) / max(seg.length_squared, 1e-12)))
        assert (c - (h + s * seg)).length < 0.2, ob.name
    assert_in_plane(rig)


def test_size_scales_the_whole_figure():
    """Size 2 builds the figure twice as large: bones, parts and rods (the figure's own
    proportions, and its feet on the cursor's height, kept)."""
    built = {}
    for size in (1.0, 2.0):
        blender_session.reset_scene()
        rig, rods = add("FIVE_ROD", size=size)
        built[size] = (sorted((b.name, b.length) for b in rig.data.bones),
                       sorted((ob.name.split(".")[-1], max(ob.dimensions)) for ob in rig.children if ob.type == "MESH"),
                       sorted((role, tuple(rod.matrix_world.translation)) for role, rod in rods.items()))
    (bones1, parts1, rods1), (bones2, parts2, rods2) = built[1.0], built[2.0]
    assert [n for n, _ in bones1] == [n for n, _ in bones2]
    np.testing.assert_allclose([n for _, n in bones2], [2 * n for _, n in bones1], rtol=1e-5)
    np.testing.assert_allclose([d for _, d in parts2], [2 * d for _, d in parts1], rtol=1e-4)
    np.testing.assert_allclose([p for _, p in rods2], [2 * np.array(p) for _, p in rods1], rtol=1e-4, atol=1e-6)


def test_add_menu_and_panel():
    funcs = bpy.types.VIEW3D_MT_armature_add._dyn_ui_initialize()
    assert any(getattr(f, "__module__", "").endswith("miniskeleton.puppet.ui") for f in funcs)
    assert bpy.types.MINISKELETON_PT_puppet.bl_category == "MiniSkeleton"
    assert L._on_depsgraph_update in bpy.app.handlers.depsgraph_update_post
    assert L._on_frame_change in bpy.app.handlers.frame_change_post
    assert L.update_scene_puppets(bpy.context.scene) == 0      # no puppet: nothing to do


# ---------------------------------------------------------------------------- live IK


def test_reachable_rods_are_reached_and_pose_stays_in_plane():
    rig, rods = add("FIVE_ROD")
    rng = np.random.default_rng(7)
    for chain, role in ((ARM, "hand.R"), (("upper_arm.L", "forearm.L", "hand.L"), "hand.L"), (LEG, "foot.L")):
        tol = 2e-3 * reach(rig, chain)
        for target in random_reachable(rig, chain, rng, 6):
            move_rod(rods[role], target.x, target.z)
            got = tip_world(rig, chain[-1])
            assert (got - rods[role].matrix_world.translation).length < tol, (role, tuple(target), tuple(got))
            assert_in_plane(rig)
            assert_within_limits(rig)


def test_the_pose_follows_the_rods_alone_from_the_seed_angles():
    """A driven bone nudged by hand goes back at once, however little; the solve starts from each
    bone's seed angle (the template's, an ID property on the pose bone), which picks among the
    arm's many poses that reach the rod."""
    rig, rods = add("FIVE_ROD")
    base, tip = head_world(rig, ARM[0]), tip_world(rig, ARM[-1])
    target = base + 0.6 * (tip - base) + Vector((0.1, 0.0, 0.1))
    move_rod(rods["hand.R"], target.x, target.z)
    solved = pose_of(rig, ARM)
    rig.pose.bones["forearm.R"].rotation_euler.z += 5e-4
    settle()
    assert pose_of(rig, ARM) == solved
    hand = rig.pose.bones["hand.R"]
    rig.pose.bones["forearm.R"][R.SEED_KEY], hand[R.SEED_KEY] = 120.0, -50.0
    rig.update_tag()   # as an edit in the Custom Properties panel does
    settle()
    assert (tip_world(rig, ARM[-1]) - rods["hand.R"].matrix_world.translation).length < 2e-3 * reach(rig, ARM)
    assert abs(hand.rotation_euler.z - solved["hand.R"][2]) > 0.05, (solved, pose_of(rig, ARM))


def test_unreachable_rod_gives_straight_arm_toward_it():
    rig, rods = add("THREE_ROD")
    shoulder = head_world(rig, ARM[0])
    for direction in ((1.0, 0.3), (-0.4, 1.0), (0.2, -1.0)):
        d = Vector((direction[0], 0, direction[1])).normalized()
        target = shoulder + 3.0 * d
        move_rod(rods["hand.R"], target.x, target.z)
        for name in ARM[1:]:
            assert abs(rig.pose.bones[name].rotation_euler.z) < 1e-6, name    # straight
        arm_dir = (tip_world(rig, ARM[-1]) - shoulder).normalized()
        assert arm_dir.dot(d) > 1 - 1e-6
        assert math.isclose((tip_world(rig, ARM[-1]) - shoulder).length, reach(rig, ARM), rel_tol=1e-5)


def test_joint_limits_hold_and_are_editable():
    rig, rods = add("FIVE_ROD")
    rng = np.random.default_rng(3)
    for _ in range(12):
        for role in ("hand.R", "hand.L", "foot.R", "foot.L"):
            p = rods["neck"].matrix_world.translation
            rods[role].matrix_world.translation = p + Vector((rng.uniform(-1.2, 1.2), 0, rng.uniform(-1.8, 0.6)))
        settle()
        assert_within_limits(rig)
        assert_in_plane(rig)
    # A tighter elbow, edited on the pose bone's IK limit, is honoured by the solver.
    fore = rig.pose.bones["forearm.R"]
    fore.ik_max_z = math.radians(40)
    move_rod(rods["hand.R"], *(lambda s: (s.x + 0.15, s.z - 0.15))(head_world(rig, "upper_arm.R")))
    assert 0.0 <= fore.rotation_euler.z <= math.radians(40) + 1e-6
    # Tightened again with no rod moved: the live solve runs on the edit alone.
    bent = fore.rotation_euler.z
    fore.ik_max_z = 0.5 * bent
    settle()
    assert 0.0 <= fore.rotation_euler.z <= 0.5 * bent + 1e-6


def test_free_bones_are_held_within_their_limits():
    """Bones no rod drives (abdomen, chest, neck, head) are the rigger's to turn, within the
    IK limits stored on them: turned past a limit, in-plane or in the abdomen's twist, the live
    solve puts them back on it."""
    rig, _ = add("FIVE_ROD")
    abdomen, chest = rig.pose.bones["abdomen"], rig.pose.bones["chest"]
    assert abdomen.use_ik_limit_y and not chest.use_ik_limit_y
    abdomen.rotation_euler = (0.0, abdomen.ik_min_y - 0.3, abdomen.ik_max_z + 0.4)
    chest.rotation_euler.z = chest.ik_min_z - 0.2
    settle()
    assert abdomen.rotation_euler.z == pytest.approx(abdomen.ik_max_z, abs=1e-6)
    assert abdomen.rotation_euler.y == pytest.approx(abdomen.ik_min_y, abs=1e-6)
    assert chest.rotation_euler.z == pytest.approx(chest.ik_min_z, abs=1e-6)
    abdomen.rotation_euler = (0.0, 0.5 * abdomen.ik_max_y, 0.5 * abdomen.ik_max_z)   # within: kept
    settle()
    assert tuple(abdomen.rotation_euler) == pytest.approx((0.0, 0.5 * abdomen.ik_max_y, 0.5 * abdomen.ik_max_z))
    # a limit the rigger turns off (Bone > Inverse Kinematics) holds no more, though its values stay
    chest.use_ik_limit_z = False
    chest.rotation_euler.z = chest.ik_min_z - 0.2
    settle()
    assert chest.rotation_euler.z == pytest.approx(chest.ik_min_z - 0.2, abs=1e-6)


def test_live_solve_off_leaves_the_pose_to_the_rigger():
    """With Live Solve off (the Puppet panel's toggle) moving a rod changes no bone and a bone
    the rigger turns stays turned; on again, the limb follows its rod."""
    rig, rods = add("FIVE_ROD")
    rig[R.LIVE_KEY] = False
    rig.pose.bones["forearm.R"].rotation_euler.z = 0.3
    settle()
    before = pose_of(rig)
    base, tip = head_world(rig, ARM[0]), tip_world(rig, ARM[-1])
    target = base + 0.7 * (tip - base) + Vector((0.05, 0.0, 0.05))
    move_rod(rods["hand.R"], target.x, target.z)
    assert pose_of(rig) == before
    rig[R.LIVE_KEY] = True
    move_rod(rods["hand.R"], target.x + 0.02, target.z)
    assert (tip_world(rig, ARM[-1]) - rods["hand.R"].matrix_world.translation).length < 2e-3 * reach(rig, ARM)


def test_three_rod_legs_hang_down_when_the_figure_tilts():
    rig, rods = add("THREE_ROD")
    rods["neck"].rotation_euler.y = math.radians(20)
    settle()
    assert_legs_hang_down(rig)


def test_a_rig_turned_on_its_own_solves_again():
    """A rigger turns the armature itself, not its rod: no rod moves, but the live solve runs
    again, so the legs hang straight down and the pose is the one a fresh solve gives (the arms
    reach for their rods from the shoulders' new places)."""
    rig, _ = add("THREE_ROD")
    rig.rotation_euler.y = math.radians(25)
    settle()
    assert_legs_hang_down(rig)
    live = pose_of(rig)
    L.solve_puppet(rig)
    fresh = pose_of(rig)
    assert all(np.allclose(fresh[n], live[n], atol=1e-9, rtol=0) for n in live), (live, fresh)


@pytest.mark.parametrize("kind", ["THREE_ROD", "FIVE_ROD"])
def test_a_puppet_turned_round_by_a_scale_of_minus_one_keeps_its_feet_level(kind):
    """Shadow puppets turn round by flipping over; here the main rod scaled by -1 on X (its
    rotations are locked to the plane). The feet keep the mirror image of their rest look at any
    tilt (they were 17 to 43 degrees off: the mirror was read as a half turn), and the rods
    are still reached."""
    def foot_angle(rig):
        d = tip_world(rig, "foot.L") - head_world(rig, "foot.L")
        return math.atan2(d.z, d.x)

    rig, rods = add(kind)
    rest = foot_angle(rig)
    main = rig.parent
    main.scale.x = -1.0
    for tilt in (0.0, 15.0, -20.0):
        main.rotation_euler.y = math.radians(tilt)
        settle()
        assert abs(T.wrap(foot_angle(rig) - (math.pi - rest))) < 1e-4, (tilt, math.degrees(foot_angle(rig)))
        base, tip = head_world(rig, ARM[0]), tip_world(rig, ARM[-1])
        target = base + 0.7 * (tip - base) + Vector((0.05, 0.0, 0.05))
        rods["hand.R"].matrix_world.translation = target
        settle()
        assert (tip_world(rig, ARM[-1]) - target).length < 2e-3 * reach(rig, ARM), tilt
        assert_within_limits(rig)


def test_live_update_on_frame_change_with_animated_rods():
    rig, rods = add("FIVE_ROD")
    hand = rods["hand.R"]
    scene = bpy.context.scene
    start = hand.location.copy()
    hand.keyframe_insert("location", frame=1)
    hand.location = start + Vector((0.35, 0, 0.35))
    hand.keyframe_insert("location", frame=11)
    for f in (1, 6, 11):
        scene.frame_set(f)
        bpy.context.view_layer.update()
        got = tip_world(rig, "hand.R")
        assert (got - hand.matrix_world.translation).length < 2e-3 * reach(rig, ARM), f


def test_strip_head_and_tail_reach_their_rods():
    rig, rods = add("STRIP")
    names = [f"trunk.{i:03d}" for i in range(T.STRIP_SEGMENTS)]
    rng = np.random.default_rng(11)
    mid = T.STRIP_SEGMENTS // 2
    for _ in range(4):
        rig[R.LIVE_KEY] = False
        for n in names[1:]:
            pb = rig.pose.bones[n]
            pb.rotation_euler.z = rng.uniform(0.5 * pb.ik_min_z, 0.5 * pb.ik_max_z)
        bpy.context.view_layer.update()
        middle, tail = tip_world(rig, names[mid - 1]).copy(), tip_world(rig, names[-1]).copy()
        for n in names:
            rig.pose.bones[n].rotation_euler.z = 0.0
        rig[R.LIVE_KEY] = True
        rods["middle"].matrix_world.translation = middle
        move_rod(rods["tail"], tail.x, tail.z)
        tol = 2e-3 * reach(rig, names)
        assert (head_world(rig, names[0]) - rods["head"].matrix_world.translation).length < 1e-6
        assert (tip_world(rig, names[-1]) - tail).length < tol
        assert (tip_world(rig, names[mid - 1]) - middle).length < tol
        assert_in_plane(rig)
        assert_within_limits(rig)


def test_prop_hands_stay_on_the_prop_while_it_turns():
    rig, rods = add("PROP")
    staff = rig["miniskeleton_prop"]
    tol = 2e-3 * reach(rig, ARM)
    for angle in (-50, -25, 0, 20, 45):
        staff.rotation_euler.y = math.radians(angle)
        staff.location.x += 0.01
        settle()
        for side in "LR":
            grip = rods[f"grip.{side}"].matrix_world.translation
            assert (tip_world(rig, f"hand.{side}") - grip).length < tol, (angle, side)
        assert_in_plane(rig)
        assert_within_limits(rig)


def test_quadruped_translates_and_turns_its_head():
    rig, rods = add("QUADRUPED")
    body = rods["body"]
    before = head_world(rig, "tail").copy()
    body.location.x += 0.5
    settle()
    assert math.isclose(head_world(rig, "tail").x - before.x, 0.5, abs_tol=1e-6)
    rods["head"].rotation_euler.y = math.radians(-20)     # about -Y is counter-clockwise: nod up
    settle()
    assert math.isclose(rig.pose.bones["head"].rotation_euler.z, math.radians(20), abs_tol=1e-6)
    rods["head"].rotation_euler.y = math.radians(-90)     # beyond the 35 degree limit
    settle()
    assert math.isclose(rig.pose.bones["head"].rotation_euler.z, rig.pose.bones["head"].ik_max_z, abs_tol=1e-6)
    assert all(rig.pose.bones[n].rotation_euler.z == 0 for n in ("body", "tail", "leg.FL"))
    # the head turns with its rod relative to the figure: the whole figure tilted, it stays level
    rods["head"].rotation_euler.y = 0.0
    body.rotation_euler.y = math.radians(15)
    settle()
    assert abs(rig.pose.bones["head"].rotation_euler.z) < 1e-6


# ---------------------------------------------------------------------------- bake


def test_bake_keys_only_the_bones_that_can_turn(capfd):
    """Bake keys the bones a rod can turn: the quadruped's rigid body, legs and tail (every
    rotation axis locked) get no F-curves, its head does."""
    rig, _ = add("QUADRUPED")
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 3
    bpy.context.view_layer.objects.active = rig
    capfd.readouterr()
    assert bpy.ops.object.miniskeleton_bake_puppet() == {"FINISHED"}
    assert f"Baked 3 frames of {rig.name}" in capfd.readouterr().out
    assert {fc.data_path for fc in K.action_fcurves(rig)} == {'pose.bones["head"].rotation_euler'}


def test_bake_keys_reproduce_the_live_pose_without_the_addon():
    rig, rods = add("FIVE_ROD")
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 9
    x0 = {role: rod.location.x for role, rod in rods.items()}
    for f, dx in ((1, 0.0), (5, 0.3), (9, -0.2)):
        for role, sign in (("hand.R", 1), ("hand.L", -1), ("foot.R", 1), ("foot.L", -1)):
            rods[role].location.x = x0[role] + sign * dx
            rods[role].keyframe_insert("location", index=0, frame=f)
        rods["neck"].location.x = 0.1 * f
        rods["neck"].keyframe_insert("location", index=0, frame=f)
    live = {}
    for f in range(1, 10):
        scene.frame_set(f)
        bpy.context.view_layer.update()
        live[f] = (pose_of(rig),
                   tip_world(rig, "hand.R").copy())

    bpy.context.view_layer.objects.active = rig
    assert bpy.ops.object.miniskeleton_bake_puppet() == {"FINISHED"}
    assert rig.get(R.LIVE_KEY) is False or rig.get(R.LIVE_KEY) == 0
    assert rig.animation_data is not None and rig.animation_data.action is not None

    # Without the add-on (no handler at all), the keys alone give the same pose.
    bpy.ops.preferences.addon_disable(module=blender_session.ADDON_MODULE)
    try:
        assert L._on_frame_change not in bpy.app.handlers.frame_change_post
        for pb in rig.pose.bones:
            pb.rotation_euler = (0, 0, 0)
        for f in (9, 2, 5, 1, 7):
            scene.frame_set(f)
            bpy.context.view_layer.update()
            rot, tip = live[f]
            for name, r in rot.items():
                assert np.allclose(tuple(rig.pose.bones[name].rotation_euler), r, atol=1e-5), (f, name)
            assert (tip_world(rig, "hand.R") - tip).length < 1e-5
    finally:
        bpy.ops.preferences.addon_enable(module=blender_session.ADDON_MODULE)



@pytest.mark.parametrize("mode", ["QUATERNION", "AXIS_ANGLE", "YXZ"])
def test_bones_a_rigger_set_to_another_rotation_mode_follow_their_rods_and_bake(mode):
    """A puppet's bones are made in XYZ Euler; one a rigger sets to another rotation mode (a
    rig-wide Quaternion habit) is solved, written and baked in that mode. Before: the solver
    wrote ``rotation_euler``, which such a bone ignores, so the arm stayed put (0.29 from a
    rod 0.3 away) and Bake keyed a property nothing reads."""
    rig, rods = add("FIVE_ROD")
    scene = bpy.context.scene
    targets = random_reachable(rig, ARM, np.random.default_rng(3), 5)
    for name in ARM:
        rig.pose.bones[name].rotation_mode = mode
    rod = rods["hand.R"]
    tol = 2e-3 * reach(rig, ARM)
    live = {}
    for f, t in enumerate(targets, start=1):
        move_rod(rod, t.x, t.z)
        assert (tip_world(rig, "hand.R") - t).length < tol, (f, tuple(t))
        assert_in_plane(rig, euler=False)
        rod.keyframe_insert("location", frame=f)
    scene.frame_start, scene.frame_end = 1, len(targets)
    for f in range(1, len(targets) + 1):
        scene.frame_set(f)
        settle()
        live[f] = tip_world(rig, "hand.R").copy()

    bpy.context.view_layer.objects.active = rig
    assert bpy.ops.object.miniskeleton_bake_puppet() == {"FINISHED"}
    path = {"QUATERNION": "rotation_quaternion", "AXIS_ANGLE": "rotation_axis_angle"}.get(mode, "rotation_euler")
    keyed = {fc.data_path for fc in K.action_fcurves(rig)}
    assert {f'pose.bones["{n}"].{path}' for n in ARM} <= keyed
    bpy.ops.preferences.addon_disable(module=blender_session.ADDON_MODULE)
    try:
        for f in (5, 2, 4, 1, 3):
            scene.frame_set(f)
            bpy.context.view_layer.update()
            assert (tip_world(rig, "hand.R") - live[f]).length < 1e-5, f
    finally:
        bpy.ops.preferences.addon_enable(module=blender_session.ADDON_MODULE)


def test_a_renamed_bone_or_deleted_rod_is_named_and_the_rest_still_follows(capfd):
    """A rigger renames a bone the template drives, or deletes a rod in the viewport: that
    chain is left as it is and named (once in the console while solving live, and in Bake's
    report), while the other limbs follow their rods. Before: nothing was said, and a limb whose
    rod was deleted went on following it unseen (the rig's reference kept it in the file)."""
    rig, rods = add("FIVE_ROD")
    capfd.readouterr()
    rig.data.bones["forearm.R"].name = "lowerarm.R"
    settle()
    assert "upper_arm.R, forearm.R, hand.R (following rod hand.R): no bone forearm.R" in capfd.readouterr().out
    broken = ("upper_arm.R", "lowerarm.R", "hand.R")
    kept = pose_of(rig, broken)
    p = rods["hand.R"].matrix_world.translation
    move_rod(rods["hand.R"], p.x + 0.2, p.z + 0.1)
    assert pose_of(rig, broken) == kept
    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    gone = rods["foot.L"]
    gone.select_set(True)
    bpy.context.view_layer.objects.active = gone
    assert bpy.ops.object.delete() == {"FINISHED"}
    assert "FiveRodPuppet.rod.foot.L" in bpy.data.objects     # still referenced by the rig
    settle()
    said = capfd.readouterr().out
    assert "no bone forearm.R; thigh.L, shin.L (following rod foot.L): no rod foot.L" in said
    assert said.count("[MiniSkeleton] Puppet") == 1

    shin = tip_world(rig, "shin.L").copy()
    gone.location.x += 0.3                                      # a script moves the deleted rod
    target = rods["hand.L"].matrix_world.translation + Vector((0.1, 0.0, 0.2))
    move_rod(rods["hand.L"], target.x, target.z)
    assert (tip_world(rig, "hand.L") - target).length < 2e-3 * reach(rig, ("upper_arm.L", "forearm.L", "hand.L"))
    assert (tip_world(rig, "shin.L") - shin).length < 1e-6
    assert "[MiniSkeleton] Puppet" not in capfd.readouterr().out   # said once, until it changes

    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 3
    bpy.context.view_layer.objects.active = rig
    assert bpy.ops.object.miniskeleton_bake_puppet() == {"FINISHED"}
    out = capfd.readouterr().out
    assert "Baked 3 frames of FiveRodPuppet; it leaves these as they are" in out and "no rod foot.L" in out


def test_bake_reports_progress_frame_by_frame_on_the_scene_frame_step():
    """Baking evaluates and solves every frame of the scene (0.36 s for 1000 frames), so the
    operator shows progress: the bake calls back after each frame, on the frames of the scene's
    range by its frame step."""
    rig, _ = add("THREE_ROD")
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end, scene.frame_step = 3, 11, 2
    done = []
    assert L.bake_puppet(scene, rig, progress=done.append) == 5
    assert done == [1, 2, 3, 4, 5]
    assert {kp.co[0] for fc in K.action_fcurves(rig) for kp in fc.keyframe_points} == {3, 5, 7, 9, 11}


def test_a_puppet_linked_from_a_library_is_refused_clearly(tmp_path):
    """A puppet linked from another .blend with its parts cannot take keys or new part images:
    Bake and Set Part Image say so and change nothing."""
    rig, _ = add("THREE_ROD")
    head = next(ob for ob in rig.children if ob.get(R.PART_KEY) == "head")
    library = str(tmp_path / "puppet.blend")
    bpy.data.libraries.write(library, {rig, head})
    with bpy.data.libraries.load(library, link=True) as (_, linked):
        linked.objects = [rig.name, head.name]
    linked_rig, linked_head = linked.objects
    for ob in linked.objects:
        bpy.context.collection.objects.link(ob)
    assert linked_head.parent == linked_rig and not linked_rig.is_editable
    bpy.context.view_layer.objects.active = linked_rig
    with pytest.raises(RuntimeError, match=r"Object '.*' is linked from puppet.blend .*Make Local"):
        bpy.ops.object.miniskeleton_bake_puppet()
    assert linked_rig.animation_data is None
    mesh = linked_head.data
    with pytest.raises(RuntimeError, match=rf"Object '{linked_head.name}' is linked from puppet.blend"):
        bpy.ops.object.miniskeleton_set_part_image(filepath=face_png(tmp_path), bone="head")
    assert linked_head.data == mesh


def test_a_puppet_playing_a_linked_action_is_not_baked(tmp_path):
    """Bake keys the rig's action: one linked from another .blend is refused by name."""
    rig, _ = add("THREE_ROD")
    rig.animation_data_create()
    rig.animation_data.action = B.link_from_library(bpy.data.actions.new("Show"), tmp_path / "a.blend")
    bpy.context.view_layer.objects.active = rig
    with pytest.raises(RuntimeError, match=r"Action 'Show' is linked from a.blend"):
        bpy.ops.object.miniskeleton_bake_puppet()
    # refused before baking: live solving (switched off by a bake) is still on
    assert rig.animation_data.action.name == "Show" and rig.get(R.LIVE_KEY, True)

def test_a_rod_or_rig_without_a_finite_place_keeps_the_pose_and_is_not_baked(capfd):
    """A rod at NaN (a driver or constraint gone wrong), or the rig scaled to zero on an axis:
    live solving printed a traceback on every update and Bake stopped with one. Now live solving
    keeps the pose and says why once; Bake is an error naming the frame, keys nothing and puts
    back the pose the frames it solved before the failure had changed."""
    rig, rods = add("FIVE_ROD")
    scene = bpy.context.scene
    move_rod(rods["hand.R"], -0.3, 1.2)
    posed = pose_of(rig)
    capfd.readouterr()
    hand = rods["hand.R"]
    placed = hand.location.copy()
    hand.location = placed + Vector((0.05, 0.0, 0.05))  # frame 1 solves to another pose
    hand.keyframe_insert("location", frame=1)
    hand.location.x = float("nan")
    hand.keyframe_insert("location", frame=3)   # NaN from frame 2 on (interpolated towards it)
    scene.frame_start, scene.frame_end = 1, 5
    for f in (3, 4, 5):
        scene.frame_set(f)
        settle()
    assert pose_of(rig) == posed
    out = capfd.readouterr()
    assert "Traceback" not in out.out + out.err
    assert out.out.count("rod(s) FiveRodPuppet.rod.hand.R have no finite place") == 1
    bpy.context.view_layer.objects.active = rig
    with pytest.raises(RuntimeError, match=r"At frame 2: Puppet 'FiveRodPuppet': rod\(s\) "
                       r"FiveRodPuppet.rod.hand.R have no finite place .*nothing was baked"):
        bpy.ops.object.miniskeleton_bake_puppet()
    assert rig.animation_data is None and pose_of(rig) == posed and rig.get(R.LIVE_KEY, True)
    assert scene.frame_current == 5

    hand.animation_data_clear()
    hand.location = placed
    rig.scale.x = 0.0
    settle()
    assert pose_of(rig) == posed
    assert "is scaled to zero on an axis (0, 1, 1)" in capfd.readouterr().out
    with pytest.raises(RuntimeError, match=r"At frame 1: Puppet 'FiveRodPuppet' is scaled to zero"):
        bpy.ops.object.miniskeleton_bake_puppet()
    assert rig.animation_data is None
    rig.scale.x = 1e-13                # zero relative to the other axes: as singular as 0
    settle()
    assert pose_of(rig) == posed
    with pytest.raises(RuntimeError, match=r"Puppet 'FiveRodPuppet' is scaled to zero on an axis \(1e-13, 1, 1\)"):
        bpy.ops.object.miniskeleton_bake_puppet()
    assert rig.animation_data is None
    rig.scale.x = 1.0                                  # mended: it solves and bakes again
    settle()
    assert bpy.ops.object.miniskeleton_bake_puppet() == {"FINISHED"}
    assert rig.animation_data.action is not None


def test_a_bake_that_fails_for_another_reason_puts_the_pose_back_and_is_one_report(capfd):
    """Bake put the bones back only on PuppetError: any other exception left the rotations the
    frames solved before it had written. Here the core itself refuses a frame (its ValueError
    for a chest whose location F-curve goes NaN, which no puppet check names): the bake is one
    error naming the frame, keys nothing, and the pose, live solving and the frame are as they
    were."""
    rig, rods = add("FIVE_ROD")
    scene = bpy.context.scene
    move_rod(rods["hand.R"], -0.3, 1.2)
    hand = rods["hand.R"]
    hand.location += Vector((0.05, 0.0, 0.05))       # frame 1 solves to another pose
    hand.keyframe_insert("location", frame=1)
    chest = rig.pose.bones["chest"]
    chest.keyframe_insert("location", frame=1)
    chest.location.x = float("nan")
    chest.keyframe_insert("location", frame=3)       # NaN from frame 2 on
    scene.frame_start, scene.frame_end = 1, 5
    scene.frame_set(5)
    settle()
    posed = pose_of(rig)
    before = {name: r for name, r in posed.items() if abs(r[2]) > 1e-6}
    assert before, "the solved pose turns some bones"
    capfd.readouterr()
    bpy.context.view_layer.objects.active = rig
    with pytest.raises(RuntimeError, match=r"At frame 2: puppet 'FiveRodPuppet' cannot be solved \(ValueError: "
                       r"\d+ IK chain\(s\) have NaN or infinite values\); nothing was baked") as err:
        bpy.ops.object.miniskeleton_bake_puppet()
    out = capfd.readouterr()
    assert "Traceback" not in out.out + out.err + str(err.value)
    assert pose_of(rig) == posed
    assert rig.get(R.LIVE_KEY) and scene.frame_current == 5
    assert not [fc for fc in K.action_fcurves(rig) if "rotation" in fc.data_path]

    # the same through the function: the pose goes back whatever the failure, and the frame
    # that failed is named
    with pytest.raises(L.PuppetError, match="At frame 2: ") as failed:
        L.bake_puppet(scene, rig)
    assert isinstance(failed.value.__cause__, ValueError) and not isinstance(failed.value.__cause__, L.PuppetError)
    assert pose_of(rig) == posed and scene.frame_current == 5


def test_a_puppet_is_not_added_at_a_nan_cursor():
    """A 3D cursor a script put at NaN: Add Puppet built the objects, then stopped with a
    traceback in its first solve and left them half made. It is an error, and nothing is added."""
    cursor = bpy.context.scene.cursor
    cursor.location = (float("nan"), 0.0, 0.0)
    before = set(bpy.data.objects)
    try:
        with pytest.raises(RuntimeError, match="The 3D cursor has a NaN or infinite location") as err:
            bpy.ops.object.miniskeleton_add_puppet(type="FIVE_ROD")
    finally:
        cursor.location = (0.0, 0.0, 0.0)
    assert "Traceback" not in str(err.value)
    assert set(bpy.data.objects) == before


def test_puppet_operators_say_what_to_select_when_no_puppet_is_active(tmp_path):
    """Bake and Set Part Image need a puppet: with a plain cube active they are greyed out, and
    the tooltip (and a script's error) says what to select instead of "context is incorrect"."""
    bpy.ops.mesh.primitive_cube_add()
    for call in (bpy.ops.object.miniskeleton_bake_puppet,
                 lambda: bpy.ops.object.miniskeleton_set_part_image(filepath=face_png(tmp_path), bone="head")):
        with pytest.raises(RuntimeError, match=r"poll\(\) Select a shadow puppet .*Add > Armature > Shadow Puppet"):
            call()
    rig, _ = add("THREE_ROD")
    bpy.context.view_layer.objects.active = rig
    assert bpy.ops.object.miniskeleton_bake_puppet.poll()


def test_a_riggers_object_parented_under_a_rod_or_part_belongs_to_that_puppet():
    """A rigger parents a plume to a hand rod, a tassel under the plume, a badge to the chest:
    with any of them active the puppet operators act on that puppet. An object not under a
    puppet, however deep its own hierarchy, belongs to none."""
    rig, rods = add("THREE_ROD")
    chest = next(ob for ob in bpy.context.scene.objects if ob.get(R.PART_KEY) == "chest")

    def empty(name, parent):
        ob = bpy.data.objects.new(name, None)
        bpy.context.scene.collection.objects.link(ob)
        ob.parent = parent
        return ob

    plume = empty("Plume", rods["hand.L"])
    tassel = empty("Tassel", empty("Cord", plume))
    badge = empty("Badge", chest)
    for ob in (plume, tassel, badge):
        assert R.puppet_rig(ob) == rig, ob.name
    bpy.context.view_layer.objects.active = tassel
    assert bpy.ops.object.miniskeleton_bake_puppet.poll()
    top = empty("Top", None)
    deep = empty("Deep", empty("C", empty("B", empty("A", top))))
    assert R.puppet_rig(deep) is None and R.puppet_rig(top) is None


def test_an_ordinary_armature_is_not_a_puppet():
    """A character's own armature next to a puppet is not solved as one: live solving leaves
    its pose alone and the theatre does not count it."""
    rig, _ = add("THREE_ROD")
    character = B.chain("Character", count=3)
    character.pose.bones["Bone1"].rotation_quaternion = (0.9, 0.3, 0.2, 0.1)
    posed = [tuple(pb.matrix) for pb in character.pose.bones]
    scene = bpy.context.scene
    assert R.scene_puppets(scene) == [rig]
    assert L.update_scene_puppets(scene, force=True) == 1
    bpy.context.view_layer.update()
    assert [tuple(pb.matrix) for pb in character.pose.bones] == posed


# ---------------------------------------------------------------------------- parts, theatre


def face_png(tmp_path) -> str:
    """An 8 x 16 PNG with alpha (a face cut-out) saved in ``tmp_path``; its path."""
    img = bpy.data.images.new("face", 8, 16, alpha=True)
    px = np.zeros((16, 8, 4), dtype=np.float32)
    px[4:12, 2:6] = (0.8, 0.2, 0.1, 1.0)
    img.pixels.foreach_set(px.ravel())
    path = str(tmp_path / "face.png")
    img.filepath_raw = path
    img.file_format = "PNG"
    img.save()
    return path


def test_puppet_angles_wrap_like_the_core_and_solver_limits_stay_on_the_circle():
    """Angles wrap to (-pi, pi] as the core's ``wrap_angle`` does (so -pi is pi), and limits
    plus rest offsets are clipped to [-pi, pi]."""
    for a, want in ((-math.pi, math.pi), (3 * math.pi, math.pi), (-0.5, -0.5), (2 * math.pi + 0.25, 0.25)):
        assert T.wrap(a) == pytest.approx(want)
    lim = T.solver_limits([(-170.0 * math.pi / 180, 170.0 * math.pi / 180)] * 2, [0.0, 0.5])
    assert lim[0].tolist() == pytest.approx([-170 * math.pi / 180, 170 * math.pi / 180])
    assert lim[1].tolist() == pytest.approx([-170 * math.pi / 180 + 0.5, math.pi])


def test_puppets_share_one_leather_material():
    """A second puppet reuses the leather material of the first (no 'Leather.001' per puppet)."""
    add("THREE_ROD")
    add("QUADRUPED")
    leather = [m for m in bpy.data.materials if m.name.startswith("MiniSkeleton Puppet Leather")]
    assert len(leather) == 1 and leather[0].users >= 2


def test_set_part_image(tmp_path):
    """The picture replaces the cut-out on the part's layer (its depth toward the viewer), and
    setting it again leaves no old mesh behind."""
    rig, rods = add("THREE_ROD")
    path = face_png(tmp_path)
    bpy.context.view_layer.objects.active = rig
    cutout = next(ob for ob in rig.children if ob.get(R.PART_KEY) == "head")
    depth = cutout.data.vertices[0].co.z
    assert depth > 0.003
    assert bpy.ops.object.miniskeleton_set_part_image(filepath=path, bone="head") == {"FINISHED"}
    part = next(ob for ob in rig.children if ob.get(R.PART_KEY) == "head")
    assert part == cutout and len(part.data.vertices) == 4 and part.parent_bone == "head"
    assert all(v.co.z == pytest.approx(depth) for v in part.data.vertices)
    meshes = len(bpy.data.meshes)
    assert bpy.ops.object.miniskeleton_set_part_image(filepath=path, bone="head") == {"FINISHED"}
    assert len(bpy.data.meshes) == meshes and all(m.users for m in bpy.data.meshes)
    xs = [v.co.x for v in part.data.vertices]
    ys = [v.co.y for v in part.data.vertices]
    assert math.isclose((max(xs) - min(xs)) / (max(ys) - min(ys)), 0.5, rel_tol=1e-6)   # image aspect
    # 1.3 bone lengths tall, centred on the bone as posed (in the picture plane, x and z)
    pb = rig.pose.bones["head"]
    assert math.isclose(max(ys) - min(ys), 1.3 * pb.bone.length, rel_tol=1e-6)
    bpy.context.view_layer.update()
    centre = world_centre(part)
    middle = rig.matrix_world @ ((pb.head + pb.tail) / 2)
    assert (centre.x, centre.z) == pytest.approx((middle.x, middle.z), abs=1e-5)
    nodes = part.data.materials[0].node_tree.nodes
    tex = [n for n in nodes if n.type == "TEX_IMAGE"]
    assert tex and tex[0].image.filepath.endswith("face.png")
    # Without a bone named, the active bone's part takes it, and the file is loaded once.
    other = next(ob for ob in rig.children if ob.get(R.PART_KEY) not in (None, "head"))
    rig.data.bones.active = rig.data.bones[other[R.PART_KEY]]
    assert bpy.ops.object.miniskeleton_set_part_image(filepath=path) == {"FINISHED"}
    assert len(other.data.vertices) == 4
    assert [i.name for i in bpy.data.images if i.filepath.endswith("face.png")] == [tex[0].image.name]


def test_set_part_image_on_a_part_in_edit_mode_is_an_error(tmp_path):
    """A part in Edit Mode cannot take a new mesh: the operator reported success and the part
    kept its cut-out. Now a clear error, and nothing changes."""
    rig, _ = add("THREE_ROD")
    part = next(ob for ob in rig.children if ob.get(R.PART_KEY) == "head")
    mesh, meshes = part.data, len(bpy.data.meshes)
    B.set_active(part)
    bpy.ops.object.mode_set(mode="EDIT")
    with pytest.raises(RuntimeError, match=f"Mesh in Edit Mode: {part.name}; leave Edit Mode first"):
        bpy.ops.object.miniskeleton_set_part_image(filepath=face_png(tmp_path), bone="head")
    bpy.ops.object.mode_set(mode="OBJECT")
    assert part.data == mesh and len(bpy.data.meshes) == meshes


def test_set_part_image_of_a_file_that_is_not_an_image_is_an_error(tmp_path):
    """Blender "loads" any file as an image of size 0 x 0 (a pink texture): refuse it instead."""
    rig, _ = add("THREE_ROD")
    part = next(ob for ob in rig.children if ob.get(R.PART_KEY) == "head")
    mesh, images = part.data, len(bpy.data.images)
    bad = tmp_path / "face.png"
    bad.write_text("not a PNG")
    bpy.context.view_layer.objects.active = rig
    with pytest.raises(RuntimeError, match="face.png is not an image Blender can read"):
        bpy.ops.object.miniskeleton_set_part_image(filepath=str(bad), bone="head")
    assert part.data == mesh and len(bpy.data.images) == images


def test_shadow_theatre_preset():
    rig, rods = add("FIVE_ROD")
    assert bpy.ops.scene.miniskeleton_shadow_theatre() == {"FINISHED"}
    scene = bpy.context.scene
    screen, light, cam = (bpy.data.objects[n] for n in ("ShadowScreen", "ShadowBacklight", "ShadowCamera"))
    assert screen.location.y > 0.05 and light.location.y > screen.location.y   # behind the puppet
    assert cam.location.y < 0 and scene.camera == cam                          # audience side
    assert cam.matrix_world.col[2].xyz.dot(Vector((0, -1, 0))) > 0.999          # looks along +Y
    assert light.matrix_world.col[2].xyz.dot(Vector((0, 1, 0))) > 0.999         # shines along -Y
    assert scene.render.engine == "BLENDER_WORKBENCH"
    # The whole figure is inside the camera's view.
    half = cam.data.ortho_scale / 2
    for name in ("head", "foot.R", "hand.L"):
        p = tip_world(rig, name)
        assert abs(p.x - cam.location.x) < half and abs(p.z - cam.location.z) < half
    assert bpy.ops.scene.miniskeleton_shadow_theatre(engine="EEVEE") == {"FINISHED"}   # refits, no duplicates
    assert len([ob for ob in bpy.data.objects if ob.name.startswith("ShadowScreen")]) == 1
    assert scene.render.engine.startswith("BLENDER_EEVEE")
    # Refitted while the screen is being edited (its Edit Mode would otherwise write the old
    # mesh back when it ends): it leaves Edit Mode first and the screen takes the new size.
    width = screen.dimensions.x
    rig.parent.scale = (2.0, 2.0, 2.0)
    B.set_active(screen)
    bpy.ops.object.mode_set(mode="EDIT")
    assert bpy.ops.scene.miniskeleton_shadow_theatre() == {"FINISHED"}
    bpy.context.view_layer.update()
    assert screen.mode == "OBJECT" and screen.dimensions.x > 1.5 * width


def test_shadow_theatre_frames_a_wide_cast_and_leaves_the_riggers_own_objects():
    """Two puppets 6 m apart are wider than tall: every part is inside the camera's frame
    (landscape, so the orthographic scale is the width). An object of the rigger's called
    ShadowScreen and a lamp of theirs called ShadowBacklight are not taken over; running the
    preset again refits its own objects (found by their role, not their name: before, a second
    run made a second screen beside the rigger's object) and leaves no old screen mesh behind."""
    from bpy_extras.object_utils import world_to_camera_view

    bpy.ops.mesh.primitive_cube_add(location=(0.0, 5.0, 0.0))
    own = bpy.context.active_object
    own.name = "ShadowScreen"
    own_mesh = own.data
    own_lamp = bpy.data.lights.new("ShadowBacklight", "POINT")
    own_lamp.energy = 7.0
    scene = bpy.context.scene
    rigs = []
    for x in (-3.0, 3.0):
        scene.cursor.location = (x, 0.0, 0.0)
        rigs.append(add("FIVE_ROD")[0])
    assert bpy.ops.scene.miniskeleton_shadow_theatre() == {"FINISHED"}
    assert own.name == "ShadowScreen" and own.data == own_mesh and tuple(own.location) == (0.0, 5.0, 0.0)
    assert own_lamp.type == "POINT" and own_lamp.energy == 7.0 and own_lamp.users == 0
    cam = scene.camera
    assert cam.name == "ShadowCamera" and scene.render.resolution_x > scene.render.resolution_y
    dg = bpy.context.evaluated_depsgraph_get()
    parts = [ob for ob in scene.objects if ob.type == "MESH" and R.puppet_rig(ob) in rigs]
    assert len(parts) > 10
    for ob in parts:
        ev = ob.evaluated_get(dg)
        for corner in ev.bound_box:
            u, v, _ = world_to_camera_view(scene, cam, ev.matrix_world @ Vector(corner))
            assert 0.0 < u < 1.0 and 0.0 < v < 1.0, f"{ob.name} at {u:.2f}, {v:.2f} of the frame"
    meshes, objects = len(bpy.data.meshes), sorted(o.name for o in bpy.data.objects)
    assert bpy.ops.scene.miniskeleton_shadow_theatre() == {"FINISHED"}
    assert len(bpy.data.meshes) == meshes and all(m.users for m in bpy.data.meshes)
    assert sorted(o.name for o in bpy.data.objects) == objects
    assert scene.camera == cam and own.data == own_mesh


def test_each_scene_gets_its_own_shadow_theatre_behind_its_own_puppets():
    """A second scene (another shot) gets its own screen, light and camera, centred behind its
    puppet, and the first scene's theatre stays where it was. Before, the second run took the
    first scene's objects (found in the file by their role), linked them into the second scene
    and refitted them there, moving the first shot's screen and camera. Running it again in
    either scene refits that scene's own objects and makes no new material."""
    first = bpy.context.scene
    add("FIVE_ROD")
    assert bpy.ops.scene.miniskeleton_shadow_theatre() == {"FINISHED"}
    theatre = sorted(o.name for o in first.objects if o.get(R.THEATRE_KEY))
    assert len(theatre) == 3
    places = {n: bpy.data.objects[n].matrix_world.copy() for n in theatre}

    second = bpy.data.scenes.new("Shot 2")
    bpy.context.window.scene = second
    second.cursor.location = (4.0, 0.0, 0.0)
    rig, _ = add("FIVE_ROD")
    assert bpy.ops.scene.miniskeleton_shadow_theatre() == {"FINISHED"}
    own = [o for o in second.objects if o.get(R.THEATRE_KEY)]
    assert len(own) == 3 and not {o.name for o in own} & set(theatre)
    assert second.camera in own and first.camera.name in theatre
    assert all(bpy.data.objects[n].matrix_world == m for n, m in places.items())
    assert not any(o.name in first.objects for o in own)
    screen = next(o for o in own if o.get(R.THEATRE_KEY) == "ShadowScreen")
    xs = [p.x for p in (tip_world(rig, b) for b in ("head", "hand.L", "hand.R", "foot.L", "foot.R"))]
    assert screen.location.x == pytest.approx(4.0, abs=0.5) and min(xs) < screen.location.x < max(xs)
    light = next(o for o in own if o.get(R.THEATRE_KEY) == "ShadowBacklight")
    assert second.camera.location.x == pytest.approx(screen.location.x) == light.location.x

    count = len(bpy.data.objects)
    for scene in (first, second):
        bpy.context.window.scene = scene
        assert bpy.ops.scene.miniskeleton_shadow_theatre() == {"FINISHED"}
    assert len(bpy.data.objects) == count
    assert [m.name for m in bpy.data.materials if m.name.startswith("MiniSkeleton Shadow Screen")] == [
        "MiniSkeleton Shadow Screen"]


def test_vertices_of_the_meshes_puppets_are_made_of_can_be_selected_in_weight_paint(tmp_path):
    """Blender 5.0.1 types the internal ``.select_edge`` attribute INT32_2D when it computes a
    new mesh's edges itself, and selecting vertices of such a mesh in Weight Paint mode (Vertex
    Selection mask, then A) crashed Blender. Every mesh the puppet tools make (parts, the prop,
    a part with a picture, the theatre's screen) is made with its edges given."""
    rig, _ = add("PROP")
    bpy.context.view_layer.objects.active = rig
    assert bpy.ops.object.miniskeleton_set_part_image(filepath=face_png(tmp_path), bone="head") == {"FINISHED"}
    assert bpy.ops.scene.miniskeleton_shadow_theatre() == {"FINISHED"}
    made = [ob for ob in bpy.data.objects if ob.type == "MESH"]
    assert {"ShadowScreen", "PropPuppet.part.head", "PropPuppet.part.neck"} <= {ob.name for ob in made}
    assert any(ob.parent is not None and ob.parent.type == "EMPTY" for ob in made)   # the prop
    for ob in made:
        kind = {a.name: a.data_type for a in ob.data.attributes}.get(".select_edge", "BOOLEAN")
        assert kind == "BOOLEAN", f"{ob.name}: .select_edge is {kind}"
    for ob in made:
        B.set_active(ob)
        bpy.ops.object.mode_set(mode="WEIGHT_PAINT")
        ob.data.use_paint_mask_vertex = True
        assert bpy.ops.paint.vert_select_all(action="DESELECT") == {"FINISHED"}
        assert bpy.ops.paint.vert_select_all(action="INVERT") == {"FINISHED"}
        bpy.ops.object.mode_set(mode="OBJECT")
        assert all(v.select for v in ob.data.vertices) and all(e.select for e in ob.data.edges)


# ---------------------------------------------------------------------------- live handler upkeep


def two_puppets():
    """A five-rod puppet at the origin, then a three-rod one at x = 3 (later in the scene's
    objects, so the live handler comes to it after the first)."""
    scene = bpy.context.scene
    scene.cursor.location = (0.0, 0.0, 0.0)
    first, first_rods = add("FIVE_ROD")
    scene.cursor.location = (3.0, 0.0, 0.0)
    second, second_rods = add("THREE_ROD")
    scene.cursor.location = (0.0, 0.0, 0.0)
    order = R.scene_puppets(scene)
    assert order.index(first) < order.index(second)
    return first, first_rods, second, second_rods


def break_puppet(rig, how):
    """What a hand in Custom Properties or a script can do: an unknown type, a seed as text."""
    if how == "type":
        rig[R.KIND_KEY] = "DRAGON"
    else:
        rig.pose.bones["forearm.R"][R.SEED_KEY] = "ninety"
    rig.update_tag()
    settle()


def mend_puppet(rig, how):
    if how == "type":
        rig[R.KIND_KEY] = "FIVE_ROD"
    else:
        rig.pose.bones["forearm.R"][R.SEED_KEY] = 0.0
    rig.update_tag()
    settle()


def follows(rig, rods, role="hand.R", chain=ARM):
    return (tip_world(rig, chain[-1]) - rods[role].matrix_world.translation).length < 2e-3 * reach(rig, chain)


@pytest.mark.parametrize("how, said", [
    ("type", "Puppet 'FiveRodPuppet' has the type 'DRAGON' in its 'miniskeleton_puppet' property, which is "
             "none of THREE_ROD, FIVE_ROD, PROP, STRIP, QUADRUPED (Object Properties > Custom Properties)"),
    ("seed", "Puppet 'FiveRodPuppet': bone forearm.R has miniskeleton_seed = 'ninety', not a finite angle "
             "in degrees (Bone Properties > Custom Properties)")])
def test_a_broken_puppet_is_said_once_and_the_others_keep_following_their_rods(how, said, capfd):
    """An unknown type in a puppet's property (a ValueError) or a seed that is not a number (a
    TypeError) went to the live handler's outer except on every depsgraph update and frame
    change, with a traceback each time, and every puppet after it in the scene stopped solving.
    Now each puppet is solved on its own: the broken one keeps its pose, is said once (console)
    and marked for the Puppet panel, and is tried again only when it changes; the other follows
    its rods, live and on frame changes; mended, the broken one solves again."""
    first, first_rods, second, second_rods = two_puppets()
    scene = bpy.context.scene
    mended_at = random_reachable(first, ARM, np.random.default_rng(4), 1)[0]
    capfd.readouterr()
    break_puppet(first, how)
    kept = pose_of(first)
    assert L.puppet_problem(first) == said and L.puppet_problem(second) is None

    targets = random_reachable(second, ARM, np.random.default_rng(5), 5)
    for k, t in enumerate(targets[:3]):                        # live: rods moved by hand
        p = first_rods["hand.R"].matrix_world.translation
        move_rod(first_rods["hand.R"], p.x + 0.1, p.z - 0.05)
        move_rod(second_rods["hand.R"], t.x, t.z)
        assert follows(second, second_rods), k
        assert pose_of(first) == kept
    for f, t in ((1, targets[3]), (5, targets[4])):            # on frame changes: animated rods
        second_rods["hand.R"].matrix_world.translation = t
        second_rods["hand.R"].keyframe_insert("location", frame=f)
        first_rods["hand.R"].location.x += 0.2
        first_rods["hand.R"].keyframe_insert("location", frame=f)
    for f in (1, 5, 3, 1, 5):
        scene.frame_set(f)
        settle()
        assert follows(second, second_rods), f
        assert pose_of(first) == kept, f
    out = capfd.readouterr()
    assert "Traceback" not in out.out + out.err
    assert out.out.count("[MiniSkeleton]") == 1 and out.out.count(f"[MiniSkeleton] {said}") == 1
    assert L.puppet_problem(first) == said

    first_rods["hand.R"].animation_data_clear()
    move_rod(first_rods["hand.R"], mended_at.x, mended_at.z)
    assert pose_of(first) == kept
    mend_puppet(first, how)                                        # mended: it solves again
    assert L.puppet_problem(first) is None and follows(first, first_rods)
    assert "[MiniSkeleton]" not in capfd.readouterr().out


def test_live_state_is_forgotten_when_a_file_is_loaded(tmp_path, capfd):
    """Live solving's per-puppet state is keyed by the armature's pointer, which means nothing in
    another file (a new object can get the same address), and it was cleared only when the
    add-on was disabled, so it grew with each file opened and a broken puppet of the old file
    could silence one of the new. A persistent load_post handler forgets it all on each load."""
    on_load = [h for h in bpy.app.handlers.load_post if getattr(h, "__name__", "") == "_on_load_post"]
    assert on_load == [L._on_load_post] and "_bpy_persistent" in vars(L._on_load_post)
    empty = str(tmp_path / "empty.blend")
    bpy.ops.wm.save_as_mainfile(filepath=empty)
    first, first_rods, second, second_rods = two_puppets()
    break_puppet(first, "type")
    assert len(L._state["last"]) == 2 and L.puppet_problem(first)
    puppets = str(tmp_path / "puppets.blend")
    bpy.ops.wm.save_as_mainfile(filepath=puppets)
    capfd.readouterr()

    bpy.ops.wm.open_mainfile(filepath=empty)
    assert L._state["last"] == {} and L._state["broken"] == {} and L._state["gaps"] == {}
    assert L._on_load_post in bpy.app.handlers.load_post          # persistent: there for the next file
    assert L._on_frame_change in bpy.app.handlers.frame_change_post

    bpy.ops.wm.open_mainfile(filepath=puppets)                    # said again in the file it is in
    first, second = bpy.data.objects["FiveRodPuppet"], bpy.data.objects["ThreeRodPuppet"]
    rods = R.puppet_rods(second)
    p = rods["hand.R"].matrix_world.translation
    move_rod(rods["hand.R"], p.x + 0.1, p.z + 0.1)
    assert follows(second, rods)
    assert L.puppet_problem(first) and capfd.readouterr().out.count("[MiniSkeleton] Puppet 'FiveRodPuppet'") == 1

    bpy.ops.preferences.addon_disable(module=blender_session.ADDON_MODULE)
    try:
        names = {getattr(h, "__name__", "") for name, _ in L._HANDLERS for h in getattr(bpy.app.handlers, name)}
        assert not names & {fn.__name__ for _, fn in L._HANDLERS}
        assert L._state["last"] == {}
    finally:
        bpy.ops.preferences.addon_enable(module=blender_session.ADDON_MODULE)


def test_live_puppets_write_no_pose_while_a_render_runs(tmp_path, capfd):
    """Blender's handlers documentation (Note on Altering Data): while rendering, frame-change
    handlers run in one thread and the viewport draws from another, so a handler that changes
    data can crash Blender. Live solving wrote poses from frame_change_post during animation
    renders. Now it writes none in a render's frame changes (their depsgraph is in RENDER mode)
    and says so once per render (bake the puppet to render its motion); frame changes in the
    viewport solve as before.

    Around the add-on's handler, one handler before it turns the forearm (as a hand or another
    add-on may) and one after it reads the forearm: nothing else runs between the two."""
    rig, rods = add("FIVE_ROD")
    scene = bpy.context.scene
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x = scene.render.resolution_y = 16
    scene.render.filepath = str(tmp_path / "frame_")
    scene.frame_start, scene.frame_end = 1, 3
    forearm = rig.pose.bones["forearm.R"]
    seen = []

    def nudge(scene_, depsgraph=None):
        forearm.rotation_euler.z += 0.3
        seen.append([depsgraph.mode, scene_.frame_current, forearm.rotation_euler.z])

    def look(scene_, depsgraph=None):
        seen[-1].append(forearm.rotation_euler.z)

    handlers = bpy.app.handlers.frame_change_post
    handlers.insert(0, nudge)
    handlers.append(look)
    try:
        for _ in range(2):
            seen.clear()
            capfd.readouterr()
            assert bpy.ops.render.render(animation=True) == {"FINISHED"}
            rendered = [(f, after == nudged) for mode, f, nudged, after in seen if mode == "RENDER"]
            assert rendered == [(1, True), (2, True), (3, True)]      # the nudge stands: nothing written
            assert capfd.readouterr().out.count(L.RENDER_SKIP) == 1     # said once per render
            seen.clear()
            scene.frame_set(2)                                          # the viewport: solved as before
            assert [(mode, after == nudged) for mode, _, nudged, after in seen] == [("VIEWPORT", False)]
    finally:
        handlers.remove(nudge)
        handlers.remove(look)


def test_bake_with_a_locked_f_curve_is_an_error_and_keys_nothing():
    rig, _ = add("QUADRUPED")
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 3
    head = rig.pose.bones["head"]
    head.keyframe_insert("rotation_euler", frame=1)
    for fc in K.action_fcurves(rig):
        fc.lock = True
    keys = {(fc.data_path, fc.array_index): [tuple(k.co) for k in fc.keyframe_points] for fc in K.action_fcurves(rig)}
    bpy.context.view_layer.objects.active = rig
    with pytest.raises(RuntimeError, match=r'locked against editing.*pose.bones\["head"\]'):
        bpy.ops.object.miniskeleton_bake_puppet()
    assert keys == {(fc.data_path, fc.array_index): [tuple(k.co) for k in fc.keyframe_points]
                    for fc in K.action_fcurves(rig)}
