"""Compile (or load from numba's cache) the body–body contact kernels with the argument types they are called with.

Called from ``compile_kernels()`` (core/simulator.py: ``make venv``, the node's first start),
under the cache's lock, so that neither a scene load nor a test pays for compiling them. Each
function of :data:`PAIR_ENTRY_POINTS` is called once on a small batch built as its callers
build theirs: :func:`~rigid_body_sim.core.contact.query.overlapping_bodies` (C-ordered float64
arrays, int64 pairs) and the narrow phase also on a strided view of the pairs (a reversed
``pairs[:, ::-1]``). This module compiles nothing of its own (it lives outside
core/kernels/, so editing it keeps the kernel cache); test_kernel_cache.py checks that the
query adds no signature afterwards.
"""

from __future__ import annotations

import numpy as np

from ..kernels.contact.broadphase import grid_pairs, shape_aabbs, sweep_pairs
from ..kernels.contact.impacts import IMPACT_WORK_SHAPE
from ..kernels.contact.kept_pairs import kept_swept_pairs
from ..kernels.contact.layout import (DIMS, GROUND_WIDTH, KIND, SHAPE_BOX, SHAPE_CAPSULE, SHAPE_CYLINDER, SHAPE_SPHERE,
                                     SHAPE_WIDTH)
from ..kernels.contact.pair_impacts import PAIR_JACOBIAN_SHAPE, normal_speed, pair_impact
from ..kernels.contact.pairs import MAX_PAIR_POINTS, apart_bounds, pair_contacts
from ..kernels.contact.swept import (deflections, grid_swept_pairs, left_pairs, screen_pairs, spheres_may_meet,
                                     swept_bounds)
from ..kernels.layout import INERTIA, INV_INERTIA, INV_MASS, MASS, PRM_WIDTH, P, Q, STATE_WIDTH, V
from .swept_pairs import SweptPairs

__all__ = ["PAIR_ENTRY_POINTS", "compile_pair_kernels"]

#: The body–body contact kernels called from Python.
PAIR_ENTRY_POINTS = (shape_aabbs, grid_pairs, sweep_pairs, pair_contacts, apart_bounds, pair_impact, normal_speed,
                     swept_bounds, grid_swept_pairs, spheres_may_meet, kept_swept_pairs, left_pairs, screen_pairs)


def compile_pair_kernels() -> None:
    """Call each of :data:`PAIR_ENTRY_POINTS` once with the argument types its callers use."""
    kinds = (SHAPE_SPHERE, SHAPE_BOX, SHAPE_CYLINDER, SHAPE_CAPSULE)
    n = len(kinds)
    shapes = np.zeros((n, SHAPE_WIDTH))
    shapes[:, KIND] = kinds
    shapes[:, DIMS:DIMS + 3] = 0.1
    pos = np.zeros((n, 3))
    pos[:, 0] = 0.15 * np.arange(n)  # neighbours touch: every kind meets another
    quat = np.zeros((n, 4))
    quat[:, 0] = 1.0
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    shape_aabbs(pos, quat, shapes, lo, hi)
    pairs = np.empty((n * n, 2), dtype=np.int64)
    sweep_pairs(lo, hi, 0.0, pairs)
    found = grid_pairs(lo, hi, 0.0, pairs)
    pairs = np.ascontiguousarray(pairs[:found])
    for batch in (pairs, pairs[:, ::-1]):
        m = len(batch)
        pair_contacts(pos, quat, shapes, batch, np.empty(m), np.empty((m, 3)), np.zeros(m, dtype=np.int64),
                      np.empty((m, MAX_PAIR_POINTS, 6)), np.empty((m, MAX_PAIR_POINTS)))
    apart_bounds(pos, quat, shapes, pairs, np.empty(len(pairs)))
    # the solver's body–body pass (body_pairs.py): state rows of the simulator's buffers, int64 members
    Ys = np.zeros((2, n, STATE_WIDTH + 1))
    members = np.arange(n, dtype=np.int64)
    swept_bounds(Ys[0], Ys[1], members, np.full(n, 0.1), 1e-3, lo, hi)
    swept = np.empty((4 * n, 2), dtype=np.int64)
    cells, heads, chain = np.empty((n, 3), dtype=np.int64), np.empty(16, dtype=np.int64), np.empty(n, dtype=np.int64)
    movable = np.ones(n, dtype=np.bool_)
    found = grid_swept_pairs(lo, hi, movable, cells, heads, chain, swept)
    spheres_may_meet(Ys[0], Ys[1], members, np.full(n, 0.1), 1e-3, np.zeros((1, GROUND_WIDTH)), swept, found)
    SweptPairs(members, movable, lo, hi, cells, heads, chain).find(Ys[0], Ys[1], np.full(n, 0.1), 1e-3,
                                                                   np.zeros((1, GROUND_WIDTH)))
    prm_rows = np.ones((n, PRM_WIDTH))
    deflections(Ys[0], Ys[1], prm_rows, members, movable, swept, found, 1e-3, np.zeros(n), np.full(n, 0.1),
                np.empty(n), np.zeros(n))
    left_pairs(Ys[0], Ys[1], members, np.full(n, 0.1), 1e-3, lo, hi, movable, np.zeros(0, dtype=np.int64),
               np.zeros(n, dtype=np.bool_), cells, heads, chain, np.empty((n, 3)), np.empty((n, 3)),
               np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64), swept)
    Ys[:, :, Q] = 1.0
    k = len(pairs)
    screen_pairs(Ys[0], Ys[1], quat.copy(), shapes, np.full(n, 0.1), pairs, 1e-3, np.zeros((2, n, 3)),
                 np.zeros((2, n, 4)), np.empty((k, 2), dtype=np.int64), np.empty(k, dtype=np.int64), np.empty(1),
                 np.empty(k), np.empty((k, 3)), np.zeros(k, dtype=np.int64), np.empty((k, MAX_PAIR_POINTS, 6)),
                 np.empty((k, MAX_PAIR_POINTS)), np.empty(k), np.empty(k), np.empty(k))
    y = np.zeros(STATE_WIDTH + 1)
    y[Q] = 1.0
    prm = np.zeros(PRM_WIDTH)
    prm[MASS] = prm[INV_MASS] = 1.0
    prm[INERTIA:INERTIA + 3] = prm[INV_INERTIA:INV_INERTIA + 3] = 1.0
    y_b = y.copy()
    y_b[P], y_b[V] = 0.2, -1.0  # b, 0.2 m along x, approaching a
    points = np.array([[0.1, 0.0, 0.0]])  # world, m
    pair_impact(y, y.copy(), prm, y_b, y_b.copy(), prm.copy(), 1, points, 1.0, 0.0, 0.0, 0.5, 0.5,
                np.zeros(PAIR_JACOBIAN_SHAPE), np.zeros(IMPACT_WORK_SHAPE))
    normal_speed(y, y_b, 1.0, 0.0, 0.0, 0.1, 0.0, 0.0)
