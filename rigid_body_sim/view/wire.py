"""The node's batches read with numpy: ``poses`` from its CDR bytes, ``velocities`` and ``contacts`` clouds.

The view subscribes to ``poses`` raw (``raw=True``): at 1000 bodies and 100 ticks a second,
building 1000 Pose objects per message in Python would cost the view more than drawing them.
Plain CDR (XCDR1): a 4-byte encapsulation header (byte 1: 1 little endian, 0 big endian), then
``header.stamp`` (int32 sec, uint32 nanosec), ``header.frame_id`` (uint32 length counting the NUL,
the bytes), the pose count (uint32, 4-aligned), then each pose's 7 float64 (8-aligned from the
end of the encapsulation header): position x, y, z (m), orientation x, y, z, w.
"""

from __future__ import annotations

import struct

import numpy as np

__all__ = ["parse_pose_array", "velocities_from_cloud", "contacts_from_cloud"]

_VELOCITY_DTYPE = np.dtype([("v", "<f8", 3), ("w", "<f8", 3), ("stopped", "u1"), ("pad", "V7")])
_CONTACT_DTYPE = np.dtype({"names": ["p", "n", "body", "state"], "formats": [("<f8", 3), ("<f8", 3), "<u4", "u1"],
                           "offsets": [0, 24, 96, 104], "itemsize": 112})


def velocities_from_cloud(msg) -> tuple[np.ndarray, np.ndarray] | None:
    """(v (N, 3) m/s, ω (N, 3) rad/s), world axes, of a ``velocities`` PointCloud2 (docs/interface.md,
    "Many bodies"), or None if its layout is not that one."""
    if msg.point_step != _VELOCITY_DTYPE.itemsize or msg.is_bigendian or len(msg.data) < msg.width * msg.point_step:
        return None
    rows = np.frombuffer(bytes(msg.data), dtype=_VELOCITY_DTYPE, count=msg.width)
    return rows["v"].copy(), rows["w"].copy()


def contacts_from_cloud(msg) -> tuple[np.ndarray, np.ndarray] | None:
    """(points (K, 3) m, unit normals (K, 3)), world, of a ``contacts`` PointCloud2 (docs/interface.md,
    "Contacts"), or None if its layout is not that one."""
    if msg.point_step != _CONTACT_DTYPE.itemsize or msg.is_bigendian or len(msg.data) < msg.width * msg.point_step:
        return None
    rows = np.frombuffer(bytes(msg.data), dtype=_CONTACT_DTYPE, count=msg.width)
    return rows["p"].copy(), rows["n"].copy()


def parse_pose_array(raw: bytes) -> tuple[tuple[int, int], str, np.ndarray, np.ndarray]:
    """((sec, nanosec), frame_id, positions (N, 3) m, orientations (N, 4) x, y, z, w) of a
    serialized PoseArray. Raises ValueError if the bytes are not one."""
    if len(raw) < 16 or raw[0] != 0 or raw[1] not in (0, 1):
        raise ValueError("not a plain-CDR PoseArray")
    order = "<" if raw[1] == 1 else ">"
    body = memoryview(raw)[4:]
    sec, nanosec, length = struct.unpack_from(order + "iII", body, 0)
    offset = 12 + length
    frame_id = bytes(body[12:12 + max(0, length - 1)]).decode("utf-8", "replace")
    offset = (offset + 3) & ~3
    (count,) = struct.unpack_from(order + "I", body, offset)
    offset = (offset + 4 + 7) & ~7
    if count == 0:
        return (sec, nanosec), frame_id, np.zeros((0, 3)), np.zeros((0, 4))
    if offset + 56 * count > len(body):
        raise ValueError("PoseArray shorter than its pose count")
    values = np.frombuffer(body, dtype=np.dtype(np.float64).newbyteorder(order), count=7 * count,
                           offset=offset).reshape(count, 7).astype(np.float64)
    return (sec, nanosec), frame_id, values[:, :3], values[:, 3:]
