"""Scenes: load and validate a YAML file or a dict into a model and an initial state.

Schema (every key not listed is an error; see README "Scene files")::

    gravity: [0.0, 0.0, -9.81]            # optional, m/s², world axes; absent = none
    energy_growth_limit: 1.0e6            # optional, > 1: the loud-failure factor (simulator.py)
    bodies:
      crate:                              # a name: ASCII letter first, then letters, digits, _;
                                          # at most MAX_NAME_LENGTH characters (a ROS topic token)
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
          imu_mount: {position: [0, 0, 0.1], imu: {}}           # an IMU on the site (imu_spec.py; {} = ideal)
    ground:                               # optional: static half-spaces n·x ≥ offset, and per body
      - {normal: [0, 0, 1], offset: 0.0}  # material/collision keys: core/contact/scene_keys.py
    wrenches:                             # optional: scripted wrenches over sim time
      - {body: crate, frame: crate/corner, force: [0, 10, 0], torque: [0, 0, 0], start: 0.5, duration: 0.2}

A scripted wrench follows the frame rule (forces.py): force (N) and torque (N·m) about the
origin of ``frame``, in its axes; ``frame`` is one of the body's frames. It acts on every
step whose start time t satisfies ``start ≤ t < start + duration`` (``duration`` absent =
forever); force and torque default to zero, ``start`` to 0.

Validation is complete before anything is built: a scene either loads whole or raises one
:class:`SceneError` naming the source, the key path and what was expected.

Loading takes time linear in the size of the scene: Python's cyclic garbage collector, which
would otherwise run over every object read so far again and again, is paused while a scene is
read and built (:func:`_gc_paused`; nothing the loader makes holds a cycle). A file that is
JSON (YAML's subset) is read by Python's json parser, about 20 times faster than YAML events
(scene_yaml.read_yaml): what ``rigid-body-sim shard`` and the node benchmark write.

Limits, for scenes from users (a scene must never hang, exhaust memory or load and
then fail to run). Files are read as YAML 1.2 by :mod:`~rigid_body_sim.core.scene_yaml`
(aliases counted as what they expand to, no recursion, no tags beyond the core ones), at most
:data:`MAX_SCENE_BYTES`, from a regular file opened without blocking
(:func:`rigid_body_sim.safe_open.read_regular_file`). A scene has at most :data:`MAX_BODIES`
bodies and :data:`MAX_SCRIPTED_WRENCHES` scripted wrenches. Every number is finite; masses,
the lengths of inertia shapes and principal moments are normal floats (≥ :data:`MIN_POSITIVE`,
so that 1/m and 1/I exist: a subnormal mass would fail at step 0), and what the dynamics
form from a scene at t = 0 can be computed in float64 (:func:`_check_derived`): velocities,
momenta, the gyroscopic term, weights, scripted forces and their accelerations are at most
:data:`MAX_NORM` (their squares are finite), and each body's kinetic energy times
``energy_growth_limit`` (the blow-up check's bound) and its potential are finite (a 1e308
moment with spin would load with infinite energy).
"""

from __future__ import annotations

import codecs
import gc
import math
import re
import sys
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..safe_open import FileTooLargeError, NotRegularFileError, read_regular_file
from .imu_spec import IMU_CHANNEL_KEYS, IMU_KEYS, ImuChannel, ImuSpec
from .mass_properties import (
    TRIANGLE_RTOL,
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
)
from .scene_yaml import YamlReadError, key_text, read_yaml

# --- contact (core/contact/scene_keys.py): the keys ground, material, collision -----------------
from .contact.scene_keys import TOP_KEYS as CONTACT_TOP_KEYS
from .contact.scene_keys import ContactSpec, read_contact, without_contact_keys
# --- end contact

__all__ = ["Scene", "SceneError", "ScriptedWrench", "load_scene", "load_scene_text", "WORLD_FRAME",
           "ORIENTATION_TOLERANCE", "DEFAULT_ENERGY_GROWTH_LIMIT", "MAX_SCENE_BYTES", "MAX_BODIES",
           "MAX_SCRIPTED_WRENCHES", "MAX_NAME_LENGTH", "MAX_NAMESPACE_LENGTH", "MIN_POSITIVE",
           "MAX_NORM", "MAX_SCENE_TEXT_CHARS", "MAX_SITES_PER_BODY", "MAX_SITES", "MAX_IMUS_PER_BODY", "MAX_IMUS"]

#: Name of the world frame in the core's frame rule.
WORLD_FRAME = "world"
#: How far | |q| − 1 | may be in a scene file; within it q is normalised, beyond it rejected.
ORIENTATION_TOLERANCE = 1e-6
#: Default ``energy_growth_limit``: a body whose kinetic energy exceeds this factor times the
#: most its initial energy and the work of the applied wrenches and gravity could give it
#: stops the simulator with a DivergenceError (simulator.py).
DEFAULT_ENERGY_GROWTH_LIMIT = 1e6
#: Largest size accepted for a scene file, bytes: room for :data:`MAX_BODIES` bodies written
#: out with a pose and a twist (~250–450 bytes a body with six or seventeen digits a number).
MAX_SCENE_BYTES = 64 * 1024 * 1024
#: Most bodies a scene may have. 10⁵ is what the benchmarks step (benchmarks/throughput.py) and
#: what the node runs with batched output only (ros/session.py says why it stops there). A
#: file of 10⁵ bodies with a mass, a box and a position loads in ~7 s of CPU on the 2-core
#: test machine as YAML (test_hostile measures it, marked slow), a few seconds as JSON.
MAX_BODIES = 100_000
#: Most scripted wrenches a scene may list (each is looked at every step).
MAX_SCRIPTED_WRENCHES = 100_000
#: Longest body or site name, characters. Names become ROS topic tokens: ``<ns>/<body>/pose``,
#: ``<ns>/<body>/<site>/imu``; ROS allows 247 characters in a whole topic name (rmw's
#: RMW_TOPIC_MAX_NAME_LENGTH), so two names of 63 leave :data:`MAX_NAMESPACE_LENGTH`.
MAX_NAME_LENGTH = 63
#: Characters left for the node's namespace (with its leading "/") and a topic suffix of up to
#: 16 characters after the longest body and site names: 247 − (3 · 1 + 2 · 63 + 16).
MAX_NAMESPACE_LENGTH = 247 - (3 + 2 * MAX_NAME_LENGTH + 16)
#: Longest scene text (characters) :func:`load_scene_text` takes: a scene file's bytes written out
#: again as JSON (a spawn or delete edits the running scene's text), with room for what a spawn adds.
MAX_SCENE_TEXT_CHARS = 2 * MAX_SCENE_BYTES
#: Most sites one body may declare, and most in a scene: each is a row of every step's site
#: kinematics and a marker, and a spawn request is checked and built while the node waits.
MAX_SITES_PER_BODY = 1_000
MAX_SITES = 100_000
#: Most IMUs one body may carry, and most in a scene. Each IMU is a ROS publisher, created while
#: the node's executor waits, and a message every tick: one spawned body with 20,000 IMUs held the
#: executor for 6.6-11.8 s; a spawn of 928 IMUs (16 bodies) took 1.9 s on the loaded 2-core test
#: machine, so 256 keep a spawn or scene change to about half a second.
MAX_IMUS_PER_BODY = 64
MAX_IMUS = 256
#: Smallest mass (kg), inertia-shape length (m) and principal moment (kg·m²): the smallest
#: normal float64. Below it 1/m and 1/I overflow and the first step is not finite.
MIN_POSITIVE = sys.float_info.min
#: Largest norm of a velocity, momentum, force, torque or acceleration a scene may give a body
#: at t = 0: the step and the blow-up check square these, and √(1.8e308) ≈ 1.3e154.
MAX_NORM = 1e154

_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_NAME_RULE = "a name of ASCII letters, digits and '_' starting with a letter (it becomes a ROS topic name token)"
_RESERVED_BODY_NAMES = {WORLD_FRAME}
_RESERVED_SITE_NAMES = {"world_aligned"}
_INERTIA_KINDS = ("box", "sphere", "cylinder", "principal", "tensor")
_TOP_KEYS = ("gravity", "bodies", "wrenches", "energy_growth_limit") + CONTACT_TOP_KEYS  # contact: ground
_WRENCH_KEYS = ("body", "frame", "force", "torque", "start", "duration")
_BODY_KEYS = ("mass", "inertia", "pose", "twist", "damping", "sites", "motion")
_IDENTITY = (1.0, 0.0, 0.0, 0.0)
_PLAIN_NUMBERS = frozenset((float, int))
_NO_KEY = object()  # _show: an item of a list, not of a mapping
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
    text : str or None
        The YAML text the scene was read from (decoded; None for a dict), e.g. to attach to a
        recording without reading the file again (it may have changed or been swapped since).
    imus : dict of str to ImuSpec
        The IMUs declared on sites, by site name ``"<body>/<site>"``, in scene order.
    contact : ContactSpec or None
        Ground half-spaces, collision shapes and materials (core/contact/scene_keys.py); None
        when the scene has no ``ground``.
    """

    source: str
    model: BodyModel
    initial_state: State
    sites: Mapping[str, tuple[str, ...]]
    wrenches: tuple[ScriptedWrench, ...] = ()
    energy_growth_limit: float = DEFAULT_ENERGY_GROWTH_LIMIT
    text: str | None = None
    imus: Mapping[str, ImuSpec] = field(default_factory=dict)
    contact: ContactSpec | None = field(default=None, compare=False)  # contact (core/contact)

    @property
    def body_names(self) -> tuple[str, ...]:
        return self.model.names

    def frames_of(self, body: str) -> tuple[str, ...]:
        """Every frame a wrench on ``body`` may be expressed in, e.g. ``("world", "box", ...)``."""
        if body not in self.sites:
            raise ValueError(f"unknown body {_show(body)}; bodies are {_choices(self.body_names)}")
        return (WORLD_FRAME, body, f"{body}/world_aligned") + tuple(
            f"{body}/{s}" for s in self.sites[body]
        )


def load_scene(source: str | Path | Mapping[str, Any]) -> Scene:
    """Load and validate a scene from a YAML file path or an already-parsed dict.

    A file must be a regular file (a FIFO, device or directory is refused without blocking,
    even if the path is swapped for one while loading) of at most :data:`MAX_SCENE_BYTES`, in
    UTF-8 (or UTF-16/32 with a byte-order mark).

    Raises
    ------
    SceneError
        Naming the file (or ``<dict>``), the key path (``bodies.crate.inertia.box``) and what
        was expected. Nothing is half-loaded: the scene is returned whole or not at all.
    """
    if isinstance(source, Mapping):
        with _gc_paused():
            return _build(source, "<dict>")
    path = Path(source)
    name = str(path) if str(path).isprintable() else repr(str(path))[1:-1]  # no control characters in messages
    try:
        raw = read_regular_file(path, MAX_SCENE_BYTES, expected="a YAML file")
    except FileTooLargeError as exc:
        raise SceneError(f"{name}: scene {exc.strerror}") from None
    except NotRegularFileError as exc:
        raise SceneError(f"{name}: cannot read scene file ({exc.strerror})") from None
    except OSError as exc:
        raise SceneError(f"{name}: cannot read scene file ({exc.strerror or exc})") from None
    except ValueError:  # os.open: "embedded null byte"
        raise SceneError(f"{name}: cannot read scene file (the path contains a NUL character)") from None
    return load_scene_text(_decode(raw, name), name)


def load_scene_text(text: str, source: str = "<text>", *, apart: bool = True) -> Scene:
    """Load and validate a scene from YAML text (e.g. a recording's attached scene).

    Parameters
    ----------
    text : str
        The YAML document.
    source : str
        What errors call it (a file name, ``"<text>"``).
    apart : bool
        Refuse bodies whose collision shapes start overlapping (scenes with a ground). False
        for a scene edited at run time, whose other bodies have moved from their initial poses:
        ``~/spawn`` checks the new bodies against their current poses instead.

    Raises
    ------
    SceneError
        As :func:`load_scene`.
    """
    if len(text) > MAX_SCENE_TEXT_CHARS:
        raise SceneError(f"{source}: expected a scene text of at most {MAX_SCENE_TEXT_CHARS:,} characters "
                         f"(MAX_SCENE_TEXT_CHARS), got {len(text):,}")
    with _gc_paused():
        try:
            data = read_yaml(text[1:] if text.startswith("\ufeff") else text)
        except YamlReadError as exc:
            raise SceneError(f"{source}: {exc}") from None
        if not isinstance(data, Mapping):
            raise SceneError(f"{source}: expected a mapping with key 'bodies' at the top, got {_kind(data)}")
        return replace(_build(data, source, apart=apart), text=text)


@contextmanager
def _gc_paused() -> Iterator[None]:
    """Pause Python's cyclic garbage collector for the block (as it was after).

    Reading and building a scene makes millions of small objects (10⁵ bodies: ~3·10⁶) and
    none that holds a reference cycle. Each collection of the oldest generation visits every
    object alive, and they come the more often the more are made, so with the collector on,
    loading grows faster than the scene (measured: 3× the bodies took 6× the time); paused,
    it is linear. Reference counting frees everything as usual.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _decode(raw: bytes, name: str) -> str:
    """A scene file's text: UTF-8 (a BOM is skipped), or UTF-16/UTF-32 with a BOM, as YAML allows."""
    encoding = "utf-8"
    if raw.startswith(codecs.BOM_UTF8):
        raw = raw[len(codecs.BOM_UTF8):]
    elif raw.startswith((codecs.BOM_UTF32_LE, codecs.BOM_UTF32_BE)):  # before UTF-16: FF FE 00 00 starts with FF FE
        encoding = "utf-32"
    elif raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        encoding = "utf-16"
    try:
        return raw.decode(encoding)
    except UnicodeDecodeError as exc:
        raise SceneError(f"{name}: cannot read scene file (not {encoding.upper()}: byte 0x{raw[exc.start]:02x} at "
                         f"offset {exc.start}; expected a YAML file in UTF-8)") from None


# --------------------------------------------------------------------------- validation


def _real(value: Any) -> float | None:
    """``value`` as a float if it is a real number (int or float, not bool; numpy scalars too), else
    None. An integer too large for a float gives ±inf (reported as not finite)."""
    kind = type(value)
    if kind is float:
        return value
    if kind is not int and (isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating))):
        return None
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


class _Checker:
    """Validation helpers that raise SceneError with the source and key path."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, path: str, expected: str, got: Any = None, *, show_got: bool = True) -> None:
        where = f"{self.source}: {path}" if path else self.source
        suffix = f", got {_show(got)}" if show_got else ""
        raise SceneError(f"{where}: expected {expected}{suffix}")

    def mapping(self, value: Any, path: str, allowed: tuple[str, ...], required: tuple[str, ...] = ()) -> Mapping:
        if type(value) is not dict and not isinstance(value, Mapping):
            self.fail(path, f"a mapping with keys {list(allowed)}", value)
        for key in value:
            if key not in allowed:
                self.fail(f"{path}.{key_text(key)}" if path else key_text(key),
                          f"one of the keys {list(allowed)} (unknown key)", show_got=False)
        for key in required:
            if key not in value:
                self.fail(path, f"required key {key!r}", show_got=False)
        return value

    def number(self, value: Any, path: str, *, minimum: float | None = None, strict: bool = False,
               scale: bool = False, unit: str = "") -> float:
        """A finite number (> or ≥ ``minimum``); with ``scale``, a positive normal float (≥ MIN_POSITIVE)."""
        unit_text = f" ({unit})" if unit else ""
        x = _real(value)
        if x is None:
            self.fail(path, f"a number{unit_text}", value)
        if x != x or x in (math.inf, -math.inf):
            self.fail(path, f"a finite number{unit_text}" if not isinstance(value, int)
                      else f"a number within float64's range (±1.8e308){unit_text}", value)
        if minimum is not None and (x <= minimum if strict else x < minimum):
            self.fail(path, f"a number {'>' if strict else '≥'} {minimum:g}{unit_text}", value)
        if scale and x < MIN_POSITIVE:
            self.fail(path, f"a number ≥ {MIN_POSITIVE:.4g}{unit_text}, a normal float64 (1/x must not overflow)", value)
        return x

    def vector(self, value: Any, path: str, length: int, *, positive: bool = False, scale: bool = False,
               unit: str = "") -> list[float]:
        """``length`` finite numbers (> 0 with ``positive``; also ≥ MIN_POSITIVE with ``scale``), as floats."""
        if type(value) is list and len(value) == length and set(map(type, value)) <= _PLAIN_NUMBERS:
            try:  # the common case, quickly (anything unusual goes the careful way below)
                out = list(map(float, value))
            except OverflowError:
                pass
            else:
                if (math.isfinite(sum(out)) and (not positive or min(out) > 0.0)
                        and (not scale or min(out) >= MIN_POSITIVE)):
                    return out
        unit_text = f" ({unit})" if unit else ""
        what = f"a list of {length} finite numbers" + (" > 0" if positive else "") + unit_text
        if not isinstance(value, (list, tuple)) or len(value) != length:
            self.fail(path, what, value)
        out = [_real(item) for item in value]
        for x in out:
            if x is None or x != x or x in (math.inf, -math.inf) or (positive and x <= 0.0):
                self.fail(path, what, value)
        if scale and min(out) < MIN_POSITIVE:
            self.fail(path, f"{length} numbers ≥ {MIN_POSITIVE:.4g}{unit_text}, normal float64s (1/x must not "
                            "overflow)", value)
        return out

    def name(self, value: Any, parent: str, reserved: set[str]) -> str:
        """``value`` as a body or site name under the key path ``parent`` (``bodies``, ``bodies.b.sites``)."""
        if type(value) is str and len(value) <= MAX_NAME_LENGTH and _NAME.fullmatch(value) and value not in reserved:
            return value
        path = f"{parent}.{key_text(value)}"
        if not isinstance(value, str):
            self.fail(path, _NAME_RULE, value)
        if len(value) > MAX_NAME_LENGTH:
            self.fail(path, f"a name of at most {MAX_NAME_LENGTH} characters (topics are <namespace>/<body>/<site>/...; "
                            f"ROS allows 247 characters in all), got {len(value)} characters", show_got=False)
        if not _NAME.fullmatch(value):
            self.fail(path, _NAME_RULE, value)
        if value in reserved:
            self.fail(path, f"a name other than the reserved {sorted(reserved)}", value)
        return value


class _Bodies:
    """What the bodies of a scene declare, gathered body by body (plain lists), in file order."""

    def __init__(self) -> None:
        self.names: list[str] = []
        self.motions: list[str] = []
        self.normals: list[Any] = []
        self.any_motion = False
        self.masses: list[float] = []
        self.moments: list[Any] = []
        self.inertia_paths: list[str] = []
        self.q_BP: list[Any] = []
        self.damping_linear: list[float] = []
        self.damping_angular: list[float] = []
        self.positions: list[list[float]] = []
        self.q_WB: list[tuple[float, float, float, float]] = []
        self.v_W: list[Any] = []
        self.w_W: list[Any] = []
        self.site_names: list[str] = []
        self.site_body: list[int] = []
        self.site_p_B: list[list[float]] = []
        self.site_world: list[bool] = []
        self.sites_of: dict[str, tuple[str, ...]] = {}
        self.imus: dict[str, ImuSpec] = {}


_ZERO3 = [0.0, 0.0, 0.0]


def _build(data: Mapping, source: str, *, apart: bool = True) -> Scene:
    check = _Checker(source)
    top = check.mapping(data, "", _TOP_KEYS, required=("bodies",))
    gravity = _ZERO3
    if top.get("gravity") is not None:
        gravity = check.vector(top["gravity"], "gravity", 3, unit="m/s²")
    energy_growth_limit = DEFAULT_ENERGY_GROWTH_LIMIT
    if top.get("energy_growth_limit") is not None:
        energy_growth_limit = check.number(top["energy_growth_limit"], "energy_growth_limit", minimum=1.0, strict=True,
                                           unit="a factor on the kinetic energy")
    bodies = top["bodies"]
    if not isinstance(bodies, Mapping) or not bodies:
        check.fail("bodies", "a non-empty mapping of body names to bodies", bodies)
    if len(bodies) > MAX_BODIES:
        check.fail("bodies", f"at most {MAX_BODIES:,} bodies, got {len(bodies):,}", show_got=False)

    out = _Bodies()
    with np.errstate(over="ignore", under="ignore"):  # _check_moments reports what over- or underflowed
        for index, (raw_name, raw_body) in enumerate(bodies.items()):
            _read_body(check, index, raw_name, raw_body, out)

    inertia_P = np.array(out.moments, dtype=float).reshape(-1, 3)
    _check_moments(check, inertia_P, out.inertia_paths)
    q_BP = np.array(out.q_BP, dtype=float).reshape(-1, 4)
    q_WP = quat_multiply(np.array(out.q_WB, dtype=float), q_BP)
    w_WP_P = quat_rotate(quat_conjugate(q_WP), np.array(out.w_W, dtype=float).reshape(-1, 3))
    site_index = np.array(out.site_body, dtype=int)
    site_p_P = quat_rotate(quat_conjugate(q_BP[site_index]), np.array(out.site_p_B, dtype=float).reshape(-1, 3))
    model = BodyModel(
        names=tuple(out.names),
        mass=np.array(out.masses, dtype=float),
        inertia_P=inertia_P,
        q_BP=q_BP,
        damping_linear=np.array(out.damping_linear, dtype=float),
        damping_angular=np.array(out.damping_angular, dtype=float),
        gravity_W=np.array(gravity, dtype=float),
        site_names=tuple(out.site_names),
        site_body=site_index,
        site_p_P=site_p_P,
        site_world_axes=np.array(out.site_world, dtype=bool),
        motion=tuple(out.motions),
        plane_normal_W=(np.array(out.normals, dtype=float).reshape(-1, 3) if out.any_motion
                        else np.zeros((len(out.names), 3))),
    )
    state = State(np.array(out.positions, dtype=float).reshape(-1, 3), q_WP,
                  np.array(out.v_W, dtype=float).reshape(-1, 3), w_WP_P)
    scene = Scene(source=source, model=model, initial_state=state, sites=out.sites_of,
                  energy_growth_limit=energy_growth_limit, imus=out.imus)
    if top.get("wrenches") is not None:
        scene = replace(scene, wrenches=_wrenches(check, top["wrenches"], scene))
    _check_derived(check, scene)
    # --- contact: ground, material, collision (core/contact/scene_keys.py)
    scene = replace(scene, contact=read_contact(check, top, model, state, apart=apart))
    # --- end contact
    return scene


def _read_body(check: _Checker, index: int, raw_name: Any, raw_body: Any, out: _Bodies) -> None:
    """Check one body of the ``bodies`` mapping and append what it declares to ``out``."""
    name = check.name(raw_name, "bodies", _RESERVED_BODY_NAMES)
    path = f"bodies.{name}"
    body = check.mapping(without_contact_keys(raw_body), path, _BODY_KEYS, required=("mass", "inertia"))  # contact
    mass = check.number(body["mass"], f"{path}.mass", minimum=0.0, strict=True, scale=True, unit="kg")
    principal, q_BP, inertia_path = _inertia(check, body["inertia"], f"{path}.inertia", mass)

    position = _ZERO3
    q_WB = _IDENTITY
    pose = body.get("pose")
    if pose is not None:
        pose = check.mapping(pose, f"{path}.pose", ("position", "orientation"))
        if "position" in pose:
            position = check.vector(pose["position"], f"{path}.pose.position", 3, unit="m")
        if "orientation" in pose:
            x, y, z, w = check.vector(pose["orientation"], f"{path}.pose.orientation", 4)
            norm = math.hypot(x, y, z, w)
            if abs(norm - 1.0) > ORIENTATION_TOLERANCE:
                check.fail(f"{path}.pose.orientation",
                           f"a unit quaternion [x, y, z, w] (| |q| - 1 | ≤ {ORIENTATION_TOLERANCE:g}; |q| = {norm:.9g})",
                           pose["orientation"])
            q_WB = (w, x, y, z) if norm == 1.0 else (w / norm, x / norm, y / norm, z / norm)

    v_W: Any = _ZERO3
    w_W: Any = _ZERO3
    twist = body.get("twist")
    if twist is not None:
        twist = check.mapping(twist, f"{path}.twist", ("linear", "angular"))
        if "linear" in twist:
            v_W = check.vector(twist["linear"], f"{path}.twist.linear", 3, unit="m/s, world axes")
        if "angular" in twist:
            w_W = check.vector(twist["angular"], f"{path}.twist.angular", 3, unit="rad/s, world axes")

    motion: str = "free"
    normal: Any = _ZERO3
    if body.get("motion") is not None:
        out.any_motion = True
        motion, normal, v_W, w_W = _motion(check, body["motion"], path, np.array(v_W), np.array(w_W))

    c_lin = c_ang = 0.0
    damping = body.get("damping")
    if damping is not None:
        damping = check.mapping(damping, f"{path}.damping", ("linear", "angular"))
        if "linear" in damping:
            c_lin = check.number(damping["linear"], f"{path}.damping.linear", minimum=0.0, unit="N·s/m")
        if "angular" in damping:
            c_ang = check.number(damping["angular"], f"{path}.damping.angular", minimum=0.0, unit="N·m·s/rad")

    body_sites: list[str] = []
    sites = body.get("sites")
    if sites is not None:
        if not isinstance(sites, Mapping):
            check.fail(f"{path}.sites", "a mapping of site names to {position: [x, y, z], axes: body|world}", sites)
        _check_site_counts(check, path, sites, out)
        for raw_site, raw_spec in sites.items():
            site = check.name(raw_site, f"{path}.sites", _RESERVED_SITE_NAMES)
            spath = f"{path}.sites.{site}"
            spec = check.mapping(raw_spec, spath, ("position", "axes", "imu"), required=("position",))
            out.site_p_B.append(check.vector(spec["position"], f"{spath}.position", 3, unit="m, body frame from the COM"))
            axes = spec.get("axes", "body")
            if axes != "body" and axes != "world":
                check.fail(f"{spath}.axes", "'body' or 'world'", axes)
            out.site_names.append(f"{name}/{site}")
            out.site_body.append(index)
            out.site_world.append(axes == "world")
            body_sites.append(site)
            if "imu" in spec:
                out.imus[f"{name}/{site}"] = _imu(check, spec["imu"], f"{spath}.imu")

    out.names.append(name)
    out.motions.append(motion)
    out.normals.append(normal)
    out.masses.append(mass)
    out.moments.append(principal)
    out.inertia_paths.append(inertia_path)
    out.q_BP.append(q_BP)
    out.damping_linear.append(c_lin)
    out.damping_angular.append(c_ang)
    out.positions.append(position)
    out.q_WB.append(q_WB)
    out.v_W.append(v_W)
    out.w_W.append(w_W)
    out.sites_of[name] = tuple(body_sites)


def _check_site_counts(check: _Checker, path: str, sites: Mapping, out: _Bodies) -> None:
    """The limits on sites and IMUs (:data:`MAX_SITES_PER_BODY`, :data:`MAX_IMUS_PER_BODY`,
    :data:`MAX_SITES`, :data:`MAX_IMUS`), checked before any site is read."""
    imus = sum(1 for spec in sites.values() if isinstance(spec, Mapping) and "imu" in spec)
    if imus > MAX_IMUS_PER_BODY:
        check.fail(f"{path}.sites", f"at most {MAX_IMUS_PER_BODY:,} sites with an imu on a body (MAX_IMUS_PER_BODY: "
                   f"each IMU is a ROS publisher), got {imus:,}", show_got=False)
    if len(sites) > MAX_SITES_PER_BODY:
        check.fail(f"{path}.sites", f"at most {MAX_SITES_PER_BODY:,} sites on a body (MAX_SITES_PER_BODY), "
                   f"got {len(sites):,}", show_got=False)
    if len(out.site_names) + len(sites) > MAX_SITES:
        check.fail(f"{path}.sites", f"at most {MAX_SITES:,} sites in a scene (MAX_SITES), got "
                   f"{len(out.site_names) + len(sites):,} up to this body", show_got=False)
    if len(out.imus) + imus > MAX_IMUS:
        check.fail(f"{path}.sites", f"at most {MAX_IMUS:,} IMUs in a scene (MAX_IMUS: each IMU is a ROS publisher), "
                   f"got {len(out.imus) + imus:,} up to this body", show_got=False)


def _imu(check: _Checker, value: Any, path: str) -> ImuSpec:
    """An ``imu:`` mapping (core/imu_spec.py): every key optional; an empty mapping (or null) is an ideal IMU."""
    if value is None:
        return ImuSpec()
    imu = check.mapping(value, path, IMU_KEYS)
    rate = None
    if imu.get("rate") is not None:
        rate = check.number(imu["rate"], f"{path}.rate", minimum=0.0, strict=True, scale=True, unit="Hz of sim time")
    seed = imu.get("seed", 0)
    if type(seed) is not int or not 0 <= seed < 2**63:
        check.fail(f"{path}.seed", "an integer in [0, 2**63)", seed)
    orientation = imu.get("orientation", True)
    if type(orientation) is not bool:
        check.fail(f"{path}.orientation", "true or false", orientation)
    channels = {}
    for key, units in (("accelerometer", ("m/s²/√Hz", "m/s²", "m/s³/√Hz")),
                       ("gyroscope", ("rad/s/√Hz", "rad/s", "rad/s²/√Hz"))):
        raw = imu.get(key)
        if raw is None:
            channels[key] = None
            continue
        cpath = f"{path}.{key}"
        spec = check.mapping(raw, cpath, IMU_CHANNEL_KEYS)
        density = walk = 0.0
        bias = (0.0, 0.0, 0.0)
        if spec.get("noise_density") is not None:
            density = check.number(spec["noise_density"], f"{cpath}.noise_density", minimum=0.0, unit=units[0])
        if spec.get("bias") is not None:
            if isinstance(spec["bias"], (list, tuple)):
                bias = tuple(check.vector(spec["bias"], f"{cpath}.bias", 3, unit=units[1] + ", sensor axes"))
            else:
                b = check.number(spec["bias"], f"{cpath}.bias", unit=units[1] + " on every axis, or [x, y, z]")
                bias = (b, b, b)
        if spec.get("bias_random_walk") is not None:
            walk = check.number(spec["bias_random_walk"], f"{cpath}.bias_random_walk", minimum=0.0, unit=units[2])
        for what, x in (("noise_density", density), ("bias_random_walk", walk), ("bias", max(map(abs, bias)))):
            if x > MAX_NORM:
                check.fail(f"{cpath}.{what}", f"at most {MAX_NORM:g}", x)
        channels[key] = ImuChannel(density, bias, walk)
    return ImuSpec(rate=rate, seed=seed, orientation=orientation, **channels)


def _check_moments(check: _Checker, inertia_P: np.ndarray, paths: list[str]) -> None:
    """Every body's principal moments are finite normal floats and meet I_i + I_j ≥ I_k
    (mass_properties.check_principal_moments, over all bodies at once; its message for the
    first that does not)."""
    with np.errstate(over="ignore", invalid="ignore"):
        total = inertia_P.sum(axis=1, keepdims=True)
        out_of_range = ~np.all(np.isfinite(inertia_P) & (inertia_P >= MIN_POSITIVE), axis=1)
        lopsided = np.any(total - inertia_P < inertia_P * (1.0 - TRIANGLE_RTOL), axis=1)
    for b in np.flatnonzero(out_of_range)[:1]:
        check.fail(paths[b], f"a mass and shape whose principal moments are finite and ≥ {MIN_POSITIVE:.4g} kg·m² "
                             f"(normal float64s), got {_show(inertia_P[b].tolist())} kg·m²", show_got=False)
    for b in np.flatnonzero(lopsided)[:1]:
        problem = check_principal_moments(inertia_P[b])
        check.fail(paths[b], problem or "principal moments satisfying the triangle inequality", show_got=False)


def _check_derived(check: _Checker, scene: Scene) -> None:
    """What the dynamics form from the scene at t = 0 is finite, so that the scene can run.

    Per body, the norms the step and the blow-up check square are at most :data:`MAX_NORM`:
    |v|, |ω|, the momenta m|v| and |Iω|, the gyroscopic term |ω × Iω| and the weight m|g|;
    the kinetic energy K = ½ m |v|² + ½ ωᵀ I ω times ``energy_growth_limit`` (the blow-up
    check compares K with that factor times its bound) and the potential m|g||p| are finite.
    Per scripted wrench: |F|, |τ| + |r||F| (r the frame's origin from the centre of mass),
    |F|/m and (|τ| + |r||F|)/I_min are at most :data:`MAX_NORM`. Past these the first step
    (or the step a wrench starts) would not be finite.
    """
    model, state = scene.model, scene.initial_state
    m, inertia, w_P = model.mass, model.inertia_P, state.w_WP_P
    speed, w_norm, p_norm = _norms(state.v_WC_W), _norms(w_P), _norms(state.p_WC_W)
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        L_P = inertia * w_P
        kinetic = 0.5 * (m * speed) * speed + 0.5 * np.sum(w_P * L_P, axis=1)
        squared = {  # norms the step and the blow-up check square: each ≤ MAX_NORM
            "speed |v|": speed,
            "angular velocity |ω|": w_norm,
            "linear momentum m|v|": m * speed,
            "angular momentum |Iω|": _norms(L_P),
            "gyroscopic term |ω × Iω|": _norms(np.cross(w_P, L_P)),
            "weight m|g|": m * math.hypot(*model.gravity_W),
        }
        finite = {
            f"kinetic energy ½m|v|² + ½ωᵀIω times energy_growth_limit = {scene.energy_growth_limit:g} (the blow-up "
            "check's bound)": kinetic * scene.energy_growth_limit,
            "gravitational potential m|g||p|": m * math.hypot(*model.gravity_W) * p_norm,
        }
    problems = [(what, values > MAX_NORM, f"at most {MAX_NORM:g}") for what, values in squared.items()]
    problems += [(what, ~np.isfinite(values), "finite") for what, values in finite.items()]
    for what, bad, bound in problems:
        for b in np.flatnonzero(bad | np.isnan(kinetic))[:1]:
            check.fail(f"bodies.{model.names[b]}", f"a body whose initial {what} is {bound} (the first step could not be "
                       f"computed in float64); mass {m[b]:.3g} kg, principal moments {_show(inertia[b].tolist())} kg·m², "
                       f"|v| {speed[b]:.3g} m/s, |ω| {w_norm[b]:.3g} rad/s, |p| {p_norm[b]:.3g} m", show_got=False)
    for i, wrench in enumerate(scene.wrenches):
        b = model.names.index(wrench.body)
        if wrench.frame == WORLD_FRAME:  # about the world origin: the lever arm is the body's position
            lever = float(p_norm[b])
        elif wrench.frame in model.site_names:
            lever = math.hypot(*model.site_p_P[model.site_names.index(wrench.frame)])
        else:  # the body frame or body/world_aligned: at the centre of mass
            lever = 0.0
        force, torque = math.hypot(*wrench.force), math.hypot(*wrench.torque)
        with np.errstate(over="ignore", invalid="ignore"):
            linear = force / float(m[b])
            angular = (torque + lever * force) / float(np.min(inertia[b]))
        if not max(force, torque + lever * force, linear, angular) <= MAX_NORM:
            check.fail(f"wrenches[{i}]", f"a wrench whose force, torque about the centre of mass and accelerations of "
                       f"{wrench.body!r} are at most {MAX_NORM:g} (|F| = {force:.3g} N, |τ| + |r||F| = "
                       f"{torque + lever * force:.3g} N·m, |F|/m = {linear:.3g} m/s², (|τ| + |r||F|)/I_min = "
                       f"{angular:.3g} rad/s²; the step squares them)", show_got=False)


def _norms(vectors: np.ndarray) -> np.ndarray:
    """|x| of each row of an (N, 3) array, without overflow where the norm itself is finite."""
    return np.hypot(np.hypot(vectors[:, 0], vectors[:, 1]), vectors[:, 2])


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
        normal = np.array(check.vector(spec["normal"], f"{path}.motion.normal", 3, unit="plane normal, world axes"))
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
    if len(value) > MAX_SCRIPTED_WRENCHES:
        check.fail("wrenches", f"at most {MAX_SCRIPTED_WRENCHES:,} scripted wrenches, got {len(value):,}", show_got=False)
    out = []
    for i, raw in enumerate(value):
        path = f"wrenches[{i}]"
        entry = check.mapping(raw, path, _WRENCH_KEYS, required=("body", "frame"))
        body = entry["body"]
        if not isinstance(body, str) or body not in scene.sites:
            check.fail(f"{path}.body", f"one of the bodies {_choices(scene.body_names)}", body)
        frames = scene.frames_of(body)
        frame = entry["frame"]
        if not isinstance(frame, str) or frame not in frames:
            check.fail(f"{path}.frame", f"one of the frames of {body!r} {_choices(frames)}", frame)
        force = torque = [0.0, 0.0, 0.0]
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
        out.append(ScriptedWrench(body, frame, np.array(force, dtype=float), np.array(torque, dtype=float), start,
                                  duration))
    return tuple(out)


def _inertia(check: _Checker, value: Any, path: str, mass: float) -> tuple[np.ndarray, tuple | np.ndarray, str]:
    """Principal moments, q_BP and the key path of the inertia form (``<path>.box``...).

    The triangle inequality and the moments' range are checked for all bodies at once afterwards.
    """
    if not isinstance(value, Mapping) or len(value) != 1:
        check.fail(path, f"a mapping with exactly one of the keys {list(_INERTIA_KINDS)}", value)
    (kind, arg), = value.items()
    sub = f"{path}.{key_text(kind)}"
    q_BP: tuple | np.ndarray = _IDENTITY
    if kind == "box":
        moments = box_inertia(mass, check.vector(arg, sub, 3, positive=True, scale=True, unit="edge lengths x, y, z in m"))
    elif kind == "sphere":
        moments = sphere_inertia(mass, check.number(arg, sub, minimum=0.0, strict=True, scale=True, unit="radius in m"))
    elif kind == "cylinder":
        radius, length = check.vector(arg, sub, 2, positive=True, scale=True,
                                      unit="[radius, length] in m, axis along body z")
        moments = cylinder_inertia(mass, radius, length)
    elif kind == "principal":
        moments = np.array(check.vector(arg, sub, 3, positive=True, scale=True, unit="Ixx, Iyy, Izz in kg·m²"))
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
    return moments, q_BP, sub


def _kind(value: Any) -> str:
    return "nothing (empty file)" if value is None else type(value).__name__


def _choices(values: Any, limit: int = 12) -> str:
    """Names (validated, short) as a list, the first ``limit`` of them when there are more."""
    values = list(values)
    shown = ", ".join(repr(v) if isinstance(v, str) and len(v) <= 100 else _show(v) for v in values[:limit])
    return f"[{shown}]" if len(values) <= limit else f"[{shown}, ... and {len(values) - limit} more]"


def _show(value: Any, limit: int = 120) -> str:
    """A short ``repr`` of ``value`` for an error message: at most ``limit`` characters, found
    without walking more of ``value`` than it shows (an alias bomb shares 10⁹ elements)."""
    parts: list[str] = []
    _show_into(value, parts, [limit + 1], depth=0)
    text = "".join(parts)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _show_into(value: Any, parts: list[str], budget: list[int], depth: int) -> None:
    if budget[0] <= 0:
        return
    if isinstance(value, bool) or value is None or isinstance(value, float):
        text = repr(value)
    elif isinstance(value, int):
        bits = value.bit_length()
        text = (repr(value) if bits <= 64 else f"an integer of {len(str(abs(value)))} digits" if bits < 13_000
                else f"an integer of about {int(bits * math.log10(2)) + 1} digits")
    elif isinstance(value, str):
        text = repr(value[:40]) + (f"...({len(value)} characters)" if len(value) > 40 else "")
    elif isinstance(value, (list, tuple, Mapping)) and depth >= 3:
        text = "[...]" if not isinstance(value, Mapping) else "{...}"
    elif isinstance(value, (list, tuple)):
        _show_items(((_NO_KEY, item) for item in value), len(value), "[]", "items", parts, budget, depth, 8)
        return
    elif isinstance(value, Mapping):
        _show_items(iter(value.items()), len(value), "{}", "keys", parts, budget, depth, 6)
        return
    else:
        text = f"<{type(value).__name__}>"
    parts.append(text)
    budget[0] -= len(text)


def _show_items(pairs: Any, count: int, brackets: str, noun: str, parts: list[str], budget: list[int], depth: int,
                most: int) -> None:
    """The first ``most`` of (key or _NO_KEY, item) ``pairs`` inside ``brackets``, within the budget."""
    parts.append(brackets[0])
    budget[0] -= 1
    for i, (key, item) in enumerate(pairs):
        if budget[0] <= 0:
            return
        if i:
            parts.append(", ")
            budget[0] -= 2
        if i == most:
            parts.append(f"...({count} {noun})")
            budget[0] -= 12
            break
        if key is not _NO_KEY:
            _show_into(key, parts, budget, depth + 1)
            parts.append(": ")
            budget[0] -= 2
        _show_into(item, parts, budget, depth + 1)
    parts.append(brackets[1])
    budget[0] -= 1
