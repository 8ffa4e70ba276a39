"""A quadruped the project generates itself: a Skin-modifier body around a generated armature.

One joint table drives both the skin graph (vertices at joints, edges along bones, radii per
joint) and the armature (one bone per edge), so the bones sit inside the body by construction.
Blender's Skin and Subdivision modifiers make the surface; the result is applied to a plain mesh.
Coordinates: metres, Z up, the creature faces -Y (Blender's front view looks along +Y).
"""

from __future__ import annotations

import bpy

# joint: (position, skin radius)
JOINTS = {
    "hips": ((0.0, 0.55, 1.00), 0.26),
    "spine": ((0.0, 0.05, 1.05), 0.28),
    "chest": ((0.0, -0.45, 1.08), 0.30),
    "neck": ((0.0, -0.75, 1.38), 0.15),
    "head": ((0.0, -0.95, 1.58), 0.17),
    "snout": ((0.0, -1.30, 1.50), 0.10),
    "tail1": ((0.0, 0.85, 1.08), 0.08),
    "tail2": ((0.0, 1.15, 1.20), 0.06),
    "tail3": ((0.0, 1.40, 1.22), 0.04),
    "ear.L": ((0.12, -0.92, 1.85), 0.04),
    "ear.R": ((-0.12, -0.92, 1.85), 0.04),
}
for side, x in (("L", 0.24), ("R", -0.24)):
    JOINTS.update({
        f"shoulder.{side}": ((x, -0.45, 0.95), 0.13),
        f"elbow.{side}": ((x, -0.48, 0.55), 0.09),
        f"wrist.{side}": ((x, -0.45, 0.12), 0.07),
        f"fronttoe.{side}": ((x, -0.60, 0.05), 0.06),
        f"hip.{side}": ((x, 0.55, 0.92), 0.15),
        f"knee.{side}": ((x, 0.62, 0.55), 0.10),
        f"ankle.{side}": ((x, 0.52, 0.12), 0.07),
        f"hindtoe.{side}": ((x, 0.38, 0.05), 0.06),
    })

# bone: (head joint, tail joint, parent bone or None, connected)
BONES = {
    "spine": ("hips", "spine", None, False),
    "chest": ("spine", "chest", "spine", True),
    "neck": ("chest", "neck", "chest", True),
    "head": ("neck", "head", "neck", True),
    "jaw": ("head", "snout", "head", True),
    "tail.001": ("hips", "tail1", "spine", False),
    "tail.002": ("tail1", "tail2", "tail.001", True),
    "tail.003": ("tail2", "tail3", "tail.002", True),
    "ear.L": ("head", "ear.L", "head", False),
    "ear.R": ("head", "ear.R", "head", False),
}
for s in ("L", "R"):
    BONES.update({
        f"upper_arm.{s}": (f"shoulder.{s}", f"elbow.{s}", "chest", False),
        f"forearm.{s}": (f"elbow.{s}", f"wrist.{s}", f"upper_arm.{s}", True),
        f"hand.{s}": (f"wrist.{s}", f"fronttoe.{s}", f"forearm.{s}", True),
        f"thigh.{s}": (f"hip.{s}", f"knee.{s}", "spine", False),
        f"shin.{s}": (f"knee.{s}", f"ankle.{s}", f"thigh.{s}", True),
        f"foot.{s}": (f"ankle.{s}", f"hindtoe.{s}", f"shin.{s}", True),
    })

# skin graph edges: every bone, plus the limb roots tied into the body
EXTRA_EDGES = [("chest", "shoulder.L"), ("chest", "shoulder.R"), ("hips", "hip.L"), ("hips", "hip.R")]


def build_body(name: str = "Creature", subdivisions: int = 2) -> bpy.types.Object:
    """The creature's surface as a plain mesh object (Skin + Subdivision applied)."""
    names = list(JOINTS)
    index = {n: i for i, n in enumerate(names)}
    edges = {tuple(sorted((index[h], index[t]))) for h, t, _, _ in BONES.values()}
    edges |= {tuple(sorted((index[a], index[b]))) for a, b in EXTRA_EDGES}
    graph = bpy.data.meshes.new(name + "Graph")
    graph.from_pydata([JOINTS[n][0] for n in names], sorted(edges), [])
    src = bpy.data.objects.new(name + "Graph", graph)
    bpy.context.scene.collection.objects.link(src)
    src.modifiers.new("Skin", "SKIN")
    for i, n in enumerate(names):
        r = JOINTS[n][1]
        graph.skin_vertices[0].data[i].radius = (r, r)
    graph.skin_vertices[0].data[index["hips"]].use_root = True
    sub = src.modifiers.new("Subdivision", "SUBSURF")
    sub.levels = sub.render_levels = subdivisions
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = bpy.data.meshes.new_from_object(src.evaluated_get(depsgraph))
    mesh.name = name
    bpy.data.objects.remove(src)
    bpy.data.meshes.remove(graph)
    body = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(body)
    for poly in mesh.polygons:
        poly.use_smooth = True
    return body


def build_armature(name: str = "CreatureRig") -> bpy.types.Object:
    """The creature's armature: one bone per entry of BONES, in object mode on return."""
    arm = bpy.data.armatures.new(name)
    ob = bpy.data.objects.new(name, arm)
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    made = {}
    for bone, (h, t, parent, connected) in BONES.items():
        eb = arm.edit_bones.new(bone)
        eb.head, eb.tail = JOINTS[h][0], JOINTS[t][0]
        if parent:
            eb.parent = made[parent]
            eb.use_connect = connected
        made[bone] = eb
    bpy.ops.object.mode_set(mode="OBJECT")
    ob.show_in_front = True
    return ob


def build() -> tuple[bpy.types.Object, bpy.types.Object]:
    """(body mesh, armature), not yet bound."""
    return build_body(), build_armature()
