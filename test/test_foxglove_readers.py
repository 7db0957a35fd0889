"""Recordings read by Foxglove's own readers, run by Node.js: none of this package's code decodes them.

test/foxglove/decode.mjs opens each recording with @mcap/core (indexed, or record by record for
a cut file) and @mcap/support's decompressors, parses every schema with @foxglove/rosmsg and
decodes every message with @foxglove/rosmsg2-serialization, the libraries Foxglove uses; their
exact versions are pinned in test/foxglove/package-lock.json and installed by ``make
foxglove-deps`` (a prerequisite of ``make test``). Every message must decode, and what is
decoded is compared with the simulator's own state or the closed form of the motion, and each
channel's ``offered_qos_profiles`` (the ros2 profile's required metadata) with the QoS the
running node's publishers really offer, as the ROS graph reports it.

Recordings: the default scene from the node (in-process harness), an IMU scene from the node
and from ``rigid-body-sim run --record``, and 200 bodies batched (``per_body_topics`` false)
from the node. The recording of a node process killed with SIGKILL (a file without a summary)
is decoded by the same readers in test_stops.py, whose run it is.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from foxglove_support import (foxglove_decode, check_everything_decodes, check_schema_text, by_topic,
                              stamp_ns, xyz, xyzw, rotation, quat_multiply, same_rotation, graph_qos,
                              recorded_qos, TICK_S)

from rigid_body_sim.cli import main
from rigid_body_sim.core import Simulator, load_scene

pytestmark = pytest.mark.ros

def box_momentum(q: np.ndarray, w_world: np.ndarray) -> np.ndarray:
    """Angular momentum (world) of the default scene's box: 2 kg, edges 1.0, 0.6, 0.4 m."""
    m, (a, b, c) = 2.0, (1.0, 0.6, 0.4)
    inertia_body = np.diag([m / 12 * (b * b + c * c), m / 12 * (a * a + c * c), m / 12 * (a * a + b * b)])
    R = rotation(q)
    return R @ inertia_body @ R.T @ w_world


def check_default_scene_poses(result: dict[str, Any]) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """The box of the default scene: at rest at (0, 0, 1), unit quaternions, |L| (world) conserved
    (torque-free: the closed form keeps L fixed), stamps on the ticks. Returns (ns, p, q) per pose."""
    poses = by_topic(result, "/box/pose")
    twists = by_topic(result, "/box/twist")
    assert len(poses) == len(twists) >= 5
    momentum0 = box_momentum(np.array([0.0, 0.0, 0.0, 1.0]), np.array([0.2, 0.1, 0.5]))
    out = []
    for (t, pose), (t2, twist) in zip(poses, twists):
        assert t == t2 == stamp_ns(pose["header"]) and pose["header"]["frame_id"] == "world"
        assert t % round(TICK_S * 1e9) == 0
        p, q = xyz(pose["pose"]["position"]), xyzw(pose["pose"]["orientation"])
        np.testing.assert_allclose(p, [0.0, 0.0, 1.0], rtol=0, atol=1e-12)
        assert abs(np.linalg.norm(q) - 1.0) < 1e-12
        np.testing.assert_allclose(xyz(twist["linear"]), 0.0, rtol=0, atol=1e-12)
        np.testing.assert_allclose(box_momentum(q, xyz(twist["angular"])), momentum0, rtol=0, atol=1e-9)
        out.append((t, p, q))
    assert [t for t, *_ in out] == sorted(t for t, *_ in out)
    return out


# --------------------------------------------------------------------------- the default scene, from the node


def test_default_scene_node_recording_decodes_in_foxglove(tmp_path: Path) -> None:
    from rigid_body_sim.testing import SimHarness

    out = tmp_path / "default.mcap"
    with SimHarness(parameters={"record_path": str(out)}) as h:
        h.step(40)
        sim = h.node.simulator
        last = (round(sim.time * 1e9), sim.positions_world()[0].copy(), sim.orientations_xyzw()[0].copy())
        live_qos = {topic: graph_qos(h.client, topic) for topic in ("/box/pose", "/box/twist", "/clock")}
    result = foxglove_decode(out)
    check_everything_decodes(result, finished=True)
    check_schema_text(out)
    assert {c["topic"] for c in result["channels"]} >= {"/box/pose", "/box/twist", "/clock"}
    for topic, qos in live_qos.items():
        assert recorded_qos(result, topic) == qos
    poses = check_default_scene_poses(result)
    t, p, q = poses[-1]
    assert t == last[0] == round(40 * TICK_S * 1e9)
    assert p.tolist() == last[1].tolist() and q.tolist() == last[2].tolist()  # bit for bit
    clocks = [c["clock"]["sec"] * 10**9 + c["clock"]["nanosec"] for _t, c in by_topic(result, "/clock")]
    assert sorted(set(clocks)) == [round(k * TICK_S * 1e9) for k in range(41)]


# --------------------------------------------------------------------------- an IMU scene, from the node and the CLI


def imu_scene(tmp_path: Path, w_z: float) -> Path:
    """A box spinning at ``w_z`` about its principal z axis, no gravity, ideal IMUs at its centre and 1 m along x."""
    path = tmp_path / "imu.yaml"
    path.write_text(yaml.safe_dump({"gravity": [0.0, 0.0, 0.0], "bodies": {"b": {
        "mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]},
        "pose": {"position": [0.0, 0.0, 5.0], "orientation": [0.0, 0.0, 0.0, 1.0]},
        "twist": {"linear": [0.0, 0.0, 0.0], "angular": [0.0, 0.0, w_z]},
        "sites": {"centre": {"position": [0.0, 0.0, 0.0], "imu": {}}, "arm": {"position": [1.0, 0.0, 0.0], "imu": {}}},
    }}}), encoding="utf-8")
    return path


def check_imu_closed_form(result: dict[str, Any], w_z: float, count: int) -> None:
    """Spin about a principal axis: ω stays w_z e_z, q(t) is a turn of w_z t about z; the centre
    reads no specific force, the arm the centripetal −w_z² x (sensor axes); orientation = the pose's."""
    poses = {t: xyzw(p["pose"]["orientation"]) for t, p in by_topic(result, "/b/pose")}
    for topic, expected in (("/b/centre/imu", [0.0, 0.0, 0.0]), ("/b/arm/imu", [-w_z**2, 0.0, 0.0])):
        imus = by_topic(result, topic)
        assert len(imus) == count
        for t, imu in imus:
            assert t == stamp_ns(imu["header"]) and imu["header"]["frame_id"] == topic[1:-4]
            np.testing.assert_allclose(xyz(imu["linear_acceleration"]), expected, rtol=0, atol=1e-9)
            np.testing.assert_allclose(xyz(imu["angular_velocity"]), [0.0, 0.0, w_z], rtol=0, atol=1e-9)
            q = xyzw(imu["orientation"])
            assert abs(np.linalg.norm(q) - 1.0) < 1e-12
            angle = w_z * t * 1e-9
            same_rotation(q, np.array([0.0, 0.0, np.sin(angle / 2), np.cos(angle / 2)]), 1e-9)
            np.testing.assert_allclose(q, poses[t], rtol=0, atol=1e-12)
            assert len(imu["orientation_covariance"]) == 9 and len(imu["linear_acceleration_covariance"]) == 9


def test_imu_scene_node_recording_decodes_in_foxglove(tmp_path: Path) -> None:
    from rigid_body_sim.testing import SimHarness

    w_z = 3.0
    out = tmp_path / "imu_node.mcap"
    with SimHarness(imu_scene(tmp_path, w_z), {"record_path": str(out), "integrator": "rk4"}) as h:
        h.step(25)
        live_qos = {topic: graph_qos(h.client, topic) for topic in ("/b/centre/imu", "/b/arm/imu", "/b/pose")}
    result = foxglove_decode(out)
    check_everything_decodes(result, finished=True)
    check_schema_text(out)
    for topic, qos in live_qos.items():
        assert recorded_qos(result, topic) == qos
    check_imu_closed_form(result, w_z, 25)


def test_imu_scene_cli_recording_decodes_in_foxglove(tmp_path: Path) -> None:
    w_z = 3.0
    scene = imu_scene(tmp_path, w_z)
    doc = yaml.safe_load(scene.read_text())  # a scripted wrench of zero force: /b/wrench is recorded too
    doc["wrenches"] = [{"body": "b", "frame": "b/arm", "force": [0.0, 0.0, 0.0], "start": 0.0}]
    scene.write_text(yaml.safe_dump(doc), encoding="utf-8")
    out = tmp_path / "imu_cli.mcap"
    assert main(["run", str(scene), "--duration", "0.3", "--dt", "0.01", "--record", str(out), "--quiet"]) == 0
    result = foxglove_decode(out)
    check_everything_decodes(result, finished=True)
    check_schema_text(out)
    check_imu_closed_form(result, w_z, 30)
    wrenches = by_topic(result, "/b/wrench")
    assert len(wrenches) == 31 and all(w["header"]["frame_id"] == "b/arm" for _t, w in wrenches)
    assert all(xyz(w["wrench"]["force"]).tolist() == [0.0, 0.0, 0.0] for _t, w in wrenches)
    # the poses are the simulator's, bit for bit
    sim = Simulator(load_scene(scene), "rk4", 0.01)
    poses = by_topic(result, "/b/pose")
    assert len(poses) == 31
    for k, (t, pose) in enumerate(poses):
        assert t == round(k * 0.01 * 1e9) == stamp_ns(pose["header"])
        assert xyz(pose["pose"]["position"]).tolist() == sim.positions_world()[0].tolist()
        assert xyzw(pose["pose"]["orientation"]).tolist() == sim.orientations_xyzw()[0].tolist()
        sim.step(1)


# --------------------------------------------------------------------------- 200 bodies, batched


def test_200_batched_bodies_decode_in_foxglove(tmp_path: Path) -> None:
    """200 bodies with per_body_topics false (in-process harness, 10 ticks): the channels are /poses,
    /velocities and /clock, the batches with the scene order in their metadata and each with the QoS
    the ROS graph reports for the node's publisher; every tick's batch is the closed form of the
    motion (poses and the velocity cloud) and the last one the simulator's state, bit for bit."""
    from rigid_body_sim.testing import SimHarness

    n, ticks = 200, 10
    rng = np.random.default_rng(7)
    p0 = rng.uniform(-10, 10, (n, 3))
    v = rng.uniform(-1, 1, (n, 3))
    w = rng.uniform(-2, 2, (n, 3))
    q0 = rng.normal(size=(n, 4))
    q0 /= np.linalg.norm(q0, axis=1, keepdims=True)
    names = [f"s{k:03d}" for k in range(n)]
    scene = tmp_path / "many.yaml"
    scene.write_text(yaml.safe_dump({"gravity": [0.0, 0.0, 0.0], "bodies": {names[k]: {
        "mass": 1.5, "inertia": {"sphere": 0.2},
        "pose": {"position": p0[k].tolist(), "orientation": q0[k].tolist()},
        "twist": {"linear": v[k].tolist(), "angular": w[k].tolist()}} for k in range(n)}}), encoding="utf-8")
    out = tmp_path / "many.mcap"
    with SimHarness(scene, {"per_body_topics": False, "record_path": str(out)}) as h:
        h.step(ticks)
        sim = h.node.simulator
        last = (round(sim.time * 1e9), sim.positions_world().tolist(), sim.orientations_xyzw().tolist())
        live_qos = {topic: graph_qos(h.client, topic) for topic in ("/poses", "/velocities", "/clock")}
    result = foxglove_decode(out)
    check_everything_decodes(result, finished=True)
    check_schema_text(out)
    assert {c["topic"] for c in result["channels"]} == {"/poses", "/velocities", "/clock"}
    for channel in result["channels"]:
        if channel["topic"] != "/clock":
            assert json.loads(channel["metadata"]["body_names"]) == names
    for topic, qos in live_qos.items():
        assert recorded_qos(result, topic) == qos
    batches = by_topic(result, "/poses")
    clouds = dict(by_topic(result, "/velocities"))
    stamps = [t for t, _ in batches]  # t = 0 also once more: the harness republishes it when connected
    assert stamps == sorted(stamps) and sorted(set(stamps)) == [round(k * TICK_S * 1e9) for k in range(ticks + 1)]
    for t, batch in batches:
        assert stamp_ns(batch["header"]) == t and batch["header"]["frame_id"] == "world"
        assert len(batch["poses"]) == n
        s = t * 1e-9
        p = np.array([xyz(pose["position"]) for pose in batch["poses"]])
        q = np.array([xyzw(pose["orientation"]) for pose in batch["poses"]])
        # closed form: uniform motion, and a sphere turns at constant ω: q(t) = exp(ω t / 2) ⊗ q0
        np.testing.assert_allclose(p, p0 + v * s, rtol=0, atol=1e-9)
        assert np.all(np.abs(np.linalg.norm(q, axis=1) - 1.0) < 1e-12)
        for k in range(n):
            angle = np.linalg.norm(w[k]) * s
            turn = np.concatenate([w[k] / np.linalg.norm(w[k]) * np.sin(angle / 2), [np.cos(angle / 2)]])
            same_rotation(q[k], quat_multiply(turn, q0[k]), 1e-9)
        cloud = clouds[t]
        assert stamp_ns(cloud["header"]) == t and cloud["width"] * cloud["height"] == n
        data = np.frombuffer(base64.b64decode(cloud["data"]["base64"]), dtype=np.uint8).reshape(n, cloud["point_step"])
        fields = {f["name"]: f for f in cloud["fields"]}
        columns = np.stack([data[:, fields[c]["offset"]:fields[c]["offset"] + 8].copy().view("<f8")[:, 0]
                            for c in ("vx", "vy", "vz", "wx", "wy", "wz")], axis=1)
        np.testing.assert_allclose(columns[:, :3], v, rtol=0, atol=1e-12)
        np.testing.assert_allclose(columns[:, 3:], w, rtol=0, atol=1e-12)
        assert data[:, fields["stopped"]["offset"]].tolist() == [0] * n
    t, batch = batches[-1]
    assert t == last[0] == round(ticks * TICK_S * 1e9)
    assert [xyz(pose["position"]).tolist() for pose in batch["poses"]] == last[1]
    assert [xyzw(pose["orientation"]).tolist() for pose in batch["poses"]] == last[2]
