"""The shared input topics ``wrench``, ``impulse`` and ``set_state`` over DDS (SimHarness).

One subscription each for all bodies, keyed by the message's frame: ``header.frame_id`` ``B``,
``B/world_aligned`` or ``B/<site>`` (with ``frame_prefix`` in front) for a wrench or impulse,
``child_frame_id`` ``B`` for a set_state. They go through the per-body topics' parser and
validator, so the same input gives bitwise the same motion; the world frame names no body and is
refused on the shared wrench. ``per_body_inputs`` decides whether ``B/wrench``, ``B/impulse``
and ``B/set_state`` exist too ("auto": as ``per_body_topics``).
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile

from rigid_body_sim.ros.diagnostics import status_values
from rigid_body_sim.testing import SimHarness

TICK_S = 0.01  # the default 100 Hz, 1 substep

#: Two free bodies without gravity, one with a site; spinning, so body axes differ from world axes.
BODIES = {
    "box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]},
            "pose": {"position": [0.0, 0.0, 1.0], "orientation": [0.1, 0.2, 0.3, 0.9273618495495703]},
            "twist": {"linear": [0.1, 0.0, 0.0], "angular": [0.2, 0.1, 0.5]},
            "sites": {"corner": {"position": [0.5, 0.3, 0.0]},
                      "nozzle": {"position": [-0.5, 0.0, 0.2], "axes": "world"}}},
    "crate": {"mass": 3.0, "inertia": {"box": [0.5, 0.8, 1.2]},
              "pose": {"position": [2.0, -1.0, 0.0]},
              "twist": {"linear": [0.0, 0.2, 0.0], "angular": [-0.4, 0.3, 0.2]}},
    "ball": {"mass": 2.0, "inertia": {"sphere": 0.5}, "pose": {"position": [1.0, 2.0, 3.0]}},
}

#: (topic, body, frame kind, force, torque): every frame kind a shared input may name (body, world-aligned,
#: a site with body axes, a site with world axes; the world frame names no body and is refused).
INPUTS = [
    ("wrench", "box", "box/corner", (0.0, 10.0, 0.0), (0.0, 0.0, 0.0)),
    ("wrench", "box", "box/nozzle", (0.0, 0.0, 3.0), (0.1, 0.0, 0.0)),
    ("wrench", "crate", "crate/world_aligned", (1.0, 0.0, -2.0), (0.0, 0.3, 0.0)),
    ("wrench", "crate", "crate", (0.0, 0.0, 4.0), (0.5, 0.0, 0.0)),
    ("impulse", "box", "box", (0.2, 0.0, 0.1), (0.0, 0.05, 0.0)),
    ("impulse", "ball", "ball/world_aligned", (0.0, -0.4, 0.0), (0.1, 0.0, 0.0)),
    ("impulse", "box", "box/nozzle", (0.0, 0.1, 0.0), (0.0, 0.0, 0.02)),
    ("impulse", "box", "box/corner", (0.05, 0.0, 0.0), (0.0, 0.0, 0.0)),
]


def write_scene(tmp_path, bodies: dict) -> str:
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump({"bodies": bodies, "gravity": [0.0, 0.0, 0.0]}))
    return str(path)


def wrench(frame_id: str, force, torque) -> WrenchStamped:
    msg = WrenchStamped()
    msg.header.frame_id = frame_id
    msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = (float(v) for v in force)
    msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z = (float(v) for v in torque)
    return msg


def odometry(frame_id: str, child: str, position, orientation_xyzw=(0.0, 0.0, 0.0, 1.0),
             linear=(0.0, 0.0, 0.0), angular=(0.0, 0.0, 0.0)) -> Odometry:
    msg = Odometry()
    msg.header.frame_id, msg.child_frame_id = frame_id, child
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    p.x, p.y, p.z = (float(v) for v in position)
    o.x, o.y, o.z, o.w = (float(v) for v in orientation_xyzw)
    v, w = msg.twist.twist.linear, msg.twist.twist.angular
    v.x, v.y, v.z = (float(x) for x in linear)
    w.x, w.y, w.z = (float(x) for x in angular)
    return msg


def publisher(h: SimHarness, msg_type: type, topic: str, depth: int = 100):
    """A client publisher on ``topic``, once the node's subscription has matched it."""
    pub = h.client.create_publisher(msg_type, topic, QoSProfile(depth=depth))
    h.spin_until(lambda: pub.get_subscription_count() > 0, f"the node's {topic} subscription")
    return pub


def send(h: SimHarness, pub, msg) -> None:
    """Publish and wait until the node has taken the message (accepted or rejected)."""
    seen = h.messages_seen()
    pub.publish(msg)
    h.spin_until(lambda: h.messages_seen() > seen, f"the node to take the message on {pub.topic_name}")


def states(h: SimHarness) -> np.ndarray:
    with h.node.locked_simulator() as sim:
        return np.concatenate([sim.positions_world().ravel(), sim.orientations_xyzw().ravel(),
                               sim.linear_velocities_world().ravel(), sim.angular_velocities_world().ravel()])


def input_subscriptions(h: SimHarness) -> list[str]:
    """The topics of the node's wrench, impulse and set_state subscriptions."""
    return sorted(s.topic_name for s in h.node.subscriptions
                  if s.topic_name.rsplit("/", 1)[-1] in ("wrench", "impulse", "set_state"))


@pytest.mark.parametrize(("prefix", "timeout"), [("", 0.0), ("sim1/", 0.0), ("", 0.03)])
def test_shared_topics_move_bodies_bitwise_as_the_per_body_topics(tmp_path, prefix: str, timeout: float) -> None:
    """The same wrenches (site, world-aligned and body frames) and impulses, on B/wrench and
    B/impulse in one node and on the shared wrench and impulse in another (no per-body inputs),
    give the same holds and, after 5 ticks, bitwise the same states of all bodies (and not the
    states without inputs). Published and read over DDS; the prefixed frame ids with frame_prefix;
    with a wrench_timeout of 3 ticks the holds end after 3 of the 5 ticks in both."""
    scene = write_scene(tmp_path, BODIES)
    results = {}
    for per_body in ("true", "false"):
        params = {"integrator": "rk4", "wrench_timeout": timeout, "frame_prefix": prefix,
                  "per_body_inputs": per_body}
        with SimHarness(scene, params) as h:
            assert h.per_body_inputs is (per_body == "true")
            start = states(h)
            for topic, body, frame, force, torque in INPUTS:
                getattr(h, f"publish_{topic}")(body, force, torque, frame_id=prefix + frame)
            assert sum(h.node.rejected.values()) == 0 and h.node.accepted_messages == len(INPUTS)
            holds = h.node.held_wrenches
            h.step(5)
            assert (h.node.held_wrenches == {}) is (timeout > 0.0)
            results[per_body] = (holds, states(h), [(h.latest_pose(b), h.latest_twist(b)) for b in BODIES])
            subscriptions = input_subscriptions(h)
        if per_body == "false":
            assert subscriptions == ["/impulse", "/set_state", "/wrench"]
        else:
            assert len(subscriptions) == 3 + 3 * len(BODIES)
    (holds_a, after_a, msgs_a), (holds_b, after_b, msgs_b) = results["true"], results["false"]
    assert set(holds_a) == set(holds_b) == {("box", "box/corner"), ("box", "box/nozzle"),
                                            ("crate", "crate/world_aligned"), ("crate", "crate")}
    for key in holds_a:
        np.testing.assert_array_equal(holds_a[key][0], holds_b[key][0])
        np.testing.assert_array_equal(holds_a[key][1], holds_b[key][1])
    np.testing.assert_array_equal(after_a, after_b)
    assert msgs_a == msgs_b  # the published poses and twists too (message equality is field by field)
    assert not np.array_equal(after_a, start)


@pytest.mark.parametrize("frame", ["ball", "ball/world_aligned"])
def test_constant_force_on_the_shared_topic_matches_the_closed_form(tmp_path, frame: str) -> None:
    """A ball at rest without gravity (a sphere: no spin, so its body axes stay the world's) held
    by F on the shared wrench, batched node (per_body_topics false: no per-body inputs by
    default): x = x0 + F t²/(2m) and v = F t/m after 10 ticks (RK4 is exact for the quadratic)."""
    scene = write_scene(tmp_path, {"ball": BODIES["ball"], "box": BODIES["box"]})
    force, m, x0 = np.array([3.0, -1.5, 0.75]), 2.0, np.array([1.0, 2.0, 3.0])
    with SimHarness(scene, {"integrator": "rk4", "wrench_timeout": 0.0, "per_body_topics": False}) as h:
        assert not h.per_body_inputs and h.node.count_subscribers("ball/wrench") == 0
        h.publish_wrench("ball", force, frame_id=frame)
        h.step(10)
        t = 10 * TICK_S
        pose, twist = h.latest_pose("ball").pose, h.latest_twist("ball")
        position = np.array([pose.position.x, pose.position.y, pose.position.z])
        velocity = np.array([twist.linear.x, twist.linear.y, twist.linear.z])
        np.testing.assert_allclose(position, x0 + force * t**2 / (2 * m), rtol=0, atol=1e-12)
        np.testing.assert_allclose(velocity, force * t / m, rtol=0, atol=1e-12)


def test_bad_input_on_the_shared_topics_is_counted_and_dropped(tmp_path) -> None:
    """Non-finite and too-large wrenches, frames of no body, and the world frame (which names no
    body) on the shared wrench and impulse; set_states naming no body (or the world) or non-finite
    on the shared set_state: each counted by reason (on /diagnostics too) and dropped; nothing
    held, the state after a tick is that without inputs."""
    scene = write_scene(tmp_path, BODIES)
    bad_wrenches = [
        ("non_finite", "wrench", wrench("box", (float("nan"), 0.0, 0.0), (0.0, 0.0, 0.0))),
        ("non_finite", "impulse", wrench("box/corner", (0.0, 0.0, 0.0), (0.0, float("inf"), 0.0))),
        ("too_large", "wrench", wrench("crate", (1e300, 0.0, 0.0), (0.0, 0.0, 0.0))),
        ("unknown_frame", "wrench", wrench("world", (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))),
        ("unknown_frame", "impulse", wrench("world", (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))),
        ("unknown_frame", "wrench", wrench("ghost", (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))),
        ("unknown_frame", "wrench", wrench("box/nowhere", (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))),
        ("unknown_frame", "wrench", wrench("sim1/box", (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))),  # no frame_prefix here
    ]
    bad_states = [
        ("unknown_frame", odometry("world", "world", [0.0, 0.0, 0.0])),
        ("unknown_frame", odometry("world", "ghost", [0.0, 0.0, 0.0])),
        ("unknown_frame", odometry("map", "ball", [0.0, 0.0, 0.0])),
        ("non_finite", odometry("world", "ball", [float("nan"), 0.0, 0.0])),
    ]
    with SimHarness(scene, {"integrator": "rk4", "per_body_topics": False}) as reference:
        reference.step(1)
        expected = states(reference)
    with SimHarness(scene, {"integrator": "rk4", "per_body_topics": False}) as h:
        pubs = {topic: publisher(h, WrenchStamped, topic) for topic in ("wrench", "impulse")}
        pubs["set_state"] = publisher(h, Odometry, "set_state")
        h.node.diagnostics()  # opens a new window
        for _reason, topic, msg in bad_wrenches:
            send(h, pubs[topic], msg)
        for _reason, msg in bad_states:
            send(h, pubs["set_state"], msg)
        assert h.node.accepted_messages == 0
        assert h.node.held_wrenches == {} and h.node.pending_impulses == {}
        everything = [reason for reason, *_ in bad_wrenches + bad_states]
        assert h.node.rejected == {reason: everything.count(reason) for reason in set(everything)}
        report = {s.name: status_values(s) for s in h.node.diagnostics().status}["rigid_body_sim: input"]
        for reason in set(everything):
            assert report[f"rejected {reason} (window)"] == str(everything.count(reason))
        h.step(1)
        np.testing.assert_array_equal(states(h), expected)


@pytest.mark.parametrize("prefix", ["", "sim1/"])
def test_set_state_on_the_shared_topic_moves_the_named_body(tmp_path, prefix: str) -> None:
    """A set_state on the shared topic whose child_frame_id is (prefixed) ``ball`` puts ball there,
    with its twist in ball's axes; the other bodies are bitwise those of a node without it; one
    on B/set_state of a per-body node gives bitwise the same state."""
    scene = write_scene(tmp_path, BODIES)
    p0, v = [4.0, -1.0, 0.5], [0.5, 0.0, -0.25]
    q0 = [0.0, 0.0, np.sin(0.3), np.cos(0.3)]
    results = {}
    for per_body in ("true", "false"):
        params = {"integrator": "rk4", "frame_prefix": prefix, "per_body_inputs": per_body}
        with SimHarness(scene, params) as h:
            untouched = states(h)
            topic = "ball/set_state" if per_body == "true" else "set_state"
            send(h, publisher(h, Odometry, topic), odometry(prefix + "world", prefix + "ball", p0, q0, v))
            h.spin_until(lambda: h.latest_pose("ball").pose.position.x == p0[0], "the set state on ball/pose")
            with h.node.locked_simulator() as sim:
                assert sim.time == 0.0
                np.testing.assert_allclose(sim.body_state("ball").position_world, p0, rtol=0, atol=1e-15)
                others = [b for b in sim.body_names if b != "ball"]
                for body in others:
                    k = sim.body_names.index(body)
                    np.testing.assert_array_equal(sim.positions_world()[k], untouched[3 * k: 3 * k + 3])
            h.step(2)
            results[per_body] = states(h)
    np.testing.assert_array_equal(results["true"], results["false"])


@pytest.mark.parametrize("many", [1000, pytest.param(10_000, marks=pytest.mark.slow)])
def test_many_batched_bodies_have_no_per_body_subscription(tmp_path, many: int) -> None:
    """per_body_topics false with 1000 bodies (10,000 in test-slow): the node's subscriptions and publishers are the
    same few as with one body (the shared inputs, the batches; nothing per body), a shared wrench reaches the last body, and a
    burst of 1000 wrenches for 1000 bodies, published without waiting, is held whole (the shared
    queue is SHARED_QUEUE_DEPTH deep, not the per-body queues' 10)."""
    bodies = {f"b{k}": {"mass": 1.0, "inertia": {"sphere": 0.5}, "pose": {"position": [float(k), 0.0, 0.0]}}
              for k in range(many)}
    counts = {}
    for n in (1, many):
        scene = tmp_path / f"free_{n}.yaml"
        scene.write_text(yaml.safe_dump({"bodies": dict(list(bodies.items())[:n]), "gravity": [0.0, 0.0, 0.0]}))
        with SimHarness(scene, {"per_body_topics": False, "wrench_timeout": 0.0}, timeout=120.0) as h:
            counts[n] = (sorted(s.topic_name for s in h.node.subscriptions),
                         sorted(p.topic_name for p in h.node.publishers))
            assert input_subscriptions(h) == ["/impulse", "/set_state", "/wrench"]
            last = f"b{n - 1}"
            h.publish_wrench(last, (1.0, 0.0, 0.0))
            assert set(h.node.held_wrenches) == {(last, last)}
            if n == many:
                burst = publisher(h, WrenchStamped, "wrench", depth=1000)  # the whole burst kept until taken
                seen = h.messages_seen()
                for k in range(1000):
                    burst.publish(wrench(f"b{k}/world_aligned", (0.0, 1.0, 0.0), (0.0, 0.0, 0.0)))
                h.spin_until(lambda: h.messages_seen() >= seen + 1000, "the burst", timeout=60.0)
                assert h.messages_seen() == seen + 1000 and sum(h.node.rejected.values()) == 0
                assert len(h.node.held_wrenches) == 1001
    assert counts[many] == counts[1]


def test_spawned_bodies_are_reachable_on_the_shared_topics_and_deleted_ones_not(tmp_path) -> None:
    """A body spawned after start-up takes a shared wrench in its frames (held, it moves the body);
    once it is deleted, its frame is unknown on the shared topics (counted, dropped)."""
    scene = write_scene(tmp_path, {"box": BODIES["box"]})
    with SimHarness(scene, {"integrator": "rk4", "per_body_topics": False, "wrench_timeout": 0.0}) as h:
        assert h.spawn(ball=yaml.safe_dump(BODIES["ball"])).successful
        h.watch_body("ball")
        h.publish_wrench("ball", (0.0, 0.0, 4.0), frame_id="ball/world_aligned")
        assert set(h.node.held_wrenches) == {("ball", "ball/world_aligned")}
        h.step(1)
        assert h.latest_pose("ball").pose.position.z > BODIES["ball"]["pose"]["position"][2]
        assert h.delete("ball").successful
        assert h.node.held_wrenches == {}
        rejected = h.node.rejected.get("unknown_frame", 0)
        h.publish_wrench("ball", (0.0, 0.0, 4.0), frame_id="ball")
        assert h.node.rejected.get("unknown_frame", 0) == rejected + 1 and h.node.held_wrenches == {}
