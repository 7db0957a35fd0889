"""``/tf`` and ``/tf_static``: where every body and site is, for tf2 (robot_localization, Nav2, RViz).

Published only where ``tf2_msgs`` is importable (every ROS install has it; PyPI has no wheel, and
``make venv`` builds it from its message definition, tools/ros_interfaces). Frames, each name
with ``frame_prefix`` in front (as robot_state_publisher does, so two simulators in one TF tree
never share a frame id):

================================  ==================  ===========================================
child frame                       parent              topic
================================  ==================  ===========================================
``B``                             ``world_frame``     ``/tf``, every tick (the body frame's pose)
``B/world_aligned``               ``world_frame``     ``/tf``, every tick (at B's centre of mass,
                                                      world axes)
``B/<site>`` (body axes)          ``B``               ``/tf_static``, once per scene (latched)
``B/<site>`` (``axes: world``)    ``world_frame``     ``/tf``, every tick
================================  ==================  ===========================================

QoS as tf2_ros's broadcasters: ``/tf`` reliable, volatile, depth 100; ``/tf_static`` reliable,
transient local, depth 1 (one message with every static transform, as tf2_ros's static
broadcaster keeps them). ``/tf`` is built and sent only while somebody subscribes to it, so a
node nobody listens to pays nothing for it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..core.quaternion import quat_conjugate, quat_multiply, quat_rotate, quat_xyzw_from_wxyz

try:  # tf2_msgs has no PyPI wheel; a ROS install (or `make venv`) provides it.
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage
except ImportError:  # pragma: no cover - exercised where tf2_msgs is missing
    TFMessage = None

__all__ = ["TF_AVAILABLE", "TF_QOS", "TF_STATIC_QOS", "TfPublisher"]

#: True where tf2_msgs is importable (then the node publishes /tf and /tf_static).
TF_AVAILABLE = TFMessage is not None
#: tf2_ros.DynamicBroadcasterQoS.
TF_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)
#: tf2_ros.StaticBroadcasterQoS.
TF_STATIC_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _transform(parent: str, child: str, stamp: Any, p: np.ndarray, q_xyzw: np.ndarray) -> "TransformStamped":
    msg = TransformStamped()
    msg.header.stamp = stamp
    msg.header.frame_id = parent
    msg.child_frame_id = child
    t, r = msg.transform.translation, msg.transform.rotation
    t.x, t.y, t.z = float(p[0]), float(p[1]), float(p[2])
    r.x, r.y, r.z, r.w = float(q_xyzw[0]), float(q_xyzw[1]), float(q_xyzw[2]), float(q_xyzw[3])
    return msg


class TfPublisher:
    """The node's /tf and /tf_static publishers (see the module doc).

    Parameters
    ----------
    node : rclpy.node.Node
    world_frame : str
        The world frame's name, without the prefix.
    frame_prefix : str
        Put in front of every frame id (``""``: none).
    """

    def __init__(self, node: Node, world_frame: str, frame_prefix: str = ""):
        if not TF_AVAILABLE:
            raise RuntimeError("tf2_msgs is not importable: /tf cannot be published (see TF_AVAILABLE)")
        self._prefix = frame_prefix
        self._world = frame_prefix + world_frame
        self._tf = node.create_publisher(TFMessage, "/tf", TF_QOS)
        self._tf_static = node.create_publisher(TFMessage, "/tf_static", TF_STATIC_QOS)
        self._body_frames: list[str] = []
        self._aligned_frames: list[str] = []
        self._world_sites: list[tuple[str, int, np.ndarray]] = []  # (child, body index, p_B)
        self._q_BP = np.zeros((0, 4))

    def set_scene(self, sim: Any, stamp: Any) -> None:
        """Take the bodies and sites of ``sim``'s scene and publish their static transforms (latched)."""
        model = sim.model
        self._body_frames = [self._prefix + name for name in model.names]
        self._aligned_frames = [f"{frame}/world_aligned" for frame in self._body_frames]
        self._q_BP = np.asarray(model.q_BP, dtype=float)
        site_p_B = quat_rotate(self._q_BP[np.asarray(model.site_body, dtype=int)], model.site_p_P) \
            if len(model.site_names) else np.zeros((0, 3))
        statics = []
        self._world_sites = []
        for name, body, p_B, world_axes in zip(model.site_names, model.site_body, site_p_B, model.site_world_axes):
            child = self._prefix + name
            if world_axes:
                self._world_sites.append((child, int(body), p_B))
            else:
                statics.append(_transform(self._body_frames[body], child, stamp, p_B, (0.0, 0.0, 0.0, 1.0)))
        self._tf_static.publish(TFMessage(transforms=statics))

    def publish(self, sim: Any, stamp: Any) -> bool:
        """Send every moving frame's transform at ``stamp`` on /tf; nothing while nobody subscribes.

        Returns True when a message was sent.
        """
        if self._tf.get_subscription_count() == 0:
            return False
        state = sim.state
        q_WB = quat_multiply(state.q_WP, quat_conjugate(self._q_BP))  # body frame B from principal axes P
        q_WB_xyzw = quat_xyzw_from_wxyz(q_WB)
        p_W = state.p_WC_W
        identity = (0.0, 0.0, 0.0, 1.0)
        transforms = []
        for b, child in enumerate(self._body_frames):
            transforms.append(_transform(self._world, child, stamp, p_W[b], q_WB_xyzw[b]))
            transforms.append(_transform(self._world, self._aligned_frames[b], stamp, p_W[b], identity))
        for child, b, p_B in self._world_sites:
            transforms.append(_transform(self._world, child, stamp, p_W[b] + quat_rotate(q_WB[b], p_B), identity))
        self._tf.publish(TFMessage(transforms=transforms))
        return True

    def destroy(self, node: Node) -> None:
        """Destroy both publishers."""
        node.destroy_publisher(self._tf)
        node.destroy_publisher(self._tf_static)
