"""The node's per-tick messages serialized directly to CDR, for ``Publisher.publish(bytes)``.

rclpy publishes a message object by converting it field by field to its C struct and letting
the middleware serialize that (≈ 7 µs per PoseStamped here, before the middleware's own send);
a ``bytes`` payload is handed to ``rcl_publish_serialized_message`` as is (≈ 2 µs). With 100
bodies the node publishes 200 messages a tick, so it builds each PoseStamped, Twist and Clock
payload with one :meth:`struct.Struct.pack` from plain floats.

The layout is plain CDR (OMG XCDR version 1, the encoding rmw_fastrtps and rmw_cyclonedds put
on the wire for these types): a 4-byte encapsulation header (representation identifier, two
bytes of options), then the fields in declaration order, each aligned to its own size counted
from the end of the header, integers and floats in the byte order the header names, a string
as a uint32 length that counts its terminating NUL, then the bytes and the NUL. The
identifier is taken from what the middleware itself produces for each type
(``rclpy.serialization.serialize_message``), and :func:`check_against_middleware` compares a
sample with the middleware's serialization; the node publishes message objects if that check
fails.

Quaternions are (x, y, z, w), the order of geometry_msgs/Quaternion.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from rclpy.serialization import deserialize_message, serialize_message
from rosgraph_msgs.msg import Clock

__all__ = ["PoseTwistClockCdr", "check_against_middleware"]

#: Plain CDR, little endian / big endian (XCDR1 representation identifiers).
_CDR_LE = b"\x00\x01"
_CDR_BE = b"\x00\x00"


def _string_block(text: str, offset: int, order: str) -> bytes:
    """CDR of a string starting at ``offset`` (4-aligned), padded so the next field is 8-aligned."""
    data = text.encode("utf-8") + b"\x00"
    block = struct.pack(order + "I", len(data)) + data
    end = offset + len(block)
    return block + b"\x00" * (-end % 8)


class PoseTwistClockCdr:
    """Serializes PoseStamped and TwistStamped (with a fixed ``frame_id``), Twist and Clock to CDR bytes.

    Parameters
    ----------
    frame_id : str
        ``header.frame_id`` of every PoseStamped (the world frame).

    Raises
    ------
    ValueError
        If the middleware does not use plain CDR for these types (then publish message objects).
    """

    def __init__(self, frame_id: str):
        encapsulation = serialize_message(Twist())[:4]
        if encapsulation[:2] not in (_CDR_LE, _CDR_BE):
            raise ValueError(f"unexpected CDR encapsulation {encapsulation!r}")
        order = "<" if encapsulation[:2] == _CDR_LE else ">"
        self._head = encapsulation[:2] + b"\x00\x00"
        self.frame_id = frame_id
        frame = _string_block(frame_id, 8, order)
        # header.stamp (int32 sec, uint32 nanosec), header.frame_id, position xyz, orientation xyzw
        self._pose = struct.Struct(f"{order}4siI{len(frame)}s7d")
        self._frame = frame
        self._twist = struct.Struct(f"{order}4s6d")  # linear xyz, angular xyz
        # header.stamp, header.frame_id, twist.linear xyz, twist.angular xyz
        self._twist_stamped = struct.Struct(f"{order}4siI{len(frame)}s6d")
        self._clock = struct.Struct(f"{order}4siI")  # clock.sec, clock.nanosec

    def pose_stamped(self, sec: int, nanosec: int, position: Sequence[float], orientation_xyzw: Sequence[float]) -> bytes:
        """CDR of a PoseStamped at stamp (``sec``, ``nanosec``) in ``frame_id``."""
        p, q = position, orientation_xyzw
        return self._pose.pack(self._head, sec, nanosec, self._frame, p[0], p[1], p[2], q[0], q[1], q[2], q[3])

    def twist(self, linear: Sequence[float], angular: Sequence[float]) -> bytes:
        """CDR of a Twist (``linear`` and ``angular``, 3 floats each)."""
        return self._twist.pack(self._head, linear[0], linear[1], linear[2], angular[0], angular[1], angular[2])

    def twist_stamped(self, sec: int, nanosec: int, linear: Sequence[float], angular: Sequence[float]) -> bytes:
        """CDR of a TwistStamped at stamp (``sec``, ``nanosec``) in ``frame_id``."""
        return self._twist_stamped.pack(self._head, sec, nanosec, self._frame, linear[0], linear[1], linear[2],
                                         angular[0], angular[1], angular[2])

    def clock(self, sec: int, nanosec: int) -> bytes:
        """CDR of a rosgraph_msgs/Clock."""
        return self._clock.pack(self._head, sec, nanosec)


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def check_against_middleware(cdr: PoseTwistClockCdr) -> str | None:
    """Why ``cdr``'s bytes differ from the middleware's for sample messages, or None if they agree.

    Compares lengths and everything but padding (by deserializing both ways) for a stamp with
    large fields, negative zero, a subnormal and a non-unit quaternion.
    """
    position = (1.25, -0.0, 5e-324)
    orientation = (0.1, -0.2, 0.3, 2.0)
    linear, angular = (-1.5, 2.5e300, 3.0), (0.0, -7.0, 1e-9)
    stamp = Time(sec=2_000_000_000, nanosec=999_999_999)

    reference = PoseStamped()
    reference.header.stamp = stamp
    reference.header.frame_id = cdr.frame_id
    p, q = reference.pose.position, reference.pose.orientation
    p.x, p.y, p.z = position
    q.x, q.y, q.z, q.w = orientation
    ours = cdr.pose_stamped(stamp.sec, stamp.nanosec, position, orientation)
    if len(ours) != len(serialize_message(reference)):
        return f"PoseStamped: {len(ours)} bytes, the middleware makes {len(serialize_message(reference))}"
    back = deserialize_message(ours, PoseStamped)
    got = (back.pose.position.x, back.pose.position.y, back.pose.position.z,
           back.pose.orientation.x, back.pose.orientation.y, back.pose.orientation.z, back.pose.orientation.w)
    if (back.header.stamp != stamp or back.header.frame_id != cdr.frame_id
            or not all(_same(a, b) and math.copysign(1, a) == math.copysign(1, b) for a, b in zip(got, position + orientation))):
        return f"PoseStamped: read back as {back}"

    reference_twist = Twist()
    reference_twist.linear.x, reference_twist.linear.y, reference_twist.linear.z = linear
    reference_twist.angular.x, reference_twist.angular.y, reference_twist.angular.z = angular
    ours = cdr.twist(linear, angular)
    if ours != serialize_message(reference_twist):  # no padding in a Twist: bytewise equal
        return "Twist: bytes differ from the middleware's"

    reference_stamped = TwistStamped()
    reference_stamped.header.stamp, reference_stamped.header.frame_id = stamp, cdr.frame_id
    reference_stamped.twist = reference_twist
    ours = cdr.twist_stamped(stamp.sec, stamp.nanosec, linear, angular)
    if len(ours) != len(serialize_message(reference_stamped)) or deserialize_message(ours, TwistStamped) != reference_stamped:
        return "TwistStamped: bytes differ from the middleware's"

    ours = cdr.clock(stamp.sec, stamp.nanosec)
    if ours != serialize_message(Clock(clock=stamp)):
        return "Clock: bytes differ from the middleware's"
    return None
