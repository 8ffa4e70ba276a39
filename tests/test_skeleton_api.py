"""The skeleton-fitting API of miniskeleton_core from plain Python: centring, options, errors."""

import numpy as np
import pytest

import miniskeleton_core as msc


@pytest.fixture(scope="module")
def tube():
    return msc.capped_cylinder(0.5, 4.0, 40, 32)


def chain(n):
    return np.array([[i, i + 1] for i in range(n - 1)], dtype=np.uint32)


def test_fit_centres_a_limb_and_reports(tube):
    v, t = tube
    rng = np.random.default_rng(3)
    start = np.array([[0.0, 0.0, 0.4 + 0.8 * i] for i in range(5)], dtype=np.float32)
    start[:, :2] += rng.uniform(-0.3, 0.3, size=(5, 2))
    out, rep = msc.fit_joints(v, t, start, chain(5))
    assert out.shape == (5, 3) and out.dtype == np.float32
    assert np.abs(out[:, :2]).max() < 0.02, out
    np.testing.assert_allclose(out[:4, 2], start[:4, 2], atol=0.05)  # along the limb: kept
    assert rep["outside_after"] == 0 and rep["pieces"] == 1
    assert msc.points_inside(v, t, out).all()
    # The free end goes toward the tube's end only with tip (the default).
    assert out[4, 2] > start[4, 2] + 0.1
    kept, _ = msc.fit_joints(v, t, start, chain(5), tip=False)
    assert abs(kept[4, 2] - start[4, 2]) < 0.01 and np.abs(kept[:, :2]).max() < 0.02
    # Joints pushed out of the tube are counted outside before and inside after.
    out, rep = msc.fit_joints(v, t, start + np.float32([0.8, 0.0, 0.0]), chain(5))
    assert rep["outside_before"] == rep["outside_before_mask"].sum() == 5
    assert rep["outside_after"] == rep["outside_after_mask"].sum() == 0


def test_fixed_joints_stay_and_options_are_checked(tube):
    v, t = tube
    start = np.array([[0.3, 0.0, 0.5], [0.3, 0.0, 2.0], [0.3, 0.0, 3.5]], dtype=np.float32)
    out, _ = msc.fit_joints(v, t, start, chain(3), movable=np.array([True, False, True]))
    np.testing.assert_array_equal(out[1], start[1])
    assert abs(out[0, 0]) < 0.3 - 0.01
    # rays / samples past 1024 would be allocated before any work (10^12 aborted the process)
    for bad in (dict(stub_ratio=-1.0), dict(max_move=0.0), dict(rays=2), dict(rays=10**12), dict(samples=10**12)):
        with pytest.raises(ValueError):
            msc.fit_joints(v, t, start, chain(3), **bad)
    with pytest.raises(ValueError):
        msc.fit_joints(v, t, start, np.array([[0, 7]], dtype=np.uint32))
    with pytest.raises(ValueError, match="go together"):
        msc.fit_joints(v, t, start, chain(3), symmetry_axis=0)   # no joint_mirror
