"""The simulation session behind the node: the simulator, its lock, ticks, stepping, reset and scene edits.

Nothing here knows ROS (no rclpy, no message types): what a session does at its edge (take the
wrenches and set_states that arrived, publish and record the state, make and destroy per-body
endpoints) goes through one object with the :class:`BodyIO` methods, which the node gives as
its :class:`~rigid_body_sim.ros.endpoints.BodyEndpoints` and a test as a plain recorder. So the
tick, ``~/step``, ``~/step_ticks``, ``~/reset``, ``~/reset_world``, ``~/spawn`` and ``~/delete`` can be run and
checked without DDS (test/test_session.py).

One re-entrant lock (:class:`SessionLock`) guards the simulator, the settings and the fault
between the tick thread and the executor's callbacks. It is fair to callers: a tick first lets
in every caller already waiting, so a caller waits for the tick under way at most, even when
ticks overrun their period. A service never waits longer than ``busy_wait_s``: it is refused,
and the answer says who holds the simulator (a tick, or which request) and for how long.
Changes of settings and scene (a parameter change, a spawn, a delete) also take
:attr:`SimSession.change_lock`, one at a time, from preparing to applying, so two never interleave.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Mapping, Protocol

from ..core import NonFiniteStateError, Scene, SceneError, Simulator, load_scene
from .node_log import log_models
from .scene_edit import edited_scene, spawn_overlap

__all__ = ["BUSY_WAIT_S", "CHANGE_WAIT_S", "MAX_BATCH_ONLY_BODIES", "MAX_BODIES", "MAX_STEP_TICKS", "BodyIO",
           "SessionBusy", "SessionLock", "SettingsChange", "SimSession", "build_simulator", "check_scene",
           "physics_dt"]

#: Most bodies a scene may have (start-up, ``scene`` change or spawn): every body costs four topics
#: and their creation (~2 ms each); above this a scene change would stall the parameter
#: service for many seconds. A larger scene is refused with this number in the reason.
MAX_BODIES = 1000
#: Most bodies with ``per_body_topics`` false (batches only; inputs on the shared topics unless
#: ``per_body_inputs`` asks for three subscriptions a body): the scene loader's own limit
#: (core/scene.MAX_BODIES). What sets it (docs/interface.md, "Many bodies"; measured by
#: ``make bench-node``): memory, ~4 KB a body in the node (state buffers, model, scene text,
#: the batch rows and their CDR copies); the size of a tick's batches, 56 bytes a body in each
#: of ``poses`` and ``velocities`` (5.6 MB each at 10⁵), which Fast DDS sends in ~64 KB
#: fragments, ~180 a tick to every subscriber; and the tick's CPU (stepping, packing, sending),
#: ~20 ms at 10⁵ bodies with rk4 (a fifth of a core at 10 Hz). A larger scene is split into shards.
MAX_BATCH_ONLY_BODIES = 100_000
#: Most ticks one ``~/step_ticks`` request may ask for (the node's other callbacks wait while it steps).
MAX_STEP_TICKS = 1_000_000
#: Longest wait (s) of a scene or parameter change for the one before it to finish.
CHANGE_WAIT_S = 30.0
#: Longest wait (s) of a service or parameter change for a tick under way; then it is refused as busy.
BUSY_WAIT_S = 1.0

_RUNNING = "refused: the simulation is running; pause it first (~/set_paused true, or paused:=true)"


class SessionBusy(RuntimeError):
    """A tick or request has kept the simulator longer than a caller would wait; the message says which and for how long."""


class BodyIO(Protocol):
    """What a session drives at its edge: the node's per-body endpoints, or a recorder in a test.

    Every method but :meth:`prepare` and :meth:`release` is called with the session's lock held;
    those two create and destroy endpoints, and are called without it (a reset prepares the
    running scene again, which creates nothing, under the lock).
    """

    def take_set_states(self, sim: Simulator) -> bool:
        """Apply the set_states that arrived; True if any body was set."""

    def take_wrenches(self, sim: Simulator, wrench_timeout: float) -> None:
        """Hand the held wrenches and pending impulses to ``sim`` for the coming steps (and record them)."""

    def publish_tick(self, sim: Simulator, tick_s: float, settings: Mapping[str, Any]) -> None:
        """After a tick's steps: sample the IMUs, then publish (and record) the state."""

    def publish(self, sim: Simulator, settings: Mapping[str, Any]) -> None:
        """Publish (and record) the state at ``sim.time`` (after a reset, a new scene, a set_state while paused)."""

    def publish_bodies(self, sim: Simulator) -> None:
        """Publish the bodies' state only (no /clock, not recorded): new bodies show at once after a spawn."""

    def prepare(self, scene: Scene, publish_odometry: bool, *, keep_state: bool) -> Any:
        """Make what ``scene`` needs beyond what exists; returns the change. Without ``keep_state``,
        committing it starts every hold, impulse, set_state and IMU afresh."""

    def commit(self, change: Any) -> None:
        """Swap the prepared change in."""

    def release(self, change: Any) -> None:
        """Destroy what the committed change replaced (without the lock)."""

    def replace_recorder(self, recorder: Any) -> Any:
        """Record from now on with ``recorder`` (None: stop recording); returns the one replaced."""

    def record_state(self, sim: Simulator, settings: Mapping[str, Any]) -> None:
        """Record the state at ``sim.time`` (if recording)."""

    def finish_recorder(self, recorder: Any) -> None:
        """Finish a replaced recorder (without the lock)."""


def physics_dt(settings: Mapping[str, Any]) -> float:
    """Step (s) of the given parameter values: real_time_factor / (rate_hz · substeps)."""
    return settings["real_time_factor"] / (settings["rate_hz"] * settings["substeps"])


def check_scene(scene: Scene, world_frame: str, per_body_topics: bool) -> None:
    """Refuse a scene the node cannot run: too many bodies for its topics, or a body named like the world.

    Raises
    ------
    SceneError
        For more than :data:`MAX_BODIES` bodies (:data:`MAX_BATCH_ONLY_BODIES` without per-body topics).
    ValueError
        If a body is named like ``world_frame``.
    """
    count = len(scene.body_names)
    if per_body_topics and count > MAX_BODIES:
        raise SceneError(f"{scene.source}: {count} bodies; this node takes at most {MAX_BODIES} "
                         f"(each body has its own topics); with per_body_topics:=false, up to {MAX_BATCH_ONLY_BODIES}")
    if count > MAX_BATCH_ONLY_BODIES:
        raise SceneError(f"{scene.source}: {count} bodies; this node takes at most {MAX_BATCH_ONLY_BODIES} "
                         "(split the scene into shards: rigid-body-sim shard, docs/shards.md)")
    if world_frame in scene.body_names:
        raise ValueError(f"body name {world_frame!r} clashes with world_frame; rename the body")


def build_simulator(path: str, settings: Mapping[str, Any]) -> Simulator:
    """Load the scene file at ``path``, check it (:func:`check_scene`) and build its simulator for ``settings``.

    Raises
    ------
    SceneError, ValueError
        From the loader or :func:`check_scene`.
    """
    scene = load_scene(path)
    check_scene(scene, settings["world_frame"], settings["per_body_topics"])
    sim = Simulator(scene, integrator=settings["integrator"], dt=physics_dt(settings),
                    model_reduction=settings["model_reduction"], threads=settings.get("threads", 0))
    _contact_settings(sim, settings)
    return sim


def _contact_settings(sim: Simulator, settings: Mapping[str, Any]) -> None:
    """The ``sleeping``, ``sleep_speed`` and ``penetration_tolerance`` settings onto the simulator's contact solver
    (if it has one)."""
    if sim.contact is not None:
        sim.contact.sleeping = settings.get("sleeping", False)
        for name in ("sleep_speed", "penetration_tolerance"):
            if name in settings:
                setattr(sim.contact, name, settings[name])


def _ignore(*_args: Any) -> None:
    return None


@dataclass
class SettingsChange:
    """A validated, prepared change of settings, waiting to be applied whole.

    ``values`` are the requested parameter values, ``settings`` all values after the change; a new
    scene comes with its ``simulator`` built, a new ``record_path`` with its ``recorder`` open.
    ``request`` is whatever the caller keys the change to (the node: rclpy's parameter list).
    """

    values: dict[str, Any]
    settings: dict[str, Any]
    request: Any = None
    simulator: Simulator | None = None
    recorder: Any = None

    def discard(self) -> None:
        """Undo what preparing did (a recording file opened for it)."""
        if self.recorder is not None:
            with contextlib.suppress(OSError):
                self.recorder.close()
            self.recorder = None


class SessionLock:
    """The session's lock: re-entrant, fair to callers over the ticks, and it knows who holds it since when.

    A tick takes it as ``with lock.ticks:``. Before it does, every caller already waiting for the
    lock gets its turn (or gives up), so a caller waits for the tick under way at most, also when
    ticks overrun their period and follow each other at once. A plain lock makes no such promise:
    the tick thread that releases it may take it again before a waiting thread wakes up.
    Callers take it as ``with lock:`` or ``with lock("~/reset"):``, naming themselves, so that one
    that gives up can say what kept it out and for how long (:meth:`held`).
    """

    TICK = "a tick"  #: How a tick is named as holder.

    def __init__(self) -> None:
        self._lock = threading.RLock()
        self._turns = threading.Condition()  # guards the tickets and the waiting set
        self._next_ticket = 0
        self._waiting: set[int] = set()  # tickets of callers waiting for the lock
        self._depth = 0  # re-entrant holds of the holder
        self._holder: tuple[str, int] | None = None  # (name, monotonic ns since) of the outermost hold
        self.ticks = _TickTurn(self)

    def acquire(self, blocking: bool = True, timeout: float = -1, holder: str = "a request") -> bool:
        """Take the lock as ``holder`` (see :meth:`threading.RLock.acquire`); True if taken."""
        with self._turns:
            ticket, self._next_ticket = self._next_ticket, self._next_ticket + 1
            self._waiting.add(ticket)
        try:
            taken = self._lock.acquire(blocking, timeout)
        finally:
            with self._turns:
                self._waiting.discard(ticket)
                self._turns.notify_all()
        if taken:
            self._enter(holder)
        return taken

    def acquire_for_tick(self) -> None:
        """Take the lock for a tick, once every caller already waiting has had its turn."""
        with self._turns:
            arrived = self._next_ticket  # callers from now on wait for this tick
            self._turns.wait_for(lambda: not self._waiting or min(self._waiting) >= arrived)
        self._lock.acquire()
        self._enter(self.TICK)

    def release(self) -> None:
        """Release one hold (the holder's thread)."""
        self._depth -= 1
        if self._depth == 0:
            self._holder = None
        self._lock.release()

    def _enter(self, holder: str) -> None:
        self._depth += 1
        if self._depth == 1:
            self._holder = (holder, time.monotonic_ns())

    def held(self) -> tuple[str, float] | None:
        """(Who holds the lock, for how many seconds so far), or None if nobody does."""
        holder = self._holder
        return None if holder is None else (holder[0], (time.monotonic_ns() - holder[1]) * 1e-9)

    def __enter__(self) -> "SessionLock":
        self.acquire()
        return self

    def __exit__(self, *exc: Any) -> None:
        self.release()

    @contextlib.contextmanager
    def __call__(self, holder: str) -> Iterator[None]:
        """``with lock("~/reset"):``: the lock, held as ``holder``."""
        self.acquire(holder=holder)
        try:
            yield
        finally:
            self.release()


class _TickTurn:
    """``with lock.ticks:`` (what the tick thread holds around a tick)."""

    def __init__(self, lock: SessionLock):
        self._lock = lock

    def __enter__(self) -> None:
        self._lock.acquire_for_tick()

    def __exit__(self, *exc: Any) -> None:
        self._lock.release()


class SimSession:
    """A running simulation: simulator, settings and fault under one lock, driven tick by tick.

    Parameters
    ----------
    simulator : Simulator
        The simulation to run.
    settings : mapping
        The node's parameter values (``paused``, ``rate_hz``, ``substeps``, ``real_time_factor``,
        ``wrench_timeout``, ``publish_odometry``, ``world_frame``, ``per_body_topics``...); copied.
    io : BodyIO
        The session's edge.
    logger : object
        With ``info`` and ``error`` methods (an rclpy or a :mod:`logging` logger).
    max_time_s : float
        Sim time (s) no tick may pass (the end of ROS time); the session faults instead.
    busy_wait_s : float
        Longest wait (s) of a service for the lock (:data:`BUSY_WAIT_S`); then it is refused as busy.
    on_bodies : callable
        Called with the new body names after a spawn or delete (without the lock).
    on_restart : callable
        Called, with the lock held, after a reset or a new simulator: sim time may have gone back.
    """

    def __init__(self, simulator: Simulator, settings: Mapping[str, Any], io: BodyIO, logger: Any, *,
                 max_time_s: float = math.inf, busy_wait_s: float = BUSY_WAIT_S,
                 on_bodies: Callable[[tuple[str, ...]], None] = _ignore, on_restart: Callable[[], None] = _ignore):
        self.lock = SessionLock()  # the tick thread takes it as ``with session.lock.ticks:``
        self.change_lock = threading.Lock()  # one scene or parameter change at a time, prepare to apply
        self.simulator = simulator
        self.settings: dict[str, Any] = dict(settings)
        self.fault: str | None = None  # why the simulation cannot go on (ERROR on /diagnostics)
        self.stop_requested = False  # the node is stopping: no tick or step starts, the one under way ends
        self._failed = False  # the fault is permanent (the tick thread died)
        self._io = io
        self._logger = logger
        self._max_time_s = max_time_s
        self._busy_wait_s = busy_wait_s
        self._on_bodies = on_bodies
        self._on_restart = on_restart

    # ------------------------------------------------------------------ the lock

    @contextlib.contextmanager
    def busy_or_locked(self, wait_s: float | None = None, holder: str = "a request") -> Iterator[None]:
        """The lock, held as ``holder``; :class:`SessionBusy` if whoever holds it keeps it longer than
        ``wait_s`` (default ``busy_wait_s``; ``math.inf``: wait), saying who and for how long."""
        wait_s = self._busy_wait_s if wait_s is None else wait_s
        if not self.lock.acquire(timeout=-1 if math.isinf(wait_s) else wait_s, holder=holder):
            raise SessionBusy(self._busy_message(wait_s))
        try:
            yield
        finally:
            self.lock.release()

    def _busy_message(self, waited_s: float) -> str:
        held = self.lock.held()
        if held is None:  # released at the moment the wait ended
            return f"busy: the simulator was held for all of the {waited_s:g} s this request waits; try again"
        holder, for_s = held
        why = (" (a heavy scene, many substeps, or the reference integrator with a long step)"
               if holder == SessionLock.TICK else "")
        return f"busy: {holder} has been running for {for_s:.1f} s{why}; try again"

    def tick_running_for(self) -> float | None:
        """Seconds the tick under way has been running, or None if no tick holds the lock."""
        held = self.lock.held()
        return held[1] if held is not None and held[0] == SessionLock.TICK else None

    def request_stop(self) -> None:
        """The node is stopping: the step under way ends at its next substep boundary
        (:meth:`Simulator.cancel`), its tick publishes the state it reached, and no tick, ``~/step``
        or further tick of ``~/step_ticks`` starts. Takes no lock: safe from any thread and from a
        signal handler."""
        self.stop_requested = True
        self.simulator.cancel()

    def fail(self, reason: str) -> None:
        """Stop for good (the tick thread died): every later tick and step is refused with ``reason``."""
        with self.lock:
            self.fault, self._failed = reason, True

    # ------------------------------------------------------------------ ticks

    def tick(self) -> None:
        """One tick of the tick thread (hold the lock): advance unless paused; while paused, a
        set_state still takes effect and is shown at once."""
        if not self.settings["paused"]:
            self.advance()
        elif self._io.take_set_states(self.simulator):
            self._io.publish(self.simulator, self.settings)

    def advance(self) -> bool:
        """``substeps`` physics steps with the held wrenches and pending impulses, then publish (hold
        the lock); False if the simulation cannot go on (see :attr:`fault`) or the node is stopping
        (:meth:`request_stop`: a tick cut short publishes the state at the substep it reached)."""
        sim, settings = self.simulator, self.settings
        if self.fault is not None or self.stop_requested:
            return False
        tick_s = settings["real_time_factor"] / settings["rate_hz"]
        self._io.take_set_states(sim)  # set_states take effect, whole, at the start of the tick
        if sim.time + tick_s > self._max_time_s:
            self.fault = (f"sim time {sim.time:.9g} s cannot advance past {self._max_time_s} s, the end of ROS time "
                          "(int32 seconds in builtin_interfaces/Time); ~/reset or a new scene starts again")
            self._logger.error(self.fault)
            return False
        self._io.take_wrenches(sim, settings["wrench_timeout"])
        start_time, target = sim.time, sim.step_count + settings["substeps"]
        while sim.step_count < target and not self.stop_requested:
            try:
                sim.step(target - sim.step_count)  # returns early once request_stop cancels it
            except NonFiniteStateError as failure:
                if not failure.bodies:
                    raise
                for body in failure.bodies:
                    sim.stop_body(body)
                self._logger.error(f"stopped {list(failure.bodies)}: {failure}")
        if sim.step_count < target:  # cut short by a stop: sim time advanced by exactly the substeps done
            if sim.time > start_time:
                self._io.publish_tick(sim, sim.time - start_time, settings)
            return False
        self._io.publish_tick(sim, tick_s, settings)
        return True

    def _why_not(self) -> str:
        return self.fault or "the node is stopping"  # advance() is False for a fault or a stop request

    # ------------------------------------------------------------------ services

    def step_paused(self) -> tuple[bool, str]:
        """``~/step``: one tick if paused; (success, message)."""
        try:
            with self.busy_or_locked(holder="~/step"):
                if not self.settings["paused"]:
                    return False, _RUNNING
                if not self.advance():
                    return False, f"refused: {self._why_not()}"
                return True, f"stepped one tick to t = {self.simulator.time:.9f} s"
        except SessionBusy as busy:
            return False, f"refused: {busy}"

    def step_ticks(self, ticks: int) -> tuple[bool, str]:
        """``~/step_ticks``: exactly ``ticks`` ticks while paused, answered when done; (success, message).
        A stop request (:meth:`request_stop`) ends it between ticks, or inside one at a substep
        boundary; the answer (and the log) say how many whole ticks it ran."""
        if not 1 <= ticks <= MAX_STEP_TICKS:
            return False, f"refused: ticks = {ticks}; expected an integer from 1 to {MAX_STEP_TICKS}"
        try:
            with self.busy_or_locked(holder="~/step_ticks"):
                if not self.settings["paused"]:
                    return False, _RUNNING
                for done in range(ticks):
                    if not self.advance():
                        stopped = (f"stopped after {done} of {ticks} ticks at t = {self.simulator.time:.9f} s: "
                                   f"{self._why_not()}")
                        if self.stop_requested:
                            self._logger.info(f"~/step_ticks {stopped}")
                        return False, stopped
                return True, f"stepped {ticks} ticks to t = {self.simulator.time:.9f} s"
        except SessionBusy as busy:
            return False, f"refused: {busy}"

    def reset(self) -> tuple[bool, str]:
        """``~/reset``: the scene's initial state at t = 0, holds, pending impulses and set_states
        dropped, IMUs afresh, published; (success, message). Clears a fault unless the tick thread died."""
        try:
            with self.busy_or_locked(holder="~/reset"):
                sim = self.simulator
                sim.reset()
                self._io.commit(self._io.prepare(sim.scene, self.settings["publish_odometry"], keep_state=False))
                self.fault = self.fault if self._failed else None
                self._on_restart()
                self._io.publish(sim, self.settings)
        except SessionBusy as busy:
            return False, f"refused: {busy}"
        return True, "reset to the scene's initial state at t = 0 s; held wrenches cleared"

    def reset_world(self) -> tuple[bool, str]:
        """``~/reset_world`` (as Gazebo's): every body back to the scene's initial pose and twist while
        sim time goes on (/clock does not go back); holds, pending impulses and set_states dropped,
        IMUs afresh, published; (success, message). A body stopped for a non-finite state stays
        stopped, and a fault stays (time did not go back): ``~/reset`` restarts both."""
        try:
            with self.busy_or_locked(holder="~/reset_world"):
                sim = self.simulator.with_scene(self.simulator.scene)  # same time, step count, dt, integrator
                sim.state = sim.scene.initial_state
                sim.model_reduction = sim.model_reduction  # re-derives each body's model from that state
                self.simulator = sim
                self._io.commit(self._io.prepare(sim.scene, self.settings["publish_odometry"], keep_state=False))
                self._io.publish(sim, self.settings)
                time_s = sim.time
        except SessionBusy as busy:
            return False, f"refused: {busy}"
        return True, f"bodies back to the scene's initial state; sim time goes on at t = {time_s:.9f} s"

    def edit(self, spawn: Mapping[str, str], delete: list[str]) -> tuple[bool, str]:
        """``~/spawn`` and ``~/delete``: add bodies (name → definition in the scene file's YAML form)
        and remove bodies, keeping sim time and every other body's state; (success, message).

        The request is checked whole and the new scene's endpoints made before the swap
        (scene_edit.py); a refused request changes nothing. Holds, set_states and IMU state of the
        bodies kept stay.
        """
        if not self.change_lock.acquire(timeout=CHANGE_WAIT_S):
            return False, f"refused: another change has been under way for more than {CHANGE_WAIT_S:g} s; try again"
        try:
            try:
                with self.busy_or_locked(holder="a spawn or delete"):
                    settings, scene = self.settings, self.simulator.scene
            except SessionBusy as busy:
                return False, f"refused: {busy}"
            try:
                new_scene = edited_scene(scene, spawn, delete)
                check_scene(new_scene, settings["world_frame"], settings["per_body_topics"])
            except (SceneError, ValueError) as exc:
                return False, f"refused: {exc}"
            if spawn:
                try:
                    with self.busy_or_locked(holder="a spawn"):  # the other bodies where they are now
                        overlap = spawn_overlap(self.simulator, new_scene, spawn)
                except SessionBusy as busy:
                    return False, f"refused: {busy}"
                if overlap is not None:
                    return False, f"refused: {overlap}"
            change = self._io.prepare(new_scene, settings["publish_odometry"], keep_state=True)
            with self.lock("a spawn or delete"):
                self.simulator = self.simulator.with_scene(new_scene)
                self._io.commit(change)
                self._io.publish_bodies(self.simulator)  # new bodies at once; /clock only from ticks
                time_s = self.simulator.time
            self._io.release(change)
            self._on_bodies(new_scene.body_names)
        finally:
            self.change_lock.release()
        what = "; ".join(part for part in (f"spawned {list(spawn)}" if spawn else "",
                                           f"deleted {list(delete)}" if delete else "") if part)
        self._logger.info(f"{what} at t = {time_s:.9f} s")
        return True, f"{what} at t = {time_s:.9f} s"

    # ------------------------------------------------------------------ parameter changes

    def begin_change(self, values: Mapping[str, Any], open_recorder: Callable[[str, Simulator, dict], Any],
                     request: Any = None) -> tuple[str | None, SettingsChange | None]:
        """Take :attr:`change_lock` (waiting up to :data:`CHANGE_WAIT_S`) and prepare what is costly in
        a change to ``values`` (already validated) without touching the running simulation: a new
        ``scene``'s simulator, a new ``record_path``'s recorder (``open_recorder(path, sim, settings)``).

        Returns (why it is refused, None), the lock released; or (None, the change), the lock held
        until :meth:`apply_change` or :meth:`abandon_change`.
        """
        if not self.change_lock.acquire(timeout=CHANGE_WAIT_S):
            return f"another parameter change has been under way for more than {CHANGE_WAIT_S:g} s; try again", None
        try:
            reason, change = self._prepare_change(values, open_recorder, request)
        except BaseException:
            self.change_lock.release()
            raise
        if change is None:
            self.change_lock.release()
        return reason, change

    def _prepare_change(self, values: Mapping[str, Any], open_recorder: Callable[[str, Simulator, dict], Any],
                        request: Any) -> tuple[str | None, SettingsChange | None]:
        try:
            with self.busy_or_locked(holder="a parameter change"):
                settings, current = {**self.settings, **values}, self.simulator
        except SessionBusy as busy:
            return str(busy), None
        change = SettingsChange(dict(values), settings, request)
        if "scene" in values:
            try:
                change.simulator = build_simulator(values["scene"], settings)
            except (SceneError, ValueError) as exc:
                return f"scene rejected: {exc}", None
        if values.get("record_path"):
            try:
                change.recorder = open_recorder(values["record_path"], change.simulator or current, settings)
            except OSError as exc:
                return f"record_path rejected: cannot record to {values['record_path']!r} ({exc})", None
        return None, change

    def abandon_change(self, change: SettingsChange) -> None:
        """Drop a change :meth:`begin_change` prepared (it will not be applied) and release :attr:`change_lock`."""
        try:
            change.discard()
        finally:
            self.change_lock.release()

    def apply_change(self, change: SettingsChange, on_applied: Callable[[set[str], bool], None] = _ignore) -> set[str]:
        """Apply a change :meth:`begin_change` prepared, whole, and release :attr:`change_lock`; returns
        the names whose values changed (``scene`` and ``record_path`` whenever given: the same path
        again reloads or restarts).

        Endpoints of a new scene (or odometry publishers) are made before the lock and those replaced
        destroyed after it. ``on_applied(changed, new_scene)`` is called under the lock once the
        change is in, before a new scene's first state is published.
        """
        try:
            old = self.settings
            changed = {name for name in change.values if old.get(name) != change.settings[name]}
            changed |= set(change.values) & {"scene", "record_path"}
            new_scene, settings = change.simulator is not None, change.settings
            sim = change.simulator or self.simulator
            old_names, endpoints, old_recorder = self.simulator.body_names, None, None
            if new_scene or "publish_odometry" in changed:
                endpoints = self._io.prepare(sim.scene, settings["publish_odometry"], keep_state=not new_scene)
            with self.lock("a parameter change"):
                self.apply_settings(settings, change.simulator)
                if endpoints is not None:
                    self._io.commit(endpoints)
                if "record_path" in changed:
                    old_recorder, change.recorder = self._io.replace_recorder(change.recorder), None
                    if not new_scene:  # else the new scene's first state is recorded below
                        self._io.record_state(sim, settings)
                on_applied(changed, new_scene)
                if new_scene:
                    self._io.publish(sim, settings)
            if endpoints is not None:
                self._io.release(endpoints)
            if old_recorder is not None:
                self._io.finish_recorder(old_recorder)
            if new_scene and tuple(sim.body_names) != tuple(old_names):
                self._on_bodies(sim.body_names)
            if "model_reduction" in changed and not new_scene:
                with self.lock:
                    log_models(self._logger, self.simulator)
            return changed
        finally:
            self.change_lock.release()

    def apply_settings(self, settings: Mapping[str, Any], simulator: Simulator | None = None) -> None:
        """Take new parameter values (hold the lock): a new ``simulator`` replaces the running one
        (clearing a fault unless the tick thread died), else the integrator, model reduction and
        step follow ``settings``."""
        old, self.settings = self.settings, dict(settings)
        if simulator is not None:
            self.simulator = simulator
            self.fault = self.fault if self._failed else None
            self._on_restart()
            return
        sim = self.simulator
        for name in ("integrator", "model_reduction", "threads"):
            if old.get(name) != settings.get(name) and name in settings:
                setattr(sim, name, settings[name])
        _contact_settings(sim, settings)  # sleeping off wakes nothing that is not asleep
        dt = physics_dt(settings)
        if dt != sim.dt:
            sim.dt = dt
