"""Unit quaternions for rotations, in the one internal order of this package: (w, x, y, z).

Every quaternion inside ``rigid_body_sim.core`` is scalar-first, ``q = w + x i + y j + z k``,
with the Hamilton product (i·j = k) and the active, body-to-world convention:
``v_world = q ⊗ (0, v_body) ⊗ q*``. ROS messages and scene files use (x, y, z, w); the only
place the two orders meet is :func:`quat_wxyz_from_xyzw` and :func:`quat_xyzw_from_wxyz`.

All functions broadcast over leading dimensions: a quaternion array has shape (..., 4), a
vector array shape (..., 3).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "quat_wxyz_from_xyzw",
    "quat_xyzw_from_wxyz",
    "quat_multiply",
    "quat_conjugate",
    "quat_rotate",
    "quat_to_matrix",
    "quat_from_matrix",
    "quat_from_rotation_vector",
    "quat_to_rotation_vector",
    "quat_angle_between",
    "IDENTITY_WXYZ",
    "cross3",
]

IDENTITY_WXYZ = np.array([1.0, 0.0, 0.0, 0.0])


def quat_wxyz_from_xyzw(q_xyzw: np.ndarray) -> np.ndarray:
    """Reorder quaternions from (x, y, z, w) (ROS, scene files) to internal (w, x, y, z).

    Parameters
    ----------
    q_xyzw : array-like, shape (..., 4)
        Scalar-last quaternions.

    Returns
    -------
    ndarray, shape (..., 4)
        The same quaternions, scalar-first.
    """
    q = np.asarray(q_xyzw, dtype=float)
    return q[..., [3, 0, 1, 2]]


def quat_xyzw_from_wxyz(q_wxyz: np.ndarray) -> np.ndarray:
    """Reorder quaternions from internal (w, x, y, z) to (x, y, z, w) (ROS, scene files).

    Parameters
    ----------
    q_wxyz : array-like, shape (..., 4)
        Scalar-first quaternions.

    Returns
    -------
    ndarray, shape (..., 4)
        The same quaternions, scalar-last.
    """
    q = np.asarray(q_wxyz, dtype=float)
    return q[..., [1, 2, 3, 0]]


def cross3(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Cross products ``u × v`` of vectors, shapes (..., 3) → (..., 3).

    The same arithmetic as ``np.cross`` (bitwise equal results) without its axis handling,
    which costs more than the product itself on the small arrays of a step.
    """
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    u0, u1, u2 = u[..., 0], u[..., 1], u[..., 2]
    v0, v1, v2 = v[..., 0], v[..., 1], v[..., 2]
    return np.stack((u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0), axis=-1)


def quat_multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` of (w, x, y, z) quaternions, shapes (..., 4) → (..., 4).

    Composition of rotations: ``q_AC = quat_multiply(q_AB, q_BC)``.
    """
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        (
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ),
        axis=-1,
    )


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate (the inverse, for unit quaternions) of (w, x, y, z) quaternions, (..., 4)."""
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_rotate(q_AB: np.ndarray, v_B: np.ndarray) -> np.ndarray:
    """Rotate vectors: ``v_A = R(q_AB) v_B``.

    Parameters
    ----------
    q_AB : array-like, shape (..., 4)
        Unit quaternions (w, x, y, z) taking frame B's axes to frame A's.
    v_B : array-like, shape (..., 3)
        Vectors expressed in B.

    Returns
    -------
    ndarray, shape (..., 3)
        The vectors expressed in A.
    """
    q = np.asarray(q_AB, dtype=float)
    v = np.asarray(v_B, dtype=float)
    w = q[..., :1]
    u = q[..., 1:]
    # v' = v + 2 w (u × v) + 2 u × (u × v), valid for unit q.
    t = 2.0 * cross3(u, v)
    return v + w * t + cross3(u, t)


def quat_to_matrix(q_AB: np.ndarray) -> np.ndarray:
    """Rotation matrices R_AB from unit (w, x, y, z) quaternions, (..., 4) → (..., 3, 3)."""
    q = np.asarray(q_AB, dtype=float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(np.shape(w) + (3, 3))
    R[..., 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    R[..., 0, 1] = 2.0 * (x * y - w * z)
    R[..., 0, 2] = 2.0 * (x * z + w * y)
    R[..., 1, 0] = 2.0 * (x * y + w * z)
    R[..., 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    R[..., 1, 2] = 2.0 * (y * z - w * x)
    R[..., 2, 0] = 2.0 * (x * z - w * y)
    R[..., 2, 1] = 2.0 * (y * z + w * x)
    R[..., 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return R


def quat_from_matrix(R_AB: np.ndarray) -> np.ndarray:
    """Unit (w, x, y, z) quaternions with w ≥ 0 from rotation matrices, (..., 3, 3) → (..., 4).

    Uses scipy's robust (Shepperd-type) conversion; only the order is changed here.
    """
    from scipy.spatial.transform import Rotation

    R = np.asarray(R_AB, dtype=float)
    q_xyzw = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat(canonical=True)
    return quat_wxyz_from_xyzw(q_xyzw).reshape(R.shape[:-2] + (4,))


def quat_from_rotation_vector(rotvec: np.ndarray) -> np.ndarray:
    """Exponential map: rotation vectors θ·axis (rad) to unit (w, x, y, z) quaternions.

    ``q = (cos(θ/2), sin(θ/2) axis)``, computed with a series for small θ so that the result
    is unit to round-off at every angle, including 0.

    Parameters
    ----------
    rotvec : array-like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 4)
    """
    rv = np.asarray(rotvec, dtype=float)
    theta = np.sqrt(np.sum(rv * rv, axis=-1))
    half = 0.5 * theta
    small = theta < 1e-4
    # sin(θ/2)/θ, with its Taylor series where θ is small (error < 1e-18 there).
    safe_theta = np.where(small, 1.0, theta)
    scale = np.where(small, 0.5 - theta * theta / 48.0, np.sin(half) / safe_theta)
    out = np.empty(rv.shape[:-1] + (4,))
    out[..., 0] = np.cos(half)
    out[..., 1:] = rv * scale[..., None]
    return out


def quat_to_rotation_vector(q: np.ndarray) -> np.ndarray:
    """Logarithm map: unit (w, x, y, z) quaternions to rotation vectors with angle in [0, π].

    Parameters
    ----------
    q : array-like, shape (..., 4)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., :1] < 0.0, -q, q)
    w = q[..., 0]
    u = q[..., 1:]
    s = np.sqrt(np.sum(u * u, axis=-1))
    angle = 2.0 * np.arctan2(s, w)
    small = s < 1e-12
    scale = np.where(small, 2.0, angle / np.where(small, 1.0, s))
    return u * scale[..., None]


def quat_angle_between(q_a: np.ndarray, q_b: np.ndarray) -> np.ndarray:
    """Geodesic angle (rad, in [0, π]) between rotations: ``2·atan2(|vec(a* ⊗ b)|, |w(a* ⊗ b)|)``.

    Parameters
    ----------
    q_a, q_b : array-like, shape (..., 4)
        Unit (w, x, y, z) quaternions.

    Returns
    -------
    ndarray, shape (...)
    """
    d = quat_multiply(quat_conjugate(q_a), q_b)
    return 2.0 * np.arctan2(np.sqrt(np.sum(d[..., 1:] ** 2, axis=-1)), np.abs(d[..., 0]))
