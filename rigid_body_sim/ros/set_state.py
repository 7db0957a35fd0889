"""``set_state`` and ``<body>/set_state`` (nav_msgs/Odometry): put a body somewhere and give it a velocity.

The shared ``set_state`` topic (one subscription for all bodies) sets the body its
``child_frame_id`` names (``B``, prefixed by ``frame_prefix``; so its twist is in body axes); the
per-body ``B/set_state`` (with per-body inputs on, the node's ``per_body_inputs``) also takes
``world_frame`` there. Both are checked by one validator (:func:`state_from_odometry`).

simulation_interfaces' SetEntityState with a standard type. The message is read as nav_msgs
defines Odometry: ``pose`` is the body frame's pose in ``header.frame_id``, which must be the
node's ``world_frame``; ``twist`` is the centre-of-mass velocity and the angular velocity in the
axes of ``child_frame_id``: the body's own name means its body axes (the new orientation's),
``world_frame`` means world axes. Covariances and the stamp are not used.

A valid message waits, whole, for the start of the next tick (the latest per body wins) and is
applied there through ``Simulator.set_body_state``, which projects it onto the body's motion
(a planar body back on its plane, a translation-only body without spin...); the tick thread
applies it also while paused (and publishes the new state), so a paused scene can be set up
and then stepped. A bad message changes nothing and is counted on ``/diagnostics`` with the
wrench inputs' counters (inputs.py), by reason: ``unknown_frame`` (header.frame_id or
child_frame_id), ``non_finite``, ``too_large`` (a component above :data:`MAX_STATE_COMPONENT`),
``non_unit_quaternion`` (| |q| − 1 | > :data:`~rigid_body_sim.core.scene.ORIENTATION_TOLERANCE`),
``non_finite_result`` (the core refused it at the tick), ``into_ground`` (the body's collision
shape would reach into a ground half-space or a static body's shape: contacts.py).

Subscriptions change in the three steps of :mod:`.publishers` (prepare, commit, release).
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any

import numpy as np
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import QoSProfile

from ..core import Simulator
from ..core.quaternion import quat_rotate, quat_wxyz_from_xyzw
from ..core.scene import ORIENTATION_TOLERANCE
from .contacts import into_ground
from .conversions import RejectedMessage
from .inputs import shared_qos
from .replaceable import create_replaceable_subscription

__all__ = ["MAX_STATE_COMPONENT", "SetStateChange", "SetStateInputs", "state_from_odometry"]

#: Largest position (m) or velocity (m/s, rad/s) component a set_state may carry.
MAX_STATE_COMPONENT = 1e12


@dataclass
class SetStateChange:
    """Prepared subscriptions: ``subscriptions`` to swap in, ``stale`` ones to destroy after."""

    subscriptions: dict[str, Any]
    stale: list[Any]
    bodies: frozenset[str] = frozenset()


def state_from_odometry(msg: Odometry, body: str, world_frame: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(position m, orientation x y z w, COM velocity m/s, angular velocity rad/s), all world frame/axes.

    Raises
    ------
    RejectedMessage
        With the reason and a detail naming what was wrong and what was expected.
    """
    if msg.header.frame_id != world_frame:
        raise RejectedMessage("unknown_frame", f"header.frame_id {msg.header.frame_id[:80]!r}: expected the world "
                                               f"frame {world_frame!r} (the pose is in the world)")
    if msg.child_frame_id not in (body, world_frame):
        raise RejectedMessage("unknown_frame", f"child_frame_id {msg.child_frame_id[:80]!r}: expected {body!r} "
                                               f"(twist in body axes) or {world_frame!r} (world axes)")
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    v, w = msg.twist.twist.linear, msg.twist.twist.angular
    values = (p.x, p.y, p.z, o.x, o.y, o.z, o.w, v.x, v.y, v.z, w.x, w.y, w.z)
    if not all(math.isfinite(x) for x in values):
        raise RejectedMessage("non_finite", f"non-finite component in pose/twist {values}")
    if max(abs(x) for x in values) > MAX_STATE_COMPONENT:
        raise RejectedMessage("too_large", f"a pose or twist component exceeds {MAX_STATE_COMPONENT:g} in magnitude")
    q = np.array(values[3:7])
    norm = math.sqrt(float(q @ q))
    if abs(norm - 1.0) > ORIENTATION_TOLERANCE:
        raise RejectedMessage("non_unit_quaternion", f"pose.orientation has |q| = {norm:.9g}; expected a unit "
                                                     f"quaternion (| |q| - 1 | <= {ORIENTATION_TOLERANCE:g})")
    q = q / norm
    v_C, w_C = np.array(values[7:10]), np.array(values[10:13])
    if msg.child_frame_id == body and msg.child_frame_id != world_frame:  # body axes of the new orientation
        q_WB = quat_wxyz_from_xyzw(q)
        v_C, w_C = quat_rotate(q_WB, v_C), quat_rotate(q_WB, w_C)
    return np.array(values[0:3]), q, v_C, w_C


class SetStateInputs:
    """The ``<body>/set_state`` subscriptions and the states waiting for the next tick.

    Parameters
    ----------
    node : rclpy.node.Node
    qos : QoSProfile
    world_frame : str
        Without the prefix.
    inputs : WrenchInputs
        Whose counters (accepted, rejected by reason; ``/diagnostics``) count these messages too.
    frame_prefix : str
        In front of the accepted frame ids (the node's ``frame_prefix``): ``header.frame_id`` must be
        the prefixed world frame, ``child_frame_id`` the prefixed body name or world frame.
    per_body : bool
        Also subscribe to ``B/set_state`` for every body B (one DDS endpoint a body).
    """

    def __init__(self, node: Node, qos: QoSProfile, world_frame: str, inputs: Any, frame_prefix: str = "", *,
                 per_body: bool = True):
        self._node = node
        self._qos = qos
        self._world_frame = frame_prefix + world_frame
        self._prefix = frame_prefix
        self._inputs = inputs
        self._lock = threading.Lock()
        self.per_body = per_body
        self.subscriptions: dict[str, Any] = {}
        self.bodies: frozenset[str] = frozenset()
        self.pending: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
        self.shared = node.create_subscription(Odometry, "set_state", lambda msg: self.on_set_state(None, msg),
                                               shared_qos(qos))

    def prepare(self, body_names: tuple[str, ...]) -> SetStateChange:
        subs = {body: self.subscriptions.get(body) or create_replaceable_subscription(
            self._node, Odometry, f"{body}/set_state", lambda msg, b=body: self.on_set_state(b, msg), self._qos)
            for body in body_names} if self.per_body else {}
        return SetStateChange(subs, [s for b, s in self.subscriptions.items() if b not in subs], frozenset(body_names))

    def commit(self, change: SetStateChange) -> None:
        """Swap in prepared subscriptions (hold the node's lock); states pending for bodies gone are dropped."""
        with self._lock:
            self.subscriptions, self.bodies = change.subscriptions, change.bodies
            self.pending = {b: s for b, s in self.pending.items() if b in self.bodies}

    def release(self, change: SetStateChange) -> None:
        for subscription in change.stale:
            self._node.destroy_subscription(subscription)
        change.stale = []

    def clear(self) -> None:
        with self._lock:
            self.pending.clear()

    def on_set_state(self, body: str | None, msg: Odometry) -> None:
        """``<body>/set_state`` (``body`` None: ``set_state``, for the body child_frame_id names):
        validate, then keep it for the next tick (replacing an earlier one)."""
        shared = body is None
        try:
            if shared:
                body = self._shared_body(msg.child_frame_id)
            state = state_from_odometry(msg, self._prefix + body, self._world_frame)
        except RejectedMessage as rejection:
            self._inputs.count_rejection(None if shared else body, "set_state", rejection)
            return
        with self._lock:
            self.pending[body] = state
        self._inputs.count_accepted()

    def _shared_body(self, child_frame_id: str) -> str:
        """The body a shared ``set_state`` names in its child_frame_id (the prefixed body name)."""
        body = child_frame_id[len(self._prefix):] if child_frame_id.startswith(self._prefix) else None
        if body not in self.bodies:
            raise RejectedMessage("unknown_frame", f"child_frame_id {child_frame_id[:80]!r}: expected a body's frame "
                                                   f"({self._prefix}B for a body B; the world frame names no body)")
        return body

    def apply(self, sim: Simulator) -> list[str]:
        """Apply the pending states to ``sim`` (at the start of a tick; hold the node's lock); the bodies set."""
        with self._lock:
            pending, self.pending = self.pending, {}
        applied = []
        for body, (p_W, q_xyzw, v_W, w_W) in pending.items():
            if body not in sim.body_names:
                continue
            refusal = into_ground(sim, body, p_W, q_xyzw)  # contacts.py: never into the static world
            if refusal is not None:
                self._inputs.count_rejection(body, "set_state", refusal)
                continue
            try:
                sim.set_body_state(body, position_world=p_W, orientation_xyzw=q_xyzw, linear_velocity_world=v_W,
                                   angular_velocity_world=w_W)
            except ValueError as exc:
                self._inputs.count_rejection(body, "set_state", RejectedMessage("non_finite_result", str(exc)))
                continue
            applied.append(body)
        return applied
