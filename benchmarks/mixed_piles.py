"""Mixed piles of fast bodies: how deep bodies end inside each other, a wall or the ground (docs/contact.md).

Each seed is one run of test/test_contact_islands.py's ``mixed_pile`` (spheres, boxes, capsules and cylinders
thrown spinning into a bin) over 2 s, its settings drawn from the seed: 27, 64, 125 or 216 bodies (at most 64 at
dt = 1 ms), restitution up to 0 or 0.5, rk4 or semi-implicit Euler, dt 1, 5 or 10 ms (15, 30 and 55 %), sleeping
on or off, penetration tolerance 0, 1e-5 or 1e-3 m. A seed whose bodies start overlapping is skipped. Every 10th
step it reads the deepest overlap of two moving bodies and of a moving body with a wall (contact.query's
overlapping_bodies) or the ground (the shape's support along the ground's normal), and K + U's rise above its
lowest earlier reading, relative to it.

    python -m benchmarks.mixed_piles run 0 200 piles.txt     # one line per seed, appended
    python -m benchmarks.mixed_piles summary piles.txt       # per dt: runs, median, runs beyond tolerance

A run is beyond its tolerance where an overlap is deeper than the tolerance + 1e-9 m; body into body, also
counted where deeper than that beyond the pair pass's skin (ADVANCE_SKIN × the pair's larger size, the depth
two bodies may end a step at between the pass's events: docs/contact.md).
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

TEST = Path(__file__).resolve().parent.parent / "test"


def settings(seed: int) -> dict:
    """The run's settings, drawn from its seed."""
    rng = np.random.default_rng(10_000 + seed)
    count = int(rng.choice([27, 64, 125, 216]))
    restitution = float(rng.choice([0.0, 0.5]))
    integrator = str(rng.choice(["rk4", "semi_implicit_euler"]))
    dt = float(rng.choice([1e-3, 5e-3, 1e-2], p=[0.15, 0.3, 0.55]))
    sleeping, tolerance = bool(rng.integers(2)), float(rng.choice([0.0, 1e-5, 1e-3]))
    return {"n": min(count, 64) if dt == 1e-3 else count, "e": restitution, "integrator": integrator, "dt": dt,
            "sleep": sleeping, "tol": tolerance}


def ground_depth(sim, moving: np.ndarray) -> float:
    """The deepest moving body below the ground z = 0 (m; 0 if none): its shape's support along −z."""
    from rigid_body_sim.core.kernels.contact.layout import DIMS, KIND, SHAPE_BOX, SHAPE_CAPSULE, SHAPE_SPHERE
    x, y, z, w = sim.orientations_xyzw().T
    zrow = np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1)  # R's row z
    kind, d = sim.contact.shapes[:, KIND], sim.contact.shapes[:, DIMS:DIMS + 3]
    along = np.abs(zrow[:, 2])  # a cylinder's or capsule's axis (body z) along the ground's normal
    across = np.hypot(zrow[:, 0], zrow[:, 1])  # its sine from the row's other entries: √(1 − along²) would put
    # a can standing upright (along = 1 − 4e-16) 3e-9 m deep
    reach = np.where(kind == SHAPE_SPHERE, d[:, 0],
                     np.where(kind == SHAPE_BOX, (np.abs(zrow) * d).sum(axis=1),
                              np.where(kind == SHAPE_CAPSULE, d[:, 1] * along + d[:, 0],
                                       d[:, 1] * along + d[:, 0] * across)))
    return max(0.0, float(-(sim.positions_world()[:, 2] - reach)[moving].min()))


def run(seed: int) -> str:
    sys.path.insert(0, str(TEST))
    from test_contact_islands import mixed_pile

    from rigid_body_sim.core.contact.body_pairs import ADVANCE_SKIN
    from rigid_body_sim.core.contact.query import overlapping_bodies
    from rigid_body_sim.core.scene import SceneError, load_scene
    from rigid_body_sim.core.simulator import Simulator

    s = settings(seed)
    head = f"seed={seed} n={s['n']}"
    try:
        scene = load_scene(mixed_pile(s["n"], seed, s["e"]))
    except SceneError as error:  # bodies that start inside each other
        return f"{head} skipped: {str(error)[:80]}"
    start = time.perf_counter()
    sim = Simulator(scene, integrator=s["integrator"], dt=s["dt"])
    sim.contact.sleeping, sim.contact.penetration_tolerance = s["sleep"], s["tol"]
    moving = np.array([m != "static" for m in sim.model.motions])
    steps = int(round(2.0 / s["dt"]))
    body = skinned = wall = ground = rise = 0.0
    size = sim.contact.pairs.size
    lowest, finite, worst = math.inf, True, "-"
    for k in range(1, steps + 1):
        sim.step()
        if k % 10 and k != steps:
            continue
        if not np.all(np.isfinite(sim.state.rows())):
            finite = False
            break
        for a, b, depth in overlapping_bodies(sim.positions_world(), sim.orientations_xyzw()[:, [3, 0, 1, 2]],
                                              sim.contact.shapes, moving):
            if moving[a] and moving[b]:
                if depth > body:
                    body, worst = depth, f"{a}-{b}@{k * s['dt']:.3f}s"
                skinned = max(skinned, depth - ADVANCE_SKIN * max(size[a], size[b]))
            else:
                wall = max(wall, depth)
        ground = max(ground, ground_depth(sim, moving))
        energy = float(sim.kinetic_energy().sum() + sim.potential_energy().sum())
        if energy > lowest:
            rise = max(rise, (energy - lowest) / abs(lowest))
        lowest = min(lowest, energy)
    return (f"{head} e={s['e']} integrator={s['integrator']} dt={s['dt']} sleep={s['sleep']} tol={s['tol']} "
            f"finite={finite} body={body:.3e} skinned={skinned:.3e} wall={wall:.3e} ground={ground:.3e} rise={rise:.2e} worst={worst} "
            f"seconds={time.perf_counter() - start:.0f}")


def summary(paths: list[str]) -> None:
    runs = [dict(kv.split("=", 1) for kv in line.split() if "=" in kv)
            for path in paths for line in Path(path).read_text().splitlines() if "skipped" not in line and line.strip()]
    print(f"{len(runs)} runs, all finite: {all(r['finite'] == 'True' for r in runs)}")
    for dt in ("0.001", "0.005", "0.01"):
        rows = [r for r in runs if r["dt"] == dt]
        if not rows:
            continue
        deepest = [max(float(r[c]) for c in ("body", "wall", "ground")) for r in rows]
        beyond = {c: sorted((float(r[c]), int(r["seed"])) for r in rows if float(r[c]) > float(r["tol"]) + 1e-9)
                  for c in ("body", "wall", "ground")}
        n_beyond = sum(any(float(r[c]) > float(r["tol"]) + 1e-9 for c in beyond) for r in rows)
        rises = sorted((float(r["rise"]), int(r["seed"]), r["integrator"], r["tol"]) for r in rows
                       if float(r["rise"]) > 1e-9)
        parts = [f"{c} {len(v)}" + (f" (deepest {v[-1][0]:.2g} m, seed {v[-1][1]})" if v else "")
                 for c, v in beyond.items()]
        skin = sorted((float(r["skinned"]), int(r["seed"])) for r in rows if "skinned" in r
                      and float(r["skinned"]) > float(r["tol"]) + 1e-9)
        parts[0] += f", {len(skin)} beyond the pair pass's skin" + (f" (by {skin[-1][0]:.2g} m, seed {skin[-1][1]})"
                                                                      if skin else "")
        print(f"dt = {dt} s: {len(rows)} runs, median deepest {np.median(deepest):.2g} m, beyond tolerance "
              f"{n_beyond}: {', '.join(parts)}; K + U rise > 1e-9: {len(rises)}"
              + (f", at most {rises[-1][0]:.2g} (" + ", ".join(f"seed {s} {i} tol {t}" for _, s, i, t in rises) + ")"
                 if rises else ""))


def main(argv: list[str]) -> None:
    if len(argv) == 4 and argv[0] == "run":
        for seed in range(int(argv[1]), int(argv[2])):
            line = run(seed)
            with open(argv[3], "a") as out:
                print(line, file=out)
    elif len(argv) >= 2 and argv[0] == "summary":
        summary(argv[1:])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
