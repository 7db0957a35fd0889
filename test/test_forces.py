"""Applied wrenches and impulses: the worked example, the frame rule, momentum bookkeeping.

The frame rule: a wrench is a force and a torque about the origin of a frame, in that frame's
axes; the same physical push named in any frame must move a body identically. These tests
build each frame's representation by hand from the current state and compare trajectories
(on one tumbling body over two steps, and on any valid body drawn by hypothesis), check the
textbook box of the worked example, and check impulses and read-outs against momentum written out
by hand (m v, R I Rᵀ ω, r × J) rather than against the simulator's own formulas.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from helpers import (
    EPS,
    FIXED_STEP_INTEGRATORS,
    NUMPY_STEPPED_INTEGRATORS,
    PROPERTY_SETTINGS,
    random_rotation_matrix,
    random_unit_quaternion,
    scene_of,
    valid_bodies,
    with_spin_step,
)
from rigid_body_sim.core import INTEGRATORS, Scene, Simulator, load_scene
from rigid_body_sim.exact import closed_form
from rigid_body_sim.core.kernels.dynamics import derivatives
from rigid_body_sim.core.frames import new_wrench_rows, parse_frame
from rigid_body_sim.core.kernels.forces import add_wrench
from rigid_body_sim.core.stepping import pack_parameters
from rigid_body_sim.core.mass_properties import box_inertia
from rigid_body_sim.core.quaternion import quat_to_matrix, quat_wxyz_from_xyzw, quat_xyzw_from_wxyz

ALL_INTEGRATORS = tuple(INTEGRATORS)

# ----------------------------------------------------------------------------- the worked example

MASS = 2.0  # kg
EDGES = [1.0, 0.6, 0.4]  # m
FORCE_B = np.array([0.0, 10.0, 0.0])  # N
POINT_B = np.array([0.5, 0.3, 0.0])  # m from the COM
# By hand: a = F/m = (0, 5, 0) m/s²; τ = r × F = (0.3·0 − 0·10, 0·0 − 0.5·0, 0.5·10 − 0.3·0) = (0, 0, 5) N·m.
ACCELERATION = np.array([0.0, 5.0, 0.0])
TORQUE = np.array([0.0, 0.0, 5.0])


def _textbook_scene() -> Scene:
    return scene_of({"box": {"mass": MASS, "inertia": {"box": EDGES}, "sites": {"corner": {"position": POINT_B.tolist()}}}})


@pytest.mark.parametrize("how", ["site", "point_in_body_frame"])
def test_textbook_box_through_derivatives(how: str) -> None:
    """The worked example through the one right-hand side every integrator uses: a = F/m, I ω̇ = r × F."""
    scene = _textbook_scene()
    prm = pack_parameters(scene.model)
    wrenches = new_wrench_rows(1)
    if how == "site":
        ref = parse_frame(scene, "box", "box/corner")
        add_wrench(wrenches[0], prm[0], ref.kind, *ref.arm_P, *FORCE_B, 0.0, 0.0, 0.0)
    else:
        ref = parse_frame(scene, "box", "box")
        add_wrench(wrenches[0], prm[0], ref.kind, 0.0, 0.0, 0.0, *FORCE_B, *np.cross(POINT_B, FORCE_B))
    rates = np.empty((1, 13))
    derivatives(scene.initial_state.rows(), prm, wrenches, rates)
    np.testing.assert_array_equal(rates[0, 7:10], ACCELERATION)
    inertia = box_inertia(MASS, EDGES)
    np.testing.assert_allclose(inertia * rates[0, 10:13], TORQUE, rtol=0, atol=4 * EPS * 5.0)
    np.testing.assert_allclose(rates[0, 10:13], [0.0, 0.0, 5.0 / (MASS * (1.0 + 0.36) / 12.0)], rtol=2 * EPS)


@pytest.mark.parametrize("how", ["site", "point_in_body_frame"])
@pytest.mark.parametrize("integrator", ALL_INTEGRATORS)
def test_textbook_box_one_small_step(integrator: str, how: str) -> None:
    """One step from rest: I·Δω/h = τ to round-off, and Δv within the step's turn of the force.

    From rest the rate stays on the principal z axis, where the gyroscopic term vanishes and the
    torque about z is constant in body axes: every method integrates it exactly (the adaptive
    reference to its 1e-12 tolerance). The force turns with the body by θ = ½ α h² during the
    step, so Δv/h departs from F/m by at most (F/m)·θ, whatever the method.
    """
    h = 1e-3
    sim = Simulator(_textbook_scene(), integrator, h)
    if how == "site":
        sim.apply_wrench("box", force=FORCE_B, frame="box/corner")
    else:
        sim.apply_force_at_point("box", force=FORCE_B, point=POINT_B, frame="box")
    sim.step()
    state = sim.body_state("box")
    inertia = box_inertia(MASS, EDGES)
    rtol = 1e-10 if integrator == "reference" else 16 * EPS
    theta = 0.5 * (TORQUE[2] / inertia[2]) * h * h
    np.testing.assert_allclose(state.linear_velocity_world / h, ACCELERATION, rtol=0, atol=5.0 * theta)
    np.testing.assert_allclose(inertia * state.angular_velocity_body / h, TORQUE, rtol=0, atol=rtol * 5.0)
    np.testing.assert_allclose(inertia * state.angular_velocity_world / h, TORQUE, rtol=0, atol=rtol * 5.0)


def test_seed_box_pushed_at_its_corner_with_rk4_is_within_1e_9_of_the_closed_form() -> None:
    """The worked example's box, 10 N along its own y at its corner for 1 s, rk4 at h = 1e-3, a new
    command every step as a controller sends it: within 1e-9 of the closed form (Fresnel integrals).
    (How the error falls with h, for every method: test_order.py.)"""
    scene = scene_of({"box": {"mass": MASS, "inertia": {"box": EDGES}, "sites": {"corner": {"position": POINT_B.tolist()}}}})
    sim = Simulator(scene, "rk4", 1e-3)
    for _ in range(1000):
        sim.apply_force_at_point("box", FORCE_B, [0.0, 0.0, 0.0], frame="box/corner")
        sim.step(1)
    inertia_z = box_inertia(MASS, EDGES)[2]
    _q, w_B, v, p = closed_form.box_body_fixed_force(MASS, inertia_z, FORCE_B, POINT_B, np.array([1.0]))
    s = sim.body_state("box")
    assert np.linalg.norm(s.position_world - p[0]) < 1e-9
    assert np.linalg.norm(s.linear_velocity_world - v[0]) < 1e-9
    assert np.linalg.norm(s.angular_velocity_body - w_B[0]) < 1e-9


# ----------------------------------------------------------------------------- no spin without torque


def _translating_bodies(rng: np.random.Generator, count: int, spin_rate: float = 0.0) -> dict[str, Any]:
    bodies = {}
    for i in range(count):
        w = rng.normal(size=3)
        bodies[f"b{i}"] = {
            "mass": float(rng.uniform(0.5, 3.0)),
            "inertia": {"box": rng.uniform(0.2, 1.5, 3).tolist()},
            "pose": {"position": rng.normal(size=3).tolist(),
                     "orientation": quat_xyzw_from_wxyz(random_unit_quaternion(rng)).tolist()},
            "twist": {"linear": rng.normal(size=3).tolist(), "angular": (spin_rate * w / np.linalg.norm(w)).tolist()},
            "sites": {"tip": {"position": rng.normal(size=3).tolist()}},
        }
    return bodies


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_force_through_the_com_never_rotates(integrator: str) -> None:
    """A force at the COM, named in each frame that follows the COM: ω stays exactly 0.

    (A force about a world point that is the COM at the step's start is not one of them: the
    COM moves off its line during the step, and the methods that see that turn the body.)
    """
    rng = np.random.default_rng(30)
    bodies = _translating_bodies(rng, 3)
    bodies["b0"]["sites"]["centre"] = {"position": [0.0, 0.0, 0.0], "axes": "world"}
    scene = scene_of(bodies)
    sim = Simulator(scene, integrator, 0.01)
    q0 = sim.orientations_xyzw()
    force = np.array([3.0, -1.0, 2.0])
    for _ in range(200):
        sim.apply_wrench("b0", force, frame="b0/centre")  # a world-axes site at the COM
        sim.apply_force_at_point("b1", force, point=np.zeros(3), frame="b1")
        sim.apply_wrench("b2", force=force, frame="b2/world_aligned")
        sim.step()
    np.testing.assert_array_equal(sim.angular_velocities_world(), np.zeros((3, 3)))
    np.testing.assert_allclose(sim.orientations_xyzw(), q0, rtol=0, atol=4 * EPS)  # at most a renormalisation


def gravity_steps(integrator: str) -> int:
    """Steps of the gravity tests: 1000 for the compiled methods; the property holds step by step, so 100
    for the numpy-stepped exact rotor (~1 ms a step) and 20 for the adaptive reference (~1 ms a step)."""
    return 20 if integrator == "reference" else 100 if integrator in NUMPY_STEPPED_INTEGRATORS else 1000


@pytest.mark.parametrize("integrator", ALL_INTEGRATORS)
def test_gravity_alone_never_spins_a_body(integrator: str) -> None:
    rng = np.random.default_rng(31)
    steps = gravity_steps(integrator)
    sim = Simulator(scene_of(_translating_bodies(rng, 4), gravity=[0.0, 0.0, -9.81]), integrator, 0.01)
    q0, v0 = sim.orientations_xyzw(), sim.linear_velocities_world()
    sim.step(steps)
    np.testing.assert_array_equal(sim.angular_velocities_world(), np.zeros((4, 3)))
    np.testing.assert_allclose(sim.orientations_xyzw(), q0, rtol=0, atol=4 * EPS)
    assert np.all(sim.linear_velocities_world()[:, 2] < v0[:, 2] - 0.1)  # and it did fall


@pytest.mark.parametrize("integrator", ALL_INTEGRATORS)
def test_gravity_does_not_change_a_spinning_body_s_rotation(integrator: str) -> None:
    """Uniform gravity acts at the COM: the rotation with it is the rotation without it.

    The fixed-step methods update (q, ω) from (q, ω) alone, so the two runs agree to round-off.
    The adaptive reference chooses its steps from the error of all components, so with gravity
    it may take other steps: agreement to its tolerance (1e-12 per step) times the steps.
    """
    bodies = _translating_bodies(np.random.default_rng(32), 4, spin_rate=2.0)
    steps = gravity_steps(integrator)
    with_g = Simulator(scene_of(bodies, gravity=[0.0, 0.0, -9.81]), integrator, 0.01)
    without = Simulator(scene_of(bodies), integrator, 0.01)
    with_g.step(steps)
    without.step(steps)
    atol = steps * 1e-11 if integrator == "reference" else 16 * EPS
    np.testing.assert_allclose(with_g.angular_velocities_body(), without.angular_velocities_body(), rtol=0, atol=atol * 2)
    np.testing.assert_allclose(with_g.orientations_xyzw(), without.orientations_xyzw(), rtol=0, atol=atol)
    assert not np.allclose(with_g.positions_world(), without.positions_world())  # gravity did act


# ----------------------------------------------------------------------------- the frame rule

SITE_B = np.array([0.3, -0.2, 0.15])  # m, where the force acts (a material point)
OTHER_SITE_B = np.array([-0.25, 0.1, -0.3])  # m, another body-fixed point
#: The same physical load named in different frames, grouped by what stays fixed while the body
#: moves inside a step: a force fixed in the body at a material point; a force fixed in world
#: axes at a material point; a force fixed in world axes along a line fixed in space. Within a
#: group the motion is the same to round-off (the frame rule); between groups the loads are
#: the same only at the instant they are given, so they agree to the method's local error.
#: (Named at another world-axes site, the moment of the offset is a couple fixed in world axes
#: from the step's start: a load of its own.)
FRAME_GROUPS = {
    "body-fixed": ("body", "site_body_axes", "other_site_body_axes", "point_in_body_frame"),
    "world axes at a material point": ("site_world_axes",),
    "world axes at another point, offset moment fixed in world axes": ("other_site_world_axes",),
    "line fixed in space": ("world", "point_in_world_frame"),
}
FRAMES = tuple(frame for group in FRAME_GROUPS.values() for frame in group)
FRAME_RUN_S = 0.5  # s of the same tumbling motion under the same push in every frame


def _frame_scene(inertia: dict[str, Any], rng: np.random.Generator) -> Scene:
    """One copy of the same tumbling, translating body per frame, all in the same initial state."""
    pose = {"position": rng.normal(size=3).tolist(), "orientation": quat_xyzw_from_wxyz(random_unit_quaternion(rng)).tolist()}
    twist = {"linear": rng.normal(size=3).tolist(), "angular": (1.5 * rng.normal(size=3)).tolist()}
    sites = {
        "s": {"position": SITE_B.tolist()},
        "sw": {"position": SITE_B.tolist(), "axes": "world"},
        "o": {"position": OTHER_SITE_B.tolist()},
        "ow": {"position": OTHER_SITE_B.tolist(), "axes": "world"},
    }
    body = {"mass": 1.7, "inertia": inertia, "pose": pose, "twist": twist, "sites": sites}
    return scene_of({f"by_{frame}": body for frame in FRAMES})


def _apply_in_frame(sim: Simulator, frame: str, force_W: np.ndarray, couple_W: np.ndarray) -> None:
    """Apply the force ``force_W`` at material point SITE_B plus the couple ``couple_W`` to the
    body ``by_<frame>``, named in that frame. Built by hand from the body's reported B pose.
    """
    name = f"by_{frame}"
    state = sim.body_state(name)
    R_WB = quat_to_matrix(quat_wxyz_from_xyzw(state.orientation_xyzw))
    p_WC = state.position_world
    F_B, C_B = R_WB.T @ force_W, R_WB.T @ couple_W
    arm_W = R_WB @ SITE_B  # from the COM to the point, world axes
    other_to_point_B = SITE_B - OTHER_SITE_B
    if frame == "world":  # torque about the world origin, world axes
        sim.apply_wrench(name, force_W, couple_W + np.cross(p_WC + arm_W, force_W), frame="world")
    elif frame == "body":  # about the COM, B axes
        sim.apply_wrench(name, F_B, C_B + np.cross(SITE_B, F_B), frame=name)
    elif frame == "site_body_axes":  # about the point itself, B axes
        sim.apply_wrench(name, F_B, C_B, frame=f"{name}/s")
    elif frame == "site_world_axes":  # about the point itself, world axes
        sim.apply_wrench(name, force_W, couple_W, frame=f"{name}/sw")
    elif frame == "other_site_body_axes":  # about another body point, B axes
        sim.apply_wrench(name, F_B, C_B + np.cross(other_to_point_B, F_B), frame=f"{name}/o")
    elif frame == "other_site_world_axes":  # about another body point, world axes
        sim.apply_wrench(name, force_W, couple_W + np.cross(R_WB @ other_to_point_B, force_W), frame=f"{name}/ow")
    elif frame == "point_in_body_frame":
        sim.apply_force_at_point(name, F_B, SITE_B, frame=name)
        sim.apply_wrench(name, torque=C_B, frame=name)
    elif frame == "point_in_world_frame":
        sim.apply_force_at_point(name, force_W, p_WC + arm_W, frame="world")
        sim.apply_wrench(name, torque=couple_W, frame="world")
    else:
        raise AssertionError(frame)


def _spread(sim: Simulator, frames: tuple[str, ...]) -> float:
    """The largest difference between the copies of ``frames``, relative to the size of each read-out."""
    rows = [FRAMES.index(frame) for frame in frames]
    worst = 0.0
    for readout in (sim.positions_world, sim.orientations_xyzw, sim.linear_velocities_world,
                    sim.angular_velocities_world, sim.angular_velocities_body):
        values = readout()[rows]
        worst = max(worst, np.abs(values - values[0]).max() / max(1.0, np.abs(values).max()))
    return worst


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
@pytest.mark.parametrize("inertia_kind", ["principal", "full_tensor"])
def test_the_same_wrench_in_every_frame_gives_the_same_motion(integrator: str, inertia_kind: str) -> None:
    """The same load named in any frame of its group moves the body identically (1e-12); the groups
    differ only by what the load does inside a step, which vanishes with the method's order."""
    rng = np.random.default_rng(33)
    if inertia_kind == "principal":
        inertia: dict[str, Any] = {"principal": [0.11, 0.23, 0.3]}
    else:  # a non-diagonal tensor: q_BP is not the identity, B is not the principal frame
        R = random_rotation_matrix(rng)
        tensor = R @ np.diag([0.11, 0.23, 0.3]) @ R.T
        inertia = {"tensor": (0.5 * (tensor + tensor.T)).tolist()}
    scene = _frame_scene(inertia, rng)
    between = []
    for h in (0.01, 0.005):
        sim = Simulator(scene, integrator, h)
        if inertia_kind == "full_tensor":
            assert not np.allclose(sim.model.q_BP[0], [1.0, 0.0, 0.0, 0.0], atol=1e-3)
        steps = round(FRAME_RUN_S / h)
        for k in range(steps):
            t = sim.time
            force_W = np.array([2.0 * np.cos(1.3 * t), 1.0, -1.5 * np.sin(0.7 * t)])  # N, world axes
            couple_W = np.array([0.05, -0.1 * np.cos(t), 0.02])  # N·m, a pure couple
            for frame in FRAMES:
                _apply_in_frame(sim, frame, force_W, couple_W)
            sim.step()
            if k % 25 == 24:
                for group, frames in FRAME_GROUPS.items():
                    assert _spread(sim, frames) <= 1e-12, f"{group} frames differ after step {k}: {frames}"
        between.append(_spread(sim, FRAMES))
    # Re-applied every step from the state then, the groups' loads agree at each step's start:
    # the methods that evaluate forces only there (euler, semi_implicit_euler) cannot tell them
    # apart; the others part by O(h) per unit time (the load's change inside a step).
    if integrator in ("euler", "semi_implicit_euler"):
        assert max(between) <= 1e-12, between
    else:
        assert between[1] < 0.7 * between[0], between
    # The push did something: the copies are far from where a free body would be.
    free = Simulator(sim.scene, integrator, 0.005)
    free.step(round(FRAME_RUN_S / 0.005))
    # |F_y| = 1 N on 1.7 kg for FRAME_RUN_S: 0.29 m/s along y alone.
    assert np.abs(sim.linear_velocities_world()[0] - free.linear_velocities_world()[0]).max() > 0.2


#: The same load named in frames that keep it the same inside a step (two groups of FRAME_GROUPS
#: above): a force and couple fixed in the body, and a force along a line fixed in space.
ANY_BODY_FRAME_GROUPS = {"body-fixed": ("body", "site_body_axes", "point_in_body_frame"),
                "line fixed in space": ("world", "point_in_world_frame")}
ANY_BODY_FRAMES = tuple(frame for group in ANY_BODY_FRAME_GROUPS.values() for frame in group)


@PROPERTY_SETTINGS
@given(spec=valid_bodies(), integrator=st.sampled_from(FIXED_STEP_INTEGRATORS), steps=st.integers(1, 8),
       force=st.lists(st.floats(-10.0, 10.0), min_size=3, max_size=3),
       couple=st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3))
def test_the_same_wrench_in_every_frame_moves_any_body_the_same(spec, integrator, steps, force, couple) -> None:
    """Any valid body (hypothesis, helpers.valid_bodies): a force F at a body-fixed point r_B plus a couple C,
    named in each frame of its group (converted by hand from the current state every step): every
    copy in a group moves identically, to round-off."""
    rng = spec["rng"]
    site_B = rng.normal(size=3)
    body = with_spin_step(spec, 0.1, 0.01)
    body["sites"] = {"s": {"position": site_B.tolist()}}
    sim = Simulator(scene_of({f"by_{frame}": body for frame in ANY_BODY_FRAMES}), integrator, 0.01)
    # Sized so that every body stays in every method's envelope over the run (|ω̇| ≲ 10 rad/s²,
    # |a| ≲ 100 m/s²): outside it, explicit methods amplify any difference, round-off included.
    I_min, arm = spec["moments"].min(), np.linalg.norm(site_B)
    F_W = np.array(force) * min(body["mass"], I_min / arm)
    C_W = np.array(couple) * 10.0 * I_min
    for _ in range(steps):
        for frame in ANY_BODY_FRAMES:
            name = f"by_{frame}"
            state = sim.body_state(name)
            R_WB = quat_to_matrix(quat_wxyz_from_xyzw(state.orientation_xyzw))
            arm_W = R_WB @ site_B  # COM → point, world axes
            if frame == "world":  # about the world origin, world axes
                sim.apply_wrench(name, F_W, C_W + np.cross(state.position_world + arm_W, F_W), frame="world")
            elif frame == "point_in_world_frame":
                sim.apply_force_at_point(name, F_W, state.position_world + arm_W, frame="world")
                sim.apply_wrench(name, torque=C_W, frame="world")
            elif frame == "body":  # about the COM, body axes
                sim.apply_wrench(name, R_WB.T @ F_W, R_WB.T @ (C_W + np.cross(arm_W, F_W)), frame=name)
            elif frame == "point_in_body_frame":
                sim.apply_force_at_point(name, R_WB.T @ F_W, site_B, frame=name)
                sim.apply_wrench(name, torque=R_WB.T @ C_W, frame=name)
            else:  # about the point, body axes
                sim.apply_wrench(name, R_WB.T @ F_W, R_WB.T @ C_W, frame=f"{name}/s")
        sim.step()
    # Round-off of the inputs: each frame's numbers reach the same (F, τ about the COM) up to
    # ~ε of the largest term added, |p + r| |F| for the world origin, through a chain of a
    # few dozen roundings per step (rotations, cross products, resolve, kicks); a torque error
    # δτ moves ω by n h δτ / I_min and the orientation by n h that; a force error likewise via
    # m; and the orientation's own round-off turns ω by ~ε per step.
    t = steps * 0.01
    lever = np.abs(sim.positions_world()).max() + np.linalg.norm(site_B) + 1.0
    d_torque = 256 * EPS * (lever * np.linalg.norm(F_W) + np.linalg.norm(C_W))
    d_force = 256 * EPS * np.linalg.norm(F_W)
    d_w = t * d_torque / spec["moments"].min() + 64 * steps * EPS * np.abs(sim.angular_velocities_world()).max()
    d_v = t * d_force / body["mass"]
    bounds = {"positions_world": t * d_v, "orientations_xyzw": t * d_w,
              "linear_velocities_world": d_v, "angular_velocities_world": d_w}
    for group, frames in ANY_BODY_FRAME_GROUPS.items():
        rows = [ANY_BODY_FRAMES.index(frame) for frame in frames]
        for readout in (sim.positions_world, sim.orientations_xyzw, sim.linear_velocities_world,
                        sim.angular_velocities_world):
            values = readout()[rows]
            bound = 1e-12 * np.abs(values).max() + bounds[readout.__name__]
            assert np.abs(values - values[0]).max() <= bound, (group, readout.__name__, values, bound)


# ----------------------------------------------------------------------------- the user's body frame B


def _tensor_body(rng: np.random.Generator) -> tuple[dict[str, Any], np.ndarray]:
    R = random_rotation_matrix(rng)
    tensor_B = R @ np.diag([0.11, 0.23, 0.3]) @ R.T
    tensor_B = 0.5 * (tensor_B + tensor_B.T)
    return {"mass": 1.3, "inertia": {"tensor": tensor_B.tolist()}}, tensor_B


def test_reported_pose_is_the_user_body_frame() -> None:
    """At rest with the identity pose, B reads as the identity, whatever the principal frame is."""
    rng = np.random.default_rng(34)
    body, tensor_B = _tensor_body(rng)
    w_W = np.array([0.3, -0.4, 1.2])
    body["twist"] = {"angular": w_W.tolist()}
    sim = Simulator(scene_of({"b": body}), "rk4", 0.01)
    state = sim.body_state("b")
    np.testing.assert_allclose(state.orientation_xyzw, [0.0, 0.0, 0.0, 1.0], rtol=0, atol=4 * EPS)
    np.testing.assert_allclose(state.angular_velocity_body, w_W, rtol=0, atol=8 * EPS)
    np.testing.assert_allclose(state.angular_velocity_world, w_W, rtol=0, atol=8 * EPS)


def test_torque_on_a_full_tensor_body_accelerates_by_the_inverse_tensor() -> None:
    """One explicit-Euler step from rest: Δω_B/h = T_B⁻¹ τ_B exactly (the rates at rest are exact)."""
    rng = np.random.default_rng(35)
    body, tensor_B = _tensor_body(rng)
    sim = Simulator(scene_of({"b": body}), "euler", 1e-3)
    torque_B = np.array([0.2, -0.1, 0.05])
    sim.apply_wrench("b", torque=torque_B, frame="b")
    sim.step()
    w_B = sim.body_state("b").angular_velocity_body
    # Only round-off, through the eigen-decomposition of T_B: relative 1e-13.
    np.testing.assert_allclose(tensor_B @ w_B / 1e-3, torque_B, rtol=0, atol=1e-13 * np.abs(torque_B).max())


def test_torque_free_full_tensor_body_conserves_momentum_written_in_b() -> None:
    """L_W = R_WB T_B ω_B from the reported B pose, B rates and the user's tensor stays constant.

    If the reported orientation were the principal frame P (or ω were in P axes), this product
    would not be the angular momentum and would not be conserved. rk4 at |ω|h ≈ 0.01 over
    1000 steps conserves L to its local error (|ω|h)⁵ per step: ~1e-7 relative at worst.
    """
    rng = np.random.default_rng(36)
    body, tensor_B = _tensor_body(rng)
    body["pose"] = {"orientation": quat_xyzw_from_wxyz(random_unit_quaternion(rng)).tolist()}
    body["twist"] = {"angular": [0.4, 1.0, -0.3]}
    sim = Simulator(scene_of({"b": body}), "rk4", 0.01)

    def momentum_and_energy() -> tuple[np.ndarray, float]:
        state = sim.body_state("b")
        R_WB = quat_to_matrix(quat_wxyz_from_xyzw(state.orientation_xyzw))
        w_B = state.angular_velocity_body
        np.testing.assert_allclose(R_WB @ w_B, state.angular_velocity_world, rtol=0, atol=1e-14)
        return R_WB @ tensor_B @ w_B, 0.5 * w_B @ tensor_B @ w_B

    L0, E0 = momentum_and_energy()
    np.testing.assert_allclose(L0, sim.angular_momentum()[0], rtol=0, atol=1e-14)
    for _ in range(10):
        sim.step(100)
        L, E = momentum_and_energy()
        np.testing.assert_allclose(L, L0, rtol=0, atol=1e-7 * np.linalg.norm(L0))
        assert abs(E - E0) <= 1e-7 * E0
    assert quat_to_matrix(quat_wxyz_from_xyzw(sim.body_state("b").orientation_xyzw))[0, 0] < 0.99  # it did turn


# ----------------------------------------------------------------------------- impulses and read-outs


def _impulse_scene(rng: np.random.Generator) -> tuple[Scene, np.ndarray]:
    body, tensor_B = _tensor_body(rng)
    body["pose"] = {"position": [0.4, -1.0, 2.0], "orientation": quat_xyzw_from_wxyz(random_unit_quaternion(rng)).tolist()}
    body["twist"] = {"linear": [0.5, 0.2, -0.1], "angular": [0.3, -0.7, 0.9]}
    body["sites"] = {"s": {"position": SITE_B.tolist()}, "sw": {"position": SITE_B.tolist(), "axes": "world"}}
    return scene_of({"b": body}), tensor_B


@pytest.mark.parametrize("frame", ["world", "b", "b/world_aligned", "b/s", "b/sw"])
def test_impulse_in_each_frame_changes_momentum_exactly(frame: str) -> None:
    """Δp = J and ΔL_C = H + (o − p_C) × J, with o and the axes those of the frame."""
    rng = np.random.default_rng(37)
    scene, _tensor = _impulse_scene(rng)
    sim = Simulator(scene, "rk4", 0.01)
    sim.step(3)  # away from the initial state
    state = sim.body_state("b")
    R_WB = quat_to_matrix(quat_wxyz_from_xyzw(state.orientation_xyzw))
    p_C = state.position_world
    origin, R_WF = {
        "world": (np.zeros(3), np.eye(3)),
        "b": (p_C, R_WB),
        "b/world_aligned": (p_C, np.eye(3)),
        "b/s": (p_C + R_WB @ SITE_B, R_WB),
        "b/sw": (p_C + R_WB @ SITE_B, np.eye(3)),
    }[frame]
    J_F = np.array([0.3, -0.2, 0.5])  # N·s, frame axes
    H_F = np.array([-0.05, 0.1, 0.02])  # N·m·s about the frame origin, frame axes
    J_W, H_W = R_WF @ J_F, R_WF @ H_F
    p0, L0, L0_O = sim.linear_momentum()[0], sim.angular_momentum()[0], sim.angular_momentum(about_origin=True)[0]
    pose_before = (sim.positions_world(), sim.orientations_xyzw())
    sim.apply_impulse("b", linear=J_F, angular=H_F, frame=frame)
    scale = 16 * EPS * 10.0
    np.testing.assert_allclose(sim.linear_momentum()[0] - p0, J_W, rtol=0, atol=scale)
    np.testing.assert_allclose(sim.angular_momentum()[0] - L0, H_W + np.cross(origin - p_C, J_W), rtol=0, atol=scale)
    np.testing.assert_allclose(sim.angular_momentum(about_origin=True)[0] - L0_O, H_W + np.cross(origin, J_W),
                               rtol=0, atol=scale)
    np.testing.assert_array_equal(sim.positions_world(), pose_before[0])  # an impulse moves nothing at once
    np.testing.assert_array_equal(sim.orientations_xyzw(), pose_before[1])


def test_readouts_against_hand_computation() -> None:
    """Energy and momenta of a full-tensor body against m v, R T_B Rᵀ ω and p × m v by hand."""
    rng = np.random.default_rng(38)
    _body, tensor_B = _tensor_body(rng)
    m, p, v, w_W = 1.3, np.array([0.4, -1.0, 2.0]), np.array([0.5, 0.2, -0.1]), np.array([0.3, -0.7, 0.9])
    q_xyzw = [0.2, -0.4, 0.1, np.sqrt(1 - 0.21)]
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "bodies": {"b": {
        "mass": m, "inertia": {"tensor": tensor_B.tolist()},
        "pose": {"position": p.tolist(), "orientation": q_xyzw},
        "twist": {"linear": v.tolist(), "angular": w_W.tolist()},
    }}}), "rk4", 0.01)
    R_WB = Rotation.from_quat(q_xyzw, scalar_first=False).as_matrix()
    tensor_W = R_WB @ tensor_B @ R_WB.T
    # Round-off of a few products of O(1) numbers, through the tensor's eigen-decomposition.
    np.testing.assert_allclose(sim.kinetic_energy()[0], 0.5 * m * v @ v + 0.5 * w_W @ tensor_W @ w_W, rtol=1e-14)
    np.testing.assert_allclose(sim.potential_energy()[0], m * 9.81 * 2.0, rtol=1e-15)
    np.testing.assert_allclose(sim.linear_momentum()[0], m * v, rtol=0, atol=4 * EPS)
    np.testing.assert_allclose(sim.angular_momentum()[0], tensor_W @ w_W, rtol=0, atol=1e-14)
    np.testing.assert_allclose(sim.angular_momentum(about_origin=True)[0], tensor_W @ w_W + np.cross(p, m * v),
                               rtol=0, atol=1e-14)
    state = sim.body_state("b")
    np.testing.assert_allclose(state.angular_velocity_body, R_WB.T @ w_W, rtol=0, atol=1e-15)
    np.testing.assert_allclose(state.angular_velocity_world, w_W, rtol=0, atol=1e-15)


# ----------------------------------------------------------------------------- API errors


def test_unknown_body_lists_the_bodies() -> None:
    sim = Simulator(_textbook_scene(), "rk4", 0.01)
    expected = re.escape("unknown body 'crate'; bodies are ['box']")
    for call in (
        lambda: sim.apply_wrench("crate", force=[1, 0, 0]),
        lambda: sim.apply_force_at_point("crate", [1, 0, 0], [0, 0, 0]),
        lambda: sim.apply_impulse("crate", linear=[1, 0, 0]),
        lambda: sim.body_state("crate"),
        lambda: sim.stop_body("crate"),
        lambda: sim.set_body_state("crate", position_world=[0, 0, 0]),
        lambda: sim.frames_of("crate"),
    ):
        with pytest.raises(ValueError, match=expected):
            call()


@pytest.mark.parametrize("frame", ["box/edge", "crate", "box/world", "world_aligned", "box/", "BOX", "box/corner/x"])
def test_unknown_frame_lists_the_frames(frame: str) -> None:
    sim = Simulator(_textbook_scene(), "rk4", 0.01)
    expected = re.escape(
        f"unknown frame {frame!r} for body 'box'; valid frames are ['world', 'box', 'box/world_aligned', 'box/corner']"
    )
    with pytest.raises(ValueError, match=expected):
        sim.apply_wrench("box", force=[1.0, 0.0, 0.0], frame=frame)
    with pytest.raises(ValueError, match=expected):
        sim.apply_impulse("box", linear=[1.0, 0.0, 0.0], frame=frame)


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda s: s.apply_wrench("box", force=[np.nan, 0.0, 0.0], frame="box"), "force"),
        (lambda s: s.apply_wrench("box", force=[1.0, 0.0, 0.0], torque=[0.0, np.inf, 0.0]), "torque"),
        (lambda s: s.apply_wrench("box", force=[1.0, 0.0]), "force"),
        (lambda s: s.apply_wrench("box", force="up"), "force"),
        (lambda s: s.apply_force_at_point("box", [0.0, -np.inf, 0.0], [0.5, 0.3, 0.0]), "force"),
        (lambda s: s.apply_force_at_point("box", [0.0, 10.0, 0.0], [np.nan, 0.3, 0.0]), "point"),
        (lambda s: s.apply_impulse("box", linear=[np.nan, 0.0, 0.0]), "linear impulse"),
        (lambda s: s.apply_impulse("box", linear=[1.0, 0.0, 0.0], angular=[0.0, 0.0, np.inf]), "angular impulse"),
        # float64 arrays take the fast path; a non-finite number in any slot is still refused
        (lambda s: s.apply_wrench("box", force=np.array([0.0, 0.0, np.nan]), frame="box/corner"), "force"),
        (lambda s: s.apply_wrench("box", torque=np.array([-np.inf, 0.0, 0.0]), frame="box"), "torque"),
        (lambda s: s.apply_force_at_point("box", np.array([0.0, np.inf, 0.0]), np.zeros(3), "box/corner"), "force"),
        (lambda s: s.apply_force_at_point("box", np.ones(3), np.array([0.0, 0.0, np.nan]), "box"), "point"),
        # finite force and point whose moment r × F overflows
        (lambda s: s.apply_force_at_point("box", np.array([0.0, 1e200, 0.0]), np.array([1e200, 0.0, 0.0])),
         "torque"),
    ],
    ids=["force-nan", "torque-inf", "force-2", "force-str", "point-force-inf", "point-nan", "impulse-nan",
         "angular-impulse-inf", "array-force-nan-z", "array-torque-inf", "array-point-force-inf",
         "array-point-nan-z", "moment-overflow"],
)
def test_non_finite_or_malformed_input_is_rejected_and_nothing_is_applied(call: Any, name: str) -> None:
    sim = Simulator(_textbook_scene(), "rk4", 0.01)
    untouched = Simulator(_textbook_scene(), "rk4", 0.01)
    with pytest.raises(ValueError, match=re.escape(f"{name}: expected 3 finite numbers, got ")):
        call(sim)
    sim.step(5)
    untouched.step(5)
    for got, want in zip((sim.positions_world(), sim.orientations_xyzw(), sim.linear_velocities_world(),
                          sim.angular_velocities_world()),
                         (untouched.positions_world(), untouched.orientations_xyzw(),
                          untouched.linear_velocities_world(), untouched.angular_velocities_world())):
        np.testing.assert_array_equal(got, want)


def test_wrenches_hold_for_one_step_call_then_clear() -> None:
    h = 1e-3
    sim = Simulator(_textbook_scene(), "euler", h)
    sim.apply_wrench("box", force=FORCE_B, frame="box/world_aligned")  # through the COM: no turn
    sim.step(3)
    v3 = sim.body_state("box").linear_velocity_world.copy()
    np.testing.assert_allclose(v3, 3 * h * ACCELERATION, rtol=1e-14)
    sim.step(2)  # no wrench any more: the velocity stays
    np.testing.assert_array_equal(sim.body_state("box").linear_velocity_world, v3)
