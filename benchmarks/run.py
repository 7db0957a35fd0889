"""One command for every benchmark: ``python -m benchmarks.run --quick|--full --out DIR``.

Writes to DIR: work_precision.csv, throughput.csv, wrench_step.csv, node_timing.csv,
targets.csv, results.md (every table, the issue's targets met or not, the machine),
work_precision_<problem>.png, throughput.png and profile_<integrator>.txt.
``--skip-node`` / ``--only-node`` select parts; ``--node-configs 1000x1,100x100`` picks node cases.
"""

from __future__ import annotations

import argparse
import csv
import math
import platform
import subprocess
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from . import mujoco_models as mjm  # noqa: E402
from . import node_timing, profile_step, reduction, throughput, work_precision  # noqa: E402
from . import problems as P  # noqa: E402

TARGETS = (1e-3, 1e-6, 1e-9)  # rad, problem (a)
#: The node's and the Simulator's default integrator (README "Choosing an integrator").
DEFAULT_INTEGRATOR = "rk4"


def _write_csv(path: Path, rows: list[dict]) -> None:
    if not rows:
        return
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)


def _fmt(x, digits=3) -> str:
    if isinstance(x, str):
        return x
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    return f"{x:.{digits}g}"


def _table(rows: list[dict], columns: list[tuple[str, str]]) -> str:
    head = "| " + " | ".join(title for title, _ in columns) + " |\n|" + "---|" * len(columns) + "\n"
    return head + "".join("| " + " | ".join(_fmt(r.get(k, "")) for _, k in columns) + " |\n" for r in rows)


def machine() -> str:
    lscpu = subprocess.run(["lscpu"], capture_output=True, text=True).stdout.splitlines()
    keep = [l for l in lscpu if l.split(":")[0].strip() in ("Architecture", "CPU(s)", "Model name", "Thread(s) per core",
                                                           "Core(s) per socket", "BogoMIPS")]
    load = Path("/proc/loadavg").read_text().split()[:3]
    return ("\n".join(f"    {l}" for l in keep)
            + f"\n    Python {platform.python_version()}, numpy {np.__version__}, MuJoCo {mjm.version()}"
            + f"\n    load average at the end: {' '.join(load)} (a shared machine: compare ratios within one run)")


def plot_work_precision(rows: list[dict], out: Path) -> list[Path]:
    paths = []
    for problem in P.PROBLEMS:
        key = "err_v" if problem == "box" else "err_angle"
        label = {"err_v": "max relative COM velocity error", "err_angle": "max orientation error (rad)"}[key]
        fig, (ax_t, ax_h) = plt.subplots(1, 2, figsize=(13, 5.2))
        series = sorted({(r["system"], r["integrator"]) for r in rows if r["problem"] == problem})
        for i, (system, name) in enumerate(series):
            pts = sorted((r["h"], r["time_s"], r[key]) for r in rows if r["problem"] == problem
                         and r["system"] == system and r["integrator"] == name and math.isfinite(r[key] if r[key] == r[key] else math.nan))
            pts = [p for p in pts if p[2] > 0 and math.isfinite(p[1])]
            if not pts:
                continue
            h, t, e = map(np.array, zip(*pts))
            style = dict(marker="o" if system == "rigid_body_sim" else "s",
                         linestyle="-" if system == "rigid_body_sim" else "--", ms=4,
                         label=f"{'MuJoCo ' if system == 'mujoco' else ''}{name}")
            ax_t.loglog(t, e, **style)
            ax_h.loglog(h, e, **style)
        hs = np.array(sorted({r["h"] for r in rows if r["problem"] == problem}))
        for order, ls in ((1, ":"), (2, "-."), (4, (0, (5, 1)))):
            ax_h.loglog(hs, 0.3 * (hs / hs.max()) ** order, color="grey", linestyle=ls, lw=1, label=f"order {order}")
        ax_t.set_xlabel("wall time of the run (s), median")
        ax_h.set_xlabel("step h (s)")
        for ax in (ax_t, ax_h):
            ax.set_ylabel(label)
            ax.grid(True, which="both", alpha=0.3)
            ax.set_ylim(bottom=1e-15)
        ax_h.legend(fontsize=7, ncol=2)
        title = {"top": "(a) torque-free asymmetric top vs elliptic closed form, t ≤ 10 s",
                 "forced": "(b) forced rigid body (HNW), t ≤ 10 s; forcing held per step (world axes)",
                 "box": "(c) box, body-fixed force, t ≤ 1 s: force held in world axes per step → order 1"}[problem]
        fig.suptitle(title)
        fig.tight_layout()
        path = out / f"work_precision_{problem}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths


def plot_throughput(rows: list[dict], out: Path) -> Path:
    fig, ax = plt.subplots(figsize=(8, 5))
    for system, name in sorted({(r["system"], r["integrator"]) for r in rows}):
        pts = sorted((r["bodies"], r["body_steps_per_s"]) for r in rows if r["system"] == system and r["integrator"] == name)
        n, v = zip(*pts)
        ax.loglog(n, v, marker="o" if system == "rigid_body_sim" else "s",
                  linestyle="-" if system == "rigid_body_sim" else "--",
                  label=f"{'MuJoCo ' if system == 'mujoco' else ''}{name}")
    ax.set_xlabel("bodies N")
    ax.set_ylabel("body-steps per second (median)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    path = out / "throughput.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


STABILITY_LIMITS = {  # largest |ω|h with energy error < 1e-3 over 1e4 steps, I = (1, 2, 3) / rod 1e-6 (docs/stability.md)
    "euler": "8e-4 / 6e-4", "semi_implicit_euler": "8e-4 / 6e-4", "implicit_gyroscopic": "8e-4 / 6e-4 (then damps)",
    "splitting": "0.75 / 0.1", "symmetric_splitting": "0.3 / 2.9", "exact_rotor_splitting": "none (exact flow)",
    "rk4": "0.25 / 0.21", "reference": "adaptive",
}


def choosing_page(wp: list[dict], tp: list[dict], ws: list[dict], red: list[dict], machine_text: str, quick: bool) -> str:
    """docs/choosing_an_integrator.md: the advice, with this run's numbers in its tables."""
    ours = [name for name in dict.fromkeys(r["integrator"] for r in wp if r["system"] == "rigid_body_sim")]
    cost = {target: {c["integrator"]: c for c in work_precision.cost_at_error(wp, "top", target)
                     if c["system"] == "rigid_body_sim"} for target in TARGETS}
    mj_cost = {target: min((c["time_s"] for c in work_precision.cost_at_error(wp, "top", target)
                            if c["system"] == "mujoco" and math.isfinite(c["time_s"])), default=math.nan)
               for target in TARGETS}
    one = {r["integrator"]: r["us_per_step"] for r in ws if r["system"] == "rigid_body_sim"}
    many = {r["integrator"]: r["body_steps_per_s"] for r in tp if r["system"] == "rigid_body_sim" and r["bodies"] == 10000}
    speedup = {r["integrator"]: r["speedup"] for r in red}
    exact_ratio = (f"{one['exact_rotor_splitting'] / one['rk4']:.0f}×" if "exact_rotor_splitting" in one and "rk4" in one
                   else "many times")

    def ms(target: float, name: str) -> str:
        c = cost[target].get(name)
        if not c or not math.isfinite(c["time_s"]):
            return "not reached"
        return f"{1e3 * c['time_s'] / P.TOP_T:.3g} ms (h = {c['h']:.2g} s)"

    rows = "".join(
        f"| `{name}` | {ms(1e-3, name)} | {ms(1e-6, name)} | {ms(1e-9, name)} | {_fmt(one.get(name))} | "
        f"{_fmt(many.get(name))} | {_fmt(speedup.get(name))} | {STABILITY_LIMITS.get(name, '')} |\n" for name in ours)
    mj = " | ".join(f"{1e3 * mj_cost[t] / P.TOP_T:.3g} ms" if math.isfinite(mj_cost[t]) else "not reached" for t in TARGETS)
    return f"""# Choosing an integrator and a step

Generated by `make bench` ({'quick' if quick else 'full'} mode) from the numbers of the same run
(`benchmarks/results/`); do not edit by hand. The stability limits come from
[stability.md](stability.md) (`make envelope`).

## In short

- **`rk4` (the default)** is the cheapest way to a given accuracy on a tumbling body at the
  steps a controller runs at: fourth order, compiled, about 4 µs per step for one body with
  a wrench applied. Keep |ω|·h below about 0.25 (ω the fastest body rate): beyond it, it loses energy,
  and past |ω|·h ≈ 3 it blows up (the simulator then raises `DivergenceError`).
- **Fast spin or large steps, torque-free:** `exact_rotor_splitting` is the exact free-rotor
  flow at any |ω|·h (torques enter as second-order half kicks). It is numpy, not compiled:
  {exact_ratio} the cost of `rk4` per step here, so it pays when it lets the step grow as much.
- **Thin rods and discs:** `symmetric_splitting` holds up to |ω|·h ≈ 2.9 on a rod with
  inertia ratio 1e-6 and keeps |L| to round-off; `splitting` degrades there.
- **Long runs where invariants matter more than phase:** the splittings keep |L| to
  round-off and bound the energy error; `rk4` drifts slowly (1e-9 over 1e6 steps at
  |ω|·h = 0.01).
- **Not for tumbling bodies:** `euler`, `semi_implicit_euler` (they gain energy every step and
  diverge after ~2e4 steps at |ω|·h = 0.01) and `implicit_gyroscopic` (it damps the spin).
  They are here for comparison with textbook and game-engine loops.
- **Spheres, cubes, cylinders, static and kinematic bodies** get exact reduced models
  whatever the integrator (README "Motions and model reduction"), so the choice matters
  only for the bodies that need it.

## Choosing the step

1. Take the fastest body rate you expect, |ω|max (rad/s), and the integrator's limit from the
   table (|ω|·h for an energy error below 1e-3 over 1e4 steps): h ≤ limit / |ω|max.
2. For an accuracy goal, read the cost table below: the largest h that reached the
   orientation error on the asymmetric top, and what one second of sim time cost.
3. In the node, h = `real_time_factor` / (`rate_hz` · `substeps`): raise `substeps` to shorten
   the step without publishing faster.
4. A wrench fixed in the body (a thruster, a force at a body-frame point) is held in world
   axes over each step, so it is first order in h with every integrator: halve h to halve
   that error.

## The numbers

Machine:

{machine_text}

Cost of one second of sim time to reach an orientation error of 1e-3, 1e-6 and 1e-9 rad over
10 s on the torque-free asymmetric top I = (1, 2, 2.5) kg·m², |ω| = 2.25 rad/s (the largest
step that reached it, interpolated on the sweep); µs per step of one body with a force at a
point (`apply_force_at_point` + `step(1)`); body-steps/s at N = 1e4 boxes; speed-up of model
reduction on the mixed 1e4-body scene; the stability limit (I = (1, 2, 3) / rod r = 1e-6).

| integrator | 1e-3 rad | 1e-6 rad | 1e-9 rad | µs/step, 1 body + wrench | body-steps/s, N = 1e4 | reduction speed-up | \|ω\|·h limit |
|---|---|---|---|---|---|---|---|
{rows}| MuJoCo 4.0 (cheapest of its integrators) | {mj} | | | | |

"""


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="short sweeps, 5 s node windows (default)")
    mode.add_argument("--full", action="store_true", help="long sweeps, N up to 1e5, 20 s node windows")
    parser.add_argument("--out", default="benchmarks/results", help="output directory")
    parser.add_argument("--skip-node", action="store_true")
    parser.add_argument("--only-node", action="store_true")
    parser.add_argument("--node-configs", default="", help="e.g. 1000x1,100x100 (rate_hz x bodies)")
    parser.add_argument("--docs", default="docs", help="where choosing_an_integrator.md is written")
    args = parser.parse_args(argv)
    quick = not args.full
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    log = lambda s: print(s, flush=True)  # noqa: E731
    md = [f"# rigid_body_sim benchmarks ({'quick' if quick else 'full'} mode)\n",
          "Machine:\n\n" + machine() + "\n"]
    if not mjm.available():
        md.append("MuJoCo is not installed (`pip install -e .[bench]`): its columns are absent.\n")
    targets: list[dict] = []

    if not args.only_node:
        log("work-precision ...")
        wp = work_precision.sweep(quick, log)
        _write_csv(out / "work_precision.csv", wp)
        plots = plot_work_precision(wp, out)
        md.append("## Work-precision\n\nErrors are maxima over 10 checkpoints; time = wall time of the stepping "
                  "loop (median of repeats). Wrenches are held constant in world axes over each step (both "
                  "systems), so problems (b) and (c) are first order in h for every integrator.\n")
        cols = [("system", "system"), ("integrator", "integrator"), ("h (s)", "h"), ("µs/step", "us_per_step"),
                ("orientation err (rad)", "err_angle"), ("rel. ω err", "err_w"), ("rel. energy err", "err_energy"),
                ("rel. abs(L) err", "err_L"), ("rel. v err", "err_v"), ("note", "note")]
        for problem in P.PROBLEMS:
            md.append(f"### Problem {problem}\n\n![{problem}]({out.name and f'work_precision_{problem}.png'})\n\n"
                      + _table([r for r in wp if r["problem"] == problem], cols))
        md.append("### Cheapest configuration per target orientation error on (a)\n")
        for target in TARGETS:
            costs = work_precision.cost_at_error(wp, "top", target)
            best = {}
            for c in costs:
                if math.isfinite(c["time_s"]) and (c["system"] not in best or c["time_s"] < best[c["system"]]["time_s"]):
                    best[c["system"]] = c
            md.append(f"\nTarget {target:g} rad:\n\n" + _table(costs, [("system", "system"), ("integrator", "integrator"),
                                                                       ("h (interp.)", "h"), ("time (s, interp.)", "time_s")]))
            ours, theirs = best.get("rigid_body_sim"), best.get("mujoco")
            if ours and theirs:
                ratio = ours["time_s"] / theirs["time_s"]
                md.append(f"\nCheapest: rigid_body_sim {ours['integrator']} {ours['time_s']:.3g} s, MuJoCo "
                          f"{theirs['integrator']} {theirs['time_s']:.3g} s: ratio ours/MuJoCo = {ratio:.3g}\n")
                if target == 1e-6:
                    targets.append({"target": "cheapest at 1e-6 rad on (a) as fast as MuJoCo's (ratio ≤ 1)",
                                    "measured": f"{ratio:.3g}× ({ours['integrator']} vs MuJoCo {theirs['integrator']})",
                                    "met": ratio <= 1.0})
            else:
                md.append(f"\nCheapest: rigid_body_sim {ours and ours['integrator']}, MuJoCo {theirs and theirs['integrator']} "
                          "(a system with none reaches the target within the sweep)\n")

        log("throughput ...")
        counts = [1, 10, 100, 1000, 10000] + ([] if quick else [100000])
        min_s, reps = (0.2, 1) if quick else (0.5, 3)
        ws = throughput.wrench_step(min_s, 3)
        _write_csv(out / "wrench_step.csv", ws)
        tp = throughput.bodies_sweep(counts, min_s, reps, log)
        _write_csv(out / "throughput.csv", tp)
        plot_throughput(tp, out)
        md.append("## One body, one wrench at a point per step (µs, median of 3)\n\n"
                  "Ours: `apply_force_at_point` + `step(1)`. MuJoCo: `mj_applyFT` (force and point from "
                  "`d.xmat`/`d.xipos` with numpy) + `mj_step`; also `mj_step` alone.\n\n"
                  + _table(ws, [("system", "system"), ("integrator", "integrator"), ("µs/step", "us_per_step")]))
        mj_ft = min((r["us_per_step"] for r in ws if r["system"] == "mujoco"), default=math.nan)
        ours_best = min((r for r in ws if r["system"] == "rigid_body_sim"), key=lambda r: r["us_per_step"])
        if math.isfinite(mj_ft):
            ratio = ours_best["us_per_step"] / mj_ft
            md.append(f"\nFastest ours ({ours_best['integrator']}) / fastest MuJoCo (mj_applyFT + mj_step) = {ratio:.3g}\n")
            targets.append({"target": "one body + wrench at a point: ≤ 0.5× MuJoCo's time",
                            "measured": f"{ratio:.3g}× ({ours_best['integrator']} {ours_best['us_per_step']:.3g} µs vs {mj_ft:.3g} µs)",
                            "met": ratio <= 0.5})
        md.append("\n## Throughput: body-steps per second\n\n![throughput](throughput.png)\n\n")
        systems = sorted({(r["system"], r["integrator"]) for r in tp})
        pivot = []
        for system, name in systems:
            row = {"system": system, "integrator": name}
            for r in tp:
                if (r["system"], r["integrator"]) == (system, name):
                    row[f"N={r['bodies']}"] = r["body_steps_per_s"]
            pivot.append(row)
        md.append(_table(pivot, [("system", "system"), ("integrator", "integrator")] + [(f"N={n}", f"N={n}") for n in counts]))
        at = [r for r in tp if r["bodies"] == 10000]
        ours_n = max((r for r in at if r["system"] == "rigid_body_sim"), key=lambda r: r["body_steps_per_s"], default=None)
        mj_n = max((r for r in at if r["system"] == "mujoco"), key=lambda r: r["body_steps_per_s"], default=None)
        if ours_n and mj_n:
            ratio = ours_n["body_steps_per_s"] / mj_n["body_steps_per_s"]
            md.append(f"\nN = 1e4: fastest ours ({ours_n['integrator']}) / fastest MuJoCo ({mj_n['integrator']}) = {ratio:.3g}\n")
            targets.append({"target": "N = 1e4: ≥ 3× MuJoCo's body-steps/s", "measured": f"{ratio:.3g}×", "met": ratio >= 3.0})
        log("model reduction ...")
        red = reduction.sweep(10000, 20 if quick else 100, 3 if quick else 5, log)
        _write_csv(out / "reduction.csv", red)
        md.append("\n## Model reduction: a mixed scene of 1e4 bodies, reduced vs forced onto the full model\n\n"
                  + (reduction.__doc__ or "").split("\n\n", 1)[1] + "\n\n"
                  + _table(red, [("integrator", "integrator"), ("reduced (body-steps/s)", "reduced_body_steps_per_s"),
                                 ("full (body-steps/s)", "full_body_steps_per_s"), ("speed-up", "speedup"),
                                 ("models (reduced)", "models")]))
        default = next(r for r in red if r["integrator"] == DEFAULT_INTEGRATOR)
        targets.append({"target": f"mixed 1e4-body scene: reduction ≥ 2× the full model ({DEFAULT_INTEGRATOR}, the default)",
                        "measured": f"{default['speedup']:.3g}× (range {min(r['speedup'] for r in red):.3g}–"
                                    f"{max(r['speedup'] for r in red):.3g}× over the integrators)",
                        "met": default["speedup"] >= 2.0})
        for name in ("rk4", "euler"):
            (out / f"profile_{name}.txt").write_text(profile_step.profile(name))
        page = Path(args.docs) / "choosing_an_integrator.md"
        page.write_text(choosing_page(wp, tp, ws, red, machine(), quick))
        log(f"  wrote {page}")
        md.append("\nProfiles of one body step: profile_rk4.txt, profile_euler.txt (cProfile, own time).\n")

    if not args.skip_node:
        log("node timing ...")
        if args.node_configs:
            configs = [tuple(c.split("x")) for c in args.node_configs.split(",")]
            node_rows = []
            for rate, bodies in configs:
                node_rows += node_timing.sweep([float(rate)], [int(bodies)], 5.0 if quick else 20.0, log)
        elif quick:  # the two node targets only, to keep the quick mode near 2 minutes
            node_rows = node_timing.sweep([1000.0], [1], 5.0, log) + node_timing.sweep([100.0], [100], 5.0, log)
        else:
            node_rows = node_timing.sweep([100.0, 500.0, 1000.0], [1, 10, 100], 20.0, log)
        _write_csv(out / "node_timing.csv", node_rows)
        md.append(f"\n## Node timing ({'5' if quick else '20'} s windows; node default integrator {DEFAULT_INTEGRATOR})\n")
        for r in node_rows:
            r["jitter"] = "/".join(_fmt(r.get(k)) for k in ("jitter_med_ms", "jitter_p99_ms", "jitter_max_ms"))
            r["late"] = "/".join(_fmt(r.get(k)) for k in ("late_med_ms", "late_p99_ms", "late_max_ms"))
            r["latency"] = "/".join(_fmt(r.get(k)) for k in ("latency_med_ms", "latency_max_ms"))
            r["node_late"] = "/".join(_fmt(r.get(k)) for k in ("node_late_med_ms", "node_late_p99_ms_max", "node_late_max_ms"))
        md.append(_table(node_rows, [
            ("rate_hz", "rate_hz"), ("bodies", "bodies"), ("achieved Hz", "achieved_hz"), ("sim/wall", "sim_wall"),
            ("jitter med/p99/max (ms)", "jitter"), ("lateness med/p99/max (ms)", "late"),
            ("node's own lateness med/worst 1-s p99/max (ms)", "node_late"), ("ticks missed (node)", "node_ticks_missed"),
            ("CPU share", "cpu_share"),
            ("bodies watched", "watched_bodies"), ("pose every tick (frac)", "pose_every_tick_frac"),
            ("twist/tick (min)", "twist_per_tick_min"), ("wrench→twist med/max (ms)", "latency"), ("error", "error")]))
        for r in node_rows:
            if r.get("rate_hz") == 1000.0 and r.get("bodies") == 1 and "sim_wall" in r:
                # Strict: the worst 1-s window's p99 of the node's own tick lateness.
                worst_p99 = r.get("node_late_p99_ms_max", math.nan)
                ok = r["sim_wall"] >= 0.999 and worst_p99 < 0.5
                targets.append({"target": f"node 1 kHz, 1 body: sim/wall ≥ 0.999, p99 lateness < 0.5 ms ({r['seconds']:g} s)",
                                "measured": f"sim/wall {r['sim_wall']:.4g}; tick lateness p99 {worst_p99:.3g} ms (node, worst "
                                            f"1-s window), {r['late_p99_ms']:.3g} ms (listener, whole run)", "met": ok})
            if r.get("rate_hz") == 100.0 and r.get("bodies") == 100 and "pose_every_tick_frac" in r:
                ok = r["pose_every_tick_frac"] >= 1.0 and r["twist_per_tick_min"] >= 0.999 and r["watched_bodies"] == 100
                targets.append({"target": f"node 100 bodies at 100 Hz: pose and twist every tick ({r['seconds']:g} s)",
                                "measured": f"pose on {r['pose_every_tick_frac']:.4g} of ticks (all 100 bodies), "
                                            f"twist/tick min {r['twist_per_tick_min']:.4g}, achieved {r['achieved_hz']:.4g} Hz",
                                "met": ok})

    _write_csv(out / "targets.csv", targets)
    md.insert(2, "## The issue's targets\n\n" + _table(
        [dict(t, met="met" if t["met"] else "NOT met") for t in targets],
        [("target", "target"), ("measured", "measured"), ("met", "met")]) + "\n")
    elapsed = time.perf_counter() - started
    md.append(f"\nRun time: {elapsed:.0f} s.\n")
    (out / ("results.md" if not args.only_node else "results_node.md")).write_text("\n".join(md))
    log(f"done in {elapsed:.0f} s: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
