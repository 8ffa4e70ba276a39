"""Shadow-puppet operators: add a puppet template, bake, part images and the Shadow Theatre
scene preset. They are thin: the work is in ``build``, ``live`` (rod-driven IK, live handlers,
bake) and ``theatre``; ``rig`` finds the puppet, ``templates`` describes the figures.
"""

from __future__ import annotations

import math
import os

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from ..common.keys import keyed_action, locked_curves
from ..common.reports import in_edit_mode, read_only
from . import templates
from .build import build_puppet, set_part_image
from .live import bake_puppet, scene_frames
from .rig import GAPS, LIVE_KEY, PART_KEY, PuppetError, puppet_gaps, puppet_poll, puppet_rig, puppet_rods
from .theatre import build_shadow_theatre


class MINISKELETON_OT_add_puppet(bpy.types.Operator):
    """Add a shadow puppet (armature, cut-out parts and control rods) in the XZ picture plane"""

    bl_idname = "object.miniskeleton_add_puppet"
    bl_label = "Shadow Puppet"
    bl_options = {"REGISTER", "UNDO"}

    type: EnumProperty(name="Type", items=templates.KIND_ITEMS, default="FIVE_ROD")
    size: FloatProperty(name="Size", default=1.0, min=0.01, max=100.0,
                        description="Scale of the figure (1 = a 1.9 m tall human figure)")

    def execute(self, context):
        at = context.scene.cursor.location
        if not all(map(math.isfinite, at)):   # a script can put it there; nothing is built
            self.report({"ERROR"}, "The 3D cursor has a NaN or infinite location, where a puppet has "
                        "no place: reset it (Shift+C, or Object > Snap > Cursor to World Origin)")
            return {"CANCELLED"}
        rig = build_puppet(context, self.type, at, self.size)
        self.report({"INFO"}, f"Added {rig.name}: {len(rig.data.bones)} bones, "
                    f"{len(puppet_rods(rig))} rods")
        return {"FINISHED"}


class MINISKELETON_OT_bake_puppet(bpy.types.Operator):
    """Solve the puppet on every frame of the scene range and keyframe the bone rotations, so
    the animation plays and renders without the add-on"""

    bl_idname = "object.miniskeleton_bake_puppet"
    bl_label = "Bake Puppet Animation"
    bl_options = {"REGISTER", "UNDO"}

    stop_live: BoolProperty(name="Stop Live Solving", default=True,
                            description="Turn live solving off afterwards so the keys play as baked")

    @classmethod
    def poll(cls, context):
        return puppet_poll(cls, context)

    def execute(self, context):
        rig = puppet_rig(context.active_object)
        locked = read_only(rig, keyed_action(rig)) or locked_curves(
            rig, [pb.name for pb in rig.pose.bones if not all(pb.lock_rotation)])
        if locked:
            self.report({"ERROR"}, locked)
            return {"CANCELLED"}
        scene = context.scene
        wm = context.window_manager
        frames = scene_frames(scene)
        wm.progress_begin(0, len(frames))  # each frame is evaluated and solved
        try:   # on any failure bake_puppet has put the bones' rotations back
            n = bake_puppet(scene, rig, frames, progress=wm.progress_update)
        except PuppetError as err:   # a frame that cannot be solved: nothing keyed
            self.report({"ERROR"}, f"{err}; nothing was baked")
            return {"CANCELLED"}
        except Exception as err:     # failed while keying, after every frame was solved
            self.report({"ERROR"}, f"Baking {rig.name} stopped while keying ({type(err).__name__}: {err}); "
                        "the bones' rotations are as they were, keys already written stay")
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        if self.stop_live:
            rig[LIVE_KEY] = False
        gaps = puppet_gaps(rig)
        if gaps:
            self.report({"WARNING"}, f"Baked {n} frames of {rig.name}; it {GAPS}: {'; '.join(gaps)}")
        else:
            self.report({"INFO"}, f"Baked {n} frames of {rig.name}")
        return {"FINISHED"}


class MINISKELETON_OT_set_part_image(bpy.types.Operator, ImportHelper):
    """Replace the active bone's cut-out with an image (PNG with alpha) on a plane"""

    bl_idname = "object.miniskeleton_set_part_image"
    bl_label = "Set Part Image"
    bl_options = {"REGISTER", "UNDO"}

    filter_glob: StringProperty(default="*.png;*.tga;*.tif;*.tiff;*.webp;*.exr", options={"HIDDEN"})
    bone: StringProperty(name="Bone", description="Bone whose part gets the image (default: active bone)")

    @classmethod
    def poll(cls, context):
        return puppet_poll(cls, context)

    def execute(self, context):
        rig = puppet_rig(context.active_object)
        name = self.bone or (rig.data.bones.active.name if rig.data.bones.active else "")
        if name not in rig.data.bones:
            self.report({"ERROR"}, "Select a bone of the puppet (Pose Mode) first")
            return {"CANCELLED"}
        part = next((ob for ob in rig.children if ob.get(PART_KEY) == name), None)
        locked = read_only(part) or (part is not None and in_edit_mode([part]))
        if locked:
            self.report({"ERROR"}, locked)
            return {"CANCELLED"}
        try:
            image = bpy.data.images.load(self.filepath, check_existing=True)
        except RuntimeError as exc:
            self.report({"ERROR"}, f"Cannot load image: {exc}")
            return {"CANCELLED"}
        if not (image.size[0] and image.size[1]):   # Blender "loads" any file; the pixels tell
            if image.users == 0:
                bpy.data.images.remove(image)
            self.report({"ERROR"}, f"Cannot load image: {os.path.basename(self.filepath)} is not an "
                        "image Blender can read (PNG, TGA, TIFF, WebP, EXR)")
            return {"CANCELLED"}
        set_part_image(rig, name, image)
        self.report({"INFO"}, f"{os.path.basename(self.filepath)} on {name}")
        return {"FINISHED"}


class MINISKELETON_OT_shadow_theatre(bpy.types.Operator):
    """Shadow Theatre: a glowing screen behind the puppets, a warm backlight and the camera on
    the audience side, with render settings for the shadow-play look"""

    bl_idname = "scene.miniskeleton_shadow_theatre"
    bl_label = "Shadow Theatre"
    bl_options = {"REGISTER", "UNDO"}

    engine: EnumProperty(name="Render Engine", default="WORKBENCH",
                         items=[("WORKBENCH", "Workbench", "Flat colours: fast, no GPU needed"),
                                ("EEVEE", "EEVEE", "Translucent screen lit from behind")])

    def execute(self, context):
        if context.mode != "OBJECT":
            bpy.ops.object.mode_set(mode="OBJECT")
        build_shadow_theatre(context, self.engine)
        return {"FINISHED"}


classes = (MINISKELETON_OT_add_puppet, MINISKELETON_OT_bake_puppet, MINISKELETON_OT_set_part_image,
           MINISKELETON_OT_shadow_theatre)
