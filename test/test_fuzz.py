"""Fuzzing the node's wrench and impulse subscriptions with hostile messages.

A seeded generator (``random.Random(seed)``: scalar draws, several times faster than numpy's here) makes rounds of WrenchStamped messages for
``B/wrench`` and ``B/impulse``: NaN (quiet, negative, signalling payloads), ±Inf, 1e300 and the
largest float, 1e12·(1 + ε), subnormals, signed zeros, all-zero, valid values; frame_ids that are
empty, unknown, case-changed, padded, another body's, 100 kB long, non-ASCII or bidirectional
control characters; raw CDR with invalid UTF-8 in frame_id, or cut short; topics of bodies
that do not exist; and header stamps at 0, at the int32 extremes (year 1901 and 2038) and with
nanosec = 2**32 − 1. Each message carries the outcome the generator expects, computed
independently of the node from the scene's frame list and the documented rule: the first of
``unknown_frame`` (frame_id not one of the body's frames), ``non_finite``, ``too_large``
(|component| > 1e12) fails; otherwise accepted.

Stamps: the node uses stamps for nothing (a hold is timed in sim time from receipt), so
"far in the past or future" means the int32 seconds extremes and an out-of-range nanosec. They
must be accepted and change nothing: the twin run sends every valid message with a zero stamp.

Run A sends everything. Most rounds go over DDS from the harness's client node (same private
context, real subscriptions: rmw take, deserialisation, the node's callbacks); some rounds go
straight into the node's subscription callbacks. Run B, the twin, feeds only the valid messages,
in the same order and between the same ticks, straight into a second node's callbacks. The
checks: no exception leaves the executor (it keeps spinning and serving ~/step), every pose,
twist and odometry message received is finite, ``node.rejected`` equals the generator's counts
by reason, and after every tick the poses and twists of run A equal run B's bitwise (float64
survives the messages unchanged, and the same messages in the same order give the same
arithmetic).
"""

from __future__ import annotations

import math
import random
import struct
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Iterator

import numpy as np
import pytest
import rclpy
import yaml
from geometry_msgs.msg import PoseStamped, Twist, WrenchStamped
from nav_msgs.msg import Odometry
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message

from rigid_body_sim.ros.diagnostics import REJECTION_REASONS, status_values
from rigid_body_sim.ros.node import RigidBodySimNode
from rigid_body_sim.testing import SimHarness

pytestmark = pytest.mark.ros

SCENE = {
    "bodies": {
        "box": {
            "mass": 2.0,
            "inertia": {"box": [1.0, 0.6, 0.4]},
            "pose": {"position": [0.0, 0.0, 1.0]},
            "twist": {"angular": [0.2, 0.1, 0.5]},
            "sites": {"corner": {"position": [0.5, 0.3, 0.0]}, "nozzle": {"position": [-0.5, 0.0, 0.2], "axes": "world"}},
        },
        "probe": {"mass": 0.5, "inertia": {"principal": [0.01, 0.02, 0.025]}, "sites": {"tip": {"position": [0.0, 0.0, 0.1]}}},
        # Receives valid but extreme values (±1e12): it may blow up and be stopped, in both runs alike.
        "crash": {"mass": 1.0, "inertia": {"sphere": 0.1}},
    }
}
#: The frames each body accepts, written out from the README's frame table (not asked of the node).
FRAMES = {
    "box": ("world", "box", "box/world_aligned", "box/corner", "box/nozzle"),
    "probe": ("world", "probe", "probe/world_aligned", "probe/tip"),
    "crash": ("world", "crash", "crash/world_aligned"),
}
BODIES = tuple(FRAMES)
GHOSTS = ("ghost", "box2")  # topics of bodies that do not exist: nobody subscribes
PARAMETERS = {"integrator": "rk4", "wrench_timeout": 0.05, "publish_odometry": True}
QUEUE_DEPTH = 10  # the node's subscription depth: a DDS round sends at most this many per topic

LONG_FRAME = "box/" + "x" * 100_000  # 100 kB
UNKNOWN_FRAMES = ("", "map", "base_link", "Box", "BOX/corner", "box/", "/box", "box ", " world", "world ",
                  "box/world_aligned/extra", "box//corner", "box/wheel", "probe/corner", "box/tip",
                  "wörld", "箱/corner", "🚀", "box/cornér", "world\u200b", "\u202eworld", "box\u0301")
QUIET_NAN = math.nan
NEGATIVE_NAN = -math.nan
SIGNALLING_NAN = struct.unpack("<d", struct.pack("<Q", 0x7FF0000000000001))[0]
PAYLOAD_NAN = struct.unpack("<d", struct.pack("<Q", 0xFFF8DEADBEEF0001))[0]
NANS = (QUIET_NAN, NEGATIVE_NAN, SIGNALLING_NAN, PAYLOAD_NAN)
INFS = (math.inf, -math.inf)
HUGE = (1e300, -1e300, 1.7976931348623157e308, -1.7976931348623157e308, math.nextafter(1e12, math.inf), -1e13, 2e12)
SUBNORMAL = (5e-324, -5e-324, 2.2250738585072009e-308, -1e-310, 0.0, -0.0)
EDGE_VALID = (1e12, -1e12, math.nextafter(1e12, 0.0), 9.999e11)
STAMPS = ((0, 0), (-2**31, 0), (2**31 - 1, 999_999_999), (2**31 - 1, 2**32 - 1), (-1, 2**32 - 1))
MAX_COMPONENT = 1e12


@dataclass
class Sent:
    """One generated message: where it goes, what it is, and what the node must do with it."""

    body: str
    topic: str  # "wrench" or "impulse"
    frame_id: str
    values: tuple[float, ...]  # force x, y, z, torque x, y, z
    stamp: tuple[int, int]  # sec, nanosec
    raw: bytes | None  # serialised CDR sent instead of a message, when set
    expected: str  # "accepted", a rejection reason, "no_subscriber" or "dropped_by_middleware"


@dataclass
class Round:
    path: str  # "dds" or "direct"
    messages: list[Sent] = field(default_factory=list)
    ticks: int = 0


def expected_outcome(body: str, frame_id: str, values: tuple[float, ...]) -> str:
    """The documented rule, applied without the node: frame, then non-finite, then too large."""
    if body not in FRAMES:
        return "no_subscriber"
    if frame_id not in FRAMES[body]:
        return "unknown_frame"
    if not all(math.isfinite(v) for v in values):
        return "non_finite"
    if any(abs(v) > MAX_COMPONENT for v in values):
        return "too_large"
    return "accepted"


KINDS = ("normal", "zero", "subnormal", "edge", "nan", "inf", "huge", "nan_huge")
KIND_WEIGHTS = (0.42, 0.06, 0.06, 0.04, 0.14, 0.10, 0.14, 0.04)
#: Standard deviations of valid values (force N or linear impulse N·s, torque N·m or N·m·s): small
#: enough that the ordinary bodies stay near the origin and slow, so world-frame moment arms and
#: |w|·dt stay small and they run to the end (a blow-up would freeze them and blunt the comparison).
SCALES = {"wrench": (0.05, 0.005), "impulse": (0.002, 0.0002)}


def _values(rng: random.Random, body: str, topic: str) -> tuple[float, ...]:
    """Six components (force xyz, torque xyz) of a kind chosen at random."""
    kind = rng.choices(KINDS, KIND_WEIGHTS)[0]
    scale_f, scale_t = SCALES[topic]
    v = [rng.gauss(0.0, scale_f) for _ in range(3)] + [rng.gauss(0.0, scale_t) for _ in range(3)]
    idx = rng.sample(range(6), rng.randint(1, 6))
    if kind == "zero":
        v = [rng.choice((0.0, -0.0)) for _ in range(6)]
    elif kind == "subnormal":
        v = [rng.choice(SUBNORMAL) for _ in range(6)]
    elif kind == "edge":
        if body == "crash":  # valid extremes only where a blow-up harms no other check
            for i in idx:
                v[i] = rng.choice(EDGE_VALID)
    elif kind in ("nan", "inf", "huge"):
        pool = {"nan": NANS, "inf": INFS, "huge": HUGE}[kind]
        for i in idx:
            v[i] = rng.choice(pool)
    elif kind == "nan_huge":
        v[idx[0]] = QUIET_NAN
        v[(idx[0] + 1) % 6] = 1e300
    return tuple(v)


def _frame(rng: random.Random, body: str) -> str:
    frames = FRAMES.get(body, FRAMES["box"])
    r = rng.random()
    if r < 0.68:
        return rng.choice(frames)
    if r < 0.685:
        return LONG_FRAME
    return rng.choice(UNKNOWN_FRAMES)


def _message(frame_id: str, values: tuple[float, ...], stamp: tuple[int, int],
             msg: WrenchStamped | None = None) -> WrenchStamped:
    """A WrenchStamped with these fields (``msg`` refilled when given: publishing serialises at
    once and the node copies the values out, so one object can carry many messages)."""
    msg = WrenchStamped() if msg is None else msg
    msg.header.frame_id = frame_id
    msg.header.stamp.sec, msg.header.stamp.nanosec = stamp
    f, t = msg.wrench.force, msg.wrench.torque
    f.x, f.y, f.z, t.x, t.y, t.z = values
    return msg


def _raw(rng: random.Random, body: str) -> tuple[bytes, str]:
    """Serialised CDR the Python API could not build: invalid UTF-8 in frame_id, or cut short."""
    template = _message("Zq", (1.0, 0.0, 0.0, 0.0, 0.0, 0.0), (0, 0))
    raw = serialize_message(template)
    if rng.random() < 0.6:
        # Same length, so the CDR stays well-formed; rclpy decodes with replacement characters.
        return raw.replace(b"Zq\x00", bytes([0xFF, 0xFE, 0x00]), 1), ("unknown_frame" if body in FRAMES else "no_subscriber")
    return raw[: rng.randint(4, len(raw) - 2)], ("dropped_by_middleware" if body in FRAMES else "no_subscriber")


def generate(seed: int, n_messages: int, direct_share: float) -> Iterator[Round]:
    """Rounds of messages and ticks; the same seed gives the same rounds."""
    rng = random.Random(seed)
    sent = 0
    while sent < n_messages:
        path = "direct" if rng.random() < direct_share else "dds"
        round_ = Round(path)
        per_topic: Counter[tuple[str, str]] = Counter()
        size = rng.randint(1, 400) if path == "direct" else rng.randint(1, 80)
        for _ in range(size):
            body = rng.choices(BODIES + GHOSTS, (0.42, 0.28, 0.24, 0.03, 0.03))[0]
            topic = "wrench" if rng.random() < 0.6 else "impulse"
            if path == "dds" and per_topic[(body, topic)] >= QUEUE_DEPTH:
                break
            per_topic[(body, topic)] += 1
            if path == "dds" and rng.random() < 0.02:
                raw, expected = _raw(rng, body)
                round_.messages.append(Sent(body, topic, "", (), (0, 0), raw, expected))
                continue
            frame_id = _frame(rng, body)
            values = _values(rng, body, topic)
            stamp = rng.choice(STAMPS) if rng.random() < 0.5 else (rng.randint(0, 10**6), 0)
            round_.messages.append(Sent(body, topic, frame_id, values, stamp, None,
                                        expected_outcome(body, frame_id, values)))
        sent += len(round_.messages)
        round_.ticks = rng.choice((0, 0, 0, 1, 2))
        yield round_


def _vec(v: Any) -> list[float]:
    return [v.x, v.y, v.z]


def published_arrays(pose: PoseStamped, twist: Twist) -> np.ndarray:
    """The 13 floats of a body's published state, in a fixed order."""
    p, q = pose.pose.position, pose.pose.orientation
    return np.array([p.x, p.y, p.z, q.x, q.y, q.z, q.w] + _vec(twist.linear) + _vec(twist.angular))


def node_arrays(node: RigidBodySimNode) -> dict[str, np.ndarray]:
    """What the node publishes for each running body right now (the same float64 values)."""
    sim = node.simulator
    p, q = sim.positions_world(), sim.orientations_xyzw()
    v, w = sim.linear_velocities_world(), sim.angular_velocities_world()
    return {b: np.concatenate([p[i], q[i], v[i], w[i]]) for i, b in enumerate(sim.body_names)
            if b not in sim.stopped_bodies}


def callbacks_of(node: RigidBodySimNode) -> dict[tuple[str, str], Any]:
    """The node's own subscription callbacks, by (body, topic)."""
    out = {}
    for sub in node.subscriptions:
        parts = sub.topic_name.strip("/").split("/")
        if len(parts) == 2 and parts[1] in ("wrench", "impulse"):
            out[(parts[0], parts[1])] = sub.callback
    return out


def run_twin(rounds: list[Round], scene_path: str) -> tuple[list[dict], dict[str, Any]]:
    """Run B: only the valid messages, zero stamps, straight into a node's callbacks; records each tick."""
    context = Context()
    rclpy.init(context=context)
    node = None
    try:
        overrides = [Parameter(k, value=v) for k, v in {**PARAMETERS, "scene": scene_path, "paused": True,
                                                          "status_period": 0.0, "diagnostics_period": 0.0}.items()]
        node = RigidBodySimNode("rigid_body_sim_twin", context=context, parameter_overrides=overrides)
        callbacks = callbacks_of(node)
        ticks: list[dict] = []
        msg = WrenchStamped()
        for round_ in rounds:
            for sent in round_.messages:
                if sent.expected == "accepted":  # with a zero stamp: stamps must not matter
                    callbacks[(sent.body, sent.topic)](_message(sent.frame_id, sent.values, (0, 0), msg))
            for _ in range(round_.ticks):
                node.advance_one_tick()
                ticks.append({"arrays": node_arrays(node), "stopped": node.simulator.stopped_bodies})
        state = node.simulator.state
        final = {"state": [a.copy() for a in (state.p_WC_W, state.q_WP, state.v_WC_W, state.w_WP_P)],
                 "held": node.held_wrenches, "rejected": Counter(node.rejected), "accepted": node.accepted_messages}
        return ticks, final
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown(context=context)


class PublishedChecker:
    """Subscribes to every pose, twist and odometry topic; counts messages and non-finite ones."""

    def __init__(self, harness: SimHarness):
        self.received = Counter()
        self.non_finite = Counter()
        for body in BODIES:
            harness.client.create_subscription(PoseStamped, f"{body}/pose", lambda m: self._check("pose", m), 100)
            harness.client.create_subscription(Twist, f"{body}/twist", lambda m: self._check("twist", m), 100)
            harness.client.create_subscription(Odometry, f"{body}/odom", lambda m: self._check("odom", m), 100)
        harness.spin_until(lambda: min(harness.node.publisher_subscription_counts().values()) >= 2,
                           "the checker's subscriptions to match")

    def _check(self, kind: str, msg: Any) -> None:
        self.received[kind] += 1
        if kind == "pose":
            values = [msg.pose.position.x, msg.pose.position.y, msg.pose.position.z, msg.pose.orientation.x,
                      msg.pose.orientation.y, msg.pose.orientation.z, msg.pose.orientation.w]
        elif kind == "twist":
            values = _vec(msg.linear) + _vec(msg.angular)
        else:
            pose, twist = msg.pose.pose, msg.twist.twist
            values = (_vec(pose.position) + [pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w]
                      + _vec(twist.linear) + _vec(twist.angular))
        if not all(math.isfinite(v) for v in values):
            self.non_finite[kind] += 1


def run_fuzz(tmp_path, seed: int, n_messages: int, direct_share: float, executor: type) -> dict[str, Any]:
    """Run A through the harness, compared tick by tick with the twin; returns the figures."""
    scene_path = tmp_path / "fuzz_scene.yaml"
    scene_path.write_text(yaml.safe_dump(SCENE))
    rounds = list(generate(seed, n_messages, direct_share))
    twin_ticks, twin_final = run_twin(rounds, str(scene_path))

    tried = Counter()
    expected = Counter()
    start = time.perf_counter()
    with SimHarness(scene_path, parameters=dict(PARAMETERS), executor=executor) as harness:
        node = harness.node
        checker = PublishedChecker(harness)
        ghost_pubs = {(g, t): harness.client.create_publisher(WrenchStamped, f"{g}/{t}", 10)
                      for g in GHOSTS for t in ("wrench", "impulse")}
        callbacks = callbacks_of(node)
        msg = WrenchStamped()
        tick = 0
        for round_ in rounds:
            to_take = 0
            seen_before = harness.messages_seen()
            for sent in round_.messages:
                tried[(round_.path, sent.topic)] += 1
                expected[sent.expected] += 1
                if round_.path == "direct":
                    if sent.body in FRAMES:  # a ghost has no callback: nothing to call
                        callbacks[(sent.body, sent.topic)](_message(sent.frame_id, sent.values, sent.stamp, msg))
                    continue
                pub = ghost_pubs.get((sent.body, sent.topic)) or harness._publishers[(sent.body, sent.topic)]
                pub.publish(sent.raw if sent.raw is not None else _message(sent.frame_id, sent.values, sent.stamp, msg))
                if sent.expected not in ("no_subscriber", "dropped_by_middleware"):
                    to_take += 1
            if to_take:
                harness.spin_until(lambda: harness.messages_seen() >= seen_before + to_take,
                                   f"the node to take {to_take} messages of a DDS round")
            for _ in range(round_.ticks):
                harness.step()
                want = twin_ticks[tick]
                assert node.simulator.stopped_bodies == want["stopped"], f"tick {tick}"
                for body, array in want["arrays"].items():
                    got = published_arrays(harness.latest_pose(body), harness.latest_twist(body))
                    assert got.tobytes() == array.tobytes(), f"tick {tick}, {body}: {got} != {array}"
                tick += 1
        elapsed = time.perf_counter() - start
        assert tick == len(twin_ticks)
        state = node.simulator.state
        for got, want in zip((state.p_WC_W, state.q_WP, state.v_WC_W, state.w_WP_P), twin_final["state"]):
            assert got.tobytes() == want.tobytes()
        held, twin_held = node.held_wrenches, twin_final["held"]
        # Holds of different bodies live in different rows of the core's accumulator, so only the
        # order within a body matters (and DDS keeps the order within one topic).
        for body in BODIES:
            assert [k for k in held if k[0] == body] == [k for k in twin_held if k[0] == body]
        for key, (force, torque) in held.items():
            assert force.tobytes() == twin_held[key][0].tobytes() and torque.tobytes() == twin_held[key][1].tobytes()
        # The executor still spins and serves: one more tick, a parameter read.
        harness.step()
        assert harness.get_parameter("integrator") == "rk4"

        rejected = Counter(node.rejected)
        accepted = node.accepted_messages
        diagnostics = {s.name: status_values(s) for s in node.diagnostics().status}
        received = Counter(checker.received)
        non_finite = Counter(checker.non_finite)

    want_rejected = Counter({r: expected[r] for r in REJECTION_REASONS if expected[r]})
    want_rejected["non_finite_result"] += twin_final["rejected"].get("non_finite_result", 0)
    assert +rejected == +want_rejected
    assert accepted == expected["accepted"] == twin_final["accepted"]
    assert set(rejected) <= set(REJECTION_REASONS)
    inputs = diagnostics["rigid_body_sim: input"]
    for reason in REJECTION_REASONS:
        assert int(inputs[f"rejected {reason} (total)"]) == rejected[reason]
    assert sum(non_finite.values()) == 0, non_finite
    assert received["pose"] >= len(twin_ticks) and received["twist"] >= len(twin_ticks)
    # The fuzz kept its teeth: the ordinary bodies ran to the end.
    assert "box" not in twin_ticks[-1]["stopped"] and "probe" not in twin_ticks[-1]["stopped"]
    return {"tried": tried, "expected": expected, "rejected": rejected, "accepted": accepted, "ticks": len(twin_ticks),
            "received": received, "non_finite": non_finite, "seconds": elapsed}


def _report(name: str, figures: dict[str, Any]) -> None:
    tried = figures["tried"]
    dds = sum(n for (path, _), n in tried.items() if path == "dds")
    direct = sum(n for (path, _), n in tried.items() if path == "direct")
    print(f"\n[{name}] tried {dds + direct} messages ({dds} over DDS, {direct} into the callbacks) in "
          f"{figures['seconds']:.1f} s; outcomes {dict(figures['expected'])}; node.rejected {dict(figures['rejected'])}; "
          f"accepted {figures['accepted']}; {figures['ticks']} ticks; received {dict(figures['received'])}; "
          f"non-finite published {sum(figures['non_finite'].values())}; crashes 0")


@pytest.mark.timeout(300)
@pytest.mark.parametrize("n_messages", [3_000, pytest.param(100_000, marks=pytest.mark.slow)])
def test_fuzz_bulk_over_dds_matches_the_clean_twin(tmp_path, n_messages):
    """About 3/4 over DDS; the harness spins an EventsExecutor (≈ 50 µs a message against
    ≈ 270 µs for SingleThreadedExecutor, whose wait set is rebuilt per wake-up). The default run
    sends 3,000 messages (the generator covers every outcome well before that:
    test_generator_is_reproducible_and_covers_every_outcome); the slow run sends 100,000."""
    figures = run_fuzz(tmp_path, seed=7, n_messages=n_messages, direct_share=0.04, executor=EventsExecutor)
    _report("fuzz, EventsExecutor", figures)
    assert sum(figures["tried"].values()) >= n_messages


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_fuzz_with_the_harness_default_executor_matches_the_clean_twin(tmp_path):
    """8,000 messages, all over DDS, with SingleThreadedExecutor (SimHarness's default; rigid_body_sim_node
    spins the EventsExecutor of the default run's fuzz)."""
    figures = run_fuzz(tmp_path, seed=8, n_messages=8_000, direct_share=0.0, executor=SingleThreadedExecutor)
    _report("fuzz, SingleThreadedExecutor", figures)
    assert sum(figures["tried"].values()) >= 8_000


def test_generator_is_reproducible_and_covers_every_outcome():
    first = [(r.path, r.ticks, [(s.body, s.topic, s.expected, s.raw) for s in r.messages]) for r in generate(3, 5000, 0.2)]
    second = [(r.path, r.ticks, [(s.body, s.topic, s.expected, s.raw) for s in r.messages]) for r in generate(3, 5000, 0.2)]
    assert first == second
    outcomes = Counter(s[2] for r in first for s in r[2])
    assert set(outcomes) == {"accepted", "unknown_frame", "non_finite", "too_large", "no_subscriber",
                             "dropped_by_middleware"}, outcomes


@pytest.mark.parametrize(("frame_id", "values", "outcome"), [
    ("box", (5e-324, 0.0, -0.0, 0.0, 0.0, 0.0), "accepted"),           # subnormal: finite, tiny
    ("box", (0.0, -0.0, 0.0, -0.0, 0.0, 0.0), "accepted"),             # all-zero: clears the hold
    ("box", (1e12, -1e12, 0.0, 0.0, 0.0, 0.0), "accepted"),            # the limit itself
    ("box", (math.nextafter(1e12, math.inf), 0.0, 0.0, 0.0, 0.0, 0.0), "too_large"),
    ("box", (1e300, math.nan, 0.0, 0.0, 0.0, 0.0), "non_finite"),      # non-finite is checked first
    ("map", (math.nan, 0.0, 0.0, 0.0, 0.0, 0.0), "unknown_frame"),     # the frame is checked before values
    ("ghost", (1.0, 0.0, 0.0, 0.0, 0.0, 0.0), "unknown_frame"),
])
def test_expected_outcome_rule(frame_id, values, outcome):
    assert expected_outcome("box", frame_id, values) == outcome
