"""Body–body contact side by side: ours, MuJoCo and PyBullet on two-body scenes with closed forms.

Part ``bodies`` of ``python -m benchmarks.contact_peers`` (``make bench-contact``): the figures
join that run's csv, tables and docs block. No gravity, no ground: every scene is two moving
bodies, or one and a static box. Cases, each at dt = 10 ms, 1 ms and 0.1 ms:

* **head-on, equal** / **head-on, unequal**: two solid spheres flying at each other along x,
  e = 0.5, frictionless (equal: r 0.1 m, 1 kg each, ±1 m/s; unequal: r 0.1 m 1 kg at +1 m/s and
  r 0.15 m 2.5 kg at −1 m/s): the velocities after (relative error of each body's velocity
  vector), the impact time (the root of |c_b(t) − c_a(t)| = r_a + r_b on the straight lines)
  and the kinetic energy change, exact −(1 − e²) m_n u_n²/2;
* **oblique, spin, sticking** / **sliding**: the unequal spheres offset sideways (b's centre
  (0.6, 0.12, 0.05) m from a's), a at (2, 0.2, 0) m/s spinning 3 or 20 rad/s about y, b at
  (−1, 0, 0.3) m/s spinning 5 rad/s about z, μ = 0.3, e = 0.5: the velocities and spins after
  against rigid_body_sim/exact/sphere_impact.py (ours' law: Coulomb's cone over the
  compression, Poisson's restitution without friction; with 3 rad/s the closed form sticks,
  with 20 rad/s it slides throughout; the regime is checked and named in the case);
* **tunnelling** (outcome only): a sphere of diameter 1 cm, 10 g, at 100 m/s toward a static box
  1 cm thick (1 m × 1 m face), and two such spheres at each other: held, or passed through
  (with the speed left if a contact acted on the way: seen, but too soft to stop it).

Readings. Ours: the located impact events. A peer's impact time: the end of the first step whose
velocity changed (no gravity: any change is a contact force), the finest a time-stepper resolves;
its error is in (0, dt] when the contact acts in the step where the surfaces meet, ≤ 0 when it
acts before they touch (a speculative contact), above dt when late. (The ground cases' reading,
the free flight from the last sample apart, would give the closed form here by construction:
the flights are straight lines.) The velocities after: the samples at the end of the run (the
impact time plus 0.2 s, the soft contacts long over).

Peers, set up as their documentation recommends (settings printed with the tables):

* **MuJoCo** has no restitution coefficient: ``oscillator`` gives e as solref (0.02 s, ζ) on
  every geom with ζ from the damped oscillator (contact_engines.zeta_of_restitution);
  ``calibrated`` bisects ζ in [0.01, 1] at each dt until the equal head-on pair separates at e
  times its approach speed (the ratio reached is printed; where no ζ reaches it within 1e-3,
  at dt = 10 ms, the setting is not run and the settings say so). Friction on every geom (MuJoCo takes the larger of the pair), pyramidal cone,
  Euler integrator. MuJoCo has no continuous collision detection (its tunnelling rows use the
  default solref).
* **PyBullet** multiplies the two bodies' restitutions and frictions: each sphere gets √e and
  √μ (the static box 1 and 1). Damping, rolling and spinning friction 0. ``default``: every
  engine parameter at its default; ``tuned``: the restitution settings of bullet3 issue 3094
  (as the bounce). Tunnelling also runs ``ccd``: ``changeDynamics(ccdSweptSphereRadius=…)``
  on each sphere, the continuous collision detection of the PyBullet Quickstart Guide, with
  its example's values (experimentalCcdSphereRadius.py: radius 0.002 m for a 0.005 m sphere,
  ``allowedCcdPenetration = 0``, ``useMaximalCoordinates=True``).

Ours: rk4 and semi_implicit_euler, defaults. The oblique case's law differs between engines:
ours is the rigid two-phase impact; MuJoCo's a soft contact (spring–damper on the constraint,
friction cone through the same solver), PyBullet's a sequential-impulse velocity target e u_n
with Coulomb friction in the same solve: the comparison is of the same physical set-up, against
ours' law.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.exact.sphere_impact import two_sphere_impact

from . import contact_engines as E
from .timing import MIN_REPEATS, Case, interleaved

DTS = (1e-2, 1e-3, 1e-4)
OURS = ("rk4", "semi_implicit_euler")
E_PAIR, MU_OBLIQUE = 0.5, 0.3
AFTER = 0.2  # s run after the closed-form impact time
TUNNEL_R, TUNNEL_V, TUNNEL_M = 0.005, 100.0, 0.01
WALL_X, WALL_HALF = 0.5, 0.005
TUNNEL_SECONDS = 0.03
CALIBRATED_TOLERANCE = 1e-3  # |rebound ratio − e| the calibration must reach, else the setting is not run
PB_CCD_RADIUS, PB_CCD_OF_R = 0.002, 0.005  # experimentalCcdSphereRadius.py: 0.002 m for a 0.005 m sphere


@dataclass
class Item:
    """One body: ``kind`` sphere (size: radius) or box (size: edge lengths); static or moving; world axes."""

    name: str
    kind: str
    size: tuple
    mass: float
    position: tuple
    velocity: tuple = (0.0, 0.0, 0.0)
    angular_velocity: tuple = (0.0, 0.0, 0.0)
    friction: float = 0.0
    restitution: float = 0.0
    static: bool = False

    @property
    def inertia(self) -> np.ndarray:
        if self.kind == "sphere":
            return np.full(3, 0.4 * self.mass * self.size[0] ** 2)
        a, b, c = self.size
        return self.mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


# ----------------------------------------------------------------------------- the scenes

def head_on(equal: bool, e: float = E_PAIR) -> list[Item]:
    rb, mb = (0.1, 1.0) if equal else (0.15, 2.5)
    return [Item("a", "sphere", (0.1,), 1.0, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), restitution=e),
            Item("b", "sphere", (rb,), mb, (0.6, 0.0, 0.0), (-1.0, 0.0, 0.0), restitution=e)]


def oblique(sliding: bool) -> list[Item]:
    """The unequal spheres offset sideways, with spins: a's spin 3 rad/s (sticking) or 20 rad/s (sliding) about y."""
    spin = 20.0 if sliding else 3.0
    return [Item("a", "sphere", (0.1,), 1.0, (0.0, 0.0, 0.0), (2.0, 0.2, 0.0), (0.0, spin, 0.0),
                 MU_OBLIQUE, E_PAIR),
            Item("b", "sphere", (0.15,), 2.5, (0.6, 0.12, 0.05), (-1.0, 0.0, 0.3), (0.0, 0.0, 5.0),
                 MU_OBLIQUE, E_PAIR)]


def tunnel_wall() -> list[Item]:
    return [Item("ball", "sphere", (TUNNEL_R,), TUNNEL_M, (0.0, 0.0, 0.0), (TUNNEL_V, 0.0, 0.0),
                 restitution=E_PAIR),
            Item("wall", "box", (2 * WALL_HALF, 1.0, 1.0), 1.0, (WALL_X, 0.0, 0.0), static=True,
                 restitution=E_PAIR)]


def tunnel_pair() -> list[Item]:
    return [Item("a", "sphere", (TUNNEL_R,), TUNNEL_M, (0.0, 0.0, 0.0), (TUNNEL_V, 0.0, 0.0), restitution=E_PAIR),
            Item("b", "sphere", (TUNNEL_R,), TUNNEL_M, (0.5, 0.0, 0.0), (-TUNNEL_V, 0.0, 0.0), restitution=E_PAIR)]


# ----------------------------------------------------------------------------- the engines

class Ours:
    name = "rigid_body_sim"

    def __init__(self, items: list[Item], dt: float, integrator: str):
        self.items, self.setting, self.dt = items, integrator, dt
        bodies = {}
        for it in items:
            shape = {"sphere": it.size[0]} if it.kind == "sphere" else {"box": list(it.size)}
            body = {"mass": it.mass, "inertia": shape, "collision": shape,
                    "material": {"restitution": it.restitution, "friction": it.friction},
                    "pose": {"position": list(it.position)}}
            if it.static:
                body["motion"] = "static"
            else:
                body["twist"] = {"linear": list(it.velocity), "angular": list(it.angular_velocity)}
            bodies[it.name] = body
        scene = load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [], "bodies": bodies})
        self.sim = Simulator(scene, integrator=integrator, dt=dt, threads=1)
        self.moving = [it.name for it in items if not it.static]

    def step(self, k: int) -> None:
        self.sim.step(k)

    def sample(self) -> np.ndarray:
        """(moving bodies, 9): position, velocity, angular velocity (world axes)."""
        out = []
        for name in self.moving:
            s = self.sim.body_state(name)
            out.append(np.concatenate((s.position_world, s.linear_velocity_world, s.angular_velocity_world)))
        return np.array(out)

    def impact_time(self) -> float:
        events = self.sim.contact.events_of(self.moving[0], "impact")
        return events[0].time if events else math.nan

    def snapshot(self) -> None:
        pass

    def restore(self) -> None:
        self.sim.reset()

    def close(self) -> None:
        pass


class MuJoCo(E.MuJoCoData):
    name = "MuJoCo"

    def __init__(self, items: list[Item], dt: float, setting: str, dampratio: float | None = None):
        self.items, self.setting = items, setting
        if setting == "oscillator":
            dampratio = E.zeta_of_restitution(E_PAIR)
        self.dampratio = dampratio if setting in ("oscillator", "calibrated") else None
        solref = f' solref="{E.MUJOCO_TIMECONST} {self.dampratio:.17g}"' if self.dampratio is not None else ""
        static, moving = "", ""
        for it in items:
            geom = (f'type="sphere" size="{it.size[0]:.17g}"' if it.kind == "sphere"
                    else 'type="box" size="{:.17g} {:.17g} {:.17g}"'.format(*(0.5 * s for s in it.size)))
            pos = " ".join(f"{x:.17g}" for x in it.position)
            g = f'<geom {geom} friction="{it.friction:.17g} 0.005 0.0001"{solref}'
            if it.static:
                static += f'{g} pos="{pos}"/>'
            else:
                moving += f'<body pos="{pos}"><freejoint/>{g} mass="{it.mass:.17g}"/></body>'
        xml = (f'<mujoco><option timestep="{dt:.17g}" gravity="0 0 0" integrator="Euler" cone="pyramidal"/>'
               f'<worldbody>{static}{moving}</worldbody></mujoco>')
        self.m = mujoco.MjModel.from_xml_string(xml)
        self.d = mujoco.MjData(self.m)
        qvel = self.d.qvel.reshape(-1, 6)
        for k, it in enumerate(i for i in items if not i.static):
            qvel[k, 0:3] = it.velocity
            qvel[k, 3:6] = it.angular_velocity  # the body axes are the world's at the start
        mujoco.mj_forward(self.m, self.d)

    def settings_text(self) -> str:
        o = self.m.opt
        text = (f"integrator Euler, cone pyramidal, solver Newton, iterations {o.iterations}, "
                f"tolerance {o.tolerance:g}, no gravity")
        if self.dampratio is not None:
            return text + f", solref ({E.MUJOCO_TIMECONST}, {self.dampratio:.4f}) on every geom"
        return text + ", solref (0.02, 1) default, no continuous collision detection (MuJoCo has none)"

    def step(self, k: int) -> None:
        mujoco.mj_step(self.m, self.d, nstep=k)

    def sample(self) -> np.ndarray:
        d = self.d
        qpos, qvel = d.qpos.reshape(-1, 7), d.qvel.reshape(-1, 6)
        out = []
        for k in range(qpos.shape[0]):
            R = d.xmat[k + 1].reshape(3, 3)  # world body 0; the free bodies in order
            out.append(np.concatenate((qpos[k, 0:3], qvel[k, 0:3], R @ qvel[k, 3:6])))
        return np.array(out)


class PyBullet(E.PyBulletClient):
    name = "PyBullet"

    def __init__(self, items: list[Item], dt: float, setting: str):
        self.items, self.setting = items, setting
        p = pybullet
        self.c = c = p.connect(p.DIRECT)
        p.resetSimulation(physicsClientId=c)
        p.setGravity(0.0, 0.0, 0.0, physicsClientId=c)
        p.setTimeStep(dt, physicsClientId=c)
        tuned, ccd = setting == "tuned", setting == "ccd"
        maximal = tuned or ccd  # the CCD example creates its spheres with useMaximalCoordinates=True
        if tuned:
            p.setPhysicsEngineParameter(restitutionVelocityThreshold=0.0, warmStartingFactor=0.0, contactSlop=0.0,
                                        physicsClientId=c)
        if ccd:
            p.setPhysicsEngineParameter(allowedCcdPenetration=0.0, physicsClientId=c)
        self.ids = []
        for it in items:
            if it.kind == "sphere":
                shape = p.createCollisionShape(p.GEOM_SPHERE, radius=it.size[0], physicsClientId=c)
            else:
                shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.5 * s for s in it.size], physicsClientId=c)
            b = p.createMultiBody(0.0 if it.static else it.mass, shape, basePosition=list(it.position),
                                  useMaximalCoordinates=maximal, physicsClientId=c)
            extra = {"contactProcessingThreshold": 0.0} if tuned else {}
            if ccd and not it.static:
                extra["ccdSweptSphereRadius"] = PB_CCD_RADIUS * it.size[0] / PB_CCD_OF_R
            e, mu = (1.0, 1.0) if it.static else (math.sqrt(it.restitution), math.sqrt(it.friction))
            p.changeDynamics(b, -1, lateralFriction=mu, restitution=e, linearDamping=0.0, angularDamping=0.0,
                             rollingFriction=0.0, spinningFriction=0.0, physicsClientId=c, **extra)
            if not it.static:
                p.resetBaseVelocity(b, list(it.velocity), list(it.angular_velocity), physicsClientId=c)
                self.ids.append(b)

    def settings_text(self) -> str:
        q = pybullet.getPhysicsEngineParameters(physicsClientId=self.c)
        keys = ("numSolverIterations", "useSplitImpulse", "restitutionVelocityThreshold", "enableConeFriction",
                "contactSlop", "warmStartingFactor", "erp", "contactERP", "frictionERP", "allowedCcdPenetration")
        extra = {"tuned": ", set: restitutionVelocityThreshold 0, warmStartingFactor 0, contactSlop 0, maximal "
                          "coordinates, contactProcessingThreshold 0",
                 "ccd": f", set: allowedCcdPenetration 0, maximal coordinates, ccdSweptSphereRadius {PB_CCD_RADIUS / PB_CCD_OF_R:g} × "
                        "the sphere's radius on each sphere (the Quickstart Guide's CCD, its example's values)",
                 }.get(self.setting, ", engine parameters at their defaults")
        return (", ".join(f"{k} {q[k]:g}" for k in keys if k in q) + extra
                + ", no gravity, damping 0, each sphere √e and √μ, a static box 1 and 1 (Bullet multiplies the pair's)")

    def step(self, k: int) -> None:
        step, c = pybullet.stepSimulation, self.c
        for _ in range(k):
            step(physicsClientId=c)

    def sample(self) -> np.ndarray:
        p, out = pybullet, []
        for b in self.ids:
            pos, _ = p.getBasePositionAndOrientation(b, physicsClientId=self.c)
            v, w = p.getBaseVelocity(b, physicsClientId=self.c)
            out.append(np.concatenate((pos, v, w)))
        return np.array(out)


mujoco, pybullet = E.mujoco, E.pybullet


def engines(items: list[Item], dt: float, tunnelling: bool, dampratio: float | None) -> list:
    out = [Ours(items, dt, name) for name in OURS]
    if tunnelling:
        out.append(MuJoCo(items, dt, "default"))
        out += [PyBullet(items, dt, s) for s in ("default", "ccd")]
    else:
        out.append(MuJoCo(items, dt, "oscillator"))
        if dampratio is not None:
            out.append(MuJoCo(items, dt, "calibrated", dampratio))
        out += [PyBullet(items, dt, s) for s in ("default", "tuned")]
    return out


# ----------------------------------------------------------------------------- closed forms and readings

def contact_time(a: Item, b: Item) -> float:
    """First t ≥ 0 with |c_b(t) − c_a(t)| = r_a + r_b on the straight lines (a quadratic)."""
    c0, v = np.subtract(b.position, a.position), np.subtract(b.velocity, a.velocity)
    reach = a.size[0] + b.size[0]
    qa, qb, qc = v @ v, 2.0 * c0 @ v, c0 @ c0 - reach**2
    return (-qb - math.sqrt(qb * qb - 4.0 * qa * qc)) / (2.0 * qa)


def exact_after(a: Item, b: Item) -> tuple[float, tuple[np.ndarray, ...]]:
    """(impact time, (v_a, ω_a, v_b, ω_b) after) of the project's law (exact/sphere_impact.py)."""
    t = contact_time(a, b)
    ca, cb = np.add(a.position, np.multiply(a.velocity, t)), np.add(b.position, np.multiply(b.velocity, t))
    n = (cb - ca) / np.linalg.norm(cb - ca)
    mu = math.sqrt(a.friction * b.friction)
    after = two_sphere_impact(a.mass, a.inertia[0], a.size[0], a.velocity, a.angular_velocity,
                              b.mass, b.inertia[0], b.size[0], b.velocity, b.angular_velocity, n,
                              max(a.restitution, b.restitution), mu)
    return t, after


def regime(a: Item, b: Item) -> str:
    """Sticking or sliding, the closed form's (Coulomb's cone over the compression)."""
    t, after = exact_after(a, b)
    ca, cb = np.add(a.position, np.multiply(a.velocity, t)), np.add(b.position, np.multiply(b.velocity, t))
    n = (cb - ca) / np.linalg.norm(cb - ca)
    ra, rb = a.size[0] * n, -b.size[0] * n
    u = (after[2] + np.cross(after[3], rb)) - (after[0] + np.cross(after[1], ra))
    return "sticking" if np.linalg.norm(u - (u @ n) * n) < 1e-9 else "sliding"


def kinetic(items: list[Item], sample: np.ndarray) -> float:
    moving = [it for it in items if not it.static]
    return sum(0.5 * it.mass * float(s[3:6] @ s[3:6]) + 0.5 * float(it.inertia @ (s[6:9] ** 2))
               for it, s in zip(moving, sample))


def run(engine, seconds: float, dt: float) -> np.ndarray:
    """Samples (steps + 1, moving bodies, 9) over ``seconds``."""
    steps = int(round(seconds / dt))
    out = np.empty((steps + 1,) + engine.sample().shape)
    out[0] = engine.sample()
    for k in range(1, steps + 1):
        engine.step(1)
        out[k] = engine.sample()
    return out


def sampled_impact_time(samples: np.ndarray, dt: float) -> float:
    """A peer's impact time: the end of the first step whose velocity changed (nan: none did)."""
    vel = samples[:, :, 3:9].reshape(len(samples), -1)
    changed = np.nonzero(np.any(np.abs(np.diff(vel, axis=0)) > 1e-9 * (1.0 + np.abs(vel[:-1])), axis=1))[0]
    return (int(changed[0]) + 1) * dt if len(changed) else math.nan


def _vector_row(case, quantity, got, ref, unit) -> dict:
    scale = float(np.linalg.norm(ref))
    return {"case": case, "quantity": quantity, "value": float(np.linalg.norm(got)), "exact": scale, "unit": unit,
            "error": float(np.linalg.norm(np.subtract(got, ref))) / scale, "relative": True}


def _row(case, quantity, value, exact_value, unit, relative=False) -> dict:
    error = value - exact_value
    if relative and exact_value != 0.0:
        error /= abs(exact_value)
    return {"case": case, "quantity": quantity, "value": value, "exact": exact_value, "unit": unit,
            "error": error, "relative": relative}


def case_impact(case: str, items: list[Item], engine, dt: float, spins: bool) -> list[dict]:
    a, b = items
    t_exact, (va, wa, vb, wb) = exact_after(a, b)
    samples = run(engine, t_exact + AFTER, dt)
    t_hit = engine.impact_time() if isinstance(engine, Ours) else sampled_impact_time(samples, dt)
    end = samples[-1]
    rows = [_vector_row(case, "v_a after", end[0, 3:6], va, "m/s"),
            _vector_row(case, "v_b after", end[1, 3:6], vb, "m/s")]
    if spins:
        rows += [_vector_row(case, "ω_a after", end[0, 6:9], wa, "rad/s"),
                 _vector_row(case, "ω_b after", end[1, 6:9], wb, "rad/s")]
    ke0 = kinetic(items, samples[0])
    exact_ke1 = sum(0.5 * it.mass * float(v @ v) + 0.5 * it.inertia[0] * float(w @ w)
                    for it, v, w in ((a, va, wa), (b, vb, wb)))
    rows.append(_row(case, "impact time", t_hit, t_exact, "s"))
    rows.append(_row(case, "energy change", kinetic(items, end) - ke0, exact_ke1 - ke0, "J", relative=True))
    return rows


def case_tunnel(case: str, items: list[Item], engine, dt: float) -> dict:
    """Held (the bodies end on their sides, apart), passed (through; "slowed" with the speed left
    if a contact acted on the way), or inside."""
    end = run(engine, TUNNEL_SECONDS, dt)[-1]
    if len(end) == 1:  # the ball and the wall
        x = end[0, 0]
        outcome = "held" if x <= WALL_X - WALL_HALF - TUNNEL_R * 0.99 else "passed" if x > WALL_X else "inside"
    else:
        gap = end[1, 0] - end[0, 0]
        outcome = "held" if gap >= 2 * TUNNEL_R * 0.99 else "passed" if gap < 0.0 else "inside"
    speed = float(np.linalg.norm(end[0, 3:6]))
    if outcome == "passed" and speed < TUNNEL_V * (1.0 - 1e-6):
        outcome = f"passed, slowed to {speed:.3g} m/s"
    return {"case": case, "quantity": "outcome", "outcome": outcome, "final_x": float(end[0, 0]),
            "final_speed": speed}


# ----------------------------------------------------------------------------- the run

def rebound_ratio(dt: float, dampratio: float) -> float:
    """MuJoCo's separation speed over approach speed for the equal head-on pair with this dampratio."""
    items = head_on(True)
    end = run(MuJoCo(items, dt, "calibrated", dampratio), contact_time(*items) + AFTER, dt)[-1]
    return (end[1, 3] - end[0, 3]) / 2.0


def calibrate_dampratio(dt: float) -> tuple[float, float]:
    """(MuJoCo's dampratio in [0.01, 1] whose equal head-on pair separates at E_PAIR × its approach
    speed, by bisection; the ratio reached, which is not E_PAIR where no dampratio gives it)."""
    lo, hi = 0.01, 1.0
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        ratio = rebound_ratio(dt, mid)
        if not math.isfinite(ratio) or ratio < E_PAIR:
            hi = mid
        else:
            lo = mid
    zeta = 0.5 * (lo + hi)
    return zeta, rebound_ratio(dt, zeta)


def _fresh(engine, items, dt):
    if isinstance(engine, Ours):
        return Ours(items, dt, engine.setting)
    if isinstance(engine, MuJoCo):
        return MuJoCo(items, dt, engine.setting, engine.dampratio)
    return PyBullet(items, dt, engine.setting)


def measure(quick: bool, log, dts=DTS, repeats: int = MIN_REPEATS, min_seconds: float | None = None):
    """(figure rows, tunnelling rows, cost rows, settings text), every case at every dt."""
    figures, tunnels, settings, timing = [], [], {}, []
    plans = [("head-on, equal", head_on(True), False), ("head-on, unequal", head_on(False), False),
             (f"oblique, spin, {regime(*oblique(False))}", oblique(False), True),
             (f"oblique, spin, {regime(*oblique(True))}", oblique(True), True)]
    tunnel_plans = [("tunnelling, sphere to wall", tunnel_wall()), ("tunnelling, sphere to sphere", tunnel_pair())]
    for dt in dts:
        dampratio, ratio = calibrate_dampratio(dt)
        if abs(ratio - E_PAIR) > CALIBRATED_TOLERANCE:
            settings[f"MuJoCo, calibrated (two bodies), dt {dt:g} s"] = (
                f"not run: no dampratio in [0.01, 1] gives the equal head-on pair e = {E_PAIR} "
                f"(its rebound ratio at {dampratio:.4f}: {ratio:.4g})")
            dampratio = None
        for case, items, spins in plans:
            for engine in engines(items, dt, False, dampratio):
                if not isinstance(engine, Ours):
                    key = f"{engine.name}, {engine.setting} (two bodies)" + (
                        f", dt {dt:g} s" if engine.setting == "calibrated" else "")
                    settings[key] = engine.settings_text() + (
                        f"; the equal head-on pair's rebound ratio with it: {ratio:.4g} (target {E_PAIR})"
                        if engine.setting == "calibrated" else "")
                rows = case_impact(case, items, engine, dt, spins)
                for r in rows:
                    r.update(engine=engine.name, setting=engine.setting, dt=dt)
                figures += rows
                log(f"  {case:26s} dt {dt:g} {engine.name} {engine.setting}: "
                    + "; ".join(f"{r['quantity']} {r['error']:+.2e}" for r in rows))
                fresh = _fresh(engine, items, dt)
                fresh.snapshot()
                steps = int(round((contact_time(*items) + AFTER) / dt))
                timing.append(Case((case, dt, engine.name, engine.setting), run=fresh.step, setup=fresh.restore,
                                   max_units=steps))
                engine.close()
        for case, items in tunnel_plans:
            for engine in engines(items, dt, True, None):
                if not isinstance(engine, Ours):
                    settings[f"{engine.name}, {engine.setting} (tunnelling)"] = engine.settings_text()
                row = case_tunnel(case, items, engine, dt)
                row.update(engine=engine.name, setting=engine.setting, dt=dt)
                tunnels.append(row)
                log(f"  {case:26s} dt {dt:g} {engine.name} {engine.setting}: {row['outcome']}")
                fresh = _fresh(engine, items, dt)
                fresh.snapshot()
                timing.append(Case((case, dt, engine.name, engine.setting), run=fresh.step, setup=fresh.restore,
                                   max_units=int(round(TUNNEL_SECONDS / dt))))
                engine.close()
    log("  timing every two-body case (µs per step)")
    if min_seconds is None:
        min_seconds = 0.02 if quick else 0.1
    stats = interleaved(timing, repeats, min_seconds)
    costs = [{"case": k[0], "dt": k[1], "engine": k[2], "setting": k[3], **s.scaled(1e6).as_row("us_per_step")}
             for k, s in stats.items()]
    for c in timing:  # PyBullet connections
        owner = getattr(c.run, "__self__", None)
        if owner is not None:
            owner.close()
    return figures, tunnels, costs, settings


def tunnel_table(tunnels: list[dict]) -> str:
    return E.dt_grid_table(tunnels, DTS, lambda r: r["outcome"])
