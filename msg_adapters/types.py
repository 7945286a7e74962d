"""`MessageTypes`: the message classes the adapters construct, supplied by the caller.

The adapters never import message packages. The ROS node fills a `MessageTypes` from rclpy's
generated classes (`MessageTypes.from_rclpy()`); tests fill it from a rosbags typestore
(`MessageTypes.from_typestore(typestore)`). Adapters always pass every field at construction,
because rosbags message dataclasses require it (rclpy classes accept it too).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

#: ROS 2 interface name of each `MessageTypes` field.
MESSAGE_NAMES: dict[str, str] = {
    "Time": "builtin_interfaces/msg/Time",
    "Header": "std_msgs/msg/Header",
    "Point": "geometry_msgs/msg/Point",
    "Quaternion": "geometry_msgs/msg/Quaternion",
    "Pose": "geometry_msgs/msg/Pose",
    "PoseStamped": "geometry_msgs/msg/PoseStamped",
    "Vector3": "geometry_msgs/msg/Vector3",
    "Twist": "geometry_msgs/msg/Twist",
    "TwistStamped": "geometry_msgs/msg/TwistStamped",
    "Transform": "geometry_msgs/msg/Transform",
    "JointState": "sensor_msgs/msg/JointState",
    "KeyValue": "diagnostic_msgs/msg/KeyValue",
    "DiagnosticStatus": "diagnostic_msgs/msg/DiagnosticStatus",
    "DiagnosticArray": "diagnostic_msgs/msg/DiagnosticArray",
}


@dataclass(frozen=True)
class MessageTypes:
    """Message classes by short name (see `MESSAGE_NAMES` for the full interface names)."""

    Time: Any
    Header: Any
    Point: Any
    Quaternion: Any
    Pose: Any
    PoseStamped: Any
    Vector3: Any
    Twist: Any
    TwistStamped: Any
    Transform: Any
    JointState: Any
    KeyValue: Any
    DiagnosticStatus: Any
    DiagnosticArray: Any

    @classmethod
    def from_rclpy(cls) -> MessageTypes:
        """The rclpy-generated classes (needs a sourced ROS 2 installation)."""
        import importlib

        found = {}
        for short, full in MESSAGE_NAMES.items():
            package, _, name = full.split("/")
            found[short] = getattr(importlib.import_module(f"{package}.msg"), name)
        return cls(**found)

    @classmethod
    def from_typestore(cls, typestore: Any) -> MessageTypes:
        """The classes of a rosbags typestore (e.g. ``get_typestore(Stores.ROS2_HUMBLE)``)."""
        return cls(**{short: typestore.types[full] for short, full in MESSAGE_NAMES.items()})
