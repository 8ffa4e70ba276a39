"""Object transforms in double precision: world points, inverses, axis scales, extents and an
armature's frame (its axes and origin at world size)."""

from __future__ import annotations

import bpy
import numpy as np


def world_points(ob: bpy.types.Object, co: np.ndarray) -> np.ndarray:
    """Object-space coordinates (flat or (n, 3)) in world space by ``ob.matrix_world``, (n, 3)
    float64: in single precision, world points 1e5 m from the origin are 8 mm apart, too
    coarse for a character's detail (``to_armature_frame`` brings them back near 0 first)."""
    m = np.array(ob.matrix_world, dtype=np.float64)
    return co.reshape(-1, 3).astype(np.float64) @ m[:3, :3].T + m[:3, 3]


def placed(m) -> bool:
    """Whether the matrix ``m`` (an object's world transform) is finite throughout."""
    return bool(np.isfinite(np.array(m, dtype=np.float64)).all())


def inverse(m) -> np.ndarray | None:
    """The inverse of the square matrix ``m`` (3x3, or 4x4 affine) in double precision, or None
    when it is not finite or its 3x3 part is singular relative to its size (a zero scale on an
    axis). mathutils inverts in single precision, where the determinant of a transform scaled by
    1e15 (1e45) overflows and one scaled by 1e-15 underflows."""
    a = np.array(m, dtype=np.float64)
    if not np.isfinite(a).all():
        return None
    sv = np.linalg.svd(a[:3, :3], compute_uv=False)
    if not sv.min() > 1e-12 * sv.max():
        return None
    return np.linalg.inv(a)


def axis_scales(m) -> np.ndarray:
    """The lengths of the axes of the transform ``m`` (``to_scale`` without its signs) in double
    precision: mathutils squares them in single precision, which overflows to inf past 1.8e19."""
    return np.linalg.norm(np.array(m, dtype=np.float64)[:3, :3], axis=0)


def extent(ob: bpy.types.Object) -> float:
    """The diagonal of ``ob``'s bounding box as placed in the world, in double precision
    (Blender's ``dimensions`` overflow to inf on an armature scaled by 1e30, which would make
    every one of its bones "zero-length")."""
    m = np.array(ob.matrix_world, dtype=np.float64)
    corners = np.array(ob.bound_box, dtype=np.float64) @ m[:3, :3].T
    return float(np.linalg.norm(np.ptp(corners, axis=0)))


def armature_frame(arm_ob: bpy.types.Object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``arm_ob``'s world matrix split by polar decomposition, M = [R S | t]: the rotation R
    (orthogonal; a reflection for a negative scale), the stretch S (symmetric) and location t.
    Fit and X symmetry work in the frame (R, t): the armature's axes and origin, at world
    size, so a scaled armature (even unevenly) does not stretch the mesh's cross-sections."""
    m = np.array(arm_ob.matrix_world, dtype=np.float64)
    u, sigma, vt = np.linalg.svd(m[:3, :3])
    return u @ vt, vt.T @ np.diag(sigma) @ vt, m[:3, 3]


def to_armature_frame(arm_ob: bpy.types.Object, points: np.ndarray) -> np.ndarray:
    """World points (n, 3) in ``arm_ob``'s frame (``armature_frame``: its axes and origin, no
    scale), float32: where X symmetry means the armature's x = 0, for Auto Weights as for Fit
    (a rig moved, turned or scaled in the scene stays symmetric)."""
    r, _, t = armature_frame(arm_ob)
    return ((points.astype(np.float64) - t) @ r).astype(np.float32)
