"""Ctrl+Z and Ctrl+Shift+Z around every operator that changes the scene: one undo step takes
the whole change back (objects, transforms, parents, modifiers, vertex groups and weights,
bones, the armature's stored original, poses, actions, images, materials, the scene's frame
range, engine, camera and world), and redo puts it back; and what each one made survives
saving the .blend and opening it again."""

from __future__ import annotations

import hashlib
import os

import bpy
import idprop
import numpy as np
import pytest

import builders as B
import creature


def _digest(x) -> str:
    return hashlib.md5(repr(x).encode()).hexdigest()


def _v(v) -> tuple:
    """A vector, a quaternion or a matrix as exact floats (undo, redo and reloading restore
    the stored values bit for bit, so nothing is rounded away)."""
    return tuple(_v(c) if hasattr(c, "__len__") else float(c) for c in v)


def _array(collection, attr: str, width: int, dtype=np.float32) -> str:
    """Digest of ``attr`` of every item of a bpy collection, read with ``foreach_get``."""
    out = np.empty(len(collection) * width, dtype)
    collection.foreach_get(attr, out)
    return hashlib.md5(out.tobytes()).hexdigest()


def _plain(x):
    """A custom property's value as plain data: groups as dicts, arrays and lists as lists,
    data-blocks by type and name, numbers and strings as they are."""
    if isinstance(x, bpy.types.ID):
        return (type(x).__name__, x.name)
    if isinstance(x, idprop.types.IDPropertyGroup):
        return {k: _plain(x[k]) for k in x.keys()}
    if isinstance(x, (idprop.types.IDPropertyArray, list, tuple)):
        return [_plain(c) for c in x]
    return x


def _props(owner) -> dict:
    """Every custom property of ``owner`` (an ID, a bone, a pose bone) with its value."""
    return {k: _plain(owner[k]) for k in owner.keys()}


def _transform(x) -> tuple:
    """An object's or pose bone's location, rotation in every mode and the mode, and scale."""
    return (x.rotation_mode, _v(x.location), _v(x.rotation_quaternion), _v(x.rotation_euler),
            _v(x.rotation_axis_angle), _v(x.scale))


def _constraints(x) -> list:
    return [(c.type, c.name, c.mute, getattr(getattr(c, "target", None), "name", None),
             getattr(c, "subtarget", None), getattr(getattr(c, "pole_target", None), "name", None),
             getattr(c, "chain_count", None)) for c in x.constraints]


def _fcurves(action) -> list:
    """Every F-curve of ``action`` with the slot it animates: the channelbags of its layers
    (Blender 4.4+), or its own list (4.2)."""
    if hasattr(action, "layers"):
        return [(bag.slot.identifier, fc) for layer in action.layers for strip in layer.strips
                for bag in strip.channelbags for fc in bag.fcurves]
    return [("", fc) for fc in action.fcurves]


def _action(action) -> list:
    """Every F-curve's data path, index and keyframe points (times, values, handles,
    interpolation)."""
    curves = []
    for slot, fc in _fcurves(action):
        keys = fc.keyframe_points
        curves.append((slot, fc.data_path, fc.array_index, len(keys), _array(keys, "co", 2),
                       _array(keys, "handle_left", 2), _array(keys, "handle_right", 2),
                       [(k.interpolation, k.handle_left_type, k.handle_right_type) for k in keys],
                       [m.type for m in fc.modifiers]))
    return sorted(curves, key=lambda c: c[:3])


def _animation(x):
    ad = x.animation_data
    if ad is None:
        return None
    slot = getattr(ad, "action_slot", None)
    return (ad.action.name if ad.action else None, slot.identifier if slot else None)


def _mesh(me, ob) -> tuple:
    """A mesh's vertex coordinates, faces, vertex groups and weights, materials, UV maps."""
    weights = [(v.index, g.group, g.weight) for v in me.vertices for g in v.groups]
    return (len(me.vertices), _array(me.vertices, "co", 3), _array(me.polygons, "loop_total", 1, np.int32),
            _array(me.loops, "vertex_index", 1, np.int32),
            [(g.name, g.index, g.lock_weight) for g in ob.vertex_groups], _digest(weights),
            [m.name if m else None for m in me.materials], [uv.name for uv in me.uv_layers],
            _props(me))


def _armature(arm, ob) -> tuple:
    """The bones (rest matrices, parents, deform and connect flags, custom properties), the
    armature's own properties (the stored original rest pose), and the pose: every pose bone's
    transform in every rotation mode, its constraints and custom properties."""
    bones = [(b.name, _v(b.head_local), _v(b.tail_local), _v(b.matrix_local),
              b.parent.name if b.parent else None, b.use_connect, b.use_deform, _props(b)) for b in arm.bones]
    pose = [(p.name, _transform(p), _constraints(p), _props(p)) for p in ob.pose.bones]
    return bones, _props(arm), pose


def fingerprint() -> dict:
    """What a user sees of the scene, as comparable values, in sections (``changed`` names the
    sections that differ)."""
    objects, meshes, armatures, data = {}, {}, {}, {}
    for ob in bpy.data.objects:
        objects[ob.name] = (ob.type, ob.data.name if ob.data else None, _transform(ob),
                            ob.parent.name if ob.parent else None, ob.parent_type, ob.parent_bone,
                            _v(ob.matrix_parent_inverse), ob.hide_viewport, ob.hide_render,
                            sorted(c.name for c in ob.users_collection),
                            [(m.type, m.name, getattr(getattr(m, "object", None), "name", None))
                             for m in ob.modifiers],
                            _constraints(ob), _props(ob), _animation(ob))
        if ob.type == "MESH":
            meshes[ob.name] = _mesh(ob.data, ob)
        elif ob.type == "ARMATURE":
            armatures[ob.name] = _armature(ob.data, ob)
        elif ob.type == "LIGHT":
            data[ob.name] = (ob.data.type, ob.data.energy, _v(ob.data.color))
        elif ob.type == "CAMERA":
            data[ob.name] = (ob.data.type, ob.data.lens, ob.data.ortho_scale)
        elif ob.type == "EMPTY":
            data[ob.name] = (ob.empty_display_type, ob.empty_display_size)
    scene = bpy.context.scene
    return dict(
        objects=objects,
        meshes=meshes,
        armatures=armatures,
        data=data,
        actions={a.name: _action(a) for a in bpy.data.actions},
        # The file each image shows, wherever it is (saving may make its path relative).
        images={i.name: (os.path.normpath(bpy.path.abspath(i.filepath)), tuple(i.size), i.source)
                for i in bpy.data.images},
        materials={m.name: sorted((n.bl_idname, getattr(getattr(n, "image", None), "name", None))
                                  for n in (m.node_tree.nodes if m.node_tree else ())) for m in bpy.data.materials},
        collections=sorted(c.name for c in bpy.data.collections),
        scene=(scene.frame_start, scene.frame_end, scene.frame_current, scene.render.fps, scene.render.engine,
               scene.render.resolution_x, scene.render.resolution_y,
               scene.camera.name if scene.camera else None, scene.world.name if scene.world else None,
               _props(scene)),
    )


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
    _, fc = next((slot, fc) for slot, fc in _fcurves(action) if len(fc.keyframe_points))
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
