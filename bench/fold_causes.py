"""Whether a clip folds the skin because of its poses or because of the weights: the same skeleton
and the same walk, run and head shake measured (``motion_corpus.folds``: the worst frame's
change of enclosed volume and share of collapsed triangles, on the largest mesh) with that mesh
bound four ways.

    .venv/bin/python -m bench.fold_causes [--rigs autorig_horse,autorig_Fox] [--motions WALK,RUN]

- ``as built``: the corpus rig's own weights (the auto-rigged rows: Auto Weights' Heat; the
  Fox: its artist's);
- ``Heat``: Auto Weights' Heat with its defaults (``miniskeleton_auto_weights``), the binding of
  the auto-rigged rows; on a rig with its artist's weights it tells our weights from theirs on
  the same skeleton;
- ``Blender``: Blender's own bone heat (Ctrl+P > With Automatic Weights, ``ARMATURE_AUTO``);
- ``segments``: each vertex to its nearest bone segments (``rig_corpus.bind_to_segments``, the
  weights the corpus gives rigs whose files have none), rigid but for a blend at the joints.

A clip that folds the skin under every binding folds it by its poses; one that stays within the
targets (``motion_corpus.FOLDS``) under another binding folds it through the weights, unless
that binding tears the skin: the second table gives, per binding, the share of the mesh's
vertices whose weights differ (L1 of the normalized rows > ``APART``) from those of another
vertex at the same rest position (the copies of a seam, of a UV split or of a flat-shaded
mesh's corners), which part when posed. Such a binding keeps each torn-off triangle's area and
leaves the enclosed volume of a closed shell, so the fold measures do not see the tear (the
Fox's 1728 vertices are its 576 triangles' own corners, and Blender's bone heat weights each
triangle alone). Writes the tables to stdout and out/fold_causes.md. Rigs default to the
auto-rigged ones and the Fox.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from testkit import ROOT, blender_session

BINDINGS = ["as built", "Heat", "Blender", "segments"]
# Copies of one rest vertex whose normalized weights differ by more than this (L1) part visibly.
APART = 0.05


def largest(meshes):
    return max(meshes, key=lambda ob: len(ob.data.vertices))


def rebind(rig, how: str) -> None:
    """Bind the largest of ``rig``'s meshes to its armature's deform bones ``how``: "Heat",
    "Blender" or "segments" (its groups and Armature modifiers replaced; the other meshes as they
    are)."""
    import bpy
    from testkit import rig_corpus

    arm, body = rig.arm, largest(rig.meshes)
    rig_corpus.unbind(body)
    deform = [b.name for b in arm.data.bones if b.use_deform]
    if how == "segments":
        rig_corpus.bind_to_segments(body, arm, deform)
    elif how == "Heat":
        rig_corpus.set_active(arm, selected=[body])
        if bpy.ops.object.miniskeleton_auto_weights(method="HEAT") != {"FINISHED"}:
            raise RuntimeError("Auto Weights' Heat failed")
    else:
        rig_corpus.set_active(arm, selected=[body])
        if bpy.ops.object.parent_set(type="ARMATURE_AUTO") != {"FINISHED"}:
            raise RuntimeError("Blender's automatic weights failed")
    bpy.context.view_layer.update()


def apart(rig) -> tuple[float, float]:
    """Of the largest of ``rig``'s meshes at rest: the % of its vertices whose normalized
    deform weights differ by more than ``APART`` (L1) from another vertex's at the same rest
    position (within 1e-5 of the diagonal), and the largest such difference."""
    from testkit.eval_weights import deform_bones, normalized, read_weights
    from testkit.measures import world_vertices

    body = largest(rig.meshes)
    p = world_vertices(body)
    w = normalized(read_weights(body, deform_bones(rig.arm)))
    key = np.round(p / max(float(np.linalg.norm(np.ptp(p, axis=0))), 1e-30) * 1e5).astype(np.int64)
    _, first, group = np.unique(key, axis=0, return_index=True, return_inverse=True)
    diff = np.abs(w - w[first[group.ravel()]]).sum(axis=1)
    worst = np.zeros(len(first))
    np.maximum.at(worst, group.ravel(), diff)
    gap = worst[group.ravel()]
    return float((gap > APART).mean()) * 100.0, float(gap.max()) if len(gap) else 0.0


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rigs", default="", help="comma list of rig_corpus names (default: auto-rigged ones and Fox)")
    ap.add_argument("--motions", default="WALK,RUN,HEAD_SHAKE")
    ap.add_argument("--out", default=str(ROOT / "out" / "fold_causes.md"))
    args = ap.parse_args(argv)
    blender_session.start()
    from testkit import motion_corpus as corpus
    from testkit import rig_corpus

    names = [n for n in args.rigs.split(",") if n] or list(rig_corpus.AUTORIG) + ["Fox"]
    motions = [m.strip().upper() for m in args.motions.split(",") if m.strip()]
    lines = ["| rig | motion | " + " | ".join(f"{b}: volume % / collapsed %" for b in BINDINGS) + " |",
             "|---|---|" + "---|" * len(BINDINGS)]
    torn = ["| rig | " + " | ".join(f"{b}: vertices apart from their copies % (largest L1)" for b in BINDINGS) + " |",
            "|---|" + "---|" * len(BINDINGS)]
    for name in names:
        why = rig_corpus.missing(name)
        if why:
            print(f"skipped {name}: {why}", flush=True)
            continue
        cells, parted = {m: [] for m in motions}, []
        for how in BINDINGS:
            blender_session.reset_scene()
            with corpus.captured_output():
                rig = rig_corpus.build(name)
                if how != "as built":
                    rebind(rig, how)
            share, worst = apart(rig)
            parted.append(f"{share:.1f} ({worst:.2f})")
            basis = rig.arm.matrix_basis.copy()
            for motion in motions:
                start = time.perf_counter()
                row = corpus.run_motion(rig.arm, rig.meshes, motion, basis)
                if row["result"] != "FINISHED":
                    cells[motion].append("–")
                    continue
                most = corpus.FOLDS.get(motion)
                ok = None if most is None else row["volume"] <= most[0] and row["collapsed"] <= most[1]
                cells[motion].append(f"{row['volume']:.2f} / {row['collapsed']:.2f}" + corpus.mark(ok))
                print(f"{name:20s} {motion:10s} {how:9s} volume {row['volume']:6.2f} collapsed "
                      f"{row['collapsed']:5.2f} ({time.perf_counter() - start:.1f} s)", flush=True)
        for motion in motions:
            lines.append(f"| {name} | {motion} | " + " | ".join(cells[motion]) + " |")
        torn.append(f"| {name} | " + " | ".join(parted) + " |")
    text = "\n".join(["## Skin folds by binding", ""] + lines + ["", "## Skin torn by binding", ""] + torn)
    print()
    print(text)
    blender_session.write_report(Path(args.out), text)


if __name__ == "__main__":
    main()
