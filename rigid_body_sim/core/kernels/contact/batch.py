"""Compiled passes over every body in persistent contact: the holding forces before the step, the projection after.

:func:`hold_all` and :func:`settle_all` do, in one compiled loop, what
solver.ContactSolver does body by body in Python for the rare cases (persistent.py holds the
physics): a resting, sliding or rolling body costs no Python call per step. A body whose step
needs an event (it lifts off, it is driven into the ground, its slide stops, another feature reaches the ground, a feature is
let go) is flagged in ``status`` and left to the solver.

**Locked bodies.** A body that starts a step exactly at rest (v = ω = 0), sticking, and whose
holding force leaves it no acceleration (≤ LOCK_ACCELERATION: round-off) is *locked*: the
exact motion over the step is none, so its step ends where it started (settle_all copies
its start row back; no projection is needed). Its holding force is a function of its state,
parameters, wrench row and tracked features alone, so while those are bitwise the ones of the
step before, the wrench row found then is used again (``cache``): a resting pile costs a
comparison per body and step, not a contact solve.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..dynamics import derivative
from ..layout import ACTIVE, AXIS_S, CACHE_RATE, F_COM_W, F_WORLD, PRM_WIDTH, Q, STATE_WIDTH, TOP_KEY, V, W, WRENCH_WIDTH
from ..rotation import rotate
from .impacts import _LAM, IMPACT_WORK_SHAPE, build_rows, kinetic_energy_row, potential_energy_row
from .layout import FLIGHT, MAX_POINTS, NORMAL, PERSISTENT
from .materials import material
from .persistent import (
    LIFT_OFF,
    SLIDE,
    add_contact_wrench,
    STICK,
    held_points,
    holding_wrench,
    normal_bias,
    project,
    rim_turn_rate,
    slip_velocity,
)
from .shapes import MAX_FEATURES, body_points, feature_gaps, feature_points, opposite_rim_gap

__all__ = ["OK", "TO_SOLVER", "LOCKED", "LOCK_ACCELERATION", "CACHE_WIDTH", "hold_all", "settle_all", "split_bodies",
           "record_holds", "gravity_gains", "fast_rims", "busy_bodies"]

_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}

#: ``status`` of a body after a pass: nothing to do, the solver's to handle in Python, or locked (its start row kept).
OK, TO_SOLVER, LOCKED = 0, 1, 2
#: m/s² and rad/s²: a body at rest whose held acceleration is below this (round-off) is locked for the step.
LOCK_ACCELERATION = 1e-12
# cache row (float64 per body): valid, ground, tracked, pressed, then the state row, the parameter row, the wrench
# row without and with the holding force
_VALID, _GROUND, _TRACKED, _PRESSED, _STATE = 0, 1, 2, 3, 4
_PRM = _STATE + STATE_WIDTH
_BARE = _PRM + PRM_WIDTH
_HELD = _BARE + WRENCH_WIDTH
#: Width of hold_all's ``cache`` rows.
CACHE_WIDTH = _HELD + WRENCH_WIDTH


@njit(**_OPTS)
def _lowest_normal_speed(y, count, points, nx, ny, nz):
    """The lowest normal velocity n·(v + ω × r) of the contact points (m/s, away from the ground positive)."""
    ox, oy, oz = rotate(y[Q], y[Q + 1], y[Q + 2], y[Q + 3], y[W], y[W + 1], y[W + 2])  # ω_W
    lowest = math.inf
    for c in range(count):
        rx, ry, rz = points[c, 0] - y[0], points[c, 1] - y[1], points[c, 2] - y[2]
        u = (nx * (y[V] + oy * rz - oz * ry) + ny * (y[V + 1] + oz * rx - ox * rz)
             + nz * (y[V + 2] + ox * ry - oy * rx))
        lowest = min(lowest, u)
    return lowest


@njit(**_OPTS)
def _cache_hit(cache, i, y, p, w, j, tracked):
    """True if body i's cache row is valid and was made for this ground, tracked features, state, parameters and wrench."""
    row = cache[i]
    if row[_VALID] == 0.0 or row[_GROUND] != j or row[_TRACKED] != tracked:
        return False
    for k in range(STATE_WIDTH):
        if row[_STATE + k] != y[k]:
            return False
    for k in range(PRM_WIDTH):  # the body's parameters; not the step's own caches in the row (NaN when empty)
        if (k < CACHE_RATE or AXIS_S <= k < TOP_KEY) and row[_PRM + k] != p[k]:
            return False
    for k in range(WRENCH_WIDTH):
        if row[_BARE + k] != w[k]:
            return False
    return True


@njit(**_OPTS)
def hold_all(Y, prm, wrenches, shapes, grounds, bodies, ground_of, tracked, friction, tangent_friction,
             first_tangent, slip_tolerance, lift_off_speed, touching_gap, bare, pressed, sliding, slide_direction,
             status, locked, cache):
    """Add each body's holding force (persistent.holding_wrench) to its wrench row; flag the ones that lift off, and
    those whose contact points move into the ground faster than ``lift_off_speed`` (struck there: the solver's).

    Body i's μ on plane row j is ``materials.material(friction, tangent_friction, first_tangent, i, j)``:
    ``friction`` (n, first_tangent) over the half-spaces and static box faces, ``tangent_friction`` (n,)
    on each body's own tangent row (empty without static shapes).

    ``bare[i]`` keeps body i's wrench row as it was before (for a step taken again in pieces).
    ``locked[i]`` ← 1 for a body locked for this step (module docstring), else 0; ``cache``
    (CACHE_WIDTH floats per body, zeros at first) holds what a locked body's hold found.
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
        locked[i] = 0
        if _cache_hit(cache, i, y, p, w, j, tracked[i]):  # the inputs of the last hold, bitwise: its result
            for k in range(WRENCH_WIDTH):
                bare[i, k] = w[k]
                w[k] = cache[i, _HELD + k]
            pressed[i] = np.int64(cache[i, _PRESSED])
            sliding[i] = False
            slide_direction[i, 0], slide_direction[i, 1] = 0.0, 0.0
            locked[i] = 1
            continue
        cache[i, _VALID] = 0.0
        count = held_points(y, p, w, shapes[i], ground, tracked[i], points, gaps, owners, d, True)
        if count == 0:
            status[i] = TO_SOLVER
            continue
        lowest = math.inf
        for c in range(count):
            lowest = min(lowest, gaps[c])
        normal_bias(y, p, shapes[i], ground, tracked[i], count, points, owners, bias, rdot, anchors)
        speed = _lowest_normal_speed(y, count, points, nx, ny, nz)
        mode, _, sx, sy = holding_wrench(y, p, w, count, points, nx, ny, nz,
                                         material(friction, tangent_friction, first_tangent, i, j), slip_tolerance,
                                         bias, rdot, work, d, force)
        if mode == LIFT_OFF or abs(speed) > lift_off_speed or lowest > touching_gap:  # lifting off, or driven in
            status[i] = TO_SOLVER
            continue
        sliding[i] = mode == SLIDE
        slide_direction[i, 0], slide_direction[i, 1] = sx, sy
        bits = 0
        for c in range(count):
            if work[3 * c, _LAM] > 0.0:
                bits |= 1 << owners[c]
        pressed[i] = bits
        for k in range(WRENCH_WIDTH):
            bare[i, k] = w[k]
        add_contact_wrench(w, y, p, count, points, anchors, work)
        if mode != STICK:
            continue
        at_rest = True
        for k in range(3):
            if y[V + k] != 0.0 or y[W + k] != 0.0:
                at_rest = False
        if not at_rest:
            continue
        derivative(y, p, w, d)
        held = 0.0
        for k in range(3):
            held = max(held, abs(d[V + k]), abs(d[W + k]))
        if held <= LOCK_ACCELERATION:  # at rest and held still: locked, and remembered
            locked[i] = 1
            cache[i, _VALID], cache[i, _GROUND], cache[i, _TRACKED], cache[i, _PRESSED] = 1.0, j, tracked[i], bits
            for k in range(STATE_WIDTH):
                cache[i, _STATE + k] = y[k]
            for k in range(PRM_WIDTH):
                cache[i, _PRM + k] = p[k]
            for k in range(WRENCH_WIDTH):
                cache[i, _BARE + k] = bare[i, k]
                cache[i, _HELD + k] = w[k]


@njit(**_OPTS)
def settle_all(Y0, Y, prm, shapes, grounds, bodies, ground_of, tracked, pressed, sliding, slide_direction, band, status,
               locked):
    """Project each body in persistent contact back onto it (persistent.project), unless its step had an event.

    A body locked by hold_all ends the step at its start row (Y0: the step's start buffer,
    Y: its end) and gets status LOCKED.

    Flagged for the solver instead: a slide whose slip reversed in the step, another ground
    reached, a feature not tracked that is now below the ground (or a can's end face come down:
    shapes.opposite_rim_gap), a tracked feature the holding force did not push on that moved off, and (its end
    row as it was) a body whose projection turned a feature not tracked into the ground.
    """
    points = np.empty((MAX_POINTS, 3))
    gaps = np.empty(MAX_POINTS)
    owners = np.zeros(MAX_POINTS, dtype=np.int64)
    features = np.empty(MAX_FEATURES)
    work = np.zeros(IMPACT_WORK_SHAPE)
    before = np.empty(STATE_WIDTH)
    for m in range(bodies.shape[0]):
        i = bodies[m]
        if locked[i]:
            for k in range(STATE_WIDTH):
                Y[i, k] = Y0[i, k]
            status[i] = LOCKED
            continue
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
        if opposite_rim_gap(Y0[i], y, p, shapes[i], ground, tracked[i], band[i]) < 0.0:  # a can's end face came down
            status[i] = TO_SOLVER
        if status[i] == OK:
            for k in range(STATE_WIDTH):
                before[k] = y[k]
            project(y, p, shapes[i], ground, tracked[i], not sliding[i], points, gaps, owners, work)
            count = feature_gaps(y, p, shapes[i], ground, features)
            for k in range(count):  # a feature not tracked that the projection turned into the ground: the solver's
                if not tracked[i] & (1 << k) and features[k] < -band[i]:
                    status[i] = TO_SOLVER
            if status[i] != OK:
                for k in range(STATE_WIDTH):
                    y[k] = before[k]


# ----------------------------------------------------------------- the bookkeeping around the passes
# (one compiled call each instead of a handful of numpy operations per step: the solver's Python layer)


@njit(**_OPTS)
def split_bodies(bodies, modes, stopped, done, other_ground, flying, one, two):
    """Sort the ``bodies`` neither stopped nor done (``done``: a mask over all bodies) by mode, keeping their order:
    in flight into ``flying``, in persistent contact on one ground or static plane into ``one``, on two half-spaces
    (other_ground ≥ 0, two_grounds.py) into ``two``. Returns (n_flying, n_one, n_two)."""
    n_flying = n_one = n_two = 0
    for m in range(bodies.shape[0]):
        i = bodies[m]
        if stopped[i] or done[i]:
            continue
        if modes[i] == FLIGHT:
            flying[n_flying] = i
            n_flying += 1
        elif modes[i] == PERSISTENT:
            if other_ground[i] >= 0:
                two[n_two] = i
                n_two += 1
            else:
                one[n_one] = i
                n_one += 1
    return n_flying, n_one, n_two


@njit(**_OPTS)
def record_holds(bodies, modes, wrenches, bare, holding_forces):
    """For each of ``bodies`` still in persistent contact: its contact force, world axes (its wrench row's forces
    less the ``bare`` row's), into ``holding_forces``."""
    for m in range(bodies.shape[0]):
        i = bodies[m]
        if modes[i] != PERSISTENT:
            continue
        for k in range(3):
            holding_forces[i, k] = ((wrenches[i, F_WORLD + k] - bare[i, F_WORLD + k])
                                    + (wrenches[i, F_COM_W + k] - bare[i, F_COM_W + k]))


@njit(**_OPTS)
def gravity_gains(Y0, Y1, prm, bodies, status, bare, rose):
    """Of the ``bodies`` with status OK under gravity alone (their ``bare`` rows empty), those whose energy
    (kinetic less m g·p) rose over the step (Y0 → Y1) by more than 1e-12 of itself: into ``rose``, in ``bodies``'
    order. Returns their count."""
    n = 0
    for m in range(bodies.shape[0]):
        i = bodies[m]
        if status[i] != OK or bare[i, ACTIVE] != 0.0:
            continue
        e0 = kinetic_energy_row(Y0[i], prm[i]) + potential_energy_row(Y0[i], prm[i])
        e1 = kinetic_energy_row(Y1[i], prm[i]) + potential_energy_row(Y1[i], prm[i])
        if e1 > e0 + 1e-12 * abs(e0) + 1e-300:
            rose[n] = i
            n += 1
    return n


@njit(**_OPTS)
def fast_rims(Y0, prm, shapes, grounds, bodies, ground_of, tracked, turn, out):
    """Into ``out``, the ``bodies`` whose rim contact point turns faster than ``turn`` (rad/s) at the step's start
    (persistent.rim_turn_rate at Y0 on their ground row, of their tracked features), in ``bodies``' order.
    Returns their count."""
    n = 0
    for m in range(bodies.shape[0]):
        i = bodies[m]
        if rim_turn_rate(Y0[i], prm[i], shapes[i], grounds[ground_of[i]], tracked[i]) > turn:
            out[n] = i
            n += 1
    return n


@njit(**_OPTS)
def busy_bodies(resting, status, two, flying, lowest, out):
    """Into ``out``, the bodies whose step needs the solver in Python: the ``resting`` ones flagged TO_SOLVER, then
    ``two``, then the ``flying`` ones whose lowest gap (``lowest[k]``, of ``flying[k]``) is below 0. Returns their
    count."""
    n = 0
    for m in range(resting.shape[0]):
        if status[resting[m]] == TO_SOLVER:
            out[n] = resting[m]
            n += 1
    for m in range(two.shape[0]):
        out[n] = two[m]
        n += 1
    for m in range(flying.shape[0]):
        if lowest[m] < 0.0:
            out[n] = flying[m]
            n += 1
    return n
