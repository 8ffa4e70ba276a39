"""The Weights panel of the MiniSkeleton sidebar tab and the Auto Weights menu entries (Object >
Parent, Weight Paint > Weights). Layout only; the operator is in ``operators``."""

from __future__ import annotations

import bpy

from ..common.panels import SidebarPanel

WEIGHTS_OP = "object.miniskeleton_auto_weights"
TRANSFER_OP = "object.miniskeleton_transfer_weights"


def draw_parent_menu(self, context):
    """Object > Parent (and Weight Paint > Weights): 'With MiniSkeleton Weights' > methods."""
    layout = self.layout
    layout.separator()
    layout.operator_context = "EXEC_REGION_WIN"
    layout.operator_menu_enum(WEIGHTS_OP, "method", text="With MiniSkeleton Weights")
    layout.operator(TRANSFER_OP, text="Transfer MiniSkeleton Weights")


class MINISKELETON_PT_weights(SidebarPanel, bpy.types.Panel):
    """Sidebar > MiniSkeleton > Weights"""

    bl_label = "Weights"
    bl_idname = "MINISKELETON_PT_weights"

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        col.label(text="Select meshes, then the armature")
        for method, text, icon in (("HEAT", "Auto Weights (Heat)", "MOD_ARMATURE"),
                                   ("VOXEL", "Geodesic Voxel", "MESH_CUBE"),
                                   ("BILINEAR", "Nearest Bones (Bilinear)", "BONE_DATA"),
                                   ("IDW", "Inverse Distance", "DRIVER_DISTANCE")):
            op = col.operator(WEIGHTS_OP, text=text, icon=icon)
            op.method = method
        col = layout.column(align=True)
        col.label(text="Select garments, then the skinned body")
        col.operator(TRANSFER_OP, text="Transfer Weights", icon="MOD_CLOTH")


classes = (MINISKELETON_PT_weights,)

# (Blender menu, draw function appended to it), in the order they are added.
MENUS = (
    ("VIEW3D_MT_object_parent", draw_parent_menu),
    ("VIEW3D_MT_paint_weight", draw_parent_menu),
)
