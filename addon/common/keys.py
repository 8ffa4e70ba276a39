"""Keyframes: an object's action and F-curves, and a whole series of keys on one property in
one go.

``keyframe_insert`` gets slower as an F-curve grows (each key goes into a sorted array), so
keying a long motion one frame at a time grows with the square of its length. ``key_series``
writes the same keys with one array write per F-curve. Rotations are keyed in each bone's own
rotation mode, continuing from its value before (``rotation_series``).
"""

from __future__ import annotations

import math
from typing import Sequence

import bpy
import numpy as np
from mathutils import Euler, Quaternion, Vector


def action_fcurves(ob: bpy.types.ID) -> list:
    """F-curves of ``ob``'s action for its own slot (Blender 4.4+ channelbags, else legacy)."""
    ad = ob.animation_data
    if ad is None or ad.action is None:
        return []
    slot = getattr(ad, "action_slot", None)
    if slot is not None:
        try:
            from bpy_extras import anim_utils
            bag = anim_utils.action_get_channelbag_for_slot(ad.action, slot)
            return list(bag.fcurves) if bag is not None else []
        except (ImportError, AttributeError):
            pass
    return list(getattr(ad.action, "fcurves", []))


def keyed_action(ob: bpy.types.Object) -> bpy.types.Action | None:
    """The action new keys on ``ob`` go to (the tweaked strip's in NLA tweak mode), or None."""
    return ob.animation_data.action if ob.animation_data is not None else None


def action_frame(ob: bpy.types.ID, frame: float, invert: bool = False) -> float:
    """Scene ``frame`` -> the same moment in ``ob``'s action (``invert``: action -> scene).
    They differ in NLA tweak mode, where the action is a strip's (moved, scaled, repeated) and
    ``keyframe_insert`` maps the scene frame it is given, as the Dope Sheet shows it."""
    ad = getattr(ob, "animation_data", None)
    if ad is None or not ad.use_tweak_mode:
        return frame
    return ad.nla_tweak_strip_time_to_scene(frame, invert=not invert)


def _curves(owner: bpy.types.bpy_struct, path: str) -> dict:
    """{component index: F-curve} of ``owner.<path>`` in its ID's action."""
    full = owner.path_from_id(path)
    return {fc.array_index: fc for fc in action_fcurves(owner.id_data) if fc.data_path == full}


def locked_curves(ob: bpy.types.Object, bones, location: bool = False) -> str | None:
    """Why keying pose bones ``bones`` (names), and ``ob``'s location if ``location``, would
    write into F-curves their user locked against editing (``FCurve.lock``: ``keyframe_insert``
    leaves them be, and a series would not), or None. The reason names them."""
    wanted = {f'pose.bones["{bpy.utils.escape_identifier(name)}"]' for name in bones}
    locked = sorted({fc.data_path for fc in action_fcurves(ob) if fc.lock and (
        (location and fc.data_path == "location") or fc.data_path.rsplit(".", 1)[0] in wanted)})
    if not locked:
        return None
    shown = ", ".join(locked[:6]) + (f" and {len(locked) - 6} more" if len(locked) > 6 else "")
    return (f"F-curves locked against editing would be keyed: {shown}; nothing was keyed. Unlock them "
            "(Graph Editor, Channel > Toggle Channel Locking) to key them")


def value_at(owner: bpy.types.bpy_struct, path: str, frame: float) -> list[float] | None:
    """``owner.<path>`` as its F-curves give it at scene ``frame``; a component without an
    F-curve keeps the property's value (nothing animates it). None when none is keyed."""
    curves = _curves(owner, path)
    if not curves:
        return None
    at = action_frame(owner.id_data, frame)
    now = list(getattr(owner, path))
    return [curves[i].evaluate(at) if i in curves else now[i] for i in range(len(now))]


def key_series(owner: bpy.types.bpy_struct, path: str, frames: Sequence[float], values,
               group: str | None = None) -> None:
    """Key ``owner.<path>`` (a vector property of a pose bone or an object) to ``values[k]`` at
    ``frames[k]`` (scene frames, ascending): the keys ``keyframe_insert`` makes one frame at a
    time, in one go (in NLA tweak mode, at the tweaked strip's action frames).

    Blender keys the first frame itself (making the action, slot, F-curves and ``group`` as
    usual); the others are added to those F-curves as arrays, with the first key's
    interpolation, handle and key types and easing (whatever Blender chose for it), and
    the curves are sorted and their handles recomputed once. Where a curve already has keys
    between the first frame and the last, each frame is keyed by ``keyframe_insert`` instead, so
    that Blender's own rules replace them. The property is left at the last frame's value.
    """
    values = np.asarray(values, dtype=np.float64).reshape(len(frames), -1)
    frames = [float(f) for f in frames]
    kw = {"group": group} if group else {}
    setattr(owner, path, values[0].tolist())
    owner.keyframe_insert(path, frame=frames[0], **kw)
    if len(frames) < 2:
        return
    at_frames = [action_frame(owner.id_data, f) for f in frames]
    curves = _curves(owner, path)
    co = {}   # each curve's keys (frame, value) as read once
    for i, fc in curves.items():
        co[i] = np.empty(2 * len(fc.keyframe_points))
        fc.keyframe_points.foreach_get("co", co[i])
    lo, hi = at_frames[1], at_frames[-1]
    if sorted(curves) != list(range(values.shape[1])) or any(
            ((c[0::2] >= lo) & (c[0::2] <= hi)).any() for c in co.values()):
        for f, v in zip(frames[1:], values[1:]):
            setattr(owner, path, v.tolist())
            owner.keyframe_insert(path, frame=f, **kw)
        return
    new = len(frames) - 1
    for i, fc in curves.items():
        points = fc.keyframe_points
        old = len(points)
        at = np.flatnonzero(co[i][0::2] == np.float32(at_frames[0]))
        first = int(at[0]) if len(at) else old - 1   # the key Blender just made
        points.add(new)
        points.foreach_set("co", np.concatenate([co[i], np.column_stack([at_frames[1:], values[1:, i]]).ravel()]))
        for prop in ("interpolation", "handle_left_type", "handle_right_type", "type", "easing"):
            kinds = np.empty(old + new, dtype=np.int32)
            points.foreach_get(prop, kinds)
            kinds[old:] = kinds[first]
            points.foreach_set(prop, kinds)
        fc.update()
    setattr(owner, path, values[-1].tolist())


def rotation_path(pb: bpy.types.PoseBone) -> str:
    """The property that holds ``pb``'s rotation in its rotation mode."""
    return {"QUATERNION": "rotation_quaternion", "AXIS_ANGLE": "rotation_axis_angle"}.get(
        pb.rotation_mode, "rotation_euler")


def rotation_series(pb: bpy.types.PoseBone, quats, before=None) -> tuple[str, list]:
    """``pb``'s rotation path and its values for the rotations ``quats`` ((frames, 4) w, x, y,
    z) in its own rotation mode, continuing from ``before`` (the path's value just before the
    first, when known) so that F-curves interpolate each step the short way: quaternions stay
    in one hemisphere, Euler angles make no 360 jumps, and an axis-angle keeps its axis on one
    side (a swing through rest goes from (+a, n) to (-a, n), not to (a, -n), whose components
    pass through a zero axis) and its angle within half a turn of the previous one."""
    qs = [Quaternion([float(x) for x in q]) for q in quats]
    mode = pb.rotation_mode
    values = []
    if mode == "QUATERNION":
        prev = Quaternion(before) if before is not None else None
        for q in qs:
            if prev is not None and q.dot(prev) < 0.0:
                q = -q
            values.append(tuple(q))
            prev = q
    elif mode == "AXIS_ANGLE":
        prev_angle, prev_axis = (before[0], Vector(before[1:])) if before is not None else (None, None)
        for q in qs:
            axis, angle = q.to_axis_angle()
            if prev_axis is not None and prev_axis.length > 0.0:
                if abs(angle) < 1e-7:             # rest: any axis, so keep the previous one
                    axis = prev_axis.normalized()
                elif axis.dot(prev_axis) < 0.0:
                    axis, angle = -axis, -angle
                angle += math.tau * round((prev_angle - angle) / math.tau)
            values.append((angle, *axis))
            prev_angle, prev_axis = angle, axis
    else:
        euler = Euler(before, mode) if before is not None else None
        for q in qs:
            euler = q.to_euler(mode, euler) if euler is not None else q.to_euler(mode)
            values.append(tuple(euler))
    return rotation_path(pb), values


def key_rotation(pb: bpy.types.PoseBone, q: Quaternion, frame: float, before=None) -> None:
    """Set and key ``pb``'s rotation to ``q`` in its own rotation mode (continuing from ``before``,
    see ``rotation_series``)."""
    path, values = rotation_series(pb, [q], before)
    key_series(pb, path, [frame], values, group=pb.name)
