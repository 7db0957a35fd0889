"""Energy and momentum of every body of a state (numpy): the read-outs of the Simulator and of describe.

The equations of motion themselves are compiled, in kernels/dynamics.py. Same conventions:
principal frame P, inertia I = (I1, I2, I3), q_WP (w, x, y, z), SI units.
"""

from __future__ import annotations

import numpy as np

from .model import BodyModel, State
from .quaternion import quat_to_matrix

__all__ = ["kinetic_energy", "potential_energy", "linear_momentum_W", "angular_momentum_W"]


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
