"""docs/choosing_an_integrator.md and its machine-checkable claims, from one benchmark run.

The page gives advice with this run's numbers; every accuracy statement in it is also written
to ``docs/choosing_an_integrator.claims.json``, in a form a test can re-measure in seconds
without this package's benchmark code (test/test_choosing_claims.py):

``reached``
    ``integrator`` at step ``h`` keeps the error of ``problem`` at or below ``max_error``
    (the largest h of the sweep that reached an accuracy goal; no interpolation).
``not_reached``
    even at the finest h of the sweep, the error stays above ``min_error``.
``order``
    the observed order log(e(h_coarse)/e(h_fine)) / log(h_coarse/h_fine) lies within
    ``order ± tolerance``.

Each problem's definition (inertia, initial rate, force, site, horizon, checkpoints, the error
measure) is written beside the claims, so the test needs nothing else. Speed is never a claim
a test checks (no wall-clock assertions); the speed columns are this run's figures only.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

from rigid_body_sim.core import INTEGRATORS

from . import mujoco_models as mjm
from . import problems as P
from . import throughput
from . import work_precision as wp_mod

#: The observed order under a body-fixed force is taken between these two steps of the box sweep.
ORDER_H = (4e-3, 1e-3)
ORDER_TOLERANCE = 0.3
TOP_GOALS = (1e-3, 1e-6, 1e-9)
BOX_GOALS = (1e-3, 1e-6, 1e-9)


def stability_limits(path: Path) -> dict[str, str]:
    """Integrator → its |ω|h limits (I = (1, 2, 3) / rod r = 1e-6) from docs/stability.md's first table."""
    limits: dict[str, str] = {}
    try:
        text = path.read_text()
    except OSError:
        return limits
    for line in text.splitlines():
        m = re.match(r"^\| `(\w+)` \| ([^|]*) \| ([^|]*) \| ([^|]*) \|$", line)
        if m and m.group(1) not in limits and m.group(1) in INTEGRATORS:
            limits[m.group(1)] = f"{m.group(2).strip()} / {m.group(4).strip()}"
    return limits


def _fmt(x: float, digits: int = 3) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{x:.{digits}g}"


def problem_definitions() -> dict:
    return {
        "top": {"mass_kg": 1.0, "principal_inertia_kg_m2": P.TOP_INERTIA.tolist(),
                "initial_angular_velocity_body_rad_s": P.TOP_W0_B.tolist(), "horizon_s": P.TOP_T,
                "checkpoints": P.CHECKPOINTS,
                "error": "max over the checkpoints of the geodesic angle (rad) between the body's orientation "
                         "and closed_form.asymmetric_top's"},
        "box": {"mass_kg": P.BOX_MASS, "box_sides_m": list(P.BOX_SIDES), "site_body_m": P.BOX_SITE_B.tolist(),
                "force_in_site_axes_N": P.BOX_FORCE_S.tolist(), "horizon_s": P.BOX_T, "checkpoints": P.CHECKPOINTS,
                "how": "apply_force_at_point(body, force, (0, 0, 0), frame=body/site) before each step(n) "
                       "between checkpoints",
                "error": "max over the checkpoints of |p - p_ref| (m), p_ref from closed_form.box_body_fixed_force"},
    }


def claims(wp: list[dict]) -> list[dict]:
    """The accuracy claims of this run (see the module docstring)."""
    out = []
    ours = [n for n in INTEGRATORS if any(r["system"] == "rigid_body_sim" and r["integrator"] == n for r in wp)]
    for problem, goals in (("top", TOP_GOALS), ("box", BOX_GOALS)):
        for name in ours:
            pts = wp_mod.curve(wp, problem, "rigid_body_sim", name)
            if not pts:
                continue
            for goal in goals:
                c = wp_mod.cost_at_error(wp, problem, "rigid_body_sim", name, goal)
                if math.isfinite(c["h_grid"]):
                    out.append({"kind": "reached", "problem": problem, "integrator": name, "h": c["h_grid"],
                                "max_error": goal, "measured": c["error_at_h_grid"]})
                else:
                    h_min, _t, e_min = pts[-1]
                    out.append({"kind": "not_reached", "problem": problem, "integrator": name, "h": h_min,
                                "min_error": goal, "measured": e_min})
        if problem == "box":
            for name in ours:
                order = wp_mod.observed_order(wp, "box", "rigid_body_sim", name, ORDER_H[1], ORDER_H[0] / ORDER_H[1])
                if math.isfinite(order):
                    out.append({"kind": "order", "problem": "box", "integrator": name, "h_coarse": ORDER_H[0],
                                "h_fine": ORDER_H[1], "order": round(order, 2), "tolerance": ORDER_TOLERANCE})
    return out


def page(wp: list[dict], sites: list[dict], tp: list[dict], red: list[dict], machine_text: str, mode_name: str,
         stability: dict[str, str], provenance: str) -> str:
    """The markdown page."""
    ours = [n for n in INTEGRATORS if any(r["system"] == "rigid_body_sim" and r["integrator"] == n for r in wp)]
    cost = {(g, n): wp_mod.cost_at_error(wp, "top", "rigid_body_sim", n, g) for g in TOP_GOALS for n in ours}
    site_us = {r["integrator"]: r["ours_us"] for r in sites}
    step_us = {r["integrator"]: r["ours_step_only_us"] for r in sites}
    n_max = throughput.headline_bodies(tp)
    many = {r["integrator"]: r["body_steps_per_s"] for r in tp
            if r["system"] == "rigid_body_sim" and r["mode"] == "batched" and r["bodies"] == n_max}
    gain = {r["integrator"]: r.get("gain", math.nan) for r in red if r["scene"] == "mixed"}
    order = {n: wp_mod.observed_order(wp, "box", "rigid_body_sim", n, ORDER_H[1], ORDER_H[0] / ORDER_H[1]) for n in ours}
    box_err = {n: next((e for h, _t, e in wp_mod.curve(wp, "box", "rigid_body_sim", n) if abs(h - 1e-3) < 1e-12), math.nan)
               for n in ours}

    def cell(goal: float, name: str) -> str:
        c = cost[goal, name]
        if not math.isfinite(c["time_s"]):
            finest = wp_mod.curve(wp, "top", "rigid_body_sim", name)
            return f"not reached down to h = {finest[-1][0]:.2g} s" if finest else "—"
        return f"{1e3 * c['time_s'] / P.TOP_T:.3g} ms (h = {c['h_grid']:.2g} s)"

    rows = "".join(
        f"| `{n}` | {cell(1e-3, n)} | {cell(1e-6, n)} | {cell(1e-9, n)} | {_fmt(box_err[n])} | {_fmt(order[n], 2)} | "
        f"{_fmt(site_us.get(n, math.nan))} | {_fmt(many.get(n, math.nan))} | {_fmt(gain.get(n, math.nan))} | "
        f"{stability.get(n, '')} |\n" for n in ours)
    mj_rows = ""
    if mjm.available():
        mj_site = {r["mujoco"]: r.get("mujoco_us", math.nan) for r in sites if r.get("mujoco")}
        mj_many = {r["integrator"]: r["body_steps_per_s"] for r in tp
                   if r["system"] == "mujoco" and r["mode"] == "batched" and r["bodies"] == n_max}
        for name in mjm.MJ_INTEGRATORS:
            cells = []
            for goal in TOP_GOALS:
                c = wp_mod.cost_at_error(wp, "top", "mujoco", name, goal)
                cells.append(f"{1e3 * c['time_s'] / P.TOP_T:.3g} ms (h = {c['h_grid']:.2g} s)"
                             if math.isfinite(c["time_s"]) else "not reached")
            e = next((e for h, _t, e in wp_mod.curve(wp, "box", "mujoco", name) if abs(h - 1e-3) < 1e-12), math.nan)
            o = wp_mod.observed_order(wp, "box", "mujoco", name, ORDER_H[1], ORDER_H[0] / ORDER_H[1])
            mj_rows += (f"| MuJoCo {mjm.version()} `{name}` (`nstep`; site motor) | {' | '.join(cells)} | {_fmt(e)} | "
                        f"{_fmt(o, 2)} | {_fmt(mj_site.get(name, math.nan))} | {_fmt(mj_many.get(name, math.nan))} | | |\n")

    cheapest = {}
    for goal in TOP_GOALS:
        finite = [(cost[goal, n]["time_s"], n) for n in ours if math.isfinite(cost[goal, n]["time_s"])]
        cheapest[goal] = min(finite)[1] if finite else None
    rk4_orders = _fmt(order.get("rk4", math.nan), 2)
    first_order = [n for n in ("euler", "semi_implicit_euler", "implicit_gyroscopic") if n in ours]
    exact_ratio = (step_us.get("exact_rotor_splitting", math.nan) / step_us.get("rk4", math.nan)
                   if "rk4" in step_us else math.nan)
    cheapest_text = ", ".join(f"{g:g} rad: `{cheapest[g]}`" for g in TOP_GOALS if cheapest[g]) or "none reached"
    return f"""# Choosing an integrator and a step

Generated by `make bench` ({mode_name} mode) from one run ({provenance}); do not edit
by hand. Every accuracy statement below is also in
[choosing_an_integrator.claims.json](choosing_an_integrator.claims.json), which
`test/test_choosing_claims.py` re-measures on every test run. The |ω|·h limits come from
[stability.md](stability.md) (`make envelope`). Speed figures are this run's, on the machine
named below; compare them only with each other.

## In short

- **`rk4` (the default)**: fourth order on a torque-free body. Cheapest of ours on the
  asymmetric top at each accuracy goal in this run: {cheapest_text}. Under a force fixed in
  the body (the box, a force at a corner site) its observed order is {rk4_orders}.
  Keep |ω|·h within its limit below ({stability.get('rk4', 'see stability.md')}).
- **Fast spin or large steps, torque-free:** `exact_rotor_splitting` is the exact free-rotor
  flow at any |ω|·h; one `step(1)` of it cost {_fmt(exact_ratio, 2)}× one of `rk4` here, so it pays
  when it lets the step grow by more than that.
- **Thin rods and discs:** `symmetric_splitting` (limit {stability.get('symmetric_splitting', 'see stability.md')}) keeps
  |L| to round-off; `splitting` degrades there ({stability.get('splitting', 'see stability.md')}).
- **Not for tumbling bodies:** {', '.join(f'`{n}`' for n in first_order)} — first order, with |ω|·h
  limits near 1e-3 (stability.md); they are here for comparison with textbook and game-engine loops.
- **Spheres, cubes, cylinders, static and kinematic bodies** get exact reduced models
  whatever the integrator ([scenes.md](scenes.md), "Motions and model reduction").

## Choosing the step

1. Take the fastest body rate you expect, |ω|max (rad/s), and the integrator's limit from the
   table (|ω|·h for an energy error below 1e-3 over 1e4 steps): h ≤ limit / |ω|max.
2. For an accuracy goal, read the largest h that reached it on the asymmetric top below.
3. In the node, h = `real_time_factor` / (`rate_hz` · `substeps`): raise `substeps` to shorten
   the step without publishing faster.
4. Under a force fixed in the body, the error falls as h^order with the observed order of the
   table's "order" column: halve h to divide that error by 2^order.

## The numbers

Machine:

{machine_text}
Columns: the cost of one second of sim time to reach an orientation error of 1e-3, 1e-6 and
1e-9 rad over 10 s on the torque-free asymmetric top I = (1, 2, 2.5) kg·m², ω0 = (1, 0.3, 2)
rad/s (interpolated on the sweep; h = the largest swept step that reached it); the box (2 kg,
1.0 × 0.6 × 0.4 m, 10 N along its own y at the corner site (0.5, 0.3, 0) m, 1 s): COM position
error at h = 1 ms and the observed order between h = 4 ms and 1 ms; µs per step of one body
with a new site-frame force every step (`apply_force_at_point` + `step(1)`); body-steps/s at
N = {n_max:g} tumbling boxes (`step(n)`); the gain of model reduction on the mixed scene
against a full model that skips static bodies; the |ω|·h limit (I = (1, 2, 3) / rod r = 1e-6).

| integrator | 1e-3 rad | 1e-6 rad | 1e-9 rad | box error at 1 ms (m) | order, body-fixed force | µs/step, 1 body + site force | body-steps/s, N = {n_max:g} | reduction gain | \\|ω\\|·h limit |
|---|---|---|---|---|---|---|---|---|---|
{rows}{mj_rows}
"""


def write(docs: Path, wp, sites, tp, red, machine_text: str, mode_name: str, provenance: str) -> list[Path]:
    """Write the page and its claims into ``docs``; returns the paths."""
    docs.mkdir(parents=True, exist_ok=True)
    text = page(wp, sites, tp, red, machine_text, mode_name, stability_limits(docs / "stability.md"), provenance)
    page_path = docs / "choosing_an_integrator.md"
    page_path.write_text(text)
    claims_path = docs / "choosing_an_integrator.claims.json"
    claims_path.write_text(json.dumps({"generated_by": "make bench (benchmarks/choosing.py)", "provenance": provenance,
                                       "problems": problem_definitions(), "claims": claims(wp)}, indent=1) + "\n")
    return [page_path, claims_path]
