"""Spawning and deleting bodies at run time: the running scene, edited as data, then loaded whole.

A spawn request gives, per new body, its definition in the scene file's form (the mapping under
``bodies.<name>`` in a scene YAML file: mass, inertia, pose, twist, sites, motion...). A delete
request names bodies. :func:`edited_scene` turns the running scene's own text plus the request
into a new scene through the ordinary loader (so every check of a scene file applies, and an
error names the key path, e.g. ``spawn request: bodies.crate2.mass: expected ...``); the node
then continues the simulation in it with ``Simulator.with_scene`` (sim time, step count and
every other body's state carry over). Scripted wrenches of a deleted body are deleted with it.
Nothing is changed unless the whole request is valid.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from ..core import Scene, SceneError
from ..core.scene import load_scene_text
from ..core.scene_yaml import YamlReadError, read_yaml

__all__ = ["SOURCE", "scene_data", "edited_scene"]

#: What errors call a scene made by an edit (and its ``Scene.source``).
SOURCE = "spawn/delete request"

#: Longest definition of one spawned body, characters: 8 MiB, far more than a body with its
#: sites needs (MAX_SITES_PER_BODY sites of ~100 characters), and read while the node waits.
MAX_DEFINITION_CHARS = 8 * 1024 * 1024


def scene_data(scene: Scene) -> dict[str, Any]:
    """The running scene as data (parsed from its text, which every scene the node runs has).

    Raises
    ------
    SceneError
        If the scene carries no text (a scene built from a dict in Python).
    """
    if scene.text is None:
        raise SceneError(f"{scene.source}: the running scene has no YAML text to edit")
    try:
        data = read_yaml(scene.text[1:] if scene.text.startswith("\ufeff") else scene.text)
    except YamlReadError as exc:  # it loaded once, so this would be a bug
        raise SceneError(f"{scene.source}: {exc}") from None
    return dict(data)


def edited_scene(scene: Scene, spawn: Mapping[str, str], delete: list[str]) -> Scene:
    """``scene`` with the bodies of ``spawn`` (name → YAML text of its definition) added after the
    others, and the bodies in ``delete`` (and their scripted wrenches) removed.

    Raises
    ------
    SceneError
        Naming the problem: an unknown body to delete, a name that exists already, a definition
        that is not YAML or not a mapping, a scene with no body left, or whatever the scene
        loader finds wrong with the result (with its key path).
    """
    data = scene_data(scene)
    bodies = dict(data.get("bodies") or {})
    unknown = [name for name in delete if name not in bodies]
    if unknown:
        raise SceneError(f"{SOURCE}: cannot delete {unknown}: no such body; bodies are {list(bodies)}")
    for name in delete:
        del bodies[name]
    for name, text in spawn.items():
        if name in bodies:
            raise SceneError(f"{SOURCE}: cannot spawn {name!r}: a body of that name exists; delete it first or "
                             "choose another name")
        if len(text) > MAX_DEFINITION_CHARS:  # the loader bounds the rest
            raise SceneError(f"{SOURCE}: bodies.{name}: expected a definition of at most {MAX_DEFINITION_CHARS} "
                             f"characters, got {len(text)}")
        try:
            definition = read_yaml(text)
        except YamlReadError as exc:
            raise SceneError(f"{SOURCE}: bodies.{name}: expected a body definition in YAML ({exc})") from None
        if not isinstance(definition, Mapping):
            raise SceneError(f"{SOURCE}: bodies.{name}: expected a mapping (mass, inertia, pose, twist, sites, "
                             f"motion, damping, as under bodies.<name> in a scene file), got {type(definition).__name__}")
        bodies[name] = definition
    if not bodies:
        raise SceneError(f"{SOURCE}: deleting {delete} would leave no body; a scene keeps at least one")
    data["bodies"] = bodies
    if data.get("wrenches"):
        data["wrenches"] = [w for w in data["wrenches"] if not (isinstance(w, Mapping) and w.get("body") in delete)]
    # JSON is YAML 1.2: the new scene keeps its text (for the next edit and recordings), floats exactly (repr).
    try:
        text = json.dumps(data, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise SceneError(f"{SOURCE}: the edited scene cannot be written as text ({exc})") from None
    return load_scene_text(text, SOURCE)
