"""Publishers and subscriptions the node replaces while it runs: per body and per site, made and
destroyed by scene changes, spawns, deletes, resets and ``publish_odometry`` / ``publish_contact_wrench``.

They are created without rclpy's default QoS event handlers (the "incompatible QoS" and
"incompatible type" warnings), because they are destroyed from whichever thread makes the change:
a thread calling ``node.set_parameters``, a MultiThreadedExecutor's worker, the tick thread
(``B/contact_wrench``). rclpy's Python executors (SingleThreadedExecutor, MultiThreadedExecutor;
ros-rclpy 9.1.2) snapshot a node's event handlers, then enter each, skipping one destroyed in
between, yet add every one of the snapshot to the wait set: ``add_to_wait_set`` on a destroyed one
raises ``InvalidHandle: cannot use Destroyable because destruction was requested`` out of
``spin_once``, in the thread spinning the node. Subscriptions, timers and publishers without event
handlers are safe to destroy from any thread: the executor skips a destroyed one and defers the
destruction of one it is waiting on. (The EventsExecutor ``rigid_body_sim_node`` spins is not affected.)

What is lost is the simulator's own log line when a peer's QoS or type does not match a per-body
topic; the peer's node still logs its side (rclpy's and rclcpp's default event callbacks), and
the node's long-lived endpoints (shared inputs, batches, /clock, /tf, /diagnostics) keep theirs.
"""

from __future__ import annotations

from typing import Any, Callable

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from rclpy.subscription import Subscription

__all__ = ["create_replaceable_publisher", "create_replaceable_subscription"]


def create_replaceable_publisher(node: Node, msg_type: Any, topic: str, qos: QoSProfile) -> Publisher:
    """``node.create_publisher`` for a publisher that may be destroyed from any thread while the node spins."""
    return node.create_publisher(msg_type, topic, qos,
                                 event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))


def create_replaceable_subscription(node: Node, msg_type: Any, topic: str, callback: Callable[[Any], None],
                                    qos: QoSProfile) -> Subscription:
    """``node.create_subscription`` for a subscription that may be destroyed from any thread while the node spins."""
    return node.create_subscription(msg_type, topic, callback, qos,
                                    event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
