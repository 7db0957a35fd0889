"""Mass properties of rigid bodies: inertia from shapes, principal moments or a full tensor.

Every body is simulated in its *principal* frame P (origin at the centre of mass, axes along
the principal axes of inertia), so the inertia is the diagonal (I1, I2, I3). The user's body
frame B (origin also at the centre of mass) may differ from P by a fixed rotation ``q_BP``
when the inertia is given as a full tensor; for every diagonal input (box, sphere, cylinder,
principal moments, a diagonal tensor) ``q_BP`` is exactly the identity, so no round-off enters.
Quaternions are (w, x, y, z).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .quaternion import IDENTITY_WXYZ, quat_from_matrix

__all__ = [
    "MassProperties",
    "box_inertia",
    "sphere_inertia",
    "cylinder_inertia",
    "principal_frame",
    "check_principal_moments",
    "TRIANGLE_RTOL",
]

#: Relative tolerance of the triangle inequality I1 + I2 ≥ I3 (a flat plate sits on it exactly).
TRIANGLE_RTOL = 1e-9


@dataclass(frozen=True)
class MassProperties:
    """Mass (kg), principal moments (kg·m², shape (3,)) and ``q_BP`` (w, x, y, z), body→principal."""

    mass: float
    principal_moments: np.ndarray
    q_BP: np.ndarray


def box_inertia(mass: float, size: np.ndarray) -> np.ndarray:
    """Principal moments (kg·m², shape (3,)) of a uniform box with edge lengths ``size`` (m), about its centre."""
    a, b, c = np.asarray(size, dtype=float)
    return mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def sphere_inertia(mass: float, radius: float) -> np.ndarray:
    """Principal moments (kg·m², shape (3,)) of a uniform solid sphere of ``radius`` (m)."""
    return np.full(3, 0.4 * mass * radius * radius)


def cylinder_inertia(mass: float, radius: float, length: float) -> np.ndarray:
    """Principal moments (kg·m², shape (3,)) of a uniform solid cylinder whose axis is body z."""
    transverse = mass * (3.0 * radius * radius + length * length) / 12.0
    return np.array([transverse, transverse, 0.5 * mass * radius * radius])


def check_principal_moments(moments: np.ndarray) -> str | None:
    """Return why ``moments`` (shape (3,)) cannot be a rigid body's principal moments, or None.

    Requires finite values > 0 and the triangle inequality I_i + I_j ≥ I_k for every k, within
    a relative tolerance of :data:`TRIANGLE_RTOL` (a flat plate meets it with equality).
    """
    m = np.asarray(moments, dtype=float)
    if m.shape != (3,) or not np.all(np.isfinite(m)):
        return f"3 finite numbers, got {m.tolist()}"
    if np.any(m <= 0.0):
        return f"principal moments > 0, got {m.tolist()}"
    total = float(m.sum())
    for k in range(3):
        if total - m[k] < m[k] * (1.0 - TRIANGLE_RTOL):
            i, j = [n for n in range(3) if n != k]
            return (
                f"principal moments satisfying the triangle inequality I{i + 1} + I{j + 1} ≥ "
                f"I{k + 1}, got {m.tolist()} ({m[i] + m[j]:.6g} < {m[k]:.6g})"
            )
    return None


def principal_frame(tensor_B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Diagonalise a symmetric inertia tensor given in the body frame B.

    Parameters
    ----------
    tensor_B : array-like, shape (3, 3)
        Symmetric inertia tensor about the centre of mass, B axes (kg·m²). Assumed validated.

    Returns
    -------
    moments : ndarray, shape (3,)
        Principal moments (kg·m²).
    q_BP : ndarray, shape (4,)
        (w, x, y, z) rotation from the principal frame P to B (``v_B = R(q_BP) v_P``).
        Exactly the identity when ``tensor_B`` is already diagonal.
    """
    tensor = np.asarray(tensor_B, dtype=float)
    off_diagonal = tensor - np.diag(np.diag(tensor))
    if not np.any(off_diagonal):
        return np.diag(tensor).copy(), IDENTITY_WXYZ.copy()
    moments, R_BP = np.linalg.eigh(0.5 * (tensor + tensor.T))
    if np.linalg.det(R_BP) < 0.0:
        R_BP[:, 2] = -R_BP[:, 2]
    return moments, quat_from_matrix(R_BP)
