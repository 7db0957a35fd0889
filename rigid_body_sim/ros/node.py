"""The ``rigid_body_sim`` node: steps the core at a fixed wall-clock rate and talks ROS 2.

Per body B (relative names, so namespaces and remaps apply):
  out ``B/pose`` (geometry_msgs/PoseStamped, frame ``world_frame``, stamp = sim time),
  out ``B/twist`` (geometry_msgs/Twist: COM velocity and angular velocity, both world axes),
  out ``B/odom`` (nav_msgs/Odometry, when ``publish_odometry``: twist in B's axes),
  in  ``B/wrench`` (geometry_msgs/WrenchStamped: force and torque about the origin of
      ``header.frame_id``, in its axes; held per (B, frame_id) until replaced, cleared by an
      all-zero wrench, or older than ``wrench_timeout`` s of sim time; all holds are summed),
  in  ``B/impulse`` (WrenchStamped read as N·s and N·m·s, applied once at the next step).
Also ``/clock`` (rosgraph_msgs/Clock) each tick, ``/diagnostics`` (diagnostic_msgs/DiagnosticArray,
every ``diagnostics_period`` wall seconds; see diagnostics.py), and services ``~/reset``,
``~/set_paused``, ``~/step``. Each physics step advances ``real_time_factor / (rate_hz · substeps)`` s.

Incoming header stamps are not used: a hold is timed in sim time from its receipt, so a stamp
in the far past or future (or a nanosec field ≥ 1e9) changes nothing. Messages are checked in
this order and the first failure is the reason counted: frame_id, then non-finite, then too large.
Impulses due at the same step in the same (body, frame) are summed (impulses add), so a flood of
them while paused holds one entry per frame, not one per message.

Ticks come from one of two sources, with the same behaviour. By default an rclpy timer in the
executor that spins the node calls them (what an in-process user, and the test harness, get).
``rigid_body_sim_node`` passes ``tick_thread=True``: a dedicated thread ticks on a deadline
schedule (due_k = start + k / rate_hz on the steady clock), and the executor keeps only the
subscriptions, services, parameters and /diagnostics. rclpy's SingleThreadedExecutor rebuilds
its wait set over every entity each time it wakes (milliseconds with 200 per-body
subscriptions), which a timer in that executor pays on every tick; the thread does not. One
lock guards the simulator and the node's state between the two threads.
"""

from __future__ import annotations

import gc
import math
import sys
import threading
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, Twist, WrenchStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    ParameterType,
    SetParametersResult,
)
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg
from std_srvs.srv import SetBool, Trigger

from ..core import INTEGRATORS, NonFiniteStateError, Scene, SceneError, Simulator, load_scene
from ..offline.recording import McapRecorder, check_record_path
from ..paths import default_scene_path
from .cdr import PoseTwistClockCdr, check_against_middleware
from .conversions import (
    RejectedMessage,
    fill_odometry,
    fill_pose_stamped,
    fill_twist,
    time_msg_from_seconds,
    wrench_from_msg,
)
from .diagnostics import TickWindow, diagnostic_statuses, timer_callback_with_info

__all__ = ["RigidBodySimNode", "main", "DEFAULT_INTEGRATOR"]

#: Integrator used unless the ``integrator`` parameter says otherwise.
DEFAULT_INTEGRATOR = "rk4"
#: History depth of every publisher and subscription (bounded memory under floods).
QUEUE_DEPTH = 10
#: Wall seconds between two warnings about dropped messages (the counts go on regardless).
REJECTION_WARNING_PERIOD = 2.0
#: With ``tick_thread``, a tick running later than this (and later than one period) skips the
#: periods it missed, as an rcl timer does; a tick less late is caught up at once, so sim time
#: keeps pace with wall time through short stalls (a GIL hand-over, a scheduling delay).
CATCH_UP_LIMIT_S = 0.05


@dataclass
class _Hold:
    """A held wrench: force and torque in the message's frame, and the sim time it arrived."""

    force: np.ndarray
    torque: np.ndarray
    received_time: float


@dataclass
class _BodyIO:
    """Publishers, subscriptions and reusable messages of one body."""

    pose_pub: Any
    twist_pub: Any
    odom_pub: Any
    wrench_sub: Any
    impulse_sub: Any
    frames: dict[str, str]  # accepted header.frame_id → core frame name
    pose_msg: PoseStamped
    twist_msg: Twist
    odom_msg: Odometry


def _float_range(low: float, high: float) -> list[FloatingPointRange]:
    return [FloatingPointRange(from_value=low, to_value=high, step=0.0)]


class RigidBodySimNode(Node):
    """Rigid-body simulator node. Keyword arguments go to :class:`rclpy.node.Node` (``context``,
    ``parameter_overrides``, ``namespace``, ``cli_args``...).

    Parameters
    ----------
    node_name : str
        Name of the node.
    tick_thread : bool
        Tick from a dedicated thread on a deadline schedule instead of from a timer in the
        executor that spins the node (see the module docstring). Topics, services, parameters
        and diagnostics behave the same; :meth:`destroy_node` stops the thread.

    Raises
    ------
    SceneError
        If the start-up scene cannot be loaded.
    ValueError
        If start-up parameters are invalid (the message says which and what was expected).
    """

    def __init__(self, node_name: str = "rigid_body_sim", *, tick_thread: bool = False, **kwargs: Any):
        super().__init__(node_name, **kwargs)
        # Guards the simulator, holds, impulses, per-body I/O, counters and tick parameters
        # between the executor's callbacks and the tick thread (re-entrant: a tick publishes).
        self._lock = threading.RLock()
        self._tick_thread: threading.Thread | None = None
        self._declare_parameters()
        p = {name: self.get_parameter(name).value for name in self._PARAMETER_NAMES}
        problems = [reason for reason in (self._check(name, value) for name, value in p.items()) if reason]
        if problems:
            raise ValueError("; ".join(problems))
        self._world_frame: str = p["world_frame"]
        self._rate_hz: float = float(p["rate_hz"])
        self._substeps: int = int(p["substeps"])
        self._real_time_factor: float = float(p["real_time_factor"])
        self._paused: bool = bool(p["paused"])
        self._publish_clock: bool = bool(p["publish_clock"])
        self._publish_odometry: bool = bool(p["publish_odometry"])
        self._wrench_timeout: float = float(p["wrench_timeout"])
        self._status_period: float = float(p["status_period"])
        self._diagnostics_period: float = float(p["diagnostics_period"])

        scene = load_scene(p["scene"])
        self._check_scene_names(scene)
        self._prepared_scenes: dict[str, Scene] = {}
        self.rejected: Counter[str] = Counter()
        self.accepted_messages = 0
        self._holds: dict[tuple[str, str], _Hold] = {}
        self._pending_impulses: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
        self._rejection_warning_wall = -math.inf
        self._rejections_since_warning = 0
        self._bodies: dict[str, _BodyIO] = {}
        self._qos = QoSProfile(depth=QUEUE_DEPTH)

        self._sim = Simulator(scene, integrator=p["integrator"], dt=self._physics_dt(),
                              model_reduction=p["model_reduction"])
        self._create_body_io()
        self._recorder: McapRecorder | None = None
        self._open_recording(p["record_path"])
        self._clock_pub = self.create_publisher(ClockMsg, "/clock", self._qos)
        self._clock_msg = ClockMsg()
        self._cdr = self._make_cdr()
        self.create_service(Trigger, "~/reset", self._on_reset)
        self.create_service(SetBool, "~/set_paused", self._on_set_paused)
        self.create_service(Trigger, "~/step", self._on_step)
        self.add_pre_set_parameters_callback(self._coerce_parameters)
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

        self._steady_clock = Clock(clock_type=ClockType.STEADY_TIME)
        self._tick_window = TickWindow(self._sim.time)
        self._timer = None
        if not tick_thread:
            self._timer = self.create_timer(1.0 / self._rate_hz, timer_callback_with_info(self._on_tick),
                                            clock=self._steady_clock)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", self._qos)
        self._diagnostics_timer = None
        self._set_diagnostics_period(self._diagnostics_period)
        self._status_wall = time.monotonic()
        self._status_sim = 0.0
        self._log_start_up()
        self.publish_state()
        if tick_thread:
            self._start_tick_thread()

    # ------------------------------------------------------------------ parameters

    _PARAMETER_NAMES = ("scene", "integrator", "model_reduction", "rate_hz", "substeps", "real_time_factor", "world_frame",
                        "publish_clock", "publish_odometry", "paused", "wrench_timeout", "status_period",
                        "diagnostics_period", "record_path")
    _FLOAT_PARAMETERS = ("rate_hz", "real_time_factor", "wrench_timeout", "status_period", "diagnostics_period")

    def _declare_parameters(self) -> None:
        # A whole number given for a float parameter at start-up (`-p rate_hz:=200`, or
        # `rate_hz: 200` in a params file) would make declare_parameter raise a type error:
        # pre-set callbacks do not run for declarations, so coerce the overrides first.
        overrides = getattr(self, "_parameter_overrides", {})
        for name in self._FLOAT_PARAMETERS:
            param = overrides.get(name)
            if param is not None and param.type_ == Parameter.Type.INTEGER:
                overrides[name] = Parameter(name, Parameter.Type.DOUBLE, float(param.value))

        def describe(text: str, **extra: Any) -> ParameterDescriptor:
            return ParameterDescriptor(description=text, **extra)

        self.declare_parameter("scene", str(default_scene_path()),
                               describe("Path of the scene YAML file (default: the installed config/default_scene.yaml)."))
        self.declare_parameter("integrator", DEFAULT_INTEGRATOR,
                               describe("Integrator name.", additional_constraints=f"one of {sorted(INTEGRATORS)}"))
        self.declare_parameter("model_reduction", True, describe(
            "Give each body the cheapest exact model for what it is and what the scene declares (README "
            "'Motions and model reduction'); false steps every free body with the integrator."))
        self.declare_parameter("rate_hz", 100.0, describe("Ticks per wall-clock second.",
                                                          floating_point_range=_float_range(0.001, 100000.0)))
        self.declare_parameter("substeps", 1, describe("Physics steps per tick.",
                                                       integer_range=[IntegerRange(from_value=1, to_value=100000, step=1)]))
        self.declare_parameter("real_time_factor", 1.0, describe("Sim seconds per wall-clock second.",
                                                                 floating_point_range=_float_range(1e-6, 1e6)))
        self.declare_parameter("world_frame", "world", describe("frame_id of the world (poses, world-frame wrenches).",
                                                                read_only=True))
        self.declare_parameter("publish_clock", True, describe("Publish /clock with sim time every tick."))
        self.declare_parameter("publish_odometry", False, describe("Also publish B/odom (nav_msgs/Odometry)."))
        self.declare_parameter("paused", False, describe("When true, time only advances through ~/step."))
        self.declare_parameter("wrench_timeout", 0.5, describe("Sim seconds a received wrench stays applied; 0 = until replaced.",
                                                               floating_point_range=_float_range(0.0, 1e9)))
        self.declare_parameter("status_period", 1.0, describe("Wall seconds between status log lines; 0 = none.",
                                                              floating_point_range=_float_range(0.0, 1e6)))
        self.declare_parameter("diagnostics_period", 1.0,
                               describe("Wall seconds between DiagnosticArray messages on /diagnostics; 0 = none.",
                                        floating_point_range=_float_range(0.0, 1e6)))
        self.declare_parameter("record_path", "", describe(
            "MCAP file to record to (B/pose, B/twist, B/wrench, /clock as ROS 2 messages, stamps = sim time); "
            "'' = no recording. A change closes the current file and starts the new one.",
            additional_constraints="'' or a file path whose directory exists and is writable"))

    def _check(self, name: str, value: Any) -> str | None:
        """Why ``value`` is not acceptable for parameter ``name``, or None."""
        if name == "integrator" and value not in INTEGRATORS:
            return f"integrator must be one of {sorted(INTEGRATORS)}, got {value!r}"
        if name in ("rate_hz", "real_time_factor") and not (isinstance(value, float) and math.isfinite(value) and value > 0.0):
            return f"{name} must be a finite number > 0, got {value!r}"
        if name in ("wrench_timeout", "status_period", "diagnostics_period") and not (isinstance(value, float) and math.isfinite(value) and value >= 0.0):
            return f"{name} must be a finite number ≥ 0, got {value!r}"
        if name == "substeps" and not (isinstance(value, int) and value >= 1):
            return f"substeps must be a whole number ≥ 1, got {value!r}"
        if name == "world_frame" and not (isinstance(value, str) and value and "/" not in value):
            return f"world_frame must be a non-empty frame name without '/', got {value!r}"
        if name == "scene" and not (isinstance(value, str) and value):
            return f"scene must be the path of a scene YAML file, got {value!r}"
        if name == "record_path":
            if not isinstance(value, str):
                return f"record_path must be the path of an .mcap file or '' (no recording), got {value!r}"
            problem = check_record_path(value) if value else None
            if problem is not None:
                return f"record_path rejected: {problem}"
        return None

    def _coerce_parameters(self, parameters: list[Parameter]) -> list[Parameter]:
        """Accept whole numbers for float parameters (``rate_hz:=200`` means 200.0)."""
        out = []
        for param in parameters:
            if param.name in self._FLOAT_PARAMETERS and param.type_ == Parameter.Type.INTEGER:
                param = Parameter(param.name, Parameter.Type.DOUBLE, float(param.value))
            out.append(param)
        return out

    def _validate_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        """Accept or reject a whole set of changes; nothing is applied here."""
        for param in parameters:
            if param.name not in self._PARAMETER_NAMES:
                continue
            reason = self._check(param.name, param.value)
            if reason is None and param.name == "scene":
                try:
                    scene = load_scene(param.value)
                    self._check_scene_names(scene)
                except (SceneError, ValueError) as exc:
                    reason = f"scene rejected: {exc}"
                else:
                    self._prepared_scenes = {param.value: scene}
            if reason is not None:
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters: list[Parameter]) -> None:
        """Apply an accepted set of changes; they take effect at the next tick."""
        with self._lock:
            self._apply_parameters_locked(parameters)

    def _apply_parameters_locked(self, parameters: list[Parameter]) -> None:
        retime = False
        for param in parameters:
            name, value = param.name, param.value
            if name == "integrator":
                self._sim.integrator = value
            elif name == "model_reduction":
                self._sim.model_reduction = bool(value)
                self._log_models()
            elif name == "rate_hz":
                self._rate_hz = float(value)
                retime = True
            elif name == "substeps":
                self._substeps = int(value)
            elif name == "real_time_factor":
                self._real_time_factor = float(value)
            elif name == "paused":
                self._paused = bool(value)
            elif name == "publish_clock":
                self._publish_clock = bool(value)
            elif name == "publish_odometry":
                self._publish_odometry = bool(value)
                self._create_body_io()
            elif name == "wrench_timeout":
                self._wrench_timeout = float(value)
            elif name == "status_period":
                self._status_period = float(value)
            elif name == "diagnostics_period":
                self._set_diagnostics_period(float(value))
            elif name == "scene":
                self._swap_scene(self._prepared_scenes.pop(value))
            elif name == "record_path":
                self._open_recording(value)
                self._record(lambda recorder: recorder.write_simulator(self._sim))
        self._sim.dt = self._physics_dt()
        if retime:
            if self._timer is not None:
                self._timer.timer_period_ns = int(round(1e9 / self._rate_hz))
            else:
                self._retime_ticks.set()
                self._wake_ticks.set()
            self._open_diagnostics_window()

    def _physics_dt(self) -> float:
        return self._real_time_factor / (self._rate_hz * self._substeps)

    def _check_scene_names(self, scene: Scene) -> None:
        if self._world_frame_name() in scene.body_names:
            raise ValueError(f"body name {self._world_frame_name()!r} clashes with world_frame; rename the body")

    def _world_frame_name(self) -> str:
        return getattr(self, "_world_frame", None) or self.get_parameter("world_frame").value

    # ------------------------------------------------------------------ per-body I/O

    def _create_body_io(self) -> None:
        """(Re)create every body's publishers and subscriptions for the current scene."""
        self._destroy_body_io()
        for body in self._sim.body_names:
            frames = {self._world_frame: "world"}
            frames.update({f: f for f in self._sim.frames_of(body) if f != "world"})
            self._bodies[body] = _BodyIO(
                pose_pub=self.create_publisher(PoseStamped, f"{body}/pose", self._qos),
                twist_pub=self.create_publisher(Twist, f"{body}/twist", self._qos),
                odom_pub=self.create_publisher(Odometry, f"{body}/odom", self._qos) if self._publish_odometry else None,
                wrench_sub=self.create_subscription(WrenchStamped, f"{body}/wrench",
                                                    lambda msg, b=body: self._on_wrench(b, msg), self._qos),
                impulse_sub=self.create_subscription(WrenchStamped, f"{body}/impulse",
                                                     lambda msg, b=body: self._on_impulse(b, msg), self._qos),
                frames=frames,
                pose_msg=PoseStamped(),
                twist_msg=Twist(),
                odom_msg=Odometry(),
            )

    def _destroy_body_io(self) -> None:
        for io in self._bodies.values():
            for entity in (io.pose_pub, io.twist_pub, io.odom_pub):
                if entity is not None:
                    self.destroy_publisher(entity)
            self.destroy_subscription(io.wrench_sub)
            self.destroy_subscription(io.impulse_sub)
        self._bodies = {}

    def _swap_scene(self, scene: Scene) -> None:
        self._sim = Simulator(scene, integrator=self._sim.integrator, dt=self._physics_dt(),
                              model_reduction=self._sim.model_reduction)
        self._open_diagnostics_window()
        self._holds.clear()
        self._pending_impulses.clear()
        self._create_body_io()
        self._log_start_up()
        self.publish_state()

    # ------------------------------------------------------------------ incoming

    def _parse(self, body: str, msg: WrenchStamped, topic: str) -> tuple[str, np.ndarray, np.ndarray] | None:
        """(core frame, force, torque) of a valid message, or None after counting and warning."""
        io = self._bodies.get(body)
        try:
            frame = io.frames.get(msg.header.frame_id) if io is not None else None
            if frame is None:
                raise RejectedMessage("unknown_frame", "")  # detail built only if it is logged
            force, torque = wrench_from_msg(msg)
        except RejectedMessage as rejection:
            self.rejected[rejection.reason] += 1
            self._warn_rejection(body, topic, msg, rejection, list(io.frames) if io else [])
            return None
        self.accepted_messages += 1
        return frame, force, torque

    def _warn_rejection(self, body: str, topic: str, msg: WrenchStamped | None, rejection: RejectedMessage,
                        valid_frames: list[str]) -> None:
        """Warn at most once per REJECTION_WARNING_PERIOD wall seconds (rclpy's own throttle
        inspects the caller's source on every call: ~0.4 ms, which a flood of bad messages
        would turn into a denial of service)."""
        self._rejections_since_warning += 1
        wall = time.monotonic()
        if wall - self._rejection_warning_wall < REJECTION_WARNING_PERIOD:
            return
        detail = rejection.detail or f"frame_id {msg.header.frame_id[:80]!r} is not one of {valid_frames}"
        more = self._rejections_since_warning - 1
        self.get_logger().warning(
            f"dropped a message on {body}/{topic} ({rejection.reason}): {detail}; valid frame_ids: {valid_frames}"
            + (f" ({more} more dropped since the last warning; counts by reason on /diagnostics)" if more else ""))
        self._rejection_warning_wall = wall
        self._rejections_since_warning = 0

    def _on_wrench(self, body: str, msg: WrenchStamped) -> None:
        with self._lock:
            parsed = self._parse(body, msg, "wrench")
            if parsed is None:
                return
            frame, force, torque = parsed
            if not force.any() and not torque.any():
                self._holds.pop((body, frame), None)
            else:
                self._holds[(body, frame)] = _Hold(force, torque, self._sim.time)

    def _on_impulse(self, body: str, msg: WrenchStamped) -> None:
        with self._lock:
            parsed = self._parse(body, msg, "impulse")
            if parsed is not None:
                frame, linear, angular = parsed
                pending = self._pending_impulses.get((body, frame))
                if pending is not None:  # impulses due at the same step add
                    linear, angular = pending[0] + linear, pending[1] + angular
                self._pending_impulses[(body, frame)] = (linear, angular)

    # ------------------------------------------------------------------ stepping

    def _on_tick(self, expected_ns: int | None = None) -> None:
        """Timer callback; ``expected_ns`` is when rcl's schedule had it due (steady clock, ns)."""
        with self._lock:
            if expected_ns is not None:
                self._tick_window.record(expected_ns, self._timer.timer_period_ns)
            if not self._paused:
                self.advance_one_tick()
            self._log_status()

    def _start_tick_thread(self) -> None:
        self._stop_ticks = threading.Event()
        self._retime_ticks = threading.Event()
        self._wake_ticks = threading.Event()
        self._tick_failure: BaseException | None = None
        # Wakes the executor to re-raise an unexpected error of the tick thread there, so the
        # node fails as loudly as it would from a timer callback.
        self._tick_failure_gc = self.create_guard_condition(self._raise_tick_failure)
        self._tick_thread = threading.Thread(target=self._tick_loop, name=f"{self.get_name()} ticks", daemon=True)
        self._tick_thread.start()

    def _stop_tick_thread(self) -> None:
        thread, self._tick_thread = self._tick_thread, None
        if thread is None:
            return
        self._stop_ticks.set()
        self._wake_ticks.set()
        if thread is not threading.current_thread():
            thread.join()

    def _raise_tick_failure(self) -> None:
        if self._tick_failure is not None:
            raise self._tick_failure

    def _tick_loop(self) -> None:
        """Body of the tick thread: tick k is due at start + k·period (steady clock, ns).

        A tick that runs late is caught up at once, so sim time tracks wall time while the
        ticks keep up on average; one later than :data:`CATCH_UP_LIMIT_S` (and than a period)
        skips the periods it missed, counted as missed ticks, like an rcl timer.
        """
        due_ns = period_ns = 0
        self._retime_ticks.set()
        while not self._stop_ticks.is_set():
            self._wake_ticks.clear()
            if self._retime_ticks.is_set():  # start, or a new rate_hz: the schedule restarts now
                self._retime_ticks.clear()
                period_ns = int(round(1e9 / self._rate_hz))
                due_ns = time.monotonic_ns() + period_ns
            now_ns = time.monotonic_ns()
            if now_ns < due_ns:
                self._wake_ticks.wait((due_ns - now_ns) * 1e-9)
                continue
            lateness_ns = now_ns - due_ns
            missed = 0
            if lateness_ns >= period_ns and lateness_ns > CATCH_UP_LIMIT_S * 1e9:
                missed = lateness_ns // period_ns
            try:
                with self._lock:
                    if self._retime_ticks.is_set() or self._stop_ticks.is_set():
                        continue
                    self._tick_window.record(due_ns, period_ns, missed=missed)  # lateness before the skip
                    due_ns += missed * period_ns
                    if not self._paused:
                        self.advance_one_tick()
                    self._log_status()
            except Exception as exc:  # noqa: BLE001  (handed to the executor, or shutdown)
                if self._stop_ticks.is_set() or not self.context.ok():
                    return  # shutting down: publishers may already be invalid
                self.get_logger().error(f"tick thread failed: {exc!r}")
                self._tick_failure = exc
                self._tick_failure_gc.trigger()
                return
            due_ns += period_ns

    def advance_one_tick(self) -> None:
        """Advance ``substeps`` physics steps with the held wrenches and pending impulses, then publish."""
        with self._lock:
            self._advance_one_tick_locked()

    def _advance_one_tick_locked(self) -> None:
        sim = self._sim
        if self._wrench_timeout > 0.0:
            now = sim.time
            expired = [key for key, hold in self._holds.items() if now - hold.received_time >= self._wrench_timeout]
            for key in expired:
                del self._holds[key]
        stopped = set(sim.stopped_bodies)
        for (body, frame), (linear, angular) in self._pending_impulses.items():
            if body in stopped:
                continue
            try:
                sim.apply_impulse(body, linear, angular, frame)
            except ValueError as exc:
                self.rejected["non_finite_result"] += 1
                self._warn_rejection(body, "impulse", None, RejectedMessage("non_finite_result", str(exc)), [])
        self._pending_impulses.clear()
        for (body, frame), hold in self._holds.items():
            sim.apply_wrench(body, hold.force, hold.torque, frame)
        self._record(lambda recorder: recorder.write_wrenches(sim.time, [
            (body, frame, hold.force, hold.torque) for (body, frame), hold in self._holds.items()
        ] + sim.active_scripted_wrenches()))
        target = sim.step_count + self._substeps
        while sim.step_count < target:
            try:
                sim.step(target - sim.step_count)
            except NonFiniteStateError as failure:
                for body in failure.bodies:
                    sim.stop_body(body)
                self.get_logger().error(f"stopped {list(failure.bodies)}: {failure}")
        self.publish_state()

    # ------------------------------------------------------------------ outgoing

    def publish_state(self) -> None:
        """Publish every running body's pose and twist (and odometry, /clock) at the current sim time."""
        with self._lock:
            self._publish_state_locked()

    def _publish_state_locked(self) -> None:
        sim = self._sim
        stamp = time_msg_from_seconds(sim.time)
        sec, nanosec = stamp.sec, stamp.nanosec
        stopped = set(sim.stopped_bodies)
        # One conversion per array and tick: rows of plain Python floats, no numpy scalars per field.
        positions = sim.positions_world().tolist()
        orientations = sim.orientations_xyzw().tolist()
        velocities = sim.linear_velocities_world().tolist()
        rates_world = sim.angular_velocities_world().tolist()
        finite = sim.state.finite_bodies().tolist()
        cdr = self._cdr
        for index, (body, io) in enumerate(self._bodies.items()):
            if not finite[index] or body in stopped:
                continue
            if cdr is not None:
                io.pose_pub.publish(cdr.pose_stamped(sec, nanosec, positions[index], orientations[index]))
                io.twist_pub.publish(cdr.twist(velocities[index], rates_world[index]))
            else:
                io.pose_pub.publish(fill_pose_stamped(io.pose_msg, stamp, self._world_frame, positions[index],
                                                      orientations[index]))
                io.twist_pub.publish(fill_twist(io.twist_msg, velocities[index], rates_world[index]))
            if io.odom_pub is not None:
                state = sim.body_state(body)
                io.odom_pub.publish(fill_odometry(io.odom_msg, stamp, self._world_frame, body, state.position_world,
                                                  state.orientation_xyzw, state.linear_velocity_body,
                                                  state.angular_velocity_body))
        if self._publish_clock:
            if cdr is not None:
                self._clock_pub.publish(cdr.clock(sec, nanosec))
            else:
                self._clock_msg.clock = stamp
                self._clock_pub.publish(self._clock_msg)
        skip = [body for index, body in enumerate(sim.body_names) if not finite[index]]
        self._record(lambda recorder: recorder.write_simulator(sim, skip=skip))

    def _make_cdr(self) -> PoseTwistClockCdr | None:
        """The CDR serializer for pose, twist and /clock, or None (publish message objects) if it
        does not match the middleware's own serialization."""
        try:
            cdr = PoseTwistClockCdr(self._world_frame)
            problem = check_against_middleware(cdr)
        except ValueError as exc:
            problem = str(exc)
        if problem is None:
            return cdr
        self.get_logger().warning(f"publishing message objects (slower): direct CDR does not match the middleware: {problem}")
        return None

    def _set_diagnostics_period(self, period: float) -> None:
        """(Re)start the /diagnostics timer at ``period`` wall seconds; 0 stops it."""
        self._diagnostics_period = period
        if self._diagnostics_timer is not None:
            self.destroy_timer(self._diagnostics_timer)
            self._diagnostics_timer = None
        if period > 0.0:
            self._diagnostics_timer = self.create_timer(period, self.publish_diagnostics, clock=self._steady_clock)
        self._open_diagnostics_window()

    def _open_diagnostics_window(self) -> None:
        self._tick_window.reopen(self._sim.time)
        self._accepted_at_open = self.accepted_messages
        self._rejected_at_open = Counter(self.rejected)

    def diagnostics(self) -> DiagnosticArray:
        """The DiagnosticArray for the window since the last one (see diagnostics.py); opens a new window."""
        with self._lock:
            return self._diagnostics_locked()

    def _diagnostics_locked(self) -> DiagnosticArray:
        sim = self._sim
        array = DiagnosticArray()
        array.header.stamp = self.get_clock().now().to_msg()
        array.status = diagnostic_statuses(
            node_name=self.get_name(), window=self._tick_window, sim_time=sim.time, paused=self._paused,
            integrator=sim.integrator, dt=sim.dt, substeps=self._substeps, rate_hz=self._rate_hz,
            real_time_factor=self._real_time_factor, bodies=sim.body_names, stopped=sim.stopped_bodies,
            held_wrenches=len(self._holds), pending_impulses=len(self._pending_impulses),
            accepted_total=self.accepted_messages, accepted_at_open=self._accepted_at_open,
            rejected_total=self.rejected, rejected_at_open=self._rejected_at_open)
        self._open_diagnostics_window()
        return array

    def publish_diagnostics(self) -> None:
        """Publish :meth:`diagnostics` on /diagnostics (the diagnostics timer calls this)."""
        self._diagnostics_pub.publish(self.diagnostics())

    # ------------------------------------------------------------------ services

    def _on_reset(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        with self._lock:
            self._sim.reset()
            self._open_diagnostics_window()
            self._holds.clear()
            self._pending_impulses.clear()
            self.publish_state()
        response.success = True
        response.message = "reset to the scene's initial state at t = 0 s; held wrenches cleared"
        return response

    def _on_set_paused(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        result = self.set_parameters([Parameter("paused", Parameter.Type.BOOL, bool(request.data))])[0]
        response.success = result.successful
        response.message = ("paused" if request.data else "running") if result.successful else result.reason
        return response

    def _on_step(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        with self._lock:
            if not self._paused:
                response.success = False
                response.message = "refused: the simulation is running; pause it first (~/set_paused true, or paused:=true)"
                return response
            self.advance_one_tick()
            response.success = True
            response.message = f"stepped one tick to t = {self._sim.time:.9f} s"
        return response

    # ------------------------------------------------------------------ logging

    def _log_start_up(self) -> None:
        sim = self._sim
        self.get_logger().info(
            f"scene {sim.scene.source}: {len(sim.body_names)} bodies; integrator {sim.integrator}, "
            f"dt = {sim.dt:g} s ({self._rate_hz:g} Hz × {self._substeps} substeps, real_time_factor {self._real_time_factor:g})")
        for body in sim.body_names[:20]:
            index = sim.body_names.index(body)
            self.get_logger().info(
                f"  {body}: mass {sim.model.mass[index]:g} kg, principal moments {np.round(sim.model.inertia_P[index], 9).tolist()} kg·m², "
                f"wrench frames {list(self._bodies[body].frames)}")
        if len(sim.body_names) > 20:
            self.get_logger().info(f"  ... and {len(sim.body_names) - 20} more bodies")
        self._log_models()

    def _log_models(self) -> None:
        """Which model each body gets and why (model reduction): one line per body, the first 20."""
        plans = self._sim.body_models()
        counts: dict[str, int] = {}
        for plan in plans:
            counts[plan.model] = counts.get(plan.model, 0) + 1
        self.get_logger().info(
            f"models (model_reduction {'on' if self._sim.model_reduction else 'off'}): "
            + ", ".join(f"{count} {model}" for model, count in sorted(counts.items())))
        for plan in plans[:20]:
            self.get_logger().info(f"  {plan.body}: {plan.model} model: {plan.reason}")

    def _log_status(self) -> None:
        if self._status_period <= 0.0:
            return
        wall = time.monotonic()
        elapsed = wall - self._status_wall
        if elapsed < self._status_period:
            return
        sim = self._sim
        rtf = (sim.time - self._status_sim) / elapsed
        self._status_wall, self._status_sim = wall, sim.time
        lines = [f"t = {sim.time:.3f} s, real-time factor {rtf:.3f}" + (" (paused)" if self._paused else "")]
        positions, orientations = sim.positions_world(), sim.orientations_xyzw()
        for index, body in enumerate(sim.body_names[:10]):
            lines.append(f"  {body}: position {np.round(positions[index], 4).tolist()} m, "
                         f"orientation xyzw {np.round(orientations[index], 4).tolist()}")
        if len(sim.body_names) > 10:
            lines.append(f"  ... and {len(sim.body_names) - 10} more bodies")
        self.get_logger().info("\n".join(lines))

    # ------------------------------------------------------------------ recording (record_path)

    def _open_recording(self, path: str) -> None:
        """Finish the current recording, if any, and start one at ``path`` ('' = none)."""
        self._close_recording()
        if not path:
            return
        sim = self._sim
        source = Path(sim.scene.source)
        try:
            scene_text = source.read_text(encoding="utf-8") if source.is_file() else None
        except (OSError, UnicodeDecodeError):
            scene_text = None
        try:
            self._recorder = McapRecorder(
                path, world_frame=self._world_frame, namespace=self.get_namespace(), scene_text=scene_text,
                metadata={"scene": str(sim.scene.source), "integrator": sim.integrator, "dt": repr(sim.dt),
                          "node": self.get_fully_qualified_name()})
        except OSError as exc:
            self.get_logger().error(f"cannot record to {path!r} ({exc}); not recording")
            return
        self.get_logger().info(f"recording to {path}")

    def _record(self, write: Any) -> None:
        """Call ``write(recorder)`` if recording; a failed write (disk full...) ends the recording."""
        if self._recorder is None:
            return
        try:
            write(self._recorder)
        except OSError as exc:
            self.get_logger().error(f"recording to {self._recorder.path} failed ({exc}); not recording")
            self._close_recording()

    def _close_recording(self) -> None:
        recorder, self._recorder = getattr(self, "_recorder", None), None
        if recorder is None:
            return
        try:
            recorder.close()
        except OSError as exc:
            self.get_logger().error(f"could not finish the recording {recorder.path} ({exc})")
        else:
            self.get_logger().info(f"recording finished: {recorder.path} ({recorder.message_count} messages)")

    def destroy_node(self) -> None:
        """Stop the tick thread if any, finish the recording (a complete, indexed MCAP file), then destroy the node."""
        self._stop_tick_thread()
        with self._lock:
            self._close_recording()
        super().destroy_node()

    # ------------------------------------------------------------------ read-only access for tools

    def publisher_subscription_counts(self) -> dict[str, int]:
        """Per body, how many subscriptions its pose and twist publishers have matched (the smaller)."""
        return {b: min(io.pose_pub.get_subscription_count(), io.twist_pub.get_subscription_count())
                for b, io in self._bodies.items()}

    @property
    def simulator(self) -> Simulator:
        """The core simulator this node steps (read it; drive it through topics and services)."""
        return self._sim

    @property
    def held_wrenches(self) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray]]:
        """Held wrenches by (body, core frame): (force, torque) in that frame."""
        with self._lock:
            return {key: (h.force.copy(), h.torque.copy()) for key, h in self._holds.items()}

    @property
    def pending_impulses(self) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray]]:
        """Impulses due at the next step by (body, core frame): summed (linear N·s, angular N·m·s) in that frame."""
        with self._lock:
            return {key: (linear.copy(), angular.copy()) for key, (linear, angular) in self._pending_impulses.items()}


def main(args: list[str] | None = None) -> int:
    """Console entry point ``rigid_body_sim_node``: run the node until Ctrl-C or shutdown."""
    rclpy.init(args=args)
    try:
        node = RigidBodySimNode(tick_thread=True)
    except (SceneError, ValueError, ParameterException) as exc:
        print(f"rigid_body_sim_node: {exc}", file=sys.stderr)
        rclpy.try_shutdown()
        return 2
    except KeyboardInterrupt:  # Ctrl-C (or SIGINT from a supervisor) during start-up: a clean exit
        rclpy.try_shutdown()
        return 0
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        # Everything made so far (rclpy, numpy, numba, the node: hundreds of thousands of
        # objects) stays for good; left to the collector, one full collection of it stalled the
        # tick thread for about 90 ms (at 100 bodies × 100 Hz: 8 ticks skipped), so keep it out.
        gc.collect()
        gc.freeze()
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
