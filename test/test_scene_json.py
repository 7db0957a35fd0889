"""A scene in JSON (YAML's subset) reads exactly as the YAML event reader reads it, limits and errors included.

scene_yaml.read_yaml reads a document that starts with ``{`` with Python's json parser when
that gives the same value; everything else (a repeated key, NaN, a long integer, too deep, not
JSON) goes to the event reader, whose errors are reported. The event reader is the oracle here:
the same text through both must give equal values, or the same error.
"""

from __future__ import annotations

import json

import pytest

from rigid_body_sim.core import load_scene
from rigid_body_sim.core.scene import SceneError
from rigid_body_sim.core.scene_yaml import MAX_DEPTH, YamlReadError, _Reader, read_yaml


def _events(text: str):
    """The event reader alone (the oracle)."""
    import yaml

    loader = yaml.CSafeLoader(text)
    try:
        return _Reader().read(loader.get_event)
    finally:
        loader.dispose()


SCENE = {"gravity": [0, 0, -9.81], "energy_growth_limit": 1e6,
         "bodies": {"box": {"mass": 2, "inertia": {"box": [1.0, 0.6, 0.4]},
                            "pose": {"position": [0.5, -1e-3, 1e5], "orientation": [0, 0, 0.6, 0.8]},
                            "sites": {"tip": {"position": [0.5, 0, 0], "axes": "world"}}},
                    "ball": {"mass": 1.5, "inertia": {"sphere": 0.2}, "damping": {"linear": 0.1}}},
         "wrenches": [{"body": "box", "frame": "box/tip", "force": [1, 2, 3], "start": 0.5, "duration": None}]}


@pytest.mark.parametrize("text", [
    json.dumps(SCENE), json.dumps(SCENE, indent=2), '{"n\u00e9": "\u00e9", "t": "\u00e9\t"}', '{"a": "x \\" ] } [", "b": [true, false, null, -0, 1E5, 2e-3]}',
])
def test_json_reads_as_the_event_reader_reads_it(text: str) -> None:
    value = read_yaml(text)
    assert value == _events(text)


@pytest.mark.parametrize("text", [
    '{"a": 1, "a": 2}',                       # a repeated key: an error naming both lines
    '{"a": NaN}', '{"a": Infinity}',          # strings to YAML, numbers to json
    '{"a": ' + "1" * 401 + "}",               # past MAX_INTEGER_DIGITS
    '{"a": ' + "[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1) + "}",  # too deep
    '{a: 1, "b": [1, 2]}',                    # YAML flow, not JSON
])
def test_what_json_would_read_differently_goes_to_the_event_reader(text: str) -> None:
    try:
        expected = _events(text)
    except YamlReadError as exc:
        with pytest.raises(YamlReadError) as got:
            read_yaml(text)
        assert str(got.value) == str(exc)
    else:
        assert read_yaml(text) == expected


def test_a_json_scene_file_loads_as_its_yaml_twin(tmp_path) -> None:
    import yaml

    as_json, as_yaml = tmp_path / "scene.yaml", tmp_path / "twin.yaml"
    as_json.write_text(json.dumps(SCENE))
    as_yaml.write_text(yaml.safe_dump(SCENE, sort_keys=False))
    a, b = load_scene(str(as_json)), load_scene(str(as_yaml))
    assert a.body_names == b.body_names
    assert (a.initial_state.rows() == b.initial_state.rows()).all()
    assert (a.model.inertia_P == b.model.inertia_P).all()
    assert [(w.body, w.frame, w.force.tolist(), w.start, w.end) for w in a.wrenches] == [
        (w.body, w.frame, w.force.tolist(), w.start, w.end) for w in b.wrenches]
    bad = tmp_path / "bad.yaml"
    bad.write_text(json.dumps({"bodies": {"box": {"mass": -1, "inertia": {"sphere": 1}}}}))
    with pytest.raises(SceneError, match=r"bodies\.box\.mass: expected a number > 0 \(kg\), got -1"):
        load_scene(str(bad))
