"""Compiled gap functions: sphere, box, cylinder and capsule against a static half-space n·x ≥ offset.

Each takes the body's centre of mass ``c`` (world, m), its orientation ``q_WB`` (w, x, y, z,
of the body frame B in which the shape is declared), the shape's dimensions (layout.py) and
the half-space (unit normal n, world axes; offset, m), and writes the contact point(s) of the
shape nearest the plane (world, on the body's surface) with their signed distances (gap, m:
negative inside) into ``points`` (MAX_POINTS, 3) and ``gaps`` (MAX_POINTS,). Every point whose
gap is within ``FEATURE_BAND`` × the shape's size of the lowest is returned (a box face gives 4
corners, an edge 2; a cylinder standing on its end 4 rim points, lying on its side 2; a
capsule lying 2), so simultaneous contacts are seen together. Returns the number of points.

All closed form, allocation-free, ``nogil``; :func:`body_gap` and :func:`min_gaps` loop over
half-spaces and bodies inside the compiled code (no Python call per pair).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..layout import P, Q, Q_PB, W
from ..rotation import qmul, rotate, rotate_back
from .layout import (
    DIMS,
    KIND,
    MAX_POINTS,
    NORMAL,
    OFFSET,
    SHAPE_BOX,
    SHAPE_CAPSULE,
    SHAPE_CYLINDER,
    SHAPE_NONE,
    SHAPE_SPHERE,
)

__all__ = ["FEATURE_BAND", "RIM_UPRIGHT", "sphere_points", "box_points", "cylinder_points", "capsule_points",
           "shape_points",
           "body_points", "body_gap", "min_gaps", "MAX_FEATURES", "feature_gaps", "feature_points",
           "held_rim", "axis_tilt", "opposite_rim_gap"]

#: Points within this fraction of the shape's largest dimension of the lowest one are in contact together.
FEATURE_BAND = 1e-9

#: rad: within this of upright, a cylinder's rim contact turns about a point of its rim (persistent.normal_bias):
#: the lowest point's travel along the rim, at a rate growing as 1/tilt, is not followed there.
RIM_UPRIGHT = 1e-6

_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}


@njit(**_OPTS)
def sphere_points(cx, cy, cz, r, nx, ny, nz, offset, points, gaps):
    """The sphere's lowest point c − r n and its gap n·c − r − offset: 1 point."""
    points[0, 0], points[0, 1], points[0, 2] = cx - r * nx, cy - r * ny, cz - r * nz
    gaps[0] = nx * cx + ny * cy + nz * cz - r - offset
    return 1


@njit(**_OPTS)
def box_points(cx, cy, cz, qw, qx, qy, qz, ax, ay, az, nx, ny, nz, offset, points, gaps):
    """The box corners (half extents a, body axes) within the band of the lowest: 1, 2 or 4 points."""
    base = nx * cx + ny * cy + nz * cz - offset
    band = FEATURE_BAND * max(ax, max(ay, az))
    lowest = math.inf
    for corner in range(8):
        sx = 1.0 if corner & 1 else -1.0
        sy = 1.0 if corner & 2 else -1.0
        sz = 1.0 if corner & 4 else -1.0
        ox, oy, oz = rotate(qw, qx, qy, qz, sx * ax, sy * ay, sz * az)
        lowest = min(lowest, base + nx * ox + ny * oy + nz * oz)
    count = 0
    for corner in range(8):
        sx = 1.0 if corner & 1 else -1.0
        sy = 1.0 if corner & 2 else -1.0
        sz = 1.0 if corner & 4 else -1.0
        ox, oy, oz = rotate(qw, qx, qy, qz, sx * ax, sy * ay, sz * az)
        gap = base + nx * ox + ny * oy + nz * oz
        if gap <= lowest + band and count < MAX_POINTS:
            points[count, 0], points[count, 1], points[count, 2] = cx + ox, cy + oy, cz + oz
            gaps[count] = gap
            count += 1
    return count


@njit(**_OPTS)
def capsule_points(cx, cy, cz, qw, qx, qy, qz, r, half, nx, ny, nz, offset, points, gaps):
    """The lower end sphere's lowest point (both ends when the axis lies in the plane): 1 or 2 points."""
    ux, uy, uz = rotate(qw, qx, qy, qz, 0.0, 0.0, 1.0)
    cos_a = nx * ux + ny * uy + nz * uz
    base = nx * cx + ny * cy + nz * cz - r - offset
    band = FEATURE_BAND * max(r, half)
    lowest = base - half * abs(cos_a)
    count = 0
    for side in (-1.0, 1.0):
        gap = base + side * half * cos_a
        if gap <= lowest + band:
            points[count, 0] = cx + side * half * ux - r * nx
            points[count, 1] = cy + side * half * uy - r * ny
            points[count, 2] = cz + side * half * uz - r * nz
            gaps[count] = gap
            count += 1
    return count


@njit(**_OPTS)
def cylinder_points(cx, cy, cz, qw, qx, qy, qz, r, half, nx, ny, nz, offset, points, gaps):
    """The lowest rim point(s): 1; 2 when lying on its side; 4 rim points when standing on an end face."""
    ux, uy, uz = rotate(qw, qx, qy, qz, 0.0, 0.0, 1.0)
    cos_a = nx * ux + ny * uy + nz * uz
    # the radial direction towards the plane: n's part across the axis, normalised
    px, py, pz = nx - cos_a * ux, ny - cos_a * uy, nz - cos_a * uz
    across = math.sqrt(px * px + py * py + pz * pz)
    base = nx * cx + ny * cy + nz * cz - offset
    band = FEATURE_BAND * max(r, half)
    count = 0
    if r * across <= band:  # standing on an end face: four rim points of the lower face
        side = -1.0 if cos_a > 0.0 else 1.0
        e1x, e1y, e1z = rotate(qw, qx, qy, qz, 1.0, 0.0, 0.0)
        e2x, e2y, e2z = rotate(qw, qx, qy, qz, 0.0, 1.0, 0.0)
        for k in range(4):
            c = (1.0, 0.0, -1.0, 0.0)[k]
            s = (0.0, 1.0, 0.0, -1.0)[k]
            ox = side * half * ux + r * (c * e1x + s * e2x)
            oy = side * half * uy + r * (c * e1y + s * e2y)
            oz = side * half * uz + r * (c * e1z + s * e2z)
            points[k, 0], points[k, 1], points[k, 2] = cx + ox, cy + oy, cz + oz
            gaps[k] = base + nx * ox + ny * oy + nz * oz
        count = 4
    else:
        px, py, pz = px / across, py / across, pz / across
        lowest = base - half * abs(cos_a) - r * across
        for side in (-1.0, 1.0):
            gap = base + side * half * cos_a - r * across
            if gap <= lowest + band:
                points[count, 0] = cx + side * half * ux - r * px
                points[count, 1] = cy + side * half * uy - r * py
                points[count, 2] = cz + side * half * uz - r * pz
                gaps[count] = gap
                count += 1
    return count


@njit(**_OPTS)
def shape_points(kind, d0, d1, d2, cx, cy, cz, qw, qx, qy, qz, nx, ny, nz, offset, points, gaps):
    """Dispatch on the shape kind (layout.SHAPE_*): the contact points and gaps; 0 for SHAPE_NONE."""
    count = 0
    if kind == SHAPE_SPHERE:
        count = sphere_points(cx, cy, cz, d0, nx, ny, nz, offset, points, gaps)
    elif kind == SHAPE_BOX:
        count = box_points(cx, cy, cz, qw, qx, qy, qz, d0, d1, d2, nx, ny, nz, offset, points, gaps)
    elif kind == SHAPE_CYLINDER:
        count = cylinder_points(cx, cy, cz, qw, qx, qy, qz, d0, d1, nx, ny, nz, offset, points, gaps)
    elif kind == SHAPE_CAPSULE:
        count = capsule_points(cx, cy, cz, qw, qx, qy, qz, d0, d1, nx, ny, nz, offset, points, gaps)
    return count


@njit(**_OPTS)
def body_points(y, p, shape, ground, points, gaps):
    """Contact points of one body (state row y, parameter row p, shape row) against one ground row."""
    # q_WB = q_WP ⊗ q_PB: the shape is declared in the body frame B
    qw, qx, qy, qz = qmul(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], p[Q_PB], p[Q_PB + 1], p[Q_PB + 2], p[Q_PB + 3])
    count = shape_points(int(shape[KIND]), shape[DIMS], shape[DIMS + 1], shape[DIMS + 2], y[P], y[P + 1], y[P + 2],
                         qw, qx, qy, qz, ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2], ground[OFFSET],
                         points, gaps)
    return count


@njit(**_OPTS)
def body_gap(y, p, shape, grounds, points, gaps):
    """(lowest gap, index of its ground) of one body over every ground row; (inf, -1) without a shape."""
    lowest = math.inf
    which = -1
    if shape[KIND] != SHAPE_NONE:
        for j in range(grounds.shape[0]):
            count = body_points(y, p, shape, grounds[j], points, gaps)
            for k in range(count):
                if gaps[k] < lowest:
                    lowest = gaps[k]
                    which = j
    return lowest, which


@njit(**_OPTS)
def min_gaps(Y, prm, shapes, grounds, bodies, out):
    """out[m] ← the lowest gap of body bodies[m] (state rows Y) over every ground: one compiled pass."""
    points = np.empty((MAX_POINTS, 3))
    gaps = np.empty(MAX_POINTS)
    for m in range(bodies.shape[0]):
        i = bodies[m]
        out[m], _ = body_gap(Y[i], prm[i], shapes[i], grounds, points, gaps)


# ----------------------------------------------------------------------------- features (persistent contact)
# A feature is what can touch the plane: the sphere's surface (1), a box corner (8), a capsule's
# end sphere (2); a cylinder has its two rims' lowest points (0, 1) and their highest points
# (2, 3): rim k's highest point reaching the ground is the end face k landing flat, after which
# the face touches along its whole rim (4 rim points); within 1e-9 rad of upright a rim's "lowest
# point" is the one going down fastest (_rim_direction). Persistent contact tracks which features
# touch, so that another feature reaching the ground is an event even while the body rests or pivots.

#: Most features a shape has (the box's corners).
MAX_FEATURES = 8


@njit(**_OPTS)
def feature_gaps(y, p, shape, ground, gaps):
    """gaps[k] ← the gap of feature k of one body against one ground row; returns the number of features."""
    qw, qx, qy, qz = qmul(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], p[Q_PB], p[Q_PB + 1], p[Q_PB + 2], p[Q_PB + 3])
    nx, ny, nz = ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2]
    base = nx * y[P] + ny * y[P + 1] + nz * y[P + 2] - ground[OFFSET]
    kind = int(shape[KIND])
    a0, a1, a2 = shape[DIMS], shape[DIMS + 1], shape[DIMS + 2]
    count = 0
    if kind == SHAPE_SPHERE:
        gaps[0] = base - a0
        count = 1
    elif kind == SHAPE_BOX:
        for corner in range(8):
            sx = 1.0 if corner & 1 else -1.0
            sy = 1.0 if corner & 2 else -1.0
            sz = 1.0 if corner & 4 else -1.0
            ox, oy, oz = rotate(qw, qx, qy, qz, sx * a0, sy * a1, sz * a2)
            gaps[corner] = base + nx * ox + ny * oy + nz * oz
        count = 8
    elif kind == SHAPE_CAPSULE or kind == SHAPE_CYLINDER:
        ux, uy, uz = rotate(qw, qx, qy, qz, 0.0, 0.0, 1.0)
        cos_a = nx * ux + ny * uy + nz * uz
        radial = a0
        count = 2
        if kind == SHAPE_CYLINDER:
            px, py, pz = nx - cos_a * ux, ny - cos_a * uy, nz - cos_a * uz
            radial = a0 * math.sqrt(px * px + py * py + pz * pz)
            gaps[2] = base - a1 * cos_a + radial
            gaps[3] = base + a1 * cos_a + radial
            count = 4
        gaps[0] = base - a1 * cos_a - radial
        gaps[1] = base + a1 * cos_a - radial
    _pin = y[P], p[0], shape[0], ground[0], gaps[0]
    return count


@njit(**_OPTS)
def held_rim(shape, mask):
    """The end (0 or 1) whose rim alone a cylinder is held on (``mask``: that rim's lowest-point feature, not
    an end face, not both rims); -1 otherwise."""
    if int(shape[KIND]) != SHAPE_CYLINDER or mask & 12 or (mask & 3) == 3 or not mask & 3:
        return -1
    return 0 if mask & 1 else 1


@njit(**_OPTS)
def axis_tilt(y, p, nx, ny, nz):
    """(u, cos θ, p, sin θ) of a capsule's or cylinder's axis u (world) at state row y against the normal n:
    cos θ = n·u, p = n − cos θ u and sin θ = |p| (accurate near upright, where √(1 − cos² θ) is not)."""
    qw, qx, qy, qz = qmul(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], p[Q_PB], p[Q_PB + 1], p[Q_PB + 2], p[Q_PB + 3])
    ux, uy, uz = rotate(qw, qx, qy, qz, 0.0, 0.0, 1.0)
    cos_a = nx * ux + ny * uy + nz * uz
    px, py, pz = nx - cos_a * ux, ny - cos_a * uy, nz - cos_a * uz
    return ux, uy, uz, cos_a, px, py, pz, math.sqrt(px * px + py * py + pz * pz)


@njit(**_OPTS)
def _rim_direction(y, ux, uy, uz, nx, ny, nz, px, py, pz, across, flat):
    """The unit direction ρ (world, across the axis u) from a cylinder rim's lowest point −r ρ (from its end's
    centre) back up: (n − (n·u) u) / sin θ against the plane of normal n, given p = n − (n·u) u and |p| = sin θ.

    Within ``flat`` (rad) of upright the rim has no lowest point: ρ is then along n × ω across u (ω the
    body's angular velocity, from the state row y), the rim point that goes down fastest (a can set tipping
    from its end turns about that point); along p, or any direction across u, when the rim does not turn.
    """
    if across > flat:
        return px / across, py / across, pz / across
    ox, oy, oz = rotate(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], y[W], y[W + 1], y[W + 2])  # ω, world axes
    # the point −r ρ moves along n at −r n·(ω × ρ) = −r ρ·(n × ω): fastest down for ρ along n × ω
    dx, dy, dz = ny * oz - nz * oy, nz * ox - nx * oz, nx * oy - ny * ox
    size = 0.0
    for _ in range(2):
        along = dx * ux + dy * uy + dz * uz
        dx, dy, dz = dx - along * ux, dy - along * uy, dz - along * uz
        size = math.sqrt(dx * dx + dy * dy + dz * dz)
        if size > 0.0:
            break
        dx, dy, dz = px, py, pz
        if across == 0.0:  # any direction across u
            dx, dy, dz = (0.0, uz, -uy) if abs(ux) < 0.7 else (-uz, 0.0, ux)
    return dx / size, dy / size, dz / size


@njit(**_OPTS)
def feature_points(y, p, shape, ground, mask, points, gaps, owners):
    """The contact points (world), gaps and features (``owners``) of the features in the bit ``mask``.

    Returns how many points (≤ MAX_POINTS; a cylinder standing on an end gives 4 for its rim).
    """
    qw, qx, qy, qz = qmul(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], p[Q_PB], p[Q_PB + 1], p[Q_PB + 2], p[Q_PB + 3])
    nx, ny, nz = ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2]
    cx, cy, cz = y[P], y[P + 1], y[P + 2]
    base = nx * cx + ny * cy + nz * cz - ground[OFFSET]
    kind = int(shape[KIND])
    a0, a1, a2 = shape[DIMS], shape[DIMS + 1], shape[DIMS + 2]
    count = 0
    if kind == SHAPE_SPHERE and mask & 1:
        count = sphere_points(cx, cy, cz, a0, nx, ny, nz, ground[OFFSET], points, gaps)
        owners[0] = 0
    elif kind == SHAPE_BOX:
        for corner in range(8):
            if mask & (1 << corner) and count < MAX_POINTS:
                sx = 1.0 if corner & 1 else -1.0
                sy = 1.0 if corner & 2 else -1.0
                sz = 1.0 if corner & 4 else -1.0
                ox, oy, oz = rotate(qw, qx, qy, qz, sx * a0, sy * a1, sz * a2)
                points[count, 0], points[count, 1], points[count, 2] = cx + ox, cy + oy, cz + oz
                gaps[count] = base + nx * ox + ny * oy + nz * oz
                owners[count] = corner
                count += 1
    elif kind == SHAPE_CAPSULE:
        ux, uy, uz = rotate(qw, qx, qy, qz, 0.0, 0.0, 1.0)
        cos_a = nx * ux + ny * uy + nz * uz
        for end in range(2):
            if mask & (1 << end):
                side = -1.0 if end == 0 else 1.0
                points[count, 0] = cx + side * a1 * ux - a0 * nx
                points[count, 1] = cy + side * a1 * uy - a0 * ny
                points[count, 2] = cz + side * a1 * uz - a0 * nz
                gaps[count] = base + side * a1 * cos_a - a0
                owners[count] = end
                count += 1
    elif kind == SHAPE_CYLINDER:
        ux, uy, uz = rotate(qw, qx, qy, qz, 0.0, 0.0, 1.0)
        cos_a = nx * ux + ny * uy + nz * uz
        px, py, pz = nx - cos_a * ux, ny - cos_a * uy, nz - cos_a * uz
        across = math.sqrt(px * px + py * py + pz * pz)
        band = FEATURE_BAND * max(a0, a1)
        for end in range(2):
            if mask & (1 << end) or mask & (4 << end):
                side = -1.0 if end == 0 else 1.0
                if mask & (4 << end):  # standing on this end face: four rim points
                    e1x, e1y, e1z = rotate(qw, qx, qy, qz, 1.0, 0.0, 0.0)
                    e2x, e2y, e2z = rotate(qw, qx, qy, qz, 0.0, 1.0, 0.0)
                    for k in range(4):
                        if count < MAX_POINTS:
                            c = (1.0, 0.0, -1.0, 0.0)[k]
                            s = (0.0, 1.0, 0.0, -1.0)[k]
                            ox = side * a1 * ux + a0 * (c * e1x + s * e2x)
                            oy = side * a1 * uy + a0 * (c * e1y + s * e2y)
                            oz = side * a1 * uz + a0 * (c * e1z + s * e2z)
                            points[count, 0], points[count, 1], points[count, 2] = cx + ox, cy + oy, cz + oz
                            gaps[count] = base + nx * ox + ny * oy + nz * oz
                            owners[count] = end
                            count += 1
                elif count < MAX_POINTS:
                    rx, ry, rz = _rim_direction(y, ux, uy, uz, nx, ny, nz, px, py, pz, across, band / a0)
                    points[count, 0] = cx + side * a1 * ux - a0 * rx
                    points[count, 1] = cy + side * a1 * uy - a0 * ry
                    points[count, 2] = cz + side * a1 * uz - a0 * rz
                    gaps[count] = base + side * a1 * cos_a - a0 * across
                    owners[count] = end
                    count += 1
    _pin = y[P], p[0], shape[0], ground[0], points[0, 0], gaps[0], owners[0]
    return count


@njit(**_OPTS)
def opposite_rim_gap(y0, y, p, shape, ground, mask, band):
    """The gap (m) at state y of the point of a cylinder held on one rim (``mask``: that rim's feature alone)
    that was the rim's highest at y0, the step's start: a point of the body, opposite the held one. It reaches
    the ground when the end face comes down flat (the can rocking back onto its end), where the held lowest
    point jumps across the rim and no feature of feature_gaps goes below. inf for another shape or mask. Where
    that point was within ``band`` of the ground at y0 (the can on its end, held on one rim point), its gap
    above a floor ``band`` below where it was: it reaches that floor when the face comes down (a can at rest
    whose opposite point rose at round-off speed, 1e-9 m/s, tipped about the held point), not when the can
    tips from its end (the point rises)."""
    end = held_rim(shape, mask)
    if end < 0:
        return math.inf
    side = -1.0 if end == 0 else 1.0
    a0, a1 = shape[DIMS], shape[DIMS + 1]
    nx, ny, nz = ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2]
    ux, uy, uz, cos_a, px, py, pz, across = axis_tilt(y0, p, nx, ny, nz)
    rx, ry, rz = _rim_direction(y0, ux, uy, uz, nx, ny, nz, px, py, pz, across, FEATURE_BAND * max(a0, a1) / a0)
    ox, oy, oz = side * a1 * ux + a0 * rx, side * a1 * uy + a0 * ry, side * a1 * uz + a0 * rz  # from the centre
    start = nx * (y0[P] + ox) + ny * (y0[P + 1] + oy) + nz * (y0[P + 2] + oz) - ground[OFFSET]
    floor = start - band if start <= band else 0.0
    bx, by, bz = rotate_back(y0[Q], y0[Q + 1], y0[Q + 2], y0[Q + 3], ox, oy, oz)  # principal axes: fixed in the body
    ox, oy, oz = rotate(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], bx, by, bz)
    _pin = y0[P], y[P], p[0], shape[0], ground[0]
    return nx * (y[P] + ox) + ny * (y[P + 1] + oy) + nz * (y[P + 2] + oz) - ground[OFFSET] - floor
