"""Batched state over ROS: ``poses`` and ``velocities`` against the simulator, the
``body_names`` parameter, ``per_body_topics``, TwistStamped, QoS overrides and late joiners.

The node runs as a separate process (its console script) on this session's private
ROS_DOMAIN_ID; this process is an ordinary rclpy peer over Fast DDS. The node is paused, so
the state it publishes is the scene's initial state (the core's own read-outs give the
expected values: same arrays, bitwise) or the state after ~/step ticks, replayed by the core
with the same steps (same arithmetic, bitwise).
"""

from __future__ import annotations

import json

import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
import yaml
from geometry_msgs.msg import PoseArray, PoseStamped, TwistStamped
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import PointCloud2
from std_srvs.srv import Trigger

from helpers import free_bodies_scene
from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.ros.batch import VELOCITY_FIELDS, VELOCITY_POINT_STEP
from rigid_body_sim.testing import start_process, stop_process

pytestmark = pytest.mark.ros

N_BODIES = 7


def cloud_points(msg: PointCloud2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(v (N,3), w (N,3), stopped (N,) bool) from ``velocities``, reading the fields by name."""
    offsets = {f.name: (f.offset, f.datatype) for f in msg.fields}
    raw = np.frombuffer(bytes(msg.data), dtype=np.uint8).reshape(msg.width, msg.point_step)

    def column(name: str) -> np.ndarray:
        offset, datatype = offsets[name]
        if datatype == 8:
            return raw[:, offset:offset + 8].copy().view("<f8")[:, 0]
        return raw[:, offset]

    v = np.stack([column(c) for c in ("vx", "vy", "vz")], axis=1)
    w = np.stack([column(c) for c in ("wx", "wy", "wz")], axis=1)
    return v, w, column("stopped").astype(bool)


def pose_rows(msg: PoseArray) -> np.ndarray:
    return np.array([[p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y,
                      p.orientation.z, p.orientation.w] for p in msg.poses])


def stamp_ns(header) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


class Peer:
    """An rclpy participant in this process: subscriptions, service and parameter clients."""

    def __init__(self, name: str = "batch_peer"):
        self.context = Context()
        rclpy.init(context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.node = Node(name, context=self.context)
        self.executor.add_node(self.node)

    def spin_until(self, condition, what: str, timeout: float = 20.0) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out waiting for {what}")
            self.executor.spin_once(timeout_sec=0.05)

    def call(self, srv_type, name: str, request, timeout: float = 20.0):
        client = self.node.create_client(srv_type, name)
        self.spin_until(client.service_is_ready, f"service {name}", timeout)
        future = client.call_async(request)
        self.spin_until(future.done, f"response of {name}", timeout)
        return future.result()

    def get_parameter(self, name: str):
        response = self.call(GetParameters, "/rigid_body_sim/get_parameters", GetParameters.Request(names=[name]))
        return parameter_value_to_python(response.values[0])

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()


@pytest.fixture
def scene_file(tmp_path) -> Path:
    path = tmp_path / "free.yaml"
    path.write_text(yaml.safe_dump(free_bodies_scene(N_BODIES)))
    return path


def run_node(tmp_path: Path, scene: Path, *extra: str):
    return start_process(["-p", f"scene:={scene}", "-p", "paused:=true", "-p", "status_period:=0.0", *extra],
                         tmp_path / "node.log")


def test_batches_match_simulator_and_body_names(tmp_path, scene_file):
    """Paused: the late-joining subscribers get the initial state (transient local); after 3 ~/step
    ticks, poses and velocities equal the core's replay of the same steps bitwise, with equal stamps."""
    process = run_node(tmp_path, scene_file, "-p", "per_body_topics:=true", "-p", "twist_stamped:=true")
    peer = Peer()
    try:
        sim = Simulator(load_scene(scene_file), integrator="rk4", dt=0.01)
        poses: list[PoseArray] = []
        clouds: list[PointCloud2] = []
        twists: list[TwistStamped] = []
        pose_b3: list[PoseStamped] = []
        latched = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        peer.node.create_subscription(PoseArray, "/poses", poses.append, latched)
        peer.node.create_subscription(PointCloud2, "/velocities", clouds.append, latched)
        peer.node.create_subscription(TwistStamped, "/b3/twist", twists.append, latched)
        peer.node.create_subscription(PoseStamped, "/b3/pose", pose_b3.append, latched)
        peer.spin_until(lambda: poses and clouds and twists and pose_b3, "the latched initial state")
        names = peer.get_parameter("body_names")
        assert names == list(sim.body_names) == [f"b{k}" for k in range(N_BODIES)]

        for step in range(3):
            result = peer.call(Trigger, "/rigid_body_sim/step", Trigger.Request())
            assert result.success, result.message
            sim.step(1)
        want_ns = round(sim.time * 1e9)
        peer.spin_until(lambda: stamp_ns(poses[-1].header) == want_ns and stamp_ns(clouds[-1].header) == want_ns
                        and twists and stamp_ns(twists[-1].header) == want_ns, "the state after 3 steps")
        msg, cloud = poses[-1], clouds[-1]
        assert msg.header.frame_id == "world" and cloud.header.frame_id == "world"
        expected = np.hstack([sim.positions_world(), sim.orientations_xyzw()])
        np.testing.assert_array_equal(pose_rows(msg), expected)
        assert (cloud.height, cloud.width, cloud.point_step, cloud.row_step, cloud.is_bigendian, cloud.is_dense) == (
            1, N_BODIES, VELOCITY_POINT_STEP, VELOCITY_POINT_STEP * N_BODIES, False, True)
        assert [(f.name, f.offset, f.datatype, f.count) for f in cloud.fields] == [
            (name, offset, datatype, 1) for name, offset, datatype in VELOCITY_FIELDS]
        v, w, stopped = cloud_points(cloud)
        np.testing.assert_array_equal(v, sim.linear_velocities_world())
        np.testing.assert_array_equal(w, sim.angular_velocities_world())
        assert not stopped.any()
        # B/twist as TwistStamped: the stamp and frame of B/pose at the same tick.
        same_tick = [p for p in pose_b3 if stamp_ns(p.header) == want_ns]
        assert same_tick and twists[-1].header == same_tick[-1].header
        assert twists[-1].twist.angular.x == sim.angular_velocities_world()[3, 0]

        # A late joiner while paused (no tick since): it gets the current state and time at once.
        from rosgraph_msgs.msg import Clock
        late_poses: list[PoseArray] = []
        late_clock: list[Clock] = []
        late = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        peer.node.create_subscription(PoseArray, "/poses", late_poses.append, late)
        peer.node.create_subscription(Clock, "/clock", late_clock.append, late)
        peer.spin_until(lambda: late_poses and late_clock, "the latched state for a late joiner")
        assert stamp_ns(late_poses[-1].header) == want_ns
        assert late_clock[-1].clock.sec * 1_000_000_000 + late_clock[-1].clock.nanosec == want_ns
        np.testing.assert_array_equal(pose_rows(late_poses[-1]), expected)

        # body_names is the node's: a client's change is refused and changes nothing.
        request = SetParameters.Request(parameters=[Parameter("body_names", Parameter.Type.STRING_ARRAY, ["x"]).to_parameter_msg()])
        result = peer.call(SetParameters, "/rigid_body_sim/set_parameters", request).results[0]
        assert not result.successful and "read-only" in result.reason
        assert peer.get_parameter("body_names") == names
    finally:
        peer.close()
        assert stop_process(process) == 0


def test_a_bad_qos_override_is_refused_at_start_up(scene_file):
    """A qos_overrides value that is no policy is refused when the node is made (rigid_body_sim_node: exit 2
    with this reason, as for every start-up ValueError). The overrides that take effect: test_parameters's
    test_a_recording_declares_the_qos_that_qos_overrides_give, as another participant discovers them."""
    from rigid_body_sim.testing import SimHarness

    with pytest.raises(ValueError, match="qos_overrides for 'velocities' rejected"):
        SimHarness(scene=scene_file, parameters={"qos_overrides./velocities.publisher.reliability": "sometimes"})


def test_body_names_follow_a_scene_change(tmp_path):
    """A ``scene`` change sets body_names to the new scene's order (and poses has its size)."""
    from rigid_body_sim.testing import SimHarness

    first, second = tmp_path / "first.yaml", tmp_path / "second.yaml"
    first.write_text(yaml.safe_dump(free_bodies_scene(3)))
    scene = free_bodies_scene(2, seed=1)
    scene["bodies"] = {f"other{k}": body for k, body in enumerate(scene["bodies"].values())}
    second.write_text(yaml.safe_dump(scene))
    with SimHarness(scene=first, parameters={"scene_dirs": [str(tmp_path)]}) as harness:
        assert harness.get_parameter("body_names") == ["b0", "b1", "b2"]
        (result,) = harness.set_parameters(scene=str(second))
        assert result.successful, result.reason
        assert harness.get_parameter("body_names") == ["other0", "other1"]
        with harness.node.locked_simulator() as sim:
            assert list(sim.body_names) == ["other0", "other1"]


def test_per_body_topics_false_publishes_and_records_only_the_batches(tmp_path, scene_file):
    """per_body_topics:=false (one node process for both checks): no B/pose, B/twist or B/odom
    publisher exists (graph query), nor any per-body input (the shared ones are there); with record_path, the recording holds
    poses, velocities and /clock only, two batch messages a tick with the scene order in their
    channel metadata, and read_recording gives back exactly what a subscriber received at every
    stamp (t = 0 and 3 ~/step ticks)."""
    from mcap.reader import make_reader

    from rigid_body_sim.offline.recording import BODY_NAMES_KEY, read_recording

    record = tmp_path / "batches.mcap"
    process = run_node(tmp_path, scene_file, "-p", "per_body_topics:=false", "-p", f"record_path:={record}")
    peer = Peer()
    try:
        poses: list[PoseArray] = []
        clouds: list[PointCloud2] = []
        latched = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        peer.node.create_subscription(PoseArray, "/poses", poses.append, latched)
        peer.node.create_subscription(PointCloud2, "/velocities", clouds.append, latched)
        peer.spin_until(lambda: poses and clouds, "the latched initial state")
        assert len(poses[-1].poses) == N_BODIES
        peer.spin_until(lambda: peer.node.count_subscribers("/wrench") == 1, "the shared wrench subscription")
        assert peer.node.count_subscribers("/b0/wrench") == 0  # per_body_inputs auto: none per body
        topics = {name for name, _types in peer.node.get_topic_names_and_types()}
        publishers = {t: peer.node.count_publishers(t) for t in topics}
        per_body = [t for t, count in publishers.items() if count and t.rsplit("/", 1)[-1] in ("pose", "twist", "odom")]
        assert per_body == []
        assert publishers["/poses"] == 1 and publishers["/velocities"] == 1
        names = peer.get_parameter("body_names")
        for _ in range(3):
            assert peer.call(Trigger, "/rigid_body_sim/step", Trigger.Request()).success
        want_ns = round(3 * 0.01 * 1e9)
        peer.spin_until(lambda: stamp_ns(poses[-1].header) == want_ns and stamp_ns(clouds[-1].header) == want_ns,
                        "the state after 3 steps")
    finally:
        peer.close()
        assert stop_process(process) == 0
    with open(record, "rb") as f:
        reader = make_reader(f)
        channels = reader.get_summary().channels.values()
        counts = reader.get_summary().statistics.channel_message_counts
    by_topic = {c.topic: c for c in channels}
    assert set(by_topic) == {"/poses", "/velocities", "/clock"}
    assert json.loads(by_topic["/poses"].metadata[BODY_NAMES_KEY]) == names
    assert json.loads(by_topic["/velocities"].metadata[BODY_NAMES_KEY]) == names
    assert counts[by_topic["/poses"].id] == counts[by_topic["/velocities"].id] == 4
    data, _scene = read_recording(record)
    assert data.meta["status"].startswith("complete")
    received = {stamp_ns(p.header): pose_rows(p) for p in poses}
    received_v = {stamp_ns(c.header): cloud_points(c) for c in clouds}
    assert [round(t * 1e9) for t in data.time] == sorted(received) == [0, 10_000_000, 20_000_000, 30_000_000]
    for k, body in enumerate(names):
        track = data.bodies[body]
        rows = np.array([received[t][k] for t in sorted(received)])
        np.testing.assert_array_equal(track.position_world, rows[:, :3])
        np.testing.assert_array_equal(track.orientation_xyzw, rows[:, 3:])
        np.testing.assert_array_equal(track.linear_velocity_world, [received_v[t][0][k] for t in sorted(received)])
        np.testing.assert_array_equal(track.angular_velocity_world, [received_v[t][1][k] for t in sorted(received)])


def test_harness_with_per_body_topics_false_reads_the_batches(tmp_path):
    """SimHarness with per_body_topics false answers latest_pose / latest_twist from the batches:
    the same wrench and ticks give bitwise the same poses and twists as a per-body harness (the
    same core computes both), with the same stamps; per-body-only reads say what to use instead."""
    from rigid_body_sim.testing import SimHarness

    path = tmp_path / "twelve.yaml"
    path.write_text(yaml.safe_dump(free_bodies_scene(12)))
    seen = {}
    for batched in (False, True):
        with SimHarness(path, parameters={"per_body_topics": not batched, "integrator": "rk4"}) as harness:
            harness.publish_wrench("b7", force=(0.0, 3.0, 0.0), torque=(0.5, 0.0, 0.0), frame_id="b7")
            harness.step(3)
            seen[batched] = {b: (harness.latest_pose(b), harness.latest_twist(b)) for b in harness.node.simulator.body_names}
            if batched:
                assert len(harness.latest_poses().poses) == 12 and harness.latest_velocities().width == 12
                with pytest.raises(ValueError, match="per_body_topics false"):
                    harness.latest_odometry("b0")
                with pytest.raises(KeyError, match="bodies are"):
                    harness.latest_pose("nope")
            else:
                with pytest.raises(ValueError, match="per_body_topics"):
                    harness.latest_poses()
    assert set(seen[True]) == set(seen[False])
    for body, (pose, twist) in seen[False].items():
        batch_pose, batch_twist = seen[True][body]
        assert batch_pose.header == pose.header and stamp_ns(pose.header) == 30_000_000
        assert batch_pose.pose == pose.pose, body
        assert batch_twist == twist, body


def test_message_object_fallback_publishes_and_records_the_same_batches(tmp_path, monkeypatch, capfd):
    """When direct CDR does not match the middleware (forced here: the check reports a mismatch,
    which this machine's Fast DDS never does), the node publishes PoseArray and PointCloud2
    objects instead: subscribers get the same messages, bitwise, and the recording, which
    serializes them only because it records, holds the same state."""
    from rigid_body_sim.offline.recording import read_recording
    from rigid_body_sim.ros import batch
    from rigid_body_sim.testing import SimHarness

    path = tmp_path / "five.yaml"
    path.write_text(yaml.safe_dump(free_bodies_scene(5)))
    seen = {}
    for fallback in (False, True):
        if fallback:
            monkeypatch.setattr(batch.BatchCdr, "check", lambda self: "forced by the test")
        record = tmp_path / f"fallback_{fallback}.mcap"
        parameters = {"per_body_topics": False, "integrator": "rk4", "record_path": str(record)}
        capfd.readouterr()
        with SimHarness(path, parameters=parameters) as harness:
            warned = "publishing batch message objects (slower)" in capfd.readouterr().err
            assert warned == fallback
            harness.publish_wrench("b3", force=(0.0, 0.0, 2.0), torque=(0.0, 0.4, 0.0), frame_id="b3")
            harness.step(4)
            seen[fallback] = (harness.latest_poses(), harness.latest_velocities())
        data, _scene = read_recording(record)
        assert data.meta["status"].startswith("complete") and len(data.time) == 5
        seen[fallback] += (data,)
    (poses, cloud, data), (poses_f, cloud_f, data_f) = seen[False], seen[True]
    assert stamp_ns(poses.header) == 40_000_000
    assert poses_f == poses and cloud_f == cloud
    np.testing.assert_array_equal(data_f.time, data.time)
    for body, track in data.bodies.items():
        for field in ("position_world", "orientation_xyzw", "linear_velocity_world", "angular_velocity_world"):
            np.testing.assert_array_equal(getattr(data_f.bodies[body], field), getattr(track, field))


def test_a_stopped_body_stays_in_the_batches_flagged_with_its_last_state(tmp_path):
    """A body driven to an infinite velocity is stopped: it stays in poses and velocities with the
    last state published for it before it was stopped and stopped = 1; nothing non-finite is
    published, and the other body runs on (stopped = 0)."""
    from rigid_body_sim.testing import SimHarness

    scene = {"bodies": {"feather": {"mass": 1e-300, "inertia": {"sphere": 1.0}},
                        "box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}}}}
    path = tmp_path / "two.yaml"
    path.write_text(yaml.safe_dump(scene))
    with SimHarness(path, parameters={"integrator": "euler", "wrench_timeout": 0.0}) as harness:
        poses: list[PoseArray] = []
        clouds: list[PointCloud2] = []
        latched = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL)  # also the t = 0 state
        harness.client.create_subscription(PoseArray, "poses", poses.append, latched)
        harness.client.create_subscription(PointCloud2, "velocities", clouds.append, latched)
        harness.spin_until(lambda: harness.client.count_publishers("poses") and harness.node.count_subscribers("poses")
                           and harness.node.count_subscribers("velocities"), "the batch subscriptions")
        harness.publish_wrench("feather", force=(1e12, 0.0, 0.0), frame_id="world")
        harness.publish_wrench("box", force=(2.0, 0.0, 0.0), frame_id="world")
        harness.spin_until(lambda: poses and clouds, "the t = 0 batches")
        harness.step(4)
        want_ns = round(4 * 0.01 * 1e9)
        harness.spin_until(lambda: poses and clouds and stamp_ns(poses[-1].header) == want_ns
                           and stamp_ns(clouds[-1].header) == want_ns, "the batches after 4 ticks")
        assert harness.node.simulator.stopped_bodies == ("feather",)
        names = harness.get_parameter("body_names")
        f, b = names.index("feather"), names.index("box")
        by_stamp = {stamp_ns(c.header): cloud_points(c) for c in clouds}
        pose_by_stamp = {stamp_ns(p.header): pose_rows(p) for p in poses}
        flagged = sorted(t for t, (_v, _w, stopped) in by_stamp.items() if stopped[f])
        assert flagged and flagged[-1] == want_ns
        before = max(t for t in by_stamp if t < flagged[0])
        for t in flagged:
            v, w, stopped = by_stamp[t]
            assert stopped[f] and not stopped[b]
            np.testing.assert_array_equal(pose_by_stamp[t][f], pose_by_stamp[before][f])
            np.testing.assert_array_equal(v[f], by_stamp[before][0][f])
        for rows in pose_by_stamp.values():
            assert np.all(np.isfinite(rows))
        for v, w, _stopped in by_stamp.values():
            assert np.all(np.isfinite(v)) and np.all(np.isfinite(w))
