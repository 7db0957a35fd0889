"""Questions a caller outside the step may ask about contact (ROS-free): gaps at a pose, touching points.

:func:`lowest_gap` answers where a body *would* be against the ground at a given pose (the
node refuses a ``set_state`` into a half-space with it); :func:`touching_points` gives the
contact points of a body in persistent contact, as the solver tracks them (both use the compiled gap
functions the solver uses, core/kernels/contact/shapes.py), and :func:`island_points` those of the
bodies resting on bodies (the islands' last step). :func:`overlapping_bodies`
finds the bodies whose collision shapes overlap one another (the scene loader and ``~/spawn``
refuse them) with the compiled broad phase (uniform grid) and narrow phase
(core/kernels/contact/broadphase.py, pairs.py).
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import layout as L
from ..kernels.contact.layout import DIMS, KIND, MAX_POINTS, PERSISTENT, SHAPE_NONE
from ..kernels.contact.broadphase import grid_pairs, shape_aabbs
from ..kernels.contact.pairs import MAX_PAIR_POINTS, pair_contacts
from ..kernels.contact.shapes import body_gap, body_points, feature_points, min_gaps
from .island_contacts import body_sides

__all__ = ["TOUCHING", "overlapping_bodies", "lowest_gap", "lowest_gaps", "lowest_gaps_along", "nearest_static",
           "lowest_point", "resting_bodies", "touching_points", "island_points"]


#: A penetration up to this × the pair's size (its largest shape dimension) counts as touching: the
#: narrow phase's round-off for shapes placed face to face (static_geometry.py uses the same).
TOUCHING = 1e-9


def overlapping_bodies(p_WC_W, q_WB, shapes, moving, of=None) -> list[tuple[int, int, float]]:
    """The pairs of bodies whose collision shapes overlap (deeper than :data:`TOUCHING`), deepest first.

    Parameters
    ----------
    p_WC_W : array-like, shape (N, 3)
        Each body's centre of mass (world, m): where its shape is centred.
    q_WB : array-like, shape (N, 4)
        Each body's frame B in the world, (w, x, y, z): the frame its shape is declared in.
    shapes : ndarray, shape (N, SHAPE_WIDTH)
        Shape rows (core/kernels/contact/layout.py); a SHAPE_NONE row overlaps nothing.
    moving : array-like of bool, shape (N,)
        Bodies that move (motion ``free``); a pair of two bodies that do not is never reported.
    of : array-like of int, optional
        Only pairs with at least one body among these indices (default: every pair).

    Returns
    -------
    list of (i, j, depth)
        i < j body indices and the penetration depth in m (minus the signed distance: the
        shortest translation that separates them), deepest first.

    Candidates come from the uniform grid (linear in N for shapes of comparable size), then one
    compiled narrow-phase call over them.
    """
    # writable C-ordered copies: the one signature compile_pairs.py compiles (a read-only array is another type)
    pos = np.array(p_WC_W, dtype=float, order="C").reshape(-1, 3)
    quat = np.array(q_WB, dtype=float, order="C").reshape(-1, 4)
    rows = np.array(shapes, dtype=float, order="C")
    n = len(pos)
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    shape_aabbs(pos, quat, rows, lo, hi)
    pairs = np.empty((max(4 * n, 16), 2), dtype=np.int64)
    found = grid_pairs(lo, hi, 0.0, pairs)
    if found > len(pairs):
        pairs = np.empty((found, 2), dtype=np.int64)
        found = grid_pairs(lo, hi, 0.0, pairs)
    pairs = pairs[:found]
    moves = np.asarray(moving, dtype=bool)
    keep = moves[pairs[:, 0]] | moves[pairs[:, 1]]
    if of is not None:
        chosen = np.zeros(n, dtype=bool)
        chosen[np.asarray(of, dtype=np.int64)] = True
        keep &= chosen[pairs[:, 0]] | chosen[pairs[:, 1]]
    pairs = np.ascontiguousarray(pairs[keep])
    m = len(pairs)
    dist, normal, count = np.empty(m), np.empty((m, 3)), np.zeros(m, dtype=np.int64)
    points, seps = np.empty((m, MAX_PAIR_POINTS, 6)), np.empty((m, MAX_PAIR_POINTS))
    pair_contacts(pos, quat, rows, pairs, dist, normal, count, points, seps)
    size = np.maximum(rows[pairs[:, 0], DIMS:DIMS + 3].max(axis=1), rows[pairs[:, 1], DIMS:DIMS + 3].max(axis=1))
    hits = np.flatnonzero(-dist > TOUCHING * size)
    hits = hits[np.argsort(dist[hits], kind="stable")]
    return [(int(pairs[k, 0]), int(pairs[k, 1]), -float(dist[k])) for k in hits]


def lowest_gap(sim, body: str, position_world, orientation_xyzw) -> tuple[float, int]:
    """(lowest gap in m, index of its ground) of ``body``'s collision shape placed at that pose (its
    centre of mass at ``position_world``, its frame B turned by ``orientation_xyzw``, (x, y, z, w)),
    over every ground half-space of ``sim``; (inf, -1) without contact or without a shape.

    A negative gap is how far the shape's lowest point lies inside that half-space.
    """
    solver = sim.contact
    if solver is None:
        return math.inf, -1
    i = sim.body_names.index(body)
    y = np.zeros(L.ROW_WIDTH)
    y[L.P:L.P + 3] = np.asarray(position_world, dtype=float)
    x, yy, z, w = (float(c) for c in orientation_xyzw)
    q_BP = sim.model.q_BP[i]  # the state row holds q_WP = q_WB ⊗ q_BP (the shape is in principal axes)
    y[L.Q:L.Q + 4] = _product((w, x, yy, z), q_BP)
    gap, j = body_gap(y, sim._prm[i], solver.shapes[i], solver.half_spaces, np.empty((MAX_POINTS, 3)),
                      np.empty(MAX_POINTS))
    return float(gap), int(j)


def nearest_static(sim, body: str, position_world, orientation_xyzw) -> tuple[float, str | None]:
    """(signed distance in m, name) of the static body whose collision shape is nearest to
    ``body``'s placed at that pose (as :func:`lowest_gap`); (inf, None) without static shapes or
    without a shape. Negative: how deep the two shapes overlap."""
    solver = sim.contact
    i = sim.body_names.index(body)
    if solver is None or solver.statics is None or solver.shapes[i, KIND] == SHAPE_NONE:
        return math.inf, None
    y = np.zeros(L.ROW_WIDTH)
    y[L.P:L.P + 3] = np.asarray(position_world, dtype=float)
    x, yy, z, w = (float(c) for c in orientation_xyzw)
    y[L.Q:L.Q + 4] = _product((w, x, yy, z), sim.model.q_BP[i])
    dist, s = solver.statics.nearest(y, i, solver.shapes[i])
    if s < 0:
        return math.inf, None
    return dist, sim.body_names[int(solver.statics.statics[s])]


def lowest_gaps_along(sim, body: str, positions_world, orientations_xyzw) -> np.ndarray:
    """(T,) lowest gap in m of ``body``'s collision shape at each of T poses (positions (T, 3) of its
    centre of mass, orientations (T, 4) of its frame B, (x, y, z, w)), over every ground half-space
    (inf without contact or without a shape): a recorded run's gap over time."""
    positions = np.asarray(positions_world, dtype=float).reshape(-1, 3)
    orientations = np.asarray(orientations_xyzw, dtype=float).reshape(-1, 4)
    return np.array([lowest_gap(sim, body, p, q)[0] for p, q in zip(positions, orientations)], dtype=float)


def _product(a, b) -> tuple[float, float, float, float]:
    """The Hamilton product a ⊗ b of two (w, x, y, z) quaternions."""
    aw, ax, ay, az = a
    bw, bx, by, bz = (float(c) for c in b)
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def touching_points(sim, index: int) -> tuple[np.ndarray, np.ndarray]:
    """((k, 3) world points, (k,) gaps in m) of the features body ``index`` rests on (k = 0 in flight)."""
    solver = sim.contact
    if solver is None or solver.modes[index] != PERSISTENT:
        return np.empty((0, 3)), np.empty(0)
    points, gaps, owners = np.empty((MAX_POINTS, 3)), np.empty(MAX_POINTS), np.zeros(MAX_POINTS, dtype=np.int64)
    y = sim._Ys[sim._control[L.CUR]][index]
    count = feature_points(y, sim._prm[index], solver.shapes[index], solver.grounds[int(solver.ground_of[index])],
                           int(solver.tracked[index]), points, gaps, owners)
    return points[:count].copy(), gaps[:count].copy()


def island_points(sim) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Per body in an island (asleep included), (its contact points of the last island step, (k, 3) world, m,
    mid-way between the surfaces; the force on it from them over that step, (3,) N, world axes)."""
    solver = sim.contact
    islands = None if solver is None or solver.pairs is None else solver.pairs.islands
    if islands is None or islands.log.h <= 0.0:
        return {}
    ints, floats = islands.contacts()
    if not len(ints):
        return {}
    body, points, impulses = body_sides(ints, floats)
    order = np.argsort(body, kind="stable")
    body, points, impulses = body[order], points[order], impulses[order]
    bodies, starts = np.unique(body, return_index=True)
    forces = np.add.reduceat(impulses, starts, axis=0) / islands.log.h
    ends = np.append(starts[1:], len(body))
    return {int(i): (points[a:b], forces[k]) for k, (i, a, b) in enumerate(zip(bodies, starts, ends))}


def lowest_point(sim, index: int, ground: int) -> tuple[np.ndarray, float]:
    """(the lowest point in world coordinates, its gap in m) of body ``index``'s shape against ground ``ground``."""
    solver = sim.contact
    points, gaps = np.empty((MAX_POINTS, 3)), np.empty(MAX_POINTS)
    y = sim._Ys[sim._control[L.CUR]][index]
    count = body_points(y, sim._prm[index], solver.shapes[index], solver.grounds[ground], points, gaps)
    if count == 0:
        return np.full(3, math.nan), math.inf
    k = int(np.argmin(gaps[:count]))
    return points[k].copy(), float(gaps[k])


def lowest_gaps(sim) -> np.ndarray:
    """The lowest gap (m) over every ground of each body with a shape, in ``sim.contact.bodies`` order."""
    solver = sim.contact
    out = np.empty(len(solver.bodies))
    min_gaps(sim._Ys[sim._control[L.CUR]], sim._prm, solver.shapes, solver.half_spaces, solver.bodies, out)
    return out


def resting_bodies(sim) -> list[int]:
    """Indices of the bodies in persistent contact, in scene order ([] without contact)."""
    solver = sim.contact
    if solver is None:
        return []
    return solver.bodies[solver.modes[solver.bodies] == PERSISTENT].tolist()
