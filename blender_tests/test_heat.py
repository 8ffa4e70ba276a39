"""Auto Weights (Heat) in Blender: symmetry, locked groups, scale, split seams, pieces."""

import bpy
import numpy as np
import pytest

from testkit import builders as B
from testkit import measures

NAMES = [f"Bone{i}" for i in range(4)]


def bind(meshes, arm, **props):
    B.select_for_parenting(meshes, arm)
    return bpy.ops.object.miniskeleton_auto_weights(method="HEAT", **props)


def legs():
    """Two mirrored leg cylinders joined to nothing, and .L/.R bones inside them."""
    v, f = B.cylinder_arrays(radius=0.35, height=3.0, rings=24, segments=16)
    left = v + np.array([0.8, 0, 0], np.float32)
    right = v * np.array([-1, 1, 1], np.float32) - np.array([0.8, 0, 0], np.float32)
    faces = f + [tuple(len(v) + i for i in reversed(face)) for face in f]
    ob = B.mesh_object("Legs", np.vstack([left, right]), faces)
    arm = B.armature(bones=[
        ("thigh.L", (0.8, 0, 2.8), (0.8, 0, 1.5), None, False),
        ("shin.L", (0.8, 0, 1.5), (0.8, 0, 0.2), "thigh.L", True),
        ("thigh.R", (-0.8, 0, 2.8), (-0.8, 0, 1.5), None, False),
        ("shin.R", (-0.8, 0, 1.5), (-0.8, 0, 0.2), "thigh.R", True),
    ])
    return ob, arm, len(v)


def test_symmetry_x_gives_exactly_mirrored_weights():
    ob, arm, half = legs()
    # Break the symmetry of the input a little: the left shin sits 3 cm off-centre.
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    arm.data.edit_bones["shin.L"].head.x += 0.03
    bpy.ops.object.mode_set(mode="OBJECT")
    names = ["thigh.L", "shin.L", "thigh.R", "shin.R"]
    assert bind([ob], arm, symmetry="X") == {"FINISHED"}
    w = B.weights_matrix(ob, names)
    left, right = w[:half], w[half:]
    np.testing.assert_allclose(left[:, 0], right[:, 2], atol=1e-4)
    np.testing.assert_allclose(left[:, 1], right[:, 3], atol=1e-4)


def test_symmetry_x_pairs_side_bones_whose_names_carry_no_side_by_place(capfd):
    """The legs' bones renamed without a side (thigh.one / thigh.two): by name each is a centre
    bone, and X symmetry averaged each with its own mirror image, so every leg got half of
    each side's bones. Off the plane they are paired by place: the weights of the named rig,
    and the report says so."""
    ob, arm, half = legs()
    assert bind([ob], arm, symmetry="X") == {"FINISHED"}
    named = B.weights_matrix(ob, ["thigh.L", "shin.L", "thigh.R", "shin.R"])
    for b in arm.data.bones:
        b.name = b.name[:-2] + (".one" if b.name.endswith(".L") else ".two")
    capfd.readouterr()
    assert bind([ob], arm, symmetry="X") == {"FINISHED"}
    assert "4 bones off the X = 0 plane have no side in their names" in "".join(capfd.readouterr())
    w = B.weights_matrix(ob, ["thigh.one", "shin.one", "thigh.two", "shin.two"])
    np.testing.assert_allclose(w, named, atol=1e-6)
    assert w[:half, :2].sum(axis=1).min() > 0.99  # the left leg on the left bones only
    # A second pair of legs apart from the first: the note, about the armature, is said once.
    twin = ob.copy()
    twin.data = ob.data.copy()
    twin.location.y += 3.0
    bpy.context.scene.collection.objects.link(twin)
    capfd.readouterr()
    assert bind([ob, twin], arm, symmetry="X") == {"FINISHED"}
    assert "".join(capfd.readouterr()).count("have no side in their names") == 1


def test_symmetry_x_is_the_armatures_x_wherever_the_rig_stands(capfd):
    """X symmetry mirrors across the armature's own x = 0, as Fit does, so a character moved and
    turned in the scene together with its armature keeps exactly mirrored weights; a mesh moved
    off that plane has no mirror twins, and the report says so."""
    from mathutils import Matrix

    ob, arm, half = legs()
    place = Matrix.Translation((2.0, 1.0, 0.5)) @ Matrix.Rotation(0.5, 4, "Z")
    ob.matrix_world = place @ ob.matrix_world
    arm.matrix_world = place @ arm.matrix_world
    names = ["thigh.L", "shin.L", "thigh.R", "shin.R"]
    capfd.readouterr()
    assert bind([ob], arm, symmetry="X") == {"FINISHED"}
    assert "mirror twin" not in "".join(capfd.readouterr())
    w = B.weights_matrix(ob, names)
    left, right = w[:half], w[half:]
    np.testing.assert_allclose(left[:, :2], right[:, 2:], atol=1e-4)
    ob.location.x += 0.31  # the mesh alone leaves the armature's mirror plane
    bpy.context.view_layer.update()
    assert bind([ob], arm, symmetry="X") == {"FINISHED"}
    assert "have a mirror twin across the armature's X = 0 plane" in "".join(capfd.readouterr())


def test_symmetry_x_weights_do_not_depend_on_the_armatures_scale():
    """X symmetry works in the armature's frame (its axes and origin), not in its scaled space:
    an armature object scaled unevenly, or mirrored by a negative scale, with its bones where
    they were in the scene, gives the same weights (in armature space the legs were squashed)."""
    from mathutils import Matrix

    ob, arm, half = legs()
    names = ["thigh.L", "shin.L", "thigh.R", "shin.R"]
    assert bind([ob], arm, symmetry="X") == {"FINISHED"}
    reference = B.weights_matrix(ob, names)
    for scale in ((2.0, 1.0, 0.5), (-1.0, 1.0, 1.0)):
        B.place_armature_keep_bones(arm, Matrix.Diagonal((*scale, 1.0)))
        assert bind([ob], arm, symmetry="X") == {"FINISHED"}
        np.testing.assert_allclose(B.weights_matrix(ob, names), reference, atol=1e-4, err_msg=str(scale))


def test_locked_group_is_not_changed_and_is_named(capfd):
    ob = B.cylinder()
    arm = B.chain()
    locked = ob.vertex_groups.new(name="Bone0")
    locked.add([0, 1, 2], 0.123, "REPLACE")
    locked.lock_weight = True
    capfd.readouterr()
    assert bind([ob], arm) == {"FINISHED"}
    assert "locked groups kept: Bone0" in "".join(capfd.readouterr())
    g = ob.vertex_groups["Bone0"]
    got = {v.index: x.weight for v in ob.data.vertices for x in v.groups if x.group == g.index}
    assert got == pytest.approx({0: 0.123, 1: 0.123, 2: 0.123})
    assert {"Bone1", "Bone2", "Bone3"} <= {g.name for g in ob.vertex_groups}


@pytest.mark.parametrize("scale", [1e-3, 1e3])
def test_scene_scale_does_not_change_weights(scale):
    ob = B.cylinder()
    arm = B.chain()
    bind([ob], arm)
    reference = B.weights_matrix(ob, NAMES)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.preferences.addon_enable(module="bl_ext.user_default.miniskeleton")
    s = (scale,) * 3
    ob = B.cylinder(scale=s)
    arm = B.chain(scale=s)
    assert bind([ob], arm) == {"FINISHED"}
    np.testing.assert_allclose(B.weights_matrix(ob, NAMES), reference, atol=1e-4)


def test_a_stray_vertex_far_away_changes_no_weight():
    """A loose vertex left 1e5 away (no face uses it) gets its nearest bone, and the surface's
    weights are those without it: tolerances follow the surface's size, not every vertex's."""
    ob = B.cylinder()
    arm = B.chain()
    bind([ob], arm)
    reference = B.weights_matrix(ob, NAMES)
    n = len(ob.data.vertices)
    ob.data.vertices.add(1)
    ob.data.vertices[n].co = (1e5, 0.0, 0.0)
    assert bind([ob], arm) == {"FINISHED"}
    w = B.weights_matrix(ob, NAMES)
    np.testing.assert_allclose(w[:n], reference, atol=1e-5)
    assert w[n].sum() == pytest.approx(1.0, abs=1e-6)


def test_a_stray_vertex_does_not_join_a_sleeve_to_the_body():
    """A sleeve just outside the body (another object) is solved on its own, as clothes are; a
    loose vertex left far away in the body must not widen the seam test until the sleeve
    counts as touching the body (it then was solved with the body in the way of its rays)."""
    body = B.cylinder("Body")
    sleeve = B.cylinder("Sleeve", radius=0.51, height=2.0, rings=20)
    arm = B.chain()
    bind([body, sleeve], arm)
    reference = [B.weights_matrix(ob, NAMES) for ob in (body, sleeve)]
    n = len(body.data.vertices)
    body.data.vertices.add(1)
    body.data.vertices[n].co = (1e5, 0.0, 0.0)
    assert bind([body, sleeve], arm) == {"FINISHED"}
    np.testing.assert_allclose(B.weights_matrix(body, NAMES)[:n], reference[0], atol=1e-5)
    np.testing.assert_allclose(B.weights_matrix(sleeve, NAMES), reference[1], atol=1e-5)


def test_flipped_faces_change_no_weight_and_are_reported(capfd):
    """Faces of the upper half turned inside out (flipped normals, as after joining a mirrored
    part): the weights are those of the clean mesh, the report says how many triangles were wound
    against their neighbours, and the mesh itself keeps its (flipped) faces."""
    ob = B.cylinder()
    arm = B.chain()
    bind([ob], arm)
    reference = B.weights_matrix(ob, NAMES)
    flipped = [p for p in ob.data.polygons if p.center.z > 2.0]
    for p in flipped:
        p.flip()
    before = [tuple(p.vertices) for p in ob.data.polygons]
    ob.data.calc_loop_triangles()
    tris = sum(len(p.vertices) - 2 for p in flipped)
    capfd.readouterr()
    assert bind([ob], arm) == {"FINISHED"}
    np.testing.assert_allclose(B.weights_matrix(ob, NAMES), reference, atol=1e-5)
    assert f"{tris} triangles are wound against their neighbours" in "".join(capfd.readouterr())
    assert [tuple(p.vertices) for p in ob.data.polygons] == before


def test_mirrored_object_negative_scale_gets_the_weights_of_its_twin(capfd):
    """An object mirrored by a negative scale (Ctrl+M, or a scale of -1 to make the other side)
    has every face inside out in world space. Its weights are those of the unmirrored twin (the
    cylinder is symmetric, so vertex i lands on a twin's vertex), and no face is reported as
    flipped. Measured: Blender's Ctrl+P changes by L1 1.28 on average here."""
    ob = B.cylinder()
    arm = B.chain()
    bind([ob], arm)
    reference = B.weights_matrix(ob, NAMES)
    for scale in ((-1, 1, 1), (1, -1, 1), (-1, -1, -1)):
        mirrored = B.cylinder("Mirrored", scale=scale, location=(0, 0, 4.0 if scale[2] < 0 else 0))
        capfd.readouterr()
        assert bind([mirrored], arm) == {"FINISHED"}
        np.testing.assert_allclose(B.weights_matrix(mirrored, NAMES)[:, ::int(np.sign(scale[2]))],
                                   reference, atol=1e-5)
        assert "wound against" not in "".join(capfd.readouterr())
        bpy.data.objects.remove(mirrored)


def test_split_seams_weighted_like_welded_twin():
    welded = B.cylinder("Welded")
    arm = B.chain()
    bind([welded], arm)
    w_welded = B.weights_matrix(welded, NAMES)
    # Flat-shaded twin: every face has its own vertices (like a glTF/FBX import).
    verts, faces = B.cylinder_arrays()
    split_v, split_f, origin = [], [], []
    for face in faces:
        split_f.append(tuple(range(len(split_v), len(split_v) + len(face))))
        split_v += [verts[i] for i in face]
        origin += list(face)
    split = B.mesh_object("Split", np.array(split_v), split_f)
    bind([split], arm)
    np.testing.assert_allclose(B.weights_matrix(split, NAMES), w_welded[origin], atol=1e-4)


def test_a_prop_that_sees_its_bones_is_reported_as_bound_rigidly(capfd):
    """A mesh that is only a prop beside the chain (no bone inside it, every vertex sees one) is
    bound rigidly by rule; the report says so although no piece fell back."""
    v, f = B.cylinder_arrays(radius=0.15, height=0.3, rings=2, segments=8)
    ob = B.mesh_object("Prop", v + [0.6, 0, 1.9], f)
    arm = B.chain()
    capfd.readouterr()
    assert bind([ob], arm) == {"FINISHED"}
    assert "Prop: of 1 pieces, 0 saw no bone (nearest bone used), 1 bound rigidly" in capfd.readouterr().out
    w = B.weights_matrix(ob, NAMES)
    assert (w.max(axis=0) > 0).sum() == 1 and (w.max(axis=1) == 1.0).all()


def test_sealed_piece_is_weighted_rigidly_where_blender_writes_nothing(capfd):
    # A body with bones, a closed shell beside it, and a button sealed inside the shell:
    # no ray from the button reaches a bone, so Blender's heat is singular there.
    body_v, body_f = B.cylinder_arrays()
    shell_v, shell_f = B.cylinder_arrays(radius=1.2, height=3.0, rings=12, segments=16)
    button_v, button_f = B.cylinder_arrays(radius=0.15, height=0.3, rings=2, segments=8)
    parts = [(body_v, body_f), (shell_v + [4, 0, 0.5], shell_f), (button_v + [4, 0, 2.3], button_f)]
    verts, faces, off = [], [], 0
    for v, f in parts:
        verts.append(v)
        faces += [tuple(i + off for i in face) for face in f]
        off += len(v)
    ob = B.mesh_object("Pieces", np.vstack(verts), faces)
    arm = B.chain()
    capfd.readouterr()
    assert bind([ob], arm) == {"FINISHED"}
    # the shell and the button see no bone; the button, small and with no bone inside, is rigid
    assert "Pieces: of 3 pieces, 2 saw no bone (nearest bone used), 1 bound rigidly" in capfd.readouterr().out
    w = B.weights_matrix(ob, NAMES)
    assert (w.sum(1) > 0.999).all()
    button = w[len(body_v) + len(shell_v):]
    assert (button.max(1) == 1.0).all() and len(set(button.argmax(1))) == 1


def test_a_coat_joined_into_the_body_follows_the_body_beneath_it():
    """Clothes joined into a character's mesh: the creature's body and a coat over it (the
    body's surface pushed out by 2 % of its size, in the same object). The body hides every
    bone from the coat except where a bone's end pokes out of it (hands, feet, tail tip), and
    heat from those few vertices bound the whole coat to them: its weights differed from the
    body's beneath by 1.36 (L1, of 2 at most; Blender's Ctrl+P: 1.30). Now the coat looks
    through itself for the bones it holds, as it would alone."""
    import bmesh
    from testkit import creature

    body, arm = creature.build()
    names = [b.name for b in arm.data.bones if b.use_deform]
    me = body.data
    n = len(me.vertices)
    bm = bmesh.new()
    bm.from_mesh(me)
    size = max(body.dimensions)
    coat = [v.co + v.normal * 0.02 * size for v in bm.verts]
    bmesh.ops.duplicate(bm, geom=bm.verts[:] + bm.edges[:] + bm.faces[:])
    bm.verts.ensure_lookup_table()
    for i, co in enumerate(coat):
        bm.verts[n + i].co = co
    bm.to_mesh(me)
    bm.free()
    assert len(me.vertices) == 2 * n
    assert bind([body], arm) == {"FINISHED"}
    w = B.weights_matrix(body, names)
    np.testing.assert_allclose(w.sum(1), 1, atol=1e-5)
    beneath, over = w[:n], w[n:]
    l1 = np.abs(over - beneath).sum(1)
    assert l1.mean() < 0.3, l1.mean()
    assert (over.argmax(1) == beneath.argmax(1)).mean() > 0.85


def imported_style_rig(connected):
    """A cylinder and a glTF-import-style chain: each tail a short sideways stub (the importer
    invents tails), each child starting 1.2 higher, nothing connected. ``connected``: a rig
    built in Blender instead, whose first bone reaches and connects to the second (the
    second's tail is still a stub)."""
    ob = B.cylinder(radius=0.2, height=4.0, rings=40, segments=16)
    zs = [0.2, 1.4, 2.6]
    bones = []
    for i, z in enumerate(zs):
        tail = (0.1, 0, z) if i + 1 < len(zs) else (0, 0, 3.8)
        if connected and i == 0:
            tail = (0, 0, zs[1])
        bones.append((f"Bone{i}", (0, 0, z), tail, f"Bone{i-1}" if i else None, connected and i == 1))
    return ob, B.armature(bones=bones)


def test_bone_extent_auto_reaches_children_on_imported_rigs_only():
    names = ["Bone0", "Bone1", "Bone2"]
    ob, arm = imported_style_rig(connected=False)
    z = measures.world_vertices(ob)[:, 2]
    mid = (z > 0.6) & (z < 1.0)  # between Bone0's head and its child's
    assert bind([ob], arm) == {"FINISHED"}  # Auto on a rig with nothing connected: To Children
    auto = B.weights_matrix(ob, names)
    assert bind([ob], arm, bone_extent="TAIL") == {"FINISHED"}
    tail = B.weights_matrix(ob, names)
    assert auto[mid, 0].mean() > 0.9 > tail[mid, 0].mean()
    assert bind([ob], arm, bone_extent="CHILDREN") == {"FINISHED"}
    np.testing.assert_allclose(B.weights_matrix(ob, names), auto, atol=1e-6)
    # A rig built in Blender (something connected): Auto is head -> tail, as in Blender, even
    # where a child starts away from its parent's tail (Bone1 -> Bone2).
    ob2, arm2 = imported_style_rig(connected=True)
    z2 = measures.world_vertices(ob2)[:, 2]
    mid2 = (z2 > 1.8) & (z2 < 2.2)  # between Bone1's head and Bone2's
    assert bind([ob2], arm2) == {"FINISHED"}
    auto2 = B.weights_matrix(ob2, names)
    assert bind([ob2], arm2, bone_extent="TAIL") == {"FINISHED"}
    np.testing.assert_allclose(B.weights_matrix(ob2, names), auto2, atol=1e-6)
    assert bind([ob2], arm2, bone_extent="CHILDREN") == {"FINISHED"}
    assert B.weights_matrix(ob2, names)[mid2, 1].mean() > 0.9 > auto2[mid2, 1].mean()


def split_in_two(body, axis, cut):
    """Two mesh objects made of ``body``'s faces on either side of a plane; both keep the edge
    loop along the cut, as after Separate on a character's neck or waist."""
    import bmesh

    parts = []
    for low in (True, False):
        ob = body.copy()
        ob.data = body.data.copy()
        ob.name = body.name + (".low" if low else ".high")
        bpy.context.scene.collection.objects.link(ob)
        bm = bmesh.new()
        bm.from_mesh(ob.data)
        bmesh.ops.delete(bm, geom=[f for f in bm.faces if (f.calc_center_median()[axis] > cut) == low],
                         context="FACES")
        bm.to_mesh(ob.data)
        bm.free()
        parts.append(ob)
    return parts


@pytest.mark.parametrize("axis", [1, 2])
def test_a_character_split_into_objects_is_weighted_as_one_surface(axis):
    """The creature separated into two objects across its body: the two copies of every seam
    vertex get the same weights (Blender's per-object solve gives them unrelated ones, L1 up
    to 1.26: a crack when posed), and every vertex gets the weights of the unsplit creature.
    A third object, a 2 % wider copy around the whole creature (a garment) sharing no vertex,
    is weighted on its own: had it joined the others, its shell would hide their bones."""
    from testkit import creature

    body, arm = creature.build()
    names = [b.name for b in arm.data.bones if b.use_deform]
    assert bind([body], arm) == {"FINISHED"}
    co = measures.world_vertices(body)
    whole = {tuple(np.round(p, 5)): w for p, w in zip(co, B.weights_matrix(body, names))}
    cut = float(np.median(co[:, axis]))
    parts = split_in_two(body, axis, cut)
    for p in parts:
        p.vertex_groups.clear()
    sleeve = body.copy()
    sleeve.data = body.data.copy()
    sleeve.vertex_groups.clear()
    sleeve.scale = (1.02, 1.02, 1.0)
    bpy.context.scene.collection.objects.link(sleeve)
    bpy.data.objects.remove(body)
    bpy.context.view_layer.update()
    assert bind(parts + [sleeve], arm) == {"FINISHED"}
    seen = {}
    for p in parts:
        for q, w in zip(measures.world_vertices(p), B.weights_matrix(p, names)):
            key = tuple(np.round(q, 5))
            assert np.abs(w - whole[key]).max() < 1e-4, (p.name, q)
            if key in seen:
                assert np.abs(w - seen[key]).max() < 1e-6
            seen[key] = w
    assert len(seen) < sum(len(p.data.vertices) for p in parts)  # there was a seam
    w = B.weights_matrix(sleeve, names)
    assert np.allclose(w.sum(axis=1), 1, atol=1e-4)


def _weight_paint_reassign(assign, mirror):
    """Bind the legs, paint every group 0.3, then in Weight Paint mode with only shin.L
    selected re-assign with ``assign``: (weights after, weights of the first bind, painted)."""
    ob, arm, _ = legs()
    names = ["thigh.L", "shin.L", "thigh.R", "shin.R"]
    bind([ob], arm)
    full = B.weights_matrix(ob, names)
    for name in names:
        ob.vertex_groups[name].add(list(range(len(ob.data.vertices))), 0.3, "REPLACE")
    B.pose_select(arm, selected=("shin.L",))
    B.set_active(ob, selected=[arm])
    ob.data.use_mirror_x = mirror
    bpy.ops.object.mode_set(mode="WEIGHT_PAINT")
    assert assign() == {"FINISHED"}
    after = B.weights_matrix(ob, names)
    bpy.ops.object.mode_set(mode="OBJECT")
    return after, full, float(np.float32(0.3))


@pytest.mark.parametrize("mirror", [False, True])
def test_weight_paint_x_mirror_writes_the_selected_bones_partners_too(mirror):
    """Weight Paint with X Mirror on: Blender's Assign Automatic from Bones with shin.L selected
    writes shin.R as well (measured in bpy 5.0); ours does too, each bone with its own weights,
    which here are those of a full bind. Before, only shin.L was written."""
    changed = {}
    for who, assign in (("blender", lambda: bpy.ops.paint.weight_from_bones(type="AUTOMATIC")),
                        ("ours", lambda: bpy.ops.object.miniskeleton_auto_weights(method="HEAT"))):
        after, full, painted = _weight_paint_reassign(assign, mirror)
        changed[who] = (after != painted).any(axis=0).tolist()
    written = [False, True, False, mirror]  # thigh.L, shin.L, thigh.R, shin.R
    assert changed == {"blender": written, "ours": written}
    np.testing.assert_allclose(after[:, written], full[:, written], atol=1e-6)
