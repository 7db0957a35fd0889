"""Scene keys of contact: ground half-spaces, materials, collision shapes, and every way they can be wrong.

Each refused scene raises one SceneError naming the key path and what was expected; the pair
rule (friction √(μ_a μ_b), restitution max(e_a, e_b), a missing side taking the other's) is
checked on its own.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import pytest

from rigid_body_sim.core import SceneError, Simulator, load_scene
from rigid_body_sim.core.kernels.contact.layout import (
    DIMS,
    KIND,
    NORMAL,
    OFFSET,
    SHAPE_BOX,
    SHAPE_CAPSULE,
    SHAPE_CYLINDER,
    SHAPE_NONE,
    SHAPE_SPHERE,
)
from rigid_body_sim.core.contact.scene_keys import DEFAULT_FRICTION, DEFAULT_RESTITUTION

CONFIG = Path(__file__).resolve().parents[1] / "config"


def scene_dict() -> dict:
    return {
        "gravity": [0.0, 0.0, -9.81],
        "ground": [{"normal": [0, 0, 1], "offset": 0.0, "material": {"restitution": 0.5, "friction": 0.5}}],
        "bodies": {
            "ball": {"mass": 1.0, "inertia": {"sphere": 0.1}, "material": {"restitution": 0.25, "friction": 0.2},
                     "pose": {"position": [0.0, 0.0, 1.0]}},
            "crate": {"mass": 2.0, "inertia": {"box": [0.4, 0.2, 0.1]}, "pose": {"position": [1.0, 0.0, 0.5]}},
            "can": {"mass": 1.0, "inertia": {"cylinder": [0.05, 0.3]}, "pose": {"position": [2.0, 0.0, 0.5]}},
            "probe": {"mass": 1.0, "inertia": {"principal": [0.1, 0.1, 0.1]}, "pose": {"position": [3.0, 0.0, 0.5]}},
        },
    }


def test_default_shapes_are_the_inertia_shapes_and_principal_has_none():
    spec = load_scene(scene_dict()).contact
    assert spec.shapes[0, KIND] == SHAPE_SPHERE and spec.shapes[0, DIMS] == 0.1
    assert spec.shapes[1, KIND] == SHAPE_BOX and spec.shapes[1, DIMS:DIMS + 3].tolist() == [0.2, 0.1, 0.05]
    assert spec.shapes[2, KIND] == SHAPE_CYLINDER and spec.shapes[2, DIMS:DIMS + 2].tolist() == [0.05, 0.15]
    assert spec.shapes[3, KIND] == SHAPE_NONE


def test_declared_collision_shapes_and_none():
    data = scene_dict()
    data["bodies"]["probe"]["collision"] = {"capsule": [0.05, 0.2]}
    data["bodies"]["crate"]["collision"] = "none"
    data["bodies"]["ball"]["collision"] = {"box": [0.1, 0.1, 0.1]}
    spec = load_scene(data).contact
    assert spec.shapes[3, KIND] == SHAPE_CAPSULE and spec.shapes[3, DIMS:DIMS + 2].tolist() == [0.05, 0.1]
    assert spec.shapes[1, KIND] == SHAPE_NONE
    assert spec.shapes[0, KIND] == SHAPE_BOX and spec.shapes[0, DIMS:DIMS + 3].tolist() == [0.05, 0.05, 0.05]


def test_pair_material_rule():
    spec = load_scene(scene_dict()).contact
    # ball (e 0.25, μ 0.2) on ground (e 0.5, μ 0.5): max e, geometric mean μ
    assert spec.restitution[0, 0] == 0.5
    assert spec.friction[0, 0] == pytest.approx(math.sqrt(0.2 * 0.5), rel=1e-15)
    # crate has no material: the ground's
    assert spec.restitution[1, 0] == 0.5 and spec.friction[1, 0] == 0.5
    data = scene_dict()
    del data["ground"][0]["material"]
    spec = load_scene(data).contact
    assert spec.restitution[0, 0] == 0.25 and spec.friction[0, 0] == pytest.approx(0.2, rel=1e-15)
    assert spec.restitution[1, 0] == DEFAULT_RESTITUTION and spec.friction[1, 0] == DEFAULT_FRICTION


def test_tilted_ground_is_normalised():
    data = scene_dict()
    data["ground"] = [{"normal": [0, 3, 4], "offset": -2.0}, {"normal": [1, 0, 0], "offset": -10.0}]
    spec = load_scene(data).contact
    assert spec.grounds[0, NORMAL:NORMAL + 3].tolist() == [0.0, 0.6, 0.8]
    assert spec.grounds[0, OFFSET] == -2.0 and spec.grounds.shape[0] == 2
    assert spec.restitution.shape == (4, 2)


def test_no_ground_means_no_contact_and_the_old_step():
    data = scene_dict()
    del data["ground"]
    scene = load_scene(data)
    assert scene.contact is None
    sim = Simulator(scene, "rk4", 0.01)
    assert sim.contact is None
    sim.step(3)  # the compiled multi-step path, as before
    assert sim.step_count == 3


@pytest.mark.parametrize("edit, path, expected", [
    (lambda d: d["ground"][0].update(normal=[0, 0, 0]), "ground[0].normal", "a non-zero vector"),
    (lambda d: d["ground"][0].update(normal=[0, 0, float("nan")]), "ground[0].normal", "finite numbers"),
    (lambda d: d["ground"][0].update(normal=[1.7e308, 1.7e308, 1.7e308]), "ground[0].normal", "length is finite"),
    (lambda d: d["ground"][0].update(offset="low"), "ground[0].offset", "a number"),
    (lambda d: d["ground"][0].update(tilt=3), "ground[0].tilt", "unknown key"),
    (lambda d: d.update(ground={"normal": [0, 0, 1]}), "ground", "a list of half-spaces"),
    (lambda d: d["ground"][0]["material"].update(restitution=1.5), "ground[0].material.restitution", "≤ 1"),
    (lambda d: d["ground"][0]["material"].update(friction=-0.1), "ground[0].material.friction", "≥ 0"),
    (lambda d: d["ground"][0]["material"].pop("friction"), "ground[0].material", "required key 'friction'"),
    (lambda d: d["bodies"]["ball"].update(material={"restitution": 0.5}), "bodies.ball.material",
     "required key 'friction'"),
    (lambda d: d["bodies"]["ball"].update(collision={"cone": 1.0}), "bodies.ball.collision",
     "none, or a mapping with one of the keys"),
    (lambda d: d["bodies"]["ball"].update(collision={"sphere": -1.0}), "bodies.ball.collision.sphere", "> 0"),
    (lambda d: d["bodies"]["ball"].update(collision={"capsule": [0.1]}), "bodies.ball.collision.capsule",
     "a list of 2 finite numbers"),
    (lambda d: d["bodies"]["ball"].update(collision="nothing"), "bodies.ball.collision", "none, or a mapping"),
])
def test_bad_contact_keys_name_the_path(edit, path, expected):
    data = copy.deepcopy(scene_dict())
    edit(data)
    with pytest.raises(SceneError) as info:
        load_scene(data)
    message = str(info.value)
    assert f"<dict>: {path}" in message and expected in message, message


@pytest.mark.parametrize("body, position, orientation, depth", [
    ("ball", [0.0, 0.0, 0.07], [0, 0, 0, 1], 0.03),
    ("crate", [1.0, 0.0, 0.04], [0, 0, 0, 1], 0.01),
    # the crate turned 90° about x: its 0.2 m edge is vertical, half 0.1
    ("crate", [1.0, 0.0, 0.09], [math.sin(math.pi / 4), 0, 0, math.cos(math.pi / 4)], 0.01),
])
def test_a_body_starting_inside_the_ground_is_refused_with_its_depth(body, position, orientation, depth):
    data = scene_dict()
    data["bodies"][body]["pose"] = {"position": position, "orientation": orientation}
    with pytest.raises(SceneError) as info:
        load_scene(data)
    message = str(info.value)
    assert f"bodies.{body}" in message and "inside ground[0]" in message, message
    shown = float(message.split("is ")[1].split(" m inside")[0])
    assert shown == pytest.approx(depth, rel=1e-6)


def test_a_tilted_ground_refuses_a_body_below_it():
    data = scene_dict()
    data["ground"] = [{"normal": [0, 3, 4], "offset": 0.0}]
    data["bodies"] = {"ball": {"mass": 1.0, "inertia": {"sphere": 0.1}, "pose": {"position": [0, -1.0, 0.8]}}}
    # n·c = (−3 + 3.2)/5 = 0.04 < r = 0.1: 0.06 inside
    with pytest.raises(SceneError, match=r"0\.06 m inside ground\[0\]"):
        load_scene(data)


def test_static_bodies_may_sit_in_the_ground():
    data = scene_dict()
    data["bodies"]["crate"].update(motion="static", pose={"position": [1.0, 0.0, 0.0]})
    assert load_scene(data).contact is not None


def test_example_scenes_load():
    for path in sorted(CONFIG.glob("contact_*.yaml")):
        scene = load_scene(path)
        assert scene.contact is not None, path


def test_a_ground_without_moving_collision_shapes_runs_without_contact():
    data = scene_dict()
    for body in data["bodies"].values():
        body["collision"] = "none"
    scene = load_scene(data)
    assert scene.contact is not None and scene.contact.bodies.size == 0
    assert Simulator(scene, "rk4", 0.01).contact is None
    data = scene_dict()
    data["bodies"] = {"wall": {"mass": 1.0, "inertia": {"box": [1, 1, 1]}, "motion": "static",
                               "pose": {"position": [0.0, 0.0, 0.5]}}}
    assert Simulator(load_scene(data), "rk4", 0.01).contact is None
