"""Computing skin weights without touching Blender data: each mesh with the chosen method
(Heat, Voxel, Bilinear, IDW from the Rust core), meshes that meet along a seam solved as one
surface (Voxel: every mesh in one solid), many small seam groups solved together in one call to
the core, and a worker-thread job that the Auto Weights operator's modal loop watches (Esc
cancels it). Nothing here writes to Blender."""

from __future__ import annotations

import numpy as np

from ..common import native
from ..common.meshes import stack_meshes
from ..common.reports import name_list



def mesh_weights(core, settings: dict, verts, tris, bones, progress):
    """One mesh with the chosen method: (indices, weights, heat report or None). No bpy."""
    k = settings["k"]
    if settings["method"] == "IDW":
        i, w = core.idw_weights(verts, bones.heads, bones.tails, max_influences=k, power=settings["power"])
        return i, w, None
    if settings["method"] == "BILINEAR":
        i, w = core.bilinear_weights(
            verts, bones.heads, bones.tails, bones.parents, max_influences=k, nearest=settings["nearest"],
            falloff=settings["falloff"], sigma=settings["sigma"], power=settings["power"])
        return i, w, None
    if settings["method"] == "VOXEL":
        out = core.voxel_weights(verts, tris, bones.heads, bones.tails, progress=progress,
                                 resolution=settings["resolution"], falloff=settings["voxel_falloff"],
                                 objects=settings.get("objects"), **_rig_options(settings, bones))
    else:
        out = core.heat_weights_report(verts, tris, bones.heads, bones.tails, progress=progress,
                                       visibility=settings["visibility"], **_rig_options(settings, bones))
    return out.indices, out.weights, out.report


def _rig_options(settings: dict, bones) -> dict:
    """The keyword arguments Heat (``core.heat_weights_report``, ``core.heat_weights_many``) and
    Voxel (``core.voxel_weights``) share."""
    return dict(max_influences=settings["k"], bone_mirror=settings["mirror"], parents=settings["parents"],
                curve_points=bones.curve_points, curve_bones=bones.curve_bones)


def compute_weights(core, settings: dict, bones, inputs, progress):
    """Weights of every mesh, nothing written: (results [(mesh, indices, weights)], notes).
    No bpy calls (meshes are passed through untouched), so it may run on a worker thread.
    ``progress(f)`` gets the overall fraction and returns False to cancel (the core then
    raises ``Cancelled``). Other errors are raised as ``WeightsError`` for the status bar.

    Meshes that meet along a seam are solved together (``seam_groups``). Small groups next to
    each other (a figure kit-built of separate objects) go to the core together
    (``_solve_batch``); ``progress`` is called from this thread only, between calls."""
    results, notes = [], []
    if settings["method"] == "VOXEL":
        # One solid of every mesh: geodesic distances cross from one object into the next.
        members = list(range(len(inputs)))
        settings = dict(settings, objects=np.repeat(np.arange(len(inputs), dtype=np.uint32),
                                                    [len(v) for _, _, v, _ in inputs]))
        _gather(inputs, members, _solve_group(core, settings, bones, inputs, members, progress), settings,
                results, notes)
        return results, notes
    try:
        groups = seam_groups(core, inputs) if settings["method"] == "HEAT" else [[m] for m in range(len(inputs))]
    except (ValueError, RuntimeError) as err:
        raise WeightsError(f"Meshes {name_list([name for _, name, _, _ in inputs])}: {err}; "
                           "nothing was changed") from err
    sizes = [sum(len(inputs[m][2]) for m in members) for members in groups]
    if settings["method"] == "HEAT":
        refuse_past_memory(core, max(sizes), len(bones.heads), settings.get("memory_limit"))
    batched = settings["method"] == "HEAT" and len(groups) > 1
    g = 0
    while g < len(groups):
        if batched and sizes[g] <= BATCH_VERTICES:
            g = _solve_batch(core, settings, bones, inputs, groups, sizes, g, results, notes)
            if not progress(g / len(groups)):
                raise core.Cancelled("cancelled by the progress callback")
            continue

        def step(f, g=g):
            return progress((g + f) / len(groups))
        _gather(inputs, groups[g], _solve_group(core, settings, bones, inputs, groups[g], step), settings,
                results, notes)
        g += 1
    return results, notes


def machine_memory() -> int | None:
    """This computer's physical memory in bytes, or None where it cannot be read."""
    import os
    import sys

    if sys.platform == "win32":
        import ctypes

        class Status(ctypes.Structure):
            _fields_ = [("length", ctypes.c_ulong), ("load", ctypes.c_ulong), ("total", ctypes.c_ulonglong),
                        ("avail", ctypes.c_ulonglong), ("page_total", ctypes.c_ulonglong),
                        ("page_avail", ctypes.c_ulonglong), ("virtual_total", ctypes.c_ulonglong),
                        ("virtual_avail", ctypes.c_ulonglong), ("extended", ctypes.c_ulonglong)]
        status = Status(length=ctypes.sizeof(Status))
        return int(status.total) if ctypes.windll.kernel32.GlobalMemoryStatusEx(ctypes.byref(status)) else None
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None


# With no Memory Limit set, a Heat solve may take this share of the computer's memory.
MEMORY_SHARE = 0.75


def refuse_past_memory(core, vertices: int, bones: int, limit_gb: float | None):
    """Raise ``WeightsError`` (nothing computed) when a Heat solve's estimated peak
    (``core.heat_peak_bytes``) exceeds ``limit_gb`` (0 or None: ``MEMORY_SHARE`` of this
    computer's memory)."""
    need = core.heat_peak_bytes(vertices, bones)
    limit = limit_gb * 2**30 if limit_gb else MEMORY_SHARE * (machine_memory() or float("inf"))
    if need > limit:
        raise WeightsError(f"Heat on {vertices} vertices and {bones} bones needs about {_size(need)} of memory, "
                           f"over the limit of {_size(limit)}; nothing was changed (raise Memory Limit, "
                           "decimate the mesh, or use Nearest Bones)")


def _size(b: float) -> str:
    return f"{b / 2**30:.1f} GB" if b >= 2**30 else f"{b / 2**20:.1f} MB" if b >= 2**20 else f"{b / 2**10:.0f} KB"


# Heat solves seam groups of at most this many vertices each in calls of this many vertices in
# all to ``core.heat_weights_many`` (both cores busy, progress and Esc between calls): many
# small objects share a call instead of paying one call's overhead each.
BATCH_VERTICES = 20_000
CALL_VERTICES = 100_000


def _solve_group(core, settings: dict, bones, inputs, members: list[int], progress):
    """One seam group's meshes stacked and solved: (indices, weights, heat report or None)."""
    verts, tris = _stacked(inputs, members, settings)
    try:
        return mesh_weights(core, settings, verts, tris, bones, progress)
    except (ValueError, RuntimeError) as err:
        raise WeightsError(f"Mesh '{_group_name(inputs, members)}': {err}; nothing was changed") from err


def _stacked(inputs, members: list[int], settings: dict):
    """A seam group's vertices and (Heat and Voxel) triangles, its meshes one after the other."""
    if settings["method"] in ("HEAT", "VOXEL"):
        return stack_meshes((inputs[m][2], inputs[m][3]) for m in members)
    return np.concatenate([inputs[m][2] for m in members]), None


def _group_name(inputs, members: list[int]) -> str:
    return " + ".join(inputs[m][1] for m in members)


def _solve_batch(core, settings: dict, bones, inputs, groups: list[list[int]], sizes: list[int], start: int,
                 results: list, notes: list) -> int:
    """Heat of the small seam groups from ``start`` on (each at most ``BATCH_VERTICES``, up to
    ``CALL_VERTICES`` in all) in one ``core.heat_weights_many`` call, gathered as one group after
    the other would be; returns where the batch ended. A group's error names its mesh."""
    end, total = start, 0
    while end < len(groups) and sizes[end] <= BATCH_VERTICES and (end == start or total + sizes[end] <= CALL_VERTICES):
        total += sizes[end]
        end += 1
    solved = core.heat_weights_many([_stacked(inputs, members, settings) for members in groups[start:end]],
                                    bones.heads, bones.tails, visibility=settings["visibility"],
                                    **_rig_options(settings, bones))
    for members, out in zip(groups[start:end], solved):
        if isinstance(out, Exception):
            raise WeightsError(f"Mesh '{_group_name(inputs, members)}': {out}; nothing was changed") from out
        _gather(inputs, members, (out.indices, out.weights, out.report), settings, results, notes)
    return end


def _gather(inputs, members: list[int], solved, settings: dict, results: list, notes: list):
    """Append one group's per-mesh rows to ``results`` and its heat report's remarks to ``notes``."""
    i, w, report = solved
    name = _group_name(inputs, members)
    counts = [len(inputs[m][2]) for m in members]
    if report and (report.fallback_pieces or report.rigid_pieces or report.spanning_pieces):
        notes.append(f"{name}: of {report.pieces} pieces, "
                     f"{report.fallback_pieces} saw no bone (nearest bone used), "
                     f"{report.rigid_pieces} bound rigidly (no bone inside)"
                     + (f", {report.spanning_pieces} with no bone inside blended over the bones "
                        "they span" if report.spanning_pieces else ""))
    if report and report.flipped_faces:
        notes.append(f"{name}: {report.flipped_faces} triangles are wound against their neighbours "
                     "(flipped normals); the weights ignore that, the mesh is unchanged (Mesh > Normals "
                     "> Recalculate Outside fixes them)")
    if report and settings["mirror"] is not None and report.mirrored_vertices < 0.9 * sum(counts):
        notes.append(f"{name}: Symmetry X: only {report.mirrored_vertices / max(sum(counts), 1):.0%} of "
                     "the vertices have a mirror twin across the armature's X = 0 plane; the others "
                     "keep their own weights")
    paired, alone = (report.side_bones_paired, report.side_bones_unpaired) if report else (0, 0)
    if paired or alone:
        note = (f"Symmetry X: {paired + alone} bones off the X = 0 plane have no side in their names "
                f"(.L/.R, _L/_R, Left/Right): {paired} paired with their mirror image by place, {alone} "
                "without one keep their own weights")
        if note not in notes:  # the same for every mesh of the armature
            notes.append(note)
    if report and report.factorization_failed:
        notes.append(f"{name}: heat solve failed, nearest-bone weights used")
    ends = np.cumsum(counts)
    for m, end, n in zip(members, ends, counts):
        results.append((inputs[m][0], i[end - n:end], w[end - n:end]))


def seam_groups(core, inputs) -> list[list[int]]:
    """Indices of ``inputs`` grouped by the meshes that meet along a seam (shared vertex
    positions, ``core.touching_meshes``): Heat solves each group as one surface, so a head and
    a body split at the neck give their shared vertices one weight and do not crack when posed."""
    if len(inputs) < 2:
        return [[m] for m in range(len(inputs))]
    sizes = [len(v) for _, _, v, _ in inputs]
    mesh_of = np.repeat(np.arange(len(inputs), dtype=np.uint32), sizes)
    verts, tris = stack_meshes((v, t) for _, _, v, t in inputs)
    ids = core.touching_meshes(verts, mesh_of, len(inputs), triangles=tris)
    groups: dict[int, list[int]] = {}
    for m, g in enumerate(ids.tolist()):
        groups.setdefault(g, []).append(m)
    return list(groups.values())


# Meshes with at least this many vertices in total are computed on a worker thread when the
# operator is invoked from the UI: Esc cancels them.
BACKGROUND_VERTICES = 50_000


class WeightsError(Exception):
    """A mesh whose weights cannot be computed; the message is for the status bar."""


class WeightsJob:
    """Run ``compute(progress)`` on a worker thread. The core releases the GIL while it works,
    so Blender's UI keeps running; ``cancel()`` makes the next progress tick return False, which
    the core answers by stopping with ``Cancelled``. Afterwards exactly one of ``result``,
    ``error`` (a ``WeightsError``) or ``cancelled`` is set."""

    def __init__(self, compute):
        import threading

        self._compute = compute
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="miniskeleton-weights", daemon=True)
        self.fraction = 0.0
        self.result = None
        self.error = None
        self.cancelled = False

    def _progress(self, f: float) -> bool:
        self.fraction = float(f)
        return not self._stop.is_set()

    def _run(self):
        core = native.core()
        try:
            self.result = self._compute(self._progress)
        except core.Cancelled:
            self.cancelled = True
        except WeightsError as err:
            self.error = err
        except Exception as err:  # never leave the modal loop waiting on a dead job
            self.error = WeightsError(f"Auto Weights failed: {err}; nothing was changed")

    def start(self):
        self._thread.start()

    def cancel(self):
        self._stop.set()

    def running(self) -> bool:
        return self._thread.is_alive()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the job ends (or ``timeout``); True if it ended."""
        self._thread.join(timeout)
        return not self._thread.is_alive()
