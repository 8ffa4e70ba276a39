"""The Puppet panel of the MiniSkeleton sidebar tab and the Add > Armature > Shadow Puppet menu
entry. Layout only; the operators are in ``operators``."""

from __future__ import annotations

import textwrap

import bpy

from ..common.panels import SidebarPanel
from .live import puppet_problem
from .rig import LIVE_KEY, puppet_rig

PUPPET_OP = "object.miniskeleton_add_puppet"


class MINISKELETON_PT_puppet(SidebarPanel, bpy.types.Panel):
    """Sidebar > MiniSkeleton > Puppet: add a shadow puppet, live solving, bake, theatre"""

    bl_label = "Puppet"
    bl_idname = "MINISKELETON_PT_puppet"

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        col.operator_menu_enum(PUPPET_OP, "type", text="Add Shadow Puppet", icon="OUTLINER_OB_ARMATURE")
        rig = puppet_rig(context.active_object)
        if rig is not None:
            col = layout.column(align=True)
            col.label(text=rig.name, icon="ARMATURE_DATA")
            col.prop(rig, f'["{LIVE_KEY}"]', text="Live Solve (rods drive the pose)")
            problem = puppet_problem(rig) if rig.get(LIVE_KEY, True) else None
            if problem:   # live solving skips it until it changes
                box = col.box()
                box.label(text="Not solving, pose kept:", icon="ERROR")
                for line in textwrap.wrap(problem, 44):
                    box.label(text=line)
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


classes = (MINISKELETON_PT_puppet,)

# (Blender menu, draw function appended to it), in the order they are added.
MENUS = (
    ("VIEW3D_MT_armature_add", draw_puppet_add_menu),
)
