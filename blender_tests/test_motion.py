"""pose.miniskeleton_add_motion and render.miniskeleton_make_video in real Blender: roles on a
generated quadruped and biped, walk phases measured on the feet, head shake, appending, MP4."""

import math
import re
import shutil
import subprocess
from types import SimpleNamespace

import bpy
import numpy as np
import pytest
from mathutils import Matrix, Quaternion, Vector

from testkit import blender_session
from testkit import builders as B
from testkit import creature

ADDON = "bl_ext.user_default.miniskeleton"


def addon_module(name: str):
    """The installed add-on's module ``name``."""
    import importlib

    return importlib.import_module(f"{ADDON}.{name}")


def keying():
    """motion.keying: the keys a motion wrote (last_key_frame, keyed_rotation_bones)."""
    return addon_module("motion.keying")


def planning():
    """motion.planning: the skeleton the core reads, the roles it found."""
    return addon_module("motion.planning")


def common_keys():
    """common.keys: an object's F-curves (action_fcurves)."""
    return addon_module("common.keys")


def skeleton_arrays(arm):
    """(names, heads, tails, parents, rest) as the operator reads them."""
    common_armatures = __import__(ADDON + ".common.armatures", fromlist=["armatures"])
    bones = common_armatures.armature_bones(arm)
    return bones, planning().rest_matrices(arm, bones.names)


def biped_rig():
    """A human facing -Y, arms down: hips, spine, chest, neck, head; clavicle..hand; thigh..toe."""
    bones = [("hips", (0, 0, 1.0), (0, 0, 1.1), None, False),
             ("spine", (0, 0, 1.1), (0, 0, 1.3), "hips", True),
             ("chest", (0, 0, 1.3), (0, 0, 1.5), "spine", True),
             ("neck", (0, 0, 1.5), (0, 0, 1.6), "chest", True),
             ("head", (0, 0, 1.6), (0, 0, 1.8), "neck", True)]
    for s, x in (("L", 1), ("R", -1)):
        bones += [(f"shoulder.{s}", (0.02 * x, 0, 1.45), (0.18 * x, 0, 1.45), "chest", False),
                  (f"upper_arm.{s}", (0.18 * x, 0, 1.45), (0.2 * x, 0, 1.17), f"shoulder.{s}", True),
                  (f"forearm.{s}", (0.2 * x, 0, 1.17), (0.21 * x, -0.02, 0.92), f"upper_arm.{s}", True),
                  (f"hand.{s}", (0.21 * x, -0.02, 0.92), (0.21 * x, -0.02, 0.75), f"forearm.{s}", True),
                  (f"thigh.{s}", (0.1 * x, 0, 1.0), (0.1 * x, -0.02, 0.52), "hips", False),
                  (f"shin.{s}", (0.1 * x, -0.02, 0.52), (0.1 * x, 0, 0.08), f"thigh.{s}", True),
                  (f"foot.{s}", (0.1 * x, 0, 0.08), (0.1 * x, -0.14, 0.02), f"shin.{s}", True),
                  (f"toe.{s}", (0.1 * x, -0.14, 0.02), (0.1 * x, -0.2, 0.02), f"foot.{s}", True)]
    return B.armature("Biped", bones)


def ik_exported_rig(invented_tails=False):
    """A game-style biped as exported from an IK set-up (the structure of the Quaternius and
    RobotExpressive rigs, not their data; as the Rust test rig ``roles::tests::ik_biped``): the
    feet and knee pole targets hang off a ground root bone, the leg chains stop at the ankle
    (with ``invented_tails``, every tail is a short stub as glTF importers make them and the
    shins end at the knee), long ears, T-posed arms whose clavicle rises. Faces -Y."""
    bones = [("Root", (0, 0.2, 0), (0, 0.2, 0.35), None),
             ("Body", (0, 0.05, 0.95), (0, 0.05, 1.2), "Root"),
             ("Hips", (0, 0.25, 0.8), (0, 0.3, 1.1), "Body"),
             ("Abdomen", (0, 0.3, 1.1), (0, 0.27, 1.4), "Hips"),
             ("Torso", (0, 0.27, 1.4), (0, 0.2, 1.7), "Abdomen"),
             ("Neck", (0, 0.1, 1.95), (0, -0.05, 2.05), "Torso"),
             ("Head", (0, -0.05, 2.05), (0, -0.2, 2.4), "Neck")]
    for s, x in (("L", 1), ("R", -1)):
        knee = (0.35 * x, 0.2, 0.55)
        bones += [(f"Ear1.{s}", (0.24 * x, -0.2, 2.3), (0.36 * x, -0.2, 2.6), "Head"),
                  (f"Ear2.{s}", (0.36 * x, -0.2, 2.6), (0.43 * x, -0.35, 3.5), f"Ear1.{s}"),
                  (f"Shoulder.{s}", (0.17 * x, 0.22, 1.65), (0.37 * x, 0.22, 1.82), "Torso"),
                  (f"UpperArm.{s}", (0.37 * x, 0.22, 1.82), (1.2 * x, 0.18, 1.82), f"Shoulder.{s}"),
                  (f"LowerArm.{s}", (1.2 * x, 0.18, 1.82), (1.74 * x, 0.16, 1.85), f"UpperArm.{s}"),
                  (f"Hand.{s}", (1.74 * x, 0.16, 1.85), (2.2 * x, 0.15, 1.88), f"LowerArm.{s}"),
                  (f"UpperLeg.{s}", (0.34 * x, 0.22, 0.97), knee, "Body"),
                  (f"LowerLeg.{s}", knee, (0.35 * x, 0.2, 0.4) if invented_tails else (0.35 * x, 0.25, 0.13),
                   f"UpperLeg.{s}"),
                  (f"Foot.{s}", (0.35 * x, 0.28, 0.04), (0.35 * x, -0.07, 0.04), "Root"),
                  (f"PoleTarget.{s}", (0.35 * x, -1.6, 0.6), (0.35 * x, -1.6, 0.95), "Root")]
    if invented_tails:
        bones = [(n, h, tuple(np.add(h, 0.006 * np.subtract(t, h) / np.linalg.norm(np.subtract(t, h)))), p)
                 for n, h, t, p in bones]
    return B.armature("GameRig", [(n, h, t, p, False) for n, h, t, p in bones])


def roles_by_name(arm):
    import miniskeleton_core as core

    bones, _ = skeleton_arrays(arm)
    r = core.detect_roles(bones.heads, bones.tails, bones.parents, names=bones.names)
    n = bones.names
    legs = {(("front" if leg.group == 0 else "back"), leg.side): [n[i] for i in leg.bones]
            for leg in r.legs}
    return r, n, legs


def add_motion(arm, **props):
    B.set_active(arm)
    return bpy.ops.pose.miniskeleton_add_motion(**props)


def tails_over_frames(arm, names, frames):
    """{bone: (len(frames), 3) world tail positions}."""
    scene = bpy.context.scene
    out = {n: [] for n in names}
    m = arm.matrix_world
    for f in frames:
        scene.frame_set(f)
        for n in names:
            out[n].append(tuple(m @ arm.pose.bones[n].tail))
    return {n: np.array(v) for n, v in out.items()}


# ---------------------------------------------------------------- roles


def test_roles_on_generated_quadruped():
    arm = creature.build_armature()
    r, n, legs = roles_by_name(arm)
    assert r.plan == "quadruped"
    assert [n[i] for i in r.spine] == ["spine", "chest"]
    assert [n[i] for i in r.neck] == ["neck"]
    assert n[r.head] == "head"
    assert sorted(n[i] for i in r.head_extras) == ["ear.L", "ear.R", "jaw"]
    assert [n[i] for i in r.tail] == ["tail.001", "tail.002", "tail.003"]
    assert legs == {("front", "L"): ["upper_arm.L", "forearm.L", "hand.L"],
                    ("front", "R"): ["upper_arm.R", "forearm.R", "hand.R"],
                    ("back", "L"): ["thigh.L", "shin.L", "foot.L"],
                    ("back", "R"): ["thigh.R", "shin.R", "foot.R"]}
    assert np.allclose(r.forward, (0, -1, 0), atol=1e-3)


def test_roles_on_generated_biped_and_the_operator_reports_them(capsys):
    arm = biped_rig()
    r, n, legs = roles_by_name(arm)
    assert r.plan == "biped"
    assert [n[i] for i in r.spine] == ["hips", "spine", "chest"]
    assert n[r.head] == "head"
    assert legs[("front", "L")][:3] == ["thigh.L", "shin.L", "foot.L"]
    assert legs[("front", "R")][:3] == ["thigh.R", "shin.R", "foot.R"]
    assert sorted(n[a.bones[1]] for a in r.arms) == ["upper_arm.L", "upper_arm.R"]
    assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
    printed = capsys.readouterr().out
    assert "head: head" in printed and "leg L: thigh.L, shin.L, foot.L" in printed, printed


def test_no_legs_or_no_head_is_refused_clearly():
    arm = B.chain("Pole", count=4)
    arm.location.z = 2.0
    with pytest.raises(RuntimeError, match="no legs"):
        add_motion(arm, motion="WALK")
    assert arm.animation_data is None or not common_keys().action_fcurves(arm)
    # (one leg connected: a rig made in Blender, whose tails are the rigger's own)
    legs_only = B.armature("Stool", [("seat", (-0.3, 0, 1), (0.3, 0, 1), None, False),
                                     ("leg.L", (0.3, 0, 1), (0.3, 0, 0), "seat", True),
                                     ("leg.R", (-0.3, 0, 1), (-0.3, 0, 0), "seat", False)])
    with pytest.raises(RuntimeError, match="no head"):
        add_motion(legs_only, motion="HEAD_SHAKE")
    two = B.armature("Pair", [("a", (0, 0, 1), (0, 0, 0), None, False), ("b", (0, 0, 1), (0, 0, 2), "a", False)])
    with pytest.raises(RuntimeError, match="Armature 'Pair' has too few deform bones for a motion"):
        add_motion(two, motion="HEAD_SHAKE")
    assert two.animation_data is None



def test_armature_linked_from_a_library_gets_no_keys_and_a_clear_error(tmp_path):
    """Keys go to the armature object's action; an object linked from another .blend is
    read-only, so the motion is refused with the reason before any key is written."""
    local = biped_rig()
    linked = B.link_from_library(local, tmp_path / "rig.blend")
    bpy.context.collection.objects.link(linked)
    with pytest.raises(RuntimeError, match=r"Object '.*' is linked from rig.blend .*Make Local"):
        add_motion(linked, motion="WALK")
    assert linked.animation_data is None


def test_action_linked_from_a_library_gets_no_keys_and_a_clear_error(tmp_path):
    """A local armature playing an action linked from another .blend: its keys cannot change
    (Blender skips them with a console warning), so the motion is refused before the pose or
    the timeline is touched."""
    arm = biped_rig()
    action = bpy.data.actions.new("Library walk")
    arm.animation_data_create()
    arm.animation_data.action = B.link_from_library(action, tmp_path / "actions.blend")
    frame_end = bpy.context.scene.frame_end
    with pytest.raises(RuntimeError, match=r"Action 'Library walk' is linked from actions.blend .*Action Editor"):
        add_motion(arm, motion="WALK")
    assert keying().last_key_frame(arm) is None and bpy.context.scene.frame_end == frame_end
    assert all(pb.matrix_basis == Matrix() for pb in arm.pose.bones)


def test_driven_bones_are_named_in_a_warning(capfd):
    """A driver overrides its bone's keys, so the motion would not show there: say which."""
    arm = biped_rig()
    driver = arm.pose.bones["shin.L"].driver_add("rotation_quaternion", 1).driver
    driver.expression = "0.2"
    assert add_motion(arm, motion="WALK") == {"FINISHED"}
    assert "1 keyed bone(s) have rotation drivers, which override their keys: shin.L" in capfd.readouterr().out

def test_an_armature_in_rest_position_gets_the_keys_and_a_warning(capfd):
    """In Rest Position the keys are written but nothing moves: say so, and how to see them."""
    arm = biped_rig()
    arm.data.pose_position = "REST"
    capfd.readouterr()
    assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
    assert "shows its Rest Position, so the motion does not show: switch to Pose Position" \
        in "".join(capfd.readouterr())
    assert keying().keyed_rotation_bones(arm) >= {"thigh.L", "shin.R"}
    arm.data.pose_position = "POSE"
    capfd.readouterr()
    assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
    assert "Rest Position" not in "".join(capfd.readouterr())


def test_roles_of_a_rig_with_hundreds_of_hair_bones_are_listed_shortly():
    """The console's role list names a dozen bones of a long role and gives the count (a rig
    with 1000 hair bones printed all 1000 names on the head's line)."""
    names = ["hips", "head"] + [f"hair{k}" for k in range(1000)] + ["thigh.L", "thigh.R"]
    roles = SimpleNamespace(plan="biped", root=0, spine=[0], neck=[], head=1, head_extras=list(range(2, 1002)),
                            tail=[], legs=[SimpleNamespace(bones=[1002], side="L", group=0),
                                           SimpleNamespace(bones=[1003], side="R", group=0)], arms=[], notes=[])
    lines = planning().describe_roles(roles, names)
    head = next(line for line in lines if line.startswith("head:"))
    assert head == "head: head (+ " + ", ".join(f"hair{k}" for k in range(12)) + " ... (1000 in all))", head
    assert "leg L: thigh.L" in lines


def test_bones_held_by_constraints_are_named_in_a_warning(capfd):
    """An IK constraint (or a Copy Rotation...) overrides the keys of its bone and, for IK, of
    the chain above it, so the walk would not show there: say which, and through which
    constraint. Muted, powerless, target-less and location-only constraints are not named."""
    arm = biped_rig()
    B.set_active(arm)
    bpy.ops.object.mode_set(mode="EDIT")
    target = arm.data.edit_bones.new("foot_ik.L")
    target.head, target.tail, target.use_deform = (0.1, 0, 0.08), (0.1, 0.2, 0.08), False
    bpy.ops.object.mode_set(mode="OBJECT")
    pose = arm.pose.bones
    ik = pose["shin.L"].constraints.new("IK")
    ik.target, ik.subtarget, ik.chain_count = arm, "foot_ik.L", 2
    one = pose["shin.R"].constraints.new("IK")                      # a chain of one: its bone only
    one.target, one.subtarget, one.chain_count = arm, "foot_ik.L", 1
    copy = pose["upper_arm.R"].constraints.new("COPY_ROTATION")
    copy.target, copy.subtarget = arm, "foot_ik.L"
    muted = pose["upper_arm.L"].constraints.new("COPY_ROTATION")
    muted.target, muted.subtarget, muted.mute = arm, "foot_ik.L", True
    pose["forearm.L"].constraints.new("DAMPED_TRACK")                # no target: not evaluated
    weak = pose["forearm.R"].constraints.new("COPY_ROTATION")
    weak.target, weak.subtarget, weak.influence = arm, "foot_ik.L", 0.0
    pose["foot.R"].constraints.new("LIMIT_LOCATION")
    capfd.readouterr()
    assert add_motion(arm, motion="WALK") == {"FINISHED"}
    out = "".join(capfd.readouterr())
    assert ("4 keyed bone(s) follow constraints that override their keys: shin.L (IK), shin.R (IK), "
            "thigh.L (IK of shin.L), upper_arm.R (Copy Rotation)") in out, out
    pose["shin.R"].constraints.remove(one)
    # An IK chain of length 0 reaches up to the root.
    whole = pose["hand.L"].constraints.new("IK")
    whole.target, whole.subtarget, whole.chain_count = arm, "foot_ik.L", 0
    assert add_motion(arm, motion="WALK") == {"FINISHED"}
    out = "".join(capfd.readouterr())
    assert ("7 keyed bone(s) follow constraints that override their keys: chest (IK of hand.L), "
            "forearm.L (IK of hand.L), shin.L (IK), spine (IK of hand.L)") in out, out


# ---------------------------------------------------------------- motions


def test_walk_feet_alternate_in_phase():
    import miniskeleton_core as core

    arm = creature.build_armature()
    scene = bpy.context.scene
    assert add_motion(arm, motion="WALK", cycles=2) == {"FINISHED"}
    bones, rest = skeleton_arrays(arm)
    fpc = int(core.make_motion(bones.heads, bones.tails, bones.parents, rest, "WALK",
                               names=bones.names, fps=scene.render.fps).frames_per_cycle)
    start = scene.frame_start
    assert scene.frame_end >= start + 2 * fpc
    feet = ["hand.L", "hand.R", "foot.L", "foot.R"]
    pos = tails_over_frames(arm, feet, range(start, start + fpc))
    peak = {}
    for name in feet:
        z = pos[name][:, 2]
        assert z.max() - z.min() > 0.05, f"{name} does not lift: {z.max() - z.min():.3f}"
        peak[name] = int(np.argmax(z)) / fpc
    for left, right in (("hand.L", "hand.R"), ("foot.L", "foot.R")):
        d = abs(peak[left] - peak[right]) % 1.0
        assert abs(min(d, 1 - d) - 0.5) < 0.1, (left, right, peak)
    # the root moved forward (-Y) over the walk
    travelled = tails_over_frames(arm, ["spine"], [start, start + 2 * fpc])["spine"]
    assert travelled[1][1] < travelled[0][1] - 0.5


def test_mirrored_armature_walks_as_the_mirror_image_of_its_twin(capfd):
    """An armature mirrored by a negative scale (its bones where its unmirrored twin's are) walks
    as the mirror image of the twin's walk, left and right swapped: its rest frames are not
    rotations, and read as they are they made a different, wrong motion. An unevenly scaled
    armature gets a warning (its bones shear as they turn)."""
    def walk(matrix):
        blender_session.reset_scene()
        arm = creature.build_armature()
        if matrix is not None:
            B.place_armature_keep_bones(arm, matrix)
        assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
        scene = bpy.context.scene
        names = [b.name for b in arm.data.bones]
        return names, tails_over_frames(arm, names, range(scene.frame_start, scene.frame_end + 1, 2))

    names, twin = walk(None)
    capfd.readouterr()
    _, mirrored = walk(Matrix.Diagonal((-1.0, 1.0, 1.0, 1.0)))
    assert "scaled unevenly" not in "".join(capfd.readouterr())
    swap = {n: n[:-2] + {".L": ".R", ".R": ".L"}.get(n[-2:], n[-2:]) for n in names}
    for n in names:
        np.testing.assert_allclose(mirrored[n], twin[swap[n]] * [-1, 1, 1], atol=1e-4, err_msg=n)
    capfd.readouterr()
    walk(Matrix.Diagonal((1.0, 2.0, 0.5, 1.0)))
    assert "is scaled unevenly (1, 2, 0.5)" in "".join(capfd.readouterr())
    walk(Matrix.Diagonal((1.0, 1.0, 1.1, 1.0)))    # a tenth is enough to shear visibly
    assert "is scaled unevenly (1, 1, 1.1)" in "".join(capfd.readouterr())


@pytest.mark.parametrize("rig, scale, twin", [("creature", 1e-15, 1e-3), ("creature", 1e15, 1e4),
                                             ("creature", 1e25, 1e4), ("creature", -1e-15, -1e-3),
                                             ("game rig", 1e25, 1e3), ("game rig", 1e4, 1e3)])
def test_an_armature_at_any_scale_gets_the_keys_of_its_twin(rig, scale, twin):
    """The walk's keys (rotations, and the root bone's location in its own space) depend on the
    armature's size only through the cadence, which follows the leg length in metres between
    0.3 and 2.3 m and is clamped outside: a rig 1e15 times the creature's size walks as one
    1e4 times it (the x scale's sign mirrors the rig). Before: at 1e15 Add Motion stopped with
    a traceback (the root's frame inverted twice in single precision), at 1e25 it was refused
    as "flat" (the core's squared lengths overflowed), and a mirror at 1e-15 walked as if
    unmirrored (its single-precision determinant underflowed to 0). A game rig's feet riding on
    the root are keyed in armature units: from 1e20 up they stood still (the scale, read in
    single precision, was inf), and its arms swung from the clavicle at some sizes and from the
    upper arm at others (its invented tails are stubs of one length, and the longer of the two
    went by rounding)."""
    def keys(scale):
        blender_session.reset_scene()
        arm = creature.build_armature() if rig == "creature" else ik_exported_rig(invented_tails=True)
        arm.scale = scale
        bpy.context.view_layer.update()
        assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
        return action_keys(arm)

    want = keys((twin, abs(twin), abs(twin)))
    got = keys((scale, abs(scale), abs(scale)))
    assert got.keys() == want.keys()
    for path, k in want.items():
        np.testing.assert_allclose(got[path], k, rtol=1e-4, atol=1e-5, err_msg=str(path))


def test_a_centimetre_scene_walks_as_its_metre_twin():
    """The cadence follows the leg length in metres, and the scene's Unit Scale says how long a
    unit is: a creature 100 times larger in a scene of 0.01 m units (Unreal's centimetres) gets
    the keys its twin gets in metres (before, its 100-unit legs walked at the slowest cadence,
    as if 100 m long: 40 frames a cycle instead of 25). The root's travel, keyed in armature
    units, is the same too, since the armature is scaled with it."""
    def keys(scale, unit):
        blender_session.reset_scene()
        bpy.context.scene.unit_settings.scale_length = unit
        arm = creature.build_armature()
        arm.scale = (scale,) * 3
        bpy.context.view_layer.update()
        assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
        return action_keys(arm)

    want, got = keys(1.0, 1.0), keys(100.0, 0.01)
    assert got.keys() == want.keys()
    for path, k in want.items():
        np.testing.assert_allclose(got[path], k, rtol=1e-4, atol=1e-5, err_msg=str(path))


def test_an_armature_far_from_the_world_origin_gets_the_keys_it_gets_at_the_origin():
    """The walk does not depend on where the rig stands. 1e5 m and more from the world origin,
    single-precision world heads are 8 mm apart, and the creature's walk keys there differed
    from its keys at the origin by up to 0.007; heads now go to the core relative to the
    armature's origin, taken off in double precision."""
    def keys(location):
        blender_session.reset_scene()
        arm = creature.build_armature()
        arm.location = location
        bpy.context.view_layer.update()
        assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
        return action_keys(arm)

    want, got = keys((0.0, 0.0, 0.0)), keys((1e6, -5e5, 2e5))
    assert got.keys() == want.keys()
    for path, k in want.items():
        np.testing.assert_allclose(got[path], k, atol=1e-6, err_msg=str(path))


@pytest.mark.parametrize("invented_tails, scale", [(False, 100.0), (True, 100.0), (True, -50.0)])
def test_feet_hanging_off_the_root_walk_with_their_legs(invented_tails, scale, capsys):
    """Game rigs exported from an IK set-up (Quaternius characters, RobotExpressive) hang each
    foot off the ground root bone, with no constraint left to make it follow the leg: the walk
    keys the feet's location so that, in Blender's own evaluation, each foot stays fixed to its
    shin, lifts in its swing and alternates with the other. The T-posed arms (clavicle rising) are
    arms, so the torso is spine and the neck is the neck alone. Armature scaled by 100 (as the
    robot imports), or mirrored and scaled by 50: locations are in the armature's units. A
    head shake appended afterwards puts the feet back to rest."""
    arm = ik_exported_rig(invented_tails)
    B.place_armature_keep_bones(arm, Matrix.Diagonal((scale, abs(scale), abs(scale), 1.0)))
    r, n, legs = roles_by_name(arm)
    assert legs[("front", "L")] == ["UpperLeg.L", "LowerLeg.L", "Foot.L"]
    assert sorted((n[a], n[b]) for a, b in r.riders) == [("Foot.L", "LowerLeg.L"), ("Foot.R", "LowerLeg.R")]
    assert [n[i] for i in r.neck] == ["Neck"] and n[r.spine[-1]] == "Torso"
    assert len(r.arms) == 2

    assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
    assert "feet hanging off the root bone, not their legs (an IK rig without its constraints): " \
           "Foot.L, Foot.R" in capsys.readouterr().out
    scene = bpy.context.scene
    end = int(keying().last_key_frame(arm))
    leg = 0.93   # hip height above the foot (world units: the bones keep their world size)
    peaks = []
    for s in "LR":
        offsets, z = B.riding(arm, f"Foot.{s}", f"LowerLeg.{s}", range(scene.frame_start, end + 1))
        spread = np.ptp(offsets, axis=0).max() * abs(scale)   # armature units -> world
        assert spread < 1e-4 * leg, f"Foot.{s} slides on its shin by {spread:.4f}"
        assert np.ptp(z) > 0.05 * leg, f"Foot.{s} does not lift: {np.ptp(z):.2f}"
        peaks.append(int(np.argmax(z)) / (end - scene.frame_start))
    d = abs(peaks[0] - peaks[1])
    assert abs(min(d, 1 - d) - 0.5) < 0.1, peaks

    assert add_motion(arm, motion="HEAD_SHAKE", duration=1.0) == {"FINISHED"}
    start = end + 1
    for f in (start + round(scene.render.fps * 0.25), int(keying().last_key_frame(arm))):
        scene.frame_set(f)
        for s in "LR":
            assert tuple(arm.pose.bones[f"Foot.{s}"].location) == pytest.approx((0, 0, 0), abs=1e-6)


def test_a_walk_appended_to_one_ending_mid_stride_bobs_through_the_same_heights():
    """The root continues from where the walk left it but without its last frame's bob: a walk
    appended to one that ends mid-stride rises and sinks through the same heights (a biped's:
    a walk on four legs keeps its body level)."""
    arm = biped_rig()
    scene = bpy.context.scene
    assert add_motion(arm, motion="WALK", cycles=1.25) == {"FINISHED"}
    first_end = int(keying().last_key_frame(arm))
    assert add_motion(arm, motion="WALK", cycles=1, blend=0.0) == {"FINISHED"}
    root = next(pb for pb in arm.pose.bones if pb.parent is None)

    def heights(frames):
        out = []
        for f in frames:
            scene.frame_set(f)
            out.append((arm.matrix_world @ root.head).z)
        return np.array(out)

    first = heights(range(scene.frame_start, first_end + 1))
    second = heights(range(first_end + 1, int(keying().last_key_frame(arm)) + 1))
    bob = np.ptp(first)
    assert bob > 1e-3
    assert abs(first.min() - second.min()) < 0.05 * bob and abs(first.max() - second.max()) < 0.05 * bob, \
        (first.min(), first.max(), second.min(), second.max())


def test_the_root_stays_at_rest_through_a_head_shake_before_an_appended_walk():
    """The root gets location keys only from the walk; appended to a head shake, it holds its
    rest place through the shake (the walk's first key, with its bob, reached back)."""
    arm = creature.build_armature()
    scene = bpy.context.scene
    assert add_motion(arm, motion="HEAD_SHAKE", duration=1.0) == {"FINISHED"}
    shake_end = int(keying().last_key_frame(arm))
    assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
    root = next(pb for pb in arm.pose.bones if pb.parent is None)
    assert any(fc.data_path == root.path_from_id("location") for fc in common_keys().action_fcurves(arm))
    for f in range(scene.frame_start, shake_end + 1):
        scene.frame_set(f)
        assert tuple(root.location) == pytest.approx((0, 0, 0), abs=1e-6), f


def test_feet_hanging_off_the_root_stay_at_rest_before_a_walk_appended_to_a_head_shake():
    """The feet of an IK-exported rig get location keys only from the walk; appended to a head
    shake, they hold their rest place through the shake (the walk's first key would reach back
    to the rig's first frame)."""
    arm = ik_exported_rig()
    scene = bpy.context.scene
    assert add_motion(arm, motion="HEAD_SHAKE", duration=1.0) == {"FINISHED"}
    shake_end = int(keying().last_key_frame(arm))
    assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
    moved = set()
    for f in range(scene.frame_start, int(keying().last_key_frame(arm)) + 1):
        scene.frame_set(f)
        for s in "LR":
            loc = tuple(arm.pose.bones[f"Foot.{s}"].location)
            if f <= shake_end:
                assert loc == pytest.approx((0, 0, 0), abs=1e-6), (f, s, loc)
            elif max(map(abs, loc)) > 1e-3:
                moved.add(s)
    assert moved == {"L", "R"}


@pytest.mark.parametrize("before", ["nothing", "earlier keys", "keys in the range", "later keys"])
@pytest.mark.parametrize("path", ["rotation_quaternion", "rotation_euler"])
def test_a_key_series_is_the_keys_keyframe_insert_makes_one_by_one(before, path):
    """Add Motion and Bake Puppet Animation write each bone's keys as one series (keying a frame
    at a time slowed as the curves grew: 100 walk cycles took 11 s, now 0.3 s). The series is
    the same keys, handles, interpolation, key types, easing and group as keyframe_insert makes
    one frame at a time, after a curve's earlier keys, over keys in its range or before later
    ones (the rigger's keys there constant, breakdowns, eased in: new keys are Blender's kind,
    not theirs)."""
    keys = __import__(ADDON + ".common.keys", fromlist=["keys"])
    rng = np.random.default_rng(5)
    values = rng.normal(size=(21, 4 if path == "rotation_quaternion" else 3))
    frames = range(10, 31)
    made = []
    for how in ("one by one", "series"):
        arm = biped_rig()
        pb = arm.pose.bones["thigh.L"]
        pb.rotation_mode = "QUATERNION" if path == "rotation_quaternion" else "XZY"
        for f in {"earlier keys": (1, 4), "keys in the range": (12, 15, 40), "later keys": (40, 45)}.get(before, ()):
            setattr(pb, path, [0.3] * len(values[0]))
            pb.keyframe_insert(path, frame=f, group="Mine")
        for fc in keys.action_fcurves(arm):   # the rigger's keys are not of Blender's new kind
            for kp in fc.keyframe_points:
                kp.interpolation, kp.type, kp.easing = "CONSTANT", "BREAKDOWN", "EASE_IN"
        if how == "series":
            keys.key_series(pb, path, frames, values, group=pb.name)
        else:
            for f, v in zip(frames, values):
                setattr(pb, path, v.tolist())
                pb.keyframe_insert(path, frame=f, group=pb.name)
        assert np.allclose(tuple(getattr(pb, path)), values[-1])
        made.append([(fc.data_path, fc.array_index, fc.group.name,
                      [(*kp.co, *kp.handle_left, *kp.handle_right) for kp in fc.keyframe_points],
                      [(kp.interpolation, kp.handle_left_type, kp.handle_right_type, kp.type, kp.easing)
                       for kp in fc.keyframe_points])
                     for fc in keys.action_fcurves(arm)])
    assert [c[:3] + c[4:] for c in made[0]] == [c[:3] + c[4:] for c in made[1]]
    for one, series in zip(made[0], made[1]):
        np.testing.assert_allclose(series[3], one[3], atol=1e-6)


@pytest.mark.parametrize("mode", ["AXIS_ANGLE", "ZXY"])
def test_keys_in_every_rotation_mode_interpolate_the_short_way(mode):
    """Keys in a bone's own rotation mode turn it as quaternion keys do: the same rotation at
    every frame, and between frames (motion blur, a retimed strip) nearly the same, also from
    the end of a Walk into a Head Shake after it. Before: axis-angle keys took each frame's
    axis as ``to_axis_angle`` gave it, so a swing through rest went from (a, n) to (a, -n),
    whose components pass through a zero axis: halfway between two frames the bone was off
    the short way by more than the whole step."""
    def motion(mode):
        blender_session.reset_scene()
        scene = bpy.context.scene
        arm = creature.build_armature()
        for pb in arm.pose.bones:
            pb.rotation_mode = mode
        assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
        assert add_motion(arm, motion="HEAD_SHAKE", cycles=1) == {"FINISHED"}
        end = int(keying().last_key_frame(arm))
        keyed = {round(kp.co[0]) for fc in common_keys().action_fcurves(arm) for kp in fc.keyframe_points}
        turns = []
        for f in range(scene.frame_start, end + 1):
            for sub in (0.0, 0.5):
                scene.frame_set(f, subframe=sub)
                turns.append([pb.matrix_basis.to_quaternion() for pb in arm.pose.bones])
        return turns, keyed

    (want, keyed), (got, _) = motion("QUATERNION"), motion(mode)
    assert len(got) == len(want) > 100
    start = bpy.context.scene.frame_start
    # mathutils' single-precision quaternions read angles near zero coarsely (the creature's
    # small turns come out as multiples of 2^-10 radians, 0.00098 and 0.00195): slack for that
    SLACK = 2.5e-3
    worst_step = 0.0
    for k in range(0, len(got) - 2, 2):
        for b in range(len(got[k])):
            step = got[k][b].rotation_difference(got[k + 2][b]).angle
            worst_step = max(worst_step, step)
            # on a key the same rotation; between the walk's last key and the head shake's
            # first (the blend) the modes interpolate, as between subframes
            on_key = got[k][b].rotation_difference(want[k][b]).angle
            assert on_key < 1e-4 if start + k // 2 in keyed else on_key <= 0.75 * step + SLACK, (
                mode, k // 2, b, on_key, step)
            off = got[k + 1][b].rotation_difference(want[k + 1][b]).angle
            # (the modes interpolate differently: an axis-angle key's four numbers interpolate
            # one by one, so a planted leg turning about a changing axis near rest is 0.65 of a
            # 0.017 step off halfway; jerks through a zero axis were 0.16 off the short way in a
            # 0.13 step, 1.2 of it)
            assert off <= 0.75 * step + SLACK, (mode, k // 2, b, off, step)
    assert worst_step > 0.05            # the motion turns bones by a few degrees a frame


@pytest.mark.parametrize("mode", ["QUATERNION", "AXIS_ANGLE", "XYZ"])
def test_a_bone_spinning_a_full_turn_gets_keys_that_turn_one_way_round(mode):
    """Rotations handed over with w >= 0 (as a matrix's ``to_quaternion`` gives them) jump to
    the other hemisphere half-way through a full spin; each key continues from the one before
    it, so every step between keys is the short 15 degrees, never the long way back."""
    keys = __import__(ADDON + ".common.keys", fromlist=["keys"])
    arm = biped_rig()
    pb = arm.pose.bones["head"]
    pb.rotation_mode = mode
    turn = np.radians(np.arange(0, 361, 15))
    quats = [Matrix.Rotation(a, 4, "Z").to_quaternion() for a in turn]
    assert min(q.w for q in quats) >= 0.0            # the input does jump hemispheres
    path, values = keys.rotation_series(pb, quats)
    for k, (q, v) in enumerate(zip(quats, values)):
        setattr(pb, path, v)
        got = pb.matrix_basis.to_quaternion()
        assert got.rotation_difference(q).angle < 1e-5, (k, v)
    if mode == "QUATERNION":
        steps = [Quaternion(a).dot(Quaternion(b)) for a, b in zip(values, values[1:])]
        assert min(steps) > np.cos(np.radians(15) / 2) - 1e-6, steps
    elif mode == "AXIS_ANGLE":
        assert np.allclose(np.diff([v[0] for v in values]), np.radians(15), atol=1e-5)
    else:
        assert np.allclose(np.diff([v[2] for v in values]), np.radians(15), atol=1e-5)


@pytest.mark.parametrize("mode, channel", [("QUATERNION", -1), ("XYZ", -1), ("XYZ", 2)])
def test_a_motion_continues_the_short_way_from_a_key_a_full_turn_round(mode, channel):
    """A bone keyed at rest written the other way round (the quaternion -1, or Euler z = 360
    degrees, as a rigger's spin or another tool leaves it) gets a motion whose keys continue
    from that value: between that key and the motion the bone stays near rest. Keys that began
    from +1 or 0 would send it half a turn (quaternion) or a whole turn (Euler) round between them.
    Also when only the turned channel is keyed (``channel``; -1: all): the others hold their value."""
    blender_session.reset_scene()
    scene = bpy.context.scene
    arm = creature.build_armature()
    pb = arm.pose.bones["head"]
    pb.rotation_mode = mode
    if mode == "QUATERNION":
        pb.rotation_quaternion = (-1.0, 0.0, 0.0, 0.0)
        path = "rotation_quaternion"
    else:
        pb.rotation_euler = (0.0, 0.0, 2 * np.pi)
        path = "rotation_euler"
    pb.keyframe_insert(path, index=channel, frame=scene.frame_start)
    assert len(common_keys().action_fcurves(arm)) == (1 if channel >= 0 else len(getattr(pb, path)))
    assert add_motion(arm, motion="HEAD_SHAKE", cycles=1) == {"FINISHED"}
    end = int(keying().last_key_frame(arm))
    worst = 0.0
    for f in range(scene.frame_start, end + 1):
        for sub in (0.0, 0.25, 0.5, 0.75):
            scene.frame_set(f, subframe=sub)
            worst = max(worst, pb.matrix_basis.to_quaternion().angle)
    assert 0.1 < worst < np.radians(60)   # the shake turns the head, never round


def test_head_shake_moves_head_not_feet_and_walk_appends():
    arm = creature.build_armature()
    scene = bpy.context.scene
    assert add_motion(arm, motion="HEAD_SHAKE", duration=1.0, cycles=2) == {"FINISHED"}
    end = keying().last_key_frame(arm)
    assert end == scene.frame_start + round(scene.render.fps * 1.0)
    frames = range(scene.frame_start, int(end) + 1)
    pos = tails_over_frames(arm, ["head", "jaw", "hand.L", "foot.R"], frames)
    assert np.ptp(pos["jaw"][:, 0]) > 0.1          # the snout swings sideways
    for foot in ("hand.L", "foot.R"):
        assert np.ptp(pos[foot], axis=0).max() < 1e-5
    paths = {fc.data_path for fc in common_keys().action_fcurves(arm)}
    assert 'pose.bones["head"].rotation_quaternion' in paths
    assert not any('"foot.L"' in p for p in paths)
    # appending: the walk starts after the shake; the action now holds both
    assert add_motion(arm, motion="WALK", cycles=1, blend=0.5) == {"FINISHED"}
    foot_w = next(fc for fc in common_keys().action_fcurves(arm)
                  if fc.data_path == 'pose.bones["foot.L"].rotation_quaternion' and fc.array_index == 0)
    keys = sorted(kp.co[:] for kp in foot_w.keyframe_points)
    assert keys[0] == (end, 1.0)      # the foot holds its rest pose until the walk starts
    assert keys[1][0] == end + round(0.5 * scene.render.fps)   # Blend: half a second later
    assert scene.frame_end >= keying().last_key_frame(arm)
    # Append off: a motion starts at the current frame, here past the others.
    scene.frame_set(300)
    assert add_motion(arm, motion="HEAD_SHAKE", duration=0.5, cycles=1, append=False) == {"FINISHED"}
    head = {kp.co[0] for fc in common_keys().action_fcurves(arm)
            if fc.data_path == 'pose.bones["head"].rotation_quaternion' for kp in fc.keyframe_points}
    shake_end = 300 + round(0.5 * scene.render.fps)
    assert {300, shake_end} <= head and max(head) == shake_end == scene.frame_end
    # keys are in the action the Dope Sheet / Graph Editor show, grouped by bone
    action = arm.animation_data.action
    assert action is not None and action.users >= 1
    groups = {fc.group.name for fc in common_keys().action_fcurves(arm) if fc.group}
    assert {"head", "foot.L", "thigh.R"} <= groups


def test_add_motion_with_a_mesh_active_keys_the_armature_it_is_parented_to():
    """With a mesh active that follows an armature by parenting only (no Armature modifier),
    Add Motion keys that armature."""
    body, arm = creature.build_body(subdivisions=0), creature.build_armature()
    body.parent = arm
    assert not any(m.type == "ARMATURE" for m in body.modifiers)
    B.set_active(body)
    assert bpy.ops.pose.miniskeleton_add_motion(motion="HEAD_SHAKE") == {"FINISHED"}
    assert any('"head"' in fc.data_path for fc in common_keys().action_fcurves(arm))
    assert body.animation_data is None


def test_appending_leaves_the_earlier_keys_as_they_were():
    """A motion appended to a walk that ends mid-stride, with the playhead elsewhere, adds keys
    after the walk and changes none of the walk's own (a hold key at the walk's end took the
    pose under the playhead)."""
    arm = creature.build_armature()
    scene = bpy.context.scene
    assert add_motion(arm, motion="WALK", cycles=1.25) == {"FINISHED"}
    before = action_keys(arm)
    scene.frame_set(scene.frame_start + 7)
    assert add_motion(arm, motion="HEAD_SHAKE") == {"FINISHED"}
    after = action_keys(arm)
    for key, co in before.items():
        assert np.array_equal(after[key][:len(co)], co), key
        assert (after[key][len(co):, 0] > co[-1, 0]).all(), key
    # The legs, mid-stride where the walk ends, are back at rest through the shake.
    walk_end = max(co[-1, 0] for co in before.values())
    legs = ("thigh.L", "upper_arm.R")
    for frame, at_rest in ((walk_end, False), (keying().last_key_frame(arm), True)):
        scene.frame_set(int(frame))
        turned = [arm.pose.bones[n].matrix_basis.to_quaternion().angle > 1e-3 for n in legs]
        assert turned == [not at_rest] * len(legs), (frame, turned)


def action_keys(arm):
    """{(data path, index): (keys, 2) array of (frame, value)} of the armature's action."""
    out = {}
    for fc in common_keys().action_fcurves(arm):
        co = np.empty(2 * len(fc.keyframe_points))
        fc.keyframe_points.foreach_get("co", co)
        out[fc.data_path, fc.array_index] = co.reshape(-1, 2)
    return out


def test_in_nla_tweak_mode_a_motion_goes_after_the_strips_keys_where_the_strip_shows_them():
    """Tweaking an NLA strip that starts at scene frame 101, the action's frame 1 is scene frame
    101. ``keyframe_insert`` maps the scene frame it is given, so the series written as arrays
    must map theirs too (they went to the scene's frame numbers, the first key 100 frames before
    the rest), and the motion is appended after the strip's last key in scene frames."""
    scene = bpy.context.scene
    twin = creature.build_armature("Twin")       # the same motions without the NLA
    assert add_motion(twin, motion="WALK", cycles=1) == {"FINISHED"}
    assert add_motion(twin, motion="HEAD_SHAKE", cycles=1) == {"FINISHED"}
    want, twin_end = action_keys(twin), scene.frame_end

    arm = creature.build_armature()
    scene.frame_end = 1
    assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
    ad = arm.animation_data
    track = ad.nla_tracks.new()
    strip = track.strips.new("walk", 101, ad.action)
    ad.action = None
    track.select = strip.select = True
    ad.nla_tracks.active = track
    ad.use_tweak_mode = True
    assert ad.use_tweak_mode and ad.action is strip.action
    assert add_motion(arm, motion="HEAD_SHAKE", cycles=1) == {"FINISHED"}
    got = action_keys(arm)
    assert got.keys() == want.keys()
    for path, keys in want.items():
        np.testing.assert_allclose(got[path], keys, atol=1e-6, err_msg=str(path))
    assert keying().last_key_frame(arm) == twin_end + 100
    assert scene.frame_end == twin_end + 100
    # the strip shows the shake 100 frames after the twin does, in tweak mode and after it
    names = ["head", "jaw", "hand.L"]
    at = [twin_end - 30, twin_end - 20, twin_end - 10]
    ref = tails_over_frames(twin, names, at)
    for tweak in (True, False):
        ad.use_tweak_mode = tweak
        pos = tails_over_frames(arm, names, [f + 100 for f in at])
        for n in names:
            np.testing.assert_allclose(pos[n], ref[n], atol=1e-5, err_msg=f"{n} tweak={tweak}")


def test_run_is_faster_and_keeps_going_after_walk():
    arm = biped_rig()
    assert add_motion(arm, motion="WALK", cycles=1) == {"FINISHED"}
    walk_end = keying().last_key_frame(arm)
    assert add_motion(arm, motion="RUN", cycles=2) == {"FINISHED"}
    assert keying().last_key_frame(arm) > walk_end
    hips = tails_over_frames(arm, ["hips"], [int(walk_end), int(keying().last_key_frame(arm))])["hips"]
    assert hips[1][1] < hips[0][1] - 0.5   # continued forward from where the walk ended


# ---------------------------------------------------------------- video


def probe(path):
    """(frames, width, height) of a movie: ffprobe when present, else Blender's movie reader."""
    if shutil.which("ffprobe"):
        out = subprocess.run(["ffprobe", "-v", "error", "-select_streams", "v:0", "-count_frames",
                              "-show_entries", "stream=nb_read_frames,width,height,codec_name",
                              "-of", "default=noprint_wrappers=1", str(path)],
                             capture_output=True, text=True, check=True).stdout
        d = dict(line.split("=", 1) for line in out.split())
        assert d["codec_name"] == "h264"
        return int(d["nb_read_frames"]), int(d["width"]), int(d["height"])
    clip = bpy.data.movieclips.load(str(path))
    return clip.frame_duration, clip.size[0], clip.size[1]


def keyed_cube(name, path):
    """A 1 m cube keyed at each (frame, location) of ``path``."""
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    ob = bpy.context.active_object
    ob.name = name
    for frame, loc in path:
        ob.location = loc
        ob.keyframe_insert("location", frame=frame)
    return ob


def corners(ob):
    """World corners of ``ob``'s bounding box, at the current frame."""
    return [ob.matrix_world @ Vector(c) for c in ob.bound_box]


def assert_in_view(scene, cam, points):
    """Every world point projects inside ``cam``'s frame (the scene's render size) and between
    its clipping distances."""
    from bpy_extras.object_utils import world_to_camera_view

    for q in points:
        p = world_to_camera_view(scene, cam, Vector(q))
        assert 0 <= p.x <= 1 and 0 <= p.y <= 1 and cam.data.clip_start < p.z < cam.data.clip_end, \
            (scene.frame_current, tuple(q), tuple(p))


def test_video_is_a_valid_mp4(tmp_path):
    body, arm = creature.build_body(subdivisions=0), creature.build_armature()
    B.select_for_parenting([body], arm)
    assert bpy.ops.object.miniskeleton_auto_weights(method="BILINEAR") == {"FINISHED"}
    assert add_motion(arm, motion="HEAD_SHAKE", duration=0.25, cycles=1) == {"FINISHED"}
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 5
    out = tmp_path / "clip.mp4"
    assert scene.camera is None
    render = scene.render
    before = (render.engine, render.resolution_x, render.resolution_y, render.filepath,
              render.image_settings.file_format, scene.display.shading.light)
    assert bpy.ops.render.miniskeleton_make_video(filepath=str(out), resolution_x=64,
                                                  resolution_y=48) == {"FINISHED"}
    # rendered with Workbench at 64 x 48, then the user's render settings are back
    assert (render.engine, render.resolution_x, render.resolution_y, render.filepath,
            render.image_settings.file_format, scene.display.shading.light) == before
    assert render.engine != "BLENDER_WORKBENCH" and render.image_settings.file_format != "FFMPEG"
    assert scene.camera is not None
    assert out.read_bytes()[4:8] == b"ftyp"
    assert probe(out) == (5, 64, 48)
    # the camera sees the whole character: its bounding box projects inside the video's frame
    render.resolution_x, render.resolution_y = 64, 48
    assert_in_view(scene, scene.camera, corners(body))


def test_a_framing_camera_films_a_long_walk_from_the_side_at_any_size():
    """Make Video's framing camera looks across a motion that travels far along Y or X (a
    walk is filmed from the side, not from behind), with the whole path in view and between its
    clipping distances, also for a 2 cm figure (inside a new camera's 0.1 m clip start) and a
    2 km one (beyond its 1 km clip end)."""
    filming = __import__(ADDON + ".motion.filming", fromlist=["filming"])
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 160, 90
    boxes = [((-0.5, -6.0, 0.0), (0.5, 0.0, 1.5), 0), ((-6.0, -0.5, 0.0), (0.0, 0.5, 1.5), 1),
             ((0.0, 0.0, 0.0), (0.01, 0.01, 0.02), None), ((0.0, 0.0, 0.0), (1000.0, 1000.0, 2000.0), None)]
    for lo, hi, across in boxes:
        cam = filming.add_camera(scene, Vector(lo), Vector(hi), 16 / 9)
        bpy.context.view_layer.update()
        look = cam.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0))
        if across is not None:
            assert abs(look[across]) > 2 * abs(look[1 - across]), (lo, hi, tuple(look))
        scene.camera = cam
        assert_in_view(scene, cam, [(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    # A portrait video: the narrower side is the width, and the box fits it too.
    scene.render.resolution_x, scene.render.resolution_y = 90, 160
    cam = filming.add_camera(scene, Vector((-1.0, -1.0, 0.0)), Vector((1.0, 1.0, 2.0)), 9 / 16)
    bpy.context.view_layer.update()
    scene.camera = cam
    assert_in_view(scene, cam, [(x, y, z) for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (0.0, 2.0)])


def test_a_following_camera_travels_level_with_the_walker_and_keeps_it_in_frame():
    """Make Video's FOLLOW camera is keyed along a 10 m walk at one height (the walker bobs, the
    camera does not), much nearer the walker than a camera framing the whole path, and has it in
    frame at every frame; a walker that stays in place gets a fixed framing camera instead."""
    filming = __import__(ADDON + ".motion.filming", fromlist=["filming"])
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 41
    scene.render.resolution_x, scene.render.resolution_y = 160, 90
    walker = keyed_cube("Walker", [(f, (0.25 * (f - 1), 0.0, 0.5 + 0.3 * ((f // 4) % 2))) for f in range(1, 42, 4)])
    objects = filming.character_objects(scene)
    assert objects == [walker]
    boxes = filming.motion_boxes(scene, objects)
    assert (boxes[0][0], boxes[-1][0], len(boxes)) == (1, 41, 24)   # both ends of the range sampled
    cam = filming.add_follow_camera(scene, boxes, 16 / 9)
    fixed = filming.add_camera(scene, *filming.union_box(boxes), 16 / 9)
    assert cam.animation_data is not None and cam.animation_data.action is not None
    heights = set()
    for f in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(f)
        heights.add(round(cam.matrix_world.translation.z, 5))
        assert_in_view(scene, cam, corners(walker))
        at = walker.matrix_world.translation
        near, far = (cam.matrix_world.translation - at).length, (fixed.matrix_world.translation - at).length
        assert near < 0.5 * far, (f, near, far)
    assert len(heights) == 1, heights

    bpy.data.objects.remove(walker)
    stay = keyed_cube("Stay", [(f, (2.0, 1.0, 0.5 + 0.3 * ((f // 4) % 2))) for f in range(1, 42, 4)])
    cam = filming.add_follow_camera(scene, filming.motion_boxes(scene, [stay]), 16 / 9)
    assert cam.animation_data is None
    for f in (1, 5, 41):
        scene.frame_set(f)
        assert_in_view(scene, cam, corners(stay))


def test_a_motion_shorter_than_the_samples_is_sampled_at_every_frame():
    """A frame range shorter than the 24 samples is sampled at each of its frames, the last
    included. The spacing was that of 24 samples: frames 1 to 5 gave boxes at 1 and 2 only, so
    a camera framed the start of a short motion, and 2 frames gave one box and no following."""
    filming = __import__(ADDON + ".motion.filming", fromlist=["filming"])
    scene = bpy.context.scene
    cube = keyed_cube("Cube", [(1, (0.0, 0.0, 0.0)), (5, (4.0, 0.0, 0.0))])
    for end, frames in ((5, [1, 2, 3, 4, 5]), (2, [1, 2]), (1, [1])):
        scene.frame_start, scene.frame_end = 1, end
        assert [b[0] for b in filming.motion_boxes(scene, [cube])] == frames
    scene.frame_end = 5
    boxes = filming.motion_boxes(scene, [cube])
    assert boxes[-1][1].x == pytest.approx(3.5)   # the cube's last place is in the box


def test_the_camera_frames_the_visible_meshes_an_armature_deforms():
    """What Make Video frames: visible meshes deformed by (or parented to) an armature, not a
    hidden proxy or an unrigged ground plane; without a rigged mesh every visible mesh; without
    a mesh the armatures."""
    filming = __import__(ADDON + ".motion.filming", fromlist=["filming"])
    scene = bpy.context.scene
    arm = B.chain("Rig", count=2)
    body, proxy, hat = B.cylinder("Body"), B.cylinder("Proxy"), B.cylinder("Hat")
    for ob in (body, proxy):
        ob.modifiers.new("Armature", "ARMATURE").object = arm
    hat.parent = arm
    proxy.hide_set(True)
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    ground = bpy.context.active_object
    assert set(filming.character_objects(scene)) == {body, hat}
    body.modifiers.clear()
    hat.parent = None
    assert set(filming.character_objects(scene)) == {body, hat, ground}
    for ob in (body, proxy, hat, ground):
        bpy.data.objects.remove(ob)
    assert filming.character_objects(scene) == [arm]


def test_the_video_goes_next_to_the_saved_blend_file_by_default(tmp_path):
    filming = __import__(ADDON + ".motion.filming", fromlist=["filming"])
    scene = bpy.context.scene
    from pathlib import Path

    assert filming.default_video_path(scene) == Path.cwd() / "out" / "Scene.mp4"
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    assert filming.default_video_path(scene) == tmp_path / "shot.mp4"


def test_video_counts_the_frames_it_renders_on_the_scene_frame_step(tmp_path, capfd):
    """Render Animation renders every frame_step-th frame; the report and the progress said
    frame_end - frame_start + 1 (5 here, for 3 frames rendered)."""
    creature.build_body(subdivisions=0)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end, scene.frame_step = 1, 5, 2
    out = tmp_path / "stepped.mp4"
    assert bpy.ops.render.miniskeleton_make_video(filepath=str(out), resolution_x=32,
                                                  resolution_y=32) == {"FINISHED"}
    assert probe(out) == (3, 32, 32)
    printed = capfd.readouterr().out
    assert "video: frame 3/3" in printed and "(3 frames, 32x32" in printed


def test_video_path_gets_the_mp4_extension(tmp_path):
    """The file is an MP4 whatever the path's extension: clip.avi is written as clip.mp4; an odd
    size is rounded up to even numbers, as H.264 wants."""
    creature.build_body(subdivisions=0)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 2
    assert bpy.ops.render.miniskeleton_make_video(filepath=str(tmp_path / "clip.avi"), resolution_x=31,
                                                  resolution_y=33) == {"FINISHED"}
    assert not (tmp_path / "clip.avi").exists() and probe(tmp_path / "clip.mp4") == (2, 32, 34)


def test_video_uses_the_scenes_camera_and_light_when_it_has_them_and_the_frame_rate_asked(tmp_path):
    """Camera 'Add If Missing' with a camera and a light in the scene adds neither (without the
    camera, only a camera); FPS 12 gives a 12 fps video, and the scene keeps its own frame rate."""
    body = creature.build_body(subdivisions=0)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 2
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    for ob in (cam, sun):
        scene.collection.objects.link(ob)
    cam.location, cam.rotation_euler = (0.0, -8.0, 1.0), (math.radians(85), 0.0, 0.0)
    scene.camera = cam
    fps = (scene.render.fps, scene.render.fps_base)
    before = set(scene.objects)
    out = tmp_path / "clip.mp4"
    assert bpy.ops.render.miniskeleton_make_video(filepath=str(out), resolution_x=32, resolution_y=32,
                                                  fps=12) == {"FINISHED"}
    assert set(scene.objects) == before and scene.camera == cam and body.name in scene.objects
    assert bpy.data.movieclips.load(str(out)).fps == 12
    assert (scene.render.fps, scene.render.fps_base) == fps != (12, 1.0)
    # Without the camera: a framing camera is added, and no light beside the scene's own.
    bpy.data.objects.remove(cam)
    before = set(scene.objects)
    assert bpy.ops.render.miniskeleton_make_video(filepath=str(out), resolution_x=32, resolution_y=32) == {"FINISHED"}
    assert [ob.type for ob in set(scene.objects) - before] == ["CAMERA"]


def test_video_with_the_scenes_own_engine_and_camera(tmp_path):
    # As a Shadow Theatre preset is rendered: its engine, shading and camera are kept.
    creature.build_body(subdivisions=0), creature.build_armature()  # something to render
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.light = "FLAT"
    scene.display.shading.show_cavity = False
    cam = bpy.data.objects.new("Audience", bpy.data.cameras.new("Audience"))
    scene.collection.objects.link(cam)
    cam.location = (0, -8, 1)
    cam.rotation_euler = (1.5708, 0, 0)
    scene.camera = cam
    scene.frame_start, scene.frame_end = 1, 3
    scene.render.fps = 30
    out = tmp_path / "theatre.mp4"
    assert bpy.ops.render.miniskeleton_make_video(
        filepath=str(out), engine="SCENE", camera="SCENE", resolution_x=64, resolution_y=48,
        fps=24) == {"FINISHED"}
    assert probe(out) == (3, 64, 48)
    assert scene.camera == cam and len([o for o in scene.objects if o.type == "CAMERA"]) == 1
    assert scene.display.shading.light == "FLAT" and not scene.display.shading.show_cavity
    assert scene.render.fps == 30   # the video's 24 fps was for the video only


def test_video_path_that_cannot_be_written_is_an_error_and_adds_nothing(tmp_path):
    creature.build_body(subdivisions=0)
    blocker = tmp_path / "file"
    blocker.write_text("a file, not a folder")
    folder = tmp_path / "named.mp4"   # a folder with a video's name
    folder.mkdir()
    for bad, why in ((blocker / "clip.mp4", "is a file, not a folder"), (folder, "it is a folder"),
                     (tmp_path / ("x" * 300 + ".mp4"), "File name too long")):
        with pytest.raises(RuntimeError, match=f"Cannot write the video to .*{bad.name}: .*{why}"):
            bpy.ops.render.miniskeleton_make_video(filepath=str(bad))
        assert bpy.context.scene.camera is None and not any(o.type == "LIGHT" for o in bpy.data.objects)
    assert not any(folder.iterdir())


def _video_state(folder):
    """What a failed Make Video must leave as it was: the data-blocks it could add, the scene
    camera, the render settings it changes, the frame, and the files in ``folder`` (bytes)."""
    scene = bpy.context.scene
    render = scene.render
    blocks = {kind: sorted(b.name for b in getattr(bpy.data, kind))
              for kind in ("objects", "cameras", "lights", "actions", "meshes", "materials", "node_groups")}
    settings = (render.engine, render.resolution_x, render.resolution_y, render.resolution_percentage, render.fps,
                render.fps_base, render.filepath, render.image_settings.file_format, render.ffmpeg.codec,
                render.use_border, render.use_multiview, scene.display.shading.light)
    files = {p.name: p.read_bytes() for p in sorted(folder.iterdir())}
    return blocks, scene.camera.name if scene.camera else None, settings, scene.frame_current, files


def _break_the_render(scene, failure):
    """A real render failure: from the scene's own settings, which Make Video keeps, a render
    border smaller than a pixel (Blender: "Image too small") or stereo views written to one
    file per view (the video's own file is never written); or Cycles asked for with its
    add-on disabled (the test enables it again)."""
    if failure == "cycles":
        bpy.ops.preferences.addon_disable(module="cycles")
    elif failure == "border":
        scene.render.use_border = scene.render.use_crop_to_border = True
        scene.render.border_min_x, scene.render.border_max_x = 0.0, 0.01
        scene.render.border_min_y, scene.render.border_max_y = 0.0, 0.01
    else:
        scene.render.use_multiview = True
        scene.render.image_settings.views_format = "INDIVIDUAL"


@pytest.mark.parametrize("failure, message", [("border", "rendering failed: Image too small"),
                                              ("views", "rendering wrote no file at .*clip"),
                                              ("cycles", "the Cycles engine is not available")])
@pytest.mark.parametrize("camera", ["IF_MISSING", "FOLLOW"])
def test_a_video_whose_render_fails_leaves_the_scene_and_the_earlier_video_as_they_were(tmp_path, camera,
                                                                                       failure, message):
    """Make Video is one transaction: it renders into a hidden file beside the video and
    replaces the earlier video only with a whole one; when the render fails, the camera (a
    following one with its keys), the light and the floor and shadow it added go again, with
    their meshes, materials and node groups, the scene camera and the render settings are as
    they were, no part file is left, and the report says why. Before,
    the earlier video was deleted first, the camera and light stayed, and "Image too small"
    and a disabled Cycles were tracebacks."""
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.active_object
    cube.keyframe_insert("location", frame=1)
    cube.location.x = 4.0
    cube.keyframe_insert("location", frame=2)
    scene.frame_start, scene.frame_end = 1, 2
    out = tmp_path / "clip.mp4"
    assert bpy.ops.render.miniskeleton_make_video(filepath=str(out), resolution_x=32, resolution_y=32,
                                                  camera="NEW") == {"FINISHED"}
    assert [p.name for p in tmp_path.iterdir()] == ["clip.mp4"] and out.read_bytes()[4:8] == b"ftyp"
    if camera == "IF_MISSING":   # a scene without a camera or light: Make Video adds both
        bpy.data.batch_remove([ob for ob in scene.objects if ob.type in ("CAMERA", "LIGHT")])
        assert scene.camera is None
    else:                        # the scene's own camera and light stay; a following camera is added
        scene.camera.name = scene.camera.data.name = "MyCamera"
    _break_the_render(scene, failure)
    before = _video_state(tmp_path)
    rendering = []   # what the scene held while it rendered (a border too small fails before)

    def seen(_scene, _depsgraph=None):
        rendering.append((scene.camera.name, sorted(a.name for a in bpy.data.actions),
                          sorted(o.type for o in bpy.data.objects)))

    engine = "CYCLES" if failure == "cycles" else "WORKBENCH"
    bpy.app.handlers.render_pre.append(seen)
    try:
        with pytest.raises(RuntimeError) as refused:
            bpy.ops.render.miniskeleton_make_video(filepath=str(out), resolution_x=32, resolution_y=32,
                                                   camera=camera, engine=engine)
    finally:
        bpy.app.handlers.render_pre.remove(seen)
        if failure == "cycles":
            bpy.ops.preferences.addon_enable(module="cycles")
    why = str(refused.value)
    assert "Traceback" not in why and re.search(
        f"No video made: {message}.*; the scene and the earlier video are as they were", why), why
    assert _video_state(tmp_path) == before
    if failure == "views":   # the render ran with what Make Video added (camera, light, floor and the
        # cube's shadow), which is gone again
        added = {"IF_MISSING": ("MiniSkeletonCamera", ["CubeAction"], ["CAMERA", "LIGHT", "MESH", "MESH", "MESH"]),
                 "FOLLOW": ("MiniSkeletonCamera", ["CubeAction", "MiniSkeletonCameraAction"],
                            ["CAMERA", "CAMERA", "LIGHT", "MESH", "MESH", "MESH"])}[camera]
        assert rendering and all(r == added for r in rendering), rendering


def test_undo_after_a_video_takes_back_its_camera_and_light_only(tmp_path):
    """Make Video adds a camera and a light to a scene without them: one Ctrl+Z takes those
    back and nothing else. Without its own undo step, Ctrl+Z went back past the user's last
    step (here: adding a cube) and left the camera and light in the scene."""
    creature.build_body(subdivisions=0)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 2
    bpy.ops.ed.undo_push(message="scene built")
    bpy.ops.mesh.primitive_cube_add(location=(5, 0, 0))
    bpy.ops.ed.undo_push(message="cube added")
    before = sorted(o.name for o in bpy.data.objects)
    # As from a menu: undo=True lets the operator's UNDO flag push its step, like the UI does.
    assert bpy.ops.render.miniskeleton_make_video("EXEC_DEFAULT", True, filepath=str(tmp_path / "v.mp4"),
                                                  resolution_x=32, resolution_y=32) == {"FINISHED"}
    after = sorted(o.name for o in bpy.data.objects)
    assert {o.type for o in bpy.data.objects if o.name not in before} == {"CAMERA", "LIGHT"}
    bpy.ops.ed.undo()
    assert sorted(o.name for o in bpy.data.objects) == before
    bpy.ops.ed.redo()
    assert sorted(o.name for o in bpy.data.objects) == after


def test_menus_and_panel():
    assert hasattr(bpy.types, "MINISKELETON_PT_motion")
    for menu in ("VIEW3D_MT_pose", "TOPBAR_MT_render"):
        funcs = getattr(bpy.types, menu)._dyn_ui_initialize()
        assert any(getattr(f, "__name__", "").startswith("draw_") and
                   getattr(f, "__module__", "").endswith("miniskeleton.motion.ui") for f in funcs), menu


def test_a_locked_f_curve_is_an_error_and_nothing_is_keyed():
    """A rotation F-curve its user locked against editing is named in an error, and neither it
    nor any other curve gets a key (keyframe_insert leaves a locked curve be; a key series would
    not)."""
    arm = creature.build_armature()
    pb = arm.pose.bones["thigh.L"]
    pb.keyframe_insert(common_keys().rotation_path(pb), frame=1)
    fc = next(fc for fc in common_keys().action_fcurves(arm) if "thigh.L" in fc.data_path)
    fc.lock = True
    before = action_keys(arm)
    with pytest.raises(RuntimeError, match=r'locked against editing.*pose.bones\["thigh.L"\]'):
        add_motion(arm, motion="WALK")
    assert action_keys(arm).keys() == before.keys()
    assert all(np.array_equal(action_keys(arm)[k], v) for k, v in before.items())
    fc.lock = False
    assert add_motion(arm, motion="WALK") == {"FINISHED"}
