"""Auto Rig's work, without reports: the character's meshes read as one surface in world space,
the core's skeleton (``miniskeleton_core.auto_rig``) built into a new armature object with
sensible rolls and Rigify's rig types, and that armature taken out again when a later step fails.

The skeleton follows Rigify's metarigs (``rigify/metarigs/Basic/basic_human.py`` and
``basic_quadruped.py``, ``Animals/shark.py`` for Chain and ``Animals/bird.py`` for Winged): the
core gives the bone names, parents and joints; which pose bones
carry a Rigify rig type, and with which parameters, is ``RIGIFY_TYPES`` here, the one table of
it. With Rigify enabled the types are set through its properties; without it they are stored
where Rigify's registered properties keep them (``rigify_storage``), so Generate Rig works once
Rigify is enabled, as on a metarig saved and opened again.
"""

from __future__ import annotations

import bpy
import numpy as np

from ..common.meshes import shaped_world_mesh, stack_meshes

TEMPLATES = [
    ("AUTO", "Auto", "Read from the shape: legs that hold the body up (two: biped, four: quadruped), wings "
     "spread to the sides (winged), or neither (chain)"),
    ("BIPED", "Biped", "Two legs on the ground, two arms: Rigify's human metarig (spine, neck, head, legs "
     "with heels, arms)"),
    ("QUADRUPED", "Quadruped", "Four legs on the ground: Rigify's quadruped metarig (spine, neck, head, "
     "four paws, a tail when the mesh has one)"),
    ("CHAIN", "Chain", "No legs (a snake, a worm, a fish, a blob with a head): Rigify's shark metarig (a spine "
     "from tail to head, fins or tentacles as side chains)"),
    ("WINGED", "Winged", "Wings spread to the sides (a bird, a dragon, a moth): Rigify's bird metarig (spine, "
     "neck, head, tail, wings, and two or four legs when it stands on them)"),
]

# The way the character faces (the mesh's frame, +Z up); AUTO: found from the mesh.
FORWARDS = {"+X": (1.0, 0.0, 0.0), "-X": (-1.0, 0.0, 0.0), "+Y": (0.0, 1.0, 0.0), "-Y": (0.0, -1.0, 0.0)}
FORWARD_ITEMS = [("AUTO", "Auto", "Found from the mesh (where the head and the toes point)")] + [
    (key, key, f"The character faces {key}") for key in FORWARDS]

# The head's ears, horns and antennae (the core's pairs, longest first), as Rigify's horse
# metarig rigs its ears: a chain of two bones from the head, a tentacle.
HEAD_APPENDAGES = ("ear", "horn", "antenna")
_APPENDAGE_TYPES = {f"{name}.S": ("limbs.simple_tentacle", {}, {}) for name in HEAD_APPENDAGES}

# Rigify rig types on the pose bones, as in Rigify's Basic metarigs: template -> bone -> (rig
# type, parameters, bone collections of its FK and tweak controls). ".S" stands for both sides
# (.L and .R). Parameters that are enum names (strings), and the control collections, are set
# only through Rigify's properties (``store_rigify_types``); ``pivot_pos`` is kept inside the
# spine's chain, and ``connect_chain`` is on only where the bone starts where Rigify can join
# its parent's chain.
RIGIFY_TYPES = {
    "BIPED": {
        "spine": ("spines.basic_spine", {"pivot_pos": 2}, {"fk": "Torso (Tweak)", "tweak": "Torso (Tweak)"}),
        "spine.004": ("spines.super_head", {"connect_chain": True}, {"tweak": "Torso (Tweak)"}),
        "shoulder.S": ("basic.super_copy", {"make_widget": True, "super_copy_widget_type": "shoulder"}, {}),
        "thigh.S": ("limbs.leg", {"extra_ik_toe": True, "ik_local_location": False},
                    {"fk": "Leg.S (FK)", "tweak": "Leg.S (Tweak)"}),
        "upper_arm.S": ("limbs.arm", {"ik_local_location": False}, {"fk": "Arm.S (FK)", "tweak": "Arm.S (Tweak)"}),
        **_APPENDAGE_TYPES,
    },
    "QUADRUPED": {
        "spine.004": ("spines.basic_spine", {"pivot_pos": 4}, {"fk": "Spine (Tweak)", "tweak": "Spine (Tweak)"}),
        "spine.009": ("spines.super_head", {"connect_chain": True}, {"tweak": "Spine (Tweak)"}),
        "spine.003": ("spines.basic_tail", {"connect_chain": True}, {"tweak": "Spine (Tweak)"}),
        "shoulder.S": ("basic.super_copy", {"make_widget": False}, {}),
        "thigh.S": ("limbs.rear_paw", {"ik_local_location": False}, {"fk": "Leg.S (FK)", "tweak": "Leg.S (Tweak)"}),
        "front_thigh.S": ("limbs.front_paw", {"ik_local_location": False},
                          {"fk": "Arm.S (FK)", "tweak": "Arm.S (Tweak)"}),
        **_APPENDAGE_TYPES,
    },
    # Rigify's shark metarig: its torso spine.003 > spine.008 > spine.004 > spine.005, the head
    # spine.006 > spine.007, the tail spine.002 > spine.001 > spine, fins as tentacles.
    "CHAIN": {
        "spine.003": ("spines.basic_spine", {"pivot_pos": 2}, {"fk": "Spine (Tweak)", "tweak": "Spine (Tweak)"}),
        "spine.006": ("spines.super_head", {"connect_chain": True}, {"tweak": "Spine (Tweak)"}),
        "spine.002": ("spines.basic_tail", {"connect_chain": True}, {"tweak": "Spine (Tweak)"}),
        **{f"{fin}.S": ("limbs.simple_tentacle", {}, {})
           for fin in ("side_fin", "chest_fin", "back_fin", "mid_fin", "tail_fin")},
    },
    # Rigify's bird metarig: torso spine.003 > ... > spine.006, neck.001 > neck.002 > head, wings
    # from a shoulder, legs as paws.
    "WINGED": {
        "spine.003": ("spines.basic_spine", {"pivot_pos": 2}, {"fk": "Spine (Tweak)", "tweak": "Spine (Tweak)"}),
        "neck.001": ("spines.super_head", {"connect_chain": True}, {"tweak": "Spine (Tweak)"}),
        "spine.002": ("spines.basic_tail", {"connect_chain": True}, {"tweak": "Spine (Tweak)"}),
        "shoulder.S": ("basic.super_copy", {"make_widget": False}, {}),
        "Wing.S": ("limbs.simple_tentacle", {}, {}),
        "thigh.S": ("limbs.paw", {"ik_local_location": False}, {"fk": "Leg.S (FK)", "tweak": "Leg.S (Tweak)"}),
        "front_thigh.S": ("limbs.paw", {"ik_local_location": False}, {"fk": "Arm.S (FK)", "tweak": "Arm.S (Tweak)"}),
    },
}

# Rigify's bone collections, as on its Basic metarigs: (name, row of its button in the rig's UI,
# title of the button). Generate Rig needs at least one with a button; the rig's controls go
# into them ("Root" gets the root control). ".S": one each side.
_LIMBS = [(f"{part}.S ({kind})", row + k, "" if kind == "IK" else f"({kind})")
          for part, row in (("Arm", 4), ("Leg", 8)) for k, kind in enumerate(("IK", "FK", "Tweak"))]
BONE_COLLECTIONS = {
    "BIPED": [("Torso", 1, ""), ("Torso (Tweak)", 2, "(Tweak)"), *_LIMBS, ("Root", 13, "")],
    "QUADRUPED": [("Spine", 1, ""), ("Spine (Tweak)", 2, "(Tweak)"), *_LIMBS, ("Tail", 12, ""), ("Root", 15, "")],
    "CHAIN": [("Spine", 1, ""), ("Spine (Tweak)", 2, "(Tweak)"), ("Fins", 3, ""), ("Tail", 4, ""), ("Root", 6, "")],
    "WINGED": [("Spine", 1, ""), ("Spine (Tweak)", 2, "(Tweak)"), ("Wings", 3, ""), *_LIMBS, ("Tail", 12, ""),
               ("Root", 15, "")],
}
# Tail bones of each template (a quadruped's tail leaves its root; a chain's and a bird's theirs).
TAIL_BONES = {"QUADRUPED": ("spine", "spine.001", "spine.002", "spine.003"),
              "CHAIN": ("spine", "spine.001", "spine.002"), "WINGED": ("spine", "spine.001", "spine.002")}
# Bones whose Z axis points forward (the arms; their X axis, the elbow's and wrist's bending
# axis, then lies across the arm), and bones whose X axis points to the character's right
# (the toes), as on Rigify's metarigs. Every other bone has its X axis to the character's left
# (knees, spine and neck bend about it), or, lying along that axis (shoulders, heels), its Z up.
ARM_BONES = ("upper_arm.", "forearm.", "hand.")
TOE_BONES = ("toe.", "front_toe.")
# Markers Rigify reads and that deform nothing: the heel (the foot's roll pivot, lying across
# the heel on the ground, partly outside the mesh), which would take weight from the foot.
MARKER_BONES = ("heel.",)


class AutoRigError(Exception):
    """Why the character cannot be rigged, as the text of the operator's error report."""


def rig_types(template: str, names: list[str]) -> dict[str, tuple[str, dict, dict]]:
    """``RIGIFY_TYPES[template]`` for the bones present in ``names``, sides spelled out (in the
    bone names and in the names of the control collections)."""
    out = {}
    for bone, (rig_type, params, refs) in RIGIFY_TYPES.get(template, {}).items():
        for side in (("L", "R") if bone.endswith(".S") else ("",)):
            name = bone[:-1] + side if side else bone
            if name in names:
                out[name] = (rig_type, params, {k: v.replace(".S ", f".{side} ") for k, v in refs.items()})
    return out


def bone_collection(template: str, name: str) -> str:
    """The Rigify bone collection (``BONE_COLLECTIONS``) bone ``name`` goes in, as on the Basic
    and Animals metarigs: limbs by side, a quadruped's shoulders with its front legs, tails,
    fins and wings apart, the rest in the torso."""
    side = name[-1] if name.endswith((".L", ".R")) else ""
    if name in TAIL_BONES.get(template, ()):
        return "Tail"
    if template == "CHAIN" and side:
        return "Fins"
    if template == "WINGED" and name.startswith(("Wing", "shoulder.")):
        return "Wings"
    if side and (name.startswith(("upper_arm.", "forearm.", "hand.", "front_"))
                 or (template == "QUADRUPED" and name.startswith("shoulder."))):
        return f"Arm.{side} (IK)"
    if side and name.startswith(("thigh.", "shin.", "foot.", "toe.", "heel.")):
        return f"Leg.{side} (IK)"
    return "Torso" if template == "BIPED" else "Spine"


def read_character(meshes) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The meshes as one surface in world space, as the viewport shows them undeformed
    (``shaped_world_mesh``: modifiers on, Armature modifiers off, so a half modelled with a
    Mirror modifier is rigged whole): (vertices (n, 3) float64, triangles (m, 3) uint32, names of
    the meshes without faces, left out). AutoRigError when a mesh has NaN or infinite
    coordinates; (empty, empty, names) when no mesh has a face."""
    parts, faceless = [], []
    for ob in meshes:
        v, t = shaped_world_mesh(ob)
        if len(v) == 0 or len(t) == 0:
            faceless.append(ob.name)
            continue
        bad = int((~np.isfinite(v)).any(axis=1).sum())
        if bad:
            raise AutoRigError(f"Mesh '{ob.name}' has {bad} {'vertex' if bad == 1 else 'vertices'} with NaN "
                               "or infinite coordinates")
        parts.append((v, t))
    if not parts:
        return np.zeros((0, 3)), np.zeros((0, 3), np.uint32), faceless
    verts, tris = stack_meshes(parts)
    return verts, tris, faceless


def ground_point(verts: np.ndarray) -> np.ndarray:
    """Where the armature object goes: under the middle of the bounding box, on its lowest
    point (the ground the character stands on), (3,) float64. Rigify's root control is made at
    the armature's origin, and the core works near 0 in single precision."""
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    return np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])


def fit_rig(core, verts: np.ndarray, tris: np.ndarray, origin: np.ndarray, template: str, forward: str):
    """The core's skeleton for the surface ``verts`` (world, float64) and ``tris``, with joints
    relative to ``origin`` (``miniskeleton_core.AutoRig``). AutoRigError with the core's reason when
    it finds none."""
    local = (verts - origin).astype(np.float32)
    try:
        rig = core.auto_rig(local, tris, template=template,
                            forward=None if forward == "AUTO" else np.array(FORWARDS[forward], np.float32))
    except (ValueError, RuntimeError) as err:
        reason = str(err).strip()
        reason = reason[len("auto_rig:"):].strip() if reason.startswith("auto_rig:") else reason
        raise AutoRigError(reason[:1].upper() + reason[1:]) from None
    heads, tails = np.asarray(rig.heads, np.float64), np.asarray(rig.tails, np.float64)
    if not len(rig.names) or not (np.isfinite(heads).all() and np.isfinite(tails).all()):
        raise AutoRigError("The core returned no usable skeleton")
    return rig


def facing_name(forward) -> str:
    """The axis nearest to the horizontal ``forward`` (3,), as "+X", "-Y"...; with its angle
    when more than 10 degrees off it."""
    f = np.asarray(forward, np.float64)[:2]
    angle = float(np.degrees(np.arctan2(f[1], f[0])))
    axis = min(FORWARDS, key=lambda k: np.linalg.norm(np.array(FORWARDS[k][:2]) - f / max(np.linalg.norm(f), 1e-30)))
    off = abs((angle - float(np.degrees(np.arctan2(FORWARDS[axis][1], FORWARDS[axis][0]))) + 180) % 360 - 180)
    return axis if off <= 10 else f"{axis} ({angle:.0f} degrees from +X)"


def bone_z_axes(names: list[str], heads: np.ndarray, tails: np.ndarray, forward, left) -> np.ndarray:
    """The direction each bone's Z axis is rolled toward (``EditBone.align_roll``), (b, 3): the
    conventions of Rigify's metarigs (``ARM_BONES``, ``TOE_BONES``)."""
    forward, left = np.asarray(forward, np.float64), np.asarray(left, np.float64)
    up = np.array([0.0, 0.0, 1.0])
    y = tails - heads
    y /= np.maximum(np.linalg.norm(y, axis=1, keepdims=True), 1e-30)
    out = np.empty_like(y)
    for i, name in enumerate(names):
        if name.startswith(ARM_BONES):
            out[i] = forward
        elif abs(float(y[i] @ left)) > 0.7:
            out[i] = up
        else:
            x = -left if name.startswith(TOE_BONES) else left
            out[i] = np.cross(x, y[i])
    return out


def _collection(context) -> bpy.types.Collection:
    """Where Add puts new objects (the active collection), unless it is linked from a library."""
    coll = context.collection
    return coll if coll is not None and coll.library is None else context.scene.collection


def build_armature(context, name: str, origin: np.ndarray, rig) -> bpy.types.Object:
    """A new armature object ``name`` at ``origin`` (world, no rotation or scale) with the
    core's bones (joints relative to ``origin``; the heel a marker that does not deform), in
    front of the mesh, active and selected alone, in Object Mode."""
    data = bpy.data.armatures.new(name)
    arm = bpy.data.objects.new(name, data)
    arm.location = tuple(float(c) for c in origin)
    arm.show_in_front = True
    _collection(context).objects.link(arm)
    if not arm.visible_get():  # the active collection is hidden or excluded: Edit Mode needs it shown
        for coll in list(arm.users_collection):
            coll.objects.unlink(arm)
        context.scene.collection.objects.link(arm)
    for ob in context.selected_objects:
        ob.select_set(False)
    arm.select_set(True)
    context.view_layer.objects.active = arm
    names = list(rig.names)
    heads, tails = np.asarray(rig.heads, np.float64), np.asarray(rig.tails, np.float64)
    parents, connected = np.asarray(rig.parents), np.asarray(rig.connected, bool)
    z_axes = bone_z_axes(names, heads, tails, rig.forward, rig.left)
    # A bone that starts a Rigify rig of its own (the head's, the tail's) is not connected to
    # its parent, as on the metarigs: Rigify's chain rigs would take it into the parent's chain.
    rig_roots = set(rig_types(rig.template, names))
    bpy.ops.object.mode_set(mode="EDIT")
    try:
        ebs = []
        for i, bone in enumerate(names):
            eb = data.edit_bones.new(bone)
            eb.head, eb.tail = heads[i].tolist(), tails[i].tolist()
            ebs.append(eb)
        for i, eb in enumerate(ebs):
            if parents[i] >= 0:
                eb.parent = ebs[int(parents[i])]
                eb.use_connect = bool(connected[i]) and eb.name not in rig_roots
            eb.align_roll(z_axes[i].tolist())
            eb.use_deform = not eb.name.startswith(MARKER_BONES)
            eb.bbone_x = eb.bbone_z = eb.length * 0.05  # the metarigs' display size
    finally:
        bpy.ops.object.mode_set(mode="OBJECT")
    return arm


def rigify_storage(owner):
    """Where Rigify's registered properties of ``owner`` (a pose bone, a bone collection) live
    while Rigify is not enabled: its system properties (Blender 5.0 keeps properties defined by
    add-ons apart from custom properties), or on 4.x its own ID properties, which those
    registered properties read."""
    system = getattr(owner, "bl_system_properties_get", None)
    return system(do_create=True) if system is not None else owner


def store_rigify_types(arm: bpy.types.Object, template: str) -> bool:
    """Give ``arm`` Rigify's bone collections (``BONE_COLLECTIONS``, every bone in its own:
    ``bone_collection``) and rig types (``RIGIFY_TYPES``). True when Rigify is enabled and they
    were set through its properties; False when they were stored for it (``rigify_storage``; enum
    parameters and the collections of the FK and tweak controls left to Rigify's defaults)."""
    enabled = hasattr(bpy.types.PoseBone, "rigify_type")
    names = [b.name for b in arm.data.bones]
    collections = {}
    for name, row, title in BONE_COLLECTIONS[template]:
        for side in (("L", "R") if ".S " in name else ("",)):
            coll = arm.data.collections.new(name.replace(".S ", f".{side} ") if side else name)
            values = {"rigify_ui_row": row, "rigify_ui_title": title}
            if enabled:
                for key, value in values.items():
                    setattr(coll, key, value)
            else:
                store = rigify_storage(coll)
                for key, value in values.items():
                    store[key] = value
            collections[coll.name] = coll
    for bone in arm.data.bones:
        collections[bone_collection(template, bone.name)].assign(bone)
    for bone, (rig_type, params, refs) in rig_types(template, names).items():
        pb = arm.pose.bones[bone]
        params = dict(params)
        if "pivot_pos" in params:  # inside the spine's chain (Rigify refuses a pivot outside it)
            params["pivot_pos"] = max(1, min(params["pivot_pos"], _chain_length(arm.data.bones[bone]) - 1))
        if params.get("connect_chain") and not _joins_parent_chain(arm.data.bones[bone]):
            params["connect_chain"] = False  # Rigify refuses to join it: the rig stays on its own
        if enabled:
            pb.rigify_type = rig_type
            for key, value in params.items():
                if hasattr(pb.rigify_parameters, key):
                    setattr(pb.rigify_parameters, key, value)
            for key, coll in refs.items():
                ref_list = getattr(pb.rigify_parameters, f"{key}_coll_refs", None)
                if ref_list is not None:
                    ref_list.add().set_collection(collections[coll])
        else:
            store = rigify_storage(pb)
            store["rigify_type"] = rig_type
            store["rigify_parameters"] = {k: v for k, v in params.items() if not isinstance(v, str)}
    return enabled


def _joins_parent_chain(bone: bpy.types.Bone) -> bool:
    """Whether Rigify's ``connect_chain`` can join ``bone``'s rig to its parent's chain: its head
    at the parent's tail, or at the head of the parent's connected chain (a tail leaving the
    hips), within Rigify's 1e-5."""
    parent = bone.parent
    if parent is None:
        return False
    root = parent
    while root.parent is not None and root.use_connect:
        root = root.parent
    head = bone.head_local
    return (parent.tail_local - head).length < 1e-5 or (root.head_local - head).length < 1e-5


def _chain_length(bone: bpy.types.Bone) -> int:
    """Bones in the connected chain that starts at ``bone`` (Rigify's spine chain)."""
    count = 1
    while True:
        nxt = [c for c in bone.children if c.use_connect]
        if not nxt:
            return count
        bone, count = nxt[0], count + 1


def remove_armature(arm: bpy.types.Object, meshes) -> None:
    """Take ``arm`` out again (its object and data), with whatever a bind had begun on
    ``meshes``: Armature modifiers deforming by it, parenting to it (the mesh kept where it is)."""
    for ob in meshes:
        for mod in [m for m in ob.modifiers if m.type == "ARMATURE" and m.object == arm]:
            ob.modifiers.remove(mod)
        if ob.parent == arm:
            world = ob.matrix_world.copy()
            ob.parent = None
            ob.matrix_world = world
    data = arm.data
    bpy.data.objects.remove(arm)
    if data.users == 0:
        bpy.data.armatures.remove(data)


def rigify_enabled() -> bool:
    """Whether the Rigify add-on is enabled (its properties are registered)."""
    return hasattr(bpy.types.PoseBone, "rigify_type")


def make_control_rig(context, metarig: bpy.types.Object, meshes, bind: bool) -> bpy.types.Object:
    """Rigify's Generate Rig on ``metarig`` (Auto Rig's armature), then, with ``bind``, the
    meshes bound to the control rig's DEF bones instead: the metarig's groups, modifier and
    parent taken off and Auto Weights (Heat) solved again for the DEF bones (Rigify splits a
    limb bone into twist segments, which take their own share). The metarig is hidden, as after
    a Generate by hand; the control rig is active and selected alone. On any failure the
    control rig is removed again and the error raised."""
    for ob in context.selected_objects:
        ob.select_set(False)
    metarig.select_set(True)
    context.view_layer.objects.active = metarig
    rig = None
    try:
        try:
            result = bpy.ops.pose.rigify_generate()
        except RuntimeError as err:
            raise RuntimeError(f"Rigify's Generate Rig failed: {str(err).removeprefix('Error: ').strip()}") from None
        rig = metarig.data.rigify_target_rig
        if result != {"FINISHED"} or rig is None:
            raise RuntimeError(f"Rigify's Generate Rig failed ({', '.join(result)})")
        if bind:
            names = {b.name for b in metarig.data.bones}
            for ob in meshes:
                for mod in [m for m in ob.modifiers if m.type == "ARMATURE" and m.object == metarig]:
                    ob.modifiers.remove(mod)
                for group in [g for g in ob.vertex_groups if g.name in names]:
                    ob.vertex_groups.remove(group)
                if ob.parent == metarig:
                    world = ob.matrix_world.copy()
                    ob.parent = None
                    ob.matrix_world = world
            if context.object is not None and context.object.mode != "OBJECT":
                bpy.ops.object.mode_set(mode="OBJECT")
            for ob in context.selected_objects:
                ob.select_set(False)
            for ob in meshes:
                ob.select_set(True)
            rig.select_set(True)
            context.view_layer.objects.active = rig
            try:
                done = bpy.ops.object.miniskeleton_auto_weights(method="HEAT")
            except RuntimeError as err:
                raise RuntimeError(f"binding to the control rig failed: "
                                   f"{str(err).removeprefix('Error: ').strip()}") from None
            if done != {"FINISHED"}:
                raise RuntimeError(f"binding to the control rig failed ({', '.join(done)})")
    except Exception:
        if rig is not None:
            remove_armature(rig, meshes)
        raise
    for ob in context.selected_objects:
        ob.select_set(False)
    metarig.hide_set(True)
    rig.select_set(True)
    context.view_layer.objects.active = rig
    return rig
