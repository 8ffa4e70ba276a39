"""MiniSkeleton: automatic skinning, skeleton fitting and puppet IK backed by a Rust core.

This file only registers; see operators_*.py (operators), ui.py (menus and panels),
common/ (Blender data to arrays and back, keyframes in bulk) and puppet_live.py (the handlers
that solve shadow puppets live).
"""

from . import ui
from .motion import operators as operators_motion
from .puppet import live as puppet_live
from .puppet import operators as operators_puppet
from .skeleton import operators as operators_skeleton
from .weights import operators as operators_weights

_modules = (operators_weights, operators_skeleton, operators_motion, operators_puppet, ui)


def register() -> None:
    import bpy

    for mod in _modules:
        for cls in mod.classes:
            bpy.utils.register_class(cls)
    ui.register_menus()
    puppet_live.register_handlers()


def unregister() -> None:
    import bpy

    puppet_live.unregister_handlers()
    ui.unregister_menus()
    for mod in reversed(_modules):
        for cls in reversed(mod.classes):
            bpy.utils.unregister_class(cls)
