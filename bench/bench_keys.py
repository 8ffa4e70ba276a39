"""Keying long motions: Add Motion (Walk) and Bake Puppet Animation over growing frame ranges.

    .venv/bin/python -m bench.bench_keys [--cycles 2,10,100] [--rigify-cycles 4] [--frames 250,1000] [--repeats 3]

Add Motion on the generated creature's rig (testkit/creature.py, 22 bones keyed) for each number
of walk cycles, on the Rigify human control rig (testkit/rig_corpus.py, built once, reset before
each run: the controls solved through Blender's evaluation of their MCH parents), and Bake
Puppet Animation on a five-rod shadow puppet over each scene range;
both write every bone's keys as one series (``addon/common/keys.py``). Prints a markdown table of the
operator's time (median of the repeats, a fresh scene each) and frames keyed, and writes it to
out/bench_keys.md. Nothing is asserted (a Blender test checks the series equals keyframe_insert
frame by frame).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from testkit import ROOT, blender_session


def timed(fn) -> tuple[float, object]:
    start = time.perf_counter()
    result = fn()
    return time.perf_counter() - start, result


def walk(bpy, cycles: float) -> tuple[float, int]:
    """Seconds for Add Motion (Walk, ``cycles``) on a fresh creature rig, and frames keyed."""
    from testkit import creature

    blender_session.reset_scene()
    arm = creature.build_armature()
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    secs, result = timed(lambda: bpy.ops.pose.miniskeleton_add_motion(motion="WALK", cycles=cycles))
    assert result == {"FINISHED"}, result
    return secs, bpy.context.scene.frame_end - bpy.context.scene.frame_start + 1


_rigify: dict = {}


def rigify_walk(bpy, cycles: float) -> tuple[float, int]:
    """Seconds for Add Motion (Walk, ``cycles``) on the Rigify human rig, and frames keyed."""
    from testkit import rig_corpus

    from testkit import motion_corpus

    if "rig" not in _rigify:
        blender_session.reset_scene()
        with motion_corpus.captured_output():
            rig = rig_corpus.build("rigify_human")
        _rigify.update(rig=rig, basis=rig.arm.matrix_basis.copy())
    arm = _rigify["rig"].arm
    motion_corpus.reset_rig(arm, _rigify["basis"])
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    with motion_corpus.captured_output():
        secs, result = timed(lambda: bpy.ops.pose.miniskeleton_add_motion(motion="WALK", cycles=cycles))
    assert result == {"FINISHED"}, result
    return secs, bpy.context.scene.frame_end - bpy.context.scene.frame_start + 1


def bake(bpy, frames: int) -> tuple[float, int]:
    """Seconds for Bake Puppet Animation on a fresh five-rod puppet over ``frames`` frames."""
    blender_session.reset_scene()
    assert bpy.ops.object.miniskeleton_add_puppet(type="FIVE_ROD") == {"FINISHED"}
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, frames
    secs, result = timed(lambda: bpy.ops.object.miniskeleton_bake_puppet())
    assert result == {"FINISHED"}, result
    return secs, frames


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cycles", default="2,10,100", help="walk cycles for Add Motion")
    ap.add_argument("--rigify-cycles", default="4", help="walk cycles for Add Motion on the Rigify human")
    ap.add_argument("--frames", default="250,1000", help="scene ranges for Bake Puppet Animation")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    bpy = blender_session.start()
    rows = []
    for label, run, sizes in (("Add Motion (Walk), cycles", walk, args.cycles),
                              ("Add Motion (Walk) on the Rigify human, cycles", rigify_walk, args.rigify_cycles),
                              ("Bake Puppet Animation, frames", bake, args.frames)):
        for size in [float(s) if "." in s else int(s) for s in sizes.split(",") if s]:
            runs = [run(bpy, size) for _ in range(max(args.repeats, 1))]
            rows.append((f"{label} {size}", runs[0][1], float(np.median([r[0] for r in runs]))))
            print(f"done {rows[-1][0]}", flush=True)
    lines = [f"bpy {bpy.app.version_string}; median of {args.repeats}", "",
             "| operator | frames keyed | s |", "|---|---:|---:|"]
    lines += [f"| {name} | {frames} | {secs:.3f} |" for name, frames, secs in rows]
    text = "\n".join(lines)
    print(text)
    blender_session.write_report(ROOT / "out" / "bench_keys.md", text)


if __name__ == "__main__":
    main()
