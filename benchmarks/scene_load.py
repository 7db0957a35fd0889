"""Scene load time with collision shapes and a ground, with and without the body–body overlap check.

N bodies (spheres, boxes, cylinders by their inertia, capsules by ``collision``; largest half
diagonal 0.18 m, random orientations) on a jittered 0.5 m lattice above a ground, so none
overlaps: the check runs to the end. Times ``load_scene_text`` of the scene's JSON text with
``apart=True`` (the default: the broad and narrow phase over every body) and ``apart=False``
(the other checks only), and the check alone (``query.overlapping_bodies`` on the loaded
scene's arrays), median [min–max] of 5, after one warm-up that also loads the compiled kernels. Run: ``python -m benchmarks.scene_load``; writes benchmarks/results/scene_load.md.
"""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import numpy as np

SPACING = 0.5  # m
OUT = Path(__file__).resolve().parent / "results" / "scene_load.md"


def scene_text(n: int, seed: int = 0) -> str:
    rng = np.random.default_rng(seed)
    side = int(np.ceil(n ** (1.0 / 3.0)))
    bodies = {}
    for k in range(n):
        ix, iy, iz = k % side, (k // side) % side, k // (side * side)
        pos = np.round(np.array([ix, iy, iz + 1.0]) * SPACING + rng.uniform(-0.05, 0.05, 3), 4).tolist()
        q = rng.normal(size=4)
        q = np.round(q / np.linalg.norm(q), 7).tolist()  # within the loader's unit-norm tolerance
        body = {"mass": 1.0, "pose": {"position": pos, "orientation": q}}
        kind = k % 4
        if kind == 0:
            body["inertia"] = {"sphere": round(float(rng.uniform(0.05, 0.1)), 4)}
        elif kind == 1:
            body["inertia"] = {"box": np.round(rng.uniform(0.1, 0.2, 3), 4).tolist()}
        elif kind == 2:
            body["inertia"] = {"cylinder": np.round([rng.uniform(0.05, 0.1), rng.uniform(0.1, 0.2)], 4).tolist()}
        else:
            body["inertia"] = {"sphere": 0.08}
            body["collision"] = {"capsule": np.round([rng.uniform(0.04, 0.08), rng.uniform(0.05, 0.15)], 4).tolist()}
        bodies[f"b{k}"] = body
    return json.dumps({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0.0, 0.0, 1.0], "offset": 0.0}],
                       "bodies": bodies}, separators=(",", ":"))


def run(n: int, apart: bool, repeats: int = 5) -> tuple[float, float, float]:
    from rigid_body_sim.core.scene import load_scene_text
    text = scene_text(n)
    load_scene_text(text, apart=apart)
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        load_scene_text(text, apart=apart)
        times.append(time.perf_counter() - t)
    return float(np.median(times)), min(times), max(times)


def check_alone(n: int, repeats: int = 5) -> tuple[float, float, float]:
    from rigid_body_sim.core.contact.query import overlapping_bodies
    from rigid_body_sim.core.quaternion import quat_conjugate, quat_multiply
    from rigid_body_sim.core.scene import load_scene_text
    scene = load_scene_text(scene_text(n), apart=False)
    q_WB = quat_multiply(scene.initial_state.q_WP, quat_conjugate(scene.model.q_BP))
    moving = np.ones(n, dtype=bool)
    times = []
    for _ in range(repeats + 1):
        t = time.perf_counter()
        assert not overlapping_bodies(scene.initial_state.p_WC_W, q_WB, scene.contact.shapes, moving)
        times.append(time.perf_counter() - t)
    times = times[1:]
    return float(np.median(times)), min(times), max(times)


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def table(sizes=(1_000, 10_000, 100_000)) -> list[str]:
    lines = [f"Scene load with a ground and collision shapes (CPU: {_cpu()}; median [min–max] of 5):", "",
             "| N | load, overlap check on | load, check off | the check alone | check per body |",
             "|---|---|---|---|---|"]
    for n in sizes:
        on, off, alone = run(n, True), run(n, False), check_alone(n)
        lines.append(f"| {n} | {on[0]:.3f} s [{on[1]:.3f}–{on[2]:.3f}] | {off[0]:.3f} s [{off[1]:.3f}–{off[2]:.3f}] "
                     f"| {alone[0] * 1e3:.2f} ms [{alone[1] * 1e3:.2f}–{alone[2] * 1e3:.2f}] | {alone[0] / n * 1e9:.0f} ns |")
    return lines


if __name__ == "__main__":
    import sys
    sizes = tuple(int(a) for a in sys.argv[1:]) or (1_000, 10_000, 100_000)
    out = "\n".join(table(sizes)) + "\n"
    print(out)
    OUT.write_text(out)
