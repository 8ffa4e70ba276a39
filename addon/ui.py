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
    register_puppet_menus()


def unregister_menus() -> None:
    unregister_puppet_menus()
    for name in _MENUS:
        getattr(bpy.types, name).remove(draw_parent_menu)


# ---------------------------------------------------------------------------- Puppet

PUPPET_OP = "object.miniskeleton_add_puppet"


class MINISKELETON_PT_puppet(bpy.types.Panel):
    """Sidebar > MiniSkeleton > Puppet: add a shadow puppet, live solving, bake, theatre"""

    bl_label = "Puppet"
    bl_idname = "MINISKELETON_PT_puppet"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "MiniSkeleton"

    def draw(self, context):
        from .operators_puppet import LIVE_KEY, puppet_rig

        layout = self.layout
        col = layout.column(align=True)
        col.operator_menu_enum(PUPPET_OP, "type", text="Add Shadow Puppet", icon="OUTLINER_OB_ARMATURE")
        rig = puppet_rig(context.active_object)
        if rig is not None:
            col = layout.column(align=True)
            col.label(text=rig.name, icon="ARMATURE_DATA")
            col.prop(rig, f'["{LIVE_KEY}"]', text="Live Solve (rods drive the pose)")
            bone = rig.pose.bones.get(rig.data.bones.active.name) if rig.data.bones.active else None
            if bone is not None:
                col.label(text=f"{bone.name} limits")
                row = col.row(align=True)
                row.prop(bone, "ik_min_z", text="Min")
                row.prop(bone, "ik_max_z", text="Max")
                col.operator("object.miniskeleton_set_part_image", icon="IMAGE_DATA").bone = bone.name
            col.operator("object.miniskeleton_bake_puppet", icon="KEYINGSET")
        layout.operator("scene.miniskeleton_shadow_theatre", icon="LIGHT_AREA")


def draw_puppet_add_menu(self, context):
    """Add > Armature: Shadow Puppet > the five templates."""
    self.layout.operator_menu_enum(PUPPET_OP, "type", text="Shadow Puppet", icon="OUTLINER_OB_ARMATURE")


classes = classes + (MINISKELETON_PT_puppet,)


def register_puppet_menus() -> None:
    bpy.types.VIEW3D_MT_armature_add.append(draw_puppet_add_menu)


def unregister_puppet_menus() -> None:
    bpy.types.VIEW3D_MT_armature_add.remove(draw_puppet_add_menu)
