"""The unrigged scans in ../shared/models/ (cow.obj, horse.ply) with the rough skeleton a rigger
blocks in by eye before fitting: a spine at 58 % of the height from the back feet to the front
feet, a neck and head toward the end that sticks out further (the head), and a two-bone leg
above each of the four feet (the clusters of the lowest vertices). Joints are rough on purpose:
Fit Skeleton centres them. Shared by bench_weights.py (speed on real meshes; its cylinder rigs
also use `armature_object`) and blender_tests/test_models.py (fit and bind on real scans); the
demo rigs scans with Auto Rig instead.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

MODELS_DIR = Path(__file__).resolve().parents[2] / "shared" / "models"
SCANS = ["cow.obj", "horse.ply"]
LEGS = ["back.L", "back.R", "front.L", "front.R"]


def load_scan(bpy, path: Path, scale: float = 1.0):
    """Import an OBJ or PLY with Blender's own importer (both leave +Z up), its mesh data scaled
    by `scale`; the new mesh object."""
    before = set(bpy.data.objects)
    if path.suffix.lower() == ".obj":
        bpy.ops.wm.obj_import(filepath=str(path))
    elif path.suffix.lower() == ".ply":
        bpy.ops.wm.ply_import(filepath=str(path))
    else:
        raise ValueError(f"{path.name}: only .obj and .ply scans")
    new = [ob for ob in bpy.data.objects if ob not in before and ob.type == "MESH"]
    if len(new) != 1:
        raise RuntimeError(f"{path.name}: expected one mesh, imported {len(new)}")
    if scale != 1.0:
        from mathutils import Matrix

        new[0].data.transform(Matrix.Scale(scale, 4))
    return new[0]


def feet(verts: np.ndarray, share: float = 0.06, rounds: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """The four feet of a +Z-up quadruped: k-means (k = 4, started at the bounding-box corners)
    on the lowest `share` of the height, in the ground plane. Returns (centres (4, 2) in xy,
    labels (n,) with -1 for vertices above the feet)."""
    z = verts[:, 2]
    low = z < z.min() + share * (z.max() - z.min())
    xy = verts[low, :2]
    lo, hi = xy.min(0), xy.max(0)
    corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [lo[0], hi[1]], [hi[0], hi[1]]])
    centres = np.array([xy[np.linalg.norm(xy - c, axis=1).argmin()] for c in corners])
    for _ in range(rounds):
        lab = np.linalg.norm(xy[:, None] - centres[None], axis=2).argmin(1)
        centres = np.array([xy[lab == k].mean(0) if (lab == k).any() else centres[k] for k in range(4)])
    labels = np.full(len(verts), -1)
    labels[low] = lab
    return centres, labels


def rough_quadruped(verts: np.ndarray):
    """The rough skeleton of a +Z-up quadruped scan. Returns (names, heads (b,3), tails (b,3),
    parents (b,) with -1 for the root, connected (b,) bools, foot labels (n,): for each vertex
    among the lowest, the index into LEGS of its foot, else -1)."""
    centres, labels = feet(verts)
    lo, hi = verts.min(0), verts.max(0)
    long = int(np.argmax((hi - lo)[:2]))
    side = 1 - long
    height = hi[2] - lo[2]
    order = np.argsort(centres[:, long])
    back, front = order[:2], order[2:]
    back_at, front_at = centres[back, long].mean(), centres[front, long].mean()
    # The head sticks out further beyond its feet than the rump does; make +long point to it.
    sign = 1.0 if hi[long] - front_at >= back_at - lo[long] else -1.0
    if sign < 0:
        back, front, back_at, front_at = front, back, front_at, back_at
    end = hi[long] if sign > 0 else lo[long]
    mid = centres[:, side].mean()

    def point(along, up, across=mid):
        p = np.zeros(3)
        p[long], p[side], p[2] = along, across, lo[2] + up * height
        return p

    pelvis, chest = point(back_at, 0.58), point(front_at, 0.58)
    spine = (pelvis + chest) / 2
    neck = point(front_at + 0.5 * (end - front_at), 0.7)
    head = point(front_at + 0.85 * (end - front_at), 0.75)
    names = ["spine", "chest", "neck", "head"]
    heads, tails = [pelvis, spine, chest, neck], [spine, chest, neck, head]
    parents, connected = [-1, 0, 1, 2], [False, True, True, True]
    foot_of = np.full(len(verts), -1)
    for k, leg in enumerate(LEGS):
        # .L is the foot on the left looking toward the head: left = up x forward.
        pair = [int(i) for i in (back if leg.startswith("back") else front)]
        left = max(pair, key=lambda i: sign * (centres[i, side] if long == 0 else -centres[i, side]))
        c = left if leg.endswith(".L") else [i for i in pair if i != left][0]
        at, across = centres[c, long], centres[c, side]
        hip, knee, hoof = point(at, 0.55, across), point(at, 0.3, across), point(at, 0.06, across)
        names += [f"thigh.{leg}", f"shin.{leg}"]
        heads += [hip, knee]
        tails += [knee, hoof]
        parents += [0 if leg.startswith("back") else 1, len(names) - 2]
        connected += [False, True]
        foot_of[labels == c] = k
    return names, np.array(heads), np.array(tails), np.array(parents), np.array(connected), foot_of


def armature_object(bpy, name, names, heads, tails, parents, connected):
    """A new armature object (at the origin, linked to the scene) with these bones: heads and
    tails (b, 3) in its space, parents (b,) earlier indices or -1, connected (b,) bools."""
    data = bpy.data.armatures.new(name)
    ob = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    ebs = []
    for i, n in enumerate(names):
        eb = data.edit_bones.new(n)
        eb.head, eb.tail = np.asarray(heads[i]).tolist(), np.asarray(tails[i]).tolist()
        if parents[i] >= 0:
            eb.parent, eb.use_connect = ebs[parents[i]], bool(connected[i])
        ebs.append(eb)
    bpy.ops.object.mode_set(mode="OBJECT")
    return ob


def armature(bpy, verts: np.ndarray, name: str = "RoughRig"):
    """A new armature object (at the origin) with `rough_quadruped(verts)`; (object, foot labels)."""
    names, heads, tails, parents, connected, foot_of = rough_quadruped(verts)
    return armature_object(bpy, name, names, heads, tails, parents, connected), foot_of
