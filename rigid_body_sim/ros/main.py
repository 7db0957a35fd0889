"""Console entry point ``rigid_body_sim_node``: start the node, spin it, stop it cleanly on a signal.

Exit status: 0 after SIGINT or SIGTERM at any moment, 2 for bad start-up parameters or scene
(the reason on stderr), 1 if the tick thread fails (said on the log and /diagnostics) or if the
orderly stop takes longer than :data:`STOP_GRACE_S` (a step that cannot be cut short: the
recording is then finished after the write under way).

Signals come in two phases (:mod:`rigid_body_sim.signals`; rclpy installs no handler of its
own). Until the recording opens and the ticks start, nothing is worth saving: a signal ends the
process at once with status 0 and one line on stderr. From then on a signal sets a flag and
cancels the step under way (``Simulator.cancel``: a long tick or ``~/step_ticks`` ends at its next
substep and publishes the state it reached); the spin loop sees the flag within
:data:`SPIN_TIMEOUT_S` and stops in order: executor, tick thread, recording (after its last
write), node, context. Module level imports only the standard library, so the handlers are in
place before the heavy imports begin.
"""

from __future__ import annotations

import gc
import sys
import time
from typing import Any

from ..signals import TwoPhaseSignals, Watchdog, exit_now
from .access import prepare_access

__all__ = ["main", "SPIN_TIMEOUT_S", "STOP_GRACE_S"]

#: Longest wait of one ``spin_once``: how soon a stop request is seen while spinning.
SPIN_TIMEOUT_S = 0.1
#: Longest wait (s) for the orderly stop after a stop request (launch escalates to SIGTERM after 5 s).
STOP_GRACE_S = 5.0
#: Above this many publishers and subscriptions, a stop by signal exits once the ticks are stopped and
#: the recording finished, without destroying each endpoint (``destroy_node`` grows faster than their
#: number: 0.22 s for 2,406, 17 s for 30,006); peers drop them when the lease expires, as after a crash.
FAST_EXIT_ENDPOINTS = 2500
COLD_COMPILE_S = (60, 150)  #: what a cold start costs, said before it begins (90-120 s seen under load)


def main(args: list[str] | None = None) -> int:
    """Run the node until SIGINT or SIGTERM; return the exit status (see the module docstring)."""
    signals = TwoPhaseSignals("rigid_body_sim_node")  # phase 1: a signal exits 0 at once
    if (refused := prepare_access(args)) is not None:  # discovery range, ROS security (access.py)
        return refused
    import rclpy
    from rclpy.exceptions import ParameterException
    from rclpy.executors import ExternalShutdownException
    from rclpy.experimental import EventsExecutor
    from rclpy.signals import SignalHandlerOptions

    from ..core import SceneError
    from .node import RigidBodySimNode

    _compile_if_cold()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = RigidBodySimNode(start_ticking=False)
    except (SceneError, ValueError, ParameterException) as exc:
        _say(str(exc))
        rclpy.try_shutdown()
        return 2
    executor = EventsExecutor()
    executor.add_node(node)
    gc.collect()  # what start-up made stays for good: a full collection of it stalled the ticks ~90 ms
    gc.freeze()
    watchdog = Watchdog(STOP_GRACE_S, lambda: _give_up(node))

    def on_signal() -> None:  # phase 2: a signal sets `stop`, cancels the step under way, arms the watchdog
        node.session.request_stop()  # no lock: also from the signal watch thread, the main thread in a step
        watchdog.start()

    stop = signals.switch_to_orderly(on_first=on_signal, on_seen=on_signal)
    status = 0
    try:
        try:
            node.start_ticking()  # opens the recording
        except ValueError as exc:  # record_path cannot be written
            _say(str(exc))
            return 2
        while not stop.is_set() and rclpy.ok():
            executor.spin_once(timeout_sec=SPIN_TIMEOUT_S)
    except ExternalShutdownException:
        pass
    except Exception as exc:  # the tick thread failed (re-raised by the executor)
        if node.tick_failure is None:
            raise
        _say(f"exiting with status 1: the tick thread failed ({exc!r})")
        status = 1
    finally:
        watchdog.start()
        endpoints = sum(1 for _ in node.publishers) + sum(1 for _ in node.subscriptions)
        if stop.is_set() and endpoints > FAST_EXIT_ENDPOINTS:
            node.stop_ticking_and_recording()
            _say(f"stopped; exiting without destroying {endpoints} endpoints one by one (slow at this count); "
                 "DDS peers drop them when the lease expires")
            sys.stdout.flush()
            exit_now(0)
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()  # stops the tick thread, finishes the recording
        rclpy.try_shutdown()
        watchdog.cancel()
    return status


def _say(message: str) -> None:
    print(f"rigid_body_sim_node: {message}", file=sys.stderr, flush=True)


def _give_up(node: Any) -> None:
    """The watchdog expired: say why and finish the recording without the node's lock (then exit 1)."""
    running = node.tick_running_for()
    _say(f"did not stop within {STOP_GRACE_S:g} s"
         + (f": a tick has been running for {running:.1f} s" if running is not None else "")
         + "; finishing the recording and exiting with status 1")
    node.finish_recording_now()


def _compile_if_cold() -> None:
    """With no compiled kernels in numba's cache (first start after an install or a change of the
    core), say so and compile them here, in start-up (phase 1: a signal stops it at once), rather
    than inside the first tick, which would hold the tick thread, and a stop, for a minute."""
    if _kernels_cached():
        return
    from ..core.simulator import compile_kernels

    low, high = COLD_COMPILE_S
    _say(f"first start: numba's cache is empty, compiling the simulator kernels now (about {low}-{high} s, "
         "once; later starts take about 2 s)")
    start = time.monotonic()
    compile_kernels()
    _say(f"kernels compiled in {time.monotonic() - start:.0f} s")


def _kernels_cached() -> bool:
    """True if numba's cache holds every compiled kernel of these sources (kernels/jit.py marks it
    once they were all compiled), or if the cache is not ours to fill (a read-only install)."""
    from ..core.kernels.jit import cache_complete

    return cache_complete()


if __name__ == "__main__":
    sys.exit(main())
