"""Model reduction: each reduced model against a closed form or the full model, constraints
that hold under arbitrary wrenches, the switch mid-run, the scene's ``motion`` key, and describe.

Quaternions are (w, x, y, z) unless a name says ``_xyzw``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from rigid_body_sim.core import SceneError, Simulator, describe_scene, load_scene
from rigid_body_sim.exact.closed_form import symmetric_top_flow
from rigid_body_sim.core.quaternion import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    quat_rotate,
    quat_wxyz_from_xyzw,
)

from helpers import COMPILED_INTEGRATORS as COMPILED
from helpers import EPS, FIXED_STEP_INTEGRATORS


def body(inertia: dict, *, mass: float = 2.0, position=(0.0, 0.0, 0.0), orientation_xyzw=(0.0, 0.0, 0.0, 1.0),
         linear=(0.0, 0.0, 0.0), angular=(0.0, 0.0, 0.0), motion: Any = None, damping: dict | None = None) -> dict:
    spec: dict[str, Any] = {"mass": mass, "inertia": inertia,
                            "pose": {"position": list(position), "orientation": list(orientation_xyzw)},
                            "twist": {"linear": list(linear), "angular": list(angular)}}
    if motion is not None:
        spec["motion"] = motion
    if damping is not None:
        spec["damping"] = damping
    return spec


def models(sim: Simulator) -> dict[str, str]:
    return {plan.body: plan.model for plan in sim.body_models()}


def q_xyzw_to_wxyz(q_xyzw: np.ndarray) -> np.ndarray:
    return quat_wxyz_from_xyzw(np.asarray(q_xyzw))


def same_rotation(q1: np.ndarray, q2: np.ndarray) -> float:
    """Geodesic angle between two unit quaternions (rad)."""
    d = quat_multiply(quat_conjugate(q1), q2)
    return 2.0 * math.atan2(float(np.linalg.norm(d[1:])), abs(float(d[0])))


# --------------------------------------------------------------------------- exact against closed forms


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_torque_free_sphere_is_exact_whatever_the_integrator(integrator: str) -> None:
    """Exact translation under a constant force and an exact exp-map rotation: closed forms to round-off."""
    p0, v0, w0 = np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -0.2]), np.array([3.0, -7.0, 11.0])
    q0_xyzw = np.array([0.2, -0.3, 0.4, 0.8]) / np.linalg.norm([0.2, -0.3, 0.4, 0.8])
    scene = load_scene({"bodies": {"ball": body({"sphere": 0.3}, position=p0, orientation_xyzw=q0_xyzw,
                                                linear=v0, angular=w0)}})
    sim = Simulator(scene, integrator=integrator, dt=0.01)
    assert models(sim) == {"ball": "isotropic"}
    force = np.array([0.5, -1.0, 2.0])
    steps = 2000
    for _ in range(steps):
        sim.apply_wrench("ball", force=force, frame="ball/world_aligned")
        sim.step()
    t = steps * 0.01
    a = force / 2.0
    s = sim.body_state("ball")
    # round-off of 2000 additions: ~steps·EPS relative
    expected_p = p0 + v0 * t + 0.5 * a * t * t
    np.testing.assert_allclose(s.position_world, expected_p, rtol=0, atol=steps * EPS * np.abs(expected_p).max())
    np.testing.assert_allclose(s.linear_velocity_world, v0 + a * t, rtol=0, atol=steps * EPS * 10)
    np.testing.assert_allclose(s.angular_velocity_world, w0, rtol=0, atol=1e-14 * np.abs(w0).max())
    expected = quat_multiply(quat_from_rotation_vector(w0 * t), q_xyzw_to_wxyz(q0_xyzw))
    assert same_rotation(q_xyzw_to_wxyz(s.orientation_xyzw), expected) < 1e-11


def test_isotropic_body_with_angular_damping_follows_the_exponential_decay() -> None:
    w0, c, I = np.array([0.0, 0.0, 5.0]), 0.05, 0.4 * 2.0 * 0.3 ** 2
    scene = load_scene({"bodies": {"ball": body({"sphere": 0.3}, angular=w0, damping={"angular": c})}})
    sim = Simulator(scene, integrator="rk4", dt=0.01)
    sim.step(1000)
    t, k = 10.0, c / I
    s = sim.body_state("ball")
    np.testing.assert_allclose(s.angular_velocity_world, w0 * math.exp(-k * t), rtol=1e-12)
    angle = 5.0 * (1.0 - math.exp(-k * t)) / k
    expected = quat_from_rotation_vector(np.array([0.0, 0.0, angle]))
    assert same_rotation(q_xyzw_to_wxyz(s.orientation_xyzw), expected) < 1e-11


@pytest.mark.parametrize("integrator", COMPILED)
def test_torque_free_axisymmetric_body_follows_the_symmetric_top_closed_form(integrator: str) -> None:
    """A cylinder (I1 = I2 ≠ I3): the exact symmetric-top flow, at a step where every integrator errs."""
    w0_W = np.array([0.7, -0.4, 9.0])
    scene = load_scene({"bodies": {"can": body({"cylinder": [0.1, 0.5]}, angular=w0_W)}})
    sim = Simulator(scene, integrator=integrator, dt=0.05)
    assert models(sim) == {"can": "symmetric"}
    sim.step(400)
    I = scene.model.inertia_P[0]
    L0 = I * scene.initial_state.w_WP_P[0]
    q_ref, _L = symmetric_top_flow(scene.initial_state.q_WP[0], L0, 1.0 / I[0], np.array([0.0, 0.0, 1.0]),
                                   1.0 / I[2] - 1.0 / I[0], np.array(20.0))
    assert same_rotation(sim.state.q_WP[0], q_ref) < 1e-11
    np.testing.assert_allclose(sim.angular_momentum()[0], quat_rotate(scene.initial_state.q_WP[0], L0), atol=1e-13)


def test_kinematic_body_moves_at_its_constant_twist_whatever_the_wrench() -> None:
    v0, w0 = np.array([1.0, 0.5, -0.25]), np.array([0.3, 1.0, 0.2])
    scene = load_scene({"gravity": [0, 0, -9.81],
                        "bodies": {"conveyor": body({"box": [1.0, 0.6, 0.4]}, linear=v0, angular=w0,
                                                    motion="kinematic")}})
    sim = Simulator(scene, integrator="rk4", dt=0.01)
    assert models(sim) == {"conveyor": "kinematic"}
    rng = np.random.default_rng(3)
    for _ in range(1000):
        sim.apply_wrench("conveyor", force=rng.normal(size=3) * 100, torque=rng.normal(size=3) * 10,
                         frame="conveyor")
        sim.step()
    sim.apply_impulse("conveyor", linear=[5.0, 0.0, 0.0], angular=[0.0, 1.0, 0.0])
    s = sim.body_state("conveyor")
    np.testing.assert_allclose(s.position_world, v0 * 10.0, rtol=1e-13)
    np.testing.assert_allclose(s.linear_velocity_world, v0, rtol=0, atol=0)
    np.testing.assert_allclose(s.angular_velocity_world, w0, atol=1e-14)
    assert same_rotation(q_xyzw_to_wxyz(s.orientation_xyzw), quat_from_rotation_vector(w0 * 10.0)) < 1e-12


def test_translation_only_body_keeps_its_orientation_and_follows_the_constant_force_closed_form() -> None:
    q0_xyzw = np.array([0.0, 0.0, math.sin(0.3), math.cos(0.3)])
    scene = load_scene({"gravity": [0, 0, -9.81],
                        "bodies": {"puck": body({"box": [1.0, 0.6, 0.4]}, orientation_xyzw=q0_xyzw,
                                                linear=[1.0, 0.0, 2.0], motion="translation_only")}})
    sim = Simulator(scene, integrator="rk4", dt=0.01)
    assert models(sim) == {"puck": "translation"}
    for _ in range(500):
        sim.apply_force_at_point("puck", force=[0.0, 4.0, 0.0], point=[0.5, 0.3, 0.0], frame="puck")
        sim.step()
    t = 5.0
    s = sim.body_state("puck")
    force_W = quat_rotate(q_xyzw_to_wxyz(q0_xyzw), np.array([0.0, 4.0, 0.0]))
    a = force_W / 2.0 + np.array([0.0, 0.0, -9.81])
    np.testing.assert_allclose(s.position_world, np.array([1.0, 0.0, 2.0]) * t + 0.5 * a * t * t, atol=1e-11)
    np.testing.assert_array_equal(s.orientation_xyzw, sim.orientations_xyzw()[0])
    np.testing.assert_array_equal(sim.state.q_WP[0], scene.initial_state.q_WP[0])
    np.testing.assert_array_equal(s.angular_velocity_world, np.zeros(3))


def test_planar_body_under_in_plane_force_and_yaw_torque_follows_the_closed_form() -> None:
    """Force in the plane, torque along its normal: p = p0 + v0 t + ½ a t², yaw = ω0 t + ½ α t²."""
    scene = load_scene({"gravity": [0, 0, -9.81],
                        "bodies": {"puck": body({"box": [1.0, 0.6, 0.4]}, position=[0, 0, 0.2],
                                                linear=[0.5, 0.0, 0.0], angular=[0.0, 0.0, 2.0],
                                                motion="planar")}})
    sim = Simulator(scene, integrator="semi_implicit_euler", dt=0.01)
    assert models(sim) == {"puck": "planar"}
    for _ in range(300):
        sim.apply_wrench("puck", force=[1.0, 2.0, 50.0], torque=[3.0, -4.0, 0.5], frame="puck/world_aligned")
        sim.step()
    t, I_zz = 3.0, scene.model.inertia_P[0][2]
    s = sim.body_state("puck")
    np.testing.assert_allclose(s.position_world, [0.5 * t + 0.25 * t * t, 0.5 * t * t, 0.2], atol=1e-12)
    yaw = 2.0 * t + 0.5 * (0.5 / I_zz) * t * t
    assert same_rotation(q_xyzw_to_wxyz(s.orientation_xyzw), quat_from_rotation_vector(np.array([0, 0, yaw]))) < 1e-11
    np.testing.assert_allclose(s.angular_velocity_world, [0.0, 0.0, 2.0 + 0.5 / I_zz * t], atol=1e-11)


def _planar_reference(I_W: np.ndarray, n: np.ndarray, mass: float, p0, v0, w_n0: float, q0_wxyz: np.ndarray,
                      force_B: np.ndarray, site_B: np.ndarray, t_end: float) -> tuple[np.ndarray, float]:
    """(position, yaw rate) of a planar body pushed by a body-fixed force at a body point: DOP853 on the
    planar equations written out here (m v̇ = P F_W, I_n ω̇_n = n·(r_W × F_W), the body turning about n)."""
    from scipy.integrate import solve_ivp
    from scipy.spatial.transform import Rotation

    R0 = Rotation.from_quat(q0_wxyz, scalar_first=True)
    I_n = float(n @ I_W @ n)

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        R = Rotation.from_rotvec(y[6] * n) * R0
        F_W, r_W = R.apply(force_B), R.apply(site_B)
        F_in_plane = F_W - (F_W @ n) * n
        return np.concatenate((y[3:6], F_in_plane / mass, [y[7], n @ np.cross(r_W, F_W) / I_n]))

    y0 = np.concatenate((p0, v0, [0.0, w_n0]))
    end = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]
    return end[0:3], end[7]


@pytest.mark.parametrize("integrator", ["euler", "rk4", "exact_rotor_splitting"])
def test_planar_body_under_a_body_fixed_force_is_fourth_order_whatever_the_integrator(integrator: str) -> None:
    """A thruster fixed on a tilted-plane puck turns with its yaw: RK4 on the planar equations, forces per stage."""
    n = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    q0_xyzw = np.array([0.1, 0.2, -0.3, 0.9]) / np.linalg.norm([0.1, 0.2, -0.3, 0.9])
    p0, v0 = np.array([1.0, 2.0, 3.0]), np.array([0.4, 0.1, 0.0])
    v0 -= (v0 @ n) * n
    site_B, force_B = np.array([0.5, 0.3, 0.1]), np.array([0.0, 10.0, 2.0])
    spec = {**body({"box": [1.0, 0.6, 0.4]}, position=p0, orientation_xyzw=q0_xyzw, linear=v0.tolist(),
                   angular=(0.7 * n).tolist()),
            "sites": {"thruster": {"position": site_B.tolist()}}, "motion": {"kind": "planar", "normal": n.tolist()}}
    scene = load_scene({"bodies": {"puck": spec}})
    q0 = q_xyzw_to_wxyz(q0_xyzw)
    from rigid_body_sim.core.quaternion import quat_to_matrix
    R_WB = quat_to_matrix(q0)
    I_B = np.diag(np.asarray(scene.model.inertia_P[0]))  # a box: principal = body axes
    I_W = R_WB @ I_B @ R_WB.T
    p_ref, w_ref = _planar_reference(I_W, n, 2.0, p0, v0, 0.7, q0, force_B, site_B, 1.0)
    errors = []
    steps = (0.1, 0.05, 0.025)
    for h in steps:
        sim = Simulator(scene, integrator=integrator, dt=h)
        sim.apply_wrench("puck", force=force_B, frame="puck/thruster")
        sim.step(int(round(1.0 / h)))
        s = sim.body_state("puck")
        errors.append(max(np.linalg.norm(s.position_world - p_ref), abs(s.angular_velocity_world @ n - w_ref)))
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert abs(slope - 4.0) <= 0.2, (errors, slope)


def test_planar_impulse_about_a_non_principal_normal_spins_by_the_moment_about_that_normal() -> None:
    """Δω = (H·n)/(nᵀ I_W n) n: the constraint keeps ω along n, so only the moment about n counts."""
    n = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)  # not a principal axis of the box
    scene = load_scene({"bodies": {"puck": {**body({"box": [1.0, 0.6, 0.4]}), "motion": {"kind": "planar",
                                                                                        "normal": n.tolist()}}}})
    sim = Simulator(scene, "rk4", 0.01)
    H = np.array([0.3, 0.7, -0.2])  # N·m·s, world axes, about the COM
    sim.apply_impulse("puck", angular=H, frame="puck/world_aligned")
    I_B = np.diag(np.asarray(scene.model.inertia_P[0]))
    expected = (H @ n) / (n @ I_B @ n) * n  # identity orientation: world = body axes
    np.testing.assert_allclose(sim.body_state("puck").angular_velocity_world, expected, rtol=0, atol=8 * EPS)
    energy = 0.5 * expected @ I_B @ expected
    np.testing.assert_allclose(sim.kinetic_energy()[0], energy, rtol=8 * EPS)


# --------------------------------------------------------------------------- constraints under arbitrary wrenches


def random_wrenches(sim: Simulator, name: str, rng: np.random.Generator, steps: int) -> None:
    frames = sim.frames_of(name)
    for _ in range(steps):
        frame = frames[rng.integers(len(frames))]
        sim.apply_wrench(name, force=rng.normal(size=3) * 20, torque=rng.normal(size=3) * 5, frame=frame)
        if rng.random() < 0.05:
            sim.apply_impulse(name, linear=rng.normal(size=3), angular=rng.normal(size=3) * 0.2, frame=frame)
        sim.step()


@pytest.mark.parametrize("normal", [[0, 0, 1], [1, 1, 0], [0.3, -0.5, 0.8]], ids=["z", "xy-diagonal", "tilted"])
@pytest.mark.parametrize("integrator", ["rk4", "exact_rotor_splitting"])
def test_planar_body_never_leaves_its_plane(normal: list[float], integrator: str) -> None:
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    p0 = np.array([1.0, 2.0, 3.0])
    q0_xyzw = np.array([0.1, 0.2, -0.3, 0.9]) / np.linalg.norm([0.1, 0.2, -0.3, 0.9])
    scene = load_scene({"gravity": [0, 0, -9.81], "bodies": {"puck": {
        **body({"box": [1.0, 0.6, 0.4]}, position=p0, orientation_xyzw=q0_xyzw, angular=(1.5 * n).tolist()),
        "sites": {"rim": {"position": [0.5, 0.0, 0.1]}, "jet": {"position": [0, 0.3, 0], "axes": "world"}},
        "motion": {"kind": "planar", "normal": normal}}}})
    sim = Simulator(scene, integrator=integrator, dt=0.01)
    rng = np.random.default_rng(11)
    for _ in range(10):
        random_wrenches(sim, "puck", rng, 50)
        s = sim.body_state("puck")
        assert abs((s.position_world - p0) @ n) <= 1e-12 * (1 + np.abs(s.position_world).max())
        assert abs(s.linear_velocity_world @ n) <= 1e-12 * (1 + np.abs(s.linear_velocity_world).max())
        w = s.angular_velocity_world
        assert np.linalg.norm(w - (w @ n) * n) <= 1e-12 * (1 + np.linalg.norm(w))
        turn = quat_multiply(q_xyzw_to_wxyz(s.orientation_xyzw), quat_conjugate(q_xyzw_to_wxyz(q0_xyzw)))
        assert np.linalg.norm(np.cross(turn[1:], n)) <= 1e-12, "the body turned about an axis other than the normal"


@pytest.mark.parametrize("integrator", ["rk4", "splitting", "exact_rotor_splitting", "reference"])
def test_rotation_only_body_keeps_its_centre_of_mass_exactly(integrator: str) -> None:
    p0 = np.array([0.5, -1.0, 2.0])
    scene = load_scene({"gravity": [0, 0, -9.81], "bodies": {"sat": {
        **body({"box": [1.0, 0.6, 0.4]}, position=p0, angular=[0.3, 1.0, 0.2], motion="rotation_only"),
        "sites": {"thruster": {"position": [0.5, 0.3, 0.0]}}}}})
    sim = Simulator(scene, integrator=integrator, dt=0.02)
    random_wrenches(sim, "sat", np.random.default_rng(5), 100 if integrator == "reference" else 400)
    s = sim.body_state("sat")
    np.testing.assert_array_equal(s.position_world, p0)
    np.testing.assert_array_equal(s.linear_velocity_world, np.zeros(3))
    assert np.linalg.norm(s.angular_velocity_world) > 0.1  # the torques did act


@pytest.mark.parametrize("integrator", ["rk4", "exact_rotor_splitting"])
def test_translation_only_body_never_turns(integrator: str) -> None:
    q0 = np.array([0.1, 0.2, -0.3, 0.9]) / np.linalg.norm([0.1, 0.2, -0.3, 0.9])
    scene = load_scene({"bodies": {"cart": {**body({"box": [1.0, 0.6, 0.4]}, orientation_xyzw=q0,
                                                   motion="translation_only"),
                                           "sites": {"hook": {"position": [0.5, 0.3, 0.0]}}}}})
    for reduce in (True, False):
        sim = Simulator(scene, integrator=integrator, dt=0.01, model_reduction=reduce)
        random_wrenches(sim, "cart", np.random.default_rng(7), 300)
        np.testing.assert_allclose(sim.state.q_WP[0], scene.initial_state.q_WP[0], rtol=0,
                                   atol=0 if reduce else 1e-13)
        np.testing.assert_array_equal(sim.state.w_WP_P[0], np.zeros(3))
        assert np.linalg.norm(sim.state.v_WC_W[0]) > 0.1


@pytest.mark.parametrize("integrator", ["rk4", "exact_rotor_splitting"])
def test_static_body_never_moves(integrator: str) -> None:
    scene = load_scene({"gravity": [0, 0, -9.81],
                        "bodies": {"wall": body({"box": [1.0, 0.6, 0.4]}, position=[1, 2, 3], motion="static"),
                                   "ball": body({"sphere": 0.1}, linear=[1.0, 0.0, 0.0])}})
    reduced = Simulator(scene, integrator=integrator, dt=0.01)
    full = Simulator(scene, integrator=integrator, dt=0.01, model_reduction=False)
    assert models(reduced) == {"wall": "static", "ball": "isotropic"}
    assert models(full) == {"wall": "full", "ball": "full"}
    before = reduced.state.copy()
    for sim in (reduced, full):
        random_wrenches(sim, "wall", np.random.default_rng(1), 200)
    for field in ("p_WC_W", "q_WP", "v_WC_W", "w_WP_P"):
        np.testing.assert_array_equal(getattr(reduced.state, field)[0], getattr(before, field)[0])
        np.testing.assert_allclose(getattr(full.state, field)[0], getattr(before, field)[0], rtol=0, atol=4 * EPS)


# --------------------------------------------------------------------------- the same numbers as the full model


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_reduced_body_under_torque_takes_the_integrators_step_and_switches_back(integrator: str) -> None:
    """Torque-free: exact; a torque arrives: the integrator's step, bit for bit; torque gone: exact again."""
    spec = body({"sphere": 0.3}, linear=[0.2, 0.0, 0.0], angular=[1.0, 2.0, -0.5])
    scene = load_scene({"bodies": {"ball": spec}})
    reduced = Simulator(scene, integrator=integrator, dt=0.02)
    full = Simulator(scene, integrator=integrator, dt=0.02, model_reduction=False)
    reduced.step(50)
    s = reduced.body_state("ball")
    np.testing.assert_allclose(s.angular_velocity_world, [1.0, 2.0, -0.5], atol=1e-14)  # exact so far
    full.state = reduced.state.copy()
    for _ in range(20):
        for sim in (reduced, full):
            sim.apply_wrench("ball", force=[0.0, 1.0, 0.0], torque=[0.3, 0.0, 0.1], frame="ball")
            sim.step()
        for field in ("p_WC_W", "q_WP", "v_WC_W", "w_WP_P"):
            np.testing.assert_array_equal(getattr(reduced.state, field), getattr(full.state, field))
    after_torque = reduced.body_state("ball")
    reduced.step(50)
    s = reduced.body_state("ball")
    w = after_torque.angular_velocity_world
    np.testing.assert_allclose(s.angular_velocity_world, w, atol=1e-13)  # constant again: exact
    expected = quat_multiply(quat_from_rotation_vector(w * 1.0), q_xyzw_to_wxyz(after_torque.orientation_xyzw))
    assert same_rotation(q_xyzw_to_wxyz(s.orientation_xyzw), expected) < 1e-12


@pytest.mark.parametrize("integrator", COMPILED + ("exact_rotor_splitting",))
def test_rotation_only_asymmetric_body_rotates_as_the_free_body_does(integrator: str) -> None:
    """rotation_only changes nothing of the rotation: same numbers as a free body under the same torques."""
    free = load_scene({"bodies": {"b": body({"box": [1.0, 0.6, 0.4]}, angular=[0.3, 1.0, 0.2])}})
    pinned = load_scene({"gravity": [0, 0, -9.81], "bodies": {
        "b": body({"box": [1.0, 0.6, 0.4]}, angular=[0.3, 1.0, 0.2], motion="rotation_only")}})
    a, b = Simulator(free, integrator=integrator, dt=0.01), Simulator(pinned, integrator=integrator, dt=0.01)
    for k in range(200):
        a.apply_wrench("b", torque=[0.1 * math.sin(k), 0.2, 0.0], frame="b")
        b.apply_wrench("b", force=[5.0, 0.0, 1.0], torque=[0.1 * math.sin(k), 0.2, 0.0], frame="b")
        a.step()
        b.step()
    np.testing.assert_array_equal(a.state.q_WP, b.state.q_WP)
    np.testing.assert_array_equal(a.state.w_WP_P, b.state.w_WP_P)


def test_stopping_a_body_makes_it_static_and_reset_brings_it_back() -> None:
    scene = load_scene({"bodies": {"a": body({"box": [1, 1, 2]}, linear=[1, 0, 0]),
                                   "b": body({"box": [1, 0.6, 0.4]}, angular=[0.3, 1.0, 0.2])}})
    sim = Simulator(scene, integrator="rk4", dt=0.01)
    assert models(sim) == {"a": "symmetric", "b": "full"}
    sim.step(10)
    sim.stop_body("a")
    frozen = sim.state.copy()
    sim.step(10)
    assert models(sim)["a"] == "static"
    np.testing.assert_array_equal(sim.state.p_WC_W[0], frozen.p_WC_W[0])
    sim.reset()
    assert models(sim) == {"a": "symmetric", "b": "full"}


# --------------------------------------------------------------------------- the scene's motion key


@pytest.mark.parametrize(("motion", "twist", "where", "expected"), [
    ("flying", None, "bodies.b.motion", "expected one of ['free', 'static', 'kinematic', 'planar', 'rotation_only', "
                                        "'translation_only']"),
    ({"kind": "static", "normal": [0, 0, 1]}, None, "bodies.b.motion.normal", "expected no normal unless kind is planar"),
    ({"kind": "planar", "normal": [0, 0, 0]}, None, "bodies.b.motion.normal", "expected a non-zero vector"),
    ({"kind": "planar", "axis": [0, 0, 1]}, None, "bodies.b.motion.axis", "expected one of the keys ['kind', 'normal']"),
    ("static", {"linear": [1, 0, 0]}, "bodies.b.twist", "expected no twist for a static body"),
    ("rotation_only", {"linear": [1, 0, 0]}, "bodies.b.twist.linear", "expected zero linear velocity"),
    ("translation_only", {"angular": [0, 1, 0]}, "bodies.b.twist.angular", "expected zero angular velocity"),
    ("planar", {"linear": [0, 0, 1]}, "bodies.b.twist.linear", "expected a velocity in the plane"),
    ("planar", {"angular": [1, 0, 0]}, "bodies.b.twist.angular", "expected an angular velocity along the plane normal"),
    (7, None, "bodies.b.motion", "expected one of"),
], ids=["unknown", "normal-not-planar", "zero-normal", "unknown-key", "static-twist", "rotation-linear",
        "translation-angular", "planar-off-plane", "planar-tilt", "not-a-name"])
def test_bad_motion_is_rejected_with_key_path_and_expectation(motion: Any, twist: Any, where: str, expected: str) -> None:
    spec: dict[str, Any] = {"mass": 1.0, "inertia": {"sphere": 0.1}, "motion": motion}
    if twist is not None:
        spec["twist"] = twist
    with pytest.raises(SceneError) as info:
        load_scene({"bodies": {"b": spec}})
    assert f"<dict>: {where}: {expected}" in str(info.value)


def test_describe_names_each_bodys_model_and_why() -> None:
    scene = load_scene({"bodies": {
        "ball": body({"sphere": 0.1}), "can": body({"cylinder": [0.1, 0.5]}), "crate": body({"box": [1, 0.6, 0.4]}),
        "wall": body({"box": [1, 1, 1]}, motion="static"), "belt": body({"box": [1, 1, 1]}, motion="kinematic"),
        "puck": body({"cylinder": [0.1, 0.05]}, motion="planar"),
        "sat": body({"box": [1, 0.6, 0.4]}, motion="rotation_only"),
        "cart": body({"box": [1, 0.6, 0.4]}, motion="translation_only")}})
    described = {d["name"]: (d["motion"], d["model"], d["model_reason"]) for d in describe_scene(scene)}
    assert {k: v[1] for k, v in described.items()} == {
        "ball": "isotropic", "can": "symmetric", "crate": "full", "wall": "static", "belt": "kinematic",
        "puck": "planar", "sat": "full", "cart": "translation"}
    assert "isotropic inertia" in described["ball"][2] and "the integrator otherwise" in described["ball"][2]
    assert "centre of mass stays put" in described["sat"][2]
    assert described["puck"][0] == "planar" and "normal [0, 0, 1]" in described["puck"][2]
    off = {d["name"]: d["model"] for d in describe_scene(scene, model_reduction=False)}
    assert off == {"ball": "full", "can": "full", "crate": "full", "wall": "full", "belt": "kinematic",
                   "puck": "planar", "sat": "full", "cart": "full"}


def test_set_body_state_keeps_a_planar_body_in_its_plane() -> None:
    scene = load_scene({"bodies": {"puck": body({"box": [1, 1, 0.2]}, position=[0, 0, 1], motion="planar")}})
    sim = Simulator(scene, integrator="rk4", dt=0.01)
    sim.set_body_state("puck", position_world=[2.0, 3.0, 5.0], linear_velocity_world=[1.0, 0.0, 4.0],
                       angular_velocity_world=[1.0, 0.0, 2.0])
    s = sim.body_state("puck")
    np.testing.assert_allclose(s.position_world, [2.0, 3.0, 1.0])
    np.testing.assert_allclose(s.linear_velocity_world, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(s.angular_velocity_world, [0.0, 0.0, 2.0], atol=1e-15)
