"""The impact law: closed forms for frictionless impacts, and energy never rising (hypothesis).

Closed form (single frictionless contact at r from the centre of mass, normal n):
P = −(1 + e) v_n / (1/m + (r × n)·I⁻¹(r × n)), Δv = P n / m, Δω = I⁻¹ (r × P n), energy lost
½ (1 − e²) m_eff v_n². Simultaneous frictionless contacts (a box landing flat): Newton's law
per contact, v⁺_n = −e v⁻_n at every corner. With friction and spin, over random bodies,
contacts and velocities: the kinetic energy after is at most the energy before (within
1e-12 relative), no contact point ends up approaching the ground, and friction never
accelerates the slip.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from helpers import random_rotation_matrix
from rigid_body_sim.core.kernels.contact.impacts import IMPACT_WORK_SHAPE, impact
from rigid_body_sim.core.kernels.contact.layout import MAX_POINTS
from rigid_body_sim.core.kernels.contact.shapes import box_points
from rigid_body_sim.core.kernels.layout import INERTIA, INV_INERTIA, INV_MASS, MASS, P, PRM_WIDTH, Q, ROW_WIDTH, V, W
from rigid_body_sim.core.quaternion import quat_from_matrix, quat_to_matrix

SETTINGS = settings(max_examples=300, deadline=None, derandomize=True, database=None)


def body(rng, mass=None, moments=None):
    """(state row, parameter row) of a random body: random orientation, velocity, spin."""
    y = np.zeros(ROW_WIDTH)
    p = np.zeros(PRM_WIDTH)
    m = rng.uniform(0.1, 10.0) if mass is None else mass
    if moments is None:
        a, b = rng.uniform(0.1, 1.0, size=2)
        moments = np.array([a, b, rng.uniform(abs(a - b) + 0.01, a + b)])  # a triangle: a real body
    p[MASS], p[INV_MASS] = m, 1.0 / m
    p[INERTIA:INERTIA + 3], p[INV_INERTIA:INV_INERTIA + 3] = moments, 1.0 / np.asarray(moments)
    y[P:P + 3] = rng.normal(size=3)
    y[Q:Q + 4] = quat_from_matrix(random_rotation_matrix(rng))
    y[V:V + 3] = rng.normal(size=3)
    y[W:W + 3] = rng.normal(size=3) * 3.0
    return y, p


def energy(y, p):
    return 0.5 * (p[MASS] * y[V:V + 3] @ y[V:V + 3] + p[INERTIA:INERTIA + 3] @ y[W:W + 3] ** 2)


def point_velocity(y, r_W):
    R = quat_to_matrix(y[Q:Q + 4])
    return y[V:V + 3] + np.cross(R @ y[W:W + 3], r_W)


def test_single_frictionless_impact_is_the_closed_form():
    rng = np.random.default_rng(4)
    for _ in range(100):
        y, p = body(rng)
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        r = rng.normal(size=3) * 0.3
        if point_velocity(y, r) @ n >= 0.0:
            y[V:V + 3] -= (point_velocity(y, r) @ n + 1.0) * n  # make it approach
        e = rng.uniform(0.0, 1.0)
        R = quat_to_matrix(y[Q:Q + 4])
        I_inv_W = R @ np.diag(1.0 / p[INERTIA:INERTIA + 3]) @ R.T
        v_n = point_velocity(y, r) @ n
        rn = np.cross(r, n)
        m_eff = 1.0 / (1.0 / p[MASS] + rn @ I_inv_W @ rn)
        P_exact = -(1.0 + e) * v_n * m_eff
        out = y.copy()
        points = np.zeros((MAX_POINTS, 3))
        points[0] = y[P:P + 3] + r
        total, before, after, alpha = impact(y, out, p, 1, points, *n, e, 0.0, np.zeros(IMPACT_WORK_SHAPE))
        assert alpha == e
        assert total == pytest.approx(P_exact, rel=1e-12)
        assert out[V:V + 3] == pytest.approx(y[V:V + 3] + P_exact * n / p[MASS], rel=1e-12, abs=1e-12)
        w_W = R @ out[W:W + 3]
        assert w_W == pytest.approx(R @ y[W:W + 3] + I_inv_W @ (P_exact * rn), rel=1e-11, abs=1e-12)
        assert point_velocity(out, r) @ n == pytest.approx(-e * v_n, rel=1e-11, abs=1e-13)
        assert before - after == pytest.approx(0.5 * (1.0 - e * e) * m_eff * v_n * v_n, rel=1e-10, abs=1e-13)
        assert before == pytest.approx(energy(y, p), rel=1e-14) and after == pytest.approx(energy(out, p), rel=1e-14)


def test_box_landing_flat_frictionless_obeys_newton_at_every_corner():
    rng = np.random.default_rng(5)
    for e in (0.0, 0.3, 1.0):
        y, p = body(rng, mass=2.0, moments=2.0 / 12.0 * np.array([0.1**2 + 0.4**2, 0.4**2 + 0.4**2,
                                                                   0.4**2 + 0.1**2]))
        y[Q:Q + 4] = (1.0, 0.0, 0.0, 0.0)
        y[P:P + 3] = (0.0, 0.0, 0.05)  # edges 0.4 × 0.4 × 0.1 → half height 0.05: on the ground
        y[V:V + 3] = (0.3, -0.2, -2.0)
        y[W:W + 3] = (0.0, 0.0, 0.0)
        points, gaps = np.zeros((MAX_POINTS, 3)), np.zeros(MAX_POINTS)
        count = box_points(*y[P:P + 3], *y[Q:Q + 4], 0.2, 0.2, 0.05, 0.0, 0.0, 1.0, 0.0, points, gaps)
        assert count == 4
        out = y.copy()
        impact(y, out, p, count, points, 0.0, 0.0, 1.0, e, 0.0, np.zeros(IMPACT_WORK_SHAPE))
        for k in range(4):
            r = points[k] - y[P:P + 3]
            assert point_velocity(out, r)[2] == pytest.approx(2.0 * e, abs=1e-12)
        assert out[V:V + 2] == pytest.approx(y[V:V + 2], abs=1e-15)  # frictionless: tangential untouched
        assert out[W:W + 3] == pytest.approx(np.zeros(3), abs=1e-12)


@SETTINGS
@example(seed=479001599, count=4, e=0.5, mu=2.0, spin=0.0)  # Gauss–Seidel short at μ = 2: frictionless after
@given(seed=st.integers(0, 2**32 - 1), count=st.sampled_from([1, 2, 4]), e=st.floats(0.0, 1.0),
       mu=st.floats(0.0, 2.0), spin=st.floats(0.0, 50.0))
def test_energy_never_rises_with_friction_and_spin(seed, count, e, mu, spin):
    rng = np.random.default_rng(seed)
    y, p = body(rng)
    y[W:W + 3] *= spin / max(np.linalg.norm(y[W:W + 3]), 1e-300)
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    # contact points: a random body-fixed patch below the centre of mass, approaching the plane
    points = np.zeros((MAX_POINTS, 3))
    for k in range(count):
        points[k] = y[P:P + 3] - 0.2 * n + 0.2 * rng.normal(size=3) * (1.0 if count > 1 else 0.0)
        points[k] -= ((points[k] - y[P:P + 3]) @ n + 0.2) * n  # all on one plane, 0.2 below the COM
    speeds = [point_velocity(y, points[k] - y[P:P + 3]) @ n for k in range(count)]
    if max(speeds) >= 0.0:
        y[V:V + 3] -= (max(speeds) + rng.uniform(0.1, 5.0)) * n  # every point approaches
    out = y.copy()
    total, before, after, alpha = impact(y, out, p, count, points, *n, e, mu, np.zeros(IMPACT_WORK_SHAPE))
    E0, E1 = energy(y, p), energy(out, p)
    assert E1 - E0 <= 1e-12 * E0
    assert after <= before * (1.0 + 1e-12)
    assert total >= 0.0 and 0.0 <= alpha <= e
    # nothing approaches the ground afterwards (the compression removed every approach)
    scale = max(abs(s) for s in speeds) + np.linalg.norm(y[V:V + 3]) + spin
    for k in range(count):
        assert point_velocity(out, points[k] - y[P:P + 3]) @ n >= -1e-9 * scale
    assert np.all(np.isfinite(out))
