"""Compiled broad phase: world-axis bounding boxes of the shapes, then sort and sweep on one axis.

:func:`shape_aabbs` writes each shape's tight axis-aligned bounding box (closed forms: a box's
half widths |R| a, a capsule's |u| h + r, a cylinder's r √(1 − u_i²) + h |u_i| per world axis i,
u its axis). :func:`sweep_pairs` sorts the boxes by their lower bound on the axis along which
the centres spread most and sweeps once: every pair whose boxes overlap on all three axes
(grown by ``margin``, m) is written, as (a, b) with a < b. The cost is the sort (N log N) plus
the pairs that overlap on the sweep axis, about linear in N at a fixed density.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..jit import JIT
from ..rotation import matrix
from .layout import DIMS, KIND, SHAPE_BOX, SHAPE_CAPSULE, SHAPE_CYLINDER, SHAPE_SPHERE

__all__ = ["shape_aabbs", "sweep_pairs", "grid_pairs"]


@njit(**JIT)
def shape_aabbs(pos, quat, shapes, lo, hi):
    """lo, hi (N, 3) ← the world bounding box of each shape (pos (N, 3), quat (N, 4) w, x, y, z; m).

    A shape of kind SHAPE_NONE gets an empty box (lo = +inf, hi = −inf): it pairs with nothing.
    """
    for i in range(pos.shape[0]):
        kind = int(shapes[i, KIND])
        a0, a1, a2 = shapes[i, DIMS], shapes[i, DIMS + 1], shapes[i, DIMS + 2]
        r = matrix(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3])
        for k in range(3):
            half = -math.inf
            if kind == SHAPE_SPHERE:
                half = a0
            elif kind == SHAPE_BOX:
                half = abs(r[3 * k]) * a0 + abs(r[3 * k + 1]) * a1 + abs(r[3 * k + 2]) * a2
            elif kind == SHAPE_CAPSULE:
                half = abs(r[3 * k + 2]) * a1 + a0
            elif kind == SHAPE_CYLINDER:
                u = r[3 * k + 2]
                half = a0 * math.sqrt(max(0.0, 1.0 - u * u)) + a1 * abs(u)
            lo[i, k] = pos[i, k] - half
            hi[i, k] = pos[i, k] + half


@njit(**JIT)
def sweep_pairs(lo, hi, margin, pairs):
    """Candidate pairs of overlapping boxes (lo, hi (N, 3), grown by margin) into pairs (capacity, 2).

    Returns the number of candidate pairs found; if it exceeds the capacity, only the first
    ``capacity`` are written and the caller should call again with a larger array.
    """
    n = lo.shape[0]
    # the axis along which the centres spread most
    axis = 0
    spread = -1.0
    for k in range(3):
        mean = 0.0
        for i in range(n):
            mean += lo[i, k] + hi[i, k]
        mean /= max(2 * n, 1)
        var = 0.0
        for i in range(n):
            d = 0.5 * (lo[i, k] + hi[i, k]) - mean
            var += d * d
        if var > spread:
            spread, axis = var, k
    keys = np.empty(n)
    for i in range(n):
        keys[i] = lo[i, axis]
    order = np.argsort(keys)
    count = 0
    capacity = pairs.shape[0]
    for s in range(n):
        i = order[s]
        if not lo[i, 0] <= hi[i, 0]:  # empty box (no shape)
            continue
        end = hi[i, axis] + 2.0 * margin
        for t in range(s + 1, n):
            j = order[t]
            if lo[j, axis] > end:
                break
            overlap = True
            for k in range(3):
                if lo[j, k] > hi[i, k] + 2.0 * margin or lo[i, k] > hi[j, k] + 2.0 * margin:
                    overlap = False
            if overlap:
                if count < capacity:
                    pairs[count, 0], pairs[count, 1] = min(i, j), max(i, j)
                count += 1
    return count


@njit(**JIT)
def _bucket(ix, iy, iz, dims, mask):
    """The bucket of cell (ix, iy, iz): its row-major index in a dense grid of dims cells, or a hash."""
    if dims[0] > 0:
        key = -1
        if 0 <= ix < dims[0] and 0 <= iy < dims[1] and 0 <= iz < dims[2]:
            key = ix + dims[0] * (iy + dims[1] * iz)
        return key
    return ((ix * 73856093) ^ (iy * 19349663) ^ (iz * 83492791)) & mask


@njit(**JIT)
def grid_pairs(lo, hi, margin, pairs):
    """Candidate pairs of overlapping boxes (lo, hi (N, 3), grown by margin) from a uniform grid.

    The cell is the largest box's widest side (+ 2 margin), each shape is filed under the cell
    of its centre, and each shape meets only the shapes of its own and the 26 neighbouring
    cells: linear in N at a fixed density (one huge shape makes every cell huge: keep shapes of
    comparable size, or use :func:`sweep_pairs`). The grid is dense (cells in row-major order)
    when it has at most 8 N cells, else hashed. Same output as :func:`sweep_pairs`.
    """
    n = lo.shape[0]
    cell = 0.0
    low = np.full(3, math.inf)
    high = np.full(3, -math.inf)
    for i in range(n):
        if lo[i, 0] <= hi[i, 0]:
            for k in range(3):
                cell = max(cell, hi[i, k] - lo[i, k])
                c = 0.5 * (lo[i, k] + hi[i, k])
                low[k] = min(low[k], c)
                high[k] = max(high[k], c)
    cell += 2.0 * margin
    if cell <= 0.0:
        cell = 1.0
    dims = np.zeros(3, np.int64)
    total = 1.0
    for k in range(3):
        total *= max(1.0, math.floor((high[k] - low[k]) / cell) + 1.0) if high[k] >= low[k] else 1.0
    size = 1
    mask = 0
    if total <= 8.0 * max(n, 1):
        for k in range(3):
            dims[k] = int(math.floor((high[k] - low[k]) / cell)) + 1 if high[k] >= low[k] else 1
        size = int(total)
    else:
        while size < 2 * n:
            size *= 2
        mask = size - 1
    cells = np.empty((n, 3), np.int64)
    start = np.zeros(size + 1, np.int64)
    for i in range(n):
        if lo[i, 0] <= hi[i, 0]:
            for k in range(3):
                cells[i, k] = int(math.floor((0.5 * (lo[i, k] + hi[i, k]) - low[k]) / cell))
            start[_bucket(cells[i, 0], cells[i, 1], cells[i, 2], dims, mask) + 1] += 1
    for b in range(size):
        start[b + 1] += start[b]
    fill = start[:size].copy()
    members = np.empty(n, np.int64)
    for i in range(n):
        if lo[i, 0] <= hi[i, 0]:
            b = _bucket(cells[i, 0], cells[i, 1], cells[i, 2], dims, mask)
            members[fill[b]] = i
            fill[b] += 1
    # the boxes and cells in bucket order, so that a cell's shapes are read from contiguous memory
    filed = start[size]
    box = np.empty((filed, 6))
    where = np.empty((filed, 3), np.int64)
    for m in range(filed):
        i = members[m]
        for k in range(3):
            box[m, k], box[m, 3 + k] = lo[i, k], hi[i, k]
            where[m, k] = cells[i, k]
    count = 0
    capacity = pairs.shape[0]
    grow = 2.0 * margin
    for p in range(filed):
        i = members[p]
        for dz in range(-1, 2):
            for dy in range(-1, 2):
                for dx in range(-1, 2):
                    cx, cy, cz = where[p, 0] + dx, where[p, 1] + dy, where[p, 2] + dz
                    b = _bucket(cx, cy, cz, dims, mask)
                    if b < 0:
                        continue
                    for m in range(start[b], start[b + 1]):
                        j = members[m]
                        if j <= i or where[m, 0] != cx or where[m, 1] != cy or where[m, 2] != cz:
                            continue
                        if (box[m, 0] <= box[p, 3] + grow and box[p, 0] <= box[m, 3] + grow
                                and box[m, 1] <= box[p, 4] + grow and box[p, 1] <= box[m, 4] + grow
                                and box[m, 2] <= box[p, 5] + grow and box[p, 2] <= box[m, 5] + grow):
                            if count < capacity:
                                pairs[count, 0], pairs[count, 1] = i, j
                            count += 1
    return count
