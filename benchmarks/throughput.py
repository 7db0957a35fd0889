"""Throughput: body-steps per second against the number of bodies N, every system side by side.

The problem: N identical 2 kg 1.0 × 0.6 × 0.4 m boxes (asymmetric: every integrator steps
them, no model reduction applies), 10 m apart, at rest, each spinning at ω = (0.3, 1.0, 0.2)
rad/s (body axes = world axes at the start), no gravity, no applied wrench, h = 1 ms. Every
sample starts from that state (``setup``), so no method drifts into a blow-up.

Rows (``system``, ``integrator``, ``mode``):

* ``rigid_body_sim`` — every integrator, on one thread (``threads=1``, as ``mj_step`` runs;
  benchmarks/threads.py measures the step on every core); ``batched``: ``sim.step(k)``;
  ``per-step``: ``sim.step(1)`` k times in a Python loop;
* ``mujoco`` — ``Euler``, ``implicitfast``, ``RK4`` (the matches of ``semi_implicit_euler``,
  ``implicit_gyroscopic``, ``rk4``); ``batched``: ``mj_step(m, d, nstep=k)``; ``per-step``:
  ``mj_step(m, d)`` k times in a Python loop;
* ``floor`` — the plain numba loop of the same step (benchmarks/floors.py), ``euler`` and ``rk4``;
* ``numpy loop`` — the do-it-yourself loop in plain numpy, one body at a time (floors.py),
  ``euler`` and ``rk4``, up to N = 1000.

Every figure is the median of ≥ 5 interleaved samples (benchmarks/timing.py) with its min–max.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from rigid_body_sim.core import INTEGRATORS, Simulator, load_scene

from . import floors
from . import mujoco_models as mjm
from .timing import Case, interleaved

DT = 1e-3                                    # s
ANGULAR_VELOCITY = np.array([0.3, 1.0, 0.2])  # rad/s, every body's initial spin (body = world axes at t = 0)
MASS = 2.0                                   # kg
SIDES = (1.0, 0.6, 0.4)                      # m
INERTIA_BOX = MASS / 12.0 * np.array([SIDES[1] ** 2 + SIDES[2] ** 2, SIDES[0] ** 2 + SIDES[2] ** 2,
                                      SIDES[0] ** 2 + SIDES[1] ** 2])  # kg·m², principal = body axes
#: MuJoCo refuses models with 65534 or more bodies ("number of bodies plus flexes must be less than 65534").
MUJOCO_MAX_BODIES = 65533
#: Largest N for the numpy/scipy integrators and the do-it-yourself loop (seconds per step beyond).
MAX_BODIES_REFERENCE = 100
MAX_BODIES_NUMPY_LOOP = 1000
#: The N of the headline figures (the targets are at N = 1e4; MuJoCo has no point at 1e5).
HEADLINE_BODIES = 10_000
#: No sample takes more steps than this from the initial state (explicit Euler gains energy every step).
MAX_STEPS_PER_SAMPLE = 200_000


def scene(count: int):
    """The throughput scene: ``count`` tumbling boxes named b0 … b{count-1}."""
    bodies = {f"b{i}": {"mass": MASS, "inertia": {"box": list(SIDES)},
                        "pose": {"position": [10.0 * i, 0.0, 0.0], "orientation": [0, 0, 0, 1]},
                        "twist": {"linear": [0.0, 0.0, 0.0], "angular": ANGULAR_VELOCITY.tolist()}}
              for i in range(count)}
    return load_scene({"bodies": bodies})


def _ours(sim: Simulator, name: str, mode: str) -> Case:
    if mode == "batched":
        run: Callable[[int], object] = sim.step
    else:
        step = sim.step

        def run(k: int) -> None:
            for _ in range(k):
                step(1)
    return Case(("rigid_body_sim", name, mode), run, sim.reset, MAX_STEPS_PER_SAMPLE)


def _mujoco(m, d, name: str, mode: str) -> Case:
    mj_step = mjm.mujoco.mj_step

    def setup() -> None:
        mjm.set_integrator(m, name)
        mjm.reset(m, d, ANGULAR_VELOCITY)

    if mode == "batched":
        def run(k: int) -> None:
            mj_step(m, d, nstep=k)
    else:
        def run(k: int) -> None:
            for _ in range(k):
                mj_step(m, d)
    return Case(("mujoco", name, mode), run, setup, MAX_STEPS_PER_SAMPLE)


def _floor(count: int, name: str) -> Case:
    kernel = floors.FLOORS[name]
    Y0 = floors.initial_rows(count, ANGULAR_VELOCITY)
    Y = Y0.copy()
    inertia = np.tile(INERTIA_BOX, (count, 1))
    kernel(Y, inertia, DT, 1)  # compile (or load from the cache) outside the timing

    def setup() -> None:
        Y[:] = Y0

    return Case(("floor", name, "batched"), lambda k: kernel(Y, inertia, DT, k), setup, MAX_STEPS_PER_SAMPLE)


def _numpy_loop(count: int, name: str) -> Case:
    Y0 = floors.initial_rows(count, ANGULAR_VELOCITY)
    holder: list[floors.NumpyBodies] = []

    def setup() -> None:
        holder[:] = [floors.NumpyBodies(Y0, np.tile(INERTIA_BOX, (count, 1)), np.full(count, MASS), name)]

    def run(k: int) -> None:
        bodies = holder[0]
        for _ in range(k):
            bodies.step(DT)
    return Case(("numpy loop", name, "per-step"), run, setup, MAX_STEPS_PER_SAMPLE)


def cases_at(count: int, integrators: tuple[str, ...] = tuple(INTEGRATORS), with_mujoco: bool = True,
             modes: tuple[str, ...] = ("batched", "per-step")) -> list[Case]:
    """Every case at N = ``count`` (the MuJoCo model is compiled here: seconds at N = 1e4)."""
    s = scene(count)
    cases = []
    for name in integrators:
        if name == "reference" and count > MAX_BODIES_REFERENCE:
            continue
        for mode in modes:
            cases.append(_ours(Simulator(s, integrator=name, dt=DT, threads=1), name, mode))
    if with_mujoco and mjm.available() and count <= MUJOCO_MAX_BODIES:
        m, d = mjm.make(count, INERTIA_BOX, MASS, DT, "Euler")
        for name in mjm.MJ_INTEGRATORS:
            for mode in modes:
                cases.append(_mujoco(m, d, name, mode))
    for name in floors.FLOORS:
        cases.append(_floor(count, name))
    if count <= MAX_BODIES_NUMPY_LOOP:
        for name in ("euler", "rk4"):
            cases.append(_numpy_loop(count, name))
    return cases


def sweep(counts: list[int], repeats: int, min_seconds: float, log=print) -> list[dict]:
    """One row per (system, integrator, mode, N): seconds per step and body-steps/s, median (min–max)."""
    rows = []
    for count in counts:
        stats = interleaved(cases_at(count), repeats, min_seconds)
        for (system, name, mode), s in stats.items():
            rate = s.rate(count)
            per_body_ns = s.scaled(1e9 / count)
            rows.append({"system": system, "integrator": name, "mode": mode, "bodies": count,
                         "peer": peer_of(system, name),
                         **rate.as_row("body_steps_per_s"), **per_body_ns.as_row("ns_per_body_step"),
                         "steps_per_sample": s.units})
        log(f"  throughput N={count} done")
    return rows


def peer_of(system: str, name: str) -> str:
    """The matched method on the other side ('' if none)."""
    if system == "rigid_body_sim":
        return mjm.MATCHED.get(name, "")
    if system == "mujoco":
        return next((ours for ours, theirs in mjm.MATCHED.items() if theirs == name), "")
    return name if system in ("floor", "numpy loop") else ""


def headline_bodies(rows: list[dict]) -> int:
    """HEADLINE_BODIES if the sweep has it, else its largest N."""
    counts = {r["bodies"] for r in rows}
    return HEADLINE_BODIES if HEADLINE_BODIES in counts else max(counts, default=0)
