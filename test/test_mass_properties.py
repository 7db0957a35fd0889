"""Mass properties against textbook formulas and independent quadrature; tensor diagonalisation.

The shape formulas are checked twice: against the textbook closed forms (with the numbers of
the issue's worked example) and against a direct numerical integration of ∫ρ r⊥² dV, so a
formula copied wrongly into both the code and a test would still be caught.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy import integrate

from helpers import EPS, random_rotation_matrix
from rigid_body_sim.core.mass_properties import (
    TRIANGLE_RTOL,
    box_inertia,
    check_principal_moments,
    cylinder_inertia,
    principal_frame,
    sphere_inertia,
)
from rigid_body_sim.core.quaternion import quat_to_matrix

# scipy's adaptive quadrature of a polynomial integrand is good to about its default 1.5e-8.
QUAD_RTOL = 1e-7


def test_box_textbook() -> None:
    # The crate: 2 kg, 1.0 × 0.6 × 0.4 m. I_xx = m(b² + c²)/12 etc.
    np.testing.assert_allclose(
        box_inertia(2.0, [1.0, 0.6, 0.4]),
        [2.0 * (0.36 + 0.16) / 12.0, 2.0 * (1.0 + 0.16) / 12.0, 2.0 * (1.0 + 0.36) / 12.0],
        rtol=2 * EPS,
    )
    # A cube: m a² / 6 about every axis.
    np.testing.assert_allclose(box_inertia(3.0, [0.5, 0.5, 0.5]), np.full(3, 3.0 * 0.25 / 6.0), rtol=2 * EPS)


def test_sphere_and_cylinder_textbook() -> None:
    np.testing.assert_allclose(sphere_inertia(5.0, 0.2), np.full(3, 0.4 * 5.0 * 0.04), rtol=2 * EPS)
    m, r, length = 4.0, 0.3, 1.2
    transverse = m * (3 * r * r + length * length) / 12.0
    np.testing.assert_allclose(cylinder_inertia(m, r, length), [transverse, transverse, 0.5 * m * r * r], rtol=2 * EPS)


def test_box_by_quadrature() -> None:
    m, (a, b, c) = 2.0, (1.0, 0.6, 0.4)
    rho = m / (a * b * c)
    # ∫∫∫ (y² + z²) dz dy dx over the box centred at the origin.
    I_xx = rho * integrate.tplquad(lambda z, y, x: y * y + z * z, -a / 2, a / 2, -b / 2, b / 2, -c / 2, c / 2)[0]
    I_zz = rho * integrate.tplquad(lambda z, y, x: x * x + y * y, -a / 2, a / 2, -b / 2, b / 2, -c / 2, c / 2)[0]
    got = box_inertia(m, [a, b, c])
    np.testing.assert_allclose(got[[0, 2]], [I_xx, I_zz], rtol=QUAD_RTOL)


def test_sphere_and_cylinder_by_quadrature() -> None:
    # Sphere: ∫₀ᴿ ∫₀^π (r sin θ)² · 2π r² sin θ dθ dr about z.
    m, R = 5.0, 0.2
    rho = m / (4.0 / 3.0 * np.pi * R**3)
    I_sphere = rho * integrate.dblquad(lambda th, r: (r * np.sin(th)) ** 2 * 2 * np.pi * r * r * np.sin(th),
                                       0.0, R, 0.0, np.pi)[0]
    np.testing.assert_allclose(sphere_inertia(m, R), np.full(3, I_sphere), rtol=QUAD_RTOL)
    # Cylinder along z: I_zz = ∫ r² dm, I_xx = ∫ (y² + z²) dm, cylindrical coordinates.
    m, R, length = 4.0, 0.3, 1.2
    rho = m / (np.pi * R * R * length)
    I_zz = rho * integrate.tplquad(lambda z, phi, r: r**3, 0.0, R, 0.0, 2 * np.pi, -length / 2, length / 2)[0]
    I_xx = rho * integrate.tplquad(lambda z, phi, r: ((r * np.sin(phi)) ** 2 + z * z) * r,
                                   0.0, R, 0.0, 2 * np.pi, -length / 2, length / 2)[0]
    np.testing.assert_allclose(cylinder_inertia(m, R, length), [I_xx, I_xx, I_zz], rtol=QUAD_RTOL)


def test_principal_frame_of_random_tensors() -> None:
    rng = np.random.default_rng(10)
    for _ in range(50):
        R_true = random_rotation_matrix(rng)
        moments_true = box_inertia(rng.uniform(0.5, 5.0), rng.uniform(0.1, 2.0, 3))
        tensor_B = R_true @ np.diag(moments_true) @ R_true.T
        tensor_B = 0.5 * (tensor_B + tensor_B.T)
        moments, q_BP = principal_frame(tensor_B)
        R_BP = quat_to_matrix(q_BP)
        # A proper rotation (det +1, orthonormal) to round-off of the eigen-solver.
        assert abs(np.linalg.det(R_BP) - 1.0) < 1e-13
        np.testing.assert_allclose(R_BP.T @ R_BP, np.eye(3), rtol=0, atol=1e-14)
        np.testing.assert_allclose(np.sort(moments), np.sort(moments_true), rtol=1e-13)
        # It reproduces the tensor: T_B = R_BP diag(I) R_BPᵀ, to the eigen-solver's backward error.
        scale = np.abs(tensor_B).max()
        np.testing.assert_allclose(R_BP @ np.diag(moments) @ R_BP.T, tensor_B, rtol=0, atol=1e-14 * scale)


def test_principal_frame_of_a_diagonal_tensor_is_exactly_the_identity() -> None:
    tensor = np.diag([0.3, 0.2, 0.4])
    moments, q_BP = principal_frame(tensor)
    np.testing.assert_array_equal(q_BP, [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(moments, [0.3, 0.2, 0.4])  # no sorting, no round-off


def test_principal_frame_with_two_equal_moments() -> None:
    """A degenerate eigenspace: any proper rotation that diagonalises it will do."""
    c, s = np.cos(0.4), np.sin(0.4)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    tensor = R @ np.diag([1.0, 1.0, 1.5]) @ R.T
    moments, q_BP = principal_frame(tensor)
    R_BP = quat_to_matrix(q_BP)
    np.testing.assert_allclose(R_BP @ np.diag(moments) @ R_BP.T, tensor, rtol=0, atol=1e-14)
    assert abs(np.linalg.det(R_BP) - 1.0) < 1e-13


@pytest.mark.parametrize(
    "moments",
    [[1.0, 1.0, 2.0], [2.0, 1.0, 1.0], [1.0, 2.0, 1.0], [1.0, 1.0, 2.0 * (1 + 0.5 * TRIANGLE_RTOL)], [1.0, 1.0, 1.0]],
    ids=["plate-z", "plate-x", "plate-y", "plate-within-tolerance", "sphere"],
)
def test_triangle_inequality_accepts_a_flat_plate(moments: list[float]) -> None:
    assert check_principal_moments(np.array(moments)) is None


@pytest.mark.parametrize(
    ("moments", "match"),
    [
        ([1.0, 1.0, 2.0 * (1 + 2 * TRIANGLE_RTOL)], r"triangle inequality I1 \+ I2 ≥ I3"),
        ([3.0, 1.0, 1.0], r"triangle inequality I2 \+ I3 ≥ I1"),
        ([1.0, 3.0, 1.5], r"triangle inequality I1 \+ I3 ≥ I2"),
        ([1.0, 0.0, 1.0], r"principal moments > 0"),
        ([1.0, -1.0, 1.0], r"principal moments > 0"),
        ([1.0, np.nan, 1.0], r"3 finite numbers"),
        ([1.0, np.inf, 1.0], r"3 finite numbers"),
    ],
)
def test_impossible_principal_moments_are_explained(moments: list[float], match: str) -> None:
    problem = check_principal_moments(np.array(moments))
    assert problem is not None
    assert re.search(match, problem), problem
