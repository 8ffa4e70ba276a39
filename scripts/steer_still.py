"""The README's steering still: Spot the cow (assets/spot, public domain), auto-rigged, walks
an S-shaped curve over bumpy ground (Add Motion with Path and Ground); five moments of the walk
are frozen as copies of the posed mesh and rendered together in one Workbench PNG, the path
drawn on the ground.

    python -m scripts.steer_still --out docs/images/motion_steer.png

Prints the operator's report and the render's path.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from scripts import demo
from testkit import blender_session

MOMENTS = 5   # frozen copies along the walk
RADIUS = 1.6  # the S-curve's turns, in the character's size


def bumpy_ground(centre, size: float):
    """A grid mesh 24 ``size`` wide around ``centre`` (x, y), its height rolling in two
    directions (up to 3 % of ``size``), and its height function (numpy arrays in, out)."""
    import bpy
    import numpy as np

    amp, wave = 0.03 * size, 0.9 * size

    def height(x, y):
        return amp * (np.sin(2 * math.pi * x / wave) * np.cos(2 * math.pi * y / (1.3 * wave)) + 1.0)

    n = 480
    u = np.linspace(-12 * size, 12 * size, n)
    xx, yy = np.meshgrid(centre[0] + u, centre[1] + u, indexing="ij")
    verts = np.stack([xx, yy, height(xx, yy)], axis=-1).reshape(-1, 3)
    faces = [(i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1)
             for i in range(n - 1) for j in range(n - 1)]
    me = bpy.data.meshes.new("Ground")
    me.from_pydata(verts.tolist(), [], faces)
    me.shade_smooth()
    ob = bpy.data.objects.new("Ground", me)
    bpy.context.scene.collection.objects.link(ob)
    return ob, height


def drawn_path(path_name: str, height, width: float):
    """A copy of the path curve laid on the ground (``height``) and given a round bevel
    ``width`` wide, to be seen in the render."""
    import bpy

    src = bpy.data.objects[path_name].data.splines[0].points
    cu = bpy.data.curves.new("Path (drawn)", "CURVE")
    cu.dimensions, cu.bevel_depth = "3D", width / 2
    sp = cu.splines.new("POLY")
    pts = [p.co for p in src]
    # denser than the path's own points, so the line follows the bumps
    dense = [pts[0].copy()]
    for a, b in zip(pts, pts[1:]):
        dense += [a.lerp(b, t / 8) for t in range(1, 9)]
    sp.points.add(len(dense) - 1)
    for p, q in zip(sp.points, dense):
        p.co = (q[0], q[1], float(height(q[0], q[1])) + width, 1.0)
    ob = bpy.data.objects.new("Path (drawn)", cu)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def frozen_copies(meshes, frames):
    """For each of ``frames``, a copy of every mesh as posed then (armature applied), linked to
    the scene; the animated meshes are hidden from the render."""
    import bpy

    scene = bpy.context.scene
    copies = []
    for f in frames:
        scene.frame_set(f)
        dg = bpy.context.evaluated_depsgraph_get()
        for ob in meshes:
            me = bpy.data.meshes.new_from_object(ob.evaluated_get(dg), depsgraph=dg)
            copy = bpy.data.objects.new(f"{ob.name} @ {f}", me)
            copy.matrix_world = ob.matrix_world.copy()
            scene.collection.objects.link(copy)
            copies.append(copy)
    for ob in meshes:
        ob.hide_render = True
    return copies


def render(out: Path, ground, drawn, copies, view_from, size=(1200, 600)):
    """One Workbench render: object colours (sand ground, dark path, a warm cow), shadows and
    cavity, from a camera high to the side of the walk (``view_from``) framing the copies."""
    import bpy
    from mathutils import Vector

    scene = bpy.context.scene
    ground.color = (0.78, 0.72, 0.60, 1.0)
    drawn.color = (0.25, 0.32, 0.45, 1.0)
    for ob in copies:
        ob.color = (0.86, 0.42, 0.22, 1.0)
    pts = [ob.matrix_world @ Vector(c) for ob in copies for c in ob.bound_box]
    lo = Vector([min(p[i] for p in pts) for i in range(3)])
    hi = Vector([max(p[i] for p in pts) for i in range(3)])
    centre, radius = (lo + hi) / 2, (hi - lo).length / 2
    cam = bpy.data.objects.new("StillCamera", bpy.data.cameras.new("StillCamera"))
    scene.collection.objects.link(cam)
    cam.data.lens = 50
    cam.location = centre + view_from.normalized() * radius * 2.9
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.clip_end = radius * 40
    scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    shading = scene.display.shading
    shading.light, shading.color_type = "STUDIO", "OBJECT"
    shading.show_shadows, shading.show_cavity = True, True
    shading.shadow_intensity = 0.6
    scene.display.render_aa = "8"
    scene.world = scene.world or bpy.data.worlds.new("World")
    scene.world.color = (0.80, 0.85, 0.92)
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(out)
    bpy.ops.render.render(write_still=True)
    if not out.exists():
        raise SystemExit(f"render did not write {out}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=Path("out") / "motion_steer.png")
    args = ap.parse_args(argv)
    args.out = args.out.resolve()
    args.out.parent.mkdir(parents=True, exist_ok=True)

    bpy = blender_session.start()
    from mathutils import Vector

    blender_session.reset_scene()
    meshes, _ = demo.import_model(demo.SPOT)
    rig = demo.auto_rig(meshes)
    lo, hi = demo.posed_box(meshes)
    size = (hi - lo).length
    ground, height = bumpy_ground(((lo + hi) / 2)[:2], size)
    path = demo.s_curve(meshes, rig, RADIUS)
    demo.select([], rig)
    result = bpy.ops.pose.miniskeleton_add_motion(motion="WALK", path=path, ground=ground.name)
    if result != {"FINISHED"}:
        raise SystemExit(f"walk failed: {result}")
    scene = bpy.context.scene
    first, last = scene.frame_start, scene.frame_end
    frames = [round(first + k * (last - first) / (MOMENTS - 1)) for k in range(MOMENTS)]
    copies = frozen_copies(meshes, frames)
    drawn = drawn_path(path, height, 0.006 * size)
    bpy.data.objects[path].hide_render = True
    rig.hide_render = True
    front = demo.facing(rig)
    left = Vector((0.0, 0.0, 1.0)).cross(front)
    render(args.out, ground, drawn, copies, 1.0 * front - 1.0 * left + Vector((0.0, 0.0, 1.2)))
    print(f"wrote {args.out} (frames {frames}, {len(meshes)} meshes, {len(copies)} copies)")


if __name__ == "__main__":
    main()
