"""The motion the core plans for an armature: which armature Add Motion acts on, its skeleton as
the core reads it (world axes from the armature's origin, metres, rest orientations), the
core's ``make_motion`` call at a size it handles in single precision, and the bone roles it
found, described for the console."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import bpy
import numpy as np

from ..common import native
from ..common.armatures import armature_bones, rest_pose
from ..common.meshes import mesh_world_vertices
from ..common.objects import follows_bone
from ..common.reports import name_list


def motion_armature(context: bpy.types.Context) -> bpy.types.Object | None:
    """The active armature, or the armature deforming / parenting the active mesh."""
    ob = context.active_object
    if ob is None:
        return None
    if ob.type == "ARMATURE":
        return ob
    if ob.type == "MESH":
        for mod in ob.modifiers:
            if mod.type == "ARMATURE" and mod.object is not None:
                return mod.object
        if ob.parent is not None and ob.parent.type == "ARMATURE":
            return ob.parent
    return None


def motion_bones(arm: bpy.types.Object, min_length: float = 0.0):
    """The deform bones the motion moves (``armature_bones``), each deform bone that hangs from
    non-deform bones only given as parent the deform bone that takes the place of one of them
    (``twin_parents``): a control rig's deform chains (Rigify's DEF- bones under its ORG- and
    MCH- bones) make one skeleton again. Weights read the armature's own parents."""
    bones = armature_bones(arm, min_length=min_length)
    bones.parents = twin_parents(arm, bones)
    return bones


def twin_parents(arm: bpy.types.Object, bones) -> np.ndarray:
    """``bones.parents`` with each root (a deform bone with no deform ancestor) whose parent is a
    non-deform bone re-parented: its non-deform ancestors are walked up, nearest first, until
    one has a deform twin (another of ``bones`` with the same head and tail, within 1e-4 of the
    skeleton's size, outside the root's own subtree) and that twin becomes its parent. Rigify
    hangs DEF-thigh.L from ORG-spine, whose twin is DEF-spine; DEF-pelvis.L hangs from its own
    twin ORG-pelvis.L, whose parent ORG-spine has the twin DEF-spine. A rig whose deform
    bones hang from deform bones keeps its parents."""
    parents = np.array(bones.parents, dtype=np.int32)
    if len(bones.names) == 0:
        return parents
    ends = np.concatenate([bones.heads, bones.tails])
    tol = 1e-4 * float(np.linalg.norm(np.ptp(ends, axis=0)))
    m = np.array(arm.matrix_world, dtype=np.float64)

    def world(v):
        return m[:3, :3] @ np.array(v, dtype=np.float64) + m[:3, 3]

    def inside(i, root):   # is bone i in root's subtree (as re-parented so far)?
        while i >= 0:
            if i == root:
                return True
            i = parents[i]
        return False

    for i, name in enumerate(bones.names):
        up = arm.data.bones[name].parent
        if parents[i] >= 0 or up is None:
            continue
        while up is not None:
            near = np.flatnonzero((np.linalg.norm(bones.heads - world(up.head_local), axis=1) <= tol)
                                  & (np.linalg.norm(bones.tails - world(up.tail_local), axis=1) <= tol))
            twins = [int(j) for j in near if int(j) != i and not inside(int(j), i)]
            if twins:
                parents[i] = twins[0]
                break
            up = up.parent
    return parents


def skinned_meshes(arm: bpy.types.Object) -> list[bpy.types.Object]:
    """The meshes of the scene that ``arm`` moves: an Armature modifier on it, or a bone parent."""
    return [ob for ob in bpy.context.scene.objects if ob.type == "MESH" and (
        follows_bone(ob, arm) or any(m.type == "ARMATURE" and m.object == arm for m in ob.modifiers))]


# Most skin points given to the core (every k-th vertex, and each mesh's lowest ones).
SKIN_POINTS = 20000
LOWEST = 256


def motion_skin(arm: bpy.types.Object, bones) -> tuple[np.ndarray, np.ndarray]:
    """The skin of the meshes ``arm`` moves, at rest, for the core: (p, 3) world points, float64,
    and (p,) int32 the index into ``bones.names`` of the bone that weighs most on each (a part
    parented to a bone: that bone; a bone not among ``bones``, such as a Rigify DEF segment
    merged into the one before it: its nearest ancestor that is; -1 for none). At most
    ``SKIN_POINTS`` points: every k-th vertex and each mesh's ``LOWEST`` lowest."""
    meshes = skinned_meshes(arm)
    total = sum(len(ob.data.vertices) for ob in meshes)
    step = max(1, -(-total // SKIN_POINTS))
    index = {n: i for i, n in enumerate(bones.names)}
    owner_of: dict[str, int] = {}

    def owner(name: str) -> int:
        if name not in owner_of:
            bone = arm.data.bones.get(name)
            while bone is not None and bone.name not in index:
                bone = bone.parent
            owner_of[name] = index[bone.name] if bone is not None else -1
        return owner_of[name]

    points, owners = [], []
    with rest_pose(arm, meshes):
        for ob in meshes:
            co = mesh_world_vertices(ob)
            if not len(co):
                continue
            pick = np.union1d(np.arange(0, len(co), step), np.argsort(co[:, 2])[:LOWEST])
            if follows_bone(ob, arm):
                own = np.full(len(pick), owner(ob.parent_bone), dtype=np.int32)
            else:
                groups = {g.index: g.name for g in ob.vertex_groups}
                verts = ob.data.vertices
                own = np.full(len(pick), -1, dtype=np.int32)
                for k, i in enumerate(pick):
                    best = max(((g.weight, g.group) for g in verts[int(i)].groups if g.group in groups),
                               default=(0.0, -1))
                    if best[0] > 0.0:
                        own[k] = owner(groups[best[1]])
            points.append(co[pick])
            owners.append(own)
    if not points:
        return np.zeros((0, 3)), np.zeros(0, dtype=np.int32)
    return np.concatenate(points), np.concatenate(owners)


def rest_matrices(arm: bpy.types.Object, names: list[str]) -> np.ndarray:
    """(b, 3, 3) rest orientation of each bone in world space (columns = bone X, Y, Z, of unit
    length: the armature's scale taken out in double precision, as the core's single-precision
    thresholds would take a rig scaled by 1e-15 or 1e25 for one with no axes)."""
    world = np.array(arm.matrix_world.to_3x3(), dtype=np.float64)
    local = np.array([np.array(arm.data.bones[n].matrix_local.to_3x3()) for n in names],
                     dtype=np.float64).reshape(-1, 3, 3)
    m = world @ local
    norms = np.linalg.norm(m, axis=1, keepdims=True)   # of each column
    return (m / np.where(norms > 0, norms, 1.0)).astype(np.float32)


def motion_skeleton(arm: bpy.types.Object, bones, skin=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Heads and tails of ``bones`` along world axes from the armature's origin, and their world
    rest orientations (``rest_matrices``), for the core; ``skin`` (world points, (p, 3)) is
    brought along in place. The origin is taken off in double precision: the motion does not
    depend on where the rig stands, and 1e5 m from the world origin single-precision points are
    8 mm apart. An armature mirrored by a negative scale is given as its mirror image across
    x = 0: there its rest frames are rotations again, and the local rotations that make that
    image walk make the armature itself walk (its mirror image's motion, mirrored back)."""
    origin = np.array(arm.matrix_world.translation, dtype=np.float64)
    heads, tails = bones.heads - origin, bones.tails - origin
    rest = rest_matrices(arm, bones.names)
    if skin is not None:
        skin -= origin
    # in double precision: mathutils' single-precision determinant of a mirror scaled by 1e-15
    # underflows to 0, and the mirror would go unseen
    if np.linalg.det(np.array(arm.matrix_world.to_3x3(), dtype=np.float64)) < 0:
        heads[:, 0] *= -1
        tails[:, 0] *= -1
        rest[:, 0, :] *= -1
        if skin is not None:
            skin[:, 0] *= -1
    return heads, tails, rest


def scene_metres(scene: bpy.types.Scene) -> float:
    """Metres per Blender unit: the scene's Unit Scale (1 when unset or unusable)."""
    m = float(scene.unit_settings.scale_length)
    return m if math.isfinite(m) and m > 0.0 else 1.0


@dataclass(frozen=True)
class Motion:
    """The core's ``MotionClip`` with its offsets in the armature's world units: root_offset
    (frames, 3) and locations (frames, b, 3) float64; the rest as the core gives them."""
    rotations: np.ndarray
    root_offset: np.ndarray
    animated: np.ndarray
    locations: np.ndarray
    located: np.ndarray
    moves_root: bool
    frames: int
    frames_per_cycle: float
    roles: object  # the core's Roles

    @classmethod
    def in_world_units(cls, clip, scale: float) -> Motion:
        """``clip`` (a ``MotionClip``) with root_offset and locations times ``scale``."""
        fields = {f.name: getattr(clip, f.name) for f in dataclasses.fields(cls)}
        for key in ("root_offset", "locations"):
            fields[key] = np.asarray(fields[key], dtype=np.float64) * scale
        return cls(**fields)


def make_motion(arm, bones, scene, fps: float, motion: str, cycles: float, duration: float, amplitude: float,
                stride: float, speed: float, root_motion: bool, path: np.ndarray | None = None,
                ground: tuple | None = None) -> Motion:
    """The core's ``motion`` (``make_motion``: "HEAD_SHAKE", "WALK" or "RUN", with the Add Motion
    options) for ``arm``'s deform ``bones`` (``armature_bones``) at ``fps``, its offsets in the
    armature's world units; ValueError when the core finds no legs or no head. The skin of the
    meshes it moves (``motion_skin``) tells the core where the feet stand and how wide the body
    is beside the arms. ``path`` (p, 3) world points and ``ground`` (``steering.ground_field``,
    world) go to the core in its space."""
    core = native.core()
    skin, skin_bones = motion_skin(arm, bones)
    heads, tails, rest = motion_skeleton(arm, bones, skin)
    origin = np.array(arm.matrix_world.translation, dtype=np.float64)
    mirrored = np.linalg.det(np.array(arm.matrix_world.to_3x3(), dtype=np.float64)) < 0
    # The cadence follows the leg length in metres: the core gets the skeleton in metres,
    # by the scene's Unit Scale (in a centimetre scene, 0.01, a creature would otherwise walk
    # at the slowest cadence, as if its legs were metres long).
    metres = scene_metres(scene)
    heads, tails, skin = heads * metres, tails * metres, skin * metres
    # The core works in single precision and squares lengths: a skeleton over about 1e19
    # units overflows ("the skeleton is flat"). One larger than 1e6 m or smaller than
    # 1e-3 m is given at that size, by a power of two (exact), and the offsets scaled back;
    # the cadence is clamped there all the same.
    size = float(np.linalg.norm(np.ptp(np.concatenate([heads, tails]).astype(np.float64), axis=0)))
    unit_size = 1.0
    if size > 1e6:
        unit_size = 2.0 ** math.floor(math.log2(size / 1e6))
    elif 0.0 < size < 1e-3:
        unit_size = 2.0 ** math.ceil(math.log2(size / 1e-3))
    scale = metres / unit_size   # world units, from the armature's origin, to the core's
    steer = {}
    if path is not None:
        points = (np.asarray(path, dtype=np.float64) - origin) * scale
        if mirrored:
            points[:, 0] *= -1
        steer["path"] = points
    if ground is not None:
        (x, y), cell, heights = ground
        heights = (np.asarray(heights, dtype=np.float64) - origin[2]) * scale
        x = x - origin[0]
        if mirrored:   # the grid seen in the mirror: its columns reversed
            x = -(x + (heights.shape[1] - 1) * cell)
            heights = heights[:, ::-1]
        steer["ground"] = ((x * scale, (y - origin[1]) * scale), cell * scale, heights)
    out = core.make_motion(
        heads / unit_size, tails / unit_size, bones.parents, rest, motion,
        names=bones.names, fps=fps, cycles=cycles, duration=duration,
        amplitude=amplitude, stride=stride, speed=speed,
        root_motion=root_motion, joint_tails=bones.imported, skin_points=skin / unit_size, skin_bones=skin_bones,
        **steer)
    return Motion.in_world_units(out, unit_size / metres)


def describe_roles(roles, names: list[str]) -> list[str]:
    """One line per role: 'head: head (+ jaw, ear.L, ear.R)'."""
    def n(ids):  # a rig with hundreds of hair bones gets a dozen names and the count
        listed = name_list([names[i] for i in ids], 12)
        return (f"{listed} ({len(ids)} in all)" if len(ids) > 12 else listed) or "-"

    lines = [f"body: {roles.plan}", f"root: {names[roles.root]}", f"spine: {n(roles.spine)}",
             f"neck: {n(roles.neck)}", f"head: {names[roles.head]}"
             + (f" (+ {n(roles.head_extras)})" if roles.head_extras else "")]
    if roles.tail:
        lines.append(f"tail: {n(roles.tail)}")
    groups = max((leg.group for leg in roles.legs), default=0) + 1
    for leg in roles.legs:
        where = ("front " if leg.group == 0 else "back " if leg.group == groups - 1 else
                 f"middle {leg.group} ") if groups > 1 else ""
        lines.append(f"leg {where}{leg.side}: {n(leg.bones)}")
    for arm in roles.arms:
        lines.append(f"arm {arm.side}: {n(arm.bones)}")
    lines += [f"note: {note}" for note in roles.notes]
    return lines


def quaternion_matrices(q: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices of the quaternions ``q`` (..., 4) w, x, y, z (normalised)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.maximum(np.linalg.norm(q, axis=-1, keepdims=True), 1e-300)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


class PlannedPose:
    """Forward kinematics of the core's motion ``out`` on ``bones`` (``motion_bones``): calling it
    with a bone index gives its (frames, 4, 4) armature-space pose matrix, what Blender's
    ``pose_bone.matrix`` would be on each frame were the motion keyed on these bones themselves
    (their local rotations and locations in their rest frames, parents as ``bones.parents``, and
    every root moved by the root offset, as the root bone or the object carries the whole
    skeleton). Bones are computed when asked for, with their ancestors, and kept."""

    def __init__(self, arm: bpy.types.Object, bones, out: Motion):
        self.arm, self.bones = arm, bones
        self.frames = int(out.frames)
        self.parents = [int(p) for p in bones.parents]
        world = np.array(arm.matrix_world, dtype=np.float64)[:3, :3]
        self.offsets = np.asarray(out.root_offset, dtype=np.float64).reshape(self.frames, 3) \
            @ np.linalg.inv(world).T
        self.unit = float(np.mean(np.linalg.norm(world, axis=0)))   # as keying.write_keys divides
        self.rot = np.asarray(out.rotations, dtype=np.float64)
        self.loc = np.asarray(out.locations, dtype=np.float64)
        self.located = {int(b) for b in out.located}
        self.posed: dict[int, np.ndarray] = {}

    def rest(self, b: int) -> np.ndarray:
        """Bone ``b``'s rest matrix in armature space (``matrix_local``), 4x4 float64."""
        return np.array(self.arm.data.bones[self.bones.names[b]].matrix_local, dtype=np.float64)

    def __call__(self, b: int) -> np.ndarray:
        chain = []
        while b >= 0 and b not in self.posed:
            chain.append(b)
            b = self.parents[b]
        for b in reversed(chain):   # parents first
            local = np.zeros((self.frames, 4, 4))
            local[:, :3, :3] = quaternion_matrices(self.rot[:, b])
            local[:, 3, 3] = 1.0
            if b in self.located:
                local[:, :3, 3] = self.loc[:, b] / self.unit
            p = self.parents[b]
            if p >= 0:
                m = self.posed[p] @ (np.linalg.inv(self.rest(p)) @ self.rest(b)) @ local
            else:
                m = self.rest(b) @ local
                m[:, :3, 3] += self.offsets
            self.posed[b] = m
        return self.posed[chain[0] if chain else b]
