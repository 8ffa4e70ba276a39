"""Where Add Motion goes: the points of a path curve and the heights of a ground mesh, read from
the scene for the core (``make_motion``'s ``path`` and ``ground``), which does the maths."""

from __future__ import annotations

import math

import bpy
import numpy as np

# The ground's grid: a cell of this share of the character's height (a quarter of a foot's
# length or finer), coarser where the region would need more than MOST_CELLS points per side.
CELL = 1.0 / 40.0
MOST_CELLS = 200
# A path whose start lies further than this many character sizes from the character is far.
FAR = 1.0


class SteeringError(ValueError):
    """A path or ground the walk cannot use; the text says why."""


def path_points(ob: bpy.types.Object | None) -> np.ndarray:
    """(p, 3) world points of curve ``ob`` along its one spline (the evaluated curve's line at
    its resolution; a beveled or extruded curve's control points; a closed spline ends where it
    starts). SteeringError for anything
    but a curve with one spline of two points or more and some length."""
    if ob is None or ob.type != "CURVE":
        raise SteeringError(f"the path '{ob.name if ob else ''}' is not a curve object")
    if len(ob.data.splines) != 1:
        raise SteeringError(f"the path '{ob.name}' has {len(ob.data.splines)} splines; it needs one")
    spline = ob.data.splines[0]
    cyclic = spline.use_cyclic_u
    if ob.data.bevel_depth > 0.0 or ob.data.extrude > 0.0 or ob.data.bevel_object is not None:
        co = spline_points(spline)   # its mesh is a tube, not its line: the control points
    else:
        dg = bpy.context.evaluated_depsgraph_get()
        ev = ob.evaluated_get(dg)
        try:
            me = ev.to_mesh()
            co = np.empty(len(me.vertices) * 3)
            me.vertices.foreach_get("co", co)
            co = co.reshape(-1, 3)
        finally:
            ev.to_mesh_clear()
        if not len(co):
            co = spline_points(spline)
    if cyclic and len(co):
        co = np.concatenate([co, co[:1]])
    m = np.array(ob.matrix_world, dtype=np.float64)
    world = co @ m[:3, :3].T + m[:3, 3]
    if len(world) < 2 or float(np.linalg.norm(np.diff(world[:, :2], axis=0), axis=1).sum()) <= 0.0 \
            or not np.isfinite(world).all():
        raise SteeringError(f"the path '{ob.name}' needs two points apart at least, seen from above")
    return world


def spline_points(spline) -> np.ndarray:
    """(p, 3) local control points of ``spline`` (a beveled curve's line, before its tube)."""
    if spline.type == "BEZIER":
        return np.array([tuple(p.co) for p in spline.bezier_points], dtype=np.float64).reshape(-1, 3)
    return np.array([tuple(p.co)[:3] for p in spline.points], dtype=np.float64).reshape(-1, 3)


def check_path_near(path: np.ndarray, centre: np.ndarray, size: float, name: str) -> None:
    """SteeringError when the ``path``'s start lies further than ``FAR`` times the character's
    ``size`` from its ``centre`` (world), seen from above: the character would jump there."""
    gap = float(np.linalg.norm(path[0, :2] - centre[:2]))
    if gap > FAR * size:
        raise SteeringError(f"the path '{name}' starts {gap:.3g} units from the character (its size is "
                            f"{size:.3g}): move the curve's start under the character")


def ground_field(ob: bpy.types.Object | None, region: tuple[np.ndarray, np.ndarray], height: float,
                 character: set) -> tuple[tuple[float, float], float, np.ndarray]:
    """The heights of mesh ``ob`` (world) over the horizontal ``region`` (low and high corners),
    cast straight down from above it on a grid of ``CELL`` of the character's ``height`` (at most
    ``MOST_CELLS`` a side): ((x, y) of the first grid point, cell, heights (ny, nx)), NaN where
    the ray missed. SteeringError for an object that is not a mesh, one of the ``character``'s
    own objects, or a mesh with no face."""
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree

    if ob is None or ob.type != "MESH":
        raise SteeringError(f"the ground '{ob.name if ob else ''}' is not a mesh object")
    if ob in character:
        raise SteeringError(f"the ground '{ob.name}' is part of the character; pick the mesh it walks on")
    dg = bpy.context.evaluated_depsgraph_get()
    tree = BVHTree.FromObject(ob, dg)
    if not ob.evaluated_get(dg).data.polygons:
        raise SteeringError(f"the ground '{ob.name}' has no faces to stand on")
    low, high = (np.asarray(c, dtype=np.float64) for c in region)
    span = float(max(high[0] - low[0], high[1] - low[1]))
    cell = max(CELL * height, span / (MOST_CELLS - 1))
    nx = max(2, int(math.ceil((high[0] - low[0]) / cell)) + 1)
    ny = max(2, int(math.ceil((high[1] - low[1]) / cell)) + 1)
    m = ob.matrix_world
    inv = m.inverted_safe()
    corners = [m @ Vector(c) for c in ob.bound_box]
    top = max(c.z for c in corners) + 1e-3 * height
    depth = top - min(c.z for c in corners) + 2e-3 * height
    down = (inv.to_3x3() @ Vector((0.0, 0.0, -1.0)))
    reach = down.length * depth   # the ray's length in the object's space
    down.normalize()
    heights = np.full((ny, nx), np.nan)
    for j in range(ny):
        y = low[1] + j * cell
        for i in range(nx):
            hit = tree.ray_cast(inv @ Vector((low[0] + i * cell, y, top)), down, reach)[0]
            if hit is not None:
                heights[j, i] = (m @ hit).z
    return (float(low[0]), float(low[1])), float(cell), heights
