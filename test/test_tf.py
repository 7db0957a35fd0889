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
    finally:
        rclpy.try_shutdown(context=context)


def test_nothing_built_while_nobody_listens():
    sim = Simulator(load_scene(SCENE), dt=0.01)
    context = Context()
    rclpy.init(context=context)
    try:
        node = Node("tf_alone", context=context)
        tf = TfPublisher(node, "world")
        assert tf.publish(sim, time_msg_from_seconds(0.0)) is False
    finally:
        rclpy.try_shutdown(context=context)
