"""Vertex groups: the bone weights in them read as arrays, and written from top-k weights,
keeping what the user made.

Weights are written one of two ways, whichever is cheaper for the object
(``write_vertex_groups``): a float point attribute converted to a vertex group by Blender's own
C code (``geometry.attribute_convert``, which does the per-vertex work that a bmesh loop would
do in Python), or ``VertexGroup.add`` calls for small meshes in scenes of many objects, where
every operator call's depsgraph rebuild would dominate. Neither stores zero weights. Groups of
other bones and locked groups are left alone, and the list keeps its order.
"""

from __future__ import annotations

from itertools import chain

import bmesh
import bpy
import numpy as np

from .objects import viewport_hidden

_TMP_ATTR = "__miniskeleton_weights_tmp"


def read_weights(ob, bone_names: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every weight > 0 in ``ob``'s bone-named groups: (vertex int64, bone int32, weight float32)
    arrays, vertex by vertex, each vertex's weights in the order Blender stores them. Read through
    a BMesh's deform layer, one call per vertex rather than one per weight (as reading
    ``MeshVertex.groups`` takes)."""
    index = {n: i for i, n in enumerate(bone_names)}
    bone_of = np.full(len(ob.vertex_groups), -1, dtype=np.int64)
    for g in ob.vertex_groups:
        bone_of[g.index] = index.get(g.name, -1)
    empty = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int32), np.zeros(0, dtype=np.float32))
    if not (bone_of >= 0).any():
        return empty
    bm = bmesh.new()
    try:
        bm.from_mesh(ob.data)
        layer = bm.verts.layers.deform.active
        rows = [v[layer].items() for v in bm.verts] if layer is not None else []
    finally:
        bm.free()
    counts = np.fromiter(map(len, rows), dtype=np.int64, count=len(rows))
    pairs = np.fromiter(chain.from_iterable(chain.from_iterable(rows)), dtype=np.float64,
                        count=2 * int(counts.sum())).reshape(-1, 2)
    vertex = np.repeat(np.arange(len(rows), dtype=np.int64), counts)
    group, weight = pairs[:, 0].astype(np.int64), pairs[:, 1].astype(np.float32)
    bone = np.where(group < len(bone_of), bone_of[np.minimum(group, len(bone_of) - 1)], -1)
    keep = (bone >= 0) & (weight > 0)
    return vertex[keep], bone[keep].astype(np.int32), weight[keep]


class BoneRows:
    """Top-k weights (``indices``, ``weights`` (n, k), -1 / 0 for unused slots) read bone by bone:
    each bone's vertices (ascending) and weights from one sort of the rows, never a dense
    (bones, n) matrix (1M vertices and 1000 bones would take 4 GB)."""

    def __init__(self, indices: np.ndarray, weights: np.ndarray, bones: int):
        self.n = indices.shape[0]
        verts, slots = np.nonzero((indices >= 0) & (weights > 0))
        bone = indices[verts, slots]
        order = np.argsort(bone, kind="stable")   # vertices stay ascending within a bone
        self.verts = verts[order]
        self.values = weights[verts, slots][order].astype(np.float32)
        self.start = np.searchsorted(bone[order], np.arange(bones + 1))

    def counts(self) -> np.ndarray:
        """(bones,) how many vertices each bone weights."""
        return np.diff(self.start)

    def entries(self, b: int) -> tuple[np.ndarray, np.ndarray]:
        """Bone ``b``'s vertices (ascending) and their weights."""
        return self.verts[self.start[b]:self.start[b + 1]], self.values[self.start[b]:self.start[b + 1]]


# The cost model that picks the cheaper way, in seconds: an operator call's fixed cost, its
# rebuild of the depsgraph's relations per object in the view layer and its conversion per
# vertex; one ``VertexGroup.add`` call.
_OP_CALL_S, _OP_PER_OBJECT_S, _OP_PER_VERTEX_S, _ADD_CALL_S = 1e-4, 1.5e-5, 7.5e-9, 1e-6


def write_vertex_groups(ob: bpy.types.Object, names: list[str], rows: BoneRows,
                        write: np.ndarray, only: np.ndarray | None = None) -> list[str]:
    """Replace the vertex groups named ``names[b]`` where ``write[b]`` with bone ``b``'s weights
    in ``rows``; with ``only`` ((n,) bool, a Weight Paint mask), only those vertices' weights.

    Groups not named after a written bone are untouched; locked groups are left as they are.
    As after Blender's Ctrl+P, the last group written ends active and a rewritten group keeps
    its place in the list; the mesh keeps its active attribute and its selection. Returns the
    names of locked groups that were kept. Both ways give the same groups; the cheaper one for
    this mesh and scene is used (one operator call per group costs a relations rebuild that
    grows with the scene, so many small meshes are written by ``add`` calls).
    """
    order = [g.name for g in ob.vertex_groups]
    held = {b: _locked(ob, names[b]) for b in np.flatnonzero(write)}
    groups = [b for b, is_locked in held.items() if not is_locked]
    locked = [names[b] for b, is_locked in held.items() if is_locked]
    calls = int(rows.counts()[groups].sum())
    per_op = _OP_CALL_S + _OP_PER_OBJECT_S * len(bpy.context.view_layer.objects) + _OP_PER_VERTEX_S * rows.n
    if only is not None:
        _patch_groups(ob, names, rows, groups, only)
    elif calls * _ADD_CALL_S < len(groups) * per_op:
        _add_groups(ob, names, rows, groups)
    else:
        _convert_hidden(ob, names, rows, groups)
    _keep_order(ob, order)
    last = ob.vertex_groups.get(names[groups[-1]]) if groups else None
    if last is not None:
        ob.vertex_groups.active_index = last.index
    return locked


def _keep_order(ob, order):
    """Put ``ob``'s groups back in the list ``order`` (their names before writing; new groups
    follow in the order made), as Blender's Ctrl+P, which rewrites a group in its place, leaves
    them. Rewriting makes a group anew at the end; one Sort by Name over temporary names that
    sort in the wanted order moves them back (one remap of the weights, where moving each
    group up one step at a time remaps them once per step)."""
    groups = ob.vertex_groups
    index = {name: i for i, name in enumerate(order)}
    now = [g.name for g in groups]
    target = sorted(now, key=lambda name: index.get(name, len(order)))  # stable: new ones as made
    if now == target:
        return
    tag = "miniskeleton_order_"
    while any(name.startswith(tag) for name in now):
        tag += "_"
    rank = {name: k for k, name in enumerate(target)}
    for g in list(groups):
        g.name = f"{tag}{rank[g.name]:06d}"
    try:
        # Blender sorts no group of an object hidden from viewports.
        with viewport_hidden(ob, False), bpy.context.temp_override(object=ob, active_object=ob):
            bpy.ops.object.vertex_group_sort(sort_type="NAME")
    finally:
        for g in list(groups):
            g.name = target[int(g.name[len(tag):])]


def _convert_hidden(ob, names, rows: BoneRows, groups):
    """``_convert_groups`` with ``ob`` hidden from viewports, keeping the active attribute."""
    # Each bpy.ops call updates the view layer before and after it, which re-evaluates a visible
    # mesh every time; hidden from viewports it is not evaluated at all.
    attrs = ob.data.attributes
    active = attrs.active.name if attrs.active is not None else None
    try:
        with viewport_hidden(ob, True):
            _convert_groups(ob, names, rows, groups)
    finally:
        attrs.active = attrs.get(active) if active is not None else None


def _locked(ob, name) -> bool:
    group = ob.vertex_groups.get(name)
    return group is not None and group.lock_weight


def _replace_group(ob, name):
    """Remove ``ob``'s unlocked group ``name`` if there is one (it is written anew)."""
    old = ob.vertex_groups.get(name)
    if old is not None:
        ob.vertex_groups.remove(old)


def _add_groups(ob, names, rows: BoneRows, groups):
    """One ``VertexGroup.add`` per distinct weight of each group (a rigid part: one call)."""
    made = []
    for b in groups:
        _replace_group(ob, names[b])
        made.append(ob.vertex_groups.new(name=names[b]))
    _add_runs(made, [rows.entries(b) for b in groups])


def _patch_groups(ob, names, rows: BoneRows, groups, only):
    """Rewrite the masked vertices only: each group loses them, then gets their new weights
    (one ``add`` per distinct weight); every other vertex keeps its weights exactly."""
    listed = np.flatnonzero(only).tolist()
    made = []
    for b in groups:
        group = ob.vertex_groups.get(names[b]) or ob.vertex_groups.new(name=names[b])
        group.remove(listed)
        made.append(group)
    entries = [rows.entries(b) for b in groups]
    _add_runs(made, [(v[only[v]], w[only[v]]) for v, w in entries])


def _add_runs(made, entries):
    """Add ``entries[g]`` ((vertices, weights) of one bone) to group ``made[g]``, one ``add``
    call per run of vertices with the same weight."""
    if not entries:
        return
    member = np.repeat(np.arange(len(entries)), [len(v) for v, _ in entries])
    verts = np.concatenate([v for v, _ in entries])
    values = np.concatenate([w for _, w in entries])
    order = np.lexsort((values, member))  # by group, then by weight (then vertex)
    member, verts, values = member[order], verts[order], values[order]
    if len(verts) == 0:
        return
    cuts = (np.flatnonzero((np.diff(member) != 0) | (np.diff(values) != 0)) + 1).tolist()
    starts, verts = [0] + cuts, verts.tolist()
    for start, end, g, w in zip(starts, cuts + [len(verts)], member[starts].tolist(), values[starts].tolist()):
        made[g].add(verts[start:end], w, "REPLACE")


def _convert_groups(ob, names, rows: BoneRows, groups):
    me = ob.data
    row = np.zeros(rows.n, dtype=np.float32)
    with bpy.context.temp_override(object=ob, active_object=ob):
        for b in groups:
            _replace_group(ob, names[b])
            attr = me.attributes.get(_TMP_ATTR) or me.attributes.new(_TMP_ATTR, "FLOAT", "POINT")
            verts, values = rows.entries(b)
            row[verts] = values
            attr.data.foreach_set("value", row)
            row[verts] = 0.0
            me.attributes.active = attr
            bpy.ops.geometry.attribute_convert(mode="VERTEX_GROUP")
            group = ob.vertex_groups.get(_TMP_ATTR)
            group.name = names[b]
