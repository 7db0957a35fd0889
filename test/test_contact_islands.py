"""Bodies resting on bodies: islands stepped together (core/contact/island.py, kernels/contact/island.py).

* A 10-cube tower (0.2 m, 1 kg, μ = 0.5, e = 0) standing on the ground, rk4 at dt = 10 ms: the
  exact motion is none. Over 60 s nothing sinks, drifts or moves by more than 1e-9 (m, m/s):
  the sticking case is solved exactly (the velocity problem as an equality, to round-off) and
  the gap term closes round-off gaps within a step. Sleeping off and on.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigid_body_sim.core import Simulator, load_scene

G = 9.81
EDGE = 0.2


def cube(position, mu=0.5, mass=1.0, edge=EDGE, orientation=(0.0, 0.0, 0.0, 1.0), velocity=(0.0, 0.0, 0.0)):
    box = {"box": [edge] * 3}
    return {"mass": mass, "inertia": box, "collision": box, "material": {"restitution": 0.0, "friction": mu},
            "pose": {"position": list(position), "orientation": list(orientation)},
            "twist": {"linear": list(velocity)}}


def simulator(bodies: dict, dt: float = 0.01, integrator: str = "rk4", sleeping: bool = False) -> Simulator:
    scene = load_scene({"gravity": [0.0, 0.0, -G], "bodies": bodies,
                        "ground": [{"normal": [0, 0, 1], "offset": 0.0,
                                    "material": {"restitution": 0.0, "friction": 0.5}}]})
    sim = Simulator(scene, integrator=integrator, dt=dt, threads=1)
    sim.contact.sleeping = sleeping
    return sim


def tower(count: int = 10, x: float = 0.0, y: float = 0.0) -> dict:
    return {f"c{x:g}_{y:g}_{k}": cube((x, y, EDGE * (k + 0.5))) for k in range(count)}


def speeds(sim: Simulator) -> float:
    """The largest linear speed and spin × half the edge over every body (m/s)."""
    v = np.linalg.norm(sim.linear_velocities_world(), axis=1)
    w = np.linalg.norm(sim.angular_velocities_world(), axis=1) * 0.5 * EDGE
    return float(max(v.max(), w.max()))


@pytest.mark.parametrize("sleeping", [False, True])
def test_a_ten_cube_tower_stands_for_a_minute(sleeping):
    sim = simulator(tower(), sleeping=sleeping)
    p0 = sim.positions_world().copy()
    q0 = sim.orientations_xyzw().copy()
    sim.step(6000)  # 60 s
    p = sim.positions_world()
    assert np.all(np.isfinite(p))
    assert np.max(np.abs(p[:, 2] - p0[:, 2])) <= 1e-9  # sink (or rise)
    assert np.max(np.abs(p[:, :2] - p0[:, :2])) <= 1e-9  # drift
    assert speeds(sim) <= 1e-9
    assert np.max(np.abs(sim.orientations_xyzw() - q0)) <= 1e-9
    assert sim.contact.counts["island_body_steps"] >= (10 if sleeping else 60_000)
