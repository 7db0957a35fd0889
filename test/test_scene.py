"""Scene loading: what a valid file becomes, and one test per way a scene can be wrong.

Every rejected scene must raise one :class:`SceneError` whose message names the file, the key
path (``bodies.crate.inertia.box``) and what was expected; nothing is returned half-loaded.
The bad scenes are written as YAML files, so the YAML spellings users type (``.nan``,
``.inf``, repeated keys) go through the real loader.
"""

from __future__ import annotations

import copy
import re
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest
import yaml

from helpers import EPS, random_rotation_matrix
from rigid_body_sim.core import SceneError, load_scene
from rigid_body_sim.core.mass_properties import box_inertia, cylinder_inertia, sphere_inertia
from rigid_body_sim.core.quaternion import quat_conjugate, quat_multiply, quat_rotate, quat_to_matrix
from rigid_body_sim.core.scene import MAX_SCENE_BYTES, ORIENTATION_TOLERANCE

VALID_YAML = """\
gravity: [0.0, 0.0, -9.81]
bodies:
  crate:
    mass: 2.0
    inertia: {box: [1.0, 0.6, 0.4]}
    pose: {position: [0.0, 0.0, 1.0], orientation: [0.0, 0.0, 0.0, 1.0]}
    twist: {linear: [1.0, 0.0, 0.0], angular: [0.0, 0.0, 0.5]}
    damping: {linear: 0.1, angular: 0.01}
    sites:
      corner: {position: [0.5, 0.3, 0.0]}
      nozzle: {position: [0.0, 0.0, -0.2], axes: world}
  ball:
    mass: 1.0
    inertia: {sphere: 0.1}
"""


def _base() -> dict[str, Any]:
    return yaml.safe_load(VALID_YAML)


def _write(tmp_path: Path, text: str, name: str = "scene.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# --------------------------------------------------------------------------- valid scenes


def test_valid_scene_from_file(tmp_path: Path) -> None:
    path = _write(tmp_path, VALID_YAML)
    scene = load_scene(path)
    assert scene.source == str(path)
    assert scene.body_names == ("crate", "ball")
    model, state = scene.model, scene.initial_state
    np.testing.assert_array_equal(model.mass, [2.0, 1.0])
    np.testing.assert_array_equal(model.inertia_P[0], box_inertia(2.0, [1.0, 0.6, 0.4]))
    np.testing.assert_array_equal(model.inertia_P[1], sphere_inertia(1.0, 0.1))
    np.testing.assert_array_equal(model.q_BP, [[1.0, 0.0, 0.0, 0.0]] * 2)  # diagonal: exactly identity
    np.testing.assert_array_equal(model.gravity_W, [0.0, 0.0, -9.81])
    np.testing.assert_array_equal(model.damping_linear, [0.1, 0.0])
    np.testing.assert_array_equal(model.damping_angular, [0.01, 0.0])
    np.testing.assert_array_equal(state.p_WC_W, [[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(state.q_WP, [[1.0, 0.0, 0.0, 0.0]] * 2)
    np.testing.assert_array_equal(state.v_WC_W, [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(state.w_WP_P, [[0.0, 0.0, 0.5], [0.0, 0.0, 0.0]])
    assert scene.sites == {"crate": ("corner", "nozzle"), "ball": ()}
    assert model.site_names == ("crate/corner", "crate/nozzle")
    np.testing.assert_array_equal(model.site_p_P, [[0.5, 0.3, 0.0], [0.0, 0.0, -0.2]])
    np.testing.assert_array_equal(model.site_world_axes, [False, True])
    assert scene.frames_of("crate") == ("world", "crate", "crate/world_aligned", "crate/corner", "crate/nozzle")
    assert scene.frames_of("ball") == ("world", "ball", "ball/world_aligned")
    # The same scene from a dict is the same model.
    from_dict = load_scene(_base())
    assert from_dict.source == "<dict>"
    np.testing.assert_array_equal(from_dict.initial_state.w_WP_P, state.w_WP_P)


def test_pose_is_xyzw_and_twist_is_in_world_axes() -> None:
    half = 0.5 * 0.7  # 0.7 rad about +z
    data = {"bodies": {"b": {
        "mass": 1.0, "inertia": {"cylinder": [0.1, 0.5]},
        "pose": {"orientation": [0.0, 0.0, np.sin(half), np.cos(half)]},
        "twist": {"angular": [1.0, 2.0, 3.0]},
    }}}
    scene = load_scene(data)
    q_WP = scene.initial_state.q_WP[0]
    np.testing.assert_allclose(q_WP, [np.cos(half), 0.0, 0.0, np.sin(half)], rtol=0, atol=EPS)
    # w_P = R_WPᵀ w_W: the world rate seen in the rotated body axes.
    np.testing.assert_allclose(quat_to_matrix(q_WP) @ scene.initial_state.w_WP_P[0], [1.0, 2.0, 3.0], rtol=0, atol=8 * EPS)
    np.testing.assert_array_equal(scene.model.inertia_P[0], cylinder_inertia(1.0, 0.1, 0.5))
    np.testing.assert_array_equal(scene.model.gravity_W, np.zeros(3))  # no gravity key: none


def test_full_tensor_gives_a_principal_frame_and_sites_in_it() -> None:
    rng = np.random.default_rng(20)
    R_BP = random_rotation_matrix(rng)
    moments = np.array([0.2, 0.3, 0.4])
    tensor_B = R_BP @ np.diag(moments) @ R_BP.T
    tensor_B = 0.5 * (tensor_B + tensor_B.T)
    scene = load_scene({"bodies": {"b": {
        "mass": 1.0, "inertia": {"tensor": tensor_B.tolist()},
        "sites": {"tip": {"position": [0.1, 0.2, 0.3]}},
    }}})
    q_BP = scene.model.q_BP[0]
    assert not np.allclose(q_BP, [1.0, 0.0, 0.0, 0.0])
    R = quat_to_matrix(q_BP)
    np.testing.assert_allclose(R @ np.diag(scene.model.inertia_P[0]) @ R.T, tensor_B, rtol=0, atol=1e-14)
    # Identity pose of B means q_WP = q_BP; sites are stored in P axes.
    np.testing.assert_allclose(scene.initial_state.q_WP[0], q_BP, rtol=0, atol=0)
    np.testing.assert_allclose(quat_rotate(q_BP, scene.model.site_p_P[0]), [0.1, 0.2, 0.3], rtol=0, atol=4 * EPS)
    np.testing.assert_allclose(
        quat_multiply(scene.initial_state.q_WP[0], quat_conjugate(q_BP)), [1.0, 0.0, 0.0, 0.0], rtol=0, atol=4 * EPS
    )


def test_orientation_within_tolerance_is_normalised() -> None:
    near = [0.0, 0.0, 0.0, 1.0 + 0.5 * ORIENTATION_TOLERANCE]
    scene = load_scene({"bodies": {"b": {"mass": 1.0, "inertia": {"sphere": 1.0}, "pose": {"orientation": near}}}})
    assert abs(np.linalg.norm(scene.initial_state.q_WP[0]) - 1.0) <= EPS


def test_optional_sections_may_be_null(tmp_path: Path) -> None:
    text = "bodies:\n  b:\n    mass: 1\n    inertia: {principal: [1, 2, 2.5]}\n    pose:\n    twist:\n    damping:\n    sites:\n"
    scene = load_scene(_write(tmp_path, text))
    np.testing.assert_array_equal(scene.model.inertia_P[0], [1.0, 2.0, 2.5])
    assert scene.sites == {"b": ()}


# --------------------------------------------------------------------------- bad scenes


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    """A mutation of the base scene: set the value at a dotted key path."""
    keys = path.split(".")

    def mutate(data: dict[str, Any]) -> None:
        node = data
        for key in keys[:-1]:
            node = node[key]
        node[keys[-1]] = value

    return mutate


def _delete(path: str) -> Callable[[dict[str, Any]], None]:
    keys = path.split(".")

    def mutate(data: dict[str, Any]) -> None:
        node = data
        for key in keys[:-1]:
            node = node[key]
        del node[keys[-1]]

    return mutate


def _rename_body(old: str, new: Any) -> Callable[[dict[str, Any]], None]:
    def mutate(data: dict[str, Any]) -> None:
        data["bodies"] = {(new if k == old else k): v for k, v in data["bodies"].items()}

    return mutate


NAN, INF = float("nan"), float("inf")
C = "bodies.crate"

# (id, mutation of the base scene, key path named in the error, what the error must say was expected)
BAD_SCENES: list[tuple[str, Callable[[dict[str, Any]], None], str, str]] = [
    # unknown keys, at every level
    ("unknown-top-key", _set("gravty", [0, 0, -9.81]), "gravty", r"one of the keys \['gravity', 'bodies', 'wrenches'.*\] \(unknown key\)"),
    ("unknown-body-key", _set(f"{C}.colour", "red"), f"{C}.colour", r"one of the keys \['mass', 'inertia', 'pose', 'twist', 'damping', 'sites', 'motion'\] \(unknown key\)"),
    ("unknown-pose-key", _set(f"{C}.pose.rotation", [0, 0, 0, 1]), f"{C}.pose.rotation", r"\['position', 'orientation'\] \(unknown key\)"),
    ("unknown-twist-key", _set(f"{C}.twist.omega", [0, 0, 1]), f"{C}.twist.omega", r"\['linear', 'angular'\] \(unknown key\)"),
    ("unknown-damping-key", _set(f"{C}.damping.quadratic", 0.1), f"{C}.damping.quadratic", r"\['linear', 'angular'\] \(unknown key\)"),
    ("unknown-site-key", _set(f"{C}.sites.corner.frame", "body"), f"{C}.sites.corner.frame", r"\['position', 'axes', 'imu'\] \(unknown key\)"),
    ("unknown-inertia-kind", _set(f"{C}.inertia", {"cube": 1.0}), f"{C}.inertia", r"one of the keys \['box', 'sphere', 'cylinder', 'principal', 'tensor'\], got 'cube'"),
    ("two-inertia-kinds", _set(f"{C}.inertia", {"box": [1, 1, 1], "sphere": 1.0}), f"{C}.inertia", r"exactly one of the keys"),
    ("bad-site-axes", _set(f"{C}.sites.corner.axes", "local"), f"{C}.sites.corner.axes", r"'body' or 'world', got 'local'"),
    # missing required keys
    ("no-bodies", _delete("bodies"), "", r"required key 'bodies'"),
    ("no-mass", _delete(f"{C}.mass"), C, r"required key 'mass'"),
    ("no-inertia", _delete(f"{C}.inertia"), C, r"required key 'inertia'"),
    ("site-without-position", _set(f"{C}.sites.corner", {"axes": "world"}), f"{C}.sites.corner", r"required key 'position'"),
    # wrong shapes and types
    ("gravity-2", _set("gravity", [0.0, -9.81]), "gravity", r"a list of 3 finite numbers \(m/s²\), got \[0.0, -9.81\]"),
    ("position-2", _set(f"{C}.pose.position", [0.0, 1.0]), f"{C}.pose.position", r"a list of 3 finite numbers"),
    ("orientation-3", _set(f"{C}.pose.orientation", [0.0, 0.0, 1.0]), f"{C}.pose.orientation", r"a list of 4 finite numbers"),
    ("linear-4", _set(f"{C}.twist.linear", [1, 2, 3, 4]), f"{C}.twist.linear", r"a list of 3 finite numbers"),
    ("angular-scalar", _set(f"{C}.twist.angular", 5.0), f"{C}.twist.angular", r"a list of 3 finite numbers"),
    ("box-2", _set(f"{C}.inertia", {"box": [1.0, 0.6]}), f"{C}.inertia.box", r"a list of 3 finite numbers > 0"),
    ("cylinder-1", _set(f"{C}.inertia", {"cylinder": [0.1]}), f"{C}.inertia.cylinder", r"a list of 2 finite numbers > 0"),
    ("sphere-list", _set(f"{C}.inertia", {"sphere": [0.5]}), f"{C}.inertia.sphere", r"a number \(radius in m\)"),
    ("tensor-2x2", _set(f"{C}.inertia", {"tensor": [[1, 0], [0, 1]]}), f"{C}.inertia.tensor", r"symmetric positive-definite 3×3"),
    ("tensor-row-2", _set(f"{C}.inertia", {"tensor": [[1, 0, 0], [0, 1], [0, 0, 1]]}), f"{C}.inertia.tensor[1]", r"a list of 3 finite numbers"),
    ("site-position-2", _set(f"{C}.sites.corner.position", [0.5, 0.3]), f"{C}.sites.corner.position", r"a list of 3 finite numbers"),
    ("mass-string", _set(f"{C}.mass", "two"), f"{C}.mass", r"a number \(kg\), got 'two'"),
    ("mass-bool", _set(f"{C}.mass", True), f"{C}.mass", r"a number \(kg\), got True"),
    ("bodies-list", _set("bodies", ["crate"]), "bodies", r"a non-empty mapping of body names to bodies"),
    ("bodies-empty", _set("bodies", {}), "bodies", r"a non-empty mapping of body names to bodies"),
    ("body-list", _set(C, [2.0]), C, r"a mapping with keys \['mass'"),
    ("pose-list", _set(f"{C}.pose", [0, 0, 1]), f"{C}.pose", r"a mapping with keys \['position', 'orientation'\]"),
    ("sites-list", _set(f"{C}.sites", ["corner"]), f"{C}.sites", r"a mapping of site names"),
    # non-finite numbers (written as .nan / .inf in the file)
    ("mass-nan", _set(f"{C}.mass", NAN), f"{C}.mass", r"a finite number \(kg\), got nan"),
    ("mass-inf", _set(f"{C}.mass", INF), f"{C}.mass", r"a finite number \(kg\), got inf"),
    ("gravity-inf", _set("gravity", [0.0, 0.0, -INF]), "gravity", r"3 finite numbers"),
    ("position-nan", _set(f"{C}.pose.position", [NAN, 0.0, 0.0]), f"{C}.pose.position", r"3 finite numbers"),
    ("orientation-nan", _set(f"{C}.pose.orientation", [0.0, 0.0, 0.0, NAN]), f"{C}.pose.orientation", r"4 finite numbers"),
    ("angular-inf", _set(f"{C}.twist.angular", [0.0, INF, 0.0]), f"{C}.twist.angular", r"3 finite numbers"),
    ("damping-inf", _set(f"{C}.damping.linear", INF), f"{C}.damping.linear", r"a finite number \(N·s/m\)"),
    ("box-inf", _set(f"{C}.inertia", {"box": [1.0, INF, 0.4]}), f"{C}.inertia.box", r"3 finite numbers"),
    ("sphere-nan", _set(f"{C}.inertia", {"sphere": NAN}), f"{C}.inertia.sphere", r"a finite number"),
    ("tensor-nan", _set(f"{C}.inertia", {"tensor": [[1, 0, 0], [0, NAN, 0], [0, 0, 1]]}), f"{C}.inertia.tensor[1]", r"3 finite numbers"),
    ("site-inf", _set(f"{C}.sites.corner.position", [INF, 0.0, 0.0]), f"{C}.sites.corner.position", r"3 finite numbers"),
    # out of range
    ("mass-zero", _set(f"{C}.mass", 0.0), f"{C}.mass", r"a number > 0 \(kg\), got 0.0"),
    ("mass-negative", _set(f"{C}.mass", -2.0), f"{C}.mass", r"a number > 0 \(kg\), got -2.0"),
    ("damping-negative", _set(f"{C}.damping.angular", -0.1), f"{C}.damping.angular", r"a number ≥ 0"),
    ("box-zero-edge", _set(f"{C}.inertia", {"box": [1.0, 0.0, 0.4]}), f"{C}.inertia.box", r"3 finite numbers > 0"),
    ("sphere-negative", _set(f"{C}.inertia", {"sphere": -1.0}), f"{C}.inertia.sphere", r"a number > 0"),
    ("principal-zero", _set(f"{C}.inertia", {"principal": [1.0, 0.0, 1.0]}), f"{C}.inertia.principal", r"3 finite numbers > 0"),
    # inertia that no body has
    ("tensor-not-symmetric", _set(f"{C}.inertia", {"tensor": [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}),
     f"{C}.inertia.tensor", r"symmetric positive-definite .*\(it is not symmetric\)"),
    ("tensor-not-positive-definite", _set(f"{C}.inertia", {"tensor": [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}),
     f"{C}.inertia.tensor", r"\(it is not positive definite\)"),
    ("tensor-negative-diagonal", _set(f"{C}.inertia", {"tensor": [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]}),
     f"{C}.inertia.tensor", r"\(it is not positive definite\)"),
    ("principal-triangle", _set(f"{C}.inertia", {"principal": [1.0, 1.0, 3.0]}), f"{C}.inertia.principal",
     r"principal moments satisfying the triangle inequality I1 \+ I2 ≥ I3, got \[1.0, 1.0, 3.0\]"),
    ("tensor-triangle", _set(f"{C}.inertia", {"tensor": [[3.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}),
     f"{C}.inertia.tensor", r"triangle inequality I2 \+ I3 ≥ I1"),
    ("rotated-tensor-triangle", _set(f"{C}.inertia", {"tensor": [[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 0.5]]}),
     f"{C}.inertia.tensor", r"triangle inequality"),
    # names
    ("reserved-body-world", _rename_body("crate", "world"), "bodies.world", r"a name other than the reserved \['world'\]"),
    ("reserved-site-world-aligned", _set(f"{C}.sites.world_aligned", {"position": [0, 0, 0]}),
     f"{C}.sites.world_aligned", r"a name other than the reserved \['world_aligned'\]"),
    ("body-name-digit-first", _rename_body("crate", "1crate"), "bodies.1crate", r"a name of ASCII letters, digits and '_' starting with a letter"),
    ("body-name-dash", _rename_body("crate", "my-crate"), "bodies.my-crate", r"a name of ASCII letters"),
    ("body-name-slash", _rename_body("crate", "a/b"), "bodies.a/b", r"a name of ASCII letters"),
    ("body-name-integer", _rename_body("crate", 7), "bodies.7", r"a name of ASCII letters.*, got 7"),
    ("site-name-space", _set(f"{C}.sites.top edge", {"position": [0, 0, 0]}), f"{C}.sites.top edge", r"a name of ASCII letters"),
    # orientation not a unit quaternion
    ("orientation-not-unit", _set(f"{C}.pose.orientation", [0.0, 0.0, 0.0, 1.01]), f"{C}.pose.orientation",
     r"a unit quaternion \[x, y, z, w\] .*\|q\| = 1.01"),
    ("orientation-just-beyond", _set(f"{C}.pose.orientation", [0.0, 0.0, 0.0, 1.0 + 2 * ORIENTATION_TOLERANCE]),
     f"{C}.pose.orientation", r"a unit quaternion"),
    ("orientation-zero", _set(f"{C}.pose.orientation", [0.0, 0.0, 0.0, 0.0]), f"{C}.pose.orientation", r"a unit quaternion"),
]


@pytest.mark.parametrize(("mutate", "key_path", "expected"), [c[1:] for c in BAD_SCENES], ids=[c[0] for c in BAD_SCENES])
def test_bad_scene_file_is_rejected_with_file_key_path_and_expectation(
    tmp_path: Path, mutate: Callable[[dict[str, Any]], None], key_path: str, expected: str
) -> None:
    data = _base()
    mutate(data)
    path = _write(tmp_path, yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
    where = f"{path}: {key_path}: " if key_path else f"{path}: "
    with pytest.raises(SceneError, match=re.escape(where) + r"expected " + r".*" + expected) as info:
        load_scene(path)
    assert str(info.value).startswith(str(path))


@pytest.mark.parametrize(("mutate", "key_path", "expected"), [c[1:] for c in BAD_SCENES], ids=[c[0] for c in BAD_SCENES])
def test_bad_scene_dict_is_rejected_the_same_way(
    mutate: Callable[[dict[str, Any]], None], key_path: str, expected: str
) -> None:
    data = _base()
    mutate(data)
    where = f"<dict>: {key_path}: " if key_path else "<dict>: "
    with pytest.raises(SceneError, match=re.escape(where) + r"expected .*" + expected):
        load_scene(data)


def test_non_finite_numbers_spelled_the_yaml_way(tmp_path: Path) -> None:
    for spelling in (".nan", ".NaN", ".inf", "-.inf", ".Inf"):
        text = VALID_YAML.replace("mass: 2.0", f"mass: {spelling}")
        assert f"mass: {spelling}" in text
        path = _write(tmp_path, text, f"scene_{spelling.strip('.-')}.yaml")
        with pytest.raises(SceneError, match=re.escape(f"{path}: bodies.crate.mass: expected a finite number (kg), got ")):
            load_scene(path)


DUPLICATE_BODY_YAML = """\
bodies:
  crate:
    mass: 2.0
    inertia: {box: [1.0, 0.6, 0.4]}
  ball:
    mass: 1.0
    inertia: {sphere: 0.1}
  crate:
    mass: 5.0
    inertia: {sphere: 0.3}
"""


def test_duplicate_body_names_are_rejected_with_their_lines(tmp_path: Path) -> None:
    """PyYAML alone silently keeps the last 'crate'; the scene loader must refuse the file."""
    assert list(yaml.safe_load(DUPLICATE_BODY_YAML)["bodies"]) == ["crate", "ball"]  # the trap
    path = _write(tmp_path, DUPLICATE_BODY_YAML)
    with pytest.raises(SceneError, match=re.escape(f"{path}: bodies.crate: expected each key once per mapping, "
                                                   "got 'crate' again at line 8 (first at line 2)")):
        load_scene(path)


@pytest.mark.parametrize(
    ("text", "key_path", "lines"),
    [
        ("bodies:\n  b:\n    mass: 1.0\n    inertia: {sphere: 1.0}\n    mass: 2.0\n", "bodies.b.mass", "line 5 (first at line 3)"),
        ("bodies: {b: {mass: 1.0, inertia: {sphere: 1.0, sphere: 2.0}}}\n", "bodies.b.inertia.sphere", "line 1 (first at line 1)"),
        ("bodies:\n  b:\n    mass: 1.0\n    inertia: {sphere: 1.0}\n    sites:\n      s: {position: [0, 0, 0]}\n"
         "      s: {position: [1, 0, 0]}\n", "bodies.b.sites.s", "line 7 (first at line 6)"),
        ("gravity: [0, 0, -9.81]\nbodies: {b: {mass: 1, inertia: {sphere: 1}}}\ngravity: [0, 0, 0]\n", "gravity",
         "line 3 (first at line 1)"),
    ],
    ids=["body-key", "inertia-kind", "site", "top-level"],
)
def test_duplicate_keys_anywhere_are_rejected(tmp_path: Path, text: str, key_path: str, lines: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(SceneError, match=re.escape(f"{path}: {key_path}: expected each key once per mapping")
                       + ".*" + re.escape(lines)):
        load_scene(path)


def test_anchors_aliases_and_merge_keys_are_not_duplicates(tmp_path: Path) -> None:
    text = (
        "shared: &shape {mass: 1.0, inertia: {sphere: 0.5}}\n"
        "bodies:\n  a: *shape\n  b: *shape\n  c: {<<: *shape, mass: 3.0}\n"
    )
    # The top-level helper key is then (correctly) unknown to the schema: the aliases passed.
    with pytest.raises(SceneError, match=re.escape(f"{tmp_path / 'scene.yaml'}: shared: expected one of the keys")):
        load_scene(_write(tmp_path, text))
    body = "{mass: 1.0, inertia: {sphere: 0.5}}"
    text = f"bodies:\n  a: &shape {body}\n  b: *shape\n  c: {{<<: *shape, mass: 3.0}}\n"
    scene = load_scene(_write(tmp_path, text))
    assert scene.body_names == ("a", "b", "c")
    np.testing.assert_array_equal(scene.model.mass, [1.0, 1.0, 3.0])


# --------------------------------------------------------------------------- bad files


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nowhere.yaml"
    with pytest.raises(SceneError, match=re.escape(f"{path}: cannot read scene file (No such file or directory)")):
        load_scene(path)


def test_directory_instead_of_file(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match=re.escape(f"{tmp_path}: cannot read scene file")):
        load_scene(tmp_path)


@pytest.mark.parametrize(
    "text",
    ["bodies: [unclosed\n", "bodies:\n  b: {mass: 1\n", "a: b: c\n", "---\nbodies: {}\n---\nbodies: {}\n", "\tbodies: 1\n"],
    ids=["unclosed-list", "unclosed-map", "nested-colon", "two-documents", "tab-indent"],
)
def test_not_yaml(tmp_path: Path, text: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(SceneError, match=re.escape(f"{path}: ") + r"(not valid YAML at line \d+|expected one YAML document)"):
        load_scene(path)


def test_not_utf8(tmp_path: Path) -> None:
    path = tmp_path / "scene.yaml"
    path.write_bytes(b"bodies:\n  b\xff\xfe: 1\n")
    with pytest.raises(SceneError, match=re.escape(f"{path}: cannot read scene file")):
        load_scene(path)


@pytest.mark.parametrize(("text", "got"), [("", "nothing (empty file)"), ("# only a comment\n", "nothing (empty file)")],
                         ids=["empty", "comment-only"])
def test_empty_file(tmp_path: Path, text: str, got: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(SceneError, match=re.escape(f"{path}: expected a mapping with key 'bodies' at the top, got {got}")):
        load_scene(path)


def test_file_over_the_size_limit(tmp_path: Path) -> None:
    path = tmp_path / "huge.yaml"
    with open(path, "wb") as handle:  # sparse: costs no disk
        handle.truncate(MAX_SCENE_BYTES + 1)
    with pytest.raises(SceneError, match=re.escape(f"{path}: scene file is ") + ".*" + re.escape(f"; expected at most {MAX_SCENE_BYTES}")):
        load_scene(path)


@pytest.mark.parametrize(("text", "got"), [("- crate\n- ball\n", "list"), ("42\n", "int"), ("just words\n", "str")],
                         ids=["list", "number", "string"])
def test_wrong_top_level_type(tmp_path: Path, text: str, got: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(SceneError, match=re.escape(f"{path}: expected a mapping with key 'bodies' at the top, got {got}")):
        load_scene(path)


# --------------------------------------------------------------------------- nothing half-loaded


def test_a_failing_load_returns_nothing_and_changes_nothing(tmp_path: Path) -> None:
    """The first body is fine, the last is not: no partial scene, and the input is untouched."""
    data = _base()
    data["bodies"]["zeppelin"] = {"mass": 1.0, "inertia": {"principal": [1.0, 1.0, 3.0]}}
    before = copy.deepcopy(data)
    result = None
    with pytest.raises(SceneError, match=r"bodies\.zeppelin\.inertia\.principal"):
        result = load_scene(data)
    assert result is None
    assert data == before
    path = _write(tmp_path, yaml.safe_dump(data, sort_keys=False))
    text_before = path.read_text(encoding="utf-8")
    with pytest.raises(SceneError, match=r"bodies\.zeppelin"):
        result = load_scene(path)
    assert result is None
    assert path.read_text(encoding="utf-8") == text_before


def test_unknown_body_in_frames_of_lists_the_bodies() -> None:
    scene = load_scene(_base())
    with pytest.raises(ValueError, match=re.escape("unknown body 'crat'; bodies are ['crate', 'ball']")):
        scene.frames_of("crat")
