"""The robot-stack surface of the node, through its real ROS interface: IMUs on sites.

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

from helpers import assert_white_noise, seeded_noise_readings
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


def test_imu_off_centre_reads_the_tangential_term_of_a_torque(tmp_path) -> None:
    """From rest, F = (0, 10, 0) N fixed in the box at its corner (0.5, 0.3, 0): τ = 5 N·m about the
    principal z axis, so ω = α t e_z with α = 5 / I_z; in free fall the centre reads F/m and the
    site 1 m along x reads F/m + α e_z × r − (α t)² r (body axes), at every tick."""
    body = spinning_box(w_z=0.0)
    body["sites"]["corner"] = {"position": [0.5, 0.3, 0.0]}
    scene = write_scene(tmp_path, {"b": body})
    with SimHarness(scene, {"integrator": "rk4", "wrench_timeout": 0.0}) as h:
        imus = Collector(h, Imu, ["b/centre/imu", "b/arm/imu"])
        imus.wait_matched(h)
        h.publish_wrench("b", force=(0.0, 10.0, 0.0), frame_id="b/corner")
        n = 20
        assert h.step_ticks(n).successful
        h.spin_until(lambda: all(len(m) >= n for m in imus.messages.values()), "the IMU messages")
        alpha = 5.0 / (2.0 * (1.0 + 0.36) / 12.0)
        for k in range(n):
            t = (k + 1) * TICK_S
            centre, arm = imus.messages["b/centre/imu"][k], imus.messages["b/arm/imu"][k]
            assert stamp_s(arm) == pytest.approx(t, abs=1e-9)
            np.testing.assert_allclose(vec(centre.linear_acceleration), [0.0, 5.0, 0.0], rtol=0, atol=1e-9)
            np.testing.assert_allclose(vec(arm.linear_acceleration), [-(alpha * t) ** 2, 5.0 + alpha, 0.0],
                                       rtol=0, atol=1e-9)
            np.testing.assert_allclose(vec(arm.angular_velocity), [0.0, 0.0, alpha * t], rtol=0, atol=1e-9)


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


def test_node_records_its_imu_messages(tmp_path) -> None:
    """record_path: /b/centre/imu and /b/arm/imu in the MCAP file, one per tick, as published."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    w_z = 3.0
    scene = write_scene(tmp_path, {"b": spinning_box(w_z=w_z)})
    record = tmp_path / "run.mcap"
    with SimHarness(scene, {"record_path": str(record)}) as h:
        h.step(4)
    with open(record, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        msgs = [(c.topic, m) for _, c, _, m in reader.iter_decoded_messages(topics=["/b/centre/imu", "/b/arm/imu"])]
    assert sorted(t for t, _ in msgs) == ["/b/arm/imu"] * 4 + ["/b/centre/imu"] * 4
    for topic, m in msgs:
        expected = [-w_z**2, 0.0, 0.0] if topic == "/b/arm/imu" else [0.0, 0.0, 0.0]
        assert m.header.frame_id == topic[1:-4]
        np.testing.assert_allclose(vec(m.linear_acceleration), expected, rtol=0, atol=1e-9)
        np.testing.assert_allclose(vec(m.angular_velocity), [0.0, 0.0, w_z], rtol=0, atol=1e-9)


def _noisy_imu_at_the_com(tmp_path, ticks: int) -> tuple[dict, dict, np.ndarray, np.ndarray, list]:
    """A noisy IMU at the COM of a body in free fall (ideal reading 0), recorded by the node for ``ticks``
    ticks: (accelerometer, gyroscope) parameters, the recorded readings (ticks, 3) each, the messages."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    accel = {"noise_density": 0.02, "bias": [0.3, -0.2, 0.5]}
    gyro = {"noise_density": 0.003, "bias": [0.05, 0.04, -0.06]}
    body = {"mass": 1.0, "inertia": {"sphere": 0.1},
            "sites": {"s": {"position": [0.0, 0.0, 0.0], "imu": {"seed": 3, "accelerometer": accel, "gyroscope": gyro}}}}
    scene = write_scene(tmp_path, {"b": body})
    record = tmp_path / "noise.mcap"
    with SimHarness(scene, {"record_path": str(record)}, timeout=60.0) as h:  # 10⁴ ticks: ~10 s
        result = h.step_ticks(ticks)
        assert result.successful, result.reason
    with open(record, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        msgs = [m for _, _, _, m in reader.iter_decoded_messages(topics=["/b/s/imu"])]
    assert len(msgs) == ticks
    return (accel, gyro, np.array([vec(m.linear_acceleration) for m in msgs]),
            np.array([vec(m.angular_velocity) for m in msgs]), msgs)


def test_node_imu_samples_are_the_site_s_seeded_noise_stream(tmp_path) -> None:
    """The node's samples (recorded as published) of a noisy IMU at the COM of a body in free fall are the
    ideal reading 0 plus, sample after sample, the noise of that site's seeded stream at Δt = the tick
    (core.imu.ImuNoise, whose statistics test_imu.py measures); the covariances are σ_n²/Δt."""
    ticks = 50
    accel, gyro, f_S, w_S, msgs = _noisy_imu_at_the_com(tmp_path, ticks)
    expected_f, expected_w = seeded_noise_readings(3, "b/s", accel, gyro, TICK_S, ticks)
    np.testing.assert_allclose(f_S, expected_f, rtol=0, atol=1e-12)
    np.testing.assert_allclose(w_S, expected_w, rtol=0, atol=1e-12)
    for cov, channel in ((msgs[0].linear_acceleration_covariance, accel), (msgs[0].angular_velocity_covariance, gyro)):
        sigma = channel["noise_density"] / np.sqrt(TICK_S)
        np.testing.assert_allclose(np.array(cov).reshape(3, 3), sigma**2 * np.eye(3), rtol=1e-12)


@pytest.mark.slow
def test_node_imu_noise_statistics(tmp_path) -> None:
    """The node's own samples of that IMU over 10⁴ ticks: per axis, mean = bias and standard deviation =
    σ_n/√Δt (Δt = the tick), each within 4.5 of its standard errors (helpers.assert_white_noise)."""
    accel, gyro, f_S, w_S, _msgs = _noisy_imu_at_the_com(tmp_path, 10_000)
    for got, channel in ((f_S, accel), (w_S, gyro)):
        assert_white_noise(got, channel["bias"], channel["noise_density"] / np.sqrt(TICK_S))


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


# ---------------------------------------------------------------------------------------- set_state

BALL = {"mass": 2.0, "inertia": {"sphere": 0.5}, "pose": {"position": [0.0, 0.0, 0.0]}}


def odometry(frame_id: str, child: str, position, orientation_xyzw, linear, angular):
    from nav_msgs.msg import Odometry

    msg = Odometry()
    msg.header.frame_id, msg.child_frame_id = frame_id, child
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    p.x, p.y, p.z = (float(v) for v in position)
    o.x, o.y, o.z, o.w = (float(v) for v in orientation_xyzw)
    v, w = msg.twist.twist.linear, msg.twist.twist.angular
    v.x, v.y, v.z = (float(x) for x in linear)
    w.x, w.y, w.z = (float(x) for x in angular)
    return msg


def set_state_publisher(h: SimHarness, body: str):
    from nav_msgs.msg import Odometry

    pub = h.client.create_publisher(Odometry, f"{body}/set_state", QoSProfile(depth=10))
    h.spin_until(lambda: pub.get_subscription_count() > 0, f"the node's {body}/set_state subscription")
    return pub


def send(h: SimHarness, pub, msg) -> None:
    seen = h.messages_seen()
    pub.publish(msg)
    h.spin_until(lambda: h.messages_seen() > seen, "the node to take the set_state message")


def quat_exp_world(w_W: np.ndarray, t: float) -> np.ndarray:
    """Rotation by |ω| t about ω (x, y, z, w)."""
    angle = np.linalg.norm(w_W) * t
    axis = w_W / np.linalg.norm(w_W)
    return np.concatenate((np.sin(angle / 2) * axis, [np.cos(angle / 2)]))


def quat_mul_xyzw(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


@pytest.mark.parametrize("twist_axes", ["body", "world"])
def test_set_state_then_one_tick_matches_the_closed_form(tmp_path, twist_axes: str) -> None:
    """A sphere (ω stays constant) under gravity, set to (p0, q0, v, ω) while paused, then one tick of
    h: p = p0 + v_W h + g h²/2, v = v_W + g h, q = Exp(ω_W h) ⊗ q0 (RK4: exact for the polynomial
    motion; the rotation's truncation error (|ω| h)⁵/5! ≈ 1e-12 is far inside 1e-9). In body axes
    the twist is turned by q0 first: v_W = R(q0) v_B, ω_W = R(q0) ω_B."""
    scene = write_scene(tmp_path, {"ball": BALL, "box": spinning_box()})
    p0 = np.array([1.0, 2.0, 3.0])
    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    q0 = np.concatenate((np.sin(0.4) * axis, [np.cos(0.4)]))
    v_in, w_in = np.array([1.0, -2.0, 0.5]), np.array([0.3, -0.7, 1.1])
    R0 = quat_to_matrix(quat_wxyz_from_xyzw(q0))
    v_W, w_W = (R0 @ v_in, R0 @ w_in) if twist_axes == "body" else (v_in, w_in)
    child = "ball" if twist_axes == "body" else "world"
    with SimHarness(scene, {"integrator": "rk4"}) as h:
        pub = set_state_publisher(h, "ball")
        send(h, pub, odometry("world", child, p0, q0, v_in, w_in))
        # paused: the tick thread applies it and publishes the new state at the same sim time
        h.spin_until(lambda: np.allclose([h.latest_pose("ball").pose.position.x], [p0[0]], rtol=0, atol=1e-12),
                     "the set state on ball/pose")
        with h.node.locked_simulator() as sim:
            assert sim.time == 0.0
            np.testing.assert_allclose(sim.body_state("ball").linear_velocity_world, v_W, rtol=0, atol=1e-15)
        h.step(1)
        g = np.array([0.0, 0.0, -G])
        pose, twist = h.latest_pose("ball").pose, h.latest_twist("ball")
        np.testing.assert_allclose(vec(pose.position), p0 + v_W * TICK_S + 0.5 * g * TICK_S**2, rtol=0, atol=1e-9)
        np.testing.assert_allclose(vec(twist.linear), v_W + g * TICK_S, rtol=0, atol=1e-9)
        np.testing.assert_allclose(vec(twist.angular), w_W, rtol=0, atol=1e-9)
        q = np.array([pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w])
        expected = quat_mul_xyzw(quat_exp_world(w_W, TICK_S), q0)
        np.testing.assert_allclose(q * np.sign(q @ expected), expected, rtol=0, atol=1e-9)
        assert stamp_s(h.latest_pose("ball")) == pytest.approx(TICK_S, abs=1e-9)


def test_set_state_while_running_acts_from_the_start_of_a_tick(tmp_path) -> None:
    """Running, no gravity, a ball at rest set to p0 with v: the first pose published afterwards is
    already one tick on (p0 + v h: applied at the start of the tick, whole), and every later one
    is p0 + v (t − t0) with t0 = that pose's stamp − h; the other body never notices."""
    from geometry_msgs.msg import PoseStamped

    scene = write_scene(tmp_path, {"ball": BALL, "box": spinning_box(w_z=0.0)}, gravity=(0.0, 0.0, 0.0))
    p0, v = np.array([1.0, 2.0, 3.0]), np.array([0.5, 0.0, -0.25])
    with SimHarness(scene, {"integrator": "rk4"}, paused=False) as h:
        poses = Collector(h, PoseStamped, ["ball/pose"])
        poses.wait_matched(h)
        send(h, set_state_publisher(h, "ball"), odometry("world", "world", p0, [0, 0, 0, 1], v, [0, 0, 0]))
        h.spin_until(lambda: sum(m.pose.position.x > 0.5 for m in poses.messages["ball/pose"]) > 5, "the set state")
        moved = [m for m in poses.messages["ball/pose"] if m.pose.position.x > 0.5]
        t0 = stamp_s(moved[0]) - TICK_S
        for m in moved:
            np.testing.assert_allclose(vec(m.pose.position), p0 + v * (stamp_s(m) - t0), rtol=0, atol=1e-9)
        np.testing.assert_array_equal(vec(h.latest_pose("box").pose.position), [0.0, 0.0, 5.0])


def test_rejected_set_state_changes_nothing_and_is_counted(tmp_path) -> None:
    from diagnostic_msgs.msg import DiagnosticArray  # noqa: F401  (the node's report type)

    from rigid_body_sim.ros.diagnostics import status_values

    scene = write_scene(tmp_path, {"ball": BALL, "box": spinning_box()})
    good_q = [0.0, 0.0, 0.0, 1.0]
    bad = [
        ("non_finite", odometry("world", "ball", [float("nan"), 0, 0], good_q, [0, 0, 0], [0, 0, 0])),
        ("non_finite", odometry("world", "ball", [0, 0, 0], good_q, [0, float("inf"), 0], [0, 0, 0])),
        ("non_unit_quaternion", odometry("world", "ball", [0, 0, 0], [0.0, 0.0, 0.0, 2.0], [0, 0, 0], [0, 0, 0])),
        ("non_unit_quaternion", odometry("world", "ball", [0, 0, 0], [0.0, 0.0, 0.0, 0.0], [0, 0, 0], [0, 0, 0])),
        ("unknown_frame", odometry("map", "ball", [0, 0, 0], good_q, [0, 0, 0], [0, 0, 0])),
        ("unknown_frame", odometry("world", "base_link", [0, 0, 0], good_q, [0, 0, 0], [0, 0, 0])),
        ("unknown_frame", odometry("world", "box", [0, 0, 0], good_q, [0, 0, 0], [0, 0, 0])),
        ("too_large", odometry("world", "ball", [1e13, 0, 0], good_q, [0, 0, 0], [0, 0, 0])),
    ]
    with SimHarness(scene, {"integrator": "rk4"}) as h:
        h.step(2)
        pub = set_state_publisher(h, "ball")
        with h.node.locked_simulator() as sim:
            before = [a.copy() for a in (sim.positions_world(), sim.orientations_xyzw(),
                                         sim.linear_velocities_world(), sim.angular_velocities_world())]
            time_before = sim.time
        rejected_before = h.node.rejected
        h.node.diagnostics()  # opens a new window
        for _, msg in bad:
            send(h, pub, msg)
        h.spin_for(0.1)  # several paused ticks: nothing pending may be applied
        with h.node.locked_simulator() as sim:
            after = [sim.positions_world(), sim.orientations_xyzw(), sim.linear_velocities_world(),
                     sim.angular_velocities_world()]
            assert sim.time == time_before
        for a, b in zip(before, after):
            np.testing.assert_array_equal(a, b)
        counts = h.node.rejected
        for reason in ("non_finite", "non_unit_quaternion", "unknown_frame", "too_large"):
            expected = sum(1 for r, _ in bad if r == reason)
            assert counts[reason] - rejected_before.get(reason, 0) == expected, reason
        report = {s.name: status_values(s) for s in h.node.diagnostics().status}
        inputs = report["rigid_body_sim: input"]
        assert inputs["rejected non_unit_quaternion (window)"] == "2"
        assert inputs["rejected unknown_frame (window)"] == "3"


def test_set_state_is_projected_onto_the_bodys_motion(tmp_path) -> None:
    """A translation-only body given a spin keeps none; a static body stays where it is."""
    scene = write_scene(tmp_path, {"ball": {**BALL, "motion": "translation_only"},
                                   "post": {**BALL, "motion": "static"}}, gravity=(0.0, 0.0, 0.0))
    with SimHarness(scene, {"integrator": "rk4"}) as h:
        for body in ("ball", "post"):
            send(h, set_state_publisher(h, body),
                 odometry("world", "world", [0.5, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, 2.0]))
        h.spin_until(lambda: h.latest_pose("ball").pose.position.x == 0.5, "the set state on ball/pose")
        h.step(1)
        np.testing.assert_allclose(vec(h.latest_twist("ball").angular), 0.0, atol=0)
        np.testing.assert_allclose(vec(h.latest_pose("ball").pose.position), [0.5 + TICK_S, 0.0, 0.0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(vec(h.latest_twist("post").linear), 0.0, atol=0)
        np.testing.assert_allclose(vec(h.latest_twist("post").angular), 0.0, atol=0)


# ---------------------------------------------------------------------------------------- step N, spawn, delete

def clock_ns(msg) -> int:
    return msg.clock.sec * 1_000_000_000 + msg.clock.nanosec


@pytest.mark.parametrize("substeps", [1, 3])
def test_step_ticks_advances_exactly_n_ticks_and_is_refused_while_running(tmp_path, substeps: int) -> None:
    from rosgraph_msgs.msg import Clock as ClockMsg

    scene = write_scene(tmp_path, {"ball": BALL})
    with SimHarness(scene, {"substeps": substeps}) as h:
        clocks = Collector(h, ClockMsg, ["/clock"])
        clocks.wait_matched(h)
        result = h.step_ticks(7)
        assert result.successful, result.reason
        assert "stepped 7 ticks to t = 0.070000000 s" in result.reason
        with h.node.locked_simulator() as sim:
            assert sim.step_count == 7 * substeps
            assert sim.time == pytest.approx(7 * TICK_S, abs=1e-12)
        h.spin_until(lambda: len(clocks.messages["/clock"]) >= 7, "seven /clock messages")
        h.spin_for(0.1)
        ticks = [clock_ns(m) for m in clocks.messages["/clock"] if clock_ns(m) > 0]
        assert ticks == [k * 10_000_000 for k in range(1, 8)]
        assert stamp_s(h.latest_pose("ball")) == pytest.approx(0.07, abs=1e-9)
        for bad in (0, -3, 2_000_000):
            refused = h.step_ticks(bad)
            assert not refused.successful and "expected an integer from 1 to" in refused.reason
        assert h.set_paused(False).success
        refused = h.step_ticks(3)
        assert not refused.successful and "running" in refused.reason and "pause it first" in refused.reason


SPAWNED = """
mass: 1.5
inertia: {box: [0.2, 0.3, 0.4]}
pose: {position: [4.0, 0.0, 1.0]}
twist: {linear: [0.0, 1.0, 0.0]}
sites:
  nose: {position: [0.1, 0.0, 0.0], imu: {}}
"""


def test_spawn_and_delete_while_running_keep_clock_increasing_and_topics_consistent(tmp_path) -> None:
    """While running: spawn a body (its pose, twist and IMU topics appear, it starts at its
    definition's state at the current sim time), delete another (its topics go); /clock never
    steps back, every other body keeps its motion, and the node's bodies are what the topics say."""
    from rosgraph_msgs.msg import Clock as ClockMsg

    from geometry_msgs.msg import PoseArray

    scene = write_scene(tmp_path, {"ball": BALL, "box": spinning_box()}, gravity=(0.0, 0.0, 0.0))
    with SimHarness(scene, {"integrator": "rk4"}, paused=False) as h:
        clocks = Collector(h, ClockMsg, ["/clock"])
        batches = Collector(h, PoseArray, ["poses"])
        clocks.wait_matched(h)
        batches.wait_matched(h)
        h.spin_until(lambda: len(clocks.messages["/clock"]) > 5, "/clock while running")
        result = h.spawn(crate=SPAWNED)
        assert result.successful, result.reason
        spawn_time = float(result.reason.rsplit("t = ", 1)[1].split()[0])
        assert spawn_time > 0.0
        imu = Collector(h, Imu, ["crate/nose/imu"])
        h.watch_body("crate")
        imu.wait_matched(h)
        h.spin_until(lambda: len(imu.messages["crate/nose/imu"]) > 3, "the spawned body's IMU")
        # the spawned body moves from its definition's pose at the spawn time: y = v (t - t_spawn)
        pose = h.latest_pose("crate")
        np.testing.assert_allclose(vec(pose.pose.position), [4.0, 1.0 * (stamp_s(pose) - spawn_time), 1.0],
                                   rtol=0, atol=1e-9)
        assert h.node.simulator.body_names == ("ball", "box", "crate")
        # the batch follows at once: three poses in body_names' order, the crate's the same as its own topic's
        assert h.get_parameter("body_names") == ["ball", "box", "crate"]
        h.spin_until(lambda: len(batches.messages["poses"][-1].poses) == 3, "a poses batch with the crate")
        pose = h.latest_pose("crate")
        h.spin_until(lambda: any(stamp_s(b) == stamp_s(pose) for b in batches.messages["poses"]),
                     "the batch of the crate's latest pose")
        batch = next(b for b in batches.messages["poses"] if stamp_s(b) == stamp_s(pose))
        assert len(batch.poses) == 3
        np.testing.assert_array_equal(vec(batch.poses[2].position), vec(pose.pose.position))
        result = h.delete("box")
        assert result.successful, result.reason
        with h.node.locked_simulator() as sim:
            assert sim.body_names == ("ball", "crate")
        assert set(h.node.publisher_subscription_counts()) == {"ball", "crate"}
        h.spin_until(lambda: h.client.count_publishers("box/pose") == 0, "box/pose to go")
        assert h.client.count_subscribers("box/wrench") == 0
        n = len(clocks.messages["/clock"])
        h.spin_until(lambda: len(clocks.messages["/clock"]) > n + 5, "/clock after the delete")
        ticks = [clock_ns(m) for m in clocks.messages["/clock"]]
        assert all(b > a for a, b in zip(ticks, ticks[1:])), "/clock stepped back or stood still"
        assert h.get_parameter("body_names") == ["ball", "crate"]
        h.spin_until(lambda: len(batches.messages["poses"][-1].poses) == 2, "a poses batch without the box")
        stamps = [stamp_s(b) for b in batches.messages["poses"]]
        # never back; a spawn or delete republishes the current state with the new body set at its
        # tick's stamp (transient local keeps the current state for late joiners), so one stamp may repeat
        assert all(b >= a for a, b in zip(stamps, stamps[1:])), "the batches' stamps stepped back"
        sizes = [len(b.poses) for b in batches.messages["poses"]]
        runs = [n for i, n in enumerate(sizes) if i == 0 or n != sizes[i - 1]]
        assert runs == [2, 3, 2], runs  # two bodies, three from the spawn on, two from the delete on
        # the box's spin and the ball's rest were never disturbed: the spawned body's pose still agrees
        pose = h.latest_pose("crate")
        np.testing.assert_allclose(pose.pose.position.y, stamp_s(pose) - spawn_time, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(vec(h.latest_pose("ball").pose.position), 0.0)


@pytest.mark.parametrize("request_kind, payload, expected", [
    ("spawn", {"crate": "mass: -1\ninertia: {sphere: 0.1}"}, "bodies.crate.mass: expected a number > 0"),
    ("spawn", {"crate": "mass: 1\n"}, "required key 'inertia'"),
    ("spawn", {"crate": "[1, 2]"}, "bodies.crate: expected a mapping"),
    ("spawn", {"crate": "mass: [1"}, "bodies.crate: expected a body definition in YAML"),
    ("spawn", {"ball": "mass: 1\ninertia: {sphere: 0.1}"}, "a body of that name exists"),
    ("spawn", {"9lives": "mass: 1\ninertia: {sphere: 0.1}"}, "9lives"),
    ("spawn", {"world": "mass: 1\ninertia: {sphere: 0.1}"}, "reserved"),
    ("spawn", {"crate": "#" * (8 * 1024 * 1024 + 1)}, "expected a definition of at most"),
    ("spawn", {"crate": "mass: 1\ninertia: {sphere: 0.1}\ncolour: red"}, "bodies.crate.colour"),
    ("delete", ["ghost"], "cannot delete ['ghost']: no such body; bodies are ['ball', 'box']"),
    ("delete", ["ball", "box"], "would leave no body"),
])
def test_bad_spawn_or_delete_names_the_problem_and_changes_nothing(tmp_path, request_kind, payload, expected) -> None:
    scene = write_scene(tmp_path, {"ball": BALL, "box": spinning_box()})
    with SimHarness(scene) as h:
        h.step(3)
        with h.node.locked_simulator() as sim:
            before = (sim.body_names, sim.time, sim.positions_world(), sim.angular_velocities_world())
        result = h.spawn(**payload) if request_kind == "spawn" else h.delete(*payload)
        assert not result.successful
        assert expected in result.reason
        with h.node.locked_simulator() as sim:
            assert sim.body_names == before[0] and sim.time == before[1]
            np.testing.assert_array_equal(sim.positions_world(), before[2])
            np.testing.assert_array_equal(sim.angular_velocities_world(), before[3])
        h.step(1)  # still steps


def test_a_spawn_into_another_body_is_refused_with_its_name_and_the_depth(tmp_path) -> None:
    """A ball (r 0.5) falling above a ground; a pea (r 0.1) spawned 0.55 m beside the ball's centre
    where it is now overlaps it by 0.5 + 0.1 − 0.55 = 0.05 m: refused, nothing changes."""
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump({"gravity": [0.0, 0.0, -G], "ground": [{"normal": [0, 0, 1], "offset": -10.0}],
                                    "bodies": {"ball": BALL}}))
    with SimHarness(path) as h:
        h.step(3)
        with h.node.locked_simulator() as sim:
            before = (sim.body_names, sim.time, sim.positions_world())
        pea = yaml.safe_dump({"mass": 0.1, "inertia": {"sphere": 0.1},
                              "pose": {"position": (before[2][0] + [0.55, 0.0, 0.0]).tolist()}})
        result = h.spawn(pea=pea)
        assert not result.successful
        assert "bodies.pea: its collision shape would overlap ball's by " in result.reason
        assert float(result.reason.split("overlap ball's by ")[1].split(" m")[0]) == pytest.approx(0.05, abs=1e-12)
        with h.node.locked_simulator() as sim:
            assert sim.body_names == before[0] and sim.time == before[1]
            np.testing.assert_array_equal(sim.positions_world(), before[2])


# ---------------------------------------------------------------------------------------- markers

def test_marker_array_shows_shapes_sites_and_held_wrenches(tmp_path) -> None:
    """Shapes from the inertia declarations (box edges, sphere and cylinder diameters, the
    equivalent ellipsoid of principal moments: a² = 5 (I_b + I_c − I_a) / (2 m)), sites at
    p + R r, an arrow from a site along the held force (scaled by marker_force_scale), all in
    world_frame at the tick's sim time; a deleted body disappears (DELETEALL first)."""
    from visualization_msgs.msg import Marker, MarkerArray

    q45 = [0.0, 0.0, float(np.sin(np.pi / 8)), float(np.cos(np.pi / 8))]  # 45° about z
    bodies = {
        "crate": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}, "pose": {"position": [1.0, 2.0, 3.0],
                                                                            "orientation": q45},
                  "sites": {"corner": {"position": [0.5, 0.3, 0.0]}}},
        "ball": {"mass": 1.0, "inertia": {"sphere": 0.25}, "pose": {"position": [-1.0, 0.0, 0.0]}},
        "can": {"mass": 1.0, "inertia": {"cylinder": [0.1, 0.5]}, "pose": {"position": [0.0, -1.0, 0.0]}},
        "rock": {"mass": 5.0, "inertia": {"principal": [1.0, 2.0, 2.5]}, "pose": {"position": [0.0, 0.0, -1.0]}},
    }
    scene = write_scene(tmp_path, bodies, gravity=(0.0, 0.0, 0.0))
    scale = 0.1
    with SimHarness(scene, {"marker_rate_hz": 1000.0, "marker_force_scale": scale, "wrench_timeout": 0.0}) as h:
        arrays = Collector(h, MarkerArray, ["markers"])
        arrays.wait_matched(h)
        h.publish_wrench("crate", force=(0.0, 10.0, 0.0), frame_id="crate/corner")
        h.step(1)
        h.spin_until(lambda: len(arrays.messages["markers"]) >= 1, "a MarkerArray")
        array = arrays.messages["markers"][-1]
        assert array.markers[0].action == Marker.DELETEALL
        by_key = {(m.ns, m.id): m for m in array.markers[1:]}
        assert all(m.header.frame_id == "world" and stamp_s(m) == pytest.approx(TICK_S, abs=1e-9)
                   for m in array.markers[1:])
        expected = {"crate": (Marker.CUBE, [1.0, 0.6, 0.4]), "ball": (Marker.SPHERE, [0.5] * 3),
                    "can": (Marker.CYLINDER, [0.2, 0.2, 0.5]),
                    "rock": (Marker.SPHERE, [2.0 * np.sqrt(5.0 * (b + c - a) / (2.0 * 5.0))
                                             for a, b, c in ((1.0, 2.0, 2.5), (2.0, 2.5, 1.0), (2.5, 1.0, 2.0))])}
        for body, (kind, dims) in expected.items():
            m = by_key[(body, 0)]
            assert m.type == kind and m.action == Marker.ADD
            np.testing.assert_allclose([m.scale.x, m.scale.y, m.scale.z], dims, rtol=1e-12)
            pose = h.latest_pose(body).pose
            np.testing.assert_array_equal(vec(m.pose.position), vec(pose.position))
        # the shape turns with the body: its orientation is the published pose's
        crate = h.latest_pose("crate").pose
        q = [crate.orientation.x, crate.orientation.y, crate.orientation.z, crate.orientation.w]
        o = by_key[("crate", 0)].pose.orientation
        np.testing.assert_allclose([o.x, o.y, o.z, o.w], q, rtol=0, atol=1e-15)
        R = quat_to_matrix(quat_wxyz_from_xyzw(np.array(q)))
        corner_W = vec(crate.position) + R @ np.array([0.5, 0.3, 0.0])
        np.testing.assert_allclose(vec(by_key[("crate", 1)].pose.position), corner_W, rtol=0, atol=1e-12)
        assert by_key[("crate", 1)].type == Marker.SPHERE
        arrow = by_key[("crate/wrench", 0)]
        assert arrow.type == Marker.ARROW
        np.testing.assert_allclose(vec(arrow.points[0]), corner_W, rtol=0, atol=1e-12)
        np.testing.assert_allclose(vec(arrow.points[1]) - vec(arrow.points[0]), scale * (R @ [0.0, 10.0, 0.0]),
                                   rtol=0, atol=1e-12)
        assert len(array.markers) == 1 + 4 + 1 + 1  # DELETEALL, 4 shapes, 1 site, 1 arrow
        assert h.delete("ball").successful
        n = len(arrays.messages["markers"])
        h.step(1)
        h.spin_until(lambda: len(arrays.messages["markers"]) > n, "a MarkerArray after the delete")
        assert "ball" not in {m.ns for m in arrays.messages["markers"][-1].markers}
