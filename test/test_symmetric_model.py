"""The symmetric model keeps its step's rotation increments with the state they lead to: never stale.

reduced_models.symmetric_free reuses q ← A ⊗ q ⊗ B from the last step when the step starts from
exactly the state that step left, with the same dt. Anything else (a state set from outside, a
step with a torque taken by the integrator, a new dt) must recompute them: each case is checked
against the closed-form symmetric top started from the state at hand.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.core.quaternion import quat_angle_between
from rigid_body_sim.exact import closed_form

#: Angle between the model's orientation and the closed form after tens of steps: round-off (a
#: stale increment is off by ~|Δω|·t, many orders of magnitude more).
ANGLE_TOL = 1e-11


def _sim(integrator: str = "rk4", dt: float = 0.05) -> Simulator:
    scene = load_scene({"bodies": {"can": {"mass": 2.0, "inertia": {"cylinder": [0.1, 0.5]},
                                           "twist": {"angular": [0.7, -0.4, 9.0]}}}})
    sim = Simulator(scene, integrator=integrator, dt=dt)
    assert [plan.model for plan in sim.body_models()] == ["symmetric"]
    return sim


def _follows_the_closed_form(sim: Simulator, steps: int) -> None:
    """Step ``steps`` torque-free steps and compare with the closed-form top from the state before them."""
    start = sim.state.copy()
    I = sim.model.inertia_P[0]
    sim.step(steps)
    q_ref, w_ref = closed_form.symmetric_top(I, start.w_WP_P[0], start.q_WP[0], np.array([steps * sim.dt]))
    assert quat_angle_between(sim.state.q_WP[0], q_ref[0]) < ANGLE_TOL
    np.testing.assert_allclose(sim.state.w_WP_P[0], w_ref[0], rtol=0, atol=1e-11 * np.linalg.norm(w_ref[0]))


def test_a_state_set_from_outside_is_not_stepped_with_the_old_increments() -> None:
    sim = _sim()
    _follows_the_closed_form(sim, 30)
    sim.set_body_state("can", angular_velocity_world=[3.0, 1.0, -2.0])
    _follows_the_closed_form(sim, 30)
    sim.set_body_state("can", orientation_xyzw=[0.0, 0.6, 0.0, 0.8])  # same rates, another orientation: new L_W
    _follows_the_closed_form(sim, 30)


@pytest.mark.parametrize("integrator", ["rk4", "euler"])
def test_a_step_under_a_torque_is_the_integrators_and_the_next_ones_start_afresh(integrator: str) -> None:
    sim = _sim(integrator)
    _follows_the_closed_form(sim, 10)
    w_before = sim.state.w_WP_P[0].copy()
    sim.apply_wrench("can", torque=[0.5, 0.0, 0.2], frame="can")
    sim.step(1)
    assert not np.allclose(sim.state.w_WP_P[0], w_before, rtol=1e-3)  # the torque acted
    _follows_the_closed_form(sim, 30)


def test_a_new_dt_recomputes_the_increments() -> None:
    sim = _sim(dt=0.05)
    _follows_the_closed_form(sim, 20)
    sim.dt = 0.02
    _follows_the_closed_form(sim, 20)
