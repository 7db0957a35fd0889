"""``rigid-body-sim view RECORDING.mcap``: replay a recording in the same view, without ROS.

The recording is read by :func:`rigid_body_sim.offline.recording.read_recording` (each body's
samples over sim time, and the scene attached as ``scene.yaml``). Each body is drawn as the live
view draws it (:class:`.drawing.Bodies`: a frame with its axes holding its shape), the shape being the
one the node's markers give it (:func:`rigid_body_sim.ros.markers.body_shapes`, from the attached
scene's inertia declaration). No ROS domain is joined: nothing here creates an rclpy context.

The sites and IMUs come from the attached scene too, and so do the masses for the plots of the
whole recording (:func:`replay_series`: total energy, |L| about the origin, a body's speed). The
page has a time slider (sim time, s; one step per sample interval), Play and Pause, a
playback speed, and a ``pose`` field with the chosen body's sample: the sample shown is the last
one at or before the slider's time, with its time, position and orientation exactly as read
(every float written in full, ``repr``), so what the page shows can be compared with the file.
"""

from __future__ import annotations

import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .app import PROG, shown_host, start_server
from .drawing import BATCH_ABOVE, BatchedBodies, Bodies, _Shape, setup_scene, shape_from_marker
from .page import REFRESH_HZ

__all__ = ["Replay", "load_replay", "run_replay", "pose_text", "replay_series", "SPEEDS"]

#: Playback speeds offered (sim seconds per wall second), the first entry being the default.
SPEEDS = ("1", "0.1", "0.25", "0.5", "2", "4", "10")


@dataclass
class Replay:
    """A recording as the replay shows it."""

    source: str
    times_ns: np.ndarray  # (T,) int64, increasing: the samples' sim times
    names: list[str]  # bodies, in the recording's order
    positions: dict[str, np.ndarray]  # (T, 3) m, world
    orientations_xyzw: dict[str, np.ndarray]  # (T, 4) B -> W
    shapes: dict[str, _Shape]  # from the attached scene; a body without one is drawn as its axes
    status: str  # how the recording ended ("complete: ...", "cut short: ...", or "")
    notes: list[str] = field(default_factory=list)  # what could not be drawn, and why
    linear_velocities: dict[str, np.ndarray] = field(default_factory=dict)  # (T, 3) m/s, world
    angular_velocities: dict[str, np.ndarray] = field(default_factory=dict)  # (T, 3) rad/s, world
    sites_B: dict[str, tuple[tuple[float, float, float], ...]] = field(default_factory=dict)  # body -> sites in B (m)
    imus: dict[str, tuple[float, float, float]] = field(default_factory=dict)  # "B/S" -> position in B (m)
    mass: Any = None  # a .mechanics.MassModel in the order of ``names``, from the attached scene, or None
    _totals: Any = None  # (T, 2) energy and |L|, computed once when first plotted

    @property
    def cut_short(self) -> bool:
        from ..offline.recording import CUT_SHORT

        return self.status.startswith(CUT_SHORT)

    def index_at(self, t_s: float) -> int:
        """The last sample at or before sim time ``t_s`` (the first one before the start)."""
        k = int(np.searchsorted(self.times_ns, int(round(float(t_s) * 1e9)), side="right")) - 1
        return min(max(k, 0), len(self.times_ns) - 1)

    def time_s(self, k: int) -> float:
        return int(self.times_ns[k]) * 1e-9


def _scene_shapes(scene_text: str | None, source: str, names: list[str]) -> tuple[dict[str, _Shape], list[str], Any]:
    """The bodies' shapes from the attached scene, as the node's markers draw them, notes on what is
    missing, and the scene (None if there is none that loads)."""
    if scene_text is None:
        return {}, ["no scene attached to the recording: bodies are drawn as their axes only"], None
    from ..core import SceneError
    from ..core.scene import load_scene_text
    from ..ros.markers import _BODY_RGBA, body_shapes

    try:
        scene = load_scene_text(scene_text, f"{source} (its attached scene.yaml)")
    except SceneError as exc:
        return {}, [f"the attached scene cannot be loaded ({exc}): bodies are drawn as their axes only"], None
    shapes: dict[str, _Shape] = {}
    for b, (name, (kind, scale, principal)) in enumerate(zip(scene.body_names, body_shapes(scene))):
        q_rel = tuple(float(x) for x in scene.model.q_BP[b]) if principal else (1.0, 0.0, 0.0, 0.0)
        shapes[name] = shape_from_marker(kind, scale, _BODY_RGBA, q_rel)  # type: ignore[arg-type]
    missing = [n for n in names if n not in shapes]
    notes = [f"the attached scene has no body {', '.join(missing)}: drawn as axes only"] if missing else []
    return shapes, notes, scene


def _scene_sites(scene: Any) -> tuple[dict[str, tuple], dict[str, tuple[float, float, float]]]:
    """Each body's sites in its body frame (m), and the IMUs ("B/S" -> position in B), from the scene."""
    from ..core.quaternion import quat_rotate

    model = scene.model
    sites: dict[str, list] = {}
    positions: dict[str, tuple[float, float, float]] = {}
    for s, key in enumerate(model.site_names):
        b = int(model.site_body[s])
        p_B = quat_rotate(model.q_BP[b], model.site_p_P[s])
        positions[key] = tuple(float(c) for c in p_B)  # type: ignore[assignment]
        sites.setdefault(scene.body_names[b], []).append(positions[key])
    return ({name: tuple(points) for name, points in sites.items()},
            {key: positions[key] for key in getattr(scene, "imus", {}) if key in positions})


def load_replay(path: str | Path) -> Replay:
    """Read ``path`` for the replay. Raises ValueError (one line) if it is not a recording that can be read."""
    from ..offline.recording import read_recording

    data, scene_text = read_recording(path)
    names = list(data.bodies)
    times_ns = np.round(np.asarray(data.time, dtype=float) * 1e9).astype(np.int64)
    shapes, notes, scene = _scene_shapes(scene_text, str(path), names)
    sites, imus, mass = {}, {}, None
    if scene is not None:
        from .mechanics import mass_model_from_scene

        sites, imus = _scene_sites(scene)
        if list(scene.body_names) == names:
            mass = mass_model_from_scene(scene)
    return Replay(source=str(path), times_ns=times_ns, names=names,
                  positions={n: np.asarray(data.bodies[n].position_world, dtype=float) for n in names},
                  orientations_xyzw={n: np.asarray(data.bodies[n].orientation_xyzw, dtype=float) for n in names},
                  shapes=shapes, status=str(data.meta.get("status", "")), notes=notes,
                  linear_velocities={n: np.asarray(data.bodies[n].linear_velocity_world, dtype=float) for n in names},
                  angular_velocities={n: np.asarray(data.bodies[n].angular_velocity_world, dtype=float) for n in names},
                  sites_B=sites, imus=imus, mass=mass)


def replay_series(replay: Replay, body: str) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, np.ndarray]:
    """(t (s), total energy (J) or None, |L| about the origin (kg·m²/s) or None, the body's speed (m/s))
    at every sample, for the plots (energy and |L| need the attached scene's masses)."""
    from .mechanics import totals

    t = replay.times_ns * 1e-9
    speed = np.linalg.norm(replay.linear_velocities[body], axis=1)
    if replay.mass is None:
        return t, None, None, speed
    if replay._totals is None:
        stack = lambda d: np.stack([d[n] for n in replay.names], axis=1)  # noqa: E731  (T, N, k)
        p, q, v, w = (stack(d) for d in (replay.positions, replay.orientations_xyzw, replay.linear_velocities,
                                         replay.angular_velocities))
        replay._totals = np.array([totals(replay.mass, p[k], q[k], v[k], w[k]) for k in range(len(t))]).reshape(-1, 2)
    energy, L = replay._totals[:, 0], replay._totals[:, 1]
    return t, energy, L, speed


def pose_text(replay: Replay, body: str, k: int) -> str:
    """The ``pose`` field: body, sample, time, position and orientation, every float in full."""
    p = [float(v) for v in replay.positions[body][k]]
    q = [float(v) for v in replay.orientations_xyzw[body][k]]
    return (f"body {body}, sample {k + 1} of {len(replay.times_ns)}\n"
            f"t = {replay.time_s(k)!r} s\n"
            f"position (m) = [{', '.join(repr(v) for v in p)}]\n"
            f"orientation (x, y, z, w) = [{', '.join(repr(v) for v in q)}]")


def _slider_step(times_ns: np.ndarray) -> float:
    """The slider's step, s: the typical (median) sample interval, at least 1 ns."""
    if len(times_ns) < 2:
        return 1e-3
    return max(1, int(np.median(np.diff(times_ns)))) * 1e-9


class _ReplayPage:
    """The viser scene and GUI of a replay; :meth:`refresh` advances playback at :data:`.app.REFRESH_HZ`."""

    def __init__(self, server: Any, replay: Replay):
        self.server, self.replay = server, replay
        self.bodies = Bodies(server)
        self.batched = BatchedBodies(server) if len(replay.names) > BATCH_ABOVE else None
        self.lock = threading.RLock()
        self.playing = False
        self.origin = (0.0, 0.0)  # (wall monotonic, sim time) playback started from
        self.index = 0
        setup_scene(server)
        gui = server.gui
        r = replay
        t0, t1 = r.time_s(0), r.time_s(len(r.times_ns) - 1)
        gui.add_markdown(f"**rigid_body_sim replay** `{Path(r.source).name}`")
        summary = (f"{len(r.names)} bod{'y' if len(r.names) == 1 else 'ies'}, {len(r.times_ns)} samples, "
                   f"t = {t0:g} … {t1:g} s")
        if r.cut_short:
            summary += f"\n\n**cut short**: plays up to t = {t1:.9g} s, the last whole sample ({r.status})"
        elif r.status:
            summary += f"\n\nrecording status: {r.status}"
        for note in r.notes:
            summary += f"\n\n{note}"
        gui.add_markdown(summary)
        step = _slider_step(r.times_ns)
        self.slider = gui.add_slider("time (s)", min=t0, max=t1 if t1 > t0 else t0 + step, step=step,
                                     initial_value=t0)
        gui.add_button("Play").on_click(lambda _event: self.play())
        gui.add_button("Pause").on_click(lambda _event: self.pause())
        self.speed = gui.add_dropdown("speed (×)", options=SPEEDS, initial_value=SPEEDS[0])
        self.body = gui.add_dropdown("body", options=tuple(r.names), initial_value=r.names[0])
        self.pose = gui.add_text("pose", initial_value="", disabled=True, multiline=True)
        self.playback = gui.add_markdown("paused")
        # Closed at first: a chart of thousands of samples redrawn with every page update slows the
        # page down on a slow machine (software WebGL), so it is drawn when the user opens it.
        self.plots_folder = gui.add_folder("Plots (the whole recording)", expand_by_default=False)
        self.plots: dict[str, Any] = {}
        self.slider.on_update(self._on_slider)
        self.speed.on_update(lambda _event: self._reanchor())
        self.body.on_update(lambda _event: (self.show(self.index), self._plot()))
        self.show(0)
        self.bodies.show_sites(r.sites_B)
        self.bodies.show_imus({key: (f"IMU {key.split('/', 1)[1]}", p) for key, p in r.imus.items()})
        self._plot()

    def _plot(self) -> None:
        """Energy and |L| of the whole recording (with the attached scene's masses) and the chosen body's speed."""
        t, energy, L, speed = replay_series(self.replay, self.body.value)
        if len(t) < 2:
            return
        for key, y, label, title, color in (
                ("energy", energy, "E (J)", "total energy (J)", "#d62728"),
                ("L", L, "|L| (kg·m²/s)", "|L| about the origin (kg·m²/s)", "#1f77b4"),
                ("speed", speed, "|v| (m/s)", f"speed of {self.body.value} (m/s)", "#2ca02c")):
            if y is None or not np.all(np.isfinite(y)):
                continue
            if key in self.plots:
                self.plots[key].data, self.plots[key].title = (t, y), title
                continue
            with self.plots_folder:
                self.plots[key] = self.server.gui.add_uplot(
                    data=(t, np.ascontiguousarray(y)), series=({"label": "t (s)"}, {"label": label, "stroke": color}),
                    title=title, scales={"x": {"time": False}}, aspect=2.2)

    # ------------------------------------------------------------------ playback
    def _on_slider(self, event: Any) -> None:
        with self.lock:
            if event.client is not None:  # the user moved it: playback (if on) goes on from there
                self._reanchor()
            self.show(self.replay.index_at(self.slider.value))

    def _reanchor(self) -> None:
        with self.lock:
            self.origin = (time.monotonic(), float(self.slider.value))

    def play(self) -> None:
        with self.lock:
            last = len(self.replay.times_ns) - 1
            if self.index >= last:  # at the end: from the start again
                self.slider.value = self.replay.time_s(0)
            self.playing = True
            self._reanchor()
            self.playback.content = "playing"

    def pause(self) -> None:
        with self.lock:
            self.playing = False
            self.playback.content = f"paused at t = {self.replay.time_s(self.index):.9g} s"

    def refresh(self) -> None:
        with self.lock:
            if not self.playing:
                return
            r = self.replay
            wall0, sim0 = self.origin
            t = sim0 + (time.monotonic() - wall0) * float(self.speed.value)
            last = len(r.times_ns) - 1
            k = r.index_at(t)
            if k >= last:
                k, self.playing = last, False
                self.playback.content = (f"the end: t = {r.time_s(last):.9g} s"
                                         + (" (the recording was cut short here)" if r.cut_short else ""))
            if k != self.index or not self.playing:
                self.slider.value = r.time_s(k)  # calls _on_slider, which shows sample k

    def show(self, k: int) -> None:
        """Draw every body at sample ``k`` and fill the ``pose`` field for the chosen body."""
        with self.lock:
            r = self.replay
            self.index = k
            poses = {}
            for name in r.names:
                p, q = r.positions[name][k], r.orientations_xyzw[name][k]
                if np.all(np.isfinite(p)) and np.all(np.isfinite(q)):
                    poses[name] = (tuple(float(v) for v in p), (float(q[3]), float(q[0]), float(q[1]), float(q[2])))
            if self.batched is not None:  # many bodies: instanced, as the live view draws them
                shown = [n for n in r.names if n in poses]
                self.batched.show_arrays(shown, np.array([r.positions[n][k] for n in shown]).reshape(-1, 3),
                                         np.array([r.orientations_xyzw[n][k] for n in shown]).reshape(-1, 4), r.shapes)
            else:
                self.bodies.show(poses, r.shapes)
            self.pose.value = pose_text(r, self.body.value, k)


def run_replay(path: str, host: str, port: int, stop: threading.Event) -> int:
    """Serve the replay of ``path`` until ``stop`` is set; returns the exit code (2: not a
    recording that can be read, or the address is in use), each failure said in one line."""
    try:
        replay = load_replay(path)
    except ValueError as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    t_end = replay.time_s(len(replay.times_ns) - 1)
    if replay.cut_short:
        print(f"{PROG}: warning: {path}: {replay.status}; the replay plays up to t = {t_end:.9g} s",
              file=sys.stderr, flush=True)
    for note in replay.notes:
        print(f"{PROG}: warning: {path}: {note}", file=sys.stderr, flush=True)
    server = start_server(host, port)
    if server is None:
        return 2
    try:
        page = _ReplayPage(server, replay)
        bodies = f"{len(replay.names)} bod{'y' if len(replay.names) == 1 else 'ies'}"
        print(f"{PROG}: open http://{shown_host(host)}:{port} (replay of {path}: {bodies}, "
              f"t = {replay.time_s(0):g} … {t_end:g} s); Ctrl-C stops", flush=True)
        while not stop.wait(1.0 / REFRESH_HZ):
            page.refresh()
        return 0
    finally:
        server.stop()
