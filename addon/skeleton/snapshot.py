"""The original rest pose: kept on the armature data (an ID property, saved in the .blend and
undoable) before MiniSkeleton first changes the rest pose, and put back exactly by Restore
Original Skeleton."""

from __future__ import annotations

import json


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


def load_snapshot(arm_data) -> dict | None:
    raw = arm_data.get(SNAPSHOT_KEY)
    if raw is None:
        return None
    try:
        snap = json.loads(raw)
    except (TypeError, ValueError):
        return None
    return snap if isinstance(snap, dict) and "names" in snap else None


def ensure_snapshot(arm_ob, edit_bones) -> bool:
    """Store the current rest pose as the original unless one is stored. Call it in Edit Mode
    before any MiniSkeleton operator changes the rest pose. True if it stored one now."""
    if has_snapshot(arm_ob.data):
        return False
    store_snapshot(arm_ob.data, read_edit_rest_pose(edit_bones))
    return True


def apply_rest_pose(edit_bones, snap: dict) -> tuple[list[str], list[str]]:
    """Put the rest pose ``snap`` back exactly: bones not in it are removed, missing ones made.
    Returns the names of the bones (removed, made), for the report."""
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
