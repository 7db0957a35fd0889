"""A box resting on the ground: exactly at rest, held by m g, and answering a push as the closed forms say.

A body at rest held by a sticking contact is locked (core/kernels/contact/batch.py): its step
ends where it started and its holding force is reused while its state, parameters and wrench
are bitwise the same. These tests check that this shortcut changes nothing a user can see: the
box stays put with the contact force m g up, a push inside the friction cone leaves it at rest
with the friction equal and opposite to the push, a push beyond it makes it slide with
a = (F − μ m g)/m from the first step (½ a t², which rk4 integrates exactly), and a box that
lands flat comes to rest exactly on the ground and stays bitwise put.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigid_body_sim.core import NonFiniteStateError, Simulator, load_scene

G, MU, M = 9.81, 0.5, 1.0


def box_scene(height: float = 0.1):
    return load_scene({"gravity": [0.0, 0.0, -G],
                       "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": MU}}],
                       "bodies": {"crate": {"mass": M, "inertia": {"box": [0.2, 0.2, 0.2]},
                                            "pose": {"position": [0.0, 0.0, height]}}}})


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_resting_box_stays_exactly_put_held_by_m_g(integrator):
    sim = Simulator(box_scene(), integrator=integrator, dt=1e-3)
    start = sim.state.copy()
    sim.step(200)
    assert np.array_equal(sim.state.p_WC_W, start.p_WC_W)
    assert np.array_equal(sim.state.q_WP, start.q_WP)
    assert not np.any(sim.state.v_WC_W) and not np.any(sim.state.w_WP_P)
    assert sim.contact.holding_forces[0] == pytest.approx([0.0, 0.0, M * G], rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
@pytest.mark.parametrize("asleep", [False, True])
def test_a_step_that_fails_adds_nothing_to_the_holding_impulses(integrator, asleep):
    """A step refused as non-finite (a rod spun by 1e307 N·m) is not applied: the resting crate's holding impulse
    and angular impulse (torques tracked; held awake, or asleep on its ground) stay as they were, bit for bit. With
    the rod stopped, the next step adds the crate's m g × dt once."""
    rod = {"box": [1.0, 0.01, 0.01]}
    scene = load_scene({"gravity": [0.0, 0.0, -G],
                        "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": MU}}],
                        "bodies": {"crate": {"mass": M, "inertia": {"box": [0.2, 0.2, 0.2]},
                                             "pose": {"position": [0.0, 0.0, 0.1]}},
                                   "rod": {"mass": 0.1, "inertia": rod, "collision": rod,
                                           "pose": {"position": [0.0, 3.0, 2.0]}}}})
    sim = Simulator(scene, integrator=integrator, dt=1e-3)
    solver = sim.contact
    solver.sleeping, solver.track_torques = asleep, True
    sim.step(5)
    assert bool(solver.pairs.islands.asleep[0]) == asleep and solver.is_resting("crate")
    impulse, angular = solver.holding_impulses.copy(), solver.holding_angular_impulses.copy()
    sim.apply_wrench("rod", torque=(0.0, 0.0, 1e307))
    with pytest.raises(NonFiniteStateError):
        sim.step()
    assert np.array_equal(solver.holding_impulses, impulse)
    assert np.array_equal(solver.holding_angular_impulses, angular)
    sim.stop_body("rod")
    sim.step()
    assert solver.holding_impulses[0] - impulse[0] == pytest.approx([0.0, 0.0, M * G * 1e-3], rel=1e-12, abs=1e-15)


def test_push_inside_the_friction_cone_leaves_it_at_rest():
    sim = Simulator(box_scene(), integrator="rk4", dt=1e-3)
    sim.step(50)  # resting (locked) before the push
    push = 0.5 * MU * M * G
    sim.apply_wrench("crate", force=(push, 0.0, 0.0))
    sim.step(100)
    assert not np.any(sim.state.v_WC_W)
    assert sim.state.p_WC_W[0] == pytest.approx([0.0, 0.0, 0.1], abs=1e-15)
    assert sim.contact.holding_forces[0] == pytest.approx([-push, 0.0, M * G], rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("rest_steps", [0, 50])
def test_push_beyond_the_friction_cone_slides_with_the_closed_form_acceleration(rest_steps):
    sim = Simulator(box_scene(), integrator="rk4", dt=1e-3)
    sim.step(rest_steps)
    push = 2.0 * MU * M * G
    sim.apply_wrench("crate", force=(push, 0.0, 0.0))
    sim.step(100)
    a = (push - MU * M * G) / M
    t = 0.1
    assert sim.state.p_WC_W[0, 0] == pytest.approx(0.5 * a * t * t, rel=1e-9)
    assert sim.state.v_WC_W[0, 0] == pytest.approx(a * t, rel=1e-9)
    assert sim.state.p_WC_W[0, 2] == pytest.approx(0.1, abs=1e-12)
    # and once the push is gone it stops after v²/(2 μ g), then stays exactly put
    sim.step(1000)
    stops = sim.contact.events_of("crate", "stick")
    assert stops and stops[-1].time == pytest.approx(rest_steps * 1e-3 + t + a * t / (MU * G), rel=1e-9)
    x = sim.state.p_WC_W[0, 0]
    assert x == pytest.approx(0.5 * a * t * t + (a * t) ** 2 / (2.0 * MU * G), rel=1e-9)
    after = sim.state.copy()
    sim.step(100)
    assert np.array_equal(sim.state.p_WC_W, after.p_WC_W) and not np.any(sim.state.v_WC_W)


def test_box_landing_flat_comes_to_rest_exactly_on_the_ground():
    sim = Simulator(box_scene(height=0.6), integrator="rk4", dt=1e-3)
    sim.step(1000)
    assert sim.contact.is_resting("crate")
    assert sim.state.p_WC_W[0, 2] == pytest.approx(0.1, abs=1e-12)
    assert not np.any(sim.state.v_WC_W) and not np.any(sim.state.w_WP_P)
    after = sim.state.copy()
    sim.step(100)
    assert np.array_equal(sim.state.p_WC_W, after.p_WC_W) and np.array_equal(sim.state.q_WP, after.q_WP)


R, LENGTH = 0.05, 0.2  # a can standing on an end: the push at its top's centre that tips it is m g R / LENGTH


def can_scene(on: str):
    """The can standing on the ground, or on a static box's top face (a table: a plane held as the ground is)."""
    material = {"restitution": 0.0, "friction": MU}
    bodies = {"can": {"mass": M, "inertia": {"cylinder": [R, LENGTH]}, "material": material,
                      "pose": {"position": [0.0, 0.0, 0.5 * LENGTH]}}}
    if on == "table":
        bodies["table"] = {"mass": 10.0, "inertia": {"box": [1.0, 1.0, 0.5]}, "motion": "static", "material": material,
                           "pose": {"position": [0.0, 0.0, -0.25]}}
    ground = [{"normal": [0, 0, 1], "material": material}] if on == "ground" else []
    return load_scene({"gravity": [0.0, 0.0, -G], "ground": ground, "bodies": bodies})


def push_at_the_top(sim, fraction: float, heading: float, steps: int) -> float:
    """Push the can at its top's centre, horizontally along ``heading`` (rad from world x), by ``fraction`` of
    the tipping push, 10 steps at a time for ``steps``; returns the largest angle it turned through (rad)."""
    push = fraction * M * G * R / LENGTH
    start = sim.state.q_WP[0].copy()
    largest = 0.0
    for _ in range(steps // 10):
        c = sim.state.p_WC_W[0]
        sim.apply_force_at_point("can", (push * np.cos(heading), push * np.sin(heading), 0.0),
                                 (c[0], c[1], c[2] + 0.5 * LENGTH))
        sim.step(10)
        largest = max(largest, 2.0 * np.arccos(min(1.0, abs(float(sim.state.q_WP[0] @ start)))))
    return largest


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
@pytest.mark.parametrize("heading", [0.0, np.pi / 4, 0.3, 2.5])
@pytest.mark.parametrize("on", ["ground", "table"])
def test_a_can_pushed_at_its_top_rests_below_the_tipping_push_in_every_direction(on, integrator, heading):
    """Its end holds over the whole disk: the push F at the top's centre, at height LENGTH, tips the can about
    the rim point along the push once F LENGTH > m g R, whichever way it points (the rim points it stands on
    turn toward the load: persistent.end_toward_load), on the ground and on a static box's face alike. At 0.99
    of that push it stays exactly at rest, the contact holding −F and m g; at 1.01 it tips over about that rim
    point, its centre moving off along the push."""
    sim = Simulator(can_scene(on), integrator=integrator, dt=1e-3)
    sim.step(50)
    start = sim.state.copy()
    assert push_at_the_top(sim, 0.99, heading, 300) < 1e-7  # arccos near 1: its resolution
    assert np.abs(sim.state.p_WC_W - start.p_WC_W).max() <= 1e-15  # on the ground: locked, bitwise put
    assert np.abs(sim.state.q_WP - start.q_WP).max() <= 1e-15
    assert np.abs(sim.state.v_WC_W).max() <= 1e-15 and np.abs(sim.state.w_WP_P).max() <= 1e-15
    push = 0.99 * M * G * R / LENGTH
    assert sim.contact.holding_forces[0] == pytest.approx([-push * np.cos(heading), -push * np.sin(heading), M * G],
                                                          rel=1e-12, abs=1e-12)
    assert push_at_the_top(sim, 1.01, heading, 500) > 1e-2
    c = sim.state.p_WC_W[0]
    assert np.arctan2(c[1], c[0]) == pytest.approx(heading if heading <= np.pi else heading - 2 * np.pi, abs=1e-6)


@pytest.mark.parametrize("how", ["set_body_state", "with_scene"])
@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_crate_at_rest_placed_on_its_side_rests_there(integrator, how):
    """A crate (0.2 × 0.15 × 0.1 m) at rest flat on the ground, placed standing on a side (set_body_state, or a body
    spawned after with with_scene, which takes the crate's pose from the old simulator): it was held by the corners
    it lay on, and its projection onto them turned it over 10 cm into the ground at the next step. Now its contact
    is taken anew from the pose: over 10 steps it stays exactly there, held by m g."""
    box = {"box": [0.2, 0.15, 0.1]}
    bodies = {"crate": {"mass": M, "inertia": box, "pose": {"position": [0.0, 0.0, 0.05]}},
              "other": {"mass": M, "inertia": box, "pose": {"position": [1.0, 0.0, 0.05]}}}
    ground = [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": MU}}]
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "ground": ground, "bodies": bodies}), integrator, 1e-2)
    sim.step(3)
    assert sim.contact.is_resting("crate")
    side = [np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)]  # (x, y, z, w): 90° about x, its 0.15 m side down
    sim.set_body_state("crate", position_world=[0.0, 0.0, 0.075], orientation_xyzw=side)
    if how == "with_scene":
        bodies["ball"] = {"mass": M, "inertia": {"sphere": 0.05}, "pose": {"position": [0.0, 2.0, 0.5]}}
        sim = sim.with_scene(load_scene({"gravity": [0.0, 0.0, -G], "ground": ground, "bodies": bodies}))
    pose = sim.state.p_WC_W[0].copy(), sim.state.q_WP[0].copy()
    for _ in range(10):
        sim.step()
        np.testing.assert_allclose(sim.state.p_WC_W[0], pose[0], rtol=0.0, atol=1e-12)
        np.testing.assert_allclose(sim.state.q_WP[0], pose[1], rtol=0.0, atol=1e-12)
    assert sim.contact.is_resting("crate")
    np.testing.assert_allclose(sim.contact.holding_forces[0], [0.0, 0.0, M * G], rtol=1e-12, atol=1e-12)
