"""Rods driving a shadow puppet's bones by planar IK: the solve, the handlers that solve live
on every change, and baking the solved pose to keys.

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
from typing import Callable

import bpy
from bpy.app.handlers import persistent
from mathutils import Euler, Matrix, Vector

from ..common import native
from ..common.keys import key_series, rotation_path, rotation_series
from ..common.reports import name_list
from ..common.transforms import axis_scales, inverse, placed
from . import templates
from .rig import (GAPS, KIND_KEY, LIVE_KEY, SEED_KEY, PuppetError, puppet_gaps, puppet_rods, puppet_template,
                  scene_puppets)


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
    offsets = [0.0] + [templates.wrap(rest[i] - rest[i - 1]) for i in range(1, len(names))]
    lengths = [bones[n].length for n in names]
    lims = [_limits(pose.pbones[n]) for n in names]
    limits = templates.solver_limits(lims, offsets)
    seeds = [templates.clamp(math.radians(_seed(pose.pbones[n])), *lim) + off
             for n, lim, off in zip(names, lims, offsets)]
    return lengths, base, base_angle, offsets, limits, seeds


def _seed(pb: bpy.types.PoseBone) -> float:
    """``pb``'s IK start angle (``SEED_KEY``, degrees, 0 when it has none). PuppetError when a
    hand or a script made it something else than a finite number."""
    v = pb.get(SEED_KEY, 0.0)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise PuppetError(f"Puppet '{pb.id_data.name}': bone {pb.name} has {SEED_KEY} = {v!r}, not a finite "
                          "angle in degrees (Bone Properties > Custom Properties)")
    return float(v)


def _write_chain(pose, names, angles, offsets):
    for n, a, off in zip(names, angles, offsets):
        pose.set_z(n, templates.wrap(float(a) - off))


def _plane_inverse(rig: bpy.types.Object, rods: dict) -> Matrix:
    """World -> armature space of ``rig``, after checking that the rig and its ``rods`` have
    finite places (a driver or constraint gone wrong can give NaN) and that the rig's scale is
    not zero on an axis (its picture plane has no inverse). PuppetError names what is wrong."""
    m = rig.matrix_world
    if not placed(m):
        raise PuppetError(f"Puppet '{rig.name}' has no finite place (NaN or infinite transform)")
    inv = inverse(m)   # in double precision, as a tiny puppet's needs
    if inv is None:
        scales = ", ".join(f"{x:.3g}" for x in axis_scales(m))
        raise PuppetError(f"Puppet '{rig.name}' is scaled to zero on an axis ({scales}): "
                          "set its scale (Object > Transform)")
    bad = sorted(rod.name for rod in rods.values() if not placed(rod.matrix_world))
    if bad:
        raise PuppetError(f"Puppet '{rig.name}': rod(s) {name_list(bad)} have no finite place "
                          "(NaN or infinite transform)")
    return Matrix(inv.tolist())


def _rod_point(inv, rod):
    p = inv @ rod.matrix_world.translation
    return (p.x, p.z)


def solve_puppet(rig: bpy.types.Object) -> dict:
    """Pose ``rig`` from its rods with the Rust planar solver; returns {driver: Ik2dSolution}.

    Only the in-plane angle (``rotation_euler.z``) of driven bones is written, and only when
    it changes; the other bones are clamped into their stored limits. Each solve starts from
    the bones' seed angles, so the pose is a function of the rods alone (scrubbing and
    baking give the same pose as live solving). PuppetError when the rig or a rod has no
    finite place, the rig is scaled to zero, its type property names no template or a bone's
    seed is not a number; nothing is written then."""
    core = native.core()
    tpl = puppet_template(rig)
    rods = puppet_rods(rig)
    inv = _plane_inverse(rig, rods)
    pose = _Pose(rig)
    turn = _plane_turn(rig.matrix_world)
    pbones = rig.pose.bones
    reports = {}
    driven = set(templates.driven_bones(tpl))
    for pb in pbones:                                  # stored limits hold for the free bones too
        if pb.name not in driven:
            e = pose.euler(pb.name)
            z = templates.clamp(e[2], *_limits(pb, "z"))
            y = templates.clamp(e[1], *_limits(pb, "y")) if pb.use_ik_limit_y else e[1]
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
            chain = core.Chain2d(lengths, seeds, base=base, base_angle=base_angle, limits=limits)
            solution = core.ik2d_solve(chain, target)
            _write_chain(pose, names, solution.angles, offsets)
            reports[drv[2] if kind == "ik" else f"hang:{names[0]}"] = solution
        elif kind == "multi":
            names = list(drv[1])
            effs = [(j, _rod_point(inv, rods[role]), w) for j, role, w in drv[2] if role in rods]
            if not effs or any(n not in pbones for n in names):
                continue
            lengths, base, base_angle, offsets, limits, seeds = _chain_setup(pose, names)
            chain = core.Chain2d(lengths, seeds, base=base, base_angle=base_angle, limits=limits)
            solution = core.ik2d_solve_multi(chain, effs)
            _write_chain(pose, names, solution.angles, offsets)
            reports["multi"] = solution
        elif kind == "level" and drv[1] in pbones:
            name = drv[1]
            rest = _angle(pose.bones[name].matrix_local.col[1])
            zero = _angle(pose.rest_frame(name).col[1])
            z = templates.clamp(templates.wrap(rest - turn - zero), *_limits(pbones[name]))
            pose.set_z(name, z)
        elif kind == "turn" and drv[1] in pbones and drv[2] in rods:
            name = drv[1]
            m = inv @ rods[drv[2]].matrix_world
            pose.set_z(name, templates.clamp(templates.wrap(_angle(m.col[0])), *_limits(pbones[name])))

    for name, e in pose.rot.items():                   # write back only what changed
        cur = bone_euler(pbones[name])
        if any(abs(cur[i] - e[i]) > 1e-9 for i in range(3)):
            set_bone_euler(pbones[name], e)
    return reports


# ---------------------------------------------------------------------------- live handlers

# Per puppet, keyed by the armature object's pointer (valid within one file, so all of it is
# forgotten when a file is loaded): "last" its signature when last solved or found broken,
# "gaps" what its drivers lacked when last said, "broken" why it does not solve (said once,
# shown in the Puppet panel). "render_said": the current render's skipped solves have been said.
_state = {"busy": False, "last": {}, "gaps": {}, "broken": {}, "render_said": False}

RENDER_SKIP = ("Live puppets do not follow their rods in a render's frames: bake them (Bake Puppet "
               "Animation) for their motion to show in the render")


def _plain(v):
    """An ID property's value as plain Python, comparable between two reads."""
    if hasattr(v, "to_dict"):
        return v.to_dict()
    if hasattr(v, "to_list"):
        return v.to_list()
    return v


def _signature(rig, rods):
    """Everything a solve depends on, rounded: the rig's type, the rig's and rods' world
    matrices and the bones' names, rotations, limits and seeds."""
    def r(v):   # NaN != NaN: as text, an unchanged broken rod keeps its signature
        return round(v, 7) if math.isfinite(v) else str(v)

    vals = [repr(_plain(rig.get(KIND_KEY)))] + [r(v) for row in rig.matrix_world for v in row]
    for role in sorted(rods):
        vals += [role] + [r(v) for row in rods[role].matrix_world for v in row]
    for pb in rig.pose.bones:
        vals += [pb.name, pb.rotation_mode] + [r(v) for v in getattr(pb, rotation_path(pb))]
        vals += [pb.ik_min_z, pb.ik_max_z, pb.ik_min_y, pb.ik_max_y, repr(_plain(pb.get(SEED_KEY, 0.0)))]
    return tuple(vals)


def puppet_problem(rig: bpy.types.Object) -> str | None:
    """Why live solving skips ``rig`` (said once in the console, shown in the Puppet panel), or
    None when it solves. It is tried again when the puppet or its rods change."""
    return _state["broken"].get(rig.as_pointer())


def rendering(depsgraph: bpy.types.Depsgraph | None) -> bool:
    """Whether a handler called with ``depsgraph`` is called by a render: a render evaluates
    each frame in a depsgraph of its own, in ``RENDER`` mode (the viewport's and a viewport
    render's are ``VIEWPORT``). Live solving writes no pose then, as Blender's handlers
    documentation advises ("Note on Altering Data": while rendering, frame-change handlers run
    in one thread and the viewport draws from another, so a handler that changes data the
    viewport reads can crash Blender unless the interface is locked). Nothing is lost by it:
    a render moves the rods to its frames in its own depsgraph, while live solving reads the
    rods' ``matrix_world``, the viewport's, so it could not follow the render's frames anyway.
    Asked of the depsgraph, not of a flag that render_init sets, it cannot stay on after a
    render that stops before its render_complete (Blender then skips that handler)."""
    return depsgraph is not None and depsgraph.mode == "RENDER"


def update_scene_puppets(scene: bpy.types.Scene, force: bool = False,
                         depsgraph: bpy.types.Depsgraph | None = None) -> int:
    """Solve every live puppet of ``scene`` whose rods or bones changed; returns how many.
    ``depsgraph``: the one the calling handler was given.

    Each puppet is solved on its own: one that cannot be solved (PuppetError, or anything else
    its properties or the core raise) keeps its pose, is said once (the console, and the Puppet
    panel through ``puppet_problem``) and is tried again only when it changes; the others solve
    as usual. Nothing is solved or written for a render's frames (``rendering``); that is said
    once per render."""
    if _state["busy"]:
        return 0
    if not any(KIND_KEY in a for a in bpy.data.armatures):   # cheap exit: no puppet at all
        return 0
    if rendering(depsgraph):
        if not _state["render_said"]:
            print(f"[MiniSkeleton] {RENDER_SKIP}")
            _state["render_said"] = True
        return 0
    _state["busy"] = True
    solved = 0
    try:
        for rig in scene_puppets(scene):
            if rig.get(LIVE_KEY, True) and rig.mode != "EDIT":
                solved += _update_puppet(rig, force)
    except Exception as err:   # outside any one puppet (a bug): said once, not on every update
        why = f"Live puppet solving stopped ({type(err).__name__}: {err})"
        if _state["broken"].get(0) != why:
            print(f"[MiniSkeleton] {why}")
        _state["broken"][0] = why        # 0: no puppet's pointer
    finally:
        _state["busy"] = False
    return solved


def _update_puppet(rig: bpy.types.Object, force: bool) -> int:
    """Solve ``rig`` if it changed since it was last solved or found broken; 1 when solved."""
    key = rig.as_pointer()
    try:
        sig = _signature(rig, puppet_rods(rig))
        if not force and _state["last"].get(key) == sig:
            return 0
        _state["last"][key] = sig          # a failure below is not tried again until it changes
        solve_puppet(rig)
        _state["last"][key] = _signature(rig, puppet_rods(rig))
        gaps = puppet_gaps(rig)
    except Exception as err:   # one puppet's failure, whatever it is, is its own
        _broken(rig, key, err)
        return 0
    _state["broken"].pop(key, None)
    if gaps != _state["gaps"].get(key, []):     # said once, when they change
        if gaps:
            print(f"[MiniSkeleton] Puppet '{rig.name}' {GAPS}: {'; '.join(gaps)}")
        _state["gaps"][key] = gaps
    return 1


def _broken(rig: bpy.types.Object, key: int, err: Exception) -> None:
    """Remember why ``rig`` does not solve, and say it when that is news (not on every frame)."""
    why = str(err) if isinstance(err, PuppetError) else (
        f"Puppet '{rig.name}' cannot be solved ({type(err).__name__}: {err})")
    if _state["broken"].get(key) != why:
        print(f"[MiniSkeleton] {why}; its pose is kept")
    _state["broken"][key] = why


def forget_puppets() -> None:
    """Forget every puppet's state (their pointers mean nothing in another file)."""
    for name in ("last", "gaps", "broken"):
        _state[name].clear()


@persistent
def _on_depsgraph_update(scene, depsgraph=None):
    update_scene_puppets(scene, depsgraph=depsgraph)


@persistent
def _on_frame_change(scene, depsgraph=None):
    update_scene_puppets(scene, depsgraph=depsgraph)


@persistent
def _on_load_post(*_args):
    forget_puppets()


@persistent
def _on_render_init(*_args):
    _state["render_said"] = False     # each render says it once


_HANDLERS = (("depsgraph_update_post", _on_depsgraph_update), ("frame_change_post", _on_frame_change),
             ("load_post", _on_load_post), ("render_init", _on_render_init))


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
    forget_puppets()


# ---------------------------------------------------------------------------- baking


def scene_frames(scene: bpy.types.Scene) -> list[int]:
    """The frames of the scene's range, by its frame step."""
    return list(range(scene.frame_start, scene.frame_end + 1, max(scene.frame_step, 1)))


def bake_puppet(scene: bpy.types.Scene, rig: bpy.types.Object, frames: list[int] | None = None,
                progress: Callable[[int], object] | None = None) -> int:
    """Key the rotation of every movable bone on each frame (scene range by default), in the
    bone's rotation mode (``rotation_euler`` as the puppet makes them); ``progress(done)`` is
    called with the number of frames baked after each one.

    A frame that cannot be solved is a PuppetError naming the frame, whatever the solve raised
    (its own PuppetError, the core's ValueError, ...). On any failure, that one or one while
    keying, the bones get back the rotations they had (the frames solved before it turned
    them), live solving and the current frame are as they were, and the exception goes on to
    the caller; no key is written when the solve fails."""
    frames = list(frames or scene_frames(scene))
    current = scene.frame_current
    bones = [pb for pb in rig.pose.bones if not all(pb.lock_rotation)]
    live = rig.get(LIVE_KEY, True)
    angles = {pb.name: [] for pb in bones}
    before = {pb.name: tuple(getattr(pb, rotation_path(pb))) for pb in bones}
    rig[LIVE_KEY] = False          # this loop solves itself; keep the handler out of it
    baked = False
    try:
        for done, f in enumerate(frames):
            scene.frame_set(f)
            try:
                solve_puppet(rig)
            except PuppetError as err:
                raise PuppetError(f"At frame {f}: {err}") from None
            except Exception as err:   # the core's ValueError for a NaN bone, a bug: the same to say
                raise PuppetError(f"At frame {f}: puppet '{rig.name}' cannot be solved "
                                  f"({type(err).__name__}: {err})") from err
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
        baked = True
    finally:
        if not baked:
            for pb in bones:
                setattr(pb, rotation_path(pb), before[pb.name])
        rig[LIVE_KEY] = live
        scene.frame_set(current)
    return len(frames)
