"""Blender data to numpy arrays and back. No UI, no algorithms: those live in Rust.

Reads use ``foreach_get``; vertex groups are written by ``groups_io``.
"""

from __future__ import annotations

import re
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import bpy
import numpy as np

@dataclass
class Bones:
    """Deform bones of an armature in world space (rest pose).

    names: bone names (b,); heads, tails: (b, 3) float64 world space; parents: (b,) int32
    index into these bones or -1; selected: (b,) bool; skipped: names of zero-length bones;
    hidden: names of bones left out as hidden (``armature_bones(weight_paint=True)``);
    imported: the armature looks imported (see ``invented_tails``); curve_points (p, 3)
    float64 world space and curve_bones (p,) uint32: the inner joints of each B-Bone's rest
    curve, head to tail (empty unless filled from ``bbone_curves``, for Heat).
    """

    names: list[str]
    heads: np.ndarray
    tails: np.ndarray
    parents: np.ndarray
    selected: np.ndarray
    skipped: list[str] = field(default_factory=list)
    hidden: list[str] = field(default_factory=list)
    imported: bool = False
    curve_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    curve_bones: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint32))


def mesh_world_vertices(ob: bpy.types.Object) -> np.ndarray:
    """Rest-pose vertex positions of ``ob`` (its own mesh, no modifiers) in world space, (n, 3) float64."""
    return _world(ob, _positions(ob.data))


def smoothing_modifier(ob: bpy.types.Object):
    """``ob``'s first Catmull-Clark Subdivision Surface modifier that shows (in the viewport or
    the render, at a level above 0), or None. Blender's Ctrl+P With Automatic Weights weights
    such a cage where its vertices lie on the smooth surface (their limit positions)."""
    for m in ob.modifiers:
        if m.type == "SUBSURF" and m.subdivision_type == "CATMULL_CLARK" and (
                (m.show_viewport and m.levels > 0) or (m.show_render and m.render_levels > 0)):
            return m
    return None


def mesh_polygons(ob: bpy.types.Object) -> tuple[np.ndarray, np.ndarray]:
    """``ob``'s faces as corners per face (f,) uint32 and their vertex indices face after face
    (sum of the former,) uint32."""
    me = ob.data
    sizes = np.empty(len(me.polygons), dtype=np.uint32)
    me.polygons.foreach_get("loop_total", sizes)
    corners = np.empty(len(me.loops), dtype=np.uint32)
    me.loops.foreach_get("vertex_index", corners)
    return sizes, corners


def _positions(me: bpy.types.Mesh) -> np.ndarray:
    """``me``'s vertex positions, flat float32 (3n,)."""
    co = np.empty(len(me.vertices) * 3, dtype=np.float32)
    me.vertices.foreach_get("co", co)
    return co


def _world(ob: bpy.types.Object, co: np.ndarray) -> np.ndarray:
    """Object-space coordinates (flat or (n, 3)) in world space by ``ob.matrix_world``, (n, 3)
    float64: in single precision, world points 1e5 m from the origin are 8 mm apart, too
    coarse for a character's detail (``to_armature_frame`` brings them back near 0 first)."""
    m = np.array(ob.matrix_world, dtype=np.float64)
    return co.reshape(-1, 3).astype(np.float64) @ m[:3, :3].T + m[:3, 3]


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


def placed(m) -> bool:
    """Whether the matrix ``m`` (an object's world transform) is finite throughout."""
    return bool(np.isfinite(np.array(m, dtype=np.float64)).all())


def inverse(m) -> np.ndarray | None:
    """The inverse of the square matrix ``m`` (3x3, or 4x4 affine) in double precision, or None
    when it is not finite or its 3x3 part is singular relative to its size (a zero scale on an
    axis). mathutils inverts in single precision, where the determinant of a transform scaled by
    1e15 (1e45) overflows and one scaled by 1e-15 underflows."""
    a = np.array(m, dtype=np.float64)
    if not np.isfinite(a).all():
        return None
    sv = np.linalg.svd(a[:3, :3], compute_uv=False)
    if not sv.min() > 1e-12 * sv.max():
        return None
    return np.linalg.inv(a)


def axis_scales(m) -> np.ndarray:
    """The lengths of the axes of the transform ``m`` (``to_scale`` without its signs) in double
    precision: mathutils squares them in single precision, which overflows to inf past 1.8e19."""
    return np.linalg.norm(np.array(m, dtype=np.float64)[:3, :3], axis=0)


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


def extent(ob: bpy.types.Object) -> float:
    """The diagonal of ``ob``'s bounding box as placed in the world, in double precision
    (Blender's ``dimensions`` overflow to inf on an armature scaled by 1e30, which would make
    every one of its bones "zero-length")."""
    m = np.array(ob.matrix_world, dtype=np.float64)
    corners = np.array(ob.bound_box, dtype=np.float64) @ m[:3, :3].T
    return float(np.linalg.norm(np.ptp(corners, axis=0)))


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


def make_folder(path: Path) -> str | None:
    """Make the folder the file ``path`` goes in (and its parents): None, or why it cannot be
    written there (for the exports' and Make Video's reports). A name the file system refuses
    (too long) fails the checks themselves: that is a reason too, not a traceback."""
    try:
        if path.is_dir():
            return "it is a folder"
        blocker = next((p for p in path.parents if p.exists()), None)
        if blocker is not None and not blocker.is_dir():
            return f"'{blocker}' is a file, not a folder"
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        return err.strerror or str(err)
    return None


def keyed_action(ob: bpy.types.Object) -> bpy.types.Action | None:
    """The action new keys on ``ob`` go to (the tweaked strip's in NLA tweak mode), or None."""
    return ob.animation_data.action if ob.animation_data is not None else None


def shaped_world_mesh(ob: bpy.types.Object) -> tuple[np.ndarray, np.ndarray]:
    """World vertices (n, 3) float64 and triangles (m, 3) uint32 of ``ob`` as the rigger sees it
    undeformed: its modifier stack (Mirror, Subdivision, Solidify, ...) evaluated with its
    Armature modifiers off. Its own mesh when it has no other enabled modifier. An object
    linked from a library too: Blender lets its modifiers be switched off and on. For reading
    only (Fit); weights are written to the mesh's own vertices, so Heat reads those, as
    Blender's Ctrl+P does."""
    shaping = any(m.show_viewport and m.type != "ARMATURE" for m in ob.modifiers)
    if not shaping:
        return mesh_world_vertices(ob), mesh_triangles(ob)
    deforming = [m for m in ob.modifiers if m.type == "ARMATURE" and m.show_viewport]
    for m in deforming:
        m.show_viewport = False
    try:
        evaluated = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
        me = evaluated.to_mesh()
        try:
            co, tris = _positions(me), _loop_triangles(me)
        finally:
            evaluated.to_mesh_clear()
    finally:
        for m in deforming:
            m.show_viewport = True
    return _world(ob, co), tris


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


@contextmanager
def rest_pose(arm_ob: bpy.types.Object, meshes):
    """For the duration, ``arm_ob`` in its rest position when some of ``meshes`` follow one of
    its bones (``follows_bone``), so they are read where they are in the rest pose, as the bones
    are; then the armature as it was."""
    data = arm_ob.data
    if not any(follows_bone(ob, arm_ob) for ob in meshes) or data.pose_position == "REST":
        yield
        return
    data.pose_position = "REST"
    bpy.context.view_layer.update()
    try:
        yield
    finally:
        data.pose_position = "POSE"
        bpy.context.view_layer.update()


def armature_frame(arm_ob: bpy.types.Object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``arm_ob``'s world matrix split by polar decomposition, M = [R S | t]: the rotation R
    (orthogonal; a reflection for a negative scale), the stretch S (symmetric) and location t.
    Fit and X symmetry work in the frame (R, t): the armature's axes and origin, at world
    size, so a scaled armature (even unevenly) does not stretch the mesh's cross-sections."""
    m = np.array(arm_ob.matrix_world, dtype=np.float64)
    u, sigma, vt = np.linalg.svd(m[:3, :3])
    return u @ vt, vt.T @ np.diag(sigma) @ vt, m[:3, 3]


def to_armature_frame(arm_ob: bpy.types.Object, points: np.ndarray) -> np.ndarray:
    """World points (n, 3) in ``arm_ob``'s frame (``armature_frame``: its axes and origin, no
    scale), float32: where X symmetry means the armature's x = 0, for Auto Weights as for Fit
    (a rig moved, turned or scaled in the scene stays symmetric)."""
    r, _, t = armature_frame(arm_ob)
    return ((points.astype(np.float64) - t) @ r).astype(np.float32)


def stack_meshes(parts) -> tuple[np.ndarray, np.ndarray]:
    """Several meshes as one: ``parts`` (non-empty) of (vertices (n, 3), triangles (m, 3)) pairs
    -> (vertices stacked in order, triangles (m, 3) uint32 re-indexed into them)."""
    parts = list(parts)
    base = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
    verts = np.concatenate([v for v, _ in parts])
    tris = np.concatenate([np.asarray(t, np.int64).reshape(-1, 3) + b for (_, t), b in zip(parts, base)])
    return verts, tris.astype(np.uint32)


def mesh_triangles(ob: bpy.types.Object) -> np.ndarray:
    """Triangulation of ``ob``'s faces, (m, 3) uint32 vertex indices (Blender's loop triangles)."""
    return _loop_triangles(ob.data)


def _loop_triangles(me: bpy.types.Mesh) -> np.ndarray:
    me.calc_loop_triangles()
    tris = np.empty(len(me.loop_triangles) * 3, dtype=np.uint32)
    me.loop_triangles.foreach_get("vertices", tris)
    return tris.reshape(-1, 3)


def pose_flag(arm_ob: bpy.types.Object, bone: bpy.types.Bone, flag: str) -> bool:
    """``bone``'s Pose Mode ``flag`` ("select" or "hide"): Blender 5.0 keeps it on the pose
    bone, 4.x on the bone."""
    pb = arm_ob.pose.bones.get(bone.name) if arm_ob.pose else None
    if pb is not None and hasattr(pb, flag):
        return bool(getattr(pb, flag))
    return bool(getattr(bone, flag, False))


def _in_visible_collection(bone: bpy.types.Bone) -> bool:
    """A bone in no collection, or in one that shows (Blender's ``ANIM_bone_in_visible_collection``)."""
    return not bone.collections or any(c.is_visible_effectively for c in bone.collections)


def armature_bones(arm_ob: bpy.types.Object, min_length: float = 0.0, weight_paint: bool = False) -> Bones:
    """Deform bones of ``arm_ob`` in world space; bones shorter than ``min_length`` are skipped.
    ``weight_paint``: as Blender's Weight Paint > Assign Automatic from Bones, bones hidden in
    Pose Mode are left out (``hidden``), and a bone counts as selected only in a visible collection."""
    m = np.array(arm_ob.matrix_world, dtype=np.float64)
    deform = [b for b in arm_ob.data.bones if b.use_deform]
    names, heads, tails, sel, skipped, hidden = [], [], [], [], [], []
    for b in deform:
        if weight_paint and pose_flag(arm_ob, b, "hide"):
            hidden.append(b.name)
            continue
        h = m[:3, :3] @ np.array(b.head_local) + m[:3, 3]
        t = m[:3, :3] @ np.array(b.tail_local) + m[:3, 3]
        if not np.all(np.isfinite(h)) or not np.all(np.isfinite(t)) or np.linalg.norm(t - h) <= min_length:
            skipped.append(b.name)
            continue
        names.append(b.name)
        heads.append(h)
        tails.append(t)
        sel.append(pose_flag(arm_ob, b, "select") and (not weight_paint or _in_visible_collection(b)))
    index = {n: i for i, n in enumerate(names)}
    parents = []
    for n in names:
        p = arm_ob.data.bones[n].parent
        while p is not None and p.name not in index:  # skip non-deform / skipped ancestors
            p = p.parent
        parents.append(index[p.name] if p is not None else -1)
    as3 = lambda rows: np.asarray(rows, dtype=np.float64).reshape(-1, 3)  # noqa: E731
    return Bones(names, as3(heads), as3(tails), np.asarray(parents, dtype=np.int32),
                 np.asarray(sel, dtype=bool), skipped, hidden, imported=invented_tails(arm_ob.data.bones))


def bbone_curves(arm_ob: bpy.types.Object, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Inner joints of the rest curve of each of ``names`` that is a B-Bone (more than one
    segment), in world space, head to tail: (p, 3) float64 and the index into ``names`` of
    each, (p,) uint32 (for ``Bones.curve_points`` / ``curve_bones``). Blender's bone heat
    weights a B-Bone as these segments (its rest shape is a curve when its handles or curve
    settings bend it)."""
    points, owners = [], []
    refreshed = False
    for j, name in enumerate(names):
        bone, pose_bone = arm_ob.data.bones[name], arm_ob.pose.bones.get(name) if arm_ob.pose else None
        if bone.bbone_segments < 2 or pose_bone is None:
            continue
        joints = _bbone_joints(pose_bone, bone.bbone_segments)
        if joints is None and not refreshed:  # out-of-date segment data: evaluate the armature once
            refreshed = True
            bpy.context.view_layer.update()
            joints = _bbone_joints(pose_bone, bone.bbone_segments)
        if joints is None:  # unreadable: the bone stays straight
            continue
        points += [tuple(bone.matrix_local @ joint) for joint in joints]
        owners += [j] * len(joints)
    return _world(arm_ob, np.asarray(points, dtype=np.float64)), np.asarray(owners, dtype=np.uint32)


def _bbone_joints(pose_bone: bpy.types.PoseBone, segments: int) -> list | None:
    """The rest joints between ``pose_bone``'s B-Bone segments in bone space, or None when
    Blender has no up-to-date segment data for it."""
    try:
        return [pose_bone.bbone_segment_matrix(k, rest=True).translation.copy() for k in range(1, segments)]
    except RuntimeError:
        return None


def invented_tails(bones) -> bool:
    """Does this armature look imported from glTF/FBX, whose tails the importer invented?
    True when no bone is connected to its parent (rigs built in Blender have connected
    chains). ``bones``: an armature's bones or edit bones. The Auto rule of both Auto Weights'
    Bone Extent and Fit's Free Tails."""
    return not any(b.use_connect for b in bones)


_MIRROR_PATTERNS = [
    (r"([._\- ])([Ll])$", {"L": "R", "l": "r"}),
    (r"([._\- ])([Rr])$", {"R": "L", "r": "l"}),
    (r"^([Ll])([._\- ])", {"L": "R", "l": "r"}),
    (r"^([Rr])([._\- ])", {"R": "L", "r": "l"}),
    # Not Blender's own rule, but common in rigs from other tools: leg_back_L_knee.
    (r"([._\-])([LlRr])([._\-])", {"L": "R", "l": "r", "R": "L", "r": "l"}),
]


def mirror_name(name: str) -> str:
    """Blender's left/right name flip (.L/.R, _L/_R, -l, Left/Right, left/right); the name itself if none."""
    for pat, swap in _MIRROR_PATTERNS:
        m = re.search(pat, name)
        if m:
            s, e = m.span()
            part = m.group(0)
            flipped = "".join(swap.get(c, c) for c in part)
            return name[:s] + flipped + name[e:]
    for a, b in (("Left", "Right"), ("Right", "Left"), ("left", "right"), ("right", "left"),
                 ("LEFT", "RIGHT"), ("RIGHT", "LEFT")):
        if a in name:
            return name.replace(a, b, 1)
    return name


def _unnumbered(name: str) -> str:
    """``name`` without a trailing number (glTF exporters number nodes: b_LeftHand_011)."""
    return re.sub(r"[._\-]?\d+$", "", name)


def bone_mirror_indices(names: list[str]) -> np.ndarray:
    """For each bone, the index of its mirror bone by name, (b,) int32: itself for a centre bone
    (no side in its name), -1 for a side bone whose partner is missing.

    The partner is the flipped name (``mirror_name``), or else the one bone whose name matches it
    up to a trailing number (b_LeftUpperArm_09 <-> b_RightUpperArm_06). Pairs agree both ways.
    """
    index = {n: i for i, n in enumerate(names)}
    by_stem: dict[str, list[int]] = {}
    for i, n in enumerate(names):
        by_stem.setdefault(_unnumbered(n), []).append(i)
    out = np.full(len(names), -1, dtype=np.int32)
    for i, n in enumerate(names):
        other = mirror_name(n)
        if other == n:
            out[i] = i
        elif other in index:
            out[i] = index[other]
        else:
            same = by_stem.get(_unnumbered(other), [])
            out[i] = same[0] if len(same) == 1 else -1
    agree = np.array([m >= 0 and out[m] == i for i, m in enumerate(out)], dtype=bool)
    out[~agree] = -1
    return out


def paint_mask(ob: bpy.types.Object) -> tuple[np.ndarray | None, str]:
    """The vertices to re-weight when ``ob`` is in Weight Paint mode with a selection mask on,
    as Blender's Weights > Assign Automatic from Bones does: ((n,) bool, the mask's name), or
    (None, "") when it is not in Weight Paint mode or no mask is on."""
    me = ob.data
    if ob.mode != "WEIGHT_PAINT" or not (me.use_paint_mask_vertex or me.use_paint_mask):
        return None, ""
    picked = np.zeros(len(me.vertices), dtype=bool)
    if me.use_paint_mask_vertex:
        me.vertices.foreach_get("select", picked)
        return picked, "Vertex Selection"
    faces = np.zeros(len(me.polygons), dtype=bool)
    me.polygons.foreach_get("select", faces)
    sizes, corners = mesh_polygons(ob)
    picked[corners[np.repeat(faces, sizes)]] = True
    return picked, "Face Selection"


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
