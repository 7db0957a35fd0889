"""Every integrator keeps its order under forcing in every frame (issue 13).

A held wrench on an asymmetric tumbling body, in each of the five kinds of frame, against an
independent reference: Newton–Euler written out plainly below (rotation matrices, body-axes
Euler equations) and integrated by scipy's DOP853 at rtol 1e-13. Nothing of the simulator's
code is used for the reference; the frame rule is applied from its definition (a force and
a torque about the frame's origin, in its axes), at the state the reference is at.

Why it matters: a force fixed in the body turns with it during a step; a wrench about a
world point has a moment about the centre of mass that changes as the centre of mass moves.
Held constant in world axes over each step, both make every method first order.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from helpers import FIXED_STEP_INTEGRATORS, ORDER, loglog_slope, scene_of
from rigid_body_sim.core import Simulator
from rigid_body_sim.exact import closed_form

#: An asymmetric body, tumbling and drifting away from the world origin.
MASS = 1.5  # kg
INERTIA = np.array([0.7, 1.3, 1.9])  # kg·m², principal = body axes
P0 = np.array([1.0, 0.5, -0.3])  # m
Q0_XYZW = np.array([0.2, -0.3, 0.1, 0.9273618495495703])  # unit (x, y, z, w)
V0 = np.array([0.3, -0.2, 0.5])  # m/s
W0_B = np.array([0.8, -0.5, 1.2])  # rad/s, body axes
SITE_B = np.array([0.4, -0.25, 0.15])  # m, body axes from the COM
FORCE = np.array([0.9, 1.7, -0.6])  # N, in the frame's axes
TORQUE = np.array([0.2, -0.4, 0.3])  # N·m, about the frame's origin, in its axes
T_END = 1.0  # s

#: (frame name, where its origin is, its axes)
FRAMES = {
    "world": ("world origin", "world"),
    "b/world_aligned": ("COM", "world"),
    "b": ("COM", "body"),
    "b/tip": ("site", "body"),
    "b/nozzle": ("site", "world"),
}

#: Step sizes per order: errors well above round-off and in the asymptotic range at T = 1 s.
STEPS = {1: (0.02, 0.01, 0.005), 2: (0.04, 0.02, 0.01), 4: (0.1, 0.05, 0.025)}
SLOPE_TOLERANCE = 0.2


def _matrix(q_wxyz: np.ndarray) -> np.ndarray:
    w, x, y, z = q_wxyz / np.linalg.norm(q_wxyz)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _wrench_on_com(frame: str, p_W: np.ndarray, R_WB: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(force, world axes; torque about the COM, body axes) of the held wrench, from the frame rule."""
    origin, axes = FRAMES[frame]
    R_WF = R_WB if axes == "body" else np.eye(3)  # the frame's axes in world axes
    force_W = R_WF @ FORCE
    torque_W = R_WF @ TORQUE  # a couple: the same about every point
    if origin == "world origin":  # the force acts along a line through the world origin
        torque_W = torque_W + np.cross(-p_W, force_W)
    elif origin == "site":
        torque_W = torque_W + np.cross(R_WB @ SITE_B, force_W)
    return force_W, R_WB.T @ torque_W


def _reference(frame: str, rtol: float = 1e-13) -> np.ndarray:
    """State (p, q_wxyz, v, w_B) at T_END by DOP853 on the equations written out here."""
    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        p, q, v, w = y[0:3], y[3:7], y[7:10], y[10:13]
        force_W, torque_B = _wrench_on_com(frame, p, _matrix(q))
        qw, qx, qy, qz = q
        dq = 0.5 * np.array([-qx * w[0] - qy * w[1] - qz * w[2],
                             qw * w[0] + qy * w[2] - qz * w[1],
                             qw * w[1] - qx * w[2] + qz * w[0],
                             qw * w[2] + qx * w[1] - qy * w[0]])
        dw = (torque_B - np.cross(w, INERTIA * w)) / INERTIA
        return np.concatenate((v, dq, force_W / MASS, dw))

    q0 = np.array([Q0_XYZW[3], *Q0_XYZW[:3]])
    y0 = np.concatenate((P0, q0, V0, W0_B))
    solution = solve_ivp(rhs, (0.0, T_END), y0, method="DOP853", rtol=rtol, atol=rtol * 1e-2)
    assert solution.success
    end = solution.y[:, -1]
    end[3:7] /= np.linalg.norm(end[3:7])
    return end


def _scene():
    R = _matrix(np.array([Q0_XYZW[3], *Q0_XYZW[:3]]))
    return scene_of({"b": {
        "mass": MASS, "inertia": {"principal": INERTIA.tolist()},
        "pose": {"position": P0.tolist(), "orientation": Q0_XYZW.tolist()},
        "twist": {"linear": V0.tolist(), "angular": (R @ W0_B).tolist()},
        "sites": {"tip": {"position": SITE_B.tolist()}, "nozzle": {"position": SITE_B.tolist(), "axes": "world"}},
    }})


def _error(integrator: str, frame: str, h: float, reference: np.ndarray) -> float:
    """The largest of |Δp| (m), |Δv| (m/s), the orientation angle (rad) and |Δw| (rad/s) at T_END."""
    sim = Simulator(_scene(), integrator, h, model_reduction=False)
    sim.apply_wrench("b", force=FORCE, torque=TORQUE, frame=frame)
    sim.step(int(round(T_END / h)))  # the wrench holds for every step of the call
    s = sim.body_state("b")
    q = np.array([s.orientation_xyzw[3], *s.orientation_xyzw[:3]])
    angle = 2.0 * np.arcsin(min(1.0, np.linalg.norm((_matrix(q).T @ _matrix(reference[3:7]) - np.eye(3))) / np.sqrt(8)))
    return max(np.linalg.norm(s.position_world - reference[0:3]), np.linalg.norm(s.linear_velocity_world - reference[7:10]),
               angle, np.linalg.norm(s.angular_velocity_body - reference[10:13]))


@pytest.fixture(scope="module")
def references() -> dict[str, np.ndarray]:
    return {frame: _reference(frame) for frame in FRAMES}


@pytest.mark.parametrize("frame", list(FRAMES))
@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_held_wrench_keeps_the_nominal_order_in_every_frame(integrator: str, frame: str,
                                                            references: dict[str, np.ndarray]) -> None:
    order = ORDER[integrator]
    h = np.array(STEPS[order])
    errors = np.array([_error(integrator, frame, step, references[frame]) for step in h])
    assert np.all(errors > 1e-12), f"{integrator}, {frame}: errors {errors} reach round-off; pick larger steps"
    slope = loglog_slope(h, errors)
    assert abs(slope - order) <= SLOPE_TOLERANCE, (
        f"{integrator} with a wrench in {frame!r}: observed order {slope:.3f}, nominal {order} "
        f"(h = {h.tolist()}, errors = {errors.tolist()})")


@pytest.mark.parametrize("frame", list(FRAMES))
def test_reference_integrator_matches_the_independent_reference(frame: str, references: dict[str, np.ndarray]) -> None:
    """Our scipy DOP853 path (reference) on our dynamics against DOP853 on the equations above."""
    assert _error("reference", frame, 0.25, references[frame]) < 1e-10


def test_the_references_are_converged(references: dict[str, np.ndarray]) -> None:
    """The reference at rtol 1e-13 and at 1e-11 agree far below the errors the orders are judged on (≥ 1e-9)."""
    for frame in ("b/tip", "world"):
        assert np.max(np.abs(_reference(frame, rtol=1e-11) - references[frame])) < 1e-10


# ----------------------------------------------------------------------------- the seed's box


def test_seed_box_pushed_at_its_corner_with_rk4_is_within_1e_9_of_the_closed_form() -> None:
    """The 2 kg, 1.0 × 0.6 × 0.4 m box, 10 N along its own y at (0.5, 0.3, 0), 1 s, rk4 at h = 1e-3."""
    scene = scene_of({"box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]},
                              "sites": {"corner": {"position": [0.5, 0.3, 0.0]}}}})
    sim = Simulator(scene, "rk4", 1e-3)
    for _ in range(1000):  # a new command every step, as a controller sends it
        sim.apply_force_at_point("box", [0.0, 10.0, 0.0], [0.0, 0.0, 0.0], frame="box/corner")
        sim.step(1)
    I_z = 2.0 * (1.0 + 0.36) / 12.0
    q, w_B, v, p = closed_form.box_body_fixed_force(2.0, I_z, [0.0, 10.0, 0.0], [0.5, 0.3, 0.0], np.array([1.0]))
    s = sim.body_state("box")
    assert np.linalg.norm(s.position_world - p[0]) < 1e-9
    assert np.linalg.norm(s.linear_velocity_world - v[0]) < 1e-9
    assert np.linalg.norm(s.angular_velocity_body - w_B[0]) < 1e-9
