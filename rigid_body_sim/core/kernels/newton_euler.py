"""The Newton–Euler equations of a free rigid body under its wrench row, written once (compiled).

In the principal frame P (diagonal inertia I = (I1, I2, I3)):

    m · dv_W/dt      = F_W − c_v v_W                        (F_W includes m g)
    I · dw_P/dt      = τ_P − c_w w_P − w_P × (I w_P)        ← the gyroscopic term
    dp_W/dt          = v_W
    dq_WP/dt         = ½ q_WP ⊗ (0, w_P)                    (w, x, y, z)

``F_W`` and ``τ_P`` are what :func:`~rigid_body_sim.core.kernels.forces.body_wrench` returns for
the state at hand: the applied wrenches evaluated in their frames, plus gravity. The gyroscopic
term is what makes a phone flip about its intermediate axis; leaving it out is the classic
textbook bug. :func:`free_derivative` is these equations without contact;
dynamics.derivative, the right-hand side every integrator stage calls, is this plus the held
contact of a body in persistent contact (kernels/contact/stage.py), which needs these
equations to find its force: so they live here, below both.
"""

from __future__ import annotations

from numba import njit

from .forces import body_wrench
from .layout import DAMP_ANG, DAMP_LIN, INERTIA, INV_INERTIA, INV_MASS, P, Q, V, W
from .jit import INLINE

__all__ = ["gyroscopic_torque", "angular_acceleration", "free_derivative"]


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
def free_derivative(y, p, w, d):
    """d ← dy/dt of one body without its held contact: state row ``y``, parameter row ``p``, wrench row ``w``."""
    fx, fy, fz, tx, ty, tz = body_wrench(y, p, w)
    qw, qx, qy, qz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
    wx, wy, wz = y[W], y[W + 1], y[W + 2]
    vx, vy, vz = y[V], y[V + 1], y[V + 2]
    d[P], d[P + 1], d[P + 2] = vx, vy, vz
    d[Q] = 0.5 * (-qx * wx - qy * wy - qz * wz)
    d[Q + 1] = 0.5 * (qw * wx + qy * wz - qz * wy)
    d[Q + 2] = 0.5 * (qw * wy - qx * wz + qz * wx)
    d[Q + 3] = 0.5 * (qw * wz + qx * wy - qy * wx)
    inv_m = p[INV_MASS]
    rate = p[DAMP_LIN] * inv_m
    d[V] = fx * inv_m - rate * vx
    d[V + 1] = fy * inv_m - rate * vy
    d[V + 2] = fz * inv_m - rate * vz
    d[W], d[W + 1], d[W + 2] = angular_acceleration(p, wx, wy, wz, tx, ty, tz)
