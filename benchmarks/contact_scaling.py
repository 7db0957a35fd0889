"""How a pile's cost grows with its bodies: 1e3 → 1e5 cubes in heaps side by side, and one pile of 10,000.

``python -m benchmarks.contact_scaling [--part cost|pile] [--quick] [--out benchmarks/results]``
(``make bench-scaling``). Writes ``contact_scaling_<part>.{csv,md}`` to ``--out``. The scene, engines,
settings and readings are those of benchmarks/contact_stacks.py (0.1 m cubes of 1 kg, μ = 0.5, e = 0,
dt = 1 ms, one thread), ours with rk4 (the default) and MuJoCo with its default pyramidal cone.

* **cost**: each engine drops contact_stacks' 1000-cube lattice on the open ground (no bin) for
  ``SETTLE_SECONDS``; the heap's poses (at rest: velocities zero) are copied into k heaps
  ``HEAP_PITCH`` apart, k = 1, 10, 100 (1e3, 1e4, 1e5 cubes; 1 and 10 with ``--quick``). Each
  engine steps its copies ``WARM`` steps, then is timed: MuJoCo from that state (``mj_copyData``), ours
  on from where it is (:func:`snapshot`): µs per step and body-steps/s, medians of ≥ 5 with min–max.
  Linear cost is a flat body-steps/s down the column.
  MuJoCo's arena: ``MUJOCO_MB_PER_CUBE`` MB per cube; it holds fewer than 65,534 bodies (not 1e5).
* **pile**: ``TEN_K`` cubes dropped together into one bin (contact_stacks' lattice, 22 cubes a side)
  for ``TEN_K_SECONDS`` (0.3 s with ``--quick``): finite, deepest penetration and largest energy rise
  read every 10 ms as in contact_stacks, and the cost timed from the state at the end.
"""

from __future__ import annotations

import argparse
import datetime
import math
import sys
from pathlib import Path

import numpy as np

from . import contact_stacks as S
from . import machine
from .timing import MIN_REPEATS, Case, interleaved

SETTLE_SECONDS = 3.0
HEAPS, HEAPS_QUICK = (1, 10, 100), (1, 10)
HEAP_PITCH = 4.0  # m between the centres of two heaps (a heap spreads to about 2.5 m across)
WARM = 20  # steps each engine takes from the copied poses before it is timed
TEN_K, TEN_K_SECONDS, TEN_K_SECONDS_QUICK = 10_000, 1.2, 0.3
MUJOCO_MAX_BODIES = 65534  # "number of bodies plus flexes must be less than 65534" (its model compiler)
MUJOCO_MB_PER_CUBE = 0.5  # its arena: 0.1 MB per cube (contact_stacks) runs out in the pile of 10,000


def heap() -> list[S.Cube]:
    """contact_stacks' 1000-cube lattice without its bin: dropped, it heaps on the open ground."""
    return [c for c in S.pile(1000) if not c.static]


def settled_piles(seconds: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each engine's own heap of 1000 cubes after ``seconds``: {engine name: (positions (1000, 3), orientations
    (1000, 4) (w, x, y, z))}."""
    out = {}
    for engine in engines(heap()):
        engine.step(int(round(seconds / S.DT)))
        p, q, _, _ = engine.sample()
        out[engine.name] = (p, q)
        engine.close()
    return out


def heaps(k: int) -> tuple[list[S.Cube], np.ndarray]:
    """``k`` copies of the 1000-cube lattice of :func:`heap` on a square grid HEAP_PITCH apart: (cubes, their
    offsets (1000 k, 3))."""
    one = heap()
    side = math.ceil(math.sqrt(k))
    cubes, offsets = [], []
    for n in range(k):
        dx, dy = HEAP_PITCH * (n % side), HEAP_PITCH * (n // side)
        for c in one:
            x, y, z = c.position
            cubes.append(S.Cube(c.edge, c.mass, (x + dx, y + dy, z), c.orientation))
            offsets.append((dx, dy, 0.0))
    return cubes, np.array(offsets)


def place(engine, p: np.ndarray, q: np.ndarray, offsets: np.ndarray) -> None:
    """The heaps' cubes put at the poses p, q (w, x, y, z) of a pile (each heap's by its offset), at rest."""
    k = len(offsets) // len(p)
    p, q = np.tile(p, (k, 1)) + offsets, np.tile(q, (k, 1))
    if isinstance(engine, S.Ours):
        Y = engine.sim.state.rows()
        Y[engine.moving, 0:3], Y[engine.moving, 3:7], Y[engine.moving, 7:13] = p, q, 0.0  # rows (p, q_WP, v, w)
        engine.set_rows(Y)
    else:  # MuJoCo: a free joint's qpos is (x, y, z, qw, qx, qy, qz)
        qpos = engine.d.qpos.reshape(-1, 7)
        qpos[:, 0:3], qpos[:, 3:7] = p, q
        engine.d.qvel[:] = 0.0
        S.mujoco.mj_forward(engine.m, engine.d)


def engines(cubes: list[S.Cube]) -> list:
    """Ours, and MuJoCo when it can hold the scene (fewer than MUJOCO_MAX_BODIES bodies)."""
    out = [S.Ours(cubes, "rk4", False)]
    if S.mujoco is not None and len(cubes) < MUJOCO_MAX_BODIES:
        out.append(S.MuJoCo(cubes, "pyramidal", False, memory_per_cube=MUJOCO_MB_PER_CUBE))
    return out


def snapshot(engine):
    """A state to time from: a peer's own snapshot; None for ours, which is timed on from where it is (a copy of a
    whole simulator of 10^5 bodies, its contact buffers included, would not fit in memory, and setting only its
    state rows back resets its contact solver: the warm start and the components held at rest, so every sample
    would time a cold step, not the step of a pile that has been running)."""
    return None if isinstance(engine, S.Ours) else engine.snapshot()


def restore(engine, saved) -> None:
    """Back to :func:`snapshot`'s state (a peer); ours steps on (these heaps and piles run awake, at rest or
    settling: consecutive steps cost alike)."""
    if saved is not None:
        engine.restore(saved)


def cost_rows(quick: bool, log) -> tuple[list[dict], dict[str, str]]:
    log(f"  each engine's 1000-cube pile for {SETTLE_SECONDS:g} s")
    settled = settled_piles(SETTLE_SECONDS)
    rows, settings = [], {}
    for k in HEAPS_QUICK if quick else HEAPS:
        cubes, offsets = heaps(k)
        count = len(offsets)
        cases, owners = [], []
        for engine in engines(cubes):
            if engine.name != S.Ours.name:
                settings[f"{engine.name}, {engine.setting}"] = engine.settings_text()
            place(engine, *settled[engine.name], offsets)
            engine.step(WARM)
            start = snapshot(engine)
            cases.append(Case((engine.name, engine.setting, count), run=engine.step,
                              setup=lambda e=engine, s=start: restore(e, s), max_units=WARM))
            owners.append(engine)
        log(f"  {count} cubes in {k} heaps: timing")
        stats = interleaved(cases, MIN_REPEATS, 0.5, log=log)
        for key, s in stats.items():
            rows.append({"part": "cost", "engine": key[0], "setting": key[1], "bodies": key[2], "heaps": k,
                         **s.scaled(1e6).as_row("us_per_step"), **s.rate(key[2]).as_row("body_steps_per_s")})
        for engine in owners:
            engine.close()
    return rows, settings


def pile_rows(quick: bool, log) -> tuple[list[dict], dict[str, str]]:
    seconds = TEN_K_SECONDS_QUICK if quick else TEN_K_SECONDS
    cubes = S.pile(TEN_K)
    depth = S.Depth(cubes)
    rows, settings = [], {}
    for engine in engines(cubes):
        if engine.name != S.Ours.name:
            settings[f"{engine.name}, {engine.setting}"] = engine.settings_text()
        readings = S.PileReadings(cubes, depth)
        readings.run(engine, seconds)
        log(f"  pile of {TEN_K} {engine.name}: finite {readings.finite}, penetration {readings.deepest:.3g} m, "
            f"energy rise {readings.rise:.3g} J")
        end = snapshot(engine)
        stats = interleaved([Case(0, run=engine.step, setup=lambda e=engine, s=end: restore(e, s), max_units=5)],
                            MIN_REPEATS, 0.5, log=log)[0]
        row = readings.row(engine)
        row.update(part="pile", seconds=seconds, **stats.scaled(1e6).as_row("us_per_step"),
                   **stats.rate(TEN_K).as_row("body_steps_per_s"))
        rows.append(row)
        engine.close()
    return rows, settings


def report(part: str, rows: list[dict], settings: dict[str, str], quick: bool) -> str:
    rate = lambda r: f"{r['body_steps_per_s']:.3g} ({r['body_steps_per_s_min']:.3g}–{r['body_steps_per_s_max']:.3g})"
    step = lambda r: f"{r['us_per_step']:.3g} ({r['us_per_step_min']:.3g}–{r['us_per_step_max']:.3g})"
    lines = [f"From `python -m benchmarks.contact_scaling --part {part}{' --quick' if quick else ''}` "
             f"({datetime.date.today().isoformat()}, commit {machine.git('rev-parse', '--short', 'HEAD')}), "
             f"dt = {S.DT:g} s, μ = {S.MU}, e = 0, one thread.", "", machine.text(), ""]
    if part == "cost":
        lines += [f"**Cost against bodies**: each engine's heap of 1000 cubes after {SETTLE_SECONDS:g} s on the open "
                  f"ground, its poses copied into heaps {HEAP_PITCH:g} m apart at rest, {WARM} steps, then timed:", "",
                  "| engine | setting | cubes | heaps | µs per step | body-steps/s |", "|---|---|---|---|---|---|"]
        lines += [f"| {r['engine']} | {r['setting']} | {r['bodies']} | {r['heaps']} | {step(r)} | {rate(r)} |"
                  for r in rows]
    else:
        lines += [f"**One pile of {TEN_K}** cubes dropped into one bin, {rows[0]['seconds']:g} s (readings every "
                  f"{S.SAMPLE_EVERY * S.DT * 1e3:g} ms; cost timed from the state at the end):", "",
                  "| engine | setting | finite | deepest penetration (m) | largest energy rise (J) | µs per step | "
                  "body-steps/s |", "|---|---|---|---|---|---|---|"]
        lines += [f"| {r['engine']} | {r['setting']} | {'yes' if r['finite'] else 'no'} | {r['penetration']:.3g} | "
                  f"{r['energy_rise']:.3g} | {step(r)} | {rate(r)} |" for r in rows]
    lines += ["", "Settings:", ""] + [f"* **{k}**: {v}" for k, v in settings.items()]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--part", choices=("cost", "pile"), default="cost",
                    help="cost: 1e3 → 1e5 cubes in heaps; pile: one pile of 10,000 (default cost)")
    ap.add_argument("--quick", action="store_true", help="fewer heaps, a shorter pile")
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args(argv)

    def log(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    rows, settings = (cost_rows if args.part == "cost" else pile_rows)(args.quick, log)
    args.out.mkdir(parents=True, exist_ok=True)
    S._write_csv(args.out / f"contact_scaling_{args.part}.csv", rows)
    text = report(args.part, rows, settings, args.quick)
    (args.out / f"contact_scaling_{args.part}.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
