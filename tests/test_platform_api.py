"""The built core on this machine: a panic in Rust comes back as a Python exception, the
process goes on (the release profile unwinds; the other platforms' binaries are checked in
release_tests/ and imported by the release workflow's Blender tests)."""

import miniskeleton_core as msc
import pytest


def test_a_panic_is_a_runtime_error_and_the_module_still_works():
    for _ in range(3):
        with pytest.raises(RuntimeError, match="test panic, raised on purpose"):
            msc._raise_test_panic()
    v, t = msc.capped_cylinder(rings=4, segments=6)
    assert len(v) > 0 and len(t) > 0
