"""Auto Weights' Geodesic Voxel method and Transfer Weights in real Blender: a character in
many pieces bound without repair, Esc, and garments dressed from a skinned body."""

import importlib
import time

import bpy
import numpy as np
import pytest

from testkit import builders as B
from testkit import measures, modal
from testkit.builders import CHAIN_NAMES as NAMES

operators = importlib.import_module("bl_ext.user_default.miniskeleton.weights.operators")


def _box_arrays(lo, hi):
    """A closed box as (verts, quads), wound outward."""
    v = [(hi[0] if k & 1 else lo[0], hi[1] if k & 2 else lo[1], hi[2] if k & 4 else lo[2]) for k in range(8)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return v, faces


def _sleeve(name, radius, z0, z1, segments=24, rings=6):
    """A tube open at both ends around the z axis."""
    verts = [(radius * np.cos(2 * np.pi * s / segments), radius * np.sin(2 * np.pi * s / segments),
              z0 + (z1 - z0) * r / rings) for r in range(rings + 1) for s in range(segments)]
    faces = [(r * segments + s, r * segments + (s + 1) % segments, (r + 1) * segments + (s + 1) % segments,
              (r + 1) * segments + s) for r in range(rings) for s in range(segments)]
    return B.mesh_object(name, verts, faces)


def _sphere(name, radius, location):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=location, segments=12, ring_count=8)
    ob = bpy.context.active_object
    ob.name = name
    return ob


def _dressed_character():
    """A 4-bone cylinder body and, as separate objects: a hat above its top that does not
    touch it, two eyes inside its top, an open sleeve around its middle, and two boxes pushed
    into each other (one object) crossing its bottom."""
    body = B.cylinder(name="Body")
    hat_v, hat_f = _box_arrays((-0.4, -0.4, 4.06), (0.4, 0.4, 4.4))
    hat = B.mesh_object("Hat", hat_v, hat_f)
    eyes = [_sphere(f"Eye{i}", 0.08, (0.3 * s, -0.3, 3.6)) for i, s in enumerate((-1, 1))]
    sleeve = _sleeve("Sleeve", 0.56, 1.6, 2.4)
    a_v, a_f = _box_arrays((-0.7, -0.2, 0.1), (0.7, 0.2, 0.5))
    b_v, b_f = _box_arrays((-0.2, -0.7, 0.2), (0.2, 0.7, 0.7))
    boxes = B.mesh_object("Boxes", a_v + b_v, a_f + [tuple(i + 8 for i in f) for f in b_f])
    return body, hat, eyes, sleeve, boxes


def test_a_character_in_many_pieces_binds_without_repair():
    """Every object weighted, each row summing to 1; the hat and the eyes follow the top bone,
    the crossing boxes the bottom one, and the open sleeve takes the body's weights beneath it."""
    body, hat, eyes, sleeve, boxes = _dressed_character()
    arm = B.chain(count=4)
    meshes = [body, hat, *eyes, sleeve, boxes]
    B.select_for_parenting(meshes, arm)
    assert bpy.ops.object.miniskeleton_auto_weights(method="VOXEL") == {"FINISHED"}
    w = {ob.name: B.weights_matrix(ob, NAMES) for ob in meshes}
    for name, m in w.items():
        np.testing.assert_allclose(m.sum(1), 1.0, atol=1e-5, err_msg=name)
    for name in ("Hat", "Eye0", "Eye1"):
        assert (w[name].argmax(1) == 3).all() and w[name][:, 3].min() > 0.9, name
    assert (w["Boxes"].argmax(1) == 0).mean() > 0.9
    # The sleeve's weights are the body's at the same height (within the blend of a joint).
    sv, bv = measures.world_vertices(sleeve), measures.world_vertices(body)
    nearest = np.abs(sv[:, 2][:, None] - bv[:, 2][None, :]).argmin(1)
    assert np.abs(w["Sleeve"] - w["Body"][nearest]).sum(1).mean() < 0.2
    for ob in meshes:
        assert ob.parent == arm and [m.type for m in ob.modifiers].count("ARMATURE") == 1


def test_voxel_options_reach_the_core():
    """Resolution and Falloff give the core's weights with those arguments, which differ from
    the defaults' on a bent tube (an option dropped on the way would show)."""
    import miniskeleton_core as core

    common_meshes = importlib.import_module("bl_ext.user_default.miniskeleton.common.meshes")
    ob, arm = B.cylinder(), B.chain(count=4)
    heads, tails = B.bone_segments_world(arm, NAMES)
    v, t = measures.world_vertices(ob), common_meshes.mesh_triangles(ob)
    assert B.select_for_parenting([ob], arm) is None
    assert bpy.ops.object.miniskeleton_auto_weights(method="VOXEL", resolution=24, voxel_falloff=0.3) == {"FINISHED"}
    got = B.weights_matrix(ob, NAMES)
    out = core.voxel_weights(v, t, heads, tails, resolution=24, falloff=0.3)
    want = B.dense_weights(out.indices, out.weights, 4)
    np.testing.assert_allclose(got, want, atol=1e-6)
    out = core.voxel_weights(v, t, heads, tails)
    default = B.dense_weights(out.indices, out.weights, 4)
    assert np.abs(default - want).max() > 0.05


def test_esc_stops_a_voxel_run_and_leaves_the_scene_as_it_was(monkeypatch, capfd):
    """Voxel always runs on the worker from the UI (its time follows the solid's volume, not
    the vertex count); Esc half way stops it and writes nothing."""
    def execute(self, context):
        import miniskeleton_core as core

        prepared = self._prepare(context)
        self._start_job(context, core, prepared)
        while not 0.0 < self._job.fraction < 1.0:
            assert modal.tick(self, context, seen, ob) == {"RUNNING_MODAL"}, "done before Esc could be pressed"
            time.sleep(0.001)
        self.modal(context, modal.Event("ESC"))
        while True:
            answer = modal.tick(self, context, seen, ob)
            if answer != {"RUNNING_MODAL"}:
                seen["job"] = self._job
                return answer
            time.sleep(0.002)

    monkeypatch.setattr(operators.MINISKELETON_OT_auto_weights, "execute", execute)
    ob, arm = modal.half_weighted_cylinder(), B.chain()
    B.select_for_parenting([ob], arm)
    before = measures.scene_state(ob)
    seen = {"ticks": []}
    assert bpy.ops.object.miniskeleton_auto_weights(method="VOXEL") == {"CANCELLED"}
    assert seen["job"].cancelled and "cancelled; nothing was changed" in capfd.readouterr().out
    assert measures.scene_state(ob) == before and not arm.children


# ---------------------------------------------------------------- Transfer Weights


def _skinned_body():
    body, arm = B.cylinder(name="Body"), B.chain(count=4)
    B.select_for_parenting([body], arm)
    assert bpy.ops.object.miniskeleton_auto_weights(method="HEAT") == {"FINISHED"}
    return body, arm


def _transfer(garments, body, **options):
    B.set_active(body, [*garments, body])
    return bpy.ops.object.miniskeleton_transfer_weights(**options)


def test_a_sleeve_takes_the_bodys_weights_where_it_lies_on_it(capfd):
    """An open sleeve just over the body: every vertex matches, and its weights are the body's
    at its nearest point; a longer sleeve reaching past the body's side inpaints the rest
    smoothly. The garment gets the Armature modifier and the parent, as Auto Weights writes."""
    body, arm = _skinned_body()
    sleeve = _sleeve("Sleeve", 0.52, 0.8, 3.2, rings=24)
    capfd.readouterr()
    assert _transfer([sleeve], body) == {"FINISHED"}
    assert "took the body's weights" in capfd.readouterr().out
    ws, wb = B.weights_matrix(sleeve, NAMES), B.weights_matrix(body, NAMES)
    np.testing.assert_allclose(ws.sum(1), 1.0, atol=1e-5)
    sv, bv = measures.world_vertices(sleeve), measures.world_vertices(body)
    nearest = np.linalg.norm(sv[:, None] - bv[None], axis=2).argmin(1)
    assert np.abs(ws - wb[nearest]).sum(1).mean() < 0.1
    assert sleeve.parent == arm and [m.type for m in sleeve.modifiers] == ["ARMATURE"]
    # A flared skirt: its hem stands off the body by more than Max Distance and is inpainted.
    skirt = _sleeve("Skirt", 0.52, 0.3, 1.8, rings=12)
    for v in skirt.data.vertices:
        s = max(0.0, 1.0 - v.co.z) * 1.5
        v.co.x *= 1 + s
        v.co.y *= 1 + s
    capfd.readouterr()
    assert _transfer([skirt], body, max_distance=0.03) == {"FINISHED"}
    out = capfd.readouterr().out
    inpainted = int(out.split("took the body's weights, ")[1].split(" were inpainted")[0])
    assert inpainted > 50
    w = B.weights_matrix(skirt, NAMES)
    np.testing.assert_allclose(w.sum(1), 1.0, atol=1e-5)
    assert (w.argmax(1) <= 1).all()  # the hem follows the bottom bones, as the body there


def test_a_prop_and_a_mesh_away_from_the_body_are_bound_directly(capfd):
    """A small box held against the body's side (holds no bone, touches it with a corner) and a
    box far away: both bound with Heat as Auto Weights would, each named in the report."""
    body, arm = _skinned_body()
    # A rod pushed into the body's side by its end (x from 0.45 to 1.45).
    prop = B.cylinder(name="Prop", radius=0.06, height=1.0, rings=10, segments=8, location=(0.45, 0.0, 2.7),
                      rotation=(0.0, np.pi / 2, 0.0))
    fv, ff = _box_arrays((5.0, 5.0, 0.0), (5.5, 5.5, 0.5))
    far = B.mesh_object("Far", fv, ff)
    capfd.readouterr()
    assert _transfer([prop, far], body) == {"FINISHED"}
    out = capfd.readouterr().out
    assert "'Prop': it holds no bone" in out and "'Far': no vertex of it lies on the body" in out
    for ob in (prop, far):
        w = B.weights_matrix(ob, NAMES)
        np.testing.assert_allclose(w.sum(1), 1.0, atol=1e-5)
        assert w.max(1).min() > 0.999  # rigid, as a prop alone under Auto Weights (Heat)


def test_transfer_refuses_an_unweighted_body_and_nothing_selected(capfd):
    body, arm = B.cylinder(name="Body"), B.chain(count=4)
    body.modifiers.new("Armature", "ARMATURE").object = arm
    sleeve = _sleeve("Sleeve", 0.52, 1.0, 2.0)
    with pytest.raises(RuntimeError, match="has no weights in the bones"):
        _transfer([sleeve], body)
    assert len(sleeve.vertex_groups) == 0 and not sleeve.modifiers and sleeve.parent is None
    B.set_active(body, [body])
    with pytest.raises(RuntimeError, match="No garment selected"):
        bpy.ops.object.miniskeleton_transfer_weights()


def test_transfer_does_not_depend_on_the_scale():
    """Max Distance is relative to the body's size: the same garment at any scale (the armature
    and, with it, its child the body scaled, and the garment) gets the same weights."""
    from testkit import blender_session

    seen = {}
    for scale in (1.0, 1e-3, 1e3):
        blender_session.reset_scene()
        body, arm = _skinned_body()
        sleeve = _sleeve("Sleeve", 0.52, 0.8, 3.2, rings=12)
        arm.scale = sleeve.scale = (scale,) * 3
        bpy.context.view_layer.update()
        assert _transfer([sleeve], body) == {"FINISHED"}
        seen[scale] = B.weights_matrix(sleeve, NAMES)
    for scale in (1e-3, 1e3):
        np.testing.assert_allclose(seen[scale], seen[1.0], atol=1e-4, err_msg=f"scale {scale}")
