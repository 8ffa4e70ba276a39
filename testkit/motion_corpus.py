"""Add Motion on real rigs: head shake, walk and run on the rig corpus of testkit/rig_corpus.py
(Rigify control rigs, Mixamo-style humanoids round-tripped through glTF and FBX, game and
hand-made rigs from ../shared/models, a deform-only rig, the generated creature, legless
characters), measured on the meshes the armature deforms.

    .venv/bin/python -m testkit.motion_corpus [--rigs Fox,mixamo_gltf] [--motions WALK,RUN,HEAD_SHAKE]

For each rig and motion: the armature's action is cleared (NLA tracks removed) and every pose
bone put at rest; ``pose.miniskeleton_add_motion`` runs with its default options; the meshes
following the armature (Armature modifier or bone parent) are evaluated on every frame it
keyed (``evaluated_get``, world space). ``diag`` is the rest meshes' bounding-box diagonal,
``ground`` their lowest z.

- moves: the largest vertex displacement from rest, % of diag.
- deform: the same with each frame's centroid travel taken off (the armature object sliding
  along moves the mesh but deforms nothing).
- skate: median over consecutive frame pairs of (mean horizontal step of the vertices within
  0.005 diag of that frame's lowest z in both frames) / (horizontal step of the vertices'
  centroid); 0 = planted feet, 1 = feet slide along with the body.
- pen.: how far the lowest vertex goes below ground, % of diag.
- float: median over frames of (lowest z - ground), % of diag.
- feet (head shake): the largest displacement of the rest pose's lowest vertices, % of diag.
- head: the largest turn of the head bone the operator reports (its evaluated world
  rotation against rest, degrees).

Targets (✓ / ✗ per cell): WALK and RUN finish, moves >= 2, skate <= 0.15, pen. <= 1,
|float| <= 1; legless rigs refused with "no legs" and nothing keyed; never FINISHED when the
meshes do not deform (deform < 0.1: no keyed bone moves them); HEAD_SHAKE finishes, keeps the
feet still (< 0.5; legged rigs) and turns the head (>= 5 degrees). The operator's INFO report names the
roles (head, legs, spine); its full role list and warnings are written below the table.

Rigs whose files are absent (no ../shared) are skipped with a line saying so. Writes the table
to stdout and out/motion_corpus.md. Nothing is asserted: a Blender test can import ``measure``
(one rig's meshes over frames) or ``run_motion`` (reset, operator, measure).
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import importlib
import math
import os
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from testkit import ROOT, blender_session
from testkit.measures import evaluated_world_vertices

MOTIONS = ["WALK", "RUN", "HEAD_SHAKE"]
CONTACT = 0.005     # contact band above the lowest z, fraction of diag
TARGET = dict(moves=2.0, skate=0.15, pen=1.0, float=1.0, feet=0.5, head=5.0, inert=0.1, contact=75.0, stance=1.0,
              hang=30.0, swing=10.0, against=0.0, elbow=45.0, hand_in=1.0)
# the skin's folds (``folds``): most volume change and collapsed triangles, %, of a walk and a
# run (a head shake's are shown, not held to them)
FOLDS = dict(WALK=(5.0, 0.4), RUN=(10.0, 1.5))


# ---------------------------------------------------------------------------- measure

def world_points(meshes) -> np.ndarray:
    """(n, 3) evaluated world vertices of ``meshes`` (modifiers and parents applied), stacked."""
    out = [evaluated_world_vertices(ob) for ob in meshes]
    return np.concatenate(out) if out else np.zeros((0, 3))


def bone_points(arm, names) -> np.ndarray:
    """(b, 2, 3) evaluated world heads and tails of ``arm``'s pose bones ``names``."""
    m = np.array(arm.matrix_world)
    ends = np.array([[arm.pose.bones[n].head, arm.pose.bones[n].tail] for n in names]).reshape(-1, 3)
    return (ends @ m[:3, :3].T + m[:3, 3]).reshape(-1, 2, 3)


def sample(meshes, frames, arm=None, bones=()):
    """(len(frames), n, 3) world vertices of ``meshes`` on each of ``frames``; with ``arm`` and
    bone names ``bones``, also their (len(frames), b, 2, 3) world heads and tails."""
    import bpy

    scene = bpy.context.scene
    out, ends = [], []
    for f in frames:
        scene.frame_set(int(f))
        out.append(world_points(meshes))
        if arm is not None:
            ends.append(bone_points(arm, bones))
    points = np.stack(out)
    return points if arm is None else (points, np.stack(ends) if ends else np.zeros((len(frames), 0, 2, 3)))


def largest_mesh(meshes) -> tuple[slice, np.ndarray]:
    """The largest of ``meshes`` (most evaluated vertices): its rows in ``world_points``'s stack
    and its (t, 3) triangles (indices into those rows)."""
    import bpy

    dg = bpy.context.evaluated_depsgraph_get()
    start, best = 0, (slice(0, 0), np.zeros((0, 3), dtype=np.int64))
    for ob in meshes:
        ev = ob.evaluated_get(dg)
        me = ev.to_mesh()
        me.calc_loop_triangles()
        n = len(me.vertices)
        if n > best[0].stop - best[0].start:
            tris = np.empty(len(me.loop_triangles) * 3, dtype=np.int64)
            me.loop_triangles.foreach_get("vertices", tris)
            best = (slice(start, start + n), tris.reshape(-1, 3))
        ev.to_mesh_clear()
        start += n
    return best


def rest_of(meshes) -> dict:
    """The rest pose's vertices, bounding-box diagonal and lowest z (call with the rig at rest),
    and the largest mesh's rows and triangles (``largest_mesh``) for the fold measures."""
    p = world_points(meshes)
    rows, tris = largest_mesh(meshes)
    return dict(points=p, diag=float(np.linalg.norm(np.ptp(p, axis=0))), ground=float(p[:, 2].min()),
                rows=rows, tris=tris)


def skate(points: np.ndarray, diag: float) -> float:
    """Median over consecutive frames of (mean horizontal step of the vertices in contact in
    both frames) / (horizontal step of the centroid); NaN when the centroid never moves."""
    z = points[:, :, 2]
    near = z <= z.min(axis=1, keepdims=True) + CONTACT * diag
    centre = points.mean(axis=1)
    ratios = []
    for f in range(len(points) - 1):
        both = near[f] & near[f + 1]
        step = float(np.linalg.norm(centre[f + 1, :2] - centre[f, :2]))
        if both.any() and step > 1e-6 * diag:
            feet = np.linalg.norm(points[f + 1, both, :2] - points[f, both, :2], axis=1).mean()
            ratios.append(feet / step)
    return float(np.median(ratios)) if ratios else float("nan")


def volumes(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """(frames,) enclosed volume of the triangles ``tris`` over ``points`` (frames, n, 3), by the
    divergence theorem about each frame's centroid (a closed surface's volume; an open one's
    depends a little on that point)."""
    c = points.mean(axis=1, keepdims=True)
    a, b, d = (points[:, tris[:, k]] - c for k in range(3))
    return np.einsum("fij,fij->f", a, np.cross(b, d)) / 6.0


def areas(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """(frames, t) areas of the triangles ``tris`` over ``points`` (frames, n, 3)."""
    a, b, d = (points[..., tris[:, k], :] for k in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, d - a), axis=-1)


def folds(points: np.ndarray, rest: dict) -> dict:
    """The skin's folds on the largest mesh (``rest_of``'s rows and triangles) over ``points``
    (frames, n, 3): ``volume``, the worst frame's change of enclosed volume from rest, and
    ``collapsed``, the worst frame's share of triangles whose area falls below a quarter of
    rest (triangles of no area at rest left out), both in %."""
    tris, rows = rest["tris"], rest["rows"]
    if not len(tris):
        return dict(volume=float("nan"), collapsed=float("nan"))
    p0, p = rest["points"][rows][None], points[:, rows]
    v0 = volumes(p0, tris)[0]
    a0 = areas(p0, tris)[0]
    live = a0 > 1e-12 * rest["diag"] ** 2
    a = areas(p, tris)[:, live]
    return dict(volume=float(np.abs(volumes(p, tris) / v0 - 1.0).max()) * 100.0 if abs(v0) > 0 else float("nan"),
                collapsed=float((a < 0.25 * a0[live]).mean(axis=1).max()) * 100.0 if live.any() else float("nan"))


def measure(arm, meshes, frames, rest: dict | None = None, anatomy: "Anatomy | None" = None) -> dict:
    """Measures of ``meshes`` over ``frames`` against ``rest`` (``rest_of``, taken now when not
    given, so the rig must then be at rest): moves, deform, skate, pen(etration), float, feet (% of
    diag but skate), the folds (``folds``) and the centroid's travel; with the rig's ``anatomy``
    also its feet's ground contact and its arms (``Anatomy.measure``). Frames are scene frames."""
    rest = rest or rest_of(meshes)
    diag, ground, p0 = rest["diag"], rest["ground"], rest["points"]
    if anatomy is not None:
        pts, ends = sample(meshes, frames, arm, anatomy.bones)
    else:
        pts, ends = sample(meshes, frames), None
    pct = 100.0 / diag
    low = pts[:, :, 2].min(axis=1)
    feet = p0[:, 2] <= ground + CONTACT * diag
    out = dict(
        diag=diag, ground=ground, frames=len(frames),
        moves=float(np.linalg.norm(pts - p0, axis=2).max()) * pct,
        deform=float(np.linalg.norm(pts - p0 - (pts.mean(axis=1) - p0.mean(axis=0))[:, None], axis=2).max()) * pct,
        skate=skate(pts, diag),
        pen=max(0.0, ground - float(low.min())) * pct,
        float=float(np.median(low - ground)) * pct,
        feet=float(np.linalg.norm(pts[:, feet] - p0[feet], axis=2).max()) * pct,
        centroid_travel=float(np.linalg.norm(pts[-1].mean(0)[:2] - pts[0].mean(0)[:2])) * pct,
        **folds(pts, rest),
    )
    if anatomy is not None:
        out.update(anatomy.measure(pts, ends, rest))
    return out


# ---------------------------------------------------------------------------- anatomy

def vertex_owners(arm, meshes) -> np.ndarray:
    """(n,) per stacked vertex of ``meshes`` (``world_points``'s order) the name of the deform bone
    of ``arm`` that weighs most on it (its vertex groups; a part parented to a bone: that bone),
    or "" for none."""
    import bpy

    deform = {b.name for b in arm.data.bones if b.use_deform}
    dg = bpy.context.evaluated_depsgraph_get()
    out = []
    for ob in meshes:
        n = len(ob.evaluated_get(dg).data.vertices)
        if ob.parent == arm and ob.parent_type == "BONE" and not ob.vertex_groups:
            out.append(np.full(n, ob.parent_bone, dtype=object))
            continue
        names = {g.index: g.name for g in ob.vertex_groups if g.name in deform}
        own = np.full(len(ob.data.vertices), "", dtype=object)
        for v in ob.data.vertices:
            best = max(((g.weight, g.group) for g in v.groups if g.group in names), default=None)
            if best is not None and best[0] > 0.0:
                own[v.index] = names[best[1]]
        if len(own) != n:   # a modifier changes the vertex count: no owners to read
            own = np.full(n, "", dtype=object)
        out.append(own)
    return np.concatenate(out) if out else np.zeros(0, dtype=object)


def console_roles(text: str) -> list[str]:
    """The role lines the operator wrote to the console (``[MiniSkeleton]   leg L: ...``), bare."""
    return [ln.split("]", 1)[1].strip() for ln in text.splitlines()
            if ln.startswith("[MiniSkeleton]") and "roles of" not in ln]


def anatomy_of(arm, meshes, console: str, rest: dict) -> "Anatomy":
    """The ``Anatomy`` of ``meshes`` from the roles Add Motion wrote to its ``console``."""
    return Anatomy(arm, meshes, role_lines(console_roles(console)), rest)


def role_lines(lines: list[str]) -> dict:
    """The operator's console role lines (``planning.describe_roles``) read back: spine, neck,
    head, legs [(label, side, bones)] and arms [(side, bones)] by bone name."""
    out = dict(spine=[], neck=[], head="", legs=[], arms=[])

    def names(text):
        text = re.sub(r" \(\d+ in all\)$", "", text.strip())
        return [n for n in text.split(", ") if n and n not in ("-", "...")]

    for line in lines:
        key, _, text = line.partition(": ")
        if key in ("spine", "neck"):
            out[key] = names(text)
        elif key == "head":
            out["head"] = text.split(" (+ ")[0].strip()
        elif key.startswith("leg "):
            out["legs"].append((key[4:], key[-1], names(text)))
        elif key.startswith("arm "):
            out["arms"].append((key[4:], names(text)))
    return out


BAND = 0.01         # a foot stands on the ground within this fraction of diag above it
FOOT = 0.15         # a foot: a leg's vertices this low in its height
PLANTED = 0.3       # a foot stands while it moves less than this share of the body's step
SLAB = 0.03         # hands are tested against the torso's slices this thick, fraction of diag


class Anatomy:
    """The parts of a rig's meshes the contact and arm measures read, from the roles the operator
    reported (``role_lines``) and the bone weighing most on each vertex (``vertex_owners``):
    each leg's foot (its vertices in the lowest ``FOOT`` of the leg), each arm's upper arm (the
    longer of its first two bones, each to the next bone's head), elbow and wrist, its hand (the
    vertices of the bones from the wrist on) and the torso (spine and neck vertices)."""

    def __init__(self, arm, meshes, roles: dict, rest: dict):
        p0 = rest["points"]
        owners = vertex_owners(arm, meshes)
        bones = arm.data.bones

        def below(names):   # the bones and their deform descendants
            out = set()
            for n in names:
                if n in bones:
                    out |= {n} | {c.name for c in bones[n].children_recursive if c.use_deform}
            return out

        def rows(names):
            return np.flatnonzero(np.isin(owners, list(names))) if names else np.zeros(0, dtype=np.int64)

        self.feet, self.legs = [], []
        for _label, side, leg in roles["legs"]:
            own = rows(below(leg))
            if len(own):
                z = p0[own, 2]
                self.feet.append(own[z <= z.min() + FOOT * (z.max() - z.min())])
                self.legs.append((side, leg[0], leg[-1]))
        self.torso = rows(set(roles["spine"]) | set(roles["neck"]))
        self.arms = []
        chains = [(side, [n for n in chain if n in bones]) for side, chain in roles["arms"]]
        chains = [(side, chain) for side, chain in chains if len(chain) >= 3]
        # the upper arm as the core takes it: the longer of the first two bones, each to the next
        # one's head (the first may be a clavicle), summed over the arms (both sides alike)
        spans = np.zeros(2)
        for _side, chain in chains:
            heads = [np.array(bones[n].head_local) for n in chain[:3]]
            spans += [np.linalg.norm(heads[1] - heads[0]), np.linalg.norm(heads[2] - heads[1])]
        k = int(spans[0] < spans[1])
        for side, chain in chains:
            wrist = chain[k + 2] if k + 2 < len(chain) else None
            hand = rows(below(chain[k + 2:])) if wrist else np.zeros(0, dtype=np.int64)
            self.arms.append(dict(side=side, upper=chain[k], elbow=chain[k + 1], wrist=wrist, hand=hand))
        names = [leg[1] for leg in self.legs] + [leg[2] for leg in self.legs]
        names += [a[key] for a in self.arms for key in ("upper", "elbow", "wrist") if a[key]]
        self.bones = list(dict.fromkeys(names))

    def end(self, ends, name, tail=False) -> np.ndarray:
        """(frames, 3) posed head (or tail) of bone ``name`` from ``sample``'s bone ends."""
        return ends[:, self.bones.index(name), int(tail)]

    def measure(self, pts: np.ndarray, ends: np.ndarray, rest: dict) -> dict:
        """Per clip: ``contact``, the share of frames (%) with a foot on the ground (its lowest point
        within ``BAND`` of it); ``stance``, the worst foot's median height above the ground (% of
        diag) over the frames it stands (moves less than ``PLANTED`` of the body's step); and
        with arms: ``hang``, the worst frame's angle of an upper arm out to the side from straight
        down (degrees; its swing along the walk apart), ``swing``, its least range of swing along
        the walk (degrees), ``against``, the largest
        correlation of an arm's swing with its own side's leg's (negative: against the legs),
        ``elbow``, the least mean bend of an elbow (degrees), and ``hand_in``, the worst frame's
        share of a hand's vertices inside the torso's slices (%)."""
        diag, ground = rest["diag"], rest["ground"]
        out = {}
        if self.feet:
            lows = np.stack([pts[:, f, 2].min(axis=1) for f in self.feet]) - ground   # (feet, frames)
            out["contact"] = float((lows.min(axis=0) <= BAND * diag).mean()) * 100.0
            body = np.linalg.norm(np.diff(pts.mean(axis=1)[:, :2], axis=0), axis=1)
            worst = 0.0
            for f, low in zip(self.feet, lows):
                step = np.linalg.norm(np.diff(pts[:, f, :2].mean(axis=1), axis=0), axis=1)
                stands = (step <= PLANTED * body) & (body > 1e-6 * diag)
                if stands.any():
                    worst = max(worst, float(np.median(np.minimum(low[1:], low[:-1])[stands])))
                else:
                    worst = float("nan")
                    break
            out["stance"] = worst * 100.0 / diag
        if not self.arms:
            return out
        travel = pts[-1].mean(axis=0) - pts[0].mean(axis=0)
        fwd = np.array([travel[0], travel[1], 0.0])
        fwd = fwd / max(np.linalg.norm(fwd), 1e-30)
        down = np.array([0.0, 0.0, -1.0])

        def swing_angle(d):   # forward angle of directions (frames, 3) from straight down
            return np.degrees(np.arctan2(d @ fwd, d @ down))

        side = np.cross(down, fwd)   # across the body

        hang, swing, against, elbow, hand_in = 0.0, float("inf"), -1.0, float("inf"), 0.0
        for a in self.arms:
            sh, el = self.end(ends, a["upper"]), self.end(ends, a["elbow"])
            wr = self.end(ends, a["wrist"]) if a["wrist"] else self.end(ends, a["elbow"], tail=True)
            up_arm, fore = el - sh, wr - el
            aside = np.degrees(np.arctan2(np.abs(up_arm @ side), up_arm @ down))   # from down, to the side
            hang = max(hang, float(aside.max()))
            s = swing_angle(up_arm)
            swing = min(swing, float(np.ptp(s)))
            legs = [leg for leg in self.legs if leg[0] == a["side"]]
            if legs and np.ptp(s) > 0:
                leg = self.end(ends, legs[0][2]) - self.end(ends, legs[0][1])
                ls = swing_angle(leg)
                if np.ptp(ls) > 0:
                    against = max(against, float(np.corrcoef(s, ls)[0, 1]))
            bend = np.einsum("ij,ij->i", up_arm, fore) / np.maximum(
                np.linalg.norm(up_arm, axis=1) * np.linalg.norm(fore, axis=1), 1e-30)
            elbow = min(elbow, float(np.degrees(np.arccos(np.clip(bend, -1, 1))).mean()))
            if len(a["hand"]) and len(self.torso):
                hand_in = max(hand_in, inside_share(pts[:, a["hand"]], pts[:, self.torso], SLAB * diag))
        out.update(hang=hang, swing=swing, against=against, elbow=elbow, hand_in=hand_in * 100.0)
        return out


def inside_share(hand: np.ndarray, torso: np.ndarray, slab: float) -> float:
    """The worst frame's share of ``hand``'s points (frames, h, 3) inside ``torso``'s (frames, t, 3):
    within the convex outline, seen from above, of the torso's points less than half a ``slab``
    above or below them."""
    from mathutils.geometry import convex_hull_2d

    worst = 0.0
    for hf, tf in zip(hand, torso):
        inside = 0
        cells = np.floor(hf[:, 2] / slab).astype(np.int64)
        for c in np.unique(cells):
            near = tf[np.abs(tf[:, 2] - (c + 0.5) * slab) <= slab]
            if len(near) < 3:
                continue
            hull = near[convex_hull_2d([tuple(p) for p in near[:, :2]]), :2]
            if len(hull) < 3:
                continue
            pts = hf[cells == c, :2]
            edge = np.roll(hull, -1, axis=0) - hull
            rel = pts[:, None, :] - hull[None]
            cross = edge[None, :, 0] * rel[..., 1] - edge[None, :, 1] * rel[..., 0]
            inside += int(((cross >= 0).all(axis=1) | (cross <= 0).all(axis=1)).sum())
        worst = max(worst, inside / max(len(hf), 1))
    return worst


def head_turn(arm, bone: str, frames) -> float:
    """The largest angle (degrees) between ``bone``'s evaluated world rotation and its rest one."""
    import bpy

    scene = bpy.context.scene
    rest = (arm.matrix_world @ arm.data.bones[bone].matrix_local).to_quaternion()
    worst = 0.0
    for f in frames:
        scene.frame_set(int(f))
        now = (arm.matrix_world @ arm.pose.bones[bone].matrix).to_quaternion()
        angle = math.degrees(rest.rotation_difference(now).angle) % 360.0   # in [0, 360): q and -q
        worst = max(worst, min(angle, 360.0 - angle))
    return worst


# ---------------------------------------------------------------------------- running

def reset_rig(arm, basis) -> None:
    """No action, no NLA track, the object at ``basis`` and every pose bone at rest."""
    import bpy
    from mathutils import Matrix

    ad = arm.animation_data
    if ad is not None:
        ad.action = None
        for track in list(ad.nla_tracks):
            ad.nla_tracks.remove(track)
    arm.matrix_basis = basis
    for pb in arm.pose.bones:
        pb.matrix_basis = Matrix.Identity(4)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 250
    scene.frame_set(1)
    bpy.context.view_layer.update()


@contextlib.contextmanager
def captured_output():
    """Everything written to stdout and stderr (Blender's C reports included) meanwhile, as the
    string in the yielded list."""
    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    sys.stderr.flush()
    libc.fflush(None)
    box = []
    streams = sys.stdout, sys.stderr
    with tempfile.TemporaryFile() as tmp:
        saved = os.dup(1), os.dup(2)
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        # Python's own streams may not be file descriptors 1 and 2 (pytest replaces them)
        sys.stdout = open(1, "w", closefd=False)
        sys.stderr = open(2, "w", closefd=False)
        try:
            yield box
        finally:
            sys.stdout.close()   # flushes; the descriptors stay open (closefd=False)
            sys.stderr.close()
            libc.fflush(None)
            sys.stdout, sys.stderr = streams
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            tmp.seek(0)
            box.append(tmp.read().decode(errors="replace"))


def keyed_bones(arm) -> set[str]:
    keys = importlib.import_module(blender_session.ADDON_MODULE + ".common.keys")
    return {fc.data_path.split('"')[1] for fc in keys.action_fcurves(arm) if fc.data_path.startswith("pose.bones")}


def keyed_anything(arm) -> bool:
    keys = importlib.import_module(blender_session.ADDON_MODULE + ".common.keys")
    return bool(keys.action_fcurves(arm))


def add_motion(arm, motion, props):
    """Run Add Motion on ``arm`` alone selected and active: (result, error or None, seconds,
    console text)."""
    import bpy

    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    arm.select_set(True)
    bpy.context.view_layer.objects.active = arm
    error = None
    with captured_output() as out:
        start = time.perf_counter()
        try:
            result = bpy.ops.pose.miniskeleton_add_motion(motion=motion, **props)
        except RuntimeError as err:
            result, error = {"CANCELLED"}, str(err).strip()
        secs = time.perf_counter() - start
    return next(iter(result)), error, secs, out[0]


def run_motion(arm, meshes, motion: str, basis=None, **props) -> dict:
    """Reset ``arm`` (no action, rest pose), run Add Motion ``motion`` on it and measure its
    ``meshes`` over the frames it keyed. Returns the result ('FINISHED' / 'CANCELLED'), the
    reports (info, warnings, error), the console's role lines, seconds, keyed bones and the
    measures (``measure``, plus ``head``: the reported head bone's turn in degrees). ``basis``:
    the armature object's matrix to restore before and after (default: its matrix now)."""
    import bpy

    basis = basis if basis is not None else arm.matrix_basis.copy()
    reset_rig(arm, basis)
    rest = rest_of(meshes)
    result, error, secs, text = add_motion(arm, motion, props)
    row = dict(motion=motion, result=result, secs=secs, error=error, console=text,
               info=[ln[6:] for ln in text.splitlines() if ln.startswith("Info: ")],
               warnings=[ln[9:] for ln in text.splitlines() if ln.startswith("Warning: ")],
               roles=console_roles(text), keyed=sorted(keyed_bones(arm)), keyed_any=keyed_anything(arm))
    if row["result"] == "FINISHED":
        span = re.search(r"frames (-?\d+)-(-?\d+)", " ".join(row["info"]))
        scene = bpy.context.scene
        lo, hi = (int(span.group(1)), int(span.group(2))) if span else (scene.frame_start, scene.frame_end)
        frames = list(range(lo, hi + 1))
        anatomy = anatomy_of(arm, meshes, text, rest)
        row.update(measure(arm, meshes, frames, rest, anatomy))
        row["biped_arms"] = bool(anatomy.arms) and "(biped)" in " ".join(row["info"])
        head = re.search(r"; head (.+?), legs", " ".join(row["info"]))
        if head and head.group(1) in arm.pose.bones:
            row["head_bone"] = head.group(1)
            row["head"] = head_turn(arm, head.group(1), frames)
    reset_rig(arm, basis)
    return row


# ---------------------------------------------------------------------------- verdicts

def fmt(x, digits=2):
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def mark(ok):
    return "" if ok is None else (" ✓" if ok else " ✗")


def cells(row: dict, legless: bool) -> dict:
    """The table's cells for one row, each with its ✓ / ✗ against the targets."""
    motion, done = row["motion"], row["result"] == "FINISHED"
    moves = row.get("moves")
    gait = motion in ("WALK", "RUN")
    if done:
        text = "FINISHED"
        held = [w for w in row["warnings"] if "constraints that override" in w]
        if held:
            text += f"; warns: {held[0].split(':')[0]}"
    else:
        text = "CANCELLED: " + shorten(re.sub(r"^Error: ", "", row["error"] or "").replace("\n", " "), 80)
    if legless and gait:
        ok = (not done) and "no legs" in (row["error"] or "") and not row["keyed_any"]
    elif done and row.get("deform") is not None and row["deform"] < TARGET["inert"]:
        ok = False   # finished, but no keyed bone moves the mesh (at most the object slides)
    else:
        ok = done
    out = dict(result=text + mark(ok), roles=roles_cell(row), secs=f"{row['secs']:.2f}")
    checks = {}
    if done and gait and not legless:
        checks = dict(moves=moves >= TARGET["moves"], skate=row["skate"] <= TARGET["skate"],
                      pen=row["pen"] <= TARGET["pen"], float=abs(row["float"]) <= TARGET["float"])
        if "contact" in row:
            checks["contact"] = row["contact"] >= TARGET["contact"]
            checks["stance"] = row["stance"] <= TARGET["stance"]   # NaN: a foot never stands
    elif done and motion == "HEAD_SHAKE":
        checks = dict(head=row.get("head", 0.0) >= TARGET["head"])
        if not legless:   # a legless rig's lowest points are a tail or a chin, not feet
            checks["feet"] = row["feet"] < TARGET["feet"]
    if done and motion in FOLDS:
        most_volume, most_collapsed = FOLDS[motion]
        checks["volume"] = row["volume"] <= most_volume
        checks["collapsed"] = row["collapsed"] <= most_collapsed
    per_motion = dict(feet="HEAD_SHAKE", head="HEAD_SHAKE", contact="gait", stance="gait")
    for key in ("moves", "deform", "skate", "pen", "float", "contact", "stance", "feet", "head", "volume",
                "collapsed"):
        wanted = per_motion.get(key)
        if not done or (wanted == "gait" and not gait) or (wanted and wanted != "gait" and motion != wanted):
            out[key] = "–"
        else:
            value = row.get(key)
            ok = checks.get(key)
            if key in ("skate", "stance") and value is not None and math.isnan(value):
                ok = False if key in checks else None
            out[key] = fmt(value, 0 if key in ("head", "contact") else 2) + mark(ok)
    out["arms"] = arms_cell(row) if done and gait and row.get("biped_arms") else "–"
    return out


def arms_cell(row: dict) -> str:
    """Hang / swing (walk) or elbow (run) degrees and hands inside the torso %, with ✓ / ✗: a walk's
    upper arms within ``hang`` of straight down, swinging at least ``swing`` against the legs; a
    run's elbows bent at least ``elbow`` (its arms swing further: their hang is shown, not held
    to the walk's); no hand in the torso."""
    t = TARGET
    ok = row["hand_in"] <= t["hand_in"]
    if row["motion"] == "WALK":
        ok = ok and row["hang"] <= t["hang"] and row["swing"] >= t["swing"] and row["against"] < t["against"]
        text = f"{row['hang']:.0f} / {row['swing']:.0f} / {row['hand_in']:.1f}"
    else:
        ok = ok and row["elbow"] >= t["elbow"]
        text = f"{row['hang']:.0f} / elbow {row['elbow']:.0f} / {row['hand_in']:.1f}"
    return text + mark(ok)


def shorten(text: str, most: int) -> str:
    return text if len(text) <= most else text[:most - 1] + "…"


def roles_cell(row: dict) -> str:
    """Plan, head, legs and spine from the operator's INFO report."""
    info = " ".join(row["info"])
    m = re.search(r"\((\w+)\): frames [^;]*; (head .*?); spine (.*?) \(full list", info)
    if not m:
        return "–"
    return shorten(f"{m.group(1)}; {m.group(2)}; spine {m.group(3)}", 140).replace("|", "/")


COLUMNS = [("rig", "rig"), ("motion", "motion"), ("result", "result"), ("roles", "roles reported"),
           ("moves", "moves %"), ("deform", "deform %"), ("skate", "skate"), ("pen", "pen. %"), ("float", "float %"),
           ("contact", "ground %"), ("stance", "stance %"), ("arms", "arms: hang° / swing° or elbow° / hand in %"),
           ("volume", "volume %"), ("collapsed", "collapsed %"), ("feet", "feet %"), ("head", "head °"),
           ("secs", "op s")]


def table(rows) -> str:
    lines = ["| " + " | ".join(title for _, title in COLUMNS) + " |",
             "|" + "|".join("---" for _ in COLUMNS) + "|"]
    for rig, legless, row in rows:
        c = dict(rig=rig, motion=row["motion"], **cells(row, legless))
        lines.append("| " + " | ".join(str(c[key]).replace("|", "/") for key, _ in COLUMNS) + " |")
    return "\n".join(lines)


def summary(rows) -> str:
    """How many rows meet every target, and which rigs fail one."""
    failing = {}
    for rig, legless, row in rows:
        if any("✗" in str(v) for v in cells(row, legless).values()):
            failing.setdefault(rig, []).append(row["motion"])
    met = len(rows) - sum(len(v) for v in failing.values())
    listed = "; ".join(f"{rig} ({', '.join(m)})" for rig, m in failing.items())
    return f"Rows meeting every target: {met} of {len(rows)}." + (f" Failing: {listed}." if listed else "")


def details(rigs_notes, rows) -> str:
    """Per rig: what it is, then per motion the operator's role lines and warnings."""
    out = []
    for rig, notes in rigs_notes:
        out.append(f"### {rig}")
        out += [f"- {n}" for n in notes]
        for name, _, row in rows:
            if name != rig:
                continue
            head = f"- {row['motion']}: {row['result']}"
            if row["result"] == "FINISHED":
                head += (f", {row['frames']} frames, keyed {len(row['keyed'])} bones, centroid travel "
                         f"{row['centroid_travel']:.1f} % diag")
                if "head_bone" in row:
                    head += f", head bone {row['head_bone']}"
            else:
                head += f": {row['error']}"
            out.append(head)
            if row["motion"] != "HEAD_SHAKE" or row["result"] != "FINISHED":
                out += [f"  - {ln}" for ln in row["roles"]]
            out += [f"  - warning: {w}" for w in row["warnings"]]
        out.append("")
    return "\n".join(out)


# ---------------------------------------------------------------------------- main

def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rigs", default="", help="comma list of rig names (default: all); see rig_corpus.NAMES")
    ap.add_argument("--motions", default=",".join(MOTIONS), help="comma list of WALK, RUN, HEAD_SHAKE")
    ap.add_argument("--out", default=str(ROOT / "out" / "motion_corpus.md"))
    ap.add_argument("--steer", default="", help="comma list of steering cases (circle, s_curve, slope, bumps, "
                    "step, in_place, or all) to run on the --rigs (default: STEER_RIGS) instead")
    args = ap.parse_args(argv)

    blender_session.start()
    from testkit import rig_corpus

    if args.steer:
        steer_main(args, rig_corpus)
        return

    names = [n for n in args.rigs.split(",") if n] or rig_corpus.NAMES
    unknown = [n for n in names if n not in rig_corpus.BUILDERS]
    if unknown:
        raise SystemExit(f"unknown rigs {unknown}; known: {', '.join(rig_corpus.NAMES)}")
    motions = [m.strip().upper() for m in args.motions.split(",") if m.strip()]
    rows, notes, skipped = [], [], []
    for name in names:
        why = rig_corpus.missing(name)
        if why:
            skipped.append(f"skipped {name}: {why}")
            print(skipped[-1], flush=True)
            continue
        blender_session.reset_scene()
        start = time.perf_counter()
        with captured_output():
            rig = rig_corpus.build(name)
        built = time.perf_counter() - start
        basis = rig.arm.matrix_basis.copy()
        kinds = f"{rig.kind}; armature '{rig.arm.name}', {len(rig.arm.data.bones)} bones " \
                f"({sum(b.use_deform for b in rig.arm.data.bones)} deform); meshes " \
                f"{', '.join(ob.name for ob in rig.meshes)} ({sum(len(ob.data.vertices) for ob in rig.meshes)} " \
                f"vertices); built in {built:.1f} s"
        notes.append((name, [kinds] + rig.notes))
        for motion in motions:
            row = run_motion(rig.arm, rig.meshes, motion, basis)
            rows.append((name, rig.legless, row))
            c = cells(row, rig.legless)
            print(f"{name:24s} {motion:10s} {c['result'][:40]:40s} skate {c['skate']:7s} pen {c['pen']:7s} "
                  f"float {c['float']:7s} ground {c['contact']:5s} stance {c['stance']:7s} arms {c['arms']:22s} "
                  f"vol {c['volume']:7s} coll {c['collapsed']:7s} feet {c['feet']:7s} head {c['head']}", flush=True)
    text = "\n".join(["## Add Motion on the rig corpus", "", table(rows), "", summary(rows), ""] + skipped
                     + ["", "## Details", "", details(notes, rows)])
    print()
    print(text)
    blender_session.write_report(Path(args.out), text)


def timed_path(rig, repeats: int = 3) -> tuple[tuple[float, float], tuple[float, float]]:
    """Least (wall, CPU) seconds of Add Motion (walk) on ``rig`` over ``repeats`` runs: along a
    quarter circle 4 strides long (4 cycles), and straight on for 4 cycles."""
    import bpy

    frame = rig_frame(rig.arm)
    stride = 1.3 * frame["leg"]   # a biped's walk (docs/motion.md)
    radius = 4 * stride / (math.pi / 2)
    fwd, start = frame["fwd"], frame["start"]
    left = np.array([-fwd[1], fwd[0], 0.0])
    a = np.linspace(0.0, math.pi / 2, 64)[:, None]
    course = Course("circle", start, fwd, 1.0, 1.0, 0.0)
    course.path = start * [1, 1, 0] + radius * (left - np.cos(a) * left + np.sin(a) * fwd)
    path = course.curve("timed_path")
    best = {}
    for key, props in (("path", dict(path=path.name)), ("straight", dict(cycles=4.0))):
        for _ in range(repeats):
            reset_rig(rig.arm, rig.arm.matrix_basis.copy())
            bpy.context.view_layer.objects.active = rig.arm
            with captured_output():
                start_t, start_cpu = time.perf_counter(), time.process_time()
                bpy.ops.pose.miniskeleton_add_motion(motion="WALK", **props)
                secs = (time.perf_counter() - start_t, time.process_time() - start_cpu)
            best[key] = min(best.get(key, secs), secs)
    reset_rig(rig.arm, rig.arm.matrix_basis.copy())
    data = path.data
    bpy.data.objects.remove(path)
    bpy.data.curves.remove(data)
    return best["path"], best["straight"]


def steer_main(args, rig_corpus) -> None:
    """The steering rows (``steer_row``) of each rig and case, walking; the slope and the
    circle also running. Writes the table to stdout and out/motion_steer.md."""
    names = [n for n in args.rigs.split(",") if n] or STEER_RIGS
    cases = STEER_CASES if args.steer == "all" else [c for c in args.steer.split(",") if c]
    rows, notes = [], []
    for name in names:
        why = rig_corpus.missing(name)
        if why:
            notes.append(f"skipped {name}: {why}")
            continue
        blender_session.reset_scene()
        with captured_output():
            rig = rig_corpus.build(name)
        if name == "rigify_human":
            along, straight = timed_path(rig)
            notes.append(f"Add Motion (walk, 4 cycles) on rigify_human, least of 3: {along[0]:.2f} s along a path "
                         f"({along[1]:.2f} CPU s), {straight[0]:.2f} s straight on ({straight[1]:.2f} CPU s); "
                         f"load average {os.getloadavg()[0]:.1f}")
            print(notes[-1], flush=True)
        for case in cases:
            for motion in ["WALK"] + (["RUN"] if case in ("circle", "slope") else []):
                row = steer_row(rig, case, motion)
                row["rig"] = name
                rows.append(row)
                c = steer_cells(row)
                print(f"{name:20s} {case:9s} {motion:5s} {c['result'][:50]:50s} skate {c['skate']:7s} "
                      f"stance {c['stance']:7s} pen {c['pen']:7s} heading {c['heading']:7s} "
                      f"travel {c['travel']:7s} {c['secs']} s", flush=True)
    text = "\n".join(["## Add Motion steered", "", steer_table(rows), ""] + notes)
    print()
    print(text)
    blender_session.write_report(Path(args.out).with_name("motion_steer.md"), text)



# ---------------------------------------------------------------------------- steering

# Rigs of each family the steering rows walk: a biped and a quadruped where the family has one
# (Mixamo characters are bipeds).
STEER_RIGS = ["ik_biped_gltf", "ik_quadruped_gltf", "CesiumMan", "Fox", "mixamo_gltf", "rigify_human", "rigify_wolf",
              "autorig_CesiumMan", "autorig_spot"]
STEER_CASES = ["circle", "s_curve", "slope", "bumps", "step", "in_place"]
SLOPE = 15.0        # degrees
STEP = 0.15         # a step's height, share of the leg's length
STEER_TARGET = dict(skate=0.15, stance=1.0, pen=1.0, heading=10.0, travel=1.0)


class Course:
    """One steering case laid out for a rig: ``path`` (p, 3) world points or None, ``height``
    (a function of world x, y arrays: the ground under them) and ``ground_mesh`` (bool: lay a
    mesh for it), from the rig's rest ``start`` (its root's head, world), ``fwd`` (unit,
    horizontal), body length and leg length."""

    def __init__(self, case: str, start, fwd, body: float, leg: float, floor: float):
        self.case = case
        start, fwd = np.asarray(start, dtype=np.float64), np.asarray(fwd, dtype=np.float64)
        left = np.array([-fwd[1], fwd[0], 0.0])
        self.path, self.ground_mesh = None, case in ("slope", "bumps", "step")
        radius = 2.0 * body
        s0 = np.array([start[0], start[1], floor])

        def arc(centre, u, v, n=96):   # a quarter turn from centre + R u, heading along v
            a = np.linspace(0.0, math.pi / 2, n)[:, None]
            return centre + radius * (np.cos(a) * u + np.sin(a) * v)

        if case == "circle":   # half a circle turning left
            centre = s0 + radius * left
            self.path = np.concatenate([arc(centre, -left, fwd), arc(centre, fwd, left)[1:]])
        elif case == "s_curve":   # a quarter turning left, then a quarter turning right
            first = arc(s0 + radius * left, -left, fwd)
            self.path = np.concatenate([first, arc(first[-1] + radius * fwd, -fwd, left)[1:]])
        ahead = 0.6 * body   # the ground changes this far ahead of the root
        tan = math.tan(math.radians(SLOPE))
        wave = body

        def height(x, y):
            d = (x - start[0]) * fwd[0] + (y - start[1]) * fwd[1]
            s = (x - start[0]) * left[0] + (y - start[1]) * left[1]
            if case == "slope":
                return floor + tan * np.maximum(0.0, d - ahead)
            if case == "bumps":
                return floor + 0.04 * leg * (1 - np.cos(2 * math.pi * np.maximum(0.0, d - ahead) / wave)) \
                    * (1 + 0.5 * np.sin(2 * math.pi * s / wave))
            if case == "step":
                return floor + STEP * leg * (d > ahead)
            return floor + 0.0 * d

        self.height = height
        self.start, self.fwd, self.left, self.body = start, fwd, left, body

    def lay(self, name: str):
        """The ground mesh (a fine grid of ``height``) in the scene, or None."""
        import bpy

        if not self.ground_mesh:
            return None
        n_along, n_side = 360, 200
        d = np.linspace(-2 * self.body, 10 * self.body, n_along)
        s = np.linspace(-5 * self.body, 5 * self.body, n_side)
        if self.case == "step":   # a vertical riser: two rows of points at its edge
            edge = 0.6 * self.body
            riser = [edge - 1e-4 * self.body, edge + 1e-4 * self.body]
            d = np.sort(np.concatenate([d[np.abs(d - edge) > 1e-6], riser]))
        dd, ss = np.meshgrid(d, s, indexing="ij")
        x = self.start[0] + dd * self.fwd[0] + ss * self.left[0]
        y = self.start[1] + dd * self.fwd[1] + ss * self.left[1]
        z = self.height(x, y)
        verts = np.stack([x, y, z], axis=-1).reshape(-1, 3)
        quads = [(i * n_side + j, (i + 1) * n_side + j, (i + 1) * n_side + j + 1, i * n_side + j + 1)
                 for i in range(len(d) - 1) for j in range(n_side - 1)]
        me = bpy.data.meshes.new(name)
        me.from_pydata(verts.tolist(), [], quads)
        ob = bpy.data.objects.new(name, me)
        bpy.context.scene.collection.objects.link(ob)
        return ob

    def curve(self, name: str):
        """The path as a poly curve object in the scene, or None."""
        import bpy

        if self.path is None:
            return None
        cu = bpy.data.curves.new(name, "CURVE")
        cu.dimensions = "3D"
        sp = cu.splines.new("POLY")
        sp.points.add(len(self.path) - 1)
        for p, q in zip(sp.points, self.path):
            p.co = (*q, 1.0)
        ob = bpy.data.objects.new(name, cu)
        bpy.context.scene.collection.objects.link(ob)
        return ob

    def tangent_angle(self, xy: np.ndarray) -> np.ndarray:
        """(k,) the path's heading (radians) at its point nearest each of ``xy`` (k, 2)."""
        seg = np.diff(self.path[:, :2], axis=0)
        near = np.argmin(np.linalg.norm(self.path[None, :-1, :2] - xy[:, None], axis=2), axis=1)
        t = seg[near]
        return np.arctan2(t[:, 1], t[:, 0])


def rig_frame(arm) -> dict:
    """The rig's forward axis, leg length and root head (world), as the core reads them."""
    import miniskeleton_core as core

    planning = importlib.import_module(blender_session.ADDON_MODULE + ".motion.planning")
    rigify = importlib.import_module(blender_session.ADDON_MODULE + ".motion.rigify")
    bones = planning.motion_bones(arm)
    if rigify.is_rigify(arm):
        bones = rigify.merged_segments(arm, bones)
    heads, tails, _ = planning.motion_skeleton(arm, bones)
    roles = core.detect_roles(heads, tails, bones.parents, bones.names)
    fwd = np.array(roles.forward, dtype=np.float64)
    fwd[2] = 0.0
    return dict(fwd=fwd / np.linalg.norm(fwd), leg=float(roles.leg_length),
                start=np.asarray(bones.heads[roles.root], dtype=np.float64))


def body_yaw(anatomy: "Anatomy", ends) -> tuple[np.ndarray, np.ndarray]:
    """(frames,) the body's heading (radians, unwrapped): square to the line from its right legs'
    tops to its left legs' (``sample``'s bone ends); and (frames, 2) where the body is: the
    centre of its legs' tops, seen from above."""
    def tops(side):
        return np.mean([anatomy.end(ends, first) for s, first, _ in anatomy.legs if s == side], axis=0)

    left, right = tops("L"), tops("R")
    across = left - right
    return np.unwrap(np.arctan2(-across[:, 0], across[:, 1])), 0.5 * (left + right)[:, :2]


def steer_row(rig, case: str, motion: str = "WALK") -> dict:
    """Add Motion ``motion`` on ``rig`` for the steering ``case`` (``Course``), measured in the
    ground's frame: each vertex's height above the ground under it. Returns the operator's
    result, seconds, and skate, stance (worst standing foot's median height above the surface, %
    of diag), pen (deepest vertex below it, %), heading (largest angle between the body's turn,
    ``body_yaw``, and the path's where the body is, degrees) and travel (the centroid's, % of
    diag; in place)."""
    import bpy

    basis = rig.arm.matrix_basis.copy()
    reset_rig(rig.arm, basis)
    rest = rest_of(rig.meshes)
    frame = rig_frame(rig.arm)
    along = rest["points"][:, :2] @ frame["fwd"][:2]
    body = max(float(np.ptp(along)), float(np.ptp(rest["points"][:, 2])))
    course = Course(case, frame["start"], frame["fwd"], body, frame["leg"], rest["ground"])
    ground, path = course.lay(f"ground_{case}"), course.curve(f"path_{case}")
    props = dict(path=path.name if path else "", ground=ground.name if ground else "", in_place=case == "in_place")
    if case == "slope" or case == "bumps" or case == "step":
        props["cycles"] = 4.0
    result, error, secs, text = add_motion(rig.arm, motion, props)
    row = dict(rig=rig.name if hasattr(rig, "name") else "", case=case, motion=motion, result=result,
               secs=secs, error=error, diag=rest["diag"])
    if row["result"] == "FINISHED":
        info = [ln[6:] for ln in text.splitlines() if ln.startswith("Info: ")]
        span = re.search(r"frames (-?\d+)-(-?\d+)", " ".join(info))
        frames = list(range(int(span.group(1)), int(span.group(2)) + 1))
        anatomy = anatomy_of(rig.arm, rig.meshes, text, rest)
        pts, ends = sample(rig.meshes, frames, rig.arm, anatomy.bones)
        row.update(steer_measures(course, pts, ends, anatomy, rest, body_yaw(anatomy, ends)))
        row["frames"] = len(frames)
    reset_rig(rig.arm, basis)
    for ob in (ground, path):
        if ob is not None:
            data = ob.data
            bpy.data.objects.remove(ob)
            (bpy.data.meshes if ground is ob else bpy.data.curves).remove(data)
    return row


def steer_measures(course: Course, pts, ends, anatomy, rest, body) -> dict:
    """The measures of ``steer_row`` from the sampled vertices ``pts`` (frames, n, 3) and the
    ``body``'s heading and place (``body_yaw``)."""
    diag = rest["diag"]
    flat = pts.copy()
    flat[..., 2] -= course.height(pts[..., 0], pts[..., 1])   # height above the ground under it
    level = dict(rest, ground=0.0)
    out = dict(skate=skate(flat, diag), pen=max(0.0, -float(flat[..., 2].min())) * 100.0 / diag,
               travel=float(np.linalg.norm(pts[-1].mean(0)[:2] - pts[0].mean(0)[:2])) * 100.0 / diag)
    out.update({k: v for k, v in anatomy.measure(flat, ends, level).items() if k in ("stance", "contact")})
    if course.path is not None:
        yaws, centre = body
        want = np.unwrap(course.tangent_angle(centre))
        turn = (yaws - yaws[0]) - (want - want[0])
        out["heading"] = float(np.degrees(np.abs(turn)).max())
    return out


def steer_cells(row: dict) -> dict:
    """The steering table's cells with ✓ / ✗ against ``STEER_TARGET``."""
    t = STEER_TARGET
    done = row["result"] == "FINISHED"
    out = dict(result="FINISHED" if done else "CANCELLED: " + shorten((row["error"] or "").replace("\n", " "), 60))
    for key in ("skate", "stance", "pen", "heading", "travel"):
        value = row.get(key)
        if not done or value is None or (key in ("skate", "stance") and row["case"] == "in_place") \
                or (key == "travel" and row["case"] != "in_place"):
            out[key] = "–"
            continue
        ok = (value <= t[key]) if key != "stance" else abs(value) <= t[key]
        out[key] = fmt(value) + mark(bool(ok) and not math.isnan(value))
    out["secs"] = f"{row['secs']:.2f}"
    return out


STEER_COLUMNS = [("rig", "rig"), ("case", "case"), ("motion", "motion"), ("result", "result"), ("skate", "skate"),
                 ("stance", "stance %"), ("pen", "pen. %"), ("heading", "heading °"), ("travel", "travel %"),
                 ("secs", "op s")]


def steer_table(rows) -> str:
    lines = ["| " + " | ".join(title for _, title in STEER_COLUMNS) + " |",
             "|" + "|".join("---" for _ in STEER_COLUMNS) + "|"]
    for row in rows:
        c = dict(rig=row["rig"], case=row["case"], motion=row["motion"], **steer_cells(row))
        lines.append("| " + " | ".join(str(c[key]) for key, _ in STEER_COLUMNS) + " |")
    met = sum(not any("✗" in str(v) for v in steer_cells(r).values()) and r["result"] == "FINISHED" for r in rows)
    return "\n".join(lines + ["", f"Rows meeting every target: {met} of {len(rows)}."])


if __name__ == "__main__":
    main()
