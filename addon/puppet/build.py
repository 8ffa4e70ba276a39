"""Building a shadow puppet from a template (``templates``): armature, cut-out parts, prop and
control rods in the XZ picture plane; and a part's picture (``set_part_image``).

Each bone's local Z axis points at the viewer (-Y), so its in-plane rotation is
``rotation_euler.z``; the other axes are locked (see ``live``).
"""

from __future__ import annotations

import math

import bpy
import numpy as np
from mathutils import Vector

from . import templates
from .live import solve_puppet
from .rig import KIND_KEY, LIVE_KEY, PART_KEY, RIG_KEY, RODS_KEY, ROLE_KEY, SEED_KEY

LEATHER = (0.06, 0.035, 0.022, 1.0)
NAMES = dict(THREE_ROD="ThreeRodPuppet", FIVE_ROD="FiveRodPuppet", PROP="PropPuppet",
             STRIP="StripPuppet", QUADRUPED="QuadrupedPuppet")


# ---------------------------------------------------------------------------- building


def _to3(p, size, y=0.0):
    return Vector((p[0] * size, y, p[1] * size))


def _material(name, color, image=None):
    mat = bpy.data.materials.get(name) if image is None else None
    if mat is not None:
        return mat
    mat = bpy.data.materials.new(name)
    mat.diffuse_color = color
    if mat.node_tree is None:      # Blender 5.0 always has one (use_nodes is deprecated)
        mat.use_nodes = True
    nt = mat.node_tree
    bsdf = next((n for n in nt.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is not None:
        bsdf.inputs["Base Color"].default_value = color
        bsdf.inputs["Roughness"].default_value = 0.9
        if image is not None:
            tex = nt.nodes.new("ShaderNodeTexImage")
            tex.image = image
            tex.location = (bsdf.location.x - 320, bsdf.location.y)
            nt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
            nt.links.new(tex.outputs["Alpha"], bsdf.inputs["Alpha"])
            nt.nodes.active = tex
    if image is not None:
        if hasattr(mat, "surface_render_method"):
            mat.surface_render_method = "DITHERED"
        if hasattr(mat, "blend_method"):
            mat.blend_method = "HASHED"
    return mat


def polygon_mesh(name: str, verts, uvs=None) -> bpy.types.Mesh:
    """A new mesh of one face through ``verts`` ((n, 3), in order), with ``uvs`` ((n, 2), one
    per vertex) as its UV map when given.

    The face's edges are given, not left to ``from_pydata`` to compute: in Blender 5.0.1
    computed edges leave the internal ``.select_edge`` attribute typed INT32_2D instead of
    BOOLEAN, and selecting vertices on such a mesh in Weight Paint mode (Vertex Selection mask,
    then A) crashes Blender."""
    n = len(verts)
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(map(float, v)) for v in verts], [(i, (i + 1) % n) for i in range(n)],
                   [tuple(range(n))])
    if uvs is not None:
        layer = me.uv_layers.new(name="UVMap")
        corners = [lp.vertex_index for lp in me.loops]
        layer.data.foreach_set("uv", np.asarray(uvs, dtype=np.float32)[corners].ravel())
    me.update()
    return me


def _outline_uvs(outline: np.ndarray) -> np.ndarray:
    """(n, 2) UVs spanning an (n, 2) outline's bounding box."""
    lo, hi = outline.min(0), outline.max(0)
    return (outline - lo) / np.maximum(hi - lo, 1e-9)


def _empty(name, coll, display, size):
    ob = bpy.data.objects.new(name, None)
    ob.empty_display_type = display
    ob.empty_display_size = size
    # Rods move in the picture plane and turn about its normal only.
    ob.lock_location = (False, True, False)
    ob.lock_rotation = (True, False, True)
    coll.objects.link(ob)
    return ob


def _setup_pose_bone(pb, bdef: templates.BoneDef):
    pb.rotation_mode = "XYZ"
    pb.lock_location = (True, True, True)
    pb.lock_scale = (True, True, True)
    twist = bdef.dof == "plane+twist"
    fixed = bdef.dof == "fixed"
    pb.lock_rotation = (True, not twist, fixed)
    pb.lock_ik_x, pb.lock_ik_y, pb.lock_ik_z = True, not twist, fixed
    pb.use_ik_limit_z = True
    lo, hi = (0.0, 0.0) if fixed else bdef.limits
    pb.ik_min_z, pb.ik_max_z = math.radians(lo), math.radians(hi)
    if twist:
        pb.use_ik_limit_y = True
        pb.ik_min_y, pb.ik_max_y = math.radians(bdef.twist[0]), math.radians(bdef.twist[1])
    pb[SEED_KEY] = float(bdef.seed)


def _part(rig, bdef: templates.BoneDef, size, coll, mat):
    """The bone's flat cut-out: an outline mesh in bone space, parented to the bone."""
    bone = rig.data.bones[bdef.name]
    outline = templates.part_outline(bdef.shape, bone.length, tuple(w * size for w in bdef.width))
    # bone space: x across (local X), y along the bone, z toward the viewer (layering).
    verts = [(u, v, bdef.depth * size) for u, v in outline]
    me = polygon_mesh(f"{rig.name}.part.{bdef.name}", verts, _outline_uvs(outline))
    me.materials.append(mat)
    ob = bpy.data.objects.new(me.name, me)
    coll.objects.link(ob)
    ob.parent = rig
    ob.parent_type = "BONE"
    ob.parent_bone = bdef.name
    ob.location = (0.0, -bone.length, 0.0)   # bone parenting starts at the tail
    ob[PART_KEY] = bdef.name
    ob[RIG_KEY] = rig
    ob.hide_select = True
    return ob


def build_puppet(context: bpy.types.Context, kind: str, location=(0.0, 0.0, 0.0),
                 size: float = 1.0) -> bpy.types.Object:
    """Create the puppet ``kind`` (see templates.KINDS) with its feet at ``location``; returns
    the armature. Objects go into a new collection inside the active one."""
    tpl = templates.template(kind)
    if context.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    origin = Vector(location)
    base = NAMES[kind]
    coll = bpy.data.collections.new(base)
    context.collection.children.link(coll)
    mat = _material("MiniSkeleton Puppet Leather", LEATHER)

    main = tpl.main_rod()
    main_ob = _empty(f"{base}.rod.{main.role}", coll, "ARROWS", 0.25 * size)
    main_ob.location = origin + _to3(main.at, size)

    arm = bpy.data.armatures.new(base)
    arm.display_type = "STICK"
    rig = bpy.data.objects.new(base, arm)
    coll.objects.link(rig)
    rig.show_in_front = True
    rig.parent = main_ob
    rig.location = -_to3(main.at, size)
    rig[KIND_KEY] = kind
    arm[KIND_KEY] = kind
    rig[LIVE_KEY] = False    # until it is whole: the handler would solve (and judge) a half-made rig

    for ob in context.view_layer.objects:
        ob.select_set(False)
    context.view_layer.objects.active = rig
    rig.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    made = {}
    for b in tpl.bones:
        eb = arm.edit_bones.new(b.name)
        eb.head, eb.tail = _to3(b.head, size), _to3(b.tail, size)
        eb.align_roll((0.0, -1.0, 0.0))     # local Z toward the viewer: in-plane turn = Z
        if b.parent:
            eb.parent = made[b.parent]
            eb.use_connect = b.connected
        made[b.name] = eb
    bpy.ops.object.mode_set(mode="OBJECT")

    for b in tpl.bones:
        _setup_pose_bone(rig.pose.bones[b.name], b)
        _part(rig, b, size, coll, mat)

    rods = {main.role: main_ob}
    prop_ob = None
    if tpl.prop is not None:
        p = tpl.prop
        centre = ((p.a[0] + p.b[0]) / 2, (p.a[1] + p.b[1]) / 2)
        outline = templates.bar_outline(p.a, p.b, p.width) - np.asarray(centre)
        outline = outline * size   # in (x, z), at depth y
        verts = [(x, -p.depth * size, z) for x, z in outline]
        me = polygon_mesh(f"{base}.{p.name}", verts, _outline_uvs(outline))
        me.materials.append(mat)
        prop_ob = bpy.data.objects.new(me.name, me)
        coll.objects.link(prop_ob)
        prop_ob.parent = main_ob
        prop_ob.location = _to3(centre, size) - _to3(main.at, size)
        prop_ob.lock_location = (False, True, False)
        prop_ob.lock_rotation = (True, False, True)
        prop_ob[RIG_KEY] = rig
        rig["miniskeleton_prop"] = prop_ob
    for r in tpl.rods:
        if r.main:
            continue
        rod = _empty(f"{base}.rod.{r.role}", coll, "SPHERE", 0.05 * size)
        if r.on_prop:
            rod.parent = prop_ob
            rod.location = _to3(r.at, size) - _to3(centre, size)
        else:
            rod.parent = main_ob
            rod.location = _to3(r.at, size) - _to3(main.at, size)
        rods[r.role] = rod
    for role, rod in rods.items():
        rod[ROLE_KEY] = role
        rod[RIG_KEY] = rig
    rig[RODS_KEY] = rods
    rig[LIVE_KEY] = True

    context.view_layer.update()
    solve_puppet(rig)
    for ob in context.view_layer.objects:
        ob.select_set(False)
    main_ob.select_set(True)
    context.view_layer.objects.active = main_ob
    return rig


# ---------------------------------------------------------------------------- part images


def set_part_image(rig: bpy.types.Object, bone_name: str, image: bpy.types.Image) -> bpy.types.Object:
    """Give the bone's part a plane with ``image`` (its aspect kept, alpha cut out), sized to
    the bone's length and centred on it. ``image`` has pixels (the operator refuses 0 x 0)."""
    part = next((ob for ob in rig.children if ob.get(PART_KEY) == bone_name), None)
    bone = rig.data.bones[bone_name]
    w, h = image.size
    height = bone.length * 1.3
    half_w = 0.5 * height * w / h
    depth = part.data.vertices[0].co.z if part is not None and len(part.data.vertices) else 0.0
    y0 = 0.5 * bone.length - 0.5 * height
    me = polygon_mesh(f"{rig.name}.part.{bone_name}",
                      [(-half_w, y0, depth), (half_w, y0, depth), (half_w, y0 + height, depth),
                       (-half_w, y0 + height, depth)], [(0, 0), (1, 0), (1, 1), (0, 1)])
    me.materials.append(_material(f"MiniSkeleton Part {image.name}", (1, 1, 1, 1), image))
    if part is None:
        part = bpy.data.objects.new(me.name, me)
        rig.users_collection[0].objects.link(part)
        part.parent, part.parent_type, part.parent_bone = rig, "BONE", bone_name
        part.location = (0.0, -bone.length, 0.0)
        part[PART_KEY], part[RIG_KEY] = bone_name, rig
    else:
        old = part.data
        part.data = me
        if old.users == 0:
            bpy.data.meshes.remove(old)
    return part
