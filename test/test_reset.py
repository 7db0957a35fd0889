"""``~/reset`` and ``~/reset_world`` over DDS: the first takes everything back to t = 0 (/clock
too), the second only the bodies (as Gazebo's reset_world): /clock goes on."""

from __future__ import annotations

import numpy as np
import pytest
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock

from rigid_body_sim.testing import SimHarness

from session_support import TICK_S, X0, make_session

pytestmark = pytest.mark.ros


def test_session_reset_world_keeps_time_and_restores_the_bodies():
    """SimSession (no ROS): the bodies' initial state back, time and step count unchanged, the
    edge told to drop holds (keep_state False) and to publish at the same time; ticks go on from there."""
    session, io = make_session()
    session.step_ticks(7)
    before_s, steps = session.simulator.time, session.simulator.step_count
    assert not np.allclose(session.simulator.body_state("box").position_world, X0)
    ok, message = session.reset_world()
    assert ok and "goes on" in message, message
    sim = session.simulator
    assert (sim.time, sim.step_count) == (before_s, steps)
    fresh = make_session()[0].simulator
    for body in sim.body_names:
        assert np.array_equal(sim.body_state(body).position_world, fresh.body_state(body).position_world)
        assert np.array_equal(sim.body_state(body).orientation_xyzw, fresh.body_state(body).orientation_xyzw)
        assert np.array_equal(sim.body_state(body).linear_velocity_world, fresh.body_state(body).linear_velocity_world)
    assert io.named("prepare")[-1] == ("prepare", sim.body_names, False)
    assert io.named("commit")[-1] == ("commit", sim.body_names, False)
    assert io.calls[-1] == ("publish", before_s)
    session.step_ticks(1)
    assert session.simulator.time == pytest.approx(before_s + TICK_S, abs=1e-12)
    ok, _ = session.reset()
    assert ok and session.simulator.time == 0.0



def _clock_ns(msg: Clock) -> int:
    return msg.clock.sec * 10**9 + msg.clock.nanosec


def _pose(harness: SimHarness, body: str) -> tuple[np.ndarray, np.ndarray]:
    pose = harness.latest_pose(body).pose
    return (np.array([pose.position.x, pose.position.y, pose.position.z]),
            np.array([pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w]))


def _with_clock(harness: SimHarness) -> list[int]:
    clocks: list[int] = []
    harness.client.create_subscription(Clock, "/clock", lambda msg: clocks.append(_clock_ns(msg)),
                                       QoSProfile(depth=100))
    harness.spin_until(lambda: harness.client.count_publishers("/clock") > 0, "the node's /clock publisher")
    return clocks


def test_reset_world_puts_bodies_back_while_clock_goes_on():
    with SimHarness(paused=True) as harness:
        clocks = _with_clock(harness)
        initial = _pose(harness, "box")
        harness.publish_wrench("box", force=(0.0, 10.0, 0.0))
        harness.step(20)
        harness.spin_until(lambda: bool(clocks) and clocks[-1] == round(harness.node.simulator.time * 1e9),
                           "/clock at the latest tick")
        moved = _pose(harness, "box")
        before_s = harness.node.simulator.time
        assert not np.allclose(moved[0], initial[0])

        response = harness.reset_world()
        assert response.success, response.message
        assert "goes on" in response.message
        assert harness.node.simulator.time == before_s  # time does not go back
        back = _pose(harness, "box")
        assert np.array_equal(back[0], initial[0]) and np.array_equal(back[1], initial[1])
        assert harness.latest_pose("box").header.stamp.sec * 10**9 + harness.latest_pose("box").header.stamp.nanosec \
            == round(before_s * 1e9)
        assert not harness.node.held_wrenches  # the push is gone with the old world

        harness.step(5)
        harness.spin_until(lambda: clocks[-1] == round(harness.node.simulator.time * 1e9), "/clock after reset_world")
        assert harness.node.simulator.time == pytest.approx(before_s + 5 * 0.01, abs=1e-12)
        assert all(a <= b for a, b in zip(clocks, clocks[1:])), "/clock went back across ~/reset_world"
        # From the initial state again: the same motion as the first ticks from t = 0, without the push.
        with SimHarness(paused=True, node_name="fresh", namespace="fresh") as fresh:
            fresh.step(5)
            same = _pose(fresh, "box")
        after = _pose(harness, "box")
        assert np.allclose(after[0], same[0], atol=1e-12) and np.allclose(after[1], same[1], atol=1e-12)


def test_reset_takes_clock_back_to_zero():
    with SimHarness(paused=True) as harness:
        clocks = _with_clock(harness)
        initial = _pose(harness, "box")
        harness.step(10)
        harness.spin_until(lambda: bool(clocks) and clocks[-1] == round(harness.node.simulator.time * 1e9),
                           "/clock at the latest tick")
        assert clocks[-1] > 0
        response = harness.reset()
        assert response.success, response.message
        harness.spin_until(lambda: clocks[-1] == 0, "/clock back at t = 0")
        assert harness.node.simulator.time == 0.0
        back = _pose(harness, "box")
        assert np.array_equal(back[0], initial[0]) and np.array_equal(back[1], initial[1])

