"""The right-hand side of a body's equations of motion (compiled; energy and momentum: core/mechanics.py).

:func:`derivative` is the one implementation; every integrator that needs the right-hand side
calls it at each of its stages, the scipy ``reference`` included. It is the Newton–Euler
equations of a free rigid body (newton_euler.py, where they are written once, with the
gyroscopic term) under the body's wrench row, plus, for a body in persistent contact whose
wrench row holds the contact (layout.HELD), the force that holds it on the ground found
from the stage's own state (kernels/contact/stage.py). Bodies without a held contact take
the free equations alone: one branch on one column of the row.
"""

from __future__ import annotations

import math

from numba import njit

from .contact.stage import held_accelerations
from .forces import resolve_wrench
from .layout import HELD, INERTIA_NORMAL, INV_INERTIA, INV_MASS, MODEL, MODEL_PLANAR, NORMAL, P, Q, V, W
from .jit import INLINE, JIT
from .newton_euler import angular_acceleration, free_derivative, gyroscopic_torque
from .rotation import normalise, rotate_back

__all__ = [
    "gyroscopic_torque",
    "angular_acceleration",
    "free_derivative",
    "derivative",
    "derivatives",
    "impulse_response",
]


@njit(**INLINE)
def derivative(y, p, w, d):
    """d ← dy/dt of one body: state row ``y``, parameter row ``p``, wrench row ``w`` (layout.py).

    The Newton–Euler equations (newton_euler.free_derivative) and, for a body whose wrench row
    holds a persistent contact (``w[HELD]`` not 0), the contact force that holds it found at
    this state (contact/stage.held_accelerations): at every stage of the methods that call this.
    """
    free_derivative(y, p, w, d)
    if w[HELD] != 0.0:
        held_accelerations(y, p, w, d)
    _pin = y[P], p[0], w[HELD], d[P]  # the arrays' last use, out of the branch (jit.py)


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
