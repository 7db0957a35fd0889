"""The node's recording (``record_path``): one MCAP file at a time, opened before it is needed.

A new file is opened while a parameter change is prepared (never under the tick lock, so an
open that blocks or fails only refuses the change), swapped in with the change, and the one it
replaces is finished afterwards. A failed write (disk full...) ends the recording with an error
in the log; the simulation goes on. Every write, and taking the recorder away, holds the
recording's own lock: a recorder taken away (by a change, the orderly stop or the stop's
watchdog) has no write under way and gets none later, so the count it logs when finished is
what the file holds.

Crash safety: the node records with :class:`FlushingRecorder`, the offline
:class:`~rigid_body_sim.offline.recording.McapRecorder` (same topics, schemas, metadata and
status records, channel metadata ``offered_qos_profiles``, so
:func:`~rigid_body_sim.offline.recording.read_recording`, Foxglove and any MCAP tool read it)
written through mcap's own ``mcap.writer.Writer`` with messages serialized by rclpy, whose
public ``flush()`` ends the open chunk. The node flushes at most :data:`FLUSH_PERIOD_S` wall
seconds after a message was written (checked every tick, also while paused), so after a
SIGKILL or a crash the file holds every message written up to about ``FLUSH_PERIOD_S`` plus one
tick before the kill, and is read as ``cut short`` (no summary). A clean stop finishes the file.
"""

from __future__ import annotations

import importlib
import json
import os
import threading
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

import numpy as np

from mcap.writer import CompressionType, Writer
from rclpy.serialization import serialize_message

from ..core import Simulator
from ..offline.msgdefs import complete_definition
from ..offline.recording import (BODY_NAMES_KEY, CHUNK_SIZE, METADATA_NAME, SCENE_ATTACHMENT, STATUS_INCOMPLETE,
                                 QOS_KEY, STATUS_METADATA_NAME, McapRecorder, channel_metadata, offered_qos_profiles,
                                 stamp_ns)
from ..safe_open import open_for_writing
from .cdr import PoseTwistClockCdr
from .file_access import RecordTargets

__all__ = ["NodeRecording", "FlushingRecorder", "FLUSH_PERIOD_S", "UNCOMPRESSED_ABOVE_BODIES"]

#: Longest wall time (s) a written message waits in memory before it is flushed to the file.
FLUSH_PERIOD_S = 0.5


def _message_from_dict(msg_type: Any, fields: Mapping[str, Any]) -> Any:
    """An rclpy message of ``msg_type`` with the (nested) ``fields`` of a recorder's dict."""
    msg = msg_type()
    for name, value in fields.items():
        if isinstance(value, Mapping):
            value = _message_from_dict(type(getattr(msg, name)), value)
        setattr(msg, name, value)
    return msg


#: Above this many bodies the node records without compression: a tick's batches are ~112 bytes
#: a body of float64 state, which zstd shrinks by ~4% for three times the CPU of writing them
#: (measured at 10⁵ bodies: ~100 ms against ~35 ms a tick), more than a 10 Hz tick can spare.
UNCOMPRESSED_ABOVE_BODIES = 1000


class FlushingRecorder(McapRecorder):
    """:class:`McapRecorder` written with ``mcap.writer.Writer`` and rclpy's serializer, flushable.

    Parameters are those of :class:`McapRecorder`, and ``compress`` (zstd chunks; else none).
    """

    def __init__(self, path: str | os.PathLike[str], *, world_frame: str = "world", namespace: str = "/",
                 metadata: Mapping[str, str] | None = None, scene_text: str | None = None,
                 offered_qos: Mapping[str, tuple[str, int, str, str]] | None = None, compress: bool = True):
        self.path = Path(path)
        # ``offered_qos_profiles`` of the topics whose publishers qos_overrides changed (topic names
        # relative to the namespace, or absolute); every other topic's is the default (topic_qos).
        prefix = namespace.rstrip("/") + "/"
        self._offered_qos = {topic if topic.startswith("/") else prefix + topic: {QOS_KEY: offered_qos_profiles(*qos)}
                             for topic, qos in (offered_qos or {}).items()}
        self.world_frame = world_frame
        self._prefix = namespace.rstrip("/") + "/"
        self._file = open_for_writing(self.path, expected="an .mcap file")
        try:
            self._writer = Writer(self._file, chunk_size=CHUNK_SIZE,
                                  compression=CompressionType.ZSTD if compress else CompressionType.NONE)
            self._writer.start(profile="ros2", library="rigid_body_sim")
            if metadata:
                self._writer.add_metadata(METADATA_NAME, {str(k): str(v) for k, v in metadata.items()})
            self._writer.add_metadata(STATUS_METADATA_NAME, {"status": STATUS_INCOMPLETE})
            if scene_text is not None:
                self._writer.add_attachment(0, 0, SCENE_ATTACHMENT, "application/yaml", scene_text.encode("utf-8"))
            self._file.flush()
        except BaseException:
            self._file.close()
            self._file = None
            raise
        self._cdr = PoseTwistClockCdr(world_frame)
        self._schema_ids: dict[str, tuple[int, Any]] = {}  # name -> (schema id, message class)
        self._channel_ids: dict[str, int] = {}
        self._wrench_keys: list[tuple[str, str]] = []
        self._batch_channels: dict[tuple[str, ...], tuple[int, int]] = {}  # body order -> (poses, velocities)
        self._batch_names: tuple[str, ...] | None = None  # the order last written (compared by identity first)
        self._batch_ids: tuple[int, int] = (0, 0)
        self.message_count = 0
        self._unflushed_since: float | None = None

    def write_state(self, time: float, bodies: Iterable[str], positions_world: np.ndarray,
                    orientations_xyzw: np.ndarray, linear_velocities_world: np.ndarray,
                    angular_velocities_world: np.ndarray) -> None:
        """As :meth:`McapRecorder.write_state`, serialized by :mod:`.cdr` (the bytes the node publishes)."""
        ns = stamp_ns(time)
        sec, nanosec = divmod(ns, 1_000_000_000)
        cdr = self._cdr
        p, q = positions_world.tolist(), orientations_xyzw.tolist()
        v, w = linear_velocities_world.tolist(), angular_velocities_world.tolist()
        for i, body in enumerate(bodies):
            self._write_bytes(f"{self._prefix}{body}/pose", "geometry_msgs/msg/PoseStamped",
                              cdr.pose_stamped(sec, nanosec, p[i], q[i]), ns)
            self._write_bytes(f"{self._prefix}{body}/twist", "geometry_msgs/msg/Twist", cdr.twist(v[i], w[i]), ns)

    def write_batches(self, body_names: tuple[str, ...], sec: int, nanosec: int, poses_cdr: bytes,
                      velocities_cdr: bytes) -> None:
        """Write ``<ns>/poses`` (geometry_msgs/PoseArray) and ``<ns>/velocities``
        (sensor_msgs/PointCloud2), the CDR bytes the node published at sim time ``sec.nanosec``
        (layout: ros/batch.py). Their channels carry the scene order in their metadata
        (:data:`~rigid_body_sim.offline.recording.BODY_NAMES_KEY`, a JSON list); a new pair of
        channels is registered whenever the order changes (a scene change, a spawn)."""
        if body_names is not self._batch_names:
            key = tuple(body_names)
            channels = self._batch_channels.get(key)
            if channels is None:
                names = {BODY_NAMES_KEY: json.dumps(list(key))}
                channels = self._batch_channels[key] = tuple(
                    self._writer.register_channel(f"{self._prefix}{topic}", "cdr", self._schema(schema)[0],
                                                  self._metadata(f"{self._prefix}{topic}", names))
                    for topic, schema in (("poses", "geometry_msgs/msg/PoseArray"),
                                          ("velocities", "sensor_msgs/msg/PointCloud2")))
            self._batch_names, self._batch_ids = body_names, channels
        ns = sec * 1_000_000_000 + nanosec
        self._add(self._batch_ids[0], poses_cdr, ns)
        self._add(self._batch_ids[1], velocities_cdr, ns)

    def write_clock(self, time: float) -> None:
        """As :meth:`McapRecorder.write_clock`."""
        ns = stamp_ns(time)
        self._write_bytes("/clock", "rosgraph_msgs/msg/Clock", self._cdr.clock(*divmod(ns, 1_000_000_000)), ns)

    def _write(self, topic: str, schema: str, message: dict[str, Any], ns: int) -> None:
        known = self._schema(schema)
        self._write_bytes(topic, schema, serialize_message(_message_from_dict(known[1], message)), ns)

    def _schema(self, schema: str) -> tuple[int, Any]:
        known = self._schema_ids.get(schema)
        if known is None:
            package, _, name = schema.split("/")
            known = (self._writer.register_schema(schema, "ros2msg", complete_definition(schema).encode()),
                     getattr(importlib.import_module(f"{package}.msg"), name))
            self._schema_ids[schema] = known
        return known

    def _write_bytes(self, topic: str, schema: str, data: bytes, ns: int) -> None:
        channel = self._channel_ids.get(topic)
        if channel is None:
            if self._file is None:
                raise ValueError(f"recording {self.path} is closed")
            channel = self._channel_ids[topic] = self._writer.register_channel(topic, "cdr", self._schema(schema)[0],
                                                                               self._metadata(topic))
        self._add(channel, data, ns)

    def _metadata(self, topic: str, extra: Mapping[str, str] | None = None) -> dict[str, str]:
        """``topic``'s channel metadata, with the QoS its publisher really offers."""
        return channel_metadata(topic, {**(extra or {}), **self._offered_qos.get(topic, {})})

    def _add(self, channel: int, data: bytes, ns: int) -> None:
        if self._file is None:
            raise ValueError(f"recording {self.path} is closed")
        self._writer.add_message(channel, log_time=ns, data=data, publish_time=ns, sequence=self.message_count)
        self.message_count += 1
        if self._unflushed_since is None:
            self._unflushed_since = time.monotonic()

    def flush_if_due(self, period_s: float = FLUSH_PERIOD_S) -> bool:
        """Flush (end the chunk, write it, flush the file) if a message has waited ``period_s``; True if it did."""
        since = self._unflushed_since
        if since is None or self._file is None or time.monotonic() - since < period_s:
            return False
        self._writer.flush()
        self._file.flush()
        self._unflushed_since = None
        return True


class NodeRecording:
    """The current recorder, if any.

    Parameters
    ----------
    logger : rclpy logger
    world_frame, namespace, node_name : str
        Written into each recording (frame of poses, topic prefix, metadata).
    overwrite : bool
        ``record_overwrite``: a recording may overwrite an existing file the node did not create.
    """

    def __init__(self, logger: Any, world_frame: str, namespace: str, node_name: str, overwrite: bool = False):
        self._logger = logger
        self._world_frame = world_frame
        self._namespace = namespace
        self._node_name = node_name
        self.recorder: McapRecorder | None = None
        self.targets = RecordTargets(overwrite)
        #: (history, depth, reliability, durability) by topic of the publishers whose QoS
        #: qos_overrides may change (StatePublishers.offered_qos), declared in each recording.
        self.offered_qos: Mapping[str, tuple[str, int, str, str]] = {}
        self._writing = threading.RLock()  # held by every write and by taking the recorder away

    def open(self, path: str, sim: Simulator, *, dt: float | None = None, integrator: str | None = None) -> McapRecorder:
        """A new recorder at ``path`` for ``sim`` (not yet the current one).

        Raises
        ------
        OSError
            If the file cannot be created, or may not be recorded to (:class:`RecordTargets`).
        """
        self.targets.claim(path, sim.scene.source, self.recorder)
        source = Path(sim.scene.source)
        try:
            scene_text = source.read_text(encoding="utf-8") if source.is_file() else None
        except (OSError, UnicodeDecodeError):
            scene_text = None
        recorder = FlushingRecorder(
            path, world_frame=self._world_frame, namespace=self._namespace, scene_text=scene_text,
            compress=len(sim.body_names) <= UNCOMPRESSED_ABOVE_BODIES,
            metadata={"scene": str(sim.scene.source), "integrator": integrator or sim.integrator,
                      "dt": repr(sim.dt if dt is None else dt), "node": self._node_name},
            offered_qos=self.offered_qos)
        self._logger.info(f"recording to {path}")
        return recorder

    def replace(self, recorder: McapRecorder | None) -> McapRecorder | None:
        """Make ``recorder`` the current one (hold the node's lock); returns the one it replaced,
        to :meth:`finish` after the lock is released. Waits for a write under way: the one replaced
        gets no write after this returns."""
        with self._writing:
            old, self.recorder = self.recorder, recorder
        return old

    def finish_now(self, wait_s: float) -> None:
        """Take the recorder away and finish it, waiting at most ``wait_s`` for a write under way (an
        exit that cannot wait for the node's lock); a write stuck longer leaves the file unfinished
        (read as ``cut short``) rather than keep the process from exiting."""
        if not self._writing.acquire(timeout=wait_s):
            self._logger.error(f"a write into the recording has run over {wait_s:g} s; leaving it unfinished")
            return
        try:
            recorder, self.recorder = self.recorder, None
        finally:
            self._writing.release()
        if recorder is not None:
            self.finish(recorder)

    def write(self, write: Callable[[McapRecorder], None]) -> None:
        """``write(recorder)`` if recording; a failed write ends the recording."""
        with self._writing:
            recorder = self.recorder
            if recorder is None:
                return
            try:
                write(recorder)
            except OSError as exc:
                self._logger.error(f"recording to {recorder.path} failed ({exc}); not recording")
                self.recorder = None
                self.finish(recorder)

    def flush_if_due(self) -> None:
        """Flush the recording if a message has waited :data:`FLUSH_PERIOD_S` (every tick, also paused)."""
        recorder = self.recorder
        if isinstance(recorder, FlushingRecorder):
            self.write(lambda r: r.flush_if_due())

    def finish(self, recorder: McapRecorder) -> None:
        """Close ``recorder``: its summary and index are written, so the file is complete."""
        try:
            recorder.close()
        except OSError as exc:
            self._logger.error(f"could not finish the recording {recorder.path} ({exc})")
        else:
            self._logger.info(f"recording finished: {recorder.path} ({recorder.message_count} messages)")
