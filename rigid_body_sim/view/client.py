"""The live view's ROS side: one rclpy node that is a client of the simulator's public interface.

``rigid_body_sim_view`` joins the domain in the simulator's namespace on a private context spun in
its own thread, and only keeps the latest of everything (under :attr:`RosClient.lock`); the page
(:mod:`.page`) reads it at its own refresh rate. It subscribes to ``poses`` (raw CDR, transient
local: a paused node's state shows at once), ``velocities`` (transient local), ``markers`` (shapes,
sites, held wrenches) and ``contacts``; reads the simulator's parameters (``body_names``,
``frame_prefix``, ``integrator``, ``rate_hz``, ``real_time_factor``, ``scene``, ``paused``) and sets
``integrator``, ``rate_hz`` and ``real_time_factor``; calls ``~/set_paused``, ``~/step``,
``~/step_ticks`` and ``~/reset``; publishes strikes on the shared ``impulse`` topic, with
``frame_id`` ``<frame_prefix>B`` (an impulse about B's origin in its axes) or
``<frame_prefix>B/world_aligned`` (world axes at B's centre of mass). IMUs are found by their
topics (``B/S/imu``, sensor_msgs/Imu) and placed by ``/tf_static`` (B → B/S).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from typing import Any

import numpy as np

from .drawing import _Shape, shape_from_marker
from .wire import contacts_from_cloud, parse_pose_array, velocities_from_cloud

__all__ = ["RosClient", "VIEW_PARAMETERS"]

#: The simulator parameters the view reads (and shows).
VIEW_PARAMETERS = ("body_names", "frame_prefix", "integrator", "rate_hz", "real_time_factor", "scene", "paused")


def _q_mul(a: tuple, b: tuple) -> tuple[float, float, float, float]:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def _rotate(q_wxyz: tuple, v: np.ndarray) -> np.ndarray:
    w, x, y, z = q_wxyz
    u = np.array([x, y, z], dtype=float)
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


class RosClient:
    """The view's rclpy node and its endpoints (see the module docstring)."""

    def __init__(self, namespace: str, node_name: str, strike_body: str):
        import rclpy
        from geometry_msgs.msg import PoseArray, WrenchStamped
        from rcl_interfaces.srv import SetParameters
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.parameter_client import AsyncParameterClient
        from rclpy.qos import DurabilityPolicy, QoSProfile
        from rclpy.signals import SignalHandlerOptions
        from sensor_msgs.msg import PointCloud2
        from std_srvs.srv import SetBool, Trigger
        from tf2_msgs.msg import TFMessage
        from visualization_msgs.msg import MarkerArray

        self.lock = threading.Lock()
        self.context = Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node("rigid_body_sim_view", namespace=namespace, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        ns = self.node.get_namespace().rstrip("/")
        self.namespace = ns
        self.sim_name = f"{ns}/{node_name}"
        self.poses_topic = self.node.resolve_topic_name("poses")
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.node.create_subscription(PoseArray, "poses", self._on_poses, latched, raw=True)
        self.node.create_subscription(PointCloud2, "velocities", self._on_velocities, latched)
        self._markers_args = (MarkerArray, "markers", self._on_markers, QoSProfile(depth=10))
        self._markers_subscription: Any = self.node.create_subscription(*self._markers_args)
        self.node.create_subscription(PointCloud2, "contacts", self._on_contacts, QoSProfile(depth=10))
        self.node.create_subscription(TFMessage, "/tf_static", self._on_tf_static,
                                      QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.parameters = AsyncParameterClient(self.node, self.sim_name)
        self.set_paused = self.node.create_client(SetBool, f"{node_name}/set_paused")
        self.step = self.node.create_client(Trigger, f"{node_name}/step")
        self.reset = self.node.create_client(Trigger, f"{node_name}/reset")
        self.step_ticks = self.node.create_client(SetParameters, f"{node_name}/step_ticks")
        self.strike_body = strike_body
        self.impulse = self.node.create_publisher(WrenchStamped, "impulse", QoSProfile(depth=10))
        self.WrenchStamped, self.SetBool, self.Trigger, self.SetParameters = WrenchStamped, SetBool, Trigger, SetParameters
        # state, under self.lock
        self.stamp_s: float | None = None
        self.positions = np.zeros((0, 3))
        self.orientations_xyzw = np.zeros((0, 4))
        self.velocities: tuple[tuple[int, int], np.ndarray, np.ndarray] | None = None  # (stamp, v (N, 3), w (N, 3))
        self.recent_poses: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        self.stamp_history: deque[tuple[float, float]] = deque(maxlen=400)  # (wall monotonic, sim s)
        self.poses_count = 0
        self.names: list[str] | None = None
        self.params: dict[str, Any] = {}
        self.shapes: dict[str, _Shape] = {}
        self.sites_B: dict[str, tuple[tuple[float, float, float], ...]] = {}
        self.arrows_W = np.zeros((0, 2, 3))
        self.contacts: tuple[np.ndarray, np.ndarray] = (np.zeros((0, 3)), np.zeros((0, 3)))
        self.static_sites: dict[str, tuple[float, float, float]] = {}  # "B/S" (prefix removed) -> position in B
        self.reply = ""
        self._names_pending = self._again = False
        self._unnamed_markers: Any = None
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._spin, name="view-ros", daemon=True)
        self.thread.start()

    # ------------------------------------------------------------------ ROS callbacks
    def _spin(self) -> None:
        while not self._stop.is_set() and self.context.ok():
            self.executor.spin_once(timeout_sec=0.1)

    def _on_poses(self, raw: bytes) -> None:
        try:
            key, _frame, positions, q_xyzw = parse_pose_array(raw)
        except ValueError:
            return
        with self.lock:
            self.stamp_s = key[0] + 1e-9 * key[1]
            self.positions, self.orientations_xyzw = positions, q_xyzw
            self.recent_poses[key] = (positions, q_xyzw)
            while len(self.recent_poses) > 50:
                self.recent_poses.pop(next(iter(self.recent_poses)))
            self.stamp_history.append((time.monotonic(), self.stamp_s))
            self.poses_count += 1
            want_names = self.names is None or len(self.names) != len(positions)
        if want_names:
            self.request_parameters()

    def _on_velocities(self, msg: Any) -> None:
        read = velocities_from_cloud(msg)
        if read is not None:
            with self.lock:
                self.velocities = ((msg.header.stamp.sec, msg.header.stamp.nanosec), *read)

    def _on_contacts(self, msg: Any) -> None:
        read = contacts_from_cloud(msg)
        if read is not None:
            with self.lock:
                self.contacts = read

    def _on_tf_static(self, msg: Any) -> None:
        prefix = str(self.params.get("frame_prefix", ""))
        found = {}
        for t in msg.transforms:
            child = t.child_frame_id.removeprefix(prefix)
            parent = t.header.frame_id.removeprefix(prefix)
            if child.startswith(parent + "/"):
                p = t.transform.translation
                found[child] = (p.x, p.y, p.z)
        with self.lock:
            self.static_sites.update(found)

    def request_parameters(self) -> None:
        """Ask the simulator for :data:`VIEW_PARAMETERS`, one request at a time."""
        with self.lock:
            if self._names_pending:
                self._again = True  # asked while a request is out: ask again when it is answered
                return
            if not self.parameters.services_are_ready():
                return
            self._names_pending, self._again = True, False
        future = self.parameters.get_parameters(list(VIEW_PARAMETERS))
        future.add_done_callback(self._on_parameters)

    def _on_parameters(self, future: Any) -> None:
        from rclpy.parameter import parameter_value_to_python

        params = None
        try:
            values = future.result().values
            if len(values) == len(VIEW_PARAMETERS):
                params = {n: parameter_value_to_python(v) for n, v in zip(VIEW_PARAMETERS, values)}
        except Exception:  # noqa: BLE001 - the simulator went away mid-request: ask again later
            params = None
        with self.lock:
            self._names_pending = False
            again = self._again
            if params is not None:
                self.params = params
                self.names = list(params["body_names"] or [])
        with self.lock:
            unnamed, self._unnamed_markers = (self._unnamed_markers, None) if self.names is not None else (None, self._unnamed_markers)
        if unnamed is not None:
            self._on_markers(unnamed)
        if again:
            self.request_parameters()

    def _on_markers(self, msg: Any) -> None:
        from visualization_msgs.msg import Marker

        shapes: dict[str, _Shape] = {}
        sites: dict[str, list] = {}
        arrows = []
        with self.lock:
            if self.names is None:  # kept until the body names come (the node sends markers only when due)
                self._unnamed_markers = msg
                return
            names = list(self.names)
        index = {n: k for k, n in enumerate(names)}
        for m in msg.markers:
            if m.action != Marker.ADD:
                continue
            with self.lock:
                poses = self.recent_poses.get((m.header.stamp.sec, m.header.stamp.nanosec))
            if m.type == Marker.ARROW and m.ns.endswith("/wrench") and len(m.points) == 2:
                arrows.append([[m.points[0].x, m.points[0].y, m.points[0].z], [m.points[1].x, m.points[1].y, m.points[1].z]])
                continue
            if m.ns not in index or m.type not in (Marker.CUBE, Marker.SPHERE, Marker.CYLINDER):
                continue
            b = index[m.ns]
            if poses is None or b >= len(poses[0]):
                pose = None
            else:
                x, y, z, w = (float(c) for c in poses[1][b])
                pose = (poses[0][b], (w, x, y, z))
            if m.id == 0:
                q_marker = (m.pose.orientation.w, m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z)
                q_rel = (1.0, 0.0, 0.0, 0.0)
                if pose is not None:
                    w, x, y, z = pose[1]
                    q_rel = _q_mul((w, -x, -y, -z), q_marker)  # a principal-axes ellipsoid sits rotated in B
                shapes[m.ns] = shape_from_marker(m.type, (m.scale.x, m.scale.y, m.scale.z),
                                                 (m.color.r, m.color.g, m.color.b, m.color.a), q_rel)
            elif pose is not None:  # a site: where it sits in B
                w, x, y, z = pose[1]
                p_W = np.array([m.pose.position.x, m.pose.position.y, m.pose.position.z]) - pose[0]
                sites.setdefault(m.ns, []).append(tuple(round(float(c), 9) for c in _rotate((w, -x, -y, -z), p_W)))
        with self.lock:
            self.shapes.update(shapes)
            for name, points in sites.items():
                self.sites_B[name] = tuple(points)
            self.arrows_W = np.asarray(arrows, dtype=float).reshape(-1, 2, 3)

    def want_markers(self, wanted: bool) -> None:
        """Subscribe to ``markers`` or not. The node builds them only while someone subscribes
        (about 20 µs a marker), so the page stops listening once it has what it needs of them."""
        if wanted and self._markers_subscription is None:
            self._markers_subscription = self.node.create_subscription(*self._markers_args)
        elif not wanted and self._markers_subscription is not None:
            self.node.destroy_subscription(self._markers_subscription)
            self._markers_subscription = None
            with self.lock:
                self.arrows_W = np.zeros((0, 2, 3))

    # ------------------------------------------------------------------ reads (any thread)
    def node_seen(self) -> bool:
        return self.node.count_publishers(self.poses_topic) > 0

    def imu_topics(self) -> list[str]:
        """The IMUs of the simulator, as ``B/S``: topics ``<namespace>/B/S/imu`` of type sensor_msgs/Imu."""
        head = self.namespace + "/"
        found = []
        for topic, types in self.node.get_topic_names_and_types():
            if "sensor_msgs/msg/Imu" in types and topic.startswith(head) and topic.endswith("/imu"):
                found.append(topic[len(head):-len("/imu")])
        return sorted(found)

    def measured_rtf(self, window_s: float = 2.0) -> float | None:
        """Sim seconds per wall second of the ``poses`` received in the last ``window_s`` (None: too few)."""
        with self.lock:
            history = list(self.stamp_history)
        if len(history) < 2:
            return None
        now = time.monotonic()
        recent = [h for h in history if now - h[0] <= window_s]
        if len(recent) < 2 or recent[-1][0] - recent[0][0] < 0.2:
            return None
        return (recent[-1][1] - recent[0][1]) / (recent[-1][0] - recent[0][0])

    # ------------------------------------------------------------------ actions (any thread)
    def _answer(self, what: str, text: str) -> None:
        with self.lock:
            self.reply = f"{what}: {text}"

    def call(self, what: str) -> None:
        """Call ``~/set_paused`` (``pause``/``run``), ``~/step`` or ``~/reset``; the answer goes to :attr:`reply`."""
        client = {"pause": self.set_paused, "run": self.set_paused, "step": self.step, "reset": self.reset}[what]
        if not client.service_is_ready():
            self._answer(what, f"no simulator answers {client.srv_name}")
            return
        request = self.SetBool.Request(data=(what == "pause")) if client is self.set_paused else self.Trigger.Request()

        def done(future: Any) -> None:
            try:
                response = future.result()
                text = ("ok" if response.success else "refused") + (f" ({response.message})" if response.message else "")
            except Exception as exc:  # noqa: BLE001 - shown on the page, not raised in the executor
                text = f"failed ({exc})"
            self._answer(what, text)
            if what in ("pause", "run"):
                self.request_parameters()

        client.call_async(request).add_done_callback(done)

    def call_step_ticks(self, ticks: int) -> None:
        """``~/step_ticks`` with ``ticks`` (exactly that many ticks, while paused)."""
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue

        what = f"step {ticks}"
        if not self.step_ticks.service_is_ready():
            self._answer(what, f"no simulator answers {self.step_ticks.srv_name}")
            return
        request = self.SetParameters.Request(parameters=[Parameter(
            name="ticks", value=ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=int(ticks)))])

        def done(future: Any) -> None:
            try:
                result = future.result().results[0]
                text = ("ok" if result.successful else "refused") + (f" ({result.reason})" if result.reason else "")
            except Exception as exc:  # noqa: BLE001
                text = f"failed ({exc})"
            self._answer(what, text)

        self.step_ticks.call_async(request).add_done_callback(done)

    def set_parameter(self, name: str, value: Any) -> None:
        """Set one simulator parameter; the node's answer (or refusal, with its reason) goes to :attr:`reply`."""
        from rclpy.parameter import Parameter

        what = f"{name} := {value}"
        if not self.parameters.services_are_ready():
            self._answer(what, f"no simulator answers {self.sim_name}/set_parameters")
            return

        def done(future: Any) -> None:
            try:
                result = future.result().results[0]
                text = "ok" if result.successful else f"refused ({result.reason})"
            except Exception as exc:  # noqa: BLE001
                text = f"failed ({exc})"
            self._answer(what, text)
            self.request_parameters()

        self.parameters.set_parameters([Parameter(name, value=value)]).add_done_callback(done)

    def publish_impulse(self, frame: str, linear: Any, angular: Any) -> str | None:
        """Publish one impulse on ``impulse`` with ``frame_id`` = the simulator's frame_prefix + ``frame``;
        returns why not (None when sent)."""
        if self.impulse.get_subscription_count() == 0:
            return f"no simulator takes {self.impulse.topic_name}"
        msg = self.WrenchStamped()
        msg.header.frame_id = str(self.params.get("frame_prefix", "")) + frame
        msg.header.stamp = self.node.get_clock().now().to_msg()
        msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = (float(c) for c in linear)
        msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z = (float(c) for c in angular)
        self.impulse.publish(msg)
        return None

    def close(self) -> None:
        self._stop.set()
        self.thread.join(timeout=2.0)
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        if self.context.ok():
            self.context.try_shutdown()
