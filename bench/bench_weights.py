"""Speed: MiniSkeleton's Auto Weights (Heat and Geodesic Voxel) operator vs Blender's own
``parent_set(type='ARMATURE_AUTO')`` on the same mesh and bones, in one process: generated
capped cylinders with a bone chain, and the unrigged scans of ../shared/models/ (cow, horse;
skipped when absent) with the skeleton Auto Rig finds in them (not bound by it).

    .venv/bin/python -m bench.bench_weights [--sizes 6.5k:10,26k:20,103k:40,206k:40]
                                                [--shapes issue,thin] [--scans cow.obj,horse.ply]
                                                [--scan-scales 1,10] [--parts 100,400]
                                                [--repeats 3] [--no-blender]

Two cylinder shapes per size. Blender's time depends strongly on the proportions (at 103k
vertices: 5.6 s with 128 segments around, 8.7 s with 256, 18 s with 512), ours hardly:
  issue  segments around chosen so that Blender's own time on this machine is close to the
         issue's reference figures (0.19 / 1.39 / 12.5 / 54.1 s);
  thin   128 segments around at every size (a long thin tube: Blender's best case).
Prints a markdown table: shape, vertices, bones, Blender s, ours s (whole operator: read mesh,
weights, write groups; median of --repeats runs), ratio, and the core's own split (best of the
repeats): total, peak memory (a fresh process making the cylinder and calling the core once),
against factor+solve, the latter both as numeric factor + solves ("f+s") and
with the symbolic analysis (ordering, elimination tree, supernodes) that is part of any
sparse factorization, as in SciPy's SuperLU figure the issue compares with ("sym+f+s"; our
symbolic step runs while the BVH is built, so it is not on the critical path). Also VOXEL (the
whole operator, median of --repeats, at its default Resolution; "voxel / heat" is its time over
HEAT's), IDW and BILINEAR. ``--parts``: a figure kit-built of that many small separate objects (86-vertex
capped cylinders along a 20-bone chain), where the cost is in writing groups to many objects,
not in the solve. Film scale (minutes; Blender's own operator would take hours):
``--sizes 1M:200,2M:200 --shapes issue --scans '' --parts '' --repeats 1 --no-blender``.
Nothing is asserted: tests check correctness, this measures speed.
"""

from __future__ import annotations

import argparse
import importlib
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from testkit import MODELS_DIR, blender_session, rig_corpus

# (rings, segments) per size and shape.
SHAPES = {
    "issue": {"6.5k": (80, 80), "26k": (133, 192), "103k": (268, 384), "206k": (200, 1024),
              "1M": (1000, 1000), "2M": (1414, 1414)},
    "thin": {"6.5k": (50, 128), "26k": (203, 128), "103k": (805, 128), "206k": (1610, 128),
             "1M": (7813, 128), "2M": (15625, 128)},
}

# The core's call alone in a fresh process, for its peak memory (the resident-set peak of a
# process holds for its whole life, so each row gets its own): the process's peak RSS in MB,
# read as VmHWM (`ru_maxrss` would keep the peak of the bench process it was forked from).
PEAK_SCRIPT = """
import sys
import miniskeleton_core as core
rings, segments, height, bones = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
v, t = core.capped_cylinder(0.5, height, rings, segments)
heads, tails, _ = core.bone_chain(height, bones)
core.heat_weights_report(v, t, heads, tails)
with open("/proc/self/status") as status:
    print(next(int(line.split()[1]) for line in status if line.startswith("VmHWM")) / 1024)
"""


def core_peak_mb(core, rings, segments, height, bones):
    """Peak resident memory (MB) of a fresh process making the cylinder and calling the core."""
    where = str(Path(core.__file__).resolve().parent.parent)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [where, os.environ.get("PYTHONPATH")])))
    args = [sys.executable, "-c", PEAK_SCRIPT, str(rings), str(segments), str(height), str(bones)]
    return float(subprocess.run(args, check=True, capture_output=True, text=True, env=env).stdout.split()[-1])


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
    names = [f"Bone{i:02d}" for i in range(len(heads))]
    bones = [(n, tuple(map(float, h)), tuple(map(float, t)), names[p] if p >= 0 else None, p >= 0)
             for n, h, t, p in zip(names, heads, tails, parents)]
    return rig_corpus.new_armature("BenchRig", bones), heads, tails


def scan_object(bpy, path, scale):
    """The scan at ``path`` (one mesh, +Z up) imported into an empty scene, its mesh data scaled
    by ``scale``, and Auto Rig's skeleton for it (not bound): (mesh, armature)."""
    from mathutils import Matrix

    blender_session.reset_scene()
    _, meshes, _ = blender_session.import_model(path)
    (mesh,) = meshes
    mesh.data.transform(Matrix.Scale(scale, 4))
    rig_corpus.set_active(mesh, selected=[mesh])
    assert bpy.ops.object.miniskeleton_auto_rig(template="AUTO", forward="AUTO", bind=False) == {"FINISHED"}
    return mesh, rig_corpus.imported_armature()


def select(bpy, mesh, rig):
    meshes = mesh if isinstance(mesh, list) else [mesh]
    for ob in bpy.context.view_layer.objects:
        ob.select_set(ob in meshes or ob == rig)
    bpy.context.view_layer.objects.active = rig
    # Evaluated before any clock starts, so that a timed call pays for its own changes and not
    # for re-evaluating what the set-up (or unbinding the previous run) changed: 400 small
    # objects take 0.04-0.09 s to re-evaluate, which fell on whichever call came next.
    bpy.context.view_layer.update()


def unbind(mesh):
    for ob in mesh if isinstance(mesh, list) else [mesh]:
        ob.vertex_groups.clear()
        for m in list(ob.modifiers):
            ob.modifiers.remove(m)
        ob.parent = None


def unweighted(mesh):
    counts = np.zeros(len(mesh.data.vertices), dtype=np.int64)
    for v in mesh.data.vertices:
        counts[v.index] = sum(1 for g in v.groups if g.weight > 0)
    return int((counts == 0).sum())


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def ours_heat(bpy, mesh, rig, repeats, method="HEAT"):
    """Median seconds of our operator (``method``) over ``repeats`` runs, each from unbound mesh(es)."""
    runs = []
    for _ in range(max(repeats, 1)):
        unbind(mesh)
        select(bpy, mesh, rig)
        secs, res = timed(lambda: bpy.ops.object.miniskeleton_auto_weights(method=method))
        assert res == {"FINISHED"}
        runs.append(secs)
    return float(np.median(runs))


def measure(bpy, core, label, mesh, rig, v, t, heads, tails, args):
    """Time Blender's ARMATURE_AUTO (once) and our operator (median of repeats) on `mesh` + `rig`,
    the core alone on (v, t, heads, tails) (best of repeats), and our BILINEAR and IDW: a row."""
    n = len(mesh.data.vertices)
    blender_s = blender_missing = None
    if not args.no_blender:
        select(bpy, mesh, rig)
        blender_s, _ = timed(lambda: bpy.ops.object.parent_set(type="ARMATURE_AUTO"))
        blender_missing = unweighted(mesh)
        unbind(mesh)
    ours_s = ours_heat(bpy, mesh, rig, args.repeats)
    ours_missing = unweighted(mesh)
    core_s, report = min((timed(lambda: core.heat_weights_report(v, t, heads, tails).report)
                          for _ in range(max(args.repeats, 1))), key=lambda r: r[0])
    fs = sum(s for k, s in report.timings.items() if k in ("factor", "solve"))
    sfs = fs + report.timings.get("symbolic", 0.0)
    extra = {"VOXEL": ours_heat(bpy, mesh, rig, args.repeats, "VOXEL")}
    extra["VOXEL missing"] = unweighted(mesh)
    for method in ("BILINEAR", "IDW"):
        unbind(mesh)
        select(bpy, mesh, rig)
        extra[method], _ = timed(lambda method=method: bpy.ops.object.miniskeleton_auto_weights(method=method))
    print(f"done {label} {n} vertices", flush=True)
    return (label, n, len(heads), blender_s, blender_missing, ours_s, ours_missing, core_s, fs, sfs,
            extra["BILINEAR"], extra["IDW"], report.timings, extra["VOXEL"], extra["VOXEL missing"])


def measure_parts(bpy, core, count, args):
    """Blender's ARMATURE_AUTO (once) and our Heat (median of repeats) on ``count`` separate
    small objects stacked along a 20-bone chain: (count, vertices, Blender s, ours s, ours with
    one core call per object s)."""
    blender_session.reset_scene()
    height = 8.0
    parts = []
    for i in range(count):
        ob, _, _ = cylinder_object(bpy, core, 6, 12, 0.8)
        ob.location = (0.05 * (i % 7), 0.0, (height - 0.8) * i / max(count - 1, 1))
        parts.append(ob)
    rig, _, _ = chain_object(bpy, core, height, 20)
    blender_s = None
    if not args.no_blender:
        select(bpy, parts, rig)
        blender_s, _ = timed(lambda: bpy.ops.object.parent_set(type="ARMATURE_AUTO"))
    # Ours as shipped (small objects to the core many per call) and one call per object, alternating.
    weights_ops = importlib.import_module(blender_session.ADDON_MODULE + ".weights.compute")
    batch = weights_ops.BATCH_VERTICES
    batched, serial = [], []
    try:
        for _ in range(max(args.repeats, 1)):
            for runs, limit in ((serial, -1), (batched, batch)):
                weights_ops.BATCH_VERTICES = limit
                runs.append(ours_heat(bpy, parts, rig, 1))
    finally:
        weights_ops.BATCH_VERTICES = batch
    print(f"done {count} parts", flush=True)
    return (count, sum(len(ob.data.vertices) for ob in parts), blender_s, float(np.median(batched)),
            float(np.median(serial)))


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="6.5k:10,26k:20,103k:40,206k:40")
    ap.add_argument("--shapes", default="issue,thin", help="cylinder proportions: issue, thin")
    ap.add_argument("--scans", default="cow.obj,horse.ply",
                    help="unrigged scans from ../shared/models with the skeleton Auto Rig finds in them")
    ap.add_argument("--scan-scales", default="1,10",
                    help="each scan at these scales (the horse is 0.2 units across as shipped)")
    ap.add_argument("--parts", default="100,400", help="figures built of this many separate small objects")
    ap.add_argument("--repeats", type=int, default=3, help="runs of our operator (median) and core (best)")
    ap.add_argument("--no-blender", action="store_true", help="skip Blender's own operator")
    args = ap.parse_args(argv)
    bpy = blender_session.start()
    import miniskeleton_core as core
    common_meshes = importlib.import_module(blender_session.ADDON_MODULE + ".common.meshes")

    rows, peaks = [], {}
    specs = [(shape, spec) for shape in args.shapes.split(",") if shape for spec in args.sizes.split(",") if spec]
    for shape, spec in specs:
        size, bones = spec.split(":")
        rings, segments = SHAPES[shape][size]
        blender_session.reset_scene()
        height = 8.0
        mesh, v, t = cylinder_object(bpy, core, rings, segments, height)
        rig, heads, tails = chain_object(bpy, core, height, int(bones))
        rows.append(measure(bpy, core, f"{shape} {rings}x{segments}", mesh, rig, v, t, heads, tails, args))
        peaks[rows[-1][0]] = core_peak_mb(core, rings, segments, height, int(bones))
    scans = [(n, float(x)) for n in args.scans.split(",") if n for x in args.scan_scales.split(",")]
    for name, scale in scans:
        path = MODELS_DIR / name
        if not path.exists():
            print(f"skipped {name}: not in {MODELS_DIR}")
            continue
        mesh, rig = scan_object(bpy, path, scale)
        v = common_meshes.mesh_world_vertices(mesh)
        t = common_meshes.mesh_triangles(mesh).astype(np.uint32)
        select(bpy, mesh, rig)
        heads = np.array([b.head_local for b in rig.data.bones], dtype=np.float32)
        tails = np.array([b.tail_local for b in rig.data.bones], dtype=np.float32)
        rows.append(measure(bpy, core, f"scan {name} x{scale:g}", mesh, rig, v, t, heads, tails, args))

    print()
    print("| shape rings x segments | vertices | bones | Blender ARMATURE_AUTO s | unweighted | ours HEAT s "
          "| unweighted | speed-up | core heat s | core peak MB | f+s s | core / (f+s) | sym+f+s s "
          "| core / (sym+f+s) | ours VOXEL s | unweighted | voxel / heat | Blender / voxel | ours BILINEAR s "
          "| ours IDW s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for shape, n, b, bs, bm, os_, om, cs, fs, sfs, bil, idw, _, vs, vm in rows:
        ratio = f"{bs / os_:.1f}x" if bs else "-"
        vratio = f"{bs / vs:.1f}x" if bs else "-"
        peak = f"{peaks[shape]:.0f}" if shape in peaks else "-"
        print(f"| {shape} | {n} | {b} | {bs if bs is None else f'{bs:.2f}'} | {bm if bm is not None else '-'} "
              f"| {os_:.3f} | {om} | {ratio} | {cs:.3f} | {peak} | {fs:.3f} | {cs / max(fs, 1e-9):.2f} "
              f"| {sfs:.3f} | {cs / max(sfs, 1e-9):.2f} "
              f"| {vs:.3f} | {vm} | {vs / os_:.2f} | {vratio} | {bil:.3f} | {idw:.3f} |")
    print()
    for shape, n, *rest in rows:
        timings = rest[-3]
        print(f"core stages, {shape}, {n}: " + ", ".join(f"{k} {s:.3f}" for k, s in timings.items()))
    parts = [measure_parts(bpy, core, int(c), args) for c in args.parts.split(",") if c]
    if parts:
        print()
        print("| separate objects | vertices | bones | Blender ARMATURE_AUTO s | ours HEAT s | speed-up "
              "| ours, a core call per object s |")
        print("|---:|---:|---:|---:|---:|---:|---:|")
        for count, n, bs, os_, one in parts:
            ratio = f"{bs / os_:.2f}x" if bs else "-"
            print(f"| {count} | {n} | 20 | {bs if bs is None else f'{bs:.2f}'} | {os_:.3f} | {ratio} | {one:.3f} |")


if __name__ == "__main__":
    main()
