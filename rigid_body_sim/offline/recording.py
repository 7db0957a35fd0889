"""Recordings: MCAP files with ROS 2 messages (CDR), openable in Foxglove, written without ROS.

A recording holds, per body B (topics under ``namespace``, "/" by default):

=================  ============================  =============================================
topic              type                          content
=================  ============================  =============================================
``/B/pose``        geometry_msgs/PoseStamped     pose of B in ``world_frame``; stamp = sim time
``/B/twist``       geometry_msgs/Twist           COM velocity and angular velocity, world axes
``/B/wrench``      geometry_msgs/WrenchStamped   one per (B, frame) that has acted: the wrench
                                                 acting from the stamp on, in that frame (frame
                                                 rule: force N, torque N·m about the frame's
                                                 origin, its axes); zeros once it stopped
``/B/S/imu``       sensor_msgs/Imu               the IMU on site S of B (scene ``imu:``), as the
                                                 node publishes it (frame ``B/S``, REP-145)
``/clock``         rosgraph_msgs/Clock           sim time
=================  ============================  =============================================

or, instead of ``/B/pose`` and ``/B/twist`` (the node with ``per_body_topics`` false: one
message per tick for all bodies, as it publishes them; ros/batch.py has the layout):

=================  ============================  =============================================
``/poses``         geometry_msgs/PoseArray       every body's pose in scene order, stamp = sim
                                                 time, frame ``world_frame``
``/velocities``    sensor_msgs/PointCloud2       per body: vx vy vz wx wy wz (float64, world
                                                 axes) and ``stopped`` (uint8: 1 once it blew up)
=================  ============================  =============================================

and, from the node on a scene with contact, ``/contacts`` (sensor_msgs/PointCloud2, one message
per tick as published: ros/contacts.py has the layout).

The scene order of the batches is in their channel's metadata, key ``body_names`` (a JSON list
of names); a new pair of channels starts wherever the order changes.

Every message's log and publish time is its sim time in nanoseconds (as rosbag2 records a
``use_sim_time`` system), so a player's timeline is sim time from t = 0. The file is written
with ``mcap``'s writer (profile ``ros2``, zstd chunks) as rosbag2 writes one: schemas in the
``ros2msg`` encoding with the complete definitions of :mod:`~rigid_body_sim.offline.msgdefs`,
messages in CDR (:class:`CdrEncoder`, driven by those definitions), and on every channel the
key ``offered_qos_profiles`` the ``ros2`` profile requires: the QoS the node offers on that
topic, as rosbag2's YAML (:func:`offered_qos_profiles`; state topics and ``/clock`` are
latched). It is finished, with its summary and index, by :meth:`McapRecorder.close`. The
scene file (when it is one) is attached as ``scene.yaml`` and the run's settings are in the
metadata record ``rigid_body_sim``, so ``rigid-body-sim plot`` can recompute energy and the
closed form from a recording alone.

How the recording ended is its ``status``, the key ``status`` of the metadata records named
``rigid_body_sim_status`` (the last one wins): ``incomplete: ...`` is written first, and
:meth:`McapRecorder.close` writes the final one (``complete: ...``, ``interrupted by SIGTERM
at t = ... s``...). A file that still
says ``incomplete`` was never closed; one cut anywhere (its writer was killed, the disk filled
up: no footer at its end) is read by :func:`read_recording` up to the last whole record before
the cut, with ``status`` ``cut short: ...``.

The file is created with :func:`rigid_body_sim.safe_open.open_for_writing`: never blocking on a FIFO
and refusing anything but a regular file (the node's ``record_path`` gets the same checks).
"""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path
from typing import IO, Any, Iterable, Mapping

import numpy as np
from mcap.writer import CompressionType, Writer

from ..core import Simulator
from ..safe_open import check_writable_path, open_for_reading, open_for_writing
from .msgdefs import MSG_TEXT, complete_definition
from .rundata import MAX_RUN_FILE_BYTES, BodyTrack, RunData, angular_velocity_body

__all__ = ["McapRecorder", "read_recording", "stamp_ns", "check_record_path", "BODY_NAMES_KEY", "METADATA_NAME",
           "SCENE_ATTACHMENT", "STATUS_METADATA_NAME", "STATUS_INCOMPLETE", "QOS_KEY", "offered_qos_profiles",
           "topic_qos", "channel_metadata", "CdrEncoder", "CUT_SHORT"]

#: Key, in the metadata of a ``poses``/``velocities`` channel, of its body order (a JSON list).
BODY_NAMES_KEY = "body_names"
#: Name of the MCAP metadata record that holds the run's settings.
METADATA_NAME = "rigid_body_sim"
#: Name of the metadata records that say how the recording ended (key ``status``; the last counts).
STATUS_METADATA_NAME = "rigid_body_sim_status"
#: Name of the attachment holding the scene file's text.
SCENE_ATTACHMENT = "scene.yaml"
#: Chunk size, bytes: a chunk is written (and safe from a crash) each time this much has gathered.
CHUNK_SIZE = 256 * 1024
#: The status a recording has until it is closed.
STATUS_INCOMPLETE = "incomplete: the recording was never closed (its writer was killed or crashed)"
#: How the status of a recording read only up to a cut starts.
CUT_SHORT = "cut short"
#: Key of the channel metadata the ``ros2`` MCAP profile requires (rosbag2 writes it).
QOS_KEY = "offered_qos_profiles"
#: RMW_DURATION_INFINITE as rosbag2 writes it (what the graph reports for the node's endpoints).
_INFINITE = {"sec": 9223372036, "nsec": 854775807}
#: Depth of the node's wrench, impulse, IMU and diagnostics endpoints (ros/node.py QUEUE_DEPTH).
_QUEUE_DEPTH = 10
#: (history, depth, reliability, durability) of the node's state topics and /clock
#: (ros/publishers.py STATE_QOS): latched, so a late subscriber gets the latest state.
_STATE_QOS = ("keep_last", 1, "reliable", "transient_local")
#: ... and of its IMU topics and the wrench topics it subscribes to (QoSProfile(depth=10)).
_QUEUE_QOS = ("keep_last", _QUEUE_DEPTH, "reliable", "volatile")


def offered_qos_profiles(history: str, depth: int, reliability: str, durability: str) -> str:
    """The ``offered_qos_profiles`` value of one publisher's QoS, as rosbag2 writes it: the YAML
    (yaml-cpp's ``Dump``) of a list of profiles with string policies (rosbag2 format 9 and
    later), durations as ``sec``/``nsec`` (infinite: RMW_DURATION_INFINITE)."""
    def duration(name: str) -> str:
        return f"  {name}:\n    sec: {_INFINITE['sec']}\n    nsec: {_INFINITE['nsec']}\n"

    return (f"- history: {history}\n  depth: {depth}\n  reliability: {reliability}\n  durability: {durability}\n"
            + duration("deadline") + duration("lifespan") + "  liveliness: automatic\n"
            + duration("liveliness_lease_duration") + "  avoid_ros_namespace_conventions: false")


def topic_qos(topic: str) -> tuple[str, int, str, str]:
    """(history, depth, reliability, durability) the node uses on a recorded topic: its state
    topics (``B/pose``, ``B/twist``, ``poses``, ``velocities``) and ``/clock`` are latched
    (``transient_local``, depth 1); ``B/S/imu``, ``contacts`` and ``B/wrench`` (an input it
    subscribes to) are ``volatile``, depth 10. Without ``qos_overrides`` parameters."""
    if topic.endswith(("/imu", "/wrench", "/contacts")):
        return _QUEUE_QOS
    return _STATE_QOS


def channel_metadata(topic: str, extra: Mapping[str, str] | None = None) -> dict[str, str]:
    """The metadata of ``topic``'s channel: ``offered_qos_profiles`` (:func:`topic_qos`) and ``extra``."""
    metadata = {QOS_KEY: offered_qos_profiles(*topic_qos(topic))}
    metadata.update(extra or {})
    return metadata


_PRIMITIVES = {"bool": "?", "byte": "B", "char": "B", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H",
               "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q", "float32": "f", "float64": "d"}


class CdrEncoder:
    """Serializes a message given as a (nested) dict to plain little-endian CDR (XCDR1, what the
    node's middleware puts on the wire), field by field in the order of its .msg definition in
    :data:`~rigid_body_sim.offline.msgdefs.MSG_TEXT`: each primitive aligned to its size from
    the end of the 4-byte encapsulation header, strings as a uint32 length counting the NUL,
    sequences as a uint32 count then the elements. A missing field is zero (or empty)."""

    def __init__(self) -> None:
        self._fields: dict[str, list[tuple[str, str, int | None]]] = {}

    def fields(self, type_name: str) -> list[tuple[str, str, int | None]]:
        """(name, full type, array length: None scalar, -1 sequence, n fixed) of ``type_name``'s fields."""
        known = self._fields.get(type_name)
        if known is not None:
            return known
        package = type_name.split("/", 1)[0]
        fields = []
        for line in MSG_TEXT[type_name].splitlines():
            words = line.split("#", 1)[0].split()
            if len(words) < 2 or "=" in line.split("#", 1)[0]:
                continue  # blank, comment or constant
            spec, name = words[0], words[1]
            base, bracketed, bound = spec.partition("[")
            bound = bound.rstrip("]")
            length = None if not bracketed else -1 if bound == "" or bound.startswith("<=") else int(bound)
            if base not in _PRIMITIVES and base != "string":
                pkg, _, msg = base.rpartition("/")
                base = f"{pkg or package}/msg/{msg}"
            fields.append((name, base, length))
        self._fields[type_name] = fields
        return fields

    def encode(self, type_name: str, message: Mapping[str, Any]) -> bytes:
        out = bytearray()
        self._message(out, type_name, message)
        return b"\x00\x01\x00\x00" + bytes(out)

    def _message(self, out: bytearray, type_name: str, message: Mapping[str, Any]) -> None:
        for name, base, length in self.fields(type_name):
            value = message.get(name)
            if length is None:
                self._value(out, base, value)
                continue
            items = list(value) if value is not None else []
            if length == -1:
                self._align(out, 4)
                out += struct.pack("<I", len(items))
            elif len(items) != length:
                raise ValueError(f"{type_name}.{name}: expected {length} elements, got {len(items)}")
            if base in ("uint8", "byte", "char") and isinstance(value, (bytes, bytearray, memoryview)):
                out += bytes(value)
                continue
            for item in items:
                self._value(out, base, item)

    def _value(self, out: bytearray, base: str, value: Any) -> None:
        code = _PRIMITIVES.get(base)
        if code is not None:
            size = struct.calcsize(code)
            self._align(out, size)
            out += struct.pack("<" + code, value if value is not None else 0)
        elif base == "string":
            data = (value or "").encode("utf-8") + b"\x00"
            self._align(out, 4)
            out += struct.pack("<I", len(data)) + data
        else:
            self._message(out, base, value or {})

    @staticmethod
    def _align(out: bytearray, size: int) -> None:
        out += b"\x00" * (-len(out) % size)


def stamp_ns(seconds: float) -> int:
    """Sim time in seconds as whole nanoseconds (the stamp the node puts on its messages)."""
    return int(round(seconds * 1e9))


def _time_dict(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def _xyz(v: np.ndarray) -> dict[str, float]:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def check_record_path(path: str | os.PathLike[str]) -> str | None:
    """Why ``path`` cannot be recorded to, or None: its directory must exist and be writable,
    and the path must not be a directory, FIFO or device (:func:`rigid_body_sim.safe_open.check_writable_path`;
    :class:`McapRecorder` checks the opened file again)."""
    return check_writable_path(path, expected="an .mcap file")


class McapRecorder:
    """Writes a simulation's state as ROS 2 messages into one MCAP file.

    Parameters
    ----------
    path : str or Path
        The .mcap file; created or overwritten. Its directory must exist.
    world_frame : str
        ``frame_id`` of poses and of world-frame wrenches.
    namespace : str
        Prefix of the body topics ("/" gives ``/B/pose``; "/robot" gives ``/robot/B/pose``).
    metadata : mapping of str to str, optional
        Written as the metadata record ``rigid_body_sim`` (e.g. scene, integrator, dt).
    scene_text : str, optional
        The scene file's text, attached as ``scene.yaml``.

    Raises
    ------
    OSError
        If the file cannot be created; :class:`rigid_body_sim.safe_open.NotRegularFileError` if the
        path is a FIFO, device or directory (never blocking, nothing written to it).
    """

    def __init__(self, path: str | os.PathLike[str], *, world_frame: str = "world", namespace: str = "/",
                 metadata: Mapping[str, str] | None = None, scene_text: str | None = None):
        self.path = Path(path)
        self.world_frame = world_frame
        self._prefix = namespace.rstrip("/") + "/"
        self._file: IO[bytes] | None = open_for_writing(self.path, expected="an .mcap file")
        try:
            self._writer = Writer(self._file, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
            self._writer.start(profile="ros2", library="rigid_body_sim")
            self._encoder = CdrEncoder()
            self._schemas = {name: self._writer.register_schema(name, "ros2msg", complete_definition(name).encode())
                             for name in ("geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/Twist",
                                          "geometry_msgs/msg/WrenchStamped", "rosgraph_msgs/msg/Clock",
                                          "sensor_msgs/msg/Imu")}
            self._channels: dict[str, int] = {}
            if metadata:
                self._writer.add_metadata(METADATA_NAME, {str(k): str(v) for k, v in metadata.items()})
            self._writer.add_metadata(STATUS_METADATA_NAME, {"status": STATUS_INCOMPLETE})
            if scene_text is not None:
                self._writer.add_attachment(0, 0, SCENE_ATTACHMENT, "application/yaml", scene_text.encode("utf-8"))
        except BaseException:
            self._file.close()
            self._file = None
            raise
        self._wrench_keys: list[tuple[str, str]] = []  # (body, frame_id) in order of first appearance
        self.message_count = 0

    @property
    def closed(self) -> bool:
        return self._file is None

    def fileno(self) -> int:
        """The open file's descriptor (e.g. to compare two outputs with ``os.path.sameopenfile``)."""
        if self._file is None:
            raise ValueError(f"recording {self.path} is closed")
        return self._file.fileno()

    def _write(self, topic: str, schema: str, message: dict[str, Any], ns: int) -> None:
        if self._file is None:
            raise ValueError(f"recording {self.path} is closed")
        channel = self._channels.get(topic)
        if channel is None:
            channel = self._channels[topic] = self._writer.register_channel(topic, "cdr", self._schemas[schema],
                                                                            channel_metadata(topic))
        self._writer.add_message(channel, log_time=ns, data=self._encoder.encode(schema, message), publish_time=ns,
                                 sequence=self.message_count)
        self.message_count += 1

    def write_state(self, time: float, bodies: Iterable[str], positions_world: np.ndarray,
                    orientations_xyzw: np.ndarray, linear_velocities_world: np.ndarray,
                    angular_velocities_world: np.ndarray) -> None:
        """Write ``/B/pose`` and ``/B/twist`` of each body at sim ``time`` (s); arrays (N, 3) or (N, 4)
        in the order of ``bodies``, world frame and axes, quaternions (x, y, z, w)."""
        ns = stamp_ns(time)
        stamp = _time_dict(ns)
        for i, body in enumerate(bodies):
            q = orientations_xyzw[i]
            self._write(f"{self._prefix}{body}/pose", "geometry_msgs/msg/PoseStamped", {
                "header": {"stamp": stamp, "frame_id": self.world_frame},
                "pose": {"position": _xyz(positions_world[i]),
                         "orientation": {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]), "w": float(q[3])}},
            }, ns)
            self._write(f"{self._prefix}{body}/twist", "geometry_msgs/msg/Twist", {
                "linear": _xyz(linear_velocities_world[i]), "angular": _xyz(angular_velocities_world[i]),
            }, ns)

    def write_contacts(self, time: float, data: bytes) -> None:
        """Write ``contacts`` (sensor_msgs/PointCloud2, the CDR bytes the node published; layout:
        ros/contacts.py) at sim ``time`` (s)."""
        self._write_bytes(f"{self._prefix}contacts", "sensor_msgs/msg/PointCloud2", data, stamp_ns(time))

    def _write_bytes(self, topic: str, schema: str, data: bytes, ns: int) -> None:
        if self._file is None:
            raise ValueError(f"recording {self.path} is closed")
        if schema not in self._schemas:
            self._schemas[schema] = self._writer.register_schema(schema, "ros2msg", complete_definition(schema).encode())
        channel = self._channels.get(topic)
        if channel is None:
            channel = self._channels[topic] = self._writer.register_channel(topic, "cdr", self._schemas[schema],
                                                                            channel_metadata(topic))
        self._writer.add_message(channel, log_time=ns, data=data, publish_time=ns, sequence=self.message_count)
        self.message_count += 1

    def write_clock(self, time: float) -> None:
        """Write ``/clock`` at sim ``time`` (s)."""
        ns = stamp_ns(time)
        self._write("/clock", "rosgraph_msgs/msg/Clock", {"clock": _time_dict(ns)}, ns)

    def write_wrenches(self, time: float, wrenches: Iterable[tuple[str, str, np.ndarray, np.ndarray]]) -> None:
        """Write the wrenches acting from sim ``time`` on: (body, frame_id, force N, torque N·m).

        Wrenches on one (body, frame_id) are summed. Every (body, frame_id) that has acted
        before but not now gets an all-zero message, so a plot of ``/B/wrench`` drops to zero.
        The core's frame name ``"world"`` is written as ``world_frame``.
        """
        totals: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
        for body, frame, force, torque in wrenches:
            frame = self.world_frame if frame == "world" else frame
            f0, t0 = totals.get((body, frame), (np.zeros(3), np.zeros(3)))
            totals[(body, frame)] = (f0 + np.asarray(force, dtype=float), t0 + np.asarray(torque, dtype=float))
        for key in totals:
            if key not in self._wrench_keys:
                self._wrench_keys.append(key)
        if not self._wrench_keys:
            return
        ns = stamp_ns(time)
        stamp = _time_dict(ns)
        zero = (np.zeros(3), np.zeros(3))
        for body, frame in self._wrench_keys:
            force, torque = totals.get((body, frame), zero)
            self._write(f"{self._prefix}{body}/wrench", "geometry_msgs/msg/WrenchStamped", {
                "header": {"stamp": stamp, "frame_id": frame},
                "wrench": {"force": _xyz(force), "torque": _xyz(torque)},
            }, ns)

    def write_imu(self, time: float, site: str, orientation_xyzw: np.ndarray | None, angular_velocity: np.ndarray,
                  specific_force: np.ndarray, covariances: tuple[list[float], list[float], list[float]]) -> None:
        """Write ``/<site>/imu`` (sensor_msgs/Imu, frame ``site`` = ``"B/S"``) at sim ``time`` (s).

        ``orientation_xyzw`` of the sensor frame in ``world_frame`` (None: zeros, as a message
        without orientation has), ``angular_velocity`` (rad/s) and ``specific_force`` (m/s²) in
        the sensor's axes, and the three row-major 3×3 covariances (orientation, angular
        velocity, linear acceleration) as the node publishes them (ros/imu.py).
        """
        ns = stamp_ns(time)
        q = orientation_xyzw if orientation_xyzw is not None else (0.0, 0.0, 0.0, 0.0)
        self._write(f"{self._prefix}{site}/imu", "sensor_msgs/msg/Imu", {
            "header": {"stamp": _time_dict(ns), "frame_id": site},
            "orientation": {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]), "w": float(q[3])},
            "orientation_covariance": [float(c) for c in covariances[0]],
            "angular_velocity": _xyz(angular_velocity),
            "angular_velocity_covariance": [float(c) for c in covariances[1]],
            "linear_acceleration": _xyz(specific_force),
            "linear_acceleration_covariance": [float(c) for c in covariances[2]],
        }, ns)

    def write_simulator(self, sim: Simulator, *, skip: Iterable[str] = (), clock: bool = True) -> None:
        """Write every body's pose and twist at ``sim.time`` (except ``skip``), then ``/clock``."""
        skipped = set(skip) | set(sim.stopped_bodies)
        keep = [i for i, body in enumerate(sim.body_names) if body not in skipped]
        self.write_state(sim.time, [sim.body_names[i] for i in keep], sim.positions_world()[keep],
                         sim.orientations_xyzw()[keep], sim.linear_velocities_world()[keep],
                         sim.angular_velocities_world()[keep])
        if clock:
            self.write_clock(sim.time)

    def close(self, status: str = "complete") -> None:
        """Write ``status`` (how the recording ended: ``"complete"``, ``"interrupted by SIGTERM at
        t = 1.5 s"``...), finish the file (summary, index, footer) and close it. Safe to call twice.

        Raises
        ------
        OSError
            If the end cannot be written (a full disk); the file is closed all the same.
        """
        if self._file is None:
            return
        try:
            self._writer.add_metadata(STATUS_METADATA_NAME, {"status": " ".join(str(status).split())})
            self._writer.finish()
        finally:
            self._file.close()
            self._file = None

    def __enter__(self) -> "McapRecorder":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _cloud_columns(cloud: Any, fields: tuple[str, ...], n: int) -> np.ndarray | None:
    """(n, len(fields)) float64 of a decoded PointCloud2's named FLOAT64 or UINT8 fields (little
    or big endian), or None if it has not ``n`` points or lacks one of the fields."""
    offsets = {f.name: (f.offset, f.datatype) for f in cloud.fields}
    step = cloud.point_step
    if cloud.width * cloud.height != n or any(name not in offsets for name in fields) or len(cloud.data) < n * step:
        return None
    raw = np.frombuffer(bytes(cloud.data), dtype=np.uint8)[: n * step].reshape(n, step)
    out = np.empty((n, len(fields)))
    for column, name in enumerate(fields):
        offset, datatype = offsets[name]
        if offset < 0 or offset + (8 if datatype == 8 else 1) > step:
            return None
        if datatype == 8:  # FLOAT64
            out[:, column] = raw[:, offset:offset + 8].copy().view(">f8" if cloud.is_bigendian else "<f8")[:, 0]
        elif datatype == 2:  # UINT8
            out[:, column] = raw[:, offset]
        else:
            return None
    return out


#: The bytes an MCAP file starts and ends with.
MCAP_MAGIC = b"\x89MCAP0\r\n"


def _why(exc: BaseException) -> str:
    """``Type: message`` of an exception, at most 200 characters."""
    text = str(exc)
    return f"{type(exc).__name__}{': ' + text if text else ''}"[:200]


def read_recording(path: str | os.PathLike[str]) -> tuple[RunData, str | None]:
    """Read the poses and twists of a recording back into a :class:`RunData`, with the scene text.

    Uses mcap's reader and mcap-ros2-support's decoder (built from the schemas in the file),
    so any MCAP file with ``<ns>/B/pose`` (PoseStamped) and ``<ns>/B/twist`` (Twist) topics
    works, and the node's batches (``poses`` and ``velocities`` channels with ``body_names`` in
    their metadata; a stopped body has no sample from where it is flagged). Samples are the log times at which a body has both; at a time written twice (a
    republish) the last message counts. Energy and |L| are left unknown
    (:func:`~rigid_body_sim.offline.rundata.with_derived_quantities` fills them in).

    A file cut anywhere (its writer was killed, the disk was full, a copy stopped half way: no
    footer at its end) is read record by record up to the last whole record before the cut,
    and never raises anything but ValueError; its ``status`` then starts with ``cut short``
    (:data:`CUT_SHORT`) and says why and up to which sim time it was read. Only regular files of at most
    :data:`~rigid_body_sim.offline.rundata.MAX_RUN_FILE_BYTES` are read, no record longer
    than the file.

    Returns
    -------
    data : RunData
        ``meta`` is the ``rigid_body_sim`` metadata record, if any, and ``status`` (from the
        last ``rigid_body_sim_status`` record, or ``cut short: ...``).
    scene_text : str or None
        The attached ``scene.yaml``, if any.

    Raises
    ------
    ValueError
        If the file is not an MCAP file (or not a regular file, or too large) or has no pose
        and twist topics; a file cut before its first complete sample says ``cut short`` too.
    """
    from mcap.reader import NonSeekingReader, SeekingReader
    from mcap_ros2.decoder import DecoderFactory

    path = Path(path)
    poses: dict[str, dict[int, tuple[list[float], list[float]]]] = {}
    twists: dict[str, dict[int, tuple[list[float], list[float]]]] = {}
    meta: dict[str, str] = {}
    found: dict[str, str | None] = {"scene": None, "cut": None}

    def take(schema: Any, channel: Any, message: Any, decoded: Any) -> None:
        topic = channel.topic
        names = channel.metadata.get(BODY_NAMES_KEY)
        if names is not None:
            take_batch(schema.name, topic, json.loads(names), message.log_time, decoded)
            return
        body = topic.rstrip("/").split("/")[-2] if topic.count("/") >= 2 else ""
        if not body:
            return
        if topic.endswith("/pose") and schema.name.endswith("PoseStamped"):
            p, q = decoded.pose.position, decoded.pose.orientation
            poses.setdefault(body, {})[message.log_time] = ([p.x, p.y, p.z], [q.x, q.y, q.z, q.w])
        elif topic.endswith("/twist") and schema.name.endswith("/Twist"):
            v, w = decoded.linear, decoded.angular
            twists.setdefault(body, {})[message.log_time] = ([v.x, v.y, v.z], [w.x, w.y, w.z])

    def take_batch(schema_name: str, topic: str, names: list[str], t_ns: int, decoded: Any) -> None:
        """A ``poses`` or ``velocities`` batch: one sample per body, none for a stopped body."""
        if topic.endswith("/poses") and schema_name.endswith("/PoseArray") and len(decoded.poses) == len(names):
            for body, pose in zip(names, decoded.poses):
                p, q = pose.position, pose.orientation
                poses.setdefault(body, {})[t_ns] = ([p.x, p.y, p.z], [q.x, q.y, q.z, q.w])
        elif topic.endswith("/velocities") and schema_name.endswith("/PointCloud2"):
            columns = _cloud_columns(decoded, ("vx", "vy", "vz", "wx", "wy", "wz", "stopped"), len(names))
            if columns is None:
                return
            v, w, stopped = columns[:, :3].tolist(), columns[:, 3:6].tolist(), columns[:, 6].tolist()
            for k, body in enumerate(names):
                if not stopped[k]:  # no sample once stopped, as a per-body recording has none
                    twists.setdefault(body, {})[t_ns] = (v[k], w[k])

    def read_metadata(reader: Any) -> None:
        for record in reader.iter_metadata():
            if record.name in (METADATA_NAME, STATUS_METADATA_NAME):
                meta.update(record.metadata)

    def read_attachments(reader: Any) -> None:
        for attachment in reader.iter_attachments():
            if attachment.name == SCENE_ATTACHMENT:
                found["scene"] = bytes(attachment.data).decode("utf-8")

    def read_messages(reader: Any) -> None:
        for item in reader.iter_decoded_messages(log_time_order=False):
            take(*item)

    parts = (read_metadata, read_attachments, read_messages)

    def forget() -> None:
        for collected in (poses, twists, meta):
            collected.clear()
        found["scene"] = None

    try:
        f = open_for_reading(path, expected="an MCAP recording")
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the recording ({exc.strerror or exc})") from None
    with f:
        try:
            size = os.fstat(f.fileno()).st_size
            if size > MAX_RUN_FILE_BYTES:
                raise ValueError(f"{path}: the recording is {size} bytes; expected at most {MAX_RUN_FILE_BYTES}")
            head = f.read(len(MCAP_MAGIC))
            if not MCAP_MAGIC.startswith(head):
                raise ValueError(f"{path}: not an MCAP recording (it does not start with the MCAP magic)")
            # A finished file ends with its footer and the magic; one without them was cut (a kill,
            # a full disk, a copy stopped half way) and is read record by record up to the cut.
            f.seek(max(0, size - len(MCAP_MAGIC)))
            finished = size >= 2 * len(MCAP_MAGIC) and f.read(len(MCAP_MAGIC)) == MCAP_MAGIC
            summary = None
            if finished:
                try:
                    f.seek(0)
                    summary = SeekingReader(f, record_size_limit=size).get_summary()
                except Exception:  # noqa: BLE001 - any failure of a damaged summary: read record by record
                    summary = None
            if summary is not None:
                try:
                    for part in parts:
                        f.seek(0)
                        part(SeekingReader(f, decoder_factories=[DecoderFactory()], record_size_limit=size))
                except Exception as exc:  # noqa: BLE001 - an index that does not lead to the data
                    found["cut"] = f"its index cannot be followed ({_why(exc)})"
                    summary = None
                    forget()
            if summary is None:
                for part in parts:
                    f.seek(0)
                    try:  # record by record, keeping every record before the first that cannot be read
                        part(NonSeekingReader(f, decoder_factories=[DecoderFactory()], record_size_limit=size))
                    except Exception as exc:  # noqa: BLE001 - struct.error, zstd, CRC...: all mean "cut here"
                        found["cut"] = found["cut"] or f"it ends in the middle of a record ({_why(exc)})"
                if not finished:
                    found["cut"] = found["cut"] or "it ends without its footer"
        except OSError as exc:
            raise ValueError(f"{path}: cannot read the recording ({exc.strerror or exc})") from None
    cut = found["cut"]
    bodies = [b for b in poses if b in twists]
    if not bodies and cut is not None:
        raise ValueError(f"{path}: {CUT_SHORT} before its first complete sample: {cut}")
    if not bodies:
        raise ValueError(f"{path}: expected <body>/pose (PoseStamped) and <body>/twist (Twist) topics, or poses "
                         f"(PoseArray) and velocities (PointCloud2) with {BODY_NAMES_KEY} in their channel metadata; "
                         "found none")
    times = sorted(set.intersection(*(set(poses[b]) & set(twists[b]) for b in bodies)))
    if not times and cut is not None:
        raise ValueError(f"{path}: {CUT_SHORT} before its first complete sample: {cut}")
    if not times:
        raise ValueError(f"{path}: no time at which every body {bodies} has both a pose and a twist")
    if cut is not None:
        ended = meta.get("status", "")
        meta["status"] = (f"{CUT_SHORT}: {cut}; read up to t = {times[-1] * 1e-9:.9g} s"
                          + (f" (its last status record: {ended})" if ended else ""))
    tracks = {}
    for body in bodies:
        p = np.array([poses[body][t][0] for t in times])
        q = np.array([poses[body][t][1] for t in times])
        v = np.array([twists[body][t][0] for t in times])
        w = np.array([twists[body][t][1] for t in times])
        tracks[body] = BodyTrack(position_world=p, orientation_xyzw=q, linear_velocity_world=v,
                                 angular_velocity_world=w, angular_velocity_body=angular_velocity_body(q, w))
    return RunData(time=np.array(times, dtype=float) * 1e-9, bodies=tracks, meta=meta,
                   source=str(path)), found["scene"]
