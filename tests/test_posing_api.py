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


def solve(lengths, target, angles=None, *, limits=None, **options):
    return msc.ik2d_solve(msc.Chain2d(lengths, angles, limits=limits), target, msc.Ik2dOptions(**options))


def test_ik2d_reaches_and_forward_agrees():
    lengths = [1.0, 0.8, 0.5]
    sol = solve(lengths, (1.2, 1.0))
    assert sol.reached and sol.error <= 1e-3 * sum(lengths)
    tip = msc.ik2d_forward(msc.Chain2d(lengths, sol.angles))[-1]
    assert math.dist(tip, (1.2, 1.0)) <= 1e-3 * sum(lengths)


def test_ik2d_chain_options_and_solution_are_typed():
    chain = msc.Chain2d([1.0, 2.0], [0.1, 0.2], base=(1.0, -1.0), base_angle=0.5, limits=[[-1, 1], [-2, 2]])
    assert list(chain.lengths) == [1.0, 2.0] and list(chain.angles) == [0.1, 0.2]
    assert chain.base == (1.0, -1.0) and chain.base_angle == 0.5 and chain.limits.shape == (2, 2)
    o = msc.Ik2dOptions()
    assert (o.max_iterations, o.tolerance, o.method) == (200, None, "ccd")
    sol = msc.ik2d_solve(chain, (1.5, 1.0))
    assert isinstance(sol, msc.Ik2dSolution) and sol.angles.shape == (2,) and isinstance(sol.iterations, int)
    with pytest.raises(ValueError, match="one entry per bone"):
        msc.Chain2d([1.0, 1.0], [0.0])
    with pytest.raises(ValueError, match="CCD only"):
        msc.ik2d_solve_multi(chain, [(2, (1.0, 1.0), 1.0)], msc.Ik2dOptions(method="fabrik"))


def test_ik2d_unreachable_straight_toward_target():
    sol = solve([1.0, 1.0], (0.0, 5.0))
    assert not sol.reached
    pts = msc.ik2d_forward(msc.Chain2d([1.0, 1.0], sol.angles))
    np.testing.assert_allclose(pts[-1], [0, 2], atol=1e-6)


def test_ik2d_limits_hold_and_methods_exist():
    limits = [[-math.pi, math.pi], [0.0, math.radians(150)]]
    for method in ("ccd", "ccd_pure", "ccd_classic3d", "fabrik"):
        angles = solve([1.0, 1.0], (0.5, -1.0), limits=limits, method=method).angles
        assert 0.0 - 1e-9 <= angles[1] <= math.radians(150) + 1e-9, method
    with pytest.raises(ValueError):
        solve([1.0], (1, 0), method="nope")


def test_ik2d_options_reach_the_solver():
    """tolerance, max_iterations and method are the solver's, not decoration: a start within
    the tolerance is kept as it is; near full reach the paper's CCD ("ccd_pure") crawls for many
    passes where the polished one takes a few, and max_iterations stops it."""
    sol = solve([1.0, 1.0], (1.97, 0.3), tolerance=0.5)
    assert sol.iterations == 0 and sol.reached and list(sol.angles) == [0.0, 0.0]
    near_full = (1.99 * math.cos(1.0), 1.99 * math.sin(1.0))
    polished = solve([1.0, 1.0], near_full)
    pure = solve([1.0, 1.0], near_full, method="ccd_pure")
    assert polished.reached and pure.reached
    assert pure.iterations > 10 * polished.iterations, (pure.iterations, polished.iterations)
    stopped = solve([1.0, 1.0], near_full, method="ccd_pure", max_iterations=3)
    assert stopped.iterations == 3 and not stopped.reached


@pytest.mark.parametrize("method", ["ccd", "ccd_pure", "ccd_classic3d", "fabrik", "multi"])
def test_ik2d_max_iterations_is_bounded(method):
    """The solve runs without the GIL, so a huge max_iterations (a script's 10**12) would hold
    Blender with no way to stop it: above 10000 it is a ValueError naming the bound, before any
    pass; at the bound a solve that never converges (tolerance 0) runs every pass, quickly."""
    lengths, target = [0.25] * 16, (1.3, 2.1)

    def run(**kw):
        if method == "multi":
            return msc.ik2d_solve_multi(msc.Chain2d(lengths), [(16, target, 1.0)], msc.Ik2dOptions(**kw))
        return solve(lengths, target, method=method, **kw)

    for n in (10_001, 10**12, 2**64 - 1):
        with pytest.raises(ValueError, match=f"max_iterations must be at most 10000, got {n}"):
            run(max_iterations=n)
    with pytest.raises(OverflowError):   # past usize: Python's own conversion error
        run(max_iterations=2**64)
    with pytest.raises(OverflowError):
        run(max_iterations=-1)
    sol = run(max_iterations=10_000, tolerance=0.0)
    assert sol.iterations <= 10_000
    if method == "ccd_classic3d":   # never lands exactly: every pass runs
        assert sol.iterations == 10_000


def test_ik2d_multi_head_and_tail():
    lengths = [0.5] * 8
    eff = [(8, (2.5, 1.0), 1.0), (4, (1.5, 0.6), 1.0)]
    sol = msc.ik2d_solve_multi(msc.Chain2d(lengths), eff)
    pts = msc.ik2d_forward(msc.Chain2d(lengths, sol.angles))
    assert math.dist(pts[8], (2.5, 1.0)) < 4e-3 and math.dist(pts[4], (1.5, 0.6)) < 4e-3
