"""A motion's keys on an armature: the keys there already (the last keyed frame, the bones with
rotation or location keys), what overrides keys (rotation drivers, constraints), and the core's
motion written as keys (``write_keys``), continuing from the keys before it."""

from __future__ import annotations

import math

import bpy
import numpy as np
from mathutils import Matrix, Quaternion, Vector

from ..common.keys import (action_fcurves, action_frame, key_rotation, key_series, rotation_path, rotation_series,
                           value_at)
from ..common.reports import name_list
from ..common.transforms import axis_scales, inverse


ROT_PATHS = ("rotation_quaternion", "rotation_euler", "rotation_axis_angle")


def last_key_frame(ob: bpy.types.Object) -> float | None:
    """Scene frame of the last keyframe on ``ob``'s action, None without keys."""
    frames = [kp.co[0] for fc in action_fcurves(ob) for kp in fc.keyframe_points[-1:]]
    return action_frame(ob, max(frames), invert=True) if frames else None


def keyed_rotation_bones(ob: bpy.types.Object) -> set[str]:
    """Names of pose bones that have rotation keys."""
    return animated_pose_bones(action_fcurves(ob))


def keyed_location_bones(ob: bpy.types.Object) -> set[str]:
    """Names of pose bones that have location keys."""
    return animated_pose_bones(action_fcurves(ob), ("location",))


def driven_rotation_bones(ob: bpy.types.Object) -> set[str]:
    """Names of pose bones whose rotation has a driver (it overrides their keys)."""
    return animated_pose_bones(ob.animation_data.drivers if ob.animation_data is not None else [])


# Constraints that set or turn a bone's rotation (limits and location-only ones leave keys be).
TURNING_CONSTRAINTS = {"IK", "SPLINE_IK", "COPY_ROTATION", "COPY_TRANSFORMS", "DAMPED_TRACK", "LOCKED_TRACK",
                       "TRACK_TO", "STRETCH_TO", "CHILD_OF", "ARMATURE", "TRANSFORM", "ACTION"}


def constrained_rotation_bones(ob: bpy.types.Object) -> dict[str, str]:
    """{pose bone: constraint} for the bones whose rotation an active constraint overrides: its
    own (enabled, valid, influence > 0), or an IK constraint further down its chain."""
    out = {}
    for pb in ob.pose.bones:
        for c in pb.constraints:
            if c.type not in TURNING_CONSTRAINTS or c.mute or not c.is_valid or c.influence <= 0.0:
                continue
            out.setdefault(pb.name, c.name)
            if c.type == "IK":  # chain_count 0: up to the root
                up, k = pb.parent, 1
                while up is not None and (c.chain_count == 0 or k < c.chain_count):
                    out.setdefault(up.name, f"{c.name} of {pb.name}")
                    up, k = up.parent, k + 1
    return out


def animated_pose_bones(fcurves, paths: tuple[str, ...] = ROT_PATHS) -> set[str]:
    """Names of the pose bones whose rotation (or another of ``paths``) one of ``fcurves`` animates."""
    out = set()
    for fc in fcurves:
        path = fc.data_path
        if path.startswith('pose.bones["') and path.rsplit(".", 1)[-1] in paths:
            out.add(bpy.utils.unescape_identifier(path[len('pose.bones["'):path.rindex('"]')]))
    return out


def write_keys(context, arm, names: list[str], out, start: int) -> int:
    """Key the core's motion ``out`` (``planning.make_motion``) on ``arm``'s pose bones ``names``
    from scene frame ``start``, continuing from the keys already there: bones keyed for the first
    time hold their pose until it starts, bones an earlier motion keyed and this one leaves go
    back to rest, and the root (or the object, when the root cannot move) carries on from where
    it stands. Returns the number of frames keyed."""
    scene = context.scene
    frame_before = scene.frame_current
    rot = out.rotations
    frames = int(out.frames)
    animated = [int(b) for b in out.animated]
    pose = arm.pose.bones
    if arm.animation_data is None:
        arm.animation_data_create()
    root_pb = pose[names[out.roles.root]]
    # Where the root is now (after earlier motions), to continue from there.
    earlier = last_key_frame(arm)
    keyed_before = keyed_rotation_bones(arm)
    # feet hanging off the root (IK rigs exported without their constraints) follow their
    # legs by location keys; the core gives them in world units
    located = [int(b) for b in out.located]
    located_before = keyed_location_bones(arm) - {root_pb.name}
    unit = float(np.mean(axis_scales(arm.matrix_world)))

    if earlier is not None:
        # bones this motion keys for the first time hold their pose until it starts
        # (an F-curve holds its first key's value before it)
        for b in animated:
            pb = pose[names[b]]
            if pb.name not in keyed_before:
                pb.keyframe_insert(rotation_path(pb), frame=earlier, group=pb.name)
        for b in located:
            pb = pose[names[b]]
            if pb.name not in located_before:
                pb.keyframe_insert("location", frame=earlier, group=pb.name)
    span = range(start, start + frames)
    for b in animated:
        pb = pose[names[b]]
        before = value_at(pb, rotation_path(pb), earlier) if earlier is not None else None
        path, values = rotation_series(pb, rot[:, b], before)
        key_series(pb, path, span, values, group=pb.name)
    for b in located:
        pb = pose[names[b]]
        key_series(pb, "location", span, np.asarray(out.locations)[:, b] / unit, group=pb.name)
    # bones keyed by earlier motions that this one leaves alone go back to rest
    animated_names = {names[b] for b in animated}
    for name in keyed_before - animated_names:
        if name in pose:
            pb = pose[name]
            key_rotation(pb, Quaternion(), start, value_at(pb, rotation_path(pb), earlier))
    for name in located_before - {names[b] for b in located}:
        if name in pose:
            pose[name].location = (0.0, 0.0, 0.0)
            pose[name].keyframe_insert("location", frame=start, group=name)

    axes = root_bone_axes(arm, root_pb, out.roles)
    to_local, to_world = axes if axes is not None else (None, None)
    if earlier is not None:
        scene.frame_set(int(math.floor(earlier)))
    if to_local is not None:
        world = to_world @ root_pb.location   # drop the last frame's bob
        world.z = 0.0
        root_base = to_local @ world
    else:
        root_base = arm.location.copy()
        root_base.z = object_base_z(arm)
    scene.frame_set(frame_before)
    if out.moves_root:
        if earlier is not None:   # hold still until the motion starts
            if to_local is not None and not has_root_keys(arm, root_pb):
                root_pb.keyframe_insert("location", frame=earlier, group=root_pb.name)
            elif to_local is None and not has_object_keys(arm):
                arm.keyframe_insert("location", frame=earlier)
        key_root(arm, root_pb, to_local, root_base, out.root_offset, span)
    elif earlier is not None:
        # keep the distance travelled, drop the gait's vertical bob
        if to_local is not None and has_root_keys(arm, root_pb):
            world = to_world @ root_base
            world.z = 0.0
            root_pb.location = to_local @ world
            root_pb.keyframe_insert("location", frame=start, group=root_pb.name)
        elif to_local is None and has_object_keys(arm):
            arm.location.z = object_base_z(arm)
            arm.keyframe_insert("location", index=2, frame=start)
    return frames


def has_object_keys(arm) -> bool:
    return any(fc.data_path == "location" for fc in action_fcurves(arm))


def object_base_z(arm) -> float:
    """The object's height before any motion moved it (its first location key)."""
    for fc in action_fcurves(arm):
        if fc.data_path == "location" and fc.array_index == 2 and len(fc.keyframe_points):
            return fc.keyframe_points[0].co[1]
    return arm.location.z


def root_bone_axes(arm, root_pb, roles) -> tuple[Matrix, Matrix] | None:
    """``root_axes`` when the root bone carries the motion's root offset, None when the object
    moves instead (the rig is several trees, or the root bone cannot translate)."""
    return root_axes(arm, root_pb) if roles.single_tree else None


def root_axes(arm, root_pb) -> tuple[Matrix, Matrix] | None:
    """(world offset -> the root pose bone's location space, and back); None when it cannot
    translate (connected, or a singular frame), or when the rig is several trees: then the
    object moves instead. Inverted in double precision (``inverse``)."""
    if root_pb.bone.use_connect:
        return None
    m = np.array(arm.matrix_world.to_3x3(), dtype=np.float64) @ np.array(root_pb.bone.matrix_local.to_3x3())
    inv = inverse(m)
    if inv is None:
        return None
    return Matrix(inv.tolist()), Matrix(m.tolist())


def has_root_keys(arm, root_pb) -> bool:
    path = root_pb.path_from_id("location")
    return any(fc.data_path == path for fc in action_fcurves(arm))


def key_root(arm, root_pb, to_local, base, offsets, frames):
    """Key the root at ``base`` + world ``offsets[k]`` on ``frames[k]`` (the object when the
    root cannot move)."""
    offsets = [Vector(o) for o in np.asarray(offsets).tolist()]
    if to_local is not None:
        key_series(root_pb, "location", frames, [base + to_local @ o for o in offsets], group=root_pb.name)
    else:
        key_series(arm, "location", frames, [base + o for o in offsets])


def overridden_keys(ob: bpy.types.Object, keyed: set[str]) -> str | None:
    """Why keying the pose bones ``keyed`` would move nothing, or None: every one of them follows
    an active constraint that turns it (``constrained_rotation_bones``) or has a rotation driver,
    which override its keys (Rigify's DEF bones copy its ORG bones). The reason names them."""
    over = {name: "a rotation driver" for name in driven_rotation_bones(ob)}
    over.update(constrained_rotation_bones(ob))
    if not keyed or any(n not in over for n in keyed):
        return None
    named = [f"{n} ({over[n]})" for n in sorted(keyed)]
    return (f"no bone the motion would key can move the mesh: each follows a constraint or driver that "
            f"overrides its keys: {name_list(named, 6)}; nothing was keyed. Mute those constraints (or set "
            "their influence to 0), or key the bones that drive them")


def write_control_keys(context, arm, targets, solved: dict, start: int, returning=()) -> int:
    """Key the Rigify controls ``targets`` (``rigify_solve.Target``) to their solved transforms
    (``rigify_solve.solve``: one ``matrix_basis`` per frame) from scene frame ``start``: the rotation
    in each control's own rotation mode, continuing from its keys before, and the location where
    the target keys it. Controls keyed for the first time hold their pose until the motion
    starts; ``returning`` controls (keyed by an earlier motion, left alone by this one, solved
    the same way) get one key at ``start``. Returns the number of frames keyed."""
    pose = arm.pose.bones
    if arm.animation_data is None:
        arm.animation_data_create()
    earlier = last_key_frame(arm)
    keyed_before = keyed_rotation_bones(arm)
    located_before = keyed_location_bones(arm)
    if earlier is not None:
        for t in targets:
            pb = pose[t.name]
            if pb.name not in keyed_before:
                pb.keyframe_insert(rotation_path(pb), frame=earlier, group=pb.name)
            if t.location and pb.name not in located_before:
                pb.keyframe_insert("location", frame=earlier, group=pb.name)
    frames = len(targets[0].matrices) if targets else 0
    span = range(start, start + frames)
    for t in list(targets) + list(returning):
        pb = pose[t.name]
        mats = solved[t.name] if t in targets else solved[t.name][:1]
        before = value_at(pb, rotation_path(pb), earlier) if earlier is not None else None
        path, values = rotation_series(pb, [tuple(m.to_quaternion()) for m in mats], before)
        key_series(pb, path, span[:len(mats)], values, group=pb.name)
        if t.location:
            key_series(pb, "location", span[:len(mats)], [tuple(m.translation) for m in mats], group=pb.name)
    return frames
