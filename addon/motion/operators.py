"""Motion operators: Add Motion (head shake, walk, run as real keyframes) and Make Video (MP4).

The roles of the bones and the per-frame rotations come from the Rust core
(``miniskeleton_core.make_motion``, called by ``planning``); ``keying`` writes them as keyframes
(the same calls on Blender 4.2 and on 5.0's slotted actions), on a Rigify rig on the controls
that ``rigify`` finds and solves, ``filming`` sets up the camera, light and output for
Blender's renderer, and ``studio`` the floor and shadow a framing camera films on. The
operators check, report and render.
"""

from __future__ import annotations

import math
import os
import time
from contextlib import nullcontext
from pathlib import Path

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty

from ..common.files import make_folder
from ..common.keys import keyed_action, locked_curves
from ..common.reports import name_list, read_only, unplaced
from ..common.transforms import axis_scales, extent
from .filming import (ENGINES, VideoError, add_camera, add_follow_camera, add_light, character_objects,
                      default_video_path, kept_render_settings, motion_boxes, render_video, taken_back_on_error,
                      union_box)
from .keying import (constrained_rotation_bones, driven_rotation_bones, last_key_frame, overridden_keys, root_bone_axes,
                     write_keys)
from .planning import describe_roles, make_motion, motion_armature, motion_bones, skinned_meshes
from .rigify import is_rigify, key_controls, merged_segments, plan_controls
from .steering import SteeringError, check_path_near, ground_field, path_points
from .studio import studio_set

MOTIONS = [
    ("HEAD_SHAKE", "Head Shake", "Neck and head yaw back and forth; ears and other head children follow"),
    ("WALK", "Walk", "Walk cycle: quadrupeds in diagonal pairs, bipeds alternating; spine sway, head bob"),
    ("RUN", "Run", "Run cycle: quadrupeds in a gallop-like phase, bipeds running"),
]


class MINISKELETON_OT_add_motion(bpy.types.Operator):
    """Key a head shake, walk or run on the active armature, from the roles of its bones"""

    bl_idname = "pose.miniskeleton_add_motion"
    bl_label = "Add Motion"
    bl_options = {"REGISTER", "UNDO"}

    motion: EnumProperty(name="Motion", items=MOTIONS, default="WALK")
    amplitude: FloatProperty(name="Amplitude", default=math.radians(30), min=0.0, max=math.pi,
                             subtype="ANGLE", description="Head shake: yaw of neck and head together")
    cycles: FloatProperty(name="Cycles", default=2.0, min=0.5, max=100.0,
                          description="Shakes (head shake) or gait cycles (walk, run)")
    duration: FloatProperty(name="Duration", default=1.5, min=0.1, max=60.0, unit="TIME_ABSOLUTE",
                            description="Head shake length in seconds")
    stride: FloatProperty(name="Stride", default=1.0, min=0.0, max=3.0,
                          description="Stride length, 1 = natural for the leg length")
    speed: FloatProperty(name="Speed", default=1.0, min=0.2, max=5.0,
                         description="Cadence, 1 = natural for the leg length")
    in_place: BoolProperty(name="In Place", default=False,
                           description="Walk or run on the spot: the cycle without its travel (the root's forward "
                           "motion taken out, as game engines want); off, the root moves along")
    path: StringProperty(name="Path", default="",
                         description="A curve object the walk or run follows (its length sets the cycles); "
                         "empty: straight ahead")
    ground: StringProperty(name="Ground", default="",
                           description="A mesh object the feet stand on, its height and slope under each foot "
                           "(cast down onto it); empty: a level floor")
    append: BoolProperty(name="Append", default=True,
                         description="Start after the last existing key (else at the current frame)")
    blend: FloatProperty(name="Blend", default=0.25, min=0.0, max=5.0, unit="TIME_ABSOLUTE",
                         description="Seconds between the last existing key and the new motion")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "motion")
        layout.prop(self, "cycles")
        if self.motion == "HEAD_SHAKE":
            layout.prop(self, "amplitude")
            layout.prop(self, "duration")
        else:
            layout.prop(self, "stride")
            layout.prop(self, "speed")
            layout.prop(self, "in_place")
            layout.prop_search(self, "path", bpy.data, "objects")
            layout.prop_search(self, "ground", bpy.data, "objects")
        layout.prop(self, "append")
        layout.prop(self, "blend")

    def execute(self, context):
        checked = self._armature(context)
        if checked is None:
            return {"CANCELLED"}
        arm, bones = checked
        scene = context.scene
        fps = scene.render.fps / scene.render.fps_base
        try:
            out = self._plan(context, arm, bones, fps)
        except ValueError as err:
            self.report({"ERROR"}, f"{arm.name}: {err}")
            return {"CANCELLED"}
        roles = out.roles
        print(f"[MiniSkeleton] roles of '{arm.name}':")
        for line in describe_roles(roles, bones.names):
            print(f"[MiniSkeleton]   {line}")

        last = last_key_frame(arm) if self.append else None
        if last is None:
            start = scene.frame_start if self.append else scene.frame_current
        else:
            start = int(math.floor(last)) + max(1, round(self.blend * fps))
        rigify = is_rigify(arm)
        if rigify:
            try:
                plan = plan_controls(context, arm, bones, out)
            except ValueError as err:
                self.report({"ERROR"}, f"{arm.name}: {err}")
                return {"CANCELLED"}
            for line in plan.notes:
                print(f"[MiniSkeleton]   rigify: {line}")
            keyed = {t.name for t in plan.moved}
        else:
            keyed = {bones.names[int(b)] for b in out.animated} | {bones.names[int(b)] for b in out.located}
        root = arm.pose.bones[bones.names[roles.root]]
        moves_object = out.moves_root and root_bone_axes(arm, root, roles) is None
        refused = overridden_keys(arm, keyed) or locked_curves(arm, keyed | {root.name}, moves_object)
        if refused:
            self.report({"ERROR"}, f"{arm.name}: {refused}")
            return {"CANCELLED"}
        if rigify:
            frames = key_controls(context, arm, plan, start)
        else:
            frames = write_keys(context, arm, bones.names, out, start)
        end = start + frames - 1
        # the timeline ends with the motion just appended (never cuts a longer one short)
        scene.frame_end = max(end, int(math.ceil(last_key_frame(arm)))) if self.append else \
            max(scene.frame_end, end)
        label = dict((m[0], m[1]) for m in MOTIONS)[self.motion]
        legs = ", ".join(bones.names[leg.bones[0]] for leg in roles.legs)
        controls = f"; Rigify controls keyed: {name_list(sorted(keyed), 12)}" if rigify else ""
        self.report({"INFO"}, f"{label} ({roles.plan}): frames {start}-{end}; head "
                    f"{bones.names[roles.head]}, legs {legs}; spine "
                    f"{', '.join(bones.names[i] for i in roles.spine)} (full list in the console){controls}")
        self._warn(arm, keyed)
        return {"FINISHED"}

    def _plan(self, context, arm, bones, fps: float) -> dict:
        """The core's motion with this operator's options, along the path and on the ground they
        name (``steering``); ValueError (a ``SteeringError`` for a bad path or ground) saying why."""
        def plan(**steer):
            return make_motion(arm, bones, context.scene, fps, self.motion, cycles=self.cycles,
                               duration=self.duration, amplitude=self.amplitude, stride=self.stride,
                               speed=self.speed, root_motion=not self.in_place, **steer)

        gait = self.motion != "HEAD_SHAKE"
        if not gait or not (self.path or self.ground):
            return plan()
        ends = np.concatenate([bones.heads, bones.tails])
        size = float(np.linalg.norm(np.ptp(ends, axis=0)))
        steer = {}
        if self.path:
            if self.in_place:
                raise SteeringError("In Place walks on the spot, so it cannot follow a path: turn In Place off "
                                    "or clear the path")
            steer["path"] = path_points(bpy.data.objects.get(self.path) or _missing("path", self.path))
            check_path_near(steer["path"], 0.5 * (ends.min(axis=0) + ends.max(axis=0)), size, self.path)
        if self.ground:
            ground = bpy.data.objects.get(self.ground) or _missing("ground", self.ground)
            # the region the walk covers: the character at rest moved by the root's offsets
            offsets = np.asarray(plan(**steer).root_offset, dtype=np.float64)[:, :2]
            margin = 0.1 * size
            region = (ends[:, :2].min(axis=0) + offsets.min(axis=0) - margin,
                      ends[:, :2].max(axis=0) + offsets.max(axis=0) + margin)
            steer["ground"] = ground_field(ground, region, size, {arm, *skinned_meshes(arm)})
        return plan(**steer)

    def _armature(self, context):
        """(armature, its deform bones) to animate, or None (reported)."""
        arm = motion_armature(context)
        if arm is None:
            self.report({"ERROR"}, "No armature: make the armature (or a mesh it deforms) active")
            return None
        if arm.mode == "EDIT":
            self.report({"ERROR"}, f"Armature '{arm.name}' is in Edit Mode: switch to Object or Pose Mode")
            return None
        locked = read_only(arm, keyed_action(arm))
        if locked:
            self.report({"ERROR"}, locked)
            return None
        nowhere = unplaced(arm)
        if nowhere:
            self.report({"ERROR"}, nowhere)
            return None
        scale = max(extent(arm), 1e-30)
        bones = motion_bones(arm, min_length=1e-6 * scale)
        if is_rigify(arm):
            bones = merged_segments(arm, bones)
        if len(bones.names) < 3:
            self.report({"ERROR"}, f"Armature '{arm.name}' has too few deform bones for a motion")
            return None
        return arm, bones

    def _warn(self, arm, keyed: set[str]):
        """Warnings on what keeps the ``keyed`` bones' motion from showing as keyed: uneven
        scale, rotation drivers, Rest Position, constraints."""
        scale = axis_scales(arm.matrix_world)   # a mirror's negative scale is even
        if max(scale) > 1.001 * min(scale):
            self.report({"WARNING"}, f"Armature '{arm.name}' is scaled unevenly ({scale[0]:.3g}, {scale[1]:.3g}, "
                        f"{scale[2]:.3g}): its bones shear as they turn, so the motion looks stretched; "
                        "apply the scale first (Ctrl+A > Scale)")
        driven = sorted(driven_rotation_bones(arm) & keyed)
        if driven:
            self.report({"WARNING"}, f"{len(driven)} keyed bone(s) have rotation drivers, which "
                        f"override their keys: {name_list(driven, 6)}")
        if arm.data.pose_position == "REST":
            self.report({"WARNING"}, f"Armature '{arm.name}' shows its Rest Position, so the motion does not "
                        "show: switch to Pose Position (Armature properties > Pose Position)")
        constrained = constrained_rotation_bones(arm)
        held = sorted(n for n in constrained if n in keyed)
        if held:
            named = [f"{n} ({constrained[n]})" for n in held]
            self.report({"WARNING"}, f"{len(held)} keyed bone(s) follow constraints that override their keys: "
                        f"{name_list(named, 6)}; mute those constraints (or set their influence to 0) "
                        "to see the motion")


# ---------------------------------------------------------------------------- video

class MINISKELETON_OT_make_video(bpy.types.Operator):
    """Render the scene's frame range to an MP4 (H.264); adds a camera and light if there is none"""

    bl_idname = "render.miniskeleton_make_video"
    bl_label = "Make Video (MP4)"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(name="File", subtype="FILE_PATH", default="",
                             description="Output .mp4; empty = next to the .blend, else out/")
    engine: EnumProperty(name="Engine", items=ENGINES, default="WORKBENCH")
    resolution_x: IntProperty(name="Width", default=960, min=16, max=7680)
    resolution_y: IntProperty(name="Height", default=540, min=16, max=4320)
    fps: IntProperty(name="FPS", default=0, min=0, max=240, description="0 = the scene's frame rate")
    camera: EnumProperty(
        name="Camera", default="IF_MISSING",
        items=[("IF_MISSING", "Add If Missing", "Use the scene camera; add one framing the whole "
                "motion (and a light) when there is none"),
               ("NEW", "New Framing Camera", "Always add a camera framing the whole motion"),
               ("FOLLOW", "New Following Camera", "Always add a camera that travels along with "
                "the character, closer than one framing the whole motion"),
               ("SCENE", "Scene Camera", "Use the scene camera only")])
    floor: BoolProperty(name="Floor and Shadow", default=True,
                        description="With a camera it adds: film the character on a floor that fills the view, "
                        "with its shadow, laid for the render only (not when the scene has a ground under it)")

    def execute(self, context):
        scene = context.scene
        start_t = time.perf_counter()
        path = Path(bpy.path.abspath(self.filepath)) if self.filepath else default_video_path(scene)
        if path.suffix.lower() != ".mp4":
            path = path.with_suffix(".mp4")
        why = make_folder(path)
        if why is None and not os.access(path.parent, os.W_OK):
            why = "its folder is not writable"
        if why is not None:
            self.report({"ERROR"}, f"Cannot write the video to {path}: {why}")
            return {"CANCELLED"}
        boxes = None   # what a new camera frames; None: the scene camera films
        if scene.camera is None or self.camera in ("NEW", "FOLLOW"):
            if self.camera == "SCENE":
                self.report({"ERROR"}, "The scene has no camera")
                return {"CANCELLED"}
            objects = character_objects(scene)
            if not objects:
                self.report({"ERROR"}, "Nothing to film: no visible mesh or armature")
                return {"CANCELLED"}
            boxes = motion_boxes(scene, objects)
            if not boxes:
                self.report({"ERROR"}, "Nothing to film: the objects to frame have a NaN or infinite "
                            f"transform or shape: {name_list([ob.name for ob in objects])} "
                            "(Object Properties > Transform)")
                return {"CANCELLED"}
        # One transaction: a render that fails takes back the camera and light, the render
        # settings are put back either way, and an earlier video is replaced only by a whole one.
        try:
            with taken_back_on_error(scene) as added, kept_render_settings(scene):
                if boxes is not None:
                    aspect = self.resolution_x / self.resolution_y
                    added.append(add_follow_camera(scene, boxes, aspect) if self.camera == "FOLLOW"
                                 else add_camera(scene, *union_box(boxes), aspect))
                    if not any(ob.type == "LIGHT" for ob in scene.objects):
                        added.append(add_light(scene))
                # The floor and shadow, when it frames the character itself, are for the render only.
                framing = boxes is not None and self.engine != "SCENE" and self.floor
                with (studio_set(scene, objects, boxes, scene.camera, aspect, shadow=self.engine == "WORKBENCH")
                      if framing else nullcontext([])) as laid:
                    total = render_video(context, path, self.video_size(), self.fps, self.engine, on_set=bool(laid))
        except VideoError as err:
            kept = "the scene and the earlier video are as they were" if path.exists() else "the scene is as it was"
            self.report({"ERROR"}, f"No video made: {err}; {kept}")
            return {"CANCELLED"}
        secs = time.perf_counter() - start_t
        w, h = self.video_size()
        self.report({"INFO"}, f"Wrote {path} ({total} frames, {w}x{h}, "
                    f"{path.stat().st_size // 1024} KiB) in {secs:.1f} s")
        return {"FINISHED"}

    def video_size(self) -> tuple[int, int]:
        """The requested width and height rounded up to even numbers (H.264 wants them even)."""
        return self.resolution_x + self.resolution_x % 2, self.resolution_y + self.resolution_y % 2


def _missing(what: str, name: str):
    raise SteeringError(f"no object named '{name}' for the {what}")


classes = (MINISKELETON_OT_add_motion, MINISKELETON_OT_make_video)
