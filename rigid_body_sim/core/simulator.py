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

import functools
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .dynamics import (
    angular_momentum_W,
    kinetic_energy,
    linear_momentum_W,
    potential_energy,
)
from . import kernels, reduction
from .forces import FrameKind, FrameRef, WrenchAccumulator, parse_frame
from .integrators import INTEGRATORS, Integrator, get_integrator, step_reference
from .model import State
from .quaternion import (
    quat_conjugate,
    quat_multiply,
    quat_rotate,
    quat_wxyz_from_xyzw,
    quat_xyzw_from_wxyz,
)
from .scene import ORIENTATION_TOLERANCE, Scene

__all__ = ["Simulator", "BodyState", "NonFiniteStateError", "DivergenceError", "SCRIPT_TIME_TOLERANCE"]

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
    """

    def __init__(self, scene: Scene, integrator: str = "rk4", dt: float = 0.01, *,
                 reference_rtol: float = 1e-12, reference_atol: float = 1e-12,
                 energy_growth_limit: float | None = None, model_reduction: bool = True):
        self.scene = scene
        self.model = scene.model
        limit = scene.energy_growth_limit if energy_growth_limit is None else energy_growth_limit
        if (isinstance(limit, bool) or not isinstance(limit, (int, float, np.floating, np.integer))
                or not math.isfinite(limit) or limit <= 1.0):
            raise ValueError(f"energy_growth_limit: expected a finite number > 1, got {limit!r}")
        self.energy_growth_limit = float(limit)
        # Per-body constants of the kernels (kernels.py): mass properties, gravity, damping, the
        # energy bound's 1/√(2m) and 1/√(2 I_min) (DivergenceError), each body's reduced model.
        self._prm = kernels.pack_parameters(self.model)
        self._budget_per_force = self._prm[:, kernels.BUDGET_FORCE]
        self._budget_per_torque = self._prm[:, kernels.BUDGET_TORQUE]
        n = self.model.count
        # The state lives in one (N, 13) array of rows (p, q, v, w), stepped in place; ``state``
        # views it. Scratch of the kernels: the next step, the resolved wrench, the bound, status.
        # Two buffers: the state is Ys[cur]; a step writes Ys[1 - cur] and, if it passes, flips cur.
        self._Ys = np.zeros((2, n, kernels.STATE_WIDTH))
        self._cur = 0
        self._views = (State.of_rows(self._Ys[0]), State.of_rows(self._Ys[1]))
        self._members = np.zeros(0, dtype=np.int64)  # the moving bodies, grouped by model (_replan)
        self._first = 0  # how many of them, first, the integrator steps (model full)
        self._wrench_W = np.zeros((n, 6))
        # The energy bound √J (see DivergenceError) in two buffers like the state, and each body's status.
        self._aux = np.zeros((3, n))
        self._status = self._aux[2]
        self._wrenches = WrenchAccumulator(self.model)
        self._frame_refs: dict[tuple[str, str], FrameRef] = {}
        # (body, force column, torque column) of the buckets, per frame whose wrench can be pending.
        self._pending_columns: dict[FrameRef, tuple[int, int, int]] = {}
        # One applied wrench waits here, (body, force column, torque column, fx, fy, fz, tx, ty, tz)
        # of the buckets, until the next step hands it to the kernel or another wrench arrives.
        self._pending: tuple | None = None
        # q_PB per body as floats, None where P = B (the usual case): body-frame wrenches.
        self._q_PB = [None if np.array_equal(q, (1.0, 0.0, 0.0, 0.0)) else tuple(quat_conjugate(q).tolist())
                      for q in self.model.q_BP]
        self._reference_options = {"rtol": _positive(reference_rtol, "reference_rtol"),
                                   "atol": _positive(reference_atol, "reference_atol")}
        self._integrator_name = ""
        self._step_function: Integrator = INTEGRATORS["rk4"]
        self._method: int | None = kernels.METHODS["rk4"]  # kernel method number; None: numpy/scipy path
        self.integrator = integrator
        self._dt = _positive(dt, "dt")
        # The scene's scripted wrenches: (frame, force, torque, start, end) per entry, applied at
        # the start of every step from their own accumulator, which user wrenches never touch.
        self._script = tuple((parse_frame(scene, w.body, w.frame), w.force, w.torque, w.start, w.end)
                             for w in scene.wrenches)
        self._script_wrenches = WrenchAccumulator(self.model)
        self._script_active: tuple[int, ...] = ()
        self._stopped = np.zeros(self.model.count, dtype=bool)
        if not isinstance(model_reduction, (bool, np.bool_)):
            raise ValueError(f"model_reduction: expected True or False, got {model_reduction!r}")
        self._reduce = bool(model_reduction)
        self._plans: list[reduction.BodyPlan] = []
        self.reset()

    # ----------------------------------------------------------------- configuration

    @property
    def integrator(self) -> str:
        """Name of the integrator in use; setting it validates the name."""
        return self._integrator_name

    @integrator.setter
    def integrator(self, name: str) -> None:
        function = get_integrator(name)
        if function is step_reference:
            function = functools.partial(step_reference, **self._reference_options)
        self._step_function = function
        self._method = kernels.METHODS.get(name)
        if self._method is not None:
            # kernels.advance compiled for this method and exactly these arrays, called without
            # numba's per-call type dispatch.
            self._advance = kernels.entry_point(
                kernels.advance, self._method, self._Ys, 0, self._prm, self._members, 0, self._wrenches.buckets,
                self._wrenches.sites, self._aux, False, 0, 1.0, 2.0, -1, 0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        self._integrator_name = name

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
        self._aux[0:2] = np.sqrt(kinetic_energy(self.model, self.state))  # √J, see DivergenceError
        self.step_count = 0
        self._time_origin = 0.0
        self._step_origin = 0
        self.clear_wrenches()
        self._stopped[:] = False
        self._replan()

    def stop_body(self, body: str) -> None:
        """Freeze ``body`` at its current state; it is no longer integrated until :meth:`reset`."""
        b = self._index(body)
        self._stopped[b] = True
        self._replan()

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

    def body_models(self) -> list[reduction.BodyPlan]:
        """The model each body gets now and why (reduction.BodyPlan: body, motion, model, code, reason)."""
        return list(self._plans)

    def _replan(self) -> None:
        """Derive each body's model from the scene, the switch, the stopped bodies and the current state."""
        self._plans = reduction.plan_models(self.model, self._reduce, self._stopped)
        self._members, self._first = reduction.apply_plan(self._prm, self.model, self.scene.initial_state, self.state,
                                                          self._plans)
        # Bodies that no longer move keep their row in both buffers (the kernels never write it).
        cur = self._cur
        self._Ys[1 - cur] = self._Ys[cur]
        self._aux[1 - cur] = self._aux[cur]

    @property
    def state(self) -> State:
        """The current state of every body (P frames, (w, x, y, z)).

        A view into the simulator's buffers, valid until the next step: ``copy()`` it to keep
        it. Assigning a :class:`State` copies it in (arrays (N, 3) and (N, 4) as its fields say).
        """
        return self._views[self._cur]

    @state.setter
    def state(self, value: State) -> None:
        rows = value.rows()
        if rows.shape != self._Ys.shape[1:]:
            raise ValueError(f"state: expected {self._Ys.shape[1]} bodies of 13 numbers, got shape {rows.shape}")
        self._Ys[:] = rows  # both buffers: bodies that do not move are never rewritten

    @property
    def stopped_bodies(self) -> tuple[str, ...]:
        """Names of the bodies frozen by :meth:`stop_body`."""
        return tuple(n for n, s in zip(self.model.names, self._stopped) if s)

    # ----------------------------------------------------------------- inputs

    def apply_wrench(self, body: str, force: Any = (0.0, 0.0, 0.0), torque: Any = (0.0, 0.0, 0.0),
                     frame: str = "world") -> None:
        """Apply force (N) and torque (N·m) about the origin of ``frame``, in ``frame``'s axes.

        The wrench holds for every step of the next :meth:`step` call (re-resolved at the start
        of each, so body-fixed frames follow the body) and is then cleared.

        Raises
        ------
        ValueError
            Unknown body or frame (the valid ones are listed), or a force/torque that is not 3
            finite numbers. Nothing is applied then.
        """
        ref = self._frame_ref(body, frame)
        fx, fy, fz = _floats3(force, "force")
        tx, ty, tz = _floats3(torque, "torque")
        self._add_wrench(ref, fx, fy, fz, tx, ty, tz)

    def apply_force_at_point(self, body: str, force: Any, point: Any, frame: str = "world") -> None:
        """Apply force F (N) at point r (m) of ``frame``, both in ``frame``'s axes: the wrench (F, r × F).

        Same rule and errors as :meth:`apply_wrench` (a moment r × F that overflows is refused).
        """
        # The hot path of a controller: kept flat (see _add_wrench for what it does).
        try:
            ref = self._frame_refs[body, frame]
        except (KeyError, TypeError):
            ref = self._frame_ref(body, frame)
        fx, fy, fz = _floats3(force, "force")
        rx, ry, rz = _floats3(point, "point")
        tx, ty, tz = ry * fz - rz * fy, rz * fx - rx * fz, rx * fy - ry * fx
        if not (math.isfinite(tx) and math.isfinite(ty) and math.isfinite(tz)):
            raise ValueError(f"torque: expected 3 finite numbers, got {[tx, ty, tz]!r} (the moment r × F of "
                             f"force {[fx, fy, fz]!r} at point {[rx, ry, rz]!r})")
        columns = self._pending_columns.get(ref)
        if columns is None or self._pending is not None:
            self._add_wrench(ref, fx, fy, fz, tx, ty, tz)
        else:
            self._pending = (columns[0], columns[1], columns[2], fx, fy, fz, tx, ty, tz)

    def _frame_ref(self, body: str, frame: str) -> FrameRef:
        """parse_frame, remembered per (body, frame) (only valid pairs are remembered)."""
        try:
            return self._frame_refs[body, frame]
        except (KeyError, TypeError):
            ref = parse_frame(self.scene, body, frame)  # raises, listing the valid choices
            self._frame_refs[body, frame] = ref
            kind, b = ref.kind, ref.body_index
            if kind is FrameKind.BODY and self._q_PB[b] is None:
                self._pending_columns[ref] = (b, 12, 15)
            elif kind is FrameKind.WORLD:
                self._pending_columns[ref] = (b, 0, 3)
            elif kind is FrameKind.WORLD_ALIGNED:
                self._pending_columns[ref] = (b, 6, 9)
            return ref

    def _add_wrench(self, ref: FrameRef, fx: float, fy: float, fz: float, tx: float, ty: float, tz: float) -> None:
        """Accumulate a validated wrench: world, world-aligned and body frames (P = B) wait as
        the pending wrench of the next step; other frames go through WrenchAccumulator.add."""
        self._flush_pending()
        columns = self._pending_columns.get(ref)
        if columns is None:
            self._wrenches.add(ref, np.array((fx, fy, fz)), np.array((tx, ty, tz)))
        else:
            self._pending = (columns[0], columns[1], columns[2], fx, fy, fz, tx, ty, tz)

    def _flush_pending(self) -> None:
        """Move the pending wrench into the accumulator."""
        if self._pending is not None:
            kernels.add_wrench(self._wrenches.buckets, *self._pending)
            self._wrenches.empty = False
            self._pending = None

    def apply_impulse(self, body: str, linear: Any = (0.0, 0.0, 0.0), angular: Any = (0.0, 0.0, 0.0),
                      frame: str = "world") -> None:
        """Change velocities at once by a linear impulse (N·s) and an angular impulse (N·m·s).

        Same frame rule as :meth:`apply_wrench`: the angular impulse is about ``frame``'s origin.
        """
        ref = self._frame_ref(body, frame)
        J = _vector3(linear, "linear impulse")
        H = _vector3(angular, "angular impulse")
        single = WrenchAccumulator(self.model)
        single.add(ref, J, H)
        J_W, H_W = single.resolve(self.state)
        b = ref.body_index
        impulse = np.concatenate((J_W[b], H_W[b]))
        kernels.project_wrench(self._prm[b], impulse)  # onto the body's motion
        J_W[b], H_W[b] = impulse[:3], impulse[3:]
        state = self.state.copy()
        state.v_WC_W[b] += J_W[b] / self.model.mass[b]
        state.w_WP_P[b] += quat_rotate(quat_conjugate(state.q_WP[b]), H_W[b]) / self.model.inertia_P[b]
        if not state.finite_bodies()[b]:
            raise ValueError(f"impulse on {body!r} would make its velocity non-finite; not applied")
        self.state = state
        self._aux[0:2, b] += (math.hypot(*J_W[b]) * self._budget_per_force[b]
                                   + math.hypot(*H_W[b]) * self._budget_per_torque[b])

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
        self._pending = None
        self._wrenches.clear()

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
        # Keep the body's motion: velocities projected as wrenches are (a kinematic body takes
        # the new twist as its constant one), a planar body's position onto its plane.
        twist = np.concatenate((state.v_WC_W[b], quat_rotate(state.q_WP[b], state.w_WP_P[b])))
        if self.model.motions[b] != "kinematic":
            kernels.project_wrench(self._prm[b], twist)
        state.v_WC_W[b] = twist[:3]
        state.w_WP_P[b] = quat_rotate(quat_conjugate(state.q_WP[b]), twist[3:])
        if self.model.motions[b] == "planar":
            n = self._prm[b, kernels.NORMAL:kernels.NORMAL + 3]
            state.p_WC_W[b] -= (state.p_WC_W[b] @ n - self._prm[b, kernels.PLANE_OFFSET]) * n
        self.state = state
        self._aux[0:2, b] = np.sqrt(kinetic_energy(self.model, state)[b])  # a new start for the bound
        self._replan()

    # ----------------------------------------------------------------- stepping

    def step(self, n: int = 1) -> None:
        """Advance ``n`` steps of ``dt``; applied wrenches hold for all of them, then clear.

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
        if type(n) is not int:
            if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
                raise ValueError(f"n: expected a whole number of steps ≥ 0, got {n!r}")
            n = int(n)
        elif n < 0:
            raise ValueError(f"n: expected a whole number of steps ≥ 0, got {n!r}")
        if self._script or self._method is None:
            for _ in range(n):
                self._step_once()
            self.clear_wrenches()
            return
        if not n:
            self.clear_wrenches()
            return
        wrenches = self._wrenches
        pending = self._pending
        if pending is None:
            done, outcome, self._cur = self._advance(
                self._method, self._Ys, self._cur, self._prm, self._members, self._first, wrenches.buckets,
                wrenches.sites, self._aux, not wrenches.empty, n, self._dt, self.energy_growth_limit,
                -1, 0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        else:
            self._pending = None
            done, outcome, self._cur = self._advance(
                self._method, self._Ys, self._cur, self._prm, self._members, self._first, wrenches.buckets,
                wrenches.sites, self._aux, not wrenches.empty, n, self._dt, self.energy_growth_limit,
                pending[0], pending[1], pending[2], pending[3], pending[4], pending[5], pending[6], pending[7],
                pending[8])
        self.step_count += done
        if outcome:
            wrenches.empty = wrenches.empty and pending is None  # the kernel kept them, pending one included
            self._raise_step_failure(outcome)
        wrenches.empty = True  # the kernel cleared them

    def _step_once(self) -> None:
        """One step with the scene's scripted wrenches added, or with a numpy/scipy integrator."""
        self._flush_pending()
        buckets, sites, has_wrench = self._wrenches_of_this_step()
        if self._method is not None:
            if buckets is self._wrenches.buckets or buckets is self._script_wrenches.buckets:
                # advance clears the buckets it is given: these must last all n steps (the script, its window)
                buckets, sites = buckets.copy(), sites.copy()
            done, outcome, self._cur = self._advance(
                self._method, self._Ys, self._cur, self._prm, self._members, self._first, buckets, sites, self._aux,
                has_wrench, 1, self._dt, self.energy_growth_limit, -1, 0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
            self.step_count += done
            if outcome:
                self._raise_step_failure(outcome)
            return
        wrench = self._wrench_W
        cur, nxt = self._cur, 1 - self._cur
        Y, Y_next = self._Ys[cur], self._Ys[nxt]
        if has_wrench:
            kernels.resolve_wrenches(Y, self._prm, buckets, sites, wrench)
        else:
            wrench.fill(0.0)
        force_W, torque_W = wrench[:, 0:3], wrench[:, 3:6]
        dt = self._dt
        members = self._members
        # The reduced models step in the kernels; the integrator takes the rest (model full,
        # and isotropic/symmetric bodies under a torque this step).
        fallback = kernels.step_reduced(Y, Y_next, self._prm, wrench, members, self._first, dt)
        full = np.concatenate((members[:self._first], fallback))
        # Overflow on the way to a non-finite state is reported as NonFiniteStateError below,
        # not as a floating-point warning from wherever it first happened.
        with np.errstate(all="ignore"):
            if len(full):
                # Each body's gravity as its motion allows (projected, in the kernels' parameters).
                sub_model = replace(self.model.subset(full),
                                    gravity_W=self._prm[full, kernels.GRAVITY:kernels.GRAVITY + 3].copy())
                sub = self._step_function(sub_model, self.state.take(full), force_W[full], torque_W[full], dt)
                Y_next[full] = sub.rows()
        outcome = kernels.check_step(Y_next, self._prm, wrench, has_wrench, self._aux[cur], self._aux[nxt],
                                     self._status, members, dt, self.energy_growth_limit)
        if outcome:
            self._raise_step_failure(outcome)
        self._cur = nxt
        self.step_count += 1

    def _raise_step_failure(self, outcome: int) -> None:
        """Raise NonFiniteStateError / DivergenceError for the failed step left in the kernels' scratch."""
        dt = self._dt
        names = self.model.names
        index = np.flatnonzero(self._status == outcome)
        bad = tuple(names[i] for i in index)
        # math.hypot scales internally: |w| of a finite w never overflows (np.linalg.norm can).
        spin = {names[i]: math.hypot(*self._Ys[self._cur, i, 10:13]) * dt for i in index}
        if outcome == kernels.NON_FINITE:
            raise NonFiniteStateError(bad, self.step_count, self._integrator_name, dt, spin)
        failed = self._views[1 - self._cur]
        with np.errstate(all="ignore"):
            energy = kinetic_energy(self.model, failed)
        raise DivergenceError(
            bad, self.step_count, self._integrator_name, dt, spin,
            {names[i]: float(energy[i]) for i in index},
            {names[i]: float(self._aux[1 - self._cur, i] ** 2) for i in index},
            self.energy_growth_limit,
        )

    def _wrenches_of_this_step(self) -> tuple[np.ndarray, np.ndarray, bool]:
        """(buckets, sites, any) of the applied plus the scripted wrenches active at the start of this step."""
        user = self._wrenches
        if self._script:
            active = self._script_indices_at(self.time)
            if active != self._script_active:
                self._script_wrenches.clear()
                for i in active:
                    ref, force, torque, _start, _end = self._script[i]
                    self._script_wrenches.add(ref, force, torque)
                self._script_active = active
            script = self._script_wrenches
            if not script.empty:
                if user.empty:
                    return script.buckets, script.sites, True
                sites = user.sites.copy()
                sites[:, 4:7] += script.site_force_W
                return user.buckets + script.buckets, sites, True
        return user.buckets, user.sites, not user.empty

    @property
    def time(self) -> float:
        """Simulated time, s, since the last reset: exact multiples of ``dt`` since ``dt`` last changed."""
        return self._time_origin + (self.step_count - self._step_origin) * self._dt

    # ----------------------------------------------------------------- read-outs

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


def _positive(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
    x = float(value)
    if not math.isfinite(x) or x <= 0.0:
        raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
    return x


_PLAIN_NUMBERS = (float, int)


def _floats3(value: Any, name: str) -> tuple[float, float, float]:
    """Three finite floats (the fast path of :func:`_vector3`); ValueError naming ``name`` otherwise."""
    if type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (3,):
        x, y, z = value.tolist()
    elif (type(value) in (list, tuple) and len(value) == 3 and type(value[0]) in _PLAIN_NUMBERS
          and type(value[1]) in _PLAIN_NUMBERS and type(value[2]) in _PLAIN_NUMBERS):
        x, y, z = float(value[0]), float(value[1]), float(value[2])
    else:
        return tuple(_vector3(value, name).tolist())
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
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


def compile_kernels() -> None:
    """Compile (or load from numba's cache) every kernel a Simulator uses: ~1 min once per checkout.

    ``make venv`` runs it, so that neither the first node start nor the first test pays it.
    Steps a scene with a body of every model, with and without a wrench, with every integrator.
    """
    from .scene import load_scene

    def spec(inertia: dict, motion: str = "free", **twist: list) -> dict:
        return {"mass": 1.0, "inertia": inertia, "motion": motion, "twist": twist,
                "sites": {"s": {"position": [0.1, 0.0, 0.0], "axes": "world"}}}

    box = {"box": [1.0, 0.6, 0.4]}
    scene = load_scene({"gravity": [0.0, 0.0, -9.81], "bodies": {
        "full": spec(box, angular=[0.3, 1.0, 0.2]), "ball": spec({"sphere": 0.1}, angular=[1.0, 0.0, 0.0]),
        "can": spec({"cylinder": [0.1, 0.5]}, angular=[1.0, 0.0, 3.0]), "wall": spec(box, "static"),
        "belt": spec(box, "kinematic", linear=[1.0, 0.0, 0.0]), "puck": spec(box, "planar"),
        "sat": spec(box, "rotation_only"), "cart": spec(box, "translation_only")}})
    for name in INTEGRATORS:
        sim = Simulator(scene, integrator=name, dt=0.01)
        sim.step(1)
        sim.apply_force_at_point("full", [0.0, 1.0, 0.0], [0.5, 0.3, 0.0], frame="full")
        sim.apply_wrench("ball", torque=[0.0, 0.0, 0.1], frame="ball/s")
        sim.step(2)
        sim.apply_impulse("can", linear=[0.1, 0.0, 0.0])
