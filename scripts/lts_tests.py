"""The Blender tests on an LTS release's bpy (4.2, 4.5): `make test-blender-4.2` runs
`.venv-bpy42/bin/python -m scripts.lts_tests` from the checkout.

Blender 4.2 segfaults at random late in one long process, inside its own C code (entering edit
mode in its glTF importer, freeing a scene's depsgraph); the same tests pass on 5.0.1 in one
process. So each test file runs in a pytest process of its own. A file whose process dies by
a signal has every one of its tests run again, each in a process of its own, and a test whose
process dies by a signal there runs once more. A test that fails is never run again.

Exit status 0 when every test passed (or skipped), 1 otherwise."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

TESTS = Path("blender_tests")


def pytest(*args: str) -> int:
    """pytest's exit status, or minus the signal that killed its process."""
    sys.stdout.flush()
    return subprocess.call([sys.executable, "-m", "pytest", "-q", *args])


def test_ids(path: Path) -> list[str]:
    """The node ids of the tests in ``path`` (parametrized ones one by one)."""
    out = subprocess.run([sys.executable, "-m", "pytest", "-q", "--collect-only", str(path)],
                         capture_output=True, text=True, check=True).stdout
    return [f"{path}::{line.split('::', 1)[1]}" for line in out.splitlines() if "::" in line]


def run_alone(node: str) -> int:
    rc = pytest(node)
    if rc < 0:
        print(f"{node}: the process died by signal {-rc}; running the test once more", flush=True)
        rc = pytest(node)
    return rc


def run_file(path: Path) -> bool:
    print(path, flush=True)
    rc = pytest(str(path))
    if rc >= 0:
        return rc == 0
    print(f"{path}: the process died by signal {-rc}; running each of its tests in a process of "
          "its own", flush=True)
    failed = [node for node in test_ids(path) if run_alone(node) != 0]
    for node in failed:
        print(f"failed: {node}", flush=True)
    return not failed


def main(files: list[str]) -> int:
    """``files``: test files to run (all of blender_tests/ when empty)."""
    paths = [Path(f) for f in files] or sorted(TESTS.glob("test_*.py"))
    results = [run_file(path) for path in paths]
    return 0 if all(results) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
