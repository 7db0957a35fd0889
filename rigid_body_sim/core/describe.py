"""What a scene holds, per body, in plain numbers: for ``rigid-body-sim describe`` and for tools.

:func:`describe_scene` turns a loaded :class:`~rigid_body_sim.core.scene.Scene` into one dict
per body (mass properties, principal axes and moments, initial state, motion, sites, wrench
frames, scripted wrenches), all SI, and names the model each body gets (model reduction,
reduction.py) and why, through :func:`body_model_kind`. Quaternions in the output are
(x, y, z, w); "B" is the body frame the scene declared, "P" the principal frame.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .mechanics import angular_momentum_W, kinetic_energy
from .quaternion import quat_conjugate, quat_multiply, quat_rotate, quat_to_matrix, quat_xyzw_from_wxyz
from .reduction import plan_models
from .scene import Scene

__all__ = ["body_model_kind", "describe_scene"]


def body_model_kind(scene: Scene, body: str, model_reduction: bool = True) -> str:
    """The model the simulator gives ``body`` in ``scene`` at the start, and why: ``"<model>: <reason>"``.

    The models are reduction.MODEL_NAMES' (full, static, kinematic, translation, planar,
    isotropic, symmetric); ``model_reduction=False`` is the switch of the Simulator.

    Raises
    ------
    ValueError
        For an unknown body (the bodies are listed).
    """
    if body not in scene.sites:
        raise ValueError(f"unknown body {body!r}; bodies are {list(scene.body_names)}")
    plan = plan_models(scene.model, model_reduction)[scene.body_names.index(body)]
    return f"{plan.model}: {plan.reason}"


def describe_scene(scene: Scene, model_reduction: bool = True) -> list[dict[str, Any]]:
    """One dict per body, in scene order: what the scene declares and what the simulator derives.

    Keys (all SI; lists, floats and strings only, so the result serialises to JSON as is):

    - ``name``, ``motion`` (the declared one), ``model`` (the model it gets: reduction.py),
      ``model_reason`` (why), ``mass`` (kg)
    - ``principal_moments`` (kg·m², [I1, I2, I3]), ``principal_axes_B`` (3 unit vectors, the
      principal axes expressed in B axes, one per moment), ``inertia_B`` (3×3 tensor about the
      centre of mass in B axes, kg·m²)
    - ``position_world`` (m), ``orientation_xyzw`` (B → world), ``linear_velocity_world`` (m/s),
      ``angular_velocity_world`` and ``angular_velocity_body`` (rad/s): the initial state
    - ``kinetic_energy`` (J) and ``angular_momentum_norm`` (|L| about the centre of mass,
      kg·m²/s), both initial
    - ``damping``: ``{"linear": N·s/m, "angular": N·m·s/rad}``
    - ``sites``: ``[{"name", "position_B" (m, from the centre of mass, B axes), "axes", "imu"}]``,
      ``imu`` None or the site's IMU (core/imu_spec.py: ``rate``, ``seed``, ``orientation``,
      ``accelerometer`` and ``gyroscope`` as ``{"noise_density", "bias", "bias_random_walk"}`` or None)
    - ``frames``: every frame a wrench on the body may name
    - ``scripted_wrenches``: ``[{"frame", "force", "torque", "start", "duration"}]`` (duration
      ``None`` = forever)
    """
    model, state = scene.model, scene.initial_state
    plans = plan_models(model, model_reduction)
    energy = kinetic_energy(model, state)
    momentum = angular_momentum_W(model, state)
    out = []
    for b, name in enumerate(model.names):
        q_BP = model.q_BP[b]
        R_BP = quat_to_matrix(q_BP)
        q_WB = quat_multiply(state.q_WP[b], quat_conjugate(q_BP))
        w_P = state.w_WP_P[b]
        sites = []
        for s, site_name in enumerate(model.site_names):
            if model.site_body[s] != b:
                continue
            sites.append({
                "name": site_name.split("/", 1)[1],
                "position_B": _floats(quat_rotate(q_BP, model.site_p_P[s])),
                "axes": "world" if model.site_world_axes[s] else "body",
                "imu": _imu(scene.imus.get(site_name)),
            })
        out.append({
            "name": name,
            "motion": plans[b].motion,
            "model": plans[b].model,
            "model_reason": plans[b].reason,
            "mass": float(model.mass[b]),
            "principal_moments": _floats(model.inertia_P[b]),
            "principal_axes_B": [_floats(R_BP[:, k]) for k in range(3)],
            "inertia_B": [_floats(row) for row in R_BP @ np.diag(model.inertia_P[b]) @ R_BP.T],
            "position_world": _floats(state.p_WC_W[b]),
            "orientation_xyzw": _floats(quat_xyzw_from_wxyz(q_WB)),
            "linear_velocity_world": _floats(state.v_WC_W[b]),
            "angular_velocity_world": _floats(quat_rotate(state.q_WP[b], w_P)),
            "angular_velocity_body": _floats(quat_rotate(q_BP, w_P)),
            "kinetic_energy": float(energy[b]),
            "angular_momentum_norm": float(np.linalg.norm(momentum[b])),
            "damping": {"linear": float(model.damping_linear[b]), "angular": float(model.damping_angular[b])},
            "sites": sites,
            "frames": list(scene.frames_of(name)),
            "scripted_wrenches": [
                {"frame": w.frame, "force": _floats(w.force), "torque": _floats(w.torque), "start": w.start,
                 "duration": None if math.isinf(w.duration) else w.duration}
                for w in scene.wrenches if w.body == name
            ],
        })
    return out


def _imu(spec: Any) -> dict | None:
    """A site's IMU spec as plain data (None without one)."""
    if spec is None:
        return None
    channels = {key: None if c is None else {"noise_density": c.noise_density, "bias": list(c.bias),
                                             "bias_random_walk": c.bias_random_walk}
                for key, c in (("accelerometer", spec.accelerometer), ("gyroscope", spec.gyroscope))}
    return {"rate": spec.rate, "seed": spec.seed, "orientation": spec.orientation, **channels}


def _floats(values: np.ndarray) -> list[float]:
    return [float(v) for v in values]
