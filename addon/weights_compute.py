"""Computing skin weights without touching Blender data: each mesh with the chosen method
(Heat, Bilinear, IDW from the Rust core), meshes that meet along a seam solved as one surface,
many small seam groups on a pool of threads, and a worker-thread job that the Auto Weights
operator's modal loop watches (Esc cancels it). Nothing here writes to Blender."""

from __future__ import annotations

import concurrent.futures
import os

import numpy as np

from . import mesh_io


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
    return core.heat_weights_report(
        verts, tris, bones.heads, bones.tails, max_influences=k, visibility=settings["visibility"],
        bone_mirror=settings["mirror"], parents=settings["parents"],
        curve_points=bones.curve_points, curve_bones=bones.curve_bones, progress=progress)


def compute_weights(core, settings: dict, bones, inputs, progress):
    """Weights of every mesh, nothing written: (results [(mesh, indices, weights)], notes).
    No bpy calls (meshes are passed through untouched), so it may run on a worker thread.
    ``progress(f)`` gets the overall fraction and returns False to cancel (the core then
    raises ``Cancelled``). Other errors are raised as ``WeightsError`` for the status bar.

    Meshes that meet along a seam are solved together (``seam_groups``). Many small groups (a
    figure kit-built of separate objects) are solved on a pool of threads, since the core
    releases the GIL and a small solve uses one core; ``progress`` is then called from this
    thread only, between groups."""
    results, notes = [], []
    try:
        groups = seam_groups(core, inputs) if settings["method"] == "HEAT" else [[m] for m in range(len(inputs))]
    except (ValueError, RuntimeError) as err:
        raise WeightsError(f"Meshes {mesh_io.name_list([name for _, name, _, _ in inputs])}: {err}; "
                           "nothing was changed") from err
    sizes = [sum(len(inputs[m][2]) for m in members) for members in groups]
    threads = min(POOL_THREADS, len(groups))
    if threads > 1 and max(sizes) <= POOL_VERTICES:
        with concurrent.futures.ThreadPoolExecutor(threads) as pool:
            solving = [pool.submit(_solve_group, core, settings, bones, inputs, members, None)
                       for members in groups]
            try:
                for g, job in enumerate(solving):
                    _gather(inputs, groups[g], job.result(), settings, results, notes)
                    if not progress((g + 1) / len(groups)):
                        raise core.Cancelled("cancelled by the progress callback")
            finally:
                for job in solving:
                    job.cancel()
        return results, notes
    for g, members in enumerate(groups):
        def step(f, g=g):
            return progress((g + f) / len(groups))
        _gather(inputs, members, _solve_group(core, settings, bones, inputs, members, step), settings,
                results, notes)
    return results, notes


# Seam groups of at most this many vertices each go to a pool of this many threads when there
# are several (400 objects of 74 vertices on 2 cores: 0.53 s serial, 0.42 s pooled).
POOL_VERTICES = 20_000
POOL_THREADS = os.cpu_count() or 1


def _solve_group(core, settings: dict, bones, inputs, members: list[int], progress):
    """One seam group's meshes stacked and solved: (indices, weights, heat report or None)."""
    name = " + ".join(inputs[m][1] for m in members)
    if settings["method"] == "HEAT":
        verts, tris = mesh_io.stack_meshes((inputs[m][2], inputs[m][3]) for m in members)
    else:
        verts, tris = np.concatenate([inputs[m][2] for m in members]), None
    try:
        return mesh_weights(core, settings, verts, tris, bones, progress)
    except (ValueError, RuntimeError) as err:
        raise WeightsError(f"Mesh '{name}': {err}; nothing was changed") from err


def _gather(inputs, members: list[int], solved, settings: dict, results: list, notes: list):
    """Append one group's per-mesh rows to ``results`` and its heat report's remarks to ``notes``."""
    i, w, report = solved
    name = " + ".join(inputs[m][1] for m in members)
    counts = [len(inputs[m][2]) for m in members]
    if report and (report.get("fallback_pieces") or report.get("rigid_pieces")):
        notes.append(f"{name}: of {report['pieces']} pieces, "
                     f"{report['fallback_pieces']} saw no bone (nearest bone used), "
                     f"{report['rigid_pieces']} bound rigidly (no bone inside)")
    if report and report.get("flipped_faces"):
        notes.append(f"{name}: {report['flipped_faces']} triangles are wound against their neighbours "
                     "(flipped normals); the weights ignore that, the mesh is unchanged (Mesh > Normals "
                     "> Recalculate Outside fixes them)")
    if report and settings["mirror"] is not None and report["mirrored_vertices"] < 0.9 * sum(counts):
        notes.append(f"{name}: Symmetry X: only {report['mirrored_vertices'] / max(sum(counts), 1):.0%} of "
                     "the vertices have a mirror twin across the armature's X = 0 plane; the others "
                     "keep their own weights")
    if report and report.get("factorization_failed"):
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
    verts, tris = mesh_io.stack_meshes((v, t) for _, _, v, t in inputs)
    ids = core.touching_meshes(verts, mesh_of, len(inputs), triangles=tris)
    groups: dict[int, list[int]] = {}
    for m, g in enumerate(ids.tolist()):
        groups.setdefault(g, []).append(m)
    return list(groups.values())


# Meshes with at least this many vertices in total are computed on a worker thread when the
# operator is invoked from the UI (about 0.2 s of Heat on 2 cores): Esc cancels them.
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
        import miniskeleton_core as core

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
