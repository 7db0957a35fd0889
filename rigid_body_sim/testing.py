"""A launch-free test harness: the simulator node in-process, driven through its real ROS interface.

Use it in your own pytest suites (no launch files, no ros2cli)::

    from rigid_body_sim.testing import SimHarness

    def test_push_moves_box():
        with SimHarness(parameters={"integrator": "rk4"}) as sim:   # default scene, paused
            sim.publish_wrench("box", force=(0, 10, 0), frame_id="box/corner")
            sim.step(10)                                            # exactly 10 ticks
            assert sim.latest_twist("box").linear.y > 0

The node and a client node live on a private :class:`rclpy.context.Context` (its own DDS
participant, on ``ROS_DOMAIN_ID`` or the ``domain_id`` given) with their own executor, so a
harness never touches the global rclpy context and several can run one after another in one
process. Everything goes through topics, services and the parameter service, as it would from
another process; ``close()`` (or leaving the ``with`` block, also on failure) destroys it all.
The node starts paused by default, so time advances only through :meth:`SimHarness.step`:
runs are bitwise deterministic. The node ticks exactly as ``rigid_body_sim_node`` does, from
its own tick thread (there is no other tick path); paused, that thread advances nothing.
With ``parameters={"per_body_topics": False}`` the harness reads the ``poses`` and
``velocities`` batches and answers :meth:`SimHarness.latest_pose` and
:meth:`SimHarness.latest_twist` from them. Where the node has no per-body inputs (its
``per_body_inputs``; by default none with ``per_body_topics`` false), :meth:`SimHarness.publish_wrench`
and :meth:`SimHarness.publish_impulse` publish on the shared ``wrench`` and ``impulse`` topics,
whose messages name their body by their frame.
"""

from __future__ import annotations

import struct
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Sequence

import rclpy
from geometry_msgs.msg import PoseArray, PoseStamped, Twist, WrenchStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import SetParametersResult
from rcl_interfaces.srv import SetParameters
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import QoSProfile
from sensor_msgs.msg import PointCloud2
from std_srvs.srv import SetBool, Trigger

from .ros.node import RigidBodySimNode

if TYPE_CHECKING:
    import subprocess

__all__ = ["SimHarness", "HarnessTimeout", "stop_process"]


class HarnessTimeout(AssertionError):
    """Something the harness waited for did not happen in time (an assertion failure in tests)."""


class SimHarness:
    """The ``rigid_body_sim`` node in-process, with a client that drives and observes it.

    Parameters
    ----------
    scene : str or Path, optional
        Scene YAML file; default the installed config/default_scene.yaml.
    parameters : dict, optional
        Node parameters at start-up (``{"integrator": "splitting", "substeps": 4}``).
    paused : bool
        Start paused (default), so only :meth:`step` advances time.
    domain_id : int, optional
        ROS domain of the private context; default ``ROS_DOMAIN_ID`` from the environment.
    node_name, namespace : str
        Of the simulator node; topics are relative to the namespace.
    timeout : float
        Seconds any single wait may take before :class:`HarnessTimeout`.
    executor : type, optional
        Executor class to spin both nodes with; default :class:`~rclpy.executors.SingleThreadedExecutor`.
        ``rclpy.experimental.EventsExecutor`` (what ``rigid_body_sim_node`` spins) takes a message
        in about a fifth of the time, which suits high-volume tests.
    """

    def __init__(self, scene: str | Path | None = None, parameters: dict[str, Any] | None = None, *,
                 paused: bool = True, domain_id: int | None = None, node_name: str = "rigid_body_sim",
                 namespace: str | None = None, timeout: float = 10.0, executor: type | None = None):
        params = dict(parameters or {})
        #: True when the node publishes only the batches (``per_body_topics`` false): the harness
        #: then reads ``poses`` and ``velocities`` and answers :meth:`latest_pose` from them.
        self.batched = params.get("per_body_topics", True) is False
        #: True when the node subscribes to B/wrench and B/impulse (``per_body_inputs``); else the
        #: harness publishes wrenches and impulses on the shared ``wrench`` and ``impulse``.
        self.per_body_inputs = {"auto": not self.batched, "true": True}.get(params.get("per_body_inputs", "auto"),
                                                                           False)
        #: The node's ``frame_prefix``: in front of the default frame_id of :meth:`publish_wrench`.
        self.frame_prefix = str(params.get("frame_prefix", ""))
        if scene is not None:
            params["scene"] = str(scene)
        params.setdefault("paused", paused)
        params.setdefault("status_period", 0.0)
        self.timeout = timeout
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node: RigidBodySimNode | None = None
        self.client: Node | None = None
        self.executor: Any = None
        try:
            overrides = [Parameter(k, value=v) for k, v in params.items()]
            self.node = RigidBodySimNode(node_name, context=self.context, namespace=namespace,
                                         parameter_overrides=overrides)
            self.client = Node("rigid_body_sim_test_client", context=self.context, namespace=namespace)
            self.executor = (executor or SingleThreadedExecutor)(context=self.context)
            self.executor.add_node(self.node)
            self.executor.add_node(self.client)
            self._service_prefix = self.node.get_fully_qualified_name()
            self._poses: dict[str, PoseStamped] = {}
            self._twists: dict[str, Twist] = {}
            self._odoms: dict[str, Odometry] = {}
            self._publishers: dict[tuple[str, str], Any] = {
                ("", topic): self.client.create_publisher(WrenchStamped, topic, QoSProfile(depth=100))
                for topic in ("wrench", "impulse")}  # the shared topics (body "")
            self._batches: dict[str, Any] = {}  # "poses" -> latest PoseArray, "velocities" -> latest PointCloud2
            if self.batched:
                for topic, msg_type in (("poses", PoseArray), ("velocities", PointCloud2)):
                    self.client.create_subscription(msg_type, topic, lambda m, t=topic: self._batches.__setitem__(t, m),
                                                    QoSProfile(depth=10))
            self._watched = set(self.node.simulator.body_names)
            for body in self._watched:
                self._create_body_endpoints(body)
            self._step = self.client.create_client(Trigger, f"{self._service_prefix}/step")
            self._reset = self.client.create_client(Trigger, f"{self._service_prefix}/reset")
            self._reset_world = self.client.create_client(Trigger, f"{self._service_prefix}/reset_world")
            self._set_paused = self.client.create_client(SetBool, f"{self._service_prefix}/set_paused")
            self._robot = {name: self.client.create_client(SetParameters, f"{self._service_prefix}/{name}")
                           for name in ("step_ticks", "spawn", "delete")}
            self._parameters = AsyncParameterClient(self.client, self._service_prefix)
            self._wait_for_connections()
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ lifecycle

    def __enter__(self) -> "SimHarness":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        """Destroy the nodes, the executor and the context. Safe to call twice."""
        if self.executor is not None:
            self.executor.shutdown()
            self.executor = None
        for attr in ("client", "node"):
            node = getattr(self, attr, None)
            if node is not None:
                node.destroy_node()
                setattr(self, attr, None)
        if self.context is not None:
            rclpy.try_shutdown(context=self.context)
            self.context = None

    # ------------------------------------------------------------------ waiting

    def spin_until(self, condition: Callable[[], bool], what: str, timeout: float | None = None) -> None:
        """Spin the executor until ``condition()`` holds; :class:`HarnessTimeout` naming ``what`` otherwise."""
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        while not condition():
            if time.monotonic() > deadline:
                raise HarnessTimeout(f"timed out after {self.timeout:g} s waiting for {what}")
            self.executor.spin_once(timeout_sec=0.01)

    def spin_for(self, seconds: float) -> None:
        """Spin for ``seconds`` of wall time (lets the node's own timer run when not paused)."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=min(0.01, max(0.0, end - time.monotonic())))

    def _create_body_endpoints(self, body: str) -> None:
        qos = QoSProfile(depth=100)
        for topic in ("wrench", "impulse") if self.per_body_inputs else ():
            self._publishers[(body, topic)] = self.client.create_publisher(WrenchStamped, f"{body}/{topic}", qos)
        if self.batched:
            return
        self.client.create_subscription(PoseStamped, f"{body}/pose", lambda m, b=body: self._poses.__setitem__(b, m), qos)
        self.client.create_subscription(Twist, f"{body}/twist", lambda m, b=body: self._twists.__setitem__(b, m), qos)
        self.client.create_subscription(Odometry, f"{body}/odom", lambda m, b=body: self._odoms.__setitem__(b, m), qos)

    def watch_body(self, body: str) -> None:
        """Subscribe to and publish for a body that appeared after start-up (a new ``scene``), and
        wait until its topics are connected and its current state has arrived. Idempotent."""
        if body not in self._watched:
            self._watched.add(body)
            self._create_body_endpoints(body)
        for topic in ("wrench", "impulse") if self.per_body_inputs else ():
            pub = self._publishers[(body, topic)]
            self.spin_until(lambda p=pub: p.get_subscription_count() > 0, f"the node's {body}/{topic} subscription")
        if not self.batched:
            self.spin_until(lambda: self.node.publisher_subscription_counts().get(body, 0) > 0,
                            f"the node's {body}/pose and {body}/twist publishers to match the harness")
        if self.get_parameter("paused"):  # running, the ticks publish it (and /clock never repeats a time)
            self.node.publish_state()
        self.wait_for_latest_state()

    def _wait_for_connections(self) -> None:
        for (body, topic), pub in self._publishers.items():
            self.spin_until(lambda p=pub: p.get_subscription_count() > 0, f"the node's {body}/{topic} subscription")
        for client in (self._step, self._reset, self._reset_world, self._set_paused, *self._robot.values()):
            self.spin_until(client.service_is_ready, f"service {client.srv_name}")
        self.spin_until(self._parameters.services_are_ready, "the node's parameter services")
        if self.batched:
            self.spin_until(lambda: self.node.batch_subscription_count() > 0,
                            "the node's poses and velocities publishers to match the harness")
        else:
            self.spin_until(lambda: min(self.node.publisher_subscription_counts().values()) > 0,
                            "the node's pose and twist publishers to match the harness")
        self.node.publish_state()
        self.wait_for_latest_state()

    def _call(self, client: Any, request: Any) -> Any:
        future = client.call_async(request)
        self.spin_until(future.done, f"a response from {client.srv_name}")
        return future.result()

    # ------------------------------------------------------------------ inputs

    def _publish(self, body: str, topic: str, force: Sequence[float], torque: Sequence[float], frame_id: str | None) -> None:
        msg = WrenchStamped()
        msg.header.frame_id = self.frame_prefix + body if frame_id is None else frame_id
        msg.header.stamp = self.client.get_clock().now().to_msg()
        msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = (float(v) for v in force)
        msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z = (float(v) for v in torque)
        seen = self.messages_seen()
        key = (body, topic) if self.per_body_inputs else ("", topic)
        self._publishers[key].publish(msg)
        where = f"{body}/{topic}" if self.per_body_inputs else topic
        self.spin_until(lambda: self.messages_seen() > seen, f"the node to take the message on {where}")

    def publish_wrench(self, body: str, force: Sequence[float] = (0.0, 0.0, 0.0),
                       torque: Sequence[float] = (0.0, 0.0, 0.0), frame_id: str | None = None) -> None:
        """Publish a WrenchStamped on ``body/wrench`` (without per-body inputs: on ``wrench``; frame_id
        default: the body, prefixed) and wait until the node took it."""
        self._publish(body, "wrench", force, torque, frame_id)

    def publish_impulse(self, body: str, linear: Sequence[float] = (0.0, 0.0, 0.0),
                        angular: Sequence[float] = (0.0, 0.0, 0.0), frame_id: str | None = None) -> None:
        """Publish an impulse (N·s, N·m·s) on ``body/impulse`` and wait until the node took it."""
        self._publish(body, "impulse", linear, angular, frame_id)

    def messages_seen(self) -> int:
        """Wrench and impulse messages the node has taken, accepted or rejected."""
        return self.node.accepted_messages + sum(self.node.rejected.values())

    # ------------------------------------------------------------------ services and parameters

    def step(self, n: int = 1) -> None:
        """Advance exactly ``n`` ticks through ``~/step`` (the node must be paused) and wait for their poses."""
        for _ in range(n):
            response = self._call(self._step, Trigger.Request())
            if not response.success:
                raise AssertionError(f"~/step refused: {response.message}")
        self.wait_for_latest_state()

    def step_ticks(self, ticks: int) -> SetParametersResult:
        """Call ``~/step_ticks`` with ``ticks`` and return its (first) result; after a success, wait
        for the poses at the sim time reached."""
        result = self._robot_call("step_ticks", [Parameter("ticks", Parameter.Type.INTEGER, ticks)])
        if result.successful:
            self.wait_for_latest_state()
        return result

    def spawn(self, **definitions: str) -> SetParametersResult:
        """Call ``~/spawn`` with body name → definition (YAML text of what goes under ``bodies.<name>``)."""
        return self._robot_call("spawn", [Parameter(name, Parameter.Type.STRING, text)
                                          for name, text in definitions.items()])

    def delete(self, *bodies: str) -> SetParametersResult:
        """Call ``~/delete`` with the bodies' names."""
        return self._robot_call("delete", [Parameter(name, Parameter.Type.BOOL, True) for name in bodies])

    def _robot_call(self, service: str, parameters: list[Parameter]) -> SetParametersResult:
        request = SetParameters.Request(parameters=[p.to_parameter_msg() for p in parameters])
        return self._call(self._robot[service], request).results[0]

    def call_step(self) -> Trigger.Response:
        """Call ``~/step`` once and return the response as is (it may be a refusal)."""
        return self._call(self._step, Trigger.Request())

    def reset(self) -> Trigger.Response:
        """Call ``~/reset`` and wait for the republished initial state."""
        response = self._call(self._reset, Trigger.Request())
        self.wait_for_latest_state()
        return response

    def reset_world(self) -> Trigger.Response:
        """Call ``~/reset_world`` (bodies back to their initial state, time goes on) and wait for
        the republished state."""
        response = self._call(self._reset_world, Trigger.Request())
        self.wait_for_latest_state()
        return response

    def set_paused(self, paused: bool) -> SetBool.Response:
        """Call ``~/set_paused``."""
        return self._call(self._set_paused, SetBool.Request(data=paused))

    def set_parameters(self, **values: Any) -> list[SetParametersResult]:
        """Set node parameters one by one through its parameter service (ROS semantics: each
        parameter is accepted or rejected on its own); returns one result per parameter."""
        future = self._parameters.set_parameters([Parameter(k, value=v) for k, v in values.items()])
        self.spin_until(future.done, "the parameter service")
        return list(future.result().results)

    def set_parameters_atomically(self, **values: Any) -> SetParametersResult:
        """Set node parameters all or none through its parameter service; returns the one result."""
        future = self._parameters.set_parameters_atomically([Parameter(k, value=v) for k, v in values.items()])
        self.spin_until(future.done, "the parameter service")
        return future.result().result

    def get_parameter(self, name: str) -> Any:
        """A node parameter's current value, read through its parameter service."""
        return self.get_parameters([name])[name]

    def get_parameters(self, names: Iterable[str]) -> dict[str, Any]:
        """The current values of the node parameters ``names`` (name -> value), read in one request to its
        parameter service."""
        names = list(names)
        future = self._parameters.get_parameters(names)
        self.spin_until(future.done, "the parameter service")
        return dict(zip(names, (parameter_value_to_python(v) for v in future.result().values), strict=True))

    # ------------------------------------------------------------------ outputs

    def wait_for_latest_state(self) -> None:
        """Spin until every running body's pose at the node's current sim time has arrived (paused:
        the latest pose carries exactly that time; running: a pose received since this call carries
        that time or a later one)."""
        with self.node.locked_simulator() as sim:
            time_s = sim.time
            running = [body for body in sim.body_names if body not in sim.stopped_bodies]
            self._names = sim.body_names
        target = int(round(time_s * 1e9))
        if self.batched:
            seen_batches = dict(self._batches)

            def batch_arrived(topic: str) -> bool:
                msg = self._batches.get(topic)
                return msg is not None and (_stamp_ns(msg) == target or (msg is not seen_batches.get(topic)
                                                                         and _stamp_ns(msg) >= target))

            for topic in ("poses", "velocities"):
                self.spin_until(lambda t=topic: batch_arrived(t), f"{topic} at t = {time_s:.9f} s")
            return
        seen = {body: self._poses.get(body) for body in running}

        def arrived(body: str) -> bool:
            pose = self._poses.get(body)
            if pose is None or body not in self._twists:
                return False
            return _stamp_ns(pose) == target or (pose is not seen[body] and _stamp_ns(pose) >= target)

        for body in running:
            self.spin_until(lambda b=body: arrived(b), f"{body}/pose at t = {time_s:.9f} s")

    def latest_pose(self, body: str) -> PoseStamped:
        """The last PoseStamped received on ``body/pose``; batched, ``body``'s pose in the last
        ``poses`` (with its header), the scene order being the node's at the last wait."""
        if self.batched:
            batch = self.latest_poses()
            msg = PoseStamped()
            msg.header = batch.header
            msg.pose = batch.poses[self._index(body)]
            return msg
        return self._poses[body]

    def latest_twist(self, body: str) -> Twist:
        """The last Twist received on ``body/twist``; batched, ``body``'s point of the last
        ``velocities`` (world axes, as ``B/twist``)."""
        if self.batched:
            cloud = self.latest_velocities()
            step, k = cloud.point_step, self._index(body)
            values = struct.unpack_from("<6d", bytes(cloud.data[k * step: k * step + 48]))
            msg = Twist()
            (msg.linear.x, msg.linear.y, msg.linear.z, msg.angular.x, msg.angular.y, msg.angular.z) = values
            return msg
        return self._twists[body]

    def latest_poses(self) -> PoseArray:
        """The last ``poses`` batch (batched harness only)."""
        return self._batch("poses")

    def latest_velocities(self) -> PointCloud2:
        """The last ``velocities`` batch (batched harness only; layout in ros/batch.py)."""
        return self._batch("velocities")

    def latest_odometry(self, body: str) -> Odometry:
        """The last Odometry received on ``body/odom`` (needs ``publish_odometry`` and per-body topics)."""
        if self.batched:
            raise ValueError("latest_odometry: the node publishes no B/odom with per_body_topics false; "
                             "use latest_pose and latest_twist")
        return self._odoms[body]

    def _batch(self, topic: str) -> Any:
        if not self.batched:
            raise ValueError(f"latest {topic}: this harness reads the per-body topics; pass "
                             "parameters={'per_body_topics': False} to read the batches")
        return self._batches[topic]

    def _index(self, body: str) -> int:
        try:
            return self._names.index(body)
        except ValueError:
            raise KeyError(f"{body!r} is not a body of the scene; bodies are {list(self._names)}") from None


def _stamp_ns(msg: Any) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def stop_process(process: "subprocess.Popen", timeout: float = 10.0) -> int:
    """Stop a node subprocess as Ctrl-C would (SIGINT), killing it after ``timeout`` s; returns its exit code."""
    import signal
    import subprocess

    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
    return process.returncode


def node_command() -> list[str]:
    """The command that runs the node: the console script next to this interpreter, else the one on PATH."""
    import shutil
    import sys

    script = Path(sys.executable).parent / "rigid_body_sim_node"
    if not script.exists():
        found = shutil.which("rigid_body_sim_node")
        if not found:
            raise FileNotFoundError("console script rigid_body_sim_node is not installed (pip install the package)")
        script = Path(found)
    return [str(script)]


def start_process(ros_arguments: Sequence[str], log_path: str | Path) -> "subprocess.Popen":
    """Start the node (:func:`node_command`) with ``--ros-args *ros_arguments``, its output in ``log_path``.

    The environment is this process's (so ROS_DOMAIN_ID and the discovery range carry over).
    Stop it with :func:`stop_process`.
    """
    import os
    import subprocess

    with open(log_path, "w") as log:
        return subprocess.Popen([*node_command(), "--ros-args", *ros_arguments], stdout=log, stderr=subprocess.STDOUT,
                                env=os.environ.copy())
