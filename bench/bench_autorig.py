"""Auto Rig against the artists' skeletons of the legged models in ``../shared/models``, and its
speed on a 50k-vertex scan.

    .venv/bin/python -m bench.bench_autorig [--models Fox,CesiumMan] [--resolution 96] [--no-time] [--dump DIR]

For each model: import it, take every mesh of the character in its rest pose (world space;
the armature's modifiers off, the importer's bone-shape objects left out), hand the vertices
and triangles to ``miniskeleton_core.auto_rig`` with nothing else (no bone, no name, no facing),
and compare the skeleton it returns with the artist's **deform** bones: bones that deform the
mesh, i.e. carry weight on some vertex or have a part parented to them (glTF marks every joint
of a skin as deform, IK pole targets and helpers included; a model without weights, spot_rig,
keeps every deform bone):

- **CD-J2B** = the mean of (a) each of our joints' distance to the nearest artist bone segment
  and (b) each artist joint's distance to the nearest of our bone segments, % of the rest
  mesh's bounding-box diagonal. Joints are bone heads and tails; an artist's childless bone
  counts by its head only (a point, not a segment), since importers invent those tails; so does
  a bone whose children deform nothing.
- **CD-J2B links**: the same with the artist's joints the file itself has (bone heads: glTF
  nodes) and its bones as the links from each head to its children's heads. A glTF bone has no
  tail: the importer invents one for every bone, and for a bone with several children (Fox's
  spine) it points anywhere. Where a tail sits on a child, both measures agree.

The rigs of ``testkit/rig_corpus.py`` the tests build around an artist's skeleton (``CORPUS``:
Rigify's generated human and quadruped, the Mixamo-style humanoid through glTF and FBX) are
measured the same way, against their deform bones; the median is over the shared legged models.

The shapes of ``testkit/shapes.py`` (a lizard, a snake, a fish, a bird, a moth, a cone, a hare:
Skin-modifier bodies over small graphs) are measured against the graph they were skinned over
(its points the joints, its edges the bones), with the template each should read; they are
shown, not in the median.

The legless models (q_Dragon, q_Orc, q_Cat) have no skeleton to compare with in the same
sense (their artists' rigs are 4-13 bones): their rows give the template Auto Rig reads, why,
and the joints outside.

Then the time of ``auto_rig`` on ``horse.ply`` (48k vertices) and on the same scan with every
edge cut four times (``bmesh.ops.subdivide_edges``, 1.21M vertices), median of 3.
Writes out/bench_autorig.md. Nothing is asserted here; the Blender tests check correctness.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from testkit import MODELS_DIR, ROOT, blender_session

MODELS = ["Fox.glb", "CesiumMan.gltf", "q_Bunny.glb", "spot_rig.glb", "RobotExpressive.glb"]
LEGLESS = ["q_Dragon.glb", "q_Orc.glb", "q_Cat.glb"]
SCANS = ["horse.ply"]
# rigs of testkit/rig_corpus.py the tests build (a body around an artist's skeleton): Rigify's
# generated human and quadruped (their DEF bones), the Mixamo-style humanoid through glTF and FBX
CORPUS = ["rigify_basic_human", "rigify_basic_quadruped", "mixamo_gltf", "mixamo_fbx"]
# the test shapes of testkit/shapes.py, against the Skin graph they were built over
SHAPES = ["lizard", "snake", "fish", "bird", "moth", "cone", "hare"]


def core():
    """The core bundled in the installed extension (after ``blender_session.start()``)."""
    import miniskeleton_core

    return miniskeleton_core


def character(bpy, path):
    """(vertices (n,3), triangles (m,3), artist segments [(head, tail)], artist joints (k,3)).
    ``path``: a glTF file, the name of a rig of testkit/rig_corpus.py (``CORPUS``) or of a shape of
    testkit/shapes.py (``SHAPES``: its Skin graph is the skeleton)."""
    blender_session.reset_scene()
    if str(path) in SHAPES:
        from testkit import shapes

        ob = shapes.build(str(path))
        v, t = mesh_arrays(bpy, [ob])
        points, edges, _ = shapes.graph(str(path))
        character.labels = [f"{path}.{i}" for i in range(len(points))]
        segs = [(points[a], points[b]) for a, b in edges]
        character.links = (segs, points)
        return v, t, segs, points
    if str(path) in CORPUS:
        from testkit import rig_corpus

        rig = rig_corpus.build(str(path))
        arms, meshes = [rig.arm], list(rig.meshes)
    else:
        bpy.ops.import_scene.gltf(filepath=str(path))
        arms = [ob for ob in bpy.data.objects if ob.type == "ARMATURE"]
        shapes = {pb.custom_shape for a in arms for pb in a.pose.bones if pb.custom_shape is not None}
        meshes = [ob for ob in bpy.data.objects if ob.type == "MESH" and ob not in shapes]
    for a in arms:
        a.data.pose_position = "REST"
    verts, tris = mesh_arrays(bpy, meshes)
    weighted = {ob.parent_bone for ob in meshes if ob.parent_type == "BONE" and ob.parent_bone}
    for ob in meshes:
        names = {g.index: g.name for g in ob.vertex_groups}
        for v in ob.data.vertices:
            weighted.update(names[g.group] for g in v.groups if g.weight > 0 and g.group in names)
    segs, joints, labels = [], [], []
    links, heads = [], []  # the joints the file has (glTF nodes) and the parent -> child links
    for a in arms:
        mw = np.array(a.matrix_world)
        deform = {b.name for b in a.data.bones if b.use_deform and (not weighted or b.name in weighted)}
        for b in a.data.bones:
            if b.name not in deform:
                continue
            h = mw[:3, :3] @ np.array(b.head_local) + mw[:3, 3]
            t = mw[:3, :3] @ np.array(b.tail_local) + mw[:3, 3]
            joints.append(h)
            labels.append(b.name + ".head")
            if any(c.name in deform for c in b.children):
                joints.append(t)
                labels.append(b.name + ".tail")
                segs.append((h, t))
            else:
                segs.append((h, h))
            kids = [c for c in b.children if c.name in deform]
            for c in kids:
                links.append((h, mw[:3, :3] @ np.array(c.head_local) + mw[:3, 3]))
            if not kids:
                links.append((h, h))
            heads.append(h)
    character.labels = labels
    character.links = (links, np.array(heads))
    return verts, tris, segs, np.array(joints)


def mesh_arrays(bpy, meshes):
    """The evaluated ``meshes`` as one mesh in world space: (vertices (n, 3), triangles (m, 3))."""
    bpy.context.view_layer.update()
    deps = bpy.context.evaluated_depsgraph_get()
    verts, tris, base = [], [], 0
    for ob in meshes:
        ev = ob.evaluated_get(deps)
        me = ev.to_mesh()
        me.calc_loop_triangles()
        co = np.empty(len(me.vertices) * 3)
        me.vertices.foreach_get("co", co)
        m = np.array(ob.matrix_world)
        verts.append(co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3])
        t = np.empty(len(me.loop_triangles) * 3, dtype=np.int64)
        me.loop_triangles.foreach_get("vertices", t)
        tris.append(t.reshape(-1, 3) + base)
        base += len(me.vertices)
        ev.to_mesh_clear()
    return np.concatenate(verts), np.concatenate(tris)


def point_segment(p, a, b):
    ab = b - a
    d = float(ab @ ab)
    t = 0.0 if d == 0 else min(1.0, max(0.0, float((p - a) @ ab) / d))
    return float(np.linalg.norm(p - (a + t * ab)))


def cd_j2b(ours_segs, ours_joints, art_segs, art_joints):
    a = np.mean([min(point_segment(p, *s) for s in art_segs) for p in ours_joints])
    b = np.mean([min(point_segment(p, *s) for s in ours_segs) for p in art_joints])
    return 0.5 * (a + b), a, b


def unique_rows(x, tol=1e-7):
    out = []
    for p in x:
        if all(np.linalg.norm(p - q) > tol for q in out):
            out.append(p)
    return np.array(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--models", default="")
    ap.add_argument("--resolution", type=int, default=96)
    ap.add_argument("--no-time", action="store_true")
    ap.add_argument("--dump", default="", help="write each model's skeletons as .npz here")
    ap.add_argument("--detail", type=int, default=0, help="print the N worst joints each way")
    args = ap.parse_args(argv)
    if not MODELS_DIR.is_dir():
        print(f"[bench_autorig] {MODELS_DIR} is absent: nothing to measure")
        return 0
    bpy = blender_session.start()
    msc = core()
    picked = args.models.split(",")
    wanted = [m for m in MODELS + LEGLESS + CORPUS + SHAPES if not args.models or m.split(".")[0] in picked]
    rows, biggest = [], None
    for name in wanted:
        path = name if name in CORPUS + SHAPES else MODELS_DIR / name
        if name not in CORPUS + SHAPES and not path.exists():
            print(f"[bench_autorig] {name}: missing, skipped")
            continue
        v, t, art_segs, art_joints = character(bpy, path)
        diag = float(np.linalg.norm(v.max(0) - v.min(0)))
        if biggest is None or len(v) > len(biggest[0]):
            biggest = (v, t)
        t0 = time.perf_counter()
        try:
            rig = msc.auto_rig(v.astype(np.float32), t, resolution=args.resolution)
        except ValueError as e:
            rows.append((name, len(v), "refused", str(e), "", "", "", time.perf_counter() - t0))
            print(f"[bench_autorig] {name}: refused: {e}")
            continue
        secs = time.perf_counter() - t0
        heads, tails = rig.heads.astype(float), rig.tails.astype(float)
        print(f"[bench_autorig] {name}: {rig.template} ({rig.reason})")
        if name in LEGLESS:
            pts = np.concatenate([heads, tails]).astype(np.float32)
            outside = int((~msc.points_inside(v.astype(np.float32), t, pts)).sum())
            rows.append((name, len(v), "legless", f"{rig.template} ({rig.reason})", len(rig.names),
                         outside, len(pts), secs))
            continue
        ours_segs = list(zip(heads, tails))
        ours_joints = unique_rows(np.concatenate([heads, tails]))
        cd, a, b = cd_j2b(ours_segs, ours_joints, art_segs, art_joints)
        cd_links = cd_j2b(ours_segs, ours_joints, *character.links)[0]
        # heel.02 lies on the ground under the heel (Rigify's foot-roll marker), outside by design.
        body = unique_rows(np.concatenate([np.stack([h, tl]) for h, tl, n in zip(heads, tails, rig.names)
                                           if not n.startswith("heel")]))
        outside = int((~msc.points_inside(v.astype(np.float32), t, body.astype(np.float32))).sum())
        if args.detail:
            worst_b = sorted(((min(point_segment(p, *sg) for sg in ours_segs), lab)
                              for p, lab in zip(art_joints, character.labels)), reverse=True)[:args.detail]
            ours_lab = [f"{n}.{e}" for n in rig.names for e in ("head", "tail")]
            ours_pts = [p for h, t in zip(heads, tails) for p in (h, t)]
            worst_a = sorted(((min(point_segment(p, *sg) for sg in art_segs), lab)
                              for p, lab in zip(ours_pts, ours_lab)), reverse=True)[:args.detail]
            print("  artist joints far from ours:", ", ".join(f"{lab} {100 * d / diag:.1f}" for d, lab in worst_b))
            print("  our joints far from artist's:", ", ".join(f"{lab} {100 * d / diag:.1f}" for d, lab in worst_a))
        if args.dump:
            Path(args.dump).mkdir(parents=True, exist_ok=True)
            np.savez(Path(args.dump) / f"{Path(name).stem}.npz", heads=heads, tails=tails, names=np.array(rig.names),
                     parents=rig.parents, art=np.array([np.concatenate(s) for s in art_segs]),
                     vertices=v, forward=rig.forward, cp=rig.centre_points, ce=rig.centre_edges)
        template = rig.template
        if name in SHAPES:
            from testkit.shapes import EXPECTED

            template += " (as expected)" if EXPECTED[name][0] == rig.template else f" (expected {EXPECTED[name][0]})"
        rows.append((name, len(v), template, f"{len(rig.names)}", 100 * cd / diag, 100 * a / diag,
                     100 * b / diag, secs, outside, len(body), 100 * cd_links / diag))
        print(f"[bench_autorig] {name}: {rig.template} {len(rig.names)} bones, tail {rig.tail}, "
              f"CD-J2B {100 * cd / diag:.2f} % (ours->artist {100 * a / diag:.2f}, artist->ours "
              f"{100 * b / diag:.2f}), links {100 * cd_links / diag:.2f} %, {outside} of {len(body)} joints outside, "
              f"{secs:.2f} s")
    lines = ["| model | vertices | template | bones | CD-J2B % | ours→artist % | artist→ours % "
             "| CD-J2B links % | joints outside | time s |",
             "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
    cds, links = [], []
    for r in rows:
        if r[2] == "legless":
            lines.append(f"| {r[0]} | {r[1]} | {r[3]} | {r[4]} | | | | | {r[5]} of {r[6]} | {r[7]:.2f} |")
            continue
        if r[2] == "refused":
            lines.append(f"| {r[0]} | {r[1]} | refused: {r[3]} | | | | | | | {r[7]:.2f} |")
        else:
            if r[0] in MODELS:   # the median is the shared legged models'; the corpus rigs are shown
                cds.append(r[4])
                links.append(r[10])
            lines.append(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]:.2f} | {r[5]:.2f} | {r[6]:.2f} | "
                         f"{r[10]:.2f} | {r[8]} of {r[9]} | {r[7]:.2f} |")
    if cds:
        lines.append(f"\nCD-J2B median {statistics.median(cds):.2f} %, max {max(cds):.2f} %; links: median "
                     f"{statistics.median(links):.2f} %, max {max(links):.2f} % "
                     f"({len(cds)} shared legged models; resolution {args.resolution})")
    if not args.no_time:
        lines.append("\n| speed input | vertices | auto_rig s (median of 3) | CPU s |\n|---|---:|---:|---:|")
        for scan in SCANS:
            path = MODELS_DIR / scan
            if path.exists():
                blender_session.reset_scene()
                bpy.ops.wm.ply_import(filepath=str(path))
                ob = [o for o in bpy.data.objects if o.type == "MESH"][0]
                me = ob.data
                me.calc_loop_triangles()
                co = np.empty(len(me.vertices) * 3, dtype=np.float32)
                me.vertices.foreach_get("co", co)
                tri = np.empty(len(me.loop_triangles) * 3, dtype=np.int64)
                me.loop_triangles.foreach_get("vertices", tri)
                lines.append(timing(msc, scan, co.reshape(-1, 3), tri.reshape(-1, 3), args.resolution))
                v, t = subdivided(me, 4)
                lines.append(timing(msc, f"{scan}, edges cut 4 times", v, t, args.resolution))
    text = "\n".join(lines)
    print(text)
    blender_session.write_report(ROOT / "out" / "bench_autorig.md", text)
    return 0


def subdivided(me, cuts):
    """``me`` with every edge cut ``cuts`` times (``bmesh.ops.subdivide_edges``, grid fill):
    (vertices (n, 3) float32, triangles (m, 3) int64)."""
    import bmesh

    bm = bmesh.new()
    bm.from_mesh(me)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=cuts, use_grid_fill=True)
    bmesh.ops.triangulate(bm, faces=bm.faces[:])
    bm.verts.index_update()
    v = np.array([p.co[:] for p in bm.verts], np.float32)
    t = np.array([[p.index for p in f.verts] for f in bm.faces], np.int64)
    bm.free()
    return v, t


def timing(msc, label, v, t, resolution):
    times, cpu = [], []
    for _ in range(3):
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            msc.auto_rig(v, t, resolution=resolution)
        except ValueError as e:
            return f"| {label} | {len(v)} | refused: {e} | |"
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return f"| {label} | {len(v)} | {statistics.median(times):.3f} | {statistics.median(cpu):.3f} |"


if __name__ == "__main__":
    sys.exit(main())
