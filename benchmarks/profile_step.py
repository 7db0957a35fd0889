"""Where the microseconds of one body step go: cProfile of apply_force_at_point + step(1)."""

from __future__ import annotations

import cProfile
import io
import pstats

import numpy as np

from rigid_body_sim.core import Simulator

from .throughput import _scene


def profile(integrator: str = "rk4", steps: int = 2000, top: int = 18) -> str:
    """cProfile text (sorted by own time) of ``steps`` one-body wrench steps with ``integrator``."""
    sim = Simulator(_scene(1), integrator=integrator, dt=1e-3)
    force, point = np.array([0.0, 10.0, 0.0]), np.array([0.5, 0.3, 0.0])
    profiler = cProfile.Profile()
    profiler.enable()
    for _ in range(steps):
        sim.apply_force_at_point("b0", force, point, frame="b0")
        sim.step(1)
    profiler.disable()
    out = io.StringIO()
    stats = pstats.Stats(profiler, stream=out)
    out.write(f"cProfile of {steps} × (apply_force_at_point + step(1)), integrator {integrator!r}, one body\n")
    stats.sort_stats("tottime").print_stats(top)
    stats.sort_stats("cumulative").print_stats(top)
    return out.getvalue()


if __name__ == "__main__":
    print(profile())
