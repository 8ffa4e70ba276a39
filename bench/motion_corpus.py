"""Add Motion on real rigs: head shake, walk and run on the rig corpus of scripts/rig_corpus.py
(Rigify control rigs, Mixamo-style humanoids round-tripped through glTF and FBX, game and
hand-made rigs from ../shared/models, a deform-only rig, the generated creature, legless
characters), measured on the meshes the armature deforms.

    .venv/bin/python bench/motion_corpus.py [--rigs Fox,mixamo_gltf] [--motions WALK,RUN,HEAD_SHAKE]

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

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "scripts")]
import blender_session  # noqa: E402

MOTIONS = ["WALK", "RUN", "HEAD_SHAKE"]
CONTACT = 0.005     # contact band above the lowest z, fraction of diag
TARGET = dict(moves=2.0, skate=0.15, pen=1.0, float=1.0, feet=0.5, head=5.0, inert=0.1)


# ---------------------------------------------------------------------------- measure

def world_points(meshes) -> np.ndarray:
    """(n, 3) evaluated world vertices of ``meshes`` (modifiers and parents applied), stacked."""
    import bpy

    dg = bpy.context.evaluated_depsgraph_get()
    out = []
    for ob in meshes:
        ev = ob.evaluated_get(dg)
        me = ev.to_mesh()
        co = np.empty(len(me.vertices) * 3)
        me.vertices.foreach_get("co", co)
        ev.to_mesh_clear()
        m = np.array(ev.matrix_world)
        out.append(co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3])
    return np.concatenate(out) if out else np.zeros((0, 3))


def sample(meshes, frames) -> np.ndarray:
    """(len(frames), n, 3) world vertices of ``meshes`` on each of ``frames``."""
    import bpy

    scene = bpy.context.scene
    out = []
    for f in frames:
        scene.frame_set(int(f))
        out.append(world_points(meshes))
    return np.stack(out)


def rest_of(meshes) -> dict:
    """The rest pose's vertices, bounding-box diagonal and lowest z (call with the rig at rest)."""
    p = world_points(meshes)
    return dict(points=p, diag=float(np.linalg.norm(np.ptp(p, axis=0))), ground=float(p[:, 2].min()))


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


def measure(arm, meshes, frames, rest: dict | None = None) -> dict:
    """Measures of ``meshes`` over ``frames`` against ``rest`` (``rest_of``, taken now when not
    given, so the rig must then be at rest): moves, deform, skate, pen(etration), float, feet (% of
    diag but skate) and the per-frame lowest z. ``arm`` is unused here but for symmetry with
    ``head_turn``; frames are scene frames."""
    rest = rest or rest_of(meshes)
    diag, ground, p0 = rest["diag"], rest["ground"], rest["points"]
    pts = sample(meshes, frames)
    pct = 100.0 / diag
    low = pts[:, :, 2].min(axis=1)
    feet = p0[:, 2] <= ground + CONTACT * diag
    return dict(
        diag=diag, ground=ground, frames=len(frames),
        moves=float(np.linalg.norm(pts - p0, axis=2).max()) * pct,
        deform=float(np.linalg.norm(pts - p0 - (pts.mean(axis=1) - p0.mean(axis=0))[:, None], axis=2).max()) * pct,
        skate=skate(pts, diag),
        pen=max(0.0, ground - float(low.min())) * pct,
        float=float(np.median(low - ground)) * pct,
        feet=float(np.linalg.norm(pts[:, feet] - p0[feet], axis=2).max()) * pct,
        centroid_travel=float(np.linalg.norm(pts[-1].mean(0)[:2] - pts[0].mean(0)[:2])) * pct,
    )


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
    text = out[0]
    row = dict(motion=motion, result=next(iter(result)), secs=secs, error=error, console=text,
               info=[ln[6:] for ln in text.splitlines() if ln.startswith("Info: ")],
               warnings=[ln[9:] for ln in text.splitlines() if ln.startswith("Warning: ")],
               roles=[ln.split("]", 1)[1].strip() for ln in text.splitlines()
                      if ln.startswith("[MiniSkeleton]") and "roles of" not in ln],
               keyed=sorted(keyed_bones(arm)), keyed_any=keyed_anything(arm))
    if row["result"] == "FINISHED":
        span = re.search(r"frames (-?\d+)-(-?\d+)", " ".join(row["info"]))
        scene = bpy.context.scene
        lo, hi = (int(span.group(1)), int(span.group(2))) if span else (scene.frame_start, scene.frame_end)
        frames = list(range(lo, hi + 1))
        row.update(measure(arm, meshes, frames, rest))
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
    elif done and motion == "HEAD_SHAKE":
        checks = dict(head=row.get("head", 0.0) >= TARGET["head"])
        if not legless:   # a legless rig's lowest points are a tail or a chin, not feet
            checks["feet"] = row["feet"] < TARGET["feet"]
    for key in ("moves", "deform", "skate", "pen", "float", "feet", "head"):
        if not done or (key == "feet" and motion != "HEAD_SHAKE") or (key == "head" and motion != "HEAD_SHAKE"):
            out[key] = "–"
        else:
            value = row.get(key)
            ok = checks.get(key)
            if key == "skate" and value is not None and math.isnan(value):
                ok = False if key in checks else None
            out[key] = fmt(value, 0 if key == "head" else 2) + mark(ok)
    return out


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
           ("feet", "feet %"), ("head", "head °"), ("secs", "op s")]


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
    args = ap.parse_args(argv)

    blender_session.start()
    import rig_corpus

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
            print(f"{name:24s} {motion:10s} {c['result'][:70]:70s} moves {c['moves']:8s} skate {c['skate']:8s} "
                  f"pen {c['pen']:8s} float {c['float']:8s} feet {c['feet']:8s} head {c['head']}", flush=True)
    text = "\n".join(["## Add Motion on the rig corpus", "", table(rows), "", summary(rows), ""] + skipped
                     + ["", "## Details", "", details(notes, rows)])
    print()
    print(text)
    blender_session.write_report(Path(args.out), text)


if __name__ == "__main__":
    main()
