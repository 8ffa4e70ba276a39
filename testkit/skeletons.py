"""Skeletons as the core takes them (heads, tails, parents, rest frames, names), for the tests of
the Python API that need no Blender."""

from __future__ import annotations

import numpy as np


def biped():
    """Hips, spine, neck, head, two two-bone legs and two arms, +Z up, metres."""
    heads = [[0, 0, 1], [0, 0, 1.2], [0, 0, 1.5], [0, 0, 1.6], [0.1, 0, 1], [0.1, 0, 0.5],
             [-0.1, 0, 1], [-0.1, 0, 0.5], [0.2, 0, 1.45], [-0.2, 0, 1.45]]
    tails = [[0, 0, 1.2], [0, 0, 1.5], [0, 0, 1.6], [0, 0, 1.8], [0.1, 0, 0.5], [0.1, 0, 0],
             [-0.1, 0, 0.5], [-0.1, 0, 0], [0.5, 0, 1.45], [-0.5, 0, 1.45]]
    names = ["hips", "spine", "neck", "head", "thigh.L", "shin.L", "thigh.R", "shin.R", "arm.L", "arm.R"]
    return (np.array(heads, np.float32), np.array(tails, np.float32), np.array([-1, 0, 1, 2, 0, 4, 0, 6, 1, 1]),
            np.tile(np.eye(3, dtype=np.float32), (10, 1, 1)), names)
