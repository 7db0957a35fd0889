"""Session-wide test set-up: a private ROS domain per pytest session, and per-test time limits.

ROS isolation
    Every pytest session takes its own ``ROS_DOMAIN_ID`` so that parallel sessions on one
    machine (two developers, CI and a developer, ``make test`` twice) never see each other's
    topics. The id is chosen from the ranges Fast DDS can map to valid, non-ephemeral UDP
    ports (1-101 and 215-232; 0 is left to whatever real ROS system may run here) and is
    claimed by holding an exclusive ``flock`` on ``/tmp/rigid_body_sim_ros_domain_<id>.lock``
    for the whole session. The kernel drops the lock when the process exits, even on a crash,
    so there are no stale claims to clean up. The search starts at an offset derived from the
    pid, so concurrent sessions rarely even contend for the same file.

    ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` keeps discovery on loopback. The rcl in these
    wheels (rcl 10.1, Kilted) reads only this variable; ``ROS_LOCALHOST_ONLY`` is not
    read at all any more. Both variables are set in ``os.environ`` here, at conftest import,
    before any test module imports rclpy, and subprocesses inherit them.

Time limits (no plugin; the two methods of pytest-timeout in a few lines)
    A test may carry ``@pytest.mark.timeout(seconds)``; otherwise it gets
    ``DEFAULT_TEST_TIMEOUT_S`` (``SLOW_TEST_TIMEOUT_S`` for tests marked ``slow``).
    At the limit ``SIGALRM`` raises in the main thread, which interrupts Python code,
    ``time.sleep`` and rclpy ``spin_once(timeout_sec=...)`` loops: that test fails, the
    session goes on. A test blocked inside C (``executor.spin()`` or
    ``spin_until_future_complete`` without a timeout, a wait set with no timeout) never sees
    the signal, so a watchdog thread, ``WATCHDOG_GRACE_S`` later, prints every thread's stack
    and ends the session with exit code 1. A test blocked in C code that holds the GIL stops
    that thread too (a DDS participant's deletion inside rclpy's ``destroy_node`` was seen to
    block for ever with the watchdog silent): faulthandler's own thread, which needs no GIL,
    writes every thread's stack ``2 × WATCHDOG_GRACE_S`` after the limit to
    ``rigid_body_sim_stuck_<pid>.txt`` in ``RIGID_BODY_SIM_STUCK_DIR`` (default: the temporary
    directory) and ends the process with exit code 1 (under xdist: that worker, reported as
    crashed in that test; ``make test`` does not restart it, which would run the test again,
    and prints the file). The Makefile wraps the whole run in ``timeout`` as the last resort.
    Rule for ROS tests: always spin with a timeout.
"""

from __future__ import annotations

import faulthandler
import fcntl
import os
import signal
import sys
import tempfile
import threading
from collections.abc import Iterator
from typing import IO

import pytest

# Fast DDS maps domain d to UDP port 7400 + 250 * d (+ offsets); ids 102-214 land in the
# Linux ephemeral port range and ids above 232 overflow 65535.
SAFE_DOMAIN_IDS: tuple[int, ...] = tuple(range(1, 102)) + tuple(range(215, 233))
_LOCK_DIR = "/tmp"
_LOCK_PATTERN = "rigid_body_sim_ros_domain_{}.lock"

DEFAULT_TEST_TIMEOUT_S = 120.0  # s, per test not marked slow
SLOW_TEST_TIMEOUT_S = 1800.0  # s, per test marked slow
WATCHDOG_GRACE_S = float(os.environ.get("RIGID_BODY_SIM_WATCHDOG_GRACE_S", "15"))  # s after the limit before a
# test stuck in C code ends the session (twice that with the GIL held); the variable is for the test of this
STUCK_DIR = os.environ.get("RIGID_BODY_SIM_STUCK_DIR", tempfile.gettempdir())


def _claim_domain_id() -> tuple[int, IO[str]]:
    """Claim a free ROS domain id for this process.

    Returns
    -------
    domain_id : int
        An id from ``SAFE_DOMAIN_IDS`` that no other live process holds.
    lock_file : file object
        The open lock file; the claim lasts as long as it stays open.

    Raises
    ------
    RuntimeError
        If every safe id is held by another process.
    """
    start = os.getpid() % len(SAFE_DOMAIN_IDS)
    for k in range(len(SAFE_DOMAIN_IDS)):
        domain_id = SAFE_DOMAIN_IDS[(start + k) % len(SAFE_DOMAIN_IDS)]
        path = os.path.join(_LOCK_DIR, _LOCK_PATTERN.format(domain_id))
        try:
            lock_file = open(path, "a+")  # noqa: SIM115 - kept open for the whole session
        except OSError:  # e.g. created by another user: treat the id as taken
            continue
        try:
            fcntl.flock(lock_file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock_file.close()
            continue
        lock_file.seek(0)
        lock_file.truncate()
        lock_file.write(f"{os.getpid()}\n")
        lock_file.flush()
        return domain_id, lock_file
    raise RuntimeError(
        f"all {len(SAFE_DOMAIN_IDS)} ROS domain ids are held by other processes "
        f"(lock files {_LOCK_DIR}/{_LOCK_PATTERN.format('*')})"
    )


# Runs at conftest import, i.e. before test modules (and so rclpy) are imported.
ROS_DOMAIN_ID, _DOMAIN_LOCK = _claim_domain_id()
os.environ["ROS_DOMAIN_ID"] = str(ROS_DOMAIN_ID)
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.pop("ROS_STATIC_PEERS", None)
os.environ.pop("ROS_LOCALHOST_ONLY", None)  # not read by this rcl; avoid misleading readers


def pytest_report_header(config: pytest.Config) -> str:
    """Show the session's ROS domain in pytest's header."""
    return (
        f"ROS_DOMAIN_ID={ROS_DOMAIN_ID} (private to this session), "
        f"ROS_AUTOMATIC_DISCOVERY_RANGE={os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE']}"
    )


def pytest_unconfigure(config: pytest.Config) -> None:
    """Release the domain id claim (the kernel would drop it at exit anyway)."""
    _DOMAIN_LOCK.close()


#: The files that take longest in the default run (each waits seconds on processes, a browser or signals), run
#: first: ``make test`` hands each file whole to the next free xdist worker (``--dist loadfile``), and a long file
#: handed out last would keep the run going while the other workers sit idle.
LONG_FILES = ("test_view.py", "test_stops.py", "test_liveness.py", "test_node_hostile.py", "test_truncation.py",
              "test_hostile.py", "test_access.py", "test_contact_landing.py")


def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items: list[pytest.Item]) -> None:
    """The files of LONG_FILES first, in that order; the other files, and the tests within each file, keep their
    order."""
    rank = {name: k for k, name in enumerate(LONG_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(LONG_FILES)))


@pytest.fixture(scope="session")
def ros_domain_id() -> int:
    """The ROS domain id private to this pytest session (also in ``os.environ``)."""
    return ROS_DOMAIN_ID


class TestTimeoutError(Exception):
    """Raised inside a test that ran past its time limit."""

    __test__ = False  # not a test class, despite the name


def _timeout_for(item: pytest.Item) -> float:
    marker = item.get_closest_marker("timeout")
    if marker is not None:
        if len(marker.args) != 1 or not isinstance(marker.args[0], (int, float)):
            raise pytest.UsageError(
                f"{item.nodeid}: expected @pytest.mark.timeout(seconds), got {marker}"
            )
        return float(marker.args[0])
    if item.get_closest_marker("slow") is not None:
        return SLOW_TEST_TIMEOUT_S
    return DEFAULT_TEST_TIMEOUT_S


def _stuck_path() -> str:
    """Where faulthandler writes this process's stacks if its test blocks with the GIL held."""
    return os.path.join(STUCK_DIR, f"rigid_body_sim_stuck_{os.getpid()}.txt")


def _kill_session(item: pytest.Item, limit_s: float) -> None:
    """Watchdog thread: the test is stuck outside Python; report where, then exit (the stack file faulthandler
    holds ready is removed: these stacks are printed here)."""
    os.unlink(_stuck_path())
    capman = item.config.pluginmanager.getplugin("capturemanager")
    if capman is not None:
        capman.suspend_global_capture(in_=True)
        out, err = capman.read_global_capture()
        sys.stdout.write(out)
        sys.stderr.write(err)
    sys.stderr.write(
        f"\n\n!!! {item.nodeid} is still running {WATCHDOG_GRACE_S:g} s after its "
        f"{limit_s:g} s limit, blocked where SIGALRM cannot reach it (C code such as "
        "executor.spin() without a timeout). Stacks of all threads:\n"
    )
    sys.stderr.flush()
    faulthandler.dump_traceback(file=sys.stderr, all_threads=True)
    sys.stderr.write("!!! ending the test session with exit code 1\n")
    sys.stderr.flush()
    os._exit(1)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_call(item: pytest.Item) -> Iterator[None]:
    """Run the test body under a time limit (setup and teardown are not limited).

    At the limit, SIGALRM raises :class:`TestTimeoutError` in the main thread: the test
    fails and the session goes on. A test blocked in C code does not see the signal; a
    watchdog thread then dumps every thread's stack and ends the session.
    """
    limit_s = _timeout_for(item)
    if limit_s <= 0:
        yield
        return

    def _on_alarm(signum: int, frame: object) -> None:
        raise TestTimeoutError(f"{item.nodeid} exceeded its time limit of {limit_s:g} s")

    previous = signal.signal(signal.SIGALRM, _on_alarm)
    signal.setitimer(signal.ITIMER_REAL, limit_s)
    watchdog = threading.Timer(limit_s + WATCHDOG_GRACE_S, _kill_session, (item, limit_s))
    watchdog.daemon = True
    watchdog.start()
    # The GIL held by the blocked call: neither the alarm nor the watchdog runs, faulthandler's C thread does.
    stuck_path = _stuck_path()
    stuck = open(stuck_path, "w")
    stuck.write(f"!!! {item.nodeid} is still running {2 * WATCHDOG_GRACE_S:g} s after its {limit_s:g} s limit, "
                "blocked in C code holding the GIL (neither the alarm nor the watchdog thread could run). "
                "Stacks of all threads; the process ends with exit code 1:\n")
    stuck.flush()
    faulthandler.dump_traceback_later(limit_s + 2 * WATCHDOG_GRACE_S, exit=True, file=stuck)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()
        stuck.close()
        os.unlink(stuck_path)
        watchdog.cancel()
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
