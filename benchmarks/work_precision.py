"""Work-precision: error against CPU time and against h, for every integrator and MuJoCo's.

Each run integrates one problem of :mod:`benchmarks.problems` over its horizon with a fixed
step h and records, at CHECKPOINTS equally spaced times, the orientation (geodesic angle),
body-rate, energy, |L| and (box) COM-velocity errors; a row keeps the maxima. The time is
the wall time (perf_counter) of the stepping loop — the wrench applied before each step
included — the median of ``repeats`` runs.
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

from rigid_body_sim.core import INTEGRATORS, Simulator

from . import mujoco_models as mjm
from . import problems as P


def _errors(problem: str, times: np.ndarray, q: np.ndarray, w: np.ndarray, v: np.ndarray | None) -> dict:
    ref = P.reference(problem, times)
    out = {"err_angle": float(np.max(P.geodesic_angle(ref["q"], q))),
           "err_w": float(np.max(np.linalg.norm(w - ref["w"], axis=1)) / max(np.max(np.linalg.norm(ref["w"], axis=1)), 1e-300))}
    e, L = P.invariants(problem, w)
    e_ref, L_ref = P.invariants(problem, ref["w"])
    out["err_energy"] = float(np.max(np.abs(e - e_ref) / np.maximum(e_ref, 1e-300)))
    out["err_L"] = float(np.max(np.abs(L - L_ref) / np.maximum(L_ref, 1e-300)))
    if v is not None and "v" in ref:
        out["err_v"] = float(np.max(np.linalg.norm(v - ref["v"], axis=1)) / np.max(np.linalg.norm(ref["v"], axis=1)))
    else:
        out["err_v"] = math.nan
    return out


def run_ours(problem: str, integrator: str, steps_per_checkpoint: int) -> tuple[float, dict]:
    """One run of rigid_body_sim: (seconds of the stepping loop, error dict)."""
    T = P.horizon(problem)
    h = T / (P.CHECKPOINTS * steps_per_checkpoint)
    sim = Simulator(P.scene(problem), integrator=integrator, dt=h)
    n = steps_per_checkpoint
    q, w, v = [], [], []
    t0 = time.perf_counter()
    for k in range(P.CHECKPOINTS):
        if problem == "top":
            sim.step(n)
        elif problem == "forced":
            for i in range(n):
                t = (k * n + i + 0.5) * h  # midpoint sample of the forcing (held over the step)
                sim.apply_wrench("b", torque=P.forced_torque_B(t), frame="b")
                sim.step(1)
        else:
            for _ in range(n):
                sim.apply_force_at_point("b", P.BOX_FORCE_B, P.BOX_POINT_B, frame="b")
                sim.step(1)
        q.append(sim.state.q_WP[0].copy())
        w.append(sim.state.w_WP_P[0].copy())
        v.append(sim.state.v_WC_W[0].copy())
    elapsed = time.perf_counter() - t0
    times = np.arange(1, P.CHECKPOINTS + 1) * n * h
    return elapsed, _errors(problem, times, np.array(q), np.array(w), np.array(v))


def run_mujoco(problem: str, integrator: str, steps_per_checkpoint: int) -> tuple[float, dict]:
    """One run of MuJoCo (one free body, mj_step from Python; wrenches via xfrc_applied).

    The body-fixed force and the forcing torque are rotated to world axes with the rotation
    of the current qpos (mju_quat2Mat): d.xmat after mj_step is of the previous step's start.
    """
    mujoco = mjm.mujoco
    T = P.horizon(problem)
    h = T / (P.CHECKPOINTS * steps_per_checkpoint)
    inertia = {"top": P.TOP_INERTIA, "forced": P.FORCED_INERTIA, "box": P.box_inertia()}[problem]
    mass = P.BOX_MASS if problem == "box" else 1.0
    m, d = mjm.make(1, inertia, mass, h, integrator)
    d.qpos[:3] = 0.0
    if problem == "top":
        d.qvel[3:6] = P.TOP_W0_B
    elif problem == "forced":
        d.qvel[3:6] = P.FORCED_W0_B
    tau_box_B = np.cross(P.BOX_POINT_B, P.BOX_FORCE_B)
    R = np.zeros(9)
    n = steps_per_checkpoint
    q, w, v = [], [], []
    xfrc = d.xfrc_applied
    t0 = time.perf_counter()
    for k in range(P.CHECKPOINTS):
        if problem == "top":
            for _ in range(n):
                mujoco.mj_step(m, d)
        elif problem == "forced":
            for i in range(n):
                mujoco.mju_quat2Mat(R, d.qpos[3:7])
                xfrc[1, 3:] = R.reshape(3, 3) @ P.forced_torque_B((k * n + i + 0.5) * h)
                mujoco.mj_step(m, d)
        else:
            for _ in range(n):
                mujoco.mju_quat2Mat(R, d.qpos[3:7])
                R3 = R.reshape(3, 3)
                xfrc[1, :3] = R3 @ P.BOX_FORCE_B
                xfrc[1, 3:] = R3 @ tau_box_B
                mujoco.mj_step(m, d)
        q.append(d.qpos[3:7].copy())
        w.append(d.qvel[3:6].copy())
        v.append(d.qvel[0:3].copy())
    elapsed = time.perf_counter() - t0
    times = np.arange(1, P.CHECKPOINTS + 1) * n * h
    return elapsed, _errors(problem, times, np.array(q), np.array(w), np.array(v))


def sweep(quick: bool, log=print) -> list[dict]:
    """Every (system, integrator, problem, h); interleaved per h so load changes hit all alike."""
    if quick:
        per_checkpoint = [1, 3, 10, 30, 100, 300]
        repeats = 1
    else:
        per_checkpoint = [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000]
        repeats = 3
    systems = [("rigid_body_sim", name, run_ours) for name in INTEGRATORS]
    if mjm.available():
        systems += [("mujoco", name, run_mujoco) for name in mjm.MJ_INTEGRATORS]
    rows = []
    for problem in P.PROBLEMS:
        for n in per_checkpoint:
            h = P.horizon(problem) / (P.CHECKPOINTS * n)
            for system, name, runner in systems:
                if system == "rigid_body_sim" and name == "reference" and n > 10:
                    continue  # solve_ivp per step: ms each; a few coarse h suffice
                times = []
                try:
                    for r in range(repeats if n * P.CHECKPOINTS <= 3000 or not quick else 1):
                        elapsed, err = runner(problem, name, n)
                        times.append(elapsed)
                except Exception as exc:  # a blow-up (DivergenceError) is a result, not a crash
                    rows.append({"system": system, "integrator": name, "problem": problem, "h": h,
                                 "steps": n * P.CHECKPOINTS, "time_s": math.nan, "us_per_step": math.nan,
                                 "err_angle": math.nan, "err_w": math.nan, "err_energy": math.nan,
                                 "err_L": math.nan, "err_v": math.nan, "note": type(exc).__name__})
                    continue
                t = statistics.median(times)
                rows.append({"system": system, "integrator": name, "problem": problem, "h": h,
                             "steps": n * P.CHECKPOINTS, "time_s": t, "us_per_step": 1e6 * t / (n * P.CHECKPOINTS),
                             **err, "note": ""})
            log(f"  work-precision {problem} h={h:.3g} done")
    return rows


def cost_at_error(rows: list[dict], problem: str, target: float, key: str = "err_angle") -> list[dict]:
    """Per (system, integrator): the time to reach ``target`` error, log-log interpolated on the curve.

    Returns rows {system, integrator, time_s, h} (time NaN when the sweep never reaches it).
    """
    out = []
    pairs = sorted({(r["system"], r["integrator"]) for r in rows if r["problem"] == problem})
    for system, name in pairs:
        pts = sorted(((r["h"], r["time_s"], r[key]) for r in rows
                      if r["problem"] == problem and r["system"] == system and r["integrator"] == name
                      and math.isfinite(r["time_s"]) and math.isfinite(r[key])), reverse=True)  # h descending
        best = (math.nan, math.nan)
        for (h0, t0, e0), (h1, t1, e1) in zip(pts, pts[1:]):
            if e0 <= target:  # the coarsest h already meets it
                best = (t0, h0)
                break
            if e1 <= target < e0 and e1 > 0:
                s = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
                best = (math.exp(math.log(t0) + s * (math.log(t1) - math.log(t0))),
                        math.exp(math.log(h0) + s * (math.log(h1) - math.log(h0))))
                break
        else:
            if pts and pts[-1][2] <= target and len(pts) == 1:
                best = (pts[0][1], pts[0][0])
        out.append({"system": system, "integrator": name, "time_s": best[0], "h": best[1]})
    return out
