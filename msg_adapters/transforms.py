"""tf2_msgs/TFMessage of parent -> child transforms (`core.joint_transforms`), without rclpy: the
node's /tf and /tf_static. (A recording's are serialised straight to CDR: `msg_adapters.cdr`.)"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .types import MessageClasses

#: ROS 2 interface name of each `TFTypes` field.
TF_MESSAGE_NAMES: dict[str, str] = {
    "Time": "builtin_interfaces/msg/Time",
    "Header": "std_msgs/msg/Header",
    "Vector3": "geometry_msgs/msg/Vector3",
    "Quaternion": "geometry_msgs/msg/Quaternion",
    "Transform": "geometry_msgs/msg/Transform",
    "TransformStamped": "geometry_msgs/msg/TransformStamped",
    "TFMessage": "tf2_msgs/msg/TFMessage",
}


@dataclass(frozen=True)
class TFTypes(MessageClasses):
    """The classes of /tf's messages (see `TF_MESSAGE_NAMES`)."""

    NAMES = TF_MESSAGE_NAMES

    Time: Any
    Header: Any
    Vector3: Any
    Quaternion: Any
    Transform: Any
    TransformStamped: Any
    TFMessage: Any


def tf_message(
    types: TFTypes,
    stamp: Any,
    parents: Sequence[str],
    children: Sequence[str],
    translations: NDArray[np.float64],
    quaternions: NDArray[np.float64],
) -> Any:
    """tf2_msgs/TFMessage with one TransformStamped per row: child in parent, translation (k, 3)
    [m], quaternion (k, 4) x y z w, each stamped with a copy of `stamp` (a Time message)."""
    sec, nanosec = int(stamp.sec), int(stamp.nanosec)
    T, V, Q, H, Time = (
        types.TransformStamped,
        types.Vector3,
        types.Quaternion,
        types.Header,
        types.Time,
    )
    out = []
    for parent, child, t, q in zip(
        parents, children, translations.tolist(), quaternions.tolist(), strict=True
    ):
        out.append(
            T(
                header=H(stamp=Time(sec=sec, nanosec=nanosec), frame_id=parent),
                child_frame_id=child,
                transform=types.Transform(
                    translation=V(x=t[0], y=t[1], z=t[2]),
                    rotation=Q(x=q[0], y=q[1], z=q[2], w=q[3]),
                ),
            )
        )
    return types.TFMessage(transforms=out)
