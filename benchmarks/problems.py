"""The three work-precision problems, their references and the error measures.

(a) ``top``: torque-free asymmetric top against the elliptic closed form
    (``closed_form.asymmetric_top``).
(b) ``forced``: Euler's equations ω' = (−2 ω2ω3, 1.25 ω3ω1, −0.5 ω1ω2) + (0, 0, 0.25 sin²t),
    ω0 = (1, 0, 0.9), t ∈ [0, 10] (Hairer, Nørsett & Wanner's rigid-body test). The
    coefficients (I2−I3)/I1 = −2, (I3−I1)/I2 = 1.25, (I1−I2)/I3 = −0.5 give I ∝ (1, 4, 6),
    which breaks the triangle inequality (1 + 4 < 6): no physical body has them, so the
    scene loader rejects them. The benchmark loads a valid body and swaps the moments into
    the model (``dataclasses.replace``) — a benchmark-only bypass of the loader's check.
    The forcing is a body-axes torque τ3 = I3·0.25 sin²t that the benchmark applies before
    every step; the simulator holds wrenches constant over a step (zero-order hold), so the
    benchmark samples the forcing at the step's midpoint t + h/2 (second-order accurate;
    a start-of-step sample would make every method first order). The reference is the
    continuous problem solved by scipy's DOP853 at rtol = atol = 1e-12 — the solver the
    ``reference`` integrator wraps — so the ZOH error is part of every method's error.
(c) ``box``: the 2 kg, 1.0 × 0.6 × 0.4 m box at rest, pushed by a body-fixed force
    F_B = (0, 10, 0) N at r_B = (0.5, 0.3, 0) m, against ``closed_form.box_body_fixed_force``
    over t ∈ [0, 1] s. The torque is constant in body axes, so the spin is reproduced
    exactly, but the force's world direction is held constant over each step (ZOH): the
    COM velocity error is first order in h for every integrator, by construction.

Orientation error is the geodesic angle 2·atan2(|vec(q_ref* ⊗ q)|, |w(q_ref* ⊗ q)|), rad.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.integrate import solve_ivp

from rigid_body_sim.core import closed_form, load_scene
from rigid_body_sim.core.quaternion import quat_conjugate, quat_multiply

# (a) torque-free asymmetric top
TOP_INERTIA = np.array([1.0, 2.0, 2.5])       # kg·m², principal, distinct, triangle-valid
TOP_W0_B = np.array([1.0, 0.3, 2.0])          # rad/s, body axes (not near the separatrix)
TOP_T = 10.0                                   # s
# (b) forced rigid body (HNW)
FORCED_INERTIA = np.array([1.0, 4.0, 6.0])    # kg·m², gives coefficients (−2, 1.25, −0.5)
FORCED_W0_B = np.array([1.0, 0.0, 0.9])       # rad/s
FORCED_T = 10.0                                # s
# (c) box with a body-fixed force
BOX_MASS = 2.0                                 # kg
BOX_SIDES = (1.0, 0.6, 0.4)                    # m
BOX_FORCE_B = np.array([0.0, 10.0, 0.0])       # N, body axes
BOX_POINT_B = np.array([0.5, 0.3, 0.0])        # m, body axes from the COM
BOX_T = 1.0                                    # s
CHECKPOINTS = 10                               # error = max over this many equally spaced times

PROBLEMS = ("top", "forced", "box")


def geodesic_angle(q_ref: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Angle (rad) of q_ref* ⊗ q; q_ref, q (w, x, y, z), shape (..., 4)."""
    d = quat_multiply(quat_conjugate(np.asarray(q_ref, float)), np.asarray(q, float))
    return 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))


def box_inertia() -> np.ndarray:
    a, b, c = BOX_SIDES
    return BOX_MASS / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def scene_dict(problem: str) -> dict:
    """The scene (as a dict for ``load_scene``) of a problem, body named ``b``."""
    if problem == "top":
        return {"bodies": {"b": {"mass": 1.0, "inertia": {"principal": TOP_INERTIA.tolist()},
                                 "twist": {"angular": TOP_W0_B.tolist()}}}}
    if problem == "forced":  # moments swapped in by scene() below
        return {"bodies": {"b": {"mass": 1.0, "inertia": {"principal": [4.0, 5.0, 6.0]},
                                 "twist": {"angular": FORCED_W0_B.tolist()}}}}
    if problem == "box":
        return {"bodies": {"b": {"mass": BOX_MASS, "inertia": {"box": list(BOX_SIDES)}}}}
    raise ValueError(f"`problem` must be one of {PROBLEMS}, got {problem!r}")


def scene(problem: str):
    s = load_scene(scene_dict(problem))
    if problem == "forced":
        model = dataclasses.replace(s.model, inertia_P=FORCED_INERTIA[None, :].copy())
        s = dataclasses.replace(s, model=model)
    return s


def horizon(problem: str) -> float:
    return {"top": TOP_T, "forced": FORCED_T, "box": BOX_T}[problem]


def forced_torque_B(t: float) -> np.ndarray:
    """Body-axes torque (N·m) of problem (b) at time t: (0, 0, I3·0.25 sin²t)."""
    return np.array([0.0, 0.0, FORCED_INERTIA[2] * 0.25 * np.sin(t) ** 2])


def _forced_rhs(t, y):
    w1, w2, w3 = y[4:]
    qw, qx, qy, qz = y[:4]
    dq = 0.5 * np.array([-qx * w1 - qy * w2 - qz * w3, qw * w1 + qy * w3 - qz * w2,
                         qw * w2 + qz * w1 - qx * w3, qw * w3 + qx * w2 - qy * w1])
    dw = np.array([-2.0 * w2 * w3, 1.25 * w3 * w1, -0.5 * w1 * w2 + 0.25 * np.sin(t) ** 2])
    return np.concatenate([dq, dw])


def reference(problem: str, times: np.ndarray) -> dict:
    """Reference orientation q_WB (T, 4) wxyz, w_B (T, 3) and, for ``box``, v_W (T, 3)."""
    times = np.asarray(times, float)
    if problem == "top":
        q, w = closed_form.asymmetric_top(TOP_INERTIA, TOP_W0_B, np.array([1.0, 0, 0, 0]), times)
        return {"q": q, "w": w}
    if problem == "forced":
        y0 = np.concatenate([[1.0, 0, 0, 0], FORCED_W0_B])
        sol = solve_ivp(_forced_rhs, (0.0, times[-1]), y0, method="DOP853", t_eval=times,
                        rtol=1e-12, atol=1e-12)
        q = sol.y[:4].T
        return {"q": q / np.linalg.norm(q, axis=1, keepdims=True), "w": sol.y[4:].T}
    if problem == "box":
        q, w, v, _p = closed_form.box_body_fixed_force(BOX_MASS, box_inertia()[2], BOX_FORCE_B,
                                                       BOX_POINT_B, times)
        return {"q": q, "w": w, "v": v}
    raise ValueError(f"`problem` must be one of {PROBLEMS}, got {problem!r}")


def invariants(problem: str, w_B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic energy and |L| of the rotation, shape (T,), for body rates w_B (T, 3)."""
    inertia = {"top": TOP_INERTIA, "forced": FORCED_INERTIA, "box": box_inertia()}[problem]
    energy = 0.5 * np.einsum("j,ij,ij->i", inertia, w_B, w_B)
    return energy, np.linalg.norm(inertia * w_B, axis=1)
