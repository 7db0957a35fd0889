"""Stopping ``rigid_body_sim_node`` (and ``rigid-body-sim run``) by SIGINT or SIGTERM: the one home of the stop tests.

What every stop must give (checked by :func:`helpers.stop_and_check`): exit status 0, no
traceback, no Fast DDS segment of the process left in /dev/shm, and no recording or a complete
one that mcap's reader opens. Start-up stops (phase 1 of :mod:`rigid_body_sim.signals`) say so
in one line and leave no recording; stops while ticking (phase 2) finish the recording. A
SIGKILL loses at most the last second of a recording (the node flushes it every 0.5 s), and
Foxglove's readers decode what is left.

The table MOMENTS × SIGNALS is the map: the default run keeps one fast row for each moment,
and ``make test-slow`` runs the rest and the soaks (20 stops at 1000 bodies, every moment of
start-up, cold compiles, 10,000 bodies, floods). Times from signal to exit are printed (``-s``),
not asserted beyond launch's 5 s: the machine is shared.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.offline.recording import read_recording
from rigid_body_sim.ros.node import DEFAULT_INTEGRATOR
from rigid_body_sim.testing import node_command, start_process

from foxglove_support import (TICK_S, by_topic, check_everything_decodes, check_schema_text, foxglove_decode, stamp_ns,
                              xyz, xyzw)
from helpers import (kill_if_running, own_shared_memory, stop_and_check, wait_for_line, wait_for_participant,
                     write_tumbling_scene)

pytestmark = pytest.mark.ros

PUBLISHER = Path(__file__).with_name("flood_publisher.py")
START_UP_LINE = "rigid_body_sim_node: stopped by {} during start-up"
#: Longest a stop may take: launch sends SIGTERM 5 s after SIGINT.
LAUNCH_GRACE_S = 5.0


@dataclass(frozen=True)
class Moment:
    """A moment of a node's life at which a signal is sent."""

    bodies: int  # 0: the default scene
    per_body_topics: bool
    reach: Callable[[subprocess.Popen, Path], None]  # wait for the moment (the process and its log)
    start_up: bool  # True: phase 1 (exit at once, no recording); False: ticking (orderly stop)
    env: dict[str, str] | None = None
    many_endpoints: bool = False  # above FAST_EXIT_ENDPOINTS: a stop while ticking skips destroying them


def after_handlers(timeout: float = 60.0) -> Callable[[subprocess.Popen, Path], None]:
    """Wait until the process catches SIGINT and SIGTERM (its handlers in place: /proc/PID/status, SigCgt), the
    first thing the entry point does, before its heavy imports: a signal sent earlier, while the interpreter
    itself starts, meets no handler of ours and kills it (exit −15), on a machine slow to start Python."""
    def reach(process: subprocess.Popen, _log: Path) -> None:
        wanted = (1 << (signal.SIGINT - 1)) | (1 << (signal.SIGTERM - 1))
        end = time.monotonic() + timeout
        while time.monotonic() < end and process.poll() is None:
            status = Path(f"/proc/{process.pid}/status").read_text()
            caught = int(next(line for line in status.splitlines() if line.startswith("SigCgt:")).split()[1], 16)
            if caught & wanted == wanted:
                return
            time.sleep(0.005)
        raise AssertionError(f"the handlers were not in place within {timeout} s")
    return reach


def after_participant(seconds: float) -> Callable[[subprocess.Popen, Path], None]:
    def reach(process: subprocess.Popen, _log: Path) -> None:
        wait_for_participant(process)
        time.sleep(seconds)
    return reach


def after_line(text: str, seconds: float, timeout: float = 240.0) -> Callable[[subprocess.Popen, Path], None]:
    def reach(process: subprocess.Popen, log: Path) -> None:
        wait_for_line(log, text, process, timeout)
        time.sleep(seconds)
    return reach


MOMENTS = {
    "imports": Moment(0, True, after_handlers(), start_up=True),
    # the participant is created first in the node's constructor, then the scene is loaded, then
    # the endpoints are created (600 bodies × 5 per-body topics here: about 2 s)
    "scene load": Moment(600, True, after_participant(0.0), start_up=True),
    "endpoint creation": Moment(600, True, after_participant(0.7), start_up=True),
    "ticking and recording": Moment(1, False, after_line("recording to", 0.5), start_up=False),
    # 600 bodies × 5 per-body topics: above FAST_EXIT_ENDPOINTS, so the exit skips destroying them
    "ticking, 3006 endpoints": Moment(600, True, after_line("recording to", 0.5), start_up=False, many_endpoints=True),
    "cold compile": Moment(2, False, after_line("compiling the simulator kernels", 2.0), start_up=True,
                           env={"NUMBA_CACHE_DIR": "{tmp}/numba_cache"}),
    "10,000 bodies loading": Moment(10_000, False, after_participant(0.5), start_up=True),
    "10,000 bodies, endpoint creation": Moment(10_000, False, after_participant(8.0), start_up=True),
    "10,000 bodies ticking": Moment(10_000, False, after_line("recording to", 2.0, timeout=300), start_up=False,
                                    many_endpoints=True),
}
SIGNALS = [signal.SIGINT, signal.SIGTERM]
#: The rows of the default run (the others are marked slow).
FAST = {("imports", signal.SIGINT), ("imports", signal.SIGTERM), ("endpoint creation", signal.SIGINT),
        ("ticking and recording", signal.SIGINT), ("ticking, 3006 endpoints", signal.SIGTERM)}


def start_node(tmp_path: Path, moment: Moment, name: str) -> tuple[subprocess.Popen, Path, Path]:
    args = ["-p", "status_period:=0.0"]
    if moment.bodies:
        scene = tmp_path / f"scene_{moment.bodies}.yaml"
        if not scene.exists():
            write_tumbling_scene(scene, moment.bodies)
        # Per-body inputs on: the floods publish on B/impulse and B/wrench, and 1000 bodies keep
        # their 3006 endpoints (the fast exit) even with batched output.
        args += ["-p", f"scene:={scene}", "-p", f"per_body_topics:={str(moment.per_body_topics).lower()}",
                 "-p", "per_body_inputs:=true"]
    record, log = tmp_path / f"{name}.mcap", tmp_path / f"{name}.log"
    args += ["-p", f"record_path:={record}"]
    if moment.env is None:
        return start_process(args, log), log, record
    env = {**os.environ, **{k: v.format(tmp=tmp_path) for k, v in moment.env.items()}}
    with open(log, "w") as out:
        return subprocess.Popen([*node_command(), "--ros-args", *args], stdout=out, stderr=subprocess.STDOUT,
                                env=env), log, record


def check_phase(moment: Moment, signum: signal.Signals, log: Path, record: Path) -> None:
    text = log.read_text()
    if moment.start_up:
        assert START_UP_LINE.format(signum.name) in text, text[-2000:]
        assert "recording to" not in text and not record.exists(), text[-2000:]
    else:
        assert START_UP_LINE.format(signum.name) not in text and record.exists(), text[-2000:]
        assert "recording finished" in text, text[-2000:]
        assert ("exiting without destroying" in text) == moment.many_endpoints, text[-2000:]


ROWS = [pytest.param(name, signum, id=f"{name}-{signum.name}",
                     marks=() if (name, signum) in FAST else (pytest.mark.slow, pytest.mark.timeout(600)))
        for name in MOMENTS for signum in SIGNALS]


@pytest.mark.parametrize(("moment_name", "signum"), ROWS)
def test_a_signal_at_each_moment_exits_0_with_no_recording_or_a_complete_one(moment_name, signum, tmp_path):
    moment = MOMENTS[moment_name]
    process, log, record = start_node(tmp_path, moment, "node")
    try:
        moment.reach(process, log)
        assert process.poll() is None, log.read_text()[-2000:]
        took = stop_and_check(process, signum, log, record, what=f"{moment_name}, {signum.name}")
    finally:
        kill_if_running(process)
    check_phase(moment, signum, log, record)
    print(f"\n{moment_name}: {signum.name} -> exit 0 in {took:.2f} s")
    if moment.bodies < 10_000:  # 10,000 bodies: 1.6 s, and 5.4 s on a loaded machine (printed only)
        assert took < LAUNCH_GRACE_S


# ---------------------------------------------------------------------- floods


def start_flooders(topics: list[str], mode: str, rate: int) -> list[subprocess.Popen]:
    """Publishers of wrenches or impulses at ``rate`` per second each, one process per topic."""
    extra = ["--mode", "impulse", "--force", "1e-6", "0", "0"] if mode == "impulse" else []
    return [subprocess.Popen([sys.executable, str(PUBLISHER), "--topic", topic, "--frame", topic.split("/")[1],
                              *extra, "--rate", str(rate), "--duration", "60"],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) for topic in topics]


def stop_flooders(flooders: list[subprocess.Popen]) -> None:
    """SIGINT, so that each destroys its participant (a SIGKILL would leave its segment in /dev/shm)."""
    for flooder in flooders:
        if flooder.poll() is None:
            flooder.send_signal(signal.SIGINT)
    for flooder in flooders:
        try:
            flooder.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            kill_if_running(flooder)


def wait_until_flooding(flooders: list[subprocess.Popen]) -> None:
    for flooder in flooders:
        line = flooder.stdout.readline()
        assert line.strip() == "ready", f"flooder: {line}{flooder.stdout.read() if flooder.poll() is not None else ''}"


FLOODS = {
    # rclpy's own handler once shut the context down under the spinning executor here:
    # "RCLError: failed to initialize wait set", or a RuntimeError in _take_subscription.
    # 1000 bodies have 3006 endpoints even with batched output (3 subscriptions each): fast exit.
    "5 kHz impulses on 1 body": (1, ["/b0/impulse"], "impulse", 5000),
    "2 × 2 kHz wrenches at 1000 bodies": (1000, ["/b0/wrench", "/b999/wrench"], "wrench", 2000),
}
FLOOD_ROWS = [pytest.param(name, signum, id=f"{name}-{signum.name}", marks=() if (name, signum) == (
    "5 kHz impulses on 1 body", signal.SIGTERM) else (pytest.mark.slow, pytest.mark.timeout(600)))
    for name in FLOODS for signum in SIGNALS]


@pytest.mark.parametrize(("flood", "signum"), FLOOD_ROWS)
def test_a_signal_under_a_flood_exits_0_with_a_complete_recording(flood, signum, tmp_path):
    flood_and_stop(tmp_path, flood, signum)


@pytest.mark.slow
@pytest.mark.parametrize("repeat", range(10))
def test_a_signal_under_an_impulse_flood_repeated(repeat, tmp_path):
    flood_and_stop(tmp_path, "5 kHz impulses on 1 body", SIGNALS[repeat % 2])


def flood_and_stop(tmp_path: Path, flood: str, signum: signal.Signals) -> None:
    bodies, topics, mode, rate = FLOODS[flood]
    moment = Moment(bodies, False, after_line("recording to", 0.0), start_up=False, many_endpoints=bodies >= 1000)
    process, log, record = start_node(tmp_path, moment, "flooded")
    senders = start_flooders(topics, mode, rate)
    try:
        moment.reach(process, log)
        wait_until_flooding(senders)
        time.sleep(1.0)
        assert process.poll() is None and all(s.poll() is None for s in senders), log.read_text()[-2000:]
        took = stop_and_check(process, signum, log, record, what=f"{flood}, {signum.name}")
    finally:
        kill_if_running(process)
        stop_flooders(senders)
    check_phase(moment, signum, log, record)
    assert took < LAUNCH_GRACE_S


# ---------------------------------------------------------------------- the rigid-body-sim command


def test_a_signal_before_run_opens_its_files_exits_0_and_writes_nothing(tmp_path):
    """Phase 1 of ``rigid-body-sim run`` (loading and building 1000 bodies: about 0.5 s): exit 0 at
    once, one line, no output file created. (A signal during the run closes and marks the files:
    test_hostile.py.)"""
    scene = write_tumbling_scene(tmp_path / "big.yaml", 1000)
    csv, record = tmp_path / "run.csv", tmp_path / "run.mcap"
    script = (f"import sys; from rigid_body_sim.cli import main; print('ready', flush=True); "
              f"sys.exit(main(['run', {str(scene)!r}, '-T', '1', '--csv', {str(csv)!r}, '--record', {str(record)!r}]))")
    process = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert process.stdout.readline().strip() == "ready", process.stderr.read()
        time.sleep(0.1)
        process.send_signal(signal.SIGTERM)
        out, err = process.communicate(timeout=30)
    finally:
        kill_if_running(process)
    assert process.returncode == 0 and out == "", out + err
    assert err == "rigid-body-sim run: stopped by SIGTERM\n"
    assert not csv.exists() and not record.exists()


# ---------------------------------------------------------------------- soaks


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_twenty_stops_at_1000_bodies_at_any_moment(tmp_path):
    """1000 bodies, batched output only, half of them recording: SIGINT or SIGTERM at delays spread
    over the whole start-up and the first seconds of ticking."""
    scene = write_tumbling_scene(tmp_path / "swarm.yaml", 1000)
    times = []
    for k, delay in enumerate(np.linspace(0.2, 4.0, 20)):
        signum = SIGNALS[k % 2]
        record, log = tmp_path / f"run{k}.mcap", tmp_path / f"run{k}.log"
        args = ["-p", f"scene:={scene}", "-p", "per_body_topics:=false", "-p", "status_period:=0.0"]
        if k % 4 in (0, 3):
            args += ["-p", f"record_path:={record}"]
        process = start_process(args, log)
        try:
            time.sleep(delay)
            times.append(stop_and_check(process, signum, log, record, what=f"run {k} ({signum.name} after {delay:.2f} s)"))
        finally:
            kill_if_running(process)
    times = np.array(times)
    print(f"\n20 stops at 1000 bodies: signal to exit median {np.median(times):.2f} s, max {times.max():.2f} s")
    assert times.max() < LAUNCH_GRACE_S


@pytest.mark.slow
@pytest.mark.timeout(900)
@pytest.mark.parametrize("signum", SIGNALS, ids=[s.name for s in SIGNALS])
def test_a_signal_at_every_moment_of_start_up_exits_0(signum, tmp_path):
    """The default scene, a signal every 0.1 s from 0.15 s to 3 s after start. (Before about 0.07 s
    the interpreter itself is still starting, twice: the ROS wheels' bootstrapper re-execs it. No
    handler of ours is installed yet: a SIGINT there ends in Python's own KeyboardInterrupt, or is
    lost across the re-exec, and a SIGTERM kills the process, status -15.)"""
    for k in range(29):
        delay = 0.15 + 0.1 * k
        log = tmp_path / f"node_{k}.log"
        process = start_process(["-p", "status_period:=0.0"], log)
        try:
            time.sleep(delay)
            stop_and_check(process, signum, log, what=f"after {delay:.2f} s")
        finally:
            kill_if_running(process)


# ---------------------------------------------------------------------- SIGKILL


def test_sigkill_during_a_recording_loses_at_most_a_second(tmp_path):
    """SIGKILL while recording 2 bodies at 100 Hz: mcap's reader opens the file (no summary: the
    writer never finished it) and it holds every tick up to at most 1 s of sim time (= wall time
    here, real_time_factor 1) before the last /clock this process received before the kill.
    Two bodies write about 50 kB/s, so a 256 KiB chunk alone would keep ~5 s in memory (nothing
    of these 2 s): what survives is the node's periodic flush (node_recording.FLUSH_PERIOD_S).

    Foxglove's own readers (test/foxglove, as in test_foxglove_readers.py) read the same cut file
    record by record: every message decodes, the batches are stamped on the ticks in order, and
    the last one is the simulator's state after as many ticks, bit for bit."""
    import rclpy
    from mcap.exceptions import EndOfFile
    from mcap.reader import NonSeekingReader
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from rosgraph_msgs.msg import Clock

    scene = write_tumbling_scene(tmp_path / "two.yaml", 2)
    record = tmp_path / "killed.mcap"
    process = start_process(["-p", f"scene:={scene}", "-p", "per_body_topics:=false", "-p", "status_period:=0.0",
                             "-p", f"record_path:={record}"], tmp_path / "node.log")
    context = Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    peer = Node("kill_peer", context=context)
    executor.add_node(peer)
    clocks: list[int] = []
    peer.create_subscription(Clock, "/clock", lambda m: clocks.append(m.clock.sec * 1_000_000_000 + m.clock.nanosec),
                             QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    try:
        deadline = time.monotonic() + 60
        while not clocks or clocks[-1] < 2_000_000_000:  # 2 s of sim time recorded
            assert time.monotonic() < deadline and process.poll() is None, (tmp_path / "node.log").read_text()[-2000:]
            executor.spin_once(timeout_sec=0.05)
        last_clock_ns = clocks[-1]
        segments = own_shared_memory(process.pid)
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=10)
        for path in segments:  # what a SIGKILL leaves in /dev/shm
            path.unlink(missing_ok=True)
    finally:
        kill_if_running(process)
        executor.shutdown()
        peer.destroy_node()
        context.try_shutdown()
    times = []
    with open(record, "rb") as f:  # read record by record up to the cut: the summary was never written
        try:
            for _schema, _channel, message in NonSeekingReader(f).iter_messages(log_time_order=False):
                times.append(message.log_time)
        except EndOfFile:
            pass
    assert times, "no message survived the kill"
    data, _scene = read_recording(record)
    assert data.meta["status"].startswith("cut short")
    lost_s = (last_clock_ns - max(times)) * 1e-9
    print(f"\nSIGKILL at sim t >= {last_clock_ns * 1e-9:.3f} s: the file holds up to t = {max(times) * 1e-9:.3f} s "
          f"(lost {lost_s:.3f} s), {len(times)} messages")
    assert lost_s <= 1.0
    assert len(data.bodies) == 2 and data.time[-1] * 1e9 >= last_clock_ns - 1e9
    result = foxglove_decode(record)
    check_everything_decodes(result, finished=False)
    check_schema_text(record)
    batches = by_topic(result, "/poses")
    assert [t for t, _ in batches] == sorted(t for t, _ in batches)
    for t, batch in batches:
        assert stamp_ns(batch["header"]) == t and t % round(TICK_S * 1e9) == 0 and len(batch["poses"]) == 2
    sim = Simulator(load_scene(scene), DEFAULT_INTEGRATOR, TICK_S)
    sim.step(round(batches[-1][0] * 1e-9 / TICK_S))
    assert [xyz(pose["position"]).tolist() for pose in batches[-1][1]["poses"]] == sim.positions_world().tolist()
    assert [xyzw(pose["orientation"]).tolist() for pose in batches[-1][1]["poses"]] == sim.orientations_xyzw().tolist()
