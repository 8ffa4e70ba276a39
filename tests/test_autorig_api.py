"""Auto Rig from plain Python: a kit-built quadruped of capped cylinders gets Rigify's quadruped
bones as numpy arrays, a snake a chain, and every bad input is one ValueError."""

import numpy as np
import pytest

import miniskeleton_core as msc


def limb(parts, a, b, r):
    """A capped cylinder of radius r from a to b."""
    v, t = msc.capped_cylinder(r, 1.0, 12, 16)
    a, b = np.asarray(a, float), np.asarray(b, float)
    z = (b - a) / np.linalg.norm(b - a)
    x = np.cross(z, [0.0, 0.0, 1.0] if abs(z[2]) < 0.9 else [1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    v = v.astype(float)
    pts = a + v[:, :1] * x + v[:, 1:2] * y + v[:, 2:3] * (b - a)
    parts.append((pts, t))


@pytest.fixture(scope="module")
def quadruped():
    parts = []
    for x in (-0.45, 0.45):
        for y in (-0.15, 0.15):
            limb(parts, [x, y, 0.75], [x, y, 0.0], 0.06)
    limb(parts, [-0.6, 0, 0.8], [0.6, 0, 0.8], 0.22)
    limb(parts, [0.5, 0, 0.85], [0.8, 0, 1.2], 0.09)
    limb(parts, [0.75, 0, 1.2], [1.05, 0, 1.1], 0.11)
    verts, tris, base = [], [], 0
    for v, t in parts:
        verts.append(v)
        tris.append(t.astype(np.int64) + base)
        base += len(v)
    return np.concatenate(verts).astype(np.float32), np.concatenate(tris)


def test_a_quadruped_gets_rigifys_bones(quadruped):
    v, t = quadruped
    rig = msc.auto_rig(v, t)
    assert rig.template == "QUADRUPED" and rig.tail is False
    assert rig.reason == "4 legs hold the body up"
    names = rig.names
    k = len(names)
    assert rig.heads.shape == (k, 3) and rig.heads.dtype == np.float32
    assert rig.tails.shape == (k, 3) and rig.parents.shape == (k,) and rig.connected.dtype == np.bool_
    assert {"spine.004", "spine.011", "thigh.L", "front_toe.R", "shoulder.L"} <= set(names)
    assert all(p < i for i, p in enumerate(rig.parents))
    assert names[rig.parents[names.index("front_thigh.L")]] == "shoulder.L"
    np.testing.assert_allclose(rig.forward, [1, 0, 0], atol=0.1)
    np.testing.assert_allclose(rig.left, [0, 1, 0], atol=0.1)
    assert rig.heads[names.index("thigh.L")][1] > 0.05
    # The tree the bones follow is returned for display.
    assert rig.centre_points.shape[1] == 3 and rig.centre_edges.max() < len(rig.centre_points)
    # The facing can be given; the template can be forced.
    back = msc.auto_rig(v, t, forward=[-1, 0, 0])
    np.testing.assert_allclose(back.forward, [-1, 0, 0], atol=1e-6)
    assert msc.auto_rig(v, t, template="BIPED").template == "BIPED"


def test_bad_input_is_one_value_error(quadruped):
    v, t = quadruped
    bad = v.copy()
    bad[5, 0] = np.nan
    cases = [
        ((bad, t), {}, "NaN"),
        ((np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int64)), {}, "empty"),
        ((v, t), {"template": "SPIDER"}, "template"),
        ((v, t), {"forward": [0, 0, 1]}, "horizontal"),
        ((v, t), {"forward": [1, 0]}, "shape"),
        ((v, t), {"resolution": 2}, "resolution"),
        (msc.capped_cylinder(0.5, 1.0, 12, 16), {}, "blob"),
        ((np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]])), {}, "volume"),
    ]
    for args, kw, word in cases:
        with pytest.raises(ValueError, match=word):
            msc.auto_rig(*args, **kw)


def test_a_snake_gets_a_chain_from_tail_to_head():
    parts = []
    pts = [[0.15 * np.sin(3 * np.pi * t), -1.2 + 2.4 * t, 0.06] for t in np.linspace(0, 1, 13)]
    for k in range(12):
        limb(parts, pts[k], pts[k + 1], 0.06 if k < 9 else 0.06 - 0.012 * (k - 8))
    limb(parts, [0, -1.2, 0.07], [0, -1.38, 0.07], 0.085)
    verts, tris, base = [], [], 0
    for v, t in parts:
        verts.append(v)
        tris.append(t.astype(np.int64) + base)
        base += len(v)
    v, t = np.concatenate(verts).astype(np.float32), np.concatenate(tris)
    rig = msc.auto_rig(v, t)
    assert rig.template == "CHAIN" and "no legs" in rig.reason, rig.reason
    names = rig.names
    assert not [n for n in names if n.startswith(("thigh", "shin"))]
    assert rig.tails[names.index("spine.007")][1] < -1.1  # the head end
    assert rig.tail and rig.tails[names.index("spine")][1] > 0.9
    with pytest.raises(ValueError, match="no wings"):
        msc.auto_rig(v, t, template="WINGED")
