"""Compiled body–body narrow phase: signed distance, normal and contact points of every shape pair.

For a pair (A, B) of shapes (sphere, box, cylinder, capsule; shape rows as in layout.py, each
posed by its centre c (world, m) and orientation q_WS (w, x, y, z)), :func:`pair_contacts`
writes

* ``dist[m]``: the signed distance (m): the distance when apart, minus the penetration depth
  (the shortest translation of B that separates them) when they overlap;
* ``normal[m]``: the unit normal from A to B (world axes) along which that distance is taken;
* ``count[m]`` contact points, ``points[m, k, 0:3]`` on A's surface and ``points[m, k, 3:6]``
  on B's (world, m), with ``seps[m, k]`` = (p_B − p_A)·n; point 0 is the deepest
  (seps[m, 0] = dist[m]). More than one point where a feature touches flat: two box faces
  (the incident face clipped to the reference face: up to 8 points), a capsule lying on a box
  face or parallel to another capsule (2), a cylinder standing or lying on a box face (its rim's 4
  points along its local ±x, ±y, its point toward the box's centre and, tilted, its deepest, clipped;
  or its side's line, clipped), two cylinder ends (each rim's points within the other disk and where
  the rims cross), a cylinder's or capsule's side on a cylinder's end (the chord over
  the disk, 2) or along a parallel cylinder (their overlap, 2). Every point whose separation is within
  ``FEATURE_BAND`` × the pair's size of the deepest, or that penetrates, is reported.

Closed forms: sphere–sphere, sphere–capsule, capsule–capsule (closest points of segments),
sphere–box and sphere–cylinder (nearest point of a box, of a solid cylinder). Polytope cores
(box–box, capsule–box as segment–box): GJK's exact distance when apart, the separating-axis
test on the Minkowski difference's face normals (15 axes; 6 for segment–box) when they
overlap or are apart by at most NEAR_TOUCH × their size, which is exact for polytopes (apart,
for a face or an edge against the other; corner on corner or edge, the distance along the
best axis, a lower bound). Pairs with a cylinder other than sphere–cylinder: GJK
and EPA on support functions (convex.py) give the direction to ~1e-5 rad; Newton's method on
the support functions, stratum by stratum (refine.py), takes it to round-off; point 0 is on
both support sets along it (refine.feature_point), nearest GJK/EPA's witness points.

One compiled call per batch: no Python call per pair, no allocation per pair.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..jit import INLINE, JIT
from ..rotation import matrix
from .convex import (CORE_BOX, CORE_CYLINDER, CORE_POINT, CORE_SEGMENT, EPA_MAX_FACES, EPA_MAX_VERTICES,
                     POSE_WIDTH, epa, gjk, support)
from .layout import DIMS, KIND, SHAPE_BOX, SHAPE_CAPSULE, SHAPE_SPHERE
from .refine import feature_point, refine_normal
from .shapes import FEATURE_BAND

__all__ = ["make_workspace_jit", "MAX_PAIR_POINTS", "FACE_ALIGNMENT", "set_pose", "surface_point", "ball_contact",
           "pair_contact", "pair_contacts",
           "boxes_apart", "boxes_apart_turned", "apart_bounds", "face_patch"]

#: Most contact points one pair reports (a box face clipped against another: a polygon of up to 8 corners; a
#: cylinder's end, up to 6 rim points, clipped against a box face: up to 10).
MAX_PAIR_POINTS = 10
#: A cylinder end's rim polygon (_rim_polygon) takes a rim point toward the other body's centre, and one deepest
#: into the face it stands on, unless that direction's part across the axis is below RIM_ACROSS × its length
#: (along the axis, or so near it that every rim point is as deep to RIM_ACROSS × the radius) or it is within
#: RIM_ACROSS (rad) of a point taken already.
RIM_ACROSS = 1e-11
#: A normal within this angle (rad) of a box face's normal makes that face a reference face for clipping.
FACE_ALIGNMENT = 1e-6
#: Polytopes apart by at most this × the pair's size take the separating-axis test's normal, as when they
#: overlap: GJK's (its witnesses' difference over the distance) carries their round-off divided by the distance
#: (a box's corner 3e-13 m from a face, at rest in a pile, got a normal 90° off the face's).
NEAR_TOUCH = 1e-6
#: A pair with a cylinder apart by d (GJK's, an upper bound of the distance, within ~2e-9 × the size of it) whose
#: refined sep falls short of d by more than CLIMB_GAP × its size started the refinement too far off the normal
#: (GJK's witnesses' round-off divided by a small distance: a box's edge 2.7e-7 m from a can's rim got a direction
#: 1.3e-2 rad off, beyond refine.NEAR, and the refinement stopped at −1.07e-3 m): a pattern search
#: (_climbed_normal) takes the direction from CLIMB_START rad down to CLIMB_END, in at most CLIMB_STEPS steps,
#: before the refinement.
CLIMB_GAP, CLIMB_START, CLIMB_END, CLIMB_STEPS = 1e-7, 5e-2, 1e-8, 400
#: Touching cores whose direction from GJK climbs to less than its distance: GJK again with B moved this × the
#: pair's size along the centres' offset (m per m), for a direction from witnesses that far apart.
NUDGE = 1e-4

_KIND, _DIM, _C, _R = 0, 1, 4, 7


@njit(**INLINE)
def set_pose(shape_kind, d0, d1, d2, cx, cy, cz, qw, qx, qy, qz, pose):
    """Write the core of a shape (layout.SHAPE_*) with its pose into a convex.py pose row; returns its margin (m)."""
    r = matrix(qw, qx, qy, qz)
    for k in range(9):
        pose[_R + k] = r[k]
    pose[_C], pose[_C + 1], pose[_C + 2] = cx, cy, cz
    margin = 0.0
    if shape_kind == SHAPE_SPHERE:
        pose[_KIND] = CORE_POINT
        pose[_DIM], pose[_DIM + 1], pose[_DIM + 2] = 0.0, 0.0, 0.0
        margin = d0
    elif shape_kind == SHAPE_CAPSULE:
        pose[_KIND] = CORE_SEGMENT
        pose[_DIM], pose[_DIM + 1], pose[_DIM + 2] = d1, 0.0, 0.0
        margin = d0
    elif shape_kind == SHAPE_BOX:
        pose[_KIND] = CORE_BOX
        pose[_DIM], pose[_DIM + 1], pose[_DIM + 2] = d0, d1, d2
    else:
        pose[_KIND] = CORE_CYLINDER
        pose[_DIM], pose[_DIM + 1], pose[_DIM + 2] = d0, d1, 0.0
    return margin


@njit(**INLINE)
def _to_local(pose, x, y, z):
    dx, dy, dz = x - pose[_C], y - pose[_C + 1], z - pose[_C + 2]
    return (pose[_R + 0] * dx + pose[_R + 3] * dy + pose[_R + 6] * dz, pose[_R + 1] * dx + pose[_R + 4] * dy + pose[_R + 7] * dz, pose[_R + 2] * dx + pose[_R + 5] * dy + pose[_R + 8] * dz)


@njit(**INLINE)
def _to_world(pose, lx, ly, lz):
    return (pose[_C] + pose[_R + 0] * lx + pose[_R + 1] * ly + pose[_R + 2] * lz, pose[_C + 1] + pose[_R + 3] * lx + pose[_R + 4] * ly + pose[_R + 5] * lz,
            pose[_C + 2] + pose[_R + 6] * lx + pose[_R + 7] * ly + pose[_R + 8] * lz)


@njit(**INLINE)
def _axis(pose, i):
    """The world direction of the core's local axis i."""
    return pose[_R + i], pose[_R + 3 + i], pose[_R + 6 + i]


@njit(**JIT)
def surface_point(pose, margin, x, y, z, nx, ny, nz):
    """The point of the shape's surface (core + margin) nearest the world point x (m).

    ``n`` is used only where the nearest point is not unique along a line (x on a point or
    segment core): the point is then taken along n.
    """
    lx, ly, lz = _to_local(pose, x, y, z)
    kind = int(pose[_KIND])
    a0, a1, a2 = pose[_DIM], pose[_DIM + 1], pose[_DIM + 2]
    qx, qy, qz = 0.0, 0.0, 0.0
    if kind == CORE_SEGMENT:
        qz = min(a0, max(-a0, lz))
    elif kind == CORE_BOX:
        qx, qy, qz = min(a0, max(-a0, lx)), min(a1, max(-a1, ly)), min(a2, max(-a2, lz))
        if qx == lx and qy == ly and qz == lz:  # inside: to the nearest face
            g0, g1, g2 = a0 - abs(lx), a1 - abs(ly), a2 - abs(lz)
            if g0 <= g1 and g0 <= g2:
                qx = a0 if lx >= 0.0 else -a0
            elif g1 <= g2:
                qy = a1 if ly >= 0.0 else -a1
            else:
                qz = a2 if lz >= 0.0 else -a2
    elif kind == CORE_CYLINDER:
        rho = math.sqrt(lx * lx + ly * ly)
        qx, qy, qz = lx, ly, min(a1, max(-a1, lz))
        if rho > a0:
            qx, qy = lx * a0 / rho, ly * a0 / rho
        elif qz == lz:  # inside: to the nearer of the side and the end face
            if a0 - rho <= a1 - abs(lz):
                if rho > 0.0:
                    qx, qy = lx * a0 / rho, ly * a0 / rho
                else:
                    qx, qy = a0, 0.0
            else:
                qz = a1 if lz >= 0.0 else -a1
    wx, wy, wz = _to_world(pose, qx, qy, qz)
    if margin > 0.0:
        dx, dy, dz = x - wx, y - wy, z - wz
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        if d > 0.0:
            wx, wy, wz = wx + margin * dx / d, wy + margin * dy / d, wz + margin * dz / d
        else:
            wx, wy, wz = wx + margin * nx, wy + margin * ny, wz + margin * nz
    return wx, wy, wz


@njit(**JIT)
def _closest_segments(p1x, p1y, p1z, d1x, d1y, d1z, p2x, p2y, p2z, d2x, d2y, d2z):
    """Parameters s, t ∈ [0, 1] of the closest points p1 + s d1 and p2 + t d2 of two segments (Ericson 5.1.9)."""
    rx, ry, rz = p1x - p2x, p1y - p2y, p1z - p2z
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    s, t = 0.0, 0.0
    if a <= 0.0 and e <= 0.0:
        pass
    elif a <= 0.0:
        t = min(1.0, max(0.0, f / e))
    else:
        c = d1x * rx + d1y * ry + d1z * rz
        if e <= 0.0:
            s = min(1.0, max(0.0, -c / a))
        else:
            b = d1x * d2x + d1y * d2y + d1z * d2z
            denom = a * e - b * b
            if denom > 0.0:
                s = min(1.0, max(0.0, (b * f - c * e) / denom))
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = min(1.0, max(0.0, -c / a))
            elif t > 1.0:
                t = 1.0
                s = min(1.0, max(0.0, (b - c) / a))
    return s, t


@njit(**INLINE)
def _put(res, seps, k, ax, ay, az, bx, by, bz, nx, ny, nz):
    res[k, 0], res[k, 1], res[k, 2] = ax, ay, az
    res[k, 3], res[k, 4], res[k, 5] = bx, by, bz
    seps[k] = (bx - ax) * nx + (by - ay) * ny + (bz - az) * nz


@njit(**INLINE)
def _round_pair(ax, ay, az, ra, bx, by, bz, rb, fx, fy, fz, res, seps, k):
    """Points of two balls (centres a, b on the cores; radii ra, rb) along b − a (or f if a = b); returns sd, n."""
    dx, dy, dz = bx - ax, by - ay, bz - az
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    if d > 0.0:
        nx, ny, nz = dx / d, dy / d, dz / d
    else:
        nx, ny, nz = fx, fy, fz
    _put(res, seps, k, ax + ra * nx, ay + ra * ny, az + ra * nz, bx - rb * nx, by - rb * ny, bz - rb * nz, nx, ny, nz)
    return d - ra - rb, nx, ny, nz


@njit(**INLINE)
def _perpendicular(ux, uy, uz, dx, dy, dz):
    """A unit vector across u, towards d's part across u if it has one."""
    t = dx * ux + dy * uy + dz * uz
    px, py, pz = dx - t * ux, dy - t * uy, dz - t * uz
    p = math.sqrt(px * px + py * py + pz * pz)
    if p <= 0.0:
        if abs(ux) < 0.6:
            px, py, pz = 0.0, -uz, uy
        else:
            px, py, pz = -uz, 0.0, ux
        p = math.sqrt(px * px + py * py + pz * pz)
    return px / p, py / p, pz / p


@njit(**INLINE)
def _segment_ends(pose):
    ux, uy, uz = _axis(pose, 2)
    h = pose[_DIM]
    return pose[_C] - h * ux, pose[_C + 1] - h * uy, pose[_C + 2] - h * uz, 2.0 * h * ux, 2.0 * h * uy, 2.0 * h * uz


@njit(**JIT)
def _point_segment(pa, ra, pb, rb, res, seps):
    """Sphere (A) against capsule (B): the ball at the nearest point of B's segment."""
    px, py, pz, dx, dy, dz = _segment_ends(pb)
    ee = dx * dx + dy * dy + dz * dz
    t = 0.0
    if ee > 0.0:
        t = min(1.0, max(0.0, ((pa[_C] - px) * dx + (pa[_C + 1] - py) * dy + (pa[_C + 2] - pz) * dz) / ee))
    ux, uy, uz = _axis(pb, 2)
    fx, fy, fz = _perpendicular(ux, uy, uz, 0.0, 0.0, 0.0)
    sd, nx, ny, nz = _round_pair(pa[_C], pa[_C + 1], pa[_C + 2], ra, px + t * dx, py + t * dy, pz + t * dz, rb,
                                 fx, fy, fz, res, seps, 0)
    return sd, nx, ny, nz, 1


@njit(**JIT)
def _segment_segment(pa, ra, pb, rb, band, res, seps):
    """Capsule (A) against capsule (B): closest points of the segments; both overlap ends when parallel."""
    p1x, p1y, p1z, d1x, d1y, d1z = _segment_ends(pa)
    p2x, p2y, p2z, d2x, d2y, d2z = _segment_ends(pb)
    s, t = _closest_segments(p1x, p1y, p1z, d1x, d1y, d1z, p2x, p2y, p2z, d2x, d2y, d2z)
    ax, ay, az = p1x + s * d1x, p1y + s * d1y, p1z + s * d1z
    bx, by, bz = p2x + t * d2x, p2y + t * d2y, p2z + t * d2z
    ux, uy, uz = _axis(pa, 2)
    vx, vy, vz = _axis(pb, 2)
    # the axes' common normal, towards B, for crossing cores
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    cross = math.sqrt(cx * cx + cy * cy + cz * cz)
    ox, oy, oz = pb[_C] - pa[_C], pb[_C + 1] - pa[_C + 1], pb[_C + 2] - pa[_C + 2]
    if cross > 0.0:
        sgn = 1.0 if cx * ox + cy * oy + cz * oz >= 0.0 else -1.0
        fx, fy, fz = sgn * cx / cross, sgn * cy / cross, sgn * cz / cross
    else:
        fx, fy, fz = _perpendicular(ux, uy, uz, ox, oy, oz)
    sd, nx, ny, nz = _round_pair(ax, ay, az, ra, bx, by, bz, rb, fx, fy, fz, res, seps, 0)
    count = 1
    if cross <= FACE_ALIGNMENT and pa[_DIM] > 0.0 and pb[_DIM] > 0.0:
        # parallel: the ends of the overlap of B's segment projected on A's, if it has length
        la = 2.0 * pa[_DIM]
        t0 = (p2x - p1x) * ux + (p2y - p1y) * uy + (p2z - p1z) * uz
        t1 = t0 + (d2x * ux + d2y * uy + d2z * uz)
        lo, hi = max(0.0, min(t0, t1)), min(la, max(t0, t1))
        if hi - lo > band:
            count = 0
            for end in (lo, hi):
                qx, qy, qz = p1x + end * ux, p1y + end * uy, p1z + end * uz
                # nearest point of B's segment to q
                ee = d2x * d2x + d2y * d2y + d2z * d2z
                tt = min(1.0, max(0.0, ((qx - p2x) * d2x + (qy - p2y) * d2y + (qz - p2z) * d2z) / ee))
                _round_pair(qx, qy, qz, ra, p2x + tt * d2x, p2y + tt * d2y, p2z + tt * d2z, rb, nx, ny, nz,
                            res, seps, count)
                count += 1
            _deepest_first(res, seps, count)
    return sd, nx, ny, nz, count


@njit(**JIT)
def _point_box(pa, ra, pb, res, seps):
    """Sphere (A) against box (B): the box point nearest the centre (the nearest face's when inside)."""
    lx, ly, lz = _to_local(pb, pa[_C], pa[_C + 1], pa[_C + 2])
    a0, a1, a2 = pb[_DIM], pb[_DIM + 1], pb[_DIM + 2]
    qx, qy, qz = min(a0, max(-a0, lx)), min(a1, max(-a1, ly)), min(a2, max(-a2, lz))
    if qx == lx and qy == ly and qz == lz:  # centre inside the box: out through the nearest face
        g0, g1, g2 = a0 - abs(lx), a1 - abs(ly), a2 - abs(lz)
        mx, my, mz = 0.0, 0.0, 0.0
        if g0 <= g1 and g0 <= g2:
            mx = 1.0 if lx >= 0.0 else -1.0
            qx, depth = mx * a0, g0
        elif g1 <= g2:
            my = 1.0 if ly >= 0.0 else -1.0
            qy, depth = my * a1, g1
        else:
            mz = 1.0 if lz >= 0.0 else -1.0
            qz, depth = mz * a2, g2
        # normal from the sphere to the box: into the box, against the face's outward normal m
        nx = -(pb[_R + 0] * mx + pb[_R + 1] * my + pb[_R + 2] * mz)
        ny = -(pb[_R + 3] * mx + pb[_R + 4] * my + pb[_R + 5] * mz)
        nz = -(pb[_R + 6] * mx + pb[_R + 7] * my + pb[_R + 8] * mz)
        bx, by, bz = _to_world(pb, qx, qy, qz)
        _put(res, seps, 0, pa[_C] + ra * nx, pa[_C + 1] + ra * ny, pa[_C + 2] + ra * nz, bx, by, bz, nx, ny, nz)
        return -depth - ra, nx, ny, nz, 1
    bx, by, bz = _to_world(pb, qx, qy, qz)
    sd, nx, ny, nz = _round_pair(pa[_C], pa[_C + 1], pa[_C + 2], ra, bx, by, bz, 0.0, 1.0, 0.0, 0.0, res, seps, 0)
    return sd, nx, ny, nz, 1


@njit(**JIT)
def _point_cylinder(pa, ra, pb, res, seps):
    """Sphere (A) against cylinder (B): the nearest point of the solid cylinder (its nearest face when inside)."""
    lx, ly, lz = _to_local(pb, pa[_C], pa[_C + 1], pa[_C + 2])
    r, h = pb[_DIM], pb[_DIM + 1]
    rho = math.sqrt(lx * lx + ly * ly)
    if rho <= r and abs(lz) <= h:
        mx, my, mz = 0.0, 0.0, 0.0
        qx, qy, qz = lx, ly, lz
        if r - rho <= h - abs(lz):
            if rho > 0.0:
                mx, my = lx / rho, ly / rho
            else:
                mx = 1.0
            qx, qy, depth = r * mx, r * my, r - rho
        else:
            mz = 1.0 if lz >= 0.0 else -1.0
            qz, depth = mz * h, h - abs(lz)
        nx = -(pb[_R + 0] * mx + pb[_R + 1] * my + pb[_R + 2] * mz)
        ny = -(pb[_R + 3] * mx + pb[_R + 4] * my + pb[_R + 5] * mz)
        nz = -(pb[_R + 6] * mx + pb[_R + 7] * my + pb[_R + 8] * mz)
        bx, by, bz = _to_world(pb, qx, qy, qz)
        _put(res, seps, 0, pa[_C] + ra * nx, pa[_C + 1] + ra * ny, pa[_C + 2] + ra * nz, bx, by, bz, nx, ny, nz)
        return -depth - ra, nx, ny, nz, 1
    qx, qy = lx, ly
    if rho > r:
        qx, qy = lx * r / rho, ly * r / rho
    qz = min(h, max(-h, lz))
    bx, by, bz = _to_world(pb, qx, qy, qz)
    sd, nx, ny, nz = _round_pair(pa[_C], pa[_C + 1], pa[_C + 2], ra, bx, by, bz, 0.0, 1.0, 0.0, 0.0, res, seps, 0)
    return sd, nx, ny, nz, 1


@njit(**INLINE)
def _box_radius(pose, ux, uy, uz):
    """Half the width of the box core along the unit world direction u."""
    return (pose[_DIM] * abs(pose[_R + 0] * ux + pose[_R + 3] * uy + pose[_R + 6] * uz) + pose[_DIM + 1] * abs(pose[_R + 1] * ux + pose[_R + 4] * uy + pose[_R + 7] * uz)
            + pose[_DIM + 2] * abs(pose[_R + 2] * ux + pose[_R + 5] * uy + pose[_R + 8] * uz))


@njit(**INLINE)
def _core_radius(pose, ux, uy, uz):
    if int(pose[_KIND]) == CORE_BOX:
        return _box_radius(pose, ux, uy, uz)
    return pose[_DIM] * abs(pose[_R + 2] * ux + pose[_R + 5] * uy + pose[_R + 8] * uz)  # segment along local z


@njit(**JIT)
def _sat(pa, pb, scale):
    """Separating-axis test of two polytope cores (box or segment A, box B) overlapping or touching.

    The candidate axes are the face normals of A ⊖ B: the boxes' face normals and the cross
    products of their edge directions (a segment has one edge and no face). Returns
    (sd, ux, uy, uz, axis id): the largest separation over the axes (exact while they overlap),
    u oriented from A to B; ids 0–2 A's faces, 3–5 B's, 6 + 3i + j edge i of A × edge j of B.
    """
    ox, oy, oz = pb[_C] - pa[_C], pb[_C + 1] - pa[_C + 1], pb[_C + 2] - pa[_C + 2]
    a_is_box = int(pa[_KIND]) == CORE_BOX
    best = -math.inf
    bx, by, bz = 0.0, 0.0, 1.0
    best_id = -1
    # face axes first, so that an edge axis has to be strictly better by round-off to replace them
    for k in range(6):
        if k < 3 and not a_is_box:
            continue
        ux, uy, uz = _axis(pa, k) if k < 3 else _axis(pb, k - 3)
        proj = ux * ox + uy * oy + uz * oz
        sep = abs(proj) - _core_radius(pa, ux, uy, uz) - _box_radius(pb, ux, uy, uz)
        if sep > best:
            sgn = 1.0 if proj >= 0.0 else -1.0
            best, bx, by, bz, best_id = sep, sgn * ux, sgn * uy, sgn * uz, k
    margin = 1e-12 * scale
    for i in range(3):
        if i < 2 and not a_is_box:
            continue
        ex, ey, ez = _axis(pa, i)
        for j in range(3):
            fx, fy, fz = _axis(pb, j)
            cx, cy, cz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
            norm = math.sqrt(cx * cx + cy * cy + cz * cz)
            if norm < 1e-9:
                continue
            cx, cy, cz = cx / norm, cy / norm, cz / norm
            proj = cx * ox + cy * oy + cz * oz
            sep = abs(proj) - _core_radius(pa, cx, cy, cz) - _box_radius(pb, cx, cy, cz)
            if sep > best + margin:
                sgn = 1.0 if proj >= 0.0 else -1.0
                best, bx, by, bz, best_id = sep, sgn * cx, sgn * cy, sgn * cz, 6 + 3 * i + j
    return best, bx, by, bz, best_id


@njit(**JIT)
def _support_edge(pose, i, ux, uy, uz):
    """The edge along local axis i of the box core furthest along u: (start, direction) in world (m)."""
    lx = pose[_R + 0] * ux + pose[_R + 3] * uy + pose[_R + 6] * uz
    ly = pose[_R + 1] * ux + pose[_R + 4] * uy + pose[_R + 7] * uz
    lz = pose[_R + 2] * ux + pose[_R + 5] * uy + pose[_R + 8] * uz
    sx = pose[_DIM] if lx >= 0.0 else -pose[_DIM]
    sy = pose[_DIM + 1] if ly >= 0.0 else -pose[_DIM + 1]
    sz = pose[_DIM + 2] if lz >= 0.0 else -pose[_DIM + 2]
    if i == 0:
        sx = -pose[_DIM]
    elif i == 1:
        sy = -pose[_DIM + 1]
    else:
        sz = -pose[_DIM + 2]
    px, py, pz = _to_world(pose, sx, sy, sz)
    ex, ey, ez = _axis(pose, i)
    length = 2.0 * pose[_DIM + i]
    return px, py, pz, length * ex, length * ey, length * ez


@njit(**JIT)
def _sat_witness(pa, ma, pb, sd_core, ux, uy, uz, axis_id, res, seps):
    """One pair of points for a SAT result: the deepest support feature's point and its match on the other core."""
    if axis_id >= 6:  # edge against edge: closest points of the two support edges
        i, j = (axis_id - 6) // 3, (axis_id - 6) % 3
        if int(pa[_KIND]) == CORE_BOX:
            p1x, p1y, p1z, d1x, d1y, d1z = _support_edge(pa, i, ux, uy, uz)
        else:
            p1x, p1y, p1z, d1x, d1y, d1z = _segment_ends(pa)
        p2x, p2y, p2z, d2x, d2y, d2z = _support_edge(pb, j, -ux, -uy, -uz)
        s, t = _closest_segments(p1x, p1y, p1z, d1x, d1y, d1z, p2x, p2y, p2z, d2x, d2y, d2z)
        ax, ay, az = p1x + s * d1x, p1y + s * d1y, p1z + s * d1z
        bx, by, bz = p2x + t * d2x, p2y + t * d2y, p2z + t * d2z
    elif axis_id >= 3:  # B's face: A's deepest point, projected onto that face
        from_a = _support_point(pa, ux, uy, uz)
        ax, ay, az = from_a
        h = (pb[_C] * ux + pb[_C + 1] * uy + pb[_C + 2] * uz) - _box_radius(pb, ux, uy, uz)
        off = ax * ux + ay * uy + az * uz - h
        bx, by, bz = surface_point(pb, 0.0, ax - off * ux, ay - off * uy, az - off * uz, ux, uy, uz)
    else:  # A's face: B's deepest point, projected onto it
        bx, by, bz = _support_point(pb, -ux, -uy, -uz)
        h = (pa[_C] * ux + pa[_C + 1] * uy + pa[_C + 2] * uz) + _box_radius(pa, ux, uy, uz)
        off = bx * ux + by * uy + bz * uz - h
        ax, ay, az = surface_point(pa, 0.0, bx - off * ux, by - off * uy, bz - off * uz, ux, uy, uz)
    _put(res, seps, 0, ax + ma * ux, ay + ma * uy, az + ma * uz, bx, by, bz, ux, uy, uz)


@njit(**INLINE)
def _support_point(pose, ux, uy, uz):
    """The core's support point along u; for a face or an edge, the middle of that feature."""
    lx = pose[_R + 0] * ux + pose[_R + 3] * uy + pose[_R + 6] * uz
    ly = pose[_R + 1] * ux + pose[_R + 4] * uy + pose[_R + 7] * uz
    lz = pose[_R + 2] * ux + pose[_R + 5] * uy + pose[_R + 8] * uz
    tol = FACE_ALIGNMENT
    kind = int(pose[_KIND])
    sx, sy, sz = 0.0, 0.0, 0.0
    if kind == CORE_BOX:
        sx = 0.0 if abs(lx) <= tol else (pose[_DIM] if lx > 0.0 else -pose[_DIM])
        sy = 0.0 if abs(ly) <= tol else (pose[_DIM + 1] if ly > 0.0 else -pose[_DIM + 1])
        sz = 0.0 if abs(lz) <= tol else (pose[_DIM + 2] if lz > 0.0 else -pose[_DIM + 2])
    elif kind == CORE_SEGMENT:
        sz = 0.0 if abs(lz) <= tol else (pose[_DIM] if lz > 0.0 else -pose[_DIM])
    return _to_world(pose, sx, sy, sz)


@njit(**INLINE)
def _face_of(pose, ux, uy, uz):
    """(axis i, sign, |cos|) of the box face whose outward normal is nearest u."""
    best, axis, sgn = -1.0, 0, 1.0
    for i in range(3):
        ex, ey, ez = _axis(pose, i)
        c = ex * ux + ey * uy + ez * uz
        if abs(c) > best:
            best, axis, sgn = abs(c), i, (1.0 if c >= 0.0 else -1.0)
    return axis, sgn, best


@njit(**INLINE)
def _clip(poly, src, n, px, py, pz, ox, oy, oz, limit):
    """Sutherland–Hodgman: keep the part of polygon poly[src, :n] with (p − o)·plane ≤ limit; returns its size."""
    dst = 1 - src
    m = 0
    for k in range(n):
        k1 = (k + 1) % n
        ax, ay, az = poly[src, k, 0], poly[src, k, 1], poly[src, k, 2]
        bx, by, bz = poly[src, k1, 0], poly[src, k1, 1], poly[src, k1, 2]
        da = (ax - ox) * px + (ay - oy) * py + (az - oz) * pz - limit
        db = (bx - ox) * px + (by - oy) * py + (bz - oz) * pz - limit
        if da <= 0.0:
            poly[dst, m, 0], poly[dst, m, 1], poly[dst, m, 2] = ax, ay, az
            m += 1
        if (da < 0.0 < db) or (db < 0.0 < da):
            t = da / (da - db)
            poly[dst, m, 0], poly[dst, m, 1], poly[dst, m, 2] = ax + t * (bx - ax), ay + t * (by - ay), az + t * (bz - az)
            m += 1
    _pin = poly[0, 0, 0]
    return m


@njit(**INLINE)
def _rim_point(pose, cx, cy, cz, r, j):
    """Rim point j (0–3: along the core's local +x, +y, −x, −y) of the cylinder end centred at c, radius r (world)."""
    c1 = 1.0 if j == 0 else (-1.0 if j == 2 else 0.0)
    c2 = 1.0 if j == 1 else (-1.0 if j == 3 else 0.0)
    e1x, e1y, e1z = _axis(pose, 0)
    e2x, e2y, e2z = _axis(pose, 1)
    return cx + r * (c1 * e1x + c2 * e2x), cy + r * (c1 * e1y + c2 * e2y), cz + r * (c1 * e1z + c2 * e2z)


@njit(**INLINE)
def _rim_angle(pose, wx, wy, wz):
    """The angle (rad, in [0, 2π)) about the cylinder core's local z, from its local x, of direction w's part
    across the axis, or NaN when that part is below RIM_ACROSS × |w|."""
    e1x, e1y, e1z = _axis(pose, 0)
    e2x, e2y, e2z = _axis(pose, 1)
    lx, ly = wx * e1x + wy * e1y + wz * e1z, wx * e2x + wy * e2y + wz * e2z
    if lx * lx + ly * ly <= (RIM_ACROSS * RIM_ACROSS) * (wx * wx + wy * wy + wz * wz):
        return math.nan
    a = math.atan2(ly, lx)
    return a + 2.0 * math.pi if a < 0.0 else a


@njit(**INLINE)
def _at_angle(pose, cx, cy, cz, r, a):
    """The rim point at angle a (rad about the core's local z, from its local x) of the end centred at c, radius r."""
    e1x, e1y, e1z = _axis(pose, 0)
    e2x, e2y, e2z = _axis(pose, 1)
    ca, sa = r * math.cos(a), r * math.sin(a)
    return cx + ca * e1x + sa * e2x, cy + ca * e1y + sa * e2y, cz + ca * e1z + sa * e2z


@njit(**JIT)
def _rim_polygon(pose, cx, cy, cz, r, a0, a1, poly):
    """The rim of the cylinder end centred at c (world, m), radius r, as a convex polygon into poly[0]: its four
    points along the core's local +x, +y, −x, −y (_rim_point) and the rim points at angles a0 and a1 (_rim_angle;
    NaN: none) in their places between them, each unless within RIM_ACROSS (rad) of a point there. Returns the
    count (4 to 6)."""
    quarter = 0.5 * math.pi
    lo, hi = (a0, a1) if math.isnan(a1) or a0 <= a1 else (a1, a0)  # NaN last
    if math.isnan(lo):
        lo, hi = hi, lo
    if not math.isnan(hi) and hi - lo <= RIM_ACROSS:
        hi = math.nan
    n = 0
    for j in range(4):
        poly[0, n, 0], poly[0, n, 1], poly[0, n, 2] = _rim_point(pose, cx, cy, cz, r, j)
        n += 1
        for a in (lo, hi):
            if not math.isnan(a) and j * quarter + RIM_ACROSS < a < (j + 1) * quarter - RIM_ACROSS:
                poly[0, n, 0], poly[0, n, 1], poly[0, n, 2] = _at_angle(pose, cx, cy, cz, r, a)
                n += 1
    return n


@njit(**JIT)
def _deepest_over_face(ref, i, rx, ry, rz, cx, cy, cz, inc, ox, oy, oz, r, deepest):
    """The point of a cylinder end's disk (centre o, radius r, world, m) deepest along −r over the reference box
    face i (outward normal r, centre c): a vertex of the disk cut by the face's four side planes, so the best of
    the rim point deepest along −r (angle ``deepest``, _rim_angle; NaN: none), the rim's crossings with the side
    planes and the face's corners carried along r onto the end's plane, each within the other sides and the disk
    (to round-off). The rim polygon's points, on chords, can lie above it where the rim crosses a side. Returns
    (found, x, y, z)."""
    ux, uy, uz = _axis(inc, 2)
    slack = 1e-12 * max(r, max(ref[_DIM + (i + 1) % 3], ref[_DIM + (i + 2) % 3]))
    best, bx, by, bz = math.inf, 0.0, 0.0, 0.0
    for cand in range(13):  # 0: the deepest rim point; 1–8: two crossings per side plane; 9–12: the corners
        px, py, pz, ok = 0.0, 0.0, 0.0, True
        if cand == 0:
            ok = not math.isnan(deepest)
            if ok:
                px, py, pz = _at_angle(inc, ox, oy, oz, r, deepest)
        elif cand <= 8:
            side = (cand - 1) // 2
            j = (i + 1 + side // 2) % 3
            sx, sy, sz = _axis(ref, j)
            sg = 1.0 if side % 2 == 0 else -1.0
            sx, sy, sz = sg * sx, sg * sy, sg * sz
            e1x, e1y, e1z = _axis(inc, 0)
            e2x, e2y, e2z = _axis(inc, 1)
            ca = r * (e1x * sx + e1y * sy + e1z * sz)
            cb = r * (e2x * sx + e2y * sy + e2z * sz)
            c = ref[_DIM + j] - ((ox - cx) * sx + (oy - cy) * sy + (oz - cz) * sz)
            rho = math.sqrt(ca * ca + cb * cb)
            ok = rho > 0.0 and abs(c) <= rho
            if ok:
                ang = math.atan2(cb, ca) + (1.0 if cand % 2 == 1 else -1.0) * math.acos(c / rho)
                px, py, pz = _at_angle(inc, ox, oy, oz, r, ang)
        else:
            corner = cand - 9
            j, k = (i + 1) % 3, (i + 2) % 3
            sj = ref[_DIM + j] * (1.0 if corner == 0 or corner == 1 else -1.0)
            sk = ref[_DIM + k] * (1.0 if corner == 1 or corner == 2 else -1.0)
            jx, jy, jz = _axis(ref, j)
            kx, ky, kz = _axis(ref, k)
            qx, qy, qz = cx + sj * jx + sk * kx, cy + sj * jy + sk * ky, cz + sj * jz + sk * kz
            t = ((ox - qx) * ux + (oy - qy) * uy + (oz - qz) * uz) / (rx * ux + ry * uy + rz * uz)
            px, py, pz = qx + t * rx, qy + t * ry, qz + t * rz
            dx, dy, dz = px - ox, py - oy, pz - oz
            ok = dx * dx + dy * dy + dz * dz <= (r + slack) ** 2
        inside = ok
        for side in range(4):
            j = (i + 1 + side // 2) % 3
            sx, sy, sz = _axis(ref, j)
            sg = 1.0 if side % 2 == 0 else -1.0
            inside = inside and sg * ((px - cx) * sx + (py - cy) * sy + (pz - cz) * sz) <= ref[_DIM + j] + slack
        d = (px - cx) * rx + (py - cy) * ry + (pz - cz) * rz
        if inside and d < best:
            best, bx, by, bz = d, px, py, pz
    _pin = ref[0], inc[0]
    return best < math.inf, bx, by, bz


@njit(**INLINE)
def _deepest_first(res, seps, count):
    """Swap the deepest of the count points into place 0 (res, seps as written by _put)."""
    for q in range(1, count):
        if seps[q] < seps[0]:
            for c in range(6):
                res[0, c], res[q, c] = res[q, c], res[0, c]
            seps[0], seps[q] = seps[q], seps[0]
    _pin = res[0, 0], seps[0]


@njit(**JIT)
def _face_manifold(ref, inc, ref_is_a, ma, mb, nx, ny, nz, sd, band, tilt, poly, res, seps):
    """Clip the incident core's feature (box face or segment) against the reference box face nearest n.

    ``ref`` is a box core; ``inc`` a box, a segment (with margin; a segment is always A here) or
    a cylinder standing on an end or lying on its side (the side's line), each within ``tilt`` (rad, small) of
    the face, else nothing is clipped. A standing cylinder's rim is the polygon of its four points along its
    local ±x, ±y, the rim point toward the reference box's centre (what rests on the end stands on the disk, not
    only on that square) and, tilted, the rim point deepest into the face (_rim_polygon); clipped, with the end's
    deepest point over the face where that is deeper (_deepest_over_face). Writes the points
    whose separation is within ``band`` of the deepest or below zero; returns their count (0 if clipping left
    nothing).
    """
    sgn_n = 1.0 if ref_is_a else -1.0  # the reference face's outward normal is ±n
    i, s_ref, _ = _face_of(ref, sgn_n * nx, sgn_n * ny, sgn_n * nz)
    rx, ry, rz = _axis(ref, i)
    rx, ry, rz = s_ref * rx, s_ref * ry, s_ref * rz
    cx = ref[_C] + ref[_DIM + i] * rx
    cy = ref[_C + 1] + ref[_DIM + i] * ry
    cz = ref[_C + 2] + ref[_DIM + i] * rz
    n = 0
    standing = False  # a cylinder on an end: its rim's polygon, plus the end's deepest point over the face
    endx = endy = endz = r = deepest = 0.0
    if int(inc[_KIND]) == CORE_BOX:
        l, s_inc, _ = _face_of(inc, -rx, -ry, -rz)
        j, k = (l + 1) % 3, (l + 2) % 3
        for corner in range(4):
            sj = 1.0 if corner == 0 or corner == 1 else -1.0
            sk = 1.0 if corner == 1 or corner == 2 else -1.0
            lx, ly, lz = _axis(inc, l)
            jx, jy, jz = _axis(inc, j)
            kx, ky, kz = _axis(inc, k)
            fl, fj, fk = s_inc * inc[_DIM + l], sj * inc[_DIM + j], sk * inc[_DIM + k]
            wx = inc[_C] + fl * lx + fj * jx + fk * kx
            wy = inc[_C + 1] + fl * ly + fj * jy + fk * ky
            wz = inc[_C + 2] + fl * lz + fj * jz + fk * kz
            poly[0, corner, 0], poly[0, corner, 1], poly[0, corner, 2] = wx, wy, wz
        n = 4
    elif int(inc[_KIND]) == CORE_CYLINDER:
        ux, uy, uz = _axis(inc, 2)
        c_axis = ux * rx + uy * ry + uz * rz
        r, h = inc[_DIM], inc[_DIM + 1]
        if abs(c_axis) >= 1.0 - 0.5 * tilt * tilt:
            # standing on an end face: the rim of the end facing the reference face
            s_end = -1.0 if c_axis > 0.0 else 1.0
            ex, ey, ez = inc[_C] + s_end * h * ux, inc[_C + 1] + s_end * h * uy, inc[_C + 2] + s_end * h * uz
            toward = _rim_angle(inc, ref[_C] - ex, ref[_C + 1] - ey, ref[_C + 2] - ez)
            deepest = _rim_angle(inc, -rx, -ry, -rz)
            n = _rim_polygon(inc, ex, ey, ez, r, toward, deepest, poly)
            standing, endx, endy, endz = True, ex, ey, ez
        elif abs(c_axis) <= tilt:
            # lying on its side: the line of the side nearest the reference face
            px, py, pz = rx - c_axis * ux, ry - c_axis * uy, rz - c_axis * uz
            norm = math.sqrt(px * px + py * py + pz * pz)
            px, py, pz = px / norm, py / norm, pz / norm
            for k in range(2):
                sgn = -1.0 if k == 0 else 1.0
                poly[0, k, 0] = inc[_C] - r * px + sgn * h * ux
                poly[0, k, 1] = inc[_C + 1] - r * py + sgn * h * uy
                poly[0, k, 2] = inc[_C + 2] - r * pz + sgn * h * uz
            n = 2
    else:
        p0x, p0y, p0z, dx, dy, dz = _segment_ends(inc)
        poly[0, 0, 0], poly[0, 0, 1], poly[0, 0, 2] = p0x, p0y, p0z
        poly[0, 1, 0], poly[0, 1, 1], poly[0, 1, 2] = p0x + dx, p0y + dy, p0z + dz
        n = 2
    src = 0
    for side in range(4):
        axis = (i + 1 + side // 2) % 3
        ex, ey, ez = _axis(ref, axis)
        sgn = 1.0 if side % 2 == 0 else -1.0
        if n > 0:
            if n == 2:  # a segment: clip its ends (the polygon routine would treat it as a closed loop)
                n = _clip_segment(poly, src, sgn * ex, sgn * ey, sgn * ez, cx, cy, cz, ref[_DIM + axis])
            else:
                n = _clip(poly, src, n, sgn * ex, sgn * ey, sgn * ez, cx, cy, cz, ref[_DIM + axis])
                src = 1 - src
    lowest = math.inf
    for q in range(n):
        d = (poly[src, q, 0] - cx) * rx + (poly[src, q, 1] - cy) * ry + (poly[src, q, 2] - cz) * rz - ma - mb
        lowest = min(lowest, d)
    if standing:  # the polygon's points lie on chords: the disk's own deepest point over the face, if deeper
        found, px, py, pz = _deepest_over_face(ref, i, rx, ry, rz, cx, cy, cz, inc, endx, endy, endz, r,
                                            deepest)
        d = (px - cx) * rx + (py - cy) * ry + (pz - cz) * rz - ma - mb
        if found and d < lowest - 1e-6 * band and n < poly.shape[1]:
            poly[src, n, 0], poly[src, n, 1], poly[src, n, 2] = px, py, pz
            n += 1
            lowest = d
    if n == 0:
        return 0
    keep = max(lowest + band, 0.0)
    count = 0
    for q in range(n):
        px, py, pz = poly[src, q, 0], poly[src, q, 1], poly[src, q, 2]
        d = (px - cx) * rx + (py - cy) * ry + (pz - cz) * rz
        if d - ma - mb <= keep and count < MAX_PAIR_POINTS:
            fx, fy, fz = px - d * rx, py - d * ry, pz - d * rz  # on the reference face
            m_inc = ma if not ref_is_a else mb
            gx, gy, gz = px - m_inc * rx, py - m_inc * ry, pz - m_inc * rz  # on the incident surface
            if ref_is_a:
                _put(res, seps, count, fx, fy, fz, gx, gy, gz, nx, ny, nz)
            else:
                _put(res, seps, count, gx, gy, gz, fx, fy, fz, nx, ny, nz)
            count += 1
    _deepest_first(res, seps, count)
    _pin = sd, ref[0], inc[0], poly[0, 0, 0], res[0, 0], seps[0]
    return count


@njit(**JIT)
def _clip_segment(poly, src, px, py, pz, ox, oy, oz, limit):
    """Clip the segment poly[src, 0:2] to (p − o)·plane ≤ limit in place; returns 2, or 0 if nothing is left."""
    ax, ay, az = poly[src, 0, 0], poly[src, 0, 1], poly[src, 0, 2]
    bx, by, bz = poly[src, 1, 0], poly[src, 1, 1], poly[src, 1, 2]
    da = (ax - ox) * px + (ay - oy) * py + (az - oz) * pz - limit
    db = (bx - ox) * px + (by - oy) * py + (bz - oz) * pz - limit
    if da > 0.0 and db > 0.0:
        return 0
    if da > 0.0:
        t = da / (da - db)
        poly[src, 0, 0], poly[src, 0, 1], poly[src, 0, 2] = ax + t * (bx - ax), ay + t * (by - ay), az + t * (bz - az)
    elif db > 0.0:
        t = db / (db - da)
        poly[src, 1, 0], poly[src, 1, 1], poly[src, 1, 2] = bx + t * (ax - bx), by + t * (ay - by), bz + t * (az - bz)
    return 2


@njit(**JIT)
def _sep(pa, pb, ux, uy, uz):
    """sep(u) = min over B of u·x − max over A of u·x, from the cores' support functions (m)."""
    ax, ay, az = support(pa, ux, uy, uz)
    bx, by, bz = support(pb, -ux, -uy, -uz)
    return (bx - ax) * ux + (by - ay) * uy + (bz - az) * uz


@njit(**JIT)
def _try(pa, pb, nx, ny, nz, best, bx, by, bz, ux, uy, uz):
    """Keep the candidate u (turned to n's side) if it separates more than the best so far."""
    norm = math.sqrt(ux * ux + uy * uy + uz * uz)
    if norm > 1e-12:
        ux, uy, uz = ux / norm, uy / norm, uz / norm
        if ux * nx + uy * ny + uz * nz < 0.0:
            ux, uy, uz = -ux, -uy, -uz
        value = _sep(pa, pb, ux, uy, uz)
        if value > best:
            best, bx, by, bz = value, ux, uy, uz
    return best, bx, by, bz


@njit(**JIT)
def _feature_normal(pa, pb, nx, ny, nz):
    """The normal of a pair with a cylinder: GJK/EPA's n, or a feature direction near it that separates more.

    On a curved rim GJK and EPA find the distance to ~1e-10 but the direction only to ~1e-5
    rad. Where the contact is between features whose normal is a fixed direction (a box face,
    an end face, a cylinder's or capsule's side across its axis, two crossing axes), that
    direction separates at least as much (sd = max over u of sep(u)); it replaces n if it does.
    """
    best = _sep(pa, pb, nx, ny, nz)
    bx, by, bz = nx, ny, nz
    for side in range(2):
        pose = pa if side == 0 else pb
        kind = int(pose[_KIND])
        if kind == CORE_BOX:
            for i in range(3):
                ex, ey, ez = _axis(pose, i)
                best, bx, by, bz = _try(pa, pb, nx, ny, nz, best, bx, by, bz, ex, ey, ez)
        elif kind == CORE_CYLINDER or kind == CORE_SEGMENT:
            ux, uy, uz = _axis(pose, 2)
            if kind == CORE_CYLINDER:
                best, bx, by, bz = _try(pa, pb, nx, ny, nz, best, bx, by, bz, ux, uy, uz)
            c = nx * ux + ny * uy + nz * uz  # across the axis: a side contact
            best, bx, by, bz = _try(pa, pb, nx, ny, nz, best, bx, by, bz, nx - c * ux, ny - c * uy, nz - c * uz)
    if int(pa[_KIND]) != CORE_BOX:
        ux, uy, uz = _axis(pa, 2)
        vx, vy, vz = _axis(pb, 2)
        best, bx, by, bz = _try(pa, pb, nx, ny, nz, best, bx, by, bz, uy * vz - uz * vy, uz * vx - ux * vz,
                                ux * vy - uy * vx)
    return bx, by, bz


@njit(**JIT)
def _exact_normal(pa, pb, nx, ny, nz):
    """(sep, normal) of a pair with a cylinder from GJK/EPA's direction n: refine.refine_normal from the
    better of n and the feature directions near it (_feature_normal)."""
    fx, fy, fz = _feature_normal(pa, pb, nx, ny, nz)
    return refine_normal(pa, pb, fx, fy, fz)


@njit(**JIT)
def _climbed_normal(pa, pb, nx, ny, nz):
    """(sep, normal) from a start n too far off the normal for refine_normal (its strata are looked for within
    refine.NEAR of the start): a pattern search on the unit sphere, the best of 8 directions at angle θ around the
    current one taken while it separates more, θ halved when none does (from CLIMB_START to CLIMB_END rad), then
    refine_normal from there. Every direction's sep is at most the signed distance: the search only comes nearer."""
    best = _sep(pa, pb, nx, ny, nz)
    theta = CLIMB_START
    for _ in range(CLIMB_STEPS):
        if theta < CLIMB_END:
            break
        # an orthonormal basis t1, t2 across n
        if abs(nx) <= abs(ny) and abs(nx) <= abs(nz):
            t1x, t1y, t1z = 0.0, -nz, ny
        elif abs(ny) <= abs(nz):
            t1x, t1y, t1z = nz, 0.0, -nx
        else:
            t1x, t1y, t1z = -ny, nx, 0.0
        norm = math.sqrt(t1x * t1x + t1y * t1y + t1z * t1z)
        t1x, t1y, t1z = t1x / norm, t1y / norm, t1z / norm
        t2x, t2y, t2z = ny * t1z - nz * t1y, nz * t1x - nx * t1z, nx * t1y - ny * t1x
        c, s = math.cos(theta), math.sin(theta)
        moved = False
        bx, by, bz = nx, ny, nz
        for k in range(8):
            ck, sk = math.cos(0.25 * math.pi * k), math.sin(0.25 * math.pi * k)
            ux = c * nx + s * (ck * t1x + sk * t2x)
            uy = c * ny + s * (ck * t1y + sk * t2y)
            uz = c * nz + s * (ck * t1z + sk * t2z)
            norm = math.sqrt(ux * ux + uy * uy + uz * uz)
            ux, uy, uz = ux / norm, uy / norm, uz / norm
            value = _sep(pa, pb, ux, uy, uz)
            if value > best:
                best, bx, by, bz, moved = value, ux, uy, uz, True
        if moved:
            nx, ny, nz = bx, by, bz
        else:
            theta *= 0.5
    return _exact_normal(pa, pb, nx, ny, nz)


@njit(**JIT)
def _nudged_direction(pa, pb, scale, ws_s, ws_lam, ws_tmp, verts, faces, face_nd, edges, out):
    """GJK's (or EPA's) direction from A to B with B moved NUDGE × scale along the centres' offset: for cores that
    touch, where GJK's own direction is the round-off of two witnesses a hair apart (m). Leaves pb as it was."""
    ox, oy, oz = pb[_C] - pa[_C], pb[_C + 1] - pa[_C + 1], pb[_C + 2] - pa[_C + 2]
    norm = math.sqrt(ox * ox + oy * oy + oz * oz)
    if norm == 0.0:
        ox, oy, oz, norm = 0.0, 0.0, 1.0, 1.0
    step = NUDGE * scale / norm
    cx, cy, cz = pb[_C], pb[_C + 1], pb[_C + 2]
    pb[_C], pb[_C + 1], pb[_C + 2] = cx + step * ox, cy + step * oy, cz + step * oz
    d, nv, overlap = gjk(pa, pb, ws_s, ws_lam, ws_tmp, scale)
    if overlap:
        epa(pa, pb, ws_s, nv, verts, faces, face_nd, edges, scale, out)
        ux, uy, uz = out[1], out[2], out[3]
    else:
        ux = uy = uz = 0.0
        for k in range(nv):
            ux += ws_lam[k] * (ws_s[1, k, 0] - ws_s[0, k, 0])
            uy += ws_lam[k] * (ws_s[1, k, 1] - ws_s[0, k, 1])
            uz += ws_lam[k] * (ws_s[1, k, 2] - ws_s[0, k, 2])
        if d > 0.0:
            ux, uy, uz = ux / d, uy / d, uz / d
        else:
            ux, uy, uz = ox / norm, oy / norm, oz / norm
    pb[_C], pb[_C + 1], pb[_C + 2] = cx, cy, cz
    return ux, uy, uz


@njit(**JIT)
def _put_feature_points(pa, ma, pb, mb, nx, ny, nz, wax, way, waz, wbx, wby, wbz, res, seps):
    """Contact point 0: on A's support set along n nearest A's witness w_a, on B's along −n nearest w_b, plus margins.

    Both points lie on their surfaces and (p_B − p_A)·n = sep(n) − ma − mb.
    """
    ax, ay, az = feature_point(pa, nx, ny, nz, wax, way, waz)
    bx, by, bz = feature_point(pb, -nx, -ny, -nz, wbx, wby, wbz)
    _put(res, seps, 0, ax + ma * nx, ay + ma * ny, az + ma * nz, bx - mb * nx, by - mb * ny, bz - mb * nz, nx, ny, nz)


@njit(**INLINE)
def _flat_end(pose, fx, fy, fz, tilt):
    """The end face of a cylinder core whose outward normal is within ``tilt`` (rad, small) of f: (True, its centre (world,
    m), its outward normal, its radius (m)), else (False, ...)."""
    if int(pose[_KIND]) != CORE_CYLINDER:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    ux, uy, uz = _axis(pose, 2)
    c = ux * fx + uy * fy + uz * fz
    if abs(c) < 1.0 - 0.5 * tilt * tilt:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    s = 1.0 if c > 0.0 else -1.0
    h = pose[_DIM + 1]
    return (True, pose[_C] + s * h * ux, pose[_C + 1] + s * h * uy, pose[_C + 2] + s * h * uz, s * ux, s * uy, s * uz,
            pose[_DIM])


@njit(**INLINE)
def _lying_line(pose, margin, fx, fy, fz, tilt):
    """The line of a cylinder's side or a capsule's surface (margin: its radius) nearest direction f, when the axis is
    within ``tilt`` (rad, small) of across f: (True, its ends p0, p1 (world, m)), else (False, ...). Both ends lie on the
    surface: the core's axis offset by the radius along f's part across the axis."""
    kind = int(pose[_KIND])
    if kind != CORE_CYLINDER and kind != CORE_SEGMENT:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    ux, uy, uz = _axis(pose, 2)
    c = ux * fx + uy * fy + uz * fz
    if abs(c) > tilt:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    wx, wy, wz = fx - c * ux, fy - c * uy, fz - c * uz
    w = math.sqrt(wx * wx + wy * wy + wz * wz)
    r, h = (pose[_DIM], pose[_DIM + 1]) if kind == CORE_CYLINDER else (margin, pose[_DIM])
    if h <= 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    ox, oy, oz = pose[_C] + r * wx / w, pose[_C + 1] + r * wy / w, pose[_C + 2] + r * wz / w
    return True, ox - h * ux, oy - h * uy, oz - h * uz, ox + h * ux, oy + h * uy, oz + h * uz


@njit(**INLINE)
def _onto_disk(ex, ey, ez, mx, my, mz, radius, px, py, pz):
    """The point of the disk (centre e, unit normal m, radius) nearest p: p projected onto its plane, drawn in to
    the rim if beyond it."""
    d = (px - ex) * mx + (py - ey) * my + (pz - ez) * mz
    qx, qy, qz = px - d * mx - ex, py - d * my - ey, pz - d * mz - ez
    q = math.sqrt(qx * qx + qy * qy + qz * qz)
    s = radius / q if q > radius else 1.0
    return ex + s * qx, ey + s * qy, ez + s * qz


@njit(**INLINE)
def _add(poly, k, ax, ay, az, bx, by, bz, tol):
    """Append the point pair (a on A, b on B) to poly[0, k], poly[1, k] unless a is within tol of one there already
    (two rims' points that coincide); returns the new count."""
    for q in range(k):
        if abs(poly[0, q, 0] - ax) <= tol and abs(poly[0, q, 1] - ay) <= tol and abs(poly[0, q, 2] - az) <= tol:
            return k
    poly[0, k, 0], poly[0, k, 1], poly[0, k, 2] = ax, ay, az
    poly[1, k, 0], poly[1, k, 1], poly[1, k, 2] = bx, by, bz
    return k + 1


@njit(**JIT)
def _disk_disk(pa, pb, ea, eb, tol, poly):
    """Two end faces touching flat (ea, eb: _flat_end of A along n, of B along −n): the rim points of each that
    lie within the other disk — its four along its core's local x and y axes, the one toward the other's centre
    and, tilted, the one deepest into the other's face (_rim_angle) — and the two points where the rims cross,
    each paired with the nearest point of the other face, into poly (_add); returns their count (≤ 14)."""
    k = 0
    for side in range(2):
        src, e, other = (pa, ea, eb) if side == 0 else (pb, eb, ea)
        toward = _rim_angle(src, other[1] - e[1], other[2] - e[2], other[3] - e[3])
        deepest = _rim_angle(src, -other[4], -other[5], -other[6])
        for j in range(6):
            if j < 4:
                px, py, pz = _rim_point(src, e[1], e[2], e[3], e[7], j)
            elif math.isnan(toward if j == 4 else deepest):
                continue
            else:
                px, py, pz = _at_angle(src, e[1], e[2], e[3], e[7], toward if j == 4 else deepest)
            d = (px - other[1]) * other[4] + (py - other[2]) * other[5] + (pz - other[3]) * other[6]
            qx, qy, qz = px - d * other[4] - other[1], py - d * other[5] - other[2], pz - d * other[6] - other[3]
            if qx * qx + qy * qy + qz * qz > (other[7] + tol) ** 2:
                continue
            fx, fy, fz = _onto_disk(other[1], other[2], other[3], other[4], other[5], other[6], other[7], px, py, pz)
            if side == 0:
                k = _add(poly, k, px, py, pz, fx, fy, fz, tol)
            else:
                k = _add(poly, k, fx, fy, fz, px, py, pz, tol)
    # where the rims cross, in A's plane: B's centre projected onto it, at d from A's
    mx, my, mz = ea[4], ea[5], ea[6]
    t = (eb[1] - ea[1]) * mx + (eb[2] - ea[2]) * my + (eb[3] - ea[3]) * mz
    ox, oy, oz = eb[1] - t * mx - ea[1], eb[2] - t * my - ea[2], eb[3] - t * mz - ea[3]
    d = math.sqrt(ox * ox + oy * oy + oz * oz)
    ra, rb = ea[7], eb[7]
    if abs(ra - rb) + tol < d < ra + rb:
        ox, oy, oz = ox / d, oy / d, oz / d
        vx, vy, vz = my * oz - mz * oy, mz * ox - mx * oz, mx * oy - my * ox
        along = (d * d + ra * ra - rb * rb) / (2.0 * d)
        across = math.sqrt(max(ra * ra - along * along, 0.0))
        for sgn in (-1.0, 1.0):
            px = ea[1] + along * ox + sgn * across * vx
            py = ea[2] + along * oy + sgn * across * vy
            pz = ea[3] + along * oz + sgn * across * vz
            fx, fy, fz = _onto_disk(eb[1], eb[2], eb[3], eb[4], eb[5], eb[6], rb, px, py, pz)
            k = _add(poly, k, px, py, pz, fx, fy, fz, tol)
    return k


@njit(**JIT)
def _line_disk(line, e, line_is_a, tol, poly):
    """A lying side (line: _lying_line) on an end face (e: _flat_end): the ends of the part of the line over the
    disk, each paired with the nearest point of the face, into poly (A's point first); returns 2, or 0 if that
    part has no length."""
    mx, my, mz = e[4], e[5], e[6]
    p0x, p0y, p0z = line[1], line[2], line[3]
    dx, dy, dz = line[4] - p0x, line[5] - p0y, line[6] - p0z
    a0 = (p0x - e[1]) * mx + (p0y - e[2]) * my + (p0z - e[3]) * mz
    ad = dx * mx + dy * my + dz * mz
    ox, oy, oz = p0x - a0 * mx - e[1], p0y - a0 * my - e[2], p0z - a0 * mz - e[3]  # in the disk's plane
    vx, vy, vz = dx - ad * mx, dy - ad * my, dz - ad * mz
    qa = vx * vx + vy * vy + vz * vz
    qb = ox * vx + oy * vy + oz * vz
    qc = ox * ox + oy * oy + oz * oz - e[7] * e[7]
    disc = qb * qb - qa * qc
    if qa <= 0.0 or disc <= 0.0:
        return 0
    root = math.sqrt(disc)
    t0, t1 = max((-qb - root) / qa, 0.0), min((-qb + root) / qa, 1.0)
    if (t1 - t0) * math.sqrt(dx * dx + dy * dy + dz * dz) <= tol:
        return 0
    k = 0
    for t in (t0, t1):
        px, py, pz = p0x + t * dx, p0y + t * dy, p0z + t * dz
        fx, fy, fz = _onto_disk(e[1], e[2], e[3], mx, my, mz, e[7], px, py, pz)
        if line_is_a:
            k = _add(poly, k, px, py, pz, fx, fy, fz, tol)
        else:
            k = _add(poly, k, fx, fy, fz, px, py, pz, tol)
    return k


@njit(**JIT)
def _line_line(la, lb, tol, poly):
    """Two lying sides along parallel axes (la, lb: _lying_line of A and B): the ends of the part of A's line
    beside B's, each paired with the nearest point of B's line, into poly; returns 2, or 0 if that part has no
    length."""
    p0x, p0y, p0z = la[1], la[2], la[3]
    dx, dy, dz = la[4] - p0x, la[5] - p0y, la[6] - p0z
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    ux, uy, uz = dx / length, dy / length, dz / length
    q0x, q0y, q0z = lb[1], lb[2], lb[3]
    ex, ey, ez = lb[4] - q0x, lb[5] - q0y, lb[6] - q0z
    s0 = (q0x - p0x) * ux + (q0y - p0y) * uy + (q0z - p0z) * uz
    s1 = s0 + ex * ux + ey * uy + ez * uz
    lo, hi = max(0.0, min(s0, s1)), min(length, max(s0, s1))
    if hi - lo <= tol:
        return 0
    ee = ex * ex + ey * ey + ez * ez
    k = 0
    for end in (lo, hi):
        px, py, pz = p0x + end * ux, p0y + end * uy, p0z + end * uz
        t = min(1.0, max(0.0, ((px - q0x) * ex + (py - q0y) * ey + (pz - q0z) * ez) / ee))
        k = _add(poly, k, px, py, pz, q0x + t * ex, q0y + t * ey, q0z + t * ez, tol)
    return k


@njit(**JIT)
def _round_manifold(pa, ma, pb, mb, nx, ny, nz, band, tilt, poly, res, seps):
    """A capsule or a cylinder (A) against a cylinder (B) touching along a flat feature, each within ``tilt`` (rad,
    small) of across n: two end faces (_disk_disk), a lying side on an end face (_line_disk), two lying sides along
    parallel axes (_line_line), to FEATURE_BAND × the pair's size. Writes the points whose separation along n is
    within ``band`` of the deepest or below zero, deepest first, into res and seps; returns their count, 0 (res
    untouched) where the pair touches at one point."""
    ea = _flat_end(pa, nx, ny, nz, tilt)
    eb = _flat_end(pb, -nx, -ny, -nz, tilt)
    la = _lying_line(pa, ma, nx, ny, nz, tilt)
    lb = _lying_line(pb, mb, -nx, -ny, -nz, tilt)
    tol = FEATURE_BAND * max(max(max(pa[_DIM], pa[_DIM + 1]), ma), max(max(pb[_DIM], pb[_DIM + 1]), mb))
    n = 0
    if ea[0] and eb[0]:
        n = _disk_disk(pa, pb, ea, eb, tol, poly)
    elif la[0] and eb[0]:
        n = _line_disk(la, eb, True, tol, poly)
    elif ea[0] and lb[0]:
        n = _line_disk(lb, ea, False, tol, poly)
    elif la[0] and lb[0]:
        ux, uy, uz = _axis(pa, 2)
        vx, vy, vz = _axis(pb, 2)
        cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        if cx * cx + cy * cy + cz * cz <= tilt * tilt:
            n = _line_line(la, lb, tol, poly)
    if n < 2:
        return 0
    lowest = math.inf
    for q in range(n):
        lowest = min(lowest, (poly[1, q, 0] - poly[0, q, 0]) * nx + (poly[1, q, 1] - poly[0, q, 1]) * ny
                     + (poly[1, q, 2] - poly[0, q, 2]) * nz)
    keep = max(lowest + band, 0.0)
    count = 0
    for q in range(n):
        sep = ((poly[1, q, 0] - poly[0, q, 0]) * nx + (poly[1, q, 1] - poly[0, q, 1]) * ny
               + (poly[1, q, 2] - poly[0, q, 2]) * nz)
        if sep <= keep and count < MAX_PAIR_POINTS:
            _put(res, seps, count, poly[0, q, 0], poly[0, q, 1], poly[0, q, 2], poly[1, q, 0], poly[1, q, 1],
                 poly[1, q, 2], nx, ny, nz)
            count += 1
    _deepest_first(res, seps, count)
    _pin = pa[0], pb[0], poly[0, 0, 0], res[0, 0], seps[0]
    return count


@njit(**INLINE)
def ball_contact(pa, ra, pb, mb, res, seps):
    """A ball (the point core pa's centre, radius ra) against the posed core pb with margin mb (set_pose): closed
    forms. Returns (sd, nx, ny, nz), the normal from the ball to B; writes the one point pair into res[0], seps[0]."""
    kb = int(pb[_KIND])
    if kb == CORE_POINT:
        sd, nx, ny, nz = _round_pair(pa[_C], pa[_C + 1], pa[_C + 2], ra, pb[_C], pb[_C + 1], pb[_C + 2], mb,
                                     0.0, 0.0, 1.0, res, seps, 0)
    elif kb == CORE_SEGMENT:
        sd, nx, ny, nz, _ = _point_segment(pa, ra, pb, mb, res, seps)
    elif kb == CORE_BOX:
        sd, nx, ny, nz, _ = _point_box(pa, ra, pb, res, seps)
    else:
        sd, nx, ny, nz, _ = _point_cylinder(pa, ra, pb, res, seps)
    return sd, nx, ny, nz


@njit(**INLINE)
def pair_contact(pa, ma, pb, mb, scale, ws_s, ws_lam, ws_tmp, ws_poly, verts, faces, face_nd, edges, out, res, seps):
    """Signed distance, normal (A to B) and contact points of two posed cores with margins (set_pose).

    Needs core kind of A ≤ core kind of B (CORE_*; the batch function swaps). Writes the points
    into res (MAX_PAIR_POINTS, 6) and seps; returns (sd, nx, ny, nz, count). ``scale`` (m) is the
    pair's size, for the tolerances.
    """
    ka, kb = int(pa[_KIND]), int(pb[_KIND])
    band = FEATURE_BAND * scale
    sd, nx, ny, nz, count = 0.0, 0.0, 0.0, 1.0, 1
    if ka == CORE_POINT:
        sd, nx, ny, nz = ball_contact(pa, ma, pb, mb, res, seps)
    elif ka == CORE_SEGMENT and kb == CORE_SEGMENT:
        sd, nx, ny, nz, count = _segment_segment(pa, ma, pb, mb, band, res, seps)
    else:
        polytopes = kb == CORE_BOX  # segment–box or box–box
        # two boxes not apart along a face normal: the separating-axis test first. Overlapping (no axis separates
        # them) or with its two witness points within NEAR_TOUCH × the size (their distance is at most that), they
        # take its result without GJK, which would find them overlapping or that near
        sat_done, sd_core, axis_id = False, 0.0, -1
        if ka == CORE_BOX and polytopes and _face_gap(pa[_R:_R + 9], pb[_R:_R + 9], pa[_DIM:_DIM + 3], pb[_DIM:_DIM + 3],
                                                      pb[_C] - pa[_C], pb[_C + 1] - pa[_C + 1],
                                                      pb[_C + 2] - pa[_C + 2], NEAR_TOUCH * scale) <= NEAR_TOUCH * scale:
            sd_core, nx, ny, nz, axis_id = _sat(pa, pb, scale)
            _sat_witness(pa, ma, pb, sd_core, nx, ny, nz, axis_id, res, seps)
            wx, wy, wz = res[0, 3] - res[0, 0], res[0, 4] - res[0, 1], res[0, 5] - res[0, 2]
            sat_done = sd_core <= 0.0 or wx * wx + wy * wy + wz * wz <= (NEAR_TOUCH * scale) ** 2
        d, nv, overlap = 0.0, 0, True
        if not sat_done:
            d, nv, overlap = gjk(pa, pb, ws_s, ws_lam, ws_tmp, scale)
        if polytopes and (overlap or d <= NEAR_TOUCH * scale):
            if not sat_done:
                sd_core, nx, ny, nz, axis_id = _sat(pa, pb, scale)
                _sat_witness(pa, ma, pb, sd_core, nx, ny, nz, axis_id, res, seps)
            sd = sd_core - ma - mb
        elif overlap:
            epa(pa, pb, ws_s, nv, verts, faces, face_nd, edges, scale, out)
            sd_core, nx, ny, nz = _exact_normal(pa, pb, out[1], out[2], out[3])
            sd = sd_core - ma - mb
            _put_feature_points(pa, ma, pb, mb, nx, ny, nz, out[4], out[5], out[6], out[7], out[8], out[9], res, seps)
        else:
            ax = ay = az = bx = by = bz = 0.0
            for k in range(nv):
                ax += ws_lam[k] * ws_s[0, k, 0]
                ay += ws_lam[k] * ws_s[0, k, 1]
                az += ws_lam[k] * ws_s[0, k, 2]
                bx += ws_lam[k] * ws_s[1, k, 0]
                by += ws_lam[k] * ws_s[1, k, 1]
                bz += ws_lam[k] * ws_s[1, k, 2]
            if d > 0.0:
                nx, ny, nz = (bx - ax) / d, (by - ay) / d, (bz - az) / d
            else:  # touching cores: the normal from the centres
                ox, oy, oz = pb[_C] - pa[_C], pb[_C + 1] - pa[_C + 1], pb[_C + 2] - pa[_C + 2]
                norm = math.sqrt(ox * ox + oy * oy + oz * oz)
                nx, ny, nz = (ox / norm, oy / norm, oz / norm) if norm > 0.0 else (0.0, 0.0, 1.0)
            sd = d - ma - mb
            if kb == CORE_CYLINDER and d > 0.0:  # GJK's direction on a rim is ~1e-5 rad off: refined
                sd_core, nx, ny, nz = _exact_normal(pa, pb, nx, ny, nz)
                if sd_core < d - CLIMB_GAP * scale:  # GJK's distance bounds it above: n was too far off
                    sd_core, nx, ny, nz = _climbed_normal(pa, pb, nx, ny, nz)
                if sd_core < d - CLIMB_GAP * scale:  # touching: GJK's direction is its witnesses' round-off
                    ux, uy, uz = _nudged_direction(pa, pb, scale, ws_s, ws_lam, ws_tmp, verts, faces, face_nd, edges,
                                                   out)
                    for k in range(2):  # refined, then climbed from there: the best kept (sep ≤ the distance)
                        found = _exact_normal(pa, pb, ux, uy, uz) if k == 0 else _climbed_normal(pa, pb, ux, uy, uz)
                        if found[0] > sd_core:
                            sd_core, nx, ny, nz = found
                        if sd_core >= d - CLIMB_GAP * scale:
                            break
                sd = sd_core - ma - mb
                _put_feature_points(pa, ma, pb, mb, nx, ny, nz, ax, ay, az, bx, by, bz, res, seps)
            else:
                if kb == CORE_CYLINDER:  # touching: GJK's witnesses are blends of rim points, put on the surfaces
                    ax, ay, az = surface_point(pa, 0.0, ax, ay, az, nx, ny, nz)
                    bx, by, bz = surface_point(pb, 0.0, bx, by, bz, -nx, -ny, -nz)
                _put(res, seps, 0, ax + ma * nx, ay + ma * ny, az + ma * nz, bx - mb * nx, by - mb * ny,
                     bz - mb * nz, nx, ny, nz)
        if polytopes:
            # a box face against a face (or a capsule lying on it): the clipped patch
            ia, sa, ca = _face_of(pa, nx, ny, nz) if ka == CORE_BOX else (0, 1.0, -1.0)
            ib, sb, cb = _face_of(pb, -nx, -ny, -nz)
            flat = 1.0 - 0.5 * FACE_ALIGNMENT * FACE_ALIGNMENT
            if ka == CORE_SEGMENT:
                ux, uy, uz = _axis(pa, 2)
                if cb >= flat and abs(ux * nx + uy * ny + uz * nz) <= FACE_ALIGNMENT and pa[_DIM] > 0.0:
                    m = _face_manifold(pb, pa, False, ma, mb, nx, ny, nz, sd, band, FACE_ALIGNMENT, ws_poly, res, seps)
                    count = max(m, 1)
            elif max(ca, cb) >= flat:
                if ca >= cb:
                    m = _face_manifold(pa, pb, True, ma, mb, nx, ny, nz, sd, band, FACE_ALIGNMENT, ws_poly, res, seps)
                else:
                    m = _face_manifold(pb, pa, False, ma, mb, nx, ny, nz, sd, band, FACE_ALIGNMENT, ws_poly, res, seps)
                count = max(m, 1)
        elif ka == CORE_BOX:  # a cylinder on a box face, standing or lying: its rim or side clipped
            ia, _, ca = _face_of(pa, nx, ny, nz)
            flat = 1.0 - 0.5 * FACE_ALIGNMENT * FACE_ALIGNMENT
            if ca >= flat:
                m = _face_manifold(pa, pb, True, ma, mb, nx, ny, nz, sd, band, FACE_ALIGNMENT, ws_poly, res, seps)
                count = max(m, 1)
                ux, uy, uz = _axis(pb, 2)
                fx, fy, fz = _axis(pa, ia)
                # overlapping, standing on an end: lifting it by its deepest point's depth over the face parts them
                # (beyond the face's sides the can is outside the box), so sd is at least that point's separation;
                # EPA's can be ~1e-10 m deeper where the end overhangs an edge, its normal on the face's
                if m > 0 and sd < min(seps[0], 0.0) and abs(ux * fx + uy * fy + uz * fz) >= flat:
                    sd = seps[0]
        else:  # a capsule or a cylinder against a cylinder: flat ends and lying sides
            m = _round_manifold(pa, ma, pb, mb, nx, ny, nz, band, FACE_ALIGNMENT, ws_poly, res, seps)
            count = max(m, 1)
    _pin = pa[0], pb[0], ws_s[0, 0, 0], ws_lam[0], ws_tmp[0], ws_poly[0, 0, 0], verts[0, 0, 0], faces[0, 0]
    _pin2 = face_nd[0, 0], edges[0, 0], out[0], res[0, 0], seps[0]
    return sd, nx, ny, nz, count


_CORE_OF = (0, 0, 2, 3, 1)  # layout.SHAPE_* → CORE_* (SHAPE_NONE unused)


@njit(**INLINE)
def _face_gap(Ra, Rb, da, db, ox, oy, oz, beyond):
    """Two boxes' largest separation (m) along their six face normals (negative when none separates them): a lower
    bound on their distance; or the first separation found larger than ``beyond`` (m; math.inf: none is), itself a
    lower bound larger than it. Ra, Rb: their rotations, row-major (9); da, db: their half extents (3); o: b's
    centre minus a's (world, m)."""
    best = -math.inf
    for side in range(2):
        for k in range(3):
            if side == 0:
                ux, uy, uz = Ra[k], Ra[3 + k], Ra[6 + k]
            else:
                ux, uy, uz = Rb[k], Rb[3 + k], Rb[6 + k]
            reach = 0.0
            for j in range(3):
                reach += da[j] * abs(Ra[j] * ux + Ra[3 + j] * uy + Ra[6 + j] * uz)
                reach += db[j] * abs(Rb[j] * ux + Rb[3 + j] * uy + Rb[6 + j] * uz)
            best = max(best, abs(ux * ox + uy * oy + uz * oz) - reach)
            if best > beyond:
                return best
    return best


@njit(**INLINE)
def boxes_apart(quat, pos, shapes, a, b):
    """A lower bound (m) on the distance of boxes a and b: their largest separation along the six face normals
    (negative when none separates them)."""
    Ra = matrix(quat[a, 0], quat[a, 1], quat[a, 2], quat[a, 3])
    Rb = matrix(quat[b, 0], quat[b, 1], quat[b, 2], quat[b, 3])
    return _face_gap(Ra, Rb, shapes[a, DIMS:DIMS + 3], shapes[b, DIMS:DIMS + 3], pos[b, 0] - pos[a, 0],
                     pos[b, 1] - pos[a, 1], pos[b, 2] - pos[a, 2], math.inf)


@njit(**INLINE)
def boxes_apart_turned(rot, pos, shapes, a, b, beyond):
    """:func:`boxes_apart` with the shapes' rotations given (rot (N, ≥ 9) rows, each the matrix of its quat,
    row-major), or the first face-normal separation found larger than ``beyond`` (m): whether the largest is, the
    same answer, found sooner."""
    return _face_gap(rot[a], rot[b], shapes[a, DIMS:DIMS + 3], shapes[b, DIMS:DIMS + 3], pos[b, 0] - pos[a, 0],
                     pos[b, 1] - pos[a, 1], pos[b, 2] - pos[a, 2], beyond)


@njit(**JIT)
def face_patch(pos, quat, shapes, a, b, nx, ny, nz, flat, band, poses, poly, res, seps):
    """Boxes and cylinders a and b (rows of pos (N, 3), quat (N, 4) w x y z, shapes) whose pair normal n (unit,
    a → b) is within acos(flat) of a flat face of either (a box's face, a cylinder's end): their patch about the
    reference face, the one nearest n (a box's before a cylinder's), every point whose separation along its
    normal is within ``band`` (m) of the deepest. Against a box face: the other's face most turned towards it,
    or a cylinder's rim or side within acos(flat) of it, clipped against it (pairs._face_manifold); two
    cylinders: their ends, or a side on an end, within acos(flat) (_round_manifold). res (k, 6): the points on
    a (0:3) and on b (3:6), world, m; seps (k,) their separations along the reference normal; poses (2,
    POSE_WIDTH) and poly (2, 16, 3) scratch. Returns (k, the reference normal a → b); k = 0 when no face is
    within acos(flat) of n, or nothing of the other lies flat on it."""
    pa, pb = poses[0], poses[1]
    set_pose(int(shapes[a, KIND]), shapes[a, DIMS], shapes[a, DIMS + 1], shapes[a, DIMS + 2], pos[a, 0], pos[a, 1],
             pos[a, 2], quat[a, 0], quat[a, 1], quat[a, 2], quat[a, 3], pa)
    set_pose(int(shapes[b, KIND]), shapes[b, DIMS], shapes[b, DIMS + 1], shapes[b, DIMS + 2], pos[b, 0], pos[b, 1],
             pos[b, 2], quat[b, 0], quat[b, 1], quat[b, 2], quat[b, 3], pb)
    tilt = math.sqrt(2.0 * (1.0 - flat))  # 1 − tilt² / 2 = flat
    box_a, box_b = int(pa[_KIND]) == CORE_BOX, int(pb[_KIND]) == CORE_BOX
    if box_a or box_b:
        ia, sa, ca = _face_of(pa, nx, ny, nz) if box_a else (0, 1.0, -1.0)
        ib, sb, cb = _face_of(pb, -nx, -ny, -nz) if box_b else (0, 1.0, -1.0)
        if max(ca, cb) < flat:
            return 0, nx, ny, nz
        if ca >= cb:
            rx, ry, rz = _axis(pa, ia)
            rx, ry, rz = sa * rx, sa * ry, sa * rz
            count = _face_manifold(pa, pb, True, 0.0, 0.0, rx, ry, rz, 0.0, band, tilt, poly, res, seps)
        else:
            rx, ry, rz = _axis(pb, ib)
            rx, ry, rz = -sb * rx, -sb * ry, -sb * rz
            count = _face_manifold(pb, pa, False, 0.0, 0.0, rx, ry, rz, 0.0, band, tilt, poly, res, seps)
        return count, rx, ry, rz
    ua, ub = _axis(pa, 2), _axis(pb, 2)
    ca = ua[0] * nx + ua[1] * ny + ua[2] * nz
    cb = -(ub[0] * nx + ub[1] * ny + ub[2] * nz)
    if max(abs(ca), abs(cb)) < flat:
        return 0, nx, ny, nz
    if abs(ca) >= abs(cb):
        s = 1.0 if ca > 0.0 else -1.0
        rx, ry, rz = s * ua[0], s * ua[1], s * ua[2]
    else:
        s = 1.0 if cb > 0.0 else -1.0
        rx, ry, rz = -s * ub[0], -s * ub[1], -s * ub[2]
    count = _round_manifold(pa, 0.0, pb, 0.0, rx, ry, rz, band, tilt, poly, res, seps)
    return count, rx, ry, rz


@njit(**JIT)
def apart_bounds(pos, quat, shapes, pairs, out):
    """For each row (a, b) of ``pairs`` (M, 2): a lower bound (m) on the distance of shapes a and b into out (M,),
    for two boxes their :func:`boxes_apart`, ~40 ns against pair_contacts' ~1 µs; −1 for other pairs (no bound).
    pos, quat, shapes as for :func:`pair_contacts`."""
    for m in range(pairs.shape[0]):
        a, b = pairs[m, 0], pairs[m, 1]
        if shapes[a, KIND] == SHAPE_BOX and shapes[b, KIND] == SHAPE_BOX:
            out[m] = boxes_apart(quat, pos, shapes, a, b)
        else:
            out[m] = -1.0


@njit(**JIT)
def pair_contacts(pos, quat, shapes, pairs, dist, normal, count, points, seps):
    """Narrow phase over a batch: for each row (a, b) of ``pairs`` (M, 2) the contact of shapes a and b.

    pos (N, 3): shape centres (world, m); quat (N, 4): q_WS (w, x, y, z); shapes (N, SHAPE_WIDTH)
    shape rows (layout.py; SHAPE_NONE is not allowed). Writes dist (M,), normal (M, 3) from a to
    b, count (M,), points (M, MAX_PAIR_POINTS, 6) (on a: 0:3, on b: 3:6, world, m) and seps
    (M, MAX_PAIR_POINTS); see the module docstring.
    """
    poses = np.zeros((2, POSE_WIDTH))
    out = np.empty(16)
    poly = np.empty((2, 16, 3))
    s, lam, verts, faces, face_nd, edges = make_workspace_jit()
    tmp = np.empty(4)
    res = np.empty((MAX_PAIR_POINTS, 6))
    sp = np.empty(MAX_PAIR_POINTS)
    pose_1, pose_2 = poses[0], poses[1]
    for m in range(pairs.shape[0]):
        a, b = pairs[m, 0], pairs[m, 1]
        ka, kb = int(shapes[a, KIND]), int(shapes[b, KIND])
        swap = _CORE_OF[ka] > _CORE_OF[kb]
        first, second = (b, a) if swap else (a, b)
        m1 = set_pose(int(shapes[first, KIND]), shapes[first, DIMS], shapes[first, DIMS + 1], shapes[first, DIMS + 2],
                      pos[first, 0], pos[first, 1], pos[first, 2],
                      quat[first, 0], quat[first, 1], quat[first, 2], quat[first, 3], pose_1)
        m2 = set_pose(int(shapes[second, KIND]), shapes[second, DIMS], shapes[second, DIMS + 1],
                      shapes[second, DIMS + 2], pos[second, 0], pos[second, 1], pos[second, 2],
                      quat[second, 0], quat[second, 1], quat[second, 2], quat[second, 3], pose_2)
        scale = max(max(shapes[a, DIMS], max(shapes[a, DIMS + 1], shapes[a, DIMS + 2])),
                    max(shapes[b, DIMS], max(shapes[b, DIMS + 1], shapes[b, DIMS + 2])))
        sd, nx, ny, nz, c = pair_contact(pose_1, m1, pose_2, m2, scale, s, lam, tmp, poly, verts, faces,
                                         face_nd, edges, out, res, sp)
        sgn = (-1.0 if swap else 1.0) / math.sqrt(nx * nx + ny * ny + nz * nz)
        dist[m] = sd
        normal[m, 0], normal[m, 1], normal[m, 2] = sgn * nx, sgn * ny, sgn * nz
        count[m] = c
        for k in range(c):
            for j in range(3):
                points[m, k, j] = res[k, 3 + j] if swap else res[k, j]
                points[m, k, 3 + j] = res[k, j] if swap else res[k, 3 + j]
            seps[m, k] = sp[k]


@njit(**JIT)
def make_workspace_jit():
    """convex.make_workspace, inside compiled code."""
    return (np.empty((3, 4, 3)), np.empty(4), np.empty((3, EPA_MAX_VERTICES, 3)),
            np.empty((EPA_MAX_FACES, 3), np.int64), np.empty((EPA_MAX_FACES, 5)),
            np.empty((3 * EPA_MAX_FACES, 2), np.int64))
