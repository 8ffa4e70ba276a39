"""Weights operators: Auto Weights (Heat / nearest-bone bilinear / inverse distance).

Context like Blender's Ctrl+P > With Automatic Weights: the selected meshes and the active
armature (in Weight Paint mode, like Assign Automatic from Bones: the painted mesh and its
armature, hidden bones left out, the selected ones and, with X Mirror, their partners
written). Everything is validated and computed before anything is written, so an error leaves
every mesh as it was. Invoked from the UI on large meshes, the computation runs on a worker
thread (the core releases the GIL) while a modal loop shows progress; Esc cancels it and
nothing is written.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import os
import time
from typing import NamedTuple

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from . import mesh_io

METHODS = [
    ("HEAT", "Auto Weights (Heat)",
     "Bone heat diffusion on the welded surface (Baran & Popovic 2007); works on meshes in "
     "many pieces, at any scale and with split seams"),
    ("BILINEAR", "Nearest Bones (Bilinear)",
     "Nearest bone segments with a radial falloff, blended with the neighbouring bone across "
     "the nearer joint"),
    ("IDW", "Inverse Distance", "Inverse-distance weights to every bone segment, top influences kept"),
]


def find_armature(context: bpy.types.Context) -> bpy.types.Object | None:
    """The active armature; else a selected one; else the active mesh's Armature modifier or parent."""
    active = context.active_object
    if active is not None and active.type == "ARMATURE":
        return active
    for ob in context.selected_objects:
        if ob.type == "ARMATURE":
            return ob
    if active is not None and active.type == "MESH":
        for mod in active.modifiers:
            if mod.type == "ARMATURE" and mod.object is not None:
                return mod.object
        if active.parent is not None and active.parent.type == "ARMATURE":
            return active.parent
    return None


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
    bones: mesh_io.Bones
    inputs: list
    linked: list
    masks: dict


class MINISKELETON_OT_auto_weights(bpy.types.Operator):
    """Skin the selected meshes to the active armature with MiniSkeleton's Rust weights"""

    bl_idname = "object.miniskeleton_auto_weights"
    bl_label = "MiniSkeleton Auto Weights"
    bl_options = {"REGISTER", "UNDO"}

    method: EnumProperty(name="Method", items=METHODS, default="HEAT")
    max_influences: IntProperty(
        name="Max Influences", default=4, min=1, max=16,
        description="Bones kept per vertex (the strongest), then renormalized")
    selected_bones_only: BoolProperty(
        name="Selected Bones Only", default=False, options={"SKIP_SAVE"},
        description="Write groups only for selected deform bones; the others still take part. "
        "On by default in Weight Paint mode when bones are selected, as Assign Automatic from Bones")
    # Heat
    symmetry: EnumProperty(
        name="Symmetry", default="NONE",
        items=[("NONE", "None", "No symmetrization"),
               ("X", "X", "Average mirrored vertices in mirrored bones (.L/.R naming)")])
    visibility: BoolProperty(
        name="Visibility Test", default=True,
        description="A bone heats a vertex only if the straight line to it stays inside the mesh")
    bone_extent: EnumProperty(
        name="Bone Extent", default="AUTO",
        items=[("AUTO", "Auto", "Imported rigs (no bone connected to its parent, as glTF and FBX "
                "imports are): To Children; rigs built in Blender: Head to Tail"),
               ("TAIL", "Head to Tail", "Each bone is its head-to-tail segment, as in Blender"),
               ("CHILDREN", "To Children", "A bone whose children start away from its tail reaches "
                "their heads (the segments that lie inside the mesh); importers invent tails, "
                "often pointing out of the limb")])
    # IDW
    power: FloatProperty(name="Power", default=2.0, min=0.1, max=16.0,
                         description="Inverse-distance exponent p")
    # Bilinear
    nearest: IntProperty(name="Nearest Bones", default=3, min=1, max=16,
                         description="How many nearest bone segments share each vertex")
    falloff: EnumProperty(
        name="Falloff", default="GAUSSIAN",
        items=[("GAUSSIAN", "Gaussian", "exp(-d^2 / 2 sigma^2)"),
               ("INVERSE_POWER", "Inverse Power", "d^-p with the Power above")])
    sigma: FloatProperty(
        name="Sigma", default=0.0, min=0.0, subtype="DISTANCE",
        description="Gaussian width in world units; 0 = half the median bone length")

    # No poll: a missing armature or mesh is reported in the status bar instead of a greyed
    # button, so the rigger learns what to select.

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "method")
        layout.prop(self, "max_influences")
        layout.prop(self, "selected_bones_only")
        if self.method == "HEAT":
            layout.prop(self, "symmetry")
            layout.prop(self, "visibility")
            layout.prop(self, "bone_extent")
        elif self.method == "IDW":
            layout.prop(self, "power")
        else:
            layout.prop(self, "nearest")
            layout.prop(self, "falloff")
            if self.falloff == "GAUSSIAN":
                layout.prop(self, "sigma")
            else:
                layout.prop(self, "power")

    # ------------------------------------------------------------------ checks

    def _validate(self, context):
        """Return (armature, meshes, bones) or report and return None."""
        arm = find_armature(context)
        meshes = find_meshes(context)
        if arm is None:
            self.report({"ERROR"}, "No armature: make an armature the active object (Ctrl+P style)")
            return None
        if not meshes:
            self.report({"ERROR"}, "No mesh selected: select the meshes to skin, then the armature")
            return None
        if arm.mode == "EDIT":
            self.report({"ERROR"}, f"Armature '{arm.name}' is in Edit Mode: switch to Object or Pose Mode")
            return None
        others = [ob.name for ob in context.selected_objects if ob.type != "MESH" and ob != arm]
        if others:
            self.report({"WARNING"}, f"Skipped {len(others)} selected object(s) that are not meshes: "
                        f"{mesh_io.name_list(sorted(others))} (Object > Convert > Mesh to weight them)")
        empty = [ob for ob in meshes if len(ob.data.vertices) == 0]
        if len(empty) == len(meshes):
            self.report({"ERROR"}, f"Mesh '{empty[0].name}' has no vertices; nothing was changed")
            return None
        if empty:
            self.report({"WARNING"}, f"Skipped {len(empty)} selected mesh(es) without vertices: "
                        f"{mesh_io.name_list(sorted(ob.name for ob in empty))}")
            meshes = [ob for ob in meshes if ob not in empty]
        locked = mesh_io.read_only(*[b for ob in meshes for b in (ob, ob.data)])
        if locked:
            self.report({"ERROR"}, locked + "; nothing was changed")
            return None
        editing = mesh_io.in_edit_mode(meshes)
        if editing:
            self.report({"ERROR"}, editing)
            return None
        unplaced = mesh_io.unplaced(arm, *meshes)
        if unplaced:
            self.report({"ERROR"}, unplaced + "; nothing was changed")
            return None
        scale = max(mesh_io.extent(arm), 1e-30)
        # Weight Paint > Weights works like Blender's Assign Automatic from Bones there: hidden
        # bones take no part, and the selected (visible) bones are the ones written.
        painting = context.mode == "PAINT_WEIGHT"
        bones = mesh_io.armature_bones(arm, min_length=1e-6 * scale, weight_paint=painting)
        if not bones.names:
            what = ("has only hidden deform bones, which Weight Paint mode leaves out: unhide some "
                    "(Pose Mode, Alt+H)" if bones.hidden else
                    "has no deform bones" if not bones.skipped else "has only zero-length deform bones")
            self.report({"ERROR"}, f"Armature '{arm.name}' {what}")
            return None
        if painting:
            bones = self._weight_paint_selection(context.active_object, bones)
        if bones.skipped:
            self.report({"WARNING"}, f"Skipped {len(bones.skipped)} zero-length bone(s): "
                        + mesh_io.name_list(bones.skipped))
        if self.selected_bones_only and not bones.selected.any():
            self.report({"ERROR"}, "Selected Bones Only is on, but no deform bone is selected")
            return None
        return arm, meshes, bones

    def _weight_paint_selection(self, painted, bones):
        """In Weight Paint mode, as Assign Automatic from Bones: Selected Bones Only is on when
        bones are selected (unless the caller chose), and with the painted mesh's X Mirror on
        the selected bones' mirror partners (by name) are written too."""
        if bones.selected.any() and not self.properties.is_property_set("selected_bones_only"):
            self.selected_bones_only = True
        if not (self.selected_bones_only and painted.type == "MESH" and painted.data.use_mirror_x):
            return bones
        partners = mesh_io.bone_mirror_indices(bones.names)[bones.selected]
        selected = bones.selected.copy()
        selected[partners[partners >= 0]] = True
        return dataclasses.replace(bones, selected=selected)

    # ------------------------------------------------------------------ run

    def _prepare(self, context):
        """Validate and read every input (``Prepared``) or return None (reported). Vertices and
        bones are given in the armature's frame (``mesh_io.to_armature_frame``), not world."""
        checked = self._validate(context)
        if checked is None:
            return None
        arm, meshes, bones = checked
        if self.method == "HEAT":  # B-Bones are weighted along their rest curve, as by Ctrl+P
            points, owners = mesh_io.bbone_curves(arm, bones.names)
            bones = dataclasses.replace(bones, curve_points=points, curve_bones=owners)
        # Every method works in the armature's frame, moved there in double precision: X
        # symmetry is about the armature's x = 0 (as for Fit), and the core's single precision
        # keeps a character 1e5 m from the world origin only 8 mm apart (its weights changed).
        bones = dataclasses.replace(bones, heads=mesh_io.to_armature_frame(arm, bones.heads),
                                    tails=mesh_io.to_armature_frame(arm, bones.tails),
                                    curve_points=mesh_io.to_armature_frame(arm, bones.curve_points))
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
            picked, mask = mesh_io.paint_mask(ob)
            if picked is not None:
                if not picked.any():
                    self.report({"ERROR"}, f"Weight Paint {mask} mask is on, but no vertex of '{ob.name}' "
                                "is selected: select the vertices to re-weight, or turn the mask off; "
                                "nothing was changed")
                    return None
                masks[ob] = (picked, mask)
            verts = mesh_io.mesh_world_vertices(ob)
            bad = int((~np.isfinite(verts)).any(axis=1).sum())
            if bad:
                self.report({"ERROR"}, f"Mesh '{ob.name}' has {bad} vertices with NaN or infinite "
                            "coordinates; nothing was changed")
                return None
            verts = mesh_io.to_armature_frame(arm, verts)
            smoothing = mesh_io.smoothing_modifier(ob)
            if smoothing is not None:
                # A subdivided cage is weighted where its vertices lie on the smooth surface,
                # as Ctrl+P does (Catmull-Clark is affine: any frame is as good as its own).
                import miniskeleton_core as core

                verts = core.catmull_clark_limit(
                    verts, *mesh_io.mesh_polygons(ob),
                    keep_corners=smoothing.boundary_smooth == "PRESERVE_CORNERS")
            tris = mesh_io.mesh_triangles(ob) if self.method == "HEAT" else None
            inputs.append((ob, ob.name, verts, tris))
        return Prepared(arm, bones, inputs, linked, masks)

    def _settings(self, bones) -> dict:
        """The options as plain values, safe to use from a worker thread."""
        return dict(method=self.method, k=self.max_influences, power=self.power, nearest=self.nearest,
                    falloff="gaussian" if self.falloff == "GAUSSIAN" else "inverse_power",
                    sigma=self.sigma if self.sigma > 0 else None, visibility=self.visibility,
                    mirror=mesh_io.bone_mirror_indices(bones.names) if self.symmetry == "X" else None,
                    parents=bones.parents if self._reach_children(bones) else None)

    def _reach_children(self, bones) -> bool:
        """Bones reach their children's heads (Bone Extent; Auto: on imported rigs)."""
        if self.bone_extent == "AUTO":
            return bones.imported
        return self.bone_extent == "CHILDREN"

    def _write(self, prepared, results, notes, secs):
        """Write groups, modifier and parent for every mesh (main thread), then report."""
        arm, bones, inputs, linked, masks = prepared
        write = bones.selected if self.selected_bones_only else np.ones(len(bones.names), bool)
        kept_locked, partial = set(), []
        for ob, i, w in results:
            dense = mesh_io.dense_weights(i, w, len(bones.names))
            picked, mask = masks.get(ob, (None, ""))
            kept_locked.update(mesh_io.write_vertex_groups(ob, bones.names, dense, write, only=picked))
            if picked is not None:
                partial.append(f"only the {int(picked.sum())} of {len(picked)} vertices of '{ob.name}' "
                               f"selected for the Weight Paint {mask} mask")
        written = [r[0] for r in results] + [ob for ob, _ in linked]
        loops = []
        for ob in written:
            mesh_io.ensure_armature_modifier(ob, arm)
            if not mesh_io.parent_keep_transform(ob, arm):
                loops.append(ob.name)
        if loops:
            notes.append(f"'{arm.name}' is a child of {mesh_io.name_list(loops)}, so they were not parented "
                         "to it (a loop); their Armature modifier deforms them all the same")
        for ob in written:
            idle = mesh_io.idle_armature_modifiers(ob, arm)
            if idle:
                notes.append(f"'{ob.name}': its Armature modifier {', '.join(idle)} for '{arm.name}' has Vertex "
                             "Groups off or is disabled, so the new weights do not deform it (turn them on in "
                             "the Modifier Properties)")
            others = mesh_io.other_armature_modifiers(ob, arm)
            if others:
                notes.append(f"'{ob.name}' also has Armature modifier(s) {', '.join(others)} for another "
                             "armature, left as they were: they deform it too (remove or disable them "
                             "if the mesh moves twice)")
        for ob, first in linked:
            notes.append(f"'{ob.name}' shares its mesh with '{first.name}': weights computed once, "
                         f"from '{first.name}'")
        nverts = sum(len(v) for _, _, v, _ in inputs)
        label = dict((m[0], m[1]) for m in METHODS)[self.method]
        msg = (f"{label}: {nverts} vertices in {len(inputs)} mesh(es), {int(write.sum())} bones, "
               f"{secs:.2f} s")
        if self.method == "HEAT" and self._reach_children(bones):
            msg += "; bones reach their children (imported rig, see Bone Extent)"
        if partial:
            msg += "; re-weighted " + ", ".join(partial)
        if bones.hidden:
            msg += f"; hidden bones left out, their groups kept: {mesh_io.name_list(bones.hidden)}"
        if kept_locked:
            notes.append(f"locked groups kept: {mesh_io.name_list(sorted(kept_locked))}")
        for note in notes:
            self.report({"WARNING"}, note)
        self.report({"INFO"}, msg)
        return {"FINISHED"}

    def execute(self, context):
        import miniskeleton_core as core

        prepared = self._prepare(context)
        if prepared is None:
            return {"CANCELLED"}
        return self._run_blocking(context, core, prepared)

    def _run_blocking(self, context, core, prepared):
        bones, inputs = prepared.bones, prepared.inputs
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        start = time.perf_counter()
        try:
            def progress(f):
                wm.progress_update(int(1000 * f))
                return True
            try:
                results, notes = compute_weights(core, self._settings(bones), bones, inputs, progress)
            except WeightsError as err:
                self.report({"ERROR"}, str(err))
                return {"CANCELLED"}
            return self._write(prepared, results, notes, time.perf_counter() - start)
        finally:
            wm.progress_end()

    # ------------------------------------------------------------------ interactive: Esc cancels

    def invoke(self, context, event):
        """From the UI: large inputs are computed on a worker thread so that Esc can cancel;
        small ones (and headless runs, which have no event loop) run ``execute`` directly."""
        import miniskeleton_core as core

        if context.window is None:
            return self.execute(context)
        prepared = self._prepare(context)
        if prepared is None:
            return {"CANCELLED"}
        bones, inputs = prepared.bones, prepared.inputs
        if sum(len(v) for _, _, v, _ in inputs) < BACKGROUND_VERTICES:
            return self._run_blocking(context, core, prepared)
        self._prepared = prepared
        self._start = time.perf_counter()
        settings = self._settings(bones)
        self._job = WeightsJob(lambda progress: compute_weights(core, settings, bones, inputs, progress))
        self._job.start()
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        context.workspace.status_text_set("Auto Weights: computing... Esc to cancel")
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        job = self._job
        if event.type == "ESC":
            job.cancel()
        if event.type != "TIMER":
            return {"RUNNING_MODAL"}  # the meshes must not change while their weights are computed
        wm = context.window_manager
        wm.progress_update(int(1000 * job.fraction))
        if job.running():
            return {"RUNNING_MODAL"}
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        if job.cancelled:
            self.report({"WARNING"}, "Auto Weights cancelled; nothing was changed")
            return {"CANCELLED"}
        if job.error is not None:
            self.report({"ERROR"}, str(job.error))
            return {"CANCELLED"}
        results, notes = job.result
        return self._write(self._prepared, results, notes, time.perf_counter() - self._start)


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


classes = (MINISKELETON_OT_auto_weights,)
