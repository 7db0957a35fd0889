"""Foxglove's own readers (test/foxglove/decode.mjs under Node.js) and what the recording tests
read from their output: messages by topic, stamps, QoS, schema text; shared by the recording tests."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from rigid_body_sim.offline.msgdefs import complete_definition

FOXGLOVE_DIR = Path(__file__).resolve().parent / "foxglove"
TICK_S = 0.01  # the node's default tick: rate_hz 100, substeps 1
LATCHED = {"pose", "twist", "poses", "velocities", "clock"}
QOS_KEYS = ["history", "depth", "reliability", "durability", "deadline", "lifespan", "liveliness",
            "liveliness_lease_duration", "avoid_ros_namespace_conventions"]


def foxglove_decode(path: Path) -> dict[str, Any]:
    """What Foxglove's readers make of ``path`` (decode.mjs's JSON)."""
    node = shutil.which("node")
    assert node is not None, "Node.js is needed: run `make foxglove-deps` (apt-get install nodejs npm)"
    assert (FOXGLOVE_DIR / "node_modules" / "@mcap" / "core").is_dir(), (
        "Foxglove's readers are not installed: run `make foxglove-deps` (npm ci --prefix test/foxglove)")
    done = subprocess.run([node, str(FOXGLOVE_DIR / "decode.mjs"), str(path)], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def check_everything_decodes(result: dict[str, Any], *, finished: bool) -> None:
    """Profile ros2, every schema parsed, 100 % of the messages decoded, ros2msg/cdr, rosbag2's QoS metadata."""
    assert result["profile"] == "ros2"
    assert result["schemaErrors"] == {}
    assert result["failures"] == []
    assert result["messageCount"] > 0
    assert result["decodedCount"] == result["messageCount"] == len(result["messages"])
    if finished:
        assert result["reader"] == "indexed" and result["complete"] and result["cut"] is None
        assert result["statisticsMessageCount"] == result["messageCount"]
    else:
        assert result["reader"] == "stream" and not result["complete"] and result["cut"]
    for channel in result["channels"]:
        assert channel["schemaEncoding"] == "ros2msg" and channel["messageEncoding"] == "cdr"
        assert "/msg/" in channel["schemaName"]
        profiles = yaml.safe_load(channel["metadata"]["offered_qos_profiles"])
        assert isinstance(profiles, list) and len(profiles) == 1, channel
        profile = profiles[0]
        assert list(profile) == QOS_KEYS
        kind = channel["topic"].rsplit("/", 1)[-1]
        assert profile["reliability"] == "reliable"
        assert profile["durability"] == ("transient_local" if kind in LATCHED else "volatile"), channel["topic"]
        assert (profile["history"], profile["depth"]) == ("keep_last", 1 if kind in LATCHED else 10)
        assert profile["liveliness"] == "automatic" and profile["avoid_ros_namespace_conventions"] is False
        for key in ("deadline", "lifespan", "liveliness_lease_duration"):
            assert profile[key] == {"sec": 9223372036, "nsec": 854775807}


def check_schema_text(path: Path) -> None:
    """Each schema in the file is the complete definition rosbag2 writes (``MSG: pkg/Type`` lines)."""
    from mcap.records import Schema
    from mcap.stream_reader import StreamReader

    schemas = []
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f).records:
                if isinstance(record, Schema):
                    schemas.append(record)
        except Exception:  # noqa: BLE001 - a cut file ends in the middle of a record; the schemas come first
            pass
    assert schemas
    for schema in schemas:
        text = schema.data.decode()
        assert text == complete_definition(schema.name)
        assert "MSG: std_msgs/msg/" not in text and "MSG: geometry_msgs/msg/" not in text


def by_topic(result: dict[str, Any], topic: str) -> list[tuple[int, dict[str, Any]]]:
    return [(int(log_time), decoded) for t, log_time, _publish, decoded in result["messages"] if t == topic]


def stamp_ns(header: dict[str, Any]) -> int:
    return header["stamp"]["sec"] * 1_000_000_000 + header["stamp"]["nanosec"]


def xyz(v: dict[str, float]) -> np.ndarray:
    return np.array([v["x"], v["y"], v["z"]])


def xyzw(q: dict[str, float]) -> np.ndarray:
    return np.array([q["x"], q["y"], q["z"], q["w"]])


def rotation(q: np.ndarray) -> np.ndarray:
    """The rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def same_rotation(a: np.ndarray, b: np.ndarray, atol: float) -> None:
    assert abs(abs(float(np.dot(a, b))) - 1.0) <= atol, (a, b)


def graph_qos(node: Any, topic: str) -> tuple[str, str]:
    """(reliability, durability) the ROS graph reports for the publishers of ``topic``."""
    infos = node.get_publishers_info_by_topic(topic)
    assert infos, f"no publisher on {topic}"
    names = {(i.qos_profile.reliability.name.lower(), i.qos_profile.durability.name.lower()) for i in infos}
    assert len(names) == 1, names
    return names.pop()


def recorded_qos(result: dict[str, Any], topic: str) -> tuple[str, str]:
    channel = next(c for c in result["channels"] if c["topic"] == topic)
    profile = yaml.safe_load(channel["metadata"]["offered_qos_profiles"])[0]
    return profile["reliability"], profile["durability"]
