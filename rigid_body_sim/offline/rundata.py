"""A finished run as arrays over time: what ``plot`` draws, read from a CSV file or a recording.

:class:`RunData` holds sample times and, per body, a :class:`BodyTrack` of its state in the
user's conventions (world frame, quaternions (x, y, z, w) of the body frame B). The energy,
|L| and body-axis angular velocity that a CSV file carries can be recomputed from the state
and the scene for a recording (:func:`with_derived_quantities`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..core import Scene
from ..core.quaternion import quat_conjugate, quat_rotate, quat_to_matrix, quat_wxyz_from_xyzw

__all__ = ["BodyTrack", "RunData", "with_derived_quantities", "angular_velocity_body", "MAX_RUN_FILE_BYTES"]

#: Largest CSV file or recording ``plot`` reads, bytes: what it reads is held in memory (about
#: a third of a CSV file's size as float64, more for a compressed recording), so a larger file,
#: a sparse one or a special file like /dev/zero is refused rather than read without end.
MAX_RUN_FILE_BYTES = 1 << 30


@dataclass(frozen=True)
class BodyTrack:
    """One body's state over T samples.

    Attributes
    ----------
    position_world : ndarray, shape (T, 3)
        Centre of mass, m, world frame.
    orientation_xyzw : ndarray, shape (T, 4)
        Orientation of the body frame B in the world (B → W), (x, y, z, w).
    linear_velocity_world : ndarray, shape (T, 3)
        m/s, world axes.
    angular_velocity_world : ndarray, shape (T, 3)
        rad/s, world axes.
    angular_velocity_body : ndarray, shape (T, 3)
        rad/s, B axes.
    energy : ndarray, shape (T,), or None
        Kinetic plus gravitational potential energy, J (None when unknown).
    angular_momentum_norm : ndarray, shape (T,), or None
        |L| about the centre of mass, kg·m²/s (None when unknown).
    """

    position_world: np.ndarray
    orientation_xyzw: np.ndarray
    linear_velocity_world: np.ndarray
    angular_velocity_world: np.ndarray
    angular_velocity_body: np.ndarray
    energy: np.ndarray | None = None
    angular_momentum_norm: np.ndarray | None = None


@dataclass(frozen=True)
class RunData:
    """Samples of a run.

    Attributes
    ----------
    time : ndarray, shape (T,)
        Sim time, s, increasing.
    bodies : dict of str to BodyTrack
    meta : dict of str to str
        What the file says about the run (``scene``, ``integrator``, ``dt``..., and ``status``:
        how it ended, e.g. ``complete: 10 steps, t = 0.1 s`` or ``interrupted by SIGTERM at ...``).
    source : str
        The file it was read from.
    """

    time: np.ndarray
    bodies: dict[str, BodyTrack]
    meta: dict[str, str] = field(default_factory=dict)
    source: str = ""


def angular_velocity_body(orientation_xyzw: np.ndarray, angular_velocity_world: np.ndarray) -> np.ndarray:
    """w_B = R_WBᵀ w_W, shape (T, 3) rad/s, from orientations (T, 4) (x, y, z, w) and world rates (T, 3)."""
    return quat_rotate(quat_conjugate(quat_wxyz_from_xyzw(orientation_xyzw)), angular_velocity_world)


def with_derived_quantities(data: RunData, scene: Scene) -> RunData:
    """``data`` with each body's energy and |L| filled in from ``scene``'s mass properties.

    E = ½ m |v|² + ½ w_Bᵀ I_B w_B − m g·p and |L| = |I_B w_B|, with I_B the inertia tensor in B
    axes. Bodies the scene does not have are left as they are.
    """
    model = scene.model
    bodies = dict(data.bodies)
    for name, track in data.bodies.items():
        if name not in model.names:
            continue
        b = model.names.index(name)
        R_BP = quat_to_matrix(model.q_BP[b])
        inertia_B = R_BP @ np.diag(model.inertia_P[b]) @ R_BP.T
        L_B = track.angular_velocity_body @ inertia_B.T
        energy = (0.5 * model.mass[b] * np.sum(track.linear_velocity_world**2, axis=1)
                  + 0.5 * np.sum(track.angular_velocity_body * L_B, axis=1)
                  - model.mass[b] * (track.position_world @ model.gravity_W))
        bodies[name] = replace(track, energy=energy, angular_momentum_norm=np.linalg.norm(L_B, axis=1))
    return replace(data, bodies=bodies)
