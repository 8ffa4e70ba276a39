"""Menus and the MiniSkeleton sidebar panel. Only layout here; operators live in operators_*.py."""

from __future__ import annotations

import bpy

WEIGHTS_OP = "object.miniskeleton_auto_weights"


class SidebarPanel:
    """Mixin: a panel in the 3D viewport sidebar (N), tab "MiniSkeleton"."""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "MiniSkeleton"


def draw_parent_menu(self, context):
    """Object > Parent (and Weight Paint > Weights): 'With MiniSkeleton Weights' > methods."""
    layout = self.layout
    layout.separator()
    layout.operator_context = "EXEC_REGION_WIN"
    layout.operator_menu_enum(WEIGHTS_OP, "method", text="With MiniSkeleton Weights")


class MINISKELETON_PT_weights(SidebarPanel, bpy.types.Panel):
    """Sidebar > MiniSkeleton > Weights"""

    bl_label = "Weights"
    bl_idname = "MINISKELETON_PT_weights"

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        col.label(text="Select meshes, then the armature")
        for method, text, icon in (("HEAT", "Auto Weights (Heat)", "MOD_ARMATURE"),
                                   ("BILINEAR", "Nearest Bones (Bilinear)", "BONE_DATA"),
                                   ("IDW", "Inverse Distance", "DRIVER_DISTANCE")):
            op = col.operator(WEIGHTS_OP, text=text, icon=icon)
            op.method = method


# ---------------------------------------------------------------------------- Puppet

PUPPET_OP = "object.miniskeleton_add_puppet"


class MINISKELETON_PT_puppet(SidebarPanel, bpy.types.Panel):
    """Sidebar > MiniSkeleton > Puppet: add a shadow puppet, live solving, bake, theatre"""

    bl_label = "Puppet"
    bl_idname = "MINISKELETON_PT_puppet"

    def draw(self, context):
        from .puppet.rig import LIVE_KEY, puppet_rig

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


# ---------------------------------------------------------------------------- Skeleton

FIT_OP = "armature.miniskeleton_fit_skeleton"


class MINISKELETON_PT_skeleton(SidebarPanel, bpy.types.Panel):
    """Sidebar > MiniSkeleton > Skeleton: fit, restore, Blender's own bone editing, rig exchange"""

    bl_label = "Skeleton"
    bl_idname = "MINISKELETON_PT_skeleton"

    def draw(self, context):
        layout = self.layout
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


def draw_export_menu(self, context):
    self.layout.operator("export_scene.miniskeleton_npz", text="MiniSkeleton Rig Bundle (.npz)")
    self.layout.operator("export_scene.miniskeleton_json", text="MiniSkeleton Rig Debug (.json)")


def draw_import_menu(self, context):
    self.layout.operator("import_scene.miniskeleton_npz", text="MiniSkeleton Rig Bundle Weights (.npz)")


# ---------------------------------------------------------------------------- Motion

MOTION_OP = "pose.miniskeleton_add_motion"
VIDEO_OP = "render.miniskeleton_make_video"


class MINISKELETON_PT_motion(SidebarPanel, bpy.types.Panel):
    """Sidebar > MiniSkeleton > Motion: head shake / walk / run keys, then an MP4"""

    bl_label = "Motion"
    bl_idname = "MINISKELETON_PT_motion"

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        col.label(text="Active armature (bound mesh)")
        for motion, text, icon in (("HEAD_SHAKE", "Auto Head Shake", "USER"),
                                   ("WALK", "Auto Walking", "MOD_DYNAMICPAINT"),
                                   ("RUN", "Auto Running", "FORCE_FORCE")):
            col.operator(MOTION_OP, text=text, icon=icon).motion = motion
        col = layout.column(align=True)
        col.label(text=f"Frames {context.scene.frame_start}-{context.scene.frame_end}")
        col.operator(VIDEO_OP, text="Make Video (MP4)", icon="RENDER_ANIMATION")


def draw_pose_motion_menu(self, context):
    """Pose menu: Add Motion (MiniSkeleton) > Head Shake / Walk / Run."""
    layout = self.layout
    layout.separator()
    layout.operator_menu_enum(MOTION_OP, "motion", text="Add Motion (MiniSkeleton)")


def draw_render_video_menu(self, context):
    """Render menu: Make Video (MP4)."""
    layout = self.layout
    layout.separator()
    layout.operator(VIDEO_OP, text="Make Video (MP4, MiniSkeleton)", icon="RENDER_ANIMATION")


# ---------------------------------------------------------------------------- Registration

classes = (MINISKELETON_PT_weights, MINISKELETON_PT_skeleton, MINISKELETON_PT_motion,
           MINISKELETON_PT_puppet)

# (Blender menu, draw function appended to it), in the order they are added.
MENUS = (
    ("VIEW3D_MT_object_parent", draw_parent_menu),
    ("VIEW3D_MT_paint_weight", draw_parent_menu),
    ("VIEW3D_MT_armature_add", draw_puppet_add_menu),
    ("VIEW3D_MT_edit_armature", draw_armature_menu),
    ("VIEW3D_MT_pose", draw_armature_menu),
    ("TOPBAR_MT_file_export", draw_export_menu),
    ("TOPBAR_MT_file_import", draw_import_menu),
    ("VIEW3D_MT_pose", draw_pose_motion_menu),
    ("TOPBAR_MT_render", draw_render_video_menu),
)


def register_menus() -> None:
    for menu, draw in MENUS:
        getattr(bpy.types, menu).append(draw)


def unregister_menus() -> None:
    for menu, draw in reversed(MENUS):
        getattr(bpy.types, menu).remove(draw)
