"""Random bad input at every miniskeleton_core entry point (fixed seeds): each call returns
well-formed, finite output or raises ValueError / OverflowError with a message, and never
panics across the boundary (pyo3 turns a Rust panic into PanicException, a BaseException that
fails these tests). Messy meshes: random soups, collinear or coincident points, several pieces
with duplicate faces, non-manifold fans, NaN / infinite coordinates, bad indices, scales from
1e-9 to 1e9, zero-length and NaN bones; odd options; perturbed rigs for the motions."""

import numpy as np
import pytest

import miniskeleton_core as msc
from test_posing_api import biped

ODD = [0.0, -1.0, 1e-30, 1e30, np.nan, np.inf, 0.5, 2.0]


def attempt(f, *args, **kwargs):
    """f's result, or None when it refused the input with a clear error."""
    try:
        return f(*args, **kwargs)
    except (ValueError, OverflowError) as e:
        assert str(e), f"{f.__name__} raised {type(e).__name__} without a message"
        return None


def messy_mesh(rng):
    kind = rng.integers(0, 6)
    if kind == 0:  # small closed cylinders, possibly a single ring
        v, t = msc.capped_cylinder(0.5, 4.0, int(rng.integers(1, 12)), int(rng.integers(3, 12)))
    elif kind == 1:  # a random soup
        n = int(rng.integers(0, 40))
        v = rng.normal(size=(n, 3))
        t = rng.integers(0, max(n, 1), size=(int(rng.integers(0, 60)) if n else 0, 3))
    elif kind == 2:  # all points on a line, or all at one place
        n = int(rng.integers(1, 30))
        v = np.zeros((n, 3))
        v[:, 0] = rng.normal(size=n) * rng.integers(0, 2)
        t = rng.integers(0, n, size=(int(rng.integers(1, 40)), 3))
    elif kind == 3:  # several pieces and duplicate faces
        v0, t0 = msc.capped_cylinder(0.5, 4.0, 4, 6)
        k = int(rng.integers(1, 5))
        v = np.concatenate([v0 + rng.normal(size=3) * 3 for _ in range(k)])
        copies = [t0.astype(np.int64) + i * len(v0) for i in range(k)]
        t = np.concatenate(copies + [t0[: int(rng.integers(0, len(t0)))]])
    elif kind == 4:  # a non-manifold fan: ten triangles on one edge
        v = rng.normal(size=(12, 3))
        t = np.array([[0, 1, i] for i in range(2, 12)])
    else:  # a cylinder lying along another axis
        v, t = msc.capped_cylinder(0.5, 4.0, 6, 8)
        v = v[:, rng.permutation(3)]
    v, t = np.array(v, np.float64), np.array(t, np.int64)
    scale = 10.0 ** rng.uniform(-9, 9) if rng.random() < 0.3 else 1.0
    v *= scale
    if rng.random() < 0.1 and len(v):
        v[rng.integers(0, len(v))] = rng.choice([np.nan, np.inf, -np.inf])
    if rng.random() < 0.05 and len(t):
        t[rng.integers(0, len(t)), 0] = rng.choice([-1, len(v), 2**31 - 1])
    return v, t, scale


def messy_bones(rng, scale):
    b = int(rng.integers(0, 7))
    heads = rng.normal(size=(b, 3)) * scale
    tails = heads + rng.normal(size=(b, 3)) * scale * rng.choice([0.0, 1.0, 1.0, 1.0, 1e-12])
    if rng.random() < 0.05 and b:
        heads[0, 0] = np.nan
    chain = rng.random() < 0.7
    parents = np.arange(b) - 1 if chain else rng.integers(-1, max(b, 1), size=b)
    return heads, tails, parents


def check_influences(name, out, n):
    idx, w = out
    assert idx.shape == w.shape and idx.shape[0] == n, name
    assert np.isfinite(w).all() and (w >= 0).all(), name
    if n and w.shape[1]:
        np.testing.assert_allclose(w.sum(1), 1.0, atol=1e-4, err_msg=name)


@pytest.mark.parametrize("seed", range(4))
def test_messy_meshes_and_bones(seed):
    rng = np.random.default_rng(seed)
    answered = 0
    for _ in range(150):
        v, t, scale = messy_mesh(rng)
        heads, tails, parents = messy_bones(rng, scale)
        opts = {}
        if rng.random() < 0.3:
            opts["parents"] = parents
        if rng.random() < 0.2:
            opts["bone_mirror"] = rng.integers(-1, max(len(heads), 1), size=len(heads))
        if rng.random() < 0.2:
            opts["max_influences"] = int(rng.integers(1, 9))
        if rng.random() < 0.1:
            opts["visibility"] = False
        for name, out in [
            ("heat", attempt(msc.heat_weights, v, t, heads, tails, **opts)),
            ("idw", attempt(msc.idw_weights, v, heads, tails)),
            ("bilinear", attempt(msc.bilinear_weights, v, heads, tails, parents if rng.random() < 0.5 else None)),
        ]:
            if out is not None:
                check_influences(name, out, len(v))
                answered += 1
        many = attempt(msc.heat_weights_many, [(v, t), (v[:5], t[:3])], heads, tails)
        if many is not None:
            assert len(many) == 2
        joints = np.concatenate([heads, tails[-1:]]) if len(heads) else rng.normal(size=(2, 3))
        pairs = np.array([[i, i + 1] for i in range(len(joints) - 1)]).reshape(-1, 2)
        fitted = attempt(msc.fit_joints, v, t, joints, pairs, symmetry_axis=0 if rng.random() < 0.3 else None)
        if fitted is not None:
            assert fitted[0].shape == joints.shape and np.isfinite(fitted[0]).all()
        inside = attempt(msc.points_inside, v, t, rng.normal(size=(5, 3)) * scale)
        if inside is not None:
            assert inside.shape == (5,)
        attempt(msc.touching_meshes, v, rng.integers(0, 3, size=len(v)), 3)
        sizes = rng.integers(3, 5, size=len(t))
        limit = attempt(msc.catmull_clark_limit, v, sizes, rng.integers(0, max(len(v), 1), size=int(sizes.sum())))
        if limit is not None:
            assert limit.shape == (len(v), 3)
        if len(heads):
            idx = rng.integers(-1, len(heads) + 1, size=(len(v), 2))
            attempt(msc.lbs, v, idx, rng.random(size=(len(v), 2)), np.tile(np.eye(4), (len(heads), 1, 1)))
    assert answered > 100  # most of the messy input gets weights, not errors


@pytest.mark.parametrize("seed", range(4))
def test_odd_options(seed):
    rng = np.random.default_rng(seed)
    v, t = msc.capped_cylinder(0.5, 4.0, 8, 10)
    heads, tails, parents = msc.bone_chain(4.0, 4)
    joints = np.concatenate([heads, tails[-1:]])
    pairs = np.array([[i, i + 1] for i in range(4)])

    def odd(keys):
        return {k: float(rng.choice(ODD)) for k in keys if rng.random() < 0.3}

    for _ in range(100):
        opts = odd(["min_weight", "weld_tolerance", "heat_constant", "symmetry_tolerance"])
        if rng.random() < 0.2:
            opts.update(bone_mirror=np.arange(4), symmetry_axis=int(rng.integers(-1, 4)))
        if rng.random() < 0.2:
            opts.update(curve_points=rng.normal(size=(3, 3)) * rng.choice([1.0, np.nan]),
                        curve_bones=rng.integers(0, 5, size=3))
        out = attempt(msc.heat_weights, v, t, heads, tails, **opts)
        if out is not None:
            check_influences(f"heat {opts}", out, len(v))
        out = attempt(msc.idw_weights, v, heads, tails, **odd(["power", "epsilon"]))
        if out is not None:
            check_influences("idw", out, len(v))
        out = attempt(msc.bilinear_weights, v, heads, tails, parents, **odd(["sigma", "power"]))
        if out is not None:
            check_influences("bilinear", out, len(v))
        opts = odd(["tolerance", "stiffness", "max_move", "stub_ratio", "symmetry_plane"])
        fitted = attempt(msc.fit_joints, v, t, joints + rng.normal(size=joints.shape) * 0.2, pairs, **opts)
        if fitted is not None:
            assert np.isfinite(fitted[0]).all(), opts
        opts = odd(["tolerance", "base_angle"])
        if rng.random() < 0.3:
            opts["limits"] = rng.normal(size=(3, 2)) * rng.choice([1.0, np.nan, 1e30])
        target = tuple(rng.choice(ODD, size=2)) if rng.random() < 0.2 else tuple(rng.normal(size=2))
        for method in ("ccd", "ccd_pure", "ccd_classic3d", "fabrik"):
            solved = attempt(msc.ik2d_solve, [1.0, 0.8, 0.5], target, method=method, **opts)
            if solved is not None:
                assert np.isfinite(solved[0]).all(), (method, opts, target)
        effectors = [(3, target, float(rng.choice(ODD))), (2, (0.5, 0.5), 1.0)]
        solved = attempt(msc.ik2d_solve_multi, [1.0, 0.8, 0.5], effectors, **opts)
        if solved is not None:
            assert np.isfinite(solved[0]).all(), (effectors, opts)


@pytest.mark.parametrize("seed", range(4))
def test_perturbed_rigs_make_finite_motions_or_errors(seed):
    """The biped scaled, with a zero-length bone, a zero / NaN / sheared / turned rest frame, a
    stray joint or jitter, and odd clip settings."""
    rng = np.random.default_rng(seed)
    made = 0
    for _ in range(100):
        heads, tails, parents, rest, names = biped()
        heads, tails, rest = heads.astype(np.float64), tails.astype(np.float64), rest.astype(np.float64)
        scale = 10.0 ** rng.uniform(-8, 8) if rng.random() < 0.3 else 1.0
        heads *= scale
        tails *= scale
        r, k = rng.random(), rng.integers(0, len(heads))
        if r < 0.15:
            tails[k] = heads[k]
        elif r < 0.25:
            rest[k] = 0.0
        elif r < 0.3:
            rest[k, rng.integers(0, 3), rng.integers(0, 3)] = np.nan
        elif r < 0.45:
            rest = rest @ np.linalg.qr(rng.normal(size=(3, 3)))[0]
        elif r < 0.55:
            rest = rest * rng.normal(size=rest.shape)
        elif r < 0.6:
            heads[k] += rng.normal(size=3) * scale * 5
        elif r < 0.7:
            heads += rng.normal(size=heads.shape) * scale * 0.05
            tails += rng.normal(size=tails.shape) * scale * 0.05
        clip = {key: float(rng.choice(values)) for key, values in [
            ("fps", [24, 1, 0.3, 1e4, 0, -5, np.nan]), ("amplitude", [0.5, 0, -1, 10, np.nan]),
            ("stride", [1, 0, -1, 1e9, np.nan]), ("speed", [1, 0.1, 10, 0, np.inf]),
            ("cycles", [2, 0.5, 0, 1e5]), ("duration", [2, 0, 1e4])] if rng.random() < 0.25}
        for motion in ("WALK", "RUN", "HEAD_SHAKE"):
            out = attempt(msc.make_motion, heads, tails, parents, rest, motion,
                          names=names if rng.random() < 0.7 else None, **clip)
            if out is None:
                continue
            made += 1
            for key in ("rotations", "root_offset", "locations"):
                assert np.isfinite(out[key]).all(), (motion, key, r, clip)
            np.testing.assert_allclose(np.linalg.norm(out["rotations"], axis=-1), 1.0, atol=1e-3)
    assert made > 100
