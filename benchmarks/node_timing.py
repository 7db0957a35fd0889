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
messages/s) competes with the node, and a lost message may be the subscriber's.
"""

from __future__ import annotations

import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from rigid_body_sim.testing import stop_process

DOMAIN_ID = 77
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


def measure(rate_hz: float, bodies: int, seconds: float, latency_trials: int = 5, log=print) -> dict:
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
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
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    qos = QoSProfile(depth=1000)
    lock = threading.Lock()
    clock: list[tuple[float, int]] = []                         # (arrival s, stamp ns)
    poses: dict[str, set[int]] = {}
    twists: dict[str, int] = {}
    b0_vx: list[tuple[float, float]] = []                       # (arrival, linear x) of b0/twist
    recording = [False]
    watched = [f"b{i}" for i in range(bodies)] if bodies * rate_hz <= 10000 else ["b0", f"b{bodies - 1}"]

    def on_clock(msg):
        now = time.monotonic()
        if recording[0]:
            clock.append((now, msg.clock.sec * 1_000_000_000 + msg.clock.nanosec))

    def on_pose(name):
        def cb(msg):
            if recording[0]:
                poses[name].add(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
        return cb

    def on_twist(name):
        def cb(msg):
            now = time.monotonic()
            if recording[0]:
                twists[name] += 1
            if name == "b0":
                with lock:
                    b0_vx.append((now, msg.linear.x))
        return cb

    node.create_subscription(Clock, "/clock", on_clock, qos)
    for name in watched:
        poses[name], twists[name] = set(), 0
        node.create_subscription(PoseStamped, f"{name}/pose", on_pose(name), qos)
        node.create_subscription(Twist, f"{name}/twist", on_twist(name), qos)
    wrench_pub = node.create_publisher(WrenchStamped, "b0/wrench", qos)

    proc = subprocess.Popen([str(NODE), "--ros-args", "-p", f"scene:={scene}", "-p", f"rate_hz:={float(rate_hz)}",
                             "-p", "status_period:=0.0", "-p", "wrench_timeout:=0.0"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    spin = threading.Thread(target=executor.spin, daemon=True)
    spin.start()
    result = {"rate_hz": rate_hz, "bodies": bodies, "seconds": seconds, "watched_bodies": len(watched)}
    try:
        t_start = time.monotonic()
        while not b0_vx and time.monotonic() - t_start < 30.0:
            if proc.poll() is not None:
                raise RuntimeError(f"node exited: {proc.stderr.read().decode()[-2000:]}")
            time.sleep(0.05)
        if not b0_vx:
            raise RuntimeError("no b0/twist within 30 s of starting the node")
        time.sleep(1.0)  # settle (first ticks, discovery of every subscription)
        cpu0, w0 = _cpu_seconds(proc.pid), time.monotonic()
        recording[0] = True
        time.sleep(seconds)
        recording[0] = False
        cpu1, w1 = _cpu_seconds(proc.pid), time.monotonic()
        result["cpu_share"] = (cpu1 - cpu0) / (w1 - w0)
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
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        spin.join(timeout=2)
    log(f"  node rate={rate_hz} bodies={bodies}: " + ", ".join(
        f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in result.items()))
    return result


def sweep(rates: list[float], counts: list[int], seconds: float, log=print) -> list[dict]:
    rows = []
    for bodies in counts:
        for rate in rates:
            try:
                rows.append(measure(rate, bodies, seconds, log=log))
            except Exception as exc:  # report, keep going
                log(f"  node rate={rate} bodies={bodies}: FAILED {exc}")
                rows.append({"rate_hz": rate, "bodies": bodies, "seconds": seconds, "error": str(exc)})
    return rows


if __name__ == "__main__":
    print(measure(float(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])))
