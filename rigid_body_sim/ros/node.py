"""The ``rigid_body_sim`` node: steps the core at a fixed wall-clock rate and talks ROS 2.

Every tick the batches ``poses`` and ``velocities`` (all bodies in scene order, batch.py) and, unless
``per_body_topics`` is false, per body B (relative names, so namespaces and remaps apply)
``B/pose``, ``B/twist``, ``B/odom`` (publishers.py); in ``B/wrench`` and ``B/impulse`` (inputs.py). Also ``/clock``
each tick, ``/diagnostics`` every ``diagnostics_period`` wall seconds (diagnostics.py), the
services ``~/reset``, ``~/set_paused`` and ``~/step`` (services.py), and the parameters of
parameters.py. For robot stacks: ``B/S/imu`` per IMU site (imu.py), ``B/set_state``
(set_state.py), ``~/step_ticks``, ``~/spawn`` and ``~/delete`` (robot_services.py,
scene_edit.py) and ``markers`` (markers.py). Each physics step advances ``real_time_factor / (rate_hz · substeps)`` s.

This module wires those parts together and owns what they share: the simulator, the lock,
the tick (tick_loop.py calls :meth:`RigidBodySimNode._tick` from its thread), parameter changes
and the recording (node_recording.py; its log lines are node_log.py's). One re-entrant lock
guards the simulator and the node's state between the tick thread and the executor's
callbacks; incoming messages take only their own lock (inputs.py), and services, parameter
changes and /diagnostics wait for a tick at most a bounded time (``BUSY_WAIT_S``,
``DIAGNOSTICS_WAIT_S``), so a long tick never silences the node. A parameter change is
validated and prepared (a new scene is loaded and its simulator built; a recording file
opened) without the lock, then applied whole under it; endpoints of a new scene are created
before and destroyed after, so a scene change never stops the ticks for longer than the swap.
"""

from __future__ import annotations

import contextlib
import threading
import traceback
from dataclasses import dataclass
from typing import Any, Callable, Iterator

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile

from ..core import NonFiniteStateError, Scene, SceneError, Simulator, load_scene
from ..offline.recording import McapRecorder
from .conversions import MAX_ROS_TIME_S
from .diagnostics import TickWindow, busy_status, diagnostic_statuses
from .file_access import change_refusal
from .imu import ImuPublishers
from .inputs import WrenchInputs
from .markers import MarkerPublisher
from .node_log import StatusLog, log_models, log_scene
from .node_recording import NodeRecording
from .parameters import BY_NAME, coerce, declare_parameters, problems
from .publishers import StatePublishers
from .robot_services import create_robot_services
from .scene_edit import edited_scene
from .services import create_services
from .set_state import SetStateInputs
from .tick_loop import TickLoop

__all__ = ["RigidBodySimNode", "DEFAULT_INTEGRATOR", "MAX_BODIES", "MAX_BATCH_ONLY_BODIES", "QUEUE_DEPTH"]

#: Integrator used unless the ``integrator`` parameter says otherwise.
DEFAULT_INTEGRATOR = BY_NAME["integrator"].default
#: History depth of every subscription and of /diagnostics (bounded memory under floods); state
#: publishers keep the latest message only (publishers.STATE_QOS).
QUEUE_DEPTH = 10
#: Most bodies a scene may have (start-up or ``scene`` change): every body costs four topics
#: and their creation (~2 ms each); above this a scene change would stall the parameter
#: service for many seconds. A larger scene is refused with this number in the reason.
MAX_BODIES = 1000
#: Most ticks one ``~/step_ticks`` request may ask for (the node's other callbacks wait while it steps).
MAX_STEP_TICKS = 1_000_000
#: Most bodies with ``per_body_topics`` false (batches only; inputs stay per body: two
#: subscriptions each).
MAX_BATCH_ONLY_BODIES = 10_000
#: Longest wait (s) of a parameter change for the one before it to finish.
CHANGE_WAIT_S = 30.0
#: Longest wait (s) of a service or parameter change for a tick under way; then it is refused as busy.
BUSY_WAIT_S = 1.0
#: Longest wait (s) of a /diagnostics report for a tick under way; then it reports the tick instead.
DIAGNOSTICS_WAIT_S = 0.1
#: A tick running longer than this (s) is reported as ERROR on /diagnostics (else WARN).
STUCK_TICK_S = 5.0


class NodeBusy(RuntimeError):
    """A tick has kept the simulator longer than a caller would wait; the message says for how long."""


def physics_dt(settings: dict[str, Any]) -> float:
    """Step (s) of the given parameter values: real_time_factor / (rate_hz · substeps)."""
    return settings["real_time_factor"] / (settings["rate_hz"] * settings["substeps"])


@dataclass
class _Change:
    """A validated, prepared parameter change, waiting for rclpy to store the values."""

    parameters: list[Parameter]
    values: dict[str, Any]
    settings: dict[str, Any]
    simulator: Simulator | None = None
    recorder: McapRecorder | None = None

    def discard(self) -> None:
        """Undo what preparing did (a recording file opened for it)."""
        if self.recorder is not None:
            with contextlib.suppress(OSError):
                self.recorder.close()
            self.recorder = None


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
        and calls it once a signal can no longer interrupt it half-way.
    on_created : callable, optional
        Called with the node as soon as it exists, before its scene and endpoints are built, so
        that a caller whose construction is interrupted (a signal during the tens of seconds
        10,000 bodies' endpoints take) can still stop what was built: ``rigid_body_sim_node``
        then exits without destroying thousands of endpoints one by one.

    Raises
    ------
    SceneError
        If the start-up scene cannot be loaded.
    ValueError
        If start-up parameters are invalid (the message says which and what was expected).
    """

    # What the tear-down reads, here as well as in the constructor: rclpy's Context.shutdown
    # destroys every node it tracks, also one whose construction a signal cut short right
    # after rclpy's own constructor returned.
    _tick_loop: TickLoop | None = None
    _recording: NodeRecording | None = None

    def __init__(self, node_name: str = "rigid_body_sim", *, start_ticking: bool = True,
                 on_created: Callable[["RigidBodySimNode"], None] | None = None, **kwargs: Any):
        super().__init__(node_name, **kwargs)
        self._lock = threading.RLock()
        self._pending = threading.local()  # the prepared change of the request being set, per thread
        self._change_lock = threading.Lock()  # one parameter change at a time, from on-set to post-set
        self._tick_loop: TickLoop | None = None
        self._recording: NodeRecording | None = None
        self._fault: str | None = None  # why the simulation cannot go on (ERROR on /diagnostics)
        if on_created is not None:
            on_created(self)
        self._settings: dict[str, Any] = declare_parameters(self)
        settings = self._settings
        self._world_frame: str = settings["world_frame"]
        self._sim = self._build_simulator(settings["scene"], settings)
        self._set_body_names(self._sim.body_names)
        qos = QoSProfile(depth=QUEUE_DEPTH)
        self._outputs = StatePublishers(self, self._world_frame, per_body_topics=settings["per_body_topics"],
                                        twist_stamped=settings["twist_stamped"])
        self._inputs = WrenchInputs(self, qos, self._world_frame)
        self._outputs.commit(self._outputs.prepare(self._sim.body_names, settings["publish_odometry"]))
        self._inputs.commit(self._inputs.prepare(self._sim))
        self._imus = ImuPublishers(self, qos)
        self._imus.commit(self._imus.prepare(self._sim.scene, keep_state=False))
        self._set_state = SetStateInputs(self, qos, self._world_frame, self._inputs)
        self._set_state.commit(self._set_state.prepare(self._sim.body_names))
        self._markers = MarkerPublisher(self, qos, self._world_frame)
        self._recording = NodeRecording(self.get_logger(), self._world_frame, self.get_namespace(),
                                        self.get_fully_qualified_name(), settings["record_overwrite"])
        self._service_handles = create_services(self) + create_robot_services(self)
        self.add_pre_set_parameters_callback(self._coerce_parameters)
        self.add_on_set_parameters_callback(self._prepare_change)
        self.add_post_set_parameters_callback(self._apply_change)

        self._steady_clock = Clock(clock_type=ClockType.STEADY_TIME)
        self._tick_window = TickWindow(self._sim.time)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", qos)
        self._diagnostics_timer = None
        self._set_diagnostics_period(settings["diagnostics_period"])
        self._status_log = StatusLog()
        self._log_start_up()
        self._tick_loop = TickLoop(f"{self.get_name()} ticks", lambda: round(1e9 / self._settings["rate_hz"]),
                                   self._tick, self._lock, self._on_tick_failure)
        if start_ticking:
            self.start_ticking()

    # ------------------------------------------------------------------ scene

    def _build_simulator(self, path: str, settings: dict[str, Any]) -> Simulator:
        """Load ``path`` and build its simulator for ``settings`` (no shared state touched).

        Raises
        ------
        SceneError
            From the loader, or for more than :data:`MAX_BODIES` bodies.
        ValueError
            If a body is named like ``world_frame``.
        """
        scene = load_scene(path)
        self._check_scene(scene, settings["world_frame"], settings["per_body_topics"])
        return Simulator(scene, integrator=settings["integrator"], dt=physics_dt(settings),
                         model_reduction=settings["model_reduction"])

    @staticmethod
    def _check_scene(scene: Scene, world_frame: str, per_body_topics: bool) -> None:
        if per_body_topics and len(scene.body_names) > MAX_BODIES:
            raise SceneError(f"{scene.source}: {len(scene.body_names)} bodies; this node takes at most {MAX_BODIES} "
                             f"(each body has its own topics); with per_body_topics:=false, up to {MAX_BATCH_ONLY_BODIES}")
        if len(scene.body_names) > MAX_BATCH_ONLY_BODIES:
            raise SceneError(f"{scene.source}: {len(scene.body_names)} bodies; this node takes at most "
                             f"{MAX_BATCH_ONLY_BODIES} (each body has its own wrench and impulse subscriptions)")
        if world_frame in scene.body_names:
            raise ValueError(f"body name {world_frame!r} clashes with world_frame; rename the body")

    # ------------------------------------------------------------------ parameters

    def _set_body_names(self, names: tuple[str, ...] | list[str]) -> None:
        """Set the node-owned ``body_names`` parameter (past the refusal clients get)."""
        self._pending.internal = True
        try:
            self.set_parameters([Parameter("body_names", Parameter.Type.STRING_ARRAY, list(names))])
        finally:
            self._pending.internal = False

    def _coerce_parameters(self, parameters: list[Parameter]) -> list[Parameter]:
        """Pre-set: whole numbers for float parameters are floats (``rate_hz:=200`` means 200.0)."""
        out = []
        for param in parameters:
            spec = BY_NAME.get(param.name)
            if spec is not None and spec.type is Parameter.Type.DOUBLE:
                value = coerce(spec, param.value)
                if value is not param.value:
                    param = Parameter(param.name, Parameter.Type.DOUBLE, value)
            out.append(param)
        return out

    def _prepare_change(self, parameters: list[Parameter]) -> SetParametersResult:
        """On-set: accept or refuse a whole request with the parameter table, and prepare what is
        costly (the new scene's simulator, a new recording file) without touching the running
        simulation. The prepared change waits, keyed to this request and thread, for
        :meth:`_apply_change`; changes are serialized from here to there, so two clients (or
        the threads of a multi-threaded executor) never interleave theirs."""
        if getattr(self._pending, "internal", False):
            return SetParametersResult(successful=True)
        stale = getattr(self._pending, "change", None)
        self._pending.change = None
        if stale is not None:  # prepared on this thread, then refused by a later callback: never applied
            stale.discard()
            self._change_lock.release()
        if not self._change_lock.acquire(timeout=CHANGE_WAIT_S):
            return SetParametersResult(successful=False, reason=(
                f"another parameter change has been under way for more than {CHANGE_WAIT_S:g} s; try again"))
        try:
            result, change = self._prepare(parameters)
        except BaseException:
            self._change_lock.release()
            raise
        if change is None:
            self._change_lock.release()
        self._pending.change = change
        return result

    def _prepare(self, parameters: list[Parameter]) -> tuple[SetParametersResult, _Change | None]:
        values = {p.name: p.value for p in parameters if p.name in BY_NAME}  # the last of a name wins, as in rclpy
        reasons = problems(values)
        if reasons:
            return SetParametersResult(successful=False, reason="; ".join(reasons)), None
        try:
            with self._lock_or_busy():
                settings = {**self._settings, **values}
                current = self._sim
        except NodeBusy as busy:
            return SetParametersResult(successful=False, reason=str(busy)), None
        if (refused := change_refusal(values, settings, current, self._recording)) is not None:
            return SetParametersResult(successful=False, reason=refused), None
        change = _Change(parameters, values, settings)
        if "scene" in values:
            try:
                change.simulator = self._build_simulator(values["scene"], settings)
            except (SceneError, ValueError) as exc:
                return SetParametersResult(successful=False, reason=f"scene rejected: {exc}"), None
        if values.get("record_path"):
            sim = change.simulator or current
            try:
                change.recorder = self._recording.open(values["record_path"], sim, dt=physics_dt(settings),
                                                       integrator=settings["integrator"])
            except OSError as exc:
                return SetParametersResult(successful=False, reason=(
                    f"record_path rejected: cannot record to {values['record_path']!r} ({exc})")), None
        return SetParametersResult(successful=True), change

    def _apply_change(self, parameters: list[Parameter]) -> None:
        """Post-set: apply the change :meth:`_prepare_change` prepared for this request, whole."""
        if getattr(self._pending, "internal", False):
            return
        change = getattr(self._pending, "change", None)
        self._pending.change = None
        if change is None:
            # rclpy calls on-set and post-set with the same list, on the same thread.
            raise RuntimeError("parameter change applied without its prepared change; refusing to guess")
        try:
            if change.parameters is not parameters:
                raise RuntimeError("parameter change applied with another request's prepared change; refusing to guess")
            self._apply(change)
        finally:
            self._change_lock.release()

    def _apply(self, change: _Change) -> None:
        old, new = self._settings, change.settings
        changed = {name for name in change.values if old.get(name) != new[name]}
        changed |= set(change.values) & {"scene", "record_path"}  # the same path again reloads / restarts
        sim = change.simulator or self._sim
        # Endpoints of a new scene (or odometry publishers) are made before the lock and the
        # replaced ones destroyed after it: the ticks wait only for the swap itself.
        publishers = inputs = imus = set_state = None
        if change.simulator is not None or "publish_odometry" in changed:
            publishers = self._outputs.prepare(sim.body_names, new["publish_odometry"])
        if change.simulator is not None:
            inputs = self._inputs.prepare(sim)
            imus = self._imus.prepare(sim.scene, keep_state=False)
            set_state = self._set_state.prepare(sim.body_names)
        with self._lock:
            self._settings = new
            if change.simulator is not None:
                self._sim = sim
                self._fault = self._fault if self.tick_failure is not None else None
                self._inputs.commit(inputs)
                self._imus.commit(imus)
                self._set_state.commit(set_state)
                self._set_state.clear()
            else:
                if "integrator" in changed:
                    sim.integrator = new["integrator"]
                if "model_reduction" in changed:
                    sim.model_reduction = new["model_reduction"]
                dt = physics_dt(new)
                if dt != sim.dt:
                    sim.dt = dt
            if publishers is not None:
                self._outputs.commit(publishers)
            old_recorder = None
            if "record_path" in changed:
                old_recorder = self._recording.replace(change.recorder)
                change.recorder = None
                if change.simulator is None:  # else the new scene's first state is written below
                    self._record_state_locked()
            if change.simulator is not None or "rate_hz" in changed:
                self._open_diagnostics_window()
            if "rate_hz" in changed and self._tick_loop is not None:
                self._tick_loop.retime()
            if change.simulator is not None:
                self._log_start_up()
                self._publish_state_locked()
        if publishers is not None:
            self._outputs.release(publishers)
        if inputs is not None:
            self._inputs.release(inputs)
        if imus is not None:
            self._imus.release(imus)
        if set_state is not None:
            self._set_state.release(set_state)
        if old_recorder is not None:
            self._recording.finish(old_recorder)
        if change.simulator is not None and tuple(change.simulator.body_names) != tuple(self.get_parameter("body_names").value):
            self._set_body_names(change.simulator.body_names)
        if "model_reduction" in changed and change.simulator is None:
            with self._lock:
                log_models(self.get_logger(), self._sim)
        if "diagnostics_period" in changed:
            self._set_diagnostics_period(new["diagnostics_period"])

    # ------------------------------------------------------------------ ticks

    def start_ticking(self) -> None:
        """Start: open the recording (``record_path``), publish the initial state, start the tick
        thread. Once; the constructor calls it unless ``start_ticking=False``.

        The recording is opened here, right before the state it starts with is written, so a
        stop during start-up leaves no recording, or one that holds the initial state.

        Raises
        ------
        ValueError
            If ``record_path`` cannot be written (the node then publishes and records nothing).
        """
        loop = self._tick_loop
        if loop is None or loop.started:
            return
        path = self._settings["record_path"]
        if path and self._recording.recorder is None:
            try:
                recorder = self._recording.open(path, self._sim)
            except OSError as exc:
                raise ValueError(f"record_path rejected: cannot record to {path!r} ({exc})") from exc
            with self._lock:
                self._recording.replace(recorder)
        self.publish_state()
        loop.start()

    def _tick(self, due_ns: int, period_ns: int, missed: int) -> None:
        """One tick of the tick thread (the lock is held): advance unless paused, then log status."""
        self._tick_window.record(due_ns, period_ns, missed=missed)
        if not self._settings["paused"]:
            self._advance_one_tick_locked()
        elif self._set_state.apply(self._sim):  # set_state also while paused: applied and shown at once
            self._publish_state_locked()
        self._recording.flush_if_due()
        self._status_log.maybe_log(self.get_logger(), self._sim, self._settings["status_period"], self._settings["paused"])

    def _on_tick_failure(self, exc: BaseException) -> None:
        """The tick thread died: say so everywhere at once, then hand the error to the executor.

        The error and its traceback are logged, ``/diagnostics`` says ERROR at once (and in every
        later message), and the executor spinning the node raises it (``rigid_body_sim_node``
        then exits with status 1). A node never goes on silently without ticks.
        """
        detail = "".join(traceback.format_exception(exc)).rstrip()
        with self._lock:
            self._fault = f"tick thread failed: {exc!r}; no more ticks"
        self.get_logger().fatal(f"tick thread failed, the simulation has stopped: {exc!r}\n{detail}")
        with contextlib.suppress(Exception):
            self.publish_diagnostics()
        # A timer due at once in the executor raises the failure there, at every spin (a guard
        # condition would do, but rclpy's EventsExecutor does not support them).
        self.create_timer(0.0, self._raise_tick_failure, clock=self._steady_clock)

    def _raise_tick_failure(self) -> None:
        failure = self.tick_failure
        if failure is not None:
            raise failure

    @property
    def tick_failure(self) -> BaseException | None:
        """The exception that ended the tick thread, or None while it runs (or before it starts)."""
        return self._tick_loop.failure if self._tick_loop is not None else None

    def advance_one_tick(self) -> None:
        """Advance ``substeps`` physics steps with the held wrenches and pending impulses, then publish."""
        with self._lock:
            self._advance_one_tick_locked()

    def _advance_one_tick_locked(self) -> bool:
        """One tick (the lock held); False if the simulation cannot go on (see ``_fault``)."""
        sim, settings = self._sim, self._settings
        if self._fault is not None:
            return False
        tick_s = settings["real_time_factor"] / settings["rate_hz"]
        self._set_state.apply(sim)  # set_state messages take effect, whole, at the start of the tick
        if sim.time + tick_s > MAX_ROS_TIME_S:
            self._fault = (f"sim time {sim.time:.9g} s cannot advance past {MAX_ROS_TIME_S} s, the end of ROS time "
                           "(int32 seconds in builtin_interfaces/Time); ~/reset or a new scene starts again")
            self.get_logger().error(self._fault)
            return False
        held = self._inputs.apply(sim, settings["wrench_timeout"])
        self._recording.write(lambda recorder: recorder.write_wrenches(sim.time, held + sim.active_scripted_wrenches()))
        target = sim.step_count + settings["substeps"]
        while sim.step_count < target:
            try:
                sim.step(target - sim.step_count)
            except NonFiniteStateError as failure:
                if not failure.bodies:
                    raise
                for body in failure.bodies:
                    sim.stop_body(body)
                self.get_logger().error(f"stopped {list(failure.bodies)}: {failure}")
        self._imus.publish(sim, tick_s, self._record_imu if self._recording.recorder is not None else None)
        self._publish_state_locked()
        return True

    def _record_imu(self, sample: Any) -> None:
        self._recording.write(lambda recorder: recorder.write_imu(
            sample.time, sample.site, sample.orientation_xyzw, sample.angular_velocity, sample.specific_force,
            sample.covariances))

    def step_paused(self) -> tuple[bool, str]:
        """``~/step``: one tick if paused; (success, message)."""
        try:
            with self._lock_or_busy():
                if not self._settings["paused"]:
                    return False, "refused: the simulation is running; pause it first (~/set_paused true, or paused:=true)"
                if not self._advance_one_tick_locked():
                    return False, f"refused: {self._fault}"
                return True, f"stepped one tick to t = {self._sim.time:.9f} s"
        except NodeBusy as busy:
            return False, f"refused: {busy}"

    def step_ticks(self, ticks: int) -> tuple[bool, str]:
        """``~/step_ticks``: exactly ``ticks`` ticks while paused, answered when done; (success, message)."""
        if not 1 <= ticks <= MAX_STEP_TICKS:
            return False, f"refused: ticks = {ticks}; expected an integer from 1 to {MAX_STEP_TICKS}"
        try:
            with self._lock_or_busy():
                if not self._settings["paused"]:
                    return False, "refused: the simulation is running; pause it first (~/set_paused true, or paused:=true)"
                for done in range(ticks):
                    if not self._advance_one_tick_locked():
                        return False, (f"stopped after {done} of {ticks} ticks at t = {self._sim.time:.9f} s: "
                                       f"{self._fault}")
                return True, f"stepped {ticks} ticks to t = {self._sim.time:.9f} s"
        except NodeBusy as busy:
            return False, f"refused: {busy}"

    def edit_scene(self, spawn: dict[str, str], delete: list[str]) -> tuple[bool, str]:
        """``~/spawn`` and ``~/delete``: add bodies (name → definition in the scene file's YAML form)
        and remove bodies, keeping sim time and every other body's state; (success, message).

        The request is checked whole and the new scene's simulator, publishers and subscriptions
        made before the swap (scene_edit.py); a refused request changes nothing. Serialized with
        parameter changes (a ``scene`` change and a spawn never interleave). Holds of the bodies
        kept stay; pending set_states of deleted bodies are dropped.
        """
        if not self._change_lock.acquire(timeout=CHANGE_WAIT_S):
            return False, f"refused: another change has been under way for more than {CHANGE_WAIT_S:g} s; try again"
        try:
            try:
                with self._lock_or_busy():
                    settings, scene = self._settings, self._sim.scene
            except NodeBusy as busy:
                return False, f"refused: {busy}"
            try:
                new_scene = edited_scene(scene, spawn, delete)
                self._check_scene(new_scene, settings["world_frame"], settings["per_body_topics"])
            except (SceneError, ValueError) as exc:
                return False, f"refused: {exc}"
            publishers = self._outputs.prepare(new_scene.body_names, settings["publish_odometry"])
            inputs = self._inputs.prepare(new_scene)
            imus = self._imus.prepare(new_scene, keep_state=True)
            set_state = self._set_state.prepare(new_scene.body_names)
            with self._lock:
                self._sim = self._sim.with_scene(new_scene)
                self._outputs.commit(publishers)
                self._inputs.commit(inputs, keep_holds=True)
                self._imus.commit(imus)
                self._set_state.commit(set_state)
                self._outputs.publish(self._sim, False)  # new bodies at once; /clock only from ticks (never repeated)
                time_s = self._sim.time
            self._outputs.release(publishers)
            self._inputs.release(inputs)
            self._imus.release(imus)
            self._set_state.release(set_state)
            self._set_body_names(new_scene.body_names)  # the batches' order follows at once
        finally:
            self._change_lock.release()
        what = "; ".join(part for part in (f"spawned {list(spawn)}" if spawn else "",
                                           f"deleted {list(delete)}" if delete else "") if part)
        self.get_logger().info(f"{what} at t = {time_s:.9f} s")
        return True, f"{what} at t = {time_s:.9f} s"

    def reset_simulation(self) -> tuple[bool, str]:
        """``~/reset``: the scene's initial state at t = 0, holds and pending impulses dropped,
        published; (success, message)."""
        try:
            with self._lock_or_busy():
                self._sim.reset()
                self._imus.commit(self._imus.prepare(self._sim.scene, keep_state=False))  # no new endpoints
                self._fault = None if self.tick_failure is None else self._fault
                self._open_diagnostics_window()
                self._inputs.clear()
                self._set_state.clear()
                self._publish_state_locked()
        except NodeBusy as busy:
            return False, f"refused: {busy}"
        return True, "reset to the scene's initial state at t = 0 s; held wrenches cleared"

    # ------------------------------------------------------------------ outgoing

    def publish_state(self) -> None:
        """Publish every running body's pose and twist (and odometry, /clock) at the current sim time."""
        with self._lock:
            self._publish_state_locked()

    def _publish_state_locked(self) -> None:
        sim, settings = self._sim, self._settings
        self._outputs.publish(sim, settings["publish_clock"])
        self._markers.publish(sim, settings["marker_rate_hz"], lambda: self._inputs.snapshot()[0],
                              settings["marker_force_scale"] if settings["marker_wrenches"] else None)
        if self._recording.recorder is not None:
            self._record_state_locked()

    def _record_state_locked(self) -> None:
        """Write the state just published, then /clock: with ``per_body_topics`` false the two
        batches as published (two messages a tick for all bodies), else each running body's
        pose and twist."""
        sim = self._sim
        batches = self._outputs.last_batches_cdr()
        if not self._settings["per_body_topics"] and batches is not None and batches[0] is sim.body_names:
            self._recording.write(lambda recorder: (recorder.write_batches(*batches), recorder.write_clock(sim.time)))
            return
        finite = sim.state.finite_bodies().tolist()
        skip = [body for index, body in enumerate(sim.body_names) if not finite[index]]
        self._recording.write(lambda recorder: recorder.write_simulator(sim, skip=skip))

    def _set_diagnostics_period(self, period: float) -> None:
        """(Re)start the /diagnostics timer at ``period`` wall seconds; 0 stops it."""
        if self._diagnostics_timer is not None:
            self.destroy_timer(self._diagnostics_timer)
            self._diagnostics_timer = None
        if period > 0.0:
            self._diagnostics_timer = self.create_timer(period, self.publish_diagnostics, clock=self._steady_clock)
        with self._lock:
            self._open_diagnostics_window()

    def _open_diagnostics_window(self) -> None:
        self._tick_window.reopen(self._sim.time)
        _, _, self._accepted_at_open, self._rejected_at_open = self._inputs.snapshot()

    def diagnostics(self, wait_s: float | None = None) -> DiagnosticArray:
        """The DiagnosticArray for the window since the last one (see diagnostics.py); opens a new window.

        With ``wait_s``, a tick that keeps the simulator longer than that gives a report that says
        so (WARN; ERROR after :data:`STUCK_TICK_S`) instead of waiting for it.
        """
        array = DiagnosticArray()
        array.header.stamp = self.get_clock().now().to_msg()
        try:
            with self._lock_or_busy(wait_s):
                sim, settings = self._sim, self._settings
                holds, pending, accepted, rejected = self._inputs.snapshot()
                array.status = diagnostic_statuses(
                    node_name=self.get_name(), window=self._tick_window, sim_time=sim.time, paused=settings["paused"],
                    integrator=sim.integrator, dt=sim.dt, substeps=settings["substeps"], rate_hz=settings["rate_hz"],
                    real_time_factor=settings["real_time_factor"], bodies=sim.body_names, stopped=sim.stopped_bodies,
                    held_wrenches=len(holds), pending_impulses=len(pending), accepted_total=accepted,
                    accepted_at_open=self._accepted_at_open, rejected_total=rejected,
                    rejected_at_open=self._rejected_at_open, fault=self._fault)
                self._open_diagnostics_window()
        except NodeBusy as busy:
            running = self.tick_running_for()
            array.status = [busy_status(node_name=self.get_name(), message=str(busy), busy_for_s=running,
                                        error=running is not None and running > STUCK_TICK_S)]
        return array

    def publish_diagnostics(self) -> None:
        """Publish :meth:`diagnostics` on /diagnostics (the diagnostics timer calls this); never waits
        long for a tick."""
        self._diagnostics_pub.publish(self.diagnostics(wait_s=DIAGNOSTICS_WAIT_S))

    @contextlib.contextmanager
    def _lock_or_busy(self, wait_s: float | None = BUSY_WAIT_S) -> Iterator[None]:
        """The node's lock; :class:`NodeBusy` if a tick keeps it longer than ``wait_s`` (None: wait)."""
        if not self._lock.acquire(timeout=-1 if wait_s is None else wait_s):
            running = self.tick_running_for()
            raise NodeBusy("busy: a tick has been running for "
                           + (f"{running:.1f} s" if running is not None else "a while")
                           + " (a heavy scene, many substeps, or the reference integrator with a long step); try again")
        try:
            yield
        finally:
            self._lock.release()

    def _log_start_up(self) -> None:
        frames = {body: list(inputs.frames) for body, inputs in self._inputs.bodies.items()}
        log_scene(self.get_logger(), self._sim, self._settings, frames)

    def destroy_node(self) -> None:
        """Stop the tick thread, finish the recording (a complete, indexed MCAP file), then destroy the node."""
        self.stop_ticking_and_recording()
        super().destroy_node()

    def stop_ticking_and_recording(self) -> None:
        """Stop the tick thread (a tick under way ends first) and finish the recording. Safe to call twice."""
        if self._tick_loop is not None:
            self._tick_loop.stop()
        recording = self._recording  # None if construction stopped before it
        if recording is not None:
            with self._lock:
                recorder = recording.replace(None)
            if recorder is not None:
                recording.finish(recorder)

    def finish_recording_now(self) -> None:
        """Finish the recording without waiting for the lock: for an exit that cannot wait for a
        tick stuck in a step (which writes nothing while it steps)."""
        recording = self._recording
        recorder = recording.replace(None) if recording is not None else None
        if recorder is not None:
            recording.finish(recorder)

    def tick_running_for(self) -> float | None:
        """Seconds the tick under way has been running, or None between ticks."""
        return self._tick_loop.busy_for() if self._tick_loop is not None else None

    # ------------------------------------------------------------------ read-only access for tools and tests

    @property
    def simulator(self) -> Simulator:
        """The core simulator this node steps. Read it while paused, or inside :meth:`locked_simulator`
        while running; drive it through topics, services and parameters."""
        return self._sim

    @contextlib.contextmanager
    def locked_simulator(self) -> Iterator[Simulator]:
        """``with node.locked_simulator() as sim:``: the simulator, with no tick or change under way."""
        with self._lock:
            yield self._sim

    def publisher_subscription_counts(self) -> dict[str, int]:
        """Per body, how many subscriptions its pose and twist publishers have matched (the smaller)."""
        with self._lock:
            return self._outputs.subscription_counts()

    def batch_subscription_count(self) -> int:
        """How many subscriptions the ``poses`` and ``velocities`` publishers have matched (the smaller)."""
        with self._lock:
            return self._outputs.batch_subscription_count()

    @property
    def rejected(self) -> dict[str, int]:
        """Dropped wrench, impulse and set_state messages by reason (see diagnostics.REJECTION_REASONS)."""
        return dict(self._inputs.snapshot()[3])

    @property
    def accepted_messages(self) -> int:
        """Wrench, impulse and set_state messages accepted so far."""
        return self._inputs.snapshot()[2]

    @property
    def held_wrenches(self) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray]]:
        """Held wrenches by (body, core frame): (force, torque) in that frame."""
        return self._inputs.snapshot()[0]

    @property
    def pending_impulses(self) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray]]:
        """Impulses due at the next step by (body, core frame): summed (linear N·s, angular N·m·s) in that frame."""
        return self._inputs.snapshot()[1]
