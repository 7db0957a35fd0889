"""The material rule of a contact pair (scene keys ``material:``): restitution and friction.

A pair's friction is √(μ_a μ_b) and its restitution max(e_a, e_b); a side without a material
takes the other's; with neither, :data:`DEFAULT_RESTITUTION` and :data:`DEFAULT_FRICTION`.
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels.contact.layout import FRICTION, HAS_MATERIAL, RESTITUTION

__all__ = ["pair_material", "DEFAULT_RESTITUTION", "DEFAULT_FRICTION"]

#: Restitution and friction of a pair where neither side declares a material.
DEFAULT_RESTITUTION = 0.0
DEFAULT_FRICTION = 0.5


def pair_material(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """(restitution, friction) of two rows with material columns: max(e_a, e_b), √(μ_a μ_b).

    A side without a material (HAS_MATERIAL 0) takes the other's; with neither, the defaults.
    """
    if not a[HAS_MATERIAL] and not b[HAS_MATERIAL]:
        return DEFAULT_RESTITUTION, DEFAULT_FRICTION
    if not a[HAS_MATERIAL]:
        a = b
    if not b[HAS_MATERIAL]:
        b = a
    return max(float(a[RESTITUTION]), float(b[RESTITUTION])), math.sqrt(float(a[FRICTION]) * float(b[FRICTION]))
