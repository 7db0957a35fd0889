"""What the body–body pass costs a step where no bodies meet: the Simulator's step with and without it.

N moving bodies (spheres and boxes alternately, largest bounding radius 0.087 m) on a 1 m lattice
above a ground, no gravity, small random velocities and spins: no two ever come near, so the pass
(core/contact/body_pairs.py) runs its two compiled loops (swept boxes, hashed grid) and finds no
candidate. "off" is the same simulator with ``contact.pairs`` set to None: the ground's pass
alone, the code a scene without body–body pairs runs. rk4, dt = 1 ms; per step, median
[min–max] of 5 runs of 200 steps after 20 warm-up steps, on and off interleaved. Run:
``python -m benchmarks.body_pairs_cost [N ...]``; writes benchmarks/results/body_pairs_cost.md.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from . import machine

OUT = Path(__file__).resolve().parent / "results" / "body_pairs_cost.md"
STEPS, REPEATS, DT = 200, 5, 1e-3


def scene(n: int, seed: int = 0):
    from rigid_body_sim.core import load_scene

    rng = np.random.default_rng(seed)
    side = int(np.ceil(n ** (1.0 / 3.0)))
    bodies = {}
    for k in range(n):
        i, j, m = k % side, (k // side) % side, k // (side * side)
        bodies[f"b{k}"] = {"mass": 1.0, "inertia": {"box": [0.1, 0.1, 0.1]} if k % 2 else {"sphere": 0.05},
                           "pose": {"position": [1.0 * i, 1.0 * j, 2.0 + 1.0 * m]},
                           "twist": {"linear": rng.normal(0.0, 0.1, 3).tolist(), "angular": rng.normal(0.0, 1.0, 3).tolist()}}
    return load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [{"normal": [0.0, 0.0, 1.0]}], "bodies": bodies})


def per_step(n: int) -> dict[str, list[float]]:
    from rigid_body_sim.core import Simulator

    times: dict[str, list[float]] = {"on": [], "off": []}
    for _ in range(REPEATS):
        for mode in ("on", "off"):
            sim = Simulator(scene(n), "rk4", DT)
            if mode == "off":
                sim.contact.pairs = None
            sim.step(20)
            t = time.perf_counter()
            sim.step(STEPS)
            times[mode].append((time.perf_counter() - t) / STEPS)
    return times


def table(sizes=(100, 1_000, 10_000)) -> list[str]:
    lines = [machine.text().rstrip("\n"), "",
             f"Step with and without the body–body pass, none meeting (rk4, dt = {DT} s; per step, median [min–max] "
             f"of {REPEATS} runs of {STEPS} steps):", "",
             "| N | with the pass | without | added per body |", "|---|---|---|---|"]
    for n in sizes:
        t = per_step(n)
        on, off = (np.median(t["on"]), min(t["on"]), max(t["on"])), (np.median(t["off"]), min(t["off"]), max(t["off"]))
        lines.append(f"| {n} | {on[0] * 1e6:.0f} µs [{on[1] * 1e6:.0f}–{on[2] * 1e6:.0f}] "
                     f"| {off[0] * 1e6:.0f} µs [{off[1] * 1e6:.0f}–{off[2] * 1e6:.0f}] | {(on[0] - off[0]) / n * 1e9:.0f} ns |")
    return lines


if __name__ == "__main__":
    import sys

    sizes = tuple(int(a) for a in sys.argv[1:]) or (100, 1_000, 10_000)
    out = "\n".join(table(sizes)) + "\n"
    print(out)
    OUT.write_text(out)
