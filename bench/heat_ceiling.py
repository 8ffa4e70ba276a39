"""How low bone heat itself can take the deformation error on a real model, whatever picks the
heat sources: the same solve fed with each vertex's nearest bone and with the artist's own
dominant bone (an oracle no automatic method has), over heat constants.

    .venv/bin/python bench/heat_ceiling.py [--models CesiumMan,Fox] [--clips 1] [--constants 0.5,1,2]

For each model (``../shared/models/``, skipped when absent) our operator rebinds it as in
``bench/eval_weights.py``; the core's inputs of that call (vertices and bones in the armature
frame, parents) are captured, and the bone-heat system of Baran & Popovic 2007 is solved again
here, densely in numpy, as the core does it: vertices welded, cotangent Laplacian ``L`` with
lumped mass ``M``, ``(L + M H) w_j = M H p_j`` with ``H = 4 c / d^2`` (``HEAT_SCALE``),
Blender's small-weight ramp, the top 4 kept, rows normalized. Only the source ``p`` (and its
distance ``d``) changes:

- nearest: the bone nearest by Blender's normal-weighted distance (the core's rule without the
  ray test; its score sits next to the core's own to show the two solves agree);
- oracle: the bone that dominates the vertex in the artist's weights, at its distance;
- artist's weights: every bone at its share of the artist's weights, at the nearest distance
  (the answer itself as the source: how close heat's diffusion alone lets a source get).

Deformation error as ``eval_weights.py`` (mean distance to the artist-weighted mesh over the
first ``--clips`` animations, % of the rest bounding-box diagonal). Nothing is asserted: this
measures what the method allows, to tell apart a weak implementation from a limit of bone heat.
Models solved in more than one core call (several skinned meshes) are skipped.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "bench"), str(ROOT / "scripts")]
import blender_session  # noqa: E402
import eval_weights as ev  # noqa: E402

HEAT_SCALE = 4.0  # the core's heat::HEAT_SCALE
MIN_DISTANCE = 1e-5  # the core's heat::MIN_DISTANCE, in bbox diagonals
RAMP = (0.05, 0.025)  # Blender's WEIGHT_LIMIT_START / _END, the core's default ramp
MAX_DENSE = 8000  # welded vertices solved densely at most


def capture(core) -> list:
    """Record the inputs of every ``heat_weights_report`` / ``heat_weights_many`` call."""
    calls = []
    report, many = core.heat_weights_report, core.heat_weights_many

    def report_spy(v, t, h, tl, **kw):
        calls.append(dict(v=np.array(v, float), t=np.array(t), h=np.array(h, float), tl=np.array(tl, float),
                          parents=kw.get("parents")))
        return report(v, t, h, tl, **kw)

    def many_spy(jobs, *a, **kw):
        calls.append(None)  # batched small meshes: not handled here
        return many(jobs, *a, **kw)

    core.heat_weights_report, core.heat_weights_many = report_spy, many_spy
    return calls


def welded(v, t, diag):
    """(unique positions, index of each input vertex, triangles on them without repeats)."""
    key = np.round(v / (1e-5 * diag)).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    p, f = v[first], inv.ravel()[t]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    return p, inv.ravel(), f


def laplacian(p, f):
    """Dense cotangent stiffness (positive semidefinite), lumped mass and outward vertex normals."""
    n = len(p)
    cross = np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]])
    twice = np.linalg.norm(cross, axis=1)
    keep = twice > 1e-12 * np.max(np.linalg.norm(p[f] - p[np.roll(f, 1, axis=1)], axis=2) ** 2, axis=1)
    f, cross, twice = f[keep], cross[keep], twice[keep]
    stiff = np.zeros((n, n))
    for k in range(3):
        i, j, o = f[:, k], f[:, (k + 1) % 3], f[:, (k + 2) % 3]
        cot = ((p[i] - p[o]) * (p[j] - p[o])).sum(axis=1) / twice
        np.add.at(stiff, (i, j), -cot / 2)
        np.add.at(stiff, (j, i), -cot / 2)
    stiff -= np.diag(stiff.sum(axis=1))
    mass, normals = np.zeros(n), np.zeros((n, 3))
    for k in range(3):
        np.add.at(mass, f[:, k], twice / 6)
        np.add.at(normals, f[:, k], cross)
    if ((p - p.mean(axis=0)) * normals).sum() < 0:  # inward winding
        normals = -normals
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-30)
    return stiff, mass, normals


def bone_segments(h, tl, parents, diag):
    """The core's segments of each bone (``reach::reach_segments``, every span taken as inside,
    a childless bone's continuation of its parent's line not cut at the surface)."""
    segs, owner = [], []
    kids = [[] for _ in h]
    for c, par in enumerate(parents if parents is not None else []):
        if par >= 0:
            kids[par].append(c)
    for b in range(len(h)):
        tail_child, spans = False, []
        for c in kids[b]:
            if np.linalg.norm(h[c] - tl[b]) <= 1e-5 * diag:
                tail_child = True
            elif np.linalg.norm(h[c] - h[b]) > 1e-5 * diag:
                spans.append(h[c])
        segs += [(h[b], s) for s in spans]
        owner += [b] * len(spans)
        if tail_child or not spans:
            segs.append((h[b], tl[b]))
            owner.append(b)
    for b in range(len(h)):
        par = parents[b] if parents is not None else -1
        line = h[b] - h[par] if par >= 0 and not kids[b] else np.zeros(3)
        if np.linalg.norm(line) > 1e-5 * diag:
            segs.append((h[b], h[b] + line / np.linalg.norm(line) * np.linalg.norm(tl[b] - h[b])))
            owner.append(b)
    return segs, np.array(owner)


def ranked_distances(p, normals, segs, owner, bones):
    """(n, bones) Blender's normal-weighted distance ``d / ((cos + 1.001) / 2)`` to each bone."""
    out = np.full((len(p), bones), np.inf)
    for (a, b), j in zip(segs, owner):
        d = b - a
        s = np.clip(((p - a) @ d) / max(d @ d, 1e-300), 0, 1)
        r = p - (a + s[:, None] * d)
        dist = np.linalg.norm(r, axis=1)
        cos = (r * normals).sum(axis=1) / np.maximum(dist, 1e-300)
        out[:, j] = np.minimum(out[:, j], dist / ((cos + 1.001) / 2))
    return out


def heat(stiff, mass, shares, dist, c, diag, k=4):
    """Solve ``(L + M H) W = M H P`` for sources ``shares`` = P (n, bones) at distances ``dist`` (n,)."""
    h = mass * HEAT_SCALE * c / np.maximum(dist, MIN_DISTANCE * diag) ** 2
    w = np.clip(np.linalg.solve(stiff + np.diag(h), h[:, None] * shares), 0, 1)
    start, end = RAMP
    w = np.where(w < end, 0, np.where(w < start, start * (w - end) / (start - end), w))
    drop = np.argsort(-w, axis=1)[:, k:]
    np.put_along_axis(w, drop, 0, axis=1)
    return w / np.maximum(w.sum(axis=1, keepdims=True), 1e-300)


def one_model(bpy, calls, model, path, args):
    """Rebind one model with our operator, then print the table of this solve's sources."""
    calls.clear()
    ctx, ours = ev.rebind(bpy, path, True, args)
    if not ctx["meshes"]:
        return print(f"[ceiling] {model}: nothing to compare ({ctx['reason']}), skipped")
    n_total = sum(len(x) for x in ctx["locals"])
    if len(ctx["meshes"]) != 1 or len(calls) != 1 or calls[0] is None or len(calls[0]["v"]) != n_total:
        return print(f"[ceiling] {model}: {len(ctx['meshes'])} skinned meshes in {len(calls)} core calls; "
                     "skipped (one mesh solved in one call only)")
    cap = calls[0]
    art = ev.normalized(np.concatenate(ctx["artist"]))
    poses = ctx["poses"]
    x_art = ev.deformed(ctx["locals"], poses, [art])

    def deform(w):
        dist = np.linalg.norm(ev.deformed(ctx["locals"], poses, [w]) - x_art, axis=2)
        return 100.0 * float(dist.mean()) / ctx["diag"]

    v = cap["v"]
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    p, inv, f = welded(v, cap["t"], diag)
    if len(p) > MAX_DENSE:
        return print(f"[ceiling] {model}: {len(p)} welded vertices, more than {MAX_DENSE}; skipped")
    stiff, mass, normals = laplacian(p, f)
    bones = len(cap["h"])
    segs, owner = bone_segments(cap["h"], cap["tl"], cap["parents"], diag)
    ranked = ranked_distances(p, normals, segs, owner, bones)
    near = ranked.argmin(axis=1)
    # The artist's dominant bone of each welded vertex (split copies vote by summed weight).
    votes = np.zeros((len(p), bones))
    np.add.at(votes, inv, art)
    oracle = votes.argmax(axis=1)
    one = np.eye(bones)
    sources = (("nearest", one[near], ranked[np.arange(len(p)), near]),
               ("oracle: artist's dominant bone", one[oracle], ranked[np.arange(len(p)), oracle]),
               ("oracle: artist's weights", votes / np.maximum(votes.sum(axis=1, keepdims=True), 1e-300),
                ranked.min(axis=1)))
    rows = [(name, [deform(heat(stiff, mass, shares, dist, c, diag)[inv]) for c in args.constants])
            for name, shares, dist in sources]
    print(f"\n{model}: {n_total} vertices ({len(p)} welded), {bones} bones, {len(poses)} frames; "
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
    if not ev.MODELS_DIR.is_dir():
        return print(f"[ceiling] no models folder {ev.MODELS_DIR}: nothing to measure")
    bpy = blender_session.start()
    import miniskeleton_core as core

    calls = capture(core)
    for model in (m.strip() for m in args.models.split(",") if m.strip()):
        hits = sorted(ev.MODELS_DIR.glob(model + ".gl*"))
        if not hits:
            print(f"[ceiling] {model}: not in {ev.MODELS_DIR}, skipped")
            continue
        one_model(bpy, calls, model, hits[0], args)


if __name__ == "__main__":
    main()
