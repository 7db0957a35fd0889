"""A box sliding on the ground with Coulomb friction, and a ball rolling, against the closed forms.

Box (0.2 m cube, 1 kg) resting on its face, launched at v0 = 2 m/s with μ = 0.5, g = 9.81: the
friction force μ m g is constant until the slip stops, so the box stops after d = v0²/(2μg)
at t = v0/(μg) (0.407747 m at 0.407747 s) and stays: v ≡ 0 after. The stop is an event
located on the step map, so the only error is round-off (1e-9 relative is asked).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from helpers import ORDER, loglog_slope
from rigid_body_sim.core import Simulator, load_scene

G, MU, V0 = 9.81, 0.5, 2.0
CONFIG = Path(__file__).resolve().parents[1] / "config"


def sliding_scene(direction=(1.0, 0.0, 0.0)):
    data = {"gravity": [0.0, 0.0, -G],
            "ground": [{"normal": [0, 0, 1], "offset": 0.0, "material": {"restitution": 0.0, "friction": MU}}],
            "bodies": {"crate": {"mass": 1.0, "inertia": {"box": [0.2, 0.2, 0.2]},
                                 "pose": {"position": [0.0, 0.0, 0.1]},
                                 "twist": {"linear": [V0 * c for c in direction]}}}}
    return load_scene(data)


# the stop is found on the step map: round-off at any dt; rk4 at 0.1 ms and the reference at 1 ms in test-slow
@pytest.mark.parametrize("integrator, dt", [("rk4", 1e-2), ("rk4", 1e-3), pytest.param("rk4", 1e-4, marks=pytest.mark.slow),
                                            ("reference", 1e-2), pytest.param("reference", 1e-3, marks=pytest.mark.slow),
                                            ("splitting", 1e-2), ("semi_implicit_euler", 1e-2)])
def test_box_stops_after_the_closed_form_distance_and_time(integrator, dt):
    sim = Simulator(sliding_scene(), integrator=integrator, dt=dt, model_reduction=False)
    assert sim.contact.is_resting("crate")  # starts touching, not moving away: persistent
    sim.step(int(round(0.6 / dt)))
    stops = sim.contact.events_of("crate", "stick")
    assert len(stops) == 1
    t_stop, d_stop = V0 / (MU * G), V0 * V0 / (2.0 * MU * G)
    if integrator == "semi_implicit_euler":  # first order in the slide: only close, the stop still located
        assert stops[0].time == pytest.approx(t_stop, rel=2e-2)
        return
    assert stops[0].time == pytest.approx(t_stop, rel=1e-9)
    assert sim.state.p_WC_W[0, 0] == pytest.approx(d_stop, rel=1e-9)
    x_after = sim.state.p_WC_W[0, 0]
    for _ in range(int(round(1.0 / dt))):  # and it stays, on the ground, not turning
        sim.step()
        assert np.linalg.norm(sim.state.v_WC_W[0]) <= 1e-12
        assert np.linalg.norm(sim.state.w_WP_P[0]) <= 1e-12
        assert sim.state.p_WC_W[0, 2] - 0.1 == pytest.approx(0.0, abs=1e-12)
    assert sim.state.p_WC_W[0, 0] == pytest.approx(x_after, abs=1e-12)


def test_example_scene_slides_to_its_stop():
    sim = Simulator(load_scene(CONFIG / "contact_sliding_box.yaml"), integrator="rk4", dt=1e-2)
    sim.step(60)
    assert sim.contact.events_of("crate", "stick")[0].time == pytest.approx(V0 / (MU * G), rel=1e-9)


def test_box_sliding_diagonally_stops_on_its_line():
    direction = np.array([3.0, 4.0, 0.0]) / 5.0
    sim = Simulator(sliding_scene(tuple(direction)), integrator="rk4", dt=1e-2, model_reduction=False)
    sim.step(60)
    d_stop = V0 * V0 / (2.0 * MU * G)
    assert sim.state.p_WC_W[0, :2] == pytest.approx(d_stop * direction[:2], rel=1e-9)


def test_sliding_friction_force_is_mu_m_g_and_the_imu_reads_it():
    data = {"gravity": [0.0, 0.0, -G],
            "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": MU}}],
            "bodies": {"crate": {"mass": 2.0, "inertia": {"box": [0.2, 0.2, 0.2]},
                                 "pose": {"position": [0.0, 0.0, 0.1]}, "twist": {"linear": [V0, 0.0, 0.0]},
                                 "sites": {"imu": {"position": [0.0, 0.0, 0.0], "imu": {}}}}}}
    sim = Simulator(load_scene(data), integrator="rk4", dt=1e-2)
    sim.step(10)
    # specific force = (contact force)/m: −μ g along x, +g up
    assert sim.site_readings().specific_force[0] == pytest.approx([-MU * G, 0.0, G], rel=1e-12, abs=1e-12)
    assert sim.state.v_WC_W[0, 0] == pytest.approx(V0 - MU * G * 0.1, rel=1e-12)


@pytest.mark.parametrize("integrator, reduction", [("rk4", False), ("rk4", True), ("reference", False)])
def test_ball_slides_then_rolls_at_the_closed_form_time_and_speed(integrator, reduction):
    """Solid ball (k² = 2/5) launched at v0 without spin, μ = 0.3: rolls from t = k² v0/((1 + k²) μ g)
    at v = v0/(1 + k²), having slid (v0² − v²)/(2μg); then rolls on at v, without slip."""
    mu, r, k2 = 0.3, 0.1, 0.4
    data = {"gravity": [0.0, 0.0, -G],
            "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": mu}}],
            "bodies": {"ball": {"mass": 1.0, "inertia": {"sphere": r}, "pose": {"position": [0.0, 0.0, r]},
                                "twist": {"linear": [V0, 0.0, 0.0]}}}}
    sim = Simulator(load_scene(data), integrator=integrator, dt=1e-2, model_reduction=reduction)
    sim.step(50)
    t_roll, v_roll = k2 * V0 / ((1.0 + k2) * mu * G), V0 / (1.0 + k2)
    assert sim.contact.events_of("ball", "stick")[0].time == pytest.approx(t_roll, rel=1e-9)
    assert sim.state.v_WC_W[0] == pytest.approx([v_roll, 0.0, 0.0], rel=1e-12, abs=1e-12)
    slid = (V0 * V0 - v_roll * v_roll) / (2.0 * mu * G)
    assert sim.state.p_WC_W[0, 0] == pytest.approx(slid + v_roll * (sim.time - t_roll), rel=1e-9)
    w_W = sim.angular_velocities_world()[0]
    assert w_W == pytest.approx([0.0, v_roll / r, 0.0], rel=1e-12, abs=1e-12)  # rolling: v = ω r
    assert sim.state.p_WC_W[0, 2] == pytest.approx(r, abs=1e-12)


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
@pytest.mark.parametrize("r, v0, dt", [(0.005, 0.05, 5e-3), (0.005, 0.01, 1e-2), (0.05, 0.01, 5e-3), (0.05, 0.05, 1e-2)])
def test_a_slow_ball_whose_slide_stops_within_a_step_rolls_on_at_the_closed_form_speed(integrator, r, v0, dt):
    """The closed forms above for a slide that stops within the step it starts in (1 cm and 10 cm balls at 1 and
    5 cm/s, μ = 0.3): the stop located at t = k² v0/((1 + k²) μ g), then rolling at v0/(1 + k²). Held to the step's
    end at the friction of its start, the slide overshoots the stop and slips back, raising K + U past the held
    step's throw guard, which left the ball at rest where it was."""
    mu, k2 = 0.3, 0.4
    data = {"gravity": [0.0, 0.0, -G],
            "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": mu}}],
            "bodies": {"ball": {"mass": 0.03, "inertia": {"sphere": r}, "pose": {"position": [0.0, 0.0, r]},
                                "twist": {"linear": [v0, 0.0, 0.0]}}}}
    sim = Simulator(load_scene(data), integrator=integrator, dt=dt)
    sim.step(3)
    t_roll, v_roll = k2 * v0 / ((1.0 + k2) * mu * G), v0 / (1.0 + k2)
    assert sim.contact.events_of("ball", "stick")[0].time == pytest.approx(t_roll, rel=1e-9)
    assert sim.state.v_WC_W[0] == pytest.approx([v_roll, 0.0, 0.0], rel=1e-12, abs=1e-12)
    assert sim.angular_velocities_world()[0] == pytest.approx([0.0, v_roll / r, 0.0], rel=1e-12, abs=1e-12)
    assert sim.contact.counts["held_thrown"] == 0


def test_box_at_rest_on_an_incline_inside_the_friction_cone_does_not_move():
    """20° incline, μ = 0.5 > tan 20°: no motion at all (peers creep 1e-7 to 1e-3 m/s)."""
    theta = math.radians(20.0)
    n = [0.0, -math.sin(theta), math.cos(theta)]
    q_xyzw = [math.sin(theta / 2.0), 0.0, 0.0, math.cos(theta / 2.0)]  # body z along n
    data = {"gravity": [0.0, 0.0, -G],
            "ground": [{"normal": n, "material": {"restitution": 0.0, "friction": 0.5}}],
            "bodies": {"crate": {"mass": 1.0, "inertia": {"box": [0.2, 0.2, 0.2]},
                                 "pose": {"position": [0.1 * c for c in n], "orientation": q_xyzw}}}}
    sim = Simulator(load_scene(data), integrator="rk4", dt=1e-2)
    assert sim.contact.is_resting("crate")
    start = sim.state.p_WC_W[0].copy()
    for _ in range(1000):
        sim.step()
        assert np.linalg.norm(sim.state.v_WC_W[0]) <= 1e-12
    assert np.linalg.norm(sim.state.p_WC_W[0] - start) <= 1e-12
    assert [e.kind for e in sim.contact.events] == ["rest"]


def test_a_resting_body_lifted_by_set_body_state_falls_again():
    sim = Simulator(sliding_scene(direction=(0.0, 0.0, 0.0)), integrator="rk4", dt=1e-2)
    assert sim.contact.is_resting("crate")
    sim.set_body_state("crate", position_world=[0.0, 0.0, 0.6])  # 0.5 m up
    sim.step(50)
    impacts = sim.contact.events_of("crate", "impact")
    assert impacts[0].time == pytest.approx(math.sqrt(2.0 * 0.5 / G), rel=1e-9)
    assert sim.contact.is_resting("crate")  # e = 0: at rest at once
    assert sim.state.p_WC_W[0] == pytest.approx([0.0, 0.0, 0.1], abs=1e-12)


def test_a_ball_sliding_on_the_floor_bounces_off_a_wall():
    """Two half-spaces: a frictionless floor (e 0) and a wall x ≤ 1 (e 1). The ball, resting on the
    floor and sliding at v0 toward the wall, reaches it when x + r = 1 (t = (1 − r)/v0), comes back
    at −v0 and stays on the floor."""
    r = 0.1
    data = {"gravity": [0.0, 0.0, -G],
            "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": 0.0}},
                       {"normal": [-2, 0, 0], "offset": -1.0, "material": {"restitution": 1.0, "friction": 0.0}}],
            "bodies": {"ball": {"mass": 1.0, "inertia": {"sphere": r}, "pose": {"position": [0.0, 0.0, r]},
                                "twist": {"linear": [V0, 0.0, 0.0]}}}}
    sim = Simulator(load_scene(data), integrator="rk4", dt=1e-2)
    assert sim.contact.is_resting("ball")
    sim.step(100)
    hits = sim.contact.events_of("ball", "impact")
    assert len(hits) == 1 and hits[0].ground == 1
    t_hit = (1.0 - r) / V0
    assert hits[0].time == pytest.approx(t_hit, rel=1e-12)
    assert sim.state.v_WC_W[0] == pytest.approx([-V0, 0.0, 0.0], rel=1e-12, abs=1e-12)
    assert sim.state.p_WC_W[0] == pytest.approx([1.0 - r - V0 * (sim.time - t_hit), 0.0, r], rel=1e-12, abs=1e-12)
    assert sim.contact.is_resting("ball")


# ----------------------------------------------------------------------------- sliding down a steeper incline

SLOPE, SLOPE_MU = math.radians(20.0), 0.3  # tan 20° = 0.364 > μ: the box slides
SLOPE_A = G * (math.sin(SLOPE) - SLOPE_MU * math.cos(SLOPE))  # 0.589716 m/s² down the slope
SLOPE_N = np.array([0.0, -math.sin(SLOPE), math.cos(SLOPE)])  # the tilted ground's normal
SLOPE_DOWN = np.array([0.0, -math.cos(SLOPE), -math.sin(SLOPE)])  # down the slope, in the plane


def slope_simulator(integrator: str, dt: float, v0: float) -> Simulator:
    """A 0.3 × 0.2 × 0.1 m box (three distinct moments: every method steps it) on its large face on the
    20° incline (the ground's normal tilted), μ = 0.3, moving down the slope at v0."""
    data = {"gravity": [0.0, 0.0, -G],
            "ground": [{"normal": SLOPE_N.tolist(), "material": {"restitution": 0.0, "friction": SLOPE_MU}}],
            "bodies": {"crate": {"mass": 1.0, "inertia": {"box": [0.3, 0.2, 0.1]},
                                 "pose": {"position": (0.05 * SLOPE_N).tolist(),
                                          "orientation": [math.sin(SLOPE / 2.0), 0.0, 0.0, math.cos(SLOPE / 2.0)]},
                                 "twist": {"linear": (v0 * SLOPE_DOWN).tolist()}}}}
    return Simulator(load_scene(data), integrator=integrator, dt=dt)


def slope_errors(integrator: str, dt: float, v0: float, t: float = 1.0) -> tuple[float, float]:
    """Relative errors of the distance slid and the speed after t against v0 t + ½ a t², v0 + a t;
    every step the box stays on the plane (gap 0, no normal velocity, no spin)."""
    sim = slope_simulator(integrator, dt, v0)
    assert sim.contact.is_resting("crate")
    start = sim.state.p_WC_W[0].copy()
    for _ in range(int(round(t / dt))):
        sim.step()
        assert float(sim.state.p_WC_W[0] @ SLOPE_N) - 0.05 == pytest.approx(0.0, abs=1e-12)
        assert abs(float(sim.state.v_WC_W[0] @ SLOPE_N)) <= 1e-12
        assert np.linalg.norm(sim.state.w_WP_P[0]) <= 1e-12
    distance = float((sim.state.p_WC_W[0] - start) @ SLOPE_DOWN)
    speed = float(sim.state.v_WC_W[0] @ SLOPE_DOWN)
    return (abs(distance / (v0 * t + 0.5 * SLOPE_A * t * t) - 1.0), abs(speed / (v0 + SLOPE_A * t) - 1.0))


@pytest.mark.parametrize("v0", [0.0, 0.5])
@pytest.mark.parametrize("integrator", ["rk4", "reference"])
def test_box_sliding_down_a_steeper_incline_accelerates_at_g_sin_minus_mu_cos(integrator, v0):
    """Released at rest (the cone cannot hold it: it starts to slide in its first step) or already sliding
    at 0.5 m/s: a = g (sin θ − μ cos θ) exactly (a constant force: a parabola in the plane), distance
    v0 t + ½ a t² (0.294851 m from rest) and speed v0 + a t after 1 s, at dt = 1 ms within 1e-9 relative
    (seen ≤ 1e-14), and the box never leaves the plane nor turns."""
    assert max(slope_errors(integrator, 1e-3, v0)) <= 1e-9


@pytest.mark.parametrize("dt", [1e-2, pytest.param(1e-3, marks=pytest.mark.slow)])
@pytest.mark.parametrize("integrator", ["implicit_gyroscopic", "splitting", "symmetric_splitting",
                                        "exact_rotor_splitting"])
def test_second_order_methods_are_exact_down_the_incline(integrator, dt):
    """A constant force without spin: the kick–drift–kick splittings and the implicit midpoint step are
    exact on a parabola, so their error is round-off at every dt (seen ≤ 6e-14 at 10 ms to 1 ms): no
    order to observe, exactness is what is checked (at 1 ms, ten times the steps, in test-slow)."""
    for v0 in (0.0, 0.5):
        assert max(slope_errors(integrator, dt, v0)) <= 1e-9


@pytest.mark.parametrize("integrator", ["euler", "semi_implicit_euler"])
def test_first_order_methods_converge_at_first_order_down_the_incline(integrator):
    """Explicit and semi-implicit Euler, released at rest: the distance error is ½ a t dt (dt/t relative:
    1e-2 at 10 ms), observed order 1 by a log-log fit over dt = 10, 5, 2.5 ms."""
    dts = np.array([1e-2, 5e-3, 2.5e-3])
    errors = np.array([slope_errors(integrator, dt, 0.0)[0] for dt in dts])
    assert abs(loglog_slope(dts, errors) - ORDER[integrator]) < 0.1, errors
