"""The Motion panel of the MiniSkeleton sidebar tab and the motion menu entries (Pose > Add
Motion, Render > Make Video). Layout only; the operators are in ``operators``."""

from __future__ import annotations

import bpy

from ..common.panels import SidebarPanel

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


classes = (MINISKELETON_PT_motion,)

# (Blender menu, draw function appended to it), in the order they are added.
MENUS = (
    ("VIEW3D_MT_pose", draw_pose_motion_menu),
    ("TOPBAR_MT_render", draw_render_video_menu),
)
