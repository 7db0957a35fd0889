"""Shared helpers of the core's physics tests: scenes built in code, random bodies, log-log fits.

Everything random here takes a seeded ``numpy.random.Generator`` from the caller, so every
test is reproducible. Quaternions are (w, x, y, z) unless a name says ``_xyzw``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rigid_body_sim.core import Scene, Simulator, load_scene
from rigid_body_sim.core.quaternion import quat_wxyz_from_xyzw, quat_xyzw_from_wxyz

#: The fixed-step integrators (``reference`` is adaptive and is tested on its own).
FIXED_STEP_INTEGRATORS = ("euler", "semi_implicit_euler", "implicit_gyroscopic", "splitting",
                          "symmetric_splitting", "exact_rotor_splitting", "rk4")

#: Observed convergence order each fixed-step method must show.
ORDER = {"euler": 1, "semi_implicit_euler": 1, "implicit_gyroscopic": 2, "splitting": 2,
         "symmetric_splitting": 2, "exact_rotor_splitting": 2, "rk4": 4}

#: Methods whose free rotor is the exact flow: torque-free, their only error is round-off
#: (their order shows with applied torques; test_stability.py).
EXACT_FREE_ROTOR = ("exact_rotor_splitting",)

#: Unit round-off of float64.
EPS = np.finfo(float).eps


def scene_of(bodies: dict[str, dict[str, Any]], gravity: Any = None) -> Scene:
    """A scene from a dict of body specs (the YAML schema, already parsed)."""
    data: dict[str, Any] = {"bodies": bodies}
    if gravity is not None:
        data["gravity"] = list(gravity)
    return load_scene(data)


def random_unit_quaternion(rng: np.random.Generator, size: int | None = None) -> np.ndarray:
    """Uniformly distributed unit quaternions (w, x, y, z), shape (4,) or (size, 4)."""
    q = rng.normal(size=(4,) if size is None else (size, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def random_principal_moments(rng: np.random.Generator, low: float = 0.5, high: float = 2.0) -> np.ndarray:
    """Three distinct principal moments (kg·m²) in [low, high) that satisfy the triangle inequality."""
    while True:
        moments = rng.uniform(low, high, 3)
        spread = np.diff(np.sort(moments))
        if moments.max() < moments.sum() - moments.max() and spread.min() > 0.05 * high:
            return moments


def random_rotation_matrix(rng: np.random.Generator) -> np.ndarray:
    """A uniformly distributed proper rotation matrix, shape (3, 3)."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(random_unit_quaternion(rng), scalar_first=True).as_matrix()


def random_tumbling_bodies(rng: np.random.Generator, count: int, spin_rate: float,
                           prefix: str = "b", mass: float = 1.0) -> dict[str, dict[str, Any]]:
    """``count`` torque-free bodies with random moments, orientation and velocity.

    Each body's angular velocity has magnitude ``spin_rate`` (rad/s) in a random direction;
    its linear velocity is random (m/s). Names are ``f"{prefix}{i}"``.
    """
    bodies = {}
    for i in range(count):
        w_W = rng.normal(size=3)
        w_W *= spin_rate / np.linalg.norm(w_W)
        bodies[f"{prefix}{i}"] = {
            "mass": mass,
            "inertia": {"principal": random_principal_moments(rng).tolist()},
            "pose": {
                "position": rng.normal(size=3).tolist(),
                "orientation": quat_xyzw_from_wxyz(random_unit_quaternion(rng)).tolist(),
            },
            "twist": {"linear": rng.normal(size=3).tolist(), "angular": w_W.tolist()},
        }
    return bodies


def orientations_wxyz(sim: Simulator) -> np.ndarray:
    """The body-frame orientations the simulator reports, converted to (w, x, y, z), (N, 4)."""
    return quat_wxyz_from_xyzw(sim.orientations_xyzw())


def loglog_slope(h: np.ndarray, error: np.ndarray) -> float:
    """Least-squares slope of log(error) against log(h): the observed order of convergence."""
    slope, _intercept = np.polyfit(np.log(np.asarray(h, dtype=float)), np.log(np.asarray(error, dtype=float)), 1)
    return float(slope)
