"""The node as a separate process, started through its console script, talked to over DDS.

A separate rclpy participant (this test process) publishes a wrench and receives PoseStamped
and Twist on loopback, in the private ROS_DOMAIN_ID of this test session. The motion is
checked against the core: from the first tick the wrench acted on, the core replays the same
steps and must land on the same pose bitwise (same arithmetic, float64 end to end).
"""

from __future__ import annotations

import subprocess
import time

import numpy as np
import pytest
import rclpy
import yaml
from geometry_msgs.msg import PoseStamped, Twist, WrenchStamped
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_srvs.srv import SetBool

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.testing import node_command, start_process, stop_process

pytestmark = pytest.mark.ros

DT = 0.01  # s: 100 Hz, 1 substep
SCENE = {"bodies": {"box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]},
                            "pose": {"position": [0.0, 0.0, 1.0]},
                            "sites": {"corner": {"position": [0.5, 0.3, 0.0]}}}}}


def stamp_ns(msg: PoseStamped) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def test_node_process_over_dds(tmp_path):
    scene_path = tmp_path / "box.yaml"
    scene_path.write_text(yaml.safe_dump(SCENE))
    log_path = tmp_path / "node.log"
    process = start_process(["-p", f"scene:={scene_path}", "-p", "wrench_timeout:=0.0"], log_path)
    context = Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    peer = Node("wrench_peer", context=context)
    executor.add_node(peer)
    poses: list[PoseStamped] = []
    twists: list[Twist] = []
    try:
        peer.create_subscription(PoseStamped, "/box/pose", poses.append, 100)
        peer.create_subscription(Twist, "/box/twist", twists.append, 100)
        wrench_pub = peer.create_publisher(WrenchStamped, "/box/wrench", 10)
        pause = peer.create_client(SetBool, "/rigid_body_sim/set_paused")

        def spin_until(condition, what, timeout=20.0):
            deadline = time.monotonic() + timeout
            while not condition():
                assert process.poll() is None, f"node exited with {process.returncode}:\n{log_path.read_text()}"
                assert time.monotonic() < deadline, f"timed out waiting for {what}; node log:\n{log_path.read_text()}"
                executor.spin_once(timeout_sec=0.01)

        spin_until(lambda: wrench_pub.get_subscription_count() > 0 and len(poses) > 5, "discovery and first poses")
        msg = WrenchStamped()
        msg.header.frame_id = "box/corner"
        msg.wrench.force.y = 10.0
        wrench_pub.publish(msg)
        spin_until(lambda: len(poses) > 5 and poses[-1].pose.position.y > 0.0, "the pushed box to move")
        first_moved = len(poses) - 1
        spin_until(lambda: len(poses) > first_moved + 30, "30 more ticks")
        spin_until(pause.service_is_ready, "~/set_paused")
        future = pause.call_async(SetBool.Request(data=True))
        spin_until(future.done, "~/set_paused response")
        assert future.result().success
        settle = time.monotonic() + 0.5
        spin_until(lambda: time.monotonic() > settle, "late messages")

        # Ticks are consecutive (nothing lost around the first forced tick).
        ticks = [round(stamp_ns(p) / (DT * 1e9)) for p in poses]
        assert all(b == a + 1 for a, b in zip(ticks, ticks[1:])), ticks
        k_first = ticks[first_moved]
        k_last = ticks[-1]
        assert poses[first_moved - 1].pose.position.y == 0.0

        core = Simulator(load_scene(scene_path), integrator="rk4", dt=DT)
        core.step(k_first - 1)
        for _ in range(k_last - k_first + 1):
            core.apply_wrench("box", force=[0.0, 10.0, 0.0], frame="box/corner")
            core.step()
        expected = core.body_state("box")
        last_pose, last_twist = poses[-1].pose, twists[-1]
        assert poses[-1].header.frame_id == "world"
        got_p = [last_pose.position.x, last_pose.position.y, last_pose.position.z]
        got_q = [last_pose.orientation.x, last_pose.orientation.y, last_pose.orientation.z, last_pose.orientation.w]
        assert np.array_equal(got_p, expected.position_world)
        assert np.array_equal(got_q, expected.orientation_xyzw)
        assert np.array_equal([last_twist.linear.x, last_twist.linear.y, last_twist.linear.z], expected.linear_velocity_world)
        assert np.array_equal([last_twist.angular.x, last_twist.angular.y, last_twist.angular.z],
                              expected.angular_velocity_world)
        # And the physics itself: the corner push turns the box about +z and drives it along +y.
        assert last_twist.angular.z > 0.0 and last_twist.linear.y > 0.0
    finally:
        executor.shutdown()
        peer.destroy_node()
        rclpy.try_shutdown(context=context)
        stop_process(process, timeout=10)
    assert process.returncode == 0, f"node did not shut down cleanly:\n{log_path.read_text()}"
    assert "scene " in log_path.read_text()


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        # every message is checked in-process (test_parameters.py); the exit-2 path of a refused parameter
        # runs in the default run's test_access (a namespace too long), these rows in test-slow:
        pytest.param(["-p", "integrator:=leapfrog"], "integrator must be one of", marks=pytest.mark.slow),
        pytest.param(["-p", "rate_hz:=-1.0"], "rate_hz out of range", marks=pytest.mark.slow),
        pytest.param(["-p", "rate_hz:=fast"], "rate_hz must be a double, got a string ('fast')", marks=pytest.mark.slow),
        (["-p", "scene:=/nonexistent/scene.yaml"], "cannot read scene file"),
    ],
)
def test_bad_start_up_parameters_exit_2_with_the_reason(arguments, message):
    result = subprocess.run(node_command() + ["--ros-args", *arguments], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2, result.stderr
    assert message in result.stderr
    assert "Traceback" not in result.stderr
