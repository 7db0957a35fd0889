"""Frame names of applied wrenches, parsed once at the API edge into what the compiled wrench rows take.

The frame rule (a force and a torque about a frame's origin, in its axes) and the compiled
functions that keep and evaluate wrenches are in kernels/forces.py; this module turns a frame
*name* (``world``, ``<body>``, ``<body>/world_aligned``, ``<body>/<site>``) into a
:class:`FrameRef` (a layout.FRAME_* code and the site's arm) and makes empty wrench rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kernels.layout import (
    FRAME_BODY,
    FRAME_SITE_BODY_AXES,
    FRAME_SITE_WORLD_AXES,
    FRAME_WORLD,
    FRAME_WORLD_ALIGNED,
    WRENCH_WIDTH,
)
from .scene import WORLD_FRAME, Scene

__all__ = ["FrameRef", "FRAME_KIND_NAMES", "parse_frame", "new_wrench_rows"]

#: layout.FRAME_* → a readable name.
FRAME_KIND_NAMES = {
    FRAME_WORLD: "world",
    FRAME_BODY: "body",
    FRAME_WORLD_ALIGNED: "world_aligned",
    FRAME_SITE_BODY_AXES: "site_body_axes",
    FRAME_SITE_WORLD_AXES: "site_world_axes",
}


@dataclass(frozen=True)
class FrameRef:
    """A frame name parsed for a wrench on body ``body_index``.

    ``kind`` is a layout.FRAME_* code; ``arm_P`` is the site's position from the centre of
    mass in principal axes (m), zeros for the frames that are not sites.
    """

    body_index: int
    kind: int
    arm_P: tuple[float, float, float] = (0.0, 0.0, 0.0)


def parse_frame(scene: Scene, body: str, frame: str) -> FrameRef:
    """Resolve the frame name ``frame`` for a wrench on ``body``.

    Raises
    ------
    ValueError
        For an unknown body, or a frame that is not one of ``scene.frames_of(body)`` (listed).
    """
    names = scene.body_names
    if not isinstance(body, str) or body not in scene.sites:
        raise ValueError(f"unknown body {body!r}; bodies are {list(names)}")
    index = names.index(body)
    if frame == WORLD_FRAME:
        return FrameRef(index, FRAME_WORLD)
    if frame == body:
        return FrameRef(index, FRAME_BODY)
    if frame == f"{body}/world_aligned":
        return FrameRef(index, FRAME_WORLD_ALIGNED)
    if isinstance(frame, str) and frame.startswith(f"{body}/") and frame[len(body) + 1:] in scene.sites[body]:
        site = scene.model.site_names.index(frame)
        kind = FRAME_SITE_WORLD_AXES if scene.model.site_world_axes[site] else FRAME_SITE_BODY_AXES
        return FrameRef(index, kind, tuple(float(x) for x in scene.model.site_p_P[site]))
    raise ValueError(f"unknown frame {frame!r} for body {body!r}; valid frames are {list(scene.frames_of(body))}")


def new_wrench_rows(count: int) -> np.ndarray:
    """Empty wrench rows for ``count`` bodies, shape (count, WRENCH_WIDTH) (layout.py)."""
    return np.zeros((count, WRENCH_WIDTH))
