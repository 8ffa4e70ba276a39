"""Fit Skeleton to Mesh against the artists' own skeletons.

    .venv/bin/python bench/bench_fit.py [--models Fox.glb,CesiumMan.gltf,spot_rig.glb] [--seeds 10] [--symmetry X]
                                        [--displace ball|depth] [--per-joint]

For each model in ``../shared/models/`` (relative to the project root; missing files are
skipped, never copied here) and for the generated creature (scripts/creature.py): take the
model's own skeleton, displace every joint randomly (seeded, uniform in a ball of radius 5 % of
the mesh's bounding-box diagonal; or, with ``--displace depth``, uniformly within 5 % along one
horizontal axis only, the depth of the view a rigger places joints in), run
``armature.miniskeleton_fit_skeleton`` and compare with the original joints. Joints are the
unique bone ends (a connected child's head is its parent's tail), and only the real ones are
scored: every bone head, plus a tail only where it is a real joint -- another bone's head, or
any tail of a rig built in Blender (the creature). glTF stores joints (nodes) only, so on an
imported model Blender's importer invents every tail that is not a child's head (leaf bones,
bones with several children); those are displaced with the rest but not scored. Prints a
markdown table: mean joint error before / after (% of the diagonal), the ratio, the error after
over the joints that were inside the mesh in the original rest pose, joints outside the mesh
(original, before, after), the floor (how far the fit moves the undisplaced artist joints) and
the operator's time; also writes it to out/bench_fit.md. ``--per-joint`` adds a table per model
of each scored joint's mean errors, split into the part along the limb (which centring cannot
undo) and across it, worst after / before first. Nothing is asserted (the test on the
creature asserts).
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "scripts")]
import blender_session  # noqa: E402

MODELS_DIR = ROOT.parent / "shared" / "models"
MODELS = ["Fox.glb", "CesiumMan.gltf", "spot_rig.glb"]


def addon(name: str):
    """The installed add-on's module ``name`` (common.meshes, skeleton.joints, ...)."""
    return importlib.import_module(f"{blender_session.ADDON_MODULE}.{name}")


def load(bpy, name):
    """Fresh scene with the model (or the creature): (armature, meshes)."""
    blender_session.reset_scene()
    if name == "creature":
        import creature

        body, arm = creature.build()
        return arm, [body]
    bpy.ops.import_scene.gltf(filepath=str(MODELS_DIR / name))
    arms = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    if len(arms) != 1:
        return None, []
    arm = arms[0]
    meshes = [o for o in bpy.data.objects if o.type == "MESH"
              and (any(m.type == "ARMATURE" and m.object is arm for m in o.modifiers) or o.parent is arm)]
    if not meshes:  # an unskinned model: every mesh with faces
        meshes = [o for o in bpy.data.objects if o.type == "MESH" and len(o.data.polygons) > 50]
    return arm, meshes


def edit_bones(bpy, arm):
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    return arm.data.edit_bones


def read_joints(bpy, arm, diag):
    ebs = edit_bones(bpy, arm)
    bones = list(ebs)
    index = {eb.name: i for i, eb in enumerate(bones)}
    h = np.array([eb.head for eb in bones], dtype=np.float64)
    t = np.array([eb.tail for eb in bones], dtype=np.float64)
    parents = [index[eb.parent.name] if eb.parent else -1 for eb in bones]
    conn = [eb.use_connect for eb in bones]
    bpy.ops.object.mode_set(mode="OBJECT")
    return addon("skeleton.joints").joint_graph(h, t, parents, conn, 1e-6 * diag)


def real_joints(ends, imported):
    """(j,) bool: joints that are real -- bone heads, and tails unless the importer invented them."""
    real = np.zeros(int(ends.max()) + 1, dtype=bool)
    real[ends[:, 0]] = True
    if not imported:
        real[ends[:, 1]] = True
    return real


def joints_now(bpy, arm, ends):
    ebs = list(edit_bones(bpy, arm))
    j = np.zeros((int(ends.max()) + 1, 3))
    for i, eb in enumerate(ebs):
        j[ends[i, 0]] = eb.head
        j[ends[i, 1]] = eb.tail
    bpy.ops.object.mode_set(mode="OBJECT")
    return j


def set_joints(bpy, arm, joints, ends):
    """Move the joints; parts parented to bones stay where they are (the mesh is fixed, only the
    skeleton is rough), as they do while the operator fits."""
    editing = addon("skeleton.editing")
    with editing.bone_children_stay(arm):
        editing.place_bone_ends(edit_bones(bpy, arm), joints[ends[:, 0]], joints[ends[:, 1]])
        bpy.ops.object.mode_set(mode="OBJECT")


def armature_space_mesh(arm, meshes):
    """The meshes in the armature's space, where edit bones live: (vertices (n,3) float32,
    triangles (m,3) uint32, bounding-box diagonal)."""
    # As the operator reads them: bone-parented parts where the rest bones are, modifiers
    # (a Mirror, say) applied with the Armature modifiers off.
    common_meshes = addon("common.meshes")
    with addon("common.armatures").rest_pose(arm, meshes):
        parts = [common_meshes.shaped_world_mesh(ob) for ob in meshes]
    inv = np.linalg.inv(np.array(arm.matrix_world, dtype=np.float64))
    verts, tris = common_meshes.stack_meshes(((v @ inv[:3, :3].T + inv[:3, 3]).astype(np.float32), t) for v, t in parts)
    return verts, tris, float(np.linalg.norm(verts.max(0) - verts.min(0)))


def fit(bpy, arm, meshes, **op):
    """Select the meshes and the armature (active) and run Fit Skeleton: (finished, seconds)."""
    for o in bpy.context.view_layer.objects:
        o.select_set(o in meshes or o is arm)
    bpy.context.view_layer.objects.active = arm
    start = time.perf_counter()
    ok = bpy.ops.armature.miniskeleton_fit_skeleton(**op) == {"FINISHED"}
    return ok, time.perf_counter() - start


def depth_axis(arm, meshes):
    """The view depth of placing joints by eye, as a unit vector in the armature's space: the world
    horizontal axis (X or Y) along which the meshes are narrowest. A biped is widest across its
    shoulders and placed in front view, a quadruped longest nose to tail and placed in side view;
    either way the joints come out right on the screen and wrong in depth."""
    world = np.concatenate([addon("common.meshes").mesh_world_vertices(ob) for ob in meshes])
    extent = world.max(0) - world.min(0)
    axis = np.eye(3)[int(np.argmin(extent[:2]))]
    inv = np.linalg.inv(np.array(arm.matrix_world, dtype=np.float64))[:3, :3]
    d = inv @ axis
    return d / np.linalg.norm(d)


def displacements(rng, n, diag, along=None):
    """(n, 3) random joint moves of at most 5 % of ``diag``: uniform in a ball, or uniform on the
    segment [-5 %, 5 %] along the unit vector ``along``."""
    if along is not None:
        return np.outer(rng.uniform(-1.0, 1.0, n) * 0.05 * diag, along)
    d = rng.normal(size=(n, 3))
    return d * (0.05 * diag * rng.random(n) ** (1 / 3) / np.linalg.norm(d, axis=1))[:, None]


def limb_axes(joints, ends):
    """(j, 3) unit direction of the limb at each joint: the mean of its bones' directions (head to
    tail), for splitting an error into its part along the limb and across it."""
    axis = np.zeros_like(joints)
    for h, t in ends:
        d = joints[t] - joints[h]
        n = np.linalg.norm(d)
        if n > 0:
            axis[h] += d / n
            axis[t] += d / n
    return axis / np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-12)


def joint_names(bones, ends):
    """A name for each joint: the first bone end found there ("Bone.head" / "Bone.tail")."""
    names = {}
    for bone, (h, t) in zip(bones, ends):
        names.setdefault(int(h), bone + ".head")
        names.setdefault(int(t), bone + ".tail")
    return names


def per_joint_table(r):
    """Markdown rows of the per-joint means over the seeds: before, after, the part of after along the
    limb (a centring fit cannot undo it: for a move uniform in direction it is half the move on
    average) and across it, the floor, and after / before, worst ratio first."""
    lines = [f"#### {r['model']}", "", "| joint | before % | after % | along % | across % | floor % | after / before |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for name, before, after, along, floor in sorted(r["joint_rows"], key=lambda j: -j[2] / j[1]):
        across = np.sqrt(max(after ** 2 - along ** 2, 0.0))
        lines.append(f"| {name} | {before:.2f} | {after:.2f} | {along:.2f} | {across:.2f} | {floor:.2f} "
                     f"| {after / before:.2f} |")
    return lines + [""]


def run(bpy, name, seeds, core, displace="ball", **op):
    arm, meshes = load(bpy, name)
    if arm is None or not meshes:
        return None
    verts, tris, diag = armature_space_mesh(arm, meshes)
    orig, ends = read_joints(bpy, arm, diag)
    real = real_joints(ends, imported=name != "creature")
    inside_orig = core.points_inside(verts, tris, orig.astype(np.float32))
    out_orig = int((~inside_orig & real).sum())
    scored_in = real & inside_orig

    def outside(j):
        return int((~core.points_inside(verts, tris, j.astype(np.float32)) & real).sum())

    # Floor: how far the fit moves the artist's own joints (where the mesh's centres disagree
    # with the artist, no displacement can be undone below this).
    if not fit(bpy, arm, meshes, **op)[0]:
        return None
    floor_each = np.linalg.norm(joints_now(bpy, arm, ends) - orig, axis=1) / diag * 100
    floor = floor_each[real].mean()
    set_joints(bpy, arm, orig, ends)
    along = depth_axis(arm, meshes) if displace == "depth" else None
    if along is not None:
        print(f"{name}: view depth in the armature's space {np.round(along, 3).tolist()}", flush=True)
    rows, per_before, per_after, per_along = [], [], [], []
    axis = limb_axes(orig, ends)
    for seed in range(seeds):
        moved = orig + displacements(np.random.default_rng(seed + 1), len(orig), diag, along)
        set_joints(bpy, arm, moved, ends)
        ok, secs = fit(bpy, arm, meshes, **op)
        if not ok:
            return None
        fitted = joints_now(bpy, arm, ends)
        err0 = np.linalg.norm(moved - orig, axis=1) / diag * 100
        err1 = np.linalg.norm(fitted - orig, axis=1) / diag * 100
        rows.append((err0[real].mean(), err1[real].mean(), err0[scored_in].mean(), err1[scored_in].mean(),
                     outside(moved), outside(fitted), secs))
        per_before.append(err0)
        per_after.append(err1)
        per_along.append(np.abs(((fitted - orig) * axis).sum(axis=1)) / diag * 100)
        set_joints(bpy, arm, orig, ends)
    r = np.array(rows, dtype=np.float64)
    names = joint_names([b.name for b in arm.data.bones], ends)
    before, after, along = (np.mean(e, axis=0) for e in (per_before, per_after, per_along))
    joint_rows = [(names[j], before[j], after[j], along[j], floor_each[j]) for j in np.nonzero(real)[0]]
    return dict(model=name, joints=int(real.sum()), ends=len(orig), vertices=len(verts), out_orig=out_orig, floor=floor,
                before=r[:, 0].mean(), after=r[:, 1].mean(), before_in=r[:, 2].mean(), after_in=r[:, 3].mean(),
                out_before=r[:, 4].mean(), out_after=r[:, 5].max(), secs=r[:, 6].mean(), joint_rows=joint_rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--tails", default="AUTO", help="the operator's Free Tails option")
    ap.add_argument("--max-move", type=float, default=None, help="the operator's Max Move (%%)")
    ap.add_argument("--symmetry", default="NONE", choices=["NONE", "X"], help="the operator's Symmetry")
    ap.add_argument("--per-joint", action="store_true",
                    help="also a table per model of every scored joint's mean errors, worst after/before first")
    ap.add_argument("--displace", default="ball", choices=["ball", "depth"],
                    help="ball: the issue's 5 %% ball; depth: up to 5 %% along the view depth only")
    args = ap.parse_args()
    bpy = blender_session.start()
    import miniskeleton_core as core

    names = ["creature"]
    for m in [m for m in args.models.split(",") if m]:
        if (MODELS_DIR / m).exists():
            names.append(m)
        else:
            print(f"skipped {m}: not in {MODELS_DIR}")
    lines = ["| model | joints (bone ends) | vertices | outside (original) | mean error before % | after % "
             "| after/before | before / after, joints inside originally % | outside before (mean) "
             "| outside after (max) | floor % | fit s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    details = []
    for name in names:
        op = dict(tails=args.tails, symmetry=args.symmetry) | ({} if args.max_move is None
                                                              else dict(max_move=args.max_move))
        r = run(bpy, name, args.seeds, core, args.displace, **op)
        if r is None:
            print(f"skipped {name}: no single armature with meshes, or the fit failed")
            continue
        lines.append(f"| {r['model']} | {r['joints']} ({r['ends']}) | {r['vertices']} | {r['out_orig']} | "
                     f"{r['before']:.2f} | {r['after']:.2f} | {r['after'] / r['before']:.2f} | "
                     f"{r['before_in']:.2f} / {r['after_in']:.2f} | {r['out_before']:.1f} | "
                     f"{int(r['out_after'])} | {r['floor']:.2f} | {r['secs']:.2f} |")
        print(lines[-1], flush=True)
        if args.per_joint:
            details += per_joint_table(r)
    table = "\n".join(lines + ([""] + details if details else []))
    how = ("uniformly in a ball of 5 % of the diagonal" if args.displace == "ball" else
           "uniformly within 5 % of the diagonal along the view depth only (the narrower horizontal axis)")
    print(f"\nJoints displaced {how}, {args.seeds} seeds; errors in % of "
          "the mesh bounding-box diagonal, against the model's own real joints (invented glTF tails not "
          "scored); outside counts are real joints. Floor: mean move of the artist's own joints when "
          "fitted undisplaced (where the mesh's cross-section centres disagree with the artist).\n")
    print(table)
    blender_session.write_report(ROOT / "out" / "bench_fit.md", table)


if __name__ == "__main__":
    main()
