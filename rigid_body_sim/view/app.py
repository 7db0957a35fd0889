"""``rigid-body-sim view``: a viser server showing a running rigid_body_sim node, and driving it.

One rclpy node (``rigid_body_sim_view``, in the namespace of the simulator) subscribes to
``poses`` (transient local, so a paused node's state shows at once) and ``markers``, reads the
simulator's ``body_names`` parameter to name the poses, and calls its ``~/set_paused``,
``~/step`` and ``~/reset``. Each body is a frame (its axes) holding its shape from the markers
(namespace B, id 0: CUBE, SPHERE, CYLINDER). The ROS executor spins in its own thread; viser's
callbacks only call services asynchronously and publish, so no GUI click ever blocks on ROS.
:class:`Bodies` (the drawing), :func:`setup_scene` and :func:`start_server` are shared with the
replay of a recording (:mod:`.replay`).
"""

from __future__ import annotations

import errno
import socket
import sys
import threading
from dataclasses import dataclass
from typing import Any

from .strike import STRIKE_IMPULSE_NS, strike_point, strike_wrench

__all__ = ["run_view", "port_in_use", "Bodies", "shape_from_marker", "setup_scene", "start_server"]

PROG = "rigid-body-sim view"
#: How often the page is brought up to date with the latest state, Hz.
REFRESH_HZ = 20.0
#: The body the "Feel the offset" panel strikes (the default scene's box) unless told otherwise.
DEFAULT_STRIKE_BODY = "box"


def port_in_use(host: str, port: int) -> str | None:
    """Why ``host:port`` cannot be listened on (a one-line reason), or None if it can."""
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server's own socket
        try:
            probe.bind((host, port))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                return f"address {host}:{port} is already in use (another view or server?); choose another with --port"
            return f"cannot listen on {host}:{port}: {exc.strerror or exc}"
    return None


@dataclass
class _Shape:
    kind: int  # visualization_msgs/Marker type
    scale: tuple[float, float, float]
    rgb: tuple[int, int, int]
    opacity: float | None
    q_rel_wxyz: tuple[float, float, float, float]  # shape in the body frame


def shape_from_marker(kind: int, scale: tuple[float, float, float], rgba: tuple[float, float, float, float],
                      q_rel_wxyz: tuple[float, float, float, float]) -> _Shape:
    """A body's shape as a marker gives it (type, scale, colour), placed in the body frame by ``q_rel_wxyz``."""
    rgb = tuple(int(round(255 * min(1.0, max(0.0, float(c))))) for c in rgba[:3])
    opacity = float(rgba[3]) if 0.0 < rgba[3] < 1.0 else None
    return _Shape(int(kind), tuple(float(x) for x in scale), rgb, opacity,  # type: ignore[arg-type]
                  tuple(float(x) for x in q_rel_wxyz))  # type: ignore[arg-type]


class Bodies:
    """The drawing of the bodies, shared by the live view and the replay: each body a frame (its
    axes) at ``/bodies/<name>`` holding its shape (box, cylinder along z, or a scaled sphere)."""

    def __init__(self, server: Any):
        self.server = server
        self.frames: dict[str, Any] = {}
        self.shape_handles: dict[str, tuple[_Shape, Any]] = {}

    def show(self, poses: dict[str, tuple[tuple[float, float, float], tuple[float, float, float, float]]],
             shapes: dict[str, _Shape]) -> set[str]:
        """Place each body of ``poses`` (name: (position, wxyz)) and draw its shape when new or changed;
        bodies not in ``poses`` are hidden. Returns the names whose frame or shape was (re)made."""
        made: set[str] = set()
        with self.server.atomic():
            for name, (position, wxyz) in poses.items():
                frame = self.frames.get(name)
                if frame is None:
                    frame = self.frames[name] = self.server.scene.add_frame(
                        f"/bodies/{name}", axes_length=0.3, axes_radius=0.01)
                    made.add(name)
                frame.position, frame.wxyz, frame.visible = position, wxyz, True
                shape = shapes.get(name)
                if shape is not None and self.shape_handles.get(name, (None,))[0] != shape:
                    self._draw_shape(name, shape)
                    made.add(name)
            for name, frame in self.frames.items():
                if name not in poses:
                    frame.visible = False
        return made

    def _draw_shape(self, name: str, shape: _Shape) -> None:
        from visualization_msgs.msg import Marker

        old = self.shape_handles.pop(name, None)
        if old is not None:
            old[1].remove()
        path, scene = f"/bodies/{name}/shape", self.server.scene
        sx, sy, sz = shape.scale
        if shape.kind == Marker.CUBE:
            handle = scene.add_box(path, color=shape.rgb, dimensions=(sx, sy, sz), opacity=shape.opacity,
                                   wxyz=shape.q_rel_wxyz)
        elif shape.kind == Marker.CYLINDER:
            handle = scene.add_cylinder(path, radius=sx / 2.0, height=sz, color=shape.rgb, opacity=shape.opacity,
                                        wxyz=shape.q_rel_wxyz)
        else:
            handle = scene.add_icosphere(path, radius=0.5, scale=(sx, sy, sz), color=shape.rgb,
                                         opacity=shape.opacity, wxyz=shape.q_rel_wxyz)
        self.shape_handles[name] = (shape, handle)


def setup_scene(server: Any) -> None:
    """The 3D scene both views share: z up, the camera on the default box, a 4 m grid at z = 0."""
    server.scene.set_up_direction("+z")
    server.initial_camera.position = (1.9, -1.9, 2.0)
    server.initial_camera.look_at = (0.0, 0.0, 0.8)
    server.scene.add_grid("/ground", width=4.0, height=4.0, cell_size=0.5)


def start_server(host: str, port: int) -> Any:
    """A viser server on ``host:port``, or None after saying why not (the address in use) on stderr."""
    problem = port_in_use(host, port)
    if problem:
        print(f"{PROG}: {problem}", file=sys.stderr)
        return None
    import viser

    server = viser.ViserServer(host=host, port=port, verbose=False)
    if server.get_port() != port:  # viser moves to the next free port; we promised this one
        server.stop()
        print(f"{PROG}: address {host}:{port} is already in use; choose another with --port", file=sys.stderr)
        return None
    return server


def shown_host(host: str) -> str:
    return "localhost" if host in ("127.0.0.1", "0.0.0.0", "::", "::1") else host


def _q_mul(a: tuple, b: tuple) -> tuple[float, float, float, float]:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


class _Ros:
    """The view's rclpy node and its endpoints, on a private context spun in a thread."""

    def __init__(self, namespace: str, node_name: str, strike_body: str):
        import rclpy
        from geometry_msgs.msg import PoseArray, WrenchStamped
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.parameter_client import AsyncParameterClient
        from rclpy.qos import DurabilityPolicy, QoSProfile
        from rclpy.signals import SignalHandlerOptions
        from std_srvs.srv import SetBool, Trigger
        from visualization_msgs.msg import MarkerArray

        self.lock = threading.Lock()
        self.context = Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node("rigid_body_sim_view", namespace=namespace, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        ns = self.node.get_namespace().rstrip("/")
        self.sim_name = f"{ns}/{node_name}"
        self.poses_topic = self.node.resolve_topic_name("poses")
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.node.create_subscription(PoseArray, "poses", self._on_poses, latched)
        self.node.create_subscription(MarkerArray, "markers", self._on_markers, QoSProfile(depth=10))
        self.parameters = AsyncParameterClient(self.node, self.sim_name)
        self.set_paused = self.node.create_client(SetBool, f"{node_name}/set_paused")
        self.step = self.node.create_client(Trigger, f"{node_name}/step")
        self.reset = self.node.create_client(Trigger, f"{node_name}/reset")
        self.strike_body = strike_body
        self.impulse = self.node.create_publisher(WrenchStamped, f"{strike_body}/impulse", QoSProfile(depth=10))
        self.WrenchStamped, self.SetBool, self.Trigger = WrenchStamped, SetBool, Trigger
        # state, under self.lock
        self.stamp_s: float | None = None
        self.poses: list[tuple[tuple[float, float, float], tuple[float, float, float, float]]] = []
        self.recent_poses: dict[tuple[int, int], list] = {}
        self.names: list[str] | None = None
        self.shapes: dict[str, _Shape] = {}
        self.reply = ""
        self._names_pending = False
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._spin, name="view-ros", daemon=True)
        self.thread.start()

    # ------------------------------------------------------------------ ROS callbacks
    def _spin(self) -> None:
        while not self._stop.is_set() and self.context.ok():
            self.executor.spin_once(timeout_sec=0.1)

    def _on_poses(self, msg: Any) -> None:
        poses = [((p.position.x, p.position.y, p.position.z),
                  (p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z)) for p in msg.poses]
        key = (msg.header.stamp.sec, msg.header.stamp.nanosec)
        with self.lock:
            self.stamp_s = key[0] + 1e-9 * key[1]
            self.poses = poses
            self.recent_poses[key] = poses
            while len(self.recent_poses) > 50:
                self.recent_poses.pop(next(iter(self.recent_poses)))
            want_names = self.names is None or len(self.names) != len(poses)
        if want_names:
            self.request_names()

    def request_names(self) -> None:
        """Ask the simulator for ``body_names`` (the order of ``poses``), once at a time."""
        with self.lock:
            if self._names_pending or not self.parameters.services_are_ready():
                return
            self._names_pending = True
        future = self.parameters.get_parameters(["body_names"])
        future.add_done_callback(self._on_names)

    def _on_names(self, future: Any) -> None:
        names = None
        try:
            values = future.result().values
            if values:
                names = list(values[0].string_array_value)
        except Exception:  # noqa: BLE001 - the simulator went away mid-request: ask again later
            names = None
        with self.lock:
            self._names_pending = False
            if names is not None:
                self.names = names

    def _on_markers(self, msg: Any) -> None:
        from visualization_msgs.msg import Marker

        shapes: dict[str, _Shape] = {}
        with self.lock:
            names = list(self.names or [])
        for m in msg.markers:
            if m.action != Marker.ADD or m.id != 0 or m.type not in (Marker.CUBE, Marker.SPHERE, Marker.CYLINDER):
                continue
            q_marker = (m.pose.orientation.w, m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z)
            q_rel = (1.0, 0.0, 0.0, 0.0)
            with self.lock:
                poses = self.recent_poses.get((m.header.stamp.sec, m.header.stamp.nanosec))
            if poses is not None and m.ns in names and names.index(m.ns) < len(poses):
                w, x, y, z = poses[names.index(m.ns)][1]
                q_rel = _q_mul((w, -x, -y, -z), q_marker)  # a principal-axes ellipsoid sits rotated in B
            shapes[m.ns] = shape_from_marker(m.type, (m.scale.x, m.scale.y, m.scale.z),
                                             (m.color.r, m.color.g, m.color.b, m.color.a), q_rel)
        with self.lock:
            self.shapes.update(shapes)

    # ------------------------------------------------------------------ actions (any thread)
    def node_seen(self) -> bool:
        return self.node.count_publishers(self.poses_topic) > 0

    def call(self, what: str) -> None:
        """Call ``~/set_paused`` (``pause``/``run``), ``~/step`` or ``~/reset``; the answer goes to :attr:`reply`."""
        client = {"pause": self.set_paused, "run": self.set_paused, "step": self.step, "reset": self.reset}[what]
        if not client.service_is_ready():
            with self.lock:
                self.reply = f"{what}: no simulator answers {client.srv_name}"
            return
        request = self.SetBool.Request(data=(what == "pause")) if client is self.set_paused else self.Trigger.Request()

        def done(future: Any) -> None:
            try:
                response = future.result()
                text = f"{what}: {'ok' if response.success else 'refused'}" + (f" ({response.message})" if response.message else "")
            except Exception as exc:  # noqa: BLE001 - shown on the page, not raised in the executor
                text = f"{what}: failed ({exc})"
            with self.lock:
                self.reply = text

        client.call_async(request).add_done_callback(done)

    def strike(self, edges: tuple[float, float, float], offset: float) -> str:
        """Publish one strike impulse on ``<strike_body>/impulse``; returns what was done."""
        linear, angular = strike_wrench(edges, offset)
        if self.impulse.get_subscription_count() == 0:
            return f"strike: no simulator takes {self.impulse.topic_name}"
        msg = self.WrenchStamped()
        msg.header.frame_id = self.strike_body
        msg.header.stamp = self.node.get_clock().now().to_msg()
        msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = linear
        msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z = angular
        self.impulse.publish(msg)
        return (f"strike sent: J = {linear[2]:g} N·s up at r = ({', '.join(f'{v:.3f}' for v in strike_point(edges, offset))}) m, "
                f"r × J = ({', '.join(f'{v:.3f}' for v in angular)}) N·m·s")

    def close(self) -> None:
        self._stop.set()
        self.thread.join(timeout=2.0)
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        if self.context.ok():
            self.context.try_shutdown()


class _Page:
    """The viser scene and GUI, refreshed from :class:`_Ros` at :data:`REFRESH_HZ`."""

    def __init__(self, server: Any, ros: _Ros, namespace: str):
        self.server, self.ros = server, ros
        self.bodies = Bodies(server)
        setup_scene(server)
        gui = server.gui
        gui.add_markdown(f"**rigid_body_sim** `{ros.sim_name}`")
        self.status = gui.add_markdown("waiting…")
        self.sim_time = gui.add_text("sim time (s)", initial_value="–", disabled=True)
        for label, what in (("Pause", "pause"), ("Run", "run"), ("Step", "step"), ("Reset", "reset")):
            gui.add_button(label).on_click(lambda _event, what=what: ros.call(what))
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
        self.strike_dot: Any = None

    def _edges(self) -> tuple[float, float, float] | None:
        with self.ros.lock:
            shape = self.ros.shapes.get(self.ros.strike_body)
        from visualization_msgs.msg import Marker

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
            name = f"/bodies/{self.ros.strike_body}/strike"
            if self.strike_dot is None:
                self.strike_dot = self.server.scene.add_icosphere(name, radius=0.03, color=(220, 30, 30))
            self.strike_dot.position = r

    def _strike(self) -> None:
        edges = self._edges()
        text = (f"strike: no box shape for `{self.ros.strike_body}` yet (markers)" if edges is None
                else self.ros.strike(edges, self.offset.value))
        with self.ros.lock:
            self.ros.reply = text

    def refresh(self) -> None:
        ros = self.ros
        seen = ros.node_seen()
        with ros.lock:
            stamp, poses, names = ros.stamp_s, list(ros.poses), ros.names
            shapes, reply = dict(ros.shapes), ros.reply
        if not seen:
            self.status.content = (f"**waiting for a rigid_body_sim node**: nothing publishes `{ros.poses_topic}` "
                                   f"(start one: `make run`)")
        elif names is None:
            self.status.content = "node found; reading its `body_names`…"
            ros.request_names()
        else:
            missing = [n for n in names if n not in shapes]
            extra = f"; no shape yet for {', '.join(missing)} (markers come with ticks: Step or Run)" if missing else ""
            self.status.content = f"showing {len(names)} bod{'y' if len(names) == 1 else 'ies'}{extra}"
        if stamp is not None:
            self.sim_time.value = f"{stamp:.9f}"
        self.reply.content = reply or " "
        if names is None or len(names) != len(poses):
            return
        made = self.bodies.show(dict(zip(names, poses)), shapes)
        if ros.strike_body in made:
            self._show_strike_point()


def run_view(namespace: str, node_name: str, host: str, port: int, strike_body: str, stop: threading.Event) -> int:
    """Serve the view until ``stop`` is set; returns the exit code (2: the address is in use)."""
    server = start_server(host, port)
    if server is None:
        return 2
    ros = _Ros(namespace, node_name, strike_body)
    try:
        page = _Page(server, ros, namespace)
        print(f"{PROG}: open http://{shown_host(host)}:{port} (simulator {ros.sim_name}); Ctrl-C stops", flush=True)
        waiting_said = False
        while not stop.wait(1.0 / REFRESH_HZ):
            page.refresh()
            if not ros.node_seen() and not waiting_said:
                print(f"{PROG}: waiting for a rigid_body_sim node (nothing publishes {ros.poses_topic} yet)", flush=True)
                waiting_said = True
            elif ros.node_seen():
                waiting_said = False
        return 0
    finally:
        ros.close()
        server.stop()
