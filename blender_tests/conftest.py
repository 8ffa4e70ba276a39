"""Blender tests: real Blender (the PyPI ``bpy`` module), extension installed from its zip.

``scripts/blender_session.start`` makes a throw-away Blender user directory before ``bpy`` is
imported and installs the zip built by ``make extension`` with ``package_install_files``, the
way a user installs it. Nothing imports the add-on from the source tree.
"""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent / "scripts")]

import blender_session  # noqa: E402

blender_session.start()

import pytest  # noqa: E402


@pytest.fixture(autouse=True)
def clean_scene():
    """Each test starts from an empty factory scene with the extension enabled."""
    blender_session.reset_scene()
    yield
