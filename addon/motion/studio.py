"""The set Make Video films a character on when it frames the character itself: a floor that
fills every view of its camera and the character's shadow on it, laid for the render only
(``studio_set``) and removed afterwards. The Workbench settings that go with it are
``filming.set_engine``'s.

Inputs: the character's objects, its world boxes (frame, lo, hi) over the frame range
(``filming.motion_boxes``; scene units, Z up) and the camera. Output: a floor (a checker of
squares half the character's size) at the height its feet stand on, reaching past every
corner ray of the camera at every sampled frame, and per character mesh a shadow object.

The shadow is a planar projected shadow (J. Blinn, "Me and my (fake) shadow", IEEE CG&A 8(1),
1988): the character's evaluated mesh at each frame, flattened onto the floor along a light
high above the camera's left shoulder by a Geometry Nodes modifier, 0.1 % of the character's
size above the floor, in the floor's colour darkened. Workbench's own shadows are stencil
shadow volumes drawn again at every anti-aliasing sample; on a CPU (Mesa's llvmpipe) they cost
about 1 s per sample at 50k vertices, where the flat copy costs one more pass over the mesh
(``bench/bench_video.py``).

Known limits: the shadow falls on the floor only (not on the character, nor on other objects)
and has a hard edge; it follows the mesh point by point, so a modifier that changes the mesh's
topology from frame to frame breaks it; a character that never touches the ground gets its
floor under its lowest point."""

from __future__ import annotations

import math
import statistics
from contextlib import contextmanager

import bpy
import numpy as np
from mathutils import Vector

from ..common.meshes import mesh_triangles, triangle_mesh

# Colours (linear RGB) and light of the set: a light character (meshes without a material show
# Workbench's 0.8 grey) on a darker, cooler floor, and a shadow that halves the floor's light.
FLOOR_COLOURS = ((0.16, 0.20, 0.26, 1.0), (0.13, 0.165, 0.215, 1.0))
SHADOW_FACTOR = 0.45
# Towards the light, in the camera's frame (x right, y forward along the view's heading, z up):
# high above, a little behind the camera and to its left, so the shadow falls behind and to the
# right of the character, near its feet.
LIGHT_FROM = Vector((-0.35, -0.45, 1.0))
# Checker squares on the floor: half the character's size, at most this many.
SQUARE = 0.5
MAX_SQUARES = 40_000
# How far below the horizon a new camera's top edge looks, so that only floor is behind the
# character (degrees); the floor reaches about 1 / tan(this) camera heights away.
FLOOR_DIP = 5.0


def half_tangents(angle: float, aspect: float) -> tuple[float, float]:
    """tan of half the horizontal and vertical field of view of a camera whose larger side
    spans ``angle`` (Blender's sensor fit Auto), for a frame of ``aspect`` width / height."""
    tx = math.tan(angle / 2) if aspect >= 1 else math.tan(angle / 2) * aspect
    return tx, tx / aspect


def min_pitch(angle: float, aspect: float) -> float:
    """The least downward pitch (radians) at which a camera of ``angle`` sees no horizon: its
    top edge FLOOR_DIP below it."""
    return math.atan(half_tangents(angle, aspect)[1]) + math.radians(FLOOR_DIP)


def ground_height(boxes) -> float:
    """The floor's height under a motion: the median over the sampled frames of the lowest
    point (a foot in stance; a foot that dips a little into the ground at one frame does not
    lower the floor for the others)."""
    return statistics.median(lo.z for _f, lo, _hi in boxes)


def _views(scene, cam, frames):
    """``cam``'s world matrices at ``frames`` (one when it does not move)."""
    if cam.animation_data is None or cam.animation_data.action is None:
        bpy.context.view_layer.update()   # a camera placed just now
        return [cam.matrix_world.copy()]
    current = scene.frame_current
    out = []
    for f in frames:
        scene.frame_set(f)
        out.append(cam.matrix_world.copy())
    scene.frame_set(current)
    return out


def floor_extent(views, angle: float, aspect: float, height: float):
    """Where the views' corner rays meet the plane z = ``height``: the (lo, hi) corners in XY of
    the rectangle they span, with a tenth of its size added on each side, and the longest ray;
    None when a corner ray does not go down to it (a camera below the floor, or level)."""
    tx, ty = half_tangents(angle, aspect)
    xs, ys, reach = [], [], 0.0
    for m in views:
        origin = m.translation
        for sx in (-tx, tx):
            for sy in (-ty, ty):
                d = m.to_3x3() @ Vector((sx, sy, -1.0))
                if d.z >= 0 or origin.z <= height:
                    return None
                t = (height - origin.z) / d.z
                hit = origin + t * d
                xs.append(hit.x)
                ys.append(hit.y)
                reach = max(reach, (hit - origin).length)
    pad = 0.1 * max(max(xs) - min(xs), max(ys) - min(ys))
    return Vector((min(xs) - pad, min(ys) - pad)), Vector((max(xs) + pad, max(ys) + pad)), reach


def has_ground(scene, characters, boxes, height: float) -> bool:
    """Whether a visible mesh other than the characters lies under them where they stand: its
    box spans the first frame's footprint centre and its top is within 5 % of the characters'
    height from the floor's."""
    lo, hi = boxes[0][1], boxes[0][2]
    centre, tol = (lo + hi) / 2, 0.05 * max(hi.z - lo.z, 1e-9)
    for ob in scene.objects:
        if ob.type != "MESH" or ob in characters or not ob.visible_get():
            continue
        pts = [ob.matrix_world @ Vector(c) for c in ob.bound_box]
        if (min(p.x for p in pts) <= centre.x <= max(p.x for p in pts)
                and min(p.y for p in pts) <= centre.y <= max(p.y for p in pts)
                and abs(max(p.z for p in pts) - height) <= tol):
            return True
    return False


def _material(name: str, colour) -> bpy.types.Material:
    """A matte material of ``colour`` for Workbench (its viewport colour) and, where it has a
    node tree (always in Blender 5.0), for EEVEE and Cycles (its Principled BSDF)."""
    mat = bpy.data.materials.new(name)
    mat.diffuse_color = colour
    mat.roughness = 1.0
    mat.metallic = 0.0
    mat.specular_intensity = 0.0
    for node in mat.node_tree.nodes if mat.node_tree is not None else ():
        if node.type == "BSDF_PRINCIPLED":
            node.inputs["Base Color"].default_value = colour
            node.inputs["Roughness"].default_value = 1.0
    return mat


def _link(scene, name: str, data) -> bpy.types.Object:
    ob = bpy.data.objects.new(name, data)
    scene.collection.objects.link(ob)
    return ob


def add_floor(scene, lo: Vector, hi: Vector, height: float, origin: Vector, tile: float) -> bpy.types.Object:
    """A floor from ``lo`` to ``hi`` (XY) at ``height``: squares of side ``tile`` in a checker
    of FLOOR_COLOURS, one corner at ``origin`` (XY), so that a camera that travels with the
    character shows it moving over the floor; larger squares where that would make more than
    MAX_SQUARES (a very long walk)."""
    tile = max(tile, math.sqrt((hi.x - lo.x) * (hi.y - lo.y) / MAX_SQUARES))
    i0, j0 = math.floor((lo.x - origin.x) / tile), math.floor((lo.y - origin.y) / tile)
    i1, j1 = math.ceil((hi.x - origin.x) / tile), math.ceil((hi.y - origin.y) / tile)
    nx, ny = i1 - i0, j1 - j0
    gx, gy = np.meshgrid(origin.x + tile * np.arange(i0, i1 + 1), origin.y + tile * np.arange(j0, j1 + 1),
                         indexing="ij")
    verts = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, height)], axis=1)
    corner = (np.arange(nx)[:, None] * (ny + 1) + np.arange(ny)[None, :]).ravel()   # each square's lo corner
    quads = np.stack([corner, corner + ny + 1, corner + ny + 2, corner + 1], axis=1)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    me = triangle_mesh("MiniSkeletonFloor", verts, tris)
    for k, colour in enumerate(FLOOR_COLOURS):
        me.materials.append(_material(f"MiniSkeletonFloor.{k}", colour))
    parity = ((np.arange(nx)[:, None] + i0 + np.arange(ny)[None, :] + j0) % 2).ravel()
    me.polygons.foreach_set("material_index", np.concatenate([parity, parity]).astype(np.int32))
    floor = _link(scene, "MiniSkeletonFloor", me)
    floor.display.show_shadows = False
    return floor


def add_shadow(scene, character: bpy.types.Object, height: float, toward_light: Vector) -> bpy.types.Object:
    """``character``'s shadow on the plane z = ``height``: a new object with the triangles of
    the character's evaluated mesh (and no custom normals, which would shade the flat copy as
    the surface it came from), whose Geometry Nodes modifier takes each point where the
    character's evaluated mesh has it at the frame rendered (world space) and moves it along
    ``toward_light`` (unit, z > 0) down to that plane, every face turned up and flat-shaded.
    The character's modifiers must keep its topology from frame to frame (an Armature does)."""
    evaluated = character.evaluated_get(bpy.context.evaluated_depsgraph_get())
    copy = triangle_mesh("MiniSkeletonShadow", np.zeros((len(evaluated.data.vertices), 3)),
                         mesh_triangles(evaluated))
    nodes = bpy.data.node_groups.new(f"MiniSkeletonShadow.{character.name}", "GeometryNodeTree")
    nodes.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    nodes.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    n, links = nodes.nodes, nodes.links
    copy_in, out = n.new("NodeGroupInput"), n.new("NodeGroupOutput")
    info = n.new("GeometryNodeObjectInfo")
    info.transform_space = "RELATIVE"          # in the shadow object's space, which is the world's
    info.inputs["Object"].default_value = character
    sample = n.new("GeometryNodeSampleIndex")  # the character's point i, for the copy's point i
    sample.data_type, sample.domain = "FLOAT_VECTOR", "POINT"
    position, index = n.new("GeometryNodeInputPosition"), n.new("GeometryNodeInputIndex")
    xyz = n.new("ShaderNodeSeparateXYZ")
    above = n.new("ShaderNodeMath")
    above.operation = "SUBTRACT"
    above.inputs[1].default_value = height
    along = n.new("ShaderNodeVectorMath")      # -(z - height) / lz * light: down to the plane
    along.operation = "SCALE"
    along.inputs[0].default_value = -toward_light / toward_light.z
    down_to = n.new("ShaderNodeVectorMath")
    down_to.operation = "ADD"
    move = n.new("GeometryNodeSetPosition")
    normal = n.new("GeometryNodeInputNormal")  # faces turned down by the flattening turn up
    normal_xyz = n.new("ShaderNodeSeparateXYZ")
    turned = n.new("ShaderNodeMath")
    turned.operation = "LESS_THAN"
    turned.inputs[1].default_value = 0.0
    flip = n.new("GeometryNodeFlipFaces")
    flat = n.new("GeometryNodeSetShadeSmooth")  # one normal per face: straight up
    flat.inputs["Shade Smooth"].default_value = False
    paint = n.new("GeometryNodeSetMaterial")
    floor_rgb = sum((Vector(c[:3]) for c in FLOOR_COLOURS), Vector()) / len(FLOOR_COLOURS) * SHADOW_FACTOR
    paint.inputs["Material"].default_value = _material("MiniSkeletonShadow", (*floor_rgb, 1.0))
    for a, b in ((info.outputs["Geometry"], sample.inputs["Geometry"]), (position.outputs[0], sample.inputs["Value"]),
                 (index.outputs[0], sample.inputs["Index"]), (sample.outputs[0], xyz.inputs[0]),
                 (xyz.outputs["Z"], above.inputs[0]), (above.outputs[0], along.inputs["Scale"]),
                 (along.outputs["Vector"], down_to.inputs[0]), (sample.outputs[0], down_to.inputs[1]),
                 (copy_in.outputs[0], move.inputs["Geometry"]), (down_to.outputs["Vector"], move.inputs["Position"]),
                 (move.outputs[0], flip.inputs[0]), (normal.outputs["Normal"], normal_xyz.inputs[0]),
                 (normal_xyz.outputs["Z"], turned.inputs[0]), (turned.outputs[0], flip.inputs["Selection"]),
                 (flip.outputs[0], flat.inputs[0]), (flat.outputs[0], paint.inputs[0]),
                 (paint.outputs[0], out.inputs[0])):
        links.new(a, b)
    shadow = _link(scene, f"MiniSkeletonShadow.{character.name}", copy)
    shadow.modifiers.new("Shadow", "NODES").node_group = nodes
    shadow.display.show_shadows = False
    return shadow


def light_direction(cam: bpy.types.Object) -> Vector:
    """LIGHT_FROM turned to ``cam``'s heading: a unit world vector towards the light."""
    forward = cam.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0))
    forward.z = 0.0
    forward = forward.normalized() if forward.length > 1e-9 else Vector((0.0, 1.0, 0.0))
    right = forward.cross(Vector((0.0, 0.0, 1.0)))
    return (LIGHT_FROM.x * right + LIGHT_FROM.y * forward + Vector((0.0, 0.0, LIGHT_FROM.z))).normalized()


@contextmanager
def studio_set(scene, characters, boxes, cam, aspect: float, shadow: bool = True):
    """Lays the set for the block: a floor under ``characters`` (objects) at their ground
    height that fills every view ``cam`` has of them at the frames of ``boxes`` (its clip end
    moved out to see it all), for a video of ``aspect`` width / height, and, with ``shadow``,
    the shadow of each character mesh on it; removes it all afterwards, with the data only it
    used, and puts the clip end back. Nothing is laid when the scene has a ground there of its
    own, or when the camera cannot see a floor (it looks up). Yields the objects laid (empty
    when none)."""
    height = ground_height(boxes)
    views = _views(scene, cam, [f for f, _lo, _hi in boxes])
    extent = floor_extent(views, cam.data.angle, aspect, height)
    laid = []
    clip_end = cam.data.clip_end
    try:
        if extent is not None and not has_ground(scene, characters, boxes, height):
            lo, hi, reach = extent
            size = max(max((b[2] - b[1]).length for b in boxes), 1e-9)
            first = (boxes[0][1] + boxes[0][2]) / 2
            laid.append(add_floor(scene, lo, hi, height, first, SQUARE * size))
            cam.data.clip_end = max(clip_end, 1.2 * reach)
            above = height + 1e-3 * size             # over the floor, never in it
            toward = light_direction(cam)
            if shadow:
                laid += [add_shadow(scene, ob, above, toward) for ob in characters if ob.type == "MESH"]
        yield laid
    finally:
        cam.data.clip_end = clip_end
        blocks = set()
        for ob in laid:
            blocks.add(ob.data)
            blocks.update(ob.data.materials)
            for m in ob.modifiers:
                if m.type == "NODES" and m.node_group is not None:
                    blocks.add(m.node_group)
                    blocks.update(node.inputs["Material"].default_value for node in m.node_group.nodes
                                  if node.bl_idname == "GeometryNodeSetMaterial")
            bpy.data.objects.remove(ob)
        bpy.data.batch_remove([b for b in blocks if b is not None])
