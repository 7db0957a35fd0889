"""One body (or a grid of cubes) on a flat ground in three engines: ours, MuJoCo and PyBullet, one interface.

An :class:`Engine` is a running world of one body on the plane z = 0 (or of many cubes for the
throughput case), built from a :class:`Body` and a dt, with the engine's settings named in
``setting`` (a key of :data:`MUJOCO_SETTINGS` / :data:`PYBULLET_SETTINGS`, or our integrator).
``step(k)`` steps k times the engine's idiomatic way (ours ``sim.step``; MuJoCo
``mj_step(m, d, nstep=k)``; PyBullet ``stepSimulation`` in a loop, it has no batched call);
``sample()`` returns (position, world angular velocity, linear velocity, kinetic energy).

How each peer is set up (its documentation's recommendations; printed by benchmarks/contact_peers.py):

* **MuJoCo**: a ``plane`` geom and a free body with one geom of the shape (``mass`` on the
  geom: MuJoCo computes the same solid-body inertia). Friction on both geoms (MuJoCo takes
  the element-wise maximum of the pair). Restitution has no coefficient in MuJoCo: an
  underdamped ``solref`` on **both** geoms (a pair mixes the two; solref on the ball alone is
  averaged with the floor's default and gives e ≈ 0.2). ``oscillator``: solref =
  (0.02 s, ζ) with the damped oscillator's ζ = −ln e / √(π² + ln² e); ``calibrated``:
  (0.02 s, ζ*) with ζ* bisected at each dt until the first apex is the closed form's. Other
  cases use the default solref (0.02, 1). Cones: ``pyramidal`` (default), ``elliptic``,
  ``elliptic`` with ``impratio = 10`` (the docs' advice against slip), and that plus
  ``noslip_iterations = 10`` (the docs' post-pass against slip).
  Integrator ``Euler`` (the default, semi-implicit).
* **PyBullet**: ``GEOM_PLANE`` of mass 0 and a ``createMultiBody`` of the shape, damping set
  to 0 (PyBullet damps by default), rolling and spinning friction 0. Bullet multiplies the
  two bodies' coefficients: the plane gets friction 1 and restitution 1, the body the pair's
  values. ``default``: every engine parameter at its default (cone friction on, a restitution
  velocity threshold of 0.2 m/s, split impulse, 50 solver iterations); ``tuned`` (bounce only,
  the settings of bullet3 issue 3094 for restitution): restitution velocity threshold 0,
  no warm starting, contact slop 0, contact processing threshold 0, maximal coordinates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rigid_body_sim.core import Simulator, load_scene

try:
    import mujoco
except ImportError:  # the bench extra is not installed
    mujoco = None
try:
    import pybullet
except ImportError:
    pybullet = None

#: MuJoCo settings: (cone, impratio, noslip_iterations) and the solref rule (None: default solref).
MUJOCO_SETTINGS = {
    "pyramidal": ("pyramidal", 1.0, 0, None),
    "elliptic": ("elliptic", 1.0, 0, None),
    "elliptic, impratio 10": ("elliptic", 10.0, 0, None),
    "elliptic, impratio 10, noslip 10": ("elliptic", 10.0, 10, None),
    "oscillator": ("pyramidal", 1.0, 0, "oscillator"),
    "calibrated": ("pyramidal", 1.0, 0, "calibrated"),
}
PYBULLET_SETTINGS = ("default", "tuned")
MUJOCO_TIMECONST = 0.02  # s, MuJoCo's default solref time constant


@dataclass
class Body:
    """One body on the ground z = 0 (world z up), or ``grid`` × the same cube for a throughput scene.

    ``shape`` ``sphere`` (size: radius) or ``box`` (size: edge lengths); ``position`` of the
    centre of mass; ``orientation`` the body's axes in the world's, a unit quaternion (x, y, z, w);
    ``velocity``, ``angular_velocity`` world axes; ``gravity`` world axes (a tilted gravity makes
    an incline of the flat ground).
    """

    shape: str
    size: tuple[float, ...]
    mass: float
    position: tuple[float, float, float]
    friction: float
    restitution: float = 0.0
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    grid: int = 1
    spacing: float = 0.5
    inertia: np.ndarray = field(init=False)

    def __post_init__(self):
        if self.shape == "sphere":
            r = self.size[0]
            self.inertia = np.full(3, 0.4 * self.mass * r * r)
        else:
            a, b, c = self.size
            self.inertia = self.mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])

    def positions(self) -> np.ndarray:
        """Centres of the ``grid`` bodies (a square-ish grid in x, y), shape (grid, 3)."""
        side = math.ceil(math.sqrt(self.grid))
        k = np.arange(self.grid)
        return np.column_stack((self.position[0] + self.spacing * (k % side),
                                self.position[1] + self.spacing * (k // side),
                                np.full(self.grid, self.position[2])))


def zeta_of_restitution(e: float) -> float:
    """Damping ratio of the damped oscillator whose half-period rebound is e: −ln e / √(π² + ln² e)."""
    ln = math.log(e)
    return -ln / math.sqrt(math.pi**2 + ln * ln)


class Engine:
    name = ""

    def step(self, k: int) -> None:
        raise NotImplementedError

    def sample(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """(position of body 0 (3,), its angular velocity in world axes (3,), its velocity (3,), its kinetic energy J)."""
        raise NotImplementedError

    def set_velocity(self, v, w) -> None:
        raise NotImplementedError

    def snapshot(self) -> None:
        """Remember the current state; :meth:`restore` goes back to it (timing samples start there)."""
        raise NotImplementedError

    def restore(self) -> None:
        raise NotImplementedError

    def close(self) -> None:
        """Free what the engine holds outside Python (a PyBullet connection)."""


class Ours(Engine):
    name = "rigid_body_sim"

    def __init__(self, body: Body, dt: float, integrator: str):
        self.body, self.setting = body, integrator
        shape = {"sphere": {"sphere": body.size[0]}, "box": {"box": list(body.size)}}[body.shape]
        bodies = {}
        for i, p in enumerate(body.positions()):
            bodies[f"b{i}"] = {"mass": body.mass, "inertia": shape, "collision": shape,
                               "material": {"restitution": body.restitution, "friction": body.friction},
                               "pose": {"position": p.tolist(), "orientation": list(body.orientation)},
                               "twist": {"linear": list(body.velocity), "angular": list(body.angular_velocity)}}
        self.scene_data = {"gravity": list(body.gravity),
                           "ground": [{"normal": [0, 0, 1], "offset": 0.0,
                                       "material": {"restitution": body.restitution, "friction": body.friction}}],
                           "bodies": bodies}
        self.sim = Simulator(load_scene(self.scene_data), integrator=integrator, dt=dt, threads=1)  # as the peers run
        self._saved = None

    def step(self, k: int) -> None:
        self.sim.step(k)

    def sample(self):
        s = self.sim.body_state("b0")
        v, w = s.linear_velocity_world, s.angular_velocity_body
        kinetic = 0.5 * self.body.mass * float(v @ v) + 0.5 * float(self.body.inertia @ (w * w))
        return s.position_world, s.angular_velocity_world, v, kinetic

    def set_velocity(self, v, w) -> None:
        raise NotImplementedError("ours starts each case in its initial state (touching ground = persistent)")

    def snapshot(self) -> None:
        self._saved = True  # the scene's initial state

    def restore(self) -> None:
        self.sim.reset()


class MuJoCoData:
    """Snapshot and restore of a MuJoCo ``self.d`` (time, qpos, qvel, the warm start), shared by
    the two MuJoCo set-ups; nothing to close."""

    def snapshot(self) -> None:
        d = self.d
        self._saved = (d.time, d.qpos.copy(), d.qvel.copy(), d.qacc_warmstart.copy())

    def restore(self) -> None:
        d = self.d
        d.time, d.qpos[:], d.qvel[:], d.qacc_warmstart[:] = self._saved[0], *self._saved[1:]

    def close(self) -> None:
        pass


class MuJoCo(MuJoCoData, Engine):
    name = "MuJoCo"

    def __init__(self, body: Body, dt: float, setting: str, dampratio: float | None = None):
        self.body, self.setting = body, setting
        cone, impratio, noslip, solref_rule = MUJOCO_SETTINGS[setting]
        solref = ""
        if solref_rule == "oscillator":
            dampratio = zeta_of_restitution(body.restitution)
        if solref_rule is not None:
            solref = f' solref="{MUJOCO_TIMECONST} {dampratio:.17g}"'
        self.dampratio = dampratio
        mu = body.friction
        if body.shape == "sphere":
            geom = f'type="sphere" size="{body.size[0]}"'
        else:
            geom = 'type="box" size="{} {} {}"'.format(*(0.5 * s for s in body.size))
        qx, qy, qz, qw = body.orientation
        bodies = "".join(f'<body pos="{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}" quat="{qw:.17g} {qx:.17g} {qy:.17g} {qz:.17g}">'
                         f'<freejoint/>'
                         f'<geom {geom} mass="{body.mass}" friction="{mu} 0.005 0.0001"{solref}/></body>'
                         for p in body.positions())
        g = " ".join(f"{x:.17g}" for x in body.gravity)
        memory = 16 + body.grid // 20
        xml = (f'<mujoco><option timestep="{dt:.17g}" gravity="{g}" integrator="Euler" cone="{cone}" '
               f'impratio="{impratio}" noslip_iterations="{noslip}"/><size memory="{memory}M"/>'
               f'<worldbody><geom type="plane" size="0 0 1" friction="{mu} 0.005 0.0001"{solref}/>'
               f'{bodies}</worldbody></mujoco>')
        self.m = mujoco.MjModel.from_xml_string(xml)
        self.d = mujoco.MjData(self.m)
        self.set_velocity(body.velocity, body.angular_velocity)
        mujoco.mj_forward(self.m, self.d)
        self._saved = None

    def settings_text(self) -> str:
        o = self.m.opt
        cone = "elliptic" if o.cone == mujoco.mjtCone.mjCONE_ELLIPTIC else "pyramidal"
        text = (f"integrator Euler, cone {cone}, impratio {o.impratio:g}, noslip_iterations {o.noslip_iterations}, "
                f"solver Newton, iterations {o.iterations}, tolerance {o.tolerance:g}")
        if self.dampratio is not None:
            text += f", solref ({MUJOCO_TIMECONST}, {self.dampratio:.4f}) on both geoms"
        else:
            text += ", solref (0.02, 1) default"
        return text

    def step(self, k: int) -> None:
        mujoco.mj_step(self.m, self.d, nstep=k)

    def sample(self):
        d = self.d
        p = d.qpos[0:3].copy()
        w_local = d.qvel[3:6].copy()  # a free joint's angular velocity is in the body's axes
        R = d.xmat[1].reshape(3, 3)
        v = d.qvel[0:3].copy()
        kinetic = 0.5 * self.body.mass * float(v @ v) + 0.5 * float(self.body.inertia @ (w_local * w_local))
        return p, R @ w_local, v, kinetic

    def set_velocity(self, v, w) -> None:
        qvel = self.d.qvel.reshape(-1, 6)
        if self.d.time > 0:
            R = self.d.xmat[1].reshape(3, 3)
        else:  # before the first mj_forward: the initial orientation (w, x, y, z)
            R = np.empty(9)
            mujoco.mju_quat2Mat(R, np.array(self.d.qpos[3:7]))
            R = R.reshape(3, 3)
        qvel[:, 0:3] = v
        qvel[:, 3:6] = R.T @ np.asarray(w, float)



class PyBulletClient:
    """Snapshot, restore and close of a PyBullet connection ``self.c`` (the two PyBullet set-ups share them)."""

    def snapshot(self) -> None:
        self._saved = pybullet.saveState(physicsClientId=self.c)

    def restore(self) -> None:
        pybullet.restoreState(self._saved, physicsClientId=self.c)

    def close(self) -> None:
        pybullet.disconnect(physicsClientId=self.c)


class PyBullet(PyBulletClient, Engine):
    name = "PyBullet"

    def __init__(self, body: Body, dt: float, setting: str):
        self.body, self.setting = body, setting
        p = pybullet
        self.c = c = p.connect(p.DIRECT)
        p.resetSimulation(physicsClientId=c)
        p.setGravity(*body.gravity, physicsClientId=c)
        p.setTimeStep(dt, physicsClientId=c)
        tuned = setting == "tuned"
        if tuned:
            p.setPhysicsEngineParameter(restitutionVelocityThreshold=0.0, warmStartingFactor=0.0, contactSlop=0.0,
                                        physicsClientId=c)
        plane = p.createMultiBody(0.0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=c), physicsClientId=c)
        p.changeDynamics(plane, -1, lateralFriction=1.0, restitution=1.0, rollingFriction=0.0, spinningFriction=0.0,
                         physicsClientId=c)
        if body.shape == "sphere":
            shape = p.createCollisionShape(p.GEOM_SPHERE, radius=body.size[0], physicsClientId=c)
        else:
            shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.5 * s for s in body.size], physicsClientId=c)
        self.ids = []
        for pos in body.positions():
            b = p.createMultiBody(body.mass, shape, basePosition=pos.tolist(), baseOrientation=list(body.orientation),
                                  useMaximalCoordinates=tuned, physicsClientId=c)
            extra = {"contactProcessingThreshold": 0.0} if tuned else {}
            p.changeDynamics(b, -1, lateralFriction=body.friction, restitution=body.restitution, linearDamping=0.0,
                             angularDamping=0.0, rollingFriction=0.0, spinningFriction=0.0, physicsClientId=c, **extra)
            self.ids.append(b)
        if tuned:
            p.changeDynamics(plane, -1, contactProcessingThreshold=0.0, physicsClientId=c)
        self.set_velocity(body.velocity, body.angular_velocity)
        self._saved = None

    def settings_text(self) -> str:
        q = pybullet.getPhysicsEngineParameters(physicsClientId=self.c)
        keys = ("numSolverIterations", "useSplitImpulse", "restitutionVelocityThreshold", "enableConeFriction",
                "contactSlop", "warmStartingFactor", "erp", "contactERP", "frictionERP")
        tuned = (", set: restitutionVelocityThreshold 0, warmStartingFactor 0, contactSlop 0, maximal coordinates, "
                 "contactProcessingThreshold 0") if self.setting == "tuned" else ", engine parameters at their defaults"
        return (", ".join(f"{k} {q[k]:g}" for k in keys if k in q) + tuned
                + ", damping 0, plane friction 1 and restitution 1 (Bullet multiplies the pair's coefficients)")

    def step(self, k: int) -> None:
        step, c = pybullet.stepSimulation, self.c
        for _ in range(k):
            step(physicsClientId=c)

    def sample(self):
        p = pybullet
        pos, orn = p.getBasePositionAndOrientation(self.ids[0], physicsClientId=self.c)
        v, w = p.getBaseVelocity(self.ids[0], physicsClientId=self.c)
        v, w = np.array(v), np.array(w)
        w_body = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3).T @ w  # the shape's axes are the body's
        kinetic = 0.5 * self.body.mass * float(v @ v) + 0.5 * float(self.body.inertia @ (w_body * w_body))
        return np.array(pos), w, v, kinetic

    def set_velocity(self, v, w) -> None:
        for b in self.ids:
            pybullet.resetBaseVelocity(b, list(v), list(w), physicsClientId=self.c)



def versions() -> dict[str, str]:
    from importlib import metadata

    out = {}
    for name in ("mujoco", "pybullet"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def dt_grid_table(rows: list[dict], dts, cell) -> str:
    """A markdown table: a line per ``case``, a column per (``engine``, ``setting``) in the order
    met, each cell the rows of that case and column at ``dts`` as ``cell(row)`` joined by " / "
    ("—" where there is none)."""
    keys, cases = [], []
    for r in rows:
        if (r["engine"], r["setting"]) not in keys:
            keys.append((r["engine"], r["setting"]))
        if r["case"] not in cases:
            cases.append(r["case"])
    head = "| case | " + " | ".join(f"{e} {s}" for e, s in keys) + " |\n|" + "---|" * (1 + len(keys)) + "\n"
    body = ""
    for case in cases:
        cells = []
        for k in keys:
            parts = []
            for dt in dts:
                r = next((r for r in rows if r["case"] == case and r["dt"] == dt
                          and (r["engine"], r["setting"]) == k), None)
                parts.append("—" if r is None else cell(r))
            cells.append(" / ".join(parts))
        body += f"| {case} | " + " | ".join(cells) + " |\n"
    return head + body
