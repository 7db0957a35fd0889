"""The two work-precision problems, their exact references and the error measures.

``top``: the torque-free asymmetric top, I = (1, 2, 2.5) kg·m², ω0 = (1, 0.3, 2) rad/s (body
    axes; not near the separatrix), t ∈ [0, 10] s, against the elliptic closed form
    (``closed_form.asymmetric_top``). Error: orientation (geodesic angle, rad).
``box``: the 2 kg, 1.0 × 0.6 × 0.4 m box at rest, pushed by 10 N along its own y at the corner
    site (0.5, 0.3, 0) m — a force fixed in the body — t ∈ [0, 1] s, against the Fresnel
    closed form (``closed_form.box_body_fixed_force``). Error: centre-of-mass position (m).
    Ours: the site ``b/corner`` and ``apply_force_at_point(..., frame="b/corner")`` held over
    each ``step(n)``; MuJoCo: a motor on a site at the same corner, ``d.ctrl[0] = 10``.

Errors are maxima over 10 equally spaced times (the checkpoints). The orientation error is the
geodesic angle 2·atan2(|vec(q_ref* ⊗ q)|, |w(q_ref* ⊗ q)|).

(The earlier third problem, Hairer–Nørsett–Wanner's forced rigid body, had a torque given as
a function of time, sampled from Python once per step: it measured the zero-order hold of that
sampling, the same for every method, not the integrators; it is gone.)
"""

from __future__ import annotations

import numpy as np

from rigid_body_sim.core import load_scene
from rigid_body_sim.exact import closed_form
from rigid_body_sim.core.quaternion import quat_conjugate, quat_multiply

# top
TOP_INERTIA = np.array([1.0, 2.0, 2.5])       # kg·m², principal, distinct, triangle-valid
TOP_W0_B = np.array([1.0, 0.3, 2.0])          # rad/s, body axes
TOP_T = 10.0                                   # s
# box with a body-fixed force at a site
BOX_MASS = 2.0                                 # kg
BOX_SIDES = (1.0, 0.6, 0.4)                    # m
BOX_FORCE_S = np.array([0.0, 10.0, 0.0])       # N, site axes = body axes
BOX_SITE_B = np.array([0.5, 0.3, 0.0])         # m, body axes from the COM
BOX_T = 1.0                                    # s
CHECKPOINTS = 10

PROBLEMS = ("top", "box")
#: The error each problem is judged by: (row key, label with unit).
ERROR_KEY = {"top": ("err_angle", "max orientation error (rad)"), "box": ("err_p", "max COM position error (m)")}


def geodesic_angle(q_ref: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Angle (rad) of q_ref* ⊗ q; q_ref, q (w, x, y, z), shape (..., 4)."""
    d = quat_multiply(quat_conjugate(np.asarray(q_ref, float)), np.asarray(q, float))
    return 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))


def box_inertia() -> np.ndarray:
    a, b, c = BOX_SIDES
    return BOX_MASS / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def inertia(problem: str) -> np.ndarray:
    return {"top": TOP_INERTIA, "box": box_inertia()}[problem]


def mass(problem: str) -> float:
    return {"top": 1.0, "box": BOX_MASS}[problem]


def horizon(problem: str) -> float:
    return {"top": TOP_T, "box": BOX_T}[problem]


def scene(problem: str):
    """The problem's scene, one body ``b`` (``box``: with the site ``corner``)."""
    if problem == "top":
        return load_scene({"bodies": {"b": {"mass": 1.0, "inertia": {"principal": TOP_INERTIA.tolist()},
                                            "twist": {"angular": TOP_W0_B.tolist()}}}})
    if problem == "box":
        return load_scene({"bodies": {"b": {"mass": BOX_MASS, "inertia": {"box": list(BOX_SIDES)},
                                            "sites": {"corner": {"position": BOX_SITE_B.tolist()}}}}})
    raise ValueError(f"`problem` must be one of {PROBLEMS}, got {problem!r}")


def reference(problem: str, times: np.ndarray) -> dict[str, np.ndarray]:
    """Exact q_WB (T, 4) (w, x, y, z), w_B (T, 3) and, for ``box``, v_W and p_W (T, 3)."""
    times = np.asarray(times, float)
    if problem == "top":
        q, w = closed_form.asymmetric_top(TOP_INERTIA, TOP_W0_B, np.array([1.0, 0, 0, 0]), times)
        return {"q": q, "w": w}
    if problem == "box":
        q, w, v, p = closed_form.box_body_fixed_force(BOX_MASS, box_inertia()[2], BOX_FORCE_S, BOX_SITE_B, times)
        return {"q": q, "w": w, "v": v, "p": p}
    raise ValueError(f"`problem` must be one of {PROBLEMS}, got {problem!r}")


def errors(problem: str, times: np.ndarray, q: np.ndarray, w_B: np.ndarray, p_W: np.ndarray) -> dict[str, float]:
    """Max over the checkpoints: orientation (rad), relative ω, energy and |L| errors; COM position (m)."""
    ref = reference(problem, times)
    I = inertia(problem)
    energy = 0.5 * np.einsum("j,ij,ij->i", I, w_B, w_B)
    energy_ref = 0.5 * np.einsum("j,ij,ij->i", I, ref["w"], ref["w"])
    L, L_ref = np.linalg.norm(I * w_B, axis=1), np.linalg.norm(I * ref["w"], axis=1)
    out = {"err_angle": float(np.max(geodesic_angle(ref["q"], q))),
           "err_w": float(np.max(np.linalg.norm(w_B - ref["w"], axis=1)) / np.max(np.linalg.norm(ref["w"], axis=1))),
           "err_energy": float(np.max(np.abs(energy - energy_ref) / energy_ref)),
           "err_L": float(np.max(np.abs(L - L_ref) / L_ref)),
           "err_p": float(np.max(np.linalg.norm(p_W - ref["p"], axis=1))) if "p" in ref else float("nan")}
    return out
