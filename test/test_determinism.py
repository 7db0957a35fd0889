"""Determinism: the same inputs in the same order give the same state, bitwise.

Both sides are computed by the same code on the same machine, so they are compared bitwise
(STYLE.md convention 12). One table over every integrator of ``INTEGRATORS`` for the core (held
wrenches in body, site and world frames, an impulse, a change of step, several bodies), and the
node through its real ROS interface (wrenches and an impulse over topics, substeps, ~/step).
Checks that a run equals a *different* run fed the same accepted inputs (rejected messages
change nothing, the fuzz's clean twin, a script against the same wrench by hand) live with the
inputs they are about.
"""

from __future__ import annotations

import numpy as np
import pytest

from helpers import random_tumbling_bodies, scene_of
from rigid_body_sim.core import INTEGRATORS, Simulator
from rigid_body_sim.testing import SimHarness


def _core_run(integrator: str) -> tuple[bytes, ...]:
    bodies = random_tumbling_bodies(np.random.default_rng(50), 3, spin_rate=2.0)
    bodies["b0"]["sites"] = {"tip": {"position": [0.3, -0.2, 0.1]}, "nozzle": {"position": [0.0, 0.1, -0.2], "axes": "world"}}
    sim = Simulator(scene_of(bodies, gravity=[0.0, 0.0, -9.81]), integrator, 0.01)
    for k in range(40):
        sim.apply_wrench("b0", force=[0.5, -1.0, 2.0], torque=[0.1, 0.0, -0.2], frame="b0/tip")
        sim.apply_wrench("b1", force=[np.cos(0.1 * k), 0.3, 0.0], torque=[0.0, 0.05, 0.0], frame="world")
        sim.apply_force_at_point("b2", [0.0, 0.0, 1.5], [0.1, 0.2, 0.0], frame="b2")
        if k == 15:
            sim.apply_impulse("b1", linear=[0.2, 0.0, -0.1], angular=[0.0, 0.03, 0.0], frame="b1/world_aligned")
        if k == 25:
            sim.dt = 0.005
        sim.step(2 if integrator != "reference" else 1)
    state = sim.state
    return tuple(a.tobytes() for a in (state.p_WC_W, state.q_WP, state.v_WC_W, state.w_WP_P)) + (np.float64(sim.time).tobytes(),)


@pytest.mark.parametrize("integrator", tuple(INTEGRATORS))
def test_two_identical_core_runs_are_bitwise_equal(integrator: str) -> None:
    first, second = _core_run(integrator), _core_run(integrator)
    assert first == second
    assert first != _core_run("rk4" if integrator != "rk4" else "splitting")  # the runs do depend on the method


def _published(harness: SimHarness, body: str) -> tuple[float, ...]:
    pose, twist = harness.latest_pose(body).pose, harness.latest_twist(body)
    return (pose.position.x, pose.position.y, pose.position.z,
            pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w,
            twist.linear.x, twist.linear.y, twist.linear.z, twist.angular.x, twist.angular.y, twist.angular.z)


@pytest.mark.ros
def test_two_identical_node_runs_are_bitwise_equal() -> None:
    def run() -> bytes:
        with SimHarness(parameters={"integrator": "splitting", "substeps": 3}) as node:
            node.publish_wrench("box", force=(0.0, 10.0, 0.0), frame_id="box/corner")
            node.step(7)
            node.publish_wrench("box", torque=(0.1, 0.0, 0.0), frame_id="world")
            node.publish_impulse("box", linear=(0.0, 0.0, 0.3), frame_id="box/world_aligned")
            node.step(60)
            return np.array(_published(node, "box")).tobytes()

    assert run() == run()
