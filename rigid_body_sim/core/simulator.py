"""The public simulator: a scene, an integrator, a step, applied wrenches and state read-outs.

Typical use::

    from rigid_body_sim.core import Simulator, load_scene

    sim = Simulator(load_scene("config/default_scene.yaml"), integrator="rk4", dt=0.01)
    sim.apply_force_at_point("box", force=[0, 10, 0], point=[0.5, 0.3, 0], frame="box")
    sim.step()                       # wrenches hold for this call's steps, then clear
    state = sim.body_state("box")    # position_world, orientation_xyzw, ...

Orientation read-outs are (x, y, z, w), as in ROS messages and scene files, of the user's body
frame B; internally the core integrates the principal frame P with (w, x, y, z) quaternions.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .dynamics import (
    angular_momentum_W,
    kinetic_energy,
    linear_momentum_W,
    potential_energy,
)
from .forces import WrenchAccumulator, parse_frame
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

__all__ = ["Simulator", "BodyState", "NonFiniteStateError"]


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
    """

    def __init__(self, scene: Scene, integrator: str = "rk4", dt: float = 0.01, *,
                 reference_rtol: float = 1e-12, reference_atol: float = 1e-12):
        self.scene = scene
        self.model = scene.model
        self._reference_options = {"rtol": _positive(reference_rtol, "reference_rtol"),
                                   "atol": _positive(reference_atol, "reference_atol")}
        self._integrator_name = ""
        self._step_function: Integrator = INTEGRATORS["rk4"]
        self.integrator = integrator
        self._dt = _positive(dt, "dt")
        self._wrenches = WrenchAccumulator(self.model)
        self._stopped = np.zeros(self.model.count, dtype=bool)
        self._active_cache: tuple[np.ndarray, Any] | None = None
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
        self.state: State = self.scene.initial_state.copy()
        self.step_count = 0
        self._time_origin = 0.0
        self._step_origin = 0
        self._wrenches.clear()
        self._stopped[:] = False
        self._active_cache = None

    def stop_body(self, body: str) -> None:
        """Freeze ``body`` at its current state; it is no longer integrated until :meth:`reset`."""
        self._stopped[self._index(body)] = True
        self._active_cache = None

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
        ref = parse_frame(self.scene, body, frame)
        f = _vector3(force, "force")
        t = _vector3(torque, "torque")
        self._wrenches.add(ref, f, t)

    def apply_force_at_point(self, body: str, force: Any, point: Any, frame: str = "world") -> None:
        """Apply force F (N) at point r (m) of ``frame``, both in ``frame``'s axes: the wrench (F, r × F)."""
        f = _vector3(force, "force")
        r = _vector3(point, "point")
        self.apply_wrench(body, f, np.cross(r, f), frame)

    def apply_impulse(self, body: str, linear: Any = (0.0, 0.0, 0.0), angular: Any = (0.0, 0.0, 0.0),
                      frame: str = "world") -> None:
        """Change velocities at once by a linear impulse (N·s) and an angular impulse (N·m·s).

        Same frame rule as :meth:`apply_wrench`: the angular impulse is about ``frame``'s origin.
        """
        ref = parse_frame(self.scene, body, frame)
        J = _vector3(linear, "linear impulse")
        H = _vector3(angular, "angular impulse")
        single = WrenchAccumulator(self.model)
        single.add(ref, J, H)
        J_W, H_W = single.resolve(self.state)
        b = ref.body_index
        state = self.state.copy()
        state.v_WC_W[b] += J_W[b] / self.model.mass[b]
        state.w_WP_P[b] += quat_rotate(quat_conjugate(state.q_WP[b]), H_W[b]) / self.model.inertia_P[b]
        if not state.finite_bodies()[b]:
            raise ValueError(f"impulse on {body!r} would make its velocity non-finite; not applied")
        self.state = state

    def clear_wrenches(self) -> None:
        """Drop every applied wrench before the next step."""
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
        self.state = state

    # ----------------------------------------------------------------- stepping

    def step(self, n: int = 1) -> None:
        """Advance ``n`` steps of ``dt``; applied wrenches hold for all of them, then clear.

        Raises
        ------
        NonFiniteStateError
            If a step makes any active body's state non-finite. That step is not applied: the
            state stays at the last finite step, ``time`` and ``step_count`` count only the
            steps done, and the applied wrenches are kept so the caller can stop the body
            (:meth:`stop_body`) and step again.
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"n: expected a whole number of steps ≥ 0, got {n!r}")
        for _ in range(int(n)):
            self._step_once()
        self._wrenches.clear()

    def _step_once(self) -> None:
        dt = self._dt
        # Overflow on the way to a non-finite state (in resolving a huge wrench, in the step, or
        # in |w| of the last finite state) is reported as NonFiniteStateError below, not as a
        # floating-point warning from wherever it first happened.
        with np.errstate(all="ignore"):
            force_W, torque_W = self._wrenches.resolve(self.state)
            if not self._stopped.any():
                new = self._step_function(self.model, self.state, force_W, torque_W, dt)
            else:
                active, sub_model = self._active()
                sub = self._step_function(sub_model, self.state.take(active), force_W[active], torque_W[active], dt)
                new = self.state.copy()
                for full, part in zip((new.p_WC_W, new.q_WP, new.v_WC_W, new.w_WP_P),
                                      (sub.p_WC_W, sub.q_WP, sub.v_WC_W, sub.w_WP_P)):
                    full[active] = part
            finite = new.finite_bodies()
            if not finite.all():
                bad = tuple(self.model.names[i] for i in np.flatnonzero(~finite))
                # math.hypot scales internally: |w| of a finite w never overflows (np.linalg.norm can).
                spin = {name: math.hypot(*self.state.w_WP_P[self.model.names.index(name)]) * dt for name in bad}
        if not finite.all():
            raise NonFiniteStateError(bad, self.step_count, self._integrator_name, dt, spin)
        self.state = new
        self.step_count += 1

    @property
    def time(self) -> float:
        """Simulated time, s, since the last reset: exact multiples of ``dt`` since ``dt`` last changed."""
        return self._time_origin + (self.step_count - self._step_origin) * self._dt

    def _active(self):
        if self._active_cache is None:
            active = np.flatnonzero(~self._stopped)
            self._active_cache = (active, self.model.subset(active))
        return self._active_cache

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


def _vector3(value: Any, name: str) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected 3 finite numbers, got {value!r}") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: expected 3 finite numbers, got {value!r}")
    return v
