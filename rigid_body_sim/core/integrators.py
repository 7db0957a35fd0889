"""Integrators: one function per method, all in :data:`INTEGRATORS`, chosen by name.

Every integrator has the signature ``step(model, state, force_W, torque_W, dt) -> State``:
it advances ``state`` by ``dt`` seconds with the applied force and torque about the centre of
mass (world axes, shape (N, 3)) held constant over the step, and returns a new :class:`State`
with unit ``q_WP`` (renormalising is part of each method). Gravity and damping come from
``model``. None of them modifies its inputs. The fixed-formula methods (all but
``exact_rotor_splitting`` and ``reference``) are compiled per body with numba, in kernels.py,
which is their one implementation.

=========================  =====  ==============================================================
name                       order  what it is
=========================  =====  ==============================================================
``euler``                  1      textbook explicit Euler, additive q update + normalise, with
                                  the gyroscopic term
``semi_implicit_euler``    1      velocities first, then positions; orientation by exp-map
``implicit_gyroscopic``    1      one Newton step on the implicit gyroscopic equation (Catto
                                  2015; Bullet's computeGyroscopicImpulseImplicit_Body)
``splitting``              2      symplectic Lie–Poisson splitting of the free rotor into exact
                                  principal-axis rotations, torques as half kicks (McLachlan
                                  1993; Dullweber, Leimkuhler & McLachlan 1997)
``symmetric_splitting``    2      the free rotor split around an exact symmetric top (the two
                                  closest moments) plus an exact one-axis remainder, torques as
                                  half kicks; exact for symmetric bodies, error ∝ asymmetry
                                  (free_rotor.py; Fassò 2003)
``exact_rotor_splitting``  2      the exact free-rotor flow (Jacobi elliptic functions, Carlson
                                  integrals), torques as half kicks: exact when torque-free, at
                                  any |ω|h (free_rotor.py; Celledoni, Fassò, Säfström & Zanna
                                  2008)
``rk4``                    4      classic Runge–Kutta on (p, q, v, w), normalise q after
``reference``              —      scipy DOP853 at tight tolerances (the accuracy end)
=========================  =====  ==============================================================

Where each one holds (|ω|h, thin bodies, long runs) is measured in docs/stability.md.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp

from . import kernels
from .dynamics import derivatives, torque_in_P
from .free_rotor import exact_rotor
from .model import BodyModel, State

__all__ = [
    "INTEGRATORS",
    "Integrator",
    "get_integrator",
    "step_euler",
    "step_semi_implicit_euler",
    "step_implicit_gyroscopic",
    "step_splitting",
    "step_symmetric_splitting",
    "step_exact_rotor_splitting",
    "step_rk4",
    "step_reference",
    "COMPILED",
    "parameters_of",
]

Integrator = Callable[[BodyModel, State, np.ndarray, np.ndarray, float], State]


def _normalised(q: np.ndarray) -> np.ndarray:
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


# ----------------------------------------------------------------------------- compiled methods
# The fixed-formula methods are implemented once, per body, in kernels.py (numba); these
# functions give them the table's signature. Simulator calls the kernels directly.

_PARAMETER_CACHE: dict[int, tuple[BodyModel, np.ndarray]] = {}
_PARAMETER_CACHE_SIZE = 32


def parameters_of(model: BodyModel) -> np.ndarray:
    """The kernels' per-body constants of ``model`` (kernels.pack_parameters), cached per model object."""
    found = _PARAMETER_CACHE.get(id(model))
    if found is not None and found[0] is model:
        return found[1]
    if len(_PARAMETER_CACHE) >= _PARAMETER_CACHE_SIZE:
        _PARAMETER_CACHE.pop(next(iter(_PARAMETER_CACHE)))
    prm = kernels.pack_parameters(model)
    _PARAMETER_CACHE[id(model)] = (model, prm)  # holding the model keeps its id from being reused
    return prm


def _compiled_step(name: str, model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray,
                   dt: float) -> State:
    n = model.count
    Ys = np.empty((2, n, kernels.STATE_WIDTH))
    Ys[0] = state.rows()
    # The force and torque about the COM, world axes, are the world-aligned bucket (forces.py).
    buckets = np.zeros((n, kernels.BUCKET_WIDTH))
    buckets[:, 6:9] = force_W
    buckets[:, 9:12] = torque_W
    aux = np.zeros((3, n))
    # One unchecked step (limit = inf; a non-finite result is returned as it is): Ys[1] holds it.
    kernels.advance(kernels.METHODS[name], Ys, 0, parameters_of(model), np.arange(n, dtype=np.int64), n, buckets,
                    np.zeros((0, 7)), aux, True, 1,
                    float(dt), np.inf, -1, 0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    return State.of_rows(Ys[1])


def step_euler(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Textbook explicit Euler (all rates at the start of the step), q += dq·dt then normalise."""
    return _compiled_step("euler", model, state, force_W, torque_W, dt)


def step_semi_implicit_euler(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Symplectic Euler: v, w from the start-of-step forces; then p, q with the new v, w (exp-map)."""
    return _compiled_step("semi_implicit_euler", model, state, force_W, torque_W, dt)


def step_implicit_gyroscopic(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Explicit external torque, then one Newton step on I(w − w*) + dt·w × Iw = 0 (Catto 2015).

    ``w* = w + dt·I⁻¹(τ_P − c_w w)``; the Newton step from ``w*`` with Jacobian
    ``J = I + dt([w*]× I − [I w*]×)`` gives ``w₁ = w* + J⁻¹(dt·(−w* × I w*))``. Orientation by
    the exp-map of ``w₁``; translation by semi-implicit Euler.
    """
    return _compiled_step("implicit_gyroscopic", model, state, force_W, torque_W, dt)


def _decay_kick(x: np.ndarray, rate: np.ndarray, drive: np.ndarray, t: float) -> np.ndarray:
    """Exact flow of dx/dt = drive − rate·x over time t (rate ≥ 0, per body, broadcast on (N, 3))."""
    decay = np.exp(-rate * t)
    # (1 − e^{−kt})/k, → t as k → 0, computed without cancellation.
    kt = rate * t
    gain = np.where(kt > 1e-12, -np.expm1(-kt) / np.where(rate > 0.0, rate, 1.0), t)
    return x * decay + drive * gain


def _kick(model: BodyModel, q_WP: np.ndarray, v: np.ndarray, L_P: np.ndarray,
          force_W: np.ndarray, torque_W: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact flow over time t of the forces with the body frozen in place: returns (v, L_P)."""
    inv_mass = (1.0 / model.mass)[:, None]
    v = _decay_kick(v, model.damping_linear[:, None] * inv_mass, force_W * inv_mass + model.gravity_W, t)
    torque_P = torque_in_P(q_WP, torque_W)
    L_P = _decay_kick(L_P, model.damping_angular[:, None] / model.inertia_P, torque_P, t)
    return v, L_P


def step_splitting(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Second-order Lie–Poisson splitting: kick(dt/2) · free rotor(dt) · kick(dt/2).

    Kicks are the exact flows of the applied force/torque, gravity and damping with the body
    frozen; the free rotor is the symmetric composition R1(dt/2) R2(dt/2) R3(dt) R2(dt/2)
    R1(dt/2) of exact rotations about the principal axes (in P's axis order), and translation
    drifts by v·dt. It conserves |L| exactly when torque-free and keeps energy bounded.
    """
    return _compiled_step("splitting", model, state, force_W, torque_W, dt)


def step_symmetric_splitting(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Second-order splitting with the free rotor split around an exact symmetric top.

    Kicks as in :func:`step_splitting`; the free rotor is remainder(dt/2) · symmetric top(dt) ·
    remainder(dt/2), all exact rotations, the composition of
    :func:`~rigid_body_sim.core.free_rotor.symmetric_split_rotor` (compiled per body in
    kernels.py). Conserves |L| to round-off when torque-free; exact for a symmetric body; for
    a thin rod the error is ∝ its asymmetry.
    """
    return _compiled_step("symmetric_splitting", model, state, force_W, torque_W, dt)


def step_exact_rotor_splitting(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Second-order splitting around the exact free-rotor flow: exact when torque-free.

    kick(dt/2) · exact free rotor(dt) · kick(dt/2), translation drifting by v·dt, as in
    :func:`step_splitting`; the free rotor is :func:`~rigid_body_sim.core.free_rotor.exact_rotor`,
    the Euler–Poinsot solution, so a torque-free body keeps its energy and |L| to round-off at
    any |ω|h; applied torques, gravity and damping enter as second-order half kicks. numpy and
    scipy (elliptic functions), vectorised over bodies.
    """
    inertia = model.inertia_P
    if not (force_W.any() or torque_W.any() or model.has_gravity or model.has_damping):
        # Nothing to kick with: the kicks are the identity, skipped (the same numbers, sooner).
        q, L = exact_rotor(inertia, state.q_WP, inertia * state.w_WP_P, dt)
        return State(state.p_WC_W + dt * state.v_WC_W, _normalised(q), state.v_WC_W.copy(), L / inertia)
    half = 0.5 * dt
    v, L = _kick(model, state.q_WP, state.v_WC_W, inertia * state.w_WP_P, force_W, torque_W, half)
    p = state.p_WC_W + dt * v
    q, L = exact_rotor(inertia, state.q_WP, L, dt)
    q = _normalised(q)
    v, L = _kick(model, q, v, L, force_W, torque_W, half)
    return State(p, q, v, L / inertia)


def step_rk4(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Classic fourth-order Runge–Kutta on (p, q, v, w); q normalised after the step."""
    return _compiled_step("rk4", model, state, force_W, torque_W, dt)


#: Default tolerances of the ``reference`` integrator (relative, absolute).
REFERENCE_RTOL = 1e-12
REFERENCE_ATOL = 1e-12


def step_reference(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float,
                   rtol: float = REFERENCE_RTOL, atol: float = REFERENCE_ATOL) -> State:
    """scipy.integrate.solve_ivp with DOP853 over one step at tolerances ``rtol``/``atol``; q normalised after."""
    n = model.count

    def unpack(y: np.ndarray) -> State:
        y = y.reshape(n, 13)
        return State(y[:, 0:3], y[:, 3:7], y[:, 7:10], y[:, 10:13])

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        d = derivatives(model, unpack(y), force_W, torque_W)
        return np.concatenate((d.p_WC_W, d.q_WP, d.v_WC_W, d.w_WP_P), axis=1).ravel()

    y0 = np.concatenate((state.p_WC_W, state.q_WP, state.v_WC_W, state.w_WP_P), axis=1).ravel()
    solution = solve_ivp(rhs, (0.0, dt), y0, method="DOP853", rtol=rtol, atol=atol)
    if solution.success:
        end = unpack(solution.y[:, -1].copy())
        return State(end.p_WC_W, _normalised(end.q_WP), end.v_WC_W, end.w_WP_P)
    if n == 1:
        # DOP853 gave up (step size underflow on a stiff or exploding body): report the body's
        # state as non-finite so the simulator raises NonFiniteStateError naming it.
        nan = np.full((1, 3), np.nan)
        return State(nan, np.full((1, 4), np.nan), nan, nan)
    # Find which bodies make the solver fail: integrate each on its own.
    parts = [step_reference(model.subset([i]), state.take([i]), force_W[i:i + 1], torque_W[i:i + 1], dt, rtol, atol)
             for i in range(n)]
    return State(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("p_WC_W", "q_WP", "v_WC_W", "w_WP_P")))


#: Every integrator, by name. Add new methods here.
INTEGRATORS: dict[str, Integrator] = {
    "euler": step_euler,
    "semi_implicit_euler": step_semi_implicit_euler,
    "implicit_gyroscopic": step_implicit_gyroscopic,
    "splitting": step_splitting,
    "symmetric_splitting": step_symmetric_splitting,
    "exact_rotor_splitting": step_exact_rotor_splitting,
    "rk4": step_rk4,
    "reference": step_reference,
}


#: The integrators compiled per body in kernels.py (Simulator runs these without leaving the kernel).
COMPILED = frozenset(kernels.METHODS)


def get_integrator(name: str) -> Integrator:
    """The integrator called ``name``; ValueError listing the choices for anything else."""
    try:
        return INTEGRATORS[name]
    except (KeyError, TypeError):
        raise ValueError(f"`integrator` must be one of {sorted(INTEGRATORS)}, got {name!r}") from None
