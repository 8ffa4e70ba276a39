"""The joint graph of a skeleton: its unique joints (bone ends that coincide, connected
children's heads on their parent's tail) and each joint's mirror partner by bone names."""

from __future__ import annotations

import numpy as np

from ..common.mirror import bone_mirror_indices


def joint_graph(heads: np.ndarray, tails: np.ndarray, parents: list[int], connected: list[bool],
                tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Unique joints of a skeleton: a connected child's head is its parent's tail, and bone ends
    closer than ``tolerance`` are one joint. Returns ``joints`` (j, 3) float64 and ``bone_joints``
    (b, 2) int32 (head joint, tail joint)."""
    b = len(heads)
    joints: list[np.ndarray] = []
    ends = np.full((b, 2), -1, dtype=np.int32)
    # joints by grid cell of side ``tolerance``: a match lies in one of the 27 cells around
    # (a scan of every joint would make Fit quadratic in the number of bones)
    cell = tolerance if tolerance > 0 else 1.0
    grid: dict[tuple[int, int, int], list[int]] = {}

    def find_or_add(p):
        p = np.asarray(p, dtype=np.float64)
        if not np.isfinite(p).all():  # never equal to another joint; the caller reports it
            joints.append(p)
            return len(joints) - 1
        key = tuple(int(k) for k in np.floor(p / cell))
        near = [i for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
                for i in grid.get((key[0] + dx, key[1] + dy, key[2] + dz), ())
                if np.linalg.norm(joints[i] - p) <= tolerance]
        if near:
            return min(near)
        joints.append(p)
        grid.setdefault(key, []).append(len(joints) - 1)
        return len(joints) - 1

    order = _parents_first(parents)
    for i in order:
        if connected[i] and parents[i] >= 0:
            ends[i, 0] = ends[parents[i], 1]
        else:
            ends[i, 0] = find_or_add(heads[i])
        ends[i, 1] = find_or_add(tails[i])
    return np.asarray(joints, dtype=np.float64).reshape(-1, 3), ends


def _parents_first(parents: list[int]) -> list[int]:
    """Bone indices with every parent before its children (no recursion: chains of thousands)."""
    done, order = set(), []
    for i in range(len(parents)):
        path = []
        while i >= 0 and i not in done:
            done.add(i)
            path.append(i)
            i = parents[i]
        order.extend(reversed(path))
    return order


def joint_mirror(bone_names: list[str], bone_joints: np.ndarray) -> np.ndarray:
    """Mirror joint of each joint by its bones' left/right names (``bone_mirror_indices``):
    the partner's joint; itself for a joint of centre bones only (it stays on the centre line);
    -1 for a joint of side bones without a partner (fitted on its own)."""
    j = int(bone_joints.max()) + 1 if len(bone_joints) else 0
    mirror = np.arange(j, dtype=np.int32)
    bone_mirror = bone_mirror_indices(bone_names)
    for bi, m in enumerate(bone_mirror):  # unpaired side bones first: a partner found later wins
        if m < 0:
            mirror[bone_joints[bi]] = -1
    for bi, m in enumerate(bone_mirror):
        if m >= 0 and m != bi:
            for end in (0, 1):
                mirror[bone_joints[bi, end]] = bone_joints[m, end]
    return mirror
