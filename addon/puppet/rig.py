"""Which objects make a shadow puppet: the ID-property keys that tie a puppet's armature, rods,
prop and parts together, and finding the puppet (and its rods) from any of them."""

from __future__ import annotations

import bpy

from . import templates

KIND_KEY = "miniskeleton_puppet"      # on the armature object (and its data): the template kind
LIVE_KEY = "miniskeleton_live"        # on the armature object: solve live from the rods
RODS_KEY = "miniskeleton_rods"        # on the armature object: {role: rod object}
RIG_KEY = "miniskeleton_rig"          # on rods, prop and parts: the armature object
ROLE_KEY = "miniskeleton_rod"         # on a rod: its role ("neck", "hand.L", ...)
PART_KEY = "miniskeleton_part"        # on a part mesh: its bone
SEED_KEY = "miniskeleton_seed"        # on a pose bone: IK start angle, degrees
THEATRE_KEY = "miniskeleton_theatre"  # the role of the Shadow Theatre's screen, light and camera


class PuppetError(ValueError):
    """A puppet that cannot be solved as its scene stands (said in a line, never a traceback)."""


# ---------------------------------------------------------------------------- finding puppets


def puppet_rig(ob: bpy.types.Object | None) -> bpy.types.Object | None:
    """The puppet armature of ``ob`` (the armature itself, one of its rods, its prop or a part)."""
    for _ in range(4):
        if ob is None:
            return None
        if ob.type == "ARMATURE" and ob.get(KIND_KEY):
            return ob
        rig = ob.get(RIG_KEY)
        if isinstance(rig, bpy.types.Object):
            return rig
        ob = ob.parent
    return None


def puppet_poll(op: type[bpy.types.Operator], context: bpy.types.Context) -> bool:
    """Poll of the operators that act on a puppet: the active object belongs to one; if not,
    the greyed button's tooltip (and a script's error) says what to select."""
    if puppet_rig(context.active_object) is not None:
        return True
    op.poll_message_set(
        "Select a shadow puppet (its armature, a rod or a part); Add > Armature > Shadow Puppet makes one")
    return False


def scene_puppets(scene: bpy.types.Scene) -> list[bpy.types.Object]:
    """The puppet armatures of ``scene`` (made by Add Puppet: they carry ``KIND_KEY``)."""
    return [ob for ob in scene.objects if ob.type == "ARMATURE" and ob.get(KIND_KEY)]


def puppet_rods(rig: bpy.types.Object) -> dict[str, bpy.types.Object]:
    """{role: rod} of ``rig``'s rods that are still in a scene: one deleted in the viewport
    stays in the file while the rig refers to it, and the limb would go on following it unseen."""
    rods = rig.get(RODS_KEY) or {}
    return {role: ob for role, ob in rods.items() if isinstance(ob, bpy.types.Object) and ob.users_scene}


GAPS = "leaves these as they are (a bone renamed or deleted, a rod deleted)"


def puppet_template(rig: bpy.types.Object) -> templates.Template:
    """The template ``rig``'s ``KIND_KEY`` property names. PuppetError when it names none (a
    property edited by hand or by a script), saying which kinds there are."""
    kind = rig.get(KIND_KEY)
    if not (isinstance(kind, str) and kind in templates.KINDS):
        raise PuppetError(f"Puppet '{rig.name}' has the type {kind!r} in its '{KIND_KEY}' property, which "
                          f"is none of {', '.join(templates.KINDS)} (Object Properties > Custom Properties)")
    return templates.template(kind)


def puppet_gaps(rig: bpy.types.Object) -> list[str]:
    """What ``rig``'s drivers lack (``templates.driver_gaps``): bones renamed or deleted, rods deleted."""
    return templates.driver_gaps(puppet_template(rig), set(rig.pose.bones.keys()), set(puppet_rods(rig)))
