"""Islands: bodies resting on bodies stepped together by a first-order velocity step (driver of kernels/contact/island.py).

Each step, before the body–body event pass, the swept broad phase's candidate pairs are joined by
union-find; a component with a pair touching at the step's start (or a sleeping body) is an
island and is stepped by one compiled call (:func:`~rigid_body_sim.core.kernels.contact.island.island_pass`:
Moreau–Jean / Stewart–Trinkle velocity step with normal non-penetration and Coulomb friction, the
case where nothing slides solved exactly, else projected Gauss–Seidel, then the projection of the
positions onto the contact manifold). Its bodies are then left out of the event-driven passes for
that step, and kept in flight mode (``ContactSolver.modes``): a body out of its island
(:attr:`Islands.left`) is handed to its ground by ``ContactSolver.after_step`` (persistent contact
from the step's start if it touches its ground and does not move away, that step taken again held).
Bodies in no island run exactly the event-driven code they ran before islands existed.

Sleeping (``ContactSolver.sleeping``, default False): a component of an island (the bodies joined by
the step's contacts) whose bodies stayed slower than ``ContactSolver.sleep_speed`` (SLEEP_SPEED: at rest, unless
raised; then for SLEEP_STEPS steps in a row) is locked, its rows copied forward,
until a wrench on one of its bodies, a changed state (an impulse, ``set_state``, ``set_body_state``)
or another awake body within reach wakes it. Its contacts from the step it fell asleep in are kept
and listed with every step's (:meth:`Islands.contacts`), each with the force it held its bodies with
then: a locked island is still held. A scene wholly asleep (:meth:`Islands.all_asleep`: every moving body
asleep, none pushed, stopped or set) is not stepped: the simulator carries its state over and
:meth:`Islands.asleep_step` lists and logs the locked contacts, as the island pass would have. A body woken is
solved from that rest: the locked contacts are the warm start of its next step (the island pass's), and
its component's first Gauss–Seidel solve gets WOKEN_SWEEPS (so does the step after one the energy step set back
at rest). A body resting alone on a half-space (the ground
pass's) sleeps by the same rule (:meth:`Islands.rest_alone`): it keeps its mode, ground and holding force.
"""

from __future__ import annotations

import numpy as np

from ..kernels import layout as L
from ..kernels.contact.island import (C_FLOATS, C_IMPULSE, C_INTS, DENSE_MAX, I_A, I_B, OUT_BODIES, OUT_CONTACTS,
                                      OUT_DEPTH, OUT_JOINED, OUT_LATE, OUT_LATE_LOST, OUT_SLEPT, OUT_WIDTH, OUT_WOKEN,
                                      all_asleep, island_pass, rest_alone)
from ..kernels.contact.layout import DIMS, FLIGHT, PERSISTENT
from ..kernels.contact.pairs import MAX_PAIR_POINTS
from .island_contacts import IslandContactLog, body_sides
from .materials import DEFAULT_FRICTION

__all__ = ["Islands"]


class Islands:
    """The island pass of a ContactSolver (module docstring); made by BodyPairs, run from ContactSolver.after_step."""

    def __init__(self, solver, sim, pairs) -> None:
        self.solver, self.pairs = solver, pairs
        n = len(solver.shapes)
        shapes = solver.shapes
        self.members = np.ascontiguousarray(solver.bodies, dtype=np.int64)
        self.size = np.ascontiguousarray(shapes[:, DIMS:DIMS + 3].max(axis=1) * 2.0)
        self.island = np.zeros(n, dtype=np.int64)  # 1: stepped by the island pass this step, 2: asleep
        self.was_island = np.zeros(n, dtype=bool)
        #: The bodies out of their island this step (in it the step before); set by each step's body–body pass.
        self.left = np.zeros(0, dtype=np.int64)
        self.asleep = np.zeros(n, dtype=np.int64)
        self._roused = np.zeros(n, dtype=np.int64)  # woken, until its first island step (island_pass)
        self._wait = np.zeros(n, dtype=np.int64)  # steps before a body's component is tried for the exact solve
        self._skips = np.zeros((n, 2), dtype=np.int64)  # steps in a row its component, due, was not tried; slipped
        self._still = np.zeros(n, dtype=np.int64)  # steps in a row at rest by the sleep rule (< 0: set back at rest)
        self._anchor = np.zeros((n, 7))  # where its run at rest began (position, quaternion)
        self._alone_still = np.zeros(n, dtype=np.int64)  # the same, resting alone on its ground (rest_alone)
        self.saved = np.zeros((n, L.STATE_WIDTH))
        self._parent = np.arange(n, dtype=np.int64)
        self._flags = np.zeros(n, dtype=np.int64)
        self._pos, self._quat = np.zeros((n, 3)), np.zeros((n, 4))
        self._rot = np.zeros((n, 10))  # the narrow phase's: each shape's rotation, and whether taken
        self._vel, self._iw, self._dx = np.zeros((n, 6)), np.zeros((n, 9)), np.zeros((n, 6))
        self._bwork, self._blist = np.zeros((n, 13)), np.zeros(n, dtype=np.int64)  # the pile solve's extrapolation
        self._cstart = np.zeros(n, dtype=np.int64)
        self._comp = np.zeros(n, dtype=np.int64)  # the velocity step's components (bodies joined by contacts)
        self._A, self._L = np.zeros((DENSE_MAX, DENSE_MAX)), np.zeros((DENSE_MAX, DENSE_MAX))
        self._vec = np.zeros((3, DENSE_MAX))
        self._band = np.zeros((2, DENSE_MAX), dtype=np.int64)  # the sticking solve's profile, points on
        self._group = np.zeros(n, dtype=np.int64)  # a sleeping body's component when it fell asleep
        self._lhead = np.zeros(n, dtype=np.int64)  # _late_pairs' scratch: per body, per broad phase member
        self._found = np.zeros(len(pairs.members), dtype=np.int64)
        self._lifts = np.zeros(n)  # island_pass' scratch (_no_gain)
        self.out = np.zeros(OUT_WIDTH)
        self._grow_pairs(16)
        self._grow_contacts(64)
        #: Body-steps taken by the island pass (first order) since the solver was made or reset.
        self.body_steps = 0
        #: Largest depth (m) the position projection closed since the solver was made or reset.
        self.deepest = 0.0
        #: How many contacts the last step's velocity problem had (rows of :meth:`contacts`; its λ warm-start the
        #: next step's); 0 after a step without islands.
        self.n_contacts = 0
        #: Each pair's impulse summed over the steps since last taken; the last step's states (island_contacts.py).
        self.log = IslandContactLog(n, len(solver.half_spaces))
        #: The contacts of the islands asleep, from the step they fell asleep in (ints, floats as :meth:`contacts`,
        #: the C_IMPULSE columns a force, N): they hold the same bodies still, and are listed with each step's.
        self._rest_int, self._rest_flt = np.zeros((0, C_INTS), dtype=np.int64), np.zeros((0, C_FLOATS))
        self._h = 0.0
        #: Per body, Σ island contact impulse (N·s, then N·m·s about the centre of mass at each step's start),
        #: world axes, since the solver was made or reset, kept while ``ContactSolver.track_torques``.
        self.impulses = np.zeros((n, 6))

    def _grow_pairs(self, k: int) -> None:
        n = len(self.island)
        self._nlist = np.zeros((k, 2), dtype=np.int64)
        self._pdist, self._pnormal = np.zeros(k), np.zeros((k, 3))
        self._pcount = np.zeros(k, dtype=np.int64)
        self._ppoints, self._pseps = np.zeros((k, MAX_PAIR_POINTS, 6)), np.zeros((k, MAX_PAIR_POINTS))
        self._bound = np.zeros(k + n)
        self._lnext = np.zeros(2 * k, dtype=np.int64)  # _late_pairs': each body's rows of the pair list

    def _grow_contacts(self, c: int) -> None:
        """Room for c contacts in each half of the scratch (the velocity step's, the projection's); the last
        step's contacts (the first half) kept."""
        old_int, old_flt = getattr(self, "_cint", None), getattr(self, "_cflt", None)
        self._cint, self._cflt = np.zeros((2 * c, C_INTS), dtype=np.int64), np.zeros((2 * c, C_FLOATS))
        if old_int is not None:
            kept = min(len(old_int) // 2, c)
            self._cint[:kept], self._cflt[:kept] = old_int[:kept], old_flt[:kept]
        self._order = np.zeros(c, dtype=np.int64)
        r = 4 * c  # 3 rows per velocity contact, then 1 per projection contact
        self._rj, self._rw = np.zeros((r, 12)), np.zeros((r, 12))
        self._rdiag, self._rbias, self._rlam = np.zeros(r), np.zeros(r), np.zeros(r)
        self._rbody = np.zeros((r, 2), dtype=np.int64)
        self._cwork, self._rwork = np.zeros((2 * c, 3)), np.zeros((r, 3))  # the solves' and sorts' scratch

    def reset(self) -> None:
        """Every body awake and out of the islands; the counts cleared."""
        self.island[:] = 0
        self.was_island[:] = False
        self.left = np.zeros(0, dtype=np.int64)
        self.asleep[:] = 0
        self._roused[:] = 0
        self._wait[:] = 0
        self._skips[:] = 0
        self._still[:] = 0
        self._alone_still[:] = 0
        self.body_steps = 0
        self.deepest = 0.0
        self.n_contacts = 0
        self.log.clear()
        self._rest_int, self._rest_flt = self._rest_int[:0], self._rest_flt[:0]
        self.impulses[:] = 0.0

    def wake_all(self) -> None:
        """Every sleeping body awake (sleeping turned off): each is solved from the rest it was locked in."""
        self._roused[self.asleep != 0] = 1
        self.asleep[:] = 0

    def wake_group(self, i: int) -> None:
        """The bodies asleep with body i (fallen asleep in its component) awake, each solved from its rest."""
        if self.asleep[i]:
            woken = (self.asleep != 0) & (self._group == self._group[i])
            self._roused[woken] = 1
            self.asleep[woken] = 0

    def in_islands(self) -> np.ndarray:
        """Per body, whether the last step stepped it in an island or kept it asleep in one (a body asleep alone on
        its ground, still in persistent contact, is not)."""
        return (self.island != 0) & (self.solver.modes != PERSISTENT)

    def contacts(self) -> tuple[np.ndarray, np.ndarray]:
        """The last step's island contacts (views, valid until the next step): ints (n, C_INTS) — bodies a and b
        (−1: fixed), the static body (−1: none), the half-space index (−1: none) — and floats (n, C_FLOATS) —
        point (world, m, mid-way between the surfaces at the step's start), normal from a to b (world), gap at
        the step's start (m), μ, the impulse on b over the step (world, N·s; a takes its opposite). Column
        indices: kernels/contact/island.py (I_A ..., C_X ...). Then the contacts of the islands asleep, from
        the step they fell asleep in, each impulse its force then × this step's length (copies)."""
        n = self.n_contacts
        if not len(self._rest_int):
            return self._cint[:n], self._cflt[:n]
        resting = self._rest_flt.copy()
        resting[:, C_IMPULSE:C_IMPULSE + 3] *= self._h  # the force holding them over this step
        return np.concatenate((self._cint[:n], self._rest_int)), np.concatenate((self._cflt[:n], resting))

    def _add_impulses(self, Y0: np.ndarray, ints: np.ndarray, floats: np.ndarray) -> None:
        """Each contact's impulse on each moving side and its moment about that body's centre of mass at the
        step's start, added to :attr:`impulses`."""
        body, point, impulse = body_sides(ints, floats)
        np.add.at(self.impulses[:, 0:3], body, impulse)
        np.add.at(self.impulses[:, 3:6], body, np.cross(point - Y0[body, L.P:L.P + 3], impulse))

    def _keep_resting(self, was_asleep: np.ndarray, h: float) -> None:
        """After a step: the contacts of the bodies that fell asleep in it kept (as forces), those of the bodies
        woken dropped."""
        asleep = self.asleep != 0
        if len(self._rest_int):
            side = np.maximum(self._rest_int[:, I_A], self._rest_int[:, I_B])  # a moving body of each
            keep = asleep[side]
            if not keep.all():
                self._rest_int, self._rest_flt = self._rest_int[keep], self._rest_flt[keep]
        fell = asleep & ~was_asleep
        if fell.any() and self.n_contacts:
            ints, floats = self._cint[:self.n_contacts], self._cflt[:self.n_contacts]
            side = np.maximum(ints[:, I_A], ints[:, I_B])
            new = fell[side]
            forces = floats[new].copy()
            forces[:, C_IMPULSE:C_IMPULSE + 3] /= h
            self._rest_int = np.concatenate((self._rest_int, ints[new]))
            self._rest_flt = np.concatenate((self._rest_flt, forces))

    def _record(self, Y0: np.ndarray, Y1: np.ndarray, h: float) -> None:
        """The step's contacts (its own and the asleep islands') into the log and the impulses, for their readers."""
        self._h = h
        solver = self.solver
        wanted = self.log.summing or solver.track_torques  # the asleep rows copied only for a reader
        ints, floats = self.contacts() if wanted else (self._cint[:self.n_contacts], self._cflt[:self.n_contacts])
        self.log.add(Y0, Y1, np.flatnonzero(self.island == 1), ints, floats, h)
        if solver.track_torques and len(ints):
            self._add_impulses(Y0, ints, floats)

    def all_asleep(self, sim, wrenches: np.ndarray, Y0: np.ndarray) -> bool:
        """Whether no body moves in the step from Y0: every moving body of the simulator asleep, none pushed by
        ``wrenches``, stopped, or set (kernels/contact/island.all_asleep); then :meth:`asleep_step` is the step."""
        return all_asleep(Y0, self.saved, wrenches, sim._stopped, self.asleep, sim._members)

    def rest_alone(self, alone: np.ndarray, Y0: np.ndarray, Y1: np.ndarray, h: float) -> np.ndarray:
        """Sleeping for ``alone`` (int64, global indices), the bodies the ground pass held alone on their ground over
        the step Y0 → Y1 (ContactSolver, after its step): each at rest by an island's rule as long as an island's
        bodies must be falls asleep, its velocities zeroed in Y1 (kernels/contact/island.rest_alone). Returns those
        that fell asleep."""
        kept = self._alone_still[alone]  # a run at rest alone ends when the body is not alone
        self._alone_still[:] = 0
        self._alone_still[alone] = kept
        # the anchor is the islands': a run in either begins by setting it (a body is in one or the other)
        rest_alone(Y0, Y1, alone, self.pairs.spin_reach, self._alone_still, self._anchor, self.asleep, self.saved,
                   self._group, float(self.solver.sleep_speed), h)
        fell = alone[self.asleep[alone] != 0]
        self.was_island[fell] = True  # woken, out of its island of one: its step is taken again held (left)
        return fell

    def asleep_step(self, Y0: np.ndarray, Y1: np.ndarray, h: float) -> None:
        """The islands' step when :meth:`all_asleep` (Y1 a copy of Y0): what :meth:`step` leaves then, its locked
        islands' contacts listed and logged, at the cost of the log alone."""
        self.left = self.left[:0]
        self.n_contacts = 0
        self.out[:] = 0.0
        self._record(Y0, Y1, h)

    def step(self, sim, wrenches: np.ndarray, Y0: np.ndarray, Y1: np.ndarray, cand: np.ndarray, h: float) -> np.ndarray:
        """The islands' step over the candidate pairs ``cand`` (k, 2) of global body indices; returns the mask of
        the bodies it stepped (or kept asleep)."""
        solver = self.solver
        if len(cand) > len(self._nlist):
            self._grow_pairs(2 * len(cand))
        args_head = (Y0, Y1, sim._prm, wrenches, solver._bare_rows, solver.modes, self.saved, solver.shapes,
                     solver.half_spaces, solver.half_space_friction, self.members, cand, len(cand),
                     self.pairs.is_static, sim._stopped, self.pairs.spin_reach, self.size, self.asleep, self._roused,
                     self._wait, self._skips, self._still, self._anchor, h, bool(solver.sleeping),
                     float(solver.sleep_speed), DEFAULT_FRICTION, float(solver.penetration_tolerance), self.n_contacts,
                     self._rest_int, self._rest_flt, self.island, self._parent, self._flags)
        was_asleep = self.asleep != 0
        while True:
            code = island_pass(*args_head, self._nlist, self._pos, self._quat, self._rot, self._pdist, self._pnormal,
                               self._pcount, self._ppoints, self._pseps, self._bound, self._cint, self._cflt, self._vel,
                               self._iw, self._dx, self._rj, self._rw, self._rdiag, self._rbias, self._rlam,
                               self._rbody, self._order, self._cstart, self._A, self._L, self._vec, self.out, self._comp,
                               self._band, self._group, self._cwork, self._rwork, self._bwork, self._blist,
                               self.pairs.broad_phase(), self._lhead, self._lnext, self._found, self._lifts,
                               self.pairs.deflection)
            if code >= 0:
                break
            self._grow_contacts(2 * -code)
        out = self.out
        if out[OUT_LATE_LOST]:  # room for the pairs left out, from the next step
            self._grow_pairs(2 * len(self._nlist))
        self.n_contacts = int(out[OUT_CONTACTS])
        self._keep_resting(was_asleep, h)
        self._record(Y0, Y1, h)
        self.body_steps += int(out[OUT_BODIES])
        solver.counts["island_body_steps"] += int(out[OUT_BODIES])
        solver.counts["island_late_pairs"] += int(out[OUT_LATE])
        solver.counts["island_late_joined"] += int(out[OUT_JOINED])
        self.deepest = max(self.deepest, float(out[OUT_DEPTH]))
        now = self.island != 0
        stepped = self.island == 1
        if stepped.any():  # in the island: not held by the ground pass (asleep, a body keeps its mode)
            solver.modes[stepped] = FLIGHT
            solver.ground_of[stepped] = -1
            solver.sliding[stepped] = False
        self.left = np.flatnonzero(self.was_island & ~now)  # handed to their ground by ContactSolver.after_step
        self.was_island = now
        return now
