"""Compiled swept broad phase that keeps the pairs of the members whose paths did not change since its last call.

grid_swept_pairs lists the members' pairs member by member (box_pairs: a movable member's own cell and its 13
forward cells, a fixed member against every movable one) and spheres_may_meet keeps those whose bounding spheres
can meet over the step (kernels/contact/swept.py). What member i lists is a function of the grid's cell edge, the
step h, the half-spaces, and the keys of i and of the members filed in those 14 cells: each one's position and
velocity at the step's two ends and its radius (KEY_WIDTH numbers), which give its box (swept_bounds) and its
sphere's path. :func:`kept_swept_pairs` lists again only the members whose own key changed bitwise, and those
whose 14 cells hold (or held) a changed member whose box overlaps (or overlapped) theirs; it copies the others'
pairs from its last call: the same pairs, in the same order, as the two would give. A scene asleep but for a few
bodies costs a pass over the keys and the grid's filing, and the pairs of the few.
"""

from __future__ import annotations

from numba import njit

from ..jit import INLINE, JIT
from ..layout import P, V
from .swept import box_pairs, cell_key, file_grid, forward_cell, keep_meeting

__all__ = ["KEY_WIDTH", "kept_swept_pairs"]

#: Every member is listed again, without marking, when more than 1 / CHANGED_MOST of them changed.
CHANGED_MOST = 8

#: A member's key: its position and velocity at the step's start and end (m, m/s; world), its radius (m).
KEY_WIDTH = 13


@njit(**INLINE)
def _key_changed(Y0, Y1, members, radius, keys, m):
    """Whether member m's key differs bitwise from keys[m] (a NaN always does)."""
    i = members[m]
    same = keys[m, 12] == radius[m]
    for a in range(3):
        same = (same and keys[m, a] == Y0[i, P + a] and keys[m, 3 + a] == Y0[i, V + a]
                and keys[m, 6 + a] == Y1[i, P + a] and keys[m, 9 + a] == Y1[i, V + a])
    _pin = Y0[0, 0], Y1[0, 0], keys[0, 0]  # (jit.py's rule)
    return not same


@njit(**INLINE)
def _meets(lo, hi, j, blo, bhi, d):
    """Whether box j of (lo, hi) and box d of (blo, bhi) overlap on all three axes (grid_swept_pairs' test)."""
    return (lo[j, 0] <= bhi[d, 0] and blo[d, 0] <= hi[j, 0] and lo[j, 1] <= bhi[d, 1] and blo[d, 1] <= hi[j, 1]
            and lo[j, 2] <= bhi[d, 2] and blo[d, 2] <= hi[j, 2])


@njit(**INLINE)
def _mark_met(d, cx, cy, cz, lo, hi, last_lo, last_hi, cells, heads, chain, marks):
    """Marks the members whose pairs moved member d may be in, or was: those filed in a cell of whose 14 the cell
    (cx, cy, cz) is one (d's now or at the last call), whose box overlaps d's box now or at the last call; returns
    how many it newly marked. (A member not so marked lists no pair with d, now or then.)"""
    mask = heads.shape[0] - 1
    marked = 0
    for nb in range(14):
        dx, dy, dz = forward_cell(nb)
        ox, oy, oz = cx - dx, cy - dy, cz - dz
        j = heads[cell_key(ox, oy, oz, mask)]
        while j >= 0:
            if (cells[j, 0] == ox and cells[j, 1] == oy and cells[j, 2] == oz and marks[j] == 0
                    and (_meets(lo, hi, j, lo, hi, d) or _meets(lo, hi, j, last_lo, last_hi, d))):
                marks[j] = 2
                marked += 1
            j = chain[j]
    _pin = lo[0, 0], hi[0, 0], last_lo[0, 0], last_hi[0, 0], cells[0, 0], heads[0], chain[0], marks[0]
    return marked


@njit(**JIT)
def kept_swept_pairs(Y0, Y1, members, radius, h, grounds, movable, fixed, lo, hi, cells, heads, chain, pairs, state,
                     keys, last_lo, last_hi, last_cells, blocks, last_pairs, starts, marks):
    """The pairs (rows m < k of members) grid_swept_pairs then spheres_may_meet would keep for the boxes lo, hi
    (M, 3; swept_bounds' of Y0, Y1, members, radius (M,; m), h (s), which the caller wrote), the half-spaces
    ``grounds``, into pairs (capacity, 2); returns how many. ``fixed``: the rows of the members not ``movable``.
    The grid (cells, heads, chain) is left as grid_swept_pairs leaves it.

    Kept between calls (owned by the caller, the same arrays each call): state (4,): 1 once a call succeeded, the
    grid's cell edge (m) and h then, and how many members it listed again; keys (M, KEY_WIDTH); last_lo, last_hi
    (M, 3), the boxes then; last_cells (M, 3) int64, the cells then; blocks (M + 1,) int64, where each member's
    pairs began in last_pairs (capacity, 2), the pairs then. Scratch: starts (M + 1,),
    marks (M,) int64. Every member is listed again when there was no successful call, when the cell edge or h
    changed, or when more than half of them would be. When pairs is too short, returns −(a length that is enough)
    and keeps nothing: call again with pairs and last_pairs that long (the kept ones lost: state[0] = 0). Every
    member is listed again, too, when more than 1 / CHANGED_MOST of them changed."""
    n = members.shape[0]
    cell = file_grid(lo, hi, movable, cells, heads, chain)
    fresh = state[0] != 1.0 or state[1] != cell or state[2] != h
    for m in range(n):
        marks[m] = 0
    changed = 0
    if not fresh:
        for d in range(n):
            if _key_changed(Y0, Y1, members, radius, keys, d):
                marks[d] = 1
                changed += 1
        fresh = CHANGED_MOST * changed > n  # (a pile awake: listing them all costs less than marking)
    if not fresh:
        marked = changed
        for d in range(n):
            if marks[d] == 1 and movable[d]:  # changed (those it marks get 2)
                same = (last_cells[d, 0] == cells[d, 0] and last_cells[d, 1] == cells[d, 1]
                        and last_cells[d, 2] == cells[d, 2])
                if not same:
                    marked += _mark_met(d, last_cells[d, 0], last_cells[d, 1], last_cells[d, 2], lo, hi, last_lo,
                                        last_hi, cells, heads, chain, marks)
                marked += _mark_met(d, cells[d, 0], cells[d, 1], cells[d, 2], lo, hi, last_lo, last_hi, cells,
                                    heads, chain, marks)
                for k in range(fixed.shape[0]):  # a fixed member lists its pairs with every movable one
                    f = fixed[k]
                    if marks[f] == 0 and (_meets(lo, hi, f, lo, hi, d) or _meets(lo, hi, f, last_lo, last_hi, d)):
                        marks[f] = 2
                        marked += 1
            if 2 * marked > n:  # listing them all costs less
                break
        fresh = 2 * marked > n
    listed = 0
    capacity = pairs.shape[0]
    count = 0
    over = False
    for m in range(n):
        starts[m] = count
        if fresh or marks[m]:
            listed += 1
            top = box_pairs(m, lo, hi, movable, cells, heads, chain, pairs, count)
            over = over or top > capacity
            if over:
                count = top
            else:  # spheres_may_meet's test, in place
                count = keep_meeting(Y0, Y1, members, radius, h, grounds, pairs, count, top)
        else:
            for k in range(blocks[m], blocks[m + 1]):
                if count < capacity:
                    pairs[count, 0], pairs[count, 1] = last_pairs[k, 0], last_pairs[k, 1]
                count += 1
    starts[n] = count
    over = over or count > capacity
    if not over:
        for m in range(n + 1):
            blocks[m] = starts[m]
        for k in range(count):
            last_pairs[k, 0], last_pairs[k, 1] = pairs[k, 0], pairs[k, 1]
        for m in range(n):
            i = members[m]
            for a in range(3):
                keys[m, a], keys[m, 3 + a] = Y0[i, P + a], Y0[i, V + a]
                keys[m, 6 + a], keys[m, 9 + a] = Y1[i, P + a], Y1[i, V + a]
                last_lo[m, a], last_hi[m, a], last_cells[m, a] = lo[m, a], hi[m, a], cells[m, a]
            keys[m, 12] = radius[m]
        state[0], state[1], state[2], state[3] = 1.0, cell, h, listed
    _pin = Y0[0, 0], Y1[0, 0], members[0], radius[0], grounds.shape[0], movable[0], lo[0, 0], hi[0, 0], cells[0, 0]
    _pin2 = heads[0], chain[0], pairs[0, 0], state[0], keys[0, 0], last_cells[0, 0], blocks[0], last_pairs[0, 0]
    _pin4 = last_lo[0, 0], last_hi[0, 0], fixed[:1]
    _pin3 = starts[0], marks[0]
    return -count if over else count
