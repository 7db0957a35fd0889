"""Newton–Euler equations of N free rigid bodies: the continuous dynamics, apart from stepping.

In the principal frame P (diagonal inertia I = (I1, I2, I3)):

    m · dv_W/dt      = F_W + m g_W − c_v v_W
    I · dw_P/dt      = τ_P − c_w w_P − w_P × (I w_P)        ← the gyroscopic term
    dp_W/dt          = v_W
    dq_WP/dt         = ½ q_WP ⊗ (0, w_P)                    (w, x, y, z)

``F_W`` and ``τ_W`` are the applied force and the torque about the centre of mass, world
axes; ``τ_P = R_WP^T τ_W``. The gyroscopic term is what makes a phone flip about its
intermediate axis; leaving it out is the classic textbook bug.
"""

from __future__ import annotations

import numpy as np

from .model import BodyModel, State
from .quaternion import cross3, quat_conjugate, quat_multiply, quat_rotate, quat_to_matrix

__all__ = [
    "gyroscopic_torque_P",
    "linear_acceleration_W",
    "angular_acceleration_P",
    "quaternion_rate",
    "derivatives",
    "kinetic_energy",
    "potential_energy",
    "linear_momentum_W",
    "angular_momentum_W",
]


def gyroscopic_torque_P(inertia_P: np.ndarray, w_WP_P: np.ndarray) -> np.ndarray:
    """The gyroscopic term ``−w × (I w)``, shape (N, 3), P axes, N·m."""
    return -cross3(w_WP_P, inertia_P * w_WP_P)


def linear_acceleration_W(model: BodyModel, v_WC_W: np.ndarray, force_W: np.ndarray) -> np.ndarray:
    """Centre-of-mass acceleration, world axes (m/s², shape (N, 3)): ``F/m + g − (c_v/m) v``."""
    inv_mass = (1.0 / model.mass)[:, None]
    return force_W * inv_mass + model.gravity_W - (model.damping_linear[:, None] * inv_mass) * v_WC_W


def angular_acceleration_P(model: BodyModel, w_WP_P: np.ndarray, torque_P: np.ndarray) -> np.ndarray:
    """Angular acceleration, P axes (rad/s², shape (N, 3)): ``I⁻¹(τ − c_w w − w × I w)``."""
    total = torque_P - model.damping_angular[:, None] * w_WP_P + gyroscopic_torque_P(model.inertia_P, w_WP_P)
    return total / model.inertia_P


def quaternion_rate(q_WP: np.ndarray, w_WP_P: np.ndarray) -> np.ndarray:
    """``dq/dt = ½ q ⊗ (0, w_P)`` for (w, x, y, z) quaternions, shape (N, 4)."""
    w_quat = np.concatenate((np.zeros(w_WP_P.shape[:-1] + (1,)), w_WP_P), axis=-1)
    return 0.5 * quat_multiply(q_WP, w_quat)


def torque_in_P(q_WP: np.ndarray, torque_W: np.ndarray) -> np.ndarray:
    """Rotate torques from world to P axes, using the normalised ``q_WP`` (shape (N, 4))."""
    q = q_WP / np.linalg.norm(q_WP, axis=-1, keepdims=True)
    return quat_rotate(quat_conjugate(q), torque_W)


def derivatives(model: BodyModel, state: State, force_W: np.ndarray, torque_W: np.ndarray) -> State:
    """Time derivative of ``state`` under applied force and torque (about the COM, world axes).

    Returns a :class:`State` whose fields hold dp/dt, dq/dt, dv/dt and dw/dt.
    """
    torque_P = torque_in_P(state.q_WP, torque_W)
    return State(
        state.v_WC_W,
        quaternion_rate(state.q_WP, state.w_WP_P),
        linear_acceleration_W(model, state.v_WC_W, force_W),
        angular_acceleration_P(model, state.w_WP_P, torque_P),
    )


def kinetic_energy(model: BodyModel, state: State) -> np.ndarray:
    """Kinetic energy per body, J, shape (N,): ½ m |v|² + ½ wᵀ I w."""
    translational = 0.5 * model.mass * np.sum(state.v_WC_W**2, axis=1)
    rotational = 0.5 * np.sum(model.inertia_P * state.w_WP_P**2, axis=1)
    return translational + rotational


def potential_energy(model: BodyModel, state: State) -> np.ndarray:
    """Gravitational potential energy per body, J, shape (N,): −m g·p (zero at the world origin)."""
    return -model.mass * (state.p_WC_W @ model.gravity_W)


def linear_momentum_W(model: BodyModel, state: State) -> np.ndarray:
    """Linear momentum per body, world axes, kg·m/s, shape (N, 3)."""
    return model.mass[:, None] * state.v_WC_W


def angular_momentum_W(model: BodyModel, state: State, about_origin: bool = False) -> np.ndarray:
    """Angular momentum per body, world axes, kg·m²/s, shape (N, 3).

    About the centre of mass (spin, ``R I w``) by default; with ``about_origin`` the orbital
    part ``p × m v`` about the world origin is added.
    """
    R_WP = quat_to_matrix(state.q_WP)
    spin = np.einsum("nij,nj->ni", R_WP, model.inertia_P * state.w_WP_P)
    if about_origin:
        return spin + np.cross(state.p_WC_W, linear_momentum_W(model, state))
    return spin
