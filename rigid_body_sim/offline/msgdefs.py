"""ROS 2 message definitions (``ros2msg`` text) of the types a recording holds, for MCAP schemas.

An MCAP file with ROS 2 messages carries, per schema, the complete definition of the type in
the ``ros2msg`` encoding that rosbag2 writes: the type's own .msg text first, then each type
it depends on (recursively), each after a line of 80 ``=`` and a ``MSG: pkg/msg/Type`` line.
Foxglove and mcap-ros2-support build their CDR decoders from this text, so it must match the
real types field for field. The texts below are the .msg files of ROS 2 Kilted (geometry_msgs
5.5, std_msgs 5.5, builtin_interfaces 2.3, rosgraph_msgs 2.3, sensor_msgs 5.5) without comments; a test
compares them with the .msg files the ROS wheels install. Kept here, not read from the ROS
installation, so that recording works without ROS.
"""

from __future__ import annotations

__all__ = ["MSG_TEXT", "complete_definition", "DELIMITER"]

#: Line between the definitions of a complete ros2msg definition (80 '=').
DELIMITER = "=" * 80

#: The .msg text of each type, by its full name, and the types it uses (full names).
MSG_TEXT: dict[str, tuple[str, tuple[str, ...]]] = {
    "builtin_interfaces/msg/Time": ("int32 sec\nuint32 nanosec\n", ()),
    "std_msgs/msg/Header": ("builtin_interfaces/Time stamp\nstring frame_id\n", ("builtin_interfaces/msg/Time",)),
    "geometry_msgs/msg/Point": ("float64 x\nfloat64 y\nfloat64 z\n", ()),
    "geometry_msgs/msg/Quaternion": ("float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n", ()),
    "geometry_msgs/msg/Vector3": ("float64 x\nfloat64 y\nfloat64 z\n", ()),
    "geometry_msgs/msg/Pose": ("Point position\nQuaternion orientation\n",
                               ("geometry_msgs/msg/Point", "geometry_msgs/msg/Quaternion")),
    "geometry_msgs/msg/PoseStamped": ("std_msgs/Header header\nPose pose\n",
                                      ("std_msgs/msg/Header", "geometry_msgs/msg/Pose")),
    "geometry_msgs/msg/Twist": ("Vector3 linear\nVector3 angular\n", ("geometry_msgs/msg/Vector3",)),
    "geometry_msgs/msg/Wrench": ("Vector3 force\nVector3 torque\n", ("geometry_msgs/msg/Vector3",)),
    "geometry_msgs/msg/WrenchStamped": ("std_msgs/Header header\nWrench wrench\n",
                                        ("std_msgs/msg/Header", "geometry_msgs/msg/Wrench")),
    "rosgraph_msgs/msg/Clock": ("builtin_interfaces/Time clock\n", ("builtin_interfaces/msg/Time",)),
    "geometry_msgs/msg/PoseArray": ("std_msgs/Header header\nPose[] poses\n",
                                    ("std_msgs/msg/Header", "geometry_msgs/msg/Pose")),
    "sensor_msgs/msg/PointField": ("uint8 INT8 = 1\nuint8 UINT8 = 2\nuint8 INT16 = 3\nuint8 UINT16 = 4\n"
                                   "uint8 INT32 = 5\nuint8 UINT32 = 6\nuint8 FLOAT32 = 7\nuint8 FLOAT64 = 8\n"
                                   "string name\nuint32 offset\nuint8 datatype\nuint32 count\n", ()),
    "sensor_msgs/msg/PointCloud2": ("std_msgs/Header header\nuint32 height\nuint32 width\nPointField[] fields\n"
                                    "bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\n"
                                    "bool is_dense\n", ("std_msgs/msg/Header", "sensor_msgs/msg/PointField")),
    "sensor_msgs/msg/Imu": ("std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n"
                            "float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n"
                            "float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n"
                            "float64[9] linear_acceleration_covariance\n",
                            ("std_msgs/msg/Header", "geometry_msgs/msg/Quaternion", "geometry_msgs/msg/Vector3")),
}


def complete_definition(type_name: str) -> str:
    """The complete ros2msg definition of ``type_name`` (e.g. ``"geometry_msgs/msg/PoseStamped"``).

    Raises
    ------
    KeyError
        For a type not in :data:`MSG_TEXT` (the known ones are listed).
    """
    if type_name not in MSG_TEXT:
        raise KeyError(f"no message definition for {type_name!r}; known types are {sorted(MSG_TEXT)}")
    order: list[str] = []

    def visit(name: str) -> None:
        for dependency in MSG_TEXT[name][1]:
            if dependency not in order:
                order.append(dependency)
                visit(dependency)

    visit(type_name)
    parts = [MSG_TEXT[type_name][0]]
    for name in order:
        parts.append(f"{DELIMITER}\nMSG: {name}\n{MSG_TEXT[name][0]}")
    return "".join(parts)
