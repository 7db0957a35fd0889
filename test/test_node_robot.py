"""The robot-stack surface of the node (issue 16), through its real ROS interface: IMUs on sites.

Every expected value is a closed form worked out by hand for a motion known exactly; the
harness drives the node paused, tick by tick.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import yaml
from rclpy.qos import QoSProfile
from sensor_msgs.msg import Imu

from rigid_body_sim.core.quaternion import quat_to_matrix, quat_wxyz_from_xyzw
from rigid_body_sim.testing import SimHarness

pytestmark = pytest.mark.ros

G = 9.81  # m/s²
TICK_S = 0.01  # the default 100 Hz, 1 substep


def write_scene(tmp_path, bodies: dict, gravity=(0.0, 0.0, -G), name: str = "scene.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump({"gravity": list(gravity), "bodies": bodies}))
    return path


def spinning_box(motion: str = "free", w_z: float = 3.0, imu: Any = None) -> dict:
    imu = {} if imu is None else imu
    return {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}, "motion": motion,
            "pose": {"position": [0.0, 0.0, 5.0], "orientation": [0.0, 0.0, 0.0, 1.0]},
            "twist": {"linear": [0.0, 0.0, 0.0], "angular": [0.0, 0.0, w_z]},
            "sites": {"centre": {"position": [0.0, 0.0, 0.0], "imu": imu},
                      "arm": {"position": [1.0, 0.0, 0.0], "imu": imu}}}


class Collector:
    """Every message received on some topics of the harness's client node, by topic."""

    def __init__(self, harness: SimHarness, msg_type: type, topics: list[str]):
        self.messages: dict[str, list] = {topic: [] for topic in topics}
        self._subs = [harness.client.create_subscription(msg_type, topic, lambda m, t=topic: self.messages[t].append(m),
                                                         QoSProfile(depth=1000)) for topic in topics]

    def wait_matched(self, harness: SimHarness) -> None:
        for sub in self._subs:
            harness.spin_until(lambda s=sub: s.get_publisher_count() > 0, f"a publisher on {sub.topic_name}")


def vec(v) -> np.ndarray:
    return np.array([v.x, v.y, v.z])


def stamp_s(msg) -> float:
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def test_imus_on_a_spinning_pushed_body_in_free_fall_read_the_closed_form(tmp_path) -> None:
    """Spin ω about the principal z axis, a body-fixed force F_B at the COM, gravity: ω stays ω e_z;
    in body axes the centre reads F_B/m (free fall cancels g) and the site 1 m off centre along x
    adds the centripetal −ω² x; both gyroscopes read ω e_z. The orientation is the body's pose."""
    w_z, force_B, mass = 3.0, np.array([1.0, -2.0, 0.5]), 2.0
    scene = write_scene(tmp_path, {"b": spinning_box(w_z=w_z)})
    with SimHarness(scene, {"integrator": "rk4", "wrench_timeout": 0.0}) as h:
        imus = Collector(h, Imu, ["b/centre/imu", "b/arm/imu"])
        imus.wait_matched(h)
        h.publish_wrench("b", force=force_B, frame_id="b")
        n = 37
        h.step(n)
        h.spin_until(lambda: all(len(m) >= n for m in imus.messages.values()), "the IMU messages")
        pose = h.latest_pose("b")
        for topic, extra in (("b/centre/imu", np.zeros(3)), ("b/arm/imu", np.array([-w_z**2, 0.0, 0.0]))):
            msgs = imus.messages[topic]
            assert len(msgs) == n
            last = msgs[-1]
            assert last.header.frame_id == topic[:-4]
            assert stamp_s(last) == pytest.approx(n * TICK_S, abs=1e-9)
            assert last.header.stamp == pose.header.stamp
            for msg in msgs:
                np.testing.assert_allclose(vec(msg.linear_acceleration), force_B / mass + extra, rtol=0, atol=1e-9)
                np.testing.assert_allclose(vec(msg.angular_velocity), [0.0, 0.0, w_z], rtol=0, atol=1e-9)
            o = last.orientation
            np.testing.assert_allclose([o.x, o.y, o.z, o.w], [pose.pose.orientation.x, pose.pose.orientation.y,
                                                              pose.pose.orientation.z, pose.pose.orientation.w],
                                       rtol=0, atol=1e-12)
            # the closed form of the orientation: a turn of ω t about z
            angle = w_z * n * TICK_S
            np.testing.assert_allclose(abs(np.dot([o.x, o.y, o.z, o.w], [0, 0, np.sin(angle / 2), np.cos(angle / 2)])),
                                       1.0, rtol=0, atol=1e-9)
            assert list(last.orientation_covariance) == [0.0] * 9  # ideal: exact
            assert list(last.linear_acceleration_covariance) == [0.0] * 9


@pytest.mark.parametrize("motion", ["static", "kinematic"])
def test_imu_at_rest_on_a_body_that_cannot_fall_reads_g_upward(tmp_path, motion: str) -> None:
    """A body tilted 90° about x, at rest, that gravity cannot move: the accelerometer feels the
    support, +g along world z, which is the body's +y axis; the gyroscope reads zero."""
    body = spinning_box(motion=motion, w_z=0.0)
    s = float(np.sqrt(0.5))
    body["pose"]["orientation"] = [s, 0.0, 0.0, s]  # 90° about x: body y → world z
    scene = write_scene(tmp_path, {"b": body})
    with SimHarness(scene) as h:
        imus = Collector(h, Imu, ["b/centre/imu", "b/arm/imu"])
        imus.wait_matched(h)
        h.publish_wrench("b", force=(5.0, 0.0, 0.0), frame_id="b")  # deaf to wrenches
        h.step(5)
        h.spin_until(lambda: all(len(m) >= 5 for m in imus.messages.values()), "the IMU messages")
        for msgs in imus.messages.values():
            np.testing.assert_allclose(vec(msgs[-1].linear_acceleration), [0.0, G, 0.0], rtol=0, atol=1e-9)
            np.testing.assert_allclose(vec(msgs[-1].angular_velocity), 0.0, rtol=0, atol=1e-12)
            R = quat_to_matrix(quat_wxyz_from_xyzw(np.array([s, 0.0, 0.0, s])))
            np.testing.assert_allclose(R @ vec(msgs[-1].linear_acceleration), [0.0, 0.0, G], rtol=0, atol=1e-9)


def test_noisy_imu_rate_and_covariances_through_the_node(tmp_path) -> None:
    """A 25 Hz IMU on 100 Hz ticks publishes every 4th tick; its covariances are σ_n²·rate."""
    imu = {"rate": 25.0, "seed": 4, "accelerometer": {"noise_density": 0.01}, "gyroscope": {"noise_density": 0.002}}
    scene = write_scene(tmp_path, {"b": spinning_box(imu=imu)})
    with SimHarness(scene) as h:
        imus = Collector(h, Imu, ["b/centre/imu"])
        imus.wait_matched(h)
        h.step(12)
        h.spin_until(lambda: len(imus.messages["b/centre/imu"]) >= 3, "the IMU messages")
        h.spin_for(0.2)
        msgs = imus.messages["b/centre/imu"]
        assert [round(stamp_s(m) / TICK_S) for m in msgs] == [1, 5, 9]
        assert msgs[0].linear_acceleration_covariance[0] == pytest.approx(0.01**2 * 25.0, rel=1e-12)
        assert msgs[0].angular_velocity_covariance[4] == pytest.approx(0.002**2 * 25.0, rel=1e-12)
