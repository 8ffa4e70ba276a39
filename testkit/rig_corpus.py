"""Rigs to measure Add Motion on (testkit/motion_corpus.py; Blender tests can import the same
builders): Rigify control rigs, Mixamo-style humanoids round-tripped through glTF and FBX,
game and hand-made rigs from ``../shared/models``, a Blender-built deform-only rig, the
project's generated creature, legless characters, and bare meshes rigged by Auto Rig.

Every builder starts from the current (empty) scene and returns a :class:`Rig`: the armature
to animate and the meshes that follow it (an Armature modifier or a bone parent). Rigs made
here get a body of their own: a Skin-modifier surface around their deform bones, weighted to
the nearest bone segments (``bind_to_segments``), so the body follows the deform bones whatever
drives them (keys, or Rigify's constraints). Models are read from ``../shared/models``
(``MODELS_DIR``) and never copied; a rig whose file is absent is reported by ``missing``.

    import rig_corpus
    rig = rig_corpus.build("rigify_basic_human")   # after blender_session.reset_scene()
"""

from __future__ import annotations

import importlib
import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix

from testkit import MODELS_DIR, ROOT


@dataclass
class Rig:
    """A rig to animate: the armature object, the meshes that follow it, and what it is."""

    name: str
    arm: bpy.types.Object
    meshes: list
    kind: str                 # rigify / mixamo / game / hand-made / legless / auto-rigged
    legless: bool = False     # WALK and RUN must be refused ("no legs")
    notes: list = field(default_factory=list)


# ---------------------------------------------------------------------------- scene helpers

def link(ob):
    bpy.context.scene.collection.objects.link(ob)
    return ob


def set_active(ob, selected=()):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    for o in selected:
        o.select_set(True)
    ob.select_set(True)
    bpy.context.view_layer.objects.active = ob


def new_armature(name, bones, matrix=None):
    """Armature object ``name`` with ``bones`` = [(name, head, tail, parent or None, connected)]
    in armature space; ``matrix``: the object's world matrix. Every bone deforms."""
    data = bpy.data.armatures.new(name)
    ob = link(bpy.data.objects.new(name, data))
    if matrix is not None:
        ob.matrix_world = matrix
    set_active(ob)
    bpy.ops.object.mode_set(mode="EDIT")
    made = {}
    for bname, head, tail, parent, connected in bones:
        eb = data.edit_bones.new(bname)
        eb.head, eb.tail = head, tail
        if parent:
            eb.parent = made[parent]
            eb.use_connect = connected
        made[bname] = eb
    bpy.ops.object.mode_set(mode="OBJECT")
    return ob


def bone_segments(arm, names):
    """World heads and tails (b, 3) of ``arm``'s bones ``names`` at rest."""
    m = np.array(arm.matrix_world)
    h = np.array([arm.data.bones[n].head_local for n in names]) @ m[:3, :3].T + m[:3, 3]
    t = np.array([arm.data.bones[n].tail_local for n in names]) @ m[:3, :3].T + m[:3, 3]
    return h, t


def segment_distances(points, heads, tails, chunk=4096):
    """(n, b) distances from ``points`` to the segments heads[j]-tails[j]."""
    out = np.empty((len(points), len(heads)))
    a, ab = heads[None], (tails - heads)[None]
    den = np.maximum((ab * ab).sum(-1), 1e-30)
    for s in range(0, len(points), chunk):
        p = points[s:s + chunk, None, :]
        t = np.clip(((p - a) * ab).sum(-1) / den, 0.0, 1.0)
        out[s:s + chunk] = np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)
    return out


def skin_body(name, points, edges, radii, subdivisions=1):
    """A plain mesh object: Blender's Skin (+ Subdivision) modifier over the graph ``points``
    (world, (n, 3)), ``edges`` (pairs), ``radii`` (n,), applied. One root per connected piece."""
    graph = bpy.data.meshes.new(name + "Graph")
    graph.from_pydata([tuple(map(float, p)) for p in points], [tuple(map(int, e)) for e in edges], [])
    src = link(bpy.data.objects.new(name + "Graph", graph))
    src.modifiers.new("Skin", "SKIN")
    skin = graph.skin_vertices[0].data
    piece = list(range(len(points)))

    def find(i):
        while piece[i] != i:
            piece[i] = piece[piece[i]]
            i = piece[i]
        return i

    for a, b in edges:
        piece[find(a)] = find(b)
    roots = set()
    for i, r in enumerate(radii):
        skin[i].radius = (float(r), float(r))
        skin[i].use_root = False
    for i in range(len(points)):
        if find(i) not in roots:
            roots.add(find(i))
            skin[i].use_root = True
    if subdivisions:
        sub = src.modifiers.new("Subdivision", "SUBSURF")
        sub.levels = sub.render_levels = subdivisions
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = bpy.data.meshes.new_from_object(src.evaluated_get(depsgraph))
    mesh.name = name
    bpy.data.objects.remove(src)
    bpy.data.meshes.remove(graph)
    body = link(bpy.data.objects.new(name, mesh))
    for poly in mesh.polygons:
        poly.use_smooth = True
    return body


def bone_graph(arm, names, radius, tol):
    """Skin graph of bones ``names`` (world): end points merged within ``tol``, one edge per
    bone; each point's radius the largest ``radius(length)`` of the bones meeting there."""
    heads, tails = bone_segments(arm, names)
    points, edges, radii = [], [], []

    def point(p, r):
        for i, q in enumerate(points):
            if np.linalg.norm(q - p) <= tol:
                radii[i] = max(radii[i], r)
                return i
        points.append(p)
        radii.append(r)
        return len(points) - 1

    for h, t in zip(heads, tails):
        r = radius(float(np.linalg.norm(t - h)))
        a, b = point(h, r), point(t, r)
        if a != b:
            edges.append((a, b))
    return np.array(points), edges, np.array(radii)


def bind_to_segments(body, arm, names, sharpness=0.15, most=3):
    """Weight ``body`` to ``arm``'s bones ``names`` by distance to their rest segments (the
    nearest bone, blended with the next ones near joints), add an Armature modifier and parent
    it to ``arm`` with its vertices in armature space (as imported characters are)."""
    me = body.data
    co = np.empty(len(me.vertices) * 3)
    me.vertices.foreach_get("co", co)
    mw = np.array(body.matrix_world)
    world = co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3]
    heads, tails = bone_segments(arm, names)
    d = segment_distances(world, heads, tails)
    dmin = np.maximum(d.min(axis=1, keepdims=True), 1e-9)
    w = np.exp(-(d / dmin - 1.0) / sharpness)
    if w.shape[1] > most:
        cut = np.partition(w, -most, axis=1)[:, -most][:, None]
        w = np.where(w >= cut, w, 0.0)
    w /= w.sum(axis=1, keepdims=True)
    for j, name in enumerate(names):
        rows = np.nonzero(w[:, j] > 1e-4)[0]
        if len(rows):
            g = body.vertex_groups.new(name=name)
            for i in rows:
                g.add([int(i)], float(w[i, j]), "REPLACE")
    # vertices into armature space, object at the armature's origin as its child
    to_arm = np.linalg.inv(np.array(arm.matrix_world))
    local = world @ to_arm[:3, :3].T + to_arm[:3, 3]
    me.vertices.foreach_set("co", local.astype(np.float32).ravel())
    me.update()
    body.parent = arm
    body.matrix_parent_inverse = Matrix.Identity(4)
    body.matrix_basis = Matrix.Identity(4)
    mod = body.modifiers.new("Armature", "ARMATURE")
    mod.object = arm
    bpy.context.view_layer.update()
    return body


def following_meshes(arm):
    """Meshes that follow ``arm``: an Armature modifier on it, or parented to one of its bones
    (RobotExpressive's rigid limbs). The glTF importer's bone-shape icosphere is neither."""
    out = []
    for ob in bpy.context.scene.objects:
        if ob.type != "MESH":
            continue
        if any(m.type == "ARMATURE" and m.object == arm for m in ob.modifiers):
            out.append(ob)
        elif ob.parent == arm and ob.parent_type == "BONE":
            out.append(ob)
    return sorted(out, key=lambda ob: ob.name)


# ---------------------------------------------------------------------------- humanoid

# A T-posed humanoid in metres, Z up, facing -Y (its left is +X), 1.8 m tall. Joint:
# (position, skin radius). The Blender-built deform-only rig and the Mixamo one share it.
HUMAN_JOINTS = {
    "hips": ((0.0, 0.0, 1.00), 0.14),
    "spine": ((0.0, 0.0, 1.10), 0.13),
    "spine1": ((0.0, 0.0, 1.22), 0.14),
    "spine2": ((0.0, 0.0, 1.36), 0.15),
    "neck": ((0.0, 0.01, 1.50), 0.06),
    "head": ((0.0, 0.0, 1.60), 0.10),
    "headtop": ((0.0, 0.0, 1.80), 0.07),
}
for _s, _x in (("L", 1.0), ("R", -1.0)):
    HUMAN_JOINTS.update({
        f"shoulder.{_s}": ((0.05 * _x, 0.0, 1.45), 0.07),
        f"arm.{_s}": ((0.18 * _x, 0.0, 1.45), 0.055),
        f"elbow.{_s}": ((0.45 * _x, 0.0, 1.45), 0.045),
        f"wrist.{_s}": ((0.70 * _x, 0.0, 1.45), 0.04),
        f"fingers.{_s}": ((0.86 * _x, 0.0, 1.45), 0.03),
        f"hip.{_s}": ((0.09 * _x, 0.0, 0.95), 0.09),
        f"knee.{_s}": ((0.09 * _x, -0.01, 0.52), 0.06),
        f"ankle.{_s}": ((0.09 * _x, 0.02, 0.09), 0.045),
        f"ball.{_s}": ((0.09 * _x, -0.12, 0.03), 0.035),
        f"toe.{_s}": ((0.09 * _x, -0.20, 0.03), 0.03),
    })

# bone: (head joint, tail joint, parent, connected), in the Mixamo names ({s}: Left/Right)
MIXAMO_BONES = [
    ("Hips", "hips", "spine", None, False),
    ("Spine", "spine", "spine1", "Hips", True),
    ("Spine1", "spine1", "spine2", "Spine", True),
    ("Spine2", "spine2", "neck", "Spine1", True),
    ("Neck", "neck", "head", "Spine2", True),
    ("Head", "head", "headtop", "Neck", True),
]
for _s, _side in (("L", "Left"), ("R", "Right")):
    MIXAMO_BONES += [
        (f"{_side}Shoulder", f"shoulder.{_s}", f"arm.{_s}", "Spine2", False),
        (f"{_side}Arm", f"arm.{_s}", f"elbow.{_s}", f"{_side}Shoulder", True),
        (f"{_side}ForeArm", f"elbow.{_s}", f"wrist.{_s}", f"{_side}Arm", True),
        (f"{_side}Hand", f"wrist.{_s}", f"fingers.{_s}", f"{_side}ForeArm", True),
        (f"{_side}UpLeg", f"hip.{_s}", f"knee.{_s}", "Hips", False),
        (f"{_side}Leg", f"knee.{_s}", f"ankle.{_s}", f"{_side}UpLeg", True),
        (f"{_side}Foot", f"ankle.{_s}", f"ball.{_s}", f"{_side}Leg", True),
        (f"{_side}ToeBase", f"ball.{_s}", f"toe.{_s}", f"{_side}Foot", True),
    ]
# Mixamo's end joints (no weights): a short bone past the head's and each toe's tip
MIXAMO_ENDS = [("HeadTop_End", "Head", (0.0, 0.0, 0.08))] + [
    (f"{side}Toe_End", f"{side}ToeBase", (0.0, -0.04, 0.0)) for side in ("Left", "Right")]
# Blender-style names for the deform-only rig
BLENDER_NAMES = {"Hips": "hips", "Spine": "spine", "Spine1": "spine.001", "Spine2": "chest", "Neck": "neck",
                 "Head": "head"}
for _s, _side in (("L", "Left"), ("R", "Right")):
    BLENDER_NAMES.update({f"{_side}Shoulder": f"shoulder.{_s}", f"{_side}Arm": f"upper_arm.{_s}",
                          f"{_side}ForeArm": f"forearm.{_s}", f"{_side}Hand": f"hand.{_s}",
                          f"{_side}UpLeg": f"thigh.{_s}", f"{_side}Leg": f"shin.{_s}", f"{_side}Foot": f"foot.{_s}",
                          f"{_side}ToeBase": f"toe.{_s}"})

# skin edges tying the limbs into the body
HUMAN_EXTRA_EDGES = [("spine2", "shoulder.L"), ("spine2", "shoulder.R"), ("hips", "hip.L"), ("hips", "hip.R")]


def human_body(name="Body"):
    """The humanoid's Skin body in world space (metres)."""
    names = list(HUMAN_JOINTS)
    index = {n: i for i, n in enumerate(names)}
    edges = {tuple(sorted((index[h], index[t]))) for _, h, t, _, _ in MIXAMO_BONES}
    edges |= {tuple(sorted((index[a], index[b]))) for a, b in HUMAN_EXTRA_EDGES}
    return skin_body(name, np.array([HUMAN_JOINTS[n][0] for n in names]), sorted(edges),
                     [HUMAN_JOINTS[n][1] for n in names])


def deform_only_human():
    """A humanoid built in Blender (metres, scale 1, Blender names), every bone deforming."""
    bones = [(BLENDER_NAMES[b], HUMAN_JOINTS[h][0], HUMAN_JOINTS[t][0], BLENDER_NAMES.get(p), c)
             for b, h, t, p, c in MIXAMO_BONES]
    arm = new_armature("HumanRig", bones)
    body = bind_to_segments(human_body("HumanBody"), arm, [b[0] for b in bones])
    return Rig("deform_only_human", arm, [body], "hand-made")


def mixamo_source():
    """The Mixamo-style humanoid as Mixamo makes it: bones ``mixamorig:*`` in centimetres in a
    Y-up armature space, the armature object turned 90 degrees about X and scaled 0.01, the body
    its child (vertices in centimetres), end joints HeadTop_End / *Toe_End without weights."""
    to_data = np.array(Matrix.Rotation(-math.pi / 2, 3, "X")) * 100.0   # world metres -> armature cm, Y up

    def d(p):
        return tuple(to_data @ np.asarray(p, dtype=float))

    pre = "mixamorig:"
    bones = [(pre + b, d(HUMAN_JOINTS[h][0]), d(HUMAN_JOINTS[t][0]), pre + p if p else None, c)
             for b, h, t, p, c in MIXAMO_BONES]
    tips = {b[0]: b[2] for b in bones}
    for end, parent, step in MIXAMO_ENDS:
        tip = np.array(tips[pre + parent])
        bones.append((pre + end, tuple(tip), tuple(tip + np.array(d(step))), pre + parent, True))
    matrix = Matrix.Rotation(math.pi / 2, 4, "X") @ Matrix.Diagonal((0.01, 0.01, 0.01, 1.0))
    arm = new_armature("Armature", bones, matrix)
    weighted = [pre + b[0] for b in MIXAMO_BONES]
    body = bind_to_segments(human_body("Beta_Surface"), arm, weighted)
    return Rig("mixamo_blend", arm, [body], "mixamo",
               notes=["as built, before any export (cm bones, object scale 0.01, turned 90 degrees about X)"])


def mixamo_roundtrip(fmt, bone_axis="Y"):
    """The Mixamo-style humanoid exported with Blender's bundled glTF or FBX exporter and
    imported again with the default options: the importers invent the bone tails as they do
    for a user's Mixamo download. ``bone_axis`` (FBX): the joint axis the exporter lays along
    each bone; "X" writes joints as Maya's convention has them (X down the bone), and Blender's
    importer, which takes Y for the bone by default, then points every tail across its bone."""
    from testkit import blender_session

    src = mixamo_source()
    folder = Path(tempfile.mkdtemp(prefix="miniskeleton-mixamo-"))
    set_active(src.arm, selected=src.meshes)
    if fmt == "gltf":
        path = folder / "mixamo.glb"
        bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLB", use_selection=True,
                                  export_animations=False)
    else:
        path = folder / "mixamo.fbx"
        bpy.ops.export_scene.fbx(filepath=str(path), use_selection=True, add_leaf_bones=False, bake_anim=False,
                                 primary_bone_axis=bone_axis, secondary_bone_axis="Y" if bone_axis == "X" else "X")
    blender_session.reset_scene()
    if fmt == "gltf":
        bpy.ops.import_scene.gltf(filepath=str(path))
    else:
        bpy.ops.import_scene.fbx(filepath=str(path))
    arm = imported_armature()
    axes = f", joints with {bone_axis} along the bone" if fmt == "fbx" else ""
    return Rig(f"mixamo_{fmt}", arm, following_meshes(arm), "mixamo",
               notes=[f"exported with Blender's {fmt} exporter{axes}, imported with the default options"])


def imported_armature():
    arms = [ob for ob in bpy.context.scene.objects if ob.type == "ARMATURE"]
    if len(arms) != 1:
        raise RuntimeError(f"expected one armature, found {[a.name for a in arms]}")
    return arms[0]


# ---------------------------------------------------------------------------- game rigs with IK

# Game rigs exported from an IK set-up: each foot (and its IK target and pole) hangs off the
# ground root bone, not off its leg, and the exporter drops the IK constraints that made it
# follow the leg. Bones: (name, head, tail, parent, connected, deforms); a head or tail is a
# joint's name or a point. Metres, Z up, facing -Y (the left is +X).
QUAD_JOINTS = {
    "root": ((0.0, 0.0, 0.0), 0.0),
    "hips": ((0.0, 0.30, 0.55), 0.11),
    "spine": ((0.0, 0.05, 0.57), 0.13),
    "chest": ((0.0, -0.20, 0.58), 0.13),
    "neck": ((0.0, -0.30, 0.62), 0.07),
    "head": ((0.0, -0.42, 0.78), 0.07),
    "snout": ((0.0, -0.60, 0.74), 0.03),
    "tail": ((0.0, 0.42, 0.56), 0.04),
    "tail_tip": ((0.0, 0.65, 0.45), 0.02),
}
for _s, _x in (("L", 1.0), ("R", -1.0)):
    QUAD_JOINTS.update({
        f"hip.{_s}": ((0.12 * _x, 0.30, 0.50), 0.07),
        f"stifle.{_s}": ((0.12 * _x, 0.20, 0.32), 0.05),
        f"hock.{_s}": ((0.12 * _x, 0.36, 0.16), 0.035),
        f"hind_fetlock.{_s}": ((0.12 * _x, 0.34, 0.03), 0.03),
        f"hind_toe.{_s}": ((0.12 * _x, 0.27, 0.0), 0.025),
        f"shoulder.{_s}": ((0.12 * _x, -0.22, 0.50), 0.07),
        f"elbow.{_s}": ((0.12 * _x, -0.16, 0.30), 0.045),
        f"wrist.{_s}": ((0.12 * _x, -0.22, 0.12), 0.035),
        f"front_fetlock.{_s}": ((0.12 * _x, -0.22, 0.03), 0.03),
        f"front_toe.{_s}": ((0.12 * _x, -0.30, 0.0), 0.025),
    })

QUAD_IK_BONES = [
    ("Root", "root", (0.0, 0.2, 0.0), None, False, False),
    ("Hips", "hips", "spine", "Root", False, True),
    ("Spine", "spine", "chest", "Hips", True, True),
    ("Chest", "chest", "neck", "Spine", True, True),
    ("Neck", "neck", "head", "Chest", True, True),
    ("Head", "head", "snout", "Neck", True, True),
    ("Tail", "tail", "tail_tip", "Hips", False, True),
]
for _s in "LR":
    _x = 0.12 if _s == "L" else -0.12
    QUAD_IK_BONES += [
        (f"Thigh.{_s}", f"hip.{_s}", f"stifle.{_s}", "Hips", False, True),
        (f"Shin.{_s}", f"stifle.{_s}", f"hock.{_s}", f"Thigh.{_s}", True, True),
        (f"HindFoot.{_s}", f"hock.{_s}", f"hind_fetlock.{_s}", "Root", False, True),
        (f"HindToe.{_s}", f"hind_fetlock.{_s}", f"hind_toe.{_s}", f"HindFoot.{_s}", True, True),
        (f"UpperArm.{_s}", f"shoulder.{_s}", f"elbow.{_s}", "Chest", False, True),
        (f"ForeArm.{_s}", f"elbow.{_s}", f"wrist.{_s}", f"UpperArm.{_s}", True, True),
        (f"FrontFoot.{_s}", f"wrist.{_s}", f"front_fetlock.{_s}", "Root", False, True),
        (f"FrontToe.{_s}", f"front_fetlock.{_s}", f"front_toe.{_s}", f"FrontFoot.{_s}", True, True),
        (f"IK_Hind.{_s}", f"hock.{_s}", (_x, 0.46, 0.16), "Root", False, False),
        (f"IK_Front.{_s}", f"wrist.{_s}", (_x, -0.12, 0.12), "Root", False, False),
        (f"Pole_Hind.{_s}", (_x, -0.05, 0.32), (_x, -0.10, 0.32), "Root", False, False),
        (f"Pole_Front.{_s}", (_x, 0.10, 0.30), (_x, 0.15, 0.30), "Root", False, False),
    ]
# IK constraints of the source rig: (bone, target, pole)
QUAD_IK = [(f"Shin.{s}", f"IK_Hind.{s}", f"Pole_Hind.{s}") for s in "LR"] + \
    [(f"ForeArm.{s}", f"IK_Front.{s}", f"Pole_Front.{s}") for s in "LR"]

BIPED_IK_BONES = [("Root", (0.0, 0.0, 0.0), (0.0, 0.2, 0.0), None, False, False)]
BIPED_IK_BONES += [(b, h, t, p or "Root", c, True) for b, h, t, p, c in MIXAMO_BONES
                   if not b.endswith(("Foot", "ToeBase"))]
for _s, _side in (("L", "Left"), ("R", "Right")):
    _x = 0.09 if _s == "L" else -0.09
    _a = 0.70 if _s == "L" else -0.70
    BIPED_IK_BONES += [
        (f"{_side}Foot", f"ankle.{_s}", f"ball.{_s}", "Root", False, True),
        (f"{_side}ToeBase", f"ball.{_s}", f"toe.{_s}", f"{_side}Foot", True, True),
        (f"IK_Foot.{_s}", f"ankle.{_s}", (_x, 0.12, 0.09), "Root", False, False),
        (f"IK_Knee.{_s}", (_x, -0.40, 0.52), (_x, -0.50, 0.52), "Root", False, False),
        (f"IK_Hand.{_s}", f"wrist.{_s}", (_a, 0.10, 1.45), "Root", False, False),
        (f"IK_Elbow.{_s}", (0.45 if _s == "L" else -0.45, 0.30, 1.45),
         (0.45 if _s == "L" else -0.45, 0.40, 1.45), "Root", False, False),
    ]
BIPED_IK = [(f"{side}Leg", f"IK_Foot.{s}", f"IK_Knee.{s}") for s, side in (("L", "Left"), ("R", "Right"))] + \
    [(f"{side}ForeArm", f"IK_Hand.{s}", f"IK_Elbow.{s}") for s, side in (("L", "Left"), ("R", "Right"))]


def ik_game_rig(name, joints, bones, constraints):
    """A game rig with its feet, IK targets and poles off the ground root (``bones``, over
    ``joints``), IK constraints on the legs (``constraints``), a Skin body over its deform bones
    bound to them; exported with Blender's glTF exporter and imported again with the default
    options, as a game character reaches a user: the constraints are gone, the feet stay
    children of the root."""
    from testkit import blender_session

    def at(p):
        return joints[p][0] if isinstance(p, str) else p

    arm = new_armature("GameRig", [(b, at(h), at(t), p, c) for b, h, t, p, c, _ in bones])
    for b, *_, deforms in bones:
        arm.data.bones[b].use_deform = deforms
    for bone, target, pole in constraints:
        ik = arm.pose.bones[bone].constraints.new("IK")
        ik.target, ik.subtarget, ik.pole_target, ik.pole_subtarget = arm, target, arm, pole
        ik.chain_count = 2
    deform = [b for b, *_, deforms in bones if deforms]
    height = max(p[2] for p, _ in joints.values())
    points, edges, radii = bone_graph(arm, deform, lambda length: 0.0, 1e-4 * height)
    radius = {tuple(np.round(p, 6)): r for p, r in joints.values()}
    radii = np.array([radius.get(tuple(np.round(p, 6)), 0.03) for p in points])
    body = bind_to_segments(skin_body(name + "_body", points, edges, radii), arm, deform)
    folder = Path(tempfile.mkdtemp(prefix="miniskeleton-gamerig-"))
    path = folder / f"{name}.glb"
    set_active(arm, selected=[body])
    bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLB", use_selection=True, export_animations=False)
    blender_session.reset_scene()
    bpy.ops.import_scene.gltf(filepath=str(path))
    arm = imported_armature()
    return Rig(name, arm, following_meshes(arm), "game",
               notes=["feet, IK targets and poles children of the root; IK constraints dropped by the glTF "
                      "exporter; imported with the default options"])


# ---------------------------------------------------------------------------- Rigify

RIGIFY_METARIGS = {
    "rigify_human": "human",
    "rigify_basic_human": "Basic.basic_human",
    "rigify_basic_quadruped": "Basic.basic_quadruped",
    "rigify_wolf": "Animals.wolf",
    "rigify_horse": "Animals.horse",
    "rigify_cat": "Animals.cat",
    "rigify_bird": "Animals.bird",
}


def rigify_rig(name):
    """Rigify's metarig ``RIGIFY_METARIGS[name]`` generated into its control rig
    (``pose.rigify_generate``), with a Skin body around the rig's DEF bones bound to them.
    The metarig stays in the scene, hidden."""
    bpy.ops.preferences.addon_enable(module="rigify")
    module = importlib.import_module("rigify.metarigs." + RIGIFY_METARIGS[name])
    meta = link(bpy.data.objects.new("metarig", bpy.data.armatures.new("metarig")))
    set_active(meta)
    bpy.ops.object.mode_set(mode="EDIT")
    module.create(meta)
    bpy.ops.object.mode_set(mode="OBJECT")
    result = bpy.ops.pose.rigify_generate()
    if result != {"FINISHED"}:
        raise RuntimeError(f"rigify_generate: {result}")
    rig = meta.data.rigify_target_rig
    meta.hide_set(True)
    meta.hide_render = True
    deform = [b.name for b in rig.data.bones if b.use_deform]
    heads, tails = bone_segments(rig, deform)
    height = float(np.ptp(np.concatenate([heads, tails])[:, 2]))
    points, edges, radii = bone_graph(
        rig, deform, lambda length: float(np.clip(0.22 * length, 0.004 * height, 0.05 * height)), 1e-4 * height)
    body = bind_to_segments(skin_body(name + "_body", points, edges, radii), rig, deform)
    set_active(rig)
    return Rig(name, rig, [body], "rigify",
               notes=[f"{len(rig.data.bones)} bones, {len(deform)} deform (DEF-)"])


# ---------------------------------------------------------------------------- files

SHARED = {
    "Fox": ("Fox.glb", "game", False),
    "CesiumMan": ("CesiumMan.gltf", "game", False),
    "RobotExpressive": ("RobotExpressive.glb", "game", False),
    "q_Bunny": ("q_Bunny.glb", "game", False),
    "spot_rig": ("spot_rig.glb", "hand-made", False),
    "q_Orc": ("q_Orc.glb", "legless", True),
    "q_Cat": ("q_Cat.glb", "legless", True),
    "q_Dragon": ("q_Dragon.glb", "legless", True),
}


def shared_model(name):
    """A model of ../shared/models imported with the glTF importer's defaults. spot_rig has no
    weights: its mesh is bound to the bones here (``bind_to_segments``)."""
    file, kind, legless = SHARED[name]
    bpy.ops.import_scene.gltf(filepath=str(MODELS_DIR / file))
    arm = imported_armature()
    meshes = following_meshes(arm)
    notes = []
    if not meshes:
        loose = [ob for ob in bpy.context.scene.objects if ob.type == "MESH" and ob.parent is None
                 and len(ob.data.vertices) > 100]
        deform = [b.name for b in arm.data.bones if b.use_deform]
        meshes = [bind_to_segments(ob, arm, deform) for ob in loose]
        notes.append("no weights in the file: bound to the nearest bone segments")
    return Rig(name, arm, meshes, kind, legless, notes)


# ---------------------------------------------------------------------------- auto-rigged

# rig: the bare mesh Auto Rig is run on (the project's Spot; the scans and the game characters
# of ../shared/models, the latter without their armature)
AUTORIG = {
    "autorig_spot": ROOT / "assets" / "spot" / "spot.glb",
    "autorig_cow": MODELS_DIR / "cow.obj",
    "autorig_horse": MODELS_DIR / "horse.ply",
    "autorig_CesiumMan": MODELS_DIR / "CesiumMan.gltf",
    "autorig_Fox": MODELS_DIR / "Fox.glb",
    "autorig_q_Bunny": MODELS_DIR / "q_Bunny.glb",
}


def unbind(ob) -> None:
    """Free mesh ``ob`` of its armature where it stands: no parent, no vertex groups, no Armature
    modifiers."""
    world = ob.matrix_world.copy()
    ob.parent = None
    ob.matrix_world = world
    ob.vertex_groups.clear()
    for mod in [m for m in ob.modifiers if m.type == "ARMATURE"]:
        ob.modifiers.remove(mod)


def bare_model(path):
    """Model ``path`` (glTF, FBX, OBJ or PLY) imported as a bare mesh: its armature(s) deleted, with
    the meshes kept where they are in the rest pose and their groups and Armature modifiers gone.
    Returns the meshes (the importer's bone shapes left out)."""
    from testkit import blender_session

    new, meshes, rigs = blender_session.import_model(path)  # new: the importer's bone shapes too
    for arm in rigs:
        arm.data.pose_position = "REST"
    bpy.context.view_layer.update()
    for ob in meshes:
        unbind(ob)
    for ob in new:
        if ob.type != "MESH" or ob not in meshes:
            bpy.data.objects.remove(ob)
    for data in list(bpy.data.armatures):
        bpy.data.armatures.remove(data)
    bpy.context.view_layer.update()
    return meshes


def unweighted(arm, meshes) -> int:
    """How many vertices of ``meshes`` carry no weight on a deform bone of ``arm``."""
    deform = {b.name for b in arm.data.bones if b.use_deform}
    count = 0
    for ob in meshes:
        groups = {g.index for g in ob.vertex_groups if g.name in deform}
        count += sum(not any(g.group in groups and g.weight > 0 for g in v.groups) for v in ob.data.vertices)
    return count


def auto_rigged(name):
    """``AUTORIG[name]`` as a bare mesh, auto-rigged and bound as a user does it: the meshes
    selected, ``object.miniskeleton_auto_rig`` with its defaults (template and facing found from
    the mesh, bound with Heat)."""
    meshes = bare_model(AUTORIG[name])
    set_active(meshes[0], selected=meshes)
    result = bpy.ops.object.miniskeleton_auto_rig(template="AUTO", forward="AUTO", bind=True)
    if result != {"FINISHED"}:
        raise RuntimeError(f"miniskeleton_auto_rig: {result}")
    arm = imported_armature()
    bound = following_meshes(arm)
    if len(bound) != len(meshes):
        raise RuntimeError(f"auto rig bound {[ob.name for ob in bound]} of {[ob.name for ob in meshes]}")
    return Rig(name, arm, bound, "auto-rigged",
               notes=[f"Auto Rig on the bare mesh of {AUTORIG[name].name}: {len(arm.data.bones)} bones, "
                      f"{unweighted(arm, bound)} unweighted vertices"])


def creature_rig():
    """The project's generated quadruped (testkit/creature.py), bound to its bones."""
    from testkit import creature

    body, arm = creature.build()
    body = bind_to_segments(body, arm, [b.name for b in arm.data.bones])
    return Rig("creature", arm, [body], "hand-made")


# ---------------------------------------------------------------------------- registry

def _rigify(name):
    return lambda: rigify_rig(name)


def _shared(name):
    return lambda: shared_model(name)


def _auto(name):
    return lambda: auto_rigged(name)


BUILDERS = {name: _rigify(name) for name in RIGIFY_METARIGS}
BUILDERS.update({
    "mixamo_blend": mixamo_source,
    "mixamo_gltf": lambda: mixamo_roundtrip("gltf"),
    "mixamo_fbx": lambda: mixamo_roundtrip("fbx"),
    "mixamo_fbx_xaxis": lambda: mixamo_roundtrip("fbx", "X"),
})
BUILDERS.update({
    "ik_quadruped_gltf": lambda: ik_game_rig("ik_quadruped_gltf", QUAD_JOINTS, QUAD_IK_BONES, QUAD_IK),
    "ik_biped_gltf": lambda: ik_game_rig("ik_biped_gltf", HUMAN_JOINTS, BIPED_IK_BONES, BIPED_IK),
})
BUILDERS.update({name: _shared(name) for name in SHARED if not SHARED[name][2]})
BUILDERS.update({"deform_only_human": deform_only_human, "creature": creature_rig})
BUILDERS.update({name: _shared(name) for name in SHARED if SHARED[name][2]})
BUILDERS.update({name: _auto(name) for name in AUTORIG})
NAMES = list(BUILDERS)


def missing(name) -> str | None:
    """Why rig ``name`` cannot be built here (its file is absent), else None."""
    path = MODELS_DIR / SHARED[name][0] if name in SHARED else AUTORIG.get(name)
    if path is not None and not path.exists():
        return f"{path} not present"
    return None


def build(name) -> Rig:
    """Rig ``name`` (one of ``NAMES``) built in the current scene, in Object Mode, with no action
    on its armature and every pose bone at rest."""
    rig = BUILDERS[name]()
    rig.name = name
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    return rig
