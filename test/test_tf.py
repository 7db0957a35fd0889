"""``/tf`` and ``/tf_static`` (ros/tf.py): each body's transform from the world, its sites, the frame prefix.

tf2_msgs has no PyPI wheel; ``make venv`` builds it from its message definition
(tools/ros_interfaces), so these tests receive real tf2_msgs/TFMessage messages over DDS.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.core.quaternion import quat_rotate, quat_wxyz_from_xyzw
from rigid_body_sim.ros.conversions import time_msg_from_seconds
from rigid_body_sim.ros.tf import TF_AVAILABLE, TF_QOS, TF_STATIC_QOS, TfPublisher

pytestmark = pytest.mark.ros

SCENE = {"bodies": {
    "box": {"mass": 2.0, "inertia": {"tensor": [[1.0, 0.1, 0.0], [0.1, 0.8, 0.0], [0.0, 0.0, 0.5]]},
            "pose": {"position": [1.0, 2.0, 3.0], "orientation": [0.2, 0.1, 0.3, 0.9273618495495703]},
            "twist": {"linear": [0.1, 0.0, 0.0], "angular": [0.3, -0.2, 1.0]},
            "sites": {"corner": {"position": [0.5, 0.3, -0.2]},
                      "nozzle": {"position": [0.0, 0.0, 0.4], "axes": "world"}}},
    "ball": {"mass": 1.0, "inertia": {"sphere": 0.1}}}}


def test_tf2_msgs_is_built_into_the_environment():
    assert TF_AVAILABLE  # make venv builds it; without it the node publishes no /tf


def test_bodies_and_sites_on_tf_with_a_prefix():
    sim = Simulator(load_scene(SCENE), dt=0.01)
    sim.step(7)
    context = Context()
    rclpy.init(context=context)
    try:
        node = Node("tf_source", context=context)
        peer = Node("tf_listener", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        executor.add_node(peer)
        from tf2_msgs.msg import TFMessage

        dynamic: list = []
        static: list = []
        tf = TfPublisher(node, "world", frame_prefix="sim1/")
        peer.create_subscription(TFMessage, "/tf", dynamic.append, TF_QOS)
        tf.set_scene(sim, time_msg_from_seconds(sim.time))
        peer.create_subscription(TFMessage, "/tf_static", static.append, TF_STATIC_QOS)  # late joiner: latched
        deadline = time.monotonic() + 10.0
        while not (dynamic and static) and time.monotonic() < deadline:
            tf.publish(sim, time_msg_from_seconds(sim.time))
            executor.spin_once(timeout_sec=0.05)
        assert dynamic and static

        by_child = {t.child_frame_id: t for t in dynamic[-1].transforms}
        assert set(by_child) == {"sim1/box", "sim1/box/world_aligned", "sim1/box/nozzle",
                                 "sim1/ball", "sim1/ball/world_aligned"}
        for t in dynamic[-1].transforms:
            assert t.header.frame_id == "sim1/world"
            assert t.header.stamp.sec * 10**9 + t.header.stamp.nanosec == round(sim.time * 1e9)
        box = sim.body_state("box")
        t = by_child["sim1/box"].transform
        assert np.allclose([t.translation.x, t.translation.y, t.translation.z], box.position_world, rtol=0, atol=1e-15)
        assert np.allclose([t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w], box.orientation_xyzw,
                           rtol=0, atol=1e-15)
        # The world-axes site: at the COM plus the site's offset turned into world axes, no rotation.
        q_WB = quat_wxyz_from_xyzw(box.orientation_xyzw)
        nozzle = by_child["sim1/box/nozzle"].transform
        expected = box.position_world + quat_rotate(q_WB, np.array([0.0, 0.0, 0.4]))
        assert np.allclose([nozzle.translation.x, nozzle.translation.y, nozzle.translation.z], expected, atol=1e-14)
        assert (nozzle.rotation.w, nozzle.rotation.x) == (1.0, 0.0)

        (corner,) = static[-1].transforms
        assert (corner.header.frame_id, corner.child_frame_id) == ("sim1/box", "sim1/box/corner")
        # The body-axes site is fixed in B: its offset in B is the scene's, whatever the principal axes.
        assert np.allclose([corner.transform.translation.x, corner.transform.translation.y,
                            corner.transform.translation.z], [0.5, 0.3, -0.2], rtol=0, atol=1e-15)
        # The listener's subscription goes now, not when the collector gets to the executor-node cycle
        # (test_nothing_built_while_nobody_listens needs a domain without a /tf subscriber).
        executor.shutdown()
        peer.destroy_node()
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def test_nothing_built_while_nobody_listens():
    sim = Simulator(load_scene(SCENE), dt=0.01)
    context = Context()
    rclpy.init(context=context)
    try:
        node = Node("tf_alone", context=context)
        tf = TfPublisher(node, "world")
        # The premise: no subscriber on /tf in this domain (one of an earlier test may take a moment
        # to be forgotten by discovery).
        deadline = time.monotonic() + 15.0
        while node.count_subscribers("/tf") and time.monotonic() < deadline:
            time.sleep(0.1)
        assert node.count_subscribers("/tf") == 0
        assert tf.publish(sim, time_msg_from_seconds(0.0)) is False
    finally:
        rclpy.try_shutdown(context=context)


def _write_scene(tmp_path) -> str:
    import yaml

    path = tmp_path / "tf_scene.yaml"
    path.write_text(yaml.safe_dump(SCENE))
    return str(path)


def test_two_prefixed_nodes_share_no_frame_id(tmp_path):
    """Two simulators in two namespaces with two prefixes, heard by a listener in a third DDS
    participant: every frame id on /tf, /tf_static, poses and odometry carries its node's prefix
    (none is shared), and a wrench is accepted in a prefixed frame, counted unknown_frame without it."""
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import Odometry
    from tf2_msgs.msg import TFMessage

    from rigid_body_sim.testing import SimHarness

    scene = _write_scene(tmp_path)
    context = Context()
    rclpy.init(context=context)
    try:
        with SimHarness(scene, {"frame_prefix": "sim1/", "publish_odometry": True}, namespace="ns1") as one, \
                SimHarness(scene, {"frame_prefix": "sim2/", "publish_odometry": True}, namespace="ns2") as two:
            listener = Node("frame_listener", context=context)
            executor = SingleThreadedExecutor(context=context)
            executor.add_node(listener)
            heard: dict[str, list] = {"/tf": [], "/tf_static": []}
            listener.create_subscription(TFMessage, "/tf", heard["/tf"].append, TF_QOS)
            # As tf2_ros's StaticListenerQoS: transient local, depth 100 (depth 1 would keep one
            # of the two latched messages that arrive together).
            static_listener_qos = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                                             reliability=ReliabilityPolicy.RELIABLE)
            listener.create_subscription(TFMessage, "/tf_static", heard["/tf_static"].append, static_listener_qos)
            for ns in ("ns1", "ns2"):
                for body in ("box", "ball"):
                    for topic, msg_type in ((f"/{ns}/{body}/pose", PoseStamped), (f"/{ns}/{body}/odom", Odometry)):
                        heard[topic] = []
                        listener.create_subscription(msg_type, topic, heard[topic].append, 10)

            def frames(topic: str) -> set[tuple[str, str]]:
                return {(t.header.frame_id, t.child_frame_id) for msg in heard[topic] for t in msg.transforms}

            expected_tf = {("world", "box"), ("world", "box/world_aligned"), ("world", "box/nozzle"),
                           ("world", "ball"), ("world", "ball/world_aligned")}
            expected_static = {("box", "box/corner")}

            def prefixed(pairs: set, prefix: str) -> set:
                return {(prefix + a, prefix + b) for a, b in pairs}

            deadline = time.monotonic() + 20.0
            while time.monotonic() < deadline:
                one.step()
                two.step()
                # Take everything the ten subscriptions got: one spin_once runs one callback, and a
                # listener that falls behind fills its /tf history (depth 100) with one node's
                # messages first, so the other's, reliable, wait for resends that meet a full history again.
                for _ in range(40):
                    executor.spin_once(timeout_sec=0.0)
                if (frames("/tf") >= prefixed(expected_tf, "sim1/") | prefixed(expected_tf, "sim2/")
                        and frames("/tf_static") >= prefixed(expected_static, "sim1/") | prefixed(expected_static, "sim2/")
                        and all(heard[topic] for topic in heard)):
                    break
            assert frames("/tf") == prefixed(expected_tf, "sim1/") | prefixed(expected_tf, "sim2/")
            assert frames("/tf_static") == prefixed(expected_static, "sim1/") | prefixed(expected_static, "sim2/")
            ids: dict[str, set[str]] = {"sim1/": set(), "sim2/": set()}
            for prefix, ns in (("sim1/", "ns1"), ("sim2/", "ns2")):
                for body in ("box", "ball"):
                    assert {m.header.frame_id for m in heard[f"/{ns}/{body}/pose"]} == {prefix + "world"}
                    odoms = heard[f"/{ns}/{body}/odom"]
                    assert {(m.header.frame_id, m.child_frame_id) for m in odoms} == {(prefix + "world", prefix + body)}
                    ids[prefix] |= {prefix + "world", prefix + body}
                ids[prefix] |= {name for pair in frames("/tf") | frames("/tf_static") for name in pair
                                if name.startswith(prefix)}
            assert ids["sim1/"] and ids["sim2/"] and not ids["sim1/"] & ids["sim2/"]
            assert all(name.startswith(("sim1/", "sim2/")) for pair in frames("/tf") | frames("/tf_static")
                       for name in pair)

            # Inputs take the prefixed names only.
            one.publish_wrench("box", force=(1.0, 0.0, 0.0), frame_id="sim1/box")
            one.publish_wrench("box", force=(0.0, 1.0, 0.0), frame_id="sim1/world")
            one.publish_wrench("box", force=(0.0, 0.0, 1.0), frame_id="sim1/box/corner")
            assert one.node.accepted_messages == 3 and not one.node.rejected
            assert set(one.node.held_wrenches) == {("box", "box"), ("box", "world"), ("box", "box/corner")}
            one.publish_wrench("box", force=(1.0, 0.0, 0.0), frame_id="box")
            one.publish_wrench("box", force=(1.0, 0.0, 0.0), frame_id="world")
            one.publish_wrench("box", force=(1.0, 0.0, 0.0), frame_id="sim2/box")
            assert one.node.rejected == {"unknown_frame": 3}
            assert one.node.accepted_messages == 3
    finally:
        rclpy.try_shutdown(context=context)


def test_set_state_takes_prefixed_frame_ids(tmp_path):
    """With a prefix, set_state's header.frame_id is the prefixed world and child_frame_id the prefixed body."""
    from nav_msgs.msg import Odometry

    from rigid_body_sim.testing import SimHarness

    with SimHarness(_write_scene(tmp_path), {"frame_prefix": "sim1/"}, namespace="ns1") as harness:
        publisher = harness.client.create_publisher(Odometry, "ball/set_state", 10)
        harness.spin_until(lambda: publisher.get_subscription_count() > 0, "the node's ball/set_state")

        def send(frame_id: str, child: str) -> None:
            msg = Odometry()
            msg.header.frame_id, msg.child_frame_id = frame_id, child
            msg.pose.pose.position.x, msg.pose.pose.orientation.w = 5.0, 1.0
            seen = harness.messages_seen()
            publisher.publish(msg)
            harness.spin_until(lambda: harness.messages_seen() > seen, "the node to take the set_state")

        send("world", "ball")
        send("sim1/world", "ball")
        assert harness.node.rejected == {"unknown_frame": 2}
        send("sim1/world", "sim1/ball")
        assert harness.node.rejected == {"unknown_frame": 2} and harness.node.accepted_messages == 1
        harness.step()
        assert harness.latest_pose("ball").pose.position.x == 5.0
        assert harness.latest_pose("ball").header.frame_id == "sim1/world"


def test_imu_frames_carry_the_prefix_and_a_spawn_sends_tf_static_again(tmp_path):
    """An IMU's header.frame_id is its prefixed site frame, which /tf_static places on its body; a
    spawned body's sites are sent on /tf_static at once (late joiners get the new set)."""
    import yaml
    from sensor_msgs.msg import Imu
    from tf2_msgs.msg import TFMessage

    from rigid_body_sim.testing import SimHarness

    scene = {"bodies": {"box": {"mass": 1.0, "inertia": {"box": [1.0, 0.6, 0.4]},
                                "sites": {"imu_link": {"position": [0.0, 0.0, 0.1], "imu": {}}}}}}
    path = tmp_path / "imu_scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    with SimHarness(str(path), {"frame_prefix": "sim1/"}, namespace="ns1") as harness:
        imus: list = []
        harness.client.create_subscription(Imu, "box/imu_link/imu", imus.append, 10)
        harness.spin_until(lambda: harness.client.count_publishers("box/imu_link/imu") > 0, "the IMU publisher")
        harness.step()
        harness.spin_until(lambda: bool(imus), "an IMU message")
        assert imus[-1].header.frame_id == "sim1/box/imu_link"

        assert harness.spawn(crate="{mass: 2.0, inertia: {sphere: 0.2}, sites: {lid: {position: [0, 0, 0.2]}}}"
                             ).successful
        static_listener_qos = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                                         reliability=ReliabilityPolicy.RELIABLE)
        late: list = []  # joins after the spawn: the latched message is the new scene's
        harness.client.create_subscription(TFMessage, "/tf_static", late.append, static_listener_qos)
        harness.spin_until(lambda: bool(late), "/tf_static for a late joiner")
        assert {(t.header.frame_id, t.child_frame_id) for t in late[-1].transforms} == {
            ("sim1/box", "sim1/box/imu_link"), ("sim1/crate", "sim1/crate/lid")}


def test_tf_never_repeats_a_stamp(tmp_path):
    """A republish at the same sim time (a reset_world, a spawn) sends no second /tf at that stamp
    (tf2 would drop it as TF_REPEATED_DATA); the next tick carries the new poses."""
    from tf2_msgs.msg import TFMessage

    from rigid_body_sim.testing import SimHarness

    with SimHarness(_write_scene(tmp_path)) as harness:
        heard: list = []
        harness.client.create_subscription(TFMessage, "/tf", heard.append, TF_QOS)
        harness.spin_until(lambda: harness.client.count_subscribers("/tf") > 0, "the /tf subscription")
        for _ in range(3):
            harness.step()
        harness.reset_world()
        harness.spin_for(0.2)
        harness.step()
        harness.spin_until(lambda: bool(heard) and _ns(heard[-1]) == round(harness.node.simulator.time * 1e9),
                           "/tf after the reset_world")
        stamps = [_ns(msg) for msg in heard]
        assert stamps == sorted(set(stamps)), stamps
        box = next(t for t in heard[-1].transforms if t.child_frame_id == "box").transform.translation
        with harness.node.locked_simulator() as sim:
            assert [box.x, box.y, box.z] == sim.body_state("box").position_world.tolist()


def _ns(msg) -> int:
    stamp = msg.transforms[0].header.stamp
    return stamp.sec * 10**9 + stamp.nanosec


def test_a_recording_carries_the_prefixed_frame_ids(tmp_path):
    """What a prefixed node records is what it publishes and takes: poses in ``sim1/world``, a
    held wrench in its prefixed frame."""
    from geometry_msgs.msg import PoseStamped, WrenchStamped
    from mcap.reader import make_reader
    from rclpy.serialization import deserialize_message

    from rigid_body_sim.testing import SimHarness

    path = tmp_path / "prefixed.mcap"
    with SimHarness(_write_scene(tmp_path), {"frame_prefix": "sim1/", "record_path": str(path),
                                             "wrench_timeout": 0.0}) as harness:
        harness.publish_wrench("box", force=(0.0, 1.0, 0.0), frame_id="sim1/box/corner")
        harness.publish_wrench("ball", force=(1.0, 0.0, 0.0), frame_id="sim1/world")
        harness.step(2)
    frames: dict[str, set[str]] = {}
    with open(path, "rb") as handle:
        for _schema, channel, message in make_reader(handle).iter_messages():
            kind = {"/box/pose": PoseStamped, "/box/wrench": WrenchStamped, "/ball/wrench": WrenchStamped}.get(
                channel.topic)
            if kind is not None:
                frames.setdefault(channel.topic, set()).add(deserialize_message(message.data, kind).header.frame_id)
    assert frames == {"/box/pose": {"sim1/world"}, "/box/wrench": {"sim1/box/corner"}, "/ball/wrench": {"sim1/world"}}
