"""Left and right bones by name: Blender's name flip (.L/.R, _L/_R, Left/Right) and each bone's
mirror partner. The rule is the Rust core's (``skeleton/names.rs``), the one the motion's roles
read too; this module only calls it."""

from __future__ import annotations

import numpy as np

from . import native


def mirror_name(name: str) -> str:
    """Blender's left/right name flip (.L/.R, _L/_R, -l, Left/Right, left/right); the name itself if none."""
    core = native.core()
    return core.mirror_name(name)


def bone_mirror_indices(names: list[str]) -> np.ndarray:
    """For each bone, the index of its mirror bone by name, (b,) int32: itself for a centre bone
    (no side in its name), -1 for a side bone whose partner is missing (the flipped name, or the
    one bone matching it up to a trailing number; pairs agree both ways)."""
    core = native.core()
    return np.asarray(core.bone_mirror_indices(list(names)), dtype=np.int32)
