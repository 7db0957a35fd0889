"""Questions a caller outside the step may ask about contact (ROS-free): gaps at a pose, touching points.

:func:`lowest_gap` answers where a body *would* be against the ground at a given pose (the
node refuses a ``set_state`` into a half-space with it); :func:`touching_points` gives the
contact points of a body in persistent contact, as the solver tracks them. Both use the
compiled gap functions the solver uses (core/kernels/contact/shapes.py).
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import layout as L
from ..kernels.contact.layout import MAX_POINTS, PERSISTENT
from ..kernels.contact.shapes import body_gap, body_points, feature_points, min_gaps

__all__ = ["lowest_gap", "lowest_gaps", "lowest_gaps_along", "lowest_point", "resting_bodies", "touching_points"]


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
