"""Compiled per-body kernels (numba): the fixed-step integrators, wrench resolution and the step checks.

Why compiled: a rigid-body step is ~100–300 floating-point operations per body. As numpy
calls on (N, 3) arrays it costs 15–40 µs per step for one body (call overhead) and ~8e6
body-steps/s at N = 1e4 (memory traffic of the temporaries); as one loop over bodies it costs
well under a microsecond per call and ~1e7–1e8 body-steps/s (benchmarks/, README "Speed").

Each integrator of :data:`~rigid_body_sim.core.integrators.INTEGRATORS` that is a fixed
formula has exactly one implementation, the ``_step_*`` function here; the table's
``step_*(model, state, force_W, torque_W, dt)`` functions call :func:`advance` for one
unchecked step. The two
that are not (``exact_rotor_splitting``, elliptic functions; ``reference``, scipy DOP853) stay
in numpy/scipy.

Array layouts (all float64, C order; the names of the column offsets are below):

``Y`` : (N, 13)
    One row per body: p_WC_W (3, m), q_WP (4, w x y z), v_WC_W (3, m/s), w_WP_P (3, rad/s).
``prm`` : (N, PRM_WIDTH)
    Per-body constants (:func:`pack_parameters`): mass, 1/m, principal moments, their
    inverses, damping, gravity, the energy-bound constants, the active flag, the pairing of
    the symmetric splitting.
``buckets`` : (N, 18)
    Applied wrenches in their frames' terms (forces.WrenchAccumulator): force_W, torque_O_W
    (about the world origin), force_A, torque_A (about the COM, world axes), force_P,
    torque_P (about the COM, principal axes).
``sites`` : (S, 7)
    World-axes sites: owning body (as a float), position from the COM in P axes (3, m), the
    force applied there (3, N, world axes).
``FT`` : (N, 6)
    Resolved force and torque about the COM, world axes.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "METHODS",
    "PRM_WIDTH",
    "STATE_WIDTH",
    "add_wrench",
    "entry_point",
    "advance",
    "check_step",
    "pack_parameters",
    "resolve_wrenches",
]

def entry_point(dispatcher, *example):
    """The compiled entry point of ``dispatcher`` for the types of ``example`` (compiling it if needed).

    Calling it skips numba's per-call type dispatch (~0.4 µs of a ~1 µs call): only for
    arguments of exactly the example's types, which the caller guarantees (Simulator: its
    own arrays, Python int/float/bool scalars). Falls back to the dispatcher itself.
    """
    from numba import typeof

    dispatcher(*example)  # compiles or loads from the cache; the example must be harmless
    signature = tuple(typeof(a) for a in example)
    compiled = dispatcher.overloads.get(signature)
    return compiled.entry_point if compiled is not None else dispatcher


# ----------------------------------------------------------------------------- layouts

STATE_WIDTH = 13
P0, Q0, V0, W0 = 0, 3, 7, 10

MASS, INV_MASS = 0, 1
INERTIA = 2  # 3 columns: I1, I2, I3 (kg·m²)
INV_INERTIA = 5  # 3 columns
DAMP_LIN, DAMP_ANG = 8, 9
GRAVITY = 10  # 3 columns, m/s²
BUDGET_FORCE, BUDGET_TORQUE = 13, 14  # 1/√(2m), 1/√(2 I_min)
ACTIVE = 15  # 1.0 integrates the body, 0.0 freezes it (Simulator.stop_body)
AXIS_S, AXIS_K = 16, 17  # symmetric splitting: symmetry and remainder axes (0, 1, 2)
INV_I_T, C_S, C_K = 18, 19, 20  # 1/I_t, 1/I_s − 1/I_t, 1/I_k − 1/I_t
GRAVITY_BUDGET_RATE = 21  # |m g| / √(2m): the energy bound's growth rate under gravity alone
PRM_WIDTH = 22

BUCKET_WIDTH = 18

#: Integrator name → method number of the kernels.
METHODS = {
    "euler": 0,
    "semi_implicit_euler": 1,
    "implicit_gyroscopic": 2,
    "splitting": 3,
    "symmetric_splitting": 4,
    "rk4": 5,
}

# Step outcome codes (advance, check_step) and per-body status.
OK, NON_FINITE, DIVERGED = 0, 1, 2


def pack_parameters(model) -> np.ndarray:
    """The (N, PRM_WIDTH) per-body constants of ``model`` (a BodyModel), every body active."""
    from .free_rotor import rotor_pairing  # numpy, once per model

    n = model.count
    prm = np.zeros((n, PRM_WIDTH))
    inertia = np.asarray(model.inertia_P, dtype=float)
    prm[:, MASS] = model.mass
    prm[:, INV_MASS] = 1.0 / model.mass
    prm[:, INERTIA:INERTIA + 3] = inertia
    prm[:, INV_INERTIA:INV_INERTIA + 3] = 1.0 / inertia
    prm[:, DAMP_LIN] = model.damping_linear
    prm[:, DAMP_ANG] = model.damping_angular
    prm[:, GRAVITY:GRAVITY + 3] = model.gravity_W
    prm[:, BUDGET_FORCE] = 1.0 / np.sqrt(2.0 * model.mass)
    prm[:, BUDGET_TORQUE] = 1.0 / np.sqrt(2.0 * inertia.min(axis=1)) if n else 0.0
    prm[:, ACTIVE] = 1.0
    prm[:, GRAVITY_BUDGET_RATE] = np.linalg.norm(model.mass[:, None] * model.gravity_W, axis=1) * prm[:, BUDGET_FORCE]
    if n:
        rows = np.arange(n)
        t, s, k = rotor_pairing(inertia)
        I_t, I_s, I_k = inertia[rows, t], inertia[rows, s], inertia[rows, k]
        prm[:, AXIS_S] = s
        prm[:, AXIS_K] = k
        prm[:, INV_I_T] = 1.0 / I_t
        prm[:, C_S] = 1.0 / I_s - 1.0 / I_t
        prm[:, C_K] = 1.0 / I_k - 1.0 / I_t
    return prm


# ----------------------------------------------------------------------------- quaternion algebra


@njit(cache=True, inline="always")
def _qmul(aw, ax, ay, az, bw, bx, by, bz):
    """Hamilton product a ⊗ b of (w, x, y, z) quaternions."""
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


@njit(cache=True, inline="always")
def _rotate(qw, qx, qy, qz, vx, vy, vz):
    """R(q) v for unit q: v + 2w (u × v) + 2 u × (u × v)."""
    tx = 2.0 * (qy * vz - qz * vy)
    ty = 2.0 * (qz * vx - qx * vz)
    tz = 2.0 * (qx * vy - qy * vx)
    return (vx + qw * tx + (qy * tz - qz * ty),
            vy + qw * ty + (qz * tx - qx * tz),
            vz + qw * tz + (qx * ty - qy * tx))


@njit(cache=True, inline="always")
def _exp(rx, ry, rz):
    """Exponential map of a rotation vector (rad) to a unit quaternion, series for small angles."""
    theta = math.sqrt(rx * rx + ry * ry + rz * rz)
    half = 0.5 * theta
    if theta < 1e-4:
        scale = 0.5 - theta * theta / 48.0
    else:
        scale = math.sin(half) / theta
    return math.cos(half), rx * scale, ry * scale, rz * scale


@njit(cache=True, inline="always")
def _normalise(qw, qx, qy, qz):
    n = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    return qw / n, qx / n, qy / n, qz / n


@njit(cache=True, inline="always")
def _torque_P(qw, qx, qy, qz, tx, ty, tz):
    """World torque in P axes, R(q̂)ᵀ τ with q̂ = q/|q|."""
    if tx == 0.0 and ty == 0.0 and tz == 0.0:
        return 0.0, 0.0, 0.0
    qw, qx, qy, qz = _normalise(qw, qx, qy, qz)
    return _rotate(qw, -qx, -qy, -qz, tx, ty, tz)


# ----------------------------------------------------------------------------- dynamics


@njit(cache=True, inline="always")
def _derivative(y, prm, F, T, d):
    """d ← dY/dt of one body (13,) under force F and torque T (about the COM, world axes)."""
    qw, qx, qy, qz = y[3], y[4], y[5], y[6]
    wx, wy, wz = y[10], y[11], y[12]
    vx, vy, vz = y[7], y[8], y[9]
    d[0] = vx
    d[1] = vy
    d[2] = vz
    # dq/dt = ½ q ⊗ (0, w)
    d[3] = 0.5 * (-qx * wx - qy * wy - qz * wz)
    d[4] = 0.5 * (qw * wx + qy * wz - qz * wy)
    d[5] = 0.5 * (qw * wy - qx * wz + qz * wx)
    d[6] = 0.5 * (qw * wz + qx * wy - qy * wx)
    inv_m = prm[INV_MASS]
    rate = prm[DAMP_LIN] * inv_m
    d[7] = F[0] * inv_m + prm[GRAVITY] - rate * vx
    d[8] = F[1] * inv_m + prm[GRAVITY + 1] - rate * vy
    d[9] = F[2] * inv_m + prm[GRAVITY + 2] - rate * vz
    ax, ay, az = _angular_acceleration(prm, wx, wy, wz, _torque_P(qw, qx, qy, qz, T[0], T[1], T[2]))
    d[10] = ax
    d[11] = ay
    d[12] = az


@njit(cache=True, inline="always")
def _angular_acceleration(prm, wx, wy, wz, tau):
    """I⁻¹(τ_P − c_w w − w × I w), P axes."""
    I1, I2, I3 = prm[INERTIA], prm[INERTIA + 1], prm[INERTIA + 2]
    c = prm[DAMP_ANG]
    hx, hy, hz = I1 * wx, I2 * wy, I3 * wz
    gx = -(wy * hz - wz * hy)
    gy = -(wz * hx - wx * hz)
    gz = -(wx * hy - wy * hx)
    return ((tau[0] - c * wx + gx) / I1, (tau[1] - c * wy + gy) / I2, (tau[2] - c * wz + gz) / I3)


@njit(cache=True, inline="always")
def _decay_kick(x, rate, drive, t):
    """Exact flow of dx/dt = drive − rate·x over t (rate ≥ 0)."""
    kt = rate * t
    if kt > 1e-12:
        gain = -math.expm1(-kt) / rate
    else:
        gain = t
    return x * math.exp(-kt) + drive * gain


@njit(cache=True, inline="always")
def _kick(y, prm, F, T, t):
    """Exact flow over t of the forces on a frozen body: v and L_P = I w of row y, in place."""
    inv_m = prm[INV_MASS]
    rate = prm[DAMP_LIN] * inv_m
    for a in range(3):
        y[7 + a] = _decay_kick(y[7 + a], rate, F[a] * inv_m + prm[GRAVITY + a], t)
    tau = _torque_P(y[3], y[4], y[5], y[6], T[0], T[1], T[2])
    c = prm[DAMP_ANG]
    for a in range(3):
        I_a = prm[INERTIA + a]
        y[10 + a] = _decay_kick(y[10 + a], c / I_a, tau[a], t)


# ----------------------------------------------------------------------------- integrators, one body each
# Signature: (y (13,) start of step, out (13,) end of step, prm row, F (3,), T (3,), dt, scratch (8, 13)).


@njit(cache=True, inline="always")
def _step_euler(y, out, prm, F, T, dt, scratch):
    d = scratch[0]
    _derivative(y, prm, F, T, d)
    for j in range(13):
        out[j] = y[j] + dt * d[j]
    out[3], out[4], out[5], out[6] = _normalise(out[3], out[4], out[5], out[6])


@njit(cache=True, inline="always")
def _rotate_by_body_rate(out, wx, wy, wz, dt):
    """out's q ← normalise(q ⊗ exp(w dt))."""
    e = _exp(wx * dt, wy * dt, wz * dt)
    q = _qmul(out[3], out[4], out[5], out[6], e[0], e[1], e[2], e[3])
    out[3], out[4], out[5], out[6] = _normalise(q[0], q[1], q[2], q[3])


@njit(cache=True, inline="always")
def _semi_implicit_translation(y, out, prm, F, dt):
    inv_m = prm[INV_MASS]
    rate = prm[DAMP_LIN] * inv_m
    for a in range(3):
        v = y[7 + a] + dt * (F[a] * inv_m + prm[GRAVITY + a] - rate * y[7 + a])
        out[7 + a] = v
        out[a] = y[a] + dt * v


@njit(cache=True, inline="always")
def _step_semi_implicit_euler(y, out, prm, F, T, dt, scratch):
    _semi_implicit_translation(y, out, prm, F, dt)
    tau = _torque_P(y[3], y[4], y[5], y[6], T[0], T[1], T[2])
    acc = _angular_acceleration(prm, y[10], y[11], y[12], tau)
    for a in range(3):
        out[10 + a] = y[10 + a] + dt * acc[a]
    out[3], out[4], out[5], out[6] = y[3], y[4], y[5], y[6]
    _rotate_by_body_rate(out, out[10], out[11], out[12], dt)


@njit(cache=True, inline="always")
def _step_implicit_gyroscopic(y, out, prm, F, T, dt, scratch):
    """Explicit torque, then one Newton step on I(w − w*) + dt·w × Iw = 0 (Catto 2015)."""
    I = (prm[INERTIA], prm[INERTIA + 1], prm[INERTIA + 2])
    tau = _torque_P(y[3], y[4], y[5], y[6], T[0], T[1], T[2])
    c = prm[DAMP_ANG]
    ws0 = y[10] + dt * (tau[0] - c * y[10]) / I[0]
    ws1 = y[11] + dt * (tau[1] - c * y[11]) / I[1]
    ws2 = y[12] + dt * (tau[2] - c * y[12]) / I[2]
    h0, h1, h2 = I[0] * ws0, I[1] * ws1, I[2] * ws2
    # J = diag(I) + dt([w*]× diag(I) − [I w*]×), augmented with rhs = −dt w* × I w*.
    A = scratch[0:3, 0:4]
    A[0, 0] = I[0]
    A[0, 1] = dt * (-ws2 * I[1] + h2)
    A[0, 2] = dt * (ws1 * I[2] - h1)
    A[1, 0] = dt * (ws2 * I[0] - h2)
    A[1, 1] = I[1]
    A[1, 2] = dt * (-ws0 * I[2] + h0)
    A[2, 0] = dt * (-ws1 * I[0] + h1)
    A[2, 1] = dt * (ws0 * I[1] - h0)
    A[2, 2] = I[2]
    A[0, 3] = -dt * (ws1 * h2 - ws2 * h1)
    A[1, 3] = -dt * (ws2 * h0 - ws0 * h2)
    A[2, 3] = -dt * (ws0 * h1 - ws1 * h0)
    x0, x1, x2 = _solve3(A)
    out[10], out[11], out[12] = ws0 + x0, ws1 + x1, ws2 + x2
    _semi_implicit_translation(y, out, prm, F, dt)
    out[3], out[4], out[5], out[6] = y[3], y[4], y[5], y[6]
    _rotate_by_body_rate(out, out[10], out[11], out[12], dt)


@njit(cache=True, inline="always")
def _solve3(A):
    """Solve the 3×3 system of the augmented (3, 4) A by Gaussian elimination, partial pivoting (A is overwritten)."""
    for col in range(3):
        pivot = col
        for r in range(col + 1, 3):
            if abs(A[r, col]) > abs(A[pivot, col]):
                pivot = r
        if pivot != col:
            for j in range(4):
                A[col, j], A[pivot, j] = A[pivot, j], A[col, j]
        for r in range(col + 1, 3):
            f = A[r, col] / A[col, col]
            for j in range(col, 4):
                A[r, j] -= f * A[col, j]
    x2 = A[2, 3] / A[2, 2]
    x1 = (A[1, 3] - A[1, 2] * x2) / A[1, 1]
    x0 = (A[0, 3] - A[0, 1] * x1 - A[0, 2] * x2) / A[0, 0]
    return x0, x1, x2


@njit(cache=True, inline="always")
def _on_axis(axis, value):
    """The vector value·e_axis as a tuple."""
    if axis == 0:
        return value, 0.0, 0.0
    if axis == 1:
        return 0.0, value, 0.0
    return 0.0, 0.0, value


@njit(cache=True, inline="always")
def _rotate_about_axis(out, prm, axis, t):
    """Exact flow of L_a²/(2 I_a) over t on out's q and L (stored in out's w slots)."""
    theta = t * out[10 + axis] / prm[INERTIA + axis]
    c, s = math.cos(theta), math.sin(theta)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    Li, Lj = out[10 + i], out[10 + j]
    out[10 + i] = c * Li + s * Lj
    out[10 + j] = -s * Li + c * Lj
    half = 0.5 * theta
    dx, dy, dz = _on_axis(axis, math.sin(half))
    q = _qmul(out[3], out[4], out[5], out[6], math.cos(half), dx, dy, dz)
    out[3], out[4], out[5], out[6] = q[0], q[1], q[2], q[3]


@njit(cache=True, inline="always")
def _begin_kick_drift(y, out, prm, F, T, dt):
    """out ← y with w turned into L = I w, half kick, then the drift of p by v·dt."""
    for j in range(13):
        out[j] = y[j]
    for a in range(3):
        out[10 + a] = prm[INERTIA + a] * y[10 + a]
    _kick(out, prm, F, T, 0.5 * dt)
    for a in range(3):
        out[a] = y[a] + dt * out[7 + a]


@njit(cache=True, inline="always")
def _end_kick(out, prm, F, T, dt):
    out[3], out[4], out[5], out[6] = _normalise(out[3], out[4], out[5], out[6])
    _kick(out, prm, F, T, 0.5 * dt)
    for a in range(3):
        out[10 + a] = out[10 + a] / prm[INERTIA + a]


@njit(cache=True, inline="always")
def _step_splitting(y, out, prm, F, T, dt, scratch):
    """kick(dt/2) · R1(dt/2) R2(dt/2) R3(dt) R2(dt/2) R1(dt/2) · kick(dt/2) (McLachlan 1993)."""
    _begin_kick_drift(y, out, prm, F, T, dt)
    half = 0.5 * dt
    _rotate_about_axis(out, prm, 0, half)
    _rotate_about_axis(out, prm, 1, half)
    _rotate_about_axis(out, prm, 2, dt)
    _rotate_about_axis(out, prm, 1, half)
    _rotate_about_axis(out, prm, 0, half)
    _end_kick(out, prm, F, T, dt)


@njit(cache=True, inline="always")
def _top_flow(out, inv_inertia_t, axis, c_axis, t):
    """Exact flow of |L|²/(2 I_t)·[inv_inertia_t ≠ 0] + ½ c L_axis² over t (closed_form.symmetric_top_flow)."""
    Lx, Ly, Lz = out[10], out[11], out[12]
    qw, qx, qy, qz = out[3], out[4], out[5], out[6]
    if inv_inertia_t != 0.0:
        s = t * inv_inertia_t
        e = _exp(s * Lx, s * Ly, s * Lz)
        qw, qx, qy, qz = _qmul(qw, qx, qy, qz, e[0], e[1], e[2], e[3])
    rx, ry, rz = _on_axis(axis, t * c_axis * out[10 + axis])
    e = _exp(rx, ry, rz)
    out[3], out[4], out[5], out[6] = _qmul(qw, qx, qy, qz, e[0], e[1], e[2], e[3])
    out[10], out[11], out[12] = _rotate(e[0], -e[1], -e[2], -e[3], Lx, Ly, Lz)


@njit(cache=True, inline="always")
def _step_symmetric_splitting(y, out, prm, F, T, dt, scratch):
    """kick(dt/2) · remainder(dt/2) · symmetric top(dt) · remainder(dt/2) · kick(dt/2) (free_rotor.py)."""
    _begin_kick_drift(y, out, prm, F, T, dt)
    s, k = int(prm[AXIS_S]), int(prm[AXIS_K])
    _top_flow(out, 0.0, k, prm[C_K], 0.5 * dt)
    _top_flow(out, prm[INV_I_T], s, prm[C_S], dt)
    _top_flow(out, 0.0, k, prm[C_K], 0.5 * dt)
    _end_kick(out, prm, F, T, dt)


@njit(cache=True, inline="always")
def _step_rk4(y, out, prm, F, T, dt, scratch):
    """Classic RK4 on the 13 components; q normalised after the step."""
    k1, k2, k3, k4, ys = scratch[0], scratch[1], scratch[2], scratch[3], scratch[4]
    _derivative(y, prm, F, T, k1)
    for j in range(13):
        ys[j] = y[j] + 0.5 * dt * k1[j]
    _derivative(ys, prm, F, T, k2)
    for j in range(13):
        ys[j] = y[j] + 0.5 * dt * k2[j]
    _derivative(ys, prm, F, T, k3)
    for j in range(13):
        ys[j] = y[j] + dt * k3[j]
    _derivative(ys, prm, F, T, k4)
    w6 = dt / 6.0
    for j in range(13):
        out[j] = y[j] + w6 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j])
    out[3], out[4], out[5], out[6] = _normalise(out[3], out[4], out[5], out[6])


# ----------------------------------------------------------------------------- wrenches


@njit(cache=True)
def resolve_wrenches(Y, buckets, sites, FT):
    """FT ← total applied (force, torque about the COM), world axes, per body, at state Y."""
    n = Y.shape[0]
    for i in range(n):
        b = buckets[i]
        qw, qx, qy, qz = Y[i, 3], Y[i, 4], Y[i, 5], Y[i, 6]
        fP = _rotate(qw, qx, qy, qz, b[12], b[13], b[14])
        tP = _rotate(qw, qx, qy, qz, b[15], b[16], b[17])
        px, py, pz = Y[i, 0], Y[i, 1], Y[i, 2]
        fx, fy, fz = b[0], b[1], b[2]
        FT[i, 0] = fx + b[6] + fP[0]
        FT[i, 1] = fy + b[7] + fP[1]
        FT[i, 2] = fz + b[8] + fP[2]
        # torque about the COM of a world-frame wrench: τ_O − p × F
        FT[i, 3] = b[3] - (py * fz - pz * fy) + b[9] + tP[0]
        FT[i, 4] = b[4] - (pz * fx - px * fz) + b[10] + tP[1]
        FT[i, 5] = b[5] - (px * fy - py * fx) + b[11] + tP[2]
    for s in range(sites.shape[0]):
        fx, fy, fz = sites[s, 4], sites[s, 5], sites[s, 6]
        if fx == 0.0 and fy == 0.0 and fz == 0.0:
            continue
        i = int(sites[s, 0])
        arm = _rotate(Y[i, 3], Y[i, 4], Y[i, 5], Y[i, 6], sites[s, 1], sites[s, 2], sites[s, 3])
        FT[i, 0] += fx
        FT[i, 1] += fy
        FT[i, 2] += fz
        FT[i, 3] += arm[1] * fz - arm[2] * fy
        FT[i, 4] += arm[2] * fx - arm[0] * fz
        FT[i, 5] += arm[0] * fy - arm[1] * fx


@njit(cache=True)
def add_wrench(buckets, body, force_column, torque_column, fx, fy, fz, tx, ty, tz):
    """buckets[body] += the force at ``force_column`` and the torque at ``torque_column`` (3 each)."""
    buckets[body, force_column] += fx
    buckets[body, force_column + 1] += fy
    buckets[body, force_column + 2] += fz
    buckets[body, torque_column] += tx
    buckets[body, torque_column + 1] += ty
    buckets[body, torque_column + 2] += tz


# ----------------------------------------------------------------------------- checks


@njit(cache=True, inline="always")
def _check_body(i, Ynew, prm, FT, has_wrench, budget, budget_new, dt, limit, status):
    """Status of body i after a step: finite, and kinetic energy within limit·B² (DivergenceError)."""
    row = Ynew[i]
    poison = 0.0  # x·0 is NaN exactly when x is inf or NaN
    for j in range(13):
        poison += row[j] * 0.0
    if poison != 0.0:
        status[i] = NON_FINITE
        return NON_FINITE
    m = prm[MASS]
    if has_wrench:
        gx, gy, gz = m * prm[GRAVITY] + FT[i, 0], m * prm[GRAVITY + 1] + FT[i, 1], m * prm[GRAVITY + 2] + FT[i, 2]
        torque = math.sqrt(FT[i, 3] ** 2 + FT[i, 4] ** 2 + FT[i, 5] ** 2)
        b = budget[i] + dt * (math.sqrt(gx * gx + gy * gy + gz * gz) * prm[BUDGET_FORCE] + torque * prm[BUDGET_TORQUE])
    else:
        b = budget[i] + dt * prm[GRAVITY_BUDGET_RATE]
    budget_new[i] = b
    v2 = row[7] * row[7] + row[8] * row[8] + row[9] * row[9]
    energy = 0.5 * (m * v2 + prm[INERTIA] * row[10] ** 2 + prm[INERTIA + 1] * row[11] ** 2
                    + prm[INERTIA + 2] * row[12] ** 2)
    if energy > limit * b * b:
        status[i] = DIVERGED
        return DIVERGED
    status[i] = OK
    return OK


@njit(cache=True)
def check_step(Ynew, prm, FT, has_wrench, aux, dt, limit):
    """Check every active body of a step computed elsewhere (the numpy/scipy integrators).

    ``aux`` as in :func:`advance`. Returns the worst outcome: NON_FINITE if any body is
    non-finite, else DIVERGED if any exceeds its energy bound, else OK; aux[2] holds each body's.
    """
    budget, budget_new, status = aux[0], aux[1], aux[2]
    worst_non_finite = False
    worst_diverged = False
    for i in range(Ynew.shape[0]):
        if prm[i, ACTIVE] == 0.0:
            status[i] = OK
            budget_new[i] = budget[i]
            continue
        outcome = _check_body(i, Ynew, prm[i], FT, has_wrench, budget, budget_new, dt, limit, status)
        worst_non_finite |= outcome == NON_FINITE
        worst_diverged |= outcome == DIVERGED
    return NON_FINITE if worst_non_finite else (DIVERGED if worst_diverged else OK)


# ----------------------------------------------------------------------------- drivers


@njit(cache=True, inline="always")
def _step_bodies(step_body, Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch):
    """One checked step of every active body from Y into Ynew; the worst outcome (see advance).

    Inlined into one function per integrator below, each compiled with only its own
    ``step_body`` (measured: ~1.5–2× faster than one loop branching on the method per body).
    """
    worst_non_finite = False
    worst_diverged = False
    for i in range(Y.shape[0]):
        p = prm[i]
        if p[ACTIVE] == 0.0:
            for j in range(13):
                Ynew[i, j] = Y[i, j]
            budget_new[i] = budget[i]
            status[i] = OK
            continue
        step_body(Y[i], Ynew[i], p, FT[i, 0:3], FT[i, 3:6], dt, scratch)
        outcome = _check_body(i, Ynew, p, FT, has_wrench, budget, budget_new, dt, limit, status)
        worst_non_finite |= outcome == NON_FINITE
        worst_diverged |= outcome == DIVERGED
    return NON_FINITE if worst_non_finite else (DIVERGED if worst_diverged else OK)


@njit(cache=True)
def _step_bodies_0(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch):
    return _step_bodies(_step_euler, Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)


@njit(cache=True)
def _step_bodies_1(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch):
    return _step_bodies(_step_semi_implicit_euler, Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)


@njit(cache=True)
def _step_bodies_2(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch):
    return _step_bodies(_step_implicit_gyroscopic, Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)


@njit(cache=True)
def _step_bodies_3(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch):
    return _step_bodies(_step_splitting, Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)


@njit(cache=True)
def _step_bodies_4(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch):
    return _step_bodies(_step_symmetric_splitting, Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)


@njit(cache=True)
def _step_bodies_5(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch):
    return _step_bodies(_step_rk4, Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)


@njit(cache=True)
def advance(method, Ys, prm, buckets, sites, aux, has_wrench, n_steps, dt, limit,
            pending_body, force_column, torque_column, fx, fy, fz, tx, ty, tz):
    """Up to ``n_steps`` checked steps of every active body, in place in Ys[0]; stops at the first bad step.

    ``Ys`` (2, N, 13) holds the state (Ys[0]) and the next step's scratch (Ys[1]); ``aux``
    (3, N) the energy bound B (√J), its next value and each body's status (OK, NON_FINITE,
    DIVERGED). If ``pending_body`` ≥ 0, the wrench (fx, fy, fz, tx, ty, tz) is first added to
    ``buckets[pending_body]`` at the given columns (add_wrench; the one-call path of a
    single applied wrench).

    Each step: resolve the applied wrenches at the step's start (if any), step every active
    body from Ys[0] into Ys[1], check each (finite; kinetic energy ≤ limit·B², B advanced by
    the step's inputs); if all pass, Ys[1] and the new B become the state and bound. A failed
    step is not applied: Ys[0] and B stay at the last good step, Ys[1] holds the failed step,
    aux[2] says which bodies failed how, and the applied wrenches are kept. After the last
    step the applied wrenches (buckets, site forces) are cleared.

    Returns
    -------
    (steps_done, outcome) : (int, int)
        outcome OK, NON_FINITE (some body non-finite) or DIVERGED (else some body over its bound).
    """
    Y, Ynew = Ys[0], Ys[1]
    budget, budget_new, status = aux[0], aux[1], aux[2]
    if pending_body >= 0:
        add_wrench(buckets, pending_body, force_column, torque_column, fx, fy, fz, tx, ty, tz)
        has_wrench = True
    scratch = np.empty((8, 13))
    FT = np.zeros((Y.shape[0], 6))
    for k in range(n_steps):
        if has_wrench:
            resolve_wrenches(Y, buckets, sites, FT)
        if method == 0:
            outcome = _step_bodies_0(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)
        elif method == 1:
            outcome = _step_bodies_1(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)
        elif method == 2:
            outcome = _step_bodies_2(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)
        elif method == 3:
            outcome = _step_bodies_3(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)
        elif method == 4:
            outcome = _step_bodies_4(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)
        else:
            outcome = _step_bodies_5(Y, Ynew, prm, FT, has_wrench, budget, budget_new, status, dt, limit, scratch)
        if outcome != OK:
            return k, outcome
        Y[:, :] = Ynew
        budget[:] = budget_new
    if has_wrench:
        buckets[:, :] = 0.0
        sites[:, 4:7] = 0.0
    return n_steps, OK
