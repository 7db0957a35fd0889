"""Observed order of convergence: one table of problems, every fixed-step integrator on each.

The order each method must show is the one :data:`~rigid_body_sim.core.integrators.INTEGRATORS`
claims (``helpers.ORDER`` is read from it). The problems, each with an exact answer that owes
nothing to the simulator's code:

* ``torque-free top``: three asymmetric tops, against ``closed_form.asymmetric_top`` (Jacobi
  elliptic functions). The exact-rotor splitting is the exact flow here: round-off at every h.
* ``box pushed at its corner``: the box of docs/choosing_an_integrator.md, a force fixed in the
  body at a corner site, from rest, against ``closed_form.box_body_fixed_force`` (Fresnel
  integrals). The spin is exact for every method (constant torque about a principal axis).
  The page's order claims are the orders measured here, over the same steps.
* a held wrench on a tumbling, drifting asymmetric body in each of the five kinds of frame
  (``world``, ``b/world_aligned``, ``b``, ``b/tip``, ``b/nozzle``), against Newton–Euler written
  out plainly below (rotation matrices, body-axes Euler equations) and integrated by scipy's
  DOP853 at rtol 1e-13. The frame rule is applied from its definition (a force and a torque
  about the frame's origin, in its axes) at the state the reference is at. Held constant in
  world axes over each step, a force fixed in the body or a moment about a world point would
  make every method first order.

The observed order is the least-squares slope of log(error) against log(h), within each
problem's tolerance of the claimed one (0.3 over the tops' longer sweeps of four steps, 0.2 for
the others), with every error above round-off.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from helpers import (
    EPS,
    EXACT_FREE_ROTOR,
    FIXED_STEP_INTEGRATORS,
    ORDER,
    loglog_slope,
    orientations_wxyz,
    random_principal_moments,
    random_unit_quaternion,
    scene_of,
)
from rigid_body_sim.core import Simulator
from rigid_body_sim.exact import closed_form
from rigid_body_sim.core.mass_properties import box_inertia
from rigid_body_sim.core.quaternion import quat_angle_between, quat_rotate, quat_xyzw_from_wxyz

ROUND_OFF_FLOOR = 1e-12  # 10× the round-off of these short runs (~1e-13): below it a slope measures noise


@dataclass(frozen=True)
class Problem:
    """A problem with an exact answer: ``error(integrator, h)``, and the steps to sweep per order."""

    error: Callable[[str, float], float]
    steps: dict[int, tuple[float, ...]]  # order → h (s), in the method's asymptotic range
    tolerance: float  # on the observed order


# ----------------------------------------------------------------------------- torque-free tops

TOP_TIME = 2.0  # s
TOP_SPIN = 1.0  # rad/s, |ω| of each top


@dataclass(frozen=True)
class Tops:
    """Three asymmetric tops and their exact state at TOP_TIME."""

    bodies: dict
    q_WB_exact: np.ndarray  # (3, 4), w x y z
    w_B_exact: np.ndarray  # (3, 3), rad/s, body axes


@functools.lru_cache(maxsize=None)
def _tops() -> Tops:
    rng = np.random.default_rng(40)
    bodies, q_exact, w_exact = {}, [], []
    for i in range(3):
        inertia = random_principal_moments(rng)
        q_WB0 = random_unit_quaternion(rng)
        w_B0 = rng.normal(size=3)
        w_B0 *= TOP_SPIN / np.linalg.norm(w_B0)
        bodies[f"top{i}"] = {
            "mass": 1.0,
            "inertia": {"principal": inertia.tolist()},
            "pose": {"orientation": quat_xyzw_from_wxyz(q_WB0).tolist()},
            "twist": {"angular": quat_rotate(q_WB0, w_B0).tolist()},  # world axes
        }
        q, w = closed_form.asymmetric_top(inertia, w_B0, q_WB0, np.array([TOP_TIME]))
        q_exact.append(q[0])
        w_exact.append(w[0])
    return Tops(bodies, np.array(q_exact), np.array(w_exact))


def _top_errors(integrator: str, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Geodesic orientation error (rad) and body-rate error (rad/s) of each top at TOP_TIME."""
    tops = _tops()
    sim = Simulator(scene_of(tops.bodies), integrator, h)
    steps = round(TOP_TIME / h)
    assert abs(steps * h - TOP_TIME) < 1e-12
    sim.step(steps)
    angle = quat_angle_between(orientations_wxyz(sim), tops.q_WB_exact)
    rate = np.linalg.norm(sim.angular_velocities_body() - tops.w_B_exact, axis=1)
    return angle, rate


def _top_error(integrator: str, h: float) -> float:
    return float(max(e.max() for e in _top_errors(integrator, h)))


def test_reference_integrator_matches_the_elliptic_solution() -> None:
    angle, rate = _top_errors("reference", 0.5)
    assert np.all(angle < 1e-9), angle
    assert np.all(rate < 1e-9), rate


def test_closed_form_tops_are_not_trivial() -> None:
    """The tops do tumble: their rates at TOP_TIME are far from the initial ones."""
    tops = _tops()
    sim = Simulator(scene_of(tops.bodies), "rk4", 0.01)
    assert np.all(np.linalg.norm(sim.angular_velocities_body() - tops.w_B_exact, axis=1) > 0.05)


@pytest.mark.parametrize("integrator", EXACT_FREE_ROTOR)
def test_exact_free_rotor_is_exact_on_the_tops_at_any_step(integrator: str) -> None:
    """The exact Euler–Poinsot flow: round-off at steps up to 0.4 rad of turn."""
    for h in (0.4, 0.2, 0.1, 0.05):
        angle, rate = _top_errors(integrator, h)
        assert np.all(angle < ROUND_OFF_FLOOR) and np.all(rate < ROUND_OFF_FLOOR), (h, angle, rate)


# ----------------------------------------------------------------------------- the page's box

#: The box of docs/choosing_an_integrator.md (its claims file's "box" problem).
BOX = {"mass_kg": 2.0, "box_sides_m": [1.0, 0.6, 0.4], "site_body_m": [0.5, 0.3, 0.0],
       "force_in_site_axes_N": [0.0, 10.0, 0.0], "horizon_s": 1.0, "checkpoints": 10}
#: The page's order claims are measured between the first and last of these.
BOX_STEPS = (0.004, 0.002, 0.001)  # s


def _box_error(integrator: str, h: float) -> float:
    """The largest |Δp| (m) and |Δv| (m/s) over the checkpoints, the force re-applied before each
    step call; the spin checked exact to round-off (I ω = τ t) at each checkpoint."""
    checkpoints, horizon = BOX["checkpoints"], BOX["horizon_s"]
    n = round(horizon / (checkpoints * h))
    assert math.isclose(n * checkpoints * h, horizon, rel_tol=1e-9)
    scene = scene_of({"b": {"mass": BOX["mass_kg"], "inertia": {"box": BOX["box_sides_m"]},
                            "sites": {"s": {"position": BOX["site_body_m"]}}}})
    sim = Simulator(scene, integrator, h)
    times = np.arange(1, checkpoints + 1) * n * h
    inertia_z = box_inertia(BOX["mass_kg"], BOX["box_sides_m"])[2]
    _q, w_B, v_W, p_W = closed_form.box_body_fixed_force(BOX["mass_kg"], inertia_z, np.array(BOX["force_in_site_axes_N"]),
                                                         np.array(BOX["site_body_m"]), times)
    worst = 0.0
    for k in range(checkpoints):
        sim.apply_force_at_point("b", BOX["force_in_site_axes_N"], (0.0, 0.0, 0.0), frame="b/s")
        sim.step(n)  # the force holds for every step of the call
        s = sim.body_state("b")
        steps_so_far = (k + 1) * n
        np.testing.assert_allclose(s.angular_velocity_body, w_B[k], rtol=0,
                                   atol=steps_so_far * 8 * EPS * np.abs(w_B).max())
        worst = max(worst, np.linalg.norm(s.position_world - p_W[k]), np.linalg.norm(s.linear_velocity_world - v_W[k]))
    return float(worst)


CLAIMS = Path(__file__).resolve().parents[1] / "docs" / "choosing_an_integrator.claims.json"


def test_the_page_s_order_claims_are_the_orders_measured_here() -> None:
    """docs/choosing_an_integrator.md claims, per integrator, the observed order on its box between
    two steps: the box, the steps and the order are the ones test_observed_order measures."""
    data = json.loads(CLAIMS.read_text())
    problem = data["problems"]["box"]
    assert {key: problem[key] for key in BOX} == BOX
    claims = {c["integrator"]: c for c in data["claims"] if c["kind"] == "order"}
    assert set(claims) == set(FIXED_STEP_INTEGRATORS)
    for name, claim in claims.items():
        assert claim["problem"] == "box", claim
        assert (claim["h_coarse"], claim["h_fine"]) == (BOX_STEPS[0], BOX_STEPS[-1]), claim
        assert abs(claim["order"] - ORDER[name]) <= claim["tolerance"], claim


# ----------------------------------------------------------------------------- a held wrench in each frame

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


@functools.lru_cache(maxsize=None)
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
    end.setflags(write=False)
    return end


def _frame_scene():
    R = _matrix(np.array([Q0_XYZW[3], *Q0_XYZW[:3]]))
    return scene_of({"b": {
        "mass": MASS, "inertia": {"principal": INERTIA.tolist()},
        "pose": {"position": P0.tolist(), "orientation": Q0_XYZW.tolist()},
        "twist": {"linear": V0.tolist(), "angular": (R @ W0_B).tolist()},
        "sites": {"tip": {"position": SITE_B.tolist()}, "nozzle": {"position": SITE_B.tolist(), "axes": "world"}},
    }})


def _held_wrench_error(frame: str, integrator: str, h: float) -> float:
    """The largest of |Δp| (m), |Δv| (m/s), the orientation angle (rad) and |Δw| (rad/s) at T_END."""
    reference = _reference(frame)
    sim = Simulator(_frame_scene(), integrator, h, model_reduction=False)
    sim.apply_wrench("b", force=FORCE, torque=TORQUE, frame=frame)
    sim.step(int(round(T_END / h)))  # the wrench holds for every step of the call
    s = sim.body_state("b")
    q = np.array([s.orientation_xyzw[3], *s.orientation_xyzw[:3]])
    angle = 2.0 * np.arcsin(min(1.0, np.linalg.norm((_matrix(q).T @ _matrix(reference[3:7]) - np.eye(3))) / np.sqrt(8)))
    return max(np.linalg.norm(s.position_world - reference[0:3]), np.linalg.norm(s.linear_velocity_world - reference[7:10]),
               angle, np.linalg.norm(s.angular_velocity_body - reference[10:13]))


@pytest.mark.parametrize("frame", list(FRAMES))
def test_reference_integrator_matches_the_independent_reference(frame: str) -> None:
    """Our scipy DOP853 path (reference) on our dynamics against DOP853 on the equations above."""
    assert _held_wrench_error(frame, "reference", 0.25) < 1e-10


def test_the_references_are_converged() -> None:
    """The reference at rtol 1e-13 and at 1e-11 agree far below the errors the orders are judged on (≥ 1e-9)."""
    for frame in ("b/tip", "world"):
        assert np.max(np.abs(_reference(frame, rtol=1e-11) - _reference(frame))) < 1e-10


# ----------------------------------------------------------------------------- the table

#: Steps per order: errors well above round-off and in each method's asymptotic range.
FRAME_STEPS = {1: (0.02, 0.01, 0.005), 2: (0.04, 0.02, 0.01), 4: (0.1, 0.05, 0.025)}

PROBLEMS: dict[str, Problem] = {
    "torque-free top": Problem(_top_error, {1: (0.02, 0.01, 0.005, 0.0025), 2: (0.02, 0.01, 0.005, 0.0025),
                                            4: (0.4, 0.2, 0.1, 0.05)}, 0.3),
    "box pushed at its corner": Problem(_box_error, {1: BOX_STEPS, 2: BOX_STEPS, 4: BOX_STEPS}, 0.2),
    **{f"held wrench in {frame}": Problem(functools.partial(_held_wrench_error, frame), FRAME_STEPS, 0.2)
       for frame in FRAMES},
}


def _cases() -> list:
    return [pytest.param(integrator, problem, id=f"{integrator}-{problem.replace(' ', '_')}")
            for problem in PROBLEMS for integrator in FIXED_STEP_INTEGRATORS
            if not (problem == "torque-free top" and integrator in EXACT_FREE_ROTOR)]  # exact there: see above


@pytest.mark.parametrize(("integrator", "problem"), _cases())
def test_observed_order(integrator: str, problem: str) -> None:
    order = ORDER[integrator]
    spec = PROBLEMS[problem]
    h = np.array(spec.steps[order])
    errors = np.array([spec.error(integrator, step) for step in h])
    assert np.all(errors > ROUND_OFF_FLOOR), f"{integrator}, {problem}: errors {errors} reach round-off"
    slope = loglog_slope(h, errors)
    assert abs(slope - order) <= spec.tolerance, (
        f"{integrator} on the {problem}: observed order {slope:.3f}, claimed {order} "
        f"(h = {h.tolist()}, errors = {errors.tolist()})")
