"""Compiled impact law for one body against the ground: one or several simultaneous contacts, Coulomb friction, spin.

The law, for contact points r_c (from the centre of mass) with the ground normal n, tangents
t1, t2, coefficients e (restitution) and μ (friction):

1. **Compression** — the inelastic frictional impulse: per contact λ_c = λ_n n + λ_t with
   λ_n ≥ 0, post-compression normal velocity u_n ≥ 0 and λ_n u_n = 0, and |λ_t| ≤ μ λ_n with
   λ_t opposing the post-compression slip when it slides (Coulomb, maximal dissipation). Solved
   by projected Gauss–Seidel on the contacts' 3 × 3 blocks of A = J M⁻¹ Jᵀ (:func:`pgs`) to
   round-off. At its solution the energy change is λᵀu − ½ λᵀAλ ≤ 0.
2. **Restitution** — Poisson's normal impulse e·λ_n on each contact, frictionless (for a
   frictionless or non-slipping impact this is exactly Newton's v⁺_n = −e v⁻_n, and for one
   frictionless contact P = −(1 + e) v_n / (1/m + (r × n)·I⁻¹(r × n))). Where friction couples
   it to the tangential motion so that it would raise the energy above the pre-impact value
   (Kane's paradox configurations), the restitution impulse is scaled down to the largest that
   does not: the kinetic energy never rises at an impact (Stronge's energetic bound).
3. If the frictional compression did not converge to a dissipative solution (never seen; it
   would take a degenerate A), the frictionless compression is used instead: projected
   Gauss–Seidel on λ_n ≥ 0 alone decreases ½ λᵀAλ + λᵀb, which *is* the energy change, at
   every update, so it cannot gain energy.
4. With several contacts, one contact's restitution impulse can push another into the ground;
   then a second compression from the state after restitution removes every approach again
   (dissipative, like the first). Where Gauss–Seidel with friction stops far short of that (a
   contact still approaching faster than APPROACH_LEFT × the fastest approach), a frictionless
   compression from there follows. So no contact point leaves an impact approaching the ground
   (beyond that fraction of its approach).

Velocities change, positions do not. Everything is in world axes except the body's angular
velocity row (principal axes P, layout.py). ``work`` is the caller's scratch (IMPACT_WORK_SHAPE).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..layout import GRAVITY, INERTIA, INV_INERTIA, INV_MASS, MASS, P, Q, V, W
from ..rotation import rotate_back
from .layout import MAX_POINTS

__all__ = ["IMPACT_WORK_SHAPE", "restitution", "PGS_MAX_SWEEPS", "PGS_TOLERANCE", "tangents", "build_rows",
           "build_rows_normals", "row_direction", "pgs", "pgs_each",
           "kinetic_energy_row", "potential_energy_row", "apply_impulses", "frictionless_after_short", "impact",
           "summed_wrench"]

_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}

_ROWS = 3 * MAX_POINTS
# work columns: lin (3), ang_P (3), A (3 MAX_POINTS), b, λ, λ saved, u
_LIN, _ANG, _A = 0, 3, 6
_B = _A + _ROWS
_LAM = _B + 1
_SAVED = _B + 2
_U = _B + 3
#: Shape of the scratch array :func:`impact` and the persistent solve take.
IMPACT_WORK_SHAPE = (_ROWS, _U + 1)
#: Projected Gauss–Seidel: at most this many sweeps, until no multiplier moves by more than the tolerance × their size.
PGS_MAX_SWEEPS = 2000
PGS_TOLERANCE = 1e-15
#: A second compression with friction after which a contact still approaches faster than this × the fastest
#: approach (before the impact or before that compression) fell short (Gauss–Seidel unconverged): a frictionless
#: compression follows it (:func:`impact`, pair_impacts.pair_impact). Far above what Gauss–Seidel leaves on points
#: that span more rows than the body has freedoms (at 1e-9, a 1000-cube pile no longer came to rest where it landed).
APPROACH_LEFT = 1e-3


@njit(**_OPTS)
def tangents(nx, ny, nz):
    """Two unit tangents t1, t2 with (n, t1, t2) right-handed orthonormal."""
    if abs(nx) < 0.6:
        ax, ay, az = 1.0, 0.0, 0.0
    else:
        ax, ay, az = 0.0, 1.0, 0.0
    # t1 = a × n normalised, t2 = n × t1
    tx, ty, tz = ay * nz - az * ny, az * nx - ax * nz, ax * ny - ay * nx
    s = math.sqrt(tx * tx + ty * ty + tz * tz)
    tx, ty, tz = tx / s, ty / s, tz / s
    return tx, ty, tz, ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx


@njit(**_OPTS)
def summed_wrench(work, rows):
    """(fx, fy, fz, hx, hy, hz): Σ λ × row over the first ``rows`` rows of ``work`` (as
    :func:`build_rows` fills it and a solve sets λ): the force in world axes and its moment about
    the centre of mass in principal axes."""
    fx = fy = fz = 0.0
    hx = hy = hz = 0.0
    for a in range(rows):
        lam = work[a, _LAM]
        fx += work[a, _LIN] * lam
        fy += work[a, _LIN + 1] * lam
        fz += work[a, _LIN + 2] * lam
        hx += work[a, _ANG] * lam
        hy += work[a, _ANG + 1] * lam
        hz += work[a, _ANG + 2] * lam
    return fx, fy, fz, hx, hy, hz


@njit(**_OPTS)
def build_rows(y, p, count, points, nx, ny, nz, work):
    """Rows (n, t1, t2 per contact) of the contact Jacobian, A = J M⁻¹ Jᵀ and b = J u (the contact velocities).

    Row k: ``lin`` its direction d (world), ``ang`` (r × d) in principal axes, so that
    d·(v + ω × r) = d·v + ang·ω_P and M⁻¹ takes a unit impulse along row k to
    (d/m, ang/I). Returns the number of rows.
    """
    t1x, t1y, t1z, t2x, t2y, t2z = tangents(nx, ny, nz)
    for c in range(count):
        _contact_rows(y, points, c, nx, ny, nz, t1x, t1y, t1z, t2x, t2y, t2z, work)
    return _mass_rows(y, p, 3 * count, work)


@njit(**_OPTS)
def build_rows_normals(y, p, count, points, normals, t1x, t1y, t1z, work):
    """:func:`build_rows` with a normal per contact (``normals`` (count, 3), world) and one t1 for all of them
    (unit, across every normal: the crease of two planes, two_grounds.py); each contact's t2 = n × t1."""
    for c in range(count):
        nx, ny, nz = normals[c, 0], normals[c, 1], normals[c, 2]
        _contact_rows(y, points, c, nx, ny, nz, t1x, t1y, t1z, ny * t1z - nz * t1y, nz * t1x - nx * t1z,
                      nx * t1y - ny * t1x, work)
    return _mass_rows(y, p, 3 * count, work)


@njit(**_OPTS, inline="always")
def row_direction(k, nx, ny, nz, t1x, t1y, t1z, t2x, t2y, t2z):
    """The direction (world) of a contact's row k: 0 its normal n, 1 its t1, 2 its t2."""
    if k == 0:
        return nx, ny, nz
    if k == 1:
        return t1x, t1y, t1z
    return t2x, t2y, t2z


@njit(**_OPTS)
def _contact_rows(y, points, c, nx, ny, nz, t1x, t1y, t1z, t2x, t2y, t2z, work):
    """Contact c's three rows (n, t1, t2) of ``work``: each direction (world) and its r × d in principal axes."""
    qw, qx, qy, qz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
    rx, ry, rz = points[c, 0] - y[P], points[c, 1] - y[P + 1], points[c, 2] - y[P + 2]
    for k in range(3):
        dx, dy, dz = row_direction(k, nx, ny, nz, t1x, t1y, t1z, t2x, t2y, t2z)
        row = 3 * c + k
        work[row, _LIN], work[row, _LIN + 1], work[row, _LIN + 2] = dx, dy, dz
        a = rotate_back(qw, qx, qy, qz, ry * dz - rz * dy, rz * dx - rx * dz, rx * dy - ry * dx)
        work[row, _ANG], work[row, _ANG + 1], work[row, _ANG + 2] = a[0], a[1], a[2]


@njit(**_OPTS)
def _mass_rows(y, p, rows, work):
    """b = J u and A = J M⁻¹ Jᵀ of the first ``rows`` rows of ``work`` (their directions filled); returns rows."""
    inv_m = p[INV_MASS]
    for a in range(rows):
        work[a, _B] = (work[a, _LIN] * y[V] + work[a, _LIN + 1] * y[V + 1] + work[a, _LIN + 2] * y[V + 2]
                       + work[a, _ANG] * y[W] + work[a, _ANG + 1] * y[W + 1] + work[a, _ANG + 2] * y[W + 2])
        for b in range(rows):
            s = inv_m * (work[a, _LIN] * work[b, _LIN] + work[a, _LIN + 1] * work[b, _LIN + 1]
                         + work[a, _LIN + 2] * work[b, _LIN + 2])
            for j in range(3):
                s += work[a, _ANG + j] * work[b, _ANG + j] * p[INV_INERTIA + j]
            work[a, _A + b] = s
    return rows


@njit(**_OPTS)
def _row_velocity(work, rows, a):
    """u_a = b_a + Σ_b A_ab λ_b."""
    u = work[a, _B]
    for b in range(rows):
        u += work[a, _A + b] * work[b, _LAM]
    return u


@njit(**_OPTS)
def pgs(work, count, mu, sx, sy):
    """Projected Gauss–Seidel for the contact multipliers λ (work[:, LAM], started from its content).

    Per contact: λ_n ← max(0, λ_n − u_n / A_nn); then, if μ > 0, λ_t by the 2 × 2 block
    solve of u_t = 0, projected onto the disk |λ_t| ≤ μ λ_n — unless the contact slides along a
    known direction (``sx``, ``sy`` components along t1, t2 of the slip, not both zero), in
    which case λ_t = −μ λ_n s and the normal update accounts for it. Stops when no
    multiplier moves by more than PGS_TOLERANCE × their size. Returns the sweeps done.
    """
    directions = np.empty((work.shape[0] // 3, 2))
    for c in range(count):
        directions[c, 0], directions[c, 1] = sx, sy
    return pgs_each(work, count, mu, directions)


@njit(**_OPTS)
def pgs_each(work, count, mu, directions):
    """:func:`pgs` with a slip direction per contact: contact c slides along ``directions[c]`` (t1, t2), or
    sticks inside the cone where both are zero."""
    rows = 3 * count
    sweeps = 0
    for sweeps in range(1, PGS_MAX_SWEEPS + 1):
        change = 0.0
        size = 0.0
        for c in range(count):
            n, t1, t2 = 3 * c, 3 * c + 1, 3 * c + 2
            sx, sy = directions[c, 0], directions[c, 1]
            sliding = sx != 0.0 or sy != 0.0
            u = _row_velocity(work, rows, n)
            if sliding and mu > 0.0:
                diag = work[n, _A + n] - mu * (work[n, _A + t1] * sx + work[n, _A + t2] * sy)
            else:
                diag = work[n, _A + n]
            new = work[n, _LAM] - u / diag if diag > 0.0 else work[n, _LAM]
            new = max(0.0, new)
            change = max(change, abs(new - work[n, _LAM]))
            work[n, _LAM] = new
            if mu > 0.0 and sliding:
                l1, l2 = -mu * new * sx, -mu * new * sy
            elif mu > 0.0:
                u1 = _row_velocity(work, rows, t1)
                u2 = _row_velocity(work, rows, t2)
                a11, a12, a21, a22 = work[t1, _A + t1], work[t1, _A + t2], work[t2, _A + t1], work[t2, _A + t2]
                det = a11 * a22 - a12 * a21
                l1, l2 = work[t1, _LAM], work[t2, _LAM]
                if det > 0.0:
                    l1 -= (a22 * u1 - a12 * u2) / det
                    l2 -= (a11 * u2 - a21 * u1) / det
                limit = mu * new
                norm = math.sqrt(l1 * l1 + l2 * l2)
                if norm > limit:
                    scale = limit / norm if norm > 0.0 else 0.0
                    l1, l2 = l1 * scale, l2 * scale
            else:
                l1, l2 = 0.0, 0.0
            change = max(change, max(abs(l1 - work[t1, _LAM]), abs(l2 - work[t2, _LAM])))
            work[t1, _LAM], work[t2, _LAM] = l1, l2
            size = max(size, abs(new))
        if change <= PGS_TOLERANCE * size or size == 0.0 and change == 0.0:
            break
    return sweeps


@njit(**_OPTS)
def kinetic_energy_row(y, p):
    """½ m |v|² + ½ Σ I_j ω_j² of one state row (principal axes), J."""
    return 0.5 * (p[MASS] * (y[V] * y[V] + y[V + 1] * y[V + 1] + y[V + 2] * y[V + 2])
                  + p[INERTIA] * y[W] * y[W] + p[INERTIA + 1] * y[W + 1] * y[W + 1]
                  + p[INERTIA + 2] * y[W + 2] * y[W + 2])


@njit(**_OPTS)
def potential_energy_row(y, p):
    """−m g · p of one state row under its gravity (J): its potential energy, zero at the world origin."""
    return -(p[MASS] * (p[GRAVITY] * y[P] + p[GRAVITY + 1] * y[P + 1] + p[GRAVITY + 2] * y[P + 2]))


@njit(**_OPTS)
def apply_impulses(y0, y, p, work, rows, column, scale):
    """y's velocities ← y0's + M⁻¹ Jᵀ (scale · work[:, column]) (positions untouched)."""
    inv_m = p[INV_MASS]
    for j in range(3):
        dv = 0.0
        dw = 0.0
        for a in range(rows):
            dv += work[a, _LIN + j] * work[a, column]
            dw += work[a, _ANG + j] * work[a, column]
        y[V + j] = y0[V + j] + scale * dv * inv_m
        y[W + j] = y0[W + j] + scale * dw * p[INV_INERTIA + j]


@njit(**_OPTS)
def restitution(work, rows, linear, before, compressed, e):
    """The restitution of an impact, capped so that the energy never rises: α ≤ e scaling the
    normal multipliers saved in ``work[:, _SAVED]``, with E(α) = E1 + α·linear + ½ α² λ_nᵀ A λ_n
    ≤ ``before`` (E1 = ``compressed``, ``linear`` = λ_nᵀ u1, u1 the normal velocities after the
    compression). Adds α λ_n to ``work[:, _LAM]``; returns (α, Σ (1 + α) λ_n). For one body
    against the ground (:func:`impact`) and for two bodies (pair_impacts.py)."""
    quadratic = 0.0
    for a in range(0, rows, 3):
        for b in range(0, rows, 3):
            quadratic += work[a, _SAVED] * work[a, _A + b] * work[b, _SAVED]
    alpha = e
    if quadratic > 0.0:
        room = max(0.0, before - compressed)
        largest = (-linear + math.sqrt(max(0.0, linear * linear + 2.0 * quadratic * room))) / quadratic
        alpha = min(e, max(0.0, largest))
    total = 0.0
    for a in range(0, rows, 3):
        total += (1.0 + alpha) * work[a, _LAM]
        work[a, _LAM] += alpha * work[a, _SAVED]
    return alpha, total


@njit(**_OPTS)
def frictionless_after_short(work, rows, count, limit):
    """After a compression λ in ``work`` (either law's rows: b the velocities before it, A): if a contact still
    approaches faster than −``limit`` (m/s, limit ≤ 0; its normal velocity b + Aλ below it), b ← the rows'
    velocities after λ and λ ← the frictionless compression from there, and returns Σ of the first λ's normal
    impulses (N·s), for the caller to add and to apply the new λ; else leaves ``work`` and returns −1."""
    short = False
    for a in range(0, rows, 3):
        if _row_velocity(work, rows, a) < limit:
            short = True
            break
    if not short:
        return -1.0
    total = 0.0
    for a in range(rows):  # b + A λ: row a's own b read once, before it is written
        work[a, _SAVED] = _row_velocity(work, rows, a)
    for a in range(rows):
        if a % 3 == 0:
            total += work[a, _LAM]
        work[a, _B] = work[a, _SAVED]
        work[a, _LAM] = 0.0
    pgs(work, count, 0.0, 0.0, 0.0)
    return total


@njit(**_OPTS)
def impact(y0, y, p, count, points, nx, ny, nz, e, mu, work):
    """y ← y0 after the impact of ``count`` simultaneous contacts (the law in the module docstring).

    Returns (Σ normal impulse N·s, kinetic energy before J, after J, the restitution factor used).
    """
    for j in range(y.shape[0]):
        y[j] = y0[j]
    rows = build_rows(y0, p, count, points, nx, ny, nz, work)
    before = kinetic_energy_row(y0, p)
    approach = 0.0  # the fastest approach (m/s, ≤ 0)
    for a in range(rows):
        work[a, _LAM] = 0.0
        if a % 3 == 0:
            approach = min(approach, work[a, _B])
    pgs(work, count, mu, 0.0, 0.0)
    apply_impulses(y0, y, p, work, rows, _LAM, 1.0)
    compressed = kinetic_energy_row(y, p)
    if compressed > before:  # not dissipative: the frictionless compression, monotone in the energy
        for a in range(rows):
            work[a, _LAM] = 0.0
        pgs(work, count, 0.0, 0.0, 0.0)
        apply_impulses(y0, y, p, work, rows, _LAM, 1.0)
        compressed = kinetic_energy_row(y, p)
    # restitution: the normal multipliers only, scaled by e (Poisson), capped so that E never rises
    for a in range(rows):
        work[a, _SAVED] = work[a, _LAM] if a % 3 == 0 else 0.0
    linear = 0.0  # λ_nᵀ u1
    for a in range(0, rows, 3):
        u1 = (work[a, _LIN] * y[V] + work[a, _LIN + 1] * y[V + 1] + work[a, _LIN + 2] * y[V + 2]
              + work[a, _ANG] * y[W] + work[a, _ANG + 1] * y[W + 1] + work[a, _ANG + 2] * y[W + 2])
        linear += work[a, _SAVED] * u1
    alpha, total = restitution(work, rows, linear, before, compressed, e)
    apply_impulses(y0, y, p, work, rows, _LAM, 1.0)
    after = kinetic_energy_row(y, p)
    if after > before:  # round-off of the cap: take the compression alone
        for a in range(0, rows, 3):
            work[a, _LAM] -= alpha * work[a, _SAVED]
        apply_impulses(y0, y, p, work, rows, _LAM, 1.0)
        after = kinetic_energy_row(y, p)
        alpha = 0.0
    # Several contacts: one contact's restitution impulse can drive another into the ground
    # (Poisson's law per contact ignores the others). Then a second compression from there takes
    # every approach out again; being a compression, it can only lower the energy.
    # A compression with friction that Gauss–Seidel leaves short (high μ over coupled points: a contact still
    # approaching faster than APPROACH_LEFT × the fastest approach, before the impact or before this compression)
    # is followed by a frictionless one from there, which always converges.
    build_rows(y, p, count, points, nx, ny, nz, work)
    again = 0.0
    for a in range(0, rows, 3):
        again = min(again, work[a, _B])
    if again < 0.0:
        mid = kinetic_energy_row(y, p)
        for a in range(rows):
            work[a, _LAM] = 0.0
        pgs(work, count, mu, 0.0, 0.0)
        apply_impulses(y, y, p, work, rows, _LAM, 1.0)
        if kinetic_energy_row(y, p) > mid:  # not dissipative: undo it, and the frictionless one instead
            for a in range(rows):
                work[a, _LAM] = -work[a, _LAM]
            apply_impulses(y, y, p, work, rows, _LAM, 1.0)
            for a in range(rows):
                work[a, _LAM] = 0.0
            pgs(work, count, 0.0, 0.0, 0.0)
            apply_impulses(y, y, p, work, rows, _LAM, 1.0)
        else:  # short of stopping every approach: a frictionless compression from there takes out what is left
            first = frictionless_after_short(work, rows, count, APPROACH_LEFT * min(approach, again))
            if first >= 0.0:
                total += first
                apply_impulses(y, y, p, work, rows, _LAM, 1.0)
        for a in range(0, rows, 3):
            total += work[a, _LAM]
        after = kinetic_energy_row(y, p)
    return total, before, after, alpha
