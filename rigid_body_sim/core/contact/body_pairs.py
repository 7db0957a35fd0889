"""Impacts between moving bodies, and no tunnelling through thin shapes: the body–body pass of the contact solver.

The ground's mechanism (solver.py) extended to pairs of bodies: events are located on the
bodies' own step maps, the impact law acts at the located state, the rest of the step follows.
After each step, before the ground pass:

1. **Swept broad phase** (compiled, no allocation; kernels/contact/swept.py): every moving body
   with a shape and every static shape gets the world box its bounding sphere stays in over the
   step; overlapping boxes, found with a hashed uniform grid, whose bounding spheres can meet over
   the step, are the candidate pairs. Where two moving bodies are candidates, a hit between them
   can send each off its free path by at most h × a bound on its change of velocity (swept.deflections):
   the broad phase is taken again with those spheres grown by that, and the islands' reach too. A
   step without a candidate costs these compiled loops and nothing else (no Python per body or per
   pair).
2. **Narrow phase** on the candidates (one compiled call, kernels/contact/swept.py's screen_pairs:
   two boxes provably apart over the whole step are left out, the others' signed distances taken at the
   step's end and at its start, batched; kernels/contact/pairs.py). A pair of moving bodies meets in
   the step if its signed distance is negative at the end, or it overlaps at the start while
   approaching; a pair apart at both ends (d₀, d₁ ≥ 0) that could have met in between
   (d₀ + d₁ ≤ B h, B the bound on |d′| below) is followed along the step by **conservative
   advancement** (below), so that an event which starts and ends inside one step is still found.
   A body against a static shape is looked at here only in that last case (a passage through it
   inside the step); a negative distance at the step's end is the ground pass's
   (static_geometry.py).
3. **Groups**: bodies linked by such pairs are stepped together, event after event, from the
   step's start. Each event time is the first root of s ↦ F(s), F the least of the group's pair
   signed distances d(Φ_a(y_a0, s h), Φ_b(y_b0, s h)), of its flying members' gaps to the
   ground and the static shapes, of its held members' gaps to the other half-spaces and static
   shapes (a wall a body sliding on the ground meets; one it touches at a piece's start and goes
   into is struck at once, _strike_wall, and stays in view) and of their features not on their ground
   (a tipping box's other edge coming down: its landing, solver._landing, and it is held again),
   Φ each body's own step map (solver.step_map). A pair touching at a piece's start and not
   approaching (just struck; sliding on the other), or met without approaching (grazing), is
   followed too, to a skin ε_k deeper than it was then: it sets no sample's length, its sign
   is read at every sample; met there approaching, it is moved apart (item 5) and has its
   impacts, and so has every other pair so followed that approaches at that instant.
   Conservative advancement finds a sample where F < 0: from s, the next
   sample is s + (F_k + ε_k)/(B_k h) over the components k, with B_k a bound on |dF_k/dt|
   (relative speed plus spin × bounding radius, the largest over the piece; a sphere's spin does
   not count) and ε_k = 1e-4 × the pair's size; no component can cross zero between samples
   (past MAX_ADVANCE samples, the piece's end is looked at). The root in the bracket is found
   by the solver's Illinois method, to round-off. A flying member touching its ground or a static
   shape at a piece's start (within its feature band, or just struck) has its next meeting with
   them located on its own step map instead, as the ground pass locates it (solver._with_events);
   the piece ends there. While a member is held on a cylinder rim whose
   lowest point turns fast, the events are looked for piece by piece (solver._rim_piece), each
   piece of that member held with its holding force found afresh.
4. **At a pair's root** the two-body impact law (kernels/contact/pair_impacts.py) acts at the
   narrow phase's contact points (mid-way between the two surfaces' points) and normal, with the
   pair's material (materials.pair_material). The pairs touching at that instant are solved
   together in sequential rounds (:meth:`BodyPairs._impacts`): each approaching pair's law in
   turn and, for a member resting on the ground that a pair drives into it, the ground's law
   (impacts.impact on its tracked contact points), and the same for a wall it touches (its second
   ground, or another half-space or static shape within its feature band), until nothing approaches
   (MAX_SEQUENTIAL rounds at most): for e = 0 the simultaneous inelastic impact, for e > 0 a
   sequential answer (docs/contact.md, "Between bodies"). A resting member stays held if any of its
   contact points still presses on its ground, else it lifts off; one still held whose velocity
   changed has its holding force (and whether it slides) found afresh. One event per body and pair
   (``other`` names the other body; a body's velocity jumps are split over its events so that they
   add up). At a flying member's ground or static-shape root, the ground's impact law
   (solver._impact; a rebound too small to resolve: its rest); at a held member's wall root, that
   wall's (solver._strike_side). After any event every member goes on in the group, its pairs
   still followed: one come to rest is held there with its holding force, one lifted off flies. A
   pair met without approaching more than MAX_GRAZES times in a step is not looked at again in it.
5. **Touching at a piece's start**: a pair overlapping (or touching, TOUCHING) at the start of
   a step or of a piece and approaching has its impacts there; if it overlaps, it is first moved
   apart along the normal by the depth, shared by inverse mass (a held member does not move).
6. **Looked at again** (:meth:`BodyPairs.look_again`, after the ground pass): items 1–2 screen the
   free paths, and a ground, a static shape or a third body can send a body into one that was no
   candidate or no hit. The candidates of a body whose end the passes changed are looked at at
   the ends as stepped, and a body whose box over its path as stepped left its free step's box is
   screened again (the grid, then the bounding spheres on the chords as stepped); two moving
   bodies ending more than ε_k inside each other, in no group together, have their steps taken
   again from the step's start in one group with the pair linked (the solver's state of its bodies
   and their events of the step set back first; counted as ``pairs_looked_again``), up to
   MAX_LOOKS rounds.

Resting contact between bodies is the islands' (island.py): before the pass, components of the
candidate pairs with a pair touching at the step's start and resting there (its normal speed
within twice the change the step's forces make to it: else striking, an impact of item 5, or
parting), or striking with restitution 0 or with a body held on its ground (the velocity step is then
its inelastic impact, with the bodies' other contacts), are stepped together by a first-order velocity step and left out of this pass. A body
meeting another outside an island is kept up by the impacts of item 5 at each step's start until
the two form an island at the next step (within that step it is followed to ε_k deeper than it
touched, then moved back out, two held ones each within its ground's plane: counted in
:attr:`BodyPairs.separations`; so are two members of a group that its held members' ends, projected onto their
grounds, leave inside each other: :meth:`BodyPairs._part`).
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import layout as L
from ..kernels.contact.impacts import IMPACT_WORK_SHAPE, impact, kinetic_energy_row
from ..kernels.contact.island import APPROACH_SPEED  # a relative normal velocity below −this (m/s) approaches
from ..kernels.contact.layout import DIMS, KIND, MAX_POINTS, NORMAL, PERSISTENT, FLIGHT, SHAPE_SPHERE
from ..kernels.contact.pair_impacts import PAIR_JACOBIAN_SHAPE, normal_speed, pair_impact
from ..kernels.contact.pairs import MAX_PAIR_POINTS, pair_contacts
from ..kernels.contact.persistent import normal_speeds
from ..kernels.contact.shapes import body_points
from ..kernels.contact.swept import deflections, left_pairs, screen_pairs, swept_bounds
from ..quaternion import quat_multiply, quat_rotate
from .events import ZENO_IMPACTS, ContactEvent
from .island import Islands
from .materials import pair_material
from .static_geometry import bounding_radius
from .swept_pairs import SweptPairs
from .two_grounds import crease

__all__ = ["BodyPairs", "ADVANCE_SKIN", "MAX_ADVANCE"]

#: Conservative advancement aims at this × the pair's size below contact (m per m), so that it ends on a
#: sample inside; a passage shallower than this that starts and ends inside one step may be missed.
ADVANCE_SKIN = 1e-4
#: Most conservative-advancement samples in one piece of a step (then the step's end is trusted).
MAX_ADVANCE = 400
#: Most rounds of a pair's impact and its members' ground impacts at one instant (module docstring, 4).
MAX_SEQUENTIAL = 200
#: Most events of one group in one step (more is reported as an error, not looped on).
MAX_GROUP_EVENTS = 10_000
#: Most times a pair is met without approaching in one step (then it is not looked at again in that step).
MAX_GRAZES = 8
#: Most rounds of look_again in one step.
MAX_LOOKS = 4
#: The solver's per-body state that look_again sets back to the step's start before a group's step is taken again.
_RESTORED = ("modes", "tracked", "sliding", "slide_direction", "pressed", "ground_of", "other_ground",
             "other_projected", "other_tracked", "impact_impulses")
#: Rounds of impacts at one piece's start before the pairs still approaching are left for the piece.
MAX_ROUNDS = 10
#: Two held members are moved apart each in its ground's plane (BodyPairs._slide_apart) when the normal's parts in
#: those planes, squared and weighted by inverse mass, are at least this share of Σ m⁻¹: on one ground, the move is
#: then at most three times the depth.
PART_SHARE = 1.0 / 9.0
#: A pair whose signed distance is below this × its size (m per m) touches.
TOUCHING = 1e-12
#: A resting body whose contact points move away from its ground faster than this (m/s) lifts off.
LIFT_OFF_SPEED = 1e-9


class BodyPairs:
    """The body–body pass of a :class:`~rigid_body_sim.core.contact.solver.ContactSolver` (module docstring).

    Parameters
    ----------
    solver : ContactSolver
    sim : Simulator
    statics : ndarray of int
        The static bodies with a shape (static_geometry.static_shapes).
    """

    def __init__(self, solver, sim, statics: np.ndarray) -> None:
        self.solver = solver
        shapes = solver.shapes
        #: Members of the broad phase: the moving bodies with a shape, then the static shapes.
        self.members = np.concatenate((solver.bodies, statics)).astype(np.int64)
        m = len(self.members)
        self.movable = np.zeros(m, dtype=np.bool_)
        self.movable[:len(solver.bodies)] = True
        self._fixed = np.flatnonzero(~self.movable).astype(np.int64)
        radius = np.array([bounding_radius(shapes[i]) for i in range(len(shapes))])  # per body, m
        self.reach = radius[self.members]
        #: Per body: the radius its spin sweeps (0 for a sphere, whose distance its spin does not change).
        self.spin_reach = np.where(shapes[:, KIND] == SHAPE_SPHERE, 0.0, radius)
        self.size = shapes[:, DIMS:DIMS + 3].max(axis=1)
        self._skin = ADVANCE_SKIN * self.size[self.members]  # per member (m): a deflection within it is left out
        self._grown = np.zeros(m)  # per member: its reach grown by h × its deflection (_candidates)
        #: Per body: the change of velocity (m/s) a hit in this step may give it (_candidates; 0 within its skin).
        self.deflection = np.zeros(len(shapes))
        self.is_static = np.zeros(len(shapes), dtype=bool)
        self.is_static[statics] = True
        self._lo, self._hi = np.empty((m, 3)), np.empty((m, 3))
        self._cells, self._chain = np.empty((m, 3), dtype=np.int64), np.empty(m, dtype=np.int64)
        self._heads = np.empty(1 << max(4, int(2 * m - 1).bit_length()), dtype=np.int64)  # ≥ 2 M buckets
        grid = (self.members, self.movable, self._lo, self._hi, self._cells, self._heads, self._chain)
        self._swept, self._swept_grown = SweptPairs(*grid), SweptPairs(*grid)  # the spheres; grown (_candidates)
        self._last_swept = None  # (lo, hi as bytes, candidate pairs) of the last broad phase: reused while the boxes are
        # bitwise equal (a bytes comparison: a fraction of np.array_equal's cost on a few bodies' boxes)
        self._q_PB = sim._prm[:, L.Q_PB:L.Q_PB + 4].copy()
        self._shapes = np.ascontiguousarray(shapes)
        # the candidates' screen (screen_pairs): each body's poses at the step's ends, per pair what it found
        self._spos, self._squat, self._lower = np.zeros((2, len(shapes), 3)), np.zeros((2, len(shapes), 4)), np.empty(1)
        self._grow_screen(64)
        # two-shape narrow-phase buffers
        self._pos2, self._quat2 = np.zeros((2, 3)), np.zeros((2, 4))
        self._shape2 = np.zeros((2, shapes.shape[1]))
        self._pair2 = np.array([[0, 1]], dtype=np.int64)
        self._dist1, self._normal1, self._count1 = np.empty(1), np.empty((1, 3)), np.zeros(1, dtype=np.int64)
        self._points1, self._seps1 = np.empty((1, MAX_PAIR_POINTS, 6)), np.empty((1, MAX_PAIR_POINTS))
        self._jac = np.zeros(PAIR_JACOBIAN_SHAPE)
        self._work = np.zeros(IMPACT_WORK_SHAPE)
        self._step_wrenches = np.zeros((len(shapes), L.WRENCH_WIDTH))  # the wrench rows of the step being looked at
        #: Impacts between moving bodies since the solver was made or reset.
        self.impacts = 0
        #: Pairs found overlapping at a step's start, or at a group's end with a held member, and moved apart
        #: (a body lying on another, a can projected into its partner: module docstring).
        self.separations = 0
        self._look: dict | None = None  # what look_again looks at: the step's candidates, hits, bodies left alone
        self._start = {name: getattr(solver, name).copy() for name in _RESTORED}  # (after_step keeps them)
        # look_again's screen (swept.left_pairs): boxes over the paths as stepped, the members that left theirs,
        # the grid's answers and the pairs found
        self._alo, self._ahi, self._left = np.empty((m, 3)), np.empty((m, 3)), np.empty(m, dtype=np.int64)
        self._found, self._left_pairs = np.empty(max(m, 16), dtype=np.int64), np.empty((64, 2), dtype=np.int64)
        #: Bodies resting on bodies, stepped together (island.py).
        self.islands = Islands(solver, sim, self)
        #: per body: whether it met another moving body in the last step (an island's or a group's step): contact
        #: passed energy to it from another body, which its blow-up bound does not count (ContactSolver)
        self.exchanged = np.zeros(len(shapes), dtype=bool)

    # ----------------------------------------------------------------- geometry

    def _shape_pose(self, y: np.ndarray, i: int) -> tuple[np.ndarray, np.ndarray]:
        return y[L.P:L.P + 3], quat_multiply(y[L.Q:L.Q + 4], self._q_PB[i])

    def contact(self, ya: np.ndarray, a: int, yb: np.ndarray, b: int) -> float:
        """Signed distance (m) of bodies a and b at state rows ya, yb; normal, points left in the buffers."""
        self._pos2[0], self._quat2[0] = self._shape_pose(ya, a)
        self._pos2[1], self._quat2[1] = self._shape_pose(yb, b)
        self._shape2[0], self._shape2[1] = self._shapes[a], self._shapes[b]
        pair_contacts(self._pos2, self._quat2, self._shape2, self._pair2, self._dist1, self._normal1, self._count1,
                      self._points1, self._seps1)
        return float(self._dist1[0])

    def _geometry(self) -> tuple[np.ndarray, np.ndarray, float]:
        """(normal from a to b (3,), contact points (k, 3) mid-way between the surfaces, signed distance) of the
        last :meth:`contact` call."""
        count = int(self._count1[0])
        points = 0.5 * (self._points1[0, :count, 0:3] + self._points1[0, :count, 3:6])
        return self._normal1[0].copy(), _spanning(points), float(self._dist1[0])

    @staticmethod
    def _relative_normal_speed(ya, yb, n, points) -> float:
        """The least normal velocity of b over a at the contact points (k, 3) (m/s, < 0 approaching)."""
        return min((normal_speed(ya, yb, n[0], n[1], n[2], x[0], x[1], x[2]) for x in points), default=math.inf)

    # ----------------------------------------------------------------- after the step

    @property
    def modes_at_start(self) -> np.ndarray:
        """Per body, the solver's contact mode as the step began (after_step's copy; not to be written)."""
        return self._start["modes"]

    def after_step(self, sim, wrenches: np.ndarray, Y0: np.ndarray, Y1: np.ndarray, t0: float,
                   h: float) -> np.ndarray | None:
        """Find and resolve the step's body–body events; the bodies done here as a bool mask (None: none)."""
        solver = self.solver
        self.exchanged.fill(False)
        for name in _RESTORED:  # as the step began, for look_again
            np.copyto(self._start[name], getattr(solver, name))
        self._look = {"events": len(solver.events), "pairs": np.zeros((0, 2), dtype=np.int64), "hits": [],
                      "kept": self.is_static | sim._stopped}
        pairs = self._candidates(sim._prm, Y0, Y1, h)
        found = len(pairs)
        islands = self.islands
        islands.left = islands.left[:0]  # none out of their island this step unless the islands' step says so
        held = islands.was_island.any() or islands.asleep.any()  # islands from the last step to go on with
        if found == 0 and not held:
            islands.n_contacts = 0
            return None
        in_island = None
        if found or held:  # islands first (island.py)
            in_island = islands.step(sim, wrenches, Y0, Y1, pairs, h)
            self.exchanged |= in_island
            self._look["kept"] = self._look["kept"] | in_island
            if in_island[self.solver.bodies].all():  # every pair has a moving body first: none is left
                pairs = pairs[:0]
            elif in_island.any():
                pairs = pairs[~(in_island[pairs[:, 0]] | in_island[pairs[:, 1]])]
            else:
                in_island = None
        stopped = sim._stopped
        if len(pairs) and stopped.any():
            pairs = pairs[~(stopped[pairs[:, 0]] | stopped[pairs[:, 1]])]
        if not len(pairs):
            return in_island
        self._step_wrenches = wrenches
        hits = self._hits(sim, pairs, Y0, Y1, h)
        moving = np.unique(pairs[~self.is_static[pairs]])
        self._look.update(pairs=pairs, hits=list(hits), moving=moving, free=Y1[moving, :L.STATE_WIDTH].copy())
        if not hits:
            return in_island
        done = np.zeros(len(sim._stopped), dtype=bool) if in_island is None else in_island.copy()
        # a body whose path may pass through a static shape (the shape is no member of its group): once held on its
        # ground in the group's step, its rest of the step on the ground pass looks along its path for the shape
        # (solver._persistent_end), as for one screened so while held (a box thrown from rest at a wall, struck onto
        # its ground at the step's start, slid on through the wall)
        self.solver.may_pass.update(a for a, b in hits if self.is_static[b])
        for group in _groups(hits, self.is_static):
            links = [p for p in map(tuple, pairs.tolist()) if p[0] in group and p[1] in group]
            members = sorted(group)
            self._group_step(sim, members, links, Y0, Y1, wrenches, t0, h)
            done[members] = True
        return done

    def look_again(self, sim, wrenches: np.ndarray, Y0: np.ndarray, Y1: np.ndarray, t0: float, h: float) -> None:
        """After the ground pass: two moving bodies that end the step more than the skin (ADVANCE_SKIN × the pair's
        size) inside each other, in no group together, have their steps taken again from the step's start, in one
        group with the pair linked. The candidates were screened on free paths, and a ground, a static shape or a
        third body can send a body into one that was no candidate or no hit: looked at again are the candidates of
        a body whose end the passes changed (at their ends), and the bodies a body whose box over its path as
        stepped (swept_bounds from the step's start to its end) left its free step's box may meet (the broad
        phase's grid, then the bounding spheres on the chords as stepped). A group's bodies are first set back as
        the step began (the solver's state of each, _RESTORED) and their events of the step dropped. Up to
        MAX_LOOKS rounds (a step taken again may meet another body)."""
        look, self._look = self._look, None
        if look is None:
            return
        kept, hits, pairs = look["kept"], look["hits"], look["pairs"]
        left = self.islands.left  # out of their island this step: those held from its start were stepped again
        kept[left[self.solver.modes[left] == PERSISTENT]] = True  # held (_out_of_islands); in flight, like any other
        links: set = set()  # pairs looked at again, followed by a group stepped again
        for _ in range(MAX_LOOKS):
            near = set()
            if "moving" in look:  # the candidates of a body whose end changed
                moving, changed = look["moving"], np.zeros(len(kept), dtype=bool)
                changed[moving] = np.any(Y1[moving, :L.STATE_WIDTH] != look["free"], axis=1)
                changed &= ~kept
                these = pairs[(changed[pairs[:, 0]] | changed[pairs[:, 1]]) & ~kept[pairs[:, 0]] & ~kept[pairs[:, 1]]]
                near.update(map(tuple, these.tolist()))
            # a body an event sent out of its free step's box (none without an event), and whom it may have met
            while len(self.solver.events) > look["events"]:
                _, count = left_pairs(Y0, Y1, self.members, self.reach, h, self._lo, self._hi, self.movable,
                                      self._fixed, kept, self._cells, self._heads, self._chain, self._alo, self._ahi,
                                      self._left, self._found, self._left_pairs)
                if count <= len(self._left_pairs):
                    near.update(map(tuple, np.sort(self.members[self._left_pairs[:count]], axis=1).tolist()))
                    break
                self._left_pairs = np.empty((2 * count, 2), dtype=np.int64)
            if not near:
                return
            rows = np.array(sorted(near), dtype=np.int64)
            k = len(rows)
            if k > len(self._reach):
                self._grow_screen(2 * k)
            screen_pairs(Y0, Y1, self._q_PB, self._shapes, self.spin_reach, rows, h, self._spos, self._squat,
                         self._near, self._which, self._lower, self._sdist, self._snormal, self._scount,
                         self._spoints, self._sseps, self._reach, self._d0, self._d1)
            group_of = {i: g for g, group in enumerate(_groups(hits, self.is_static)) for i in group}
            skins = ADVANCE_SKIN * np.maximum(self.size[rows[:, 0]], self.size[rows[:, 1]])
            new = [(a, b) for (a, b), inside in zip(rows.tolist(), self._d1[:k] < -skins)
                   if inside and group_of.get(a, ("alone", a)) != group_of.get(b, ("alone", b))]
            if not new:
                return
            hits = hits + new
            links.update(near)
            for group in _groups(hits, self.is_static):
                if not any(a in group for a, _ in new):
                    continue
                members = sorted(group)
                self._restore(look["events"], members)
                inside = pairs[np.isin(pairs[:, 0], members) & np.isin(pairs[:, 1], members)]
                group_links = set(map(tuple, inside.tolist())) | {p for p in links if p[0] in group and p[1] in group}
                self._group_step(sim, members, sorted(group_links), Y0, Y1, wrenches, t0, h)
                self.solver.counts["pairs_looked_again"] += 1

    def _restore(self, events: int, members: list[int]) -> None:
        """The solver's state of ``members`` set back to the step's start (_RESTORED, as after_step kept it), their
        events of the step (from index ``events``) dropped and what the step's attempts left of them (static shapes
        skipped, side hits, face landings) forgotten."""
        solver = self.solver
        for name in _RESTORED:
            getattr(solver, name)[members] = self._start[name][members]
        names = {solver.names[i] for i in members}
        solver.events[events:] = [e for e in solver.events[events:] if e.body not in names]
        for i in members:
            solver._static_skipped.pop(i, None)
            solver._side_hits.pop(i, None)
            solver._face_landings.pop(i, None)

    def _candidates(self, prm: np.ndarray, Y0: np.ndarray, Y1: np.ndarray, h: float) -> np.ndarray:
        """The broad phase's pairs (k, 2) of global body indices whose boxes swept over the step overlap, a moving
        body first (a static shape never is: each row is its two members in order, the moving bodies listed
        first). A hit changes a body's velocity by at most what its pair's kinetic energy allows
        (swept.deflections), so over the rest of the step its bounding sphere leaves its free chord by at most
        h × that: when two moving bodies are candidates, the broad phase is taken again with each such body's
        radius grown by that (the largest over its pairs; not within its skin), and those pairs too are
        candidates. One hit each: a chain of hits inside one step can send a body farther (look_again looks at the
        ends as stepped, of bodies outside the islands only). The same boxes as the last step's (a scene asleep or
        stopped) give the same pairs: they are not searched again; nor are those of the bodies whose paths and
        neighbours' paths did not change (SweptPairs)."""
        swept_bounds(Y0, Y1, self.members, self.reach, h, self._lo, self._hi)
        last, lo, hi = self._last_swept, self._lo.tobytes(), self._hi.tobytes()
        if last is not None and lo == last[0] and hi == last[1]:
            return last[2]
        grounds = self.solver.half_spaces
        found, swept = self._swept.find(Y0, Y1, self.reach, h, grounds), self._swept
        if deflections(Y0, Y1, prm, self.members, self.movable, swept.pairs, found, h, self._skin, self.reach,
                       self._grown, self.deflection):
            swept_bounds(Y0, Y1, self.members, self._grown, h, self._lo, self._hi)
            found, swept = self._swept_grown.find(Y0, Y1, self._grown, h, grounds), self._swept_grown
        pairs = self.members[swept.pairs[:found]]
        self._last_swept = (lo, hi, pairs)
        return pairs

    def broad_phase(self) -> tuple:
        """The last broad phase's boxes and grid, as island_pass takes them (kernels/contact/island._late_pairs):
        (lo, hi, movable, fixed, members, reach, cells, heads, chain), rows of :attr:`members`."""
        return (self._lo, self._hi, self.movable, self._fixed, self.members, self.reach, self._cells, self._heads,
                self._chain)

    def _hits(self, sim, pairs: np.ndarray, Y0: np.ndarray, Y1: np.ndarray, h: float) -> list[tuple[int, int]]:
        """The candidate pairs that meet inside the step (module docstring, 2); a static shape is never first.

        One compiled call over the candidates (kernels/contact/swept.py, screen_pairs: each pair's bound B on
        |d′| and, unless two boxes are provably apart over the step, d₀ and d₁); Python per pair only for those
        that overlap at an end of the step or that may have passed through each other: apart at both ends with
        d₀ + d₁ ≤ B h (if |d′| ≤ B, d stays ≥ (d₀ + d₁ − B h)/2 > 0 otherwise).
        """
        solver = self.solver
        static_a = self.is_static[pairs[:, 0]]
        pairs = np.ascontiguousarray(np.where(static_a[:, None], pairs[:, ::-1], pairs))  # a moving body first
        k = len(pairs)
        if k > len(self._reach):
            self._grow_screen(2 * k)
        reach, d0, d1 = self._reach[:k], self._d0[:k], self._d1[:k]
        near = screen_pairs(Y0, Y1, self._q_PB, self._shapes, self.spin_reach, pairs, h, self._spos, self._squat,
                            self._near, self._which, self._lower, self._sdist, self._snormal, self._scount,
                            self._spoints, self._sseps, self._reach, self._d0, self._d1)
        if near == 0:
            return []
        static = self.is_static[pairs[:, 1]]
        resting = solver.modes[pairs[:, 0]] == PERSISTENT
        ends = ~static & ((d1 < 0.0) | (d0 < 0.0))
        inside = (d0 >= 0.0) & (d1 >= 0.0) & (d0 + d1 <= reach)
        # a body held on a half-space that may pass through a static shape apart from it at both ends (a pebble slid
        # into a wall; along the crease of the floor and a wall, held on both, into the next wall): the ground pass
        # looks for its side impact along the step (solver._persistent_end, solver._third_met)
        first = pairs[:, 0]
        on_half_space = solver.ground_of[first] < len(solver.half_spaces)
        passing = inside & static & resting & on_half_space & (reach > 0.0)
        if passing.any():
            solver.may_pass.update(first[passing].tolist())
        inside &= ~(static & resting)
        hits = []
        for k in np.flatnonzero(ends | inside):
            a, b = int(pairs[k, 0]), int(pairs[k, 1])
            if d1[k] < 0.0:
                hits.append((a, b))
            elif d0[k] < 0.0:
                if self._approaching(sim, Y0[a], a, Y0[b], b):
                    hits.append((a, b))
            elif self._advance_hits(sim, a, b, Y0, h):
                hits.append((a, b))
        return hits

    def _grow_screen(self, k: int) -> None:
        """Room for k candidate pairs in screen_pairs' arrays."""
        self._reach, self._d0, self._d1 = np.empty(k), np.empty(k), np.empty(k)
        self._near, self._which = np.empty((k, 2), dtype=np.int64), np.empty(k, dtype=np.int64)
        self._sdist, self._snormal, self._scount = np.empty(k), np.empty((k, 3)), np.zeros(k, dtype=np.int64)
        self._spoints, self._sseps = np.empty((k, MAX_PAIR_POINTS, 6)), np.empty((k, MAX_PAIR_POINTS))

    def _approaching(self, sim, ya, a, yb, b) -> bool:
        self.contact(ya, a, yb, b)
        n, points, _ = self._geometry()
        return self._relative_normal_speed(ya, yb, n, points) < -APPROACH_SPEED

    def _advance_hits(self, sim, a: int, b: int, Y0: np.ndarray, h: float) -> bool:
        """Whether conservative advancement of pair (a, b) over the step finds it overlapping."""
        solver = self.solver
        ya, yb = Y0[a].copy(), Y0[b].copy()
        wa, wb = self._wrench_of(sim, a), self._wrench_of(sim, b)
        static = self.is_static[b]

        def states(s):
            return (solver.step_map(sim, a, ya, s * h, wa) if s > 0.0 else ya,
                    yb if static or s == 0.0 else solver.step_map(sim, b, yb, s * h, wb))

        ends = states(1.0)
        bound = self._pair_bound((ya, ends[0]), (yb, ends[1]), a, b) * h
        if bound <= 0.0:
            return False
        skin = ADVANCE_SKIN * max(self.size[a], self.size[b])

        def distance(s):
            at = states(s)
            return self.contact(at[0], a, at[1], b)

        return _advance(self.contact(ya, a, yb, b), 0.0, skin, bound, distance) is not None

    def advance_alone(self, sim, i: int, y0: np.ndarray, end: np.ndarray, w: np.ndarray, h: float, gap,
                      touching: float) -> float | None:
        """The first fraction s of body i's step from y0 over h under the wrench row w (its end: ``end``) at which
        gap(state) (m: a signed distance to fixed geometry) is below 0, or, touching at y0 (gap ≤ ``touching``), a
        skin deeper than it was there (sliding along a wall is not a meeting), by conservative advancement on the
        body's surface bound (_body_bound) to a skin (ADVANCE_SKIN × its size) below that; None if none is found."""
        bound = self._body_bound(y0, end, i) * h
        if bound <= 0.0:
            return None
        skin = ADVANCE_SKIN * self.size[i]
        d = gap(y0)
        floor = min(d, 0.0) - skin if d <= touching else 0.0
        return _advance(d, floor, skin, bound, lambda s: gap(self.solver.step_map(sim, i, y0, s * h, w)))

    def _wrench_of(self, sim, i: int) -> np.ndarray:
        """The wrench row body i's step ran with (static shapes: none)."""
        return self._step_wrenches[i] if not self.is_static[i] else np.zeros(L.WRENCH_WIDTH)

    def _pair_bound(self, A, B, a: int, b: int) -> float:
        """A bound (m/s) on |d'(t)| of pair a, b over a piece whose end states are A = (ya0, ya1), B = (yb0, yb1)."""
        rel0 = B[0][L.V:L.V + 3] - A[0][L.V:L.V + 3]
        rel1 = B[1][L.V:L.V + 3] - A[1][L.V:L.V + 3]
        speed = max(np.linalg.norm(rel0), np.linalg.norm(rel1)) + np.linalg.norm(rel1 - rel0)
        for y, i in ((A, a), (B, b)):
            spin = max(np.linalg.norm(y[0][L.W:L.W + 3]), np.linalg.norm(y[1][L.W:L.W + 3]))
            spin += np.linalg.norm(y[1][L.W:L.W + 3] - y[0][L.W:L.W + 3])
            speed += spin * self.spin_reach[i]
        return float(speed)

    def _body_bound(self, y0, y1, i: int) -> float:
        """A bound (m/s) on how fast body i's surface moves over a piece from y0 to y1 (against fixed geometry)."""
        speed = max(np.linalg.norm(y0[L.V:L.V + 3]), np.linalg.norm(y1[L.V:L.V + 3]))
        speed += np.linalg.norm(y1[L.V:L.V + 3] - y0[L.V:L.V + 3])
        spin = max(np.linalg.norm(y0[L.W:L.W + 3]), np.linalg.norm(y1[L.W:L.W + 3]))
        spin += np.linalg.norm(y1[L.W:L.W + 3] - y0[L.W:L.W + 3])
        return float(speed + spin * self.spin_reach[i])

    # ----------------------------------------------------------------- a group's step

    def _group_step(self, sim, members: list[int], links: list[tuple[int, int]], Y0: np.ndarray, Y1: np.ndarray,
                    wrenches: np.ndarray, t: float, h: float) -> None:
        """Step the bodies of one group together from Y0 over h, event after event; results into Y1."""
        solver = self.solver
        self.exchanged[members] = True
        y = {i: Y0[i].copy() for i in members}
        w = {i: wrenches[i].copy() for i in members}
        pairs = [(a, b) for a, b in links if not self.is_static[b]]
        active = set(members)
        #: members held on their ground, with the holding force of the step's start or of their rest in it (w[i])
        held = {i for i in members if solver.modes[i] == PERSISTENT}
        rounds = 0
        grazed: dict = {}  # a pair met without approaching: its floor (below) and how often it was so met
        dropped: set = set()  # grazed more than MAX_GRAZES times: not looked at again in the step
        hints: dict[int, float] = {}  # a flying member just struck: its apex hint, its gap 0 (solver._with_events)
        struck: set = set()
        env_impacts: dict[int, int] = {}  # impacts of each flying member on its ground or static shapes (ZENO_IMPACTS)
        struck_walls: set = set()  # (held member, instant) struck against a wall it touched at a piece's start
        rested: dict[int, np.ndarray] = {}  # held members a held step threw, left at rest: their state while at rest
        sunk: dict[int, int] = {}  # held members whose untracked feature, touching, was met at its floor: how often
        pressed_on: dict[int, int] = {}  # held members touching a wall struck at an instant, met at its floor: how often

        def still(i: int) -> bool:  # left at rest by a throw and not moved since (no event of its own)
            return i in rested and np.array_equal(y[i], rested[i])

        for _ in range(MAX_GROUP_EVENTS):
            if h <= 0.0 or not active:
                break
            pairs_now = [(a, b) for a, b in pairs if a in active and b in active and (a, b) not in dropped]
            if not pairs_now and not any(solver.modes[i] == FLIGHT for i in active):
                break
            # pairs touching at the piece's start: those that approach have their impacts now, all together
            # (sequential rounds, so that a chain passes its impulse on); the others are left for this piece
            touching = [(a, b) for a, b in pairs_now if self.contact(y[a], a, y[b], b)
                        <= TOUCHING * max(self.size[a], self.size[b])]
            closing = [(a, b) for a, b in touching if self._approaching(sim, y[a], a, y[b], b)]
            if closing and rounds < MAX_ROUNDS:
                rounds += 1
                for a, b in closing:
                    self._separate(sim, a, b, y, held)
                self._impacts(sim, touching, y, w, t, held)
                continue
            # a held member touching another half-space or a static shape (a wall) at the piece's start, whose step
            # goes into it: its impact there now, once at an instant (as solver._persistent_end has it at a span's
            # start), then held again; its path from there is the group's to follow
            band = solver._band
            walled = [i for i in sorted(active & held) if (i, t) not in struck_walls and solver._may_strike_side(i)
                      and solver._other_gap(sim, y[i], i)[0] <= band[i]
                      and (solver._other_gap(sim, solver.step_map(sim, i, y[i], h, w[i]), i)[0] < 0.0
                           or solver._driven_into_side(sim, y[i], i, w[i]))]  # (or through a static shape)
            if walled:
                for i in walled:
                    struck_walls.add((i, t))
                    self._strike_wall(sim, i, y, w, held, t)
                continue
            # a pair touching at the piece's start and not approaching (just struck, sliding on the other), or met
            # without approaching (grazed), is followed to a floor a skin deeper than it was then (its meeting): it
            # sets no sample's length (its bound against a gap of 0 would), its sign is read at every sample
            floors = {p: grazed[p][0] for p in pairs_now if p in grazed and p not in touching}
            floors.update((p, self._floor(y, p)) for p in touching)
            live = [p for p in pairs_now if p not in floors]
            flying = [i for i in active if solver.modes[i] == FLIGHT]
            # a flying member on its ground or a static shape at the piece's start (just struck, or within its
            # feature band: touching) has its next meeting with them located on its own step map, as the ground pass
            # locates it (solver._with_events); the others' gaps are followed with the pairs'
            on_it = [i for i in flying if i in struck or solver._gap(sim, y[i], i)[0] <= band[i]]
            watched = [i for i in flying if i not in on_it]
            # a member on_it may yet pass through a thin static shape it is apart from at the piece's start (a
            # pebble sliding along one wall into another): its distance to those shapes is followed as a watched gap
            apart = {} if solver.statics is None else {
                i: solver.statics.distances(y[i], i, solver.shapes[i]) > band[i] for i in on_it}
            apart = {i: among for i, among in apart.items() if among.any()}
            # a held member's gap to the other half-spaces and static shapes (a wall it slides into), while apart
            # (touching one, it is the ground pass's, solver._persistent_end); touching a wall it was struck against
            # at this instant (a partner presses it there), followed to a floor a skin deeper than it was, as a pair
            # that touches is (met there MAX_GRAZES times: no longer)
            sides, side_floors = [], {}
            for i in sorted(active & held):
                if not solver._may_strike_side(i):
                    continue
                gap = solver._other_gap(sim, y[i], i)[0]
                if gap > band[i]:
                    sides.append(i)
                elif (i, t) in struck_walls and pressed_on.get(i, 0) <= MAX_GRAZES:
                    side_floors[i] = min(gap, 0.0) - ADVANCE_SKIN * self.size[i]
                    sides.append(i)
            # a held member's features not on its ground (a box tipping on an edge: its other edge comes down; a can
            # rocking on its rim: its end face): a landing there changes its path (solver._reaching, on the ground
            # pass). One touching at the piece's start (just landed and not held, a partner's impulse on it) is
            # followed to a floor a skin deeper than it was, as a pair that touches is (landed there more than
            # MAX_GRAZES times: no longer)
            lands, land_floors = [], {}
            for i in sorted(active & held):
                if solver.other_ground[i] >= 0 or sunk.get(i, 0) > MAX_GRAZES:
                    continue
                lands.append(i)
                gap = solver._untracked_gap(sim, y[i], i, y[i])
                if gap <= 0.0:
                    land_floors[i] = gap - ADVANCE_SKIN * self.size[i]
            # a held can rocking on a rim whose lowest point turns fast: the events looked for piece by piece, each
            # piece's holding force found afresh (solver._rim_piece), as on the ground pass
            span = min([h] + [solver._rim_piece(sim, i, y[i], h) for i in active & held])
            cache: dict[float, dict[int, np.ndarray]] = {}

            def at(s: float) -> dict[int, np.ndarray]:
                if s not in cache:
                    cache[s] = {i: (solver.step_map(sim, i, y[i], s * span, w[i]) if s > 0.0 and not still(i)
                                    else y[i]) for i in active}
                return cache[s]

            def components(s: float) -> list[tuple[float, tuple]]:
                states = at(s)
                values = [(self.contact(states[a], a, states[b], b), ("pair", a, b)) for a, b in live]
                values += [(self.contact(states[a], a, states[b], b) - floors[(a, b)], ("pair", a, b))
                           for a, b in floors]
                values += [(solver._gap(sim, states[i], i)[0], ("env", i)) for i in watched]
                values += [(solver.statics.nearest_among(states[i], i, solver.shapes[i], among), ("env", i))
                           for i, among in apart.items()]
                values += [(solver._other_gap(sim, states[i], i)[0] - side_floors.get(i, 0.0), ("side", i))
                           for i in sides]
                values += [(solver._untracked_gap(sim, states[i], i, y[i]) - land_floors.get(i, 0.0), ("land", i))
                           for i in lands]
                return values

            end = at(1.0)
            s_env, first, rests = 1.0, None, False  # the first meeting of a member on_it: the piece ends there
            for i in sorted(on_it):
                if env_impacts.get(i, 0) < ZENO_IMPACTS and solver._driven_in(sim, y[i], i, w[i], i in struck):
                    # touching, driven in: struck at once (just struck: by a static shape it touches as well)
                    s = 0.0  # (its step may end beyond a thin static shape)
                elif solver._gap(sim, end[i], i)[0] >= 0.0:
                    continue
                else:
                    g0 = 0.0 if i in struck else solver._gap(sim, y[i], i)[0]
                    s = solver._locate(lambda u, i=i: solver._gap(sim, solver.step_map(sim, i, y[i], u * span, w[i]),
                                                                  i)[0], g0, hints.get(i, -1.0))
                if first is None or (0.0 if s is None else s) < s_env:  # None: a rebound too small: it rests
                    s_env, first, rests = (0.0 if s is None else s), i, s is None
            bounds, skins = {}, {}
            for a, b in live:
                bounds[("pair", a, b)] = self._pair_bound((y[a], end[a]), (y[b], end[b]), a, b) * span
                skins[("pair", a, b)] = ADVANCE_SKIN * max(self.size[a], self.size[b])
            for kind, group in (("env", watched + list(apart)), ("side", sides), ("land", lands)):
                for i in group:
                    bounds[(kind, i)] = self._body_bound(y[i], end[i], i) * span
                    skins[(kind, i)] = ADVANCE_SKIN * self.size[i]
            s_lo, values = 0.0, components(0.0)
            s_hi = None
            for _ in range(MAX_ADVANCE if values and s_env > 0.0 else 0):  # conservative advancement, to s_env
                step = math.inf
                for v, key in values:
                    if bounds.get(key, 0.0) > 0.0:
                        step = min(step, (max(v, 0.0) + skins[key]) / bounds[key])
                s = min(s_env, s_lo + step)
                values_s = components(s)
                if min(v for v, _ in values_s) < 0.0:
                    s_hi = s
                    break
                if s >= s_env:
                    break
                s_lo, values = s, values_s
            else:  # the most samples taken short of s_env: its state is looked at (an event there is bracketed)
                if values and s_env > 0.0 and min(v for v, _ in components(s_env)) < 0.0:
                    s_hi = s_env
            hints, struck = {}, set()  # an impact's apex hint and gap of 0 hold for the piece right after it
            if s_hi is None and first is None:  # no event in the rest of the step (or of the piece)
                for i in list(active):
                    if still(i):
                        continue
                    if i in held:
                        start = y[i]
                        y[i] = solver._held_rest(sim, i, start, w[i], t, span, end[i])
                        if solver._thrown(sim, i, start, y[i], solver._bare(i, w[i])):
                            y[i] = solver._left_at_rest(start)  # as on the ground pass (a can on its rim)
                        if solver.modes[i] != PERSISTENT:  # it left its ground in the piece: in flight from here
                            held.discard(i)
                            w[i] = solver._bare_rows[i].copy()
                    else:
                        y[i] = end[i].copy()
                if span < h:
                    t, h = t + span, h - span
                    continue
                active.clear()
                break
            if s_hi is None:  # a member on_it meets its ground or a static shape first
                s, key = s_env, ("env", first)
            else:
                lo, hi = s_lo, s_hi
                u = solver._locate(lambda u: min(v for v, _ in components(lo + u * (hi - lo))),
                                   min(v for v, _ in values), -1.0)
                s = lo + (1.0 if u is None else u) * (hi - lo)
                key = min(components(s), key=lambda vk: vk[0])[1]
                rests = False
            states, starts = at(s), dict(y)
            # a held member whose step to the event threw it (its holding force, held over the piece, raised its
            # K + U under gravity alone): as on the ground pass, a can held on its rim has its end face land where
            # it was, and any other body stays at rest there for the rest of the step, until an event of its own;
            # the event, found on that throw, is not had: the piece is looked at again from its start
            thrown = [i for i in sorted(active & held) if solver._thrown(sim, i, y[i], states[i], solver._bare(i, w[i]))]
            if thrown:
                for i in thrown:
                    bare = solver._bare(i, w[i])
                    y[i], landed = solver._instead_of_throw(sim, i, y[i], bare, t, 0.0)
                    if landed:
                        self._hold_again(sim, i, y[i], w, bare, held, t, True)
                    else:
                        rested[i] = y[i].copy()
                continue
            for i in active:
                y[i] = states[i].copy()
            t, h = t + s * span, h - s * span
            if key[0] == "pair":
                _, a, b = key
                if self._approaching(sim, y[a], a, y[b], b):  # with every other pair touching now
                    if (a, b) in floors:  # met a skin deeper than it started: moved apart first
                        self._separate(sim, a, b, y, held)
                    touching = [p for p in pairs_now if p == (a, b) or p in touching or self.contact(
                        y[p[0]], p[0], y[p[1]], p[1]) <= TOUCHING * max(self.size[p[0]], self.size[p[1]])]
                    for p in touching:  # so is every other pair followed to its floor that approaches now (a chain
                        # struck again and again would go a skin deeper at each event)
                        if p != (a, b) and p in floors and self._approaching(sim, y[p[0]], p[0], y[p[1]], p[1]):
                            self._separate(sim, p[0], p[1], y, held)
                    self._impacts(sim, touching, y, w, t, held)
                    rounds = 0
                else:  # grazing: it does not approach at its root; followed to a skin deeper (a few times)
                    times = grazed.get((a, b), (0.0, 0))[1] + 1
                    grazed[(a, b)] = (self._floor(y, (a, b)), times)
                    if times > MAX_GRAZES:
                        dropped.add((a, b))
                continue
            i = key[1]
            if key[0] == "land":  # a held member's other feature comes down: its landing, held again (or in flight)
                if i in land_floors:
                    sunk[i] = sunk.get(i, 0) + 1
                bare = solver._bare(i, w[i])
                y[i] = solver._landing(sim, i, y[i], bare, t, 0.0, solver.landing_face(sim, i, starts[i], y[i]))
                self._hold_again(sim, i, y[i], w, bare, held, t, True)
                continue
            if key[0] == "side":  # a held member meets a wall: its impact there, held again (or lifted off)
                if i in side_floors:
                    pressed_on[i] = pressed_on.get(i, 0) + 1
                struck_walls.add((i, t))
                self._strike_wall(sim, i, y, w, held, t)
                continue
            # a flying member meets its ground or a static shape: its impact (or its rest), and it stays in the
            # group (its pairs still followed); at rest, it is held with its holding force (else, lifted off at
            # once, it flies on, its ground looked at again, as the ground pass does)
            if rests or env_impacts.get(i, 0) >= ZENO_IMPACTS:  # a rebound too small, or a Zeno sequence: rests
                solver._rest(sim, i, y[i], int(solver._gap(sim, y[i], i)[1]), t, 0.0, 0.0)
            else:
                hints[i] = solver._impact(sim, i, y[i], w[i], t, h)
                struck.add(i)
                env_impacts[i] = env_impacts.get(i, 0) + 1
            self._hold_again(sim, i, y[i], w, w[i], held, t, True)  # w[i]: its bare row (flying)
        else:
            names = ", ".join(repr(solver.names[i]) for i in members)
            raise RuntimeError(f"bodies {names}: more than {MAX_GROUP_EVENTS} body–body events in one step at t = {t}")
        for i in list(active):
            if not still(i):
                self._finish(sim, i, y, w, t, h, held)
        for a, b in pairs:  # members whose ends, projected onto their grounds, the group did not sample together
            self._part(sim, a, b, y)
        for i in members:
            Y1[i, :L.STATE_WIDTH] = y[i][:L.STATE_WIDTH]

    def _part(self, sim, a: int, b: int, y: dict) -> None:
        """Bodies a and b at their step's end y (in place), overlapping: the group sampled their paths on the step
        maps, then each held member's end was projected onto its ground (a can spun into the ground by an impact
        with the other; a box held flat on it, tipped a little by a partner's pushes over the group's pieces). Moved
        apart by the depth, their velocities kept (counted in :attr:`separations`; at the next step the two have
        their impacts or form an island; :meth:`_separate`): two held ones each within its ground's plane, a held
        one and a flying one along the normal, the held one staying. Two flying ones, followed on their own maps
        to a skin deeper than they were (item 3), end deeper than the skin only where that was repeated (a pair
        grazed again and again: its path sinks, its relative normal acceleration pulling it in, while its states'
        velocities at each graze part it): moved apart along the normal by their inverse masses."""
        held = {i for i in (a, b) if self.solver.modes[i] == PERSISTENT}
        size = max(self.size[a], self.size[b])
        self._separate(sim, a, b, y, held, -(TOUCHING if held else ADVANCE_SKIN) * size)

    def _strike_wall(self, sim, i: int, y: dict, w: dict, held: set, t: float) -> None:
        """Held member i at y[i] meets another half-space or a static shape (a wall) at t: its impact there
        (solver._strike_side), then held again. The wall stays in view for the rest of the group's step (the ground
        pass leaves a static shape a body stays pressed on out of it: here a partner can still drive it in)."""
        solver = self.solver
        if solver._strike_side(sim, i, y[i], w[i], t):
            self._hold_again(sim, i, y[i], w, solver._bare(i, w[i]), held, t, True)
        solver._static_skipped.pop(i, None)

    def _floor(self, y: dict, pair: tuple[int, int]) -> float:
        """The signed distance (m) a pair at y, touching or just met, is followed to: a skin below its own."""
        a, b = pair
        return min(self.contact(y[a], a, y[b], b), 0.0) - ADVANCE_SKIN * max(self.size[a], self.size[b])

    def _finish(self, sim, i: int, y: dict, w: dict, t: float, h: float, held: set) -> None:
        """Body i's rest of the step (h from y[i]) on its own: the ground pass's flight or resting path."""
        solver = self.solver
        if h <= 0.0:
            return
        if i in held:  # still under the holding force of the step's start
            y[i] = solver._held_rest(sim, i, y[i], w[i], t, h)
        else:
            y[i] = solver._with_events(sim, i, y[i], w[i], t, h)

    def _impacts(self, sim, pairs: list, y: dict, w: dict, t: float, held: set) -> None:
        """The impacts of ``pairs`` (of bodies at y, in place) at one instant: each pair's two-body law in turn,
        and the ground's law for a member held on one that it drives in, round after round while any pair
        still approaches (sequential impacts, module docstring 4); one event per body and pair."""
        solver = self.solver
        geometry = []
        for a, b in pairs:
            self.contact(y[a], a, y[b], b)
            geometry.append(self._geometry() + pair_material(self._shapes[a], self._shapes[b]))
        bodies = sorted({i for pair in pairs for i in pair})
        energy_before = sum(kinetic_energy_row(y[i], sim._prm[i]) for i in bodies)
        befores = [self._relative_normal_speed(y[a], y[b], g[0], g[1]) for (a, b), g in zip(pairs, geometry)]
        totals = [0.0] * len(pairs)
        alphas = [g[3] for g in geometry]
        jumps = [{a: np.zeros(6), b: np.zeros(6)} for a, b in pairs]  # per pair, each body's share of its jump
        grounded = held & set(bodies)
        entry = {i: y[i][L.V:L.W + 3].copy() for i in grounded}
        for _ in range(MAX_SEQUENTIAL):
            moved = False
            for k, (a, b) in enumerate(pairs):
                n, points, _, e, mu = geometry[k]
                if self._relative_normal_speed(y[a], y[b], n, points) >= -APPROACH_SPEED:
                    continue
                moved = True
                start = {a: y[a].copy(), b: y[b].copy()}
                ya, yb = y[a].copy(), y[b].copy()
                impulse, _, _, alpha = pair_impact(y[a], ya, sim._prm[a], y[b], yb, sim._prm[b], len(points), points,
                                                   n[0], n[1], n[2], e, mu, self._jac, self._work)
                totals[k] += impulse
                alphas[k] = min(alphas[k], alpha)
                y[a][L.V:L.W + 3] = ya[L.V:L.W + 3]
                y[b][L.V:L.W + 3] = yb[L.V:L.W + 3]
                for i in (a, b):
                    if i in grounded:  # its ground takes what drives it in, and a wall it touches what drives it
                        self._ground_push(sim, i, y[i])  # into that
                        self._side_push(sim, i, y[i])
                    jumps[k][i] += np.concatenate((y[i][L.V:L.V + 3] - start[i][L.V:L.V + 3],
                                                   y[i][L.W:L.W + 3] - start[i][L.W:L.W + 3]))
            if not moved:
                break
        energy_after = sum(kinetic_energy_row(y[i], sim._prm[i]) for i in bodies)
        for k, (a, b) in enumerate(pairs):
            if totals[k] == 0.0 and not jumps[k][a].any() and not jumps[k][b].any():
                continue  # touching, but it took no part
            n, points, d, e, _ = geometry[k]
            after = self._relative_normal_speed(y[a], y[b], n, points)
            self.impacts += 1
            if alphas[k] < e:
                solver.counts["restitution_capped"] += 1
            if len(points) > 1 and e > 0.0:
                solver.counts["multi_contact_elastic"] += 1
            point = tuple(points.mean(axis=0).tolist())
            for i, other, sign in ((a, b, -1.0), (b, a, 1.0)):
                prm = sim._prm[i]
                dv, dw = jumps[k][i][0:3], jumps[k][i][3:6]
                q = y[i][L.Q:L.Q + 4]
                solver.impact_impulses[i, 0:3] += prm[L.MASS] * dv
                solver.impact_impulses[i, 3:6] += quat_rotate(q, prm[L.INERTIA:L.INERTIA + 3] * dw)
                solver.events.append(ContactEvent(
                    t, solver.names[i], -1, "impact", befores[k], after, totals[k], energy_before, energy_after,
                    tuple(dv.tolist()), tuple(dw.tolist()), tuple(q.tolist()), len(points), float(alphas[k]),
                    other=solver.names[other], point_world=point, normal_world=tuple((sign * n).tolist()), distance=d))
        for i in sorted(grounded):  # still resting on its ground unless all its contact points now move away from it
            j = int(solver.ground_of[i])
            g = solver.grounds[j, NORMAL:NORMAL + 3]
            k = solver._tracked_points(sim, y[i], i)
            lowest, _ = normal_speeds(y[i], sim._prm[i], k, solver._points, g[0], g[1], g[2], solver._work)
            if k == 0 or lowest > LIFT_OFF_SPEED:
                held.discard(i)
                w[i] = solver._bare_rows[i].copy()
                solver.modes[i] = FLIGHT
                solver.sliding[i] = False
                solver.events.append(ContactEvent(t, solver.names[i], j, "lift-off", lowest, lowest))
        for i in sorted(grounded & held):  # struck and still on its ground: its holding force (and whether it slides)
            if not np.array_equal(y[i][L.V:L.W + 3], entry[i]):  # found afresh at its new velocity
                self._hold_again(sim, i, y[i], w, solver._bare(i, w[i]), held, t, False)

    def _hold_again(self, sim, i: int, y: np.ndarray, w: dict, bare: np.ndarray, held: set, t: float,
                    came_back: bool) -> None:
        """Member i at y (struck, or come to rest) from t: held on its ground with its holding force found afresh
        (solver._hold, into w[i]; ``bare`` its wrench row without one; ``came_back``: kept through a lift-off found
        at the instant it came back to rest, as the ground pass does), or, let go, in flight with ``bare``."""
        solver = self.solver
        row = bare.copy()
        keep = came_back and solver._came_back(i, t, sim.dt)
        if solver.modes[i] == PERSISTENT and solver._hold(sim, y, i, row, t, keep=keep):
            held.add(i)
            w[i] = row
        else:
            held.discard(i)
            w[i] = bare.copy()

    def _side_push(self, sim, i: int, y: np.ndarray) -> bool:
        """Body i, held on its ground and touching another half-space or static shape (its second ground, or within
        its feature band of one), after a pair impulse: that one's impact law if its points now move into it (in
        place), as its ground's (_ground_push); whether it did."""
        solver = self.solver
        jj = int(solver.other_ground[i])
        if jj < 0:
            gap, jj = solver._other_gap(sim, y, i, pressed=True)
            if jj < 0 or gap > solver._band[i]:
                return False
        k = body_points(y, sim._prm[i], solver.shapes[i], solver.grounds[jj], solver._points, solver._gaps)
        return self._push(sim, i, y, jj, k)

    def _ground_push(self, sim, i: int, y: np.ndarray) -> bool:
        """Body i, resting on its ground, after a pair impulse: the ground's impact law if its contact points
        now move into the ground (in place); whether it did. Its points are its tracked features' and those of
        any other feature touching the ground (within its band of the lowest: a box held on the corner it has just
        landed on, the one it pivoted on still touching), which the impulse must not drive in either."""
        solver = self.solver
        j = int(solver.ground_of[i])
        mask = int(solver.tracked[i]) | solver._touching(sim, y, i, j)
        return self._push(sim, i, y, j, solver._tracked_points(sim, y, i, mask))

    def _push(self, sim, i: int, y: np.ndarray, j: int, k: int) -> bool:
        """The impact law of ground row j on body i at y (in place) at its k contact points in solver._points, if
        they move into it; whether they did."""
        solver = self.solver
        n = solver.grounds[j, NORMAL:NORMAL + 3]
        lowest, _ = normal_speeds(y, sim._prm[i], k, solver._points, n[0], n[1], n[2], solver._work)
        if k == 0 or lowest >= -APPROACH_SPEED:
            return False
        out = y.copy()
        impact(y, out, sim._prm[i], k, solver._points, n[0], n[1], n[2], solver.restitution_of(i, j),
               solver.friction_of(i, j), solver._work)
        y[L.V:L.W + 3] = out[L.V:L.W + 3]
        return True

    def _separate(self, sim, a: int, b: int, y: dict, held: set, below: float = 0.0) -> float:
        """Bodies a and b at y, overlapping (their signed distance below ``below``, m): moved apart along the normal
        by the depth (a held one stays: its ground is under it), shared by inverse mass otherwise; two held ones
        each within its ground's plane (:meth:`_slide_apart`). Returns the depth (m), 0 where they were not moved."""
        d = self.contact(y[a], a, y[b], b)
        if d >= below:
            return 0.0
        n = self._normal1[0]
        if a in held and b in held:
            return -d if self._slide_apart(sim, a, b, y, d, n) else 0.0
        inverse = {i: 0.0 if i in held else sim._prm[i, L.INV_MASS] for i in (a, b)}
        total = inverse[a] + inverse[b]
        for i, sign in ((a, 1.0), (b, -1.0)):
            if inverse[i] > 0.0:
                self._move_beside_wall(sim, i, y, sign * d * inverse[i] / total * n)
        self.separations += 1
        return -d

    def _move_beside_wall(self, sim, i: int, y: dict, move: np.ndarray) -> None:
        """Flying body i at y[i] (in place) moved by ``move`` (m, world: its share of a separation); where that would
        take it deeper into a half-space or static shape (a ball pushed off the floor by a partner, into the wall
        beside it), by the least move along that one's plane with the same part along ``move`` instead, when that
        plane keeps at least PART_SHARE of it squared (the move at most three times as long), else by ``move``."""
        solver = self.solver
        end = y[i].copy()
        end[L.P:L.P + 3] += move
        gap, j = solver._gap(sim, end, i)
        if gap < min(0.0, solver._gap(sim, y[i], i)[0]):
            g = solver.grounds[j, NORMAL:NORMAL + 3]
            along = move - (move @ g) * g
            share = (along @ along) / (move @ move)
            if share >= PART_SHARE:
                end[L.P:L.P + 3] = y[i][L.P:L.P + 3] + along / share
        y[i][L.P:L.P + 3] = end[L.P:L.P + 3]

    def _slide_apart(self, sim, a: int, b: int, y: dict, d: float, n: np.ndarray) -> bool:
        """Bodies a and b, both held, at y (in place) d < 0 into each other along n (a → b): each moved along the
        normal's part u in its ground's plane (along the crease of its two grounds where it is held on two), by
        −d × its inverse mass / Σ m⁻¹ |u|² (the least move in the mass metric that closes the depth to first
        order); not where that sum is below PART_SHARE × Σ m⁻¹, mostly across their grounds (one body above the
        other: the moves would be large beside the depth). A body that move would take into another half-space or
        static shape (deeper than it was: a can standing in a bin's corner, held on the floor and one wall, slid
        along their crease into the other) stays, and the other takes the whole move, or neither moves. True when
        moved (counted in :attr:`separations`)."""
        solver = self.solver
        moves, inverse = {}, {}
        for i in (a, b):
            if solver.other_ground[i] >= 0:  # along the crease
                e = crease(solver, i)
                u = (n @ e) * e
            else:
                g = solver.grounds[int(solver.ground_of[i]), NORMAL:NORMAL + 3]
                u = n - (n @ g) * g
            moves[i] = u
            inverse[i] = sim._prm[i, L.INV_MASS]
        for _ in range(2):  # the shares, then again without a body the first shares would put into a wall
            total = sum(inverse[i] * (moves[i] @ moves[i]) for i in (a, b))
            if total < PART_SHARE * (sim._prm[a, L.INV_MASS] + sim._prm[b, L.INV_MASS]):
                return False
            ends = {i: y[i].copy() for i in (a, b)}
            ends[a][L.P:L.P + 3] += d * inverse[a] / total * moves[a]
            ends[b][L.P:L.P + 3] -= d * inverse[b] / total * moves[b]
            walled = [i for i in (a, b) if inverse[i] > 0.0
                      and solver._other_gap(sim, ends[i], i, pressed=True)[0]
                      < min(0.0, solver._other_gap(sim, y[i], i, pressed=True)[0])]
            if not walled:
                break
            for i in walled:
                inverse[i] = 0.0
        else:
            return False
        for i in (a, b):
            y[i][L.P:L.P + 3] = ends[i][L.P:L.P + 3]
        self.separations += 1
        return True


def _spanning(points: np.ndarray) -> np.ndarray:
    """At most MAX_POINTS of the contact points (k, 3), the impact law's capacity (pair_impacts.py): the deepest
    (the first), then each time the one farthest from those kept (a face on a face may give up to 8 points)."""
    if len(points) <= MAX_POINTS:
        return points
    kept = [0]
    far = np.linalg.norm(points - points[0], axis=1)
    while len(kept) < MAX_POINTS:
        k = int(np.argmax(far))
        kept.append(k)
        far = np.minimum(far, np.linalg.norm(points - points[k], axis=1))
    return points[sorted(kept)]


def _advance(d: float, floor: float, skin: float, bound: float, distance) -> float | None:
    """Conservative advancement over a step: from a distance d (m) at its start, the first fraction s of it at which
    distance(s) < floor, each sample a skin below it at the rate ``bound`` (m per step, > 0: |d'| at most); None if
    none is found within MAX_ADVANCE samples."""
    s = 0.0
    for _ in range(MAX_ADVANCE):
        s += (max(d - floor, 0.0) + skin) / bound
        if s >= 1.0:
            return None
        d = distance(s)
        if d < floor:
            return s
    return None


def _groups(hits: list[tuple[int, int]], is_static: np.ndarray) -> list[set[int]]:
    """The connected groups of moving bodies linked by ``hits`` (a static shape links nothing)."""
    parent: dict[int, int] = {}

    def root(i: int) -> int:
        while parent.setdefault(i, i) != i:
            i = parent[i]
        return i

    for a, b in hits:
        ra = root(a)
        if not is_static[b]:
            rb = root(b)
            if ra != rb:
                parent[rb] = ra
    groups: dict[int, set[int]] = {}
    for i in list(parent):
        groups.setdefault(root(i), set()).add(i)
    return list(groups.values())
