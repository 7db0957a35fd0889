"""Applied wrenches: the frame rule, the wrench rows, and the one function that evaluates them.

One rule for every applied wrench: a force and a torque *about the origin of a frame,
expressed in that frame's axes*. The frames a wrench on body ``b`` may name:

=========================  ===========================  ============================
frame                      origin                       axes
=========================  ===========================  ============================
``world``                  world origin                 world
``b``                      b's centre of mass           b's body frame B
``b/world_aligned``        b's centre of mass           world
``b/<site>``               the site (body-fixed point)  B, or world if the site says
=========================  ===========================  ============================

A force F at point r of a frame is therefore the wrench (F, r × F) in that frame.

A wrench is *kept in its frame's terms* in the body's wrench row (layout.py: F_WORLD …
SITE_MOMENT), by :func:`add_wrench`, and *evaluated* from the body's state by
:func:`body_wrench` wherever an integrator evaluates the dynamics: at every stage of rk4,
every kick of the splittings, every step of the first-order methods. So a force fixed in the
body turns with it inside the step, and the torque about the centre of mass of a wrench
given about a world point sees the centre of mass where the stage puts it: every integrator
keeps its order under forcing in every frame (MuJoCo re-runs its forward pass per RK stage
for the same reason). Impulses are resolved by the same function at the state they act on.
"""

from __future__ import annotations

from numba import njit

from .layout import (
    ACTIVE,
    F_COM_P,
    F_COM_W,
    F_WORLD,
    FRAME_SITE_WORLD_AXES,
    FRAME_WORLD,
    FRAME_WORLD_ALIGNED,
    GRAVITY,
    MASS,
    NORMAL,
    P,
    PROJECT,
    PROJECT_ALL,
    PROJECT_FORCE,
    PROJECT_PLANE,
    PROJECT_TORQUE,
    Q,
    Q_PB,
    SITE_MOMENT,
    T_COM_P,
    T_COM_W,
    T_WORLD,
)
from .jit import INLINE, JIT
from .rotation import matrix, normalise, rotate, rotate_back

__all__ = ["add_wrench", "body_wrench", "resolve_wrench", "wrench_about_com", "project", "project_twist"]

@njit(**JIT)
def add_wrench(w, p, kind, ax, ay, az, fx, fy, fz, tx, ty, tz):
    """Add to wrench row ``w`` the wrench (f, t) about the origin of a frame, in its axes, in the frame's terms.

    ``kind`` is a layout.FRAME_*, ``(ax, ay, az)`` the site's position from the COM in
    principal axes (site frames), ``p`` the body's parameter row (q_PB for body axes).
    """
    if kind == FRAME_WORLD:
        w[F_WORLD] += fx
        w[F_WORLD + 1] += fy
        w[F_WORLD + 2] += fz
        w[T_WORLD] += tx
        w[T_WORLD + 1] += ty
        w[T_WORLD + 2] += tz
    elif kind == FRAME_WORLD_ALIGNED or kind == FRAME_SITE_WORLD_AXES:
        w[F_COM_W] += fx
        w[F_COM_W + 1] += fy
        w[F_COM_W + 2] += fz
        w[T_COM_W] += tx
        w[T_COM_W + 1] += ty
        w[T_COM_W + 2] += tz
        if kind == FRAME_SITE_WORLD_AXES:  # M += f ⊗ r: the moment (R r) × f, evaluated per stage
            for j, f in enumerate((fx, fy, fz)):
                w[SITE_MOMENT + 3 * j] += f * ax
                w[SITE_MOMENT + 3 * j + 1] += f * ay
                w[SITE_MOMENT + 3 * j + 2] += f * az
    else:  # FRAME_BODY, FRAME_SITE_BODY_AXES: into principal axes, where they stay
        qw, qx, qy, qz = p[Q_PB], p[Q_PB + 1], p[Q_PB + 2], p[Q_PB + 3]
        f_P = rotate(qw, qx, qy, qz, fx, fy, fz)
        t_P = rotate(qw, qx, qy, qz, tx, ty, tz)
        w[F_COM_P] += f_P[0]
        w[F_COM_P + 1] += f_P[1]
        w[F_COM_P + 2] += f_P[2]
        w[T_COM_P] += t_P[0] + (ay * f_P[2] - az * f_P[1])
        w[T_COM_P + 1] += t_P[1] + (az * f_P[0] - ax * f_P[2])
        w[T_COM_P + 2] += t_P[2] + (ax * f_P[1] - ay * f_P[0])
    w[ACTIVE] = 1.0


@njit(**JIT)
def project(kind, nx, ny, nz, fx, fy, fz, tx, ty, tz):
    """The wrench (force, torque; world axes) with what a motion forbids projected out.

    ``kind`` is the body's layout.PROJECT_*, (nx, ny, nz) its plane normal (planar).
    """
    if kind == PROJECT_ALL or kind == PROJECT_FORCE:
        fx, fy, fz = 0.0, 0.0, 0.0
    if kind == PROJECT_ALL or kind == PROJECT_TORQUE:
        tx, ty, tz = 0.0, 0.0, 0.0
    if kind == PROJECT_PLANE:  # force in the plane, torque along its normal
        f_n = fx * nx + fy * ny + fz * nz
        t_n = tx * nx + ty * ny + tz * nz
        fx, fy, fz = fx - f_n * nx, fy - f_n * ny, fz - f_n * nz
        tx, ty, tz = t_n * nx, t_n * ny, t_n * nz
    return fx, fy, fz, tx, ty, tz


@njit(**JIT)
def wrench_about_com(R, p_W, f_world, t_world, f_com_w, t_com_w, f_com_p, t_com_p, site_moment):
    """Force (world axes) and torque about the COM (world axes) of a wrench row's parts, at a pose.

    ``R`` is R(q) row-major (9), ``p_W`` the COM position (3); the rest are the wrench row's
    parts (layout.py): 3-tuples, and ``site_moment`` M = Σ f_W ⊗ r_P row-major (9). The torque
    is τ_O − p × F of the world-frame wrench, the COM torques (world and, turned by R,
    principal axes) and the moment Σ (R r) × f of world-axes sites: τ_k = ε_kij (R Mᵀ)_ij.
    Scalars in, scalars out: this is the frame algebra, read once from the row by the caller.
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R
    px, py, pz = p_W
    f0, f1, f2 = f_world
    bx, by, bz = f_com_p
    cx, cy, cz = t_com_p
    m0, m1, m2, m3, m4, m5, m6, m7, m8 = site_moment
    fx = f0 + f_com_w[0] + r00 * bx + r01 * by + r02 * bz
    fy = f1 + f_com_w[1] + r10 * bx + r11 * by + r12 * bz
    fz = f2 + f_com_w[2] + r20 * bx + r21 * by + r22 * bz
    a01 = r00 * m3 + r01 * m4 + r02 * m5
    a02 = r00 * m6 + r01 * m7 + r02 * m8
    a10 = r10 * m0 + r11 * m1 + r12 * m2
    a12 = r10 * m6 + r11 * m7 + r12 * m8
    a20 = r20 * m0 + r21 * m1 + r22 * m2
    a21 = r20 * m3 + r21 * m4 + r22 * m5
    tx = t_world[0] - (py * f2 - pz * f1) + t_com_w[0] + r00 * cx + r01 * cy + r02 * cz + (a12 - a21)
    ty = t_world[1] - (pz * f0 - px * f2) + t_com_w[1] + r10 * cx + r11 * cy + r12 * cz + (a20 - a02)
    tz = t_world[2] - (px * f1 - py * f0) + t_com_w[2] + r20 * cx + r21 * cy + r22 * cz + (a01 - a10)
    return fx, fy, fz, tx, ty, tz


@njit(**INLINE)
def resolve_wrench(y, p, w):
    """The applied force and torque about the COM of wrench row ``w`` at state row ``y``, world axes, projected.

    Returns (fx, fy, fz, tx, ty, tz): N and N·m, world axes, no gravity.
    """
    qw, qx, qy, qz = normalise(y[Q], y[Q + 1], y[Q + 2], y[Q + 3])
    # Every number is read here, in straight-line code: inlined functions that take the rows
    # must not be called in a branch (stepping.py's loops would keep their reference counts).
    fx, fy, fz, tx, ty, tz = wrench_about_com(
        matrix(qw, qx, qy, qz), (y[P], y[P + 1], y[P + 2]),
        (w[F_WORLD], w[F_WORLD + 1], w[F_WORLD + 2]), (w[T_WORLD], w[T_WORLD + 1], w[T_WORLD + 2]),
        (w[F_COM_W], w[F_COM_W + 1], w[F_COM_W + 2]), (w[T_COM_W], w[T_COM_W + 1], w[T_COM_W + 2]),
        (w[F_COM_P], w[F_COM_P + 1], w[F_COM_P + 2]), (w[T_COM_P], w[T_COM_P + 1], w[T_COM_P + 2]),
        (w[SITE_MOMENT], w[SITE_MOMENT + 1], w[SITE_MOMENT + 2], w[SITE_MOMENT + 3], w[SITE_MOMENT + 4],
         w[SITE_MOMENT + 5], w[SITE_MOMENT + 6], w[SITE_MOMENT + 7], w[SITE_MOMENT + 8]))
    return project(p[PROJECT], p[NORMAL], p[NORMAL + 1], p[NORMAL + 2], fx, fy, fz, tx, ty, tz)


@njit(**INLINE)
def body_wrench(y, p, w):
    """The generalised force on a body at state ``y``: what every stage of every integrator calls.

    Parameters
    ----------
    y : state row (layout.P, Q; only the position and orientation are read)
    p : parameter row (mass, gravity as the motion allows it, projection)
    w : wrench row in frame terms (:func:`add_wrench`)

    Returns
    -------
    (fx, fy, fz, tx, ty, tz)
        The total force on the COM, N, world axes (applied wrenches and gravity), and the
        applied torque about the COM, N·m, principal axes P. Damping, which depends on the
        velocities, is part of the dynamics (dynamics.derivative) and of the exact kicks.
    """
    m = p[MASS]
    fx, fy, fz = m * p[GRAVITY], m * p[GRAVITY + 1], m * p[GRAVITY + 2]
    tx, ty, tz = 0.0, 0.0, 0.0
    if w[ACTIVE] != 0.0:  # indexing only in here, and functions of scalars (see resolve_wrench)
        qw, qx, qy, qz = normalise(y[Q], y[Q + 1], y[Q + 2], y[Q + 3])
        R = matrix(qw, qx, qy, qz)
        ax, ay, az, bx, by, bz = wrench_about_com(
            R, (y[P], y[P + 1], y[P + 2]),
            (w[F_WORLD], w[F_WORLD + 1], w[F_WORLD + 2]), (w[T_WORLD], w[T_WORLD + 1], w[T_WORLD + 2]),
            (w[F_COM_W], w[F_COM_W + 1], w[F_COM_W + 2]), (w[T_COM_W], w[T_COM_W + 1], w[T_COM_W + 2]),
            (w[F_COM_P], w[F_COM_P + 1], w[F_COM_P + 2]), (w[T_COM_P], w[T_COM_P + 1], w[T_COM_P + 2]),
            (w[SITE_MOMENT], w[SITE_MOMENT + 1], w[SITE_MOMENT + 2], w[SITE_MOMENT + 3], w[SITE_MOMENT + 4],
             w[SITE_MOMENT + 5], w[SITE_MOMENT + 6], w[SITE_MOMENT + 7], w[SITE_MOMENT + 8]))
        ax, ay, az, bx, by, bz = project(p[PROJECT], p[NORMAL], p[NORMAL + 1], p[NORMAL + 2], ax, ay, az, bx, by, bz)
        fx, fy, fz = fx + ax, fy + ay, fz + az
        tx, ty, tz = rotate_back(qw, qx, qy, qz, bx, by, bz)  # into principal axes
    _pin = y[P], p[MASS], w[ACTIVE]  # the arrays' last use, out of the branch (jit.py)
    return fx, fy, fz, tx, ty, tz


@njit(**JIT)
def project_twist(p, twist):
    """Project the twist (6,: v, ω; world axes) of a body in place onto its motion (as a wrench is)."""
    twist[0], twist[1], twist[2], twist[3], twist[4], twist[5] = project(
        p[PROJECT], p[NORMAL], p[NORMAL + 1], p[NORMAL + 2], twist[0], twist[1], twist[2], twist[3], twist[4], twist[5])
