"""The browser view's frame rate at 1, 100 and 1000 bodies, and what a viewer costs the node.

For each N, ``rigid_body_sim_node`` runs N free asymmetric boxes (:func:`.node_batch.write_scene`:
random poses and spins, no gravity; rk4, 1 substep, 100 Hz, real-time factor 1,
``per_body_topics:=false``) on a ROS domain claimed for this run. Measured, each over
:data:`WINDOWS` windows of :data:`WINDOW_S` s after a settle of :data:`SETTLE_S` s:

* ``node_ms_per_tick`` without a viewer: the node's CPU time (user + system, /proc) over the window
  divided by the ticks it made (the sim span of ``/clock`` stamps this process received, over the
  tick's sim length);
* then ``rigid-body-sim view`` starts and Debian's headless chromium (software WebGL, 1200×800)
  opens its page, through selenium; once the page shows all N bodies with their shapes:
  ``fps``: frames the page renders per second (``requestAnimationFrame`` callbacks counted in the
  page: three.js draws the scene in that loop), ``updates``: new poses the view sent to the page
  per second (its refreshes that had a new ``poses`` stamp, at most 20 a second, as the page's
  status line shows them over the last 2 s; viser's websocket runs in a web worker, out of reach
  of a counter in the page);
  ``node_ms_per_tick`` with the viewer connected (it subscribes to poses, velocities, markers and
  contacts, so the node also builds markers at ``marker_rate_hz``); and the view process's CPU
  share (``view_cpu``, of one core).

Each figure is the median over the windows with the min-max. The node, the view, chromium and
this process share the machine's cores (with whatever else runs): a loaded machine lowers the
frame rate and raises CPU per tick. Run: ``python -m benchmarks.view_fps [--sizes 1 100 1000]``
(``make bench-view``); it writes ``benchmarks/results/view.md`` and, with ``--docs``, the block of
docs/view.md between its ``view-bench`` markers.
"""

from __future__ import annotations

import argparse
import fcntl
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from . import machine
from .node_batch import _cpu_seconds, write_scene

REPO = Path(__file__).resolve().parent.parent
BIN = REPO / ".venv" / "bin"
SETTLE_S = 3.0
WINDOW_S = 3.0
WINDOWS = 5
RATE_HZ = 100.0
SIZES = (1, 100, 1000)
BEGIN, END = "<!-- view-bench:begin (generated: python -m benchmarks.view_fps --docs) -->", "<!-- view-bench:end -->"

#: Counts frames (requestAnimationFrame callbacks) from the page's first line on.
COUNTERS_JS = """
window.__frames = 0;
(function tick() { window.__frames++; requestAnimationFrame(tick); })();
"""


def claim_domain() -> tuple[int, object]:
    """A ROS domain id nobody else on this machine uses now (the test suite's flock convention)."""
    for i in list(range(215, 233)) + list(range(1, 102)):
        f = open(f"/tmp/rigid_body_sim_ros_domain_{i}.lock", "w")
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return i, f
        except OSError:
            f.close()
    raise RuntimeError("no free ROS domain id")


class Clock:
    """This process's subscription to ``/clock``: (wall monotonic, sim s) of every message."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile
        from rosgraph_msgs.msg import Clock as ClockMsg

        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("view_bench_clock", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.samples: list[tuple[float, float]] = []
        self.node.create_subscription(ClockMsg, "/clock", lambda m: self.samples.append(
            (time.monotonic(), m.clock.sec + 1e-9 * m.clock.nanosec)), QoSProfile(depth=100))
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set():
            self.executor.spin_once(timeout_sec=0.05)

    def sim_now(self) -> float:
        return self.samples[-1][1] if self.samples else float("nan")

    def close(self) -> None:
        self._stop.set()
        self.thread.join()
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()


def chromium(width: int = 1200, height: int = 800):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                f"--user-data-dir={tempfile.mkdtemp(prefix='rbs-view-bench-')}", f"--window-size={width},{height}"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": COUNTERS_JS})
    return driver


def _node_window(node: subprocess.Popen, clock: Clock, seconds: float) -> float:
    """The node's CPU ms per tick over ``seconds``."""
    cpu0, t0 = _cpu_seconds(node.pid), clock.sim_now()
    time.sleep(seconds)
    cpu1, t1 = _cpu_seconds(node.pid), clock.sim_now()
    ticks = round((t1 - t0) * RATE_HZ)  # real_time_factor 1: a tick is 1 / rate_hz s of sim time
    return (cpu1 - cpu0) / max(ticks, 1) * 1e3


def measure(n: int, directory: Path, log: Path) -> dict:
    from selenium.webdriver.common.by import By

    scene = write_scene(directory, n)
    clock = Clock()
    env = os.environ.copy()
    node = subprocess.Popen([str(BIN / "rigid_body_sim_node"), "--ros-args", "-p", f"scene:={scene}", "-p", f"rate_hz:={RATE_HZ}",
                             "-p", "per_body_topics:=false", "-p", "status_period:=0.0", "-p", "integrator:=rk4"],
                            stdout=open(log / f"node_{n}.log", "w"), stderr=subprocess.STDOUT, env=env)
    view = driver = None
    row: dict = {"bodies": n}
    try:
        end = time.monotonic() + 180.0
        while not clock.samples:
            if node.poll() is not None or time.monotonic() > end:
                raise RuntimeError(f"the node ({n} bodies) never ticked; see {log / f'node_{n}.log'}")
            time.sleep(0.1)
        time.sleep(SETTLE_S)
        row["node_alone"] = [_node_window(node, clock, WINDOW_S) for _ in range(WINDOWS)]
        port = 8300 + n % 97
        view = subprocess.Popen([str(BIN / "rigid-body-sim"), "view", "--port", str(port), "--strike-body", "b0"],
                                stdout=open(log / f"view_{n}.log", "w"), stderr=subprocess.STDOUT, env=env)
        driver = chromium()
        end = time.monotonic() + 120.0
        while True:
            try:
                driver.get(f"http://127.0.0.1:{port}")
                break
            except Exception:  # noqa: BLE001 - the view is still starting
                if view.poll() is not None or time.monotonic() > end:
                    raise
                time.sleep(0.5)
        want = f"showing {n} bod{'y' if n == 1 else 'ies'}"
        end = time.monotonic() + 120.0
        while True:
            text = driver.find_element(By.TAG_NAME, "body").text
            if want in text and "no shape yet" not in text:
                break
            if time.monotonic() > end:
                raise RuntimeError(f"the page never showed {want!r} with shapes; it shows {text[:300]!r}")
            time.sleep(0.5)
        time.sleep(SETTLE_S)
        fps, updates, with_view, view_cpu = [], [], [], []
        for _ in range(WINDOWS):
            f0 = driver.execute_script("return window.__frames")
            c0, w0 = _cpu_seconds(view.pid), time.monotonic()
            with_view.append(_node_window(node, clock, WINDOW_S))
            f1 = driver.execute_script("return window.__frames")
            wall = time.monotonic() - w0
            fps.append((f1 - f0) / wall)
            text = driver.find_element(By.TAG_NAME, "body").text
            updates.append(float(text.split("page updates ", 1)[1].split("/s", 1)[0]))
            view_cpu.append((_cpu_seconds(view.pid) - c0) / wall)
        row.update(fps=fps, updates=updates, node_with_view=with_view, view_cpu=view_cpu)
    finally:
        if driver is not None:
            driver.quit()
        for process in (view, node):
            if process is not None and process.poll() is None:
                process.send_signal(2)
                try:
                    process.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()
        clock.close()
    return row


def _fmt(values: list[float], digits: str) -> str:
    return f"{np.median(values):{digits}} ({min(values):{digits}}-{max(values):{digits}})"


def markdown(rows: list[dict], info: dict) -> str:
    lines = [
        "| bodies | page frames/s | page updates/s | node CPU ms/tick, no viewer | node CPU ms/tick, viewer connected | view process CPU (of one core) |",
        "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['bodies']} | {_fmt(r['fps'], '.1f')} | {_fmt(r['updates'], '.1f')} "
                     f"| {_fmt(r['node_alone'], '.3f')} | {_fmt(r['node_with_view'], '.3f')} | {_fmt(r['view_cpu'], '.2f')} |")
    return ("\n".join(lines) + f"\n\nMedians of {WINDOWS} windows of {WINDOW_S:g} s (min-max in brackets); node at "
            f"{RATE_HZ:g} Hz, rk4, real-time factor 1, `per_body_topics:=false`; headless Debian chromium "
            f"{_chromium_version()} with software WebGL at 1200×800. Machine:\n\n" + machine.text(info))


def _chromium_version() -> str:
    try:
        return subprocess.run(["/usr/bin/chromium", "--version"], capture_output=True, text=True, timeout=30).stdout.split()[1]
    except Exception:  # noqa: BLE001
        return "(version unknown)"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    parser.add_argument("--out", default=str(REPO / "benchmarks" / "results"))
    parser.add_argument("--docs", action="store_true", help="also write the block of docs/view.md")
    args = parser.parse_args(argv)
    domain, _lock = claim_domain()
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    rows = []
    with tempfile.TemporaryDirectory(prefix="rbs-view-bench-") as tmp:
        for n in args.sizes:
            print(f"[view_fps] {n} bodies (ROS_DOMAIN_ID {domain})", flush=True)
            rows.append(measure(n, Path(tmp), Path(tmp)))
            print(markdown(rows[-1:], machine.describe()).split("\n\n")[0], flush=True)
    text = markdown(rows, machine.describe())
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "view.md").write_text("# The browser view: frames per second and the node's cost\n\n"
                                 "`python -m benchmarks.view_fps` (`make bench-view`); see docs/view.md.\n\n" + text)
    if args.docs:
        docs = REPO / "docs" / "view.md"
        page = docs.read_text()
        if BEGIN not in page or END not in page:
            print(f"{docs} has no {BEGIN} ... {END} block", file=sys.stderr)
            return 1
        head, rest = page.split(BEGIN, 1)
        docs.write_text(head + BEGIN + "\n" + text + "\n" + END + rest.split(END, 1)[1])
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
