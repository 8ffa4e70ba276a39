"""Make Video's speed without a GPU: seconds per frame, and where they go.

    .venv/bin/python -m bench.bench_video [--models spot,spot-x16,horse.ply] [--frames 16] [--size 480x320]

Models: Spot the cow's bare mesh (``assets/spot``, 2930 vertices), the same subdivided twice
(``spot-x16``: each triangle cut into 16, 46.9k vertices) and the horse scan (``horse.ply`` from
``../shared/models``, 48.5k vertices; skipped with a message when absent), each auto-rigged
and bound as ``make demo`` does, with a walk keyed. ``--frames`` frames from the middle of
the walk are rendered at ``--size`` (the demo's 480 x 320) with Workbench, in one process:

- **Make Video**: the operator as ``make demo`` calls it (camera FOLLOW): its set-up (framing,
  camera, floor and shadow), then seconds per frame of the render (first frame started to
  file written: render, encode, per-frame Python).
- **Its parts**, each an animation render of the same frames on the same set, adding one
  feature at a time: Workbench with nothing (no anti-aliasing, no cavity, no shadow, no
  floor), the floor, the shadow, the cavity, FXAA (= Make Video's look); and the same frames
  without a render (frame change and evaluation: Armature modifier, shadow geometry).
  "encode and rest" is Make Video's frame minus the last of these.
- **Workbench's own shadows** in place of the set's shadow, at 1 sample (FXAA) and at 8
  (Make Video's look before the set: 8 samples, its own shadows, cavity, no floor).

Columns: wall seconds per frame, and CPU seconds per frame (every thread of the process,
Mesa's llvmpipe rasteriser's included); the machine is shared, so the CPU column moves
less from run to run. Writes out/bench_video.md. Nothing is asserted; the Blender tests
check what the video shows.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

from scripts import demo
from testkit import MODELS_DIR, ROOT, blender_session

SPOT = ROOT / "assets" / "spot" / "spot.glb"


def clock():
    return time.perf_counter(), time.process_time()


def since(start, frames: int) -> tuple[float, float]:
    """(wall, CPU) seconds per frame since ``start`` (a ``clock()``)."""
    wall, cpu = clock()
    return (wall - start[0]) / frames, (cpu - start[1]) / frames


def character(bpy, name: str):
    """A fresh scene with model ``name`` auto-rigged, bound (Heat) and walking; its meshes, or
    None when its file is absent."""
    path = SPOT if name.startswith("spot") else MODELS_DIR / name
    if not path.exists():
        print(f"skipped {name}: {path} is absent")
        return None
    blender_session.reset_scene()
    meshes, rig = demo.import_model(path)
    if name == "spot-x16":   # each triangle cut into 16, the shape unchanged
        import bmesh

        for ob in meshes:
            bm = bmesh.new()
            bm.from_mesh(ob.data)
            bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=3, use_grid_fill=True)
            bm.to_mesh(ob.data)
            bm.free()
    if rig is None:
        rig = demo.auto_rig(meshes)
    else:
        demo.bind(meshes, rig)
    if not demo.add_motion(rig, "WALK", cycles=2):
        raise SystemExit(f"{name}: no walk")
    return meshes


def middle(scene, frames: int) -> None:
    """Limit the scene's range to ``frames`` frames from the middle of its motion."""
    mid = (scene.frame_start + scene.frame_end) // 2
    scene.frame_start, scene.frame_end = mid - frames // 2, mid - frames // 2 + frames - 1


def make_video(bpy, out: Path, size) -> dict:
    """Make Video as ``make demo`` calls it: set-up seconds, and (wall, CPU) per frame from the
    first frame's start to the file written."""
    scene = bpy.context.scene
    first = []

    def started(_scene, _depsgraph=None):
        if not first:
            first.append(clock())

    bpy.app.handlers.render_pre.append(started)
    try:
        t0 = clock()
        result = bpy.ops.render.miniskeleton_make_video(filepath=str(out), engine="WORKBENCH", resolution_x=size[0],
                                                        resolution_y=size[1], camera="FOLLOW")
    finally:
        bpy.app.handlers.render_pre.remove(started)
    assert result == {"FINISHED"}, result
    n = scene.frame_end - scene.frame_start + 1
    return {"setup": first[0][0] - t0[0], "frame": since(first[0], n)}


def parts(bpy, meshes, out: Path, size) -> list[tuple[str, tuple[float, float]]]:
    """(label, (wall, CPU) per frame) of the evaluation alone and of animation renders adding
    the set's features one at a time, then with Workbench's own shadows."""
    filming, studio = (demo.addon_module(m) for m in ("motion.filming", "motion.studio"))
    scene = bpy.context.scene
    shading, display = scene.display.shading, scene.display
    n = scene.frame_end - scene.frame_start + 1
    aspect = size[0] / size[1]
    boxes = filming.motion_boxes(scene, meshes)
    rows = []
    with filming.taken_back_on_error(scene) as added, filming.kept_render_settings(scene):
        added.append(filming.add_follow_camera(scene, boxes, aspect))
        scene.render.resolution_x, scene.render.resolution_y = size
        scene.render.resolution_percentage = 100
        filming.set_engine(scene, "WORKBENCH", on_set=True)
        filming.set_mp4(scene, out)

        def render(label, **settings):
            for key, value in settings.items():
                setattr(display if key == "render_aa" else shading, key, value)
            scene.frame_set(scene.frame_start)
            start = clock()
            assert bpy.ops.render.render(animation=True) == {"FINISHED"}
            rows.append((label, since(start, n)))

        def evaluation(label):
            start = clock()
            for f in range(scene.frame_start, scene.frame_end + 1):
                scene.frame_set(f)
            rows.append((label, since(start, n)))

        with studio.studio_set(scene, meshes, boxes, scene.camera, aspect, shadow=False) as laid:
            floor = laid[0]
            floor.hide_render = True
            evaluation("frame change and evaluation, no set")
            render("Workbench, nothing", render_aa="OFF", show_cavity=False, show_shadows=False)
            floor.hide_render = False
            render("+ floor")
        with studio.studio_set(scene, meshes, boxes, scene.camera, aspect):
            evaluation("frame change and evaluation, with the set's shadow")
            render("+ shadow")
            render("+ cavity", show_cavity=True)
            render("+ FXAA (Make Video's look)", render_aa="FXAA")
        with studio.studio_set(scene, meshes, boxes, scene.camera, aspect, shadow=False):
            render("Workbench's own shadows instead, FXAA", show_shadows=True)
        render("before: 8 samples, own shadows, cavity, no floor", render_aa="8")
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--models", default="spot,spot-x16,horse.ply")
    ap.add_argument("--frames", type=int, default=16)
    ap.add_argument("--size", default="480x320")
    args = ap.parse_args(argv)
    size = tuple(int(v) for v in args.size.split("x"))
    bpy = blender_session.start()
    tmp = Path(tempfile.mkdtemp(prefix="bench_video."))
    lines = [f"bpy {bpy.app.version_string}; {args.frames} frames of a walk at {size[0]}x{size[1]}, Workbench, "
             "seconds per frame (wall / CPU of all threads)", ""]
    try:
        for name in args.models.split(","):
            meshes = character(bpy, name)
            if meshes is None:
                continue
            verts = sum(len(ob.data.vertices) for ob in meshes)
            scene = bpy.context.scene
            middle(scene, args.frames)
            video = make_video(bpy, tmp / "video.mp4", size)
            for ob in [ob for ob in scene.objects if ob.type in ("CAMERA", "LIGHT")]:
                bpy.data.objects.remove(ob)
            rows = parts(bpy, meshes, tmp / "part.mp4", size)
            look = next(secs for label, secs in rows if label.startswith("+ FXAA"))
            rows.insert(0, ("**Make Video** (operator, FOLLOW camera)", video["frame"]))
            rows.insert(len(rows) - 2, ("encode and rest (Make Video minus its look's render)",
                                        (video["frame"][0] - look[0], video["frame"][1] - look[1])))
            lines += [f"**{name}**: {verts} vertices; Make Video's set-up {video['setup']:.2f} s", "",
                      "| part | wall s/frame | CPU s/frame |", "|---|---:|---:|"]
            lines += [f"| {label} | {wall:.3f} | {cpu:.3f} |" for label, (wall, cpu) in rows]
            lines.append("")
            print("\n".join(lines[-len(rows) - 4:]), flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    text = "\n".join(lines)
    print(text)
    blender_session.write_report(ROOT / "out" / "bench_video.md", text)


if __name__ == "__main__":
    main()
