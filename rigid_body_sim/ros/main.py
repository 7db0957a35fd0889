"""Console entry point ``rigid_body_sim_node``: start the node, spin it, stop it cleanly on a signal.

Exit status: 0 after SIGINT or SIGTERM at any moment (also during start-up: imports, a cold
numba compile, loading the scene), 2 for bad start-up parameters or scene (the reason on
stderr), 1 if the tick thread fails (after saying so on the log and /diagnostics), and 1 if
the orderly stop takes longer than :data:`STOP_GRACE_S` (a tick stuck in a step that will not
end soon): then the recording is finished without waiting for the tick and the process exits.

Signals are the node's own business here, not rclpy's: ``rclpy.init`` is told to install no
handler (its handlers shut the context down underneath a spinning executor, which then fails
in the middle of building a wait set or taking a message). Until the node is built and
spinning, SIGINT and SIGTERM raise :class:`KeyboardInterrupt`, so start-up stops at once, and
whatever was built is torn down quietly (the node hands itself over as soon as it exists, so
an interrupted construction is stopped too; with thousands of endpoints, without destroying
them one by one), also when a library turned the KeyboardInterrupt into its own error (an
import of a C extension interrupted during its initialization) or when it landed where Python
drops exceptions (see :class:`_Signals`). The recording is opened and the ticks started only once a signal just sets
the flag, so a stop never leaves a recording half-opened. Once spinning, a signal only sets a flag; the spin
loop (``spin_once`` with a timeout) sees it within :data:`SPIN_TIMEOUT_S` and stops the tick
thread, finishes the recording, destroys the node and shuts the context down, in that order.

This module imports only the standard library at module level, so that the console script
reaches :func:`main`, and its signal handlers, before the heavy imports begin.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from importlib.machinery import ExtensionFileLoader
from types import FrameType
from typing import Any, Callable

from .access import prepare_access

__all__ = ["main", "SPIN_TIMEOUT_S"]

#: Longest wait of one ``spin_once``: how soon a stop request is seen while spinning.
SPIN_TIMEOUT_S = 0.1
#: Longest wait (s) for the orderly stop after a stop request, before exiting without it.
STOP_GRACE_S = 5.0
#: Delay (s) before a start-up signal that arrived in a C callback is sent again.
RETRY_SIGNAL_S = 0.02

_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class _Signals:
    """SIGINT/SIGTERM: raise KeyboardInterrupt during start-up, only set a flag once running.

    A KeyboardInterrupt raised where Python can only print and drop an exception (a finalizer
    or what it calls, a weakref or gc callback, a ctypes callback such as llvmlite's while numba
    loads its cache) would not stop start-up and would print "Exception ignored ... Traceback";
    raised in an extension module's initialization, it may be printed and replaced by another
    error. Where the frames show such a place, the signal is sent again shortly instead of
    raising; anywhere else that drops it, ``sys.unraisablehook`` sees this handler's own
    exception, says nothing, and sends the signal again, so that it lands in ordinary code.
    """

    def __init__(self) -> None:
        self.requested: int | None = None
        self.raising = True
        self.on_stop: Callable[[], None] | None = None  # called at the first signal once running
        self._raised: KeyboardInterrupt | None = None  # the exception raised at a start-up signal
        self._traced: FrameType | None = None  # the frame a raise waits in (see _raise_when_back_in)
        self._previous_trace: Any = None
        self._print_unraisable = sys.unraisablehook
        sys.unraisablehook = self._unraisable
        for signum in _STOP_SIGNALS:
            signal.signal(signum, self._handle)

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        first = self.requested is None
        if first:
            self.requested = signum
        if self.raising:
            if _swallows_exceptions(frame):
                _send_again(signum)
                return
            caller = _caller_of_torn_down_package(frame)
            if caller is not None:
                self._raise_when_back_in(caller)
                return
            self._raise()
        if first and self.on_stop is not None:
            self.on_stop()

    def _raise(self) -> None:
        self.raising = False
        self._raised = KeyboardInterrupt()
        raise self._raised

    def _raise_when_back_in(self, caller: FrameType) -> None:
        """Raise the KeyboardInterrupt in ``caller`` as soon as the call it made returns: a trace
        function on that frame alone (the documented ``frame.f_trace``, as pdb's ``set_trace``
        uses it) raises at its next line or its return; new frames are not traced. Python unsets
        the thread's trace function when it raises; :meth:`ignore` puts the previous one back
        (a debugger's, coverage's)."""

        def back_in_caller(frame: FrameType, event: str, _arg: Any) -> Any:
            if event in ("line", "return") and self.raising:
                caller.f_trace = None
                self._raise()
            return back_in_caller

        if self._traced is None:
            self._previous_trace = sys.gettrace()
        self._traced = caller
        caller.f_trace_lines = True
        caller.f_trace = back_in_caller
        sys.settrace(_trace_no_new_frames)

    @property
    def interrupted(self) -> bool:
        """True once a start-up signal has raised its KeyboardInterrupt (start-up was cut short)."""
        return self._raised is not None

    def stopped_by(self, exc: BaseException) -> bool:
        """True if start-up ended with ``exc`` because of a signal: the KeyboardInterrupt itself, or
        any error after it interrupted start-up (a library may turn it into its own error, with
        or without a chain; seen: "ImportError: initialization failed" from scipy's highspy)."""
        return isinstance(exc, KeyboardInterrupt) or self.interrupted

    def _unraisable(self, info: Any) -> None:
        """``sys.unraisablehook``: this handler's KeyboardInterrupt was dropped; raise it again soon."""
        if self._raised is not None and info.exc_value is self._raised:
            self._raised = None
            self.raising = True
            _send_again(self.requested)
            return
        self._print_unraisable(info)

    def ignore(self) -> None:
        """From now on a signal changes nothing (tear-down is under way)."""
        self.raising = False
        if self._traced is not None:
            self._traced.f_trace = None
            self._traced = None
            sys.settrace(self._previous_trace)
        for signum in _STOP_SIGNALS:
            signal.signal(signum, lambda *_: None)
        sys.unraisablehook = self._print_unraisable


def _send_again(signum: int) -> None:
    """Send ``signum`` to this process after :data:`RETRY_SIGNAL_S`, from a timer thread."""
    timer = threading.Timer(RETRY_SIGNAL_S, os.kill, (os.getpid(), signum))
    timer.daemon = True
    timer.start()


class _StopWatchdog:
    """Ends the process if the orderly stop has not finished :data:`STOP_GRACE_S` after it began.

    The main thread may be the one that waits (joining a tick thread stuck in a long step), so
    a timer thread does it: it says why, finishes the recording without the node's lock, and
    exits with status 1.
    """

    def __init__(self, node: Any) -> None:
        self._node = node
        self._timer: threading.Timer | None = None

    def start(self) -> None:
        if self._timer is None:
            self._timer = threading.Timer(STOP_GRACE_S, self._expire)
            self._timer.daemon = True
            self._timer.start()

    def cancel(self) -> None:
        if self._timer is not None:
            self._timer.cancel()

    def _expire(self) -> None:
        running = self._node.tick_running_for()
        _say(f"did not stop within {STOP_GRACE_S:g} s"
             + (f": a tick has been running for {running:.1f} s" if running is not None else "")
             + "; finishing the recording and exiting with status 1")
        try:
            self._node.finish_recording_now()
        finally:
            os._exit(1)


#: Code of the import steps that run an extension module's initialization (C code that may call
#: Python and then print or replace an exception instead of passing it on).
_EXTENSION_INIT_CODE = (ExtensionFileLoader.create_module.__code__, ExtensionFileLoader.exec_module.__code__)

#: Packages whose state the tear-down relies on: a KeyboardInterrupt inside one of their calls
#: could leave it half-updated (seen: rclpy's create_subscription interrupted after listing the
#: subscription but before its event handlers, so destroy_node failed with "list.remove(x): x
#: not in list"); a start-up signal there is raised once the call has returned.
_TORN_DOWN_WITH = ("rclpy",)


def _swallows_exceptions(frame: FrameType | None) -> bool:
    """True if a KeyboardInterrupt raised in ``frame`` may not propagate as raised: in llvmlite, or
    in anything called from its ctypes callbacks (numba's object-cache hooks), from a finalizer
    or from an extension module's initialization (numba's ``_dispatcher`` prints a
    KeyboardInterrupt and raises "ImportError: numba._devicearray failed to import" instead).
    Other places that drop exceptions (weakref and gc callbacks, other ctypes callbacks) do not
    show in the frames: :meth:`_Signals._unraisable` catches those."""
    innermost = True
    while frame is not None:
        code = frame.f_code
        if code.co_name == "__del__" or code.co_name.startswith("_raw_object_cache_") or code in _EXTENSION_INIT_CODE:
            return True
        if innermost and "llvmlite" in code.co_filename:
            return True
        innermost = False
        frame = frame.f_back
    return False


def _caller_of_torn_down_package(frame: FrameType | None) -> FrameType | None:
    """The frame that made the outermost call into a :data:`_TORN_DOWN_WITH` package under way in
    ``frame``'s stack, or None if no such call is under way."""
    package_dirs = tuple(os.path.dirname(module.__file__) + os.sep for module in map(sys.modules.get, _TORN_DOWN_WITH)
                         if getattr(module, "__file__", None))
    caller = None
    while frame is not None:
        if package_dirs and frame.f_code.co_filename.startswith(package_dirs):
            caller = frame.f_back
        frame = frame.f_back
    return caller


def _trace_no_new_frames(_frame: FrameType, _event: str, _arg: Any) -> None:
    """Global trace function while a raise waits for a call to return: trace no new frame."""
    return None


def _say(message: str) -> None:
    print(f"rigid_body_sim_node: {message}", file=sys.stderr, flush=True)


def main(args: list[str] | None = None) -> int:
    """Run the node until SIGINT or SIGTERM; return the exit status (see the module docstring)."""
    signals = _Signals()
    context = node = executor = watchdog = None
    built: list[Any] = []  # the node as soon as it exists, also if a signal interrupts its construction
    try:
        if (refused := prepare_access(args)) is not None: return refused  # discovery range, ROS security: access.py
        import rclpy
        from rclpy.exceptions import ParameterException
        from rclpy.executors import ExternalShutdownException
        from rclpy.experimental import EventsExecutor
        from rclpy.signals import SignalHandlerOptions

        from ..core import SceneError
        from .node import RigidBodySimNode

        _compile_if_cold()
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        context = rclpy.get_default_context()
        try:
            node = RigidBodySimNode(start_ticking=False, on_created=built.append)
        except (SceneError, ValueError, ParameterException) as exc:
            if signals.stopped_by(exc):
                return 0
            _say(str(exc))
            return 2
        executor = EventsExecutor()
        executor.add_node(node)
        _freeze_start_up_objects()
        watchdog = _StopWatchdog(node)
        signals.on_stop = watchdog.start
        signals.raising = False
        if signals.requested is not None:
            return 0
        try:
            node.start_ticking()
        except ValueError as exc:  # record_path cannot be written
            _say(str(exc))
            return 2
        try:
            while signals.requested is None and context.ok():
                executor.spin_once(timeout_sec=SPIN_TIMEOUT_S)
        except ExternalShutdownException:
            pass
        except Exception as exc:  # noqa: BLE001  (a failure of the tick thread, re-raised by the executor)
            if node.tick_failure is None:
                raise
            _say(f"exiting with status 1: the tick thread failed ({exc!r})")
            return 1
        return 0
    except BaseException as exc:  # noqa: BLE001  (a signal during start-up, as raised or as a library re-raised it)
        if signals.stopped_by(exc):
            return 0
        raise
    finally:
        signals.ignore()
        if node is None and built:
            node = built[0]  # construction was interrupted: stop what was built
        if watchdog is not None:
            watchdog.start()
        if signals.requested is not None and node is not None and _endpoints(node) > FAST_EXIT_ENDPOINTS:
            _exit_without_tear_down(node)
        if signals.interrupted:
            _tear_down_half_built(executor, node, context)
        else:
            _tear_down(executor, node, context)
        if watchdog is not None:
            watchdog.cancel()


#: What a cold start costs, said before it begins (measured: 90-120 s on a 2-core machine under load).
COLD_COMPILE_S = (60, 150)


def _compile_if_cold() -> None:
    """With no compiled kernels in numba's cache (first start after an install or a change of the
    core), say so at once and compile them here, in the main thread, during start-up: a signal
    then stops the process at once (exit 0), where a compile inside the first tick would hold
    the tick thread, and the stop, for a minute. ``make venv`` compiles them at install time."""
    if _kernels_cached():
        return
    low, high = COLD_COMPILE_S
    _say(f"first start: numba's cache is empty, compiling the simulator kernels now (about {low}-{high} s, "
         "once; later starts take about 2 s)")
    import time

    from ..core.simulator import compile_kernels

    start = time.monotonic()
    compile_kernels()
    _say(f"kernels compiled in {time.monotonic() - start:.0f} s")


def _kernels_cached() -> bool:
    """True if numba's cache holds compiled core kernels, or if where it keeps them is unknown.

    numba caches next to the sources (``core/__pycache__``) unless ``NUMBA_CACHE_DIR`` is set
    (numba's documented variable: anything compiled under it counts, its layout is numba's) or
    the sources are read-only (a per-user directory this does not guess: reported as cached)."""
    from pathlib import Path

    from ..core.jit import CACHE_DIR

    user_dir = os.environ.get("NUMBA_CACHE_DIR")
    if user_dir:
        return any(Path(user_dir).rglob("*.nbi"))
    return not os.access(CACHE_DIR, os.W_OK) or any(CACHE_DIR.glob("*.nbi"))


#: Above this many publishers and subscriptions, a stop by signal ends the process once the
#: ticks are stopped and the recording finished, without destroying each endpoint: destroying
#: them one by one in rclpy and Fast DDS grows faster than their number (measured with
#: ``destroy_node``: 0.22 s for 2,406 endpoints, 2.8 s for 9,006, 17 s for the 30,006 of
#: 10,000 bodies), which would break the 2 s a stop may take. Peers then drop the endpoints when
#: the participant's lease expires, as after a crash, instead of at once.
FAST_EXIT_ENDPOINTS = 2500


def _endpoints(node: Any) -> int:
    return sum(1 for _ in node.publishers) + sum(1 for _ in node.subscriptions)


def _exit_without_tear_down(node: Any) -> None:
    """Stop the ticks, finish the recording, say why, and exit 0 without destroying the endpoints."""
    node.stop_ticking_and_recording()
    _say(f"stopped; exiting without destroying {_endpoints(node)} endpoints one by one (slow at this "
         f"count); DDS peers drop them when the lease expires")
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


def _tear_down(executor, node, context) -> None:
    """Stop in order: executor, node (tick thread, recording), context; quietly for what was never built."""
    if executor is not None:
        executor.shutdown(timeout_sec=1.0)
    if node is not None:
        node.destroy_node()
    if context is not None:
        context.try_shutdown()


def _tear_down_half_built(executor, node, context) -> None:
    """:func:`_tear_down` after a signal cut start-up short (nothing recorded, no ticks): if what was
    half-built cannot be destroyed, say so in one line and exit 0 without it, as after a crash."""
    try:
        _tear_down(executor, node, context)
    except Exception as exc:  # noqa: BLE001
        _say(f"stopped during start-up; destroying what was built failed ({exc!r}), exiting without it")
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)


def _freeze_start_up_objects() -> None:
    """Move everything allocated so far out of the garbage collector's reach.

    What start-up made (rclpy, numpy, numba, the node: hundreds of thousands of objects) stays
    for good; left to the collector, one full collection of it stalled the tick thread for
    about 90 ms (at 100 bodies × 100 Hz: 8 ticks skipped).
    """
    import gc

    gc.collect()
    gc.freeze()


if __name__ == "__main__":
    sys.exit(main())
