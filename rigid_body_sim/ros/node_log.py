"""What the node writes to its log: the scene at start-up, each body's model, and a periodic status.

Plain functions of a logger and the simulator; the caller holds the node's lock where the
simulator may be stepping.
"""

from __future__ import annotations

import time
from typing import Any, Mapping, Sequence

import numpy as np

from ..core import Simulator

__all__ = ["log_scene", "log_models", "StatusLog"]

#: Bodies listed one per line at most; the rest are counted.
LISTED_BODIES = 20


def log_scene(logger: Any, sim: Simulator, settings: Mapping[str, Any], frames: Mapping[str, Sequence[str]]) -> None:
    """The scene, integrator and step, then each body's mass, moments and wrench frames, then its model."""
    logger.info(f"scene {sim.scene.source}: {len(sim.body_names)} bodies; integrator {sim.integrator}, "
                f"dt = {sim.dt:g} s ({settings['rate_hz']:g} Hz × {settings['substeps']} substeps, "
                f"real_time_factor {settings['real_time_factor']:g})")
    for index, body in enumerate(sim.body_names[:LISTED_BODIES]):
        logger.info(f"  {body}: mass {sim.model.mass[index]:g} kg, principal moments "
                    f"{np.round(sim.model.inertia_P[index], 9).tolist()} kg·m², wrench frames {list(frames.get(body, ()))}")
    if len(sim.body_names) > LISTED_BODIES:
        logger.info(f"  ... and {len(sim.body_names) - LISTED_BODIES} more bodies")
    log_models(logger, sim)


def log_models(logger: Any, sim: Simulator) -> None:
    """Which model each body gets and why (model reduction): counts, then one line per body."""
    counts = sim.model_counts()
    logger.info(f"models (model_reduction {'on' if sim.model_reduction else 'off'}): "
                + ", ".join(f"{count} {model}" for model, count in sorted(counts.items())))
    for plan in sim.body_models(first=LISTED_BODIES):
        logger.info(f"  {plan.body}: {plan.model} model: {plan.reason}")


class StatusLog:
    """A status line every ``period`` wall seconds: sim time, measured real-time factor, poses."""

    def __init__(self) -> None:
        self._wall = time.monotonic()
        self._sim_time = 0.0

    def maybe_log(self, logger: Any, sim: Simulator, period: float, paused: bool) -> None:
        """Log if ``period`` (> 0) wall seconds passed since the last line."""
        if period <= 0.0:
            return
        wall = time.monotonic()
        elapsed = wall - self._wall
        if elapsed < period:
            return
        rtf = (sim.time - self._sim_time) / elapsed
        self._wall, self._sim_time = wall, sim.time
        lines = [f"t = {sim.time:.3f} s, real-time factor {rtf:.3f}" + (" (paused)" if paused else "")]
        positions, orientations = sim.positions_world(), sim.orientations_xyzw()
        for index, body in enumerate(sim.body_names[:10]):
            lines.append(f"  {body}: position {np.round(positions[index], 4).tolist()} m, "
                         f"orientation xyzw {np.round(orientations[index], 4).tolist()}")
        if len(sim.body_names) > 10:
            lines.append(f"  ... and {len(sim.body_names) - 10} more bodies")
        logger.info("\n".join(lines))
