"""The motion API of miniskeleton_core from plain Python: bone roles and clips (head shake, walk,
run)."""

import numpy as np
import pytest

import miniskeleton_core as msc
from testkit.skeletons import biped


def test_make_motion_frames_and_a_clip_too_long_for_blender():
    h, t, p, rest, names = biped()
    shake = msc.make_motion(h, t, p, rest, "HEAD_SHAKE", names=names, fps=24, duration=2)
    assert shake.frames == 49 and shake.rotations.shape == (49, 10, 4)
    assert np.isfinite(shake.rotations).all() and not shake.moves_root
    walk = msc.make_motion(h, t, p, rest, "WALK", names=names, cycles=2)
    assert walk.frames == 2 * walk.frames_per_cycle + 1 and walk.moves_root
    # feet on their legs: nothing is moved by location
    assert walk.locations.shape == (walk.frames, 10, 3) and not walk.locations.any()
    assert walk.located.size == 0 and walk.roles.riders == []
    # Motion names in any case; root_motion=False walks on the spot (the hips only bob).
    on_the_spot = msc.make_motion(h, t, p, rest, "walk", names=names, cycles=2, root_motion=False)
    # the same leg motion, to rounding: the feet are solved at positions a travel apart, and a
    # leg nearly straight turns its knee by much more than its foot's rounding moves
    np.testing.assert_allclose(on_the_spot.rotations, walk.rotations, atol=1e-3)
    assert np.abs(on_the_spot.root_offset).max() < 0.1 < np.abs(walk.root_offset).max()
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
    assert sorted(walk.roles.riders) == [(10, 5), (11, 7)]
    assert sorted(walk.located.tolist()) == [10, 11]
    moved = np.abs(walk.locations).max(axis=(0, 2))
    assert moved[10] > 0.05 and moved[11] > 0.05 and not moved[:10].any()
    # Clips past Blender's last frame (1048574) are refused before anything is allocated,
    # where fps 1e9 x 1e9 s used to abort the process on a failed allocation.
    for kw in (dict(fps=1e9, duration=1e9), dict(fps=1e30, duration=1e30)):
        with pytest.raises(ValueError, match="frames"):
            msc.make_motion(h, t, p, rest, "HEAD_SHAKE", names=names, **kw)
    for kw in (dict(cycles=1e12), dict(speed=1e-30)):
        with pytest.raises(ValueError, match="frames"):
            msc.make_motion(h, t, p, rest, "WALK", names=names, **kw)


def test_detect_roles_of_a_biped_and_a_rig_without_legs():
    h, t, p, _, names = biped()
    roles = msc.detect_roles(h, t, p, names)
    assert roles.plan == "biped" and roles.root == 0 and roles.head == 3
    sides = {names[leg.bones[0]]: leg.side for leg in roles.legs}
    assert sides == {"thigh.L": "L", "thigh.R": "R"}
    assert [leg.bones for leg in roles.legs] == [[4, 5], [6, 7]]
    assert roles.arms == ()   # arm.L and arm.R are one bone each: an arm is a chain of two or more
    assert roles.riders == [] and roles.single_tree
    # the same roles without names: they only confirm the geometry
    assert msc.detect_roles(h, t, p).legs == roles.legs
    # without its legs the body is legless: roles for a head shake, a walk refused
    legless = msc.detect_roles(h[:4], t[:4], p[:4], names[:4])
    assert legless.plan == "legless" and legless.legs == () and legless.head == 3
    rest = np.tile(np.eye(3, dtype=np.float32), (4, 1, 1))
    with pytest.raises(ValueError, match="no legs"):
        msc.make_motion(h[:4], t[:4], p[:4], rest, "WALK", names=names[:4])
    shake = msc.make_motion(h[:4], t[:4], p[:4], rest, "HEAD_SHAKE", names=names[:4])
    assert 3 in shake.animated.tolist()
