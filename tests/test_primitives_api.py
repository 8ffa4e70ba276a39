"""The generated test meshes and bone chains of miniskeleton_core from plain Python. (Their first
check, test_generated_cylinder_and_chain, lives with the weights tests that use them.)"""

import numpy as np
import pytest

import miniskeleton_core as msc


@pytest.mark.parametrize("rings, segments", [(2, 3), (5, 8), (40, 24)])
def test_capped_cylinder_is_closed_and_faces_outward(rings, segments):
    v, t = msc.capped_cylinder(0.5, 4.0, rings, segments)
    assert v.shape == (rings * segments + 2, 3) and t.shape == (2 * segments * rings, 3)
    assert v.dtype == np.float32 and t.dtype == np.uint32
    # every edge in two triangles, once in each direction: closed and consistently wound
    directed = {(int(a), int(b)) for tri in t for a, b in zip(tri, np.roll(tri, -1))}
    assert len(directed) == 3 * len(t) and all((b, a) in directed for a, b in directed)
    # outward: a positive volume, the prism's (s / 2) r^2 sin(2 pi / s) h
    a, b, c = (v[t[:, k]].astype(np.float64) for k in range(3))
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6
    assert volume == pytest.approx(segments / 2 * 0.25 * np.sin(2 * np.pi / segments) * 4.0, rel=1e-5)
    assert np.abs(np.linalg.norm(v[:-2, :2], axis=1) - 0.5).max() < 1e-6
    assert v[:, 2].min() == 0 and v[:, 2].max() == pytest.approx(4.0)


def test_capped_cylinder_clamps_its_counts_and_sizes():
    v, t = msc.capped_cylinder(0.5, 4.0, rings=0, segments=1)   # at least 2 rings of 3
    assert v.shape == (8, 3) and t.shape == (12, 3)
    v, _ = msc.capped_cylinder(-1.0, float("nan"), 2, 3)   # not positive or not finite: 1
    assert np.abs(v).max() == pytest.approx(1.0)
    with pytest.raises(ValueError, match="segments must be at most"):
        msc.capped_cylinder(segments=10**6)


def test_bone_chain_runs_up_the_cylinders_inside():
    heads, tails, parents = msc.bone_chain(2.0, 5)
    assert heads.dtype == tails.dtype == np.float32 and parents.dtype == np.int32
    assert parents.tolist() == [-1, 0, 1, 2, 3]
    np.testing.assert_array_equal(heads[1:], tails[:-1])
    np.testing.assert_allclose(heads[:, 2], 0.05 + 0.38 * np.arange(5), atol=1e-6)
    assert tails[-1, 2] == pytest.approx(1.95) and not heads[:, :2].any() and not tails[:, :2].any()
    heads, tails, parents = msc.bone_chain(2.0, 0)   # at least one bone
    assert heads.shape == (1, 3) and parents.tolist() == [-1]


def test_split_flat_gives_each_triangle_its_own_corners():
    v, t = msc.capped_cylinder(0.5, 4.0, 3, 5)
    sv, st = msc.split_flat(v, t)
    assert sv.shape == (3 * len(t), 3) and st.shape == t.shape and st.dtype == np.uint32
    np.testing.assert_array_equal(st.ravel(), np.arange(3 * len(t)))
    np.testing.assert_array_equal(sv, v[t.ravel()])
    # an index past the vertices is an error naming the triangle (it was copied as the origin,
    # a corner made up without a word); so is a negative one
    far = t.copy()
    far[4, 1] = len(v) + 7
    far[6, 0] = len(v)
    with pytest.raises(ValueError, match=rf"triangle 4 refers to vertex {len(v) + 7}, but the mesh has {len(v)} "):
        msc.split_flat(v, far)
    with pytest.raises(ValueError, match="triangle 0 refers to vertex 0, but the mesh has 0 vertices"):
        msc.split_flat(np.zeros((0, 3), np.float32), t[:1])
    sv, st = msc.split_flat(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint32))
    assert sv.shape == (0, 3) and st.shape == (0, 3)
    with pytest.raises(ValueError, match=r"triangles\[0, 1\] is -1"):
        msc.split_flat(v, np.where(np.arange(t.size).reshape(t.shape) == 1, -1, t.astype(np.int64)))
    with pytest.raises(ValueError, match="shape"):
        msc.split_flat(v[:, :2], t)
