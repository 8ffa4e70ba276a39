"""Transfer Weights: the active skinned body's weights copied onto the selected garments
(Abdrashitov et al. 2023, ``core.transfer_weights``), read and decided here, written by
``binding.write_weights`` as Auto Weights writes.

A selected mesh that is not worn over the body is not transferred onto: one whose vertices lie
on the body nowhere (within Max Distance and Max Angle), and one that holds no bone and lies on
the body along less than half of its vertices (a prop held in a hand, a hat above the head) are
bound directly with Auto Weights (Heat), as if alone, and the report says so. Transferred onto
such a mesh, the weights of the few vertices that touch the body (fingers around a carrot)
spread over the whole of it."""

from __future__ import annotations

import numpy as np

from ..common.groups import read_weights
from ..common.meshes import mesh_triangles, mesh_world_vertices
from ..common.transforms import to_armature_frame
from .compute import WeightsError, mesh_weights

# Body weights read per vertex: the strongest this many bones.
BODY_INFLUENCES = 8
# A mesh that holds no bone and lies on the body along less than this share of its vertices is
# a prop, bound directly.
WORN_SHARE = 0.5


def body_rows(body, arm, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """The body's weights in the bones ``names`` as top-k rows (indices int32, weights float32,
    (n, BODY_INFLUENCES)), each row normalized; WeightsError when no vertex is weighted."""
    vertex, bone, weight = read_weights(body, names)
    n = len(body.data.vertices)
    if len(vertex) == 0:
        raise WeightsError(f"The body '{body.name}' has no weights in the bones of '{arm.name}': "
                           "weight it first (Auto Weights), then transfer; nothing was changed")
    dense = np.zeros((n, len(names)), dtype=np.float32)
    np.add.at(dense, (vertex, bone), weight)
    order = np.argsort(-dense, axis=1)[:, :BODY_INFLUENCES]
    w = np.take_along_axis(dense, order, axis=1)
    total = w.sum(axis=1, keepdims=True)
    w = np.divide(w, total, out=np.zeros_like(w), where=total > 0)
    return np.where(w > 0, order, -1).astype(np.int32), w


def read_mesh(arm, ob) -> tuple[np.ndarray, np.ndarray]:
    """``ob``'s vertices in the armature's frame and its triangles; WeightsError on NaN."""
    verts = mesh_world_vertices(ob)
    bad = int((~np.isfinite(verts)).any(axis=1).sum())
    if bad:
        raise WeightsError(f"Mesh '{ob.name}' has {bad} vertices with NaN or infinite coordinates; "
                           "nothing was changed")
    return to_armature_frame(arm, verts), mesh_triangles(ob)


def holds_bone(core, verts, tris, bones) -> bool:
    """Does some bone lie inside the mesh (3 of the 5 points along it: ends and quarters)?"""
    if len(tris) == 0:
        return False
    s = np.linspace(0.0, 1.0, 5)[None, :, None]
    points = (bones.heads[:, None, :] + s * (bones.tails - bones.heads)[:, None, :]).reshape(-1, 3)
    inside = core.points_inside(verts, tris, points).reshape(len(bones.heads), 5)
    return bool((inside.sum(axis=1) >= 3).any())


def transfer(core, body_mesh, body_weights, garments, bones, settings: dict):
    """Weights of every garment: (results [(mesh, indices, weights)], notes). ``body_mesh``
    (vertices, triangles), ``body_weights`` (indices, weights) from ``body_rows``; ``garments``
    [(mesh, name, vertices, triangles)] as Auto Weights reads them; ``settings``: max_distance,
    max_angle, k. No bpy calls."""
    results, notes = [], []
    direct = dict(method="HEAT", k=settings["k"], visibility=True, mirror=None, parents=settings["parents"])
    for ob, name, verts, tris in garments:
        try:
            out = core.transfer_weights(*body_mesh, *body_weights, verts, tris,
                                        max_distance=settings["max_distance"],
                                        max_angle=settings["max_angle"], max_influences=settings["k"])
        except (ValueError, RuntimeError) as err:
            raise WeightsError(f"Mesh '{name}': {err}; nothing was changed") from err
        i, w, report = out.indices, out.weights, out.report
        worn = report.matched / max(len(verts), 1)
        why = None
        if report.matched == 0:
            why = "no vertex of it lies on the body"
        elif worn < WORN_SHARE and not holds_bone(core, verts, tris, bones):
            why = f"it holds no bone and only {worn:.0%} of it lies on the body (a prop)"
        if why is not None:
            i, w, _ = mesh_weights(core, direct, verts, tris, bones, lambda f: True)
            notes.append(f"'{name}': {why}, so it was bound directly with Auto Weights (Heat)")
        else:
            notes.append(f"'{name}': {report.matched} vertices took the body's weights, "
                         f"{report.inpainted} were inpainted")
        results.append((ob, i, w))
    return results, notes
