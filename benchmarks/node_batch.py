"""Node benchmark with batched output: 1, 100, 1000, 10 000 bodies over DDS.

For each (bodies, rate_hz) and each repeat, ``rigid_body_sim_node`` runs as a subprocess on N
free asymmetric bodies (random poses and spins, no gravity), rk4, 1 substep,
``per_body_topics:=false``, on a private ROS_DOMAIN_ID over loopback; this process subscribes
to ``poses`` (transient local, raw CDR bytes, rclpy's EventsExecutor in a thread) before the
node starts. Measured:

* ``first_poses_s``: from just before ``Popen`` to the arrival of the first ``poses`` message
  (the one the node publishes when it is built, kept for late joiners): what a user waits;
* over a window of ``seconds`` after a 2 s settle: ``sim_over_wall`` = sim span of the
  received stamps / wall span of their arrivals; ``delivered`` = distinct stamps received /
  ticks the node made in that span (sim span / tick + 1); ``achieved_hz`` = ticks made / wall
  span;
* ``cpu_ms_per_tick``: the node's CPU time (user + system, /proc) over the window / ticks made;
* ``rss_mb``: the node's resident memory at the end of the window;
* ``stop_s`` and ``exit``: SIGINT to exit, and the exit status.

With "recording" the node also records to an MCAP file (``record_path``; with
``per_body_topics:=false`` it records the two batches a tick as published).

Each figure is the median over the repeats, with the min-max beside it. The subscriber shares
the 2 cores with the node (and with whatever else runs): a lost message may be the
subscriber's. Run: ``python -m benchmarks.node_batch [--quick] [--out benchmarks/results]``
(``make bench-node``).
"""

from __future__ import annotations

import argparse
import os
import signal
import struct
import subprocess
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import yaml

from . import machine

REPO = Path(__file__).resolve().parent.parent
NODE = REPO / ".venv" / "bin" / "rigid_body_sim_node"
DOMAIN_ID = 78
SETTLE_S = 2.0
#: (bodies, rate_hz, recording): the target sizes and rates, and 1000 bodies recording (``record_path``).
CASES = ((1, 100.0, False), (100, 100.0, False), (1000, 100.0, False), (1000, 100.0, True), (10_000, 100.0, False),
         (100, 1000.0, False))


def write_scene(directory: Path, n: int, seed: int = 0) -> Path:
    """``n`` free asymmetric bodies at random poses with random spins, no gravity."""
    rng = np.random.default_rng(seed)
    bodies = {}
    for k in range(n):
        q = rng.normal(size=4)
        bodies[f"b{k}"] = {"mass": 1.0, "inertia": {"box": [1.0, 0.6, 0.4]},
                           "pose": {"position": (10.0 * rng.normal(size=3)).tolist(), "orientation": (q / np.linalg.norm(q)).tolist()},
                           "twist": {"linear": rng.normal(size=3).tolist(), "angular": (2.0 * rng.normal(size=3)).tolist()}}
    path = directory / f"free_{n}.yaml"
    path.write_text(yaml.safe_dump({"bodies": bodies}))
    return path


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def measure(scene: Path, n: int, rate_hz: float, seconds: float, record: Path | None = None) -> dict:
    """One run of the node on ``scene`` (recording to ``record`` if given): the figures of the module docstring."""
    import rclpy
    from geometry_msgs.msg import PoseArray
    from rclpy.context import Context
    from rclpy.experimental import EventsExecutor
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, QoSProfile

    context = Context()
    rclpy.init(context=context, domain_id=DOMAIN_ID)
    node = Node("batch_bench", context=context)
    executor = EventsExecutor(context=context)
    executor.add_node(node)
    arrivals: list[tuple[float, int]] = []
    stamp = struct.Struct("<iI")

    def on_poses(data: bytes) -> None:
        sec, nanosec = stamp.unpack_from(data, 4)
        arrivals.append((time.monotonic(), sec * 1_000_000_000 + nanosec))

    node.create_subscription(PoseArray, "/poses", on_poses,
                             QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL), raw=True)
    stop = threading.Event()
    spinner = threading.Thread(target=lambda: [executor.spin_once(timeout_sec=0.05) for _ in iter(stop.is_set, True)],
                               daemon=True)
    spinner.start()
    env = {**os.environ, "ROS_DOMAIN_ID": str(DOMAIN_ID), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    log = tempfile.NamedTemporaryFile("w+", suffix=".log", delete=False)
    start = time.monotonic()
    process = subprocess.Popen([str(NODE), "--ros-args", "-p", f"scene:={scene}", "-p", f"rate_hz:={rate_hz}",
                                "-p", "per_body_topics:=false", "-p", "status_period:=0.0", "-p", "integrator:=rk4",
                                "-p", "substeps:=1", *(["-p", f"record_path:={record}"] if record else [])],
                               stdout=log, stderr=subprocess.STDOUT, env=env)
    row: dict = {"bodies": n, "rate_hz": rate_hz, "recording": record is not None}
    try:
        deadline = start + 120.0
        while not arrivals and time.monotonic() < deadline and process.poll() is None:
            time.sleep(0.005)
        if not arrivals:
            raise RuntimeError(f"no poses from the node ({n} bodies); log {log.name}")
        row["first_poses_s"] = arrivals[0][0] - start
        time.sleep(SETTLE_S)
        cpu0, k0 = _cpu_seconds(process.pid), len(arrivals)
        time.sleep(seconds)
        cpu1, k1 = _cpu_seconds(process.pid), len(arrivals)
        row["rss_mb"] = _rss_mb(process.pid)
        window = arrivals[k0:k1]
        wall = window[-1][0] - window[0][0]
        sim = (window[-1][1] - window[0][1]) * 1e-9
        ticks = round(sim * rate_hz)
        row["sim_over_wall"] = sim / wall
        row["achieved_hz"] = ticks / wall
        row["delivered"] = len({s for _, s in window}) / (ticks + 1)
        row["cpu_ms_per_tick"] = (cpu1 - cpu0) / max(ticks, 1) * 1e3
        row["cpu_share"] = (cpu1 - cpu0) / wall
        sent = time.monotonic()
        process.send_signal(signal.SIGINT)
        row["exit"] = process.wait(timeout=30)
        row["stop_s"] = time.monotonic() - sent
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        stop.set()
        spinner.join()
        executor.shutdown()
        node.destroy_node()
        context.try_shutdown()
    return row


def _median_row(rows: list[dict]) -> dict:
    out = {"bodies": rows[0]["bodies"], "rate_hz": rows[0]["rate_hz"], "recording": rows[0]["recording"],
           "repeats": len(rows)}
    for key in ("first_poses_s", "sim_over_wall", "achieved_hz", "delivered", "cpu_ms_per_tick", "cpu_share",
                "rss_mb", "stop_s"):
        values = np.array([r[key] for r in rows])
        out[key], out[key + "_min"], out[key + "_max"] = float(np.median(values)), float(values.min()), float(values.max())
    out["exits"] = sorted({r["exit"] for r in rows})
    return out


def markdown(rows: list[dict]) -> str:
    """The table of node_batch.md."""
    lines = ["| bodies | rate (Hz) | recording | sim/wall | ticks delivered to a `poses` subscriber | CPU per tick (ms) | CPU share (cores) "
             "| RSS (MB) | start to first `poses` (s) | SIGINT to exit (s), exit status |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        def f(key, fmt):
            return f"{r[key]:{fmt}} ({r[key + '_min']:{fmt}}–{r[key + '_max']:{fmt}})"
        lines.append(f"| {r['bodies']} | {r['rate_hz']:g} | {'yes' if r['recording'] else 'no'} | {f('sim_over_wall', '.3f')} | {f('delivered', '.1%')} "
                     f"| {f('cpu_ms_per_tick', '.3f')} | {f('cpu_share', '.2f')} | {f('rss_mb', '.0f')} "
                     f"| {f('first_poses_s', '.2f')} | {f('stop_s', '.2f')}, {r['exits']} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="3 repeats of 5 s windows (default 5 of 10 s)")
    parser.add_argument("--repeats", type=int)
    parser.add_argument("--seconds", type=float)
    parser.add_argument("--bodies", type=int, nargs="*", help="only these body counts")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results")
    args = parser.parse_args(argv)
    repeats = args.repeats or (3 if args.quick else 5)
    seconds = args.seconds or (5.0 if args.quick else 10.0)
    cases = [c for c in CASES if not args.bodies or c[0] in args.bodies]
    rows = []
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as directory:
        for n, rate, recording in cases:
            scene = write_scene(Path(directory), n)
            runs = [measure(scene, n, rate, seconds, Path(directory) / f"run{k}.mcap" if recording else None)
                    for k in range(repeats)]
            rows.append(_median_row(runs))
            print(markdown(rows[-1:]).splitlines()[-1], flush=True)
    text = (f"# Node with batched output ({repeats} repeats, {seconds:g} s windows; medians, min–max)\n\n"
            + __doc__.split("\n\n", 1)[1] + "\n" + machine.text()
            + f"    load average before the runs: {' '.join(f'{x:.2f}' for x in load_before)}\n\n" + markdown(rows))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "node_batch.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
