"""Persistent contact with two ground half-spaces at once: resting in a corner or a groove, sliding along its crease.

A body in persistent contact with its ground A (``ContactSolver.ground_of``) that also touches a
second half-space B (``ContactSolver.other_ground``, its touching features
``ContactSolver.other_tracked``), or a static box's face beside a half-space it rests on (while its
points on B lie within the face), is held by both together: one acceleration-level problem on
the contact rows of both sets of points, each point with its own half-space's normal, and one
tangent basis for all of them — t1 along the crease n_A × n_B, t2 = n × t1 — so that a slide
along the crease is the same direction (±1, 0) at every point and the Coulomb law of
impacts.pgs applies unchanged (friction −μ f_n along the slip while sliding, on the cone while
sticking; the normal forces ≥ 0 and complementary). The compiled pieces are the ones the
one-ground contact uses (persistent.accelerations, impacts.pgs, persistent.add_contact_wrench,
persistent.project); only the rows are built here, with numpy.

After the step the body is projected onto both contacts: onto each in turn (persistent.project, the least-energy
correction in the mass metric) to a fixed point, which is the joint projection; where that has not come within
ALTERNATE_ROUNDS (the two contacts' rows nearly parallel in the mass metric), onto both at once
(:func:`_project_jointly`, with numpy).

Transitions: a half-space whose normal forces all vanish while its points move away is let go
(the body goes on with the other, or flies); a slide along the crease whose slip reverses in a
step stops there (the stop is not located inside the step, unlike on one half-space: first
order in time), and a feature that went below either half-space in the step is taken into its contact at the
step's end (the projection stops it there: an inelastic landing, not located). Limits (docs/contact.md): at most
MAX_POINTS contact points over both (a sphere
or a capsule in a groove); with more (a box with a face on each side) the body is held on its
first half-space alone and projected onto both after each step (:func:`project_second`,
``ContactSolver.other_projected``: first order in the second one's force, without its friction).
The smaller of the two pairs' friction coefficients when they differ; a third half-space or static
shape the body reaches in a step is taken in at the step's end (projected onto with the two, its
normal velocity removed: an inelastic impact, not located, first order) but not held; and no
located landing of another feature.
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import layout as L
from ..kernels.contact.impacts import _B, _LAM, _row_velocity, kinetic_energy_row, pgs
from ..kernels.contact.layout import MAX_POINTS, NORMAL, PERSISTENT
from ..kernels.contact.persistent import (SLIDE, START_SLIDE_ACCELERATION, STICK, accelerations, add_contact_wrench,
                                          project)
from ..kernels.contact.shapes import MAX_FEATURES, feature_gaps, feature_points
from ..kernels.contact.stage import hold_on_two_planes_in_row, two_plane_rows
from ..quaternion import cross3, quat_from_rotation_vector, quat_multiply, quat_rotate
from .events import ContactEvent

__all__ = ["touching_other", "hold", "end_of_step", "project_second", "take_out_of_pressed", "take_out_of_static",
           "crease", "start_if_touching"]

#: Projections onto each contact in turn: at most this many rounds before the joint projection takes over (one or
#: two reach a fixed point when the contacts' rows are orthogonal in the body's mass metric).
ALTERNATE_ROUNDS = 8
#: The joint projection onto the contacts: at most this many Gauss–Newton rounds (each closes the gaps to second
#: order in the correction; two or three reach round-off).
PROJECTION_ROUNDS = 8
#: A body pressed on walls it is not held on is taken out of at most this many of them at a step's end (a bin's
#: corner: two).
PRESSED_WALLS = 3


def crease(solver, i: int) -> np.ndarray:
    """The unit direction n_A × n_B of the crease between body i's two half-spaces (world axes)."""
    n_a = solver.grounds[int(solver.ground_of[i]), NORMAL:NORMAL + 3]
    n_b = solver.grounds[int(solver.other_ground[i]), NORMAL:NORMAL + 3]
    t = cross3(n_a, n_b)
    return t / np.linalg.norm(t)


def touching_other(solver, sim, y: np.ndarray, i: int, speed_limit: float, gap_limit: float,
                   rows: tuple[int, ...] | None = None) -> int:
    """A half-space other than body i's ground (or one of the plane ``rows`` given: a static box's face) that it
    touches (gap ≤ ``gap_limit``; on a face, its contact points within it) without moving away from it (contact
    points slower than ``speed_limit``) and that is not parallel to its ground; -1 if none. Sets
    :attr:`other_tracked` to the touching features when one is found."""
    j = int(solver.ground_of[i])
    prm, shape = sim._prm[i], solver.shapes[i]
    gaps = np.empty(MAX_FEATURES)
    for jj in range(len(solver.half_spaces)) if rows is None else rows:
        if jj == j or abs(abs(solver.grounds[jj, NORMAL:NORMAL + 3] @ solver.grounds[j, NORMAL:NORMAL + 3]) - 1.0) < 1e-12:
            continue
        count = feature_gaps(y, prm, shape, solver.grounds[jj], gaps)
        mask = sum(1 << k for k in range(count) if gaps[k] <= gap_limit)
        if not mask:
            continue
        points, pgaps, owners = np.empty((MAX_POINTS, 3)), np.empty(MAX_POINTS), np.zeros(MAX_POINTS, dtype=np.int64)
        n = feature_points(y, prm, shape, solver.grounds[jj], mask, points, pgaps, owners)
        if jj >= len(solver.half_spaces) and not solver.statics.within_face(jj, points[:n]):
            continue
        velocity = _point_velocities(sim, y, i, points[:n])
        if n and np.max(velocity @ solver.grounds[jj, NORMAL:NORMAL + 3]) <= speed_limit:
            solver.other_tracked[i] = mask
            solver.other_projected[i] = False
            return jj
    return -1


def _point_velocities(sim, y: np.ndarray, i: int, points: np.ndarray) -> np.ndarray:
    """(k, 3) world velocities of body points ``points`` (world positions) of body i at state row y."""
    w_W = quat_rotate(y[L.Q:L.Q + 4], y[L.W:L.W + 3])
    return y[L.V:L.V + 3] + cross3(w_W, points - y[L.P:L.P + 3])


def _jacobian(y: np.ndarray, points: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(k, 6) rows of body state y: each row's direction (world) and its angular part r × direction in principal
    axes, r from the centre of mass to its point ``points`` (k, 3, world)."""
    q = y[L.Q:L.Q + 4]
    angular_P = quat_rotate(q * np.array([1.0, -1.0, -1.0, -1.0]), cross3(points - y[L.P:L.P + 3], directions))
    return np.concatenate((directions, angular_P), axis=1)


def _inverse_mass(prm: np.ndarray) -> np.ndarray:
    """The body's inverse mass metric, diagonal in (world translation, principal rotation): (6,)."""
    return np.concatenate(([prm[L.INV_MASS]] * 3, prm[L.INV_INERTIA:L.INV_INERTIA + 3]))


def _tangential_acceleration(work: np.ndarray, rows: int, count: int) -> float:
    """Σ over the points of their acceleration along the crease (t1 rows) after the solve in ``work``."""
    return sum(_row_velocity(work, rows, 3 * c + 1) for c in range(count))


def hold(solver, sim, y: np.ndarray, i: int, w: np.ndarray, t: float, lift_off_speed: float,
         touching_gap: float, slip_tolerance: float, stages: bool = True) -> bool:
    """Add the force holding body i on both its half-spaces into the wrench row w (in place).

    A half-space it no longer presses on (all its normal forces zero, or its points moving away
    or lifted) is let go: the one-ground hold takes over (:meth:`ContactSolver._hold`). Returns
    False if the body leaves both (lift-off: flight). With ``stages``, a body stepped by a method
    whose stages evaluate the right-hand side (rk4, euler, reference) on two exact planes (half-spaces
    or a static box's faces) gets instead its contact in the row, found at every stage by this same law
    (kernels/contact/stage.py; the row with the force found here kept in ``ContactSolver._held_rows``),
    as on one plane; not a cylinder whose rim point on a plane may swing round the rim within the step
    (``ContactSolver.stages_on_two_planes``).
    """

    prm = sim._prm[i]
    name = solver.names[i]
    j_a, j_b = int(solver.ground_of[i]), int(solver.other_ground[i])
    points, gaps, on_b = np.empty((MAX_POINTS, 3)), np.empty(MAX_POINTS), np.empty(MAX_POINTS, dtype=np.int64)
    bias, rdot, anchors = np.empty(MAX_POINTS), np.empty((MAX_POINTS, 3)), np.empty((MAX_POINTS, 3))
    work, d = solver._work, solver._d
    count = two_plane_rows(y, prm, solver.shapes[i], solver.grounds[j_a], int(solver.tracked[i]), solver.grounds[j_b],
                           int(solver.other_tracked[i]), points, gaps, on_b, bias, rdot, anchors,
                           np.empty((MAX_POINTS, 3)), work)  # the same rows as at every stage (stage.py)
    if count < 0:  # more points than the rows hold: held on ground_of, projected onto both (counted)
        solver.counts["two_ground_overflow"] += 1
        solver.other_projected[i] = True
        return solver._hold(sim, y, i, w, t, stages=stages)
    which = np.where(on_b[:count] == 1, j_b, j_a)  # the plane of each point
    gaps = gaps[:count]
    if j_b >= len(solver.half_spaces) and not solver.statics.within_face(j_b, points[:count][which == j_b]):
        # off the static box's face it was held on (past its edge): let go, its contact with that box found afresh
        solver.events.append(ContactEvent(t, name, j_b, "lift-off", 0.0, 0.0))
        solver.other_ground[i] = -1
        return solver._hold(sim, y, i, w, t, stages=stages)
    rows = 3 * count
    slip = sum(work[3 * c + 1, _B] for c in range(count)) / count  # along the crease
    velocities = work[0:rows:3, _B].copy()  # normal velocities of the points
    accelerations(y, prm, w, count, rows, points, bias, rdot, work, d)
    mu = min(solver.friction_of(i, j_a), solver.friction_of(i, j_b))
    work[:rows, _LAM] = 0.0
    sx = 0.0
    sliding = mu == 0.0
    if not sliding and abs(slip) > slip_tolerance:
        sliding, sx = True, math.copysign(1.0, slip)
    pgs(work, count, mu, sx, 0.0)
    if not sliding:  # not slipping: does the cone hold it? (a groove tilted steeper than its friction angle)
        along = _tangential_acceleration(work, rows, count)
        if abs(along) > START_SLIDE_ACCELERATION * count:
            work[:rows, _LAM] = 0.0
            pgs(work, count, 0.0, 0.0, 0.0)
            direction = math.copysign(1.0, _tangential_acceleration(work, rows, count))
            work[:rows, _LAM] = 0.0
            pgs(work, count, mu, direction, 0.0)
            if _tangential_acceleration(work, rows, count) * direction > START_SLIDE_ACCELERATION * count:
                sliding, sx = True, direction
            else:
                work[:rows, _LAM] = 0.0
                pgs(work, count, mu, 0.0, 0.0)
    normal = work[0:rows:3, _LAM]
    for j, other in ((j_b, j_a), (j_a, j_b)):
        on = which == j
        leaving = (not on.any() or normal[on].sum() <= 0.0 or velocities[on].max() > lift_off_speed
                   or gaps[on].min() > touching_gap)
        if leaving:  # let go of half-space j; the other one alone from here
            speed = float(velocities[on].max()) if on.any() else 0.0
            solver.events.append(ContactEvent(t, name, j, "lift-off", speed, speed))
            if j == j_a:
                solver.ground_of[i], solver.tracked[i] = j_b, solver.other_tracked[i]
            elif j >= len(solver.half_spaces):  # a static box's face: not looked at again in this step (as pressed)
                solver._static_skipped[i] = int(solver.statics.row_owner[j])
            solver.other_ground[i] = -1
            return solver._hold(sim, y, i, w, t, stages=stages)
    solver.sliding[i] = sliding
    solver.slide_direction[i] = sx, 0.0
    solver.pressed[i] = int(solver.tracked[i])
    solver._bare_rows[i] = w
    add_contact_wrench(w, y, prm, count, points, anchors, work)
    if stages and solver.stages_on_two_planes(sim, y, i):
        solver._held_rows[i] = w
        hold_on_two_planes_in_row(w, solver._bare_rows[i], solver.shapes[i], solver.grounds[j_a],
                                  int(solver.tracked[i]), solver.grounds[j_b], int(solver.other_tracked[i]), mu,
                                  SLIDE if sliding else STICK, sx)
        solver._staged[i] = 1
    return True


def end_of_step(solver, sim, i: int, end: np.ndarray, t: float, h: float, lift_off_speed: float) -> np.ndarray:
    """End of a step of body i held on two half-spaces: a feature that went below either of them in the step is
    taken into its contact (a landing at the step's end, inelastic, not located: first order), a slide along the
    crease that reversed stops (``stick`` at the step's end), then the body is projected onto both contacts, and
    onto a third half-space or static shape it reached in the step (:func:`_third`; an ``impact`` there, listed
    if it came at more than ``lift_off_speed``)."""

    end = end.copy()
    gaps = np.empty(MAX_FEATURES)
    _take_in(solver, sim, i, end, int(solver.ground_of[i]), solver.tracked, gaps)
    _take_in(solver, sim, i, end, int(solver.other_ground[i]), solver.other_tracked, gaps)
    sticking = not solver.sliding[i]
    if solver.sliding[i] and solver.slide_direction[i][0] != 0.0:
        if end[L.V:L.V + 3] @ crease(solver, i) * solver.slide_direction[i][0] <= 0.0:
            solver.sliding[i] = False
            sticking = True
            solver.events.append(ContactEvent(t + h, solver.names[i], int(solver.ground_of[i]), "stick"))
    third = _third(solver, sim, i, end)
    before = end.copy()
    _project_all(solver, sim, i, end, sticking, () if third is None else ((solver.grounds[third[0]], third[1]),))
    if third is not None and third[2] < -lift_off_speed:
        _struck_third(solver, sim, i, before, end, third, t + h)
    return end


def _third(solver, sim, i: int, y: np.ndarray) -> tuple[int, int, float, int] | None:
    """A half-space or static shape other than body i's two (``ContactSolver._other_gap``; one it was pressed on
    earlier in the step too) that it reached at y: (its plane row, the features below it as bits, their lowest
    normal speed, m/s, their contact points), or None. Also where those features move out of it (a capsule
    sliding away from a wall along the crease of the floor and another wall, its raised end swinging down into the
    first one): it is taken out of it all the same."""
    gap, which = solver._other_gap(sim, y, i, pressed=True)
    if gap >= 0.0 or which < 0:
        return None
    gaps = np.empty(MAX_FEATURES)
    count = feature_gaps(y, sim._prm[i], solver.shapes[i], solver.grounds[which], gaps)
    mask = sum(1 << k for k in range(count) if gaps[k] <= 0.0)
    speed, points = _lowest_speed(solver, sim, y, i, solver.grounds[which], mask) if mask else (0.0, 0)
    return (which, mask, speed, points) if mask else None


def _lowest_speed(solver, sim, y: np.ndarray, i: int, plane: np.ndarray, mask: int) -> tuple[float, int]:
    """The lowest normal velocity (m/s, positive away) of body i's features ``mask`` at y against the plane row
    ``plane``, and their number of contact points."""
    points, gaps, owners = np.empty((MAX_POINTS, 3)), np.empty(MAX_POINTS), np.zeros(MAX_POINTS, dtype=np.int64)
    n = feature_points(y, sim._prm[i], solver.shapes[i], plane, mask, points, gaps, owners)
    return float((_point_velocities(sim, y, i, points[:n]) @ plane[NORMAL:NORMAL + 3]).min()), n


def _struck_third(solver, sim, i: int, before: np.ndarray, end: np.ndarray, third: tuple[int, int, float, int],
                  t: float, counted: str = "third_half_space") -> None:
    """The event of body i taken onto a third half-space or static shape at t (an inelastic impact, not located),
    from state row ``before`` to ``end``: its velocity jump (that of the whole projection, onto the two as well),
    its impulse m Δv·n along the third's normal n, the kinetic energies."""
    j, mask, speed, points = third
    prm = sim._prm[i]
    n = solver.grounds[j, NORMAL:NORMAL + 3]
    impulse = max(float(prm[L.MASS] * (end[L.V:L.V + 3] - before[L.V:L.V + 3]) @ n), 0.0)
    jump = solver._jump(sim, i, before, end, points, 0.0, 0.0)
    solver.counts[counted] += 1
    after = _lowest_speed(solver, sim, end, i, solver.grounds[j], mask)[0]
    solver.events.append(ContactEvent(t, solver.names[i], j, "impact", speed, after, impulse,
                                      kinetic_energy_row(before, prm), kinetic_energy_row(end, prm), *jump))


def project_second(solver, sim, i: int, end: np.ndarray, touching_gap: float) -> None:
    """Body i, held on its ground alone this step (too many contact points for both), at the step's end
    ``end`` (in place): projected onto both half-spaces if it still reaches the second one, else that
    one is let go."""
    gaps = np.empty(MAX_FEATURES)
    count = _take_in(solver, sim, i, end, int(solver.other_ground[i]), solver.other_tracked, gaps)
    if not count or gaps[:count].min() > touching_gap:
        solver.other_ground[i] = -1
        solver.other_projected[i] = False
        return
    _project_all(solver, sim, i, end, not solver.sliding[i])


def take_out_of_pressed(solver, sim, i: int, end: np.ndarray, t: float, sticking: bool,
                        lift_off_speed: float) -> None:
    """Body i, held on its ground (and projected onto a second one, :func:`project_second`) and pressed in this step
    on a static shape it is not held on, or on the walls it was struck against (left out of the step's view from
    then: ``ContactSolver._static_skipped``, ``_press_aside``), at the step's end ``end`` (in place): if it went
    into the nearest of them (a spinning body turning its other points in), it is taken out of it (:func:`_take_out`:
    an inelastic impact at the step's end, not located: first order; an ``impact`` event if it came at more than
    ``lift_off_speed``). Then out of the next one it is still in, if any (a ball spun into a bin's corner, pressed
    on both walls), projected onto the first too: up to PRESSED_WALLS of them."""
    taken_out: list[tuple[np.ndarray, int]] = []
    seen: set[int] = set()
    for _ in range(PRESSED_WALLS):
        gap, which = solver._other_gap(sim, end, i, pressed=True)
        if gap >= 0.0 or which < 0 or which in seen:
            return
        taken = _take_out(solver, sim, i, end, solver.grounds[which], sticking, tuple(taken_out))
        if taken is None:
            return
        before, mask, speed, points = taken
        if speed < -lift_off_speed:
            _struck_third(solver, sim, i, before, end, (which, mask, speed, points), t, "static_taken_out")
        else:
            solver.counts["static_taken_out"] += 1
        seen.add(which)
        taken_out.append((solver.grounds[which], mask))


def take_out_of_static(solver, sim, i: int, end: np.ndarray, sticking: bool) -> None:
    """Body i, held on a static shape's tangent row (ContactSolver._other_gap looks at no static shape for it: one
    would write that row), at the step's end ``end`` (in place): if it went into another static shape (a box
    lying across a bin's corner on one wall's top edge, pushed into the other's), it is taken out of it through the
    tangent plane of their contact (:func:`_take_out`, first order; counted in ``static_taken_out``, not listed as
    an event: that plane is not a row of the solver's)."""
    gap, plane = solver._other_static(sim, end, i)
    if gap < 0.0 and _take_out(solver, sim, i, end, plane, sticking) is not None:
        solver.counts["static_taken_out"] += 1


def _take_out(solver, sim, i: int, end: np.ndarray, plane: np.ndarray, sticking: bool,
              earlier: tuple[tuple[np.ndarray, int], ...] = ()):
    """Body i's step end ``end`` (in place), its features below the plane row ``plane``, projected onto its ground
    (and second one), the planes it was taken out of ``earlier`` (rows, the features on each as bits) and that
    plane together, its normal velocities into it removed; repeated while the projection turns another feature in
    (a can's other rim, as it lifts one). (its state before, the features taken in as bits, their lowest normal
    speed before, m/s, their contact points), or None if no feature is below."""
    gaps = np.empty(MAX_FEATURES)
    count = feature_gaps(end, sim._prm[i], solver.shapes[i], plane, gaps)
    mask = sum(1 << k for k in range(count) if gaps[k] <= 0.0)
    if not mask:
        return None
    speed, points = _lowest_speed(solver, sim, end, i, plane, mask)
    before = end.copy()
    for _ in range(count):
        _project_all(solver, sim, i, end, sticking, (*earlier, (plane, mask)), second=solver.other_ground[i] >= 0)
        feature_gaps(end, sim._prm[i], solver.shapes[i], plane, gaps)
        below = sum(1 << k for k in range(count) if gaps[k] < 0.0)
        if not below & ~mask:
            break
        mask |= below
    return before, mask, speed, points


def _take_in(solver, sim, i: int, end: np.ndarray, j: int, tracked: np.ndarray, gaps: np.ndarray) -> int:
    """Body i's features on or below half-space j at ``end`` added to its feature mask ``tracked[i]`` (taken into
    that contact); returns the features' count, their gaps in ``gaps``."""
    count = feature_gaps(end, sim._prm[i], solver.shapes[i], solver.grounds[j], gaps)
    tracked[i] = int(tracked[i]) | sum(1 << k for k in range(count) if gaps[k] <= 0.0)
    return count


def _project_all(solver, sim, i: int, end: np.ndarray, sticking: bool,
                 others: tuple[tuple[np.ndarray, int], ...] = (), second: bool = True) -> None:
    """Project body i's row ``end`` (in place) onto both its half-spaces (its ground alone without ``second``), and
    onto each of ``others`` (plane rows, the features on each as bits) too, its normal velocities alone removed
    there: onto each in turn to a fixed point (:func:`_alternate`), or where that is slow, onto all at once
    (:func:`_project_jointly`)."""
    planes = [(solver.grounds[int(solver.ground_of[i])], int(solver.tracked[i]), sticking)]
    if second:
        planes.append((solver.grounds[int(solver.other_ground[i])], int(solver.other_tracked[i]), sticking))
    planes += [(plane, mask, False) for plane, mask in others]
    if not _alternate(solver, sim, i, end, planes):
        _project_jointly(solver, sim, i, end, planes)


def _alternate(solver, sim, i: int, end: np.ndarray, planes: list[tuple[np.ndarray, int, bool]]) -> bool:
    """Body i's row ``end`` (in place) projected onto each plane of ``planes`` in turn (persistent.project), round
    after round, at most ALTERNATE_ROUNDS: whether a round left it unchanged to round-off (a fixed point: the joint
    projection, reached in one or two rounds when the planes' rows are orthogonal in the mass metric)."""
    prm, shape, work = sim._prm[i], solver.shapes[i], solver._work
    points, gaps, owners = solver._points, solver._gaps, solver._owners
    scale = 4.0 * np.finfo(float).eps * max(1.0, float(np.abs(end[:L.STATE_WIDTH]).max()))
    for _ in range(ALTERNATE_ROUNDS):
        before = end[:L.STATE_WIDTH].copy()
        for plane, mask, stick in planes:
            project(end, prm, shape, plane, mask, stick, points, gaps, owners, work)
        if np.abs(end[:L.STATE_WIDTH] - before).max() <= scale:
            return True
    return False


def _project_jointly(solver, sim, i: int, end: np.ndarray, planes: list[tuple[np.ndarray, int, bool]]) -> None:
    """Body i's row ``end`` (in place) put onto every plane of ``planes`` (a plane row, the features on it as bits,
    whether sticking there) together, as persistent.project puts it onto one: positions by the smallest
    displacement in the body's mass metric that closes the gaps of all their contact points at once (Gauss–Newton,
    to round-off: the joint projection, which projections onto one plane after the other reach only in the limit,
    slowly when the planes' rows are nearly parallel in that metric), then velocities by the impulse of least
    kinetic energy that removes the points' normal velocities and, on a sticking plane, their tangential ones;
    sticking points that span the body (rank 6, three or more points) leave it exactly at rest."""
    inverse = _inverse_mass(sim._prm[i])
    tolerance = 4.0 * np.finfo(float).eps * max(1.0, float(np.abs(end[L.P:L.P + 3]).max()))
    for _ in range(PROJECTION_ROUNDS):
        J, gaps, _ = _plane_rows(solver, sim, i, end, planes, False)
        if not len(gaps) or np.abs(gaps).max() <= tolerance:
            break
        step = inverse * (J.T @ np.linalg.lstsq((J * inverse) @ J.T, -gaps, rcond=None)[0])
        end[L.P:L.P + 3] += step[:3]
        q = quat_multiply(end[L.Q:L.Q + 4], quat_from_rotation_vector(step[3:]))  # Δθ in principal axes
        end[L.Q:L.Q + 4] = q / np.linalg.norm(q)
    J, _, stuck = _plane_rows(solver, sim, i, end, planes, True)
    if not len(J):
        return
    if stuck.sum() >= 9 and np.linalg.matrix_rank(J[stuck]) == 6:  # three or more sticking points spanning it
        end[L.V:L.W + 3] = 0.0
        return
    u = np.concatenate((end[L.V:L.V + 3], end[L.W:L.W + 3]))
    u += inverse * (J.T @ np.linalg.lstsq((J * inverse) @ J.T, -(J @ u), rcond=None)[0])
    end[L.V:L.V + 3], end[L.W:L.W + 3] = u[:3], u[3:]


def _plane_rows(solver, sim, i: int, y: np.ndarray, planes: list[tuple[np.ndarray, int, bool]], tangents: bool):
    """The contact rows of body i at y on ``planes`` (_project_jointly): (J (rows, 6): each row's direction and its
    angular part in principal axes, the gaps (m) of the normal rows, which rows are a sticking plane's), a normal
    row per contact point, and with ``tangents`` two tangent rows per point of a sticking plane."""
    prm, shape = sim._prm[i], solver.shapes[i]
    points, gaps, owners = solver._points, solver._gaps, solver._owners
    directions, at, normal_gaps, stuck = [], [], [], []
    for plane, mask, sticking in planes:
        n = plane[NORMAL:NORMAL + 3]
        count = feature_points(y, prm, shape, plane, mask, points, gaps, owners)
        normal_gaps.append(gaps[:count].copy())
        basis = n[None, :]
        if tangents and sticking:
            t1 = cross3(n, np.eye(3)[int(np.argmin(np.abs(n)))])
            t1 /= np.linalg.norm(t1)
            basis = np.array([n, t1, cross3(n, t1)])
        directions.append(np.tile(basis, (count, 1)))
        at.append(np.repeat(points[:count], len(basis), axis=0))  # copied: the scratch is filled again next plane
        stuck.append(np.full(count * len(basis), sticking))
    J = _jacobian(y, np.concatenate(at), np.concatenate(directions))
    return J, np.concatenate(normal_gaps), np.concatenate(stuck)


def start_if_touching(solver, sim, y: np.ndarray, i: int, speed_limit: float, gap_limit: float) -> None:
    """Hold body i, in persistent contact with its ground, on a second half-space it touches too (if any)."""
    if solver.modes[i] == PERSISTENT:
        solver.other_ground[i] = touching_other(solver, sim, y, i, speed_limit, gap_limit)
