"""The node against hostile clients, files, parameters and processes (the node side).

Each test reproduces something that ended in a traceback, a hang or a silent node before the
fix (named in its docstring), through the node's real interfaces: in-process through the
harness, or the ``rigid_body_sim_node`` process over DDS. Long repetitions are marked slow:

    .venv/bin/python -m pytest -m slow test/test_node_hostile.py

Scene bombs and the loader's own limits are the loader's tests (test_scene.py); here only what
the node does with what the loader accepts or refuses. Stops by SIGINT/SIGTERM at every moment,
also under floods, are in test_stops.py.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path
from typing import Iterator

import pytest
import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.srv import SetParameters
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from rigid_body_sim.ros.conversions import MAX_ROS_TIME_S
from rigid_body_sim.ros.diagnostics import level_name, status_values
from rigid_body_sim.ros.node import MAX_BODIES
from rigid_body_sim.testing import SimHarness, start_process, stop_process

pytestmark = pytest.mark.ros

SIM = "rigid_body_sim: simulation"
BALL = {"mass": 1.0, "inertia": {"sphere": 0.1}}


def write_scene(path: Path, names: list[str]) -> str:
    path.write_text(yaml.safe_dump({"bodies": {name: BALL for name in names}}))
    return str(path)


def clean_log(text: str) -> list[str]:
    """Lines of a node's output that are not its INFO log: what an operator would notice."""
    return [line for line in text.splitlines() if line.strip() and not line.startswith("[INFO]")]


# ---------------------------------------------------------------------- parameters


def test_one_request_naming_scene_twice_applies_the_last(tmp_path):
    """One parameter request naming ``scene`` twice loads the last one; nothing escapes into the
    executor (the scene prepared by the on-set callback is the one the post-set callback applies)."""
    a = write_scene(tmp_path / "a.yaml", ["p"])
    b = write_scene(tmp_path / "b.yaml", ["q"])
    with SimHarness(a, parameters={"scene_dirs": [str(tmp_path)]}) as harness:
        future = harness._parameters.set_parameters_atomically([Parameter("scene", value=a), Parameter("scene", value=b)])
        harness.spin_until(future.done, "the parameter service")
        assert future.result().result.successful
        assert harness.get_parameter("scene") == b
        assert harness.node.simulator.body_names == ("q",)
        harness.watch_body("q")
        harness.step()


@contextlib.contextmanager
def frequent_thread_switches(interval_s: float = 1e-5) -> Iterator[None]:
    """Let the interpreter switch threads every ``interval_s`` inside the block (its own interval
    is 5 ms), so that a race between threads shows in a few runs instead of a few hundred."""
    previous = sys.getswitchinterval()
    sys.setswitchinterval(interval_s)
    try:
        yield
    finally:
        sys.setswitchinterval(previous)


def test_scene_changes_from_two_threads_at_once_stay_consistent(tmp_path):
    """Two threads (an in-process client, a multi-threaded executor) change ``scene`` at once,
    20 times each, while the executor serves the node: each change is applied whole, one at a
    time, and the scene the node runs is always the one its parameter names. The endpoints each
    change replaces are destroyed from those threads while the executor builds its wait sets
    (threads switching every 10 µs): the executor never meets a destroyed one (InvalidHandle)."""
    scenes = [write_scene(tmp_path / f"s{k}.yaml", [f"body{k}", "shared"]) for k in range(4)]
    failures: list[BaseException] = []
    with SimHarness(scenes[0], paused=False, parameters={"scene_dirs": [str(tmp_path)]}) as harness:
        node = harness.node

        def hammer(offset: int) -> None:
            try:
                for k in range(20):
                    path = scenes[(offset + k) % len(scenes)]
                    result = node.set_parameters([Parameter("scene", value=path)])[0]
                    assert result.successful, result.reason
            except BaseException as exc:  # noqa: BLE001  (reported below)
                failures.append(exc)

        threads = [threading.Thread(target=hammer, args=(offset,)) for offset in (0, 1)]
        with frequent_thread_switches():
            for thread in threads:
                thread.start()
            harness.spin_until(lambda: not any(t.is_alive() for t in threads), "both threads", timeout=120.0)
        assert not failures, failures
        path = node.get_parameter("scene").value
        with node.locked_simulator() as sim:
            assert str(sim.scene.source) == path
            assert set(sim.body_names) == {f"body{scenes.index(path)}", "shared"}
        expected = sorted(f"/{b}/{t}" for b in sim.body_names for t in ("pose", "twist"))
        publishers = sorted(name for name, _ in node.get_publisher_names_and_types_by_node(node.get_name(), "/")
                            if name.endswith(("/pose", "/twist")))
        assert publishers == expected
        harness.spin_for(0.2)  # still ticking
        assert node.tick_failure is None


def test_contact_wrench_publishers_come_and_go_from_the_tick_thread_while_the_executor_spins():
    """``publish_contact_wrench`` switched on and off 10 times while running at 1 kHz: the tick
    thread creates and destroys the ``B/contact_wrench`` publishers while the executor builds its
    wait sets (threads switching every 10 µs); neither the executor nor the ticks raise."""
    scene = Path(__file__).resolve().parents[1] / "config" / "contact_resting_box_imu.yaml"
    with SimHarness(scene, paused=False, parameters={"rate_hz": 1000.0, "publish_contact_wrench": False}) as harness:
        node = harness.node
        with frequent_thread_switches():
            for k in range(10):
                on = k % 2 == 0
                assert all(r.successful for r in harness.set_parameters(publish_contact_wrench=on))
                harness.spin_until(lambda: node.count_publishers("crate/contact_wrench") == int(on),
                                   f"crate/contact_wrench {'made' if on else 'destroyed'} by the ticks")
        assert node.tick_failure is None


def test_parameter_and_service_hammering_while_running_at_1khz(tmp_path):
    """Rate, substeps, integrator and pause changed at random from a thread, ~/step, ~/reset and
    ~/set_paused called without pause from the executor, at 1 kHz: nothing raises, no change is
    half-applied (dt always equals real_time_factor / (rate_hz · substeps) of the parameters)."""
    import random

    rng = random.Random(0)
    scene = write_scene(tmp_path / "s.yaml", ["a", "b"])
    failures: list[BaseException] = []
    with SimHarness(scene, paused=False, parameters={"rate_hz": 1000.0, "diagnostics_period": 0.1}) as harness:
        node = harness.node
        stop = threading.Event()

        def change_parameters() -> None:
            try:
                while not stop.is_set():
                    changes = [Parameter("rate_hz", value=rng.choice([200.0, 1000.0, 2000.0])),
                               Parameter("substeps", value=rng.choice([1, 2, 5])),
                               Parameter("integrator", value=rng.choice(["rk4", "splitting", "euler"]))]
                    result = node.set_parameters_atomically(changes)
                    assert result.successful, result.reason
                    with node.locked_simulator() as sim:
                        values = {p.name: p.value for p in node.get_parameters(["rate_hz", "substeps", "real_time_factor"])}
                        assert sim.dt == values["real_time_factor"] / (values["rate_hz"] * values["substeps"])
            except BaseException as exc:  # noqa: BLE001  (reported below)
                failures.append(exc)

        thread = threading.Thread(target=change_parameters)
        thread.start()
        try:
            deadline = time.monotonic() + 3.0
            calls = 0
            while time.monotonic() < deadline:
                choice = rng.random()
                if choice < 0.4:
                    harness.call_step()
                elif choice < 0.6:
                    harness._call(harness._reset, __import__("std_srvs.srv", fromlist=["Trigger"]).Trigger.Request())
                else:
                    harness.set_paused(rng.random() < 0.5)
                calls += 1
        finally:
            stop.set()
            thread.join(timeout=30)
        assert not failures, failures
        assert node.tick_failure is None
        assert calls > 20
        assert harness.set_paused(False).success
        with node.locked_simulator() as sim:
            before = sim.time
        harness.spin_for(0.2)
        with node.locked_simulator() as sim:
            assert sim.time > before  # still ticking


def test_sim_time_at_the_end_of_ros_time_stops_loudly_and_reset_recovers(tmp_path):
    """With real_time_factor 1e6 at 0.001 Hz (1e9 s a tick) the third tick's stamp would not fit
    builtin_interfaces/Time (int32 seconds): the node refuses to advance past the end of ROS time,
    says so (~/step's reason, ERROR on /diagnostics) and keeps serving; ~/reset starts again."""
    scene = write_scene(tmp_path / "s.yaml", ["ball"])
    params = {"real_time_factor": 1e6, "rate_hz": 0.001, "integrator": "splitting", "diagnostics_period": 0.0}
    with SimHarness(scene, parameters=params) as harness:
        harness.step(2)
        assert harness.node.simulator.time == pytest.approx(2e9)
        refused = harness.call_step()
        assert not refused.success and "end of ROS time" in refused.message
        assert harness.node.simulator.time == pytest.approx(2e9)
        status = {s.name: s for s in harness.node.diagnostics().status}[SIM]
        assert level_name(status) == "ERROR" and str(MAX_ROS_TIME_S) in status.message
        assert harness.reset().success
        harness.step()
        assert harness.node.simulator.time == pytest.approx(1e9)
        assert level_name({s.name: s for s in harness.node.diagnostics().status}[SIM]) == "OK"


def test_record_path_fifo_is_refused_at_once_and_ticks_go_on(tmp_path):
    """``record_path:=`` a FIFO (opening it for writing would block until a reader appears) is refused
    with a reason, and the simulation never waits for it."""
    fifo = tmp_path / "record.mcap"  # named like a recording, inside record_dirs: the opener's own check refuses it
    os.mkfifo(fifo)
    with SimHarness(paused=False, parameters={"diagnostics_period": 0.0, "record_dirs": [str(tmp_path)]}) as harness:
        start = time.monotonic()
        result = harness.set_parameters_atomically(record_path=str(fifo))
        assert not result.successful and "is a FIFO" in result.reason
        assert time.monotonic() - start < 5.0
        assert harness.get_parameter("record_path") == ""
        with harness.node.locked_simulator() as sim:
            before = sim.time
        harness.spin_for(0.2)
        assert harness.node.simulator.time > before


def test_too_many_bodies_are_refused_and_ticks_go_on_while_loading(tmp_path):
    """A scene of more than MAX_BODIES bodies is refused with the limit in the reason, and the ticks
    go on while the file is loaded and checked."""
    big = write_scene(tmp_path / "big.yaml", [f"b{i}" for i in range(MAX_BODIES + 1)])
    with SimHarness(paused=False, parameters={"diagnostics_period": 0.0, "scene_dirs": [str(tmp_path)]}) as harness:
        with harness.node.locked_simulator() as sim:
            sim_before, wall_before = sim.time, time.monotonic()
        result = harness.set_parameters_atomically(scene=big)
        with harness.node.locked_simulator() as sim:
            sim_after, wall_after = sim.time, time.monotonic()
        assert not result.successful and f"at most {MAX_BODIES}" in result.reason
        assert harness.node.simulator.body_names == ("box",)
        # The tick thread kept sim time going while the executor thread was loading the file (up to
        # two ticks of 10 ms may fall outside a short wait).
        assert sim_after - sim_before >= 0.5 * (wall_after - wall_before) - 0.02


def test_an_alias_bomb_scene_change_is_refused_and_ticks_go_on(tmp_path):
    """A ~600-byte scene whose anchors expand to 10⁹ nodes (loaded, it would take the node's memory and
    time): the change is refused with the loader's reason, the scene stays, and the tick thread keeps
    sim time going while the file is refused."""
    bomb = "[" + ", ".join(["&a0 [" + ", ".join(["1"] * 10) + "]"]
                           + [f"&a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 9)]) + "]"
    path = tmp_path / "bomb.yaml"
    path.write_text(f"bodies: {{b: {{mass: {bomb}, inertia: {{sphere: 1}}}}}}\n")
    with SimHarness(paused=False, parameters={"diagnostics_period": 0.0, "scene_dirs": [str(tmp_path)]}) as harness:
        with harness.node.locked_simulator() as sim:
            sim_before, wall_before = sim.time, time.monotonic()
        result = harness.set_parameters_atomically(scene=str(path))
        time.sleep(0.3)  # running, not paused: the tick thread advances sim time meanwhile
        with harness.node.locked_simulator() as sim:
            sim_after, wall_after = sim.time, time.monotonic()
        assert not result.successful
        assert "at most 10,000,000 nodes with aliases expanded" in result.reason, result.reason
        assert harness.node.simulator.body_names == ("box",)
        assert wall_after - wall_before < 10.0  # refused at once (measured well under 1 s)
        assert sim_after - sim_before >= 0.5 * (wall_after - wall_before)
        assert harness.get_parameter("scene") != str(path)


def test_locked_simulator_holds_the_ticks():
    with SimHarness(paused=False, parameters={"diagnostics_period": 0.0}) as harness:
        harness.spin_for(0.1)
        with harness.node.locked_simulator() as sim:
            frozen = sim.time
            time.sleep(0.1)
            assert sim.time == frozen


# ---------------------------------------------------------------------- the node process

class Observer:
    """A participant of its own in this test process: /clock and /diagnostics of the node."""

    def __init__(self) -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node("hostile_observer", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.clock_ns: list[int] = []
        self.diagnostics: list[DiagnosticArray] = []
        self.node.create_subscription(Clock, "/clock", lambda m: self.clock_ns.append(m.clock.sec * 10**9 + m.clock.nanosec), 100)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.diagnostics.append, 100)

    def spin_until(self, condition, what: str, process: subprocess.Popen, log: Path, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            assert process.poll() is None, f"node exited with {process.returncode} waiting for {what}:\n{log.read_text()}"
            assert time.monotonic() < deadline, f"timed out waiting for {what}:\n{log.read_text()}"
            self.executor.spin_once(timeout_sec=0.02)

    def spin_for(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.02)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


#: Longest wait (s) for a node process to start: a fresh installation (colcon test in a new
#: workspace) compiles the numba kernels first, about 100 s here.
START_TIMEOUT_S = 600.0


def wait_until_started(process: subprocess.Popen, log: Path) -> None:
    """Wait for the node's start-up log line (the scene it runs)."""
    deadline = time.monotonic() + START_TIMEOUT_S
    while "scene " not in log.read_text():
        assert process.poll() is None, f"node exited with {process.returncode}:\n{log.read_text()}"
        assert time.monotonic() < deadline, f"no start-up in {START_TIMEOUT_S:g} s:\n{log.read_text()}"
        time.sleep(0.05)


def signal_and_wait(process: subprocess.Popen, signum: int, timeout: float = 15.0) -> tuple[int, float]:
    start = time.monotonic()
    process.send_signal(signum)
    try:
        code = process.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
        pytest.fail(f"no exit within {timeout} s of signal {signum}")
    return code, time.monotonic() - start


@pytest.mark.timeout(900)  # a fresh installation compiles the kernels first (START_TIMEOUT_S)
def test_sigstop_sigcont_the_node_resumes_and_counts_the_missed_ticks(tmp_path):
    """The node process stopped for 1.5 s (SIGSTOP) then continued: it resumes ticking at once
    (no burst of catch-up ticks beyond the catch-up limit), /diagnostics counts the ticks
    missed, and it still stops cleanly."""
    log = tmp_path / "node.log"
    process = start_process(["-p", "status_period:=0.0", "-p", "diagnostics_period:=0.5"], log)
    wait_until_started(process, log)
    observer = Observer()
    try:
        observer.spin_until(lambda: len(observer.clock_ns) > 20, "ticks", process, log)
        process.send_signal(signal.SIGSTOP)
        time.sleep(1.5)
        process.send_signal(signal.SIGCONT)
        resumed = len(observer.clock_ns)
        observer.spin_until(lambda: len(observer.clock_ns) > resumed + 50, "ticks after SIGCONT", process, log)
        observer.spin_until(lambda: any(int(status_values(s).get("ticks missed", 0)) > 50
                                        for array in observer.diagnostics for s in array.status if s.name == SIM),
                            "the missed ticks on /diagnostics", process, log)
        stamps = observer.clock_ns
        assert all(b > a for a, b in zip(stamps, stamps[1:])), "sim time went backwards"
        code, _took = signal_and_wait(process, signal.SIGINT)
    finally:
        observer.close()
        stop_process(process)
    assert code == 0, log.read_text()


FAILING_TICK = textwrap.dedent("""
    import os
    import sys
    from rigid_body_sim.ros.main import main
    from rigid_body_sim.ros.session import SimSession

    original = SimSession.advance
    trigger = os.environ["FAIL_TICK_TRIGGER"]

    def failing(self):
        if os.path.exists(trigger):
            raise ZeroDivisionError("float division by zero (injected into the first tick after the trigger)")
        original(self)

    SimSession.advance = failing
    sys.exit(main(sys.argv[1:]))
""")


@pytest.mark.timeout(900)  # a fresh installation compiles the kernels first (START_TIMEOUT_S)
def test_a_failing_tick_thread_is_loud_and_the_process_exits_1(tmp_path):
    """An exception in the tick thread (a ZeroDivisionError from the compiled step): the error and its
    traceback are logged, /diagnostics says ERROR at once, and the process exits 1."""
    script = tmp_path / "failing_node.py"
    script.write_text(FAILING_TICK)
    trigger = tmp_path / "fail_now"
    log = tmp_path / "node.log"
    with open(log, "w") as out:
        process = subprocess.Popen([sys.executable, str(script), "--ros-args", "-p", "status_period:=0.0",
                                    "-p", "diagnostics_period:=0.5"], stdout=out, stderr=subprocess.STDOUT,
                                   env={**os.environ, "FAIL_TICK_TRIGGER": str(trigger)})
    wait_until_started(process, log)
    observer = Observer()
    try:
        # The tick fails only once the observer has heard the node's /diagnostics (so it is
        # matched with that publisher and cannot miss the ERROR for discovery's sake).
        observer.spin_until(lambda: observer.diagnostics, "a first /diagnostics", process, log)
        # Then no periodic report for a minute: the ERROR must be the report sent at once.
        client = observer.node.create_client(SetParameters, "/rigid_body_sim/set_parameters")
        assert client.wait_for_service(timeout_sec=30.0), "the node's parameter service never appeared"
        request = SetParameters.Request(parameters=[Parameter("diagnostics_period", value=60.0).to_parameter_msg()])
        future = client.call_async(request)
        observer.executor.spin_until_future_complete(future, timeout_sec=30.0)
        assert future.done() and future.result().results[0].successful, future.result()
        heard_before = len(observer.diagnostics)
        trigger.touch()
        deadline = time.monotonic() + 60.0
        while process.poll() is None and time.monotonic() < deadline:
            observer.executor.spin_once(timeout_sec=0.02)
        observer.spin_for(0.5)
    finally:
        observer.close()
        stop_process(process)
    text = log.read_text()
    assert process.returncode == 1, text
    assert "tick thread failed" in text and "ZeroDivisionError" in text and "Traceback" in text
    assert "exiting with status 1" in text
    before = [s for array in observer.diagnostics[:heard_before] for s in array.status if s.name == SIM]
    assert before and all(level_name(s) != "ERROR" for s in before), before
    errors = [s for array in observer.diagnostics[heard_before:] for s in array.status
              if s.name == SIM and level_name(s) == "ERROR"]
    assert errors and "tick thread failed" in errors[0].message
    # Nothing else failed: after the injected error, no second traceback.
    assert len(re.findall("Traceback", text)) == 1, text


STUCK_TICK = textwrap.dedent("""
    import sys
    import time
    from rigid_body_sim.ros.main import main
    from rigid_body_sim.ros.session import SimSession

    original = SimSession.advance
    ticks = [0]

    def stuck(self):
        ticks[0] += 1
        if ticks[0] == 100:
            print("tick 100: stuck", flush=True)
            time.sleep(3600)  # as a step of days would (the reference integrator, dt = 1e9 s)
        return original(self)

    SimSession.advance = stuck
    sys.exit(main(sys.argv[1:]))
""")


@pytest.mark.timeout(900)  # a fresh installation compiles the kernels first (START_TIMEOUT_S)
def test_a_stuck_tick_keeps_the_node_answering_and_sigterm_still_ends_it(tmp_path):
    """A tick that does not end (found with integrator reference and real_time_factor 1e6: one
    step of 1e9 s takes weeks; or 1000 bodies × 100,000 substeps): messages are still taken,
    ~/reset is refused as busy within a second, /diagnostics reports the running tick, and a
    signal ends the process after STOP_GRACE_S with a complete recording (exit 1: forced)."""
    from mcap.reader import make_reader
    from std_srvs.srv import Trigger

    from rigid_body_sim.ros.main import STOP_GRACE_S

    script = tmp_path / "stuck_node.py"
    script.write_text(STUCK_TICK)
    log = tmp_path / "node.log"
    record = tmp_path / "run.mcap"
    with open(log, "w") as out:
        process = subprocess.Popen([sys.executable, str(script), "--ros-args", "-p", "status_period:=0.0",
                                    "-p", "diagnostics_period:=0.2", "-p", f"record_path:={record}"],
                                   stdout=out, stderr=subprocess.STDOUT, env=os.environ.copy())
    wait_until_started(process, log)
    observer = Observer()
    try:
        observer.spin_until(lambda: "tick 100: stuck" in log.read_text(), "the stuck tick", process, log)
        observer.spin_until(lambda: any(s.name == SIM and "busy" in s.message for a in observer.diagnostics
                                        for s in a.status), "/diagnostics to report the running tick", process, log)
        reset = observer.node.create_client(Trigger, "/rigid_body_sim/reset")
        observer.spin_until(reset.service_is_ready, "~/reset", process, log)
        future = reset.call_async(Trigger.Request())
        start = time.monotonic()
        observer.spin_until(future.done, "the ~/reset answer", process, log)
        assert time.monotonic() - start < 5.0
        assert not future.result().success and "busy" in future.result().message
        code, took = signal_and_wait(process, signal.SIGTERM, timeout=STOP_GRACE_S + 15.0)
    finally:
        observer.close()
        stop_process(process)
    text = log.read_text()
    assert code == 1 and f"did not stop within {STOP_GRACE_S:g} s" in text, text
    assert STOP_GRACE_S - 0.5 < took < STOP_GRACE_S + 10.0
    with open(record, "rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None and summary.statistics.message_count > 0


def rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError(f"no VmRSS for pid {pid}")


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_long_run_at_1khz(tmp_path):
    """Ten tumbling bodies at 1 kHz for 120 s, observed over DDS: /clock never goes back, memory
    stays flat after the first 10 s, nothing is logged above INFO, SIGINT exits 0. Prints the
    tick rate and lateness (a shared machine delays ticks; the rate is checked only loosely)."""
    scene = tmp_path / "ten.yaml"
    scene.write_text(yaml.safe_dump({"bodies": {f"b{i}": {"mass": 1.0, "inertia": {"box": [1, 2, 3]},
                                                           "twist": {"angular": [0.3, 1.0, 0.2]}} for i in range(10)}}))
    log = tmp_path / "node.log"
    process = start_process(["-p", f"scene:={scene}", "-p", "rate_hz:=1000.0", "-p", "status_period:=0.0",
                             "-p", "diagnostics_period:=10.0"], log)
    wait_until_started(process, log)
    observer = Observer()
    clock_wall: list[tuple[float, int]] = []
    observer.node.create_subscription(Clock, "/clock", lambda m: clock_wall.append(
        (time.monotonic(), m.clock.sec * 10**9 + m.clock.nanosec)), 1000)
    try:
        observer.spin_until(lambda: len(clock_wall) > 100, "ticks", process, log)
        observer.spin_for(10.0)
        rss_start, wall_start = rss_kib(process.pid), time.monotonic()
        observer.spin_until(lambda: time.monotonic() - wall_start > 110.0, "the run", process, log, timeout=200.0)
        rss_end = rss_kib(process.pid)
        code, _took = signal_and_wait(process, signal.SIGINT)
    finally:
        observer.close()
        stop_process(process)
    text = log.read_text()
    window = [(w, ns) for w, ns in clock_wall if w >= wall_start]
    rate = (window[-1][1] - window[0][1]) * 1e-9 / 1e-3 / (window[-1][0] - window[0][0])
    stamps = [ns for _w, ns in clock_wall]
    reports = [status_values(s) for a in observer.diagnostics for s in a.status if s.name == SIM]
    print(f"\n[1 kHz, 10 bodies, 120 s] tick rate {rate:.1f}/s from /clock, RSS {rss_start} -> {rss_end} KiB; "
          + "; ".join(f"lateness median/p99/max {r['tick lateness median [ms]']}/{r['tick lateness p99 [ms]']}/"
                      f"{r['tick lateness max [ms]']} ms, missed {r['ticks missed']}" for r in reports))
    assert code == 0 and not clean_log(text), text
    assert all(b > a for a, b in zip(stamps, stamps[1:]))
    assert rss_end - rss_start < 4096
    assert rate > 500.0
