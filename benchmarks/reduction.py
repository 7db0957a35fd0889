"""Model reduction: a mixed scene stepped with reduction on and forced onto the full model, same run.

The scene (``mixed_scene``), the issue's example: N bodies, no gravity, in a repeating pattern
of a sphere (isotropic: exact exp-map rotation), a box 1.0 × 0.6 × 0.4 m (asymmetric: the
integrator either way) and a static wall, each moving body with a random twist. Nothing
pushes them, as in a scene of debris among fixed objects; a torque on a sphere would hand it
to the integrator for that step. (A square crate, 1.0 × 0.5 × 0.5 m, would get the exact
symmetric-top flow; it is left out of the scene the target is measured on.)

For each fixed-step integrator: body-steps/s of ``sim.step(k)`` with ``model_reduction``
True and False, interleaved, median of ``repeats``; the ratio is reduced / full.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from rigid_body_sim.core import Simulator, load_scene

INTEGRATORS = ("euler", "semi_implicit_euler", "implicit_gyroscopic", "splitting", "symmetric_splitting", "rk4")
PATTERN = ("sphere", "box", "wall")
DT = 1e-3
INERTIA = {"sphere": {"sphere": 0.2}, "box": {"box": [1.0, 0.6, 0.4]}}


def mixed_scene(count: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    bodies = {}
    for i in range(count):
        kind = PATTERN[i % len(PATTERN)]
        spec = {"mass": 1.0, "pose": {"position": [2.0 * i, 0.0, 0.0]}}
        if kind == "wall":
            spec.update(inertia={"box": [1.0, 1.0, 0.1]}, motion="static")
        else:
            spec.update(inertia=INERTIA[kind],
                        twist={"linear": rng.normal(size=3).tolist(), "angular": rng.normal(size=3).tolist()})
        bodies[f"{kind}{i}"] = spec
    return load_scene({"bodies": bodies})


def _rate(sim: Simulator, steps: int) -> float:
    t0 = time.perf_counter()
    sim.step(steps)
    return sim.model.count * steps / (time.perf_counter() - t0)


def sweep(count: int, steps: int, repeats: int, log=print) -> list[dict]:
    scene = mixed_scene(count)
    rows = []
    for name in INTEGRATORS:
        sims = {flag: Simulator(scene, integrator=name, dt=DT, model_reduction=flag) for flag in (True, False)}
        for sim in sims.values():
            sim.step(1)  # warm-up
        samples = {True: [], False: []}
        for _ in range(repeats):
            for flag, sim in sims.items():
                samples[flag].append(_rate(sim, steps))
        on, off = statistics.median(samples[True]), statistics.median(samples[False])
        models = {}
        for plan in sims[True].body_models():
            models[plan.model] = models.get(plan.model, 0) + 1
        rows.append({"integrator": name, "bodies": count, "reduced_body_steps_per_s": on, "full_body_steps_per_s": off,
                     "speedup": on / off, "models": ", ".join(f"{k} {v}" for k, v in sorted(models.items()))})
        log(f"  reduction {name}: {on / off:.2f}×")
    return rows
