"""The node's contact outputs besides ``contacts``: ``B/contact_wrench``, contact markers, /diagnostics counts.

Against closed forms (g = 9.81), through the node stepped with ``~/step`` while paused (rk4,
100 Hz, one step a tick):

* The dropped ball (config/contact_bouncing_ball.yaml: m = 1 kg, h = 1 m, e = 0.5): its mean
  contact wrench over a tick is 0 in flight, m (1 + e) v1 / Δt up in the tick holding the first
  impact (v1 = √(2gh)), and m g up with no torque once at rest.
* The sliding cube (config/contact_sliding_box.yaml: 1 kg, v0 = 2 m/s, μ = 0.5): while it slides
  the ground pushes m g up and μ m g against the motion, and the torque about its centre of mass
  is zero (it does not turn: the normal forces shift forward to balance friction's moment); once
  stuck, m g up and nothing else.
* A ball launched sliding without spin (μ = 0.3): friction's torque μ m g R about its centre until it
  rolls at t = 2 v0 / (7 μ g), then none.
* The resting box (config/contact_resting_box_imu.yaml, 0.4 × 0.3 × 0.2 m, 2 kg): ``markers`` shows
  its four bottom corners and an arrow of m g × marker_force_scale up from their centre.
* An IMU at the dropped ball's centre reads the first impact as (1 + e) v1 / Δt over its sample.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import WrenchStamped
from rclpy.qos import QoSProfile

from rigid_body_sim.core.contact.solver import ZENO_APEX
from rigid_body_sim.ros.diagnostics import status_values
from rigid_body_sim.testing import SimHarness

pytestmark = pytest.mark.ros

CONFIG = Path(__file__).resolve().parents[1] / "config"
G, TICK = 9.81, 0.01
PARAMETERS = {"integrator": "rk4", "rate_hz": 100.0, "substeps": 1, "real_time_factor": 1.0,
              "diagnostics_period": 0.0, "publish_contact_wrench": True}


def collect(h: SimHarness, topic: str, msg_type: type) -> list:
    got: list = []
    h.client.create_subscription(msg_type, topic, got.append, QoSProfile(depth=1000))
    h.spin_until(lambda: h.node.count_subscribers(topic) > 0, f"the node's {topic} publisher to match")
    return got


def force_torque(msg: WrenchStamped) -> np.ndarray:
    f, t = msg.wrench.force, msg.wrench.torque
    return np.array([f.x, f.y, f.z, t.x, t.y, t.z])


def contact_status(h: SimHarness) -> dict[str, str]:
    statuses = [s for s in h.node.diagnostics().status if s.name.endswith(": contact")]
    assert len(statuses) == 1
    return status_values(statuses[0])


def test_contact_wrench_and_diagnostics_of_the_dropped_ball() -> None:
    e, m, h0 = 0.5, 1.0, 1.0
    t1, v1 = math.sqrt(2.0 * h0 / G), math.sqrt(2.0 * G * h0)
    rest = t1 * (1.0 + e) / (1.0 - e)
    impacts = [t1]  # the impacts before the Zeno guard (test_contact_node.py says why)
    while (e ** len(impacts) * v1) ** 2 / (2.0 * G) >= ZENO_APEX:
        impacts.append(impacts[-1] + 2.0 * e ** len(impacts) * v1 / G)
    ticks = int(round(1.6 / TICK))
    with SimHarness(CONFIG / "contact_bouncing_ball.yaml", PARAMETERS) as h:
        wrenches = collect(h, "ball/contact_wrench", WrenchStamped)
        for _ in range(ticks // 20):
            h.step(20)
        h.spin_until(lambda: len(wrenches) >= ticks, f"{ticks} contact wrenches")
        status = contact_status(h)
    assert [w.header.frame_id for w in wrenches] == ["ball/world_aligned"] * ticks
    assert [w.header.stamp.sec * 10**9 + w.header.stamp.nanosec for w in wrenches] == \
        [round(k * TICK * 1e9) for k in range(1, ticks + 1)]
    first = int(math.ceil(t1 / TICK))  # 1-based tick holding the first impact
    second = int(math.ceil(impacts[1] / TICK))
    for k, msg in enumerate(wrenches, start=1):
        wrench = force_torque(msg)
        if k == first:
            np.testing.assert_allclose(wrench, [0, 0, m * (1 + e) * v1 / TICK, 0, 0, 0], rtol=1e-9, atol=1e-9)
        elif k < second or (k - 1) * TICK > rest + TICK:  # in flight before the 2nd impact, or resting
            np.testing.assert_allclose(wrench, [0, 0, m * G if k > second else 0.0, 0, 0, 0], rtol=0, atol=1e-9)
    # /diagnostics: the most events in one tick (impacts, and the Zeno guard's rest with the last of them)
    per_tick: dict[int, int] = {}
    for t in impacts:
        per_tick[int(math.ceil(t / TICK - 1e-9))] = per_tick.get(int(math.ceil(t / TICK - 1e-9)), 0) + 1
    per_tick[int(math.ceil(impacts[-1] / TICK - 1e-9))] += 1
    assert int(status["most events in one tick (window)"]) == max(per_tick.values())
    assert int(status["multi-contact impacts with e > 0, model-dependent (total)"]) == 0
    assert int(status["impacts with restitution capped (total)"]) == 0
    assert int(status["impacts on a second half-space while resting (total)"]) == 0
    assert int(status["steps of a resting body projected out of a wall it went into, first order (total)"]) == 0


def test_contact_wrench_of_a_sliding_box_has_friction_and_no_torque() -> None:
    mu, v0, m = 0.5, 2.0, 1.0
    t_stop = v0 / (mu * G)
    ticks = 60
    with SimHarness(CONFIG / "contact_sliding_box.yaml", PARAMETERS) as h:
        wrenches = collect(h, "crate/contact_wrench", WrenchStamped)
        h.step(ticks)
        h.spin_until(lambda: len(wrenches) >= ticks, f"{ticks} contact wrenches")
    sliding = np.array([force_torque(w) for k, w in enumerate(wrenches, start=1) if k * TICK < t_stop])
    stuck = np.array([force_torque(w) for k, w in enumerate(wrenches, start=1) if (k - 1) * TICK > t_stop])
    assert len(sliding) == int(t_stop / TICK) and len(stuck) > 10
    np.testing.assert_allclose(sliding, np.tile([-mu * m * G, 0, m * G, 0, 0, 0], (len(sliding), 1)),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(stuck, np.tile([0, 0, m * G, 0, 0, 0], (len(stuck), 1)), rtol=0, atol=1e-9)


def test_contact_wrench_of_a_ball_launched_sliding_turns_it_until_it_rolls(tmp_path: Path) -> None:
    """A solid ball (r = 0.1 m, 1 kg) launched at v0 = 2 m/s without spin, μ = 0.3: friction μ m g at the
    contact point, r = (0, 0, −R) from the centre, gives the torque r × F = (0, μ m g R, 0) until it rolls
    at t = 2 v0 / (7 μ g); then no friction and no torque."""
    mu, v0, m, r = 0.3, 2.0, 1.0, 0.1
    t_roll = 2.0 * v0 / (7.0 * mu * G)
    scene = tmp_path / "rolling.yaml"
    scene.write_text(f"""gravity: [0.0, 0.0, -9.81]
ground:
  - {{normal: [0, 0, 1], offset: 0.0, material: {{restitution: 0.0, friction: {mu}}}}}
bodies:
  ball:
    mass: {m}
    inertia: {{sphere: {r}}}
    pose: {{position: [0.0, 0.0, {r}]}}
    twist: {{linear: [{v0}, 0.0, 0.0]}}
""")
    ticks = 40
    with SimHarness(scene, PARAMETERS) as h:
        wrenches = collect(h, "ball/contact_wrench", WrenchStamped)
        h.step(ticks)
        h.spin_until(lambda: len(wrenches) >= ticks, f"{ticks} contact wrenches")
    sliding = np.array([force_torque(w) for k, w in enumerate(wrenches, start=1) if k * TICK < t_roll])
    rolling = np.array([force_torque(w) for k, w in enumerate(wrenches, start=1) if (k - 1) * TICK > t_roll])
    assert len(sliding) == int(t_roll / TICK) and len(rolling) > 10
    np.testing.assert_allclose(sliding, np.tile([-mu * m * G, 0, m * G, 0, mu * m * G * r, 0], (len(sliding), 1)),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(rolling, np.tile([0, 0, m * G, 0, 0, 0], (len(rolling), 1)), rtol=0, atol=1e-9)


def test_contact_wrench_is_off_by_default_and_follows_the_parameter() -> None:
    with SimHarness(CONFIG / "contact_resting_box_imu.yaml", {**PARAMETERS, "publish_contact_wrench": False}) as h:
        h.step(2)
        assert h.node.count_publishers("crate/contact_wrench") == 0
        assert all(r.successful for r in h.set_parameters(publish_contact_wrench=True))
        h.step(1)  # the first tick after the change creates the publisher (it started before: nothing sent)
        wrenches = collect(h, "crate/contact_wrench", WrenchStamped)
        h.step(3)
        h.spin_until(lambda: len(wrenches) >= 3, "3 contact wrenches")
        for msg in wrenches:
            np.testing.assert_allclose(force_torque(msg), [0, 0, 2.0 * G, 0, 0, 0], rtol=0, atol=1e-9)
        assert all(r.successful for r in h.set_parameters(publish_contact_wrench=False))
        h.step(1)
        assert h.node.count_publishers("crate/contact_wrench") == 0


def test_markers_show_the_contact_points_and_the_holding_force() -> None:
    from visualization_msgs.msg import Marker, MarkerArray

    scale = 0.05
    with SimHarness(CONFIG / "contact_resting_box_imu.yaml",
                    {**PARAMETERS, "marker_rate_hz": 100.0, "marker_force_scale": scale}) as h:
        arrays = collect(h, "markers", MarkerArray)
        h.step(3)
        h.spin_until(lambda: len(arrays) >= 1, "a MarkerArray")
        array = arrays[-1]
    contact = sorted((m for m in array.markers if m.ns == "crate/contact"), key=lambda m: m.id)
    spheres = [m for m in contact if m.type == Marker.SPHERE]
    arrows = [m for m in contact if m.type == Marker.ARROW]
    assert len(spheres) == 4 and len(arrows) == 1 and len(contact) == 5
    corners = sorted(tuple(round(v, 9) for v in (m.pose.position.x, m.pose.position.y, m.pose.position.z))
                     for m in spheres)
    assert corners == sorted((x, y, 0.0) for x in (-0.2, 0.2) for y in (-0.15, 0.15))
    start, tip = arrows[0].points
    np.testing.assert_allclose([start.x, start.y, start.z], [0.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose([tip.x, tip.y, tip.z], [0.0, 0.0, scale * 2.0 * G], atol=1e-9)


STACK = """gravity: [0.0, 0.0, -9.81]
ground:
  - {normal: [0, 0, 1], offset: 0.0, material: {restitution: 0.0, friction: 0.5}}
bodies:
  base:
    {mass: 3.0, inertia: {box: [0.4, 0.4, 0.2]}, collision: {box: [0.4, 0.4, 0.2]},
     material: {restitution: 0.0, friction: 0.5}, pose: {position: [0.0, 0.0, 0.1]}}
  crate:
    {mass: 2.0, inertia: {box: [0.2, 0.2, 0.2]}, collision: {box: [0.2, 0.2, 0.2]},
     material: {restitution: 0.0, friction: 0.5}, pose: {position: [0.05, 0.0, 0.3]}}
"""


def test_a_stack_s_contact_wrench_and_markers_carry_the_bodies_it_rests_on(tmp_path: Path) -> None:
    """A 2 kg crate resting off-centre on a 3 kg base on the ground (an island): each at rest, so its mean
    contact wrench over a tick balances its weight: m g up and no torque about its centre of mass (the
    base's: the ground's (m_b + m_c) g, shifted towards the crate, less the crate's weight); ``markers`` shows the crate's four bottom corners and the base's eight
    (the crate's and the ground's), with arrows of those forces × marker_force_scale."""
    from visualization_msgs.msg import Marker, MarkerArray

    scene = tmp_path / "stack.yaml"
    scene.write_text(STACK)
    scale, mb, mc = 0.05, 3.0, 2.0
    with SimHarness(scene, {**PARAMETERS, "marker_rate_hz": 100.0, "marker_force_scale": scale}) as h:
        arrays = collect(h, "markers", MarkerArray)
        crate = collect(h, "crate/contact_wrench", WrenchStamped)
        base = collect(h, "base/contact_wrench", WrenchStamped)
        h.step(4)
        h.spin_until(lambda: len(arrays) >= 4 and len(crate) >= 3 and len(base) >= 3, "markers and wrenches")
        assert h.node.session.simulator.contact.in_island("crate")
        array = arrays[-1]
    for msg in crate[-3:]:
        np.testing.assert_allclose(force_torque(msg), [0, 0, mc * G, 0, 0, 0], rtol=0, atol=1e-9)
    for msg in base[-3:]:
        np.testing.assert_allclose(force_torque(msg), [0, 0, mb * G, 0, 0, 0], rtol=0, atol=1e-9)
    for body, count, force in (("crate", 4, mc * G), ("base", 8, mb * G)):
        contact = sorted((m for m in array.markers if m.ns == f"{body}/contact"), key=lambda m: m.id)
        spheres = [m for m in contact if m.type == Marker.SPHERE]
        arrows = [m for m in contact if m.type == Marker.ARROW]
        assert len(spheres) == count and len(arrows) == 1
        start, tip = arrows[0].points
        np.testing.assert_allclose([tip.x - start.x, tip.y - start.y, tip.z - start.z],
                                   [0.0, 0.0, scale * force], atol=1e-9)
    top = sorted(tuple(round(v, 9) for v in (m.pose.position.x, m.pose.position.y, m.pose.position.z))
                 for m in array.markers if m.ns == "crate/contact" and m.type == Marker.SPHERE)
    assert top == sorted((x, y, 0.2) for x in (-0.05, 0.15) for y in (-0.1, 0.1))


def test_an_imu_reads_the_impact_as_the_velocity_jump_over_its_sample(tmp_path: Path) -> None:
    """The dropped ball with an ideal IMU at its centre (world axes), sampled every tick through the node:
    0 in free fall, (1 + e) v1 / Δt up in the tick holding the first impact, 0 again in flight after it."""
    from sensor_msgs.msg import Imu

    e, h0 = 0.5, 1.0
    t1, v1 = math.sqrt(2.0 * h0 / G), math.sqrt(2.0 * G * h0)
    scene = tmp_path / "ball_imu.yaml"
    scene.write_text((CONFIG / "contact_bouncing_ball.yaml").read_text()
                     + "    sites:\n      centre: {position: [0.0, 0.0, 0.0], axes: world, imu: {}}\n")
    first = int(math.ceil(t1 / TICK))
    with SimHarness(scene, PARAMETERS) as h:
        imus = collect(h, "ball/centre/imu", Imu)
        h.step(first + 3)
        h.spin_until(lambda: len(imus) >= first + 3, f"{first + 3} IMU samples")
    for k, imu in enumerate(imus[:first + 3], start=1):
        a = imu.linear_acceleration
        expected = (1.0 + e) * v1 / TICK if k == first else 0.0
        np.testing.assert_allclose([a.x, a.y, a.z], [0.0, 0.0, expected], rtol=1e-9, atol=1e-9)
