"""Shadow-puppet templates as data, plus the pure helpers that need no Blender.

A template lists its bones in the picture plane, the control rods, and the *drivers* that
say how each part of the figure follows the rods. Coordinates are ``(x, z)`` in the puppet's
own picture plane (Blender's XZ plane, seen from the front along +Y), metres, feet on
``z = 0``; the human figures face +X, in profile, as traditional figures do. Angles are in
degrees here; ``build`` and ``live`` convert them for Blender and for the Rust
solver (``miniskeleton_core.ik2d_*``).

Degrees of freedom (``BoneDef.dof``):

* ``"plane"`` (1 DOF): rotation about the bone's local Z only, which the builder points at the
  viewer (``-Y``), so the rotation is in the picture plane; X and Y rotation are locked.
* ``"plane+twist"`` (2 DOF): in-plane rotation plus the bone's own Y (twist) axis: the head
  turning back, the abdomen's small twist.
* ``"fixed"`` (0 DOF): a rigid piece of its parent (the quadruped's legs and tail).

Limits (``BoneDef.limits`` in-plane, ``BoneDef.twist`` about Y) are the pose rotation relative
to the rest pose, ``lo <= 0 <= hi`` (Blender's IK limit fields, where they are stored and can be
edited per bone, require it).

Drivers (``Template.drivers``), solved in order, parents before children:

* ``("ik", bones, rod)``: a limb chain whose last tip follows ``rod`` (single-effector CCD).
* ``("hang", bones)``: a limb without a rod hangs straight down under gravity, within limits.
* ``("level", bone)``: the bone keeps its rest direction in the world (a foot stays flat).
* ``("multi", bones, [(joint, rod, weight), ...])``: a strip chain, several weighted effectors
  (joint ``k`` is the tip of ``bones[k - 1]``; the chain's root follows the main rod).
* ``("turn", bone, rod)``: the bone turns with the rod's in-plane rotation (quadruped head).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

KINDS = ("THREE_ROD", "FIVE_ROD", "PROP", "STRIP", "QUADRUPED")

KIND_ITEMS = [
    ("THREE_ROD", "Three-Rod Figure",
     "Neck rod carries the figure, two hand rods pull the arms by IK, the legs hang free"),
    ("FIVE_ROD", "Five-Rod Figure", "Three-rod figure plus two foot rods driving the legs by IK"),
    ("PROP", "Prop-Holding Figure",
     "Both hands grip a staff: moving or turning the staff moves both arms by IK"),
    ("STRIP", "Strip (Snake, Dragon)",
     "One long trunk chain pulled by head, middle and tail rods (multi-effector IK)"),
    ("QUADRUPED", "Quadruped",
     "The body rod moves the whole animal; the head rod's rotation turns the head"),
]


@dataclass(frozen=True)
class BoneDef:
    """One bone and its cut-out part. head/tail: (x, z) picture-plane metres."""

    name: str
    head: tuple[float, float]
    tail: tuple[float, float]
    parent: str | None = None
    connected: bool = False
    dof: str = "plane"                      # "plane" | "plane+twist" | "fixed"
    limits: tuple[float, float] = (-180.0, 180.0)   # in-plane (local Z), degrees, lo <= 0 <= hi
    twist: tuple[float, float] = (0.0, 0.0)         # about local Y, degrees (plane+twist only)
    seed: float = 0.0                       # IK start angle, degrees (solves are deterministic)
    shape: str = "limb"                     # outline, see part_outline()
    width: tuple[float, float] = (0.05, 0.04)   # half-widths at head and tail, metres
    depth: float = 0.0                      # layering toward the viewer, metres


@dataclass(frozen=True)
class RodDef:
    """A control rod (an empty). at: (x, z); the main rod carries the armature, the others
    are its children. A rod with ``on_prop`` is a grip point parented to the prop."""

    role: str
    at: tuple[float, float]
    main: bool = False
    on_prop: bool = False


@dataclass(frozen=True)
class PropDef:
    """A held prop (a staff): a thin bar from ``a`` to ``b`` (x, z), half-width ``width``."""

    name: str
    a: tuple[float, float]
    b: tuple[float, float]
    width: float = 0.02
    depth: float = 0.012


@dataclass(frozen=True)
class Template:
    kind: str
    bones: tuple[BoneDef, ...]
    rods: tuple[RodDef, ...]
    drivers: tuple = ()
    prop: PropDef | None = None
    description: str = ""

    def bone(self, name: str) -> BoneDef:
        return next(b for b in self.bones if b.name == name)

    def main_rod(self) -> RodDef:
        return next(r for r in self.rods if r.main)


# ---------------------------------------------------------------------------- human figure


def _polar(start, angle_deg, length):
    a = math.radians(angle_deg)
    return (start[0] + length * math.cos(a), start[1] + length * math.sin(a))


def _limb(prefix, side, start, angle, lengths, parent, limits, seeds, shapes, widths, depth):
    """A connected straight chain (arm or leg) from ``start`` along ``angle`` degrees."""
    out, head = [], start
    for i, (name, length) in enumerate(zip(prefix, lengths)):
        tail = _polar(head, angle, length)
        out.append(BoneDef(f"{name}.{side}", head, tail, parent if i == 0 else f"{prefix[i-1]}.{side}",
                           connected=i > 0, limits=limits[i], seed=seeds[i], shape=shapes[i],
                           width=widths[i], depth=depth))
        head = tail
    return out


def human_bones() -> tuple[BoneDef, ...]:
    """The 17-bone figure, root at the abdomen (see the README for the picture).

    abdomen -> chest -> neck -> head; chest -> upper_arm -> forearm -> hand (.L, .R);
    abdomen -> thigh -> shin -> foot (.L, .R); abdomen -> skirt (the robe's lower panel, the
    17th piece, which hangs over the hips as on traditional figures). The figure faces +X;
    ``.R`` is the near side (toward the viewer), ``.L`` the far side.
    """
    hip, waist, shoulder_z = (0.0, 0.95), (0.0, 1.22), 1.46
    bones = [
        BoneDef("abdomen", hip, waist, None, dof="plane+twist", limits=(-30, 30), twist=(-15, 15),
                shape="torso", width=(0.11, 0.12)),
        BoneDef("chest", waist, (0.0, 1.50), "abdomen", True, limits=(-25, 25),
                shape="torso", width=(0.12, 0.14)),
        BoneDef("neck", (0.0, 1.50), (0.0, 1.60), "chest", True, limits=(-30, 30),
                shape="limb", width=(0.04, 0.035)),
        BoneDef("head", (0.0, 1.60), (0.0, 1.90), "neck", True, dof="plane+twist",
                limits=(-40, 40), twist=(-180, 180), shape="head", width=(0.12, 0.12), depth=0.004),
        BoneDef("skirt", (0.0, 1.02), (0.0, 0.64), "abdomen", dof="plane", limits=(-25, 25),
                shape="skirt", width=(0.12, 0.17), depth=0.006),
    ]
    arm = dict(prefix=("upper_arm", "forearm", "hand"), lengths=(0.30, 0.26, 0.12),
               limits=((-180, 180), (0, 150), (-60, 60)), seeds=(0, 30, 0),
               shapes=("limb", "limb", "hand"), widths=((0.05, 0.045), (0.045, 0.036), (0.04, 0.05)))
    leg = dict(prefix=("thigh", "shin"), lengths=(0.43, 0.40),
               limits=((-45, 120), (-150, 0)), seeds=(10, -25),
               shapes=("limb", "limb"), widths=((0.065, 0.05), (0.05, 0.04)))
    for side, depth, swing in (("R", 0.02, -80.0), ("L", -0.02, -100.0)):
        bones += _limb(side=side, start=(0.0, shoulder_z), angle=swing, parent="chest",
                       depth=depth, **arm)
        bones += _limb(side=side, start=hip, angle=-90.0, parent="abdomen", depth=depth * 0.5, **leg)
        ankle = bones[-1].tail
        bones.append(BoneDef(f"foot.{side}", ankle, (ankle[0] + 0.17, ankle[1] - 0.09),
                             f"shin.{side}", True, limits=(-40, 40), shape="foot",
                             width=(0.045, 0.03), depth=depth * 0.5))
    return tuple(bones)


def _tip(bones, name):
    return next(b for b in bones if b.name == name).tail


def _human(kind: str) -> Template:
    bones = human_bones()
    neck = (0.0, 1.55)
    rods = [RodDef("neck", neck, main=True)]
    drivers = []
    prop = None
    if kind == "PROP":
        prop = PropDef("staff", (0.32, 0.25), (0.32, 1.95))
        rods += [RodDef("grip.R", (0.32, 1.20), on_prop=True), RodDef("grip.L", (0.32, 0.96), on_prop=True)]
        drivers += [("ik", ("upper_arm.R", "forearm.R", "hand.R"), "grip.R"),
                    ("ik", ("upper_arm.L", "forearm.L", "hand.L"), "grip.L")]
    else:
        rods += [RodDef("hand.R", _tip(bones, "hand.R")), RodDef("hand.L", _tip(bones, "hand.L"))]
        drivers += [("ik", ("upper_arm.R", "forearm.R", "hand.R"), "hand.R"),
                    ("ik", ("upper_arm.L", "forearm.L", "hand.L"), "hand.L")]
    if kind == "FIVE_ROD":
        rods += [RodDef("foot.R", _tip(bones, "shin.R")), RodDef("foot.L", _tip(bones, "shin.L"))]
        drivers += [("ik", ("thigh.R", "shin.R"), "foot.R"), ("ik", ("thigh.L", "shin.L"), "foot.L")]
    else:
        drivers += [("hang", ("thigh.R", "shin.R")), ("hang", ("thigh.L", "shin.L"))]
    drivers += [("hang", ("skirt",)), ("level", "foot.R"), ("level", "foot.L")]
    desc = dict(THREE_ROD="neck rod + two hand rods; legs hang",
                FIVE_ROD="neck rod + hand rods + foot rods",
                PROP="neck rod + a staff both hands grip")[kind]
    return Template(kind, bones, tuple(rods), tuple(drivers), prop, desc)


# ---------------------------------------------------------------------------- strip, quadruped

STRIP_SEGMENTS = 10
STRIP_LENGTH = 0.28


def _strip() -> Template:
    """A dragon/snake: head at the right (x = 0), trunk along -X. The head rod is the main
    rod (the chain's fixed root); the middle and tail rods pull joints 5 and 10."""
    z, n, seg = 1.0, STRIP_SEGMENTS, STRIP_LENGTH
    bones = []
    for i in range(n):
        name = f"trunk.{i:03d}"
        bones.append(BoneDef(name, (-seg * i, z), (-seg * (i + 1), z), f"trunk.{i-1:03d}" if i else None,
                             connected=i > 0, limits=(-180, 180) if i == 0 else (-45, 45),
                             seed=0 if i == 0 else (8 if i % 2 else -8),
                             shape="taper" if i == n - 1 else "segment",
                             width=(0.11, 0.13) if i == 0 else (0.1 - 0.007 * i, 0.095 - 0.007 * i),
                             depth=0.001 * (n - i)))
    mid = n // 2
    rods = (RodDef("head", (0.0, z), main=True),
            RodDef("middle", bones[mid - 1].tail), RodDef("tail", bones[-1].tail))
    drivers = (("multi", tuple(b.name for b in bones), ((mid, "middle", 0.5), (n, "tail", 1.0))),)
    return Template("STRIP", tuple(bones), rods, drivers, None, "head rod + middle and tail rods")


def _quadruped() -> Template:
    """A horse-like animal: rigid body, legs and tail; only the head turns (head rod)."""
    bones = (
        BoneDef("body", (-0.55, 0.95), (0.50, 0.95), None, dof="fixed", shape="torso", width=(0.20, 0.22)),
        BoneDef("head", (0.50, 1.00), (0.95, 1.30), "body", dof="plane", limits=(-45, 35),
                shape="limb", width=(0.11, 0.07), depth=0.004),
        BoneDef("tail", (-0.55, 1.02), (-0.95, 0.80), "body", dof="fixed", shape="taper",
                width=(0.05, 0.02), depth=-0.004),
        BoneDef("leg.FR", (0.38, 0.85), (0.42, 0.02), "body", dof="fixed", width=(0.06, 0.04), depth=0.01),
        BoneDef("leg.FL", (0.30, 0.85), (0.26, 0.02), "body", dof="fixed", width=(0.06, 0.04), depth=-0.01),
        BoneDef("leg.BR", (-0.40, 0.85), (-0.36, 0.02), "body", dof="fixed", width=(0.07, 0.04), depth=0.01),
        BoneDef("leg.BL", (-0.48, 0.85), (-0.52, 0.02), "body", dof="fixed", width=(0.07, 0.04), depth=-0.01),
    )
    rods = (RodDef("body", (0.0, 0.95), main=True), RodDef("head", (0.50, 1.00)))
    return Template("QUADRUPED", bones, rods, (("turn", "head", "head"),), None,
                    "body rod moves the animal; head rod turns the head")


def template(kind: str) -> Template:
    if kind in ("THREE_ROD", "FIVE_ROD", "PROP"):
        return _human(kind)
    if kind == "STRIP":
        return _strip()
    if kind == "QUADRUPED":
        return _quadruped()
    raise ValueError(f"unknown puppet type {kind!r}; one of {KINDS}")


def driven_bones(tpl: Template) -> list[str]:
    """Bones whose in-plane rotation the solver writes (and the bake keys), in driver order."""
    out = []
    for drv in tpl.drivers:
        names = drv[1] if isinstance(drv[1], tuple) else (drv[1],)
        out += [n for n in names if n not in out]
    return out


def driver_gaps(tpl: Template, bones, rods) -> list[str]:
    """One line per driver of ``tpl`` that a rig with the bone names ``bones`` and the rod
    roles ``rods`` cannot solve in full, naming what it lacks (a bone renamed or deleted, a rod
    deleted); the solver leaves such a chain as it is, or follows the rods it still has."""
    out = []
    for drv in tpl.drivers:
        kind = drv[0]
        names = drv[1] if isinstance(drv[1], tuple) else (drv[1],)
        if kind in ("ik", "turn"):
            wanted = (drv[2],)
        elif kind == "multi":
            wanted = tuple(role for _, role, _ in drv[2])
        else:
            wanted = ()
        lost = [f"bone {n}" for n in names if n not in bones] + [f"rod {r}" for r in wanted if r not in rods]
        if lost:
            how = {"ik": "following rod", "turn": "turned by rod", "multi": "following rods",
                   "hang": "hanging", "level": "kept level"}.get(kind, kind)
            if wanted:
                how += " " + ", ".join(wanted)
            out.append(f"{', '.join(names)} ({how}): no {', '.join(lost)}")
    return out


# ---------------------------------------------------------------------------- pure maths


def wrap(a: float) -> float:
    """Angle (radians) wrapped to (-pi, pi]."""
    a = math.fmod(a + math.pi, 2 * math.pi)
    if a <= 0:
        a += 2 * math.pi
    return a - math.pi


def clamp(a: float, lo: float, hi: float) -> float:
    return min(max(a, lo), hi)


def solver_limits(pose_limits, offsets) -> np.ndarray:
    """(b, 2) solver limits (radians, relative joint angles) from pose limits (relative to rest)
    and the rest offsets between consecutive bones; clipped to [-pi, pi]."""
    lim = np.asarray(pose_limits, dtype=np.float64) + np.asarray(offsets, dtype=np.float64)[:, None]
    return np.clip(lim, -math.pi, math.pi)


# ---------------------------------------------------------------------------- part outlines


def _arc(cx, cy, r, a0, a1, n):
    t = np.linspace(a0, a1, n)
    return np.stack([cx + r * np.cos(t), cy + r * np.sin(t)], 1)


def part_outline(shape: str, length: float, width=(0.05, 0.04), segments: int = 8) -> np.ndarray:
    """(n, 2) counter-clockwise outline of a bone's cut-out in bone space: column 0 across
    the bone (its local X), column 1 along it (local Y, 0 at the head, ``length`` at the
    tail). Joint ends are round so neighbouring pieces overlap like pinned leather.

    Shapes: ``limb`` (stadium tapering from width[0] to width[1]), ``torso`` (rounded
    trapezoid), ``segment`` (strip body piece), ``taper`` (to a point), ``head`` (round head
    with a nose to +X and a hat peak), ``hand`` (mitten), ``foot`` (boot), ``skirt`` (flared).
    """
    w0, w1 = width
    L = max(length, 1e-6)
    n = segments
    if shape in ("limb", "segment"):
        tail = _arc(0, L, w1, 0, math.pi, n)
        head = _arc(0, 0, w0, math.pi, 2 * math.pi, n)
        return np.vstack([tail, head])
    if shape == "torso":
        r = min(w0, w1) * 0.5
        return np.vstack([_arc(w1 - r, L - r * 0.2, r, 0, math.pi / 2, n // 2 + 1),
                          _arc(-w1 + r, L - r * 0.2, r, math.pi / 2, math.pi, n // 2 + 1),
                          _arc(-w0 + r, r * 0.2, r, math.pi, 1.5 * math.pi, n // 2 + 1),
                          _arc(w0 - r, r * 0.2, r, 1.5 * math.pi, 2 * math.pi, n // 2 + 1)])
    if shape == "taper":
        return np.vstack([[(0.0, L)], _arc(0, 0, w0, math.pi, 2 * math.pi, n)])
    if shape == "skirt":
        return np.array([(w1, L), (0.6 * w1, L * 1.04), (0, L), (-0.6 * w1, L * 1.04), (-w1, L),
                         (-w0, 0.0), (-0.5 * w0, -0.25 * w0), (0.5 * w0, -0.25 * w0), (w0, 0.0)])
    if shape == "hand":
        return np.vstack([_arc(0, L * 0.7, w1, -0.3, math.pi + 0.3, n),
                          [(-w0 * 0.7, 0.0)], _arc(0, 0, w0 * 0.7, math.pi, 2 * math.pi, n // 2),
                          [(w0 * 0.9, L * 0.35)]])
    if shape == "foot":
        return np.array([(-w0, 0.0), (-w0 * 0.8, -w0 * 0.8), (0.0, -w0), (w0, -w0 * 0.3),
                         (w0 * 1.3, L * 0.3), (w0 * 1.3, L), (w1 * 0.4, L * 1.12), (-w1, L)])
    if shape == "head":
        c = L * 0.5
        r = min(L * 0.45, max(w0, w1))
        # Round face, a nose toward +X (the side the figure faces), a hat peak behind the crown.
        return np.vstack([_arc(0, c, r, -math.pi / 2, -0.35, n),
                          [(r * 1.4, c - 0.15 * r)],
                          _arc(0, c, r, 0.1, math.pi / 2, n),
                          [(-0.2 * r, c + 1.25 * r), (-1.25 * r, c + 0.55 * r)],
                          _arc(0, c, r, math.pi * 0.85, 1.5 * math.pi, n)[:-1]])
    raise ValueError(f"unknown part shape {shape!r}")


def bar_outline(a, b, width: float) -> np.ndarray:
    """(4, 2) rectangle around the segment a-b (x, z), half-width ``width``."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    n = np.array([-d[1], d[0]]) / max(np.linalg.norm(d), 1e-12) * width
    return np.array([a - n, b - n, b + n, a + n])
