"""The ``rigid_body_sim`` node: steps the core at a fixed wall-clock rate and talks ROS 2.

Every tick the batches ``poses`` and ``velocities`` (all bodies in scene order, batch.py) and, unless
``per_body_topics`` is false, per body B (relative names, so namespaces and remaps apply)
``B/pose``, ``B/twist``, ``B/odom`` (publishers.py); in ``B/wrench`` and ``B/impulse`` (inputs.py). Also ``/clock``
each tick, ``/tf`` and ``/tf_static`` (tf.py), ``/diagnostics`` every ``diagnostics_period`` wall seconds
(diagnostics.py), the services ``~/reset``, ``~/reset_world``, ``~/set_paused`` and ``~/step`` (services.py), and the parameters of
parameters.py. For robot stacks: ``B/S/imu`` per IMU site (imu.py), ``B/set_state``
(set_state.py), ``~/step_ticks``, ``~/spawn`` and ``~/delete`` (robot_services.py,
scene_edit.py) and ``markers`` (markers.py). Each physics step advances ``real_time_factor / (rate_hz · substeps)`` s.

This module wires those parts together (session.py, endpoints.py, tick_loop.py, node_diagnostics.py)
and keeps rclpy's parameter callbacks: a change is validated and prepared by the session in the
on-set callback, then applied whole in the post-set callback.
"""

from __future__ import annotations

import contextlib
import threading
import traceback
from typing import Any, Iterator

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile

from ..core import Simulator
from .conversions import MAX_ROS_TIME_S
from .endpoints import BodyEndpoints
from .file_access import change_refusal
from .node_diagnostics import NodeDiagnostics
from .node_log import StatusLog, log_scene
from .node_recording import NodeRecording
from .parameters import BY_NAME, change_problems, coerce_parameters, declare_parameters, misspelt_parameters
from .robot_services import create_robot_services
from .services import create_services
from .session import MAX_BATCH_ONLY_BODIES, MAX_BODIES, SimSession, build_simulator
from .tick_loop import TickLoop

__all__ = ["RigidBodySimNode", "DEFAULT_INTEGRATOR", "MAX_BODIES", "MAX_BATCH_ONLY_BODIES", "QUEUE_DEPTH"]

#: Integrator used unless the ``integrator`` parameter says otherwise.
DEFAULT_INTEGRATOR = BY_NAME["integrator"].default
#: History depth of every subscription and of /diagnostics (bounded memory under floods); state
#: publishers keep the latest message only (publishers.STATE_QOS).
QUEUE_DEPTH = 10


class RigidBodySimNode(Node):
    """Rigid-body simulator node. Keyword arguments go to :class:`rclpy.node.Node` (``context``,
    ``parameter_overrides``, ``namespace``, ``cli_args``...).

    Parameters
    ----------
    node_name : str
        Name of the node.
    start_ticking : bool
        Call :meth:`start_ticking` at the end of the constructor (default): open the recording,
        publish the initial state, start the tick thread. ``rigid_body_sim_node`` passes False
        and calls it once the executor is set up.

    Raises
    ------
    SceneError
        If the start-up scene cannot be loaded.
    ValueError
        If start-up parameters are invalid (the message says which and what was expected).
    """

    def __init__(self, node_name: str = "rigid_body_sim", *, start_ticking: bool = True, **kwargs: Any):
        super().__init__(node_name, **kwargs)
        self._tick_loop: TickLoop | None = None  # what destroy_node reads, if construction stops early
        self._pending = threading.local()  # the prepared change of the request being set, per thread
        settings = declare_parameters(self)
        for warning in misspelt_parameters(self.get_name(), self.get_fully_qualified_name(), kwargs):
            self.get_logger().warning(warning)
        sim = build_simulator(settings["scene"], settings)
        self._set_body_names(sim.body_names)
        qos = QoSProfile(depth=QUEUE_DEPTH)
        self._endpoints = BodyEndpoints(self, qos, settings, NodeRecording(
            self.get_logger(), settings["frame_prefix"] + settings["world_frame"], self.get_namespace(),
            self.get_fully_qualified_name(), settings["record_overwrite"]))
        self._endpoints.commit(self._endpoints.prepare(sim.scene, settings["publish_odometry"], keep_state=False))
        self._session = SimSession(sim, settings, self._endpoints, self.get_logger(), max_time_s=MAX_ROS_TIME_S,
                                   on_bodies=self._set_body_names,
                                   on_restart=lambda: self._diagnostics.open_window())
        self._service_handles = create_services(self, self._session) + create_robot_services(self, self._session)
        self.add_pre_set_parameters_callback(coerce_parameters)
        self.add_on_set_parameters_callback(self._prepare_change)
        self.add_post_set_parameters_callback(self._apply_change)
        self._steady_clock = Clock(clock_type=ClockType.STEADY_TIME)
        self._diagnostics = NodeDiagnostics(self, self._session, self._endpoints.inputs, qos, self._steady_clock,
                                            self._endpoints.contacts)
        self._diagnostics.set_period(settings["diagnostics_period"])
        self._status_log = StatusLog()
        self._log_start_up()
        self._tick_loop = TickLoop(f"{self.get_name()} ticks", lambda: round(1e9 / self._session.settings["rate_hz"]),
                                   self._tick, self._session.lock.ticks, self._on_tick_failure)
        if start_ticking:
            self.start_ticking()

    # ------------------------------------------------------------------ parameters

    def _set_body_names(self, names: tuple[str, ...] | list[str]) -> None:
        """Set the node-owned ``body_names`` parameter (past the refusal clients get)."""
        self._pending.internal = True
        try:
            self.set_parameters([Parameter("body_names", Parameter.Type.STRING_ARRAY, list(names))])
        finally:
            self._pending.internal = False

    def describe_parameter(self, name: str) -> ParameterDescriptor:
        """The table's full descriptor (type, ranges, read-only) for the node's parameters: what
        ``describe_parameters`` answers. rclpy keeps them dynamically typed (parameters.py says why)."""
        spec = BY_NAME.get(name)
        return spec.descriptor() if spec is not None else super().describe_parameter(name)

    def _prepare_change(self, parameters: list[Parameter]) -> SetParametersResult:
        """On-set: accept or refuse a whole request with the parameter table, then let the session
        prepare what is costly (session.py: the change lock is held from here to :meth:`_apply_change`).
        The prepared change waits, keyed to this request and thread, for the post-set callback."""
        if getattr(self._pending, "internal", False):
            return SetParametersResult(successful=True)
        stale, self._pending.change = getattr(self._pending, "change", None), None
        if stale is not None:  # prepared on this thread, then refused by a later callback: never applied
            self._session.abandon_change(stale)
        values = {p.name: p.value for p in parameters if p.name in BY_NAME}  # the last of a name wins, as in rclpy
        reason = "; ".join(change_problems(values))
        if not reason:  # a peer's scene or record_path only inside scene_dirs / record_dirs (file_access.py)
            reason = change_refusal(values, {**self._session.settings, **values}, self._session.simulator,
                                    self._endpoints.recording) or ""
        if not reason:
            reason, self._pending.change = self._session.begin_change(values, self._endpoints.open_recorder, parameters)
        return SetParametersResult(successful=not reason, reason=reason or "")

    def _apply_change(self, parameters: list[Parameter]) -> None:
        """Post-set: apply the change :meth:`_prepare_change` prepared for this request, whole."""
        if getattr(self._pending, "internal", False):
            return
        change, self._pending.change = getattr(self._pending, "change", None), None
        if change is None:  # rclpy calls on-set and post-set with the same list, on the same thread.
            raise RuntimeError("parameter change applied without its prepared change; refusing to guess")
        if change.request is not parameters:
            self._session.abandon_change(change)
            raise RuntimeError("parameter change applied with another request's prepared change; refusing to guess")
        if "diagnostics_period" in self._session.apply_change(change, self._on_applied):
            self._diagnostics.set_period(change.settings["diagnostics_period"])

    def _on_applied(self, changed: set[str], new_scene: bool) -> None:
        """A change is in (the session's lock held): a new rate restarts the schedule; a new scene is logged."""
        if "rate_hz" in changed:
            self._diagnostics.open_window()
            self._tick_loop.retime()
        if new_scene:
            self._log_start_up()

    # ------------------------------------------------------------------ ticks

    def start_ticking(self) -> None:
        """Open the recording (``record_path``), publish the initial state, start the tick thread; once.

        Raises
        ------
        ValueError
            If ``record_path`` cannot be written (the node then publishes and records nothing).
        """
        loop = self._tick_loop
        if loop is None or loop.started:
            return
        self._endpoints.start_recording(self._session.settings["record_path"], self._session.simulator,
                                        self._session.lock)
        self.publish_state()
        loop.start()

    def _tick(self, due_ns: int, period_ns: int, missed: int) -> None:
        """One tick of the tick thread (the session's lock is held): the session's tick, then flush and log."""
        self._diagnostics.window.record(due_ns, period_ns, missed=missed)
        self._session.tick()
        self._endpoints.recording.flush_if_due()
        settings = self._session.settings
        self._status_log.maybe_log(self.get_logger(), self._session.simulator, settings["status_period"],
                                   settings["paused"])

    def _on_tick_failure(self, exc: BaseException) -> None:
        """The tick thread died: log it with its traceback, ERROR on /diagnostics at once and from
        then on, and the executor spinning the node raises it (``rigid_body_sim_node`` exits 1)."""
        self._session.fail(f"tick thread failed: {exc!r}; no more ticks")
        detail = "".join(traceback.format_exception(exc)).rstrip()
        self.get_logger().fatal(f"tick thread failed, the simulation has stopped: {exc!r}\n{detail}")
        with contextlib.suppress(Exception):
            self._diagnostics.publish()
        # A timer due at once raises the failure in the executor at every spin (rclpy's
        # EventsExecutor does not support guard conditions).
        self.create_timer(0.0, self._raise_tick_failure, clock=self._steady_clock)

    def _raise_tick_failure(self) -> None:
        if self.tick_failure is not None:
            raise self.tick_failure

    @property
    def tick_failure(self) -> BaseException | None:
        """The exception that ended the tick thread, or None while it runs (or before it starts)."""
        return self._tick_loop.failure if self._tick_loop is not None else None

    def tick_running_for(self) -> float | None:
        """Seconds the tick under way has been running, or None between ticks (the session's lock knows)."""
        return self._session.tick_running_for() if self._tick_loop is not None else None

    def advance_one_tick(self) -> None:
        """Advance ``substeps`` physics steps with the held wrenches and pending impulses, then publish."""
        with self._session.lock:
            self._session.advance()

    def publish_state(self) -> None:
        """Publish every running body's pose and twist (and odometry, /clock) at the current sim time."""
        with self._session.lock:
            self._endpoints.publish(self._session.simulator, self._session.settings)

    def _log_start_up(self) -> None:
        frames = {body: list(inputs.frames) for body, inputs in self._endpoints.inputs.bodies.items()}
        log_scene(self.get_logger(), self._session.simulator, self._session.settings, frames)

    # ------------------------------------------------------------------ stopping

    def destroy_node(self) -> None:
        """Stop the tick thread, finish the recording (a complete, indexed MCAP file), then destroy the node."""
        self.stop_ticking_and_recording()
        super().destroy_node()

    def stop_ticking_and_recording(self) -> None:
        """Cancel the step under way, stop the ticks, finish the recording after its last write (twice: safe)."""
        if self._tick_loop is not None:  # else construction stopped before any recording could start
            self._session.request_stop()
            self._tick_loop.stop()
            self._endpoints.stop_recording(self._session.lock)

    def finish_recording_now(self) -> None:
        """Finish the recording without the session's lock: a write under way ends first, none follows."""
        if self._tick_loop is not None:
            self._endpoints.recording.finish_now(wait_s=1.0)

    # ------------------------------------------------------------------ read-only access for tools and tests

    def diagnostics(self, wait_s: float | None = None) -> DiagnosticArray:
        """The /diagnostics report since the last one (node_diagnostics.NodeDiagnostics.report)."""
        return self._diagnostics.report(wait_s)

    @property
    def session(self) -> SimSession:
        """The simulation session (session.py) the node's services and ticks drive."""
        return self._session

    @property
    def simulator(self) -> Simulator:
        """The core simulator this node steps (read it while paused, or inside :meth:`locked_simulator`)."""
        return self._session.simulator

    @contextlib.contextmanager
    def locked_simulator(self) -> Iterator[Simulator]:
        """``with node.locked_simulator() as sim:``: the simulator, with no tick or change under way."""
        with self._session.lock:
            yield self._session.simulator

    def publisher_subscription_counts(self) -> dict[str, int]:
        """Per body, how many subscriptions its pose and twist publishers have matched (the smaller)."""
        with self._session.lock:
            return self._endpoints.outputs.subscription_counts()

    def batch_subscription_count(self) -> int:
        """How many subscriptions the ``poses`` and ``velocities`` publishers have matched (the smaller)."""
        with self._session.lock:
            return self._endpoints.outputs.batch_subscription_count()

    @property
    def rejected(self) -> dict[str, int]:
        """Dropped wrench, impulse and set_state messages by reason (see diagnostics.REJECTION_REASONS)."""
        return dict(self._endpoints.inputs.snapshot()[3])

    @property
    def accepted_messages(self) -> int:
        """Wrench, impulse and set_state messages accepted so far."""
        return self._endpoints.inputs.snapshot()[2]

    @property
    def held_wrenches(self) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray]]:
        """Held wrenches by (body, core frame): (force, torque) in that frame."""
        return self._endpoints.inputs.snapshot()[0]

    @property
    def pending_impulses(self) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray]]:
        """Impulses due at the next step by (body, core frame): summed (linear N·s, angular N·m·s) in that frame."""
        return self._endpoints.inputs.snapshot()[1]
