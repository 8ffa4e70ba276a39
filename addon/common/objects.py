"""Objects in the scene: hidden from viewports for a while, parented to a bone or to an armature
without moving, and their world matrix before their constraints act."""

from __future__ import annotations

from contextlib import contextmanager

import bpy


@contextmanager
def viewport_hidden(ob: bpy.types.Object, hidden: bool):
    """``ob`` with ``hide_viewport`` (Disable in Viewports) set to ``hidden`` for a while. Its
    own setting, and its selection in every view layer (hiding deselects it), come back
    afterwards."""
    if ob.hide_viewport == hidden:
        yield
        return
    was = ob.hide_viewport
    layers = [layer for scene in ob.users_scene for layer in scene.view_layers
              if layer.objects.get(ob.name) == ob]
    selected = [layer for layer in layers if ob.select_get(view_layer=layer)]
    ob.hide_viewport = hidden
    try:
        yield
    finally:
        ob.hide_viewport = was
        for layer in selected:
            ob.select_set(True, view_layer=layer)


def follows_bone(ob: bpy.types.Object, arm_ob: bpy.types.Object) -> bool:
    """``ob`` is parented to one of ``arm_ob``'s bones (Bone parenting): its world position
    depends on the pose, and on its bone's rest position."""
    return ob.parent == arm_ob and ob.parent_type == "BONE"


def parent_keep_transform(ob: bpy.types.Object, arm_ob: bpy.types.Object) -> bool:
    """Parent ``ob`` to ``arm_ob`` (object parenting) without moving it in world space. False,
    changing nothing, when ``ob`` is an ancestor of ``arm_ob`` (a loop, which Blender refuses:
    its Armature modifier deforms it all the same)."""
    if ob.parent == arm_ob and ob.parent_type == "OBJECT":
        return True
    up = arm_ob
    while up is not None:
        if up == ob:
            return False
        up = up.parent
    world = unconstrained_world(ob)
    ob.parent = arm_ob
    ob.parent_type = "OBJECT"
    ob.matrix_parent_inverse = arm_ob.matrix_world.inverted_safe()
    ob.matrix_basis = (arm_ob.matrix_world @ ob.matrix_parent_inverse).inverted_safe() @ world
    return True


def unconstrained_world(ob: bpy.types.Object):
    """``ob``'s world matrix before its constraints act (parent, parent inverse, basis): what a
    new parenting must reproduce so that its constraints, which act again afterwards, leave it
    where it was (a Copy Rotation that adds to its own rotation would otherwise count twice)."""
    active = [c for c in ob.constraints if not c.mute]
    if not active:
        return ob.matrix_world.copy()
    layer = bpy.context.view_layer
    for c in active:
        c.mute = True
    try:
        layer.update()
        return ob.matrix_world.copy()
    finally:
        for c in active:
            c.mute = False
        layer.update()
