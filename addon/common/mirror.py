"""Left and right bones by name: Blender's name flip (.L/.R, _L/_R, Left/Right) and each bone's
mirror partner."""

from __future__ import annotations

import re

import numpy as np


_MIRROR_PATTERNS = [
    (r"([._\- ])([Ll])$", {"L": "R", "l": "r"}),
    (r"([._\- ])([Rr])$", {"R": "L", "r": "l"}),
    (r"^([Ll])([._\- ])", {"L": "R", "l": "r"}),
    (r"^([Rr])([._\- ])", {"R": "L", "r": "l"}),
    # Not Blender's own rule, but common in rigs from other tools: leg_back_L_knee.
    (r"([._\-])([LlRr])([._\-])", {"L": "R", "l": "r", "R": "L", "r": "l"}),
]


def mirror_name(name: str) -> str:
    """Blender's left/right name flip (.L/.R, _L/_R, -l, Left/Right, left/right); the name itself if none."""
    for pat, swap in _MIRROR_PATTERNS:
        m = re.search(pat, name)
        if m:
            s, e = m.span()
            part = m.group(0)
            flipped = "".join(swap.get(c, c) for c in part)
            return name[:s] + flipped + name[e:]
    for a, b in (("Left", "Right"), ("Right", "Left"), ("left", "right"), ("right", "left"),
                 ("LEFT", "RIGHT"), ("RIGHT", "LEFT")):
        if a in name:
            return name.replace(a, b, 1)
    return name


def _unnumbered(name: str) -> str:
    """``name`` without a trailing number (glTF exporters number nodes: b_LeftHand_011)."""
    return re.sub(r"[._\-]?\d+$", "", name)


def bone_mirror_indices(names: list[str]) -> np.ndarray:
    """For each bone, the index of its mirror bone by name, (b,) int32: itself for a centre bone
    (no side in its name), -1 for a side bone whose partner is missing.

    The partner is the flipped name (``mirror_name``), or else the one bone whose name matches it
    up to a trailing number (b_LeftUpperArm_09 <-> b_RightUpperArm_06). Pairs agree both ways.
    """
    index = {n: i for i, n in enumerate(names)}
    by_stem: dict[str, list[int]] = {}
    for i, n in enumerate(names):
        by_stem.setdefault(_unnumbered(n), []).append(i)
    out = np.full(len(names), -1, dtype=np.int32)
    for i, n in enumerate(names):
        other = mirror_name(n)
        if other == n:
            out[i] = i
        elif other in index:
            out[i] = index[other]
        else:
            same = by_stem.get(_unnumbered(other), [])
            out[i] = same[0] if len(same) == 1 else -1
    agree = np.array([m >= 0 and out[m] == i for i, m in enumerate(out)], dtype=bool)
    out[~agree] = -1
    return out
