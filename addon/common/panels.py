"""What every area's panels and menus share: the MiniSkeleton tab of the 3D viewport sidebar, and
registering an area's classes and menu entries (and unregistering them in reverse)."""

from __future__ import annotations

import bpy


class SidebarPanel:
    """Mixin: a panel in the 3D viewport sidebar (N), tab "MiniSkeleton"."""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "MiniSkeleton"


def register_area(classes, menus=()) -> None:
    """Register ``classes`` (operators, panels) in order, then append each ``(Blender menu, draw
    function)`` of ``menus`` to its menu. The sidebar lists panels in the order they are
    registered, and a menu lists appended entries in the order they are added."""
    for cls in classes:
        bpy.utils.register_class(cls)
    for menu, draw in menus:
        getattr(bpy.types, menu).append(draw)


def unregister_area(classes, menus=()) -> None:
    """Undo ``register_area``: the menu entries removed, then the classes, in reverse order."""
    for menu, draw in reversed(menus):
        getattr(bpy.types, menu).remove(draw)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
