"""Integrators: one function per method, all in :data:`INTEGRATORS`, chosen by name.

Each compiled method advances one body by ``dt`` from state row ``y`` into ``out`` (layout.py:
p_WC_W, q_WP (w x y z), v_WC_W, w_WP_P), with parameter row ``p`` and wrench row ``w``, and
``k`` as scratch. Every one evaluates the forces through
:func:`~rigid_body_sim.core.forces.body_wrench` (directly or through
:func:`~rigid_body_sim.core.dynamics.derivative`) *at every stage, kick or iterate* from the
state there, so a wrench fixed in the body turns with it during the step and each method
keeps its order under forcing in every frame. Renormalising q is part of each method.

=========================  =====  ==============================================================
name                       order  what it is
=========================  =====  ==============================================================
``euler``                  1      explicit Euler: the one-stage tableau (additive q update,
                                  then normalise), with the gyroscopic term
``semi_implicit_euler``    1      velocities from the start-of-step forces, then positions with
                                  the new velocities; orientation by the exponential map
``implicit_gyroscopic``    2      kick(h/2) · implicit-midpoint free rotor on the body angular
                                  momentum (energy and |L| kept exactly at any |ω|h) ·
                                  kick(h/2); translation by the same Strang splitting
``splitting``              2      kick(h/2) · exact principal-axis rotations R1 R2 R3 R2 R1 ·
                                  kick(h/2) (McLachlan 1993; Dullweber, Leimkuhler & McLachlan
                                  1997)
``symmetric_splitting``    2      kick(h/2) · exact symmetric top + one-axis remainder ·
                                  kick(h/2) (core/free_rotor.py; Fassò 2003)
``exact_rotor_splitting``  2      kick(h/2) · the exact free-rotor flow (Jacobi elliptic
                                  functions) · kick(h/2): exact when torque-free, any |ω|h
                                  (numpy; Celledoni, Fassò, Säfström & Zanna 2008)
``rk4``                    4      classic Runge–Kutta: the four-stage tableau on (p, q, v, w),
                                  q normalised after the step
``reference``              —      scipy DOP853 at tight tolerances on :func:`dynamics.derivative`
=========================  =====  ==============================================================

A kick is the exact flow of the forces with the body frozen in place (gravity, the wrenches
evaluated at the frozen pose, damping as an exact decay), so each splitting's second kick
sees the pose the rotor and the drift produced. Where each method holds (|ω|h, thin bodies,
long runs) is measured in docs/stability.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numba import njit

from .contact.stage import held_derivative
from .dynamics import angular_acceleration, derivative, rates
from .forces import body_wrench
from .layout import (
    AXIS_K,
    AXIS_S,
    C_K,
    C_S,
    DAMP_ANG,
    DAMP_LIN,
    INERTIA,
    INV_I_T,
    INV_INERTIA,
    INV_MASS,
    P,
    Q,
    STATE_WIDTH,
    V,
    W,
)
from .jit import INLINE, JIT, LOOP, named
from .rotation import exp_map, normalise, qmul, rotate

__all__ = ["Method", "INTEGRATORS", "COMPILED", "euler_held", "rk4_held", "get_integrator", "kick_and_drift", "final_kick", "EULER_TABLEAU", "RK4_TABLEAU"]


# ----------------------------------------------------------------------------- explicit Runge–Kutta


@dataclass(frozen=True)
class Tableau:
    """An explicit Runge–Kutta method as data (Butcher): y1 = y0 + h Σ b_i k_i, k_i = f(y0 + h Σ_j A_ij k_j)."""

    A: np.ndarray
    b: np.ndarray


#: Explicit Euler: one stage.
EULER_TABLEAU = Tableau(A=np.array([[0.0]]), b=np.array([1.0]))
#: The classic fourth-order Runge–Kutta (Kutta 1901).
RK4_TABLEAU = Tableau(
    A=np.array([[0.0, 0.0, 0.0, 0.0],
                [0.5, 0.0, 0.0, 0.0],
                [0.0, 0.5, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0]]),
    b=np.array([1.0, 2.0, 2.0, 1.0]) / 6.0,
)
# numba freezes module-level arrays into the compiled code as constants.
_EULER_A, _EULER_B = EULER_TABLEAU.A, EULER_TABLEAU.b
_RK4_A, _RK4_B = RK4_TABLEAU.A, RK4_TABLEAU.b


def _explicit_rk_on(rhs):
    """The explicit tableau's step on the right-hand side ``rhs(y, p, w, d)`` (inlined where it is called)."""

    @njit(**LOOP, inline="always")  # a closure: compiled into its cached callers (jit.py)
    @named(rhs.__name__)
    def explicit_rk(A, b, y, out, p, w, dt, k):
        """One step of the explicit tableau (A, b): stage derivatives in k[0..s), the stage state in k[s]."""
        s = b.shape[0]
        rhs(y, p, w, k[0])  # the first stage is at y (A's first row is zero: explicit)
        stage = k[s]
        for i in range(1, s):
            for j in range(STATE_WIDTH):
                stage[j] = y[j]
            for l in range(i):
                if A[i, l] != 0.0:
                    for j in range(STATE_WIDTH):
                        stage[j] += dt * A[i, l] * k[l, j]
            rhs(stage, p, w, k[i])
        for j in range(STATE_WIDTH):
            total = 0.0
            for i in range(s):
                total += b[i] * k[i, j]
            out[j] = y[j] + dt * total
        out[Q], out[Q + 1], out[Q + 2], out[Q + 3] = normalise(out[Q], out[Q + 1], out[Q + 2], out[Q + 3])
        _pin = y[P], out[P], p[0], w[0], k[0, 0], stage[0]  # the arrays' last use, out of branches and loops (jit.py)

    return explicit_rk


#: The explicit tableau on dynamics.derivative (every body), and on contact/stage.held_derivative (a body whose
#: wrench row carries its persistent contact: the holding force found at every stage). One tableau code.
explicit_rk = _explicit_rk_on(derivative)
_explicit_rk_held = _explicit_rk_on(held_derivative)


@njit(**INLINE)
def euler(y, out, p, w, dt, k):
    """Textbook explicit Euler: every rate at the start of the step; q += dq·dt, then normalise.

    :func:`explicit_rk` of the one-stage tableau written out on scalars (no scratch row): the
    same operations in the same order, ``y + dt·(0 + 1·d)``, so the same numbers to the bit.
    """
    d = rates(y, p, w)
    out[P], out[P + 1], out[P + 2] = y[P] + dt * (0.0 + d[0]), y[P + 1] + dt * (0.0 + d[1]), y[P + 2] + dt * (0.0 + d[2])
    out[Q], out[Q + 1], out[Q + 2], out[Q + 3] = normalise(
        y[Q] + dt * (0.0 + d[3]), y[Q + 1] + dt * (0.0 + d[4]), y[Q + 2] + dt * (0.0 + d[5]),
        y[Q + 3] + dt * (0.0 + d[6]))
    out[V], out[V + 1], out[V + 2] = y[V] + dt * (0.0 + d[7]), y[V + 1] + dt * (0.0 + d[8]), y[V + 2] + dt * (0.0 + d[9])
    out[W], out[W + 1], out[W + 2] = (y[W] + dt * (0.0 + d[10]), y[W + 1] + dt * (0.0 + d[11]),
                                      y[W + 2] + dt * (0.0 + d[12]))
    _pin = y[P], out[P], p[0], w[0], k[0, 0]  # the arrays' last use, out of branches and loops (jit.py)


@njit(**INLINE)
def rk4(y, out, p, w, dt, k):
    """Classic RK4 on the 13 components, the forces evaluated at each of the four stages; q normalised after."""
    explicit_rk(_RK4_A, _RK4_B, y, out, p, w, dt, k)


@njit(**JIT)
def euler_held(Y, Ynew, prm, wrenches, bodies, dt):
    """:func:`euler` of ``bodies`` (rows of Y into Ynew, the state columns), whose wrench rows carry their contact."""
    k = np.empty((_EULER_B.shape[0] + 1, Y.shape[1]))
    for i in bodies:
        _explicit_rk_held(_EULER_A, _EULER_B, Y[i], Ynew[i], prm[i], wrenches[i], dt, k)


@njit(**JIT)
def rk4_held(Y, Ynew, prm, wrenches, bodies, dt):
    """:func:`rk4` of ``bodies`` (rows of Y into Ynew, the state columns), whose wrench rows carry their contact."""
    k = np.empty((_RK4_B.shape[0] + 1, Y.shape[1]))
    for i in bodies:
        _explicit_rk_held(_RK4_A, _RK4_B, Y[i], Ynew[i], prm[i], wrenches[i], dt, k)


# ----------------------------------------------------------------------------- semi-implicit Euler


@njit(**INLINE)
def semi_implicit_euler(y, out, p, w, dt, k):
    """Symplectic Euler: v, w from the start-of-step forces; then p, and q ⊗ exp(w dt), with the new ones."""
    fx, fy, fz, tx, ty, tz = body_wrench(y, p, w)
    inv_m = p[INV_MASS]
    rate = p[DAMP_LIN] * inv_m
    for a, f in enumerate((fx, fy, fz)):
        v = y[V + a] + dt * (f * inv_m - rate * y[V + a])
        out[V + a] = v
        out[P + a] = y[P + a] + dt * v
    ax, ay, az = angular_acceleration(p, y[W], y[W + 1], y[W + 2], tx, ty, tz)
    out[W], out[W + 1], out[W + 2] = y[W] + dt * ax, y[W + 1] + dt * ay, y[W + 2] + dt * az
    e = exp_map(out[W] * dt, out[W + 1] * dt, out[W + 2] * dt)
    q = qmul(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], e[0], e[1], e[2], e[3])
    out[Q], out[Q + 1], out[Q + 2], out[Q + 3] = normalise(q[0], q[1], q[2], q[3])
    _pin = y[P], out[P], p[0], w[0]  # the arrays' last use, out of branches and loops (jit.py)


# ----------------------------------------------------------------------------- kicks (the splittings' forcing)
# Inside a splitting step the state row holds L = I w (principal axes) in the W slots.


@njit(**JIT)
def decay(x, rate, drive, t):
    """Exact flow of dx/dt = drive − rate·x over t (rate ≥ 0)."""
    if rate == 0.0:  # no damping: exactly x + drive t, without the exponentials
        x = x + drive * t
    else:
        kt = rate * t
        gain = -math.expm1(-kt) / rate if kt > 1e-12 else t
        x = x * math.exp(-kt) + drive * gain
    return x


@njit(**INLINE)
def kick(out, p, w, t):
    """Exact flow over t of the forces on the body frozen at out's pose: v and L_P of row ``out``, in place."""
    fx, fy, fz, tx, ty, tz = body_wrench(out, p, w)
    inv_m = p[INV_MASS]
    rate = p[DAMP_LIN] * inv_m
    for a, f in enumerate((fx, fy, fz)):
        out[V + a] = decay(out[V + a], rate, f * inv_m, t)
    c = p[DAMP_ANG]
    for a, tau in enumerate((tx, ty, tz)):
        out[W + a] = decay(out[W + a], c / p[INERTIA + a], tau, t)
    _pin = out[P], p[0], w[0]  # the arrays' last use, out of branches and loops (jit.py)


@njit(**INLINE)
def kick_drift(y, out, p, w, dt):
    """out ← y with w turned into L = I w, a half kick, then the drift of p by v·dt."""
    for j in range(STATE_WIDTH):
        out[j] = y[j]
    for a in range(3):
        out[W + a] = p[INERTIA + a] * y[W + a]
    kick(out, p, w, 0.5 * dt)
    for a in range(3):
        out[P + a] = y[P + a] + dt * out[V + a]
    _pin = y[P], out[P], p[0], w[0]  # the arrays' last use, out of branches and loops (jit.py)


@njit(**INLINE)
def end_kick(out, p, w, dt):
    """Normalise q, the second half kick at the new pose, and L back to w = L / I."""
    out[Q], out[Q + 1], out[Q + 2], out[Q + 3] = normalise(out[Q], out[Q + 1], out[Q + 2], out[Q + 3])
    kick(out, p, w, 0.5 * dt)
    for a in range(3):  # a division, not a product with 1/I: that would bias |L| by 1/I's rounding every step
        out[W + a] = out[W + a] / p[INERTIA + a]
    _pin = out[P], p[0], w[0]  # the arrays' last use, out of branches and loops (jit.py)


# ----------------------------------------------------------------------------- splittings


@njit(**JIT)
def _on_axis(axis, value):
    """The vector value·e_axis as a tuple."""
    if axis == 0:
        return value, 0.0, 0.0
    if axis == 1:
        return 0.0, value, 0.0
    return 0.0, 0.0, value


@njit(**INLINE)
def rotate_about_axis(out, p, axis, t):
    """Exact flow of L_a²/(2 I_a) over t on out's q and L."""
    theta = t * out[W + axis] / p[INERTIA + axis]
    c, s = math.cos(theta), math.sin(theta)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    Li, Lj = out[W + i], out[W + j]
    out[W + i] = c * Li + s * Lj
    out[W + j] = -s * Li + c * Lj
    dx, dy, dz = _on_axis(axis, math.sin(0.5 * theta))
    out[Q], out[Q + 1], out[Q + 2], out[Q + 3] = qmul(out[Q], out[Q + 1], out[Q + 2], out[Q + 3],
                                                      math.cos(0.5 * theta), dx, dy, dz)


@njit(**INLINE)
def splitting(y, out, p, w, dt, k):
    """kick(dt/2) · R1(dt/2) R2(dt/2) R3(dt) R2(dt/2) R1(dt/2) · kick(dt/2) (McLachlan 1993)."""
    kick_drift(y, out, p, w, dt)
    half = 0.5 * dt
    rotate_about_axis(out, p, 0, half)
    rotate_about_axis(out, p, 1, half)
    rotate_about_axis(out, p, 2, dt)
    rotate_about_axis(out, p, 1, half)
    rotate_about_axis(out, p, 0, half)
    end_kick(out, p, w, dt)


@njit(**INLINE)
def top_flow(out, inv_inertia_t, axis, c_axis, t):
    """Exact flow of |L|²/(2 I_t)·[inv_inertia_t ≠ 0] + ½ c L_axis² over t (free_rotor._top_flow in numpy)."""
    Lx, Ly, Lz = out[W], out[W + 1], out[W + 2]
    qw, qx, qy, qz = out[Q], out[Q + 1], out[Q + 2], out[Q + 3]
    if inv_inertia_t != 0.0:
        s = t * inv_inertia_t
        e = exp_map(s * Lx, s * Ly, s * Lz)
        qw, qx, qy, qz = qmul(qw, qx, qy, qz, e[0], e[1], e[2], e[3])
    rx, ry, rz = _on_axis(axis, t * c_axis * out[W + axis])
    e = exp_map(rx, ry, rz)
    out[Q], out[Q + 1], out[Q + 2], out[Q + 3] = qmul(qw, qx, qy, qz, e[0], e[1], e[2], e[3])
    out[W], out[W + 1], out[W + 2] = rotate(e[0], -e[1], -e[2], -e[3], Lx, Ly, Lz)


@njit(**INLINE)
def symmetric_splitting(y, out, p, w, dt, k):
    """kick(dt/2) · remainder(dt/2) · symmetric top(dt) · remainder(dt/2) · kick(dt/2) (free_rotor.py)."""
    kick_drift(y, out, p, w, dt)
    s, r = int(p[AXIS_S]), int(p[AXIS_K])
    top_flow(out, 0.0, r, p[C_K], 0.5 * dt)
    top_flow(out, p[INV_I_T], s, p[C_S], dt)
    top_flow(out, 0.0, r, p[C_K], 0.5 * dt)
    end_kick(out, p, w, dt)


# ----------------------------------------------------------------------------- implicit midpoint rotor

#: Newton's method on the midpoint stops when the residual is below this fraction of |L| (a few ulps).
MIDPOINT_TOLERANCE = 8.0 * np.finfo(float).eps
MIDPOINT_MAX_ITERATIONS = 40
#: A step whose midpoint damped Newton cannot find from L (seen from |ω|·dt ≈ 5 on, for a few
#: bodies in a hundred) is taken as 2, 4, ... equal midpoint steps: at most this many.
MIDPOINT_MAX_PIECES = 256


@njit(**JIT)
def _midpoint_residual(d0, d1, d2, L0, L1, L2, g, x0, x1, x2):
    """r = x − L0 − g x × D x, and |r|."""
    w0, w1, w2 = d0 * x0, d1 * x1, d2 * x2
    r0 = x0 - L0 - g * (x1 * w2 - x2 * w1)
    r1 = x1 - L1 - g * (x2 * w0 - x0 * w2)
    r2 = x2 - L2 - g * (x0 * w1 - x1 * w0)
    return r0, r1, r2, math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)


@njit(**JIT)
def midpoint_of(d0, d1, d2, L0, L1, L2, h):
    """The midpoint x of the implicit midpoint rule on dL/dt = L × D L over h, D = diag(d): (x, converged).

    Solves x = L0 + (h/2) x × D x by Newton's method from x = L0, damped by halving the step
    until the residual falls (Jacobian E − (h/2)([x]× D − [D x]×), by Cramer's rule);
    ``converged`` is False when the residual does not reach round-off.
    """
    x0, x1, x2 = L0, L1, L2
    size = math.sqrt(L0 * L0 + L1 * L1 + L2 * L2)
    g = 0.5 * h
    r0, r1, r2, norm = _midpoint_residual(d0, d1, d2, L0, L1, L2, g, x0, x1, x2)
    for _ in range(MIDPOINT_MAX_ITERATIONS):
        if norm <= MIDPOINT_TOLERANCE * size:
            break
        w0, w1, w2 = d0 * x0, d1 * x1, d2 * x2
        a00, a01, a02 = 1.0, -g * (-x2 * d1 + w2), -g * (x1 * d2 - w1)
        a10, a11, a12 = -g * (x2 * d0 - w2), 1.0, -g * (-x0 * d2 + w0)
        a20, a21, a22 = -g * (-x1 * d0 + w1), -g * (x0 * d1 - w0), 1.0
        c00, c01, c02 = a11 * a22 - a12 * a21, a02 * a21 - a01 * a22, a01 * a12 - a02 * a11
        c10, c11, c12 = a12 * a20 - a10 * a22, a00 * a22 - a02 * a20, a02 * a10 - a00 * a12
        c20, c21, c22 = a10 * a21 - a11 * a20, a01 * a20 - a00 * a21, a00 * a11 - a01 * a10
        det = a00 * c00 + a01 * c10 + a02 * c20
        s0 = -(c00 * r0 + c01 * r1 + c02 * r2) / det
        s1 = -(c10 * r0 + c11 * r1 + c12 * r2) / det
        s2 = -(c20 * r0 + c21 * r1 + c22 * r2) / det
        t = 1.0
        while True:  # halve the step until the residual falls
            y0, y1, y2 = x0 + t * s0, x1 + t * s1, x2 + t * s2
            q0, q1, q2, trial = _midpoint_residual(d0, d1, d2, L0, L1, L2, g, y0, y1, y2)
            if trial < (1.0 - 1e-4 * t) * norm or t < 1e-6:
                break
            t *= 0.5
        x0, x1, x2, r0, r1, r2, norm = y0, y1, y2, q0, q1, q2, trial
    return x0, x1, x2, norm <= MIDPOINT_TOLERANCE * size


@njit(**JIT)
def onto_invariants(d0, d1, d2, L0, L1, L2, size2, energy2):
    """L moved (Newton, along L and D L) onto |L|² = size2 and L·D L = energy2: the free rotor's invariants."""
    for _ in range(8):
        e0, e1, e2 = d0 * L0, d1 * L1, d2 * L2
        f = L0 * L0 + L1 * L1 + L2 * L2 - size2
        h = L0 * e0 + L1 * e1 + L2 * e2 - energy2
        # L ← L + a L + b D L: Jacobian [[2|L|², 2 L·DL], [2 L·DL, 2 |DL|²]]
        j11, j12, j22 = 2.0 * (L0 * L0 + L1 * L1 + L2 * L2), 2.0 * (L0 * e0 + L1 * e1 + L2 * e2), \
            2.0 * (e0 * e0 + e1 * e1 + e2 * e2)
        det = j11 * j22 - j12 * j12
        if det == 0.0:
            break
        a = -(j22 * f - j12 * h) / det
        b = -(j11 * h - j12 * f) / det
        L0, L1, L2 = L0 + a * L0 + b * e0, L1 + a * L1 + b * e1, L2 + a * L2 + b * e2
    return L0, L1, L2


@njit(**JIT)
def midpoint_rotor_flow(d0, d1, d2, qw, qx, qy, qz, L0, L1, L2, dt):
    """The implicit midpoint rule on the free rotor over dt: (q, L) after it, from (q, L) in principal axes.

    Each midpoint step L1 = 2x − L0, q ← q ⊗ exp(h D x) keeps |L| and the energy ½ L·D L
    exactly: both are quadratic invariants, which the midpoint rule conserves for any solution
    x. Where damped Newton cannot find x in one step (midpoint_of), the step is taken as 2,
    4, ... equal midpoint steps; past MIDPOINT_MAX_PIECES (|ω|·dt in the thousands, where no
    step resolves the motion) the last attempt's L is put back onto the invariants. So the
    rotor never gains energy at any |ω|·dt.
    """
    size2 = L0 * L0 + L1 * L1 + L2 * L2
    energy2 = d0 * L0 * L0 + d1 * L1 * L1 + d2 * L2 * L2
    pieces = 1
    done = False
    while not done:
        q_w, q_x, q_y, q_z, M0, M1, M2 = qw, qx, qy, qz, L0, L1, L2
        h = dt / pieces
        done = True
        for _ in range(pieces):
            x0, x1, x2, converged = midpoint_of(d0, d1, d2, M0, M1, M2, h)
            if not converged and pieces < MIDPOINT_MAX_PIECES:
                done = False
                break
            e = exp_map(h * d0 * x0, h * d1 * x1, h * d2 * x2)
            q_w, q_x, q_y, q_z = qmul(q_w, q_x, q_y, q_z, e[0], e[1], e[2], e[3])
            M0, M1, M2 = 2.0 * x0 - M0, 2.0 * x1 - M1, 2.0 * x2 - M2
            if not converged:
                M0, M1, M2 = onto_invariants(d0, d1, d2, M0, M1, M2, size2, energy2)
        pieces *= 2
    return q_w, q_x, q_y, q_z, M0, M1, M2


@njit(**INLINE)
def implicit_gyroscopic(y, out, p, w, dt, k):
    """kick(dt/2) · implicit-midpoint free rotor(dt) · kick(dt/2), translation drifting by v·dt."""
    kick_drift(y, out, p, w, dt)
    out[Q], out[Q + 1], out[Q + 2], out[Q + 3], out[W], out[W + 1], out[W + 2] = midpoint_rotor_flow(
        p[INV_INERTIA], p[INV_INERTIA + 1], p[INV_INERTIA + 2], out[Q], out[Q + 1], out[Q + 2], out[Q + 3],
        out[W], out[W + 1], out[W + 2], dt)
    end_kick(out, p, w, dt)


# ----------------------------------------------------------------------------- the table


@dataclass(frozen=True)
class Method:
    """An integrator of :data:`INTEGRATORS`.

    ``order`` is its order of convergence under forcing in any frame (None: adaptive);
    ``step`` the compiled per-body step ``step(y, out, p, w, dt, k)`` (None: a numpy/scipy
    method the Simulator runs group by group, core/integrators.py: exact_rotor_splitting,
    reference); ``code`` its position in :data:`COMPILED`, the number stepping.integrate
    dispatches on (None with ``step``). ``derivative_stages``: every stage evaluates
    dynamics.derivative from its own state, so a persistent contact carried in the wrench row
    (layout.HELD) is found at every stage (kernels/contact/stage.py); the other methods
    evaluate the forces on a frozen pose (kicks) and are given the contact force found at the
    step's start. ``held``: the compiled step ``held(Y, Ynew, prm, wrenches, bodies, dt)`` of
    bodies whose wrench rows carry their contact (layout.HELD): the same tableau on
    contact/stage.held_derivative. The contact solver takes those bodies' steps again with it
    (core/contact/solver.py), so the step loops, and every body without a held contact, run
    exactly the plain step.
    """

    name: str
    order: int | None
    step: Any
    summary: str
    code: int | None = None
    derivative_stages: bool = False
    held: Any = None


#: Every integrator, by name: the one place to add one. A compiled one is a per-body step
#: function (as above) in a row here; stepping.py builds its loop over bodies from the row.
INTEGRATORS: dict[str, Method] = {}
for _method in (
    Method("euler", 1, euler, "explicit Euler with the gyroscopic term; q += dq·dt, then normalised",
           derivative_stages=True, held=euler_held),
    Method("semi_implicit_euler", 1, semi_implicit_euler,
           "velocities first, then positions; orientation by the exponential map"),
    Method("implicit_gyroscopic", 2, implicit_gyroscopic,
           "half kicks around an implicit-midpoint free rotor: energy and |L| kept at any |ω|·dt"),
    Method("splitting", 2, splitting, "half kicks around exact principal-axis rotations (McLachlan 1993)"),
    Method("symmetric_splitting", 2, symmetric_splitting,
           "half kicks around an exact symmetric top and a one-axis remainder"),
    Method("exact_rotor_splitting", 2, None, "half kicks around the exact free-rotor flow (elliptic functions): "
                                             "exact when torque-free, at any |ω|·dt"),
    Method("rk4", 4, rk4, "classic fourth-order Runge–Kutta, forces evaluated at every stage",
           derivative_stages=True, held=rk4_held),
    Method("reference", None, None, "scipy DOP853 at tight tolerances (the accuracy end)", derivative_stages=True),
):
    _code = None if _method.step is None else sum(m.step is not None for m in INTEGRATORS.values())
    INTEGRATORS[_method.name] = replace(_method, code=_code)
del _method, _code

#: The compiled steps, by Method.code.
COMPILED = tuple(m.step for m in INTEGRATORS.values() if m.step is not None)


def get_integrator(name: str) -> Method:
    """The integrator called ``name``; ValueError listing the choices for anything else."""
    try:
        return INTEGRATORS[name]
    except (KeyError, TypeError):
        raise ValueError(f"`integrator` must be one of {sorted(INTEGRATORS)}, got {name!r}") from None


# ----------------------------------------------------------------------------- the halves of a splitting step
# for the numpy splitting (core/integrators.py)


@njit(**JIT)
def kick_and_drift(Y, Ynew, prm, wrenches, bodies, dt):
    """The first half of a splitting step for ``bodies``: Ynew ← kick(dt/2) and drift of Y (L in the W slots)."""
    for i in bodies:
        kick_drift(Y[i], Ynew[i], prm[i], wrenches[i], dt)


@njit(**JIT)
def final_kick(Ynew, prm, wrenches, bodies, dt):
    """The last half of a splitting step for ``bodies``, in place on Ynew (L back to w)."""
    for i in bodies:
        end_kick(Ynew[i], prm[i], wrenches[i], dt)
