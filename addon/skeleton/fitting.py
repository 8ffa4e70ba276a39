"""Fit Skeleton's work, without reports: the armature's skeleton read without entering Edit
Mode, the joints and bones the fit sees, which joints move, the core's fit
(``miniskeleton_core.fit_joints``) in the armature's frame, and the fitted bone ends written to
the armature."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .editing import armature_edit, bone_children_stay, current_bones, place_bone_ends
from .joints import joint_graph, joint_mirror
from .snapshot import ensure_snapshot


class Skeleton(NamedTuple):
    """An armature's bones as the rigger sees them (``current_bones``): the bones, their names,
    heads and tails (b, 3) float64 in armature space, parents (b,) (-1 for roots); its joints
    (j, 3) and each bone's (head, tail) joint (b, 2) (``joint_graph``); its size (the diagonal of
    its bones' bounding box)."""
    bones: list
    names: list[str]
    heads: np.ndarray
    tails: np.ndarray
    parents: list[int]
    joints: np.ndarray
    ends: np.ndarray
    size: float


def read_skeleton(arm) -> Skeleton | None:
    """``arm``'s skeleton, read without entering Edit Mode (which would re-evaluate its action,
    dropping a pose the rigger has not keyed); None when it has no bones."""
    bones, heads, tails = current_bones(arm)
    if not bones:
        return None
    names = [b.name for b in bones]
    index = {n: i for i, n in enumerate(names)}
    parents = [index[b.parent.name] if b.parent else -1 for b in bones]
    connected = [bool(b.use_connect) for b in bones]
    # Joints coincide relative to the skeleton's size (a stray mesh vertex far away
    # must not merge distinct joints).
    size = float(np.linalg.norm(np.ptp(np.concatenate([heads, tails]), axis=0)))
    joints, ends = joint_graph(heads, tails, parents, connected, 1e-6 * max(size, 1e-30))
    return Skeleton(bones, names, heads, tails, parents, joints, ends, size)


def fit_graph(ends, real, parents, follow, names):
    """The joints and bones the fit sees: (joint indices (k,), bones (e,2) uint32 into them,
    mirror (k,) int32). Without ``follow`` every bone end is a joint and every bone an edge. With
    ``follow`` (a rig whose tails were invented by an importer) only bone heads and tails that are
    some bone's head are joints, and the edges are the bones whose tail is such a joint plus
    parent head -> child head (glTF's own joint hierarchy)."""
    nj = int(ends.max()) + 1
    if not follow:
        keep = np.arange(nj)
        edges = [tuple(e) for e in ends[real]]
    else:
        is_head = np.zeros(nj, dtype=bool)
        is_head[ends[:, 0]] = True
        keep = np.flatnonzero(is_head)
        edges = []
        for i, (h, t) in enumerate(ends):
            if real[i] and is_head[t]:
                edges.append((h, t))
            p = parents[i]
            if p >= 0 and ends[p, 0] != h:
                edges.append((ends[p, 0], h))
        seen, uniq = set(), []
        for a, b in edges:
            if (a, b) not in seen and (b, a) not in seen:
                seen.add((a, b))
                uniq.append((a, b))
        edges = uniq
    pos = np.full(nj, -1, dtype=np.int64)
    pos[keep] = np.arange(len(keep))
    bones = np.array([(pos[a], pos[b]) for a, b in edges], dtype=np.uint32).reshape(-1, 2)
    full = joint_mirror(names, ends)
    # A partner that is not a fitted joint (an invented tail) leaves the joint free (-1).
    mirror = np.array([pos[m] if 0 <= m < nj and pos[m] >= 0 else -1 for m in full[keep]], dtype=np.int32)
    return keep, bones, mirror


def movable_joints(mode: str, bones, pose_sel: dict, ends: np.ndarray, nj: int) -> tuple[np.ndarray, np.ndarray]:
    """(movable, controls) (nj,) bools: the selected joints (bone ends selected in Edit Mode,
    ends of bones selected in Pose Mode); with none selected, every joint of a deform bone,
    and the joints only non-deform bones use (IK and pole targets, a root on the ground:
    controls, which place no weight) are the ``controls`` that keep their place."""
    sel = np.zeros(nj, dtype=bool)
    if mode == "EDIT":
        for i, eb in enumerate(bones):
            sel[ends[i, 0]] |= eb.select_head
            sel[ends[i, 1]] |= eb.select_tail
    elif mode == "POSE":
        for i, eb in enumerate(bones):
            if pose_sel.get(eb.name):
                sel[ends[i]] = True
    controls = np.zeros(nj, dtype=bool)
    if sel.any():
        return sel, controls
    deform = np.zeros(nj, dtype=bool)
    for i, eb in enumerate(bones):
        if eb.use_deform:
            deform[ends[i]] = True
    if deform.any():
        return deform, ~deform
    return np.ones(nj, dtype=bool), controls


class FitError(ValueError):
    """The core could not fit the skeleton; the message is for the status bar."""


def fit_skeleton(core, skel: Skeleton, verts: np.ndarray, tris: np.ndarray, stretch: np.ndarray,
                 movable: np.ndarray, follow: bool, symmetry: str, rounds: int, max_move: float):
    """Fit the ``movable`` joints ((j,) bool) of ``skel`` into the mesh (``verts`` in the
    armature's frame, ``tris``); ``stretch``: the armature's scale S (``armature_frame``), which
    maps armature space to its frame; ``follow``: invented tails follow their bones;
    ``symmetry`` "X": mirrored joints end mirrored across the armature's x = 0; ``max_move``: a
    fraction of the mesh's diagonal. Returns (new heads, new tails (b, 3) in armature space,
    the core's report, the indices of the joints fitted); FitError when the core fails."""
    joints, ends = skel.joints, skel.ends
    joints_f = joints @ stretch  # S is symmetric
    real = ends[:, 0] != ends[:, 1]
    fit_j, fit_bones, mirror = fit_graph(ends, real, skel.parents, follow, skel.names)
    kw = {}
    if symmetry == "X":
        kw = dict(symmetry_axis=0, symmetry_plane=0.0, joint_mirror=mirror)
    try:
        rep = core.fit_joints(verts, tris, joints_f[fit_j].astype(np.float32), fit_bones,
                              movable[fit_j], rounds=rounds, tip=not follow, max_move=max_move, **kw)
    except (ValueError, RuntimeError) as err:
        raise FitError(f"Fit failed: {err}; nothing was changed") from err
    new = joints.copy()
    new[fit_j] = np.linalg.solve(stretch, np.asarray(rep.joints, dtype=np.float64).T).T
    fitted = np.zeros(len(joints), dtype=bool)
    fitted[fit_j] = True
    new_heads = new[ends[:, 0]]
    new_tails = new[ends[:, 1]]
    heads, tails = skel.heads, skel.tails
    for i in range(len(skel.bones)):
        h = new_heads[i]
        # An invented tail (not fitted) keeps the bone's direction and length from its head.
        if not (real[i] and fitted[ends[i, 1]]) or np.linalg.norm(new_tails[i] - h) <= 1e-6 * skel.size:
            new_tails[i] = h + (tails[i] - heads[i])  # and never collapse a bone (Blender deletes it)
    return new_heads, new_tails, rep, fit_j


def place_fitted(context, arm, names: list[str], heads: np.ndarray, tails: np.ndarray) -> None:
    """Move the bones ``names`` to ``heads`` / ``tails`` (armature space), their rolls kept
    aligned, after storing the original rest pose if none is stored; objects parented to bones
    stay where they are."""
    with bone_children_stay(arm), armature_edit(context, arm) as ebs:
        ensure_snapshot(arm, ebs)
        edit = [ebs[n] for n in names]
        place_bone_ends(edit, heads, tails, [eb.z_axis.copy() for eb in edit])
