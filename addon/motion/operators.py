"""Motion operators: Add Motion (head shake, walk, run as real keyframes) and Make Video (MP4).

The roles of the bones and the per-frame rotations come from the Rust core
(``miniskeleton_core.make_motion``); this module only reads the armature, writes keyframes with
``keyframe_insert`` (the same call on Blender 4.2 and on 5.0's slotted actions) and drives
Blender's renderer (the camera, light and output settings are in ``filming``).
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty
from mathutils import Matrix, Quaternion, Vector

from ..common.armatures import armature_bones
from ..common.files import make_folder
from ..common.keys import (action_fcurves, action_frame, key_rotation, key_series, keyed_action, rotation_path,
                          rotation_series, value_at)
from ..common.reports import name_list, read_only, unplaced
from ..common.transforms import axis_scales, extent, inverse
from .filming import (ENGINES, add_camera, add_follow_camera, add_light, character_objects, default_video_path,
                      kept_render_settings, motion_boxes, set_engine, set_mp4, union_box)

MOTIONS = [
    ("HEAD_SHAKE", "Head Shake", "Neck and head yaw back and forth; ears and other head children follow"),
    ("WALK", "Walk", "Walk cycle: quadrupeds in diagonal pairs, bipeds alternating; spine sway, head bob"),
    ("RUN", "Run", "Run cycle: quadrupeds in a gallop-like phase, bipeds running"),
]

ROT_PATHS = ("rotation_quaternion", "rotation_euler", "rotation_axis_angle")


def motion_armature(context: bpy.types.Context) -> bpy.types.Object | None:
    """The active armature, or the armature deforming / parenting the active mesh."""
    ob = context.active_object
    if ob is None:
        return None
    if ob.type == "ARMATURE":
        return ob
    if ob.type == "MESH":
        for mod in ob.modifiers:
            if mod.type == "ARMATURE" and mod.object is not None:
                return mod.object
        if ob.parent is not None and ob.parent.type == "ARMATURE":
            return ob.parent
    return None


def rest_matrices(arm: bpy.types.Object, names: list[str]) -> np.ndarray:
    """(b, 3, 3) rest orientation of each bone in world space (columns = bone X, Y, Z, of unit
    length: the armature's scale taken out in double precision, as the core's single-precision
    thresholds would take a rig scaled by 1e-15 or 1e25 for one with no axes)."""
    world = np.array(arm.matrix_world.to_3x3(), dtype=np.float64)
    local = np.array([np.array(arm.data.bones[n].matrix_local.to_3x3()) for n in names],
                     dtype=np.float64).reshape(-1, 3, 3)
    m = world @ local
    norms = np.linalg.norm(m, axis=1, keepdims=True)   # of each column
    return (m / np.where(norms > 0, norms, 1.0)).astype(np.float32)


def motion_skeleton(arm: bpy.types.Object, bones) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Heads and tails of ``bones`` along world axes from the armature's origin, and their world
    rest orientations (``rest_matrices``), for the core. The origin is taken off in double
    precision: the motion does not depend on where the rig stands, and 1e5 m from the world
    origin single-precision points are 8 mm apart. An armature mirrored by a negative scale is
    given as its mirror image across x = 0: there its rest frames are rotations again, and the
    local rotations that make that image walk make the armature itself walk (its mirror image's
    motion, mirrored back)."""
    origin = np.array(arm.matrix_world.translation, dtype=np.float64)
    heads, tails = bones.heads - origin, bones.tails - origin
    rest = rest_matrices(arm, bones.names)
    # in double precision: mathutils' single-precision determinant of a mirror scaled by 1e-15
    # underflows to 0, and the mirror would go unseen
    if np.linalg.det(np.array(arm.matrix_world.to_3x3(), dtype=np.float64)) < 0:
        heads[:, 0] *= -1
        tails[:, 0] *= -1
        rest[:, 0, :] *= -1
    return heads, tails, rest


def scene_metres(scene: bpy.types.Scene) -> float:
    """Metres per Blender unit: the scene's Unit Scale (1 when unset or unusable)."""
    m = float(scene.unit_settings.scale_length)
    return m if math.isfinite(m) and m > 0.0 else 1.0


def last_key_frame(ob: bpy.types.Object) -> float | None:
    """Scene frame of the last keyframe on ``ob``'s action, None without keys."""
    frames = [kp.co[0] for fc in action_fcurves(ob) for kp in fc.keyframe_points[-1:]]
    return action_frame(ob, max(frames), invert=True) if frames else None


def keyed_rotation_bones(ob: bpy.types.Object) -> set[str]:
    """Names of pose bones that have rotation keys."""
    return animated_pose_bones(action_fcurves(ob))


def keyed_location_bones(ob: bpy.types.Object) -> set[str]:
    """Names of pose bones that have location keys."""
    return animated_pose_bones(action_fcurves(ob), ("location",))


def driven_rotation_bones(ob: bpy.types.Object) -> set[str]:
    """Names of pose bones whose rotation has a driver (it overrides their keys)."""
    return animated_pose_bones(ob.animation_data.drivers if ob.animation_data is not None else [])


# Constraints that set or turn a bone's rotation (limits and location-only ones leave keys be).
TURNING_CONSTRAINTS = {"IK", "SPLINE_IK", "COPY_ROTATION", "COPY_TRANSFORMS", "DAMPED_TRACK", "LOCKED_TRACK",
                       "TRACK_TO", "STRETCH_TO", "CHILD_OF", "ARMATURE", "TRANSFORM", "ACTION"}


def constrained_rotation_bones(ob: bpy.types.Object) -> dict[str, str]:
    """{pose bone: constraint} for the bones whose rotation an active constraint overrides: its
    own (enabled, valid, influence > 0), or an IK constraint further down its chain."""
    out = {}
    for pb in ob.pose.bones:
        for c in pb.constraints:
            if c.type not in TURNING_CONSTRAINTS or c.mute or not c.is_valid or c.influence <= 0.0:
                continue
            out.setdefault(pb.name, c.name)
            if c.type == "IK":  # chain_count 0: up to the root
                up, k = pb.parent, 1
                while up is not None and (c.chain_count == 0 or k < c.chain_count):
                    out.setdefault(up.name, f"{c.name} of {pb.name}")
                    up, k = up.parent, k + 1
    return out


def animated_pose_bones(fcurves, paths: tuple[str, ...] = ROT_PATHS) -> set[str]:
    """Names of the pose bones whose rotation (or another of ``paths``) one of ``fcurves`` animates."""
    out = set()
    for fc in fcurves:
        path = fc.data_path
        if path.startswith('pose.bones["') and path.rsplit(".", 1)[-1] in paths:
            out.add(bpy.utils.unescape_identifier(path[len('pose.bones["'):path.rindex('"]')]))
    return out


def describe_roles(roles: dict, names: list[str]) -> list[str]:
    """One line per role: 'head: head (+ jaw, ear.L, ear.R)'."""
    def n(ids):  # a rig with hundreds of hair bones gets a dozen names and the count
        listed = name_list([names[i] for i in ids], 12)
        return (f"{listed} ({len(ids)} in all)" if len(ids) > 12 else listed) or "-"

    lines = [f"body: {roles['plan']}", f"root: {names[roles['root']]}", f"spine: {n(roles['spine'])}",
             f"neck: {n(roles['neck'])}", f"head: {names[roles['head']]}"
             + (f" (+ {n(roles['head_extras'])})" if roles["head_extras"] else "")]
    if roles["tail"]:
        lines.append(f"tail: {n(roles['tail'])}")
    groups = max(leg["group"] for leg in roles["legs"]) + 1
    for leg in roles["legs"]:
        where = ("front " if leg["group"] == 0 else "back " if leg["group"] == groups - 1 else
                 f"middle {leg['group']} ") if groups > 1 else ""
        lines.append(f"leg {where}{leg['side']}: {n(leg['bones'])}")
    for arm in roles["arms"]:
        lines.append(f"arm {arm['side']}: {n(arm['bones'])}")
    lines += [f"note: {note}" for note in roles["notes"]]
    return lines


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
    root_motion: BoolProperty(name="Move Forward", default=True,
                              description="Move the root bone forward (else walk on the spot)")
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
            layout.prop(self, "root_motion")
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
            out = self._motion(arm, bones, scene, fps)
        except ValueError as err:
            self.report({"ERROR"}, f"{arm.name}: {err}")
            return {"CANCELLED"}
        roles = out["roles"]
        print(f"[MiniSkeleton] roles of '{arm.name}':")
        for line in describe_roles(roles, bones.names):
            print(f"[MiniSkeleton]   {line}")

        last = last_key_frame(arm) if self.append else None
        if last is None:
            start = scene.frame_start if self.append else scene.frame_current
        else:
            start = int(math.floor(last)) + max(1, round(self.blend * fps))
        frames = self.write_keys(context, arm, bones.names, out, start)
        end = start + frames - 1
        # the timeline ends with the motion just appended (never cuts a longer one short)
        scene.frame_end = max(end, int(math.ceil(last_key_frame(arm)))) if self.append else \
            max(scene.frame_end, end)
        label = dict((m[0], m[1]) for m in MOTIONS)[self.motion]
        legs = ", ".join(bones.names[leg["bones"][0]] for leg in roles["legs"])
        self.report({"INFO"}, f"{label} ({roles['plan']}): frames {start}-{end}; head "
                    f"{bones.names[roles['head']]}, legs {legs}; spine "
                    f"{', '.join(bones.names[i] for i in roles['spine'])} (full list in the console)")
        self._warn(arm, {bones.names[int(b)] for b in out["animated"]})
        return {"FINISHED"}

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
        bones = armature_bones(arm, min_length=1e-6 * scale)
        if len(bones.names) < 3:
            self.report({"ERROR"}, f"Armature '{arm.name}' has too few deform bones for a motion")
            return None
        return arm, bones

    def _motion(self, arm, bones, scene, fps: float) -> dict:
        """The core's motion (``make_motion``) with its offsets in the armature's world units;
        ValueError when the core finds no legs or no head."""
        import miniskeleton_core as core

        heads, tails, rest = motion_skeleton(arm, bones)
        # The cadence follows the leg length in metres: the core gets the skeleton in metres,
        # by the scene's Unit Scale (in a centimetre scene, 0.01, a creature would otherwise walk
        # at the slowest cadence, as if its legs were metres long).
        metres = scene_metres(scene)
        heads, tails = heads * metres, tails * metres
        # The core works in single precision and squares lengths: a skeleton over about 1e19
        # units overflows ("the skeleton is flat"). One larger than 1e6 m or smaller than
        # 1e-3 m is given at that size, by a power of two (exact), and the offsets scaled back;
        # the cadence is clamped there all the same.
        size = float(np.linalg.norm(np.ptp(np.concatenate([heads, tails]).astype(np.float64), axis=0)))
        unit_size = 1.0
        if size > 1e6:
            unit_size = 2.0 ** math.floor(math.log2(size / 1e6))
        elif 0.0 < size < 1e-3:
            unit_size = 2.0 ** math.ceil(math.log2(size / 1e-3))
        out = core.make_motion(
            heads / unit_size, tails / unit_size, bones.parents, rest, self.motion,
            names=bones.names, fps=fps, cycles=self.cycles, duration=self.duration,
            amplitude=self.amplitude, stride=self.stride, speed=self.speed,
            root_motion=self.root_motion)
        for key in ("root_offset", "locations"):   # back in world units
            out[key] = np.asarray(out[key], dtype=np.float64) * (unit_size / metres)
        return out

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

    def write_keys(self, context, arm, names, out, start) -> int:
        scene = context.scene
        frame_before = scene.frame_current
        rot = out["rotations"]
        frames = int(out["frames"])
        animated = [int(b) for b in out["animated"]]
        pose = arm.pose.bones
        if arm.animation_data is None:
            arm.animation_data_create()
        root_pb = pose[names[out["roles"]["root"]]]
        # Where the root is now (after earlier motions), to continue from there.
        earlier = last_key_frame(arm)
        keyed_before = keyed_rotation_bones(arm)
        # feet hanging off the root (IK rigs exported without their constraints) follow their
        # legs by location keys; the core gives them in world units
        located = [int(b) for b in out["located"]]
        located_before = keyed_location_bones(arm) - {root_pb.name}
        unit = float(np.mean(axis_scales(arm.matrix_world)))

        if earlier is not None:
            # bones this motion keys for the first time hold their pose until it starts
            # (an F-curve holds its first key's value before it)
            for b in animated:
                pb = pose[names[b]]
                if pb.name not in keyed_before:
                    pb.keyframe_insert(rotation_path(pb), frame=earlier, group=pb.name)
            for b in located:
                pb = pose[names[b]]
                if pb.name not in located_before:
                    pb.keyframe_insert("location", frame=earlier, group=pb.name)
        span = range(start, start + frames)
        for b in animated:
            pb = pose[names[b]]
            before = value_at(pb, rotation_path(pb), earlier) if earlier is not None else None
            path, values = rotation_series(pb, rot[:, b], before)
            key_series(pb, path, span, values, group=pb.name)
        for b in located:
            pb = pose[names[b]]
            key_series(pb, "location", span, np.asarray(out["locations"])[:, b] / unit, group=pb.name)
        # bones keyed by earlier motions that this one leaves alone go back to rest
        animated_names = {names[b] for b in animated}
        for name in keyed_before - animated_names:
            if name in pose:
                pb = pose[name]
                key_rotation(pb, Quaternion(), start, value_at(pb, rotation_path(pb), earlier))
        for name in located_before - {names[b] for b in located}:
            if name in pose:
                pose[name].location = (0.0, 0.0, 0.0)
                pose[name].keyframe_insert("location", frame=start, group=name)

        axes = self.root_axes(arm, root_pb) if out["roles"]["single_tree"] else None
        to_local, to_world = axes if axes is not None else (None, None)
        if earlier is not None:
            scene.frame_set(int(math.floor(earlier)))
        if to_local is not None:
            world = to_world @ root_pb.location   # drop the last frame's bob
            world.z = 0.0
            root_base = to_local @ world
        else:
            root_base = arm.location.copy()
            root_base.z = self.object_base_z(arm)
        scene.frame_set(frame_before)
        if out["moves_root"]:
            if earlier is not None:   # hold still until the motion starts
                if to_local is not None and not self.has_root_keys(arm, root_pb):
                    root_pb.keyframe_insert("location", frame=earlier, group=root_pb.name)
                elif to_local is None and not self.has_object_keys(arm):
                    arm.keyframe_insert("location", frame=earlier)
            self.key_root(arm, root_pb, to_local, root_base, out["root_offset"], span)
        elif earlier is not None:
            # keep the distance travelled, drop the gait's vertical bob
            if to_local is not None and self.has_root_keys(arm, root_pb):
                world = to_world @ root_base
                world.z = 0.0
                root_pb.location = to_local @ world
                root_pb.keyframe_insert("location", frame=start, group=root_pb.name)
            elif to_local is None and self.has_object_keys(arm):
                arm.location.z = self.object_base_z(arm)
                arm.keyframe_insert("location", index=2, frame=start)
        return frames

    @staticmethod
    def has_object_keys(arm) -> bool:
        return any(fc.data_path == "location" for fc in action_fcurves(arm))

    @staticmethod
    def object_base_z(arm) -> float:
        """The object's height before any motion moved it (its first location key)."""
        for fc in action_fcurves(arm):
            if fc.data_path == "location" and fc.array_index == 2 and len(fc.keyframe_points):
                return fc.keyframe_points[0].co[1]
        return arm.location.z

    @staticmethod
    def root_axes(arm, root_pb) -> tuple[Matrix, Matrix] | None:
        """(world offset -> the root pose bone's location space, and back); None when it cannot
        translate (connected, or a singular frame), or when the rig is several trees: then the
        object moves instead. Inverted in double precision (``inverse``)."""
        if root_pb.bone.use_connect:
            return None
        m = np.array(arm.matrix_world.to_3x3(), dtype=np.float64) @ np.array(root_pb.bone.matrix_local.to_3x3())
        inv = inverse(m)
        if inv is None:
            return None
        return Matrix(inv.tolist()), Matrix(m.tolist())

    @staticmethod
    def has_root_keys(arm, root_pb) -> bool:
        path = root_pb.path_from_id("location")
        return any(fc.data_path == path for fc in action_fcurves(arm))

    @staticmethod
    def key_root(arm, root_pb, to_local, base, offsets, frames):
        """Key the root at ``base`` + world ``offsets[k]`` on ``frames[k]`` (the object when the
        root cannot move)."""
        offsets = [Vector(o) for o in np.asarray(offsets).tolist()]
        if to_local is not None:
            key_series(root_pb, "location", frames, [base + to_local @ o for o in offsets], group=root_pb.name)
        else:
            key_series(arm, "location", frames, [base + o for o in offsets])


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
            aspect = self.resolution_x / self.resolution_y
            if self.camera == "FOLLOW":
                add_follow_camera(scene, boxes, aspect)
            else:
                add_camera(scene, *union_box(boxes), aspect)
            if not any(ob.type == "LIGHT" for ob in scene.objects):
                add_light(scene)
        with kept_render_settings(scene):
            total = self.render(context, path)
        if not path.exists() or path.stat().st_size == 0:
            self.report({"ERROR"}, f"Rendering did not write {path}")
            return {"CANCELLED"}
        secs = time.perf_counter() - start_t
        w, h = self.video_size()
        self.report({"INFO"}, f"Wrote {path} ({total} frames, {w}x{h}, "
                    f"{path.stat().st_size // 1024} KiB) in {secs:.1f} s")
        return {"FINISHED"}

    def video_size(self) -> tuple[int, int]:
        """The requested width and height rounded up to even numbers (H.264 wants them even)."""
        return self.resolution_x + self.resolution_x % 2, self.resolution_y + self.resolution_y % 2

    def render(self, context, path: Path) -> int:
        """Set the scene up for the MP4 and render its frame range with progress; frames rendered."""
        scene = context.scene
        render = scene.render
        render.resolution_x, render.resolution_y = self.video_size()
        render.resolution_percentage = 100
        if self.fps:
            render.fps, render.fps_base = self.fps, 1.0
        set_engine(scene, self.engine)
        set_mp4(scene, path)
        path.unlink(missing_ok=True)   # so a failed render cannot pass for this one

        total = len(range(scene.frame_start, scene.frame_end + 1, scene.frame_step))  # as Blender renders
        wm = context.window_manager
        done = [0]

        def progress(_scene, _depsgraph=None):
            done[0] += 1
            wm.progress_update(done[0])
            if done[0] == total or done[0] % 10 == 0:
                print(f"[MiniSkeleton] video: frame {done[0]}/{total}", flush=True)

        wm.progress_begin(0, total)
        bpy.app.handlers.render_post.append(progress)
        try:
            bpy.ops.render.render(animation=True)
        finally:
            bpy.app.handlers.render_post.remove(progress)
            wm.progress_end()
        return total


classes = (MINISKELETON_OT_add_motion, MINISKELETON_OT_make_video)
