"""Contact side by side: ours, MuJoCo and PyBullet on the closed-form contact cases, in one run.

``python -m benchmarks.contact_peers [--quick] [--out benchmarks/results] [--docs docs/contact_benchmarks.md]``
(``make bench-contact``). Writes ``contact_peers.csv`` (every measured figure) and
``contact_peers.md`` (the tables, the settings, the machine) to ``--out`` and, with ``--docs``,
the generated block of that page (between ``<!-- contact-bench:begin -->`` and ``-end -->``).

Cases (g = 9.81 m/s², exact answers from rigid_body_sim/exact/contact.py), each at dt = 10 ms,
1 ms and 0.1 ms:

* **bounce**: a solid sphere r = 0.1 m, 1 kg, dropped at rest with its lowest point 1 m up,
  e = 0.5: the first three apexes (h + v²/(2g) at the highest sample of each flight) and
  impact times (ours: the located events; peers: where the free flight from the last sample
  above the ground before the first step whose velocity change is not free fall reaches the
  ground, within the next step),
  the penetration at t = 3 s, the energy gain across a bounce (E = KE + m g z, the median over
  each flight, its largest rise from one flight to the next: 0 if it never rises) and the
  largest rise of E over any earlier value (0 for a rigid contact; a soft contact stores energy
  in its spring while in contact and returns it);
* **slide**: a 0.2 m cube, 1 kg, μ = 0.5, launched at 2 m/s: the distance to its stop and the
  stop time (ours: the located ``stick`` event; peers: the time the speed falls below
  1e-3 m/s, interpolated, against the closed-form time of that speed), the penetration at rest;
* **roll**: a solid sphere r = 0.1 m launched sliding at 2 m/s without spin, μ = 0.3: the time
  rolling starts (ours: the ``stick`` event; peers: the slip speed below 1e-3 m/s,
  interpolated, against the closed form for that slip) and the speed then;
* **incline**: the cube on a 20° slope (gravity tilted by 20° about y on the flat ground —
  the same physics in every engine): μ = 0.5 must not move (the mean speed over t = 1 … 3 s is
  the creep), μ = 0.3 slides with a = g (sin θ − μ cos θ) (measured as the velocity change over
  t = 0.5 … 1.5 s);
* **rock**: a 0.2 × 0.2 × 1 m box, 1 kg, μ = 0.9, e = 0, released at rest tilted 0.02 rad onto a
  bottom edge: it rocks on its edges (Housner's block). Landings 1 and 5 (ours: the located
  impacts; peers: the instants the centre passes over the footprint's middle, interpolated) and
  the rocking energy kept at them (KE + m g (z − z_rest), z_rest the engine's own standing rest
  height, the median over the middle half of the rock after the landing over the one before).

Between bodies (part ``bodies``, benchmarks/contact_bodies.py, whose docstring has the
conventions): two spheres head-on (equal and unequal masses, e = 0.5, frictionless) and oblique
with friction and spin, against rigid_body_sim/exact/sphere_impact.py; a 1 cm sphere at 100 m/s
toward a 1 cm static box and two such spheres at each other (held or passed), at the same dts.

Peers start a launched case at rest on the ground, settle 0.5 s, then get the launch velocity;
ours starts touching (persistent contact) with its launch velocity. The cost of each case (µs
per step) is timed apart from the sampling: the median (min–max) of ≥ 5 interleaved samples
(benchmarks/timing.py) of stepping from the case's start state.

Throughput: 1000 cubes resting on a plane (a 32 × 32 grid, 0.5 m apart, dt = 1 ms, settled),
body-steps/s, ours (rk4 and semi_implicit_euler) against MuJoCo (pyramidal and elliptic cone,
``mj_step(m, d, nstep=k)``) and PyBullet (``stepSimulation`` loop). And the free-body scene of
benchmarks/throughput.py at N = 1e4 (rk4, no contact) with no ``ground:`` key against the same
scene with a ground and every body ``collision: none`` (the contact code is present but has no
body: the simulator runs its contact-free step), and, with ``--baseline REV``, against that
revision's core (benchmarks/core_compare.py; default: the last commit before contact).
"""

from __future__ import annotations

import argparse
import csv
import datetime
import math
import sys
import time
from pathlib import Path

import numpy as np

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.exact import contact as exact

from . import contact_bodies as B
from . import contact_engines as E
from . import machine
from .timing import MIN_REPEATS, Case, interleaved

G = 9.81
DTS = (1e-2, 1e-3, 1e-4)
OURS = ("rk4", "semi_implicit_euler")
BLOCK_BEGIN, BLOCK_END = "<!-- contact-bench:begin -->", "<!-- contact-bench:end -->"
#: The last commit before contact (the --baseline default): its free-body throughput is "today's".
PRE_CONTACT = "1800032^"
SETTLE = 0.5  # s a peer rests on the ground before a launch
SPEED_THRESHOLD = 1e-3  # m/s: a peer's slide has stopped / its ball rolls below this speed / slip
R, H0, E_BOUNCE = 0.1, 1.0, 0.5
CUBE = (0.2, 0.2, 0.2)
V0 = 2.0
MU_SLIDE, MU_ROLL = 0.5, 0.3
THETA = math.radians(20.0)
ROCK, ROCK_TILT, MU_ROCK = (0.2, 0.2, 1.0), 0.02, 0.9  # the rocking box (m), its release tilt (rad), its μ
ROCK_LANDINGS = 5
CUBES = 1000
FREE_BODIES = 10_000


# ----------------------------------------------------------------------------- scenes of the cases

def bounce_body() -> E.Body:
    return E.Body("sphere", (R,), 1.0, (0.0, 0.0, H0 + R), friction=0.5, restitution=E_BOUNCE)


def slide_body(launched: bool) -> E.Body:
    return E.Body("box", CUBE, 1.0, (0.0, 0.0, 0.1), friction=MU_SLIDE,
                  velocity=(V0, 0.0, 0.0) if launched else (0.0, 0.0, 0.0))


def roll_body(launched: bool) -> E.Body:
    return E.Body("sphere", (R,), 1.0, (0.0, 0.0, R), friction=MU_ROLL,
                  velocity=(V0, 0.0, 0.0) if launched else (0.0, 0.0, 0.0))


def incline_body(mu: float) -> E.Body:
    return E.Body("box", CUBE, 1.0, (0.0, 0.0, 0.1), friction=mu,
                  gravity=(G * math.sin(THETA), 0.0, -G * math.cos(THETA)))


def rock_body() -> E.Body:
    """The box upright centred on x = 0, turned by ROCK_TILT about y onto its bottom edge x = +w/2 (at rest)."""
    w, _, h = ROCK
    c, s = math.cos(ROCK_TILT), math.sin(ROCK_TILT)
    edge_x = 0.5 * w  # the centre from that edge, upright (−w/2, h/2), turned about y
    return E.Body("box", ROCK, 1.0, (edge_x - 0.5 * w * c + 0.5 * h * s, 0.0, 0.5 * w * s + 0.5 * h * c),
                  friction=MU_ROCK, orientation=(0.0, math.sin(0.5 * ROCK_TILT), 0.0, math.cos(0.5 * ROCK_TILT)))


def engines(body: E.Body, dt: float, case: str, rest: E.Body | None = None) -> list[E.Engine]:
    """Ours (each of OURS) on ``body``; MuJoCo's and PyBullet's settings on ``rest`` (a launched case) or ``body``."""
    out: list[E.Engine] = [E.Ours(body, dt, name) for name in OURS]
    peer = body if rest is None else rest
    if case == "bounce":
        out.append(E.MuJoCo(peer, dt, "oscillator"))
        out.append(E.MuJoCo(peer, dt, "calibrated", calibrate_dampratio(dt)))
        out += [E.PyBullet(peer, dt, s) for s in ("default", "tuned")]
    else:
        out += [E.MuJoCo(peer, dt, s) for s in ("pyramidal", "elliptic, impratio 10", "elliptic, impratio 10, noslip 10")]
        out.append(E.PyBullet(peer, dt, "default"))
    return out


# ----------------------------------------------------------------------------- sampled runs

def run(engine: E.Engine, seconds: float, launch=None) -> dict:
    """Step ``engine`` for ``seconds`` (after SETTLE s at rest and a launch, for a peer, if ``launch``).

    Returns arrays t (from the launch), p (3), w (world), v (3), kinetic energy per sample.
    """
    dt = engine.sim.dt if isinstance(engine, E.Ours) else _dt(engine)
    if launch is not None and not isinstance(engine, E.Ours):
        engine.step(int(round(SETTLE / dt)))
        engine.set_velocity(*launch)
    steps = int(round(seconds / dt))
    t = np.arange(steps + 1) * dt
    P, Wv, Vv, K = np.empty((steps + 1, 3)), np.empty((steps + 1, 3)), np.empty((steps + 1, 3)), np.empty(steps + 1)
    P[0], Wv[0], Vv[0], K[0] = engine.sample()
    for k in range(1, steps + 1):
        engine.step(1)
        P[k], Wv[k], Vv[k], K[k] = engine.sample()
    return {"t": t, "p": P, "w": Wv, "v": Vv, "ke": K}


def _dt(engine) -> float:
    if isinstance(engine, E.MuJoCo):
        return float(engine.m.opt.timestep)
    return float(E.pybullet.getPhysicsEngineParameters(physicsClientId=engine.c)["fixedTimeStep"])


def _crossing(t: np.ndarray, x: np.ndarray, level: float, start: int = 0, downward: bool = True) -> tuple[float, int]:
    """(time, index) of the first sample from ``start`` at or past ``level`` (falling if ``downward``), interpolated."""
    for k in range(max(start, 1), len(x)):
        if (x[k] <= level < x[k - 1]) if downward else (x[k] >= level > x[k - 1]):
            s = (x[k - 1] - level) / (x[k - 1] - x[k])
            return float(t[k - 1] + s * (t[k] - t[k - 1])), k
    return math.nan, -1


# ----------------------------------------------------------------------------- cases

def calibrate_dampratio(dt: float) -> float:
    """MuJoCo's dampratio (solref (0.02, ζ) on both geoms) whose first apex is the closed form's, by bisection."""
    target = exact.bounce_apex(1, H0, E_BOUNCE)
    lo, hi = 0.01, 1.0
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        apex = bounce_apexes(E.MuJoCo(bounce_body(), dt, "calibrated", mid), 1, 1.1)[0]
        if not math.isfinite(apex) or apex < target:
            hi = mid  # too much damping: less
        else:
            lo = mid
    return 0.5 * (lo + hi)


def bounce_apexes(engine, count: int, seconds: float) -> list[float]:
    r = run(engine, seconds)
    return _apexes(r, _impacts(r, count + 1)[1], count)


def _impacts(r: dict, count: int) -> tuple[list[float], list[tuple[int, int]]]:
    """A peer's first ``count`` impacts from its samples, and its flights as (first, last) sample indices.

    A contact force acted in step k when the vertical velocity change departs from free fall
    (Δv_z > −g dt + 1 % of g dt); the impact time is where the free flight from the last sample
    above the ground (gap = z − R > 0) up to k reaches gap 0, within the step after that
    sample (a soft contact acts only once the body is inside; a speculative one before it
    arrives). A flight starts at the first sample above the ground, moving up, after which the
    velocity changes as in free fall again.
    """
    t, gap, vz = r["t"], r["p"][:, 2] - R, r["v"][:, 2]
    h = t[1] - t[0]
    free = np.diff(vz) <= -G * h * 0.99  # step k → k+1 in free fall
    times, flights, k, start = [], [], 0, 0
    while len(times) < count:
        while k < len(free) and free[k]:
            k += 1
        if k >= len(free):
            break
        j = k  # the last sample above the ground up to k: the free flight from it reaches the ground
        while j > start and gap[j] <= 0.0:
            j -= 1
        g0, v0 = gap[j], vz[j]  # g0 + v0 s − ½ g s² = 0
        disc = v0 * v0 + 2.0 * G * g0
        s = (v0 + math.sqrt(disc)) / G if disc >= 0.0 else h
        times.append(float(t[j] + min(max(s, 0.0), h)))
        flights.append((start, k))
        while k < len(free) and not (free[k] and gap[k] > 0.0 and vz[k] > 0.0):  # in contact until it flies up
            k += 1
        start = k
    return times + [math.nan] * (count - len(times)), flights


def _apexes(r: dict, flights: list[tuple[int, int]], count: int) -> list[float]:
    """Apex of flights 1..``count`` (``flights[0]`` is the drop): h + v²/(2g) at the highest sample (nan: none)."""
    gap, vz = r["p"][:, 2] - R, r["v"][:, 2]
    apexes = []
    for f in range(1, count + 1):
        if f >= len(flights) or flights[f][1] <= flights[f][0]:
            apexes.append(math.nan)
            continue
        a, b = flights[f]
        m = a + int(np.argmax(gap[a:b + 1]))
        apexes.append(float(gap[m] + vz[m] ** 2 / (2.0 * G)) if gap[m] > 0.0 else math.nan)
    return apexes


def _flights_between(r: dict, impacts: list[float]) -> list[tuple[int, int]]:
    """Flights as sample ranges between located impact times (ours: the events)."""
    t = r["t"]
    edges = [0.0] + [x for x in impacts if math.isfinite(x)]
    out = []
    for a, b in zip(edges, edges[1:]):
        ia, ib = int(np.searchsorted(t, a, side="right")), int(np.searchsorted(t, b, side="left")) - 1
        out.append((ia, ib))
    return out


def case_bounce(engine) -> list[dict]:
    r = run(engine, 3.0)
    if isinstance(engine, E.Ours):
        events = engine.sim.contact.events_of("b0", "impact")
        impacts = [e.time for e in events[:4]] + [math.nan] * max(0, 4 - len(events))
        flights = _flights_between(r, impacts)
    else:
        impacts, flights = _impacts(r, 4)
    apexes = _apexes(r, flights, 3)
    energy = r["ke"] + 1.0 * G * r["p"][:, 2]
    rise = float(np.max(energy - np.minimum.accumulate(energy)))
    in_flight = [float(np.median(energy[a:b + 1])) for a, b in flights[:4] if b >= a]
    gain = max((max(0.0, b - a) for a, b in zip(in_flight, in_flight[1:])), default=math.nan)  # 0: none
    rows = []
    for k in range(3):
        a_exact = exact.bounce_apex(k + 1, H0, E_BOUNCE)
        t_exact = exact.bounce_impact_time(k + 1, H0, E_BOUNCE, G)
        rows.append(_row("bounce", f"apex {k + 1}", apexes[k], a_exact, "m", relative=True))
        rows.append(_row("bounce", f"impact {k + 1}", impacts[k], t_exact, "s"))
    rows.append(_row("bounce", "penetration at 3 s", max(0.0, R - r["p"][-1, 2]), 0.0, "m"))
    rows.append(_row("bounce", "energy gain across a bounce", gain, 0.0, "J"))
    rows.append(_row("bounce", "largest energy rise", rise, 0.0, "J"))
    return rows


def case_slide(engine) -> list[dict]:
    r = run(engine, 1.0, launch=((V0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    d_exact, t_exact = exact.sliding_stop(V0, MU_SLIDE, G)
    x = r["p"][:, 0] - r["p"][0, 0]
    if isinstance(engine, E.Ours):
        stops = engine.sim.contact.events_of("b0", "stick")
        t_stop, t_ref = (stops[0].time if stops else math.nan), t_exact
    else:
        speed = np.linalg.norm(r["v"], axis=1)
        t_stop, _ = _crossing(r["t"], speed, SPEED_THRESHOLD)
        t_ref = exact.sliding_speed_time(SPEED_THRESHOLD, V0, MU_SLIDE, G)
    return [_row("slide", "distance", float(x[-1]), d_exact, "m", relative=True),
            _row("slide", "stop time", t_stop, t_ref, "s", relative=True),
            _row("slide", "penetration at rest", max(0.0, 0.1 - r["p"][-1, 2]), 0.0, "m")]


def case_roll(engine) -> list[dict]:
    r = run(engine, 0.5, launch=((V0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    t_exact, v_exact = exact.rolling_start(V0, MU_ROLL, G)
    if isinstance(engine, E.Ours):
        sticks = engine.sim.contact.events_of("b0", "stick")
        t_roll, t_ref = (sticks[0].time if sticks else math.nan), t_exact
        k = int(np.searchsorted(r["t"], t_roll)) if sticks else -1  # the first sample rolling
    else:
        # slip = velocity of the contact point r_c = −R ẑ: v + ω × r_c
        w, v = r["w"], r["v"]
        slip = np.hypot(v[:, 0] - R * w[:, 1], v[:, 1] + R * w[:, 0])
        t_roll, k = _crossing(r["t"], slip, SPEED_THRESHOLD)
        t_ref = exact.slip_speed_time(SPEED_THRESHOLD, V0, MU_ROLL, G)
    speed = float(np.linalg.norm(r["v"][min(k, len(r["t"]) - 1)])) if k >= 0 else math.nan
    return [_row("roll", "rolling from", t_roll, t_ref, "s", relative=True),
            _row("roll", "speed then", speed, v_exact, "m/s", relative=True)]


def case_incline(engine, mu: float) -> list[dict]:
    if mu == 0.5:
        r = run(engine, 3.0)
        i1 = int(round(1.0 / (r["t"][1] - r["t"][0])))
        creep = float(abs(r["p"][-1, 0] - r["p"][i1, 0]) / (r["t"][-1] - r["t"][i1]))
        return [_row("incline", "creep, mu 0.5", creep, 0.0, "m/s")]
    r = run(engine, 1.5)
    h = r["t"][1] - r["t"][0]
    i0 = int(round(0.5 / h))
    a = float((r["v"][-1, 0] - r["v"][i0, 0]) / (r["t"][-1] - r["t"][i0]))
    return [_row("incline", "acceleration, mu 0.3", a, exact.incline_acceleration(THETA, mu, G), "m/s²",
                 relative=True)]


def _standing_height(engine: E.Engine, seconds: float = 1.0) -> float:
    """The height of the rocking box's centre standing upright at rest in ``engine``'s kind and setting."""
    body = E.Body("box", ROCK, engine.body.mass, (0.0, 0.0, 0.5 * ROCK[2]), friction=MU_ROCK)
    dt = engine.sim.dt if isinstance(engine, E.Ours) else _dt(engine)
    extra = (engine.dampratio,) if isinstance(engine, E.MuJoCo) else ()
    standing = type(engine)(body, dt, engine.setting, *extra)
    standing.step(int(round(seconds / dt)))
    z = float(standing.sample()[0][2])
    standing.close()
    return z


def case_rock(engine) -> list[dict]:
    r = run(engine, 1.2)
    w, _, h = ROCK
    t, x = r["t"], r["p"][:, 0]
    flips = np.flatnonzero(np.sign(x[1:]) != np.sign(x[:-1]))  # upright between samples k and k + 1
    upright = [float(t[k] + (t[k + 1] - t[k]) * x[k] / (x[k] - x[k + 1])) for k in flips]
    if isinstance(engine, E.Ours):
        landings = [e.time for e in engine.sim.contact.events_of("b0", "impact")]
    else:
        landings = upright
    # the rocking energy above the engine's own rest standing (a soft contact rests sunk in): KE + m g (z − z_rest),
    # the median over the middle half of each rock between uprights
    energy = r["ke"] + engine.body.mass * G * (r["p"][:, 2] - _standing_height(engine))
    ends = [0.0] + upright
    rocks = [float(np.median(energy[(t >= a + 0.25 * (b - a)) & (t <= b - 0.25 * (b - a))]))
             for a, b in zip(ends[:-1], ends[1:])]
    kept = exact.rocking_spin_kept(w, h) ** 2
    times = exact.rocking_landings(ROCK_LANDINGS, w, h, ROCK_TILT, G)
    rows = []
    for k in (1, ROCK_LANDINGS):
        at = landings[k - 1] if len(landings) >= k else math.nan
        share = rocks[k] / rocks[k - 1] if len(rocks) > k and rocks[k - 1] > 0.0 else math.nan
        rows.append(_row("rock", f"landing {k}", at, times[k - 1], "s"))
        rows.append(_row("rock", f"energy kept at landing {k}", share, kept, "", relative=True))
    return rows


def _row(case: str, quantity: str, value: float, exact_value: float, unit: str, relative: bool = False) -> dict:
    error = value - exact_value
    if relative and exact_value != 0.0:
        error /= abs(exact_value)
    return {"case": case, "quantity": quantity, "value": value, "exact": exact_value, "unit": unit,
            "error": error, "relative": relative}


# ----------------------------------------------------------------------------- cost per step

def _timing_case(key, engine: E.Engine, max_steps: int) -> Case:
    engine.snapshot()
    return Case(key, run=engine.step, setup=engine.restore, max_units=max_steps)


# ----------------------------------------------------------------------------- the run

def measure_cases(quick: bool, log) -> tuple[list[dict], list[dict], dict[str, str]]:
    """Every case at every dt on every engine: (figure rows, cost rows, settings text per engine/setting)."""
    figures, settings = [], {}
    timing_cases = []
    plans = [("bounce", bounce_body(), None, case_bounce, 1.2),
             ("slide", slide_body(True), slide_body(False), case_slide, 1.0),
             ("roll", roll_body(True), roll_body(False), case_roll, 0.5),
             ("incline mu 0.5", incline_body(0.5), None, lambda e: case_incline(e, 0.5), 3.0),
             ("incline mu 0.3", incline_body(0.3), None, lambda e: case_incline(e, 0.3), 1.5),
             ("rock", rock_body(), None, case_rock, 1.2)]
    for dt in DTS:
        for case, body, rest, measure, seconds in plans:
            for engine in engines(body, dt, case.split()[0], rest):
                label = (engine.name, engine.setting)
                if not isinstance(engine, E.Ours):
                    key = f"{engine.name}, {engine.setting}" + (f", dt {dt:g} s" if engine.setting == "calibrated" else "")
                    settings[key] = engine.settings_text()
                t0 = time.perf_counter()
                rows = measure(engine)
                for row in rows:
                    row.update(engine=engine.name, setting=engine.setting, dt=dt)
                figures += rows
                log(f"  {case:15s} dt {dt:g} {engine.name} {engine.setting}: "
                    + "; ".join(f"{r['quantity']} {_fmt_err(r)}" for r in rows) + f"  ({time.perf_counter() - t0:.1f} s)")
                fresh = _fresh(engine, body, rest, dt)  # at the case's start state, for the cost per step
                timing_cases.append(_timing_case((case, dt) + label, fresh, int(round(seconds / dt))))
                engine.close()
    log("  timing every case (µs per step)")
    stats = interleaved(timing_cases, MIN_REPEATS, 0.02 if quick else 0.1)
    costs = [{"case": key[0], "dt": key[1], "engine": key[2], "setting": key[3], **s.scaled(1e6).as_row("us_per_step")}
             for key, s in stats.items()]
    return figures, costs, settings


def _fresh(engine: E.Engine, body: E.Body, rest: E.Body | None, dt: float) -> E.Engine:
    """A new engine like ``engine`` at the case's start (a peer of a launched case: settled, then launched)."""
    if isinstance(engine, E.Ours):
        return E.Ours(body, dt, engine.setting)
    extra = (engine.dampratio,) if isinstance(engine, E.MuJoCo) else ()
    fresh = type(engine)(body if rest is None else rest, dt, engine.setting, *extra)
    if rest is not None:
        fresh.step(int(round(SETTLE / dt)))
        fresh.set_velocity(body.velocity, body.angular_velocity)
    return fresh


def _fmt_err(r: dict) -> str:
    if not math.isfinite(r["value"]):
        return "none"
    if r["relative"]:
        return f"{r['error']:+.2e} rel."
    return f"{r['value']:.3g} {r['unit']}" if r["exact"] == 0.0 else f"{r['error']:+.2e} {r['unit']}"


def measure_cubes(quick: bool, log) -> list[dict]:
    """Body-steps/s of CUBES cubes resting on a plane, dt = 1 ms, every engine, interleaved."""
    body = E.Body("box", CUBE, 1.0, (0.0, 0.0, 0.1), friction=0.5, grid=CUBES)
    cases = []
    for name in OURS:
        eng = E.Ours(body, 1e-3, name)
        eng.step(int(round(SETTLE / 1e-3)))
        cases.append(Case(("rigid_body_sim", name), run=eng.step, max_units=10**6))
    if E.mujoco is not None:
        for s in ("pyramidal", "elliptic"):
            eng = E.MuJoCo(body, 1e-3, s)
            eng.step(int(round(SETTLE / 1e-3)))
            cases.append(Case(("MuJoCo", s), run=eng.step, max_units=10**6))
    if E.pybullet is not None:
        eng = E.PyBullet(body, 1e-3, "default")
        eng.step(int(round(SETTLE / 1e-3)))
        cases.append(Case(("PyBullet", "default"), run=eng.step, max_units=10**6))
    stats = interleaved(cases, MIN_REPEATS, 0.2 if quick else 1.0, log=log)
    return [{"engine": k[0], "setting": k[1], "bodies": CUBES, **s.rate(CUBES).as_row("body_steps_per_s")}
            for k, s in stats.items()]


def _no_collision_scene(count: int):
    """benchmarks/throughput.py's scene with a ground half-space below it and every body ``collision: none``."""
    from .throughput import ANGULAR_VELOCITY, MASS, SIDES

    bodies = {f"b{i}": {"mass": MASS, "inertia": {"box": list(SIDES)}, "collision": "none",
                        "pose": {"position": [10.0 * i, 0.0, 0.0], "orientation": [0, 0, 0, 1]},
                        "twist": {"linear": [0.0, 0.0, 0.0], "angular": ANGULAR_VELOCITY.tolist()}}
              for i in range(count)}
    return load_scene({"ground": [{"normal": [0, 0, 1], "offset": -1.0}], "bodies": bodies})


def measure_free(quick: bool, baseline: str | None, log) -> list[dict]:
    """Body-steps/s at N = FREE_BODIES: no ground key vs a ground with no collision body (vs ``baseline``'s core)."""
    from .throughput import DT, MAX_STEPS_PER_SAMPLE, scene as free_scene

    # one thread, as the core before contact ran (the parallel step would make this a threads benchmark)
    plain = Simulator(free_scene(FREE_BODIES), integrator="rk4", dt=DT, threads=1)
    grounded = Simulator(_no_collision_scene(FREE_BODIES), integrator="rk4", dt=DT, threads=1)
    assert grounded.contact is None, "a scene without collision geometry must run the contact-free step"
    cases = [Case(("no ground key", "this checkout"), plain.step, plain.reset, MAX_STEPS_PER_SAMPLE),
             Case(("ground, every body collision: none", "this checkout"), grounded.step, grounded.reset,
                  MAX_STEPS_PER_SAMPLE)]
    other = None
    if baseline:
        from .core_compare import OtherCore

        log(f"  starting the core of {baseline} in a child process (its first run compiles its kernels: minutes)")
        other = OtherCore(baseline)
        cases.append(other.case(("no ground key", f"{baseline} ({other.sha[:10]})"), FREE_BODIES, "rk4", DT,
                                MAX_STEPS_PER_SAMPLE))
    try:
        stats = interleaved(cases, MIN_REPEATS, 0.2 if quick else 1.0, log=log)
    finally:
        if other is not None:
            other.close()
    return [{"scene": k[0], "core": k[1], "bodies": FREE_BODIES, "integrator": "rk4",
             **s.rate(FREE_BODIES).as_row("body_steps_per_s")} for k, s in stats.items()]


# ----------------------------------------------------------------------------- output

def _write_csv(path: Path, rows: list[dict]) -> None:
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)


def _cell(rows: list[dict]) -> str:
    """One table cell: the error(s) of one engine/setting for one quantity, over the dts (10, 1, 0.1 ms)."""
    parts = []
    for dt in DTS:
        r = next((r for r in rows if r["dt"] == dt), None)
        parts.append("—" if r is None else _short(r))
    return " / ".join(parts)


def _short(r: dict) -> str:
    v = r["value"]
    if not math.isfinite(v):
        return "none"
    if r["relative"]:
        e = r["error"]
        return "0" if e == 0.0 else f"{100.0 * e:+.2g} %" if abs(e) >= 1e-4 else f"{e:+.1e}"
    if r["exact"] == 0.0:
        return _si(v, r["unit"])
    return _si(r["error"], r["unit"], signed=True)


def _si(x: float, unit: str, signed: bool = False) -> str:
    if x == 0.0:
        return "0"
    if unit in ("m", "s", "J", "m/s"):
        for factor, prefix in ((1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n")):
            if abs(x) >= factor or factor == 1e-9:
                value = x / factor
                if abs(value) < 1e-3:
                    return f"{x:+.1e} {unit}" if signed else f"{x:.1e} {unit}"
                return (f"{value:+.3g}" if signed else f"{value:.3g}") + f" {prefix}{unit}"
    return f"{x:+.3g} {unit}" if signed else f"{x:.3g} {unit}"


def accuracy_tables(figures: list[dict]) -> str:
    """The bounce's table and the other cases' (their peers' settings differ)."""
    bounce = [r for r in figures if r["case"] == "bounce"]
    others = [r for r in figures if r["case"] != "bounce"]
    return "\n".join(accuracy_table(rows) for rows in (bounce, others) if rows)


def accuracy_table(figures: list[dict]) -> str:
    keys = []
    for r in figures:
        k = (r["engine"], r["setting"])
        if k not in keys:
            keys.append(k)
    quantities = []
    for r in figures:
        q = (r["case"], r["quantity"])
        if q not in quantities:
            quantities.append(q)
    head = ("| case | quantity (exact) | " + " | ".join(f"{e} {s}" for e, s in keys) + " |\n|"
            + "---|" * (2 + len(keys)) + "\n")
    body = ""
    for case, q in quantities:
        rows = [r for r in figures if r["case"] == case and r["quantity"] == q]
        ex = rows[0]["exact"]
        exact_text = f"{ex:.6g} {rows[0]['unit']}".rstrip() if ex != 0.0 else "0"
        cells = []
        for k in keys:
            mine = [r for r in rows if (r["engine"], r["setting"]) == k]
            cells.append(_cell(mine) if mine else "")
        body += f"| {case} | {q} ({exact_text}) | " + " | ".join(cells) + " |\n"
    return head + body


def cost_tables(costs: list[dict]) -> str:
    """The bounce's table and the other cases' (their peers' settings differ)."""
    bounce = [r for r in costs if r["case"] == "bounce"]
    others = [r for r in costs if r["case"] != "bounce"]
    return "\n".join(cost_table(rows) for rows in (bounce, others) if rows)


def cost_table(costs: list[dict]) -> str:
    return E.dt_grid_table(costs, DTS, lambda r: f"{r['us_per_step']:.3g}")


#: Column order of the two-body tables: ours, then each peer's settings side by side.
BODY_COLUMNS = [("rigid_body_sim", "rk4"), ("rigid_body_sim", "semi_implicit_euler"), ("MuJoCo", "oscillator"),
                ("MuJoCo", "calibrated"), ("MuJoCo", "default"), ("PyBullet", "default"), ("PyBullet", "tuned"),
                ("PyBullet", "ccd")]


def _by_column(rows: list[dict]) -> list[dict]:
    rank = {k: i for i, k in enumerate(BODY_COLUMNS)}
    return sorted(rows, key=lambda r: rank.get((r["engine"], r["setting"]), len(rank)))  # stable


def bodies_text(bodies: dict) -> str:
    """The two-body section of the block: accuracy, tunnelling, cost."""
    bodies = {k: _by_column(v) for k, v in bodies.items()}
    return f"""**Between bodies** (no gravity; benchmarks/contact_bodies.py): the error against the closed form
of ours' law (`exact/sphere_impact.py`) at dt = 10 ms / 1 ms / 0.1 ms; a velocity or a spin
after the impact: |x − x_exact| / |x_exact| in % (the exact |x| in brackets); the impact time:
absolute; the energy change: relative to the exact change:

{accuracy_table(bodies["figures"])}
**Tunnelling** (a sphere of diameter 1 cm, 10 g, at 100 m/s; "held": it ends on its side,
"passed": through ("slowed": a contact acted but did not stop it), "inside": stuck in it;
dt = 10 ms / 1 ms / 0.1 ms):

{B.tunnel_table(bodies["tunnels"])}
**Cost between bodies** (µs per step from Python of each case's scene from its start, over the
case's run, at dt = 10 ms / 1 ms / 0.1 ms, median of {MIN_REPEATS} interleaved samples):

{cost_table(bodies["costs"])}
"""


def report(figures, costs, settings, cubes, free, prov: str, quick: bool, bodies: dict | None = None
           ) -> tuple[str, str]:
    """(results markdown, docs block)."""
    best_mj = max((r for r in cubes if r["engine"] == "MuJoCo"), key=lambda r: r["body_steps_per_s"], default=None)
    ours = max((r for r in cubes if r["engine"] == "rigid_body_sim"), key=lambda r: r["body_steps_per_s"])
    lines = ["| engine | setting | body-steps/s, median (min–max) |", "|---|---|---|"]
    for r in cubes:
        lines.append(f"| {r['engine']} | {r['setting']} | {r['body_steps_per_s']:.3g} "
                     f"({r['body_steps_per_s_min']:.3g}–{r['body_steps_per_s_max']:.3g}) |")
    cube_table = "\n".join(lines) + "\n"
    goal = ""
    if best_mj is not None:
        ratio = ours["body_steps_per_s"] / best_mj["body_steps_per_s"]
        goal = (f"Ours at best ({ours['setting']}) / MuJoCo at best ({best_mj['setting']}): **{ratio:.2f}×** "
                f"(goal ≥ 2×: {'met' if ratio >= 2.0 else 'not met'}).\n")
    lines = ["| scene | core | body-steps/s, median (min–max) |", "|---|---|---|"]
    for r in free:
        lines.append(f"| {r['scene']} | {r['core']} | {r['body_steps_per_s']:.3g} "
                     f"({r['body_steps_per_s_min']:.3g}–{r['body_steps_per_s_max']:.3g}) |")
    free_table = "\n".join(lines) + "\n"
    plain = next(r for r in free if r["scene"] == "no ground key" and r["core"] == "this checkout")
    free_note = ""
    for r in free:
        if r is plain:
            continue
        overlap = r["body_steps_per_s_min"] <= plain["body_steps_per_s_max"] and \
            plain["body_steps_per_s_min"] <= r["body_steps_per_s_max"]
        free_note += (f"* {r['scene']}, {r['core']}: {r['body_steps_per_s'] / plain['body_steps_per_s']:.3f}× "
                      f"the plain scene ({'ranges overlap: within noise' if overlap else 'ranges apart'}).\n")
    settings_text = "\n".join(f"* {k}: {v}" for k, v in sorted(settings.items()))
    block = f"""*Generated by `make bench-contact` ({prov}). A shared machine: compare within one run.*

{machine.text()}
**Accuracy** (error against the closed form at dt = 10 ms / 1 ms / 0.1 ms; relative where marked %,
else absolute; "none": the event did not happen; penetration, creep and energy rise: the value,
whose exact answer is 0):

{accuracy_tables(figures)}
**Cost** (µs per step from Python at dt = 10 ms / 1 ms / 0.1 ms, median of {MIN_REPEATS} samples; ours:
`sim.step(k)`, MuJoCo: `mj_step(m, d, nstep=k)`, PyBullet: `stepSimulation()` in a loop):

{cost_tables(costs)}
{bodies_text(bodies) if bodies else ""}**{CUBES} cubes resting on a plane** (0.2 m, 1 kg, μ = 0.5, dt = 1 ms, settled 0.5 s first):

{cube_table}
{goal}
**No collision geometry** (the free-body throughput scene, N = {FREE_BODIES}, rk4, dt = 1 ms):

{free_table}
{free_note}
**Peer settings** (printed by the benchmark; ours: defaults, the integrator named):

{settings_text}
"""
    results = f"# Contact benchmarks: ours, MuJoCo, PyBullet\n\n{block}"
    return results, block


def update_block(path: Path, block: str) -> None:
    text = path.read_text() if path.exists() else ""
    if BLOCK_BEGIN in text and BLOCK_END in text:
        head, rest = text.split(BLOCK_BEGIN, 1)
        _, tail = rest.split(BLOCK_END, 1)
        text = f"{head}{BLOCK_BEGIN}\n{block}{BLOCK_END}{tail}"
    else:
        text = f"{text}\n{BLOCK_BEGIN}\n{block}{BLOCK_END}\n"
    path.write_text(text)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="shorter timing samples (the same cases and repeats)")
    ap.add_argument("--out", default="benchmarks/results", help="directory for contact_peers.csv and .md")
    ap.add_argument("--docs", default=None, help="page whose generated block to rewrite (docs/contact_benchmarks.md)")
    ap.add_argument("--baseline", default=PRE_CONTACT,
                    help=f"git revision whose core is timed on the free-body scene too ('' to skip; default {PRE_CONTACT})")
    ap.add_argument("--parts", default="cases,bodies,cubes,free",
                    help="comma-separated subset of cases,bodies,cubes,free")
    args = ap.parse_args(argv)
    if E.mujoco is None or E.pybullet is None:
        print("the bench extra is missing (MuJoCo and PyBullet): make bench-deps, or "
              ".venv/bin/pip install -r requirements-bench.txt", file=sys.stderr)
        return 2
    parts = set(args.parts.split(","))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    def log(msg: str) -> None:
        print(msg, flush=True)

    log(machine.text() + f"    {E.versions()}")
    figures, costs, settings, cubes, free = [], [], {}, [], []
    if "cases" in parts:
        log("contact cases, every engine, dt = 10, 1, 0.1 ms")
        figures, costs, settings = measure_cases(args.quick, log)
    bodies = {"figures": [], "tunnels": [], "costs": []}
    if "bodies" in parts:
        log("between bodies, every engine, dt = 10, 1, 0.1 ms")
        b_figures, b_tunnels, b_costs, b_settings = B.measure(args.quick, log)
        bodies = {"figures": b_figures, "tunnels": b_tunnels, "costs": b_costs}
        settings.update(b_settings)
    if "cubes" in parts:
        log(f"{CUBES} cubes resting on a plane")
        cubes = measure_cubes(args.quick, log)
    if "free" in parts:
        log(f"no collision geometry, N = {FREE_BODIES}")
        free = measure_free(args.quick, args.baseline or None, log)
    dirty = " + uncommitted changes" if machine.git("status", "--porcelain", "--", "rigid_body_sim",
                                            ":(glob)benchmarks/*.py") else ""
    prov = (f"{'quick' if args.quick else 'full'} mode, commit {machine.git('rev-parse', '--short', 'HEAD')}{dirty}, "
            f"{datetime.date.today().isoformat()}, {machine.one_line()}, PyBullet {E.versions()['pybullet']}")
    _write_csv(out / "contact_peers.csv", figures + costs + bodies["figures"] + bodies["tunnels"] + bodies["costs"]
               + cubes + free)
    if parts == {"cases", "bodies", "cubes", "free"}:
        results, block = report(figures, costs, settings, cubes, free, prov, args.quick, bodies)
        (out / "contact_peers.md").write_text(results)
        if args.docs:
            update_block(Path(args.docs), block)
        log(f"wrote {out / 'contact_peers.csv'}, {out / 'contact_peers.md'}" + (f", {args.docs}" if args.docs else ""))
    else:
        log(f"wrote {out / 'contact_peers.csv'} (a subset: no .md, no docs block)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
