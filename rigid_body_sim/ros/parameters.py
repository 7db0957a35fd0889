"""The node's parameters, all in one table: name, type, default, range, description, and whether
a change is allowed while running.

:data:`PARAMETERS` drives everything else: the declarations (a full
rcl_interfaces/ParameterDescriptor per parameter, with its FloatingPointRange or IntegerRange,
so ``ros2 param describe`` and ``describe_parameters`` show the valid values), the one
validation :func:`problem` used at start-up and for every change, the coercion of whole
numbers for float parameters, ``config/params.yaml`` (:func:`params_yaml`) and the README's
parameter table (:func:`markdown_table`); ``python -m rigid_body_sim.ros.parameters`` prints
both, and a test checks that the files in the repository equal them.

What a change *does* is the node's business (``node.py``); this module only says whether a
value is acceptable.
"""

from __future__ import annotations

import array
import difflib
import json
import math
import sys
from dataclasses import dataclass
from typing import Any, Callable, Mapping

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..core import INTEGRATORS
from ..core.kernels.parallel import MIN_BODIES as PARALLEL_MIN_BODIES
from ..core.kernels.parallel import max_threads
from ..core.scene import MAX_NAMESPACE_LENGTH
from ..offline.recording import check_record_path
from ..package_data import default_scene_path
from .file_access import default_scene_dirs

__all__ = [
    "ParameterSpec",
    "PARAMETERS",
    "BY_NAME",
    "NODE_NAME",
    "coerce",
    "coerce_parameters",
    "declare_parameters",
    "namespace_problem",
    "MIN_DIAGNOSTICS_PERIOD_S",
    "MAX_MARKER_RATE_HZ",
    "problem",
    "problems",
    "change_problems",
    "misspelt_parameters",
    "params_yaml",
    "markdown_table",
]

#: Default node name (the key of ``config/params.yaml``).
NODE_NAME = "rigid_body_sim"

_TYPE_NAMES = {
    Parameter.Type.BOOL: "bool",
    Parameter.Type.INTEGER: "integer",
    Parameter.Type.DOUBLE: "double",
    Parameter.Type.STRING: "string",
    Parameter.Type.STRING_ARRAY: "string array",
}


@dataclass(frozen=True)
class ParameterSpec:
    """One node parameter.

    Attributes
    ----------
    name : str
        Parameter name.
    type : rclpy.parameter.Parameter.Type
        BOOL, INTEGER, DOUBLE or STRING (a DOUBLE also takes a whole number, converted).
    default : Any
        Value when not overridden; None for ``scene`` (the installed default scene, found at run time).
    description : str
        One sentence with units; shown by ``describe_parameters`` and in the README.
    range : (low, high), optional
        Inclusive bounds of an INTEGER or DOUBLE (FloatingPointRange / IntegerRange).
    read_only : bool
        True: only settable at start-up.
    choices : tuple of str
        The only accepted values of a STRING, if not empty.
    constraints : str
        Further constraints in words (``additional_constraints``), beyond range and choices.
    check : callable, optional
        ``check(value) -> reason or None``: a constraint that needs code (paths, frame names).
    takes_effect : str
        When an accepted change takes effect (README).
    node_owned : bool
        The node sets the value (``body_names``); any value from outside, at start-up or later,
        is refused.
    default_text : str
        The default in words where :attr:`default` is None (computed from the installation).
    """

    name: str
    type: Parameter.Type
    default: Any
    description: str
    range: tuple[float, float] | None = None
    read_only: bool = False
    choices: tuple[str, ...] = ()
    constraints: str = ""
    check: Callable[[Any], str | None] | None = None
    takes_effect: str = "at the next tick"
    node_owned: bool = False
    default_text: str = ""

    def default_value(self) -> Any:
        """The default, with ``scene``'s and ``scene_dirs``' computed from the installation."""
        if self.name == "scene":
            return str(default_scene_path())
        if self.name == "scene_dirs":
            return default_scene_dirs()
        return self.default

    def additional_constraints(self) -> str:
        """The constraints in words: choices, range and :attr:`constraints`."""
        parts = []
        if self.choices:
            parts.append(f"one of {list(self.choices)}")
        if self.range is not None:
            parts.append(f"from {_fmt(self.range[0])} to {_fmt(self.range[1])}, inclusive")
        if self.constraints:
            parts.append(self.constraints)
        if self.read_only:
            parts.append("read-only: set at start-up only")
        if self.node_owned:
            parts.append("read-only: set by the node, never by a client")
        return "; ".join(parts)

    def descriptor(self) -> ParameterDescriptor:
        """The full ParameterDescriptor: type, description, constraints, range, read_only."""
        descriptor = ParameterDescriptor(name=self.name, type=self.type.value, description=self.description,
                                         additional_constraints=self.additional_constraints(),
                                         read_only=self.read_only or self.node_owned, dynamic_typing=False)
        if self.range is not None and self.type is Parameter.Type.DOUBLE:
            descriptor.floating_point_range = [FloatingPointRange(from_value=float(self.range[0]),
                                                                  to_value=float(self.range[1]), step=0.0)]
        elif self.range is not None and self.type is Parameter.Type.INTEGER:
            descriptor.integer_range = [IntegerRange(from_value=int(self.range[0]), to_value=int(self.range[1]),
                                                     step=1)]
        return descriptor

    def expected(self) -> str:
        """What a valid value is, in words (for error messages)."""
        kind = {Parameter.Type.BOOL: "a bool (true or false)", Parameter.Type.INTEGER: "a whole number",
                Parameter.Type.DOUBLE: "a finite number (double)", Parameter.Type.STRING: "a string",
                Parameter.Type.STRING_ARRAY: "a list of strings"}[self.type]
        extra = self.additional_constraints()
        return f"{kind}, {extra}" if extra else kind


def _fmt(value: float) -> str:
    return f"{value:g}"


def _check_scene_path(value: str) -> str | None:
    if not value:
        return "scene must be the path of a scene YAML file, got ''"
    return None


def _check_dirs(name: str) -> Callable[[Any], str | None]:
    def check(value: Any) -> str | None:
        if any(not d or "\0" in d for d in value):
            return f"{name} must list directories (non-empty paths), got {list(value)!r}"
        return None
    return check


#: Shortest ``diagnostics_period`` (s) other than 0: at most 10 DiagnosticArray messages a second
#: (each is built under the node's lock; a period of 1e-9 s flooded /diagnostics at 10 k msgs/s).
MIN_DIAGNOSTICS_PERIOD_S = 0.1
#: Highest ``marker_rate_hz``: a MarkerArray holds every body's shape, sites and wrenches, so its
#: rate is bounded (and it is at most once a tick anyway).
MAX_MARKER_RATE_HZ = 1000.0


def _check_diagnostics_period(value: float) -> str | None:
    if 0.0 < value < MIN_DIAGNOSTICS_PERIOD_S:
        return (f"diagnostics_period must be 0 (none) or at least {MIN_DIAGNOSTICS_PERIOD_S:g} s (the limit on "
                f"/diagnostics: at most {1 / MIN_DIAGNOSTICS_PERIOD_S:g} messages a second); got {value!r}")
    return None


def _check_threads(value: int) -> str | None:
    if value > max_threads():
        return (f"threads must be 0 (every core) or at most {max_threads()} (NUMBA_NUM_THREADS on this machine), "
                f"got {value!r}")
    return None


def _check_world_frame(value: str) -> str | None:
    if not value or "/" in value or any(c.isspace() for c in value):
        return f"world_frame must be a non-empty frame name without '/' or spaces, got {value!r}"
    return None


def _check_frame_prefix(value: str) -> str | None:
    if any(c.isspace() for c in value) or value.startswith("/"):
        return f"frame_prefix must be '' or a frame-name prefix without spaces or a leading '/' (e.g. 'robot1/'), got {value!r}"
    return None


def _check_record_path(value: str) -> str | None:
    # Only the text here: the file system is looked at once the path is known to be inside
    # record_dirs (file_access.py), so a refusal never tells whether a path elsewhere exists.
    if "\0" in value:
        return "record_path rejected: the path contains a NUL character"
    return None


_T = Parameter.Type

#: Every parameter of the node, in the order of the README and config/params.yaml.
PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec("scene", _T.STRING, None,
                  "Path of the scene YAML file (default: the installed config/default_scene.yaml). A change "
                  "loads and checks the new file, then swaps the whole scene (its initial state at t = 0, "
                  "holds and pending impulses dropped), or is refused with the loader's message.",
                  constraints="a regular file holding a valid scene (at run time: a .yaml or .yml file inside "
                  "scene_dirs)", check=_check_scene_path,
                  takes_effect="at once (t = 0)"),
    ParameterSpec("integrator", _T.STRING, "rk4",
                  "Integrator of free bodies (docs/choosing_an_integrator.md).",
                  choices=tuple(sorted(INTEGRATORS))),
    ParameterSpec("model_reduction", _T.BOOL, True,
                  "Give each body the cheapest exact model for what it is and what the scene declares "
                  "(docs/scenes.md); false steps every free body with the integrator."),
    ParameterSpec("sleeping", _T.BOOL, False,
                  "Lock the bodies resting on bodies (islands) or alone on the ground that stayed slower than "
                  "sleep_speed, each group of them "
                  "until a wrench, a state change or a moving body within reach wakes it (docs/contact.md, "
                  "'Sleeping'): a pile at rest then costs little. False steps every island body; turning it off "
                  "wakes every sleeping body. No effect in a scene without contact."),
    ParameterSpec("sleep_speed", _T.DOUBLE, 1e-9,
                  "Speed (m/s, spin × bounding radius included) below which resting bodies fall asleep while "
                  "sleeping is on. 1e-9 is rest to round-off: locked where they stand. Raised (MuJoCo's "
                  "sleep_tolerance is 1e-3), a group must stay for 10 steps within that speed × 10 steps of where "
                  "it began them (its mean speed below it: jittering in place is rest) and is then stopped where "
                  "it is, creeping or not (its kinetic energy dropped): a pile sleeps sooner.",
                  range=(1e-9, 1e3)),
    ParameterSpec("penetration_tolerance", _T.DOUBLE, 0.0,
                  "Depth (m) to which bodies resting on bodies may overlap before they are moved apart. 0 is exact "
                  "(1e-12 × a body's size). Raised (1e-5: ten micrometres), a landing pile skips most of that "
                  "correction and steps about 1.7 times as fast (docs/contact.md, 'Penetration tolerance'). A body "
                  "touching no other body keeps its exact contact. No effect in a scene without contact.",
                  range=(0.0, 1e-2)),
    ParameterSpec("threads", _T.INTEGER, 0,
                  "Threads the physics step may use over the bodies: 0 = every core (NUMBA_NUM_THREADS, by default "
                  f"the CPU count). The step runs in parallel only from {PARALLEL_MIN_BODIES} moving bodies; the results "
                  "are the same to the bit for any count (docs/performance.md).",
                  range=(0, 1024), constraints="at most NUMBA_NUM_THREADS", check=_check_threads),
    ParameterSpec("rate_hz", _T.DOUBLE, 100.0, "Ticks per wall-clock second (Hz).", range=(0.001, 100000.0)),
    ParameterSpec("substeps", _T.INTEGER, 1,
                  "Physics steps per tick; dt = real_time_factor / (rate_hz * substeps) seconds.",
                  range=(1, 100000)),
    ParameterSpec("real_time_factor", _T.DOUBLE, 1.0, "Sim seconds per wall-clock second.", range=(1e-6, 1e6)),
    ParameterSpec("world_frame", _T.STRING, "world",
                  "frame_id of the world: header.frame_id of poses, and of wrenches given in world axes.",
                  read_only=True, constraints="no '/' or spaces", check=_check_world_frame,
                  takes_effect="start-up only"),
    ParameterSpec("frame_prefix", _T.STRING, "",
                  "Put in front of every frame id the node writes (headers of poses, batches, odometry, IMU, "
                  "markers; child frames; /tf and /tf_static) and expects in wrench, impulse and set_state "
                  "headers, as robot_state_publisher's frame_prefix: 'sim1/' makes the world 'sim1/world' and "
                  "body B 'sim1/B'.",
                  read_only=True, constraints="no spaces or leading '/'", check=_check_frame_prefix,
                  takes_effect="start-up only"),
    ParameterSpec("publish_clock", _T.BOOL, True, "Publish /clock (rosgraph_msgs/Clock) with sim time every tick."),
    ParameterSpec("publish_odometry", _T.BOOL, False,
                  "Also publish B/odom (nav_msgs/Odometry, twist in B's body axes) for every body B."),
    ParameterSpec("per_body_topics", _T.BOOL, True,
                  "Publish B/pose, B/twist (and B/odom) for every body B besides the batches poses and "
                  "velocities; false: only the batches (and, unless per_body_inputs says otherwise, no per-body "
                  "inputs). False also lifts the node's body limit from 1000 to 100000.",
                  read_only=True, takes_effect="start-up only"),
    ParameterSpec("per_body_inputs", _T.STRING, "auto",
                  "Subscribe to B/wrench, B/impulse and B/set_state for every body B, besides the shared "
                  "wrench, impulse and set_state topics (always there; keyed by the message's frame). "
                  "'auto': as per_body_topics (per-body inputs with per-body topics, none with batches only, "
                  "so a swarm costs no DDS endpoint a body); 'true' or 'false' to choose.",
                  choices=("auto", "true", "false"), read_only=True, takes_effect="start-up only"),
    ParameterSpec("twist_stamped", _T.BOOL, False,
                  "Publish B/twist as geometry_msgs/TwistStamped (the stamp and frame_id of B/pose) instead "
                  "of Twist.", read_only=True, takes_effect="start-up only"),
    ParameterSpec("body_names", _T.STRING_ARRAY, None,
                  "The scene's body names in scene order: the order of poses and velocities. Set by the node "
                  "at start-up and on every scene change.", node_owned=True, takes_effect="set by the node"),
    ParameterSpec("paused", _T.BOOL, False, "When true, sim time advances only through ~/step."),
    ParameterSpec("wrench_timeout", _T.DOUBLE, 0.5,
                  "Sim seconds a received wrench stays applied; 0 = until replaced or cleared.",
                  range=(0.0, 1e9)),
    ParameterSpec("status_period", _T.DOUBLE, 1.0, "Wall seconds between status log lines; 0 = none.",
                  range=(0.0, 1e6), takes_effect="at once"),
    ParameterSpec("diagnostics_period", _T.DOUBLE, 1.0,
                  "Wall seconds between DiagnosticArray messages on /diagnostics; 0 = none. At least "
                  f"{MIN_DIAGNOSTICS_PERIOD_S:g} s otherwise, so no client can flood /diagnostics.",
                  range=(0.0, 1e6), constraints=f"0 or at least {MIN_DIAGNOSTICS_PERIOD_S:g}",
                  check=_check_diagnostics_period, takes_effect="at once"),
    ParameterSpec("record_path", _T.STRING, "",
                  "MCAP file to record to (B/pose and B/twist, or with per_body_topics false the poses and "
                  "velocities batches; B/wrench, /clock; ROS 2 messages, stamps = sim time); '' = no recording. "
                  "A change finishes the current file and starts the new one.",
                  constraints="'' or the path of a new file in a writable directory (at run time: an .mcap file inside record_dirs); "
                  "never the scene file, the file being recorded, or an existing file the node did not create "
                  "(unless record_overwrite)",
                  check=_check_record_path, takes_effect="at once"),
    ParameterSpec("scene_dirs", _T.STRING_ARRAY, None,
                  "Directories a run-time change of scene may read from (a .yaml or .yml file inside one of "
                  "them, symlinks resolved); any other path is refused without being looked at. Relative "
                  "paths are from the working directory. The start-up scene is not confined.",
                  read_only=True, check=_check_dirs("scene_dirs"), takes_effect="start-up only",
                  default_text="the installed `config/` and `.` (the working directory)"),
    ParameterSpec("record_dirs", _T.STRING_ARRAY, ["."],
                  "Directories a run-time change of record_path may write in (an .mcap file, symlinks resolved); any other "
                  "path is refused without being looked at. Relative paths are from the working directory. "
                  "The start-up record_path is not confined.",
                  read_only=True, check=_check_dirs("record_dirs"), takes_effect="start-up only"),
    ParameterSpec("record_overwrite", _T.BOOL, False,
                  "Allow a recording to overwrite an existing file the node did not create. False: such a "
                  "record_path is refused (at start-up too). Never the scene file or the file being recorded.",
                  read_only=True, takes_effect="start-up only"),
    ParameterSpec("marker_rate_hz", _T.DOUBLE, 10.0,
                  "MarkerArray on 'markers' (bodies' shapes, sites, held wrenches in world_frame) per sim "
                  f"second, at most once a tick and only while subscribed; 0 = none. At most {MAX_MARKER_RATE_HZ:g}, "
                  "so no client can flood 'markers'.", range=(0.0, MAX_MARKER_RATE_HZ)),
    ParameterSpec("marker_wrenches", _T.BOOL, True,
                  "Draw each held wrench's force as an arrow from its frame's origin in 'markers'."),
    ParameterSpec("marker_force_scale", _T.DOUBLE, 0.05,
                  "Length of a wrench arrow, and of a contact force arrow, in 'markers' per newton (m/N).",
                  range=(1e-9, 1e9)),
    ParameterSpec("publish_contact_wrench", _T.BOOL, False,
                  "Publish B/contact_wrench (geometry_msgs/WrenchStamped) after every tick for every body B with a "
                  "collision shape, in a scene with ground contact: the contacts' mean force and torque on B over the "
                  "tick (the ground, static shapes, and the bodies it rests on or that rest on it; frame "
                  "B/world_aligned).",
                  takes_effect="from the first tick that starts after the change"),
)

#: :data:`PARAMETERS` by name.
BY_NAME: dict[str, ParameterSpec] = {spec.name: spec for spec in PARAMETERS}


def coerce(spec: ParameterSpec, value: Any) -> Any:
    """``value`` as the parameter's type where that is lossless: a whole number for a DOUBLE is a float;
    ``true``/``false`` (parsed by ROS as a bool) for a string whose choices include them."""
    if spec.type is Parameter.Type.DOUBLE and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if spec.type is Parameter.Type.STRING and isinstance(value, bool) and str(value).lower() in spec.choices:
        return str(value).lower()
    return value


def coerce_parameters(parameters: list[Parameter]) -> list[Parameter]:
    """The node's pre-set callback: whole numbers for float parameters are floats (``rate_hz:=200`` means
    200.0), and ``per_body_inputs:=true`` is the string ``"true"``."""
    def as_declared(param: Parameter) -> Parameter:
        spec = BY_NAME.get(param.name)
        if spec is None or spec.type not in (Parameter.Type.DOUBLE, Parameter.Type.STRING):
            return param
        value = coerce(spec, param.value)
        return param if value is param.value else Parameter(param.name, spec.type, value)
    return [as_declared(param) for param in parameters]


def problem(name: str, value: Any) -> str | None:
    """Why ``value`` is not acceptable for parameter ``name`` (type, finiteness, range, choices,
    constraints), or None. Call it with coerced values (:func:`coerce`)."""
    spec = BY_NAME.get(name)
    if spec is None:
        return f"{name!r} is not a parameter of this node; expected one of {list(BY_NAME)}"
    if spec.node_owned:
        return (f"{name} is read-only: the node sets it (the scene's body names in scene order); "
                f"got a request to set it to {value!r}")
    given = _type_name_of(value)
    if given != _TYPE_NAMES[spec.type]:
        shown = value.tolist() if isinstance(value, array.array) else value
        return f"{name} must be {_with_article(_TYPE_NAMES[spec.type])}, got {_with_article(given)} ({shown!r}): wrong type"
    if spec.type is Parameter.Type.DOUBLE and not math.isfinite(value):
        return f"{name} must be a finite double, {spec.expected()}; got {value!r}"
    if spec.range is not None and not spec.range[0] <= value <= spec.range[1]:
        return f"{name} out of range: must be {spec.expected()}; got {value!r}"
    if spec.choices and value not in spec.choices:
        return f"{name} must be one of {list(spec.choices)}, got {value!r}"
    if spec.check is not None:
        return spec.check(value)
    return None


def _type_name_of(value: Any) -> str:
    """The ROS parameter type of a Python value, in the words of :data:`_TYPE_NAMES`."""
    if value is None:
        return "unset value"
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "double"
    if isinstance(value, str):
        return "string"
    if isinstance(value, (bytes, bytearray)) or (isinstance(value, (list, tuple)) and value
                                                 and all(isinstance(v, bytes) for v in value)):
        return "byte array"
    if isinstance(value, array.array):
        return "double array" if value.typecode in "fd" else "integer array"
    if isinstance(value, (list, tuple)):
        kinds = {_type_name_of(v) for v in value}
        return f"{kinds.pop()} array" if len(kinds) == 1 else ("string array" if not value else "mixed array")
    return type(value).__name__


def _with_article(words: str) -> str:
    return f"{'an' if words[0] in 'aeiou' else 'a'} {words}"


def change_problems(values: Mapping[str, Any]) -> list[str]:
    """:func:`problems` of a change at run time, read-only parameters refused first."""
    read_only = [f"{name} is read-only: set at start-up only (--ros-args -p {name}:=...); got a request to set "
                 f"it to {values[name]!r}" for name in values if name in BY_NAME and BY_NAME[name].read_only]
    return read_only + problems(values)


def problems(values: Mapping[str, Any]) -> list[str]:
    """:func:`problem` of every (name, value), in table order; empty if all are acceptable."""
    order = {spec.name: k for k, spec in enumerate(PARAMETERS)}
    reasons = (problem(name, values[name]) for name in sorted(values, key=lambda n: order.get(n, len(order))))
    return [reason for reason in reasons if reason]


def namespace_problem(namespace: str) -> str | None:
    """Why the node's ``namespace`` is too long for its topics, or None.

    Topics are ``<namespace>/<body>/<site>/imu`` and the like, with body and site names of up to
    :data:`~rigid_body_sim.core.scene.MAX_NAME_LENGTH` characters, and ROS takes 247 characters
    in a topic name: the namespace may have :data:`~rigid_body_sim.core.scene.MAX_NAMESPACE_LENGTH`.
    """
    if len(namespace) > MAX_NAMESPACE_LENGTH:
        return (f"namespace {namespace!r} has {len(namespace)} characters; this node takes at most "
                f"{MAX_NAMESPACE_LENGTH} (MAX_NAMESPACE_LENGTH: a topic name <namespace>/<body>/<site>/imu with "
                "body and site names of up to 63 characters must fit ROS's 247)")
    return None


def declare_parameters(node: Node) -> dict[str, Any]:
    """Declare every parameter of :data:`PARAMETERS` on ``node`` with its full descriptor; return
    the start-up values (overrides from ``--ros-args``, params files or ``parameter_overrides``).

    Each parameter is declared dynamically typed, without ranges and writable, so that a whole
    number given for a float parameter (``-p rate_hz:=200``, or ``rate_hz: 200`` in a params
    file) is accepted and converted, and so that every refusal, at start-up or later (wrong type,
    out of range, read-only), is this module's, in its words (the node's on-set callback checks
    every change with :func:`change_problems`). What clients are told is the full, statically
    typed descriptor (:meth:`ParameterSpec.descriptor`): the node answers ``describe_parameters``
    with it.

    Raises
    ------
    ValueError
        Naming every start-up value that is not acceptable and what was expected.
    """
    values = {}
    reasons = [namespace_problem(node.get_namespace())]
    for spec in PARAMETERS:
        if spec.node_owned:  # declared without a value; an override from outside is refused
            declared = node.declare_parameter(spec.name, spec.type, ParameterDescriptor(
                description=spec.description, type=spec.type.value))
            if declared.type_ is not Parameter.Type.NOT_SET:
                reasons.append(problem(spec.name, declared.value))
            continue
        declared = node.declare_parameter(spec.name, spec.default_value(),
                                          ParameterDescriptor(description=spec.description, dynamic_typing=True))
        values[spec.name] = coerce(spec, declared.value)
    reasons = problems(values) + [reason for reason in reasons if reason]
    if values.get("record_path") and not reasons:  # the operator's start-up path: said before the scene loads
        unwritable = check_record_path(values["record_path"])
        if unwritable is not None:
            reasons.append(f"record_path rejected: {unwritable}")
    if reasons:
        raise ValueError("; ".join(reasons))
    whole = [Parameter(spec.name, spec.type, values[spec.name]) for spec in PARAMETERS
             if spec.type is Parameter.Type.DOUBLE and type(node.get_parameter(spec.name).value) is not float]
    if whole:  # stored as given; the node's value is the float (before its callbacks are added)
        node.set_parameters(whole)
    return values


#: Parameters every rclpy node has besides the table's.
_ROS_PARAMETERS = ("use_sim_time", "start_type_description_service")


def misspelt_parameters(node_name: str, fully_qualified_name: str, node_kwargs: Mapping[str, Any]) -> list[str]:
    """A warning for every start-up parameter given to this node that it does not have, naming the
    closest valid one (:mod:`difflib`): ``rate_hx:=200`` → ``rate_hz``.

    Read are the arguments the node reads (``-p [node:]name:=value`` and ``--params-file FILE``
    inside ``--ros-args``: its ``cli_args`` and, unless ``use_global_arguments`` is false, the
    process's) and its ``parameter_overrides`` (``node_kwargs``: the keyword arguments of
    :class:`rclpy.node.Node`). ``qos_overrides.*`` and rclpy's own parameters are valid.
    """
    args = list(node_kwargs.get("cli_args") or []) + (sys.argv if node_kwargs.get("use_global_arguments", True)
                                                        else [])
    targets = {node_name, fully_qualified_name, fully_qualified_name.lstrip("/"), "/**", "**"}
    names: list[str] = [param.name for param in node_kwargs.get("parameter_overrides") or ()]
    in_ros, items = False, iter(args)
    for arg in items:
        if arg in ("--ros-args", "--"):
            in_ros = arg == "--ros-args"
        elif in_ros and arg in ("-p", "--param"):
            target, sep, name = next(items, "").split(":=", 1)[0].rpartition(":")
            if not sep or target in targets:
                names.append(name)
        elif in_ros and arg == "--params-file":
            names += _params_file_names(next(items, ""), targets)
    warnings = []
    for name in dict.fromkeys(names):
        if name in BY_NAME or name in _ROS_PARAMETERS or name.startswith("qos_overrides."):
            continue
        close = difflib.get_close_matches(name, list(BY_NAME) + list(_ROS_PARAMETERS), n=1, cutoff=0.6)
        hint = f"did you mean {close[0]!r}?" if close else f"this node's parameters are {list(BY_NAME)}"
        warnings.append(f"unknown start-up parameter {name!r} ignored: {hint}")
    return warnings


def _params_file_names(path: str, targets: set[str]) -> list[str]:
    """Parameter names a ROS 2 params file gives any of ``targets`` (nothing if it cannot be read:
    rcl reports that file itself)."""
    try:
        import yaml

        with open(path, encoding="utf-8") as handle:
            data = yaml.safe_load(handle)
    except (OSError, ValueError, ImportError):
        return []
    names: list[str] = []
    for key, section in (data or {}).items() if isinstance(data, dict) else ():
        if str(key) in targets and isinstance(section, dict) and isinstance(section.get("ros__parameters"), dict):
            names += _flatten(section["ros__parameters"])
    return names


def _flatten(tree: dict, prefix: str = "") -> list[str]:
    names: list[str] = []
    for key, value in tree.items():
        name = f"{prefix}{key}"
        names += _flatten(value, name + ".") if isinstance(value, dict) else [name]
    return names


# ---------------------------------------------------------------------- generated documents

def _yaml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        text = repr(value)
        if "e" in text and "." not in text:  # YAML 1.1 (PyYAML, ROS's parser) reads 1e-09 as a string: 1.0e-09
            mantissa, exponent = text.split("e")
            text = f"{mantissa}.0e{exponent}"
        return text
    return json.dumps(value) if isinstance(value, (str, list)) else str(value)


def params_yaml(node_name: str = NODE_NAME) -> str:
    """The text of ``config/params.yaml``: every parameter but ``scene`` at its default, with its
    description and constraints as comments."""
    lines = [
        "# Parameters of the rigid_body_sim node, generated from rigid_body_sim/ros/parameters.py",
        "# (python -m rigid_body_sim.ros.parameters --yaml > config/params.yaml; a test checks it). Use:",
        "#   rigid_body_sim_node --ros-args --params-file config/params.yaml",
        "# `scene` is left out: it defaults to the installed config/default_scene.yaml; `scene_dirs` too: it",
        "# defaults to the installed config/ and the working directory; `body_names` too: the node sets it.",
        f"{node_name}:",
        "  ros__parameters:",
    ]
    for spec in PARAMETERS:
        if spec.default is None:
            continue
        lines.append(f"    # {spec.description}")
        constraints = spec.additional_constraints()
        if constraints:
            lines.append(f"    #   ({constraints})")
        lines.append(f"    {spec.name}: {_yaml_value(spec.default)}")
    return "\n".join(lines) + "\n"


def markdown_table() -> str:
    """The parameter table of docs/interface.md (between the ``parameters`` markers)."""
    rows = ["| parameter | type | default | valid values | changes | meaning |", "|---|---|---|---|---|---|"]
    for spec in PARAMETERS:
        default = ("the scene's body names" if spec.node_owned else spec.default_text
                   or "installed `config/default_scene.yaml`" if spec.default is None else f"`{_yaml_value(spec.default)}`")
        valid = []
        if spec.choices:
            valid.append(", ".join(f"`{c}`" for c in spec.choices))
        if spec.range is not None:
            valid.append(f"{_fmt(spec.range[0])} to {_fmt(spec.range[1])}")
        if spec.constraints:
            valid.append(spec.constraints)
        changes = "read-only" if spec.read_only or spec.node_owned else spec.takes_effect
        rows.append(f"| `{spec.name}` | {_TYPE_NAMES[spec.type]} | {default} | {'; '.join(valid) or 'any'} "
                    f"| {changes} | {spec.description} |")
    return "\n".join(rows) + "\n"


def _main(argv: list[str]) -> int:
    if argv == ["--yaml"]:
        sys.stdout.write(params_yaml())
        return 0
    if argv == ["--markdown"]:
        sys.stdout.write(markdown_table())
        return 0
    print("usage: python -m rigid_body_sim.ros.parameters --yaml | --markdown", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
