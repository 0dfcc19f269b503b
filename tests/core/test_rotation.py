"""Rotation matrices and (x, y, z, w) quaternions."""
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from sgpipe.core import (axis_angle_matrix, quat_from_to, quat_multiply, quat_rotate,
                         quat_to_matrix, rotation_between)

from .conftest import unit


def test_rotation_between(rng):
    a = unit(rng.normal(size=(200, 3)))
    b = unit(rng.normal(size=(200, 3)))
    b[0] = -a[0]
    b[1] = a[1]
    R = rotation_between(a, b)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", R, a), b, atol=1e-12)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    # shortest arc: the axis a × b is fixed
    ax = np.cross(a[2], b[2])
    np.testing.assert_allclose(R[2] @ ax, ax, atol=1e-12)


def test_quaternion_consistency(rng):
    q = unit(rng.normal(size=(50, 4)))
    v = rng.normal(size=(50, 3))
    np.testing.assert_allclose(quat_rotate(q, v), np.einsum("nij,nj->ni", quat_to_matrix(q), v), atol=1e-12)
    q2 = unit(rng.normal(size=(50, 4)))
    np.testing.assert_allclose(quat_rotate(quat_multiply(q2, q), v), quat_rotate(q2, quat_rotate(q, v)),
                               atol=1e-12)
    # scalar-last: 90° about +Z is (0, 0, sin 45°, cos 45°) and takes +X to +Y
    qz = np.array([0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)])
    np.testing.assert_allclose(quat_rotate(qz, [1.0, 0, 0]), [0, 1.0, 0], atol=1e-15)
    np.testing.assert_allclose(axis_angle_matrix([0, 0, 1.0], np.pi / 2), quat_to_matrix(qz), atol=1e-15)


vec = st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda t: np.linalg.norm(t) > 0.1).map(unit)


@settings(max_examples=80, deadline=None)
@given(vec, vec)
@example(np.array([1.0, 0.0, 0.0]), unit((-1.0, 0.0, 5.960464477539063e-08)))  # near-antipodal
@example(np.array([0.0, 1.0, 0.0]), unit((0.0, -1.0, 1e-08)))  # b_y rounds to exactly −1
def test_quat_from_to_property(a, b):
    q = quat_from_to(a, b)
    assert np.linalg.norm(q) == pytest.approx(1.0)
    np.testing.assert_allclose(quat_rotate(q, a), b, atol=1e-9)
