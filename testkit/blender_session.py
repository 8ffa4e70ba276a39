"""Start headless Blender (the PyPI ``bpy`` module) with MiniSkeleton installed like a user does.

``start()`` points Blender at a throw-away user directory *before* ``bpy`` is imported, then
installs the extension zip built by ``make extension`` with ``package_install_files``.
Used by the demo, the benchmarks and blender_tests/conftest.py. ``write_report`` saves a
benchmark's markdown under out/, and ``Stages`` prints the demos' stage timings.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

from testkit import ROOT

ADDON_MODULE = "bl_ext.user_default.miniskeleton"


def extension_zip() -> Path:
    """The zip from ``make extension`` ($MINISKELETON_EXTENSION_ZIP, else the newest in dist/)."""
    env = os.environ.get("MINISKELETON_EXTENSION_ZIP")
    if env and Path(env).exists():
        return Path(env)
    zips = sorted((ROOT / "dist").glob("miniskeleton-*-linux_x64.zip"))
    if not zips:
        raise RuntimeError("no extension zip in dist/: run `make extension`")
    return zips[-1]


def start(user_dir: str | None = None):
    """Import bpy with a fresh user directory and the extension installed and enabled; returns bpy."""
    if "bpy" not in __import__("sys").modules:
        os.environ["BLENDER_USER_RESOURCES"] = user_dir or tempfile.mkdtemp(prefix="miniskeleton-user-")
    import bpy

    if ADDON_MODULE not in bpy.context.preferences.addons.keys():
        result = bpy.ops.extensions.package_install_files(
            filepath=str(extension_zip()), repo="user_default", enable_on_install=True)
        if result != {"FINISHED"}:
            raise RuntimeError(f"installing the extension failed: {result}")
    return bpy


def write_report(path: Path, text: str) -> Path:
    """Write a benchmark's markdown ``text`` to ``path`` (e.g. out/bench_fit.md), making its
    folder if missing; returns ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text + "\n")
    return path


def reset_scene() -> None:
    """Empty factory scene, extension still enabled (factory settings disable add-ons)."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.preferences.addon_enable(module=ADDON_MODULE)


class Stages:
    """Prints '[prefix] name ... 1.23 s' lines, one per stage, and the total."""

    def __init__(self, prefix: str = "demo"):
        self.prefix = prefix
        self.t0 = time.perf_counter()

    def run(self, name, fn, *args):
        t = time.perf_counter()
        print(f"[{self.prefix}] {name} ...", flush=True)
        out = fn(*args)
        print(f"[{self.prefix}] {name}: {time.perf_counter() - t:.2f} s", flush=True)
        return out

    def total(self):
        print(f"[{self.prefix}] total: {time.perf_counter() - self.t0:.2f} s", flush=True)


def import_model(path):
    """Import a model file (glTF/GLB, FBX, OBJ or PLY) into the current scene; returns (the new
    objects, the new meshes with faces, the new armatures). The glTF importer's bone-shape
    objects are not among the meshes. ValueError for another format."""
    import bpy

    path = Path(path)
    before = set(bpy.data.objects)
    suffix = path.suffix.lower()
    if suffix in (".glb", ".gltf"):
        bpy.ops.import_scene.gltf(filepath=str(path))
    elif suffix == ".fbx":
        bpy.ops.import_scene.fbx(filepath=str(path))
    elif suffix == ".obj":
        bpy.ops.wm.obj_import(filepath=str(path))
    elif suffix == ".ply":
        bpy.ops.wm.ply_import(filepath=str(path))
    else:
        raise ValueError(f"unsupported model format: {path} (GLB, glTF, FBX, OBJ or PLY)")
    new = [ob for ob in bpy.data.objects if ob not in before]
    rigs = [ob for ob in new if ob.type == "ARMATURE"]
    shapes = {pb.custom_shape for rig in rigs for pb in rig.pose.bones}  # the glTF importer's bone shapes
    meshes = [ob for ob in new if ob.type == "MESH" and len(ob.data.polygons) and ob not in shapes]
    return new, meshes, rigs
