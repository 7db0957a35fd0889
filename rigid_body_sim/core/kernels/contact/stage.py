"""The holding force of persistent contact found at an integrator stage, from the stage's own state.

A body in persistent contact stepped by a method whose stages evaluate the right-hand side
from their own state (euler, rk4, the scipy ``reference``: integrators.Method.derivative_stages)
carries its contact in its wrench row (layout.HELD …: the mode, the shape, the plane, the
tracked features, μ, each contact point's slip direction at the step's start:
:func:`hold_in_row`, :func:`stage_rows`). Its right-hand side is :func:`held_derivative`:
dynamics.derivative, the one force evaluation of every body, then :func:`held_accelerations`,
which solves at that stage's state the same law persistent.holding_wrench solves at the step's
start — normal forces f_n ≥ 0 that make
the contact points' normal accelerations ≥ 0 with f_n a_n = 0; friction −μ f_n ŝ along the
slip while sliding, else inside the cone |f_t| ≤ μ f_n keeping the tangential acceleration
zero — at the stage's state, and adds the accelerations it gives to the stage's derivative.
The force is then a smooth function of the state along the step (while the contact's mode
holds), so each method keeps its order while the body pivots on an edge or rolls on a rim.

The step loops (stepping.py) and dynamics.derivative are those of a free body, untouched: a
branch on the contact there, even one never taken, made euler and rk4 several times slower on
free bodies. The loops step a held body as if free (its wrench row has no contact force), and
the contact solver then takes its step again with the method's ``held`` step
(integrators.euler_held, rk4_held: the same tableau on :func:`held_derivative`), in the
simulator's step and in its step map alike; ``reference`` evaluates :func:`held_derivatives`.

The mode (sticking or sliding) is the step's: it changes between steps, at events the solver
locates (core/contact/solver.py). While sliding, each contact point's friction opposes that
point's own slip at the stage (Coulomb's law per point: it never does positive work, where
one direction for the whole contact would on a body spinning as it slides); a point whose
slip has turned against its direction at the step's start (the slide stopped inside the
step) keeps that direction, so the slip goes on reversing and the solver locates the stop on
the step map, as for the methods given the force of the step's start.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..dynamics import derivative
from ..forces import project
from ..layout import (ACTIVE, HELD, HELD_FEATURES, HELD_GROUND, HELD_MU, HELD_OTHER, HELD_OTHER_FEATURES, HELD_SHAPE,
                      HELD_SLIDE, INV_INERTIA, INV_MASS, MODEL, MODEL_FULL, MODEL_ISOTROPIC, MODEL_SYMMETRIC,
                      NORMAL as PLANE_NORMAL, P, PROJECT, PROJECT_NONE, Q, STATE_WIDTH, V, W)
from ..rotation import rotate, rotate_back
from .impacts import _B, IMPACT_WORK_SHAPE, build_rows, build_rows_normals, pgs_each, summed_wrench
from .layout import DIMS, KIND, MAX_POINTS, NORMAL, OFFSET
from .materials import material
from .persistent import SLIDE, STICK, accelerations_from, held_points, normal_bias
from .shapes import feature_points

__all__ = ["held_derivative", "held_derivatives", "held_accelerations", "held_acceleration", "hold_in_row",
           "hold_on_two_planes_in_row", "on_two_planes", "two_plane_rows", "stage_rows", "stepped_by_integrator"]

_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}


@njit(**_OPTS)
def held_derivative(y, p, w, d):
    """d ← dy/dt of a body whose wrench row ``w`` carries its contact: dynamics.derivative, then the force
    holding it found at this state (:func:`held_accelerations`). The right-hand side every stage of
    euler and rk4 (integrators.py: their ``held`` steps) and of ``reference`` (:func:`held_derivatives`)
    evaluates for such a body."""
    derivative(y, p, w, d)
    if w[HELD] != 0.0:
        held_accelerations(y, p, w, d)


@njit(**_OPTS)
def held_derivatives(Y, prm, wrenches, D):
    """D ← dY/dt for every body (dynamics.derivatives), a body whose row carries its contact by :func:`held_derivative`."""
    for i in range(Y.shape[0]):
        held_derivative(Y[i], prm[i], wrenches[i], D[i])


@njit(**_OPTS)
def held_accelerations(y, p, w, d):
    """d[V:V+3], d[W:W+3] += the accelerations of the contact force holding the body at state ``y``.

    ``d`` holds dy/dt at y without contact (dynamics.derivative); ``w`` is the wrench
    row with the contact (layout.HELD …). The force, world axes at the contact points, is
    projected onto the body's motion like any wrench (forces.project). A stage at which no
    tracked feature has a contact point, or the normal forces come out zero, adds nothing.
    """
    if on_two_planes(w):
        _two_plane_accelerations(y, p, w, d)
        return
    shape = w[HELD_SHAPE:HELD_SHAPE + 4]  # KIND, DIMS: the columns of a shape row
    ground = w[HELD_GROUND:HELD_GROUND + 4]  # NORMAL, OFFSET: the columns of a ground row
    mask = np.int64(w[HELD_FEATURES])
    mu = w[HELD_MU]
    points = np.empty((MAX_POINTS, 3))
    gaps = np.empty(MAX_POINTS)
    owners = np.zeros(MAX_POINTS, dtype=np.int64)
    bias = np.empty(MAX_POINTS)
    rdot = np.empty((MAX_POINTS, 3))
    anchors = np.empty((MAX_POINTS, 3))
    work = np.zeros(IMPACT_WORK_SHAPE)
    count = held_points(y, p, w, shape, ground, mask, points, gaps, owners, d, False)  # as at the step's start
    if count > 0:
        nx, ny, nz = ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2]
        normal_bias(y, p, shape, ground, mask, count, points, owners, bias, rdot, anchors)
        rows = build_rows(y, p, count, points, nx, ny, nz, work)
        directions = np.zeros((MAX_POINTS, 2))  # per contact: the direction (t1, t2) its friction opposes
        if mu != 0.0 and w[HELD] == SLIDE:
            for c in range(count):
                ux, uy = w[HELD_SLIDE + 2 * c], w[HELD_SLIDE + 2 * c + 1]  # its slip direction at the step's start
                vx, vy = work[3 * c + 1, _B], work[3 * c + 2, _B]  # its slip at this stage
                slip = math.sqrt(vx * vx + vy * vy)
                if slip > 0.0 and vx * ux + vy * uy > 0.0:  # against its own slip at this stage
                    ux, uy = vx / slip, vy / slip
                directions[c, 0], directions[c, 1] = ux, uy  # reversed since the start: on along the start's
        accelerations_from(y, count, rdot, bias, work, d)
        pgs_each(work, count, mu, directions)
        _add_accelerations(y, p, work, rows, d)
    _pin = y[P], p[0], w[0], d[0]


@njit(**_OPTS)
def _add_accelerations(y, p, work, rows, d):
    """d[V:V+3], d[W:W+3] += the accelerations of the force the multipliers in ``work`` give (its first ``rows``
    rows), projected onto the body's motion like any wrench (forces.project)."""
    fx, fy, fz, hx, hy, hz = summed_wrench(work, rows)  # moment about the centre of mass, principal axes
    if p[PROJECT] != PROJECT_NONE:  # onto the body's motion, in world axes, as forces.body_wrench does
        qw, qx, qy, qz = y[Q], y[Q + 1], y[Q + 2], y[Q + 3]
        tx, ty, tz = rotate(qw, qx, qy, qz, hx, hy, hz)
        fx, fy, fz, tx, ty, tz = project(p[PROJECT], p[PLANE_NORMAL], p[PLANE_NORMAL + 1],
                                         p[PLANE_NORMAL + 2], fx, fy, fz, tx, ty, tz)
        hx, hy, hz = rotate_back(qw, qx, qy, qz, tx, ty, tz)
    inv_m = p[INV_MASS]
    d[V] += fx * inv_m
    d[V + 1] += fy * inv_m
    d[V + 2] += fz * inv_m
    d[W] += hx * p[INV_INERTIA]
    d[W + 1] += hy * p[INV_INERTIA + 1]
    d[W + 2] += hz * p[INV_INERTIA + 2]


@njit(**_OPTS)
def on_two_planes(w):
    """Whether wrench row ``w`` carries a second plane (layout.HELD_OTHER: its normal not zero)."""
    return w[HELD_OTHER] != 0.0 or w[HELD_OTHER + 1] != 0.0 or w[HELD_OTHER + 2] != 0.0


@njit(**_OPTS)
def two_plane_rows(y, p, shape, plane_a, mask_a, plane_b, mask_b, points, gaps, on_b, bias, rdot, anchors, normals,
                   work):
    """The contact rows of a body held on two planes at once (two_grounds.py), for state ``y``: the points of the
    features ``mask_a`` on ``plane_a`` then of ``mask_b`` on ``plane_b`` (ground rows: normal, offset), each
    row with its own plane's normal, t1 along the crease n_A × n_B for all (impacts.build_rows_normals). Fills
    ``points``, their ``gaps`` (m), ``on_b`` (1 for a point on plane_b, else 0), ``bias``, ``rdot``, ``anchors``
    (persistent.normal_bias), ``normals`` (MAX_POINTS × 3) and ``work``'s rows, A and b (the contact velocities).
    Returns the count, or −1 where the two planes' points are more than MAX_POINTS (nothing filled then)."""
    more = np.empty((MAX_POINTS, 3))
    b_gaps = np.empty(MAX_POINTS)
    owners = np.zeros(MAX_POINTS, dtype=np.int64)
    n_a = feature_points(y, p, shape, plane_a, mask_a, points, gaps, owners)
    normal_bias(y, p, shape, plane_a, mask_a, n_a, points, owners, bias, rdot, anchors)
    n_b = feature_points(y, p, shape, plane_b, mask_b, more, b_gaps, owners)
    if n_a + n_b > MAX_POINTS:
        return -1
    b_bias = np.empty(MAX_POINTS)
    b_rdot = np.empty((MAX_POINTS, 3))
    b_anchors = np.empty((MAX_POINTS, 3))
    normal_bias(y, p, shape, plane_b, mask_b, n_b, more, owners, b_bias, b_rdot, b_anchors)
    for c in range(n_a + n_b):
        plane = plane_a if c < n_a else plane_b
        on_b[c] = 0 if c < n_a else 1
        for k in range(3):
            normals[c, k] = plane[NORMAL + k]
        if c >= n_a:
            gaps[c] = b_gaps[c - n_a]
            bias[c] = b_bias[c - n_a]
            for k in range(3):
                points[c, k] = more[c - n_a, k]
                rdot[c, k] = b_rdot[c - n_a, k]
                anchors[c, k] = b_anchors[c - n_a, k]
    ax, ay, az = plane_a[NORMAL], plane_a[NORMAL + 1], plane_a[NORMAL + 2]
    bx, by, bz = plane_b[NORMAL], plane_b[NORMAL + 1], plane_b[NORMAL + 2]
    tx, ty, tz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    size = math.sqrt(tx * tx + ty * ty + tz * tz)
    build_rows_normals(y, p, n_a + n_b, points, normals, tx / size, ty / size, tz / size, work)
    return n_a + n_b


@njit(**_OPTS)
def _two_plane_accelerations(y, p, w, d):
    """:func:`held_accelerations` for a body held on two planes at once (the row's ``HELD_GROUND`` and
    ``HELD_OTHER``): the law two_grounds.hold solves at the step's start, at this stage's state — the points of
    both planes' tracked features (:func:`two_plane_rows`), one μ, sliding along the crease (``HELD_SLIDE``'s
    first direction, (±1, 0) for every point) or sticking inside the cone."""
    points = np.empty((MAX_POINTS, 3))
    gaps = np.empty(MAX_POINTS)
    on_b = np.empty(MAX_POINTS, dtype=np.int64)
    bias = np.empty(MAX_POINTS)
    rdot = np.empty((MAX_POINTS, 3))
    anchors = np.empty((MAX_POINTS, 3))
    normals = np.empty((MAX_POINTS, 3))
    work = np.zeros(IMPACT_WORK_SHAPE)
    count = two_plane_rows(y, p, w[HELD_SHAPE:HELD_SHAPE + 4], w[HELD_GROUND:HELD_GROUND + 4],
                           np.int64(w[HELD_FEATURES]), w[HELD_OTHER:HELD_OTHER + 4], np.int64(w[HELD_OTHER_FEATURES]),
                           points, gaps, on_b, bias, rdot, anchors, normals, work)
    if count > 0:
        directions = np.zeros((MAX_POINTS, 2))
        if w[HELD] == SLIDE:
            for c in range(count):
                directions[c, 0], directions[c, 1] = w[HELD_SLIDE], w[HELD_SLIDE + 1]
        accelerations_from(y, count, rdot, bias, work, d)
        pgs_each(work, count, w[HELD_MU], directions)
        _add_accelerations(y, p, work, 3 * count, d)
    _pin = y[P], p[0], w[0], d[0]


@njit(**_OPTS)
def hold_in_row(w, bare, y, p, shape, ground, mask, mu, mode, sx, sy, slip_tolerance):
    """Wrench row ``w`` ← ``bare`` (the row without contact) carrying the contact, to be found at every stage.

    ``y``, ``p`` the body's state and parameter rows at the step's start, ``shape`` and
    ``ground`` its shape row and the plane's ground row (contact/layout.py), ``mask`` the
    tracked features, ``mode`` persistent.STICK or SLIDE and (sx, sy) the body's slip direction
    along (t1, t2) (persistent.holding_wrench). Each contact point's slip direction at y goes in
    ``HELD_SLIDE`` (while sliding; (sx, sy) for a point slipping slower than ``slip_tolerance``).
    """
    _held_row(w, bare, shape, ground, mask, mu, mode)
    if mode == SLIDE:
        points = np.empty((MAX_POINTS, 3))
        gaps = np.empty(MAX_POINTS)
        owners = np.zeros(MAX_POINTS, dtype=np.int64)
        work = np.zeros(IMPACT_WORK_SHAPE)
        count = held_points(y, p, bare, shape, ground, mask, points, gaps, owners, np.empty(STATE_WIDTH), True)
        build_rows(y, p, count, points, ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2], work)
        for c in range(MAX_POINTS):
            ux, uy = sx, sy
            if c < count:
                vx, vy = work[3 * c + 1, _B], work[3 * c + 2, _B]
                slip = math.sqrt(vx * vx + vy * vy)
                if slip > slip_tolerance:
                    ux, uy = vx / slip, vy / slip
            w[HELD_SLIDE + 2 * c], w[HELD_SLIDE + 2 * c + 1] = ux, uy
    w[ACTIVE] = 1.0  # so that the row is cleared before the next step (stepping.clear_wrenches)


@njit(**_OPTS)
def hold_on_two_planes_in_row(w, bare, shape, plane_a, mask_a, plane_b, mask_b, mu, mode, sx):
    """Wrench row ``w`` ← ``bare`` carrying a hold on two planes at once (two_grounds.hold's), to be found at every
    stage: the features ``mask_a`` on ``plane_a`` and ``mask_b`` on ``plane_b`` (ground rows), one μ, ``mode``
    persistent.STICK or SLIDE, and while sliding ``sx`` = ±1, the slip's sense along the crease n_A × n_B."""
    _held_row(w, bare, shape, plane_a, mask_a, mu, mode)
    for k in range(4):
        w[HELD_OTHER + k] = plane_b[NORMAL + k]
    w[HELD_OTHER_FEATURES] = mask_b
    for c in range(MAX_POINTS):
        w[HELD_SLIDE + 2 * c], w[HELD_SLIDE + 2 * c + 1] = sx, 0.0
    w[ACTIVE] = 1.0


@njit(**_OPTS)
def _held_row(w, bare, shape, ground, mask, mu, mode):
    """``w`` ← ``bare`` with the columns HELD … HELD_MU set (the body's shape row, the plane's ground row), and no
    second plane."""
    for k in range(w.shape[0]):
        w[k] = bare[k]
    w[HELD] = mode
    w[HELD_SHAPE] = shape[KIND]
    for k in range(3):
        w[HELD_SHAPE + 1 + k] = shape[DIMS + k]
        w[HELD_GROUND + k] = ground[NORMAL + k]
    w[HELD_GROUND + 3] = ground[OFFSET]
    w[HELD_FEATURES] = mask
    w[HELD_MU] = mu
    for k in range(4):
        w[HELD_OTHER + k] = 0.0
    w[HELD_OTHER_FEATURES] = 0.0


@njit(**_OPTS)
def stage_rows(wrenches, bare, held_rows, Y, prm, shapes, grounds, bodies, ground_of, tracked, friction,
               tangent_friction, first_tangent, sliding, slide_direction, slip_tolerance, locked, staged):
    """The wrench rows of ``bodies`` (held by batch.hold_all) turned into rows carrying their contact (hold_in_row).

    Each body not locked (a locked body's held row is exact over its step: it stays) whose
    model the integrator steps (full, and the isotropic and symmetric models, which leave a
    body with a held contact to the integrator: reduced_models.torque_free): ``held_rows[i]``
    ← its row with the holding force of the step's start (what the records report), then
    ``wrenches[i]`` ← ``bare[i]`` with the contact; ``staged[i]`` ← 1. Body i's μ on plane row j is
    ``materials.material(friction, tangent_friction, first_tangent, i, j)`` (as in batch.hold_all).
    """
    for m in range(bodies.shape[0]):
        i = bodies[m]
        if locked[i] != 0 or not stepped_by_integrator(prm[i]):
            continue
        for k in range(wrenches.shape[1]):
            held_rows[i, k] = wrenches[i, k]
        j = ground_of[i]
        hold_in_row(wrenches[i], bare[i], Y[i], prm[i], shapes[i], grounds[j], tracked[i],
                    material(friction, tangent_friction, first_tangent, i, j), SLIDE if sliding[i] else STICK,
                    slide_direction[i, 0], slide_direction[i, 1], slip_tolerance)
        staged[i] = 1


@njit(**_OPTS)
def stepped_by_integrator(p):
    """True for a body whose model leaves a held contact to the integrator (full, isotropic, symmetric)."""
    model = p[MODEL]
    return model == MODEL_FULL or model == MODEL_ISOTROPIC or model == MODEL_SYMMETRIC


@njit(**_OPTS)
def held_acceleration(y, p, w, ax, ay, az, bx, by, bz):
    """(a_C, ω̇_P) of :func:`held_accelerations` for a body whose accelerations without contact are given."""
    d = np.zeros(y.shape[0])
    d[V], d[V + 1], d[V + 2] = ax, ay, az
    d[W], d[W + 1], d[W + 2] = bx, by, bz
    held_accelerations(y, p, w, d)
    return d[V], d[V + 1], d[V + 2], d[W], d[W + 1], d[W + 2]
