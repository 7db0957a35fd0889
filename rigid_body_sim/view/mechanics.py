"""The numbers the view plots: total energy, |L| and a body's speed, from the published state.

The node publishes poses (``poses``) and velocities (``velocities``, world axes) but not the
bodies' mass and inertia; the view reads those from the scene file the node's ``scene`` parameter
names (same host, or a shared path). Per body b, with R_WP = R(q_WB ⊗ q_BP) and the principal
moments I_P: kinetic energy ½ m |v|² + ½ ωᵀ R I_P Rᵀ ω, potential −m g·p (zero at the world
origin, as the core's), angular momentum about the world origin R I_P Rᵀ ω + p × m v. The plots
show the sums over the bodies (J, kg·m²/s) and one body's |v| (m/s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MassModel", "totals", "mass_model_from_scene"]


@dataclass(frozen=True)
class MassModel:
    names: tuple[str, ...]
    mass: np.ndarray  # (N,) kg
    inertia_P: np.ndarray  # (N, 3) principal moments, kg·m²
    q_BP_wxyz: np.ndarray  # (N, 4) principal axes P in the body frame B
    gravity_W: np.ndarray  # (3,) m/s²


def mass_model_from_scene(scene) -> MassModel:
    m = scene.model
    return MassModel(tuple(scene.body_names), np.asarray(m.mass, dtype=float), np.asarray(m.inertia_P, dtype=float),
                     np.asarray(m.q_BP, dtype=float), np.asarray(m.gravity_W, dtype=float))


def _quat_mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack((pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw), axis=-1)


def _matrices(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack((np.stack((1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)), -1),
                     np.stack((2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)), -1),
                     np.stack((2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)), -1)), -2)


def totals(model: MassModel, p_W: np.ndarray, q_WB_xyzw: np.ndarray, v_W: np.ndarray, w_W: np.ndarray
           ) -> tuple[float, float]:
    """(total energy J, |total angular momentum about the world origin| kg·m²/s) of N bodies:
    positions (N, 3), orientations (N, 4) x, y, z, w, velocities (N, 3) and angular velocities
    (N, 3), world axes, in the order of ``model.names``."""
    q_WB = np.concatenate((q_WB_xyzw[:, 3:], q_WB_xyzw[:, :3]), axis=1)
    R = _matrices(_quat_mul(q_WB, model.q_BP_wxyz))  # R_WP, (N, 3, 3)
    w_P = np.einsum("nji,nj->ni", R, w_W)
    kinetic = 0.5 * model.mass * np.sum(v_W ** 2, axis=1) + 0.5 * np.sum(model.inertia_P * w_P ** 2, axis=1)
    potential = -model.mass * (p_W @ model.gravity_W)
    spin = np.einsum("nij,nj->ni", R, model.inertia_P * w_P)
    L = spin.sum(axis=0) + np.cross(p_W, model.mass[:, None] * v_W).sum(axis=0)
    return float(np.sum(kinetic + potential)), float(np.linalg.norm(L))
