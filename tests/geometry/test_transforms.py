"""Rotations, rigid transforms and eq. 3 kinematics."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from rasc.errors import InputError
from rasc.geometry.kinematics import R_gaze_from_ptu, T_gaze_from_ptu
from rasc.geometry.transforms import (
    invert_transform,
    make_transform,
    matrix_from_rotvec,
    project_to_rotation,
    rotation_angle,
    rotvec_from_matrix,
    validate_rigid_transform,
)


def _Rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _Rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_eq3_equals_Rz_tilt_Rx_minus_pan():
    rng = np.random.default_rng(0)
    pan, tilt = rng.uniform(-np.pi, np.pi, (2, 50))
    R = R_gaze_from_ptu(pan, tilt)
    for k in range(50):
        # 1e-15: products of two rotations with entries ≤ 1, a few roundings each.
        np.testing.assert_allclose(R[k], _Rz(tilt[k]) @ _Rx(-pan[k]), atol=1e-15)
    T = T_gaze_from_ptu(pan, tilt)
    assert T.shape == (50, 4, 4)
    np.testing.assert_array_equal(T[:, :3, 3], 0.0)


def test_eq3_axis_reading():
    # ptu frame: x up, y forward, z left. The line of sight is gaze +y in ptu coordinates.
    sight = lambda pan, tilt: R_gaze_from_ptu(pan, tilt).T @ [0.0, 1.0, 0.0]  # noqa: E731
    left = sight(np.radians(10), 0.0)
    assert left[2] > 0 and abs(left[0]) < 1e-15  # positive pan looks left
    up = sight(0.0, np.radians(10))
    assert up[0] > 0 and abs(up[2]) < 1e-15  # positive tilt looks up
    np.testing.assert_array_equal(R_gaze_from_ptu(0.0, 0.0), np.eye(3))


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-8, 1e-4, np.pi - 1e-4, np.pi - 1e-9, np.pi])
def test_log_exp_near_zero_and_pi(angle):
    rng = np.random.default_rng(1)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    R = matrix_from_rotvec(axis * angle)
    v = rotvec_from_matrix(R)
    assert abs(np.linalg.norm(v) - angle) < 1e-12  # round-off of an orthonormal matrix
    # At π the axis sign is ambiguous: compare the rotations, not the vectors.
    np.testing.assert_allclose(matrix_from_rotvec(v), R, atol=1e-12)
    assert abs(rotation_angle(R) - angle) < 1e-12


@pytest.mark.slow
@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0, allow_nan=False), min_size=3, max_size=3))
def test_rotvec_round_trip(v):
    v = np.array(v)
    if np.linalg.norm(v) >= np.pi:  # log returns the angle in [0, π]
        return
    np.testing.assert_allclose(rotvec_from_matrix(matrix_from_rotvec(v)), v, atol=1e-12)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_invert_and_compose(seed):
    rng = np.random.default_rng(seed)
    R = Rotation.random(2, random_state=seed).as_matrix()
    t = rng.normal(size=(2, 3))
    T_a_from_b, T_b_from_c = make_transform(R, t)
    T_a_from_c = T_a_from_b @ T_b_from_c
    np.testing.assert_allclose(invert_transform(T_a_from_c) @ T_a_from_c, np.eye(4), atol=1e-12)
    np.testing.assert_allclose(
        invert_transform(T_a_from_c), invert_transform(T_b_from_c) @ invert_transform(T_a_from_b),
        atol=1e-12)


def test_project_to_rotation():
    rng = np.random.default_rng(2)
    R = Rotation.random(10, random_state=2).as_matrix()
    Rn = project_to_rotation(R + 1e-3 * rng.normal(size=R.shape))
    np.testing.assert_allclose(np.swapaxes(Rn, 1, 2) @ Rn, np.broadcast_to(np.eye(3), Rn.shape),
                               atol=1e-12)
    assert np.all(np.linalg.det(Rn) > 0)


@pytest.mark.parametrize("bad, fragment", [
    (np.eye(3), "expected a 4x4"),
    (np.full((4, 4), np.nan), "NaN"),
    (np.diag([1.0, 1.0, 1.1, 1.0]), "not orthonormal"),
    (np.diag([1.0, 1.0, -1.0, 1.0]), "determinant"),
    (np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1.0]]), "last row"),
    ("abc", "numeric"),
])
def test_validate_rejects(bad, fragment):
    with pytest.raises(InputError, match=fragment):
        validate_rigid_transform(bad, name="T_x")
    validate_rigid_transform(np.eye(4))
