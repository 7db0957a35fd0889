"""Compiled refinement of a pair's normal to round-off: Newton's method on the support functions, stratum by stratum.

For two cores (convex.py pose rows: point, segment, box, cylinder) the signed distance is
max over unit u of sep(u) = (c_B − c_A)·u − Σ terms, the centred support functions written as

* abs terms w|g·u|: a box's half extents d_i along its axes e_i, a segment's or a cylinder's
  half length h along its axis a;
* radial terms r|u − (a·u)a|: a cylinder's radius.

sep is smooth on the unit sphere except on the great circles g·u = 0 and at the poles ±a. GJK and
EPA find the distance of a curved pair to ~1e-10 of its size but its direction only to ~1e-5 rad
(convex.py); :func:`refine_normal` takes that direction u₀ and returns the best of

1. u₀'s smooth piece: Newton on the sphere (Riemannian gradient and Hessian, the signs of the abs
   terms fixed at u₀);
2. each circle g·u = 0 within ``NEAR`` of u₀: Newton on the circle's angle (the circle's own term
   is 0 along it);
3. each crossing ±g₁×g₂ of two such circles and each pole ±a within ``NEAR`` of u₀;

each candidate judged by sep itself (from the support points); a second round from the first's
best unless that is a stationary point. A maximum lies in one of these strata, and Newton converges quadratically from
1e-5 rad. Values alone cannot place the direction closer than ~1e-8 rad (sep is flat to second
order at a smooth maximum: round-off hides the rest), so among candidates whose sep equals the
largest within round-off the most precise kind wins: a stationary point inside a smooth piece
(its gradient 0 to round-off), then one on a circle, then a crossing or a pole. The distance is
sep along the returned direction. :func:`feature_point` then puts a contact point on a core's support set
along u (a face, an edge, a side line, an end disk, a rim point) nearest a given point.

Allocation-free, no Python per pair.
"""

from __future__ import annotations

import math

from numba import njit

from ..jit import INLINE, JIT
from .convex import CORE_BOX, CORE_CYLINDER, CORE_SEGMENT, support

__all__ = ["NEAR", "FEATURE_TOLERANCE", "sep", "refine_normal", "feature_point"]

_KIND, _DIM, _C, _R = 0, 1, 4, 7
#: A stratum (circle, crossing, pole) is tried when it is within this (rad, as a sine) of the start.
NEAR = 1e-2
#: A unit direction's component below this counts as 0 in feature_point (the support set is a face, edge, ...).
FEATURE_TOLERANCE = 1e-10
_NEWTON_STEPS = 8
_TERMS = 8  # four per core: a box's three axes; a cylinder's abs and radial term; a segment's abs term


@njit(**INLINE)
def sep(pa, pb, ux, uy, uz):
    """sep(u) = min over B of u·x − max over A of u·x, from the cores' support points (m)."""
    ax, ay, az = support(pa, ux, uy, uz)
    bx, by, bz = support(pb, -ux, -uy, -uz)
    return (bx - ax) * ux + (by - ay) * uy + (bz - az) * uz


@njit(**INLINE)
def _term(pa, pb, k):
    """Term k (0..7; 0–3 of A, 4–7 of B): (type 0 none / 1 abs / 2 radial, weight (m), unit g or a)."""
    pose = pa if k < 4 else pb
    j = k % 4
    kind = int(pose[_KIND])
    if (kind == CORE_BOX and j < 3) or ((kind == CORE_SEGMENT or kind == CORE_CYLINDER) and j == 2):
        w = pose[_DIM + j] if kind == CORE_BOX else (pose[_DIM] if kind == CORE_SEGMENT else pose[_DIM + 1])
        return 1, w, pose[_R + j], pose[_R + 3 + j], pose[_R + 6 + j]
    if kind == CORE_CYLINDER and j == 3:
        return 2, pose[_DIM], pose[_R + 2], pose[_R + 5], pose[_R + 8]
    return 0, 0.0, 0.0, 0.0, 0.0


@njit(**JIT)
def _derivatives(pa, pb, ux, uy, uz, sx, sy, sz):
    """Gradient and Hessian (xx, xy, xz, yy, yz, zz) of the smooth piece of sep at u whose abs signs are those at s.

    Returns (ok, g (3), H (6)); ok is False at a pole (a radial term not differentiable).
    """
    gx, gy, gz = pb[_C] - pa[_C], pb[_C + 1] - pa[_C + 1], pb[_C + 2] - pa[_C + 2]
    hxx = hxy = hxz = hyy = hyz = hzz = 0.0
    ok = True
    for k in range(_TERMS):
        kind, w, ax, ay, az = _term(pa, pb, k)
        if kind == 1:
            sgn = 1.0 if ax * sx + ay * sy + az * sz >= 0.0 else -1.0
            gx, gy, gz = gx - w * sgn * ax, gy - w * sgn * ay, gz - w * sgn * az
        elif kind == 2:
            t = ax * ux + ay * uy + az * uz
            px, py, pz = ux - t * ax, uy - t * ay, uz - t * az
            p = math.sqrt(px * px + py * py + pz * pz)
            if p <= 1e-12:
                ok = False
            else:
                gx, gy, gz = gx - w * px / p, gy - w * py / p, gz - w * pz / p
                # −w (P − p̂ p̂ᵀ) / |p| with P = I − a aᵀ
                c = w / p
                qx, qy, qz = px / p, py / p, pz / p
                hxx -= c * (1.0 - ax * ax - qx * qx)
                hxy -= c * (-ax * ay - qx * qy)
                hxz -= c * (-ax * az - qx * qz)
                hyy -= c * (1.0 - ay * ay - qy * qy)
                hyz -= c * (-ay * az - qy * qz)
                hzz -= c * (1.0 - az * az - qz * qz)
    return ok, gx, gy, gz, hxx, hxy, hxz, hyy, hyz, hzz


@njit(**INLINE)
def _quad(hxx, hxy, hxz, hyy, hyz, hzz, ax, ay, az, bx, by, bz):
    """aᵀ H b for the symmetric H."""
    return (ax * (hxx * bx + hxy * by + hxz * bz) + ay * (hxy * bx + hyy * by + hyz * bz)
            + az * (hxz * bx + hyz * by + hzz * bz))


@njit(**INLINE)
def _across(ux, uy, uz):
    """Two unit vectors completing the unit u to an orthonormal basis."""
    if abs(ux) < 0.6:
        tx, ty, tz = 1.0, 0.0, 0.0
    else:
        tx, ty, tz = 0.0, 1.0, 0.0
    d = tx * ux + ty * uy + tz * uz
    tx, ty, tz = tx - d * ux, ty - d * uy, tz - d * uz
    n = math.sqrt(tx * tx + ty * ty + tz * tz)
    tx, ty, tz = tx / n, ty / n, tz / n
    return tx, ty, tz, uy * tz - uz * ty, uz * tx - ux * tz, ux * ty - uy * tx


@njit(**INLINE)
def _unit(x, y, z):
    n = math.sqrt(x * x + y * y + z * z)
    return x / n, y / n, z / n


@njit(**INLINE)
def _offer(pa, pb, tie, bv, bx, by, bz, pv, px, py, pz, pr, ux, uy, uz, ox, oy, oz, rank):
    """Judge the candidate u (turned to o's side, normalised) of the given rank.

    Keeps (bv, b): the largest sep; (pv, p, pr): among candidates of rank ≥ 1 the largest sep,
    a higher rank winning over values equal within ``tie`` (round-off of sep).
    """
    n = math.sqrt(ux * ux + uy * uy + uz * uz)
    if not n > 1e-12:
        return bv, bx, by, bz, pv, px, py, pz, pr
    ux, uy, uz = ux / n, uy / n, uz / n
    if ux * ox + uy * oy + uz * oz < 0.0:
        ux, uy, uz = -ux, -uy, -uz
    v = sep(pa, pb, ux, uy, uz)
    if v > bv:
        bv, bx, by, bz = v, ux, uy, uz
    if rank >= 1 and (v > pv + tie or (v >= pv - tie and (rank > pr or (rank == pr and v > pv)))):
        pv, px, py, pz, pr = v, ux, uy, uz, rank
    return bv, bx, by, bz, pv, px, py, pz, pr


@njit(**JIT)
def _signs_agree(pa, pb, sx, sy, sz, ux, uy, uz):
    """Whether every abs term has the same sign of g·u at s and at u (both in one smooth piece)."""
    for k in range(_TERMS):
        kind, _, gx, gy, gz = _term(pa, pb, k)
        if kind == 1 and (gx * sx + gy * sy + gz * sz >= 0.0) != (gx * ux + gy * uy + gz * uz >= 0.0):
            return False
    return True


@njit(**JIT)
def _newton_piece(pa, pb, ux, uy, uz):
    """Newton on the sphere over the smooth piece of u (abs signs fixed at u).

    Returns (u, stationary): stationary when the step fell to round-off at a point of the same
    piece with a negative definite Hessian (a local maximum inside the piece).
    """
    sx, sy, sz = ux, uy, uz
    for _ in range(_NEWTON_STEPS):
        ok, gx, gy, gz, hxx, hxy, hxz, hyy, hyz, hzz = _derivatives(pa, pb, ux, uy, uz, sx, sy, sz)
        if not ok:
            return ux, uy, uz, False
        t1x, t1y, t1z, t2x, t2y, t2z = _across(ux, uy, uz)
        g1 = gx * t1x + gy * t1y + gz * t1z
        g2 = gx * t2x + gy * t2y + gz * t2z
        lam = gx * ux + gy * uy + gz * uz
        h11 = _quad(hxx, hxy, hxz, hyy, hyz, hzz, t1x, t1y, t1z, t1x, t1y, t1z) - lam
        h12 = _quad(hxx, hxy, hxz, hyy, hyz, hzz, t1x, t1y, t1z, t2x, t2y, t2z)
        h22 = _quad(hxx, hxy, hxz, hyy, hyz, hzz, t2x, t2y, t2z, t2x, t2y, t2z) - lam
        det = h11 * h22 - h12 * h12
        if not (h11 < 0.0 and det > 0.0):  # not a maximum's basin
            return ux, uy, uz, False
        s1 = -(h22 * g1 - h12 * g2) / det
        s2 = -(h11 * g2 - h12 * g1) / det
        step = math.sqrt(s1 * s1 + s2 * s2)
        if step > 0.1:
            return ux, uy, uz, False
        ux, uy, uz = _unit(ux + s1 * t1x + s2 * t2x, uy + s1 * t1y + s2 * t2y, uz + s1 * t1z + s2 * t2z)
        if step <= 1e-15:
            return ux, uy, uz, _signs_agree(pa, pb, sx, sy, sz, ux, uy, uz)
    return ux, uy, uz, False


@njit(**JIT)
def _newton_circle(pa, pb, cx, cy, cz, ux, uy, uz):
    """Newton on the angle along the great circle c·u = 0 (c unit) from u's projection on it.

    Returns (u, stationary) as _newton_piece (the signs taken at each iterate; the circle's own
    term is 0 along it).
    """
    t = cx * ux + cy * uy + cz * uz
    px, py, pz = ux - t * cx, uy - t * cy, uz - t * cz
    norm = math.sqrt(px * px + py * py + pz * pz)
    if norm <= 1e-12:
        return ux, uy, uz, False
    px, py, pz = px / norm, py / norm, pz / norm
    qx, qy, qz = cy * pz - cz * py, cz * px - cx * pz, cx * py - cy * px
    theta = 0.0
    for _ in range(_NEWTON_STEPS):
        co, si = math.cos(theta), math.sin(theta)
        wx, wy, wz = co * px + si * qx, co * py + si * qy, co * pz + si * qz
        dx, dy, dz = -si * px + co * qx, -si * py + co * qy, -si * pz + co * qz
        ok, gx, gy, gz, hxx, hxy, hxz, hyy, hyz, hzz = _derivatives(pa, pb, wx, wy, wz, wx, wy, wz)
        if not ok:
            return wx, wy, wz, False
        d1 = gx * dx + gy * dy + gz * dz
        d2 = _quad(hxx, hxy, hxz, hyy, hyz, hzz, dx, dy, dz, dx, dy, dz) - (gx * wx + gy * wy + gz * wz)
        if not d2 < 0.0:
            return wx, wy, wz, False
        step = -d1 / d2
        if abs(step) > 0.1:
            return wx, wy, wz, False
        theta += step
        if abs(step) <= 1e-15:
            co, si = math.cos(theta), math.sin(theta)
            return co * px + si * qx, co * py + si * qy, co * pz + si * qz, True
    co, si = math.cos(theta), math.sin(theta)
    return co * px + si * qx, co * py + si * qy, co * pz + si * qz, False


@njit(**JIT)
def _round(pa, pb, tie, bv, bx, by, bz, pv, px, py, pz, pr, ux, uy, uz):
    """One round of candidates around the direction u (see the module docstring)."""
    wx, wy, wz, stationary = _newton_piece(pa, pb, ux, uy, uz)
    bv, bx, by, bz, pv, px, py, pz, pr = _offer(pa, pb, tie, bv, bx, by, bz, pv, px, py, pz, pr, wx, wy, wz,
                                                ux, uy, uz, 3 if stationary else 0)
    for i in range(_TERMS):
        kind, _, gx, gy, gz = _term(pa, pb, i)
        if kind == 0:
            continue
        ci = gx * ux + gy * uy + gz * uz
        if kind == 2:  # a pole: u along the axis
            if 1.0 - abs(ci) <= 0.5 * NEAR * NEAR:
                bv, bx, by, bz, pv, px, py, pz, pr = _offer(pa, pb, tie, bv, bx, by, bz, pv, px, py, pz, pr,
                                                            gx, gy, gz, ux, uy, uz, 1)
            continue
        if abs(ci) > NEAR:
            continue
        wx, wy, wz, stationary = _newton_circle(pa, pb, gx, gy, gz, ux, uy, uz)
        bv, bx, by, bz, pv, px, py, pz, pr = _offer(pa, pb, tie, bv, bx, by, bz, pv, px, py, pz, pr, wx, wy, wz,
                                                    ux, uy, uz, 2 if stationary else 0)
        for j in range(i + 1, _TERMS):
            kj, _, hx, hy, hz = _term(pa, pb, j)
            if kj == 1 and abs(hx * ux + hy * uy + hz * uz) <= NEAR:
                bv, bx, by, bz, pv, px, py, pz, pr = _offer(pa, pb, tie, bv, bx, by, bz, pv, px, py, pz, pr,
                                                            gy * hz - gz * hy, gz * hx - gx * hz, gx * hy - gy * hx,
                                                            ux, uy, uz, 1)
    return bv, bx, by, bz, pv, px, py, pz, pr


@njit(**JIT)
def refine_normal(pa, pb, ux, uy, uz):
    """The direction near the unit u that maximises sep, and sep there: (sep (m), nx, ny, nz); see the module docstring."""
    ux, uy, uz = _unit(ux, uy, uz)
    # round-off of sep: the centres' offset and the support terms' weights
    ox, oy, oz = pb[_C] - pa[_C], pb[_C + 1] - pa[_C + 1], pb[_C + 2] - pa[_C + 2]
    size = math.sqrt(ox * ox + oy * oy + oz * oz)
    for k in range(_TERMS):
        size += _term(pa, pb, k)[1]
    tie = 1e-14 * size
    bv = sep(pa, pb, ux, uy, uz)
    bx, by, bz = ux, uy, uz
    pv, px, py, pz, pr = -math.inf, ux, uy, uz, 0
    for _ in range(2):
        bv, bx, by, bz, pv, px, py, pz, pr = _round(pa, pb, tie, bv, bx, by, bz, pv, px, py, pz, pr, bx, by, bz)
        if pr >= 2 and pv >= bv - tie:  # a stationary point is the best: no second round
            break
    if pv >= bv - tie:
        return pv, px, py, pz
    return bv, bx, by, bz


@njit(**JIT)
def feature_point(pose, ux, uy, uz, x, y, z):
    """The point of the core's support set along the unit u (world) nearest to the world point x, about.

    Per local axis: a direction component below FEATURE_TOLERANCE leaves that coordinate free
    (clamped to the core), otherwise it is the extreme one. A cylinder's end disk is taken when
    u is along its axis. The point is on the core's boundary and u·point = the support value.
    """
    lux = pose[_R + 0] * ux + pose[_R + 3] * uy + pose[_R + 6] * uz
    luy = pose[_R + 1] * ux + pose[_R + 4] * uy + pose[_R + 7] * uz
    luz = pose[_R + 2] * ux + pose[_R + 5] * uy + pose[_R + 8] * uz
    dx, dy, dz = x - pose[_C], y - pose[_C + 1], z - pose[_C + 2]
    lx = pose[_R + 0] * dx + pose[_R + 3] * dy + pose[_R + 6] * dz
    ly = pose[_R + 1] * dx + pose[_R + 4] * dy + pose[_R + 7] * dz
    lz = pose[_R + 2] * dx + pose[_R + 5] * dy + pose[_R + 8] * dz
    kind = int(pose[_KIND])
    qx, qy, qz = 0.0, 0.0, 0.0
    tol = FEATURE_TOLERANCE
    if kind == CORE_SEGMENT:
        h = pose[_DIM]
        qz = min(h, max(-h, lz)) if abs(luz) <= tol else (h if luz > 0.0 else -h)
    elif kind == CORE_BOX:
        a0, a1, a2 = pose[_DIM], pose[_DIM + 1], pose[_DIM + 2]
        qx = min(a0, max(-a0, lx)) if abs(lux) <= tol else (a0 if lux > 0.0 else -a0)
        qy = min(a1, max(-a1, ly)) if abs(luy) <= tol else (a1 if luy > 0.0 else -a1)
        qz = min(a2, max(-a2, lz)) if abs(luz) <= tol else (a2 if luz > 0.0 else -a2)
    elif kind == CORE_CYLINDER:
        r, h = pose[_DIM], pose[_DIM + 1]
        qz = min(h, max(-h, lz)) if abs(luz) <= tol else (h if luz > 0.0 else -h)
        rho_u = math.sqrt(lux * lux + luy * luy)
        if rho_u <= tol:  # the end disk
            rho = math.sqrt(lx * lx + ly * ly)
            qx, qy = (lx, ly) if rho <= r else (lx * r / rho, ly * r / rho)
        else:
            qx, qy = r * lux / rho_u, r * luy / rho_u
    return (pose[_C] + pose[_R + 0] * qx + pose[_R + 1] * qy + pose[_R + 2] * qz,
            pose[_C + 1] + pose[_R + 3] * qx + pose[_R + 4] * qy + pose[_R + 5] * qz,
            pose[_C + 2] + pose[_R + 6] * qx + pose[_R + 7] * qy + pose[_R + 8] * qz)
