"""Bodies whose collision shapes start overlapping: refused at scene load (core/contact/scene_keys.py)
through core/contact/query.py's ``overlapping_bodies`` (grid broad phase, compiled narrow phase).

Depths are checked against closed forms: two spheres overlap by r_a + r_b − |c_b − c_a|, a
sphere over a box face by r − (its centre's height over the face). Tolerance 1e-12 m: a few
ulps of the 1 m coordinates.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from rigid_body_sim.core import SceneError, load_scene
from rigid_body_sim.core.contact.query import overlapping_bodies
from rigid_body_sim.core.kernels.contact.layout import DIMS, KIND, SHAPE_SPHERE, SHAPE_WIDTH

GROUND = [{"normal": [0.0, 0.0, 1.0], "offset": -5.0}]


def ball(position, radius, **extra) -> dict:
    return {"mass": 1.0, "inertia": {"sphere": radius}, "pose": {"position": list(position)}, **extra}


def refusal_depth(message: str) -> float:
    return float(re.search(r"overlap by ([0-9.e+-]+) m", message).group(1))


def test_two_spheres_starting_inside_each_other_are_refused_with_both_names_and_the_depth():
    ra, rb = 0.1, 0.23
    ca, cb = np.array([0.3, -0.2, 1.0]), np.array([0.3 + 0.17, -0.2 + 0.11, 1.0 - 0.05])
    depth = ra + rb - float(np.linalg.norm(cb - ca))
    with pytest.raises(SceneError, match=r"<dict>: bodies\.cup: expected bodies that start apart: the collision "
                                         r"shapes of saucer and cup overlap by") as error:
        load_scene({"ground": GROUND, "bodies": {"saucer": ball(ca, ra), "other": ball([3.0, 0.0, 0.0], 0.1),
                                                   "cup": ball(cb, rb)}})
    assert refusal_depth(str(error.value)) == pytest.approx(depth, abs=1e-12)
    # the same depth from the query itself
    shapes = np.zeros((2, SHAPE_WIDTH))
    shapes[:, KIND] = SHAPE_SPHERE
    shapes[:, DIMS] = ra, rb
    (i, j, found), = overlapping_bodies([ca, cb], [[1.0, 0, 0, 0]] * 2, shapes, [True, True])
    assert (i, j) == (0, 1) and found == pytest.approx(depth, abs=1e-12)


def test_a_sphere_sunk_into_a_turned_box_face():
    """A box turned 30° about z; a sphere over the middle of its +x face, sunk 3 mm into it."""
    half = np.array([0.4, 0.3, 0.2])
    angle = np.radians(30.0)
    q_xyzw = [0.0, 0.0, np.sin(angle / 2), np.cos(angle / 2)]
    normal = np.array([np.cos(angle), np.sin(angle), 0.0])
    centre = np.array([1.0, 1.0, 1.0]) + (half[0] + 0.15 - 0.003) * normal
    with pytest.raises(SceneError, match="the collision shapes of crate and ball overlap") as error:
        load_scene({"ground": GROUND, "bodies": {
            "crate": {"mass": 1.0, "inertia": {"box": (2 * half).tolist()},
                      "pose": {"position": [1.0, 1.0, 1.0], "orientation": q_xyzw}},
            "ball": ball(centre, 0.15)}})
    assert refusal_depth(str(error.value)) == pytest.approx(0.003, abs=1e-12)


def test_what_is_not_refused():
    """Apart by 1 nm; touching within round-off; no ground (no contact); a body without a shape; two
    bodies that do not move. A kinematic body and a free one are refused (inside a static one:
    static_geometry.py's own refusal)."""
    load_scene({"ground": GROUND, "bodies": {"a": ball([0, 0, 0], 0.1), "b": ball([0.2 + 1e-9, 0, 0], 0.1)}})
    load_scene({"bodies": {"a": ball([0, 0, 0], 0.1), "b": ball([0.1, 0, 0], 0.1)}})
    load_scene({"ground": GROUND, "bodies": {"a": ball([0, 0, 0], 0.1), "b": ball([0.1, 0, 0], 0.1, collision="none")}})
    third = 1.0 / 3.0  # 0.1 + 0.2 − (1/3 − 0.0333...) is a round-off away from 0
    load_scene({"ground": GROUND, "bodies": {"a": ball([0, 0, 0], 0.1), "b": ball([third, 0, 0], third - 0.1)}})
    load_scene({"ground": GROUND, "bodies": {"a": ball([0, 0, 0], 0.1, motion="static"),
                                             "b": ball([0.1, 0, 0], 0.1, motion="static")}})
    with pytest.raises(SceneError, match="shapes of a and b overlap by 0.1 m"):  # one moves: refused
        load_scene({"ground": GROUND, "bodies": {"a": ball([0, 0, 0], 0.1, motion="kinematic"),
                                                 "b": ball([0.1, 0, 0], 0.1)}})
    with pytest.raises(SceneError, match="inside static body 'a'"):
        load_scene({"ground": GROUND, "bodies": {"a": ball([0, 0, 0], 0.1, motion="static"),
                                                 "b": ball([0.1, 0, 0], 0.1)}})


def test_overlapping_bodies_finds_every_overlapping_pair_of_many_spheres():
    """2,000 random spheres: exactly the pairs with |c_b − c_a| < r_a + r_b, deepest first, depths to 1e-12."""
    rng = np.random.default_rng(0)
    n = 2000
    centres = rng.uniform(0.0, 6.0, size=(n, 3))
    radii = rng.uniform(0.05, 0.15, size=n)
    shapes = np.zeros((n, SHAPE_WIDTH))
    shapes[:, KIND] = SHAPE_SPHERE
    shapes[:, DIMS] = radii
    quats = rng.normal(size=(n, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    d = np.linalg.norm(centres[:, None, :] - centres[None, :, :], axis=-1)
    depth = radii[:, None] + radii[None, :] - d
    expected = {(i, j): depth[i, j] for i, j in zip(*np.nonzero(np.triu(depth > 0.0, 1)))}
    assert len(expected) > 20
    found = overlapping_bodies(centres, quats, shapes, np.ones(n, bool))
    assert {(i, j) for i, j, _ in found} == set(expected)
    for i, j, value in found:
        assert value == pytest.approx(expected[i, j], abs=1e-12)
    assert [value for _, _, value in found] == sorted((value for _, _, value in found), reverse=True)
    # only the pairs of some bodies; pairs where neither moves left out
    some = [i for i, _ in list(expected)[:3]]
    assert {(i, j) for i, j, _ in overlapping_bodies(centres, quats, shapes, np.ones(n, bool), of=some)} == \
        {p for p in expected if p[0] in some or p[1] in some}
    moving = np.zeros(n, bool)
    moving[some] = True
    assert {(i, j) for i, j, _ in overlapping_bodies(centres, quats, shapes, moving)} == \
        {p for p in expected if p[0] in some or p[1] in some}
