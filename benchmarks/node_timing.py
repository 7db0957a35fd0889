"""Node timing, measured from another process over DDS.

For each (rate_hz, bodies) the node runs as a subprocess
(``.venv/bin/rigid_body_sim_node --ros-args -p scene:=... -p rate_hz:=... -p status_period:=0``)
on a private ROS_DOMAIN_ID with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, and this process
subscribes to it. Over a window of ``seconds``:

* achieved tick rate and sim/wall ratio from /clock: (ticks − 1) / wall span and sim span /
  wall span, the wall time being this process's arrival time (time.monotonic);
* tick lateness, proxied by /clock arrivals: inter-arrival jitter Δt − 1/rate_hz (median,
  p99, max), and schedule lateness = arrival − (first arrival + sim time elapsed / rtf),
  shifted so its minimum is 0 (grows without bound when the node falls behind);
* CPU share of the node: Δ(utime + stime) of /proc/<pid>/stat over the window / wall span;
* delivery: for every body subscribed, pose messages whose stamp equals a /clock tick of
  the window's interior, and twist message count (Twist has no stamp), against the ticks;
* wrench→pose latency: a WrenchStamped (100 N along x in ``b0/world_aligned``, b0 moving at
  constant velocity or at rest, no damping) is published; latency = arrival of the first
  ``b0/twist`` whose linear x velocity changed, minus the publish time (the node publishes
  b0's pose and twist in the same tick, pose first). A zero wrench then clears the hold.

Both processes share a loaded 2-core machine: the subscriber's own CPU (about 2·N·rate
messages/s) competes with the node, and a lost message may be the subscriber's. To keep that
share small, the subscriber takes every message serialized (``raw=True``) and reads only what
it needs from the CDR bytes (stamp, or b0's linear x velocity). It spins with rclpy's public
``rclpy.experimental.EventsExecutor`` (C++ event queue; no wait set rebuilt per wake) in a
thread; ``executor="single"`` takes the SingleThreadedExecutor instead, which rebuilds its wait
set over all 201 subscriptions at every wake and, at 100 bodies × 100 Hz on a loaded machine,
fell far behind the node it was measuring (seen: 13 of 100 ticks/s received). The earlier
listener held one private ``_rclpy.WaitSet`` for the whole run; it is gone (no private APIs).
The listener's own CPU share is recorded (``listener_cpu_share``: this process's user + system
time over the window) — seen ≈ 0.4 of a core at 100 bodies × 100 Hz with the EventsExecutor.
When the subscriber still falls behind, the arrival-based figures measure it, not the node;
so the node's own account is recorded too, from its /diagnostics windows that closed inside
the measurement window (``node_*``: sim/wall over those windows; the lowest window tick rate;
tick lateness as the median of the window medians, the median and the largest of the window
p99s, and the largest maximum; ticks missed). The node targets are judged on the node's own
account.
"""

from __future__ import annotations

import os
import statistics
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from rigid_body_sim.testing import stop_process

DOMAIN_ID = 77
#: The listener's rclpy executor (see the module docstring for the measured choice).
LISTENER_EXECUTOR = "events"
REPO = Path(__file__).resolve().parent.parent
NODE = REPO / ".venv" / "bin" / "rigid_body_sim_node"


def _write_scene(directory: Path, count: int) -> Path:
    lines = ["bodies:"]
    for i in range(count):
        angular = "[0.0, 0.0, 0.0]" if i == 0 else "[0.3, 1.0, 0.2]"
        lines += [f"  b{i}:", "    mass: 2.0", "    inertia: {box: [1.0, 0.6, 0.4]}",
                  f"    pose: {{position: [{10.0 * i}, 0.0, 0.0], orientation: [0, 0, 0, 1]}}",
                  f"    twist: {{linear: [0.0, 0.0, 0.0], angular: {angular}}}"]
    path = directory / f"bench_{count}_bodies.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime, stime


def _percentiles(x: list[float]) -> tuple[float, float, float]:
    if not x:
        return (float("nan"),) * 3
    a = np.asarray(x)
    return float(np.median(a)), float(np.percentile(a, 99)), float(a.max())


def _spin(executor, context, stop: threading.Event) -> None:
    """Spin ``executor`` (rclpy's public executors; the listener node added) until ``stop``."""
    while not stop.is_set() and context.ok():
        executor.spin_once(timeout_sec=0.05)


def _make_executor(kind: str, context):
    """The listener's executor: ``single`` (SingleThreadedExecutor) or ``events`` (rclpy.experimental.EventsExecutor)."""
    if kind == "single":
        from rclpy.executors import SingleThreadedExecutor
        return SingleThreadedExecutor(context=context)
    if kind == "events":
        from rclpy.experimental import EventsExecutor
        return EventsExecutor(context=context)
    raise ValueError(f"`executor` must be one of ('single', 'events'), got {kind!r}")


def _own_cpu_seconds() -> float:
    """CPU seconds (user + system) of this whole process: the listener's cost."""
    return _cpu_seconds(os.getpid())


def measure(rate_hz: float, bodies: int, seconds: float, latency_trials: int = 5, executor: str = LISTENER_EXECUTOR,
            log=print) -> dict:
    import rclpy
    from rclpy.context import Context
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.qos import QoSProfile
    from geometry_msgs.msg import PoseStamped, Twist, WrenchStamped
    from rosgraph_msgs.msg import Clock

    env = dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN_ID), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    os.environ.update(ROS_DOMAIN_ID=str(DOMAIN_ID), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    tmp = Path(tempfile.mkdtemp(prefix="rbs_bench_"))
    scene = _write_scene(tmp, bodies)
    context = Context()
    rclpy.init(context=context, domain_id=DOMAIN_ID)
    node = rclpy.create_node("bench_listener", context=context)
    qos = QoSProfile(depth=1000)
    lock = threading.Lock()
    clock: list[tuple[float, int]] = []                         # (arrival s, stamp ns)
    poses: dict[str, set[int]] = {}
    twists: dict[str, int] = {}
    b0_vx: list[tuple[float, float]] = []                       # (arrival, linear x) of b0/twist
    recording = [False]
    watched = [f"b{i}" for i in range(bodies)] if bodies * rate_hz <= 10000 else ["b0", f"b{bodies - 1}"]

    # Raw CDR: a 4-byte encapsulation header, then Clock = (sec, nanosec); PoseStamped starts
    # with header.stamp = (sec, nanosec); Twist starts with linear.x (float64). Byte order from
    # the header's representation identifier (0x0001: little endian).
    def stamp_ns(data: bytes) -> int:
        sec, nanosec = struct.unpack_from("<iI" if data[1] == 1 else ">iI", data, 4)
        return sec * 1_000_000_000 + nanosec

    def on_clock(data):
        now = time.monotonic()
        if recording[0]:
            clock.append((now, stamp_ns(data)))

    def on_pose(name):
        def cb(data):
            if recording[0]:
                poses[name].add(stamp_ns(data))
        return cb

    def on_twist(name):
        def cb(data):
            now = time.monotonic()
            if recording[0]:
                twists[name] += 1
            if name == "b0":
                (vx,) = struct.unpack_from("<d" if data[1] == 1 else ">d", data, 4)
                with lock:
                    b0_vx.append((now, vx))
        return cb

    diagnostics: list[dict[str, str]] = []

    def on_diagnostics(msg):
        if recording[0]:
            for status in msg.status:
                if status.name.endswith(": simulation"):
                    diagnostics.append({kv.key: kv.value for kv in status.values})

    node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, qos)
    node.create_subscription(Clock, "/clock", on_clock, qos, raw=True)
    for name in watched:
        poses[name], twists[name] = set(), 0
        node.create_subscription(PoseStamped, f"{name}/pose", on_pose(name), qos, raw=True)
        node.create_subscription(Twist, f"{name}/twist", on_twist(name), qos, raw=True)
    wrench_pub = node.create_publisher(WrenchStamped, "b0/wrench", qos)

    proc = subprocess.Popen([str(NODE), "--ros-args", "-p", f"scene:={scene}", "-p", f"rate_hz:={float(rate_hz)}",
                             "-p", "status_period:=0.0", "-p", "wrench_timeout:=0.0"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    stop = threading.Event()
    spinner = _make_executor(executor, context)
    spinner.add_node(node)
    spin = threading.Thread(target=_spin, args=(spinner, context, stop), daemon=True)
    spin.start()
    result = {"rate_hz": rate_hz, "bodies": bodies, "seconds": seconds, "watched_bodies": len(watched),
              "listener_executor": executor}
    try:
        t_start = time.monotonic()
        while not b0_vx and time.monotonic() - t_start < 30.0:
            if proc.poll() is not None:
                raise RuntimeError(f"node exited: {proc.stderr.read().decode()[-2000:]}")
            time.sleep(0.05)
        if not b0_vx:
            raise RuntimeError("no b0/twist within 30 s of starting the node")
        time.sleep(1.0)  # settle (first ticks, discovery of every subscription)
        cpu0, own0, w0 = _cpu_seconds(proc.pid), _own_cpu_seconds(), time.monotonic()
        recording[0] = True
        time.sleep(seconds)
        recording[0] = False
        cpu1, own1, w1 = _cpu_seconds(proc.pid), _own_cpu_seconds(), time.monotonic()
        result["cpu_share"] = (cpu1 - cpu0) / (w1 - w0)
        result["listener_cpu_share"] = (own1 - own0) / (w1 - w0)
        windows = diagnostics[1:]  # the first opened before the measurement window
        if windows:
            result["node_windows"] = len(windows)
            result["node_sim_wall"] = ((float(windows[-1]["sim time [s]"]) - float(diagnostics[0]["sim time [s]"]))
                                       / sum(float(d["window [s]"]) for d in windows))
            result["node_tick_rate_min"] = min(float(d["tick rate [1/s]"]) for d in windows)
            result["node_late_med_ms"] = float(statistics.median(float(d["tick lateness median [ms]"]) for d in windows))
            if all("tick lateness p99 [ms]" in d for d in windows):
                p99s = [float(d["tick lateness p99 [ms]"]) for d in windows]
                result["node_late_p99_ms_med"], result["node_late_p99_ms_max"] = float(statistics.median(p99s)), max(p99s)
            result["node_late_max_ms"] = max(float(d["tick lateness max [ms]"]) for d in windows)
            result["node_ticks_missed"] = sum(int(d["ticks missed"]) for d in windows)
        arrivals = np.array([a for a, _ in clock])
        stamps = np.array([s for _, s in clock], dtype=np.int64)
        period = 1.0 / rate_hz
        if len(clock) > 2:
            span = arrivals[-1] - arrivals[0]
            result["ticks"] = len(clock)
            result["achieved_hz"] = (len(clock) - 1) / span
            result["sim_wall"] = (stamps[-1] - stamps[0]) * 1e-9 / span
            gaps = np.diff(arrivals) - period
            result["jitter_med_ms"], result["jitter_p99_ms"], result["jitter_max_ms"] = (
                1e3 * v for v in _percentiles(list(gaps)))
            late = (arrivals - arrivals[0]) - (stamps - stamps[0]) * 1e-9  # rtf = 1
            late -= late.min()
            result["late_med_ms"], result["late_p99_ms"], result["late_max_ms"] = (
                1e3 * v for v in _percentiles(list(late)))
            interior = set(stamps[5:-5].tolist())
            result["pose_every_tick_frac"] = min(len(interior & poses[n]) for n in watched) / max(len(interior), 1)
            result["twist_per_tick_min"] = min(twists[n] for n in watched) / len(clock)
        # wrench → twist latency
        while wrench_pub.get_subscription_count() == 0:
            time.sleep(0.01)
        latencies = []
        for k in range(latency_trials):
            with lock:
                vx_before = b0_vx[-1][1]
                n_before = len(b0_vx)
            msg = WrenchStamped()
            msg.header.frame_id = "b0/world_aligned"
            msg.wrench.force.x = 100.0 if k % 2 == 0 else -100.0
            t_pub = time.monotonic()
            wrench_pub.publish(msg)
            hit = None
            while hit is None and time.monotonic() - t_pub < 2.0:
                with lock:
                    for a, vx in b0_vx[n_before:]:
                        if abs(vx - vx_before) > 1e-9:
                            hit = a
                            break
                if hit is None:
                    time.sleep(0.0002)
            wrench_pub.publish(WrenchStamped(header=msg.header))  # zero wrench: clear the hold
            if hit is not None:
                latencies.append(hit - t_pub)
            time.sleep(0.1 + 3 * period)
        result["latency_med_ms"] = 1e3 * statistics.median(latencies) if latencies else float("nan")
        result["latency_max_ms"] = 1e3 * max(latencies) if latencies else float("nan")
        result["latency_trials"] = len(latencies)
    finally:
        stop_process(proc, timeout=10)
        stop.set()
        spin.join(timeout=2)
        spinner.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    log(f"  node rate={rate_hz} bodies={bodies}: " + ", ".join(
        f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in result.items()))
    return result


def sweep(rates: list[float], counts: list[int], seconds: float, log=print, executor: str = LISTENER_EXECUTOR) -> list[dict]:
    rows = []
    for bodies in counts:
        for rate in rates:
            try:
                rows.append(measure(rate, bodies, seconds, executor=executor, log=log))
            except Exception as exc:  # report, keep going
                log(f"  node rate={rate} bodies={bodies}: FAILED {exc}")
                rows.append({"rate_hz": rate, "bodies": bodies, "seconds": seconds, "error": str(exc)})
    return rows


if __name__ == "__main__":
    print(measure(float(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])))
