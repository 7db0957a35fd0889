"""``free_rotor.exact_rotor`` against an independent solver: ≤ 1e-10 rad after 10 s, any ω, any h.

The reference is written here, not taken from the package: the body angular momentum obeys
``dL_B/dt = L_B × ω_B`` (Euler's equations, ω_B = L_B / I), the quaternion ``q' = ½ q ⊗ (0, ω_B)``
with the Hamilton product spelled out, integrated by ``scipy.integrate.solve_ivp`` with DOP853
at rtol = 2.5e-14 (scipy's floor is 100 ulp) and atol = 1e-16 |y0|. Its own error is bounded by
solving again at rtol = 1e-13 (:func:`test_reference_is_accurate_enough`): the two agree to
≲ 5e-12 rad, so a 1e-10 tolerance judges the rotor, not the reference.

Why 1e-10 is meaningful even on the separatrix: a torque-free body that starts on (or within
1e-9 of) the separatrix near the intermediate axis amplifies a perturbation by at most
e^{ν t} ≈ e^{0.58 · 10} ≈ 330 over 10 s here, so round-off in the state (1e-16 per step,
10³ steps) can cost ~1e-11 at worst: the method is held to what a backward-stable step
allows. The cases: the reference body exactly on the separatrix (L² = 2E·I2 in real numbers),
1e-9 to either side, leaving the saddle on the unstable branch, near each principal axis,
fast spin (|ω| h up to 94 at h = 10), tiny and huge moments (|L| from 1e-6 to 1e6), a
near-symmetric body (the |n| > 1 form of Π) and random seeded bodies.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigid_body_sim.core.free_rotor import exact_rotor

T_END = 10.0  # s
ANGLE_TOL = 1e-10  # rad, the exact rotor's accuracy target
REFERENCE_RTOL = 2.5e-14
EPS = np.finfo(float).eps

I123 = (1.0, 2.0, 3.0)  # kg·m²
SQRT3 = np.sqrt(3.0)


def _random_cases() -> list[tuple[str, tuple, tuple]]:
    rng = np.random.default_rng(13)
    cases = []
    for k in range(4):
        inertia = np.sort(rng.uniform(0.5, 1.5, 3))
        inertia[2] = min(inertia[2], inertia[0] + inertia[1])  # a real body
        cases.append((f"random {k}", tuple(inertia), tuple(rng.normal(size=3))))
    return cases


#: (name, principal moments kg·m², ω_B0 rad/s)
CASES = [
    ("on the separatrix", I123, (0.1 * SQRT3, 1.0, 0.1)),
    ("separatrix + 1e-9 (about I3)", I123, (0.1 * SQRT3 * (1.0 - 1e-9), 1.0, 0.1)),
    ("separatrix - 1e-9 (about I1)", I123, (0.1 * SQRT3 * (1.0 + 1e-9), 1.0, 0.1)),
    ("separatrix, leaving the saddle", I123, (1e-6 * SQRT3, 1.0, -1e-6)),
    ("near the intermediate axis", I123, (1e-6, 1.0, 2e-6)),
    ("near the smallest axis", I123, (2.0, 1e-7, -1e-7)),
    ("near the largest axis", I123, (1e-7, -1e-7, 2.0)),
    ("fast spin", I123, (3.0, -5.0, 8.0)),
    ("tiny moments", tuple(1e-6 * np.array(I123)), (0.3, 0.7, -0.5)),
    ("huge moments", tuple(1e6 * np.array(I123)), (0.3, 0.7, -0.5)),
    ("near-symmetric", (1.0, 2.0, 2.0 + 1e-6), (0.4, 0.6, 0.5)),
    ("other moment order", (3.0, 1.0, 2.0), (-0.2, 1.1, 0.6)),
    *_random_cases(),
]
NAMES = [c[0] for c in CASES]
INERTIA = np.array([c[1] for c in CASES])
W0 = np.array([c[2] for c in CASES])
Q0 = np.array([np.cos(0.3), 0.6 * np.sin(0.3), 0.0, 0.8 * np.sin(0.3)])  # (w, x, y, z)


# ----------------------------------------------------------------------------- the independent reference


def _q_times_pure(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """q ⊗ (0, w), (w, x, y, z), Hamilton (i·j = k), written out."""
    qw, qx, qy, qz = q
    a, b, c = w
    return np.array([-qx * a - qy * b - qz * c, qw * a + qy * c - qz * b,
                     qw * b - qx * c + qz * a, qw * c + qx * b - qy * a])


def solve_free_rotor(inertia, w_B0, q_WB0, t_end: float, rtol: float) -> tuple[np.ndarray, np.ndarray]:
    """(q_WB, w_B) at t_end by DOP853 on (L_B, q); q returned normalised."""
    I = np.asarray(inertia, dtype=float)
    y0 = np.concatenate((I * np.asarray(w_B0, dtype=float), q_WB0))

    def rhs(_t, y):
        L, q = y[:3], y[3:]
        w = L / I
        return np.concatenate((np.cross(L, w), 0.5 * _q_times_pure(q, w)))

    sol = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=rtol, atol=1e-16 * np.max(np.abs(y0)))
    assert sol.success, sol.message
    q = sol.y[3:, -1]
    return q / np.linalg.norm(q), sol.y[:3, -1] / I


def rotation_angle(q_a: np.ndarray, q_b: np.ndarray) -> np.ndarray:
    """Angle (rad) of the rotation between (w, x, y, z) quaternions, rows; sign-blind."""
    dot = np.abs(np.sum(q_a * q_b, axis=-1))
    chord = np.minimum(np.linalg.norm(q_a - q_b, axis=-1), np.linalg.norm(q_a + q_b, axis=-1))
    return 4.0 * np.arcsin(np.minimum(0.5 * chord, 1.0)) * (dot <= 1.0 + 1e-15)


@pytest.fixture(scope="module")
def reference() -> tuple[np.ndarray, np.ndarray]:
    out = [solve_free_rotor(INERTIA[i], W0[i], Q0, T_END, REFERENCE_RTOL) for i in range(len(CASES))]
    return np.array([o[0] for o in out]), np.array([o[1] for o in out])


def run_rotor(h: float) -> tuple[np.ndarray, np.ndarray]:
    """All cases at once (the rotor is vectorised over bodies), T_END / h steps of h."""
    steps = int(round(T_END / h))
    assert abs(steps * h - T_END) < 1e-12
    q = np.tile(Q0, (len(CASES), 1))
    L = INERTIA * W0
    for _ in range(steps):
        q, L = exact_rotor(INERTIA, q, L, h)
        q = q / np.linalg.norm(q, axis=1, keepdims=True)  # as the integrators do
    return q, L


def _check_against_reference(h: float, reference) -> None:
    q_ref, w_ref = reference
    q, L = run_rotor(h)
    w = L / INERTIA
    angle = rotation_angle(q, q_ref)
    rate_err = np.max(np.abs(w - w_ref), axis=1) / np.max(np.abs(W0), axis=1)
    bad = [f"{NAMES[i]}: {angle[i]:.1e} rad, dw/|w| {rate_err[i]:.1e}"
           for i in range(len(CASES)) if not (angle[i] <= ANGLE_TOL and rate_err[i] <= ANGLE_TOL)]
    assert not bad, f"h = {h}: " + "; ".join(bad)
    # Invariants: exact for the flow; the rotor puts them back to ~ulp² each step, so what is
    # left is the unbiased rounding of L: a random walk of ~1 ulp per step.
    steps = round(T_END / h)
    L0 = INERTIA * W0
    tol = 16.0 * EPS * np.sqrt(steps)
    assert np.max(np.abs(np.linalg.norm(L, axis=1) / np.linalg.norm(L0, axis=1) - 1.0)) <= tol
    energy, energy0 = np.sum(L * L / INERTIA, axis=1), np.sum(L0 * L0 / INERTIA, axis=1)
    assert np.max(np.abs(energy / energy0 - 1.0)) <= tol


# ----------------------------------------------------------------------------- tests


def test_reference_is_accurate_enough(reference) -> None:
    """DOP853 at rtol 1e-13 and 2.5e-14 agree to 5e-12 rad: it can judge 1e-10."""
    q_ref, w_ref = reference
    for i in range(len(CASES)):
        q, w = solve_free_rotor(INERTIA[i], W0[i], Q0, T_END, 1e-13)
        assert rotation_angle(q, q_ref[i]) < 5e-12, NAMES[i]
        assert np.max(np.abs(w - w_ref[i])) < 5e-12 * np.max(np.abs(W0[i])), NAMES[i]


def test_reference_case_is_on_the_separatrix() -> None:
    """L² − 2E·I2 = 0 in real numbers for I = (1, 2, 3), ω = (0.1√3, 1, 0.1); ~1 ulp once rounded."""
    I, w = np.array(I123), W0[0]
    L2, two_E_I2 = np.sum((I * w) ** 2), 2.0 * np.sum(I * w * w)
    assert abs(L2 - two_E_I2) <= 4 * EPS * L2


@pytest.mark.parametrize("h", [10.0, 2.5, 1.0, 0.1, 0.01])
def test_exact_rotor_matches_the_reference(h: float, reference) -> None:
    """≤ 1e-10 rad and rad/s after 10 s for every case, from one step of 10 s to 10³ steps."""
    _check_against_reference(h, reference)


@pytest.mark.slow
@pytest.mark.parametrize("h", [1e-3, 1e-4])
def test_exact_rotor_matches_the_reference_small_steps(h: float, reference) -> None:
    """The same at 10⁴ and 10⁵ steps: round-off per step does not add up to 1e-10."""
    _check_against_reference(h, reference)


def test_one_step_equals_many_steps_on_the_separatrix() -> None:
    """The flow property at the reference body: 1 × 10 s and 40 × 0.25 s agree to 1e-12 rad."""
    I, L0 = INERTIA[:1], INERTIA[:1] * W0[:1]
    q_one, L_one = exact_rotor(I, Q0[None], L0, 10.0)
    q, L = Q0[None], L0
    for _ in range(40):
        q, L = exact_rotor(I, q, L, 0.25)
    assert rotation_angle(q, q_one)[0] < 1e-12
    assert np.max(np.abs(L - L_one)) < 1e-12 * np.max(np.abs(L0))


def test_a_step_and_its_reverse_return_to_the_start() -> None:
    """exact_rotor(−h) undoes exact_rotor(h) to round-off, for every case and a long step."""
    q1, L1 = exact_rotor(INERTIA, np.tile(Q0, (len(CASES), 1)), INERTIA * W0, 3.7)
    q0, L0 = exact_rotor(INERTIA, q1, L1, -3.7)
    assert np.max(rotation_angle(q0, np.tile(Q0, (len(CASES), 1)))) < 1e-12
    assert np.max(np.abs(L0 - INERTIA * W0) / np.abs(INERTIA * W0).max(axis=1, keepdims=True)) < 1e-12


def test_exact_rotor_handles_the_degenerate_spins() -> None:
    """L = 0, pure spins about each principal axis (the intermediate one included), in one call."""
    inertia = np.tile(I123, (5, 1))
    L = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, -3.0, 0.0], [0.0, 0.0, 4.5], [0.0, 1e-200, 3.0]])
    q, L_out = exact_rotor(inertia, np.tile(Q0, (5, 1)), L, 2.0)
    assert np.all(np.isfinite(q)) and np.array_equal(L_out, L)
    for i in range(5):
        w = L[i] / inertia[i]
        angle = 2.0 * np.linalg.norm(w)  # rad turned in 2 s
        expected = np.concatenate(([np.cos(0.5 * angle)], np.sin(0.5 * angle) * w / max(np.linalg.norm(w), 1e-300)))
        w_, x, y, z = Q0
        a, b, c, d = expected
        q_exp = np.array([w_ * a - x * b - y * c - z * d, w_ * b + x * a + y * d - z * c,
                          w_ * c - x * d + y * a + z * b, w_ * d + x * c - y * b + z * a])
        assert rotation_angle(q[i], q_exp) < 1e-14
