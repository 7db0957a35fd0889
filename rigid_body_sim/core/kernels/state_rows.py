"""Every body's pose and twist in the user's conventions, in one compiled pass (what a batch message carries).

:func:`pose_twist_rows` writes, for each body of the state rows ``Y`` (layout.py), the pose row
(x, y, z, qx, qy, qz, qw) of its body frame B in the world and the twist row (v, ω), both in
world axes, and whether its 13 state numbers are finite. The arithmetic is that of
core/quaternion.py's numpy functions, operation for operation (q_WB = q_WP ⊗ conj(q_BP);
ω_W = w + 2 w₀ (u × w) + u × (2 u × w)), so the results are bitwise those of
Simulator.positions_world, orientations_xyzw, linear_velocities_world and
angular_velocities_world: at 10⁵ bodies one pass instead of a dozen numpy temporaries.
"""

from __future__ import annotations

import math

from numba import njit

from .jit import JIT
from .layout import P, Q, STATE_WIDTH, V, W

__all__ = ["pose_twist_rows"]


@njit(**JIT)
def pose_twist_rows(Y, q_BP, poses, twists, finite):
    """Fill ``poses`` (N, ≥7), ``twists`` (N, ≥6; columns 0–5) and ``finite`` (N,) bool from ``Y`` (N, ROW_WIDTH) and ``q_BP`` (N, 4)."""
    for i in range(Y.shape[0]):
        y = Y[i]
        ok = True
        for j in range(STATE_WIDTH):
            ok = ok and math.isfinite(y[j])
        finite[i] = ok
        pw, px, py, pz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
        qw, qx, qy, qz = q_BP[i, 0], -q_BP[i, 1], -q_BP[i, 2], -q_BP[i, 3]
        out = poses[i]
        out[0], out[1], out[2] = y[P], y[P + 1], y[P + 2]
        out[6] = pw * qw - px * qx - py * qy - pz * qz
        out[3] = pw * qx + px * qw + py * qz - pz * qy
        out[4] = pw * qy - px * qz + py * qw + pz * qx
        out[5] = pw * qz + px * qy - py * qx + pz * qw
        v0, v1, v2 = y[W], y[W + 1], y[W + 2]
        t0 = 2.0 * (py * v2 - pz * v1)
        t1 = 2.0 * (pz * v0 - px * v2)
        t2 = 2.0 * (px * v1 - py * v0)
        tw = twists[i]
        tw[0], tw[1], tw[2] = y[V], y[V + 1], y[V + 2]
        tw[3] = v0 + pw * t0 + (py * t2 - pz * t1)
        tw[4] = v1 + pw * t1 + (pz * t0 - px * t2)
        tw[5] = v2 + pw * t2 + (px * t1 - py * t0)
