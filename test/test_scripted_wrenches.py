"""Scripted wrenches: the scene's ``wrenches`` list, validated like the rest, applied by the core
on every step whose start time lies in [start, start + duration), and honoured by the node.

The physics checks are closed forms: a constant force through the centre of mass over n whole
steps changes the velocity by exactly F/m · n·dt for every fixed-step method (each adds the
constant acceleration times dt, kicks included), rk4 is exact for piecewise-constant
acceleration in position too, and a torque about a principal axis of a body at rest changes
only that rate, by τ/I · n·dt. n counts the steps whose start time k·dt is in the window.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from helpers import EPS, FIXED_STEP_INTEGRATORS
from rigid_body_sim.core import SceneError, Simulator, describe_scene, load_scene
from rigid_body_sim.core.simulator import SCRIPT_TIME_TOLERANCE

BOX = {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]},
       "sites": {"corner": {"position": [0.5, 0.3, 0.0]}, "nozzle": {"position": [0.0, 0.0, -0.2], "axes": "world"}}}


def scene_with(wrenches: Any, **extra: Any) -> dict[str, Any]:
    return {"bodies": {"box": dict(BOX), "ball": {"mass": 1.0, "inertia": {"sphere": 0.1}}}, "wrenches": wrenches, **extra}


def steps_in_window(start: float, duration: float, dt: float, total: int) -> int:
    """Steps k < total whose start time k·dt lies in [start, start + duration) (the documented rule)."""
    tol = SCRIPT_TIME_TOLERANCE * dt
    return sum(1 for k in range(total) if start - tol <= k * dt < start + duration - tol)


# --------------------------------------------------------------------------- loading


def test_defaults_and_fields() -> None:
    scene = load_scene(scene_with([{"body": "box", "frame": "box/corner", "force": [0, 10, 0]},
                                   {"body": "ball", "frame": "world", "torque": [0, 0, 1], "start": 0.5, "duration": 2}]))
    first, second = scene.wrenches
    assert (first.body, first.frame, first.start, first.duration, first.end) == ("box", "box/corner", 0.0, math.inf, math.inf)
    np.testing.assert_array_equal(first.force, [0.0, 10.0, 0.0])
    np.testing.assert_array_equal(first.torque, [0.0, 0.0, 0.0])
    assert (second.start, second.duration, second.end) == (0.5, 2.0, 2.5)
    np.testing.assert_array_equal(second.force, np.zeros(3))
    described = {d["name"]: d["scripted_wrenches"] for d in describe_scene(scene)}
    assert described["box"] == [{"frame": "box/corner", "force": [0.0, 10.0, 0.0], "torque": [0.0, 0.0, 0.0],
                                 "start": 0.0, "duration": None}]
    assert described["ball"][0]["duration"] == 2.0


def test_no_wrenches_key_and_null_mean_none() -> None:
    assert load_scene({"bodies": {"b": BOX}}).wrenches == ()
    assert load_scene(scene_with(None)).wrenches == ()
    assert load_scene(scene_with([])).wrenches == ()


W = "wrenches[0]"
BAD_WRENCHES = [
    ("not-a-list", {"body": "box"}, "wrenches", r"a list of \{body, frame, force, torque, start, duration\} mappings"),
    ("entry-not-mapping", ["box"], W, r"a mapping with keys \['body', 'frame', 'force', 'torque', 'start', 'duration'\]"),
    ("unknown-key", [{"body": "box", "frame": "box", "point": [0, 0, 0]}], f"{W}.point",
     r"one of the keys \['body', 'frame', 'force', 'torque', 'start', 'duration'\] \(unknown key\)"),
    ("no-body", [{"frame": "world"}], W, r"required key 'body'"),
    ("no-frame", [{"body": "box"}], W, r"required key 'frame'"),
    ("unknown-body", [{"body": "crate", "frame": "world"}], f"{W}.body", r"one of the bodies \['box', 'ball'\], got 'crate'"),
    ("unknown-frame", [{"body": "box", "frame": "ball"}], f"{W}.frame",
     r"one of the frames of 'box' \['world', 'box', 'box/world_aligned', 'box/corner', 'box/nozzle'\], got 'ball'"),
    ("other-body-site", [{"body": "ball", "frame": "box/corner"}], f"{W}.frame", r"one of the frames of 'ball'"),
    ("force-2", [{"body": "box", "frame": "box", "force": [1, 2]}], f"{W}.force", r"a list of 3 finite numbers \(N"),
    ("force-nan", [{"body": "box", "frame": "box", "force": [1, float("nan"), 0]}], f"{W}.force", r"a list of 3 finite numbers"),
    ("torque-inf", [{"body": "box", "frame": "box", "torque": [0, 0, float("inf")]}], f"{W}.torque",
     r"a list of 3 finite numbers \(N·m about the frame's origin"),
    ("start-negative", [{"body": "box", "frame": "box", "start": -0.1}], f"{W}.start", r"a number ≥ 0 \(s of sim time\), got -0.1"),
    ("start-string", [{"body": "box", "frame": "box", "start": "soon"}], f"{W}.start", r"a number \(s of sim time\), got 'soon'"),
    ("duration-zero", [{"body": "box", "frame": "box", "duration": 0}], f"{W}.duration", r"a number > 0 \(s; leave it out"),
    ("duration-negative", [{"body": "box", "frame": "box", "duration": -1.0}], f"{W}.duration", r"a number > 0"),
    ("duration-inf", [{"body": "box", "frame": "box", "duration": float("inf")}], f"{W}.duration", r"a finite number"),
    ("second-entry", [{"body": "box", "frame": "box"}, {"body": "box", "frame": "box", "start": True}], "wrenches[1].start",
     r"a number \(s of sim time\), got True"),
]


@pytest.mark.parametrize(("wrenches", "key_path", "expected"), [c[1:] for c in BAD_WRENCHES], ids=[c[0] for c in BAD_WRENCHES])
def test_bad_wrenches_are_rejected_with_file_key_path_and_expectation(
        tmp_path: Path, wrenches: Any, key_path: str, expected: str) -> None:
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene_with(wrenches), sort_keys=False, allow_unicode=True), encoding="utf-8")
    with pytest.raises(SceneError, match=re.escape(f"{path}: {key_path}: expected ") + expected):
        load_scene(path)
    with pytest.raises(SceneError, match=re.escape(f"<dict>: {key_path}: expected ") + expected):
        load_scene(scene_with(wrenches))


# --------------------------------------------------------------------------- the window, against closed forms


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
@pytest.mark.parametrize(("start", "duration", "dt"), [
    (0.25, 0.42, 0.1),     # edges between steps: steps 3..6 act (t = 0.3, 0.4, 0.5, 0.6)
    (0.3, 0.3, 0.1),       # edges on steps, where k·dt carries round-off: steps 3, 4, 5
    (0.0, 0.05, 0.01),     # from the first step
    (0.123, 0.0001, 0.01),  # shorter than a step, not on a step start: no step acts
])
def test_force_through_com_over_a_window_gives_the_exact_velocity_change(
        integrator: str, start: float, duration: float, dt: float) -> None:
    force_W = np.array([3.0, -1.0, 2.0])
    scene = load_scene(scene_with([{"body": "ball", "frame": "ball/world_aligned", "force": force_W.tolist(),
                                    "start": start, "duration": duration}]))
    sim = Simulator(scene, integrator=integrator, dt=dt)
    total = int(round((start + duration) / dt)) + 5
    sim.step(total)
    n = steps_in_window(start, duration, dt, total)
    assert n == {(0.25, 0.42): 4, (0.3, 0.3): 3, (0.0, 0.05): 5, (0.123, 0.0001): 0}[(start, duration)]
    v = sim.body_state("ball").linear_velocity_world
    np.testing.assert_allclose(v, force_W / 1.0 * n * dt, rtol=0, atol=8 * n * EPS * np.abs(force_W).max() * dt)
    np.testing.assert_array_equal(sim.body_state("ball").angular_velocity_world, np.zeros(3))


def test_rk4_position_is_exact_for_a_windowed_force() -> None:
    """Piecewise-constant acceleration a on the steps [k0, k1): p(T) = ½ a (t1 − t0)² + a (t1 − t0)(T − t1)."""
    dt, start, duration = 0.01, 0.1, 0.2
    force = np.array([0.0, 4.0, 0.0])
    sim = Simulator(load_scene(scene_with([{"body": "box", "frame": "world", "force": force.tolist(),
                                            "start": start, "duration": duration}])), "rk4", dt)
    total = 50
    sim.step(total)
    k0, k1 = 10, 30
    assert steps_in_window(start, duration, dt, total) == k1 - k0
    a = force / 2.0
    t0, t1, T = k0 * dt, k1 * dt, total * dt
    expected = 0.5 * a * (t1 - t0) ** 2 + a * (t1 - t0) * (T - t1)
    np.testing.assert_allclose(sim.body_state("box").position_world, expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(sim.body_state("box").angular_velocity_world, np.zeros(3))  # world force at the COM


def test_torque_about_a_principal_axis_over_a_window() -> None:
    """Body frame torque about z on a box at rest: ω_z = τ/I_z · n·dt, ω_x = ω_y = 0, v = 0."""
    dt, tau = 0.01, 0.5
    sim = Simulator(load_scene(scene_with([{"body": "box", "frame": "box", "torque": [0, 0, tau], "start": 0.05,
                                            "duration": 0.1}])), "rk4", dt)
    sim.step(40)
    I_z = 2.0 * (1.0**2 + 0.6**2) / 12.0
    w_B = sim.body_state("box").angular_velocity_body
    np.testing.assert_allclose(w_B, [0.0, 0.0, tau / I_z * 10 * dt], rtol=1e-14, atol=1e-17)
    np.testing.assert_array_equal(sim.body_state("box").linear_velocity_world, np.zeros(3))


def test_window_lookup_and_edges() -> None:
    scene = load_scene(scene_with([{"body": "box", "frame": "box/corner", "force": [0, 1, 0], "start": 0.3, "duration": 0.3},
                                   {"body": "ball", "frame": "ball", "torque": [1, 0, 0], "start": 0.5}]))
    sim = Simulator(scene, dt=0.1)
    names = lambda t: [(b, f) for b, f, _force, _torque in sim.active_scripted_wrenches(t)]  # noqa: E731
    assert names(0.0) == []
    assert names(3 * 0.1) == [("box", "box/corner")]        # 0.30000000000000004: on the edge, in
    assert names(0.3 - 0.5 * SCRIPT_TIME_TOLERANCE * 0.1) == [("box", "box/corner")]
    assert names(0.5) == [("box", "box/corner"), ("ball", "ball")]
    assert names(6 * 0.1) == [("ball", "ball")]              # 0.6000000000000001: the end is excluded
    assert names(1e9) == [("ball", "ball")]                  # no duration: forever
    sim.step(4)
    assert names(None) == [("box", "box/corner")]            # default: now (t = 0.4)


def test_script_is_the_same_as_applying_the_wrench_each_step() -> None:
    """A scripted site wrench and the same wrench applied by hand before each step: bitwise equal."""
    wrench = {"body": "box", "frame": "box/nozzle", "force": [1.0, -2.0, 0.5], "torque": [0.1, 0.0, -0.2],
              "start": 0.02, "duration": 0.05}
    base = {"bodies": {"box": {**BOX, "twist": {"angular": [0.3, -0.2, 0.9]}}}}
    scripted = Simulator(load_scene({**base, "wrenches": [wrench]}), "rk4", 0.01)
    by_hand = Simulator(load_scene(base), "rk4", 0.01)
    for k in range(12):
        if 2 <= k < 7:
            by_hand.apply_wrench("box", wrench["force"], wrench["torque"], "box/nozzle")
        scripted.step()
        by_hand.step()
        np.testing.assert_array_equal(scripted.state.w_WP_P, by_hand.state.w_WP_P)
        np.testing.assert_array_equal(scripted.state.q_WP, by_hand.state.q_WP)
        np.testing.assert_array_equal(scripted.state.v_WC_W, by_hand.state.v_WC_W)


def test_applied_wrenches_add_to_the_script_and_still_clear() -> None:
    sim = Simulator(load_scene(scene_with([{"body": "ball", "frame": "world", "force": [1, 0, 0]}])), "rk4", 0.01)
    sim.apply_wrench("ball", force=[0, 2, 0], frame="world")
    sim.step(3)   # the applied one holds for this call only
    sim.step(2)   # the script alone
    np.testing.assert_allclose(sim.body_state("ball").linear_velocity_world, [5 * 0.01, 3 * 2 * 0.01, 0.0],
                               rtol=1e-14, atol=0)


def test_reset_replays_the_script() -> None:
    sim = Simulator(load_scene(scene_with([{"body": "ball", "frame": "world", "force": [1, 0, 0], "duration": 0.02}])),
                    "rk4", 0.01)
    sim.step(5)
    first = sim.body_state("ball").linear_velocity_world
    sim.reset()
    sim.step(5)
    np.testing.assert_array_equal(sim.body_state("ball").linear_velocity_world, first)
    np.testing.assert_allclose(first, [0.02, 0.0, 0.0], rtol=1e-14)


# --------------------------------------------------------------------------- the node honours the script


@pytest.mark.ros
def test_node_applies_the_script_per_physics_step_mid_tick(tmp_path: Path) -> None:
    """100 Hz × 4 substeps: dt = 2.5 ms. A window [12.5 ms, 17.5 ms) starts mid-tick (ticks at 10, 20 ms)
    and covers exactly 2 physics steps, so Δv = F/m · 2 dt, which no tick-granular scheme gives.
    A held wrench from the topic adds to it over whole ticks."""
    from rigid_body_sim.testing import SimHarness

    dt = 1.0 / (100.0 * 4)
    scene = scene_with([{"body": "ball", "frame": "ball/world_aligned", "force": [1.0, 0.0, 0.0], "start": 5 * dt,
                         "duration": 2 * dt}])
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene), encoding="utf-8")
    with SimHarness(scene=path, parameters={"substeps": 4, "wrench_timeout": 0.0}) as harness:
        harness.step(1)
        assert harness.latest_twist("ball").linear.x == 0.0
        harness.publish_wrench("ball", force=(0.0, 3.0, 0.0), frame_id="ball/world_aligned")
        harness.step(3)
        twist = harness.latest_twist("ball")
        assert twist.linear.x == pytest.approx(2 * dt, rel=1e-14, abs=0)
        assert twist.linear.y == pytest.approx(3.0 * 12 * dt, rel=1e-14, abs=0)
        assert harness.node.simulator.step_count == 16
