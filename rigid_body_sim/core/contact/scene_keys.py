"""The contact keys of a scene: static ground half-spaces, per-body materials and collision shapes.

Schema (scene.py's other keys are unchanged)::

    ground:                     # optional: any number of static half-spaces n·x >= offset
      - normal: [0, 0, 1]       # world axes, any non-zero finite vector (normalised)
        offset: 0.0             # m: the plane is {x : n·x = offset}, n unit; default 0
        material: {restitution: 0.5, friction: 0.5}   # optional
    bodies:
      ball:
        mass: 1.0
        inertia: {sphere: 0.1}
        material: {restitution: 0.5, friction: 0.3}   # optional: e in [0, 1], μ >= 0
        collision: {sphere: 0.1}  # optional; default: the inertia shape ({sphere: r},
                                  # {box: [x, y, z]}, {cylinder: [r, length]}); `none` opts out;
                                  # also {capsule: [r, length]} (length between the end centres).
                                  # Body frame B, centred at the centre of mass.

A body whose inertia is ``principal`` or ``tensor`` has no collision shape unless it declares
one. Contact acts on bodies whose motion is ``free``; the others pass through the ground (they
do not move, or move as declared).
A body whose motion is ``static`` and that has a collision shape is static geometry in a scene
with a ``ground`` key (``ground: []`` for no half-space): the solver's static_geometry.py.

Pair material: friction √(μ_a μ_b), restitution max(e_a, e_b) (Box2D's rule); a side without
a material takes the other's; with neither, :data:`DEFAULT_RESTITUTION` and
:data:`DEFAULT_FRICTION`. A scene whose moving bodies start inside the ground is refused, with
the body, the half-space and the depth named; so is a scene with a ground whose bodies start
with their collision shapes overlapping (a pair with at least one ``free`` body; inside a
static body: static_geometry.py), with both bodies and the depth named. Without a ``ground`` key the scene has no contact
(``Scene.contact`` is None) and runs exactly as before.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..kernels.contact.layout import (
    DIMS,
    FRICTION,
    GROUND_WIDTH,
    HAS_MATERIAL,
    KIND,
    MAX_POINTS,
    NORMAL,
    OFFSET,
    RESTITUTION,
    SHAPE_BOX,
    SHAPE_CAPSULE,
    SHAPE_CYLINDER,
    SHAPE_NAMES,
    SHAPE_NONE,
    SHAPE_SPHERE,
    SHAPE_WIDTH,
)
from .materials import DEFAULT_FRICTION, DEFAULT_RESTITUTION, pair_material

__all__ = ["ContactSpec", "read_contact", "apart_shapes", "without_contact_keys", "pair_material", "DEFAULT_RESTITUTION", "DEFAULT_FRICTION",
           "MAX_GROUNDS", "BODY_KEYS", "TOP_KEYS"]

#: Most half-spaces a scene may list.
MAX_GROUNDS = 64
#: The keys this module adds to a scene's top level and to a body.
TOP_KEYS = ("ground",)
BODY_KEYS = ("material", "collision")

_GROUND_KEYS = ("normal", "offset", "material")
_MATERIAL_KEYS = ("restitution", "friction")


@dataclass(frozen=True)
class ContactSpec:
    """What a scene declares for contact (read-only arrays, layout.py names the columns).

    Attributes
    ----------
    grounds : ndarray, shape (G, GROUND_WIDTH)
        The half-spaces n·x ≥ offset: unit normal (world axes), offset (m), material.
    shapes : ndarray, shape (N, SHAPE_WIDTH)
        Each body's collision shape (body frame B, at the centre of mass) and material.
    restitution, friction : ndarray, shape (N, G)
        The pair coefficients of body i against ground j (:func:`pair_material`).
    bodies : ndarray of int, shape (M,)
        The bodies contact acts on: motion ``free`` and a collision shape. None of them: the
        scene has no collision geometry that can touch anything, and a Simulator runs without
        contact (exactly its code and cost without a ground).
    """

    grounds: np.ndarray
    shapes: np.ndarray
    restitution: np.ndarray
    friction: np.ndarray
    bodies: np.ndarray

    def __post_init__(self) -> None:
        for array in (self.grounds, self.shapes, self.restitution, self.friction, self.bodies):
            array.flags.writeable = False

    def __setstate__(self, state: dict) -> None:
        """A copy (``copy.deepcopy``, ``pickle``) keeps its arrays read-only: numpy's copies of them are
        writable, and the compiled kernels, specialised on read-only arrays, would compile again for them."""
        for name, value in state.items():
            object.__setattr__(self, name, value)
        self.__post_init__()


def without_contact_keys(body: Any) -> Any:
    """A body mapping without the keys read here (scene.py checks the rest against its own list).

    scene.py's unknown-key message lists only its own body keys, which a test pins; the keys
    of this module are read and checked by :func:`read_contact`. Anything not a mapping is
    returned as it is, for scene.py to refuse.
    """
    if not isinstance(body, Mapping) or not any(key in body for key in BODY_KEYS):
        return body
    return {key: value for key, value in body.items() if key not in BODY_KEYS}


def _material(check: Any, value: Any, path: str, row: np.ndarray) -> None:
    spec = check.mapping(value, path, _MATERIAL_KEYS, required=_MATERIAL_KEYS)
    e = check.number(spec["restitution"], f"{path}.restitution", minimum=0.0, unit="Newton's coefficient, 0 to 1")
    if e > 1.0:
        check.fail(f"{path}.restitution", "a number ≤ 1 (Newton's coefficient: 1 keeps all the normal speed)", e)
    mu = check.number(spec["friction"], f"{path}.friction", minimum=0.0, unit="Coulomb's coefficient μ")
    row[RESTITUTION], row[FRICTION], row[HAS_MATERIAL] = e, mu, 1.0


def _ground(check: Any, value: Any) -> np.ndarray:
    if not isinstance(value, (list, tuple)):
        check.fail("ground", "a list of half-spaces {normal: [x, y, z], offset: m, material: {...}}", value)
    if len(value) > MAX_GROUNDS:
        check.fail("ground", f"at most {MAX_GROUNDS} half-spaces, got {len(value)}", show_got=False)
    rows = np.zeros((len(value), GROUND_WIDTH))
    for j, raw in enumerate(value):
        path = f"ground[{j}]"
        entry = check.mapping(raw, path, _GROUND_KEYS, required=("normal",))
        normal = check.vector(entry["normal"], f"{path}.normal", 3, unit="world axes, pointing out of the ground")
        length = math.hypot(*normal)
        if not (length > 0.0 and math.isfinite(length)):
            check.fail(f"{path}.normal", "a non-zero vector whose length is finite (the half-space's outward "
                       "normal, world axes; it is normalised)", entry["normal"])
        rows[j, NORMAL:NORMAL + 3] = [x / length for x in normal]
        if entry.get("offset") is not None:
            rows[j, OFFSET] = check.number(entry["offset"], f"{path}.offset",
                                           unit="m: the plane is n·x = offset with n normalised")
        if entry.get("material") is not None:
            _material(check, entry["material"], f"{path}.material", rows[j])
    return rows


def _shape(check: Any, value: Any, path: str, row: np.ndarray) -> None:
    """A ``collision`` value: ``none`` or a one-key mapping {sphere|box|cylinder|capsule: dims}."""
    expected = "none, or a mapping with one of the keys ['sphere', 'box', 'cylinder', 'capsule']"
    if value == "none":
        row[KIND] = SHAPE_NONE
        return
    if not isinstance(value, Mapping) or len(value) != 1:
        check.fail(path, expected, value)
    (kind, arg), = value.items()
    if kind not in SHAPE_NAMES:
        check.fail(path, expected, value)
    sub = f"{path}.{kind}"
    code = SHAPE_NAMES[kind]
    if code == SHAPE_SPHERE:
        dims = [check.number(arg, sub, minimum=0.0, strict=True, scale=True, unit="radius in m"), 0.0, 0.0]
    elif code == SHAPE_BOX:
        dims = [0.5 * x for x in check.vector(arg, sub, 3, positive=True, scale=True,
                                               unit="edge lengths x, y, z in m, body axes")]
    else:
        r, length = check.vector(arg, sub, 2, positive=True, scale=True,
                                 unit="[radius, length] in m, axis along body z" + (
                                     " (length between the end spheres' centres)" if code == SHAPE_CAPSULE else ""))
        dims = [r, 0.5 * length, 0.0]
    row[KIND] = code
    row[DIMS:DIMS + 3] = dims


def _default_shape(inertia: Any, row: np.ndarray) -> None:
    """The collision shape a body's (already validated) inertia shape implies; none for principal/tensor."""
    (kind, arg), = inertia.items()
    if kind == "sphere":
        row[KIND], row[DIMS] = SHAPE_SPHERE, float(arg)
    elif kind == "box":
        row[KIND] = SHAPE_BOX
        row[DIMS:DIMS + 3] = [0.5 * float(x) for x in arg]
    elif kind == "cylinder":
        row[KIND] = SHAPE_CYLINDER
        row[DIMS:DIMS + 2] = [float(arg[0]), 0.5 * float(arg[1])]


def read_contact(check: Any, top: Mapping, model: Any, state: Any, *, apart: bool = True) -> ContactSpec | None:
    """Read and check the contact keys of a scene whose bodies scene.py has already read.

    ``check`` is scene.py's checker (errors name the key path and what was expected), ``top``
    the scene mapping, ``model`` and ``state`` the BodyModel and initial State built from it.
    Returns None when the scene has no ``ground`` (the body keys are still checked). With
    ``apart`` false, bodies whose shapes overlap are not refused (a spawn checks its new bodies
    against the others' current poses instead).
    """
    bodies = top["bodies"]
    shapes = np.zeros((len(bodies), SHAPE_WIDTH))
    for i, (name, body) in enumerate(bodies.items()):
        path = f"bodies.{name}"
        if body.get("material") is not None:
            _material(check, body["material"], f"{path}.material", shapes[i])
        if "collision" in body:
            _shape(check, body["collision"], f"{path}.collision", shapes[i])
        else:
            _default_shape(body["inertia"], shapes[i])
    if top.get("ground") is None:
        return None
    grounds = _ground(check, top["ground"])
    n, g = len(bodies), len(grounds)
    restitution, friction = np.zeros((n, g)), np.zeros((n, g))
    for i in range(n):
        for j in range(g):
            restitution[i, j], friction[i, j] = pair_material(shapes[i], grounds[j])
    _check_not_inside(check, model, state, shapes, grounds)
    from .static_geometry import check_not_inside_statics  # compiled: imported only when a scene has a ground

    check_not_inside_statics(check, model, state, shapes)
    if apart:
        _check_apart(check, model, state, shapes)
    bodies = np.array([i for i in range(n) if shapes[i, KIND] != SHAPE_NONE and model.motions[i] == "free"],
                      dtype=np.int64)
    return ContactSpec(grounds, shapes, restitution, friction, bodies)  # read-only from here


def _check_not_inside(check: Any, model: Any, state: Any, shapes: np.ndarray, grounds: np.ndarray) -> None:
    """Refuse a moving body whose shape starts inside a half-space, naming the body, the ground and the depth."""
    from ..kernels.layout import PRM_WIDTH, Q_PB, ROW_WIDTH, STATE_WIDTH
    from ..quaternion import quat_conjugate  # numpy
    from ..kernels.contact.shapes import body_points

    rows = np.zeros((model.count, ROW_WIDTH))
    rows[:, :STATE_WIDTH] = state.rows()
    prm = np.zeros((model.count, PRM_WIDTH))  # only q_PB is read
    prm[:, Q_PB:Q_PB + 4] = quat_conjugate(np.asarray(model.q_BP, dtype=float).reshape(-1, 4))
    points, gaps = np.empty((MAX_POINTS, 3)), np.empty(MAX_POINTS)
    motions = model.motions
    for i, name in enumerate(model.names):
        if shapes[i, KIND] == SHAPE_NONE or motions[i] != "free":
            continue
        for j in range(len(grounds)):
            count = body_points(rows[i], prm[i], shapes[i], grounds[j], points, gaps)
            depth = -float(gaps[:count].min())
            if depth > 0.0:
                check.fail(f"bodies.{name}", f"a body that starts outside the ground: its collision shape is {depth:.6g} m "
                           f"inside ground[{j}] (normal {grounds[j, NORMAL:NORMAL + 3].tolist()}, offset "
                           f"{grounds[j, OFFSET]:g} m); move it up by at least that", show_got=False)


def apart_shapes(shapes: np.ndarray, motions: Any) -> np.ndarray:
    """``shapes`` with the static bodies' rows emptied (SHAPE_NONE): the shapes the body–body overlap
    check pairs. A moving body inside a static one is refused by static_geometry.py's own check."""
    out = np.array(shapes, dtype=float)
    out[[i for i, motion in enumerate(motions) if motion == "static"], KIND] = SHAPE_NONE
    return out


def _check_apart(check: Any, model: Any, state: Any, shapes: np.ndarray) -> None:
    """Refuse bodies whose collision shapes start overlapping (at least one free, neither static), naming both and the depth."""
    from ..quaternion import quat_conjugate, quat_multiply  # numpy
    from .query import overlapping_bodies  # compiled: imported only when a scene has a ground

    q_WB = quat_multiply(state.q_WP, quat_conjugate(np.asarray(model.q_BP, dtype=float).reshape(-1, 4)))
    moving = np.array([motion == "free" for motion in model.motions], dtype=bool)
    overlaps = overlapping_bodies(state.p_WC_W, q_WB, apart_shapes(shapes, model.motions), moving)
    if overlaps:
        i, j, depth = overlaps[0]
        a, b = model.names[i], model.names[j]
        more = f" ({len(overlaps) - 1} more overlapping pairs)" if len(overlaps) > 1 else ""
        check.fail(f"bodies.{b}", f"bodies that start apart: the collision shapes of {a} and {b} overlap by "
                   f"{depth:.12g} m{more}; move them apart by at least that", show_got=False)
