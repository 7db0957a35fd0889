"""MuJoCo counterparts of the benchmark bodies, used the way MuJoCo's documentation recommends.

Free bodies (a ``freejoint`` each, diagonal inertia, centre of mass at the body origin), no
gravity, contacts disabled. How each of our inputs maps onto MuJoCo's:

==================================  =========================================================
ours                                MuJoCo
==================================  =========================================================
``sim.step(n)`` (batched)           ``mujoco.mj_step(m, d, nstep=n)``
``sim.step(1)`` in a Python loop    ``mujoco.mj_step(m, d)`` in a Python loop
a force fixed in the body at a      a site on the body and a ``<motor site=... gear="0 1 0 0
site (``frame="<body>/<site>"``)    0 0"/>`` actuator driven through ``d.ctrl``: the gear is a
                                    force along the site's axes (XML reference, actuator
                                    ``site``: "the gear vector defines a 3d translation axis
                                    followed by a 3d rotation axis. Both are defined in the
                                    site's frame"), evaluated by the forward pass at every
                                    stage of RK4
a force in world axes at the COM    ``d.xfrc_applied[body, 0:3]`` (world axes, at the COM,
(``frame="<body>/world_aligned"``)  held over the step)
==================================  =========================================================

Matched methods (:data:`MATCHED`): our ``semi_implicit_euler`` is MuJoCo's ``Euler`` (velocities
first, then positions with the new velocities, orientation by the exponential map), ``rk4`` is
``RK4``, ``implicit_gyroscopic`` is ``implicitfast``.

MuJoCo is optional (``pip install -r requirements-bench.txt``); :func:`available` says whether
it imports.
"""

from __future__ import annotations

import numpy as np

try:
    import mujoco
except ImportError:  # the bench extra is not installed
    mujoco = None

#: MuJoCo integrators compared (name → mjtIntegrator member name).
MJ_INTEGRATORS = {"Euler": "mjINT_EULER", "implicitfast": "mjINT_IMPLICITFAST", "RK4": "mjINT_RK4"}
#: Our integrator → its MuJoCo counterpart (same method).
MATCHED = {"semi_implicit_euler": "Euler", "implicit_gyroscopic": "implicitfast", "rk4": "RK4"}


def available() -> bool:
    return mujoco is not None


def version() -> str:
    return mujoco.__version__ if mujoco is not None else "not installed"


def _body_xml(index: int, mass: float, inertia: np.ndarray, site: tuple[float, float, float] | None) -> str:
    d = " ".join(f"{x:.17g}" for x in inertia)
    site_xml = ""
    if site is not None:
        site_xml = f'<site name="s{index}" pos="{site[0]:.17g} {site[1]:.17g} {site[2]:.17g}"/>'
    return (f'<body name="b{index}" pos="{10.0 * index} 0 0"><freejoint/>'
            f'<inertial pos="0 0 0" mass="{mass:.17g}" diaginertia="{d}"/>'
            f'<geom type="sphere" size="0.1" contype="0" conaffinity="0" mass="0"/>{site_xml}</body>')


def free_bodies_xml(count: int, inertia: np.ndarray, mass: float, dt: float, integrator: str,
                    site: tuple[float, float, float] | None = None,
                    site_gear: tuple[float, ...] = (0.0, 1.0, 0.0, 0.0, 0.0, 0.0)) -> str:
    """MJCF of ``count`` free bodies spaced 10 m apart along x.

    With ``site`` (body axes, m from the COM), each body carries a site there and a motor
    actuator on it whose ``gear`` (force along the site's axes, then torque) is ``site_gear``:
    ``d.ctrl[i]`` is then the force (N) on body i along the site's y axis.
    """
    bodies = "".join(_body_xml(i, mass, np.asarray(inertia, float), site) for i in range(count))
    actuators = ""
    if site is not None:
        gear = " ".join(f"{g:.17g}" for g in site_gear)
        actuators = "<actuator>" + "".join(f'<motor site="s{i}" gear="{gear}"/>' for i in range(count)) + "</actuator>"
    memory_mb = 16 + count // 50  # the default arena is too small for 1e4 bodies
    return (f'<mujoco><option timestep="{dt:.17g}" integrator="{integrator}" gravity="0 0 0">'
            '<flag contact="disable" gravity="disable"/></option>'
            f'<size memory="{memory_mb}M"/><worldbody>{bodies}</worldbody>{actuators}</mujoco>')


def make(count: int, inertia: np.ndarray, mass: float, dt: float, integrator: str,
         site: tuple[float, float, float] | None = None):
    """(model, data) for ``count`` free bodies; ``integrator`` a key of MJ_INTEGRATORS (or any MJCF name)."""
    m = mujoco.MjModel.from_xml_string(free_bodies_xml(count, inertia, mass, dt, integrator, site))
    return m, mujoco.MjData(m)


def set_integrator(m, name: str) -> None:
    """Switch a compiled model's integrator (a key of MJ_INTEGRATORS)."""
    m.opt.integrator = getattr(mujoco.mjtIntegrator, MJ_INTEGRATORS[name])


def reset(m, d, angular_velocity_body: np.ndarray) -> None:
    """Back to the initial state: every body at rest at its origin pose, spinning at ``angular_velocity_body``.

    A free joint's angular velocity (qvel[3:6]) is in the body's local axes; at the identity
    orientation that is also the world axes our scenes give their twist in.
    """
    mujoco.mj_resetData(m, d)
    d.qvel.reshape(-1, 6)[:, 3:] = angular_velocity_body
