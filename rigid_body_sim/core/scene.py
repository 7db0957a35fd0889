"""Scenes: load and validate a YAML file or a dict into a model and an initial state.

Schema (every key not listed is an error; see README "Scene files")::

    gravity: [0.0, 0.0, -9.81]            # optional, m/s², world axes; absent = none
    energy_growth_limit: 1.0e6            # optional, > 1: the loud-failure factor (simulator.py)
    bodies:
      crate:                              # a name: letter first, then letters, digits, _
        mass: 2.0                         # kg
        inertia: {box: [1.0, 0.6, 0.4]}   # or {sphere: r}, {cylinder: [r, length]} (axis z),
                                          # {principal: [Ixx, Iyy, Izz]}, {tensor: [[..],[..],[..]]}
        pose: {position: [0, 0, 1], orientation: [0, 0, 0, 1]}   # optional; x, y, z, w
        twist: {linear: [0, 0, 0], angular: [0, 0, 0]}          # optional; world axes
        damping: {linear: 0.0, angular: 0.0}                    # optional; N·s/m, N·m·s/rad
        motion: free                      # optional: free | static | kinematic | rotation_only |
                                          # translation_only | planar, or
                                          # {kind: planar, normal: [0, 0, 1]} (plane through the
                                          # initial position; default normal world z)
        sites:                                                  # optional
          corner: {position: [0.5, 0.3, 0.0]}                   # body frame, from the COM
          nozzle: {position: [0, 0, -0.2], axes: world}         # axes: body (default) | world
    wrenches:                             # optional: scripted wrenches over sim time
      - {body: crate, frame: crate/corner, force: [0, 10, 0], torque: [0, 0, 0], start: 0.5, duration: 0.2}

A scripted wrench follows the frame rule (forces.py): force (N) and torque (N·m) about the
origin of ``frame``, in its axes; ``frame`` is one of the body's frames. It acts on every
step whose start time t satisfies ``start ≤ t < start + duration`` (``duration`` absent =
forever); force and torque default to zero, ``start`` to 0.

Validation is complete before anything is built: a scene either loads whole or raises one
:class:`SceneError` naming the source, the key path and what was expected.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from pathlib import Path
from stat import S_ISREG
from typing import Any, Mapping

import numpy as np

from .mass_properties import (
    box_inertia,
    check_principal_moments,
    cylinder_inertia,
    principal_frame,
    sphere_inertia,
)
from .model import MOTIONS, BodyModel, State
from .quaternion import (
    quat_conjugate,
    quat_multiply,
    quat_rotate,
    quat_wxyz_from_xyzw,
)

__all__ = ["Scene", "SceneError", "ScriptedWrench", "load_scene", "WORLD_FRAME", "ORIENTATION_TOLERANCE",
           "DEFAULT_ENERGY_GROWTH_LIMIT"]

#: Name of the world frame in the core's frame rule.
WORLD_FRAME = "world"
#: How far | |q| − 1 | may be in a scene file; within it q is normalised, beyond it rejected.
ORIENTATION_TOLERANCE = 1e-6
#: Default ``energy_growth_limit``: a body whose kinetic energy exceeds this factor times the
#: most its initial energy and the work of the applied wrenches and gravity could give it
#: stops the simulator with a DivergenceError (simulator.py).
DEFAULT_ENERGY_GROWTH_LIMIT = 1e6
#: Largest size accepted for a scene file, bytes.
MAX_SCENE_BYTES = 8 * 1024 * 1024

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
_RESERVED_BODY_NAMES = {WORLD_FRAME}
_RESERVED_SITE_NAMES = {"world_aligned"}
_INERTIA_KINDS = ("box", "sphere", "cylinder", "principal", "tensor")
_TOP_KEYS = ("gravity", "bodies", "wrenches", "energy_growth_limit")
_WRENCH_KEYS = ("body", "frame", "force", "torque", "start", "duration")
_BODY_KEYS = ("mass", "inertia", "pose", "twist", "damping", "sites", "motion")
#: Relative tolerance of the initial twist's consistency with a planar motion (then projected).
PLANAR_TWIST_RTOL = 1e-9


class SceneError(ValueError):
    """A scene that cannot be loaded; the message names the source, key path and expectation."""


@dataclass(frozen=True)
class ScriptedWrench:
    """A wrench the scene applies over a window of sim time (the ``wrenches`` list of a scene).

    Attributes
    ----------
    body : str
    frame : str
        One of ``Scene.frames_of(body)``; force and torque follow the frame rule (forces.py).
    force : ndarray, shape (3,)
        N, in ``frame``'s axes.
    torque : ndarray, shape (3,)
        N·m about ``frame``'s origin, in its axes.
    start : float
        s of sim time, ≥ 0.
    duration : float
        s, > 0; ``math.inf`` for "until the end of the run".
    """

    body: str
    frame: str
    force: np.ndarray
    torque: np.ndarray
    start: float
    duration: float

    @property
    def end(self) -> float:
        """``start + duration``, s (``inf`` when it never ends): the window is [start, end)."""
        return self.start + self.duration


@dataclass(frozen=True)
class Scene:
    """A validated scene: the model, the initial state and where it came from.

    Attributes
    ----------
    source : str
        File path, or ``"<dict>"``.
    model : BodyModel
    initial_state : State
    sites : dict of str to tuple of str
        Site names per body, in file order.
    wrenches : tuple of ScriptedWrench
        The scripted wrenches, in file order (empty when the scene has none).
    energy_growth_limit : float
        Factor (> 1) past which a body's kinetic energy growth is a DivergenceError
        (default :data:`DEFAULT_ENERGY_GROWTH_LIMIT`).
    """

    source: str
    model: BodyModel
    initial_state: State
    sites: Mapping[str, tuple[str, ...]]
    wrenches: tuple[ScriptedWrench, ...] = ()
    energy_growth_limit: float = DEFAULT_ENERGY_GROWTH_LIMIT

    @property
    def body_names(self) -> tuple[str, ...]:
        return self.model.names

    def frames_of(self, body: str) -> tuple[str, ...]:
        """Every frame a wrench on ``body`` may be expressed in, e.g. ``("world", "box", ...)``."""
        if body not in self.sites:
            raise ValueError(f"unknown body {body!r}; bodies are {list(self.body_names)}")
        return (WORLD_FRAME, body, f"{body}/world_aligned") + tuple(
            f"{body}/{s}" for s in self.sites[body]
        )


def load_scene(source: str | Path | Mapping[str, Any]) -> Scene:
    """Load and validate a scene from a YAML file path or an already-parsed dict.

    Raises
    ------
    SceneError
        Naming the file (or ``<dict>``), the key path (``bodies.crate.inertia.box``) and what
        was expected. Nothing is half-loaded: the scene is returned whole or not at all.
    """
    if isinstance(source, Mapping):
        return _build(dict(source), "<dict>")
    path = Path(source)
    name = str(path)
    try:
        info = path.stat()
    except OSError as exc:
        raise SceneError(f"{name}: cannot read scene file ({exc.strerror or exc})") from None
    # Not a regular file (a directory, /dev/zero, a FIFO): reading it would fail, never end, or
    # block until a writer comes, so it is refused before it is opened.
    if not S_ISREG(info.st_mode):
        raise SceneError(f"{name}: cannot read scene file (not a regular file; expected a YAML file)")
    if info.st_size > MAX_SCENE_BYTES:
        raise SceneError(f"{name}: scene file is {info.st_size} bytes; expected at most {MAX_SCENE_BYTES}")
    import yaml  # deferred: only file loading needs it

    try:
        with open(path, "rb") as handle:  # at most one byte past the limit, in case the file grew since stat
            raw = handle.read(MAX_SCENE_BYTES + 1)
        if len(raw) > MAX_SCENE_BYTES:
            raise SceneError(f"{name}: scene file is over {MAX_SCENE_BYTES} bytes; expected at most {MAX_SCENE_BYTES}")
        text = raw.decode("utf-8")
        data = _load_yaml_without_duplicate_keys(text, name)
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{name}: cannot read scene file ({exc})") from None
    except yaml.YAMLError as exc:
        raise SceneError(f"{name}: not valid YAML ({exc})") from None
    if not isinstance(data, Mapping):
        raise SceneError(f"{name}: expected a mapping with key 'bodies' at the top, got {_kind(data)}")
    return _build(dict(data), name)


def _load_yaml_without_duplicate_keys(text: str, source: str) -> Any:
    """``yaml.safe_load(text)``, except that a key repeated in one mapping is a SceneError.

    PyYAML silently keeps the last of two equal keys, so a scene with two bodies of the same
    name would quietly lose one. The document is composed into nodes first, every mapping is
    checked for repeated keys (with their key path and line numbers), then constructed.
    """
    import yaml

    loader = yaml.SafeLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _reject_duplicate_keys(loader, node, "", source, set())
        return loader.construct_document(node)
    finally:
        loader.dispose()


def _reject_duplicate_keys(loader: Any, node: Any, path: str, source: str, visited: set[int]) -> None:
    import yaml

    if id(node) in visited:  # an alias seen before (also guards against recursive anchors)
        return
    visited.add(id(node))
    if isinstance(node, yaml.MappingNode):
        first_line: dict[Any, int] = {}
        for key_node, value_node in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                _reject_duplicate_keys(loader, value_node, path, source, visited)
                continue
            if not isinstance(key_node, yaml.ScalarNode):  # a collection as a key: validation rejects it
                continue
            key = loader.construct_object(key_node, deep=True)
            key_path = f"{path}.{key}" if path else str(key)
            line = key_node.start_mark.line + 1
            if key in first_line:
                raise SceneError(
                    f"{source}: {key_path}: expected each key once per mapping, got {key!r} again at "
                    f"line {line} (first at line {first_line[key]}); YAML would silently keep only the last"
                )
            first_line[key] = line
            _reject_duplicate_keys(loader, value_node, key_path, source, visited)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _reject_duplicate_keys(loader, item, f"{path}[{i}]", source, visited)


# --------------------------------------------------------------------------- validation


class _Checker:
    """Validation helpers that raise SceneError with the source and key path."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, path: str, expected: str, got: Any = None, *, show_got: bool = True) -> None:
        where = f"{self.source}: {path}" if path else self.source
        suffix = f", got {_show(got)}" if show_got else ""
        raise SceneError(f"{where}: expected {expected}{suffix}")

    def mapping(self, value: Any, path: str, allowed: tuple[str, ...], required: tuple[str, ...] = ()) -> dict:
        if not isinstance(value, Mapping):
            self.fail(path, f"a mapping with keys {list(allowed)}", value)
        for key in value:
            if key not in allowed:
                self.fail(f"{path}.{key}" if path else str(key), f"one of the keys {list(allowed)} (unknown key)", show_got=False)
        for key in required:
            if key not in value:
                self.fail(path, f"required key {key!r}", show_got=False)
        return dict(value)

    def number(self, value: Any, path: str, *, minimum: float | None = None, strict: bool = False, unit: str = "") -> float:
        unit_text = f" ({unit})" if unit else ""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"a number{unit_text}", value)
        x = float(value)
        if not math.isfinite(x):
            self.fail(path, f"a finite number{unit_text}", value)
        if minimum is not None and (x <= minimum if strict else x < minimum):
            self.fail(path, f"a number {'>' if strict else '≥'} {minimum:g}{unit_text}", value)
        return x

    def vector(self, value: Any, path: str, length: int, *, positive: bool = False, unit: str = "") -> np.ndarray:
        what = f"a list of {length} finite numbers" + (" > 0" if positive else "") + (f" ({unit})" if unit else "")
        if not isinstance(value, (list, tuple)) or len(value) != length:
            self.fail(path, what, value)
        out = np.empty(length)
        for i, item in enumerate(value):
            if isinstance(item, bool) or not isinstance(item, (int, float)) or not math.isfinite(float(item)):
                self.fail(path, what, value)
            out[i] = float(item)
        if positive and np.any(out <= 0.0):
            self.fail(path, what, value)
        return out

    def name(self, value: Any, path: str, reserved: set[str]) -> str:
        if not isinstance(value, str) or not _NAME.match(value):
            self.fail(path, "a name of letters, digits and '_' starting with a letter", value)
        if value in reserved:
            self.fail(path, f"a name other than the reserved {sorted(reserved)}", value)
        return value


def _build(data: dict, source: str) -> Scene:
    check = _Checker(source)
    top = check.mapping(data, "", _TOP_KEYS, required=("bodies",))
    gravity = np.zeros(3)
    if top.get("gravity") is not None:
        gravity = check.vector(top["gravity"], "gravity", 3, unit="m/s²")
    energy_growth_limit = DEFAULT_ENERGY_GROWTH_LIMIT
    if top.get("energy_growth_limit") is not None:
        energy_growth_limit = check.number(top["energy_growth_limit"], "energy_growth_limit", minimum=1.0, strict=True,
                                           unit="a factor on the kinetic energy")
    bodies = top["bodies"]
    if not isinstance(bodies, Mapping) or not bodies:
        check.fail("bodies", "a non-empty mapping of body names to bodies", bodies)

    names: list[str] = []
    motions: list[str] = []
    normals: list[np.ndarray] = []
    masses, moments, q_BPs, damp_lin, damp_ang = [], [], [], [], []
    p0, q0, v0, w0 = [], [], [], []
    site_names: list[str] = []
    site_body: list[int] = []
    site_p_P: list[np.ndarray] = []
    site_world: list[bool] = []
    sites_of: dict[str, tuple[str, ...]] = {}

    for index, (raw_name, raw_body) in enumerate(bodies.items()):
        name = check.name(raw_name, f"bodies.{raw_name}", _RESERVED_BODY_NAMES)
        path = f"bodies.{name}"
        body = check.mapping(raw_body, path, _BODY_KEYS, required=("mass", "inertia"))
        mass = check.number(body["mass"], f"{path}.mass", minimum=0.0, strict=True, unit="kg")
        principal, q_BP = _inertia(check, body["inertia"], f"{path}.inertia", mass)

        position = np.zeros(3)
        q_WB = np.array([1.0, 0.0, 0.0, 0.0])
        if body.get("pose") is not None:
            pose = check.mapping(body["pose"], f"{path}.pose", ("position", "orientation"))
            if "position" in pose:
                position = check.vector(pose["position"], f"{path}.pose.position", 3, unit="m")
            if "orientation" in pose:
                q_xyzw = check.vector(pose["orientation"], f"{path}.pose.orientation", 4)
                norm = float(np.linalg.norm(q_xyzw))
                if abs(norm - 1.0) > ORIENTATION_TOLERANCE:
                    check.fail(
                        f"{path}.pose.orientation",
                        f"a unit quaternion [x, y, z, w] (| |q| - 1 | ≤ {ORIENTATION_TOLERANCE:g}; |q| = {norm:.9g})",
                        pose["orientation"],
                    )
                q_WB = quat_wxyz_from_xyzw(q_xyzw / norm)

        v_W = np.zeros(3)
        w_W = np.zeros(3)
        if body.get("twist") is not None:
            twist = check.mapping(body["twist"], f"{path}.twist", ("linear", "angular"))
            if "linear" in twist:
                v_W = check.vector(twist["linear"], f"{path}.twist.linear", 3, unit="m/s, world axes")
            if "angular" in twist:
                w_W = check.vector(twist["angular"], f"{path}.twist.angular", 3, unit="rad/s, world axes")

        motion, normal = "free", np.zeros(3)
        if body.get("motion") is not None:
            motion, normal, v_W, w_W = _motion(check, body["motion"], f"{path}", v_W, w_W)

        c_lin = c_ang = 0.0
        if body.get("damping") is not None:
            damping = check.mapping(body["damping"], f"{path}.damping", ("linear", "angular"))
            if "linear" in damping:
                c_lin = check.number(damping["linear"], f"{path}.damping.linear", minimum=0.0, unit="N·s/m")
            if "angular" in damping:
                c_ang = check.number(damping["angular"], f"{path}.damping.angular", minimum=0.0, unit="N·m·s/rad")

        q_PB = quat_conjugate(q_BP)
        body_sites: list[str] = []
        if body.get("sites") is not None:
            sites = body["sites"]
            if not isinstance(sites, Mapping):
                check.fail(f"{path}.sites", "a mapping of site names to {position: [x, y, z], axes: body|world}", sites)
            for raw_site, raw_spec in sites.items():
                site = check.name(raw_site, f"{path}.sites.{raw_site}", _RESERVED_SITE_NAMES)
                spath = f"{path}.sites.{site}"
                spec = check.mapping(raw_spec, spath, ("position", "axes"), required=("position",))
                p_B = check.vector(spec["position"], f"{spath}.position", 3, unit="m, body frame from the COM")
                axes = spec.get("axes", "body")
                if axes not in ("body", "world"):
                    check.fail(f"{spath}.axes", "'body' or 'world'", axes)
                site_names.append(f"{name}/{site}")
                site_body.append(index)
                site_p_P.append(quat_rotate(q_PB, p_B))
                site_world.append(axes == "world")
                body_sites.append(site)

        names.append(name)
        motions.append(motion)
        normals.append(normal)
        masses.append(mass)
        moments.append(principal)
        q_BPs.append(q_BP)
        damp_lin.append(c_lin)
        damp_ang.append(c_ang)
        q_WP = quat_multiply(q_WB, q_BP)
        p0.append(position)
        q0.append(q_WP)
        v0.append(v_W)
        w0.append(quat_rotate(quat_conjugate(q_WP), w_W))
        sites_of[name] = tuple(body_sites)

    model = BodyModel(
        names=tuple(names),
        mass=np.array(masses),
        inertia_P=np.array(moments),
        q_BP=np.array(q_BPs),
        damping_linear=np.array(damp_lin),
        damping_angular=np.array(damp_ang),
        gravity_W=gravity,
        site_names=tuple(site_names),
        site_body=np.array(site_body, dtype=int),
        site_p_P=np.array(site_p_P).reshape(-1, 3),
        site_world_axes=np.array(site_world, dtype=bool),
        motion=tuple(motions),
        plane_normal_W=np.array(normals).reshape(-1, 3),
    )
    state = State(np.array(p0), np.array(q0), np.array(v0), np.array(w0))
    scene = Scene(source=source, model=model, initial_state=state, sites=sites_of,
                  energy_growth_limit=energy_growth_limit)
    if top.get("wrenches") is not None:
        scene = replace(scene, wrenches=_wrenches(check, top["wrenches"], scene))
    return scene


def _motion(check: _Checker, value: Any, path: str, v_W: np.ndarray, w_W: np.ndarray
            ) -> tuple[str, np.ndarray, np.ndarray, np.ndarray]:
    """The ``motion`` of a body: (kind, unit plane normal or zeros, initial v_W, initial w_W).

    The initial twist must be one the motion allows: none for ``static``; no linear part for
    ``rotation_only``; no angular part for ``translation_only``; for ``planar``, linear
    velocity in the plane and angular velocity along its normal (within PLANAR_TWIST_RTOL,
    then projected exactly).
    """
    where = f"{path}.motion"
    expected = f"one of {list(MOTIONS)}, or {{kind: planar, normal: [x, y, z]}}"
    normal = np.zeros(3)
    if isinstance(value, str):
        kind, spec = value, {}
    elif isinstance(value, Mapping):
        spec = check.mapping(value, where, ("kind", "normal"), required=("kind",))
        kind = spec["kind"]
        where = f"{where}.kind"
    else:
        check.fail(where, expected, value)
        raise AssertionError  # unreachable
    if kind not in MOTIONS:
        check.fail(where, expected, kind)
    if "normal" in spec:
        if kind != "planar":
            check.fail(f"{path}.motion.normal", "no normal unless kind is planar", spec["normal"])
        normal = check.vector(spec["normal"], f"{path}.motion.normal", 3, unit="plane normal, world axes")
        length = float(np.linalg.norm(normal))
        if not length > 0.0:
            check.fail(f"{path}.motion.normal", "a non-zero vector (the plane's normal, world axes)", spec["normal"])
        normal = normal / length
    elif kind == "planar":
        normal = np.array([0.0, 0.0, 1.0])
    twist = f"{path}.twist"
    if kind == "static" and (v_W.any() or w_W.any()):
        check.fail(twist, "no twist for a static body (motion: static)", {"linear": v_W.tolist(), "angular": w_W.tolist()})
    if kind == "rotation_only" and v_W.any():
        check.fail(f"{twist}.linear", "zero linear velocity for motion: rotation_only (the centre of mass stays put)",
                   v_W.tolist())
    if kind == "translation_only" and w_W.any():
        check.fail(f"{twist}.angular", "zero angular velocity for motion: translation_only (the orientation is fixed)",
                   w_W.tolist())
    if kind == "planar":
        off_plane = float(v_W @ normal)
        if abs(off_plane) > PLANAR_TWIST_RTOL * max(float(np.linalg.norm(v_W)), 1e-300):
            check.fail(f"{twist}.linear", f"a velocity in the plane of normal {normal.tolist()} (motion: planar; "
                       f"its normal component is {off_plane:.3g} m/s)", v_W.tolist())
        about_normal = float(w_W @ normal)
        tilt = float(np.linalg.norm(w_W - about_normal * normal))
        if tilt > PLANAR_TWIST_RTOL * max(float(np.linalg.norm(w_W)), 1e-300):
            check.fail(f"{twist}.angular", f"an angular velocity along the plane normal {normal.tolist()} (motion: "
                       f"planar: only yaw; its tilting part is {tilt:.3g} rad/s)", w_W.tolist())
        v_W = v_W - off_plane * normal
        w_W = about_normal * normal
    return kind, normal, v_W, w_W


def _wrenches(check: _Checker, value: Any, scene: Scene) -> tuple[ScriptedWrench, ...]:
    """The ``wrenches`` list: each entry's body, frame (of that body), force, torque and window."""
    if not isinstance(value, (list, tuple)):
        check.fail("wrenches", "a list of {body, frame, force, torque, start, duration} mappings", value)
    out = []
    for i, raw in enumerate(value):
        path = f"wrenches[{i}]"
        entry = check.mapping(raw, path, _WRENCH_KEYS, required=("body", "frame"))
        body = entry["body"]
        if not isinstance(body, str) or body not in scene.sites:
            check.fail(f"{path}.body", f"one of the bodies {list(scene.body_names)}", body)
        frames = scene.frames_of(body)
        if entry["frame"] not in frames:
            check.fail(f"{path}.frame", f"one of the frames of {body!r} {list(frames)}", entry["frame"])
        force = np.zeros(3)
        torque = np.zeros(3)
        if entry.get("force") is not None:
            force = check.vector(entry["force"], f"{path}.force", 3, unit="N, in the frame's axes")
        if entry.get("torque") is not None:
            torque = check.vector(entry["torque"], f"{path}.torque", 3, unit="N·m about the frame's origin, in its axes")
        start = 0.0
        if entry.get("start") is not None:
            start = check.number(entry["start"], f"{path}.start", minimum=0.0, unit="s of sim time")
        duration = math.inf
        if entry.get("duration") is not None:
            duration = check.number(entry["duration"], f"{path}.duration", minimum=0.0, strict=True,
                                    unit="s; leave it out for 'forever'")
        out.append(ScriptedWrench(body, entry["frame"], force, torque, start, duration))
    return tuple(out)


def _inertia(check: _Checker, value: Any, path: str, mass: float) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments and q_BP from one of the inertia forms."""
    if not isinstance(value, Mapping) or len(value) != 1:
        check.fail(path, f"a mapping with exactly one of the keys {list(_INERTIA_KINDS)}", value)
    (kind, arg), = value.items()
    sub = f"{path}.{kind}"
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    if kind == "box":
        moments = box_inertia(mass, check.vector(arg, sub, 3, positive=True, unit="edge lengths x, y, z in m"))
        q_BP = identity
    elif kind == "sphere":
        moments = sphere_inertia(mass, check.number(arg, sub, minimum=0.0, strict=True, unit="radius in m"))
        q_BP = identity
    elif kind == "cylinder":
        radius, length = check.vector(arg, sub, 2, positive=True, unit="[radius, length] in m, axis along body z")
        moments = cylinder_inertia(mass, radius, length)
        q_BP = identity
    elif kind == "principal":
        moments = check.vector(arg, sub, 3, positive=True, unit="Ixx, Iyy, Izz in kg·m²")
        q_BP = identity
    elif kind == "tensor":
        what = "a symmetric positive-definite 3×3 list of lists (kg·m², body frame, about the COM)"
        if not isinstance(arg, (list, tuple)) or len(arg) != 3:
            check.fail(sub, what, arg)
        tensor = np.array([check.vector(row, f"{sub}[{i}]", 3, unit="kg·m²") for i, row in enumerate(arg)])
        scale = float(np.max(np.abs(tensor)))
        if not np.allclose(tensor, tensor.T, rtol=0.0, atol=1e-9 * max(scale, 1e-300)):
            check.fail(sub, what + " (it is not symmetric)", arg)
        if np.any(np.linalg.eigvalsh(0.5 * (tensor + tensor.T)) <= 0.0):
            check.fail(sub, what + " (it is not positive definite)", arg)
        moments, q_BP = principal_frame(tensor)
    else:
        check.fail(path, f"one of the keys {list(_INERTIA_KINDS)}", kind)
        raise AssertionError  # unreachable: fail raises
    problem = check_principal_moments(moments)
    if problem is not None:
        check.fail(sub, problem, show_got=False)
    return np.asarray(moments, dtype=float), np.asarray(q_BP, dtype=float)


def _kind(value: Any) -> str:
    return "nothing (empty file)" if value is None else type(value).__name__


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 120 else text[:117] + "..."
