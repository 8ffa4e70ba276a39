"""Weights operators: Auto Weights (Heat / Voxel / nearest-bone bilinear / inverse distance).

Context like Blender's Ctrl+P > With Automatic Weights: the selected meshes and the active
armature (in Weight Paint mode, like Assign Automatic from Bones: the painted mesh and its
armature, hidden bones left out, the selected ones and, with X Mirror, their partners
written). Everything is validated and computed before anything is written, so an error leaves
every mesh as it was. Invoked from the UI on large meshes, the computation runs on a worker
thread (the core releases the GIL) while a modal loop shows progress; Esc cancels it and
nothing is written. Reading and writing Blender data is in ``binding``; the computing itself,
without bpy, in ``compute``.
"""

from __future__ import annotations

import dataclasses
import time

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from ..common import native
from ..common.armatures import armature_bones, find_armature
from ..common.mirror import bone_mirror_indices
from ..common.reports import in_edit_mode, name_list, read_only, unplaced
from ..common.transforms import extent, to_armature_frame
from .binding import find_meshes, read_inputs, write_weights
from .compute import BACKGROUND_VERTICES, WeightsError, WeightsJob, compute_weights

METHODS = [
    ("HEAT", "Auto Weights (Heat)",
     "Bone heat diffusion on the welded surface (Baran & Popovic 2007); works on meshes in "
     "many pieces, at any scale and with split seams"),
    ("VOXEL", "Geodesic Voxel",
     "Every selected mesh voxelized as one solid, bones found by geodesic distance through it "
     "(Dionne & de Lasa 2013); for meshes in many pieces, open or self-intersecting"),
    ("BILINEAR", "Nearest Bones (Bilinear)",
     "Nearest bone segments with a radial falloff, blended with the neighbouring bone across "
     "the nearer joint"),
    ("IDW", "Inverse Distance", "Inverse-distance weights to every bone segment, top influences kept"),
]


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
    # Heat and Voxel
    symmetry: EnumProperty(
        name="Symmetry", default="NONE",
        items=[("NONE", "None", "No symmetrization"),
               ("X", "X", "Average mirrored vertices in mirrored bones (.L/.R naming)")])
    memory_limit: FloatProperty(
        name="Memory Limit", default=0.0, min=0.0, soft_max=256.0,
        description="Refuse a Heat solve whose estimated peak memory is over this many GB "
        "(0: three quarters of this computer's memory)")
    visibility: BoolProperty(
        name="Visibility Test", default=True,
        description="A bone heats a vertex only if the straight line to it stays inside the mesh")
    bone_extent: EnumProperty(
        name="Bone Extent", default="AUTO",
        items=[("AUTO", "Auto", "Imported rigs (no bone connected to its parent, as glTF and FBX "
                "imports are): To Children; rigs built in Blender: Head to Tail"),
               ("TAIL", "Head to Tail", "Each bone is its head-to-tail segment, as in Blender"),
               ("CHILDREN", "To Children", "A bone whose children start away from its tail reaches "
                "their heads (the segments that lie inside the mesh), and a bone with no children "
                "continues its parent's line; importers invent tails, often pointing out of the limb")])
    # Voxel
    resolution: IntProperty(
        name="Resolution", default=64, min=16, max=1024,
        description="Voxels along the longest side of the meshes; parts closer than a voxel merge "
        "(the time grows with the cube of it)")
    voxel_falloff: FloatProperty(
        name="Falloff", default=0.002, min=0.0, max=1.0, precision=3, step=0.1,
        description="How far a vertex shares its weight with bones farther than its nearest one, "
        "relative to its distance (0: the nearest bone alone, then smoothed)")
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
        if self.method in ("HEAT", "VOXEL"):
            layout.prop(self, "symmetry")
            if self.method == "HEAT":
                layout.prop(self, "visibility")
            layout.prop(self, "bone_extent")
            if self.method == "HEAT":
                layout.prop(self, "memory_limit")
            if self.method == "VOXEL":
                layout.prop(self, "resolution")
                layout.prop(self, "voxel_falloff")
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
                        f"{name_list(sorted(others))} (Object > Convert > Mesh to weight them)")
        empty = [ob for ob in meshes if len(ob.data.vertices) == 0]
        if len(empty) == len(meshes):
            self.report({"ERROR"}, f"Mesh '{empty[0].name}' has no vertices; nothing was changed")
            return None
        if empty:
            self.report({"WARNING"}, f"Skipped {len(empty)} selected mesh(es) without vertices: "
                        f"{name_list(sorted(ob.name for ob in empty))}")
            meshes = [ob for ob in meshes if ob not in empty]
        locked = read_only(*[b for ob in meshes for b in (ob, ob.data)])
        if locked:
            self.report({"ERROR"}, locked + "; nothing was changed")
            return None
        editing = in_edit_mode(meshes)
        if editing:
            self.report({"ERROR"}, editing)
            return None
        nowhere = unplaced(arm, *meshes)
        if nowhere:
            self.report({"ERROR"}, nowhere + "; nothing was changed")
            return None
        scale = max(extent(arm), 1e-30)
        # Weight Paint > Weights works like Blender's Assign Automatic from Bones there: hidden
        # bones take no part, and the selected (visible) bones are the ones written.
        painting = context.mode == "PAINT_WEIGHT"
        bones = armature_bones(arm, min_length=1e-6 * scale, weight_paint=painting)
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
                        + name_list(bones.skipped))
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
        partners = bone_mirror_indices(bones.names)[bones.selected]
        selected = bones.selected.copy()
        selected[partners[partners >= 0]] = True
        return dataclasses.replace(bones, selected=selected)

    # ------------------------------------------------------------------ run

    def _prepare(self, context):
        """Validate and read every input (``Prepared``) or return None (reported)."""
        checked = self._validate(context)
        if checked is None:
            return None
        arm, meshes, bones = checked
        try:
            return read_inputs(arm, meshes, bones, heat=self.method in ("HEAT", "VOXEL"))
        except WeightsError as err:
            self.report({"ERROR"}, str(err))
            return None

    def _settings(self, bones) -> dict:
        """The options as plain values, safe to use from a worker thread."""
        return dict(method=self.method, k=self.max_influences, power=self.power, nearest=self.nearest,
                    falloff="gaussian" if self.falloff == "GAUSSIAN" else "inverse_power",
                    sigma=self.sigma if self.sigma > 0 else None, visibility=self.visibility,
                    memory_limit=self.memory_limit,
                    mirror=bone_mirror_indices(bones.names) if self.symmetry == "X" else None,
                    parents=bones.parents if self._reach_children(bones) else None,
                    resolution=self.resolution, voxel_falloff=self.voxel_falloff)

    def _reach_children(self, bones) -> bool:
        """Bones reach their children's heads (Bone Extent; Auto: on imported rigs)."""
        if self.bone_extent == "AUTO":
            return bones.imported
        return self.bone_extent == "CHILDREN"

    def _write(self, prepared, results, notes, secs):
        """Write groups, modifier and parent for every mesh (main thread), then report."""
        bones, inputs = prepared.bones, prepared.inputs
        write = bones.selected if self.selected_bones_only else np.ones(len(bones.names), bool)
        written_notes, partial, kept_locked = write_weights(prepared, results, write)
        notes += written_notes
        nverts = sum(len(v) for _, _, v, _ in inputs)
        label = dict((m[0], m[1]) for m in METHODS)[self.method]
        msg = (f"{label}: {nverts} vertices in {len(inputs)} mesh(es), {int(write.sum())} bones, "
               f"{secs:.2f} s")
        if self.method in ("HEAT", "VOXEL") and self._reach_children(bones):
            msg += "; bones reach their children (imported rig, see Bone Extent)"
        if partial:
            msg += "; re-weighted " + ", ".join(partial)
        if bones.hidden:
            msg += f"; hidden bones left out, their groups kept: {name_list(bones.hidden)}"
        if kept_locked:
            notes.append(f"locked groups kept: {name_list(sorted(kept_locked))}")
        for note in notes:
            self.report({"WARNING"}, note)
        self.report({"INFO"}, msg)
        return {"FINISHED"}

    def execute(self, context):
        core = native.core()
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
        core = native.core()
        if context.window is None:
            return self.execute(context)
        prepared = self._prepare(context)
        if prepared is None:
            return {"CANCELLED"}
        # Voxel's time follows the solid's volume, not the vertex count: always on the worker.
        if self.method != "VOXEL" and sum(len(v) for _, _, v, _ in prepared.inputs) < BACKGROUND_VERTICES:
            return self._run_blocking(context, core, prepared)
        self._start_job(context, core, prepared)
        context.window_manager.modal_handler_add(self)
        context.workspace.status_text_set("Auto Weights: computing... Esc to cancel")
        return {"RUNNING_MODAL"}

    def _start_job(self, context, core, prepared):
        """Start computing ``prepared`` on a worker thread, with the progress bar and the timer
        whose ticks ``modal`` checks the job on (the window sends them; a test can too)."""
        bones, inputs = prepared.bones, prepared.inputs
        self._prepared = prepared
        self._start = time.perf_counter()
        settings = self._settings(bones)
        self._job = WeightsJob(lambda progress: compute_weights(core, settings, bones, inputs, progress))
        self._job.start()
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        self._timer = wm.event_timer_add(0.1, window=context.window)

    def modal(self, context, event):
        job = self._job
        if event.type == "ESC":
            job.cancel()
        if event.type != "TIMER":
            return {"RUNNING_MODAL"}  # the meshes must not change while their weights are computed
        context.window_manager.progress_update(int(1000 * job.fraction))
        if job.running():
            return {"RUNNING_MODAL"}
        self._end_job(context)
        if job.cancelled:
            self.report({"WARNING"}, "Auto Weights cancelled; nothing was changed")
            return {"CANCELLED"}
        if job.error is not None:
            self.report({"ERROR"}, str(job.error))
            return {"CANCELLED"}
        results, notes = job.result
        return self._write(self._prepared, results, notes, time.perf_counter() - self._start)

    def cancel(self, context):
        """Blender ends the modal run itself (another file is opened, the window closes): the
        worker is told to stop at its next progress tick, nothing is written (the job never
        touches Blender data) and the timer and the progress bar go."""
        self._job.cancel()
        self._end_job(context)

    def _end_job(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)


class MINISKELETON_OT_transfer_weights(bpy.types.Operator):
    """Copy the active skinned body's weights onto the selected garments where they lie on it,
    inpainting the rest (Robust Skin Weights Transfer, Abdrashitov et al. 2023)"""

    bl_idname = "object.miniskeleton_transfer_weights"
    bl_label = "MiniSkeleton Transfer Weights"
    bl_options = {"REGISTER", "UNDO"}

    max_distance: FloatProperty(
        name="Max Distance", default=0.05, min=0.0, max=1.0, precision=3,
        description="A garment vertex takes the body's weights where the body is at most this far, "
        "as a fraction of the body's size")
    max_angle: FloatProperty(
        name="Max Angle", default=30.0, min=0.0, max=180.0,
        description="... and where their normals differ by at most this many degrees (either way round)")
    max_influences: IntProperty(
        name="Max Influences", default=4, min=1, max=16,
        description="Bones kept per vertex (the strongest), then renormalized")

    def _validate(self, context):
        """Return (armature, body, garments, bones) or report and return None."""
        body = context.active_object
        if body is None or body.type != "MESH":
            self.report({"ERROR"}, "Make the skinned body the active object, with the garments selected")
            return None
        garments = [ob for ob in context.selected_objects if ob.type == "MESH" and ob != body]
        if not garments:
            self.report({"ERROR"}, f"No garment selected: select the meshes to dress, then the body '{body.name}'")
            return None
        arm = find_armature(context)
        if arm is None:
            self.report({"ERROR"}, f"The body '{body.name}' has no armature (no Armature modifier or "
                        "armature parent): bind it first with Auto Weights")
            return None
        empty = [ob.name for ob in garments if len(ob.data.vertices) == 0]
        if empty:
            self.report({"ERROR"}, f"Mesh(es) without vertices: {name_list(empty)}; nothing was changed")
            return None
        problem = (read_only(*[b for ob in garments for b in (ob, ob.data)]) or in_edit_mode([body, *garments])
                   or unplaced(arm, body, *garments))
        if problem:
            self.report({"ERROR"}, problem + "; nothing was changed")
            return None
        bones = armature_bones(arm, min_length=1e-6 * max(extent(arm), 1e-30))
        if not bones.names:
            self.report({"ERROR"}, f"Armature '{arm.name}' has no deform bones")
            return None
        return arm, body, garments, bones

    def execute(self, context):
        core = native.core()
        from .binding import Prepared, write_weights
        from .transfer import body_rows, read_mesh, transfer

        checked = self._validate(context)
        if checked is None:
            return {"CANCELLED"}
        arm, body, garments, bones = checked
        start = time.perf_counter()
        bones = dataclasses.replace(bones, heads=to_armature_frame(arm, bones.heads),
                                    tails=to_armature_frame(arm, bones.tails))
        try:
            weights = body_rows(body, arm, bones.names)
            body_mesh = read_mesh(arm, body)
            inputs = [(ob, ob.name, *read_mesh(arm, ob)) for ob in garments]
            settings = dict(max_distance=self.max_distance, max_angle=self.max_angle, k=self.max_influences,
                            parents=bones.parents if bones.imported else None)
            results, notes = transfer(core, body_mesh, weights, inputs, bones, settings)
        except WeightsError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        prepared = Prepared(arm, bones, inputs, [], {})
        written, _, kept_locked = write_weights(prepared, results, np.ones(len(bones.names), bool))
        if kept_locked:
            written.append(f"locked groups kept: {name_list(sorted(kept_locked))}")
        for note in notes + written:
            self.report({"INFO"} if "took the body" in note else {"WARNING"}, note)
        self.report({"INFO"}, f"Transfer Weights from '{body.name}': {len(garments)} mesh(es), "
                    f"{time.perf_counter() - start:.2f} s")
        return {"FINISHED"}


classes = (MINISKELETON_OT_auto_weights, MINISKELETON_OT_transfer_weights)
