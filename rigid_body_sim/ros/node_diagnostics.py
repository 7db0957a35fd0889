"""The node's ``/diagnostics``: the report window, its timer, and a report that never waits long for a tick.

A report covers the window since the one before (tick count and lateness, sim time advanced,
messages accepted and rejected; diagnostics.py builds it); making it opens the next window, and so
do a reset, a new scene and a new ``rate_hz``. The timer runs every ``diagnostics_period`` wall
seconds on the steady clock. A tick that keeps the session's lock longer than the report may wait
gives a report that says so (WARN; ERROR after :data:`STUCK_TICK_S`) instead, and one more report is
sent when that tick reaches :data:`STUCK_TICK_S`, so the ERROR comes then, not up to a period later.
The kernels release the GIL while they step, so the executor publishes these during the tick.
"""

from __future__ import annotations

import math
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.clock import Clock
from rclpy.node import Node
from rclpy.qos import QoSProfile

from .contacts import ContactPublisher
from .diagnostics import TickWindow, busy_status, diagnostic_statuses
from .inputs import WrenchInputs
from .session import SessionBusy, SimSession

__all__ = ["DIAGNOSTICS_WAIT_S", "STUCK_TICK_S", "NodeDiagnostics"]

#: Longest wait (s) of a /diagnostics report for a tick under way; then it reports the tick instead.
DIAGNOSTICS_WAIT_S = 0.1
#: A tick running longer than this (s) is reported as ERROR on /diagnostics (else WARN).
STUCK_TICK_S = 5.0


class NodeDiagnostics:
    """``/diagnostics`` of ``node`` over ``session``, counting the messages of ``inputs``.

    Parameters
    ----------
    node : rclpy.node.Node
        Owner of the publisher and the timer.
    session : SimSession
        Whose simulator, settings and fault are reported.
    inputs : WrenchInputs
        Whose accepted and rejected counts are reported.
    qos : QoSProfile
        Of the /diagnostics publisher.
    clock : rclpy.clock.Clock
        The steady clock the timer runs on.
    contacts : ContactPublisher, optional
        Whose contact counts (contacts.py) are reported, as ``<node>: contact``, when the scene has contact.
    """

    def __init__(self, node: Node, session: SimSession, inputs: WrenchInputs, qos: QoSProfile, clock: Clock,
                 contacts: ContactPublisher | None = None):
        self._node = node
        self._session = session
        self._inputs = inputs
        self._contacts = contacts
        self._clock = clock
        self.window = TickWindow(session.simulator.time)
        self.open_window()
        self._publisher = node.create_publisher(DiagnosticArray, "/diagnostics", qos)
        self._timer: Any = None
        self._stuck_timer: Any = None  # one report when a running tick reaches STUCK_TICK_S

    def set_period(self, period: float) -> None:
        """(Re)start the timer at ``period`` wall seconds; 0 stops it. Opens a new window."""
        if self._timer is not None:
            self._node.destroy_timer(self._timer)
            self._timer = None
        if period > 0.0:
            self._timer = self._node.create_timer(period, self.publish, clock=self._clock)
        with self._session.lock:
            self.open_window()

    def open_window(self) -> None:
        """Start a new report window at the current sim time (hold the session's lock)."""
        self.window.reopen(self._session.simulator.time)
        _, _, self._accepted_at_open, self._rejected_at_open = self._inputs.snapshot()
        if self._contacts is not None:
            self._contacts.open_window()

    def report(self, wait_s: float | None = None) -> DiagnosticArray:
        """The DiagnosticArray for the window since the last one; opens a new window. With ``wait_s``,
        a tick that keeps the session longer than that gives a report that says so instead."""
        array = DiagnosticArray()
        array.header.stamp = self._node.get_clock().now().to_msg()
        name, session = self._node.get_name(), self._session
        try:
            with session.busy_or_locked(math.inf if wait_s is None else wait_s, holder="a /diagnostics report"):
                sim, settings = session.simulator, session.settings
                holds, pending, accepted, rejected = self._inputs.snapshot()
                array.status = diagnostic_statuses(
                    node_name=name, window=self.window, sim_time=sim.time, paused=settings["paused"],
                    integrator=sim.integrator, dt=sim.dt, substeps=settings["substeps"], rate_hz=settings["rate_hz"],
                    real_time_factor=settings["real_time_factor"], bodies=sim.body_names, stopped=sim.stopped_bodies,
                    held_wrenches=len(holds), pending_impulses=len(pending), accepted_total=accepted,
                    accepted_at_open=self._accepted_at_open, rejected_total=rejected,
                    rejected_at_open=self._rejected_at_open, fault=session.fault)
                contact = self._contacts.status(name, sim) if self._contacts is not None else None
                if contact is not None:
                    array.status.append(contact)
                self.open_window()
        except SessionBusy as busy:
            running = session.tick_running_for()
            array.status = [busy_status(node_name=name, message=str(busy), busy_for_s=running,
                                        error=running is not None and running > STUCK_TICK_S)]
        return array

    def publish(self) -> None:
        """Publish :meth:`report` on /diagnostics (the timer calls this); never waits long for a tick.
        A tick found running, not yet for :data:`STUCK_TICK_S`, gets one more report when it will have."""
        self._publisher.publish(self.report(wait_s=DIAGNOSTICS_WAIT_S))
        running = self._session.tick_running_for()
        armed = self._stuck_timer is not None and not self._stuck_timer.is_canceled()
        if not armed and running is not None and DIAGNOSTICS_WAIT_S <= running <= STUCK_TICK_S:
            if self._stuck_timer is not None:  # the spent one (not destroyed inside its own callback)
                self._node.destroy_timer(self._stuck_timer)
            self._stuck_timer = self._node.create_timer(STUCK_TICK_S - running + 0.01, self._publish_stuck,
                                                        clock=self._clock)

    def _publish_stuck(self) -> None:
        self._stuck_timer.cancel()  # once
        running = self._session.tick_running_for()
        if running is not None and running > STUCK_TICK_S:  # the same tick, or another as long: report it now
            self._publisher.publish(self.report(wait_s=DIAGNOSTICS_WAIT_S))
