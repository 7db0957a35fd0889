"""A thrown, spinning, tilted phone (thin box) landing: no closed trajectory, but bounds that hold exactly.

CONTACT_NOTES §3: E = KE + m g z never increases at an impact (e ≤ 1) and is constant in
flight, so along the whole run E never rises (beyond the integrator's round-off in flight);
no corner ever ends a step inside the ground; and the phone ends at rest, flat on a face, with
gap 0 and zero velocity, its energy then exactly m g h/2 (h its thickness). Also: a box dropped
flat onto its face bounces like the ball (four corners at once, Newton's law at each).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.core.contact.shapes import MAX_FEATURES, feature_gaps

G = 9.81
MASS, THICK = 0.2, 0.008


def phone(e, integrator="rk4", dt=1e-3):
    s, c = math.sin(0.3), math.cos(0.3)
    data = {"gravity": [0.0, 0.0, -G],
            "ground": [{"normal": [0, 0, 1], "material": {"restitution": e, "friction": 0.5}}],
            "bodies": {"phone": {"mass": MASS, "inertia": {"box": [0.15, 0.075, THICK]},
                                 "pose": {"position": [0.0, 0.0, 1.0], "orientation": [0.6 * s, 0.8 * s, 0.0, c]},
                                 "twist": {"angular": [3.0, 5.0, 1.0]}}}}
    return Simulator(load_scene(data), integrator=integrator, dt=dt, model_reduction=False)


@pytest.mark.parametrize("e", [0.0, 0.5])
def test_phone_landing_never_gains_energy_never_sinks_and_ends_flat_at_rest(e):
    sim = phone(e)
    contact = sim.contact
    gaps = np.empty(MAX_FEATURES)

    def energy():
        return float(sim.kinetic_energy()[0]) + MASS * G * float(sim.state.p_WC_W[0, 2])

    start = previous = energy()
    for _ in range(2000):
        in_flight, seen = contact.modes[0] == 0, len(contact.events)
        sim.step()
        now = energy()
        if in_flight and len(contact.events) == seen:
            # a flight step: rk4's own error on the spinning body, local order 5 in |ω|·dt ≈ 6e-3 (seen ≤ 3e-11)
            assert now <= previous + 1e-10 * start
        else:  # a step with an impact, a landing or a resting contact: never more energy (round-off)
            assert now <= previous + 1e-14 * start
        previous = now
        y = sim._Ys[sim._control[0]][0]
        count = feature_gaps(y, sim._prm[0], contact.shapes[0], contact.grounds[0], gaps)
        assert gaps[:count].min() >= -1e-12
    assert contact.is_resting("phone")
    assert sim.state.p_WC_W[0, 2] == pytest.approx(THICK / 2.0, abs=1e-12)
    assert np.linalg.norm(sim.state.v_WC_W[0]) <= 1e-12 and np.linalg.norm(sim.state.w_WP_P[0]) <= 1e-12
    assert energy() == pytest.approx(MASS * G * THICK / 2.0, rel=1e-9)
    impacts = contact.events_of("phone", "impact")
    assert impacts and all(ev.energy_after <= ev.energy_before for ev in impacts)


def test_box_dropped_flat_bounces_like_the_ball():
    e, h0, half = 0.5, 1.0, 0.1
    data = {"gravity": [0.0, 0.0, -G],
            "ground": [{"normal": [0, 0, 1], "material": {"restitution": e, "friction": 0.5}}],
            "bodies": {"crate": {"mass": 1.0, "inertia": {"box": [0.4, 0.2, 2 * half]},
                                 "pose": {"position": [0.0, 0.0, h0 + half]}}}}
    sim = Simulator(load_scene(data), integrator="rk4", dt=1e-2, model_reduction=False)
    sim.step(150)
    t1 = math.sqrt(2.0 * h0 / G)
    v1 = G * t1
    impacts = sim.contact.events_of("crate", "impact")
    for k, event in enumerate(impacts[:3], start=1):
        assert event.time == pytest.approx(t1 + sum(2.0 * e**j * v1 / G for j in range(1, k)), rel=1e-9)
        assert event.normal_speed_after == pytest.approx(e**k * v1, rel=1e-9)
    assert sim.contact.events_of("crate", "rest")[0].time == pytest.approx(t1 * (1 + e) / (1 - e), abs=1e-6)
    assert sim.state.p_WC_W[0] == pytest.approx([0.0, 0.0, half], abs=1e-12)
    assert np.linalg.norm(sim.state.w_WP_P[0]) <= 1e-12  # it never tipped
