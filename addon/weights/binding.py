"""Auto Weights' Blender side: reading the meshes and bones to weight (in the armature's frame,
B-Bones along their rest curve, linked duplicates once, Weight Paint masks, subdivided cages on
their smooth surface) and writing the computed weights back as vertex groups, with an Armature
modifier and the armature as parent. The computing itself, without bpy, is in ``compute``."""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import bpy
import numpy as np

from ..common import native
from ..common.armatures import Bones, bbone_curves
from ..common.groups import BoneRows, write_vertex_groups
from ..common.meshes import mesh_polygons, mesh_triangles, mesh_world_vertices, paint_mask
from ..common.modifiers import (ensure_armature_modifier, idle_armature_modifiers, other_armature_modifiers,
                                smoothing_modifier)
from ..common.objects import parent_keep_transform
from ..common.reports import name_list
from ..common.transforms import to_armature_frame
from .compute import WeightsError


def find_meshes(context: bpy.types.Context) -> list[bpy.types.Object]:
    """Selected mesh objects; in Weight Paint mode the painted mesh even if not selected."""
    meshes = [ob for ob in context.selected_objects if ob.type == "MESH"]
    active = context.active_object
    if active is not None and active.type == "MESH" and active not in meshes:
        if context.mode == "PAINT_WEIGHT":
            meshes.append(active)
    return meshes


class Prepared(NamedTuple):
    """Everything read and checked before computing: the armature, its bones, the inputs
    [(mesh, name, vertices, triangles)], linked duplicates [(mesh, the mesh it shares data
    with)] and Weight Paint masks {mesh: ((n,) bool, mask name)}."""
    arm: bpy.types.Object
    bones: Bones
    inputs: list
    linked: list
    masks: dict


def read_inputs(arm: bpy.types.Object, meshes: list[bpy.types.Object], bones: Bones, heat: bool) -> Prepared:
    """Every input of the computation (``Prepared``), read from the checked ``arm``, ``meshes``
    and ``bones``; ``heat``: for the Heat method (B-Bone curves and triangles too). Vertices and
    bones are given in the armature's frame (``to_armature_frame``), not world. WeightsError,
    with the message for the status bar, when a mesh cannot be weighted."""
    if heat:  # B-Bones are weighted along their rest curve, as by Ctrl+P
        points, owners = bbone_curves(arm, bones.names)
        bones = dataclasses.replace(bones, curve_points=points, curve_bones=owners)
    # Every method works in the armature's frame, moved there in double precision: X
    # symmetry is about the armature's x = 0 (as for Fit), and the core's single precision
    # keeps a character 1e5 m from the world origin only 8 mm apart (which would change its weights).
    bones = dataclasses.replace(bones, heads=to_armature_frame(arm, bones.heads),
                                tails=to_armature_frame(arm, bones.tails),
                                curve_points=to_armature_frame(arm, bones.curve_points))
    inputs = []
    # Linked duplicates (Alt+D) share one mesh, and Blender keeps vertex weights in the
    # mesh: compute them once, on the first of those objects; the others get the modifier.
    owner, linked, masks = {}, [], {}
    for ob in meshes:
        if ob.data in owner:
            linked.append((ob, owner[ob.data]))
            continue
        owner[ob.data] = ob
        # Weight Paint with a selection mask re-weights the selected vertices only, as
        # Blender's Assign Automatic from Bones does; the whole mesh is still solved.
        picked, mask = paint_mask(ob)
        if picked is not None:
            if not picked.any():
                raise WeightsError(f"Weight Paint {mask} mask is on, but no vertex of '{ob.name}' "
                                   "is selected: select the vertices to re-weight, or turn the mask off; "
                                   "nothing was changed")
            masks[ob] = (picked, mask)
        verts = mesh_world_vertices(ob)
        bad = int((~np.isfinite(verts)).any(axis=1).sum())
        if bad:
            raise WeightsError(f"Mesh '{ob.name}' has {bad} vertices with NaN or infinite "
                               "coordinates; nothing was changed")
        verts = to_armature_frame(arm, verts)
        smoothing = smoothing_modifier(ob)
        if smoothing is not None:
            # A subdivided cage is weighted where its vertices lie on the smooth surface,
            # as Ctrl+P does (Catmull-Clark is affine: any frame is as good as its own).
            core = native.core()
            verts = core.catmull_clark_limit(
                verts, *mesh_polygons(ob),
                keep_corners=smoothing.boundary_smooth == "PRESERVE_CORNERS")
        tris = mesh_triangles(ob) if heat else None
        inputs.append((ob, ob.name, verts, tris))
    return Prepared(arm, bones, inputs, linked, masks)


def write_weights(prepared: Prepared, results, write: np.ndarray) -> tuple[list[str], list[str], set[str]]:
    """Write the groups of the bones where ``write`` ((b,) bool) from ``results`` [(mesh,
    indices, weights)], then give every mesh written (and each linked duplicate) an Armature
    modifier and the armature as parent. Main thread only. Returns (notes for the status bar,
    the Weight Paint masks that limited the writing, the names of locked groups kept)."""
    arm, bones, _, linked, masks = prepared
    notes, kept_locked, partial = [], set(), []
    for ob, i, w in results:
        rows = BoneRows(i, w, len(bones.names))
        picked, mask = masks.get(ob, (None, ""))
        kept_locked.update(write_vertex_groups(ob, bones.names, rows, write, only=picked))
        if picked is not None:
            partial.append(f"only the {int(picked.sum())} of {len(picked)} vertices of '{ob.name}' "
                           f"selected for the Weight Paint {mask} mask")
    written = [r[0] for r in results] + [ob for ob, _ in linked]
    loops = []
    for ob in written:
        ensure_armature_modifier(ob, arm)
        if not parent_keep_transform(ob, arm):
            loops.append(ob.name)
    if loops:
        notes.append(f"'{arm.name}' is a child of {name_list(loops)}, so they were not parented "
                     "to it (a loop); their Armature modifier deforms them all the same")
    for ob in written:
        idle = idle_armature_modifiers(ob, arm)
        if idle:
            notes.append(f"'{ob.name}': its Armature modifier {', '.join(idle)} for '{arm.name}' has Vertex "
                         "Groups off or is disabled, so the new weights do not deform it (turn them on in "
                         "the Modifier Properties)")
        others = other_armature_modifiers(ob, arm)
        if others:
            notes.append(f"'{ob.name}' also has Armature modifier(s) {', '.join(others)} for another "
                         "armature, left as they were: they deform it too (remove or disable them "
                         "if the mesh moves twice)")
    for ob, first in linked:
        notes.append(f"'{ob.name}' shares its mesh with '{first.name}': weights computed once, "
                     f"from '{first.name}'")
    return notes, partial, kept_locked
