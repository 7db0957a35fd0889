"""The node through its real ROS interface (in-process, private context, FastDDS on loopback).

Every check compares what arrives over topics with the core stepped directly or with a
closed form; the harness drives the node paused, tick by tick, through ``~/step``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.exact import closed_form
from rigid_body_sim.package_data import default_scene_path
from rigid_body_sim.testing import SimHarness

pytestmark = pytest.mark.ros

DT = 0.01  # s: the default 100 Hz, 1 substep, real-time factor 1

RESTING_BOX = {
    "bodies": {
        "box": {
            "mass": 2.0,
            "inertia": {"box": [1.0, 0.6, 0.4]},
            "pose": {"position": [0.0, 0.0, 1.0], "orientation": [0.0, 0.0, 0.0, 1.0]},
            "sites": {
                "corner": {"position": [0.5, 0.3, 0.0]},
                "nozzle": {"position": [-0.5, 0.0, 0.2], "axes": "world"},
            },
        }
    }
}


@pytest.fixture
def resting_box(tmp_path):
    path = tmp_path / "resting_box.yaml"
    path.write_text(yaml.safe_dump(RESTING_BOX))
    return path


def pose_arrays(harness: SimHarness, body: str):
    pose = harness.latest_pose(body).pose
    twist = harness.latest_twist(body)
    return (
        np.array([pose.position.x, pose.position.y, pose.position.z]),
        np.array([pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w]),
        np.array([twist.linear.x, twist.linear.y, twist.linear.z]),
        np.array([twist.angular.x, twist.angular.y, twist.angular.z]),
    )


def core_arrays(sim: Simulator, body: str):
    s = sim.body_state(body)
    return s.position_world, s.orientation_xyzw, s.linear_velocity_world, s.angular_velocity_world


def assert_same_motion(got, expected, atol=0.0):
    for name, a, b in zip(("position", "orientation", "linear velocity", "angular velocity"), got, expected):
        np.testing.assert_allclose(a, b, rtol=0.0, atol=atol, err_msg=name)


def test_textbook_push_at_corner_matches_core():
    """The default (tumbling) box pushed at box/corner: the node's topics equal the core, bitwise.

    The node forwards the held wrench to the same core calls, and float64 survives the
    messages unchanged, so nothing but identical arithmetic is involved: atol = 0.
    """
    core = Simulator(load_scene(default_scene_path()), integrator="rk4", dt=DT)
    with SimHarness(parameters={"integrator": "rk4", "wrench_timeout": 0.0}) as node:
        node.publish_wrench("box", force=(0.0, 10.0, 0.0), frame_id="box/corner")
        node.step(25)
        for _ in range(25):
            core.apply_force_at_point("box", force=[0.0, 10.0, 0.0], point=[0.0, 0.0, 0.0], frame="box/corner")
            core.step()
        assert_same_motion(pose_arrays(node, "box"), core_arrays(core, "box"))
        stamp = node.latest_pose("box").header.stamp
        assert stamp.sec * 1_000_000_000 + stamp.nanosec == round(25 * DT * 1e9)
        assert node.latest_pose("box").header.frame_id == "world"


def test_textbook_acceleration_from_rest(resting_box):
    """First tick from rest: Δv = (F/m)·dt = (0, 0.05, 0) m/s and I_z·Δω_z = τ·dt = 0.05 N·m·s."""
    with SimHarness(resting_box, parameters={"integrator": "semi_implicit_euler"}) as node:
        node.publish_wrench("box", force=(0.0, 10.0, 0.0), frame_id="box/corner")
        node.step()
        _, _, v, w = pose_arrays(node, "box")
        I_z = 2.0 * (1.0**2 + 0.6**2) / 12.0
        np.testing.assert_allclose(v, [0.0, 0.05, 0.0], atol=1e-15)
        np.testing.assert_allclose(w * I_z, [0.0, 0.0, 0.05], atol=1e-15)


@pytest.mark.parametrize("frame_id", ["world", "box", "box/world_aligned", "box/corner", "box/nozzle"])
def test_each_frame_of_the_rule_matches_core(resting_box, frame_id):
    """A wrench held in each frame gives exactly what the core gives for that frame (bitwise)."""
    force, torque = (1.0, -2.0, 3.0), (0.3, 0.2, -0.1)
    core = Simulator(load_scene(resting_box), integrator="rk4", dt=DT)
    core.set_body_state("box", angular_velocity_world=[0.5, -0.4, 1.0], linear_velocity_world=[0.2, 0.0, 0.0])
    with SimHarness(resting_box, parameters={"integrator": "rk4", "wrench_timeout": 0.0}) as node:
        node.node.simulator.set_body_state("box", angular_velocity_world=[0.5, -0.4, 1.0],
                                           linear_velocity_world=[0.2, 0.0, 0.0])
        node.publish_wrench("box", force=force, torque=torque, frame_id=frame_id)
        node.step(20)
        for _ in range(20):
            core.apply_wrench("box", force, torque, frame_id)
            core.step()
        assert_same_motion(pose_arrays(node, "box"), core_arrays(core, "box"))


def test_same_physical_wrench_in_every_frame_of_a_group_gives_same_tick(resting_box):
    """One tick: F at the corner named in frames that hold the same load through the tick.

    A wrench is kept in its frame and evaluated at every stage of a step, so frames agree
    bitwise-close (1e-12) only within a group that moves the load the same way: the box and its
    corner are both fixed in the box. A force in world axes (``box/world_aligned``, ``world``)
    does not turn with the box: the body-fixed force turns by θ = α t²/2 (α = τ/I_z), so the
    velocities part by (F/m) ∫ sin θ ≈ (F/m) α h³/6 = 1.84e-5 m/s over one tick (h = 0.01 s),
    the positions by (F/m) α h⁴/24, the rates not at all (the torque about the COM is the same
    to O(h²) of the COM's travel). Bound: 1.1 × that figure.
    """
    F_B = np.array([0.0, 10.0, 0.0])
    r_B = np.array([0.5, 0.3, 0.0])
    p = np.array([0.0, 0.0, 1.0])  # resting box: COM at (0, 0, 1), identity orientation
    representations = {
        "box/corner": (F_B, np.zeros(3)),
        "box": (F_B, np.cross(r_B, F_B)),
        "box/world_aligned": (F_B, np.cross(r_B, F_B)),  # identity orientation: axes coincide
        "world": (F_B, np.cross(p + r_B, F_B)),
    }
    results = {}
    for frame_id, (force, torque) in representations.items():
        with SimHarness(resting_box, parameters={"integrator": "rk4"}) as node:
            node.publish_wrench("box", force=force, torque=torque, frame_id=frame_id)
            node.step()
            results[frame_id] = pose_arrays(node, "box")
    assert_same_motion(results["box"], results["box/corner"], atol=1e-12)
    alpha = 5.0 / (2.0 * (1.0 + 0.36) / 12.0)  # τ_z = (r × F)_z = 0.5 · 10 N·m over I_z
    part = 1.1 * (10.0 / 2.0) * alpha * DT**3 / 6.0
    for frame_id in ("box/world_aligned", "world"):
        assert_same_motion(results[frame_id], results["box/corner"], atol=part)
    # ...and the world-axes frames really do part from the body-fixed one (not held alike).
    moved = [np.max(np.abs(a - b)) for a, b in zip(results["world"], results["box/corner"])]
    assert max(moved) > 1e-12, moved


def test_seed_box_through_the_node_matches_the_closed_form_to_1e_6(tmp_path):
    """A force fixed in the body, through ROS: the 2 kg box pushed by 10 N along its own y at box/corner by one
    WrenchStamped held (wrench_timeout 0), rk4, rate 100 Hz × 10 substeps (h = 1e-3), stepped
    100 ticks with ~/step while paused: pose, orientation and twist within 1e-6 of the Fresnel
    closed form after 1 s (rk4's own error at h = 1e-3 is ~1e-11; the seed missed by 2.2e-3)."""
    scene = {"bodies": {"box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]},
                                "sites": {"corner": {"position": [0.5, 0.3, 0.0]}}}}}
    path = tmp_path / "seed_box.yaml"
    path.write_text(yaml.safe_dump(scene))
    I_z = 2.0 * (1.0 + 0.36) / 12.0
    q_ref, w_B_ref, v_ref, p_ref = closed_form.box_body_fixed_force(
        2.0, I_z, [0.0, 10.0, 0.0], [0.5, 0.3, 0.0], np.array([1.0]))
    with SimHarness(path, parameters={"integrator": "rk4", "rate_hz": 100.0, "substeps": 10,
                                       "wrench_timeout": 0.0}) as node:
        node.publish_wrench("box", force=(0.0, 10.0, 0.0), frame_id="box/corner")
        node.step(100)
        p, q_xyzw, v, w_W = pose_arrays(node, "box")
    assert np.linalg.norm(p - p_ref[0]) < 1e-6
    assert np.linalg.norm(v - v_ref[0]) < 1e-6
    q_ref_xyzw = q_ref[0][[1, 2, 3, 0]]  # closed form: (w, x, y, z)
    assert min(np.linalg.norm(q_xyzw - q_ref_xyzw), np.linalg.norm(q_xyzw + q_ref_xyzw)) < 1e-6
    # A planar spin about z: the world and body rates are the same vector.
    assert np.linalg.norm(w_W - w_B_ref[0]) < 1e-6


def test_hold_timeout_replace_sum_and_clear(resting_box):
    """Forces through the COM on a box at rest: v after k ticks is Σ(F/m)·dt over the ticks each was held."""
    with SimHarness(resting_box, parameters={"integrator": "semi_implicit_euler", "wrench_timeout": 0.05}) as node:
        # Held for exactly 5 ticks (0.05 s of sim time), then it times out.
        node.publish_wrench("box", force=(2.0, 0.0, 0.0), frame_id="box/world_aligned")
        node.step(8)
        np.testing.assert_allclose(pose_arrays(node, "box")[2], [(2.0 / 2.0) * 0.05, 0.0, 0.0], atol=1e-14)
        assert node.node.held_wrenches == {}

        # Sum of two holds in different frames; replacing one in the same frame does not add.
        node.set_parameters(wrench_timeout=0.0)
        node.publish_wrench("box", force=(0.0, 4.0, 0.0), frame_id="world")
        node.publish_wrench("box", force=(0.0, 0.0, 6.0), frame_id="box/world_aligned")
        node.publish_wrench("box", force=(0.0, 0.0, 2.0), frame_id="box/world_aligned")  # replaces 6 N
        assert len(node.node.held_wrenches) == 2
        node.step(10)
        v = pose_arrays(node, "box")[2]
        np.testing.assert_allclose(v, [0.05, (4.0 / 2.0) * 0.1, (2.0 / 2.0) * 0.1], atol=1e-14)

        # An all-zero wrench clears its hold: that component stops growing.
        node.publish_wrench("box", force=(0.0, 0.0, 0.0), frame_id="world")
        node.step(10)
        v = pose_arrays(node, "box")[2]
        np.testing.assert_allclose(v, [0.05, 0.2, 0.2], atol=1e-14)
        assert list(node.node.held_wrenches) == [("box", "box/world_aligned")]


def test_impulse_applied_once_at_next_step(resting_box):
    """Δv = J/m and Δω = I⁻¹·H, once; the body then coasts (torque-free about a principal axis)."""
    I_z = 2.0 * (1.0**2 + 0.6**2) / 12.0
    with SimHarness(resting_box, parameters={"integrator": "rk4"}) as node:
        node.publish_impulse("box", linear=(1.0, 0.0, 0.0), angular=(0.0, 0.0, 0.5), frame_id="box")
        node.step(3)
        p, q, v, w = pose_arrays(node, "box")
        np.testing.assert_allclose(v, [0.5, 0.0, 0.0], atol=1e-15)
        np.testing.assert_allclose(w, [0.0, 0.0, 0.5 / I_z], atol=1e-15)
        # Free translation and steady spin about a principal axis: exact to round-off.
        np.testing.assert_allclose(p, [0.5 * 3 * DT, 0.0, 1.0], atol=1e-14)
        angle = 0.5 / I_z * 3 * DT
        np.testing.assert_allclose(q, [0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2)], atol=1e-14)


def test_reset_pause_and_step():
    with SimHarness(paused=True) as node:
        start = pose_arrays(node, "box")
        node.step(5)
        assert not np.array_equal(pose_arrays(node, "box")[1], start[1])
        response = node.reset()
        assert response.success
        assert_same_motion(pose_arrays(node, "box"), start)
        assert node.node.simulator.time == 0.0

        assert node.set_paused(False).success
        assert node.get_parameter("paused") is False
        refused = node.call_step()
        assert not refused.success and "running" in refused.message
        node.spin_for(0.3)  # the node's own timer advances time while running
        assert node.node.simulator.time > 0.0
        assert node.set_paused(True).success
        assert node.get_parameter("paused") is True
        frozen = node.node.simulator.time
        node.spin_for(0.2)
        assert node.node.simulator.time == frozen
        assert node.call_step().success
        assert node.node.simulator.time == pytest.approx(frozen + DT, abs=1e-12)


# A refused parameter change (alone or with valid ones, at every place it can be refused) changes no
# parameter, no state and no dt: test_parameter_abuse.py; each ranged parameter's refusal: test_parameters.py.


def test_runtime_parameter_changes_take_effect_next_tick():
    with SimHarness() as node:
        results = node.set_parameters(integrator="splitting", substeps=4, rate_hz=50, real_time_factor=2.0)
        assert all(r.successful for r in results), results
        assert node.node.simulator.integrator == "splitting"
        assert node.node.simulator.dt == pytest.approx(2.0 / (50.0 * 4))
        assert node.get_parameter("rate_hz") == 50.0  # a whole number is taken as a float
        node.step()
        assert node.node.simulator.step_count == 4
        assert node.node.simulator.time == pytest.approx(2.0 / 50.0)


def test_bad_wrenches_dropped_and_counted(resting_box):
    """Bad messages are counted by reason and leave the motion exactly as without them."""
    bad = [
        ({"force": (math.nan, 0.0, 0.0)}, "box", "non_finite"),
        ({"torque": (0.0, math.inf, 0.0)}, "box", "non_finite"),
        ({"force": (0.0, -math.inf, 0.0)}, "world", "non_finite"),
        ({"force": (2e12, 0.0, 0.0)}, "box", "too_large"),
        ({"force": (1.0, 0.0, 0.0)}, "", "unknown_frame"),
        ({"force": (1.0, 0.0, 0.0)}, "map", "unknown_frame"),
        ({"force": (1.0, 0.0, 0.0)}, "box/wheel", "unknown_frame"),
        ({"force": (1.0, 0.0, 0.0)}, "box/world_aligned/extra", "unknown_frame"),
    ]
    with SimHarness(resting_box, parameters={"wrench_timeout": 0.0}) as clean:
        clean.publish_wrench("box", force=(0.0, 1.0, 0.0), frame_id="box/corner")
        clean.step(5)
        expected = pose_arrays(clean, "box")
    with SimHarness(resting_box, parameters={"wrench_timeout": 0.0}) as node:
        node.publish_wrench("box", force=(0.0, 1.0, 0.0), frame_id="box/corner")
        for kwargs, frame_id, _reason in bad:
            node.publish_wrench("box", frame_id=frame_id, **kwargs)
            node.publish_impulse("box", linear=kwargs.get("force", (0, 0, 0)), angular=kwargs.get("torque", (0, 0, 0)),
                                 frame_id=frame_id)
        node.step(5)
        assert_same_motion(pose_arrays(node, "box"), expected)
        expected_counts = {}
        for _kwargs, _frame, reason in bad:
            expected_counts[reason] = expected_counts.get(reason, 0) + 2  # the wrench and the impulse
        assert dict(node.node.rejected) == expected_counts
        assert node.node.accepted_messages == 1


def test_odometry_twist_is_in_body_axes(resting_box):
    """nav_msgs/Odometry: pose in the world frame, twist in the body frame, child_frame_id = body."""
    with SimHarness(resting_box, parameters={"publish_odometry": True}) as node:
        node.publish_impulse("box", linear=(0.0, 2.0, 0.0), angular=(0.0, 0.0, 0.4), frame_id="box/world_aligned")
        node.step(30)
        odom = node.latest_odometry("box")
        assert odom.header.frame_id == "world" and odom.child_frame_id == "box"
        state = node.node.simulator.body_state("box")
        twist = odom.twist.twist
        np.testing.assert_allclose([twist.linear.x, twist.linear.y, twist.linear.z], state.linear_velocity_body, atol=1e-15)
        np.testing.assert_allclose([twist.angular.x, twist.angular.y, twist.angular.z], state.angular_velocity_body, atol=1e-15)
        # The box turned (ω_z t ≈ 0.4/I_z·0.3 rad), so body and world velocity differ.
        assert abs(twist.linear.x) > 1e-3
        np.testing.assert_allclose(np.linalg.norm([twist.linear.x, twist.linear.y, twist.linear.z]), 1.0, rtol=1e-12)
        pose = odom.pose.pose
        np.testing.assert_allclose([pose.position.x, pose.position.y, pose.position.z], state.position_world, atol=0)


def test_clock_carries_sim_time():
    from rosgraph_msgs.msg import Clock

    with SimHarness() as node:
        stamps = []
        node.client.create_subscription(Clock, "/clock", lambda m: stamps.append(m.clock.sec * 10**9 + m.clock.nanosec), 10)
        node.spin_until(lambda: node.node.count_subscribers("/clock") > 0, "the /clock subscription")
        node.step(3)
        node.spin_until(lambda: stamps and stamps[-1] == round(3 * DT * 1e9), "/clock at 3 ticks")


def test_non_finite_body_is_stopped_and_never_published(tmp_path):
    """A body driven to an infinite velocity is stopped and no longer published; the other runs on."""
    scene = {
        "bodies": {
            "feather": {"mass": 1e-300, "inertia": {"sphere": 1.0}},
            "box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}},
        }
    }
    path = tmp_path / "two.yaml"
    path.write_text(yaml.safe_dump(scene))
    with SimHarness(path, parameters={"integrator": "euler", "wrench_timeout": 0.0}) as node:
        node.publish_wrench("feather", force=(1e12, 0.0, 0.0), frame_id="world")
        node.publish_wrench("box", force=(2.0, 0.0, 0.0), frame_id="world")
        last_feather = node.latest_pose("feather")
        node.step(4)
        assert node.node.simulator.stopped_bodies == ("feather",)
        assert node.latest_pose("feather") is last_feather  # nothing new was published for it
        for value in pose_arrays(node, "box"):
            assert np.all(np.isfinite(value))
        np.testing.assert_allclose(pose_arrays(node, "box")[2], [1.0 * 4 * DT, 0.0, 0.0], atol=1e-14)


def test_harness_tears_down_after_a_failing_test():
    with pytest.raises(ZeroDivisionError):
        with SimHarness() as node:
            context = node.context
            1 / 0
    assert not context.ok()
    with SimHarness() as again:  # a fresh harness starts cleanly afterwards
        again.step()


def test_model_reduction_parameter_switches_the_models_and_keeps_the_motion(tmp_path):
    """A sphere gets the exact isotropic model; model_reduction:=false puts it on the integrator; the
    published pose is the core's either way (bitwise)."""
    scene = tmp_path / "ball.yaml"
    scene.write_text(yaml.safe_dump({"bodies": {
        "ball": {"mass": 1.0, "inertia": {"sphere": 0.1}, "twist": {"angular": [1.0, 2.0, 3.0]}},
        "wall": {"mass": 1.0, "inertia": {"box": [1, 1, 1]}, "motion": "static"}}}))
    with SimHarness(scene) as node:
        sim = node.node.simulator
        assert {p.body: p.model for p in sim.body_models()} == {"ball": "isotropic", "wall": "static"}
        node.step(10)
        core = Simulator(load_scene(scene), integrator="rk4", dt=DT)
        core.step(10)
        np.testing.assert_array_equal(pose_arrays(node, "ball")[1], core_arrays(core, "ball")[1])
        results = node.set_parameters(model_reduction=False)
        assert all(r.successful for r in results), results
        assert {p.body: p.model for p in sim.body_models()} == {"ball": "full", "wall": "full"}
        assert not node.get_parameter("model_reduction")
        rejected = node.set_parameters(model_reduction="yes")
        assert not rejected[0].successful and not node.get_parameter("model_reduction")
