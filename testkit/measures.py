"""What the tests and benches read back from a Blender scene: mesh vertices in world space, at
rest (the mesh data) or evaluated (modifiers, the Armature modifier's deformation, parents)."""

from __future__ import annotations

import numpy as np


def _to_world(co: np.ndarray, matrix_world) -> np.ndarray:
    m = np.array(matrix_world)
    return co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]


def world_vertices(ob) -> np.ndarray:
    """(n, 3) float64 world positions of mesh object ``ob``'s own vertices (no modifiers)."""
    co = np.empty(len(ob.data.vertices) * 3)
    ob.data.vertices.foreach_get("co", co)
    return _to_world(co, ob.matrix_world)


def evaluated_world_vertices(ob) -> np.ndarray:
    """(n, 3) float64 world positions of ``ob`` after its modifiers (the Armature modifier's
    deformation) at the current frame."""
    import bpy

    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    me = ev.to_mesh()
    co = np.empty(len(me.vertices) * 3)
    me.vertices.foreach_get("co", co)
    ev.to_mesh_clear()
    return _to_world(co, ev.matrix_world)


def group_state(ob) -> tuple:
    """``ob``'s vertex group names and every (vertex, group name, weight to 6 places)."""
    names = {g.index: g.name for g in ob.vertex_groups}
    return (sorted(names.values()),
            sorted((v.index, names[g.group], round(g.weight, 6)) for v in ob.data.vertices for g in v.groups))


def scene_state(ob) -> tuple:
    """What a cancelled operator must leave as it was on mesh ``ob``: its groups and weights,
    modifiers, parent, world matrix and vertices."""
    return (group_state(ob), [(m.type, m.name) for m in ob.modifiers], ob.parent,
            [tuple(r) for r in ob.matrix_world], world_vertices(ob).tobytes())
