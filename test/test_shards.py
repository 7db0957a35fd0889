"""Shards: ``rigid-body-sim shard`` splits a scene, each shard runs as a node, one consumer joins them.

The split is checked against the whole scene (every body's initial state and scripted wrench
in exactly one shard, the bodies in scene order); the shard nodes run in their own namespaces
and one :class:`~rigid_body_sim.tools.shards.ShardJoiner` must get every shard's ``poses`` at
every tick of a stretch, joined in scene order, equal to the whole scene stepped offline (the
same compiled step on the same numbers per body: bitwise). The slow test runs 4 node
processes of 10,000 bodies each.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
import yaml
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from rigid_body_sim.cli import main as cli_main
from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.ros.node import RigidBodySimNode
from rigid_body_sim.tools.shards import JOIN_DEPTH, MANIFEST, ShardJoiner, read_manifest, split_bodies, write_shards

NODE = Path(sys.executable).parent / "rigid_body_sim_node"


def free_bodies(n: int, seed: int = 0) -> dict:
    """``n`` free asymmetric bodies at random poses and spins (JSON-ready)."""
    rng = np.random.default_rng(seed)
    bodies = {}
    for k in range(n):
        q = rng.normal(size=4)
        bodies[f"b{k}"] = {"mass": 1.0 + k % 3, "inertia": {"box": [1.0, 0.6, 0.4]},
                           # 3 m apart along x: a scene with a ground refuses overlapping shapes
                           "pose": {"position": (rng.normal(size=3) * 0.1 + [3.0 * k, 0.0, 0.0]).tolist(),
                                    "orientation": (q / np.linalg.norm(q)).tolist()},
                           "twist": {"linear": rng.normal(size=3).tolist(), "angular": (2.0 * rng.normal(size=3)).tolist()},
                           "sites": {"tip": {"position": [0.5, 0.0, 0.0]}}}
    return bodies


def test_split_bodies_is_contiguous_and_balanced() -> None:
    assert split_bodies(10, 4) == [(0, 2), (2, 5), (5, 7), (7, 10)]
    assert split_bodies(3, 3) == [(0, 1), (1, 2), (2, 3)]
    for bad in (0, 4, 2.0, True):
        with pytest.raises(ValueError, match="shards: expected a whole number from 1 to the body count 3"):
            split_bodies(3, bad)


def test_shard_command_splits_bodies_wrenches_and_keeps_the_ground(tmp_path, capsys) -> None:
    scene = {"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1], "offset": -100.0}],
             "bodies": free_bodies(7),
             "wrenches": [{"body": "b1", "frame": "b1/tip", "force": [0.0, 1.0, 0.0]},
                          {"body": "b6", "frame": "world", "force": [2.0, 0.0, 0.0], "start": 0.1, "duration": 0.2}]}
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    assert cli_main(["shard", str(path), "--shards", "3", "--out", str(tmp_path / "out")]) == 0
    assert "shards.yaml" in capsys.readouterr().out
    whole = load_scene(str(path))
    shards = read_manifest(tmp_path / "out")
    assert [s.namespace for s in shards] == ["/shard_0", "/shard_1", "/shard_2"]
    parts = [load_scene(str(s.file)) for s in shards]
    assert sum((p.body_names for p in parts), ()) == whole.body_names
    assert [s.bodies for s in shards] == [len(p.body_names) for p in parts] == [2, 2, 3]
    for part in parts:
        assert np.array_equal(part.model.gravity_W, whole.model.gravity_W)
        assert part.contact is not None
        rows = [whole.body_names.index(b) for b in part.body_names]
        assert np.array_equal(part.initial_state.rows(), whole.initial_state.rows()[rows])
    assert [(w.body, w.frame) for p in parts for w in p.wrenches] == [("b1", "b1/tip"), ("b6", "world")]
    manifest = yaml.safe_load((tmp_path / "out" / MANIFEST).read_text())
    assert "-r __ns:=/shard_1" in manifest["shards"][1]["command"]
    assert "publish_clock:=false" in manifest["shards"][1]["command"]  # one /clock in the domain: shard 0's


def test_shard_command_refuses_more_shards_than_bodies(tmp_path, capsys) -> None:
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump({"bodies": free_bodies(2)}))
    with pytest.raises(SystemExit) as exit_info:
        cli_main(["shard", str(path), "--shards", "3", "--out", str(tmp_path / "out")])
    assert exit_info.value.code == 2
    assert "shards: expected a whole number from 1 to the body count 2, got 3" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def _whole_scene_poses(scene_path: Path, ticks: int, tick_s: float) -> list[np.ndarray]:
    """The whole scene's (N, 7) pose rows after each of ``ticks`` ticks, stepped offline as the node does (rk4)."""
    sim = Simulator(load_scene(str(scene_path)), integrator="rk4", dt=tick_s)
    out = []
    for _ in range(ticks):
        sim.step(1)
        out.append(np.hstack([sim.positions_world(), sim.orientations_xyzw()]))
    return out


def test_one_consumer_joins_every_tick_of_three_shard_nodes(tmp_path) -> None:
    scene_path = tmp_path / "scene.json"
    scene_path.write_text(json.dumps({"bodies": free_bodies(9)}))
    shards = write_shards(scene_path, 3, tmp_path / "out")
    context = Context()
    rclpy.init(context=context)
    nodes, executor = [], None
    joined: dict[int, np.ndarray] = {}
    try:
        for spec in shards:
            overrides = [Parameter("scene", value=str(spec.file)), Parameter("per_body_topics", value=False),
                         Parameter("paused", value=True), Parameter("status_period", value=0.0),
                         Parameter("publish_clock", value=spec.namespace == "/shard_0"),
                         Parameter(f"qos_overrides.{spec.namespace}/poses.publisher.depth", value=JOIN_DEPTH)]
            nodes.append(RigidBodySimNode("rigid_body_sim", context=context, namespace=spec.namespace,
                                          parameter_overrides=overrides))
        consumer = Node("shard_consumer", context=context)
        joiner = ShardJoiner(consumer, shards, lambda stamp, rows: joined.__setitem__(stamp, rows.copy()), depth=50)
        executor = MultiThreadedExecutor(num_threads=2, context=context)
        for node in (*nodes, consumer):
            executor.add_node(node)
        deadline = time.monotonic() + 10.0
        while 0 not in joined and time.monotonic() < deadline:  # the initial poses, kept for late joiners
            executor.spin_once(timeout_sec=0.05)
        assert 0 in joined, f"no joined initial tick; last stamps {joiner.last_stamp}"
        ticks = 20
        for node in nodes:  # each shard ticks on its own clock from here: the joiner waits for the slowest
            node.set_parameters([Parameter("paused", value=False)])
        tick_ns = 10_000_000
        deadline = time.monotonic() + 15.0
        # list(joined): a snapshot taken in one call, while the executor's threads may be adding to it
        while len([s for s in list(joined) if s <= ticks * tick_ns]) < ticks + 1 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        for node in nodes:
            node.set_parameters([Parameter("paused", value=True)])
        stamps = sorted(s for s in list(joined) if s <= ticks * tick_ns)
        assert stamps == [k * tick_ns for k in range(ticks + 1)], f"joined {stamps}; given up {joiner.incomplete}"
        expected = _whole_scene_poses(scene_path, ticks, 0.01)
        for k in range(1, ticks + 1):
            assert np.array_equal(joined[k * tick_ns], expected[k - 1]), f"tick {k}"
    finally:
        if executor is not None:
            executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown(context=context)


def _write_free_scene_json(path: Path, n: int, seed: int = 0) -> None:
    """``n`` free asymmetric bodies (random poses and spins, no gravity) as JSON, one body a line."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    p, v, w = 10.0 * rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), 2.0 * rng.normal(size=(n, 3))
    lines = [f'"b{k}": {{"mass": 1.0, "inertia": {{"box": [1.0, 0.6, 0.4]}}, "pose": {{"position": {p[k].tolist()}, '
             f'"orientation": {q[k].tolist()}}}, "twist": {{"linear": {v[k].tolist()}, "angular": {w[k].tolist()}}}}}'
             for k in range(n)]
    path.write_text('{"bodies": {\n' + ",\n".join(lines) + "\n}}\n")


#: Rate of the 4 × 10,000 shard run (Hz) and its length (wall s).
SHARD_RATE_HZ = float(os.environ.get("SHARD_RATE_HZ", "20"))
SHARD_SECONDS = 10.0


@pytest.mark.slow
def test_one_consumer_gets_every_tick_of_four_shard_processes_of_ten_thousand_bodies(tmp_path) -> None:
    """4 node processes × 10,000 bodies at SHARD_RATE_HZ, one joiner: every stamp joined; prints body-steps/s."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter_client import AsyncParameterClient

    scene_path = tmp_path / "scene.json"
    _write_free_scene_json(scene_path, 40_000)
    shards = write_shards(scene_path, 4, tmp_path / "out")
    processes = []
    context = Context()
    rclpy.init(context=context)
    executor = None
    joined: list[int] = []
    try:
        for k, spec in enumerate(shards):
            processes.append(subprocess.Popen(
                [str(NODE), "--ros-args", "-r", f"__ns:={spec.namespace}", "-p", f"scene:={spec.file}",
                 "-p", "per_body_topics:=false", "-p", f"publish_clock:={'true' if k == 0 else 'false'}",
                 "-p", f"qos_overrides.{spec.namespace}/poses.publisher.depth:={JOIN_DEPTH}",
                 "-p", "paused:=true", "-p", f"rate_hz:={SHARD_RATE_HZ}", "-p", "status_period:=0.0"],
                stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT))
        consumer = Node("shard_consumer", context=context)
        joiner = ShardJoiner(consumer, shards, lambda stamp, rows: joined.append(stamp), depth=100, window=1000)
        clients = [AsyncParameterClient(consumer, f"{spec.namespace}/rigid_body_sim") for spec in shards]
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(consumer)
        deadline = time.monotonic() + 180.0
        while 0 not in joined and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        assert joined == [0], f"the shards' initial poses were not joined; last stamps {joiner.last_stamp}"
        for client in clients:
            assert client.wait_for_services(timeout_sec=30.0)
        futures = [client.set_parameters([Parameter("paused", value=False)]) for client in clients]
        start = time.monotonic()
        while time.monotonic() - start < SHARD_SECONDS:
            executor.spin_once(timeout_sec=0.05)
        assert all(f.done() for f in futures)
        futures = [client.set_parameters([Parameter("paused", value=True)]) for client in clients]
        while not all(f.done() for f in futures):
            executor.spin_once(timeout_sec=0.05)
        end = time.monotonic()
        settle = time.monotonic() + 2.0  # the last ticks in flight
        while time.monotonic() < settle:
            executor.spin_once(timeout_sec=0.05)
        tick_ns = round(1e9 / SHARD_RATE_HZ)
        last = max(joined) // tick_ns
        missing = sorted(set(range(last + 1)) - {s // tick_ns for s in joined})
        print(f"\n4 shards x 10,000 bodies at {SHARD_RATE_HZ:g} Hz: {len(joined)} ticks joined in {end - start:.1f} s, "
              f"missing {len(missing)}, given up {joiner.incomplete}; {40_000 * last / (end - start):.3g} body-steps/s "
              f"joined (sim/wall {last / SHARD_RATE_HZ / (end - start):.3f})")
        assert not missing and joiner.incomplete == 0, f"ticks missing {missing[:20]}; given up {joiner.incomplete}"
        assert last >= 0.9 * SHARD_RATE_HZ * SHARD_SECONDS
    finally:
        if executor is not None:
            executor.shutdown()
        for process in processes:
            process.send_signal(signal.SIGINT)
        for process in processes:
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        rclpy.try_shutdown(context=context)
