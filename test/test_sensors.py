"""Ideal IMU readings at sites (core/sensors.py) against closed forms, and carrying a simulation into a new scene.

The specific force at a site r of a rigid body is a_C + ω̇ × r + ω × (ω × r) − g (REP-145: zero
in free fall, +g upward at rest), in the site's axes. The closed forms below are worked out by
hand for bodies whose motion is known exactly.
"""

from __future__ import annotations

import numpy as np
import pytest

from helpers import scene_of
from rigid_body_sim.core import Simulator
from rigid_body_sim.core.quaternion import quat_to_matrix, quat_wxyz_from_xyzw

G = np.array([0.0, 0.0, -9.81])  # m/s²


def _box(motion: str = "free", angular=(0.0, 0.0, 0.0), linear=(0.0, 0.0, 0.0)) -> dict:
    return {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}, "motion": motion,
            "twist": {"linear": list(linear), "angular": list(angular)},
            "sites": {"centre": {"position": [0.0, 0.0, 0.0]}, "arm": {"position": [1.0, 0.0, 0.0]},
                      "arm_world": {"position": [1.0, 0.0, 0.0], "axes": "world"},
                      "corner": {"position": [0.5, 0.3, 0.0]}}}


def test_spinning_body_pushed_by_a_body_fixed_force_in_free_fall() -> None:
    """Spin about the principal z axis, a body-fixed force at the COM, gravity: no torque, ω constant.

    In body axes the centre reads F_B/m (gravity cancels in free fall) and the arm, 1 m off
    centre, adds the centripetal −ω² r; both gyroscopes read ω.
    """
    w_z, force_B = 3.0, np.array([1.0, -2.0, 0.5])
    sim = Simulator(scene_of({"b": _box(angular=(0.0, 0.0, w_z))}, gravity=G), "rk4", 1e-3)
    for _ in range(700):
        sim.apply_wrench("b", force=force_B, frame="b")
        sim.step()
    r = sim.site_readings(["b/centre", "b/arm"])
    np.testing.assert_allclose(r.specific_force[0], force_B / 2.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.specific_force[1], force_B / 2.0 + np.array([-w_z**2, 0.0, 0.0]), rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.angular_velocity, [[0.0, 0.0, w_z]] * 2, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.orientation_xyzw, [sim.body_state("b").orientation_xyzw] * 2, rtol=0, atol=1e-15)


def test_torque_from_a_body_fixed_force_adds_the_tangential_term() -> None:
    """The seed's box pushed at its corner from rest: ω = α t about z, ω̇ = α; at the arm (1, 0, 0),
    body axes: F/m + α e_z × r − (α t)² r, with F = (0, 10, 0) N and α = 5 N·m / I_z."""
    sim = Simulator(scene_of({"b": _box()}, gravity=G), "rk4", 1e-3)
    for _ in range(500):
        sim.apply_force_at_point("b", [0.0, 10.0, 0.0], [0.0, 0.0, 0.0], frame="b/corner")
        sim.step()
    alpha, t = 5.0 / (2.0 * (1.0 + 0.36) / 12.0), 0.5
    expected = np.array([0.0, 5.0, 0.0]) + alpha * np.array([0.0, 1.0, 0.0]) - (alpha * t) ** 2 * np.array([1.0, 0, 0])
    r = sim.site_readings(["b/arm"])
    np.testing.assert_allclose(r.specific_force[0], expected, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.angular_velocity[0], [0.0, 0.0, alpha * t], rtol=0, atol=1e-9)


def test_world_axes_site_reads_in_world_axes() -> None:
    w_z = 2.0
    sim = Simulator(scene_of({"b": _box(angular=(0.0, 0.0, w_z))}, gravity=G), "rk4", 1e-3)
    sim.step(300)
    R = quat_to_matrix(quat_wxyz_from_xyzw(sim.body_state("b").orientation_xyzw))
    r = sim.site_readings(["b/arm_world"])
    np.testing.assert_allclose(r.specific_force[0], -w_z**2 * (R @ [1.0, 0.0, 0.0]), rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.angular_velocity[0], [0.0, 0.0, w_z], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r.orientation_xyzw[0], [0.0, 0.0, 0.0, 1.0])


@pytest.mark.parametrize("motion", ["static", "kinematic"])
def test_imu_on_a_body_that_cannot_fall_reads_g_upward(motion: str) -> None:
    """No model acceleration: the accelerometer feels the support, +g upward (plus the centripetal
    term of a kinematic body's constant spin at an off-centre site)."""
    w_z = 0.0 if motion == "static" else 1.5
    sim = Simulator(scene_of({"b": _box(motion, angular=(0.0, 0.0, w_z))}, gravity=G), "rk4", 1e-3)
    sim.apply_wrench("b", force=[5.0, 0.0, 0.0], frame="b")  # deaf to wrenches
    sim.step(200)
    R = quat_to_matrix(quat_wxyz_from_xyzw(sim.body_state("b").orientation_xyzw))
    r = sim.site_readings(["b/centre", "b/arm"])
    np.testing.assert_allclose(R @ r.specific_force[0], -G, rtol=0, atol=1e-12)
    np.testing.assert_allclose(R @ r.specific_force[1], -G - w_z**2 * (R @ [1.0, 0.0, 0.0]), rtol=0, atol=1e-12)


def test_unknown_site_lists_the_sites() -> None:
    sim = Simulator(scene_of({"b": _box()}), "rk4", 1e-3)
    with pytest.raises(ValueError, match=r"unknown site\(s\) \['b/nose'\]; sites are \['b/centre'"):
        sim.site_readings(["b/nose"])


# ----------------------------------------------------------------------------- a new scene, the same run


def test_with_scene_keeps_time_and_every_kept_body_and_adds_the_new_one_at_its_initial_state() -> None:
    a = {"mass": 1.0, "inertia": {"principal": [1.0, 2.0, 3.0]}, "twist": {"angular": [0.4, 1.0, 0.3]}}
    b = {"mass": 2.0, "inertia": {"sphere": 0.2}, "twist": {"linear": [1.0, 0.0, 0.0]}}
    sim = Simulator(scene_of({"a": a, "b": b}), "rk4", 0.01)
    sim.step(37)
    before = sim.body_state("a")
    c = {"mass": 1.0, "inertia": {"sphere": 0.1}, "pose": {"position": [0.0, 5.0, 0.0]}}
    moved = sim.with_scene(scene_of({"a": a, "c": c}))  # b deleted, c spawned
    assert moved.time == sim.time and moved.step_count == 37
    assert moved.body_names == ("a", "c")
    after = moved.body_state("a")
    for field in ("position_world", "orientation_xyzw", "linear_velocity_world", "angular_velocity_world"):
        np.testing.assert_allclose(getattr(after, field), getattr(before, field), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(moved.body_state("c").position_world, [0.0, 5.0, 0.0])
    sim.step(5)
    moved.step(5)
    assert moved.time == sim.time
    np.testing.assert_allclose(moved.body_state("a").orientation_xyzw, sim.body_state("a").orientation_xyzw,
                               rtol=0, atol=1e-14)
