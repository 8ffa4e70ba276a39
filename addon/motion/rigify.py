"""Add Motion on Rigify control rigs: the motion the core plans on the DEF skeleton, keyed on the
controls an animator keys (torso, hips, chest, neck, head, IK feet and hands or FK limb chains,
tail master) so that the DEF bones follow it.

Rigify's DEF bones copy its ORG bones, which its controls drive through MCH bones, so keys on
DEF bones do nothing there. An armature is a Rigify rig when its data carries Rigify's
``rig_id``; the controls are then found by Rigify's own naming (``ORG-``/``MCH-``/``DEF-``
prefixes, ``make_derived_name`` suffixes such as ``_ik``, ``_fk``, ``_parent``) and the
mechanism it builds (the ``IK_FK`` switch on each limb's ``*_parent`` bone, the MCH chains that
copy ``hips`` and ``chest``, ``MCH-ROT-tail`` under a tail's first control).

The core plans on the DEF skeleton with the DEF segments of each ORG bone (DEF-thigh.L and
DEF-thigh.L.001) as one bone (``merged_segments``), so that knees bend at the knee. Each
control follows a span of that skeleton (``Span``): the DEF bones from the one at the
control's (or its ORG bone's) head to the one ending at its tail. On each frame the span's
planned motion (``planning.PlannedPose``), a rigid motion of its rest place, carries the
control's rest matrix to the matrix it should have (``Target``); ``rigify_solve`` turns those
into each control's own transform through its parent's pose.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import bpy
import numpy as np

from .keying import keyed_location_bones, keyed_rotation_bones, last_key_frame, write_control_keys
from .planning import PlannedPose
from .rigify_solve import Target, solve, transparent

# Rigify's own name rule (rigify/utils/naming.py ``split_name``): prefix, base, side, number.
NAME_PARTS = re.compile(r"^(?:(ORG|MCH|DEF)-)?(.*?)([._-][tTbB])?([._-][lLrR])?(?:\.(\d+))?$")
PREFIXES = ("ORG-", "MCH-", "DEF-")
# constraints that leave a bone's rotation and location be while nothing is scaled


def is_rigify(arm: bpy.types.Object) -> bool:
    """Whether ``arm`` is a rig Rigify generated: its armature data carries Rigify's ``rig_id``."""
    return arm.type == "ARMATURE" and arm.data.get("rig_id") is not None


def derived(name: str, prefix: str = "", suffix: str = "") -> str:
    """Rigify's ``make_derived_name``: ``name`` with its ORG/MCH/DEF prefix replaced by
    ``prefix`` and ``suffix`` added before the side ("ORG-foot.L", "", "_ik" -> "foot_ik.L")."""
    pre, base, side_z, side, number = NAME_PARTS.match(name).groups()
    return "".join([prefix + "-" if prefix else "", base + suffix, side_z or "", side or "",
                    "." + number if number else ""])


def limb_org(prop_bone: str) -> str | None:
    """The first ORG bone of the limb whose settings bone (``IK_FK``) is ``prop_bone``:
    "thigh_parent.L" -> "ORG-thigh.L"."""
    pre, base, side_z, side, number = NAME_PARTS.match(prop_bone).groups()
    if pre or not base.endswith("_parent"):
        return None
    return "".join(["ORG-", base[:-len("_parent")], side_z or "", side or "", "." + number if number else ""])


@dataclass(eq=False)
class Span:
    """DEF bones ``first`` .. ``last`` (indices into the motion's bones, ``last`` in ``first``'s
    subtree) between armature-space points ``head`` (on ``first``) and ``tail`` (on ``last``)."""

    first: int
    last: int
    head: np.ndarray
    tail: np.ndarray

    def motion(self, pose: PlannedPose) -> np.ndarray:
        """(frames, 4, 4) rigid motions (armature space) carrying the span's rest place to its
        planned one: ``first``'s rotation, then the swing that turns the head-tail chord to
        where ``last`` puts the tail, the head where ``first`` puts it."""
        mf, ml = pose(self.first), pose(self.last)
        rf, rl = pose.rest(self.first), pose.rest(self.last)
        carry_f, carry_l = mf @ np.linalg.inv(rf), ml @ np.linalg.inv(rl)
        head = carry_f[:, :3, :3] @ self.head + carry_f[:, :3, 3]
        tail = carry_l[:, :3, :3] @ self.tail + carry_l[:, :3, 3]
        turn = carry_f[:, :3, :3]
        turn = swings(turn @ (self.tail - self.head), tail - head) @ turn
        out = np.zeros_like(mf)
        out[:, :3, :3] = turn
        out[:, :3, 3] = head - turn @ self.head
        out[:, 3, 3] = 1.0
        return out


def swings(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(frames, 3, 3) shortest rotations turning the directions ``u`` into ``v`` ((frames, 3))."""
    u = u / np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
    v = v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)
    axis = np.cross(u, v)
    c = np.einsum("ij,ij->i", u, v)
    k = np.zeros((len(u), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    k = k - k.transpose(0, 2, 1)
    scale = 1.0 / (1.0 + np.maximum(c, -1.0 + 1e-12))
    out = np.eye(3) + k + (k @ k) * scale[:, None, None]
    back = c < -1.0 + 1e-9   # opposite directions: half a turn about an axis across u
    if back.any():
        ub = u[back]
        across = np.cross(ub, np.where(np.abs(ub[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
        across /= np.linalg.norm(across, axis=1, keepdims=True)
        out[back] = 2.0 * np.einsum("ni,nj->nij", across, across) - np.eye(3)
    return out


class Skeleton:
    """The motion's DEF bones in armature space, for finding spans (``span``, ``nearest``)."""

    def __init__(self, arm: bpy.types.Object, bones):
        self.arm, self.bones = arm, bones
        m = np.array(arm.matrix_world, dtype=np.float64)
        inv = np.linalg.inv(m[:3, :3])
        self.heads = (np.asarray(bones.heads, dtype=np.float64).reshape(-1, 3) - m[:3, 3]) @ inv.T
        self.tails = (np.asarray(bones.tails, dtype=np.float64).reshape(-1, 3) - m[:3, 3]) @ inv.T
        size = float(np.linalg.norm(np.ptp(np.concatenate([self.heads, self.tails]), axis=0))) if len(
            bones.names) else 0.0
        self.tol = 1e-4 * size
        self.children: list[list[int]] = [[] for _ in bones.names]
        for b, p in enumerate(bones.parents):
            if p >= 0:
                self.children[int(p)].append(b)

    def span(self, head, tail, most: int = 12) -> Span | None:
        """The DEF bones from one whose head is ``head`` down to one whose tail is ``tail``
        (fewest bones, at most ``most``), or None."""
        head, tail = np.asarray(head, dtype=np.float64), np.asarray(tail, dtype=np.float64)
        best = None
        for first in np.flatnonzero(np.linalg.norm(self.heads - head, axis=1) <= self.tol):
            level, depth = [int(first)], 0
            while level and depth < most and (best is None or depth < best[0]):
                hit = [b for b in level if np.linalg.norm(self.tails[b] - tail) <= self.tol]
                if hit:
                    best = (depth, int(first), hit[0])
                    break
                level, depth = [c for b in level for c in self.children[b]], depth + 1
        return Span(best[1], best[2], head, tail) if best else None

    def nearest(self, point) -> Span | None:
        """The one DEF bone whose segment passes nearest ``point``, as a span."""
        if not len(self.heads):
            return None
        p = np.asarray(point, dtype=np.float64)
        d = self.tails - self.heads
        t = np.clip(np.einsum("ij,ij->i", p - self.heads, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300),
                    0.0, 1.0)
        b = int(np.argmin(np.linalg.norm(self.heads + t[:, None] * d - p, axis=1)))
        return Span(b, b, self.heads[b], self.tails[b])

    def of_bone(self, bone: bpy.types.Bone | None) -> Span | None:
        """The span of the DEF bones lying where ``bone`` (an ORG bone or a control) lies, from
        its head to its tail, or from its tail to its head (a tail's DEF chain may run towards
        the body while its controls run away from it)."""
        if bone is None:
            return None
        return self.span(bone.head_local, bone.tail_local) or self.span(bone.tail_local, bone.head_local)


def merged_segments(arm: bpy.types.Object, bones):
    """``bones`` (``planning.motion_bones``) with the DEF segments of each Rigify limb or spine
    bone made one bone again: DEF bones in a chain lying along one non-deform bone (ORG-thigh.L
    split into DEF-thigh.L and DEF-thigh.L.001, B-Bone segments that bend together) become the
    first of them, reaching to the last one's tail. The core bends a leg at the joints between
    its bones, so it plans knees at the knee and not in mid-thigh; the controls follow the ORG
    bones, which are these merged bones. Returns ``bones`` itself when nothing merges."""
    skel = Skeleton(arm, bones)
    parents = [int(p) for p in bones.parents]
    group_of: dict[int, int] = {}
    groups: list[list[int]] = []
    for o in arm.data.bones:
        if o.use_deform:
            continue
        sp = skel.span(o.head_local, o.tail_local)
        if sp is None or sp.first == sp.last:
            continue
        chain = [sp.last]
        while chain[-1] != sp.first:
            chain.append(parents[chain[-1]])
        chain.reverse()
        head, axis = np.array(o.head_local), np.array(o.tail_local) - np.array(o.head_local)
        axis /= max(float(np.linalg.norm(axis)), 1e-300)

        ends = np.concatenate([skel.heads[chain], skel.tails[chain]]) - head
        off = np.linalg.norm(ends - np.outer(ends @ axis, axis), axis=1)
        if any(b in group_of for b in chain) or off.max() > skel.tol:
            continue
        for b in chain:
            group_of[b] = len(groups)
        groups.append(chain)
    if not groups:
        return bones
    rep = {b: groups[g][0] for b, g in group_of.items()}
    keep = [b for b in range(len(bones.names)) if rep.get(b, b) == b]
    index = {b: i for i, b in enumerate(keep)}
    tails = np.array(bones.tails, dtype=np.float64)
    for chain in groups:
        tails[chain[0]] = bones.tails[chain[-1]]
    new_parents = []
    for b in keep:
        p = parents[b]
        new_parents.append(index[rep.get(p, p)] if p >= 0 else -1)
    return replace(bones, names=[bones.names[b] for b in keep], heads=np.asarray(bones.heads)[keep],
                   tails=tails[keep], parents=np.asarray(new_parents, dtype=np.int32),
                   selected=np.asarray(bones.selected)[keep])


class _Chooser:
    """Finds the controls (``choose``) and collects their ``Target``s."""

    def __init__(self, arm: bpy.types.Object, bones, out):
        self.arm, self.bones, self.out = arm, bones, out
        self.pose, self.data = arm.pose.bones, arm.data.bones
        self.planned = PlannedPose(arm, bones, out)
        self.skel = Skeleton(arm, bones)
        self.targets: list[Target] = []
        self.notes: list[str] = []
        self.limbs: list[Span] = []   # the DEF spans of every limb's ORG bones

    def add(self, name: str, span: Span | None, location: bool, motion: np.ndarray | None = None,
            follows: str = "") -> None:
        """Target ``name``, carried by ``motion`` ((frames, 4, 4) rigid motions; by default the
        planned motion of ``span``). Bones with Rigify's ORG/MCH/DEF prefixes are never keyed."""
        if name not in self.pose or name.startswith(PREFIXES) or any(t.name == name for t in self.targets):
            return
        if span is None:
            self.notes.append(f"{name}: no DEF bones lie where it does; not keyed")
            return
        rest = np.array(self.data[name].matrix_local, dtype=np.float64)
        names = self.bones.names
        follows = follows or names[span.first] + ("" if span.last == span.first else f" .. {names[span.last]}")
        carry = span.motion(self.planned) if motion is None else motion
        self.targets.append(Target(name, carry @ rest, location, follows, rest, (span.first, span.last)))

    def choose(self) -> None:
        self.spine()
        self.tails()
        for pb in self.pose:
            if "IK_FK" in pb.keys():
                self.limb(pb)
        self.others()

    def spine(self) -> None:
        data, skel = self.data, self.skel
        # torso carries the body (travel, height, turn) from where its head lies
        if "torso" in self.pose:
            self.add("torso", skel.nearest(data["torso"].head_local), True)
        # hips and chest turn the spine's ends: the MCH chain copying each ends at the ORG bone
        # that takes all of its turn (the farthest from the control)
        for name in ("hips", "chest"):
            if name not in self.pose:
                continue
            chain = [derived(pb.name, "ORG") for pb in self.pose if pb.name.startswith("MCH-") and any(
                c.type == "COPY_TRANSFORMS" and c.subtarget == name for c in pb.constraints)]
            chain = [n for n in chain if n in data]
            if chain:
                head = np.array(data[name].head_local)
                end = max(chain, key=lambda n: np.linalg.norm(np.array(data[n].head_local) - head)
                          + np.linalg.norm(np.array(data[n].tail_local) - head))
                self.add(name, skel.of_bone(data[end]), False)
        # neck spans the neck bones; head lies on the head bone
        for name in ("neck", "head"):
            if name in self.pose:
                self.add(name, skel.of_bone(data[name]), False)

    def tails(self) -> None:
        """A tail's master control (a copy of its first bone) turns every tail bone: it is what
        the first tail control (under ``MCH-ROT-tail``) copies its rotation from."""
        for pb in self.pose:
            if pb.name.startswith("MCH-ROT-tail"):
                for child in pb.children:
                    for c in child.constraints:
                        if c.type == "COPY_ROTATION" and c.subtarget in self.pose:
                            self.add(c.subtarget, self.skel.of_bone(self.data[c.subtarget]), False)

    def limb(self, pb: bpy.types.PoseBone) -> None:
        """The limb whose settings bone ``pb`` has the IK_FK switch: its IK controls (IK
        control, toes beyond it, the pole when used) in IK, its FK chain in FK."""
        data, pose, skel = self.data, self.pose, self.skel
        org = limb_org(pb.name)
        if org not in data:
            return
        orgs = [data[org]]
        while True:   # the ORG bones that start where the last one ends (a toe need not connect)
            nxt = [c for c in orgs[-1].children if c.name.startswith("ORG-") and np.linalg.norm(
                np.array(c.head_local) - np.array(orgs[-1].tail_local)) <= skel.tol]
            if not nxt:
                break
            orgs.append(nxt[0])
        if len(orgs) < 3:
            return
        spans = [skel.of_bone(o) for o in orgs]
        self.limbs += [sp for sp in spans if sp is not None]
        try:
            fk = float(pb["IK_FK"]) >= 0.5
        except (TypeError, ValueError):
            return
        if fk:
            fit = limb_fit(self.planned, skel, orgs, spans)
            for k, o in enumerate(orgs):
                name = derived(o.name, "", "_fk")
                name = name if name in pose else derived(o.name)
                if k < 2 and fit is not None:
                    self.add(name, spans[k], False, fit[k],
                             f"a two-bone fit reaching the planned {self.bones.names[spans[2].first]}")
                else:
                    self.add(name, spans[k], False)
            return
        ik = derived(orgs[2].name, "", "_ik")
        if ik not in pose:
            self.notes.append(f"{pb.name}: no IK control {ik}")
            return
        # the ORG bone the IK control was copied from: the one with an end at its head
        # (a leg's foot; a paw's toe, whose control is flipped to stand on its tip)
        at = np.array(data[ik].head_local)
        ends = [k for k, o in enumerate(orgs) if k >= 2 and min(
            np.linalg.norm(np.array(o.head_local) - at), np.linalg.norm(np.array(o.tail_local) - at)) <= skel.tol]
        end = ends[0] if ends else 2
        self.add(ik, spans[end], True)
        for o, span in zip(orgs[end + 1:], spans[end + 1:]):   # toes beyond it turn on their own
            name = derived(o.name, "", "_ik")
            self.add(name if name in pose else derived(o.name), span, False)
        if pb.get("pole_vector") and spans[0] is not None:
            # the pole keeps its place before the knee as the body carries the limb
            up = int(self.bones.parents[spans[0].first])
            if up >= 0:
                self.add(derived(orgs[0].name, "", "_ik_target"), spans[0], True,
                         self.planned(up) @ np.linalg.inv(self.planned.rest(up)), self.bones.names[up])

    def others(self) -> None:
        """Other bones the motion turns (a shoulder blade that swings a leg, ears after the
        head): the control lying where the bone lies, with no constraint of its own, unless a
        control chosen above already carries the bone (spine, neck, head and tail are carried
        by torso, hips, chest, neck, head and the tail master; limbs by their IK or FK
        controls)."""
        roles, skel, bones = self.out.roles, self.skel, self.bones
        carried = set(roles.spine) | set(roles.neck) | set(roles.tail) | {roles.head}
        for first, last in [t.span for t in self.targets] + [(sp.first, sp.last) for sp in self.limbs]:
            carried.update(_between(bones, first, last))
        taken = {t.name for t in self.targets}
        free = [pb.name for pb in self.pose if pb.name not in taken and not pb.name.startswith(PREFIXES)
                and pb.parent is not None and all(transparent(c) for c in pb.constraints)]
        if not free:
            return
        ends = np.array([[self.data[n].head_local, self.data[n].tail_local] for n in free],
                        dtype=np.float64).reshape(-1, 2, 3)
        for b in sorted(int(i) for i in self.out.animated):
            if b in carried:
                continue
            near = np.flatnonzero((np.linalg.norm(ends[:, 0] - skel.heads[b], axis=1) <= skel.tol)
                                  & (np.linalg.norm(ends[:, 1] - skel.tails[b], axis=1) <= skel.tol))
            if len(near):
                self.add(free[int(near[0])], Span(b, b, skel.heads[b], skel.tails[b]), False)


def control_targets(arm: bpy.types.Object, bones, out) -> tuple[list[Target], list[str]]:
    """The Rigify controls that make the DEF ``bones`` (``merged_segments``) follow the core's
    motion ``out``, each with the matrices it should have (``Target``), moved or not; and notes
    for the console (controls looked for and not found)."""
    chooser = _Chooser(arm, bones, out)
    chooser.choose()
    return chooser.targets, chooser.notes


def _between(bones, first: int, last: int) -> list[int]:
    """The bones from ``last`` up to ``first`` (``first`` an ancestor of ``last``)."""
    out, b = [last], last
    while b != first and b >= 0:
        b = int(bones.parents[b])
        out.append(b)
    return out if b == first else [first, last]


def limb_fit(planned: PlannedPose, skel: Skeleton, orgs, spans) -> tuple[np.ndarray, np.ndarray] | None:
    """Rigid motions (frames, 4, 4) of a limb's first two ORG bones (thigh and shin) that put
    the head of the third (the ankle) where the plan puts it, with the knee bent in the limb's
    rest plane as the plan turns it (as an IK chain without a pole does): an FK limb reaches the
    planned foot whatever joints the plan bent between. None when a span is missing or the
    limb has no parent in the plan."""
    if any(sp is None for sp in spans[:3]):
        return None
    up = int(skel.bones.parents[spans[0].first])
    if up < 0:
        return None
    hip0, knee0, ankle0 = (np.array(orgs[0].head_local), np.array(orgs[1].head_local),
                           np.array(orgs[2].head_local))
    l1, l2 = np.linalg.norm(knee0 - hip0), np.linalg.norm(ankle0 - knee0)
    carry = planned(up) @ np.linalg.inv(planned.rest(up))
    first, third = spans[0].motion(planned), spans[2].motion(planned)
    hip = first[:, :3, :3] @ hip0 + first[:, :3, 3]
    ankle = third[:, :3, :3] @ ankle0 + third[:, :3, 3]
    # the rest limb carried by its parent, turned so that hip-ankle lies along the plan's
    line = swings(carry[:, :3, :3] @ (ankle0 - hip0), ankle - hip) @ carry[:, :3, :3]
    reach = ankle0 - hip0
    bend = (knee0 - hip0) - np.dot(knee0 - hip0, reach) / max(np.dot(reach, reach), 1e-300) * reach
    side = line @ bend
    d = ankle - hip
    dist = np.linalg.norm(d, axis=1)
    e = d / np.maximum(dist, 1e-300)[:, None]
    side = side - np.einsum("ij,ij->i", side, e)[:, None] * e
    side /= np.maximum(np.linalg.norm(side, axis=1), 1e-300)[:, None]
    dist = np.clip(dist, abs(l1 - l2) + 1e-9, l1 + l2)
    a = (l1 * l1 - l2 * l2 + dist * dist) / (2 * dist)
    knee = hip + a[:, None] * e + np.sqrt(np.maximum(l1 * l1 - a * a, 0.0))[:, None] * side
    out = []
    for start, end, p0, q0 in ((hip, knee, hip0, knee0), (knee, ankle, knee0, ankle0)):
        turn = swings(line @ (q0 - p0), end - start) @ line
        m = np.zeros((len(hip), 4, 4))
        m[:, :3, :3] = turn
        m[:, :3, 3] = start - turn @ p0
        m[:, 3, 3] = 1.0
        out.append(m)
    return out[0], out[1]


def moving(targets: list[Target], size: float) -> list[Target]:
    """The targets the motion moves: on some frame their matrix leaves their rest matrix by more
    than 1e-6 (rotation) or 1e-6 of ``size`` (location)."""
    out = []
    for t in targets:
        off = t.matrices - t.rest
        if np.abs(off[:, :3, :3]).max(initial=0.0) > 1e-6 or \
                np.abs(off[:, :3, 3]).max(initial=0.0) > 1e-6 * size:
            out.append(t)
    return out


def shift_targets(context, arm: bpy.types.Object, targets: list[Target], earlier: float | None) -> None:
    """Move every target along the ground to where an earlier motion left the rig: by the mean
    horizontal offset from rest, at scene frame ``earlier``, of the controls with location keys
    among ``targets`` (a second walk carries on from where the first one ended). Nothing without
    an earlier motion."""
    if earlier is None:
        return
    keyed = keyed_location_bones(arm)
    located = [t for t in targets if t.location and t.name in keyed]
    if not located:
        return
    scene = context.scene
    now = scene.frame_current
    scene.frame_set(int(np.floor(earlier)))
    pose = arm.pose.bones
    offset = np.mean([np.array(pose[t.name].matrix.translation) - t.rest[:3, 3] for t in located], axis=0)
    scene.frame_set(now)
    up = np.linalg.inv(np.array(arm.matrix_world, dtype=np.float64)[:3, :3]) @ np.array([0.0, 0.0, 1.0])
    up /= max(float(np.linalg.norm(up)), 1e-300)
    offset -= np.dot(offset, up) * up
    for t in targets:
        t.matrices[:, :3, 3] += offset


@dataclass(eq=False)
class ControlPlan:
    """The controls to key: ``moved`` by the motion; ``returning``, keyed by an earlier motion and
    left alone by this one (one key back at rest, where the rig now stands); console ``notes``."""

    moved: list[Target]
    returning: list[Target]
    notes: list[str]


def plan_controls(context, arm: bpy.types.Object, bones, out) -> ControlPlan:
    """The Rigify controls to key for the core's motion ``out`` on ``bones`` (``merged_segments``),
    their targets moved along to where an earlier motion left the rig. ValueError when none of
    them follows the bones the motion moves."""
    targets, notes = control_targets(arm, bones, out)
    ends = np.array([p for b in arm.data.bones for p in (b.head_local, b.tail_local)], dtype=np.float64)
    moved = moving(targets, float(np.linalg.norm(np.ptp(ends.reshape(-1, 3), axis=0))))
    if not moved:
        raise ValueError("a Rigify rig, but none of its controls (torso, hips, chest, neck, head, IK or FK "
                         "limb controls, tail master) follows the bones this motion moves; nothing was keyed")
    earlier = last_key_frame(arm)
    keyed_before = keyed_rotation_bones(arm) | keyed_location_bones(arm)
    returning = [t for t in targets if t not in moved and t.name in keyed_before]
    shift_targets(context, arm, moved + returning, earlier)
    return ControlPlan(moved, returning, notes)


def key_controls(context, arm: bpy.types.Object, plan: ControlPlan, start: int) -> int:
    """Key ``plan``'s controls from scene frame ``start`` (``solve``, then
    ``keying.write_control_keys``), naming what each follows in the console. Returns the
    number of frames keyed."""
    solved = solve(context, arm, plan.moved + plan.returning)
    for t in plan.moved:
        print(f"[MiniSkeleton]   rigify: {t.name} follows {t.follows}"
              + (" (location and rotation)" if t.location else " (rotation)"))
    return write_control_keys(context, arm, plan.moved, solved, start, plan.returning)
