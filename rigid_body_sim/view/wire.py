"""``poses`` (geometry_msgs/PoseArray) read straight from its CDR bytes with numpy.

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

__all__ = ["parse_pose_array"]


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
