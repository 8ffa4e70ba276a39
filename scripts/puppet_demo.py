"""Shadow-play demo, headless: build a puppet, animate its rods, bake the solved pose to keys,
set up the Shadow Theatre and render a short clip with Workbench.

    python -m scripts.puppet_demo --out out [--puppet five-rod] [--frames 48] [--size 480x360]

(`make demo PUPPET=five-rod` runs it through scripts/demo.py.) The five-rod figure walks
across the screen (neck rod forward with a bob, foot rods stepping) while waving both arms
(hand rods); the other types get a simpler dance of their rods. Writes out/puppet.mp4 and
out/puppet.blend and prints one line per stage with its time.
"""

from __future__ import annotations

import argparse
import importlib
import math
from pathlib import Path


from testkit import blender_session

KINDS = {"three-rod": "THREE_ROD", "five-rod": "FIVE_ROD", "prop": "PROP", "strip": "STRIP",
         "quadruped": "QUADRUPED"}
CYCLE = 24          # frames per step cycle / wave


def build(kind):
    import bpy

    R = importlib.import_module(f"{blender_session.ADDON_MODULE}.puppet.rig")
    if bpy.ops.object.miniskeleton_add_puppet(type=kind) != {"FINISHED"}:
        raise SystemExit(f"adding the {kind} puppet failed")
    rig = R.puppet_rig(bpy.context.active_object)
    return rig, R.puppet_rods(rig)


def _key(ob, frame, loc=None, rot_y=None):
    if loc is not None:
        ob.location = loc
        ob.keyframe_insert("location", frame=frame)
    if rot_y is not None:
        ob.rotation_euler.y = rot_y
        ob.keyframe_insert("rotation_euler", index=1, frame=frame)


def animate(kind, rig, rods, frames):
    """Key the rods every other frame. Rod locations are relative to the main rod."""
    import bpy
    from mathutils import Vector

    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, frames
    rest = {role: rod.location.copy() for role, rod in rods.items()}
    main_role = next(r for r, ob in rods.items() if ob.parent is None)
    main = rods[main_role]
    travel = 1.6
    for f in list(range(1, frames + 1, 2)) + ([frames] if frames % 2 == 0 else []):
        u = (f - 1) / max(frames - 1, 1)
        phi = 2 * math.pi * (f - 1) / CYCLE
        if kind in ("FIVE_ROD", "THREE_ROD", "PROP"):
            # Walk: the neck rod crosses the screen, bobbing twice per step cycle, slightly low
            # so the knees bend.
            _key(main, f, rest[main_role] + Vector((-travel / 2 + travel * u, 0, -0.06 + 0.025 * math.cos(2 * phi))))
            shoulder = Vector((0, 0, -0.09))
            for role, side, base_deg in (("hand.R", 1, 55), ("hand.L", -1, 125)):
                if role in rods:   # wave: hands high, swinging 30 degrees
                    a = math.radians(base_deg + 30 * math.sin(2 * phi + (0 if side > 0 else math.pi)))
                    _key(rods[role], f, shoulder + 0.55 * Vector((math.cos(a), 0, math.sin(a))))
            for role, shift in (("foot.R", 0.0), ("foot.L", math.pi)):
                if role in rods:   # step: forward swing lifted, backward stance on the ground
                    p = phi + shift
                    lift = 0.09 * max(0.0, math.cos(p))
                    _key(rods[role], f, rest[role] + Vector((0.2 * math.sin(p), 0, 0.06 + lift)))
            if kind == "PROP":
                staff = rig["miniskeleton_prop"]
                _key(staff, f, rot_y=math.radians(35) * math.sin(phi))
        elif kind == "STRIP":
            _key(main, f, rest[main_role] + Vector((-travel / 2 + travel * u, 0, 0.25 * math.sin(phi))))
            for role, lag in (("middle", 1.2), ("tail", 2.4)):
                _key(rods[role], f, rest[role] + Vector((0.15, 0, 0.3 * math.sin(phi - lag))))
        else:  # QUADRUPED
            _key(main, f, rest[main_role] + Vector((-travel / 2 + travel * u, 0, 0.03 * math.cos(2 * phi))))
            _key(rods["head"], f, rot_y=-math.radians(25) * math.sin(phi))


def bake(rig):
    import bpy

    bpy.context.view_layer.objects.active = rig
    if bpy.ops.object.miniskeleton_bake_puppet() != {"FINISHED"}:
        raise SystemExit("baking failed")


def theatre(frames, size):
    import bpy

    r = bpy.context.scene.render
    r.resolution_x, r.resolution_y = size         # the preset frames for this aspect
    bpy.context.scene.frame_set((frames + 1) // 2)   # the walk's middle: framed on the centre
    if bpy.ops.scene.miniskeleton_shadow_theatre(engine="WORKBENCH") != {"FINISHED"}:
        raise SystemExit("shadow theatre failed")


def render(path: Path, size):
    """render.miniskeleton_make_video with the theatre's camera, engine and shading."""
    import bpy

    bpy.context.scene.display.render_aa = "8"
    result = bpy.ops.render.miniskeleton_make_video(
        filepath=str(path), engine="SCENE", camera="SCENE", resolution_x=size[0],
        resolution_y=size[1], fps=24)
    if result != {"FINISHED"} or not path.exists():
        raise SystemExit(f"video failed: {result}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="out", type=Path)
    ap.add_argument("--puppet", default="five-rod", choices=sorted(KINDS))
    ap.add_argument("--frames", default=48, type=int)
    ap.add_argument("--size", default="480x360")
    args = ap.parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    kind = KINDS[args.puppet]
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)

    st = blender_session.Stages("puppet")
    bpy = st.run("start Blender and install the extension", blender_session.start)
    st.run("empty scene", blender_session.reset_scene)
    rig, rods = st.run(f"build {args.puppet} puppet", build, kind)
    st.run(f"animate rods ({args.frames} frames)", animate, kind, rig, rods, args.frames)
    st.run("bake puppet animation (Rust IK per frame)", bake, rig)
    st.run("shadow theatre", theatre, args.frames, size)
    mp4 = out / "puppet.mp4"
    st.run(f"render {size[0]}x{size[1]} x {args.frames} frames (Workbench)", render, mp4, size)
    blend = out / "puppet.blend"
    st.run("save .blend", lambda: bpy.ops.wm.save_as_mainfile(filepath=str(blend)))
    print(f"[puppet] wrote {mp4} ({mp4.stat().st_size // 1024} KiB) and {blend}")
    st.total()


if __name__ == "__main__":
    main()
