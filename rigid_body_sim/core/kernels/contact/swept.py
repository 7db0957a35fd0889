"""Compiled swept broad phase of the body–body pass: the boxes bodies sweep over a step, and their overlaps.

After each step the solver (core/contact/body_pairs.py) looks for pairs of shapes that may have
met inside the step, not only at its end, so that a small fast body cannot pass through a thin
one unseen. :func:`swept_bounds` writes, for each shape, a world-axis box that holds its
bounding sphere (radius ``reach``, about the centre of mass) all along the step: the box of the
sphere at the step's start and end, grown by ``GROWTH × |v₁ − v₀| h`` (GROWTH = 1): eight times the furthest a
path of constant acceleration strays from its chord (|a| h²/8 = |Δv| h/8), and as far as an island's step, whose
contacts cancel the step's change of velocity (a body held at rest: p₀ + h v₀ against the free step's
p₀ + h v₀ + h² a/2 or, semi-implicit Euler's, + h² a), moves its end (kernels/contact/island._late_pairs: a body an
island's step moves farther from its free step's end than that is screened again). :func:`grid_swept_pairs` files each movable box
under the cell of its centre in a hashed uniform grid (cell = the largest movable box's widest
side, so two overlapping boxes sit in the same or neighbouring cells) and writes every
overlapping pair: about linear in the number of shapes while the moving ones have comparable
sizes (one huge box, a very fast body's sweep, makes every cell huge). The fixed boxes (static
shapes, any size) are tested against every movable box: S × N tests for S of them.
:func:`spheres_may_meet` keeps of these the pairs whose bounding spheres can meet over the step
(boxes overlap where spheres do not: every diagonal neighbour of a lattice), a body that a half-space
may stop within the step taken anywhere on its chord (the ground's pass, after this one, changes its
path). :func:`deflections` bounds what a hit between two candidates may change each one's velocity by, and
the broad phase is taken again with each sphere grown by h × that. :func:`left_pairs` looks again after the step's passes: the bodies an event sent out of their
free step's box, and each pair such a body may have met on the grid. :func:`screen_pairs` then gives
each candidate its bound on how fast its distance changes and, unless it is provably apart over the
whole step, its signed distances at the step's two ends (two batched narrow-phase
calls). No allocation: the caller owns every array, so a step without any candidate pair costs
two compiled loops over the shapes and nothing else.
"""

from __future__ import annotations

import math

from numba import njit

from ..jit import INLINE, JIT
from ..layout import INERTIA, MASS, P, Q, V, W
from ..rotation import qmul
from .layout import NORMAL, OFFSET
from .pairs import apart_bounds, pair_contacts

__all__ = ["GROWTH", "growth", "chords_apart", "chords_near", "rebound", "paths_may_meet", "swept_bounds",
           "CELL_STEPS", "cell_key", "grid_cell", "file_grid", "forward_cell", "box_pairs", "grid_swept_pairs", "boxes_meet",
           "grid_overlaps", "spheres_may_meet", "keep_meeting", "deflection_bound", "deflections", "left_pairs", "screen_pairs"]


#: A body's box and sphere over the step are grown by this × |v₁ − v₀| h (m): module docstring.
GROWTH = 1.0


@njit(**JIT)
def swept_bounds(Y0, Y1, members, reach, h, lo, hi):
    """lo, hi (M, 3) ← the world box (m) body members[m]'s bounding sphere stays in over the step.

    Y0, Y1: state rows at the step's start and end (layout.py: p_WC_W at P, v_WC_W at V);
    members (M,) body indices; reach (M,) bounding radii (m) about the centre of mass; h (s).
    """
    for m in range(members.shape[0]):
        i = members[m]
        grow = reach[m] + growth(Y0, Y1, i, h)
        for k in range(3):
            a, b = Y0[i, P + k], Y1[i, P + k]
            lo[m, k] = min(a, b) - grow
            hi[m, k] = max(a, b) + grow


@njit(**INLINE)
def cell_key(cx, cy, cz, mask):
    return ((cx * 73856093) ^ (cy * 19349663) ^ (cz * 83492791)) & mask


#: The grid's cell edge is the largest movable box's extent rounded up to a power of 2^(1 / CELL_STEPS) m: the same
#: edge step after step while that box changes a little (kept_pairs.py keeps the pairs of an unchanged grid).
CELL_STEPS = 16


@njit(**INLINE)
def grid_cell(lo, hi, movable):
    """The grid's cell edge (m): the largest extent of a movable box (lo, hi (M, 3)) rounded up to a power of
    2^(1 / CELL_STEPS), 1 if none has one."""
    cell = 0.0
    for i in range(lo.shape[0]):
        if movable[i]:
            for k in range(3):
                cell = max(cell, hi[i, k] - lo[i, k])
    edge = 1.0
    if cell > 0.0 and cell < math.inf:
        k = math.ceil(CELL_STEPS * math.log2(cell))
        edge = 2.0 ** (k / CELL_STEPS)
        if edge < cell:  # (the rounding of log2 and of the power)
            edge = 2.0 ** ((k + 1) / CELL_STEPS)
    elif cell > 0.0:
        edge = cell
    _pin = lo[0, 0], hi[0, 0], movable[0]  # (jit.py's rule)
    return edge


@njit(**INLINE)
def _cell_of(x, cell):
    return int(math.floor(x / cell))


@njit(**INLINE)
def boxes_meet(alo, ahi, blo, bhi, slack):
    """Whether boxes (alo, ahi) and (blo, bhi) (3,) come within ``slack`` (m) of each other on all three axes."""
    return (alo[0] <= bhi[0] + slack and blo[0] <= ahi[0] + slack and alo[1] <= bhi[1] + slack
            and blo[1] <= ahi[1] + slack and alo[2] <= bhi[2] + slack and blo[2] <= ahi[2] + slack)


@njit(**JIT)
def grid_overlaps(qlo, qhi, slack, lo, hi, movable, fixed, cells, heads, chain, found):
    """The members (rows of lo, hi) whose boxes come within ``slack`` (m) of the box qlo, qhi (3,) into found;
    returns how many (beyond found's length only the first are written). The movable ones from the hashed grid
    grid_swept_pairs built over lo, hi (cells, heads, chain as it left them), the others (``fixed``: their rows)
    each looked at. A box meets the query only if its centre lies within half a cell of it, so the cells looked at
    are those the query box grown by half a cell covers (all movable boxes when that is more than the grid holds)."""
    cell = grid_cell(lo, hi, movable)
    mask = heads.shape[0] - 1
    count = 0
    capacity = found.shape[0]
    half = 0.5 * cell * (1.0 + 1e-9)  # (the grid's cells of centres found with its own rounding)
    x0, x1 = _cell_of(qlo[0] - slack - half, cell), _cell_of(qhi[0] + slack + half, cell)
    y0, y1 = _cell_of(qlo[1] - slack - half, cell), _cell_of(qhi[1] + slack + half, cell)
    z0, z1 = _cell_of(qlo[2] - slack - half, cell), _cell_of(qhi[2] + slack + half, cell)
    span = float(x1 - x0 + 1) * float(y1 - y0 + 1) * float(z1 - z0 + 1)
    if span > lo.shape[0]:  # a query wider than the grid holds: every movable box
        for i in range(lo.shape[0]):
            if movable[i] and boxes_meet(qlo, qhi, lo[i], hi[i], slack):
                if count < capacity:
                    found[count] = i
                count += 1
    else:
        for cx in range(x0, x1 + 1):
            for cy in range(y0, y1 + 1):
                for cz in range(z0, z1 + 1):
                    i = heads[cell_key(cx, cy, cz, mask)]
                    while i >= 0:
                        if (cells[i, 0] == cx and cells[i, 1] == cy and cells[i, 2] == cz
                                and boxes_meet(qlo, qhi, lo[i], hi[i], slack)):
                            if count < capacity:
                                found[count] = i
                            count += 1
                        i = chain[i]
    for f in range(fixed.shape[0]):
        i = fixed[f]
        if boxes_meet(qlo, qhi, lo[i], hi[i], slack):
            if count < capacity:
                found[count] = i
            count += 1
    _pin = qlo[0], qhi[0], lo[0, 0], hi[0, 0], movable[0], fixed[:1], cells[0, 0], heads[0], chain[0], found[:1]
    return count


@njit(**INLINE)
def file_grid(lo, hi, movable, cells, heads, chain):
    """Files each movable box (lo, hi (M, 3)) under the cell of its centre in the hashed grid (cells (M, 3), heads
    (2^p,), chain (M,): grid_swept_pairs'); returns the cell's edge (m). A cell's chain lists its members by index,
    highest first (colliding cells' members among them)."""
    cell = grid_cell(lo, hi, movable)
    mask = heads.shape[0] - 1
    for b in range(heads.shape[0]):
        heads[b] = -1
    for i in range(lo.shape[0]):
        if movable[i]:
            for k in range(3):
                cells[i, k] = int(math.floor(0.5 * (lo[i, k] + hi[i, k]) / cell))
            key = cell_key(cells[i, 0], cells[i, 1], cells[i, 2], mask)
            chain[i] = heads[key]
            heads[key] = i
    _pin = lo[0, 0], hi[0, 0], movable[0], cells[0, 0], heads[0], chain[0]  # (jit.py's rule)
    return cell


@njit(**INLINE)
def forward_cell(nb):
    """The offset (dx, dy, dz) of the nb-th cell (0 … 13) a movable box's pairs are looked for in: its own cell,
    then the 13 neighbours "after" it (each pair of neighbouring cells once)."""
    code = nb + 13 if nb > 0 else 13  # 14 … 26: the offsets (dx, dy, dz) ∈ {−1, 0, 1}³ after 13 = (0, 0, 0)
    return code % 3 - 1, (code // 3) % 3 - 1, code // 9 - 1


@njit(**INLINE)
def box_pairs(i, lo, hi, movable, cells, heads, chain, pairs, count):
    """Member i's overlapping pairs into pairs from row ``count`` (rows (m, k), m < k; beyond its capacity only
    counted), as grid_swept_pairs writes them; returns the count after them. A movable i: the members of its own
    cell after it and those of its 13 forward cells (forward_cell), in chain order; a fixed one: every movable box,
    by index. One exit (as paths_may_meet's docstring says: inlined, an early return keeps reference counts)."""
    n = lo.shape[0]
    mask = heads.shape[0] - 1
    capacity = pairs.shape[0]
    if not movable[i]:  # a fixed box: against every movable one
        for j in range(n):
            if (movable[j] and lo[j, 0] <= hi[i, 0] and lo[i, 0] <= hi[j, 0] and lo[j, 1] <= hi[i, 1]
                    and lo[i, 1] <= hi[j, 1] and lo[j, 2] <= hi[i, 2] and lo[i, 2] <= hi[j, 2]):
                if count < capacity:
                    pairs[count, 0], pairs[count, 1] = min(i, j), max(i, j)
                count += 1
    else:
        for nb in range(14):
            dx, dy, dz = forward_cell(nb)
            cx, cy, cz = cells[i, 0] + dx, cells[i, 1] + dy, cells[i, 2] + dz
            j = heads[cell_key(cx, cy, cz, mask)]
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


@njit(**JIT)
def grid_swept_pairs(lo, hi, movable, cells, heads, chain, pairs):
    """Overlapping boxes (lo, hi (M, 3)) into pairs (capacity, 2) as rows (m, k), m < k, from a hashed grid.

    Each movable shape meets those of its own cell and of the 13 neighbouring cells on one side
    (the other 13 see it from theirs): every overlapping pair once.

    Scratch owned by the caller: cells (M, 3) int64, heads (2^p ≥ M,) int64 (the hash table),
    chain (M,) int64. Only movable members are filed in the grid; each one that is not is
    tested against every movable one (a pair of two fixed members is never written). Returns
    the number found (beyond the capacity only the first ``capacity`` are written): member by member, each
    one's pairs as box_pairs lists them.
    """
    file_grid(lo, hi, movable, cells, heads, chain)
    count = 0
    for i in range(lo.shape[0]):
        count = box_pairs(i, lo, hi, movable, cells, heads, chain, pairs, count)
    _pin = lo[0, 0], hi[0, 0], movable[0], cells[0, 0], heads[0], chain[0], pairs[0, 0]
    return count


@njit(**INLINE)
def growth(Y0, Y1, i, h):
    """Body i's growth over the step (m): GROWTH × |v₁ − v₀| h (module docstring)."""
    dvx, dvy, dvz = Y1[i, V] - Y0[i, V], Y1[i, V + 1] - Y0[i, V + 1], Y1[i, V + 2] - Y0[i, V + 2]
    return GROWTH * h * math.sqrt(dvx * dvx + dvy * dvy + dvz * dvz)


@njit(**INLINE)
def chords_apart(Y0, Y1, a, b):
    """The least distance (m) between the centres of bodies a and b over the step, each on its chord from its
    position in Y0 to its position in Y1 at the same rate (the relative chord's closest point to zero)."""
    r0x, r0y, r0z = Y0[b, P] - Y0[a, P], Y0[b, P + 1] - Y0[a, P + 1], Y0[b, P + 2] - Y0[a, P + 2]
    dx = Y1[b, P] - Y1[a, P] - r0x
    dy = Y1[b, P + 1] - Y1[a, P + 1] - r0y
    dz = Y1[b, P + 2] - Y1[a, P + 2] - r0z
    d2 = dx * dx + dy * dy + dz * dz
    t = 0.0
    if d2 > 0.0:
        t = min(max(-(r0x * dx + r0y * dy + r0z * dz) / d2, 0.0), 1.0)
    cx, cy, cz = r0x + t * dx, r0y + t * dy, r0z + t * dz
    return math.sqrt(cx * cx + cy * cy + cz * cz)


@njit(**INLINE)
def chords_near(Y0, Y1, a, b):
    """The least distance (m) between the chords of bodies a and b (each centre's segment from its position in Y0
    to its position in Y1), each anywhere on its own: the closest points of two segments (Ericson, Real-Time
    Collision Detection, 5.1.9)."""
    d1x, d1y, d1z = Y1[a, P] - Y0[a, P], Y1[a, P + 1] - Y0[a, P + 1], Y1[a, P + 2] - Y0[a, P + 2]
    d2x, d2y, d2z = Y1[b, P] - Y0[b, P], Y1[b, P + 1] - Y0[b, P + 1], Y1[b, P + 2] - Y0[b, P + 2]
    rx, ry, rz = Y0[a, P] - Y0[b, P], Y0[a, P + 1] - Y0[b, P + 1], Y0[a, P + 2] - Y0[b, P + 2]
    aa, ee = d1x * d1x + d1y * d1y + d1z * d1z, d2x * d2x + d2y * d2y + d2z * d2z
    ff, cc, bb = d2x * rx + d2y * ry + d2z * rz, d1x * rx + d1y * ry + d1z * rz, d1x * d2x + d1y * d2y + d1z * d2z
    s = t = 0.0
    if aa == 0.0:
        if ee > 0.0:
            t = min(max(ff / ee, 0.0), 1.0)
    elif ee == 0.0:
        s = min(max(-cc / aa, 0.0), 1.0)
    else:
        denom = aa * ee - bb * bb
        if denom > 0.0:
            s = min(max((bb * ff - cc * ee) / denom, 0.0), 1.0)
        t = (bb * s + ff) / ee
        if t < 0.0:
            t, s = 0.0, min(max(-cc / aa, 0.0), 1.0)
        elif t > 1.0:
            t, s = 1.0, min(max((bb - cc) / aa, 0.0), 1.0)
    cx, cy, cz = rx + s * d1x - t * d2x, ry + s * d1y - t * d2y, rz + s * d1z - t * d2z
    return math.sqrt(cx * cx + cy * cy + cz * cz)


@njit(**INLINE)
def rebound(Y0, Y1, grounds, i, r):
    """How far (m) body i, on its free step, may be from where its chord puts it at a time, when a half-space of
    ``grounds`` (rows n·x ≥ offset) may stop it within the step: the chord's length, where its bounding sphere
    (radius r) at the step's end reaches past one (its ground pass stops it anywhere on the chord or sends it
    back along it, by at most what is left of the chord); −1 where none does (its path is the chord's)."""
    x, y, z = Y1[i, P], Y1[i, P + 1], Y1[i, P + 2]
    reaches = False
    for g in range(grounds.shape[0]):
        reaches = reaches or grounds[g, NORMAL] * x + grounds[g, NORMAL + 1] * y + grounds[g, NORMAL + 2] * z \
            - grounds[g, OFFSET] < r
    dx, dy, dz = x - Y0[i, P], y - Y0[i, P + 1], z - Y0[i, P + 2]
    return math.sqrt(dx * dx + dy * dy + dz * dz) if reaches else -1.0


@njit(**JIT)
def paths_may_meet(Y0, Y1, grounds, a, b, ra, rb, grow, free_a, free_b):
    """Whether the bounding spheres (radii ra, rb; their growths summed, ``grow``) of bodies a and b can meet over
    the step: on their chords at the same rate (chords_apart), or, where one on its free step (free_a, free_b) may
    be stopped by a half-space of ``grounds`` (rebound), each anywhere on its chord (chords_near) within the radii,
    the growths and the rebounds. A ball on the ground moving down, whose free chord goes on into the ground, is
    stopped by its ground pass: a can coming down beside it meets it though their free chords keep apart.

    Compiled on its own, with one exit and its arrays read at the end (_pin), not inlined: inlined, its branches
    left an atomic reference-count increment and decrement of three arrays in its callers' loops, per pair. The
    rebound inlined here has one exit too (with an early return, each call of this kept its arrays' counts)."""
    limit = (ra + rb) * (1.0 + 1e-6) + grow
    meet = chords_apart(Y0, Y1, a, b) <= limit
    if not meet:
        back_a = rebound(Y0, Y1, grounds, a, ra) if free_a else -1.0
        back_b = rebound(Y0, Y1, grounds, b, rb) if free_b else -1.0
        meet = (back_a >= 0.0 or back_b >= 0.0) and \
            chords_near(Y0, Y1, a, b) <= limit + max(back_a, 0.0) + max(back_b, 0.0)
    _pin = Y0[0, 0], Y1[0, 0], grounds.shape[0]
    return meet


@njit(**JIT)
def spheres_may_meet(Y0, Y1, members, reach, h, grounds, pairs, found):
    """Of the overlapping boxes' pairs (rows of members) pairs[:found], those whose bounding spheres can meet over
    the step kept at the front, in their order; returns how many. A pair is dropped when its centres' relative
    path, taken as the chord from its start to its end offset to its start, stays further from zero than both
    spheres' radii (``reach``) plus both growths (GROWTH × |v₁ − v₀| h each, as swept_bounds') and 1e-6 of the radii:
    each centre stays within its growth of its own chord (swept_bounds), so their difference within both of the
    chords' difference; and, where one of them may be stopped by a half-space of ``grounds`` (the ground's pass
    after this one changes its path: paths_may_meet), when the chords themselves stay that far apart, the
    rebounds added. Y0, Y1, members, reach, h as for swept_bounds."""
    kept = keep_meeting(Y0, Y1, members, reach, h, grounds, pairs, 0, found)
    _pin = Y0[0, 0], Y1[0, 0], members[0], reach[0], grounds.shape[0], pairs[0, 0]
    return kept


@njit(**INLINE)
def keep_meeting(Y0, Y1, members, reach, h, grounds, pairs, start, stop):
    """spheres_may_meet's test on pairs[start:stop]: those kept moved to the front of that range, in their order;
    returns where they end (kept_pairs.py tests each member's pairs as it lists them)."""
    kept = start
    for k in range(start, stop):
        m, n = pairs[k, 0], pairs[k, 1]
        a, b = members[m], members[n]
        if paths_may_meet(Y0, Y1, grounds, a, b, reach[m], reach[n], growth(Y0, Y1, a, h) + growth(Y0, Y1, b, h),
                          True, True):
            pairs[kept, 0], pairs[kept, 1] = m, n
            kept += 1
    _pin = Y0[0, 0], Y1[0, 0], members[0], reach[0], grounds.shape[0], pairs[0, 0]  # (jit.py's rule)
    return kept


@njit(**INLINE)
def _spheres_meet(Y0, Y1, members, reach, h, m, n):
    """spheres_may_meet's test of members m and n (rows) on chords that no ground will change (the paths as
    stepped)."""
    a, b = members[m], members[n]
    grow = growth(Y0, Y1, a, h) + growth(Y0, Y1, b, h)
    return chords_apart(Y0, Y1, a, b) <= (reach[m] + reach[n]) * (1.0 + 1e-6) + grow


@njit(**INLINE)
def _spin_energy_twice(Y, prm, i):
    """Σ I_j ω_j² of body i (principal axes, J): twice its spin's kinetic energy."""
    return (prm[i, INERTIA] * Y[i, W] * Y[i, W] + prm[i, INERTIA + 1] * Y[i, W + 1] * Y[i, W + 1]
            + prm[i, INERTIA + 2] * Y[i, W + 2] * Y[i, W + 2])


@njit(**JIT)
def deflection_bound(Y, prm, a, b):
    """A bound (m/s) on how much one impact between moving bodies a and b at state rows Y can change their relative
    velocity: the law conserves momentum and adds no energy, so the relative velocity after is at most
    √(|v_a − v_b|² + Σ I ω² / μ) (the pair's kinetic energy in its centre of mass' frame, spins included, all in
    it; μ the reduced mass), the change at most that plus |v_a − v_b|. a's velocity changes by m_b / (m_a + m_b)
    of it, b's by m_a / (m_a + m_b); a head-on elastic impact without spin attains it."""
    dx, dy, dz = Y[a, V] - Y[b, V], Y[a, V + 1] - Y[b, V + 1], Y[a, V + 2] - Y[b, V + 2]
    relative = dx * dx + dy * dy + dz * dz
    ma, mb = prm[a, MASS], prm[b, MASS]
    spins = _spin_energy_twice(Y, prm, a) + _spin_energy_twice(Y, prm, b)
    return math.sqrt(relative) + math.sqrt(relative + spins * (ma + mb) / (ma * mb))


@njit(**JIT)
def deflections(Y0, Y1, prm, members, movable, pairs, found, h, skin, reach, grown, deflect):
    """deflect (per body, m/s) ← for each member, the largest change of velocity a hit with one of its candidates
    may give it (deflection_bound at the step's start Y0 or free end Y1, its share; over pairs[:found], rows of
    members, both movable), 0 where h × that is within its ``skin`` (M,; m); grown (M,) ← ``reach`` (M,; m) + h ×
    that. Returns whether any member grew."""
    for m in range(members.shape[0]):
        deflect[members[m]] = 0.0
    for k in range(found):
        ma, mb = pairs[k, 0], pairs[k, 1]
        if not (movable[ma] and movable[mb]):
            continue
        a, b = members[ma], members[mb]
        change = max(deflection_bound(Y0, prm, a, b), deflection_bound(Y1, prm, a, b))
        share = prm[b, MASS] / (prm[a, MASS] + prm[b, MASS])
        deflect[a] = max(deflect[a], change * share)
        deflect[b] = max(deflect[b], change * (1.0 - share))
    grew = False
    for m in range(members.shape[0]):
        i = members[m]
        if h * deflect[i] <= skin[m]:
            deflect[i] = 0.0
        grew = grew or deflect[i] > 0.0
        grown[m] = reach[m] + h * deflect[i]
    return grew


@njit(**JIT)
def left_pairs(Y0, Y1, members, reach, h, lo, hi, movable, fixed, skip, cells, heads, chain, alo, ahi, left, found,
               out):
    """The step's passes done (Y1: the ends as stepped), the pairs a body they sent out of its free step's box may
    have met: into out (capacity, 2), rows of members; returns (how many left their box, how many pairs; beyond
    out's capacity only the first are written).

    A movable member whose body is not ``skip``ped (per body) left its box when its box over the step as stepped
    (swept_bounds' from Y0 to Y1, into alo, ahi (M, 3)) is not inside the broad phase's (lo, hi, of the free step);
    those are listed in ``left``. A pair is one of them and another movable member not skipped whose box meets that
    one (lo, hi as grid_swept_pairs filed them in cells, heads, chain, queried by grid_overlaps with scratch
    ``found``; for two that left, their new boxes), whose bounding spheres can meet on the chords as stepped
    (spheres_may_meet's test, no ground left to change a path)."""
    n_left = 0
    for m in range(members.shape[0]):
        i = members[m]
        if not movable[m] or skip[i]:
            continue
        grow = reach[m] + growth(Y0, Y1, i, h)
        outside = False
        for k in range(3):
            a, b = Y0[i, P + k], Y1[i, P + k]
            alo[m, k] = min(a, b) - grow
            ahi[m, k] = max(a, b) + grow
            outside = outside or alo[m, k] < lo[m, k] or ahi[m, k] > hi[m, k]
        if outside:
            left[n_left] = m
            n_left += 1
    count = 0
    capacity = out.shape[0]
    for e in range(n_left):
        m = left[e]
        got = grid_overlaps(alo[m], ahi[m], 0.0, lo, hi, movable, fixed, cells, heads, chain, found)
        for c in range(min(got, found.shape[0])):
            k = found[c]
            if k != m and movable[k] and not skip[members[k]] and _spheres_meet(Y0, Y1, members, reach, h, m, k):
                if count < capacity:
                    out[count, 0], out[count, 1] = m, k
                count += 1
        for e2 in range(e + 1, n_left):
            k = left[e2]
            if boxes_meet(alo[m], ahi[m], alo[k], ahi[k], 0.0) and _spheres_meet(Y0, Y1, members, reach, h, m, k):
                if count < capacity:
                    out[count, 0], out[count, 1] = m, k
                count += 1
    _pin = Y0[0, 0], Y1[0, 0], members[0], reach[0], lo[0, 0], hi[0, 0], movable[0], fixed[:1], skip[0]
    _pin2 = cells[0, 0], heads[0], chain[0], alo[0, 0], ahi[0, 0], left[0], found[0], out[0, 0]
    return n_left, count


@njit(**INLINE)
def _norm3(x, y, z):
    return math.sqrt(x * x + y * y + z * z)


@njit(**JIT)
def screen_pairs(Y0, Y1, q_PB, shapes, spin_reach, pairs, h, pos, quat, near, which, lower, dist, normal, count, points,
                 seps, reach, d0, d1):
    """For each candidate pair (a, b), row k of ``pairs`` (K, 2; body indices): reach[k] ← h × a bound (m/s) on
    how fast its signed distance changes over the step, and d0[k], d1[k] ← its signed distances (m) at the step's
    start and end, or +inf for both where the pair cannot have met in the step: two boxes whose lower bounds on
    their distance (apart_bounds) at both ends are positive and sum to more than reach[k] (pairs whose bounding
    spheres cannot meet were dropped before, by spheres_may_meet).

    The bound: the larger relative speed |v_b − v_a| of the step's two ends plus its change, and for each body the
    larger spin |ω| plus its change times its spin_reach (per body, m: the radius its spin sweeps). Y0, Y1: state
    rows at the step's start and end; q_PB (per body, w x y z): each shape's orientation in its body's principal
    axes (the shape q_WS = q ⊗ q_PB, its centre the centre of mass); shapes (per body: shape rows).

    Scratch owned by the caller: pos (2, N, 3) and quat (2, N, 4) (a pair's bodies' poses at each end, in their
    rows), near (K, 2) and which (K,) int64 (the pairs looked at, and their rows k), lower (1,), and dist (K,),
    normal (K, 3), count (K,) int64, points (K, MAX_PAIR_POINTS, 6), seps (K, MAX_PAIR_POINTS) (pair_contacts').
    Returns how many pairs were looked at.
    """
    m = 0
    for k in range(pairs.shape[0]):
        a, b = pairs[k, 0], pairs[k, 1]
        r0x, r0y, r0z = Y0[b, V] - Y0[a, V], Y0[b, V + 1] - Y0[a, V + 1], Y0[b, V + 2] - Y0[a, V + 2]
        r1x, r1y, r1z = Y1[b, V] - Y1[a, V], Y1[b, V + 1] - Y1[a, V + 1], Y1[b, V + 2] - Y1[a, V + 2]
        bound = max(_norm3(r0x, r0y, r0z), _norm3(r1x, r1y, r1z))
        bound += _norm3(r1x - r0x, r1y - r0y, r1z - r0z)
        for side in range(2):
            i = pairs[k, side]
            spin = max(_norm3(Y0[i, W], Y0[i, W + 1], Y0[i, W + 2]), _norm3(Y1[i, W], Y1[i, W + 1], Y1[i, W + 2]))
            bound += (spin + _norm3(Y1[i, W] - Y0[i, W], Y1[i, W + 1] - Y0[i, W + 1], Y1[i, W + 2] - Y0[i, W + 2])) \
                * spin_reach[i]
        reach[k] = bound * h
        for side in range(2):
            i = pairs[k, side]
            for end in range(2):
                Y = Y0 if end == 0 else Y1
                for j in range(3):
                    pos[end, i, j] = Y[i, P + j]
                qw, qx, qy, qz = qmul(Y[i, Q], Y[i, Q + 1], Y[i, Q + 2], Y[i, Q + 3],
                                      q_PB[i, 0], q_PB[i, 1], q_PB[i, 2], q_PB[i, 3])
                quat[end, i, 0], quat[end, i, 1], quat[end, i, 2], quat[end, i, 3] = qw, qx, qy, qz
        near[m, 0], near[m, 1] = a, b
        apart_bounds(pos[0], quat[0], shapes, near[m:m + 1], lower)
        at0 = lower[0]
        apart_bounds(pos[1], quat[1], shapes, near[m:m + 1], lower)
        if at0 > 0.0 and lower[0] > 0.0 and at0 + lower[0] > reach[k]:
            d0[k] = d1[k] = math.inf
        else:
            which[m] = k
            m += 1
    if m > 0:
        pair_contacts(pos[1], quat[1], shapes, near[:m], dist, normal, count, points, seps)
        for j in range(m):
            d1[which[j]] = dist[j]
        pair_contacts(pos[0], quat[0], shapes, near[:m], dist, normal, count, points, seps)
        for j in range(m):
            d0[which[j]] = dist[j]
    _pin = Y0[0, 0], Y1[0, 0], q_PB[0, 0], shapes[0, 0], spin_reach[0], pairs[0, 0], pos[0, 0, 0]
    _pin2 = quat[0, 0, 0], near[0, 0], which[0], lower[0], dist[0], normal[0, 0], count[0], points[0, 0, 0]
    _pin3 = seps[0, 0], reach[0], d0[0], d1[0]
    return m
