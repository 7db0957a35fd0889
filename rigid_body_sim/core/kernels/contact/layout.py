"""Named columns of the contact rows (like core/layout.py for the step's buffers).

Shape row (``SHAPE_WIDTH`` floats per body): ``KIND`` (SHAPE_*), ``DIMS`` (3: sphere r; box
half extents x, y, z; cylinder and capsule r, half length along body z), all in the body's
frame B, centred at the centre of mass; ``MATERIAL`` (restitution e, friction μ) and
``HAS_MATERIAL`` (0: none declared).

Ground row (``GROUND_WIDTH`` floats per half-space n·x ≥ offset): unit normal ``NORMAL`` (3,
world axes), ``OFFSET`` (m), then ``MATERIAL`` and ``HAS_MATERIAL`` at the same columns as a
shape row.
"""

from __future__ import annotations

SHAPE_NONE, SHAPE_SPHERE, SHAPE_BOX, SHAPE_CYLINDER, SHAPE_CAPSULE = 0, 1, 2, 3, 4
SHAPE_NAMES = {"sphere": SHAPE_SPHERE, "box": SHAPE_BOX, "cylinder": SHAPE_CYLINDER, "capsule": SHAPE_CAPSULE}

KIND = 0
DIMS = 1  # 3 columns
RESTITUTION = 4
FRICTION = 5
HAS_MATERIAL = 6
SHAPE_WIDTH = 7

NORMAL = 0  # 3 columns
OFFSET = 3
GROUND_WIDTH = 7  # RESTITUTION, FRICTION, HAS_MATERIAL as in a shape row

#: Most contact points one body has against one half-space (a box face).
MAX_POINTS = 4

#: Contact modes of a body (ContactSolver.modes).
FLIGHT, PERSISTENT = 0, 1
