"""The swept broad phase's pairs, kept from step to step where the bodies' paths did not change.

:class:`SweptPairs` owns what kernels/contact/kept_pairs.kept_swept_pairs keeps between calls, and the room it
writes into; body_pairs.py holds one for the bounding spheres and one for the spheres grown by each body's
deflection bound. The grid and the boxes are body_pairs.py's (its ``broad_phase()`` hands them on).
"""

from __future__ import annotations

import numpy as np

from ..kernels.contact.kept_pairs import KEY_WIDTH, kept_swept_pairs

__all__ = ["SweptPairs"]


class SweptPairs:
    """The candidate pairs of one sphere radius per member, as grid_swept_pairs then spheres_may_meet find them.

    Parameters
    ----------
    members : ndarray of int (M,)
        The broad phase's members (body indices), the movable ones first.
    movable : ndarray of bool (M,)
    lo, hi : ndarray (M, 3)
        The boxes (m, world) over the step of the spheres of each call (swept_bounds'), which its caller writes.
    cells, heads, chain : ndarray of int
        The hashed grid (swept.grid_swept_pairs' scratch), left filed over the boxes by each call.
    """

    def __init__(self, members: np.ndarray, movable: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                 cells: np.ndarray, heads: np.ndarray, chain: np.ndarray) -> None:
        m = len(members)
        self.members, self.movable = members, movable
        self._fixed = np.flatnonzero(~movable).astype(np.int64)
        self._grid = (lo, hi, cells, heads, chain)
        #: (capacity, 2) int: the last call's pairs in its first rows (rows of members).
        self.pairs = np.empty((max(4 * m, 16), 2), dtype=np.int64)
        self._last = np.empty_like(self.pairs)
        self._state = np.zeros(4)
        self._keys = np.zeros((m, KEY_WIDTH))
        self._last_lo, self._last_hi = np.zeros((m, 3)), np.zeros((m, 3))
        self._last_cells = np.zeros((m, 3), dtype=np.int64)
        self._blocks = np.zeros(m + 1, dtype=np.int64)
        self._starts = np.zeros(m + 1, dtype=np.int64)
        self._marks = np.zeros(m, dtype=np.int64)
        self._grounds = b""

    @property
    def listed(self) -> int:
        """How many members the last call listed again (the others' pairs were kept)."""
        return int(self._state[3])

    def find(self, Y0: np.ndarray, Y1: np.ndarray, radius: np.ndarray, h: float, grounds: np.ndarray) -> int:
        """How many pairs the step from Y0 to Y1 (state rows, h s) has, of members whose spheres (radius (M,), m)
        may meet over it, a half-space of ``grounds`` stopping one anywhere on its chord; they are self.pairs[:k].
        The boxes lo, hi hold swept_bounds' for this step and these radii."""
        here = grounds.tobytes()
        if here != self._grounds:  # other half-spaces: nothing kept holds
            self._state[0] = 0.0
            self._grounds = here
        lo, hi, cells, heads, chain = self._grid
        while True:
            found = kept_swept_pairs(Y0, Y1, self.members, radius, h, grounds, self.movable, self._fixed, lo, hi,
                                     cells, heads, chain, self.pairs, self._state, self._keys, self._last_lo,
                                     self._last_hi, self._last_cells, self._blocks, self._last, self._starts,
                                     self._marks)
            if found >= 0:
                return found
            self.pairs = np.empty((2 * -found, 2), dtype=np.int64)
            self._last = np.empty_like(self.pairs)
            self._state[0] = 0.0
