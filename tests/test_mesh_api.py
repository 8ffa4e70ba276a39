"""The mesh API of miniskeleton_core from plain Python: welding points."""

import numpy as np
import pytest

import miniskeleton_core as msc


def test_weld_points_keeps_each_clusters_first_point_and_does_not_chain():
    # 0.6 apart in a row, tolerance 1 (absolute, in the points' units): the third point is 0.6
    # from the second but 1.2 from the first, its cluster's point, so it starts a new cluster.
    pts = np.array([[0, 0, 0], [0.6, 0, 0], [1.2, 0, 0], [1.8, 0, 0], [0, 0.9, 0], [0, 0, 0]], np.float64)
    m, welded = msc.weld_points(pts, 1.0)
    assert m.dtype == np.int32 and welded.dtype == np.float64 and welded.shape == (2, 3)
    assert m.tolist() == [0, 0, 1, 1, 0, 0]
    np.testing.assert_array_equal(welded, pts[[0, 2]])  # first points, not means
    # float32 and lists are cast to float64
    m32, w32 = msc.weld_points(pts.astype(np.float32), 1.0)
    np.testing.assert_array_equal(m32, m)
    np.testing.assert_array_equal(w32, pts.astype(np.float32)[[0, 2]])
    assert msc.weld_points(pts.tolist(), 1.0).map.tolist() == m.tolist()
    # the scale is the caller's: the same points in centimetres need a tolerance in centimetres
    assert msc.weld_points(pts * 100, 1.0).map.tolist() == [0, 1, 2, 3, 4, 0]
    assert msc.weld_points(pts * 100, 100.0).map.tolist() == m.tolist()


def test_weld_points_a_point_near_two_welded_points_joins_one_of_them():
    pts = np.array([[0.1, 0, 0], [2.05, 0, 0], [1.05, 0, 0]])   # the last is within 1 of both
    m, welded = msc.weld_points(pts, 1.0)
    assert len(welded) == 2 and m[:2].tolist() == [0, 1] and m[2] in (0, 1)


def test_weld_points_exact_duplicates_without_a_positive_tolerance_and_non_finite_points_apart():
    pts = np.array([[0, 0, 0], [1e-9, 0, 0], [0, 0, 0], [-0.0, 0, 0]])
    for tolerance in (0.0, -1.0, float("nan"), float("inf")):
        m, welded = msc.weld_points(pts, tolerance)
        assert m.tolist() == [0, 1, 0, 0] and len(welded) == 2, tolerance
    odd = np.array([[np.nan, 0, 0], [np.nan, 0, 0], [np.inf, 0, 0], [np.inf, 0, 0]])
    m, welded = msc.weld_points(odd, 1.0)
    assert m.tolist() == [0, 1, 2, 3]
    np.testing.assert_array_equal(welded, odd)
    m, welded = msc.weld_points(np.zeros((0, 3)), 1.0)
    assert m.shape == (0,) and welded.shape == (0, 3)


def test_weld_points_bad_input():
    with pytest.raises(ValueError, match=r"points must have shape \(n, 3\)"):
        msc.weld_points(np.zeros((4, 2)), 1.0)
    with pytest.raises(TypeError):
        msc.weld_points(np.zeros((4, 3)), "near")


def test_weld_points_rebuilds_a_skeletons_joint_graph():
    """The add-on's joint graph (rig_io.joint_graph): bone ends closer than the tolerance are one
    joint, the first joint within it (lowest index) taken, and a connected bone's head is its
    parent's tail joint. On weld_points: the bone ends in the graph's order (parents first; a
    bone's head unless it is connected, then its tail), welded; the same joints and ends when
    no end lies within the tolerance of two joints."""
    rng = np.random.default_rng(7)
    centres = np.array([[x, y, z] for x in range(3) for y in range(2) for z in range(3)], np.float64)
    n, tol = 60, 0.1

    def near_centre():   # within 0.02 of one of 18 centres 1 apart: no end near two joints
        d = rng.normal(size=3)
        return centres[rng.integers(len(centres))] + 0.02 * rng.random() * d / np.linalg.norm(d)

    heads = np.array([near_centre() for _ in range(n)])
    tails = np.array([near_centre() for _ in range(n)])
    parents = [-1 if i % 10 == 0 else int(rng.integers(0, i)) for i in range(n)]   # parents first
    connected = [p >= 0 and i % 3 == 0 for i, p in enumerate(parents)]
    tails[17] = np.nan   # a bad end: a joint of its own

    joints, ends = [], np.full((n, 2), -1, np.int32)

    def first_within(p):
        for k, q in enumerate(joints):
            if np.linalg.norm(q - p) <= tol:
                return k
        joints.append(p)
        return len(joints) - 1

    for i in range(n):
        ends[i, 0] = ends[parents[i], 1] if connected[i] and parents[i] >= 0 else first_within(heads[i])
        ends[i, 1] = first_within(tails[i])

    points, slots = [], np.full((n, 2), -1)
    for i in range(n):
        if not (connected[i] and parents[i] >= 0):
            slots[i, 0] = len(points)
            points.append(heads[i])
        slots[i, 1] = len(points)
        points.append(tails[i])
    m, welded = msc.weld_points(np.array(points), tol)
    by_weld = np.full((n, 2), -1, np.int32)
    for i in range(n):
        by_weld[i, 0] = m[slots[i, 0]] if slots[i, 0] >= 0 else by_weld[parents[i], 1]
        by_weld[i, 1] = m[slots[i, 1]]

    np.testing.assert_array_equal(by_weld, ends)
    np.testing.assert_array_equal(welded, np.array(joints))
    assert len(welded) < 2 * n - 10   # ends did merge


def test_results_are_named_and_unpack_in_order():
    """Results are classes with named fields that also unpack and index, as a NamedTuple's do."""
    mesh = msc.capped_cylinder(0.5, 2.0, 4, 8)
    vertices, triangles = mesh
    assert vertices is mesh.vertices and triangles is mesh.triangles and len(mesh) == 2
    chain = msc.bone_chain(2.0, 3)
    heads, tails, parents = chain
    assert heads is chain.heads and tails is chain.tails and parents is chain.parents and len(chain) == 3
    weights = msc.idw_weights(mesh.vertices, chain.heads, chain.tails, max_influences=2)
    indices, w = weights
    assert indices is weights.indices and w is weights.weights and indices.shape == (len(vertices), 2)
    welded = msc.weld_points(np.zeros((3, 3)), 0.1)
    assert welded.map.tolist() == [0, 0, 0] and welded.welded.shape == (1, 3) and len(welded) == 2
    assert welded[0] is welded.map and welded[-1] is welded.welded
    with pytest.raises(IndexError):
        welded[2]
