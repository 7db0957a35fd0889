"""Scene pieces the contact tests share."""

from __future__ import annotations


def bin_walls(inner: float) -> dict:
    """Four static walls (0.1 m thick, 1 m high, μ = 0.5, e = 0) around a square of side ``inner`` (m) centred on
    the origin: a bin on the ground (scene ``bodies`` entries)."""
    reach, long = 0.5 * (inner + 0.1), inner + 0.2
    walls = {}
    for name, pos, size in (("wall_xp", (reach, 0.0), (0.1, long)), ("wall_xm", (-reach, 0.0), (0.1, long)),
                            ("wall_yp", (0.0, reach), (long, 0.1)), ("wall_ym", (0.0, -reach), (long, 0.1))):
        box = {"box": [*size, 1.0]}
        walls[name] = {"motion": "static", "mass": 1.0, "inertia": box, "collision": box,
                       "material": {"restitution": 0.0, "friction": 0.5}, "pose": {"position": [*pos, 0.5]}}
    return walls
