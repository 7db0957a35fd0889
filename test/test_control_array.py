"""The control array (Simulator.control): a numpy row a controller writes, added inside the compiled step.

A control row and an applied wrench go through the same compiled function (forces.add_wrench)
into a zero wrench row, so the motion is compared bitwise with apply_wrench /
apply_force_at_point, in every frame kind, on the one-call path (stepping.advance) and the
step-by-step one (a numpy integrator). A row with a non-finite number, or whose wrench
overflows, is rejected for its body only, with nothing of it applied, and reported.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.core.simulator import ControlRejectedWarning

SCENE = {"bodies": {
    "b": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]},
          "pose": {"position": [0.0, 0.0, 1.0], "orientation": [0.1, 0.2, 0.3, 0.9273618495495703]},
          "twist": {"linear": [0.1, 0.0, 0.0], "angular": [0.3, 1.0, 0.2]},
          "sites": {"corner": {"position": [0.5, 0.3, 0.0]}, "corner_w": {"position": [0.5, 0.3, 0.0], "axes": "world"}}},
    "c": {"mass": 3.0, "inertia": {"box": [0.5, 0.8, 1.2]}, "twist": {"angular": [-0.4, 0.3, 0.2]}},
}}
FRAMES = ["world", "b", "b/world_aligned", "b/corner", "b/corner_w"]
#: One of each path: the one-call compiled step, and a numpy integrator stepped one step per call.
INTEGRATORS = ["rk4", "semi_implicit_euler", "exact_rotor_splitting"]


def _free(scene, steps: int, integrator: str = "rk4") -> np.ndarray:
    """The state rows after ``steps`` steps with no input."""
    sim = Simulator(scene, integrator=integrator, dt=0.01)
    sim.step(steps)
    return sim.state.rows()


def _forces(k: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(k)
    return rng.normal(size=3) * 5.0, rng.normal(size=3)


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("frame", FRAMES)
@pytest.mark.parametrize("call", ["apply_wrench", "apply_force_at_point"])
def test_control_moves_the_body_bitwise_as_an_applied_wrench(call: str, integrator: str, frame: str) -> None:
    scene = load_scene(SCENE)
    applied, controlled = Simulator(scene, integrator=integrator, dt=0.01), Simulator(scene, integrator=integrator, dt=0.01)
    u = controlled.control("b", frame)
    for k in range(5):
        force, torque = _forces(k)
        if call == "apply_wrench":
            applied.apply_wrench("b", force, torque, frame)
            u[:3], u[3:] = force, torque
        else:  # a force at the frame's origin
            applied.apply_force_at_point("b", force, (0.0, 0.0, 0.0), frame)
            u[:3], u[3:] = force, 0.0
        applied.step(2)
        controlled.step(2)
    assert np.array_equal(applied.state.rows(), controlled.state.rows())
    assert not np.array_equal(applied.state.rows(), _free(scene, 10, integrator))  # the wrench did something


def test_a_control_holds_until_written_and_reset_zeroes_it() -> None:
    scene = load_scene(SCENE)
    sim, reference = Simulator(scene, dt=0.01), Simulator(scene, dt=0.01)
    u = sim.control("c", "c/world_aligned")
    assert u.shape == (6,) and u.dtype == np.float64 and not u.any()
    assert np.shares_memory(u, sim.control("c", "c/world_aligned"))
    u[:] = (0.0, 0.0, 3.0, 0.0, 0.0, 0.0)
    for _ in range(5):  # written once, acts at every step call
        reference.apply_wrench("c", (0.0, 0.0, 3.0), frame="c/world_aligned")
        reference.step(2)
        sim.step(2)
    assert np.array_equal(sim.state.rows(), reference.state.rows())
    sim.reset()
    assert not u.any()
    sim.step(3)
    assert np.array_equal(sim.state.rows(), _free(scene, 3))


def test_unknown_frame_is_refused_with_the_valid_ones() -> None:
    sim = Simulator(load_scene(SCENE), dt=0.01)
    with pytest.raises(ValueError, match=r"unknown frame 'b/nose' for body 'b'; valid frames are \['world', 'b'"):
        sim.control("b", "b/nose")
    with pytest.raises(ValueError, match="unknown body 'd'"):
        sim.control("d")


@pytest.mark.parametrize("integrator", ["rk4", "exact_rotor_splitting"])
@pytest.mark.parametrize("bad", [
    pytest.param(("b/corner", (np.nan, 1.0, 0.0, 0.0, 0.0, 0.0)), id="nan-force"),
    pytest.param(("b", (0.0, 0.0, 0.0, 0.0, np.inf, 0.0)), id="inf-torque"),
    pytest.param(("b/corner", (1.7e308,) * 6), id="wrench-overflows"),  # torque + arm × force: inf
])
def test_a_non_finite_control_is_rejected_for_its_body_only_and_reported(integrator: str, bad) -> None:
    scene = load_scene(SCENE)
    frame, values = bad
    sim, reference = Simulator(scene, integrator=integrator, dt=0.01), Simulator(scene, integrator=integrator, dt=0.01)
    u_b, u_c = sim.control("b", frame), sim.control("c", "c")
    u_b[:] = values
    u_c[:] = (1.0, 2.0, 0.0, 0.0, 0.0, 0.5)
    with pytest.warns(ControlRejectedWarning, match=rf"control rejected, nothing of it applied .*'b' in '{frame}'"):
        sim.step(2)
    assert [(body, f) for body, f, _values in sim.rejected_controls] == [("b", frame)]
    assert np.array_equal(np.array(sim.rejected_controls[0][2]), np.array(values), equal_nan=True)
    reference.apply_wrench("c", (1.0, 2.0, 0.0), (0.0, 0.0, 0.5), "c")  # b: nothing applied; c: its control
    reference.step(2)
    assert np.array_equal(sim.state.rows(), reference.state.rows())
    u_b[:] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.step(1)
    assert sim.rejected_controls == ()
