"""``rigid-body-sim view`` in a real browser: Debian's headless chromium, driven by selenium.

The simulator runs as its own process (paused, in the namespace ``/view_test`` with the
``frame_prefix`` ``sim1/``), the view as another (``--namespace /view_test``), and the test is a
third ROS participant that watches ``box/twist`` and the shared ``impulse`` topic. One browser
serves the module's browser tests. Through the page only (its buttons, its slider, a click on the
box) it steps, strikes and resets the node, and checks:

- the box is drawn: box-coloured pixels of a screenshot after the first tick (when the view has
  the markers) against one before it (the view knows the pose but not yet the shape);
- a strike under the centre changes the linear velocity by J/m upwards and the angular velocity
  by nothing; a strike at the bottom corner changes the angular velocity by I⁻¹ (r × J) (world
  axes: the strike is at t = 0, where body and world axes coincide), within 1e-9, with I and r
  computed here from the scene file. The node ticks 1e-10 s of sim time (real_time_factor 1e-6,
  rate_hz 1e4), so the free tumbling during the tick moves ω by less than 1e-9 (about 1e-10);
- Step N with 3 in ``ticks`` makes exactly three ticks (three twists);
- ``rate_hz`` typed into the page and the integrator chosen in its list are set on the node
  (read back from it), Run makes ticks flow and Pause stops them;
- a click on the box's pixels strikes it where the click's ray meets it: the impulse comes in
  ``box/world_aligned``, of the default size 0.5 N·s, at a point of the box's surface (as the
  page reports it), with the angular impulse r × J.

Without a node the view says it waits (no traceback); on a port in use it exits 2 saying so.

The replay (``rigid-body-sim view RECORDING``, no node): a 40 s recording of the tumbling box made
once for the module with ``rigid-body-sim run --record``; through the page (the slider's thumb by keyboard, the number
box beside it typed into, Play and Pause) the time moves, and the ``pose`` field's time, position
and quaternion equal read_recording's sample at that time within 1e-9; the box is drawn elsewhere
at t = 2.5 s than at t = 0.03 s (box-coloured pixels of two screenshots differ). A file that is
not a recording, or a missing one: one line, exit 2; a recording cut in half replays up to the
cut and says so.
``RIGID_BODY_SIM_VIEW_PNG=docs/view.png`` also saves the screenshot with the box (the README's).
Without a browser: ``poses`` read from CDR against rclpy's serialiser, click rays against shapes
and the plotted energy and |L| against closed forms.
"""

from __future__ import annotations

import io
import os
import shutil
import signal
import socket
import subprocess
import sys
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
#: The live test's node runs in a namespace with a frame prefix: the view's strikes must name its frames.
NAMESPACE, PREFIX = "/view_test", "sim1/"


def view_command(*args: str) -> list[str]:
    script = Path(sys.executable).parent / "rigid-body-sim"
    return [str(script) if script.exists() else shutil.which("rigid-body-sim") or "rigid-body-sim", "view", *args]


def stack_dump_env(tmp_path: Path) -> dict[str, str]:
    """The environment for a view whose threads' stacks can be asked for: SIGUSR1 prints them to its
    stderr (faulthandler, registered by a sitecustomize on PYTHONPATH; the command itself unchanged)."""
    hook = tmp_path / "stack_dump"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(
        "import faulthandler, signal\nfaulthandler.register(signal.SIGUSR1, all_threads=True)\n")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(hook), env.get("PYTHONPATH", "")) if p)
    return env


def with_stacks(view: subprocess.Popen, log: Path, failure: AssertionError) -> AssertionError:
    """``failure`` with the view's log, ending with the stacks of its threads (a view started with
    :func:`stack_dump_env`): where it was when the page stopped following it."""
    if view.poll() is None:
        view.send_signal(signal.SIGUSR1)
        time.sleep(1.0)
    return AssertionError(f"{failure}\n\nthe view's log, the stacks of its threads last:\n{log.read_text()}")


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
    """The test's own ROS participant: box/twist (latched), the shared impulse topic and the node's pending impulses."""

    def __init__(self):
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("view_test_watcher", namespace=NAMESPACE, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.twists: list[Twist] = []
        self.impulses: list[WrenchStamped] = []
        self.node.create_subscription(Twist, "box/twist", self.twists.append,
                                      QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.node.create_subscription(WrenchStamped, "impulse", self.impulses.append, QoSProfile(depth=10))
        self.pending_impulses: int | None = None
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, QoSProfile(depth=10))

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            for kv in status.values:
                if kv.key == "pending impulses":
                    self.pending_impulses = int(kv.value)

    def wait(self, what: str, condition, timeout: float = 20.0, expire_ok: bool = False) -> None:
        end = time.monotonic() + timeout
        while not condition():
            if time.monotonic() >= end:
                assert expire_ok, f"timed out waiting for {what}"
                return
            self.executor.spin_once(timeout_sec=0.05)

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        self.context.try_shutdown()


def twist_arrays(t: Twist) -> tuple[np.ndarray, np.ndarray]:
    return (np.array([t.linear.x, t.linear.y, t.linear.z]), np.array([t.angular.x, t.angular.y, t.angular.z]))


#: The browser window (px). Software WebGL draws every pixel on the CPU each frame, so the run's window is small;
#: the README's picture is made at 1200 × 800.
WINDOW = (1200, 800) if os.environ.get("RIGID_BODY_SIM_VIEW_PNG") else (800, 533)
#: Pixel counts the checks ask for, as shares of the window: a box drawn, and the box drawn elsewhere.
DRAWN_SHARE, MOVED_SHARE = 0.003, 0.002


def at_least(share: float) -> int:
    """``share`` of the window's pixels."""
    return int(share * WINDOW[0] * WINDOW[1])


def chromium(profile: Path) -> webdriver.Chrome:
    """Headless chromium with its profile in the folder ``profile``."""
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                f"--user-data-dir={profile}", f"--window-size={WINDOW[0]},{WINDOW[1]}"):
        options.add_argument(arg)
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """One headless chromium for the module's browser tests (starting one costs seconds)."""
    assert os.access(CHROMIUM, os.X_OK) and os.access(CHROMEDRIVER, os.X_OK), "make browser-deps installs them"
    driver = chromium(tmp_path_factory.mktemp("chromium-profile"))
    yield driver
    driver.quit()


def open_page(driver, port: int, server: subprocess.Popen, log: Path) -> None:
    """Load the view's page once the view says it serves it (retrying while the view starts) and close
    the software-WebGL notice."""
    end = time.monotonic() + 60.0
    while "Ctrl-C stops" not in log.read_text():  # its page is built: no load of a half-made page, no retry
        assert server.poll() is None and time.monotonic() < end, log.read_text()
        time.sleep(0.05)
    while True:
        try:
            driver.get(f"http://127.0.0.1:{port}")
            break
        except Exception:  # noqa: BLE001 - the view is still starting
            assert server.poll() is None and time.monotonic() < end, log.read_text()
            time.sleep(0.5)
    wait_text(driver, lambda t: "Connected" in t or "rigid_body_sim" in t, "the page")
    for close in driver.find_elements(By.CSS_SELECTOR, "[class*='Notification-closeButton']"):
        close.click()  # the software-WebGL notice of a headless browser (cosmetic: the README's picture)


def settled_screenshot(driver, timeout: float = 10.0) -> bytes:
    """A screenshot once the software renderer has drawn the scene: the 3D part (left of the GUI
    panel) drawn (not blank) and the same in two screenshots 0.3 s apart."""
    def scene_part(png: bytes) -> np.ndarray:
        rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)
        return rgb[:, : int(rgb.shape[1] * 0.7)]

    end = time.monotonic() + timeout
    png = driver.get_screenshot_as_png()
    while True:
        time.sleep(0.3)
        again = driver.get_screenshot_as_png()
        a, b = scene_part(png), scene_part(again)
        if np.array_equal(a, b) and np.count_nonzero(a.min(axis=2) < 200) > 1000 or time.monotonic() > end:
            return again
        png = again


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
    """Click the button named ``label``: the click is dispatched to that element (the page above it
    can move while it updates, so a click at a screen position can land on a neighbour)."""
    button = driver.find_element(By.XPATH, f"//button[normalize-space()='{label}']")
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'}); arguments[0].click()", button)


@pytest.mark.timeout(240)
def test_view_in_chromium_draws_the_box_and_strikes_it(tmp_path, browser):
    mass, inertia, corner = box_from_scene()
    J = np.array([0.0, 0.0, STRIKE_IMPULSE_NS])
    node = start_process(["-r", f"__ns:={NAMESPACE}", "-p", f"frame_prefix:={PREFIX}", "-p", "paused:=true", "-p", "status_period:=0.0", "-p", "diagnostics_period:=0.1",
                          "-p", "real_time_factor:=1e-6", "-p", "rate_hz:=10000.0"], tmp_path / "node.log")
    watcher = Watcher()
    view = None
    driver = browser
    try:
        watcher.wait("the node's first twist", lambda: watcher.twists, timeout=60.0)
        port = free_port()
        with open(tmp_path / "view.log", "w") as log:
            view = subprocess.Popen(view_command("--port", str(port), "--namespace", NAMESPACE), stdout=log,
                                    stderr=subprocess.STDOUT)
        open_page(driver, port, view, tmp_path / "view.log")
        # The node is found, its pose known; no tick yet, so no markers: no shape drawn.
        wait_text(driver, lambda t: "showing 1 body; no shape yet for box" in t, "the node found, no shape yet")
        without_box = box_pixels(settled_screenshot(driver))

        n = len(watcher.twists)
        click(driver, "Step")
        watcher.wait("the twist after Step", lambda: len(watcher.twists) > n)
        wait_text(driver, lambda t: "showing 1 body" in t and "no shape yet" not in t, "the box's shape")
        wait_text(driver, lambda t: "step: ok" in t, "Step's answer")
        png = settled_screenshot(driver)
        (tmp_path / "view.png").write_bytes(png)
        with_box = box_pixels(png)
        print(f"box-coloured pixels: {with_box} with the box, {without_box} before its shape came")
        assert with_box > at_least(DRAWN_SHARE) and with_box > 20 * max(1, without_box), (with_box, without_box)

        def strike_and_step(expected_r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            v0, w0 = twist_arrays(watcher.twists[-1])
            k = len(watcher.impulses)
            click(driver, "Strike")
            watcher.wait("the view's impulse", lambda: len(watcher.impulses) > k)
            msg = watcher.impulses[-1]
            assert msg.header.frame_id == PREFIX + "box"  # about the box's origin in its axes, on the shared topic
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
        slider = driver.find_element(By.XPATH, "//label[normalize-space()='offset']/following::*[@role='slider'][1]")
        driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", slider)
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

        # Step N through the page: exactly that many ticks (one twist each).
        n = len(watcher.twists)
        ticks = driver.find_element(By.XPATH, "//label[normalize-space()='ticks']/following::input[1]")
        driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", ticks)
        ticks.send_keys(Keys.CONTROL, "a")
        ticks.send_keys("3")
        click(driver, "Step N")
        wait_text(driver, lambda t: "step 3: ok" in t, "Step N's answer")
        watcher.wait("three twists", lambda: len(watcher.twists) >= n + 3)
        watcher.wait("no fourth", lambda: False, timeout=0.3, expire_ok=True)
        assert len(watcher.twists) == n + 3

        # Click to strike: a click on the box strikes it where the click's ray meets it, along the ray.
        ys, xs = np.nonzero(box_mask(driver.get_screenshot_as_png()))
        canvas = driver.find_element(By.TAG_NAME, "canvas")
        k = len(watcher.impulses)
        webdriver.ActionChains(driver).move_to_element_with_offset(
            canvas, int(np.median(xs)) - canvas.rect["width"] // 2, int(np.median(ys)) - canvas.rect["height"] // 2).click().perform()
        watcher.wait("the click's impulse", lambda: len(watcher.impulses) > k)
        msg = watcher.impulses[-1]
        assert msg.header.frame_id == PREFIX + "box/world_aligned"
        f = np.array([msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z])
        tau = np.array([msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z])
        text = wait_text(driver, lambda t: "struck `box` at" in t or "struck box at" in t, "the click's report")
        report = text.split("struck", 1)[1]
        r = np.array(yaml.safe_load(report.split("r = ", 1)[1].split(" m from", 1)[0].replace("(", "[").replace(")", "]")))
        assert abs(np.linalg.norm(f) - 0.5) < 1e-12  # the default size, N·s
        half = corner * [1, 1, -1]  # (a/2, b/2, c/2): the box is still axis-aligned (t < 1e-8 s)
        assert abs(np.max(np.abs(r) / half) - 1.0) < 1e-3, r  # the struck point is on the box's surface
        np.testing.assert_allclose(tau, np.cross(r, f), rtol=0, atol=1e-4)  # r as shown, to 4 decimals
        watcher.pending_impulses = None
        watcher.wait("the node taking the click's impulse (its frame is valid)", lambda: watcher.pending_impulses == 1)
        print(f"click strike at r = {r.tolist()} m: J = {f.tolist()} N·s, r x J = {tau.tolist()} N·m·s")

        # rate_hz through the page (the node's own value read back on the status line), then Run
        # and Pause: ticks flow, then stop.
        rate = driver.find_element(By.XPATH, "//label[normalize-space()='rate_hz']/following::input[1]")
        driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", rate)
        rate.send_keys(Keys.CONTROL, "a")
        rate.send_keys("100")
        wait_text(driver, lambda t: "rate_hz 100 ·" in t and "rate_hz := 100.0: ok" in t, "rate_hz 100 from the node")
        integrator = driver.find_element(By.XPATH, "//label[normalize-space()='integrator']/following::input[1]")
        driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", integrator)
        integrator.click()
        driver.find_element(By.XPATH, "//*[@role='option' and normalize-space()='semi_implicit_euler']").click()
        wait_text(driver, lambda t: "paused · integrator semi_implicit_euler\n" in t, "the integrator from the node")
        n = len(watcher.twists)
        click(driver, "Run")
        watcher.wait("ticks while running", lambda: len(watcher.twists) >= n + 5)
        click(driver, "Pause")
        wait_text(driver, lambda t: "pause: ok" in t, "Pause's answer")
        watcher.wait("the last tick's twist", lambda: False, timeout=0.3, expire_ok=True)
        n = len(watcher.twists)
        watcher.wait("no tick while paused", lambda: len(watcher.twists) > n, timeout=0.5, expire_ok=True)
        assert len(watcher.twists) == n
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
    """``rigid-body-sim run`` of the default scene (the box tumbling at ω = (0.2, 0.1, 0.5) rad/s), 100 samples/s."""
    script = Path(view_command()[0])
    done = subprocess.run([str(script), "run", str(SCENE), "--duration", f"{duration_s:g}", "--record", str(path), "-q"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and path.is_file(), done


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


@pytest.fixture(scope="module")
def tumble_recording(tmp_path_factory) -> Path:
    """The default box tumbling for 40 s, recorded once for the module (0.5 MB: two 256 KiB chunks)."""
    path = tmp_path_factory.mktemp("recording") / "tumble.mcap"
    record_tumbling_box(path, duration_s=40.0)
    return path


@pytest.mark.timeout(240)
def test_replay_in_chromium_shows_the_recorded_pose_at_the_slider_time(tmp_path, browser, tumble_recording):
    from rigid_body_sim.offline.recording import read_recording

    record = tumble_recording
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
        view = subprocess.Popen(view_command(str(record), "--port", str(port)), stdout=log, stderr=subprocess.STDOUT,
                                env=stack_dump_env(tmp_path))
    driver = browser
    try:
        open_page(driver, port, view, tmp_path / "view.log")
        wait_text(driver, lambda t: "1 body, 4001 samples, t = 0 … 40 s" in t and "Plots (the whole recording)" in t,
                  "the recording's summary and its plots")
        check(wait_pose_at(driver, 0.0), 0.0)

        # The keyboard on the slider's thumb: three steps of one sample (0.01 s) to the right.
        thumb = driver.find_element(By.CSS_SELECTOR, "[role='slider']")
        for _ in range(3):
            thumb.send_keys(Keys.ARROW_RIGHT)
        check(wait_pose_at(driver, 0.03), 0.03)
        early = box_mask(settled_screenshot(driver))

        # The number box beside the slider, typed into as a user would.
        box = thumb.find_element(By.XPATH, "./ancestor::div[contains(@class, 'Slider-root')]/following::input[1]")
        box.send_keys(Keys.CONTROL, "a")
        box.send_keys("2.5")
        check(wait_pose_at(driver, 2.5), 2.5)
        png = settled_screenshot(driver)
        (tmp_path / "replay.png").write_bytes(png)
        late = box_mask(png)
        moved = int(np.count_nonzero(early ^ late))
        print(f"box-coloured pixels: {int(early.sum())} at t = 0.03 s, {int(late.sum())} at t = 2.5 s, "
              f"{moved} differ")
        assert early.sum() > at_least(DRAWN_SHARE) and late.sum() > at_least(DRAWN_SHARE), (early.sum(), late.sum())
        assert moved > at_least(MOVED_SHARE), moved

        thumb.send_keys(Keys.END)
        check(wait_pose_at(driver, 40.0), 40.0)

        # Play from the end starts again at 0 and moves on; Pause holds a recorded sample.
        click(driver, "Play")
        try:
            wait_text(driver, lambda t: "playing" in t, "playing")
            end = time.monotonic() + 30.0
            while not ((pose := shown_pose(driver)) and 0.3 < pose[0] < 40.0):
                assert time.monotonic() < end, f"playback never moved on; the page shows {pose}"
                time.sleep(0.1)
            click(driver, "Pause")
            paused = wait_text(driver, lambda t: "paused at t = " in t, "paused")
        except AssertionError as failure:
            raise with_stacks(view, tmp_path / "view.log", failure) from failure
        at = float(paused.split("paused at t = ", 1)[1].split(" s", 1)[0])
        pose = wait_pose_at(driver, at)
        check(pose, pose[0])
        time.sleep(0.5)
        assert shown_pose(driver)[0] == pose[0]
    finally:
        code = stop_process(view)
    log = (tmp_path / "view.log").read_text()
    assert code == 0 and "Traceback" not in log, log


@pytest.mark.timeout(120)
def test_replay_refuses_what_is_no_recording_and_plays_a_cut_one_up_to_the_cut(tmp_path, tumble_recording):
    from rigid_body_sim.offline.recording import read_recording

    (tmp_path / "notes.mcap").write_text("not a recording\n")
    for path, says in ((tmp_path / "notes.mcap", "not an MCAP recording"),
                       (tmp_path / "missing.mcap", "No such file or directory")):
        done = subprocess.run(view_command(str(path), "--port", str(free_port())), capture_output=True, text=True,
                              timeout=60)
        assert done.returncode == 2, done
        assert done.stdout == "" and done.stderr.count("\n") == 1 and says in done.stderr, done
        assert done.stderr.startswith(f"rigid-body-sim view: {path}: "), done

    whole = tumble_recording  # two chunks: the cut keeps the first
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


# ------------------------------------------------------------------------------ the view's pure parts


def test_poses_are_read_from_cdr_as_the_middleware_writes_them():
    from geometry_msgs.msg import Pose, PoseArray
    from rclpy.serialization import serialize_message

    from rigid_body_sim.view.wire import parse_pose_array

    rng = np.random.default_rng(1)
    for frame in ("", "w", "world", "sim1/world", "a" * 13):  # every alignment of the pose block
        for n in (0, 1, 3):
            msg = PoseArray()
            msg.header.frame_id = frame
            msg.header.stamp.sec, msg.header.stamp.nanosec = 12, 345678901
            values = rng.normal(size=(n, 7))
            for row in values:
                pose = Pose()
                pose.position.x, pose.position.y, pose.position.z = (float(v) for v in row[:3])
                pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = (float(v) for v in row[3:])
                msg.poses.append(pose)
            stamp, frame_id, p, q = parse_pose_array(serialize_message(msg))
            assert (stamp, frame_id) == ((12, 345678901), frame)
            assert p.shape == (n, 3) and q.shape == (n, 4)
            assert np.array_equal(np.hstack((p, q)), values)  # the same float64s, bit for bit
    with pytest.raises(ValueError):
        parse_pose_array(b"not cdr at all")


def test_velocities_and_contacts_are_read_at_the_offsets_the_node_writes():
    from rclpy.serialization import deserialize_message, serialize_message
    from sensor_msgs.msg import PointCloud2

    from rigid_body_sim.ros.batch import batch_rows, velocity_cloud
    from rigid_body_sim.ros.contacts import CONTACT_POINT_STEP, contact_points
    from rigid_body_sim.view.wire import contacts_from_cloud, velocities_from_cloud

    rng = np.random.default_rng(2)
    v, w = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    cloud = velocity_cloud(3)
    cloud.data = batch_rows(np.zeros((3, 3)), np.zeros((3, 4)), v, w, np.array([False, True, False]))[1].tobytes()
    read_v, read_w = velocities_from_cloud(deserialize_message(serialize_message(cloud), PointCloud2))
    assert np.array_equal(read_v, v) and np.array_equal(read_w, w)

    rows = [{"x": 0.1, "y": -0.2, "z": 0.0, "nx": 0.0, "ny": 0.6, "nz": 0.8, "gap": -1e-9, "normal_force": 19.62,
             "body": 4, "ground": 1, "state": 1},
            {"x": 2.0, "y": 3.0, "z": 4.0, "nx": 1.0, "ny": 0.0, "nz": 0.0, "impulse": 0.5, "state": 0}]
    cloud = PointCloud2(height=1, width=2, point_step=CONTACT_POINT_STEP, row_step=2 * CONTACT_POINT_STEP,
                        is_dense=True, data=contact_points(rows).tobytes())
    points, normals = contacts_from_cloud(deserialize_message(serialize_message(cloud), PointCloud2))
    assert np.array_equal(points, [[0.1, -0.2, 0.0], [2.0, 3.0, 4.0]])
    assert np.array_equal(normals, [[0.0, 0.6, 0.8], [1.0, 0.0, 0.0]])
    cloud.point_step = 100  # another layout: not read
    assert contacts_from_cloud(cloud) is None


def test_click_rays_meet_each_shape_where_geometry_says():
    from rigid_body_sim.view.pick import BOX, CYLINDER, ELLIPSOID, ray_hit, strike_at

    quarter_z = (np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4))  # 90 degrees about z
    # A 1 x 0.6 x 0.4 box at (0, 0, 1) turned 90 degrees about z: its 1 m edge lies along world y.
    hit = ray_hit(BOX, (1.0, 0.6, 0.4), (1, 0, 0, 0), (0, 0, 1), quarter_z, (0.0, 0.45, 5.0), (0, 0, -1))
    np.testing.assert_allclose(hit, [0.0, 0.45, 1.2], atol=1e-12)  # the top face, inside the turned footprint
    assert ray_hit(BOX, (1.0, 0.6, 0.4), (1, 0, 0, 0), (0, 0, 1), quarter_z, (0.45, 0.0, 5.0), (0, 0, -1)) is None
    # A sphere of radius 0.5 at the origin, a ray along -x at height y = 0.3: x = sqrt(0.25 - 0.09) = 0.4.
    hit = ray_hit(ELLIPSOID, (1.0, 1.0, 1.0), (1, 0, 0, 0), (0, 0, 0), (1, 0, 0, 0), (3.0, 0.3, 0.0), (-2, 0, 0))
    np.testing.assert_allclose(hit, [0.4, 0.3, 0.0], atol=1e-12)
    # An ellipsoid of semi-axes (1, 0.5, 0.25) whose frame is turned 90 degrees about z in the body:
    # its long axis is the body's y, so a ray along -y meets it at y = 1.
    hit = ray_hit(ELLIPSOID, (2.0, 1.0, 0.5), quarter_z, (0, 0, 0), (1, 0, 0, 0), (0.0, 4.0, 0.0), (0, -1, 0))
    np.testing.assert_allclose(hit, [0.0, 1.0, 0.0], atol=1e-12)
    # A cylinder of radius 0.2 and length 1 along its z: the side from +x, the cap from +z.
    np.testing.assert_allclose(ray_hit(CYLINDER, (0.4, 0.4, 1.0), (1, 0, 0, 0), (0, 0, 0), (1, 0, 0, 0),
                                       (2.0, 0.0, 0.3), (-1, 0, 0)), [0.2, 0.0, 0.3], atol=1e-12)
    np.testing.assert_allclose(ray_hit(CYLINDER, (0.4, 0.4, 1.0), (1, 0, 0, 0), (0, 0, 0), (1, 0, 0, 0),
                                       (0.1, 0.0, 3.0), (0, 0, -1)), [0.1, 0.0, 0.5], atol=1e-12)
    # The strike: J d along the (normalised) direction, (p - c) x J d about the centre of mass.
    linear, angular = strike_at((0.5, 0.3, 0.8), (0.0, 0.0, 1.0), (0.0, 0.0, 2.0), 0.5)
    np.testing.assert_allclose(linear, [0.0, 0.0, 0.5], atol=0)
    np.testing.assert_allclose(angular, [0.3 * 0.5, -0.5 * 0.5, 0.0], atol=1e-15)
    with pytest.raises(ValueError, match="non-zero finite"):
        strike_at((0, 0, 0), (0, 0, 0), (0.0, 0.0, 0.0), 1.0)


def test_plotted_energy_and_momentum_match_the_closed_forms_of_a_spinning_box():
    from rigid_body_sim.view.mechanics import MassModel, totals

    # A 2 kg box of principal moments (1, 2, 3) kg m^2, turned 90 degrees about x, spinning at 4 rad/s
    # about its own third principal axis (world -y after the turn), moving at v, at p, under gravity g.
    s2 = np.sqrt(0.5)
    q_WB_xyzw = np.array([[s2, 0.0, 0.0, s2]])
    w_W = np.array([[0.0, -4.0, 0.0]])
    v_W, p_W, g = np.array([[0.3, 0.0, -0.4]]), np.array([[1.0, 2.0, 3.0]]), np.array([0.0, 0.0, -9.81])
    model = MassModel(("b",), np.array([2.0]), np.array([[1.0, 2.0, 3.0]]), np.array([[1.0, 0.0, 0.0, 0.0]]), g)
    energy, L = totals(model, p_W, q_WB_xyzw, v_W, w_W)
    expected_energy = 0.5 * 3.0 * 16.0 + 0.5 * 2.0 * 0.25 + 2.0 * 9.81 * 3.0  # spin + translation + height
    expected_L = np.array([0.0, -3.0 * 4.0, 0.0]) + np.cross(p_W[0], 2.0 * v_W[0])  # I w + p x m v
    assert abs(energy - expected_energy) < 1e-12 and abs(L - np.linalg.norm(expected_L)) < 1e-12


def test_replay_plots_the_closed_form_energy_and_momentum_of_the_free_box(tumble_recording):
    from rigid_body_sim.view.replay import load_replay, replay_series

    _mass, inertia, _corner = box_from_scene()
    w0 = np.array(yaml.safe_load(SCENE.read_text())["bodies"]["box"]["twist"]["angular"])
    replay = load_replay(tumble_recording)
    t, energy, L, speed = replay_series(replay, "box")
    assert len(t) == 4001 and replay.sites_B == {"box": ((0.5, 0.3, 0.0),)}
    # Torque-free, at rest in translation: E = ½ ωᵀ I ω and L = I ω at t = 0, conserved (rk4, dt 0.01 s:
    # its drift over 40 s is far below the 1e-6 bound, which still catches any wrong term).
    np.testing.assert_allclose(energy, 0.5 * w0 @ inertia @ w0, rtol=1e-6)
    np.testing.assert_allclose(L, np.linalg.norm(inertia @ w0), rtol=1e-6)
    np.testing.assert_allclose(speed, 0.0, atol=1e-12)
