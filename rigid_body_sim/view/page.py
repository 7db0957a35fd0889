"""The live view's page: the 3D drawing, the status, the controls, the plots and the strikes.

Built once on a viser server from a :class:`.client.RosClient`; :meth:`LivePage.refresh` (called
at :data:`REFRESH_HZ` by :func:`.app.run_view`) brings the page up to date with the latest state
the client holds. GUI callbacks (viser's threads) only ask the client to call a service, set a
parameter or publish, so no click ever waits on ROS.
"""

from __future__ import annotations

import time
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from .client import RosClient
from .drawing import BATCH_ABOVE, BatchedBodies, Bodies, setup_scene
from .mechanics import MassModel, mass_model_from_scene, totals
from .pick import BOX, CYLINDER, ELLIPSOID, ray_hit, strike_at
from .strike import STRIKE_IMPULSE_NS, strike_point, strike_wrench

__all__ = ["LivePage", "REFRESH_HZ", "INTEGRATORS", "STRIKE_DIRECTIONS"]

#: How often the page is brought up to date with the latest state, Hz.
REFRESH_HZ = 20.0
#: Plots, the IMU search and trails are refreshed at most this often, Hz.
SLOW_HZ = 4.0
#: How often the node's parameters are read again, s.
PARAMS_PERIOD_S = 2.0
#: A control the user has just edited is not overwritten with the node's value for this long, s
#: (a field being typed in keeps what is typed; the node's value shows once the user stops).
EDIT_HOLD_S = 2.0
#: Samples kept in each plot.
PLOT_SAMPLES = 600
INTEGRATORS = ("rk4", "euler", "exact_rotor_splitting", "implicit_gyroscopic", "reference", "semi_implicit_euler",
               "splitting", "symmetric_splitting")
#: Click-to-strike directions: along the click's view ray (into the body), or a world axis.
STRIKE_DIRECTIONS = {"into the body (view ray)": None, "world +z": (0.0, 0.0, 1.0), "world −z": (0.0, 0.0, -1.0),
                     "world +x": (1.0, 0.0, 0.0), "world −x": (-1.0, 0.0, 0.0), "world +y": (0.0, 1.0, 0.0),
                     "world −y": (0.0, -1.0, 0.0)}


def _pick_kind(kind: int) -> str:
    from visualization_msgs.msg import Marker

    return {Marker.CUBE: BOX, Marker.CYLINDER: CYLINDER}.get(kind, ELLIPSOID)


class LivePage:
    """The viser scene and GUI of the live view."""

    def __init__(self, server: Any, ros: RosClient):
        self.server, self.ros = server, ros
        self.bodies = Bodies(server, on_click=self._on_body_click)
        self.batched = BatchedBodies(server, on_click=self._on_body_click, pick=self._pick)
        setup_scene(server)
        gui = server.gui
        gui.add_markdown(f"**rigid_body_sim** `{ros.sim_name}`")
        self.status = gui.add_markdown("waiting…")
        self.sim_time = gui.add_text("sim time (s)", initial_value="–", disabled=True)
        self.rate_text = gui.add_markdown(" ")
        with gui.add_folder("Run"):
            for label, what in (("Pause", "pause"), ("Run", "run"), ("Step", "step"), ("Reset", "reset")):
                gui.add_button(label).on_click(lambda _event, what=what: ros.call(what))
            self.step_n = gui.add_number("ticks", initial_value=10, min=1, max=1_000_000, step=1)
            gui.add_button("Step N").on_click(lambda _event: ros.call_step_ticks(int(self.step_n.value)))
        self.reply = gui.add_markdown(" ")
        with gui.add_folder("Feel the offset"):
            gui.add_markdown(
                f"An upward impulse J = {STRIKE_IMPULSE_NS:g} N·s on `{ros.strike_body}`'s bottom face, "
                "from under its centre (0) to the corner (1): at 0 it only rises, further out it also turns, "
                "by Δω = I⁻¹ (r × J).")
            self.offset = gui.add_slider("offset", min=0.0, max=1.0, step=0.01, initial_value=0.0)
            self.strike_text = gui.add_markdown("offset 0: r under the centre")
            gui.add_button("Strike").on_click(lambda _event: self._strike())
            self.offset.on_update(lambda _event: self._show_strike_point())
        with gui.add_folder("Integrator and rate"):
            self.integrator = gui.add_dropdown("integrator", options=INTEGRATORS, initial_value=INTEGRATORS[0])
            self.rate_hz = gui.add_number("rate_hz", initial_value=100.0, min=0.001, max=100000.0, step=0.001)
            self.rtf = gui.add_number("real_time_factor", initial_value=1.0, min=1e-6, max=1e6, step=1e-6)
            self._controls = {"integrator": (self.integrator, str), "rate_hz": (self.rate_hz, float),
                              "real_time_factor": (self.rtf, float)}
            self._edited_at = dict.fromkeys(self._controls, -EDIT_HOLD_S)  # monotonic s of the user's last edit
            # each control's value as the page last set it or last heard it from the user: a control that
            # differs holds a user's edit whose callback has not run yet (it is not overwritten)
            self._known = {name: handle.value for name, (handle, _cast) in self._controls.items()}
            for name, (handle, cast) in self._controls.items():
                handle.on_update(lambda event, h=handle, n=name, c=cast: self._edited(event, n, c(h.value)))
        with gui.add_folder("Click to strike"):
            gui.add_markdown("Click a point of a body: an impulse of the chosen size and direction is applied there "
                             "at the next step (on `impulse`, frame `B/world_aligned`).")
            self.click_direction = gui.add_dropdown("direction", options=tuple(STRIKE_DIRECTIONS),
                                                    initial_value=next(iter(STRIKE_DIRECTIONS)))
            self.click_size = gui.add_slider("impulse (N·s)", min=0.01, max=5.0, step=0.01, initial_value=0.5)
            self.click_text = gui.add_markdown("no click yet")
        with gui.add_folder("Show"):
            self.trails_on = gui.add_checkbox("trails", initial_value=False)
            self.trails_on.on_update(lambda _event: self.bodies.show_trails(self.trails_on.value))
            gui.add_button("Clear trails").on_click(lambda _event: self._clear_trails())
            self.imu_text = gui.add_markdown("IMUs: none")
        with gui.add_folder("Plots") as self.plots_folder:
            self.plot_note = gui.add_markdown("waiting for the scene")
            self.speed_body = gui.add_dropdown("speed of", options=("–",), initial_value="–")
        # Made when their first two samples are there (viser's uPlot shows no data added to an empty chart).
        self.plots: dict[str, Any] = {}
        self.history: deque[tuple[float, float, float, float]] = deque(maxlen=PLOT_SAMPLES)
        self._mass: tuple[tuple, MassModel | None, str] = ((), None, "")
        self._last_velocity_stamp: float | None = None
        self._plotted_body = ""
        self.strike_dot: Any = None
        self._slow_due = self._params_due = 0.0
        self._drawn_stamp: float | None = None
        self._draws: deque[float] = deque(maxlen=400)  # wall times at which new poses were drawn

    # ------------------------------------------------------------------ strikes
    def _edges(self) -> tuple[float, float, float] | None:
        from visualization_msgs.msg import Marker

        with self.ros.lock:
            shape = self.ros.shapes.get(self.ros.strike_body)
        if shape is None or shape.kind != Marker.CUBE:
            return None
        return shape.scale

    def _show_strike_point(self) -> None:
        edges = self._edges()
        if edges is None:
            self.strike_text.content = f"waiting for `{self.ros.strike_body}`'s box shape (markers)"
            return
        r = strike_point(edges, self.offset.value)
        self.strike_text.content = f"offset {self.offset.value:.2f}: r = ({r[0]:.3f}, {r[1]:.3f}, {r[2]:.3f}) m"
        if self.ros.strike_body in self.bodies.frames:
            if self.strike_dot is None:
                self.strike_dot = self.server.scene.add_icosphere(f"/bodies/{self.ros.strike_body}/strike",
                                                                  radius=0.03, color=(220, 30, 30))
            self.strike_dot.position = r

    def _strike(self) -> None:
        edges = self._edges()
        body = self.ros.strike_body
        if edges is None:
            text = f"strike: no box shape for `{body}` yet (markers)"
        else:
            linear, angular = strike_wrench(edges, self.offset.value)
            why_not = self.ros.publish_impulse(body, linear, angular)
            r = strike_point(edges, self.offset.value)
            text = (f"strike: {why_not}" if why_not else
                    f"strike sent: J = {linear[2]:g} N·s up at r = ({', '.join(f'{v:.3f}' for v in r)}) m, "
                    f"r × J = ({', '.join(f'{v:.3f}' for v in angular)}) N·m·s")
        with self.ros.lock:
            self.ros.reply = text

    def _on_body_click(self, name: str, event: Any) -> None:
        """A click on body ``name``'s shape: strike it where the click's ray meets the shape."""
        ros = self.ros
        with ros.lock:
            names = list(ros.names or [])
            shape = ros.shapes.get(name)
            if name not in names or shape is None or names.index(name) >= len(ros.positions):
                self.click_text.content = f"click on `{name}`: its pose or shape is not known yet"
                return
            b = names.index(name)
            p_W = np.array(ros.positions[b], dtype=float)
            x, y, z, w = (float(c) for c in ros.orientations_xyzw[b])
        hit = ray_hit(_pick_kind(shape.kind), shape.scale, shape.q_rel_wxyz, p_W, (w, x, y, z),
                      event.ray_origin, event.ray_direction)
        if hit is None:
            self.click_text.content = f"click on `{name}`: the ray misses its shape (moved since?); click again"
            return
        direction = STRIKE_DIRECTIONS[self.click_direction.value]
        d = np.asarray(event.ray_direction, dtype=float) if direction is None else np.asarray(direction)
        linear, angular = strike_at(hit, p_W, d, float(self.click_size.value))
        why_not = ros.publish_impulse(f"{name}/world_aligned", linear, angular)
        fmt = lambda v: "(" + ", ".join(f"{c:.4f}" for c in v) + ")"  # noqa: E731
        self.click_text.content = (f"click on `{name}`: {why_not}" if why_not else
                                   f"struck `{name}` at {fmt(hit)} m (world), r = {fmt(hit - p_W)} m from its centre "
                                   f"of mass: J = {fmt(linear)} N·s, r × J = {fmt(angular)} N·m·s (world axes)")

    def _pick(self, names: tuple[str, ...], event: Any) -> str | None:
        """The body among ``names`` whose shape the click's ray meets first (batched drawing)."""
        ros = self.ros
        with ros.lock:
            all_names = list(ros.names or [])
            shapes, positions, q_xyzw = dict(ros.shapes), ros.positions, ros.orientations_xyzw
        best, best_d = None, np.inf
        origin = np.asarray(event.ray_origin, dtype=float)
        for name in names:
            if name not in shapes or name not in all_names or all_names.index(name) >= len(positions):
                continue
            b = all_names.index(name)
            x, y, z, w = (float(c) for c in q_xyzw[b])
            shape = shapes[name]
            hit = ray_hit(_pick_kind(shape.kind), shape.scale, shape.q_rel_wxyz, positions[b], (w, x, y, z),
                          origin, event.ray_direction)
            if hit is not None and np.linalg.norm(hit - origin) < best_d:
                best, best_d = name, float(np.linalg.norm(hit - origin))
        return best

    def _clear_trails(self) -> None:
        self.bodies.clear_trails()
        self.bodies.show_trails(self.trails_on.value)

    # ------------------------------------------------------------------ plots
    def _mass_model(self, names: list[str], params: dict) -> MassModel | None:
        key = (tuple(names), params.get("scene"))
        if self._mass[0] == key:
            return self._mass[1]
        from ..core import SceneError
        from ..core.scene import load_scene

        model, note = None, ""
        path = str(params.get("scene") or "")
        try:
            scene = load_scene(Path(path))
            if tuple(scene.body_names) != tuple(names):
                note = f"the scene file `{path}` no longer matches the node's bodies (spawned or deleted): no plots"
            else:
                model = mass_model_from_scene(scene)
                note = f"masses and inertias from `{Path(path).name}` (the node's `scene`)"
        except (OSError, SceneError, ValueError) as exc:
            note = f"no energy or |L| plot: the node's scene file cannot be read here ({exc})"
        self._mass = (key, model, note)
        self.plot_note.content = note
        return model

    def _update_plots(self, names: list[str], params: dict) -> None:
        ros = self.ros
        with ros.lock:
            velocities = ros.velocities
            poses = ros.recent_poses.get(velocities[0]) if velocities is not None else None
        if velocities is None or len(velocities[1]) != len(names):
            return
        key, v, w = velocities
        t = key[0] + 1e-9 * key[1]
        if self._last_velocity_stamp is not None and t < self._last_velocity_stamp:
            self.history.clear()  # a reset: time went back
        body = self.speed_body.value
        if self.history and self._plotted_body != body:
            self.history.clear()  # another body chosen: its speed from now on
        self._plotted_body = body
        if t == self._last_velocity_stamp:
            return
        self._last_velocity_stamp = t
        model = self._mass_model(names, params)
        energy = L = np.nan
        if model is not None and poses is not None and len(poses[0]) == len(names):
            energy, L = totals(model, poses[0], poses[1], v, w)
        speed = float(np.linalg.norm(v[names.index(body)])) if body in names else np.nan
        self.history.append((t, energy, L, speed))
        data = np.asarray(self.history, dtype=float)
        if len(data) < 2:
            return
        for key, column, label, title, color in (
                ("energy", 1, "E (J)", "total energy (J)", "#d62728"),
                ("L", 2, "|L| (kg·m²/s)", "|L| about the origin (kg·m²/s)", "#1f77b4"),
                ("speed", 3, "|v| (m/s)", "speed of the chosen body (m/s)", "#2ca02c")):
            xy = (np.ascontiguousarray(data[:, 0]), np.ascontiguousarray(data[:, column]))
            if not np.all(np.isfinite(xy[1])):  # no masses (energy, |L|) or no such body (speed)
                continue
            if key in self.plots:
                self.plots[key].data = xy
            else:
                with self.plots_folder:
                    self.plots[key] = self.server.gui.add_uplot(
                        data=xy, series=({"label": "t (s)"}, {"label": label, "stroke": color}), title=title,
                        scales={"x": {"time": False}}, aspect=2.2)

    # ------------------------------------------------------------------ refresh
    def refresh(self) -> None:
        ros = self.ros
        seen = ros.node_seen()
        with ros.lock:
            stamp, names, params = ros.stamp_s, ros.names, dict(ros.params)
            positions, q_xyzw = ros.positions, ros.orientations_xyzw
            shapes, reply, sites = dict(ros.shapes), ros.reply, dict(ros.sites_B)
            arrows, contacts = ros.arrows_W, ros.contacts
        if not seen:
            self.status.content = (f"**waiting for a rigid_body_sim node**: nothing publishes `{ros.poses_topic}` "
                                   f"(start one: `make run`)")
        elif names is None:
            self.status.content = "node found; reading its parameters…"
            ros.request_parameters()
        else:
            missing = [n for n in names if n not in shapes]
            extra = f"; no shape yet for {', '.join(missing[:5])}{'…' if len(missing) > 5 else ''} (markers come with ticks: Step or Run)" if missing else ""
            self.status.content = f"showing {len(names)} bod{'y' if len(names) == 1 else 'ies'}{extra}"
        if stamp is not None:
            self.sim_time.value = f"{stamp:.9f}"
        self._show_parameters(params)
        self.reply.content = reply or " "
        if names is None or len(names) != len(positions):
            return
        batched = len(names) > BATCH_ABOVE
        poses = {}
        if not batched or self.trails_on.value:
            poses = {n: (tuple(float(c) for c in positions[k]),
                         (float(q_xyzw[k][3]), float(q_xyzw[k][0]), float(q_xyzw[k][1]), float(q_xyzw[k][2])))
                     for k, n in enumerate(names)}
        # Many bodies: the markers are wanted for the shapes only (sites and wrench arrows are not
        # drawn batched), so the view stops listening once it has every shape, and the node stops
        # building them; a body without a shape (a new scene, a spawn) brings the subscription back.
        ros.want_markers(not batched or any(n not in shapes for n in names))
        if batched:
            if any(f.visible for f in self.bodies.frames.values()):
                self.bodies.show({}, {})  # hide the bodies drawn one by one
            self.batched.show_arrays(names, positions, q_xyzw, shapes)
        else:
            self.batched.clear()
            made = self.bodies.show(poses, shapes)
            if ros.strike_body in made:
                self._show_strike_point()
            self.bodies.show_sites(sites)
        if stamp != self._drawn_stamp:
            self._drawn_stamp = stamp
            self._draws.append(time.monotonic())
        self.bodies.show_arrows(arrows)
        self.bodies.show_contacts(*contacts)
        if self.trails_on.value:
            self.bodies.record_trails(poses)
        now = time.monotonic()
        if now >= self._slow_due:
            self._slow_due = now + 1.0 / SLOW_HZ
            if tuple(self.speed_body.options) != tuple(names) and names:
                self.speed_body.options = tuple(names)
                self.speed_body.value = ros.strike_body if ros.strike_body in names else names[0]
            self._update_plots(names, params)
            self._show_imus()
            if now >= self._params_due:  # the node's parameters as they are now (another client may change them)
                self._params_due = now + PARAMS_PERIOD_S
                ros.request_parameters()
            if self.trails_on.value:
                self.bodies.show_trails(True)

    def _show_parameters(self, params: dict) -> None:
        rtf = self.ros.measured_rtf()
        now = time.monotonic()
        draws = sum(1 for t in self._draws if now - t <= 2.0) / 2.0
        if params:
            paused = "paused" if params.get("paused") else "running"
            # short lines, the changing figures last: the line count (and the buttons below) stays put
            self.rate_text.content = (f"{paused} · integrator `{params.get('integrator')}`  \n"
                                      f"rate_hz {params.get('rate_hz'):g} · real-time factor set "
                                      f"{params.get('real_time_factor'):g}  \n"
                                      f"measured real-time factor {'–' if rtf is None else f'{rtf:.3g}'}  \n"
                                      f"page updates {draws:.1f}/s")
        for name, (handle, cast) in self._controls.items():  # the node's values in the controls
            value = params.get(name)
            if value is None or (name == "integrator" and value not in INTEGRATORS):
                continue
            if handle.value != self._known[name] or now - self._edited_at[name] < EDIT_HOLD_S:
                continue  # being edited
            value = cast(value)
            if value != handle.value:
                self._known[name] = handle.value = value

    def _edited(self, event: Any, name: str, value: Any) -> None:
        """A control changed: by a user (sent to the node, and the control held for :data:`EDIT_HOLD_S`)
        or by the page itself (nothing to do)."""
        if event.client is None:
            return
        self._known[name] = value
        self._edited_at[name] = time.monotonic()
        self.ros.set_parameter(name, value)

    def _show_imus(self) -> None:
        imus = self.ros.imu_topics()
        with self.ros.lock:
            static = dict(self.ros.static_sites)
        self.imu_text.content = ("IMUs: " + ", ".join(f"`{k}`" for k in imus)) if imus else "IMUs: none"
        self.bodies.show_imus({k: (f"IMU {k.split('/', 1)[1]}", static.get(k)) for k in imus if "/" in k})
