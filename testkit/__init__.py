"""MiniSkeleton's helpers for the tests, the benchmarks and the scripts: one package that
``blender_tests/``, ``bench/`` and ``scripts/`` import (pytest finds it through
``pythonpath`` in pyproject.toml; the Makefile runs benches and scripts as ``python -m``
from the checkout, so it is on the path there too).

- ``blender_session``: headless Blender with the extension installed as a user does it, a fresh
  scene, model import (glTF, FBX, OBJ, PLY), report writing, stage timings.
- ``builders``: scene building for the Blender tests (meshes, armatures, selections).
- ``measures``: what is read back from a scene (world and evaluated world vertices, weights).
- ``rig_corpus``, ``creature``, ``shapes``: the rigs and bodies the tests and benches share.
- ``motion_corpus``, ``eval_weights``, ``eval_fit``: the measures of Add Motion, Auto Weights
  and Fit on those rigs and on ../shared/models; each also prints its table
  (``python -m testkit.motion_corpus``).

``MODELS_DIR`` is where the real models are read from (``../shared/models`` beside the
checkout, never copied into it).
"""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODELS_DIR = ROOT.parent / "shared" / "models"
