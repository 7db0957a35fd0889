"""The two phases of :mod:`rigid_body_sim.signals`, each in a process of its own.

Phase 1: a signal ends the process at once, status 0, one line on stderr, no ``finally`` run,
and its Fast DDS segments removed. Phase 2: a signal only sets the flag (``on_first`` once,
also for a second signal), and the program goes on to stop in order. The watchdog ends a stop
that takes too long with status 1. The node and the CLI built on them: test_stops.py.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

SHM = Path("/dev/shm")

SIGNALS = [signal.SIGINT, signal.SIGTERM]
IDS = [s.name for s in SIGNALS]


def signal_after_ready(script: str, *signums: signal.Signals, timeout: float = 30.0,
                       between: str | None = None) -> tuple[int, str, str, float]:
    """Run ``script`` in its own Python; once it prints "ready", send ``signums`` 0.1 s apart, or, with
    ``between``, each after the script printed that line (the first signal handled before the next is sent:
    signals pending together are handled lowest number first, whatever order they were sent in); then writes
    "sent" to its stdin (a script that reads that line knows every signal was delivered: a handler runs before
    the read returns). Returns (exit status, stdout after "ready", stderr, seconds from the first signal to the exit)."""
    process = subprocess.Popen([sys.executable, "-c", textwrap.dedent(script)], stdin=subprocess.PIPE,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert process.stdout.readline().strip() == "ready", process.stderr.read()
        sent = time.monotonic()
        seen = ""
        for k, signum in enumerate(signums):
            if k and between is not None:
                line = process.stdout.readline()
                assert line.strip() == between, line + process.stderr.read()
                seen += line
            process.send_signal(signum)
            time.sleep(0.1)
        try:
            process.stdin.write("sent\n")
            process.stdin.flush()
        except BrokenPipeError:  # it has exited already (phase 1)
            pass
        out, err = process.communicate(timeout=timeout)
        return process.returncode, seen + out, err, time.monotonic() - sent
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


@pytest.mark.parametrize("to_thread", [False, True], ids=["to-process", "to-other-thread"])
@pytest.mark.parametrize("signum", SIGNALS, ids=IDS)
def test_phase_1_exits_0_at_once_with_one_line(signum, to_thread):
    """Sent to the process, or by a second thread of the child to itself alone once it reads "sent": a signal
    may be delivered to any thread (OpenBLAS's, Fast DDS's), and then the main thread's sleep goes on and its
    handler would run only when the sleep ends."""
    other = f"""
        def other():
            sys.stdin.readline()
            signal.pthread_kill(threading.get_ident(), signal.{signum.name})
            time.sleep(20)
        threading.Thread(target=other, daemon=True).start()""" if to_thread else ""
    returncode, out, err, took = signal_after_ready(f"""
        import signal, sys, threading, time
        from rigid_body_sim.signals import TwoPhaseSignals

        signals = TwoPhaseSignals("prog"){other}
        try:
            print("ready", flush=True)
            time.sleep(20)
        finally:
            print("finally ran", flush=True)
    """, *(() if to_thread else (signum,)))
    assert returncode == 0 and out == "", out + err
    assert err == f"prog: stopped by {signum.name} during start-up\n"
    assert took < 5.0


@pytest.mark.parametrize("signum", SIGNALS, ids=IDS)
def test_phase_2_only_sets_the_flag_and_calls_on_first_once(signum):
    returncode, out, err, _took = signal_after_ready("""
        import signal
        import sys
        from rigid_body_sim.signals import TwoPhaseSignals

        signals = TwoPhaseSignals("prog")
        stop = signals.switch_to_orderly(on_first=lambda: print("first", flush=True))
        print("ready", flush=True)
        while not stop.wait(0.05):  # short waits, as the program's loops: a handler that runs between one wait's
            pass                    # look at the flag and its sleep sets it unseen by that wait (not by the next)
        sys.stdin.readline()  # "sent": the second signal was sent before, and handled (nothing more happens)
        print("stopped in order by", signals.signal_name, flush=True)
        signals.restore()
        print("restored", signal.getsignal(signal.SIGINT) is signal.default_int_handler, flush=True)
    """, signum, signal.SIGINT, between="first")
    assert returncode == 0 and err == "", err
    assert out.splitlines() == ["first", f"stopped in order by {signum.name}", "restored True"]


@pytest.mark.parametrize("signum", SIGNALS, ids=IDS)
def test_phase_2_stops_a_main_thread_that_waits_on_the_flag(signum):
    """The main thread inside ``stop.wait()`` holds the event's lock most of the time with a zero timeout (the
    view's loop waits on it too): a handler that set the event there waited for that lock forever."""
    returncode, out, err, took = signal_after_ready("""
        from rigid_body_sim.signals import TwoPhaseSignals

        signals = TwoPhaseSignals("prog")
        stop = signals.switch_to_orderly(on_first=lambda: print("first", flush=True))
        print("ready", flush=True)
        while not stop.wait(0):
            pass
        print("stopped in order by", signals.signal_name, flush=True)
    """, signum, timeout=15.0)
    assert returncode == 0 and err == "", err
    assert sorted(out.splitlines()) == sorted(["first", f"stopped in order by {signum.name}"]), out
    assert took < 5.0


@pytest.mark.parametrize("fails", [False, True], ids=["on_expire", "on_expire-fails"])
def test_the_watchdog_calls_on_expire_then_exits_1(fails):
    process = subprocess.run([sys.executable, "-c", textwrap.dedent(f"""
        import time
        from rigid_body_sim.signals import Watchdog

        def on_expire():
            print("expired", flush=True)
            if {fails}:
                raise RuntimeError("saving failed")

        Watchdog(0.2, on_expire).start()
        time.sleep(20)  # an orderly stop that does not end
        print("not reached", flush=True)
    """)], capture_output=True, text=True, timeout=30)
    assert process.returncode == 1 and process.stdout == "expired\n", process.stdout + process.stderr


def test_a_cancelled_watchdog_does_nothing():
    process = subprocess.run([sys.executable, "-c", textwrap.dedent("""
        import time
        from rigid_body_sim.signals import Watchdog

        watchdog = Watchdog(0.2, lambda: print("expired", flush=True))
        watchdog.start()
        watchdog.cancel()
        time.sleep(0.5)
        print("went on", flush=True)
    """)], capture_output=True, text=True, timeout=30)
    assert process.returncode == 0 and process.stdout == "went on\n", process.stdout + process.stderr


@pytest.mark.ros
def test_an_exit_without_tear_down_removes_the_participants_shared_memory():
    """A Fast DDS participant's segment (/dev/shm/fastdds_<id> and its lock file) outlives
    ``os._exit``; :func:`exit_now` removes it first, and only it (not the port segments, which
    every participant on the host shares)."""
    process = subprocess.run([sys.executable, "-c", textwrap.dedent("""
        import rclpy
        from rclpy.node import Node
        from std_msgs.msg import Empty
        from rigid_body_sim.signals import exit_now

        rclpy.init()
        node = Node("shm_check")
        node.create_publisher(Empty, "shm_check", 10)
        maps = open("/proc/self/maps").read()
        for name in sorted({line.split("/dev/shm/")[1] for line in maps.splitlines() if "/dev/shm/fastdds_" in line}):
            print(name, flush=True)
        exit_now(0, "bye")
    """)], capture_output=True, text=True, timeout=60)
    assert process.returncode == 0 and process.stderr.endswith("bye\n"), process.stderr
    own = [name for name in process.stdout.split() if not name.startswith("fastdds_port")]
    assert own, f"no segment of its own: {process.stdout}"
    left = [path for name in own for path in (SHM / name, SHM / f"{name}_el") if path.exists()]
    assert not left, left


def test_only_the_segments_whose_lock_this_process_holds_are_removed(tmp_path, monkeypatch):
    """The owner of a segment keeps its ``_el`` lock file open; peers' segments (mapped, not
    locked here), port segments and other files stay. What is removed is returned."""
    from rigid_body_sim import signals

    shm, fds = tmp_path / "shm", tmp_path / "fd"
    shm.mkdir()
    fds.mkdir()
    for name in ("fastdds_0123abcd", "fastdds_0123abcd_el", "fastdds_port7000", "fastdds_port7000_el",
                 "sem.fastdds_port7000_mutex", "fastdds_feedbeef", "fastdds_feedbeef_el", "other_el"):
        (shm / name).write_text("")
    for fd, name in enumerate(("fastdds_0123abcd_el", "fastdds_port7000_el", "fastdds_feedbeef", "other_el")):
        (fds / str(fd)).symlink_to(shm / name)
    (fds / "9").symlink_to(tmp_path / "elsewhere_el")
    monkeypatch.setattr(signals, "SHM_DIR", shm)
    monkeypatch.setattr(signals, "FDS", fds)
    assert signals.remove_own_shared_memory() == ["fastdds_0123abcd", "fastdds_0123abcd_el"]
    assert sorted(p.name for p in shm.iterdir()) == [
        "fastdds_feedbeef", "fastdds_feedbeef_el", "fastdds_port7000", "fastdds_port7000_el", "other_el",
        "sem.fastdds_port7000_mutex"]
