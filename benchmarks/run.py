"""One command for every benchmark: ``python -m benchmarks.run --quick|--full --out DIR``.

Writes to DIR: results.md (every table, the targets met or not, the machine), throughput.csv,
apply_cost.csv, site_force.csv, work_precision.csv, reduction.csv, targets.csv,
core_compare.csv (with ``--baseline-core``), the plots, and profile_kernels.txt;
to ``--docs``: choosing_an_integrator.md and its claims (benchmarks/choosing.py); with
``--performance``: the generated block of docs/performance.md (between ``<!-- bench:begin -->``
and ``<!-- bench:end -->``): the provenance, the machine, the per-integrator table and the
per-frame cost tables of results.md, from the same run (the targets table stays in results.md).

Quick and full modes differ in the sizes swept and the seconds per sample, not in the number
of repeats (≥ 5 everywhere). ``--parts`` runs a subset (while developing): it writes results_partial.md,
which says which parts are missing, and never touches results.md or docs/performance.md.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from . import apply_cost, choosing, machine, reduction, throughput, work_precision  # noqa: E402
from . import mujoco_models as mjm  # noqa: E402
from . import problems as P  # noqa: E402
from .timing import MIN_REPEATS  # noqa: E402

PARTS = ("throughput", "apply", "work", "reduction", "profile")
BLOCK_BEGIN, BLOCK_END = "<!-- bench:begin -->", "<!-- bench:end -->"


@dataclass(frozen=True)
class Mode:
    name: str
    counts: tuple[int, ...]
    repeats: int
    min_seconds: float
    steps_per_checkpoint: tuple[int, ...]
    budget_s: float
    reduction_count: int
    kind_integrators: tuple[str, ...]
    profile_count: int


QUICK = Mode("quick", (1, 100, 10_000), MIN_REPEATS, 0.05, work_precision.QUICK_STEPS_PER_CHECKPOINT, 0.5, 10_000,
             reduction.INTEGRATORS, 10_000)
FULL = Mode("full", (1, 10, 100, 1000, 10_000, 100_000), 7, 0.2, work_precision.FULL_STEPS_PER_CHECKPOINT, 3.0,
            10_000, reduction.INTEGRATORS, 10_000)
#: Tiny sizes and samples: checks that the code runs (test/test_bench_smoke.py); its figures mean nothing.
SMOKE = Mode("smoke", (1, 3), MIN_REPEATS, 0.0005, (1, 25, 100), 0.05, 6, ("rk4",), 3)


# ----------------------------------------------------------------------------- formatting


def _write_csv(path: Path, rows: list[dict]) -> None:
    if not rows:
        return
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)


def _fmt(x, digits: int = 3) -> str:
    if isinstance(x, str):
        return x
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    return f"{x:.{digits}g}"


def _range(row: dict, key: str, digits: int = 3) -> str:
    """``median (min–max)`` of a Stats.as_row triple in ``row``."""
    if key not in row or row[key] is None or not math.isfinite(row[key]):
        return "—"
    return f"{row[key]:.{digits}g} ({row[key + '_min']:.{digits}g}–{row[key + '_max']:.{digits}g})"


def _table(rows: list[dict], columns: list[tuple[str, object]]) -> str:
    """Markdown table; a column is (title, key) or (title, function of the row)."""
    head = "| " + " | ".join(t for t, _ in columns) + " |\n|" + "---|" * len(columns) + "\n"
    body = ""
    for r in rows:
        cells = [c(r) if callable(c) else _fmt(r.get(c, "")) for _, c in columns]
        body += "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |\n"
    return head + body


def provenance(mode: Mode) -> str:
    # code only: the results and docs a previous run left uncommitted do not make the code dirty
    dirty = " + uncommitted changes" if machine.git("status", "--porcelain", "--", "rigid_body_sim", ":(glob)benchmarks/*.py",
                                            "requirements*.txt") else ""
    return (f"`make bench` {mode.name} mode, commit {machine.git('rev-parse', '--short', 'HEAD')}{dirty}, "
            f"{datetime.date.today().isoformat()}, {machine.one_line()}")


def _target(rows: list[dict], comparison: str, goal: str, measured: str, met: bool | None) -> None:
    rows.append({"comparison": comparison, "target": goal, "measured": measured,
                 "met": "—" if met is None else ("met" if met else "NOT met")})


# ----------------------------------------------------------------------------- plots


def plot_work_precision(rows: list[dict], out: Path) -> list[Path]:
    paths = []
    for problem in P.PROBLEMS:
        key, label = P.ERROR_KEY[problem]
        fig, (ax_t, ax_h) = plt.subplots(1, 2, figsize=(13, 5.2))
        for system, name in sorted({(r["system"], r["integrator"]) for r in rows if r["problem"] == problem}):
            pts = [p for p in work_precision.curve(rows, problem, system, name, key) if p[2] > 0]
            if not pts:
                continue
            h, t, e = map(np.array, zip(*pts))
            style = dict(marker="o" if system == "rigid_body_sim" else "s",
                         linestyle="-" if system == "rigid_body_sim" else "--", ms=4,
                         label=f"{'MuJoCo ' if system == 'mujoco' else ''}{name}")
            ax_t.loglog(t, e, **style)
            ax_h.loglog(h, e, **style)
        hs = np.array(sorted({r["h"] for r in rows if r["problem"] == problem and math.isfinite(r["h"])}))
        if len(hs):
            for order, ls in ((1, ":"), (2, "-."), (4, (0, (5, 1)))):
                ax_h.loglog(hs, 0.3 * (hs / hs.max()) ** order, color="grey", linestyle=ls, lw=1, label=f"order {order}")
        ax_t.set_xlabel("wall time of the stepping calls (s), median")
        ax_h.set_xlabel("step h (s)")
        for ax in (ax_t, ax_h):
            ax.set_ylabel(label)
            ax.grid(True, which="both", alpha=0.3)
            ax.set_ylim(bottom=1e-15)
        ax_h.legend(fontsize=7, ncol=2)
        fig.suptitle({"top": "torque-free asymmetric top vs elliptic closed form, t ≤ 10 s; ours step(n), MuJoCo nstep",
                      "box": "box, 10 N fixed in the body at a corner site, t ≤ 1 s; ours site frame, MuJoCo site motor"}
                     [problem])
        fig.tight_layout()
        path = out / f"work_precision_{problem}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths


def plot_throughput(rows: list[dict], out: Path) -> Path:
    fig, ax = plt.subplots(figsize=(9, 5.5))
    for system, name, mode in sorted({(r["system"], r["integrator"], r["mode"]) for r in rows}):
        if mode == "per-step" and system != "numpy loop":
            continue
        pts = sorted((r["bodies"], r["body_steps_per_s"]) for r in rows
                     if (r["system"], r["integrator"], r["mode"]) == (system, name, mode))
        n, v = zip(*pts)
        style = {"rigid_body_sim": ("o", "-"), "mujoco": ("s", "--"), "floor": ("^", ":"), "numpy loop": ("x", "-.")}[system]
        ax.loglog(n, v, marker=style[0], linestyle=style[1], label=f"{system} {name}")
    ax.set_xlabel("bodies N")
    ax.set_ylabel("body-steps per second (median; batched where the system has it)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    path = out / "throughput.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


# ----------------------------------------------------------------------------- sections


def section_throughput(tp: list[dict], targets: list[dict], compare: list[dict]) -> str:
    n_max = throughput.headline_bodies(tp)
    at = {(r["system"], r["integrator"], r["mode"]): r for r in tp if r["bodies"] == n_max}
    floor = {name: at.get(("floor", name, "batched")) for name in ("euler", "rk4")}

    def vs_floor(r: dict) -> str:
        f = floor.get(r["integrator"]) if r["system"] == "rigid_body_sim" else None
        return _fmt(r["ns_per_body_step"] / f["ns_per_body_step"], 3) + "×" if f else ""

    def vs_mujoco(r: dict) -> str:
        if r["system"] != "rigid_body_sim" or not r["peer"]:
            return ""
        m = at.get(("mujoco", r["peer"], r["mode"]))
        return f"{r['body_steps_per_s'] / m['body_steps_per_s']:.3g}× MuJoCo {r['peer']}" if m else ""

    head_rows = sorted(at.values(), key=lambda r: (["rigid_body_sim", "mujoco", "floor", "numpy loop"].index(r["system"]),
                                                  r["integrator"], r["mode"]))
    text = (f"## Throughput: N tumbling boxes, no wrench, h = 1 ms\n\n{throughput.__doc__.split(chr(10) * 2, 1)[1]}\n"
            f"### At N = {n_max:g}\n\n"
            + _table(head_rows, [("system", "system"), ("integrator", "integrator"), ("mode", "mode"),
                                 ("ns per body-step", lambda r: _range(r, "ns_per_body_step")),
                                 ("body-steps/s", lambda r: _fmt(r["body_steps_per_s"])),
                                 ("time / floor of the same method", vs_floor),
                                 ("vs the matched MuJoCo method, same mode", vs_mujoco)]))
    counts = sorted({r["bodies"] for r in tp})
    series = sorted({(r["system"], r["integrator"], r["mode"]) for r in tp})
    pivot = []
    for key in series:
        row = {"system": key[0], "integrator": key[1], "mode": key[2]}
        for r in tp:
            if (r["system"], r["integrator"], r["mode"]) == key:
                row[r["bodies"]] = _range(r, "body_steps_per_s")
        pivot.append(row)
    text += ("\n### Every N: body-steps/s, median (min–max)\n\n![throughput](throughput.png)\n\n"
             + _table(pivot, [("system", "system"), ("integrator", "integrator"), ("mode", "mode")]
                      + [(f"N = {n:g}", (lambda n: lambda r: r.get(n, ""))(n)) for n in counts]))

    def ratio(a, b):
        return a["ns_per_body_step"] / b["ns_per_body_step"] if a and b else math.nan

    ours = {name: at.get(("rigid_body_sim", name, "batched")) for name in ("euler", "rk4", "semi_implicit_euler")}
    r_euler = ratio(ours["euler"], floor["euler"])
    _target(targets, f"N = {n_max:g}, batched: our `euler` `step(n)` vs the plain numba loop of the same step (time ratio)",
            "≤ 3 (goal 2)", f"{_fmt(r_euler)}×", r_euler <= 3.0 if math.isfinite(r_euler) else None)
    r_rk4 = ratio(ours["rk4"], floor["rk4"])
    _target(targets, f"N = {n_max:g}, batched: our `rk4` `step(n)` vs the plain numba rk4 loop (time ratio)",
            "≤ 3", f"{_fmt(r_rk4)}×", r_rk4 <= 3.0 if math.isfinite(r_rk4) else None)
    mj = at.get(("mujoco", "Euler", "batched"))
    sie = ours["semi_implicit_euler"]
    speed = sie["body_steps_per_s"] / mj["body_steps_per_s"] if sie and mj else math.nan
    _target(targets, f"N = {n_max:g}: our `semi_implicit_euler` `step(n)` vs MuJoCo `Euler` `mj_step(m, d, nstep=n)` "
            "(body-steps/s ratio)", "≥ 3", f"{_fmt(speed)}×", speed >= 3.0 if math.isfinite(speed) else None)
    diy = at.get(("numpy loop", "euler", "per-step")) or next(
        (r for r in sorted(tp, key=lambda r: -r["bodies"]) if r["system"] == "numpy loop" and r["integrator"] == "euler"),
        None)
    if diy and ours["euler"]:
        n_diy = diy["bodies"]
        ours_at = next(r for r in tp if r["bodies"] == n_diy and (r["system"], r["integrator"], r["mode"])
                       == ("rigid_body_sim", "euler", "batched"))
        text += (f"\nThe do-it-yourself numpy loop (`euler`, one body at a time) at N = {n_diy:g}: "
                 f"{_fmt(diy['ns_per_body_step'])} ns per body-step; ours `euler` `step(n)` is "
                 f"{_fmt(diy['ns_per_body_step'] / ours_at['ns_per_body_step'])}× faster.\n")
    if compare:
        text += ("\n### This checkout's core against another revision's, same run\n\n"
                 + _table(compare, [("integrator", "integrator"), ("N", "bodies"),
                                    ("this checkout, body-steps/s", lambda r: _range(r, "this_body_steps_per_s")),
                                    (f"{compare[0]['baseline']}, body-steps/s", lambda r: _range(r, "base_body_steps_per_s")),
                                    ("this / baseline", "ratio")]))
        worst = min(compare, key=lambda r: r["ratio"])
        _target(targets, f"N = {compare[0]['bodies']:g}, `step(n)`, every integrator: this checkout's core vs "
                f"{compare[0]['baseline']}'s, interleaved in one run (body-steps/s ratio)", "≥ 1 (must not fall; ≥ 0.9 "
                "counts as held: the same core against itself gave 0.88–1.12 on the loaded machine)",
                f"lowest {_fmt(worst['ratio'])} ({worst['integrator']})", worst["ratio"] >= 0.9)
    else:
        _target(targets, f"N = {n_max:g} throughput per integrator must not fall after the rewrite",
                "≥ the baseline core's", "not measured in this run (pass `--baseline-core REV`)", None)
    return text


def apply_tables(frames: list[dict], sites: list[dict], level: str = "###") -> str:
    """The two tables of what a force costs from Python (results.md and docs/performance.md's block)."""
    return (f"{level} (i) Per frame, µs, median (min–max); integrator rk4 / MuJoCo RK4\n\n"
            + _table(frames, [("call", "function"), ("frame", "frame"),
                              ("one call", lambda r: _range(r, "call_us")),
                              ("call + step(1)", lambda r: _range(r, "apply_step_us")),
                              ("over step(1)", lambda r: _fmt(r.get("over_step_us"))),
                              ("call / world", lambda r: _fmt(r.get("call_vs_world")) + ("×" if "call_vs_world" in r else "")),
                              ("call + step / world", lambda r: _fmt(r.get("apply_step_vs_world"))
                               + ("×" if "apply_step_vs_world" in r else ""))])
            + f"\n{level} (ii) One body, a new site-frame force every step from Python, µs, median (min–max)\n\n"
            "Ours `apply_force_at_point(\"b\", F, (0, 0, 0), frame=\"b/corner\")` + `step(1)`; MuJoCo "
            "`d.ctrl[0] = f` + `mj_step(m, d)` with a motor on a site at the same corner; each with its step "
            "alone beside it.\n\n"
            + _table(sites, [("ours", "integrator"), ("apply + step(1)", lambda r: _range(r, "ours_us")),
                             ("step(1) alone", lambda r: _range(r, "ours_step_only_us")),
                             ("MuJoCo (matched)", lambda r: r["mujoco"] or ""),
                             ("ctrl + mj_step", lambda r: _range(r, "mujoco_us")),
                             ("mj_step alone", lambda r: _range(r, "mujoco_step_only_us")),
                             ("ours / MuJoCo", lambda r: _fmt(r.get("ratio")) + ("×" if "ratio" in r else "")),
                             ("control array + step(1)", lambda r: _range(r, "control_us") if "control_us" in r else "—"),
                             ("control array / MuJoCo",
                              lambda r: _fmt(r.get("control_ratio")) + ("×" if "control_ratio" in r else ""))]))


def section_apply(frames: list[dict], sites: list[dict], targets: list[dict]) -> str:
    text = ("## What a force costs from Python\n\n" + apply_cost.__doc__.split(chr(10) * 2, 1)[1] + "\n"
            + apply_tables(frames, sites))
    ours = [r for r in frames if "call_vs_world" in r and r["frame"] != "world"]
    if ours:
        worst = max(ours, key=lambda r: max(r["call_vs_world"], r["apply_step_vs_world"]))
        worst_ratio = max(worst["call_vs_world"], worst["apply_step_vs_world"])
        _target(targets, "`apply_force_at_point` / `apply_wrench` in `<body>/world_aligned`, `<body>`, a site (body "
                "axes), a site (world axes) vs the `world` frame: the call alone and call + `step(1)` (time ratio)",
                "≤ 1.5", f"worst {_fmt(worst_ratio)}× ({worst['function']}, {worst['frame']})", worst_ratio <= 1.5)
    for r in sites:
        if "ratio" in r:
            _target(targets, f"1 body, new site force every step: our `{r['integrator']}` apply + `step(1)` vs MuJoCo "
                    f"`{r['mujoco']}` `d.ctrl[0] = f; mj_step(m, d)` with a site motor (time ratio)", "≤ 0.5",
                    f"{_fmt(r['ratio'])}× ({r['ours_us']:.3g} vs {r['mujoco_us']:.3g} µs)", r["ratio"] <= 0.5)
            _target(targets, f"1 body, new site force every step: our `{r['integrator']}` control array "
                    f"(`u[1] = f; step(1)`) vs MuJoCo `{r['mujoco']}` `d.ctrl[0] = f; mj_step(m, d)` (time ratio)",
                    "≤ 0.7", f"{_fmt(r['control_ratio'])}× ({r['control_us']:.3g} vs {r['mujoco_us']:.3g} µs)",
                    r["control_ratio"] <= 0.7)
    return text


def section_work(wp: list[dict], targets: list[dict]) -> str:
    text = ("## Work-precision\n\n" + work_precision.__doc__.split(chr(10) * 2, 1)[1] + "\n"
            + P.__doc__.split(chr(10) * 2, 1)[1].split("(The earlier")[0] + "\n")
    for problem in P.PROBLEMS:
        key, label = P.ERROR_KEY[problem]
        unit = "rad" if problem == "top" else "m"
        text += f"### {problem}\n\n![{problem}](work_precision_{problem}.png)\n\n"
        goals = work_precision.TARGETS[problem]
        series = [(s, n) for _p, s, n in work_precision.series((problem,))]
        rows = []
        for system, name in series:
            row = {"system": system, "integrator": name}
            for g in goals:
                c = work_precision.cost_at_error(wp, problem, system, name, g)
                row[g] = (f"{1e3 * c['time_s']:.3g} ms (h {c['h']:.2g})" if math.isfinite(c["time_s"]) else "not reached")
            rows.append(row)
        text += (f"Wall time of the whole run (interpolated) to reach a {label}; h interpolated, s:\n\n"
                 + _table(rows, [("system", "system"), ("integrator", "integrator")]
                          + [(f"{g:g} {unit}", (lambda g: lambda r: r[g])(g)) for g in goals]))
        hs = sorted({r["h"] for r in wp if r["problem"] == problem and math.isfinite(r["h"])}, reverse=True)
        pivot = []
        for system, name in series:
            row = {"system": system, "integrator": name}
            for r in wp:
                if r["problem"] == problem and r["system"] == system and r["integrator"] == name and math.isfinite(r["h"]):
                    row[r["h"]] = r["note"] or _fmt(r.get(key, math.nan), 2)
            pivot.append(row)
        text += (f"\n{label} at each h (s):\n\n"
                 + _table(pivot, [("system", "system"), ("integrator", "integrator")]
                          + [(f"{h:.2g}", (lambda h: lambda r: r.get(h, ""))(h)) for h in hs]))
        notes = [r for r in wp if r["problem"] == problem and not math.isfinite(r["h"])]
        if notes:
            text += "\n" + "".join(f"- {r['system']} {r['integrator']}: {r['note']}\n" for r in notes)
        text += "\n"
    # targets
    ours = work_precision.cost_at_error(wp, "top", "rigid_body_sim", "rk4", 1e-6)
    theirs = work_precision.cost_at_error(wp, "top", "mujoco", "RK4", 1e-6) if mjm.available() else None
    if theirs:
        r = ours["time_s"] / theirs["time_s"]
        _target(targets, "torque-free top to 1e-6 rad: our `rk4` `step(n)` vs MuJoCo `RK4` `mj_step(m, d, nstep=n)` "
                "(wall-time ratio, interpolated)", "≤ 0.5 (goal 0.2)",
                f"{_fmt(r)}× ({ours['time_s'] * 1e3:.3g} vs {theirs['time_s'] * 1e3:.3g} ms)",
                r <= 0.5 if math.isfinite(r) else False)
        e_ours = next((e for h, _t, e in work_precision.curve(wp, "box", "rigid_body_sim", "rk4") if abs(h - 1e-3) < 1e-12),
                      math.nan)
        e_mj = next((e for h, _t, e in work_precision.curve(wp, "box", "mujoco", "RK4") if abs(h - 1e-3) < 1e-12), math.nan)
        q = e_ours / e_mj
        _target(targets, "box, 10 N fixed in the body at a corner site, h = 1 ms: our `rk4` COM error vs MuJoCo `RK4` "
                "with a site motor (error ratio)", "≤ 10", f"{_fmt(q)}× ({_fmt(e_ours)} m vs {_fmt(e_mj)} m)",
                q <= 10 if math.isfinite(q) else False)
        worst = -math.inf
        detail = []
        for g in work_precision.TARGETS["box"]:
            best = {}
            for system, names in (("rigid_body_sim", sorted({r["integrator"] for r in wp if r["system"] == "rigid_body_sim"})),
                                  ("mujoco", list(mjm.MJ_INTEGRATORS))):
                found = [(c["time_s"], n) for n in names
                         if math.isfinite((c := work_precision.cost_at_error(wp, "box", system, n, g))["time_s"])]
                best[system] = min(found) if found else (math.inf, None)
            (t_ours, n_ours), (t_mj, n_mj) = best["rigid_body_sim"], best["mujoco"]
            if math.isinf(t_ours) and math.isinf(t_mj):
                detail.append(f"{g:g} m: neither reached")
                continue
            ratio = t_ours / t_mj
            worst = max(worst, ratio)
            detail.append(f"{g:g} m: {_fmt(ratio) if math.isfinite(ratio) else 'ours not reached'}"
                          + (f" ({n_ours} vs {n_mj})" if n_ours and n_mj else ""))
        _target(targets, "box (body-fixed force at a site): our cheapest vs MuJoCo's cheapest (`nstep`, site motor) "
                "at every accuracy 1e-3 … 1e-9 m (wall-time ratio)", "≤ 1 at each",
                "; ".join(detail), bool(worst <= 1.0))
    return text


def section_reduction(red: list[dict], targets: list[dict]) -> str:
    text = ("## Model reduction\n\n" + reduction.__doc__.split(chr(10) * 2, 1)[1] + "\n"
            + _table(red, [("scene", "scene"), ("integrator", "integrator"), ("bodies (moving)", lambda r: f"{r['bodies']} ({r['moving']})"),
                           ("reduced, µs/step", lambda r: _range(r, "reduced_us")),
                           ("full (statics skipped), µs/step", lambda r: _range(r, "full_us")),
                           ("full, statics stepped, µs/step", lambda r: _range(r, "full_statics_stepped_us")),
                           ("gain", lambda r: _fmt(r.get("gain"))),
                           ("gain vs statics stepped", lambda r: _fmt(r.get("gain_vs_statics_stepped"))),
                           ("models", "models"), ("note", lambda r: r.get("note", ""))]))
    mixed = next((r for r in red if r["scene"] == "mixed" and r["integrator"] == "rk4"), None)
    if mixed:
        _target(targets, f"mixed scene of {mixed['bodies']:g} bodies (sphere, box, static wall), `rk4`: reduced vs the full "
                "model that skips static bodies (time ratio)", "≥ 2 (against the fair baseline)",
                f"{_fmt(mixed['gain'])}× ({_fmt(mixed.get('gain_vs_statics_stepped'))}× against a baseline that steps the walls)",
                mixed["gain"] >= 2.0)
    return text


def per_integrator(wp: list[dict], sites: list[dict], tp: list[dict]) -> str:
    """One row per integrator (ours, then MuJoCo's): accuracy on both problems and cost, from this run."""
    if not (wp and sites and tp):
        return ""
    n_max = throughput.headline_bodies(tp)
    rate = {(r["system"], r["integrator"]): r for r in tp if r["bodies"] == n_max and r["mode"] == "batched"}
    floor = {name: rate.get(("floor", name)) for name in ("euler", "rk4")}
    site = {r["integrator"]: r for r in sites}
    mj_site = {r["mujoco"]: r for r in sites if r.get("mujoco") and "mujoco_us" in r}

    def err(problem, system, name, h):
        """The error at h; if the series stopped refining before h, why (converged: below 1e-12; or its cost)."""
        pts = work_precision.curve(wp, problem, system, name)
        e = next((e for hh, _t, e in pts if abs(hh - h) < 1e-12 * h), None)
        if e is not None:
            return _fmt(e, 2)
        stop = next((r["note"] for r in wp if r["problem"] == problem and r["system"] == system
                     and r["integrator"] == name and not math.isfinite(r["h"])), "")
        if pts and pts[-1][0] > h and "error below" in stop:
            return f"< {work_precision.CONVERGED:g}"
        if pts and pts[-1][0] > h:
            return "not run (cost)"
        return "—"

    rows = []
    systems = [("rigid_body_sim", n) for n in dict.fromkeys(r["integrator"] for r in wp if r["system"] == "rigid_body_sim")]
    systems += [("mujoco", n) for n in mjm.MJ_INTEGRATORS if mjm.available()]
    for system, name in systems:
        r = rate.get((system, name))
        f = floor.get(name) if system == "rigid_body_sim" else None
        us = (site[name]["ours_us"] if system == "rigid_body_sim" and name in site
              else mj_site[name]["mujoco_us"] if system == "mujoco" and name in mj_site else math.nan)
        rows.append({
            "name": f"`{name}`" if system == "rigid_body_sim" else f"MuJoCo `{name}`",
            "top_01": err("top", system, name, 0.1), "top_001": err("top", system, name, 0.01),
            "box": err("box", system, name, 1e-3),
            "order": work_precision.observed_order(wp, "box", system, name, 1e-3, 4.0),
            "site_us": us, "rate": r["body_steps_per_s"] if r else math.nan,
            "floor": (r["ns_per_body_step"] / f["ns_per_body_step"]) if r and f else math.nan})
    return ("Per integrator, this run: orientation error after 10 s on the torque-free asymmetric top at h = 0.1 s "
            "and 0.01 s (rad); the box pushed by 10 N fixed in it at a corner site, COM error after 1 s at h = 1 ms (m) "
            "and the observed order between h = 4 ms and 1 ms; one body with a new site-frame force every step "
            "(ours `apply_force_at_point` + `step(1)`, MuJoCo `d.ctrl[0] = f` + `mj_step`), µs; "
            f"body-steps/s at N = {n_max:g} batched (`step(n)`, `nstep`), and its time against the plain numba loop of "
            "the same method.\n\n"
            + _table(rows, [("integrator", "name"), ("top, h = 0.1", "top_01"), ("top, h = 0.01", "top_001"),
                            ("box, h = 1 ms", "box"),
                            ("box order", lambda r: _fmt(r["order"], 2)), ("µs/step, 1 body + site force", "site_us"),
                            (f"body-steps/s, N = {n_max:g}", "rate"),
                            ("time / plain loop", lambda r: _fmt(r["floor"]) + ("×" if math.isfinite(r["floor"]) else ""))]))


def headline(targets: list[dict], prov: str, machine_text: str, summary: str) -> str:
    return (f"From {prov}.\n\nMachine:\n\n{machine_text}\n"
            + _table(targets, [("what is compared with what", "comparison"), ("target", "target"),
                               ("measured (medians of ≥ 5)", "measured"), ("met", "met")])
            + ("\n" + summary if summary else ""))


def performance_block(prov: str, machine_text: str, summary: str, frames: list[dict], sites: list[dict]) -> str:
    """docs/performance.md's generated block: results.md's headline without its targets table, and the
    per-frame cost tables one heading level down (each part is text of results.md, from the same run)."""
    return (f"From {prov}.\n\nMachine:\n\n{machine_text}\n" + summary
            + "\n**What a force costs from Python**, this run "
            "(how: [results.md](../benchmarks/results/results.md#what-a-force-costs-from-python)):\n\n"
            + apply_tables(frames, sites, level="####"))


def update_block(path: Path, block: str) -> None:
    """Replace the text between the bench markers of ``path`` (docs/performance.md) with ``block``."""
    text = path.read_text()
    if BLOCK_BEGIN not in text or BLOCK_END not in text:
        raise SystemExit(f"{path}: no {BLOCK_BEGIN} … {BLOCK_END} block to update")
    head, rest = text.split(BLOCK_BEGIN, 1)
    _old, tail = rest.split(BLOCK_END, 1)
    path.write_text(f"{head}{BLOCK_BEGIN}\n{block}{BLOCK_END}{tail}")


# ----------------------------------------------------------------------------- main


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    mode_group = parser.add_mutually_exclusive_group()
    mode_group.add_argument("--quick", action="store_true", help="fewer sizes, shorter samples (default)")
    mode_group.add_argument("--full", action="store_true", help="every size up to 1e5, longer samples")
    mode_group.add_argument("--smoke", action="store_true", help="tiny sizes: only checks that the code runs")
    parser.add_argument("--out", default="benchmarks/results", help="output directory")
    parser.add_argument("--docs", default="docs", help="where choosing_an_integrator.md and its claims go")
    parser.add_argument("--performance", default="",
                        help="update the generated block of this page (docs/performance.md)")
    parser.add_argument("--parts", default=",".join(PARTS), help=f"comma-separated subset of {','.join(PARTS)}")
    parser.add_argument("--baseline-core", default="", help="a git revision whose core is timed beside this one")
    args = parser.parse_args(argv)
    mode = FULL if args.full else (SMOKE if args.smoke else QUICK)
    parts = [p for p in args.parts.split(",") if p]
    unknown = set(parts) - set(PARTS)
    if unknown:
        parser.error(f"--parts: unknown {sorted(unknown)}; choose from {PARTS}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    log = lambda s: print(s, flush=True)  # noqa: E731
    targets: list[dict] = []
    sections: list[str] = []
    tp: list[dict] = []
    frames: list[dict] = []
    sites: list[dict] = []
    wp: list[dict] = []
    red: list[dict] = []
    compare: list[dict] = []
    if not mjm.available():
        sections.append("MuJoCo is not installed (`make bench-deps`): its rows are absent.\n")

    if "throughput" in parts:
        log("throughput ...")
        tp = throughput.sweep(list(mode.counts), mode.repeats, mode.min_seconds, log)
        _write_csv(out / "throughput.csv", tp)
        plot_throughput(tp, out)
        if args.baseline_core:
            from .core_compare import compare_throughput
            compare = compare_throughput(args.baseline_core, throughput.headline_bodies(tp), mode.repeats,
                                         mode.min_seconds, log)
            _write_csv(out / "core_compare.csv", compare)
        sections.append(section_throughput(tp, targets, compare))
    if "apply" in parts:
        log("apply cost ...")
        frames = apply_cost.per_frame(mode.repeats, mode.min_seconds, log)
        sites = apply_cost.site_force_per_step(mode.repeats, mode.min_seconds, log=log)
        _write_csv(out / "apply_cost.csv", frames)
        _write_csv(out / "site_force.csv", sites)
        sections.append(section_apply(frames, sites, targets))
    if "work" in parts:
        log("work-precision ...")
        wp = work_precision.sweep(mode.steps_per_checkpoint, mode.repeats, mode.budget_s, log=log)
        _write_csv(out / "work_precision.csv", wp)
        plot_work_precision(wp, out)
        sections.append(section_work(wp, targets))
    if "reduction" in parts:
        log("model reduction ...")
        red = reduction.sweep(mode.reduction_count, mode.repeats, mode.min_seconds,
                              kind_integrators=mode.kind_integrators, log=log)
        _write_csv(out / "reduction.csv", red)
        sections.append(section_reduction(red, targets))
    if "profile" in parts:
        log("kernel profile ...")
        from .profile import kernels as profile_kernels
        (out / "profile_kernels.txt").write_text(profile_kernels.report(mode.repeats, mode.min_seconds, mode.profile_count, log=log))
        sections.append("## Where our kernels lose time against the floor\n\n"
                        "[profile_kernels.txt](profile_kernels.txt) (benchmarks/profile/kernels.py): the floor loop "
                        f"with our costs added one at a time, at N = {mode.profile_count:g} and N = 1.\n")
    machine_text = machine.text()
    prov = provenance(mode)
    missing = [p for p in PARTS if p not in parts]
    if not set(missing) & {"throughput", "apply", "work", "reduction"}:  # the page's data, all from this run
        for path in choosing.write(Path(args.docs), wp, sites, tp, red, machine_text, mode.name, prov):
            log(f"  wrote {path}")
    _write_csv(out / "targets.csv", targets)
    head = headline(targets, prov, machine_text, per_integrator(wp, sites, tp))
    elapsed = time.perf_counter() - started
    md = (f"# rigid_body_sim benchmarks ({mode.name} mode)\n\n"
          + (f"Parts not run in this run: {', '.join(missing)}.\n\n" if missing else "")
          + "## Headline: every target, each row one comparison\n\n" + head + "\n" + "\n".join(sections)
          + f"\nRun time: {elapsed:.0f} s.\n")
    # A partial run (--parts) never overwrites the complete results.md docs/performance.md is checked against.
    (out / ("results_partial.md" if missing else "results.md")).write_text(md)
    if args.performance and not missing:
        update_block(Path(args.performance),
                     performance_block(prov, machine_text, per_integrator(wp, sites, tp), frames, sites))
        log(f"  updated {args.performance}")
    log(f"done in {elapsed:.0f} s: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
