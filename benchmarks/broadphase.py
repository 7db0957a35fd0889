"""Cost of the body–body broad phase (bounding boxes + sort and sweep) against the number of bodies.

N = 1e3, 1e4, 1e5 shapes (a mix of spheres, boxes, cylinders and capsules, sizes 0.05–0.15 m,
random orientations) at random positions in a cube whose side keeps the density fixed
(DENSITY shapes per m³). Times one compiled pass of ``broadphase.shape_aabbs`` and
``broadphase.grid_pairs`` (or ``sweep_pairs``) (median [min–max] of 5), the candidate pairs
found, and ns per body. The sweep on one axis grows as N^(5/3) at a fixed density (the slab a
body sweeps holds a share 1/side of all bodies); the grid is linear. Printed, and written by ``benchmarks.pair_oracle`` into its results.
"""

from __future__ import annotations

import time

import numpy as np

#: Shapes per m³.
DENSITY = 50.0


def scene(n, seed=0):
    from rigid_body_sim.core.kernels.contact.layout import DIMS, KIND, SHAPE_WIDTH
    rng = np.random.default_rng(seed)
    side = (n / DENSITY) ** (1.0 / 3.0)
    pos = rng.uniform(0.0, side, size=(n, 3))
    quat = rng.normal(size=(n, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    shapes = np.zeros((n, SHAPE_WIDTH))
    shapes[:, KIND] = rng.integers(1, 5, size=n)
    shapes[:, DIMS:DIMS + 3] = rng.uniform(0.05, 0.15, size=(n, 3))
    return pos, quat, shapes


def run(n, method="grid", repeats=5):
    """(median, min, max seconds per pass, candidate pairs) for n shapes."""
    from rigid_body_sim.core.kernels.contact.broadphase import grid_pairs, shape_aabbs, sweep_pairs
    pos, quat, shapes = scene(n)
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    pairs = np.empty((8 * n, 2), np.int64)
    times, found = [], 0
    for _ in range(repeats + 1):
        t = time.perf_counter()
        shape_aabbs(pos, quat, shapes, lo, hi)
        found = (grid_pairs if method == "grid" else sweep_pairs)(lo, hi, 0.0, pairs)
        times.append(time.perf_counter() - t)
    times = times[1:]  # the first includes loading the compiled code
    return float(np.median(times)), float(min(times)), float(max(times)), found


def table(sizes=(1_000, 10_000, 100_000)):
    lines = [f"Broad phase (density {DENSITY:g} shapes/m³, half sizes 0.05–0.15 m; one pass of bounding boxes + pairs):",
             "", "| method | N | time per pass (median [min–max] of 5) | ns per body | candidate pairs |",
             "|---|---|---|---|---|"]
    for method in ("grid", "sweep"):
        for n in sizes:
            med, lo, hi, found = run(n, method)
            lines.append(f"| {method} | {n} | {med * 1e3:.3f} ms [{lo * 1e3:.3f}–{hi * 1e3:.3f}] | {med / n * 1e9:.0f} | {found} |")
    return lines


if __name__ == "__main__":
    print("\n".join(table()))
