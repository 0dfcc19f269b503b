"""Rotations: matrices and unit quaternions (x, y, z, w), scalar LAST (scipy / float4 layout).

Used for normal / tangent maps as quaternion maps q(x) (Wang09 §7) and SG rotation (eq 7).
"""
from __future__ import annotations

import numpy as np


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _any_perpendicular(a):
    """A unit vector ⟂ a (cross with the axis of a's smallest |component|)."""
    idx = np.argmin(np.abs(a), axis=-1)
    e = np.eye(3)[idx]
    return _unit(np.cross(a, e))


def axis_angle_matrix(axis, angle):
    """Rodrigues: rotation by `angle` (rad, right-handed) about unit `axis` → (..., 3, 3)."""
    k = _unit(axis)
    angle = np.asarray(angle, float)[..., None, None]
    K = np.zeros(k.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2] = -k[..., 2], k[..., 1]
    K[..., 1, 0], K[..., 1, 2] = k[..., 2], -k[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -k[..., 1], k[..., 0]
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


def quat_from_to(a, b):
    """Shortest-arc unit quaternion (x, y, z, w) rotating unit a onto unit b (π about a ⟂ axis if a = −b)."""
    a = _unit(a)
    b = _unit(b)
    a, b = np.broadcast_arrays(a, b)
    # q ∝ (a × b, 1 + a·b). Near b = −a, 1 + a·b cancels to nothing; use the identity
    # 1 + c = |a × b|² / (1 − c) there, which keeps every digit of the small tilt.
    c = np.sum(a * b, axis=-1)
    v = np.cross(a, b)
    # Rounding leaves a 1e-16 component of a × b along a; relative to a tiny |a × b| it would
    # tilt the rotation axis off a's orthogonal plane, so project it out.
    v = v - np.sum(v * a, axis=-1)[..., None] * a
    vv = np.sum(v * v, axis=-1)
    w = np.where(c < 0.0, vv / (1.0 - np.minimum(c, 0.0)), 1.0 + c)
    q = np.concatenate([v, w[..., None]], axis=-1)
    anti = vv + w * w < 1e-300
    if np.any(anti):
        perp = _any_perpendicular(a)
        q = np.where(anti[..., None], np.concatenate([perp, np.zeros(c.shape + (1,))], -1), q)
    return _unit(q)


def quat_rotate(q, v):
    """Rotate v by unit quaternion q = (x, y, z, w): v' = v + 2w(u×v) + 2u×(u×v)."""
    q = np.asarray(q, float)
    v = np.asarray(v, float)
    u, w = q[..., :3], q[..., 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quat_multiply(q1, q2):
    """Hamilton product q1 ⊗ q2 (apply q2 first), scalar-last layout."""
    q1 = np.asarray(q1, float)
    q2 = np.asarray(q2, float)
    u1, w1 = q1[..., :3], q1[..., 3:4]
    u2, w2 = q2[..., :3], q2[..., 3:4]
    u = w1 * u2 + w2 * u1 + np.cross(u1, u2)
    w = w1 * w2 - np.sum(u1 * u2, axis=-1, keepdims=True)
    return np.concatenate([u, w], axis=-1)


def quat_to_matrix(q):
    """Unit quaternion (x, y, z, w) → rotation matrix (..., 3, 3)."""
    q = _unit(q)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - z * w)
    R[..., 0, 2] = 2 * (x * z + y * w)
    R[..., 1, 0] = 2 * (x * y + z * w)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - x * w)
    R[..., 2, 0] = 2 * (x * z - y * w)
    R[..., 2, 1] = 2 * (y * z + x * w)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def rotation_between(a, b):
    """Rotation matrix (..., 3, 3) of the shortest arc taking unit a to unit b."""
    return quat_to_matrix(quat_from_to(a, b))


def rotation_matrix(axis, angle_deg: float) -> np.ndarray:
    """World ← map rotation (3, 3) float64 by `angle_deg` (right-handed) about `axis` (any
    length > 0): what the map shows in direction d appears in world direction R·d. Multiples
    of 90° about a coordinate axis come out with exact 0 / ±1 entries."""
    axis = np.asarray(axis, np.float64)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or not np.linalg.norm(axis) > 0:
        raise ValueError(f"rotation axis must be a non-zero 3-vector, got {axis.tolist()}")
    R = axis_angle_matrix(axis, np.radians(float(angle_deg)))
    snapped = np.round(R)
    # cos 90° = 6e-17, not 0: snap entries within rounding of an integer so that quarter turns
    # permute cube faces exactly (and leave the identity an identity)
    return np.where(np.abs(R - snapped) < 1e-12, snapped, R) + 0.0


def checked_rotation(rotation) -> np.ndarray | None:
    """None, or `rotation` as a (3, 3) float64 proper rotation (None for the identity, so
    callers skip the work); ValueError for anything else."""
    if rotation is None:
        return None
    R = np.array(rotation, np.float64)
    if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9) \
            or np.linalg.det(R) < 0:
        raise ValueError(f"not a rotation matrix: {np.asarray(rotation).tolist()}")
    return None if np.array_equal(R, np.eye(3)) else R
