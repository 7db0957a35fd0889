"""What the node sends each tick: the batches ``poses`` and ``velocities`` (batch.py), per body
``B/pose``, ``B/twist`` (and ``B/odom``) unless ``per_body_topics`` is false, and ``/clock``.

Poses, twists, the batches and /clock go out as CDR bytes built by :mod:`.cdr` and
:mod:`.batch` (``Publisher.publish`` takes serialized bytes; checked against the middleware at
start-up, message objects otherwise); odometry as message objects.

QoS (README "QoS"): every state topic (``poses``, ``velocities``, ``B/pose``, ``B/twist``,
``B/odom``) and ``/clock`` is RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1 (:data:`STATE_QOS`): a
subscriber that joins late (also while the simulation is paused) gets the latest state at once,
and the publisher matches both reliable and best-effort, volatile and transient-local
subscribers. ``poses``, ``velocities`` and ``/clock`` take the standard
``qos_overrides./<topic>.publisher.{history,depth,reliability,durability}`` parameters
(:class:`rclpy.qos_overriding_options.QoSOverridingOptions`); per-body topics do not (four
read-only parameters per topic and body would be thousands of parameters).

Per-body publishers change in three steps so that a scene change never holds the tick lock
while creating or destroying endpoints: :meth:`StatePublishers.prepare` creates what the new
set of bodies needs (no shared state touched), :meth:`StatePublishers.commit` swaps it in
(under the node's lock, O(1)), :meth:`StatePublishers.release` destroys what is no longer used.
Publishers of bodies present before and after are kept, so their subscribers stay connected.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterable

import numpy as np
from geometry_msgs.msg import PoseArray, PoseStamped, Twist, TwistStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.qos_overriding_options import InvalidQosOverridesError, QoSOverridingOptions, QoSPolicyKind
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import PointCloud2

from ..core import Simulator
from .batch import VELOCITY_POINT_STEP, BatchCdr, pose_array, velocity_cloud
from .cdr import PoseTwistClockCdr, check_against_middleware
from .conversions import fill_odometry, fill_pose_stamped, fill_twist, time_msg_from_seconds
from .replaceable import create_replaceable_publisher

__all__ = ["BodyPublishers", "PublisherChange", "StatePublishers", "STATE_QOS", "OVERRIDABLE_TOPICS"]

#: QoS of every state topic and /clock, before ``qos_overrides``: the latest state to late joiners.
STATE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: Topics whose publisher QoS the ``qos_overrides./<topic>.publisher.*`` parameters change.
OVERRIDABLE_TOPICS = ("poses", "velocities", "/clock")
_OVERRIDDEN_POLICIES = (QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH, QoSPolicyKind.RELIABILITY,
                        QoSPolicyKind.DURABILITY)


def _valid_qos(qos: QoSProfile) -> SetParametersResult:
    """A KEEP_LAST history needs a depth of at least 1."""
    if qos.history == HistoryPolicy.KEEP_LAST and qos.depth < 1:
        return SetParametersResult(successful=False, reason=f"depth must be at least 1 with history keep_last, got {qos.depth}")
    return SetParametersResult(successful=True)


@dataclass
class BodyPublishers:
    """One body's publishers and the messages reused for them."""

    pose: Any
    twist: Any
    odom: Any | None
    pose_msg: PoseStamped = field(default_factory=PoseStamped)
    twist_msg: Any = field(default_factory=Twist)
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
    world_frame : str
        ``header.frame_id`` of poses, batches, odometry and stamped twists.
    per_body_topics : bool
        Publish ``B/pose``, ``B/twist`` (``B/odom``) per body; False: only the batches.
    twist_stamped : bool
        ``B/twist`` as TwistStamped (the pose's stamp and frame) instead of Twist.

    Raises
    ------
    ValueError
        If a ``qos_overrides`` parameter is not a valid policy value.
    """

    def __init__(self, node: Node, world_frame: str, *, per_body_topics: bool = True, twist_stamped: bool = False,
                 frame_prefix: str = ""):
        self._node = node
        self._prefix = frame_prefix  # in front of odometry's child_frame_id (world_frame comes with it)
        self._qos = STATE_QOS
        self._world_frame = world_frame
        self.per_body_topics = per_body_topics
        self._twist_type = TwistStamped if twist_stamped else Twist
        self.bodies: dict[str, BodyPublishers] = {}
        # (body names, sec, nanosec, poses, velocities) of the batches published last: CDR bytes,
        # or the message objects of the fallback, serialized only if asked (last_batches_cdr).
        self._last_batches: tuple[tuple[str, ...], int, int, Any, Any] | None = None
        self._clock_pub = self._overridable(ClockMsg, "/clock")
        self._poses_pub = self._overridable(PoseArray, "poses")
        self._velocities_pub = self._overridable(PointCloud2, "velocities")
        self._clock_msg = ClockMsg()
        self._cdr = self._make_cdr()
        self._batch: BatchCdr | None = None
        self._batch_failed = False
        self._index: dict[str, int] = {}
        self._last: tuple[Any, int, np.ndarray, np.ndarray] | None = None  # (sim, n, pose rows, points)

    def _overridable(self, msg_type: Any, topic: str) -> Any:
        try:
            return self._node.create_publisher(
                msg_type, topic, QoSProfile(**{k: getattr(STATE_QOS, k) for k in ("history", "depth", "reliability", "durability")}),
                qos_overriding_options=QoSOverridingOptions(_OVERRIDDEN_POLICIES, callback=_valid_qos))
        except (InvalidQosOverridesError, RuntimeError, ValueError) as exc:
            raise ValueError(f"qos_overrides for {topic!r} rejected: {exc}; expected history keep_last|keep_all, "
                             "depth >= 1, reliability reliable|best_effort, durability volatile|transient_local") from exc

    def offered_qos(self) -> dict[str, tuple[str, int, str, str]]:
        """(history, depth, reliability, durability) the publishers of :data:`OVERRIDABLE_TOPICS` really
        offer, ``qos_overrides`` applied (what a recording declares in ``offered_qos_profiles``)."""
        def policies(qos: QoSProfile) -> tuple[str, int, str, str]:
            return qos.history.name.lower(), int(qos.depth), qos.reliability.name.lower(), qos.durability.name.lower()
        return {topic: policies(pub.qos_profile) for topic, pub in
                zip(OVERRIDABLE_TOPICS, (self._poses_pub, self._velocities_pub, self._clock_pub))}

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
        for name in names if self.per_body_topics else ():
            old = self.bodies.get(name)
            if old is None:
                bodies[name] = BodyPublishers(
                    pose=create_replaceable_publisher(self._node, PoseStamped, f"{name}/pose", self._qos),
                    twist=create_replaceable_publisher(self._node, self._twist_type, f"{name}/twist", self._qos),
                    twist_msg=self._twist_type(),
                    odom=self._odom_publisher(name) if publish_odometry else None)
            elif (old.odom is not None) == publish_odometry:
                bodies[name] = old
            else:
                bodies[name] = BodyPublishers(pose=old.pose, twist=old.twist, twist_msg=old.twist_msg,
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
        return create_replaceable_publisher(self._node, Odometry, f"{name}/odom", self._qos)

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

    def batch_subscription_count(self) -> int:
        """How many subscriptions the ``poses`` and ``velocities`` publishers have matched (the smaller)."""
        return min(self._poses_pub.get_subscription_count(), self._velocities_pub.get_subscription_count())

    # ------------------------------------------------------------------ per tick

    def publish(self, sim: Simulator, publish_clock: bool) -> None:
        """Publish ``poses`` and ``velocities``, then every running body's pose and twist (and
        odometry) if ``per_body_topics``, then /clock, at ``sim.time``. Hold the node's lock.

        Bodies stopped for blow-up, or with a non-finite state, stay in the batches with the
        last finite state published for them and ``stopped`` = 1; the per-body topics skip them.
        """
        stamp = time_msg_from_seconds(sim.time)
        sec, nanosec = stamp.sec, stamp.nanosec
        names = sim.body_names
        n = len(names)
        # The pose rows and the velocity points (batch.py) in one compiled pass over the state:
        # bitwise batch_rows of positions_world, orientations_xyzw and the velocities.
        rows, twists = np.empty((n, 7)), np.zeros((n, 7))
        finite = sim.pose_twist_rows(rows, twists)
        stopped_names = sim.stopped_bodies
        stopped = ~finite
        if stopped_names:
            if len(self._index) != n or any(self._index.get(b) is None for b in stopped_names):
                self._index = {b: k for k, b in enumerate(names)}
            stopped[[self._index[b] for b in stopped_names]] = True
        points = twists.astype("<f8", copy=False).view(np.uint8).reshape(n, VELOCITY_POINT_STEP)  # little endian
        points[:, 48] = stopped
        last = self._last
        if not finite.all():
            if last is not None and last[0] is sim and last[1] == n:
                rows[~finite] = last[2][~finite]
                points[~finite, :48] = last[3][~finite, :48]
            else:  # never published finite (cannot happen: a scene starts finite); publish zeros, flagged
                rows[~finite] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
                points[~finite, :48] = 0
        self._last = (sim, n, rows, points)
        self._publish_batches(names, sec, nanosec, stamp, rows, points)
        if self.bodies:
            self._publish_per_body(sim, stamp, stopped)
        if publish_clock:
            if self._cdr is not None:
                self._clock_pub.publish(self._cdr.clock(sec, nanosec))
            else:
                self._clock_msg.clock = stamp
                self._clock_pub.publish(self._clock_msg)

    def _publish_batches(self, names: tuple[str, ...], sec: int, nanosec: int, stamp: Any, rows: np.ndarray,
                         points: np.ndarray) -> None:
        n = len(rows)
        batch = self._batch
        if not self._batch_failed and (batch is None or batch.n != n):
            try:
                batch = BatchCdr(n, self._world_frame)
                reason = batch.check()
            except ValueError as exc:
                reason = str(exc)
            if reason is not None:
                self._node.get_logger().warning(
                    f"publishing batch message objects (slower): direct CDR does not match the middleware: {reason}")
                self._batch_failed, batch = True, None
            self._batch = batch
        if batch is not None:
            poses_cdr, velocities_cdr = batch.poses(sec, nanosec, rows), batch.velocities(sec, nanosec, points)
            self._poses_pub.publish(poses_cdr)
            self._velocities_pub.publish(velocities_cdr)
            self._last_batches = (names, sec, nanosec, poses_cdr, velocities_cdr)
            return
        poses = pose_array(n)
        poses.header.stamp, poses.header.frame_id = stamp, self._world_frame
        for pose, row in zip(poses.poses, rows.tolist()):
            pose.position.x, pose.position.y, pose.position.z = row[:3]
            pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = row[3:]
        cloud = velocity_cloud(n)
        cloud.header.stamp, cloud.header.frame_id = stamp, self._world_frame
        cloud.data = points.tobytes()
        self._poses_pub.publish(poses)
        self._velocities_pub.publish(cloud)
        self._last_batches = (names, sec, nanosec, poses, cloud)

    def last_batches_cdr(self) -> tuple[tuple[str, ...], int, int, bytes, bytes] | None:
        """(body names, sec, nanosec, poses CDR, velocities CDR) of the batches published last, or
        None before the first: for the recording. The names are the simulator's ``body_names``
        tuple itself. With the message-object fallback they are serialized here, so a node that
        does not record never pays for it."""
        last = self._last_batches
        if last is not None and not isinstance(last[3], bytes):
            names, sec, nanosec, poses, cloud = last
            last = self._last_batches = (names, sec, nanosec, serialize_message(poses), serialize_message(cloud))
        return last

    def _publish_per_body(self, sim: Simulator, stamp: Any, stopped: np.ndarray) -> None:
        sec, nanosec = stamp.sec, stamp.nanosec
        # One conversion per array and tick: rows of plain Python floats, no numpy scalars per field.
        positions = sim.positions_world().tolist()
        orientations = sim.orientations_xyzw().tolist()
        velocities = sim.linear_velocities_world().tolist()
        rates_world = sim.angular_velocities_world().tolist()
        skip = stopped.tolist()
        cdr = self._cdr
        world = self._world_frame
        stamped = self._twist_type is TwistStamped
        for index, body in enumerate(sim.body_names):
            if skip[index]:
                continue
            pubs = self.bodies[body]
            if cdr is not None:
                pubs.pose.publish(cdr.pose_stamped(sec, nanosec, positions[index], orientations[index]))
                pubs.twist.publish(cdr.twist_stamped(sec, nanosec, velocities[index], rates_world[index]) if stamped
                                   else cdr.twist(velocities[index], rates_world[index]))
            else:
                pubs.pose.publish(fill_pose_stamped(pubs.pose_msg, stamp, world, positions[index], orientations[index]))
                if stamped:
                    pubs.twist_msg.header.stamp, pubs.twist_msg.header.frame_id = stamp, world
                    fill_twist(pubs.twist_msg.twist, velocities[index], rates_world[index])
                    pubs.twist.publish(pubs.twist_msg)
                else:
                    pubs.twist.publish(fill_twist(pubs.twist_msg, velocities[index], rates_world[index]))
            if pubs.odom is not None:
                state = sim.body_state(body)
                pubs.odom.publish(fill_odometry(pubs.odom_msg, stamp, world, self._prefix + body, state.position_world,
                                                state.orientation_xyzw, state.linear_velocity_body,
                                                state.angular_velocity_body))
