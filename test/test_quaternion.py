"""Quaternion conventions pinned down: Hamilton product, rotation direction, orders, exp/log.

The core's quaternions are (w, x, y, z), Hamilton (i·j = k), active body-to-world. These tests
fix each of those choices against hand values and against scipy's Rotation (whose order is
stated at every call with ``scalar_first``), so a silent switch of any convention fails here.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from helpers import EPS, random_unit_quaternion
from rigid_body_sim.core.quaternion import (
    IDENTITY_WXYZ,
    cross3,
    quat_angle_between,
    quat_conjugate,
    quat_from_matrix,
    quat_from_rotation_vector,
    quat_multiply,
    quat_rotate,
    quat_to_matrix,
    quat_to_rotation_vector,
    quat_wxyz_from_xyzw,
    quat_xyzw_from_wxyz,
)

ONE = np.array([1.0, 0.0, 0.0, 0.0])
I = np.array([0.0, 1.0, 0.0, 0.0])
J = np.array([0.0, 0.0, 1.0, 0.0])
K = np.array([0.0, 0.0, 0.0, 1.0])


def _scipy(q_wxyz: np.ndarray) -> Rotation:
    return Rotation.from_quat(q_wxyz, scalar_first=True)


def _same_rotation(q_a: np.ndarray, q_b: np.ndarray) -> bool:
    """q and −q are the same rotation."""
    return np.allclose(q_a, q_b, rtol=0, atol=1e-15) or np.allclose(q_a, -q_b, rtol=0, atol=1e-15)


# --------------------------------------------------------------------------- Hamilton product


@pytest.mark.parametrize(
    ("p", "q", "expected"),
    [
        (I, J, K), (J, K, I), (K, I, J),  # i·j = k, j·k = i, k·i = j
        (J, I, -K), (K, J, -I), (I, K, -J),  # anti-commutative
        (I, I, -ONE), (J, J, -ONE), (K, K, -ONE),  # i² = j² = k² = −1
        (ONE, I, I), (K, ONE, K),  # 1 is the identity
    ],
    ids=["ij=k", "jk=i", "ki=j", "ji=-k", "kj=-i", "ik=-j", "ii=-1", "jj=-1", "kk=-1", "1i=i", "k1=k"],
)
def test_hamilton_product_table(p: np.ndarray, q: np.ndarray, expected: np.ndarray) -> None:
    np.testing.assert_array_equal(quat_multiply(p, q), expected)


def test_ijk_is_minus_one() -> None:
    np.testing.assert_array_equal(quat_multiply(quat_multiply(I, J), K), -ONE)


def test_product_composes_rotations_like_scipy() -> None:
    """q_AC = q_AB ⊗ q_BC is the rotation 'first q_BC, then q_AB', as scipy's ``r_AB * r_BC``."""
    rng = np.random.default_rng(0)
    q_AB = random_unit_quaternion(rng, 50)
    q_BC = random_unit_quaternion(rng, 50)
    q_AC = quat_multiply(q_AB, q_BC)
    expected = (_scipy(q_AB) * _scipy(q_BC)).as_quat(scalar_first=True)
    for got, want in zip(q_AC, expected):
        assert _same_rotation(got, want)


def test_conjugate_is_the_inverse_of_a_unit_quaternion() -> None:
    rng = np.random.default_rng(1)
    q = random_unit_quaternion(rng, 20)
    np.testing.assert_allclose(quat_multiply(q, quat_conjugate(q)), np.tile(ONE, (20, 1)), rtol=0, atol=4 * EPS)


def test_cross3_is_bitwise_np_cross() -> None:
    rng = np.random.default_rng(2)
    u, v = rng.normal(size=(2, 7, 3))
    np.testing.assert_array_equal(cross3(u, v), np.cross(u, v))
    np.testing.assert_array_equal(cross3(u[0], v), np.cross(u[0], v))  # broadcasting


# --------------------------------------------------------------------------- rotation direction


def test_plus_90_degrees_about_z_takes_x_to_y() -> None:
    q_z90 = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])
    np.testing.assert_allclose(quat_rotate(q_z90, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], rtol=0, atol=2 * EPS)
    np.testing.assert_allclose(quat_rotate(q_z90, [0.0, 1.0, 0.0]), [-1.0, 0.0, 0.0], rtol=0, atol=2 * EPS)
    np.testing.assert_allclose(
        quat_to_matrix(q_z90), [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], rtol=0, atol=2 * EPS
    )
    # The same through the exponential map, with the angle on the right-hand rule about +z.
    np.testing.assert_allclose(quat_from_rotation_vector([0.0, 0.0, np.pi / 2]), q_z90, rtol=0, atol=EPS)


def test_rotate_and_matrix_match_scipy() -> None:
    rng = np.random.default_rng(3)
    q = random_unit_quaternion(rng, 100)
    v = rng.normal(size=(100, 3))
    expected = _scipy(q).apply(v)
    # Both are a handful of products of unit-size numbers: a few ulps of |v|.
    np.testing.assert_allclose(quat_rotate(q, v), expected, rtol=0, atol=16 * EPS * np.abs(v).max())
    np.testing.assert_allclose(quat_to_matrix(q), _scipy(q).as_matrix(), rtol=0, atol=8 * EPS)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", quat_to_matrix(q), v), expected, rtol=0,
                               atol=16 * EPS * np.abs(v).max())


def test_matrix_round_trip_with_non_negative_w() -> None:
    rng = np.random.default_rng(4)
    q = random_unit_quaternion(rng, 100)
    back = quat_from_matrix(quat_to_matrix(q))
    assert np.all(back[:, 0] >= 0.0)
    canonical = np.where(q[:, :1] < 0.0, -q, q)
    np.testing.assert_allclose(back, canonical, rtol=0, atol=8 * EPS)


def test_identity() -> None:
    np.testing.assert_array_equal(IDENTITY_WXYZ, ONE)
    v = np.array([0.3, -2.0, 5.0])
    np.testing.assert_array_equal(quat_rotate(IDENTITY_WXYZ, v), v)
    np.testing.assert_array_equal(quat_to_matrix(IDENTITY_WXYZ), np.eye(3))


# --------------------------------------------------------------------------- orders


def test_xyzw_wxyz_conversions() -> None:
    np.testing.assert_array_equal(quat_wxyz_from_xyzw([0.0, 0.0, 0.0, 1.0]), ONE)
    np.testing.assert_array_equal(quat_xyzw_from_wxyz(ONE), [0.0, 0.0, 0.0, 1.0])
    np.testing.assert_array_equal(quat_wxyz_from_xyzw([1.0, 2.0, 3.0, 4.0]), [4.0, 1.0, 2.0, 3.0])
    np.testing.assert_array_equal(quat_xyzw_from_wxyz([4.0, 1.0, 2.0, 3.0]), [1.0, 2.0, 3.0, 4.0])


def test_xyzw_wxyz_round_trips_and_match_scipy_orders() -> None:
    rng = np.random.default_rng(5)
    q_wxyz = random_unit_quaternion(rng, 30)
    np.testing.assert_array_equal(quat_wxyz_from_xyzw(quat_xyzw_from_wxyz(q_wxyz)), q_wxyz)
    q_xyzw = quat_xyzw_from_wxyz(q_wxyz)
    np.testing.assert_array_equal(quat_xyzw_from_wxyz(quat_wxyz_from_xyzw(q_xyzw)), q_xyzw)
    # scipy reads the same rotation from either order when told which one it is.
    np.testing.assert_allclose(
        Rotation.from_quat(q_xyzw, scalar_first=False).as_matrix(),
        Rotation.from_quat(q_wxyz, scalar_first=True).as_matrix(), rtol=0, atol=0,
    )
    # Broadcasting over leading dimensions.
    assert quat_wxyz_from_xyzw(np.zeros((2, 5, 4))).shape == (2, 5, 4)


# --------------------------------------------------------------------------- exp / log maps


def test_exp_log_round_trip_random() -> None:
    rng = np.random.default_rng(6)
    axis = rng.normal(size=(200, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = rng.uniform(0.0, np.pi * (1 - 1e-6), 200)
    rotvec = axis * angle[:, None]
    q = quat_from_rotation_vector(rotvec)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, rtol=0, atol=2 * EPS)
    np.testing.assert_allclose(quat_from_rotation_vector(rotvec), Rotation.from_rotvec(rotvec).as_quat(scalar_first=True),
                               rtol=0, atol=4 * EPS)
    # atan2 recovers the angle to a few ulps of π at every angle.
    np.testing.assert_allclose(quat_to_rotation_vector(q), rotvec, rtol=0, atol=8 * EPS * np.pi)


@pytest.mark.parametrize("angle", [0.0, 1e-300, 1e-200, 1e-12, 1e-8, 0.99e-4, 1e-4, 1.01e-4, 1e-3])
def test_exp_log_round_trip_tiny_angles(angle: float) -> None:
    """Across the small-angle series switch (1e-4) and down to denormal-free tiny angles."""
    axis = np.array([2.0, -3.0, 6.0]) / 7.0
    rotvec = angle * axis
    q = quat_from_rotation_vector(rotvec)
    assert abs(np.linalg.norm(q) - 1.0) <= EPS
    # Exact (θ/2 series) values: w = cos(θ/2), vector part sin(θ/2)·axis, to a couple of ulps.
    np.testing.assert_allclose(q[0], np.cos(angle / 2), rtol=2 * EPS, atol=0)
    np.testing.assert_allclose(q[1:], np.sin(angle / 2) * axis, rtol=4 * EPS, atol=0)
    np.testing.assert_allclose(quat_to_rotation_vector(q), rotvec, rtol=8 * EPS, atol=0)


@pytest.mark.parametrize("gap", [1e-3, 1e-6, 1e-9, 1e-12])
def test_exp_log_round_trip_near_pi(gap: float) -> None:
    axis = np.array([2.0, -3.0, 6.0]) / 7.0
    rotvec = (np.pi - gap) * axis
    q = quat_from_rotation_vector(rotvec)
    assert abs(np.linalg.norm(q) - 1.0) <= 2 * EPS
    np.testing.assert_allclose(quat_to_rotation_vector(q), rotvec, rtol=0, atol=8 * EPS * np.pi)
    # −q is the same rotation; the log map returns the same vector with the angle in [0, π].
    np.testing.assert_allclose(quat_to_rotation_vector(-q), rotvec, rtol=0, atol=8 * EPS * np.pi)


def test_log_of_a_half_turn_has_angle_pi() -> None:
    q = np.array([0.0, 0.0, 1.0, 0.0])  # 180° about y
    np.testing.assert_allclose(quat_to_rotation_vector(q), [0.0, np.pi, 0.0], rtol=0, atol=EPS)


# --------------------------------------------------------------------------- geodesic angle


def test_angle_between() -> None:
    rng = np.random.default_rng(7)
    q = random_unit_quaternion(rng, 50)
    axis = rng.normal(size=(50, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = rng.uniform(0.0, np.pi, 50)
    q_turned = quat_multiply(q, quat_from_rotation_vector(axis * angle[:, None]))
    np.testing.assert_allclose(quat_angle_between(q, q_turned), angle, rtol=0, atol=16 * EPS)
    np.testing.assert_allclose(quat_angle_between(q, -q_turned), angle, rtol=0, atol=16 * EPS)  # sign-blind
    assert np.all(quat_angle_between(q, q) <= 4 * EPS)
    # Tiny angles are resolved to a few ulps absolute (atan2 of the vector part), where an
    # acos of the scalar part could not see anything below √eps ≈ 1.5e-8 rad.
    tiny = quat_multiply(q[0], quat_from_rotation_vector([1e-10, 0.0, 0.0]))
    np.testing.assert_allclose(quat_angle_between(q[0], tiny), 1e-10, rtol=0, atol=8 * EPS)
