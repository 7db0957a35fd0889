"""Split a scene into shard scenes, one node each, and join the shards' batches back by stamp.

A scene's bodies interact with the ground (each body with each half-space on its own:
core/contact) and, in a scene with contact, moving bodies with a collision shape with each other
(core/contact/body_pairs.py). Bodies that never meet are stepped by any split exactly as the
whole scene steps them: the same integrator on the same numbers. What must stay together is
what couples bodies: bodies that can touch each other. This module does not check it (two
bodies in different shards pass through each other): docs/shards.md.

``rigid-body-sim shard SCENE --shards K --out DIR`` (:func:`write_shards`) writes

* ``DIR/shard_<k>.yaml`` (JSON, which is YAML and loads fastest), k = 0..K−1: the bodies ``k·N/K .. (k+1)·N/K − 1`` in scene order
  (contiguous, so shard k's ``poses`` is a slice of the whole scene's), each with its scripted
  wrenches; gravity, ground, ``energy_growth_limit`` copied into every shard;
* ``DIR/shards.yaml``, the manifest: for each shard its file, namespace ``/shard_<k>``, body
  count and first body, and the command that runs it.

Each shard runs as its own node, in its own namespace, on any host of the ROS domain
(docs/shards.md). :class:`ShardJoiner` is the consumer side: it subscribes to each shard's
``poses`` and hands on, for every stamp that all shards have published, the whole scene's
(N, 7) pose rows in scene order. ``python -m rigid_body_sim.tools.shards join DIR`` runs it and
prints, once a second, the ticks joined and any shard that lags.
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import yaml

from rigid_body_sim.core.scene import MAX_SCENE_BYTES, SceneError, load_scene
from rigid_body_sim.core.scene_yaml import read_yaml

__all__ = ["JOIN_DEPTH", "MANIFEST", "ShardJoiner", "ShardSpec", "read_manifest", "split_bodies", "write_shards", "main"]

#: The manifest's file name in the output folder.
MANIFEST = "shards.yaml"
#: History depth of each shard's ``poses`` publisher in the manifest's commands (the node's
#: default is 1: the latest state; a reliable writer that keeps only the latest may replace a tick
#: a busy consumer has not yet acknowledged, and a joiner needs every tick of every shard).
JOIN_DEPTH = 10
#: Top-level scene keys copied into every shard (bodies and wrenches are split).
_SHARED_KEYS = ("gravity", "ground", "energy_growth_limit")


@dataclass(frozen=True)
class ShardSpec:
    """One shard of the manifest: its scene file, namespace, body count and first body (scene order)."""

    file: Path
    namespace: str
    bodies: int
    first_body: str


def split_bodies(count: int, shards: int) -> list[tuple[int, int]]:
    """[start, end) of each shard's bodies: ``shards`` contiguous blocks of sizes differing by at most one."""
    if isinstance(shards, bool) or not isinstance(shards, int) or not 1 <= shards <= count:
        raise ValueError(f"shards: expected a whole number from 1 to the body count {count}, got {shards!r}")
    edges = [k * count // shards for k in range(shards + 1)]
    return list(zip(edges[:-1], edges[1:]))


def write_shards(scene_path: str | Path, shards: int, out: str | Path, node_args: Sequence[str] = ()) -> list[ShardSpec]:
    """Write the shard scenes and the manifest of the module docstring; returns the shards.

    Raises
    ------
    SceneError
        The scene does not load, or a shard scene would exceed MAX_SCENE_BYTES (then ask for
        more shards).
    ValueError
        ``shards`` not in 1..N.
    """
    scene = load_scene(scene_path)  # validated whole first: a shard of a bad scene is never written
    data = read_yaml(scene.text)
    bodies: Mapping[str, Any] = data["bodies"]
    names = list(bodies)
    wrenches = data.get("wrenches") or []
    blocks = split_bodies(len(names), shards)  # refused before anything is written
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    specs = []
    for k, (start, end) in enumerate(blocks):
        mine = names[start:end]
        members = set(mine)
        shard: dict[str, Any] = {key: data[key] for key in _SHARED_KEYS if data.get(key) is not None}
        shard["bodies"] = {name: bodies[name] for name in mine}
        scripted = [w for w in wrenches if w.get("body") in members]
        if scripted:
            shard["wrenches"] = scripted
        text = _scene_text(shard)
        if len(text.encode()) > MAX_SCENE_BYTES:
            raise SceneError(f"{scene.source}: shard {k} would be {len(text.encode()):,} bytes, more than a scene "
                             f"file may be ({MAX_SCENE_BYTES:,}); ask for more shards")
        path = out / f"shard_{k}.yaml"
        path.write_text(text)
        specs.append(ShardSpec(path, f"/shard_{k}", len(mine), mine[0]))
    manifest = {"scene": str(scene_path), "bodies": len(names), "shards": [
        {"file": spec.file.name, "namespace": spec.namespace, "bodies": spec.bodies, "first_body": spec.first_body,
         "command": " ".join(["rigid_body_sim_node", "--ros-args", "-r", f"__ns:={spec.namespace}",
                              "-p", f"scene:={spec.file.resolve()}", "-p", "per_body_topics:=false",
                              "-p", f"qos_overrides.{spec.namespace}/poses.publisher.depth:={JOIN_DEPTH}",
                              *(["-p", "publish_clock:=false"] if k else []), *node_args])}
        for k, spec in enumerate(specs)]}
    (out / MANIFEST).write_text(yaml.safe_dump(manifest, sort_keys=False, width=1 << 16))
    return specs


def _scene_text(scene: Mapping[str, Any]) -> str:
    """A scene as JSON (YAML's subset, which the loader reads fastest), one body a line."""
    head = [f"{json.dumps(key)}: {json.dumps(value)}" for key, value in scene.items() if key != "bodies"]
    bodies = [f"{json.dumps(name)}: {json.dumps(body)}" for name, body in scene["bodies"].items()]
    return "{" + "".join(f"{line},\n" for line in head) + '"bodies": {\n' + ",\n".join(bodies) + "\n}}\n"


def read_manifest(folder: str | Path) -> list[ShardSpec]:
    """The shards listed in ``folder``/shards.yaml, in order."""
    folder = Path(folder)
    manifest = yaml.safe_load((folder / MANIFEST).read_text())
    return [ShardSpec(folder / s["file"], s["namespace"], int(s["bodies"]), s["first_body"])
            for s in manifest["shards"]]


_STAMP = struct.Struct("<iI")
_LENGTH = struct.Struct("<I")


def _pose_rows(data: bytes) -> tuple[int, np.ndarray]:
    """(stamp in ns, (n, 7) pose rows) of a geometry_msgs/PoseArray in CDR (little endian)."""
    sec, nanosec = _STAMP.unpack_from(data, 4)
    (frame_length,) = _LENGTH.unpack_from(data, 12)
    offset = 16 + frame_length
    offset += -(offset - 4) % 4  # the sequence length is 4-aligned (CDR offsets count from after the 4-byte header)
    (n,) = _LENGTH.unpack_from(data, offset)
    offset += 4
    offset += -(offset - 4) % 8  # doubles are 8-aligned
    if len(data) != offset + 7 * 8 * n:
        raise ValueError(f"not a little-endian PoseArray in CDR: {len(data)} bytes for {n} poses")
    rows = np.frombuffer(data, dtype="<f8", count=7 * n, offset=offset).reshape(n, 7)
    return sec * 1_000_000_000 + nanosec, rows


class ShardJoiner:
    """Joins the shards' ``poses`` by stamp: ``on_tick(stamp_ns, rows)`` once every shard has that stamp.

    ``rows`` is (N, 7) float64, scene order (shard after shard), (x, y, z, qx, qy, qz, qw) as in
    ``poses``. Subscribes (raw CDR, depth ``depth``, transient local so a late consumer gets
    each shard's latest) to ``<namespace>/poses`` of each shard on ``node``. Stamps not yet
    complete wait, at most ``window`` of them; an older incomplete stamp is given up
    (counted in ``incomplete``). Callbacks run in the node's executor thread(s);
    ``on_tick`` runs with an internal lock held.
    """

    def __init__(self, node: Any, shards: Sequence[ShardSpec], on_tick: Callable[[int, np.ndarray], None] | None = None,
                 *, depth: int = 10, window: int = 100):
        from geometry_msgs.msg import PoseArray
        from rclpy.qos import DurabilityPolicy, QoSProfile

        self.shards = list(shards)
        self.offsets = np.cumsum([0] + [s.bodies for s in self.shards])
        self.on_tick = on_tick
        self.window = window
        self.joined = 0
        self.incomplete = 0
        self.last_stamp: dict[str, int] = {}
        self._partial: OrderedDict[int, tuple[np.ndarray, set[int]]] = OrderedDict()
        self._lock = threading.Lock()
        qos = QoSProfile(depth=depth, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.subscriptions = [
            node.create_subscription(PoseArray, f"{spec.namespace.rstrip('/')}/poses",
                                     lambda data, k=k: self._on_poses(k, data), qos, raw=True)
            for k, spec in enumerate(self.shards)]

    def _on_poses(self, k: int, data: bytes) -> None:
        stamp, rows = _pose_rows(data)
        spec = self.shards[k]
        if rows.shape[0] != spec.bodies:
            return  # not the shard the manifest describes (a scene change): never joined wrongly
        with self._lock:
            self.last_stamp[spec.namespace] = stamp
            entry = self._partial.get(stamp)
            if entry is None:
                if self._partial and stamp < next(iter(self._partial)) and len(self._partial) >= self.window:
                    return
                entry = self._partial[stamp] = (np.empty((int(self.offsets[-1]), 7)), set())
                while len(self._partial) > self.window:
                    self._partial.popitem(last=False)
                    self.incomplete += 1
            joined, seen = entry
            joined[self.offsets[k]:self.offsets[k + 1]] = rows
            seen.add(k)
            if len(seen) == len(self.shards):
                del self._partial[stamp]
                for older in [s for s in self._partial if s < stamp]:  # they will not complete in order now
                    del self._partial[older]
                    self.incomplete += 1
                self.joined += 1
                if self.on_tick is not None:
                    self.on_tick(stamp, joined)


def _join(folder: Path, seconds: float | None) -> int:
    import rclpy
    from rclpy.executors import ExternalShutdownException

    shards = read_manifest(folder)
    try:
        with rclpy.init():
            node = rclpy.create_node("shard_joiner")
            joiner = ShardJoiner(node, shards)
            start = last = time.monotonic()
            count = 0
            while seconds is None or time.monotonic() - start < seconds:
                rclpy.spin_once(node, timeout_sec=0.1)
                now = time.monotonic()
                if now - last >= 1.0:
                    print(f"joined {joiner.joined - count} ticks in {now - last:.2f} s ({joiner.joined} in all, "
                          f"{joiner.incomplete} given up); last stamps: {joiner.last_stamp}", flush=True)
                    count, last = joiner.joined, now
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rigid_body_sim.tools.shards split SCENE --shards K --out DIR`` or ``... join DIR``."""
    parser = argparse.ArgumentParser(prog="python -m rigid_body_sim.tools.shards", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    split = sub.add_parser("split", help="write the shard scenes and the manifest (as `rigid-body-sim shard`)")
    split.add_argument("scene")
    split.add_argument("--shards", type=int, required=True)
    split.add_argument("--out", type=Path, required=True)
    join = sub.add_parser("join", help="join the shards of DIR's manifest by stamp and print the rate")
    join.add_argument("folder", type=Path)
    join.add_argument("--seconds", type=float)
    args = parser.parse_args(argv)
    if args.command == "join":
        return _join(args.folder, args.seconds)
    try:
        specs = write_shards(args.scene, args.shards, args.out)
    except (SceneError, ValueError) as exc:
        print(f"shards: {exc}", file=sys.stderr)
        return 1
    print(f"{len(specs)} shards in {args.out} ({MANIFEST} lists them and the command for each)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
