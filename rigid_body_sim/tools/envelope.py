"""The stability envelope of every fixed-step integrator, measured and written to docs/stability.md.

One command regenerates the document (``make envelope`` runs the same)::

    .venv/bin/python -m rigid_body_sim.tools.envelope --out docs/stability.md

What is measured, on torque-free bodies (then |ω|h is the only parameter: h = 1 s, |ω| swept;
time rescales away), with the core's integrator functions on batches of bodies:

* **Envelope**: per integrator and body, the largest |ω|h such that the relative energy error
  ``max_n |E_n / E_0 − 1|`` over ``ENVELOPE_STEPS`` = 1e4 steps stays below
  ``ENERGY_TOLERANCE`` = 1e-3 at every grid point up to it.
* **Long runs**: ``LONG_STEPS`` = 1e6 steps at |ω|h = ``LONG_SPIN_STEP`` = 0.01: the largest
  relative energy and |L| errors seen (sampled every ``LONG_SAMPLE_EVERY`` steps), or the step
  at which the energy error passed 1 (diverged).
* **Unit quaternion**: the largest | |q| − 1 | seen in all of these runs (finite states only).
* **Issue targets**: ``exact_rotor_splitting`` at |ω|h = 4 for I = (1, 2, 3) and at 0.5 for
  the rod r = 1e-6, energy and |L| over 1e4 steps.

Bodies (``BODIES``): I = (1, 2, 3) kg·m² and rods I = (r, 1, 1 + r/2) with r = 1e-3 and 1e-6,
starting at q = identity with ω along ``SPIN_DIRECTION_P`` = (1, 1, 1)/√3 in principal axes
(every axis spins; for (1, 2, 3) it is well off the separatrix, L² = 14/12 · 2E·I2).

The |ω|h search (``stable_limits``): a coarse grid 2^(k/4) over [2^-14, 2^4] ≈ [6.1e-5, 16],
all points as one batch of bodies; then the fine grid 2^(k/32) strictly between the last coarse
point that holds and the first that fails, as a second batch. The limit is the last fine point
before the first fine failure (or that coarse point if the first fine point fails). Resolution:
a factor 2^(1/32) ≈ 1.022; a limit of 2^4 means "at least the top of the grid", 2^-14 with
status ``below`` means "fails already at the bottom of the grid".

This module imports only the core. test/test_stability.py calls the same functions with the
same constants and checks docs/stability.md against fresh measurements.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

from rigid_body_sim.core.integrators import INTEGRATORS
from rigid_body_sim.core.stepping import UncheckedStepper
from rigid_body_sim.core.model import BodyModel, State

__all__ = [
    "ENERGY_TOLERANCE",
    "ENVELOPE_STEPS",
    "LONG_STEPS",
    "LONG_SPIN_STEP",
    "BODIES",
    "SWEPT_INTEGRATORS",
    "Run",
    "torque_free_run",
    "coarse_grid",
    "Envelope",
    "Limit",
    "stable_limits",
    "long_run",
    "issue_targets",
    "measure",
    "render",
    "read_data",
    "main",
]

ENERGY_TOLERANCE = 1e-3  # relative energy error that bounds the envelope
ENVELOPE_STEPS = 10_000
LONG_STEPS = 1_000_000
LONG_SPIN_STEP = 0.01  # |ω|h of the long runs, rad
LONG_SAMPLE_EVERY = 10  # steps between samples of the long runs
SAMPLES_PER_BLOCK = 256  # samples stepped before their errors are evaluated together
DIVERGED_ERROR = 1.0  # a long run whose energy error passes this has diverged; it stops there
GRID_MIN_EXP, GRID_MAX_EXP = -14, 4  # the grid spans [2^-14, 2^4] in |ω|h
COARSE_PER_OCTAVE, FINE_PER_OCTAVE = 4, 32
SPIN_DIRECTION_P = np.ones(3) / np.sqrt(3.0)  # direction of ω in principal axes
BODIES: dict[str, tuple[float, float, float]] = {
    "I = (1, 2, 3)": (1.0, 2.0, 3.0),
    "rod r = 1e-3": (1e-3, 1.0, 1.0 + 0.5e-3),
    "rod r = 1e-6": (1e-6, 1.0, 1.0 + 0.5e-6),
}
#: Every fixed-step method; ``reference`` is adaptive (its error is set by rtol/atol, not h).
SWEPT_INTEGRATORS = tuple(name for name in INTEGRATORS if name != "reference")
#: The issue's targets for the robust integrator: (body, |ω|h).
TARGET_INTEGRATOR = "exact_rotor_splitting"
TARGETS = (("I = (1, 2, 3)", 4.0), ("rod r = 1e-6", 0.5))
TARGET_MOMENTUM_TOLERANCE = 1e-10

_DATA_MARK = "envelope-data"


# ----------------------------------------------------------------------------- runs


@dataclass(frozen=True)
class Run:
    """Result of :func:`torque_free_run` for N bodies.

    Attributes
    ----------
    energy_error : ndarray, shape (N,)
        Largest |E/E0 − 1| over the samples (``inf`` once non-finite).
    momentum_error : ndarray, shape (N,)
        Largest | |L|/|L0| − 1 | over the samples.
    unit_error : float
        Largest | |q| − 1 | over all finite samples of all bodies.
    stopped_at : ndarray of int, shape (N,)
        Step at which the body's energy error first exceeded ``stop_error`` (it was dropped
        from the batch there); −1 if it never did.
    """

    energy_error: np.ndarray
    momentum_error: np.ndarray
    unit_error: float
    stopped_at: np.ndarray


def _model(inertia: np.ndarray) -> BodyModel:
    n = len(inertia)
    return BodyModel(
        names=tuple(f"b{i}" for i in range(n)),
        mass=np.ones(n),
        inertia_P=inertia,
        q_BP=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
        damping_linear=np.zeros(n),
        damping_angular=np.zeros(n),
        gravity_W=np.zeros(3),
    )


def torque_free_run(integrator: str, inertia: np.ndarray, spin_step: np.ndarray, steps: int, *,
                    sample_every: int = 1, stop_error: float = np.inf) -> Run:
    """Integrate torque-free bodies with h = 1 s and record their worst errors.

    Parameters
    ----------
    integrator : str
        A key of INTEGRATORS.
    inertia : array-like, shape (N, 3)
        Principal moments, kg·m².
    spin_step : array-like, shape (N,)
        |ω|h of each body (rad; = |ω| in rad/s since h = 1 s); ω along SPIN_DIRECTION_P.
    steps : int
    sample_every : int
        Steps between samples of E, |L| and |q| (the last step is always sampled).
    stop_error : float
        A body whose energy error exceeds this is dropped from the batch (its maximum can
        only grow; dropping saves time and keeps overflow out).
    """
    inertia = np.asarray(inertia, dtype=float).reshape(-1, 3)
    spin = np.asarray(spin_step, dtype=float).reshape(-1)
    n = len(inertia)
    active = np.arange(n)
    model = _model(inertia)
    state = State(np.zeros((n, 3)), np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)), np.zeros((n, 3)),
                  spin[:, None] * SPIN_DIRECTION_P)
    E0 = 0.5 * np.sum(inertia * state.w_WP_P**2, axis=1)
    L0 = np.linalg.norm(inertia * state.w_WP_P, axis=1)
    energy_error = np.zeros(n)
    momentum_error = np.zeros(n)
    stopped_at = np.full(n, -1)
    unit_error = 0.0
    stepper = UncheckedStepper(integrator, model, 1.0)
    # the sample points: every sample_every steps and the last step
    ends = [*range(sample_every, steps, sample_every), steps] if steps > 0 else []
    done = 0
    with np.errstate(all="ignore"):  # blow-ups are measured, not warned about
        for first in range(0, len(ends), SAMPLES_PER_BLOCK):
            block = ends[first:first + SAMPLES_PER_BLOCK]
            counts = np.diff([done, *block])
            done = block[-1]
            rows = stepper.samples(state, counts)  # (S, n_active, 13): p, q, v, w
            I = inertia[active]
            w = rows[:, :, 10:13]
            e = np.abs(0.5 * np.sum(I * w * w, axis=2) / E0[active] - 1.0)
            m = np.abs(np.linalg.norm(I * w, axis=2) / L0[active] - 1.0)
            u = np.abs(np.linalg.norm(rows[:, :, 3:7], axis=2) - 1.0)
            finite = np.isfinite(rows).all(axis=2)
            e[~finite] = np.inf
            m[~finite] = np.inf
            # a body is sampled up to and including its first sample past stop_error, as if dropped there
            failed = e > stop_error
            last = np.where(failed.any(axis=0), failed.argmax(axis=0), len(block) - 1)
            taken = np.arange(len(block))[:, None] <= last
            if (taken & finite).any():
                unit_error = max(unit_error, float(u[taken & finite].max()))
            energy_error[active] = np.maximum(energy_error[active], np.where(taken, e, 0.0).max(axis=0))
            momentum_error[active] = np.maximum(momentum_error[active], np.where(taken, m, 0.0).max(axis=0))
            dropped = failed.any(axis=0)
            state = State.of_rows(rows[-1])
            if dropped.any():
                stopped_at[active[dropped]] = np.asarray(block)[last[dropped]]
                keep = np.flatnonzero(~dropped)
                if keep.size == 0:
                    break
                active = active[keep]
                model = model.subset(keep)
                state = state.take(keep)
                stepper = UncheckedStepper(integrator, model, 1.0)
    return Run(energy_error, momentum_error, unit_error, stopped_at)


# ----------------------------------------------------------------------------- envelope


def coarse_grid() -> np.ndarray:
    """The coarse |ω|h grid 2^(k/4), k = 4·GRID_MIN_EXP … 4·GRID_MAX_EXP."""
    return 2.0 ** (np.arange(GRID_MIN_EXP * COARSE_PER_OCTAVE, GRID_MAX_EXP * COARSE_PER_OCTAVE + 1) / COARSE_PER_OCTAVE)


@dataclass(frozen=True)
class Limit:
    """The envelope of one integrator on one body.

    Attributes
    ----------
    limit : float
        Largest |ω|h that holds (see the module docstring); the grid bottom if ``status`` is
        ``"below"``, the grid top if ``"top"``.
    status : str
        ``"inside"`` (a failure above it was found), ``"top"`` (holds over the whole grid) or
        ``"below"`` (fails at the bottom of the grid already).
    first_failure : float or None
        The grid point just above ``limit`` that fails (``None`` for ``"top"``).
    """

    limit: float
    status: str
    first_failure: float | None


@dataclass(frozen=True)
class Envelope:
    """Result of :func:`stable_limits`: the limit per body, and the largest | |q| − 1 | seen."""

    limits: dict[str, Limit]
    unit_error: float


def stable_limits(integrator: str, bodies: dict[str, tuple[float, float, float]] | None = None) -> Envelope:
    """The envelope of ``integrator`` on each body: the coarse grid in one batch, then the fine one."""
    bodies = BODIES if bodies is None else bodies
    names = list(bodies)
    grid = coarse_grid()
    inertia = np.repeat(np.array([bodies[b] for b in names]), len(grid), axis=0)
    run = torque_free_run(integrator, inertia, np.tile(grid, len(names)), ENVELOPE_STEPS, stop_error=ENERGY_TOLERANCE)
    holds = (run.energy_error < ENERGY_TOLERANCE).reshape(len(names), len(grid))
    unit_error = run.unit_error
    ratio = FINE_PER_OCTAVE // COARSE_PER_OCTAVE
    out: dict[str, Limit] = {}
    refine: list[tuple[str, int]] = []
    for i, name in enumerate(names):
        if holds[i].all():
            out[name] = Limit(float(grid[-1]), "top", None)
        elif not holds[i, 0]:
            out[name] = Limit(float(grid[0]), "below", float(grid[0]))
        else:
            refine.append((name, int(np.argmin(holds[i]))))  # first coarse failure
    if refine:
        fine_exp = [(GRID_MIN_EXP * COARSE_PER_OCTAVE + f - 1) * ratio + np.arange(1, ratio) for _, f in refine]
        fine = [2.0 ** (e / FINE_PER_OCTAVE) for e in fine_exp]
        inertia = np.repeat(np.array([bodies[name] for name, _ in refine]), ratio - 1, axis=0)
        run = torque_free_run(integrator, inertia, np.concatenate(fine), ENVELOPE_STEPS, stop_error=ENERGY_TOLERANCE)
        fine_holds = (run.energy_error < ENERGY_TOLERANCE).reshape(len(refine), ratio - 1)
        unit_error = max(unit_error, run.unit_error)
        for (name, f), points, ok in zip(refine, fine, fine_holds):
            j = int(np.argmin(ok)) if not ok.all() else len(points)  # first fine failure
            limit = grid[f - 1] if j == 0 else points[j - 1]
            failure = points[j] if j < len(points) else grid[f]
            out[name] = Limit(float(limit), "inside", float(failure))
    return Envelope({name: out[name] for name in names}, unit_error)


def long_run(integrator: str, steps: int = LONG_STEPS) -> Run:
    """``steps`` steps at |ω|h = LONG_SPIN_STEP of every body in BODIES, as one batch."""
    inertia = np.array(list(BODIES.values()))
    return torque_free_run(integrator, inertia, np.full(len(inertia), LONG_SPIN_STEP), steps,
                           sample_every=LONG_SAMPLE_EVERY, stop_error=DIVERGED_ERROR)


def issue_targets() -> Run:
    """TARGET_INTEGRATOR on the TARGETS (body, |ω|h) pairs over ENVELOPE_STEPS, as one batch."""
    inertia = np.array([BODIES[body] for body, _ in TARGETS])
    return torque_free_run(TARGET_INTEGRATOR, inertia, np.array([s for _, s in TARGETS]), ENVELOPE_STEPS)


# ----------------------------------------------------------------------------- the whole measurement


def _task(kind: str, integrator: str) -> tuple[str, str, Any, float]:
    start = time.perf_counter()
    if kind == "envelope":
        envelope = stable_limits(integrator)
        result: Any = {"limits": {name: limit.__dict__ for name, limit in envelope.limits.items()},
                       "unit_error": envelope.unit_error}
    elif kind == "long":
        run = long_run(integrator)
        result = {"energy_error": run.energy_error.tolist(), "momentum_error": run.momentum_error.tolist(),
                  "unit_error": run.unit_error, "stopped_at": run.stopped_at.tolist()}
    else:
        run = issue_targets()
        result = {"energy_error": run.energy_error.tolist(), "momentum_error": run.momentum_error.tolist(),
                  "unit_error": run.unit_error}
    return kind, integrator, result, time.perf_counter() - start


def measure(integrators: tuple[str, ...] = SWEPT_INTEGRATORS, *, long: bool = True, jobs: int = 1) -> dict:
    """Every measurement of the document, as plain data (see :func:`render`)."""
    tasks = [("targets", TARGET_INTEGRATOR)] + [("envelope", name) for name in integrators]
    if long:
        tasks = [("long", name) for name in integrators] + tasks  # the long ones first: better packing
    start = time.perf_counter()
    if jobs > 1:
        with ProcessPoolExecutor(max_workers=jobs, mp_context=get_context("spawn")) as pool:
            results = list(pool.map(_task, *zip(*tasks)))
    else:
        results = [_task(kind, name) for kind, name in tasks]
    data: dict[str, Any] = {"envelope": {}, "long": {}, "seconds": {}}
    for kind, name, result, seconds in results:
        if kind == "targets":
            data["targets"] = result
        else:
            data[kind][name] = result
        data["seconds"][f"{kind}:{name}"] = round(seconds, 1)
    data["wall_seconds"] = round(time.perf_counter() - start, 1)
    data["jobs"] = jobs
    data["integrators"] = list(integrators)
    data["bodies"] = {name: list(inertia) for name, inertia in BODIES.items()}
    data["environment"] = (f"Python {platform.python_version()}, numpy {np.__version__}, "
                           f"{os.cpu_count()} CPUs, {platform.machine()}")
    return data


# ----------------------------------------------------------------------------- the document


def _fmt(x: float) -> str:
    return f"{x:.2g}" if x >= 0.01 else f"{x:.1e}"


def _limit_cell(limit: dict) -> str:
    if limit["status"] == "top":
        return f"≥ {_fmt(limit['limit'])} (grid top)"
    if limit["status"] == "below":
        return f"< {_fmt(limit['limit'])} (grid bottom)"
    return _fmt(limit["limit"])


def _error_cell(error: float, stopped_at: int | None = None) -> str:
    if stopped_at is not None and stopped_at >= 0:
        return f"diverged (step {stopped_at:,})"
    return f"{error:.1e}"


def render(data: dict) -> str:
    """docs/stability.md from :func:`measure`'s data (which it embeds, for the tests)."""
    bodies = list(data["bodies"])
    lines = [
        "# Stability envelope of the integrators",
        "",
        "Generated by `.venv/bin/python -m rigid_body_sim.tools.envelope --out docs/stability.md`",
        "(`make envelope`); do not edit by hand. `test/test_stability.py` re-measures the",
        "envelope columns in the default test run and everything in the slow run",
        "(`.venv/bin/python -m pytest -m slow`), and fails if this file disagrees.",
        "",
        "Torque-free bodies starting at q = identity with ω along (1, 1, 1)/√3 in principal axes:",
        "I = (1, 2, 3) kg·m² and thin rods I = (r, 1, 1 + r/2). For a free body only |ω|h matters",
        "(high spin and large steps are the same test). Definitions and the search are in",
        "`rigid_body_sim/tools/envelope.py`.",
        "",
        f"## Largest |ω|h with relative energy error < {ENERGY_TOLERANCE:g} over {ENVELOPE_STEPS:,} steps",
        "",
        f"Grid 2^(k/{COARSE_PER_OCTAVE}) over [2^{GRID_MIN_EXP}, 2^{GRID_MAX_EXP}], refined to 2^(k/{FINE_PER_OCTAVE}) "
        f"near the limit: resolution a factor {2 ** (1 / FINE_PER_OCTAVE):.3f}.",
        "",
        "| integrator | " + " | ".join(bodies) + " |",
        "|---" * (len(bodies) + 1) + "|",
    ]
    for name in data["integrators"]:
        cells = [_limit_cell(data["envelope"][name]["limits"][b]) for b in bodies]
        lines.append(f"| `{name}` | " + " | ".join(cells) + " |")
    lines.append("| `reference` | adaptive (DOP853, rtol = atol = 1e-12): its error is set by the tolerances, "
                 "not by h; not swept | | |")
    lines += ["",
              "Beyond its limit each method fails in its own way (test/test_stability.py checks each):",
              "`euler` and `semi_implicit_euler` gain energy every step and blow up (|ω|h = 0.1 trips the",
              "simulator's DivergenceError within ~1000 steps); `implicit_gyroscopic` has no limit on a free",
              "body (its implicit-midpoint rotor keeps energy and |L| exactly at any |ω|h, taking a step",
              "as several where Newton's method needs it); `rk4` loses energy beyond it and blows up once h",
              "times the body's fastest rate passes",
              "its stability bound 2√2 (rods and spins near the intermediate axis at |ω|h ≈ 3, within a few",
              "hundred steps); `splitting` and `symmetric_splitting` keep |L| exactly, but their energy wanders",
              "within what |L| allows (|L|²/2I_max … |L|²/2I_min: far, for a thin rod); `exact_rotor_splitting`",
              "has no limit on a free body (it is the exact flow).",
              "",
              f"## {LONG_STEPS:,} steps at |ω|h = {LONG_SPIN_STEP:g}",
              "",
              f"Largest relative error seen (sampled every {LONG_SAMPLE_EVERY} steps); a run whose energy error "
              f"passes {DIVERGED_ERROR:g} is reported as diverged at that step. The last column is the largest "
              f"| \\|q\\| − 1 | seen in every run of this document (long, envelope and targets).",
              ""]
    if data["long"]:
        lines += ["| integrator | " + " | ".join(f"energy, {b}" for b in bodies) + " | "
                  + " | ".join(f"\\|L\\|, {b}" for b in bodies) + " | largest \\| \\|q\\| − 1 \\| |",
                  "|---" * (2 * len(bodies) + 2) + "|"]
        for name in data["integrators"]:
            run = data["long"][name]
            energy = [_error_cell(run["energy_error"][i], run["stopped_at"][i]) for i in range(len(bodies))]
            momentum = ["—" if run["stopped_at"][i] >= 0 else _error_cell(run["momentum_error"][i])
                        for i in range(len(bodies))]
            unit = max(run["unit_error"], data["envelope"][name]["unit_error"],
                       data["targets"]["unit_error"] if name == TARGET_INTEGRATOR else 0.0)
            lines.append(f"| `{name}` | " + " | ".join(energy + momentum) + f" | {unit:.1e} |")
    else:
        lines.append("(not measured: generated with --no-long)")
    targets = data["targets"]
    lines += ["",
              "## The issue's targets",
              "",
              f"`{TARGET_INTEGRATOR}` over {ENVELOPE_STEPS:,} steps (goal: energy < {ENERGY_TOLERANCE:g}, "
              f"|L| < {TARGET_MOMENTUM_TOLERANCE:g}):",
              ""]
    for i, (body, spin) in enumerate(TARGETS):
        lines.append(f"- {body}, |ω|h = {spin:g}: relative energy error {targets['energy_error'][i]:.1e}, "
                     f"|L| error {targets['momentum_error'][i]:.1e}")
    lines += ["",
              "## How it was made",
              "",
              f"{data['environment']}; {data['jobs']} worker process(es); {data['wall_seconds']:g} s wall time.",
              "",
              f"<!-- {_DATA_MARK}",
              json.dumps(data, indent=1, sort_keys=True),
              "-->",
              ""]
    return "\n".join(lines)


def read_data(path: str | Path) -> dict:
    """The data embedded in a document written by :func:`render`."""
    text = Path(path).read_text(encoding="utf-8")
    match = re.search(rf"<!-- {_DATA_MARK}\n(.*?)\n-->", text, flags=re.S)
    if match is None:
        raise ValueError(f"{path}: no '{_DATA_MARK}' block; regenerate it with python -m rigid_body_sim.tools.envelope")
    return json.loads(match.group(1))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rigid_body_sim.tools.envelope", description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=Path("docs/stability.md"), help="markdown file to write")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes (default: CPUs)")
    parser.add_argument("--no-long", action="store_true", help="skip the 1e6-step runs (a quick look)")
    parser.add_argument("--integrators", nargs="+", default=list(SWEPT_INTEGRATORS), choices=SWEPT_INTEGRATORS)
    args = parser.parse_args(argv)
    data = measure(tuple(args.integrators), long=not args.no_long, jobs=max(1, args.jobs))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(render(data), encoding="utf-8")
    print(f"wrote {args.out} in {data['wall_seconds']:g} s ({data['jobs']} jobs)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
