"""Modifiers that matter to skinning: the Subdivision Surface that smooths a cage, and the
Armature modifiers that deform a mesh (added as Ctrl+P adds them, others found and named)."""

from __future__ import annotations

import bpy


def smoothing_modifier(ob: bpy.types.Object):
    """``ob``'s first Catmull-Clark Subdivision Surface modifier that shows (in the viewport or
    the render, at a level above 0), or None. Blender's Ctrl+P With Automatic Weights weights
    such a cage where its vertices lie on the smooth surface (their limit positions)."""
    for m in ob.modifiers:
        if m.type == "SUBSURF" and m.subdivision_type == "CATMULL_CLARK" and (
                (m.show_viewport and m.levels > 0) or (m.show_render and m.render_levels > 0)):
            return m
    return None


def ensure_armature_modifier(ob: bpy.types.Object, arm_ob: bpy.types.Object) -> bool:
    """Add an Armature modifier deforming ``ob`` by ``arm_ob`` unless one exists, last in the
    stack as Blender's Ctrl+P adds it: after a Mirror modifier, whose mirrored half then follows
    the mirrored (.R) groups rather than repeating the .L side's pose."""
    for mod in ob.modifiers:
        if mod.type == "ARMATURE" and mod.object == arm_ob:
            return False
    mod = ob.modifiers.new(name=arm_ob.name, type="ARMATURE")
    mod.object = arm_ob
    mod.use_vertex_groups = True
    return True


def other_armature_modifiers(ob: bpy.types.Object, arm_ob: bpy.types.Object) -> list[str]:
    """Names of ``ob``'s enabled Armature modifiers that deform it by another armature: left in
    place, but they deform the mesh as well as ``arm_ob`` does."""
    return [m.name for m in ob.modifiers if m.type == "ARMATURE" and m.object is not None
            and m.object != arm_ob and (m.show_viewport or m.show_render)]


def idle_armature_modifiers(ob: bpy.types.Object, arm_ob: bpy.types.Object) -> list[str]:
    """Names of ``ob``'s Armature modifiers for ``arm_ob`` that do not apply its vertex groups:
    Vertex Groups off (envelopes only), or disabled in both viewport and render. They are the
    user's and kept (as Blender's Ctrl+P keeps them), but new weights do not deform through them."""
    return [m.name for m in ob.modifiers if m.type == "ARMATURE" and m.object == arm_ob
            and not (m.use_vertex_groups and (m.show_viewport or m.show_render))]
