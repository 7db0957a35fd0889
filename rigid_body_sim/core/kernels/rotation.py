"""Compiled scalar quaternion algebra for the per-body loops: (w, x, y, z), Hamilton product.

The same conventions as :mod:`quaternion` (which works on numpy arrays): ``q ⊗ (0, v) ⊗ q*``
turns a vector from the rotated frame into the reference frame. These work on scalars and
return tuples, so a compiled loop does no allocation.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["qmul", "rotate", "rotate_back", "exp_map", "normalise", "matrix"]

from .jit import JIT


@njit(**JIT)
def qmul(aw, ax, ay, az, bw, bx, by, bz):
    """Hamilton product a ⊗ b."""
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


@njit(**JIT)
def rotate(qw, qx, qy, qz, vx, vy, vz):
    """R(q) v for a unit q: v + 2w (u × v) + 2 u × (u × v)."""
    tx = 2.0 * (qy * vz - qz * vy)
    ty = 2.0 * (qz * vx - qx * vz)
    tz = 2.0 * (qx * vy - qy * vx)
    return (vx + qw * tx + (qy * tz - qz * ty),
            vy + qw * ty + (qz * tx - qx * tz),
            vz + qw * tz + (qx * ty - qy * tx))


@njit(**JIT)
def rotate_back(qw, qx, qy, qz, vx, vy, vz):
    """R(q)ᵀ v for a unit q."""
    return rotate(qw, -qx, -qy, -qz, vx, vy, vz)


@njit(**JIT)
def exp_map(rx, ry, rz):
    """Unit quaternion of the rotation vector r (rad): (cos |r|/2, sin(|r|/2) r/|r|), by series for small |r|."""
    theta = math.sqrt(rx * rx + ry * ry + rz * rz)
    if theta < 1e-4:
        scale = 0.5 - theta * theta / 48.0
    else:
        scale = math.sin(0.5 * theta) / theta
    return math.cos(0.5 * theta), rx * scale, ry * scale, rz * scale


@njit(**JIT)
def normalise(qw, qx, qy, qz):
    """q / |q|."""
    s = 1.0 / math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    return qw * s, qx * s, qy * s, qz * s


@njit(**JIT)
def matrix(qw, qx, qy, qz):
    """The rotation matrix of a unit q, row-major as 9 floats (r00, r01, ..., r22)."""
    xx, yy, zz = qx * qx, qy * qy, qz * qz
    xy, xz, yz = qx * qy, qx * qz, qy * qz
    wx, wy, wz = qw * qx, qw * qy, qw * qz
    return (1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy),
            2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx),
            2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy))
