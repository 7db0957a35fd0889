"""``rigid-body-sim view`` in a real browser: Debian's headless chromium, driven by selenium.

The simulator runs as its own process (paused), the view as another, and the test is a third
ROS participant that watches ``box/twist`` and ``box/impulse``. Through the page only (its
buttons, its slider) it steps, strikes and resets the node, and checks:

- the box is drawn: box-coloured pixels of a screenshot after the first tick (when the view has
  the markers) against one before it (the view knows the pose but not yet the shape);
- a strike under the centre changes the linear velocity by J/m upwards and the angular velocity
  by nothing; a strike at the bottom corner changes the angular velocity by I⁻¹ (r × J) (world
  axes: the strike is at t = 0, where body and world axes coincide), within 1e-9, with I and r
  computed here from the scene file. The node ticks 1e-10 s of sim time (real_time_factor 1e-6,
  rate_hz 1e4), so the free tumbling during the tick moves ω by less than 1e-9 (about 1e-10).

Without a node the view says it waits (no traceback); on a port in use it exits 2 saying so.

The replay (``rigid-body-sim view RECORDING``, no node): a 4 s recording of the tumbling box made
with ``rigid-body-sim run --record``; through the page (the slider's thumb by keyboard, the number
box beside it typed into, Play and Pause) the time moves, and the ``pose`` field's time, position
and quaternion equal read_recording's sample at that time within 1e-9; the box is drawn elsewhere
at t = 2.5 s than at t = 0.02 s (box-coloured pixels of two screenshots differ). A file that is
not a recording, or a missing one: one line, exit 2; a recording cut in half replays up to the
cut and says so.
``RIGID_BODY_SIM_VIEW_PNG=docs/view.png`` also saves the screenshot with the box (the README's).
"""

from __future__ import annotations

import io
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Twist, WrenchStamped
from PIL import Image
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys

from rigid_body_sim.testing import start_process, stop_process
from rigid_body_sim.view import STRIKE_IMPULSE_NS

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "config" / "default_scene.yaml"
CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"


def view_command(*args: str) -> list[str]:
    script = Path(sys.executable).parent / "rigid-body-sim"
    return [str(script) if script.exists() else shutil.which("rigid-body-sim") or "rigid-body-sim", "view", *args]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def box_from_scene() -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, inertia about the COM in body axes, bottom corner r) of the scene file's box."""
    box = yaml.safe_load(SCENE.read_text())["bodies"]["box"]
    m = float(box["mass"])
    a, b, c = (float(e) for e in box["inertia"]["box"])
    inertia = m / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    assert box["pose"]["orientation"] == [0.0, 0.0, 0.0, 1.0]  # body axes = world axes at t = 0
    return m, inertia, np.array([a / 2.0, b / 2.0, -c / 2.0])


def box_pixels(png: bytes) -> int:
    """Pixels of the box's colour (the markers' blue-grey, lit or not) in the 3D part of the page."""
    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)
    h, w, _ = rgb.shape
    scene = rgb[:, : int(w * 0.7)]  # the GUI panel is on the right
    r, g, b = scene[..., 0], scene[..., 1], scene[..., 2]
    return int(np.count_nonzero((r > 60) & (b - r > 25) & (b > g + 8) & (b < 250)))


class Watcher:
    """The test's own ROS participant: box/twist (latched), box/impulse and the node's pending impulses."""

    def __init__(self):
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("view_test_watcher", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.twists: list[Twist] = []
        self.impulses: list[WrenchStamped] = []
        self.node.create_subscription(Twist, "box/twist", self.twists.append,
                                      QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.node.create_subscription(WrenchStamped, "box/impulse", self.impulses.append, QoSProfile(depth=10))
        self.pending_impulses: int | None = None
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, QoSProfile(depth=10))

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            for kv in status.values:
                if kv.key == "pending impulses":
                    self.pending_impulses = int(kv.value)

    def wait(self, what: str, condition, timeout: float = 20.0) -> None:
        end = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < end, f"timed out waiting for {what}"
            self.executor.spin_once(timeout_sec=0.05)

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        self.context.try_shutdown()


def twist_arrays(t: Twist) -> tuple[np.ndarray, np.ndarray]:
    return (np.array([t.linear.x, t.linear.y, t.linear.z]), np.array([t.angular.x, t.angular.y, t.angular.z]))


def chromium() -> webdriver.Chrome:
    """A new headless chromium (the tests share one: the ``browser`` fixture)."""
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                f"--user-data-dir={tempfile.mkdtemp(prefix='rbs-view-chromium-')}", "--window-size=1200,800"):
        options.add_argument(arg)
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)


@pytest.fixture(scope="module")
def browser():
    """One chromium for the module's tests (each loads its own page); quit at the end."""
    assert os.access(CHROMIUM, os.X_OK) and os.access(CHROMEDRIVER, os.X_OK), "make browser-deps installs them"
    driver = chromium()
    try:
        yield driver
    finally:
        driver.quit()


def open_page(driver, port: int, view: subprocess.Popen, log: Path) -> None:
    """Load the view's page once it serves (it may still be starting); close the software-WebGL notice."""
    end = time.monotonic() + 60.0
    while True:
        try:
            driver.get(f"http://127.0.0.1:{port}")
            break
        except Exception:  # noqa: BLE001 - the view is still starting
            assert view.poll() is None and time.monotonic() < end, log.read_text()
            time.sleep(0.5)
    for close in driver.find_elements(By.CSS_SELECTOR, "[class*='Notification-closeButton']"):
        close.click()  # the software-WebGL notice of a headless browser (cosmetic: the README's picture)


def screenshot_when(driver, predicate, what: str, timeout: float = 30.0) -> bytes:
    """The first screenshot (taken every 0.25 s) that ``predicate`` accepts: the software renderer
    has drawn the frame by then."""
    end = time.monotonic() + timeout
    while True:
        png = driver.get_screenshot_as_png()
        if predicate(png):
            return png
        assert time.monotonic() < end, f"the page never showed {what}"
        time.sleep(0.25)


def page_text(driver) -> str:
    return driver.find_element(By.TAG_NAME, "body").text


def wait_text(driver, predicate, what: str, timeout: float = 60.0) -> str:
    end = time.monotonic() + timeout
    while True:
        text = page_text(driver)
        if predicate(text):
            return text
        assert time.monotonic() < end, f"page never showed {what}; it shows:\n{text}"
        time.sleep(0.1)


def click(driver, label: str) -> None:
    driver.find_element(By.XPATH, f"//button[normalize-space()='{label}']").click()


@pytest.mark.timeout(240)
def test_view_in_chromium_draws_the_box_and_strikes_it(tmp_path, browser):
    mass, inertia, corner = box_from_scene()
    J = np.array([0.0, 0.0, STRIKE_IMPULSE_NS])
    node = start_process(["-p", "paused:=true", "-p", "status_period:=0.0", "-p", "diagnostics_period:=0.1",
                          "-p", "real_time_factor:=1e-6", "-p", "rate_hz:=10000.0"], tmp_path / "node.log")
    watcher = Watcher()
    view = None
    driver = browser
    try:
        watcher.wait("the node's first twist", lambda: watcher.twists, timeout=60.0)
        port = free_port()
        with open(tmp_path / "view.log", "w") as log:
            view = subprocess.Popen(view_command("--port", str(port)), stdout=log, stderr=subprocess.STDOUT)
        open_page(driver, port, view, tmp_path / "view.log")
        # The node is found, its pose known; no tick yet, so no markers: no shape drawn.
        wait_text(driver, lambda t: "showing 1 body; no shape yet for box" in t, "the node found, no shape yet")
        time.sleep(2.0)  # let the software renderer draw the frame
        without_box = box_pixels(driver.get_screenshot_as_png())

        n = len(watcher.twists)
        click(driver, "Step")
        watcher.wait("the twist after Step", lambda: len(watcher.twists) > n)
        wait_text(driver, lambda t: "showing 1 body" in t and "no shape yet" not in t, "the box's shape")
        wait_text(driver, lambda t: "step: ok" in t, "Step's answer")
        png = screenshot_when(driver, lambda png: box_pixels(png) > 3000, "the box drawn")
        (tmp_path / "view.png").write_bytes(png)
        with_box = box_pixels(png)
        print(f"box-coloured pixels: {with_box} with the box, {without_box} before its shape came")
        assert with_box > 3000 and with_box > 20 * max(1, without_box), (with_box, without_box)

        def strike_and_step(expected_r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            v0, w0 = twist_arrays(watcher.twists[-1])
            k = len(watcher.impulses)
            click(driver, "Strike")
            watcher.wait("the view's impulse", lambda: len(watcher.impulses) > k)
            msg = watcher.impulses[-1]
            assert msg.header.frame_id == "box"
            f, tau = msg.wrench.force, msg.wrench.torque
            np.testing.assert_allclose([f.x, f.y, f.z], J, atol=1e-15)
            np.testing.assert_allclose([tau.x, tau.y, tau.z], np.cross(expected_r, J), atol=1e-15)
            wait_text(driver, lambda t: "strike sent: J = 0.5 N·s up" in t, "the strike's report")
            watcher.pending_impulses = None  # the node has it (its /diagnostics say so) before Step asks for the tick
            watcher.wait("the node's pending impulse", lambda: watcher.pending_impulses == 1)
            n = len(watcher.twists)
            click(driver, "Step")
            watcher.wait("the twist after the strike", lambda: len(watcher.twists) > n)
            v1, w1 = twist_arrays(watcher.twists[-1])
            return v1 - v0, w1 - w0

        # Offset 0: under the centre of mass. The box only rises.
        r0 = np.array([0.0, 0.0, corner[2]])
        dv, dw = strike_and_step(r0)
        np.testing.assert_allclose(dv, J / mass, rtol=0, atol=1e-9)
        np.testing.assert_allclose(dw, np.zeros(3), rtol=0, atol=1e-9)
        print(f"centre strike: dw = {dw.tolist()} rad/s, dv = {dv.tolist()} m/s")

        # Back to t = 0 through the page, then the slider to the corner (End key) and strike again.
        n = len(watcher.twists)
        click(driver, "Reset")
        watcher.wait("the twist after Reset", lambda: len(watcher.twists) > n)
        v_init, w_init = twist_arrays(watcher.twists[-1])
        np.testing.assert_allclose(w_init, [0.2, 0.1, 0.5], atol=1e-15)
        slider = driver.find_element(By.CSS_SELECTOR, "[role='slider']")
        slider.click()
        slider.send_keys(Keys.END)
        wait_text(driver, lambda t: "offset 1.00: r = (0.500, 0.300, -0.200) m" in t, "the corner offset")
        dv, dw = strike_and_step(corner)
        np.testing.assert_allclose(dv, J / mass, rtol=0, atol=1e-9)
        expected = np.linalg.solve(inertia, np.cross(corner, J))
        assert np.linalg.norm(expected) > 1.0  # a real turn: about (1.73, -1.29, 0) rad/s
        print(f"corner strike: dw = {dw.tolist()} rad/s, I^-1 (r x J) = {expected.tolist()}, "
              f"|error| = {np.abs(dw - expected).max():.2e}; dv_z = {dv[2]!r} m/s, J/m = {J[2] / mass!r}")
        np.testing.assert_allclose(dw, expected, rtol=0, atol=1e-9)

        target = os.environ.get("RIGID_BODY_SIM_VIEW_PNG")
        if target:
            shutil.copyfile(tmp_path / "view.png", target)
    finally:
        view_code = stop_process(view) if view is not None else 0
        watcher.close()
        stop_process(node)
    assert view_code == 0, (tmp_path / "view.log").read_text()
    log = (tmp_path / "view.log").read_text()
    assert "Traceback" not in log, log


@pytest.mark.timeout(120)
def test_view_waits_for_a_node_and_refuses_a_port_in_use(tmp_path):
    port = free_port()
    with open(tmp_path / "view.log", "w") as log:
        view = subprocess.Popen(view_command("--port", str(port), "--namespace", "/nobody_here"),
                                stdout=log, stderr=subprocess.STDOUT)
    try:
        end = time.monotonic() + 60.0
        while "waiting for a rigid_body_sim node" not in (tmp_path / "view.log").read_text():
            assert view.poll() is None and time.monotonic() < end, (tmp_path / "view.log").read_text()
            time.sleep(0.2)
        second = subprocess.run(view_command("--port", str(port)), capture_output=True, text=True, timeout=60)
        assert second.returncode == 2, second
        assert f"address 127.0.0.1:{port} is already in use" in second.stderr
        assert "Traceback" not in second.stderr + second.stdout
    finally:
        code = stop_process(view)
    text = (tmp_path / "view.log").read_text()
    assert code == 0 and "Traceback" not in text, text
    assert "/nobody_here/poses" in text


# ------------------------------------------------------------------------------ replay of a recording


def record_tumbling_box(path: Path, duration_s: float = 4.0) -> None:
    """``rigid-body-sim run`` (in this process) of the default scene (the box tumbling at
    ω = (0.2, 0.1, 0.5) rad/s), 100 samples/s."""
    from rigid_body_sim.cli import main

    assert main(["run", str(SCENE), "--duration", f"{duration_s:g}", "--record", str(path), "-q"]) == 0
    assert path.is_file()


def shown_pose(driver) -> tuple[float, np.ndarray, np.ndarray] | None:
    """(t, position, quaternion xyzw) from the page's ``pose`` field, or None before it is filled."""
    for area in driver.find_elements(By.TAG_NAME, "textarea"):
        text = area.get_property("value") or ""
        if text.startswith("body box,"):
            lines = dict(line.split(" = ", 1) for line in text.splitlines()[1:])
            return (float(lines["t"].removesuffix(" s")), np.array(yaml.safe_load(lines["position (m)"])),
                    np.array(yaml.safe_load(lines["orientation (x, y, z, w)"])))
    return None


def wait_pose_at(driver, t: float, timeout: float = 30.0) -> tuple[float, np.ndarray, np.ndarray]:
    end = time.monotonic() + timeout
    while True:
        pose = shown_pose(driver)
        if pose is not None and abs(pose[0] - t) < 1e-9:
            return pose
        assert time.monotonic() < end, f"the page never showed t = {t}; it shows {pose}"
        time.sleep(0.1)


def box_mask(png: bytes) -> np.ndarray:
    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)[:, : int(1200 * 0.7)]
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return (r > 60) & (b - r > 25) & (b > g + 8) & (b < 250)


@pytest.mark.timeout(240)
def test_replay_in_chromium_shows_the_recorded_pose_at_the_slider_time(tmp_path, browser):
    from rigid_body_sim.offline.recording import read_recording

    record = tmp_path / "tumble.mcap"
    record_tumbling_box(record)
    data, _scene = read_recording(record)
    track = data.bodies["box"]

    def check(pose: tuple[float, np.ndarray, np.ndarray], t: float) -> None:
        k = int(np.argmin(np.abs(data.time - t)))
        assert abs(data.time[k] - t) < 1e-9
        shown_t, p, q = pose
        assert abs(shown_t - data.time[k]) < 1e-9
        np.testing.assert_allclose(p, track.position_world[k], rtol=0, atol=1e-9)
        np.testing.assert_allclose(q, track.orientation_xyzw[k], rtol=0, atol=1e-9)

    port = free_port()
    with open(tmp_path / "view.log", "w") as log:
        view = subprocess.Popen(view_command(str(record), "--port", str(port)), stdout=log, stderr=subprocess.STDOUT)
    driver = browser
    try:
        open_page(driver, port, view, tmp_path / "view.log")
        wait_text(driver, lambda t: "1 body, 401 samples, t = 0 … 4 s" in t, "the recording's summary")
        check(wait_pose_at(driver, 0.0), 0.0)

        # The keyboard on the slider's thumb: two steps of one sample (0.01 s) to the right (each key
        # redraws the page in software WebGL: seconds on a loaded machine).
        thumb = driver.find_element(By.CSS_SELECTOR, "[role='slider']")
        for _ in range(2):
            thumb.send_keys(Keys.ARROW_RIGHT)
        check(wait_pose_at(driver, 0.02), 0.02)
        early = box_mask(screenshot_when(driver, lambda png: box_mask(png).sum() > 3000, "the box at t = 0.02 s"))

        # The number box beside the slider, typed into as a user would.
        box = thumb.find_element(By.XPATH, "./ancestor::div[contains(@class, 'Slider-root')]/following::input[1]")
        box.send_keys(Keys.CONTROL, "a")
        box.send_keys("2.5")
        check(wait_pose_at(driver, 2.5), 2.5)
        png = screenshot_when(driver, lambda png: box_mask(png).sum() > 3000 and np.count_nonzero(early ^ box_mask(png)) > 2000,
                              "the box moved at t = 2.5 s")
        (tmp_path / "replay.png").write_bytes(png)
        late = box_mask(png)
        moved = int(np.count_nonzero(early ^ late))
        print(f"box-coloured pixels: {int(early.sum())} at t = 0.02 s, {int(late.sum())} at t = 2.5 s, "
              f"{moved} differ")
        assert early.sum() > 3000 and late.sum() > 3000, (early.sum(), late.sum())
        assert moved > 2000, moved

        thumb.send_keys(Keys.END)
        check(wait_pose_at(driver, 4.0), 4.0)

        # Play from the end starts again at 0 and moves on; Pause holds a recorded sample.
        click(driver, "Play")
        wait_text(driver, lambda t: "playing" in t, "playing")
        end = time.monotonic() + 30.0
        while not ((pose := shown_pose(driver)) and 0.3 < pose[0] < 4.0):
            assert time.monotonic() < end, f"playback never moved on; the page shows {pose}"
            time.sleep(0.1)
        click(driver, "Pause")
        paused = wait_text(driver, lambda t: "paused at t = " in t, "paused")
        at = float(paused.split("paused at t = ", 1)[1].split(" s", 1)[0])
        pose = wait_pose_at(driver, at)
        check(pose, pose[0])
        time.sleep(1.0)
        assert shown_pose(driver)[0] == pose[0]
    finally:
        code = stop_process(view)
    log = (tmp_path / "view.log").read_text()
    assert code == 0 and "Traceback" not in log, log


@pytest.mark.timeout(120)
def test_replay_refuses_what_is_no_recording_and_plays_a_cut_one_up_to_the_cut(tmp_path):
    from rigid_body_sim.offline.recording import read_recording

    (tmp_path / "notes.mcap").write_text("not a recording\n")
    for path, says in ((tmp_path / "notes.mcap", "not an MCAP recording"),
                       (tmp_path / "missing.mcap", "No such file or directory")):
        done = subprocess.run(view_command(str(path), "--port", str(free_port())), capture_output=True, text=True,
                              timeout=60)
        assert done.returncode == 2, done
        assert done.stdout == "" and done.stderr.count("\n") == 1 and says in done.stderr, done
        assert done.stderr.startswith(f"rigid-body-sim view: {path}: "), done

    whole = tmp_path / "whole.mcap"
    record_tumbling_box(whole, duration_s=40.0)  # 0.5 MB, two 256 KiB chunks: the cut keeps the first
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    data, _ = read_recording(cut)
    assert 1.0 < data.time[-1] < 39.0 and data.meta["status"].startswith("cut short: "), data.meta
    with open(tmp_path / "view.log", "w") as log:
        view = subprocess.Popen(view_command(str(cut), "--port", str(free_port())), stdout=log,
                                stderr=subprocess.STDOUT)
    try:
        end = time.monotonic() + 60.0
        while "Ctrl-C stops" not in (tmp_path / "view.log").read_text():
            assert view.poll() is None and time.monotonic() < end, (tmp_path / "view.log").read_text()
            time.sleep(0.2)
    finally:
        code = stop_process(view)
    text = (tmp_path / "view.log").read_text()
    assert code == 0 and "Traceback" not in text, text
    warning = f"rigid-body-sim view: warning: {cut}: cut short: "
    assert text.count(warning) == 1, text
    line = text.split(warning, 1)[1].split("\n", 1)[0]
    assert line.endswith(f"; the replay plays up to t = {data.time[-1]:.9g} s"), line
    assert f"read up to t = {data.time[-1]:.9g} s" in line, line
