"""Skeleton: Fit Skeleton to Mesh, the original rest pose kept and restored, and rig exchange
(NPZ bundle, debug JSON). ``operators`` holds the operators and ``ui`` their panel and menu
entries; ``fitting``, ``snapshot``, ``editing``, ``joints`` and ``exchange`` the work they do."""

from ..common.panels import register_area, unregister_area
from . import operators, ui

_classes = (*operators.classes, *ui.classes)


def register() -> None:
    register_area(_classes, ui.MENUS)


def unregister() -> None:
    unregister_area(_classes, ui.MENUS)
