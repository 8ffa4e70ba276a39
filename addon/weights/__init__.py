"""Weights: Auto Weights skins meshes to an armature with the Rust core's bone heat,
nearest-bone (bilinear) or inverse-distance weights. ``operators`` holds the operator and
``ui`` its panel and menu entries; ``binding`` reads and writes the Blender data and
``compute`` computes without bpy."""

from ..common.panels import register_area, unregister_area
from . import operators, ui

_classes = (*operators.classes, *ui.classes)


def register() -> None:
    register_area(_classes, ui.MENUS)


def unregister() -> None:
    unregister_area(_classes, ui.MENUS)
