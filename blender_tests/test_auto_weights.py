"""object.miniskeleton_auto_weights in real Blender: every method, write-back, undo, bad input."""

import importlib
import math
import os
import time

import bpy
import numpy as np
import pytest

from testkit import builders as B
from testkit import creature, measures, modal
from testkit.builders import CHAIN_NAMES as NAMES

common_groups = importlib.import_module("bl_ext.user_default.miniskeleton.common.groups")

METHODS = ["HEAT", "VOXEL", "BILINEAR", "IDW"]


def bind(meshes, arm, **props):
    B.select_for_parenting(meshes, arm)
    return bpy.ops.object.miniskeleton_auto_weights(**props)


# ---------------------------------------------------------------- install


def test_installed_from_zip_like_a_user():
    import miniskeleton_core

    assert "bl_ext.user_default.miniskeleton" in bpy.context.preferences.addons.keys()
    # The core must come from the wheel bundled in the extension, not from the source tree.
    user = os.environ["BLENDER_USER_RESOURCES"]
    assert os.path.realpath(miniskeleton_core.__file__).startswith(os.path.realpath(user))
    assert hasattr(bpy.ops.object, "miniskeleton_auto_weights")


def test_installed_manifest_asks_for_the_file_access_the_rig_exchange_uses():
    """The NPZ / JSON exports and the NPZ import open files themselves, and Set Part Image loads a
    picture, so Blender's extension rules want a ``files`` permission (a reason of at most 64
    characters with no final punctuation) in the manifest that was installed, and nothing more."""
    import tomllib

    folder = os.path.dirname(importlib.import_module("bl_ext.user_default.miniskeleton").__file__)
    with open(os.path.join(folder, "blender_manifest.toml"), "rb") as f:
        manifest = tomllib.load(f)
    reason = manifest["permissions"]["files"]
    assert 0 < len(reason) <= 64 and (reason[-1].isalnum() or reason[-1] == ")")
    assert set(manifest["permissions"]) == {"files"}  # no network, clipboard, camera or microphone


def test_menus_offer_the_operator():
    for menu in ("VIEW3D_MT_object_parent", "VIEW3D_MT_paint_weight"):
        funcs = getattr(bpy.types, menu)._dyn_ui_initialize()
        assert any(getattr(f, "__module__", "").endswith("miniskeleton.weights.ui") for f in funcs), menu
    assert hasattr(bpy.types, "MINISKELETON_PT_weights")
    assert bpy.types.MINISKELETON_PT_weights.bl_category == "MiniSkeleton"


def test_selected_objects_that_are_not_meshes_are_named_and_left_alone(capfd):
    """A curve (or text, or another armature) selected with the mesh gets no weights, modifier
    or parent, and the warning names it; the mesh is bound as usual."""
    ob, arm = B.cylinder(), B.chain()
    curve = bpy.data.objects.new("Rope", bpy.data.curves.new("Rope", "CURVE"))
    bpy.context.collection.objects.link(curve)
    capfd.readouterr()
    assert bind([ob, curve], arm) == {"FINISHED"}
    assert "Skipped 1 selected object(s) that are not meshes: Rope" in "".join(capfd.readouterr())
    assert curve.parent is None and len(curve.modifiers) == 0
    assert B.weights_matrix(ob, NAMES).sum(1) == pytest.approx(1.0, abs=1e-5)


def test_mesh_linked_from_a_library_is_refused_and_left_alone(tmp_path):
    """A mesh linked from another .blend is read-only. Auto Weights names it and the way out and
    changes nothing (Blender's Ctrl+P writes no weights there and says nothing); made local, it binds."""
    ob, arm = B.cylinder(), B.chain()
    ob.data = B.link_from_library(ob.data, tmp_path / "character.blend")
    for method in METHODS:
        with pytest.raises(RuntimeError, match=r"Mesh '.*' is linked from character.blend .*Make Local"):
            bind([ob], arm, method=method)
    assert len(ob.vertex_groups) == 0 and len(ob.modifiers) == 0 and ob.parent is None
    ob.data = ob.data.make_local()
    assert bind([ob], arm, method="HEAT") == {"FINISHED"}
    assert B.weights_matrix(ob, NAMES).sum(1) == pytest.approx(1.0, abs=1e-5)



# ---------------------------------------------------------------- per method


@pytest.mark.parametrize("method", METHODS)
def test_weights_on_cylinder_chain(method):
    ob = B.cylinder()
    arm = B.chain(count=4)
    assert bind([ob], arm, method=method) == {"FINISHED"}

    w = B.weights_matrix(ob, NAMES)
    np.testing.assert_allclose(w.sum(1), 1.0, atol=1e-5)

    # Strongest bone = nearest segment, wherever the nearest is unambiguous.
    verts = measures.world_vertices(ob)
    heads, tails = B.bone_segments_world(arm, NAMES)
    d = B.segment_distances(verts, heads, tails)
    order = np.sort(d, axis=1)
    clear = order[:, 1] - order[:, 0] > 0.2
    assert clear.sum() > 100
    assert (w[clear].argmax(1) == d[clear].argmin(1)).mean() == 1.0

    # Neighbours blend across the joint at z = 2.0 (between Bone1 and Bone2).
    at_joint = np.abs(verts[:, 2] - 2.0) < 1e-4
    assert at_joint.sum() >= 24
    assert (w[at_joint, 1] > 0.25).all() and (w[at_joint, 2] > 0.25).all()

    # The Armature modifier and parenting are in place; bending moves the top, not the bottom.
    assert [m.type for m in ob.modifiers].count("ARMATURE") == 1
    assert ob.parent == arm
    rest = measures.evaluated_world_vertices(ob)
    np.testing.assert_allclose(rest, verts, atol=1e-5)
    arm.pose.bones["Bone2"].rotation_mode = "XYZ"
    arm.pose.bones["Bone2"].rotation_euler = (math.radians(60), 0, 0)
    bpy.context.view_layer.update()
    posed = measures.evaluated_world_vertices(ob)
    moved = np.linalg.norm(posed - verts, axis=1)
    top, bottom = verts[:, 2] > 3.5, verts[:, 2] < 0.5
    assert moved[top].min() > 0.5
    # IDW is long-range by construction (every bone keeps some d^-2 share), the others local.
    assert moved[bottom].max() < (0.25 if method == "IDW" else 0.05) * moved[top].min()


@pytest.mark.parametrize("method, options, core_kw", [
    ("IDW", dict(power=4.0, max_influences=3), dict(power=4.0, max_influences=3)),
    ("BILINEAR", dict(falloff="INVERSE_POWER", power=3.0, nearest=2),
     dict(falloff="inverse_power", power=3.0, nearest=2)),
    ("BILINEAR", dict(falloff="GAUSSIAN", sigma=0.03), dict(falloff="gaussian", sigma=0.03)),
    ("HEAT", dict(visibility=False), dict(visibility=False)),
    ("VOXEL", dict(resolution=32, voxel_falloff=0.2), dict(resolution=32, falloff=0.2)),
], ids=["IDW power", "BILINEAR inverse power", "BILINEAR sigma", "HEAT no visibility", "VOXEL resolution falloff"])
def test_each_option_reaches_the_core(method, options, core_kw):
    """An option of Auto Weights gives the weights the core gives with that argument, which on
    the creature differ from the defaults' (so an option that is dropped on the way shows)."""
    import miniskeleton_core as core

    common_armatures = importlib.import_module("bl_ext.user_default.miniskeleton.common.armatures")
    common_meshes = importlib.import_module("bl_ext.user_default.miniskeleton.common.meshes")
    body, arm = creature.build_body(subdivisions=0), creature.build_armature()
    bones = common_armatures.armature_bones(arm)
    v, t = measures.world_vertices(body), common_meshes.mesh_triangles(body)

    def solve(**kw):
        if method == "IDW":
            return core.idw_weights(v, bones.heads, bones.tails, **kw)
        if method == "BILINEAR":
            return core.bilinear_weights(v, bones.heads, bones.tails, bones.parents, **kw)
        if method == "VOXEL":
            out = core.voxel_weights(v, t, bones.heads, bones.tails, **kw)
            return out.indices, out.weights
        return core.heat_weights(v, t, bones.heads, bones.tails, **kw)

    assert bind([body], arm, method=method, **options) == {"FINISHED"}
    got = B.weights_matrix(body, bones.names)
    want = B.dense_weights(*solve(**core_kw), len(bones.names))
    np.testing.assert_allclose(got, want, atol=1e-6)
    assert np.abs(B.dense_weights(*solve(), len(bones.names)) - want).max() > 0.05


def test_heat_is_default_and_rebinding_does_not_duplicate_modifier():
    ob = B.cylinder()
    arm = B.chain()
    bind([ob], arm)
    bind([ob], arm)
    assert [m.type for m in ob.modifiers].count("ARMATURE") == 1
    assert sorted(g.name for g in ob.vertex_groups) == NAMES
    op = bpy.context.window_manager.operator_properties_last("object.miniskeleton_auto_weights")
    assert op.method == "HEAT"


def test_own_modifier_that_ignores_the_weights_is_kept_and_named(capfd):
    """The mesh already has an Armature modifier for this rig with Vertex Groups off (envelopes
    only) or disabled: it is the user's and kept as it is, but the warning says the new weights
    do not deform through it."""
    ob, arm = B.cylinder(), B.chain()
    bind([ob], arm)
    mod = next(m for m in ob.modifiers if m.type == "ARMATURE")
    capfd.readouterr()
    assert bind([ob], arm) == {"FINISHED"}
    assert "do not deform it" not in "".join(capfd.readouterr())
    for setting, value in (("use_vertex_groups", False), ("show_viewport", False)):
        mod.use_vertex_groups = True
        mod.show_viewport = mod.show_render = setting != "show_viewport"
        setattr(mod, setting, value)
        assert bind([ob], arm) == {"FINISHED"}
        assert f"its Armature modifier {mod.name} for '{arm.name}'" in "".join(capfd.readouterr())
        assert [m.type for m in ob.modifiers] == ["ARMATURE"] and getattr(mod, setting) == value


def test_another_armatures_modifier_is_kept_and_named_in_a_warning(capfd):
    """Rebinding to a new rig keeps the old rig's Armature modifier (the user's), but says it
    still deforms the mesh; a disabled one or one with no armature is not mentioned."""
    ob = B.cylinder()
    old, new = B.chain("OldRig"), B.chain("NewRig")
    bind([ob], old)
    capfd.readouterr()
    assert bind([ob], new) == {"FINISHED"}
    assert [(m.type, m.object) for m in ob.modifiers] == [("ARMATURE", old), ("ARMATURE", new)]
    out = "".join(capfd.readouterr())
    assert f"'{ob.name}' also has Armature modifier(s) OldRig for another armature" in out
    ob.modifiers["OldRig"].show_viewport = ob.modifiers["OldRig"].show_render = False
    ob.modifiers.new("Empty", "ARMATURE")
    assert bind([ob], new) == {"FINISHED"}
    assert "also has Armature modifier" not in "".join(capfd.readouterr())


def test_a_mesh_that_carries_its_armature_is_weighted_and_not_parented_in_a_loop(capfd):
    """A body that carries its own rig (the armature is the mesh's child, as for a vehicle) gets
    its groups and modifier, is not parented to its own child (Blender refuses that loop: 'Loop
    in parents') and stays where it was. Before, the refused parent left a stray parent inverse
    matrix on the mesh, and nothing said why it was not parented."""
    ob = B.cylinder()
    ob.location = (2.0, 1.0, 0.5)
    arm = B.chain()
    arm.location = ob.location
    bpy.context.view_layer.update()
    arm.parent = ob
    arm.matrix_parent_inverse = ob.matrix_world.inverted()
    bpy.context.view_layer.update()
    world = ob.matrix_world.copy()
    capfd.readouterr()
    assert bind([ob], arm, method="HEAT") == {"FINISHED"}
    assert f"'{arm.name}' is a child of Cylinder, so they were not parented" in "".join(capfd.readouterr())
    assert ob.parent is None and arm.parent is ob
    np.testing.assert_array_equal(np.array(ob.matrix_parent_inverse), np.eye(4))
    np.testing.assert_allclose(np.array(ob.matrix_world), np.array(world), atol=1e-6)
    assert sorted(g.name for g in ob.vertex_groups) == NAMES
    assert [m.object for m in ob.modifiers if m.type == "ARMATURE"] == [arm]
    # The modifier deforms it: bending the top bone moves the top, not the bottom.
    rest = measures.evaluated_world_vertices(ob)
    arm.pose.bones["Bone3"].rotation_mode = "XYZ"
    arm.pose.bones["Bone3"].rotation_euler = (0.5, 0, 0)
    bpy.context.view_layer.update()
    moved = np.linalg.norm(measures.evaluated_world_vertices(ob) - rest, axis=1)
    z = measures.world_vertices(ob)[:, 2] - ob.location.z
    assert moved[z > 3.8].min() > 0.1 and moved[z < 2.0].max() < 1e-5


@pytest.mark.parametrize("parent", [None, "EMPTY", "BONE"])
def test_a_constrained_mesh_stays_where_it_is(parent):
    """Parenting keeps the mesh where it is even when its own constraints act on top of its
    parenting: a Copy Rotation that adds an empty's turn, on a mesh with no parent, under an
    empty, or parented to a bone. Before, the world matrix with the constraint in it became the
    new basis, the constraint added its turn again and the mesh swung by 0.25 units (Blender's
    Ctrl+P with Keep Transform does the same; without it, a mesh with a parent jumps)."""
    ob, arm = B.cylinder(location=(0.3, 0.1, 0.0)), B.chain(location=(0.3, 0.1, 0.0))
    turn = bpy.data.objects.new("Turn", None)
    bpy.context.collection.objects.link(turn)
    turn.rotation_euler = (0.0, 0.0, 0.5)
    if parent == "EMPTY":
        holder = bpy.data.objects.new("Holder", None)
        bpy.context.collection.objects.link(holder)
        holder.location, holder.rotation_euler = (0.0, 1.0, 0.0), (0.0, 0.0, 0.3)
        ob.parent = holder
    elif parent == "BONE":
        ob.parent, ob.parent_type, ob.parent_bone = arm, "BONE", "Bone1"
    spin = ob.constraints.new("COPY_ROTATION")
    spin.target, spin.mix_mode = turn, "ADD"
    bpy.context.view_layer.update()
    world, rest = ob.matrix_world.copy(), measures.evaluated_world_vertices(ob)
    assert bind([ob], arm, method="HEAT") == {"FINISHED"}
    bpy.context.view_layer.update()
    assert ob.parent == arm and ob.parent_type == "OBJECT" and not spin.mute
    np.testing.assert_allclose(np.array(ob.matrix_world), np.array(world), atol=1e-6)
    np.testing.assert_allclose(measures.evaluated_world_vertices(ob), rest, atol=1e-5)
    turn.rotation_euler = (0.0, 0.0, 0.9)  # and the constraint still acts
    bpy.context.view_layer.update()
    assert np.abs(np.array(ob.matrix_world) - np.array(world)).max() > 0.1


def test_a_new_parenting_keeps_the_meshs_transform_values_as_ctrl_p_does():
    """A mesh not yet parented gets the armature's inverse as its parent inverse, as Blender's
    Ctrl+P does, so its Location, Rotation and Scale fields keep the values the rigger typed
    (a basis rewritten to compensate would have put the armature's offset into them)."""
    arm = B.chain(location=(1.0, -2.0, 0.5), rotation=(0.0, 0.0, 0.4), scale=(2.0, 2.0, 2.0))
    ob = B.cylinder(location=(0.25, 0.5, -0.5), rotation=(0.1, 0.0, 0.0), scale=(1.5, 1.5, 1.5))
    bpy.context.view_layer.update()
    world, basis = np.array(ob.matrix_world), np.array(ob.matrix_basis)
    assert bind([ob], arm, method="HEAT") == {"FINISHED"}
    bpy.context.view_layer.update()
    assert ob.parent == arm and ob.parent_type == "OBJECT"
    np.testing.assert_allclose(np.array(ob.matrix_basis), basis, atol=1e-6)
    np.testing.assert_allclose(np.array(ob.matrix_parent_inverse), np.linalg.inv(np.array(arm.matrix_world)),
                               atol=1e-6)
    np.testing.assert_allclose(np.array(ob.matrix_world), world, atol=1e-6)


def test_a_mesh_already_parented_to_the_armature_keeps_its_own_transform_values():
    """Re-binding a mesh already object-parented to the armature (here without inverse, its
    offset in Location) leaves its parenting and transform values as the rigger set them, rather
    than rewriting them into an equivalent parent inverse and basis."""
    arm = B.chain(location=(0.0, 0.0, 0.5))
    ob = B.cylinder(location=(0.25, 0.0, -0.5))
    ob.parent = arm
    bpy.context.view_layer.update()
    world = np.array(ob.matrix_world)
    assert bind([ob], arm, method="HEAT") == {"FINISHED"}
    bpy.context.view_layer.update()
    assert ob.parent == arm and ob.parent_type == "OBJECT"
    assert tuple(ob.location) == (0.25, 0.0, -0.5)
    np.testing.assert_array_equal(np.array(ob.matrix_parent_inverse), np.eye(4))
    np.testing.assert_allclose(np.array(ob.matrix_world), world, atol=1e-7)


def test_a_half_modelled_with_a_mirror_modifier_poses_one_side_only():
    """Characters are often modelled as one half with a Mirror modifier. The new Armature
    modifier goes last in the stack, where Blender's Ctrl+P puts it, so the mirrored half follows
    the mirrored (.R) groups: raising the left arm moves the left arm only. Before, it went first
    and the Mirror modifier copied the left arm's pose onto the right (147 vertices moved)."""
    from testkit import blender_session
    from testkit import creature

    def setup():
        blender_session.reset_scene()
        body, arm = creature.build_body(subdivisions=1), creature.build_armature()
        B.keep_positive_x_half(body)
        mirror = body.modifiers.new("Mirror", "MIRROR")
        mirror.use_clip, mirror.use_mirror_merge = True, False
        body.modifiers.new("Subdivision", "SUBSURF")
        B.select_for_parenting([body], arm)
        return body, arm

    body, arm = setup()
    assert bpy.ops.object.parent_set(type="ARMATURE_NAME") == {"FINISHED"}
    blenders = [m.type for m in body.modifiers]
    body, arm = setup()
    assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
    assert [m.type for m in body.modifiers] == blenders == ["MIRROR", "SUBSURF", "ARMATURE"]
    rest = measures.evaluated_world_vertices(body)
    arm.pose.bones["upper_arm.L"].rotation_mode = "XYZ"
    arm.pose.bones["upper_arm.L"].rotation_euler = (0.0, 0.0, 1.2)
    bpy.context.view_layer.update()
    moved = np.linalg.norm(measures.evaluated_world_vertices(body) - rest, axis=1)
    assert (moved[rest[:, 0] > 0.05] > 0.1).sum() > 100
    assert moved[rest[:, 0] < -0.05].max() < 1e-5


def test_a_subdivided_cage_is_weighted_on_its_smooth_surface_like_ctrl_p():
    """Blender's Ctrl+P With Automatic Weights reads a mesh with a Subdivision Surface modifier
    at its vertices' limit positions (on the smooth surface the rigger sees; a coarse cage's
    vertices sit outside it). Ours does too: the core's limit positions equal Blender's own
    (OpenSubdiv, the first vertices of the subdivided mesh), the cage gets the heat weights of
    its faces at those positions, and it is closer to Blender's weights than before (on the
    198-vertex creature cage: L1 0.05 instead of 0.20). A Simple or hidden subdivision changes
    nothing."""
    from testkit import blender_session
    from testkit import creature
    import miniskeleton_core as core

    common_armatures = importlib.import_module("bl_ext.user_default.miniskeleton.common.armatures")
    common_meshes = importlib.import_module("bl_ext.user_default.miniskeleton.common.meshes")

    def setup(subsurf=None):
        blender_session.reset_scene()
        body, arm = creature.build_body(subdivisions=0), creature.build_armature()
        if subsurf is not None:
            mod = body.modifiers.new("Subdivision", "SUBSURF")
            for key, value in subsurf.items():
                setattr(mod, key, value)
        B.select_for_parenting([body], arm)
        return body, arm

    def blender_limit(ob, **settings):
        mod = ob.modifiers.new("Limit", "SUBSURF")
        mod.levels = 1
        for key, value in settings.items():
            setattr(mod, key, value)
        evaluated = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
        me = evaluated.to_mesh()
        co = np.array([v.co[:] for v in me.vertices])[:len(ob.data.vertices)]
        evaluated.to_mesh_clear()
        ob.modifiers.remove(mod)
        return co

    body, arm = setup()
    names = [b.name for b in arm.data.bones]
    cage = np.array([v.co[:] for v in body.data.vertices])
    diag = np.linalg.norm(cage.max(0) - cage.min(0))
    limit = core.catmull_clark_limit(cage, *common_meshes.mesh_polygons(body))
    np.testing.assert_allclose(limit, blender_limit(body), atol=1e-6 * diag)
    assert np.linalg.norm(limit - cage, axis=1).max() > 0.03 * diag
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=5, y_subdivisions=4)
    grid = bpy.context.active_object
    flat = np.array([v.co[:] for v in grid.data.vertices])
    np.testing.assert_allclose(core.catmull_clark_limit(flat, *common_meshes.mesh_polygons(grid), keep_corners=True),
                               blender_limit(grid, boundary_smooth="PRESERVE_CORNERS"), atol=1e-6)

    B.select_for_parenting([body], arm)
    assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
    plain = B.weights_matrix(body, names)
    bones = common_armatures.armature_bones(arm)
    assert bones.names == names
    m = np.array(body.matrix_world)
    i, w = core.heat_weights(limit @ m[:3, :3].T + m[:3, 3], common_meshes.mesh_triangles(body),
                             bones.heads, bones.tails)
    twin = B.dense_weights(i, w, len(names))

    body, _ = setup({"levels": 2})
    assert bpy.ops.object.parent_set(type="ARMATURE_AUTO") == {"FINISHED"}
    blenders = B.weights_matrix(body, names)
    body, _ = setup({"levels": 2})
    assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
    ours = B.weights_matrix(body, names)
    np.testing.assert_allclose(ours, twin, atol=1e-6)
    assert np.abs(plain - twin).sum(1).mean() > 0.1
    assert np.abs(ours - blenders).sum(1).mean() < 0.5 * np.abs(plain - blenders).sum(1).mean()
    for unsmoothed in ({"subdivision_type": "SIMPLE"}, {"show_viewport": False, "show_render": False},
                       {"levels": 0, "render_levels": 0}):
        body, _ = setup(unsmoothed)
        assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
        np.testing.assert_allclose(B.weights_matrix(body, names), plain, atol=1e-6)
    for render_only in ({"show_viewport": False}, {"levels": 0, "render_levels": 2}):  # smooth in the render
        body, _ = setup(render_only)
        assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
        np.testing.assert_allclose(B.weights_matrix(body, names), twin, atol=1e-6)


@pytest.mark.parametrize("boundary", ["ALL", "PRESERVE_CORNERS"])
def test_an_open_subdivided_cage_is_weighted_with_its_modifiers_boundary_smooth(boundary):
    """Boundary Smooth decides where an open cage's corners (a boundary vertex of one face) lie
    on the smooth surface: "Keep Corners" leaves them, "All" rounds them off. Auto Weights reads
    the setting: a flat banner along the chain gets the heat weights of the limit positions the
    modifier shows, which differ from the other setting's."""
    import miniskeleton_core as core

    common_armatures = importlib.import_module("bl_ext.user_default.miniskeleton.common.armatures")
    common_meshes = importlib.import_module("bl_ext.user_default.miniskeleton.common.meshes")
    cols, rows = 3, 8
    verts = [(x, 0.0, z) for z in np.linspace(0.0, 4.0, rows + 1) for x in np.linspace(-0.6, 0.6, cols + 1)]
    faces = [(r * (cols + 1) + c, r * (cols + 1) + c + 1, (r + 1) * (cols + 1) + c + 1, (r + 1) * (cols + 1) + c)
             for r in range(rows) for c in range(cols)]
    banner = B.mesh_object("Banner", verts, faces)
    mod = banner.modifiers.new("Subdivision", "SUBSURF")
    mod.boundary_smooth = boundary
    arm = B.chain()
    assert bind([banner], arm) == {"FINISHED"}
    got = B.weights_matrix(banner, NAMES)
    bones = common_armatures.armature_bones(arm)
    cage = np.array(verts, dtype=np.float32)
    tris = common_meshes.mesh_triangles(banner)
    expected = {}
    for keep in (True, False):
        limit = core.catmull_clark_limit(cage, *common_meshes.mesh_polygons(banner), keep_corners=keep)
        expected[keep] = B.dense_weights(*core.heat_weights(limit, tris, bones.heads, bones.tails), len(NAMES))
    keep = boundary == "PRESERVE_CORNERS"
    np.testing.assert_allclose(got, expected[keep], atol=1e-6)
    assert np.abs(got - expected[not keep]).sum(1).max() > 1e-3


def test_b_bones_are_weighted_along_their_rest_curve_like_ctrl_p():
    """Blender's bone heat splits a B-Bone into its segments along its rest curve (Rigify's
    deform bones are B-Bones). Three connected B-Bones along a half torus bend with the chain
    (automatic handles): with 8 segments instead of 1, Blender's weights change by L1 0.045 and
    ours by 0.040; ours are then within 0.013 of Blender's (0.042 before: ours stayed straight).
    Lone B-Bones, straight at rest, are weighted as plain bones (up to float-level ties where
    two bones meet)."""
    from testkit import blender_session

    def setup(segments, chain=True):
        blender_session.reset_scene()
        bpy.ops.mesh.primitive_torus_add(major_radius=2.0, minor_radius=0.4, major_segments=96,
                                         minor_segments=24)
        ob = bpy.context.active_object
        arm = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
        bpy.context.collection.objects.link(arm)
        B.set_active(arm, [])
        bpy.ops.object.mode_set(mode="EDIT")
        previous = None
        for i, (a0, a1) in enumerate(zip(np.linspace(0, np.pi, 4)[:-1], np.linspace(0, np.pi, 4)[1:])):
            eb = arm.data.edit_bones.new(f"B{i}")
            eb.head = (2 * np.cos(a0), 2 * np.sin(a0), 0)
            eb.tail = (2 * np.cos(a1), 2 * np.sin(a1), 0)
            eb.bbone_segments = segments
            if previous is not None and chain:
                eb.parent, eb.use_connect = previous, True
            previous = eb
        bpy.ops.object.mode_set(mode="OBJECT")
        B.select_for_parenting([ob], arm)
        return ob

    names = ["B0", "B1", "B2"]

    def weights(op, segments, chain=True):
        ob = setup(segments, chain)
        assert op() == {"FINISHED"}
        w = B.weights_matrix(ob, names)
        return w / np.maximum(w.sum(1, keepdims=True), 1e-12), measures.world_vertices(ob)[:, 1] > -0.1

    def l1(a, b, used):
        return np.abs(a - b).sum(1)[used].mean()

    ours = lambda: bpy.ops.object.miniskeleton_auto_weights()  # noqa: E731
    blender = lambda: bpy.ops.object.parent_set(type="ARMATURE_AUTO")  # noqa: E731
    ours1, used = weights(ours, 1)
    ours8, _ = weights(ours, 8)
    blender8, _ = weights(blender, 8)
    assert l1(ours1, ours8, used) > 0.02
    assert l1(ours8, blender8, used) < 0.5 * l1(ours1, blender8, used)
    # Segments set by a script just before (Blender has no segment data for them until the
    # next depsgraph update, which the operator call makes first): the same weights.
    ob = setup(1)
    for bone in bpy.data.objects["Rig"].data.bones:
        bone.bbone_segments = 8
    assert ours() == {"FINISHED"}
    scripted = B.weights_matrix(ob, names)
    assert l1(scripted / np.maximum(scripted.sum(1, keepdims=True), 1e-12), ours8, used) < 1e-6
    lone1, _ = weights(ours, 1, chain=False)
    lone8, _ = weights(ours, 8, chain=False)
    assert l1(lone8, lone1, used) < 1e-3  # the same up to ties at the joints (max 0.002)


def test_foreign_groups_untouched_bone_groups_replaced():
    ob = B.cylinder()
    arm = B.chain()
    mine = ob.vertex_groups.new(name="MyGroup")
    mine.add(list(range(0, 200, 3)), 0.37, "REPLACE")
    stale = ob.vertex_groups.new(name="Bone3")
    stale.add(list(range(len(ob.data.vertices))), 1.0, "REPLACE")  # junk: everything on Bone3
    other_mod = ob.modifiers.new("Keep", "SUBSURF")
    bind([ob], arm, method="HEAT")

    g = ob.vertex_groups["MyGroup"]
    got = {v.index: grp.weight for v in ob.data.vertices for grp in v.groups if grp.group == g.index}
    assert got == pytest.approx({i: 0.37 for i in range(0, 200, 3)})
    w = B.weights_matrix(ob, NAMES)
    # the stale "everything on Bone3" group was replaced: the bottom is on Bone0 now
    bottom = measures.world_vertices(ob)[:, 2] < 0.5
    assert (w[bottom, 3] == 0).all() and (w[bottom, 0] > 0.5).all()
    assert ob.modifiers.get("Keep") == other_mod and other_mod.type == "SUBSURF"
    assert [m.type for m in ob.modifiers] == ["SUBSURF", "ARMATURE"]  # added last, as Ctrl+P does
    assert not ob.hide_viewport  # hidden only while the groups are written


@pytest.mark.parametrize("way", ["convert", "add"])
def test_group_writer_ways_write_the_same_groups(way, monkeypatch):
    """Both ways of writing groups (attribute conversion for big meshes, VertexGroup.add for
    small ones in busy scenes) replace a bone's group in its place in the list, keep locked and
    foreign groups, store no zero weight, write exact values, and keep the viewport visibility
    and the selection."""
    monkeypatch.setattr(common_groups, "_ADD_CALL_S", 0.0 if way == "add" else math.inf)
    ob = B.cylinder()
    n = len(ob.data.vertices)
    ob.vertex_groups.new(name="Mine").add([0, 1], 0.25, "REPLACE")
    ob.vertex_groups.new(name="B").add([2], 0.5, "REPLACE")
    ob.vertex_groups.new(name="Held").add([3], 0.75, "REPLACE")
    ob.vertex_groups["Held"].lock_weight = True
    ramp = np.linspace(0, 1, n)
    dense = np.stack([ramp, 1 - ramp, np.ones(n), np.where(ramp > 0.5, 1.0, 0.0),
                      np.zeros(n)]).astype(np.float32)
    names = ["A", "B", "Held", "Rigid", "Unused"]
    ob.data.attributes.active = ob.data.attributes.new("mine", "FLOAT", "POINT")
    B.set_active(ob)
    for hidden in (True, False):
        ob.hide_viewport = hidden
        selected = ob.select_get()
        rows = common_groups.BoneRows(np.tile(np.arange(5, dtype=np.int32), (n, 1)), dense.T.copy(), 5)
        kept = common_groups.write_vertex_groups(ob, names, rows, np.ones(5, bool))
        assert kept == ["Held"] and ob.hide_viewport == hidden
        assert ob.select_get() == selected
        # B stays second, between the user's groups; the new ones follow in the bones' order
        assert [g.name for g in ob.vertex_groups] == ["Mine", "B", "Held", "A", "Rigid", "Unused"]
        assert "Unused" in ob.vertex_groups  # an empty group, as Blender's Ctrl+P writes
        got = B.weights_matrix(ob, ["A", "B", "Rigid", "Unused"])
        assert np.array_equal(got, dense[[0, 1, 3, 4]].T.astype(got.dtype))
        assert all(g.weight > 0 for v in ob.data.vertices for g in v.groups)
        assert B.weights_matrix(ob, ["Mine"])[:3, 0].tolist() == [0.25, 0.25, 0.0]
        held = B.weights_matrix(ob, ["Held"])[:, 0]
        assert held[3] == 0.75 and np.count_nonzero(held) == 1
        # As after Blender's Ctrl+P: the last group written is active, the attribute kept.
        assert ob.vertex_groups.active.name == "Unused"
        assert ob.data.attributes.active.name == "mine"
    assert "__miniskeleton_weights_tmp" not in ob.data.attributes


def test_running_again_keeps_the_group_list_as_blenders_ctrl_p_does():
    """A second Auto Weights rewrites each bone's group in its place in the list, as Blender's
    Ctrl+P does, so a rigger's own groups stay where they were put; and the mesh stays
    selected, so the operator can be run again at once (hiding it while the groups were written
    used to deselect it)."""
    lists = {}
    for who in ("ours", "blender"):
        ob, arm = B.cylinder(f"Mesh_{who}"), B.chain(f"Rig_{who}")
        for name in ("Bone2", "Mine", "Bone0"):
            ob.vertex_groups.new(name=name)
        ob.vertex_groups["Mine"].add([0, 1], 0.5, "REPLACE")
        B.select_for_parenting([ob], arm)
        if who == "ours":
            assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
            first = B.weights_matrix(ob, NAMES)
            assert ob.select_get()
            assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}  # no reselecting
            assert np.array_equal(B.weights_matrix(ob, NAMES), first)
        else:
            assert bpy.ops.object.parent_set(type="ARMATURE_AUTO") == {"FINISHED"}
        lists[who] = [g.name for g in ob.vertex_groups]
        assert B.weights_matrix(ob, ["Mine"])[:3, 0].tolist() == [0.5, 0.5, 0.0]
        assert ob.vertex_groups.active.name == "Bone3"
    assert lists["ours"] == lists["blender"] == ["Bone2", "Mine", "Bone0", "Bone1", "Bone3"]


def test_selected_bones_only_writes_only_those(capfd):
    ob = B.cylinder()
    arm = B.chain()
    B.pose_select(arm, selected=())
    with pytest.raises(RuntimeError, match="Selected Bones Only is on, but no deform bone is selected"):
        bind([ob], arm, method="HEAT", selected_bones_only=True)
    assert len(ob.vertex_groups) == 0 and ob.parent is None and len(ob.modifiers) == 0
    B.pose_select(arm, selected=("Bone1", "Bone2"))
    capfd.readouterr()
    bind([ob], arm, method="HEAT", selected_bones_only=True)
    assert sorted(g.name for g in ob.vertex_groups) == ["Bone1", "Bone2"]
    assert f"{len(ob.data.vertices)} vertices in 1 mesh(es), 2 bones," in capfd.readouterr().out  # those written


def test_multiple_meshes_with_own_transforms_world_space():
    arm = B.chain(location=(1, 2, 0))
    a = B.cylinder("A", location=(1, 2, 0))
    # B: the same world shape, made from a half-height cylinder scaled by 2 and rotated about Z
    b = B.cylinder("B", height=2.0, location=(1, 2, 0), rotation=(0, 0, 0.7), scale=(1, 1, 2))
    assert bind([a, b], arm, method="BILINEAR") == {"FINISHED"}
    wa, wb = B.weights_matrix(a, NAMES), B.weights_matrix(b, NAMES)
    heads, tails = B.bone_segments_world(arm, NAMES)
    for ob, w in ((a, wa), (b, wb)):
        verts = measures.world_vertices(ob)
        d = B.segment_distances(verts, heads, tails)
        order = np.sort(d, axis=1)
        clear = order[:, 1] - order[:, 0] > 0.2
        assert (w[clear].argmax(1) == d[clear].argmin(1)).all(), ob.name
        np.testing.assert_allclose(w.sum(1), 1, atol=1e-5)
    # same world shape -> the same weights for vertices at the same world height on the axis ring
    za = measures.world_vertices(a)[:, 2]
    zb = measures.world_vertices(b)[:, 2]
    ia, ib = np.argmin(np.abs(za - 3.0)), np.argmin(np.abs(zb - 3.0))
    np.testing.assert_allclose(wa[ia], wb[ib], atol=1e-3)


def test_linked_duplicates_computed_once_from_the_first(capfd):
    # Alt+D duplicates share one mesh, and Blender stores weights in the mesh: one answer,
    # from the first selected object; every duplicate gets the modifier and the parent.
    arm = B.chain()
    a = B.cylinder("A")
    b = bpy.data.objects.new("B", a.data)
    bpy.context.scene.collection.objects.link(b)
    b.location = (0.25, 0.0, 0.0)  # moved: its own world-space weights would differ
    expected = {}
    for ob in (a, b):
        assert bind([ob], arm, method="HEAT") == {"FINISHED"}
        expected[ob.name] = B.weights_matrix(ob, NAMES)
    assert np.abs(expected["A"] - expected["B"]).max() > 1e-3
    for ob in (a, b):
        ob.vertex_groups.clear()
        ob.modifiers.clear()
        ob.parent = None
    B.select_for_parenting([a, b], arm)
    first = [ob for ob in bpy.context.selected_objects if ob in (a, b)][0]
    other = b if first is a else a
    capfd.readouterr()
    assert bpy.ops.object.miniskeleton_auto_weights(method="HEAT") == {"FINISHED"}
    assert (f"'{other.name}' shares its mesh with '{first.name}': weights computed once"
            in "".join(capfd.readouterr()))
    np.testing.assert_allclose(B.weights_matrix(a, NAMES), expected[first.name], atol=1e-6)
    for ob in (a, b):
        assert [m.object for m in ob.modifiers if m.type == "ARMATURE"] == [arm]
        assert ob.parent is arm


def test_undo_restores_previous_groups_exactly():
    ob = B.cylinder()
    arm = B.chain()
    g = ob.vertex_groups.new(name="Bone1")
    g.add([1, 2, 3], 0.5, "REPLACE")
    ob.vertex_groups.new(name="Extra").add([7], 0.25, "REPLACE")
    B.select_for_parenting([ob], arm)
    bpy.ops.ed.undo_push(message="scene built")
    before = measures.group_state(ob)
    # As from a menu: the operator's UNDO flag pushes its step (undo=True, like the UI does).
    assert bpy.ops.object.miniskeleton_auto_weights("EXEC_DEFAULT", True, method="HEAT") == {"FINISHED"}
    after = measures.group_state(bpy.data.objects["Cylinder"])
    assert after != before
    bpy.ops.ed.undo()
    ob = bpy.data.objects["Cylinder"]
    assert measures.group_state(ob) == before
    assert not any(m.type == "ARMATURE" for m in ob.modifiers) and ob.parent is None
    bpy.ops.ed.redo()
    assert measures.group_state(bpy.data.objects["Cylinder"]) == after


# ---------------------------------------------------------------- bad input


def _untouched(ob):
    return not ob.vertex_groups and not ob.modifiers and ob.parent is None


def test_no_armature_reports_error():
    ob = B.cylinder()
    B.set_active(ob)
    with pytest.raises(RuntimeError, match="No armature"):
        bpy.ops.object.miniskeleton_auto_weights()
    assert _untouched(ob)


def test_no_mesh_selected_reports_error():
    arm = B.chain()
    B.set_active(arm)
    with pytest.raises(RuntimeError, match="No mesh selected"):
        bpy.ops.object.miniskeleton_auto_weights()


def test_no_deform_bones_reports_error():
    ob = B.cylinder()
    arm = B.chain()
    for b in arm.data.bones:
        b.use_deform = False
    with pytest.raises(RuntimeError, match="no deform bones"):
        bind([ob], arm)
    assert _untouched(ob)


def test_nan_coordinates_report_count_and_leave_mesh_untouched():
    ob = B.cylinder()
    arm = B.chain()
    ob.data.vertices[5].co = (float("nan"), 0, 0)
    ob.data.vertices[9].co = (0, float("nan"), 0)  # (RNA clamps inf to FLT_MAX on assignment)
    with pytest.raises(RuntimeError, match="2 vertices with NaN"):
        bind([ob], arm, method="HEAT")
    assert _untouched(ob)


def test_an_object_placed_at_nan_is_named_by_every_operator_and_nothing_changes(tmp_path):
    """An armature or mesh whose transform went NaN (a driver or script gone wrong): its bones
    came out NaN and were reported as "zero-length", Walk said "too few deform bones", Fit
    stopped with a traceback (SVD did not converge). Every operator now names the object."""
    ob, arm = B.cylinder(), B.chain()
    heads = [tuple(b.head_local) for b in arm.data.bones]
    arm.location.x = float("nan")
    bpy.context.view_layer.update()
    calls = [lambda m=m: bind([ob], arm, method=m) for m in ("HEAT", "BILINEAR", "IDW")]
    calls += [lambda: (B.select_for_parenting([ob], arm), bpy.ops.armature.miniskeleton_fit_skeleton())]
    calls += [lambda: (B.set_active(arm), bpy.ops.pose.miniskeleton_add_motion(motion="WALK"))]
    calls += [lambda: (B.select_for_parenting([ob], arm),
                       bpy.ops.export_scene.miniskeleton_npz(filepath=str(tmp_path / "rig.npz")))]
    for call in calls:
        with pytest.raises(RuntimeError) as err:
            call()
        assert f"Object '{arm.name}' has a NaN or infinite transform" in str(err.value), str(err.value)
        assert "Traceback" not in str(err.value)
    assert _untouched(ob) and arm.animation_data is None and not (tmp_path / "rig.npz").exists()
    assert [tuple(b.head_local) for b in arm.data.bones] == heads
    arm.location.x = 0.0
    ob.location.z = float("nan")
    bpy.context.view_layer.update()
    with pytest.raises(RuntimeError, match="Object 'Cylinder' has a NaN or infinite transform"):
        bind([ob], arm)
    with pytest.raises(RuntimeError, match="Nothing to film: the objects to frame have a NaN"):
        bpy.ops.render.miniskeleton_make_video(filepath=str(tmp_path / "v.mp4"), camera="NEW")
    assert _untouched(ob) and bpy.context.scene.camera is None


def test_an_armature_scaled_by_1e30_is_weighted_as_at_scale_one():
    """Blender's ``dimensions`` of an armature scaled by 1e30 are inf: read as its size, every
    bone fell under the zero-length limit and the rig was refused ("only zero-length deform
    bones"). The mesh, parented to the chain by the first binding, scales with it, and the pair
    gets the weights it had unscaled."""
    ob, arm = creature.build()
    names = [b.name for b in arm.data.bones if b.use_deform]
    assert bind([ob], arm) == {"FINISHED"}
    want = B.weights_matrix(ob, names)
    for g in list(ob.vertex_groups):
        ob.vertex_groups.remove(g)
    arm.scale = (1e30,) * 3
    bpy.context.view_layer.update()
    assert np.linalg.norm(np.array(ob.matrix_world, dtype=np.float64)[:3, 0]) == pytest.approx(1e30, rel=1e-6)
    assert bind([ob], arm) == {"FINISHED"}
    np.testing.assert_allclose(B.weights_matrix(ob, names), want, atol=1e-4)


@pytest.mark.parametrize("method", METHODS)
def test_a_character_far_from_the_world_origin_is_weighted_as_at_the_origin(method):
    """A game level or a surveyed site puts characters 1e5 m and more from the world origin,
    where single-precision world coordinates are 8 mm apart (6 cm at 1e6). Read in world space,
    the creature's Heat weights changed by up to 0.63 (L1) at 1e5 and 0.75 at 1e6, and IDW's
    and Bilinear's too. The core is now given vertices and bones in the armature's frame, moved
    there in double precision, and the pair (the mesh parented to the rig by the first binding)
    gets the weights it had at the origin."""
    ob, arm = creature.build()
    names = [b.name for b in arm.data.bones if b.use_deform]
    assert bind([ob], arm, method=method) == {"FINISHED"}
    want = B.weights_matrix(ob, names)
    for g in list(ob.vertex_groups):
        ob.vertex_groups.remove(g)
    arm.location = (1e6, -5e5, 2e5)
    bpy.context.view_layer.update()
    assert measures.world_vertices(ob)[:, 0].min() > 9e5
    assert bind([ob], arm, method=method) == {"FINISHED"}
    np.testing.assert_allclose(B.weights_matrix(ob, names), want, atol=1e-5)


def test_an_empty_mesh_is_skipped_with_a_warning_and_alone_is_an_error(capfd):
    """A placeholder mesh with no vertices among the selection no longer stops the others."""
    empty = bpy.data.objects.new("Placeholder", bpy.data.meshes.new("Placeholder"))
    bpy.context.collection.objects.link(empty)
    ob, arm = B.cylinder(), B.chain()
    assert bind([empty, ob], arm) == {"FINISHED"}
    assert "Skipped 1 selected mesh(es) without vertices: Placeholder" in capfd.readouterr().out
    assert sorted(g.name for g in ob.vertex_groups) == NAMES and ob.parent == arm
    assert len(empty.vertex_groups) == 0 and empty.parent is None and not empty.modifiers
    with pytest.raises(RuntimeError, match="Mesh 'Placeholder' has no vertices; nothing was changed"):
        bind([empty], arm)


def test_armature_in_edit_mode_reports_error():
    ob = B.cylinder()
    arm = B.chain()
    B.select_for_parenting([ob], arm)
    bpy.ops.object.mode_set(mode="EDIT")
    with pytest.raises(RuntimeError, match="Edit Mode"):
        bpy.ops.object.miniskeleton_auto_weights()
    bpy.ops.object.mode_set(mode="OBJECT")
    assert _untouched(ob)


@pytest.mark.parametrize("squash", [0.0, 1e-9])
def test_zero_length_bone_skipped_with_warning(capfd, squash):
    # Scaling the armature to zero along Z collapses the vertical bone in world space; a
    # millionth of the rig's size counts as zero too (the core would take it for a point).
    ob = B.cylinder(height=1.0)
    arm = B.armature(bones=[("Up", (0, 0, 0), (0, 0, 1), None, False),
                            ("Side", (-0.4, 0, 0), (0.4, 0, 0), None, False)],
                     location=(0, 0, 0.5), scale=(1, 1, squash))
    capfd.readouterr()
    assert bind([ob], arm, method="IDW") == {"FINISHED"}
    assert "Skipped 1 zero-length bone(s): Up" in "".join(capfd.readouterr())
    assert [g.name for g in ob.vertex_groups] == ["Side"]
    w = B.weights_matrix(ob, ["Side"])
    np.testing.assert_allclose(w[:, 0], 1.0, atol=1e-6)


@pytest.mark.parametrize("method", METHODS)
def test_mesh_without_faces_still_weighted(method):
    verts, _ = B.cylinder_arrays()
    ob = B.mesh_object("Points", verts, [])
    arm = B.chain()
    assert bind([ob], arm, method=method) == {"FINISHED"}
    w = B.weights_matrix(ob, NAMES)
    np.testing.assert_allclose(w.sum(1), 1.0, atol=1e-5)


def test_weight_paint_mode_uses_painted_mesh_and_its_armature():
    ob = B.cylinder()
    arm = B.chain()
    bind([ob], arm, method="IDW")
    for g in list(ob.vertex_groups):
        ob.vertex_groups.remove(g)
    B.set_active(ob)
    bpy.ops.object.mode_set(mode="WEIGHT_PAINT")
    assert bpy.ops.object.miniskeleton_auto_weights(method="BILINEAR") == {"FINISHED"}
    bpy.ops.object.mode_set(mode="OBJECT")
    assert sorted(g.name for g in ob.vertex_groups) == NAMES


def test_the_armature_is_found_from_the_mesh_as_riggers_select_it():
    """Besides Ctrl+P's order (meshes selected, armature active), the armature is the selected
    one when a mesh is active, else the one the active mesh's Armature modifier names, else its
    parent armature; in Weight Paint mode the painted mesh is weighted even when it is not
    selected. Each way alone finds it here (no other way is set up)."""
    def bound(ob):
        assert bpy.ops.object.miniskeleton_auto_weights(method="IDW") == {"FINISHED"}
        assert sorted(g.name for g in ob.vertex_groups) == NAMES
        assert [m.object for m in ob.modifiers if m.type == "ARMATURE"] == [arm]

    ob, arm = B.cylinder(), B.chain()
    B.set_active(ob, selected=[arm])            # the armature picked first, then the mesh
    bound(ob)

    ob, arm = B.cylinder(), B.chain()
    ob.modifiers.new("Armature", "ARMATURE").object = arm
    B.set_active(ob)                            # the mesh alone, its modifier set up by hand
    bound(ob)

    ob, arm = B.cylinder(), B.chain()
    ob.parent = arm                             # the mesh alone, parented without a modifier
    B.set_active(ob)
    bound(ob)

    ob, arm = B.cylinder(), B.chain()
    ob.modifiers.new("Armature", "ARMATURE").object = arm
    B.set_active(ob)
    bpy.ops.object.mode_set(mode="WEIGHT_PAINT")
    ob.select_set(False)                        # painted, but not selected
    bound(ob)
    bpy.ops.object.mode_set(mode="OBJECT")


def test_weight_paint_selection_masks_reweight_only_the_selected_vertices(capfd):
    """In Weight Paint mode with the Vertex or Face Selection mask on, only the selected
    vertices get new weights, as with Blender's Weights > Assign Automatic from Bones (measured
    in bpy 5.0: unselected vertices keep every weight). The whole mesh is still solved, so the
    selected rows are those of a full bind. Before, the whole mesh was re-weighted and the
    weights painted elsewhere were lost."""
    ob = B.cylinder(rings=24, segments=12)
    arm = B.chain()
    bind([ob], arm, method="HEAT")
    full = B.weights_matrix(ob, NAMES)
    z = np.array([v.co.z for v in ob.data.vertices])
    top, bottom, middle = z > 3.0, z < 1.0, (z > 1.5) & (z < 2.5)
    # Touch-ups a rigger painted: on top, and wrong ones at the bottom and the middle.
    ob.vertex_groups[NAMES[0]].add(np.flatnonzero(top).tolist(), 0.123, "REPLACE")
    ob.vertex_groups[NAMES[-1]].add(np.flatnonzero(bottom | middle).tolist(), 0.777, "REPLACE")
    ob.vertex_groups.new(name="Extra").add(list(range(len(z))), 0.5, "REPLACE")
    painted = B.weights_matrix(ob, NAMES)
    for v in ob.data.vertices:
        v.select = bool(bottom[v.index])
    for p in ob.data.polygons:
        p.select = all(middle[i] for i in p.vertices)
    B.set_active(ob)
    bpy.ops.object.mode_set(mode="WEIGHT_PAINT")

    ob.data.use_paint_mask_vertex = True
    capfd.readouterr()
    assert bpy.ops.object.miniskeleton_auto_weights(method="HEAT") == {"FINISHED"}
    assert (f"re-weighted only the {bottom.sum()} of {len(z)} vertices of 'Cylinder' selected for the "
            "Weight Paint") in capfd.readouterr().out
    after = B.weights_matrix(ob, NAMES)
    np.testing.assert_array_equal(after[~bottom], painted[~bottom])   # the painted top kept exactly
    np.testing.assert_allclose(after[bottom], full[bottom], atol=1e-6)  # the wrong 0.777 re-weighted

    ob.data.use_paint_mask_vertex, ob.data.use_paint_mask = False, True
    in_faces = np.zeros(len(z), bool)
    for p in ob.data.polygons:
        if p.select:
            in_faces[list(p.vertices)] = True
    assert in_faces.any() and not (in_faces & ~middle).any()
    assert bpy.ops.object.miniskeleton_auto_weights(method="HEAT") == {"FINISHED"}
    final = B.weights_matrix(ob, NAMES)
    np.testing.assert_array_equal(final[~in_faces], after[~in_faces])
    np.testing.assert_allclose(final[in_faces], full[in_faces], atol=1e-6)
    assert ob.vertex_groups["Extra"].weight(0) == 0.5

    ob.data.use_paint_mask = False
    ob.data.use_paint_mask_vertex = True
    for v in ob.data.vertices:
        v.select = False
    with pytest.raises(RuntimeError, match="no vertex of 'Cylinder' is selected"):
        bpy.ops.object.miniskeleton_auto_weights(method="HEAT")
    np.testing.assert_array_equal(B.weights_matrix(ob, NAMES), final)
    # bpy 5.0 without a window segfaults leaving Weight Paint with a mask on (so does a bare
    # cylinder, without MiniSkeleton): masks off first.
    ob.data.use_paint_mask_vertex = False
    bpy.ops.object.mode_set(mode="OBJECT")


def test_weight_paint_assigns_the_selected_bones_and_leaves_hidden_ones_out(capfd):
    """In Weight Paint mode, as Blender's Weights > Assign Automatic from Bones (measured in
    bpy 5.0 and 4.2): a bone hidden in Pose Mode is no heat source and keeps its group (hiding
    Bone2 changed Blender's Bone1 weights by 0.57), and only the selected bones get new weights.
    Before, every deform bone was a source and every group was rewritten."""
    ob, arm = B.cylinder(rings=24, segments=12), B.chain()
    bind([ob], arm, method="HEAT")
    bound = B.weights_matrix(ob, NAMES)
    rule = bpy.ops.object.miniskeleton_auto_weights.get_rna_type().properties["selected_bones_only"]
    assert rule.is_skip_save  # a Weight Paint default must not carry over to the next Ctrl+P
    for name in NAMES:
        ob.vertex_groups[name].add(list(range(len(ob.data.vertices))), 0.3, "REPLACE")
    # Bone0 is selected too, but in a bone collection that is hidden: not written either.
    B.pose_select(arm, selected=("Bone0", "Bone1"), hidden=("Bone2",))
    tucked = arm.data.collections.new("Tucked away")
    tucked.assign(arm.data.bones["Bone0"])
    tucked.is_visible = False
    B.set_active(ob, selected=[arm])
    bpy.ops.object.mode_set(mode="WEIGHT_PAINT")
    painted = float(np.float32(0.3))  # as Blender stores it
    capfd.readouterr()
    assert bpy.ops.object.miniskeleton_auto_weights(method="HEAT") == {"FINISHED"}
    assert "hidden bones left out, their groups kept: Bone2" in "".join(capfd.readouterr())
    after = B.weights_matrix(ob, NAMES)
    np.testing.assert_array_equal(after[:, [0, 2, 3]], painted)  # selected where hidden, or hidden: kept

    import miniskeleton_core as core

    common_armatures = importlib.import_module("bl_ext.user_default.miniskeleton.common.armatures")
    common_meshes = importlib.import_module("bl_ext.user_default.miniskeleton.common.meshes")
    bones = common_armatures.armature_bones(arm)
    seen = [0, 1, 3]  # Bone2 is hidden: no heat source
    i, w = core.heat_weights(measures.world_vertices(ob), common_meshes.mesh_triangles(ob),
                             bones.heads[seen], bones.tails[seen])
    np.testing.assert_allclose(after[:, 1], B.dense_weights(i, w, 3)[:, 1], atol=1e-6)
    z = np.array([v.co.z for v in ob.data.vertices])
    low_half = (z > 2.0) & (z < 2.3)  # of Bone2 (z 2.0 to 2.9)
    assert after[low_half, 1].min() > 0.8 and bound[low_half, 1].max() < 0.5  # Bone1 reaches in now

    # Nothing selected: every visible bone is written; an explicit choice is kept.
    B.pose_select(arm, hidden=("Bone2",))
    assert bpy.ops.object.miniskeleton_auto_weights(method="HEAT") == {"FINISHED"}
    np.testing.assert_array_equal(B.weights_matrix(ob, ["Bone2"]), painted)
    full = B.weights_matrix(ob, NAMES)
    np.testing.assert_allclose(full[:, 1], after[:, 1], atol=1e-6)
    assert np.abs(full[:, [0, 3]] - 0.3).max() > 0.5
    B.pose_select(arm, selected=("Bone0",))
    for name in NAMES:
        ob.vertex_groups[name].add(list(range(len(ob.data.vertices))), 0.3, "REPLACE")
    assert bpy.ops.object.miniskeleton_auto_weights(method="HEAT", selected_bones_only=False) == {"FINISHED"}
    assert np.abs(B.weights_matrix(ob, NAMES) - 0.3).max(0).min() > 0.5  # all four rewritten

    B.pose_select(arm, hidden=NAMES)
    with pytest.raises(RuntimeError, match="only hidden deform bones.*Alt\\+H"):
        bpy.ops.object.miniskeleton_auto_weights(method="HEAT")
    bpy.ops.object.mode_set(mode="OBJECT")
    # In Object Mode (Ctrl+P), as in Blender, hiding and selection change nothing.
    bind([ob], arm, method="HEAT")
    np.testing.assert_allclose(B.weights_matrix(ob, NAMES), B.dense_weights(
        *core.heat_weights(measures.world_vertices(ob), common_meshes.mesh_triangles(ob), bones.heads, bones.tails), 4),
        atol=1e-6)


# ---------------------------------------------------------------- worker thread (Esc to cancel)


def _weights_module():
    return importlib.import_module("bl_ext.user_default.miniskeleton.weights.compute")


def _job_inputs(rings=120, segments=64):
    common_armatures = importlib.import_module("bl_ext.user_default.miniskeleton.common.armatures")
    common_meshes = importlib.import_module("bl_ext.user_default.miniskeleton.common.meshes")
    ob = B.cylinder(rings=rings, segments=segments)
    arm = B.chain()
    bones = common_armatures.armature_bones(arm)
    inputs = [(ob, ob.name, common_meshes.mesh_world_vertices(ob), common_meshes.mesh_triangles(ob))]
    settings = dict(method="HEAT", k=4, power=2.0, nearest=3, falloff="gaussian", sigma=None,
                    visibility=True, mirror=None, parents=None)
    return ob, bones, inputs, settings


def test_weights_job_runs_on_a_worker_thread():
    ow = _weights_module()
    import miniskeleton_core as core

    ob, bones, inputs, settings = _job_inputs()
    job = ow.WeightsJob(lambda progress: ow.compute_weights(core, settings, bones, inputs, progress))
    job.start()
    assert job.wait(60)
    assert not job.cancelled and job.error is None and job.fraction == pytest.approx(1.0)
    (got_ob, idx, w), = job.result[0]
    assert got_ob is ob and idx.shape == (len(ob.data.vertices), 4)
    assert w.sum(axis=1) == pytest.approx(1.0, abs=1e-5)
    assert len(ob.vertex_groups) == 0  # the job computes, it never writes


def test_weights_job_cancel_stops_the_core_and_writes_nothing():
    ow = _weights_module()
    import miniskeleton_core as core

    ob, bones, inputs, settings = _job_inputs()
    job = ow.WeightsJob(lambda progress: ow.compute_weights(core, settings, bones, inputs, progress))
    job.cancel()  # Esc pressed before the first progress tick
    job.start()
    assert job.wait(60)
    assert job.cancelled and job.result is None and job.error is None
    assert len(ob.vertex_groups) == 0


def test_weights_job_reports_bad_input_as_an_error():
    ow = _weights_module()
    import miniskeleton_core as core

    ob, bones, inputs, settings = _job_inputs()
    ob_, name, verts, tris = inputs[0]
    bad = [(ob_, name, verts, np.full_like(tris, len(verts) + 5))]  # triangle indices out of range
    job = ow.WeightsJob(lambda progress: ow.compute_weights(core, settings, bones, bad, progress))
    job.start()
    assert job.wait(60)
    assert not job.cancelled and job.result is None
    assert isinstance(job.error, ow.WeightsError) and name in str(job.error)
    # An unexpected failure inside the job is an error too, never a job that ends with nothing.
    def broken(progress):
        raise KeyError("no such bone")

    job = ow.WeightsJob(broken)
    job.start()
    assert job.wait(60)
    assert not job.cancelled and job.result is None
    assert isinstance(job.error, ow.WeightsError) and "Auto Weights failed: 'no such bone'" in str(job.error)


def test_many_small_meshes_solved_in_batches_get_the_one_by_one_weights_and_notes(monkeypatch):
    """A figure of many small objects goes to the core several objects per call: the same
    weights and notes, in the same order, as one object after the other, and a big mesh among
    them is solved on its own in its place; progress is reported from the calling thread only,
    between calls (it may touch Blender's UI), cancelling stops between calls, and an error
    names its mesh."""
    import threading

    import miniskeleton_core as core

    ow = _weights_module()
    common_armatures = importlib.import_module("bl_ext.user_default.miniskeleton.common.armatures")
    common_meshes = importlib.import_module("bl_ext.user_default.miniskeleton.common.meshes")
    part = dict(radius=0.3, height=0.5, rings=4, segments=8)
    obs = [B.cylinder(name=f"Part{i}", location=(0.0, 0.0, 0.35 * i), **part) for i in range(6)]
    obs.append(B.cylinder(name="Big", radius=0.27, height=0.5, rings=20, segments=16, location=(0.013, 0.0, 2.1)))
    obs += [B.cylinder(name=f"Part{i}", location=(0.0, 0.0, 0.35 * i), **part) for i in range(6, 10)]
    obs.append(B.cylinder(name="Upper", location=(0.0, 0.0, 4.0), **part))
    obs.append(B.cylinder(name="Lower", location=(0.0, 0.0, 3.5), **part))  # one seam group with Upper
    arm = B.chain()
    bones = common_armatures.armature_bones(arm)
    inputs = [(ob, ob.name, common_meshes.mesh_world_vertices(ob), common_meshes.mesh_triangles(ob)) for ob in obs]
    flipped = inputs[3][3].copy()
    flipped[: len(flipped) // 2] = flipped[: len(flipped) // 2, ::-1]
    inputs[3] = inputs[3][:3] + (flipped,)
    small = len(inputs[0][2])
    monkeypatch.setattr(ow, "BATCH_VERTICES", 2 * small)        # Big (> 2 parts) is solved alone
    monkeypatch.setattr(ow, "CALL_VERTICES", 3 * small)         # at most 3 parts per call
    settings = dict(method="HEAT", k=4, power=2.0, nearest=3, falloff="gaussian", sigma=None,
                    visibility=True, mirror=None, parents=None)

    class Counted:
        """The core, counting its calls and the meshes they carry."""
        def __init__(self):
            self.many, self.single = [], 0

        def __getattr__(self, name):
            return getattr(core, name)

        def heat_weights_many(self, meshes, *a, **kw):
            self.many.append(len(meshes))
            return core.heat_weights_many(meshes, *a, **kw)

        def heat_weights_report(self, *a, **kw):
            self.single += 1
            return core.heat_weights_report(*a, **kw)

    one_by_one = Counted()
    with monkeypatch.context() as m:
        m.setattr(ow, "BATCH_VERTICES", -1)
        serial_results, serial_notes = ow.compute_weights(one_by_one, settings, bones, inputs, lambda f: True)
    assert one_by_one.many == [] and one_by_one.single == 12   # Upper + Lower: one group
    batched = Counted()
    reported_on, fractions = set(), []
    results, notes = ow.compute_weights(
        batched, settings, bones, inputs,
        lambda f: reported_on.add(threading.current_thread()) or fractions.append(f) or True)
    assert batched.many == [3, 3, 3, 2] and batched.single == 1  # parts 0-5 | Big | 6-9, Upper + Lower
    assert reported_on == {threading.main_thread()}
    assert fractions == sorted(fractions) and fractions[-1] == pytest.approx(1.0)
    assert [r[0] for r in results] == [r[0] for r in serial_results] == obs
    for (_, i, w), (_, si, sw) in zip(results, serial_results):
        assert np.array_equal(i, si) and np.array_equal(w, sw)
    assert notes == serial_notes and any("Part3" in n and "wound against" in n for n in notes)

    stopped = Counted()
    with pytest.raises(core.Cancelled):
        ow.compute_weights(stopped, settings, bones, inputs, lambda f: f < 0.2)
    assert stopped.many == [3]              # 3 of 12 groups done (0.25): stopped before the next call
    bad = list(inputs)
    bad[5] = inputs[5][:3] + (np.full_like(inputs[5][3], len(inputs[5][2])),)  # the next part's vertex once stacked
    with pytest.raises(ow.WeightsError, match="Mesh 'Part5'"):
        ow.compute_weights(core, settings, bones, bad, lambda f: True)
    bad[5] = inputs[5][:3] + (np.full_like(inputs[5][3], 10_000),)  # out of range even stacked
    with pytest.raises(ow.WeightsError, match="nothing was changed"):
        ow.compute_weights(core, settings, bones, bad, lambda f: True)


def test_invoke_without_a_window_runs_directly():
    ob = B.cylinder()
    arm = B.chain()
    B.select_for_parenting([ob], arm)
    assert bpy.ops.object.miniskeleton_auto_weights("INVOKE_DEFAULT") == {"FINISHED"}
    assert B.weights_matrix(ob, NAMES).sum(axis=1) == pytest.approx(1.0, abs=1e-5)


# ---------------------------------------------------------------- the modal loop (Esc to cancel)


@pytest.fixture
def driven(monkeypatch):
    """Auto Weights as the UI runs it on a large mesh, with the window's part played by the
    test: for the test, the operator's ``execute`` does what ``invoke`` does before it hands
    the operator to the window (validate and read the inputs, start the worker thread, the
    progress bar and the timer), then ``script(op, context)`` (set by the test) sends the events
    ``modal`` gets and returns its answer. The operator's own ``_prepare``, ``_start_job``,
    ``modal``, ``cancel`` and ``_write`` run; only the window's event queue is the test's."""
    operators = importlib.import_module("bl_ext.user_default.miniskeleton.weights.operators")
    test = {}

    def execute(self, context):
        import miniskeleton_core as core

        prepared = self._prepare(context)
        if prepared is None:
            return {"CANCELLED"}
        self._start_job(context, core, prepared)
        return test["script"](self, context)

    monkeypatch.setattr(operators.MINISKELETON_OT_auto_weights, "execute", execute)
    return test


def test_modal_run_shows_progress_and_writes_the_weights_when_done(driven, monkeypatch, capfd):
    """Timer ticks while the worker computes: the progress only grows, with values between 0
    and 1; other events (a click, a key) are swallowed while the meshes must not change; and
    nothing is written until the tick that finds the job done writes every group, the modifier
    and the parent, as a blocking run does."""
    ob, arm = modal.large_cylinder(), B.chain()
    seen = {"ticks": [], "other": []}

    def run_to_the_end(op, context):
        while True:
            seen["other"].append(op.modal(context, modal.Event("LEFTMOUSE")))
            answer = modal.tick(op, context, seen, ob)
            if answer != {"RUNNING_MODAL"}:
                return answer
            time.sleep(0.002)

    driven["script"] = run_to_the_end
    B.select_for_parenting([ob], arm)
    assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
    fractions = [f for f, _, _ in seen["ticks"]]
    assert fractions == sorted(fractions) and fractions[-1] == pytest.approx(1.0)
    assert any(0.0 < f < 1.0 for f in fractions), fractions  # seen between start and end
    assert len(set(fractions)) >= 3, fractions
    assert all(answer == {"RUNNING_MODAL"} for answer in seen["other"])
    # Groups appear on the last tick only.
    assert all(groups == 0 for _, groups, _ in seen["ticks"][:-1]) and seen["ticks"][-1][1] == 4
    assert "Auto Weights (Heat): 51330 vertices in 1 mesh(es), 4 bones" in capfd.readouterr().out
    w = B.weights_matrix(ob, NAMES)
    np.testing.assert_allclose(w.sum(1), 1.0, atol=1e-5)
    assert [m.type for m in ob.modifiers] == ["ARMATURE"] and ob.modifiers[0].object == arm and ob.parent == arm
    # The same weights as a blocking run (the operator's own execute again) writes.
    monkeypatch.undo()
    blocking = B.cylinder(name="Blocking", rings=400, segments=128)
    B.select_for_parenting([blocking], arm)
    assert bpy.ops.object.miniskeleton_auto_weights() == {"FINISHED"}
    np.testing.assert_allclose(B.weights_matrix(blocking, NAMES), w, atol=1e-6)


def test_esc_stops_the_modal_run_and_leaves_the_scene_as_it_was(driven, capfd):
    """Esc while the worker is half way: ``modal`` tells the job to stop and keeps running
    until the job has stopped (at its next progress tick), then cancels with a warning; the
    mesh keeps its groups, weights, modifiers and place, and the armature gets no child."""
    ob, arm = modal.half_weighted_cylinder(), B.chain()
    B.select_for_parenting([ob], arm)
    before = measures.scene_state(ob)
    seen = {"ticks": []}

    def press_esc_half_way(op, context):
        while not 0.0 < op._job.fraction < 1.0:
            assert modal.tick(op, context, seen, ob) == {"RUNNING_MODAL"}, "done before Esc could be pressed"
            time.sleep(0.001)
        seen["esc at"] = op._job.fraction
        seen["esc"] = op.modal(context, modal.Event("ESC"))
        while True:
            answer = modal.tick(op, context, seen, ob)
            if answer != {"RUNNING_MODAL"}:
                seen["job"] = op._job
                return answer
            time.sleep(0.002)

    driven["script"] = press_esc_half_way
    capfd.readouterr()
    assert bpy.ops.object.miniskeleton_auto_weights() == {"CANCELLED"}
    assert seen["esc"] == {"RUNNING_MODAL"} and 0.0 < seen["esc at"] < 1.0
    job = seen["job"]
    assert job.cancelled and job.result is None and job.error is None and job.fraction < 1.0
    assert "Auto Weights cancelled; nothing was changed" in capfd.readouterr().out
    assert measures.scene_state(ob) == before
    assert [g.name for g in ob.vertex_groups] == ["Keep", "Bone1"] and [m.type for m in ob.modifiers] == ["SMOOTH"]
    assert not arm.children


def test_blender_ending_the_modal_run_stops_the_worker_and_writes_nothing(driven):
    """Blender ends a modal operator itself when another file is opened or the window closes,
    by calling its ``cancel``: the worker stops at its next progress tick and nothing is
    written."""
    ob, arm = modal.half_weighted_cylinder(), B.chain()
    B.select_for_parenting([ob], arm)
    before = measures.scene_state(ob)
    seen = {"ticks": []}

    def cancelled_by_blender(op, context):
        while not 0.0 < op._job.fraction < 1.0:
            assert modal.tick(op, context, seen, ob) == {"RUNNING_MODAL"}, "done before Blender could end it"
            time.sleep(0.001)
        op.cancel(context)
        seen["job"] = op._job
        return {"CANCELLED"}

    driven["script"] = cancelled_by_blender
    assert bpy.ops.object.miniskeleton_auto_weights() == {"CANCELLED"}
    job = seen["job"]
    assert job.wait(60) and job.cancelled and job.result is None and job.error is None
    assert measures.scene_state(ob) == before and not arm.children
