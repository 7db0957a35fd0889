"""Compiled general convex distance: support functions, GJK (distance) and EPA (penetration depth).

A shape is handled as a **core** and a **margin**: a sphere is a point with margin r, a
capsule a segment (half length h along its z axis) with margin r, a box (half extents) and a
cylinder (r, half length h along z) are their own core with margin 0. The signed distance of
two shapes is the signed distance of their cores minus both margins, exactly (a margin adds r
to the support function in every direction).

A shape's pose is a row of ``POSE_WIDTH`` floats (:func:`set_pose`): ``core kind`` (CORE_*),
three dimensions, the centre (world, m) and the rotation matrix R_WS row-major (9 floats).

Signed distance, for both separated and overlapping shapes, is max over unit u of
sep(u) = min_{b∈B} u·b − max_{a∈A} u·a (the support-function form, exact for convex sets):
the distance when they are apart, minus the penetration depth (the shortest translation that
separates them) when they overlap. The maximising u is the normal from A to B.

* :func:`gjk` finds the point of the Minkowski difference D = A − B nearest the origin from
  support points (Gilbert–Johnson–Keerthi, closest points on the simplex by Voronoi regions).
  For polytope cores (point, segment, box) it ends on the exact simplex; for a cylinder it stops
  when the lower and upper bounds of the distance meet within ``GJK_TOLERANCE`` × the scale.
* :func:`epa` expands GJK's final tetrahedron (which holds the origin) towards the boundary of
  D (expanding polytope algorithm) until the nearest face's support gap is within
  ``EPA_TOLERANCE`` × the scale, or the polytope is full (``EPA_MAX_VERTICES``): for polytope
  cores exact, for a cylinder's curved rim an approximation whose error is this tolerance.

Allocation-free: the caller passes the scratch arrays (:func:`make_workspace` shapes).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..jit import INLINE, JIT

__all__ = ["CORE_POINT", "CORE_SEGMENT", "CORE_BOX", "CORE_CYLINDER", "POSE_WIDTH", "GJK_TOLERANCE",
           "GJK_MAX_ITERATIONS", "EPA_TOLERANCE", "EPA_MAX_VERTICES", "EPA_MAX_FACES", "support",
           "gjk", "epa", "make_workspace"]

CORE_POINT, CORE_SEGMENT, CORE_BOX, CORE_CYLINDER = 0, 1, 2, 3
# pose row columns
_KIND, _DIM, _C, _R = 0, 1, 4, 7
POSE_WIDTH = 16

#: GJK stops when its distance bounds meet within this × the pair's scale (m).
GJK_TOLERANCE = 1e-14
GJK_MAX_ITERATIONS = 200
#: EPA stops when its upper and lower bounds of the depth are within this × the pair's scale (m).
EPA_TOLERANCE = 1e-12
EPA_MAX_VERTICES = 1024
EPA_MAX_FACES = 2 * EPA_MAX_VERTICES
_EPA_MAX_EDGES = 3 * EPA_MAX_FACES  # a horizon never has more edges than the removed faces have


def make_workspace():
    """The scratch arrays :func:`gjk` and :func:`epa` take, allocated once per batch.

    Returns (simplex (3, 4, 3): rows a, b, w of up to 4 support points; lam (4,);
    verts (3, EPA_MAX_VERTICES, 3); faces (EPA_MAX_FACES, 3) int64; face_nd (EPA_MAX_FACES, 5):
    unit normal, distance, alive flag; edges (_EPA_MAX_EDGES, 2) int64).
    """
    return (np.empty((3, 4, 3)), np.empty(4), np.empty((3, EPA_MAX_VERTICES, 3)),
            np.empty((EPA_MAX_FACES, 3), np.int64), np.empty((EPA_MAX_FACES, 5)),
            np.empty((_EPA_MAX_EDGES, 2), np.int64))


@njit(**INLINE)
def support(pose, dx, dy, dz):
    """The point of the core (pose row) furthest along the world direction d (world, m)."""
    # local direction: R^T d
    lx = pose[_R + 0] * dx + pose[_R + 3] * dy + pose[_R + 6] * dz
    ly = pose[_R + 1] * dx + pose[_R + 4] * dy + pose[_R + 7] * dz
    lz = pose[_R + 2] * dx + pose[_R + 5] * dy + pose[_R + 8] * dz
    kind = int(pose[_KIND])
    sx, sy, sz = 0.0, 0.0, 0.0
    if kind == CORE_SEGMENT:
        sz = pose[_DIM] if lz >= 0.0 else -pose[_DIM]
    elif kind == CORE_BOX:
        sx = pose[_DIM] if lx >= 0.0 else -pose[_DIM]
        sy = pose[_DIM + 1] if ly >= 0.0 else -pose[_DIM + 1]
        sz = pose[_DIM + 2] if lz >= 0.0 else -pose[_DIM + 2]
    elif kind == CORE_CYLINDER:
        rho = math.sqrt(lx * lx + ly * ly)
        if rho > 0.0:
            sx, sy = pose[_DIM] * lx / rho, pose[_DIM] * ly / rho
        else:
            sx = pose[_DIM]
        sz = pose[_DIM + 1] if lz >= 0.0 else -pose[_DIM + 1]
    return (pose[_C] + pose[_R + 0] * sx + pose[_R + 1] * sy + pose[_R + 2] * sz,
            pose[_C + 1] + pose[_R + 3] * sx + pose[_R + 4] * sy + pose[_R + 5] * sz,
            pose[_C + 2] + pose[_R + 6] * sx + pose[_R + 7] * sy + pose[_R + 8] * sz)


@njit(**INLINE)
def _add_support(pa, pb, dx, dy, dz, s, k):
    """Support point k of D = A − B in the direction d: a = s_A(d), b = s_B(−d), w = a − b."""
    ax, ay, az = support(pa, dx, dy, dz)
    bx, by, bz = support(pb, -dx, -dy, -dz)
    s[0, k, 0], s[0, k, 1], s[0, k, 2] = ax, ay, az
    s[1, k, 0], s[1, k, 1], s[1, k, 2] = bx, by, bz
    s[2, k, 0], s[2, k, 1], s[2, k, 2] = ax - bx, ay - by, az - bz


@njit(**JIT)
def _keep(s, lam, n):
    """Drop the simplex vertices whose weight is zero, keeping their order; returns the new count."""
    m = 0
    for k in range(n):
        if lam[k] > 0.0:
            for row in range(3):
                for c in range(3):
                    s[row, m, c] = s[row, k, c]
            lam[m] = lam[k]
            m += 1
    return m


@njit(**INLINE)
def _dot(s, i, j):
    return s[2, i, 0] * s[2, j, 0] + s[2, i, 1] * s[2, j, 1] + s[2, i, 2] * s[2, j, 2]


@njit(**JIT)
def _closest_segment(s, i, j, lam):
    """Weights (on slots i, j; others 0) of the point of segment w_i w_j nearest the origin; returns |v|²."""
    for k in range(4):
        lam[k] = 0.0
    ex = s[2, j, 0] - s[2, i, 0]
    ey = s[2, j, 1] - s[2, i, 1]
    ez = s[2, j, 2] - s[2, i, 2]
    ee = ex * ex + ey * ey + ez * ez
    t = 0.0
    if ee > 0.0:
        t = -(s[2, i, 0] * ex + s[2, i, 1] * ey + s[2, i, 2] * ez) / ee
    t = min(1.0, max(0.0, t))
    if t <= 0.0:
        lam[i] = 1.0
    elif t >= 1.0:
        lam[j] = 1.0
    else:
        lam[i], lam[j] = 1.0 - t, t
    vx = s[2, i, 0] + t * ex
    vy = s[2, i, 1] + t * ey
    vz = s[2, i, 2] + t * ez
    return vx * vx + vy * vy + vz * vz


@njit(**JIT)
def _closest_triangle(s, i, j, k, lam):
    """Weights (slots i, j, k) of the point of triangle w_i w_j w_k nearest the origin (Ericson 5.1.5); |v|²."""
    for m in range(4):
        lam[m] = 0.0
    ax, ay, az = s[2, i, 0], s[2, i, 1], s[2, i, 2]
    abx, aby, abz = s[2, j, 0] - ax, s[2, j, 1] - ay, s[2, j, 2] - az
    acx, acy, acz = s[2, k, 0] - ax, s[2, k, 1] - ay, s[2, k, 2] - az
    # p = origin: ap = −a
    d1 = -(abx * ax + aby * ay + abz * az)
    d2 = -(acx * ax + acy * ay + acz * az)
    u, v, w = 1.0, 0.0, 0.0
    done = False
    if d1 <= 0.0 and d2 <= 0.0:
        done = True
    if not done:
        bx, by, bz = s[2, j, 0], s[2, j, 1], s[2, j, 2]
        d3 = -(abx * bx + aby * by + abz * bz)
        d4 = -(acx * bx + acy * by + acz * bz)
        cx, cy, cz = s[2, k, 0], s[2, k, 1], s[2, k, 2]
        d5 = -(abx * cx + aby * cy + abz * cz)
        d6 = -(acx * cx + acy * cy + acz * cz)
        vc = d1 * d4 - d3 * d2
        vb = d5 * d2 - d1 * d6
        va = d3 * d6 - d5 * d4
        if d3 >= 0.0 and d4 <= d3:
            u, v, w = 0.0, 1.0, 0.0
        elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
            t = d1 / (d1 - d3)
            u, v, w = 1.0 - t, t, 0.0
        elif d6 >= 0.0 and d5 <= d6:
            u, v, w = 0.0, 0.0, 1.0
        elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
            t = d2 / (d2 - d6)
            u, v, w = 1.0 - t, 0.0, t
        elif va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
            t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            u, v, w = 0.0, 1.0 - t, t
        else:
            denom = 1.0 / (va + vb + vc)
            v = vb * denom
            w = vc * denom
            u = 1.0 - v - w
    lam[i], lam[j], lam[k] = u, v, w
    px = u * ax + v * s[2, j, 0] + w * s[2, k, 0]
    py = u * ay + v * s[2, j, 1] + w * s[2, k, 1]
    pz = u * az + v * s[2, j, 2] + w * s[2, k, 2]
    return px * px + py * py + pz * pz


@njit(**JIT)
def _closest_tetrahedron(s, lam, tmp):
    """Weights of the point of tetrahedron w_0..w_3 nearest the origin; returns (|v|², inside).

    A tetrahedron too flat to have a trustworthy inside (volume below round-off of its edges,
    which happens when GJK's support points bunch up on a curved surface) never holds the
    origin: its nearest point is then taken on its faces.
    """
    ax, ay, az = s[2, 1, 0] - s[2, 0, 0], s[2, 1, 1] - s[2, 0, 1], s[2, 1, 2] - s[2, 0, 2]
    bx, by, bz = s[2, 2, 0] - s[2, 0, 0], s[2, 2, 1] - s[2, 0, 1], s[2, 2, 2] - s[2, 0, 2]
    cx, cy, cz = s[2, 3, 0] - s[2, 0, 0], s[2, 3, 1] - s[2, 0, 1], s[2, 3, 2] - s[2, 0, 2]
    volume = abs(ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx))
    la = math.sqrt(ax * ax + ay * ay + az * az)
    lb = math.sqrt(bx * bx + by * by + bz * bz)
    lc = math.sqrt(cx * cx + cy * cy + cz * cz)
    flat = volume <= 1e-10 * la * lb * lc
    best = math.inf
    inside = not flat
    for f in range(4):
        # face (i, j, k) opposite l
        i, j, k = (1, 2, 3) if f == 0 else ((0, 3, 2) if f == 1 else ((0, 1, 3) if f == 2 else (0, 2, 1)))
        l = f
        ex, ey, ez = s[2, j, 0] - s[2, i, 0], s[2, j, 1] - s[2, i, 1], s[2, j, 2] - s[2, i, 2]
        fx, fy, fz = s[2, k, 0] - s[2, i, 0], s[2, k, 1] - s[2, i, 1], s[2, k, 2] - s[2, i, 2]
        nx, ny, nz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
        side_o = -(nx * s[2, i, 0] + ny * s[2, i, 1] + nz * s[2, i, 2])
        side_l = nx * (s[2, l, 0] - s[2, i, 0]) + ny * (s[2, l, 1] - s[2, i, 1]) + nz * (s[2, l, 2] - s[2, i, 2])
        if flat or side_o * side_l < 0.0:  # the origin is on the far side of this face
            inside = False
            d2 = _closest_triangle(s, i, j, k, tmp)
            if d2 < best:
                best = d2
                for m in range(4):
                    lam[m] = tmp[m]
    if inside:
        best = 0.0
    return best, inside


@njit(**JIT)
def gjk(pa, pb, s, lam, tmp, scale):
    """GJK distance between the cores pa, pb (pose rows).

    Returns (distance d ≥ 0, n_vertices, overlap). On return s[0..2, :n] hold the simplex's
    support points a, b, w = a − b and lam[:n] their weights: the witness points are Σ lam a
    (on A) and Σ lam b (on B). ``overlap`` is True when the origin is inside the final
    tetrahedron (n = 4: the cores overlap, EPA starts from it) or nearer than round-off.
    ``tmp`` is a scratch (4,).
    """
    dx, dy, dz = pb[_C] - pa[_C], pb[_C + 1] - pa[_C + 1], pb[_C + 2] - pa[_C + 2]
    if dx * dx + dy * dy + dz * dz == 0.0:
        dx = 1.0
    _add_support(pa, pb, dx, dy, dz, s, 0)
    n = 1
    lam[0], lam[1], lam[2], lam[3] = 1.0, 0.0, 0.0, 0.0
    vx, vy, vz = s[2, 0, 0], s[2, 0, 1], s[2, 0, 2]
    v2 = vx * vx + vy * vy + vz * vz
    overlap = False
    tol = GJK_TOLERANCE * scale
    for _ in range(GJK_MAX_ITERATIONS):
        if v2 <= (1e-3 * tol) ** 2:
            overlap = True
            break
        _add_support(pa, pb, -vx, -vy, -vz, s, n)
        wx, wy, wz = s[2, n, 0], s[2, n, 1], s[2, n, 2]
        # lower bound v·w/|v| of the distance against the upper bound |v|
        vw = vx * wx + vy * wy + vz * wz
        v_norm = math.sqrt(v2)
        if v_norm - vw / v_norm <= tol:
            break
        # a support point (nearly) repeated ends it: on a curved rim the points bunch up, and a
        # simplex of points closer than 1e-7 × the scale gains ~1e-14 × the scale at most
        repeated = False
        for k in range(n):
            ex, ey, ez = s[2, k, 0] - wx, s[2, k, 1] - wy, s[2, k, 2] - wz
            if ex * ex + ey * ey + ez * ez <= (1e-7 * scale) ** 2:
                repeated = True
        if repeated:
            break
        l0, l1, l2, l3 = lam[0], lam[1], lam[2], lam[3]
        n += 1
        if n == 2:
            new_v2 = _closest_segment(s, 0, 1, lam)
        elif n == 3:
            new_v2 = _closest_triangle(s, 0, 1, 2, lam)
        else:
            new_v2, inside = _closest_tetrahedron(s, lam, tmp)
            if inside:
                overlap = True
                break
        if new_v2 >= v2:  # no progress: round-off; keep the previous simplex's answer
            n -= 1
            lam[0], lam[1], lam[2], lam[3] = l0, l1, l2, l3
            break
        n = _keep(s, lam, n)
        v2 = new_v2
        vx = vy = vz = 0.0
        for k in range(n):
            vx += lam[k] * s[2, k, 0]
            vy += lam[k] * s[2, k, 1]
            vz += lam[k] * s[2, k, 2]
    # nearer than round-off of the pair's size: touching or overlapping, for EPA to tell
    if overlap or v2 <= (1e-12 * scale) ** 2:
        return 0.0, n, True
    return math.sqrt(v2), n, False


@njit(**JIT)
def _face(verts, faces, face_nd, f, i, j, k):
    """Face f = (i, j, k) of the EPA polytope: its outward unit normal and its distance from the origin."""
    faces[f, 0], faces[f, 1], faces[f, 2] = i, j, k
    ex = verts[2, j, 0] - verts[2, i, 0]
    ey = verts[2, j, 1] - verts[2, i, 1]
    ez = verts[2, j, 2] - verts[2, i, 2]
    fx = verts[2, k, 0] - verts[2, i, 0]
    fy = verts[2, k, 1] - verts[2, i, 1]
    fz = verts[2, k, 2] - verts[2, i, 2]
    nx, ny, nz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    if norm > 0.0:
        nx, ny, nz = nx / norm, ny / norm, nz / norm
    face_nd[f, 0], face_nd[f, 1], face_nd[f, 2] = nx, ny, nz
    face_nd[f, 3] = nx * verts[2, i, 0] + ny * verts[2, i, 1] + nz * verts[2, i, 2]
    face_nd[f, 4] = 1.0 if norm > 0.0 else 0.0


@njit(**JIT)
def _remove_face(faces, face_nd, f, edges, nedges):
    """Mark face f dead and toggle its directed edges in the horizon list; returns the list's new length."""
    face_nd[f, 4] = 0.0
    for e in range(3):
        p, q = faces[f, e], faces[f, (e + 1) % 3]
        shared = -1
        for g in range(nedges):
            if edges[g, 0] == q and edges[g, 1] == p:
                shared = g
        if shared >= 0:
            nedges -= 1
            edges[shared, 0], edges[shared, 1] = edges[nedges, 0], edges[nedges, 1]
        else:
            edges[nedges, 0], edges[nedges, 1] = p, q
            nedges += 1
    return nedges


@njit(**JIT)
def _touches(faces, f, edges, nedges):
    """Whether face f shares an edge with the horizon (one of its edges is a horizon edge reversed)."""
    hit = False
    for e in range(3):
        p, q = faces[f, e], faces[f, (e + 1) % 3]
        for g in range(nedges):
            if edges[g, 0] == q and edges[g, 1] == p:
                hit = True
    return hit


@njit(**JIT)
def _complete(pa, pb, s, nv):
    """Grow GJK's final simplex (it holds the origin, possibly on its boundary) to a tetrahedron.

    Adds support points along directions across the simplex, keeping the one furthest from its
    span, so that the tetrahedron has volume and still holds the origin. Returns the new count.
    """
    while nv < 4:
        best, bdx, bdy, bdz = -1.0, 1.0, 0.0, 0.0
        ex, ey, ez = 0.0, 0.0, 0.0
        fx, fy, fz = 0.0, 0.0, 0.0
        if nv >= 2:
            ex, ey, ez = s[2, 1, 0] - s[2, 0, 0], s[2, 1, 1] - s[2, 0, 1], s[2, 1, 2] - s[2, 0, 2]
        if nv == 3:
            fx, fy, fz = s[2, 2, 0] - s[2, 0, 0], s[2, 2, 1] - s[2, 0, 1], s[2, 2, 2] - s[2, 0, 2]
        for k in range(6):
            ax = 1.0 if k // 2 == 0 else 0.0
            ay = 1.0 if k // 2 == 1 else 0.0
            az = 1.0 if k // 2 == 2 else 0.0
            sgn = 1.0 if k % 2 == 0 else -1.0
            if nv == 1:
                dx, dy, dz = sgn * ax, sgn * ay, sgn * az
            elif nv == 2:  # across the segment
                dx, dy, dz = sgn * (ey * az - ez * ay), sgn * (ez * ax - ex * az), sgn * (ex * ay - ey * ax)
            else:  # along the triangle's normal, both ways
                dx, dy, dz = sgn * (ey * fz - ez * fy), sgn * (ez * fx - ex * fz), sgn * (ex * fy - ey * fx)
            norm = math.sqrt(dx * dx + dy * dy + dz * dz)
            if norm == 0.0:
                continue
            dx, dy, dz = dx / norm, dy / norm, dz / norm
            _add_support(pa, pb, dx, dy, dz, s, nv)
            gx, gy, gz = s[2, nv, 0] - s[2, 0, 0], s[2, nv, 1] - s[2, 0, 1], s[2, nv, 2] - s[2, 0, 2]
            if nv == 1:
                far = math.sqrt(gx * gx + gy * gy + gz * gz)
            else:  # distance from the span of the simplex, along the direction tried
                far = abs(gx * dx + gy * dy + gz * dz)
            if far > best:
                best, bdx, bdy, bdz = far, dx, dy, dz
        _add_support(pa, pb, bdx, bdy, bdz, s, nv)
        nv += 1
    return nv


@njit(**JIT)
def epa(pa, pb, s, nv, verts, faces, face_nd, edges, scale, out):
    """Penetration depth of overlapping cores from GJK's final simplex s (nv points; it holds the origin).

    Writes out[0] = depth ≥ 0 (the core signed distance is −depth), out[1:4] the unit normal u
    from A to B, out[4:7] and out[7:10] the witness points on A and B (world; blends of support
    points of the nearest face). The depth is the smallest support value h_D(u) met, so sep(u)
    = −depth exactly: translating B by depth·u separates the cores. It stops when that upper
    bound is within the tolerance of the polytope's nearest face (a lower bound), or when
    round-off makes the nearest face come nearer. Returns the number of iterations, or −1 if it
    stopped on the vertex limit.
    """
    _complete(pa, pb, s, nv)
    for row in range(3):
        for k in range(4):
            for c in range(3):
                verts[row, k, c] = s[row, k, c]
    nverts = 4
    # orient the tetrahedron's faces outwards
    nfaces = 0
    for f in range(4):
        i, j, k = (1, 2, 3) if f == 0 else ((0, 3, 2) if f == 1 else ((0, 1, 3) if f == 2 else (0, 2, 1)))
        _face(verts, faces, face_nd, nfaces, i, j, k)
        side = (face_nd[nfaces, 0] * (verts[2, f, 0] - verts[2, i, 0]) + face_nd[nfaces, 1] * (verts[2, f, 1] - verts[2, i, 1])
                + face_nd[nfaces, 2] * (verts[2, f, 2] - verts[2, i, 2]))
        if side > 0.0:
            _face(verts, faces, face_nd, nfaces, i, k, j)
        nfaces += 1
    tol = EPA_TOLERANCE * scale
    iterations = 0
    best = 0
    # the smallest support value h_D(n) seen: an upper bound of the depth, exact along its n
    upper, ux, uy, uz = math.inf, 0.0, 0.0, 1.0
    previous = -math.inf
    while True:
        best = -1
        best_d = math.inf
        for f in range(nfaces):
            if face_nd[f, 4] > 0.0 and face_nd[f, 3] < best_d:
                best_d = face_nd[f, 3]
                best = f
        if best < 0:
            break
        nx, ny, nz = face_nd[best, 0], face_nd[best, 1], face_nd[best, 2]
        if nverts >= verts.shape[1] or nfaces + 2 * nverts >= faces.shape[0]:
            iterations = -1
            break
        ax, ay, az = support(pa, nx, ny, nz)
        bx, by, bz = support(pb, -nx, -ny, -nz)
        wx, wy, wz = ax - bx, ay - by, az - bz
        value = nx * wx + ny * wy + nz * wz
        if value < upper:
            upper, ux, uy, uz = value, nx, ny, nz
        # converged, or round-off: the polytope's nearest face must not come nearer
        if upper - best_d <= tol or best_d < previous - tol:
            break
        previous = max(previous, best_d)
        iterations += 1
        v = nverts
        verts[0, v, 0], verts[0, v, 1], verts[0, v, 2] = ax, ay, az
        verts[1, v, 0], verts[1, v, 1], verts[1, v, 2] = bx, by, bz
        verts[2, v, 0], verts[2, v, 1], verts[2, v, 2] = wx, wy, wz
        nverts += 1
        # remove the faces w sees, grown from the nearest face across shared edges (so that
        # round-off in the visibility of a far face cannot cut a hole); the edges of removed faces
        # not shared by two of them form the horizon
        nedges = _remove_face(faces, face_nd, best, edges, 0)
        grown = True
        while grown:
            grown = False
            for f in range(nfaces):
                if face_nd[f, 4] > 0.0:
                    i = faces[f, 0]
                    seen = (face_nd[f, 0] * (wx - verts[2, i, 0]) + face_nd[f, 1] * (wy - verts[2, i, 1])
                            + face_nd[f, 2] * (wz - verts[2, i, 2]))
                    if seen > 0.0 and _touches(faces, f, edges, nedges):
                        nedges = _remove_face(faces, face_nd, f, edges, nedges)
                        grown = True
        # reuse dead face slots, then append
        slot = 0
        for g in range(nedges):
            while slot < nfaces and face_nd[slot, 4] > 0.0:
                slot += 1
            _face(verts, faces, face_nd, slot, edges[g, 0], edges[g, 1], v)
            if slot == nfaces:
                nfaces += 1
            slot += 1
    f = best
    nx, ny, nz = face_nd[f, 0], face_nd[f, 1], face_nd[f, 2]
    depth = face_nd[f, 3]
    # barycentric weights of the origin's projection depth·n on the face
    i, j, k = faces[f, 0], faces[f, 1], faces[f, 2]
    px, py, pz = depth * nx, depth * ny, depth * nz
    ex, ey, ez = verts[2, j, 0] - verts[2, i, 0], verts[2, j, 1] - verts[2, i, 1], verts[2, j, 2] - verts[2, i, 2]
    fx, fy, fz = verts[2, k, 0] - verts[2, i, 0], verts[2, k, 1] - verts[2, i, 1], verts[2, k, 2] - verts[2, i, 2]
    gx, gy, gz = px - verts[2, i, 0], py - verts[2, i, 1], pz - verts[2, i, 2]
    d00 = ex * ex + ey * ey + ez * ez
    d01 = ex * fx + ey * fy + ez * fz
    d11 = fx * fx + fy * fy + fz * fz
    d20 = gx * ex + gy * ey + gz * ez
    d21 = gx * fx + gy * fy + gz * fz
    den = d00 * d11 - d01 * d01
    lj, lk = 0.0, 0.0
    if den > 0.0:
        lj = (d11 * d20 - d01 * d21) / den
        lk = (d00 * d21 - d01 * d20) / den
    li = 1.0 - lj - lk
    if upper == math.inf:
        upper, ux, uy, uz = depth, nx, ny, nz
    # the depth and normal: the best upper bound, an exact separation along its direction
    out[0] = upper
    out[1], out[2], out[3] = ux, uy, uz
    for c in range(3):
        out[4 + c] = li * verts[0, i, c] + lj * verts[0, j, c] + lk * verts[0, k, c]
        out[7 + c] = li * verts[1, i, c] + lj * verts[1, j, c] + lk * verts[1, k, c]
    _pin = s[0, 0, 0], verts[0, 0, 0], faces[0, 0], face_nd[0, 0], edges[0, 0], pa[0], pb[0]
    return iterations
