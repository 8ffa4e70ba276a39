"""Motion: Add Motion keys a head shake, walk or run from the roles the Rust core finds in the
bones, and Make Video renders the frame range to an MP4. ``operators`` holds the operators and
``ui`` their panel and menu entries; ``planning`` (the core's motion), ``keying`` (keys
written), ``rigify`` (the controls keyed on a Rigify rig), ``rigify_solve`` (their transforms,
solved through a pruned copy of the rig) and ``filming`` (camera, light, render) the work they
do."""

from ..common.panels import register_area, unregister_area
from . import operators, ui

_classes = (*operators.classes, *ui.classes)


def register() -> None:
    register_area(_classes, ui.MENUS)


def unregister() -> None:
    unregister_area(_classes, ui.MENUS)
