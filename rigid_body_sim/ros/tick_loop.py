"""The node's ticks: one thread that calls the tick on a deadline schedule, and says so loudly if it dies.

Tick k is due at start + k · period on the steady clock (:func:`time.monotonic_ns`, which is
``CLOCK_MONOTONIC``). A tick that runs late is caught up at once, so sim time keeps pace with
wall time while the ticks keep up on average; a tick later than :data:`CATCH_UP_LIMIT_S` (and
than one period) skips the periods it missed, which are counted, as an rcl timer would.

Why a thread and not an rclpy timer: rclpy's SingleThreadedExecutor rebuilds its wait set over
every entity each time it wakes (milliseconds with hundreds of per-body subscriptions), which a
timer in that executor would pay on every tick (``rigid_body_sim_node`` now spins the
EventsExecutor, which does not, but the launch-free harness may spin either; a thread also keeps
the deadline schedule independent of the executor's callbacks). The executor keeps the
subscriptions, services, parameters and /diagnostics; the session's lock guards what both threads touch.

This is the only tick path: ``rigid_body_sim_node`` and the launch-free harness
(:mod:`rigid_body_sim.testing`) both tick through it.
"""

from __future__ import annotations

import threading
import time
from typing import Callable, ContextManager

__all__ = ["CATCH_UP_LIMIT_S", "TickLoop"]

#: A tick running later than this (and later than one period) skips the periods it missed, as
#: an rcl timer does; a tick less late is caught up at once, so sim time keeps pace with wall
#: time through short stalls (a GIL hand-over, a scheduling delay).
CATCH_UP_LIMIT_S = 0.05


class TickLoop:
    """Calls ``tick(due_ns, period_ns, missed)`` from its own thread, holding ``lock``.

    Parameters
    ----------
    name : str
        Thread name.
    period_ns : callable
        Returns the current tick period in ns (read at start and after :meth:`retime`).
    tick : callable
        ``tick(due_ns, period_ns, missed)``: one tick, due at ``due_ns`` (steady clock), with
        ``missed`` periods skipped before it. Called with ``lock`` held.
    lock : context manager
        Held around each tick: the session's lock as ticks take it (``session.lock.ticks``, which
        first lets in every caller already waiting, so back-to-back ticks cannot keep them out).
    on_failure : callable
        Called once, from the thread, with the exception if ``tick`` raises; the thread then
        ends. Never called for an exception raised after :meth:`stop`.
    """

    def __init__(self, name: str, period_ns: Callable[[], int], tick: Callable[[int, int, int], None],
                 lock: ContextManager[object], on_failure: Callable[[BaseException], None]):
        self._period_ns = period_ns
        self._tick = tick
        self._lock = lock
        self._on_failure = on_failure
        self._stop = threading.Event()
        self._retime = threading.Event()
        self._wake = threading.Event()
        self.failure: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> None:
        """Start ticking; the first tick is due one period from now."""
        self._retime.set()
        self._thread.start()

    @property
    def started(self) -> bool:
        """True once :meth:`start` was called (a thread starts once)."""
        return self._thread.ident is not None

    @property
    def alive(self) -> bool:
        """True while the thread runs."""
        return self._thread.is_alive()

    def retime(self) -> None:
        """Restart the schedule from now with the current period (a new ``rate_hz``)."""
        self._retime.set()
        self._wake.set()

    def stop(self) -> None:
        """Stop the thread and wait for it (a tick under way finishes first). Safe to call twice."""
        self._stop.set()
        self._wake.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join()

    def _run(self) -> None:
        due_ns = period_ns = 0
        while not self._stop.is_set():
            self._wake.clear()
            if self._retime.is_set():  # start, or a new period: the schedule restarts now
                self._retime.clear()
                period_ns = max(1, self._period_ns())
                due_ns = time.monotonic_ns() + period_ns
            now_ns = time.monotonic_ns()
            if now_ns < due_ns:
                self._wake.wait((due_ns - now_ns) * 1e-9)
                continue
            lateness_ns = now_ns - due_ns
            missed = 0
            if lateness_ns >= period_ns and lateness_ns > CATCH_UP_LIMIT_S * 1e9:
                missed = lateness_ns // period_ns
            try:
                with self._lock:
                    if self._retime.is_set() or self._stop.is_set():
                        continue
                    self._tick(due_ns, period_ns, missed)
            except BaseException as exc:  # noqa: BLE001  (reported through on_failure)
                if self._stop.is_set():
                    return  # shutting down: publishers may already be invalid
                self.failure = exc
                self._on_failure(exc)
                return
            due_ns += (missed + 1) * period_ns
