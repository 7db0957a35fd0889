"""Integrators: one function per method, all in :data:`INTEGRATORS`, chosen by name.

Every integrator has the signature ``step(model, state, force_W, torque_W, dt) -> State``:
it advances ``state`` by ``dt`` seconds with the applied force and torque about the centre of
mass (world axes, shape (N, 3)) held constant over the step, and returns a new :class:`State`
with unit ``q_WP`` (renormalising is part of each method). Gravity and damping come from
``model``. None of them modifies its inputs.

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

from .dynamics import (
    angular_acceleration_P,
    derivatives,
    gyroscopic_torque_P,
    linear_acceleration_W,
    torque_in_P,
)
from .free_rotor import exact_rotor, symmetric_split_rotor
from .model import BodyModel, State
from .quaternion import quat_from_rotation_vector, quat_multiply

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
]

Integrator = Callable[[BodyModel, State, np.ndarray, np.ndarray, float], State]


def _normalised(q: np.ndarray) -> np.ndarray:
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _rotate_by_body_rate(q_WP: np.ndarray, w_WP_P: np.ndarray, dt: float) -> np.ndarray:
    """Exact orientation update for a body rate held constant over ``dt``: q ⊗ exp(w dt)."""
    return _normalised(quat_multiply(q_WP, quat_from_rotation_vector(w_WP_P * dt)))


def step_euler(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Textbook explicit Euler (all rates at the start of the step), q += dq·dt then normalise."""
    d = derivatives(model, state, force_W, torque_W)
    return State(
        state.p_WC_W + dt * d.p_WC_W,
        _normalised(state.q_WP + dt * d.q_WP),
        state.v_WC_W + dt * d.v_WC_W,
        state.w_WP_P + dt * d.w_WP_P,
    )


def step_semi_implicit_euler(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Symplectic Euler: v, w from the start-of-step forces; then p, q with the new v, w (exp-map)."""
    torque_P = torque_in_P(state.q_WP, torque_W)
    v_new = state.v_WC_W + dt * linear_acceleration_W(model, state.v_WC_W, force_W)
    w_new = state.w_WP_P + dt * angular_acceleration_P(model, state.w_WP_P, torque_P)
    return State(
        state.p_WC_W + dt * v_new,
        _rotate_by_body_rate(state.q_WP, w_new, dt),
        v_new,
        w_new,
    )


def step_implicit_gyroscopic(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Explicit external torque, then one Newton step on I(w − w*) + dt·w × Iw = 0 (Catto 2015).

    ``w* = w + dt·I⁻¹(τ_P − c_w w)``; the Newton step from ``w*`` with Jacobian
    ``J = I + dt([w*]× I − [I w*]×)`` gives ``w₁ = w* + J⁻¹(dt·(−w* × I w*))``. Orientation by
    the exp-map of ``w₁``; translation by semi-implicit Euler.
    """
    inertia = model.inertia_P
    torque_P = torque_in_P(state.q_WP, torque_W)
    w_star = state.w_WP_P + dt * (torque_P - model.damping_angular[:, None] * state.w_WP_P) / inertia
    Iw = inertia * w_star
    jacobian = np.empty(w_star.shape[:-1] + (3, 3))
    jacobian[:] = 0.0
    idx = np.arange(3)
    jacobian[..., idx, idx] = inertia
    jacobian += dt * (_skew(w_star) * inertia[:, None, :] - _skew(Iw))
    correction = np.linalg.solve(jacobian, (dt * gyroscopic_torque_P(inertia, w_star))[..., None])[..., 0]
    w_new = w_star + correction
    v_new = state.v_WC_W + dt * linear_acceleration_W(model, state.v_WC_W, force_W)
    return State(state.p_WC_W + dt * v_new, _rotate_by_body_rate(state.q_WP, w_new, dt), v_new, w_new)


def _skew(u: np.ndarray) -> np.ndarray:
    """Cross-product matrices [u]×, shape (N, 3) → (N, 3, 3)."""
    S = np.zeros(u.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -u[..., 2], u[..., 1]
    S[..., 1, 0], S[..., 1, 2] = u[..., 2], -u[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -u[..., 1], u[..., 0]
    return S


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


def _free_rotation_about_axis(q_WP: np.ndarray, L_P: np.ndarray, inertia: np.ndarray, axis: int, t: float):
    """Exact flow of H_axis = L_axis²/(2 I_axis) over time t: rotate about principal ``axis``.

    The body turns by θ = t·L_axis/I_axis about the axis (q ← q ⊗ exp(θ e_axis)) and the
    body-frame angular momentum turns by −θ about it.
    """
    theta = t * L_P[:, axis] / inertia[:, axis]
    c, s = np.cos(theta), np.sin(theta)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    L_new = L_P.copy()
    L_new[:, i] = c * L_P[:, i] + s * L_P[:, j]
    L_new[:, j] = -s * L_P[:, i] + c * L_P[:, j]
    half = 0.5 * theta
    dq = np.zeros(q_WP.shape)
    dq[:, 0] = np.cos(half)
    dq[:, 1 + axis] = np.sin(half)
    return quat_multiply(q_WP, dq), L_new


def step_splitting(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Second-order Lie–Poisson splitting: kick(dt/2) · free rotor(dt) · kick(dt/2).

    Kicks are the exact flows of the applied force/torque, gravity and damping with the body
    frozen; the free rotor is the symmetric composition R1(dt/2) R2(dt/2) R3(dt) R2(dt/2)
    R1(dt/2) of exact rotations about the principal axes (in P's axis order), and translation
    drifts by v·dt. It conserves |L| exactly when torque-free and keeps energy bounded.
    """
    inertia = model.inertia_P
    half = 0.5 * dt
    v, L = _kick(model, state.q_WP, state.v_WC_W, inertia * state.w_WP_P, force_W, torque_W, half)
    p = state.p_WC_W + dt * v
    q = state.q_WP
    for axis, t in ((0, half), (1, half), (2, dt), (1, half), (0, half)):
        q, L = _free_rotation_about_axis(q, L, inertia, axis, t)
    q = _normalised(q)
    v, L = _kick(model, q, v, L, force_W, torque_W, half)
    return State(p, q, v, L / inertia)


def _kick_rotor_kick(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float,
                     rotor: Callable[[np.ndarray, np.ndarray, np.ndarray, float], tuple[np.ndarray, np.ndarray]]) -> State:
    """kick(dt/2) · free rotor(dt) · kick(dt/2), translation drifting by v·dt, as in step_splitting."""
    inertia = model.inertia_P
    if not (force_W.any() or torque_W.any() or model.has_gravity or model.has_damping):
        # Nothing to kick with: the kicks are the identity, skipped (the same numbers, sooner).
        q, L = rotor(inertia, state.q_WP, inertia * state.w_WP_P, dt)
        return State(state.p_WC_W + dt * state.v_WC_W, _normalised(q), state.v_WC_W.copy(), L / inertia)
    half = 0.5 * dt
    v, L = _kick(model, state.q_WP, state.v_WC_W, inertia * state.w_WP_P, force_W, torque_W, half)
    p = state.p_WC_W + dt * v
    q, L = rotor(inertia, state.q_WP, L, dt)
    q = _normalised(q)
    v, L = _kick(model, q, v, L, force_W, torque_W, half)
    return State(p, q, v, L / inertia)


def step_symmetric_splitting(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Second-order splitting with the free rotor split around an exact symmetric top.

    Kicks as in :func:`step_splitting`; the free rotor is
    :func:`~rigid_body_sim.core.free_rotor.symmetric_split_rotor`: remainder(dt/2) ·
    symmetric top(dt) · remainder(dt/2), all exact rotations. Conserves |L| to round-off when
    torque-free; exact for a symmetric body; for a thin rod the error is ∝ its asymmetry.
    """
    return _kick_rotor_kick(model, state, force_W, torque_W, dt, symmetric_split_rotor)


def step_exact_rotor_splitting(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Second-order splitting around the exact free-rotor flow: exact when torque-free.

    Kicks as in :func:`step_splitting`; the free rotor is
    :func:`~rigid_body_sim.core.free_rotor.exact_rotor`, the Euler–Poinsot solution, so a
    torque-free body keeps its energy and |L| to round-off at any |ω|h; applied torques,
    gravity and damping enter as second-order half kicks.
    """
    return _kick_rotor_kick(model, state, force_W, torque_W, dt, exact_rotor)


def step_rk4(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray, dt: float) -> State:
    """Classic fourth-order Runge–Kutta on (p, q, v, w); q normalised after the step."""

    def shifted(k: State, h: float) -> State:
        return State(
            state.p_WC_W + h * k.p_WC_W,
            state.q_WP + h * k.q_WP,
            state.v_WC_W + h * k.v_WC_W,
            state.w_WP_P + h * k.w_WP_P,
        )

    k1 = derivatives(model, state, force_W, torque_W)
    k2 = derivatives(model, shifted(k1, 0.5 * dt), force_W, torque_W)
    k3 = derivatives(model, shifted(k2, 0.5 * dt), force_W, torque_W)
    k4 = derivatives(model, shifted(k3, dt), force_W, torque_W)
    w6 = dt / 6.0
    return State(
        state.p_WC_W + w6 * (k1.p_WC_W + 2.0 * (k2.p_WC_W + k3.p_WC_W) + k4.p_WC_W),
        _normalised(state.q_WP + w6 * (k1.q_WP + 2.0 * (k2.q_WP + k3.q_WP) + k4.q_WP)),
        state.v_WC_W + w6 * (k1.v_WC_W + 2.0 * (k2.v_WC_W + k3.v_WC_W) + k4.v_WC_W),
        state.w_WP_P + w6 * (k1.w_WP_P + 2.0 * (k2.w_WP_P + k3.w_WP_P) + k4.w_WP_P),
    )


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


def get_integrator(name: str) -> Integrator:
    """The integrator called ``name``; ValueError listing the choices for anything else."""
    try:
        return INTEGRATORS[name]
    except (KeyError, TypeError):
        raise ValueError(f"`integrator` must be one of {sorted(INTEGRATORS)}, got {name!r}") from None
