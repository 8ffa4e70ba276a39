"""Shadow-puppet operators: add a puppet template, live rod-driven IK, bake, part images and
the Shadow Theatre scene preset.

The puppet's picture plane is the armature's XZ plane (front view looks along +Y). Each bone's
local Z axis points at the viewer (-Y), so its in-plane rotation is ``rotation_euler.z``
(Euler XYZ, the mode the puppet's bones are made in; a bone a rigger sets to another rotation
mode is read and written in that mode, see ``bone_euler``) and the other axes are locked. A
2D point is ``(x, z)`` in armature space; a 2D angle is counter-clockwise as seen from the
front. The IK maths is ``miniskeleton_core.ik2d_*`` (Rust); this module maps rods and bones to
arrays and writes the angles back.
"""

from __future__ import annotations

import math
import os
import traceback

import bpy
import numpy as np
from bpy.app.handlers import persistent
from bpy.props import BoolProperty, EnumProperty, FloatProperty, StringProperty
from bpy_extras.io_utils import ImportHelper
from mathutils import Euler, Matrix, Vector

from . import mesh_io, puppet
from .keys import key_series, rotation_path, rotation_series

KIND_KEY = "miniskeleton_puppet"      # on the armature object (and its data): the template kind
LIVE_KEY = "miniskeleton_live"        # on the armature object: solve live from the rods
RODS_KEY = "miniskeleton_rods"        # on the armature object: {role: rod object}
RIG_KEY = "miniskeleton_rig"          # on rods, prop and parts: the armature object
ROLE_KEY = "miniskeleton_rod"         # on a rod: its role ("neck", "hand.L", ...)
PART_KEY = "miniskeleton_part"        # on a part mesh: its bone
SEED_KEY = "miniskeleton_seed"        # on a pose bone: IK start angle, degrees
THEATRE_KEY = "miniskeleton_theatre"  # on the Shadow Theatre's screen, light and camera

LEATHER = (0.06, 0.035, 0.022, 1.0)
SCREEN = (1.0, 0.62, 0.28, 1.0)
NAMES = dict(THREE_ROD="ThreeRodPuppet", FIVE_ROD="FiveRodPuppet", PROP="PropPuppet",
             STRIP="StripPuppet", QUADRUPED="QuadrupedPuppet")


# ---------------------------------------------------------------------------- finding puppets


def puppet_rig(ob: bpy.types.Object | None) -> bpy.types.Object | None:
    """The puppet armature of ``ob`` (the armature itself, one of its rods, its prop or a part)."""
    for _ in range(4):
        if ob is None:
            return None
        if ob.type == "ARMATURE" and ob.get(KIND_KEY):
            return ob
        rig = ob.get(RIG_KEY)
        if isinstance(rig, bpy.types.Object):
            return rig
        ob = ob.parent
    return None


def puppet_poll(op: type[bpy.types.Operator], context: bpy.types.Context) -> bool:
    """Poll of the operators that act on a puppet: the active object belongs to one; if not,
    the greyed button's tooltip (and a script's error) says what to select."""
    if puppet_rig(context.active_object) is not None:
        return True
    op.poll_message_set(
        "Select a shadow puppet (its armature, a rod or a part); Add > Armature > Shadow Puppet makes one")
    return False


def scene_puppets(scene: bpy.types.Scene) -> list[bpy.types.Object]:
    return [ob for ob in scene.objects if ob.type == "ARMATURE" and ob.get(KIND_KEY)]


def puppet_rods(rig: bpy.types.Object) -> dict[str, bpy.types.Object]:
    """{role: rod} of ``rig``'s rods that are still in a scene: one deleted in the viewport
    stays in the file while the rig refers to it, and the limb went on following it unseen."""
    rods = rig.get(RODS_KEY) or {}
    return {role: ob for role, ob in rods.items() if isinstance(ob, bpy.types.Object) and ob.users_scene}


GAPS = "leaves these as they are (a bone renamed or deleted, a rod deleted)"


def puppet_gaps(rig: bpy.types.Object) -> list[str]:
    """What ``rig``'s drivers lack (``puppet.driver_gaps``): bones renamed or deleted, rods deleted."""
    return puppet.driver_gaps(puppet.template(rig[KIND_KEY]), set(rig.pose.bones.keys()), set(puppet_rods(rig)))


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


def _flat_mesh(name, outline_xz, y, uv=True):
    """A one-face mesh from an (n, 2) outline given in (x, z) with depth y."""
    me = bpy.data.meshes.new(name)
    verts = [(float(x), float(y), float(z)) for x, z in outline_xz]
    me.from_pydata(verts, [], [tuple(range(len(verts)))])
    if uv:
        lo, hi = outline_xz.min(0), outline_xz.max(0)
        span = np.maximum(hi - lo, 1e-9)
        layer = me.uv_layers.new(name="UVMap")
        for loop in me.loops:
            x, z = outline_xz[loop.vertex_index]
            layer.data[loop.index].uv = ((x - lo[0]) / span[0], (z - lo[1]) / span[1])
    me.update()
    return me


def _empty(name, coll, display, size):
    ob = bpy.data.objects.new(name, None)
    ob.empty_display_type = display
    ob.empty_display_size = size
    # Rods move in the picture plane and turn about its normal only.
    ob.lock_location = (False, True, False)
    ob.lock_rotation = (True, False, True)
    coll.objects.link(ob)
    return ob


def _setup_pose_bone(pb, bdef: puppet.BoneDef):
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


def _part(rig, bdef: puppet.BoneDef, size, coll, mat):
    """The bone's flat cut-out: an outline mesh in bone space, parented to the bone."""
    bone = rig.data.bones[bdef.name]
    outline = puppet.part_outline(bdef.shape, bone.length, tuple(w * size for w in bdef.width))
    me = bpy.data.meshes.new(f"{rig.name}.part.{bdef.name}")
    # bone space: x across (local X), y along the bone, z toward the viewer (layering).
    verts = [(float(u), float(v), bdef.depth * size) for u, v in outline]
    me.from_pydata(verts, [], [tuple(range(len(verts)))])
    lo, hi = outline.min(0), outline.max(0)
    layer = me.uv_layers.new(name="UVMap")
    for loop in me.loops:
        u, v = outline[loop.vertex_index]
        layer.data[loop.index].uv = ((u - lo[0]) / max(hi[0] - lo[0], 1e-9), (v - lo[1]) / max(hi[1] - lo[1], 1e-9))
    me.update()
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


def build_puppet(context, kind: str, location=(0.0, 0.0, 0.0), size: float = 1.0) -> bpy.types.Object:
    """Create the puppet ``kind`` (see puppet.KINDS) with its feet at ``location``; returns
    the armature. Objects go into a new collection inside the active one."""
    tpl = puppet.template(kind)
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
        outline = puppet.bar_outline(p.a, p.b, p.width) - np.asarray(centre)
        me = _flat_mesh(f"{base}.{p.name}", outline * size, -p.depth * size)
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


# ---------------------------------------------------------------------------- solving


def _angle(v) -> float:
    """Counter-clockwise angle (radians) of a 3D direction's (x, z) projection."""
    return math.atan2(v[2], v[0])


def _plane_turn(m: Matrix) -> float:
    """The in-plane angle that undoes the figure's tilt in armature space: the world matrix in
    the picture plane is a rotation by the tilt t, after a mirror for a puppet turned round by a
    scale of -1 (f = -1), M = R(t) diag(f, 1); a level bone keeps its rest look when it turns by
    -f t in armature space (R(t) diag(f, 1) R(-f t) = diag(f, 1))."""
    flip = -1.0 if m[0][0] * m[2][2] - m[0][2] * m[2][0] < 0 else 1.0
    return flip * _angle(flip * m.col[0])


def _limits(pb, axis="z"):
    if getattr(pb, f"use_ik_limit_{axis}"):
        return getattr(pb, f"ik_min_{axis}"), getattr(pb, f"ik_max_{axis}")
    return -math.pi, math.pi


def bone_euler(pb: bpy.types.PoseBone) -> Euler:
    """``pb``'s rotation as XYZ Euler angles, the puppet's terms (its in-plane angle is z),
    whatever its rotation mode."""
    if pb.rotation_mode == "XYZ":
        return pb.rotation_euler.copy()
    return pb.matrix_basis.to_3x3().normalized().to_quaternion().to_euler("XYZ")


def set_bone_euler(pb: bpy.types.PoseBone, e: Euler) -> None:
    """Turn ``pb`` to the XYZ Euler angles ``e`` in its own rotation mode (continuing from its
    value: the short way for a quaternion or an axis-angle, no 360 jump for an Euler)."""
    if pb.rotation_mode == "XYZ":
        pb.rotation_euler = e
        return
    path = rotation_path(pb)
    setattr(pb, path, rotation_series(pb, [e.to_quaternion()], tuple(getattr(pb, path)))[1][0])


class _Pose:
    """Armature-space pose matrices from rest matrices and rotations (forward kinematics as
    Blender's default bone inheritance does it), with rotations being overridden as drivers
    are solved so children see their parents' new pose."""

    def __init__(self, rig):
        self.bones = rig.data.bones
        self.pbones = rig.pose.bones
        self.rot = {}
        self.cache = {}

    def euler(self, name) -> Euler:
        return self.rot.get(name) or bone_euler(self.pbones[name])

    def set_z(self, name, z):
        e = self.euler(name)
        e[2] = z
        self.rot[name] = e
        self.cache.clear()

    def rest_frame(self, name) -> Matrix:
        """The bone's pose matrix with its own rotation at rest (its parents posed)."""
        b = self.bones[name]
        if b.parent is None:
            return b.matrix_local.copy()
        return self.matrix(b.parent.name) @ b.parent.matrix_local.inverted() @ b.matrix_local

    def matrix(self, name) -> Matrix:
        m = self.cache.get(name)
        if m is None:
            pb = self.pbones[name]
            basis = Matrix.LocRotScale(pb.location, self.euler(name), pb.scale)
            m = self.rest_frame(name) @ basis
            self.cache[name] = m
        return m

    def tip(self, name) -> Vector:
        return self.matrix(name) @ Vector((0.0, self.bones[name].length, 0.0))


def _chain_setup(pose: _Pose, names):
    """Lengths, base, base angle, rest offsets, solver limits and seeds of a connected chain."""
    bones = pose.bones
    m0 = pose.rest_frame(names[0])
    base = (m0.translation.x, m0.translation.z)
    base_angle = _angle(m0.col[1])
    rest = [_angle(bones[n].matrix_local.col[1]) for n in names]
    offsets = [0.0] + [puppet.wrap(rest[i] - rest[i - 1]) for i in range(1, len(names))]
    lengths = [bones[n].length for n in names]
    lims = [_limits(pose.pbones[n]) for n in names]
    limits = puppet.solver_limits(lims, offsets)
    seeds = [puppet.clamp(math.radians(pose.pbones[n].get(SEED_KEY, 0.0)), *lim) + off
             for n, lim, off in zip(names, lims, offsets)]
    return lengths, base, base_angle, offsets, limits, seeds


def _write_chain(pose, names, angles, offsets):
    for n, a, off in zip(names, angles, offsets):
        pose.set_z(n, puppet.wrap(float(a) - off))


class PuppetError(ValueError):
    """A puppet that cannot be solved as its scene stands (said in a line, never a traceback)."""


def _plane_inverse(rig: bpy.types.Object, rods: dict) -> Matrix:
    """World -> armature space of ``rig``, after checking that the rig and its ``rods`` have
    finite places (a driver or constraint gone wrong can give NaN) and that the rig's scale is
    not zero on an axis (its picture plane has no inverse). PuppetError names what is wrong."""
    m = rig.matrix_world
    if not mesh_io.placed(m):
        raise PuppetError(f"Puppet '{rig.name}' has no finite place (NaN or infinite transform)")
    inv = mesh_io.inverse(m)   # in double precision, as a tiny puppet's needs
    if inv is None:
        scales = ", ".join(f"{x:.3g}" for x in mesh_io.axis_scales(m))
        raise PuppetError(f"Puppet '{rig.name}' is scaled to zero on an axis ({scales}): "
                          "set its scale (Object > Transform)")
    bad = sorted(rod.name for rod in rods.values() if not mesh_io.placed(rod.matrix_world))
    if bad:
        raise PuppetError(f"Puppet '{rig.name}': rod(s) {mesh_io.name_list(bad)} have no finite place "
                          "(NaN or infinite transform)")
    return Matrix(inv.tolist())


def _rod_point(inv, rod):
    p = inv @ rod.matrix_world.translation
    return (p.x, p.z)


def solve_puppet(rig: bpy.types.Object) -> dict:
    """Pose ``rig`` from its rods with the Rust planar solver; returns {driver: report}.

    Only the in-plane angle (``rotation_euler.z``) of driven bones is written, and only when
    it changes; the other bones are clamped into their stored limits. Each solve starts from
    the bones' seed angles, so the pose is a function of the rods alone (scrubbing and
    baking give the same pose as live solving). PuppetError when the rig or a rod has no
    finite place, or the rig is scaled to zero; nothing is written then."""
    import miniskeleton_core as core

    tpl = puppet.template(rig[KIND_KEY])
    rods = puppet_rods(rig)
    inv = _plane_inverse(rig, rods)
    pose = _Pose(rig)
    turn = _plane_turn(rig.matrix_world)
    pbones = rig.pose.bones
    reports = {}
    driven = set(puppet.driven_bones(tpl))
    for pb in pbones:                                  # stored limits hold for the free bones too
        if pb.name not in driven:
            e = pose.euler(pb.name)
            z = puppet.clamp(e[2], *_limits(pb, "z"))
            y = puppet.clamp(e[1], *_limits(pb, "y")) if pb.use_ik_limit_y else e[1]
            if z != e[2] or y != e[1]:
                e[1], e[2] = y, z
                pose.rot[pb.name] = e
                pose.cache.clear()

    for drv in tpl.drivers:
        kind = drv[0]
        if kind in ("ik", "hang"):
            names = [n for n in drv[1] if n in pbones]
            if len(names) != len(drv[1]):
                continue
            lengths, base, base_angle, offsets, limits, seeds = _chain_setup(pose, names)
            if kind == "ik":
                rod = rods.get(drv[2])
                if rod is None:
                    continue
                target = _rod_point(inv, rod)
            else:
                down = inv.to_3x3() @ Vector((0.0, 0.0, -1.0))
                far = 100.0 * max(sum(lengths), 1e-6) / max(math.hypot(down.x, down.z), 1e-9)
                target = (base[0] + far * down.x, base[1] + far * down.z)
            angles, rep = core.ik2d_solve(lengths, target, seeds, base=base, base_angle=base_angle,
                                          limits=limits)
            _write_chain(pose, names, angles, offsets)
            reports[drv[2] if kind == "ik" else f"hang:{names[0]}"] = rep
        elif kind == "multi":
            names = list(drv[1])
            effs = [(j, _rod_point(inv, rods[role]), w) for j, role, w in drv[2] if role in rods]
            if not effs or any(n not in pbones for n in names):
                continue
            lengths, base, base_angle, offsets, limits, seeds = _chain_setup(pose, names)
            angles, rep = core.ik2d_solve_multi(lengths, effs, seeds, base=base, base_angle=base_angle,
                                                limits=limits)
            _write_chain(pose, names, angles, offsets)
            reports["multi"] = rep
        elif kind == "level" and drv[1] in pbones:
            name = drv[1]
            rest = _angle(pose.bones[name].matrix_local.col[1])
            zero = _angle(pose.rest_frame(name).col[1])
            z = puppet.clamp(puppet.wrap(rest - turn - zero), *_limits(pbones[name]))
            pose.set_z(name, z)
        elif kind == "turn" and drv[1] in pbones and drv[2] in rods:
            name = drv[1]
            m = inv @ rods[drv[2]].matrix_world
            pose.set_z(name, puppet.clamp(puppet.wrap(_angle(m.col[0])), *_limits(pbones[name])))

    for name, e in pose.rot.items():                   # write back only what changed
        cur = bone_euler(pbones[name])
        if any(abs(cur[i] - e[i]) > 1e-9 for i in range(3)):
            set_bone_euler(pbones[name], e)
    return reports


# ---------------------------------------------------------------------------- live handlers

_state = {"busy": False, "last": {}, "gaps": {}}


def _signature(rig, rods):
    """Everything a solve depends on, rounded: the rig's and rods' world matrices and the
    bones' names, rotations and limits."""
    def r(v):   # NaN != NaN: as text, an unchanged broken rod keeps its signature
        return round(v, 7) if math.isfinite(v) else str(v)

    vals = [r(v) for row in rig.matrix_world for v in row]
    for role in sorted(rods):
        vals += [r(v) for row in rods[role].matrix_world for v in row]
    for pb in rig.pose.bones:
        vals += [pb.name, pb.rotation_mode] + [r(v) for v in getattr(pb, rotation_path(pb))]
        vals += [pb.ik_min_z, pb.ik_max_z, pb.ik_min_y, pb.ik_max_y, pb.get(SEED_KEY, 0.0)]
    return tuple(vals)


def update_scene_puppets(scene, force=False) -> int:
    """Solve every live puppet of ``scene`` whose rods or bones changed; returns how many."""
    if _state["busy"]:
        return 0
    if not any(KIND_KEY in a for a in bpy.data.armatures):   # cheap exit: no puppet at all
        return 0
    _state["busy"] = True
    solved = 0
    try:
        for rig in scene_puppets(scene):
            if not rig.get(LIVE_KEY, True) or rig.mode == "EDIT":
                continue
            key = rig.as_pointer()
            sig = _signature(rig, puppet_rods(rig))
            if not force and _state["last"].get(key) == sig:
                continue
            try:
                solve_puppet(rig)
            except PuppetError as err:   # said once, until the rods or the rig change
                print(f"[MiniSkeleton] {err}; its pose is kept")
                _state["last"][key] = sig
                continue
            _state["last"][key] = _signature(rig, puppet_rods(rig))
            solved += 1
            gaps = puppet_gaps(rig)
            if gaps != _state["gaps"].get(key, []):     # said once, when they change
                if gaps:
                    print(f"[MiniSkeleton] Puppet '{rig.name}' {GAPS}: {'; '.join(gaps)}")
                _state["gaps"][key] = gaps
    except Exception:   # a handler must never break Blender's update loop
        traceback.print_exc()
    finally:
        _state["busy"] = False
    return solved


@persistent
def _on_depsgraph_update(scene, depsgraph=None):
    update_scene_puppets(scene)


@persistent
def _on_frame_change(scene, depsgraph=None):
    update_scene_puppets(scene)


_HANDLERS = (("depsgraph_update_post", _on_depsgraph_update), ("frame_change_post", _on_frame_change))


def register_handlers() -> None:
    unregister_handlers()
    for name, fn in _HANDLERS:
        getattr(bpy.app.handlers, name).append(fn)


def unregister_handlers() -> None:
    for name, fn in _HANDLERS:
        lst = getattr(bpy.app.handlers, name)
        for h in list(lst):
            if getattr(h, "__name__", "") == fn.__name__ and getattr(h, "__module__", "") == fn.__module__:
                lst.remove(h)
    _state["last"].clear()
    _state["gaps"].clear()


# ---------------------------------------------------------------------------- operators


class MINISKELETON_OT_add_puppet(bpy.types.Operator):
    """Add a shadow puppet (armature, cut-out parts and control rods) in the XZ picture plane"""

    bl_idname = "object.miniskeleton_add_puppet"
    bl_label = "Shadow Puppet"
    bl_options = {"REGISTER", "UNDO"}

    type: EnumProperty(name="Type", items=puppet.KIND_ITEMS, default="FIVE_ROD")
    size: FloatProperty(name="Size", default=1.0, min=0.01, max=100.0,
                        description="Scale of the figure (1 = a 1.9 m tall human figure)")

    def execute(self, context):
        at = context.scene.cursor.location
        if not all(map(math.isfinite, at)):   # a script can put it there; nothing is built
            self.report({"ERROR"}, "The 3D cursor has a NaN or infinite location, where a puppet has "
                        "no place: reset it (Shift+C, or Object > Snap > Cursor to World Origin)")
            return {"CANCELLED"}
        rig = build_puppet(context, self.type, at, self.size)
        self.report({"INFO"}, f"Added {rig.name}: {len(rig.data.bones)} bones, "
                    f"{len(puppet_rods(rig))} rods")
        return {"FINISHED"}


class MINISKELETON_OT_bake_puppet(bpy.types.Operator):
    """Solve the puppet on every frame of the scene range and keyframe the bone rotations, so
    the animation plays and renders without the add-on"""

    bl_idname = "object.miniskeleton_bake_puppet"
    bl_label = "Bake Puppet Animation"
    bl_options = {"REGISTER", "UNDO"}

    stop_live: BoolProperty(name="Stop Live Solving", default=True,
                            description="Turn live solving off afterwards so the keys play as baked")

    @classmethod
    def poll(cls, context):
        return puppet_poll(cls, context)

    def execute(self, context):
        rig = puppet_rig(context.active_object)
        locked = mesh_io.read_only(rig, mesh_io.keyed_action(rig))
        if locked:
            self.report({"ERROR"}, locked)
            return {"CANCELLED"}
        scene = context.scene
        wm = context.window_manager
        frames = scene_frames(scene)
        wm.progress_begin(0, len(frames))  # each frame is evaluated and solved: 0.36 s for 1000 frames
        try:
            n = bake_puppet(scene, rig, frames, progress=wm.progress_update)
        except PuppetError as err:
            self.report({"ERROR"}, f"{err}; nothing was baked")
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        if self.stop_live:
            rig[LIVE_KEY] = False
        gaps = puppet_gaps(rig)
        if gaps:
            self.report({"WARNING"}, f"Baked {n} frames of {rig.name}; it {GAPS}: {'; '.join(gaps)}")
        else:
            self.report({"INFO"}, f"Baked {n} frames of {rig.name}")
        return {"FINISHED"}


def scene_frames(scene) -> list[int]:
    """The frames of the scene's range, by its frame step."""
    return list(range(scene.frame_start, scene.frame_end + 1, max(scene.frame_step, 1)))


def bake_puppet(scene, rig, frames=None, progress=None) -> int:
    """Key the rotation of every movable bone on each frame (scene range by default), in the
    bone's rotation mode (``rotation_euler`` as the puppet makes them); ``progress(done)`` is
    called with the number of frames baked after each one. PuppetError (naming the frame) when
    a frame cannot be solved: then no key is written and the bones keep the rotations they had."""
    frames = list(frames or scene_frames(scene))
    current = scene.frame_current
    bones = [pb for pb in rig.pose.bones if not all(pb.lock_rotation)]
    live = rig.get(LIVE_KEY, True)
    rig[LIVE_KEY] = False          # this loop solves itself; keep the handler out of it
    angles = {pb.name: [] for pb in bones}
    before = {pb.name: tuple(getattr(pb, rotation_path(pb))) for pb in bones}
    try:
        for done, f in enumerate(frames):
            scene.frame_set(f)
            try:
                solve_puppet(rig)
            except PuppetError as err:
                for pb in bones:
                    setattr(pb, rotation_path(pb), before[pb.name])
                raise PuppetError(f"At frame {f}: {err}") from None
            for pb in bones:
                angles[pb.name].append(bone_euler(pb))
            if progress is not None:
                progress(done + 1)
        for pb in bones:
            if pb.rotation_mode == "XYZ":
                path, values = "rotation_euler", [tuple(e) for e in angles[pb.name]]
            else:
                path, values = rotation_series(pb, [e.to_quaternion() for e in angles[pb.name]],
                                               before[pb.name])
            key_series(pb, path, frames, values, group=pb.name)
    finally:
        rig[LIVE_KEY] = live
        scene.frame_set(current)
    return len(frames)


class MINISKELETON_OT_set_part_image(bpy.types.Operator, ImportHelper):
    """Replace the active bone's cut-out with an image (PNG with alpha) on a plane"""

    bl_idname = "object.miniskeleton_set_part_image"
    bl_label = "Set Part Image"
    bl_options = {"REGISTER", "UNDO"}

    filter_glob: StringProperty(default="*.png;*.tga;*.tif;*.tiff;*.webp;*.exr", options={"HIDDEN"})
    bone: StringProperty(name="Bone", description="Bone whose part gets the image (default: active bone)")

    @classmethod
    def poll(cls, context):
        return puppet_poll(cls, context)

    def execute(self, context):
        rig = puppet_rig(context.active_object)
        name = self.bone or (rig.data.bones.active.name if rig.data.bones.active else "")
        if name not in rig.data.bones:
            self.report({"ERROR"}, "Select a bone of the puppet (Pose Mode) first")
            return {"CANCELLED"}
        part = next((ob for ob in rig.children if ob.get(PART_KEY) == name), None)
        locked = mesh_io.read_only(part) or (part is not None and mesh_io.in_edit_mode([part]))
        if locked:
            self.report({"ERROR"}, locked)
            return {"CANCELLED"}
        try:
            image = bpy.data.images.load(self.filepath, check_existing=True)
        except RuntimeError as exc:
            self.report({"ERROR"}, f"Cannot load image: {exc}")
            return {"CANCELLED"}
        if not (image.size[0] and image.size[1]):   # Blender "loads" any file; the pixels tell
            if image.users == 0:
                bpy.data.images.remove(image)
            self.report({"ERROR"}, f"Cannot load image: {os.path.basename(self.filepath)} is not an "
                        "image Blender can read (PNG, TGA, TIFF, WebP, EXR)")
            return {"CANCELLED"}
        set_part_image(rig, name, image)
        self.report({"INFO"}, f"{os.path.basename(self.filepath)} on {name}")
        return {"FINISHED"}


def set_part_image(rig, bone_name, image):
    """Give the bone's part a plane with ``image`` (its aspect kept, alpha cut out), sized to
    the bone's length and centred on it. ``image`` has pixels (the operator refuses 0 x 0)."""
    part = next((ob for ob in rig.children if ob.get(PART_KEY) == bone_name), None)
    bone = rig.data.bones[bone_name]
    w, h = image.size
    height = bone.length * 1.3
    half_w = 0.5 * height * w / h
    depth = part.data.vertices[0].co.z if part is not None and len(part.data.vertices) else 0.0
    y0 = 0.5 * bone.length - 0.5 * height
    me = bpy.data.meshes.new(f"{rig.name}.part.{bone_name}")
    me.from_pydata([(-half_w, y0, depth), (half_w, y0, depth), (half_w, y0 + height, depth),
                    (-half_w, y0 + height, depth)], [], [(0, 1, 2, 3)])
    uv = me.uv_layers.new(name="UVMap")
    for loop, co in zip(me.loops, ((0, 0), (1, 0), (1, 1), (0, 1))):
        uv.data[loop.index].uv = co
    me.update()
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


# ---------------------------------------------------------------------------- shadow theatre


def _puppet_bounds(scene):
    """(min, max) of the puppets' parts and props in world (x, z); a default box if none."""
    pts = []
    dg = bpy.context.evaluated_depsgraph_get()
    for rig in scene_puppets(scene):
        for ob in [o for o in scene.objects if puppet_rig(o) == rig and o.type == "MESH"]:
            ev = ob.evaluated_get(dg)
            pts += [ev.matrix_world @ Vector(c) for c in ev.bound_box]
    if not pts:
        return np.array([-1.0, 0.0]), np.array([1.0, 2.0])
    xz = np.array([(p.x, p.z) for p in pts])
    return xz.min(0), xz.max(0)


def _theatre_object(scene, name, data):
    ob = bpy.data.objects.get(name)
    if ob is None or ob.get(THEATRE_KEY) is None:
        ob = bpy.data.objects.new(name, data)
        scene.collection.objects.link(ob)
        ob[THEATRE_KEY] = True
    elif ob.name not in scene.objects:
        scene.collection.objects.link(ob)
    return ob


def build_shadow_theatre(context, engine="WORKBENCH", margin=0.1):
    """Screen behind the puppets (XZ plane, +Y), a warm area light behind the screen facing
    the audience, an orthographic camera on the audience side (-Y); render settings for the
    shadow-play look. Running it again refits the same objects."""
    scene = context.scene
    lo, hi = _puppet_bounds(scene)
    centre = (lo + hi) / 2
    aspect = scene.render.resolution_x / max(scene.render.resolution_y, 1)
    span = (hi - lo) * (1 + 2 * margin)
    height = max(span[1], span[0] / aspect, 1e-3) * 1.1     # a little room to walk and wave
    width = height * aspect

    me = bpy.data.meshes.new("ShadowScreen")
    me.from_pydata([(-width / 2, 0, -height / 2), (width / 2, 0, -height / 2),
                    (width / 2, 0, height / 2), (-width / 2, 0, height / 2)], [], [(0, 1, 2, 3)])
    screen = _theatre_object(scene, "ShadowScreen", me)
    if screen.data != me:
        old = screen.data
        screen.data = me
        if old.users == 0:
            bpy.data.meshes.remove(old)
    screen.location = (centre[0], 0.25 * height / 2, centre[1])
    mat = bpy.data.materials.get("MiniSkeleton Shadow Screen")
    if mat is None:
        mat = bpy.data.materials.new("MiniSkeleton Shadow Screen")
        mat.diffuse_color = SCREEN
        if mat.node_tree is None:
            mat.use_nodes = True
        nt = mat.node_tree
        for n in list(nt.nodes):
            if n.type != "OUTPUT_MATERIAL":
                nt.nodes.remove(n)
        out = next(n for n in nt.nodes if n.type == "OUTPUT_MATERIAL")
        trans = nt.nodes.new("ShaderNodeBsdfTranslucent")
        trans.inputs["Color"].default_value = SCREEN
        emit = nt.nodes.new("ShaderNodeEmission")
        emit.inputs["Color"].default_value = SCREEN
        emit.inputs["Strength"].default_value = 1.2
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(trans.outputs[0], add.inputs[0])
        nt.links.new(emit.outputs[0], add.inputs[1])
        nt.links.new(add.outputs[0], out.inputs["Surface"])
    screen.data.materials.append(mat)

    light_data = bpy.data.lights.get("ShadowBacklight") or bpy.data.lights.new("ShadowBacklight", "AREA")
    light_data.color = (1.0, 0.7, 0.4)
    light_data.energy = 300.0 * height * height
    if light_data.type == "AREA":
        light_data.shape = "RECTANGLE"
        light_data.size, light_data.size_y = width, height
    light = _theatre_object(scene, "ShadowBacklight", light_data)
    light.location = (centre[0], height, centre[1])
    light.rotation_euler = (-math.pi / 2, 0.0, 0.0)       # shines along -Y, through the screen

    cam_data = bpy.data.cameras.get("ShadowCamera") or bpy.data.cameras.new("ShadowCamera")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = max(width, height)
    cam_data.clip_end = 10 * height + 100
    cam = _theatre_object(scene, "ShadowCamera", cam_data)
    cam.location = (centre[0], -4.0 * height, centre[1])
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)          # looks along +Y at the screen
    scene.camera = cam

    if scene.world is None:
        scene.world = bpy.data.worlds.new("ShadowTheatre")
    scene.world.color = (0.02, 0.012, 0.008)
    if engine == "EEVEE":
        items = {i.identifier for i in bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items}
        scene.render.engine = "BLENDER_EEVEE_NEXT" if "BLENDER_EEVEE_NEXT" in items else "BLENDER_EEVEE"
    else:
        scene.render.engine = "BLENDER_WORKBENCH"
    shading = scene.display.shading
    shading.light = "FLAT"
    shading.color_type = "TEXTURE"      # image parts show their picture, the rest their colour
    shading.show_shadows = False
    shading.show_cavity = False
    scene.view_settings.view_transform = "Standard"
    return screen, light, cam


class MINISKELETON_OT_shadow_theatre(bpy.types.Operator):
    """Shadow Theatre: a glowing screen behind the puppets, a warm backlight and the camera on
    the audience side, with render settings for the shadow-play look"""

    bl_idname = "scene.miniskeleton_shadow_theatre"
    bl_label = "Shadow Theatre"
    bl_options = {"REGISTER", "UNDO"}

    engine: EnumProperty(name="Render Engine", default="WORKBENCH",
                         items=[("WORKBENCH", "Workbench", "Flat colours: fast, no GPU needed"),
                                ("EEVEE", "EEVEE", "Translucent screen lit from behind")])

    def execute(self, context):
        if context.mode != "OBJECT":
            bpy.ops.object.mode_set(mode="OBJECT")
        build_shadow_theatre(context, self.engine)
        return {"FINISHED"}


classes = (MINISKELETON_OT_add_puppet, MINISKELETON_OT_bake_puppet, MINISKELETON_OT_set_part_image,
           MINISKELETON_OT_shadow_theatre)
