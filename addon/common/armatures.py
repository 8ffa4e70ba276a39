"""Armatures as arrays: the armature an operator acts on, its deform bones in world space
(``Bones``), B-Bone rest curves, Pose Mode flags, whether its tails look invented by an importer,
and the rest position for reading bone-parented meshes."""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field

import bpy
import numpy as np

from .objects import follows_bone
from .transforms import world_points


def find_armature(context: bpy.types.Context) -> bpy.types.Object | None:
    """The active armature; else a selected one; else the active mesh's Armature modifier or parent."""
    active = context.active_object
    if active is not None and active.type == "ARMATURE":
        return active
    for ob in context.selected_objects:
        if ob.type == "ARMATURE":
            return ob
    if active is not None and active.type == "MESH":
        for mod in active.modifiers:
            if mod.type == "ARMATURE" and mod.object is not None:
                return mod.object
        if active.parent is not None and active.parent.type == "ARMATURE":
            return active.parent
    return None


@dataclass
class Bones:
    """Deform bones of an armature in world space (rest pose).

    names: bone names (b,); heads, tails: (b, 3) float64 world space; parents: (b,) int32
    index into these bones or -1; selected: (b,) bool; skipped: names of zero-length bones;
    hidden: names of bones left out as hidden (``armature_bones(weight_paint=True)``);
    imported: the armature looks imported (see ``invented_tails``); curve_points (p, 3)
    float64 world space and curve_bones (p,) uint32: the inner joints of each B-Bone's rest
    curve, head to tail (empty unless filled from ``bbone_curves``, for Heat).
    """

    names: list[str]
    heads: np.ndarray
    tails: np.ndarray
    parents: np.ndarray
    selected: np.ndarray
    skipped: list[str] = field(default_factory=list)
    hidden: list[str] = field(default_factory=list)
    imported: bool = False
    curve_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    curve_bones: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint32))


@contextmanager
def rest_pose(arm_ob: bpy.types.Object, meshes):
    """For the duration, ``arm_ob`` in its rest position when some of ``meshes`` follow one of
    its bones (``follows_bone``), so they are read where they are in the rest pose, as the bones
    are; then the armature as it was."""
    data = arm_ob.data
    if not any(follows_bone(ob, arm_ob) for ob in meshes) or data.pose_position == "REST":
        yield
        return
    data.pose_position = "REST"
    bpy.context.view_layer.update()
    try:
        yield
    finally:
        data.pose_position = "POSE"
        bpy.context.view_layer.update()


def pose_flag(arm_ob: bpy.types.Object, bone: bpy.types.Bone, flag: str) -> bool:
    """``bone``'s Pose Mode ``flag`` ("select" or "hide"): Blender 5.0 keeps it on the pose
    bone, 4.x on the bone."""
    pb = arm_ob.pose.bones.get(bone.name) if arm_ob.pose else None
    if pb is not None and hasattr(pb, flag):
        return bool(getattr(pb, flag))
    return bool(getattr(bone, flag, False))


def _in_visible_collection(bone: bpy.types.Bone) -> bool:
    """A bone in no collection, or in one that shows (Blender's ``ANIM_bone_in_visible_collection``)."""
    return not bone.collections or any(c.is_visible_effectively for c in bone.collections)


def armature_bones(arm_ob: bpy.types.Object, min_length: float = 0.0, weight_paint: bool = False) -> Bones:
    """Deform bones of ``arm_ob`` in world space; bones shorter than ``min_length`` are skipped.
    ``weight_paint``: as Blender's Weight Paint > Assign Automatic from Bones, bones hidden in
    Pose Mode are left out (``hidden``), and a bone counts as selected only in a visible collection."""
    m = np.array(arm_ob.matrix_world, dtype=np.float64)
    deform = [b for b in arm_ob.data.bones if b.use_deform]
    names, heads, tails, sel, skipped, hidden = [], [], [], [], [], []
    for b in deform:
        if weight_paint and pose_flag(arm_ob, b, "hide"):
            hidden.append(b.name)
            continue
        h = m[:3, :3] @ np.array(b.head_local) + m[:3, 3]
        t = m[:3, :3] @ np.array(b.tail_local) + m[:3, 3]
        if not np.all(np.isfinite(h)) or not np.all(np.isfinite(t)) or np.linalg.norm(t - h) <= min_length:
            skipped.append(b.name)
            continue
        names.append(b.name)
        heads.append(h)
        tails.append(t)
        sel.append(pose_flag(arm_ob, b, "select") and (not weight_paint or _in_visible_collection(b)))
    index = {n: i for i, n in enumerate(names)}
    parents = []
    for n in names:
        p = arm_ob.data.bones[n].parent
        while p is not None and p.name not in index:  # skip non-deform / skipped ancestors
            p = p.parent
        parents.append(index[p.name] if p is not None else -1)
    as3 = lambda rows: np.asarray(rows, dtype=np.float64).reshape(-1, 3)  # noqa: E731
    return Bones(names, as3(heads), as3(tails), np.asarray(parents, dtype=np.int32),
                 np.asarray(sel, dtype=bool), skipped, hidden, imported=invented_tails(arm_ob.data.bones))


def bbone_curves(arm_ob: bpy.types.Object, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Inner joints of the rest curve of each of ``names`` that is a B-Bone (more than one
    segment), in world space, head to tail: (p, 3) float64 and the index into ``names`` of
    each, (p,) uint32 (for ``Bones.curve_points`` / ``curve_bones``). Blender's bone heat
    weights a B-Bone as these segments (its rest shape is a curve when its handles or curve
    settings bend it)."""
    points, owners = [], []
    refreshed = False
    for j, name in enumerate(names):
        bone, pose_bone = arm_ob.data.bones[name], arm_ob.pose.bones.get(name) if arm_ob.pose else None
        if bone.bbone_segments < 2 or pose_bone is None:
            continue
        joints = _bbone_joints(pose_bone, bone.bbone_segments)
        if joints is None and not refreshed:  # out-of-date segment data: evaluate the armature once
            refreshed = True
            bpy.context.view_layer.update()
            joints = _bbone_joints(pose_bone, bone.bbone_segments)
        if joints is None:  # unreadable: the bone stays straight
            continue
        points += [tuple(bone.matrix_local @ joint) for joint in joints]
        owners += [j] * len(joints)
    return world_points(arm_ob, np.asarray(points, dtype=np.float64)), np.asarray(owners, dtype=np.uint32)


def _bbone_joints(pose_bone: bpy.types.PoseBone, segments: int) -> list | None:
    """The rest joints between ``pose_bone``'s B-Bone segments in bone space, or None when
    Blender has no up-to-date segment data for it."""
    try:
        return [pose_bone.bbone_segment_matrix(k, rest=True).translation.copy() for k in range(1, segments)]
    except RuntimeError:
        return None


def invented_tails(bones) -> bool:
    """Does this armature look imported from glTF/FBX, whose tails the importer invented?
    True when no bone is connected to its parent (rigs built in Blender have connected
    chains). ``bones``: an armature's bones or edit bones. The Auto rule of both Auto Weights'
    Bone Extent and Fit's Free Tails."""
    return not any(b.use_connect for b in bones)
