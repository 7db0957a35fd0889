"""Exact motions of a scene's bodies where one exists, to plot a run's error against.

A body's rotation has a closed form when nothing exerts a torque on it about its centre of
mass: no angular damping and no scripted wrench (uniform gravity exerts none). It is then the
torque-free top of :mod:`rigid_body_sim.exact.closed_form`: symmetric (two equal principal
moments, or a sphere) or asymmetric (Jacobi elliptic functions). Its translation has one when
no force acts but gravity: no linear damping and no scripted wrench (a projectile). A body the
ground can touch (a collision shape in a scene with ``ground``) has neither: contact exerts
force and torque. Runs start at t = 0 from the scene's initial state, so the references do too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import Scene
from ..exact.closed_form import (
    EQUAL_MOMENTS_RTOL,
    asymmetric_top,
    intermediate_axis_flip_period,
    projectile,
    symmetric_top,
)
from ..core.quaternion import quat_conjugate, quat_multiply, quat_rotate, quat_xyzw_from_wxyz

__all__ = ["Reference", "closed_form_reference"]


@dataclass(frozen=True)
class Reference:
    """The exact motion of one body at the times asked for (None where there is no closed form).

    Attributes
    ----------
    orientation_xyzw : ndarray, shape (T, 4), or None
        Orientation of the body frame B in the world, (x, y, z, w).
    angular_velocity_body : ndarray, shape (T, 3), or None
        rad/s, B axes.
    position_world, linear_velocity_world : ndarray, shape (T, 3), or None
        m and m/s, world.
    rotation : str
        Which closed form the rotation follows, or why there is none.
    translation : str
        The same for the translation.
    flip_period : float or None
        For three distinct moments: time between sign changes of the rate about the
        intermediate axis, s (the "tennis racket" flip when spun near that axis).
    """

    orientation_xyzw: np.ndarray | None
    angular_velocity_body: np.ndarray | None
    position_world: np.ndarray | None
    linear_velocity_world: np.ndarray | None
    rotation: str
    translation: str
    flip_period: float | None = None


def closed_form_reference(scene: Scene, body: str, t: np.ndarray) -> Reference:
    """The closed-form motion of ``body`` from the scene's initial state, at times ``t`` (s, shape (T,)).

    Raises
    ------
    ValueError
        For an unknown body.
    """
    model, state = scene.model, scene.initial_state
    if body not in model.names:
        raise ValueError(f"unknown body {body!r}; bodies are {list(model.names)}")
    b = model.names.index(body)
    t = np.asarray(t, dtype=float)
    scripted = any(w.body == body for w in scene.wrenches)
    touches = scene.contact is not None and b in np.asarray(scene.contact.bodies).tolist()

    q_WB = w_B = None
    flip_period = None
    inertia = model.inertia_P[b]
    if touches:
        rotation = "none: ground contact"
    elif scripted:
        rotation = "none: scripted wrenches act on it"
    elif model.damping_angular[b] > 0.0:
        rotation = "none: angular damping"
    else:
        w_P0 = state.w_WP_P[b]
        equal = any(abs(inertia[j] - inertia[k]) <= EQUAL_MOMENTS_RTOL * max(inertia[j], inertia[k])
                    for j, k in ((0, 1), (0, 2), (1, 2)))
        try:
            if equal:
                q_WP, w_P = symmetric_top(inertia, w_P0, state.q_WP[b], t)
                rotation = "torque-free symmetric top (closed form)"
            else:
                q_WP, w_P = asymmetric_top(inertia, w_P0, state.q_WP[b], t)
                rotation = "torque-free asymmetric top (Jacobi elliptic functions)"
                if np.any(w_P0):
                    flip_period = intermediate_axis_flip_period(inertia, w_P0)
        except ValueError as exc:  # e.g. exactly on the separatrix
            rotation = f"none: {exc}"
        else:
            q_BP = model.q_BP[b]
            q_WB = quat_xyzw_from_wxyz(quat_multiply(q_WP, quat_conjugate(q_BP)))
            w_B = quat_rotate(q_BP, w_P)

    p_W = v_W = None
    if touches:
        translation = "none: ground contact"
    elif scripted:
        translation = "none: scripted wrenches act on it"
    elif model.damping_linear[b] > 0.0:
        translation = "none: linear damping"
    else:
        p_W, v_W = projectile(state.p_WC_W[b], state.v_WC_W[b], model.gravity_W, t)
        translation = "free flight under uniform gravity" if model.has_gravity else "uniform motion"
    return Reference(q_WB, w_B, p_W, v_W, rotation, translation, flip_period)
