"""What an ideal IMU at a site measures: the specific force and the angular velocity, in the site's axes.

REP-145 conventions: the accelerometer measures the *specific force*, the acceleration of the
sensor minus gravity (zero in free fall, +g upward at rest), in the sensor's axes; the gyroscope
the angular velocity of the sensor's frame, in its axes. At a site r (from the centre of mass)
of a rigid body,

    a_site = a_C + ω̇ × r + ω × (ω × r),        specific force = a_site − g,

with a_C and ω̇ those the body's model gives it at its state under the wrenches of the step it
just took (dynamics.derivative — with a persistent contact carried in the wrench row, its
force found at the state read — and the constraints of static, kinematic, planar and
translation-only bodies: a body that cannot move has a = 0, so at rest it reads +g upward).
A site's axes are the body's axes B, or world axes if the site says ``axes: world``.
Noise, bias and rates belong to the sensor model that uses these readings.
"""

from __future__ import annotations

from numba import njit

from .contact.stage import held_acceleration
from .dynamics import angular_acceleration
from .forces import body_wrench
from .jit import INLINE, JIT
from .layout import (
    DAMP_ANG,
    DAMP_LIN,
    HELD,
    INERTIA_NORMAL,
    INV_MASS,
    MODEL,
    MODEL_KINEMATIC,
    MODEL_PLANAR,
    MODEL_STATIC,
    MODEL_TRANSLATION,
    NORMAL,
    P,
    Q,
    Q_PB,
    V,
    W,
)
from .rotation import qmul, rotate, rotate_back

__all__ = ["body_acceleration", "site_readings"]


@njit(**INLINE)
def body_acceleration(y, p, w):
    """(a_C, world axes, m/s²; ω̇, principal axes, rad/s²) of a body at state row ``y`` under wrench row ``w``.

    As its model moves it: nothing for static and kinematic bodies (a constant twist), no
    spin-up for translation-only ones, the in-plane motion and the spin about the normal for
    planar ones, the Newton–Euler equations otherwise.
    """
    model = p[MODEL]
    fx, fy, fz, tx, ty, tz = body_wrench(y, p, w)  # gravity included, projected onto the motion
    inv_m = p[INV_MASS]
    rate = p[DAMP_LIN] * inv_m
    ax, ay, az = fx * inv_m - rate * y[V], fy * inv_m - rate * y[V + 1], fz * inv_m - rate * y[V + 2]
    bx, by, bz = angular_acceleration(p, y[W], y[W + 1], y[W + 2], tx, ty, tz)
    if w[HELD] != 0.0:  # a persistent contact carried in the row: its force at this state (contact/stage.py)
        ax, ay, az, bx, by, bz = held_acceleration(y, p, w, ax, ay, az, bx, by, bz)
    if model == MODEL_STATIC or model == MODEL_KINEMATIC:
        ax, ay, az, bx, by, bz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    elif model == MODEL_TRANSLATION:
        bx, by, bz = 0.0, 0.0, 0.0
    elif model == MODEL_PLANAR:  # ω stays along n: I_n ω̇_n = τ·n − c ω_n
        nx, ny, nz = p[NORMAL], p[NORMAL + 1], p[NORMAL + 2]
        qw, qx, qy, qz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
        t_W = rotate(qw, qx, qy, qz, tx, ty, tz)
        w_W = rotate(qw, qx, qy, qz, y[W], y[W + 1], y[W + 2])
        w_n = w_W[0] * nx + w_W[1] * ny + w_W[2] * nz
        alpha = (t_W[0] * nx + t_W[1] * ny + t_W[2] * nz - p[DAMP_ANG] * w_n) / p[INERTIA_NORMAL]
        bx, by, bz = rotate_back(qw, qx, qy, qz, alpha * nx, alpha * ny, alpha * nz)
    _pin = y[P], p[0], w[0]  # the arrays' last use, out of the branches (jit.py)
    return ax, ay, az, bx, by, bz


@njit(**JIT)
def site_readings(Y, prm, wrenches, gravity, site_body, site_arm_P, site_world_axes, out):
    """Ideal IMU readings at sites: out[s] ← (specific force (3), angular velocity (3), q_WS (4, w x y z)).

    ``Y`` state rows, ``prm`` parameter rows, ``wrenches`` the rows of the step just taken,
    ``gravity`` the scene's g (3, world axes, not projected: a sensor feels the real one);
    per site: its body, its position from the COM in principal axes, and whether its axes are
    world axes (else the body's axes B). Forces and rates are in the site's axes.
    """
    for s in range(site_body.shape[0]):
        i = site_body[s]
        y, p = Y[i], prm[i]
        ax, ay, az, bx, by, bz = body_acceleration(y, p, wrenches[i])
        wx, wy, wz = y[W], y[W + 1], y[W + 2]
        rx, ry, rz = site_arm_P[s, 0], site_arm_P[s, 1], site_arm_P[s, 2]
        # ω × r and ω × (ω × r), ω̇ × r: principal axes
        ux, uy, uz = wy * rz - wz * ry, wz * rx - wx * rz, wx * ry - wy * rx
        cx = by * rz - bz * ry + (wy * uz - wz * uy)
        cy = bz * rx - bx * rz + (wz * ux - wx * uz)
        cz = bx * ry - by * rx + (wx * uy - wy * ux)
        qw, qx, qy, qz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
        c_W = rotate(qw, qx, qy, qz, cx, cy, cz)
        fx = ax + c_W[0] - gravity[0]
        fy = ay + c_W[1] - gravity[1]
        fz = az + c_W[2] - gravity[2]
        if site_world_axes[s]:
            w_S = rotate(qw, qx, qy, qz, wx, wy, wz)
            f_S = (fx, fy, fz)
            q_WS = (1.0, 0.0, 0.0, 0.0)
        else:  # the body's axes B: q_WB = q_WP ⊗ q_PB
            q_WS = qmul(qw, qx, qy, qz, p[Q_PB], p[Q_PB + 1], p[Q_PB + 2], p[Q_PB + 3])
            w_S = rotate(p[Q_PB], -p[Q_PB + 1], -p[Q_PB + 2], -p[Q_PB + 3], wx, wy, wz)
            f_S = rotate_back(q_WS[0], q_WS[1], q_WS[2], q_WS[3], fx, fy, fz)
        for j in range(3):
            out[s, j] = f_S[j]
            out[s, 3 + j] = w_S[j]
        for j in range(4):
            out[s, 6 + j] = q_WS[j]
