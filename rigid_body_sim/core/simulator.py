"""The public simulator: a scene, an integrator, a step, applied wrenches and state read-outs.

Typical use::

    from rigid_body_sim.core import Simulator, load_scene

    sim = Simulator(load_scene("config/default_scene.yaml"), integrator="rk4", dt=0.01)
    sim.apply_force_at_point("box", force=[0, 10, 0], point=[0.5, 0.3, 0], frame="box")
    sim.step()                       # wrenches hold for this call's steps, then clear
                                     # (the scene's scripted wrenches act by themselves)
    state = sim.body_state("box")    # position_world, orientation_xyzw, ...

Orientation read-outs are (x, y, z, w), as in ROS messages and scene files, of the user's body
frame B; internally the core integrates the principal frame P with (w, x, y, z) quaternions.
"""

from __future__ import annotations

import math
import struct
import warnings
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from . import reduction
from .frames import new_wrench_rows, parse_frame
from .integrators import INTEGRATORS, Method, get_integrator, step_exact_rotor_splitting, step_reference
from .kernels import layout as L
from .kernels import controls, parallel, sensors, stepping
from .kernels.state_rows import pose_twist_rows
from .kernels.compile import compile_kernels as compile_stepping_kernels
from .kernels.jit import cache_complete, cache_lock, mark_cache_complete, sources_unchanged
from .kernels.dynamics import impulse_response
from .kernels.forces import add_wrench, project_twist
from .mechanics import angular_momentum_W, kinetic_energy, linear_momentum_W, potential_energy
from .model import State
from .quaternion import (
    quat_conjugate,
    quat_multiply,
    quat_rotate,
    quat_wxyz_from_xyzw,
    quat_xyzw_from_wxyz,
)
from .scene import ORIENTATION_TOLERANCE, Scene
from .stepping import pack_parameters

__all__ = ["Simulator", "BodyState", "SiteReadings", "NonFiniteStateError", "DivergenceError",
           "ControlRejectedWarning", "SCRIPT_TIME_TOLERANCE"]

#: A step whose start time is within this fraction of ``dt`` of a scripted wrench's window edge
#: counts as on the edge, so a window given in multiples of ``dt`` covers exactly
#: ``duration / dt`` steps despite round-off in ``time``.
SCRIPT_TIME_TOLERANCE = 1e-6


class NonFiniteStateError(RuntimeError):
    """A step produced a non-finite state. The step was not applied; the state is the last good one.

    Attributes
    ----------
    bodies : tuple of str
        The bodies whose state turned non-finite.
    step_index : int
        Index (0-based, counted from the last reset) of the step that failed.
    integrator : str
    spin_step : dict of str to float
        |w|·dt (rad) of each failing body at the start of the step.
    """

    def __init__(self, bodies: tuple[str, ...], step_index: int, integrator: str, dt: float,
                 spin_step: dict[str, float]):
        self.bodies = bodies
        self.step_index = step_index
        self.integrator = integrator
        self.dt = dt
        self.spin_step = spin_step
        rates = ", ".join(f"{b} (|w|·dt = {spin_step[b]:.3g} rad)" for b in bodies)
        super().__init__(
            f"non-finite state at step {step_index} with integrator {integrator!r}, dt = {dt:g} s: {rates}. "
            "Try a smaller dt, more substeps, or another integrator; the state was left at the last finite step."
        )


class DivergenceError(NonFiniteStateError):
    """A step made a body's kinetic energy grow past what its inputs can explain: a blow-up.

    The rule (checked after every step, for every body not stopped): with K the kinetic
    energy, the exact motion obeys ``d√K/dt ≤ |F + m g| / √(2m) + |τ| / √(2 I_min)`` (power
    ``F·v + τ·ω`` with ``|v| ≤ √(2K/m)``, ``|ω| ≤ √(2K/I_min)``; damping only removes energy), so

        √K(t) ≤ B(t) = √K(t0) + Σ_steps (|F + m g| / √(2m) + |τ| / √(2 I_min)) dt
                       + Σ_impulses (|J| / √m + |H| / √I_min) / √2,

    F and τ being the force and torque about the centre of mass each step applied (user and
    scripted wrenches), t0 the last reset or :meth:`Simulator.set_body_state` of the body.
    B² is the most energy the body can physically have; a step that leaves
    ``K > energy_growth_limit · B²`` (scene key ``energy_growth_limit``, default 1e6) is a
    numerical blow-up. A body pushed from rest, or falling, never trips it. Like a
    non-finite state, the step is not applied and the state stays at the last good step; it
    subclasses :class:`NonFiniteStateError` so that code stopping bodies on one stops them on
    both (the node does).

    Attributes
    ----------
    bodies, step_index, integrator, dt, spin_step
        As :class:`NonFiniteStateError`.
    kinetic_energy : dict of str to float
        J, of each failing body after the rejected step.
    energy_bound : dict of str to float
        B², J: the most kinetic energy its initial energy and inputs could give it.
    limit : float
        The energy_growth_limit in force.
    """

    def __init__(self, bodies: tuple[str, ...], step_index: int, integrator: str, dt: float,
                 spin_step: dict[str, float], kinetic_energy: dict[str, float], energy_bound: dict[str, float],
                 limit: float):
        self.bodies = bodies
        self.step_index = step_index
        self.integrator = integrator
        self.dt = dt
        self.spin_step = spin_step
        self.kinetic_energy = kinetic_energy
        self.energy_bound = energy_bound
        self.limit = limit
        details = "; ".join(
            f"{b} (|w|·dt = {spin_step[b]:.3g} rad) has kinetic energy {kinetic_energy[b]:.3g} J, more than "
            f"{limit:g} × {energy_bound[b]:.3g} J, the most its initial energy and the applied wrenches and gravity "
            "could give it"
            for b in bodies
        )
        RuntimeError.__init__(
            self,
            f"energy blow-up at step {step_index} with integrator {integrator!r}, dt = {dt:g} s: {details}. "
            "The integrator is unstable at this |w|·dt: try a smaller dt, more substeps, or another integrator "
            "(exact_rotor_splitting keeps a torque-free body's energy at any |w|·dt; see docs/stability.md); "
            "the state was left at the last step before it.",
        )


class ControlRejectedWarning(RuntimeWarning):
    """A control row (:meth:`Simulator.control`) held a non-finite number at a step: it was skipped whole.

    ``rejected`` : tuple of (body, frame, values) of the rows skipped, ``values`` the six numbers read.
    """

    def __init__(self, rejected: tuple[tuple[str, str, tuple[float, ...]], ...]):
        self.rejected = rejected
        rows = "; ".join(f"{body!r} in {frame!r}: {list(values)}" for body, frame, values in rejected)
        super().__init__(f"control rejected, nothing of it applied (expected 6 finite numbers: force, torque, "
                         f"and a finite wrench from them): {rows}")


@dataclass(frozen=True)
class SiteReadings:
    """Ideal IMU readings at sites (:meth:`Simulator.site_readings`), one row per site.

    Attributes
    ----------
    sites : tuple of str
        ``"<body>/<site>"``.
    specific_force : ndarray, shape (k, 3)
        Acceleration minus gravity, m/s², in the site's axes (the body's axes B, or world).
    angular_velocity : ndarray, shape (k, 3)
        rad/s, in the site's axes.
    orientation_xyzw : ndarray, shape (k, 4)
        Unit quaternion (x, y, z, w) of the site's axes in the world.
    """

    sites: tuple[str, ...]
    specific_force: np.ndarray
    angular_velocity: np.ndarray
    orientation_xyzw: np.ndarray


@dataclass(frozen=True)
class BodyState:
    """One body's state, in the user's conventions.

    Attributes
    ----------
    position_world : ndarray, shape (3,)
        Centre of mass, m, world frame.
    orientation_xyzw : ndarray, shape (4,)
        Unit quaternion (x, y, z, w) of the body frame B in the world (B → W).
    linear_velocity_world : ndarray, shape (3,)
        Centre-of-mass velocity, m/s, world axes.
    linear_velocity_body : ndarray, shape (3,)
        Centre-of-mass velocity, m/s, body axes B.
    angular_velocity_world : ndarray, shape (3,)
        rad/s, world axes.
    angular_velocity_body : ndarray, shape (3,)
        rad/s, body axes B.
    """

    position_world: np.ndarray
    orientation_xyzw: np.ndarray
    linear_velocity_world: np.ndarray
    linear_velocity_body: np.ndarray
    angular_velocity_world: np.ndarray
    angular_velocity_body: np.ndarray


class Simulator:
    """N rigid bodies stepped with a fixed step ``dt`` by a named integrator.

    Parameters
    ----------
    scene : Scene
        From :func:`~rigid_body_sim.core.load_scene`.
    integrator : str
        A key of :data:`~rigid_body_sim.core.INTEGRATORS`.
    dt : float
        Step, s (finite, > 0).
    reference_rtol, reference_atol : float
        Tolerances of the ``reference`` integrator.
    energy_growth_limit : float, optional
        Factor (> 1) of the blow-up check (:class:`DivergenceError`); default the scene's.
    model_reduction : bool
        Give each body the cheapest exact model for what it is and what the scene declares
        (reduction.py; :meth:`body_models` says which and why). False steps every body with the
        integrator, except the declared constraints the full equations cannot make (kinematic,
        planar): the switch for comparing.
    threads : int
        Threads the compiled step may use over the bodies: 0 (default) for every core numba
        may use (``NUMBA_NUM_THREADS``, by default the CPU count), else 1 to that many. The
        step runs in parallel only from ``kernels/parallel.MIN_BODIES`` moving bodies; the
        results are the same to the bit for any count (kernels/parallel.py).
    """

    def __init__(self, scene: Scene, integrator: str = "rk4", dt: float = 0.01, *,
                 reference_rtol: float = 1e-12, reference_atol: float = 1e-12,
                 energy_growth_limit: float | None = None, model_reduction: bool = True, threads: int = 0):
        ensure_kernels()
        self.scene = scene
        self.model = scene.model
        limit = scene.energy_growth_limit if energy_growth_limit is None else energy_growth_limit
        if (isinstance(limit, bool) or not isinstance(limit, (int, float, np.floating, np.integer))
                or not math.isfinite(limit) or limit <= 1.0):
            raise ValueError(f"energy_growth_limit: expected a finite number > 1, got {limit!r}")
        n = self.model.count
        # The buffers of the compiled step (stepping.py; layout.py names their columns): two
        # state buffers (the state is _Ys[_control[CUR]]), per-body parameters, status, step
        # controls and inputs, and the applied wrenches in their frames' terms.
        self._prm = pack_parameters(self.model)
        self._Ys, self._status, self._control, self._inputs = stepping.new_buffers(n)
        self._views = (State.of_rows(self._Ys[0]), State.of_rows(self._Ys[1]))
        self._wrenches = new_wrench_rows(n)
        self._members = np.zeros(0, dtype=np.int64)  # the moving bodies, grouped by model (_replan)
        # Set by cancel() from any thread; the compiled step reads it between steps (it holds no GIL).
        self._cancel = np.zeros(1, dtype=np.int64)
        self._inputs[L.LIMIT] = float(limit)
        self._pending_heads: dict[tuple[str, str], tuple[float, ...]] = {}
        # An applied wrench waits in _inputs[PENDING...] (the one-call fast path); any other goes
        # into _wrenches at once. True while one waits.
        self._pending = False
        self._any_wrench = False  # something is in _wrenches (or pending)
        self._last_wrenches = self._wrenches  # the rows the last step ran with (site_readings)
        self._reference_options = {"rtol": _positive(reference_rtol, "reference_rtol"),
                                   "atol": _positive(reference_atol, "reference_atol")}
        # The scene's scripted wrenches: (frame, force, torque, start, end) per entry, summed into
        # their own rows, which user wrenches never touch, whenever the active set changes.
        self._script = tuple((parse_frame(scene, w.body, w.frame), w.force, w.torque, w.start, w.end)
                             for w in scene.wrenches)
        # --- contact (core/contact): a ContactSolver only when the scene has ground half-spaces and a
        # moving body with a collision shape; None otherwise, and then every step runs exactly the
        # code it ran before contact existed.
        self.contact = None
        if scene.contact is not None and scene.contact.bodies.size:
            from .contact.solver import ContactSolver

            self.contact = ContactSolver(self)
        # --- end contact
        self._method: Method = INTEGRATORS["rk4"]
        self.integrator = integrator
        self.dt = dt
        self._script_wrenches = new_wrench_rows(n)
        self._script_active: tuple[int, ...] = ()
        self._stopped = np.zeros(n, dtype=bool)
        if not isinstance(model_reduction, (bool, np.bool_)):
            raise ValueError(f"model_reduction: expected True or False, got {model_reduction!r}")
        self._reduce = bool(model_reduction)
        self._plans: list[reduction.BodyPlan] | None = None
        # The control array (control()): rows allocated on first use, one per (body, frame) asked for.
        self._control_rows: dict[tuple[str, str], int] = {}
        self._control_table: np.ndarray | None = None  # kernels/controls.py's table
        self._advance, self._advance_tail = stepping.advance, (self._cancel,)
        self._rejected_controls: tuple[tuple[str, str, tuple[float, ...]], ...] = ()
        self._parts = np.zeros((0, 3), dtype=np.int64)  # the parallel step's parts (_replan)
        self._parallel = 0  # threads of the parallel step, 0 for the serial one (_replan)
        # The single-step path (kernels/single_step.py): the buffers' addresses in one block, so that
        # a step(1) of a serial scene is one compiled call of one argument; _single is its ctypes
        # function when the scene allows it (_choose_single), else None.
        from .kernels import single_step  # loaded after ensure_kernels: a cfunc is compiled at import

        self._block, self._block_sizes = single_step.new_block()
        self._block_address = int(self._block.ctypes.data)
        self._single = None
        # The scratch the single-step path lends the compiled step (what stepping.advance allocates per call).
        self._scratch_k = np.empty((stepping.SCRATCH_ROWS, L.ROW_WIDTH))
        self._scratch_deferred = np.empty(0, dtype=np.int64)  # as long as _members (_point_block)
        self._scratch_wrench = np.empty(L.WRENCH_WIDTH)
        self.threads = threads
        self.reset()

    # ----------------------------------------------------------------- copies

    def __getstate__(self) -> dict:
        """For ``copy.deepcopy`` and ``pickle``: everything but what points into this object's own buffers (the
        state views, the single-step block's addresses and its compiled entry), rebuilt by :meth:`__setstate__`."""
        state = self.__dict__.copy()
        for name in ("_views", "_single", "_block_address"):
            del state[name]
        return state

    def __setstate__(self, state: dict) -> None:
        ensure_kernels()  # a copy unpickled in a fresh process steps on a complete cache, as a new Simulator does
        self.__dict__.update(state)
        self._views = (State.of_rows(self._Ys[0]), State.of_rows(self._Ys[1]))
        self._block_address = int(self._block.ctypes.data)
        self._point_block()
        self._choose_single()

    # ----------------------------------------------------------------- configuration

    @property
    def integrator(self) -> str:
        """Name of the integrator in use; setting it validates the name."""
        return self._method.name

    @integrator.setter
    def integrator(self, name: str) -> None:
        method = get_integrator(name)
        self._method = method
        self._control[L.METHOD] = -1 if method.code is None else method.code
        # Scripted wrenches and the numpy/scipy integrators step one step per call (_step_once).
        self._step_by_step = bool(self._script) or method.code is None or self.contact is not None  # contact
        if hasattr(self, "_single"):
            self._choose_single()

    @property
    def threads(self) -> int:
        """Threads the step may use (0: every core numba may use); setting it validates (0 to parallel.max_threads())."""
        return self._threads

    @threads.setter
    def threads(self, value: int) -> None:
        most = parallel.max_threads()
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value <= most:
            raise ValueError(f"threads: expected a whole number from 0 (every core) to {most} (NUMBA_NUM_THREADS), "
                             f"got {value!r}")
        self._threads = int(value)
        if hasattr(self, "_members"):
            self._choose_parallel()

    def _choose_parallel(self) -> None:
        """The parallel step when more than one thread may run and enough bodies move (parallel.MIN_BODIES)."""
        threads = self._threads or parallel.max_threads()
        self._parallel = threads if threads > 1 and len(self._members) >= parallel.MIN_BODIES else 0
        self._choose_single()

    def _choose_single(self) -> None:
        """The single-step path for step(1) when the step is the one serial compiled call (kernels/single_step.py)."""
        from .kernels import single_step

        self._single = None if self._step_by_step or self._parallel else single_step.entry()

    def _point_block(self) -> None:
        """Point the single-step block at the current buffers (after _members or the control table changes)."""
        from .kernels import single_step

        if self._scratch_deferred.shape[0] != self._members.shape[0]:
            self._scratch_deferred = np.empty(self._members.shape[0], dtype=np.int64)
        single_step.fill_block(self._block, self._block_sizes, self._Ys, self._prm, self._wrenches, self._members,
                               self._status, self._control, self._inputs, self._cancel, self._control_table,
                               self._scratch_k, self._scratch_deferred, self._scratch_wrench)

    def _advance_with(self, wrenches: np.ndarray, n: int, cancel: np.ndarray) -> int:
        """stepping.advance of ``n`` steps with ``wrenches``, on the threads _choose_parallel chose; the steps done."""
        if self._parallel:
            return parallel.run_parallel(self._parallel, self._Ys, self._prm, wrenches, self._members, self._status,
                                         self._control, self._inputs, n, cancel, self._parts)
        return stepping.advance(self._Ys, self._prm, wrenches, self._members, self._status, self._control,
                                self._inputs, n, cancel)

    @property
    def energy_growth_limit(self) -> float:
        """The factor of the blow-up check (:class:`DivergenceError`)."""
        return float(self._inputs[L.LIMIT])

    @property
    def dt(self) -> float:
        """Step, s; setting it validates (finite, > 0)."""
        return self._dt

    @dt.setter
    def dt(self, value: float) -> None:
        new_dt = _positive(value, "dt")
        if hasattr(self, "step_count"):
            self._time_origin = self.time
            self._step_origin = self.step_count
        self._dt = new_dt
        self._inputs[L.DT] = new_dt

    @property
    def body_names(self) -> tuple[str, ...]:
        return self.model.names

    def frames_of(self, body: str) -> tuple[str, ...]:
        """Valid frame names for a wrench on ``body``."""
        return self.scene.frames_of(body)

    # ----------------------------------------------------------------- lifecycle

    def reset(self) -> None:
        """Back to the scene's initial state: t = 0, no applied wrench, no stopped body."""
        self.state = self.scene.initial_state
        self._Ys[:, :, L.BOUND] = np.sqrt(kinetic_energy(self.model, self.state))  # √J, see DivergenceError
        self.step_count = 0
        self._time_origin = 0.0
        self._step_origin = 0
        self.clear_wrenches()
        if self._control_table is not None:
            self._control_table[:-1, controls.VALUES:controls.VALUES + 6] = 0.0
        self._stopped[:] = False
        self._replan()
        if self.contact is not None:  # contact: modes from the initial state, events cleared
            self.contact.reset(self)

    def stop_body(self, body: str) -> None:
        """Freeze ``body`` at its current state; it is no longer integrated until :meth:`reset`. With contact it
        leaves the contact too: other bodies pass through it, and those asleep with it wake."""
        b = self._index(body)
        self._stopped[b] = True
        self._replan()
        if self.contact is not None:
            self.contact.body_stopped(b)

    @property
    def model_reduction(self) -> bool:
        """Whether bodies get reduced models (see the constructor); setting it re-derives them."""
        return self._reduce

    @model_reduction.setter
    def model_reduction(self, value: bool) -> None:
        if not isinstance(value, (bool, np.bool_)):
            raise ValueError(f"model_reduction: expected True or False, got {value!r}")
        self._reduce = bool(value)
        self._replan()

    def body_models(self, first: int | None = None) -> list[reduction.BodyPlan]:
        """The model each body gets now and why (reduction.BodyPlan: body, motion, model, code, reason).

        ``first``: only the first that many bodies (what a log lists of 10⁵).
        """
        if first is not None and first < self.model.count:
            return reduction.plan_models(self.model, self._reduce, self._stopped,
                                         self._prm[:, L.MODEL].astype(np.int64), first=first)
        if self._plans is None:
            self._plans = reduction.plan_models(self.model, self._reduce, self._stopped,
                                                self._prm[:, L.MODEL].astype(np.int64))
        return list(self._plans)

    def model_counts(self) -> dict[str, int]:
        """How many bodies each model (reduction.MODEL_NAMES) has now; models no body has are left out."""
        codes, counts = np.unique(self._prm[:, L.MODEL].astype(np.int64), return_counts=True)
        return {reduction.MODEL_NAMES[int(c)]: int(k) for c, k in zip(codes, counts)}

    def _replan(self) -> None:
        """Derive each body's model from the scene, the switch, the stopped bodies and the current state."""
        codes = reduction.model_codes(self.model, self._reduce, self._stopped)
        self._plans = None  # body_models() explains the codes when asked
        self._members, groups = reduction.apply_plan(self._prm, self.model, self.scene.initial_state, self.state,
                                                     codes)
        self._control[L.GROUPS:L.GROUPS + groups.size] = groups.ravel()
        self._parts = parallel.parts_of(groups)
        self._choose_parallel()
        # The buffers of stepping.advance, in its order: one tuple, so a step(1) builds no arguments.
        self._buffers = (self._Ys, self._prm, self._wrenches, self._members, self._status, self._control,
                         self._inputs)
        self._point_block()
        # Bodies that no longer move keep their row in both buffers (the step never writes it).
        cur = self._control[L.CUR]
        self._Ys[1 - cur] = self._Ys[cur]

    @property
    def state(self) -> State:
        """The current state of every body (P frames, (w, x, y, z)).

        A view into the simulator's buffers, valid until the next step: ``copy()`` it to keep
        it. Assigning a :class:`State` copies it in (arrays (N, 3) and (N, 4) as its fields say).
        """
        return self._views[self._control[L.CUR]]

    @state.setter
    def state(self, value: State) -> None:
        rows = value.rows()
        if rows.shape != (self.model.count, L.STATE_WIDTH):
            raise ValueError(f"state: expected {self.model.count} bodies of {L.STATE_WIDTH} numbers, "
                             f"got shape {rows.shape}")
        self._Ys[:, :, :L.STATE_WIDTH] = rows  # both buffers: bodies that do not move are never rewritten

    @property
    def stopped_bodies(self) -> tuple[str, ...]:
        """Names of the bodies frozen by :meth:`stop_body`."""
        return tuple(n for n, s in zip(self.model.names, self._stopped) if s)

    # ----------------------------------------------------------------- inputs

    def apply_wrench(self, body: str, force: Any = (0.0, 0.0, 0.0), torque: Any = (0.0, 0.0, 0.0),
                     frame: str = "world") -> None:
        """Apply force (N) and torque (N·m) about the origin of ``frame``, in ``frame``'s axes.

        The wrench holds for every step of the next :meth:`step` call and is then cleared. It
        is kept in ``frame``'s terms and evaluated wherever the integrator evaluates the
        forces (every stage, kick or iterate), so a wrench in a body-fixed frame turns with the
        body during each step, and one about a world point sees where the centre of mass is.

        Raises
        ------
        ValueError
            Unknown body or frame (the valid ones are listed), or a force/torque that is not 3
            finite numbers. Nothing is applied then.
        """
        head = self._pending_heads.get((body, frame)) if isinstance(body, str) and isinstance(frame, str) else None
        if head is None:
            head = self._pending_head(body, frame)
        fx, fy, fz = _floats3(force, "force")
        tx, ty, tz = _floats3(torque, "torque")
        self._set_pending(head, fx, fy, fz, tx, ty, tz)

    def apply_force_at_point(self, body: str, force: Any, point: Any, frame: str = "world") -> None:
        """Apply force F (N) at point r (m) of ``frame``, both in ``frame``'s axes: the wrench (F, r × F).

        Same rule and errors as :meth:`apply_wrench` (a moment r × F that overflows is refused).
        """
        head = self._pending_heads.get((body, frame)) if isinstance(body, str) and isinstance(frame, str) else None
        if head is None:
            head = self._pending_head(body, frame)
        fx, fy, fz = _floats3(force, "force")
        rx, ry, rz = _floats3(point, "point")
        tx, ty, tz = ry * fz - rz * fy, rz * fx - rx * fz, rx * fy - ry * fx
        if not math.isfinite(tx * 0.0 + ty * 0.0 + tz * 0.0):  # x·0 is 0 for finite x, NaN for ±inf or NaN
            raise ValueError(f"torque: expected 3 finite numbers, got {[tx, ty, tz]!r} (the moment r × F of "
                             f"force {[fx, fy, fz]!r} at point {[rx, ry, rz]!r})")
        self._set_pending(head, fx, fy, fz, tx, ty, tz)

    def _set_pending(self, head: tuple[float, ...], fx: float, fy: float, fz: float, tx: float, ty: float,
                     tz: float) -> None:
        """The hot path of a controller: the wrench waits as the pending one (inputs[PENDING...])
        and the next step's single compiled call adds it; an earlier pending one goes in now.

        The 13 numbers are written with one ``struct.pack_into`` through the array's buffer
        (numpy's documented buffer protocol): 0.25 µs against 0.6 µs for a slice assignment.
        """
        if self._pending:
            self._flush_pending()
        _PENDING_ROW.pack_into(self._inputs, _PENDING_OFFSET, *head, fx, fy, fz, tx, ty, tz)
        self._pending = self._any_wrench = True

    def _pending_head(self, body: str, frame: str) -> tuple[float, ...]:
        """(1, body index, frame kind, arm_P) of a wrench in ``frame`` on ``body``: the first six
        numbers of the pending row, remembered per valid (body, frame)."""
        ref = parse_frame(self.scene, body, frame)  # raises, listing the valid choices
        head = (1.0, float(ref.body_index), float(ref.kind), *map(float, ref.arm_P))
        self._pending_heads[body, frame] = head
        return head

    def _flush_pending(self) -> None:
        """Move the pending wrench into the wrench rows (dropping the last step's spent ones first)."""
        stepping.add_pending(self._wrenches, self._prm, self._inputs)
        self._pending = False

    def control(self, body: str, frame: str = "world") -> np.ndarray:
        """The control row of ``body`` in ``frame``: a numpy view a controller writes, read by every step.

        MuJoCo's ``d.ctrl`` idiom: write the numbers, then :meth:`step`; no call per input.
        Returns an array of shape (6,), float64: force (N, indices 0–2) and torque (N·m, 3–5)
        about the origin of ``frame``, in its axes (the frame rule of :meth:`apply_wrench`).
        The same (body, frame) always gives the same array, zero at first and after
        :meth:`reset`. Each :meth:`step` call reads every row once, at its start, and holds
        the wrench for all its steps, on top of any applied wrench; the values stay until
        written again (a control is a setting, an applied wrench a one-call input).

        Checked inside the compiled step, not here: a row holding a non-finite number, or
        whose wrench would not be finite (a moment that overflows), is skipped whole for
        that step: nothing of it acts on its body, the other rows act. The step then says so
        with a :class:`ControlRejectedWarning` and :attr:`rejected_controls`. The rows of a
        simulator from :meth:`with_scene` are new ones.

        Raises
        ------
        ValueError
            Unknown body or frame (the valid ones are listed).
        """
        row = self._control_rows.get((body, frame)) if isinstance(body, str) and isinstance(frame, str) else None
        if row is None:
            ref = parse_frame(self.scene, body, frame)  # raises, listing the valid choices
            table = self._control_table
            if table is None:
                # One row per distinct (body, frame) a scene allows (world, body, world_aligned, each
                # site), allocated once so that the views handed out stay valid.
                table = self._control_table = controls.new_table(3 * self.model.count + len(self.model.site_names))
                self._advance, self._advance_tail = controls.advance_controlled, (self._cancel, table)
                self._point_block()
            row = int(table[-1, 0])
            table[row, controls.HEAD:controls.REJECTED] = (ref.body_index, ref.kind, *ref.arm_P)
            table[-1, 0] = row + 1
            self._control_rows[body, frame] = row
        return self._control_table[row, controls.VALUES:controls.VALUES + 6]

    @property
    def rejected_controls(self) -> tuple[tuple[str, str, tuple[float, ...]], ...]:
        """The control rows the last :meth:`step` call skipped: (body, frame, the six values read); empty if none."""
        return self._rejected_controls

    def _add_controls(self) -> None:
        """Add the control rows to the wrench rows now (the step-by-step path); report any rejected."""
        self._any_wrench = True
        if controls.add_controls(self._wrenches, self._prm, self._control_table):
            self._report_controls()
        else:
            self._rejected_controls = ()

    def _report_controls(self, stacklevel: int = 3) -> None:
        """Record and warn about the control rows the step skipped (marked in the table)."""
        table = self._control_table
        names = {row: key for key, row in self._control_rows.items()}
        rows = np.flatnonzero(table[:-1, controls.REJECTED])
        self._rejected_controls = tuple((*names[k], tuple(table[k, :6].tolist())) for k in rows)
        warnings.warn(ControlRejectedWarning(self._rejected_controls), stacklevel=stacklevel)

    def apply_impulse(self, body: str, linear: Any = (0.0, 0.0, 0.0), angular: Any = (0.0, 0.0, 0.0),
                      frame: str = "world") -> None:
        """Change velocities at once by a linear impulse (N·s) and an angular impulse (N·m·s).

        Same frame rule as :meth:`apply_wrench`: the angular impulse is about ``frame``'s
        origin, resolved at the current state by the same function as wrenches, and projected
        onto the body's motion (a planar body takes only the spin about its plane normal, with
        the moment of inertia about that normal).
        """
        ref = parse_frame(self.scene, body, frame)
        jx, jy, jz = _floats3(linear, "linear impulse")
        hx, hy, hz = _floats3(angular, "angular impulse")
        b = ref.body_index
        row = np.zeros(L.WRENCH_WIDTH)
        add_wrench(row, self._prm[b], ref.kind, *ref.arm_P, jx, jy, jz, hx, hy, hz)
        Y = self._Ys[self._control[L.CUR]]
        out = np.empty(L.ROW_WIDTH)
        with np.errstate(all="ignore"):
            size_J, size_H = impulse_response(Y[b], self._prm[b], row, out)
        if not np.isfinite(out[:L.STATE_WIDTH]).all():
            raise ValueError(f"impulse on {body!r} would make its velocity non-finite; not applied")
        self._Ys[:, b, L.V:L.W + 3] = out[L.V:L.W + 3]
        self._Ys[:, b, L.BOUND] += size_J * self._prm[b, L.BUDGET_FORCE] + size_H * self._prm[b, L.BUDGET_TORQUE]

    def active_scripted_wrenches(self, time: float | None = None) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
        """The scene's scripted wrenches that act on a step starting at ``time`` (default: now).

        A wrench acts on every step whose start time t satisfies ``start ≤ t < start + duration``
        (edges compared within ``SCRIPT_TIME_TOLERANCE · dt``). Returns (body, frame, force N,
        torque N·m) per active entry, in scene order, as given in the scene (frame rule).
        """
        t = self.time if time is None else float(time)
        return [(w.body, w.frame, w.force.copy(), w.torque.copy())
                for i, w in enumerate(self.scene.wrenches) if i in self._script_indices_at(t)]

    def _script_indices_at(self, t: float) -> tuple[int, ...]:
        tol = SCRIPT_TIME_TOLERANCE * self._dt
        return tuple(i for i, (_ref, _f, _tau, start, end) in enumerate(self._script)
                     if start - tol <= t < end - tol)

    def clear_wrenches(self) -> None:
        """Drop every applied wrench before the next step."""
        self._pending = False
        self._inputs[L.PENDING] = self._inputs[L.SPENT] = 0.0
        if self._any_wrench or self._control_table is not None:  # the controls' wrenches may be in the rows
            stepping.clear_wrenches(self._wrenches)
            self._any_wrench = False

    def set_body_state(self, body: str, position_world: Any = None, orientation_xyzw: Any = None,
                       linear_velocity_world: Any = None, angular_velocity_world: Any = None) -> None:
        """Overwrite parts of one body's state (user conventions, as in :class:`BodyState`)."""
        b = self._index(body)
        state = self.state.copy()
        if position_world is not None:
            state.p_WC_W[b] = _vector3(position_world, "position_world")
        if orientation_xyzw is not None:
            q = np.asarray(orientation_xyzw, dtype=float)
            if q.shape != (4,) or not np.all(np.isfinite(q)):
                raise ValueError(f"orientation_xyzw: expected 4 finite numbers (x, y, z, w), got {orientation_xyzw!r}")
            norm = float(np.linalg.norm(q))
            if abs(norm - 1.0) > ORIENTATION_TOLERANCE:
                raise ValueError(f"orientation_xyzw: expected a unit quaternion, |q| = {norm:.9g}")
            state.q_WP[b] = quat_multiply(quat_wxyz_from_xyzw(q / norm), self.model.q_BP[b])
        if linear_velocity_world is not None:
            state.v_WC_W[b] = _vector3(linear_velocity_world, "linear_velocity_world")
        if angular_velocity_world is not None:
            w_W = _vector3(angular_velocity_world, "angular_velocity_world")
            state.w_WP_P[b] = quat_rotate(quat_conjugate(state.q_WP[b]), w_W)
        self._constrain(b, state)
        if not state.finite_bodies()[b]:
            raise ValueError(f"set_body_state of {body!r}: the new state is not finite; nothing was changed")
        self.state = state
        self._Ys[:, b, L.BOUND] = np.sqrt(kinetic_energy(self.model, state)[b])  # a new start for the bound
        self._replan()
        if self.contact is not None and self.model.motions[b] == "static":
            self.contact.reset(self)  # contact: the static geometry moved; modes anew from the state, as at a reset
        elif self.contact is not None and (position_world is not None or orientation_xyzw is not None):
            self.contact.pose_set(self, b)  # its contact mode anew from its new pose

    def _constrain(self, b: int, state: State) -> None:
        """Keep body b's motion in ``state`` (in place): velocities projected as wrenches are (a
        kinematic body takes its twist as its constant one), a planar body put back on its plane."""
        twist = np.concatenate((state.v_WC_W[b], quat_rotate(state.q_WP[b], state.w_WP_P[b])))
        if self.model.motions[b] != "kinematic":
            project_twist(self._prm[b], twist)
        state.v_WC_W[b] = twist[:3]
        state.w_WP_P[b] = quat_rotate(quat_conjugate(state.q_WP[b]), twist[3:])
        if self.model.motions[b] == "planar":
            n = self._prm[b, L.NORMAL:L.NORMAL + 3]
            state.p_WC_W[b] -= (state.p_WC_W[b] @ n - self._prm[b, L.PLANE_OFFSET]) * n

    def with_scene(self, scene: Scene) -> "Simulator":
        """A simulator of ``scene`` that goes on from this one, for adding and removing bodies at run time.

        The time, step count, integrator, dt, blow-up limit, reduction switch and contact sleeping
        switch and sleep speed carry over (every body awake);
        every body in both scenes (by name) keeps its current pose and twist (in its own frame
        B and world axes, so a redefined body keeps where it is), its energy bound and whether
        it is stopped; bodies new to ``scene`` start at their initial state; bodies not in it
        are gone; each body's contact mode is derived anew from that state, as at a reset. The applied wrenches do
        not carry over. This simulator is unchanged.
        """
        options = self._reference_options
        new = Simulator(scene, self.integrator, self.dt, reference_rtol=options["rtol"], reference_atol=options["atol"],
                        energy_growth_limit=self.energy_growth_limit, model_reduction=self._reduce,
                        threads=self._threads)
        if new.contact is not None and self.contact is not None:
            new.contact.sleeping = self.contact.sleeping
            new.contact.sleep_speed = self.contact.sleep_speed
            new.contact.penetration_tolerance = self.contact.penetration_tolerance
        state = new.state.copy()
        old_state = self.state
        for b, name in enumerate(scene.body_names):
            if name not in self.scene.sites:  # new to the scene: its initial state
                continue
            a = self._index(name)
            q_WB = quat_multiply(old_state.q_WP[a], quat_conjugate(self.model.q_BP[a]))
            state.q_WP[b] = quat_multiply(q_WB, scene.model.q_BP[b])
            state.p_WC_W[b] = old_state.p_WC_W[a]
            state.v_WC_W[b] = old_state.v_WC_W[a]
            state.w_WP_P[b] = quat_rotate(quat_conjugate(state.q_WP[b]), quat_rotate(old_state.q_WP[a],
                                                                                      old_state.w_WP_P[a]))
            new._constrain(b, state)
            new._stopped[b] = self._stopped[a]
        new.state = state
        if new.contact is not None:  # its contact modes anew from the state carried over, not the scene's poses
            new.contact.reset(new)
        bound = np.sqrt(kinetic_energy(new.model, state))
        for b, name in enumerate(scene.body_names):
            if name in self.scene.sites:
                bound[b] = max(bound[b], self._Ys[self._control[L.CUR], self._index(name), L.BOUND])
        new._Ys[:, :, L.BOUND] = bound
        new.step_count = self.step_count
        new._time_origin, new._step_origin = self.time, self.step_count
        new._replan()
        return new

    # ----------------------------------------------------------------- stepping

    def step(self, n: int = 1) -> int:
        """Advance ``n`` steps of ``dt``; applied wrenches hold for all of them, then clear. Returns the steps done.

        Fewer than ``n`` only when :meth:`cancel` stopped it: then the state is the one after
        the steps done, and ``time`` and ``step_count`` count exactly those.

        The scene's scripted wrenches (``Scene.wrenches``) are added at the start of each step
        whose start time lies in their window (see :meth:`active_scripted_wrenches`), on top of
        the applied wrenches; they are part of the scene, so no call is needed for them.

        Raises
        ------
        NonFiniteStateError
            If a step makes any active body's state non-finite. That step is not applied: the
            state stays at the last finite step, ``time`` and ``step_count`` count only the
            steps done, and the applied wrenches are kept so the caller can stop the body
            (:meth:`stop_body`) and step again.
        DivergenceError
            (a NonFiniteStateError) If a step makes a body's kinetic energy exceed
            ``energy_growth_limit`` times the most its initial energy and inputs could give
            it (the rule is in :class:`DivergenceError`); handled the same way.
        """
        single = self._single
        if n == 1 and single is not None and type(n) is int:
            # The single-step path (kernels/single_step.py): stepping.advance, or controls.advance_controlled
            # once a control exists, as below, through one compiled call; it clears the cancel flag.
            done = single(self._block_address)
            if done == 1 and not self._rejected_controls:
                self._pending = False  # advance took the pending wrench
                self.step_count += 1
                self._last_wrenches = self._wrenches
                return 1
            return self._finish_serial(done, 1)
        if type(n) is not int:
            if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
                raise ValueError(f"n: expected a whole number of steps ≥ 0, got {n!r}")
            n = int(n)
        elif n < 0:
            raise ValueError(f"n: expected a whole number of steps ≥ 0, got {n!r}")
        try:
            if self._step_by_step:
                self._flush_pending()
                if self._control_table is not None:
                    self._add_controls()
                done = 0
                while done < n and not self._cancel[0]:
                    self._last_wrenches = self._step_once()
                    done += 1
                self.clear_wrenches()
                return done
            if not n:
                self.clear_wrenches()
                return 0
            if self._parallel:  # the step on several threads (kernels/parallel.py); the controls added first
                if self._control_table is not None:
                    self._flush_pending()
                    self._add_controls()
                done = self._advance_with(self._wrenches, n, self._cancel)
            else:
                # stepping.advance, or controls.advance_controlled once a control exists (control()).
                return self._finish_serial(self._advance(*self._buffers, n, *self._advance_tail), n)
            return self._finish(done, n)
        finally:
            self._cancel[0] = 0

    def _finish_serial(self, done: int, n: int) -> int:
        """After the serial compiled step: report rejected control rows (``done`` < 0 says so), then :meth:`_finish`."""
        if done < 0:  # a control row was rejected (controls.advance_controlled)
            done = -1 - done
            self._report_controls(stacklevel=4)  # the warning names the caller of step()
        elif self._rejected_controls:
            self._rejected_controls = ()
        return self._finish(done, n)

    def _finish(self, done: int, n: int) -> int:
        """Count the ``done`` steps of the compiled step; raise its failure if it stopped at one."""
        self._pending = False  # advance took the pending wrench
        self.step_count += done
        if done != n and self._control[L.OUTCOME]:  # all n done: every step passed its checks
            self._raise_step_failure(int(self._control[L.OUTCOME]))  # the wrenches are kept, for the caller
        self._last_wrenches = self._wrenches  # spent: they stay for the sensors until something new is applied
        return done

    def cancel(self) -> None:
        """Stop the :meth:`step` running in another thread at its next step boundary (or, if none runs, the next one).

        Safe to call from any thread: the compiled step releases the GIL and reads this flag
        between steps, so a long call (many bodies, many steps) returns within one step of it,
        with the steps done applied and counted. The flag is cleared when that step returns.
        """
        self._cancel[0] = 1

    def _step_once(self) -> np.ndarray:
        """One step with the scene's scripted wrenches added, or with a numpy/scipy integrator; its wrench rows."""
        wrenches = self._wrenches_of_this_step()
        if self.contact is not None:  # contact: the force holding bodies at rest is a wrench of this step
            self.contact.add_holding_wrenches(self, wrenches)
            if self.contact.all_asleep(self, wrenches):  # no body moves (all asleep, none pushed): nothing to step
                self._carry_state()
                self.contact.after_asleep_step(self)
                return wrenches
        if self._method.code is not None:
            self._advance_with(wrenches, 1, _NEVER)
            self._inputs[L.SPENT] = 0.0  # ``wrenches`` is this step's own array: nothing to drop before the next
        else:
            bodies = stepping.step_reduced(self._Ys, self._prm, wrenches, self._members, self._status,
                                           self._control, self._inputs)
            cur = self._control[L.CUR]
            if len(bodies):
                with np.errstate(all="ignore"):  # a blow-up is reported as NonFiniteStateError below
                    if self._method.name == "exact_rotor_splitting":
                        step_exact_rotor_splitting(self._Ys[cur], self._Ys[1 - cur], self._prm, wrenches, bodies,
                                                   self._dt)
                    else:
                        step_reference(self._Ys[cur], self._Ys[1 - cur], self._prm, wrenches, bodies, self._dt,
                                       **self._reference_options)
            stepping.check_members(self._Ys, self._prm, wrenches, self._members, self._status, self._control,
                                   self._inputs)
        self.step_count += int(self._control[L.DONE])
        if self._control[L.OUTCOME]:
            self._raise_step_failure(int(self._control[L.OUTCOME]))
        if self.contact is not None:  # contact: events located inside the step; resting bodies projected
            self.contact.after_step(self, wrenches)
        return wrenches

    def _carry_state(self) -> None:
        """A step in which no body moves: the state carried into the other buffer, which becomes the current one
        (as stepping.advance leaves a step done)."""
        cur = self._control[L.CUR]
        self._Ys[1 - cur] = self._Ys[cur]
        self._control[L.CUR] = 1 - cur
        self._control[L.DONE] = 1
        self._control[L.OUTCOME] = L.OK
        self._inputs[L.SPENT] = 0.0
        self.step_count += 1

    def _wrenches_of_this_step(self) -> np.ndarray:
        """The applied plus the scripted wrenches active at the start of this step: a fresh array of rows."""
        if self._script:
            active = self._script_indices_at(self.time)
            if active != self._script_active:
                self._script_wrenches.fill(0.0)
                for i in active:
                    ref, force, torque, _start, _end = self._script[i]
                    add_wrench(self._script_wrenches[ref.body_index], self._prm[ref.body_index], ref.kind,
                               *ref.arm_P, *force, *torque)
                self._script_active = active
            if active:
                return self._wrenches + self._script_wrenches
        return self._wrenches.copy()

    def _raise_step_failure(self, outcome: int) -> None:
        """Raise NonFiniteStateError / DivergenceError for the failed step left in the other buffer."""
        dt = self._dt
        names = self.model.names
        index = np.flatnonzero(self._status == outcome)
        bad = tuple(names[i] for i in index)
        cur = self._control[L.CUR]
        # math.hypot scales internally: |w| of a finite w never overflows (np.linalg.norm can).
        spin = {names[i]: math.hypot(*self._Ys[cur, i, L.W:L.W + 3]) * dt for i in index}
        if outcome == L.NON_FINITE:
            raise NonFiniteStateError(bad, self.step_count, self.integrator, dt, spin)
        failed = self._views[1 - cur]
        with np.errstate(all="ignore"):
            energy = kinetic_energy(self.model, failed)
        raise DivergenceError(
            bad, self.step_count, self.integrator, dt, spin,
            {names[i]: float(energy[i]) for i in index},
            {names[i]: float(self._Ys[1 - cur, i, L.BOUND] ** 2) for i in index},
            self.energy_growth_limit,
        )

    @property
    def time(self) -> float:
        """Simulated time, s, since the last reset: exact multiples of ``dt`` since ``dt`` last changed."""
        return self._time_origin + (self.step_count - self._step_origin) * self._dt

    # ----------------------------------------------------------------- read-outs

    def site_readings(self, sites: Sequence[str] | None = None) -> SiteReadings:
        """What an ideal IMU at each site reads now: specific force and angular velocity, in the site's axes.

        ``sites`` are names ``"<body>/<site>"`` (default: every site of the scene, in scene
        order). The specific force is the site's acceleration minus gravity (REP-145: zero in
        free fall, +g upward at rest), the acceleration that of the body's model at the current
        state under the wrenches of the last :meth:`step` (read right after stepping: applying
        a second wrench, or :meth:`clear_wrenches`, replaces them). See sensors.py.
        """
        model = self.model
        if sites is None:
            index = np.arange(len(model.site_names))
        else:
            names = list(model.site_names)
            try:
                index = np.array([names.index(s) for s in sites], dtype=np.int64)
            except ValueError:
                unknown = [s for s in sites if s not in names]
                raise ValueError(f"unknown site(s) {unknown}; sites are {names}") from None
        out = np.empty((len(index), 10))
        with np.errstate(all="ignore"):
            sensors.site_readings(self._Ys[self._control[L.CUR]], self._prm, self._last_wrenches,
                                  np.asarray(model.gravity_W, dtype=float), np.asarray(model.site_body, np.int64)[index],
                                  np.ascontiguousarray(model.site_p_P[index], dtype=float),
                                  np.asarray(model.site_world_axes, dtype=np.bool_)[index], out)
        return SiteReadings(tuple(model.site_names[i] for i in index), out[:, 0:3], out[:, 3:6],
                            quat_xyzw_from_wxyz(out[:, 6:10]))


    def body_state(self, body: str) -> BodyState:
        """The state of ``body`` in the user's conventions (see :class:`BodyState`)."""
        b = self._index(body)
        q_WP = self.state.q_WP[b]
        w_P = self.state.w_WP_P[b]
        q_WB = quat_multiply(q_WP, quat_conjugate(self.model.q_BP[b]))
        return BodyState(
            position_world=self.state.p_WC_W[b].copy(),
            orientation_xyzw=quat_xyzw_from_wxyz(q_WB),
            linear_velocity_world=self.state.v_WC_W[b].copy(),
            linear_velocity_body=quat_rotate(quat_conjugate(q_WB), self.state.v_WC_W[b]),
            angular_velocity_world=quat_rotate(q_WP, w_P),
            angular_velocity_body=quat_rotate(self.model.q_BP[b], w_P),
        )

    def positions_world(self) -> np.ndarray:
        """Centre-of-mass positions, m, world frame, shape (N, 3) (a copy)."""
        return self.state.p_WC_W.copy()

    def orientations_xyzw(self) -> np.ndarray:
        """Body-frame orientations (x, y, z, w), B → W, shape (N, 4)."""
        return quat_xyzw_from_wxyz(quat_multiply(self.state.q_WP, quat_conjugate(self.model.q_BP)))

    def linear_velocities_world(self) -> np.ndarray:
        """Centre-of-mass velocities, m/s, world axes, shape (N, 3) (a copy)."""
        return self.state.v_WC_W.copy()

    def angular_velocities_world(self) -> np.ndarray:
        """Angular velocities, rad/s, world axes, shape (N, 3)."""
        return quat_rotate(self.state.q_WP, self.state.w_WP_P)

    def angular_velocities_body(self) -> np.ndarray:
        """Angular velocities, rad/s, body axes B, shape (N, 3)."""
        return quat_rotate(self.model.q_BP, self.state.w_WP_P)

    def pose_twist_rows(self, poses: np.ndarray, twists: np.ndarray) -> np.ndarray:
        """Every body's pose and twist in one compiled pass, into the caller's arrays; returns which are finite.

        ``poses`` : float64 (N, k ≥ 7), C order: columns 0–6 get (x, y, z, qx, qy, qz, qw), the
        centre of mass (m) and body frame B in the world. ``twists`` : float64 (N, k ≥ 6): columns
        0–5 get the linear (m/s) and angular (rad/s) velocity in world axes; other columns are
        left as they are. Bitwise what positions_world, orientations_xyzw,
        linear_velocities_world and angular_velocities_world give. Returns (N,) bool: True
        where all of the body's state is finite (State.finite_bodies).
        """
        finite = np.empty(self.model.count, dtype=np.bool_)
        pose_twist_rows(self._Ys[self._control[L.CUR]], self.model.q_BP, poses, twists, finite)
        return finite

    def kinetic_energy(self) -> np.ndarray:
        """Kinetic energy per body, J, shape (N,)."""
        return kinetic_energy(self.model, self.state)

    def potential_energy(self) -> np.ndarray:
        """Gravitational potential energy per body, J, shape (N,) (zero at the world origin)."""
        return potential_energy(self.model, self.state)

    def linear_momentum(self) -> np.ndarray:
        """Linear momentum per body, kg·m/s, world axes, shape (N, 3)."""
        return linear_momentum_W(self.model, self.state)

    def angular_momentum(self, about_origin: bool = False) -> np.ndarray:
        """Angular momentum per body, kg·m²/s, world axes, shape (N, 3); about the COM unless ``about_origin``."""
        return angular_momentum_W(self.model, self.state, about_origin)

    def _index(self, body: str) -> int:
        try:
            return self.model.names.index(body)
        except ValueError:
            raise ValueError(f"unknown body {body!r}; bodies are {list(self.model.names)}") from None


#: The cancel flag of a single step taken on its own (Simulator._step_once checks the real one between steps).
_NEVER = np.zeros(1, dtype=np.int64)


def _positive(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
    x = float(value)
    if not math.isfinite(x) or x <= 0.0:
        raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
    return x


_PLAIN_NUMBERS = (float, int)
_FLOAT64 = np.dtype(np.float64)
#: inputs[PENDING:INPUT_WIDTH] as raw float64s (native order), and its byte offset.
_PENDING_ROW = struct.Struct(f"={L.INPUT_WIDTH - L.PENDING}d")
_PENDING_OFFSET = L.PENDING * 8


def _floats3(value: Any, name: str) -> tuple[float, float, float]:
    """Three finite floats (the fast path of :func:`_vector3`); ValueError naming ``name`` otherwise."""
    if type(value) is np.ndarray and value.dtype is _FLOAT64 and value.shape == (3,):
        x, y, z = value.tolist()
    elif (type(value) in (list, tuple) and len(value) == 3 and type(value[0]) in _PLAIN_NUMBERS
          and type(value[1]) in _PLAIN_NUMBERS and type(value[2]) in _PLAIN_NUMBERS):
        x, y, z = float(value[0]), float(value[1]), float(value[2])
    else:
        return tuple(_vector3(value, name).tolist())
    if not math.isfinite(x * 0.0 + y * 0.0 + z * 0.0):  # x·0 is 0 for finite x, NaN for ±inf or NaN
        raise ValueError(f"{name}: expected 3 finite numbers, got {value!r}")
    return x, y, z


def _vector3(value: Any, name: str) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected 3 finite numbers, got {value!r}") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: expected 3 finite numbers, got {value!r}")
    return v


_kernels_ready = False


def ensure_kernels() -> None:
    """Once per process, before its first Simulator steps: if the kernel cache is not complete
    for these sources, compile every kernel into it (:func:`compile_kernels`), under the cache's
    lock, so that processes starting together on a cold cache compile once and never interleave
    their writes (kernels/jit.py, cache_lock)."""
    global _kernels_ready
    if _kernels_ready:
        return
    _kernels_ready = True
    with cache_lock():
        if not cache_complete():
            compile_kernels()


def compile_kernels() -> None:
    """Compile (or load from numba's cache) every compiled kernel: the stepping entry points
    (:func:`~rigid_body_sim.core.kernels.compile.compile_kernels`), then the contact kernels, by
    dropping one body of each shape onto a ground until it rests, then the body–body kernels
    (:func:`~rigid_body_sim.core.contact.compile_pairs.compile_pair_kernels`) (``make venv`` and
    the node's first start call this). Runs under the cache's lock and marks the cache complete.

    Raises
    ------
    RuntimeError
        If the kernel sources changed on disk since this process imported them: its machine
        code would be cached under the new sources' name.
    """
    global _kernels_ready
    _kernels_ready = True
    with cache_lock():
        if not sources_unchanged():
            raise RuntimeError("the kernel sources (rigid_body_sim/core/kernels) changed since this process started; "
                               "start it again to compile the new ones")
        _compile_all()
        mark_cache_complete()


def _compile_all() -> None:
    compile_stepping_kernels()
    parallel.compile_parallel()  # the step over bodies on several threads (kernels/parallel.py)
    shapes = {"sphere": {"inertia": {"sphere": 0.1}},
              "box": {"inertia": {"box": [0.2, 0.2, 0.1]}},
              "cylinder": {"inertia": {"cylinder": [0.1, 0.2]}},
              "capsule": {"inertia": {"sphere": 0.1}, "collision": {"capsule": [0.05, 0.1]}}}
    bodies = {name: {"mass": 1.0, **spec, "pose": {"position": [float(k), 0.0, 0.4]},
                     "twist": {"linear": [0.5, 0.0, 0.0], "angular": [0.3, 0.2, 0.1]}}
              for k, (name, spec) in enumerate(shapes.items())}
    from .scene import load_scene

    scene = load_scene({"gravity": [0.0, 0.0, -9.81], "bodies": bodies,
                        "ground": [{"normal": [0.0, 0.0, 1.0], "offset": 0.0,
                                    "material": {"restitution": 0.5, "friction": 0.5}}]})
    # a static shape as geometry (contact/static_geometry.py): a ball and a crate onto a static table
    table = load_scene({"gravity": [0.0, 0.0, -9.81],
                        "ground": [{"normal": [0.0, 0.0, 1.0], "offset": 0.0}],
                        "bodies": {"table": {"mass": 20.0, "inertia": {"box": [1.0, 1.0, 0.5]}, "motion": "static",
                                             "pose": {"position": [0.0, 0.0, 0.25]}},
                                   "ball": {"mass": 1.0, "inertia": {"sphere": 0.1},
                                            "material": {"restitution": 0.5, "friction": 0.3},
                                            "pose": {"position": [-0.2, 0.0, 1.1]}},
                                   "crate": {"mass": 2.0, "inertia": {"box": [0.2, 0.2, 0.2]},
                                             "pose": {"position": [0.25, 0.1, 0.7]}}}})
    # islands (contact/island.py): a box resting on a box, stepped together by one compiled call
    cube = {"mass": 1.0, "inertia": {"box": [0.2, 0.2, 0.2]}}
    stack = load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0.0, 0.0, 1.0], "offset": 0.0}],
                        "bodies": {"low": {**cube, "pose": {"position": [0.0, 0.0, 0.1]}},
                                   "high": {**cube, "pose": {"position": [0.0, 0.0, 0.3]}}}})
    for integrator in ("rk4", "euler", "semi_implicit_euler"):  # with the contact found per stage, and held
        Simulator(scene, integrator=integrator, dt=0.01).step(200)
        Simulator(table, integrator=integrator, dt=0.01).step(150)
    resting = Simulator(stack, integrator="rk4", dt=0.01)
    resting.step(5)
    resting.contact.sleeping = True  # then the check of a scene wholly asleep
    resting.step(30)
    from .kernels.contact.stage import held_derivatives

    one = Simulator(scene, integrator="rk4", dt=0.01)  # reference's right-hand side (core/integrators.py)
    held_derivatives(one._Ys[0][:, :L.STATE_WIDTH].copy(), one._prm, one._wrenches, np.empty((len(one._prm), L.STATE_WIDTH)))
    from .contact.compile_pairs import compile_pair_kernels

    compile_pair_kernels()  # body–body geometry (the scene loader's overlap check) and the pair impact
