"""The Skeleton panel of the MiniSkeleton sidebar tab and the skeleton menu entries (Add >
Armature, Armature in Edit Mode, Pose, File > Export / Import). Layout only; the operators are in ``operators``."""

from __future__ import annotations

import bpy

from ..common.panels import SidebarPanel

FIT_OP = "armature.miniskeleton_fit_skeleton"
AUTO_RIG_OP = "object.miniskeleton_auto_rig"


class MINISKELETON_PT_skeleton(SidebarPanel, bpy.types.Panel):
    """Sidebar > MiniSkeleton > Skeleton: auto rig, fit, restore, Blender's own bone editing, rig exchange"""

    bl_label = "Skeleton"
    bl_idname = "MINISKELETON_PT_skeleton"

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        col.label(text="Select the character's meshes")
        col.operator(AUTO_RIG_OP, text="Auto Rig", icon="OUTLINER_OB_ARMATURE")
        col = layout.column(align=True)
        col.label(text="Select meshes, then the armature")
        col.operator(FIT_OP, text="Fit Skeleton to Mesh", icon="ARMATURE_DATA").symmetry = "NONE"
        col.operator(FIT_OP, text="Fit Skeleton (X Symmetry)", icon="MOD_MIRROR").symmetry = "X"
        col = layout.column(align=True)
        col.operator("armature.miniskeleton_restore_skeleton", icon="LOOP_BACK")
        col.operator("armature.miniskeleton_snapshot_skeleton", icon="PINNED")
        if context.mode == "EDIT_ARMATURE":
            col = layout.column(align=True)
            col.label(text="Edit Bones (Blender)")
            col.operator("armature.extrude_move", text="Extrude", icon="BONE_DATA")
            row = col.row(align=True)
            row.operator_menu_enum("armature.parent_set", "type", text="Make Parent")
            row.operator_menu_enum("armature.parent_clear", "type", text="Clear Parent")
        col = layout.column(align=True)
        col.label(text="Rig Exchange")
        col.operator("export_scene.miniskeleton_npz", text="Export Bundle (.npz)", icon="EXPORT")
        col.operator("import_scene.miniskeleton_npz", text="Import Weights (.npz)", icon="IMPORT")
        col.operator("export_scene.miniskeleton_json", text="Export Debug JSON", icon="TEXT")


def draw_armature_menu(self, context):
    """Armature (Edit Mode) and Pose menus: fit / restore / keep."""
    layout = self.layout
    layout.separator()
    layout.operator(FIT_OP, text="Fit Skeleton to Mesh (MiniSkeleton)")
    layout.operator("armature.miniskeleton_restore_skeleton")
    layout.operator("armature.miniskeleton_snapshot_skeleton")


def draw_auto_rig_add_menu(self, context):
    """Add > Armature: Auto Rig (from the selected meshes)."""
    self.layout.operator(AUTO_RIG_OP, text="Auto Rig (from Selected Meshes)", icon="OUTLINER_OB_ARMATURE")


def draw_export_menu(self, context):
    self.layout.operator("export_scene.miniskeleton_npz", text="MiniSkeleton Rig Bundle (.npz)")
    self.layout.operator("export_scene.miniskeleton_json", text="MiniSkeleton Rig Debug (.json)")


def draw_import_menu(self, context):
    self.layout.operator("import_scene.miniskeleton_npz", text="MiniSkeleton Rig Bundle Weights (.npz)")


classes = (MINISKELETON_PT_skeleton,)

# (Blender menu, draw function appended to it), in the order they are added.
MENUS = (
    ("VIEW3D_MT_armature_add", draw_auto_rig_add_menu),
    ("VIEW3D_MT_edit_armature", draw_armature_menu),
    ("VIEW3D_MT_pose", draw_armature_menu),
    ("TOPBAR_MT_file_export", draw_export_menu),
    ("TOPBAR_MT_file_import", draw_import_menu),
)
