"""MiniSkeleton: automatic skinning, skeleton fitting and puppet IK backed by a Rust core.

This file only registers: each area registers its own operators, panel and menu entries
(``weights``, ``skeleton``, ``motion``, ``puppet``; the puppet area also its live handlers).
``common`` holds what the areas share: Blender data to arrays and back, keyframes in bulk.
"""

from . import motion, puppet, skeleton, weights

# In this order: the sidebar tab lists the panels in the order they are registered, and a menu
# that two areas add to (Pose) lists their entries in this order.
_areas = (weights, skeleton, motion, puppet)


def register() -> None:
    for area in _areas:
        area.register()


def unregister() -> None:
    for area in reversed(_areas):
        area.unregister()
