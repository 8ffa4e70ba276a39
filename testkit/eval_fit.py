"""Fit Skeleton to Mesh against the artists' own skeletons.

    .venv/bin/python -m testkit.eval_fit [--models Fox.glb,CesiumMan.gltf,spot_rig.glb|all] [--seeds 10]
                                        [--symmetry X] [--displace ball|depth] [--per-joint]

Models: the generated creature (testkit/creature.py), the files of ``../shared/models/`` named
in ``--models`` (relative to the project root; missing files are skipped, never copied here)
and the rigs of testkit/rig_corpus.py named there (Rigify's generated rigs and the Mixamo-style
humanoid, each in a Skin body: ``rigify_basic_human``, ``mixamo_gltf``, ...); ``--models all``
is every rigged shared model (``RIGGED``) and ``CORPUS``. For each, take the model's own
skeleton, displace every joint randomly (seeded, uniform in a ball of radius 5 % of the mesh's
bounding-box diagonal; or, with ``--displace depth``, uniformly within 5 % along one horizontal
axis only, the depth of the view a rigger places joints in), run
``armature.miniskeleton_fit_skeleton`` and compare with the original joints. Joints are the
unique bone ends (a connected child's head is its parent's tail), and only the real joints that
Fit moves are scored: joints of deform bones (IK and pole targets keep their place), every bone
head, plus a tail only where it is a real joint -- another bone's head, or any tail of a rig
built in Blender. glTF and FBX store joints (nodes) only, so on an imported model (a file, or
one of ``IMPORTED_RIGS``) Blender's importer invents every tail that is not a child's head (leaf
bones, bones with several children); those are displaced with the rest but not scored (an FBX
import connects its chains, so connection does not tell).

Prints markdown tables: mean joint error before / after (% of the diagonal), the ratio, the
error after over the joints that were inside the mesh in the original rest pose, joints outside
the mesh (original, before, after), the floor (how far the fit moves the undisplaced artist
joints) and the operator's time; then the do-no-harm table: per group of joints (limbs,
junctions, spine, ends: ``joint_groups``, from the skeleton's shape alone) the mean error
before -> after, and how many joints inside the mesh when displaced end outside (over all
seeds). Also written to out/bench_fit.md. ``--per-joint`` adds a table per model of each scored
joint's group and mean errors, split into the part along the limb (which centring cannot undo)
and across it, worst after / before first. Nothing is asserted (blender_tests/test_models.py
asserts do no harm on the shared models, test_skeleton.py on the creature).
"""

from __future__ import annotations

import argparse
import importlib
import time

import numpy as np

from testkit import MODELS_DIR, ROOT, blender_session

MODELS = ["Fox.glb", "CesiumMan.gltf", "spot_rig.glb"]
# ``--models all``: every rigged model of ../shared/models, and rigs built by testkit/rig_corpus.py
RIGGED = ["Fox.glb", "CesiumMan.gltf", "RiggedSimple.gltf", "RobotExpressive.glb", "q_Bunny.glb", "q_Orc.glb",
          "q_Cat.glb", "q_Dragon.glb", "spot_rig.glb"]
CORPUS = ["rigify_basic_human", "rigify_basic_quadruped", "mixamo_gltf", "mixamo_fbx"]
# rigs of testkit/rig_corpus.py that come through an importer, which invents their leaf tails
IMPORTED_RIGS = {"mixamo_gltf", "mixamo_fbx", "mixamo_fbx_xaxis"}
GROUPS = ("limbs", "junctions", "spine", "ends")


def addon(name: str):
    """The installed add-on's module ``name`` (common.meshes, skeleton.joints, ...)."""
    return importlib.import_module(f"{blender_session.ADDON_MODULE}.{name}")


def load(bpy, name):
    """Fresh scene with the model (or the creature, or a rig of testkit/rig_corpus.py):
    (armature, meshes)."""
    blender_session.reset_scene()
    if name == "creature":
        from testkit import creature

        body, arm = creature.build()
        return arm, [body]
    if "." not in name:
        from testkit import rig_corpus

        rig = rig_corpus.build(name)
        return rig.arm, rig.meshes
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


def bone_facts(arm):
    """(parents (b,), deform (b,) bools) of ``arm``'s bones, in the order of its edit bones."""
    bones = list(arm.data.bones)
    index = {b.name: i for i, b in enumerate(bones)}
    parents = [index[b.parent.name] if b.parent else -1 for b in bones]
    return parents, np.array([b.use_deform for b in bones])


def joint_groups(joints, ends, parents, real):
    """(j,) group name of every real joint ("" for the others), from the skeleton's shape alone:
    the joints are linked by their bones (head to tail, where the tail is real) and each child
    not connected to its parent by a link from its head to the nearer real end of its parent (a
    thigh hangs from the hips at its parent's head, an arm from the chest at its parent's tail).
    A joint with one link is an *end* (a limb's tip, a root), with three or more a *junction*
    (hips, chest, a wrist with fingers); the others are chain joints, *spine* where the chain runs
    between two junctions, else *limbs* (legs, arms, neck, tail, fingers: chains to an end)."""
    links = [set() for _ in range(len(joints))]

    def link(a, b):
        if a != b and real[a] and real[b]:
            links[a].add(b)
            links[b].add(a)

    for i, (h, t) in enumerate(ends):
        link(h, t)
        p = parents[i]
        if p >= 0 and h not in ends[p]:
            cands = [e for e in ends[p] if real[e]]
            if cands:
                link(h, min(cands, key=lambda e: np.linalg.norm(joints[e] - joints[h])))
    degree = np.array([len(n) for n in links])

    def chain_end(prev, j):
        """Walk a chain from ``prev`` through ``j`` to the first joint that is not a chain joint."""
        seen = {prev}
        while degree[j] == 2 and j not in seen:
            seen.add(j)
            prev, j = j, next(iter(links[j] - {prev}))
        return j

    groups = np.full(len(joints), "", dtype=object)
    for j in np.flatnonzero(real):
        if degree[j] <= 1:
            groups[j] = "ends"
        elif degree[j] >= 3:
            groups[j] = "junctions"
        else:
            a, b = links[j]
            groups[j] = "spine" if degree[chain_end(j, a)] >= 3 and degree[chain_end(j, b)] >= 3 else "limbs"
    return groups


def fitted_joints(ends, deform):
    """(j,) bool: joints of deform bones, the ones Fit moves when no joint is selected (the others,
    IK and pole targets, keep their place)."""
    fitted = np.zeros(int(ends.max()) + 1, dtype=bool)
    fitted[ends[deform].ravel()] = True
    return fitted


def deform_parents(parents, deform):
    """Parents among the deform bones only: each deform bone's nearest deform ancestor, as an
    index into the deform bones (-1 for none)."""
    index = np.cumsum(deform) - 1
    out = []
    for i in np.flatnonzero(deform):
        p = parents[i]
        while p >= 0 and not deform[p]:
            p = parents[p]
        out.append(int(index[p]) if p >= 0 else -1)
    return out


def imported(name):
    """Whether the model ``name`` comes through an importer (a file, or one of ``IMPORTED_RIGS``),
    whose leaf bones' tails are invented."""
    return "." in name or name in IMPORTED_RIGS


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
    lines = [f"#### {r['model']}", "",
             "| joint | group | before % | after % | along % | across % | floor % | after / before |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for name, before, after, along, floor, group in sorted(r["joint_rows"], key=lambda j: -j[2] / j[1]):
        across = np.sqrt(max(after ** 2 - along ** 2, 0.0))
        lines.append(f"| {name} | {group} | {before:.2f} | {after:.2f} | {along:.2f} | {across:.2f} | {floor:.2f} "
                     f"| {after / before:.2f} |")
    return lines + [""]


def worse(before, after):
    """After farther than before, at the tables' precision (0.01 % of the diagonal)."""
    return round(after, 2) > round(before, 2)


def harm_header():
    """Header of the do-no-harm table: per group of joints, mean error before -> after."""
    return ["| model | " + " | ".join(f"{g} (n) before -> after %" for g in GROUPS) + " | inside -> outside |",
            "|---|" + "---|" * len(GROUPS) + "---:|"]


def harm_row(r):
    """One model's row of the do-no-harm table; a group that ends farther than it started (at the
    table's precision: joints left in place come back through single precision) is marked
    **worse**."""
    cells = []
    for g in GROUPS:
        if g not in r["groups"]:
            cells.append("-")
            continue
        n, before, after = r["groups"][g]
        cells.append(f"({n}) {before:.2f} -> {after:.2f}" + (" **worse**" if worse(before, after) else ""))
    return f"| {r['model']} | " + " | ".join(cells) + f" | {r['in_to_out']} |"


def model_names(spec):
    """The models ``--models`` names (``all``: every rigged shared model and ``CORPUS``), present
    here, after the creature; missing files are reported and skipped."""
    from testkit import rig_corpus

    wanted = RIGGED + CORPUS if spec == "all" else [m for m in spec.split(",") if m]
    names = ["creature"]
    for m in wanted:
        why = None if "." not in m else (None if (MODELS_DIR / m).exists() else f"not in {MODELS_DIR}")
        if "." not in m and m not in rig_corpus.NAMES:
            why = "not a model file nor a rig of testkit/rig_corpus.py"
        if why:
            print(f"skipped {m}: {why}")
        else:
            names.append(m)
    return names


def run(bpy, name, seeds, core, displace="ball", **op):
    arm, meshes = load(bpy, name)
    if arm is None or not meshes:
        return None
    verts, tris, diag = armature_space_mesh(arm, meshes)
    orig, ends = read_joints(bpy, arm, diag)
    parents, deform = bone_facts(arm)
    real = real_joints(ends, imported(name)) & fitted_joints(ends, deform)
    groups = joint_groups(orig, ends[deform], deform_parents(parents, deform), real)
    inside_orig = core.points_inside(verts, tris, orig.astype(np.float32))
    out_orig = int((~inside_orig & real).sum())
    scored_in = real & inside_orig

    def inside(j):
        return np.asarray(core.points_inside(verts, tris, j.astype(np.float32)))

    def outside(j):
        return int((~inside(j) & real).sum())

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
                     outside(moved), outside(fitted), secs, (inside(moved) & ~inside(fitted) & real).sum()))
        per_before.append(err0)
        per_after.append(err1)
        per_along.append(np.abs(((fitted - orig) * axis).sum(axis=1)) / diag * 100)
        set_joints(bpy, arm, orig, ends)
    r = np.array(rows, dtype=np.float64)
    names = joint_names([b.name for b in arm.data.bones], ends)
    before, after, along = (np.mean(e, axis=0) for e in (per_before, per_after, per_along))
    joint_rows = [(names[j], before[j], after[j], along[j], floor_each[j], groups[j]) for j in np.nonzero(real)[0]]
    group_rows = {g: (int((groups == g).sum()), before[groups == g].mean(), after[groups == g].mean())
                  for g in GROUPS if (groups == g).any()}
    return dict(model=name, joints=int(real.sum()), ends=len(orig), vertices=len(verts), out_orig=out_orig, floor=floor,
                before=r[:, 0].mean(), after=r[:, 1].mean(), before_in=r[:, 2].mean(), after_in=r[:, 3].mean(),
                out_before=r[:, 4].mean(), out_after=r[:, 5].max(), secs=r[:, 6].mean(), in_to_out=int(r[:, 7].sum()),
                joint_rows=joint_rows, groups=group_rows)


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

    names = model_names(args.models)
    lines = ["| model | joints (bone ends) | vertices | outside (original) | mean error before % | after % "
             "| after/before | before / after, joints inside originally % | outside before (mean) "
             "| outside after (max) | floor % | fit s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    details, harm = [], harm_header()
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
        harm.append(harm_row(r))
        print(lines[-1], flush=True)
        print(harm[-1], flush=True)
        if args.per_joint:
            details += per_joint_table(r)
    table = "\n".join(lines + [""] + harm + ([""] + details if details else []))
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
