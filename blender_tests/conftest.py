"""Blender tests: real Blender (the PyPI ``bpy`` module), extension installed from its zip.

``scripts/blender_session.start`` makes a throw-away Blender user directory before ``bpy`` is
imported and installs the zip built by ``make extension`` with ``package_install_files``, the
way a user installs it. Nothing imports the add-on from the source tree.
"""

import sys

from testkit import blender_session

blender_session.start()

import pytest  # noqa: E402


@pytest.fixture(autouse=True)
def clean_scene():
    """Each test starts from an empty factory scene with the extension enabled."""
    blender_session.reset_scene()
    yield


_exit_status = {"code": 0}


def pytest_sessionfinish(session, exitstatus):
    _exit_status["code"] = int(exitstatus)


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """Blender 4.2 LTS (4.2.0 to 4.2.23) segfaults while the interpreter shuts down after any
    glTF export, with or without this extension (5 lines reproduce it: factory settings, add a
    cube, export_scene.gltf, exit). By now every result is reported, so on 4.2 leave with
    pytest's own exit status instead of running Blender's broken teardown."""
    import bpy

    if bpy.app.version < (4, 3, 0):
        import os

        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_exit_status["code"])
