"""Flood: four processes publish at 10× the tick rate each at the node process (slow);
``test_flood_in_process_short`` is a 1.5 s in-process version for the default suite.

The node runs as ``rigid_body_sim_node`` (its console script) at 100 Hz; four publisher
processes (flood_publisher.py) each send 1000 messages/s for ``FLOOD_S`` seconds:

- ``b0/wrench`` and ``b1/wrench``: one constant force each at the centre of mass
  (``B/world_aligned``): ten copies per tick of a hold that must be *replaced*, not added;
- ``b2/impulse``: a constant linear impulse J = 2⁻¹⁰ N·s, which must all be applied (J/m is a
  power of two, so the velocity is an exact count of the impulses applied);
- ``b3/wrench``: hostile messages (NaN, ±Inf, 1e300, unknown and 100 kB frame_ids), all dropped.

Measured from outside, as an operator would: the tick rate from /clock stamps (sim time
advanced / dt per wall second) before and during the flood; the node's RSS from
/proc/<pid>/status; its /diagnostics; and the twists. Expected: the rate holds (≥ 90 % of the
no-flood baseline, which is the benchmark figure here), RSS is flat during the flood (history
depth 10 everywhere), the holds are replaced not summed (b0's velocity counts at most one force
per tick), they expire ``wrench_timeout`` after the flood, every hostile message is counted
and none moves b3.
"""

from __future__ import annotations

import bisect
import json
import math
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Twist, WrenchStamped
from rclpy.context import Context
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from rigid_body_sim.ros.diagnostics import level_name, status_values
from rigid_body_sim.testing import SimHarness, start_process, stop_process

pytestmark = pytest.mark.ros

RATE_HZ = 100.0
DT = 1.0 / RATE_HZ
FLOOD_RATE_HZ = 10 * RATE_HZ  # per publisher process
FLOOD_S = 12.0
BASELINE_S = 4.0
WRENCH_TIMEOUT = 0.2  # s of sim time
MASS = 2.0
IMPULSE = 2.0**-10  # N·s; J/m = 2⁻¹¹ exactly
FORCES = {"b0": (2.0, 0.0, 0.0), "b1": (0.0, -3.0, 0.0)}
SCENE = {"bodies": {b: {"mass": MASS, "inertia": {"sphere": 0.2}} for b in ("b0", "b1", "b2", "b3")}}
PUBLISHER = Path(__file__).with_name("flood_publisher.py")
RSS_FLAT_KIB = 2048  # growth allowed between 2 s into the flood and its end


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process so far, s (/proc/<pid>/stat fields 14 and 15)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError(f"no VmRSS for pid {pid}")


class Observer:
    """The test's own participant: /clock, /diagnostics and the twists, with wall receipt times."""

    def __init__(self):
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node("flood_observer", context=self.context)
        self.executor = EventsExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.clock: list[tuple[float, int]] = []  # (wall s, sim ns)
        self.diagnostics: list[tuple[float, dict]] = []
        self.twists: dict[str, Twist] = {}
        self.node.create_subscription(Clock, "/clock", self._on_clock, 100)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        for body in SCENE["bodies"]:
            self.node.create_subscription(Twist, f"/{body}/twist", lambda m, b=body: self.twists.__setitem__(b, m), 10)

    def _on_clock(self, msg: Clock) -> None:
        self.clock.append((time.monotonic(), msg.clock.sec * 1_000_000_000 + msg.clock.nanosec))

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        self.diagnostics.append((time.monotonic(), {s.name: s for s in msg.status}))

    def spin_for(self, seconds: float, every=None) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.05)
            if every is not None:
                every()

    def tick_rate(self, start: float, end: float) -> float:
        """Ticks per wall second between two wall times, from the sim stamps on /clock."""
        inside = [(w, ns) for w, ns in self.clock if start <= w <= end]
        assert len(inside) >= 2, f"no /clock between {start} and {end}"
        (w0, ns0), (w1, ns1) = inside[0], inside[-1]
        return (ns1 - ns0) * 1e-9 / DT / (w1 - w0)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def start_flooder(topic: str, frame: str, mode: str, force=(1.0, 0.0, 0.0)) -> tuple[subprocess.Popen, list[str]]:
    process = subprocess.Popen(
        [sys.executable, str(PUBLISHER), "--topic", topic, "--frame", frame, "--mode", mode,
         "--force", *(repr(float(f)) for f in force), "--rate", str(FLOOD_RATE_HZ), "--duration", str(FLOOD_S)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=os.environ.copy())
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(iter(process.stdout.readline, "")), daemon=True).start()
    return process, lines


@pytest.mark.slow
def test_flood_keeps_rate_memory_and_holds(tmp_path):
    scene_path = tmp_path / "flood.yaml"
    scene_path.write_text(yaml.safe_dump(SCENE))
    log_path = tmp_path / "node.log"
    node = start_process(["-p", f"scene:={scene_path}", "-p", "integrator:=semi_implicit_euler",
                          "-p", f"rate_hz:={RATE_HZ}", "-p", f"wrench_timeout:={WRENCH_TIMEOUT}",
                          "-p", "status_period:=0.0", "-p", "diagnostics_period:=1.0"], log_path)
    observer = Observer()
    flooders: list[tuple[subprocess.Popen, list[str]]] = []
    rss: list[tuple[float, int]] = []

    def sample_rss() -> None:
        assert node.poll() is None, f"the node exited with {node.returncode}:\n{log_path.read_text()[-3000:]}"
        if not rss or time.monotonic() - rss[-1][0] >= 0.25:
            rss.append((time.monotonic(), rss_kib(node.pid)))

    try:
        deadline = time.monotonic() + 30.0
        while len(observer.clock) < 10:
            assert time.monotonic() < deadline, f"no /clock from the node:\n{log_path.read_text()}"
            observer.spin_for(0.1, sample_rss)
        observer.spin_for(2.0, sample_rss)  # warm-up
        base_start = time.monotonic()
        observer.spin_for(BASELINE_S, sample_rss)
        base_end = time.monotonic()
        rss_before = rss[-1][1]

        flooders = [start_flooder("/b0/wrench", "b0/world_aligned", "wrench", FORCES["b0"]),
                    start_flooder("/b1/wrench", "b1/world_aligned", "wrench", FORCES["b1"]),
                    start_flooder("/b2/impulse", "b2/world_aligned", "impulse", (IMPULSE, 0.0, 0.0)),
                    start_flooder("/b3/wrench", "b3", "hostile")]
        deadline = time.monotonic() + 30.0
        ready: dict[int, float] = {}  # flooder → when its "ready" was seen (it starts right after)
        while len(ready) < len(flooders):
            assert time.monotonic() < deadline, f"flooders not ready: {[lines for _p, lines in flooders]}"
            observer.spin_for(0.02, sample_rss)
            ready.update({i: time.monotonic() for i, (_p, lines) in enumerate(flooders) if i not in ready and "ready\n" in lines})
        # All four flood between the last start and the first end.
        flood_start, cpu_start = max(ready.values()), cpu_seconds(node.pid)
        observer.spin_for(min(ready.values()) + FLOOD_S - 0.3 - time.monotonic(), sample_rss)
        flood_end, cpu_end = time.monotonic(), cpu_seconds(node.pid)
        assert flood_end - flood_start > FLOOD_S / 2, "the flooders started too far apart"
        results = []
        for process, lines in flooders:
            process.wait(timeout=30)
            observer.spin_for(0.0)
            results.append(json.loads([line for line in lines if line.startswith("{")][-1]))
        observer.spin_for(2.5, sample_rss)  # holds expire (0.2 s of sim time); a diagnostics window passes
        rss_after = rss[-1][1]
        assert node.poll() is None, log_path.read_text()[-3000:]
    finally:
        for process, _lines in flooders:
            if process.poll() is None:
                process.kill()
                process.wait()
            process.stdout.close()
        observer.close()
        stop_process(node, timeout=15)
    assert node.returncode == 0, log_path.read_text()[-3000:]

    # Rate: /clock stamps, before and during the flood (first and last second left out).
    base_rate = observer.tick_rate(base_start, base_end)
    flood_rate = observer.tick_rate(flood_start + 1.0, flood_end)
    published = [r["published"] for r in results]
    offered = sum(published) / FLOOD_S

    # Memory: flat during the flood.
    during = [kib for wall, kib in rss if flood_start + 2.0 <= wall <= flood_end]
    growth_during = during[-1] - during[0]

    # Diagnostics: windows wholly inside the flood, and the last one after it.
    inside = [s for wall, s in observer.diagnostics if flood_start + 1.2 <= wall <= flood_end]
    assert inside, "no /diagnostics during the flood"
    last = observer.diagnostics[-1][1]
    node_name = "rigid_body_sim"
    sim_inside = [status_values(s[f"{node_name}: simulation"]) for s in inside]
    input_inside = [s[f"{node_name}: input"] for s in inside]
    final_sim = status_values(last[f"{node_name}: simulation"])
    final_input = status_values(last[f"{node_name}: input"])

    # Holds: replaced, not summed. b0 gained exactly F/m·dt per tick it was held (an integer
    # count), for about the FLOOD_S seconds of flooding plus the timeout; ten messages a tick added
    # up instead of replacing each other would give ten times as much.
    ticks_in_flood = flood_rate * FLOOD_S
    held_ticks = {}
    for body, force in FORCES.items():
        twist = observer.twists[body]
        axis = 0 if force[0] else 1
        v = [twist.linear.x, twist.linear.y, twist.linear.z]
        n = v[axis] / (force[axis] / MASS * DT)
        held_ticks[body] = n
        assert abs(n - round(n)) < 1e-6, (body, n)
        assert all(v[i] == 0.0 for i in range(3) if i != axis), (body, v)
        assert 0.8 * ticks_in_flood <= n <= 1.05 * RATE_HZ * (FLOOD_S + 1.0) + WRENCH_TIMEOUT / DT, (body, n)
    impulses_applied = observer.twists["b2"].linear.x / (IMPULSE / MASS)
    assert impulses_applied == int(impulses_applied) and 0 < impulses_applied <= published[2]
    b3 = observer.twists["b3"]
    assert [b3.linear.x, b3.linear.y, b3.linear.z, b3.angular.x, b3.angular.y, b3.angular.z] == [0.0] * 6

    print(f"\n[flood] node at {RATE_HZ:g} Hz; 4 publishers × {FLOOD_RATE_HZ:g} msg/s for {FLOOD_S:g} s "
          f"(published {published}, {offered:.0f} msg/s offered)")
    print(f"[flood] tick rate from /clock: {base_rate:.2f} /s before, {flood_rate:.2f} /s during the flood")
    print(f"[flood] node diagnostics during the flood: tick rate "
          f"{[float(v['tick rate [1/s]']) for v in sim_inside]}, lateness median/max ms "
          f"{[(v['tick lateness median [ms]'], v['tick lateness max [ms]']) for v in sim_inside]}, "
          f"held wrenches {[v['held wrenches'] for v in sim_inside]}")
    taken = [sum(int(v) for k, v in status_values(s).items() if k.endswith("(window)"))
             / float(sim_values["window [s]"]) for s, sim_values in zip(input_inside, sim_inside)]
    print(f"[flood] input status during the flood: {[level_name(s) + ': ' + s.message for s in input_inside[:2]]}")
    print(f"[flood] messages taken by the node: {[round(t) for t in taken]} /s of {offered:.0f} offered; node CPU "
          f"{(cpu_end - cpu_start) / (flood_end - flood_start):.0%} of one core during the flood")
    print(f"[flood] node RSS: {rss_before} KiB before, {during[0]} → {during[-1]} KiB during (Δ {growth_during} KiB), "
          f"{rss_after} KiB after")
    print(f"[flood] held ticks b0/b1: {held_ticks}, ticks in flood {ticks_in_flood:.0f}; impulses applied on b2: "
          f"{impulses_applied:.0f} of {published[2]} published ({impulses_applied / published[2]:.1%}); "
          f"after: held {final_sim['held wrenches']}, rejected totals "
          f"{ {k: v for k, v in final_input.items() if k.endswith('(total)')} }")

    assert flood_rate >= 0.9 * base_rate, (flood_rate, base_rate)
    assert growth_during <= RSS_FLAT_KIB, rss
    assert all(v["held wrenches"] == "2" for v in sim_inside), sim_inside
    assert all(level_name(s) == "WARN" and "non_finite" in s.message for s in input_inside)
    assert final_sim["held wrenches"] == "0" and final_sim["pending impulses"] == "0"
    assert int(final_input["rejected non_finite (total)"]) > 0 and int(final_input["rejected unknown_frame (total)"]) > 0
    assert int(final_input["rejected too_large (total)"]) > 0
    assert not math.isnan(flood_rate)


def median_bin_rate(stamps: list[tuple[float, float]], bin_s: float = 0.1) -> float:
    """The median over ``bin_s`` wall-clock bins of the tick rate, 1/s, from (wall time s, sim time s)
    pairs sampled as the executor spins: a single stall of the host (another process, the GC) empties a
    few bins and leaves the median, unlike the rate over the whole window."""
    walls = [wall for wall, _ in stamps]
    rates = []
    for k in range(int((walls[-1] - walls[0]) / bin_s)):
        lo = bisect.bisect_right(walls, walls[0] + k * bin_s) - 1  # the last sample at or before the bin
        hi = bisect.bisect_right(walls, walls[0] + (k + 1) * bin_s) - 1
        rates.append(round((stamps[hi][1] - stamps[lo][1]) / DT) / bin_s)
    return statistics.median(rates)


def test_flood_in_process_short(tmp_path):
    """The default suite's flood: in-process, 1.5 s, one publisher at 10× the tick rate alternating a
    valid force with a NaN one. The node keeps ticking (the median over 0.1 s bins of its tick rate at
    ≥ 80 % of the same median in the 1 s before the flood, on the same shared thread: the machine's
    load is in both, and one stall of the host moves neither median), the hold is replaced rather than
    summed, it acts on the ticks that follow each valid message the node took and on no others (a NaN
    neither clears nor extends it), it expires after the flood, the NaNs taken are counted.

    Which messages the node takes, of those that overflow its queue, is the host's scheduling: the
    ticks the hold acts on are bounded from the takes seen, not from the messages sent."""
    scene_path = tmp_path / "flood.yaml"
    scene_path.write_text(yaml.safe_dump({"bodies": {"b0": SCENE["bodies"]["b0"]}}))
    parameters = {"integrator": "semi_implicit_euler", "wrench_timeout": 0.05, "diagnostics_period": 0.0}
    with SimHarness(scene_path, parameters=parameters, paused=False) as node:
        good, bad = WrenchStamped(), WrenchStamped()
        good.header.frame_id = bad.header.frame_id = "b0/world_aligned"
        good.wrench.force.x = FORCES["b0"][0]
        bad.wrench.force.x = math.nan
        publisher = node._publishers[("b0", "wrench")]
        simulator = node.node.simulator
        quiet = time.monotonic()
        quiet_stamps = []
        while time.monotonic() - quiet < 1.0:
            node.executor.spin_once(timeout_sec=0.0005)
            quiet_stamps.append((time.monotonic(), simulator.time))
        node.node.diagnostics()  # a fresh window: the flood's lateness
        start_time, sent, held = simulator.time, 0, set()
        takes = []  # (ticks done before, ticks done after) the spin_once that took a valid message
        start = time.monotonic()
        flood_stamps = []

        def spin_once() -> None:
            before, accepted = round(simulator.time / DT), node.node.accepted_messages
            node.executor.spin_once(timeout_sec=0.0005)
            held.add(len(node.node.held_wrenches))
            if node.node.accepted_messages > accepted:
                takes.append((before, round(simulator.time / DT)))

        while time.monotonic() - start < 1.5:
            if sent < (time.monotonic() - start) * FLOOD_RATE_HZ:
                publisher.publish(good if sent % 2 else bad)
                sent += 1
            spin_once()
            flood_stamps.append((time.monotonic(), simulator.time))
        window = status_values(node.node.diagnostics().status[0])
        ticks = round((simulator.time - start_time) / DT)
        after = time.monotonic()
        while time.monotonic() - after < 0.3:  # the queue's last messages; the hold expires 0.05 s after
            spin_once()
        assert node.node.held_wrenches == {}
        v = simulator.body_state("b0").linear_velocity_world
        n = v[0] / (FORCES["b0"][0] / MASS * DT)
        rejected = node.node.rejected["non_finite"]
        taken = node.messages_seen()
    quiet_rate, flood_rate = median_bin_rate(quiet_stamps), median_bin_rate(flood_stamps)
    print(f"\n[flood, in-process] {sent} messages in 1.5 s; {ticks} ticks (median rate over 0.1 s bins "
          f"{flood_rate:g} /s against {quiet_rate:g} /s before the flood; over the whole window "
          f"{window['tick rate [1/s]']} /s, lateness median {window['tick lateness median [ms]']} ms, max "
          f"{window['tick lateness max [ms]']} ms); hold applied on {n:.0f} ticks; the node took {taken} messages "
          f"(the rest overflowed the depth-10 queue), {rejected} of them NaN and counted")
    # A message taken while `before` ticks were done and before `after` were: the first tick to apply
    # it is `before` + 1 or later (+ 2 if a tick was past its inputs when it came), `after` + 2 at the
    # latest; the timeout (5 ticks) then holds it on that tick and the next 4, maybe 5 (sim time is a sum).
    surely = set().union(*(range(after + 2, before + 6) for before, after in takes))
    maybe = set().union(*(range(before + 1, after + 8) for before, after in takes))
    print(f"valid messages taken: {len(takes)}; the hold acts on {len(surely)} to {len(maybe)} ticks")
    assert abs(n - round(n)) < 1e-9 and len(surely) <= round(n) <= len(maybe)
    assert len(surely) >= 4
    assert held <= {0, 1}
    assert flood_rate >= 0.8 * quiet_rate
    assert 0 < rejected <= sent // 2 + sent % 2 and taken <= sent
