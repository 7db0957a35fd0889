"""Parameter abuse: a bad change is refused whole, with a reason, and the running simulation
does not notice, wherever on its way it is refused (rclpy, the parameter table, the node's file
rules, the scene loader); a valid ``scene`` swaps the scene whole.

One harness takes a bad change for each of those places in turn (``bad_changes``), each time
with a wrench held and an impulse pending, ticking between attempts; a twin harness gets the
same wrenches and ticks and no bad change. Refusals must leave the state, time, holds, pending
impulses, topics and every parameter exactly as they were (compared before and after each
attempt), and the two runs must end bitwise equal.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import PoseStamped

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.ros.parameters import BY_NAME
from rigid_body_sim.testing import SimHarness

pytestmark = pytest.mark.ros

PARAMETER_NAMES = tuple(BY_NAME)
START = {"integrator": "rk4", "wrench_timeout": 0.0, "substeps": 2}

SCENE_A = {
    "bodies": {
        "box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}, "pose": {"position": [0.0, 0.0, 1.0]},
                "twist": {"angular": [0.2, 0.1, 0.5]}, "sites": {"corner": {"position": [0.5, 0.3, 0.0]}}},
        "probe": {"mass": 0.5, "inertia": {"sphere": 0.1}},
    }
}
SCENE_B = {
    "gravity": [0.0, 0.0, -9.81],
    "bodies": {
        "box": {"mass": 3.0, "inertia": {"principal": [0.1, 0.2, 0.25]}, "pose": {"position": [1.0, 2.0, 3.0]}},
        "rover": {"mass": 10.0, "inertia": {"cylinder": [0.3, 0.2]}, "twist": {"linear": [1.0, 0.0, 0.0]},
                  "sites": {"wheel": {"position": [0.3, 0.0, -0.1]}}},
    }
}


def _write(path, data) -> str:
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data))
    return str(path)


def bad_changes(tmp_path) -> list[tuple[str, dict, str]]:
    """(label, changes, a phrase the refusal must contain): one bad change for each place on the way
    from the parameter service to the running simulation where a change can be refused.

    Every bad value of every parameter is not repeated here: each ranged parameter's refusal at either
    end and NaN, through the service, is in test_parameters.py (``ranged``); the reasons of other bad
    values (wrong types, choices, read-only parameters) in-process there too
    (``test_change_problems_name_every_bad_value``); each way a scene file can be bad, in-process in
    test_scene.py and test_hostile.py (the node wraps every loader error the same way).
    """
    fifo = tmp_path / "fifo.yaml"  # named like a scene: the node's file rules let it through to the loader
    os.mkfifo(fifo)
    scene_b = _write(tmp_path / "b.yaml", SCENE_B)
    return [
        # rclpy, before the node's callback: a name the node never declared.
        ("undeclared parameter", {"no_such_parameter": 1.0}, "undeclared"),
        # The parameter table (parameters.change_problems), in its order of checks: read-only, node-owned,
        # type (a scalar, and an array, which only arrives as one through the service), finiteness,
        # range (a double's and an integer's: rclpy would check either against its descriptor in its own
        # words), choices, a check in code.
        ("read-only world frame", {"world_frame": "map"}, "world_frame is read-only: set at start-up only"),
        ("node-owned body names", {"body_names": ["x"]}, "body_names is read-only: the node sets it"),
        ("rate as text", {"rate_hz": "fast"}, "rate_hz must be a double, got a string ('fast')"),
        ("rate as a list", {"rate_hz": [1.0, 2.0]}, "rate_hz must be a double, got a double array"),
        ("NaN rate", {"rate_hz": math.nan}, "rate_hz must be a finite double"),
        ("negative rate", {"rate_hz": -5.0}, "rate_hz out of range"),
        ("zero substeps", {"substeps": 0}, "substeps out of range"),
        ("unknown integrator", {"integrator": "leapfrog"}, "integrator must be one of"),
        ("empty scene path", {"scene": ""}, "scene must be the path"),
        # The node's file rules (file_access.change_refusal): a scene outside scene_dirs.
        ("scene is /dev/zero", {"scene": "/dev/zero"}, "not inside the directories of scene_dirs"),
        # The loader, while the change is prepared (session.begin_change): a FIFO must not block it.
        ("scene is a FIFO", {"scene": str(fifo)}, "not a regular file"),
        # All or nothing: a valid scene and substeps with one bad value change nothing.
        ("valid scene with a bad rate", {"scene": scene_b, "substeps": 4, "rate_hz": -1.0}, "rate_hz"),
        ("valid rate with a bad scene", {"rate_hz": 50.0, "integrator": "splitting", "scene": str(fifo)},
         "not a regular file"),
    ]


def snapshot(harness: SimHarness) -> dict:
    node = harness.node
    sim = node.simulator
    state = sim.state
    return {
        "time": sim.time, "steps": sim.step_count, "dt": sim.dt, "integrator": sim.integrator, "bodies": sim.body_names,
        "state": b"".join(a.tobytes() for a in (state.p_WC_W, state.q_WP, state.v_WC_W, state.w_WP_P)),
        "held": {k: (f.tobytes(), t.tobytes()) for k, (f, t) in node.held_wrenches.items()},
        "pending": {k: (j.tobytes(), h.tobytes()) for k, (j, h) in node.pending_impulses.items()},
        "parameters": harness.get_parameters(PARAMETER_NAMES),
        "publishers": sorted(name for name, _types in node.get_publisher_names_and_types_by_node(node.get_name(), "/")),
        "subscriptions": sorted(name for name, _types in node.get_subscriber_names_and_types_by_node(node.get_name(), "/")),
    }


def drive(harness: SimHarness, k: int) -> None:
    """The same inputs for both runs: a held wrench (replaced each time) and a pending impulse."""
    harness.publish_wrench("box", force=(0.1 * k, 0.0, 0.05), torque=(0.0, 0.01, 0.0), frame_id="box/corner")
    harness.publish_impulse("probe", linear=(0.0, 0.002 * k, 0.0), angular=(0.0, 0.0, 1e-4), frame_id="world")


def test_bad_parameters_are_refused_whole_and_change_nothing(tmp_path):
    scene_a = _write(tmp_path / "a.yaml", SCENE_A)
    cases = bad_changes(tmp_path)
    refusals = []
    with SimHarness(scene_a, parameters={**START, "scene_dirs": [str(tmp_path)]}) as node:
        for k, (label, changes, phrase) in enumerate(cases):
            drive(node, k)
            before = snapshot(node)
            result = node.set_parameters_atomically(**changes)
            after = snapshot(node)
            assert not result.successful, f"{label}: accepted"
            assert phrase in result.reason, f"{label}: reason {result.reason!r} does not mention {phrase!r}"
            assert after == before, f"{label}: the refusal changed something"
            for rclpy_words in ("Wrong parameter type", "Trying to set a read-only", "Min:", "got 'Type."):
                assert rclpy_words not in result.reason, f"{label}: rclpy's words in {result.reason!r}"
            refusals.append((label, result.reason))
            node.step(2)
        final = snapshot(node)
    with SimHarness(scene_a, parameters=START) as twin:
        for k in range(len(cases)):
            drive(twin, k)
            twin.step(2)
        twin_final = snapshot(twin)
        assert twin_final["state"] == final["state"]
        assert twin_final["time"] == final["time"]
    for label, reason in refusals:  # shown with -s: what an operator reads
        print(f"{label:32s} {reason[:150]}")


def test_bad_start_up_diagnostics_period_is_refused():
    with pytest.raises(ValueError, match="diagnostics_period out of range"):
        SimHarness(parameters={"diagnostics_period": -1.0})


def test_valid_scene_swaps_atomically(tmp_path):
    """Changing ``scene`` (with other parameters, atomically) swaps the scene whole: topics of new
    bodies appear, those of removed bodies go, holds and pending impulses are dropped, the state is
    the new scene's initial state at t = 0, and the next tick is the core's first step on it."""
    scene_a = _write(tmp_path / "a.yaml", SCENE_A)
    scene_b = _write(tmp_path / "b.yaml", SCENE_B)
    with SimHarness(scene_a, parameters={**START, "scene_dirs": [str(tmp_path)]}) as node:
        drive(node, 1)
        node.step(3)
        drive(node, 2)  # a hold and a pending impulse at the moment of the swap
        result = node.set_parameters_atomically(scene=scene_b, integrator="splitting", substeps=3)
        assert result.successful, result.reason
        sim = node.node.simulator
        assert sim.body_names == ("box", "rover") and sim.time == 0.0 and sim.step_count == 0
        assert node.node.held_wrenches == {} and node.node.pending_impulses == {}
        assert node.get_parameter("scene") == scene_b
        expected = Simulator(load_scene(scene_b), integrator="splitting", dt=0.01 / 3)
        for got, want in zip((sim.state.p_WC_W, sim.state.q_WP, sim.state.v_WC_W, sim.state.w_WP_P),
                             (expected.state.p_WC_W, expected.state.q_WP, expected.state.v_WC_W, expected.state.w_WP_P)):
            assert got.tobytes() == want.tobytes()
        topics = snapshot(node)
        assert "/rover/pose" in topics["publishers"] and "/rover/wrench" in topics["subscriptions"]
        assert not any(t.startswith("/probe/") for t in topics["publishers"] + topics["subscriptions"])
        # The harness sees the new body once it subscribes to it, and the old topics go quiet.
        node.watch_body("rover")
        node.spin_until(lambda: node.client.count_publishers("/probe/pose") == 0, "/probe/pose to disappear")
        node.publish_wrench("rover", force=(0.0, 5.0, 0.0), frame_id="rover/wheel")
        node.step()
        expected.apply_wrench("rover", force=[0.0, 5.0, 0.0], frame="rover/wheel")
        expected.step(3)
        for body in ("box", "rover"):
            pose = node.latest_pose(body).pose
            got = [pose.position.x, pose.position.y, pose.position.z]
            assert np.array_equal(got, expected.body_state(body).position_world), body
        # Back to the first scene: probe returns, rover goes.
        assert node.set_parameters_atomically(scene=scene_a).successful
        node.watch_body("probe")
        assert node.node.simulator.body_names == ("box", "probe")
        assert isinstance(node.latest_pose("probe"), PoseStamped)
