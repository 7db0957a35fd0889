"""Compiled passes over every body in persistent contact: the holding forces before the step, the projection after.

:func:`hold_all` and :func:`settle_all` do, in one compiled loop, what
solver.ContactSolver does body by body in Python for the rare cases (persistent.py holds the
physics): a resting, sliding or rolling body costs no Python call per step. A body whose step
needs an event (it lifts off, its slide stops, another feature reaches the ground, a feature is
let go) is flagged in ``status`` and left to the solver.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..layout import STATE_WIDTH
from .impacts import _LAM, IMPACT_WORK_SHAPE, build_rows
from .layout import MAX_POINTS, NORMAL
from .persistent import (
    LIFT_OFF,
    SLIDE,
    add_contact_wrench,
    holding_wrench,
    normal_bias,
    normal_motion,
    project,
    slip_velocity,
)
from .shapes import MAX_FEATURES, body_points, feature_gaps, feature_points

__all__ = ["OK", "TO_SOLVER", "hold_all", "settle_all"]

_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}

#: ``status`` of a body after a pass: nothing to do, or the solver's to handle in Python.
OK, TO_SOLVER = 0, 1


@njit(**_OPTS)
def hold_all(Y, prm, wrenches, shapes, grounds, bodies, ground_of, tracked, friction, slip_tolerance,
             lift_off_speed, touching_gap, bare, pressed, sliding, slide_direction, status):
    """Add each body's holding force (persistent.holding_wrench) to its wrench row; flag the ones that lift off.

    ``bare[i]`` keeps body i's wrench row as it was before (for a step taken again in pieces).
    """
    points = np.empty((MAX_POINTS, 3))
    gaps = np.empty(MAX_POINTS)
    owners = np.zeros(MAX_POINTS, dtype=np.int64)
    bias = np.empty(MAX_POINTS)
    rdot = np.empty((MAX_POINTS, 3))
    anchors = np.empty((MAX_POINTS, 3))
    work = np.zeros(IMPACT_WORK_SHAPE)
    d = np.empty(STATE_WIDTH)
    force = np.empty(6)
    for m in range(bodies.shape[0]):
        i = bodies[m]
        j = ground_of[i]
        y, p, w, ground = Y[i], prm[i], wrenches[i], grounds[j]
        nx, ny, nz = ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2]
        status[i] = OK
        count = feature_points(y, p, shapes[i], ground, tracked[i], points, gaps, owners)
        if count == 0:
            status[i] = TO_SOLVER
            continue
        lowest = math.inf
        for c in range(count):
            lowest = min(lowest, gaps[c])
        normal_bias(y, p, shapes[i], ground, tracked[i], count, points, owners, bias, rdot, anchors)
        speed, _, _, _ = normal_motion(y, p, w, count, points, nx, ny, nz, bias, rdot, work, d)
        mode, _, sx, sy = holding_wrench(y, p, w, count, points, nx, ny, nz, friction[i, j], slip_tolerance, bias,
                                         rdot, work, d, force)
        if mode == LIFT_OFF or speed > lift_off_speed or lowest > touching_gap:
            status[i] = TO_SOLVER
            continue
        sliding[i] = mode == SLIDE
        slide_direction[i, 0], slide_direction[i, 1] = sx, sy
        bits = 0
        for c in range(count):
            if work[3 * c, _LAM] > 0.0:
                bits |= 1 << owners[c]
        pressed[i] = bits
        for k in range(w.shape[0]):
            bare[i, k] = w[k]
        add_contact_wrench(w, y, p, count, points, anchors, work)


@njit(**_OPTS)
def settle_all(Y, prm, shapes, grounds, bodies, ground_of, tracked, pressed, sliding, slide_direction, band, status):
    """Project each body in persistent contact back onto it (persistent.project), unless its step had an event.

    Flagged for the solver instead: a slide whose slip reversed in the step, another ground
    reached, a feature not tracked that is now below the ground, a tracked feature the holding
    force did not push on that moved off.
    """
    points = np.empty((MAX_POINTS, 3))
    gaps = np.empty(MAX_POINTS)
    owners = np.zeros(MAX_POINTS, dtype=np.int64)
    features = np.empty(MAX_FEATURES)
    work = np.zeros(IMPACT_WORK_SHAPE)
    for m in range(bodies.shape[0]):
        i = bodies[m]
        j = ground_of[i]
        y, p, ground = Y[i], prm[i], grounds[j]
        nx, ny, nz = ground[NORMAL], ground[NORMAL + 1], ground[NORMAL + 2]
        status[i] = OK
        sx, sy = slide_direction[i, 0], slide_direction[i, 1]
        if sliding[i] and (sx != 0.0 or sy != 0.0):
            count = feature_points(y, p, shapes[i], ground, tracked[i], points, gaps, owners)
            build_rows(y, p, count, points, nx, ny, nz, work)
            vx, vy = slip_velocity(work, count)
            if vx * sx + vy * sy <= 0.0:
                status[i] = TO_SOLVER
                continue
        for jj in range(grounds.shape[0]):  # another half-space reached: an impact for the solver
            if jj != j and status[i] == OK:
                count = body_points(y, p, shapes[i], grounds[jj], points, gaps)
                for c in range(count):
                    if gaps[c] < 0.0:
                        status[i] = TO_SOLVER
        if status[i] != OK:
            continue
        count = feature_gaps(y, p, shapes[i], ground, features)
        for k in range(count):
            inside = not tracked[i] & (1 << k) and features[k] < 0.0
            let_go = tracked[i] & (1 << k) and not pressed[i] & (1 << k) and features[k] > band[i]
            if inside or let_go:
                status[i] = TO_SOLVER
        if status[i] == OK:
            project(y, p, shapes[i], ground, tracked[i], not sliding[i], points, gaps, owners, work)
