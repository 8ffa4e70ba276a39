"""The MiniSkeleton demo, headless: import Spot the cow's bare mesh (assets/spot, public domain),
Auto Rig it (a Rigify-named skeleton found in the mesh, bound with Auto Weights (Heat)), pose it,
render a PNG with Workbench and save the .blend; then key a head shake, a walk along an
S-shaped curve and a run on it, render them to an MP4 and save the .blend again. No joint is placed by hand.

    python -m scripts.demo --out out [--model path/to/model.glb]

Any mesh goes the same way (OBJ, PLY, GLB/glTF, FBX; +Z up, standing on its feet, such as
../shared/models/cow.obj or horse.ply): Auto Rig finds its skeleton. A model that comes with an
armature keeps it and is bound to it. A motion the rig cannot take (too few bones, no legs) is
skipped with the operator's reason, and so is the video when no motion was added.

`make demo` runs this after building and packaging the extension. Prints one line per stage
with the time it took.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path


from testkit import blender_session


SPOT = Path(__file__).resolve().parents[1] / "assets" / "spot" / "spot.glb"


def import_model(path: Path):
    try:
        _, meshes, rigs = blender_session.import_model(path)
    except ValueError as err:
        raise SystemExit(str(err)) from None
    if not meshes:
        raise SystemExit(f"{path} has no mesh with faces")
    return meshes, (rigs[0] if rigs else None)


def addon_module(name: str):
    """The installed add-on's module ``name`` (common.meshes, puppet.build, ...)."""
    import importlib

    return importlib.import_module(f"{blender_session.ADDON_MODULE}.{name}")


def auto_rig(meshes):
    """Auto Rig: a skeleton found in the mesh (Rigify's metarig names), bound with Heat; the
    operator's report names the template, the bones and the time."""
    import bpy

    select(meshes, meshes[0])
    try:
        result = bpy.ops.object.miniskeleton_auto_rig(bind=True)
    except RuntimeError as err:  # its error report: the mesh is no character it can rig
        raise SystemExit(f"auto rig failed: {str(err).strip()}") from None
    if result != {"FINISHED"}:
        raise SystemExit(f"auto rig failed: {result}")
    rig = bpy.context.view_layer.objects.active
    print(f"[demo]   {rig.name}: {len(rig.data.bones)} bones, "
          f"{sum(len(ob.vertex_groups) for ob in meshes)} groups written")
    return rig


def select(meshes, rig):
    """Select ``meshes`` and ``rig`` (and nothing else), ``rig`` active, in Object Mode: what the
    operators below act on, as when a rigger clicks the meshes and then the armature."""
    import bpy

    for ob in bpy.context.view_layer.objects:
        ob.select_set(ob in meshes or ob == rig)
    bpy.context.view_layer.objects.active = rig
    if bpy.context.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")


def bind(meshes, rig):
    import bpy

    select(meshes, rig)
    result = bpy.ops.object.miniskeleton_auto_weights(method="HEAT")
    if result != {"FINISHED"}:
        raise SystemExit(f"binding failed: {result}")
    groups = sum(len(ob.vertex_groups) for ob in meshes)
    print(f"[demo]   {sum(len(ob.data.vertices) for ob in meshes)} vertices, {groups} groups written")


def pose(rig):
    """A lively pose: head turned, one front leg raised, tail up (by bone-name keywords)."""
    import bpy

    wanted = {"head": (0, 0, 30), "neck": (-15, 0, 10), "upper_arm.L": (-50, 0, 0),
              "forearm.L": (70, 0, 0), "thigh.R": (30, 0, 0), "tail.001": (-30, 0, 0),
              "tail.002": (-20, 0, 0)}
    if "spine.011" in rig.pose.bones:  # Auto Rig's quadruped (Rigify's names): head, neck, front leg, tail
        wanted = {"spine.011": (0, 0, 25), "spine.010": (-10, 0, 0), "front_thigh.L": (-40, 0, 0),
                  "front_shin.L": (60, 0, 0), "spine.002": (20, 0, 0), "spine.001": (15, 0, 0)}
    elif "spine.006" in rig.pose.bones:  # Auto Rig's biped
        wanted = {"spine.006": (0, 0, 25), "spine.005": (-10, 0, 0), "upper_arm.L": (-50, 0, 0),
                  "forearm.L": (70, 0, 0), "thigh.R": (30, 0, 0)}
    posed = 0
    for pb in rig.pose.bones:
        for key, deg in wanted.items():
            if pb.name.lower() == key.lower() or (key in ("head", "neck") and key in pb.name.lower()):
                pb.rotation_mode = "XYZ"
                pb.rotation_euler = [math.radians(a) for a in deg]
                posed += 1
                break
    if posed == 0:  # unknown naming: bend the first few bones that have children
        for pb in [p for p in rig.pose.bones if p.children][:3]:
            pb.rotation_mode = "XYZ"
            pb.rotation_euler = (math.radians(25), 0, 0)
    bpy.context.view_layer.update()


def facing(rig):
    """The horizontal way an Auto Rig skeleton faces (hips to head for a quadruped, heel to toe
    for a biped), else -Y (Blender's front view), as a unit mathutils Vector."""
    from mathutils import Vector

    bones, m = rig.data.bones, rig.matrix_world
    if "spine.011" in bones and "spine.004" in bones:
        way = m @ bones["spine.011"].tail_local - m @ bones["spine.004"].head_local
    elif "toe.L" in bones and "foot.L" in bones:
        way = m @ bones["toe.L"].tail_local - m @ bones["foot.L"].head_local
    else:
        way = Vector((0.0, -1.0, 0.0))
    way.z = 0.0
    return way.normalized() if way.length > 0 else Vector((0.0, -1.0, 0.0))


def s_curve(meshes, rig, radius: float = 1.0):
    """A poly curve from under the rig's root bone: a quarter turn left then one right, each of a
    radius of ``radius`` times the character's size, so it ends heading the way it started (the
    run goes on straight). Returns its name."""
    import bpy
    import numpy as np

    box = posed_box(meshes)
    size = radius * float(np.linalg.norm(box[1] - box[0]))
    fwd = np.array(facing(rig)[:])
    left = np.array([-fwd[1], fwd[0], 0.0])
    root = next(b for b in rig.data.bones if b.parent is None)
    start = np.array((rig.matrix_world @ root.head_local)[:])
    start[2] = 0.0
    a = np.linspace(0.0, math.pi / 2, 24)[:, None]
    first = start + size * (left - np.cos(a) * left + np.sin(a) * fwd)
    second = first[-1] + size * (fwd - np.cos(a) * fwd + np.sin(a) * left)
    points = np.concatenate([first, second[1:]])
    cu = bpy.data.curves.new("Path", "CURVE")
    cu.dimensions = "3D"
    sp = cu.splines.new("POLY")
    sp.points.add(len(points) - 1)
    for p, q in zip(sp.points, points):
        p.co = (*q, 1.0)
    ob = bpy.data.objects.new("Path", cu)
    bpy.context.scene.collection.objects.link(ob)
    return ob.name


def frame_camera(meshes, rig):
    """A camera in front of the character, to its left, framing the evaluated meshes."""
    import bpy
    from mathutils import Vector

    scene = bpy.context.scene
    lo, hi = posed_box(meshes)
    centre, radius = (lo + hi) / 2, (hi - lo).length / 2
    cam_data = bpy.data.cameras.new("DemoCamera")
    cam_data.lens = 50
    cam = bpy.data.objects.new("DemoCamera", cam_data)
    scene.collection.objects.link(cam)
    front = facing(rig)
    left = Vector((0.0, 0.0, 1.0)).cross(front)
    direction = (1.8 * front + 1.2 * left + Vector((0.0, 0.0, 0.7))).normalized()
    cam.location = centre + direction * radius * 3.2
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam_data.clip_end = max(cam_data.clip_end, radius * 8)
    scene.camera = cam


def posed_box(meshes):
    """World bounding box (lo, hi) of the evaluated ``meshes`` as they are posed now."""
    import bpy
    from mathutils import Vector

    depsgraph = bpy.context.evaluated_depsgraph_get()
    pts = []
    for ob in meshes:
        ev = ob.evaluated_get(depsgraph)
        pts += [ev.matrix_world @ Vector(c) for c in ev.bound_box]
    return Vector(min(p[i] for p in pts) for i in range(3)), Vector(max(p[i] for p in pts) for i in range(3))


def render_png(path: Path, meshes, size=(960, 640)):
    """The still, on Make Video's set (floor and shadow, laid for this render only) with its
    Workbench look, anti-aliased with 8 samples."""
    import bpy

    filming, studio = addon_module("motion.filming"), addon_module("motion.studio")
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(path)
    boxes = [(scene.frame_current, *posed_box(meshes))]
    with studio.studio_set(scene, meshes, boxes, scene.camera, size[0] / size[1]) as laid:
        filming.set_engine(scene, "WORKBENCH", on_set=bool(laid))
        scene.display.render_aa = "8"
        bpy.ops.render.render(write_still=True)
    if not path.exists():
        raise SystemExit(f"render did not write {path}")


def rest_pose(rig):
    """Back to the rest pose before the motions (the still pose above was for the PNG)."""
    import bpy

    for pb in rig.pose.bones:
        pb.location = (0, 0, 0)
        pb.rotation_quaternion = (1, 0, 0, 0)
        pb.rotation_euler = (0, 0, 0)
        pb.scale = (1, 1, 1)
    bpy.context.view_layer.update()


def add_motion(rig, motion, **props) -> bool:
    """pose.miniskeleton_add_motion on the rig, appended after the keys already there; False
    (and the operator's reason printed) when the rig cannot take this motion."""
    import bpy

    select([], rig)
    try:
        result = bpy.ops.pose.miniskeleton_add_motion(motion=motion, **props)
    except RuntimeError as err:  # the operator's error report (a rig without legs, say)
        print(f"[demo]   skipped {motion}: {str(err).strip()}")
        return False
    if result != {"FINISHED"}:
        raise SystemExit(f"{motion} failed: {result}")
    scene = bpy.context.scene
    print(f"[demo]   timeline now {scene.frame_start}-{scene.frame_end}")
    return True


def render_video(path: Path, size=(480, 320)):
    """render.miniskeleton_make_video: Workbench MP4, a new camera travelling with the creature
    (the still's camera stays in the file) over the floor Make Video lays for it."""
    import bpy

    result = bpy.ops.render.miniskeleton_make_video(
        filepath=str(path), engine="WORKBENCH", resolution_x=size[0], resolution_y=size[1],
        camera="FOLLOW")
    if result != {"FINISHED"} or not path.exists():
        raise SystemExit(f"video failed: {result}")
    print(f"[demo]   {path.stat().st_size // 1024} KiB")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="out", type=Path)
    ap.add_argument("--model", type=Path, default=SPOT, help="a mesh to Auto Rig (OBJ, PLY, GLB/glTF, FBX; +Z "
                    "up, standing), or a model with its armature (default: Spot the cow, assets/spot/spot.glb)")
    ap.add_argument("--puppet", help="shadow-play clip instead: five-rod, three-rod, prop, strip, quadruped")
    args = ap.parse_args(argv)
    if args.puppet:
        from scripts import puppet_demo

        return puppet_demo.main(["--out", str(args.out), "--puppet", args.puppet])
    args.out.mkdir(parents=True, exist_ok=True)

    st = blender_session.Stages()
    bpy = st.run("start Blender and install the extension", blender_session.start)
    st.run("empty scene", blender_session.reset_scene)
    meshes, rig = st.run(f"import {args.model.name}", import_model, args.model)
    if rig is None:
        rig = st.run("auto rig and bind with Auto Weights (Heat)", auto_rig, meshes)
    else:
        st.run("bind with Auto Weights (Heat)", bind, meshes, rig)
    st.run("pose", pose, rig)
    st.run("camera", frame_camera, meshes, rig)
    png = args.out.resolve() / "demo.png"
    st.run("render PNG (Workbench)", render_png, png, meshes)
    blend = args.out.resolve() / "demo.blend"
    st.run("save .blend", lambda: bpy.ops.wm.save_as_mainfile(filepath=str(blend)))
    print(f"[demo] wrote {png} and {blend}")
    st.run("rest pose", rest_pose, rig)
    added = [st.run("motion: head shake", lambda: add_motion(rig, "HEAD_SHAKE", duration=1.25, cycles=2)),
             st.run("motion: walk along a curve", lambda: add_motion(rig, "WALK", path=s_curve(meshes, rig))),
             st.run("motion: run", lambda: add_motion(rig, "RUN", cycles=2))]
    if not any(added):
        print("[demo] no motion fits this rig: no video")
        st.total()
        return
    mp4 = args.out.resolve() / "demo.mp4"
    st.run("render MP4 (Workbench)", render_video, mp4)
    bpy.context.preferences.filepaths.save_version = 0  # no demo.blend1 next to it
    st.run("save .blend with the motion", lambda: bpy.ops.wm.save_as_mainfile(filepath=str(blend)))
    print(f"[demo] wrote {mp4} and {blend}")
    st.total()


if __name__ == "__main__":
    main()
