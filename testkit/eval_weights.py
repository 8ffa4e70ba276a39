"""Quality: MiniSkeleton's Auto Weights (Heat and Geodesic Voxel) and Blender's own
``parent_set(type='ARMATURE_AUTO')`` against the artist's weights of real rigged models, in one
process; and Transfer Weights onto the other skinned meshes of a model and onto a shell around it.

    .venv/bin/python -m testkit.eval_weights [--models Fox,CesiumMan] [--no-blender] [--detail 5] [--symmetry X]
        [--clips 3] [--frames 20] [--actions ThumbsUp,Wave] [--bone-extent AUTO|TAIL|CHILDREN]
        [--resolution 64] [--falloff 0.002] [--no-transfer]

Models are read from ``../shared/models/`` relative to the project root (never copied into the
repository); a missing folder or file is skipped with a message. For each model the glTF is
imported, the artist's weights of every *skinned* mesh (a mesh with an Armature modifier) are
kept, the bone-named vertex groups are removed, and the meshes are rebound with our operator
and, on a fresh import, with Blender's (``keep_transform=True``: without it Blender moves meshes
whose armature has a non-identity world matrix, e.g. RobotExpressive's scale 100). Meshes
parented rigidly to bones are not skinned: they are left out, and named in the output.

Per model (all skinned meshes together, every split vertex counted):
- unweighted: vertices with no deform-bone group of weight > 0;
- L1: mean over vertices of sum_b |w_artist - w_auto|, each row normalized to sum 1
  (an unweighted row is all zero, so it costs 1);
- precision / recall of each vertex's influence set {b : w_b > 1e-3} (normalized weights),
  averaged over vertices (an empty set against a non-empty one scores 0; two empty sets 1);
- deform %: mean distance between the artist-weighted and the auto-weighted mesh, deformed by
  linear blend skinning (numpy) with Blender's own bone matrices, over the model's animation
  (up to --frames frames of each of the first --clips animations, in the file's order; seeded
  random poses if it has none), as % of the bounding-box diagonal of the rest mesh. ``--clips 1``
  (the file's first animation) reproduces the issue's figures for Blender: Fox 0.90 (Survey),
  CesiumMan 0.15, q_Bunny 2.66 (Death) here, against the issue's 0.89 / 0.15 / 2.65. Both sides
  use normalized weights; an unweighted vertex stays at rest, as in Blender's Armature modifier. Before it is used, the
  numpy skinning is checked against Blender's evaluated mesh for the artist weights (and ours)
  on one frame: the max difference is printed.
- time s: the whole operator call.

Sides: "heat" (our Heat), "voxel" (our Geodesic Voxel, ``--resolution``, ``--falloff``),
"Blender". Transfer (``transfer_rows``), two tables:
- the models with more than one skinned mesh: the largest keeps the artist's weights, the
  others are stripped and dressed from it by Transfer Weights; deform % of those meshes, beside
  binding them directly (heat, voxel, as in the first table), and the paper's transfer alone
  (``core.transfer_weights`` without the operator's prop and nowhere rules);
- every model's skinned meshes copied as a shell pushed out along the normals by 1 % of the
  diagonal (a tight garment whose truth is the artist's weights of the vertices it came from):
  Transfer Weights from the artist-weighted model, and the shell bound directly with Heat and
  with Geodesic Voxel (alone, its model hidden).

Writes the markdown table (and the per-model details) to stdout and to out/eval_weights.md.
Nothing is asserted: tests check correctness, this measures quality.
"""

from __future__ import annotations

import argparse
import importlib
import time
from pathlib import Path

import numpy as np

from testkit import MODELS_DIR, ROOT, blender_session
from testkit.measures import evaluated_world_vertices, world_vertices

MODELS = ["Fox.glb", "CesiumMan.gltf", "RiggedSimple.gltf", "RobotExpressive.glb", "q_Bunny.glb",
          "q_Orc.glb", "q_Cat.glb", "q_Dragon.glb"]
INFLUENCE = 1e-3


# ---------------------------------------------------------------------------- scene

def import_model(bpy, path):
    """Fresh scene with the model; returns (armature, skinned meshes, rigid bone-parented meshes)."""
    blender_session.reset_scene()
    bpy.ops.import_scene.gltf(filepath=str(path))
    skinned, rigid = [], []
    arms = set()
    for ob in bpy.data.objects:
        if ob.type != "MESH":
            continue
        mods = [m for m in ob.modifiers if m.type == "ARMATURE" and m.object is not None]
        if mods:
            skinned.append(ob)
            arms.add(mods[0].object)
        elif ob.parent is not None and ob.parent.type == "ARMATURE":
            rigid.append(ob)  # bone-parented parts (the importer's bone-shape icosphere has no parent)
    if len(arms) != 1:
        return None, skinned, rigid
    skinned.sort(key=lambda ob: ob.name)
    return arms.pop(), skinned, sorted(rigid, key=lambda ob: ob.name)


def deform_bones(arm):
    return [b.name for b in arm.data.bones if b.use_deform]


def read_weights(ob, bones):
    """Deform-bone weights of ``ob`` as a dense (n, len(bones)) float64 matrix (raw, not normalized)."""
    col = {ob.vertex_groups[name].index: j for j, name in enumerate(bones) if name in ob.vertex_groups}
    w = np.zeros((len(ob.data.vertices), len(bones)))
    for v in ob.data.vertices:
        for g in v.groups:
            j = col.get(g.group)
            if j is not None:
                w[v.index, j] = g.weight
    return w


def strip(meshes, bones):
    """Remove the bone-named vertex groups only (modifier, parent and other groups stay)."""
    for ob in meshes:
        for name in bones:
            g = ob.vertex_groups.get(name)
            if g is not None:
                ob.vertex_groups.remove(g)


SYMMETRY = {"value": "NONE"}  # our operator's Symmetry option (--symmetry)
BONE_EXTENT = {"value": "AUTO"}  # our operator's Bone Extent option (--bone-extent)
VOXEL = {"resolution": 64, "voxel_falloff": 0.002}  # our Geodesic Voxel's options (--resolution, --falloff)
# The sides of a rebinding: our methods and Blender's.
SIDES = {"ours": "HEAT", "voxel": "VOXEL", "Blender": None}


def bind(bpy, arm, meshes, method):
    """Ctrl+P-style selection, then our operator with ``method`` ("HEAT", "VOXEL") or Blender's
    (None); returns (seconds, result)."""
    for ob in bpy.context.view_layer.objects:
        ob.select_set(ob in meshes or ob == arm)
    bpy.context.view_layer.objects.active = arm
    arm.data.pose_position = "REST"  # bind in rest pose whatever frame the import left
    bpy.context.view_layer.update()
    t = time.perf_counter()
    if method is not None:
        extra = VOXEL if method == "VOXEL" else {}
        res = bpy.ops.object.miniskeleton_auto_weights(method=method, symmetry=SYMMETRY["value"],
                                                        bone_extent=BONE_EXTENT["value"], **extra)
    else:
        res = bpy.ops.object.parent_set(type="ARMATURE_AUTO", keep_transform=True)
    secs = time.perf_counter() - t
    arm.data.pose_position = "POSE"
    bpy.context.view_layer.update()
    return secs, res


# ---------------------------------------------------------------------------- poses

def gltf_animation_names(path):
    """Animation names in the file's own order (bpy.data sorts actions by name); [] if unreadable."""
    import json
    import struct

    try:
        data = Path(path).read_bytes()
        if data[:4] == b"glTF":
            length = struct.unpack("<I", data[12:16])[0]
            doc = json.loads(data[20:20 + length])
        else:
            doc = json.loads(data)
        return [a.get("name", "") for a in doc.get("animations", [])]
    except (OSError, ValueError, struct.error):
        return []


def armature_actions(bpy, arm, order=()):
    """Actions that animate an object (the armature): those named in ``order`` first, in that
    order (the glTF file's animation order), then the rest in bpy.data order."""
    out = []
    for act in bpy.data.actions:
        slots = getattr(act, "slots", None)
        if slots is not None:
            if any(s.target_id_type == "OBJECT" for s in slots):
                out.append(act)
        elif getattr(act, "id_root", "OBJECT") == "OBJECT":
            out.append(act)
    rank = {name: i for i, name in enumerate(order)}
    return sorted(out, key=lambda a: rank.get(a.name, len(rank)))


def assign_action(arm, act):
    ad = arm.animation_data or arm.animation_data_create()
    ad.action = act
    if act is not None and hasattr(ad, "action_slot") and getattr(act, "slots", None):
        slots = [s for s in act.slots if s.target_id_type == "OBJECT"]
        pick = [s for s in slots if s.identifier == "OB" + arm.name] or slots
        if pick and ad.action_slot != pick[0]:
            ad.action_slot = pick[0]


def reset_pose(arm, basis):
    from mathutils import Matrix

    arm.matrix_basis = basis
    for pb in arm.pose.bones:
        pb.matrix_basis = Matrix.Identity(4)


def snapshot(arm, bones, meshes):
    """Bone matrices world rest -> world posed (b, 4, 4) and the meshes' world matrices."""
    a = np.array(arm.matrix_world)
    ainv = np.linalg.inv(a)
    mats = np.stack([a @ np.array(arm.pose.bones[n].matrix) @ np.linalg.inv(np.array(arm.data.bones[n].matrix_local))
                     @ ainv for n in bones])
    return mats, [np.array(ob.matrix_world) for ob in meshes]


def sample_poses(bpy, arm, basis, bones, meshes, clips, frames, names=None, seed=0, order=()):
    """[(label, frame, mats, mesh world matrices, replay)] over the first ``clips`` actions in the file's
    order ``order`` (or the actions called ``names``), else seeded random poses."""
    scene = bpy.context.scene
    ad = arm.animation_data or arm.animation_data_create()
    for track in ad.nla_tracks:  # the importer parks every clip on a (muted) NLA track
        track.mute = True
    out = []
    acts = armature_actions(bpy, arm, order)
    if names:
        missing = [n for n in names if n not in {a.name for a in acts}]
        if missing:
            print(f"[eval] actions not in this model, ignored: {', '.join(missing)}")
        acts = [a for a in acts if a.name in names] or acts
    acts = acts[:clips]
    for act in acts:
        reset_pose(arm, basis)
        assign_action(arm, act)
        lo, hi = act.frame_range
        for f in np.unique(np.linspace(lo, hi, frames)):
            scene.frame_set(int(np.floor(f)), subframe=float(f - np.floor(f)))
            out.append((act.name, float(f), *snapshot(arm, bones, meshes), None))
    if not acts:
        from mathutils import Matrix, Vector

        assign_action(arm, None)
        rng = np.random.default_rng(seed)
        for p in range(8):
            reset_pose(arm, basis)
            for pb in arm.pose.bones:
                axis = Vector(rng.normal(size=3)).normalized()
                pb.matrix_basis = Matrix.Rotation(float(rng.uniform(-0.6, 0.6)), 4, axis)
            bpy.context.view_layer.update()
            replay = {pb.name: pb.matrix_basis.copy() for pb in arm.pose.bones}
            out.append(("random", float(p), *snapshot(arm, bones, meshes), replay))
    return out


def check_pose(bpy, arm, basis, pose):
    """Put the armature back in ``pose`` (label, frame) so the depsgraph matches the snapshot."""
    label, frame, replay = pose[0], pose[1], pose[4]
    reset_pose(arm, basis)
    if replay is not None:
        assign_action(arm, None)
        for pb in arm.pose.bones:
            pb.matrix_basis = replay[pb.name]
        bpy.context.view_layer.update()
        return
    assign_action(arm, bpy.data.actions[label])
    bpy.context.scene.frame_set(int(np.floor(frame)), subframe=float(frame - np.floor(frame)))


# ---------------------------------------------------------------------------- metrics

def normalized(w):
    w = np.where(w > 0, w, 0.0)
    s = w.sum(axis=1, keepdims=True)
    return np.divide(w, s, out=np.zeros_like(w), where=s > 0)


def lbs(rest_local, mesh_mw, mats, w):
    """World positions of one mesh: rest_local (n, 3) object coordinates, w (n, b) normalized."""
    x = rest_local @ mesh_mw[:3, :3].T + mesh_mw[:3, 3]
    rot = np.einsum("bij,nj->bni", mats[:, :3, :3], x)
    out = np.einsum("nb,bni->ni", w, rot) + w @ mats[:, :3, 3]
    return out + (1.0 - w.sum(axis=1))[:, None] * x  # unweighted rows stay at rest


def deformed(locals_, poses, w_parts):
    """(frames, n_total, 3) for per-mesh normalized weights w_parts."""
    return np.stack([np.concatenate([lbs(x, mw, mats, w) for x, mw, w in zip(locals_, mws, w_parts)])
                     for _, _, mats, mws, _ in poses])


def influence_scores(a, b):
    """Per-vertex precision and recall of b's influence set against a's (both normalized)."""
    sa, sb = a > INFLUENCE, b > INFLUENCE
    hit = (sa & sb).sum(axis=1)
    na, nb = sa.sum(axis=1), sb.sum(axis=1)
    both_empty = (na == 0) & (nb == 0)
    prec = np.where(nb > 0, hit / np.maximum(nb, 1), np.where(both_empty, 1.0, 0.0))
    rec = np.where(na > 0, hit / np.maximum(na, 1), 1.0)
    return prec, rec


def lbs_check(bpy, arm, basis, bones, meshes, poses, diag):
    """Max |numpy LBS - Blender's Armature modifier| on one frame, as % of diag; None if not checkable."""
    pose = poses[len(poses) // 2]
    check_pose(bpy, arm, basis, pose)
    mats, mws = snapshot(arm, bones, meshes)
    worst, skipped = 0.0, []
    for ob, mw in zip(meshes, mws):
        others = [m.type for m in ob.modifiers if m.type != "ARMATURE"]
        arms = [m for m in ob.modifiers if m.type == "ARMATURE"]
        if ob.data.shape_keys is not None or others or len(arms) != 1:
            skipped.append(ob.name)
            continue
        ours = lbs(np.array([v.co for v in ob.data.vertices]), mw, mats, normalized(read_weights(ob, bones)))
        theirs = evaluated_world_vertices(ob)
        if theirs.shape != ours.shape:
            skipped.append(ob.name)
            continue
        worst = max(worst, float(np.abs(ours - theirs).max()))
    note = f"{pose[0]} frame {pose[1]:.1f}" + (f"; not checked: {', '.join(skipped)}" if skipped else "")
    return 100.0 * worst / diag, note


# ---------------------------------------------------------------------------- one model

class Side:
    """One rebinding (ours or Blender's): weights per mesh and the operator's time."""

    def __init__(self, name, secs, result, parts, check, moved):
        self.name, self.secs, self.result, self.parts, self.check, self.moved = name, secs, result, parts, check, moved
        self.w = np.concatenate(parts)


def rebind(bpy, path, side, args, poses=None):
    """Fresh import, artist weights kept, groups stripped, rebound; poses are sampled when not given."""
    arm, meshes, rigid = import_model(bpy, path)
    if arm is None or not meshes:
        return dict(meshes=[], reason=f"{len(meshes)} skinned meshes, armatures "
                    f"{'not exactly one' if meshes else 'none'}"), None
    bones = deform_bones(arm)
    basis = arm.matrix_basis.copy()
    artist = [read_weights(ob, bones) for ob in meshes]
    locals_ = [np.array([v.co for v in ob.data.vertices]) for ob in meshes]
    before = np.concatenate([world_vertices(ob) for ob in meshes])
    diag = float(np.linalg.norm(before.max(axis=0) - before.min(axis=0)))
    ctx = dict(arm=arm, meshes=meshes, rigid=rigid, mesh_names=[ob.name for ob in meshes],
               rigid_names=[ob.name for ob in rigid], bones=bones, artist=artist, locals=locals_, diag=diag)
    if poses is None:
        ctx["poses"] = sample_poses(bpy, arm, basis, bones, meshes, args.clips, args.frames,
                                    [a for a in args.actions.split(",") if a], order=gltf_animation_names(path))
        ctx["artist_check"] = lbs_check(bpy, arm, basis, bones, meshes, ctx["poses"], diag)
        reset_pose(arm, basis)
        assign_action(arm, None)
        bpy.context.scene.frame_set(0)
    strip(meshes, bones)
    secs, res = bind(bpy, arm, meshes, SIDES[side])
    after = np.concatenate([world_vertices(ob) for ob in meshes])
    moved = 100.0 * float(np.abs(after - before).max()) / diag
    parts = [read_weights(ob, bones) for ob in meshes]
    check = lbs_check(bpy, arm, basis, bones, meshes, poses or ctx["poses"], diag)
    return ctx, Side(side, secs, res, parts, check, moved)


def dominant(w):
    return np.where(w.sum(axis=1) > 0, w.argmax(axis=1), -1)


def evaluate(model, path, bpy, args):
    t0 = time.perf_counter()
    ctx, ours = rebind(bpy, path, "ours", args)
    if not ctx["meshes"]:
        print(f"[eval] {model}: nothing to compare ({ctx['reason']}), skipped", flush=True)
        return None
    sides = [ours]
    for name in [s for s in SIDES if s != "ours" and not (s == "Blender" and args.no_blender)]:
        ctx2, other = rebind(bpy, path, name, args, poses=ctx["poses"])
        same = all(np.allclose(a, b) for a, b in zip(ctx["locals"], ctx2["locals"]))
        if not same or len(ctx2["meshes"]) != len(ctx["meshes"]):
            raise RuntimeError(f"{model}: another import differs from the first")
        sides.append(other)
    poses, bones = ctx["poses"], ctx["bones"]
    art_parts = [normalized(w) for w in ctx["artist"]]
    art = np.concatenate(art_parts)
    x_art = deformed(ctx["locals"], poses, art_parts)
    diag = ctx["diag"]
    row = dict(model=model, verts=len(art), bones=len(bones), meshes=ctx["mesh_names"],
               rigid=ctx["rigid_names"], frames=len(poses),
               clips=sorted({p[0] for p in poses}, key=[p[0] for p in poses].index),
               artist_check=ctx["artist_check"], raw_sum=ctx["artist"], sides={})
    for side in sides:
        w_parts = [normalized(w) for w in side.parts]
        w = np.concatenate(w_parts)
        x = deformed(ctx["locals"], poses, w_parts)
        dist = np.linalg.norm(x - x_art, axis=2)  # (frames, n)
        prec, rec = influence_scores(art, w)
        row["sides"][side.name] = dict(
            unweighted=int((side.w.max(axis=1, initial=0) <= 0).sum()),
            l1=float(np.abs(art - w).sum(axis=1).mean()), l1_rows=np.abs(art - w).sum(axis=1),
            precision=float(prec.mean()), recall=float(rec.mean()),
            deform=100.0 * float(dist.mean()) / diag, per_vertex=100.0 * dist.mean(axis=0) / diag,
            max_deform=100.0 * float(dist.max()) / diag,
            per_clip={c: 100.0 * float(dist[[p[0] == c for p in poses]].mean()) / diag for c in row["clips"]},
            secs=side.secs, result=side.result,
            check=side.check, moved=side.moved, w=w, parts=side.parts)
    row["art"] = art
    row["poses"], row["diag"] = poses, diag
    row["bone_names"] = bones
    row["mesh_sizes"] = [len(x) for x in ctx["locals"]]
    row["total_s"] = time.perf_counter() - t0
    return row


# ---------------------------------------------------------------------------- report

def pair(row, key, fmt):
    """The values of every side of ``row`` for ``key``, "heat / voxel / Blender"."""
    return " / ".join(fmt(row["sides"][s][key]) if s in row["sides"] else "-" for s in SIDES)


def table(rows):
    names = "/".join("heat" if s == "ours" else s for s in SIDES)
    lines = [f"| model | verts | bones | unweighted {names} | L1 {names} | precision {names} "
             f"| recall {names} | deform % {names} | voxel / heat | voxel / Blender | time s {names} |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        d = {s: r["sides"][s]["deform"] for s in r["sides"]}

        def ratio(a, b, d=d):
            return f"{d[a] / d[b]:.2f}" if a in d and b in d and d[b] > 0 else "-"
        lines.append(
            f"| {r['model']} | {r['verts']} | {r['bones']} | {pair(r, 'unweighted', str)} "
            f"| {pair(r, 'l1', '{:.3f}'.format)} | {pair(r, 'precision', '{:.3f}'.format)} "
            f"| {pair(r, 'recall', '{:.3f}'.format)} | {pair(r, 'deform', '{:.3f}'.format)} "
            f"| {ratio('voxel', 'ours')} | {ratio('voxel', 'Blender')} | {pair(r, 'secs', '{:.3f}'.format)} |")
    return lines


def details(r, top):
    """Where the auto weights differ: per mesh, and grouped by the artist's dominant bone."""
    names = r["bone_names"]
    sides = [s for s in SIDES if s in r["sides"]]
    out = [f"### {r['model']}", ""]
    raw = np.concatenate(r["raw_sum"]).sum(axis=1)
    out.append(f"- skinned meshes: {', '.join(f'{m} ({n} v)' for m, n in zip(r['meshes'], r['mesh_sizes']))}"
               f"; artist rows not summing to 1 (|sum-1| > 1e-3): {int((np.abs(raw - 1) > 1e-3).sum())}")
    if r["rigid"]:
        out.append(f"- not skinned (rigid, bone-parented), excluded: {', '.join(r['rigid'])}")
    out.append(f"- poses: {r['frames']} frames of {', '.join(r['clips'])}")
    out.append("- deform % per clip: " + "; ".join(
        f"{c} " + " / ".join(f"{r['sides'][s]['per_clip'][c]:.2f}" for s in sides) for c in r["clips"])
        + f" ({'/'.join(sides)})")
    chk, note = r["artist_check"]
    out.append(f"- numpy LBS vs Blender's Armature modifier, artist weights: max "
               f"{'-' if chk is None else f'{chk:.2e}'} % of diag ({note})")
    for s in sides:
        d = r["sides"][s]
        c, n = d["check"] or (None, "")
        out.append(f"- {s}: operator {d['result']}, {d['secs']:.2f} s; LBS check with its weights max "
                   f"{'-' if c is None else f'{c:.2e}'} %; rest mesh moved by binding {d['moved']:.2e} %; "
                   f"max deform {d['max_deform']:.2f} %")
    if len(r["meshes"]) > 1:
        starts = np.cumsum([0] + r["mesh_sizes"])
        for m, a, b in zip(r["meshes"], starts[:-1], starts[1:]):
            out.append(f"- mesh {m}: deform % " + " / ".join(
                f"{s} {r['sides'][s]['per_vertex'][a:b].mean():.2f}" for s in sides)
                + ", unweighted " + " / ".join(
                f"{s} {int((r['sides'][s]['w'][a:b].sum(axis=1) == 0).sum())}" for s in sides))
    unused = r["art"].sum(axis=0) == 0  # deform bones the artist never weights (e.g. glTF root joints)
    if unused.any():
        for s in sides:
            w = r["sides"][s]["w"]
            mass = w[:, unused].sum(axis=0)
            most = np.argsort(-mass)[:3]
            ids = np.nonzero(unused)[0]
            out.append(f"- {s}: weight on the {int(unused.sum())} bones the artist never uses: "
                       f"{100 * mass.sum() / max(w.sum(), 1e-12):.1f} % of all weight"
                       + (" (most: " + ", ".join(f"{names[ids[i]]} {100 * mass[i] / max(w.sum(), 1e-12):.1f} %"
                                                 for i in most if mass[i] > 0) + ")" if mass.sum() > 0 else ""))
    dom = dominant(r["art"])
    ours = r["sides"]["ours"]
    groups = []
    for b in np.unique(dom):
        sel = dom == b
        groups.append((float(ours["per_vertex"][sel].mean()), b, int(sel.sum()), sel))
    groups.sort(key=lambda g: -g[0])
    out += ["", f"Worst {top} artist-dominant bones for ours (mean deform % of their vertices; L1):", "",
            "| artist bone | verts | " + " | ".join(f"deform % {s} | L1 {s} | unweighted {s}" for s in sides) + " |",
            "|---|---:|" + "---:|---:|---:|" * len(sides)]
    for _, b, n, sel in groups[:top]:
        cells = []
        for s in sides:
            d = r["sides"][s]
            cells.append(f"{d['per_vertex'][sel].mean():.2f} | {d['l1_rows'][sel].mean():.2f} "
                         f"| {int((d['w'][sel].sum(axis=1) == 0).sum())}")
        out.append(f"| {names[b] if b >= 0 else '(none)'} | {n} | " + " | ".join(cells) + " |")
    # which bone took the vertices the artist gave to another one
    mis = {}
    od = dominant(ours["w"])
    for a, o, e in zip(dom, od, ours["per_vertex"]):
        if a != o:
            k = (a, o)
            cnt, tot = mis.get(k, (0, 0.0))
            mis[k] = (cnt + 1, tot + e)
    worst = sorted(mis.items(), key=lambda kv: -kv[1][1])[:top]
    if worst:
        out += ["", f"Ours: dominant bone differs from the artist's on {int((dom != od).sum())} vertices; "
                "largest (by summed deform %):", ""]
        for (a, o), (cnt, tot) in worst:
            an = names[a] if a >= 0 else "(none)"
            on = names[o] if o >= 0 else "(unweighted)"
            out.append(f"- artist {an} -> ours {on}: {cnt} vertices, mean deform {tot / cnt:.2f} %")
    out.append("")
    return out


# ---------------------------------------------------------------------------- transfer

def _deform_of(ctx, parts, which):
    """Deform % of the meshes ``which`` (indices into ctx["meshes"]) with weights ``parts``
    (per mesh, dense (n, b)), over ctx's poses, against the artist's."""
    art_parts = [normalized(w) for w in ctx["artist"]]
    x_art = deformed(ctx["locals"], ctx["poses"], art_parts)
    x = deformed(ctx["locals"], ctx["poses"], [normalized(w) for w in parts])
    dist = np.linalg.norm(x - x_art, axis=2)
    starts = np.cumsum([0] + [len(v) for v in ctx["locals"]])
    cols = np.concatenate([np.arange(starts[m], starts[m + 1]) for m in which])
    return 100.0 * float(dist[:, cols].mean()) / ctx["diag"]


def _transfer_op(bpy, body, garments):
    for ob in bpy.context.view_layer.objects:
        ob.select_set(ob in garments or ob == body)
    bpy.context.view_layer.objects.active = body
    t = time.perf_counter()
    res = bpy.ops.object.miniskeleton_transfer_weights()
    return time.perf_counter() - t, res


def _rows_of(weights):
    """Dense (n, b) weights as top-8 rows for core.transfer_weights."""
    order = np.argsort(-weights, axis=1)[:, :8]
    w = np.take_along_axis(weights, order, axis=1).astype(np.float32)
    return np.where(w > 0, order, -1).astype(np.int32), w


def transfer_rows(model, path, bpy, args, row):
    """Transfer Weights onto the other skinned meshes of a model (see the module doc): one row
    per dressed mesh, or [] for a model with one skinned mesh."""
    import miniskeleton_core as core

    arm, meshes, _ = import_model(bpy, path)
    if arm is None or len(meshes) < 2:
        return []
    bones = deform_bones(arm)
    body = max(meshes, key=lambda ob: len(ob.data.vertices))
    garments = [ob for ob in meshes if ob is not body]
    artist = [read_weights(ob, bones) for ob in meshes]
    ctx = dict(artist=artist, locals=[np.array([v.co for v in ob.data.vertices]) for ob in meshes],
               poses=row["poses"], diag=row["diag"])
    # The paper's transfer alone, in world space (the core directly).
    tri = importlib.import_module(blender_session.ADDON_MODULE + ".common.meshes")
    bv, bt = world_vertices(body), tri.mesh_triangles(body)
    alone = [w.copy() for w in artist]
    for g in garments:
        out = core.transfer_weights(bv, bt, *_rows_of(normalized(artist[meshes.index(body)])),
                                    world_vertices(g), tri.mesh_triangles(g))
        i, w = out.indices, out.weights
        dense = np.zeros_like(artist[meshes.index(g)])
        for k in range(i.shape[1]):
            ok = i[:, k] >= 0
            dense[np.nonzero(ok)[0], i[ok, k]] += w[ok, k]
        alone[meshes.index(g)] = dense
    strip(garments, bones)
    arm.data.pose_position = "REST"
    bpy.context.view_layer.update()
    secs, res = _transfer_op(bpy, body, garments)
    arm.data.pose_position = "POSE"
    bpy.context.view_layer.update()
    parts = [read_weights(ob, bones) for ob in meshes]
    out = []
    for g in garments:
        m = meshes.index(g)
        direct = {s: _deform_of(ctx, [row["sides"][s]["parts"][k] if k == m else artist[k] for k in range(len(meshes))],
                                [m]) for s in ("ours", "voxel") if s in row["sides"]}
        out.append(dict(model=model, mesh=g.name, body=body.name, verts=len(g.data.vertices), result=res, secs=secs,
                        transfer=_deform_of(ctx, [parts[k] if k == m else artist[k] for k in range(len(meshes))], [m]),
                        alone=_deform_of(ctx, [alone[k] if k == m else artist[k] for k in range(len(meshes))], [m]),
                        unweighted=int((parts[m].max(axis=1, initial=0) <= 0).sum()), **direct))
    return out


def shell_rows(model, path, bpy, args, row):
    """A shell around the model's skinned meshes (see the module doc): Transfer Weights from the
    artist-weighted model, and the shell bound directly with Heat and with Geodesic Voxel."""
    arm, meshes, _ = import_model(bpy, path)
    if arm is None or not meshes:
        return None
    bones = deform_bones(arm)
    artist = [read_weights(ob, bones) for ob in meshes]
    shells = []
    for ob in meshes:
        sh = ob.copy()
        sh.data = ob.data.copy()
        sh.name = ob.name + ".shell"
        sh.vertex_groups.clear()
        bpy.context.scene.collection.objects.link(sh)
        n = np.empty(len(sh.data.vertices) * 3)
        sh.data.vertices.foreach_get("normal", n)
        co = np.empty(len(sh.data.vertices) * 3)
        sh.data.vertices.foreach_get("co", co)
        m3 = np.array(sh.matrix_world)[:3, :3]
        local = 0.01 * row["diag"] / max(float(np.cbrt(abs(np.linalg.det(m3)))), 1e-12)
        sh.data.vertices.foreach_set("co", co + local * n)
        sh.data.update()
        shells.append(sh)
    ctx = dict(artist=artist, locals=[np.array([v.co for v in sh.data.vertices]) for sh in shells],
               poses=row["poses"], diag=row["diag"])
    which = list(range(len(shells)))
    out = dict(model=model, verts=sum(len(sh.data.vertices) for sh in shells))
    arm.data.pose_position = "REST"
    bpy.context.view_layer.update()
    # Transfer from the largest artist-weighted mesh (a body dressed from one mesh).
    body = max(meshes, key=lambda ob: len(ob.data.vertices))
    out["secs"], out["result"] = _transfer_op(bpy, body, shells)
    out["transfer"] = _deform_of(ctx, [read_weights(sh, bones) for sh in shells], which)
    for side, method in (("ours", "HEAT"), ("voxel", "VOXEL")):
        for ob in meshes:
            ob.hide_set(True)
        strip(shells, bones)
        bind(bpy, arm, shells, method)
        for ob in meshes:
            ob.hide_set(False)
        out[side] = _deform_of(ctx, [read_weights(sh, bones) for sh in shells], which)
    arm.data.pose_position = "POSE"
    return out


def transfer_tables(rows, shells):
    lines = ["| model | dressed mesh (from body) | verts | Transfer Weights % | paper's transfer alone % "
             "| direct heat % | direct voxel % | unweighted | time s |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['model']} | {r['mesh']} ({r['body']}) | {r['verts']} | {r['transfer']:.3f} | "
                     f"{r['alone']:.3f} | {r.get('ours', float('nan')):.3f} | {r.get('voxel', float('nan')):.3f} "
                     f"| {r['unweighted']} | {r['secs']:.3f} |")
    lines += ["", "| model (shell 1 % out) | verts | Transfer Weights % | direct heat % | direct voxel % | time s |",
              "|---|---:|---:|---:|---:|---:|"]
    for r in shells:
        lines.append(f"| {r['model']} | {r['verts']} | {r['transfer']:.3f} | {r['ours']:.3f} | {r['voxel']:.3f} "
                     f"| {r['secs']:.3f} |")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--models", default=",".join(Path(m).stem for m in MODELS),
                    help="comma-separated model names (file stems in ../shared/models)")
    ap.add_argument("--models-dir", default=str(MODELS_DIR))
    ap.add_argument("--no-blender", action="store_true", help="skip Blender's own operator")
    ap.add_argument("--symmetry", default="NONE", choices=["NONE", "X"],
                    help="our operator's Symmetry (the armature's x = 0 mirror plane, bones paired by name)")
    ap.add_argument("--bone-extent", default="AUTO", choices=["AUTO", "TAIL", "CHILDREN"],
                    help="our operator's Bone Extent (AUTO: imported rigs reach their children)")
    ap.add_argument("--clips", type=int, default=3,
                    help="first N actions of the model (bpy.data order); 0: 8 seeded random poses")
    ap.add_argument("--actions", default="",
                    help="comma-separated action names to use instead of the first --clips ones "
                         "(e.g. RobotExpressive's fingers only move in ThumbsUp,Wave)")
    ap.add_argument("--frames", type=int, default=20, help="frames sampled per action")
    ap.add_argument("--detail", type=int, default=5, help="rows in the per-model detail lists")
    ap.add_argument("--resolution", type=int, default=VOXEL["resolution"], help="our Geodesic Voxel's Resolution")
    ap.add_argument("--falloff", type=float, default=VOXEL["voxel_falloff"], help="our Geodesic Voxel's Falloff")
    ap.add_argument("--no-transfer", action="store_true", help="skip the Transfer Weights tables")
    ap.add_argument("--out", default=str(ROOT / "out" / "eval_weights.md"))
    args = ap.parse_args(argv)
    SYMMETRY["value"] = args.symmetry
    BONE_EXTENT["value"] = args.bone_extent
    VOXEL.update(resolution=args.resolution, voxel_falloff=args.falloff)

    folder = Path(args.models_dir)
    if not folder.is_dir():
        print(f"[eval] no models folder {folder}: nothing to evaluate")
        return
    files = {Path(m).stem: m for m in MODELS}
    wanted = []
    for name in args.models.split(","):
        name = name.strip()
        fname = files.get(name, name)
        path = folder / fname
        if not path.exists():
            hits = sorted(folder.glob(name + ".gl*"))
            path = hits[0] if hits else path
        if not path.exists():
            print(f"[eval] {name}: {path} not found, skipped")
            continue
        wanted.append((Path(path).stem, path))
    if not wanted:
        print("[eval] no models to evaluate")
        return

    bpy = blender_session.start()
    rows, dressed, shells = [], [], []
    for model, path in wanted:
        print(f"[eval] {model} ...", flush=True)
        row = evaluate(model, path, bpy, args)
        if row is None:
            continue
        rows.append(row)
        if not args.no_transfer:
            dressed += transfer_rows(model, path, bpy, args, row)
            shell = shell_rows(model, path, bpy, args, row)
            if shell is not None:
                shells.append(shell)
        chk, note = row["artist_check"]
        chk = "-" if chk is None else f"{chk:.2e}"
        print(f"[eval] {model}: {row['total_s']:.1f} s; numpy LBS vs Blender's Armature modifier "
              f"(artist weights): max {chk} % of diag ({note})", flush=True)

    if not rows:
        print("[eval] no model evaluated")
        return
    lines = ["# Auto weights vs the artist's", "",
             f"bpy {bpy.app.version_string}; deform % = mean LBS distance to the artist-weighted mesh over "
             f"the animation, % of the rest bounding-box diagonal; Blender = parent_set ARMATURE_AUTO "
             f"(keep_transform).", ""]
    lines += table(rows) + [""]
    if not args.no_transfer:
        lines += ["## Transfer Weights", ""] + transfer_tables(dressed, shells) + [""]
    for r in rows:
        lines += details(r, args.detail)
    text = "\n".join(lines)
    print()
    print(text)
    out = blender_session.write_report(Path(args.out), text)
    print(f"[eval] wrote {out}")


if __name__ == "__main__":
    main()
