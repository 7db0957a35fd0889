"""Conversions between ROS messages and the core's arrays, and validation of incoming wrenches.

ROS messages use (x, y, z, w) quaternions, exactly like the core's public API, so no reordering
happens here. Stamps are simulated time. Everything incoming is validated here, once: the
node never passes a message the core would reject.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose, PoseStamped, Twist, WrenchStamped
from nav_msgs.msg import Odometry

__all__ = [
    "MAX_ROS_TIME_S",
    "MAX_WRENCH_COMPONENT",
    "RejectedMessage",
    "time_msg_from_seconds",
    "wrench_from_msg",
    "fill_pose_stamped",
    "fill_twist",
    "fill_odometry",
]

#: Any incoming force, torque or impulse component larger than this (in magnitude) is absurd.
MAX_WRENCH_COMPONENT = 1e12
#: The last second builtin_interfaces/Time can hold (``sec`` is an int32): about 68 years.
MAX_ROS_TIME_S = 2**31 - 1


@dataclass
class RejectedMessage(Exception):
    """An incoming message that was dropped: ``reason`` is a short key, ``detail`` says why."""

    reason: str
    detail: str

    def __str__(self) -> str:
        return self.detail


def time_msg_from_seconds(seconds: float) -> Time:
    """builtin_interfaces/Time for a non-negative simulated time in seconds (nanosecond resolution)."""
    total_ns = int(round(seconds * 1e9))
    return Time(sec=total_ns // 1_000_000_000, nanosec=total_ns % 1_000_000_000)


def wrench_from_msg(msg: WrenchStamped) -> tuple[np.ndarray, np.ndarray]:
    """Force and torque arrays, shape (3,), from a WrenchStamped, validated.

    Raises
    ------
    RejectedMessage
        ``non_finite`` for NaN or ±Inf components, ``too_large`` for any component above
        :data:`MAX_WRENCH_COMPONENT` in magnitude.
    """
    f, t = msg.wrench.force, msg.wrench.torque
    values = (f.x, f.y, f.z, t.x, t.y, t.z)
    for v in values:
        if not math.isfinite(v):
            raise RejectedMessage("non_finite", f"non-finite component in {values}")
    for v in values:
        if abs(v) > MAX_WRENCH_COMPONENT:
            raise RejectedMessage("too_large", f"component {v:g} exceeds {MAX_WRENCH_COMPONENT:g} in magnitude")
    return np.array(values[:3]), np.array(values[3:])


def _fill_pose(pose: Pose, position: np.ndarray, orientation_xyzw: np.ndarray) -> None:
    p, q = pose.position, pose.orientation
    p.x, p.y, p.z = float(position[0]), float(position[1]), float(position[2])
    q.x, q.y, q.z, q.w = (float(orientation_xyzw[0]), float(orientation_xyzw[1]),
                          float(orientation_xyzw[2]), float(orientation_xyzw[3]))


def _fill_vector(vector, values: np.ndarray) -> None:
    vector.x, vector.y, vector.z = float(values[0]), float(values[1]), float(values[2])


def fill_pose_stamped(msg: PoseStamped, stamp: Time, frame_id: str, position_world: np.ndarray,
                      orientation_xyzw: np.ndarray) -> PoseStamped:
    """Fill ``msg`` with the body frame's pose in ``frame_id`` (the world); returns it."""
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    _fill_pose(msg.pose, position_world, orientation_xyzw)
    return msg


def fill_twist(msg: Twist, linear_velocity_world: np.ndarray, angular_velocity_world: np.ndarray) -> Twist:
    """Fill ``msg`` with the centre-of-mass velocity and the angular velocity, both world axes."""
    _fill_vector(msg.linear, linear_velocity_world)
    _fill_vector(msg.angular, angular_velocity_world)
    return msg


def fill_odometry(msg: Odometry, stamp: Time, world_frame: str, body_frame: str, position_world: np.ndarray,
                  orientation_xyzw: np.ndarray, linear_velocity_body: np.ndarray,
                  angular_velocity_body: np.ndarray) -> Odometry:
    """Fill nav_msgs/Odometry as nav_msgs defines it: pose in ``world_frame``, twist in ``body_frame`` axes."""
    msg.header.stamp = stamp
    msg.header.frame_id = world_frame
    msg.child_frame_id = body_frame
    _fill_pose(msg.pose.pose, position_world, orientation_xyzw)
    _fill_vector(msg.twist.twist.linear, linear_velocity_body)
    _fill_vector(msg.twist.twist.angular, angular_velocity_body)
    return msg
