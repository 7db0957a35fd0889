"""The floor and the do-it-yourself loop: what the same step costs as a plain compiled loop, and in plain numpy.

Floors (numba, compiled like our kernels, ``fastmath`` off like them): one loop over bodies
doing the same step as ours with nothing else — no blow-up checks, no wrench resolution, no
model dispatch, no double buffer, no index list. The state is one (N, 13) array of rows
(p_WC_W, q_WB (w, x, y, z), v_WC_W, w_B), the inertia an (N, 3) array of principal moments,
the bodies torque- and force-free (the throughput problem):

* :func:`euler_floor`: explicit Euler with the gyroscopic term in principal axes,
  ``w += dt I⁻¹(−w × I w)``, ``q += dt ½ q ⊗ (0, w)`` then normalise, ``p += dt v``;
* :func:`rk4_floor`: classic RK4 on the same 13 components, q normalised after the step.

The do-it-yourself loop (:class:`NumpyBodies`): the step a user writes in plain numpy, one
body at a time, as in the textbook loop this product started from (a force and a torque
accumulator per body, cleared each step; here with the gyroscopic term): per body a few small
numpy arrays and calls. ``euler`` and ``rk4`` variants, the same formulas as the floors.

Both are checked against our integrators on the same problem in test/test_bench_smoke.py
(the same step to round-off), so the comparison is like for like.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


# ----------------------------------------------------------------------------- compiled floors


@njit(cache=True, inline="always")
def _rates(qw, qx, qy, qz, wx, wy, wz, I1, I2, I3):
    """(dq/dt, dw/dt) of a torque-free body: ½ q ⊗ (0, w) and I⁻¹(−w × I w)."""
    dqw = 0.5 * (-qx * wx - qy * wy - qz * wz)
    dqx = 0.5 * (qw * wx + qy * wz - qz * wy)
    dqy = 0.5 * (qw * wy - qx * wz + qz * wx)
    dqz = 0.5 * (qw * wz + qx * wy - qy * wx)
    hx, hy, hz = I1 * wx, I2 * wy, I3 * wz
    dwx = -(wy * hz - wz * hy) / I1
    dwy = -(wz * hx - wx * hz) / I2
    dwz = -(wx * hy - wy * hx) / I3
    return dqw, dqx, dqy, dqz, dwx, dwy, dwz


@njit(cache=True)
def euler_floor(Y, inertia, dt, n_steps):
    """``n_steps`` explicit Euler steps of every row of Y (N, 13), in place; inertia (N, 3)."""
    for _ in range(n_steps):
        for i in range(Y.shape[0]):
            y = Y[i]
            qw, qx, qy, qz = y[3], y[4], y[5], y[6]
            wx, wy, wz = y[10], y[11], y[12]
            dqw, dqx, dqy, dqz, dwx, dwy, dwz = _rates(qw, qx, qy, qz, wx, wy, wz,
                                                       inertia[i, 0], inertia[i, 1], inertia[i, 2])
            y[0] += dt * y[7]
            y[1] += dt * y[8]
            y[2] += dt * y[9]
            qw += dt * dqw
            qx += dt * dqx
            qy += dt * dqy
            qz += dt * dqz
            n = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
            y[3], y[4], y[5], y[6] = qw / n, qx / n, qy / n, qz / n
            y[10], y[11], y[12] = wx + dt * dwx, wy + dt * dwy, wz + dt * dwz


@njit(cache=True)
def rk4_floor(Y, inertia, dt, n_steps):
    """``n_steps`` classic RK4 steps of every row of Y (N, 13), in place; q normalised after each step."""
    h2, h6 = 0.5 * dt, dt / 6.0
    for _ in range(n_steps):
        for i in range(Y.shape[0]):
            y = Y[i]
            I1, I2, I3 = inertia[i, 0], inertia[i, 1], inertia[i, 2]
            qw, qx, qy, qz = y[3], y[4], y[5], y[6]
            wx, wy, wz = y[10], y[11], y[12]
            vx, vy, vz = y[7], y[8], y[9]
            a = _rates(qw, qx, qy, qz, wx, wy, wz, I1, I2, I3)
            b = _rates(qw + h2 * a[0], qx + h2 * a[1], qy + h2 * a[2], qz + h2 * a[3],
                       wx + h2 * a[4], wy + h2 * a[5], wz + h2 * a[6], I1, I2, I3)
            c = _rates(qw + h2 * b[0], qx + h2 * b[1], qy + h2 * b[2], qz + h2 * b[3],
                       wx + h2 * b[4], wy + h2 * b[5], wz + h2 * b[6], I1, I2, I3)
            d = _rates(qw + dt * c[0], qx + dt * c[1], qy + dt * c[2], qz + dt * c[3],
                       wx + dt * c[4], wy + dt * c[5], wz + dt * c[6], I1, I2, I3)
            # force-free: v is constant, so p += dt v exactly as RK4 gives it
            y[0] += dt * vx
            y[1] += dt * vy
            y[2] += dt * vz
            qw += h6 * (a[0] + 2.0 * (b[0] + c[0]) + d[0])
            qx += h6 * (a[1] + 2.0 * (b[1] + c[1]) + d[1])
            qy += h6 * (a[2] + 2.0 * (b[2] + c[2]) + d[2])
            qz += h6 * (a[3] + 2.0 * (b[3] + c[3]) + d[3])
            n = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
            y[3], y[4], y[5], y[6] = qw / n, qx / n, qy / n, qz / n
            y[10] = wx + h6 * (a[4] + 2.0 * (b[4] + c[4]) + d[4])
            y[11] = wy + h6 * (a[5] + 2.0 * (b[5] + c[5]) + d[5])
            y[12] = wz + h6 * (a[6] + 2.0 * (b[6] + c[6]) + d[6])


FLOORS = {"euler": euler_floor, "rk4": rk4_floor}


def initial_rows(count: int, angular_velocity_body: np.ndarray, spacing: float = 10.0) -> np.ndarray:
    """(N, 13) rows of the throughput problem: body i at (spacing·i, 0, 0), identity q, at rest, spinning."""
    Y = np.zeros((count, 13))
    Y[:, 0] = spacing * np.arange(count)
    Y[:, 3] = 1.0
    Y[:, 10:13] = angular_velocity_body
    return Y


# ----------------------------------------------------------------------------- the do-it-yourself loop


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of (w, x, y, z) quaternions, as a user writes it."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw])


class NumpyBodies:
    """Bodies as a list of small numpy arrays, stepped one body at a time (the user's own loop).

    ``method`` is ``"euler"`` or ``"rk4"``. Each body has a force and a torque accumulator
    (world axes, cleared after each step), as in the textbook loop.
    """

    def __init__(self, rows: np.ndarray, inertia: np.ndarray, mass: np.ndarray, method: str = "euler"):
        if method not in ("euler", "rk4"):
            raise ValueError(f"`method` must be one of ('euler', 'rk4'), got {method!r}")
        self.method = method
        self.x = [r[0:3].copy() for r in rows]
        self.q = [r[3:7].copy() for r in rows]
        self.v = [r[7:10].copy() for r in rows]
        self.w = [r[10:13].copy() for r in rows]
        self.inertia = [np.array(I, float) for I in inertia]
        self.mass = [float(m) for m in mass]
        self.force = [np.zeros(3) for _ in rows]
        self.torque = [np.zeros(3) for _ in rows]

    def rows(self) -> np.ndarray:
        return np.array([np.concatenate((x, q, v, w)) for x, q, v, w in zip(self.x, self.q, self.v, self.w)])

    @staticmethod
    def _derivative(q, v, w, I, m, force_W, torque_W):
        # torque into body axes: R(q)ᵀ τ
        q_conj = q * np.array([1.0, -1.0, -1.0, -1.0])
        torque_B = _qmul(_qmul(q_conj, np.concatenate(([0.0], torque_W))), q)[1:]
        dw = (torque_B - np.cross(w, I * w)) / I
        dq = 0.5 * _qmul(q, np.concatenate(([0.0], w)))
        dv = force_W / m
        return v, dq, dv, dw

    def step(self, dt: float) -> None:
        for i in range(len(self.x)):
            x, q, v, w = self.x[i], self.q[i], self.v[i], self.w[i]
            I, m, F, T = self.inertia[i], self.mass[i], self.force[i], self.torque[i]
            if self.method == "euler":
                dx, dq, dv, dw = self._derivative(q, v, w, I, m, F, T)
                x, q, v, w = x + dt * dx, q + dt * dq, v + dt * dv, w + dt * dw
            else:
                k1 = self._derivative(q, v, w, I, m, F, T)
                k2 = self._derivative(q + 0.5 * dt * k1[1], v + 0.5 * dt * k1[2], w + 0.5 * dt * k1[3], I, m, F, T)
                k3 = self._derivative(q + 0.5 * dt * k2[1], v + 0.5 * dt * k2[2], w + 0.5 * dt * k2[3], I, m, F, T)
                k4 = self._derivative(q + dt * k3[1], v + dt * k3[2], w + dt * k3[3], I, m, F, T)
                x, q, v, w = (s + dt / 6.0 * (a + 2.0 * (b + c) + d)
                              for s, a, b, c, d in zip((x, q, v, w), k1, k2, k3, k4))
            self.x[i], self.q[i], self.v[i], self.w[i] = x, q / np.linalg.norm(q), v, w
            F[:] = 0.0
            T[:] = 0.0
