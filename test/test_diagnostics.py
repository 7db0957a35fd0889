"""``/diagnostics``: what the node tells an operator, and when it says WARN or ERROR.

The statuses are read as an operator's tool would, from diagnostic_msgs/DiagnosticArray messages
received over DDS, except where a test needs one exact window (``node.diagnostics()`` closes the
window and returns the array the timer would publish).
"""

from __future__ import annotations

import math
import time

import pytest
import yaml
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

from rigid_body_sim.ros.diagnostics import (
    LATENESS_SAMPLES,
    REJECTION_REASONS,
    TickWindow,
    level_name,
    status_values,
)
from rigid_body_sim.testing import SimHarness

pytestmark = pytest.mark.ros

SIM = "rigid_body_sim: simulation"
INPUT = "rigid_body_sim: input"


def by_name(array: DiagnosticArray) -> dict[str, DiagnosticStatus]:
    return {status.name: status for status in array.status}


def listen(harness: SimHarness) -> list[DiagnosticArray]:
    received: list[DiagnosticArray] = []
    harness.client.create_subscription(DiagnosticArray, "/diagnostics", received.append, 10)
    harness.spin_until(lambda: harness.node.count_subscribers("/diagnostics") > 0, "the /diagnostics subscription")
    return received


def test_published_about_every_period_with_every_field():
    with SimHarness(paused=False, parameters={"diagnostics_period": 0.25}) as node:
        received = listen(node)
        start = time.monotonic()
        node.spin_until(lambda: len(received) >= 5, "five DiagnosticArray messages", timeout=10.0)
        elapsed = time.monotonic() - start
        assert 5 * 0.25 * 0.5 < elapsed < 5 * 0.25 * 3.0  # about the period; loose for a loaded machine
        statuses = by_name(received[-1])
        assert set(statuses) == {SIM, INPUT}
        for status in statuses.values():
            assert status.hardware_id == "none"  # diagnostic_updater's value for software without hardware
        sim = status_values(statuses[SIM])
        assert sim["integrator"] == "rk4" and float(sim["dt [s]"]) == 0.01 and sim["substeps"] == "1"
        for key in ("tick rate [1/s]", "tick lateness median [ms]", "tick lateness p99 [ms]", "tick lateness max [ms]",
                    "ticks missed",
                    "real-time factor measured", "bodies stopped for blow-up", "held wrenches", "pending impulses"):
            assert key in sim, key
        assert float(sim["tick rate [1/s]"]) > 20.0  # 100 Hz set; anything alive passes on a busy machine
        assert 0.0 <= float(sim["tick lateness median [ms]"]) <= float(sim["tick lateness p99 [ms]"]) \
            <= float(sim["tick lateness max [ms]"])
        assert sim["bodies stopped for blow-up"] == "0" and sim["held wrenches"] == "0"
        inputs = status_values(statuses[INPUT])
        for reason in REJECTION_REASONS:
            assert inputs[f"rejected {reason} (window)"] == "0" and inputs[f"rejected {reason} (total)"] == "0"
        assert level_name(statuses[INPUT]) == "OK"


def test_rejections_warn_for_one_window_and_count_by_reason():
    with SimHarness(parameters={"diagnostics_period": 0.0, "wrench_timeout": 0.0}) as node:
        node.node.diagnostics()  # close the start-up window
        node.publish_wrench("box", force=(1.0, 0.0, 0.0), frame_id="map")
        node.publish_wrench("box", force=(float("nan"), 0.0, 0.0), frame_id="box")
        node.publish_impulse("box", linear=(1e13, 0.0, 0.0), frame_id="box")
        node.publish_wrench("box", force=(1.0, 0.0, 0.0), frame_id="box")  # accepted, held
        statuses = by_name(node.node.diagnostics())
        inputs = statuses[INPUT]
        assert level_name(inputs) == "WARN"
        assert inputs.message == "rejected 3 of 4 messages (unknown_frame: 1, non_finite: 1, too_large: 1)"
        values = status_values(inputs)
        assert values["rejected unknown_frame (window)"] == "1" and values["accepted (window)"] == "1"
        assert status_values(statuses[SIM])["held wrenches"] == "1"
        # The next window saw nothing new: OK again, totals kept.
        later = by_name(node.node.diagnostics())[INPUT]
        assert level_name(later) == "OK"
        assert status_values(later)["rejected unknown_frame (total)"] == "1"


def test_a_stopped_body_is_an_error(tmp_path):
    scene = {"bodies": {"feather": {"mass": 1e-300, "inertia": {"sphere": 1.0}},
                        "box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}}}}
    path = tmp_path / "two.yaml"
    path.write_text(yaml.safe_dump(scene))
    with SimHarness(path, parameters={"integrator": "euler", "wrench_timeout": 0.0, "diagnostics_period": 0.0}) as node:
        node.publish_wrench("feather", force=(1e12, 0.0, 0.0), frame_id="world")
        node.step(3)
        sim = by_name(node.node.diagnostics())[SIM]
        assert level_name(sim) == "ERROR"
        assert sim.message == "stopped for blow-up: feather"
        assert status_values(sim)["bodies stopped for blow-up"] == "1"
        assert status_values(sim)["stopped bodies"] == "feather"
        node.reset()  # reset clears the stop
        assert level_name(by_name(node.node.diagnostics())[SIM]) == "OK"


def test_falling_behind_is_a_warning_with_the_lateness():
    """100,000 rk4 substeps of the box per 10 ms tick take about 20 ms (the compiled core steps one
    body in about 0.2 µs; 400 substeps were enough for the numpy core, not for it): the
    node cannot keep 100 Hz, and says so, with a lateness above one period and missed ticks."""
    with SimHarness(paused=False, parameters={"substeps": 100_000, "diagnostics_period": 0.0}) as node:
        node.spin_for(0.3)
        node.node.diagnostics()  # a fresh window, already running
        node.spin_for(1.0)
        sim = by_name(node.node.diagnostics())[SIM]
        values = status_values(sim)
        assert level_name(sim) == "WARN", values
        assert sim.message.startswith("behind: ")
        assert float(values["tick rate [1/s]"]) < 90.0
        assert float(values["tick lateness max [ms]"]) > 10.0 and int(values["ticks missed"]) > 0
        assert float(values["real-time factor measured"]) < 0.9


def test_diagnostics_period_zero_stops_and_a_change_applies():
    with SimHarness(parameters={"diagnostics_period": 0.0}) as node:
        received = listen(node)
        node.spin_for(0.6)
        assert received == []
        assert node.set_parameters_atomically(diagnostics_period=0.1).successful
        node.spin_until(lambda: len(received) >= 3, "three messages at 10 Hz", timeout=5.0)
        refused = node.set_parameters_atomically(diagnostics_period=-1.0)
        assert not refused.successful and "diagnostics_period" in refused.reason
        assert node.get_parameter("diagnostics_period") == 0.1
        assert node.set_parameters_atomically(diagnostics_period=0).successful  # a whole number is taken
        count = len(received)
        node.spin_for(0.4)
        assert len(received) <= count + 1  # at most one already on its way


def test_tick_window_measures_against_the_schedule():
    window = TickWindow(sim_time=0.0)
    now = time.monotonic_ns()
    period = 10_000_000  # 10 ms
    window.record(now - 2_000_000, period)  # 2 ms late
    window.record(now - 4_000_000, period)  # 4 ms late
    window.record(now - 25_000_000, period)  # 25 ms late: two periods missed
    window.record(now + 1_000_000_000, period)  # "early" (clock granularity): counted as 0 late
    assert window.ticks == 4 and window.missed_ticks == 2
    assert 25_000_000 <= window.max_lateness_ns < 26_000_000
    assert 2_000_000 <= window.median_lateness_ns() < 4_000_000 + 1_000_000  # median of 0, 2, 4, 25 ms
    for _ in range(LATENESS_SAMPLES + 5):  # bounded: only the last LATENESS_SAMPLES are kept
        window.record(now, period)
    assert len(window._lateness_ns) == LATENESS_SAMPLES
    window.reopen(sim_time=1.0)
    assert window.ticks == 0 and window.max_lateness_ns == 0 and window.sim_time_at_open == 1.0


def test_tick_window_p99_and_missed_ticks_given_by_the_caller():
    window = TickWindow(sim_time=0.0)
    assert math.isnan(window.p99_lateness_ns())
    now = time.monotonic_ns()
    for k in range(200):  # lateness k ms + the time since `now`: the 198th smallest (nearest rank) is k = 197's
        window.record(now - 1_000_000 * k, 10_000_000, missed=0)
    since = time.monotonic_ns() - now  # record() reads the clock itself: each lateness is later by at most this
    assert 197_000_000 <= window.p99_lateness_ns() <= 197_000_000 + since
    assert window.missed_ticks == 0  # the caller said none were skipped, whatever the lateness
    window.record(now - 60_000_000, 10_000_000, missed=6)
    assert window.missed_ticks == 6


def test_tick_window_opens_at_the_first_tick_not_at_start_up():
    window = TickWindow(sim_time=0.0)
    assert window.elapsed_s() == 0.0  # no tick yet: nothing to measure, nothing behind
    time.sleep(0.3)  # start-up: imports, compile, endpoints
    period = 10_000_000
    first_due = time.monotonic_ns()
    for k in range(10):  # ten ticks on schedule, 10 ms apart
        while time.monotonic_ns() < first_due + k * period:
            time.sleep(0.0005)
        window.record(first_due + k * period, period)
    # The window is the 90 ms (and change) since the first tick, not the 390 ms since it was built.
    assert 0.09 <= window.elapsed_s() < 0.25
    assert window.opened_ns == first_due


def test_a_healthy_start_is_ok_from_the_first_message(tmp_path):
    """The node as a process: its first /diagnostics message says OK with a real-time factor near 1,
    whatever the start-up (imports, scene, endpoints) took before the first tick."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    from rigid_body_sim.testing import start_process, stop_process

    # 5 Hz: even a heavily loaded machine keeps up, while start-up (seconds) would still be counted
    # against the first 2 s window if the window opened when the node was built.
    process = start_process(["-p", "diagnostics_period:=2.0", "-p", "paused:=false", "-p", "rate_hz:=5.0"],
                            tmp_path / "node.log")
    context = Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    peer = Node("diagnostics_listener", context=context)
    executor.add_node(peer)
    received: list[DiagnosticArray] = []
    try:
        peer.create_subscription(DiagnosticArray, "/diagnostics", received.append, 10)
        deadline = time.monotonic() + 60.0
        while not received and time.monotonic() < deadline and process.poll() is None:
            executor.spin_once(timeout_sec=0.1)
        assert received, f"no /diagnostics message; node log:\n{(tmp_path / 'node.log').read_text()}"
        statuses = by_name(received[0])
        sim = status_values(statuses[SIM])
        assert level_name(statuses[SIM]) == "OK", statuses[SIM].message
        assert float(sim["real-time factor measured"]) > 0.9, sim
    finally:
        executor.shutdown()
        peer.destroy_node()
        rclpy.try_shutdown(context=context)
        assert stop_process(process) == 0
