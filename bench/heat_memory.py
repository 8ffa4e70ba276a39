"""Memory: the peak of one Heat solve (``core.heat_weights_report``) on capped cylinders with a
bone chain, each size in a fresh process (the peak resident size is per process), against the
core's estimate ``core.heat_peak_bytes``, from which the Auto Weights operator refuses a solve
over its Memory Limit.

    .venv/bin/python -m bench.heat_memory [--sizes 316x316:200,632x632:200,632x632:40,1000x1000:200]

Prints a markdown table: vertices, bones, wall and CPU seconds, peak MB (the process, less
what it held before the call), the estimate in MB and measured / estimate. Run after
``make wheel`` (the core is imported from .build/core). Nothing is asserted.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

ONE = """
import resource, time
import miniskeleton_core as core
v, t = core.capped_cylinder(0.5, 4.0, {rings}, {segments})
heads, tails, _ = core.bone_chain(4.0, {bones})
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
wall, cpu = time.perf_counter(), time.process_time()
core.heat_weights_report(v, t, heads, tails)
print(len(v), time.perf_counter() - wall, time.process_time() - cpu,
      (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) * 1024, core.heat_peak_bytes(len(v), {bones}))
"""


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="316x316:200,632x632:200,632x632:40,1000x1000:200")
    args = ap.parse_args(argv)
    print("| vertices | bones | wall s | CPU s | peak MB | estimate MB | peak / estimate |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for size in args.sizes.split(","):
        shape, bones = size.split(":")
        rings, segments = shape.split("x")
        code = ONE.format(rings=int(rings), segments=int(segments), bones=int(bones))
        env = {**os.environ, "PYTHONPATH": str(ROOT / ".build" / "core")}
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env).stdout
        n, wall, cpu, peak, est = out.split()
        n, peak, est = int(n), int(peak), int(est)
        print(f"| {n} | {bones} | {float(wall):.1f} | {float(cpu):.1f} | {peak / 2**20:.0f} | {est / 2**20:.0f} "
              f"| {peak / est:.2f} |", flush=True)


if __name__ == "__main__":
    main()
