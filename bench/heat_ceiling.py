"""How low bone heat itself can take the deformation error on a real model, whatever picks the
heat sources: the core's own solve fed with each vertex's nearest visible bone (its own rule)
and with the artist's own dominant bone (an oracle no automatic method has), over heat
constants.

    .venv/bin/python -m bench.heat_ceiling [--models CesiumMan,Fox] [--clips 1] [--constants 0.5,1,2]

For each model (``../shared/models/``, skipped when absent) our operator rebinds it as in
``testkit/eval_weights.py``; the core's inputs of that call (vertices and bones in the armature
frame, and its keywords) are captured, and the same bone-heat solve of Baran & Popovic 2007 is
run again through ``miniskeleton_core.heat_weights_from_sources`` (the core's debug entry point:
the operator's solve, weld, Laplacian, bone segments, ramp and top 4 included), with the heat
sources ``p`` given and every other keyword as the operator passed it. Only the sources change,
not the distance ``d`` in ``H = 4 c / d^2`` (each vertex's own, to its nearest visible bone):

- nearest visible bone: the core's own sources (``heat_sources``); at c 1 it is the operator's
  result;
- oracle: the bone that dominates the vertex in the artist's weights;
- artist's weights: every bone at its share of the artist's weights (the answer itself as the
  source: how close heat's diffusion alone lets a source get).

Deformation error as ``eval_weights.py`` (mean distance to the artist-weighted mesh over the
first ``--clips`` animations, % of the rest bounding-box diagonal). Nothing is asserted: this
measures what the method allows, to tell apart a weak implementation from a limit of bone heat.
Models solved in more than one core call (several skinned meshes) are skipped.
"""

from __future__ import annotations

import argparse

import numpy as np

from testkit import MODELS_DIR, blender_session
from testkit import eval_weights as ev


def capture(core) -> list:
    """Record the inputs of every ``heat_weights_report`` / ``heat_weights_many`` call."""
    calls = []
    report, many = core.heat_weights_report, core.heat_weights_many

    def report_spy(v, t, h, tl, progress=None, **options):
        calls.append(dict(args=(v, t, h, tl), options=options))
        return report(v, t, h, tl, progress=progress, **options)

    def many_spy(jobs, *a, **kw):
        calls.append(None)  # batched small meshes: not handled here
        return many(jobs, *a, **kw)

    core.heat_weights_report, core.heat_weights_many = report_spy, many_spy
    return calls


def dense(indices, weights, bones):
    """(n, bones) weights from top-k rows."""
    out = np.zeros((len(indices), bones))
    rows = np.nonzero(indices >= 0)
    np.add.at(out, (rows[0], indices[rows]), weights[rows])
    return out


def one_model(bpy, core, calls, model, path, args):
    """Rebind one model with our operator, then print the table of this solve's sources."""
    calls.clear()
    ctx, ours = ev.rebind(bpy, path, True, args)
    if not ctx["meshes"]:
        return print(f"[ceiling] {model}: nothing to compare ({ctx['reason']}), skipped")
    n_total = sum(len(x) for x in ctx["locals"])
    if len(ctx["meshes"]) != 1 or len(calls) != 1 or calls[0] is None or len(calls[0]["args"][0]) != n_total:
        return print(f"[ceiling] {model}: {len(ctx['meshes'])} skinned meshes in {len(calls)} core calls; "
                     "skipped (one mesh solved in one call only)")
    mesh, options = calls[0]["args"], calls[0]["options"]
    art = ev.normalized(np.concatenate(ctx["artist"]))
    poses = ctx["poses"]
    x_art = ev.deformed(ctx["locals"], poses, [art])

    def deform(w):
        dist = np.linalg.norm(ev.deformed(ctx["locals"], poses, [w]) - x_art, axis=2)
        return 100.0 * float(dist.mean()) / ctx["diag"]

    bones, n = len(mesh[2]), len(mesh[0])
    if art.shape[1] != bones:
        return print(f"[ceiling] {model}: {art.shape[1]} deform bones but {bones} bones solved; skipped")
    oracle = np.where(art.sum(axis=1) > 0, art.argmax(axis=1), -1)[:, None]
    sources = (("nearest visible bone (the operator's)", core.heat_sources(*mesh, **options)),
               ("oracle: artist's dominant bone", (oracle, np.ones((n, 1)))),
               ("oracle: artist's weights", (np.tile(np.arange(bones), (n, 1)), art)))
    rows = []
    for name, (indices, weights) in sources:
        vals = []
        for c in args.constants:
            out = core.heat_weights_from_sources(*mesh, indices, weights, **{**options, "heat_constant": c})
            report = out.report
            vals.append(deform(ev.normalized(dense(out.indices, out.weights, bones))))
        rows.append((name, vals))
    welded = n - report.welded_vertices
    print(f"\n{model}: {n_total} vertices ({welded} welded), {bones} bones, {len(poses)} frames; "
          f"deform %: our operator {deform(ev.normalized(ours.w)):.3f} (c 1); this solve by heat constant c:")
    print("| source | " + " | ".join(f"c {c:g}" for c in args.constants) + " |")
    print("|---|" + "---:|" * len(args.constants))
    for name, vals in rows:
        print(f"| {name} | " + " | ".join(f"{x:.3f}" for x in vals) + " |", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--models", default="CesiumMan,Fox", help="file stems in ../shared/models")
    ap.add_argument("--clips", type=int, default=1, help="first N animations (1: the issue's protocol)")
    ap.add_argument("--frames", type=int, default=20, help="frames sampled per animation")
    ap.add_argument("--constants", default="0.5,1,2", help="heat constants c (the operator uses 1)")
    args = ap.parse_args(argv)
    args.constants = [float(c) for c in args.constants.split(",")]
    args.actions, args.no_blender = "", True
    if not MODELS_DIR.is_dir():
        return print(f"[ceiling] no models folder {MODELS_DIR}: nothing to measure")
    bpy = blender_session.start()
    import miniskeleton_core as core

    calls = capture(core)
    for model in (m.strip() for m in args.models.split(",") if m.strip()):
        hits = sorted(MODELS_DIR.glob(model + ".gl*"))
        if not hits:
            print(f"[ceiling] {model}: not in {MODELS_DIR}, skipped")
            continue
        one_model(bpy, core, calls, model, hits[0], args)


if __name__ == "__main__":
    main()
