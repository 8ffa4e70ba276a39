"""Puppet: shadow puppets (an armature, cut-out parts and control rods in the picture plane)
whose rods drive the bones by planar IK, solved live and baked to keys, and the Shadow Theatre
scene preset. ``operators`` holds the operators and ``ui`` their panel and menu entry;
``templates`` (the figures as data), ``build``, ``live`` (rod-driven IK, the handlers that
solve live, bake), ``rig`` (finding a puppet) and ``theatre`` the work they do."""

from ..common.panels import register_area, unregister_area
from . import live, operators, ui

_classes = (*operators.classes, *ui.classes)


def register() -> None:
    register_area(_classes, ui.MENUS)
    live.register_handlers()


def unregister() -> None:
    live.unregister_handlers()
    unregister_area(_classes, ui.MENUS)
