"""Weights operators: Auto Weights (Heat / nearest-bone bilinear / inverse distance).

Context like Blender's Ctrl+P > With Automatic Weights: the selected meshes and the active
armature (in Weight Paint mode: the painted mesh and its armature). Everything is validated
and computed before anything is written, so an error leaves every mesh as it was.
"""

from __future__ import annotations

import time

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
        name="Selected Bones Only", default=False,
        description="Write groups only for selected deform bones; the others still take part")
    # Heat
    symmetry: EnumProperty(
        name="Symmetry", default="NONE",
        items=[("NONE", "None", "No symmetrization"),
               ("X", "X", "Average mirrored vertices in mirrored bones (.L/.R naming)")])
    visibility: BoolProperty(
        name="Visibility Test", default=True,
        description="A bone heats a vertex only if the straight line to it stays inside the mesh")
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
        editing = [ob.name for ob in meshes if ob.mode == "EDIT"]
        if editing:
            self.report({"ERROR"}, f"Mesh in Edit Mode: {', '.join(editing)}; leave Edit Mode first")
            return None
        scale = max(arm.dimensions.length, 1e-30)
        bones = mesh_io.armature_bones(arm, min_length=1e-6 * scale)
        if not bones.names:
            what = "has no deform bones" if not bones.skipped else "has only zero-length deform bones"
            self.report({"ERROR"}, f"Armature '{arm.name}' {what}")
            return None
        if bones.skipped:
            self.report({"WARNING"}, f"Skipped {len(bones.skipped)} zero-length bone(s): "
                        + ", ".join(bones.skipped[:5]))
        if self.selected_bones_only and not bones.selected.any():
            self.report({"ERROR"}, "Selected Bones Only is on, but no deform bone is selected")
            return None
        return arm, meshes, bones

    # ------------------------------------------------------------------ run

    def _weights(self, core, ob, verts, bones, progress):
        """Run the chosen method on one mesh; returns (indices, weights, heat report or None)."""
        k = self.max_influences
        if self.method == "IDW":
            i, w = core.idw_weights(verts, bones.heads, bones.tails, max_influences=k, power=self.power)
            return i, w, None
        if self.method == "BILINEAR":
            i, w = core.bilinear_weights(
                verts, bones.heads, bones.tails, bones.parents, max_influences=k, nearest=self.nearest,
                falloff="gaussian" if self.falloff == "GAUSSIAN" else "inverse_power",
                sigma=self.sigma if self.sigma > 0 else None, power=self.power)
            return i, w, None
        tris = mesh_io.mesh_triangles(ob)
        mirror = mesh_io.bone_mirror_indices(bones.names) if self.symmetry == "X" else None
        i, w, report = core.heat_weights_report(
            verts, tris, bones.heads, bones.tails, max_influences=k, visibility=self.visibility,
            bone_mirror=mirror, progress=progress)
        return i, w, report

    def execute(self, context):
        import miniskeleton_core as core

        checked = self._validate(context)
        if checked is None:
            return {"CANCELLED"}
        arm, meshes, bones = checked

        inputs = []
        for ob in meshes:
            verts = mesh_io.mesh_world_vertices(ob)
            bad = int((~np.isfinite(verts)).any(axis=1).sum())
            if bad:
                self.report({"ERROR"}, f"Mesh '{ob.name}' has {bad} vertices with NaN or infinite "
                            "coordinates; nothing was changed")
                return {"CANCELLED"}
            if len(verts) == 0:
                self.report({"ERROR"}, f"Mesh '{ob.name}' has no vertices; nothing was changed")
                return {"CANCELLED"}
            inputs.append((ob, verts))

        wm = context.window_manager
        wm.progress_begin(0, 1000)
        start = time.perf_counter()
        results = []
        notes = []
        try:
            for m, (ob, verts) in enumerate(inputs):
                def progress(f, m=m):
                    wm.progress_update(int(1000 * (m + f) / len(inputs)))
                    return True
                try:
                    i, w, report = self._weights(core, ob, verts, bones, progress)
                except (ValueError, RuntimeError, core.Cancelled) as err:
                    self.report({"ERROR"}, f"Mesh '{ob.name}': {err}; nothing was changed")
                    return {"CANCELLED"}
                if report and (report.get("fallback_pieces") or report.get("rigid_pieces")):
                    notes.append(f"{ob.name}: of {report['pieces']} pieces, "
                                 f"{report['fallback_pieces']} saw no bone (nearest bone used), "
                                 f"{report['rigid_pieces']} bound rigidly (no bone inside)")
                if report and report.get("factorization_failed"):
                    notes.append(f"{ob.name}: heat solve failed, nearest-bone weights used")
                results.append((ob, i, w))

            write = bones.selected if self.selected_bones_only else np.ones(len(bones.names), bool)
            kept_locked = set()
            for ob, i, w in results:
                dense = mesh_io.dense_weights(i, w, len(bones.names))
                kept_locked.update(mesh_io.write_vertex_groups(ob, bones.names, dense, write))
                mesh_io.ensure_armature_modifier(ob, arm)
                mesh_io.parent_keep_transform(ob, arm)
        finally:
            wm.progress_end()

        secs = time.perf_counter() - start
        nverts = sum(len(v) for _, v in inputs)
        label = dict((m[0], m[1]) for m in METHODS)[self.method]
        msg = (f"{label}: {nverts} vertices in {len(inputs)} mesh(es), {int(write.sum())} bones, "
               f"{secs:.2f} s")
        if kept_locked:
            notes.append(f"locked groups kept: {', '.join(sorted(kept_locked)[:5])}")
        for note in notes:
            self.report({"WARNING"}, note)
        self.report({"INFO"}, msg)
        return {"FINISHED"}


classes = (MINISKELETON_OT_auto_weights,)
