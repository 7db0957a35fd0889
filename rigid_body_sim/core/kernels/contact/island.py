"""Compiled islands of bodies resting on bodies: union-find, contact rows, the velocity step, the projection, sleeping.

Bodies in persistent contact with each other (and the ground and static shapes they touch) are
stepped together by :func:`island_pass`, one compiled call per simulator step (driver:
core/contact/island.py). The step is **first order** (Moreau–Jean / Stewart–Trinkle):

    v⁺ = v + h M⁻¹ (f_ext + gyroscopic) + M⁻¹ Jᵀ λ,   p⁺ = p + h v⁺,   q⁺ = q ⊗ exp(h ω_P⁺)

with, at each contact point (normal n, tangents t1, t2, gap g ≥ 0 at the step's start),
u_n⁺ + g/h ≥ 0 ⊥ λ_n ≥ 0 (Stewart–Trinkle's gap term: a gap closes exactly within the step, never
more; a gap within TOUCH_GAP × the pair's size is touching, g = 0) and Coulomb's cone |λ_t| ≤ μ λ_n,
e = 0. The points of two boxes or cylinders face on face (their normal within 0.1 rad of a box face's
or a cylinder end's) are the clipped patch of the two faces (pairs.face_patch), each at its own gap, as
far as the pair's reach over the step or PATCH_REACH × its size: the gap term lets a row act only where
the step would close it, and a box or a can turned or tilted on another is held by its whole face, not
rocked about the narrow phase's deepest corner or rim point.

The velocity problem is solved per component of the step's contacts (bodies joined by contacts; an
island's bodies within reach but not touching are apart there). The case where nothing slides is
solved exactly first: when the last step's λ (the warm start) was solved from rest and already meets this step's
sticking conditions below to their tolerances (a component at rest), it is kept without a factorisation (_held);
else (_sticking) the points that stay as equalities (J M⁻¹ Jᵀ λ = −(J v* + g/h) on
their rows), the others at λ = 0, by a Cholesky factorisation of J M⁻¹ Jᵀ + εI within its profile
(the contacts sorted along the component's longest extent: a column is banded) refined by iterated
Tikhonov steps (the minimum-norm λ of the consistent rank-deficient system: four coplanar corners of
a face share its load evenly; v⁺ does not depend on which λ); points that pull are let go and points
let go that would close taken back, at most STICK_PIVOTS times (the attempt ends when its first solve
changes more than STICK_CHANGES points: not at rest). It is kept when the points on are
met (to EQUALITY_TOL of the right-hand side), every λ_n ≥ 0 and every λ_t is in its cone (to
round-off); a component whose attempt failed is tried again only after STICK_RETRY − 1 steps
(landing, nearly none holds), and one due with a body that slipped at the end of the last step is looked at
again at the next step instead (at most STICK_SKIPS steps in a row). Else
projected Gauss–Seidel on the component's rows (over more than PILE_CONTACTS contacts, a pile, each
component on its own, from the highest against gravity down, then back up, in turn: a weight passes
down a pile and a stop up it within a sweep). Then the
positions (a body the velocity step moved off the free path the broad phase screened it on is screened again on
its new one, _late_pairs: a pair so found is projected, a body outside the islands so met joins them; a body the
projection below moves off it likewise, after it, and the projection is taken once more if that finds a pair); then
every point found penetrating at the new poses (narrow phase again) deeper than the projection's
tolerance (PROJECT_TOL × its body's size, or the solver's penetration tolerance where that is more) is closed by a
mass-metric least correction (Gauss–Seidel on the linearised gaps, λ ≥ 0; over a pile, bottom-up with each
upright pair's lower body held, _pile_rows), the narrow phase iterated PROJECT_ROUNDS times; only the
components with a deep point move, the others are held as fixed.

Islands: union-find over the swept broad phase's candidate pairs of moving bodies (a sleeping
body's with an awake one only when that is within the step's reach, with a sleeping one only when
they fell asleep together); a component is an island when one of its pairs touches at the step's start (signed distance ≤ TOUCH × the
pair's size) and rests there or strikes without restitution or with a body held on its ground, or when it holds
a sleeping body. Sleeping (when enabled): a component of the step's
contacts whose bodies all moved slower than SLEEP_SPEED at the start and end of the step (at rest), or, with
the sleep speed raised, all stayed within it × SLEEP_STEPS steps of where they were SLEEP_STEPS steps ago, is
locked (velocities set to zero, its rows copied forward, no narrow phase between its bodies) until a
wrench, a changed state or another body within reach wakes it (the driver and this pass).

Scratch is owned by the caller and preallocated; nothing here allocates per pair or per body
(pair_contacts, _gather and _sort_by allocate small fixed workspaces once per call).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..forces import body_wrench
from ..jit import INLINE, JIT
from ..layout import ACTIVE, BOUND, GRAVITY, INV_INERTIA, INV_MASS, INERTIA, MASS, P, Q, Q_PB, STATE_WIDTH, V, W
from ..rotation import exp_map, matrix, normalise, qmul, rotate, rotate_back
from .layout import (DIMS, FRICTION, HAS_MATERIAL, KIND, NORMAL, OFFSET, RESTITUTION, SHAPE_BOX, SHAPE_CAPSULE,
                     SHAPE_CYLINDER, SHAPE_SPHERE)
from .convex import POSE_WIDTH
from .impacts import kinetic_energy_row, potential_energy_row, row_direction
from .pair_impacts import normal_speed
from .pairs import MAX_PAIR_POINTS, RIM_ACROSS, ball_contact, boxes_apart_turned, face_patch, pair_contacts, set_pose
from .shapes import MAX_FEATURES, feature_gaps, feature_points
from .swept import boxes_meet, grid_overlaps, growth, paths_may_meet

__all__ = ["island_pass", "all_asleep", "rest_alone", "TOUCH", "SLEEP_SPEED", "SLEEP_STEPS", "DENSE_MAX", "PROJECT_TOL", "C_FLOATS", "C_INTS", "OUT_WIDTH"]

#: A pair whose signed distance is at most this × its size (m per m) touches: its component is an island if it rests.
TOUCH = 1e-6
#: A touching pair rests unless its least normal speed is beyond IMPACT_MARGIN × the change the step's forces make to
#: a point's and beyond APPROACH_SPEED (m/s), either way: striking, it is an impact, the impact law's
#: (core/contact/body_pairs.py, restitution and all), unless its restitution is 0 or one of its bodies is held on its
#: ground (_link: the island's velocity step is then the inelastic impact); parting, its bodies fly on.
#: APPROACH_SPEED is also the impact law's: a normal velocity below −this approaches.
IMPACT_MARGIN, APPROACH_SPEED = 2.0, 1e-12
#: Bodies slower than this (m/s, and spin × bounding radius) at a step's start and after its solve are at rest.
SLEEP_SPEED = 1e-9
#: Steps a component's bodies must all stay within a sleep speed raised above SLEEP_SPEED × SLEEP_STEPS steps of
#: where they were when the run began (their mean speed over it below the sleep speed; MuJoCo's mjMINAWAKE)
#: before it sleeps: a body slow only for an instant (a rocking column at its turning point) stays awake, and
#: one jittering in place (a Gauss–Seidel residue over a pile) is at rest.
SLEEP_STEPS = 10
#: Two boxes or cylinders whose pair normal is within acos(PATCH_FLAT) of a box face's or a cylinder end's normal
#: touch by a patch: the other's face, rim or side clipped against that one (pairs.face_patch), every point within
#: the pair's reach or PATCH_REACH × its size.
PATCH_FLAT, PATCH_REACH = math.cos(0.1), 1e-2
#: Most rows (3 per contact point) of an island solved densely for the sticking case.
DENSE_MAX = 360
#: Points deeper than this × the pair's size (m per m) after the step are projected out, or than the solver's
#: penetration tolerance (m) where that is more (_depth_tol).
PROJECT_TOL = 1e-12
#: A component's rise of K + U over a step within this × the sum of its bodies' |K + U| is round-off (_no_gain).
RISE_ROUNDOFF = 1e-15
#: A point whose gap is at most this × the pair's size (half the projection's tolerance) touches: the velocity step
#: does not close it (no gap term), so that the narrow phase's round-off in a resting gap (~1e-15 m) is not made a
#: speed (~1e-12 m/s at dt = 1 ms) that the next step must stop.
TOUCH_GAP = 0.5 * PROJECT_TOL
#: Narrow-phase rounds of the position projection, the first TURN_ROUNDS in the mass metric (turning and
#: translating), the others translating only; Gauss–Seidel sweeps per round.
PROJECT_ROUNDS, TURN_ROUNDS, PROJECT_SWEEPS = 8, 1, 100
#: Most of the projection's first-round points deeper than TOUCH × the size (and its tolerance), between two bodies
#: one of them a cylinder (_with_a_can), that are kept as rows of the stop of approach after it: the velocity step
#: drove the bodies in there at a point it had no row for.
DRIVEN_KEPT = 256
#: Most projected Gauss–Seidel sweeps of the velocity problem, or PGS_WORK / its contacts when that is more (the
#: last few columns of a pile still moving get more); it stops earlier below PGS_TOL (m/s). What a step short of
#: convergence adds to K + U is taken out by _no_gain.
PGS_SWEEPS, PGS_WORK, PGS_TOL = 200, 20000, 1e-13
#: Gauss–Seidel over more contacts than this (a pile; the dense solve's DENSE_MAX / 3) sweeps them by height.
PILE_CONTACTS = DENSE_MAX // 3
#: A pile's velocity step: at most PILE_PGS_SWEEPS sweeps (or PGS_WORK / its contacts), each extrapolated
#: (nonsmooth nonlinear conjugate gradient). A pile's projection: at most PILE_SWEEPS sweeps a round, from the lowest point up, and a pair whose
#: normal is within acos(PILE_UPRIGHT) of gravity moves only its upper body (the lower held: shock propagation).
PILE_PGS_SWEEPS, PILE_SWEEPS, PILE_UPRIGHT = 20, 20, 0.5
#: A pile's projection round that begins with more than half the depth the round before it began with, or with a
#: depth that the rounds left, each taking off what the last one did in proportion, would not bring within its
#: tolerance (Gauss–Seidel slow over a chain of bodies wedged wall to wall): it and the later rounds sweep up to
#: PILE_SLOW_SWEEPS times.
PILE_SLOW_SWEEPS = 400
#: The first velocity step of a pile's component just woken, or set back at rest by the energy step (_no_gain) at
#: the step before: at most this many sweeps. Solved from the rest it was locked in (its λ the warm start),
#: PILE_PGS_SWEEPS short of convergence can let a column that rests slide (a tenth of a millimetre in the 1000-cube
#: pile); the converged solve holds it. Set back, a component would otherwise take the same short step from the
#: same rest and warm start at every step, and be set back again: a column balanced where it should tip was held
#: there until it slept (FROZEN_STEPS) and, woken, tipped.
WOKEN_SWEEPS = PGS_SWEEPS
#: Ranges of the islands' sort (_sort_by) at most this long are insertion sorted.
SORT_SMALL = 16
#: A component's warm start is kept as its sticking solve (_held) when its points' speeds after are within this ×
#: the projection's tolerance (_depth_tol) / h: over a step a body at rest moves a hundredth of it.
HELD_TOL = 1e-2
#: Iterated Tikhonov steps of the sticking solve (fewer once the residual is below TIKHONOV_TOL × the right-hand
#: side's), and its regularisation (× the largest diagonal); most solves of its pivoting (points let go or taken
#: back, then one that changes none: a heavy box off-centre on a can lets go of the can's far rim points over three
#: rounds, so four solves).
TIKHONOV_STEPS, TIKHONOV_TOL, TIKHONOV_EPS, STICK_PIVOTS = 6, 1e-15, 1e-9, 6
#: A sticking attempt ends when its first solve (from the points that held last step or touch) has more than
#: STICK_CHANGES points to let go or take back: the component lands or slides, and its pivots would not settle (a
#: column rocking on an edge changes the corners of one face at most).
STICK_CHANGES = 4
#: The sticking solve is kept only when the points on are met as equalities within EQUALITY_TOL × its largest
#: right-hand side: a pile's redundant points (a face's four corners) agree only to the narrow phase's round-off,
#: which leaves a residue of about 1.5e-9 of it that no further refinement removes (a 52-point component at rest).
EQUALITY_TOL = 1e-8
#: A component whose sticking solve failed is tried again only after STICK_RETRY − 1 steps on Gauss–Seidel (while
#: a pile lands, or a point slides, nearly none holds); one solved exactly is tried again at the next step.
STICK_RETRY = 4
#: A component due for the sticking solve with a body that slipped at the end of the last step (a point of its
#: Gauss–Seidel step slipping faster than SLIP × its body's size / h) is looked at again at the next step instead,
#: at most STICK_SKIPS steps in a row: one still slipping nearly never holds (a pile landing), one that came to
#: rest in its last step is tried at once.
STICK_SKIPS, SLIP = 12, 1e-6
#: A component set back where it began by the energy step (_no_gain) this many steps in a row sleeps (its bodies have
#: not moved since; at least two of its sticking attempts failed meanwhile, each STICK_RETRY + STICK_SKIPS steps
#: apart at most): a rest imposed once is not counted as one (a body that should move would be locked), but a
#: component whose every step is set back (a resting pile whose exact solve leaves a friction cone and whose
#: Gauss–Seidel step and projection add energy) would otherwise be stepped, unmoving, for ever.
FROZEN_STEPS = 2 * (STICK_RETRY + STICK_SKIPS)
#: A body's wait (steps before its component is tried for the sticking solve again) after an exact step: solved
#: (WAIT_SOLVED: its λ also stopped what the bodies brought in, so it is solved once more, from that rest) or held or
#: solved from a step solved exactly (WAIT_HELD: its λ is the resting one, kept by _held while it holds). Holding a
#: λ that stopped a motion would stop it again, the other way: a component at rest would alternate.
WAIT_SOLVED, WAIT_HELD = -1, -2
#: Columns of a contact's float row: point (3), normal a → b (3), gap, μ, and after the velocity step the
#: impulse on b (3, world, N·s; a gets its opposite).
C_X, C_N, C_GAP, C_MU, C_IMPULSE, C_FLOATS = 0, 3, 6, 7, 8, 11
#: Columns of a contact's int row: the two bodies (−1: fixed), the static body (−1: none), the half-space (−1: none),
#: then scratch (the warm start's list of a body's last-step contacts).
I_A, I_B, I_STATIC, I_GROUND, I_NEXT, C_INTS = 0, 1, 2, 3, 4, 5
#: A contact takes the λ of the last step's contact of its pair nearest to its point within this × the body's size.
WARM_REACH = 0.1
#: Columns of the per-call outputs: island body-steps, contact points, sticking solves kept, PGS islands,
#: projected points, largest depth projected (m), bodies woken, bodies put to sleep, points whose approach was
#: stopped after the projection, sticking solves kept from the warm start (_held, of OUT_STICK), components whose
#: gain of K + U was taken out of their kinetic energy, components set back at rest where they began (_no_gain),
#: pairs the broad phase had not listed that the island step's paths (after the velocity step or the projection) may
#: meet (_late_pairs), bodies those joined to the islands, and such pairs left out for want of room (the driver makes
#: room for the next step).
(OUT_BODIES, OUT_CONTACTS, OUT_STICK, OUT_PGS, OUT_PROJECTED, OUT_DEPTH, OUT_WOKEN, OUT_SLEPT, OUT_STOPPED, OUT_HELD,
 OUT_TRIMMED, OUT_RESTORED, OUT_LATE, OUT_JOINED, OUT_LATE_LOST) = range(15)
OUT_WIDTH = 15
#: flags bit of a body whose velocity step (or projection) left the path the broad phase screened it on (_late_pairs).
LEFT_PATH = 4096


@njit(**INLINE)
def _depth_tol(size, i, depth_tol):
    """How deep (m) a point of body i may be before the projection moves it out: PROJECT_TOL × its size, or the
    solver's penetration tolerance ``depth_tol`` (m; 0: none) where that is more."""
    return max(PROJECT_TOL * size[i], depth_tol)


@njit(**INLINE)
def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(**JIT)
def _union(parent, a, b):
    ra, rb = _find(parent, a), _find(parent, b)
    if ra != rb:
        if ra < rb:
            parent[rb] = ra
        else:
            parent[ra] = rb


@njit(**INLINE)
def _pose(Y, prm, i, pos, quat):
    pos[i, 0], pos[i, 1], pos[i, 2] = Y[i, P], Y[i, P + 1], Y[i, P + 2]
    qw, qx, qy, qz = qmul(Y[i, Q], Y[i, Q + 1], Y[i, Q + 2], Y[i, Q + 3],
                          prm[i, Q_PB], prm[i, Q_PB + 1], prm[i, Q_PB + 2], prm[i, Q_PB + 3])
    quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3] = qw, qx, qy, qz


@njit(**JIT)
def _poses(Y, prm, nlist, n_pairs, pos, quat, rot):
    """The shape poses at Y of the bodies of pairs nlist[:n_pairs] into pos, quat (_pose) and their rotation
    matrices into rot[:, :9] (row-major), each body once (rot[i, 9]: 1 once done)."""
    for k in range(n_pairs):
        rot[nlist[k, 0], 9] = rot[nlist[k, 1], 9] = 0.0
    for k in range(n_pairs):
        for side in range(2):
            i = nlist[k, side]
            if rot[i, 9] == 0.0:
                _pose(Y, prm, i, pos, quat)
                R = matrix(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3])
                rot[i, 0], rot[i, 1], rot[i, 2], rot[i, 3], rot[i, 4], rot[i, 5], rot[i, 6], rot[i, 7], rot[i, 8] = R
                rot[i, 9] = 1.0
    _pin = Y[0, 0], prm[0, 0], nlist[0, 0], pos[0, 0], quat[0, 0], rot[0, 0]


@njit(**INLINE)
def _speed(Y, i, spin_reach):
    v = math.sqrt(Y[i, V] ** 2 + Y[i, V + 1] ** 2 + Y[i, V + 2] ** 2)
    w = math.sqrt(Y[i, W] ** 2 + Y[i, W + 1] ** 2 + Y[i, W + 2] ** 2)
    return v + w * spin_reach[i]


@njit(**JIT)
def _moved(Y, anchor, i, spin_reach):
    """How far body i at state rows Y is from its pose anchor[i] (position, quaternion): the distance its centre
    moved plus the angle it turned × its bounding radius (m)."""
    d = math.sqrt((Y[i, P] - anchor[i, 0]) ** 2 + (Y[i, P + 1] - anchor[i, 1]) ** 2 + (Y[i, P + 2] - anchor[i, 2]) ** 2)
    # the turn from the anchor: conj(q_a) ⊗ q, its vector part's length sin(θ/2)
    t = qmul(anchor[i, 3], -anchor[i, 4], -anchor[i, 5], -anchor[i, 6], Y[i, Q], Y[i, Q + 1], Y[i, Q + 2], Y[i, Q + 3])
    s = min(math.sqrt(t[1] * t[1] + t[2] * t[2] + t[3] * t[3]), 1.0)
    return d + 2.0 * math.asin(s) * spin_reach[i]


@njit(**INLINE)
def _at_rest(Y0, Y1, i, still, anchor, need, sleep_speed, h, spin_reach):
    """Whether body i was at rest over the step from Y0 to Y1 by the sleep rule: with ``need`` = 1 (the sleep speed
    at SLEEP_SPEED, rest to round-off) slower than ``sleep_speed`` at its start and end; else (raised) within
    sleep_speed × SLEEP_STEPS steps of the pose ``anchor[i]`` (position, quaternion), which a run at rest
    (``still[i]`` ≤ 0: none yet) begins at this step's start."""
    if need == 1:
        return _speed(Y0, i, spin_reach) <= sleep_speed and _speed(Y1, i, spin_reach) <= sleep_speed
    if still[i] <= 0:
        for j in range(3):
            anchor[i, j] = Y0[i, P + j]
        for j in range(4):
            anchor[i, 3 + j] = Y0[i, Q + j]
    return _moved(Y1, anchor, i, spin_reach) <= sleep_speed * SLEEP_STEPS * h


@njit(**JIT)
def _reach_bound(Y0, Y1, i, spin_reach):
    """A bound (m/s) on how fast body i's surface moves over the step (the larger end plus the change)."""
    s0, s1 = _speed(Y0, i, spin_reach), _speed(Y1, i, spin_reach)
    dv = math.sqrt((Y1[i, V] - Y0[i, V]) ** 2 + (Y1[i, V + 1] - Y0[i, V + 1]) ** 2 + (Y1[i, V + 2] - Y0[i, V + 2]) ** 2)
    return max(s0, s1) + dv


@njit(**INLINE)
def _pair_sides(shapes, a, b, column):
    """Pair (a, b)'s coefficient ``column`` (FRICTION or RESTITUTION) on each side, a side without a material taking
    the other's (materials.pair_material's rule), and whether either side has one."""
    ha, hb = shapes[a, HAS_MATERIAL] != 0.0, shapes[b, HAS_MATERIAL] != 0.0
    ca = shapes[a, column] if ha else shapes[b, column]
    cb = shapes[b, column] if hb else shapes[a, column]
    _pin = shapes[0, 0]
    return ca, cb, ha or hb


@njit(**INLINE)
def _pair_mu(shapes, a, b, default_mu):
    ma, mb, has = _pair_sides(shapes, a, b, FRICTION)
    return math.sqrt(ma * mb) if has else default_mu


@njit(**INLINE)
def _on_box(pos, quat, shapes, i, x, y, z, slack):
    """Whether the world point (x, y, z) is inside box i grown by ``slack`` (m)."""
    lx, ly, lz = rotate_back(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3], x - pos[i, 0], y - pos[i, 1], z - pos[i, 2])
    _pin = shapes[0, 0]
    return (abs(lx) <= shapes[i, DIMS] + slack and abs(ly) <= shapes[i, DIMS + 1] + slack
            and abs(lz) <= shapes[i, DIMS + 2] + slack)


@njit(**INLINE)
def _corner(pos, quat, shapes, i, corner, dx, dy, dz):
    """Ball ``corner`` of body i's corner set: (found, its centre x, y, z (world, m), its radius (m)). A box's
    corners 0–7 (radius 0). A cylinder's rim points (radius 0) along its local ±x, ±y (corner & 3) of its end at
    ±z (corner & 4), as the narrow phase's rims standing flat (pairs._disk_disk), and (8, 9) each end's rim point
    farthest along the world direction d (not found where d is within RIM_ACROSS of its axis: every rim point is
    as far). A capsule's segment ends (0, 1), balls of its radius."""
    kind = shapes[i, KIND]
    if kind == SHAPE_CAPSULE:
        end = shapes[i, DIMS + 1] if corner == 1 else -shapes[i, DIMS + 1]
        ox, oy, oz = rotate(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3], 0.0, 0.0, end)
        return True, pos[i, 0] + ox, pos[i, 1] + oy, pos[i, 2] + oz, shapes[i, DIMS]
    if kind == SHAPE_CYLINDER and corner >= 8:
        ux, uy, uz = rotate(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3], 0.0, 0.0, 1.0)
        t = dx * ux + dy * uy + dz * uz
        px, py, pz = dx - t * ux, dy - t * uy, dz - t * uz
        across = math.sqrt(px * px + py * py + pz * pz)
        if not across > RIM_ACROSS:
            return False, 0.0, 0.0, 0.0, 0.0
        r = shapes[i, DIMS] / across
        end = shapes[i, DIMS + 1] if corner == 9 else -shapes[i, DIMS + 1]
        return (True, pos[i, 0] + end * ux + r * px, pos[i, 1] + end * uy + r * py, pos[i, 2] + end * uz + r * pz,
                0.0)
    if kind == SHAPE_CYLINDER:
        j = corner & 3
        r = shapes[i, DIMS]
        lx = r if j == 0 else (-r if j == 2 else 0.0)
        ly = r if j == 1 else (-r if j == 3 else 0.0)
        lz = shapes[i, DIMS + 1] if corner & 4 else -shapes[i, DIMS + 1]
    else:
        lx = shapes[i, DIMS] if corner & 1 else -shapes[i, DIMS]
        ly = shapes[i, DIMS + 1] if corner & 2 else -shapes[i, DIMS + 1]
        lz = shapes[i, DIMS + 2] if corner & 4 else -shapes[i, DIMS + 2]
    ox, oy, oz = rotate(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3], lx, ly, lz)
    return True, pos[i, 0] + ox, pos[i, 1] + oy, pos[i, 2] + oz, 0.0


@njit(**INLINE)
def _with_a_can(shapes, cint, c):
    """Whether contact c is between two bodies, one of them a cylinder: the narrow phase gives its rim as a
    polygon and its deepest point, so a rim crossing an edge can be driven in where the velocity step had no row
    (box and sphere pairs' manifolds have every vertex)."""
    found = False
    if cint[c, I_GROUND] < 0:
        for col in range(3):  # I_A, I_B, I_STATIC
            j = cint[c, col]
            found = found or (j >= 0 and shapes[j, KIND] == SHAPE_CYLINDER)
    return found


@njit(**INLINE)
def _flat_faced(shapes, i):
    """Box or cylinder: the shapes with a flat face, whose pairs face_patch looks at."""
    return shapes[i, KIND] == SHAPE_BOX or shapes[i, KIND] == SHAPE_CYLINDER


@njit(**INLINE)
def _owners(cint, c, a, b, is_static):
    """Contact c's int row for the pair (a, b): its moving bodies (−1: static) and the static body, if any."""
    cint[c, I_A] = -1 if is_static[a] else a
    cint[c, I_B] = -1 if is_static[b] else b
    cint[c, I_STATIC] = a if is_static[a] else (b if is_static[b] else -1)
    cint[c, I_GROUND] = -1
    _pin = is_static[0]


@njit(**JIT)
def _corners(pos, quat, shapes, k, a, b, pnormal, pcount, ppoints, limit, scale, is_static, mu, cint, cflt, count,
             poses, res, seps):
    """Pair k of boxes, cylinders and capsules not face on face (no patch): besides the narrow phase's points (the
    nearest feature), each ball of one's corner set (_corner: a box's corners, a cylinder's rim points, a
    capsule's ends) within ``limit`` of the other: a tilted box's other corners, a tilted can's other side of its
    rim, a box's edge lying across a can's end, a capsule's other end, which a spin or a push about the touching
    point brings in. Between two boxes (the pair's normal a face's or two edges'), a corner's separation along
    the pair's normal from the other's supporting plane, where its foot on that plane lies on the other box;
    otherwise the ball's exact distance to the other and its normal (pairs.ball_contact, closed forms): a
    curved surface leaves its tangent plane, and a can's rim over a box's edge is nearest to a face the pair's
    normal is not. poses (2, POSE_WIDTH), res and seps are scratch. Returns the count."""
    nx, ny, nz = pnormal[k, 0], pnormal[k, 1], pnormal[k, 2]
    plane_a = nx * ppoints[k, 0, 0] + ny * ppoints[k, 0, 1] + nz * ppoints[k, 0, 2]  # a's support along n
    plane_b = nx * ppoints[k, 0, 3] + ny * ppoints[k, 0, 4] + nz * ppoints[k, 0, 5]  # b's support along −n
    slack = 1e-9 * scale
    for side in range(2):
        i = b if side == 0 else a
        other = a if side == 0 else b
        sign = -1.0 if side == 0 else 1.0  # the ball's normal (from i to the other) as the pair's, a to b
        kind = shapes[i, KIND]
        corners = 2 if kind == SHAPE_CAPSULE else (10 if kind == SHAPE_CYLINDER else 8)
        boxes = kind == SHAPE_BOX and shapes[other, KIND] == SHAPE_BOX
        margin = 0.0
        if not boxes:  # the other posed once for ball_contact (not between two boxes: a pile of cubes' pairs)
            margin = set_pose(int(shapes[other, KIND]), shapes[other, DIMS], shapes[other, DIMS + 1],
                              shapes[other, DIMS + 2], pos[other, 0], pos[other, 1], pos[other, 2], quat[other, 0],
                              quat[other, 1], quat[other, 2], quat[other, 3], poses[1])
        for corner in range(corners):
            found, x, y, z, r = _corner(pos, quat, shapes, i, corner, sign * nx, sign * ny, sign * nz)
            if not found:
                continue
            if boxes:
                along = nx * x + ny * y + nz * z
                sd = along - plane_a if side == 0 else plane_b - along
                if sd > limit:
                    continue
                fx, fy, fz = x + sign * sd * nx, y + sign * sd * ny, z + sign * sd * nz  # its foot on that plane
                if not _on_box(pos, quat, shapes, other, fx, fy, fz, slack):
                    continue
                mx, my, mz = 0.5 * (x + fx), 0.5 * (y + fy), 0.5 * (z + fz)
                ux, uy, uz = sign * nx, sign * ny, sign * nz
            else:
                set_pose(SHAPE_SPHERE, r, 0.0, 0.0, x, y, z, 1.0, 0.0, 0.0, 0.0, poses[0])
                sd, ux, uy, uz = ball_contact(poses[0], r, poses[1], margin, res, seps)
                if sd > limit:
                    continue
                mx, my, mz = 0.5 * (res[0, 0] + res[0, 3]), 0.5 * (res[0, 1] + res[0, 4]), 0.5 * (res[0, 2] + res[0, 5])
            seen = False
            for c in range(pcount[k]):  # already one of the narrow phase's points
                px = 0.5 * (ppoints[k, c, 0] + ppoints[k, c, 3])
                py = 0.5 * (ppoints[k, c, 1] + ppoints[k, c, 4])
                pz = 0.5 * (ppoints[k, c, 2] + ppoints[k, c, 5])
                if abs(px - mx) + abs(py - my) + abs(pz - mz) <= 1e-6 * scale:
                    seen = True
            if seen:
                continue
            _owners(cint, count, a, b, is_static)
            cflt[count, C_X], cflt[count, C_X + 1], cflt[count, C_X + 2] = mx, my, mz
            cflt[count, C_N], cflt[count, C_N + 1], cflt[count, C_N + 2] = sign * ux, sign * uy, sign * uz
            cflt[count, C_GAP] = sd
            cflt[count, C_MU] = mu
            count += 1
    _pin = pos[0, 0], quat[0, 0], shapes[0, 0], pnormal[0, 0], pcount[0], ppoints[0, 0, 0], is_static[0], cint[0, 0]
    _pin2 = cflt[0, 0], poses[0, 0], res[0, 0], seps[0]
    return count


@njit(**JIT)
def _end_toward(Y, prm, shapes, grounds, gmu, i, other, limit, cint, cflt, count):
    """Cylinder i standing on an end on a half-space (that end's face within ``limit`` of it, m) touching body
    ``other``: besides its 4 rim points along its local ±x, ±y (the half-space's features, written by _gather),
    the rim point of that end toward ``other``'s centre, so that the disk, not only that square, holds the load
    that body puts on it (a heavy box resting off-centre on a can). A point of the disk: never a wrong contact.
    Returns the count; nothing where ``other``'s centre is on the axis (within RIM_ACROSS of it)."""
    qw, qx, qy, qz = qmul(Y[i, Q], Y[i, Q + 1], Y[i, Q + 2], Y[i, Q + 3], prm[i, Q_PB], prm[i, Q_PB + 1],
                          prm[i, Q_PB + 2], prm[i, Q_PB + 3])
    ux, uy, uz = rotate(qw, qx, qy, qz, 0.0, 0.0, 1.0)
    dx, dy, dz = Y[other, P] - Y[i, P], Y[other, P + 1] - Y[i, P + 1], Y[other, P + 2] - Y[i, P + 2]
    along = dx * ux + dy * uy + dz * uz
    reach = math.sqrt(dx * dx + dy * dy + dz * dz)
    dx, dy, dz = dx - along * ux, dy - along * uy, dz - along * uz
    across = math.sqrt(dx * dx + dy * dy + dz * dz)
    if not across > RIM_ACROSS * reach:
        return count
    r, half = shapes[i, DIMS], shapes[i, DIMS + 1]
    for j in range(grounds.shape[0]):
        nx, ny, nz = grounds[j, NORMAL], grounds[j, NORMAL + 1], grounds[j, NORMAL + 2]
        cos_a = nx * ux + ny * uy + nz * uz
        side = -1.0 if cos_a > 0.0 else 1.0  # the end facing the plane
        px, py, pz = nx - cos_a * ux, ny - cos_a * uy, nz - cos_a * uz
        base = nx * Y[i, P] + ny * Y[i, P + 1] + nz * Y[i, P + 2] - grounds[j, OFFSET] - half * abs(cos_a)
        if base + r * math.sqrt(px * px + py * py + pz * pz) > limit:  # its end's highest rim point: not flat on it
            continue
        ox = side * half * ux + r * dx / across
        oy = side * half * uy + r * dy / across
        oz = side * half * uz + r * dz / across
        cint[count, I_A], cint[count, I_B] = -1, i
        cint[count, I_STATIC], cint[count, I_GROUND] = -1, j
        cflt[count, C_X], cflt[count, C_X + 1], cflt[count, C_X + 2] = Y[i, P] + ox, Y[i, P + 1] + oy, Y[i, P + 2] + oz
        for d in range(3):
            cflt[count, C_N + d] = grounds[j, NORMAL + d]
        cflt[count, C_GAP] = nx * (Y[i, P] + ox) + ny * (Y[i, P + 1] + oy) + nz * (Y[i, P + 2] + oz) - grounds[j, OFFSET]
        cflt[count, C_MU] = gmu[i, j]
        count += 1
        break
    _pin = Y[0, 0], prm[0, 0], shapes[0, 0], grounds[0, 0], gmu[0, 0], cint[0, 0], cflt[0, 0]
    return count


@njit(**JIT)
def _gather(Y, prm, shapes, grounds, gmu, island, nlist, n_pairs, pos, quat, pdist, pnormal, pcount, ppoints, pseps,
            members, bound, size, is_static, default_mu, deep_only, extra, cint, cflt):
    """Contacts of the island bodies (island[i] == 1) at state rows Y into cint (a, b; −1: fixed) and cflt.

    Pairs: the narrow phase's points (mid-way between the surfaces) whose separation is at most
    ``bound`` of the pair (or, with ``deep_only``, TOUCH × its size: the projection's rows); two boxes face on
    face: their patch's (module docstring), as far as PATCH_REACH × the size when that is more. Half-spaces:
    each feature's point likewise (a = −1, the normal the plane's). Returns the count.
    """
    count = 0
    poses, poly = np.zeros((2, POSE_WIDTH)), np.empty((2, 16, 3))
    res, seps = np.empty((MAX_PAIR_POINTS, 6)), np.empty(MAX_PAIR_POINTS)
    for k in range(n_pairs):
        a, b = nlist[k, 0], nlist[k, 1]
        if not (island[a] == 1 or island[b] == 1):
            continue
        scale = max(size[a], size[b])
        limit = TOUCH * scale + extra if deep_only else bound[k]
        mu = _pair_mu(shapes, a, b, default_mu)
        for end, other in ((a, b), (b, a)):  # a can standing on a half-space: its rim point toward the other
            if shapes[end, KIND] == SHAPE_CYLINDER and island[end] == 1 and not is_static[end]:
                count = _end_toward(Y, prm, shapes, grounds, gmu, end, other, TOUCH * size[end] + extra, cint, cflt,
                                    count)
        if _flat_faced(shapes, a) and _flat_faced(shapes, b) and pcount[k] > 0:
            reach = limit if deep_only else max(limit, PATCH_REACH * scale)
            m, rx, ry, rz = face_patch(pos, quat, shapes, a, b, pnormal[k, 0], pnormal[k, 1], pnormal[k, 2],
                                      PATCH_FLAT, max(reach - pdist[k], 0.0), poses, poly, res, seps)
            if m > 0:  # a face on a face: the clipped patch, each point at its own gap
                lowest = math.inf
                for c in range(m):
                    lowest = min(lowest, seps[c])
                    if seps[c] <= reach:
                        _owners(cint, count, a, b, is_static)
                        for j in range(3):
                            cflt[count, C_X + j] = 0.5 * (res[c, j] + res[c, 3 + j])
                        cflt[count, C_N], cflt[count, C_N + 1], cflt[count, C_N + 2] = rx, ry, rz
                        cflt[count, C_GAP] = seps[c]
                        cflt[count, C_MU] = mu
                        count += 1
                # a cylinder's patch is polygons on its round rims: the narrow phase's deepest point besides, where
                # the patch left it out (a box's edge over a rim, beyond its clipped chord)
                if ((shapes[a, KIND] == SHAPE_CYLINDER or shapes[b, KIND] == SHAPE_CYLINDER)
                        and pseps[k, 0] <= limit and pseps[k, 0] < lowest - PROJECT_TOL * scale):
                    _owners(cint, count, a, b, is_static)
                    for j in range(3):
                        cflt[count, C_X + j] = 0.5 * (ppoints[k, 0, j] + ppoints[k, 0, 3 + j])
                        cflt[count, C_N + j] = pnormal[k, j]
                    cflt[count, C_GAP] = pseps[k, 0]
                    cflt[count, C_MU] = mu
                    count += 1
                continue
        for c in range(pcount[k]):
            if pseps[k, c] <= limit:
                _owners(cint, count, a, b, is_static)
                for j in range(3):
                    cflt[count, C_X + j] = 0.5 * (ppoints[k, c, j] + ppoints[k, c, 3 + j])
                    cflt[count, C_N + j] = pnormal[k, j]
                cflt[count, C_GAP] = pseps[k, c]
                cflt[count, C_MU] = mu
                count += 1
        if shapes[a, KIND] != SHAPE_SPHERE and shapes[b, KIND] != SHAPE_SPHERE and pcount[k] > 0:
            count = _corners(pos, quat, shapes, k, a, b, pnormal, pcount, ppoints, limit, scale, is_static, mu, cint,
                             cflt, count, poses, res, seps)
    gaps = np.empty(MAX_FEATURES)
    points = np.empty((4, 3))
    pg = np.empty(4)
    owners = np.zeros(4, dtype=np.int64)
    for m in range(members.shape[0]):
        i = members[m]
        if island[i] != 1:
            continue
        reach = (shapes[i, DIMS] + shapes[i, DIMS + 1] + shapes[i, DIMS + 2]) * (1.0 + 1e-12)  # ≥ any feature's
        for j in range(grounds.shape[0]):
            limit = TOUCH * size[i] + extra if deep_only else bound[n_pairs + m]
            nx, ny, nz = grounds[j, NORMAL], grounds[j, NORMAL + 1], grounds[j, NORMAL + 2]
            if nx * Y[i, P] + ny * Y[i, P + 1] + nz * Y[i, P + 2] - grounds[j, OFFSET] - reach > limit:
                continue  # its centre's distance less its reach beyond limit: every feature's is (feature_gaps')
            nf = feature_gaps(Y[i], prm[i], shapes[i], grounds[j], gaps)
            for f in range(nf):
                if gaps[f] <= limit:
                    npts = feature_points(Y[i], prm[i], shapes[i], grounds[j], 1 << f, points, pg, owners)
                    for c in range(npts):
                        if pg[c] <= limit:
                            cint[count, I_A], cint[count, I_B] = -1, i
                            cint[count, I_STATIC], cint[count, I_GROUND] = -1, j
                            for d in range(3):
                                cflt[count, C_X + d] = points[c, d]
                                cflt[count, C_N + d] = grounds[j, NORMAL + d]
                            cflt[count, C_GAP] = pg[c]
                            cflt[count, C_MU] = gmu[i, j]
                            count += 1
    _pin = Y[0, 0], nlist[0, 0], cint[0, 0], cflt[0, 0], members[0], bound[0], island[0]
    return count


@njit(**JIT)
def _rows(Y, prm, n_contacts, cint, cflt, iw, normal_only, h, size, rj, rw, rdiag, rbias, rbody, island):
    """Each contact's rows (normal, t1, t2; or the normal alone): J (per side 6: linear, angular world), M⁻¹Jᵀ,
    the diagonal of J M⁻¹ Jᵀ, the bias (the gap term g/h for a gap above TOUCH_GAP × the pair's size, else 0:
    touching), the two bodies (−1: fixed, or not moved by this solve: island[i] != 1)."""
    per = 1 if normal_only else 3
    for c in range(n_contacts):
        nx, ny, nz = cflt[c, C_N], cflt[c, C_N + 1], cflt[c, C_N + 2]
        # tangents: t1 ⟂ n from the world axis least aligned with n
        if abs(nx) < 0.57735:
            ex, ey, ez = 1.0, 0.0, 0.0
        elif abs(ny) < 0.57735:
            ex, ey, ez = 0.0, 1.0, 0.0
        else:
            ex, ey, ez = 0.0, 0.0, 1.0
        t1x, t1y, t1z = ny * ez - nz * ey, nz * ex - nx * ez, nx * ey - ny * ex
        s = 1.0 / math.sqrt(t1x * t1x + t1y * t1y + t1z * t1z)
        t1x, t1y, t1z = t1x * s, t1y * s, t1z * s
        t2x, t2y, t2z = ny * t1z - nz * t1y, nz * t1x - nx * t1z, nx * t1y - ny * t1x
        body = cint[c, I_B] if cint[c, I_B] >= 0 else cint[c, I_A]
        bias = cflt[c, C_GAP] / h if cflt[c, C_GAP] > TOUCH_GAP * size[body] else 0.0  # else touching
        for k in range(per):
            r = per * c + k
            dx, dy, dz = row_direction(k, nx, ny, nz, t1x, t1y, t1z, t2x, t2y, t2z)
            diag = 0.0
            for side in range(2):
                i = cint[c, side]
                if i >= 0 and island[i] != 1:
                    i = -1
                rbody[r, side] = i
                o = 6 * side
                if i < 0:
                    for j in range(6):
                        rj[r, o + j] = 0.0
                        rw[r, o + j] = 0.0
                    continue
                sign = -1.0 if side == 0 else 1.0
                arx = cflt[c, C_X] - Y[i, P]
                ary = cflt[c, C_X + 1] - Y[i, P + 1]
                arz = cflt[c, C_X + 2] - Y[i, P + 2]
                cx, cy, cz = ary * dz - arz * dy, arz * dx - arx * dz, arx * dy - ary * dx
                rj[r, o], rj[r, o + 1], rj[r, o + 2] = sign * dx, sign * dy, sign * dz
                rj[r, o + 3], rj[r, o + 4], rj[r, o + 5] = sign * cx, sign * cy, sign * cz
                im = prm[i, INV_MASS]
                rw[r, o], rw[r, o + 1], rw[r, o + 2] = sign * im * dx, sign * im * dy, sign * im * dz
                for j in range(3):
                    rw[r, o + 3 + j] = sign * (iw[i, 3 * j] * cx + iw[i, 3 * j + 1] * cy + iw[i, 3 * j + 2] * cz)
                for j in range(6):
                    diag += rj[r, o + j] * rw[r, o + j]
            rdiag[r] = diag
            rbias[r] = bias if k == 0 else 0.0
    _pin = Y[0, 0], prm[0, 0], cint[0, 0], cflt[0, 0], iw[0, 0], rj[0, 0], rw[0, 0], rdiag[0], rbias[0], rbody[0, 0]
    _pin2 = island[0], size[0]


@njit(**INLINE)
def _row_speed(vel, rj, rbody, r):
    u = 0.0
    for side in range(2):
        i = rbody[r, side]
        if i >= 0:
            for j in range(6):
                u += rj[r, 6 * side + j] * vel[i, j]
    _pin = vel[0, 0], rj[0, 0]
    return u


@njit(**INLINE)
def _apply(vel, rw, rbody, r, dl):
    for side in range(2):
        i = rbody[r, side]
        if i >= 0:
            for j in range(6):
                vel[i, j] += rw[r, 6 * side + j] * dl
    _pin = vel[0, 0], rw[0, 0]


@njit(**INLINE)
def _before(key, a, b):
    """Whether index a sorts before b: by key, ties by index (a total order: the sort is deterministic)."""
    return key[a] < key[b] or (key[a] == key[b] and a < b)


@njit(**JIT)
def _sift(key, idx, start, top, n):
    """Move idx[start + top] down the max-heap idx[start:start + n] to its place."""
    while True:
        child = 2 * top + 1
        if child >= n:
            return
        if child + 1 < n and _before(key, idx[start + child], idx[start + child + 1]):
            child += 1
        if not _before(key, idx[start + top], idx[start + child]):
            return
        idx[start + top], idx[start + child] = idx[start + child], idx[start + top]
        top = child


@njit(**JIT)
def _heap_sort(key, idx, lo, hi):
    """Heap sort of idx[lo:hi] by _before (n log n at worst, no allocation)."""
    n = hi - lo
    for top in range(n // 2 - 1, -1, -1):
        _sift(key, idx, lo, top, n)
    for end in range(n - 1, 0, -1):
        idx[lo], idx[lo + end] = idx[lo + end], idx[lo]
        _sift(key, idx, lo, 0, end)
    _pin = key[0], idx[0]


@njit(**JIT)
def _sort_by(key, idx, start, stop):
    """Sort idx[start:stop] in place by key[idx] ascending, ties by index: a total order, so one result whatever
    the method. Introsort: quicksort (median of three, Hoare's partition) while a range is longer than SORT_SMALL,
    insertion sort below; a range still split after 2 log2 n levels heap sorted (n log n at worst). The larger part
    waits on a stack of 64 ranges (it holds at most log2 n), the smaller is sorted first."""
    stack = np.empty((64, 3), dtype=np.int64)
    stack[0, 0], stack[0, 1], stack[0, 2] = start, stop, 2 * int(math.log2(max(stop - start, 1)) + 1)
    top = 1
    while top > 0:
        top -= 1
        lo, hi, depth = stack[top, 0], stack[top, 1], stack[top, 2]
        while hi - lo > SORT_SMALL:
            if depth == 0:
                _heap_sort(key, idx, lo, hi)
                lo = hi
                break
            depth -= 1
            mid = (lo + hi - 1) // 2
            if _before(key, idx[mid], idx[lo]):
                idx[mid], idx[lo] = idx[lo], idx[mid]
            if _before(key, idx[hi - 1], idx[mid]):
                idx[mid], idx[hi - 1] = idx[hi - 1], idx[mid]
                if _before(key, idx[mid], idx[lo]):
                    idx[mid], idx[lo] = idx[lo], idx[mid]
            pivot = idx[mid]
            i, j = lo - 1, hi
            while True:
                i += 1
                while _before(key, idx[i], pivot):
                    i += 1
                j -= 1
                while _before(key, pivot, idx[j]):
                    j -= 1
                if i >= j:
                    break
                idx[i], idx[j] = idx[j], idx[i]
            # idx[lo:j + 1] before or at the pivot, idx[j + 1:hi] at or after it; both non-empty
            if j + 1 - lo < hi - j - 1:
                stack[top, 0], stack[top, 1], stack[top, 2] = j + 1, hi, depth
                hi = j + 1
            else:
                stack[top, 0], stack[top, 1], stack[top, 2] = lo, j + 1, depth
                lo = j + 1
            top += 1
        for a in range(lo + 1, hi):  # insertion sort of what is left of the range
            v = idx[a]
            b = a - 1
            while b >= lo and _before(key, v, idx[b]):
                idx[b + 1] = idx[b]
                b -= 1
            idx[b + 1] = v
    _pin = key[0], idx[0]


@njit(**JIT)
def _profile_order(cflt, order, start, stop, key):
    """Sort contacts order[start:stop] along their points' longest extent (a column's from its foot up), so that
    their J M⁻¹ Jᵀ has a narrow profile; key (per contact) is scratch."""
    lo_x, lo_y, lo_z, hi_x, hi_y, hi_z = np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf
    for c in range(start, stop):
        q = order[c]
        lo_x, hi_x = min(lo_x, cflt[q, C_X]), max(hi_x, cflt[q, C_X])
        lo_y, hi_y = min(lo_y, cflt[q, C_X + 1]), max(hi_y, cflt[q, C_X + 1])
        lo_z, hi_z = min(lo_z, cflt[q, C_X + 2]), max(hi_z, cflt[q, C_X + 2])
    axis = 0
    if hi_y - lo_y > max(hi_x - lo_x, hi_z - lo_z):
        axis = 1
    elif hi_z - lo_z > hi_x - lo_x:
        axis = 2
    for c in range(start, stop):
        key[order[c]] = cflt[order[c], C_X + axis]
    _sort_by(key, order, start, stop)
    _pin = cflt[0, 0], order[0], key[0]


@njit(**JIT)
def _delassus(vel, rj, rw, rbody, rbias, order, start, stop, A, rhs, first):
    """The lower triangle of A = J M⁻¹ Jᵀ of contacts order[start:stop] (3 rows each, in that order),
    rhs = −(J v* + g/h), and each row's first structurally nonzero column first[x]: the first row of the first
    contact sharing a body with it (rows sharing none are exact zeros and are neither written nor read)."""
    nc = stop - start
    for cx in range(nc):
        qx = order[start + cx]
        a0, a1 = rbody[3 * qx, 0], rbody[3 * qx, 1]
        lead = cx
        for cy in range(cx):
            b0, b1 = rbody[3 * order[start + cy], 0], rbody[3 * order[start + cy], 1]
            if (a0 >= 0 and (a0 == b0 or a0 == b1)) or (a1 >= 0 and (a1 == b0 or a1 == b1)):
                lead = cy
                break
        for k in range(3):
            x = 3 * cx + k
            rx = 3 * qx + k
            rhs[x] = -(_row_speed(vel, rj, rbody, rx) + rbias[rx])
            first[x] = 3 * lead
            for y in range(3 * lead, x + 1):
                ry = 3 * order[start + y // 3] + y % 3
                a = 0.0
                for sx in range(2):
                    bx = rbody[rx, sx]
                    if bx < 0:
                        continue
                    for sy in range(2):
                        if rbody[ry, sy] == bx:
                            for j in range(6):
                                a += rj[rx, 6 * sx + j] * rw[ry, 6 * sy + j]
                A[x, y] = a
    _pin = vel[0, 0], rj[0, 0], rw[0, 0], rbody[0, 0], rbias[0], order[0], A[0, 0], rhs[0], first[0]


@njit(**JIT)
def _equalities(m, A, rhs, first, on, L, lam, res, x0):
    """λ with (A + εI) λ = rhs on the rows with on[x] (the others' λ = 0), by a Cholesky factorisation within the
    profile first[] (skyline: what lies before a row's first nonzero stays zero) refined by TIKHONOV_STEPS iterated
    Tikhonov steps; False when A is zero or not positive definite there. Rows of L before x0 are kept: they were
    factorised by the last call, with the same A and on[] before x0 (a row of L depends only on those above it)."""
    top = 0.0
    for x in range(m):
        top = max(top, A[x, x])
    eps = TIKHONOV_EPS * top
    ok = top > 0.0
    for x in range(x0, m):
        fx = first[x]
        y = fx
        while y <= x:
            if y + 1 < x and on[x] and on[y] and on[y + 1]:
                # two entries of row x at once: two independent sums (each in its own order, k ascending, as
                # one at a time: the same roundings), one pass over row x
                k0, k1 = max(fx, first[y]), max(fx, first[y + 1])
                both = min(max(k0, k1), y)
                s0, s1 = A[x, y], A[x, y + 1]
                for k in range(k0, both):
                    s0 -= L[x, k] * L[y, k]
                for k in range(k1, both):
                    s1 -= L[x, k] * L[y + 1, k]
                for k in range(both, y):
                    lk = L[x, k]
                    s0 -= lk * L[y, k]
                    s1 -= lk * L[y + 1, k]
                L[x, y] = s0 / L[y, y]
                if k1 <= y:
                    s1 -= L[x, y] * L[y + 1, y]
                L[x, y + 1] = s1 / L[y + 1, y + 1]
                y += 2
                continue
            if not on[x] or not on[y]:
                L[x, y] = 1.0 if x == y else 0.0
                y += 1
                continue
            s = A[x, y] + (eps if x == y else 0.0)
            for k in range(max(fx, first[y]), y):
                s -= L[x, k] * L[y, k]
            if x == y:
                if s <= 0.0:
                    ok = False
                    s = 1.0
                L[x, x] = math.sqrt(s)
            else:
                L[x, y] = s / L[y, y]
            y += 1
    scale = 0.0
    for x in range(m):
        lam[x] = 0.0
        res[x] = rhs[x] if on[x] else 0.0
        scale = max(scale, abs(res[x]))
    last = np.inf
    for _ in range(TIKHONOV_STEPS):
        # solve (A + εI) δ = res: forward, backward (δ in res)
        for x in range(m):
            s = res[x]
            for k in range(first[x], x):
                s -= L[x, k] * res[k]
            res[x] = s / L[x, x]
        for x in range(m - 1, -1, -1):
            res[x] /= L[x, x]
            for k in range(first[x], x):
                res[k] -= L[x, k] * res[x]
        for x in range(m):
            lam[x] += res[x]
        _residual(m, A, rhs, first, lam, res)
        worst = 0.0
        for x in range(m):
            if not on[x]:
                res[x] = 0.0
            worst = max(worst, abs(res[x]))
        if worst <= TIKHONOV_TOL * scale or worst >= last:  # at round-off, or no longer shrinking
            break
        last = worst
    _pin = A[0, 0], rhs[0], first[0], on[0], L[0, 0], lam[0], res[0]
    return ok


@njit(**JIT)
def _residual(m, A, rhs, first, lam, res):
    """res = rhs − A λ, A symmetric and zero before each row's first[x]: what each row's speed still lacks."""
    for x in range(m):
        res[x] = rhs[x] - A[x, x] * lam[x]
    for x in range(m):
        s, lx = res[x], lam[x]  # row x's own sum in a register (the same order as in memory)
        for y in range(first[x], x):
            s -= A[x, y] * lam[y]
            res[y] -= A[x, y] * lx
        res[x] = s
    _pin = A[0, 0], rhs[0], first[0], lam[0], res[0]


@njit(**JIT)
def _sticking(vel, rj, rw, rbody, rbias, rlam, cflt, order, start, stop, A, L, rhs, lam, res, band, key):
    """The contacts order[start:stop] (3 rows each) solved exactly when none slides: the points that stay are
    equalities (u⁺ = 0), the others have λ = 0 and part (u_n⁺ ≥ 0). From the points that held last step or
    touch, points whose λ_n < 0 are let go and points let go that would close are taken back, at most
    STICK_PIVOTS times (block principal pivoting on the normals: a column rocking on an edge); the attempt ends
    when the first solve changes more than STICK_CHANGES points. True (and vel, rlam updated) when the points on
    are met to EQUALITY_TOL × the largest right-hand side and every λ_n ≥ 0, every λ_t is in its cone and every
    point let go parts, to round-off. Scratch: band[0] the profile, band[1] the points on, key (per contact) the
    sort's."""
    m = 3 * (stop - start)
    first, on = band[0], band[1]
    _profile_order(cflt, order, start, stop, key)
    _delassus(vel, rj, rw, rbody, rbias, order, start, stop, A, rhs, first)
    for x in range(0, m, 3):  # the points that held last step (warm start) or touch
        r = 3 * order[start + x // 3]
        on[x] = on[x + 1] = on[x + 2] = 1 if rlam[r] > 0.0 or rbias[r] == 0.0 else 0
    kept = False
    x0 = 0  # the first row whose point changed: L above it is kept
    for _pivot in range(STICK_PIVOTS):
        if not _equalities(m, A, rhs, first, on, L, lam, res, x0):
            break
        biggest, fastest = 0.0, 0.0
        for x in range(m):
            if x % 3 == 0:
                biggest = max(biggest, abs(lam[x]))
            fastest = max(fastest, abs(rhs[x]))
        tol, slack = 1e-9 * biggest, 1e-9 * fastest
        _residual(m, A, rhs, first, lam, res)  # −res: each row's speed after
        changed = 0
        x0 = m
        for x in range(0, m, 3):
            if on[x] and lam[x] < -tol:  # pulls: let go
                on[x] = on[x + 1] = on[x + 2] = 0
                changed += 1
            elif not on[x] and -res[x] < -slack:  # closes: take back
                on[x] = on[x + 1] = on[x + 2] = 1
                changed += 1
            if changed and x0 == m:
                x0 = x
        if changed > STICK_CHANGES and _pivot == 0:  # lands or slides: the pivots would not settle
            break
        if changed:
            continue
        kept = True
        for x in range(m):  # the points on are met as equalities (a consistent system)
            if on[x] and abs(res[x]) > EQUALITY_TOL * fastest:
                kept = False
        for c in range(stop - start):
            ln, l1, l2 = lam[3 * c], lam[3 * c + 1], lam[3 * c + 2]
            mu = cflt[order[start + c], C_MU]
            if math.sqrt(l1 * l1 + l2 * l2) > mu * max(ln, 0.0) + tol:
                kept = False
        break
    if kept:
        for x in range(m):
            rx = 3 * order[start + x // 3] + x % 3
            rlam[rx] = lam[x]
            _apply(vel, rw, rbody, rx, lam[x])
    _pin = vel[0, 0], rj[0, 0], rw[0, 0], rbody[0, 0], rbias[0], rlam[0], cflt[0, 0], order[0], A[0, 0], L[0, 0]
    _pin2 = rhs[0], lam[0], res[0], band[0, 0], key[0]
    return kept


@njit(**INLINE)
def _copy_rows(src, dst, rbody, order, start, stop):
    """dst[i] = src[i] (6 columns) for every body of the contacts order[start:stop]."""
    for c in range(start, stop):
        r = 3 * order[c]
        for side in range(2):
            i = rbody[r, side]
            if i >= 0:
                for j in range(6):
                    dst[i, j] = src[i, j]
    _pin = src[0, 0], dst[0, 0], rbody[0, 0], order[0]


@njit(**JIT)
def _held(vel, rj, rw, rbody, rbias, rlam, cflt, cint, size, depth_tol, h, order, start, stop, saved):
    """Whether the contacts order[start:stop] are solved exactly by their warm start (rlam: the last step's λ
    carried over): every point with λ_n > 0 holds (its three rows' speeds after within 1e-9 × the largest row
    speed before, a tenth of the sticking solve's EQUALITY_TOL, and within HELD_TOL × the projection's tolerance
    (_depth_tol) / h: over the step it moves a hundredth of that, so that a component at rest does not creep),
    every other parts (u_n⁺ ≥ 0 to that tolerance), every point's gap after the step (linear) at least minus the
    projection's tolerance (as deep as the projection leaves a point: a component resting there is held as at its
    faces), every λ_n ≥ 0 and every λ_t in its cone. Then the sticking solve's λ is that one, found without a
    factorisation (a component at rest: the same λ step after step, until what it leaves of the speeds, the solve's round-off,
    grows past that tolerance: a held λ does not follow the bodies' turn, so its residue grows step by step).
    True: vel has λ applied; False: vel as it was (its bodies' rows kept in ``saved``, per body 6)."""
    fastest, biggest = 0.0, 0.0
    fits = True
    for c in range(start, stop):
        r = 3 * order[c]
        u0, u1, u2 = _speeds3(vel, rj, rbody, r)
        fastest = max(fastest, abs(u0 + rbias[r]), abs(u1 + rbias[r + 1]), abs(u2 + rbias[r + 2]))
        ln, l1, l2 = rlam[r], rlam[r + 1], rlam[r + 2]
        biggest = max(biggest, abs(ln))
        if ln < 0.0 or (ln == 0.0 and (l1 != 0.0 or l2 != 0.0)):
            fits = False
    tol, slack = 1e-9 * biggest, 1e-9 * fastest
    fits = fits and biggest > 0.0
    if fits:
        for c in range(start, stop):
            q = order[c]
            r = 3 * q
            if math.sqrt(rlam[r + 1] ** 2 + rlam[r + 2] ** 2) > cflt[q, C_MU] * rlam[r] + tol:
                fits = False
    if fits:
        _copy_rows(vel, saved, rbody, order, start, stop)
        for c in range(start, stop):
            r = 3 * order[c]
            for k in range(3):
                if rlam[r + k] != 0.0:
                    _apply(vel, rw, rbody, r + k, rlam[r + k])
        for c in range(start, stop):
            q = order[c]
            r = 3 * q
            body = cint[q, I_B] if cint[q, I_B] >= 0 else cint[q, I_A]
            reach = _depth_tol(size, body, depth_tol)
            close = min(slack, HELD_TOL * reach / h)
            un, u1, u2 = _speeds3(vel, rj, rbody, r)
            if cflt[q, C_GAP] + h * un < -reach:
                fits = False
            if rlam[r] > 0.0:
                if max(abs(un + rbias[r]), abs(u1 + rbias[r + 1]), abs(u2 + rbias[r + 2])) > close:
                    fits = False
            elif un + rbias[r] < -close:
                fits = False
        if not fits:
            _copy_rows(saved, vel, rbody, order, start, stop)
    _pin = vel[0, 0], rj[0, 0], rw[0, 0], rbody[0, 0], rbias[0], rlam[0], cflt[0, 0], cint[0, 0], size[0], order[0]
    _pin2 = saved[0, 0]
    return fits


@njit(**INLINE)
def _span(cint, order, start, stop, per_body):
    """The least and the largest per_body[b] over the bodies b of the contacts order[start:stop] (a component's
    wait, its run of skips, whether a body of it slipped)."""
    least = per_body[cint[order[start], I_B]] if cint[order[start], I_B] >= 0 else per_body[cint[order[start], I_A]]
    most = least
    for k in range(start, stop):
        for side in range(2):
            b = cint[order[k], side]
            if b >= 0:
                least = min(least, per_body[b])
                most = max(most, per_body[b])
    return least, most


@njit(**INLINE)
def _inverse(d):
    """1 / d for a row's diagonal d (Gauss–Seidel multiplies by it: a division is about a sixth of a sweep); 0 where
    d is not positive (a row that moves nothing, skipped)."""
    return 1.0 / d if d > 0.0 else 0.0


@njit(**INLINE)
def _speeds3(vel, rj, rbody, r):
    """The speeds of a contact's three rows r, r + 1, r + 2 (normal, t1, t2; the same two bodies), one pass over
    its bodies' velocities."""
    u0, u1, u2 = 0.0, 0.0, 0.0
    for side in range(2):
        i = rbody[r, side]
        if i >= 0:
            o = 6 * side
            for j in range(6):
                v = vel[i, j]
                u0 += rj[r, o + j] * v
                u1 += rj[r + 1, o + j] * v
                u2 += rj[r + 2, o + j] * v
    return u0, u1, u2


@njit(**INLINE)
def _apply3(vel, rw, rbody, r, d0, d1, d2):
    """vel += M⁻¹Jᵀ (d0, d1, d2) over a contact's three rows r, r + 1, r + 2, one pass over its bodies."""
    for side in range(2):
        i = rbody[r, side]
        if i >= 0:
            o = 6 * side
            for j in range(6):
                vel[i, j] += rw[r, o + j] * d0 + rw[r + 1, o + j] * d1 + rw[r + 2, o + j] * d2


@njit(**JIT)
def _sweep(vel, rj, rw, rbody, rdiag, inv, rbias, rlam, cflt, cross, order, start, stop, backward):
    """One projected Gauss–Seidel sweep over contacts order[start:stop] (normal, then the two tangents in
    Coulomb's disk of the new normal λ), in that order or ``backward``; returns the largest change of a row's
    speed (m/s). The tangents' speeds after the normal's change are J_t (v + M⁻¹J_nᵀ Δλ_n), J_t M⁻¹J_nᵀ in
    cross[q] (per step, _pgs), inv the rows' 1 / rdiag: the contact's velocities are read once and written
    once."""
    change = 0.0
    for k in range(start, stop):
        q = order[start + stop - 1 - k] if backward else order[k]
        r = 3 * q
        u0, u1, u2 = _speeds3(vel, rj, rbody, r)
        dl = 0.0
        if rdiag[r] > 0.0:
            new = max(rlam[r] - (u0 + rbias[r]) * inv[r], 0.0)
            dl = new - rlam[r]
            rlam[r] = new
            u1 += cross[q, 0] * dl  # the tangents' speeds after it: + J_t M⁻¹ J_nᵀ Δλ_n
            u2 += cross[q, 1] * dl
            change = max(change, abs(dl) * rdiag[r])
        limit = cflt[q, C_MU] * rlam[r]
        l1, l2 = rlam[r + 1], rlam[r + 2]
        if rdiag[r + 1] > 0.0:
            l1 = l1 - u1 * inv[r + 1]
        if rdiag[r + 2] > 0.0:
            l2 = l2 - u2 * inv[r + 2]
        norm = math.sqrt(l1 * l1 + l2 * l2)
        if norm > limit:
            s = limit / norm if norm > 0.0 else 0.0
            l1, l2 = l1 * s, l2 * s
        d1, d2 = l1 - rlam[r + 1], l2 - rlam[r + 2]
        rlam[r + 1], rlam[r + 2] = l1, l2
        if dl != 0.0 or d1 != 0.0 or d2 != 0.0:
            _apply3(vel, rw, rbody, r, dl, d1, d2)
        change = max(change, max(abs(d1) * rdiag[r + 1], abs(d2) * rdiag[r + 2]))
    _pin = vel[0, 0], rj[0, 0], rw[0, 0], rbody[0, 0], rdiag[0], rbias[0], rlam[0], cflt[0, 0], order[0]
    _pin2 = cross[0, 0], inv[0]
    return change


@njit(**JIT)
def _pile_sweeps(vel, rj, rw, rbody, rdiag, inv, rbias, rlam, cflt, cross, order, start, stop, sweeps, last, step,
                 bwork, blist):
    """At most ``sweeps`` projected Gauss–Seidel sweeps over one component's contacts order[start:stop] (sorted from
    the highest against gravity down), down then back up in turn, each extrapolated: nonsmooth nonlinear conjugate
    gradient (Silcowitz, Niebe, Erleben 2010). Each sweep's change of λ, Δ, is the descent direction; λ is then
    extrapolated by β p (β = |Δ|² / |Δ_prev|², p ← β p + Δ), restarted (p = Δ) when |Δ| grows; the next
    sweep projects onto the cones again. Stops when no row's speed changes by more than PGS_TOL (m/s). The
    extrapolation moves the velocities per body, not per contact (they are linear in λ: M⁻¹Jᵀ p kept per body).
    Scratch: last and step (per row of order[start:stop], at 3 × its place), bwork (per body: M⁻¹Jᵀ p, the
    velocities at the sweep's start, and whether listed, zero between calls) and blist (the component's bodies)."""
    for x in range(3 * start, 3 * stop):
        step[x] = 0.0
    nb = 0  # the component's bodies; bwork[i, :6]: M⁻¹Jᵀ p, [6:12]: vel at the sweep's start, [12]: listed
    for c in range(start, stop):
        r = 3 * order[c]
        for side in range(2):
            i = rbody[r, side]
            if i >= 0 and bwork[i, 12] == 0.0:
                bwork[i, 12] = 1.0
                blist[nb] = i
                nb += 1
    for b in range(nb):
        for j in range(6):
            bwork[blist[b], j] = 0.0
    shrink = 0.0
    for sweep in range(sweeps):
        for c in range(start, stop):
            for k in range(3):
                last[3 * c + k] = rlam[3 * order[c] + k]
        for b in range(nb):
            i = blist[b]
            for j in range(6):
                bwork[i, 6 + j] = vel[i, j]
        backward = sweep % 2 == 1
        if _sweep(vel, rj, rw, rbody, rdiag, inv, rbias, rlam, cflt, cross, order, start, stop, backward) <= PGS_TOL:
            break
        if sweep == sweeps - 1:  # the last λ is a sweep's: in its cones
            break
        size2 = 0.0
        for c in range(start, stop):
            for k in range(3):
                d = rlam[3 * order[c] + k] - last[3 * c + k]
                size2 += d * d
        beta = size2 / shrink if sweep > 0 and size2 <= shrink else 0.0
        for c in range(start, stop):
            r = 3 * order[c]
            m0, m1, m2 = beta * step[3 * c], beta * step[3 * c + 1], beta * step[3 * c + 2]
            for k in range(3):
                step[3 * c + k] = beta * step[3 * c + k] + rlam[r + k] - last[3 * c + k]
            rlam[r] += m0
            rlam[r + 1] += m1
            rlam[r + 2] += m2
        for b in range(nb):  # vel += M⁻¹Jᵀ β p; M⁻¹Jᵀ p ← β M⁻¹Jᵀ p + the sweep's change of vel (linear in λ)
            i = blist[b]
            for j in range(6):
                m = beta * bwork[i, j]
                bwork[i, j] = m + (vel[i, j] - bwork[i, 6 + j])
                vel[i, j] += m
        shrink = size2
    for b in range(nb):
        bwork[blist[b], 12] = 0.0
    _pin = vel[0, 0], rj[0, 0], rw[0, 0], rbody[0, 0], rdiag[0], rbias[0], rlam[0], cflt[0, 0], order[0]
    _pin2 = cross[0, 0], inv[0], last[0], step[0], bwork[0, 0], blist[0]


@njit(**INLINE)
def _root(cint, comp, q):
    """The velocity step's component (its root in comp) of contact q: that of its moving body."""
    return _find(comp, cint[q, I_B] if cint[q, I_B] >= 0 else cint[q, I_A])


@njit(**JIT)
def _pgs(vel, rj, rw, rbody, rdiag, rbias, rlam, cflt, cint, comp, flags, order, stop, gx, gy, gz, cwork, rwork, bwork,
         blist):
    """Projected Gauss–Seidel on contacts order[:stop] (each component's contiguous; comp: the components'
    union-find, cint the contacts' bodies) from their λ in rlam (the warm start): sweeps until none changes a row's
    speed by more than PGS_TOL (m/s), at most PGS_SWEEPS or PGS_WORK / stop. More than PILE_CONTACTS contacts (a
    pile): each component on its own (_pile_sweeps), from the highest against gravity (gx, gy, gz) down, then back
    up, in turn (a weight passes down a pile, and a stop up it, within one sweep), at most PILE_PGS_SWEEPS or
    PGS_WORK / stop (WOKEN_SWEEPS for a component whose root has flag 2048: just woken or set back at rest); fewer,
    in their order.
    Scratch: cwork (per contact: the tangents' cross terms, the sort's key), rwork (per row: 1 / the diagonal, the
    last sweep's λ, the extrapolation), bwork and blist (per body: _pile_sweeps')."""
    cross, key = cwork[:, 0:2], cwork[:, 2]
    inv, last, step = rwork[:, 0], rwork[:, 1], rwork[:, 2]
    for c in range(stop):
        q = order[c]
        r = 3 * q
        c1, c2 = 0.0, 0.0  # J_t M⁻¹ J_nᵀ: a normal's change in its tangents' speeds
        for j in range(12):
            c1 += rj[r + 1, j] * rw[r, j]
            c2 += rj[r + 2, j] * rw[r, j]
        cross[q, 0], cross[q, 1] = c1, c2
        for k in range(3):
            inv[r + k] = _inverse(rdiag[r + k])
            if rlam[r + k] != 0.0:
                _apply(vel, rw, rbody, r + k, rlam[r + k])
    work = PGS_WORK // max(stop, 1)
    if stop <= PILE_CONTACTS:
        for sweep in range(max(PGS_SWEEPS, work)):
            if _sweep(vel, rj, rw, rbody, rdiag, inv, rbias, rlam, cflt, cross, order, 0, stop, False) <= PGS_TOL:
                break
    else:  # a pile: component by component (what one sweep reads stays in cache), highest first: g · x ascending
        for c in range(stop):
            q = order[c]
            key[q] = gx * cflt[q, C_X] + gy * cflt[q, C_X + 1] + gz * cflt[q, C_X + 2]
        lo = 0
        while lo < stop:
            root = _root(cint, comp, order[lo])
            hi = lo + 1
            while hi < stop and _root(cint, comp, order[hi]) == root:
                hi += 1
            _sort_by(key, order, lo, hi)
            sweeps = WOKEN_SWEEPS if flags[root] & 2048 else max(PILE_PGS_SWEEPS, work)
            _pile_sweeps(vel, rj, rw, rbody, rdiag, inv, rbias, rlam, cflt, cross, order, lo, hi, sweeps, last, step,
                         bwork, blist)
            lo = hi
    _pin = vel[0, 0], rj[0, 0], rw[0, 0], rbody[0, 0], rdiag[0], rbias[0], rlam[0], cflt[0, 0], order[0]
    _pin2 = cwork[0, 0], rwork[0, 0], cint[0, 0], comp[0], flags[0], bwork[0, 0], blist[0]


@njit(**INLINE)
def _row_dir(rj, rbody, r):
    """Row r's direction (world, unit): J's linear part on body b, or minus a's when b is fixed."""
    if rbody[r, 1] >= 0:
        return rj[r, 6], rj[r, 7], rj[r, 8]
    return -rj[r, 0], -rj[r, 1], -rj[r, 2]


@njit(**INLINE)
def _same_pair(aint, a, bint, b):
    """Whether contact a of int rows aint and contact b of bint are between the same two sides."""
    return (aint[a, I_A] == bint[b, I_A] and aint[a, I_B] == bint[b, I_B] and aint[a, I_STATIC] == bint[b, I_STATIC]
            and aint[a, I_GROUND] == bint[b, I_GROUND])


@njit(**INLINE)
def _list_per_body(cint, count, members, head):
    """Contacts cint[:count] listed per moving body (side b, else a), in their order: head[i] the first of body i,
    cint[c, I_NEXT] the next after c, −1 the end."""
    for m in range(members.shape[0]):
        head[members[m]] = -1
    for c in range(count - 1, -1, -1):
        i = cint[c, I_B] if cint[c, I_B] >= 0 else cint[c, I_A]
        cint[c, I_NEXT] = head[i]
        head[i] = c


@njit(**JIT)
def _warm_start(nc, cint, cflt, n_prev, prev_int, prev_flt, members, size, head, rj, rbody, rlam):
    """Each contact's λ (3 rows) from the last step's contact of the same pair (same static body or half-space)
    nearest to its point within WARM_REACH × its body's size: that impulse taken onto the new rows and into the
    cone (each old contact used once); 0 where none. prev_int[:, I_NEXT], prev_flt[:, C_MU] and head (per body)
    are overwritten."""
    _list_per_body(prev_int, n_prev, members, head)
    for c in range(nc):
        i = cint[c, I_B] if cint[c, I_B] >= 0 else cint[c, I_A]
        best = (WARM_REACH * size[i]) ** 2
        found = -1
        p = head[i]
        while p >= 0:
            if prev_flt[p, C_MU] >= 0.0 and _same_pair(prev_int, p, cint, c):
                d2 = ((prev_flt[p, C_X] - cflt[c, C_X]) ** 2 + (prev_flt[p, C_X + 1] - cflt[c, C_X + 1]) ** 2
                      + (prev_flt[p, C_X + 2] - cflt[c, C_X + 2]) ** 2)
                if d2 < best:
                    best, found = d2, p
            p = prev_int[p, I_NEXT]
        r = 3 * c
        if found < 0:
            rlam[r], rlam[r + 1], rlam[r + 2] = 0.0, 0.0, 0.0
            continue
        prev_flt[found, C_MU] = -1.0  # taken
        ix, iy, iz = prev_flt[found, C_IMPULSE], prev_flt[found, C_IMPULSE + 1], prev_flt[found, C_IMPULSE + 2]
        for k in range(3):
            dx, dy, dz = _row_dir(rj, rbody, r + k)
            rlam[r + k] = ix * dx + iy * dy + iz * dz
        rlam[r] = max(rlam[r], 0.0)
        limit = cflt[c, C_MU] * rlam[r]
        norm = math.sqrt(rlam[r + 1] ** 2 + rlam[r + 2] ** 2)
        if norm > limit:
            s = limit / norm
            rlam[r + 1], rlam[r + 2] = rlam[r + 1] * s, rlam[r + 2] * s
    _pin = cint[0, 0], cflt[0, 0], prev_int[0, 0], prev_flt[0, 0], members[0], size[0], head[0], rj[0, 0]
    _pin2 = rbody[0, 0], rlam[0]


@njit(**JIT)
def _impulses(nc, rj, rbody, rlam, cflt):
    """Each contact's impulse on its body b (world, N·s) from its three rows' λ, into cflt[:, C_IMPULSE:]."""
    for c in range(nc):
        ix = iy = iz = 0.0
        for k in range(3):
            r = 3 * c + k
            dx, dy, dz = _row_dir(rj, rbody, r)
            ix += rlam[r] * dx
            iy += rlam[r] * dy
            iz += rlam[r] * dz
        cflt[c, C_IMPULSE], cflt[c, C_IMPULSE + 1], cflt[c, C_IMPULSE + 2] = ix, iy, iz
    _pin = rj[0, 0], rbody[0, 0], rlam[0], cflt[0, 0]


@njit(**INLINE)
def _still_apart(Y, shapes, path, lower, bound, a, b):
    """Whether boxes a and b, apart by at least ``lower`` (m) when their bodies had moved path[·, 0] (m) and turned
    path[·, 1] (rad) less than now (path: each body's since, summed), are still apart by more than ``bound`` (m):
    a face-normal separation changes by at most the two translations plus the two turns × (the centres' distance
    along the way + each box's half-extents summed)."""
    ta, tb = path[a, 0], path[b, 0]
    turn = path[a, 1] + path[b, 1]
    extents = 0.0
    for j in range(3):
        extents += shapes[a, DIMS + j] + shapes[b, DIMS + j]
    ox, oy, oz = Y[b, P] - Y[a, P], Y[b, P + 1] - Y[a, P + 1], Y[b, P + 2] - Y[a, P + 2]
    centres = math.sqrt(ox * ox + oy * oy + oz * oz) + ta + tb
    return lower - (ta + tb + turn * (centres + extents)) - 1e-12 * extents > bound


@njit(**JIT)
def _narrow(Y, prm, shapes, nlist, n_pairs, pos, quat, pdist, pnormal, pcount, ppoints, pseps, bound, path, again,
            rot):
    """The narrow phase of pairs nlist[:n_pairs] at state rows Y, but for two boxes farther apart than their
    bound[k] (m; by a face-normal separation, ~15 ns against ~0.5 µs): those get that lower bound as pdist and no
    points. Reorders nlist[:n_pairs] and bound[:n_pairs] (the pairs looked at first). ``again`` (a later round of
    the projection: pdist and pcount at each place the pair's from an earlier round): a pair found apart then is
    not looked at while _still_apart holds (path: per body, what it moved and turned since). rot (per body, 10
    columns) is scratch: each body's pose is taken once (_poses), before the pairs are looked at."""
    _poses(Y, prm, nlist, n_pairs, pos, quat, rot)
    near = 0
    for k in range(n_pairs):
        a, b = nlist[k, 0], nlist[k, 1]
        if again and pcount[k] == 0 and _still_apart(Y, shapes, path, pdist[k], bound[k], a, b):
            continue  # as apart as when looked at (the same decision; pdist keeps that lower bound)
        apart = -1.0
        if shapes[a, KIND] == SHAPE_BOX and shapes[b, KIND] == SHAPE_BOX:  # its bound decides: found sooner
            apart = boxes_apart_turned(rot, pos, shapes, a, b, bound[k])
        if apart > bound[k]:
            pdist[k] = apart
            pcount[k] = 0
            continue
        if k != near:  # swapped to the front
            nlist[k, 0], nlist[near, 0] = nlist[near, 0], a
            nlist[k, 1], nlist[near, 1] = nlist[near, 1], b
            bound[k], bound[near] = bound[near], bound[k]
            pdist[k], pcount[k] = pdist[near], pcount[near]
        near += 1
    if near > 0:
        pair_contacts(pos, quat, shapes, nlist[:near], pdist, pnormal, pcount, ppoints, pseps)
    _pin = Y[0, 0], prm[0, 0], nlist[0, 0], pos[0, 0], quat[0, 0], pdist[0], pcount[0], bound[0], path[0, 0], rot[0, 0]


@njit(**JIT)
def _bounds(Y0, Y1, nlist, lo, hi, is_static, spin_reach, size, h, bound, members, speed, deflect, hit):
    """Each pair's reach over the step from Y0 to Y1 (m): how close it must be to meet within the step. speed (per
    body) is scratch: each member's _reach_bound, taken once, plus ``hit`` × its ``deflect`` (per body, m/s: the
    change of velocity a hit in the step may give it; ``hit`` 1 before the velocity step, 0 after, on its
    velocities)."""
    for m in range(members.shape[0]):
        i = members[m]
        speed[i] = _reach_bound(Y0, Y1, i, spin_reach) + hit * deflect[i]
    for k in range(lo, hi):
        a, b = nlist[k, 0], nlist[k, 1]
        reach = 0.0
        if not is_static[a]:
            reach += speed[a]
        if not is_static[b]:
            reach += speed[b]
        bound[k] = reach * h + TOUCH * max(size[a], size[b])
    _pin = Y0[0, 0], Y1[0, 0], nlist[0, 0], is_static[0], spin_reach[0], size[0], bound[0], members[0], speed[0]
    _pin2 = deflect[0]


@njit(**INLINE)
def _inertia_world(Y, prm, i, iw):
    qw, qx, qy, qz = normalise(Y[i, Q], Y[i, Q + 1], Y[i, Q + 2], Y[i, Q + 3])
    R = matrix(qw, qx, qy, qz)
    for a in range(3):
        for b in range(3):
            s = 0.0
            for k in range(3):
                s += R[3 * a + k] * prm[i, INV_INERTIA + k] * R[3 * b + k]
            iw[i, 3 * a + b] = s


@njit(**INLINE)
def _motion(Y0, Y1, pnormal, pcount, ppoints, k, a, b):
    """Touching pair k (a, b) at the step's start: 0 resting, −1 striking, 1 parting. It does not rest when its least
    normal speed over its points (< 0 approaching) is beyond IMPACT_MARGIN × the largest change the step's forces
    make to one (Y1: the free step's end) and beyond APPROACH_SPEED, either way: striking (an impact, the impact
    law's, unless _joins takes it) or parting (each body flies on, its own step)."""
    nx, ny, nz = pnormal[k, 0], pnormal[k, 1], pnormal[k, 2]
    least, change = math.inf, 0.0
    for c in range(pcount[k]):
        x = 0.5 * (ppoints[k, c, 0] + ppoints[k, c, 3])
        y = 0.5 * (ppoints[k, c, 1] + ppoints[k, c, 4])
        z = 0.5 * (ppoints[k, c, 2] + ppoints[k, c, 5])
        u0 = normal_speed(Y0[a], Y0[b], nx, ny, nz, x, y, z)
        least = min(least, u0)
        change = max(change, abs(normal_speed(Y1[a], Y1[b], nx, ny, nz, x, y, z) - u0))
    if pcount[k] == 0 or abs(least) <= max(IMPACT_MARGIN * change, APPROACH_SPEED):
        return 0
    return -1 if least < 0.0 else 1


@njit(**INLINE)
def _inelastic(shapes, a, b):
    """Whether pair (a, b) has restitution 0 by the pair rule (the larger of the two; a side without a material
    takes the other's): False when neither has a material (the default restitution)."""
    ea, eb, has = _pair_sides(shapes, a, b, RESTITUTION)
    return has and max(ea, eb) == 0.0


@njit(**INLINE)
def _joins(Y0, Y1, pnormal, pcount, ppoints, k, a, b, shapes, modes):
    """Whether touching pair k (a, b) joins an island: resting, or striking without restitution or with a body held
    on its ground (_motion)."""
    motion = _motion(Y0, Y1, pnormal, pcount, ppoints, k, a, b)
    return motion == 0 or (motion < 0 and (_inelastic(shapes, a, b) or modes[a] != 0 or modes[b] != 0))


@njit(**JIT)
def _link(Y0, Y1, nlist, lo, hi, pdist, pnormal, pcount, ppoints, bound, is_static, size, shapes, modes, parent,
          flags):
    """Pairs nlist[lo:hi] after their narrow phase at Y0 (bound: their reach, _bounds; Y1: the free step's end):
    moving pairs joined (flags bit 8 on a touching pair's first body)."""
    for k in range(lo, hi):
        a, b = nlist[k, 0], nlist[k, 1]
        touch = TOUCH * max(size[a], size[b])
        if is_static[a] or is_static[b]:
            continue
        settling = flags[a] & 64 and flags[b] & 64 and pdist[k] <= bound[k]
        if settling or (pdist[k] <= touch and _joins(Y0, Y1, pnormal, pcount, ppoints, k, a, b, shapes, modes)):
            # touching and resting, or striking without restitution or with a body held on its ground (the
            # island's velocity step is then the inelastic impact, together with the bodies' other contacts: a box
            # landing on a can held on its rim on the ground); or both stepped in an island last step and still
            # within reach: the island holds them while they settle (a Gauss–Seidel residue may part them by more
            # than TOUCH)
            _union(parent, a, b)
            flags[a] |= 8
        elif pdist[k] <= bound[k] or not (flags[a] & 32 or flags[b] & 32):
            # awake pairs whose swept boxes overlap are joined whatever their distance: an island's solve
            # and projection can move its bodies beyond the free step's reach; a sleeping island is woken
            # only by a body within that reach
            _union(parent, a, b)
    _pin = Y0[0, 0], Y1[0, 0], nlist[0, 0], pdist[0], pnormal[0, 0], pcount[0], ppoints[0, 0, 0], bound[0]
    _pin2 = is_static[0], size[0], parent[0]


@njit(**JIT)
def _pile_rows(prm, nd, cint, cflt, rj, rw, rdiag, rbody, porder, key):
    """The order of the nd normal rows' Gauss–Seidel in porder[:nd]: over a pile (more than PILE_CONTACTS, under
    gravity) from the lowest point up, with each upright pair's lower body (the one its normal points down to)
    held (its M⁻¹Jᵀ side zeroed, the diagonal the upper's alone), and True; else their order, and False. key (per
    row) is the sort's scratch."""
    for c in range(nd):
        porder[c] = c
    pile = False
    if nd > PILE_CONTACTS:
        i = cint[0, 1] if cint[0, 1] >= 0 else cint[0, 0]
        gx, gy, gz = prm[i, GRAVITY], prm[i, GRAVITY + 1], prm[i, GRAVITY + 2]
        g = math.sqrt(gx * gx + gy * gy + gz * gz)
        pile = g > 0.0
    if pile:
        for c in range(nd):
            key[c] = -(gx * cflt[c, C_X] + gy * cflt[c, C_X + 1] + gz * cflt[c, C_X + 2])
        _sort_by(key, porder, 0, nd)
        for c in range(nd):
            a, b = rbody[c, 0], rbody[c, 1]
            upright = abs(gx * cflt[c, C_N] + gy * cflt[c, C_N + 1] + gz * cflt[c, C_N + 2]) >= PILE_UPRIGHT * g
            if a < 0 or b < 0 or not upright:
                continue
            # the lower body: the one the normal (a → b) points down to, not the one whose centre is lower (a box
            # leaning on a body whose centre is a little higher would be the lower of both its pairs, held from
            # above and below at once: a point between the two that neither may move out of)
            low = 1 if gx * cflt[c, C_N] + gy * cflt[c, C_N + 1] + gz * cflt[c, C_N + 2] > 0.0 else 0
            d = 0.0
            for j in range(6):
                rw[c, 6 * low + j] = 0.0
                d += rj[c, 6 * (1 - low) + j] * rw[c, 6 * (1 - low) + j]
            rdiag[c] = d
    _pin = prm[0, 0], cint[0, 0], cflt[0, 0], rj[0, 0], rw[0, 0], rdiag[0], rbody[0, 0], porder[0], key[0]
    return pile


@njit(**JIT)
def _stop_approach(Y1, prm, members, island, nd, cint, cflt, iw, h, size, rj, rw, rdiag, rbias, rbody, rlam, vel,
                   inv, act):
    """After the projection: the island bodies' velocities in Y1 made not to approach at the nd touching points
    cint/cflt (normal rows, λ ≥ 0, e = 0): the projection moved them out, they must not be left moving in
    again. Gauss–Seidel in the kinetic metric first, then on the linear velocities alone for what approach is
    left (that one converges in a pile, as the projection's translating rounds do); over a pile (more than
    PILE_CONTACTS points) at most PILE_SWEEPS sweeps each, what approach is left being the next step's to stop.
    Only removes kinetic energy (not as the projection over a pile: holding a lower body there gave the upper its
    speed, energy and motion that kept a pile from sleeping). inv (per row) and act (per row: the rows that move a
    body) are scratch."""
    n = members.shape[0]
    for m in range(n):
        i = members[m]
        if island[i] != 1:
            continue
        R = matrix(Y1[i, Q], Y1[i, Q + 1], Y1[i, Q + 2], Y1[i, Q + 3])
        for a in range(3):
            vel[i, a] = Y1[i, V + a]
            vel[i, 3 + a] = R[3 * a] * Y1[i, W] + R[3 * a + 1] * Y1[i, W + 1] + R[3 * a + 2] * Y1[i, W + 2]
    for metric in range(2):
        for m in range(n):
            i = members[m]
            if island[i] == 1:
                if metric == 0:
                    _inertia_world(Y1, prm, i, iw)
                else:
                    for j in range(9):
                        iw[i, j] = 0.0
        _rows(Y1, prm, nd, cint, cflt, iw, True, h, size, rj, rw, rdiag, rbias, rbody, island)
        moving = 0
        for c in range(nd):
            rlam[c] = 0.0
            inv[c] = _inverse(rdiag[c])
            if rdiag[c] > 0.0:  # the others (between bodies held) are not swept
                act[moving] = c
                moving += 1
        for _s in range(PILE_SWEEPS if nd > PILE_CONTACTS else PROJECT_SWEEPS):
            change = 0.0
            for k in range(moving):
                c = act[k]
                new = max(rlam[c] - _row_speed(vel, rj, rbody, c) * inv[c], 0.0)
                dl = new - rlam[c]
                rlam[c] = new
                if dl != 0.0:
                    _apply(vel, rw, rbody, c, dl)
                change = max(change, abs(dl) * rdiag[c])
            if change <= PGS_TOL:
                break
        for c in range(nd):  # each point's impulse on b (world, N·s), both passes summed
            ux, uy, uz = _row_dir(rj, rbody, c)
            if metric == 0:
                cflt[c, C_IMPULSE], cflt[c, C_IMPULSE + 1], cflt[c, C_IMPULSE + 2] = 0.0, 0.0, 0.0
            cflt[c, C_IMPULSE] += rlam[c] * ux
            cflt[c, C_IMPULSE + 1] += rlam[c] * uy
            cflt[c, C_IMPULSE + 2] += rlam[c] * uz
    for m in range(n):
        i = members[m]
        if island[i] != 1:
            continue
        R = matrix(Y1[i, Q], Y1[i, Q + 1], Y1[i, Q + 2], Y1[i, Q + 3])
        for a in range(3):
            Y1[i, V + a] = vel[i, a]
        Y1[i, W] = R[0] * vel[i, 3] + R[3] * vel[i, 4] + R[6] * vel[i, 5]
        Y1[i, W + 1] = R[1] * vel[i, 3] + R[4] * vel[i, 4] + R[7] * vel[i, 5]
        Y1[i, W + 2] = R[2] * vel[i, 3] + R[5] * vel[i, 4] + R[8] * vel[i, 5]
    _pin = Y1[0, 0], prm[0, 0], members[0], island[0], cint[0, 0], cflt[0, 0], iw[0, 0], rj[0, 0], rw[0, 0]
    _pin2 = rdiag[0], rbias[0], rbody[0, 0], rlam[0], vel[0, 0], inv[0], size[0], act[0]


@njit(**JIT)
def _attribute(nc, cint, cflt, nd, sint, sflt, members, head, room):
    """The impulses of the nd points whose approach was stopped after the projection (sint/sflt) added to the
    step's contacts (cint/cflt[:nc]) of the same pair (the first listed), so that a pair's summed impulse is all
    it gave; a point of a pair without one (met after the velocity step) is listed after them as it is (its
    point and gap the step's end's), while there is room (rows). Returns the count. head (per body) and
    cint[:, I_NEXT] are overwritten."""
    _list_per_body(cint, nc, members, head)
    count = nc
    for p in range(nd):
        i = sint[p, I_B] if sint[p, I_B] >= 0 else sint[p, I_A]
        c = head[i]
        while c >= 0:
            if _same_pair(cint, c, sint, p):
                for k in range(3):
                    cflt[c, C_IMPULSE + k] += sflt[p, C_IMPULSE + k]
                break
            c = cint[c, I_NEXT]
        if c < 0 and count < room and (sflt[p, C_IMPULSE] != 0.0 or sflt[p, C_IMPULSE + 1] != 0.0
                                       or sflt[p, C_IMPULSE + 2] != 0.0):
            for k in range(C_INTS):
                cint[count, k] = sint[p, k]
            for k in range(C_FLOATS):
                cflt[count, k] = sflt[p, k]
            count += 1
    _pin = cint[0, 0], cflt[0, 0], sint[0, 0], sflt[0, 0], members[0], head[0]
    return count


@njit(**JIT)
def _project(Y1, prm, shapes, grounds, gmu, island, nlist, n_pairs, pos, quat, rot, pdist, pnormal, pcount, ppoints,
             pseps, members, bound, size, is_static, default_mu, depth_tol, h, iw, dx, vel, cint, cflt, rj, rw, rdiag,
             rbias, rlam, rbody, porder, out, comp, flags, rwork):
    """The projection of the island bodies' poses Y1: points deeper than its tolerance (_depth_tol) closed by
    the least mass-metric correction (over a pile, bottom-up with lower bodies held: _pile_rows), then their
    velocities kept from approaching where it moved them (_stop_approach: the touching points at the final poses,
    and the first round's points deeper than TOUCH × the size with a cylinder, at most DRIVEN_KEPT, where the
    velocity step drove bodies in at a point it had no row for); returns the largest depth it took on (m).
    Only the bodies of the velocity step's components (comp) with a deep point move; the others (solved exactly,
    at their contacts' gaps to round-off) are held as fixed, and their pairs with each other not looked at again.
    rwork (per row, 2 columns) and rot (per body, _narrow's) are scratch."""
    n = members.shape[0]
    deepest = 0.0
    settled = False
    live = n_pairs
    before = math.inf  # the depth the last round began with (m)
    slow = False
    kept = 0  # the first round's points deep beyond TOUCH × the size, kept at the scratch's tail until the end
    tail = cint.shape[0] - DRIVEN_KEPT
    path = vel  # per body: what it moved (m) and turned (rad) since the first round, summed (a static body's row is
    # never written: zero, as it does not move)
    for m in range(n):
        path[members[m], 0] = path[members[m], 1] = 0.0
    for rnd in range(PROJECT_ROUNDS):
        if rnd <= 1:  # the pairs with a moving body first: the rounds' narrow phase (the others' data stale)
            live = 0
            for k in range(n_pairs):
                a, b = nlist[k, 0], nlist[k, 1]
                if island[a] == 1 or island[b] == 1:
                    nlist[k, 0], nlist[live, 0] = nlist[live, 0], a
                    nlist[k, 1], nlist[live, 1] = nlist[live, 1], b
                    bound[k], bound[live] = bound[live], bound[k]
                    pdist[k], pdist[live] = pdist[live], pdist[k]
                    pcount[k], pcount[live] = pcount[live], pcount[k]
                    live += 1
        _narrow(Y1, prm, shapes, nlist, live, pos, quat, pdist, pnormal, pcount, ppoints, pseps, bound, path, rnd > 0,
                rot)
        nd = _gather(Y1, prm, shapes, grounds, gmu, island, nlist, n_pairs, pos, quat, pdist, pnormal, pcount, ppoints, pseps,
                     members, bound, size, is_static, default_mu, True, 0.0, cint, cflt)
        deep = 0
        depth = 0.0
        tol = 0.0  # the deepest point's tolerance (m)
        for c in range(nd):
            i = cint[c, 1] if cint[c, 1] >= 0 else cint[c, 0]
            if cflt[c, C_GAP] < -_depth_tol(size, i, depth_tol):
                deep += 1
                if -cflt[c, C_GAP] > depth:
                    depth, tol = -cflt[c, C_GAP], _depth_tol(size, i, depth_tol)
                if rnd == 0:  # its components move
                    for side in range(2):
                        if cint[c, side] >= 0:
                            flags[_find(comp, cint[c, side])] |= 256
                    if -cflt[c, C_GAP] > TOUCH * size[i] and kept < DRIVEN_KEPT and _with_a_can(shapes, cint, c):
                        for j in range(C_INTS):
                            cint[tail + kept, j] = cint[c, j]
                        for j in range(C_FLOATS):
                            cflt[tail + kept, j] = cflt[c, j]
                        cflt[tail + kept, C_GAP] = 0.0
                        kept += 1
        if deep == 0:
            settled = True  # nd: the touching points at the final poses
            break
        if rnd > 0 and not slow:  # the rounds left, at the last one's rate, would not close it
            rate = depth / before
            slow = rate > 0.5 or depth * rate ** (PROJECT_ROUNDS - rnd) > tol
        before = depth
        if rnd == 0:  # the components without a deep point are held (island 3 until the end)
            for m in range(n):
                i = members[m]
                if island[i] == 1 and not flags[_find(comp, i)] & 256:
                    island[i] = 3
        # the rows: every point within twice the depth above contact too, so that turning a body out of one
        # penetration does not drive its neighbouring corners into another
        nd = _gather(Y1, prm, shapes, grounds, gmu, island, nlist, n_pairs, pos, quat, pdist, pnormal, pcount,
                     ppoints, pseps, members, bound, size, is_static, default_mu, True, 2.0 * depth, cint, cflt)
        out[OUT_PROJECTED] += deep
        for m in range(n):
            i = members[m]
            if island[i] == 1:
                if rnd < TURN_ROUNDS:
                    _inertia_world(Y1, prm, i, iw)
                else:  # the later rounds translate only: turning a body out of one penetration can drive its
                    for j in range(9):  # other corners into another, round after round in a pile
                        iw[i, j] = 0.0
                for j in range(6):
                    dx[i, j] = 0.0
        _rows(Y1, prm, nd, cint, cflt, iw, True, h, size, rj, rw, rdiag, rbias, rbody, island)
        for c in range(nd):  # every touching point is a row (λ ≥ 0): closing one gap must not open another
            rlam[c] = 0.0
            deepest = max(deepest, -cflt[c, C_GAP])
        pile = _pile_rows(prm, nd, cint, cflt, rj, rw, rdiag, rbody, porder, rwork[:, 1])
        inv = rwork[:, 0]  # the rows' 1 / rdiag
        moving = 0
        for k in range(nd):
            c = porder[k]
            inv[c] = _inverse(rdiag[c])
            if rdiag[c] > 0.0:  # in their order; the others (between bodies held) are not swept
                porder[moving] = c
                moving += 1
        for _s in range((PILE_SLOW_SWEEPS if slow else PILE_SWEEPS) if pile else PROJECT_SWEEPS):
            change = 0.0
            for k in range(moving):
                c = porder[k]
                g = cflt[c, C_GAP] + _row_speed(dx, rj, rbody, c)
                new = max(rlam[c] - g * inv[c], 0.0)
                dl = new - rlam[c]
                rlam[c] = new
                if dl != 0.0:
                    _apply(dx, rw, rbody, c, dl)
                change = max(change, abs(dl) * rdiag[c])
            if change <= 1e-16:
                break
        for m in range(n):
            i = members[m]
            if island[i] != 1:
                continue
            for a in range(3):
                Y1[i, P + a] += dx[i, a]
            path[i, 0] += math.sqrt(dx[i, 0] ** 2 + dx[i, 1] ** 2 + dx[i, 2] ** 2)
            path[i, 1] += math.sqrt(dx[i, 3] ** 2 + dx[i, 4] ** 2 + dx[i, 5] ** 2)
            ew, ex, ey, ez = exp_map(dx[i, 3], dx[i, 4], dx[i, 5])  # a world-axes turn: exp(δθ) ⊗ q
            q = qmul(ew, ex, ey, ez, Y1[i, Q], Y1[i, Q + 1], Y1[i, Q + 2], Y1[i, Q + 3])
            Y1[i, Q], Y1[i, Q + 1], Y1[i, Q + 2], Y1[i, Q + 3] = normalise(q[0], q[1], q[2], q[3])
    if deepest > 0.0:
        if not settled:  # the touching points at the final poses (settled: the last round's first gather)
            _narrow(Y1, prm, shapes, nlist, live, pos, quat, pdist, pnormal, pcount, ppoints, pseps, bound, path, True,
                    rot)
            nd = _gather(Y1, prm, shapes, grounds, gmu, island, nlist, n_pairs, pos, quat, pdist, pnormal, pcount,
                         ppoints, pseps, members, bound, size, is_static, default_mu, True, 0.0, cint, cflt)
        for c in range(kept):  # and the first round's deep points: the velocity step drove the bodies in there
            for j in range(C_INTS):
                cint[nd + c, j] = cint[tail + c, j]
            for j in range(C_FLOATS):
                cflt[nd + c, j] = cflt[tail + c, j]
        nd += kept
        _stop_approach(Y1, prm, members, island, nd, cint, cflt, iw, h, size, rj, rw, rdiag, rbias, rbody, rlam, vel,
                       rwork[:, 0], porder)
        out[OUT_STOPPED] = nd
    for m in range(n):
        i = members[m]
        if island[i] == 3:
            island[i] = 1
    _pin = Y1[0, 0], prm[0, 0], nlist[0, 0], members[0], cint[0, 0], cflt[0, 0], rj[0, 0], rbody[0, 0], out[0]
    _pin2 = comp[0], flags[0], rwork[0, 0]
    return deepest


@njit(**INLINE)
def _wakes(Y0, saved, wr, stopped, i):
    """Whether sleeping body i wakes at the step's start: a wrench on it, stopped, or its state not the one it was
    locked in (an impulse, a state set)."""
    changed = wr[i, ACTIVE] != 0.0 or stopped[i]
    for j in range(STATE_WIDTH):
        changed = changed or Y0[i, j] != saved[i, j]
    return changed


@njit(**JIT)
def all_asleep(Y0, saved, wr, stopped, asleep, moving):
    """Whether no body moves in this step: every body of ``moving`` (the simulator's moving bodies, global indices)
    asleep, none woken at the step's start (:func:`_wakes`). Then :func:`island_pass` would copy every row forward
    and find nothing else to do: the driver carries the state over instead (a scene wholly asleep costs a check)."""
    for m in range(moving.shape[0]):
        i = moving[m]
        if not asleep[i] or _wakes(Y0, saved, wr, stopped, i):
            return False
    return moving.shape[0] > 0


@njit(**JIT)
def rest_alone(Y0, Y1, alone, spin_reach, still, anchor, asleep, saved, group, sleep_speed, h):
    """Sleeping for bodies resting alone on their ground (held by the ground pass, in no island): each body of
    ``alone`` (global indices) at rest over the step Y0 → Y1 by the islands' rule (:func:`_at_rest`) as many steps
    in a row as an island's bodies (``still``, per body, kept across calls: the caller sets it to 0 for a body not
    alone) falls asleep as a one-body island's would: its velocities set to zero in Y1, its row saved, its own
    group. Returns how many fell asleep."""
    need = 1 if sleep_speed <= SLEEP_SPEED else SLEEP_STEPS
    fell = 0
    for m in range(alone.shape[0]):
        i = alone[m]
        if _at_rest(Y0, Y1, i, still, anchor, need, sleep_speed, h, spin_reach):
            still[i] = max(still[i], 0) + 1
        else:
            still[i] = 0
        if still[i] >= need:
            asleep[i] = 1
            still[i] = 0
            group[i] = i
            fell += 1
            for j in range(6):
                Y1[i, V + j] = 0.0
            for j in range(STATE_WIDTH):
                saved[i, j] = Y1[i, j]
    return fell


@njit(**JIT)
def _energy(Y, prm, i):
    """Body i's kinetic energy and its K + U under its gravity at state rows Y (J): ½ m v² + ½ Σ Iⱼ ωⱼ² − m g · p."""
    k = kinetic_energy_row(Y[i], prm[i])
    return k, k + potential_energy_row(Y[i], prm[i])


@njit(**JIT)
def _no_gain(Y0, Y1, prm, wr, bare, modes, members, island, comp, nc, cint, cflt, size, depth_tol, sums, flags, out,
             lifts):
    """Keep each component of the step's contacts (comp) that nothing but gravity pushes (no applied wrench on
    its bodies; its fixed sides never move) from ending the step with more K + U than it began it with. What the
    step added (a Gauss–Seidel step short of convergence, the projection's lift) is taken out of its kinetic
    energy, every body's v and ω scaled by √(1 − ΔE/K), which keeps separating every contact between its bodies
    or with a fixed side that was (OUT_TRIMMED). Where it added more than the component's kinetic energy, its
    bodies are set back where they began the step, at rest (K + U then U₀ ≤ K₀ + U₀; OUT_RESTORED): it was nearly
    at rest, and it had no contact with another component over the step. That rest is imposed, not found: its root
    is flagged (128) and the sleep rule does not count the step as at rest (FROZEN_STEPS such steps in a row it
    counts apart). A component with points of the step's start (nc rows of cint, cflt) deeper than the projection's
    tolerance (overlapping as it was set) keeps what a lift out of them may add: its rise of U over the step, up to
    its bodies' Σ m |g| × those depths summed (none is lifted farther out of them than that); only the rest of a
    rise is taken out, and where that is more than its kinetic energy its bodies stop where they are (not set
    back into the overlap). A rise within RISE_ROUNDOFF × Σ |E| is round-off and left alone: the exact solve's
    steps are not touched. sums (per body, 6 columns) and lifts (per body) are scratch: per root the
    rise, K at the end, Σ |E|, what is done (−1: left alone, pushed; 1: trimmed; 2: restored; 3: stopped where it
    is), the depths summed, its rise of U; Σ m |g|."""
    n = members.shape[0]
    for m in range(n):
        i = members[m]
        if island[i] == 1:
            r = _find(comp, i)
            for j in range(6):
                sums[r, j] = 0.0
            lifts[r] = 0.0
    for c in range(nc):
        i = cint[c, I_B] if cint[c, I_B] >= 0 else cint[c, I_A]
        if cflt[c, C_GAP] < -_depth_tol(size, i, depth_tol):
            sums[_find(comp, i), 4] -= cflt[c, C_GAP]
    for m in range(n):
        i = members[m]
        if island[i] != 1:
            continue
        r = _find(comp, i)
        row = bare[i] if modes[i] != 0 else wr[i]
        if row[ACTIVE] != 0.0:
            sums[r, 3] = -1.0
        k0, e0 = _energy(Y0, prm, i)
        k1, e1 = _energy(Y1, prm, i)
        sums[r, 0] += e1 - e0
        sums[r, 1] += k1
        sums[r, 2] += abs(e0) + abs(e1)
        sums[r, 5] += (e1 - k1) - (e0 - k0)
        lifts[r] += prm[i, MASS] * math.sqrt(prm[i, GRAVITY] ** 2 + prm[i, GRAVITY + 1] ** 2
                                             + prm[i, GRAVITY + 2] ** 2)
    for m in range(n):
        i = members[m]
        if island[i] != 1:
            continue
        r = _find(comp, i)
        lift = min(max(sums[r, 5], 0.0), lifts[r] * sums[r, 4])  # what a lift out of its overlaps may add
        if sums[r, 3] == 0.0 and sums[r, 0] - lift > RISE_ROUNDOFF * sums[r, 2]:
            sums[r, 0] -= lift
            if sums[r, 0] < sums[r, 1]:
                sums[r, 3] = 1.0
                out[OUT_TRIMMED] += 1
            elif sums[r, 4] > 0.0:
                sums[r, 3] = 3.0
                out[OUT_TRIMMED] += 1
            else:
                sums[r, 3] = 2.0
                flags[r] |= 128
                out[OUT_RESTORED] += 1
        if sums[r, 3] == 1.0:
            scale = math.sqrt(1.0 - sums[r, 0] / sums[r, 1])
            for a in range(3):
                Y1[i, V + a] *= scale
                Y1[i, W + a] *= scale
        elif sums[r, 3] == 2.0:
            for j in range(STATE_WIDTH):
                Y1[i, j] = Y0[i, j]
            Y1[i, BOUND] = Y0[i, BOUND]
            for j in range(3):
                Y1[i, V + j] = 0.0
                Y1[i, W + j] = 0.0
        elif sums[r, 3] == 3.0:
            for j in range(3):
                Y1[i, V + j] = 0.0
                Y1[i, W + j] = 0.0


@njit(**INLINE)
def _listed(nlist, lhead, lnext, i, j):
    """Whether pair (i, j) is a row of nlist (lhead, lnext: each body's rows, _late_pairs)."""
    c = lhead[i]
    while c >= 0:
        if nlist[c // 2, 1 - c % 2] == j:
            return True
        c = lnext[c]
    return False


@njit(**JIT)
def _late_pairs(Y0, Y1, grounds, island, stopped, is_static, members, nlist, n_pairs, comp, flags, broad, h, boxes,
                left, n_left, lhead, lnext, found, out):
    """The pairs the velocity step's paths may bring together that the broad phase, screening the free step's,
    did not list: appended to nlist for the projection (returns the new n_pairs). ``left`` (n_left rows of members,
    each flagged LEFT_PATH): the island bodies whose end left its free step's end by more than that screen's growth
    (swept_bounds'); ``boxes`` (per body, 6 columns): each one's box over its new path (lo, hi). A pair is one of
    those and a body whose box meets it (the broad phase's box, or the other's new one) whose bounding spheres
    can meet over the step as now stepped (spheres_may_meet's test on their chords; a body not in an island keeps its
    growth, and may be stopped by a half-space of ``grounds``: paths_may_meet), not in nlist, neither stopped. A
    moving body outside the islands so met joins them (island 1, its free step as it is: it is moved by the
    projection and the stop of approach, with momentum) and its component
    joins the other's. ``broad``: the broad phase's (lo, hi, movable, fixed, members, reach, cells, heads, chain),
    its members' first rows this pass's members. lhead (per body), lnext (2 per nlist row) and found (per broad
    phase member) are scratch."""
    lo, hi, movable, fixed, bmembers, reach, cells, heads, chain = broad
    n = members.shape[0]
    for m in range(n):
        lhead[members[m]] = -1
    for f in range(fixed.shape[0]):
        lhead[bmembers[fixed[f]]] = -1
    for k in range(n_pairs):
        for side in range(2):
            i = nlist[k, side]
            lnext[2 * k + side] = lhead[i]
            lhead[i] = 2 * k + side
    most = 0.0  # a body on its box's path strays from it by up to 1e-6 of its reach (the test that listed it)
    for m in range(n):
        most = max(most, reach[m])
    for e in range(n_left):
        m = left[e]
        i = members[m]
        count = grid_overlaps(boxes[i, 0:3], boxes[i, 3:6], 1e-6 * most, lo, hi, movable, fixed, cells, heads, chain,
                              found)
        for c in range(min(count, found.shape[0])):
            k = found[c]
            if k < n and flags[members[k]] & LEFT_PATH:
                continue  # another that left its path: the pairs of those below
            n_pairs = _late_pair(Y0, Y1, grounds, island, stopped, is_static, nlist, n_pairs, comp, flags, bmembers,
                                 reach, h, m, k, lhead, lnext, out)
        for e2 in range(e + 1, n_left):
            m2 = left[e2]
            j = members[m2]
            if boxes_meet(boxes[i, 0:3], boxes[i, 3:6], boxes[j, 0:3], boxes[j, 3:6], 0.0):
                n_pairs = _late_pair(Y0, Y1, grounds, island, stopped, is_static, nlist, n_pairs, comp, flags,
                                     bmembers, reach, h, m, m2, lhead, lnext, out)
    _pin = Y0[0, 0], Y1[0, 0], island[0], stopped[0], is_static[0], members[0], nlist[0, 0], comp[0], flags[0]
    _pin2 = boxes[0, 0], left[0], lhead[0], lnext[0], found[0], out[0]
    return n_pairs


@njit(**INLINE)
def _late_pair(Y0, Y1, grounds, island, stopped, is_static, nlist, n_pairs, comp, flags, bmembers, reach, h, m, k,
               lhead, lnext, out):
    """_late_pairs' test of broad phase members m (an island body that left its path) and k, and the pair added."""
    i, j = bmembers[m], bmembers[k]
    if i == j or stopped[i] or stopped[j] or _listed(nlist, lhead, lnext, i, j):
        return n_pairs
    free = island[j] == 0 and not is_static[j]  # a free step keeps its growth, and its ground may stop it
    grow = growth(Y0, Y1, j, h) if free else 0.0
    if not paths_may_meet(Y0, Y1, grounds, i, j, reach[m], reach[k], grow, False, free):
        return n_pairs
    if n_pairs == nlist.shape[0]:
        out[OUT_LATE_LOST] += 1
        return n_pairs
    a, b = (i, j) if m < k else (j, i)  # as the broad phase lists them: a static shape second
    nlist[n_pairs, 0], nlist[n_pairs, 1] = a, b
    for side in range(2):
        body = nlist[n_pairs, side]
        lnext[2 * n_pairs + side] = lhead[body]
        lhead[body] = 2 * n_pairs + side
    out[OUT_LATE] += 1
    if island[j] == 0 and not is_static[j]:
        island[j] = 1
        out[OUT_JOINED] += 1
        out[OUT_BODIES] += 1
    if island[j] == 1:
        _union(comp, i, j)
        flags[_find(comp, i)] &= ~512  # not solved exactly as one: its bodies may move in the projection
    return n_pairs + 1


@njit(**JIT)
def _left_path(Y0, Y1, island, members, flags, reach, free, boxes, left):
    """The island bodies whose end (Y1) is farther from their free step's end (free[i, :3], world, m) than its
    growth (free[i, 3], m) and 1e-6 of their reach (m): listed in left (rows of members, each flagged LEFT_PATH,
    the flag cleared on the others) with their box over the path from Y0 to that end (boxes: lo, hi), for
    _late_pairs. Returns how many."""
    n_left = 0
    for m in range(members.shape[0]):
        i = members[m]
        flags[i] &= ~LEFT_PATH
        if island[i] != 1:
            continue
        ex, ey, ez = Y1[i, P] - free[i, 0], Y1[i, P + 1] - free[i, 1], Y1[i, P + 2] - free[i, 2]
        if math.sqrt(ex * ex + ey * ey + ez * ez) > free[i, 3] + 1e-6 * reach[m]:
            flags[i] |= LEFT_PATH
            left[n_left] = m
            n_left += 1
            for a in range(3):
                boxes[i, a] = min(Y0[i, P + a], Y1[i, P + a]) - reach[m]
                boxes[i, 3 + a] = max(Y0[i, P + a], Y1[i, P + a]) + reach[m]
    _pin = Y0[0, 0], Y1[0, 0], island[0], members[0], flags[0], reach[0], free[0, 0], boxes[0, 0], left[0]
    return n_left


@njit(**JIT)
def island_pass(Y0, Y1, prm, wr, bare, modes, saved, shapes, grounds, gmu, members, cand, n_cand, is_static, stopped,
                spin_reach, size, asleep, roused, wait, skips, still, anchor, h, sleeping, sleep_speed, default_mu,
                depth_tol, n_prev, rest_int, rest_flt, island, parent, flags, nlist, pos, quat, rot, pdist, pnormal,
                pcount, ppoints, pseps, bound, cint, cflt, vel, iw, dx, rj, rw, rdiag, rbias, rlam, rbody, order,
                cstart, A, L, vec, out, comp, band, group, cwork, rwork, bwork, blist, broad, lhead, lnext, found,
                lifts, deflect):
    """One step of every island (module docstring): results into Y1 for the bodies marked island[i] = 1 (solved)
    or 2 (asleep: their rows copied from Y0). Returns 0, or −(contacts needed) when cint is too small
    (then nothing was changed but ``asleep`` and the outputs; call again with room). ``depth_tol`` (m, ≥ 0): the
    solver's penetration tolerance, how deep a point may be left before the projection moves it out, where that is
    more than PROJECT_TOL × its body's size (_depth_tol; 0: exact). ``wait`` (per body, kept
    across calls): steps before its component is tried for the sticking solve again (≤ 0: at once; WAIT_SOLVED,
    WAIT_HELD); ``skips`` (per body, 2 columns, kept across calls): the steps in a row its component, due, was not
    tried (STICK_SKIPS), and 1 if a point of it slipped at the end of the step (SLIP); ``still`` (per body, kept
    across calls): the steps in a row it was at rest by the sleep rule (end of this function) in an island, from
    the pose ``anchor`` (per body: position, quaternion) with a sleep speed raised above rest; negative, the steps
    in a row _no_gain set it back where it began (FROZEN_STEPS). ``roused`` (per body, kept across calls): 1 from
    when it wakes (here, or all at once when sleeping is turned off), 2 from a step _no_gain set it back at rest, to
    its next step in an island, whose Gauss–Seidel solve gets PGS_SWEEPS sweeps (WOKEN_SWEEPS). The warm start:
    the last step's n_prev contacts (the first half of cint/cflt) and, while a body is woken (roused 1), the
    contacts of the islands asleep (rest_int, rest_flt:
    each a force, N; × h, the λ that held it), so that one woken is solved from the rest it was locked in.
    ``broad``: the broad phase's boxes and grid (_late_pairs), which listed ``cand``. ``cwork`` (per contact, 3
    columns), ``rwork`` (per row, 3 columns), ``bwork`` (per body, 13 columns, the last zero between calls),
    ``blist`` (per body), ``lhead`` (per body), ``lnext`` (2 per row of nlist), ``found`` (per broad phase
    member) and ``lifts`` (per body) are scratch. ``deflect`` (per body, m/s): the change of velocity a hit in the
    step may give it (the broad phase's bound, swept.deflections; 0 where within its skin), added to its
    reach before the velocity step: a pair a hit may bring together within the step has its points there."""
    n = members.shape[0]
    for k in range(OUT_WIDTH):
        out[k] = 0.0
    woken = 0
    for m in range(n):  # a sleeping body pushed (a wrench) or whose state was set wakes
        i = members[m]
        if asleep[i] and _wakes(Y0, saved, wr, stopped, i):
            asleep[i] = 0
            roused[i] = 1
            woken += 1
    for m in range(n):
        i = members[m]
        parent[i] = i
        flags[i] = (32 if asleep[i] else 0) | (64 if island[i] == 1 else 0)  # asleep now; in an island last step
        island[i] = 0
    # candidate pairs: sleeping with sleeping are linked without a narrow phase; the others looked at
    n_pairs = 0
    for k in range(n_cand):
        a, b = cand[k, 0], cand[k, 1]
        if stopped[a] or stopped[b]:
            continue
        if asleep[a] and (asleep[b] or is_static[b]):
            if not is_static[b] and group[a] == group[b]:  # fell asleep together (apart, each wakes alone)
                _union(parent, a, b)
            continue
        if is_static[a] and asleep[b]:
            continue
        nlist[n_pairs, 0], nlist[n_pairs, 1] = a, b
        n_pairs += 1
    _bounds(Y0, Y1, nlist, 0, n_pairs, is_static, spin_reach, size, h, bound, members, dx[:, 0], deflect, 1.0)
    _narrow(Y0, prm, shapes, nlist, n_pairs, pos, quat, pdist, pnormal, pcount, ppoints, pseps, bound, dx, False, rot)
    _link(Y0, Y1, nlist, 0, n_pairs, pdist, pnormal, pcount, ppoints, bound, is_static, size, shapes, modes, parent,
          flags)
    for m in range(n):
        i = members[m]
        r = _find(parent, i)
        flags[r] |= (2 if asleep[i] else 4) | (1 if flags[i] & 8 else 0)
    for m in range(n):
        i = members[m]
        r = _find(parent, i)
        if flags[r] & 2 and flags[r] & 4:  # something awake within reach of a sleeping island: it wakes
            if asleep[i]:
                asleep[i] = 0
                roused[i] = 1
                woken += 1
            island[i] = 1
        elif flags[r] & 2:
            island[i] = 2
        elif flags[r] & 1:
            island[i] = 1
    if woken:  # the woken islands' own pairs, skipped above, get their narrow phase now
        n0 = n_pairs
        for k in range(n_cand):
            a, b = cand[k, 0], cand[k, 1]
            if stopped[a] or stopped[b] or island[a] != 1:
                continue
            if flags[a] & 32 and (is_static[b] or flags[b] & 32):  # skipped above (asleep with asleep)
                nlist[n_pairs, 0], nlist[n_pairs, 1] = a, b
                n_pairs += 1
        _bounds(Y0, Y1, nlist, n0, n_pairs, is_static, spin_reach, size, h, bound, members, dx[:, 0], deflect, 1.0)
        _narrow(Y0, prm, shapes, nlist[n0:], n_pairs - n0, pos, quat, pdist[n0:], pnormal[n0:], pcount[n0:],
                ppoints[n0:], pseps[n0:], bound[n0:], dx, False, rot)
        _link(Y0, Y1, nlist, n0, n_pairs, pdist, pnormal, pcount, ppoints, bound, is_static, size, shapes, modes,
              parent, flags)
    out[OUT_WOKEN] = woken
    # room for the contacts (pairs' points and each island body's features against each half-space)
    need = 0
    for k in range(n_pairs):
        if island[nlist[k, 0]] == 1 or island[nlist[k, 1]] == 1:
            need += pcount[k] + 24  # its corners besides (_corners: up to 10 a body), a can's rim point on a
            # half-space (_end_toward)
    for m in range(n):
        if island[members[m]] == 1:
            need += MAX_FEATURES * 4 * grounds.shape[0]
        bound[n_pairs + m] = 0.0
    n_warm = n_prev  # and the asleep islands' contacts while a body woken has not had its first island step
    for m in range(n):
        if roused[members[m]] == 1:
            n_warm = n_prev + rest_int.shape[0]
            break
    half = cint.shape[0] // 2
    if max(need + DRIVEN_KEPT, n_warm) > half:  # the first half: the velocity step's contacts; the second: the
        return -max(need + DRIVEN_KEPT, n_warm)  # projection's, its last DRIVEN_KEPT rows _project's own
    for c in range(n_prev):  # the last step's contacts (the first half) kept in the second for the warm start
        for j in range(C_INTS):
            cint[half + c, j] = cint[c, j]
        for j in range(C_FLOATS):
            cflt[half + c, j] = cflt[c, j]
    for c in range(n_warm - n_prev):
        for j in range(C_INTS):
            cint[half + n_prev + c, j] = rest_int[c, j]
        for j in range(C_FLOATS):
            cflt[half + n_prev + c, j] = rest_flt[c, j]
        for j in range(3):
            cflt[half + n_prev + c, C_IMPULSE + j] *= h
    bodies = 0
    for m in range(n):
        i = members[m]
        if island[i] == 2:
            for j in range(STATE_WIDTH):
                Y1[i, j] = Y0[i, j]
            Y1[i, BOUND] = Y0[i, BOUND]
        elif island[i] == 1:
            bodies += 1
            bound[n_pairs + m] = (_reach_bound(Y0, Y1, i, spin_reach) + deflect[i]) * h + TOUCH * size[i]
            # the free velocity: v + h f/m, ω_P + h I⁻¹ (τ_P − ω × I ω), then ω in world axes
            row = bare[i] if modes[i] != 0 else wr[i]  # a body held on its ground until now: without that force
            fx, fy, fz, tx, ty, tz = body_wrench(Y0[i], prm[i], row)
            im = prm[i, INV_MASS]
            vel[i, 0] = Y0[i, V] + h * im * fx
            vel[i, 1] = Y0[i, V + 1] + h * im * fy
            vel[i, 2] = Y0[i, V + 2] + h * im * fz
            w0, w1, w2 = Y0[i, W], Y0[i, W + 1], Y0[i, W + 2]
            I0, I1, I2 = prm[i, INERTIA], prm[i, INERTIA + 1], prm[i, INERTIA + 2]
            g0 = tx - (w1 * I2 * w2 - w2 * I1 * w1)
            g1 = ty - (w2 * I0 * w0 - w0 * I2 * w2)
            g2 = tz - (w0 * I1 * w1 - w1 * I0 * w0)
            w0 += h * prm[i, INV_INERTIA] * g0
            w1 += h * prm[i, INV_INERTIA + 1] * g1
            w2 += h * prm[i, INV_INERTIA + 2] * g2
            qw, qx, qy, qz = normalise(Y0[i, Q], Y0[i, Q + 1], Y0[i, Q + 2], Y0[i, Q + 3])
            R = matrix(qw, qx, qy, qz)
            for a in range(3):
                vel[i, 3 + a] = R[3 * a] * w0 + R[3 * a + 1] * w1 + R[3 * a + 2] * w2
            _inertia_world(Y0, prm, i, iw)
    out[OUT_BODIES] = bodies
    if bodies == 0:
        for m in range(n):
            still[members[m]] = 0
            wait[members[m]] = 0
            skips[members[m], 0] = skips[members[m], 1] = 0
        _pin = Y0[0, 0], Y1[0, 0], prm[0, 0], wr[0, 0], bare[0, 0], modes[0], saved[0, 0], cand[0, 0], A[0, 0], L[0, 0], vec[0, 0], order[0], cstart[0]
        _pin2 = group[0], cwork[0, 0], rwork[0, 0], roused[0], rest_int[:1], rest_flt[:1], bwork[0, 0], blist[0]
        _pin3 = broad[0][0, 0], lhead[0], lnext[0], found[0], lifts[0]
        return 0
    # the velocity problem
    nc = _gather(Y0, prm, shapes, grounds, gmu, island, nlist, n_pairs, pos, quat, pdist, pnormal, pcount, ppoints, pseps,
                 members, bound, size, is_static, default_mu, False, 0.0, cint, cflt)
    out[OUT_CONTACTS] = nc
    _rows(Y0, prm, nc, cint, cflt, iw, False, h, size, rj, rw, rdiag, rbias, rbody, island)
    _warm_start(nc, cint, cflt, n_warm, cint[half:], cflt[half:], members, size, cstart, rj, rbody, rlam)
    # contacts sorted by their component (counting sort on the root of their moving body): the bodies joined by
    # this step's contacts. An island's bodies within reach but not touching are apart here: the velocity problem
    # decouples over its components, and each (a tower beside a tower) may be the sticking case
    for m in range(n):
        i = members[m]
        comp[i] = i
        cstart[i] = 0
    for c in range(nc):
        if cint[c, 0] >= 0 and cint[c, 1] >= 0:
            _union(comp, cint[c, 0], cint[c, 1])
    for c in range(nc):
        i = cint[c, 1] if cint[c, 1] >= 0 else cint[c, 0]
        cstart[_find(comp, i)] += 1
    total = 0
    for m in range(n):
        i = members[m]
        if _find(comp, i) == i:
            k = cstart[i]
            cstart[i] = total
            total += k
    for c in range(nc):
        i = cint[c, 1] if cint[c, 1] >= 0 else cint[c, 0]
        r = _find(comp, i)
        order[cstart[r]] = c
        cstart[r] += 1
    lo = 0
    stop = 0  # the contacts of the components not solved exactly, moved to the front of order (one PGS over all)
    for m in range(n):
        i = members[m]
        if _find(comp, i) != i or island[i] != 1:
            continue
        hi = cstart[i]
        if hi == lo:
            continue
        kept = False
        if 3 * (hi - lo) <= A.shape[0]:
            # the steps its bodies still wait before an attempt (≤ 0: now; WAIT_SOLVED, WAIT_HELD)
            least, most = _span(cint, order, lo, hi, wait)
            left = least - 1
            skipped = _span(cint, order, lo, hi, skips[:, 0])[1]
            if left < 0:
                if most == WAIT_HELD:  # dx (per body) is scratch until the projection
                    kept = _held(vel, rj, rw, rbody, rbias, rlam, cflt, cint, size, depth_tol, h, order, lo, hi,
                                 dx)
                if kept:
                    out[OUT_HELD] += 1
                    left = WAIT_HELD
                    skipped = 0
                elif skipped < STICK_SKIPS and _span(cint, order, lo, hi, skips[:, 1])[1] > 0:
                    left = 0  # due again at the next step
                    skipped += 1
                else:
                    skipped = 0
                    kept = _sticking(vel, rj, rw, rbody, rbias, rlam, cflt, order, lo, hi, A, L, vec[0], vec[1],
                                     vec[2], band, cwork[:, 2])
                    if not kept:
                        left = STICK_RETRY - 1
                    else:  # solved from a step solved exactly: its λ is the resting one, without a stop in it
                        left = WAIT_HELD if least == most == WAIT_SOLVED else WAIT_SOLVED
            for c in range(lo, hi):
                for side in range(2):
                    if cint[order[c], side] >= 0:
                        wait[cint[order[c], side]] = left
                        skips[cint[order[c], side], 0] = skipped
        if kept:
            out[OUT_STICK] += 1
            shallow = True  # and began with no point deeper than half the projection's tolerance (a deeper one,
            # left there by the projection, is looked at by it again: a held step may take it toward the tolerance)
            for c in range(lo, hi):
                q = order[c]
                body = cint[q, I_B] if cint[q, I_B] >= 0 else cint[q, I_A]
                shallow = shallow and cflt[q, C_GAP] >= -0.5 * _depth_tol(size, body, depth_tol)
            if shallow:
                flags[i] |= 512  # its root: the component was solved exactly, nothing to project at the start
        else:
            for c in range(lo, hi):
                order[stop] = order[c]
                stop += 1
            out[OUT_PGS] += 1
        lo = hi
    for m in range(n):  # the components of bodies just woken or set back at rest: a converged solve (WOKEN_SWEEPS)
        i = members[m]
        if island[i] == 1 and roused[i]:
            flags[_find(comp, i)] |= 2048
            roused[i] = 0
    if stop > 0:
        body = cint[order[0], I_B] if cint[order[0], I_B] >= 0 else cint[order[0], I_A]
        g = prm[body, GRAVITY:GRAVITY + 3]  # the order's gravity: any order is Gauss–Seidel
        _pgs(vel, rj, rw, rbody, rdiag, rbias, rlam, cflt, cint, comp, flags, order, stop, g[0], g[1], g[2], cwork,
             rwork, bwork, blist)
    for m in range(n):  # which bodies slipped: for the next step's attempts (those solved exactly did not)
        skips[members[m], 1] = 0
    for c in range(stop):
        q = order[c]
        r = 3 * q
        u1, u2 = _row_speed(vel, rj, rbody, r + 1), _row_speed(vel, rj, rbody, r + 2)
        body = cint[q, I_B] if cint[q, I_B] >= 0 else cint[q, I_A]
        if u1 * u1 + u2 * u2 > (SLIP * size[body] / h) ** 2:
            for side in range(2):
                if cint[q, side] >= 0:
                    skips[cint[q, side], 1] = 1
    _impulses(nc, rj, rbody, rlam, cflt)
    # positions: p + h v, q ⊗ exp(h ω_P); a body whose end leaves its free step's by more than the broad phase's
    # growth (swept_bounds) is listed with its box over the new path (dx: lo, hi), for _late_pairs (_left_path)
    reach = broad[5]
    for m in range(n):  # each member's free step's end and growth, which the broad phase screened (bwork: scratch
        i = members[m]  # after the velocity step), for _left_path after the velocity step and after the projection
        for a in range(3):
            bwork[i, a] = Y1[i, P + a]
        bwork[i, 3] = growth(Y0, Y1, i, h)
    for m in range(n):
        i = members[m]
        if island[i] != 1:
            continue
        qw, qx, qy, qz = normalise(Y0[i, Q], Y0[i, Q + 1], Y0[i, Q + 2], Y0[i, Q + 3])
        R = matrix(qw, qx, qy, qz)
        wp0 = R[0] * vel[i, 3] + R[3] * vel[i, 4] + R[6] * vel[i, 5]
        wp1 = R[1] * vel[i, 3] + R[4] * vel[i, 4] + R[7] * vel[i, 5]
        wp2 = R[2] * vel[i, 3] + R[5] * vel[i, 4] + R[8] * vel[i, 5]
        for a in range(3):
            Y1[i, P + a] = Y0[i, P + a] + h * vel[i, a]
            Y1[i, V + a] = vel[i, a]
        Y1[i, W], Y1[i, W + 1], Y1[i, W + 2] = wp0, wp1, wp2
        ew, ex, ey, ez = exp_map(h * wp0, h * wp1, h * wp2)
        q = qmul(qw, qx, qy, qz, ew, ex, ey, ez)
        Y1[i, Q], Y1[i, Q + 1], Y1[i, Q + 2], Y1[i, Q + 3] = normalise(q[0], q[1], q[2], q[3])
    n_left = _left_path(Y0, Y1, island, members, flags, reach, bwork, dx, blist)
    if n_left:
        n_pairs = _late_pairs(Y0, Y1, grounds, island, stopped, is_static, members, nlist, n_pairs, comp, flags, broad,
                              h, dx, blist, n_left, lhead, lnext, found, out)
    # the projection, on the second half of the contact and row scratch (the first keeps the velocity step's),
    # looking at the pairs within their reach over the step as solved. A body of a component solved exactly from
    # no point deeper than half the tolerance that moved less than PROJECT_TOL × its size over the step is held
    # from the start (island 3): its points' gaps were closed exactly (linear in the step, and it barely turned)
    for m in range(n):
        i = members[m]
        if island[i] == 1 and flags[_find(comp, i)] & 512:
            if h * max(_speed(Y0, i, spin_reach), _speed(Y1, i, spin_reach)) <= _depth_tol(size, i, depth_tol):
                island[i] = 3
    _bounds(Y0, Y1, nlist, 0, n_pairs, is_static, spin_reach, size, h, bound, members, dx[:, 0], deflect, 0.0)
    deepest = 0.0
    n_stopped = 0
    n_step = nc  # the velocity step's contacts (_no_gain's); the projection's stopped points are added after them
    for again in range(2):
        deepest = max(deepest, _project(Y1, prm, shapes, grounds, gmu, island, nlist, n_pairs, pos, quat, rot, pdist,
                                        pnormal, pcount, ppoints, pseps, members, bound, size, is_static, default_mu,
                                        depth_tol, h, iw, dx, vel, cint[half:], cflt[half:], rj[3 * half:],
                                        rw[3 * half:], rdiag[3 * half:], rbias[3 * half:], rlam[3 * half:],
                                        rbody[3 * half:], order, out, comp, flags, rwork[3 * half:]))
        if out[OUT_STOPPED] > 0:  # its impulses to their pairs' contacts, before another projection's replace them
            nc = _attribute(nc, cint, cflt, int(out[OUT_STOPPED]), cint[half:], cflt[half:], members, cstart, half)
            n_stopped += int(out[OUT_STOPPED])
            out[OUT_STOPPED] = 0
        if again == 1:
            break
        # a body the projection moved off the path the broad phase screened it on (by more than its growth, as
        # after the velocity step) is screened again on its path to where it ends: a pair so found (and a body
        # outside the islands it meets) is projected again, the bodies already at their tolerance held
        n_left = _left_path(Y0, Y1, island, members, flags, reach, bwork, dx, blist)
        late = out[OUT_LATE]
        if n_left:
            n_pairs = _late_pairs(Y0, Y1, grounds, island, stopped, is_static, members, nlist, n_pairs, comp, flags,
                                  broad, h, dx, blist, n_left, lhead, lnext, found, out)
        if out[OUT_LATE] == late:
            break
        _bounds(Y0, Y1, nlist, 0, n_pairs, is_static, spin_reach, size, h, bound, members, dx[:, 0], deflect, 0.0)
    out[OUT_DEPTH] = deepest
    out[OUT_STOPPED] = n_stopped
    out[OUT_CONTACTS] = nc
    _no_gain(Y0, Y1, prm, wr, bare, modes, members, island, comp, n_step, cint, cflt, size, depth_tol, dx, flags,
             out, lifts)
    # sleeping: a component of the step's contacts whose bodies were and stay slower than the sleep speed (at
    # rest, SLEEP_SPEED: one step), or with a sleep speed raised above rest stayed within sleep_speed × SLEEP_STEPS
    # steps of where they began SLEEP_STEPS steps ago (anchor: that pose), is locked (its island's other bodies are
    # beyond the step's reach: a sleeping body is woken by one within it)
    need = 1 if sleep_speed <= SLEEP_SPEED else SLEEP_STEPS
    for m in range(n):
        i = members[m]
        if island[i] != 1:  # out of the islands (or asleep): no run at rest, no wait for the exact solve
            still[i] = 0
            wait[i] = 0
            skips[i, 0] = skips[i, 1] = 0
            roused[i] = 0
            continue
        at_rest = _at_rest(Y0, Y1, i, still, anchor, need, sleep_speed, h, spin_reach)
        r = _find(comp, i)
        if flags[r] & 128:  # set back where it began by _no_gain: a rest imposed, not found; counted apart (< 0)
            still[i] = min(still[i], 0) - 1
            roused[i] = 2  # its next step's Gauss–Seidel solve converges (WOKEN_SWEEPS)
        elif at_rest:
            still[i] = max(still[i], 0) + 1
        else:
            still[i] = 0
        if still[i] < need and -still[i] < FROZEN_STEPS:
            flags[r] |= 16
    if sleeping:
        for m in range(n):
            i = members[m]
            if island[i] != 1:
                continue
            r = _find(comp, i)
            if not flags[r] & 16:
                asleep[i] = 1
                still[i] = 0  # woken, it begins a new run at rest and is tried for the exact solve at once
                wait[i] = 0
                skips[i, 0] = skips[i, 1] = 0
                group[i] = r
                out[OUT_SLEPT] += 1
                for j in range(6):
                    Y1[i, V + j] = 0.0
                for j in range(STATE_WIDTH):
                    saved[i, j] = Y1[i, j]
    _pin = Y0[0, 0], Y1[0, 0], prm[0, 0], wr[0, 0], bare[0, 0], modes[0], saved[0, 0], cand[0, 0], A[0, 0], L[0, 0], vec[0, 0], order[0], cstart[0]
    _pin2 = group[0], cwork[0, 0], rwork[0, 0], roused[0], rest_int[:1], rest_flt[:1], bwork[0, 0], blist[0]
    _pin3 = broad[0][0, 0], lhead[0], lnext[0], found[0], lifts[0]
    return 0
