"""Why data cannot be read or changed, as the text an operator reports: data linked from a
library, objects with no finite place, meshes in Edit Mode; and lists of names for a report."""

from __future__ import annotations

import bpy

from .transforms import placed


def read_only(*blocks) -> str | None:
    """Why one of these data-blocks cannot be changed, or None. Data linked from another .blend
    file is read-only (``ID.is_editable``): writing groups, modifiers, bones or keys to it raises,
    so operators check before they change anything (keys: the object and its action)."""
    for block in blocks:
        if block is not None and not block.is_editable:
            where = bpy.path.basename(block.library.filepath) if block.library else "a library"
            how = ("the link icon beside its name in the Action Editor" if block.id_type == "ACTION"
                   else "Object > Relations > Make Local")
            return (f"{block.id_type.title()} '{block.name}' is linked from {where} and is read-only "
                    f"here: make it local ({how}) to change it")
    return None


def unplaced(*objects) -> str | None:
    """Why one of ``objects`` cannot be read in world space, or None: a NaN or infinite world
    transform (its own location, rotation or scale, a parent's, a constraint's, a driver gone
    wrong) puts it nowhere. Read as it is, an armature's bones would come out NaN and be
    reported as "zero-length", and Fit would stop with a traceback."""
    bad = [ob.name for ob in objects if ob is not None and not placed(ob.matrix_world)]
    if not bad:
        return None
    return (f"{'Object' if len(bad) == 1 else 'Objects'} {name_list([repr(n) for n in bad])} "
            f"{'has' if len(bad) == 1 else 'have'} a NaN or infinite transform (location, rotation or "
            "scale, or a parent's): set it in Object Properties > Transform")


def in_edit_mode(meshes) -> str | None:
    """Why ``meshes`` cannot be written now, or None: in Edit Mode a mesh's edits live apart
    from its data until Edit Mode ends, which then overwrites what an operator wrote."""
    editing = [ob.name for ob in meshes if ob.mode == "EDIT"]
    if editing:
        return f"Mesh in Edit Mode: {name_list(editing)}; leave Edit Mode first"
    return None


def name_list(names: list[str], most: int = 5) -> str:
    """The first ``most`` names for a report, comma-separated, with " ..." when there are more."""
    return ", ".join(names[:most]) + (" ..." if len(names) > most else "")
