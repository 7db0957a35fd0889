"""Ground contact through the node's ROS interface, against closed forms.

The dropped ball (config/contact_bouncing_ball.yaml: r = 0.1 m, lowest point at h = 1 m,
e = max(0.5, 0.5), g = 9.81), paused and stepped tick by tick through ``~/step`` by a peer:
impacts at t1 = √(2h/g), t_{k+1} = t_k + 2 e^k v1 / g (v1 = √(2gh)), the centre's height the
parabolas z(t) = r + e^k v1 (t − t_k) − g (t − t_k)²/2 between them, at rest (r) from the
accumulation time t1 (1 + e)/(1 − e). rk4 integrates a parabola exactly, so the only error is
round-off and the event location: 1e-9 is asked. ``contacts`` must carry every impact at its
time, with the impulse m (1 + e) e^{k−1} v1; /diagnostics its counts. An ideal IMU on a box
resting on the ground (config/contact_resting_box_imu.yaml) reads the specific force +g up; a
``set_state`` that puts the ball into the ground is refused (``into_ground``) and changes nothing.
A recording of the ball carries ``contacts`` and Foxglove's readers decode it.
A box spawned onto a two-box stack through ``~/spawn`` comes to rest on it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile
from sensor_msgs.msg import Imu, PointCloud2, PointField

from rigid_body_sim.core.contact.solver import ZENO_APEX
from rigid_body_sim.ros.diagnostics import status_values
from rigid_body_sim.testing import SimHarness

pytestmark = pytest.mark.ros

CONFIG = Path(__file__).resolve().parents[1] / "config"
BALL = CONFIG / "contact_bouncing_ball.yaml"
BOX = CONFIG / "contact_resting_box_imu.yaml"
G, E, R, H, M = 9.81, 0.5, 0.1, 1.0, 1.0
T1 = math.sqrt(2.0 * H / G)
V1 = math.sqrt(2.0 * G * H)
REST = T1 * (1.0 + E) / (1.0 - E)
TICK = 0.01  # rate_hz 100, substeps 1, real_time_factor 1
PARAMETERS = {"integrator": "rk4", "rate_hz": 100.0, "substeps": 1, "real_time_factor": 1.0,
              "diagnostics_period": 0.0}  # no timer: one /diagnostics window over the whole test
#: The impacts t_k before the Zeno guard: the last is the first whose rebound e^k v1 would rise
#: less than ZENO_APEX (e^k v1)²/(2g) (the solver's documented constant, 1e-10 m).
IMPACTS = [T1]
while (E ** len(IMPACTS) * V1) ** 2 / (2.0 * G) >= ZENO_APEX:
    IMPACTS.append(IMPACTS[-1] + 2.0 * E ** len(IMPACTS) * V1 / G)

_NUMPY = {PointField.FLOAT64: "<f8", PointField.UINT32: "<u4", PointField.UINT8: "u1"}


def centre_height(t: float) -> float:
    """Closed form z(t) of the ball's centre."""
    if t <= T1:
        return R + H - 0.5 * G * t * t
    if t >= REST:
        return R
    k = max(k for k, tk in enumerate(IMPACTS, start=1) if tk <= t)
    s = t - IMPACTS[k - 1]
    return R + E**k * V1 * s - 0.5 * G * s * s


def cloud_points(msg: PointCloud2) -> np.ndarray:
    """The points of a PointCloud2, read from its own ``fields`` (as any consumer would)."""
    dtype = np.dtype({"names": [f.name for f in msg.fields], "formats": [_NUMPY[f.datatype] for f in msg.fields],
                      "offsets": [f.offset for f in msg.fields], "itemsize": msg.point_step})
    assert not msg.is_bigendian and msg.height == 1 and msg.row_step == msg.point_step * msg.width
    return np.frombuffer(bytes(msg.data), dtype=dtype, count=msg.width)


def collect(h: SimHarness, topic: str, msg_type: type) -> list:
    got: list = []
    h.client.create_subscription(msg_type, topic, got.append, QoSProfile(depth=1000))
    h.spin_until(lambda: h.node.count_subscribers(topic) > 0, f"the node's {topic} publisher to match")
    return got


def contact_status(h: SimHarness) -> dict[str, str]:
    statuses = [s for s in h.node.diagnostics().status if s.name.endswith(": contact")]
    assert len(statuses) == 1
    return status_values(statuses[0])


def set_state(h: SimHarness, publisher, z: float) -> None:
    msg = Odometry()
    msg.header.frame_id, msg.child_frame_id = "world", "world"
    msg.pose.pose.position.z = z
    msg.pose.pose.orientation.w = 1.0
    publisher.publish(msg)


def test_dropped_ball_poses_and_contacts_through_the_node_match_the_closed_form() -> None:
    ticks = int(round(1.5 / TICK))
    with SimHarness(BALL, PARAMETERS) as h:
        clouds = collect(h, "/contacts", PointCloud2)
        heights = []
        for k in range(1, ticks + 1):
            h.step(1)
            heights.append(h.latest_pose("ball").pose.position.z)
            h.spin_until(lambda: len(clouds) >= k, f"contacts of tick {k}")
        status = contact_status(h)
    # poses: the piecewise parabolas, and at rest on the ground after the accumulation time
    errors = [abs(z - centre_height(k * TICK)) for k, z in enumerate(heights, start=1)]
    assert max(errors) < 1e-9, max(errors)
    # contacts: every impact, at its closed-form time, with its impulse; then the rest event
    assert [c.header.frame_id for c in clouds] == ["world"] * ticks
    points = np.concatenate([cloud_points(c) for c in clouds])
    assert set(points["body"].tolist()) == {0} and set(points["ground"].tolist()) == {0}
    impacts = points[points["state"] == 0]
    assert len(impacts) == len(IMPACTS)
    np.testing.assert_allclose(impacts["time"], IMPACTS, rtol=0, atol=1e-9)
    np.testing.assert_allclose(impacts["impulse"], [M * (1 + E) * E**k * V1 for k in range(len(IMPACTS))],
                               rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(impacts["energy_change"],
                               [-0.5 * M * (1 - E**2) * (E**k * V1) ** 2 for k in range(len(IMPACTS))],
                               rtol=1e-9, atol=1e-12)
    for name, value in (("x", 0.0), ("y", 0.0), ("z", 0.0), ("nx", 0.0), ("ny", 0.0), ("nz", 1.0)):
        np.testing.assert_allclose(impacts[name], value, rtol=0, atol=1e-9)
    rests = points[points["state"] == 3]
    assert len(rests) == 1
    assert abs(rests["time"][0] - REST) < 1e-9
    # each impact is in the message of the tick that contains it
    for cloud_index, cloud in enumerate(clouds):
        for t in cloud_points(cloud)[cloud_points(cloud)["state"] == 0]["time"]:
            assert cloud_index * TICK - 1e-12 < t <= (cloud_index + 1) * TICK + 1e-12
    # resting after: one point per tick at the contact, gap 0, held by m g along the normal
    settled = [cloud_points(c) for k, c in enumerate(clouds, start=1) if (k - 1) * TICK > REST + TICK]
    assert settled and all(len(p) == 1 and p["state"][0] == 1 for p in settled)
    resting = np.concatenate(settled)
    np.testing.assert_allclose(resting["normal_force"], M * G, rtol=1e-9)
    np.testing.assert_allclose(resting["friction_force"], 0.0, atol=1e-9)
    np.testing.assert_allclose(resting["gap"], 0.0, atol=1e-9)
    np.testing.assert_allclose(resting["z"], 0.0, atol=1e-9)
    # /diagnostics: the counts of the window (all of it)
    assert int(status["impacts (window)"]) == len(IMPACTS)
    assert int(status["events (window)"]) == len(IMPACTS) + 1
    assert int(status["Zeno guards (window)"]) == 1
    assert int(status["contacts (resting bodies)"]) == 1
    assert float(status["largest gap violation [m] (window)"]) < 1e-9
    energy = -sum(0.5 * M * (1 - E**2) * (E**k * V1) ** 2 for k in range(len(IMPACTS)))
    assert abs(float(status["energy change at impacts [J] (window)"]) - energy) < 1e-9


def test_imu_on_a_resting_box_reads_g_up() -> None:
    with SimHarness(BOX, PARAMETERS) as h:
        imus = collect(h, "crate/top/imu", Imu)
        clouds = collect(h, "/contacts", PointCloud2)
        h.step(20)
        h.spin_until(lambda: len(imus) >= 20 and len(clouds) >= 20, "20 IMU samples and contacts")
        z = h.latest_pose("crate").pose.position.z
    assert abs(z - 0.1) < 1e-9
    for imu in imus:
        a, w = imu.linear_acceleration, imu.angular_velocity
        np.testing.assert_allclose([a.x, a.y, a.z], [0.0, 0.0, G], rtol=0, atol=1e-9)
        np.testing.assert_allclose([w.x, w.y, w.z], 0.0, atol=1e-9)
    for cloud in clouds[1:]:
        points = cloud_points(cloud)
        assert len(points) == 1 and points["state"][0] == 1
        assert abs(points["normal_force"][0] - 2.0 * G) < 1e-9 and abs(points["friction_force"][0]) < 1e-9


def test_set_state_into_the_ground_is_refused_with_a_reason() -> None:
    with SimHarness(BALL, PARAMETERS) as h:
        publisher = h.client.create_publisher(Odometry, "ball/set_state", QoSProfile(depth=10))
        h.spin_until(lambda: publisher.get_subscription_count() > 0, "the node's ball/set_state subscription")
        set_state(h, publisher, 0.05)  # r = 0.1: 5 cm into the ground
        h.spin_until(lambda: h.node.rejected.get("into_ground", 0) == 1, "the into_ground rejection")
        h.step(1)
        z = h.latest_pose("ball").pose.position.z
        assert abs(z - centre_height(TICK)) < 1e-9  # unchanged: still the free fall from 1.1 m
        inputs = [s for s in h.node.diagnostics().status if s.name.endswith(": input")][0]
        assert status_values(inputs)["rejected into_ground (total)"] == "1"
        set_state(h, publisher, R)  # touching: allowed
        h.spin_until(lambda: h.node.accepted_messages == 2, "the second set_state")
        h.step(1)
        assert h.node.rejected.get("into_ground", 0) == 1
        assert abs(h.latest_pose("ball").pose.position.z - R) < 1e-9  # resting on the ground from there


def test_set_state_into_a_static_shape_is_refused_naming_it() -> None:
    """The check the set_state above goes through (contacts.into_ground) covers the static world:
    a static body's shape as well as the half-spaces."""
    from rigid_body_sim.core import Simulator, load_scene
    from rigid_body_sim.ros.contacts import into_ground

    sim = Simulator(load_scene(CONFIG / "contact_static_table.yaml"), "rk4", TICK)
    top, level = 0.5, [0.0, 0.0, 0.0, 1.0]  # the table's top face z = 0.5 m
    refusal = into_ground(sim, "ball", [0.0, 0.0, top + R - 0.02], level)
    assert refusal is not None and refusal.reason == "into_ground"
    assert "'ball' would reach 0.02 m into static body 'table'" in refusal.detail
    assert into_ground(sim, "ball", [0.0, 0.0, top + R], level) is None  # touching: allowed
    assert into_ground(sim, "ball", [3.0, 0.0, R + 0.01], level) is None  # over the floor, beside the table


def test_recording_carries_contacts_and_foxglove_decodes_them(tmp_path: Path) -> None:
    import base64

    from foxglove_support import (by_topic, check_everything_decodes, check_schema_text, foxglove_decode,
                                       graph_qos, recorded_qos, stamp_ns)

    out = tmp_path / "ball.mcap"
    ticks = 50  # past the first impact, t1 = 0.4515 s
    with SimHarness(BALL, {**PARAMETERS, "record_path": str(out)}) as h:
        h.step(ticks)
        live = graph_qos(h.client, "/contacts")
    result = foxglove_decode(out)
    check_everything_decodes(result, finished=True)
    check_schema_text(out)
    assert recorded_qos(result, "/contacts") == live
    clouds = by_topic(result, "/contacts")
    assert len(clouds) == ticks
    impacts = []
    for k, (log_ns, cloud) in enumerate(clouds, start=1):
        assert log_ns == stamp_ns(cloud["header"]) == round(k * TICK * 1e9)
        fields = cloud["fields"]
        dtype = np.dtype({"names": [f["name"] for f in fields], "formats": [_NUMPY[f["datatype"]] for f in fields],
                          "offsets": [f["offset"] for f in fields], "itemsize": cloud["point_step"]})
        points = np.frombuffer(base64.b64decode(cloud["data"]["base64"]), dtype=dtype, count=cloud["width"])
        impacts += points[points["state"] == 0].tolist()
    assert len(impacts) == 1
    impact = dict(zip(dtype.names, impacts[0]))
    assert abs(impact["time"] - T1) < 1e-9
    assert abs(impact["impulse"] - M * (1 + E) * V1) < 1e-9


def test_sliding_box_friction_and_stick_through_the_node() -> None:
    """config/contact_sliding_box.yaml: a cube (1 kg) launched at v0 = 2 m/s along x on the ground,
    μ = 0.5 (the body has no material: the ground's): x(t) = v0 t − μ g t²/2 until it sticks at
    t_s = v0/(μ g), there x_s = v0²/(2 μ g); meanwhile held by m g along the normal and μ m g of friction."""
    mu, v0, m = 0.5, 2.0, 1.0
    t_stop = v0 / (mu * G)
    ticks = 50
    with SimHarness(CONFIG / "contact_sliding_box.yaml", PARAMETERS) as h:
        clouds = collect(h, "/contacts", PointCloud2)
        xs = []
        for k in range(1, ticks + 1):
            h.step(1)
            xs.append(h.latest_pose("crate").pose.position.x)
            h.spin_until(lambda: len(clouds) >= k, f"contacts of tick {k}")
    for k, x in enumerate(xs, start=1):
        t = min(k * TICK, t_stop)
        assert abs(x - (v0 * t - 0.5 * mu * G * t * t)) < 1e-9, (k, x)
    points = [cloud_points(c) for c in clouds]
    sticks = np.concatenate([p[p["state"] == 4] for p in points])
    assert len(sticks) == 1 and abs(sticks["time"][0] - t_stop) < 1e-9
    sliding = np.concatenate([p[p["state"] == 2] for k, p in enumerate(points, start=1) if k * TICK < t_stop])
    assert len(sliding) == int(t_stop / TICK)
    np.testing.assert_allclose(sliding["normal_force"], m * G, rtol=1e-9)
    np.testing.assert_allclose(sliding["friction_force"], mu * m * G, rtol=1e-9)
    np.testing.assert_allclose(sliding["gap"], 0.0, atol=1e-9)
    stuck = np.concatenate([p[p["state"] == 1] for k, p in enumerate(points, start=1) if (k - 1) * TICK > t_stop])
    assert len(stuck) and np.all(np.abs(stuck["friction_force"]) < 1e-9)


def test_no_contacts_without_ground() -> None:
    """The default scene has no ground: nothing is published on ``contacts``, no contact status."""
    with SimHarness(None, PARAMETERS) as h:
        clouds = collect(h, "/contacts", PointCloud2)
        h.step(3)
        h.spin_for(0.2)
        assert clouds == []
        assert not [s for s in h.node.diagnostics().status if s.name.endswith(": contact")]


def test_contacts_start_afresh_after_reset() -> None:
    """~/reset puts the ball back at t = 0: the first impact is reported again at t1 (and only once)."""
    with SimHarness(BALL, PARAMETERS) as h:
        clouds = collect(h, "/contacts", PointCloud2)
        h.step(50)
        h.spin_until(lambda: len(clouds) >= 50, "50 contacts")
        assert h.reset().success
        h.step(50)
        h.spin_until(lambda: len(clouds) >= 100, "50 more contacts")
    for part in (clouds[:50], clouds[50:]):
        points = np.concatenate([cloud_points(c) for c in part])
        impacts = points[points["state"] == 0]
        assert len(impacts) == 1 and abs(impacts["time"][0] - T1) < 1e-9


TWO_BALLS = """\
# two balls flying at each other in free fall (the same fall for both: their relative motion is a
# straight line), e = max(0.8, 0.8); b (2 kg) 0.6 m from a (1 kg) along x, closing at 3 m/s
gravity: [0.0, 0.0, -9.81]
ground: []
bodies:
  a: {mass: 1.0, inertia: {sphere: 0.1}, material: {restitution: 0.8, friction: 0.0},
      pose: {position: [0.0, 0.0, 5.0]}, twist: {linear: [1.0, 0.0, 0.0]}}
  b: {mass: 2.0, inertia: {sphere: 0.1}, material: {restitution: 0.8, friction: 0.0},
      pose: {position: [0.6, 0.0, 5.0]}, twist: {linear: [-2.0, 0.0, 0.0]}}
"""


def test_contacts_name_both_bodies_of_a_body_body_impact(tmp_path: Path) -> None:
    """Two balls meet in flight: ``contacts`` has one point per body, each naming the other (``other``),
    ``ground`` NO_INDEX, at the closed-form time (0.6 − 0.2)/3 s with the normal impulse
    (1 + e) m_a m_b/(m_a + m_b) × 3 m/s and the normal from the other body towards each."""
    scene = tmp_path / "two_balls.yaml"
    scene.write_text(TWO_BALLS)
    ticks = 20
    with SimHarness(scene, PARAMETERS) as h:
        clouds = collect(h, "/contacts", PointCloud2)
        for k in range(1, ticks + 1):
            h.step(1)
            h.spin_until(lambda: len(clouds) >= k, f"contacts of tick {k}")
        status = contact_status(h)
    points = np.concatenate([cloud_points(c) for c in clouds])
    impacts = points[points["state"] == 0]
    assert sorted(zip(impacts["body"].tolist(), impacts["other"].tolist())) == [(0, 1), (1, 0)]
    assert set(impacts["ground"].tolist()) == {0xFFFFFFFF}
    t_hit = (0.6 - 0.2) / 3.0
    np.testing.assert_allclose(impacts["time"], t_hit, rtol=1e-9)
    np.testing.assert_allclose(impacts["impulse"], 1.8 * (2.0 / 3.0) * 3.0, rtol=1e-9)
    for row in impacts:
        sign = 1.0 if row["body"] == 1 else -1.0  # from a to b on b's point, from b to a on a's
        np.testing.assert_allclose([row["nx"], row["ny"], row["nz"]], [sign, 0.0, 0.0], atol=1e-9)
        np.testing.assert_allclose([row["x"], row["y"]], [1.0 * t_hit + 0.1, 0.0], atol=1e-9)
    assert int(status["impacts (window)"]) == 1


STACK = """\
# two 0.2 m boxes stacked exactly on the ground, at rest (e = 0, μ = 0.5 everywhere)
gravity: [0.0, 0.0, -9.81]
ground:
  - {normal: [0, 0, 1], offset: 0.0, material: {restitution: 0.0, friction: 0.5}}
bodies:
  bottom: {mass: 1.0, inertia: {box: [0.2, 0.2, 0.2]}, material: {restitution: 0.0, friction: 0.5},
           pose: {position: [0.0, 0.0, 0.1]}}
  middle: {mass: 1.0, inertia: {box: [0.2, 0.2, 0.2]}, material: {restitution: 0.0, friction: 0.5},
           pose: {position: [0.0, 0.0, 0.3]}}
"""
CRATE = """\
mass: 2.0
inertia: {box: [0.2, 0.2, 0.2]}
material: {restitution: 0.0, friction: 0.5}
pose: {position: [0.0, 0.0, 0.55]}
"""


def test_a_box_spawned_onto_a_stack_rests_on_it(tmp_path: Path) -> None:
    """``~/spawn`` puts a crate 5 cm above a two-box stack: it falls and lands (e = 0), then rests
    on the stack (an island): its centre at 0.5 m (the stack's top + half its edge) and
    every speed zero to round-off, the stack where it stood."""
    scene = tmp_path / "stack.yaml"
    scene.write_text(STACK)
    with SimHarness(scene, PARAMETERS) as h:
        result = h.spawn(crate=CRATE)
        assert result.successful, result.reason
        h.watch_body("crate")
        h.step(100)  # 1 s: the crate lands after √(2 × 0.05 / g) = 0.101 s
        h.wait_for_latest_state()
        poses = {b: h.latest_pose(b).pose for b in ("bottom", "middle", "crate")}
        twists = {b: h.latest_twist(b) for b in ("bottom", "middle", "crate")}
    for body, z in (("bottom", 0.1), ("middle", 0.3), ("crate", 0.5)):
        p, q = poses[body].position, poses[body].orientation
        np.testing.assert_allclose([p.x, p.y, p.z], [0.0, 0.0, z], atol=1e-9)
        np.testing.assert_allclose([q.x, q.y, q.z, q.w], [0.0, 0.0, 0.0, 1.0], atol=1e-9)
        t = twists[body]
        assert max(abs(v) for v in (t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y,
                                    t.angular.z)) <= 1e-9, (body, t)


def test_contacts_list_an_islands_pairs_with_the_weight_they_carry(tmp_path: Path) -> None:
    """The crate spawned onto the two-box stack, after 1 s at rest: ``contacts`` has one point per
    side of each island pair, naming both bodies, the normal from ``other`` towards ``body``:
    crate on middle and middle under crate carry the crate's weight (2 kg × g), middle on bottom
    and bottom under middle 3 kg × g, the ground under bottom 4 kg × g; no friction, resting, no
    persistent row besides (every body is in the island). 1e-9 relative: the sticking solve is exact
    to round-off. /diagnostics counts the island points in the points published."""
    scene = tmp_path / "stack.yaml"
    scene.write_text(STACK)
    with SimHarness(scene, PARAMETERS) as h:
        assert h.spawn(crate=CRATE).successful
        h.watch_body("crate")
        clouds = collect(h, "/contacts", PointCloud2)
        h.step(100)
        h.spin_until(lambda: len(clouds) >= 100, "100 contacts")
        status = contact_status(h)
    bottom, middle, crate, none = 0, 1, 2, 0xFFFFFFFF
    points = cloud_points(clouds[-1])
    got = {(int(p["body"]), int(p["other"]), int(p["ground"])): p for p in points}
    assert len(got) == len(points) == 5
    for body, other, ground, mass, nz in ((crate, middle, none, 2.0, 1.0), (middle, crate, none, 2.0, -1.0),
                                          (middle, bottom, none, 3.0, 1.0), (bottom, middle, none, 3.0, -1.0),
                                          (bottom, none, 0, 4.0, 1.0)):
        p = got[(body, other, ground)]
        assert p["state"] == 1 and p["time"] == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose([p["nx"], p["ny"], p["nz"]], [0.0, 0.0, nz], atol=1e-12)
        assert p["normal_force"] == pytest.approx(mass * G, rel=1e-9)
        assert abs(p["friction_force"]) <= 1e-9 * mass * G
        assert abs(p["gap"]) <= 1e-12
    assert int(status["island contact points published (window)"]) >= 5 * 90  # resting from ~0.2 s on
    assert int(status["contact points published (window)"]) >= int(status["island contact points published (window)"])
    assert int(status["bodies in islands"]) == 3


def test_sleeping_locks_a_resting_stack_and_turning_it_off_wakes_it(tmp_path: Path) -> None:
    """With the ``sleeping`` parameter on, the two-box stack (at rest on the ground: an island) is locked from
    its first tick: /diagnostics counts both boxes asleep. Set to false over ROS, both wake (none asleep) and
    step again; the stack stands where it was placed to round-off throughout (its rest is exact)."""
    scene = tmp_path / "stack.yaml"
    scene.write_text(STACK)
    with SimHarness(scene, {**PARAMETERS, "sleeping": True}) as h:
        h.step(10)
        asleep = int(contact_status(h)["bodies asleep"])
        steps = h.node.session.simulator.contact.counts["island_body_steps"]
        assert all(r.successful for r in h.set_parameters(sleeping=False))
        h.step(10)
        awake = int(contact_status(h)["bodies asleep"])
        stepped = h.node.session.simulator.contact.counts["island_body_steps"] - steps
        h.wait_for_latest_state()
        poses = {b: h.latest_pose(b).pose.position for b in ("bottom", "middle")}
    assert asleep == 2 and awake == 0
    assert stepped == 2 * 10  # both boxes, every step since
    for body, z in (("bottom", 0.1), ("middle", 0.3)):
        np.testing.assert_allclose([poses[body].x, poses[body].y, poses[body].z], [0.0, 0.0, z], atol=1e-12)


def test_a_crate_asleep_alone_on_the_ground_is_listed_resting_with_its_weight(tmp_path: Path) -> None:
    """With ``sleeping`` on, a 2 kg crate resting alone on the ground 2 m from the two-box stack falls asleep with
    it: /diagnostics counts three bodies asleep, two in islands and one resting; ``contacts`` still lists the
    crate resting on the ground (ground 0, no other body) with its weight along the normal over each tick, and
    its pose stays where it was placed."""
    scene = tmp_path / "stack.yaml"
    scene.write_text(STACK + """\
  crate: {mass: 2.0, inertia: {box: [0.2, 0.2, 0.2]}, material: {restitution: 0.0, friction: 0.5},
          pose: {position: [2.0, 0.0, 0.1]}}
""")
    with SimHarness(scene, {**PARAMETERS, "sleeping": True}) as h:
        h.watch_body("crate")
        clouds = collect(h, "/contacts", PointCloud2)
        h.step(20)
        h.spin_until(lambda: len(clouds) >= 20, "20 contacts")
        status = contact_status(h)
        assert h.node.session.simulator.contact.pairs.islands.asleep.all()
        h.wait_for_latest_state()
        pose = h.latest_pose("crate").pose.position
    assert int(status["bodies asleep"]) == 3 and int(status["bodies in islands"]) == 2
    assert int(status["contacts (resting bodies)"]) == 1
    crate, none = 2, 0xFFFFFFFF
    for cloud in clouds[-5:]:
        rows = [p for p in cloud_points(cloud) if int(p["body"]) == crate]
        assert len(rows) == 1
        p = rows[0]
        assert int(p["ground"]) == 0 and int(p["other"]) == none and p["state"] == 1
        assert p["normal_force"] == pytest.approx(2.0 * G, rel=1e-9)
        assert abs(p["friction_force"]) <= 1e-9 * 2.0 * G
    np.testing.assert_allclose([pose.x, pose.y, pose.z], [2.0, 0.0, 0.1], atol=1e-12)


def test_the_contact_settings_go_on_after_a_spawn(tmp_path: Path) -> None:
    """``sleeping`` on, ``sleep_speed`` raised to 1 mm/s and ``penetration_tolerance`` to 10 µm, a crate spawned
    5 cm above the two-box stack (the spawn makes a new simulator: all three carry over): it lands, comes to rest,
    and within 1 s all three bodies are asleep."""
    scene = tmp_path / "stack.yaml"
    scene.write_text(STACK)
    settings = {**PARAMETERS, "sleeping": True, "sleep_speed": 1e-3, "penetration_tolerance": 1e-5}
    with SimHarness(scene, settings) as h:
        assert h.spawn(crate=CRATE).successful
        h.watch_body("crate")
        h.step(100)
        assert int(contact_status(h)["bodies asleep"]) == 3
        assert h.node.session.simulator.contact.sleep_speed == 1e-3
        assert h.node.session.simulator.contact.penetration_tolerance == 1e-5


PUSHED = """\
# a cube (1 kg, 0.2 m) 5 cm behind the centre of one resting on the ground, pushed along x by 6 N at
# its centre of mass (μ = 0.5 everywhere: it slides on the lower cube, which sticks)
gravity: [0.0, 0.0, -9.81]
ground:
  - {normal: [0, 0, 1], offset: 0.0, material: {restitution: 0.0, friction: 0.5}}
bodies:
  low: {mass: 1.0, inertia: {box: [0.2, 0.2, 0.2]}, material: {restitution: 0.0, friction: 0.5},
        pose: {position: [0.0, 0.0, 0.1]}}
  top: {mass: 1.0, inertia: {box: [0.2, 0.2, 0.2]}, material: {restitution: 0.0, friction: 0.5},
        pose: {position: [-0.05, 0.0, 0.3]}}
wrenches:
  - {body: top, frame: top/world_aligned, force: [6.0, 0.0, 0.0], torque: [0.0, 0.0, 0.0], start: 0.0}
"""


def test_contacts_of_a_box_sliding_on_a_box_carry_mu_times_its_weight(tmp_path: Path) -> None:
    """The pushed cube slides on the lower one (F = 6 N > μ m g): every tick (4 steps, the mean over
    them), the pair's two points are sliding with m g along the normal and μ m g of friction; the
    ground holds the lower cube (resting) with 2 m g and μ m g of friction. Closed forms, 1e-9
    relative; 20 ticks (0.2 s: the top's centre stays behind x = 5 cm, where it would tip)."""
    scene = tmp_path / "pushed.yaml"
    scene.write_text(PUSHED)
    mu, m, ticks = 0.5, 1.0, 20
    with SimHarness(scene, {**PARAMETERS, "substeps": 4}) as h:
        clouds = collect(h, "/contacts", PointCloud2)
        for k in range(1, ticks + 1):
            h.step(1)
            h.spin_until(lambda: len(clouds) >= k, f"contacts of tick {k}")
    low, top, none = 0, 1, 0xFFFFFFFF
    for cloud in clouds:
        points = cloud_points(cloud)
        points = points[np.isin(points["state"], (1, 2))]  # contacts (the first tick has the rest events of t = 0)
        got = {(int(p["body"]), int(p["other"]), int(p["ground"])): p for p in points}
        assert len(got) == len(points) and set(got) == {(top, low, none), (low, top, none), (low, none, 0)}
        for key, normal, friction, state in (((top, low, none), m * G, mu * m * G, 2),
                                             ((low, top, none), m * G, mu * m * G, 2),
                                             ((low, none, 0), 2 * m * G, mu * m * G, 1)):
            p = got[key]
            assert p["state"] == state, key
            assert p["normal_force"] == pytest.approx(normal, rel=1e-9), key
            assert p["friction_force"] == pytest.approx(friction, rel=1e-9), key
