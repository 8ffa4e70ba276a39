"""The zip installed here is the one for the platform Blender runs on, and its core behaves:
a panic in Rust is a Python exception inside Blender, which goes on working. The release
workflow runs these on Windows and macOS against the zips cross-built by `make extension`."""

from __future__ import annotations

import importlib
import os
import platform
import sys
import tomllib

import bpy
import pytest


def _blender_platform() -> str:
    """Blender's name for this machine's platform, as the extension manifest spells it."""
    system = {"linux": "linux", "win32": "windows", "darwin": "macos"}[sys.platform]
    arch = {"x86_64": "x64", "amd64": "x64", "arm64": "arm64", "aarch64": "arm64"}[platform.machine().lower()]
    return f"{system}-{arch}"


def test_installed_zip_is_built_for_this_platform_and_bundles_only_its_wheel():
    folder = os.path.dirname(importlib.import_module("bl_ext.user_default.miniskeleton").__file__)
    with open(os.path.join(folder, "blender_manifest.toml"), "rb") as fh:
        manifest = tomllib.load(fh)
    generated = manifest["build"]["generated"]
    assert generated["platforms"] == [_blender_platform()]
    assert len(generated["wheels"]) == 1
    wheels = os.listdir(os.path.join(folder, "wheels"))
    assert wheels == [os.path.basename(generated["wheels"][0])]


def test_a_panic_in_the_core_is_a_python_error_and_blender_goes_on():
    import miniskeleton_core

    with pytest.raises(RuntimeError, match="test panic, raised on purpose"):
        miniskeleton_core._raise_test_panic()
    bpy.ops.mesh.primitive_cube_add()
    assert bpy.context.object.type == "MESH"
    with pytest.raises(RuntimeError):
        miniskeleton_core._raise_test_panic()
