"""The drawing shared by the live view and the replay: bodies, sites, IMUs, wrenches, contacts, trails.

Each body B is a frame at ``/bodies/B`` (its axes) holding its shape at ``/bodies/B/shape`` (a box,
a cylinder along z, or a scaled sphere: an inertia ellipsoid sits rotated in B by ``q_rel``) and
its sites at ``/bodies/B/sites`` (small orange spheres, positions in B); an IMU site also gets a
small triad and a label. Held wrenches are red arrows in world coordinates (``/wrenches``), the
tick's contacts yellow points with their normals (``/contacts``), and trails (optional) each
body's last positions as line segments (``/trails``).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

__all__ = ["Bodies", "BatchedBodies", "BATCH_ABOVE", "shape_from_marker", "setup_scene", "SITE_RGB", "CONTACT_RGB", "ARROW_RGB"]

SITE_RGB = (255, 140, 0)
ARROW_RGB = (230, 25, 25)
CONTACT_RGB = (250, 200, 0)
#: Positions kept per body for its trail.
TRAIL_LENGTH = 300


@dataclass
class _Shape:
    kind: int  # visualization_msgs/Marker type
    scale: tuple[float, float, float]
    rgb: tuple[int, int, int]
    opacity: float | None
    q_rel_wxyz: tuple[float, float, float, float]  # shape in the body frame


def shape_from_marker(kind: int, scale: tuple[float, float, float], rgba: tuple[float, float, float, float],
                      q_rel_wxyz: tuple[float, float, float, float]) -> _Shape:
    """A body's shape as a marker gives it (type, scale, colour), placed in the body frame by ``q_rel_wxyz``."""
    rgb = tuple(int(round(255 * min(1.0, max(0.0, float(c))))) for c in rgba[:3])
    opacity = float(rgba[3]) if 0.0 < rgba[3] < 1.0 else None
    return _Shape(int(kind), tuple(float(x) for x in scale), rgb, opacity,  # type: ignore[arg-type]
                  tuple(float(x) for x in q_rel_wxyz))  # type: ignore[arg-type]


class Bodies:
    """The drawing of the bodies and what goes with them. ``on_click(name, event)``, if given, is
    called when a body's shape is clicked (viser's SceneNodePointerEvent: the click's ray)."""

    def __init__(self, server: Any, on_click: Callable[[str, Any], None] | None = None):
        self.server = server
        self.on_click = on_click
        self.frames: dict[str, Any] = {}
        self.shape_handles: dict[str, tuple[_Shape, Any]] = {}
        self.site_handles: dict[str, tuple[tuple, Any]] = {}
        self.imu_handles: dict[str, Any] = {}
        self._arrows: Any = None
        self._arrows_shown = np.zeros((0, 2, 3))
        self._contacts: list[Any] = []
        self._contacts_shown = np.zeros((0, 3))
        self._trail_handle: Any = None
        self.trails: dict[str, deque] = {}

    def show(self, poses: dict[str, tuple[tuple[float, float, float], tuple[float, float, float, float]]],
             shapes: dict[str, _Shape]) -> set[str]:
        """Place each body of ``poses`` (name: (position, wxyz)) and draw its shape when new or changed;
        bodies not in ``poses`` are hidden. Returns the names whose frame or shape was (re)made."""
        made: set[str] = set()
        with self.server.atomic():
            for name, (position, wxyz) in poses.items():
                frame = self.frames.get(name)
                if frame is None:
                    frame = self.frames[name] = self.server.scene.add_frame(
                        f"/bodies/{name}", axes_length=0.3, axes_radius=0.01)
                    made.add(name)
                frame.position, frame.wxyz, frame.visible = position, wxyz, True
                shape = shapes.get(name)
                if shape is not None and self.shape_handles.get(name, (None,))[0] != shape:
                    self._draw_shape(name, shape)
                    made.add(name)
            for name, frame in self.frames.items():
                if name not in poses and frame.visible:
                    frame.visible = False
        return made

    def _draw_shape(self, name: str, shape: _Shape) -> None:
        from visualization_msgs.msg import Marker

        old = self.shape_handles.pop(name, None)
        if old is not None:
            old[1].remove()
        path, scene = f"/bodies/{name}/shape", self.server.scene
        sx, sy, sz = shape.scale
        if shape.kind == Marker.CUBE:
            handle = scene.add_box(path, color=shape.rgb, dimensions=(sx, sy, sz), opacity=shape.opacity,
                                   wxyz=shape.q_rel_wxyz)
        elif shape.kind == Marker.CYLINDER:
            handle = scene.add_cylinder(path, radius=sx / 2.0, height=sz, color=shape.rgb, opacity=shape.opacity,
                                        wxyz=shape.q_rel_wxyz)
        else:
            handle = scene.add_icosphere(path, radius=0.5, scale=(sx, sy, sz), color=shape.rgb,
                                         opacity=shape.opacity, wxyz=shape.q_rel_wxyz)
        if self.on_click is not None:
            handle.on_click(lambda event, name=name: self.on_click(name, event))
        self.shape_handles[name] = (shape, handle)

    def show_sites(self, sites_B: dict[str, tuple[tuple[float, float, float], ...]], diameter_m: float = 0.05) -> None:
        """Each body's sites (positions in its body frame, m) as small spheres, redrawn when they change."""
        for name, points in sites_B.items():
            if name not in self.frames or self.site_handles.get(name, (None,))[0] == points:
                continue
            old = self.site_handles.pop(name, None)
            if old is not None:
                old[1].remove()
            if points:
                handle = self.server.scene.add_point_cloud(
                    f"/bodies/{name}/sites", points=np.asarray(points, dtype=np.float32).reshape(-1, 3),
                    colors=SITE_RGB, point_size=diameter_m, point_shape="circle", precision="float32")
                self.site_handles[name] = (points, handle)

    def show_imus(self, imus: dict[str, tuple[str, tuple[float, float, float] | None]]) -> None:
        """IMUs: key ``B/S`` → (label, position in B or None if unknown): a triad and a label at the site."""
        for key, (label, position) in imus.items():
            body = key.split("/", 1)[0]
            if key in self.imu_handles or body not in self.frames or position is None:
                continue
            self.imu_handles[key] = (
                self.server.scene.add_frame(f"/bodies/{body}/imu_{key.split('/', 1)[1]}", axes_length=0.12,
                                            axes_radius=0.006, position=position),
                self.server.scene.add_label(f"/bodies/{body}/imu_{key.split('/', 1)[1]}/label", label,
                                            position=(0.0, 0.0, 0.05)))

    def show_arrows(self, segments_W: np.ndarray) -> None:
        """Held wrenches: (K, 2, 3) start and tip of each arrow, world (m); K = 0 clears them."""
        segments_W = np.asarray(segments_W, dtype=float).reshape(-1, 2, 3)
        if np.array_equal(segments_W, self._arrows_shown):
            return
        self._arrows_shown = segments_W
        if self._arrows is not None:
            self._arrows.remove()
            self._arrows = None
        if len(segments_W):
            self._arrows = self.server.scene.add_arrows("/wrenches", points=np.asarray(segments_W, dtype=np.float32),
                                                        colors=ARROW_RGB, shaft_radius=0.01, head_radius=0.025,
                                                        head_length=0.05)

    def show_contacts(self, points_W: np.ndarray, normals_W: np.ndarray) -> None:
        """The tick's contacts: points (K, 3) world (m) and their unit normals (K, 3); K = 0 clears them."""
        points_W = np.asarray(points_W, dtype=float).reshape(-1, 3)
        if np.array_equal(points_W, self._contacts_shown):
            return
        self._contacts_shown = points_W
        for handle in self._contacts:
            handle.remove()
        self._contacts = []
        if len(points_W):
            p = np.asarray(points_W, dtype=np.float32)
            self._contacts.append(self.server.scene.add_point_cloud("/contacts/points", points=p, colors=CONTACT_RGB,
                                                                    point_size=0.04, point_shape="circle"))
            tips = np.stack((p, p + 0.2 * np.asarray(normals_W, dtype=np.float32)), axis=1)
            self._contacts.append(self.server.scene.add_arrows("/contacts/normals", points=tips, colors=CONTACT_RGB,
                                                               shaft_radius=0.006, head_radius=0.015,
                                                               head_length=0.03))

    def record_trails(self, poses: dict[str, tuple[tuple[float, float, float], Any]]) -> None:
        for name, (position, _q) in poses.items():
            trail = self.trails.setdefault(name, deque(maxlen=TRAIL_LENGTH))
            if not trail or trail[-1] != position:
                trail.append(position)

    def show_trails(self, on: bool) -> None:
        """Draw (or clear) each body's trail of its last :data:`TRAIL_LENGTH` positions."""
        if self._trail_handle is not None:
            self._trail_handle.remove()
            self._trail_handle = None
        if not on:
            return
        segments = [np.stack((np.asarray(t)[:-1], np.asarray(t)[1:]), axis=1) for t in self.trails.values() if len(t) > 1]
        if segments:
            self._trail_handle = self.server.scene.add_line_segments(
                "/trails", points=np.concatenate(segments).astype(np.float32), colors=(120, 120, 220), thickness=0.008)

    def clear_trails(self) -> None:
        self.trails.clear()


def setup_scene(server: Any) -> None:
    """The 3D scene both views share: z up, the camera on the default box, a 4 m grid at z = 0, lit by
    viser's default lights and a hemisphere light (sky above, grey ground) instead of viser's image-based
    environment map: a browser without a GPU (software WebGL) prepares that map for 5-10 s at every page
    load, and the two light the shapes alike."""
    server.scene.set_up_direction("+z")
    server.scene.configure_environment_map(hdri=None)
    server.scene.add_light_hemisphere("/sky", sky_color=(255, 255, 255), ground_color=(110, 110, 120),
                                      intensity=2.0, position=(0.0, 0.0, 1.0))
    server.initial_camera.position = (1.9, -1.9, 2.0)
    server.initial_camera.look_at = (0.0, 0.0, 0.8)
    server.scene.add_grid("/ground", width=4.0, height=4.0, cell_size=0.5)


#: Above this many bodies the live view draws them batched (:class:`BatchedBodies`).
BATCH_ABOVE = 20


def _unit_mesh(kind: int) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (V, 3), faces (F, 3), outward counter-clockwise) of the unit shape a batched instance
    scales: a cube of edge 1, a sphere of diameter 1, a cylinder of diameter 1 and length 1 along z."""
    from visualization_msgs.msg import Marker

    if kind == Marker.CUBE:
        v = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
        quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
        f = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
        return v.astype(np.float32), np.asarray(f, dtype=np.uint32)
    sections = 24
    phi = np.linspace(0.0, 2.0 * np.pi, sections, endpoint=False)
    if kind == Marker.CYLINDER:
        ring = np.stack((0.5 * np.cos(phi), 0.5 * np.sin(phi)), axis=1)
        v = np.vstack((np.c_[ring, np.full(sections, -0.5)], np.c_[ring, np.full(sections, 0.5)],
                       [[0.0, 0.0, -0.5], [0.0, 0.0, 0.5]]))
        f = []
        for i in range(sections):
            j = (i + 1) % sections
            f += [(i, j, sections + j), (i, sections + j, sections + i),  # side
                  (2 * sections, j, i), (2 * sections + 1, sections + i, sections + j)]  # caps
        return v.astype(np.float32), np.asarray(f, dtype=np.uint32)
    rings = 12
    theta = np.linspace(0.0, np.pi, rings + 1)[1:-1]
    v = [[0.0, 0.0, 0.5]] + [[0.5 * np.sin(t) * np.cos(p), 0.5 * np.sin(t) * np.sin(p), 0.5 * np.cos(t)]
                             for t in theta for p in phi] + [[0.0, 0.0, -0.5]]
    f = []
    for i in range(sections):
        j = (i + 1) % sections
        f.append((0, 1 + i, 1 + j))
        for r in range(rings - 2):
            a, b = 1 + r * sections, 1 + (r + 1) * sections
            f += [(a + i, b + i, b + j), (a + i, b + j, a + j)]
        last = 1 + (rings - 2) * sections
        f.append((len(v) - 1, last + j, last + i))
    return np.asarray(v, dtype=np.float32), np.asarray(f, dtype=np.uint32)


def _q_mul_rows(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    pw, px, py, pz = p[:, 0], p[:, 1], p[:, 2], p[:, 3]
    qw, qx, qy, qz = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack((pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw), axis=1)


class BatchedBodies:
    """Many bodies drawn as instances: one batched set of axes for the body frames, and one batched
    mesh per shape kind (box, cylinder, ellipsoid) scaled per body, so a refresh sends a handful of
    messages whatever the number of bodies. Sites, IMU triads and the strike point are not drawn.
    ``on_click(name, event)`` is called with the body whose shape the click's ray meets first."""

    def __init__(self, server: Any, on_click: Callable[[str, Any], None] | None = None, pick: Callable | None = None):
        self.server = server
        self.on_click = on_click
        self.pick = pick  # (names, event) -> the name hit first, or None
        self.axes: Any = None
        self.meshes: dict[int, tuple[tuple, Any, np.ndarray, np.ndarray]] = {}  # kind -> (key, handle, rows, q_rel)
        self._names: tuple[str, ...] = ()

    def show_arrays(self, names: list[str], positions: np.ndarray, q_WB_xyzw: np.ndarray, shapes: dict[str, _Shape]) -> None:
        """Place N bodies: positions (N, 3) m, orientations (N, 4) x, y, z, w, world; shapes by name."""
        q_WB = np.concatenate((q_WB_xyzw[:, 3:], q_WB_xyzw[:, :3]), axis=1).astype(np.float32)
        p = np.asarray(positions, dtype=np.float32)
        with self.server.atomic():
            if self.axes is None or self._names != tuple(names):
                if self.axes is not None:
                    self.axes.remove()
                self.axes = self.server.scene.add_batched_axes("/batched/axes", batched_wxyzs=q_WB, batched_positions=p,
                                                               axes_length=0.3, axes_radius=0.01)
                self._names = tuple(names)
            else:
                self.axes.batched_positions, self.axes.batched_wxyzs = p, q_WB
            groups: dict[int, list[int]] = {}
            for k, name in enumerate(names):
                if name in shapes:
                    groups.setdefault(shapes[name].kind, []).append(k)
            for kind in list(self.meshes):
                if kind not in groups:
                    self.meshes.pop(kind)[1].remove()
            for kind, rows in groups.items():
                key = (tuple(names[k] for k in rows), tuple(shapes[names[k]].scale for k in rows),
                       tuple(shapes[names[k]].q_rel_wxyz for k in rows))
                rows_a = np.asarray(rows)
                q_rel = np.asarray(key[2], dtype=np.float32)
                wxyz = _q_mul_rows(q_WB[rows_a], q_rel).astype(np.float32)
                held = self.meshes.get(kind)
                if held is None or held[0] != key:
                    if held is not None:
                        held[1].remove()
                    vertices, faces = _unit_mesh(kind)
                    first = shapes[names[rows[0]]]
                    handle = self.server.scene.add_batched_meshes_simple(
                        f"/batched/shapes_{kind}", vertices, faces, batched_wxyzs=wxyz, batched_positions=p[rows_a],
                        batched_scales=np.asarray(key[1], dtype=np.float32), batched_colors=first.rgb,
                        opacity=first.opacity, lod="off")
                    if self.on_click is not None and self.pick is not None:
                        handle.on_click(lambda event, names=key[0]: self._clicked(names, event))
                    self.meshes[kind] = (key, handle, rows_a, q_rel)
                else:
                    held[1].batched_positions, held[1].batched_wxyzs = p[rows_a], wxyz

    def clear(self) -> None:
        """Remove every batched node (the view went back to drawing bodies one by one)."""
        if self.axes is not None:
            self.axes.remove()
            self.axes = None
        for held in self.meshes.values():
            held[1].remove()
        self.meshes.clear()
        self._names = ()

    def _clicked(self, names: tuple[str, ...], event: Any) -> None:
        name = self.pick(names, event)
        if name is not None:
            self.on_click(name, event)
