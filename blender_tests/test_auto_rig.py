"""Auto Rig (object.miniskeleton_auto_rig) in real Blender: a biped and a quadruped built here get
an armature named and parented as Rigify's metarigs, every joint inside the mesh, rolls as on
the metarigs, every vertex weighted, Rigify types that Generate Rig turns into a control rig,
and a walk; bad input (a flat plane, a sphere, a figure lying on its side, NaN coordinates, an
empty mesh, nothing or no mesh selected, Edit Mode) is one clear report and leaves the scene as
it was; one undo takes it all back; the shared models (../shared/models, skipped when absent)
auto-rig once their armature and groups are gone."""

from __future__ import annotations

import importlib
import math
import re

import bpy
import numpy as np
import pytest

from testkit import blender_session
from testkit import builders as B
from testkit import measures
from testkit import creature
from testkit import rig_corpus
from testkit import shapes
from testkit.fingerprint import fingerprint

from testkit import motion_corpus as corpus

core = importlib.import_module("miniskeleton_core")
autorig = importlib.import_module(f"{blender_session.ADDON_MODULE}.skeleton.autorig")

SIDES = ("L", "R")
# bone: parent, as Rigify's Basic metarigs (and the core's contract) have them
BIPED = {"spine": None, "spine.001": "spine", "spine.002": "spine.001", "spine.003": "spine.002",
         "spine.004": "spine.003", "spine.005": "spine.004", "spine.006": "spine.005"}
QUADRUPED = {"spine.004": None, "spine.005": "spine.004", "spine.006": "spine.005", "spine.007": "spine.006",
             "spine.008": "spine.007", "spine.009": "spine.008", "spine.010": "spine.009", "spine.011": "spine.010"}
TAIL = {"spine.003": "spine.004", "spine.002": "spine.003", "spine.001": "spine.002", "spine": "spine.001"}
for _s in SIDES:
    BIPED.update({f"thigh.{_s}": "spine", f"shin.{_s}": f"thigh.{_s}", f"foot.{_s}": f"shin.{_s}",
                  f"toe.{_s}": f"foot.{_s}", f"heel.02.{_s}": f"foot.{_s}", f"shoulder.{_s}": "spine.003",
                  f"upper_arm.{_s}": f"shoulder.{_s}", f"forearm.{_s}": f"upper_arm.{_s}",
                  f"hand.{_s}": f"forearm.{_s}"})
    QUADRUPED.update({f"thigh.{_s}": "spine.004", f"shin.{_s}": f"thigh.{_s}", f"foot.{_s}": f"shin.{_s}",
                      f"toe.{_s}": f"foot.{_s}", f"shoulder.{_s}": "spine.008",
                      f"front_thigh.{_s}": f"shoulder.{_s}", f"front_shin.{_s}": f"front_thigh.{_s}",
                      f"front_foot.{_s}": f"front_shin.{_s}", f"front_toe.{_s}": f"front_foot.{_s}"})
# chains Rigify's limb rigs take as connected bones
CHAINS = {"BIPED": [["thigh", "shin", "foot", "toe"], ["upper_arm", "forearm", "hand"]],
          "QUADRUPED": [["thigh", "shin", "foot", "toe"], ["front_thigh", "front_shin", "front_foot", "front_toe"]]}


# ---------------------------------------------------------------------------- helpers

def run(capfd, meshes, active=None, **props) -> tuple[set, str]:
    """Auto Rig on ``meshes`` selected (``active`` or the first active): (result, its reports as
    printed, or the error report Blender raises)."""
    if meshes:
        B.set_active(active or meshes[0], selected=meshes)
    else:
        for ob in bpy.context.view_layer.objects:
            ob.select_set(False)
    capfd.readouterr()
    try:
        result, error = bpy.ops.object.miniskeleton_auto_rig(**props), ""
    except RuntimeError as err:
        result, error = {"CANCELLED"}, str(err)
    return result, "".join(capfd.readouterr()) + error


def armatures() -> list:
    return [ob for ob in bpy.data.objects if ob.type == "ARMATURE"]


def human(name="Human"):
    body = rig_corpus.human_body(name)
    bpy.context.view_layer.update()
    return body


def quadruped(name="Creature"):
    body = creature.build_body(name)
    bpy.context.view_layer.update()
    return body


def world_surface(meshes):
    parts = [(measures.world_vertices(ob), autorig.shaped_world_mesh(ob)[1]) for ob in meshes]
    return autorig.stack_meshes(parts)


def joints_world(arm):
    names = [b.name for b in arm.data.bones]
    heads, tails = B.bone_segments_world(arm, names)
    return names, heads, tails


def axis(arm, name: str, k: int):
    """Bone ``name``'s X (k = 0), Y or Z axis in world space (``Bone.x_axis`` is in its parent's
    space)."""
    return (arm.matrix_world.to_3x3() @ arm.data.bones[name].matrix_local.to_3x3()).col[k]


def assert_rigged(arm, meshes, template, tail=None, ears=False):
    """Bone names and parents as Rigify's metarig ``template``, limb chains connected, the heel a
    loose childless child of the foot, every joint inside the meshes, and every vertex weighted.
    ``ears``: how many pairs of ears from the head, as on Rigify's horse metarig (``ear``, then
    ``horn``; and no other pair)."""
    want = dict(BIPED if template == "BIPED" else QUADRUPED)
    names = [b.name for b in arm.data.bones]
    if template == "QUADRUPED" and (tail or (tail is None and "spine.003" in names)):
        want.update(TAIL)
    head = "spine.006" if template == "BIPED" else "spine.011"
    for base in ("ear", "horn", "antenna")[:int(ears)]:
        for s in SIDES:
            want.update({f"{base}.{s}": head, f"{base}.{s}.001": f"{base}.{s}"})
    got = {b.name: b.parent.name if b.parent else None for b in arm.data.bones}
    assert got == want, sorted(set(got.items()) ^ set(want.items()))
    bones = arm.data.bones
    for s in SIDES:
        for chain in CHAINS[template]:
            for child in chain[1:]:
                assert bones[f"{child}.{s}"].use_connect, f"{child}.{s} is not connected"
        if template == "BIPED":
            heel = bones[f"heel.02.{s}"]
            assert not heel.use_connect and not heel.children
    # The heel is a marker on the ground (the foot's roll pivot), not a deforming bone.
    deform = [b.name for b in bones if b.use_deform]
    assert deform == [n for n in names if not n.startswith("heel.")], names
    assert_inside_and_bound(arm, meshes)


def assert_inside_and_bound(arm, meshes):
    """Every joint of a deform bone inside the meshes, every vertex weighted, an Armature
    modifier on each mesh."""
    deform = [b.name for b in arm.data.bones if b.use_deform]
    verts, tris = world_surface(meshes)
    heads, tails = B.bone_segments_world(arm, deform)
    inside = core.points_inside(verts, tris, np.concatenate([heads, tails]).astype(np.float32))
    outside = [n for n, a, b in zip(deform, inside[:len(deform)], inside[len(deform):]) if not (a and b)]
    assert not outside, f"bones with a joint outside the mesh: {outside}"
    for ob in meshes:
        w = B.weights_matrix(ob, deform)
        assert (w.max(axis=1) > 0).all(), f"{ob.name}: {(w.max(axis=1) <= 0).sum()} unweighted vertices"
        assert any(m.type == "ARMATURE" and m.object == arm for m in ob.modifiers)


def rigify_generate(arm) -> tuple[set, str]:
    """Rigify's Generate Rig on ``arm``: (result, the error Rigify raised, or "")."""
    bpy.ops.preferences.addon_enable(module="rigify")
    B.set_active(arm)
    try:
        return bpy.ops.pose.rigify_generate(), ""
    except RuntimeError as err:
        return {"CANCELLED"}, str(err)


def one_clear_error(console: str, *words: str, added=True, nested=()):
    """The operator's error report: one line (Blender prints it, and raises it), none of Python's
    tracebacks, "nothing was added" when the check came after reading the meshes (``added``), and
    one of ``words`` (regular expressions) in it; besides it only the ``nested`` errors (of the
    operators it runs)."""
    assert "Traceback" not in console, console
    errors = sorted({line for line in console.splitlines() if line.startswith("Error:")} - set(nested))
    assert len(errors) == 1, console
    assert not added or "nothing was added" in errors[0], errors[0]
    if words:
        assert any(re.search(w, errors[0], re.I) for w in words), errors[0]
    return errors[0]


# ---------------------------------------------------------------------------- good input

def test_biped_gets_rigify_human_bones_inside_bound_and_rolled(capfd):
    body = human()
    result, console = run(capfd, [body])
    assert result == {"FINISHED"}, console
    assert "Auto Rig: biped" in console, console
    (arm,) = armatures()
    assert arm.name == "Human_rig" and bpy.context.view_layer.objects.active == arm
    assert_rigged(arm, [body], "BIPED")
    # The legs and the spine bend about the character's left (+X: it faces -Y), the arms' Z
    # axis points forward, as on Rigify's metarig.
    for name in ("thigh.L", "shin.R", "spine.001"):
        assert axis(arm, name, 0).x > 0.9, (name, axis(arm, name, 0))
    for name in ("upper_arm.L", "forearm.R"):
        assert axis(arm, name, 2).y < -0.9, (name, axis(arm, name, 2))
    # Origin on the ground under the body (Rigify's root control goes there).
    lo = measures.world_vertices(body).min(axis=0)
    assert abs(arm.location.z - lo[2]) < 1e-5


def test_quadruped_with_tail_gets_rigify_quadruped_bones_inside_and_bound(capfd):
    body = quadruped()
    result, console = run(capfd, [body])
    assert result == {"FINISHED"}, console
    assert "Auto Rig: quadruped with a tail" in console, console
    (arm,) = armatures()
    assert_rigged(arm, [body], "QUADRUPED", tail=True)
    for name in ("thigh.L", "front_shin.R", "spine.006"):
        assert axis(arm, name, 0).x > 0.9, (name, axis(arm, name, 0))


@pytest.mark.parametrize("template", ["BIPED", "QUADRUPED"])
def test_rigify_types_are_set_and_generate_rig_makes_the_control_rig(capfd, template):
    body = human() if template == "BIPED" else quadruped()
    assert run(capfd, [body], template=template)[0] == {"FINISHED"}
    (arm,) = armatures()
    result, error = rigify_generate(arm)
    assert result == {"FINISHED"}, error
    names = [b.name for b in arm.data.bones]
    for bone, (rig_type, _, _) in autorig.rig_types(template, names).items():
        assert arm.pose.bones[bone].rigify_type == rig_type
    rig = arm.data.rigify_target_rig
    assert rig is not None and rig != arm
    deform = {b.name for b in rig.data.bones if b.use_deform}
    # every deform bone of ours has its DEF- bone in the control rig
    for name in names:
        if not name.startswith("heel"):
            assert any(d.startswith(f"DEF-{name}") for d in deform), name
    assert "torso" in rig.data.bones and "root" in rig.data.bones


def test_without_rigify_the_types_are_stored_where_rigify_reads_them(capfd):
    assert not hasattr(bpy.types.PoseBone, "rigify_type"), "Rigify is enabled: the test would prove nothing"
    body = human()
    result, console = run(capfd, [body])
    assert result == {"FINISHED"} and "enable Rigify to Generate Rig" in console, console
    (arm,) = armatures()
    bpy.ops.preferences.addon_enable(module="rigify")
    assert arm.pose.bones["thigh.L"].rigify_type == "limbs.leg"
    assert arm.pose.bones["spine.004"].rigify_parameters.connect_chain
    assert arm.pose.bones["spine.001"].rigify_type == ""
    assert rigify_generate(arm)[0] == {"FINISHED"}


@pytest.mark.parametrize("template", ["BIPED", "QUADRUPED"])
def test_the_auto_rig_walks(capfd, template):
    body = human() if template == "BIPED" else quadruped()
    assert run(capfd, [body])[0] == {"FINISHED"}
    (arm,) = armatures()
    B.set_active(arm)
    assert bpy.ops.pose.miniskeleton_add_motion(motion="WALK", cycles=1) == {"FINISHED"}
    rest = measures.world_vertices(body)
    bpy.context.scene.frame_set(bpy.context.scene.frame_start + 6)
    moved = np.linalg.norm(measures.evaluated_world_vertices(body) - rest, axis=1)
    assert moved.max() > 0.02 * np.ptp(rest, axis=0).max()


def test_several_pieces_are_one_character_named_after_the_active_one(capfd):
    """A body and a hat (two objects, the hat off the body): one armature named after the active
    mesh, both bound."""
    body = human("Body")
    hat = B.cylinder("Hat", radius=0.12, height=0.08, rings=2, segments=16, location=(0, 0, 1.79))
    result, console = run(capfd, [body, hat], active=hat)
    assert result == {"FINISHED"}, console
    (arm,) = armatures()
    assert arm.name == "Hat_rig"
    for ob in (body, hat):
        w = B.weights_matrix(ob, [b.name for b in arm.data.bones])
        assert (w.max(axis=1) > 0).all(), ob.name
    head = B.weights_matrix(hat, ["spine.006"])[:, 0]
    assert head.mean() > 0.5, head.mean()


def test_far_from_the_origin_turned_and_without_bind(capfd):
    """A quadruped 1e4 units away, facing +X: the same skeleton as at the origin (moved and
    turned), named Forward +X, and with Bind off no mesh changes."""
    body = quadruped()
    assert run(capfd, [body])[0] == {"FINISHED"}
    (near,) = armatures()
    _, heads0, tails0 = joints_world(near)
    bpy.data.objects.remove(near)
    body.vertex_groups.clear()
    body.modifiers.clear()
    body.parent = None
    body.matrix_world.identity()
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # -Y -> +X
    shift = np.array([1e4, -2e4, 5.0])
    body.rotation_euler = (0, 0, math.pi / 2)
    body.location = tuple(shift)
    bpy.context.view_layer.update()
    result, console = run(capfd, [body], bind=False, forward="+X")
    assert result == {"FINISHED"}, console
    assert "facing +X" in console, console
    (far,) = armatures()
    assert not body.vertex_groups and not body.modifiers and body.parent is None
    _, heads, tails = joints_world(far)
    size = np.ptp(measures.world_vertices(body), axis=0).max()
    err = max(np.abs(heads - (heads0 @ turn.T + shift)).max(), np.abs(tails - (tails0 @ turn.T + shift)).max())
    names, _, _ = joints_world(far)
    per = np.maximum(np.abs(heads - (heads0 @ turn.T + shift)).max(1), np.abs(tails - (tails0 @ turn.T + shift)).max(1))
    assert err < 0.03 * size, (err / size, sorted(zip(per / size, names))[-4:])


# ---------------------------------------------------------------------------- bad input

def _plane():
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    return [bpy.context.object]


def _sphere():
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0)
    return [bpy.context.object]


def _lying():
    body = human("Lying")
    body.rotation_euler = (0.0, math.pi / 2, 0.0)
    return [body]


def _nan():
    bpy.ops.mesh.primitive_cube_add()
    ob = bpy.context.object
    ob.data.vertices[3].co.x = float("nan")
    return [ob]


def _empty():
    ob = bpy.data.objects.new("Empty", bpy.data.meshes.new("Empty"))
    bpy.context.scene.collection.objects.link(ob)
    return [ob]


def _edges_only():
    me = bpy.data.meshes.new("Wire")
    me.from_pydata([(0, 0, 0), (0, 0, 1), (0, 1, 1)], [(0, 1), (1, 2)], [])
    ob = bpy.data.objects.new("Wire", me)
    bpy.context.scene.collection.objects.link(ob)
    return [ob]


# case: (scene builder -> the meshes to select, words one of which the report has)
BAD = {
    "flat plane": (_plane, [r"volume", r"flat", r"closed"]),
    "sphere": (_sphere, [r"blob", r"legs"]),
    "NaN coordinates": (_nan, [r"NaN"]),
    "empty mesh": (_empty, [r"'Empty' is empty"]),
    "edges only": (_edges_only, [r"'Wire' has no faces"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_is_one_clear_report_and_adds_nothing(capfd, case):
    build, words = BAD[case]
    meshes = build()
    B.set_active(meshes[0], selected=meshes)
    bpy.ops.ed.undo_push(message="before")
    before = fingerprint()
    selected = set(bpy.context.selected_objects)
    result, console = run(capfd, meshes)
    assert result == {"CANCELLED"}
    one_clear_error(console, *words)
    assert not armatures() and not bpy.data.armatures
    assert fingerprint() == before
    assert set(bpy.context.selected_objects) == selected and bpy.context.view_layer.objects.active == meshes[0]


def test_nothing_selected_no_mesh_and_edit_mode_are_reported(capfd):
    result, console = run(capfd, [])
    assert result == {"CANCELLED"} and "Nothing selected" in one_clear_error(console, added=False)
    bpy.ops.object.camera_add()
    cam = bpy.context.object
    result, console = run(capfd, [cam])
    assert result == {"CANCELLED"}
    assert "No mesh selected ('Camera' is not a mesh" in one_clear_error(console, added=False)
    body = human()
    B.set_active(body)
    bpy.ops.object.mode_set(mode="EDIT")
    result, console = run(capfd, [body])
    assert result == {"CANCELLED"} and "Edit Mode" in one_clear_error(console, added=False)
    bpy.ops.object.mode_set(mode="OBJECT")
    assert not bpy.data.armatures


def test_a_failing_bind_takes_the_armature_out_again(capfd):
    """The bind is the last step: when it fails (here the weights operator is made to refuse),
    the armature just built goes again, with its data, and the selection is as it was."""
    body = human()
    weights_ops = importlib.import_module(f"{blender_session.ADDON_MODULE}.weights.operators")
    cls = weights_ops.MINISKELETON_OT_auto_weights
    original = cls.execute

    def refuse(self, context):
        self.report({"ERROR"}, "refused for the test")
        return {"CANCELLED"}

    bpy.utils.unregister_class(cls)
    cls.execute = refuse
    bpy.utils.register_class(cls)
    try:
        result, console = run(capfd, [body])
    finally:
        bpy.utils.unregister_class(cls)
        cls.execute = original
        bpy.utils.register_class(cls)
    assert result == {"CANCELLED"}
    assert "binding failed: refused for the test" in one_clear_error(
        console, nested=["Error: refused for the test"])
    assert not armatures() and not bpy.data.armatures
    assert not body.modifiers and not body.vertex_groups and body.parent is None
    assert bpy.context.view_layer.objects.active == body and body.select_get()


def test_one_undo_takes_it_all_back(capfd):
    body = human()
    B.set_active(body)
    bpy.ops.ed.undo_push(message="before")
    before = fingerprint()
    assert bpy.ops.object.miniskeleton_auto_rig("EXEC_DEFAULT", True) == {"FINISHED"}
    after = fingerprint()
    assert after["armatures"] and after["meshes"] != before["meshes"]
    bpy.ops.ed.undo()
    assert fingerprint() == before
    bpy.ops.ed.redo()
    assert fingerprint() == after


# ---------------------------------------------------------------------------- shared models

def _bare_model(name):
    """Model ``name`` of ../shared/models as a bare mesh (``rig_corpus.bare_model``)."""
    path = rig_corpus.MODELS_DIR / name
    if not path.exists():
        pytest.skip(f"{path} not present")
    return rig_corpus.bare_model(path)


@pytest.mark.parametrize("name,template,ears", [("CesiumMan.gltf", "BIPED", 0), ("Fox.glb", "QUADRUPED", 1),
                                                ("spot_rig.glb", "QUADRUPED", 2),
                                                ("cow.obj", "QUADRUPED", 1), ("horse.ply", "QUADRUPED", 0)])
def test_shared_models_auto_rig_inside_and_bound(capfd, name, template, ears):
    """The shared models get their template, the fox its ears, the cow a pair of ears or horns
    and spot_rig its horns and its ears (short beside its big head: no leaves of its centre
    line; the horse's are too short)."""
    meshes = _bare_model(name)
    result, console = run(capfd, meshes)
    assert result == {"FINISHED"}, console
    assert f"Auto Rig: {template.lower()}" in console, console
    (arm,) = armatures()
    assert_rigged(arm, meshes, template, ears=ears)


def test_ears_on_a_head_are_a_pair_of_tentacles_that_generate(capfd):
    """A hare's two long ears are rigged as Rigify's horse metarig rigs its ears (two bones from
    the head, a tentacle each side), inside and bound, and Generate Rig makes their controls; the
    quadruped without ears gets none (``test_quadruped_with_tail_gets...``)."""
    body = shapes.build("hare")
    bpy.context.view_layer.update()
    result, console = run(capfd, [body])
    assert result == {"FINISHED"}, console
    (arm,) = armatures()
    assert_rigged(arm, [body], "QUADRUPED", ears=True)
    left, right = (arm.matrix_world @ arm.data.bones[f"ear.{s}.001"].tail_local for s in SIDES)
    assert left.x > 0.05 and right.x < -0.05 and min(left.z, right.z) > 1.5, (left, right)
    assert arm.data.bones["ear.L.001"].use_connect
    result, error = rigify_generate(arm)
    assert result == {"FINISHED"}, error
    for s in SIDES:
        assert arm.pose.bones[f"ear.{s}"].rigify_type == "limbs.simple_tentacle"
    deform = {b.name for b in arm.data.rigify_target_rig.data.bones if b.use_deform}
    assert {"DEF-ear.L", "DEF-ear.L.001", "DEF-ear.R", "DEF-ear.R.001"} <= deform, sorted(deform)


# ---------------------------------------------------------------------------- shape classes

def _leg_bones(arm) -> list[str]:
    return [b.name for b in arm.data.bones if b.name.startswith(("thigh", "shin", "front_thigh", "front_shin"))]


@pytest.mark.parametrize("name", sorted(shapes.EXPECTED))
def test_each_shape_class_gets_its_template_inside_bound_and_generates(capfd, name):
    """A long, low lizard faces along its body on four legs; a snake, a fish on its fins and a cone
    on flippers get a chain; a bird and an upright moth wings (the moth no legs): every joint
    inside, every vertex weighted, and Rigify's Generate Rig makes a control rig of it."""
    template, facing, legged = shapes.EXPECTED[name]
    body = shapes.build(name)
    bpy.context.view_layer.update()
    result, console = run(capfd, [body])
    assert result == {"FINISHED"}, console
    assert f"Auto Rig: {template.lower()}" in console, console
    if facing:
        assert f"facing {facing}" in console, console
    (arm,) = armatures()
    assert bool(_leg_bones(arm)) == legged, _leg_bones(arm)
    assert_inside_and_bound(arm, [body])
    result, error = rigify_generate(arm)
    assert result == {"FINISHED"}, error
    rig = arm.data.rigify_target_rig
    assert rig is not None and any(b.name.startswith("DEF-") for b in rig.data.bones)


def test_a_figure_lying_on_its_side_gets_no_legs(capfd):
    result, console = run(capfd, _lying())
    assert "Traceback" not in console
    if result == {"FINISHED"}:
        (arm,) = armatures()
        assert not _leg_bones(arm), console
    else:
        one_clear_error(console)


@pytest.mark.parametrize("name,templates", [("q_Dragon.glb", ("WINGED",)), ("q_Orc.glb", ("CHAIN", "WINGED"))])
def test_legless_shared_models_get_a_chain_or_wings_inside_bound_and_generate(capfd, name, templates):
    meshes = _bare_model(name)
    result, console = run(capfd, meshes)
    assert result == {"FINISHED"}, console
    assert any(f"Auto Rig: {t.lower()}" in console for t in templates), console
    (arm,) = armatures()
    assert not _leg_bones(arm)
    assert_inside_and_bound(arm, meshes)
    result, error = rigify_generate(arm)
    assert result == {"FINISHED"}, error


# ---------------------------------------------------------------------------- control rig

@pytest.mark.parametrize("template", ["BIPED", "QUADRUPED"])
def test_control_rig_binds_the_def_bones_and_walks_cleanly(capfd, template):
    """With Rigify enabled, Control Rig (on by default) generates Rigify's control rig, binds the
    mesh to its DEF bones and leaves it active, one undo taking it all back; Add Motion walks it
    with the feet planted (the motion corpus' measure)."""
    bpy.ops.preferences.addon_enable(module="rigify")
    body = human() if template == "BIPED" else quadruped()
    name = body.name
    B.set_active(body)
    bpy.ops.ed.undo_push(message="before")
    before = fingerprint()
    capfd.readouterr()
    assert bpy.ops.object.miniskeleton_auto_rig("EXEC_DEFAULT", True) == {"FINISHED"}
    console = "".join(capfd.readouterr())
    assert "control rig" in console, console
    after = fingerprint()
    bpy.ops.ed.undo()
    assert fingerprint() == before
    bpy.ops.ed.redo()
    assert fingerprint() == after
    metarig = next(ob for ob in armatures() if ob.data.rigify_target_rig is not None)
    rig = metarig.data.rigify_target_rig
    body = bpy.data.objects[name]  # undo and redo made the scene's objects anew
    assert bpy.context.view_layer.objects.active == rig and metarig.hide_get()
    assert [m.object for m in body.modifiers if m.type == "ARMATURE"] == [rig]
    groups = {g.name for g in body.vertex_groups}
    assert groups and all(g.startswith("DEF-") for g in groups), sorted(groups)[:5]
    deform = [b.name for b in rig.data.bones if b.use_deform]
    w = B.weights_matrix(body, deform)
    assert (w.max(axis=1) > 0).all()
    row = corpus.run_motion(rig, [body], "WALK")
    assert row["result"] == "FINISHED", row["error"]
    t = corpus.TARGET
    assert row["moves"] >= t["moves"] and row["skate"] <= t["skate"] and abs(row["float"]) <= t["float"], row
    assert row["pen"] <= t["pen"], row
