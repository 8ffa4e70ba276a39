"""Quality guard: on every rigged model of ../shared/models/ (skipped when the folder or the file
is absent; never copied here), Auto Weights (Heat and Geodesic Voxel) leaves no vertex unweighted
and deforms no worse than Blender's own bone heat (Ctrl+P > With Automatic Weights) against the
artist's weights, all bound in the same run and posed with the same frames of the model's own
clips.

The measure is ``testkit/eval_weights.py``'s deform error (mean distance to the artist-weighted
mesh, % of the bounding-box diagonal), on fewer frames to stay quick; the full table is that
script's. A change that makes any model worse than Blender's fails here."""

from pathlib import Path
from types import SimpleNamespace

import bpy
import pytest

from testkit import eval_weights

# The table's 3 clips, 6 frames each instead of 20: quick, and the same side wins on every model.
ARGS = SimpleNamespace(clips=3, frames=6, actions="", no_blender=False)


@pytest.mark.parametrize("name", eval_weights.MODELS)
def test_auto_weights_no_worse_than_blenders(name):
    path = eval_weights.MODELS_DIR / name
    if not path.exists():
        pytest.skip(f"{path} not present")
    row = eval_weights.evaluate(Path(name).stem, path, bpy, ARGS)
    assert row is not None, f"{name}: nothing to compare"
    theirs = row["sides"]["Blender"]
    assert theirs["result"] == {"FINISHED"}
    for side in ("ours", "voxel"):
        ours = row["sides"][side]
        assert ours["result"] == {"FINISHED"}, side
        assert ours["unweighted"] == 0, f"{name} {side}: {ours['unweighted']} vertices unweighted"
        # Equal weights (RiggedSimple's two bones) give equal errors up to rounding.
        assert ours["deform"] <= theirs["deform"] * (1 + 1e-6) + 1e-9, (
            f"{name} {side}: deform {ours['deform']:.4f} % against Blender's {theirs['deform']:.4f} %")
