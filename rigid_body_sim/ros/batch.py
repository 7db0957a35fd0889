"""The batched state messages, ``poses`` and ``velocities``, filled with numpy and sent as CDR bytes.

``poses`` is a geometry_msgs/PoseArray: ``header.stamp`` = sim time, ``header.frame_id`` =
``world_frame``, one pose per body in scene order (the order of the ``body_names`` parameter):
centre-of-mass position (m) and orientation (x, y, z, w) of body frame B in the world frame.

``velocities`` is a sensor_msgs/PointCloud2 with the same stamp and frame_id, ``height`` 1,
``width`` = number of bodies, one point per body in the same order, little endian,
``point_step`` 56, ``is_dense`` true, and the fields (:data:`VELOCITY_FIELDS`)

====== ====== ======= ==========================================================
name   offset type    meaning
====== ====== ======= ==========================================================
vx     0      FLOAT64 linear velocity of the centre of mass, world axes (m/s)
vy     8      FLOAT64
vz     16     FLOAT64
wx     24     FLOAT64 angular velocity, world axes (rad/s)
wy     32     FLOAT64
wz     40     FLOAT64
stopped 48    UINT8   1 if the body was stopped (blown up): its last finite state
                      is repeated in both messages; 0 while it moves
====== ====== ======= ==========================================================

(bytes 49 to 55 of each point are zero padding, so every float stays 8-byte aligned).

Why bytes: a PoseArray of 1000 ``Pose`` objects costs milliseconds to build in Python and more
to convert; here one message of the same shape is serialized once by the middleware
(:func:`rclpy.serialization.serialize_message`) as a template, and each tick only the stamp
and the trailing array are replaced (both fixed-size, at offsets found from the template).
:meth:`BatchCdr.check` deserializes a sample both ways at start-up; the node publishes
message objects if they differ.
"""

from __future__ import annotations

import struct

import numpy as np
from geometry_msgs.msg import Pose, PoseArray
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import PointCloud2, PointField

__all__ = ["BatchCdr", "VELOCITY_FIELDS", "VELOCITY_POINT_STEP", "batch_rows", "pose_array", "velocity_cloud"]

#: (name, byte offset, PointField datatype) of each point of ``velocities``.
VELOCITY_FIELDS: tuple[tuple[str, int, int], ...] = (
    ("vx", 0, PointField.FLOAT64), ("vy", 8, PointField.FLOAT64), ("vz", 16, PointField.FLOAT64),
    ("wx", 24, PointField.FLOAT64), ("wy", 32, PointField.FLOAT64), ("wz", 40, PointField.FLOAT64),
    ("stopped", 48, PointField.UINT8))
#: Bytes per point of ``velocities``.
VELOCITY_POINT_STEP = 56
_POSE_BYTES = 7 * 8
#: Most bodies :meth:`BatchCdr.check` reads back (a larger batch is checked on this many, built the same way).
CHECK_BODIES = 64


def _patched(head: bytes, counts: list[tuple[int, int]], n: int, word: struct.Struct) -> bytes:
    """``head`` (of 1 body) with each count field (offset, value per body) set for ``n`` bodies."""
    out = bytearray(head)
    for offset, per_body in counts:
        word.pack_into(out, offset, per_body * n)
    return bytes(out)


def batch_rows(positions_world: np.ndarray, orientations_xyzw: np.ndarray, linear_velocities_world: np.ndarray,
               angular_velocities_world: np.ndarray, stopped: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (N, 7) float64 pose rows (x, y, z, qx, qy, qz, qw) and the (N, 56) uint8 velocity points.

    ``stopped`` : (N,) bool, the flag of each point.
    """
    n = len(positions_world)
    poses = np.empty((n, 7))
    poses[:, :3] = positions_world
    poses[:, 3:] = orientations_xyzw
    points = np.zeros((n, 7))
    points[:, :3] = linear_velocities_world
    points[:, 3:6] = angular_velocities_world
    raw = points.astype("<f8", copy=False).view(np.uint8).reshape(n, VELOCITY_POINT_STEP)
    raw[:, 48] = stopped
    return poses, raw


def velocity_cloud(n: int) -> PointCloud2:
    """An empty-stamped ``velocities`` message for ``n`` bodies (fields, steps; data zero)."""
    msg = PointCloud2()
    msg.height, msg.width = 1, n
    msg.fields = [PointField(name=name, offset=offset, datatype=datatype, count=1)
                  for name, offset, datatype in VELOCITY_FIELDS]
    msg.is_bigendian = False
    msg.point_step = VELOCITY_POINT_STEP
    msg.row_step = VELOCITY_POINT_STEP * n
    msg.is_dense = True
    msg.data = bytes(VELOCITY_POINT_STEP * n)
    return msg


def pose_array(n: int) -> PoseArray:
    """A PoseArray of ``n`` default poses."""
    msg = PoseArray()
    msg.poses = [Pose() for _ in range(n)]
    return msg


class BatchCdr:
    """CDR bytes of ``poses`` and ``velocities`` for a fixed number of bodies and frame_id.

    Parameters
    ----------
    n : int
        Number of bodies.
    frame_id : str
        ``header.frame_id`` of both messages.

    Raises
    ------
    ValueError
        If the middleware's serialization does not have the expected shape (then publish
        message objects).
    """

    def __init__(self, n: int, frame_id: str):
        self.n = n
        self.frame_id = frame_id
        # The middleware's bytes of 1, 2 and 3 bodies (building the messages of n bodies as objects
        # would take seconds at 10⁵): the heads differ in the count fields (the sequence lengths,
        # width, row_step), each a uint32 k·n, and in padding bytes the serializer leaves as they
        # were (any value is valid there). A count field is a word that reads k, 2k and 3k;
        # check() reads a batch back on CHECK_BODIES bodies.
        heads = [self._templates(k) for k in (1, 2, 3)]
        pose_bytes = heads[0][0]
        if pose_bytes[:2] not in (b"\x00\x01", b"\x00\x00") or heads[0][1][:4] != pose_bytes[:4]:
            raise ValueError(f"unexpected CDR encapsulation {pose_bytes[:4]!r}")
        self._order = "<" if pose_bytes[:2] == b"\x00\x01" else ">"
        self._stamp = struct.Struct(self._order + "iI")
        self._pose_dtype = np.dtype(self._order + "f8")
        word = struct.Struct(self._order + "I")
        parts = []
        for which in range(3):  # pose head, cloud head, cloud tail
            one, two, three = (h[which] for h in heads)
            if not len(one) == len(two) == len(three):
                raise ValueError("the message heads change length with the body count")
            counts = []
            for o in range(4, len(one) - 3, 4):  # CDR aligns a uint32 to 4 from the end of the encapsulation
                k, k2, k3 = (word.unpack_from(h, o)[0] for h in (one, two, three))
                if k and k2 == 2 * k and k3 == 3 * k:
                    counts.append((o, k))
            parts.append(_patched(one, counts, n, word))
        self._pose_head, self._cloud_head, self._cloud_tail = parts

    def _templates(self, n: int) -> tuple[bytes, bytes, bytes]:
        """(PoseArray head, PointCloud2 head, PointCloud2 tail) of ``n`` bodies as the middleware serializes them."""
        poses = pose_array(n)
        poses.header.frame_id = self.frame_id
        pose_bytes = serialize_message(poses)
        cloud = velocity_cloud(n)
        cloud.header.frame_id = self.frame_id
        cloud_bytes = serialize_message(cloud)
        # PoseArray: header, then poses (sequence of 7 float64, 8-aligned) at the very end.
        # PointCloud2: ... data (uint8 sequence), then is_dense (1 byte) at the very end.
        data_len, tail = VELOCITY_POINT_STEP * n, 1
        return (pose_bytes[: len(pose_bytes) - n * _POSE_BYTES], cloud_bytes[: len(cloud_bytes) - data_len - tail],
                cloud_bytes[len(cloud_bytes) - tail:])

    def _stamped(self, head: bytes, sec: int, nanosec: int) -> bytes:
        return head[:4] + self._stamp.pack(sec, nanosec) + head[12:]

    def poses(self, sec: int, nanosec: int, rows: np.ndarray) -> bytes:
        """CDR of the PoseArray of ``rows`` (N, 7): x, y, z, qx, qy, qz, qw per body."""
        return b"".join((self._stamped(self._pose_head, sec, nanosec),
                         rows.astype(self._pose_dtype, copy=False).tobytes()))

    def velocities(self, sec: int, nanosec: int, points: np.ndarray) -> bytes:
        """CDR of the PointCloud2 of ``points`` (N, 56) uint8 (see :func:`batch_rows`)."""
        return b"".join((self._stamped(self._cloud_head, sec, nanosec), points.tobytes(), self._cloud_tail))

    def check(self) -> str | None:
        """Why these bytes differ from the middleware's messages, or None if they agree (a sample
        with distinct values in every pose and point, a large stamp, a stopped body), on at most
        :data:`CHECK_BODIES` bodies built the same way (reading 10⁵ poses back as objects takes seconds)."""
        if self.n > CHECK_BODIES:
            return BatchCdr(CHECK_BODIES, self.frame_id).check()
        rng = np.random.default_rng(0)
        n = self.n
        p, q = rng.normal(size=(n, 3)), rng.normal(size=(n, 4))
        v, w = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
        stopped = np.arange(n) % 2 == 1
        rows, points = batch_rows(p, q, v, w, stopped)
        sec, nanosec = 2_000_000_000, 999_999_999
        back = deserialize_message(self.poses(sec, nanosec, rows), PoseArray)
        if (back.header.stamp.sec, back.header.stamp.nanosec, back.header.frame_id) != (sec, nanosec, self.frame_id):
            return f"PoseArray header read back as {back.header}"
        got = np.array([[a.position.x, a.position.y, a.position.z, a.orientation.x, a.orientation.y,
                         a.orientation.z, a.orientation.w] for a in back.poses]).reshape(n, 7)
        if not np.array_equal(got, rows):
            return "PoseArray poses read back differently"
        cloud = deserialize_message(self.velocities(sec, nanosec, points), PointCloud2)
        reference = velocity_cloud(n)
        reference.header.stamp.sec, reference.header.stamp.nanosec = sec, nanosec
        reference.header.frame_id = self.frame_id
        reference.data = points.tobytes()
        if cloud != reference:
            return "PointCloud2 read back differently"
        return None
