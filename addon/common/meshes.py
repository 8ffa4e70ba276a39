"""Mesh data as arrays: world vertices, triangles and faces, the shape its modifiers give it,
several meshes stacked as one, the vertices a Weight Paint mask selects, and a new mesh of triangles."""

from __future__ import annotations

import bpy
import numpy as np

from .transforms import world_points


def mesh_world_vertices(ob: bpy.types.Object) -> np.ndarray:
    """Rest-pose vertex positions of ``ob`` (its own mesh, no modifiers) in world space, (n, 3) float64."""
    return world_points(ob, _positions(ob.data))


def mesh_polygons(ob: bpy.types.Object) -> tuple[np.ndarray, np.ndarray]:
    """``ob``'s faces as corners per face (f,) uint32 and their vertex indices face after face
    (sum of the former,) uint32."""
    me = ob.data
    sizes = np.empty(len(me.polygons), dtype=np.uint32)
    me.polygons.foreach_get("loop_total", sizes)
    corners = np.empty(len(me.loops), dtype=np.uint32)
    me.loops.foreach_get("vertex_index", corners)
    return sizes, corners


def _positions(me: bpy.types.Mesh) -> np.ndarray:
    """``me``'s vertex positions, flat float32 (3n,)."""
    co = np.empty(len(me.vertices) * 3, dtype=np.float32)
    me.vertices.foreach_get("co", co)
    return co


def shaped_world_mesh(ob: bpy.types.Object) -> tuple[np.ndarray, np.ndarray]:
    """World vertices (n, 3) float64 and triangles (m, 3) uint32 of ``ob`` as the rigger sees it
    undeformed: its modifier stack (Mirror, Subdivision, Solidify, ...) evaluated with its
    Armature modifiers off. Its own mesh when it has no other enabled modifier. An object
    linked from a library too: Blender lets its modifiers be switched off and on. For reading
    only (Fit); weights are written to the mesh's own vertices, so Heat reads those, as
    Blender's Ctrl+P does."""
    shaping = any(m.show_viewport and m.type != "ARMATURE" for m in ob.modifiers)
    if not shaping:
        return mesh_world_vertices(ob), mesh_triangles(ob)
    deforming = [m for m in ob.modifiers if m.type == "ARMATURE" and m.show_viewport]
    for m in deforming:
        m.show_viewport = False
    try:
        evaluated = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
        me = evaluated.to_mesh()
        try:
            co, tris = _positions(me), _loop_triangles(me)
        finally:
            evaluated.to_mesh_clear()
    finally:
        for m in deforming:
            m.show_viewport = True
    return world_points(ob, co), tris


def stack_meshes(parts) -> tuple[np.ndarray, np.ndarray]:
    """Several meshes as one: ``parts`` (non-empty) of (vertices (n, 3), triangles (m, 3)) pairs
    -> (vertices stacked in order, triangles (m, 3) uint32 re-indexed into them)."""
    parts = list(parts)
    base = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
    verts = np.concatenate([v for v, _ in parts])
    tris = np.concatenate([np.asarray(t, np.int64).reshape(-1, 3) + b for (_, t), b in zip(parts, base)])
    return verts, tris.astype(np.uint32)


def mesh_triangles(ob: bpy.types.Object) -> np.ndarray:
    """Triangulation of ``ob``'s faces, (m, 3) uint32 vertex indices (Blender's loop triangles)."""
    return _loop_triangles(ob.data)


def _loop_triangles(me: bpy.types.Mesh) -> np.ndarray:
    me.calc_loop_triangles()
    tris = np.empty(len(me.loop_triangles) * 3, dtype=np.uint32)
    me.loop_triangles.foreach_get("vertices", tris)
    return tris.reshape(-1, 3)


def paint_mask(ob: bpy.types.Object) -> tuple[np.ndarray | None, str]:
    """The vertices to re-weight when ``ob`` is in Weight Paint mode with a selection mask on,
    as Blender's Weights > Assign Automatic from Bones does: ((n,) bool, the mask's name), or
    (None, "") when it is not in Weight Paint mode or no mask is on."""
    me = ob.data
    if ob.mode != "WEIGHT_PAINT" or not (me.use_paint_mask_vertex or me.use_paint_mask):
        return None, ""
    picked = np.zeros(len(me.vertices), dtype=bool)
    if me.use_paint_mask_vertex:
        me.vertices.foreach_get("select", picked)
        return picked, "Vertex Selection"
    faces = np.zeros(len(me.polygons), dtype=bool)
    me.polygons.foreach_get("select", faces)
    sizes, corners = mesh_polygons(ob)
    picked[corners[np.repeat(faces, sizes)]] = True
    return picked, "Face Selection"


def triangle_mesh(name: str, verts: np.ndarray, tris: np.ndarray) -> bpy.types.Mesh:
    """A new mesh of ``verts`` (n, 3) and the triangles ``tris`` (m, 3) (vertex indices), its
    edges computed; nothing else (no normals of its own, no UVs)."""
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(verts))
    me.vertices.foreach_set("co", np.asarray(verts, np.float32).ravel())
    me.loops.add(3 * len(tris))
    me.loops.foreach_set("vertex_index", np.asarray(tris, np.int32).ravel())
    me.polygons.add(len(tris))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(tris), 3, dtype=np.int32))
    me.update(calc_edges=True)
    return me
