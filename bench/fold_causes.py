"""Whether a clip folds the skin because of its poses or because of the weights: the same skeleton
and the same walk, run and head shake measured (``motion_corpus.folds``: the worst frame's
change of enclosed volume and share of collapsed triangles, on the largest mesh) with that mesh
bound three ways.

    .venv/bin/python -m bench.fold_causes [--rigs autorig_horse,autorig_Fox] [--motions WALK,RUN]

- ``as built``: the corpus rig's own weights (the auto-rigged rows: Auto Weights' Heat; the
  Fox: its artist's);
- ``Blender``: Blender's own bone heat (Ctrl+P > With Automatic Weights, ``ARMATURE_AUTO``);
- ``segments``: each vertex to its nearest bone segments (``rig_corpus.bind_to_segments``, the
  weights the corpus gives rigs whose files have none), rigid but for a blend at the joints.

A clip that folds the skin under every binding folds it by its poses; one that stays within the
targets (``motion_corpus.FOLDS``) under another binding folds it through the weights. Writes the
table to stdout and out/fold_causes.md. Rigs default to the auto-rigged ones and the Fox.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from testkit import ROOT, blender_session

BINDINGS = ["as built", "Blender", "segments"]


def largest(meshes):
    return max(meshes, key=lambda ob: len(ob.data.vertices))


def rebind(rig, how: str) -> None:
    """Bind the largest of ``rig``'s meshes to its armature's deform bones ``how``: "Blender" or
    "segments" (its groups and Armature modifiers replaced; the other meshes as they are)."""
    import bpy
    from testkit import rig_corpus

    arm, body = rig.arm, largest(rig.meshes)
    rig_corpus.unbind(body)
    deform = [b.name for b in arm.data.bones if b.use_deform]
    if how == "segments":
        rig_corpus.bind_to_segments(body, arm, deform)
    else:
        rig_corpus.set_active(arm, selected=[body])
        if bpy.ops.object.parent_set(type="ARMATURE_AUTO") != {"FINISHED"}:
            raise RuntimeError("Blender's automatic weights failed")
    bpy.context.view_layer.update()


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
    for name in names:
        why = rig_corpus.missing(name)
        if why:
            print(f"skipped {name}: {why}", flush=True)
            continue
        cells = {m: [] for m in motions}
        for how in BINDINGS:
            blender_session.reset_scene()
            with corpus.captured_output():
                rig = rig_corpus.build(name)
                if how != "as built":
                    rebind(rig, how)
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
    text = "\n".join(["## Skin folds by binding", ""] + lines)
    print()
    print(text)
    blender_session.write_report(Path(args.out), text)


if __name__ == "__main__":
    main()
