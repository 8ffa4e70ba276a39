"""Ctrl+Z and Ctrl+Shift+Z around every operator that changes the scene: one undo step takes
the whole change back (objects, transforms, parents, modifiers, vertex groups and weights,
bones, the armature's stored original, poses, actions, images, materials, the scene's frame
range, engine, camera and world), and redo puts it back; and what each one made survives
saving the .blend and opening it again."""

from __future__ import annotations

import bpy
import pytest

from testkit import builders as B
from testkit import creature
from testkit.fingerprint import fcurves, fingerprint


def changed(before: dict, after: dict) -> set:
    """The sections of two fingerprints that differ."""
    return {k for k in before if before[k] != after[k]}


def _creature():
    body, arm = creature.build()
    B.select_for_parenting([body], arm)
    return body, arm


def _creature_body():
    """The creature's bare mesh, selected and active (for Auto Rig)."""
    body = creature.build_body()
    bpy.context.view_layer.update()  # the Skin graph object it removed leaves the layer
    B.set_active(body, [body])


def _creature_posed():
    body, arm = _creature()
    assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
    B.set_active(arm, [arm])
    bpy.ops.object.mode_set(mode="POSE")


def _creature_dressed():
    """The creature bound, and a coat over it (its surface pushed out by 2 % of its size, a
    separate object) selected with the body active, for Transfer Weights."""
    body, arm = _creature()
    assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
    coat = body.copy()
    coat.data = body.data.copy()
    coat.name = "Coat"
    coat.vertex_groups.clear()
    coat.modifiers.clear()
    bpy.context.scene.collection.objects.link(coat)
    size = max(body.dimensions)
    for v in coat.data.vertices:
        v.co += v.normal * 0.02 * size
    B.set_active(body, [coat, body])


def _creature_fitted():
    _creature()
    assert bpy.ops.armature.miniskeleton_fit_skeleton() == {"FINISHED"}


def _creature_bundle(path):
    body, arm = _creature()
    assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
    assert bpy.ops.export_scene.miniskeleton_npz(filepath=path) == {"FINISHED"}
    for group in list(body.vertex_groups)[:5]:
        body.vertex_groups.remove(group)
    B.set_active(body, [body])


def _puppet():
    assert bpy.ops.object.miniskeleton_add_puppet(type="FIVE_ROD") == {"FINISHED"}


def _face_png(tmp_path) -> str:
    img = bpy.data.images.new("face", 8, 16, alpha=True)
    path = str(tmp_path / "face.png")
    img.filepath_raw = path
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)
    return path


def _puppet_and_png(tmp_path) -> dict:
    path = _face_png(tmp_path)
    _puppet()
    return dict(filepath=path, bone="head")


# case: (set-up (returns the operator's options), operator, the fingerprint's sections it changes)
CASES = {
    "auto_rig": (lambda tmp: _creature_body() or {}, lambda: bpy.ops.object.miniskeleton_auto_rig,
                 {"objects", "meshes", "armatures"}),
    "auto_weights": (lambda tmp: _creature() and {}, lambda: bpy.ops.object.miniskeleton_auto_weights,
                     {"meshes", "objects"}),
    "voxel_weights": (lambda tmp: _creature() and dict(method="VOXEL"),
                      lambda: bpy.ops.object.miniskeleton_auto_weights, {"meshes", "objects"}),
    "transfer_weights": (lambda tmp: _creature_dressed() or {}, lambda: bpy.ops.object.miniskeleton_transfer_weights,
                         {"meshes", "objects"}),
    "fit": (lambda tmp: _creature() and {}, lambda: bpy.ops.armature.miniskeleton_fit_skeleton, {"armatures"}),
    "restore": (lambda tmp: _creature_fitted() or {}, lambda: bpy.ops.armature.miniskeleton_restore_skeleton,
                {"armatures"}),
    "snapshot": (lambda tmp: _creature_fitted() or {}, lambda: bpy.ops.armature.miniskeleton_snapshot_skeleton,
                 {"armatures"}),
    "add_motion": (lambda tmp: _creature_posed() or dict(motion="WALK"), lambda: bpy.ops.pose.miniskeleton_add_motion,
                   {"actions", "armatures", "objects", "scene"}),
    "import_npz": (lambda tmp: _creature_bundle(str(tmp / "rig.npz")) or dict(filepath=str(tmp / "rig.npz")),
                   lambda: bpy.ops.import_scene.miniskeleton_npz, {"meshes"}),
    "add_puppet": (lambda tmp: dict(type="FIVE_ROD"), lambda: bpy.ops.object.miniskeleton_add_puppet,
                   {"objects", "meshes", "armatures", "materials"}),
    "bake_puppet": (lambda tmp: _puppet() or {}, lambda: bpy.ops.object.miniskeleton_bake_puppet,
                    {"actions", "objects"}),
    "set_part_image": (_puppet_and_png, lambda: bpy.ops.object.miniskeleton_set_part_image,
                       {"images", "materials", "meshes"}),
    "shadow_theatre": (lambda tmp: _puppet() or {}, lambda: bpy.ops.scene.miniskeleton_shadow_theatre,
                       {"objects", "data", "scene"}),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_one_undo_takes_an_operator_back_and_redo_puts_it_again(case, tmp_path):
    setup, operator, sections = CASES[case]
    options = setup(tmp_path)
    bpy.ops.ed.undo_push(message="before")
    before = fingerprint()
    # As from a menu: the operator's UNDO flag pushes its own step (undo=True, like the UI does).
    assert operator()("EXEC_DEFAULT", True, **options) == {"FINISHED"}
    after = fingerprint()
    assert changed(before, after) >= sections  # what the operator does is seen
    bpy.ops.ed.undo()
    assert fingerprint() == before
    bpy.ops.ed.redo()
    assert fingerprint() == after


@pytest.mark.parametrize("case", sorted(CASES))
def test_what_an_operator_made_survives_save_and_reload(case, tmp_path):
    setup, operator, sections = CASES[case]
    options = setup(tmp_path)
    assert operator()(**options) == {"FINISHED"}
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    made = fingerprint()
    path = str(tmp_path / f"{case}.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    assert fingerprint() == made


# ---------------------------------------------------------------- the fingerprint sees a broken undo


def _rig():
    return next(ob for ob in bpy.data.objects if ob.type == "ARMATURE" and ob.get("miniskeleton_puppet"))


def _first_key(ob):
    action = ob.animation_data.action
    _, fc = next((slot, fc) for slot, fc in fcurves(action) if len(fc.keyframe_points))
    return fc.keyframe_points[0]


def _euler_bone():
    return next(pb for pb in _rig().pose.bones if pb.rotation_mode == "XYZ")


def _seeded_bone():
    return next(pb for pb in _rig().pose.bones if "miniskeleton_seed" in pb.keys())


# What an undo that misses one thing leaves behind: (the sections it shows in, the change).
BREAKS = {
    "custom property value": ("armatures", lambda body, arm: _seeded_bone().__setitem__(
        "miniskeleton_seed", _seeded_bone()["miniskeleton_seed"] + 1.0)),
    "object property value": ("objects", lambda body, arm: _rig().__setitem__(
        "miniskeleton_live", not _rig()["miniskeleton_live"])),
    "euler rotation of a puppet bone": ("armatures", lambda body, arm: setattr(
        _euler_bone().rotation_euler, "z", _euler_bone().rotation_euler.z + 0.01)),
    "quaternion rotation of a bone": ("armatures", lambda body, arm: setattr(
        arm.pose.bones[1].rotation_quaternion, "x", 0.01)),
    "axis-angle rotation of a bone": ("armatures", lambda body, arm: arm.pose.bones[1].rotation_axis_angle.__setitem__(
        0, 0.5)),
    "rotation mode of a bone": ("armatures", lambda body, arm: setattr(arm.pose.bones[1], "rotation_mode", "ZXY")),
    "quaternion rotation of an object": ("objects", lambda body, arm: setattr(body.rotation_quaternion, "y", 0.2)),
    "rotation mode of an object": ("objects", lambda body, arm: setattr(body, "rotation_mode", "QUATERNION")),
    # The pose follows the moved key on the current frame.
    "key value": ({"actions", "armatures"}, lambda body, arm: setattr(_first_key(arm).co, "y",
                                                                      _first_key(arm).co.y + 0.01)),
    "key handle": ("actions", lambda body, arm: setattr(_first_key(arm).handle_right, "y", 5.0)),
    "key interpolation": ("actions", lambda body, arm: setattr(_first_key(arm), "interpolation", "CONSTANT")),
    "vertex coordinate": ("meshes", lambda body, arm: setattr(body.data.vertices[7].co, "x",
                                                              body.data.vertices[7].co.x + 1e-4)),
    "vertex weight": ("meshes", lambda body, arm: setattr(body.data.vertices[7].groups[0], "weight",
                                                          body.data.vertices[7].groups[0].weight * 0.999)),
    "vertex group lock": ("meshes", lambda body, arm: setattr(body.vertex_groups[0], "lock_weight", True)),
}


@pytest.mark.parametrize("what", sorted(BREAKS))
def test_an_undo_that_misses_one_thing_is_caught(what):
    """The fingerprint is no weaker than the undo it judges: an undo broken so that it leaves
    one value as the operator's step had it (here an ``undo_post`` handler changes it back) gives
    a different fingerprint, in the section where that value lives. The scene has Euler-rotated
    puppet bones with custom properties, a walk's keys and a skinned mesh."""
    section, corrupt = BREAKS[what]
    body, arm = _creature()
    names = body.name, arm.name  # undo replaces the objects: find them again by name
    assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
    B.set_active(arm, [arm])
    bpy.ops.object.mode_set(mode="POSE")
    assert bpy.ops.pose.miniskeleton_add_motion(motion="WALK") == {"FINISHED"}
    bpy.ops.object.mode_set(mode="OBJECT")
    _puppet()
    _rig()["miniskeleton_live"] = False  # the rods would pose the puppet's bones again after undo
    bpy.ops.object.select_all(action="DESELECT")
    bpy.ops.ed.undo_push(message="before")
    before = fingerprint()

    def broken_undo(*_):
        corrupt(*(bpy.data.objects[name] for name in names))

    assert bpy.ops.object.empty_add("EXEC_DEFAULT", True) == {"FINISHED"}
    bpy.ops.ed.undo()
    assert fingerprint() == before  # a sound undo
    bpy.ops.ed.redo()
    bpy.app.handlers.undo_post.append(broken_undo)
    try:
        bpy.ops.ed.undo()
    finally:
        bpy.app.handlers.undo_post.remove(broken_undo)
    assert changed(before, fingerprint()) == ({section} if isinstance(section, str) else section)
