"""Compiled swept broad phase of the body–body pass: the boxes bodies sweep over a step, and their overlaps.

After each step the solver (core/contact/body_pairs.py) looks for pairs of shapes that may have
met inside the step, not only at its end, so that a small fast body cannot pass through a thin
one unseen. :func:`swept_bounds` writes, for each shape, a world-axis box that holds its
bounding sphere (radius ``reach``, about the centre of mass) all along the step: the box of the
sphere at the step's start and end, grown by ``|v₁ − v₀| h / 4``, twice the furthest a path of
constant acceleration strays from its chord (|a| h²/8 = |Δv| h/8). :func:`swept_pairs` sorts the
boxes along one world axis by insertion sort of an order kept from the step before (nearly
sorted: about linear), sweeps once, and writes every overlapping pair with at least one
movable shape. No allocation: the caller owns every array, so a step without any candidate
pair costs two compiled loops over the shapes and nothing else.
"""

from __future__ import annotations

import math

from numba import njit

from ..jit import JIT
from ..layout import P, V

__all__ = ["swept_bounds", "swept_pairs"]


@njit(**JIT)
def swept_bounds(Y0, Y1, members, reach, h, lo, hi):
    """lo, hi (M, 3) ← the world box (m) body members[m]'s bounding sphere stays in over the step.

    Y0, Y1: state rows at the step's start and end (layout.py: p_WC_W at P, v_WC_W at V);
    members (M,) body indices; reach (M,) bounding radii (m) about the centre of mass; h (s).
    """
    for m in range(members.shape[0]):
        i = members[m]
        dvx, dvy, dvz = Y1[i, V] - Y0[i, V], Y1[i, V + 1] - Y0[i, V + 1], Y1[i, V + 2] - Y0[i, V + 2]
        grow = reach[m] + 0.25 * h * math.sqrt(dvx * dvx + dvy * dvy + dvz * dvz)
        for k in range(3):
            a, b = Y0[i, P + k], Y1[i, P + k]
            lo[m, k] = min(a, b) - grow
            hi[m, k] = max(a, b) + grow


@njit(**JIT)
def swept_pairs(lo, hi, order, axis, movable, pairs):
    """Overlapping boxes (lo, hi (M, 3)) into pairs (capacity, 2) as rows (m, k) of member indices, m < k.

    ``order`` (M,) is a permutation of 0 … M − 1, sorted here in place by lo[:, axis] (insertion
    sort: fast when it is the order of the step before); a pair of two members that are not
    ``movable`` (M,) is skipped. Returns the number found; beyond the capacity only the first
    ``capacity`` are written (call again with a larger array).
    """
    n = order.shape[0]
    for s in range(1, n):
        j = order[s]
        key = lo[j, axis]
        t = s - 1
        while t >= 0 and lo[order[t], axis] > key:
            order[t + 1] = order[t]
            t -= 1
        order[t + 1] = j
    count = 0
    capacity = pairs.shape[0]
    for s in range(n):
        i = order[s]
        for t in range(s + 1, n):
            j = order[t]
            if lo[j, axis] > hi[i, axis]:
                break
            if (movable[i] or movable[j]) and lo[j, 0] <= hi[i, 0] and lo[i, 0] <= hi[j, 0] \
                    and lo[j, 1] <= hi[i, 1] and lo[i, 1] <= hi[j, 1] and lo[j, 2] <= hi[i, 2] and lo[i, 2] <= hi[j, 2]:
                if count < capacity:
                    pairs[count, 0], pairs[count, 1] = min(i, j), max(i, j)
                count += 1
    _pin = lo[0, 0], hi[0, 0], order[0], movable[0], pairs[0, 0]
    return count
