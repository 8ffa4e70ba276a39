"""Changing an armature's rest pose: Edit Mode for a block (the mode, active object and pose
put back afterwards), the bones as the rigger sees them without changing mode, bone ends
placed with their connections kept, and bone-parented objects that stay where they are while
their bones move."""

from __future__ import annotations

from contextlib import contextmanager

import bpy
import numpy as np

from ..common.armatures import rest_pose
from ..common.objects import follows_bone, unconstrained_world, viewport_hidden


_POSE_CHANNELS = ("location", "rotation_quaternion", "rotation_euler", "rotation_axis_angle", "scale")


def pose_values(arm_ob) -> dict[str, np.ndarray] | None:
    """Every pose bone's local transform channels, read at once: {channel: (bones, width)};
    None for an armature not evaluated yet (it has no pose)."""
    if arm_ob.pose is None:
        return None
    bones = arm_ob.pose.bones
    out = {}
    for name in _POSE_CHANNELS:
        width = 4 if name in ("rotation_quaternion", "rotation_axis_angle") else 3
        out[name] = np.empty(len(bones) * width, dtype=np.float32)
        bones.foreach_get(name, out[name])
        out[name] = out[name].reshape(len(bones), width)
    out["names"] = [b.name for b in bones]
    return out


def put_back_pose(arm_ob, before: dict | None) -> None:
    """Give the pose bones still named as in ``before`` (``pose_values``) those values again
    where they changed: leaving Edit Mode re-evaluates the armature's action, which drops pose
    changes not yet keyed on animated bones (as Tab does), though the pose is the rigger's."""
    now = pose_values(arm_ob)
    if before is None or now is None:
        return
    index = {name: i for i, name in enumerate(now["names"])}
    bones = arm_ob.pose.bones
    for i, name in enumerate(before["names"]):
        j = index.get(name)
        if j is None:
            continue
        for channel in _POSE_CHANNELS:
            if not np.array_equal(before[channel][i], now[channel][j]):
                setattr(bones[j], channel, before[channel][i].tolist())


@contextmanager
def armature_edit(context, arm_ob):
    """Edit Mode on ``arm_ob`` for the block (edit bones in armature space), then the previous
    mode and active object again, with the pose as it was (``put_back_pose``). Yields
    ``arm_ob.data.edit_bones``. An armature disabled in viewports (which Blender does not let
    into Edit Mode) is enabled for the block only."""
    view_layer = context.view_layer
    prev_active = view_layer.objects.active
    prev_mode = arm_ob.mode
    pose = pose_values(arm_ob) if prev_mode != "EDIT" else None
    with viewport_hidden(arm_ob, False):
        if prev_active is not arm_ob:
            if prev_active is not None and prev_active.mode != "OBJECT":
                bpy.ops.object.mode_set(mode="OBJECT")
            view_layer.objects.active = arm_ob
        if arm_ob.mode != "EDIT":
            bpy.ops.object.mode_set(mode="EDIT")
        try:
            yield arm_ob.data.edit_bones
        finally:
            if prev_mode != "EDIT":
                bpy.ops.object.mode_set(mode=prev_mode)
                put_back_pose(arm_ob, pose)
            else:
                arm_ob.update_from_editmode()
            if prev_active is not arm_ob and prev_active is not None:
                view_layer.objects.active = prev_active


def current_bones(arm_ob) -> tuple[list, np.ndarray, np.ndarray]:
    """The armature's bones as the rigger sees them, read without changing mode: its edit bones
    in Edit Mode (edits not yet in its bones), else its bones; with their heads and tails (b, 3)
    float64 in armature space."""
    edit = arm_ob.mode == "EDIT"
    bones = list(arm_ob.data.edit_bones if edit else arm_ob.data.bones)
    heads = np.array([b.head if edit else b.head_local for b in bones], dtype=np.float64).reshape(-1, 3)
    tails = np.array([b.tail if edit else b.tail_local for b in bones], dtype=np.float64).reshape(-1, 3)
    return bones, heads, tails


@contextmanager
def bone_children_stay(arm_ob):
    """Objects parented to bones of ``arm_ob`` (Bone parenting: a robot's rigid parts, a
    prop in a hand) keep their rest-pose place while the block moves bones: Blender would carry
    them along with their bone, so fitting a skeleton would move the very mesh it is fitted to.
    Their parent inverse is solved again afterwards; the armature stays in its rest position for
    the block, and its pose is left as it was."""
    children = [o for o in bpy.data.objects if follows_bone(o, arm_ob)]
    if not children:
        yield
        return
    with rest_pose(arm_ob, children):
        # Before their constraints act, which act again on the new parenting.
        before = [unconstrained_world(o) for o in children]
        try:
            yield
        finally:
            bpy.context.view_layer.update()  # the children where their moved bones took them
            for o, w0 in zip(children, before):
                basis = o.matrix_basis.copy()
                # world = parent @ parent_inverse @ basis: keep world, solve parent_inverse.
                w1 = unconstrained_world(o)
                o.matrix_parent_inverse = (o.matrix_parent_inverse @ basis @ w1.inverted_safe()
                                           @ w0 @ basis.inverted_safe())
            bpy.context.view_layer.update()


def place_bone_ends(edit_bones, heads, tails, z_axes=None) -> None:
    """Move every edit bone to ``heads[i]``/``tails[i]`` (armature space), keeping which bones
    are connected: connections are dropped first so that moving a child never drags its
    parent's tail, then put back. With ``z_axes``, each bone's roll is re-aligned to it."""
    ebs = list(edit_bones)
    connected = [eb.use_connect for eb in ebs]
    for eb in ebs:
        eb.use_connect = False
    for i, eb in enumerate(ebs):
        eb.head = heads[i]
        eb.tail = tails[i]
        if z_axes is not None:
            eb.align_roll(z_axes[i])
    for eb, c in zip(ebs, connected):
        eb.use_connect = c
