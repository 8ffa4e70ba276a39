"""The original rest pose: kept on the armature data (an ID property, saved in the .blend and
undoable) before MiniSkeleton first changes the rest pose, and put back exactly by Restore
Original Skeleton."""

from __future__ import annotations

import json
import math
from collections import Counter


SNAPSHOT_KEY = "miniskeleton_original_rest_pose"


def read_edit_rest_pose(edit_bones) -> dict:
    """Heads, tails, rolls, parents and connection of every edit bone (armature space)."""
    bones = list(edit_bones)
    return {
        "version": 1,
        "names": [eb.name for eb in bones],
        "heads": [list(map(float, eb.head)) for eb in bones],
        "tails": [list(map(float, eb.tail)) for eb in bones],
        "rolls": [float(eb.roll) for eb in bones],
        "parents": [eb.parent.name if eb.parent else "" for eb in bones],
        "connect": [bool(eb.use_connect) for eb in bones],
    }


def has_snapshot(arm_data) -> bool:
    return SNAPSHOT_KEY in arm_data.keys()


def store_snapshot(arm_data, snap: dict) -> None:
    """Keep ``snap`` on the armature data (an ID property: saved in the .blend, undoable).
    JSON keeps every float exactly (repr round trip)."""
    arm_data[SNAPSHOT_KEY] = json.dumps(snap)


class SnapshotError(ValueError):
    """A stored snapshot that cannot be restored (edited by hand), with the reason."""


def load_snapshot(arm_data) -> dict | None:
    """The rest pose stored on ``arm_data``, checked whole (``check_snapshot``): None when none
    is stored, SnapshotError with the reason when the stored one cannot be restored."""
    raw = arm_data.get(SNAPSHOT_KEY)
    if raw is None:
        return None
    if not isinstance(raw, str):
        raise SnapshotError(f"it is a {type(raw).__name__}, not the JSON text Keep Current as Original "
                            "writes")
    try:
        snap = json.loads(raw)
    except (ValueError, RecursionError) as err:   # JSONDecodeError is a ValueError
        raise SnapshotError(f"it is not JSON ({err})") from err
    check_snapshot(snap)
    return snap


_KEYS = ("version", "names", "heads", "tails", "rolls", "parents", "connect")
_FLOAT32_MAX = 3.4028234e38


def check_snapshot(snap) -> None:
    """SnapshotError unless ``snap`` can be restored exactly as it says (``apply_rest_pose``
    relies on it): a dict with every key of ``read_edit_rest_pose``, version 1; one entry per
    name in each list; unique names usable as bone names (1 to 63 bytes, no NUL); heads and
    tails three finite numbers each (in single precision, as Blender keeps them), at least
    1e-6 apart (Blender deletes shorter bones when Edit Mode ends); finite rolls; parents ""
    or another bone of the snapshot, with no loop (Blender ignores a parent that would make
    one); connection true or false."""
    if not isinstance(snap, dict):
        raise SnapshotError(f"it holds a {type(snap).__name__}, not a dictionary")
    missing = [k for k in _KEYS if k not in snap]
    if missing:
        raise SnapshotError(f"it has no {', '.join(missing)}")
    if type(snap["version"]) is not int or snap["version"] != 1:
        raise SnapshotError(f"its version is {snap['version']!r}, not 1")
    names = snap["names"]
    for key in _KEYS[1:]:
        if not isinstance(snap[key], list):
            raise SnapshotError(f"its {key} are a {type(snap[key]).__name__}, not a list")
        if len(snap[key]) != len(names):
            raise SnapshotError(f"it has {len(snap[key])} {key} for {len(names)} names")
    for i, name in enumerate(names):
        if not _bone_name(name):
            raise SnapshotError(f"name {i} ({_short(name)}) is not a bone name (text of 1 to 63 bytes)")
    twice = sorted(n for n, count in Counter(names).items() if count > 1)
    if twice:
        raise SnapshotError(f"the name {twice[0]!r} appears twice")
    for key in ("heads", "tails"):
        for name, point in zip(names, snap[key]):
            if not (isinstance(point, list) and len(point) == 3 and all(map(_finite, point))):
                raise SnapshotError(f"the {key[:-1]} of '{name}' ({_short(point)}) is not three finite numbers")
    for name, h, t in zip(names, snap["heads"], snap["tails"]):
        if math.dist(tuple(map(float, h)), tuple(map(float, t))) <= 1e-6:
            raise SnapshotError(f"bone '{name}' has no length (Blender would delete it)")
    for name, roll in zip(names, snap["rolls"]):
        if not _finite(roll):
            raise SnapshotError(f"the roll of '{name}' ({_short(roll)}) is not a finite number")
    index = {n: i for i, n in enumerate(names)}
    for name, parent in zip(names, snap["parents"]):
        if not isinstance(parent, str) or (parent and parent not in index):
            raise SnapshotError(f"the parent of '{name}' ({_short(parent)}) is not a bone of it")
    for i, name in enumerate(names):
        seen, at = {i}, snap["parents"][i]
        while at:
            if index[at] in seen:
                raise SnapshotError(f"the parents of '{name}' go round in a loop")
            seen.add(index[at])
            at = snap["parents"][index[at]]
    for name, c in zip(names, snap["connect"]):
        if not isinstance(c, bool):
            raise SnapshotError(f"the connection of '{name}' ({_short(c)}) is not true or false")


def _bone_name(name) -> bool:
    """Text Blender keeps as a bone name as it is: 1 to 63 bytes of UTF-8 (a lone surrogate
    from a JSON escape is none), no NUL."""
    if not isinstance(name, str) or "\0" in name:
        return False
    try:
        return 0 < len(name.encode("utf-8")) <= 63
    except UnicodeEncodeError:
        return False


def _finite(x) -> bool:
    """A number (not a bool) that is finite in single precision."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return False
    try:
        return abs(float(x)) <= _FLOAT32_MAX
    except OverflowError:   # an integer past the float range
        return False


def _short(value) -> str:
    """``value`` for a report, at most 40 characters."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def ensure_snapshot(arm_ob, edit_bones) -> bool:
    """Store the current rest pose as the original unless one is stored. Call it in Edit Mode
    before any MiniSkeleton operator changes the rest pose. True if it stored one now."""
    if has_snapshot(arm_ob.data):
        return False
    store_snapshot(arm_ob.data, read_edit_rest_pose(edit_bones))
    return True


def apply_rest_pose(edit_bones, snap: dict) -> tuple[list[str], list[str]]:
    """Put the rest pose ``snap`` (checked by ``check_snapshot``) back exactly: bones not in it
    are removed, missing ones made. Returns the names of the bones (removed, made), for the report."""
    names = snap["names"]
    wanted = set(names)
    removed = [eb.name for eb in edit_bones if eb.name not in wanted]
    for n in removed:
        edit_bones.remove(edit_bones[n])
    made = [n for n in names if edit_bones.get(n) is None]
    for n in made:
        eb = edit_bones.new(n)
        eb.tail = (0.0, 0.0, 1.0)
    ebs = [edit_bones[n] for n in names]
    for eb in ebs:
        eb.use_connect = False
        eb.parent = None
    for eb, h, t, r in zip(ebs, snap["heads"], snap["tails"], snap["rolls"]):
        eb.head = h
        eb.tail = t
        eb.roll = r
    for eb, p in zip(ebs, snap["parents"]):
        if p:
            eb.parent = edit_bones[p]
    for eb, c in zip(ebs, snap["connect"]):
        eb.use_connect = bool(c)
    return removed, made
