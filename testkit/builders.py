"""Scene builders for the Blender tests: generated meshes and armatures, made with bpy itself."""

from __future__ import annotations

import importlib
import math

import bpy
import numpy as np

from testkit import blender_session, motion_corpus, rig_corpus
from testkit.rig_corpus import set_active


def cylinder_arrays(radius=0.5, height=4.0, rings=40, segments=24):
    """Closed capped cylinder along +Z (z in [0, height]) as (verts (n,3), quads+tris faces)."""
    verts, faces = [], []
    for r in range(rings + 1):
        z = height * r / rings
        for s in range(segments):
            a = 2 * math.pi * s / segments
            verts.append((radius * math.cos(a), radius * math.sin(a), z))
    for r in range(rings):
        for s in range(segments):
            a, b = r * segments + s, r * segments + (s + 1) % segments
            faces.append((a, b, b + segments, a + segments))
    bottom, top = len(verts), len(verts) + 1
    verts += [(0, 0, 0), (0, 0, height)]
    for s in range(segments):
        faces.append((bottom, (s + 1) % segments, s))
        t = rings * segments
        faces.append((top, t + s, t + (s + 1) % segments))
    return np.array(verts, dtype=np.float32), faces


def mesh_object(name, verts, faces, location=(0, 0, 0), rotation=(0, 0, 0), scale=(1, 1, 1)):
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(map(float, v)) for v in verts], [], faces)
    me.update()
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    ob.location, ob.rotation_euler, ob.scale = location, rotation, scale
    return ob


def cylinder(name="Cylinder", **kw):
    verts, faces = cylinder_arrays(**{k: kw.pop(k) for k in list(kw) if k in ("radius", "height", "rings", "segments")})
    return mesh_object(name, verts, faces, **kw)


def armature(name="Armature", bones=(), location=(0, 0, 0), rotation=(0, 0, 0), scale=(1, 1, 1)):
    """bones: [(name, head, tail, parent_name_or_None, connected)] in armature space
    (``rig_corpus.new_armature``), the object placed at ``location``, ``rotation``, ``scale``."""
    ob = rig_corpus.new_armature(name, bones)
    ob.location, ob.rotation_euler, ob.scale = location, rotation, scale
    return ob


def place_armature_keep_bones(arm_ob, matrix):
    """Give the armature object the world matrix ``matrix`` (a mathutils Matrix) with its bones
    kept where they are in world space (its data transformed by the inverse), and its child
    objects where they are too."""
    old = arm_ob.matrix_world.copy()
    children = [(ob, ob.matrix_world.copy()) for ob in arm_ob.children]
    set_active(arm_ob)
    bpy.ops.object.mode_set(mode="EDIT")
    arm_ob.data.transform(matrix.inverted() @ old)
    bpy.ops.object.mode_set(mode="OBJECT")
    arm_ob.matrix_world = matrix
    bpy.context.view_layer.update()
    for ob, world in children:
        ob.matrix_world = world
    bpy.context.view_layer.update()


def chain(name="Armature", count=4, height=4.0, margin=0.2, **kw):
    """A straight connected chain Bone0..Bone{count-1} along +Z from margin to height-margin."""
    zs = np.linspace(margin, height - margin, count + 1)
    bones = [(f"Bone{i}", (0, 0, zs[i]), (0, 0, zs[i + 1]), f"Bone{i-1}" if i else None, True)
             for i in range(count)]
    return armature(name, bones, **kw)


# chain()'s bone names with its default count
CHAIN_NAMES = [f"Bone{i}" for i in range(4)]


def pose_select(arm, selected=(), hidden=()):
    """Select and hide ``arm``'s bones as in Pose Mode: exactly ``selected`` selected and
    ``hidden`` hidden (Blender 5.0 keeps both on the pose bone, 4.x on the bone)."""
    for pb in arm.pose.bones:
        bone = arm.data.bones[pb.name]
        (pb if hasattr(pb, "select") else bone).select = pb.name in selected
        (pb if hasattr(pb, "hide") else bone).hide = pb.name in hidden


def select_for_parenting(meshes, arm):
    """Ctrl+P convention: meshes selected, armature selected and active."""
    set_active(arm, selected=meshes)


def dense_weights(indices, weights, bones):
    """Dense (n, bones) weights from the core's top-k (indices, weights) rows (-1: unused slot)."""
    out = np.zeros((len(indices), bones))
    rows, slots = np.nonzero((indices >= 0) & (weights > 0))
    out[rows, indices[rows, slots]] = weights[rows, slots]
    return out


def weights_matrix(ob, names):
    """Dense (n, len(names)) weights read back from ``ob``'s vertex groups."""
    index = {g.index: names.index(g.name) for g in ob.vertex_groups if g.name in names}
    w = np.zeros((len(ob.data.vertices), len(names)))
    for v in ob.data.vertices:
        for g in v.groups:
            if g.group in index:
                w[v.index, index[g.group]] = g.weight
    return w


def segment_distances(points, heads, tails):
    """(n, b) distances from points to segments."""
    p = points[:, None, :]
    a, b = np.asarray(heads)[None], np.asarray(tails)[None]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-30), 0, 1)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def bone_segments_world(arm_ob, names):
    m = np.array(arm_ob.matrix_world)
    h = np.array([arm_ob.data.bones[n].head_local for n in names]) @ m[:3, :3].T + m[:3, 3]
    t = np.array([arm_ob.data.bones[n].tail_local for n in names]) @ m[:3, :3].T + m[:3, 3]
    return h, t


def link_from_library(block, path):
    """``block`` written to the .blend file ``path`` and linked back from it: a read-only copy,
    as a character linked from another file. Returns the linked data-block."""
    collection = {"MESH": "meshes", "ARMATURE": "armatures", "OBJECT": "objects",
                  "ACTION": "actions"}[block.id_type]
    bpy.data.libraries.write(str(path), {block})
    with bpy.data.libraries.load(str(path), link=True) as (_, linked):
        setattr(linked, collection, [block.name])
    out = getattr(linked, collection)[0]
    assert out.library is not None and not out.is_editable
    return out


def keep_positive_x_half(ob):
    """Cut ``ob``'s mesh at x = 0 and keep the +X side: a half modelled for a Mirror modifier."""
    import bmesh

    bm = bmesh.new()
    bm.from_mesh(ob.data)
    bmesh.ops.bisect_plane(bm, geom=bm.verts[:] + bm.edges[:] + bm.faces[:], plane_co=(0, 0, 0),
                           plane_no=(1, 0, 0), clear_inner=True)
    bm.to_mesh(ob.data)
    bm.free()


def riding(arm, rider, carrier, frames):
    """Over ``frames``: ``rider``'s posed head in ``carrier``'s posed frame (constant when the
    rider stays fixed to it), and its world height. Two arrays, (len(frames), 3) and (len(frames),)."""
    scene, mw, pose = bpy.context.scene, arm.matrix_world, arm.pose.bones
    offsets, heights = [], []
    for f in frames:
        scene.frame_set(f)
        head = mw @ pose[rider].head
        offsets.append(tuple((mw @ pose[carrier].matrix).inverted() @ head))
        heights.append(head.z)
    return np.array(offsets), np.array(heights)


# ---------------------------------------------------------------------------- corpus rigs

_corpus_rigs: dict = {}


def addon(name: str):
    """The installed extension's module ``name`` ("motion.planning")."""
    return importlib.import_module(f"{blender_session.ADDON_MODULE}.{name}")


def corpus_rig(name: str) -> rig_corpus.Rig:
    """Rig ``name`` of ``rig_corpus``, built in a fresh scene unless it is there already
    (another test may have reset the scene, or undone it), then reset: no action, every pose
    bone at rest, the armature object where it was built (``rig.basis``)."""
    rig = _corpus_rigs.get(name)
    try:
        alive = rig is not None and rig.arm.name in bpy.context.scene.objects and all(
            ob.name in bpy.context.scene.objects for ob in rig.meshes)
    except ReferenceError:
        alive = False
    if not alive:
        blender_session.reset_scene()
        _corpus_rigs.clear()
        with motion_corpus.captured_output():
            rig = rig_corpus.build(name)
        rig.basis = rig.arm.matrix_basis.copy()
        _corpus_rigs[name] = rig
    motion_corpus.reset_rig(rig.arm, rig.basis)
    return rig
