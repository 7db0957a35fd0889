"""Every integrator keeps its order through impacts: a ball with linear air drag bouncing.

With linear drag (force −c v, k = c/m) the flight is no longer a polynomial, so no method is
exact. Dropped from rest with its lowest point at H: z(t) = H − (g/k) t + (g/k²)(1 − e^{−kt});
after the impact it leaves at u = −e v₁ and z(s) = (u + g/k)(1 − e^{−ks})/k − (g/k) s. Both
impact times are the roots of these closed forms (brentq to round-off). The located impact
times must converge at each method's order (helpers.ORDER): the event is found on the
method's own step map, so the located time carries only the method's error, which an order
p method shrinks 2^p-fold when dt halves. (First sample below the ground would be first order
for all of them.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from helpers import FIXED_STEP_INTEGRATORS, ORDER
from rigid_body_sim.core import Simulator, load_scene

G, E, R, H, C, M = 9.81, 0.5, 0.1, 1.0, 0.5, 1.0
K = C / M


def closed_form_impacts() -> tuple[float, float]:
    t1 = brentq(lambda t: H - (G / K) * t + (G / K**2) * (1.0 - math.exp(-K * t)), 0.1, 2.0, xtol=1e-16, rtol=8.9e-16)
    u = E * (G / K) * (1.0 - math.exp(-K * t1))
    s2 = brentq(lambda s: (u + G / K) * (1.0 - math.exp(-K * s)) / K - (G / K) * s, 1e-3, 2.0, xtol=1e-16,
                rtol=8.9e-16)
    return t1, t1 + s2


def impact_errors(integrator: str, dt: float) -> np.ndarray:
    data = {"gravity": [0.0, 0.0, -G], "ground": [{"normal": [0, 0, 1], "material": {"restitution": E, "friction": 0.5}}],
            "bodies": {"ball": {"mass": M, "inertia": {"sphere": R}, "damping": {"linear": C},
                                "pose": {"position": [0.0, 0.0, H + R]}}}}
    t1, t2 = closed_form_impacts()
    sim = Simulator(load_scene(data), integrator=integrator, dt=dt, model_reduction=False)
    sim.step(int(round((t2 + 0.3) / dt)))
    impacts = sim.contact.events_of("ball", "impact")
    return np.array([abs(impacts[0].time - t1), abs(impacts[1].time - t2)])


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_located_impacts_converge_at_the_integrators_order(integrator):
    dts = (0.04, 0.02, 0.01) if ORDER[integrator] < 4 else (0.04, 0.02, 0.01, 0.005)
    errors = np.array([impact_errors(integrator, dt) for dt in dts])
    observed = np.log2(errors[:-1] / errors[1:])
    assert np.all(np.abs(observed - ORDER[integrator]) < 0.15), (errors, observed)


def test_reference_locates_the_impacts_to_its_tolerance():
    assert np.all(impact_errors("reference", 0.04) < 1e-10)
