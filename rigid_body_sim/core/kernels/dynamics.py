"""Newton–Euler equations of a free rigid body, written once (compiled; energy and momentum: core/mechanics.py).

In the principal frame P (diagonal inertia I = (I1, I2, I3)):

    m · dv_W/dt      = F_W − c_v v_W                        (F_W includes m g)
    I · dw_P/dt      = τ_P − c_w w_P − w_P × (I w_P)        ← the gyroscopic term
    dp_W/dt          = v_W
    dq_WP/dt         = ½ q_WP ⊗ (0, w_P)                    (w, x, y, z)

``F_W`` and ``τ_P`` are what :func:`~rigid_body_sim.core.forces.body_wrench` returns for the
state at hand: the applied wrenches evaluated in their frames, plus gravity. The gyroscopic
term is what makes a phone flip about its intermediate axis; leaving it out is the classic
textbook bug. :func:`derivative` is the one implementation (compiled); every integrator that
needs the right-hand side calls it, the scipy ``reference`` included.
"""

from __future__ import annotations

import math

from numba import njit

from .forces import body_wrench, resolve_wrench
from .layout import (DAMP_ANG, DAMP_LIN, INERTIA, INERTIA_NORMAL, INV_INERTIA, INV_MASS, MODEL, MODEL_PLANAR, NORMAL,
                     P, Q, V, W)
from .jit import INLINE, JIT
from .rotation import normalise, rotate_back

__all__ = [
    "gyroscopic_torque",
    "angular_acceleration",
    "rates",
    "derivative",
    "derivatives",
    "impulse_response",
]


@njit(**INLINE)
def gyroscopic_torque(p, wx, wy, wz):
    """The gyroscopic term −w × (I w), N·m, principal axes, of a body with parameter row ``p``."""
    hx, hy, hz = p[INERTIA] * wx, p[INERTIA + 1] * wy, p[INERTIA + 2] * wz
    return -(wy * hz - wz * hy), -(wz * hx - wx * hz), -(wx * hy - wy * hx)


@njit(**INLINE)
def angular_acceleration(p, wx, wy, wz, tx, ty, tz):
    """dw_P/dt = I⁻¹(τ_P − c_w w − w × I w), rad/s², principal axes."""
    gx, gy, gz = gyroscopic_torque(p, wx, wy, wz)
    c = p[DAMP_ANG]
    return ((tx - c * wx + gx) * p[INV_INERTIA], (ty - c * wy + gy) * p[INV_INERTIA + 1],
            (tz - c * wz + gz) * p[INV_INERTIA + 2])


@njit(**INLINE)
def rates(y, p, w):
    """dy/dt of one body as 13 scalars (layout order: dp, dq, dv, dw): state row ``y``, parameter row ``p``,
    wrench row ``w`` (layout.py). :func:`derivative` stores them; explicit Euler uses them as they are."""
    fx, fy, fz, tx, ty, tz = body_wrench(y, p, w)
    qw, qx, qy, qz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
    wx, wy, wz = y[W], y[W + 1], y[W + 2]
    vx, vy, vz = y[V], y[V + 1], y[V + 2]
    dqw = 0.5 * (-qx * wx - qy * wy - qz * wz)
    dqx = 0.5 * (qw * wx + qy * wz - qz * wy)
    dqy = 0.5 * (qw * wy - qx * wz + qz * wx)
    dqz = 0.5 * (qw * wz + qx * wy - qy * wx)
    inv_m = p[INV_MASS]
    rate = p[DAMP_LIN] * inv_m
    ax, ay, az = angular_acceleration(p, wx, wy, wz, tx, ty, tz)
    return (vx, vy, vz, dqw, dqx, dqy, dqz, fx * inv_m - rate * vx, fy * inv_m - rate * vy, fz * inv_m - rate * vz,
            ax, ay, az)


@njit(**INLINE)
def derivative(y, p, w, d):
    """d ← dy/dt of one body: state row ``y``, parameter row ``p``, wrench row ``w`` (layout.py)."""
    (d[P], d[P + 1], d[P + 2], d[Q], d[Q + 1], d[Q + 2], d[Q + 3], d[V], d[V + 1], d[V + 2], d[W], d[W + 1],
     d[W + 2]) = rates(y, p, w)


@njit(**JIT)
def derivatives(Y, prm, wrenches, D):
    """D ← dY/dt for every body: rows of ``Y`` (N, ≥ 13), ``prm``, ``wrenches``; D (N, 13)."""
    for i in range(Y.shape[0]):
        derivative(Y[i], prm[i], wrenches[i], D[i])


@njit(**JIT)
def impulse_response(y, p, impulse, out):
    """out ← y after the impulse row ``impulse`` (a wrench row of N·s and N·m·s, forces.add_wrench) acts at once.

    The impulse is resolved at ``y`` like a wrench (forces.resolve_wrench, projected onto the
    motion): Δv = J/m, and ΔL = H about the COM. A free body's Δw_P = I⁻¹ R(q)ᵀ H; a planar
    body, whose angular velocity stays along the plane normal n, takes only
    Δw = (H·n)/(nᵀ I_W n) n (the constraint's reaction absorbs the rest). Returns the
    impulse's (|J|, |H|) after projection, for the energy bound.
    """
    for j in range(W + 3):
        out[j] = y[j]
    jx, jy, jz, hx, hy, hz = resolve_wrench(y, p, impulse)
    inv_m = p[INV_MASS]
    out[V] += jx * inv_m
    out[V + 1] += jy * inv_m
    out[V + 2] += jz * inv_m
    qw, qx, qy, qz = normalise(y[Q], y[Q + 1], y[Q + 2], y[Q + 3])
    if p[MODEL] == MODEL_PLANAR:
        nx, ny, nz = p[NORMAL], p[NORMAL + 1], p[NORMAL + 2]
        dw = (hx * nx + hy * ny + hz * nz) / p[INERTIA_NORMAL]
        dP = rotate_back(qw, qx, qy, qz, dw * nx, dw * ny, dw * nz)
        out[W], out[W + 1], out[W + 2] = out[W] + dP[0], out[W + 1] + dP[1], out[W + 2] + dP[2]
    else:
        hP = rotate_back(qw, qx, qy, qz, hx, hy, hz)
        for a in range(3):
            out[W + a] += hP[a] * p[INV_INERTIA + a]
    return math.sqrt(jx * jx + jy * jy + jz * jz), math.sqrt(hx * hx + hy * hy + hz * hz)
