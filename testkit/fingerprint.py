"""What a user sees of a Blender scene, as comparable values: ``fingerprint()`` before and after
an operator, an undo, a redo or a save and reload tells whether the scene is as it was. Floats
are kept exact (undo, redo and reloading restore the stored values bit for bit)."""

from __future__ import annotations

import hashlib
import os

import bpy
import idprop
import numpy as np


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


def fcurves(action) -> list:
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
    for slot, fc in fcurves(action):
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
