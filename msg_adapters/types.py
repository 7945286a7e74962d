"""`MessageTypes`: the message classes the adapters construct, supplied by the caller.

The adapters never import message packages. The ROS node fills a `MessageTypes` from rclpy's
generated classes (`MessageTypes.from_rclpy()`); tests fill it from a rosbags typestore
(`MessageTypes.from_typestore(typestore)`). The servo's classes (`servo_messages.ServoMessageTypes`)
come from a table of names of their own the same way (`MessageClasses`). Adapters always pass every field at construction, because rosbags message
dataclasses require it (rclpy classes accept it too).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, TypeVar

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

_Classes = TypeVar("_Classes", bound="MessageClasses")


class MessageClasses:
    """Base of a frozen dataclass of message classes, one field per short name of its table
    `NAMES` ({short name: "package/msg/Name"}): built from rclpy's generated classes or from a
    rosbags typestore."""

    NAMES: ClassVar[Mapping[str, str]]

    @classmethod
    def from_rclpy(cls: type[_Classes]) -> _Classes:
        """The rclpy-generated classes (needs a sourced ROS 2 installation)."""
        return cls(**rclpy_classes(cls.NAMES))

    @classmethod
    def from_typestore(cls: type[_Classes], typestore: Any) -> _Classes:
        """The classes of a rosbags typestore (e.g. ``get_typestore(Stores.ROS2_HUMBLE)``)."""
        return cls(**typestore_classes(typestore, cls.NAMES))


@dataclass(frozen=True)
class MessageTypes(MessageClasses):
    """Message classes by short name (see `MESSAGE_NAMES` for the full interface names)."""

    NAMES = MESSAGE_NAMES

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


def rclpy_classes(names: Mapping[str, str]) -> dict[str, Any]:
    """{short name: rclpy-generated class} of `names` ({short name: "package/msg/Name"}),
    imported from the message packages of a sourced ROS 2 (no import at this module's load)."""
    import importlib

    found = {}
    for short, full in names.items():
        package, _, name = full.split("/")
        found[short] = getattr(importlib.import_module(f"{package}.msg"), name)
    return found


def typestore_classes(typestore: Any, names: Mapping[str, str]) -> dict[str, Any]:
    """{short name: class} of `names` ({short name: "package/msg/Name"}) in a rosbags
    typestore."""
    return {short: typestore.types[full] for short, full in names.items()}
