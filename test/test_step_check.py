"""The blow-up check of every step (kernels/stepping.check_body) against its rule, written in numpy; the shared
zero wrench row of a step with no wrench (stepping.wrench_rows) against every body's own row.

The rule (simulator.NonFiniteStateError, DivergenceError): NON_FINITE if any of the 13 state
numbers the step produced is not finite; else DIVERGED if the kinetic energy ½(m|v|² + Σ I_i w_i²)
exceeds limit·B², B the bound carried with the state; else OK. The compiled check tests fewer
numbers when it can (a finite energy implies finite v and w), so it is run here on rows with
an inf, a NaN or a huge finite number in every position, and on overflowing energies.
"""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from rigid_body_sim.core import INTEGRATORS, Simulator, load_scene
from rigid_body_sim.core.kernels import layout as L
from rigid_body_sim.core.kernels.forces import add_wrench
from rigid_body_sim.core.kernels.stepping import check_body
from rigid_body_sim.core.stepping import pack_parameters, unchecked_steps


@njit(cache=False)
def _check(y, out, p, w, dt, limit):
    return check_body(y, out, p, w, dt, limit)


def _rule(out: np.ndarray, p: np.ndarray, bound: float, limit: float) -> int:
    with np.errstate(all="ignore"):
        if not np.isfinite(out[:L.STATE_WIDTH]).all():
            return L.NON_FINITE
        v, w = out[L.V:L.V + 3], out[L.W:L.W + 3]
        energy = 0.5 * (p[L.MASS] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
                        + p[L.INERTIA] * w[0] ** 2 + p[L.INERTIA + 1] * w[1] ** 2 + p[L.INERTIA + 2] * w[2] ** 2)
        return L.DIVERGED if energy > limit * bound * bound else L.OK


def test_the_check_gives_the_rule_for_every_non_finite_or_huge_number_anywhere() -> None:
    rng = np.random.default_rng(7)
    p = np.zeros(L.PRM_WIDTH)
    p[L.MASS], p[L.INERTIA:L.INERTIA + 3] = 2.0, (0.1, 0.2, 0.3)
    p[L.GRAVITY_BUDGET_RATE] = 1.0
    w = np.zeros(L.WRENCH_WIDTH)
    y = np.zeros(L.ROW_WIDTH)
    y[L.Q], y[L.BOUND] = 1.0, 10.0
    dt, limit = 0.01, 1e6
    bound = y[L.BOUND] + dt * p[L.GRAVITY_BUDGET_RATE]
    outcomes = set()
    for value in (np.inf, -np.inf, np.nan, 1e200, -1e160, 3e3, 0.5):
        for j in range(L.STATE_WIDTH):
            for base in (0.0, 1.0):
                out = np.full(L.ROW_WIDTH, base) + rng.normal(size=L.ROW_WIDTH) * 0.1
                out[j] = value
                got = _check(y, out, p, w, dt, limit)
                assert got == _rule(out, p, bound, limit), (value, j, base)
                assert out[L.BOUND] == bound
                outcomes.add(got)
    assert outcomes == {L.OK, L.NON_FINITE, L.DIVERGED}



def test_the_check_gives_the_rule_where_its_one_test_of_the_common_case_cannot_decide() -> None:
    """check_body passes a row at once when the sum of p, q and the energy is finite and the energy is
    within limit·B²; otherwise it applies the rule. Against the rule: finite rows whose sum overflows,
    energies that overflow, an energy a few ulps either side of limit·B², bounds of 0, inf and NaN,
    and signed zeros."""
    p = np.zeros(L.PRM_WIDTH)
    p[L.MASS], p[L.INERTIA:L.INERTIA + 3] = 2.0, (0.1, 0.2, 0.3)
    p[L.GRAVITY_BUDGET_RATE] = 1.0
    w = np.zeros(L.WRENCH_WIDTH)
    dt = 0.01

    def row(pos=(0.0, 0.0, 0.0), q=(1.0, 0.0, 0.0, 0.0), v=(0.1, 0.0, 0.0), omega=(0.0, 0.2, 0.0)) -> np.ndarray:
        out = np.zeros(L.ROW_WIDTH)
        out[L.P:L.P + 3], out[L.Q:L.Q + 4], out[L.V:L.V + 3], out[L.W:L.W + 3] = pos, q, v, omega
        return out

    rows = [row(pos=(1e308, 1e308, 0.0)), row(pos=(-1e308, 0.0, -1e308)), row(q=(1e308, 1e308, 1e308, 1e308)),
            row(pos=(1e308, 1e308, 0.0), v=(1e10, 0.0, 0.0)), row(v=(1e200, 0.0, 0.0)), row(omega=(0.0, 0.0, -1e200)),
            row(pos=(1e308, 1e308, 0.0), v=(1e200, 0.0, 0.0)), row(pos=(-0.0, -0.0, -0.0), q=(-0.0, -1.0, -0.0, -0.0)),
            row(v=(-0.0, 0.0, -0.0), omega=(-0.0, -0.0, 0.0)), row(v=(3.0, -4.0, 12.0), omega=(5.0, -6.0, 7.0))]
    outcomes = set()
    for out0 in rows:
        for y_bound in (0.0, 1.0, 1e155, np.inf, np.nan):
            y = np.zeros(L.ROW_WIDTH)
            y[L.Q], y[L.BOUND] = 1.0, y_bound
            bound = y[L.BOUND] + dt * p[L.GRAVITY_BUDGET_RATE]
            v, omega = out0[L.V:L.V + 3], out0[L.W:L.W + 3]
            with np.errstate(all="ignore"):
                energy = 0.5 * (p[L.MASS] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + p[L.INERTIA] * omega[0] ** 2
                                + p[L.INERTIA + 1] * omega[1] ** 2 + p[L.INERTIA + 2] * omega[2] ** 2)
                at_limit = energy / (bound * bound) if 0.0 < bound < np.inf and 0.0 < energy < np.inf else 1e6
            limits = [1.0, 1e6, np.inf]
            step = at_limit
            for _ in range(3):  # the limit where limit·B² meets the energy, and a few ulps either side
                step = np.nextafter(step, 0.0)
            for _ in range(7):
                limits.append(step)
                step = np.nextafter(step, np.inf)
            for limit in limits:
                out = out0.copy()
                got = _check(y, out, p, w, dt, limit)
                assert got == _rule(out, p, bound, limit), (out0, y_bound, limit)
                assert np.array_equal(out[L.BOUND], bound, equal_nan=True)
                outcomes.add(got)
    assert outcomes == {L.OK, L.DIVERGED}


COMPILED = [name for name, method in INTEGRATORS.items() if method.code is not None]


@pytest.mark.parametrize("integrator", COMPILED)
@pytest.mark.parametrize("wrench", [False, True], ids=["no-wrench", "one-wrench"])
def test_the_step_reads_the_same_wrench_rows_whether_or_not_any_is_active(integrator: str, wrench: bool) -> None:
    """Simulator.step (stepping.advance: every body reads one shared zero row when no row is active,
    stepping.wrench_rows) against core/stepping.unchecked_steps (the integrator's loop on every
    body's own row): the same states to the bit."""
    bodies = {f"b{i}": {"mass": 1.0 + i, "inertia": {"box": [1.0, 0.6 + 0.1 * i, 0.4]},
                        "pose": {"position": [2.0 * i, 0.0, 0.0]},
                        "twist": {"linear": [0.1, 0.0, -0.2], "angular": [0.3, 1.0 - 0.2 * i, 0.2]}} for i in range(4)}
    scene = load_scene({"gravity": [0.0, 0.0, -9.81], "bodies": bodies})
    sim = Simulator(scene, integrator=integrator, dt=0.01, model_reduction=False)
    rows = np.zeros((4, L.WRENCH_WIDTH))
    if wrench:
        sim.apply_wrench("b2", (1.0, -2.0, 0.5), (0.1, 0.0, -0.3), "b2")
        add_wrench(rows[2], pack_parameters(scene.model)[2], L.FRAME_BODY, 0.0, 0.0, 0.0, 1.0, -2.0, 0.5, 0.1, 0.0, -0.3)
    sim.step(5)
    expected = unchecked_steps(integrator, scene.model, scene.initial_state, 0.01, 5, rows)
    assert np.array_equal(sim.state.rows(), expected.rows())
