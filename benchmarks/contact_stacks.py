"""Bodies resting on bodies side by side: ours, MuJoCo and PyBullet on a tower and a pile, in one run.

``python -m benchmarks.contact_stacks [--quick] [--out benchmarks/results] [--bodies 1000]``
(``make bench-stacks``). Writes ``contact_stacks.csv`` (every figure) and ``contact_stacks.md``
(the tables, the settings, the machine) to ``--out``. g = 9.81 m/s², dt = 1 ms in every engine,
μ = 0.5 and e = 0 on every body and the ground.

* **tower**: 10 cubes (0.2 m, 1 kg) stacked exactly on the ground, at rest, for ``TOWER_SECONDS``
  (60 s; 5 s with ``--quick``). The exact motion is none: the top cube's sink, the largest
  horizontal drift of any cube and the largest speed (linear, m/s; angular × 0.1 m) at the end
  are each engine's error. Cost: µs per step.
* **pile**: ``--bodies`` cubes (0.1 m, 1 kg) on a lattice 0.15 m apart, each turned by up to
  0.3 rad about a random axis (seed 2026), dropped together into a bin (four static walls
  0.1 m thick and 1 m high around a square of side 0.15 m × the lattice's side + 0.2 m) on
  the ground, for ``PILE_SECONDS``. Readings, every 10 ms: nothing non-finite; the deepest
  penetration of a cube into another, a wall or the ground (the project's narrow phase,
  core/contact/query.py, on each engine's poses: the same geometry for everyone); the largest
  rise of the energy K + U over its lowest earlier value (0 when the energy never rises, as
  for rigid contact with e = 0; a soft contact stores energy in its spring and returns it).
  Cost: body-steps/s timed from the state at ``LANDING`` s (the cubes landing) and at the end
  (settled), sleeping off and on; the sleeping settings also from ``PILE_LATER`` s (8 s: gone quiet).

Peers, set up as their documentation recommends (settings printed with the tables):

* **MuJoCo**: a ``plane`` and a free body per cube (``mass`` on the geom), friction on every geom,
  default solref/solimp, integrator ``Euler``; cones ``pyramidal`` (default) and ``elliptic``;
  ``sleep``: the option flag ``<flag sleep="enable"/>`` (island sleeping, its default
  ``sleep_tolerance``). ``mj_step(m, d, nstep=k)``.
* **PyBullet**: ``GEOM_PLANE`` and a ``createMultiBody`` per cube, damping 0, the plane's and
  walls' friction 1 (Bullet multiplies the pair's: the cube's μ is the pair's); ``default``
  engine parameters; ``sleeping``: ``changeDynamics(activationState=ACTIVATION_STATE_ENABLE_SLEEPING)``
  on every cube (Bullet's deactivation). ``stepSimulation`` in a loop (it has no batched call).

Ours: rk4 (the default) and semi_implicit_euler, through :class:`Simulator`, one thread; sleeping at the
default sleep speed (rest to round-off), and rk4 also at MuJoCo's default sleep_tolerance (``PEER_SLEEP_SPEED``,
1e-3 m/s: the contact solver's ``sleep_speed``). On the pile, rk4 also with the contact solver's
``penetration_tolerance`` at ``PILE_TOLERANCE`` (1e-5 m: points that shallow are left, not projected out), sleeping
off and on.
"""

from __future__ import annotations

import argparse
import copy
import csv
import datetime
import gc
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.core.contact.query import overlapping_bodies
from rigid_body_sim.core.model import State

from . import contact_engines as E
from . import machine
from .timing import MIN_REPEATS, Case, interleaved

G = 9.81
DT = 1e-3
MU = 0.5
OURS = ("rk4", "semi_implicit_euler")
TOWER_CUBES, TOWER_EDGE = 10, 0.2
TOWER_SECONDS, TOWER_SECONDS_QUICK = 60.0, 5.0
PILE_EDGE, PILE_SPACING, PILE_TILT, PILE_SEED = 0.1, 0.15, 0.3, 2026
PILE_SECONDS, LANDING = 3.0, 0.6
PILE_LATER = 8.0  # s: the sleeping settings are also timed from here (the pile gone quiet)
WALL_THICKNESS, WALL_HEIGHT = 0.1, 1.0
SAMPLE_EVERY = 10  # steps between readings
PEER_SLEEP_SPEED = 1e-3  # m/s: MuJoCo's default sleep_tolerance, printed with its settings
PILE_TOLERANCE = 1e-5  # m: ours on the pile also with this penetration tolerance
mujoco, pybullet = E.mujoco, E.pybullet


@dataclass
class Cube:
    """One cube: edge length, mass, centre (world, m), orientation (x, y, z, w); static or moving."""

    edge: float
    mass: float
    position: tuple
    orientation: tuple = (0.0, 0.0, 0.0, 1.0)
    static: bool = False
    size: tuple | None = None  # edge lengths of a static box (a wall); None: a cube of ``edge``

    @property
    def sizes(self) -> tuple:
        return self.size if self.size is not None else (self.edge,) * 3

    @property
    def inertia(self) -> float:
        return self.mass * self.edge**2 / 6.0  # a solid cube's, about any axis through its centre


# ----------------------------------------------------------------------------- the scenes

def tower() -> list[Cube]:
    return [Cube(TOWER_EDGE, 1.0, (0.0, 0.0, TOWER_EDGE * (k + 0.5))) for k in range(TOWER_CUBES)]


def pile(count: int) -> list[Cube]:
    """``count`` cubes on a lattice (side ⌈count^(1/3)⌉), randomly turned, inside four static walls."""
    side = math.ceil(round(count ** (1.0 / 3.0), 9))
    rng = np.random.default_rng(PILE_SEED)
    cubes = []
    offset = 0.5 * PILE_SPACING * (side - 1)
    for k in range(count):
        i, j, layer = k % side, (k // side) % side, k // (side * side)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = rng.uniform(0.0, PILE_TILT)
        q = (*(math.sin(0.5 * angle) * axis), math.cos(0.5 * angle))
        z = PILE_SPACING * (layer + 0.5) + 0.05
        cubes.append(Cube(PILE_EDGE, 1.0, (PILE_SPACING * i - offset, PILE_SPACING * j - offset, z), q))
    inner = PILE_SPACING * side + 0.2
    reach = 0.5 * (inner + WALL_THICKNESS)
    long = inner + 2 * WALL_THICKNESS
    for pos, size in (((reach, 0.0), (WALL_THICKNESS, long)), ((-reach, 0.0), (WALL_THICKNESS, long)),
                      ((0.0, reach), (long, WALL_THICKNESS)), ((0.0, -reach), (long, WALL_THICKNESS))):
        cubes.append(Cube(0.0, 1.0, (*pos, 0.5 * WALL_HEIGHT), static=True, size=(*size, WALL_HEIGHT)))
    return cubes


# ----------------------------------------------------------------------------- the engines

class Ours:
    name = "rigid_body_sim"
    restores_sleep = True  # a copy of the whole simulator

    def __init__(self, cubes: list[Cube], integrator: str, sleeping: bool, sleep_speed: float | None = None,
                 penetration_tolerance: float = 0.0):
        """``sleep_speed``, ``penetration_tolerance``: the contact solver's (m/s; None: its default, rest to
        round-off; m: 0, exact)."""
        self.cubes, self.setting = cubes, integrator + (", sleeping" if sleeping else "")
        if sleep_speed is not None:
            self.setting += f" below {sleep_speed:g} m/s"
        if penetration_tolerance:
            self.setting += f", depth ≤ {penetration_tolerance:g} m"
        bodies = {}
        for k, c in enumerate(cubes):
            box = {"box": list(c.sizes)}
            body = {"mass": c.mass, "inertia": box, "collision": box, "material": {"restitution": 0.0, "friction": MU},
                    "pose": {"position": list(c.position), "orientation": list(c.orientation)}}
            if c.static:
                body["motion"] = "static"
            bodies[f"c{k}"] = body
        self.scene = load_scene({"gravity": [0.0, 0.0, -G], "bodies": bodies,
                                 "ground": [{"normal": [0, 0, 1], "offset": 0.0,
                                             "material": {"restitution": 0.0, "friction": MU}}]})
        self.sim = Simulator(self.scene, integrator=integrator, dt=DT, threads=1)
        if sleeping:
            self.sim.contact.sleeping = True
        if sleep_speed is not None:
            self.sim.contact.sleep_speed = sleep_speed
        self.sim.contact.penetration_tolerance = penetration_tolerance
        self.moving = np.array([not c.static for c in cubes])

    def step(self, k: int) -> None:
        self.sim.step(k)

    def sample(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Moving cubes' (positions (n, 3), quaternions (n, 4) (w, x, y, z), velocities, world angular velocities)."""
        s, m = self.sim, self.moving
        q = s.orientations_xyzw()[m]
        return (s.positions_world()[m], q[:, [3, 0, 1, 2]], s.linear_velocities_world()[m],
                s.angular_velocities_world()[m])

    def snapshot(self) -> Simulator:
        """The whole simulator now, for :meth:`restore`: its contact solver's state too (islands, which are
        asleep, the warm start), as MuJoCo's mj_copyData and PyBullet's saveState."""
        return copy.deepcopy(self.sim)

    def restore(self, saved: Simulator) -> None:
        self.sim = None
        gc.collect()  # the replaced copy's buffers (~0.6 GB for a pile of 1000) are held in reference cycles
        self.sim = copy.deepcopy(saved)

    def set_rows(self, rows: np.ndarray) -> None:
        """Every body's state set from ``rows`` (the contact modes derived from it afresh, as after a set_state)."""
        self.sim.state = State.of_rows(rows.copy())
        self.sim.contact.reset(self.sim)

    def asleep(self) -> int:
        """How many bodies are asleep."""
        return int(np.count_nonzero(self.sim.contact.pairs.islands.asleep))

    def close(self) -> None:
        pass


class MuJoCo:
    name = "MuJoCo"
    restores_sleep = True  # mj_copyData copies the sleep state

    def __init__(self, cubes: list[Cube], cone: str, sleep: bool, memory_per_cube: float = 0.1):
        """``memory_per_cube``: MB of MuJoCo's arena per cube (above 16 MB); a pile of 10,000 needs more than 0.1."""
        self.cubes, self.setting = cubes, cone + (", sleep" if sleep else "")
        friction = f'friction="{MU} 0.005 0.0001"'
        static, moving = "", ""
        for c in cubes:
            size = " ".join(f"{0.5 * s:.17g}" for s in c.sizes)
            pos = " ".join(f"{x:.17g}" for x in c.position)
            x, y, z, w = c.orientation
            if c.static:
                static += f'<geom type="box" size="{size}" pos="{pos}" {friction}/>'
            else:
                moving += (f'<body pos="{pos}" quat="{w:.17g} {x:.17g} {y:.17g} {z:.17g}"><freejoint/>'
                           f'<geom type="box" size="{size}" mass="{c.mass:.17g}" {friction}/></body>')
        flag = '<flag sleep="enable"/>' if sleep else ""
        memory = 16 + int(len(cubes) * memory_per_cube)
        xml = (f'<mujoco><option timestep="{DT:.17g}" gravity="0 0 {-G}" integrator="Euler" cone="{cone}">{flag}'
               f'</option><size memory="{memory}M"/><worldbody><geom type="plane" size="0 0 1" {friction}/>'
               f'{static}{moving}</worldbody></mujoco>')
        self.m = mujoco.MjModel.from_xml_string(xml)
        self.d = mujoco.MjData(self.m)
        mujoco.mj_forward(self.m, self.d)

    def settings_text(self) -> str:
        o = self.m.opt
        sleep = (f", sleep enabled (sleep_tolerance {o.sleep_tolerance:g})"
                 if o.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP else ", sleep off (default)")
        return (f"integrator Euler, cone {self.setting.split(',')[0]}, solver Newton, iterations {o.iterations}, "
                f"tolerance {o.tolerance:g}, solref (0.02, 1) and solimp default" + sleep)

    def step(self, k: int) -> None:
        mujoco.mj_step(self.m, self.d, nstep=k)

    def sample(self):
        d = self.d
        qpos, qvel = d.qpos.reshape(-1, 7), d.qvel.reshape(-1, 6)
        R = d.xmat[1:].reshape(-1, 3, 3)  # world body 0; the free bodies in order
        w_world = np.einsum("nij,nj->ni", R, qvel[:, 3:6])  # a free joint's angular velocity is in body axes
        return qpos[:, 0:3].copy(), qpos[:, 3:7].copy(), qvel[:, 0:3].copy(), w_world

    def snapshot(self):
        """The data now (mj_copyData: every field, the sleep state and the warm start included)."""
        return copy.copy(self.d)

    def restore(self, saved) -> None:
        mujoco.mj_copyData(self.d, self.m, saved)

    def close(self) -> None:
        pass


class PyBullet:
    name = "PyBullet"
    #: saveState/restoreState do not carry which bodies sleep (restored to a landing state after its cubes fell
    #: asleep, the world stepped at 4.6e6 body-steps/s, its cubes still asleep): :meth:`restore` wakes every cube,
    #: which is the saved state only while none slept, so a sleeping world is not timed after its cubes sleep.
    restores_sleep = False

    def __init__(self, cubes: list[Cube], sleeping: bool):
        self.cubes, self.setting, self.sleeping = cubes, "default" + (", sleeping" if sleeping else ""), sleeping
        p = pybullet
        self.c = c = p.connect(p.DIRECT)
        p.resetSimulation(physicsClientId=c)
        p.setGravity(0.0, 0.0, -G, physicsClientId=c)
        p.setTimeStep(DT, physicsClientId=c)
        plane = p.createMultiBody(0.0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=c), physicsClientId=c)
        p.changeDynamics(plane, -1, lateralFriction=1.0, restitution=1.0, physicsClientId=c)
        self.ids = []
        for cube in cubes:
            shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.5 * s for s in cube.sizes], physicsClientId=c)
            b = p.createMultiBody(0.0 if cube.static else cube.mass, shape, basePosition=list(cube.position),
                                  baseOrientation=list(cube.orientation), physicsClientId=c)
            if cube.static:
                p.changeDynamics(b, -1, lateralFriction=1.0, restitution=1.0, physicsClientId=c)
                continue
            state = p.ACTIVATION_STATE_ENABLE_SLEEPING if sleeping else p.ACTIVATION_STATE_DISABLE_SLEEPING
            p.changeDynamics(b, -1, lateralFriction=MU, restitution=0.0, linearDamping=0.0, angularDamping=0.0,
                             rollingFriction=0.0, spinningFriction=0.0, activationState=state, physicsClientId=c)
            self.ids.append(b)

    def settings_text(self) -> str:
        q = pybullet.getPhysicsEngineParameters(physicsClientId=self.c)
        keys = ("numSolverIterations", "useSplitImpulse", "enableConeFriction", "contactSlop", "erp", "contactERP",
                "frictionERP")
        sleep = (", ACTIVATION_STATE_ENABLE_SLEEPING on every cube" if self.sleeping
                 else ", ACTIVATION_STATE_DISABLE_SLEEPING on every cube")
        return (", ".join(f"{k} {q[k]:g}" for k in keys if k in q) + ", engine parameters at their defaults"
                + sleep + ", damping 0, plane and walls friction 1 (Bullet multiplies the pair's coefficients)")

    def step(self, k: int) -> None:
        step, c = pybullet.stepSimulation, self.c
        for _ in range(k):
            step(physicsClientId=c)

    def sample(self):
        p, c = pybullet, self.c
        pos, quat, vel, ang = [], [], [], []
        for b in self.ids:
            x, q = p.getBasePositionAndOrientation(b, physicsClientId=c)
            v, w = p.getBaseVelocity(b, physicsClientId=c)
            pos.append(x)
            quat.append((q[3], q[0], q[1], q[2]))
            vel.append(v)
            ang.append(w)
        return np.array(pos), np.array(quat), np.array(vel), np.array(ang)

    def snapshot(self) -> int:
        """A saved state's id (saveState), for :meth:`restore`."""
        return pybullet.saveState(physicsClientId=self.c)

    def restore(self, saved: int) -> None:
        """The saved state, every cube awake (the state does not carry sleep)."""
        p, c = pybullet, self.c
        p.restoreState(saved, physicsClientId=c)
        if self.sleeping:
            for b in self.ids:
                p.changeDynamics(b, -1, activationState=p.ACTIVATION_STATE_WAKE_UP, physicsClientId=c)

    def close(self) -> None:
        pybullet.disconnect(physicsClientId=self.c)


def engines(cubes: list[Cube], sleeping_too: bool) -> list:
    """Every engine and setting on ``cubes`` (each with sleeping off, and on when ``sleeping_too``)."""
    sleeps = (False, True) if sleeping_too else (False,)
    out = [Ours(cubes, name, s) for name in OURS for s in sleeps]
    if sleeping_too:  # and at MuJoCo's sleep threshold (its default sleep_tolerance); with a penetration tolerance
        out.append(Ours(cubes, OURS[0], True, PEER_SLEEP_SPEED))
        out += [Ours(cubes, OURS[0], s, penetration_tolerance=PILE_TOLERANCE) for s in sleeps]
    if mujoco is not None:
        out += [MuJoCo(cubes, cone, s) for cone in ("pyramidal", "elliptic") for s in sleeps]
    if pybullet is not None:
        out += [PyBullet(cubes, s) for s in sleeps]
    return out


# ----------------------------------------------------------------------------- readings

def energy(cubes: list[Cube], sample) -> float:
    """K + U (J) of the moving cubes (a cube's inertia is the same about every axis)."""
    moving = [c for c in cubes if not c.static]
    m = np.array([c.mass for c in moving])
    inertia = np.array([c.inertia for c in moving])
    p, _, v, w = sample
    return float(np.sum(0.5 * m * np.sum(v * v, axis=1) + 0.5 * inertia * np.sum(w * w, axis=1) + m * G * p[:, 2]))


class Depth:
    """The deepest penetration (m) of a moving cube into another cube, a static wall or the ground z = 0."""

    def __init__(self, cubes: list[Cube]):
        scene = Ours(cubes, "rk4", False).scene  # the same shape rows for every engine's poses
        self.shapes = scene.contact.shapes
        self.moving = np.array([not c.static for c in cubes])
        self.static_pos = np.array([c.position for c in cubes if c.static]).reshape(-1, 3)
        self.static_quat = np.array([(c.orientation[3], *c.orientation[:3]) for c in cubes if c.static]).reshape(-1, 4)
        self.half = np.array([0.5 * c.edge for c in cubes if not c.static])

    def __call__(self, sample) -> float:
        p, q, _, _ = sample
        pos = np.empty((len(self.moving), 3))
        quat = np.empty((len(self.moving), 4))
        pos[self.moving], quat[self.moving] = p, q
        pos[~self.moving], quat[~self.moving] = self.static_pos, self.static_quat
        pairs = overlapping_bodies(pos, quat, self.shapes, self.moving)
        deepest = pairs[0][2] if pairs else 0.0
        w, x, y, z = q.T  # the lowest corner: z − Σ |R₂ⱼ| h, R₂ the rotation's third row
        r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        lowest = p[:, 2] - self.half * (np.abs(r20) + np.abs(r21) + np.abs(r22))
        return max(deepest, float(-lowest.min()), 0.0)


def tower_case(engine, seconds: float) -> dict:
    start = engine.sample()
    engine.step(int(round(seconds / DT)))
    p, _, v, w = engine.sample()
    p0 = start[0]
    speed = max(float(np.max(np.linalg.norm(v, axis=1))), float(np.max(np.linalg.norm(w, axis=1))) * 0.5 * TOWER_EDGE)
    return {"case": "tower", "engine": engine.name, "setting": engine.setting, "seconds": seconds,
            "bodies": TOWER_CUBES, "finite": bool(np.all(np.isfinite(p))), "sink": float(p0[-1, 2] - p[-1, 2]),
            "drift": float(np.max(np.linalg.norm((p - p0)[:, :2], axis=1))), "speed": speed}


class PileReadings:
    """The pile's readings so far: finite, the deepest penetration, the largest energy rise over an earlier low."""

    def __init__(self, cubes: list[Cube], depth: Depth):
        self.cubes, self.depth = cubes, depth
        self.finite, self.deepest, self.rise, self.lowest = True, 0.0, 0.0, math.inf

    def run(self, engine, seconds: float) -> None:
        for _ in range(int(round(seconds / DT)) // SAMPLE_EVERY):
            if not self.finite:
                return
            engine.step(SAMPLE_EVERY)
            s = engine.sample()
            if not all(np.all(np.isfinite(a)) for a in s):
                self.finite = False
                return
            self.deepest = max(self.deepest, self.depth(s))
            e = energy(self.cubes, s)
            self.rise = max(self.rise, e - self.lowest)
            self.lowest = min(self.lowest, e)

    def row(self, engine) -> dict:
        return {"case": "pile", "engine": engine.name, "setting": engine.setting, "seconds": PILE_SECONDS,
                "bodies": int(sum(not c.static for c in self.cubes)), "finite": self.finite,
                "penetration": self.deepest, "energy_rise": self.rise}


# ----------------------------------------------------------------------------- the run

def measure(count: int, quick: bool, log) -> tuple[list[dict], list[dict], dict[str, str]]:
    """(figure rows, cost rows, settings text): the tower and the pile in every engine, then their costs."""
    figures, timing, settings, owners = [], [], {}, []
    seconds = TOWER_SECONDS_QUICK if quick else TOWER_SECONDS
    for engine in engines(tower(), sleeping_too=False):
        if engine.name != Ours.name:
            settings[f"{engine.name}, {engine.setting}"] = engine.settings_text()
        start = engine.snapshot()
        row = tower_case(engine, seconds)
        figures.append(row)
        log(f"  tower {engine.name} {engine.setting}: sink {row['sink']:.3g} m, drift {row['drift']:.3g} m, "
            f"speed {row['speed']:.3g} m/s")
        timing.append(Case(("tower", engine.name, engine.setting, TOWER_CUBES), run=engine.step,
                           setup=lambda e=engine, s=start: e.restore(s), max_units=10**5))
        owners.append(engine)
    cubes = pile(count)
    depth = Depth(cubes)
    for engine in engines(cubes, sleeping_too=True):
        if engine.name != Ours.name:
            settings[f"{engine.name}, {engine.setting}"] = engine.settings_text()
        readings = PileReadings(cubes, depth)
        readings.run(engine, LANDING)
        landing = engine.snapshot()
        readings.run(engine, PILE_SECONDS - LANDING)
        settled = engine.snapshot()
        figures.append(readings.row(engine))
        log(f"  pile of {count} {engine.name} {engine.setting}: finite {readings.finite}, penetration "
            f"{readings.deepest:.3g} m, energy rise {readings.rise:.3g} J")
        phases = [("pile, landing", landing), ("pile, settled", settled)]
        if "sleep" in engine.setting and engine.restores_sleep:  # on to PILE_LATER (no readings: the figures
            asleep = engine.asleep() if isinstance(engine, Ours) else None  # are the first PILE_SECONDS')
            engine.step(round((PILE_LATER - PILE_SECONDS) / DT))
            phases.append(("pile, later", engine.snapshot()))
            if asleep is not None:
                log(f"    cubes asleep: {asleep} at {PILE_SECONDS:g} s, {engine.asleep()} at {PILE_LATER:g} s")
        for phase, saved in phases:
            timing.append(Case((phase, engine.name, engine.setting, count), run=engine.step,
                               setup=lambda e=engine, s=saved: e.restore(s), max_units=200))
        owners.append(engine)
    log("  timing (µs per step, interleaved)")
    stats = interleaved(timing, MIN_REPEATS, 0.1 if quick else 0.5, log=log)
    costs = [{"case": k[0], "engine": k[1], "setting": k[2], "bodies": k[3], **s.scaled(1e6).as_row("us_per_step"),
              **s.rate(k[3]).as_row("body_steps_per_s")} for k, s in stats.items()]
    for engine in owners:
        engine.close()
    return figures, costs, settings


# ----------------------------------------------------------------------------- output

def _write_csv(path: Path, rows: list[dict]) -> None:
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, keys)
        w.writeheader()
        w.writerows(rows)


def report(figures: list[dict], costs: list[dict], settings: dict[str, str], count: int, quick: bool) -> str:
    seconds = TOWER_SECONDS_QUICK if quick else TOWER_SECONDS
    lines = [f"From `python -m benchmarks.contact_stacks{' --quick' if quick else ''} --bodies {count}` "
             f"({datetime.date.today().isoformat()}, commit {machine.git('rev-parse', '--short', 'HEAD')}), "
             f"dt = {DT:g} s, μ = {MU}, e = 0, one thread.", "", machine.text(), "",
             f"**Tower**: {TOWER_CUBES} cubes ({TOWER_EDGE} m, 1 kg) stacked on the ground, at rest for {seconds:g} s "
             "(exact: nothing moves):", "",
             "| engine | setting | top's sink (m) | largest drift (m) | largest speed at the end (m/s) | µs per step |",
             "|---|---|---|---|---|---|"]
    cost = {(c["case"], c["engine"], c["setting"]): c for c in costs}
    for r in (r for r in figures if r["case"] == "tower"):
        c = cost[("tower", r["engine"], r["setting"])]
        lines.append(f"| {r['engine']} | {r['setting']} | {r['sink']:.3g} | {r['drift']:.3g} | {r['speed']:.3g} | "
                     f"{c['us_per_step']:.3g} ({c['us_per_step_min']:.3g}–{c['us_per_step_max']:.3g}) |")
    lines += ["", f"**Pile**: {count} cubes ({PILE_EDGE} m, 1 kg) dropped together into a bin, {PILE_SECONDS:g} s "
              f"(readings every {SAMPLE_EVERY * DT * 1e3:g} ms; cost timed from the state at {LANDING:g} s, landing, "
              f"at {PILE_SECONDS:g} s, settled, and with sleeping at {PILE_LATER:g} s):", "",
              "| engine | setting | finite | deepest penetration (m) | largest energy rise (J) | body-steps/s landing | "
              f"body-steps/s settled | body-steps/s at {PILE_LATER:g} s |", "|---|---|---|---|---|---|---|---|"]
    rate = lambda c: (f"{c['body_steps_per_s']:.3g} ({c['body_steps_per_s_min']:.3g}–{c['body_steps_per_s_max']:.3g})"
                      if c is not None else "—")
    for r in (r for r in figures if r["case"] == "pile"):
        a, b, c = (cost.get((phase, r["engine"], r["setting"])) for phase in ("pile, landing", "pile, settled",
                                                                              "pile, later"))
        lines.append(f"| {r['engine']} | {r['setting']} | {'yes' if r['finite'] else 'no'} | {r['penetration']:.3g} | "
                     f"{r['energy_rise']:.3g} | {rate(a)} | {rate(b)} | {rate(c)} |")
    lines += ["", "Settings:", ""] + [f"* **{k}**: {v}" for k, v in settings.items()]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--quick", action="store_true", help=f"the tower for {TOWER_SECONDS_QUICK:g} s, shorter samples")
    ap.add_argument("--bodies", type=int, default=1000, help="cubes in the pile (default 1000)")
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args(argv)

    def log(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    figures, costs, settings = measure(args.bodies, args.quick, log)
    args.out.mkdir(parents=True, exist_ok=True)
    _write_csv(args.out / "contact_stacks.csv", figures + costs)
    text = report(figures, costs, settings, args.bodies, args.quick)
    (args.out / "contact_stacks.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
