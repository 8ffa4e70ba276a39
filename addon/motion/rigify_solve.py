"""Add Motion on Rigify control rigs, the solving half (``rigify`` chooses the controls and
their targets): each control's own transform from the matrix it should have, through its
parent's pose: computed when the parent is a control solved before, a bone nothing moves, or a
plain child of one of those, else read from Blender after the controls it depends on are set
(``view_layer.update``, a few times per frame at most) on a copy of the rig pruned to the bones
those parents depend on (``pruned_copy``: tens of bones instead of hundreds, each update a
small part of the rig's)."""

from __future__ import annotations

from contextlib import contextmanager, nullcontext
from dataclasses import dataclass

import bpy
import numpy as np
from mathutils import Matrix

SCALE_ONLY = {"COPY_SCALE", "LIMIT_SCALE", "MAINTAIN_VOLUME"}


@dataclass(eq=False)
class Target:
    """A control to key: the armature-space matrix it should have on each frame, whether its
    location is keyed (else only its rotation), the DEF bones it follows (named for the console;
    ``span``: the first and last), and its rest matrix."""

    name: str
    matrices: np.ndarray
    location: bool
    follows: str
    rest: np.ndarray
    span: tuple[int, int]


def transparent(c) -> bool:
    """A constraint that does not move its bone now: muted, off, or acting on scale only."""
    return c.mute or c.influence <= 0.0 or c.type in SCALE_ONLY or not c.is_valid


class _Graph:
    """Which controls each pose bone's evaluated matrix depends on (its parent and the bones its
    constraints read), and whether a bone moves only with its parent (no acting constraint)."""

    def __init__(self, arm, controls: set[str]):
        self.arm, self.controls = arm, controls
        self.pose = arm.pose.bones
        self.memo: dict[str, frozenset] = {}

    def plain(self, name: str) -> bool:
        return all(transparent(c) for c in self.pose[name].constraints)

    def needs(self, name: str) -> frozenset:
        """The controls whose keys change bone ``name``'s evaluated matrix."""
        if name not in self.memo:
            self.memo[name] = frozenset()   # a dependency cycle adds nothing
            got = {name} if name in self.controls else set()
            for m in self._links(name):
                got |= self.needs(m)
            self.memo[name] = frozenset(got)
        return self.memo[name]

    def closure(self, names) -> set[str]:
        """``names`` and every bone their evaluated matrices depend on (parents, constraint
        targets)."""
        out: set[str] = set()
        todo = [n for n in names if n in self.pose]
        while todo:
            n = todo.pop()
            if n not in out:
                out.add(n)
                todo += [m for m in self._links(n) if m not in out]
        return out

    def _links(self, name: str) -> list[str]:
        pb = self.pose.get(name)
        if pb is None:
            return []
        out = [pb.parent.name] if pb.parent is not None else []
        for c in pb.constraints:
            if transparent(c):
                continue
            if c.type == "ARMATURE":   # a parent switch: the parents it weighs now
                out += [t.subtarget for t in c.targets if t.target == self.arm and t.weight > 0.0]
                continue
            if getattr(c, "target", None) == self.arm:
                out += [getattr(c, "subtarget", ""), getattr(c, "pole_subtarget", "")]
        return [n for n in out if n in self.pose]


@contextmanager
def pruned_copy(context, arm: bpy.types.Object, keep: set[str]):
    """A temporary copy of ``arm`` holding only the bones ``keep`` (which must hold their own
    parents and constraint targets), posed as ``arm`` is now, with ``arm``'s constraints on them
    re-aimed at the copy and every driven influence frozen at its current value (no drivers, no
    action); removed on exit. Yields None when the copy cannot be made (the caller then
    evaluates ``arm`` itself). ``arm`` keeps its mode, and the selection is put back."""
    data = arm.data.copy()
    data.animation_data_clear()
    proxy = bpy.data.objects.new(arm.name + " (solving)", data)
    try:
        try:
            _prune(context, arm, proxy, keep)
            made = True
        except RuntimeError:   # a mode Blender refuses to enter here
            made = False
        yield proxy if made else None
    finally:
        bpy.data.objects.remove(proxy)
        bpy.data.armatures.remove(data)


def _prune(context, arm: bpy.types.Object, proxy: bpy.types.Object, keep: set[str]) -> None:
    """``pruned_copy``'s copy made: linked, its bones outside ``keep`` deleted in Edit Mode, then
    posed and constrained as ``arm``'s."""
    view_layer = context.view_layer
    active, mode = view_layer.objects.active, arm.mode
    selected = [ob for ob in view_layer.objects if ob.select_get()]
    context.scene.collection.objects.link(proxy)
    proxy.matrix_world = arm.matrix_world.copy()
    try:
        if mode != "OBJECT":
            bpy.ops.object.mode_set(mode="OBJECT")
        for ob in selected:
            ob.select_set(False)
        proxy.select_set(True)
        view_layer.objects.active = proxy
        bpy.ops.object.mode_set(mode="EDIT")
        bones = proxy.data.edit_bones
        for eb in list(bones):
            if eb.name not in keep:
                bones.remove(eb)
        bpy.ops.object.mode_set(mode="OBJECT")
    finally:
        proxy.select_set(False)
        for ob in selected:
            ob.select_set(True)
        view_layer.objects.active = active
        if arm.mode != mode and active == arm:
            bpy.ops.object.mode_set(mode=mode)
    evaluated = arm.evaluated_get(context.evaluated_depsgraph_get())
    for pb in proxy.pose.bones:
        src, ev = arm.pose.bones[pb.name], evaluated.pose.bones[pb.name]
        pb.rotation_mode = src.rotation_mode
        pb.matrix_basis = src.matrix_basis
        for c in src.constraints:
            copy = pb.constraints.copy(c)
            copy.influence = ev.constraints[c.name].influence
            aims = [(copy, "target"), (copy, "pole_target")] + [(t, "target") for t in getattr(copy, "targets", ())]
            for owner, attr in aims:
                if getattr(owner, attr, None) == arm:
                    setattr(owner, attr, proxy)


def solve(context, arm: bpy.types.Object, targets: list[Target]) -> dict[str, list[Matrix]]:
    """Each target control's own transform (``matrix_basis``) on each frame that gives it its
    target matrix (``Target.matrices``; only the rotation where its location is not keyed, the
    location then staying as it is). Controls are solved parents first; a control whose parent's
    pose comes from Blender (an MCH bone with constraints) waits for the controls it depends on
    to be set and the view layer updated. The pose is left as it was."""
    pose = arm.pose.bones
    by_name = {t.name: t for t in targets}
    graph = _Graph(arm, set(by_name))
    kept = {t.name: pose[t.name].matrix_basis.copy() for t in targets}
    context.view_layer.update()

    # how each control's parent pose is had: from a control ('control'), from a bone nothing
    # moves ('still', read now), or from Blender ('blender')
    how: dict[str, tuple[str, str | None, list[str]]] = {}
    for t in targets:
        up, chain = pose[t.name].parent, []
        while True:
            if up is None:
                how[t.name] = ("still", None, [])
                break
            if up.name in by_name:
                how[t.name] = ("control", up.name, chain)
                break
            if not graph.needs(up.name):
                how[t.name] = ("still", up.name, [])
                break
            if not graph.plain(up.name):
                how[t.name] = ("blender", pose[t.name].parent.name, [])
                break
            chain.insert(0, up.name)
            up = up.parent
    level: dict[str, int] = {}

    def level_of(name: str, stack=()) -> int:
        if name in level:
            return level[name]
        if name in stack:
            return 0
        kind, parent, _ = how[name]
        if kind == "still":
            lv = 0
        elif kind == "control":
            lv = level_of(parent, stack + (name,))
        else:
            lv = 1 + max([level_of(n, stack + (name,)) for n in graph.needs(parent) if n != name] or [-1])
        level[name] = lv
        return lv

    for t in targets:
        level_of(t.name)
    depth = {t.name: _depth(pose[t.name]) for t in targets}
    order = sorted(by_name, key=lambda n: (level[n], depth[n]))
    still = {p: pose[p].matrix.copy() for kind, p, _ in how.values() if kind == "still" and p is not None}

    frames = len(targets[0].matrices) if targets else 0
    solved: dict[str, list[Matrix]] = {n: [] for n in by_name}
    levels = sorted(set(level.values()))
    from_blender = [parent for kind, parent, _ in how.values() if kind == "blender"]
    keep = graph.closure(from_blender)
    with pruned_copy(context, arm, keep) if from_blender else nullcontext() as proxy:
        evaluated = proxy.pose.bones if proxy is not None else pose
        try:
            for f in range(frames):
                reached: dict[str, Matrix] = {}
                for lv in levels:
                    if lv > 0:
                        for n in order:
                            if level[n] < lv and n in evaluated:
                                evaluated[n].matrix_basis = solved[n][f]
                        context.view_layer.update()
                    for n in order:
                        if level[n] != lv:
                            continue
                        kind, parent, chain = how[n]
                        pb = pose[n]
                        if kind == "still":
                            up = still.get(parent) if parent is not None else None
                        elif kind == "control":
                            up = reached[parent]
                            for c in chain:   # plain bones between: their own transform as it is
                                cb = pose[c]
                                up = cb.bone.convert_local_to_pose(
                                    cb.matrix_basis, cb.bone.matrix_local, parent_matrix=up,
                                    parent_matrix_local=cb.parent.bone.matrix_local)
                        else:
                            up = evaluated[pb.parent.name].matrix.copy()
                        target = Matrix(by_name[n].matrices[f].tolist())
                        kw = {} if up is None else dict(parent_matrix=up,
                                                        parent_matrix_local=pb.parent.bone.matrix_local)
                        basis = pb.bone.convert_local_to_pose(target, pb.bone.matrix_local, invert=True, **kw)
                        loc, rot, _ = basis.decompose()
                        k_loc, _, k_scale = kept[n].decompose()
                        basis = Matrix.LocRotScale(loc if by_name[n].location else k_loc, rot, k_scale)
                        solved[n].append(basis)
                        reached[n] = pb.bone.convert_local_to_pose(basis, pb.bone.matrix_local, **kw)
        finally:
            for n, m in kept.items():
                pose[n].matrix_basis = m
            context.view_layer.update()
    return solved


def _depth(pb) -> int:
    d = 0
    while pb.parent is not None:
        pb, d = pb.parent, d + 1
    return d
