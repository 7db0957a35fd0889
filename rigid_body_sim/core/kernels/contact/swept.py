"""Compiled swept broad phase of the body–body pass: the boxes bodies sweep over a step, and their overlaps.

After each step the solver (core/contact/body_pairs.py) looks for pairs of shapes that may have
met inside the step, not only at its end, so that a small fast body cannot pass through a thin
one unseen. :func:`swept_bounds` writes, for each shape, a world-axis box that holds its
bounding sphere (radius ``reach``, about the centre of mass) all along the step: the box of the
sphere at the step's start and end, grown by ``|v₁ − v₀| h / 4``, twice the furthest a path of
constant acceleration strays from its chord (|a| h²/8 = |Δv| h/8). :func:`grid_swept_pairs` files each movable box
under the cell of its centre in a hashed uniform grid (cell = the largest movable box's widest
side, so two overlapping boxes sit in the same or neighbouring cells) and writes every
overlapping pair: about linear in the number of shapes while the moving ones have comparable
sizes (one huge box, a very fast body's sweep, makes every cell huge). The fixed boxes (static
shapes, any size) are tested against every movable box: S × N tests for S of them.
No allocation: the caller owns every array, so a step without any candidate pair
costs two compiled loops over the shapes and nothing else.
"""

from __future__ import annotations

import math

from numba import njit

from ..jit import INLINE, JIT
from ..layout import P, V

__all__ = ["swept_bounds", "grid_swept_pairs"]


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


@njit(**INLINE)
def _cell_key(cx, cy, cz, mask):
    return ((cx * 73856093) ^ (cy * 19349663) ^ (cz * 83492791)) & mask


@njit(**JIT)
def grid_swept_pairs(lo, hi, movable, cells, heads, chain, pairs):
    """Overlapping boxes (lo, hi (M, 3)) into pairs (capacity, 2) as rows (m, k), m < k, from a hashed grid.

    Each movable shape meets those of its own cell and of the 13 neighbouring cells on one side
    (the other 13 see it from theirs): every overlapping pair once.

    Scratch owned by the caller: cells (M, 3) int64, heads (2^p ≥ M,) int64 (the hash table),
    chain (M,) int64. Only movable members are filed in the grid; each one that is not is
    tested against every movable one (a pair of two fixed members is never written). Returns
    the number found (beyond the capacity only the first ``capacity`` are written).
    """
    n = lo.shape[0]
    cell = 0.0
    for i in range(n):
        if movable[i]:
            for k in range(3):
                cell = max(cell, hi[i, k] - lo[i, k])
    if not cell > 0.0:
        cell = 1.0
    mask = heads.shape[0] - 1
    for b in range(heads.shape[0]):
        heads[b] = -1
    for i in range(n):
        if movable[i]:
            for k in range(3):
                cells[i, k] = int(math.floor(0.5 * (lo[i, k] + hi[i, k]) / cell))
            key = _cell_key(cells[i, 0], cells[i, 1], cells[i, 2], mask)
            chain[i] = heads[key]
            heads[key] = i
    count = 0
    capacity = pairs.shape[0]
    for i in range(n):
        if not movable[i]:  # a fixed box: against every movable one
            for j in range(n):
                if (movable[j] and lo[j, 0] <= hi[i, 0] and lo[i, 0] <= hi[j, 0] and lo[j, 1] <= hi[i, 1]
                        and lo[i, 1] <= hi[j, 1] and lo[j, 2] <= hi[i, 2] and lo[i, 2] <= hi[j, 2]):
                    if count < capacity:
                        pairs[count, 0], pairs[count, 1] = min(i, j), max(i, j)
                    count += 1
            continue
        for nb in range(14):  # its own cell, then the 13 neighbours "after" it (each neighbour pair once)
            dx, dy, dz = 0, 0, 0
            if nb > 0:
                code = nb + 13  # 14 … 26: the offsets (dx, dy, dz) ∈ {−1, 0, 1}³ after (0, 0, 0) in base 3
                dx, dy, dz = code % 3 - 1, (code // 3) % 3 - 1, code // 9 - 1
            cx, cy, cz = cells[i, 0] + dx, cells[i, 1] + dy, cells[i, 2] + dz
            j = heads[_cell_key(cx, cy, cz, mask)]
            while j >= 0:
                if ((nb > 0 or j > i) and cells[j, 0] == cx and cells[j, 1] == cy and cells[j, 2] == cz
                        and lo[j, 0] <= hi[i, 0] and lo[i, 0] <= hi[j, 0] and lo[j, 1] <= hi[i, 1]
                        and lo[i, 1] <= hi[j, 1] and lo[j, 2] <= hi[i, 2] and lo[i, 2] <= hi[j, 2]):
                    if count < capacity:
                        pairs[count, 0], pairs[count, 1] = min(i, j), max(i, j)
                    count += 1
                j = chain[j]
    _pin = lo[0, 0], hi[0, 0], movable[0], cells[0, 0], heads[0], chain[0], pairs[0, 0]
    return count
