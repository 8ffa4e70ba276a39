"""Skeleton operators: Auto Rig, Fit Skeleton to Mesh, Restore Original Skeleton / Keep Current as
Original, and rig exchange (NPZ bundle export/import, debug JSON export).

Auto Rig's skeleton is found by ``miniskeleton_core.auto_rig`` in world space around the ground
point of the meshes; the armature is built and bound in ``autorig``.

Fitting is computed by ``miniskeleton_core.fit_joints`` in the armature's frame (its axes and
origin at world size, ``armature_frame``: X symmetry is the armature's x = 0, and a scaled
armature does not stretch the mesh's cross-sections). The operators check and report; the work is
in ``autorig`` (Auto Rig), ``fitting``, ``snapshot`` (the original rest pose), ``editing`` (Edit Mode and bone ends),
``joints`` (the joint graph) and ``exchange`` (NPZ / JSON).
"""

from __future__ import annotations

import os
import time

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from ..common import native
from ..common.armatures import find_armature, invented_tails, pose_flag, rest_pose
from ..common.meshes import shaped_world_mesh, stack_meshes
from ..common.reports import in_edit_mode, name_list, read_only, unplaced
from ..common.transforms import armature_frame, to_armature_frame
from .autorig import (FORWARD_ITEMS, TEMPLATES, AutoRigError, build_armature, facing_name, fit_rig, ground_point,
                      make_control_rig, read_character, remove_armature, rigify_enabled, store_rigify_types)
from .editing import armature_edit, bone_children_stay
from .exchange import RigError, apply_weights, collect_rig, load_npz, output_path, rig_json, save_json, save_npz
from .fitting import FitError, fit_skeleton, movable_joints, place_fitted, read_skeleton
from .snapshot import (SNAPSHOT_KEY, SnapshotError, apply_rest_pose, load_snapshot, read_edit_rest_pose,
                       store_snapshot)


def _selected_meshes(context, arm):
    return [ob for ob in context.selected_objects if ob.type == "MESH" and ob is not arm]


def _skinned_meshes(context, arm):
    """Selected meshes; if none, every mesh deformed by (or parented to) ``arm``."""
    meshes = _selected_meshes(context, arm)
    if meshes:
        return meshes
    out = []
    for ob in context.scene.objects:
        if ob.type != "MESH":
            continue
        if any(m.type == "ARMATURE" and m.object is arm for m in ob.modifiers) or ob.parent is arm:
            out.append(ob)
    return sorted(out, key=lambda ob: ob.name)


def _armature_check(op, arm, need_bones=True):
    """There is an armature, with bones unless not ``need_bones``; otherwise reported."""
    if arm is None:
        op.report({"ERROR"}, "No armature: make the armature the active object")
        return False
    if need_bones and len(arm.data.bones) == 0 and not (arm.mode == "EDIT" and len(arm.data.edit_bones)):
        op.report({"ERROR"}, f"Armature '{arm.name}' has no bones")
        return False
    return True


def _editable_armature(op, arm, need_bones=True):
    """``_armature_check``, and the armature can be changed (not linked from a library)."""
    if not _armature_check(op, arm, need_bones):
        return False
    locked = read_only(arm, arm.data)
    if locked:
        op.report({"ERROR"}, locked)
        return False
    return True


class MINISKELETON_OT_auto_rig(bpy.types.Operator):
    """Add a skeleton fitted inside the selected meshes (biped, quadruped, chain or winged), as Rigify's metarigs"""

    bl_idname = "object.miniskeleton_auto_rig"
    bl_label = "Auto Rig"
    bl_options = {"REGISTER", "UNDO"}

    template: EnumProperty(name="Template", items=TEMPLATES, default="AUTO")
    forward: EnumProperty(name="Forward", items=FORWARD_ITEMS, default="AUTO",
                          description="The way the character faces")
    bind: BoolProperty(name="Bind", default=True,
                       description="Bind the meshes to the new armature with Auto Weights (Heat)")
    control_rig: BoolProperty(
        name="Control Rig", default=True,
        description="Run Rigify's Generate Rig on the new armature and bind the meshes to the control rig's DEF "
        "bones (needs the Rigify add-on: Edit > Preferences > Add-ons > Rigify; greyed out while it is disabled)")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        for name in ("template", "forward", "bind"):
            layout.prop(self, name)
        row = layout.row()
        row.enabled = rigify_enabled()
        row.prop(self, "control_rig", text="Control Rig" if row.enabled else "Control Rig (enable Rigify)")

    def _meshes(self, context):
        """The selected meshes, checked, or None (reported)."""
        selected = list(context.selected_objects)
        meshes = sorted((ob for ob in selected if ob.type == "MESH"), key=lambda ob: ob.name)
        editing = in_edit_mode(meshes)
        if editing:
            self.report({"ERROR"}, editing)
            return None
        if context.mode != "OBJECT":
            self.report({"ERROR"}, "Auto Rig works in Object Mode: switch to Object Mode, select the "
                        "character's mesh(es) and run it again")
            return None
        if not selected:
            self.report({"ERROR"}, "Nothing selected: select the character's mesh(es)")
            return None
        others = sorted(ob.name for ob in selected if ob.type != "MESH")
        if not meshes:
            self.report({"ERROR"}, f"No mesh selected ({name_list([repr(n) for n in others])} "
                        f"{'is not a mesh' if len(others) == 1 else 'are not meshes'}): select the "
                        "character's mesh(es); Object > Convert > Mesh turns curves and text into meshes")
            return None
        if others:
            self.report({"WARNING"}, f"Skipped {len(others)} selected object(s) that are not meshes: "
                        f"{name_list(others)}")
        problem = unplaced(*meshes) or (read_only(*[b for ob in meshes for b in (ob, ob.data)])
                                        if self.bind else None)
        if problem:
            self.report({"ERROR"}, problem + ("; or turn Bind off" if "linked" in problem else "")
                        + "; nothing was added")
            return None
        return meshes

    def execute(self, context):
        core = native.core()
        meshes = self._meshes(context)
        if meshes is None:
            return {"CANCELLED"}
        try:
            verts, tris, faceless = read_character(meshes)
        except AutoRigError as err:
            self.report({"ERROR"}, f"{err}; nothing was added")
            return {"CANCELLED"}
        if len(tris) == 0:
            what = "is empty" if not any(len(ob.data.vertices) for ob in meshes) else "has no faces"
            self.report({"ERROR"}, f"{'Mesh' if len(meshes) == 1 else 'The selected meshes'} "
                        f"{name_list([repr(n) for n in faceless])} {what}: Auto Rig needs the character's "
                        "surface; nothing was added")
            return {"CANCELLED"}
        if faceless:
            self.report({"WARNING"}, f"Skipped {len(faceless)} mesh(es) without faces: {name_list(faceless)}")
        origin = ground_point(verts)
        start = time.perf_counter()
        try:
            rig = fit_rig(core, verts, tris, origin, self.template, self.forward)
        except AutoRigError as err:
            self.report({"ERROR"}, f"Auto Rig: {err}; nothing was added")
            return {"CANCELLED"}
        secs = time.perf_counter() - start
        active = context.active_object
        character = active if active in meshes else meshes[0]
        selection = (list(context.selected_objects), active)
        arm = None
        control = None
        try:
            arm = build_armature(context, f"{character.name}_rig", origin, rig)
            rigify = store_rigify_types(arm, rig.template)
            bound = self._bind(context, meshes, arm) if self.bind else ""
            if self.control_rig and rigify:
                control = make_control_rig(context, arm, meshes, self.bind)
        except Exception as err:  # noqa: BLE001 - any failure: the scene as it was, one report
            if arm is not None:
                remove_armature(arm, meshes)
            self._reselect(context, *selection)
            self.report({"ERROR"}, f"Auto Rig: {str(err).strip() or type(err).__name__}; nothing was added")
            return {"CANCELLED"}
        tail = " with a tail" if rig.tail else ""
        note = "" if rigify else "; Rigify types stored (enable Rigify to Generate Rig)"
        if control is not None:
            note = f"; control rig '{control.name}' generated by Rigify" + (", the meshes bound to its DEF bones"
                                                                            if self.bind else "")
        self.report({"INFO"}, f"Auto Rig: {rig.template.lower()}{tail} ({rig.reason}), "
                    f"{len(rig.names)} bones in '{arm.name}' facing {facing_name(rig.forward)} "
                    f"({len(verts)} vertices, {secs:.2f} s){bound}{note}")
        return {"FINISHED"}

    def _bind(self, context, meshes, arm) -> str:
        """Auto Weights (Heat) from ``meshes`` to ``arm``, as Ctrl+P would; the armature active
        and selected alone afterwards. The text for the report; raises with the reason."""
        for ob in meshes:
            ob.select_set(True)
        context.view_layer.objects.active = arm
        try:
            result = bpy.ops.object.miniskeleton_auto_weights(method="HEAT")
        except RuntimeError as err:  # its error report
            raise RuntimeError(f"binding failed: {str(err).removeprefix('Error: ').strip()}") from None
        if result != {"FINISHED"}:
            raise RuntimeError(f"binding failed ({', '.join(result)})")
        for ob in meshes:
            ob.select_set(False)
        return f"; bound {len(meshes)} mesh(es) with Heat"

    @staticmethod
    def _reselect(context, selected, active):
        for ob in context.selected_objects:
            ob.select_set(False)
        for ob in selected:
            ob.select_set(True)
        context.view_layer.objects.active = active


class MINISKELETON_OT_fit_skeleton(bpy.types.Operator):
    """Move the selected joints (none selected: the deform bones' joints) to the middle of the selected meshes"""

    bl_idname = "armature.miniskeleton_fit_skeleton"
    bl_label = "Fit Skeleton to Mesh"
    bl_options = {"REGISTER", "UNDO"}

    symmetry: EnumProperty(
        name="Symmetry", default="NONE",
        items=[("NONE", "None", "Each joint on its own"),
               ("X", "X", "Left/right joints (.L/.R, _L/_R, Left/Right names) end exactly mirrored "
                "and centre joints (within Max Move of it) on the armature's x = 0")])
    rounds: IntProperty(name="Rounds", default=12, min=1, max=100,
                        description="Maximum rounds of centre lines and joint updates")
    max_move: FloatProperty(name="Max Move", default=5.0, min=0.1, max=100.0, subtype="PERCENTAGE",
                            description="How far a joint may move while fitting, in % of the mesh's "
                            "bounding-box diagonal (how rough the skeleton is; pulling a joint inside "
                            "the mesh may add more)")
    tails: EnumProperty(
        name="Free Tails", default="AUTO",
        items=[("AUTO", "Auto", "Follow their bone when no bone of the armature is connected (an imported "
                "glTF/FBX rig: those formats store joints only and the importer invents tails), else Joints"),
               ("JOINTS", "Joints", "Every bone tail is a joint and is fitted"),
               ("FOLLOW", "Follow Bone", "A tail that is not another bone's head was invented: it keeps its "
                "bone's direction and length from the fitted head; bones are fitted from parent to child heads")])

    def _inputs(self, context, arm):
        """(vertices (n,3) in the armature's frame, triangles) of the selected meshes, or None (reported)."""
        meshes = _selected_meshes(context, arm)
        if not meshes:
            self.report({"ERROR"}, "No mesh selected: select the mesh(es), then the armature (active)")
            return None
        editing = in_edit_mode(meshes) or unplaced(*meshes)
        if editing:
            self.report({"ERROR"}, editing)
            return None
        parts, faceless = [], []
        # Bone-parented parts are read where they are in the rest pose, as the bones are.
        with rest_pose(arm, meshes):
            for ob in meshes:
                v, t = shaped_world_mesh(ob)
                v = v.astype(np.float64)
                if len(v) == 0 or len(t) == 0:
                    faceless.append(ob.name)
                    continue
                bad = int((~np.isfinite(v)).any(axis=1).sum())
                if bad:
                    self.report({"ERROR"}, f"Mesh '{ob.name}' has {bad} vertices with NaN or infinite coordinates")
                    return None
                parts.append((to_armature_frame(arm, v), t))
        if not parts:
            self.report({"ERROR"}, f"Mesh '{faceless[0]}' has no faces: fitting needs a closed surface")
            return None
        if faceless:
            self.report({"WARNING"}, f"Skipped {len(faceless)} mesh(es) without faces: "
                        f"{name_list(sorted(faceless))}")
        return stack_meshes(parts)

    def execute(self, context):
        core = native.core()
        arm = find_armature(context)
        if not _editable_armature(self, arm):
            return {"CANCELLED"}
        nowhere = unplaced(arm)
        if nowhere:
            self.report({"ERROR"}, nowhere + "; nothing was changed")
            return {"CANCELLED"}
        # Bones are stored in armature space, the mesh is read in the armature's frame: the
        # stretch S (the armature's scale) maps one to the other, p_frame = S p_armature.
        _, stretch, _ = armature_frame(arm)
        sv = np.linalg.svd(stretch, compute_uv=False)
        if not sv.min() > 1e-9 * sv.max():
            self.report({"ERROR"}, f"Armature '{arm.name}' has a zero scale: set its Scale (Object "
                        "Properties > Transform) before fitting; nothing was changed")
            return {"CANCELLED"}
        inputs = self._inputs(context, arm)
        if inputs is None:
            return {"CANCELLED"}
        verts, tris = inputs
        mode = arm.mode
        pose_sel = {b.name: pose_flag(arm, b, "select") for b in arm.data.bones} if mode == "POSE" else {}

        # Read and fit without entering Edit Mode: an error leaves the armature exactly as it was.
        skel = read_skeleton(arm)
        if skel is None:
            self.report({"ERROR"}, f"Armature '{arm.name}' has no bones")
            return {"CANCELLED"}
        nj = len(skel.joints)
        movable, controls = movable_joints(mode, skel.bones, pose_sel, skel.ends, nj)
        follow = self.tails == "FOLLOW" or (self.tails == "AUTO" and invented_tails(skel.bones))
        try:
            new_heads, new_tails, rep, fit_j = fit_skeleton(core, skel, verts, tris, stretch, movable, follow,
                                                            self.symmetry, self.rounds, self.max_move / 100.0)
        except FitError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        if rep.outside_before_mask.all():
            self.report({"ERROR"}, f"All {len(fit_j)} joints of '{arm.name}' are outside the selected "
                        "mesh(es): is this the right mesh, and are both objects placed over each other? "
                        "Nothing was changed")
            return {"CANCELLED"}
        place_fitted(context, arm, skel.names, new_heads, new_tails)
        self._report_fit(rep, movable[fit_j], controls[fit_j], nj)
        return {"FINISHED"}

    def _report_fit(self, rep, movable: np.ndarray, kept: np.ndarray, joints: int):
        """Warnings on the mesh and the symmetry, then the counts; ``movable`` and ``kept``
        (controls left in place, counted apart) are over the ``len(movable)`` joints fitted of
        the armature's ``joints``."""
        if rep.open_edges or rep.nonmanifold_edges:
            self.report({"WARNING"}, f"The mesh is not closed ({rep.open_edges} open edges, "
                        f"{rep.nonmanifold_edges} non-manifold edges): inside tests may be wrong")
        if rep.pieces > 1:
            self.report({"WARNING"}, f"The mesh has {rep.pieces} separate pieces: each joint was "
                        "fitted into the piece around it")
        before = int((rep.outside_before_mask & ~kept).sum())
        after = int((rep.outside_after_mask & ~kept).sum())
        mirrored = rep.mirrored_surface
        if after and mirrored is not None and mirrored < 0.9:
            self.report({"WARNING"}, f"Symmetry X: only {mirrored:.0%} of the mesh's surface has a mirror "
                        "image across the armature's X = 0 plane (a posed scan, or the armature's origin off "
                        "the mesh's middle), so mirrored joints can end outside; fit without Symmetry, or put "
                        "the armature's origin on the mesh's mirror plane")
        unnamed = rep.off_plane_centre
        if unnamed:
            self.report({"WARNING"}, f"Symmetry X: {unnamed} joints lie farther than Max Move off the armature's "
                        "X = 0 plane, but their bones' names carry no side (.L/.R, _L/_R, Left/Right): they were "
                        "fitted without a mirror partner instead of being pulled onto the plane; name the sides "
                        "to mirror them")
        far = int(rep.kept_outside)
        level = {"WARNING"} if after > far else {"INFO"}
        fitted = len(movable)
        extra = f" ({joints - fitted} invented tails followed their bones)" if fitted < joints else ""
        controls_note = (f"; {int(kept.sum())} joints of non-deform bones (controls such as IK and pole "
                         "targets) kept in place: select them to fit them too") if kept.any() else ""
        far_note = (f" ({far} farther than Max Move outside kept their place, as a root on the ground or a "
                    "pole target: raise Max Move to pull them in)") if far else ""
        self.report(level, f"Fitted {int(movable.sum())} of {fitted} joints{extra}: outside the mesh "
                    f"before {before}, after {after}{far_note}{controls_note}")


class MINISKELETON_OT_restore_skeleton(bpy.types.Operator):
    """Put back the rest pose the armature had before MiniSkeleton first changed it"""

    bl_idname = "armature.miniskeleton_restore_skeleton"
    bl_label = "Restore Original Skeleton"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        arm = find_armature(context)
        if not _editable_armature(self, arm, need_bones=False):  # all deleted: still restorable
            return {"CANCELLED"}
        try:
            snap = load_snapshot(arm.data)  # checked whole before Edit Mode: a bad one changes nothing
        except SnapshotError as err:
            self.report({"ERROR"}, f"The stored original skeleton of '{arm.name}' (custom property "
                        f"'{SNAPSHOT_KEY}' of armature data '{arm.data.name}') cannot be restored: {err}. "
                        "Nothing was changed; Keep Current as Original stores a new one")
            return {"CANCELLED"}
        if snap is None:
            self.report({"ERROR"}, f"Armature '{arm.name}' has no stored original skeleton "
                        "(MiniSkeleton has not changed it)")
            return {"CANCELLED"}
        with bone_children_stay(arm), armature_edit(context, arm) as ebs:
            removed, made = apply_rest_pose(ebs, snap)
        done = f"Restored the original skeleton of '{arm.name}' ({len(snap['names'])} bones)"
        # Bones added or renamed since lose their pose-bone settings: say which (Ctrl+Z undoes).
        changes = []
        if removed:
            changes.append(f"removed {len(removed)} bone(s) added or renamed since: {name_list(removed)}")
        if made:
            changes.append(f"made again {len(made)} deleted or renamed: {name_list(made)}")
        if changes:
            self.report({"WARNING"}, f"{done}; {'; '.join(changes)} (Ctrl+Z to undo)")
        else:
            self.report({"INFO"}, done)
        return {"FINISHED"}


class MINISKELETON_OT_snapshot_skeleton(bpy.types.Operator):
    """Keep the current rest pose as the original that Restore Original Skeleton goes back to"""

    bl_idname = "armature.miniskeleton_snapshot_skeleton"
    bl_label = "Keep Current as Original"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        arm = find_armature(context)
        if not _editable_armature(self, arm):
            return {"CANCELLED"}
        with armature_edit(context, arm) as ebs:
            store_snapshot(arm.data, read_edit_rest_pose(ebs))
        self.report({"INFO"}, f"Current skeleton of '{arm.name}' kept as the original")
        return {"FINISHED"}


def _rig_context(op, context):
    """(armature, meshes) for export, or None (reported)."""
    arm = find_armature(context)
    if not _armature_check(op, arm):
        return None
    if arm.mode == "EDIT":
        arm.update_from_editmode()
    meshes = _skinned_meshes(context, arm)
    if not meshes:
        op.report({"ERROR"}, "No mesh: select the skinned mesh(es) or bind a mesh to the armature")
        return None
    nowhere = unplaced(arm, *meshes)   # world-space vertices and joints would be NaN
    if nowhere:
        op.report({"ERROR"}, nowhere + "; nothing was written")
        return None
    for ob in meshes:  # export what the rigger sees, edits made in Edit Mode included
        if ob.mode == "EDIT":
            ob.update_from_editmode()
    return arm, meshes


class MINISKELETON_OT_export_npz(bpy.types.Operator, ExportHelper):
    """Export mesh, skeleton and weights as a NumPy .npz bundle (RigNet-style pipelines)"""

    bl_idname = "export_scene.miniskeleton_npz"
    bl_label = "Export Rig Bundle (.npz)"
    bl_options = {"REGISTER"}

    filename_ext = ".npz"
    filter_glob: StringProperty(default="*.npz", options={"HIDDEN"})
    max_influences: IntProperty(name="Max Influences", default=0, min=0, max=64,
                                description="Bones kept per vertex (0 = all, unchanged weights)")

    def execute(self, context):
        found = _rig_context(self, context)
        if found is None:
            return {"CANCELLED"}
        arm, meshes = found
        try:
            rig = collect_rig(arm, meshes, self.max_influences)
            path = output_path(self.filepath, self.filename_ext)
            save_npz(path, rig)
        except RigError as err:
            self.report({"ERROR"}, f"Not exported: {err}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Exported {len(rig['vertices'])} vertices, {len(rig['bone_names'])} bones "
                    f"(k = {rig['indices'].shape[1]}) to {path}")
        return {"FINISHED"}


class MINISKELETON_OT_import_npz(bpy.types.Operator, ImportHelper):
    """Restore the weights of a .npz rig bundle onto the selected mesh (same vertex count)"""

    bl_idname = "import_scene.miniskeleton_npz"
    bl_label = "Import Rig Bundle Weights (.npz)"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".npz"
    filter_glob: StringProperty(default="*.npz", options={"HIDDEN"})

    def execute(self, context):
        meshes = [ob for ob in context.selected_objects if ob.type == "MESH"]
        if not meshes and context.active_object is not None and context.active_object.type == "MESH":
            meshes = [context.active_object]
        locked = read_only(*[ob.data for ob in meshes]) or in_edit_mode(meshes)
        if locked:
            self.report({"ERROR"}, locked + "; nothing was changed")
            return {"CANCELLED"}
        try:
            rig = load_npz(self.filepath)
            n = apply_weights(rig, meshes)
        except RigError as err:   # named by its file, whichever check refused it
            name, text = os.path.basename(self.filepath), str(err)
            self.report({"ERROR"}, text if not name or name in text else f"{name}: {text}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Weights of {len(rig['bone_names'])} bones restored on {n} vertices")
        return {"FINISHED"}


class MINISKELETON_OT_export_json(bpy.types.Operator, ExportHelper):
    """Export joints, bone edges and per-bone weight statistics as JSON, for debugging a rig"""

    bl_idname = "export_scene.miniskeleton_json"
    bl_label = "Export Rig Debug JSON"
    bl_options = {"REGISTER"}

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    def execute(self, context):
        found = _rig_context(self, context)
        if found is None:
            return {"CANCELLED"}
        arm, meshes = found
        try:
            data = rig_json(arm, meshes)
            path = output_path(self.filepath, self.filename_ext)
            save_json(path, data)
        except RigError as err:
            self.report({"ERROR"}, f"Not exported: {err}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Exported {len(data['joints'])} joints, {len(data['bones'])} bones to {path}")
        return {"FINISHED"}


classes = (
    MINISKELETON_OT_auto_rig,
    MINISKELETON_OT_fit_skeleton,
    MINISKELETON_OT_restore_skeleton,
    MINISKELETON_OT_snapshot_skeleton,
    MINISKELETON_OT_export_npz,
    MINISKELETON_OT_import_npz,
    MINISKELETON_OT_export_json,
)
