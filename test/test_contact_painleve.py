"""Painlevé configurations are counted (ContactSolver.counts["painleve"], /diagnostics), against the closed form.

A uniform rod (length L = 1 m, mass 1 kg, a thin capsule: its contact point lies on its axis'
line below the end) leaning at θ to the ground with its lower end on it, sliding along the
ground. For the end sliding away from the side the rod leans to, friction turns the normal
force's effect on the end's normal acceleration into (1 + 3 cos²θ − 3 μ sin θ cos θ)/m: the
rigid problem has no solution or several where that is ≤ 0, which first happens at
tan θ = 2 for μ = 4/3. At θ = atan 2: μ = 1.34 is inside (counted), μ = 1.33 is not, and the end
sliding the other way (the term enters with + ) never is.
"""

from __future__ import annotations

import math

import pytest

from rigid_body_sim.core import Simulator
from rigid_body_sim.core.scene import load_scene_text

THETA = math.atan(2.0)
L, RHO = 1.0, 1e-3


def rod(mu: float, vx: float) -> Simulator:
    phi = math.pi / 2 - THETA  # turns the rod's axis (body z) to (cos θ, 0, sin θ)
    z = 0.5 * L * math.sin(THETA) + RHO + 1e-13
    scene = f"""
gravity: [0.0, 0.0, -9.81]
ground:
  - {{normal: [0, 0, 1], offset: 0.0, material: {{restitution: 0.0, friction: {mu}}}}}
bodies:
  rod:
    mass: 1.0
    inertia: {{cylinder: [{RHO}, {L}]}}
    collision: {{capsule: [{RHO}, {L}]}}
    pose: {{position: [{0.5 * L * math.cos(THETA)}, 0.0, {z}], orientation: [0, {math.sin(phi / 2)}, 0, {math.cos(phi / 2)}]}}
    twist: {{linear: [{vx}, 0.0, 0.0]}}
"""
    sim = Simulator(load_scene_text(scene, "rod"), "rk4", 1e-4)
    assert sim.contact.is_resting("rod")
    sim.step(1)
    return sim


@pytest.mark.parametrize("mu, vx, counted", [(1.34, -1.0, True), (1.33, -1.0, False), (2.0, 1.0, False)])
def test_a_rod_sliding_on_its_end_is_counted_as_painleve_beyond_mu_four_thirds(mu, vx, counted) -> None:
    sim = rod(mu, vx)
    assert (sim.contact.counts["painleve"] > 0) is counted
