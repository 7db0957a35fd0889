"""Check the exact references in ``rigid_body_sim.exact.closed_form`` against an independent solver.

The independent solution is written here, not taken from the package: Euler's equations
``I w' = τ − w × (I w)``, the kinematics ``q' = ½ q ⊗ (0, w)`` with the Hamilton product
spelled out, and (for the pushed box) ``v' = R(q) F_B / m``, integrated with
``scipy.integrate.solve_ivp(method="DOP853", rtol=1e-13, atol=1e-13)``.

Tolerances. DOP853 is 8th order; with rtol = atol = 1e-13 its local error per step is below
~1e-13 of the state (|state| = O(1) here), and over the 10²–10³ steps of a ≤ 20 s run of
these integrable (non-chaotic) motions the global error grows at most about linearly, so it
stays below ~1e-10. The closed forms are exact up to round-off and a 1e-13 quadrature. So
rates (rad/s, |w| ≲ 5) and geodesic angles (rad) are compared at ``ODE_TOL = 1e-9``: a margin
of ≥ 10 over the solver's error, while any mistake in a formula (a sign, λ, a phase, a case)
shows up at 1e-3 or worse. Near the separatrix the solver's error is amplified by the ratio of
the large to the small rate components, and those tests widen the tolerance by that ratio.
"""

from __future__ import annotations

import itertools
import time

import numpy as np
import pytest
from scipy import special
from scipy.integrate import solve_ivp

from rigid_body_sim.exact import closed_form as cf
from rigid_body_sim.core.quaternion import quat_angle_between, quat_from_rotation_vector

ODE_TOL = 1e-9  # rad/s and rad; see the module docstring
ROUNDOFF_TOL = 1e-12  # relative; algebraic invariants of the closed forms, ~10³ ulp


# ----------------------------------------------------------------------------- the independent solver


def _hamilton_q_times_pure(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """q ⊗ (0, w), (w, x, y, z), written out (i·j = k)."""
    qw, qx, qy, qz = q
    a, b, c = w
    return np.array(
        [
            -qx * a - qy * b - qz * c,
            qw * a + qy * c - qz * b,
            qw * b - qx * c + qz * a,
            qw * c + qx * b - qy * a,
        ]
    )


def _matrix_from_quat(q: np.ndarray) -> np.ndarray:
    """R_WB from a (w, x, y, z) quaternion, normalised first (the solver lets |q| drift ~1e-13)."""
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def solve_rotation(inertia, w_B0, q_WB0, t, torque_B=(0.0, 0.0, 0.0)):
    """Integrate Euler's equations and quaternion kinematics; returns q_WB (T, 4), w_B (T, 3)."""
    I = np.asarray(inertia, dtype=float)
    tau = np.asarray(torque_B, dtype=float)

    def rhs(_t, y):
        q, w = y[:4], y[4:]
        return np.concatenate((0.5 * _hamilton_q_times_pure(q, w), (tau - np.cross(w, I * w)) / I))

    t = np.asarray(t, dtype=float)
    y0 = np.concatenate((q_WB0, w_B0))
    sol = solve_ivp(rhs, (0.0, t[-1]), y0, method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t)
    assert sol.success, sol.message
    return sol.y[:4].T, sol.y[4:].T


def solve_pushed_body(mass, inertia, force_B, point_B, t):
    """Body at rest at the origin pushed by a body-fixed force; returns q, w_B, v_W, p_W."""
    I = np.asarray(inertia, dtype=float)
    F_B = np.asarray(force_B, dtype=float)
    tau_B = np.cross(point_B, F_B)

    def rhs(_t, y):
        q, w, v = y[:4], y[4:7], y[7:10]
        return np.concatenate(
            (
                0.5 * _hamilton_q_times_pure(q, w),
                (tau_B - np.cross(w, I * w)) / I,
                _matrix_from_quat(q) @ F_B / mass,
                v,
            )
        )

    y0 = np.concatenate(([1.0, 0.0, 0.0, 0.0], np.zeros(9)))
    sol = solve_ivp(rhs, (0.0, t[-1]), y0, method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t)
    assert sol.success, sol.message
    return sol.y[:4].T, sol.y[4:7].T, sol.y[7:10].T, sol.y[10:13].T


# ----------------------------------------------------------------------------- helpers


def random_unit_quaternion(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def random_box_inertia(rng: np.random.Generator) -> np.ndarray:
    """Principal moments of a random solid box (always satisfies the triangle inequality)."""
    mass = rng.uniform(0.5, 3.0)  # kg
    a, b, c = rng.uniform(0.2, 1.5, size=3)  # m
    return mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def elliptic_case(inertia, w_B0) -> int:
    """1 if L² > 2E·I2 (polhode about the largest axis), 2 if L² < 2E·I2."""
    I = np.asarray(inertia, dtype=float)
    w = np.asarray(w_B0, dtype=float)
    L2 = np.sum((I * w) ** 2)
    two_E = np.sum(I * w * w)
    return 1 if L2 > two_E * np.median(I) else 2


def assert_matches_ode(q, w, q_ref, w_ref, tol=ODE_TOL):
    """Rates, geodesic angle, and the quaternion itself (same sign branch: both continuous from q0)."""
    assert np.max(np.abs(w - w_ref)) < tol
    assert np.max(quat_angle_between(q, q_ref)) < tol
    assert np.max(np.abs(q - q_ref)) < tol


def assert_conserves_energy_and_momentum(inertia, q, w):
    """E and L_W = R(q) I w constant to round-off (a check that needs no solver)."""
    I = np.asarray(inertia, dtype=float)
    energy = 0.5 * np.sum(I * w * w, axis=1)
    L_W = np.einsum("tij,tj->ti", np.array([_matrix_from_quat(qi) for qi in q]), I * w)
    scale = np.linalg.norm(L_W[0])
    assert np.max(np.abs(energy - energy[0])) <= ROUNDOFF_TOL * energy[0]
    assert np.max(np.abs(np.linalg.norm(L_W, axis=1) - scale)) <= ROUNDOFF_TOL * scale
    assert np.max(np.abs(L_W - L_W[0])) <= ROUNDOFF_TOL * scale


T_SHORT = np.linspace(0.0, 20.0, 81)  # s


# ----------------------------------------------------------------------------- symmetric top


@pytest.mark.parametrize(
    ("inertia", "w_B0"),
    [
        ((1.0, 1.0, 2.0), (0.3, -0.4, 2.0)),  # oblate (disc-like), symmetry axis z
        ((2.0, 2.0, 1.0), (0.8, 0.1, -3.0)),  # prolate (rod-like)
        ((0.7, 1.3, 0.7), (0.5, 1.5, -0.2)),  # symmetry axis y
        ((1.1, 0.6, 0.6), (-2.0, 0.3, 0.9)),  # symmetry axis x
        ((1.0, 1.0, 1.0), (0.3, 0.2, 0.1)),  # sphere: uniform rotation
    ],
)
def test_symmetric_top_matches_ode_named(inertia, w_B0):
    q0 = quat_from_rotation_vector([0.4, -0.2, 1.1])
    q, w = cf.symmetric_top(inertia, w_B0, q0, T_SHORT)
    q_ref, w_ref = solve_rotation(inertia, w_B0, q0, T_SHORT)
    assert_matches_ode(q, w, q_ref, w_ref)
    assert_conserves_energy_and_momentum(inertia, q, w)


def test_symmetric_top_matches_ode_random():
    rng = np.random.default_rng(0)
    for trial in range(6):
        a, c = rng.uniform(0.2, 1.5, size=2)  # square cross-section a × a, length c
        mass = rng.uniform(0.5, 3.0)
        I = mass / 12.0 * np.array([a * a + c * c, a * a + c * c, 2 * a * a])
        I = np.roll(I, trial % 3)  # the symmetry axis visits x, y and z
        w0 = rng.normal(scale=2.0, size=3)
        q0 = random_unit_quaternion(rng)
        q, w = cf.symmetric_top(I, w0, q0, T_SHORT)
        q_ref, w_ref = solve_rotation(I, w0, q0, T_SHORT)
        assert_matches_ode(q, w, q_ref, w_ref)
        assert_conserves_energy_and_momentum(I, q, w)


def test_symmetric_top_spin_rate_constant_and_transverse_rate_turns_at_minus_lambda():
    I = np.array([2.0, 2.0, 0.5])
    w0 = np.array([0.6, 0.0, 4.0])
    t = np.array([0.0, 0.7, 3.0])
    _, w = cf.symmetric_top(I, w0, [1.0, 0.0, 0.0, 0.0], t)
    lam = w0[2] * (1.0 - I[2] / I[0])
    assert np.allclose(w[:, 2], w0[2], rtol=0.0, atol=1e-15)
    # body-frame transverse rate turns by −λ t about z: (0.6 cos λt, −0.6 sin λt)
    assert np.allclose(w[:, 0], 0.6 * np.cos(lam * t), rtol=0.0, atol=1e-14)
    assert np.allclose(w[:, 1], -0.6 * np.sin(lam * t), rtol=0.0, atol=1e-14)


def test_symmetric_top_rejects_asymmetric_inertia():
    with pytest.raises(ValueError, match="two equal principal moments"):
        cf.symmetric_top([1.0, 2.0, 2.5], [0.1, 0.2, 0.3], [1.0, 0.0, 0.0, 0.0], T_SHORT)


# ----------------------------------------------------------------------------- asymmetric top


def test_asymmetric_top_matches_ode_random():
    rng = np.random.default_rng(0)
    cases = set()
    for _ in range(10):
        I = random_box_inertia(rng)
        w0 = rng.normal(scale=2.0, size=3)
        q0 = random_unit_quaternion(rng)
        cases.add(elliptic_case(I, w0))
        q, w = cf.asymmetric_top(I, w0, q0, T_SHORT)
        q_ref, w_ref = solve_rotation(I, w0, q0, T_SHORT)
        assert_matches_ode(q, w, q_ref, w_ref)
        assert np.array_equal(w, cf.asymmetric_top_body_rates(I, w0, T_SHORT))
        assert_conserves_energy_and_momentum(I, q, w)
    assert cases == {1, 2}, "the random sample should exercise both elliptic cases"


@pytest.mark.parametrize(
    ("w_sorted", "case"),
    [((0.3, 0.2, 1.5), 1), ((1.5, 0.2, 0.3), 2)],
)
@pytest.mark.parametrize("perm", list(itertools.permutations(range(3))))
def test_asymmetric_top_every_ordering_and_sign(w_sorted, case, perm):
    """Moments (1, 2, 2.5) in every order; rates carried along, with some signs flipped."""
    perm = list(perm)
    I = np.array([1.0, 2.0, 2.5])[perm]
    w0 = np.array(w_sorted)[perm] * np.array([1.0, -1.0, 1.0]) * (-1.0 if perm[0] == 2 else 1.0)
    assert elliptic_case(I, w0) == case
    q0 = quat_from_rotation_vector([-0.3, 0.9, 0.5])
    t = np.linspace(0.0, 15.0, 31)
    q, w = cf.asymmetric_top(I, w0, q0, t)
    q_ref, w_ref = solve_rotation(I, w0, q0, t)
    assert_matches_ode(q, w, q_ref, w_ref)


@pytest.mark.parametrize(
    ("inertia", "w_B0"),
    [
        ((1.0, 2.0, 3.0), (0.0, 0.0, 2.0)),  # largest axis
        ((1.0, 2.0, 3.0), (-1.5, 0.0, 0.0)),  # smallest axis, negative
        ((3.0, 1.0, 2.0), (-0.7, 0.0, 0.0)),  # largest axis listed first
        ((2.0, 3.0, 1.0), (0.0, 0.0, 1.2)),  # smallest axis listed last
    ],
)
def test_asymmetric_top_pure_spin_is_uniform_rotation(inertia, w_B0):
    q0 = quat_from_rotation_vector([0.1, 0.2, -0.3])
    q, w = cf.asymmetric_top(inertia, w_B0, q0, T_SHORT)
    assert np.array_equal(w, np.tile(w_B0, (T_SHORT.size, 1)))
    q_ref, w_ref = solve_rotation(inertia, w_B0, q0, T_SHORT)
    assert_matches_ode(q, w, q_ref, w_ref)


def test_asymmetric_top_nearly_pure_spin():
    """Tiny wobble amplitudes (1e-9 of the spin): the Euler-angle route must stay regular."""
    q0 = quat_from_rotation_vector([0.1, 0.2, -0.3])
    for w0 in ([1e-9, -1e-9, 2.0], [-1.5, 1e-9, 2e-9]):
        q, w = cf.asymmetric_top([1.0, 2.0, 3.0], w0, q0, T_SHORT)
        q_ref, w_ref = solve_rotation([1.0, 2.0, 3.0], w0, q0, T_SHORT)
        assert_matches_ode(q, w, q_ref, w_ref)


def test_asymmetric_top_initial_state_and_time_order():
    """t = 0 returns the initial state; unsorted and negative times agree with sorted ones."""
    I = np.array([1.3, 0.4, 1.0])
    w0 = np.array([0.5, -2.0, 0.7])
    q0 = quat_from_rotation_vector([1.0, -2.0, 0.5])
    t = np.array([3.0, -2.5, 0.0, 11.0, 1.0])
    q, w = cf.asymmetric_top(I, w0, q0, t)
    assert np.allclose(q[2], q0, rtol=0.0, atol=1e-15)
    assert np.allclose(w[2], w0, rtol=0.0, atol=1e-15)
    for i in (0, 3, 4):
        q_i, w_i = cf.asymmetric_top(I, w0, q0, t[i : i + 1])
        assert np.allclose(q_i[0], q[i], rtol=0.0, atol=1e-13)
        assert np.allclose(w_i[0], w[i], rtol=0.0, atol=1e-15)
    # backwards in time: the motion reversed is the motion with −w0 from the same pose
    q_back, w_back = solve_rotation(I, -w0, q0, np.array([0.0, 2.5]))
    assert np.max(np.abs(w[1] + w_back[1])) < ODE_TOL
    assert np.max(np.abs(q[1] - q_back[1])) < ODE_TOL


def test_asymmetric_top_long_run_conserves_energy_and_momentum():
    """10³ s (hundreds of periods): no solver, only invariants and a continuous quaternion.

    Round-off in the angles grows like eps · (phase ≈ 2·10³ rad) ≈ 5e-13, inside ROUNDOFF_TOL.
    """
    rng = np.random.default_rng(0)
    for w0 in ([0.3, 0.2, 1.5], [1.5, 0.2, -0.3]):
        I = random_box_inertia(rng)
        t = np.linspace(0.0, 1000.0, 4001)
        q, w = cf.asymmetric_top(I, w0, random_unit_quaternion(rng), t)
        assert_conserves_energy_and_momentum(I, q, w)
        # continuous in t: steps of 0.25 s at |w| ≲ 2 rad/s move q by ≲ 0.25 (no sign flips ~2)
        assert np.max(np.linalg.norm(np.diff(q, axis=0), axis=1)) < 0.5


def test_body_rates_zero_velocity():
    w = cf.asymmetric_top_body_rates([1.0, 2.0, 3.0], [0.0, 0.0, 0.0], T_SHORT)
    assert np.array_equal(w, np.zeros((T_SHORT.size, 3)))


def test_near_separatrix_matches_ode_through_first_flip():
    """m = 1 − 2e-12: scipy.special.ellipj is O(1) wrong here (scipy#8480); ours is not.

    The small rates start at 1e-6 of the large one; the solver's ~1e-13 absolute error in them
    is amplified by up to ~1e6 while they grow to O(1) in the flip, so the tolerance is 1e-6.
    """
    I = (1.0, 2.0, 3.0)
    w0 = (1e-6, 1.0, 1e-6)
    t = np.linspace(0.0, 30.0, 121)  # the first flip is at ~25 s
    q0 = quat_from_rotation_vector([0.2, 0.1, 0.0])
    q, w = cf.asymmetric_top(I, w0, q0, t)
    q_ref, w_ref = solve_rotation(I, w0, q0, t)
    assert np.sign(w[-1, 1]) == -1.0 == np.sign(w_ref[-1, 1])
    assert_matches_ode(q, w, q_ref, w_ref, tol=1e-6)


@pytest.mark.parametrize(
    ("inertia", "w_B0", "message"),
    [
        ((1.0, 2.0, 3.0), (0.0, 1.0, 0.0), "separatrix"),  # pure intermediate-axis spin
        ((1.0, 2.0, 3.0), (1.0, np.sqrt(2.0 / 3.0), 1.0 / np.sqrt(3.0)), "separatrix"),
        ((1.0, 2.0, 2.0), (0.1, 0.2, 0.3), "symmetric_top"),
    ],
)
def test_asymmetric_top_rejects_separatrix_and_equal_moments(inertia, w_B0, message):
    with pytest.raises(ValueError, match=message):
        cf.asymmetric_top_body_rates(inertia, w_B0, T_SHORT)
    with pytest.raises(ValueError, match=message):
        cf.asymmetric_top(inertia, w_B0, [1.0, 0.0, 0.0, 0.0], T_SHORT)


# ----------------------------------------------------------------------------- intermediate-axis flip


def _sign_change_times(inertia, w_B0, t_end):
    """Times at which the intermediate-axis rate changes sign, located by the solver's events."""
    I = np.asarray(inertia, dtype=float)
    k = int(np.argsort(I)[1])

    def rhs(_t, w):
        return -np.cross(w, I * w) / I

    def crossing(_t, w):
        return w[k]

    sol = solve_ivp(rhs, (0.0, t_end), w_B0, method="DOP853", rtol=1e-13, atol=1e-13, events=crossing)
    assert sol.success, sol.message
    return sol.t_events[0]


def test_flip_period_named_case():
    """I = (1, 2, 3), w0 = (1e-3, 1, 1e-3): the textbook 27.53 s, and the solver's flips agree.

    The solver's crossing times are located to ~1e-10 s, amplified ≲ 1e3 by the 1e-3 amplitude,
    so 0.1 % (the brief's tolerance) is generous; the closed form is exact to round-off.
    """
    period = cf.intermediate_axis_flip_period([1.0, 2.0, 3.0], [1e-3, 1.0, 1e-3])
    assert abs(period - 27.53) < 0.005
    crossings = _sign_change_times([1.0, 2.0, 3.0], [1e-3, 1.0, 1e-3], 4.2 * period)
    assert crossings.size >= 3
    measured = np.diff(crossings)
    assert np.max(np.abs(measured - period)) < 1e-3 * period


def test_flip_period_random_and_both_cases():
    rng = np.random.default_rng(0)
    cases = set()
    for _ in range(6):
        I = random_box_inertia(rng)
        w0 = rng.normal(size=3)
        cases.add(elliptic_case(I, w0))
        period = cf.intermediate_axis_flip_period(I, w0)
        k = int(np.argsort(I)[1])
        crossings = _sign_change_times(I, w0, 3.5 * period)
        assert crossings.size >= 3
        assert np.max(np.abs(np.diff(crossings) - period)) < 1e-3 * period
        # and the closed-form rate changes sign at the same instants
        w_mid = cf.asymmetric_top_body_rates(I, w0, crossings)[:, k]
        assert np.max(np.abs(w_mid)) < ODE_TOL
    assert cases == {1, 2}


# ----------------------------------------------------------------------------- driven motions


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_constant_principal_torque_matches_ode(axis):
    rng = np.random.default_rng(axis)
    I = random_box_inertia(rng)
    w0, torque = rng.normal(), rng.normal()  # rad/s, N·m
    q0 = random_unit_quaternion(rng)
    t = np.linspace(0.0, 5.0, 41)
    q, w = cf.constant_principal_torque(I, axis, w0, torque, q0, t)
    torque_B = np.zeros(3)
    torque_B[axis] = torque
    w_B0 = np.zeros(3)
    w_B0[axis] = w0
    q_ref, w_ref = solve_rotation(I, w_B0, q0, t, torque_B=torque_B)
    assert_matches_ode(q, w, q_ref, w_ref)


def test_projectile_matches_ode():
    rng = np.random.default_rng(0)
    p0, v0 = rng.normal(size=3), rng.normal(size=3)
    g = np.array([0.0, 0.0, -9.81])
    t = np.linspace(0.0, 3.0, 31)
    p, v = cf.projectile(p0, v0, g, t)
    sol = solve_ivp(
        lambda _t, y: np.concatenate((y[3:], g)),
        (0.0, t[-1]),
        np.concatenate((p0, v0)),
        method="DOP853",
        rtol=1e-13,
        atol=1e-13,
        t_eval=t,
    )
    assert np.max(np.abs(p - sol.y[:3].T)) < ODE_TOL * 10  # |p| ≲ 50 m: the same relative bound
    assert np.max(np.abs(v - sol.y[3:].T)) < ODE_TOL * 10


def _box(mass, a, b, c):
    return mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def test_box_textbook_case():
    """F_B = (0, 10, 0) N at r = (0.5, 0.3, 0) m on a 2 kg, 1.0 × 0.6 × 0.4 m box.

    The positions reach ~1 m in 2 s, so they are compared at 10 × ODE_TOL (same relative bound).
    """
    mass = 2.0
    I = _box(mass, 1.0, 0.6, 0.4)
    F_B, r_B = np.array([0.0, 10.0, 0.0]), np.array([0.5, 0.3, 0.0])
    t = np.linspace(0.0, 2.0, 41)
    q, w, v, p = cf.box_body_fixed_force(mass, I[2], F_B, r_B, t)
    alpha = 5.0 / I[2]  # τ_z = 0.5 · 10 = 5 N·m
    S, C = special.fresnel(t * np.sqrt(alpha / np.pi))
    textbook = (10.0 / mass) * np.sqrt(np.pi / alpha) * np.stack((-S, C, np.zeros_like(t)), axis=1)
    assert np.max(np.abs(v - textbook)) < 1e-14
    q_ref, w_ref, v_ref, p_ref = solve_pushed_body(mass, I, F_B, r_B, t)
    assert_matches_ode(q, w, q_ref, w_ref)
    assert np.max(np.abs(v - v_ref)) < ODE_TOL
    assert np.max(np.abs(p - p_ref)) < 10 * ODE_TOL


def test_box_random_planar_pushes_and_zero_torque():
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 2.0, 21)
    for k in (0, 1, 2, 0, 1, 2):
        mass = rng.uniform(0.5, 3.0)
        I = _box(mass, *rng.uniform(0.2, 1.5, size=3))
        F_B = rng.normal(size=3) * 3.0
        r_B = rng.normal(size=3) * 0.4
        F_B[k] = 0.0
        r_B[k] = 0.0  # torque along ±e_k
        q, w, v, p = cf.box_body_fixed_force(mass, I[k], F_B, r_B, t)
        q_ref, w_ref, v_ref, p_ref = solve_pushed_body(mass, I, F_B, r_B, t)
        assert_matches_ode(q, w, q_ref, w_ref)
        assert np.max(np.abs(v - v_ref)) < ODE_TOL
        assert np.max(np.abs(p - p_ref)) < 10 * ODE_TOL
    # force through the centre of mass: plain translation
    F_B = np.array([1.0, -2.0, 0.5])
    q, w, v, p = cf.box_body_fixed_force(1.5, 0.3, F_B, 0.2 * F_B, t)
    assert np.array_equal(q, np.tile([1.0, 0.0, 0.0, 0.0], (t.size, 1)))
    assert np.array_equal(w, np.zeros((t.size, 3)))
    assert np.allclose(p, 0.5 * F_B / 1.5 * t[:, None] ** 2, rtol=1e-15, atol=0.0)


def test_box_rejects_torque_off_a_principal_axis():
    with pytest.raises(ValueError, match="along one principal axis"):
        cf.box_body_fixed_force(2.0, 0.2, [0.0, 10.0, 1.0], [0.5, 0.3, 0.0], T_SHORT)


# ----------------------------------------------------------------------------- edge validation


Q0 = [1.0, 0.0, 0.0, 0.0]


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: cf.symmetric_top([1.0, 1.0], [0, 0, 1], Q0, T_SHORT), r"`inertia` to have shape \(3,\), got \(2,\)"),
        (lambda: cf.symmetric_top([1.0, 1.0, -2.0], [0, 0, 1], Q0, T_SHORT), "`inertia` to hold three positive"),
        (lambda: cf.symmetric_top([1.0, 1.0, 2.5], [0, 0, 1], Q0, T_SHORT), "triangle inequality"),
        (lambda: cf.symmetric_top([1.0, 1.0, 2.0], [0, 0, np.nan], Q0, T_SHORT), "`w_B0` to be finite"),
        (lambda: cf.symmetric_top([1.0, 1.0, 2.0], [0, 0, 1], [1, 0, 0], T_SHORT), r"`q_WB0` to have shape \(4,\)"),
        (lambda: cf.symmetric_top([1.0, 1.0, 2.0], [0, 0, 1], [1, 0, 0, 1e-3], T_SHORT), "unit quaternion"),
        (lambda: cf.asymmetric_top([1, 2, 3], [0, 0, 1], Q0, [[0.0, 1.0]]), r"`t` to have shape \(T,\), got \(1, 2\)"),
        (lambda: cf.asymmetric_top([1, 2, 3], [0, 0, 1], Q0, 1.0), r"`t` to have shape \(T,\), got \(\)"),
        (lambda: cf.asymmetric_top_body_rates([1, 2, 3], [0, 1], T_SHORT), r"`w_B0` to have shape \(3,\), got \(2,\)"),
        (lambda: cf.asymmetric_top_body_rates([1, 2, 3], [0, 0, 1], [0.0, np.inf]), "`t` to be finite"),
        (lambda: cf.intermediate_axis_flip_period([1, 2, 3], [0, 0, 0]), "`w_B0` to be non-zero"),
        (lambda: cf.constant_principal_torque([1, 2, 3], 3, 1.0, 0.1, Q0, T_SHORT), "`axis` to be one of"),
        (lambda: cf.constant_principal_torque([1, 2, 3], 0, [1.0], 0.1, Q0, T_SHORT), "`w0` to have shape"),
        (lambda: cf.projectile([0, 0, 0], [1, 0], [0, 0, -9.81], T_SHORT), r"`v0_W` to have shape \(3,\)"),
        (lambda: cf.box_body_fixed_force(0.0, 0.2, [0, 1, 0], [1, 0, 0], T_SHORT), "`mass` to be positive"),
        (lambda: cf.box_body_fixed_force(1.0, -0.2, [0, 1, 0], [1, 0, 0], T_SHORT), "`inertia_axis` to be positive"),
        (lambda: cf.box_body_fixed_force(1.0, 0.2, [0, 1, 0, 0], [1, 0, 0], T_SHORT), "`force_B` to have shape"),
    ],
)
def test_inputs_validated_at_the_edge(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_output_shapes_and_empty_time_array():
    t = np.linspace(0.0, 1.0, 7)
    q, w = cf.asymmetric_top([1, 2, 3], [0.1, 0.2, 1.0], Q0, t)
    assert q.shape == (7, 4) and w.shape == (7, 3)
    outs = cf.box_body_fixed_force(2.0, 0.2, [0, 10, 0], [0.5, 0.3, 0], t)
    assert [o.shape for o in outs] == [(7, 4), (7, 3), (7, 3), (7, 3)]
    empty = np.array([])
    for q, w in (
        cf.asymmetric_top([1, 2, 3], [0.1, 0.2, 1.0], Q0, empty),
        cf.symmetric_top([1, 1, 2], [0.1, 0.2, 1.0], Q0, empty),
    ):
        assert q.shape == (0, 4) and w.shape == (0, 3)


def test_asymmetric_top_cost_does_not_grow_with_time_span():
    """The quadrature covers at most one period of β whatever t is (incremental, reduced)."""
    args = ([1.0, 2.0, 3.0], [0.3, 0.2, 1.5], Q0)
    start = time.perf_counter()
    cf.asymmetric_top(*args, np.linspace(0.0, 10.0, 200))
    short = time.perf_counter() - start
    start = time.perf_counter()
    cf.asymmetric_top(*args, np.linspace(0.0, 1e6, 200))
    long = time.perf_counter() - start
    assert long < 5.0 * short + 0.05
