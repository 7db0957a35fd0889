"""What the node sends each tick: per body ``B/pose``, ``B/twist`` (and ``B/odom``), and ``/clock``.

Poses, twists and /clock go out as CDR bytes built by :mod:`.cdr` (``Publisher.publish``
takes serialized bytes; checked against the middleware at start-up, message objects
otherwise); odometry as message objects.

Per-body publishers change in three steps so that a scene change never holds the tick lock
while creating or destroying endpoints: :meth:`StatePublishers.prepare` creates what the new
set of bodies needs (no shared state touched), :meth:`StatePublishers.commit` swaps it in
(under the node's lock, O(1)), :meth:`StatePublishers.release` destroys what is no longer used.
Publishers of bodies present before and after are kept, so their subscribers stay connected.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterable

from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg

from ..core import Simulator
from .cdr import PoseTwistClockCdr, check_against_middleware
from .conversions import fill_odometry, fill_pose_stamped, fill_twist, time_msg_from_seconds

__all__ = ["BodyPublishers", "PublisherChange", "StatePublishers"]


@dataclass
class BodyPublishers:
    """One body's publishers and the messages reused for them."""

    pose: Any
    twist: Any
    odom: Any | None
    pose_msg: PoseStamped = field(default_factory=PoseStamped)
    twist_msg: Twist = field(default_factory=Twist)
    odom_msg: Odometry = field(default_factory=Odometry)


@dataclass
class PublisherChange:
    """A prepared set of per-body publishers: ``bodies`` to swap in, ``stale`` publishers to destroy after."""

    bodies: dict[str, BodyPublishers]
    stale: list[Any]


class StatePublishers:
    """The node's outgoing state.

    Parameters
    ----------
    node : rclpy.node.Node
        Owner of the publishers.
    qos : QoSProfile
        Of every publisher.
    world_frame : str
        ``header.frame_id`` of poses and odometry.
    """

    def __init__(self, node: Node, qos: QoSProfile, world_frame: str):
        self._node = node
        self._qos = qos
        self._world_frame = world_frame
        self.bodies: dict[str, BodyPublishers] = {}
        self._clock_pub = node.create_publisher(ClockMsg, "/clock", qos)
        self._clock_msg = ClockMsg()
        self._cdr = self._make_cdr()

    def _make_cdr(self) -> PoseTwistClockCdr | None:
        """The CDR serializer for pose, twist and /clock, or None (publish message objects) if it
        does not match the middleware's own serialization."""
        try:
            cdr = PoseTwistClockCdr(self._world_frame)
            reason = check_against_middleware(cdr)
        except ValueError as exc:
            reason = str(exc)
        if reason is None:
            return cdr
        self._node.get_logger().warning(
            f"publishing message objects (slower): direct CDR does not match the middleware: {reason}")
        return None

    # ------------------------------------------------------------------ endpoints

    def prepare(self, names: Iterable[str], publish_odometry: bool) -> PublisherChange:
        """Create what ``names`` need beyond what exists; touches nothing the ticks read."""
        bodies: dict[str, BodyPublishers] = {}
        for name in names:
            old = self.bodies.get(name)
            if old is None:
                bodies[name] = BodyPublishers(
                    pose=self._node.create_publisher(PoseStamped, f"{name}/pose", self._qos),
                    twist=self._node.create_publisher(Twist, f"{name}/twist", self._qos),
                    odom=self._odom_publisher(name) if publish_odometry else None)
            elif (old.odom is not None) == publish_odometry:
                bodies[name] = old
            else:
                bodies[name] = BodyPublishers(pose=old.pose, twist=old.twist,
                                              odom=self._odom_publisher(name) if publish_odometry else None)
        stale = []
        for name, old in self.bodies.items():
            new = bodies.get(name)
            if new is None:
                stale += [old.pose, old.twist]
            if old.odom is not None and (new is None or new.odom is not old.odom):
                stale.append(old.odom)
        return PublisherChange(bodies, stale)

    def _odom_publisher(self, name: str) -> Any:
        return self._node.create_publisher(Odometry, f"{name}/odom", self._qos)

    def commit(self, change: PublisherChange) -> None:
        """Swap in prepared publishers (hold the node's lock)."""
        self.bodies = change.bodies

    def release(self, change: PublisherChange) -> None:
        """Destroy the publishers ``change`` replaced (after :meth:`commit`, without the lock)."""
        for publisher in change.stale:
            self._node.destroy_publisher(publisher)
        change.stale = []

    def subscription_counts(self) -> dict[str, int]:
        """Per body, how many subscriptions its pose and twist publishers have matched (the smaller)."""
        return {b: min(p.pose.get_subscription_count(), p.twist.get_subscription_count())
                for b, p in self.bodies.items()}

    # ------------------------------------------------------------------ per tick

    def publish(self, sim: Simulator, publish_clock: bool) -> None:
        """Publish every running body's pose and twist (and odometry), then /clock, at ``sim.time``.

        Bodies stopped for blow-up, or with a non-finite state, are skipped. Hold the node's lock.
        """
        stamp = time_msg_from_seconds(sim.time)
        sec, nanosec = stamp.sec, stamp.nanosec
        stopped = set(sim.stopped_bodies)
        # One conversion per array and tick: rows of plain Python floats, no numpy scalars per field.
        positions = sim.positions_world().tolist()
        orientations = sim.orientations_xyzw().tolist()
        velocities = sim.linear_velocities_world().tolist()
        rates_world = sim.angular_velocities_world().tolist()
        finite = sim.state.finite_bodies().tolist()
        cdr = self._cdr
        world = self._world_frame
        for index, body in enumerate(sim.body_names):
            if not finite[index] or body in stopped:
                continue
            pubs = self.bodies[body]
            if cdr is not None:
                pubs.pose.publish(cdr.pose_stamped(sec, nanosec, positions[index], orientations[index]))
                pubs.twist.publish(cdr.twist(velocities[index], rates_world[index]))
            else:
                pubs.pose.publish(fill_pose_stamped(pubs.pose_msg, stamp, world, positions[index], orientations[index]))
                pubs.twist.publish(fill_twist(pubs.twist_msg, velocities[index], rates_world[index]))
            if pubs.odom is not None:
                state = sim.body_state(body)
                pubs.odom.publish(fill_odometry(pubs.odom_msg, stamp, world, body, state.position_world,
                                                state.orientation_xyzw, state.linear_velocity_body,
                                                state.angular_velocity_body))
        if publish_clock:
            if cdr is not None:
                self._clock_pub.publish(cdr.clock(sec, nanosec))
            else:
                self._clock_msg.clock = stamp
                self._clock_pub.publish(self._clock_msg)
