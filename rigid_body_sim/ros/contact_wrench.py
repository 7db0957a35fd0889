"""``B/contact_wrench`` (geometry_msgs/WrenchStamped): the contacts' wrench on each body over a tick.

Optional (parameter ``publish_contact_wrench``, off by default). With it, and a scene with
contact (``Simulator.contact`` is a ContactSolver), every body B with a collision shape has a
publisher ``B/contact_wrench``, and after every tick it carries the **mean contact wrench over
the tick**: (Σ holding force × step + Σ impact impulses + Σ island contact impulses, the bodies
it rests on or that rest on it included) / the tick's length for the force,
likewise the torque about B's centre of mass; world axes, ``header.frame_id`` = ``B/world_aligned``
(the centre of mass with world axes, as in /tf; ``frame_prefix`` applied), ``header.stamp`` =
sim time at the end of the tick. Gravity and the applied wrenches are not in it; a body in
flight reads zero. The holding force and torque of a step are those found at its start (held
over the step, or standing for its mean with the methods that find the force at every stage:
core/contact/solver.py). It starts with the first tick that begins after the
parameter is set, and follows spawns, deletes, resets and new scenes.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.qos import QoSProfile

from ..core import Simulator
from .conversions import time_msg_from_seconds
from .replaceable import create_replaceable_publisher

__all__ = ["ContactWrenchPublishers", "contact_impulses"]


def contact_impulses(solver: Any) -> np.ndarray:
    """(N, 6) per body of the solver's simulator: Σ contact impulse (N·s) and angular impulse about the
    centre of mass (N·m·s), world axes, since the solver was made or reset (holding forces and impacts)."""
    out = solver.impact_impulses.copy()
    out[:, 0:3] += solver.holding_impulses
    out[:, 3:6] += solver.holding_angular_impulses
    if solver.pairs is not None:  # bodies resting on bodies (islands)
        out += solver.pairs.islands.impulses
    return out


class ContactWrenchPublishers:
    """The ``B/contact_wrench`` publishers of ``node`` (the session's lock held for every call).

    Parameters
    ----------
    node : rclpy.node.Node
    qos : QoSProfile
    prefix : str
        The node's ``frame_prefix``.
    enabled : bool
        ``publish_contact_wrench`` at start-up.
    """

    def __init__(self, node: Node, qos: QoSProfile, prefix: str, enabled: bool):
        self._node = node
        self._qos = qos
        self._prefix = prefix
        self.enabled = enabled
        self.publishers: dict[str, Any] = {}  # body name → publisher
        self._start: tuple[Any, float, np.ndarray] | None = None  # (solver, sim time, contact_impulses) at tick start
        self._msg = WrenchStamped()

    def before_tick(self, sim: Simulator) -> None:
        """Remember where the coming tick starts (and have the solver keep the holding torques)."""
        solver = sim.contact
        if not self.enabled or solver is None:
            self._start = None
            return
        solver.track_torques = True
        self._start = (solver, sim.time, contact_impulses(solver))

    def publish(self, sim: Simulator, enabled: bool) -> int:
        """After the tick: publish each body's mean contact wrench over it; ``enabled`` is the parameter
        now (a change takes effect from the next tick). Returns the messages published."""
        start, self._start = self._start, None
        self.enabled = enabled
        solver = sim.contact
        if not enabled or solver is None:
            self._sync(())
            return 0
        names = [sim.body_names[i] for i in solver.bodies.tolist()]
        self._sync(names)
        if start is None or start[0] is not solver or not sim.time > start[1]:
            return 0  # no start of this tick seen (just enabled, or nothing stepped)
        span = sim.time - start[1]
        mean = (contact_impulses(solver) - start[2]) / span
        msg = self._msg
        msg.header.stamp = time_msg_from_seconds(sim.time)
        stopped = set(sim.stopped_bodies)
        published = 0
        for i, name in zip(solver.bodies.tolist(), names):
            if name in stopped:
                continue
            msg.header.frame_id = f"{self._prefix}{name}/world_aligned"
            f, t = msg.wrench.force, msg.wrench.torque
            f.x, f.y, f.z, t.x, t.y, t.z = (float(v) for v in mean[i])
            self.publishers[name].publish(msg)
            published += 1
        return published

    def _sync(self, names: Any) -> None:
        """Publishers for exactly ``names`` (created and destroyed as bodies come and go)."""
        wanted = set(names)
        for name in [n for n in self.publishers if n not in wanted]:
            self._node.destroy_publisher(self.publishers.pop(name))
        for name in names:
            if name not in self.publishers:
                self.publishers[name] = create_replaceable_publisher(
                    self._node, WrenchStamped, f"{name}/contact_wrench", self._qos)
