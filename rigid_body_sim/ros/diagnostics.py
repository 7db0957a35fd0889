"""The node's health on ``/diagnostics``: tick timing over a window, rejected input, blow-ups.

:class:`TickWindow` collects, between two reports, how late each tick ran against the tick
thread's ideal schedule (the time each tick was due on the steady clock, ``CLOCK_MONOTONIC``, the
clock of :func:`time.monotonic_ns`) and how far sim time advanced. The first window opens at the
first tick, not when the node was built: start-up time is no tick the node failed to run.
:func:`diagnostic_statuses` turns a window and the node's counters into two
diagnostic_msgs/DiagnosticStatus entries, named as ``diagnostic_updater`` names them
("<node name>: <task>"), with ``hardware_id`` ``"none"`` (the value diagnostic_updater asks
software without hardware to use):

``<node>: simulation``
    ERROR when the simulation cannot go on (the tick thread failed, or sim time reached the
    end of ROS time) or a body is stopped for blow-up, WARN when the timer ticked at less than
    :data:`BEHIND_FRACTION` of ``rate_hz`` over the window while running, OK otherwise.
``<node>: input``
    WARN when messages were rejected during the window, OK otherwise; counts by reason, for
    the window and since start.
"""

from __future__ import annotations

import math
import time
from collections import Counter, deque
from typing import Mapping, Sequence

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

__all__ = [
    "BEHIND_FRACTION",
    "LATENESS_SAMPLES",
    "REJECTION_REASONS",
    "TickWindow",
    "busy_status",
    "diagnostic_statuses",
    "level_name",
    "status_values",
]

#: Every reason an incoming wrench or impulse can be dropped for (``node.rejected`` keys):
#: ``unknown_frame`` (header.frame_id is not one of the body's frames; checked first),
#: ``non_finite`` (a NaN or ±Inf component), ``too_large`` (a component above
#: conversions.MAX_WRENCH_COMPONENT in magnitude), ``non_finite_result`` (an impulse that would
#: make the body's velocity non-finite; dropped at the step it was due), ``non_unit_quaternion``
#: (a set_state pose whose orientation is not a unit quaternion; set_state.py), ``into_ground`` (a
#: set_state that would put a body's collision shape into a ground half-space or a static shape;
#: contacts.py).
REJECTION_REASONS = ("unknown_frame", "non_finite", "too_large", "non_finite_result", "non_unit_quaternion",
                     "into_ground")
#: The simulation status is WARN when, while running, the timer ticked at less than this
#: fraction of ``rate_hz`` over the window.
BEHIND_FRACTION = 0.9
#: Lateness samples kept per window for the median (the maximum is exact over the window).
LATENESS_SAMPLES = 10_000


class TickWindow:
    """Timer ticks since the window opened: count, lateness (median, max) and sim time advanced.

    Parameters
    ----------
    sim_time : float
        Sim time (s) when the window opens.
    """

    def __init__(self, sim_time: float):
        self._lateness_ns: deque[int] = deque(maxlen=LATENESS_SAMPLES)
        self.reopen(sim_time)

    #: True until the first tick is recorded: the window then opens at that tick's due time.
    awaiting_first_tick = True

    def reopen(self, sim_time: float) -> None:
        """Start a new window now (wall, steady clock) at ``sim_time``; before the first tick, the
        window opens at the first tick's due time instead (see :meth:`record`)."""
        self.opened_ns = time.monotonic_ns()
        self.sim_time_at_open = sim_time
        self.ticks = 0
        self.missed_ticks = 0
        self.max_lateness_ns = 0
        self._lateness_ns.clear()

    def record(self, expected_ns: int, period_ns: int, missed: int | None = None) -> None:
        """One timer tick that was due at ``expected_ns`` (steady clock) and is running now.

        ``missed_ticks`` counts the periods skipped because the tick was that late: ``missed``
        when the caller knows it (the node's tick thread catches short delays up and skips
        only beyond a limit), otherwise as rcl's timer does, every whole period of lateness.
        """
        now_ns = time.monotonic_ns()
        if self.awaiting_first_tick:
            self.awaiting_first_tick = False
            self.opened_ns = min(expected_ns, now_ns)
        lateness = max(0, now_ns - expected_ns)
        self.ticks += 1
        self._lateness_ns.append(lateness)
        if lateness > self.max_lateness_ns:
            self.max_lateness_ns = lateness
        if missed is not None:
            self.missed_ticks += missed
        elif period_ns > 0:
            self.missed_ticks += lateness // period_ns

    def elapsed_s(self) -> float:
        """Wall seconds (steady clock) since the window opened (0 before the first tick)."""
        if self.awaiting_first_tick:
            return 0.0
        return (time.monotonic_ns() - self.opened_ns) * 1e-9

    def median_lateness_ns(self) -> float:
        """Median lateness of the last :data:`LATENESS_SAMPLES` ticks of the window, ns (NaN if none)."""
        if not self._lateness_ns:
            return math.nan
        ordered = sorted(self._lateness_ns)
        mid = len(ordered) // 2
        return float(ordered[mid]) if len(ordered) % 2 else 0.5 * (ordered[mid - 1] + ordered[mid])

    def p99_lateness_ns(self) -> float:
        """99th percentile (nearest rank) of the lateness of the last :data:`LATENESS_SAMPLES`
        ticks of the window, ns (NaN if none)."""
        if not self._lateness_ns:
            return math.nan
        ordered = sorted(self._lateness_ns)
        return float(ordered[max(0, math.ceil(0.99 * len(ordered)) - 1)])


def _kv(key: str, value: object) -> KeyValue:
    return KeyValue(key=key, value=str(value))


def _ms(ns: float) -> str:
    return "n/a" if math.isnan(ns) else f"{ns * 1e-6:.3f}"


def diagnostic_statuses(*, node_name: str, window: TickWindow, sim_time: float, paused: bool, integrator: str,
                        dt: float, substeps: int, rate_hz: float, real_time_factor: float, bodies: Sequence[str],
                        stopped: Sequence[str], held_wrenches: int, pending_impulses: int,
                        accepted_total: int, accepted_at_open: int, rejected_total: Mapping[str, int],
                        rejected_at_open: Mapping[str, int], fault: str | None = None) -> list[DiagnosticStatus]:
    """The node's two DiagnosticStatus entries for the window that is closing (see the module doc)."""
    elapsed = window.elapsed_s()
    tick_rate = window.ticks / elapsed if elapsed > 0.0 else math.nan
    measured_rtf = (sim_time - window.sim_time_at_open) / elapsed if elapsed > 0.0 else math.nan
    expected_ticks = elapsed * rate_hz
    behind = (not paused and expected_ticks >= 2.0 and window.ticks < BEHIND_FRACTION * expected_ticks)

    sim = DiagnosticStatus(name=f"{node_name}: simulation", hardware_id="none")
    if fault:
        sim.level = DiagnosticStatus.ERROR
        sim.message = fault
    elif stopped:
        sim.level = DiagnosticStatus.ERROR
        sim.message = f"stopped for blow-up: {', '.join(stopped)}"
    elif behind:
        sim.level = DiagnosticStatus.WARN
        sim.message = f"behind: {tick_rate:.1f} ticks/s of {rate_hz:g} Hz"
    else:
        sim.level = DiagnosticStatus.OK
        sim.message = "paused" if paused else "running"
    sim.values = [
        _kv("sim time [s]", f"{sim_time:.9f}"),
        _kv("paused", paused),
        _kv("integrator", integrator),
        _kv("dt [s]", f"{dt:.9g}"),
        _kv("substeps", substeps),
        _kv("rate_hz", f"{rate_hz:g}"),
        _kv("tick rate [1/s]", f"{tick_rate:.3f}"),
        _kv("tick lateness median [ms]", _ms(window.median_lateness_ns())),
        _kv("tick lateness p99 [ms]", _ms(window.p99_lateness_ns())),
        _kv("tick lateness max [ms]", _ms(float(window.max_lateness_ns) if window.ticks else math.nan)),
        _kv("ticks missed", window.missed_ticks),
        _kv("real_time_factor", f"{real_time_factor:g}"),
        _kv("real-time factor measured", f"{measured_rtf:.4f}"),
        _kv("window [s]", f"{elapsed:.3f}"),
        _kv("bodies", len(bodies)),
        _kv("bodies stopped for blow-up", len(stopped)),
        _kv("stopped bodies", ", ".join(stopped)),
        _kv("held wrenches", held_wrenches),
        _kv("pending impulses", pending_impulses),
    ]

    rejected_window = Counter({r: rejected_total.get(r, 0) - rejected_at_open.get(r, 0) for r in REJECTION_REASONS})
    accepted_window = accepted_total - accepted_at_open
    n_rejected = sum(rejected_window.values())
    inputs = DiagnosticStatus(name=f"{node_name}: input", hardware_id="none")
    if n_rejected:
        inputs.level = DiagnosticStatus.WARN
        by_reason = ", ".join(f"{r}: {n}" for r, n in rejected_window.items() if n)
        inputs.message = f"rejected {n_rejected} of {n_rejected + accepted_window} messages ({by_reason})"
    else:
        inputs.level = DiagnosticStatus.OK
        inputs.message = f"accepted all {accepted_window} messages"
    inputs.values = [_kv("accepted (window)", accepted_window), _kv("accepted (total)", accepted_total)]
    for reason in REJECTION_REASONS:
        inputs.values.append(_kv(f"rejected {reason} (window)", rejected_window[reason]))
    for reason in REJECTION_REASONS:
        inputs.values.append(_kv(f"rejected {reason} (total)", rejected_total.get(reason, 0)))
    return [sim, inputs]


def busy_status(*, node_name: str, message: str, busy_for_s: float | None, error: bool) -> DiagnosticStatus:
    """The simulation status while a tick keeps the simulator (its figures wait for the next
    report): WARN, or ERROR when ``error`` (the tick has run far longer than a period)."""
    status = DiagnosticStatus(name=f"{node_name}: simulation", hardware_id="none")
    status.level = DiagnosticStatus.ERROR if error else DiagnosticStatus.WARN
    status.message = message
    status.values = [_kv("tick running [s]", "n/a" if busy_for_s is None else f"{busy_for_s:.3f}")]
    return status


def status_values(status: DiagnosticStatus) -> dict[str, str]:
    """``{key: value}`` of a DiagnosticStatus (for tools and tests)."""
    return {kv.key: kv.value for kv in status.values}


def level_name(status: DiagnosticStatus) -> str:
    """"OK", "WARN", "ERROR" or "STALE" for a DiagnosticStatus."""
    return {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}.get(status.level[0], "unknown")

