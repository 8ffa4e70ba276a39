"""Random bad input at every miniskeleton_core entry point (fixed seeds), each case with the one
outcome it must have: a valid result whose properties are checked, or the exception type and
message the fault calls for. Never a panic across the boundary (pyo3 turns a Rust panic into
PanicException, a BaseException that fails these tests) and never "some ValueError".

Messy but valid meshes (random soups, collinear or coincident points, several pieces with
duplicate faces, non-manifold fans, turned cylinders, scales from 1e-9 to 1e9, zero-length
bones) must get weights; one fault at a time is put in (a NaN or infinite vertex, no vertices,
no triangles, a triangle index past the end, -1 or 2^31 - 1, no bones, a NaN bone, fewer tails
than heads, a bone its own parent, a parent cycle, a one-way bone mirror) and every function
that reads what the fault spoiled must name it. Odd options go in one at a time, each value
checked against the option's documented range. Perturbed rigs make finite motions unless
the fault (a NaN rest frame, an odd clip setting, a rig without legs) calls for its error.
Each test counts what it checked and has floors, so it cannot pass on nothing."""

from __future__ import annotations

import collections
import math
import re

import numpy as np
import pytest

import miniskeleton_core as msc
from testkit.skeletons import biped

ODD = [0.0, -1.0, 1e-30, 1e30, np.nan, np.inf, -np.inf, 0.5, 2.0]


def outcome(expected, f, *args, **kwargs):
    """Call ``f``: with ``expected`` None it must return (its result is returned); else
    ``expected`` is (exception type, message regex) and it must raise exactly that (None is
    returned). Anything else fails with the call named."""
    try:
        out = f(*args, **kwargs)
    except Exception as e:  # noqa: BLE001 - compared with what was expected just below
        if expected is None:
            raise AssertionError(f"{f.__name__} refused valid input: {type(e).__name__}: {e}") from e
        kind, pattern = expected
        if type(e) is not kind or not re.search(pattern, str(e)):
            raise AssertionError(f"{f.__name__}: expected {kind.__name__} matching {pattern!r}, "
                                 f"got {type(e).__name__}: {e}") from e
        return None
    assert expected is None, f"{f.__name__}: expected {expected[0].__name__} matching {expected[1]!r}, got a result"
    return out


def check_influences(name, out, n, b, k):
    """Dense top-k influences of ``n`` vertices over ``b`` bones: k = min(max_influences, b)
    columns, bone indices in range (-1 only for unused slots, with weight 0), weights finite,
    not negative, every row's first slot used and every row summing to 1."""
    idx, w = out[0], out[1]
    assert idx.shape == w.shape == (n, min(k, b)), (name, idx.shape, n, b, k)
    assert ((idx >= -1) & (idx < b)).all(), name
    assert np.isfinite(w).all() and (w >= 0).all(), name
    assert (w[idx == -1] == 0).all(), name
    if n:
        assert (idx[:, 0] >= 0).all(), f"{name}: a vertex left unweighted"
        np.testing.assert_allclose(w.sum(1), 1.0, atol=1e-4, err_msg=name)


# ---------------------------------------------------------------- messy meshes and bones


def messy_mesh(rng):
    """A valid but messy mesh: (vertices (n, 3), triangles (m, 3), kind); "line" meshes have
    only degenerate triangles, every other kind has at least one proper triangle."""
    kind = ["cylinder", "soup", "line", "pieces", "fan", "turned"][rng.integers(0, 6)]
    if kind == "cylinder":  # small closed cylinders, possibly a single ring
        v, t = msc.capped_cylinder(0.5, 4.0, int(rng.integers(1, 12)), int(rng.integers(3, 12)))
    elif kind == "soup":  # random points and triangles, some with a vertex twice
        n = int(rng.integers(3, 40))
        v = rng.normal(size=(n, 3))
        t = rng.integers(0, n, size=(int(rng.integers(1, 60)), 3))
        t[0] = rng.choice(n, 3, replace=False)
    elif kind == "line":  # all points on a line, or all at one place
        n = int(rng.integers(1, 30))
        v = np.zeros((n, 3))
        v[:, 0] = rng.normal(size=n) * rng.integers(0, 2)
        t = rng.integers(0, n, size=(int(rng.integers(1, 40)), 3))
    elif kind == "pieces":  # several pieces and duplicate faces
        v0, t0 = msc.capped_cylinder(0.5, 4.0, 4, 6)
        k = int(rng.integers(1, 5))
        v = np.concatenate([v0 + rng.normal(size=3) * 3 for _ in range(k)])
        copies = [t0.astype(np.int64) + i * len(v0) for i in range(k)]
        t = np.concatenate(copies + [t0[: int(rng.integers(0, len(t0)))]])
    elif kind == "fan":  # a non-manifold fan: ten triangles on one edge
        v = rng.normal(size=(12, 3))
        t = np.array([[0, 1, i] for i in range(2, 12)])
    else:  # a cylinder lying along another axis
        v, t = msc.capped_cylinder(0.5, 4.0, 6, 8)
        v = v[:, rng.permutation(3)]
    v, t = np.array(v, np.float64), np.array(t, np.int64)
    if rng.random() < 0.3:
        v *= 10.0 ** rng.uniform(-9, 9)
    return v, t, kind


def messy_bones(rng, v):
    """1 to 6 bones around the mesh (some zero-length or 1e-12 long), valid parents (a chain
    or a random forest) and a valid mirror map (pairs, centre bones and unpaired side bones)."""
    b = int(rng.integers(1, 7))
    scale = float(np.abs(v).max()) if len(v) and np.abs(v).max() > 0 else 1.0
    heads = rng.normal(size=(b, 3)) * scale
    tails = heads + rng.normal(size=(b, 3)) * scale * rng.choice([0.0, 1.0, 1.0, 1.0, 1e-12])
    if rng.random() < 0.7:
        parents = np.arange(b) - 1
    else:
        parents = np.array([int(rng.integers(-1, i)) for i in range(b)])  # each below its parent
    mirror = np.arange(b)
    order = rng.permutation(b)
    for i, j in zip(order[0::2], order[1::2]):
        if rng.random() < 0.5:
            mirror[i], mirror[j] = j, i
    mirror[rng.random(b) < 0.1] = -1  # and its partner, if it had one, is left unpaired
    mirror = np.array([m if m < 0 or mirror[m] == i else -1 for i, m in enumerate(mirror)])
    return heads, tails, parents, mirror


MESH_FAULTS = ["nan vertex", "inf vertex", "no vertices", "no triangles", "index past the end",
               "negative index", "index 2^31-1"]
BONE_FAULTS = ["no bones", "nan bone", "fewer tails", "own parent", "parent cycle", "one-way mirror"]
# In 150 cases every fault 7 or 8 times, and 52 cases without one.
SCHEDULE = [None] * 7 + MESH_FAULTS + BONE_FAULTS
VE = ValueError


def put_fault(fault, rng, v, t, heads, tails, parents, mirror):
    """Spoil one thing; returns the inputs and {function: expected outcome} for the functions
    the fault reaches (the others must still return a valid result)."""
    n, b = len(v), len(heads)
    expect = {}
    mesh_readers = ("heat", "idw", "bilinear", "fit", "inside", "touching", "limit", "lbs")
    triangle_readers = ("heat", "fit", "inside")
    if fault in ("nan vertex", "inf vertex"):
        v = v.copy()
        v[rng.integers(0, n), rng.integers(0, 3)] = np.nan if fault == "nan vertex" else -np.inf
        expect = dict.fromkeys(mesh_readers, (VE, r"^1 vertex\(s\) have NaN or infinite values$"))
    elif fault == "no vertices":
        v, t = np.zeros((0, 3)), np.zeros((0, 3), np.int64)
        expect = dict.fromkeys(("heat", "idw", "bilinear", "fit", "inside"),
                               (VE, r"^empty mesh: the mesh has no vertices$"))
    elif fault == "no triangles":
        t = np.zeros((0, 3), np.int64)
        expect = dict.fromkeys(("fit", "inside"), (VE, r"^empty mesh: the mesh has no triangles$"))
    elif fault in ("index past the end", "index 2^31-1", "negative index"):
        t = t.copy()
        j, c = int(rng.integers(0, len(t))), int(rng.integers(0, 3))
        t[j, c] = {"index past the end": n, "index 2^31-1": 2**31 - 1, "negative index": -1}[fault]
        if fault == "negative index":  # refused as it is read, before anything runs
            expect = dict.fromkeys(triangle_readers, (
                VE, rf"^triangles\[{j}, {c}\] is -1: indices must be whole numbers in 0\.\.2\^32$"))
            expect["limit"] = (VE, rf"^face_vertices\[{3 * j + c}\] is -1: indices must be whole numbers")
        else:
            expect = dict.fromkeys(triangle_readers, (
                VE, rf"^triangle {j} refers to vertex {t[j, c]}, but the mesh has {n} vertices$"))
            expect["limit"] = (VE, rf"^invalid argument: a face refers to vertex {t[j, c]}, but the mesh has {n} ")
    elif fault == "no bones":
        heads, tails, parents, mirror = np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int), np.zeros(0, int)
        expect = dict.fromkeys(("heat", "idw", "bilinear"), (VE, r"^no bones: the bone list is empty$"))
    elif fault == "nan bone":
        heads = heads.copy()
        heads[0, 0] = np.nan
        expect = dict.fromkeys(("heat", "idw", "bilinear"), (VE, r"^1 bone\(s\) have NaN or infinite values$"))
        expect["fit"] = (VE, r"^1 joint\(s\) have NaN or infinite values$")
    elif fault == "fewer tails":
        tails = tails[:-1]
        expect = dict.fromkeys(("heat", "idw", "bilinear"), (
            VE, rf"^shape mismatch: {b} bone heads but {b - 1} bone tails$"))
    elif fault == "own parent":
        k = int(rng.integers(0, b))
        parents = parents.copy()
        parents[k] = k
        expect = dict.fromkeys(("heat", "bilinear"), (
            VE, rf"^invalid argument: parent of bone {k} is {k}; it must be -1 or another bone's index \(0\.\.{b}\)$"))
    elif fault == "parent cycle":
        parents = np.roll(np.arange(b), 1)  # 0 <- b-1 <- ... <- 1 <- 0
        expect = dict.fromkeys(("heat", "bilinear"), (VE, r"^invalid argument: bone \d+ is in a parent cycle$"))
    elif fault == "one-way mirror":
        mirror = np.arange(b)
        mirror[0] = 1  # bone 0 -> 1, but 1 -> 1
        expect["heat"] = (VE, r"^invalid argument: bone_mirror must pair bones both ways \(bone 0 -> 1\)$")
    return v, t, heads, tails, parents, mirror, expect


@pytest.mark.parametrize("seed", range(4))
def test_messy_meshes_and_bones(seed):
    rng = np.random.default_rng(seed)
    results, refused, faults = collections.Counter(), collections.Counter(), collections.Counter()
    for case in range(150):
        fault = SCHEDULE[case % len(SCHEDULE)]
        faults[fault] += 1
        v, t, kind = messy_mesh(rng)
        heads, tails, parents, mirror = messy_bones(rng, v)
        if fault in ("own parent", "parent cycle", "one-way mirror", "fewer tails") and len(heads) < 2:
            heads, tails = np.concatenate([heads, heads + 1.0]), np.concatenate([tails, tails + 1.0])
            parents, mirror = np.array([-1, 0]), np.array([0, 1])
        joints = np.concatenate([heads, tails[-1:]])  # before any fault: the fit's own input
        v, t, heads, tails, parents, mirror, expect = put_fault(fault, rng, v, t, heads, tails, parents, mirror)
        n, b = len(v), len(heads)
        if fault == "nan bone":
            joints[0, 0] = np.nan
        elif fault == "no bones":
            joints = rng.normal(size=(2, 3))

        opts = dict(max_influences=int(rng.integers(1, 9)), visibility=bool(rng.random() < 0.8))
        if fault in ("own parent", "parent cycle") or rng.random() < 0.3:
            opts["parents"] = parents
        if fault == "one-way mirror" or rng.random() < 0.3:
            opts["bone_mirror"] = mirror
        use_parents = "parents" in opts or rng.random() < 0.5
        for name, k, out in [
            ("heat", opts["max_influences"], outcome(expect.get("heat"), msc.heat_weights, v, t, heads, tails, **opts)),
            ("idw", 4, outcome(expect.get("idw"), msc.idw_weights, v, heads, tails)),
            ("bilinear", 4, outcome(expect.get("bilinear"), msc.bilinear_weights, v, heads, tails,
                                    parents if use_parents else None)),
        ]:
            if out is not None:
                check_influences(f"{name} ({kind}, {fault})", out, n, b, k)
                results[name] += 1
            else:
                refused[name] += 1

        # Several meshes in one call: the spoiled one gets its error in its place, the good one
        # its weights; an index that is not a whole number in range is refused for the call.
        good = tuple(msc.capped_cylinder(0.5, 4.0, 3, 6))
        many = outcome(expect.get("heat") if fault == "negative index" else None,
                       msc.heat_weights_many, [(v, t), good], heads, tails, **opts)
        if many is not None:
            assert len(many) == 2
            bone_fault = fault in BONE_FAULTS
            for entry, (mesh_n, spoiled) in zip(many, [(n, True), (len(good[0]), bone_fault)]):
                want = expect.get("heat") if spoiled else None
                if want is None:
                    assert isinstance(entry, msc.Weights) and isinstance(entry.report, msc.WeightsReport), entry
                    check_influences(f"heat_many ({kind}, {fault})", (entry.indices, entry.weights), mesh_n, b,
                                     opts["max_influences"])
                    results["heat_many"] += 1
                else:
                    assert type(entry) is want[0] and re.search(want[1], str(entry)), (fault, entry)
                    refused["heat_many"] += 1

        symmetric = rng.random() < 0.3  # every joint free of a partner: no plane to refuse
        sym = dict(symmetry_axis=int(rng.integers(0, 3)), joint_mirror=-np.ones(len(joints))) if symmetric else {}
        pairs = np.array([[i, i + 1] for i in range(len(joints) - 1)]).reshape(-1, 2)
        want = expect.get("fit")
        if want is None and kind == "line":
            want = (VE, r"^empty mesh: every triangle of the mesh is degenerate$")
        fitted = outcome(want, msc.fit_joints, v, t, joints, pairs, **sym)
        if fitted is not None:
            assert fitted.joints.shape == joints.shape and np.isfinite(fitted.joints).all()
            assert fitted.pieces >= 1 and (fitted.mirrored_surface is None) != symmetric
            results["fit"] += 1
        else:
            refused["fit"] += 1

        size = float(np.abs(v[np.isfinite(v)]).max()) if np.isfinite(v).any() else 1.0
        size = size or 1.0
        probes = np.concatenate([[[0.0, 0.0, 2.0 * size / 4.0], [10 * size, 10 * size, 10 * size]],
                                 rng.normal(size=(3, 3)) * size])
        inside = outcome(expect.get("inside"), msc.points_inside, v, t, probes)
        if inside is not None:
            assert inside.shape == (5,) and inside.dtype == bool
            assert not inside[1], "a point far outside the mesh's box is inside"
            if kind == "cylinder":  # the middle of its axis
                assert inside[0], "the middle of a closed cylinder is not inside it"
            results["inside"] += 1
        else:
            refused["inside"] += 1

        mesh_of = rng.integers(0, 3, size=n)
        groups = outcome(expect.get("touching"), msc.touching_meshes, v, mesh_of, 3)
        if groups is not None:  # numbered in order of each group's first mesh
            assert groups.shape == (3,) and groups[0] == 0
            assert all(g <= max(groups[:i], default=-1) + 1 for i, g in enumerate(groups))
            results["touching"] += 1
        else:
            refused["touching"] += 1

        limit = outcome(expect.get("limit"), msc.catmull_clark_limit, v, np.full(len(t), 3), t.ravel())
        if limit is not None:
            assert limit.shape == (n, 3) and np.isfinite(limit).all()
            results["limit"] += 1
        else:
            refused["limit"] += 1

        # Skinning by a translation: weighted vertices move by it, all-zero rows stay.
        nb = max(b, 1)
        idx = rng.integers(-1, nb, size=(n, 2))
        w = rng.random(size=(n, 2)) * (rng.random(size=(n, 1)) < 0.9)
        shift = np.array([1.0, -2.0, 3.0]) * size
        mats = np.tile(np.eye(4), (nb, 1, 1))
        mats[:, :3, 3] = shift
        moved = outcome(expect.get("lbs"), msc.lbs, v, idx, w, mats)
        if moved is not None:
            held = ((w > 0) & (idx >= 0)).any(axis=1)
            want_v = v + np.where(held[:, None], shift, 0.0)
            np.testing.assert_allclose(moved, want_v, rtol=1e-5, atol=1e-5 * size)
            results["lbs"] += 1
        else:
            refused["lbs"] += 1
        # A slot naming a bone past the matrices is refused, naming the place.
        if n and case % 5 == 0:
            idx[n - 1, 1] = nb
            outcome((VE, rf"^invalid argument: vertex {n - 1} slot 1 refers to bone {nb}, but there are {nb} "
                         r"bone matrices \(use -1 for an unused slot\)$") if fault not in ("nan vertex", "inf vertex")
                    else expect["lbs"], msc.lbs, v, idx, w, mats)
            refused["lbs past the matrices"] += 1

    # Floors: each fault was put in 7 or 8 times, every function checked results in most of
    # the cases and refused the faults that reach it (the counts follow from SCHEDULE).
    assert set(faults) == set(SCHEDULE) and min(faults.values()) >= 7, faults
    for name in ("heat", "idw", "bilinear", "fit", "inside", "touching", "limit", "lbs"):
        assert results[name] >= 60, (name, results)
    assert results["heat_many"] >= 150
    floors = dict(heat=85, idw=45, bilinear=55, heat_many=120, fit=60, inside=50, touching=15, limit=35, lbs=15)
    floors["lbs past the matrices"] = 30
    assert all(refused[name] >= floor for name, floor in floors.items()), refused


# ---------------------------------------------------------------- odd options, one at a time


def finite_at_least(lo, strict=False):
    """A rule: finite and >= lo (> lo when strict)."""
    return lambda x: math.isfinite(x) and (x > lo if strict else x >= lo)


def above(lo):
    """A rule: > lo, infinity allowed (NaN is not)."""
    return lambda x: x > lo


@pytest.mark.parametrize("seed", range(4))
def test_odd_options(seed):
    """Every float option of the weights, the fit and the planar IK takes each value of ODD
    (0, -1, 1e-30, 1e30, NaN, +-inf, 0.5, 2), the others at their defaults, and the whole-number
    options their edges (max_influences, nearest, symmetry_axis, rays, samples, the IK's
    max_iterations up to MAX_ITERATIONS = 10 000): a value in the option's documented range gives a checked result, any
    other the option's own error."""
    rng = np.random.default_rng(seed)
    v, t = msc.capped_cylinder(0.5, 4.0, 8, 10)
    heads, tails, parents = msc.bone_chain(4.0, 4)
    joints = np.concatenate([heads, tails[-1:]])
    jittered = joints + rng.normal(size=joints.shape) * 0.2
    pairs = np.array([[i, i + 1] for i in range(4)])
    n = len(v)
    tried = collections.Counter()

    def run(name, option, value, ok, pattern, check, f, *args, **kwargs):
        """``f(*args, **kwargs)`` with ``option`` = ``value``: a result passing ``check`` when
        ``ok(value)``, else a ValueError matching ``pattern``; counted in ``tried``."""
        expected = None if ok(value) else (VE, pattern)
        out = outcome(expected, f, *args, **kwargs)
        if out is not None:
            check(out)
        tried[name, option, "result" if out is not None else "refused"] += 1

    def weights(k=4):
        return lambda out: check_influences("weights", out, n, 4, k)

    def fitted(out):
        assert out.joints.shape == joints.shape and np.isfinite(out.joints).all()

    def anything(x):
        return True

    heat_rules = {
        "min_weight": (lambda x: math.isfinite(x) and 0 <= x < 1, r"^invalid argument: min_weight must be in \[0, 1\)"),
        "weld_tolerance": (finite_at_least(0), r"^invalid argument: weld_tolerance must be >= 0, got "),
        "heat_constant": (finite_at_least(0, strict=True), r"^invalid argument: heat_constant must be > 0, got "),
    }
    idw_rules = {
        "power": (finite_at_least(0), r"^invalid argument: power must be finite and >= 0, got "),
        "epsilon": (finite_at_least(0), r"^invalid argument: epsilon must be finite and >= 0, got "),
    }
    fit_pattern = r"^invalid argument: fit options: rays 3\.\.=\d+, samples 1\.\.=\d+, stiffness > 0"
    fit_rules = {"tolerance": above(0), "stiffness": above(0), "max_move": above(0), "stub_ratio": lambda x: x >= 0}
    positive = finite_at_least(0, strict=True)
    for value in ODD:
        for option, (ok, pattern) in heat_rules.items():
            run("heat", option, value, ok, pattern, weights(), msc.heat_weights, v, t, heads, tails, **{option: value})
        run("heat", "symmetry_tolerance", value, finite_at_least(0),
            r"^invalid argument: mirror tolerance must be >= 0$", weights(),
            msc.heat_weights, v, t, heads, tails, symmetry_tolerance=value, bone_mirror=np.arange(4))
        # Without a mirror map the symmetry tolerance is not read.
        run("heat", "symmetry_tolerance (no mirror)", value, anything, "", weights(),
            msc.heat_weights, v, t, heads, tails, symmetry_tolerance=value)
        for option, (ok, pattern) in idw_rules.items():
            run("idw", option, value, ok, pattern, weights(), msc.idw_weights, v, heads, tails, **{option: value})
        run("bilinear", "sigma", value, positive, r"^invalid argument: sigma must be > 0, got ", weights(),
            msc.bilinear_weights, v, heads, tails, parents, sigma=value)
        run("bilinear", "power", value, positive, r"^invalid argument: power must be > 0, got ", weights(),
            msc.bilinear_weights, v, heads, tails, parents, falloff="inverse_power", power=value)
        # The Gaussian falloff does not read the power.
        run("bilinear", "power (gaussian)", value, anything, "", weights(),
            msc.bilinear_weights, v, heads, tails, parents, power=value)
        for option, ok in fit_rules.items():
            run("fit", option, value, ok, fit_pattern, fitted, msc.fit_joints, v, t, jittered, pairs, **{option: value})
        run("fit", "symmetry_plane", value, math.isfinite, r"^1 symmetry plane\(s\) have NaN or infinite values$",
            fitted, msc.fit_joints, v, t, jittered, pairs, symmetry_axis=0, joint_mirror=-np.ones(5),
            symmetry_plane=value)
        run("fit", "symmetry_plane (no symmetry)", value, anything, "", fitted,
            msc.fit_joints, v, t, jittered, pairs, symmetry_plane=value)

    # Whole-number options: their edges.
    one = r"^(invalid argument: )?(nearest and )?max_influences must be (>= 1|at least 1)$"
    for k in (0, 1, 4, 16):
        run("heat", "max_influences", k, lambda x: x >= 1, one, weights(k),
            msc.heat_weights, v, t, heads, tails, max_influences=k)
        run("idw", "max_influences", k, lambda x: x >= 1, one, weights(k),
            msc.idw_weights, v, heads, tails, max_influences=k)
        run("bilinear", "max_influences", k, lambda x: x >= 1, one, weights(k),
            msc.bilinear_weights, v, heads, tails, parents, max_influences=k)
        run("bilinear", "nearest", k, lambda x: x >= 1, one, weights(),
            msc.bilinear_weights, v, heads, tails, parents, nearest=k)
    for axis in (0, 1, 2, 3):
        run("heat", "symmetry_axis", axis, lambda x: x <= 2, r"^symmetry_axis must be 0, 1 or 2$", weights(),
            msc.heat_weights, v, t, heads, tails, bone_mirror=np.arange(4), symmetry_axis=axis)
    outcome((OverflowError, "can't convert negative int to unsigned"), msc.heat_weights, v, t, heads, tails,
            bone_mirror=np.arange(4), symmetry_axis=-1)
    outcome((OverflowError, "can't convert negative int to unsigned"), msc.Ik2dOptions, max_iterations=-1)
    outcome((VE, r"^falloff must be 'gaussian' or 'inverse_power', got \"cubic\"$"), msc.bilinear_weights,
            v, heads, tails, parents, falloff="cubic")
    for rays, samples in [(2, 5), (3, 5), (12, 0), (12, 1)]:
        run("fit", "rays/samples", (rays, samples), lambda x: x[0] >= 3 and x[1] >= 1, fit_pattern, fitted,
            msc.fit_joints, v, t, jittered, pairs, rays=rays, samples=samples)
    # Bent bones: points on a bone that is not there, or NaN points, are refused.
    points = rng.normal(size=(3, 3))
    for bones, nan, ok in [([0, 1, 3], False, True), ([0, 4, 1], False, False), ([0, 1, 1], True, False)]:
        pattern = (r"^3 curve point\(s\) have NaN or infinite values$" if nan else
                   r"^invalid argument: curve point of bone 4, but there are 4 bones$")
        run("heat", "curve_points", (bones, nan), lambda x, ok=ok: ok, pattern, weights(),
            msc.heat_weights, v, t, heads, tails, curve_points=points * (np.nan if nan else 1.0),
            curve_bones=np.array(bones))

    # Planar IK: a three-bone chain, every method.
    lengths = [1.0, 0.8, 0.5]
    reach = sum(lengths)

    def ik_solve(lengths, target, *, base_angle=0.0, limits=None, **options):
        """ik2d_solve as the add-on calls it: a chain and options built here, then solved."""
        chain = msc.Chain2d(lengths, base_angle=base_angle, limits=limits)
        return msc.ik2d_solve(chain, target, msc.Ik2dOptions(**options))

    def ik_solve_multi(lengths, effectors, **options):
        return msc.ik2d_solve_multi(msc.Chain2d(lengths), effectors, msc.Ik2dOptions(**options))

    def solved(limits=None, tolerance=None, target=None):
        def check(out):
            angles = out.angles
            assert angles.shape == (3,) and np.isfinite(angles).all()
            assert isinstance(out, msc.Ik2dSolution) and np.isfinite(out.error) and out.iterations >= 0
            if limits is not None:
                assert ((angles >= limits[:, 0] - 1e-9) & (angles <= limits[:, 1] + 1e-9)).all(), (angles, limits)
            if out.reached and target is not None:  # the tip is where the solution says
                tip = msc.ik2d_forward(msc.Chain2d(lengths, angles))[-1]
                tol = tolerance if tolerance is not None else 1e-3 * reach
                assert np.hypot(*(tip - target)) <= tol * 1.01 + 1e-9, (tip, target, out.error)
        return check

    tolerance_pattern = r"^invalid argument: tolerance must be finite and >= 0, got "
    too_many = r"invalid argument: max_iterations must be at most 10000, got 10001"
    for _ in range(6):
        target = rng.normal(size=2)
        aim = tuple(target)
        for method in ("ccd", "ccd_pure", "ccd_classic3d", "fabrik"):
            name = f"ik {method}"
            for value in ODD:
                run(name, "tolerance", value, finite_at_least(0), tolerance_pattern,
                    solved(tolerance=value, target=target), ik_solve, lengths, aim, method=method,
                    tolerance=value)
                run(name, "base_angle", value, math.isfinite, r"^1 IK chain\(s\) have NaN or infinite values$",
                    solved(), ik_solve, lengths, aim, method=method, base_angle=value)
                odd = (value, aim[1])
                run(name, "target", value, math.isfinite, r"^1 target\(s\) have NaN or infinite values$",
                    solved(target=np.array(odd)), ik_solve, lengths, odd, method=method)
            # Limits: ordered in (-pi, pi) or as wide as 1e30 (the result within them), one NaN, or
            # a pair with min > max.
            limits = np.sort(rng.uniform(-3.0, 3.0, size=(3, 2)), axis=1)
            if rng.random() < 0.3:
                limits[rng.integers(0, 3)] = [-1e30, 1e30]
            run(name, "limits", "ordered", anything, "", solved(limits=limits),
                ik_solve, lengths, aim, method=method, limits=limits)
            nan = limits.copy()
            nan[rng.integers(0, 3), rng.integers(0, 2)] = np.nan
            run(name, "limits", "nan", lambda x: False, r"^1 joint limit\(s\) have NaN or infinite values$",
                solved(), ik_solve, lengths, aim, method=method, limits=nan)
            swapped = limits.copy()
            j = int(rng.integers(0, 3))
            swapped[j] = swapped[j, ::-1] + [1.0, -1.0]
            run(name, "limits", "min > max", lambda x: False,
                rf"^invalid argument: joint {j} has limits \[.*\] with min > max$",
                solved(), ik_solve, lengths, aim, method=method, limits=swapped)
            # Passes: at most MAX_ITERATIONS (the solvers run without the GIL, uninterruptible).
            for passes in (0, 1, 10_000, 10_001):
                run(name, "max_iterations", passes, lambda x: x <= 10_000, rf"^{too_many}$", solved(),
                    ik_solve, lengths, aim, method=method, max_iterations=passes)
        for value in ODD:
            run("ik multi", "weight", value, finite_at_least(0),
                r"^invalid argument: effector 0 has weight \S+; weights must be finite and >= 0$",
                solved(), ik_solve_multi, lengths, [(3, aim, value), (2, (0.5, 0.5), 1.0)])
            run("ik multi", "target", value, math.isfinite, r"^1 effector target\(s\) have NaN or infinite values$",
                solved(), ik_solve_multi, lengths, [(3, (value, 0.3), 1.0), (2, (0.5, 0.5), 1.0)])
            run("ik multi", "tolerance", value, finite_at_least(0), tolerance_pattern,
                solved(), ik_solve_multi, lengths, [(3, aim, 1.0)], tolerance=value)
        for passes in (0, 10_000, 10_001):
            run("ik multi", "max_iterations", passes, lambda x: x <= 10_000, rf"^{too_many}$", solved(),
                ik_solve_multi, lengths, [(3, aim, 1.0)], max_iterations=passes)
        for joint in (0, 1, 3, 4):
            run("ik multi", "joint", joint, lambda x: 1 <= x <= 3,
                rf"^invalid argument: effector 0 is on joint {joint}, but a chain of 3 bones has movable joints",
                solved(), ik_solve_multi, lengths, [(joint, aim, 1.0)])
        outcome((VE, r"^invalid argument: all effector weights are zero$"), ik_solve_multi, lengths,
                [(3, aim, 0.0), (2, (0.5, 0.5), 0.0)])

    # Floors: every option was tried, and each took values in its range and values outside it
    # (but those its function does not read, which must never be refused).
    options = {(name, option) for name, option, _ in tried}
    assert len(options) >= 40, sorted(options)
    for name, option in options:
        accepted, refused = tried[name, option, "result"], tried[name, option, "refused"]
        assert accepted >= 1, (name, option, "no value in range was tried")
        if "(no " in option or "(gaussian)" in option:
            assert refused == 0, (name, option)
        else:
            assert refused >= 1, (name, option, "no value out of range was tried")
    assert sum(c for (_, _, kind), c in tried.items() if kind == "result") >= 600
    assert sum(c for (_, _, kind), c in tried.items() if kind == "refused") >= 400


# ---------------------------------------------------------------- motions of perturbed rigs


CLIP_RULES = {
    # option: (values tried, rule, message when outside it); one per clip, the others at their defaults
    "fps": ([24, 1, 0.3, 1e4, 0, -5, np.nan], lambda x: x > 0 and math.isfinite(x),
            r"^invalid argument: fps must be positive, got "),
    "cycles": ([2, 0.5, 0, -1, 1e6, np.inf], lambda x: x > 0 and math.isfinite(x),
               r"^invalid argument: cycles must be positive, got "),
    "speed": ([1, 0.1, 10, 0, -1, np.inf], lambda x: x > 0 and math.isfinite(x),
              r"^invalid argument: speed must be positive and stride not negative$"),
    "stride": ([1, 0, -1, 1e9, np.nan], lambda x: x >= 0 and math.isfinite(x),
               r"^invalid argument: speed must be positive and stride not negative$"),
    "amplitude": ([0.5, 0, -1, 10, np.nan, np.inf], math.isfinite, r"^invalid argument: amplitude must be finite$"),
    "duration": ([2, 0.01, 0, -1, 1e4, np.nan], lambda x: x > 0 and math.isfinite(x),
                 r"^invalid argument: duration must be positive, got "),
}


def clip_outcome(option: str, x: float, motion: str):
    """What ``make_motion`` must do with ``option`` = ``x``: None (a clip) or its error. The
    duration is a head shake's only (a walk's length is its cycles); a million cycles of any
    walk or run are more frames than Blender has (a cycle is at least 8 frames)."""
    shake = motion == "HEAD_SHAKE"
    if option == "duration" and not shake:
        return None
    if option == "cycles" and x == 1e6:
        return None if shake else (VE, r"^invalid argument: the clip would have \d+ frames; at most 1048574 ")
    _, ok, pattern = CLIP_RULES[option]
    return None if ok(x) else (VE, pattern)


def rounded(x) -> int:
    """Rust's f32 round (half away from zero) of a positive ``x``."""
    return math.floor(float(x) + 0.5)


@pytest.mark.parametrize("seed", range(4))
def test_perturbed_rigs_make_finite_motions_or_errors(seed):
    """The biped scaled, with a zero-length bone, a zero / NaN / sheared / turned rest frame, a
    stray joint or jitter, or one odd clip setting. A NaN rest frame, a clip setting out of its
    range (or a clip longer than Blender's last frame) and, for a walk or a run, a rig in
    which ``detect_roles`` finds no legs are refused with their own message; every
    other case makes a clip of finite keys, unit quaternions and the frames it asked for."""
    rng = np.random.default_rng(seed)
    made, refused = collections.Counter(), collections.Counter()
    perturbations = ["none", "zero-length", "zero rest", "nan rest", "turned", "sheared", "stray", "jitter", "clip"]
    for case in range(108):
        heads, tails, parents, rest, names = biped()
        heads, tails, rest = heads.astype(np.float64), tails.astype(np.float64), rest.astype(np.float64)
        scale = 10.0 ** rng.uniform(-8, 8) if rng.random() < 0.3 else 1.0
        heads *= scale
        tails *= scale
        what, k = perturbations[case % len(perturbations)], rng.integers(0, len(heads))
        clip, expect = {}, None
        if what == "zero-length":
            tails[k] = heads[k]
        elif what == "zero rest":
            rest[k] = 0.0
        elif what == "nan rest":
            rest[k, rng.integers(0, 3), rng.integers(0, 3)] = np.nan
            expect = (VE, r"^1 rest matrix\(s\) have NaN or infinite values$")
        elif what == "turned":
            rest = rest @ np.linalg.qr(rng.normal(size=(3, 3)))[0]
        elif what == "sheared":
            rest = rest * rng.normal(size=rest.shape)
        elif what == "stray":
            heads[k] += rng.normal(size=3) * scale * 5
        elif what == "jitter":
            heads += rng.normal(size=heads.shape) * scale * 0.05
            tails += rng.normal(size=tails.shape) * scale * 0.05
        elif what == "clip":
            option = list(CLIP_RULES)[case // len(perturbations) % len(CLIP_RULES)]
            clip[option] = float(rng.choice(CLIP_RULES[option][0]))
        use_names = names if rng.random() < 0.7 else None
        # The roles make_motion finds: without legs, a walk or a run is refused.
        try:
            roles, unfound = msc.detect_roles(heads, tails, parents, names=use_names), None
        except ValueError as e:  # then every motion is refused with the same words
            roles, unfound = None, (VE, "^" + re.escape(str(e)) + "$")
        legless = unfound or (None if roles.legs else (VE, r"^no legs: no two bone chains branch off the body"))
        for motion in ("WALK", "RUN", "HEAD_SHAKE"):
            want = expect
            if clip:
                want = clip_outcome(*next(iter(clip.items())), motion)
            if want is None and (motion != "HEAD_SHAKE" or unfound):
                want = legless
            out = outcome(want, msc.make_motion, heads, tails, parents, rest, motion, names=use_names, **clip)
            if out is None:
                refused[what] += 1
                continue
            made[what] += 1
            frames = out.frames
            for key in ("rotations", "root_offset", "locations"):
                assert np.isfinite(getattr(out, key)).all(), (motion, key, what, clip)
            assert out.rotations.shape == (frames, len(heads), 4)
            np.testing.assert_allclose(np.linalg.norm(out.rotations, axis=-1), 1.0, atol=1e-3)
            if motion == "HEAD_SHAKE":
                fps, duration = clip.get("fps", 24.0), clip.get("duration", 2.0)
                assert frames == max(rounded(np.float32(fps) * np.float32(duration)), 2) + 1, (frames, clip)
            else:
                cycles = np.float32(clip.get("cycles", 2.0))
                assert frames == max(rounded(cycles * np.float32(out.frames_per_cycle)), 1) + 1, (frames, clip)
    # Floors: 12 cases of each perturbation, 3 motions each.
    assert all(made[what] == 36 for what in ("none", "zero rest", "turned", "sheared", "jitter")), made
    assert refused["nan rest"] == 36 and made["clip"] >= 12 and refused["clip"] >= 12, (made, refused)
    assert sum(made.values()) >= 240, made
