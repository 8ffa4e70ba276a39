"""Ctrl+Z and Ctrl+Shift+Z around every operator that changes the scene: one undo step takes
the whole change back (objects, transforms, parents, modifiers, vertex groups and weights,
bones, the armature's stored original, poses, actions, images, materials, the scene's frame
range, engine, camera and world), and redo puts it back; and what each one made survives
saving the .blend and opening it again."""

from __future__ import annotations

import hashlib

import bpy
import pytest

import builders as B
import creature


def _digest(x) -> str:
    return hashlib.md5(repr(x).encode()).hexdigest()


def _r(v) -> tuple:
    return tuple(round(c, 5) for c in v)


def fingerprint() -> dict:
    """What a user sees of the scene, as comparable values."""
    objects = []
    for ob in sorted(bpy.data.objects, key=lambda o: o.name):
        item = [ob.name, ob.type, _r(ob.location), _r(ob.rotation_euler), _r(ob.scale),
                ob.parent.name if ob.parent else None, [(m.type, m.name) for m in ob.modifiers],
                sorted(ob.keys())]
        if ob.type == "MESH":
            item.append([g.name for g in ob.vertex_groups])
            item.append(_digest(sorted((v.index, g.group, round(g.weight, 5))
                                       for v in ob.data.vertices for g in v.groups)))
        if ob.type == "ARMATURE":
            item.append(_digest([(b.name, _r(b.head_local), _r(b.tail_local)) for b in ob.data.bones]))
            item.append({k: _digest(ob.data[k].to_dict() if hasattr(ob.data[k], "to_dict") else ob.data[k])
                         for k in ob.data.keys()})
            item.append(_digest([(p.name, _r(p.rotation_quaternion), _r(p.location)) for p in ob.pose.bones]))
        ad = ob.animation_data
        item.append(ad.action.name if ad and ad.action else None)
        objects.append(item)
    scene = bpy.context.scene
    return dict(
        objects=objects,
        actions=sorted(a.name for a in bpy.data.actions),
        images=sorted(i.name for i in bpy.data.images),
        materials=sorted(m.name for m in bpy.data.materials),
        scene=(scene.frame_start, scene.frame_end, scene.render.engine,
               scene.camera.name if scene.camera else None, scene.world.name if scene.world else None),
    )


def _creature():
    body, arm = creature.build()
    B.select_for_parenting([body], arm)
    return body, arm


def _creature_posed():
    body, arm = _creature()
    assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
    B.set_active(arm, [arm])
    bpy.ops.object.mode_set(mode="POSE")


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


# case: (set-up (returns the operator's options), operator)
CASES = {
    "auto_weights": (lambda tmp: _creature() and {}, lambda: bpy.ops.object.miniskeleton_auto_weights),
    "fit": (lambda tmp: _creature() and {}, lambda: bpy.ops.armature.miniskeleton_fit_skeleton),
    "restore": (lambda tmp: _creature_fitted() or {}, lambda: bpy.ops.armature.miniskeleton_restore_skeleton),
    "snapshot": (lambda tmp: _creature_fitted() or {}, lambda: bpy.ops.armature.miniskeleton_snapshot_skeleton),
    "add_motion": (lambda tmp: _creature_posed() or dict(motion="WALK"), lambda: bpy.ops.pose.miniskeleton_add_motion),
    "import_npz": (lambda tmp: _creature_bundle(str(tmp / "rig.npz")) or dict(filepath=str(tmp / "rig.npz")),
                   lambda: bpy.ops.import_scene.miniskeleton_npz),
    "add_puppet": (lambda tmp: dict(type="FIVE_ROD"), lambda: bpy.ops.object.miniskeleton_add_puppet),
    "bake_puppet": (lambda tmp: _puppet() or {}, lambda: bpy.ops.object.miniskeleton_bake_puppet),
    "set_part_image": (_puppet_and_png, lambda: bpy.ops.object.miniskeleton_set_part_image),
    "shadow_theatre": (lambda tmp: _puppet() or {}, lambda: bpy.ops.scene.miniskeleton_shadow_theatre),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_one_undo_takes_an_operator_back_and_redo_puts_it_again(case, tmp_path):
    setup, operator = CASES[case]
    options = setup(tmp_path)
    bpy.ops.ed.undo_push(message="before")
    before = fingerprint()
    # As from a menu: the operator's UNDO flag pushes its own step (undo=True, like the UI does).
    assert operator()("EXEC_DEFAULT", True, **options) == {"FINISHED"}
    after = fingerprint()
    assert after != before
    bpy.ops.ed.undo()
    assert fingerprint() == before
    bpy.ops.ed.redo()
    assert fingerprint() == after


@pytest.mark.parametrize("case", sorted(CASES))
def test_what_an_operator_made_survives_save_and_reload(case, tmp_path):
    setup, operator = CASES[case]
    options = setup(tmp_path)
    assert operator()(**options) == {"FINISHED"}
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    made = fingerprint()
    path = str(tmp_path / f"{case}.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    assert fingerprint() == made
