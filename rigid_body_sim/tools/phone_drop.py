"""Phone drops: how often does a phone slipping off a fingertip land screen-down?

The scene is config/phone_drop.yaml: a phone (a thin box, 14.6 × 7.1 × 0.78 cm, 170 g, the
screen its body +z face) let go screen up at hand height, turning about its intermediate axis
(body y: the tennis-racket axis, unstable, so a small rate about x or z grows in flight and
twists the screen), landing on a floor (restitution 0.2, friction 0.5). Each drop draws, with a
seeded generator:

* the height of the phone's lowest point, uniform in ``HEIGHT`` (m);
* the turn rate about body y, uniform in ``SPIN`` (rad/s);
* the nudge of the spin axis: rates about body x and z, each normal with standard deviation
  ``NUDGE`` × the turn rate (a spin axis off body y by a few degrees);

and runs the core's contact solver (rk4, dt = ``DT``) until the phone is at rest
(:func:`drop`). It then reads which face is down: screen-down when the body +z axis points
into the floor. One command regenerates docs/phone_drop.png and docs/phone_drop.md::

    .venv/bin/python -m rigid_body_sim.tools.phone_drop --drops 2000 --seed 2026 --out docs

This module imports only the core (no ROS).
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.core.quaternion import quat_to_matrix, quat_wxyz_from_xyzw
from rigid_body_sim.package_data import config_dir

__all__ = ["SCENE_FILE", "HEIGHT", "SPIN", "NUDGE", "DT", "MAX_TIME", "Drop", "scene_data", "drop", "run", "main"]

SCENE_FILE = "phone_drop.yaml"
#: Height of the phone's lowest point when it is let go, m (uniform).
HEIGHT = (1.0, 1.4)
#: Turn rate about the intermediate axis (body y), rad/s (uniform): 0 to 4 turns a second.
SPIN = (0.0, 8.0 * math.pi)
#: Standard deviation of the rates about body x and z, as a fraction of the turn rate.
NUDGE = 0.05
#: Integrator and step of every drop.
INTEGRATOR, DT = "rk4", 1e-3
#: A drop not at rest after this long (s of sim time) is reported as such (never seen).
MAX_TIME = 5.0


@dataclass(frozen=True)
class Drop:
    """One drop: what was drawn and how it ended.

    ``face_down``: the screen (body +z) faces the floor at rest. ``up_z``: the world z component
    of body +z at rest (±1 on a face). ``gap``: the lowest corner's height at rest, m.
    ``height_rest``: the centre's height at rest, m. The largest rise of E = KE + m g z over one
    step, J (≤ 0: never gained): ``rest_rise`` over steps in persistent contact without an event
    (resting, sliding, rolling: the contact forces and the projection), ``event_rise`` over steps
    with an event (impacts, landings, lift-offs, stops; such a step also holds flight pieces) and
    ``flight_rise`` over contact-free steps (the integrator's own error on the tumbling phone).
    ``impacts``: their number; ``impact_gain``: the largest kinetic energy after over before, minus 1,
    over them (≤ 0: no impact gained).
    """

    height: float
    spin: float
    nudge_x: float
    nudge_z: float
    at_rest: bool
    t_rest: float
    face_down: bool
    up_z: float
    gap: float
    height_rest: float
    energy_start: float
    energy_end: float
    rest_rise: float
    event_rise: float
    flight_rise: float
    impacts: int
    impact_gain: float


def scene_data(path: Path | None = None) -> dict[str, Any]:
    """The phone scene as a mapping (config/phone_drop.yaml unless ``path``)."""
    with open(path or config_dir() / SCENE_FILE, encoding="utf-8") as f:
        return yaml.safe_load(f)


def _corners(size: np.ndarray) -> np.ndarray:
    half = 0.5 * size
    return np.array([[sx * half[0], sy * half[1], sz * half[2]]
                     for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])


def drop(data: dict[str, Any], height: float, spin: float, nudge_x: float, nudge_z: float,
         integrator: str = INTEGRATOR, dt: float = DT, max_time: float = MAX_TIME) -> Drop:
    """One drop of the phone of ``data`` (scene_data()): let go screen up, lowest point at ``height``,
    turning at ``spin`` about body y and (nudge_x, nudge_z) about x and z (rad/s), until at rest."""
    data = {**data, "bodies": {name: dict(body) for name, body in data["bodies"].items()}}
    (name, body), = data["bodies"].items()
    size = np.asarray(body["collision"]["box"], dtype=float)
    body["pose"] = {"position": [0.0, 0.0, height + 0.5 * size[2]], "orientation": [0.0, 0.0, 0.0, 1.0]}
    body["twist"] = {"linear": [0.0, 0.0, 0.0], "angular": [nudge_x, spin, nudge_z]}
    sim = Simulator(load_scene(data), integrator=integrator, dt=dt)
    contact = sim.contact
    mass, g = float(body["mass"]), -float(data["gravity"][2])
    corners = _corners(size)

    def energy() -> float:
        return float(sim.kinetic_energy()[0]) + mass * g * float(sim.state.p_WC_W[0, 2])

    start = previous = energy()
    rises = {"rest": -math.inf, "event": -math.inf, "flight": -math.inf}
    at_rest = False
    while sim.time < max_time:
        resting, seen = contact.is_resting(name), len(contact.events)
        sim.step()
        now = energy()
        kind = "event" if len(contact.events) != seen else "rest" if resting else "flight"
        rises[kind] = max(rises[kind], now - previous)
        previous = now
        if (contact.is_resting(name) and np.linalg.norm(sim.state.v_WC_W[0]) <= 1e-12
                and np.linalg.norm(sim.state.w_WP_P[0]) <= 1e-12):
            at_rest = True
            break
    impacts = contact.events_of(name, "impact")
    R = quat_to_matrix(quat_wxyz_from_xyzw(sim.orientations_xyzw()[0]))
    p = np.array(sim.state.p_WC_W[0])
    gap = float(np.min(p[2] + corners @ R[2]))
    up_z = float(R[2, 2])
    return Drop(height, spin, nudge_x, nudge_z, at_rest, sim.time, up_z < 0.0, up_z, gap, float(p[2]),
                start, energy(), rises["rest"], rises["event"], rises["flight"], len(impacts),
                max((e.energy_after / e.energy_before - 1.0 for e in impacts if e.energy_before > 0.0),
                    default=-math.inf))


def run(drops: int, seed: int = 0, data: dict[str, Any] | None = None, spin: tuple[float, float] = SPIN,
        height: tuple[float, float] = HEIGHT, nudge: float = NUDGE, progress: bool = False) -> list[Drop]:
    """``drops`` randomised drops (the module docstring), from ``np.random.default_rng(seed)``."""
    data = data or scene_data()
    rng = np.random.default_rng(seed)
    results = []
    for k in range(drops):
        h = float(rng.uniform(*height))
        w = float(rng.uniform(*spin))
        nx, nz = (float(x) for x in rng.normal(0.0, nudge * w, 2))
        results.append(drop(data, h, w, nx, nz))
        if progress:
            print(f"\r{k + 1}/{drops}", end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)
    return results


def _binned(results: list[Drop], key: str, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per bin of ``key``: (centres, face-down fraction, count)."""
    x = np.array([getattr(d, key) for d in results])
    down = np.array([d.face_down for d in results], dtype=float)
    which = np.clip(np.digitize(x, edges) - 1, 0, len(edges) - 2)
    count = np.bincount(which, minlength=len(edges) - 1)
    hits = np.bincount(which, weights=down, minlength=len(edges) - 1)
    with np.errstate(invalid="ignore"):
        return 0.5 * (edges[1:] + edges[:-1]), hits / count, count


def plot(results: list[Drop], path: Path, spin_bins: int = 16) -> None:
    """Face-down fraction against the turn rate (binned, with binomial standard errors), and each drop."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    spins = np.array([d.spin for d in results])
    heights = np.array([d.height for d in results])
    down = np.array([d.face_down for d in results])
    edges = np.linspace(SPIN[0], SPIN[1], spin_bins + 1)
    centres, fraction, count = _binned(results, "spin", edges)
    error = np.sqrt(fraction * (1.0 - fraction) / np.maximum(count, 1))
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    turns = 1.0 / (2.0 * math.pi)
    a.errorbar(centres * turns, fraction, yerr=error, fmt="o-", capsize=3)
    a.axhline(np.mean(down), color="grey", ls="--", lw=1, label=f"all drops: {np.mean(down):.2f}")
    a.set_xlabel("turn rate about the intermediate axis, turns/s")
    a.set_ylabel("fraction landing screen-down")
    a.set_ylim(-0.05, 1.05)
    a.set_title(f"{len(results)} drops, {count.min()}–{count.max()} per bin (±1 s.e.)")
    a.legend(loc="upper left")
    b.scatter(spins[~down] * turns, heights[~down], s=12, marker="o", label="not screen-down", color="tab:blue")
    b.scatter(spins[down] * turns, heights[down], s=14, marker="x", label="screen down", color="tab:red")
    b.set_xlabel("turn rate, turns/s")
    b.set_ylabel("height of the lowest point when let go, m")
    b.set_title("each drop")
    b.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def page(results: list[Drop], seed: int, seconds: float, spin_bins: int = 16) -> str:
    """docs/phone_drop.md: the settings, the measured fractions, and the checks every drop passed."""
    n = len(results)
    down = sum(d.face_down for d in results)
    edges = np.linspace(SPIN[0], SPIN[1], spin_bins + 1)
    centres, fraction, count = _binned(results, "spin", edges)
    rows = "\n".join(f"| {lo / (2 * math.pi):.2f}–{hi / (2 * math.pi):.2f} | {c} | {f:.2f} |"
                     for lo, hi, c, f in zip(edges[:-1], edges[1:], count, fraction))
    flat = [d for d in results if d.at_rest and abs(d.up_z) > 0.5]
    side = [d for d in results if abs(d.up_z) <= 0.5]
    moving = [d for d in results if not d.at_rest]
    gaps = max(abs(d.gap) for d in flat)
    heights = max(abs(d.height_rest - 0.5 * 0.0078) for d in flat)
    faces = max(abs(abs(d.up_z) - 1.0) for d in flat)
    others = "\n".join(f"| {d.height:.3f} | {d.spin / (2 * math.pi):.3f} | {d.nudge_x:+.3f}, {d.nudge_z:+.3f} | "
                        f"{'yes' if d.at_rest else 'no'} | {d.up_z:+.3f} | {d.height_rest * 1e3:.2f} | {d.gap:.1e} |"
                        for d in [d for d in results if d not in flat][:20])
    rest = max(d.rest_rise / d.energy_start for d in results)
    gaining = sum(d.rest_rise > 1e-12 * d.energy_start for d in results)
    event = max(d.event_rise / d.energy_start for d in results)
    flight = max(d.flight_rise / d.energy_start for d in results)
    impact = max(d.impact_gain for d in results)
    gained = ("≤ 0: no impact gained" if impact <= 0.0 else "round-off: no impact gained more than 1e-12 of it"
              if impact <= 1e-12 else "an impact gained energy")

    half = sum(d.face_down for d in results if d.spin < math.pi)
    half_n = sum(1 for d in results if d.spin < math.pi)
    return f"""# Dropping a phone: how often does it land screen-down?

A phone slips off a fingertip, screen up, at hand height, turning end over end about its
intermediate axis (the short in-plane axis: the tennis-racket axis, so any small rate about the
other two grows in flight and twists the screen), and lands on a hard floor. How often does it
end screen-down? The scene is [config/phone_drop.yaml](../config/phone_drop.yaml); the drops are
run by `rigid_body_sim/tools/phone_drop.py` (core only, no ROS) with the rigid contact model of
[contact.md](contact.md).

![Face-down fraction against the turn rate](phone_drop.png)

## Settings

* Phone: box 0.146 × 0.071 × 0.0078 m, 0.17 kg, screen = body +z face; let go screen up, at rest
  apart from its spin.
* Floor: restitution 0.2, friction 0.5 (pair values; the phone declares the same box as its
  collision shape).
* Per drop, from `numpy.random.default_rng({seed})`: lowest point at a height uniform in
  {HEIGHT[0]}–{HEIGHT[1]} m; turn rate about body y uniform in 0–{SPIN[1] / (2 * math.pi):.0f} turns/s;
  rates about body x and z each normal with standard deviation {NUDGE} × the turn rate.
* rk4, dt = {DT * 1e3:g} ms, run until the phone is at rest (contact persistent, |v| and |ω| ≤ 1e-12).
* N = {n} drops, {seconds:.0f} s on {platform.machine()} ({platform.python_implementation()} {platform.python_version()}),
  regenerated by `.venv/bin/python -m rigid_body_sim.tools.phone_drop --drops {n} --seed {seed} --out docs`.

## Measured

**{down} of {n} drops ({down / n:.2f}) ended screen-down.** Below half a turn a second (the
phone has not turned over by the time it lands): {half} of {half_n}.

| turn rate, turns/s | drops | screen-down fraction |
|---|---|---|
{rows}

The fraction swings with the turn rate because the flight lasts about √(2h/g) ≈ 0.45–0.53 s:
the number of half-turns made before the first impact decides the face, and the bounce (e = 0.2)
and the tumble after it only sometimes turn the phone over again. The spread in height shifts
the turned angle by ±8 % of the turns made, which blurs the pattern at high rates.

## How the drops ended, and where energy was gained

{len(flat)} of {n} drops ended at rest flat on the screen or the back, after
{min(d.t_rest for d in flat):.2f}–{max(d.t_rest for d in flat):.2f} s of sim time: the lowest corner's
height at rest |gap| ≤ {gaps:.1e} m; the centre's height at rest minus half the thickness
≤ {heights:.1e} m; | |z-component of body z| − 1 | ≤ {faces:.1e}. {len(side)} ended standing on a
long or short side (|z-component of body z| ≤ 0.5), {len(moving)} were still moving when the run
stopped at {MAX_TIME:g} s of sim time (counted as not screen-down above). The first of those
{n - len(flat)} (up to 20):

| height, m | turns/s | x, z rates, rad/s | at rest | body z · world z | centre height, mm | gap, m |
|---|---|---|---|---|---|---|
{others}

Largest change of the kinetic energy across an impact, relative to it: {impact:.1e} ({gained}). Largest rise of E = KE + m g z over one step, relative to the drop's energy: contact-free
steps {flight:.1e} (rk4's own error on the tumbling phone), steps with an event {event:.1e},
steps in persistent contact {rest:.1e}. **{gaining} of {n} drops gained energy (more than 1e-12
of theirs) in some step of persistent contact** (rk4 finds the contact force at every stage, each
contact point's sliding friction against its own slip: [contact.md](contact.md), "Persistent
contact"). test/test_contact_landing.py runs a handful of these drops and checks the rest state,
the impacts and the flight steps, and for one drop that slides on an edge while spinning, the
steps in persistent contact.

What this does not model: the floor's and the phone's compliance (real restitution depends on
the impact speed), the hand's release (a phone slipping off a finger also picks up a little
sideways speed), air drag, and a phone landing on its corner at an angle where several
simultaneous contacts with e > 0 make the outcome depend on the impact model (contact.md,
"What is model-dependent").
"""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--drops", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--out", type=Path, default=Path("docs"), help="directory for phone_drop.png and phone_drop.md")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    results = run(args.drops, args.seed, progress=True)
    seconds = time.perf_counter() - started
    args.out.mkdir(parents=True, exist_ok=True)
    plot(results, args.out / "phone_drop.png")
    (args.out / "phone_drop.md").write_text(page(results, args.seed, seconds), encoding="utf-8")
    down = sum(d.face_down for d in results)
    print(f"{down}/{len(results)} screen-down ({down / len(results):.3f}); {seconds:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
