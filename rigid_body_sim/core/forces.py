"""Applied wrenches and the frame rule.

One rule for every applied wrench: it is a force and a torque *about the origin of a frame,
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

Applied wrenches are kept in their own frame's terms in :class:`WrenchAccumulator` and are
*resolved* into (force, torque about the centre of mass), world axes, at the start of every
step (:meth:`WrenchAccumulator.resolve`), then held constant over that step. So a wrench in a
body-fixed frame follows the body from step to step, and the same physical wrench named in
any frame gives the same motion to round-off.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from . import kernels
from .model import BodyModel, State
from .quaternion import quat_conjugate, quat_rotate
from .scene import WORLD_FRAME, Scene

__all__ = ["FrameKind", "FrameRef", "parse_frame", "WrenchAccumulator"]


class FrameKind(Enum):
    """How a frame's origin and axes relate to its body."""

    WORLD = "world"  # world origin, world axes
    BODY = "body"  # centre of mass, body axes
    WORLD_ALIGNED = "world_aligned"  # centre of mass, world axes
    SITE_BODY_AXES = "site_body_axes"  # body-fixed point, body axes
    SITE_WORLD_AXES = "site_world_axes"  # body-fixed point, world axes


@dataclass(frozen=True)
class FrameRef:
    """A parsed frame name for a wrench on body ``body_index``."""

    body_index: int
    kind: FrameKind
    site_index: int = -1


def parse_frame(scene: Scene, body: str, frame: str) -> FrameRef:
    """Resolve the frame name ``frame`` for a wrench on ``body``.

    Raises
    ------
    ValueError
        For an unknown body, or a frame that is not one of ``scene.frames_of(body)`` (listed).
    """
    names = scene.body_names
    if body not in scene.sites:
        raise ValueError(f"unknown body {body!r}; bodies are {list(names)}")
    index = names.index(body)
    if frame == WORLD_FRAME:
        return FrameRef(index, FrameKind.WORLD)
    if frame == body:
        return FrameRef(index, FrameKind.BODY)
    if frame == f"{body}/world_aligned":
        return FrameRef(index, FrameKind.WORLD_ALIGNED)
    if isinstance(frame, str) and frame.startswith(f"{body}/") and frame[len(body) + 1:] in scene.sites[body]:
        site = scene.model.site_names.index(frame)
        world_axes = bool(scene.model.site_world_axes[site])
        return FrameRef(index, FrameKind.SITE_WORLD_AXES if world_axes else FrameKind.SITE_BODY_AXES, site)
    raise ValueError(f"unknown frame {frame!r} for body {body!r}; valid frames are {list(scene.frames_of(body))}")


class WrenchAccumulator:
    """Wrenches applied to N bodies, kept in the terms of the frame they were given in.

    Buckets (all SI, all cleared by :meth:`clear`):

    - ``force_W``, ``torque_O_W``: world frame; torque about the world origin, world axes.
    - ``force_A``, ``torque_A``: about the centre of mass, world axes (``world_aligned``, and
      the torque part of world-axes sites).
    - ``force_P``, ``torque_P``: about the centre of mass, principal axes (body frame and
      body-axes sites, whose moment arm is added when applied).
    - ``site_force_W`` (S, 3): force at each world-axes site, world axes; its moment arm
      rotates with the body, so it is resolved every step.
    """

    def __init__(self, model: BodyModel):
        self._model = model
        n, s = model.count, len(model.site_names)
        #: (N, 18) all six buckets side by side, the layout of kernels.resolve_wrenches.
        self.buckets = np.zeros((n, 18))
        self.force_W = self.buckets[:, 0:3]
        self.torque_O_W = self.buckets[:, 3:6]
        self.force_A = self.buckets[:, 6:9]
        self.torque_A = self.buckets[:, 9:12]
        self.force_P = self.buckets[:, 12:15]
        self.torque_P = self.buckets[:, 15:18]
        #: (S, 7) world-axes sites for the kernels: owning body, p_P (m), the force there (N, world).
        self.sites = np.zeros((s, 7))
        if s:
            self.sites[:, 0] = model.site_body
            self.sites[:, 1:4] = model.site_p_P
        self.site_force_W = self.sites[:, 4:7]
        self.empty = True

    def clear(self) -> None:
        """Drop every applied wrench."""
        if not self.empty:
            self.buckets.fill(0.0)
            self.site_force_W.fill(0.0)
            self.empty = True

    def add(self, ref: FrameRef, force: np.ndarray, torque: np.ndarray) -> None:
        """Add the wrench (force N, torque N·m about the frame origin, frame axes) in frame ``ref``."""
        b = ref.body_index
        model = self._model
        if ref.kind is FrameKind.WORLD:
            self.force_W[b] += force
            self.torque_O_W[b] += torque
        elif ref.kind is FrameKind.WORLD_ALIGNED:
            self.force_A[b] += force
            self.torque_A[b] += torque
        elif ref.kind is FrameKind.BODY:
            q_PB = quat_conjugate(model.q_BP[b])
            self.force_P[b] += quat_rotate(q_PB, force)
            self.torque_P[b] += quat_rotate(q_PB, torque)
        elif ref.kind is FrameKind.SITE_BODY_AXES:
            q_PB = quat_conjugate(model.q_BP[b])
            force_P = quat_rotate(q_PB, force)
            self.force_P[b] += force_P
            self.torque_P[b] += quat_rotate(q_PB, torque) + np.cross(model.site_p_P[ref.site_index], force_P)
        else:  # SITE_WORLD_AXES: the moment arm of the force is added at resolution
            self.site_force_W[ref.site_index] += force
            self.torque_A[b] += torque
        self.empty = False

    def resolve(self, state: State) -> tuple[np.ndarray, np.ndarray]:
        """Total applied (force, torque about the centre of mass), world axes, at ``state``.

        Returns
        -------
        force_W, torque_W : ndarray, shape (N, 3)
            Fresh arrays (zeros when nothing is applied).
        """
        n = self._model.count
        wrench = np.zeros((n, 6))
        if not self.empty:
            unconstrained = np.zeros((n, kernels.PRM_WIDTH))  # PROJECT_NONE: nothing projected out
            kernels.resolve_wrenches(state.rows(), unconstrained, self.buckets, self.sites, wrench)
        return wrench[:, 0:3], wrench[:, 3:6]
