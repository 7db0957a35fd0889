"""The node benchmark: batched output, shared inputs, up to 100,000 bodies, over DDS.

For each case (bodies, rate_hz, recording) and each repeat, ``rigid_body_sim_node`` runs as a
subprocess on N free asymmetric bodies (random poses and spins, no gravity; the scene file in
JSON, which the loader reads ~20× faster than YAML), rk4, 1 substep,
``per_body_topics:=false`` (so the inputs are the three shared topics ``wrench``, ``impulse``,
``set_state``), with the ``poses`` publisher's history depth of each ``--publisher-depth`` (1, the
node's own: the latest state; 10: for a consumer of every tick), on a private ROS_DOMAIN_ID over loopback. A plain rclpy subscriber to
``poses`` runs in a third process (``rclpy.spin`` on one node: raw CDR bytes, reliable,
transient local, keep last ``--depth``, default 10, as a user writes it), started and matched
before the node. Measured:

* ``first_poses_s``: from just before the node's ``Popen`` to the arrival of the first
  ``poses`` (the one the node publishes when it is built, kept for late joiners): what a user
  waits, Python start, scene loading and kernel cache loading included;
* over a window of ``seconds`` after a settle: ``sim_over_wall`` = sim span of the received
  stamps / wall span of their arrivals; ``delivered`` = distinct stamps received / ticks the
  node made in that span (sim span / tick + 1);
* ``cpu_ms_per_tick``: the node's CPU time (user + system, /proc) over the window / ticks made;
* ``rss_mb``: the node's resident memory at the end of the window;
* ``stop_s`` and ``exit``: SIGINT to exit, and the exit status;
* with a recording (``record_path``; the two batches a tick): ``recorded`` = ``poses``
  messages in the finished file / ticks the node made from its first to its last recorded
  stamp. The recording keeps up when it holds every tick and sim/wall stays >= 0.99.

Each figure is the median over the repeats, with the min-max beside it. The subscriber and
the node share the machine's cores (and with whatever else runs): a lost message may be the
subscriber's. The targets table compares the medians with the node's targets. Run:
``python -m benchmarks.node_batch [--quick] [--bodies 10000 100000] [--out benchmarks/results]``
(``make bench-node``).
"""

from __future__ import annotations

import argparse
import fcntl
import os
import select
import signal
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from . import machine

REPO = Path(__file__).resolve().parent.parent
NODE = REPO / ".venv" / "bin" / "rigid_body_sim_node"
#: ROS domain ids the runs may take (Fast DDS's safe ones, test/conftest.py): each run holds one
#: with the tests' lock files, so a benchmark and a test session never share a domain.
DOMAIN_IDS = tuple(range(1, 102)) + tuple(range(215, 233))
#: Settle (s) after the first ``poses`` before the window: the first ticks catch up on start-up work.
SETTLE_S = 3.0
#: (bodies, rate_hz, recording): the small sizes, and the two targets with and without a recording.
CASES = ((1, 100.0, False), (100, 100.0, False), (1000, 100.0, False), (100, 1000.0, False),
         (10_000, 100.0, False), (10_000, 100.0, True), (100_000, 10.0, False), (100_000, 10.0, True))
#: (bodies, rate_hz): the node's targets for these cases (recording or not).
TARGETS = {(10_000, 100.0): {"first_poses_s": ("<=", 5.0), "rss_mb": ("<=", 1024.0),
                             "sim_over_wall": (">=", 0.99), "delivered": (">=", 0.99)},
           (100_000, 10.0): {"first_poses_s": ("<=", 30.0), "rss_mb": ("<=", 4096.0),
                             "sim_over_wall": (">=", 0.99), "delivered": (">=", 0.99)}}


def write_scene(directory: Path, n: int, seed: int = 0) -> Path:
    """``n`` free asymmetric bodies at random poses with random spins, no gravity: JSON (YAML's
    subset, read by the loader's json fast path), one body a line, numbers to 6 digits."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    p, v, w = 10.0 * rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), 2.0 * rng.normal(size=(n, 3))

    def flow(row) -> str:
        return "[" + ", ".join(f"{x:.6g}" for x in row) + "]"

    lines = [f'"b{k}": {{"mass": 1.0, "inertia": {{"box": [1.0, 0.6, 0.4]}}, "pose": {{"position": {flow(p[k])}, '
             f'"orientation": {flow(q[k])}}}, "twist": {{"linear": {flow(v[k])}, "angular": {flow(w[k])}}}}}'
             for k in range(n)]
    path = directory / f"free_{n}.yaml"  # JSON is YAML; a run-time scene must be .yaml
    path.write_text('{"bodies": {\n' + ",\n".join(lines) + "\n}}\n")
    return path


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def listen(out: Path, depth: int) -> int:
    """The subscriber process: a plain rclpy node spinning one raw ``poses`` subscription.

    Prints ``ready`` once subscribed; on SIGINT writes (arrival time.monotonic(), stamp ns) of
    every message to ``out`` (.npy, shape (k, 2) float64 and int64 as two arrays).
    """
    import rclpy
    from geometry_msgs.msg import PoseArray
    from rclpy.executors import ExternalShutdownException
    from rclpy.qos import DurabilityPolicy, QoSProfile

    arrivals: list[float] = []
    stamps: list[int] = []
    stamp = struct.Struct("<iI")

    def on_poses(data: bytes) -> None:
        arrivals.append(time.monotonic())
        sec, nanosec = stamp.unpack_from(data, 4)
        stamps.append(sec * 1_000_000_000 + nanosec)
        if len(arrivals) == 1:
            print("first", flush=True)

    try:
        with rclpy.init():
            node = rclpy.create_node("poses_listener")
            node.create_subscription(PoseArray, "/poses", on_poses,
                                     QoSProfile(depth=depth, durability=DurabilityPolicy.TRANSIENT_LOCAL), raw=True)
            print("ready", flush=True)
            rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    np.savez(out, arrival=np.array(arrivals), stamp=np.array(stamps, dtype=np.int64))
    return 0


def _count_recorded(path: Path, rate_hz: float) -> float:
    """``poses`` messages in the recording / ticks from its first to its last ``poses`` stamp."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        channel = next(c.id for c in summary.channels.values() if c.topic.endswith("poses"))
        count = summary.statistics.channel_message_counts.get(channel, 0)
        first = last = None
        for _schema, ch, message in reader.iter_messages(topics=[summary.channels[channel].topic]):
            first = message.log_time if first is None else first
            last = message.log_time
    if not count or first is None:
        return 0.0
    return count / (round((last - first) * 1e-9 * rate_hz) + 1)


def claim_domain() -> tuple[int, object]:
    """A ROS domain id no test session or other run holds (the lock of test/conftest.py), and its open lock file."""
    for k in range(len(DOMAIN_IDS)):
        domain = DOMAIN_IDS[(os.getpid() + k) % len(DOMAIN_IDS)]
        try:
            lock = open(f"/tmp/rigid_body_sim_ros_domain_{domain}.lock", "a+")  # noqa: SIM115 - held for the run
        except OSError:
            continue
        try:
            fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        return domain, lock
    raise RuntimeError("every ROS domain id is held by another process")


def measure(scene: Path, n: int, rate_hz: float, seconds: float, depth: int, record: Path | None = None,
            domain: int = 78, publisher_depth: int = 1) -> dict:
    """One run of the node on ``scene`` (recording to ``record`` if given): the figures of the module docstring."""
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    work = Path(tempfile.mkdtemp(prefix="node_batch_"))
    arrivals_file = work / "arrivals.npz"
    listener = subprocess.Popen([sys.executable, "-m", "benchmarks.node_batch", "--listen", str(arrivals_file),
                                 "--depth", str(depth)], cwd=REPO, env=env, stdout=subprocess.PIPE, text=True)
    if listener.stdout.readline().strip() != "ready":
        listener.kill()
        raise RuntimeError("the poses listener did not start")
    log = open(work / "node.log", "w+")
    start = time.monotonic()
    process = subprocess.Popen([str(NODE), "--ros-args", "-p", f"scene:={scene}", "-p", f"rate_hz:={rate_hz}",
                                "-p", "per_body_topics:=false", "-p", "status_period:=0.0", "-p", "integrator:=rk4",
                                "-p", "substeps:=1", *(["-p", f"record_path:={record}"] if record else []),
                                *(["-p", f"qos_overrides./poses.publisher.depth:={publisher_depth}"]
                                  if publisher_depth != 1 else [])],
                               stdout=log, stderr=subprocess.STDOUT, env=env)
    row: dict = {"bodies": n, "rate_hz": rate_hz, "recording": record is not None, "publisher_depth": publisher_depth}
    try:
        # The listener says "first" at the first poses (its arrival time is in its file).
        ready, _, _ = select.select([listener.stdout], [], [], 180.0)
        if not ready or listener.stdout.readline().strip() != "first":
            raise RuntimeError(f"no poses from the node ({n} bodies) within 180 s; log {log.name}")
        time.sleep(SETTLE_S)
        window_start = time.monotonic()
        cpu0 = _cpu_seconds(process.pid)
        time.sleep(seconds)
        cpu1 = _cpu_seconds(process.pid)
        window_end = time.monotonic()
        row["rss_mb"] = _rss_mb(process.pid)
        sent = time.monotonic()
        process.send_signal(signal.SIGINT)
        row["exit"] = process.wait(timeout=60)
        row["stop_s"] = time.monotonic() - sent
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        listener.send_signal(signal.SIGINT)
        try:
            listener.wait(timeout=60)
        except subprocess.TimeoutExpired:
            listener.kill()
            listener.wait()
    data = np.load(arrivals_file)
    arrival, stamps = data["arrival"], data["stamp"]
    if not len(arrival):
        raise RuntimeError(f"no poses from the node ({n} bodies); log {log.name}")
    row["first_poses_s"] = float(arrival[0] - start)
    inside = (arrival >= window_start) & (arrival <= window_end)
    a, st = arrival[inside], stamps[inside]
    wall = a[-1] - a[0]
    sim = (st.max() - st.min()) * 1e-9
    ticks = round(sim * rate_hz)
    row["sim_over_wall"] = sim / wall
    row["achieved_hz"] = ticks / wall
    row["delivered"] = len(np.unique(st)) / (ticks + 1)
    row["cpu_ms_per_tick"] = (cpu1 - cpu0) / max(ticks, 1) * 1e3
    row["cpu_share"] = (cpu1 - cpu0) / (window_end - window_start)
    row["recorded"] = _count_recorded(record, rate_hz) if record else float("nan")
    return row



def _median_row(rows: list[dict]) -> dict:
    out = {"bodies": rows[0]["bodies"], "rate_hz": rows[0]["rate_hz"], "recording": rows[0]["recording"],
           "publisher_depth": rows[0]["publisher_depth"], "repeats": len(rows)}
    for key in ("first_poses_s", "sim_over_wall", "achieved_hz", "delivered", "cpu_ms_per_tick", "cpu_share",
                "rss_mb", "stop_s", "recorded"):
        values = np.array([r[key] for r in rows])
        out[key], out[key + "_min"], out[key + "_max"] = float(np.median(values)), float(values.min()), float(values.max())
    out["exits"] = sorted({r["exit"] for r in rows})
    return out


def markdown(rows: list[dict]) -> str:
    """The table of node_batch.md."""
    lines = ["| bodies | rate (Hz) | recording | `poses` depth | sim/wall | ticks delivered to a `poses` subscriber "
             "| ticks recorded | CPU per tick (ms) | CPU share (cores) | RSS (MB) | start to first `poses` (s) "
             "| SIGINT to exit (s), exit status |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        def f(key, fmt):
            if np.isnan(r[key]):
                return "—"
            return f"{r[key]:{fmt}} ({r[key + '_min']:{fmt}}–{r[key + '_max']:{fmt}})"
        lines.append(f"| {r['bodies']} | {r['rate_hz']:g} | {'yes' if r['recording'] else 'no'} | {r['publisher_depth']} "
                     f"| {f('sim_over_wall', '.3f')} "
                     f"| {f('delivered', '.1%')} | {f('recorded', '.1%')} "
                     f"| {f('cpu_ms_per_tick', '.3f')} | {f('cpu_share', '.2f')} | {f('rss_mb', '.0f')} "
                     f"| {f('first_poses_s', '.2f')} | {f('stop_s', '.2f')}, {r['exits']} |")
    return "\n".join(lines) + "\n"


def targets(rows: list[dict]) -> str:
    """The targets table: each target case's medians against the node's targets (met or not)."""
    lines = ["| bodies | rate (Hz) | recording | `poses` depth | figure | target | median | met |",
             "|---|---|---|---|---|---|---|---|"]
    names = {"first_poses_s": ("start to first `poses` (s)", ".2f"), "rss_mb": ("RSS (MB)", ".0f"),
             "sim_over_wall": ("sim/wall", ".3f"), "delivered": ("ticks delivered", ".1%")}
    for r in rows:
        goal = TARGETS.get((r["bodies"], r["rate_hz"]))
        for key, (op, limit) in (goal or {}).items():
            label, fmt = names[key]
            met = r[key] <= limit if op == "<=" else r[key] >= limit
            lines.append(f"| {r['bodies']} | {r['rate_hz']:g} | {'yes' if r['recording'] else 'no'} "
                         f"| {r['publisher_depth']} | {label} "
                         f"| {op} {limit:{fmt}} | {r[key]:{fmt}} | {'yes' if met else 'no'} |")
        if goal and r["recording"]:
            met = r["recorded"] >= 1.0 and r["sim_over_wall"] >= 0.99
            lines.append(f"| {r['bodies']} | {r['rate_hz']:g} | yes | {r['publisher_depth']} "
                         "| recording keeps up (every tick, sim/wall >= 0.99) "
                         f"| every tick | {r['recorded']:.1%} | {'yes' if met else 'no'} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="3 repeats of 5 s windows (default 5 of 10 s)")
    parser.add_argument("--repeats", type=int)
    parser.add_argument("--seconds", type=float)
    parser.add_argument("--bodies", type=int, nargs="*", help="only these body counts")
    parser.add_argument("--depth", type=int, default=10, help="the subscriber's history depth (default 10)")
    parser.add_argument("--publisher-depth", type=int, nargs="+", default=[1, 10],
                        help="the node's poses history depths to run (qos_overrides./poses.publisher.depth; "
                             "default 1, the node's own, and 10, for a consumer of every tick)")
    parser.add_argument("--recording", choices=("both", "yes", "no"), default="both",
                        help="only the cases with (yes) or without (no) a recording")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results")
    parser.add_argument("--listen", type=Path, help=argparse.SUPPRESS)  # the subscriber process (listen())
    args = parser.parse_args(argv)
    if args.listen:
        return listen(args.listen, args.depth)
    repeats = args.repeats or (3 if args.quick else 5)
    seconds = args.seconds or (5.0 if args.quick else 10.0)
    cases = [c for c in CASES if (not args.bodies or c[0] in args.bodies)
             and args.recording in ("both", "yes" if c[2] else "no")]
    rows = []
    # Stopped with SIGTERM (kill, a CI timeout) as with Ctrl-C: the finally blocks stop the node and the
    # listener and the temporary directory goes, rather than a node left recording into it.
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
    domain, _lock = claim_domain()  # held until the process ends
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as directory:
        for n, rate, recording in cases:
            scene = write_scene(Path(directory), n)
            for publisher_depth in args.publisher_depth:
                runs = []
                for k in range(repeats):
                    record = Path(directory) / f"run{k}.mcap" if recording else None
                    runs.append(measure(scene, n, rate, seconds, args.depth, record, domain, publisher_depth))
                    if record is not None:
                        record.unlink(missing_ok=True)
                rows.append(_median_row(runs))
                print(markdown(rows[-1:]).splitlines()[-1], flush=True)
    load_after = os.getloadavg()
    text = (f"# The node benchmark ({repeats} repeats, {seconds:g} s windows; medians, min–max)\n\n"
            + __doc__.split("\n\n", 1)[1] + "\n" + machine.text()
            + f"    load average before the runs: {' '.join(f'{x:.2f}' for x in load_before)}, after: "
            + f"{' '.join(f'{x:.2f}' for x in load_after)}\n"
            + f"    subscriber: keep last {args.depth}, reliable, transient local, raw, rclpy.spin; "
            + "node's `poses` publisher: reliable, transient local, keep last the depth of the table\n\n"
            + markdown(rows) + "\n## Targets\n\n" + targets(rows))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "node_batch.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
