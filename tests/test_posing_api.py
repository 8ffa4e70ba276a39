"""LBS and planar IK from plain Python."""

import math

import numpy as np
import pytest

import miniskeleton_core as msc


def test_lbs_rotation_blend_and_translation():
    v = np.array([[1, 0, 0], [0, 0, 2]], np.float32)
    rot = np.eye(4, dtype=np.float32)
    rot[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]  # 90 deg about Z
    move = np.eye(4, dtype=np.float32)
    move[:3, 3] = [0, 0, 1]
    idx = np.array([[0, 1], [1, -1]], np.int32)
    w = np.array([[0.5, 0.5], [1, 0]], np.float32)
    out = msc.lbs(v, idx, w, np.stack([rot, move]))
    np.testing.assert_allclose(out[0], [0.5, 0.5, 0.5], atol=1e-6)  # half rotated, half lifted
    np.testing.assert_allclose(out[1], [0, 0, 3], atol=1e-6)


def test_lbs_rejects_bad_index():
    v = np.zeros((1, 3), np.float32)
    with pytest.raises(ValueError):
        msc.lbs(v, [[3]], [[1.0]], np.eye(4)[None])
    # 2^32 would be cast by numpy to int32 0, a valid bone, and 0.5 to 0.
    for bad in (2**32, 0.5):
        with pytest.raises(ValueError, match=r"indices\[0, 0\] is "):
            msc.lbs(v, np.array([[bad]]), [[1.0]], np.eye(4)[None])


def test_ik2d_reaches_and_forward_agrees():
    lengths = [1.0, 0.8, 0.5]
    angles, rep = msc.ik2d_solve(lengths, (1.2, 1.0))
    assert rep["reached"] and rep["error"] <= 1e-3 * sum(lengths)
    tip = msc.ik2d_forward(lengths, angles)[-1]
    assert math.dist(tip, (1.2, 1.0)) <= 1e-3 * sum(lengths)


def test_ik2d_unreachable_straight_toward_target():
    angles, rep = msc.ik2d_solve([1.0, 1.0], (0.0, 5.0))
    assert not rep["reached"]
    pts = msc.ik2d_forward([1.0, 1.0], angles)
    np.testing.assert_allclose(pts[-1], [0, 2], atol=1e-6)


def test_ik2d_limits_hold_and_methods_exist():
    limits = [[-math.pi, math.pi], [0.0, math.radians(150)]]
    for method in ("ccd", "ccd_pure", "ccd_classic3d", "fabrik"):
        angles, _ = msc.ik2d_solve([1.0, 1.0], (0.5, -1.0), limits=limits, method=method)
        assert 0.0 - 1e-9 <= angles[1] <= math.radians(150) + 1e-9, method
    with pytest.raises(ValueError):
        msc.ik2d_solve([1.0], (1, 0), method="nope")


def test_ik2d_options_reach_the_solver():
    """tolerance, max_iterations and method are the solver's, not decoration: a start within
    the tolerance is kept as it is; near full reach the paper's CCD ("ccd_pure") crawls for many
    passes where the polished one takes a few, and max_iterations stops it."""
    angles, rep = msc.ik2d_solve([1.0, 1.0], (1.97, 0.3), tolerance=0.5)
    assert rep["iterations"] == 0 and rep["reached"] and list(angles) == [0.0, 0.0]
    near_full = (1.99 * math.cos(1.0), 1.99 * math.sin(1.0))
    _, polished = msc.ik2d_solve([1.0, 1.0], near_full)
    _, pure = msc.ik2d_solve([1.0, 1.0], near_full, method="ccd_pure")
    assert polished["reached"] and pure["reached"]
    assert pure["iterations"] > 10 * polished["iterations"], (pure, polished)
    _, stopped = msc.ik2d_solve([1.0, 1.0], near_full, method="ccd_pure", max_iterations=3)
    assert stopped["iterations"] == 3 and not stopped["reached"]


def test_ik2d_multi_head_and_tail():
    lengths = [0.5] * 8
    eff = [(8, (2.5, 1.0), 1.0), (4, (1.5, 0.6), 1.0)]
    angles, rep = msc.ik2d_solve_multi(lengths, eff)
    pts = msc.ik2d_forward(lengths, angles)
    assert math.dist(pts[8], (2.5, 1.0)) < 4e-3 and math.dist(pts[4], (1.5, 0.6)) < 4e-3


def biped():
    """Hips, spine, neck, head, two two-bone legs and two arms, +Z up, metres."""
    heads = [[0, 0, 1], [0, 0, 1.2], [0, 0, 1.5], [0, 0, 1.6], [0.1, 0, 1], [0.1, 0, 0.5],
             [-0.1, 0, 1], [-0.1, 0, 0.5], [0.2, 0, 1.45], [-0.2, 0, 1.45]]
    tails = [[0, 0, 1.2], [0, 0, 1.5], [0, 0, 1.6], [0, 0, 1.8], [0.1, 0, 0.5], [0.1, 0, 0],
             [-0.1, 0, 0.5], [-0.1, 0, 0], [0.5, 0, 1.45], [-0.5, 0, 1.45]]
    names = ["hips", "spine", "neck", "head", "thigh.L", "shin.L", "thigh.R", "shin.R", "arm.L", "arm.R"]
    return (np.array(heads, np.float32), np.array(tails, np.float32), np.array([-1, 0, 1, 2, 0, 4, 0, 6, 1, 1]),
            np.tile(np.eye(3, dtype=np.float32), (10, 1, 1)), names)


def test_make_motion_frames_and_a_clip_too_long_for_blender():
    h, t, p, rest, names = biped()
    shake = msc.make_motion(h, t, p, rest, "HEAD_SHAKE", names=names, fps=24, duration=2)
    assert shake["frames"] == 49 and shake["rotations"].shape == (49, 10, 4)
    assert np.isfinite(shake["rotations"]).all() and not shake["moves_root"]
    walk = msc.make_motion(h, t, p, rest, "WALK", names=names, cycles=2)
    assert walk["frames"] == 2 * walk["frames_per_cycle"] + 1 and walk["moves_root"]
    # feet on their legs: nothing is moved by location
    assert walk["locations"].shape == (walk["frames"], 10, 3) and not walk["locations"].any()
    assert walk["located"].size == 0 and walk["roles"]["riders"] == []
    # Motion names in any case; root_motion=False walks on the spot (the hips only bob).
    on_the_spot = msc.make_motion(h, t, p, rest, "walk", names=names, cycles=2, root_motion=False)
    # the same leg motion (to rounding: the feet are solved at positions a travel apart)
    np.testing.assert_allclose(on_the_spot["rotations"], walk["rotations"], atol=1e-5)
    assert np.abs(on_the_spot["root_offset"]).max() < 0.1 < np.abs(walk["root_offset"]).max()
    with pytest.raises(ValueError, match="rest_matrices must have shape"):
        msc.make_motion(h, t, p, rest.ravel(), "WALK", names=names)


def test_feet_hanging_off_the_root_are_moved_by_location():
    """The shins end at the ankle; the feet are children of the hips (the root), as game rigs
    exported from an IK set-up have them: they ride on the shins, moved by location keys."""
    h, t, p, rest, names = biped()
    t[[5, 7], 2] = 0.08   # ankles
    h = np.vstack([h, [[0.1, -0.02, 0.0], [-0.1, -0.02, 0.0]]]).astype(np.float32)
    t = np.vstack([t, [[0.1, -0.2, 0.0], [-0.1, -0.2, 0.0]]]).astype(np.float32)
    p = np.append(p, [0, 0])
    rest = np.tile(np.eye(3, dtype=np.float32), (12, 1, 1))
    names = names + ["foot.L", "foot.R"]
    walk = msc.make_motion(h, t, p, rest, "WALK", names=names, cycles=1)
    assert sorted(walk["roles"]["riders"]) == [(10, 5), (11, 7)]
    assert sorted(walk["located"].tolist()) == [10, 11]
    moved = np.abs(walk["locations"]).max(axis=(0, 2))
    assert moved[10] > 0.05 and moved[11] > 0.05 and not moved[:10].any()
    # Clips past Blender's last frame (1048574) are refused before anything is allocated,
    # where fps 1e9 x 1e9 s used to abort the process on a failed allocation.
    for kw in (dict(fps=1e9, duration=1e9), dict(fps=1e30, duration=1e30)):
        with pytest.raises(ValueError, match="frames"):
            msc.make_motion(h, t, p, rest, "HEAD_SHAKE", names=names, **kw)
    for kw in (dict(cycles=1e12), dict(speed=1e-30)):
        with pytest.raises(ValueError, match="frames"):
            msc.make_motion(h, t, p, rest, "WALK", names=names, **kw)
