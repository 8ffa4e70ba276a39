"""The rig exchange formats, no UI: the NPZ bundle (mesh, skeleton and weights) written and read
back, and the debug JSON (joints, bone edges, per-bone weight statistics).

NPZ bundle (``FORMAT_VERSION`` 1), what RigNet-style learning pipelines read:
  format_version ()  int32
  vertices       (n, 3) float32  world space, the meshes concatenated in ``mesh_names`` order
  triangles      (m, 3) int32    into ``vertices``
  mesh_names     (p,)   str;  mesh_vertex_counts (p,) int32
  armature_name  ()     str
  bone_names     (b,)   str   every bone of the armature, in Blender's order
  heads, tails   (b, 3) float32 world space (rest pose)
  parents        (b,)   int32  index into bone_names, -1 for roots
  indices        (n, k) int32  top-k bones per vertex (-1 = unused slot)
  weights        (n, k) float32 raw vertex-group weights (not renormalized unless k was capped)
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import bpy
import numpy as np

from ..common.files import ArraySpec, FileReadError, make_folder, read_npz
from ..common.groups import BoneRows, read_weights, write_vertex_groups
from ..common.meshes import mesh_triangles, mesh_world_vertices, stack_meshes
from ..common.reports import name_list
from .joints import joint_graph

FORMAT_VERSION = 1


class RigError(ValueError):
    """A rig file or scene that cannot be used, with a message for the status bar."""


def world_bones(arm_ob):
    """Every bone of ``arm_ob`` (rest pose, world space): names, heads (b,3), tails (b,3), parents (b,)."""
    m = np.array(arm_ob.matrix_world, dtype=np.float64)
    bones = list(arm_ob.data.bones)
    names = [b.name for b in bones]
    index = {n: i for i, n in enumerate(names)}
    h = np.array([b.head_local for b in bones], dtype=np.float64).reshape(-1, 3)
    t = np.array([b.tail_local for b in bones], dtype=np.float64).reshape(-1, 3)
    h = h @ m[:3, :3].T + m[:3, 3]
    t = t @ m[:3, :3].T + m[:3, 3]
    parents = np.array([index[b.parent.name] if b.parent else -1 for b in bones], dtype=np.int32)
    connected = [bool(b.use_connect) for b in bones]
    return names, h, t, parents, connected


def top_k(vertex: np.ndarray, bone: np.ndarray, weight: np.ndarray, n: int,
          max_influences: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Weights as (vertex, bone, weight) entries (``read_weights``) to dense (n, k) indices int32
    / weights float32, strongest first (equal weights in stored order). k = the most weights a
    vertex has when ``max_influences`` is 0; else capped and renormalized."""
    counts = np.bincount(vertex, minlength=n)
    k = int(counts.max(initial=0))
    capped = 0 < max_influences < k
    if capped:
        k = max_influences
    k = max(k, 1)
    order = np.lexsort((np.arange(len(vertex)), -weight.astype(np.float64), vertex))
    vertex, bone, weight = vertex[order], bone[order], weight[order]
    rank = np.arange(len(vertex)) - np.repeat(np.cumsum(counts) - counts, counts)
    kept = rank < k
    idx = np.full((n, k), -1, dtype=np.int32)
    w = np.zeros((n, k), dtype=np.float64)
    idx[vertex[kept], rank[kept]] = bone[kept]
    w[vertex[kept], rank[kept]] = weight[kept]
    if capped:
        total = np.zeros(n)
        for slot in range(k):        # summed slot by slot, strongest first
            total += w[:, slot]
        w = np.divide(w, total[:, None], out=w, where=total[:, None] > 0)
    return idx, w.astype(np.float32)


def collect_rig(arm_ob, meshes, max_influences: int = 0) -> dict:
    """Everything the NPZ bundle holds, as numpy arrays (see the module doc)."""
    if not meshes:
        raise RigError("no mesh: select the skinned meshes (or bind some to the armature)")
    if len(arm_ob.data.bones) == 0:
        raise RigError(f"armature '{arm_ob.name}' has no bones")
    names, h, t, parents, _ = world_bones(arm_ob)
    verts, tris = stack_meshes((mesh_world_vertices(ob), mesh_triangles(ob)) for ob in meshes)
    counts = [len(ob.data.vertices) for ob in meshes]
    read = [read_weights(ob, names) for ob in meshes]
    starts = np.cumsum([0] + counts[:-1])
    vertex = np.concatenate([r[0] + start for r, start in zip(read, starts)])
    idx, w = top_k(vertex, np.concatenate([r[1] for r in read]), np.concatenate([r[2] for r in read]),
                   sum(counts), max_influences)
    return {
        "format_version": np.int32(FORMAT_VERSION),
        "vertices": verts.astype(np.float32),
        "triangles": tris.astype(np.int32),
        "mesh_names": np.array([ob.name for ob in meshes], dtype=str),
        "mesh_vertex_counts": np.array(counts, dtype=np.int32),
        "armature_name": np.array(arm_ob.name, dtype=str),
        "bone_names": np.array(names, dtype=str),
        "heads": h.astype(np.float32),
        "tails": t.astype(np.float32),
        "parents": parents,
        "indices": idx,
        "weights": w,
    }


def output_path(filepath: str, ext: str) -> Path:
    """Where an export writes: ``filepath`` made absolute (``//`` is the .blend's folder), with
    ``ext`` added when it has another or none (as Blender's file browser does), its folder made.
    RigError when no file name is given or the folder cannot be made."""
    if not filepath.strip():
        raise RigError("no file name given")
    path = Path(bpy.path.abspath(filepath))
    try:
        folder = path.is_dir()
    except OSError as err:   # a name the file system refuses (too long)
        raise RigError(f"cannot write '{path}': {err.strerror or err}") from err
    if folder or filepath.endswith(("/", "\\")):
        raise RigError(f"'{path}' is a folder: give a file name")
    if path.suffix.lower() != ext:
        path = path.with_name(path.name + ext)
    why = make_folder(path)
    if why is not None:
        raise RigError(f"cannot write '{path}': {why}")
    return path


def save_npz(path: Path, rig: dict) -> None:
    """Write the bundle (compressed); RigError when the file cannot be written. Written through
    an open file: given a name, numpy adds ".npz" to one that does not end in lower-case
    ".npz", and "rig.NPZ" became "rig.NPZ.npz"."""
    try:
        with open(path, "wb") as fh:
            np.savez_compressed(fh, **rig)
    except OSError as err:
        raise RigError(f"cannot write '{path}': {err.strerror or err}") from err


def save_json(path: Path, data: dict) -> None:
    """Write the debug JSON ``data`` (``rig_json``); RigError when the file cannot be written."""
    try:
        with open(path, "w", encoding="utf-8") as f:
            json.dump(data, f, indent=1)
    except OSError as err:
        raise RigError(f"cannot write '{path}': {err.strerror or err}") from err


# What the import reads, checked on each array's header before any data is read.
_BUNDLE_ARRAYS = {
    "format_version": ArraySpec(0, None, "iu", "one integer"),
    "vertices": ArraySpec(2, 3, "fiu", "numbers (n, 3)"),
    "bone_names": ArraySpec(1, None, "US", "a 1-D array of strings"),
    "indices": ArraySpec(2, None, "iu", "integers (n, k)"),
    "weights": ArraySpec(2, None, "f", "floats (n, k)"),
    "mesh_names": ArraySpec(1, None, "US", "a 1-D array of strings"),
    "mesh_vertex_counts": ArraySpec(1, None, "iu", "a 1-D array of integers"),
}
_BUNDLE_REQUIRED = ("format_version", "vertices", "bone_names", "indices", "weights")


def load_npz(filepath: str) -> dict:
    """Read and check a bundle; RigError naming the file and the reason. The file is read by
    ``read_npz`` (zip, headers and sizes checked before any data, every array's shape and type
    checked, every read error an error); then its content is checked: shapes that agree, weights
    finite in [0, 1], indices in range, bone names usable as vertex groups. Byte-string names
    are decoded as UTF-8."""
    if not filepath.strip():
        raise RigError("no file given")
    path = Path(bpy.path.abspath(filepath))
    try:
        rig = read_npz(path, "rig bundle", _BUNDLE_ARRAYS, _BUNDLE_REQUIRED)
    except FileReadError as err:
        raise RigError(str(err)) from err
    try:
        _check_bundle(rig)
    except RigError as err:
        raise RigError(f"rig bundle '{path}' cannot be used: {err}") from err
    return rig


def _check_bundle(rig: dict) -> None:
    """The content of a bundle whose arrays have the shapes and types of ``_BUNDLE_ARRAYS``:
    RigError with the reason (names are decoded in place)."""
    version = int(rig["format_version"])
    if version > FORMAT_VERSION:
        raise RigError(f"rig bundle format {version} is newer than this add-on ({FORMAT_VERSION})")
    for key in ("bone_names", "mesh_names"):
        if key in rig:
            rig[key] = _names(rig[key], key)
    n = len(rig["vertices"])
    idx, w = rig["indices"], rig["weights"]
    if idx.shape != w.shape or len(idx) != n:
        raise RigError(f"indices {idx.shape} / weights {w.shape} do not match {n} vertices")
    b = len(rig["bone_names"])
    if idx.size and (idx.max() >= b or idx.min() < -1):
        raise RigError(f"indices refer to bones that are not in bone_names (0..{b - 1}, -1 = unused)")
    bad = int(np.count_nonzero(~((w >= 0) & (w <= 1))))   # NaN fails both
    if bad:
        raise RigError(f"{bad} weights are not numbers in [0, 1]; nothing was changed")
    names = [str(s) for s in rig["bone_names"]]
    unusable = [s for s in names if not s or len(s.encode("utf-8")) > 63]
    if unusable:
        raise RigError(f"bone names must be 1 to 63 bytes (Blender's limit): {unusable[0][:70]!r}")
    twice = sorted(s for s, count in Counter(names).items() if count > 1)
    if twice:
        raise RigError(f"bone names appear twice: {name_list(twice)}")
    if "mesh_names" in rig or "mesh_vertex_counts" in rig:
        counts = rig.get("mesh_vertex_counts", np.zeros(0, np.int32))
        if (len(rig.get("mesh_names", ())) != len(counts) or (counts < 0).any()
                or sum(int(c) for c in counts) != n):
            raise RigError(f"mesh_names / mesh_vertex_counts do not split the {n} vertices")


def _names(arr: np.ndarray, key: str) -> np.ndarray:
    """A 1-D array of names (``_BUNDLE_ARRAYS``; ``read_npz`` has checked that str ones are
    Unicode) as str, bytes decoded as UTF-8; none may hold a NUL (Blender's names end there)."""
    if arr.dtype.kind == "S":
        try:
            arr = np.array([s.decode("utf-8") for s in arr.tolist()], dtype=str)
        except UnicodeDecodeError as err:
            raise RigError(f"{key} are not UTF-8: {err}") from err
    if any("\0" in s for s in arr.tolist()):
        raise RigError(f"{key} hold a NUL character")
    return arr


def apply_weights(rig: dict, meshes) -> int:
    """Write the bundle's weights as bone-named vertex groups. One mesh takes all vertices; several
    meshes are matched by the stored mesh names. Vertex counts must agree (RigError otherwise).
    Returns the number of vertices written."""
    if not meshes:
        raise RigError("no mesh selected to receive the weights")
    n = len(rig["vertices"])
    names = [str(s) for s in rig["bone_names"]]
    if len(meshes) == 1:
        targets = [(meshes[0], 0, n)]
    else:
        stored = [str(s) for s in rig.get("mesh_names", [])]
        counts = [int(c) for c in rig.get("mesh_vertex_counts", [])]
        starts = np.concatenate([[0], np.cumsum(counts)]).astype(int)
        by_name = {ob.name: ob for ob in meshes}
        targets = [(by_name[s], starts[i], counts[i]) for i, s in enumerate(stored) if s in by_name]
        if not targets:
            raise RigError(f"none of the selected meshes is named like the bundle's ({', '.join(stored)})")
    for ob, _, count in targets:
        if len(ob.data.vertices) != count:
            raise RigError(f"vertex count mismatch: the bundle has {count} vertices for this mesh, "
                           f"'{ob.name}' has {len(ob.data.vertices)}; nothing was changed")
    for ob, start, count in targets:
        idx = rig["indices"][start:start + count]
        w = rig["weights"][start:start + count]
        rows = BoneRows(idx, w, len(names))
        # The bundle's bones with weights here, and the mesh's groups of its other bones (emptied,
        # so the weights are the bundle's exactly; no empty group is added for the rest).
        write = (rows.counts() > 0) | np.array([ob.vertex_groups.get(s) is not None for s in names])
        write_vertex_groups(ob, names, rows, write)
    return sum(t[2] for t in targets)


def rig_json(arm_ob, meshes) -> dict:
    """Debug view of a rig: world-space joints, bone edges and per-bone weight statistics."""
    names, h, t, parents, connected = world_bones(arm_ob)
    size = max(float(np.linalg.norm(np.ptp(np.concatenate([h, t]), axis=0))) if len(h) else 0.0, 1e-30)
    joints, ends = joint_graph(h, t, list(parents), connected, 1e-6 * size)
    count = np.zeros(len(names), dtype=np.int64)
    wmax = np.zeros(len(names), dtype=np.float64)
    for ob in meshes:
        _, bone, weight = read_weights(ob, names)
        count += np.bincount(bone, minlength=len(names))
        np.maximum.at(wmax, bone, weight.astype(np.float64))
    return {
        "format": "miniskeleton-rig-debug",
        "version": FORMAT_VERSION,
        "armature": arm_ob.name,
        "meshes": [ob.name for ob in meshes],
        "vertex_count": int(sum(len(ob.data.vertices) for ob in meshes)),
        "joints": joints.tolist(),
        "bone_edges": ends.tolist(),
        "bones": [
            {"name": n, "parent": names[p] if p >= 0 else None, "head": h[i].tolist(), "tail": t[i].tolist(),
             "joints": ends[i].tolist(), "deform": bool(arm_ob.data.bones[n].use_deform),
             "vertices_influenced": int(count[i]), "max_weight": float(wmax[i])}
            for i, (n, p) in enumerate(zip(names, parents))
        ],
    }
