"""The read-only model of N bodies and the mutable state they are integrated in.

MuJoCo's split: :class:`BodyModel` holds what a scene declares and never changes while
stepping (masses, principal moments, damping, gravity, sites); :class:`State` holds what the
integrators advance. Both are plain arrays over bodies, so every pass is vectorised.

Frames: W is the world frame; P is a body's principal frame (origin at the centre of mass,
axes along the principal axes); B is the body frame the user declared (origin at the centre
of mass, ``q_BP`` away from P). Quaternions are (w, x, y, z).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

__all__ = ["BodyModel", "State", "MOTIONS"]

#: The motions a body may be given (scene key ``motion``; reduction.py):
#: ``free`` (six degrees of freedom), ``static`` (never moves), ``kinematic`` (moves at its
#: constant initial twist, deaf to wrenches), ``planar`` (x, y and yaw in a plane),
#: ``rotation_only`` (the centre of mass stays put), ``translation_only`` (orientation fixed).
MOTIONS = ("free", "static", "kinematic", "planar", "rotation_only", "translation_only")


@dataclass(frozen=True)
class BodyModel:
    """Constant description of N bodies (arrays are not to be modified).

    Attributes
    ----------
    names : tuple of str, length N
    mass : ndarray, shape (N,)
        kg.
    inertia_P : ndarray, shape (N, 3)
        Principal moments (I1, I2, I3) in kg·m², in P axes.
    q_BP : ndarray, shape (N, 4)
        (w, x, y, z) rotation from P to the user's body frame B.
    damping_linear : ndarray, shape (N,)
        c_v in N·s/m: force ``-c_v v_W``.
    damping_angular : ndarray, shape (N,)
        c_w in N·m·s/rad: torque ``-c_w w_WP_P``.
    gravity_W : ndarray, shape (3,)
        m/s², world axes (zeros when the scene has none).
    site_names : tuple of str, length S
        ``"<body>/<site>"``.
    site_body : ndarray of int, shape (S,)
        Index of the body each site belongs to.
    site_p_P : ndarray, shape (S, 3)
        Site position from the centre of mass, P axes (m).
    site_world_axes : ndarray of bool, shape (S,)
        True where the site's axes are world-aligned rather than body-fixed.
    motion : tuple of str, length N (or empty: every body ``free``)
        The motion each body is allowed (:data:`MOTIONS`; scene key ``motion``).
    plane_normal_W : ndarray, shape (N, 3) (or empty)
        Unit normal of the plane of a ``planar`` body, world axes (zeros for the others).
    """

    names: tuple[str, ...]
    mass: np.ndarray
    inertia_P: np.ndarray
    q_BP: np.ndarray
    damping_linear: np.ndarray
    damping_angular: np.ndarray
    gravity_W: np.ndarray
    site_names: tuple[str, ...] = ()
    site_body: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    site_p_P: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    site_world_axes: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    motion: tuple[str, ...] = ()
    plane_normal_W: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def motions(self) -> tuple[str, ...]:
        """The motion of every body (``free`` where the model declares none), length N."""
        return self.motion if self.motion else ("free",) * self.count

    @property
    def plane_normals_W(self) -> np.ndarray:
        """(N, 3) plane normals (zeros for bodies that are not planar)."""
        return self.plane_normal_W if len(self.plane_normal_W) else np.zeros((self.count, 3))

    @property
    def count(self) -> int:
        """Number of bodies N."""
        return len(self.names)

    @property
    def has_gravity(self) -> bool:
        return bool(np.any(self.gravity_W))

    @property
    def has_damping(self) -> bool:
        return bool(np.any(self.damping_linear) or np.any(self.damping_angular))

    def subset(self, indices: np.ndarray) -> "BodyModel":
        """The model of the bodies at ``indices`` (sites are dropped: integrators never use them)."""
        idx = np.asarray(indices, dtype=int)
        return replace(
            self,
            names=tuple(self.names[i] for i in idx),
            mass=self.mass[idx],
            inertia_P=self.inertia_P[idx],
            q_BP=self.q_BP[idx],
            damping_linear=self.damping_linear[idx],
            damping_angular=self.damping_angular[idx],
            motion=tuple(self.motions[i] for i in idx),
            plane_normal_W=self.plane_normals_W[idx],
            site_names=(),
            site_body=np.zeros(0, dtype=int),
            site_p_P=np.zeros((0, 3)),
            site_world_axes=np.zeros(0, dtype=bool),
        )


@dataclass(frozen=True)
class State:
    """Integrated state of N bodies.

    Attributes
    ----------
    p_WC_W : ndarray, shape (N, 3)
        Centre-of-mass position in the world, m.
    q_WP : ndarray, shape (N, 4)
        Unit quaternion (w, x, y, z) of the principal frame P in the world (P → W).
    v_WC_W : ndarray, shape (N, 3)
        Centre-of-mass velocity, world axes, m/s.
    w_WP_P : ndarray, shape (N, 3)
        Angular velocity of P relative to the world, P axes, rad/s.
    """

    p_WC_W: np.ndarray
    q_WP: np.ndarray
    v_WC_W: np.ndarray
    w_WP_P: np.ndarray

    @staticmethod
    def of_rows(rows: np.ndarray) -> "State":
        """The State viewing an (N, 13) array of rows (p, q, v, w), as the compiled step stores it, layout.py (no copy)."""
        return State(rows[:, 0:3], rows[:, 3:7], rows[:, 7:10], rows[:, 10:13])

    def rows(self) -> np.ndarray:
        """A new (N, 13) C-ordered array of rows (p, q, v, w): the compiled step's layout (layout.py)."""
        return np.concatenate((self.p_WC_W, self.q_WP, self.v_WC_W, self.w_WP_P), axis=-1)

    def take(self, indices: np.ndarray) -> "State":
        """The state of the bodies at ``indices``."""
        idx = np.asarray(indices, dtype=int)
        return State(self.p_WC_W[idx], self.q_WP[idx], self.v_WC_W[idx], self.w_WP_P[idx])

    def copy(self) -> "State":
        return State(self.p_WC_W.copy(), self.q_WP.copy(), self.v_WC_W.copy(), self.w_WP_P.copy())

    def finite_bodies(self) -> np.ndarray:
        """Boolean mask, shape (N,): True where every component of the body's state is finite."""
        return (
            np.isfinite(self.p_WC_W).all(axis=1)
            & np.isfinite(self.q_WP).all(axis=1)
            & np.isfinite(self.v_WC_W).all(axis=1)
            & np.isfinite(self.w_WP_P).all(axis=1)
        )
