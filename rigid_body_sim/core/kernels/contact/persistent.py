"""Compiled persistent contact: the force that holds a body on the ground, and the projection onto the contact.

A body at rest on the ground (or sliding, or rolling on it) is held by contact forces found at
the acceleration level (at the start of each step here; at every integrator stage for the
methods of kernels/contact/stage.py): with a_c the acceleration of each contact
point under everything else (gravity, applied and scripted wrenches, the gyroscopic term —
dynamics.derivative), the normal forces f_n ≥ 0 make the normal accelerations ≥ 0 with
f_n a_n = 0; friction is −μ f_n ŝ along the slip ŝ while the contact slides, and otherwise
whatever keeps the tangential acceleration zero inside the cone |f_t| ≤ μ f_n (projected
Gauss–Seidel, impacts.pgs, on the same contact rows as the impact law). The force found at the
step's start decides the contact's mode; for the methods that do not find it per stage (and
for a locked body) it is added to the step's wrench rows (world axes at the contact points'
anchors, forces.add_wrench) and held over the step; the site readings see it either way (a
resting IMU reads +g up).

After the step, :func:`project` puts the body back onto the contact exactly: the smallest
displacement in the body's mass metric that closes the gaps of the touching features, and the
normal (and, while sticking, tangential) velocity of the contact points removed by the smallest
impulse in the same metric. No Baumgarte term,
no compliance: the gap and normal velocity are zero to round-off, and the projection never adds
energy (it removes a velocity component in the mass metric).
"""

from __future__ import annotations

import math

from numba import njit

from ..dynamics import derivative
from ..forces import add_wrench
from ..layout import FRAME_SITE_WORLD_AXES, INV_INERTIA, INV_MASS, P, PROJECT, PROJECT_NONE, Q, Q_PB, V, W
from ..rotation import exp_map, normalise, qmul, rotate, rotate_back
from .impacts import _A, _ANG, _B, _LAM, _LIN, _row_velocity, apply_impulses, build_rows, pgs, summed_wrench
from .layout import DIMS, KIND, NORMAL, OFFSET, SHAPE_CAPSULE, SHAPE_CYLINDER, SHAPE_SPHERE
from .shapes import RIM_UPRIGHT, axis_tilt, feature_points, held_rim

__all__ = ["LIFT_OFF", "STICK", "SLIDE", "START_SLIDE_ACCELERATION", "add_contact_wrench", "accelerations", "accelerations_from", "normal_bias", "normal_motion", "holding_wrench", "project",
           "normal_speeds", "rim_turn_rate", "slip_velocity", "held_points", "end_toward_load"]

_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}

#: What :func:`holding_wrench` found the contact doing.
LIFT_OFF, STICK, SLIDE = 0, 1, 2
#: m/s²: a sticking contact whose points still accelerate along the ground faster than this starts to slide.
START_SLIDE_ACCELERATION = 1e-9


@njit(**_OPTS)
def slip_velocity(work, count):
    """Mean tangential velocity (along t1, t2) of the contact points, from the rows' b column (velocities)."""
    sx = 0.0
    sy = 0.0
    for c in range(count):
        sx += work[3 * c + 1, _B]
        sy += work[3 * c + 2, _B]
    return sx / count, sy / count


@njit(**_OPTS)
def accelerations(y, p, w, count, rows, points, bias, rdot, work, d):
    """work[:, B] ← the rows' components of the contact points' accelerations without contact force.

    a_c = a + α × r (+ ω × (ω × r) when the contact points are ``vertex`` es, fixed in the body:
    box corners) from dynamics.derivative at y under the wrench row ``w`` (gravity, applied and
    scripted wrenches, damping, the gyroscopic term), into ``d``, a 13-float scratch:
    :func:`accelerations_from`. The rows (build_rows) must be built for y.
    """
    derivative(y, p, w, d)
    accelerations_from(y, count, rdot, bias, work, d)
    _pin = y[P], p[0], w[0], d[0], points[0, 0], bias[0], rdot[0, 0]


@njit(**_OPTS)
def accelerations_from(y, count, rdot, bias, work, d):
    """work[:, B] ← the rows' components of the contact points' accelerations, the body's own in ``d``.

    ``d`` holds dy/dt without contact force (dynamics.derivative at y). On a curved
    surface (sphere, the round side of a cylinder or capsule) the contact point moves over the
    body as it rolls, and the surface's curvature cancels the centripetal term in the gap's
    second derivative (exactly for a sphere: gap = n·c − r, so g̈ = n·a), so it is left out.
    The normal rows take ``bias[c]`` instead: the velocity-product part of the second
    derivative of each contact's gap function (:func:`normal_bias`, exact for every shape).
    """
    qw, qx, qy, qz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
    ox, oy, oz = rotate(qw, qx, qy, qz, y[W], y[W + 1], y[W + 2])  # ω_W
    for c in range(count):
        wrx, wry, wrz = rdot[c, 0], rdot[c, 1], rdot[c, 2]  # how the contact point moves (ω × r for a body point)
        cx, cy, cz = oy * wrz - oz * wry, oz * wrx - ox * wrz, ox * wry - oy * wrx  # ω × that
        for k in range(3):
            a = 3 * c + k
            lx, ly, lz = work[a, _LIN], work[a, _LIN + 1], work[a, _LIN + 2]
            # d·(α × r) = α·(r × d) = α_P·ang_P
            work[a, _B] = (lx * (d[V] + cx) + ly * (d[V + 1] + cy) + lz * (d[V + 2] + cz)
                           + work[a, _ANG] * d[W] + work[a, _ANG + 1] * d[W + 1] + work[a, _ANG + 2] * d[W + 2])
            if k == 0:  # the normal row: n·a + α·(r × n) + the gap's own velocity-product term
                work[a, _B] += bias[c] - (lx * cx + ly * cy + lz * cz)
    _pin = y[P], d[0], bias[0], rdot[0, 0], work[0, 0]


@njit(**_OPTS)
def normal_motion(y, p, w, count, points, nx, ny, nz, bias, rdot, work, d):
    """(lowest normal velocity of the contact points, m/s; its free normal acceleration, m/s²; mean slip t1, t2)."""
    rows = build_rows(y, p, count, points, nx, ny, nz, work)
    sx, sy = slip_velocity(work, count)
    lowest = math.inf
    which = 0
    for c in range(count):
        if work[3 * c, _B] < lowest:
            lowest = work[3 * c, _B]
            which = c
    accelerations(y, p, w, count, rows, points, bias, rdot, work, d)
    return lowest, work[3 * which, _B], sx, sy


@njit(**_OPTS)
def normal_bias(y, p, shape, ground, mask, count, points, owners, bias, rdot, anchors):
    """bias[c] ← the velocity-product term of the second derivative of contact c's gap (m/s²).

    g̈ = n·a + α·(r × n) + bias, from each feature's gap function: a box corner or a point of a
    flat face is a point of the body, bias = n·(ω × (ω × r)); a sphere's gap n·c − r has none;
    a capsule end's gap n·(c ± h u) − r gives n·(ω × (ω × (± h u))); a cylinder rim's lowest
    point, gap n·c + f(n·u) with f(x) = ±h x − r √(1 − x²), gives f'(x) n·(ω × (ω × u)) +
    f''(x) (n·(ω × u))² (the rim's curvature: the contact point moves along the rim as it rolls);
    within RIM_UPRIGHT of upright, where those terms grow as 1/sin³ θ, the rim point is taken as a
    point of the body.
    ``owners`` are the features of the points (shapes.feature_points).

    rdot[c] ← the world velocity of contact c's point relative to the centre of mass: ω × r for
    a point of the body, 0 for a sphere's (it stays below the centre), ± h ω × u for a
    capsule's, and the rim point's own motion for a cylinder's. The tangential rows use
    ω × rdot, so that a rolling contact keeps its contact point at rest (d/dt (v + ω × r)).
    anchors[c] ← the body-fixed point (from the centre of mass, world axes) contact c's feature
    hangs on: the point itself for a box corner or a face point, the end's centre for a capsule
    or a cylinder rim, the centre for a sphere.
    """
    kind = int(shape[KIND])
    nx, ny, nz = ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2]
    qw, qx, qy, qz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
    ox, oy, oz = rotate(qw, qx, qy, qz, y[W], y[W + 1], y[W + 2])  # ω_W
    bw, bx, by, bz = qmul(qw, qx, qy, qz, p[Q_PB], p[Q_PB + 1], p[Q_PB + 2], p[Q_PB + 3])  # q_WB
    ux, uy, uz = rotate(bw, bx, by, bz, 0.0, 0.0, 1.0)  # the axis of a capsule or cylinder
    cos_a = nx * ux + ny * uy + nz * uz
    # sin² θ of the tilt as |n − cos θ u|² (1 − cos² θ loses its digits near upright, where 1/sin θ is large)
    sin2 = (nx - cos_a * ux) ** 2 + (ny - cos_a * uy) ** 2 + (nz - cos_a * uz) ** 2
    a0, a1 = shape[DIMS], shape[DIMS + 1]
    for c in range(count):
        end = owners[c]
        side = -1.0 if end % 2 == 0 else 1.0
        face = kind == SHAPE_CYLINDER and (mask & (4 << (end % 2)) or sin2 <= RIM_UPRIGHT * RIM_UPRIGHT)
        if kind == SHAPE_SPHERE:
            rx, ry, rz = 0.0, 0.0, 0.0
        elif kind == SHAPE_CAPSULE or (kind == SHAPE_CYLINDER and not face):
            rx, ry, rz = side * a1 * ux, side * a1 * uy, side * a1 * uz
        else:
            rx, ry, rz = points[c, 0] - y[P], points[c, 1] - y[P + 1], points[c, 2] - y[P + 2]
        anchors[c, 0], anchors[c, 1], anchors[c, 2] = rx, ry, rz
        wrx, wry, wrz = oy * rz - oz * ry, oz * rx - ox * rz, ox * ry - oy * rx
        b = nx * (oy * wrz - oz * wry) + ny * (oz * wrx - ox * wrz) + nz * (ox * wry - oy * wrx)
        if kind == SHAPE_SPHERE or kind == SHAPE_CAPSULE or kind == SHAPE_CYLINDER and not face:
            rdot[c, 0], rdot[c, 1], rdot[c, 2] = wrx, wry, wrz  # ω × (centre of the end, or 0 for a sphere)
        else:  # a point of the body
            px, py, pz = points[c, 0] - y[P], points[c, 1] - y[P + 1], points[c, 2] - y[P + 2]
            rdot[c, 0], rdot[c, 1], rdot[c, 2] = oy * pz - oz * py, oz * px - ox * pz, ox * py - oy * px
        if kind == SHAPE_CYLINDER and not face:  # − r √(1 − x²): f' = r x / s, f'' = r / s³
            sin_a = math.sqrt(sin2)
            wux, wuy, wuz = oy * uz - oz * uy, oz * ux - ox * uz, ox * uy - oy * ux  # ω × u
            rate = nx * wux + ny * wuy + nz * wuz  # d(n·u)/dt
            uu = nx * (oy * wuz - oz * wuy) + ny * (oz * wux - ox * wuz) + nz * (ox * wuy - oy * wux)
            b += a0 * cos_a / sin_a * uu + a0 / (sin2 * sin_a) * rate * rate
            # the rim point is − r ρ from the end's centre, ρ = (n − x u)/s: add − r dρ/dt
            ds = -cos_a * rate / sin_a
            for j in range(3):
                nj = (nx, ny, nz)[j]
                uj = (ux, uy, uz)[j]
                wuj = (wux, wuy, wuz)[j]
                drho = (-rate * uj - cos_a * wuj) / sin_a - (nj - cos_a * uj) * ds / sin2
                rdot[c, j] -= a0 * drho
        bias[c] = b
    _pin = y[P], p[0], shape[0], ground[0], points[0, 0], owners[0], bias[0], rdot[0, 0], anchors[0, 0]


@njit(**_OPTS)
def rim_turn_rate(y, p, shape, ground, mask):
    """How fast (rad/s) a cylinder held on a rim changes near upright: the larger of the rate at which its
    rim's lowest point turns about the plane's normal, |cot θ ρ·ω|, and, while it tilts back toward upright,
    its tilt's relative rate |θ̇|/θ.

    θ is the tilt of the axis u from the normal n, ρ = (n − cos θ u)/sin θ the direction from the
    rim's lowest point up across the axis, ω the angular velocity. A can wobbling near upright sweeps its
    contact point round the rim at a rate growing as 1/θ, and one coming down toward upright reaches it
    in about θ/|θ̇|: the solver cuts a step into pieces that each turn the point, or shrink the tilt, by
    less than a fraction. 0 for another shape, a body held on an end face or on both rims (lying), and within
    RIM_UPRIGHT of upright (turning about a rim point).
    """
    if held_rim(shape, mask) < 0:
        return 0.0
    nx, ny, nz = ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2]
    ox, oy, oz = rotate(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], y[W], y[W + 1], y[W + 2])  # ω_W
    ux, uy, uz, cos_a, _, _, _, sin_a = axis_tilt(y, p, nx, ny, nz)
    if sin_a <= RIM_UPRIGHT:
        return 0.0
    # ρ·ω sin θ = n·ω − cos θ u·ω
    turn = abs(cos_a * (nx * ox + ny * oy + nz * oz - cos_a * (ux * ox + uy * oy + uz * oz))) / (sin_a * sin_a)
    # d(cos θ)/dt = n·(ω × u) = −sin θ θ̇; the tilt from the rim's end: upright is cos θ = ±1
    tilt = math.atan2(sin_a, abs(cos_a))
    closing = (nx * (oy * uz - oz * uy) + ny * (oz * ux - ox * uz) + nz * (ox * uy - oy * ux)) / sin_a
    if cos_a < 0.0:
        closing = -closing
    return max(turn, closing / tilt) if closing > 0.0 else turn


@njit(**_OPTS)
def held_points(y, p, w, shape, ground, mask, points, gaps, owners, d, fresh):
    """The contact points a hold solves at (shapes.feature_points of the tracked features ``mask``: world points,
    gaps, features), a cylinder standing on an end face's 4 rim points turned toward its load (end_toward_load).
    ``d`` holds dy/dt at y without contact under the wrench row ``w`` (dynamics.derivative), or, with ``fresh``,
    is a 13-float scratch it is computed into when needed. Returns the count."""
    count = feature_points(y, p, shape, ground, mask, points, gaps, owners)
    if int(shape[KIND]) == SHAPE_CYLINDER and (mask & 12) != 0 and count == 4:  # standing on an end face
        if fresh:
            derivative(y, p, w, d)
        end_toward_load(y, p, shape, ground, mask, points, gaps, d)
    _pin = y[P], p[0], w[0], shape[0], ground[0], points[0, 0], gaps[0], owners[0], d[0]
    return count


@njit(**_OPTS)
def end_toward_load(y, p, shape, ground, mask, points, gaps, d):
    """Turn the 4 rim points of a cylinder standing on an end face (shapes.feature_points) toward its load.

    The end holds over its whole disk; 4 rim points hold a centre of pressure inside their square
    only. ``d`` holds dy/dt at y without contact (dynamics.derivative): the contact force and
    moment that would hold the body still are F = −m a and τ = −I α (principal axes; about the
    centre of mass), and their centre of pressure on the end face lies at s = n × τ_o / (n·F) from
    the face's centre o (τ_o = τ + (c − o) × F, n the plane's normal; friction in the plane adds
    nothing across it). Where s lies outside the square of the rim points along the body's ±x, ±y,
    the 4 points (``points``, world, and their ``gaps``, m) are put at 90° steps from the rim point
    along s: the disk holds a centre of pressure up to the radius along s, and beyond it the body
    pivots about that rim point, where the whole disk's would. Else, and for a body whose motion is
    projected (planar), or pressed off the plane, the points are left as they are.
    """
    inv_m = p[INV_MASS]
    if p[PROJECT] != PROJECT_NONE or inv_m <= 0.0:
        return
    for k in range(3):
        if p[INV_INERTIA + k] <= 0.0:
            return
    nx, ny, nz = ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2]
    fx, fy, fz = -d[V] / inv_m, -d[V + 1] / inv_m, -d[V + 2] / inv_m
    normal = nx * fx + ny * fy + nz * fz
    if not normal > 0.0:
        return
    tx, ty, tz = rotate(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], -d[W] / p[INV_INERTIA], -d[W + 1] / p[INV_INERTIA + 1],
                        -d[W + 2] / p[INV_INERTIA + 2])
    qw, qx, qy, qz = qmul(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], p[Q_PB], p[Q_PB + 1], p[Q_PB + 2], p[Q_PB + 3])
    ux, uy, uz = rotate(qw, qx, qy, qz, 0.0, 0.0, 1.0)
    e1x, e1y, e1z = rotate(qw, qx, qy, qz, 1.0, 0.0, 0.0)
    e2x, e2y, e2z = rotate(qw, qx, qy, qz, 0.0, 1.0, 0.0)
    r, half = shape[DIMS], shape[DIMS + 1]
    side = -1.0 if mask & 4 else 1.0
    lx, ly, lz = -side * half * ux, -side * half * uy, -side * half * uz  # c − o
    tx, ty, tz = tx + ly * fz - lz * fy, ty + lz * fx - lx * fz, tz + lx * fy - ly * fx  # τ_o
    sx, sy, sz = (ny * tz - nz * ty) / normal, (nz * tx - nx * tz) / normal, (nx * ty - ny * tx) / normal
    s1, s2 = sx * e1x + sy * e1y + sz * e1z, sx * e2x + sy * e2y + sz * e2z
    if abs(s1) + abs(s2) <= r:
        return
    size = math.sqrt(s1 * s1 + s2 * s2)
    c, s = s1 / size, s2 / size
    base = nx * y[P] + ny * y[P + 1] + nz * y[P + 2] - ground[OFFSET]
    for k in range(4):
        ox = -lx + r * (c * e1x + s * e2x)
        oy = -ly + r * (c * e1y + s * e2y)
        oz = -lz + r * (c * e1z + s * e2z)
        points[k, 0], points[k, 1], points[k, 2] = y[P] + ox, y[P + 1] + oy, y[P + 2] + oz
        gaps[k] = base + nx * ox + ny * oy + nz * oz
        c, s = -s, c  # the next rim point, 90° on
    _pin = y[P], p[0], shape[0], ground[0], points[0, 0], gaps[0], d[0]


@njit(**_OPTS)
def holding_wrench(y, p, w, count, points, nx, ny, nz, mu, slip_tolerance, bias, rdot, work, d, out):
    """out[0:6] ← the contact force (N, world) at the centre of mass and its moment (N·m, world axes).

    ``w`` is the step's wrench row without contact, ``d`` a 13-float scratch. Returns
    (mode, Σ f_n, ŝ1, ŝ2): LIFT_OFF (every f_n is zero: the body leaves), STICK or SLIDE, and
    the slip direction along (t1, t2) used while sliding (zeros otherwise, and always when
    μ = 0: a frictionless contact slides, never sticks). A contact not slipping whose friction,
    on the cone, cannot stop the contact points accelerating along the ground (their mean
    tangential acceleration after the solve above START_SLIDE_ACCELERATION: a box released on a
    slope steeper than its friction angle) starts to slide: SLIDE, ŝ along the points' mean
    tangential acceleration under the normal forces alone, and the forces solved again with
    friction −μ f_n ŝ — if, with that friction, the points still accelerate along ŝ (else the
    sticking solution is kept: a spinning body whose onset direction is not consistent).
    """
    rows = build_rows(y, p, count, points, nx, ny, nz, work)
    vx, vy = slip_velocity(work, count)
    slip = math.sqrt(vx * vx + vy * vy)
    accelerations(y, p, w, count, rows, points, bias, rdot, work, d)
    for a in range(rows):
        work[a, _LAM] = 0.0
    qw, qx, qy, qz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
    sx = sy = 0.0
    mode = STICK
    if mu == 0.0:
        mode = SLIDE
    elif slip > slip_tolerance:
        sx, sy = vx / slip, vy / slip
        mode = SLIDE
    pgs(work, count, mu, sx, sy)
    if mode == STICK:  # not slipping yet: if the cone cannot hold it, the contact points still accelerate along
        ax = ay = 0.0  # the ground after the solve, and it starts to slide
        for c in range(count):
            ax += _row_velocity(work, rows, 3 * c + 1)
            ay += _row_velocity(work, rows, 3 * c + 2)
        if math.sqrt(ax * ax + ay * ay) > START_SLIDE_ACCELERATION * count:
            # along the points' mean tangential acceleration under the normal forces alone, friction against it
            for a in range(rows):
                work[a, _LAM] = 0.0
            pgs(work, count, 0.0, 0.0, 0.0)
            ax = ay = 0.0
            for c in range(count):
                ax += _row_velocity(work, rows, 3 * c + 1)
                ay += _row_velocity(work, rows, 3 * c + 2)
            size = math.sqrt(ax * ax + ay * ay)
            for a in range(rows):
                work[a, _LAM] = 0.0
            if size > 0.0:
                mode = SLIDE
                sx, sy = ax / size, ay / size
            pgs(work, count, mu, sx, sy)
            ax = ay = 0.0  # consistent only if, with that friction, the points still accelerate along ŝ
            for c in range(count):
                ax += _row_velocity(work, rows, 3 * c + 1)
                ay += _row_velocity(work, rows, 3 * c + 2)
            if mode == SLIDE and ax * sx + ay * sy <= START_SLIDE_ACCELERATION * count:
                mode = STICK  # not: the sticking solve (friction on the cone), as before
                sx = sy = 0.0
                for a in range(rows):
                    work[a, _LAM] = 0.0
                pgs(work, count, mu, 0.0, 0.0)
    normal = 0.0
    for c in range(count):
        normal += work[3 * c, _LAM]
    if normal <= 0.0:
        mode = LIFT_OFF
    fx, fy, fz, hx, hy, hz = summed_wrench(work, rows)
    tx, ty, tz = rotate(qw, qx, qy, qz, hx, hy, hz)
    out[0], out[1], out[2], out[3], out[4], out[5] = fx, fy, fz, tx, ty, tz
    _pin = y[P], p[0], w[0], d[0]
    return mode, normal, sx, sy


@njit(**_OPTS)
def add_contact_wrench(w, y, p, count, points, anchors, work):
    """Add to wrench row ``w`` the contact forces of the multipliers in ``work`` (after holding_wrench).

    Each contact's force f (world axes) goes in at the body-fixed point its feature hangs on
    (``anchors``, from the centre of mass, normal_bias: a box corner itself, a capsule or
    cylinder end's centre, a sphere's centre) as a world-axes force at a body point
    (forces.add_wrench, FRAME_SITE_WORLD_AXES), so its moment turns with the body at every
    integrator stage (a pivot's force then does no work), plus the moment of the rest of the
    lever, (point − anchor) × f, which stays in world axes as the point stays below its anchor.
    """
    qw, qx, qy, qz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
    for c in range(count):
        gx = gy = gz = 0.0
        for k in range(3):
            a = 3 * c + k
            lam = work[a, _LAM]
            gx += work[a, _LIN] * lam
            gy += work[a, _LIN + 1] * lam
            gz += work[a, _LIN + 2] * lam
        ax, ay, az = anchors[c, 0], anchors[c, 1], anchors[c, 2]
        lx, ly, lz = points[c, 0] - y[P] - ax, points[c, 1] - y[P + 1] - ay, points[c, 2] - y[P + 2] - az
        r = rotate_back(qw, qx, qy, qz, ax, ay, az)
        add_wrench(w, p, FRAME_SITE_WORLD_AXES, r[0], r[1], r[2], gx, gy, gz,
                   ly * gz - lz * gy, lz * gx - lx * gz, lx * gy - ly * gx)
    _pin = w[0], y[P], p[0], points[0, 0], anchors[0, 0], work[0, 0]


#: A pivot of the contact rows' Cholesky factor below this × the largest diagonal is a redundant row (dropped).
REDUNDANT_PIVOT = 1e-10


@njit(**_OPTS)
def _solve_normal_rows(work, rows, step):
    """λ on the rows 0, step, 2 step, ... with (A λ)_a = −b_a (bilateral), the other λ zero; returns the rank.

    A direct solve: the Cholesky factorisation A = L D Lᵀ of those rows (in place of A's block
    in ``work``: the caller rebuilds the rows before using A again), a row whose pivot is below
    REDUNDANT_PIVOT × the largest diagonal being redundant (four corners of a face on the
    ground have rank 3 in their normal rows): its λ is 0. A is positive semi-definite and the
    right-hand side consistent (gaps and velocities of one rigid body), so every solution gives
    the same body displacement M⁻¹ Jᵀ λ: the one of least norm in the mass metric.
    """
    largest = 0.0
    for a in range(0, rows, step):
        largest = max(largest, work[a, _A + a])
    for a in range(rows):
        work[a, _LAM] = 0.0
    rank = 0
    if largest <= 0.0:
        return rank
    for a in range(0, rows, step):  # L (strictly below the diagonal) and D (on it), column by column
        d = work[a, _A + a]
        for k in range(0, a, step):
            d -= work[a, _A + k] * work[a, _A + k] * work[k, _A + k]
        if d <= REDUNDANT_PIVOT * largest:
            work[a, _A + a] = 0.0
            for i in range(a + step, rows, step):
                work[i, _A + a] = 0.0
            continue
        rank += 1
        work[a, _A + a] = d
        for i in range(a + step, rows, step):
            s = work[i, _A + a]
            for k in range(0, a, step):
                s -= work[i, _A + k] * work[a, _A + k] * work[k, _A + k]
            work[i, _A + a] = s / d
    for a in range(0, rows, step):  # L z = −b
        z = -work[a, _B]
        for k in range(0, a, step):
            z -= work[a, _A + k] * work[k, _LAM]
        work[a, _LAM] = z
    for a in range(0, rows, step):  # z / D (0 on a redundant row)
        d = work[a, _A + a]
        work[a, _LAM] = work[a, _LAM] / d if d > 0.0 else 0.0
    last = (rows - 1) // step * step
    for a in range(last, -1, -step):  # Lᵀ λ = z / D
        lam = work[a, _LAM]
        if work[a, _A + a] > 0.0:
            for i in range(a + step, rows, step):
                lam -= work[i, _A + a] * work[i, _LAM]
        else:
            lam = 0.0
        work[a, _LAM] = lam
    return rank


@njit(**_OPTS)
def project(y, p, shape, ground, mask, sticking, points, gaps, owners, work):
    """Body row y put back onto its contact in place: the tracked features' gaps 0, their contact velocities removed.

    Positions: the smallest displacement in the body's mass metric (translation and rotation,
    M⁻¹ Jᵀ λ with J M⁻¹ Jᵀ λ = −gap over the normal rows) that closes the gaps of the features
    in ``mask`` (shapes.feature_points), twice (the second pass takes the first's round-off).
    Velocities: the normal velocities of the contact points (and their tangential ones when
    ``sticking``) removed by the impulse of least kinetic energy (the same solve on
    velocities); sticking points that span the body (rank 6, three or more points: a face,
    three corners) leave it exactly at rest. Never adds energy. Returns the number of contact points.
    """
    nx, ny, nz = ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2]
    inv_m = p[INV_MASS]
    count = 0
    for _ in range(2):
        count = feature_points(y, p, shape, ground, mask, points, gaps, owners)
        if count == 0:
            break
        rows = build_rows(y, p, count, points, nx, ny, nz, work)
        for c in range(count):
            work[3 * c, _B] = gaps[c]
        _solve_normal_rows(work, rows, 3)
        dx = dy = dz = 0.0
        rx = ry = rz = 0.0
        for a in range(0, rows, 3):
            lam = work[a, _LAM]
            dx += work[a, _LIN] * lam * inv_m
            dy += work[a, _LIN + 1] * lam * inv_m
            dz += work[a, _LIN + 2] * lam * inv_m
            rx += work[a, _ANG] * lam * p[INV_INERTIA]
            ry += work[a, _ANG + 1] * lam * p[INV_INERTIA + 1]
            rz += work[a, _ANG + 2] * lam * p[INV_INERTIA + 2]
        y[P] += dx
        y[P + 1] += dy
        y[P + 2] += dz
        if rx != 0.0 or ry != 0.0 or rz != 0.0:
            e = exp_map(rx, ry, rz)  # a rotation by Δθ in principal axes: q ← q ⊗ exp(Δθ)
            qw, qx, qy, qz = qmul(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], e[0], e[1], e[2], e[3])
            y[Q], y[Q + 1], y[Q + 2], y[Q + 3] = normalise(qw, qx, qy, qz)
    if count > 0:
        count = feature_points(y, p, shape, ground, mask, points, gaps, owners)
        rows = build_rows(y, p, count, points, nx, ny, nz, work)
        rank = _solve_normal_rows(work, rows, 1 if sticking else 3)
        # the contact points span the body (three or more: two points leave the turn about their line free,
        # whatever the factorisation's pivots say): no velocity is left, exactly
        if sticking and rank == 6 and count >= 3:
            for j in range(3):
                y[V + j] = 0.0
                y[W + j] = 0.0
        else:
            apply_impulses(y, y, p, work, rows, _LAM, 1.0)
    _pin = y[P], p[0], shape[0], ground[0], points[0, 0], gaps[0], owners[0]
    return count


@njit(**_OPTS)
def normal_speeds(y, p, count, points, nx, ny, nz, work):
    """(lowest, highest) normal velocity of the contact points, m/s (positive away from the ground)."""
    build_rows(y, p, count, points, nx, ny, nz, work)
    lowest = math.inf
    highest = -math.inf
    for c in range(count):
        lowest = min(lowest, work[3 * c, _B])
        highest = max(highest, work[3 * c, _B])
    return lowest, highest
