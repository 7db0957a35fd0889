"""``contacts`` (sensor_msgs/PointCloud2): the contacts of each tick, their /diagnostics counts, and
the refusal of a ``set_state`` into the ground or a static shape.

Published after every tick that stepped a scene with contact (``Simulator.contact`` is a
ContactSolver: the scene has ``ground`` and a body with a ``collision`` shape), also when the
tick had none (``width`` 0). ``header.stamp`` = sim time at the end of the tick,
``header.frame_id`` = ``world_frame``; ``height`` 1, little endian, ``point_step``
:data:`CONTACT_POINT_STEP` (112), ``is_dense`` true. One point per event the tick had (in the
order the solver recorded them), then one per body in persistent contact at the end of the
tick, then one per side of each island pair of the tick's last step (bodies resting on bodies,
core/contact/island_contacts.py; in the order of their lower body). An impact between two moving
bodies (core/contact/body_pairs.py) and an island pair of two moving bodies have two points, one
per body (``body`` and ``other`` swapped); an island body on a half-space or a static shape has
one. An island body is in flight mode, never also a persistent contact. Fields
(:data:`CONTACT_FIELDS`; bytes 105 to 107 are zero padding):

============== ====== ======= ===================================================================
name           offset type    meaning
============== ====== ======= ===================================================================
x, y, z        0..16  FLOAT64 contact point, world (m): a persistent contact's touching points'
                              centre; an event's: the body's lowest point at the end of the tick
                              projected onto the half-space's boundary; between two bodies: the
                              mean of the contact points at the impact; island pair: the centre
                              of its points at the last step's start (mid-way between surfaces)
nx, ny, nz     24..40 FLOAT64 the half-space's unit normal, world axes; between two bodies and in
                              an island: the contact normal, from ``other`` (or the half-space or
                              static shape) towards ``body``
gap            48     FLOAT64 lowest gap of the body against that half-space at the end of the
                              tick (m; negative: inside); between two bodies: their signed
                              distance at the end of the tick; island pair: its points' smallest
                              gap at the last step's start
normal_force   56     FLOAT64 persistent contact and island pair: the force on ``body`` along the
                              normal, mean over the tick (N); events: 0
friction_force 64     FLOAT64 persistent contact and island pair: magnitude of its tangential
                              part, mean over the tick (N); events: 0
impulse        72     FLOAT64 impact: Σ normal impulse (N·s); else 0
time           80     FLOAT64 event: its sim time, located inside the step (s); persistent
                              contact and island pair: the stamp's time
energy_change  88     FLOAT64 impact: kinetic energy after − before (J, ≤ 0; between two bodies:
                              of both, on each of the two points); else 0
body           96     UINT32  index of the body in scene order (``body_names``)
ground         100    UINT32  index of the half-space in the scene's ``ground`` list; from its
                              length on, a static shape's plane (ContactSolver.static_body_of);
                              :data:`NO_INDEX` between two moving bodies
state          104    UINT8   :data:`STATES`: 0 impact, 1 resting, 2 sliding (persistent contact,
                              island pair), 3 rest (came to rest; a Zeno sequence's accumulation
                              time), 4 stick (a slide stopped), 5 lift_off
other          108    UINT32  between two moving bodies: the other body's index in scene order;
                              else :data:`NO_INDEX`
============== ====== ======= ===================================================================

An island pair's force is its impulses summed over the tick's steps divided by the tick's length
(the mean over the tick, a step without the pair counting as zero); at the first publish of a run
(or after a reset), when there is no earlier publish to start from, its last step's impulse / h.
It slides (2) when one of its points slipped faster than island_contacts.SLIDE_SPEED (1e-9 m/s)
after the last step, else rests (1).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import serialize_message
from sensor_msgs.msg import PointCloud2, PointField

from ..core import Simulator
from ..core.contact.island_contacts import pair_sides
from ..core.contact.query import lowest_gap, lowest_gaps, nearest_static, lowest_point, resting_bodies, touching_points
from .conversions import RejectedMessage, time_msg_from_seconds

__all__ = ["CONTACT_FIELDS", "CONTACT_POINT_STEP", "STATES", "NO_INDEX", "INTO_GROUND_TOLERANCE", "ContactPublisher",
           "contact_points", "into_ground"]

#: (name, byte offset, PointField datatype) of each point of ``contacts``.
CONTACT_FIELDS: tuple[tuple[str, int, int], ...] = (
    ("x", 0, PointField.FLOAT64), ("y", 8, PointField.FLOAT64), ("z", 16, PointField.FLOAT64),
    ("nx", 24, PointField.FLOAT64), ("ny", 32, PointField.FLOAT64), ("nz", 40, PointField.FLOAT64),
    ("gap", 48, PointField.FLOAT64), ("normal_force", 56, PointField.FLOAT64),
    ("friction_force", 64, PointField.FLOAT64), ("impulse", 72, PointField.FLOAT64),
    ("time", 80, PointField.FLOAT64), ("energy_change", 88, PointField.FLOAT64),
    ("body", 96, PointField.UINT32), ("ground", 100, PointField.UINT32), ("state", 104, PointField.UINT8),
    ("other", 108, PointField.UINT32))
#: Bytes per point of ``contacts``.
CONTACT_POINT_STEP = 112
#: ``ground`` of a contact between two moving bodies, ``other`` of one with the ground or a static shape.
NO_INDEX = 0xFFFFFFFF
#: The ``state`` field's values.
STATES = {"impact": 0, "resting": 1, "sliding": 2, "rest": 3, "stick": 4, "lift-off": 5}
#: A set_state whose shape would reach deeper than this (m) into a ground half-space is refused.
INTO_GROUND_TOLERANCE = 1e-9

_NUMPY = {PointField.FLOAT64: "<f8", PointField.UINT32: "<u4", PointField.UINT8: "u1"}
CONTACT_DTYPE = np.dtype({"names": [f[0] for f in CONTACT_FIELDS], "formats": [_NUMPY[f[2]] for f in CONTACT_FIELDS],
                          "offsets": [f[1] for f in CONTACT_FIELDS], "itemsize": CONTACT_POINT_STEP})


def into_ground(sim: Simulator, body: str, position_world: Any, orientation_xyzw: Any) -> RejectedMessage | None:
    """The refusal (reason ``into_ground``) of putting ``body`` at that pose, if its collision shape
    would reach deeper than :data:`INTO_GROUND_TOLERANCE` into a ground half-space or into a
    static body's shape (the static world); else None."""
    gap, ground = lowest_gap(sim, body, position_world, orientation_xyzw)
    if gap < -INTO_GROUND_TOLERANCE:
        return RejectedMessage("into_ground", f"{body!r} would reach {-gap:.6g} m into ground {ground} (n·x >= offset): "
                                              "lift it to gap >= 0")
    dist, static = nearest_static(sim, body, position_world, orientation_xyzw)
    if dist < -INTO_GROUND_TOLERANCE:
        return RejectedMessage("into_ground", f"{body!r} would reach {-dist:.6g} m into static body {static!r}: "
                                              "move it out to a distance >= 0")
    return None


def contact_points(rows: list[dict[str, Any]]) -> np.ndarray:
    """The (N,) structured array (:data:`CONTACT_DTYPE`, zero padding) of ``rows`` (field -> value)."""
    points = np.zeros(len(rows), dtype=CONTACT_DTYPE)
    for k, row in enumerate(rows):
        for name, value in row.items():
            points[name][k] = value
    return points


def _kv(key: str, value: Any) -> KeyValue:
    return KeyValue(key=key, value=str(value))


class ContactPublisher:
    """``contacts`` of ``node`` and the contact counts of /diagnostics (the session's lock held for all).

    Parameters
    ----------
    node : rclpy.node.Node
    qos : QoSProfile
        Of the publisher (every tick's events matter: not latched, a queue).
    frame_id : str
        ``header.frame_id`` (the prefixed world frame).
    """

    def __init__(self, node: Node, qos: QoSProfile, frame_id: str):
        self._publisher = node.create_publisher(PointCloud2, "contacts", qos)
        self.frame_id = frame_id
        self._solver: Any = None  # the ContactSolver the counts below follow
        self._seen = 0  # events of its list already published
        self._last: Any = None  # the last of them (a reset clears the list: then it is gone)
        self._impulses = np.zeros((0, 3))  # its holding_impulses at the last publish
        self._time: float | None = None  # sim time of the last publish
        self.totals = {"events": 0, "impacts": 0, "zeno_guards": 0, "contact_points": 0, "island_contacts": 0}
        self.energy_change = 0.0  # J, Σ over impacts
        self._at_open: dict[str, float] = {}
        self.window_violation = 0.0  # m, the deepest gap seen at a tick end in the window (≥ 0)
        self.window_most_events = 0  # the most events one tick had in the window
        self.open_window()

    def publish(self, sim: Simulator) -> PointCloud2 | None:
        """Publish the tick's contacts (if ``sim`` has contact); the message published, or None."""
        solver = sim.contact
        if solver is None:
            return None
        events = solver.events
        if solver is not self._solver or (self._seen and (len(events) < self._seen
                                                          or events[self._seen - 1] is not self._last)):
            self._solver, self._seen, self._time = solver, 0, None  # a new scene, or a reset (events cleared)
        elif self._time is not None and sim.time <= self._time:  # time went back (reset_world...)
            self._time = None
        event_rows = self._event_rows(sim, solver)
        self.window_most_events = max(self.window_most_events, len(event_rows))
        rows = contact_points(event_rows + self._resting_rows(sim, solver))
        island = self._island_points(sim, solver)
        points = np.zeros(len(rows) + len(island), dtype=CONTACT_DTYPE)  # (np.concatenate would drop the padding)
        points[:len(rows)], points[len(rows):] = rows, island
        self._impulses, self._time = solver.holding_impulses.copy(), sim.time
        gaps = lowest_gaps(sim)
        if gaps.size:
            self.window_violation = max(self.window_violation, -float(gaps.min()))
        self.totals["contact_points"] += len(points)
        self.totals["island_contacts"] += len(island)
        msg = PointCloud2()
        msg.header.stamp = time_msg_from_seconds(sim.time)
        msg.header.frame_id = self.frame_id
        msg.height, msg.width = 1, len(points)
        msg.fields = [PointField(name=name, offset=offset, datatype=datatype, count=1)
                      for name, offset, datatype in CONTACT_FIELDS]
        msg.is_bigendian = False
        msg.point_step = CONTACT_POINT_STEP
        msg.row_step = CONTACT_POINT_STEP * len(points)
        msg.is_dense = True
        msg.data = points.tobytes()
        self._publisher.publish(msg)
        return msg

    @staticmethod
    def cdr(msg: PointCloud2) -> bytes:
        """The CDR bytes of ``msg`` (what a recording stores)."""
        return serialize_message(msg)

    def _event_rows(self, sim: Simulator, solver: Any) -> list[dict[str, Any]]:
        rows = []
        names = sim.body_names
        events = solver.events
        for k in range(self._seen, len(events)):
            event = events[k]
            if event.body not in names:
                continue
            i = names.index(event.body)
            self.totals["events"] += 1
            if event.other:  # between two moving bodies (body_pairs.py): counted once, on the first body's point
                if event.other not in names:
                    continue
                j = names.index(event.other)
                if i < j:
                    self.totals["impacts"] += 1
                    self.energy_change += event.energy_after - event.energy_before
                rows.append(self._pair_row(sim, event, i, j))
                continue
            n = solver.grounds[event.ground, 0:3]
            point, gap = lowest_point(sim, i, event.ground)
            if event.kind == "impact":
                self.totals["impacts"] += 1
                self.energy_change += event.energy_after - event.energy_before
            previous = events[k - 1] if k > 0 else None
            if (event.kind == "rest" and previous is not None and previous.body == event.body
                    and previous.kind == "impact" and event.time > previous.time):
                self.totals["zeno_guards"] += 1  # dated at the bounce sequence's accumulation time
            rows.append({"x": point[0] - gap * n[0], "y": point[1] - gap * n[1], "z": point[2] - gap * n[2],
                         "nx": n[0], "ny": n[1], "nz": n[2], "gap": gap, "impulse": event.impulse,
                         "time": event.time, "body": i, "ground": event.ground, "state": STATES[event.kind],
                         "energy_change": (event.energy_after - event.energy_before) if event.kind == "impact" else 0.0,
                         "other": NO_INDEX})
        self._seen = len(events)
        self._last = events[-1] if events else None
        return rows

    @staticmethod
    def _pair_row(sim: Simulator, event: Any, i: int, j: int) -> dict[str, Any]:
        """The point of an impact between bodies i and j (the event of body i)."""
        rows = sim.state.rows()
        gap = sim.contact.pairs.contact(rows[i], i, rows[j], j)
        (x, y, z), (nx, ny, nz) = event.point_world, event.normal_world
        return {"x": x, "y": y, "z": z, "nx": nx, "ny": ny, "nz": nz, "gap": gap, "impulse": event.impulse,
                "time": event.time, "body": i, "ground": NO_INDEX, "state": STATES[event.kind],
                "energy_change": event.energy_after - event.energy_before, "other": j}

    def _resting_rows(self, sim: Simulator, solver: Any) -> list[dict[str, Any]]:
        rows = []
        span = sim.time - self._time if self._time is not None else 0.0
        for i in resting_bodies(sim):
            points, gaps = touching_points(sim, i)
            if not len(points):
                continue
            j = int(solver.ground_of[i])
            n = solver.grounds[j, 0:3]
            if span > 0.0 and len(self._impulses) == len(solver.holding_impulses):
                force = (solver.holding_impulses[i] - self._impulses[i]) / span
            else:  # no earlier tick to take the mean over: the last step's holding force
                force = solver.holding_forces[i]
            normal = float(force @ n)
            centre = points.mean(axis=0)
            rows.append({"x": centre[0], "y": centre[1], "z": centre[2], "nx": n[0], "ny": n[1], "nz": n[2],
                         "gap": float(gaps.min()), "normal_force": normal,
                         "friction_force": float(np.linalg.norm(force - normal * n)), "time": sim.time, "body": i,
                         "ground": j, "state": STATES["sliding" if solver.sliding[i] else "resting"],
                         "other": NO_INDEX})
        return rows

    def _island_points(self, sim: Simulator, solver: Any) -> np.ndarray:
        """The points of the last step's island contacts, one per pair side (core/contact/island_contacts.py):
        forces the mean over the tick (the pairs' impulses summed since the last publish / its length), or
        the last step's (impulse / h) when there is no earlier publish of this run to take the mean from."""
        if solver.pairs is None:
            return np.zeros(0, dtype=CONTACT_DTYPE)
        log = solver.pairs.islands.log
        log.summing = True  # from now on: the pairs' impulses summed over each tick
        keys, impulses = log.take()
        span = sim.time - self._time if self._time is not None else 0.0
        sides = pair_sides(solver, keys, impulses, span)
        points = np.zeros(len(sides), dtype=CONTACT_DTYPE)
        if not len(sides):
            return points
        n = sides.normal_W
        normal = np.einsum("ka,ka->k", sides.force_W, n)
        for k, name in enumerate("xyz"):
            points[name] = sides.point_W[:, k]
            points["n" + name] = n[:, k]
        points["gap"] = sides.gap
        points["normal_force"] = normal
        points["friction_force"] = np.linalg.norm(sides.force_W - normal[:, None] * n, axis=1)
        points["time"] = sim.time
        points["body"] = sides.body
        points["ground"] = np.where(sides.ground >= 0, sides.ground, NO_INDEX)
        points["state"] = np.where(sides.sliding, STATES["sliding"], STATES["resting"])
        points["other"] = np.where(sides.other >= 0, sides.other, NO_INDEX)
        return points

    # ------------------------------------------------------------------ /diagnostics

    def open_window(self) -> None:
        """Start a new /diagnostics window (the counts below are since then)."""
        self._at_open = {**self.totals, "energy_change": self.energy_change}
        self.window_violation = 0.0
        self.window_most_events = 0

    def status(self, node_name: str, sim: Simulator) -> DiagnosticStatus | None:
        """The ``<node>: contact`` status of the window (None without contact in the scene)."""
        solver = sim.contact
        if solver is None:
            return None
        window = {key: value - self._at_open.get(key, 0) for key, value in self.totals.items()}
        energy = self.energy_change - self._at_open.get("energy_change", 0.0)
        resting = len(resting_bodies(sim))
        in_islands = int(np.count_nonzero(solver.pairs.islands.in_islands())) if solver.pairs is not None else 0
        asleep = int(np.count_nonzero(solver.pairs.islands.asleep)) if solver.pairs is not None else 0
        status = DiagnosticStatus(name=f"{node_name}: contact", hardware_id="none")
        status.level = DiagnosticStatus.OK
        status.message = (f"{resting} resting, {window['events']} events ({window['impacts']} impacts) "
                          f"in the window")
        status.values = [
            _kv("contacts (resting bodies)", resting),
            _kv("bodies in islands", in_islands),
            _kv("bodies asleep", asleep),
            _kv("contact points published (window)", window["contact_points"]),
            _kv("island contact points published (window)", window["island_contacts"]),
            _kv("events (window)", window["events"]),
            _kv("most events in one tick (window)", self.window_most_events),
            _kv("impacts (window)", window["impacts"]),
            _kv("Zeno guards (window)", window["zeno_guards"]),
            _kv("largest gap violation [m] (window)", f"{self.window_violation:.9g}"),
            _kv("energy change at impacts [J] (window)", f"{energy:.9g}"),
            _kv("events (total)", self.totals["events"]),
            _kv("Zeno guards (total)", self.totals["zeno_guards"]),
            _kv("resting steps that gained energy (total)", solver.energy_gains),
            _kv("resting steps refined (total)", solver.counts["refined_steps"]),
            _kv("impacts with restitution capped (total)", solver.counts["restitution_capped"]),
            _kv("multi-contact impacts with e > 0, model-dependent (total)", solver.counts["multi_contact_elastic"]),
            _kv("sliding holds in a Painlevé configuration, model-dependent (total)", solver.counts["painleve"]),
            _kv("impacts on a second half-space while resting (total)", solver.counts["second_half_space"]),
            _kv("two half-spaces with too many contact points: projected (total)", solver.counts["two_ground_overflow"]),
            _kv("steps held on a static shape's tangent plane, first order (total)", solver.counts["static_tangent"]),
            _kv("impacts of a resting body pressed on a static shape, not held (total)", solver.counts["static_pressed"]),
            _kv("steps of a resting body projected out of a wall it went into, first order (total)",
                solver.counts["static_taken_out"]),
            _kv("spans of a resting body just struck whose side gap never opened, or struck too often: pressed, "
                "not struck again (total)", solver.counts["side_pressed"]),
            _kv("spans of a resting body whose held step threw it: left at rest where it was (total)",
                solver.counts["held_thrown"]),
            _kv("island body-steps, first order (total)", solver.counts["island_body_steps"]),
            _kv("island pairs found on the paths the islands' step gave (total)", solver.counts["island_late_pairs"]),
            _kv("of them, bodies joined to the islands (total)", solver.counts["island_late_joined"]),
            _kv("groups of bodies stepped again, two having ended the step inside each other (total)",
                solver.counts["pairs_looked_again"]),
            _kv("pieces of steps of cylinders rolling on a rim near upright (total)", solver.counts["rim_pieces"]),
            _kv("of them at the most pieces, the rim turning faster (total)", solver.counts["rim_capped"]),
            _kv("of those, throwing the can: its end face landed instead (total)", solver.counts["face_landed"]),
            _kv("cylinders held on a rim projected onto their end face (total)", solver.counts["face_down"]),
            _kv("projections that turned a feature into the ground, taken again with it held (total)",
                solver.counts["projected_down"]),
        ]
        return status
