"""What Make Video's video shows, read back from the MP4 it writes (decoded by Blender's
sequencer): the floor it lays fills every frame, the character stands apart from it, and its
shadow lies at its feet; a scene with a ground or a camera of its own gets no floor; the set is
gone after the render. The rest of Make Video is tested in test_motion.py."""

import math
import tempfile
from pathlib import Path

import bpy
import numpy as np
import pytest
from mathutils import Vector

from testkit import builders as B
from testkit import measures
from testkit import creature


def walker(cycles=1):
    """The generated quadruped, bound (Nearest Bones, quick) and walking; its body."""
    body, arm = creature.build_body(subdivisions=1), creature.build_armature()
    B.select_for_parenting([body], arm)
    assert bpy.ops.object.miniskeleton_auto_weights(method="BILINEAR") == {"FINISHED"}
    B.set_active(arm)
    assert bpy.ops.pose.miniskeleton_add_motion(motion="WALK", cycles=cycles) == {"FINISHED"}
    return body


def magenta_world():
    """A world of a colour the set never shows, for Workbench's background."""
    world = bpy.data.worlds.new("Magenta")
    world.color = (1.0, 0.0, 1.0)
    bpy.context.scene.world = world


def decoded(path: Path) -> list[np.ndarray]:
    """Every frame of the movie at ``path``, (h, w, 3) floats in 0..1 as stored (top row first),
    rendered by the sequencer of a scene of its own (removed afterwards)."""
    scene = bpy.data.scenes.new("Decode")
    folder = Path(tempfile.mkdtemp(prefix="decode."))
    try:
        editor = scene.sequence_editor_create()
        strips = editor.strips if hasattr(editor, "strips") else editor.sequences   # 5.0 / 4.2
        clip = strips.new_movie("clip", str(path), channel=1, frame_start=1)
        render = scene.render
        render.resolution_x, render.resolution_y = clip.elements[0].orig_width, clip.elements[0].orig_height
        render.resolution_percentage = 100
        render.image_settings.file_format = "PNG"
        scene.view_settings.view_transform = "Standard"
        frames = []
        for f in range(1, clip.frame_final_duration + 1):
            scene.frame_current = f
            render.filepath = str(folder / f"{f}.png")
            bpy.ops.render.render(write_still=True, scene=scene.name)
            img = bpy.data.images.load(render.filepath)
            w, h = img.size
            frames.append(np.array(img.pixels[:], np.float32).reshape(h, w, 4)[::-1, :, :3])
            bpy.data.images.remove(img)
        return frames
    finally:
        bpy.data.scenes.remove(scene)


def is_magenta(px: np.ndarray) -> np.ndarray:
    return (px[..., 0] - px[..., 1] > 0.3) & (px[..., 2] - px[..., 1] > 0.3)


def luminance(px: np.ndarray) -> np.ndarray:
    return px @ np.array([0.2126, 0.7152, 0.0722], np.float32)


def blocks():
    """Names of the data-blocks a set could leave behind."""
    return {kind: {b.name for b in getattr(bpy.data, kind)}
            for kind in ("objects", "meshes", "materials", "node_groups", "cameras", "lights")}


def video_frames(scene):
    return list(range(scene.frame_start, scene.frame_end + 1, scene.frame_step))


def silhouette(uv: np.ndarray, tris: np.ndarray, size) -> np.ndarray:
    """(h, w) bool: the pixels whose centres lie in a triangle ``tris`` (m, 3) of the points
    projected to ``uv`` (n, 2) pixel columns and rows."""
    w, h = size
    mask = np.zeros((h, w), bool)
    for a, b, c in uv[tris]:
        lo = np.maximum(np.floor(np.minimum(np.minimum(a, b), c)).astype(int), 0)
        hi = np.minimum(np.ceil(np.maximum(np.maximum(a, b), c)).astype(int), [w - 1, h - 1])
        if (hi < lo).any():
            continue
        cols, rows = np.meshgrid(np.arange(lo[0], hi[0] + 1) + 0.5, np.arange(lo[1], hi[1] + 1) + 0.5)
        p = np.stack([cols, rows], -1)
        area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        if abs(area) < 1e-12:
            continue
        s = [((q[0] - o[0]) * (p[..., 1] - o[1]) - (q[1] - o[1]) * (p[..., 0] - o[0])) * np.sign(area)
             for o, q in ((a, b), (b, c), (c, a))]
        mask[lo[1]:hi[1] + 1, lo[0]:hi[0] + 1] |= (s[0] >= 0) & (s[1] >= 0) & (s[2] >= 0)
    return mask


def pixels_of(scene, cam, points: np.ndarray, size) -> np.ndarray:
    """(n, 2) pixel columns and rows (top row 0) of world ``points`` (n, 3) in ``cam``'s view."""
    w, h = size
    dg = bpy.context.evaluated_depsgraph_get()
    proj = np.array(cam.calc_matrix_camera(dg, x=w, y=h)) @ np.array(cam.matrix_world.inverted())
    q = np.c_[points, np.ones(len(points))] @ proj.T
    ndc = q[:, :2] / q[:, 3:4]
    return np.c_[(ndc[:, 0] + 1) / 2 * w, (1 - ndc[:, 1]) / 2 * h]


@pytest.mark.parametrize("size", [(96, 64), (48, 96)])
@pytest.mark.parametrize("camera", ["FOLLOW", "NEW"])
def test_the_floor_fills_every_frame_and_goes_with_the_render(tmp_path, camera, size):
    """A walk filmed by a camera Make Video adds, in a landscape and a portrait video: no pixel
    of any frame shows the world behind the floor (the camera looks down past the horizon, the
    floor reaches past the frame's corners and inside the clip end), and after the render the
    scene has the camera and light and nothing else of the set: no floor, shadow, material or
    node group."""
    walker()
    magenta_world()
    scene = bpy.context.scene
    scene.frame_step = max(1, (scene.frame_end - scene.frame_start) // 8)
    before = blocks()
    out = tmp_path / "walk.mp4"
    assert bpy.ops.render.miniskeleton_make_video(filepath=str(out), resolution_x=size[0], resolution_y=size[1],
                                                  camera=camera) == {"FINISHED"}
    frames = decoded(out)
    assert len(frames) == len(video_frames(scene)) >= 8
    for k, px in enumerate(frames):
        assert not is_magenta(px).any(), (k, int(is_magenta(px).sum()))
    added = {kind: names - before[kind] for kind, names in blocks().items()}
    assert {kind: len(names) for kind, names in added.items()} == \
        dict(objects=2, meshes=0, materials=0, node_groups=0, cameras=1, lights=1), added


def test_a_scene_camera_that_sees_the_horizon_shows_the_world_and_gets_no_floor(tmp_path):
    """The check above can fail: the scene's own camera, level with the walker, sees the world
    above the horizon, and Make Video lays no floor in a scene it does not frame itself."""
    body = walker()
    magenta_world()
    scene = bpy.context.scene
    scene.frame_end = scene.frame_start + 1
    cam = bpy.data.objects.new("Level", bpy.data.cameras.new("Level"))
    scene.collection.objects.link(cam)
    cam.location = body.matrix_world.translation + Vector((0.0, -8.0, 1.0))
    cam.rotation_euler = (math.radians(90), 0.0, 0.0)
    scene.camera = cam
    out = tmp_path / "level.mp4"
    assert bpy.ops.render.miniskeleton_make_video(filepath=str(out), resolution_x=96, resolution_y=64) == {"FINISHED"}
    assert all(is_magenta(px).mean() > 0.3 for px in decoded(out))


def shade_at_feet(px: np.ndarray, inside: np.ndarray, foot) -> tuple[float, float, int]:
    """Of a frame ``px`` with the character's pixels ``inside``: the median luminance of the
    character's pixels away from its edges, that of the floor at the top of the frame (far
    behind it), and how many floor pixels within 8 % of the width of the pixel ``foot`` are
    darker than 0.8 times the darkest floor square there (shadow)."""
    h, w = inside.shape
    core = inside.copy()                                          # away from its edges, which blend
    core[1:-1, 1:-1] &= inside[:-2, 1:-1] & inside[2:, 1:-1] & inside[1:-1, :-2] & inside[1:-1, 2:]
    lum = luminance(px)
    floor = lum[:h // 5][~inside[:h // 5]]
    rows, cols = np.mgrid[0:h, 0:w]
    near = (np.hypot(cols - foot[0], rows - foot[1]) < 0.08 * w) & ~inside
    return float(np.median(lum[core])), float(np.median(floor)), int((lum[near] < 0.8 * np.percentile(floor, 2)).sum())


def test_the_character_stands_apart_from_the_floor_with_its_shadow_at_its_feet(tmp_path):
    """In every frame of a followed walk the character's pixels are much lighter than the
    floor's (a light figure on a dark floor), and beside the foot that stands on the floor there
    are pixels darker than any floor square: its shadow. A frame rendered on the same set
    without the shadow has none."""
    body = walker()
    scene = bpy.context.scene
    scene.frame_step = max(1, (scene.frame_end - scene.frame_start) // 6)
    size = (240, 160)
    out = tmp_path / "walk.mp4"
    assert bpy.ops.render.miniskeleton_make_video(filepath=str(out), resolution_x=size[0], resolution_y=size[1],
                                                  camera="FOLLOW") == {"FINISHED"}
    cam = scene.camera
    body.data.calc_loop_triangles()
    tris = np.array([tri.vertices[:] for tri in body.data.loop_triangles])

    def seen(f):
        """The character's pixels at frame ``f``, and the pixel of its lowest point (a foot)."""
        scene.frame_set(f)
        verts = measures.evaluated_world_vertices(body)
        uv = pixels_of(scene, cam, verts, size)
        return silhouette(uv, tris, size), uv[np.argmin(verts[:, 2])]

    for f, px in zip(video_frames(scene), decoded(out)):
        figure, floor, shadow = shade_at_feet(px, *seen(f))
        assert figure > max(1.5 * floor, floor + 0.15), (f, figure, floor)
        assert shadow >= 10, (f, shadow)

    filming, studio = B.addon("motion.filming"), B.addon("motion.studio")
    f = scene.frame_start
    boxes = filming.motion_boxes(scene, [body])
    still = tmp_path / "still.png"
    with filming.kept_render_settings(scene), \
            studio.studio_set(scene, [body], boxes, cam, size[0] / size[1], shadow=False) as laid:
        assert [ob.type for ob in laid] == ["MESH"]                 # the floor alone
        filming.set_engine(scene, "WORKBENCH", on_set=True)
        scene.render.resolution_x, scene.render.resolution_y = size
        scene.render.image_settings.file_format = "PNG"
        scene.render.filepath = str(still)
        scene.frame_set(f)
        bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(str(still))
    px = np.array(img.pixels[:], np.float32).reshape(size[1], size[0], 4)[::-1, :, :3]
    assert shade_at_feet(px, *seen(f))[2] < 3


def laid_while_rendering():
    """A render_pre handler and the list it fills, per frame rendered, with the names of the
    scene's mesh objects and whether Workbench draws its own shadows."""
    seen = []

    def handler(scene, _depsgraph=None):
        seen.append((sorted(ob.name for ob in scene.objects if ob.type == "MESH"),
                     scene.display.shading.show_shadows))

    return handler, seen


@pytest.mark.parametrize("engine", ["WORKBENCH", "CYCLES"])
def test_the_set_is_laid_for_the_render_only_unless_off_or_the_scene_has_a_ground(tmp_path, engine):
    """While Make Video renders with the camera it adds, the scene holds the floor and (with
    Workbench, which then draws no shadows of its own) the character's shadow; Cycles, which
    casts real shadows from the sun Make Video adds, gets the floor alone. With Floor and Shadow
    off, or in a scene with a ground of its own under the character, neither is laid, and
    Workbench draws its own shadows."""
    body = walker()
    scene = bpy.context.scene
    scene.frame_end = scene.frame_start + 1
    if engine == "CYCLES":
        scene.cycles.samples = 1
    handler, seen = laid_while_rendering()
    bpy.app.handlers.render_pre.append(handler)
    try:
        assert bpy.ops.render.miniskeleton_make_video(filepath=str(tmp_path / "set.mp4"), resolution_x=32,
                                                      resolution_y=32, camera="NEW", engine=engine) == {"FINISHED"}
        shadow = [f"MiniSkeletonShadow.{body.name}"] if engine == "WORKBENCH" else []
        assert seen == [(sorted([body.name, "MiniSkeletonFloor", *shadow]), False)] * 2, seen
        assert sorted(ob.name for ob in scene.objects if ob.type == "MESH") == [body.name]
        seen.clear()
        assert bpy.ops.render.miniskeleton_make_video(filepath=str(tmp_path / "bare.mp4"), resolution_x=32,
                                                      resolution_y=32, camera="NEW", engine=engine,
                                                      floor=False) == {"FINISHED"}
        assert seen == [([body.name], engine == "WORKBENCH")] * 2, seen
        seen.clear()
        lowest = measures.evaluated_world_vertices(body)[:, 2].min()
        bpy.ops.mesh.primitive_plane_add(size=50.0, location=(0.0, 0.0, lowest))
        ground = bpy.context.active_object
        assert bpy.ops.render.miniskeleton_make_video(filepath=str(tmp_path / "ground.mp4"), resolution_x=32,
                                                      resolution_y=32, camera="NEW", engine=engine) == {"FINISHED"}
        assert seen == [(sorted([body.name, ground.name]), engine == "WORKBENCH")] * 2, seen
    finally:
        bpy.app.handlers.render_pre.remove(handler)
