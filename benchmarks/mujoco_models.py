"""MuJoCo counterparts of the benchmark bodies: free bodies, no gravity, no contact.

MuJoCo is optional (``pip install -e .[bench]``); :func:`available` says whether it imports.
"""

from __future__ import annotations

import numpy as np

try:
    import mujoco
except ImportError:  # the bench extra is not installed
    mujoco = None

#: MuJoCo integrators compared (name → mjtIntegrator member name).
MJ_INTEGRATORS = {"Euler": "mjINT_EULER", "implicit": "mjINT_IMPLICIT",
                  "implicitfast": "mjINT_IMPLICITFAST", "RK4": "mjINT_RK4"}


def available() -> bool:
    return mujoco is not None


def version() -> str:
    return mujoco.__version__ if mujoco is not None else "not installed"


def free_bodies_xml(count: int, inertia: np.ndarray, mass: float, dt: float, integrator: str) -> str:
    """MJCF of ``count`` free bodies (freejoint, diaginertia, COM at the body origin), spaced 10 m apart."""
    d = " ".join(f"{x:.17g}" for x in inertia)
    bodies = "".join(
        f'<body pos="{10.0 * i} 0 0"><freejoint/><inertial pos="0 0 0" mass="{mass:.17g}" diaginertia="{d}"/>'
        f'<geom type="sphere" size="0.1" contype="0" conaffinity="0" mass="0"/></body>'
        for i in range(count))
    memory_mb = 16 + count // 50  # the default arena is too small for 1e4 bodies
    return (f'<mujoco><option timestep="{dt:.17g}" integrator="{integrator}" gravity="0 0 0">'
            '<flag contact="disable" gravity="disable"/></option>'
            f"<size memory=\"{memory_mb}M\"/><worldbody>{bodies}</worldbody></mujoco>")


def make(count: int, inertia: np.ndarray, mass: float, dt: float, integrator: str):
    """(model, data) for ``count`` free bodies; ``integrator`` a key of MJ_INTEGRATORS.

    Moments that break the triangle inequality (problem (b)) are rejected by the compiler;
    they are then written into ``model.body_inertia`` after compiling a valid placeholder,
    and ``mj_setConst`` recomputes the derived constants (without it the edit is ignored) —
    the same benchmark-only bypass as ours of the scene loader.
    """
    inertia = np.asarray(inertia, float)
    I = np.sort(inertia)
    valid = I[0] + I[1] >= I[2]
    m = mujoco.MjModel.from_xml_string(
        free_bodies_xml(count, inertia if valid else np.array([1.0, 1.0, 1.0]), mass, dt, integrator))
    d = mujoco.MjData(m)
    if not valid:
        m.body_inertia[1:] = inertia
        mujoco.mj_setConst(m, d)
    return m, d
