"""The contact driver around the integrator step: events located on the step map, impacts, resting contact.

A :class:`ContactSolver` is what a :class:`~rigid_body_sim.core.simulator.Simulator` holds when
its scene has ground half-spaces (``Scene.contact``); without one the simulator runs exactly its
old code. Per step:

1. :meth:`ContactSolver.add_holding_wrenches` — before the step, every body in persistent
   contact gets the contact force that holds it (persistent.holding_wrench) added to the
   step's wrench rows, in one compiled pass (batch.hold_all); a body whose holding force would
   pull (or that moves away) lifts off. With ``euler``, ``rk4`` and ``reference``
   (Method.derivative_stages) a body on one half-space stepped by the integrator, unless
   locked, gets instead its contact in its row (stage.stage_rows, :meth:`_hold`): its force is
   then found at every stage of its step (kernels/contact/stage.py). The holding impulses are added
   to their sums only once the step is applied (a step refused as non-finite adds nothing).
2. The simulator steps every body with its integrator, as without contact; the rows carrying a
   contact are stepped again, at the start of :meth:`ContactSolver.after_step`, by the
   method's ``held`` step (the same tableau, the contact force at every stage).
3. :meth:`ContactSolver.after_step` — one compiled pass computes every body's lowest gap
   (shapes.min_gaps). A body in flight whose gap became negative has its step taken again
   from the step's start, in pieces: the impact time is the root of s ↦ gap(Φ(y₀, s·h)), Φ
   the body's own step map (its integrator, or its reduced model — the same code the step
   ran), bracketed and found by the Illinois method to round-off; there the impact law acts
   (impacts.impact), and the rest of the step follows, event after event. A body in persistent
   contact is projected back onto the contact (persistent.project, compiled pass
   batch.settle_all) unless its step had an event, located on the step map the same way: its
   slide stopped (the rest of the step sticking), another of its features reached the ground
   (an impact of all touching features together, :meth:`ContactSolver._landing`), another
   half-space was reached, or a feature the holding force did not push on moved off.

A body that touches a second half-space while resting on one (a groove, a corner) is held by
both together (two_grounds.py); those bodies take the Python path around the compiled passes.

Static bodies with a shape are geometry too (static_geometry.py): the flight gap is the least of
the half-spaces' gaps and the narrow phase's signed distances to them, and each contact with one
is a plane row of :attr:`ContactSolver.grounds` after the half-spaces (a static box's face, or a
body's tangent row); bodies resting on such a row take the Python path. Without static shapes
``grounds`` are the half-spaces and the code path is the one without them.

Moving bodies meet each other in a pass before the ground's (body_pairs.py, :attr:`ContactSolver.pairs`):
a swept broad phase and the narrow phase find the pairs that met inside the step, the bodies of
such a pair are stepped again together from the step's start and the two-body impact law acts at
the root of their signed distance along both step maps; those bodies are then left out of the
ground's pass for this step. Without two moving bodies with a shape, and without static shapes,
``pairs`` is None and nothing of it runs.

Persistent contact tracks *features* (shapes.feature_gaps: box corners, capsule ends, cylinder
rims), so resting on a face, pivoting on an edge or rolling on a rim are one mechanism. With
``euler``, ``rk4`` and ``reference`` the holding force is found at every stage from the
stage's state, each contact point's sliding friction against its own slip: those methods keep
their order while a body pivots or rolls (rk4 keeps a pivoting box's energy to ~1e-12 at
dt = 1 ms). With the other methods (their kicks evaluate the forces on a frozen pose), for
bodies held on two half-spaces or on a static shape, for the planar, translation-only and
kinematic models, and for a locked body, the force found at the step's start is held over the
step (zero-order hold): exact for resting and sliding at constant force (the closed-form
tests), order at most 2 where the force changes along the step (pivoting on an edge, a disk
rolling on its rim, Euler's disk): there a step can raise the energy. Such a step of a body
under gravity alone is taken again in up to MAX_REFINEMENT pieces (_refine_gains), whichever
the method; what still gains is counted in ``energy_gains``. A cylinder rolling on its rim near
upright, whose rim's lowest point sweeps round at a rate growing as 1/tilt, has its step taken in
pieces that each turn that point by at most RIM_TURN (and shrink its tilt by at most that fraction:
_rim_piece), and its end face coming down flat is located as a landing (shapes.opposite_rim_gap).

Zeno guard: after an impact whose rebound would rise less than :data:`ZENO_APEX` (the normal
speed u⁺ with u⁺²/(2a) < ZENO_APEX, a the free normal acceleration of the contact point toward
the ground), the remaining bounces form a geometric series u⁺, e u⁺, e² u⁺, ... whose flights
sum to 2u⁺/(a(1 − e)): the body is put into persistent contact at once and its ``rest`` event
is dated at that accumulation time (the positions it skips are below ZENO_APEX). Rocking (a landing
after which the body turns on the new features, the others rising) ends the same way once the
rising features would come down again before the end of the next step (_comes_down_in): every
touching feature is held from that landing.

Events are recorded in :attr:`ContactSolver.events` (:class:`ContactEvent`).
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import layout as L
from ..quaternion import quat_rotate, quat_to_matrix
from . import static_geometry, two_grounds
from .events import ZENO_IMPACTS, ContactEvent
from ..kernels.stepping import advance, step_reduced
from ..kernels.contact.batch import (CACHE_WIDTH, OK, TO_SOLVER, busy_bodies, fast_rims, gravity_gains, hold_all,
                                     record_holds, settle_all, split_bodies)
from ..kernels.contact.impacts import _A, _LAM, IMPACT_WORK_SHAPE, impact, kinetic_energy_row, potential_energy_row
from ..kernels.contact.layout import DIMS, FLIGHT, KIND, MAX_POINTS, NORMAL, PERSISTENT, SHAPE_BOX, SHAPE_CYLINDER
from ..kernels.contact.island import SLEEP_SPEED
from ..kernels.contact.materials import material
from ..kernels.contact.persistent import (
    LIFT_OFF,
    SLIDE,
    add_contact_wrench,
    held_points,
    holding_wrench,
    normal_bias,
    normal_motion,
    normal_speeds,
    project,
    rim_turn_rate,
)
from ..kernels.contact.stage import hold_in_row, stage_rows, stepped_by_integrator
from ..kernels.contact.shapes import (
    FEATURE_BAND,
    MAX_FEATURES,
    axis_tilt,
    body_gap,
    body_points,
    feature_gaps,
    feature_points,
    held_rim,
    min_gaps,
    opposite_rim_gap,
)

__all__ = ["ContactSolver", "ContactEvent", "ZENO_APEX", "SLIP_TOLERANCE", "TOUCHING_GAP", "MAX_EVENTS_PER_STEP",
           "MAX_PENETRATION_TOLERANCE"]

#: A rebound that would rise less than this (m) ends the bounce sequence (the Zeno guard).
ZENO_APEX = 1e-10
#: A contact point slipping slower than this (m/s) sticks.
SLIP_TOLERANCE = 1e-12
#: A body this close to the ground (m) and not moving away starts in persistent contact.
TOUCHING_GAP = 1e-12
#: A body in persistent contact whose contact points move away faster than this (m/s) lifts off; one whose points
#: move into its ground faster than this (an impulse, a state set, a body thrown out of its island) is struck there
#: (the impact law, restitution and all) before its step goes on.
LIFT_OFF_SPEED = 1e-9
#: Most events one body may have in one step (more is reported as an error, not looped on).
MAX_EVENTS_PER_STEP = 10_000
#: Most impacts of a body resting on the ground against other half-spaces or static shapes in one step (each taken
#: a call deeper); past them it stays pressed on them for the rest of the step (counted in ``side_pressed``).
MAX_SIDE_IMPACTS = 64
#: A can held on its rim whose held span threw it more than this many times in one step is left at rest for the
#: rest of that step (counted as ``held_thrown``), not landed on its end face again (:meth:`ContactSolver._held_span`).
MAX_FACE_LANDINGS = 8
#: A thrown can held on its rim lands its end face only while its axis is within this (sin of the tilt) of the
#: ground's normal, its face within a hair of flat; one tilted further is left at rest (landing a face held up at
#: a slant turns it flat at once: a can lying on its side was stood on its end, 15 cm up).
FACE_TILT = 0.05
PRESSED = -1  # ContactSolver._side_hits of a body pressed on them
#: Most pieces a resting body's step is cut into when it gained energy (ContactSolver._refine_gains).
MAX_REFINEMENT = 32
#: rad: the most a piece of a step turns the lowest point of a cylinder rolling on its rim about the normal, and
#: the fraction its tilt may shrink by toward upright in one (persistent.rim_turn_rate): a can wobbling near
#: upright, or coming down onto its end, has its step cut into pieces (_rim_piece).
RIM_TURN = 0.25
#: Most pieces a step is cut into for RIM_TURN (a can closer to upright turns more within a piece).
MAX_RIM_PIECES = 64
#: A piece at MAX_RIM_PIECES that raised a can's K + U under gravity alone by more than this × |K + U| threw it: its
#: end face lands instead (:meth:`ContactSolver._persistent_span`). rk4's own error over a piece is far below it.
THROWN = 1e-3
#: The most a penetration tolerance may be (m): a centimetre, MuJoCo's pile depth (its soft contacts).
MAX_PENETRATION_TOLERANCE = 1e-2
#: Samples of s in (0, 1] looked at for the first sign change of the gap in a step.
BRACKET_SAMPLES = 16


class ContactSolver:
    """Contact of a Simulator's bodies with the scene's ground half-spaces (the module docstring).

    Parameters
    ----------
    sim : Simulator
        Whose scene has ``contact`` (not None). The solver reads and writes the simulator's
        state buffers; it holds per-body contact modes and the event list.
    """

    def __init__(self, sim) -> None:
        spec = sim.scene.contact
        self.grounds = spec.grounds
        self.shapes = spec.shapes
        #: Per body, restitution and friction against the plane rows of :attr:`grounds` below
        #: :attr:`first_tangent` (the half-spaces, then the static box faces): (n, first_tangent). Read
        #: through :meth:`restitution_of` and :meth:`friction_of` (kernels/contact/materials.py).
        self.restitution = spec.restitution
        self.friction = spec.friction
        #: Per body, restitution and friction against its own tangent row first_tangent + i: (n,), or (0,)
        #: without static shapes (then there is no tangent row).
        self.tangent_restitution = np.zeros(0)
        self.tangent_friction = np.zeros(0)
        #: The first tangent row of :attr:`grounds` (body 0's); the number of half-spaces without static shapes.
        self.first_tangent = len(spec.grounds)
        #: Per body, friction against each half-space: (n, G), contiguous (the islands' kernel, island.py).
        self.half_space_friction = spec.friction
        model = sim.model
        #: The scene's half-spaces (rows 0 … G − 1 of :attr:`grounds`).
        self.half_spaces = spec.grounds
        #: Static bodies with a shape as geometry (static_geometry.py), or None: then ``grounds`` are the
        #: half-spaces alone and nothing here differs from a scene without static shapes.
        self.statics = None
        statics = static_geometry.static_shapes(spec.shapes, model.motions)
        if statics.size:
            self.statics = static_geometry.StaticGeometry(sim, spec, statics)
            # plane rows: half-spaces, static box faces, one tangent row per body (static_geometry.py)
            self.grounds, self.first_tangent = self.statics.rows, self.statics.first_tangent
            self.restitution, self.friction = self.statics.restitution, self.statics.friction
            self.tangent_restitution, self.tangent_friction = (self.statics.tangent_restitution,
                                                               self.statics.tangent_friction)
        n = model.count
        self.bodies = np.array(spec.bodies, dtype=np.int64)  # free bodies with a collision shape
        self.is_contact_body = np.zeros(model.count, dtype=bool)
        self.is_contact_body[self.bodies] = True
        #: The body–body pass (body_pairs.py), or None: a scene with fewer than two moving bodies with a
        #: shape and no static shape has no pair that can meet, and runs without it.
        self.pairs = None
        self.names = model.names
        # contact points fixed in the body (box corners) see the centripetal acceleration (persistent.accelerations)
        self.vertex = spec.shapes[:, KIND] == SHAPE_BOX
        self.modes = np.full(n, FLIGHT, dtype=np.int64)
        self.ground_of = np.full(n, -1, dtype=np.int64)
        self.sliding = np.zeros(n, dtype=bool)
        self.slide_direction = np.zeros((n, 2))
        self._bare_rows = np.zeros((n, L.WRENCH_WIDTH))  # each body's wrench row before its holding force
        self._held_rows = np.zeros((n, L.WRENCH_WIDTH))  # a staged body's row with the step start's holding force
        self._staged = np.zeros(n, dtype=np.int64)  # 1: the body's row carries its contact to every stage (stage.py)
        self._anchors = np.zeros((MAX_POINTS, 3))  # normal_bias: the body points the contact forces act at
        # the features (shapes.feature_gaps) touching the ground in persistent contact, as bits
        self.tracked = np.zeros(n, dtype=np.int64)
        self._band = FEATURE_BAND * spec.shapes[:, DIMS:DIMS + 3].max(axis=1)  # m: "touching together"
        self._features = np.empty(MAX_FEATURES)
        self._owners = np.zeros(MAX_POINTS, dtype=np.int64)
        self._bias = np.zeros(MAX_POINTS)
        self._status = np.zeros(n, dtype=np.int64)  # batch.OK / TO_SOLVER / LOCKED of each body after a compiled pass
        self._locked = np.zeros(n, dtype=np.int64)  # batch.hold_all: 1 for a body locked at rest for this step
        self._hold_cache = np.zeros((n, CACHE_WIDTH))  # batch.hold_all: what each locked body's hold found
        self._rdot = np.zeros((MAX_POINTS, 3))
        self.pressed = np.zeros(n, dtype=np.int64)  # the tracked features the holding force pushes on, as bits
        self.events: list[ContactEvent] = []
        #: Per body, the contact force (N, world axes) found at the last step's start (zero while not resting).
        self.holding_forces = np.zeros((n, 3))
        #: Per body, Σ holding force × step (N·s, world axes) since the solver was made (impacts not included).
        self.holding_impulses = np.zeros((n, 3))
        #: Steps of resting bodies that still gained energy when cut into MAX_REFINEMENT pieces.
        self.energy_gains = 0
        #: Per body, Σ impact impulse since the solver was made or reset: (N·s, then N·m·s about the
        #: centre of mass), world axes.
        self.impact_impulses = np.zeros((n, 6))
        #: Set True to have :attr:`holding_angular_impulses` kept (off: the resting path costs nothing more).
        self.track_torques = False
        #: Per body, Σ holding torque about the centre of mass × step (N·m·s, world axes, the torque at
        #: each step's start), while :attr:`track_torques`.
        self.holding_angular_impulses = np.zeros((n, 3))
        # the holding angular impulses of the step under way (torque × step), added to the sum once it is applied
        # with holding_forces × step (a step refused as non-finite adds nothing): add_holding_wrenches, _count_holds
        self._step_angular = np.zeros((n, 3))
        #: Counts of what /diagnostics reports (reset clears them): ``restitution_capped`` impacts whose
        #: restitution the energy cap lowered below e; ``multi_contact_elastic`` impacts of several
        #: contact points with e > 0 (the model-dependent case); ``refined_steps`` resting steps taken
        #: again in pieces because they gained energy; ``second_half_space`` impacts of a resting body
        #: against another half-space; ``two_ground_overflow`` holds on two half-spaces with more
        #: contact points than the rows take (two_grounds.py); ``painleve`` sliding holds in a
        #: Painlevé configuration (:meth:`_painleve`); ``static_tangent`` body-steps held on a static shape's
        #: tangent plane (a curved support, an edge or a rim: first order; static_geometry.py);
        #: ``static_pressed`` impacts of a resting body against a static shape it stays pressed on but is not held
        #: on (a curved one, an edge, a second wall: out of the rest of its step's view; a static box's face beside
        #: its ground holds it, two_grounds.py);
        #: ``island_body_steps`` body-steps taken by the islands' first-order velocity step (island.py);
        #: ``rim_pieces`` pieces of steps of cylinders rolling on a rim near upright (:meth:`_rim_piece`),
        #: ``rim_capped`` those whose rim turned more than RIM_TURN even at MAX_RIM_PIECES; ``face_landed`` of
        #: those, the ones that threw the can (:meth:`_thrown`), taken instead as its end face landing;
        #: ``face_down``
        #: projections of a cylinder held on a rim that went through upright onto its end face (:meth:`_project`);
        #: ``projected_down`` projections that turned a feature not tracked into the ground, taken again with it
        #: tracked (:meth:`_project`; the compiled pass hands such a body to the solver);
        #: ``side_pressed`` spans of a resting body just struck against another half-space or static shape whose gap
        #: there never opens within the span (a corner swinging in as the struck point leaves): not struck again
        #: at the same instant, it stays pressed on it for the rest of the step (:meth:`_persistent_end`), or struck
        #: more than MAX_SIDE_IMPACTS times in the step; ``held_thrown`` spans of a resting body under gravity alone
        #: whose held step raised its K + U by more than THROWN of it: it stays where it was, at rest (:meth:`_held_span`);
        #: ``island_late_pairs`` pairs the islands found by screening a body again on the path their velocity step
        #: gave it, ``island_late_joined`` bodies outside the islands those joined to them (island.py);
        #: ``pairs_looked_again`` groups of bodies whose step was taken again after the ground pass, two of them
        #: having ended it inside each other (body_pairs.BodyPairs.look_again); ``third_half_space`` steps of a body
        #: held on two half-spaces that ended below a third half-space or static shape, taken in at the step's end
        #: (two_grounds.end_of_step); ``static_taken_out`` steps of a resting body that ended inside a wall it was
        #: pressed on and not held on (a static shape, or a half-space it was left pressed on: ``side_pressed``), or
        #: inside another static shape while held on a static shape's tangent row, projected out of it at the
        #: step's end (two_grounds.take_out_of_pressed, take_out_of_static).
        #: per body, the static shape (static index) it was found pressed on: not looked at for the rest of the step
        self._static_skipped: dict[int, int] = {}
        #: side impacts of each body in this step; PRESSED: not looked at for them for the rest of the step
        self._side_hits: dict[int, int] = {}
        self._face_landings: dict[int, int] = {}  # end-face landings of each can in this step (_held_span)
        #: bodies held on one half-space whose path in this step may pass through a static shape they are apart
        #: from at both its ends (body_pairs._hits): their side impacts are looked for along the step too
        self.may_pass: set[int] = set()
        self.counts = dict.fromkeys(("restitution_capped", "multi_contact_elastic", "refined_steps",
                                     "second_half_space", "two_ground_overflow", "painleve",
                                     "static_tangent", "static_pressed", "island_body_steps", "rim_pieces",
                                     "rim_capped", "face_landed", "face_down", "projected_down", "side_pressed",
                                     "held_thrown",
                                     "island_late_pairs", "island_late_joined", "pairs_looked_again", "third_half_space",
                                     "static_taken_out"), 0)
        #: Per body, a second half-space it is held on besides ``ground_of`` (two_grounds.py), or -1.
        self.other_ground = np.full(n, -1, dtype=np.int64)
        #: The features touching ``other_ground``, as bits.
        self.other_tracked = np.zeros(n, dtype=np.int64)
        #: Per body with an ``other_ground``: True when the two together have more contact points than the
        #: rows hold, so it is held on ``ground_of`` alone and projected onto both after each step.
        self.other_projected = np.zeros(n, dtype=bool)
        self._points = np.empty((MAX_POINTS, 3))
        self._gaps = np.empty(MAX_POINTS)
        self._work = np.zeros(IMPACT_WORK_SHAPE)
        self._d = np.empty(L.STATE_WIDTH)
        self._force = np.empty(6)
        self._lowest = np.empty(len(self.bodies))
        self._flying_gaps = np.empty(len(self.bodies))
        m = len(self.bodies)  # batch.split_bodies' and busy_bodies' lists, before the step (hold) and after it (step)
        self._hold_lists = np.empty((3, m), dtype=np.int64)
        self._step_lists = np.empty((3, m), dtype=np.int64)
        self._busy = np.empty(m, dtype=np.int64)
        self._not_done = np.zeros(n, dtype=np.bool_)
        self._no_bodies = np.zeros(0, dtype=np.int64)
        #: Per body asleep on its ground alone (:meth:`_rest_alone`): the holding force (N) and its torque about the
        #: centre of mass (N·m), world axes, of the step it fell asleep in, which hold it while it sleeps.
        self._rest_force, self._rest_torque = np.zeros((n, 3)), np.zeros((n, 3))
        self._rose = np.empty(m, dtype=np.int64)  # batch.gravity_gains
        self._rims = np.empty(m, dtype=np.int64)  # batch.fast_rims
        self._any_cylinder = bool((self.shapes[:, KIND] == SHAPE_CYLINDER).any())
        # one-body buffers of the step map
        self._Y1 = np.zeros((2, 1, L.ROW_WIDTH))
        self._w1 = np.zeros((1, L.WRENCH_WIDTH))
        self._members1 = np.zeros(1, dtype=np.int64)
        self._status1 = np.zeros(1, dtype=np.int64)
        self._control1 = np.zeros(L.CONTROL_WIDTH, dtype=np.int64)
        self._inputs1 = np.zeros(L.INPUT_WIDTH)
        self._never = np.zeros(1, dtype=np.int64)  # the step map's cancel flag (kernels.stepping.advance): never set
        self._sleeping = False
        self._sleep_speed = SLEEP_SPEED
        self._penetration_tolerance = 0.0
        if len(self.bodies) >= 2 or (len(self.bodies) and statics.size):
            from .body_pairs import BodyPairs

            self.pairs = BodyPairs(self, sim, statics)

    @property
    def sleeping(self) -> bool:
        """Islands at rest, and bodies at rest alone on a half-space, are locked (no step, no narrow phase inside
        them) until something touches or pushes them (island.py). Off by default: a sleeping island's bodies keep
        their state exactly, but a locked island does not see gravity change or a slow creep below
        :attr:`sleep_speed`. Set to False, every sleeping body wakes (its next step is the island step from the
        state it was locked in)."""
        return self._sleeping

    @sleeping.setter
    def sleeping(self, on: bool) -> None:
        self._sleeping = bool(on)
        if not on and self.pairs is not None:
            self.pairs.islands.wake_all()

    @property
    def sleep_speed(self) -> float:
        """The speed (m/s, spin × bounding radius included) below which an island's bodies fall asleep while
        :attr:`sleeping`. The default, island.SLEEP_SPEED = 1e-9 m/s, is rest to round-off (the exact sticking
        solve's): a step that starts and ends that slow locks them where they are. Raised (as the peers' sleep
        thresholds: MuJoCo's sleep_tolerance is 1e-3), bodies must stay for island.SLEEP_STEPS steps within that
        speed × SLEEP_STEPS steps of where they began them (their mean speed below it: a body jittering in place,
        a Gauss–Seidel residue, is at rest), and are then stopped where they are, creeping or not: their kinetic
        energy is dropped."""
        return self._sleep_speed

    @sleep_speed.setter
    def sleep_speed(self, speed: float) -> None:
        speed = float(speed)
        if not (math.isfinite(speed) and speed >= SLEEP_SPEED):
            raise ValueError(f"sleep_speed must be a finite speed of at least {SLEEP_SPEED:g} m/s, got {speed!r}")
        self._sleep_speed = speed

    @property
    def penetration_tolerance(self) -> float:
        """How deep (m) a point of bodies resting on bodies (islands) may be left before the projection moves it
        out. The default, 0, is exact: island.PROJECT_TOL = 1e-12 × the body's size. Raised (at most
        MAX_PENETRATION_TOLERANCE), the projection leaves points that shallow where they are: a step of a landing
        pile mostly skips it (its velocity step leaves a few µm at 1 ms) and costs about 0.6 of the exact step. A body
        touching no other body (alone on the ground or on a static shape) keeps its exact contact."""
        return self._penetration_tolerance

    @penetration_tolerance.setter
    def penetration_tolerance(self, depth: float) -> None:
        depth = float(depth)
        if not (math.isfinite(depth) and 0.0 <= depth <= MAX_PENETRATION_TOLERANCE):
            raise ValueError(f"penetration_tolerance must be a depth from 0 to {MAX_PENETRATION_TOLERANCE:g} m, "
                             f"got {depth!r}")
        self._penetration_tolerance = depth

    # ----------------------------------------------------------------- modes

    def body_stopped(self, i: int) -> None:
        """Body i was stopped (Simulator.stop_body): every pass leaves its pairs out from the next step, so the
        bodies asleep with it (its sleeping island, which it may have held) wake and move on without it."""
        if self.pairs is not None:
            self.pairs.islands.wake_group(i)

    def reset(self, sim) -> None:
        """Modes from the current state: touching and not moving away means persistent; the events cleared."""
        self.events.clear()
        if self.pairs is not None:
            self.pairs.impacts = self.pairs.separations = 0
            self.pairs._look = None
        self.impact_impulses[:] = 0.0
        self.holding_angular_impulses[:] = 0.0
        for key in self.counts:
            self.counts[key] = 0
        if self.statics is not None:
            self.statics.place(sim)
        if self.pairs is not None:
            self.pairs.islands.reset()
        for i in self.bodies:
            self.pose_set(sim, i)

    def pose_set(self, sim, i: int) -> None:
        """Body i's contact mode derived anew from its state, as at a reset: it was placed anew
        (Simulator.set_body_state with a position or orientation; the features it was held on by are not those that
        touch now: a box set standing on a side was held by its old bottom face's corners, and its projection turned
        it over into the ground)."""
        if not self.is_contact_body[i]:
            return
        self.modes[i] = FLIGHT
        self.ground_of[i] = -1
        self.other_ground[i] = -1
        self.other_projected[i] = False
        self.sliding[i] = False
        self.classify(sim, sim._Ys[sim._control[L.CUR]], i)

    def classify(self, sim, Y: np.ndarray, i: int) -> None:
        """Body i (in flight) at state rows Y: persistent contact if it touches its ground and its contact points move
        neither away from it nor into it (faster than LIFT_OFF_SPEED)."""
        gap, j = self._gap(sim, Y[i], i)
        if gap <= TOUCHING_GAP:
            count = self._contact_points(sim, Y[i], i, j)
            speed, _, vx, vy = self._normal_motion(sim, Y[i], i, j, count, np.zeros(L.WRENCH_WIDTH))
            if -LIFT_OFF_SPEED <= speed <= LIFT_OFF_SPEED:  # moving into it: in flight, struck in its step
                self.modes[i] = PERSISTENT
                self.ground_of[i] = j
                # sliding if its points slip (as holding_wrench: frictionless, it slides along no direction)
                slip, mu = math.hypot(vx, vy), self.friction_of(i, j)
                self.sliding[i] = mu == 0.0 or slip > SLIP_TOLERANCE
                self.slide_direction[i] = (vx / slip, vy / slip) if mu != 0.0 and slip > SLIP_TOLERANCE else (0.0, 0.0)
                self.tracked[i] = self._staying(sim, Y[i], i, j, self._touching(sim, Y[i], i, j))
                self.events.append(ContactEvent(sim.time, self.names[i], int(j), "rest", speed, speed))
                two_grounds.start_if_touching(self, sim, Y[i], i, LIFT_OFF_SPEED, TOUCHING_GAP)

    def is_resting(self, body: str) -> bool:
        """True while ``body`` is in persistent contact with the ground."""
        return bool(self.modes[self.names.index(body)] == PERSISTENT)

    def in_island(self, body: str) -> bool:
        """True while ``body`` is stepped with the bodies it rests on or carries (island.py; asleep included, but not
        asleep alone on its ground: that one is resting)."""
        return self.pairs is not None and bool(self.pairs.islands.in_islands()[self.names.index(body)])

    def static_body_of(self, ground: int) -> str | None:
        """The static body whose shape plane row ``ground`` (a ContactEvent's) belongs to; None for a
        half-space of the scene's ``ground`` list (static_geometry.py; a tangent row names its latest owner)."""
        b = -1 if self.statics is None or ground < len(self.half_spaces) else self.statics.static_of(ground)
        return self.names[b] if b >= 0 else None

    def restitution_of(self, i: int, j: int) -> float:
        """Body i's restitution against plane row j of :attr:`grounds` (kernels/contact/materials.material)."""
        return float(material.py_func(self.restitution, self.tangent_restitution, self.first_tangent, i, j))

    def friction_of(self, i: int, j: int) -> float:
        """Body i's friction coefficient against plane row j of :attr:`grounds` (kernels/contact/materials.material)."""
        return float(material.py_func(self.friction, self.tangent_friction, self.first_tangent, i, j))

    def events_of(self, body: str, kind: str | None = None) -> list[ContactEvent]:
        """The recorded events of ``body`` (of one ``kind`` if given), in time order of their recording."""
        return [e for e in self.events if e.body == body and (kind is None or e.kind == kind)]

    # ----------------------------------------------------------------- helpers

    def _contact_points(self, sim, y: np.ndarray, i: int, j: int) -> int:
        return body_points(y, sim._prm[i], self.shapes[i], self.grounds[j], self._points, self._gaps)

    def _touching(self, sim, y: np.ndarray, i: int, j: int) -> int:
        """The features of body i within its band of the lowest one against ground j, as bits."""
        count = feature_gaps(y, sim._prm[i], self.shapes[i], self.grounds[j], self._features)
        gaps = self._features[:count]
        return int(sum(1 << k for k in np.flatnonzero(gaps <= gaps.min() + self._band[i])))

    def _staying(self, sim, y: np.ndarray, i: int, j: int, mask: int) -> int:
        """The features of ``mask`` whose contact points do not move away from ground j (a box spun about a
        bottom edge touches with four corners, but two of them rise: only the edge is in contact), or all of
        ``mask`` when every one does."""
        return self._not_rising(sim, y, i, j, mask) or mask

    def _not_rising(self, sim, y: np.ndarray, i: int, j: int, mask: int) -> int:
        """The features of ``mask`` whose contact points do not move away from ground j (none: 0)."""
        n = self.grounds[j, NORMAL:NORMAL + 3]
        kept = 0
        for k in range(MAX_FEATURES):
            if mask & (1 << k):
                count = feature_points(y, sim._prm[i], self.shapes[i], self.grounds[j], 1 << k, self._points,
                                       self._gaps, self._owners)
                _, highest = normal_speeds(y, sim._prm[i], count, self._points, n[0], n[1], n[2], self._work)
                if count and highest <= LIFT_OFF_SPEED:
                    kept |= 1 << k
        return kept

    def _tracked_points(self, sim, y: np.ndarray, i: int, mask: int | None = None) -> int:
        """Contact points (self._points, self._gaps) of body i's tracked features (or of ``mask``)."""
        j = int(self.ground_of[i])
        return feature_points(y, sim._prm[i], self.shapes[i], self.grounds[j],
                              int(self.tracked[i]) if mask is None else mask, self._points, self._gaps, self._owners)

    def _untracked_gap(self, sim, y: np.ndarray, i: int, y0: np.ndarray | None = None) -> float:
        """The lowest gap of body i's features that are not tracked (inf if every one is); with ``y0`` (the
        step's start), also of a can's end face coming down (shapes.opposite_rim_gap)."""
        j = int(self.ground_of[i])
        count = feature_gaps(y, sim._prm[i], self.shapes[i], self.grounds[j], self._features)
        mask = int(self.tracked[i])
        free = [self._features[k] for k in range(count) if not mask & (1 << k)]
        lowest = min(free) if free else math.inf
        if y0 is not None:
            lowest = min(lowest, opposite_rim_gap(y0, y, sim._prm[i], self.shapes[i], self.grounds[j], mask,
                                                  self._band[i]))
        return lowest

    def _settle(self, sim, y: np.ndarray, i: int, sticking: bool) -> None:
        """Project body i onto its tracked features, adding every feature the projection leaves touching (≤ band)
        that does not move away (a box landed on an edge turns about it: its other edge, within the band, rises)."""
        j = int(self.ground_of[i])
        for _ in range(4):
            self._project(sim, y, i, sticking)
            count = feature_gaps(y, sim._prm[i], self.shapes[i], self.grounds[j], self._features)
            more = sum(1 << k for k in range(count) if self._features[k] <= self._band[i]) & ~int(self.tracked[i])
            more = self._not_rising(sim, y, i, j, more) if more else 0
            if not more:
                break
            self.tracked[i] = int(self.tracked[i]) | more

    def _project(self, sim, y: np.ndarray, i: int, sticking: bool) -> None:
        """persistent.project of body i onto its tracked features at y (in place).

        A cylinder held on a rim within a hair of upright has a kink in its lowest point's gap (the
        point jumps across the rim as the tilt goes through zero): a projection that went through
        upright leaves the rim below the ground and the end face flat on it. That face is then
        down: it is tracked too and the body projected onto it (counted in ``face_down``). Likewise any feature
        not tracked that the projection turned into the ground (pulling a tracked feature the holding force
        pressed on back down after a held step in which the body turned fast: a box spun up by a blow about a
        corner): it is tracked too, and the body projected again (``projected_down``), when it is held on this
        plane alone."""
        j = int(self.ground_of[i])
        mask = int(self.tracked[i])
        project(y, sim._prm[i], self.shapes[i], self.grounds[j], mask, sticking, self._points, self._gaps,
                self._owners, self._work)
        band = self._band[i]
        count = feature_gaps(y, sim._prm[i], self.shapes[i], self.grounds[j], self._features)
        end = held_rim(self.shapes[i], mask)
        if end >= 0 and self._features[end] < -band and self._features[2 + end] <= band:  # the face is down, not a
            self.tracked[i] = mask | (4 << end)  # rim point
            self.counts["face_down"] += 1
            project(y, sim._prm[i], self.shapes[i], self.grounds[j], int(self.tracked[i]), sticking, self._points,
                    self._gaps, self._owners, self._work)
            return
        if self.other_ground[i] >= 0:  # held on two planes: projected onto the second after (two_grounds.py)
            return
        for _ in range(count):  # a feature not tracked that the projection turned into the ground: tracked too
            mask = int(self.tracked[i])
            sunk = sum(1 << k for k in range(count) if not mask >> k & 1 and self._features[k] < -band)
            if not sunk:
                return
            self.tracked[i] = mask | sunk
            self.counts["projected_down"] += 1
            project(y, sim._prm[i], self.shapes[i], self.grounds[j], mask | sunk, sticking, self._points, self._gaps,
                    self._owners, self._work)
            feature_gaps(y, sim._prm[i], self.shapes[i], self.grounds[j], self._features)

    def _normal_motion(self, sim, y: np.ndarray, i: int, j: int, count: int, w: np.ndarray, mask: int | None = None):
        """(lowest normal speed, its free normal acceleration, mean slip) of the points in self._points.

        With ``mask`` (the points are those of feature_points, with their owners) the normal
        accelerations carry each gap's exact velocity-product term (persistent.normal_bias);
        without, the points' own centripetal acceleration for a box, none for the round shapes.
        """
        n = self.grounds[j, NORMAL:NORMAL + 3]
        if mask is None:
            self._owners[:] = 0
        normal_bias(y, sim._prm[i], self.shapes[i], self.grounds[j], 0 if mask is None else mask, count,
                    self._points, self._owners, self._bias, self._rdot, self._anchors)
        if mask is None and not self.vertex[i]:
            self._bias[:] = 0.0
            self._rdot[:] = 0.0
        return normal_motion(y, sim._prm[i], w, count, self._points, n[0], n[1], n[2], self._bias, self._rdot,
                             self._work, self._d)

    def _gap(self, sim, y: np.ndarray, i: int) -> tuple[float, int]:
        """(lowest gap, its plane row) of body i at y over the half-spaces and the static shapes."""
        gap, j = body_gap(y, sim._prm[i], self.shapes[i], self.half_spaces, self._points, self._gaps)
        if self.statics is not None:
            dist, s = self.statics.nearest(y, i, self.shapes[i])
            if dist < gap:
                gap, j = dist, self.statics.plane_for(y, sim._prm[i], i, self.shapes[i], s)
        return gap, j

    def step_map(self, sim, i: int, y0: np.ndarray, h: float, w: np.ndarray) -> np.ndarray:
        """Φ(y0, h): body i's state row after one step of length h from y0 under the wrench row w.

        The same code the simulator's step runs for it: its reduced model, or the integrator
        (compiled through stepping.advance, or the numpy/scipy ones), on one-body buffers; a row
        carrying its contact (layout.HELD) taken again by the method's ``held`` step, as
        :meth:`after_step` does.
        """
        Y1, w1, control, inputs = self._Y1, self._w1, self._control1, self._inputs1
        prm1 = sim._prm[i:i + 1]
        Y1[0, 0] = y0
        w1[0] = w
        control[:] = 0
        control[L.METHOD] = sim._control[L.METHOD]
        model = int(prm1[0, L.MODEL])
        control[L.GROUPS + 2 * model + 1] = 1
        inputs[:] = 0.0
        inputs[L.DT], inputs[L.LIMIT] = h, math.inf
        method = sim._method
        with np.errstate(all="ignore"):
            if method.code is not None:
                advance(Y1, prm1, w1, self._members1, self._status1, control, inputs, 1, self._never)
                if w[L.HELD] != 0.0 and method.held is not None:  # its contact found at every stage (stage.py)
                    method.held(Y1[0], Y1[1], prm1, w1, self._members1, h)
            else:
                deferred = step_reduced(Y1, prm1, w1, self._members1, self._status1, control, inputs)
                if len(deferred):
                    from ..integrators import step_exact_rotor_splitting, step_reference

                    if method.name == "exact_rotor_splitting":
                        step_exact_rotor_splitting(Y1[0], Y1[1], prm1, w1, deferred, h)
                    else:
                        step_reference(Y1[0], Y1[1], prm1, w1, deferred, h, **sim._reference_options)
        return Y1[1, 0].copy()

    # ----------------------------------------------------------------- before and after the step

    def add_holding_wrenches(self, sim, wrenches: np.ndarray) -> None:
        """Add to ``wrenches`` (the step's rows, in place) the force holding each body in persistent contact."""
        Y = sim._Ys[sim._control[L.CUR]]
        lists = self._hold_lists
        sleepers, asleep = self._asleep_on_ground(Y, wrenches)
        _, n_one, n_two = split_bodies(self.bodies, self.modes, sim._stopped, asleep, self.other_ground,
                                       lists[0], lists[1], lists[2])
        self.holding_forces[:] = 0.0
        if self.track_torques:
            self._step_angular[:] = 0.0
        if sleepers.size:  # asleep on their ground: held by the force they fell asleep with, not looked at
            self.holding_forces[sleepers] = self._rest_force[sleepers]
            if self.track_torques:
                self._step_angular[sleepers] = self._rest_torque[sleepers] * sim.dt
        self._locked[:] = 0
        self._staged[:] = 0
        if not n_one + n_two:
            return
        one, two = lists[1, :n_one], lists[2, :n_two]  # two: held on two half-spaces (two_grounds.py)
        held_one, held_two = one, two
        if self.statics is not None:  # held on a static shape's plane: in Python (static_geometry.py)
            on_static = one[self.ground_of[one] >= len(self.half_spaces)]
            one = one[self.ground_of[one] < len(self.half_spaces)]
            two = np.concatenate((two, self._refresh_static(sim, Y, on_static)))
        hold_all(Y, sim._prm, wrenches, self.shapes, self.grounds, one, self.ground_of, self.tracked, self.friction,
                 self.tangent_friction, self.first_tangent, SLIP_TOLERANCE, LIFT_OFF_SPEED, TOUCHING_GAP,
                 self._bare_rows, self.pressed, self.sliding, self.slide_direction, self._status, self._locked,
                 self._hold_cache)
        for i in one[self._status[one] != OK]:  # lifting off: the solver says so and records it
            self._hold(sim, Y[i], i, wrenches[i], sim.time, stages=False)
        for i in two:
            self._hold(sim, Y[i], i, wrenches[i], sim.time)
        rows = wrenches  # with the holding forces: a row _hold staged (on a static box's face) has its in _held_rows
        if (staged := np.flatnonzero(self._staged)).size:
            rows = wrenches.copy()
            rows[staged] = self._held_rows[staged]
        for bodies in (held_one, held_two):  # the contact forces go in as world-axes forces (add_wrench)
            record_holds(bodies, self.modes, rows, self._bare_rows, self.holding_forces)
        if self.track_torques:
            resting = np.concatenate((held_one, held_two))
            held = resting[self.modes[resting] == PERSISTENT]
            added = rows[held] - self._bare_rows[held]
            self._step_angular[held] = _torques_about_com(Y[held], added) * sim.dt
        if sim._method.derivative_stages:  # the force found at every stage instead (stage.py)
            one = one[self.modes[one] == PERSISTENT]
            stage_rows(wrenches, self._bare_rows, self._held_rows, Y, sim._prm, self.shapes, self.grounds, one,
                       self.ground_of, self.tracked, self.friction, self.tangent_friction, self.first_tangent,
                       self.sliding, self.slide_direction, SLIP_TOLERANCE, self._locked, self._staged)

    def _asleep_on_ground(self, Y: np.ndarray, wrenches: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(the bodies asleep on their ground alone (:meth:`_rest_alone`), a mask over all bodies of them) at the
        step's start (state rows Y, wrench rows ``wrenches``). One pushed, or whose state was set (an impulse,
        set_body_state: thrown into the ground, say), wakes in this step (the islands' pass) and is held as an awake
        one is, not by the force it fell asleep with."""
        if not self._sleeping or self.pairs is None:
            return self._no_bodies, self._not_done
        islands = self.pairs.islands
        asleep = (islands.asleep != 0) & (self.modes == PERSISTENT)
        sleepers = np.flatnonzero(asleep)
        if sleepers.size:  # the islands' wake rule (island._wakes), on the sleepers' rows alone
            woken = ((wrenches[sleepers, L.ACTIVE] != 0.0)
                     | (Y[sleepers, :L.STATE_WIDTH] != islands.saved[sleepers]).any(axis=1))
            if woken.any():
                asleep[sleepers[woken]] = False
                sleepers = sleepers[~woken]
        return (sleepers, asleep) if sleepers.size else (self._no_bodies, self._not_done)

    def _rest_alone(self, sim, wrenches: np.ndarray, Y0: np.ndarray, Y1: np.ndarray) -> None:
        """After the step: sleeping for the bodies held on one half-space alone (in persistent contact, not sliding,
        pushed by no wrench, in no island; not on a static shape), by the islands' rule (Islands.rest_alone). One
        that falls asleep keeps its mode and ground; the force and torque of its last hold hold it while it sleeps
        (:attr:`holding_forces`, the impulses). Only a body held as the step began: one that landed within it (from
        rest, a drop under g h² / 2) had no hold yet to sleep with."""
        b = self.bodies
        alone = b[(self.modes[b] == PERSISTENT) & (self.pairs.modes_at_start[b] == PERSISTENT)
                  & (self.ground_of[b] < len(self.half_spaces))
                  & (self.other_ground[b] < 0) & ~self.sliding[b] & ~sim._stopped[b]
                  & (self.pairs.islands.island[b] == 0) & (self._bare_rows[b, L.ACTIVE] == 0.0)]
        fell = self.pairs.islands.rest_alone(alone, Y0, Y1, sim.dt)
        if fell.size:
            self._rest_force[fell] = self.holding_forces[fell]
            self._rest_torque[fell] = _torques_about_com(Y0[fell], wrenches[fell] - self._bare_rows[fell])

    def _hold(self, sim, y: np.ndarray, i: int, w: np.ndarray, t: float, stages: bool = True,
              keep: bool = False) -> bool:
        """Add the holding force of body i at y into the wrench row w; False (and flight) if it lifts off, or if its
        contact points move into the ground faster than LIFT_OFF_SPEED (an impulse, a state set): it is then struck
        there at the start of its step (:meth:`_with_events`).

        With ``stages`` and an integrator that evaluates dynamics.derivative at every stage, a body
        on one or two exact planes (half-spaces, static boxes' faces: :meth:`on_exact_plane`) stepped by it gets
        instead its contact in the row, found at every stage (kernels/contact/stage.py; the row with the force
        found here kept in ``_held_rows``)."""
        if self.other_ground[i] >= 0 and not self.other_projected[i]:
            return two_grounds.hold(self, sim, y, i, w, t, LIFT_OFF_SPEED, TOUCHING_GAP, SLIP_TOLERANCE, stages)
        j = int(self.ground_of[i])
        count = held_points(y, sim._prm[i], w, self.shapes[i], self.grounds[j], int(self.tracked[i]), self._points,
                            self._gaps, self._owners, self._d, True)  # a can on its end: turned toward the load
        lowest = float(self._gaps[:count].min()) if count else math.inf  # set_body_state may have lifted it
        mu = self.friction_of(i, j)
        speed, mode, sx, sy = self._holding_force(sim, y, i, count, w, mu)
        if count and self._painleve(count, mu, sx, sy):
            self.counts["painleve"] += 1
        if count and lowest <= TOUCHING_GAP and speed < -LIFT_OFF_SPEED:  # driven into its ground: struck there
            self.modes[i] = FLIGHT  # (_with_events, at the step's start)
            self.sliding[i] = False
            return False
        if count == 0 or (mode == LIFT_OFF and not keep) or speed > LIFT_OFF_SPEED or lowest > TOUCHING_GAP:
            self.modes[i] = FLIGHT
            self.sliding[i] = False
            self.events.append(ContactEvent(t, self.names[i], j, "lift-off", speed, speed))
            return False
        self.sliding[i] = mode == SLIDE
        self.slide_direction[i] = sx, sy
        lam = self._work[0:3 * count:3, _LAM]  # the normal forces of the points, in the order of _tracked_points
        self.pressed[i] = int(sum(1 << int(self._owners[c]) for c in range(count) if lam[c] > 0.0))
        self._bare_rows[i] = w
        add_contact_wrench(w, y, sim._prm[i], count, self._points, self._anchors, self._work)
        if (stages and sim._method.derivative_stages and self.on_exact_plane(j) and self.other_ground[i] < 0
                and stepped_by_integrator(sim._prm[i])):
            self._held_rows[i] = w
            hold_in_row(w, self._bare_rows[i], y, sim._prm[i], self.shapes[i], self.grounds[j], int(self.tracked[i]),
                        mu, mode, sx, sy, SLIP_TOLERANCE)
            self._staged[i] = 1
        return True

    def stages_on_two_planes(self, sim, y: np.ndarray, i: int) -> bool:
        """Whether body i, held on two planes at y (two_grounds.hold), has its contact found at every stage: both
        exact planes (:meth:`on_exact_plane`), the body stepped by a method that evaluates every stage and by
        the integrator (stage.stepped_by_integrator), and no cylinder rim held at one point of a plane it stands
        near upright to (its axis within FACE_TILT of the normal) or whose point turns by more than RIM_TURN in
        the step (persistent.rim_turn_rate). There the point swings round the rim within the step, with the
        force found at it: a frictionless can at rest with its end face on a wall and its rim on the floor gained
        1.5e7 J in a 10 ms rk4 step. The force of the step's start is held over the step instead."""
        if not (sim._method.derivative_stages and stepped_by_integrator(sim._prm[i])):
            return False
        shape = self.shapes[i]
        for j, mask in ((int(self.ground_of[i]), int(self.tracked[i])),
                        (int(self.other_ground[i]), int(self.other_tracked[i]))):
            if not self.on_exact_plane(j):
                return False
            if held_rim(shape, mask) < 0:
                continue
            n = self.grounds[j, NORMAL:NORMAL + 3]
            if (axis_tilt(y, sim._prm[i], n[0], n[1], n[2])[7] < FACE_TILT
                    or rim_turn_rate(y, sim._prm[i], shape, self.grounds[j], mask) * sim.dt > RIM_TURN):
                return False
        return True

    def on_exact_plane(self, j: int) -> bool:
        """Whether ground row j is an exact plane: a half-space or a static box's face (not the tangent plane of a
        static shape's curved side, which holds to first order only)."""
        return j < len(self.half_spaces) or not self.statics.is_tangent(j)

    def _holding_force(self, sim, y: np.ndarray, i: int, count: int, w: np.ndarray, mu: float):
        """(lowest normal speed, mode, ŝ1, ŝ2) of body i at y held on the ``count`` points of its tracked features
        (self._points) under the wrench row w (without contact); the force in self._work, for add_contact_wrench."""
        j = int(self.ground_of[i])
        n = self.grounds[j, NORMAL:NORMAL + 3]
        speed, _, _, _ = self._normal_motion(sim, y, i, j, count, w, int(self.tracked[i]))
        mode, _, sx, sy = holding_wrench(y, sim._prm[i], w, count, self._points, n[0], n[1], n[2], mu,
                                         SLIP_TOLERANCE, self._bias, self._rdot, self._work, self._d, self._force)
        return speed, mode, sx, sy

    def _painleve(self, count: int, mu: float, sx: float, sy: float) -> bool:
        """Whether the sliding contact rows in self._work (holding_wrench's) are in a Painlevé configuration.

        Sliding along ŝ, friction −μ f_n ŝ enters each normal acceleration: f_n acts on it through
        A_nn − μ (A_nt1 ŝ1 + A_nt2 ŝ2), the diagonal projected Gauss–Seidel solves with. Where that is
        ≤ 0 the rigid problem may have no solution or several (a uniform rod sliding on its end at θ
        to the ground: 1 + 3 cos²θ − 3 μ sin θ cos θ ≤ 0, possible for μ ≥ 4/3). The solver does not
        resolve it (the normal force stays 0: the body lifts off and lands again); it is counted.
        """
        if mu == 0.0 or (sx == 0.0 and sy == 0.0):
            return False
        work = self._work
        for c in range(count):
            a = 3 * c
            if work[a, _A + a] - mu * (work[a, _A + a + 1] * sx + work[a, _A + a + 2] * sy) <= 0.0:
                return True
        return False

    def all_asleep(self, sim, wrenches: np.ndarray) -> bool:
        """Whether no body moves in the coming step (``wrenches`` its rows): every moving body asleep, none pushed,
        stopped or set (Islands.all_asleep). Then the simulator carries the state over and calls
        :meth:`after_asleep_step` instead of stepping."""
        return (self._sleeping and self.pairs is not None  # sleeping off: none asleep, no check
                and self.pairs.islands.all_asleep(sim, wrenches, sim._Ys[sim._control[L.CUR]]))

    def _count_holds(self, dt: float) -> None:
        """The step (dt) is applied: its holding forces and torques (add_holding_wrenches) × dt added to the sums."""
        self.holding_impulses += self.holding_forces * dt
        if self.track_torques:
            self.holding_angular_impulses += self._step_angular

    def after_asleep_step(self, sim) -> None:
        """After a step in which no body moved (:meth:`all_asleep`): the locked islands' contacts listed and logged
        for it, as :meth:`after_step` would have."""
        self._count_holds(sim.dt)
        cur = sim._control[L.CUR]
        self._static_skipped.clear()
        self._side_hits.clear()
        self._face_landings.clear()
        self.may_pass.clear()
        self.pairs.islands.asleep_step(sim._Ys[1 - cur], sim._Ys[cur], sim.dt)

    def after_step(self, sim, wrenches: np.ndarray) -> None:
        """Events inside the step just taken (the simulator's buffers: start in 1 − CUR, end in CUR)."""
        self._count_holds(sim.dt)
        cur = sim._control[L.CUR]
        Y0, Y1 = sim._Ys[1 - cur], sim._Ys[cur]
        h = sim.dt
        t0 = sim.time - h
        if sim._method.held is not None and (staged := np.flatnonzero(self._staged)).size:
            sim._method.held(Y0, Y1, sim._prm, wrenches, staged, h)  # their steps with the contact found at every stage
        self._static_skipped.clear()
        self._side_hits.clear()
        self._face_landings.clear()
        self.may_pass.clear()
        # body–body events first (body_pairs.py): the bodies it stepped are done
        done = self.pairs.after_step(sim, wrenches, Y0, Y1, t0, h) if self.pairs is not None else None
        if self.pairs is not None and len(self.pairs.islands.left):
            done = self._out_of_islands(sim, wrenches, Y0, Y1, t0, h, done)
        lists = self._step_lists
        n_flying, n_one, n_two = split_bodies(self.bodies, self.modes, sim._stopped,
                                              self._not_done if done is None else done, self.other_ground,
                                              lists[0], lists[1], lists[2])
        flying, resting, two = lists[0, :n_flying], lists[1, :n_one], lists[2, :n_two]  # two: two_grounds.py
        lowest = self._flying_gaps[:flying.size]
        min_gaps(Y1, sim._prm, self.shapes, self.half_spaces, flying, lowest)
        # static shapes: their gaps too (the bodies outside the islands); bodies on their planes in Python
        if self.statics is not None:
            moving = ~sim._stopped[self.bodies]
            if done is not None:
                moving &= ~done[self.bodies]
            in_flight = (self.modes[self.bodies] == FLIGHT) & moving
            self._lowest[:] = math.inf
            self._lowest[in_flight] = lowest
            two = np.concatenate((two, self._static_busy(Y1, resting, moving)))
            resting = resting[self.ground_of[resting] < len(self.half_spaces)]
            lowest = self._lowest[in_flight]
        settle_all(Y0, Y1, sim._prm, self.shapes, self.half_spaces, resting, self.ground_of, self.tracked,
                   self.pressed, self.sliding, self.slide_direction, self._band, self._status, self._locked)
        settled = resting
        if self._any_cylinder:
            resting = self._fast_rims(sim, resting, Y0, Y1, t0, h)
        resting = self._refine_gains(sim, resting, Y0, Y1, t0, h)
        two = self._refine_two(sim, two, Y0, Y1, t0, h)
        if len(resting) < len(settled) and len(two):  # a step taken again whole is done, near a static shape too
            two = two[~np.isin(two, np.setdiff1d(settled, resting))]
        if len(two):  # a body on a half-space near a static shape that the compiled pass hands over too: looked at
            # once (its step taken a second time from its start had the wall it was struck against and left pressed
            # on out of view, and went through it; and the busy list, as long as the bodies, overflowed)
            two = two[~np.isin(two, resting[self._status[resting] == TO_SOLVER])]
        # only the bodies with an event in the step are looked at in Python
        for i in self._busy[:busy_bodies(resting, self._status, two, flying, lowest, self._busy)].tolist():
            if sim._stopped[i]:
                continue
            if self.modes[i] == PERSISTENT:
                end = self._held_end(sim, i, Y0[i], Y1[i], wrenches[i], self._bare(i, wrenches[i]), t0, h)
                Y1[i, :L.STATE_WIDTH] = end[:L.STATE_WIDTH]
            else:
                Y1[i, :L.STATE_WIDTH] = self._with_events(sim, i, Y0[i], wrenches[i], t0, h)[:L.STATE_WIDTH]
        if self.pairs is not None:  # bodies that meet each other (a ground alone takes energy, never passes it on)
            self.pairs.look_again(sim, wrenches, Y0, Y1, t0, h)  # a pair a ground or a third body sent in, again
            if self._sleeping:
                self._rest_alone(sim, wrenches, Y0, Y1)
            self._bound_energy(sim, Y1)

    def _bound_energy(self, sim, Y1: np.ndarray) -> None:
        """The blow-up bound (√J, simulator.DivergenceError) of each body that met another moving body in the step
        (an impact, an island's step) raised to at least √K at the step's end: contact passes energy from body to
        body and never adds it, so what a body took from another is not a blow-up (a ball resting on the ground,
        locked, hit by a falling one). Any other body's is left as its step set it: the ground and static shapes
        only take energy, so one that gained more than its wrenches and gravity could give it (a held step far
        beyond its integrator's |ω| h limit) blew up, and the next step's check says so. A body in flight has √K
        within its bound already."""
        b = self.bodies[self.pairs.exchanged[self.bodies]]
        if not len(b):
            return
        p, rows = sim._prm[b], Y1[b]
        v, w = rows[:, L.V:L.V + 3], rows[:, L.W:L.W + 3]
        spin = np.einsum("ij,ij,ij->i", p[:, L.INERTIA:L.INERTIA + 3], w, w)
        energy = 0.5 * (p[:, L.MASS] * np.einsum("ij,ij->i", v, v) + spin)
        Y1[b, L.BOUND] = np.maximum(rows[:, L.BOUND], np.sqrt(energy))

    def _out_of_islands(self, sim, wrenches: np.ndarray, Y0: np.ndarray, Y1: np.ndarray, t0: float, h: float,
                        done: np.ndarray | None) -> np.ndarray:
        """The bodies out of their island this step: each touching its ground at the step's start (and not moving
        away) is in persistent contact from there, and its step is taken again held on it (the free step it had
        lacked the holding force: friction included); those a body–body event stepped are classified at the end.
        Returns ``done`` with the bodies stepped here."""
        done = np.zeros(len(sim._stopped), dtype=bool) if done is None else done.copy()  # (the islands' own mask)
        for i in self.pairs.islands.left:
            i = int(i)
            if sim._stopped[i]:
                continue
            if done[i]:
                self.classify(sim, Y1, i)
                continue
            self.classify(sim, Y0, i)
            if self.modes[i] == PERSISTENT:
                Y1[i, :L.STATE_WIDTH] = self._persistent_span(sim, i, Y0[i].copy(), wrenches[i], t0, h)[:L.STATE_WIDTH]
                done[i] = True
        return done

    def _fast_rims(self, sim, resting: np.ndarray, Y0: np.ndarray, Y1: np.ndarray, t0: float, h: float) -> np.ndarray:
        """Take again, in pieces (:meth:`_persistent_span`), the step of every ``resting`` body rolling on a
        cylinder rim whose lowest point turns by more than RIM_TURN in it; returns ``resting`` without them
        (marked done in the status)."""
        fast = fast_rims(Y0, sim._prm, self.shapes, self.grounds, resting, self.ground_of, self.tracked,
                         RIM_TURN / h, self._rims)
        return self._retake_all(sim, self._rims[:fast], resting, Y0, Y1, t0, h, 1)

    def _retake_all(self, sim, bodies: np.ndarray, resting: np.ndarray, Y0: np.ndarray, Y1: np.ndarray, t0: float,
                    h: float, pieces: int) -> np.ndarray:
        """The steps of ``bodies`` taken again from Y0 in ``pieces`` pieces (:meth:`_retaken`) into Y1; returns
        ``resting`` without them (marked done in the status)."""
        if not bodies.size:
            return resting
        for i in bodies.tolist():
            Y1[i, :L.STATE_WIDTH] = self._retaken(sim, i, Y0[i], t0, h, pieces)
            self._status[i] = -1  # done here
        return resting[self._status[resting] != -1]

    def _retaken(self, sim, i: int, y0: np.ndarray, t0: float, h: float, pieces: int) -> np.ndarray:
        """Body i's step from y0 (the step's start, the solver's state of body i as it was there) taken again in
        ``pieces`` pieces, each holding force found afresh; under gravity alone (an empty bare row: its energy
        must not rise), in twice as many while its energy rose, up to MAX_REFINEMENT (a step taken in more than
        one piece is counted in ``refined_steps``, one still gaining in :attr:`energy_gains`). Returns its state
        row."""
        prm = sim._prm
        e0 = None if self._bare_rows[i, L.ACTIVE] != 0.0 else _energy(y0, prm[i])
        saved = (int(self.modes[i]), int(self.tracked[i]), bool(self.sliding[i]), self.slide_direction[i].copy(),
                 int(self.pressed[i]), int(self.ground_of[i]), int(self.other_ground[i]), bool(self.other_projected[i]),
                 int(self.other_tracked[i]), len(self.events))
        # what an attempt's impacts leave (a static shape it was found pressed on, its side impacts, the impulses
        # it was given) is undone with it: an attempt taken again must meet the same walls
        skipped, hits, impulses = self._static_skipped.get(i), self._side_hits.get(i), self.impact_impulses[i].copy()
        bare = self._bare_rows[i].copy()
        gained = 0.0
        while True:
            self.modes[i], self.tracked[i], self.sliding[i], self.slide_direction[i], self.pressed[i], \
                self.ground_of[i], self.other_ground[i], self.other_projected[i], self.other_tracked[i] = saved[:9]
            del self.events[saved[9]:]
            if skipped is None:
                self._static_skipped.pop(i, None)
            else:
                self._static_skipped[i] = skipped
            if hits is None:
                self._side_hits.pop(i, None)
            else:
                self._side_hits[i] = hits
            self.impact_impulses[i] = impulses
            y = y0.copy()
            for k in range(pieces):
                t = t0 + k * h / pieces
                if self.modes[i] == PERSISTENT:
                    y = self._persistent_span(sim, i, y, bare.copy(), t, h / pieces)
                else:
                    y = self._with_events(sim, i, y, bare.copy(), t, h / pieces)
            row = y[:L.STATE_WIDTH]
            if e0 is None:
                break
            gained = _energy(row, prm[i]) - e0
            if gained <= 1e-12 * abs(e0) or pieces >= MAX_REFINEMENT:
                break
            pieces *= 2
        if pieces > 1:
            self.counts["refined_steps"] += 1
        if e0 is not None and gained > 1e-12 * abs(e0):
            self.energy_gains += 1
        return row

    def _rim_piece(self, sim, i: int, y: np.ndarray, h: float) -> float:
        """How much of the span h body i, held at y, steps in one piece: all of it, or, on a cylinder rim whose
        lowest point turns fast (persistent.rim_turn_rate), the time it takes to turn RIM_TURN (at least
        dt / MAX_RIM_PIECES)."""
        if self.shapes[i, KIND] != SHAPE_CYLINDER or self.other_ground[i] >= 0:
            return h
        j = int(self.ground_of[i])
        rate = rim_turn_rate(y, sim._prm[i], self.shapes[i], self.grounds[j], int(self.tracked[i]))
        if rate * h <= RIM_TURN:
            return h
        return min(max(RIM_TURN / rate, sim.dt / MAX_RIM_PIECES), h)

    def _refine_gains(self, sim, resting: np.ndarray, Y0: np.ndarray, Y1: np.ndarray, t0: float,
                      h: float) -> np.ndarray:
        """Take again, in 2, 4, ... MAX_REFINEMENT pieces, each holding force found afresh, the step
        of every resting body under gravity alone whose energy it raised.

        The holding force is held over a step (zero-order hold); where the contact point races
        over a curved rim (a disk or cylinder rolling on its edge) that can do work. Shorter
        pieces shrink it; a body still gaining at the finest split keeps that result and is
        counted in :attr:`energy_gains`. Returns ``resting`` (the bodies handled here are marked
        done in the status).
        """
        # gravity alone (an empty bare row): the energy must not rise
        rose = gravity_gains(Y0, Y1, sim._prm, resting, self._status, self._bare_rows, self._rose)
        return self._retake_all(sim, self._rose[:rose], resting, Y0, Y1, t0, h, 2)

    def _refine_two(self, sim, two: np.ndarray, Y0: np.ndarray, Y1: np.ndarray, t0: float, h: float) -> np.ndarray:
        """:meth:`_refine_gains` for the bodies held on two half-spaces or beside a static shape (``two``): the step
        of each under gravity alone whose energy it raised (its holding force held over the step: a can on its side
        against a wall, held up by the wall until its other rim lands within the step) taken again in 2, 4, ...
        MAX_REFINEMENT pieces. Returns ``two`` without them (done)."""
        if not two.size:
            return two
        prm = sim._prm
        rose = []  # gravity alone (an empty bare row): the energy must not rise (as gravity_gains has it)
        for i in two.tolist():
            if self._bare_rows[i, L.ACTIVE] == 0.0 and not sim._stopped[i]:
                e0 = _energy(Y0[i], prm[i])
                if _energy(Y1[i], prm[i]) > e0 + 1e-12 * abs(e0) + 1e-300:
                    rose.append(i)
        if not rose:
            return two
        for i in rose:
            Y1[i, :L.STATE_WIDTH] = self._retaken(sim, i, Y0[i], t0, h, 2)
        return two[~np.isin(two, rose)]

    # ----------------------------------------------------------------- flight: impacts

    def _with_events(self, sim, i: int, y0: np.ndarray, w: np.ndarray, t: float, h: float) -> np.ndarray:
        """Body i's step from y0 over h taken again in pieces, event after event (flight to persistent)."""
        y = y0.copy()
        after_impact = False
        hint = -1.0
        impacts = 0
        for _ in range(MAX_EVENTS_PER_STEP):
            if h <= 0.0:
                return y
            if self.modes[i] == PERSISTENT:
                return self._persistent_span(sim, i, y, w, t, h)
            # touching and moving into it: struck at once; just struck, only by a static shape it touches as well
            # and moves into (its step may end beyond a thin wall: a pebble in a bin's corner struck off the ground)
            if impacts < ZENO_IMPACTS and self._driven_in(sim, y, i, w, after_impact):
                hint = self._impact(sim, i, y, w, t, h)
                after_impact = True
                impacts += 1
                continue
            end = self.step_map(sim, i, y, h, w)
            if self._gap(sim, end, i)[0] >= 0.0:
                return end
            s = None if impacts >= ZENO_IMPACTS else self._locate(
                lambda s: self._gap(sim, self.step_map(sim, i, y, s * h, w), i)[0],
                0.0 if after_impact else self._gap(sim, y, i)[0], hint)
            if s is None:  # a rebound too small to resolve, or a Zeno sequence (ZENO_IMPACTS): rest here
                self._rest(sim, i, y, self._resting_ground(sim, y, i), t, 0.0, 0.0)
                continue
            y = self.step_map(sim, i, y, s * h, w) if s > 0.0 else y
            t, h = t + s * h, h - s * h
            hint = self._impact(sim, i, y, w, t, h)
            after_impact = True
            impacts += 1
        raise RuntimeError(f"{self.names[i]!r}: more than {MAX_EVENTS_PER_STEP} contact events in one step at t = {t}")

    def _driven_in(self, sim, y: np.ndarray, i: int, w: np.ndarray, just_struck: bool = False) -> bool:
        """Whether body i at y touches its nearest ground (within TOUCHING_GAP) with a contact point moving into it
        faster than LIFT_OFF_SPEED, or a static shape it touches too (:meth:`_approached_static`): a resting body
        given an impulse or a velocity into it, which no root of the gap inside the step marks (it starts at
        zero). ``just_struck``: body i was struck at y against its lowest plane, which it leaves (its speed into
        it within LIFT_OFF_SPEED of zero is round-off, not a new impact): only a static shape it touches as well
        and moves into counts (a pebble in a bin's corner struck off the ground into a wall: its step went through
        the wall)."""
        if not y[L.V:L.W + 3].any():  # at rest
            return False
        gap, j = self._gap(sim, y, i)
        if gap > TOUCHING_GAP:
            return False
        speed = self._speed_into(sim, y, i, j, w)
        if speed < -LIFT_OFF_SPEED and not just_struck:
            return True
        # not into its lowest plane: into a static shape it touches as well (a pebble in a bin's corner thrown into
        # one wall; _impact strikes it there)
        other = self._approached_static(sim, y.copy(), i, gap, j, w) if speed >= -LIFT_OFF_SPEED else None
        return other is not None and other[3] < -LIFT_OFF_SPEED

    def _driven_into_side(self, sim, y: np.ndarray, i: int, w: np.ndarray) -> bool:
        """Whether body i at y, in persistent contact, touches another half-space or a static shape (within its
        feature band) with a contact point moving into it faster than LIFT_OFF_SPEED: its step may go through a
        static shape and end beyond it."""
        if not y[L.V:L.W + 3].any():  # at rest
            return False
        gap, jj = self._other_gap(sim, y, i)
        return jj >= 0 and gap <= self._band[i] and self._speed_into(sim, y, i, jj, w) < -LIFT_OFF_SPEED

    def _speed_into(self, sim, y: np.ndarray, i: int, j: int, w: np.ndarray) -> float:
        """The lowest normal speed (m/s, positive away) of body i's contact points at y on plane row j; 0 without
        any."""
        count = self._contact_points(sim, y, i, j)
        return self._normal_motion(sim, y, i, j, count, w)[0] if count else 0.0

    def _resting_ground(self, sim, y: np.ndarray, i: int) -> int:
        """The ground body i at y comes to rest on where a rebound is too small to resolve: its lowest plane (a
        half-space, or a static shape's plane), or a half-space it touches too (within its feature band or inside)
        that faces more against gravity (a box lying flat on the floor in a bin's corner, a little inside a wall:
        held on the wall alone, it fell into the floor)."""
        j = self._gap(sim, y, i)[1]
        down = sim._prm[i, L.GRAVITY:L.GRAVITY + 3]
        best = -float(self.grounds[j, NORMAL:NORMAL + 3] @ down)
        for jj in range(len(self.half_spaces)):
            facing = -float(self.grounds[jj, NORMAL:NORMAL + 3] @ down)
            if jj != j and facing > best:
                count = body_points(y, sim._prm[i], self.shapes[i], self.grounds[jj], self._points, self._gaps)
                if count and self._gaps[:count].min() <= self._band[i]:
                    j, best = jj, facing
        return int(j)

    def _locate(self, gap, g0: float, hint: float) -> float | None:
        """The first root s in [0, 1] of gap(s) (gap(1) < 0), to round-off: bracket, then Illinois.

        ``g0`` is gap(0) (0 right after an impact, where the gap opens first); ``hint`` a
        fraction of the step where the gap should be positive (the rebound's apex), or < 0.
        """
        samples = sorted({k / BRACKET_SAMPLES for k in range(1, BRACKET_SAMPLES + 1)} | ({hint} if 0.0 < hint < 1.0 else set()))
        lo, g_lo = 0.0, g0
        hi = g_hi = None
        for s in samples:
            g = gap(s)
            if g < 0.0:
                hi, g_hi = s, g
                break
            if g > 0.0:
                lo, g_lo = s, g
        if hi is None:  # gap(1) < 0 was seen by the caller; round-off made it ≥ 0 here
            return 1.0
        if lo == 0.0 and g_lo <= 0.0:  # the rebound ends before the first sample: halve towards 0
            s = hi
            for _ in range(60):
                s *= 0.5
                g = gap(s)
                if g > 0.0:
                    lo, g_lo = s, g
                    break
                if g < 0.0:
                    hi, g_hi = s, g
            else:
                return None
        side = 0
        for _ in range(200):
            s = (lo * g_hi - hi * g_lo) / (g_hi - g_lo)
            if not lo < s < hi:
                s = 0.5 * (lo + hi)
                if not lo < s < hi:
                    break
            g = gap(s)
            if g > 0.0:
                lo, g_lo = s, g
                if side == 1:
                    g_hi *= 0.5
                side = 1
            elif g < 0.0:
                hi, g_hi = s, g
                if side == -1:
                    g_lo *= 0.5
                side = -1
            else:
                return s
        return lo

    def _impact(self, sim, i: int, y: np.ndarray, w: np.ndarray, t: float, h_left: float) -> float:
        """The impact of body i at y (in place: put onto the surface, velocities changed). The apex hint."""
        gap, j = self._gap(sim, y, i)
        n = self.grounds[j, NORMAL:NORMAL + 3]
        y[L.P:L.P + 3] -= gap * n
        count = self._contact_points(sim, y, i, j)
        before, _, _, _ = self._normal_motion(sim, y, i, j, count, w)
        if before >= 0.0 and (other := self._approached_static(sim, y, i, gap, j, w)) is not None:
            j, n, count, before = other  # touching a static shape as well, and moving into it: it is struck
        e, mu = self.restitution_of(i, j), self.friction_of(i, j)
        after_row = y.copy()
        impulse, e0, e1, alpha = impact(y, after_row, sim._prm[i], count, self._points, n[0], n[1], n[2], e, mu,
                                        self._work)
        jump = self._jump(sim, i, y, after_row, count, e, alpha)
        y[L.V:L.W + 3] = after_row[L.V:L.W + 3]
        speed, accel, _, _ = self._normal_motion(sim, y, i, j, count, w)
        self.events.append(ContactEvent(t, self.names[i], j, "impact", before, speed, impulse, e0, e1, *jump))
        toward = -accel  # the free normal acceleration toward the ground
        if speed <= 0.0 or (toward > 0.0 and speed * speed <= 2.0 * toward * ZENO_APEX):
            rest = 0.0
            if speed > 0.0 and e < 1.0:
                rest = 2.0 * speed / (toward * (1.0 - e))  # the remaining flights: a geometric series
            self._rest(sim, i, y, j, t, rest, speed)
            return -1.0
        return speed / (toward * h_left) if toward > 0.0 and h_left > 0.0 else -1.0

    def _approached_static(self, sim, y: np.ndarray, i: int, gap: float, j: int, w: np.ndarray):
        """Body i at y, not moving into plane j (its lowest gap, ``gap``): of the planes of the two static shapes
        nearest it that it touches as well (their distance within the body's feature band of ``gap``), the one it
        moves into fastest, put onto it: (its plane row, normal, contact points' count, normal speed); else None,
        the contact points left as plane j's. A ball in a corner of the ground and two walls, rising off the ground
        and rolling into the walls, was struck against the ground (the tie of the lowest gap went to it) again and
        again at one instant."""
        if self.statics is None:
            return None
        best = None
        k = -1
        for _ in range(2):
            dist, k = self.statics.nearest(y, i, self.shapes[i], exclude=k)
            if k < 0 or dist > gap + self._band[i]:
                break
            jj = self.statics.plane_for(y, sim._prm[i], i, self.shapes[i], k)
            if jj == j:
                continue
            count = self._contact_points(sim, y, i, jj)
            before, _, _, _ = self._normal_motion(sim, y, i, jj, count, w)
            if before < 0.0 and (best is None or before < best[3]):
                best = (jj, self.grounds[jj, NORMAL:NORMAL + 3].copy(), count, before, dist)
        if best is None:
            self._contact_points(sim, y, i, j)
            return None
        jj, n, count, before, dist = best
        y[L.P:L.P + 3] -= min(dist, 0.0) * n
        self._contact_points(sim, y, i, jj)
        return jj, n, count, before

    def _jump(self, sim, i: int, before: np.ndarray, after: np.ndarray, count: int, e: float,
              alpha: float) -> tuple:
        """The velocity jump of body i's impact from ``before`` to ``after`` (state rows), as ContactEvent's
        (delta_v_world, delta_w_principal, q_WP, contacts, restitution_used); adds its impulse to
        :attr:`impact_impulses` and counts the model-dependent and capped impacts."""
        prm = sim._prm[i]
        dv = after[L.V:L.V + 3] - before[L.V:L.V + 3]
        dw = after[L.W:L.W + 3] - before[L.W:L.W + 3]
        q = before[L.Q:L.Q + 4]
        self.impact_impulses[i, 0:3] += prm[L.MASS] * dv
        self.impact_impulses[i, 3:6] += quat_rotate(q, prm[L.INERTIA:L.INERTIA + 3] * dw)
        if count > 1 and e > 0.0:
            self.counts["multi_contact_elastic"] += 1
        if alpha < e:
            self.counts["restitution_capped"] += 1
        return tuple(dv.tolist()), tuple(dw.tolist()), tuple(q.tolist()), int(count), float(alpha)

    def _rest(self, sim, i: int, y: np.ndarray, j: int, t: float, remaining: float, speed: float) -> None:
        """Body i goes into persistent contact with ground j at y (projected in place), on it alone (a second ground
        is taken when it meets one: :meth:`_side_impact`); 'rest' dated t + remaining."""
        self.modes[i] = PERSISTENT
        self.ground_of[i] = j
        self.other_ground[i] = -1  # not the one of an earlier rest (it may be j itself, or parallel to it)
        self.other_projected[i] = False
        self.tracked[i] = self._staying(sim, y, i, j, self._touching(sim, y, i, j))
        self._settle(sim, y, i, False)
        self.events.append(ContactEvent(t + remaining, self.names[i], j, "rest", speed, 0.0))

    # ----------------------------------------------------------------- persistent contact

    def _persistent_span(self, sim, i: int, y: np.ndarray, w: np.ndarray, t: float, h: float) -> np.ndarray:
        """Body i from y over h in persistent contact starting mid-step: holding force, step, projection; in
        pieces while it rolls on a cylinder rim whose lowest point turns fast (:meth:`_rim_piece`). A piece that
        threw it (:meth:`_thrown`), the smallest or not (a can dropped on near its rim gained 1.6 J in a larger
        one), is taken from its start as :meth:`_instead_of_throw` has a thrown held step."""
        while (piece := self._rim_piece(sim, i, y, h)) < h:
            self.counts["rim_pieces"] += 1
            self.counts["rim_capped"] += piece == sim.dt / MAX_RIM_PIECES
            start, end = y, held_rim(self.shapes[i], int(self.tracked[i]))
            y = self._held_span(sim, i, y, w, t, piece, thrown_at_rest=False)  # a throw is a landing (below)
            if end >= 0 and self._thrown(sim, i, start, y, w):
                # near upright the rim's force found at every stage (growing as 1/sin³ θ) threw the can: taken from
                # the piece's start as a thrown held step is (its end face lands there)
                return self._instead_of_throw(sim, i, start.copy(), w, t, h)[0]
            t, h = t + piece, h - piece
            if self.modes[i] != PERSISTENT:
                return self._with_events(sim, i, y, w, t, h)
        return self._held_span(sim, i, y, w, t, h)

    @staticmethod
    def _thrown(sim, i: int, y0: np.ndarray, y1: np.ndarray, w: np.ndarray) -> bool:
        """Whether body i's K + U rose from y0 to y1 by more than THROWN of it under gravity alone (its wrench row
        ``w``, without contact, empty; False otherwise)."""
        if w[L.ACTIVE] != 0.0:
            return False
        p = sim._prm[i]
        e0 = _energy(y0, p)
        return _energy(y1, p) > e0 + THROWN * abs(e0)

    def _came_back(self, i: int, t: float, dt: float) -> bool:
        """Whether body i rests at t (its latest event, dated within 1e-9 dt of t: a rest after an impact too
        small to resolve is dated at its accumulation time) having lifted off within 1e-9 dt before: its contact
        points accelerate away from the ground (no holding force), but the method's own step of its flight comes
        down at once (a first-order method on a can spinning on its rim; a body barely touching a static shape's
        plane, struck again 1e-14 s on). It is then held with a zero force and projected after the span, so that
        its time moves on instead of lifting off and resting again."""
        mine = [e for e in self.events[-3:] if e.body == self.names[i]]
        return (len(mine) >= 2 and mine[-1].kind == "rest" and abs(mine[-1].time - t) <= 1e-9 * dt
                and any(e.kind == "lift-off" and t - e.time <= 1e-9 * dt for e in mine[:-1]))

    def _held_rest(self, sim, i: int, y: np.ndarray, held: np.ndarray, t: float, h: float,
                   end: np.ndarray | None = None) -> np.ndarray:
        """Body i held at y over the rest h of its step under ``held`` (its row with the holding force of the
        step's start), ``end`` that step's end if taken: :meth:`_persistent_end`, or on a fast rim
        (:meth:`_rim_piece`) the span again in pieces, each with its holding force found afresh."""
        if self._rim_piece(sim, i, y, h) < h:
            return self._persistent_span(sim, i, y, self._bare(i, held), t, h)
        end = self.step_map(sim, i, y, h, held) if end is None else end
        return self._persistent_end(sim, i, y, end, held, t, h)

    def _held_span(self, sim, i: int, y: np.ndarray, w: np.ndarray, t: float, h: float,
                   thrown_at_rest: bool = True) -> np.ndarray:
        """Body i from y over h in persistent contact, in one piece: holding force, step, projection. A step that
        threw it is taken as :meth:`_held_end` has it, unless ``thrown_at_rest`` is False (a rim piece: the caller
        lands the can's end face instead)."""
        held = w.copy()
        if not self._hold(sim, y, i, held, t, keep=self._came_back(i, t, sim.dt)):
            return self._with_events(sim, i, y, w, t, h)
        end = self.step_map(sim, i, y, h, held)
        if not thrown_at_rest:
            return self._persistent_end(sim, i, y, end, held, t, h)
        return self._held_end(sim, i, y, end, held, w, t, h)

    def _held_end(self, sim, i: int, y0: np.ndarray, end: np.ndarray, held: np.ndarray, bare: np.ndarray, t: float,
                  h: float) -> np.ndarray:
        """The end of body i's held step from y0 over h (``end``, under ``held``; ``bare`` its row without the
        holding force): one that threw it (:meth:`_thrown`) taken as :meth:`_instead_of_throw` has it, else
        :meth:`_persistent_end`. y0 is not changed. A slide that stops within the step is not looked at so: held
        at its start's friction to the step's end, it overshoots the stop and slips back, which can raise K + U past
        THROWN (a 1 cm pebble at 5 cm/s, dt = 5 ms); :meth:`_persistent_end` locates the stop and looks at the
        piece up to it (:meth:`_unless_thrown`)."""
        if self._thrown(sim, i, y0, end, bare) and not self._slide_stops(sim, i, end, held):
            return self._instead_of_throw(sim, i, y0.copy(), bare, t, h)[0]
        return self._persistent_end(sim, i, y0, end, held, t, h)

    def _slide_stops(self, sim, i: int, end: np.ndarray, held: np.ndarray) -> bool:
        """Whether body i slides and its slip along its slide's direction has stopped or reversed at ``end``."""
        sx, sy = self.slide_direction[i]
        if not self.sliding[i] or (sx == 0.0 and sy == 0.0):
            return False
        count = self._tracked_points(sim, end, i)
        _, _, vx, vy = self._normal_motion(sim, end, i, int(self.ground_of[i]), count, held, int(self.tracked[i]))
        return vx * sx + vy * sy <= 0.0

    def _instead_of_throw(self, sim, i: int, y: np.ndarray, w: np.ndarray, t: float,
                          h: float) -> tuple[np.ndarray, bool]:
        """Body i, held at y, thrown by its held step (:meth:`_thrown`): (its state instead, whether a face landed).
        A can held on its rim near upright (FACE_TILT) has its end face land there, as after a rim piece, then the
        rest h of its span (:meth:`_landing`; ``w`` its wrench row without the holding force), at most
        MAX_FACE_LANDINGS times a step; any other body (or a can past those) stays where it was, at rest, for the
        span (:meth:`_left_at_rest`: a squat can standing on its end against a wall spun up to 3.4e5 rad/s in one
        10 ms step; a can beside a wall landed on its end face and held on its rim again, thrown again, 150 times in
        one step)."""
        rim = held_rim(self.shapes[i], int(self.tracked[i]))
        landings = self._face_landings.get(i, 0)
        if rim < 0 or landings >= MAX_FACE_LANDINGS or self._tilt(sim, y, i) > FACE_TILT:
            return self._left_at_rest(y), False
        self.counts["face_landed"] += 1
        self._face_landings[i] = landings + 1
        return self._landing(sim, i, y, w, t, h, 4 << rim), True

    def _tilt(self, sim, y: np.ndarray, i: int) -> float:
        """sin of the tilt of body i's axis (a can's, a capsule's) at y from its ground's normal."""
        n = self.grounds[int(self.ground_of[i]), NORMAL:NORMAL + 3]
        return float(axis_tilt(y, sim._prm[i], n[0], n[1], n[2])[7])

    def _left_at_rest(self, y: np.ndarray) -> np.ndarray:
        """A held step threw the body from y (its holding force, found at every stage, raised its K + U under gravity
        alone by more than THROWN): it stays where it was, at rest, for the span, counted in ``held_thrown``."""
        self.counts["held_thrown"] += 1
        rest = y.copy()
        rest[L.V:L.W + 3] = 0.0
        return rest

    def _bare(self, i: int, held: np.ndarray) -> np.ndarray:
        """The wrench row ``held`` without the holding force _hold added to it for body i."""
        return self._bare_rows[i].copy()

    def _persistent_end(self, sim, i: int, y0: np.ndarray, end: np.ndarray, held: np.ndarray, t: float,
                        h: float) -> np.ndarray:
        """End of a step of body i in persistent contact, from y0 over h under ``held`` (with the holding force).

        In order: the stop of a slide, or another feature reaching the ground (each located on
        the step map, the rest of the step taken from there); tracked features that moved off
        the ground dropped (none left: lift-off); then the projection onto the contact.
        """
        if self.other_ground[i] >= 0 and not self.other_projected[i]:
            if (met := self._third_met(sim, i, y0, end, held, h)) is not None:  # its end went through a third:
                s, meet = met  # struck where it meets it, the rest of the span from there
                if self._strike_side(sim, i, meet, held, t + s * h):
                    return self._persistent_span(sim, i, meet, self._bare(i, held), t + s * h, h - s * h)
            return two_grounds.end_of_step(self, sim, i, end, t, h, LIFT_OFF_SPEED)
        end = end.copy()
        j = int(self.ground_of[i])
        landing = self._reaching(sim, i, y0, end, held, h)  # another feature reaching the ground in the step
        sx, sy = self.slide_direction[i]
        if self.sliding[i] and (sx != 0.0 or sy != 0.0):  # sliding with friction: it may stop in this step

            def along(s: float) -> float:
                row = self.step_map(sim, i, y0, s * h, held) if s > 0.0 else y0
                count = self._tracked_points(sim, row, i)
                _, _, vx, vy = self._normal_motion(sim, row, i, j, count, held, int(self.tracked[i]))
                return vx * sx + vy * sy

            reach = 1.0 if landing is None else landing  # a stop counts before another feature lands
            if reach > 0.0 and along(reach) <= 0.0:  # the slip reversed before: the stop, located
                s = self._locate(lambda f: along(f * reach), along(0.0), -1.0)
                s = reach if s is None else s * reach
                last = self.events[-1] if self.events else None
                if s <= 1e-9 and last is not None and (last.body, last.kind, last.time) == (self.names[i], "stick", t):
                    # it stuck here already, and the slide found from there reverses at once (within 1e-9 of the
                    # span) under the force held over it (a zero-order hold): the span ends sticking, projected
                    # so below
                    self.sliding[i] = False
                else:
                    stop = self.step_map(sim, i, y0, s * h, held)
                    if (instead := self._unless_thrown(sim, i, y0, stop, held, t, h, s)) is not None:
                        return instead
                    # a feature that came down before the stop and is not down at the step's end (a can's face,
                    # the can going through upright and on): the landing, first
                    if (before := self._reaching(sim, i, y0, stop, held, s * h)) is not None:
                        return self._land(sim, i, y0, held, t, h, before * s)
                    self._project(sim, stop, i, True)
                    self.sliding[i] = False
                    self.events.append(ContactEvent(t + s * h, self.names[i], j, "stick"))
                    if s < 1.0:  # the rest of the step sticking, with the holding force found at the stop
                        return self._persistent_span(sim, i, stop, self._bare(i, held), t + s * h, h - s * h)
                    return stop
        upto = 1.0  # the fraction of the span by which another half-space or static shape is reached
        if self._side_hits.get(i, 0) != PRESSED and self._other_gap(sim, end, i)[0] >= 0.0:
            upto = None
            if i in self.may_pass or self._driven_into_side(sim, y0, i, held):  # apart at its end, but its path
                # may have gone through a static shape (a pebble slid or thrown through a wall)
                upto = self.pairs.advance_alone(sim, i, y0, end, held, h, lambda y: self._other_gap(sim, y, i)[0],
                                                self._band[i])
                if upto is None and (along := self._along_into_other(sim, i, y0, end, held, h)) is not None:
                    s, hit = along  # sliding along one static shape into another: struck there
                    if self._strike_side(sim, i, hit, held, t + s * h):
                        return self._persistent_span(sim, i, hit, self._bare(i, held), t + s * h, h - s * h)
        if upto is not None and self._side_hits.get(i, 0) != PRESSED:
            # another half-space or static shape reached: an impact against it alone
            g0, jj = self._other_gap(sim, y0, i)
            again = self._side_impact_at(i, jj, t)  # just struck at y0: its gap opens first, the hit is later
            gap = lambda s: self._other_gap(sim, self.step_map(sim, i, y0, s * upto * h, held), i)[0]  # noqa: E731
            s = 0.0 if g0 <= 0.0 and not again else self._locate(gap, min(g0, 0.0) if again else g0, -1.0)
            if again and not s:  # it does not open: it stays pressed on them for the rest of the step
                self._press_aside(i)
                return self._persistent_end(sim, i, y0, end, held, t, h)
            s = (0.0 if s is None else s) * upto
            hit = self.step_map(sim, i, y0, s * h, held) if s > 0.0 else y0.copy()
            if (instead := self._unless_thrown(sim, i, y0, hit, held, t, h, s)) is not None:
                return instead
            if not self._strike_side(sim, i, hit, held, t + s * h):  # pressed on them (from wall to wall)
                return self._persistent_end(sim, i, y0, end, held, t, h)
            return self._persistent_span(sim, i, hit, self._bare(i, held), t + s * h, h - s * h) if s < 1.0 else hit
        if landing is not None:  # another feature reached the ground: an impact
            return self._land(sim, i, y0, held, t, h, landing)
        count = feature_gaps(end, sim._prm[i], self.shapes[i], self.grounds[j], self._features)
        tracked, pressed = int(self.tracked[i]), int(self.pressed[i])
        let_go = sum(1 << k for k in range(count)
                     if tracked & (1 << k) and not pressed & (1 << k) and self._features[k] > self._band[i])
        if let_go:  # features the holding force did not push on, and that moved off the ground
            self.tracked[i] = tracked & ~let_go
            if not self.tracked[i]:
                self.modes[i] = FLIGHT
                self.sliding[i] = False
                self.events.append(ContactEvent(t + h, self.names[i], j, "lift-off"))
                return end
        self._project(sim, end, i, not self.sliding[i])
        if self.other_ground[i] >= 0:  # held on ground_of alone, projected onto the second half-space too
            two_grounds.project_second(self, sim, i, end, TOUCHING_GAP)
        if i in self._static_skipped or self._side_hits.get(i, 0) == PRESSED:  # pressed on walls out of its view
            two_grounds.take_out_of_pressed(self, sim, i, end, t + h, not self.sliding[i], LIFT_OFF_SPEED)
        if self.statics is not None and self.statics.is_tangent(int(self.ground_of[i])):  # the others were out of view
            two_grounds.take_out_of_static(self, sim, i, end, not self.sliding[i])
        return end

    def _along_into_other(self, sim, i: int, y0: np.ndarray, end: np.ndarray, held: np.ndarray,
                          h: float) -> tuple[float, np.ndarray] | None:
        """Body i, held on a half-space, from y0 over h under ``held`` (its end: ``end``), touching a static shape at
        y0 (within its feature band) and apart from the others: where its path meets one of those others, (the
        fraction s of the span, the state there, to round-off), or None. The static shape it touches is left out of
        the rest of its step (pressed on it, as :meth:`_side_impact` leaves one; taken out of it at the end), so
        that the one it meets is the one struck. The advancement on the least gap of all stays a skin below the
        touching one's and runs out of samples short of the other (a pebble sliding at 16 m/s along one wall of a
        bin's corner went through the other)."""
        if self.statics is None or self.ground_of[i] >= len(self.half_spaces):
            return None
        touch_dist, touched = self.statics.nearest(y0, i, self.shapes[i], -1, self._static_skipped.get(i, -1))
        if touched < 0 or touch_dist > self._band[i]:
            return None
        among = self.statics.distances(y0, i, self.shapes[i]) > self._band[i]
        if not among.any():
            return None
        met = self._met_on_path(sim, i, y0, end, held, h,
                                lambda y: self.statics.nearest_among(y, i, self.shapes[i], among))
        if met is not None:
            self._static_skipped[i] = touched
        return met

    def _third_met(self, sim, i: int, y0: np.ndarray, end: np.ndarray, held: np.ndarray,
                   h: float) -> tuple[float, np.ndarray] | None:
        """Body i, held on two half-spaces, from y0 over h under ``held`` (its end: ``end``): where its path first
        meets a third half-space or static shape, (the fraction s of the span, the state there), if the end is past
        it: apart from it again (through a thin wall) or nearest another of its planes (beyond its middle, where the
        end's take-in would push it out through the far face); else None (the end's take-in, first order, is on the
        plane it met). The meeting is located on the step map (conservative advancement, then the root). A ball
        sliding along the crease of the floor and a bin's wall into the next wall went 9 cm into it in one step and
        was taken out through its back face."""
        if self.statics is None or self.pairs is None or self._side_hits.get(i, 0) == PRESSED:
            return None
        gap_end, row_end = self._other_gap(sim, end, i, pressed=True)
        if gap_end >= 0.0 and i not in self.may_pass:
            return None
        met = self._met_on_path(sim, i, y0, end, held, h, lambda y: self._other_gap(sim, y, i, pressed=True)[0])
        if met is None or (gap_end < 0.0 and self._other_gap(sim, met[1], i, pressed=True)[1] == row_end):
            return None
        return met

    def _met_on_path(self, sim, i: int, y0: np.ndarray, end: np.ndarray, held: np.ndarray, h: float,
                     gap) -> tuple[float, np.ndarray] | None:
        """Where gap(state) (m: a signed distance to fixed geometry) first goes below 0 on body i's held path from y0
        over h under ``held`` (its end: ``end``): (the fraction s of the span, the state there), found by conservative
        advancement (BodyPairs.advance_alone) and, apart at y0, the root located to round-off; None if not met."""
        s = self.pairs.advance_alone(sim, i, y0, end, held, h, gap, self._band[i])
        if s is None:
            return None
        g0 = gap(y0)
        if g0 > 0.0 and (u := self._locate(lambda u: gap(self.step_map(sim, i, y0, u * s * h, held)), g0,
                                           -1.0)) is not None:
            s *= u
        return s, self.step_map(sim, i, y0, s * h, held)

    def _land(self, sim, i: int, y0: np.ndarray, held: np.ndarray, t: float, h: float, s: float) -> np.ndarray:
        """The landing (:meth:`_landing`) of a feature of body i at the fraction s of its step from y0 over h
        under ``held``, then the rest of the step. A held step to the landing that threw the body (:meth:`_thrown`:
        a can's rim force, held over it) is taken as in :meth:`_held_span`: a can on its rim lands its end face at
        y0, any other body stays at rest there for the step."""
        hit = self.step_map(sim, i, y0, s * h, held) if s > 0.0 else y0.copy()
        if (instead := self._unless_thrown(sim, i, y0, hit, held, t, h, s)) is not None:
            return instead
        return self._landing(sim, i, hit, self._bare(i, held), t + s * h, h - s * h,
                             self.landing_face(sim, i, y0, hit))

    def _unless_thrown(self, sim, i: int, y0: np.ndarray, at: np.ndarray, held: np.ndarray, t: float, h: float,
                       s: float) -> np.ndarray | None:
        """None, or, where the held step of body i from y0 to ``at`` (its state at the fraction s of its step over h
        under ``held``, where an event was located: a stop, a side's hit, a landing) threw it (:meth:`_thrown`), its
        state instead (:meth:`_instead_of_throw`): an event is not taken from a thrown step."""
        bare = self._bare(i, held)
        if s > 0.0 and self._thrown(sim, i, y0, at, bare):
            return self._instead_of_throw(sim, i, y0, bare, t, h)[0]
        return None

    def landing_face(self, sim, i: int, y0: np.ndarray, hit: np.ndarray) -> int:
        """The features of a can's end face come down flat from y0 to ``hit`` (it lands as a whole), else 0."""
        j, mask = int(self.ground_of[i]), int(self.tracked[i])
        band = self._band[i]
        if opposite_rim_gap(y0, hit, sim._prm[i], self.shapes[i], self.grounds[j], mask, band) <= band:
            return 4 << held_rim(self.shapes[i], mask)
        return 0

    def _reaching(self, sim, i: int, y0: np.ndarray, end: np.ndarray, held: np.ndarray, h: float) -> float | None:
        """The fraction of the step (from y0 over h under ``held``, to ``end``) at which a feature of body i not
        tracked reaches the ground (a can's face landing flat, a box's edge coming down), located on the step
        map; None if none does."""
        if self._untracked_gap(sim, end, i, y0) >= 0.0:
            return None
        g0 = self._untracked_gap(sim, y0, i, y0)
        s = 0.0 if g0 <= 0.0 else self._locate(
            lambda s: self._untracked_gap(sim, self.step_map(sim, i, y0, s * h, held), i, y0), g0, -1.0)
        return 0.0 if s is None else s

    def _other_gap(self, sim, y: np.ndarray, i: int, pressed: bool = False) -> tuple[float, int]:
        """(lowest gap, ground) of body i against the half-spaces other than the one it rests on, and the static
        shapes (not the one it was found pressed on in this step, unless ``pressed``)."""
        lowest, which = math.inf, -1
        for jj in range(len(self.half_spaces)):
            if jj != self.ground_of[i] and jj != self.other_ground[i]:
                count = body_points(y, sim._prm[i], self.shapes[i], self.grounds[jj], self._points, self._gaps)
                if count and self._gaps[:count].min() < lowest:
                    lowest, which = float(self._gaps[:count].min()), jj
        if self.statics is not None and not self.statics.is_tangent(int(self.ground_of[i])):
            held = int(self.statics.row_owner[self.ground_of[i]])  # the static shape it rests on, or the one beside
            if held < 0 and self.other_ground[i] >= 0:  # its ground that it is held on too (two_grounds.py)
                held = int(self.statics.row_owner[self.other_ground[i]])
            dist, s = self.statics.nearest(y, i, self.shapes[i], held, -1 if pressed else self._static_skipped.get(i, -1))
            if dist < lowest:
                lowest, which = dist, self.statics.plane_for(y, sim._prm[i], i, self.shapes[i], s)
        return lowest, which

    def _other_static(self, sim, y: np.ndarray, i: int) -> tuple[float, np.ndarray | None]:
        """(signed distance in m, plane row through their contact: StaticGeometry.plane_through) of body i at y,
        held on a static shape's tangent row, to the nearest other static shape; (inf, None) if there is none."""
        held = int(self.statics.row_owner[self.ground_of[i]])
        dist, s = self.statics.nearest(y, i, self.shapes[i], held)
        return (dist, self.statics.plane_through(s)) if s >= 0 else (math.inf, None)

    def _side_impact_at(self, i: int, jj: int, t: float) -> bool:
        """Whether body i was struck against half-space or static plane ``jj`` at time t: an impact among its
        events at t (the side impact just taken at this span's start, perhaps followed there by a lift-off and
        a rest, as in a corner of the ground and a wall)."""
        name = self.names[i]
        for event in reversed(self.events):
            if event.body == name:
                if event.time != t:
                    return False
                if event.kind == "impact" and event.ground == jj:
                    return True
        return False

    # ----------------------------------------------------------------- static shapes (static_geometry.py)

    def _refresh_static(self, sim, Y: np.ndarray, on_static: np.ndarray) -> np.ndarray:
        """Before the step, the bodies resting on a static shape's plane: one on a face row whose tracked contact
        points left the face goes on on its tangent row; a tangent row is refreshed from the narrow phase against
        the static shape it belongs to (each such body-step counted in ``static_tangent``), and a body to which
        another static shape is nearer than that one lifts off (StaticGeometry.refresh). Returns those still held,
        for the Python hold."""
        statics = self.statics
        held = np.ones(len(on_static), dtype=bool)
        for k, i in enumerate(on_static):
            j = int(self.ground_of[i])
            if not statics.is_tangent(j):
                count = self._tracked_points(sim, Y[i], i)
                if statics.within_face(j, self._points[:count]):
                    continue
            self.counts["static_tangent"] += 1
            row = statics.refresh(Y[i], sim._prm[i], i, self.shapes[i], j, self._band[i])
            if row >= 0:
                self.ground_of[i] = row
            else:  # another static shape is nearer (a box sliding along a wall's top into the next wall): its held
                # features are not that one's, so it flies this step, its contacts with every shape located afresh
                self.modes[i] = FLIGHT
                self.sliding[i] = False
                self.events.append(ContactEvent(sim.time, self.names[i], j, "lift-off"))
                held[k] = False
        return on_static[held]

    def _static_busy(self, Y1: np.ndarray, resting: np.ndarray, moving: np.ndarray) -> np.ndarray:
        """After the step: ``_lowest`` (the half-spaces' lowest gaps of the bodies in flight, else inf) lowered, in
        place, to the signed distances to the static shapes of the bodies ``moving`` (a mask over :attr:`bodies`: not stopped, not stepped by the islands, whose own rows
        hold the static shapes); returns the resting bodies the solver looks at in Python: those on a static
        shape's plane, and those on a half-space that reached a static shape or may have passed through one
        (:attr:`may_pass`; an impact against it, located on the step map)."""
        g = len(self.half_spaces)
        looked = ((self.modes[self.bodies] == FLIGHT) | (self.ground_of[self.bodies] < g)) & moving  # not on a static
        static_gaps = np.full(int(looked.sum()), math.inf)
        self.statics.lower_gaps(Y1, self.shapes, self.bodies[looked], static_gaps)
        self._lowest[looked] = np.minimum(self._lowest[looked], static_gaps)
        reached = np.zeros(len(self.modes), dtype=bool)
        reached[self.bodies[looked]] = static_gaps < 0.0
        reached[list(self.may_pass)] = True  # or may have passed through one (body_pairs._hits)
        return np.concatenate((resting[self.ground_of[resting] >= g],
                               resting[(self.ground_of[resting] < g) & reached[resting]]))

    def _press_aside(self, i: int) -> None:
        """Body i stays pressed on the walls it meets for the rest of the step (not struck there again)."""
        self._side_hits[i] = PRESSED
        self.counts["side_pressed"] += 1

    def _may_strike_side(self, i: int) -> bool:
        """Whether body i, resting on one ground, can be struck against another in this step (not held on two,
        not pressed on them: :meth:`_strike_side`)."""
        return self.other_ground[i] < 0 and self._side_hits.get(i, 0) != PRESSED

    def _strike_side(self, sim, i: int, y: np.ndarray, w: np.ndarray, t: float) -> bool:
        """Body i, resting on its ground, meets another half-space or static shape at y (at a step's end,
        :meth:`_persistent_end`, or inside a body–body group's step, body_pairs.py): the impact against it and the
        contact projected again (in place); past MAX_SIDE_IMPACTS in the step (from wall to wall, each event a level
        deeper) it is pressed on them instead (False)."""
        self._side_hits[i] = self._side_hits.get(i, 0) + 1
        if self._side_hits[i] > MAX_SIDE_IMPACTS:
            self._press_aside(i)
            return False
        self._side_impact(sim, i, y, w, t)
        self._project(sim, y, i, False)
        return True

    def _side_impact(self, sim, i: int, y: np.ndarray, w: np.ndarray, t: float) -> None:
        """Body i, resting on its ground, hits another half-space at y: the impact against that one (in place).

        The impact acts against that half-space alone, then the resting contact is projected again;
        if the body stays on the second half-space (no rebound), it is held on both from there
        (two_grounds.py).
        """
        gap, jj = self._other_gap(sim, y, i)
        n = self.grounds[jj, NORMAL:NORMAL + 3]
        y[L.P:L.P + 3] -= gap * n
        count = body_points(y, sim._prm[i], self.shapes[i], self.grounds[jj], self._points, self._gaps)
        before, _ = normal_speeds(y, sim._prm[i], count, self._points, n[0], n[1], n[2], self._work)
        after_row = y.copy()
        e = self.restitution_of(i, jj)
        impulse, e0, e1, alpha = impact(y, after_row, sim._prm[i], count, self._points, n[0], n[1], n[2],
                                        e, self.friction_of(i, jj), self._work)
        jump = self._jump(sim, i, y, after_row, count, e, alpha)
        self.counts["second_half_space"] += 1
        y[L.V:L.W + 3] = after_row[L.V:L.W + 3]
        after, _ = normal_speeds(y, sim._prm[i], count, self._points, n[0], n[1], n[2], self._work)
        self.events.append(ContactEvent(t, self.names[i], jj, "impact", before, after, impulse, e0, e1, *jump))
        g = len(self.half_spaces)
        if after <= LIFT_OFF_SPEED and self.other_ground[i] < 0 and (
                jj < g or (self.ground_of[i] < g and not self.statics.is_tangent(jj))):
            # it stays on the second one (a half-space, or a static box's face beside its ground): held on both
            self.other_ground[i] = two_grounds.touching_other(self, sim, y, i, LIFT_OFF_SPEED,
                                                              max(TOUCHING_GAP, float(self._band[i])),
                                                              None if jj < g else (jj,))
        if after <= LIFT_OFF_SPEED and jj >= g and self.other_ground[i] != jj:  # pressed on a static shape, not held
            self.counts["static_pressed"] += 1
            self._static_skipped[i] = int(self.statics.row_owner[jj])

    def _landing(self, sim, i: int, y: np.ndarray, w: np.ndarray, t: float, h: float, face: int = 0) -> np.ndarray:
        """A feature of body i, in persistent contact, reaches the ground at y: the impact of every touching
        feature together (and of the features ``face``, a can's end face come down), then the rest h of the
        step (persistent, or in flight if it bounces off)."""
        j = int(self.ground_of[i])
        n = self.grounds[j, NORMAL:NORMAL + 3]
        mask = int(self.tracked[i]) | self._touching(sim, y, i, j) | face
        count = self._tracked_points(sim, y, i, mask)
        before, _, _, _ = self._normal_motion(sim, y, i, j, count, w, mask)
        staying = mask  # nothing strikes (a feature that rose off the ground and came back within the step, located
        # at its start): no impact, held on every touching feature as below ZENO_APEX
        if before < -LIFT_OFF_SPEED:
            e, mu = self.restitution_of(i, j), self.friction_of(i, j)
            after_row = y.copy()
            impulse, e0, e1, alpha = impact(y, after_row, sim._prm[i], count, self._points, n[0], n[1], n[2], e, mu,
                                            self._work)
            jump = self._jump(sim, i, y, after_row, count, e, alpha)
            y = after_row
            _, highest = normal_speeds(y, sim._prm[i], count, self._points, n[0], n[1], n[2], self._work)
            _, accel, _, _ = self._normal_motion(sim, y, i, j, count, w, mask)
            self.events.append(ContactEvent(t, self.names[i], j, "impact", before, highest, impulse, e0, e1, *jump))
            toward = -accel
            staying = self._not_rising(sim, y, i, j, mask)  # the features it turns about (the others rise)
            if not staying and toward > 0.0 and highest * highest <= 2.0 * toward * ZENO_APEX:
                staying = mask
        if staying:
            self.tracked[i] = staying
            self._settle(sim, y, i, False)
            rising = mask & ~int(self.tracked[i])
            if rising and self._comes_down_in(sim, i, y, w, rising) <= h + sim.dt:  # rocking below the step
                self.tracked[i] = mask
                self._settle(sim, y, i, False)
            return self._persistent_span(sim, i, y, w, t, h) if h > 0.0 else y
        self.modes[i] = FLIGHT
        self.sliding[i] = False
        return self._with_events(sim, i, y, w, t, h) if h > 0.0 else y

    def _comes_down_in(self, sim, i: int, y: np.ndarray, w: np.ndarray, rising: int) -> float:
        """The time (s) until the ``rising`` features of body i, at y turning on its tracked ones under the wrench
        row w (without contact), come back to the ground: 2u/a, u their normal speed and a their normal acceleration
        toward the ground under the holding force found at y (inf if they do not come back)."""
        j = int(self.ground_of[i])
        count = self._tracked_points(sim, y, i)
        _, mode, _, _ = self._holding_force(sim, y, i, count, w, self.friction_of(i, j))
        if mode == LIFT_OFF:
            return math.inf
        held = w.copy()
        add_contact_wrench(held, y, sim._prm[i], count, self._points, self._anchors, self._work)
        count = self._tracked_points(sim, y, i, rising)
        speed, accel, _, _ = self._normal_motion(sim, y, i, j, count, held, rising)
        return 2.0 * speed / -accel if speed > 0.0 and accel < 0.0 else math.inf


def _energy(y: np.ndarray, p: np.ndarray) -> float:
    """K + U (J) of a body at state row y with parameter row p (U from its own gravity)."""
    return kinetic_energy_row(y, p) + potential_energy_row(y, p)


def _torques_about_com(Y: np.ndarray, added: np.ndarray) -> np.ndarray:
    """(k, 3) torques about the centre of mass, world axes, N·m, of the wrench rows ``added`` (k, WRENCH_WIDTH)
    on bodies at state rows ``Y`` (k, ≥ STATE_WIDTH), at those states (layout: the wrench row's columns)."""
    R_WP = quat_to_matrix(Y[:, L.Q:L.Q + 4])
    p_W = Y[:, L.P:L.P + 3]
    torque = added[:, L.T_WORLD:L.T_WORLD + 3] - np.cross(p_W, added[:, L.F_WORLD:L.F_WORLD + 3])
    torque += added[:, L.T_COM_W:L.T_COM_W + 3] + np.einsum("kij,kj->ki", R_WP, added[:, L.T_COM_P:L.T_COM_P + 3])
    moment = added[:, L.SITE_MOMENT:L.SITE_MOMENT + 9].reshape(-1, 3, 3)  # M[j, l] = f_j r_l
    for col in range(3):  # Σ_l (R r_l e_l) × f: the lever R[:, l] r_l crossed with f, r_l folded into M[:, l]
        torque += np.cross(R_WP[:, :, col], moment[:, :, col])
    return torque
