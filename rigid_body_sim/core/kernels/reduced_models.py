"""The reduced per-body models (reduction.py says which body gets which, and why), one function each.

Same signature as the compiled integrators: ``model(y, out, p, w, dt, k)`` steps one body from
state row ``y`` into ``out`` with parameter row ``p``, wrench row ``w`` and scratch ``k``.
Each is exact for what it claims:

* ``kinematic``: constant twist (p += v dt, q ← exp(ω_W dt) ⊗ q); wrenches are ignored.
* ``translation``: the orientation is fixed, so every applied force is constant over the step
  (a body-fixed force does not turn): the exact flow of the COM under it, gravity and linear
  damping.
* ``planar``: when the step's in-plane force and normal torque are constant (wrenches fixed
  in world axes, or body-axes torques, whose normal part a yaw does not change), the exact
  flow of x, y and yaw; when they turn with the body or depend on where it is (a body-fixed
  force, a force about a world point, a world-axes force at a site), classic RK4 on the
  planar equations with the forces evaluated at every stage.
* ``isotropic`` / ``symmetric`` (:func:`torque_free`): while no torque acts and the force is
  fixed in world axes, exact translation and the exact exp-map / symmetric-top rotation;
  otherwise the caller steps the body with the integrator.
"""

from __future__ import annotations

import math

from numba import njit

from .forces import body_wrench, resolve_wrench
from .layout import (
    ACTIVE,
    AXIS_S,
    C_S,
    CACHE_DT,
    CACHE_Q,
    CACHE_RATE,
    DAMP_ANG,
    DAMP_LIN,
    F_COM_P,
    F_COM_W,
    F_WORLD,
    GRAVITY,
    INERTIA,
    INERTIA_NORMAL,
    INV_I_T,
    INV_MASS,
    KINEMATIC_W,
    MASS,
    NORMAL,
    P,
    PLANE_OFFSET,
    Q,
    SITE_MOMENT,
    TOP_A,
    TOP_B,
    TOP_DT,
    TOP_KEY,
    V,
    W,
    WRENCH_WIDTH,
)
from .jit import INLINE, JIT
from .rotation import exp_map, normalise, qmul, rotate, rotate_back

__all__ = ["kinematic", "translation", "planar", "isotropic_free", "symmetric_free", "torque_free",
           "force_fixed_in_world"]


@njit(**JIT)
def phis(k, t):
    """(φ1, φ2, e^{−kt}) of dx/dt = a − k x over t: x(t) = x0 e^{−kt} + a φ1, ∫x = x0 φ1 + a φ2.

    φ1 = (1 − e^{−kt})/k and φ2 = (t − φ1)/k, by their series where kt < 0.01 (no
    cancellation; truncation < 1e-18 relative); t and t²/2 exactly when k = 0.
    """
    x = k * t
    if x < 1e-2:
        phi1 = t * (1.0 - x / 2.0 * (1.0 - x / 3.0 * (1.0 - x / 4.0 * (1.0 - x / 5.0 * (1.0 - x / 6.0 * (1.0 - x / 7.0))))))
        phi2 = 0.5 * t * t * (1.0 - x / 3.0 * (1.0 - x / 4.0 * (1.0 - x / 5.0 * (1.0 - x / 6.0 * (1.0 - x / 7.0
                                                                                                  * (1.0 - x / 8.0))))))
        return phi1, phi2, math.exp(-x)
    phi1 = -math.expm1(-x) / k
    return phi1, (t - phi1) / k, math.exp(-x)


@njit(**INLINE)
def torque_free(w):
    """True when wrench row ``w`` holds only forces at the COM fixed in world axes (or nothing).

    Then the body feels no torque and a force constant in world axes for the whole step,
    whatever it does: the condition of the exact isotropic and symmetric flows.
    """
    free = True
    if w[ACTIVE] != 0.0:
        for j in range(WRENCH_WIDTH - 1):
            if w[j] != 0.0 and not (F_COM_W <= j < F_COM_W + 3):
                free = False
    _pin = w[0]  # the arrays' last use, out of branches and loops (jit.py)
    return free


@njit(**INLINE)
def force_fixed_in_world(w):
    """True when the in-plane force and the normal torque of wrench row ``w`` are constant under a planar motion.

    Not so for a force about a world point (its moment arm moves), a body-axes force (it
    turns with the yaw) or a world-axes force at a site (its moment arm turns).
    """
    fixed = True
    if w[ACTIVE] != 0.0:
        for j in range(3):
            if w[F_WORLD + j] != 0.0 or w[F_COM_P + j] != 0.0:
                fixed = False
        for j in range(9):
            if w[SITE_MOMENT + j] != 0.0:
                fixed = False
    _pin = w[0]  # the arrays' last use, out of branches and loops (jit.py)
    return fixed


@njit(**INLINE)
def constant_rate_increment(p, rx, ry, rz, dt):
    """exp((rx, ry, rz)·dt), from the body's cache when the rate and dt are those of its last step."""
    if not (p[CACHE_DT] == dt and p[CACHE_RATE] == rx and p[CACHE_RATE + 1] == ry and p[CACHE_RATE + 2] == rz):
        e = exp_map(rx * dt, ry * dt, rz * dt)
        p[CACHE_RATE], p[CACHE_RATE + 1], p[CACHE_RATE + 2], p[CACHE_DT] = rx, ry, rz, dt
        p[CACHE_Q], p[CACHE_Q + 1], p[CACHE_Q + 2], p[CACHE_Q + 3] = e[0], e[1], e[2], e[3]
    return p[CACHE_Q], p[CACHE_Q + 1], p[CACHE_Q + 2], p[CACHE_Q + 3]


@njit(**INLINE)
def translate_exact(y, out, p, fx, fy, fz, dt):
    """Exact flow of the COM under the constant total force (fx, fy, fz) (gravity included) and linear damping."""
    inv_m = p[INV_MASS]
    k = p[DAMP_LIN] * inv_m
    if k == 0.0:  # the common case; phis gives exactly these numbers
        phi1, phi2, decay = dt, 0.5 * dt * dt, 1.0
    else:
        phi1, phi2, decay = phis(k, dt)
    for a, f in enumerate((fx, fy, fz)):
        acc = f * inv_m
        v0 = y[V + a]
        out[V + a] = v0 * decay + acc * phi1
        out[P + a] = y[P + a] + v0 * phi1 + acc * phi2
    _pin = y[P], out[P], p[0]  # the arrays' last use, out of branches and loops (jit.py)


@njit(**INLINE)
def translation(y, out, p, w, dt, k):
    """translation_only: exact translation; orientation and (zero) angular velocity kept."""
    fx, fy, fz, _tx, _ty, _tz = body_wrench(y, p, w)
    translate_exact(y, out, p, fx, fy, fz, dt)
    for j in range(4):
        out[Q + j] = y[Q + j]
    for j in range(3):
        out[W + j] = y[W + j]
    _pin = y[P], out[P], p[0], w[0]  # the arrays' last use, out of branches and loops (jit.py)


@njit(**INLINE)
def kinematic(y, out, p, w, dt, k):
    """Constant twist: p += v dt; q ← exp(ω_W dt) ⊗ q; w_P = R(q)ᵀ ω_W. Wrenches are ignored."""
    for a in range(3):
        out[P + a] = y[P + a] + dt * y[V + a]
        out[V + a] = y[V + a]
    wx, wy, wz = p[KINEMATIC_W], p[KINEMATIC_W + 1], p[KINEMATIC_W + 2]
    e = constant_rate_increment(p, wx, wy, wz, dt)
    q = qmul(e[0], e[1], e[2], e[3], y[Q], y[Q + 1], y[Q + 2], y[Q + 3])
    qw, qx, qy, qz = normalise(q[0], q[1], q[2], q[3])
    out[Q], out[Q + 1], out[Q + 2], out[Q + 3] = qw, qx, qy, qz
    out[W], out[W + 1], out[W + 2] = rotate_back(qw, qx, qy, qz, wx, wy, wz)
    _pin = y[P], out[P], p[0]  # the arrays' last use, out of branches and loops (jit.py)


@njit(**INLINE)
def _planar_forces(y, p, w):
    """(in-plane total force, N, world axes; torque about the normal, N·m) at state row ``y``."""
    fx, fy, fz, tx, ty, tz = resolve_wrench(y, p, w)  # projected onto the plane
    m = p[MASS]
    n0, n1, n2 = p[NORMAL], p[NORMAL + 1], p[NORMAL + 2]
    return fx + m * p[GRAVITY], fy + m * p[GRAVITY + 1], fz + m * p[GRAVITY + 2], tx * n0 + ty * n1 + tz * n2


@njit(**INLINE)
def _planar_finish(y, out, p, theta, w_n):
    """out's q ← exp(θ n) ⊗ q(y), w_P ← R(q)ᵀ (w_n n), and p, v put back onto the plane against round-off."""
    nx, ny, nz = p[NORMAL], p[NORMAL + 1], p[NORMAL + 2]
    off = out[P] * nx + out[P + 1] * ny + out[P + 2] * nz - p[PLANE_OFFSET]
    v_n = out[V] * nx + out[V + 1] * ny + out[V + 2] * nz
    for a, n in enumerate((nx, ny, nz)):
        out[P + a] -= off * n
        out[V + a] -= v_n * n
    e = exp_map(theta * nx, theta * ny, theta * nz)
    q = qmul(e[0], e[1], e[2], e[3], y[Q], y[Q + 1], y[Q + 2], y[Q + 3])
    qw, qx, qy, qz = normalise(q[0], q[1], q[2], q[3])
    out[Q], out[Q + 1], out[Q + 2], out[Q + 3] = qw, qx, qy, qz
    out[W], out[W + 1], out[W + 2] = rotate_back(qw, qx, qy, qz, w_n * nx, w_n * ny, w_n * nz)
    _pin = y[P], out[P], p[0]  # the arrays' last use, out of branches and loops (jit.py)


@njit(**INLINE)
def _planar_rate(y, p):
    """The angular velocity about the plane normal, rad/s, of state row ``y``."""
    w_W = rotate(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], y[W], y[W + 1], y[W + 2])
    return w_W[0] * p[NORMAL] + w_W[1] * p[NORMAL + 1] + w_W[2] * p[NORMAL + 2]


@njit(**INLINE)
def _planar_exact(y, out, p, w, dt):
    """Exact flow of x, y and yaw under an in-plane force and a normal torque constant over the step."""
    fx, fy, fz, t_n = _planar_forces(y, p, w)
    translate_exact(y, out, p, fx, fy, fz, dt)
    I_n = p[INERTIA_NORMAL]
    phi1, phi2, decay = phis(p[DAMP_ANG] / I_n, dt)
    w_n = _planar_rate(y, p)
    alpha = t_n / I_n
    _planar_finish(y, out, p, w_n * phi1 + alpha * phi2, w_n * decay + alpha * phi1)


@njit(**INLINE)
def _planar_rk4(y, out, p, w, dt, k):
    """Classic RK4 on (p, v, yaw, w_n) of a planar body, the wrench evaluated at every stage's pose.

    k[4] holds the stage's state row (its q is exp(θ n) ⊗ q(y)); k[0..3] the stage rates:
    columns P, V as in a state row, then yaw rate and normal angular acceleration in Q, Q+1.
    """
    stage = k[4]
    for j in range(W + 3):
        stage[j] = y[j]
    nx, ny, nz = p[NORMAL], p[NORMAL + 1], p[NORMAL + 2]
    inv_m = p[INV_MASS]
    rate_v = p[DAMP_LIN] * inv_m
    I_n = p[INERTIA_NORMAL]
    rate_w = p[DAMP_ANG] / I_n
    w0 = _planar_rate(y, p)
    A = (0.0, 0.5, 0.5, 1.0)  # the classic tableau: stage i starts from y + A[i] dt k[i − 1]
    theta, w_n = 0.0, w0
    for i in range(4):
        if i > 0:
            a = A[i] * dt
            for j in range(3):
                stage[P + j] = y[P + j] + a * k[i - 1, P + j]
                stage[V + j] = y[V + j] + a * k[i - 1, V + j]
            theta = a * k[i - 1, Q]
            w_n = w0 + a * k[i - 1, Q + 1]
            e = exp_map(theta * nx, theta * ny, theta * nz)
            stage[Q], stage[Q + 1], stage[Q + 2], stage[Q + 3] = qmul(e[0], e[1], e[2], e[3],
                                                                      y[Q], y[Q + 1], y[Q + 2], y[Q + 3])
        fx, fy, fz, t_n = _planar_forces(stage, p, w)
        for j, f in enumerate((fx, fy, fz)):
            k[i, P + j] = stage[V + j]
            k[i, V + j] = f * inv_m - rate_v * stage[V + j]
        k[i, Q] = w_n
        k[i, Q + 1] = t_n / I_n - rate_w * w_n
    b = (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)
    for j in range(3):
        out[P + j] = y[P + j] + dt * (b[0] * k[0, P + j] + b[1] * k[1, P + j] + b[2] * k[2, P + j] + b[3] * k[3, P + j])
        out[V + j] = y[V + j] + dt * (b[0] * k[0, V + j] + b[1] * k[1, V + j] + b[2] * k[2, V + j] + b[3] * k[3, V + j])
    theta = dt * (b[0] * k[0, Q] + b[1] * k[1, Q] + b[2] * k[2, Q] + b[3] * k[3, Q])
    w_n = w0 + dt * (b[0] * k[0, Q + 1] + b[1] * k[1, Q + 1] + b[2] * k[2, Q + 1] + b[3] * k[3, Q + 1])
    _planar_finish(y, out, p, theta, w_n)
    _pin = y[P], out[P], p[0], w[0], k[0, 0], stage[0]  # the arrays' last use, out of branches and loops (jit.py)


@njit(**INLINE)
def planar(y, out, p, w, dt, k):
    """x, y and yaw in the plane: exact under a constant in-plane wrench, RK4 under one that turns or moves."""
    if force_fixed_in_world(w):
        _planar_exact(y, out, p, w, dt)
    else:
        _planar_rk4(y, out, p, w, dt, k)
    _pin = y[P], out[P], p[0], w[0], k[0, 0]  # the arrays' last use, out of branches and loops (jit.py)


@njit(**INLINE)
def isotropic_free(y, out, p, w, dt, k):
    """Isotropic, torque-free: exact translation; w_P decays (angular damping), q ← q ⊗ exp(w_P φ1)."""
    fx, fy, fz, _tx, _ty, _tz = body_wrench(y, p, w)
    translate_exact(y, out, p, fx, fy, fz, dt)
    wx, wy, wz = y[W], y[W + 1], y[W + 2]
    if p[DAMP_ANG] == 0.0:
        decay = 1.0
        e = constant_rate_increment(p, wx, wy, wz, dt)
    else:
        phi1, _phi2, decay = phis(p[DAMP_ANG] / p[INERTIA], dt)
        e = exp_map(wx * phi1, wy * phi1, wz * phi1)
    q = qmul(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], e[0], e[1], e[2], e[3])
    out[Q], out[Q + 1], out[Q + 2], out[Q + 3] = normalise(q[0], q[1], q[2], q[3])
    out[W], out[W + 1], out[W + 2] = wx * decay, wy * decay, wz * decay
    _pin = y[P], out[P], p[0], w[0]  # the arrays' last use, out of branches and loops (jit.py)


@njit(**INLINE)
def top_increments(y, p, dt):
    """(A, B) with q(t + dt) = A ⊗ q ⊗ B for the torque-free symmetric top at state ``y``; from the cache if it holds.

    A = exp(dt L_W / I_t) and B = exp(dt λ e_s), λ = (1/I_s − 1/I_t) L_s: the exact flow of
    integrators.top_flow, with the precession written on the world side, where L_W is
    constant; L_s is constant too, so A and B stay the same along the motion. They are kept
    with the state they led to, and reused when the step starts from exactly that state and dt.
    """
    hit = p[TOP_DT] == dt
    for j in range(4):
        hit = hit and y[Q + j] == p[TOP_KEY + j]
    for j in range(3):
        hit = hit and y[W + j] == p[TOP_KEY + 4 + j]
    if not hit:
        qw, qx, qy, qz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
        Lx, Ly, Lz = rotate(qw, qx, qy, qz, p[INERTIA] * y[W], p[INERTIA + 1] * y[W + 1], p[INERTIA + 2] * y[W + 2])
        s = dt * p[INV_I_T]
        a = exp_map(s * Lx, s * Ly, s * Lz)
        axis = int(p[AXIS_S])
        turn = dt * p[C_S] * p[INERTIA + axis] * y[W + axis]
        b = exp_map(turn if axis == 0 else 0.0, turn if axis == 1 else 0.0, turn if axis == 2 else 0.0)
        p[TOP_DT] = dt
        for j in range(4):
            p[TOP_A + j] = a[j]
            p[TOP_B + j] = b[j]
    _pin = y[P], p[0]  # the arrays' last use, out of branches and loops (jit.py)
    return (p[TOP_A], p[TOP_A + 1], p[TOP_A + 2], p[TOP_A + 3]), (p[TOP_B], p[TOP_B + 1], p[TOP_B + 2], p[TOP_B + 3])


@njit(**INLINE)
def symmetric_free(y, out, p, w, dt, k):
    """Axisymmetric, torque-free, no angular damping: exact translation; the exact symmetric-top flow.

    q ← A ⊗ q ⊗ B (:func:`top_increments`), and L_P turned back by B (L_P = I w_P).
    """
    fx, fy, fz, _tx, _ty, _tz = body_wrench(y, p, w)
    translate_exact(y, out, p, fx, fy, fz, dt)
    a, b = top_increments(y, p, dt)
    q = qmul(a[0], a[1], a[2], a[3], y[Q], y[Q + 1], y[Q + 2], y[Q + 3])
    q = qmul(q[0], q[1], q[2], q[3], b[0], b[1], b[2], b[3])
    out[Q], out[Q + 1], out[Q + 2], out[Q + 3] = normalise(q[0], q[1], q[2], q[3])
    L = rotate(b[0], -b[1], -b[2], -b[3], p[INERTIA] * y[W], p[INERTIA + 1] * y[W + 1], p[INERTIA + 2] * y[W + 2])
    for j in range(3):  # a division, not a product with 1/I (integrators.end_kick)
        out[W + j] = L[j] / p[INERTIA + j]
    for j in range(4):
        p[TOP_KEY + j] = out[Q + j]
    for j in range(3):
        p[TOP_KEY + 4 + j] = out[W + j]
    _pin = y[P], out[P], p[0], w[0]  # the arrays' last use, out of branches and loops (jit.py)
