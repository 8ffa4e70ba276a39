"""Menus and the MiniSkeleton sidebar panel. Only layout here; operators live in operators_*.py."""

from __future__ import annotations

import bpy

WEIGHTS_OP = "object.miniskeleton_auto_weights"


def draw_parent_menu(self, context):
    """Object > Parent (and Weight Paint > Weights): 'With MiniSkeleton Weights' > methods."""
    layout = self.layout
    layout.separator()
    layout.operator_context = "EXEC_REGION_WIN"
    layout.operator_menu_enum(WEIGHTS_OP, "method", text="With MiniSkeleton Weights")


class MINISKELETON_PT_weights(bpy.types.Panel):
    """Sidebar > MiniSkeleton > Weights"""

    bl_label = "Weights"
    bl_idname = "MINISKELETON_PT_weights"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "MiniSkeleton"

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        col.label(text="Select meshes, then the armature")
        for method, text, icon in (("HEAT", "Auto Weights (Heat)", "MOD_ARMATURE"),
                                   ("BILINEAR", "Nearest Bones (Bilinear)", "BONE_DATA"),
                                   ("IDW", "Inverse Distance", "DRIVER_DISTANCE")):
            op = col.operator(WEIGHTS_OP, text=text, icon=icon)
            op.method = method


classes = (MINISKELETON_PT_weights,)

_MENUS = ("VIEW3D_MT_object_parent", "VIEW3D_MT_paint_weight")


def register_menus() -> None:
    for name in _MENUS:
        getattr(bpy.types, name).append(draw_parent_menu)


def unregister_menus() -> None:
    for name in _MENUS:
        getattr(bpy.types, name).remove(draw_parent_menu)
