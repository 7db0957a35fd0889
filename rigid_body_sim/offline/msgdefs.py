"""ROS 2 message definitions (``ros2msg`` text) of the types a recording holds, for MCAP schemas.

An MCAP file with ROS 2 messages carries, per schema, the complete definition of the type in
the ``ros2msg`` encoding, exactly as rosbag2 writes it (rosbag2_cpp's
``LocalMessageDefinitionSource::get_full_text``): the type's own .msg file, verbatim (comments
included), then each type it depends on, depth first, each dependency once, in sorted order
per file, each after a newline, a line of 80 ``=`` and a ``MSG: pkg/Type`` line naming the type
as the field that uses it does (``std_msgs/Header``, ``geometry_msgs/Pose``; never
``pkg/msg/Type``). Foxglove (``@foxglove/rosmsg``) and mcap-ros2-support build their CDR
decoders from this text and look the ``MSG:`` names up by the field types, so a ``MSG:
std_msgs/msg/Header`` line leaves ``std_msgs/Header`` undefined for them.

The texts below are the .msg files of ROS 2 Kilted (geometry_msgs 5.5, std_msgs 5.5,
builtin_interfaces 2.3, rosgraph_msgs 2.3, sensor_msgs 5.5), byte for byte; a test compares
them with the .msg files the ROS wheels install. Kept here, not read from the ROS installation,
so that recording works without ROS.
"""

from __future__ import annotations

import re

__all__ = ["MSG_TEXT", "complete_definition", "dependencies", "DELIMITER"]

#: Line between the definitions of a complete ros2msg definition (80 '=').
DELIMITER = "=" * 80

#: Field types in .msg text: the first word of a line, before an optional array suffix
#: (rosbag2's MSG_FIELD_TYPE_REGEX; comment lines start with '#' and never match).
_FIELD_TYPE = re.compile(r"(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+")
#: The primitive types rosbag2 skips when it looks for dependencies.
PRIMITIVE_TYPES = frozenset({"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
                             "int32", "uint32", "int64", "uint64", "string"})

#: The .msg file of each type, by its full name (``pkg/msg/Type``), verbatim.
MSG_TEXT: dict[str, str] = {
    "builtin_interfaces/msg/Time": """\
# This message communicates ROS Time defined here:
# https://design.ros2.org/articles/clock_and_time.html

# The seconds component, valid over all int32 values.
int32 sec

# The nanoseconds component, valid in the range [0, 1e9).
uint32 nanosec
""",
    "std_msgs/msg/Header": """\
# Standard metadata for higher-level stamped data types.
# This is generally used to communicate timestamped data
# in a particular coordinate frame.

# Two-integer timestamp that is expressed as seconds and nanoseconds.
builtin_interfaces/Time stamp

# Transform frame with which this data is associated.
string frame_id
""",
    "geometry_msgs/msg/Point": """\
# This contains the position of a point in free space
float64 x
float64 y
float64 z
""",
    "geometry_msgs/msg/Quaternion": """\
# This represents an orientation in free space in quaternion form.

float64 x 0
float64 y 0
float64 z 0
float64 w 1
""",
    "geometry_msgs/msg/Vector3": """\
# This represents a vector in free space.

# This is semantically different than a point.
# A vector is always anchored at the origin.
# When a transform is applied to a vector, only the rotational component is applied.

float64 x
float64 y
float64 z
""",
    "geometry_msgs/msg/Pose": """\
# A representation of pose in free space, composed of position and orientation.

Point position
Quaternion orientation
""",
    "geometry_msgs/msg/PoseStamped": """\
# A Pose with reference coordinate frame and timestamp

std_msgs/Header header
Pose pose
""",
    "geometry_msgs/msg/PoseArray": """\
# An array of poses with a header for global reference.

std_msgs/Header header

Pose[] poses
""",
    "geometry_msgs/msg/Twist": """\
# This expresses velocity in free space broken into its linear and angular parts.

Vector3  linear
Vector3  angular
""",
    "geometry_msgs/msg/Wrench": """\
# This represents force in free space, separated into its linear and angular parts.

Vector3  force
Vector3  torque
""",
    "geometry_msgs/msg/WrenchStamped": """\
# A wrench with reference coordinate frame and timestamp

std_msgs/Header header
Wrench wrench
""",
    "rosgraph_msgs/msg/Clock": """\
# This message communicates the current time.
#
# For more information, see https://design.ros2.org/articles/clock_and_time.html.
builtin_interfaces/Time clock
""",
    "sensor_msgs/msg/PointField": """\
# This message holds the description of one point entry in the
# PointCloud2 message format.
uint8 INT8    = 1
uint8 UINT8   = 2
uint8 INT16   = 3
uint8 UINT16  = 4
uint8 INT32   = 5
uint8 UINT32  = 6
uint8 FLOAT32 = 7
uint8 FLOAT64 = 8

# Common PointField names are x, y, z, intensity, rgb, rgba
string name      # Name of field
uint32 offset    # Offset from start of point struct
uint8  datatype  # Datatype enumeration, see above
uint32 count     # How many elements in the field
""",
    "sensor_msgs/msg/PointCloud2": """\
# This message holds a collection of N-dimensional points, which may
# contain additional information such as normals, intensity, etc. The
# point data is stored as a binary blob, its layout described by the
# contents of the "fields" array.
#
# The point cloud data may be organized 2d (image-like) or 1d (unordered).
# Point clouds organized as 2d images may be produced by camera depth sensors
# such as stereo or time-of-flight.

# Time of sensor data acquisition, and the coordinate frame ID (for 3d points).
std_msgs/Header header

# 2D structure of the point cloud. If the cloud is unordered, height is
# 1 and width is the length of the point cloud.
uint32 height
uint32 width

# Describes the channels and their layout in the binary data blob.
PointField[] fields

bool    is_bigendian # Is this data bigendian?
uint32  point_step   # Length of a point in bytes
uint32  row_step     # Length of a row in bytes
uint8[] data         # Actual point data, size is (row_step*height)

bool is_dense        # True if there are no invalid points
""",
    "sensor_msgs/msg/Imu": """\
# This is a message to hold data from an IMU (Inertial Measurement Unit)
#
# Accelerations should be in m/s^2 (not in g's), and rotational velocity should be in rad/sec
#
# If the covariance of the measurement is known, it should be filled in (if all you know is the
# variance of each measurement, e.g. from the datasheet, just put those along the diagonal)
# A covariance matrix of all zeros will be interpreted as "covariance unknown", and to use the
# data a covariance will have to be assumed or gotten from some other source
#
# If you have no estimate for one of the data elements (e.g. your IMU doesn't produce an
# orientation estimate), please set element 0 of the associated covariance matrix to -1
# If you are interpreting this message, please check for a value of -1 in the first element of each
# covariance matrix, and disregard the associated estimate.

std_msgs/Header header

geometry_msgs/Quaternion orientation
float64[9] orientation_covariance # Row major about x, y, z axes

geometry_msgs/Vector3 angular_velocity
float64[9] angular_velocity_covariance # Row major about x, y, z axes

geometry_msgs/Vector3 linear_acceleration
float64[9] linear_acceleration_covariance # Row major x, y z
""",
}


def _full_name(name: str) -> str:
    """``pkg/msg/Type`` of ``pkg/Type`` (or of ``pkg/msg/Type`` itself)."""
    package, _, rest = name.partition("/")
    return name if "/" in rest else f"{package}/msg/{rest}"


def dependencies(type_name: str) -> list[str]:
    """The types the .msg text of ``type_name`` uses, as its fields name them (``pkg/Type``;
    a bare ``Type`` is in the same package), sorted, each once: rosbag2's std::set order."""
    package = type_name.split("/", 1)[0]
    found = set()
    for match in _FIELD_TYPE.finditer(MSG_TEXT[type_name]):
        field_type = match.group(1)
        if field_type in PRIMITIVE_TYPES:
            continue
        found.add(field_type if "/" in field_type else f"{package}/{field_type}")
    return sorted(found)


def complete_definition(type_name: str) -> str:
    """The complete ros2msg definition of ``type_name`` (e.g. ``"geometry_msgs/msg/PoseStamped"``),
    as rosbag2 writes it into the schema record.

    Raises
    ------
    KeyError
        For a type not in :data:`MSG_TEXT` (the known ones are listed).
    """
    if type_name not in MSG_TEXT:
        raise KeyError(f"no message definition for {type_name!r}; known types are {sorted(MSG_TEXT)}")
    seen: set[str] = set()

    def append(name: str) -> str:
        text = MSG_TEXT[name]
        for dependency in dependencies(name):
            if dependency not in seen:
                seen.add(dependency)
                if _full_name(dependency) not in MSG_TEXT:
                    raise KeyError(f"no message definition for {dependency!r}, used by {name!r}")
                text += f"\n{DELIMITER}\nMSG: {dependency}\n" + append(_full_name(dependency))
        return text

    return append(type_name)
