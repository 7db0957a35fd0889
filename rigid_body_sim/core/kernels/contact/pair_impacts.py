"""Compiled impact law between two bodies: the ground law of impacts.py with both bodies moving.

The same two-phase law (compression: the inelastic frictional impulse, solved by impacts.pgs
on the 3 × 3 blocks of A; restitution: Poisson's normal impulse e·λ_n, frictionless, capped
so that the kinetic energy never rises; a second compression if one contact's restitution
drove another together), on the relative velocity of body b with respect to body a at each
contact point. The normal n points from a to b (pairs.py); the impulse λ acts on b and −λ on
a, so the rows of the contact Jacobian are (−d, −(r_a × d)) for a and (d, r_b × d) for b, and
A = J_a M_a⁻¹ J_aᵀ + J_b M_b⁻¹ J_bᵀ. Velocities change, positions do not.

State rows y (layout.py: p_WC_W, q_WP, v_WC_W, ω_WP_P), parameter rows p; contact points in
world axes (m). ``jac`` is the caller's scratch (3 MAX_POINTS, 12), ``work`` impacts'
(IMPACT_WORK_SHAPE).
"""

from __future__ import annotations


from numba import njit

from ..jit import INLINE, JIT
from ..layout import INV_INERTIA, INV_MASS, P, Q, V, W
from ..rotation import rotate, rotate_back
from .impacts import (_A, _B, _LAM, _SAVED, APPROACH_LEFT, frictionless_after_short, kinetic_energy_row, pgs,
                      restitution, row_direction, tangents)
from .layout import MAX_POINTS

__all__ = ["PAIR_JACOBIAN_SHAPE", "normal_speed", "pair_rows", "pair_impact"]

#: Shape of the Jacobian scratch: per row, a's linear (3) and angular (3, principal axes), then b's.
PAIR_JACOBIAN_SHAPE = (3 * MAX_POINTS, 12)


@njit(**INLINE)
def normal_speed(ya, yb, nx, ny, nz, x, y, z):
    """The normal velocity (m/s, < 0 approaching) of body b over body a at world point (x, y, z), normal n from a
    to b, at state rows ya, yb."""
    u = 0.0
    for row, sign in ((ya, -1.0), (yb, 1.0)):
        wx, wy, wz = rotate(row[Q], row[Q + 1], row[Q + 2], row[Q + 3], row[W], row[W + 1], row[W + 2])
        rx, ry, rz = x - row[P], y - row[P + 1], z - row[P + 2]
        u += sign * ((row[V] + wy * rz - wz * ry) * nx + (row[V + 1] + wz * rx - wx * rz) * ny
                     + (row[V + 2] + wx * ry - wy * rx) * nz)
    return u


@njit(**JIT)
def pair_rows(ya, pa, yb, pb, count, points, nx, ny, nz, jac, work):
    """Rows (n, t1, t2 per contact) of the pair's Jacobian, A and b = J u (relative velocities of b over a)."""
    t1x, t1y, t1z, t2x, t2y, t2z = tangents(nx, ny, nz)
    rows = 3 * count
    for c in range(count):
        rax, ray, raz = points[c, 0] - ya[P], points[c, 1] - ya[P + 1], points[c, 2] - ya[P + 2]
        rbx, rby, rbz = points[c, 0] - yb[P], points[c, 1] - yb[P + 1], points[c, 2] - yb[P + 2]
        for k in range(3):
            dx, dy, dz = row_direction(k, nx, ny, nz, t1x, t1y, t1z, t2x, t2y, t2z)
            row = 3 * c + k
            aa = rotate_back(ya[Q], ya[Q + 1], ya[Q + 2], ya[Q + 3],
                             ray * dz - raz * dy, raz * dx - rax * dz, rax * dy - ray * dx)
            ab = rotate_back(yb[Q], yb[Q + 1], yb[Q + 2], yb[Q + 3],
                             rby * dz - rbz * dy, rbz * dx - rbx * dz, rbx * dy - rby * dx)
            jac[row, 0], jac[row, 1], jac[row, 2] = -dx, -dy, -dz
            jac[row, 3], jac[row, 4], jac[row, 5] = -aa[0], -aa[1], -aa[2]
            jac[row, 6], jac[row, 7], jac[row, 8] = dx, dy, dz
            jac[row, 9], jac[row, 10], jac[row, 11] = ab[0], ab[1], ab[2]
    for a in range(rows):
        u = 0.0
        for j in range(3):
            u += jac[a, j] * ya[V + j] + jac[a, 3 + j] * ya[W + j] + jac[a, 6 + j] * yb[V + j] + jac[a, 9 + j] * yb[W + j]
        work[a, _B] = u
        for b in range(rows):
            s = 0.0
            for j in range(3):
                s += pa[INV_MASS] * jac[a, j] * jac[b, j] + pb[INV_MASS] * jac[a, 6 + j] * jac[b, 6 + j]
                s += pa[INV_INERTIA + j] * jac[a, 3 + j] * jac[b, 3 + j] + pb[INV_INERTIA + j] * jac[a, 9 + j] * jac[b, 9 + j]
            work[a, _A + b] = s
    return rows


@njit(**JIT)
def _apply(y0a, ya, pa, y0b, yb, pb, jac, work, rows, column):
    """Both bodies' velocities ← their y0's + M⁻¹ Jᵀ work[:, column]."""
    for j in range(3):
        dva = dwa = dvb = dwb = 0.0
        for a in range(rows):
            lam = work[a, column]
            dva += jac[a, j] * lam
            dwa += jac[a, 3 + j] * lam
            dvb += jac[a, 6 + j] * lam
            dwb += jac[a, 9 + j] * lam
        ya[V + j] = y0a[V + j] + dva * pa[INV_MASS]
        ya[W + j] = y0a[W + j] + dwa * pa[INV_INERTIA + j]
        yb[V + j] = y0b[V + j] + dvb * pb[INV_MASS]
        yb[W + j] = y0b[W + j] + dwb * pb[INV_INERTIA + j]


@njit(**JIT)
def _energy(ya, pa, yb, pb):
    return kinetic_energy_row(ya, pa) + kinetic_energy_row(yb, pb)


@njit(**JIT)
def pair_impact(y0a, ya, pa, y0b, yb, pb, count, points, nx, ny, nz, e, mu, jac, work):
    """ya, yb ← y0a, y0b after the impact of ``count`` simultaneous contacts between a and b.

    Returns (Σ normal impulse on b, N·s; kinetic energy of both before, J; after, J; the
    restitution factor used).
    """
    for j in range(ya.shape[0]):
        ya[j] = y0a[j]
        yb[j] = y0b[j]
    rows = pair_rows(y0a, pa, y0b, pb, count, points, nx, ny, nz, jac, work)
    before = _energy(y0a, pa, y0b, pb)
    approach = 0.0  # the fastest approach (m/s, ≤ 0)
    for a in range(rows):
        work[a, _LAM] = 0.0
        if a % 3 == 0:
            approach = min(approach, work[a, _B])
    pgs(work, count, mu, 0.0, 0.0)
    _apply(y0a, ya, pa, y0b, yb, pb, jac, work, rows, _LAM)
    compressed = _energy(ya, pa, yb, pb)
    if compressed > before:  # not dissipative: the frictionless compression, monotone in the energy
        for a in range(rows):
            work[a, _LAM] = 0.0
        pgs(work, count, 0.0, 0.0, 0.0)
        _apply(y0a, ya, pa, y0b, yb, pb, jac, work, rows, _LAM)
        compressed = _energy(ya, pa, yb, pb)
    # restitution: the normal multipliers scaled by α ≤ e, E(α) = E1 + α λ_nᵀ u1 + ½ α² λ_nᵀ A λ_n ≤ E0
    for a in range(rows):
        work[a, _SAVED] = work[a, _LAM] if a % 3 == 0 else 0.0
    linear = 0.0  # λ_nᵀ u1
    for a in range(0, rows, 3):
        u1 = 0.0
        for j in range(3):
            u1 += jac[a, j] * ya[V + j] + jac[a, 3 + j] * ya[W + j] + jac[a, 6 + j] * yb[V + j] + jac[a, 9 + j] * yb[W + j]
        linear += work[a, _SAVED] * u1
    alpha, total = restitution(work, rows, linear, before, compressed, e)
    _apply(y0a, ya, pa, y0b, yb, pb, jac, work, rows, _LAM)
    after = _energy(ya, pa, yb, pb)
    if after > before:  # round-off of the cap: the compression alone
        for a in range(0, rows, 3):
            work[a, _LAM] -= alpha * work[a, _SAVED]
        _apply(y0a, ya, pa, y0b, yb, pb, jac, work, rows, _LAM)
        after = _energy(ya, pa, yb, pb)
        alpha = 0.0
    # one contact's restitution can drive another together: a second compression from there; where Gauss–Seidel
    # with friction leaves it short (a contact still approaching faster than impacts.APPROACH_LEFT × the fastest
    # approach, before the impact or before this compression), a frictionless one follows
    pair_rows(ya, pa, yb, pb, count, points, nx, ny, nz, jac, work)
    again = 0.0
    for a in range(0, rows, 3):
        again = min(again, work[a, _B])
    if again < 0.0:
        mid = after
        for a in range(rows):
            work[a, _SAVED] = 0.0
            work[a, _LAM] = 0.0
        pgs(work, count, mu, 0.0, 0.0)
        _apply(ya, ya, pa, yb, yb, pb, jac, work, rows, _LAM)
        if _energy(ya, pa, yb, pb) > mid:  # not dissipative: undo, and the frictionless one instead
            for a in range(rows):
                work[a, _LAM] = -work[a, _LAM]
            _apply(ya, ya, pa, yb, yb, pb, jac, work, rows, _LAM)
            for a in range(rows):
                work[a, _LAM] = 0.0
            pgs(work, count, 0.0, 0.0, 0.0)
            _apply(ya, ya, pa, yb, yb, pb, jac, work, rows, _LAM)
        else:  # short of stopping every approach: a frictionless compression from there takes out what is left
            first = frictionless_after_short(work, rows, count, APPROACH_LEFT * min(approach, again))
            if first >= 0.0:
                total += first
                _apply(ya, ya, pa, yb, yb, pb, jac, work, rows, _LAM)
        for a in range(0, rows, 3):
            total += work[a, _LAM]
        after = _energy(ya, pa, yb, pb)
    return total, before, after, alpha
