"""Speed: MiniSkeleton's Auto Weights (Heat) operator vs Blender's own
``parent_set(type='ARMATURE_AUTO')`` on the same capped cylinder + bone chain, in one process.

    .venv/bin/python bench/bench_weights.py [--sizes 6.5k:10,26k:20,103k:40,206k:40]
                                            [--shapes issue,thin] [--repeats 3] [--no-blender]

Two cylinder shapes per size. Blender's time depends strongly on the proportions (at 103k
vertices: 5.6 s with 128 segments around, 8.7 s with 256, 18 s with 512), ours hardly:
  issue  segments around chosen so that Blender's own time on this machine is close to the
         issue's reference figures (0.19 / 1.39 / 12.5 / 54.1 s);
  thin   128 segments around at every size (a long thin tube: Blender's best case).
Prints a markdown table: shape, vertices, bones, Blender s, ours s (whole operator: read mesh,
weights, write groups; median of --repeats runs), ratio, and the core's own split (best of the
repeats): total against factor+solve, the latter both as numeric factor + solves ("f+s") and
with the symbolic analysis (AMD ordering, elimination tree, supernodes) that is part of any
sparse factorization, as in SciPy's SuperLU figure the issue compares with ("sym+f+s"; our
symbolic step runs while the BVH is built, so it is not on the critical path). Also IDW and
BILINEAR. Nothing is asserted: tests check correctness, this measures speed.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import blender_session  # noqa: E402

# (rings, segments) per size and shape.
SHAPES = {
    "issue": {"6.5k": (80, 80), "26k": (133, 192), "103k": (268, 384), "206k": (200, 1024)},
    "thin": {"6.5k": (50, 128), "26k": (203, 128), "103k": (805, 128), "206k": (1610, 128)},
}


def cylinder_object(bpy, core, rings, segments, height):
    v, t = core.capped_cylinder(0.5, height, rings, segments)
    me = bpy.data.meshes.new("BenchCylinder")
    me.vertices.add(len(v))
    me.vertices.foreach_set("co", v.ravel())
    me.loops.add(t.size)
    me.loops.foreach_set("vertex_index", t.ravel().astype(np.int32))
    me.polygons.add(len(t))
    me.polygons.foreach_set("loop_start", np.arange(0, t.size, 3, dtype=np.int32))
    me.update(calc_edges=True)
    ob = bpy.data.objects.new("BenchCylinder", me)
    bpy.context.scene.collection.objects.link(ob)
    return ob, v, t


def chain_object(bpy, core, height, bones):
    heads, tails, parents = core.bone_chain(height, bones)
    arm = bpy.data.armatures.new("BenchRig")
    ob = bpy.data.objects.new("BenchRig", arm)
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    prev = None
    for i, (h, t) in enumerate(zip(heads, tails)):
        eb = arm.edit_bones.new(f"Bone{i:02d}")
        eb.head, eb.tail = h.tolist(), t.tolist()
        if prev is not None:
            eb.parent, eb.use_connect = prev, True
        prev = eb
    bpy.ops.object.mode_set(mode="OBJECT")
    return ob, heads, tails


def select(bpy, mesh, rig):
    for ob in bpy.context.view_layer.objects:
        ob.select_set(ob in (mesh, rig))
    bpy.context.view_layer.objects.active = rig


def unbind(mesh):
    mesh.vertex_groups.clear()
    for m in list(mesh.modifiers):
        mesh.modifiers.remove(m)
    mesh.parent = None


def unweighted(mesh):
    counts = np.zeros(len(mesh.data.vertices), dtype=np.int64)
    for v in mesh.data.vertices:
        counts[v.index] = sum(1 for g in v.groups if g.weight > 0)
    return int((counts == 0).sum())


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="6.5k:10,26k:20,103k:40,206k:40")
    ap.add_argument("--shapes", default="issue,thin", help="cylinder proportions: issue, thin")
    ap.add_argument("--repeats", type=int, default=3, help="runs of our operator (median) and core (best)")
    ap.add_argument("--no-blender", action="store_true", help="skip Blender's own operator")
    args = ap.parse_args(argv)
    bpy = blender_session.start()
    import miniskeleton_core as core

    rows = []
    specs = [(shape, spec) for shape in args.shapes.split(",") for spec in args.sizes.split(",")]
    for shape, spec in specs:
        size, bones = spec.split(":")
        rings, segments = SHAPES[shape][size]
        blender_session.reset_scene()
        height = 8.0
        mesh, v, t = cylinder_object(bpy, core, rings, segments, height)
        rig, heads, tails = chain_object(bpy, core, height, int(bones))
        n = len(mesh.data.vertices)

        blender_s = blender_missing = None
        if not args.no_blender:
            select(bpy, mesh, rig)
            blender_s, _ = timed(lambda: bpy.ops.object.parent_set(type="ARMATURE_AUTO"))
            blender_missing = unweighted(mesh)
            unbind(mesh)

        runs = []
        for _ in range(max(args.repeats, 1)):
            unbind(mesh)
            select(bpy, mesh, rig)
            secs, res = timed(lambda: bpy.ops.object.miniskeleton_auto_weights(method="HEAT"))
            assert res == {"FINISHED"}
            runs.append(secs)
        ours_s = float(np.median(runs))
        ours_missing = unweighted(mesh)
        core_s, report = min((timed(lambda: core.heat_weights_report(v, t, heads, tails)[2])
                              for _ in range(max(args.repeats, 1))), key=lambda r: r[0])
        fs = sum(s for k, s in report["timings"].items() if k in ("factor", "solve"))
        sfs = fs + report["timings"].get("symbolic", 0.0)
        extra = {}
        for method in ("BILINEAR", "IDW"):
            unbind(mesh)
            select(bpy, mesh, rig)
            extra[method], _ = timed(lambda: bpy.ops.object.miniskeleton_auto_weights(method=method))
        rows.append((f"{shape} {rings}x{segments}", n, int(bones), blender_s, blender_missing, ours_s, ours_missing, core_s, fs, sfs,
                     extra["BILINEAR"], extra["IDW"], report["timings"]))
        print(f"done {shape} {n} vertices", flush=True)

    print()
    print("| shape rings x segments | vertices | bones | Blender ARMATURE_AUTO s | unweighted | ours HEAT s "
          "| unweighted | speed-up | core heat s | f+s s | core / (f+s) | sym+f+s s | core / (sym+f+s) "
          "| ours BILINEAR s | ours IDW s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for shape, n, b, bs, bm, os_, om, cs, fs, sfs, bil, idw, _ in rows:
        ratio = f"{bs / os_:.1f}x" if bs else "-"
        print(f"| {shape} | {n} | {b} | {bs if bs is None else f'{bs:.2f}'} | {bm if bm is not None else '-'} "
              f"| {os_:.3f} | {om} | {ratio} | {cs:.3f} | {fs:.3f} | {cs / max(fs, 1e-9):.2f} "
              f"| {sfs:.3f} | {cs / max(sfs, 1e-9):.2f} "
              f"| {bil:.3f} | {idw:.3f} |")
    print()
    for shape, n, *_, timings in rows:
        print(f"core stages, {shape}, {n}: " + ", ".join(f"{k} {s:.3f}" for k, s in timings.items()))


if __name__ == "__main__":
    main()
