"""Auto Weights' memory estimate: a Heat solve whose estimated peak is over the Memory Limit is
refused before anything is computed, with the estimate in the report, and nothing changes."""

import importlib
import re

import bpy
import pytest

from testkit import builders as B

import miniskeleton_core as core

compute = importlib.import_module("bl_ext.user_default.miniskeleton.weights.compute")


def _untouched(ob):
    return not ob.vertex_groups and not ob.modifiers and ob.parent is None


def test_heat_over_the_memory_limit_is_refused_with_its_estimate_and_nothing_changes():
    ob, arm = B.cylinder(), B.chain()
    n = len(ob.data.vertices)
    need = core.heat_peak_bytes(n, 4)
    B.select_for_parenting([ob], arm)
    with pytest.raises(RuntimeError, match=r"needs about .* of memory, over the limit of") as err:
        bpy.ops.object.miniskeleton_auto_weights(method="HEAT", memory_limit=0.5 * need / 2**30)
    assert f"Heat on {n} vertices and 4 bones" in str(err.value)
    sizes = [float(x) * 2.0 ** (10 * " KMG".index(u)) for x, u in re.findall(r"([0-9.]+) ([KMG])B", str(err.value))]
    assert sizes == [pytest.approx(need, rel=0.05), pytest.approx(0.5 * need, rel=0.05)]
    assert _untouched(ob)
    # Just over the estimate, the same solve runs; the limit is Heat's alone.
    assert bpy.ops.object.miniskeleton_auto_weights(method="HEAT", memory_limit=1.01 * need / 2**30) == {"FINISHED"}
    assert len(ob.vertex_groups) == 4


def test_the_limit_is_heats_alone():
    ob, arm = B.cylinder(), B.chain()
    B.select_for_parenting([ob], arm)
    assert bpy.ops.object.miniskeleton_auto_weights(method="BILINEAR", memory_limit=1e-9) == {"FINISHED"}
    assert len(ob.vertex_groups) == 4


def test_default_limit_is_a_share_of_this_computers_memory():
    """With no limit set (0), a solve whose estimate is over the machine's memory is refused and
    a small one is not; a limit set above the estimate lets the large one through."""
    total = compute.machine_memory()
    assert total is not None and total > 2**30
    big = 1_000_000
    while core.heat_peak_bytes(big, 200) <= total:
        big *= 2
    compute.refuse_past_memory(core, 10_000, 200, 0.0)
    with pytest.raises(compute.WeightsError, match=f"Heat on {big} vertices and 200 bones needs about"):
        compute.refuse_past_memory(core, big, 200, 0.0)
    compute.refuse_past_memory(core, big, 200, 2 * core.heat_peak_bytes(big, 200) / 2**30)
