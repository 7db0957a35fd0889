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


def energy(sim: Simulator) -> float:
    """K + U (J) of every body, U = m g z."""
    prm, rows = sim._prm, sim.state.rows()
    kinetic = 0.5 * prm[:, 0] * (rows[:, 7:10] ** 2).sum(axis=1) + 0.5 * (prm[:, 2:5] * rows[:, 10:13] ** 2).sum(axis=1)
    return float((kinetic + prm[:, 0] * G * rows[:, 2]).sum())


def deepest(sim: Simulator) -> float:
    """The most negative signed distance (m) of any two bodies or of a body and the ground (0 if none)."""
    from rigid_body_sim.core.contact.query import lowest_gaps

    rows, pairs = sim.state.rows(), sim.contact.pairs
    n = len(rows)
    worst = min(0.0, float(lowest_gaps(sim).min()))
    for a in range(n):
        for b in range(a + 1, n):
            worst = min(worst, pairs.contact(rows[a], a, rows[b], b))
    return worst


DROPPED = {
    "box": cube((0.03, 0.02, 0.8), orientation=(0.0, 0.0, np.sin(0.2), np.cos(0.2))),  # turned 0.4 rad, off-centre
    "ball": {"mass": 0.5, "inertia": {"sphere": 0.05}, "collision": {"sphere": 0.05},
             "material": {"restitution": 0.0, "friction": 0.5}, "pose": {"position": [0.04, 0.03, 0.75]}},
}


@pytest.mark.parametrize("dt", [1e-3, 1e-2])
@pytest.mark.parametrize("what", sorted(DROPPED))
def test_a_body_dropped_onto_a_two_box_stack_comes_to_rest_on_it(what, dt):
    """A box (turned, off-centre) or a ball (off-centre) dropped 0.3 m onto two stacked cubes, e = 0.

    At every step: finite, no penetration beyond the projection's tolerance (PROJECT_TOL × the
    pair's size), and the energy K + U never above its lowest earlier value by more than
    round-off (1e-12 relative: e = 0 and the velocity step's gap term only dissipate). At 3 s: the
    dropped body lies on the stack (its height the closed form: 0.5 m for the box's centre, 0.45 m
    for the ball's), every speed ≤ 1e-9, the stack where it stood."""
    from rigid_body_sim.core.kernels.contact.island import PROJECT_TOL

    bodies = {"low": cube((0.0, 0.0, 0.1)), "mid": cube((0.0, 0.0, 0.3)), "top": DROPPED[what]}
    sim = simulator(bodies, dt=dt)
    lowest = energy(sim)
    for _ in range(int(round(3.0 / dt))):
        sim.step()
        assert np.all(np.isfinite(sim.state.rows()))
        assert deepest(sim) >= -PROJECT_TOL * EDGE
        e = energy(sim)
        assert e <= lowest + 1e-12 * abs(lowest)
        lowest = min(lowest, e)
    z = sim.positions_world()[:, 2]
    assert z[:2] == pytest.approx([0.1, 0.3], abs=1e-12)
    assert z[2] == pytest.approx(0.5 if what == "box" else 0.45, abs=1e-12)
    assert speeds(sim) <= 1e-9
    assert sim.contact.counts["island_body_steps"] > 0
