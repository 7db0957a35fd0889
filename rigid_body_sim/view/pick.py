"""Click-to-strike: where a click ray meets a body's shape, and the impulse of a strike there.

A click gives a ray in world coordinates (origin, direction). :func:`ray_hit` finds where it
first meets the body's drawn shape (a box of edges (a, b, c), an ellipsoid of diameters
(a, b, c), or a cylinder of diameter a and length c along its z), the shape placed at the body's
pose with its own rotation in the body frame (a principal-axes ellipsoid). :func:`strike_at`
gives the impulse to publish with ``frame_id`` ``B/world_aligned`` (world axes at B's centre of
mass c): the linear impulse J d and the angular impulse (p − c) × J d for a strike of size J
(N·s) along the unit direction d (world) at the world point p.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

__all__ = ["ray_hit", "strike_at", "BOX", "ELLIPSOID", "CYLINDER"]

BOX, ELLIPSOID, CYLINDER = "box", "ellipsoid", "cylinder"


def _rotate(q_wxyz: Sequence[float], v: np.ndarray) -> np.ndarray:
    w, x, y, z = (float(c) for c in q_wxyz)
    u = np.array([x, y, z])
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _conj(q_wxyz: Sequence[float]) -> tuple[float, float, float, float]:
    w, x, y, z = (float(c) for c in q_wxyz)
    return (w, -x, -y, -z)


def _first_t(candidates: list[float]) -> float | None:
    ahead = [t for t in candidates if t >= 0.0 and np.isfinite(t)]
    return min(ahead) if ahead else None


def _hit_in_shape(kind: str, size: np.ndarray, o: np.ndarray, d: np.ndarray) -> float | None:
    """The ray parameter t >= 0 of the first hit of o + t d with the shape (in its own frame)."""
    half = size / 2.0
    if kind == BOX:
        t_near, t_far = -np.inf, np.inf
        for i in range(3):
            if abs(d[i]) < 1e-300:
                if abs(o[i]) > half[i]:
                    return None
                continue
            t1, t2 = (-half[i] - o[i]) / d[i], (half[i] - o[i]) / d[i]
            t_near, t_far = max(t_near, min(t1, t2)), min(t_far, max(t1, t2))
        if t_near > t_far or t_far < 0.0:
            return None
        return max(t_near, 0.0)
    if kind == ELLIPSOID:
        os_, ds = o / half, d / half
        a, b, c = ds @ ds, 2.0 * (os_ @ ds), os_ @ os_ - 1.0
        disc = b * b - 4.0 * a * c
        if a <= 0.0 or disc < 0.0:
            return None
        root = np.sqrt(disc)
        return _first_t([(-b - root) / (2.0 * a), (-b + root) / (2.0 * a)] if c > 0.0 else [0.0])
    if kind == CYLINDER:
        r, h = half[0], half[2]
        ts: list[float] = []
        a = d[0] ** 2 + d[1] ** 2
        if a > 0.0:
            b, c = 2.0 * (o[0] * d[0] + o[1] * d[1]), o[0] ** 2 + o[1] ** 2 - r * r
            disc = b * b - 4.0 * a * c
            if disc >= 0.0:
                for t in ((-b - np.sqrt(disc)) / (2.0 * a), (-b + np.sqrt(disc)) / (2.0 * a)):
                    if abs(o[2] + t * d[2]) <= h:
                        ts.append(t)
        if abs(d[2]) > 0.0:
            for zc in (-h, h):
                t = (zc - o[2]) / d[2]
                p = o + t * d
                if p[0] ** 2 + p[1] ** 2 <= r * r:
                    ts.append(t)
        return _first_t(ts)
    raise ValueError(f"unknown shape kind {kind!r}; expected {BOX}, {ELLIPSOID} or {CYLINDER}")


def ray_hit(kind: str, size: Sequence[float], q_BS_wxyz: Sequence[float], p_WB: Sequence[float],
            q_WB_wxyz: Sequence[float], ray_origin_W: Sequence[float], ray_direction_W: Sequence[float]
            ) -> np.ndarray | None:
    """The world point (m, shape (3,)) where the ray first meets the shape, or None if it misses.

    ``kind``: :data:`BOX`, :data:`ELLIPSOID` or :data:`CYLINDER`; ``size``: its extents along the
    shape frame S's axes (m: edges, diameters, or diameter, diameter, length); ``q_BS_wxyz``: S in
    the body frame B; ``p_WB``, ``q_WB_wxyz``: B's origin and orientation in the world.
    """
    q_WS = _q_mul(q_WB_wxyz, q_BS_wxyz)
    d_W = np.asarray(ray_direction_W, dtype=float)
    norm = float(np.linalg.norm(d_W))
    if not norm > 0.0:
        return None
    d_W = d_W / norm
    o_S = _rotate(_conj(q_WS), np.asarray(ray_origin_W, dtype=float) - np.asarray(p_WB, dtype=float))
    d_S = _rotate(_conj(q_WS), d_W)
    t = _hit_in_shape(kind, np.asarray(size, dtype=float), o_S, d_S)
    return None if t is None else np.asarray(ray_origin_W, dtype=float) + t * d_W


def _q_mul(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float, float]:
    aw, ax, ay, az = (float(c) for c in a)
    bw, bx, by, bz = (float(c) for c in b)
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def strike_at(point_W: Sequence[float], com_W: Sequence[float], direction_W: Sequence[float], size_Ns: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """(linear (N·s), angular (N·m·s)) impulse about the COM in world axes (``B/world_aligned``) of a
    strike of ``size_Ns`` along ``direction_W`` (normalised here) at ``point_W``. Raises ValueError
    for a zero or non-finite direction."""
    d = np.asarray(direction_W, dtype=float)
    norm = float(np.linalg.norm(d))
    if not (np.isfinite(norm) and norm > 0.0):
        raise ValueError(f"strike direction must be a non-zero finite vector, got {tuple(d)}")
    linear = float(size_Ns) * d / norm
    r = np.asarray(point_W, dtype=float) - np.asarray(com_W, dtype=float)
    return linear, np.cross(r, linear)
