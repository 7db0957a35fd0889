"""Island contacts by pair (core/contact/island_contacts.py) against closed forms, rk4 through the Simulator.

* A tower of k cubes (0.2 m, 1 kg, μ = 0.5) at rest on the ground: the pair of cubes j and j + 1
  carries (k − j − 1) m g along +z on j + 1 and the opposite on j, the ground k m g on cube 0, no
  friction, resting; the mean over a tick of 10 steps and the last step's impulse / h alike.
* A cube pushed along x by F = 6 N at its centre of mass on a cube resting on the ground (μ = 0.5
  everywhere), 5 cm behind it: it slides (F > μ m g), so the pair carries m g along the normal and μ m g of
  friction against the push, and the top's velocity after n steps is the first-order step's
  n h (F/m − μ g) exactly; the lower cube sticks: the ground carries 2 m g and μ m g of friction
  against the push on the top. For 0.2 s: friction at the base turns the top forward, so its centre
  of pressure is μ × half the edge = 5 cm ahead of its centre, on the lower cube while the top's
  centre is behind x = 5 cm (it reaches −2.8 cm); beyond, it would tip.
* A tilted cube dropped onto a cube, rocking onto its face: on each tick in the island, the mean
  force on it is its momentum balance m Δv / T − m g (measured 2e-14 × m g; the last step's force
  differs from it by up to 5.7 m g).
* A stack on a static box and on a static cylinder: ``ground`` names the static body's plane (the
  box's top face; the body's tangent row for the cylinder), its normal +z.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.core.contact.island_contacts import SLIDE_SPEED, pair_sides
from rigid_body_sim.core.contact.query import resting_bodies
from rigid_body_sim.core.quaternion import quat_multiply

G, EDGE, M, MU = 9.81, 0.2, 1.0, 0.5


def cube(z: float, x: float = 0.0) -> dict:
    box = {"box": [EDGE] * 3}
    return {"mass": M, "inertia": box, "collision": box, "material": {"restitution": 0.0, "friction": MU},
            "pose": {"position": [x, 0.0, z]}}


def simulator(bodies: dict, dt: float = 0.01) -> Simulator:
    scene = load_scene({"gravity": [0.0, 0.0, -G], "bodies": bodies,
                        "ground": [{"normal": [0, 0, 1], "offset": 0.0,
                                    "material": {"restitution": 0.0, "friction": MU}}]})
    return Simulator(scene, integrator="rk4", dt=dt, threads=1)


def tick(sim: Simulator, steps: int):
    """Step ``steps`` and return the pair sides with forces the mean over them (the sums taken before and after)."""
    log = sim.contact.pairs.islands.log
    log.summing = True
    log.take()
    sim.step(steps)
    keys, impulses = log.take()
    return pair_sides(sim.contact, keys, impulses, steps * sim.dt)


def row(sides, body: int, other: int = -1, ground: int = -1) -> int:
    found = np.flatnonzero((sides.body == body) & (sides.other == other) & (sides.ground == ground))
    assert len(found) == 1, (body, other, ground, sides)
    return int(found[0])


@pytest.mark.parametrize("sleeping", [False, True])
@pytest.mark.parametrize("k", [2, 5])
def test_a_towers_contacts_carry_the_weight_above_them(k, sleeping):
    """Awake, and asleep (locked after its first step): an island asleep is listed with the forces it was held
    by when it fell asleep."""
    sim = simulator({f"c{j}": cube(EDGE * (j + 0.5)) for j in range(k)})
    sim.contact.sleeping = sleeping
    sim.step(3)
    assert bool(sim.contact.pairs.islands.asleep[:k].all()) == sleeping
    for sides in (tick(sim, 10), pair_sides(sim.contact)):  # the mean over a tick; the last step alone
        assert len(sides) == 2 * (k - 1) + 1  # two sides per pair of cubes, one on the ground
        assert not resting_bodies(sim)  # every cube in the island: no persistent row besides
        for j in range(k - 1):
            up, down = row(sides, j + 1, other=j), row(sides, j, other=j + 1)
            weight = (k - j - 1) * M * G
            np.testing.assert_allclose(sides.force_W[up], [0.0, 0.0, weight], rtol=1e-9, atol=1e-9 * weight)
            np.testing.assert_allclose(sides.force_W[down], [0.0, 0.0, -weight], rtol=1e-9, atol=1e-9 * weight)
            np.testing.assert_allclose(sides.normal_W[up], [0.0, 0.0, 1.0], atol=1e-12)
            np.testing.assert_allclose(sides.normal_W[down], [0.0, 0.0, -1.0], atol=1e-12)
            np.testing.assert_allclose(sides.point_W[up], [0.0, 0.0, EDGE * (j + 1)], atol=1e-12)
        floor = row(sides, 0, ground=0)
        np.testing.assert_allclose(sides.force_W[floor], [0.0, 0.0, k * M * G], rtol=1e-9, atol=1e-9 * k * M * G)
        np.testing.assert_allclose(sides.normal_W[floor], [0.0, 0.0, 1.0], atol=1e-12)
        assert np.all(np.abs(sides.gap) <= 1e-12)
        assert not sides.sliding.any()


def test_a_cube_pushed_on_a_cube_slides_with_mu_times_its_weight():
    force, steps = 6.0, 10
    sim = simulator({"low": cube(0.1), "top": cube(0.3, x=-0.05)})
    sim.step(3)
    for n in (1, 2):  # two ticks of 10 steps each, pushed throughout
        sim.apply_wrench("top", force=(force, 0.0, 0.0), frame="top/world_aligned")
        sides = tick(sim, steps)
        top, low, floor = row(sides, 1, other=0), row(sides, 0, other=1), row(sides, 0, ground=0)
        np.testing.assert_allclose(sides.force_W[top], [-MU * M * G, 0.0, M * G], rtol=1e-9, atol=1e-9 * M * G)
        np.testing.assert_allclose(sides.force_W[low], [MU * M * G, 0.0, -M * G], rtol=1e-9, atol=1e-9 * M * G)
        np.testing.assert_allclose(sides.force_W[floor], [-MU * M * G, 0.0, 2 * M * G], rtol=1e-9,
                                   atol=1e-9 * M * G)
        assert sides.sliding[top] and sides.sliding[low] and not sides.sliding[floor]
        v = sim.linear_velocities_world()
        np.testing.assert_allclose(v[1], [n * steps * sim.dt * (force / M - MU * G), 0.0, 0.0], rtol=1e-9, atol=1e-10)
        assert np.abs(v[0]).max() <= SLIDE_SPEED


def test_island_contacts_on_static_shapes_name_them():
    table = {"box": [1.0, 1.0, 0.2]}
    post = {"cylinder": [0.3, 0.4]}
    bodies = {"table": {"motion": "static", "mass": 1.0, "inertia": table, "collision": table,
                        "pose": {"position": [0.0, 0.0, 0.1]}},
              "post": {"motion": "static", "mass": 1.0, "inertia": post, "collision": post,
                       "pose": {"position": [2.0, 0.0, 0.2]}},
              "a": cube(0.3), "b": cube(0.5), "c": cube(0.5, x=2.0), "d": cube(0.7, x=2.0)}
    sim = simulator(bodies)
    sim.step(3)
    sides = tick(sim, 10)
    names = sim.body_names
    for lower, static, tangent in (("a", "table", False), ("c", "post", True)):
        i = names.index(lower)
        on = np.flatnonzero((sides.body == i) & (sides.other == -1))
        assert len(on) == 1
        r = int(on[0])
        assert sides.ground[r] >= len(sim.contact.half_spaces)
        assert sim.contact.static_body_of(int(sides.ground[r])) == static
        np.testing.assert_allclose(sim.contact.grounds[sides.ground[r], 0:3], [0.0, 0.0, 1.0], atol=1e-12)
        assert sim.contact.statics.is_tangent(int(sides.ground[r])) == tangent  # the box's face row; else tangent
        np.testing.assert_allclose(sides.force_W[r], [0.0, 0.0, 2 * M * G], rtol=1e-9, atol=1e-9 * M * G)


def test_the_mean_force_over_a_tick_is_the_momentum_the_pair_gave():
    """A cube turned 0.4 rad about z and tilted 0.3 rad about x, dropped 2 cm onto a cube: it lands
    on an edge and falls flat, the pair's force changing within each tick. On every tick of 10 steps
    that the top cube spends in the island (no event-driven impact in it), the mean force on it from
    the lower cube is its momentum balance m (v_end − v_start) / T − m g, exactly (the island step
    changes velocities by h f / m and the contact impulses / m only): 1e-9 × m g."""
    w, x, y, z = quat_multiply(np.array([np.cos(0.15), np.sin(0.15), 0.0, 0.0]),
                               np.array([np.cos(0.2), 0.0, 0.0, np.sin(0.2)]))  # (w, x, y, z): about x after z
    top = cube(0.2 + EDGE * 0.9, x=0.03)
    top["pose"]["orientation"] = [x, y, z, w]
    sim = simulator({"low": cube(0.1), "top": top}, dt=1e-3)
    log = sim.contact.pairs.islands.log
    log.summing = True
    checked, changing, steps = 0, 0.0, 10
    for _ in range(100):
        v0, events = sim.linear_velocities_world()[1].copy(), len(sim.contact.events)
        log.take()
        in_island = True
        for _ in range(steps):
            sim.step(1)
            in_island &= sim.contact.in_island("top")
        keys, impulses = log.take()
        if not in_island or len(sim.contact.events) != events:
            continue
        sides = pair_sides(sim.contact, keys, impulses, steps * sim.dt)
        r = row(sides, 1, other=0)
        expected = M * (sim.linear_velocities_world()[1] - v0) / (steps * sim.dt) - M * np.array([0.0, 0.0, -G])
        np.testing.assert_allclose(sides.force_W[r], expected, rtol=0, atol=1e-9 * M * G)
        last = pair_sides(sim.contact)  # the last step's force alone
        changing = max(changing, float(np.abs(sides.force_W[r] - last.force_W[row(last, 1, other=0)]).max()))
        checked += 1
    assert checked >= 50
    assert changing > M * G  # the force changed within a tick: the mean is not the last step's
