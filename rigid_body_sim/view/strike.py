"""The "Feel the offset" strike: one upward impulse J at a point of a box's bottom face.

The point moves with ``offset`` from the centre of the bottom face (offset 0, straight under the
centre of mass) to its corner (offset 1): r = (offset · a/2, offset · b/2, −c/2) in the box's body
frame, for edges (a, b, c). The impulse is J = (0, 0, J) along the box's own +z, so the message on
``B/impulse`` with ``frame_id`` B (an impulse about the origin of B's frame, in its axes) carries the
linear impulse J and the angular impulse r × J. At offset 0 the box only rises; further out it also
turns, by Δω = I⁻¹ (r × J).
"""

from __future__ import annotations

from typing import Sequence

#: The fixed upward impulse of a strike, N·s (a 2 kg box rises at 0.25 m/s).
STRIKE_IMPULSE_NS = 0.5


def strike_point(edges: Sequence[float], offset: float) -> tuple[float, float, float]:
    """The struck point in the box's body frame (m), ``offset`` in [0, 1] from centre to corner."""
    a, b, c = (float(e) for e in edges)
    s = min(1.0, max(0.0, float(offset)))
    return (s * a / 2.0, s * b / 2.0, -c / 2.0)


def strike_wrench(edges: Sequence[float], offset: float, impulse: float = STRIKE_IMPULSE_NS
                  ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """(linear, angular) impulse about the box's origin in its axes: ((0, 0, J), r × J)."""
    rx, ry, _rz = strike_point(edges, offset)
    j = float(impulse)
    # r × (0, 0, J) = (r_y J, −r_x J, 0)
    return (0.0, 0.0, j), (ry * j, -rx * j, 0.0)
