"""Work-precision: error against wall time and against h, every integrator of ours beside MuJoCo's.

For each problem of ``benchmarks/problems.py`` and each step h = T / (CHECKPOINTS · n), one run
integrates the horizon T and reads the state at the CHECKPOINTS; a row keeps the maximum
errors and the wall time of the stepping calls only (read-outs excluded), the median of ≥ 5
runs interleaved across systems at that h.

* Ours, batched: per checkpoint ``sim.step(n)`` (``box``: ``apply_force_at_point(b, F,
  (0, 0, 0), frame="b/corner")`` first, held over the n steps).
* MuJoCo, batched as its docs recommend: per checkpoint ``mj_step(m, d, nstep=n)`` (``box``:
  ``d.ctrl[0] = 10`` on the site motor, set once), integrators Euler, implicitfast, RK4.

A series stops refining once its error is below 1e-12 (finer steps only add
round-off) or a run took longer than ``budget_s`` (the numpy/scipy integrators at fine h);
the row says which.
"""

from __future__ import annotations

import math
import time

import numpy as np

from rigid_body_sim.core import INTEGRATORS, NonFiniteStateError, Simulator

from . import mujoco_models as mjm
from . import problems as P
from .timing import MIN_REPEATS, Stats

#: Below this error (rad or m) a series is converged: no finer h is run.
CONVERGED = 1e-12
QUICK_STEPS_PER_CHECKPOINT = (1, 2, 5, 10, 20, 25, 50, 100, 200, 500)
FULL_STEPS_PER_CHECKPOINT = (1, 2, 3, 5, 7, 10, 15, 20, 25, 30, 50, 70, 100, 150, 200, 300, 500, 700, 1000, 2000)
#: Accuracy goals of the cost tables: rad on ``top``, m on ``box``.
TARGETS = {"top": (1e-3, 1e-6, 1e-9), "box": (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9)}


def _xyzw_to_wxyz(q: np.ndarray) -> np.ndarray:
    return np.array([q[3], q[0], q[1], q[2]])


class OurRun:
    """One of our integrators on a problem at n steps per checkpoint."""

    system = "rigid_body_sim"

    def __init__(self, problem: str, integrator: str, n: int):
        self.problem, self.integrator, self.n = problem, integrator, n
        self.h = P.horizon(problem) / (P.CHECKPOINTS * n)
        self.scene = P.scene(problem)

    def __call__(self) -> tuple[float, dict]:
        sim = Simulator(self.scene, integrator=self.integrator, dt=self.h)
        apply, step, n = sim.apply_force_at_point, sim.step, self.n
        force, origin = P.BOX_FORCE_S, np.zeros(3)
        box = self.problem == "box"
        q, w, p = [], [], []
        elapsed = 0.0
        for _ in range(P.CHECKPOINTS):
            t0 = time.perf_counter()
            if box:
                apply("b", force, origin, "b/corner")
            step(n)
            elapsed += time.perf_counter() - t0
            s = sim.body_state("b")
            q.append(_xyzw_to_wxyz(s.orientation_xyzw))
            w.append(s.angular_velocity_body)
            p.append(s.position_world)
        times = np.arange(1, P.CHECKPOINTS + 1) * n * self.h
        return elapsed, P.errors(self.problem, times, np.array(q), np.array(w), np.array(p))


class MujocoRun:
    """One of MuJoCo's integrators on a problem at n steps per checkpoint (mj_step with nstep)."""

    system = "mujoco"

    def __init__(self, problem: str, integrator: str, n: int):
        self.problem, self.integrator, self.n = problem, integrator, n
        self.h = P.horizon(problem) / (P.CHECKPOINTS * n)
        site = tuple(P.BOX_SITE_B) if problem == "box" else None
        self.m, self.d = mjm.make(1, P.inertia(problem), P.mass(problem), self.h, integrator, site=site)

    def __call__(self) -> tuple[float, dict]:
        mujoco = mjm.mujoco
        m, d, n = self.m, self.d, self.n
        mujoco.mj_resetData(m, d)
        if self.problem == "top":
            d.qvel[3:6] = P.TOP_W0_B
        else:
            d.ctrl[0] = P.BOX_FORCE_S[1]  # the motor's gear is the site's y axis
        mj_step = mujoco.mj_step
        q, w, p = [], [], []
        elapsed = 0.0
        for _ in range(P.CHECKPOINTS):
            t0 = time.perf_counter()
            mj_step(m, d, nstep=n)
            elapsed += time.perf_counter() - t0
            q.append(d.qpos[3:7].copy())
            w.append(d.qvel[3:6].copy())
            p.append(d.qpos[0:3].copy())
        if any(d.warning[int(w)].number for w in (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQVEL,
                                                     mujoco.mjtWarning.mjWARN_BADQPOS)):
            # MuJoCo resets the state when it meets a non-finite or huge value: a blow-up
            raise MujocoDiverged(f"MuJoCo {self.integrator} reset after a non-finite or huge value at h = {self.h:g}")
        times = np.arange(1, P.CHECKPOINTS + 1) * n * self.h
        return elapsed, P.errors(self.problem, times, np.array(q), np.array(w), np.array(p))


class MujocoDiverged(RuntimeError):
    """MuJoCo met a non-finite or huge value and reset its state (its warning counters say so)."""


def series(problems=P.PROBLEMS) -> list[tuple[str, str, str]]:
    """(problem, system, integrator) of every curve."""
    out = []
    for problem in problems:
        out += [(problem, "rigid_body_sim", name) for name in INTEGRATORS]
        if mjm.available():
            out += [(problem, "mujoco", name) for name in mjm.MJ_INTEGRATORS]
    return out


def sweep(steps_per_checkpoint=QUICK_STEPS_PER_CHECKPOINT, repeats: int = MIN_REPEATS, budget_s: float = 0.5,
          problems=P.PROBLEMS, log=print) -> list[dict]:
    """Every (problem, system, integrator, h): errors and wall time, median (min–max) of ``repeats``."""
    rows: list[dict] = []
    for problem in problems:
        stopped: dict[tuple[str, str], str] = {}  # series → why it stopped refining
        for n in steps_per_checkpoint:
            h = P.horizon(problem) / (P.CHECKPOINTS * n)
            runs = []
            for _problem, system, name in series((problem,)):
                base = {"problem": problem, "system": system, "integrator": name, "h": h, "steps": n * P.CHECKPOINTS}
                if (system, name) in stopped:
                    continue
                runs.append((base, (OurRun if system == "rigid_body_sim" else MujocoRun)(problem, name, n)))
            times: dict[int, list[float]] = {i: [] for i in range(len(runs))}
            result: dict[int, dict] = {}
            for _ in range(repeats):
                for i, (base, run) in enumerate(runs):
                    if i in result and "note" in result[i]:
                        continue
                    try:
                        elapsed, err = run()
                    except (NonFiniteStateError, MujocoDiverged) as exc:  # a blow-up is a result, not a crash
                        result[i] = {"note": type(exc).__name__}
                        continue
                    times[i].append(elapsed)
                    result[i] = err
            for i, (base, _run) in enumerate(runs):
                key = (base["system"], base["integrator"])
                if "note" in result[i]:
                    rows.append({**base, "time_s": math.nan, "us_per_step": math.nan, "note": result[i]["note"]})
                    continue
                t = Stats.of(times[i], 1)
                err = result[i]
                rows.append({**base, **t.as_row("time_s"), "us_per_step": 1e6 * t.median / base["steps"], **err,
                             "note": ""})
                if err[P.ERROR_KEY[problem][0]] < CONVERGED:
                    stopped[key] = "converged"
                elif t.median > budget_s:
                    stopped[key] = "cost"
            log(f"  work-precision {problem} h={h:.3g} done ({len(runs)} series)")
        for (system, name), why in stopped.items():
            rows.append({"problem": problem, "system": system, "integrator": name, "h": math.nan, "steps": 0,
                         "time_s": math.nan, "us_per_step": math.nan,
                         "note": f"finer h not run: {'error below %g' % CONVERGED if why == 'converged' else 'run over %g s' % budget_s}"})
    return rows


def curve(rows: list[dict], problem: str, system: str, integrator: str, key: str | None = None) -> list[tuple[float, float, float]]:
    """(h, time_s, error) of one series, h descending, finite points only."""
    key = key or P.ERROR_KEY[problem][0]
    pts = [(r["h"], r["time_s"], r[key]) for r in rows if r["problem"] == problem and r["system"] == system
           and r["integrator"] == integrator and math.isfinite(r.get("time_s", math.nan))
           and math.isfinite(r.get(key, math.nan))]
    return sorted(pts, reverse=True)


def cost_at_error(rows: list[dict], problem: str, system: str, integrator: str, target: float) -> dict:
    """Wall time (and h) to reach ``target`` error: log-log interpolation between the sweep's points.

    The coarsest h whose error is ≤ target, interpolated against the point before it (the
    error curve is monotone in h for these methods over the sweep); NaN if never reached.
    ``h_grid``: the largest h of the sweep itself that reached the target (no interpolation:
    a claim a test can re-measure).
    """
    pts = curve(rows, problem, system, integrator)
    for j, (h1, t1, e1) in enumerate(pts):
        if e1 <= target:
            if j == 0 or e1 <= 0.0:
                return {"time_s": t1, "h": h1, "h_grid": h1, "error_at_h_grid": e1}
            h0, t0, e0 = pts[j - 1]
            s = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return {"time_s": math.exp(math.log(t0) + s * (math.log(t1) - math.log(t0))),
                    "h": math.exp(math.log(h0) + s * (math.log(h1) - math.log(h0))), "h_grid": h1,
                    "error_at_h_grid": e1}
    return {"time_s": math.nan, "h": math.nan, "h_grid": math.nan, "error_at_h_grid": math.nan}


def observed_order(rows: list[dict], problem: str, system: str, integrator: str, h_fine: float,
                   ratio: float = 4.0) -> float:
    """log(e(ratio·h_fine) / e(h_fine)) / log(ratio) from the sweep (NaN if either point is missing)."""
    pts = {round(math.log(h), 9): e for h, _t, e in curve(rows, problem, system, integrator)}
    e_fine = pts.get(round(math.log(h_fine), 9))
    e_coarse = pts.get(round(math.log(ratio * h_fine), 9))
    if not e_fine or not e_coarse:
        return math.nan
    return math.log(e_coarse / e_fine) / math.log(ratio)
