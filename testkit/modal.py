"""Auto Weights' modal run driven as a window drives it: the events ``modal`` is handed, one
timer tick, and meshes large enough for the worker thread."""

from __future__ import annotations

import importlib

from testkit import blender_session, builders


class Event:
    """What a window's event loop hands an operator's ``modal``: only its type is read."""

    def __init__(self, type):
        self.type = type


def tick(op, context, seen, ob):
    """One timer tick: ``modal``'s answer, with the job's progress and the mesh's groups then."""
    answer = op.modal(context, Event("TIMER"))
    seen["ticks"].append((op._job.fraction, len(ob.vertex_groups), answer))
    return answer


def large_cylinder():
    """A mesh big enough for the UI to compute it on the worker thread (BACKGROUND_VERTICES)."""
    compute = importlib.import_module(f"{blender_session.ADDON_MODULE}.weights.compute")
    ob = builders.cylinder(rings=400, segments=128)
    assert len(ob.data.vertices) >= compute.BACKGROUND_VERTICES
    return ob


def half_weighted_cylinder():
    """The large mesh with a foreign group and an old 'Bone1' group (a run would replace it)
    carrying weights, and a modifier of its own: a cancelled run must keep all of them."""
    ob = large_cylinder()
    keep, old = ob.vertex_groups.new(name="Keep"), ob.vertex_groups.new(name="Bone1")
    keep.add(list(range(0, 5000, 7)), 0.25, "REPLACE")
    old.add(list(range(100, 900)), 0.5, "REPLACE")
    ob.modifiers.new("Smooth", "SMOOTH")
    return ob
