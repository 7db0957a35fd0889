"""Where the microseconds of one body step go from Python: cProfile of apply + step(1), per frame.

``python -m benchmarks.profile step [integrator] [frame]`` (default rk4, the site ``b/corner``):
the Python functions behind ``apply_force_at_point`` in that frame and ``step(1)``, sorted by
own time — the per-call path that the per-frame table of results.md times
(benchmarks/apply_cost.py).
"""

from __future__ import annotations

import cProfile
import io
import pstats

import numpy as np

from rigid_body_sim.core import Simulator

from ..apply_cost import FRAMES, scene


def profile(integrator: str = "rk4", frame: str = "b/corner", steps: int = 5000, top: int = 18) -> str:
    """cProfile text (own time, then cumulative) of ``steps`` × (apply_force_at_point in ``frame`` + step(1))."""
    points = {name: point for _label, name, point in FRAMES}
    if frame not in points:
        raise ValueError(f"`frame` must be one of {sorted(points)}, got {frame!r}")
    sim = Simulator(scene(), integrator=integrator, dt=1e-3)
    forces = (np.array([0.0, 10.0, 0.0]), np.array([0.0, -10.0, 0.0]))
    point = points[frame]
    sim.apply_force_at_point("b", forces[0], point, frame)
    sim.step(1)
    profiler = cProfile.Profile()
    profiler.enable()
    for i in range(steps):
        sim.apply_force_at_point("b", forces[i & 1], point, frame)
        sim.step(1)
    profiler.disable()
    out = io.StringIO()
    out.write(f"cProfile of {steps} × (apply_force_at_point in {frame!r} + step(1)), integrator {integrator!r}\n")
    stats = pstats.Stats(profiler, stream=out)
    stats.sort_stats("tottime").print_stats(top)
    stats.sort_stats("cumulative").print_stats(top)
    return out.getvalue()

