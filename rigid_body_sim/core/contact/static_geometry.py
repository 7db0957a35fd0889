"""Static bodies with a collision shape as contact geometry: the gap to them, and the planes the solver holds on.

A body whose motion is ``static`` and that has a collision shape is an obstacle for the moving
bodies, like a ground half-space, in a scene with contact (a ``ground`` key, possibly ``[]``).
The solver (solver.py) works on *planes*: rows n·x ≥ offset (layout.py's ground rows). This
module gives it, on top of the scene's half-spaces (rows 0 … G − 1):

* **face rows**: the six faces of every static box, each an exact plane (outward normal,
  offset), for contact that stays *within* the face;
* **tangent rows**: one per moving body, rewritten from the narrow phase
  (kernels/contact/pairs.py) where the body meets a static shape elsewhere (a static sphere,
  cylinder or capsule, a box's edge or corner, or a face the body overhangs): the plane through
  the contact point on the static surface, normal to the narrow phase's normal.

The materials of the rows (the pair material of the body with the row's half-space or static
shape) are a table (n, G + 6 × static boxes) over the half-spaces and the face rows, and one
number per body for its tangent row (``tangent_restitution``, ``tangent_friction``, (n,)):
linear in the bodies.

In flight the gap is the **signed distance** of the narrow phase, min over the static shapes
(continuous along the step map, so an impact is located to round-off as on the ground); at the
impact the solver takes the plane row of that contact (:meth:`StaticGeometry.plane_for`) and
applies the ground's impact law there: the static body has infinite mass, the contact normal is
the narrow phase's, and the contact points are the body's lowest features against that plane
(exact for a sphere, and for any shape landing on a face within it).

Persistent contact on a face row is the ground's, exact (held and projected on the face's
plane, the force found at every stage by the methods that do so on the ground) while the contact
points stay within the face. On a tangent row (a curved static
support, an edge, a corner, or a face the body has slid over the rim of) the row is refreshed
from the narrow phase before each step, against the static shape the row is for, and the body is held on
that plane (where another static shape has come nearer than that one, by more than the body's feature band, it
lifts off: its held features are not that shape's, and its flight meets whichever it reaches): first order in time,
not checked against a closed form, and counted (``ContactSolver.counts["static_tangent"]``, per
body-step).
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import layout as L
from ..kernels.contact.layout import (
    DIMS,
    GROUND_WIDTH,
    KIND,
    MAX_POINTS,
    NORMAL,
    OFFSET,
    SHAPE_BOX,
    SHAPE_CAPSULE,
    SHAPE_CYLINDER,
    SHAPE_NONE,
    SHAPE_SPHERE,
)
from ..kernels.contact.pairs import FACE_ALIGNMENT, MAX_PAIR_POINTS, apart_bounds, pair_contacts
from ..kernels.contact.shapes import body_points
from ..quaternion import quat_conjugate, quat_multiply, quat_to_matrix
from .materials import pair_material

__all__ = ["StaticGeometry", "static_shapes", "bounding_radius", "check_not_inside_statics"]

#: A contact point this far (× the face's size) outside a static box face's rectangle is off the face.
FACE_MARGIN = 1e-9


def static_shapes(shapes: np.ndarray, motions) -> np.ndarray:
    """Indices of the bodies that are static geometry: motion ``static`` and a collision shape."""
    return np.array([i for i in range(len(motions)) if motions[i] == "static" and shapes[i, KIND] != SHAPE_NONE],
                    dtype=np.int64)


def bounding_radius(shape: np.ndarray) -> float:
    """Radius (m) of the smallest sphere about the shape's centre that holds it."""
    kind, d = int(shape[KIND]), shape[DIMS:DIMS + 3]
    if kind == SHAPE_SPHERE:
        return float(d[0])
    if kind == SHAPE_BOX:
        return float(math.sqrt(d @ d))
    if kind == SHAPE_CYLINDER:
        return float(math.hypot(d[0], d[1]))
    if kind == SHAPE_CAPSULE:
        return float(d[0] + d[1])
    return 0.0


def shape_poses(rows: np.ndarray, q_PB: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centres (k, 3), q_WB (k, 4)) of shapes declared in frame B of bodies at state rows ``rows`` (k, ≥ 7)."""
    return rows[:, L.P:L.P + 3].copy(), quat_multiply(rows[:, L.Q:L.Q + 4], q_PB)


def check_not_inside_statics(check, model, state, shapes: np.ndarray) -> None:
    """Refuse a moving body whose shape starts inside a static body's shape, naming both and the depth.

    A depth up to 1e-9 × the pair's size (the narrow phase's round-off for shapes placed touching)
    is let through; ``check`` is scene.py's checker, ``model`` and ``state`` the scene's bodies.
    """
    statics = static_shapes(shapes, model.motions)
    moving = [i for i in range(model.count) if model.motions[i] == "free" and shapes[i, KIND] != SHAPE_NONE]
    if not statics.size or not moving:
        return
    rows = state.rows()
    pos, quat = shape_poses(rows, quat_conjugate(np.asarray(model.q_BP, dtype=float).reshape(-1, 4)))
    pairs = np.array([[s, i] for s in statics for i in moving], dtype=np.int64)
    m = len(pairs)
    dist = np.empty(m)
    pair_contacts(pos, quat, shapes, pairs, dist, np.empty((m, 3)), np.empty(m, dtype=np.int64),
                  np.empty((m, MAX_PAIR_POINTS, 6)), np.empty((m, MAX_PAIR_POINTS)))
    for (s, i), d in zip(pairs, dist):
        size = max(shapes[s, DIMS:DIMS + 3].max(), shapes[i, DIMS:DIMS + 3].max())
        if -d > 1e-9 * size:
            name, other = model.names[i], model.names[s]
            check.fail(f"bodies.{name}", f"a body that starts outside the static shapes: its collision shape is "
                       f"{-d:.6g} m inside static body {other!r}'s; move it out by at least that", show_got=False)


class StaticGeometry:
    """The static shapes of a scene and the plane rows the solver holds bodies on (the module docstring).

    Parameters
    ----------
    sim : Simulator
        Its model and parameter rows; the static bodies' poses are read from its state by
        :meth:`place` (the solver's reset: they do not move).
    spec : ContactSpec
        The scene's contact declaration (shapes, materials, half-spaces).
    statics : ndarray of int
        The static bodies with a shape (:func:`static_shapes`), not empty.
    """

    def __init__(self, sim, spec, statics: np.ndarray) -> None:
        n = sim.model.count
        self.statics = statics
        #: Body index → index into ``statics`` (−1: not a static shape).
        self._static_index = np.full(n, -1, dtype=np.int64)
        self._static_index[statics] = np.arange(len(statics))
        self.half_spaces = spec.grounds
        g = len(spec.grounds)
        self.shapes = spec.shapes[statics].copy()
        self.pos, self.quat = np.zeros((len(statics), 3)), np.tile([1.0, 0.0, 0.0, 0.0], (len(statics), 1))
        self.radius = np.array([bounding_radius(s) for s in self.shapes])
        boxes = [s for s in range(len(statics)) if self.shapes[s, KIND] == SHAPE_BOX]
        #: First face row of each static shape (6 rows: +x, −x, +y, −y, +z, −z of its frame B), -1 if not a box.
        self.first_face = np.full(len(statics), -1, dtype=np.int64)
        for m, s in enumerate(boxes):
            self.first_face[s] = g + 6 * m
        rows = [np.asarray(spec.grounds)]
        face = np.zeros((6 * len(boxes), GROUND_WIDTH))
        rows.append(face)
        #: The first tangent row: body i's is first_tangent + i.
        self.first_tangent = g + len(face)
        rows.append(np.zeros((n, GROUND_WIDTH)))
        rows[-1][:, NORMAL + 2] = 1.0
        #: Every plane row the solver uses: half-spaces, static box faces, the bodies' tangent rows.
        self.rows = np.concatenate(rows)
        #: Per row, the static shape (index into ``statics``) it belongs to; -1 for a half-space.
        self.row_owner = np.full(len(self.rows), -1, dtype=np.int64)
        for s in boxes:
            self.row_owner[self.first_face[s]:self.first_face[s] + 6] = s
        # every body's pair material with every static shape (n, len(statics))
        self._pair_e = np.zeros((n, len(statics)))
        self._pair_mu = np.zeros((n, len(statics)))
        for i in range(n):
            for s, b in enumerate(statics):
                self._pair_e[i, s], self._pair_mu[i, s] = pair_material(spec.shapes[i], spec.shapes[b])
        #: Per body, restitution and friction against the half-spaces and the face rows: (n, first_tangent).
        self.restitution = np.zeros((n, self.first_tangent))
        self.friction = np.zeros((n, self.first_tangent))
        self.restitution[:, :g], self.friction[:, :g] = spec.restitution, spec.friction
        for s in boxes:
            f = self.first_face[s]
            self.restitution[:, f:f + 6] = self._pair_e[:, s:s + 1]
            self.friction[:, f:f + 6] = self._pair_mu[:, s:s + 1]
        #: Per body, restitution and friction against its own tangent row first_tangent + i: (n,), the pair
        #: material with the static shape the row was last written for (0 until then). A body is only ever on
        #: its own tangent row: one number per body (kernels/contact/materials.material reads both).
        self.tangent_restitution = np.zeros(n)
        self.tangent_friction = np.zeros(n)
        # narrow-phase buffers: the static shapes, then one moving shape (index S)
        k = len(statics)
        self._pos = np.zeros((k + 1, 3))
        self._quat = np.zeros((k + 1, 4))
        self._shapes = np.zeros((k + 1, spec.shapes.shape[1]))
        self._shapes[:k] = self.shapes
        self._pairs = np.array([[s, k] for s in range(k)], dtype=np.int64)
        self._dist = np.empty(k)
        self._normal = np.empty((k, 3))
        self._count = np.empty(k, dtype=np.int64)
        self._points = np.empty((k, MAX_PAIR_POINTS, 6))
        self._seps = np.empty((k, MAX_PAIR_POINTS))
        self._q_PB = sim._prm[:, L.Q_PB:L.Q_PB + 4].copy()
        self._reach = np.array([bounding_radius(shape) for shape in spec.shapes])
        self._body_points = np.empty((MAX_POINTS, 3))
        self._body_gaps = np.empty(MAX_POINTS)

    def place(self, sim) -> None:
        """Read the static shapes' poses from the simulator's current state; the face rows from them."""
        Y = sim._Ys[sim._control[L.CUR]]
        self.pos, self.quat = shape_poses(Y[self.statics], sim._prm[self.statics, L.Q_PB:L.Q_PB + 4])
        k = len(self.statics)
        self._pos[:k], self._quat[:k] = self.pos, self.quat
        R = self._R_WB = quat_to_matrix(self.quat)
        for s in range(k):
            f = int(self.first_face[s])
            if f < 0:
                continue
            for face in range(6):
                axis, sign = face // 2, 1.0 - 2.0 * (face % 2)
                normal = sign * R[s, :, axis]
                self.rows[f + face, NORMAL:NORMAL + 3] = normal
                self.rows[f + face, OFFSET] = normal @ self.pos[s] + self.shapes[s, DIMS + axis]

    # ----------------------------------------------------------------- narrow phase

    def nearest(self, y: np.ndarray, i: int, shape: np.ndarray, exclude: int = -1,
                also: int = -1) -> tuple[float, int]:
        """(signed distance in m, static index) of body i at state row y to its nearest static shape.

        ``exclude``, ``also``: static indices not looked at (-1: none). (inf, -1) if there is none. The normal (static to
        body, world axes) and the contact point on the static surface are left in
        ``self._normal[s]`` and ``self._points[s, 0, 0:3]``.
        """
        k = len(self.statics)
        self._pos[k] = y[L.P:L.P + 3]
        self._quat[k] = quat_multiply(y[L.Q:L.Q + 4], self._q_PB[i])
        self._shapes[k] = shape
        pair_contacts(self._pos, self._quat, self._shapes, self._pairs, self._dist, self._normal, self._count,
                      self._points, self._seps)
        best, which = math.inf, -1
        for s in range(k):
            if s != exclude and s != also and self._dist[s] < best:
                best, which = float(self._dist[s]), s
        return best, which

    def distances(self, y: np.ndarray, i: int, shape: np.ndarray) -> np.ndarray:
        """Signed distances (m; per static shape, in order) of body i at state row y to every static shape."""
        self.nearest(y, i, shape)
        return self._dist.copy()

    def nearest_among(self, y: np.ndarray, i: int, shape: np.ndarray, among: np.ndarray) -> float:
        """Signed distance (m) of body i at state row y to its nearest static shape of those ``among`` marks (a bool
        per static shape); inf if it marks none."""
        self.nearest(y, i, shape)
        return float(self._dist[among].min()) if among.any() else math.inf

    def lower_gaps(self, Y: np.ndarray, shapes: np.ndarray, bodies: np.ndarray, out: np.ndarray) -> None:
        """out[m] ← min(out[m], signed distance of body bodies[m] to the static shapes), in place.

        Pairs whose bounding spheres are apart, or two boxes with a positive lower bound on their distance
        (apart_bounds), are not passed to the narrow phase: their distance is positive, and out[m] stays as it
        was (callers ask only whether it went below zero).
        """
        k = len(self.statics)
        centres = Y[bodies, L.P:L.P + 3]
        reach = self._reach[bodies]
        apart = np.linalg.norm(centres[:, None, :] - self.pos[None, :, :], axis=2) - reach[:, None] - self.radius[None, :]
        near_m, near_s = np.nonzero(apart <= 0.0)
        if not near_m.size:
            return
        pos = np.concatenate((self.pos, centres[near_m]))
        quat = np.concatenate((self.quat, quat_multiply(Y[bodies[near_m], L.Q:L.Q + 4], self._q_PB[bodies[near_m]])))
        rows = np.concatenate((self.shapes, shapes[bodies[near_m]]))
        pairs = np.stack((near_s, k + np.arange(near_m.size)), axis=1).astype(np.int64)
        lower = np.empty(len(pairs))
        apart_bounds(pos, quat, rows, pairs, lower)
        touching = lower <= 0.0
        if not touching.any():
            return
        pairs, near_m = np.ascontiguousarray(pairs[touching]), near_m[touching]
        m = len(pairs)
        dist, normal, count = np.empty(m), np.empty((m, 3)), np.empty(m, dtype=np.int64)
        pair_contacts(pos, quat, rows, pairs, dist, normal, count, np.empty((m, MAX_PAIR_POINTS, 6)),
                      np.empty((m, MAX_PAIR_POINTS)))
        np.minimum.at(out, near_m, dist)

    # ----------------------------------------------------------------- plane rows

    def is_tangent(self, j: int) -> bool:
        """Whether plane row j is a body's tangent row (refreshed from the narrow phase)."""
        return j >= self.first_tangent

    def plane_for(self, y: np.ndarray, p: np.ndarray, i: int, shape: np.ndarray, s: int) -> int:
        """The plane row for body i at y touching static shape s (after :meth:`nearest`, whose normal and
        point are used): a face row of a static box if the normal is that face's and the body's contact
        points against it lie within the face, else body i's tangent row, written here."""
        n = self._normal[s]
        f = int(self.first_face[s])
        if f >= 0:
            faces = self.rows[f:f + 6, NORMAL:NORMAL + 3]
            k = int(np.argmax(faces @ n))
            if faces[k] @ n >= 1.0 - 0.5 * FACE_ALIGNMENT * FACE_ALIGNMENT:
                count = body_points(y, p, shape, self.rows[f + k], self._body_points, self._body_gaps)
                if self.within_face(f + k, self._body_points[:count]):
                    return f + k
        j = self.first_tangent + i
        self.rows[j, NORMAL:NORMAL + 3] = n
        self.rows[j, OFFSET] = float(n @ self._points[s, 0, 0:3])
        self.row_owner[j] = s
        self.tangent_restitution[i], self.tangent_friction[i] = self._pair_e[i, s], self._pair_mu[i, s]
        return j

    def plane_through(self, s: int) -> np.ndarray:
        """A plane row, none of :attr:`rows`, through the contact :meth:`nearest` last found with static shape s:
        its normal (static to body) and its point on the static surface."""
        row = np.zeros(self.rows.shape[1])
        row[NORMAL:NORMAL + 3] = self._normal[s]
        row[OFFSET] = float(self._normal[s] @ self._points[s, 0, 0:3])
        return row

    def plane_rows(self, bodies: np.ndarray, static_bodies: np.ndarray, normals_W: np.ndarray,
                   points_W: np.ndarray) -> np.ndarray:
        """The plane row of each contact of a body in an island with a static shape (island_contacts.py).

        bodies, static_bodies : (k,) int, body indices (the moving body, the static one); normals_W : (k, 3),
        unit, from the static shape towards the body; points_W : (k, 3), on the contact (m). A static
        box's face row where its outward normal is the contact's (as :meth:`plane_for`); else body i's
        tangent row, written here through the point (the solver does not hold an island body on it: it
        is rewritten when the body next meets a static shape outside an island). A body against two
        such shapes at once has one tangent row: it names the last of them.
        """
        s = self._static_index[static_bodies]
        first = self.first_face[s]
        rows = self.first_tangent + bodies
        box = np.flatnonzero(first >= 0)
        if box.size:
            faces = self.rows[first[box, None] + np.arange(6), NORMAL:NORMAL + 3]  # (b, 6, 3)
            alignment = np.einsum("kfa,ka->kf", faces, normals_W[box])
            best = np.argmax(alignment, axis=1)
            on_face = alignment[np.arange(box.size), best] >= 1.0 - 0.5 * FACE_ALIGNMENT * FACE_ALIGNMENT
            rows[box[on_face]] = first[box[on_face]] + best[on_face]
        tangent = rows >= self.first_tangent
        if tangent.any():
            j, i, t = rows[tangent], bodies[tangent], s[tangent]
            self.rows[j, NORMAL:NORMAL + 3] = normals_W[tangent]
            self.rows[j, OFFSET] = np.einsum("ka,ka->k", normals_W[tangent], points_W[tangent])
            self.row_owner[j] = t
            self.tangent_restitution[i], self.tangent_friction[i] = self._pair_e[i, t], self._pair_mu[i, t]
        return rows

    def within_face(self, j: int, points: np.ndarray) -> bool:
        """Whether every point (k, 3), world, lies within the rectangle of face row j (to FACE_MARGIN)."""
        s = int(self.row_owner[j])
        axis = (j - int(self.first_face[s])) // 2
        half = self.shapes[s, DIMS:DIMS + 3]
        local = (points - self.pos[s]) @ self._R_WB[s]  # rows: Rᵀ (p − c)
        margin = FACE_MARGIN * float(half.max())
        for other in range(3):
            if other != axis and np.any(np.abs(local[:, other]) > half[other] + margin):
                return False
        return True

    def refresh(self, y: np.ndarray, p: np.ndarray, i: int, shape: np.ndarray, j: int, band: float) -> int:
        """Body i, held on plane row j, its row rewritten from the narrow phase at y against the static shape j
        belongs to (its support moved or is curved): the row index (a face row if the contact is now within a
        face), or -1 if another static shape is nearer than that one by more than ``band`` (m): the body's
        support is no longer the one its held features were found on."""
        owner = int(self.row_owner[j])
        dist, s = self.nearest(y, i, shape)
        if s != owner and dist < float(self._dist[owner]) - band:
            return -1
        return self.plane_for(y, p, i, shape, owner)

    def static_of(self, j: int) -> int:
        """The body index of the static shape plane row j belongs to (now), or -1 for a half-space."""
        s = int(self.row_owner[j])
        return int(self.statics[s]) if s >= 0 else -1
