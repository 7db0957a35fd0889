"""A ball bouncing on the ground against the closed form, with every integrator.

Ball r = 0.1 m dropped with its lowest point at h0 = 1 m, e = 0.5 on both sides, g = 9.81:
impact k at t_k = t1 + Σ_{j<k} 2 e^j v1 / g with t1 = √(2 h0 / g), v1 = g t1, leaving at
e^k v1; apex of flight k at h0 e^{2k} (0.25, 0.0625, 0.015625 m); at rest at the accumulation
time T = t1 (1 + e)/(1 − e). The flight is a parabola, which rk4, the splittings (velocity
Verlet for a constant force) and DOP853 integrate exactly, so their only error is round-off
and the event location: 1e-9 relative is asked (seen: ~1e-14). Explicit and semi-implicit
Euler are first order: their error must fall 10× when dt does.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_body_sim.core import INTEGRATORS, Simulator, load_scene

G, E, R, H0 = 9.81, 0.5, 0.1, 1.0
T1 = math.sqrt(2.0 * H0 / G)
V1 = G * T1
REST = T1 * (1.0 + E) / (1.0 - E)


def impact_time(k: int) -> float:
    """Closed form t_k, k = 1, 2, ..."""
    return T1 + sum(2.0 * E**j * V1 / G for j in range(1, k))


def exact_height(t: float) -> float:
    """Height of the lowest point at t (before the accumulation time)."""
    if t <= T1:
        return H0 - 0.5 * G * t * t
    k = 1
    while impact_time(k + 1) <= t:
        k += 1
    s = t - impact_time(k)
    return E**k * V1 * s - 0.5 * G * s * s


def scene(material_ball=True, normal=(0.0, 0.0, 1.0), friction=0.5, site=False):
    ball = {"mass": 1.0, "inertia": {"sphere": R}, "collision": {"sphere": R}, "pose": {"position": [0.0, 0.0, H0 + R]}}
    if material_ball:
        ball["material"] = {"restitution": E, "friction": 0.3}
    if site:
        ball["sites"] = {"centre": {"position": [0.0, 0.0, 0.0], "imu": {}}}
    return load_scene({"gravity": [0.0, 0.0, -G],
                       "ground": [{"normal": list(normal), "offset": 0.0,
                                   "material": {"restitution": E, "friction": friction}}],
                       "bodies": {"ball": ball}})


def run(integrator: str, dt: float, until: float, reduction: bool = False):
    """Step to ``until``; (sim, times, heights of the lowest point, vertical speeds) at every step."""
    sim = Simulator(scene(), integrator=integrator, dt=dt, model_reduction=reduction)
    steps = int(round(until / dt))
    times, heights, speeds = np.empty(steps), np.empty(steps), np.empty(steps)
    for k in range(steps):
        sim.step()
        times[k] = sim.time
        heights[k] = sim.state.p_WC_W[0, 2] - R
        speeds[k] = sim.state.v_WC_W[0, 2]
    return sim, times, heights, speeds


def check_exact(sim, times, heights, speeds, rtol=1e-9):
    impacts = sim.contact.events_of("ball", "impact")
    assert len(impacts) >= 3
    for k, event in enumerate(impacts[:3], start=1):
        assert event.time == pytest.approx(impact_time(k), rel=rtol)
        assert event.normal_speed_before == pytest.approx(-E ** (k - 1) * V1, rel=rtol)
        assert event.normal_speed_after == pytest.approx(E**k * V1, rel=rtol)
        assert event.energy_after <= event.energy_before
    # every sample of flights 1..3: its apex h + v²/(2g) is h0 e^{2k}, and its height the closed form's
    for k in (1, 2, 3):
        inside = (times > impact_time(k)) & (times < impact_time(k + 1))
        assert inside.sum() >= 1
        apex = heights[inside] + speeds[inside] ** 2 / (2.0 * G)
        np.testing.assert_allclose(apex, H0 * E ** (2 * k), rtol=rtol)
    before = times < impact_time(4)
    exact = np.array([exact_height(t) for t in times[before]])
    np.testing.assert_allclose(heights[before], exact, rtol=0, atol=rtol * H0)


@pytest.mark.parametrize("dt", [1e-2, 1e-3, 1e-4])
def test_rk4_bounces_as_the_closed_form(dt):
    check_exact(*run("rk4", dt, 1.25))


@pytest.mark.parametrize("dt", [1e-2, 1e-3, pytest.param(1e-4, marks=pytest.mark.slow)])  # 1e-4: 12,500 Python steps
def test_reference_bounces_as_the_closed_form(dt):
    check_exact(*run("reference", dt, 1.25))


@pytest.mark.parametrize("integrator", ["splitting", "symmetric_splitting", "implicit_gyroscopic",
                                        "exact_rotor_splitting"])
def test_splittings_are_exact_for_a_parabola_and_bounce_as_the_closed_form(integrator):
    check_exact(*run(integrator, 1e-2, 1.25))


@pytest.mark.parametrize("dt", [1e-2, 1e-3])
@pytest.mark.parametrize("integrator", list(INTEGRATORS))
def test_every_integrator_under_the_default_model_reduction_bounces_as_the_closed_form(integrator, dt):
    """Model reduction on (the Simulator's default): the ball is isotropic, so every method steps it
    with the exact translation flow and the impacts are located on that map. Impact times, speeds,
    apexes 1–3 and every sampled height within 1e-9 relative for all eight (seen: ~1e-14); none is
    left to converge."""
    sim = Simulator(scene(), integrator=integrator, dt=dt)
    assert sim.model_reduction
    check_exact(*run(integrator, dt, 1.25, reduction=True))


@pytest.mark.parametrize("integrator", ["euler", "semi_implicit_euler"])
def test_first_order_methods_converge_at_first_order_through_the_impacts(integrator):
    errors = []
    for dt in (1e-3, 1e-4):
        sim, *_ = run(integrator, dt, 1.0)
        impacts = sim.contact.events_of("ball", "impact")
        errors.append(max(abs(impacts[k - 1].time - impact_time(k)) for k in (1, 2)))
    order = math.log10(errors[0] / errors[1])
    assert 0.9 < order < 1.1, (errors, order)


@pytest.mark.parametrize("integrator, dt", [("rk4", 1e-2), ("rk4", 1e-3), ("reference", 1e-2)])
def test_comes_to_rest_at_the_accumulation_time(integrator, dt):
    sim, *_ = run(integrator, dt, 1.5)
    rest = sim.contact.events_of("ball", "rest")
    assert len(rest) == 1
    assert rest[0].time == pytest.approx(REST, abs=1e-6)
    assert sim.contact.is_resting("ball")
    energies = [(e.energy_before, e.energy_after) for e in sim.contact.events_of("ball", "impact")]
    assert all(after <= before for before, after in energies)


def test_stays_at_rest_for_100_s_and_an_imu_reads_g_up():
    sim = Simulator(scene(site=True), integrator="rk4", dt=1e-2, model_reduction=False)
    sim.step(int(round(1.5 / 1e-2)))
    assert sim.contact.is_resting("ball")
    for _ in range(int(round(100.0 / 1e-2))):
        sim.step()
        assert abs(sim.state.p_WC_W[0, 2] - R) <= 1e-12
        assert np.linalg.norm(sim.state.v_WC_W[0]) <= 1e-12
    readings = sim.site_readings()
    assert readings.specific_force[0] == pytest.approx([0.0, 0.0, G], abs=1e-12)
    assert len(sim.contact.events_of("ball", "lift-off")) == 0


@pytest.mark.parametrize("asleep", [False, True])
@pytest.mark.parametrize("how", ["impulse", "set_body_state"])
@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_resting_ball_struck_into_the_ground_bounces_by_its_restitution(integrator, how, asleep):
    """A ball (and, 1 m away, another) at rest on the ground, struck down at 2 m/s (an impulse of 2 N·s, or its
    velocity set): the ground's impact law acts at once, e = 0.5: it leaves at 1 m/s, then flies (closed form)."""
    dt, v0 = 1e-2, 2.0
    bodies = {name: {"mass": 1.0, "inertia": {"sphere": R}, "material": {"restitution": E, "friction": 0.3},
                     "pose": {"position": [x, 0.0, R]}} for name, x in (("ball", 0.0), ("other", 1.0))}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "bodies": bodies,
                                "ground": [{"normal": [0, 0, 1], "offset": 0.0,
                                            "material": {"restitution": E, "friction": 0.3}}]}),
                    integrator=integrator, dt=dt)
    sim.contact.sleeping = asleep
    sim.step(3)
    assert sim.contact.is_resting("ball") and sim.contact.pairs.islands.asleep[0] == asleep
    if how == "impulse":
        sim.apply_impulse("ball", linear=[0.0, 0.0, -v0])
    else:
        sim.set_body_state("ball", linear_velocity_world=[0.0, 0.0, -v0])
    t0 = sim.time
    sim.step()
    impacts = sim.contact.events_of("ball", "impact")
    assert len(impacts) == 1
    assert impacts[0].time == t0
    assert impacts[0].normal_speed_before == pytest.approx(-v0, rel=1e-12)
    assert impacts[0].normal_speed_after == pytest.approx(E * v0, rel=1e-12)
    assert impacts[0].energy_after == pytest.approx(E**2 * impacts[0].energy_before, rel=1e-12)
    v, z = sim.state.v_WC_W[0], sim.state.p_WC_W[0, 2]
    assert v[2] == pytest.approx(E * v0 - G * dt, rel=1e-12)  # exact for a constant force, either method
    assert v[0] == v[1] == 0.0
    if integrator == "rk4":  # the parabola, exactly; semi-implicit Euler's own position step is first order
        assert z == pytest.approx(R + E * v0 * dt - 0.5 * G * dt * dt, rel=1e-12)
    assert z > R
    assert not sim.contact.is_resting("ball")
    assert sim.state.p_WC_W[1, 2] == R and not sim.contact.events_of("other", "impact")


def test_tilted_frictionless_ground_bounces_along_its_normal_and_rests_sliding():
    theta = math.radians(20.0)
    n = (0.0, -math.sin(theta), math.cos(theta))
    data = {"gravity": [0.0, 0.0, -G],
            "ground": [{"normal": list(n), "offset": 0.0, "material": {"restitution": E, "friction": 0.0}}],
            "bodies": {"ball": {"mass": 1.0, "inertia": {"sphere": R},
                                "material": {"restitution": E, "friction": 0.0},
                                "pose": {"position": [(H0 + R) * c for c in n]}}}}
    sim = Simulator(load_scene(data), integrator="rk4", dt=1e-3, model_reduction=False)
    g_n = G * math.cos(theta)  # the normal motion is a bounce under g cos θ
    t1 = math.sqrt(2.0 * H0 / g_n)
    v1 = g_n * t1
    sim.step(int(round(2.5 * t1 * (1 + E) / (1 - E) / 1e-3)))
    impacts = sim.contact.events_of("ball", "impact")
    for k, event in enumerate(impacts[:3], start=1):
        expected = t1 + sum(2.0 * E**j * v1 / g_n for j in range(1, k))
        assert event.time == pytest.approx(expected, rel=1e-9)
    rest = sim.contact.events_of("ball", "rest")
    assert rest[0].time == pytest.approx(t1 * (1 + E) / (1 - E), abs=1e-6)
    # at rest on a frictionless incline: it slides down at g sin θ, on the plane
    p = sim.state.p_WC_W[0]
    assert float(np.dot(p, n)) - R == pytest.approx(0.0, abs=1e-12)
    v = sim.state.v_WC_W[0]
    assert abs(float(np.dot(v, n))) <= 1e-12
    t_rest, t_now = rest[0].time, sim.time
    # along the slope: the velocity at rest (from the last impacts' tangential motion) plus g sin θ (t − t_rest)
    down = np.cross(np.cross(n, [0.0, 0.0, -1.0]), n)
    down /= np.linalg.norm(down)
    assert float(np.dot(v, down)) == pytest.approx(G * math.sin(theta) * t_now, rel=1e-9)
    assert t_now > t_rest


def test_collision_none_falls_through():
    data = {"gravity": [0.0, 0.0, -G], "ground": [{"normal": [0, 0, 1]}],
            "bodies": {"ghost": {"mass": 1.0, "inertia": {"sphere": R}, "collision": "none",
                                 "pose": {"position": [0.0, 0.0, 0.5]}}}}
    sim = Simulator(load_scene(data), integrator="rk4", dt=1e-2)
    sim.step(100)
    assert sim.state.p_WC_W[0, 2] == pytest.approx(0.5 - 0.5 * G * 1.0, rel=1e-12)
    assert sim.contact is None  # nothing can touch the ground: the simulator runs without contact
