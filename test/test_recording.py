"""MCAP recordings, read back by readers no one here wrote.

Each recording is read with mcap's own reader and mcap-ros2-support's decoder, which builds
its CDR decoders from the schema text in the file (as Foxglove does), and every message's
raw bytes are also deserialised by rclpy's type support into the real geometry_msgs /
rosgraph_msgs classes. Values must equal, bit for bit, what the core simulated or what the
node published; stamps and log times must be the sim time in nanoseconds. The schema texts
are compared with the .msg files the ROS wheels install.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from rigid_body_sim.cli import main
from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.offline.msgdefs import MSG_TEXT, complete_definition, dependencies
from rigid_body_sim.offline.recording import METADATA_NAME, SCENE_ATTACHMENT

SCENE = {
    "bodies": {
        "box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}, "pose": {"position": [0.0, 0.0, 1.0]},
                "twist": {"angular": [0.2, 0.1, 0.5]}, "sites": {"corner": {"position": [0.5, 0.3, 0.0]}}},
        "ball": {"mass": 1.0, "inertia": {"sphere": 0.1}, "twist": {"linear": [1.0, 0.0, 0.0]}},
    },
    "wrenches": [{"body": "box", "frame": "box/corner", "force": [0.0, 10.0, 0.0], "start": 0.04, "duration": 0.06}],
}
TYPES = {"pose": "geometry_msgs/msg/PoseStamped", "twist": "geometry_msgs/msg/Twist",
         "wrench": "geometry_msgs/msg/WrenchStamped", "clock": "rosgraph_msgs/msg/Clock"}


def ns(t: float) -> int:
    return int(round(t * 1e9))


def read_back(path: Path) -> dict[str, Any]:
    """Everything in the file, through mcap's reader and mcap-ros2-support's decoder."""
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        summary = reader.get_summary()
        messages = [(channel.topic, schema, channel.message_encoding, message, decoded)
                    for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False)]
        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        attachments = {a.name: bytes(a.data) for a in reader.iter_attachments()}
    return {"header": header, "summary": summary, "messages": messages, "metadata": metadata, "attachments": attachments}


def by_topic(recording: dict[str, Any], topic: str) -> list[tuple[Any, Any, Any]]:
    return [(schema, message, decoded) for t, schema, _enc, message, decoded in recording["messages"] if t == topic]


def xyz(v: Any) -> list[float]:
    return [v.x, v.y, v.z]


def stamp(header: Any) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def check_file_form(recording: dict[str, Any], bodies: list[str]) -> None:
    """Profile ros2, a finished file (summary present), ros2msg schemas equal to the full definitions, CDR."""
    assert recording["header"].profile == "ros2"
    assert recording["summary"] is not None, "no summary: the file was not finished"
    topics = {t for t, *_ in recording["messages"]}
    assert {f"/{b}/pose" for b in bodies} | {f"/{b}/twist" for b in bodies} | {"/clock"} <= topics
    for topic, schema, encoding, _message, _decoded in recording["messages"]:
        kind = topic.rsplit("/", 1)[-1]
        assert schema.name == TYPES[kind]
        assert schema.encoding == "ros2msg"
        assert schema.data.decode() == complete_definition(TYPES[kind])
        assert encoding == "cdr"


def check_rclpy_agrees(recording: dict[str, Any]) -> None:
    """The real ROS 2 type support deserialises every message's bytes to the same values."""
    from geometry_msgs.msg import PoseStamped, Twist, WrenchStamped
    from rclpy.serialization import deserialize_message
    from rosgraph_msgs.msg import Clock

    classes = {"pose": PoseStamped, "twist": Twist, "wrench": WrenchStamped, "clock": Clock}
    for topic, _schema, _enc, message, decoded in recording["messages"]:
        real = deserialize_message(message.data, classes[topic.rsplit("/", 1)[-1]])
        if isinstance(real, PoseStamped):
            assert stamp(real.header) == stamp(decoded.header) and real.header.frame_id == decoded.header.frame_id
            assert xyz(real.pose.position) == xyz(decoded.pose.position)
            q, d = real.pose.orientation, decoded.pose.orientation
            assert [q.x, q.y, q.z, q.w] == [d.x, d.y, d.z, d.w]
        elif isinstance(real, Twist):
            assert xyz(real.linear) == xyz(decoded.linear) and xyz(real.angular) == xyz(decoded.angular)
        elif isinstance(real, WrenchStamped):
            assert stamp(real.header) == stamp(decoded.header) and real.header.frame_id == decoded.header.frame_id
            assert xyz(real.wrench.force) == xyz(decoded.wrench.force)
            assert xyz(real.wrench.torque) == xyz(decoded.wrench.torque)
        else:
            assert real.clock.sec == decoded.clock.sec and real.clock.nanosec == decoded.clock.nanosec


# --------------------------------------------------------------------------- message definitions


def _significant(text: str) -> list[str]:
    lines = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            lines.append(" ".join(line.split()))
    return lines


@pytest.mark.parametrize("type_name", sorted(MSG_TEXT))
def test_definitions_are_the_installed_msg_files(type_name: str) -> None:
    """Byte for byte the .msg file the ROS wheels install (what rosbag2 copies into a schema)."""
    package, _, name = type_name.split("/")
    path = Path(sys.prefix, "share", package, "msg", f"{name}.msg")
    assert path.is_file(), f"{path} is not installed (the ROS wheels install it)"
    assert MSG_TEXT[type_name] == path.read_text(encoding="utf-8")
    primitive = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32",
                 "int64", "uint64", "string", "wstring"}
    used = set()
    for line in _significant(MSG_TEXT[type_name]):
        field_type = line.split()[0].split("[", 1)[0]  # float64[9] is an array of float64
        if field_type not in primitive:
            pkg, _, msg = field_type.rpartition("/")
            used.add(f"{pkg or package}/{msg}")
    assert dependencies(type_name) == sorted(used)


def test_complete_definition_is_rosbag2s() -> None:
    """rosbag2's order (depth first, sorted per file, each type once) and its ``MSG: pkg/Type`` lines."""
    text = complete_definition("geometry_msgs/msg/PoseStamped")
    assert re.findall(r"^MSG: (\S+)$", text, flags=re.M) == [
        "geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion", "std_msgs/Header",
        "builtin_interfaces/Time"]
    assert text.count("\n" + "=" * 80 + "\n") == 5
    assert text.startswith(MSG_TEXT["geometry_msgs/msg/PoseStamped"] + "\n" + "=" * 80 + "\nMSG: geometry_msgs/Pose\n")
    imu = complete_definition("sensor_msgs/msg/Imu")
    assert re.findall(r"^MSG: (\S+)$", imu, flags=re.M) == [
        "geometry_msgs/Quaternion", "geometry_msgs/Vector3", "std_msgs/Header", "builtin_interfaces/Time"]
    cloud = complete_definition("sensor_msgs/msg/PointCloud2")
    assert re.findall(r"^MSG: (\S+)$", cloud, flags=re.M) == [
        "sensor_msgs/PointField", "std_msgs/Header", "builtin_interfaces/Time"]
    with pytest.raises(KeyError, match="known types are"):
        complete_definition("sensor_msgs/msg/LaserScan")


# --------------------------------------------------------------------------- a recording made by `run`


@pytest.mark.ros  # rclpy's deserialiser is one of the two readers
def test_run_recording_reads_back_with_the_simulated_values(tmp_path: Path) -> None:
    scene_path = tmp_path / "scene.yaml"
    scene_path.write_text(yaml.safe_dump(SCENE), encoding="utf-8")
    out = tmp_path / "run.mcap"
    code = main(["run", str(scene_path), "--duration", "0.2", "--dt", "0.01", "--rate", "50",
                 "--record", str(out), "--quiet"])
    assert code == 0
    recording = read_back(out)
    check_file_form(recording, ["box", "ball"])
    check_rclpy_agrees(recording)

    # The same run, sampled by hand: every 2 steps from t = 0 to 0.2 s.
    sim = Simulator(load_scene(scene_path), "rk4", 0.01)
    expected = []
    for k in range(11):
        expected.append((sim.time, sim.positions_world(), sim.orientations_xyzw(), sim.linear_velocities_world(),
                         sim.angular_velocities_world(), sim.active_scripted_wrenches()))
        if k < 10:
            sim.step(2)
    for b, body in enumerate(sim.body_names):
        poses = by_topic(recording, f"/{body}/pose")
        twists = by_topic(recording, f"/{body}/twist")
        assert len(poses) == len(twists) == len(expected)
        for (t, p, q, v, w, _active), (_s, pose_record, pose), (_s2, twist_record, twist) in zip(expected, poses, twists):
            assert pose_record.log_time == pose_record.publish_time == twist_record.log_time == ns(t)
            assert stamp(pose.header) == ns(t) and pose.header.frame_id == "world"
            assert xyz(pose.pose.position) == p[b].tolist()
            o = pose.pose.orientation
            assert [o.x, o.y, o.z, o.w] == q[b].tolist()
            assert xyz(twist.linear) == v[b].tolist() and xyz(twist.angular) == w[b].tolist()
    clock = by_topic(recording, "/clock")
    assert [c.clock.sec * 10**9 + c.clock.nanosec for _s, _m, c in clock] == [ns(e[0]) for e in expected]
    # The script: 10 N along the corner's y, acting on steps starting in [0.04, 0.10) s.
    wrenches = by_topic(recording, "/box/wrench")
    first_active = next(i for i, e in enumerate(expected) if e[5])
    assert len(wrenches) == len(expected) - first_active
    for (t, *_rest, active), (_s, record, wrench) in zip(expected[first_active:], wrenches):
        assert record.log_time == stamp(wrench.header) == ns(t)
        assert wrench.header.frame_id == "box/corner"
        assert xyz(wrench.wrench.force) == ([0.0, 10.0, 0.0] if active else [0.0, 0.0, 0.0])
        assert xyz(wrench.wrench.torque) == [0.0, 0.0, 0.0]
    assert [round(e[0], 9) for e in expected if e[5]] == [0.04, 0.06, 0.08]
    assert by_topic(recording, "/ball/wrench") == []
    assert recording["metadata"][METADATA_NAME]["integrator"] == "rk4"
    assert yaml.safe_load(recording["attachments"][SCENE_ATTACHMENT].decode()) == SCENE


# --------------------------------------------------------------------------- recordings made by the node


@pytest.mark.ros
def test_node_recording_reads_back_with_what_was_published(tmp_path: Path) -> None:
    from rigid_body_sim.testing import SimHarness

    scene_path = tmp_path / "scene.yaml"
    scene_path.write_text(yaml.safe_dump(SCENE), encoding="utf-8")
    out = tmp_path / "node.mcap"
    published: list[tuple[int, list[float], list[float], list[float], list[float]]] = []
    with SimHarness(scene=scene_path, parameters={"record_path": str(out), "wrench_timeout": 0.0}) as harness:
        harness.publish_wrench("ball", force=(0.0, 0.0, 2.0), frame_id="world")
        for _ in range(6):
            harness.step(1)
            pose, twist = harness.latest_pose("box"), harness.latest_twist("box")
            o = pose.pose.orientation
            published.append((stamp(pose.header), xyz(pose.pose.position), [o.x, o.y, o.z, o.w],
                              xyz(twist.linear), xyz(twist.angular)))
        assert read_back_is_unfinished(out)  # finished only when the node goes
    recording = read_back(out)  # the harness closed the node: the file is finished
    check_file_form(recording, ["box", "ball"])
    check_rclpy_agrees(recording)

    poses = by_topic(recording, "/box/pose")
    twists = by_topic(recording, "/box/twist")
    # One pose per publication: at start-up, the harness's republish, then one per tick.
    times = [stamp(p.header) for _s, _m, p in poses]
    assert times[-6:] == [ns(0.01 * k) for k in range(1, 7)] and set(times[:-6]) == {0}
    for (t, p, q, v, w), (_s, record, pose), (_s2, _r2, twist) in zip(published, poses[-6:], twists[-6:]):
        assert record.log_time == t == stamp(pose.header)
        o = pose.pose.orientation
        assert xyz(pose.pose.position) == p and [o.x, o.y, o.z, o.w] == q
        assert xyz(twist.linear) == v and xyz(twist.angular) == w
    # Wrenches: the held one in its frame_id, every tick; the script's while it is active.
    held = by_topic(recording, "/ball/wrench")
    assert [stamp(w.header) for _s, _m, w in held] == [ns(0.01 * k) for k in range(6)]
    assert all(w.header.frame_id == "world" and xyz(w.wrench.force) == [0.0, 0.0, 2.0] for _s, _m, w in held)
    scripted = by_topic(recording, "/box/wrench")
    assert [(stamp(w.header), xyz(w.wrench.force)) for _s, _m, w in scripted] == [
        (ns(0.04), [0.0, 10.0, 0.0]), (ns(0.05), [0.0, 10.0, 0.0])]
    assert {c.clock.sec * 10**9 + c.clock.nanosec for _s, _m, c in by_topic(recording, "/clock")} == {
        ns(0.01 * k) for k in range(7)}


def read_back_is_unfinished(path: Path) -> bool:
    """While recording, the file has no summary yet (it is finished on close)."""
    with open(path, "rb") as f:
        try:
            return make_reader(f).get_summary() is None
        except Exception:  # noqa: BLE001 - an unfinished file may not even have a footer to read
            return True


@pytest.mark.ros
def test_record_path_changes_at_runtime_and_bad_paths_are_rejected(tmp_path: Path) -> None:
    from rigid_body_sim.testing import SimHarness

    first, second = tmp_path / "first.mcap", tmp_path / "second.mcap"
    with SimHarness(parameters={"record_dirs": [str(tmp_path)]}) as harness:
        assert harness.get_parameter("record_path") == ""
        assert harness.set_parameters(record_path=str(first))[0].successful
        harness.step(2)
        assert harness.set_parameters(record_path=str(second))[0].successful
        assert read_back(first)["summary"] is not None  # finished when the path changed
        harness.step(3)
        result = harness.set_parameters(record_path=str(tmp_path / "missing" / "x.mcap"))[0]
        assert not result.successful and "does not exist" in result.reason
        (tmp_path / "directory.mcap").mkdir()
        result = harness.set_parameters(record_path=str(tmp_path / "directory.mcap"))[0]
        assert not result.successful and "is a directory" in result.reason
        assert harness.get_parameter("record_path") == str(second)
        assert harness.set_parameters(record_path="")[0].successful
        harness.step(1)
    times = lambda path: sorted({stamp(p.header) for _s, _m, p in by_topic(read_back(path), "/box/pose")})  # noqa: E731
    assert times(first) == [ns(0.01 * k) for k in range(3)]
    assert times(second) == [ns(0.01 * k) for k in range(2, 6)]
    with pytest.raises(ValueError, match=r"record_path rejected: directory .* does not exist"):
        SimHarness(parameters={"record_path": str(tmp_path / "missing" / "x.mcap")})


# --------------------------------------------------------------------------- CLI paths that cannot name a file


def _cli_error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    capsys.readouterr()
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    return code, capsys.readouterr().err


@pytest.mark.parametrize("kind", ["loop", "through-loop", "too-long", "not-a-directory", "directory"])
@pytest.mark.parametrize("option", ["--csv", "--record", "--imu-csv", "SCENE", "plot RUN", "plot --output",
                                    "plot --scene"])
def test_paths_that_cannot_name_a_file_are_usage_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                        kind: str, option: str) -> None:
    """A symlink loop (ELOOP), a name too long (ENAMETOOLONG), a file used as a directory
    (ENOTDIR), a directory for a file: exit 2 with one error line naming the path and what was
    expected, never a traceback."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump(SCENE), encoding="utf-8")
    record = tmp_path / "run.mcap"
    assert main(["run", str(scene), "-T", "0.02", "--record", str(record), "-q"]) == 0
    (tmp_path / "loop_a").symlink_to(tmp_path / "loop_b")
    (tmp_path / "loop_b").symlink_to(tmp_path / "loop_a")
    path = {"loop": str(tmp_path / "loop_a"), "through-loop": str(tmp_path / "loop_a" / "x.out"),
            "too-long": str(tmp_path / ("n" * 300)), "not-a-directory": str(scene / "x.out"),
            "directory": str(tmp_path)}[kind]
    argv = {"--csv": ["run", str(scene), "-T", "0.02", "--csv", path],
            "--record": ["run", str(scene), "-T", "0.02", "--record", path],
            "--imu-csv": ["run", str(scene), "-T", "0.02", "--imu-csv", path],
            "SCENE": ["run", path, "-T", "0.02", "--csv", str(tmp_path / "out.csv")],
            "plot RUN": ["plot", path],
            "plot --output": ["plot", str(record), "-o", path],
            "plot --scene": ["plot", str(record), "--scene", path, "-o", str(tmp_path / "p.png")]}[option]
    code, err = _cli_error(argv, capsys)
    assert code == 2, err
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("rigid-body-sim")]
    assert len(errors) == 1 and " error: argument " in errors[0], err
    assert repr(path) in errors[0] and "; expected " in errors[0], err
    assert not (tmp_path / "out.csv").exists()


@pytest.mark.ros  # rclpy's serializer is the reference
def test_cdr_encoder_writes_the_bytes_rclpy_writes() -> None:
    """The offline writer's CDR, from the .msg definitions, has the middleware's layout and decodes,
    by rclpy's type support, to the very message."""
    from geometry_msgs.msg import PoseArray, PoseStamped, Twist, WrenchStamped
    from rclpy.serialization import deserialize_message, serialize_message
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import Imu, PointCloud2

    from rigid_body_sim.offline.recording import CdrEncoder

    stamp = {"sec": 12, "nanosec": 345_678_901}
    q = {"x": 0.1, "y": -0.2, "z": 0.3, "w": 0.9273618495495703}
    v = {"x": 1.5, "y": -2.25, "z": 1e-300}
    pose = {"position": {"x": 1.0, "y": 2.0, "z": -3.5}, "orientation": q}
    messages = {
        "geometry_msgs/msg/PoseStamped": (PoseStamped, {"header": {"stamp": stamp, "frame_id": "world"}, "pose": pose}),
        "geometry_msgs/msg/Twist": (Twist, {"linear": v, "angular": {"x": 0.0, "y": 7.0, "z": -0.5}}),
        "geometry_msgs/msg/WrenchStamped": (WrenchStamped, {"header": {"stamp": stamp, "frame_id": "box/corner"},
                                                            "wrench": {"force": v, "torque": v}}),
        "rosgraph_msgs/msg/Clock": (Clock, {"clock": stamp}),
        "sensor_msgs/msg/Imu": (Imu, {"header": {"stamp": stamp, "frame_id": "b/s"}, "orientation": q,
                                      "orientation_covariance": [float(k) for k in range(9)], "angular_velocity": v,
                                      "angular_velocity_covariance": [0.5] * 9, "linear_acceleration": v,
                                      "linear_acceleration_covariance": [-1.0] + [0.0] * 8}),
        "geometry_msgs/msg/PoseArray": (PoseArray, {"header": {"stamp": stamp, "frame_id": "w"}, "poses": [pose] * 3}),
        "sensor_msgs/msg/PointCloud2": (PointCloud2, {
            "header": {"stamp": stamp, "frame_id": "w"}, "height": 1, "width": 2,
            "fields": [{"name": "vx", "offset": 0, "datatype": 8, "count": 1},
                       {"name": "stopped", "offset": 8, "datatype": 2, "count": 1}],
            "is_bigendian": False, "point_step": 9, "row_step": 18, "data": bytes(range(18)), "is_dense": True}),
    }
    encoder = CdrEncoder()
    for type_name, (msg_type, fields) in messages.items():
        message = _ros_message(msg_type, fields)
        ours, theirs = encoder.encode(type_name, fields), serialize_message(message)
        # same layout (the middleware leaves its alignment padding unset, so compare all else)
        assert len(ours) == len(theirs) and ours[:4] == theirs[:4], type_name
        assert deserialize_message(ours, msg_type) == message, type_name
        # Padding only: where the bytes differ, ours are zero (the middleware leaves its padding as the
        # memory held it, so how many differ varies from run to run), and the decode above is equal.
        differing = [i for i in range(len(ours)) if ours[i] != theirs[i]]
        assert all(ours[i] == 0 for i in differing), (type_name, differing)


def _ros_message(msg_type: Any, fields: dict[str, Any]) -> Any:
    msg = msg_type()
    for name, value in fields.items():
        current = getattr(msg, name)
        if isinstance(value, dict):
            value = _ros_message(type(current), value)
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            element = type(msg).SLOT_TYPES[list(msg.get_fields_and_field_types()).index(name)].value_type
            module = __import__(f"{element.namespaces[0]}.msg", fromlist=[element.name])
            value = [_ros_message(getattr(module, element.name), item) for item in value]
        setattr(msg, name, value)
    return msg
