"""The weights API of miniskeleton_core from plain Python: shapes, dtypes, invariants, errors."""

import numpy as np
import pytest

import miniskeleton_core as msc


@pytest.fixture(scope="module")
def cyl():
    v, t = msc.capped_cylinder(0.5, 4.0, 40, 24)
    h, tl, p = msc.bone_chain(4.0, 4)
    return v, t, h, tl, p


def check_influences(idx, w, n, k, bones):
    assert idx.shape == (n, k) and w.shape == (n, k)
    assert idx.dtype == np.int32 and w.dtype == np.float32
    np.testing.assert_allclose(w.sum(1), 1.0, atol=1e-5)
    assert (w >= 0).all()
    assert ((idx >= 0) | (w == 0)).all()  # unused slots carry weight 0
    assert idx.max() < bones


def dense(idx, w, b):
    out = np.zeros((len(idx), b))
    for j in range(idx.shape[1]):
        ok = idx[:, j] >= 0
        out[np.nonzero(ok)[0], idx[ok, j]] += w[ok, j]
    return out


def test_generated_cylinder_and_chain(cyl):
    v, t, h, tl, p = cyl
    assert v.dtype == np.float32 and v.shape[1] == 3 and t.dtype == np.uint32
    assert v[:, 2].min() == pytest.approx(0) and v[:, 2].max() == pytest.approx(4)
    assert list(p) == [-1, 0, 1, 2]
    np.testing.assert_allclose(tl[:-1], h[1:])  # connected chain


@pytest.mark.parametrize("fn", ["idw", "bilinear", "heat"])
def test_rows_sum_to_one_and_nearest_bone_wins(cyl, fn):
    v, t, h, tl, p = cyl
    if fn == "idw":
        idx, w = msc.idw_weights(v, h, tl, max_influences=3)
    elif fn == "bilinear":
        idx, w = msc.bilinear_weights(v, h, tl, p, max_influences=3)
    else:
        idx, w = msc.heat_weights(v, t, h, tl, max_influences=3)
    check_influences(idx, w, len(v), 3, len(h))
    # nearest bone: along the axis, by height
    z = v[:, 2]
    joints = np.append(h[:, 2], tl[-1, 2])
    inner = np.array([np.min(np.abs(zz - joints)) > 0.3 for zz in z])
    expected = np.clip(np.searchsorted(joints, z) - 1, 0, len(h) - 1)
    assert inner.sum() > 100
    assert (dense(idx, w, 4)[inner].argmax(1) == expected[inner]).all()


def test_float64_and_lists_accepted(cyl):
    v, t, h, tl, p = cyl
    idx, w = msc.idw_weights(v.astype(np.float64), h.tolist(), tl.tolist())
    assert idx.shape == (len(v), 4)


def pieces_mesh(pieces):
    verts, tris, off = [], [], 0
    for pv, pt in pieces:
        verts.append(pv)
        tris.append(pt + off)
        off += len(pv)
    return np.vstack(verts).astype(np.float32), np.vstack(tris)


def test_heat_two_pieces_all_weighted_and_report(cyl):
    v, t, h, tl, p = cyl
    v2, t2 = pieces_mesh([(v, t), (v + [5, 0, 0], t)])  # a twin cylinder with no bone inside
    out = msc.heat_weights_report(v2, t2, h, tl)
    idx, w, report = out.indices, out.weights, out.report
    check_influences(idx, w, len(v2), 4, len(h))
    assert report.pieces == 2


def test_heat_many_meshes_in_one_call_match_one_call_each(cyl):
    """Independent meshes in one call get what one call each gives them (options included); a
    bad mesh gets its own exception back and the others still get their weights."""
    v, t, h, tl, p = cyl
    meshes = [(v * 0.3 + [0.0, 0.0, z], t) for z in (0.0, 1.2, 2.4, 3.6)] + [(v, t)]
    opts = dict(max_influences=3, parents=p, bone_mirror=np.arange(len(h), dtype=np.int32))
    many = msc.heat_weights_many(meshes, h, tl, **opts)
    assert len(many) == len(meshes)
    for (mv, mt), got in zip(meshes, many):
        one = msc.heat_weights_report(mv, mt, h, tl, **opts)
        assert isinstance(got, msc.Weights) and isinstance(got.report, msc.WeightsReport)
        assert np.array_equal(got.indices, one.indices) and np.array_equal(got.weights, one.weights)
        assert got.report.pieces == one.report.pieces and set(got.report.timings) == set(one.report.timings)
    bad = list(meshes)
    bad[1] = (meshes[1][0], np.full_like(t, 10_000))
    bad[3] = (np.full_like(v, np.nan), t)
    out = msc.heat_weights_many(bad, h, tl, **opts)
    assert isinstance(out[1], ValueError) and "10000" in str(out[1])
    assert isinstance(out[3], ValueError) and "NaN" in str(out[3])
    for k in (0, 2, 4):
        assert np.array_equal(out[k].indices, many[k].indices) and np.array_equal(out[k].weights, many[k].weights)
    assert msc.heat_weights_many([], h, tl) == []
    with pytest.raises(ValueError, match="max_influences"):
        msc.heat_weights_many(meshes, h, tl, max_influences=0)


HEAT_DEFAULTS = dict(max_influences=4, min_weight=1e-3, visibility=True, weld_tolerance=1e-5, heat_constant=1.0,
                     bone_mirror=None, symmetry_axis=0, symmetry_tolerance=1e-3, parents=None, curve_points=None,
                     curve_bones=None)


def test_heat_keywords_default_as_documented_and_unknown_ones_are_type_errors(cyl):
    """Each heat keyword's default is what passing it explicitly gives (the core's defaults,
    written once); a keyword the functions do not know is a TypeError naming it, as Python's."""
    v, t, h, tl, p = cyl
    out = msc.heat_weights_report(v, t, h, tl)
    i0, w0 = out.indices, out.weights
    for key, value in HEAT_DEFAULTS.items():
        out = msc.heat_weights_report(v, t, h, tl, **{key: value})
        i, w = out.indices, out.weights
        assert np.array_equal(i, i0) and np.array_equal(w, w0), key
    i, w = msc.heat_weights(v, t, h, tl, **HEAT_DEFAULTS)
    assert np.array_equal(i, i0) and np.array_equal(w, w0)
    got, = msc.heat_weights_many([(v, t)], h, tl, **HEAT_DEFAULTS)
    i, w = got.indices, got.weights
    assert np.array_equal(i, i0) and np.array_equal(w, w0)
    # symmetry_tolerance is the core's mirror tolerance: on a mesh moved 0.01 off the plane (its
    # twins 0.5 % of its size apart), the default matches none of them and 1 % matches all.
    off = (v + np.float32([0.01, 0, 0]), t, h, tl)
    mirror = np.arange(len(h))
    tight = msc.heat_weights_report(*off, bone_mirror=mirror).report.mirrored_vertices
    loose = msc.heat_weights_report(*off, bone_mirror=mirror, symmetry_tolerance=0.01).report.mirrored_vertices
    assert (tight, loose) == (0, len(v))
    for fn, args in ((msc.heat_weights, (v, t, h, tl)), (msc.heat_weights_report, (v, t, h, tl)),
                     (msc.heat_weights_many, ([(v, t)], h, tl)), (msc.heat_sources, (v, t, h, tl))):
        with pytest.raises(TypeError, match=rf"{fn.__name__}\(\) got an unexpected keyword argument 'max_influence'"):
            fn(*args, max_influence=2)
    with pytest.raises(TypeError, match="unexpected keyword argument 'progress'"):
        msc.heat_weights_many([(v, t)], h, tl, progress=print)
    with pytest.raises(TypeError, match="argument 'visibility'"):
        msc.heat_weights(v, t, h, tl, visibility="yes")
    with pytest.raises(TypeError, match="argument 'heat_constant'"):
        msc.heat_weights(v, t, h, tl, heat_constant=None)


def test_heat_from_its_own_sources_is_heat_itself(cyl):
    """The debug entry points: heat with the sources heat finds, given back, is heat bit for bit
    (split seams, symmetry and imported bones included); other sources move the weights."""
    v, t, h, tl, p = cyl
    sv, st = msc.split_flat(v, t)
    for verts, tris, opts in ((v, t, {}), (sv, st, {}), (v, t, dict(bone_mirror=np.arange(len(h)), parents=p)),
                              (v, t, dict(visibility=False, max_influences=2))):
        si, sw = msc.heat_sources(verts, tris, h, tl, **opts)
        assert si.shape == sw.shape == (len(verts), 4) and si.dtype == np.int32 and sw.dtype == np.float32
        assert ((si[:, 0] >= 0) & (np.abs(sw.sum(1) - 1) < 1e-6)).all()
        out = msc.heat_weights_report(verts, tris, h, tl, **opts)
        i0, w0, r0 = out.indices, out.weights, out.report
        out = msc.heat_weights_from_sources(verts, tris, h, tl, si, sw, **opts)
        i, w, r = out.indices, out.weights, out.report
        assert np.array_equal(i, i0) and np.array_equal(w, w0)
        assert set(r.timings) == set(r0.timings) and r.pieces == r0.pieces
    # Every vertex a source of bone 3: bone 3 everywhere.
    out = msc.heat_weights_from_sources(v, t, h, tl, np.full((len(v), 1), 3), np.ones((len(v), 1)))
    i, w, _ = out.indices, out.weights, out.report
    assert (i[:, 0] == 3).all() and (w[:, 0] == 1).all()
    with pytest.raises(ValueError, match="one shape"):
        msc.heat_weights_from_sources(v, t, h, tl, np.zeros((len(v), 2)), np.ones((len(v), 1)))
    with pytest.raises(ValueError, match="sources for"):
        msc.heat_weights_from_sources(v, t, h, tl, np.zeros((3, 1)), np.ones((3, 1)))
    with pytest.raises(ValueError, match="source bone 4"):
        msc.heat_weights_from_sources(v, t, h, tl, np.full((len(v), 1), 4), np.ones((len(v), 1)))


def test_heat_small_boneless_piece_is_rigid_on_nearest_bone(cyl):
    # An accessory (button, eye, held prop) with no bone inside moves as one rigid body.
    v, t, h, tl, p = cyl
    sv, st = msc.capped_cylinder(0.25, 1.0, 8, 12)
    verts, tris = pieces_mesh([(v, t), (sv + [3, 0, 2.0], st)])  # centre z = 2.5: Bone2's middle
    for visibility in (True, False):  # the inside tests need rays without the visibility test too
        out = msc.heat_weights_report(verts, tris, h, tl, visibility=visibility)
        idx, w, report = out.indices, out.weights, out.report
        check_influences(idx, w, len(verts), 4, len(h))
        assert report.rigid_pieces == 1 and report.boneless_pieces >= 1, visibility
        part = slice(len(v), None)
        assert (w[part, 0] == 1).all() and set(idx[part, 0]) == {2}
        # the body itself is still smoothly blended
        assert (w[: len(v), 1] > 0.05).sum() > 50


def test_heat_piece_that_sees_no_bone_falls_back_rigidly(cyl):
    # A small part sealed inside a closed shell far from the bones: every ray to a bone is
    # blocked by the shell, the case where Blender's heat goes singular and writes nothing.
    v, t, h, tl, p = cyl
    shell_v, shell_t = msc.capped_cylinder(1.5, 4.0, 20, 24)
    part_v, part_t = msc.capped_cylinder(0.2, 0.5, 4, 8)
    verts, tris = pieces_mesh([(v, t), (shell_v + [6, 0, 0], shell_t), (part_v + [6, 0, 2.25], part_t)])
    out = msc.heat_weights_report(verts, tris, h, tl)
    idx, w, report = out.indices, out.weights, out.report
    check_influences(idx, w, len(verts), 4, len(h))
    assert report.pieces == 3
    assert report.fallback_pieces >= 1 and report.rigid_pieces == 1
    part = slice(len(v) + len(shell_v), None)
    assert (w[part, 0] == 1).all() and set(idx[part, 0]) == {2}  # centre z = 2.5: Bone2


def test_heat_split_flat_matches_welded(cyl):
    v, t, h, tl, p = cyl
    sv, st = msc.split_flat(v, t)
    assert len(sv) == 3 * len(t)
    i1, w1 = msc.heat_weights(v, t, h, tl)
    i2, w2 = msc.heat_weights(sv, st, h, tl)
    d1, d2 = dense(i1, w1, 4), dense(i2, w2, 4)
    np.testing.assert_allclose(d2, d1[t.reshape(-1)], atol=1e-4)


@pytest.mark.parametrize("s", [1e-3, 1e3])
def test_heat_scale_free(cyl, s):
    v, t, h, tl, p = cyl
    d1 = dense(*msc.heat_weights(v, t, h, tl), 4)
    d2 = dense(*msc.heat_weights(v * s, t, h * s, tl * s), 4)
    np.testing.assert_allclose(d2, d1, atol=1e-4)


def test_progress_callback_and_cancel(cyl):
    v, t, h, tl, p = cyl
    seen = []
    msc.heat_weights(v, t, h, tl, progress=lambda f: seen.append(f))
    assert seen and 0 <= min(seen) and max(seen) <= 1.0
    with pytest.raises(msc.Cancelled):
        msc.heat_weights(v, t, h, tl, progress=lambda f: False)


def test_a_failing_progress_callback_raises_its_own_error(cyl):
    """A bug in the caller's callback stops the solve and surfaces as itself (with its
    traceback), not as a cancel; a callback that cannot be called is a TypeError up front."""
    v, t, h, tl, p = cyl

    def broken(f):
        raise KeyError("from the callback")

    with pytest.raises(KeyError, match="from the callback"):
        msc.heat_weights(v, t, h, tl, progress=broken)
    with pytest.raises(TypeError, match="callable"):
        msc.heat_weights(v, t, h, tl, progress=3)


@pytest.mark.parametrize("fn", ["idw", "bilinear", "heat"])
def test_more_influences_than_bones_gives_one_column_per_bone(cyl, fn):
    """k = min(max_influences, bones): an absurd max_influences is not an allocation of
    n x 2^40 slots (which aborted the process), just every bone."""
    v, t, h, tl, p = cyl
    call = {"idw": lambda k: msc.idw_weights(v, h, tl, max_influences=k),
            "bilinear": lambda k: msc.bilinear_weights(v, h, tl, p, max_influences=k),
            "heat": lambda k: msc.heat_weights(v, t, h, tl, max_influences=k)}[fn]
    idx, w = call(2**40)
    check_influences(idx, w, len(v), len(h), len(h))
    i4, w4 = call(len(h))
    np.testing.assert_array_equal(idx, i4)
    np.testing.assert_array_equal(w, w4)


def test_bad_inputs_raise_clear_errors(cyl):
    v, t, h, tl, p = cyl
    bad = v.copy()
    bad[[3, 8, 9]] = np.nan
    with pytest.raises(ValueError, match="3 vertex"):
        msc.heat_weights(bad, t, h, tl)
    with pytest.raises(ValueError, match="3 vertex"):
        msc.idw_weights(bad, h, tl)
    with pytest.raises(ValueError):
        msc.heat_weights(v, t + len(v), h, tl)  # indices out of range
    # Negative or huge indices are named as given (cast to u32, -1 read as 4294967295 and
    # 2^32 + i wrapped round to i, a valid index).
    neg = t.astype(np.int64)
    neg[5, 1] = -1
    with pytest.raises(ValueError, match=r"triangles\[5, 1\] is -1"):
        msc.heat_weights(v, neg, h, tl)
    with pytest.raises(ValueError, match=r"triangles\[0, 0\] is 4294967296"):
        msc.heat_weights(v, t.astype(np.int64) + 2**32, h, tl)
    with pytest.raises(ValueError, match=r"triangles\[5, 1\] is -1"):
        msc.fit_joints(v, neg, (h + tl) / 2, np.array([[0, 1]], np.uint32))
    with pytest.raises(ValueError, match="shape"):
        msc.idw_weights(v[:, :2], h, tl)
    with pytest.raises(ValueError, match="shape"):   # (n, 4), e.g. homogeneous: not cut to 3
        msc.heat_weights(np.c_[v, np.ones(len(v), np.float32)], t, h, tl)
    with pytest.raises(ValueError):
        msc.heat_weights(v, t, h[:0], tl[:0])  # no bones
    with pytest.raises(ValueError, match="max_influences"):
        msc.idw_weights(v, h, tl, max_influences=0)
    with pytest.raises(ValueError, match="nearest"):
        msc.bilinear_weights(v, h, tl, nearest=0)
    mirror = np.arange(len(h))
    for axis in (3, -1):
        with pytest.raises((ValueError, OverflowError), match="symmetry_axis|negative"):
            msc.heat_weights(v, t, h, tl, bone_mirror=mirror, symmetry_axis=axis)
    with pytest.raises(ValueError, match="go together"):
        msc.heat_weights(v, t, h, tl, curve_points=v[:2])
    with pytest.raises(ValueError):
        msc.heat_weights(v[:0], t[:0], h, tl)  # empty mesh
    # Sizes that would not fit in memory are refused before anything is allocated.
    with pytest.raises(ValueError, match="rings must be at most"):
        msc.capped_cylinder(rings=10**12)
    with pytest.raises(ValueError, match="bones must be at most"):
        msc.bone_chain(bones=10**12)
    with pytest.raises(ValueError, match="meshes"):
        msc.touching_meshes(v, np.zeros(len(v), np.uint32), 10**12)


def test_index_arrays_must_hold_whole_numbers_in_range(cyl):
    """numpy would cast a float index 1.7 to 1, and int64 -1 or 2^32 + 1 into a valid index."""
    v, t, h, tl, p = cyl
    frac = t.astype(np.float64)
    frac[5, 1] += 0.7
    with pytest.raises(ValueError, match=r"triangles\[5, 1\] is .*\.7: indices must be whole"):
        msc.heat_weights(v, frac, h, tl)
    with pytest.raises(ValueError, match=r"triangles\[5, 1\] is NaN"):
        msc.touching_meshes(v, np.zeros(len(v)), 1, triangles=np.where(frac % 1, np.nan, frac))
    idx, w = msc.heat_weights(v, t.astype(np.float64), h, tl)  # whole floats are indices
    i0, w0 = msc.heat_weights(v, t, h, tl)
    np.testing.assert_array_equal(idx, i0)
    np.testing.assert_array_equal(w, w0)
    for name, value in [("parents", [-1, 0, 1.5, 2]), ("parents", [-1, 0, 2**32 + 1, 2]),
                        ("bone_mirror", [0.5, 1, 2, 3])]:
        with pytest.raises(ValueError, match=rf"{name}\[\d\] is "):
            msc.heat_weights(v, t, h, tl, **{name: np.array(value)})
    with pytest.raises(ValueError, match=r"parents\[2\] is 1.5"):
        msc.bilinear_weights(v, h, tl, [-1, 0, 1.5, 2])
    with pytest.raises(ValueError, match=r"parents\[1\] is 0.5"):
        msc.detect_roles(h, tl, [-1, 0.5, 1, 2])
    with pytest.raises(ValueError, match=r"mesh_of\[0\] is -1"):
        msc.touching_meshes(v, np.full(len(v), -1), 1)
    with pytest.raises(ValueError, match=r"face_sizes\[1\] is -1"):
        msc.catmull_clark_limit(v, [3, -1], [0, 1, 2])
    with pytest.raises(ValueError, match=r"bones\[0, 1\] is 1.25"):
        msc.fit_joints(v, t, (h + tl) / 2, [[0, 1.25]])


def test_symmetric_mesh_symmetric_weights():
    # Two legs: cylinders at x = +-1 with a bone each, named as mirror pairs.
    v, t = msc.capped_cylinder(0.4, 3.0, 20, 16)
    left, right = v + [1, 0, 0], v * [-1, 1, 1] + [-1, 0, 0]
    verts = np.vstack([left, right]).astype(np.float32)
    tri = np.vstack([t, t[:, ::-1] + len(v)])
    heads = np.array([[1, 0, 0.2], [-1, 0, 0.2], [0, 0, 0.2]], np.float32)
    tails = np.array([[1, 0, 2.8], [-1, 0, 2.8], [0, 0, 2.8]], np.float32)
    i, w = msc.heat_weights(verts, tri, heads, tails, bone_mirror=[1, 0, 2])
    d = dense(i, w, 3)
    np.testing.assert_allclose(d[: len(v), 0], d[len(v):, 1], atol=1e-5)
    np.testing.assert_allclose(d[: len(v), 2], d[len(v):, 2], atol=1e-5)


def test_heat_parents_make_imported_bones_reach_their_children():
    # An importer-style chain: bone 0's tail is a sideways stub, its child starts 0.9 higher.
    v, t = msc.capped_cylinder(0.08, 2.0, 41, 16)
    heads = np.array([[0, 0, 0.1], [0, 0, 1.0]], np.float32)
    tails = np.array([[0.05, 0, 0.1], [0, 0, 1.9]], np.float32)
    mid = (v[:, 2] > 0.4) & (v[:, 2] < 0.7)
    plain = dense(*msc.heat_weights(v, t, heads, tails), 2)
    reach = dense(*msc.heat_weights(v, t, heads, tails, parents=[-1, 0]), 2)
    # k = min(4, bones)
    check_influences(*msc.heat_weights(v, t, heads, tails, parents=np.array([-1, 0])), len(v), 2, 2)
    assert reach[mid, 0].mean() > 0.9 > plain[mid, 0].mean()
    # Roots only (no child anywhere) change nothing.
    np.testing.assert_array_equal(dense(*msc.heat_weights(v, t, heads, tails, parents=[-1, -1]), 2), plain)
    for bad, what in (([-1], "parents for 2 bones"), ([-1, 1], "parent of bone 1"), ([-1, 5], "parent of bone 1"),
                      ([1, 0], "parent cycle")):
        with pytest.raises(ValueError, match=what):
            msc.heat_weights(v, t, heads, tails, parents=bad)


def test_touching_meshes_groups_objects_that_share_a_seam(cyl):
    v = cyl[0]
    ring = v[np.isclose(v[:, 2], v[np.argmin(np.abs(v[:, 2] - 2.0)), 2])]
    low = np.vstack([v[v[:, 2] < ring[0, 2]], ring])
    high = np.vstack([ring, v[v[:, 2] > ring[0, 2]]])
    apart = high + np.float32([5, 0, 0])
    parts = [low, apart, high]
    mesh_of = np.repeat(np.arange(3), [len(p) for p in parts])
    g = msc.touching_meshes(np.vstack(parts), mesh_of, 3)
    assert g.dtype == np.int32 and g.tolist() == [0, 1, 0]
    assert msc.touching_meshes(np.vstack(parts), mesh_of, 3, min_shared=len(ring) + 1).tolist() == [0, 1, 2]
    # A sleeve 1 % outside the lower half and a stray vertex far away in it: with the
    # triangles, the stray vertex sets no scale and the sleeve stays apart.
    sleeve = (low * np.float32([1.01, 1.01, 1])).astype(np.float32)
    body = np.vstack([low, np.float32([[1e5, 0, 0]])])
    both, two = np.vstack([sleeve, body]), np.repeat(np.arange(2), [len(sleeve), len(body)])
    tris = np.array([[0, i, i + 1] for i in range(1, len(both) - 2)], dtype=np.uint32)
    assert msc.touching_meshes(both, two, 2).tolist() == [0, 0]
    assert msc.touching_meshes(both, two, 2, triangles=tris).tolist() == [0, 1]
    with pytest.raises(ValueError, match="triangle"):
        msc.touching_meshes(both, two, 2, triangles=np.array([[0, 1, len(both)]], dtype=np.uint32))
    with pytest.raises(ValueError, match="mesh index"):
        msc.touching_meshes(np.vstack(parts), mesh_of, 2)
    with pytest.raises(ValueError):
        msc.touching_meshes(np.vstack(parts), mesh_of[1:], 3)


def test_catmull_clark_limit_of_a_cube_and_bad_faces():
    """The limit of a cube cage's corner is half way to the centre (valence 3: (9 (5/9) + 4 (3/2)
    + 1) / 24 = 1/2); polygons of any size are read face after face; bad input is a ValueError."""
    v = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], np.float32)
    quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
    limit = msc.catmull_clark_limit(v, [4] * 6, np.ravel(quads))
    assert limit.dtype == np.float32 and limit.shape == (8, 3)
    np.testing.assert_allclose(limit, v / 2, atol=1e-6)
    # The top face as two triangles: the corners lose their symmetry, the cage stays closed.
    tri = quads[:1] + quads[2:]
    sizes = [4] + [4] * 4 + [3, 3]
    corners = np.concatenate([np.ravel(tri), [4, 5, 7, 4, 7, 6]])
    split = msc.catmull_clark_limit(v, sizes, corners)
    assert np.abs(split - v / 2).max() > 0.01 and np.all(np.abs(split) < 1)
    with pytest.raises(ValueError, match="corners"):
        msc.catmull_clark_limit(v, [4] * 5, np.ravel(quads))
    with pytest.raises(ValueError, match="vertex 8"):
        msc.catmull_clark_limit(v, [3], [0, 1, 8])
    bad = v.copy()
    bad[3, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        msc.catmull_clark_limit(bad, [4] * 6, np.ravel(quads))


def test_heat_bent_bones_take_their_curve_points(cyl):
    """A bone given inner curve points (a B-Bone's rest curve) is the polyline through them:
    points on the straight bone change nothing, points off it do; the two go together."""
    v, t = cyl[:2]
    heads, tails = np.float32([[0, 0, 0], [0, 0, 2]]), np.float32([[0, 0, 2], [0, 0, 4]])
    plain = msc.heat_weights(v, t, heads, tails)
    on = msc.heat_weights(v, t, heads, tails, curve_points=[[0, 0, 3]], curve_bones=[1])
    off = msc.heat_weights(v, t, heads, tails, curve_points=[[0.3, 0, 3]], curve_bones=[1])
    np.testing.assert_allclose(dense(*on, 2), dense(*plain, 2), atol=1e-6)
    assert np.abs(dense(*off, 2) - dense(*plain, 2)).max() > 0.05
    with pytest.raises(ValueError, match="together"):
        msc.heat_weights(v, t, heads, tails, curve_points=[[0, 0, 3]])
    with pytest.raises(ValueError, match="bone 2"):
        msc.heat_weights(v, t, heads, tails, curve_points=[[0, 0, 3]], curve_bones=[2])


@pytest.mark.parametrize("radius", [0.002, 0.05])
def test_heat_blends_across_a_joint_over_a_width_set_by_the_limbs_thickness(radius):
    """Heat's blend across a joint is as wide as the limb is thick (Pinocchio's H = c / d^2, d
    down to 1e-5 of the mesh's size), for a finger-thin tube too: the side vertices go from 0.9
    to 0.1 of the lower bone within 1 to 2.5 radii of the joint (1.4-1.6 here; 7.5 radii on the
    thin tube when d is clamped at 1 % of the size)."""
    v, t = msc.capped_cylinder(radius, 1.0, 1000, 12)
    h, tl, _ = msc.bone_chain(1.0, 2)  # joint at z = 0.5
    lower = dense(*msc.heat_weights(v, t, h, tl), 2)[:, 0]
    side = np.hypot(v[:, 0], v[:, 1]) > 0.99 * radius
    z, a = v[side, 2], lower[side]
    width = z[a > 0.1].max() - z[a < 0.9].min()
    assert radius <= width <= 2.5 * radius, width / radius


# ---------------------------------------------------------------- geodesic voxel, transfer


def test_voxel_weights_follow_the_chain_and_report_the_solid(cyl):
    v, t, h, tl, p = cyl
    out = msc.voxel_weights(v, t, h, tl, resolution=32)
    idx, w, report = out.indices, out.weights, out.report
    check_influences(idx, w, len(v), 4, 4)
    # Mid-bone vertices take the bone at their height (bones 0.95 long from z = 0.1).
    along = (v[:, 2] - 0.1) / 0.95
    mid = (np.abs(along - np.floor(along) - 0.5) < 0.2) & (along < 4)
    assert (idx[mid, 0] == np.floor(along[mid])).all()
    assert len(report.grid) == 3 and report.solid_voxels > 0 and report.outside_bones == 0
    assert {"voxelize", "geodesic", "falloff", "total"} <= set(report.timings)


def test_voxel_weights_objects_bind_a_prop_rigidly(cyl):
    """A box beside the cylinder as a second object, holding no bone: one rigid body."""
    v, t, h, tl, p = cyl
    bv = np.array([[x, y, z] for z in (2.0, 2.3) for y in (-0.1, 0.1) for x in (0.6, 0.9)], np.float32)
    bt = np.array([[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4], [2, 6, 7], [2, 7, 3],
                   [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]], np.uint32) + len(v)
    objects = np.repeat(np.array([0, 1], np.uint32), [len(v), 8])
    out = msc.voxel_weights(np.vstack([v, bv]), np.vstack([t, bt]), h, tl, objects=objects)
    idx, w, _ = out.indices, out.weights, out.report
    assert (w[len(v):, 0] == 1.0).all() and len(set(idx[len(v):, 0])) == 1


def test_voxel_weights_bad_input_is_a_value_error(cyl):
    v, t, h, tl, p = cyl
    with pytest.raises(ValueError, match="resolution"):
        msc.voxel_weights(v, t, h, tl, resolution=4)
    with pytest.raises(ValueError, match="falloff"):
        msc.voxel_weights(v, t, h, tl, falloff=-1.0)
    with pytest.raises(ValueError, match="objects"):
        msc.voxel_weights(v, t, h, tl, objects=np.zeros(3, np.uint32))
    with pytest.raises(msc.Cancelled):
        msc.voxel_weights(v, t, h, tl, progress=lambda f: False)


def test_transfer_weights_copy_onto_a_sleeve(cyl):
    v, t, h, tl, p = cyl
    idx, w = msc.heat_weights(v, t, h, tl)
    gv, gt = msc.capped_cylinder(0.52, 2.0, 21, 24)
    gv = gv + np.array([0, 0, 1.0], np.float32)
    out = msc.transfer_weights(v, t, idx, w, gv, gt)
    gi, gw, report = out.indices, out.weights, out.report
    check_influences(gi, gw, len(gv), 4, 4)
    assert report.matched > 0.9 * len(gv) and report.nearest == 0
    # Each sleeve vertex carries the weights of the body vertex nearest to it (within a blend).
    near = np.linalg.norm(gv[:, None] - v[None], axis=2).argmin(1)
    assert np.abs(dense(gi, gw, 4) - dense(idx, w, 4)[near]).sum(1).mean() < 0.15
    with pytest.raises(ValueError, match="body weights"):
        msc.transfer_weights(v, t, idx[:5], w[:5], gv, gt)
