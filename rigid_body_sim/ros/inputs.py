"""What the node takes in: ``B/wrench`` (held) and ``B/impulse`` (applied once), validated.

Each comes on the shared topics ``wrench`` and ``impulse`` (one subscription each for all
bodies: the body is the one whose frame ``header.frame_id`` is, ``B``, ``B/world_aligned`` or
``B/<site>``; the world frame names no body, so it is refused there as ``unknown_frame``) and,
with per-body inputs on (the node's ``per_body_inputs``), on each body's ``B/wrench`` and
``B/impulse`` too. Both go through one parser, one validator and the same holds.

A wrench is geometry_msgs/WrenchStamped: force and torque about the origin of
``header.frame_id``, in its axes. It is held per (B, frame_id) until replaced, cleared by an
all-zero wrench, or older than ``wrench_timeout`` s of sim time; all holds are summed. An
impulse (the same message read as N·s and N·m·s) is applied once at the next step; impulses due
at the same step in the same (body, frame) are summed, so a flood of them while paused holds
one entry per frame, not one per message.

Incoming header stamps are not used: a hold is timed in sim time from the first tick it acts
on (the tick after its receipt), so a stamp in the far past or future (or a nanosec field
≥ 1e9) changes nothing. Messages are checked in
this order and the first failure is the reason counted: frame_id, then non-finite, then too
large (:mod:`.conversions`). Rejections are counted by reason (``/diagnostics``) and warned
about at most once per :data:`REJECTION_WARNING_PERIOD`.

The callbacks take only this module's own lock, never the node's: a long tick (a heavy
scene, many substeps) delays no message, and the executor that runs them stays free for the
node's other callbacks. Subscriptions change in the three steps :mod:`.publishers` describes
(prepare, commit, release).
"""

from __future__ import annotations

import math
import threading
import time
from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.qos import QoSProfile

from ..core import Scene, Simulator
from .conversions import RejectedMessage, wrench_from_msg
from .replaceable import create_replaceable_subscription

__all__ = ["REJECTION_WARNING_PERIOD", "SHARED_QUEUE_DEPTH", "BodyInputs", "InputChange", "WrenchInputs",
           "shared_qos"]

#: Wall seconds between two warnings about dropped messages (the counts go on regardless).
REJECTION_WARNING_PERIOD = 2.0
#: History depth of the shared ``wrench``, ``impulse`` and ``set_state`` subscriptions: one queue
#: for all bodies, so a burst for many bodies at once is not cut to the per-body queues' 10
#: (bounded still: 1000 WrenchStamped are ~100 kB).
SHARED_QUEUE_DEPTH = 1000


def shared_qos(qos: QoSProfile) -> QoSProfile:
    """``qos`` (the per-body subscriptions') with the depth :data:`SHARED_QUEUE_DEPTH`."""
    return QoSProfile(history=qos.history, depth=SHARED_QUEUE_DEPTH, reliability=qos.reliability,
                      durability=qos.durability)


@dataclass
class _Hold:
    """A held wrench: force and torque in the message's frame, and the sim time of the first tick
    it acted on (None until then)."""

    force: np.ndarray
    torque: np.ndarray
    first_time: float | None = None


@dataclass
class BodyInputs:
    """One body's subscriptions and the header.frame_id values it accepts (→ core frame name)."""

    wrench: Any  # None without per-body inputs
    impulse: Any
    frames: dict[str, str]


@dataclass
class InputChange:
    """Prepared subscriptions: ``bodies`` to swap in, ``stale`` subscriptions to destroy after;
    ``shared``: header.frame_id on the shared topics → (body, core frame)."""

    bodies: dict[str, BodyInputs]
    stale: list[Any]
    shared: dict[str, tuple[str, str]]


class WrenchInputs:
    """Held wrenches and pending impulses from ``wrench`` and ``impulse`` (and ``B/wrench`` and ``B/impulse``).

    Parameters
    ----------
    node : rclpy.node.Node
        Owner of the subscriptions (its logger warns about rejections).
    qos : QoSProfile
        Of every subscription.
    world_frame : str
        The name of the world frame (without the prefix).
    frame_prefix : str
        In front of every accepted header.frame_id (the node's ``frame_prefix``): with ``sim1/``,
        ``sim1/world`` and ``sim1/B/site`` are accepted, ``world`` and ``B/site`` are unknown frames.
    per_body : bool
        Also subscribe to ``B/wrench`` and ``B/impulse`` for every body B (two DDS endpoints a body).
    """

    def __init__(self, node: Node, qos: QoSProfile, world_frame: str, frame_prefix: str = "", *,
                 per_body: bool = True):
        self._node = node
        self._qos = qos
        self._world_frame = frame_prefix + world_frame
        self._prefix = frame_prefix
        self.per_body = per_body
        self._lock = threading.Lock()  # guards bodies' frames in use, holds, pending impulses, counters
        self.bodies: dict[str, BodyInputs] = {}
        self.shared_frames: dict[str, tuple[str, str]] = {}
        self.shared = [node.create_subscription(WrenchStamped, "wrench", lambda msg: self.on_wrench(None, msg),
                                                shared_qos(qos)),
                       node.create_subscription(WrenchStamped, "impulse", lambda msg: self.on_impulse(None, msg),
                                                shared_qos(qos))]
        self.holds: dict[tuple[str, str], _Hold] = {}
        self.pending_impulses: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
        self.rejected: Counter[str] = Counter()
        self.accepted = 0
        self._warned_wall = -math.inf
        self._rejections_since_warning = 0

    # ------------------------------------------------------------------ endpoints

    def prepare(self, sim: Simulator | Scene) -> InputChange:
        """Subscriptions for the bodies of ``sim`` (or a scene): existing ones kept (frames updated), new ones created."""
        bodies: dict[str, BodyInputs] = {}
        shared: dict[str, tuple[str, str]] = {}
        for body in sim.body_names:
            frames = {self._world_frame: "world"}
            frames.update({self._prefix + f: f for f in sim.frames_of(body) if f != "world"})
            shared.update((frame_id, (body, frame)) for frame_id, frame in frames.items() if frame != "world")
            old = self.bodies.get(body)
            if old is not None or not self.per_body:
                bodies[body] = BodyInputs(old.wrench, old.impulse, frames) if old else BodyInputs(None, None, frames)
            else:
                bodies[body] = BodyInputs(
                    wrench=create_replaceable_subscription(self._node, WrenchStamped, f"{body}/wrench",
                                                           lambda msg, b=body: self.on_wrench(b, msg), self._qos),
                    impulse=create_replaceable_subscription(self._node, WrenchStamped, f"{body}/impulse",
                                                            lambda msg, b=body: self.on_impulse(b, msg), self._qos),
                    frames=frames)
        stale = [s for name, old in self.bodies.items() if name not in bodies for s in (old.wrench, old.impulse)
                 if s is not None]
        return InputChange(bodies, stale, shared)

    def commit(self, change: InputChange, keep_holds: bool = False) -> None:
        """Swap in prepared subscriptions and drop every hold and pending impulse (with ``keep_holds``:
        only those of bodies no longer there, for a spawn or delete)."""
        with self._lock:
            self.bodies, self.shared_frames = change.bodies, change.shared
            if keep_holds:
                self.holds = {key: h for key, h in self.holds.items() if key[0] in self.bodies}
                self.pending_impulses = {key: j for key, j in self.pending_impulses.items() if key[0] in self.bodies}
            else:
                self.holds.clear()
                self.pending_impulses.clear()

    def release(self, change: InputChange) -> None:
        """Destroy the subscriptions ``change`` replaced (after :meth:`commit`, without the lock)."""
        for subscription in change.stale:
            self._node.destroy_subscription(subscription)
        change.stale = []

    def clear(self) -> None:
        """Drop every hold and pending impulse."""
        with self._lock:
            self.holds.clear()
            self.pending_impulses.clear()

    def snapshot(self) -> tuple[dict, dict, int, Counter]:
        """Copies of (holds as (force, torque), pending impulses, accepted count, rejected counts)."""
        with self._lock:
            holds = {key: (h.force.copy(), h.torque.copy()) for key, h in self.holds.items()}
            pending = {key: (j.copy(), h.copy()) for key, (j, h) in self.pending_impulses.items()}
            return holds, pending, self.accepted, Counter(self.rejected)

    # ------------------------------------------------------------------ callbacks

    def _parse(self, body: str | None, msg: WrenchStamped,
               topic: str) -> tuple[str, str, np.ndarray, np.ndarray] | None:
        """(body, core frame, force, torque) of a valid message, or None after counting and warning.
        ``body`` None: a shared topic's message, whose body is the one header.frame_id is a frame of."""
        shared = body is None
        try:
            if shared:
                body, frame = self.shared_frames.get(msg.header.frame_id, (None, None))
            else:
                inputs = self.bodies.get(body)
                frame = inputs.frames.get(msg.header.frame_id) if inputs is not None else None
            if frame is None:
                raise RejectedMessage("unknown_frame", "")  # detail built only if it is logged
            force, torque = wrench_from_msg(msg)
        except RejectedMessage as rejection:
            self._reject(None if shared else body, topic, msg, rejection)
            return None
        self.accepted += 1
        return body, frame, force, torque

    def _reject(self, body: str | None, topic: str, msg: WrenchStamped | None, rejection: RejectedMessage) -> None:
        """Count a dropped message by reason (the lock held); warn at most once per REJECTION_WARNING_PERIOD wall
        seconds (rclpy's own throttle inspects the caller's source on every call: ~0.4 ms, which a
        flood of bad messages would turn into a denial of service)."""
        self.rejected[rejection.reason] += 1
        self._rejections_since_warning += 1
        wall = time.monotonic()
        if wall - self._warned_wall < REJECTION_WARNING_PERIOD:
            return
        more = self._rejections_since_warning - 1
        more = f" ({more} more dropped since the last warning; counts by reason on /diagnostics)" if more else ""
        if body is None:  # a shared topic's message
            detail = rejection.detail or (
                f"frame_id {msg.header.frame_id[:80]!r} is no body's frame (valid: {self._prefix}B, "
                f"{self._prefix}B/world_aligned or {self._prefix}B/<site> of a body B; the world frame names "
                f"no body: for world axes use B/world_aligned, or B/{topic})")
            self._node.get_logger().warning(f"dropped a message on {topic} ({rejection.reason}): {detail}" + more)
        else:
            inputs = self.bodies.get(body)
            valid_frames = list(inputs.frames) if inputs is not None else []
            detail = rejection.detail or f"frame_id {msg.header.frame_id[:80]!r} is not one of {valid_frames}"
            self._node.get_logger().warning(
                f"dropped a message on {body}/{topic} ({rejection.reason}): {detail}; valid frame_ids: {valid_frames}"
                + more)
        self._warned_wall = wall
        self._rejections_since_warning = 0

    def on_wrench(self, body: str | None, msg: WrenchStamped) -> None:
        """``B/wrench`` (``body`` None: ``wrench``): hold it per (body, frame), or clear the hold if all-zero."""
        with self._lock:
            parsed = self._parse(body, msg, "wrench")
            if parsed is None:
                return
            body, frame, force, torque = parsed
            if not force.any() and not torque.any():
                self.holds.pop((body, frame), None)
            else:
                self.holds[(body, frame)] = _Hold(force, torque)

    def on_impulse(self, body: str | None, msg: WrenchStamped) -> None:
        """``B/impulse`` (``body`` None: ``impulse``): add it to what is due at the next step in its (body, frame)."""
        with self._lock:
            parsed = self._parse(body, msg, "impulse")
            if parsed is None:
                return
            body, frame, linear, angular = parsed
            pending = self.pending_impulses.get((body, frame))
            if pending is not None:  # impulses due at the same step add
                linear, angular = pending[0] + linear, pending[1] + angular
            self.pending_impulses[(body, frame)] = (linear, angular)

    def count_rejection(self, body: str | None, topic: str, rejection: RejectedMessage) -> None:
        """Count (and warn about, throttled) a message dropped by another input of the node (``set_state``)."""
        with self._lock:
            self._reject(body, topic, None, rejection)

    def count_accepted(self) -> None:
        """Count a message accepted by another input of the node (``set_state``)."""
        with self._lock:
            self.accepted += 1

    # ------------------------------------------------------------------ per tick

    def apply(self, sim: Simulator, wrench_timeout: float) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
        """Expire old holds, then hand the pending impulses and the held wrenches to ``sim`` for
        its next step; returns the holds applied as (body, core frame, force, torque). An impulse
        that would make a body's velocity non-finite is dropped and counted as ``non_finite_result``."""
        with self._lock:
            return self._apply(sim, wrench_timeout)

    def _apply(self, sim: Simulator, wrench_timeout: float) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
        now = sim.time
        for hold in self.holds.values():
            if hold.first_time is None:
                hold.first_time = now
        if wrench_timeout > 0.0:
            expired = [key for key, hold in self.holds.items() if now - hold.first_time >= wrench_timeout]
            for key in expired:
                del self.holds[key]
        stopped = set(sim.stopped_bodies)
        for (body, frame), (linear, angular) in self.pending_impulses.items():
            if body in stopped:
                continue
            try:
                sim.apply_impulse(body, linear, angular, frame)
            except ValueError as exc:
                self._reject(body, "impulse", None, RejectedMessage("non_finite_result", str(exc)))
        self.pending_impulses.clear()
        for (body, frame), hold in self.holds.items():
            sim.apply_wrench(body, hold.force, hold.torque, frame)
        return [(body, frame, hold.force, hold.torque) for (body, frame), hold in self.holds.items()]
