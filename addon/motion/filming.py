"""Filming a character for Make Video: which objects to frame, a camera that frames (or
follows) their motion over the frame range looking down past the horizon (``studio`` lays the
floor it sees), a light, the render engine and H.264 MP4 output, the frame range rendered with
progress into a file that replaces the video only when whole, and the scene's render settings
put back afterwards; a failed video takes back the camera and light it added. Rendering itself
is Blender's."""

from __future__ import annotations

import glob
import math
import os
from contextlib import contextmanager
from pathlib import Path

import bpy
from mathutils import Quaternion, Vector

from ..common.files import part_path
from .studio import half_tangents, min_pitch

ENGINES = [
    ("WORKBENCH", "Workbench", "Fast solid shading, any machine"),
    ("EEVEE", "EEVEE", "Real-time renderer (needs a GPU context)"),
    ("CYCLES", "Cycles", "Path tracer on the CPU (slow)"),
    ("SCENE", "Scene's Own", "Keep the scene's engine and its settings (e.g. a Shadow Theatre preset)"),
]


class VideoError(Exception):
    """A video that could not be made, with the reason (``render_video``)."""


def character_objects(scene) -> list[bpy.types.Object]:
    """What the camera should frame: visible meshes an armature deforms (else all visible
    meshes, else the armatures). Ground planes and props without a rig are left out."""
    meshes = [ob for ob in scene.objects if ob.type == "MESH" and ob.visible_get()]
    rigged = [ob for ob in meshes if any(m.type == "ARMATURE" and m.object for m in ob.modifiers)
              or (ob.parent is not None and ob.parent.type == "ARMATURE")]
    return rigged or meshes or [ob for ob in scene.objects if ob.type == "ARMATURE"]


def motion_boxes(scene, objects, samples: int = 24) -> list[tuple[int, Vector, Vector]]:
    """World bounding boxes (frame, lo, hi) of ``objects`` at ``samples`` frames spread evenly
    over the frame range (start and end included). Corners that are NaN or infinite (an object
    or a bone with a broken transform) are left out, and so are frames with none left."""
    current = scene.frame_current
    n = scene.frame_end - scene.frame_start + 1
    k = min(samples, n)
    frames = sorted({scene.frame_start + round(i * (n - 1) / max(k - 1, 1)) for i in range(k)})
    boxes = []
    for f in frames:
        scene.frame_set(f)
        dg = bpy.context.evaluated_depsgraph_get()
        lo = Vector((math.inf,) * 3)
        hi = Vector((-math.inf,) * 3)
        for ob in objects:
            ev = ob.evaluated_get(dg)
            for c in ev.bound_box:
                p = ev.matrix_world @ Vector(c)
                if all(map(math.isfinite, p)):
                    lo = Vector(map(min, lo, p))
                    hi = Vector(map(max, hi, p))
        if lo.x <= hi.x:
            boxes.append((f, lo, hi))
    scene.frame_set(current)
    return boxes


def union_box(boxes) -> tuple[Vector, Vector]:
    lo = Vector(map(min, *(b[1] for b in boxes))) if len(boxes) > 1 else boxes[0][1].copy()
    hi = Vector(map(max, *(b[2] for b in boxes))) if len(boxes) > 1 else boxes[0][2].copy()
    return lo, hi


def _fit_distance(lo: Vector, hi: Vector, rot: Quaternion, angle: float, aspect: float) -> float:
    """Distance along the view axis at which the box (lo, hi) fits the frame (with a margin)."""
    right, up, back = (rot @ Vector(a) for a in ((1, 0, 0), (0, 1, 0), (0, 0, 1)))
    tx, ty = half_tangents(angle, aspect)
    centre, dist, margin = (lo + hi) / 2, 0.0, 0.88
    for i in range(8):
        c = Vector((hi.x if i & 1 else lo.x, hi.y if i & 2 else lo.y, hi.z if i & 4 else lo.z)) - centre
        x, y, z = c.dot(right), c.dot(up), c.dot(back)
        dist = max(dist, z + abs(x) / (tx * margin), z + abs(y) / (ty * margin))
    return dist


def _aim(view: Vector, angle: float, aspect: float) -> Quaternion:
    """The rotation of a camera looking back along ``view`` (from the subject towards the
    camera), pitched down at least ``min_pitch`` so that it sees no horizon."""
    flat = math.hypot(view.x, view.y)
    pitch = max(math.atan2(view.z, flat), min_pitch(angle, aspect))
    look = Vector((view.x / flat * math.cos(pitch), view.y / flat * math.cos(pitch), math.sin(pitch)))
    return (-look).to_track_quat("-Z", "Y")


def _new_camera(scene) -> bpy.types.Object:
    data = bpy.data.cameras.new("MiniSkeletonCamera")
    data.lens = 40
    cam = bpy.data.objects.new("MiniSkeletonCamera", data)
    scene.collection.objects.link(cam)
    scene.camera = cam
    return cam


def _clip_for(cam: bpy.types.Object, dist: float) -> None:
    cam.data.clip_end = max(cam.data.clip_end, dist * 4)
    cam.data.clip_start = min(cam.data.clip_start, dist / 100)


def add_camera(scene, lo: Vector, hi: Vector, aspect: float) -> bpy.types.Object:
    """A fixed camera looking at the box (lo, hi) from the front-side, the whole box in view."""
    size = hi - lo
    if size.y > 1.5 * size.x:      # long travel along Y: look from the side
        view = Vector((1.0, -0.35, 0.4))
    elif size.x > 1.5 * size.y:    # along X
        view = Vector((0.35, -1.0, 0.4))
    else:
        view = Vector((1.2, -1.8, 0.7))
    cam = _new_camera(scene)
    rot = _aim(view, cam.data.angle, aspect)
    dist = _fit_distance(lo, hi, rot, cam.data.angle, aspect)
    _clip_for(cam, dist)
    cam.location = (lo + hi) / 2 + rot @ Vector((0, 0, dist))
    cam.rotation_euler = rot.to_euler()
    return cam


def add_follow_camera(scene, boxes, aspect: float) -> bpy.types.Object:
    """A camera that travels along with the character (front three-quarter view of the way it
    moves), far enough that its largest box fits and the whole height the figure bobs or jumps
    through (the camera stays level); keyed at the sampled frames."""
    lo, hi = union_box(boxes)
    c0 = (boxes[0][1] + boxes[0][2]) / 2
    c1 = (boxes[-1][1] + boxes[-1][2]) / 2
    travel = Vector((c1.x - c0.x, c1.y - c0.y, 0.0))
    if travel.length < 1e-3 * max((hi - lo).length, 1e-9):
        return add_camera(scene, lo, hi, aspect)
    t = travel.normalized()
    side = Vector((-t.y, t.x, 0.0))            # left of the direction of travel
    view = side + 0.6 * t + Vector((0, 0, 0.35))
    half = Vector(map(max, *((b[2] - b[1]) / 2 for b in boxes))) if len(boxes) > 1 else \
        (boxes[0][2] - boxes[0][1]) / 2
    half.z = (hi.z - lo.z) / 2                     # the camera stays at mid_z while the figure bobs or jumps
    cam = _new_camera(scene)
    rot = _aim(view, cam.data.angle, aspect)
    dist = _fit_distance(-half, half, rot, cam.data.angle, aspect)
    _clip_for(cam, dist)
    cam.rotation_euler = rot.to_euler()
    mid_z = (lo.z + hi.z) / 2
    for f, blo, bhi in boxes:
        c = (blo + bhi) / 2
        c.z = mid_z                                # no bobbing camera
        cam.location = c + rot @ Vector((0, 0, dist))
        cam.keyframe_insert("location", frame=f)
    return cam


def add_light(scene) -> bpy.types.Object:
    data = bpy.data.lights.new("MiniSkeletonSun", "SUN")
    data.energy = 3.0
    sun = bpy.data.objects.new("MiniSkeletonSun", data)
    sun.rotation_euler = (math.radians(50), math.radians(10), math.radians(30))
    scene.collection.objects.link(sun)
    return sun


def set_engine(scene, engine: str, on_set: bool = False) -> None:
    """Pick the render engine with settings that suit a character video; SCENE changes nothing.
    On Make Video's set (``studio.studio_set``, which draws the shadow) Workbench renders one
    sample with FXAA and without its own shadows; in a scene of the user's, with its shadows
    and the scene's anti-aliasing. VideoError when this Blender does not offer the engine
    (Cycles is an add-on that can be disabled)."""
    if engine == "SCENE":
        return
    if engine == "WORKBENCH":
        scene.render.engine = "BLENDER_WORKBENCH"
        shading = scene.display.shading
        shading.light = "STUDIO"
        shading.color_type = "MATERIAL"
        shading.show_shadows = not on_set
        shading.show_cavity = True
        if on_set:
            scene.display.render_aa = "FXAA"
    elif engine == "EEVEE":
        for name in ("BLENDER_EEVEE_NEXT", "BLENDER_EEVEE"):  # 4.2-4.4 / 5.0
            try:
                scene.render.engine = name
                break
            except TypeError:
                continue
        else:
            raise VideoError("this Blender offers no EEVEE engine")
    else:
        try:
            scene.render.engine = "CYCLES"
        except TypeError as err:   # "enum 'CYCLES' not found"
            raise VideoError("the Cycles engine is not available: enable the Cycles add-on "
                             "(Preferences > Add-ons)") from err
        scene.cycles.device = "CPU"
        scene.cycles.samples = 32


def set_mp4(scene, path: Path) -> None:
    """H.264 in MP4. Blender 5.0 first needs media_type = 'VIDEO' before FFMPEG is accepted."""
    im = scene.render.image_settings
    if hasattr(im, "media_type"):
        im.media_type = "VIDEO"
    im.file_format = "FFMPEG"
    ff = scene.render.ffmpeg
    ff.format = "MPEG4"
    ff.codec = "H264"
    ff.constant_rate_factor = "MEDIUM"
    ff.ffmpeg_preset = "GOOD"
    ff.gopsize = max(1, round(scene.render.fps / scene.render.fps_base))
    ff.audio_codec = "NONE"
    scene.render.use_file_extension = True
    scene.render.filepath = str(path)


def render_video(context, path: Path, size: tuple[int, int], fps: int, engine: str, on_set: bool = False) -> int:
    """Set the scene up for the MP4 (``size`` (even width, height); ``fps`` 0: the scene's; the
    ``engine`` and ``on_set`` of ``set_engine``) and render its frame range with progress; frames rendered.
    The frames go to a hidden file beside ``path`` (``part_path``) that replaces ``path`` only
    once the render has finished and written it: VideoError with the reason otherwise (Blender's
    render error, such as "Image too small" for a render border smaller than a pixel; a render
    that wrote no file there), with an earlier video at ``path`` as it was and no part file left."""
    scene = context.scene
    render = scene.render
    part = part_path(path)
    render.resolution_x, render.resolution_y = size
    render.resolution_percentage = 100
    if fps:
        render.fps, render.fps_base = fps, 1.0
    set_engine(scene, engine, on_set)
    set_mp4(scene, part)

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
        try:
            result = bpy.ops.render.render(animation=True)
        except RuntimeError as err:   # Blender's report, "Error: Image too small"
            raise VideoError(f"rendering failed: {str(err).strip().removeprefix('Error: ')}") from err
        if result != {"FINISHED"}:
            raise VideoError("rendering was cancelled")
        if not part.is_file() or part.stat().st_size == 0:
            raise VideoError(f"rendering wrote no file at {part}")
        try:
            os.replace(part, path)
        except OSError as err:
            raise VideoError(f"cannot put the video at {path}: {err.strerror or err}") from err
    finally:
        bpy.app.handlers.render_post.remove(progress)
        wm.progress_end()
        # The part file, and any a multi-view render wrote beside it (its _L / _R views).
        for left in glob.glob(glob.escape(str(part.with_suffix(""))) + "*"):
            Path(left).unlink(missing_ok=True)
    return total


@contextmanager
def taken_back_on_error(scene):
    """Yields a list for the objects the block adds to ``scene``: if the block raises, they
    are removed with the data and actions only they used, and the scene camera is put back."""
    camera = scene.camera
    added = []
    try:
        yield added
    except BaseException:
        scene.camera = camera
        for ob in reversed(added):
            owned = [ob.data, ob.animation_data.action if ob.animation_data else None]
            bpy.data.objects.remove(ob)
            bpy.data.batch_remove([block for block in owned if block is not None and block.users == 0])
        raise


# What Make Video sets on the scene for its render, put back afterwards (in this order: 5.0's
# media_type before file_format), as Blender's own Render Animation leaves the settings alone.
_VIDEO_SETTINGS = (
    ("render", ("engine", "resolution_x", "resolution_y", "resolution_percentage", "fps", "fps_base",
                "filepath", "use_file_extension")),
    ("render.image_settings", ("media_type", "file_format")),
    ("render.ffmpeg", ("format", "codec", "constant_rate_factor", "ffmpeg_preset", "gopsize", "audio_codec")),
    ("display", ("render_aa",)),
    ("display.shading", ("light", "color_type", "show_shadows", "show_cavity")),
    ("cycles", ("device", "samples")),
)


@contextmanager
def kept_render_settings(scene):
    """The scene's render settings (``_VIDEO_SETTINGS``) as they were when the block ends."""
    saved = []
    for path, names in _VIDEO_SETTINGS:
        try:
            owner = scene.path_resolve(path)
        except ValueError:   # e.g. no Cycles settings without the Cycles add-on
            continue
        saved += [(owner, n, getattr(owner, n)) for n in names if hasattr(owner, n)]
    try:
        yield
    finally:
        for owner, name, value in saved:
            try:
                setattr(owner, name, value)
            except (TypeError, ValueError, AttributeError):
                pass   # a value this build no longer offers: leave the video's


def default_video_path(scene) -> Path:
    if bpy.data.filepath:
        blend = Path(bpy.data.filepath)
        return blend.with_suffix(".mp4")
    return Path.cwd() / "out" / f"{bpy.path.clean_name(scene.name)}.mp4"
