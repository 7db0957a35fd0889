"""Island contacts by pair: each pair's impulse summed over a span of steps, and one row per pair side.

An island's velocity step (island.py, kernels/contact/island.py) has several contact points per
touching pair: a box face's corners against another box, a body's features against a half-space.
:class:`IslandContactLog`, fed by the island driver after each of its steps, keeps the step's
start and end states of its bodies and, once a consumer has set :attr:`IslandContactLog.summing`
(the node's ``contacts`` publisher does), sums each pair's impulse over the steps since it was
last taken (sorted keys and one ``np.unique`` per step: no Python per pair; 50 µs per step for
640 points). :func:`pair_sides` groups the last step's points by pair and gives one row per pair
side: two for two moving bodies (each naming the other), one for a body against a half-space or
a static shape, with the pair's mean force and whether it slides (:data:`SLIDE_SPEED`).

An island asleep (``ContactSolver.sleeping``) has no step: its contacts are those of the step it fell
asleep in, with the forces it was held by then (Islands.contacts). Not listed: a pair that parted before
the last step.

A pair is (body, other): ``body`` the lower index of two moving bodies, else the moving one;
``other`` the other moving body's or the static body's index, or ``n_bodies + k`` for half-space k.
Its key is ``body × (n_bodies + n_half_spaces) + other``; its summed impulse is the one on ``body``
(world axes, N·s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernels import layout as L
from ..kernels.contact.island import C_FLOATS, C_GAP, C_IMPULSE, C_INTS, C_N, C_X, I_A, I_B, I_GROUND, I_STATIC
from ..quaternion import quat_to_matrix

__all__ = ["SLIDE_SPEED", "IslandContactLog", "PairSides", "pair_keys", "body_sides", "slip_speeds", "pair_sides"]

#: A pair slides when, after the last step, one of its points slips faster than this (m/s): the relative
#: velocity of the two surfaces at the point, tangential part (the island pass's SLEEP_SPEED scale).
SLIDE_SPEED = 1e-9


def pair_keys(ints: np.ndarray, n_bodies: int, width: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(key, body, sign) of each island contact (the module docstring), each of shape (n,).

    ``ints`` : (n, C_INTS) int rows of Islands.contacts(). ``sign`` is +1 where ``body`` is the
    contact's side b (its normal points from the other side towards ``body``; its impulse is on
    ``body``), −1 where it is side a.
    """
    a, b = ints[:, I_A], ints[:, I_B]
    static, ground = ints[:, I_STATIC], ints[:, I_GROUND]
    both = (a >= 0) & (b >= 0)
    body = np.where(both, np.minimum(a, b), np.maximum(a, b))
    other = np.where(both, np.maximum(a, b), np.where(ground >= 0, n_bodies + ground, static))
    sign = np.where(body == b, 1.0, -1.0)
    return body * width + other, body, sign


def body_sides(ints: np.ndarray, floats: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each island contact once per moving side: (body (m,), point (m, 3), world, m, impulse on that body (m, 3),
    world, N·s); the rows of side b first, then those of side a (its impulse the opposite). Fixed sides are
    left out. ``ints``, ``floats``: the rows of Islands.contacts()."""
    on_b, on_a = ints[:, I_B] >= 0, ints[:, I_A] >= 0
    body = np.concatenate((ints[on_b, I_B], ints[on_a, I_A]))
    point = np.concatenate((floats[on_b, C_X:C_X + 3], floats[on_a, C_X:C_X + 3]))
    impulse = np.concatenate((floats[on_b, C_IMPULSE:C_IMPULSE + 3], -floats[on_a, C_IMPULSE:C_IMPULSE + 3]))
    return body, point, impulse


def slip_speeds(Y0: np.ndarray, Y1: np.ndarray, ints: np.ndarray, floats: np.ndarray) -> np.ndarray:
    """(n,) slip speed (m/s) at each island contact after the step: |tangential part of v_b(x) − v_a(x)|.

    v_i(x) = v_i + ω_i × (x − p_i) with the step's new velocities (``Y1``; ω_P turned to world axes by
    the step start's q, as the velocity step does) and the point x and centre p_i at the step's
    start (``Y0``): the velocities the contact rows of the step constrain. A fixed side is at rest.
    """
    x, n = floats[:, C_X:C_X + 3], floats[:, C_N:C_N + 3]
    relative = np.zeros((len(ints), 3))
    for side, sign in ((I_B, 1.0), (I_A, -1.0)):
        moving = ints[:, side] >= 0
        i = ints[moving, side]
        R_WP = quat_to_matrix(Y0[i, L.Q:L.Q + 4])
        w_W = np.einsum("kab,kb->ka", R_WP, Y1[i, L.W:L.W + 3])
        relative[moving] += sign * (Y1[i, L.V:L.V + 3] + np.cross(w_W, x[moving] - Y0[i, L.P:L.P + 3]))
    along = np.einsum("ka,ka->k", relative, n)
    return np.linalg.norm(relative - along[:, None] * n, axis=1)


class IslandContactLog:
    """Each island pair's impulse summed since :meth:`take`, and the last island step's states (module docstring).

    Parameters
    ----------
    n_bodies : int
        Bodies in the scene (every index of a contact row is below it).
    n_half_spaces : int
        The scene's half-spaces (a contact's I_GROUND is below it).
    """

    def __init__(self, n_bodies: int, n_half_spaces: int) -> None:
        self.n_bodies = n_bodies
        self.width = n_bodies + n_half_spaces
        #: Sorted keys of the pairs with a contact since the last take, shape (p,).
        self.keys = np.zeros(0, dtype=np.int64)
        #: Their summed impulse on the pair's ``body`` (world, N·s), shape (p, 3).
        self.impulses = np.zeros((0, 3))
        #: The last island step's state rows at its start and end (rows of its bodies only), (n_bodies, STATE_WIDTH).
        self.start, self.end = np.zeros((n_bodies, L.STATE_WIDTH)), np.zeros((n_bodies, L.STATE_WIDTH))
        #: The last island step's length (s).
        self.h = 0.0
        #: Sum the impulses (set by a consumer that takes them); off, nothing is summed and :func:`pair_sides`
        #: gives the last step's forces. Off by default: a run nobody reads pays no grouping per step.
        self.summing = False

    def clear(self) -> None:
        """Forget the sums (a reset)."""
        self.keys, self.impulses = np.zeros(0, dtype=np.int64), np.zeros((0, 3))

    def add(self, Y0: np.ndarray, Y1: np.ndarray, bodies: np.ndarray, ints: np.ndarray, floats: np.ndarray,
            h: float) -> None:
        """After an island step of length ``h`` that took ``bodies`` (int, (b,)) from state rows ``Y0`` to
        ``Y1``, with the contacts (ints, floats) of Islands.contacts()."""
        self.h = h
        self.start[bodies] = Y0[bodies, :L.STATE_WIDTH]
        self.end[bodies] = Y1[bodies, :L.STATE_WIDTH]
        if not self.summing or not len(ints):
            return
        keys, _, sign = pair_keys(ints, self.n_bodies, self.width)
        keys = np.concatenate((self.keys, keys))
        impulses = np.concatenate((self.impulses, sign[:, None] * floats[:, C_IMPULSE:C_IMPULSE + 3]))
        self.keys, inverse = np.unique(keys, return_inverse=True)
        self.impulses = _sums(inverse, impulses, len(self.keys))

    def take(self) -> tuple[np.ndarray, np.ndarray]:
        """(keys (p,), impulses (p, 3)) summed since the last take (or clear); the sums start again."""
        taken = self.keys, self.impulses
        self.keys, self.impulses = np.zeros(0, dtype=np.int64), np.zeros((0, 3))
        return taken


@dataclass(frozen=True)
class PairSides:
    """One row per side of each island pair of the last step (:func:`pair_sides`); every array has m rows.

    Attributes
    ----------
    body : (m,) int
        The body the row is about.
    other : (m,) int
        The other moving body, −1 against a half-space or a static shape.
    ground : (m,) int
        The half-space's index, or the static shape's plane row (``ContactSolver.static_body_of`` names
        it: a static box's face, else the body's tangent row); −1 between two moving bodies.
    point_W : (m, 3)
        The centre of the pair's points at the last step's start (mid-way between the surfaces), world, m.
    normal_W : (m, 3)
        Unit contact normal from ``other`` (or the fixed side) towards ``body``, world axes.
    gap : (m,)
        The pair's smallest gap at the last step's start (m).
    force_W : (m, 3)
        The mean force on ``body`` from the other side (world, N): summed impulse / the time it covers.
    sliding : (m,) bool
        A point of the pair slipped faster than :data:`SLIDE_SPEED` after the last step.
    """

    body: np.ndarray
    other: np.ndarray
    ground: np.ndarray
    point_W: np.ndarray
    normal_W: np.ndarray
    gap: np.ndarray
    force_W: np.ndarray
    sliding: np.ndarray

    def __len__(self) -> int:
        return len(self.body)


def pair_sides(solver, keys: np.ndarray | None = None, impulses: np.ndarray | None = None,
               span: float = 0.0) -> PairSides:
    """The pair sides of the last step's island contacts of ``solver`` (a ContactSolver).

    Forces: the pair's ``impulses`` (from :meth:`IslandContactLog.take`, keys sorted) divided by
    ``span`` (s), the time they were summed over; with no keys or ``span`` ≤ 0, the last step's own
    impulse divided by its length. Pairs of the sums that have no contact at the last step are not
    listed. Rows are in key order, a pair's two sides next to each other (``body`` < ``other`` first).
    """
    islands = None if solver.pairs is None else solver.pairs.islands
    ints, floats = islands.contacts() if islands is not None else (np.zeros((0, C_INTS), np.int64),
                                                                   np.zeros((0, C_FLOATS)))
    if not len(ints):
        z = np.zeros(0, dtype=np.int64)
        return PairSides(z, z, z, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)),
                         np.zeros(0, dtype=bool))
    log = islands.log
    key, body, sign = pair_keys(ints, log.n_bodies, log.width)
    pair_key, inverse = np.unique(key, return_inverse=True)
    order = np.argsort(inverse, kind="stable")
    starts = np.searchsorted(inverse[order], np.arange(len(pair_key)))
    count = np.bincount(inverse, minlength=len(pair_key))
    point = _sums(inverse, floats[:, C_X:C_X + 3], len(pair_key)) / count[:, None]
    gap = np.minimum.reduceat(floats[order, C_GAP], starts)
    slip = slip_speeds(log.start, log.end, ints, floats)
    slipping = np.maximum.reduceat(slip[order], starts) > SLIDE_SPEED
    first = order[starts]  # each pair's first point: its normal (a pair's points share it) and its sides
    normal = sign[first, None] * floats[first, C_N:C_N + 3]
    force = _sums(inverse, sign[:, None] * floats[:, C_IMPULSE:C_IMPULSE + 3], len(pair_key)) / log.h
    if keys is not None and len(keys) and span > 0.0:
        at = np.minimum(np.searchsorted(keys, pair_key), len(keys) - 1)
        summed = keys[at] == pair_key  # every pair of the last step, when the sums were kept through it
        force[summed] = impulses[at[summed]] / span
    pair_body, code = body[first], pair_key % log.width
    between = (ints[first, I_A] >= 0) & (ints[first, I_B] >= 0)
    other = np.where(between, code, -1)
    ground = np.where(code >= log.n_bodies, code - log.n_bodies, -1)
    on_static = ~between & (code < log.n_bodies)
    if on_static.any():
        ground[on_static] = solver.statics.plane_rows(pair_body[on_static], code[on_static], normal[on_static],
                                                      point[on_static])
    # a pair of two moving bodies: a second side, body and other swapped, normal and force turned round
    rows = np.repeat(np.arange(len(pair_key)), np.where(between, 2, 1))
    second = np.zeros(len(rows), dtype=bool)
    second[1:] = rows[1:] == rows[:-1]
    flip = np.where(second, -1.0, 1.0)[:, None]
    return PairSides(body=np.where(second, other[rows], pair_body[rows]),
                     other=np.where(second, pair_body[rows], other[rows]), ground=ground[rows],
                     point_W=point[rows], normal_W=flip * normal[rows], gap=gap[rows], force_W=flip * force[rows],
                     sliding=slipping[rows])


def _sums(inverse: np.ndarray, values: np.ndarray, count: int) -> np.ndarray:
    """(count, 3) sums of the (n, 3) ``values`` grouped by ``inverse`` (n,)."""
    return np.stack([np.bincount(inverse, weights=values[:, k], minlength=count) for k in range(3)], axis=1)
