"""Test shapes for Auto Rig built from primitives: Skin-modifier bodies over small graphs
(``rig_corpus.skin_body``), in metres, +Z up. Each is a shape class Auto Rig must read: a long,
low lizard on splayed legs (faces -Y), a snake lying in curves (head at -Y), a fish resting on
its fins (faces +X), a bird on two legs with its wings spread (faces -Y), an upright moth on its
abdomen and hind wing tips, a cone on four flippers, and a hare on four legs with two long
ears on its head (faces -Y).

    import shapes
    body = shapes.build("lizard")   # a mesh object in the current scene
"""

from __future__ import annotations

import math

import numpy as np

# name: (chains: lists of (point, radius) joined in order; a chain's first point may repeat an
# earlier one to branch from it)
SHAPES: dict[str, list[list[tuple[tuple[float, float, float], float]]]] = {}


def _mirrored(chain):
    return [((-x, y, z), r) for (x, y, z), r in chain]


_lizard = [[((0, -0.85, 0.15), 0.05), ((0, -0.7, 0.16), 0.08), ((0, -0.5, 0.15), 0.06), ((0, -0.3, 0.15), 0.09),
            ((0, 0.0, 0.15), 0.1), ((0, 0.22, 0.15), 0.09), ((0, 0.5, 0.12), 0.06), ((0, 0.9, 0.08), 0.04),
            ((0, 1.3, 0.05), 0.025)]]
for _y in (-0.3, 0.22):
    _leg = [((0, _y, 0.15), 0.06), ((0.24, _y + 0.02, 0.17), 0.04), ((0.29, _y - 0.02, 0.04), 0.035),
            ((0.31, _y - 0.1, 0.025), 0.025)]
    _lizard += [_leg, _mirrored(_leg)]
SHAPES["lizard"] = _lizard

SHAPES["snake"] = [[((0.18 * math.sin(3 * math.pi * t), -1.2 + 2.4 * t, 0.065),
                     0.06 if t < 0.8 else 0.06 - 0.2 * (t - 0.8)) for t in np.linspace(0, 1, 17)]
                   + [], [((0.0, -1.2, 0.065), 0.06), ((0.0, -1.3, 0.075), 0.085), ((0.0, -1.4, 0.07), 0.05)]]

_fish = [[((-1.0, 0, 0.42), 0.02), ((-0.8, 0, 0.22), 0.04), ((-0.5, 0, 0.2), 0.1), ((-0.2, 0, 0.2), 0.18),
          ((0.25, 0, 0.2), 0.18), ((0.5, 0, 0.2), 0.13), ((0.65, 0, 0.2), 0.06)],
         [((-0.8, 0, 0.22), 0.04), ((-1.0, 0, 0.04), 0.02)],
         [((0.0, 0, 0.2), 0.15), ((-0.1, 0, 0.5), 0.03)]]
for _fin in ([((0.25, 0.12, 0.12), 0.05), ((0.32, 0.36, 0.03), 0.025)],
             [((-0.25, 0.1, 0.1), 0.04), ((-0.3, 0.3, 0.03), 0.02)]):
    _fish += [[((x, y, z), r) for (x, y, z), r in _fin], [((x, -y, z), r) for (x, y, z), r in _fin]]
SHAPES["fish"] = _fish

_bird = [[((0, 0.42, 0.32), 0.02), ((0, 0.15, 0.36), 0.05), ((0, 0.05, 0.37), 0.1), ((0, -0.08, 0.4), 0.09),
          ((0, -0.14, 0.52), 0.045), ((0, -0.18, 0.6), 0.06), ((0, -0.3, 0.58), 0.02)]]
_bleg = [((0, 0.05, 0.33), 0.05), ((0.06, 0.0, 0.17), 0.022), ((0.06, 0.04, 0.04), 0.016), ((0.06, -0.07, 0.02), 0.014)]
_wing = [((0, -0.04, 0.42), 0.06), ((0.3, 0.0, 0.48), 0.035), ((0.5, 0.04, 0.46), 0.028), ((0.72, 0.1, 0.42), 0.012)]
SHAPES["bird"] = _bird + [_bleg, _mirrored(_bleg), _wing, _mirrored(_wing)]

_moth = [[((0, 0, 0.03), 0.05), ((0, 0, 0.3), 0.08), ((0, 0, 0.6), 0.1), ((0, -0.02, 0.85), 0.07)]]
_fore = [((0, 0, 0.64), 0.07), ((0.5, 0, 0.95), 0.06), ((0.8, 0, 0.72), 0.03)]
_hind = [((0, 0, 0.52), 0.06), ((0.4, 0, 0.3), 0.05), ((0.5, 0, 0.04), 0.03)]
SHAPES["moth"] = _moth + [_fore, _mirrored(_fore), _hind, _mirrored(_hind)]

_cone = [[((0, 0, -0.06), 0.45), ((0, 0, 0.4), 0.36), ((0, 0, 0.7), 0.26), ((0, 0, 1.0), 0.16), ((0, 0, 1.25), 0.06)]]
for _sx in (-1, 1):
    for _sy in (-1, 1):
        _cone.append([((0, 0, 0.35), 0.3), ((0.3 * _sx, 0.18 * _sy, 0.3), 0.07), ((0.6 * _sx, 0.32 * _sy, 0.0), 0.04)])
SHAPES["cone"] = _cone

_hare = [[((0, 0.75, 0.85), 0.06), ((0, 0.55, 0.8), 0.17), ((0, 0.4, 0.8), 0.2), ((0, 0.0, 0.8), 0.2),
          ((0, -0.4, 0.82), 0.19), ((0, -0.6, 0.95), 0.1), ((0, -0.75, 1.15), 0.09), ((0, -0.85, 1.2), 0.12),
          ((0, -1.05, 1.12), 0.07)],
         [((0, 0.75, 0.85), 0.06), ((0, 0.95, 0.75), 0.03)]]
for _y in (0.4, -0.4):
    _hleg = [((0.1, _y, 0.72), 0.08), ((0.15, _y + 0.02, 0.35), 0.055), ((0.15, _y, 0.04), 0.045),
             ((0.15, _y - 0.1, 0.03), 0.035)]
    _hip = ((0, _y, 0.8 if _y > 0 else 0.82), 0.2)
    _hare += [[_hip] + _hleg, [_hip] + _mirrored(_hleg)]
_ear = [((0, -0.85, 1.2), 0.12), ((0.05, -0.85, 1.32), 0.035), ((0.09, -0.83, 1.5), 0.03), ((0.12, -0.8, 1.68), 0.015)]
SHAPES["hare"] = _hare + [_ear, _mirrored(_ear)]

# What each shape is: the template Auto Rig should read, its facing, and whether it has legs.
EXPECTED = {"lizard": ("QUADRUPED", "-Y", True), "snake": ("CHAIN", None, False), "fish": ("CHAIN", "+X", False),
            "bird": ("WINGED", "-Y", True), "moth": ("WINGED", None, False), "cone": ("CHAIN", None, False),
            "hare": ("QUADRUPED", "-Y", True)}


def graph(name):
    """The shape's Skin graph: points (n, 3), edges [(a, b)], radii (n,)."""
    points, radii, edges, index = [], [], [], {}
    for chain in SHAPES[name]:
        prev = None
        for p, r in chain:
            key = tuple(round(c, 6) for c in p)
            if key not in index:
                index[key] = len(points)
                points.append(p)
                radii.append(r)
            i = index[key]
            if prev is not None and prev != i:
                edges.append((prev, i))
            prev = i
    return np.array(points, float), sorted(set(tuple(sorted(e)) for e in edges)), np.array(radii, float)


def build(name, object_name=None):
    """Shape ``name`` as a plain mesh object in the current scene."""
    from testkit import rig_corpus

    points, edges, radii = graph(name)
    return rig_corpus.skin_body(object_name or name.capitalize(), points, edges, radii)
