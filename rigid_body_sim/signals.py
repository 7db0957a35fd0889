"""SIGINT and SIGTERM in two phases, for ``rigid_body_sim_node`` and the ``rigid-body-sim`` command.

Phase 1, while nothing worth saving is open (imports, a numba compile, loading the scene,
creating endpoints): a signal ends the process at once with status 0. The handler writes one
line to stderr and calls :func:`os._exit`; no exception is raised, so there is nothing that
can land half-way through a library call, be printed and dropped, or be turned into another
error. Before it exits it removes the Fast DDS shared-memory files this process created (see
:func:`remove_own_shared_memory`), which an exit without tear-down would otherwise leave in
``/dev/shm``.

Phase 2, from :meth:`TwoPhaseSignals.switch_to_orderly` on (just before a recording or an
output file is opened): a signal only sets :attr:`TwoPhaseSignals.stop`, a
:class:`threading.Event`, and calls ``on_first`` once; the program sees the flag between two
samples or spins and stops in order. A :class:`Watchdog` bounds how long that stop may take.

Python runs signal handlers in the main thread between bytecodes, and a signal sent to the
process may be delivered to any of its threads (OpenBLAS's, Fast DDS's): the main thread's
sleep or wait is then not interrupted, and its handler runs only when that call returns. So a
thread of this class (the signal watch) learns of each signal at once, through
:func:`signal.set_wakeup_fd`: in phase 1 it exits, in phase 2 it sets the flag and calls
``on_seen`` (a main thread inside a long compiled call that holds no GIL, a step of the
simulator, can so be told to return, ``Simulator.cancel``, before its handler can run). The
handler itself takes no lock: a main thread inside ``stop.wait()`` holds the event's, and a
handler run there that set the event would wait for it forever (CPython runs the handler in
that thread).
"""

from __future__ import annotations

import os
import signal
import threading
from pathlib import Path
from typing import Any, Callable, NoReturn

__all__ = ["STOP_SIGNALS", "TwoPhaseSignals", "Watchdog", "exit_now", "remove_own_shared_memory"]

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)

#: Where Fast DDS keeps its shared-memory segments and their named semaphores.
SHM_DIR = Path("/dev/shm")
#: Where this process's open files are listed (Linux).
FDS = Path("/proc/self/fd")
#: Names of Fast DDS segments there, and of the lock file their owner keeps open.
SEGMENT_PREFIX = "fastdds_"
LOCK_SUFFIX = "_el"
#: Names of the segments shared by every participant listening on a port.
PORT_PREFIX = "fastdds_port"


class TwoPhaseSignals:
    """SIGINT/SIGTERM: exit 0 at once (phase 1) until :meth:`switch_to_orderly`, then only set :attr:`stop`.

    Installs its handlers and starts the signal watch when created (only in the main thread:
    elsewhere Python cannot, and the process's handlers stay as they are); :meth:`restore` puts
    the previous ones back and ends the watch.

    Parameters
    ----------
    prog : str
        Name that starts the line written at a phase 1 exit (``"<prog>: stopped by SIGINT ..."``).
    during : str
        What phase 1 is, for that line (default ``"during start-up"``).
    """

    def __init__(self, prog: str, during: str = "during start-up") -> None:
        self.stop = threading.Event()
        self.signum: int | None = None
        self._prog = prog
        self._during = during
        self._on_first: Callable[[], None] | None = None
        self._on_seen: Callable[[], None] | None = None
        self._first_called = False
        self._orderly = False
        self._exiting = threading.Lock()  # phase 1: the handler and the watch may both see one signal
        self._previous: dict[int, Any] = {}
        self._wakeup: tuple[int, int] | None = None  # (write fd, the wakeup fd before)
        if threading.current_thread() is threading.main_thread():
            self._previous = {signum: signal.signal(signum, self._handle) for signum in STOP_SIGNALS}
            read_fd, write_fd = os.pipe()
            os.set_blocking(write_fd, False)
            self._wakeup = (write_fd, signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False))
            threading.Thread(target=self._watch, args=(read_fd,), name="signal watch", daemon=True).start()

    def switch_to_orderly(self, on_first: Callable[[], None] | None = None,
                          on_seen: Callable[[], None] | None = None) -> threading.Event:
        """Enter phase 2: from now on a signal sets the returned event and calls ``on_first`` (once,
        from the handler, in the main thread).

        The event is set by the signal watch as soon as a signal arrives, which then calls
        ``on_seen`` (optional), even while the main thread is in a long call that holds no GIL;
        ``on_seen`` must take no lock the main thread may hold. Created in another thread than the
        main one, this object installs nothing: the event is never set by a signal."""
        self._on_first = on_first
        self._on_seen = on_seen
        self._orderly = True
        return self.stop

    def _watch(self, read_fd: int) -> None:
        stops = {int(signum) for signum in STOP_SIGNALS}
        try:
            while data := os.read(read_fd, 64):  # b"" once restore closed the write end
                seen = [signum for signum in data if signum in stops]
                if not seen:
                    continue
                if not self._orderly:
                    self._exit_phase_1(seen[0])
                    return
                if self.signum is None:
                    self.signum = seen[0]
                self.stop.set()
                if self._on_seen is not None:
                    self._on_seen()
        except OSError:
            pass
        finally:
            os.close(read_fd)

    def _exit_phase_1(self, signum: int) -> None:
        """Exit 0 with the one line; the handler or the watch, whichever comes second, waits for
        the first to end the process (it does not run on in the meantime)."""
        if self._exiting.acquire(blocking=False):
            exit_now(0, f"{self._prog}: stopped by {signal.Signals(signum).name} {self._during}".rstrip())
        if threading.current_thread() is threading.main_thread():
            threading.Event().wait()

    @property
    def signal_name(self) -> str:
        """``"SIGINT"`` or ``"SIGTERM"`` once a signal came, else ``""``."""
        return signal.Signals(self.signum).name if self.signum is not None else ""

    def _handle(self, signum: int, _frame: Any) -> None:
        if not self._orderly:
            self._exit_phase_1(signum)
        if self._first_called:
            return
        self._first_called = True
        if self.signum is None:
            self.signum = signum
        if self._on_first is not None:
            self._on_first()

    def restore(self) -> None:
        """Put back the handlers that were there before (a signal then does what it did before)."""
        for signum, previous in self._previous.items():
            signal.signal(signum, previous)
        self._previous = {}
        if self._wakeup is not None:
            write_fd, before = self._wakeup
            signal.set_wakeup_fd(before)
            os.close(write_fd)  # the watch thread reads the end of the pipe and ends
            self._wakeup = None


class Watchdog:
    """Ends the process if an orderly stop has not finished ``grace_s`` after :meth:`start`.

    The main thread may be the one that waits (joining a tick thread stuck in a long step), so a
    timer thread does it: it calls ``on_expire`` (say why, save what can be saved) and exits with
    status 1, also if ``on_expire`` fails.
    """

    def __init__(self, grace_s: float, on_expire: Callable[[], None]) -> None:
        self._grace_s = grace_s
        self._on_expire = on_expire
        self._timer: threading.Timer | None = None
        self._starting = threading.RLock()  # start may come from a signal handler and from another thread

    def start(self) -> None:
        """Start counting (a second call changes nothing)."""
        with self._starting:
            if self._timer is None:
                timer = threading.Timer(self._grace_s, self._expire)
                timer.daemon = True
                timer.start()
                self._timer = timer

    def cancel(self) -> None:
        if self._timer is not None:
            self._timer.cancel()

    def _expire(self) -> None:
        try:
            self._on_expire()
        finally:
            exit_now(1)


def exit_now(status: int, line: str = "") -> NoReturn:
    """Write ``line`` (if any) to stderr, remove this process's Fast DDS shared memory
    (:func:`remove_own_shared_memory`) and end the process with ``status`` without any tear-down
    (:func:`os._exit`: no ``finally``, no ``atexit``, no buffered output flushed)."""
    if line:
        os.write(2, line.encode() + b"\n")
    remove_own_shared_memory()
    os._exit(status)


def remove_own_shared_memory() -> list[str]:
    """Remove the Fast DDS shared-memory segments this process owns, with their lock files;
    return the names removed.

    Fast DDS removes a participant's segment (``/dev/shm/fastdds_<id>``, 0.5 MB, and its
    ``fastdds_<id>_el`` lock file) when the participant is destroyed; after :func:`os._exit`
    they stay, and no later participant removes them. The owner is the process that keeps the
    lock file open (read from ``/proc/self/fd``; the segments of peers are mapped here too, and
    are left alone). Port segments (``fastdds_port<N>``) are left too: a later participant takes
    a free port's segment over, so they do not pile up.
    """
    removed = []
    for path in sorted(_open_files()):
        name = path.name.removesuffix(LOCK_SUFFIX)
        if path.parent != SHM_DIR or name == path.name or not name.startswith(SEGMENT_PREFIX) \
                or name.startswith(PORT_PREFIX):
            continue
        for own in (SHM_DIR / name, path):
            try:
                own.unlink()
                removed.append(own.name)
            except OSError:
                pass
    return removed


def _open_files() -> set[Path]:
    """The paths this process has open (empty where ``/proc`` is not there)."""
    paths = set()
    try:
        fds = os.listdir(FDS)
    except OSError:
        return paths
    for fd in fds:
        try:
            paths.add(Path(os.readlink(FDS / fd)))
        except OSError:  # closed meanwhile
            pass
    return paths
