"""``markers`` (visualization_msgs/MarkerArray): the scene's bodies, sites and held wrenches in ``world_frame``.

Every marker is placed in ``world_frame`` directly (no /tf needed, though the node publishes it), and RViz
or Foxglove shows the scene with the fixed frame set to it. Per body B (namespace ``B``):

- id 0, its shape from the inertia declaration: ``box: [a, b, c]`` a CUBE of those edges along
  B's axes, ``sphere: r`` a SPHERE of diameter 2r, ``cylinder: [r, length]`` a CYLINDER along B's
  z; ``principal`` or ``tensor`` the solid ellipsoid of the same mass and inertia (a SPHERE
  scaled to diameters 2a, 2b, 2c along the principal axes, a² = 5 (I_b + I_c − I_a) / (2 m));
- ids 1, 2, ... its sites in scene order: SPHEREs of diameter :data:`SITE_DIAMETER_M`;
- namespace ``B/wrench``, with ``marker_wrenches``: one ARROW per held wrench (B/wrench topic),
  from the origin of its frame (the site, the COM for B and B/world_aligned, the world origin
  for ``world_frame``) along the force, ``marker_force_scale`` m per N;
- namespace ``B/contact``, in a scene with ground contact, while B rests on the ground (persistent
  contact): ids 0, 1, ... a SPHERE of diameter :data:`CONTACT_POINT_DIAMETER_M` at each of its
  touching contact points, then one ARROW from their centre along the ground's holding force of
  the last step (``marker_force_scale`` m per N; the force that holds a 1 kg box at rest on level
  ground points up, 9.81 N); while B is in an island (resting on bodies, or bodies on it), its
  island contact points of the last island step and the force they gave it over that step.

Each array starts with a DELETEALL marker, so bodies deleted and wrenches released disappear.
Published at ``marker_rate_hz`` of sim time (at most once a tick; 0 = never), and only while
someone subscribes (building the array costs ~20 µs a marker).
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping

import numpy as np
from geometry_msgs.msg import Point
from rclpy.node import Node
from rclpy.qos import QoSProfile
from visualization_msgs.msg import Marker, MarkerArray

from ..core import Scene, Simulator
from ..core.contact.query import island_points, resting_bodies, touching_points
from ..core.quaternion import quat_multiply, quat_rotate, quat_wxyz_from_xyzw, quat_xyzw_from_wxyz
from .conversions import time_msg_from_seconds
from .scene_edit import scene_data

__all__ = ["MarkerPublisher", "SITE_DIAMETER_M", "CONTACT_POINT_DIAMETER_M", "body_shapes", "TOPIC"]

#: Topic of the MarkerArray (relative: in the node's namespace).
TOPIC = "markers"
#: Diameter of a site's sphere, m.
SITE_DIAMETER_M = 0.05
_BODY_RGBA = (0.55, 0.65, 0.8, 0.8)
_SITE_RGBA = (1.0, 0.55, 0.0, 1.0)
_ARROW_RGBA = (0.9, 0.1, 0.1, 1.0)
#: Diameter of a contact point's sphere, m.
CONTACT_POINT_DIAMETER_M = 0.03
_CONTACT_RGBA = (0.1, 0.7, 0.2, 1.0)


def body_shapes(scene: Scene) -> list[tuple[int, tuple[float, float, float], bool]]:
    """Per body, in scene order: (Marker type, scale (x, y, z) m, True if in principal axes P
    (an ellipsoid) rather than body axes B)."""
    try:
        declared = scene_data(scene).get("bodies") or {}
    except Exception:  # noqa: BLE001  (no text: every body gets its ellipsoid)
        declared = {}
    model = scene.model
    shapes = []
    for b, name in enumerate(scene.body_names):
        inertia = declared.get(name, {}).get("inertia") if isinstance(declared.get(name), Mapping) else None
        kind = next(iter(inertia), None) if isinstance(inertia, Mapping) and len(inertia) == 1 else None
        if kind == "box":
            shapes.append((Marker.CUBE, tuple(float(x) for x in inertia["box"]), False))
        elif kind == "sphere":
            d = 2.0 * float(inertia["sphere"])
            shapes.append((Marker.SPHERE, (d, d, d), False))
        elif kind == "cylinder":
            r, length = (float(x) for x in inertia["cylinder"])
            shapes.append((Marker.CYLINDER, (2.0 * r, 2.0 * r, length), False))
        else:
            moments = np.asarray(model.inertia_P[b], dtype=float)
            total = moments.sum()
            semi = [math.sqrt(max(0.0, 5.0 * (total - 2.0 * moments[i]) / (2.0 * float(model.mass[b]))))
                    for i in range(3)]
            shapes.append((Marker.SPHERE, tuple(2.0 * a for a in semi), True))
    return shapes


def _color(marker: Marker, rgba: tuple[float, float, float, float]) -> None:
    marker.color.r, marker.color.g, marker.color.b, marker.color.a = rgba


def _pose(marker: Marker, position: Any, q_xyzw: Any) -> None:
    p, o = marker.pose.position, marker.pose.orientation
    p.x, p.y, p.z = (float(v) for v in position)
    o.x, o.y, o.z, o.w = (float(v) for v in q_xyzw)


class MarkerPublisher:
    """Builds and publishes the MarkerArray.

    Parameters
    ----------
    node : rclpy.node.Node
    qos : QoSProfile
    world_frame : str
    """

    def __init__(self, node: Node, qos: QoSProfile, world_frame: str):
        self._world_frame = world_frame
        self._publisher = node.create_publisher(MarkerArray, TOPIC, qos)
        self._scene: Scene | None = None
        self._shapes: list = []
        self._next_due_s: float | None = None
        self._last_t = -math.inf

    def publish(self, sim: Simulator, rate_hz: float,
                holds: Callable[[], Mapping[tuple[str, str], tuple[np.ndarray, np.ndarray]]],
                force_scale: float | None, *, contact_force_scale: float = 0.05) -> None:
        """Publish the markers if due at ``sim.time`` (every ``1 / rate_hz`` s of sim time) and
        someone listens; ``holds()`` gives the held wrenches ((body, core frame) → (force, torque)
        in that frame), drawn when ``force_scale`` (m/N) is not None; contact forces are drawn at
        ``contact_force_scale`` (m/N). Hold the node's lock."""
        if rate_hz <= 0.0 or self._publisher.get_subscription_count() == 0:
            return
        t = sim.time
        went_back = t < self._last_t  # a reset or a new scene: start the schedule again
        if self._next_due_s is not None and not went_back and t < self._next_due_s - 1e-9 * max(1.0, t):
            return
        self._last_t = t
        self._next_due_s = t + 1.0 / rate_hz
        self._publisher.publish(self.build(sim, holds() if force_scale is not None else {}, force_scale,
                                           contact_force_scale=contact_force_scale))

    def build(self, sim: Simulator, holds: Mapping[tuple[str, str], tuple[np.ndarray, np.ndarray]],
              force_scale: float | None, *, contact_force_scale: float = 0.05) -> MarkerArray:
        """The MarkerArray of ``sim``'s current state (see the module docstring)."""
        scene = sim.scene
        if scene is not self._scene:
            self._scene, self._shapes = scene, body_shapes(scene)
        model = scene.model
        stamp = time_msg_from_seconds(sim.time)
        array = MarkerArray()
        clear = Marker()
        clear.header.frame_id = self._world_frame
        clear.header.stamp = stamp
        clear.action = Marker.DELETEALL
        markers = [clear]

        def marker(ns: str, marker_id: int, kind: int, rgba: tuple) -> Marker:
            m = Marker()
            m.header.frame_id = self._world_frame
            m.header.stamp = stamp
            m.ns, m.id, m.type, m.action = ns, marker_id, kind, Marker.ADD
            _color(m, rgba)
            return m

        positions = sim.positions_world()
        q_WB_xyzw = sim.orientations_xyzw()
        q_WB = quat_wxyz_from_xyzw(q_WB_xyzw)
        q_WP = quat_multiply(q_WB, model.q_BP)
        stopped = set(sim.stopped_bodies)
        site_index = {name: k for k, name in enumerate(model.site_names)}
        for b, body in enumerate(scene.body_names):
            if body in stopped or not np.all(np.isfinite(positions[b])):
                continue
            kind, scale, principal = self._shapes[b]
            shape = marker(body, 0, kind, _BODY_RGBA)
            _pose(shape, positions[b], quat_xyzw_from_wxyz(q_WP[b]) if principal else q_WB_xyzw[b])
            shape.scale.x, shape.scale.y, shape.scale.z = scale
            markers.append(shape)
            for k, site in enumerate(scene.sites.get(body, ())):
                s = site_index[f"{body}/{site}"]
                m = marker(body, 1 + k, Marker.SPHERE, _SITE_RGBA)
                _pose(m, positions[b] + quat_rotate(q_WP[b], model.site_p_P[s]), (0.0, 0.0, 0.0, 1.0))
                m.scale.x = m.scale.y = m.scale.z = SITE_DIAMETER_M
                markers.append(m)
        if force_scale is not None:
            ids: dict[str, int] = {}
            for (body, frame), (force, _torque) in sorted(holds.items()):
                if body not in scene.sites or body in stopped:
                    continue
                b = scene.body_names.index(body)
                if frame == "world":
                    origin, f_W = np.zeros(3), np.asarray(force, dtype=float)
                elif frame == f"{body}/world_aligned":
                    origin, f_W = positions[b], np.asarray(force, dtype=float)
                elif frame == body:
                    origin, f_W = positions[b], quat_rotate(q_WB[b], force)
                else:
                    s = site_index[frame]
                    origin = positions[b] + quat_rotate(q_WP[b], model.site_p_P[s])
                    f_W = np.asarray(force, dtype=float) if model.site_world_axes[s] else quat_rotate(q_WB[b], force)
                ns = f"{body}/wrench"
                m = marker(ns, ids.setdefault(ns, 0), Marker.ARROW, _ARROW_RGBA)
                ids[ns] += 1
                _pose(m, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
                start = Point(x=float(origin[0]), y=float(origin[1]), z=float(origin[2]))
                tip = origin + force_scale * f_W
                end = Point(x=float(tip[0]), y=float(tip[1]), z=float(tip[2]))
                m.points = [start, end]
                m.scale.x, m.scale.y, m.scale.z = 0.02, 0.04, 0.06  # shaft and head diameters, head length (m)
                markers.append(m)
        markers += self._contact_markers(sim, marker, contact_force_scale)
        array.markers = markers
        return array

    @staticmethod
    def _contact_markers(sim: Simulator, marker: Callable[..., Marker], force_scale: float) -> list[Marker]:
        """The ``B/contact`` markers of every body resting on the ground or on bodies (the module docstring)."""
        solver = sim.contact
        if solver is None:
            return []
        out = []
        stopped = set(sim.stopped_bodies)
        held = [(i, touching_points(sim, i)[0], solver.holding_forces[i]) for i in resting_bodies(sim)]
        held += [(i, points, force) for i, (points, force) in island_points(sim).items()]
        for i, points, force in held:
            body = sim.body_names[i]
            if body in stopped or not len(points):
                continue
            ns = f"{body}/contact"
            for k, point in enumerate(points):
                m = marker(ns, k, Marker.SPHERE, _CONTACT_RGBA)
                _pose(m, point, (0.0, 0.0, 0.0, 1.0))
                m.scale.x = m.scale.y = m.scale.z = CONTACT_POINT_DIAMETER_M
                out.append(m)
            centre = points.mean(axis=0)
            tip = centre + force_scale * force
            m = marker(ns, len(points), Marker.ARROW, _CONTACT_RGBA)
            _pose(m, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
            m.points = [Point(x=float(centre[0]), y=float(centre[1]), z=float(centre[2])),
                        Point(x=float(tip[0]), y=float(tip[1]), z=float(tip[2]))]
            m.scale.x, m.scale.y, m.scale.z = 0.02, 0.04, 0.06
            out.append(m)
        return out
