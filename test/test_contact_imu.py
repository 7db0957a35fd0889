"""IMUs feel contact, against closed forms (core and the node's IMU sampler, core/imu.py ImuBank).

A ball (r = 0.1 m, m = 1 kg) dropped with its lowest point at h = 1 m onto the ground, e = 0.5,
g = 9.81: the first impact at t1 = √(2h/g) turns the velocity −v1 = −√(2gh) into +e v1, and the
ball's rotation is untouched (a frictional impact of a sphere hit along its normal through its
centre has no tangential impulse). An ideal IMU samples once a tick of Δt: in flight it reads 0
(free fall), in the sample holding an impact it reads the site's velocity jump over the sample,
(1 + e) v1 / Δt up (world axes; in the body's axes that vector turned by the body's orientation),
and once at rest +g up. With a sample rate of half the tick rate, the jump is spread over that
sample's 2Δt. The readings, integrated, give the velocity change: Σ (f + g) Δt = v(T) − v(0).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_body_sim.core import Simulator
from rigid_body_sim.core.scene import load_scene_text
from rigid_body_sim.core.imu import ImuBank
from rigid_body_sim.core.quaternion import quat_conjugate, quat_rotate

G, E, R, H, M = 9.81, 0.5, 0.1, 1.0, 1.0
T1 = math.sqrt(2.0 * H / G)
V1 = math.sqrt(2.0 * G * H)
REST = T1 * (1.0 + E) / (1.0 - E)
TICK = 0.01
#: The ball's orientation: a quarter turn about x, (x, y, z, w); its body z axis points along world −y.
ORIENTATION_XYZW = (math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))

SCENE = f"""
gravity: [0.0, 0.0, -9.81]
ground:
  - {{normal: [0, 0, 1], offset: 0.0, material: {{restitution: 0.5, friction: 0.5}}}}
bodies:
  ball:
    mass: 1.0
    inertia: {{sphere: 0.1}}
    collision: {{sphere: 0.1}}
    pose: {{position: [0.0, 0.0, 1.1], orientation: [{", ".join(map(str, ORIENTATION_XYZW))}]}}
    sites:
      centre: {{position: [0.0, 0.0, 0.0], axes: world, imu: {{}}}}
      rim: {{position: [0.05, 0.02, -0.03], imu: {{}}}}
      slow: {{position: [0.0, 0.0, 0.0], axes: world, imu: {{rate: 50.0}}}}
"""


def run(ticks: int) -> list[list]:
    """Each tick's samples of the three IMUs, the ball stepped as the node does (rk4, one step a tick)."""
    sim = Simulator(load_scene_text(SCENE, "imu ball"), "rk4", TICK)
    bank = ImuBank(sim.scene.imus)
    samples = []
    for _ in range(ticks):
        sim.step(1)
        samples.append(bank.sample(sim, TICK))
    return samples


@pytest.fixture(scope="module")
def samples() -> list[list]:
    return run(int(round(1.6 / TICK)))


def test_free_fall_reads_zero_and_the_impact_reads_the_velocity_jump_over_the_sample(samples) -> None:
    impact_tick = int(math.ceil(T1 / TICK))  # the tick (1-based) whose interval holds t1
    jump = (1.0 + E) * V1
    q_WB = np.array([ORIENTATION_XYZW[3], *ORIENTATION_XYZW[:3]])  # (w, x, y, z)
    up_in_body = quat_rotate(quat_conjugate(q_WB), np.array([0.0, 0.0, 1.0]))  # world z in the body's axes B
    np.testing.assert_allclose(up_in_body, [0.0, 1.0, 0.0], atol=1e-15)
    for k, tick in enumerate(samples[:impact_tick + 5], start=1):
        centre = next(s for s in tick if s.site == "ball/centre")
        rim = next(s for s in tick if s.site == "ball/rim")
        expected = jump / TICK if k == impact_tick else 0.0
        np.testing.assert_allclose(centre.specific_force, [0.0, 0.0, expected], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(rim.specific_force, expected * up_in_body, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(rim.angular_velocity, 0.0, atol=1e-12)
    slow = [(k, s) for k, tick in enumerate(samples, start=1) for s in tick if s.site == "ball/slow"]
    assert [k for k, _ in slow[:30]] == list(range(1, 60, 2))  # 50 Hz: every other tick
    for k, s in slow:
        if k - 2 < T1 / TICK <= k:  # this sample's 2Δt holds the first impact
            np.testing.assert_allclose(s.specific_force, [0.0, 0.0, jump / (2 * TICK)], rtol=1e-9)
            break
        np.testing.assert_allclose(s.specific_force, 0.0, atol=1e-9)
    else:
        pytest.fail("no sample of the 50 Hz IMU holds the first impact")


def test_at_rest_the_imu_reads_g_up_and_the_readings_integrate_to_the_velocity_change(samples) -> None:
    centre = np.array([next(s for s in tick if s.site == "ball/centre").specific_force for tick in samples])
    resting = centre[int(REST / TICK) + 2:]
    assert len(resting) > 10
    np.testing.assert_allclose(resting, np.tile([0.0, 0.0, G], (len(resting), 1)), rtol=0, atol=1e-9)
    # Σ (f + g) Δt over the ticks up to t = 0.8 s (in flight between the first two impacts) is the
    # velocity change: v(t) − v(0) = e v1 − g (t − t1). Free fall reads 0 (a = −g), so the sum is
    # exact: the impact's jump is all in the readings.
    ticks = int(round(0.8 / TICK))
    change = ((centre[:ticks, 2] - G) * TICK).sum()
    assert abs(change - (E * V1 - G * (0.8 - T1))) < 1e-9


def test_an_off_centre_imu_on_a_spinning_ball_reads_the_jump_of_its_own_velocity() -> None:
    """The ball dropped spinning at ω = 10 rad/s about y (μ = √(0.3 · 0.5) on the pair, enough to stop the
    contact point slipping within the impact): the contact point moves at u = −ω R, the compression's
    tangential impulse P_t = −u m / (1 + m R² / I) = (2/7) m ω R brings it to rest, the normal impulse is
    m (1 + e) v1, so Δv = (P_t / m, 0, (1 + e) v1) and Δω_y = −R P_t / I. An IMU at r = R on the ball
    (world axes) sits at r_W = R (sin α, 0, cos α), α = ω t1, at the impact: its jump is
    Δv + Δω × r_W, read over the tick's Δt on top of the centripetal −ω² r_W of the spin."""
    omega, radius, inertia = 10.0, 0.1, 0.4 * M * 0.1**2
    scene = SCENE.replace("collision: {sphere: 0.1}\n", "collision: {sphere: 0.1}\n    material: {restitution: 0.5, friction: 0.3}\n"
                          f"    twist: {{angular: [0.0, {omega}, 0.0]}}\n")
    scene = scene.replace(f"orientation: [{', '.join(map(str, ORIENTATION_XYZW))}]", "orientation: [0, 0, 0, 1]")
    scene = scene.replace("rim: {position: [0.05, 0.02, -0.03], imu: {}}", "rim: {position: [0.0, 0.0, 0.1], axes: world, imu: {}}")
    sim = Simulator(load_scene_text(scene, "spinning ball"), "rk4", TICK)
    bank = ImuBank(sim.scene.imus)
    first = int(math.ceil(T1 / TICK))
    p_t = (2.0 / 7.0) * M * omega * radius
    omega_after = omega - radius * p_t / inertia
    alpha = omega * T1
    r_hit = radius * np.array([math.sin(alpha), 0.0, math.cos(alpha)])
    jump = np.array([p_t / M, 0.0, (1.0 + E) * V1]) + np.cross([0.0, omega_after - omega, 0.0], r_hit)
    for k in range(1, first + 4):
        sim.step(1)
        rim = next(s for s in bank.sample(sim, TICK) if s.site == "ball/rim")
        t = k * TICK
        w, angle = (omega, omega * t) if t < T1 else (omega_after, alpha + omega_after * (t - T1))
        expected = -w * w * radius * np.array([math.sin(angle), 0.0, math.cos(angle)])
        if k == first:
            expected = expected + jump / TICK
        np.testing.assert_allclose(rim.specific_force, expected, rtol=1e-9, atol=1e-9)
    assert abs(sim.body_state("ball").angular_velocity_world[1] - omega_after) < 1e-9
