"""Where a body's restitution or friction against a plane row is stored: one accessor for every reader.

The plane rows a body can be held on or meet (layout.py's ground rows; core/contact/solver.py
``grounds``) are the scene's half-spaces (rows 0 … G − 1), then, in a scene with static
shapes, six face rows per static box, then one *tangent row per body* (body i's is
``first_tangent + i``: core/contact/static_geometry.py). A body only ever uses its own tangent
row, so its materials there are one number per body, not a column per body: the materials are a
table (n, first_tangent) over the half-spaces and faces and a vector (n,) over the tangent rows.
Without static shapes there is no tangent block: ``first_tangent`` is the table's column count
and ``tangent`` may be empty.
"""

from __future__ import annotations

from numba import njit

from ..jit import INLINE

__all__ = ["material"]


@njit(**INLINE)
def material(table, tangent, first_tangent, i, j):
    """Body i's coefficient (restitution or friction) against plane row j.

    Parameters
    ----------
    table : ndarray, shape (n, first_tangent)
        Per body, the coefficient against each half-space and each static box face row.
    tangent : ndarray, shape (n,) or (0,)
        Per body, the coefficient against its own tangent row (the static shape it was last written
        for); empty when the scene has no static shapes.
    first_tangent : int
        Index of the first tangent row (body 0's).
    i, j : int
        The body and the plane row: j < first_tangent, or j = first_tangent + i (its own tangent row).
    """
    value = tangent[i] if j >= first_tangent else table[i, j]
    _pin = table.shape[0], tangent.shape[0]  # the arrays' last use out of the branch (jit.py)
    return value
