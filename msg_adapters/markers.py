"""The manipulability markers (visualization_msgs/MarkerArray) of an `Ellipsoid`, without rclpy.

The node's ``~/markers`` and the markers `kinematics bag` writes into a recording are built here,
from `kinematics_node.core.analysis.translational_ellipsoid`, so both show the same:

* id 0, a SPHERE: the translational manipulability ellipsoid at the tool, its pose the
  ellipsoid's (centre, proper rotation: the SVD's left singular vectors), its scale the axes
  2σ₁, 2σ₂, 2σ₃ [m] (each at least `MIN_SCALE`, as RViz draws nothing of a zero scale),
  half-transparent, coloured by the condition number σ₁/σ₃ (`condition_colour`: green at 1,
  yellow at √red_at, red from red_at on);
* id 1, an ARROW: the most singular direction, the axis of σ₃, from the tool origin, as long as
  the longest semi-axis σ₁ (at least `MIN_ARROW` [m]), so that it stands out of the ellipsoid
  where the ellipsoid is thinnest; the same colour, opaque.

Namespace "manipulability", frame the chain's base link, stamp the joint_states'. Every field is
given at construction (rosbags' classes require it; rclpy's accept it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from kinematics_node.core.analysis import RED_CONDITION, Ellipsoid, condition_colour
from kinematics_node.core.so3 import quaternion_from_matrix

from .cdr import CdrTemplate, as_bytes, stamps
from .types import MessageClasses

#: ROS 2 interface name of each `MarkerTypes` field.
MARKER_MESSAGE_NAMES: dict[str, str] = {
    "Time": "builtin_interfaces/msg/Time",
    "Duration": "builtin_interfaces/msg/Duration",
    "Header": "std_msgs/msg/Header",
    "ColorRGBA": "std_msgs/msg/ColorRGBA",
    "Point": "geometry_msgs/msg/Point",
    "Quaternion": "geometry_msgs/msg/Quaternion",
    "Pose": "geometry_msgs/msg/Pose",
    "Vector3": "geometry_msgs/msg/Vector3",
    "CompressedImage": "sensor_msgs/msg/CompressedImage",
    "MeshFile": "visualization_msgs/msg/MeshFile",
    "Marker": "visualization_msgs/msg/Marker",
    "MarkerArray": "visualization_msgs/msg/MarkerArray",
}

MARKER_ARRAY_TYPE = MARKER_MESSAGE_NAMES["MarkerArray"]
NAMESPACE = "manipulability"
#: Smallest scale of the ellipsoid's axes [m] (a flat ellipsoid, σ₃ = 0, is drawn this thin).
MIN_SCALE = 1e-4
#: Shortest arrow [m] (where every σ is tiny the direction still shows).
MIN_ARROW = 0.05
#: The ellipsoid's opacity (the arm stays visible through it).
ELLIPSOID_ALPHA = 0.4
#: visualization_msgs/Marker's constants (its definition's SPHERE, ARROW and ADD).
_ARROW, _SPHERE, _ADD = 0, 2, 0


@dataclass(frozen=True)
class MarkerTypes(MessageClasses):
    """The classes the markers are built from (see `MARKER_MESSAGE_NAMES`)."""

    NAMES = MARKER_MESSAGE_NAMES

    Time: Any
    Duration: Any
    Header: Any
    ColorRGBA: Any
    Point: Any
    Quaternion: Any
    Pose: Any
    Vector3: Any
    CompressedImage: Any
    MeshFile: Any
    Marker: Any
    MarkerArray: Any


def manipulability_markers(
    types: MarkerTypes,
    ellipsoid: Ellipsoid,
    frame_id: str,
    stamp_sec: int,
    stamp_nanosec: int,
    red_at: float = RED_CONDITION,
) -> Any:
    """visualization_msgs/MarkerArray of `ellipsoid` (see the module docstring), in `frame_id`,
    stamped (stamp_sec, stamp_nanosec)."""
    r, g, b = condition_colour(ellipsoid.condition_number, red_at)
    centre = [float(v) for v in ellipsoid.centre]
    scale = [max(2.0 * float(s), MIN_SCALE) for s in ellipsoid.semi_axes]
    x, y, z, w = (float(v) for v in quaternion_from_matrix(ellipsoid.rotation))
    length = max(float(ellipsoid.semi_axes[0]), MIN_ARROW)
    tip = [c + length * float(u) for c, u in zip(centre, ellipsoid.weakest, strict=True)]
    sphere = marker(
        types,
        frame_id,
        (stamp_sec, stamp_nanosec),
        0,
        types.Marker.SPHERE,
        types.Pose(
            position=types.Point(x=centre[0], y=centre[1], z=centre[2]),
            orientation=types.Quaternion(x=x, y=y, z=z, w=w),
        ),
        scale,
        (r, g, b, ELLIPSOID_ALPHA),
        [],
    )
    arrow = marker(
        types,
        frame_id,
        (stamp_sec, stamp_nanosec),
        1,
        types.Marker.ARROW,
        types.Pose(
            position=types.Point(x=0.0, y=0.0, z=0.0),
            orientation=types.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
        ),
        [0.1 * length, 0.2 * length, 0.25 * length],  # shaft and head diameters, head length
        (r, g, b, 1.0),
        [types.Point(x=p[0], y=p[1], z=p[2]) for p in (centre, tip)],
    )
    return types.MarkerArray(markers=[sphere, arrow])


def marker(
    types: MarkerTypes,
    frame_id: str,
    stamp: tuple[int, int],
    marker_id: int,
    kind: int,
    pose: Any,
    scale: list[float],
    rgba: tuple[float, float, float, float],
    points: list[Any],
    colors: list[Any] | None = None,
    ns: str = NAMESPACE,
) -> Any:
    """One visualization_msgs/Marker (ADD, no lifetime, no texture, mesh or text) of `types`'
    classes; `colors` per point (list markers), else none."""
    return types.Marker(
        header=types.Header(
            stamp=types.Time(sec=int(stamp[0]), nanosec=int(stamp[1])), frame_id=str(frame_id)
        ),
        ns=ns,
        id=int(marker_id),
        type=int(kind),
        action=int(types.Marker.ADD),
        pose=pose,
        scale=types.Vector3(x=scale[0], y=scale[1], z=scale[2]),
        color=types.ColorRGBA(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]),
        lifetime=types.Duration(sec=0, nanosec=0),
        frame_locked=False,
        points=points,
        colors=[] if colors is None else colors,
        texture_resource="",
        texture=types.CompressedImage(
            header=types.Header(stamp=types.Time(sec=0, nanosec=0), frame_id=""),
            format="",
            data=np.zeros(0, dtype=np.uint8),
        ),
        uv_coordinates=[],
        text="",
        mesh_resource="",
        mesh_file=types.MeshFile(filename="", data=np.zeros(0, dtype=np.uint8)),
        mesh_use_embedded_materials=False,
    )


def manipulability_markers_cdr(
    ellipsoids: list[Ellipsoid],
    frame_id: str,
    stamp_ns: NDArray[np.int64],
    red_at: float = RED_CONDITION,
) -> NDArray[np.uint8]:
    """`manipulability_markers` of many ellipsoids, serialised (CDR, visualization_msgs of ROS 2
    Jazzy and later: Marker with its texture and mesh_file fields), one row of bytes each, without
    building a message object: the layout of the two markers is fixed, so one template row is
    filled (`msg_adapters.cdr.CdrTemplate`). The same bytes as rosbags' serialiser gives for
    `manipulability_markers` (tested); ~10 µs a message against ~0.3 ms.
    """
    n = len(ellipsoids)
    centre = np.empty((n, 3))
    quat = np.empty((n, 4))
    scale = np.empty((n, 3))
    colour = np.empty((n, 3))
    length = np.empty(n)
    weakest = np.empty((n, 3))
    for k, e in enumerate(ellipsoids):
        centre[k] = e.centre
        quat[k] = quaternion_from_matrix(e.rotation)
        scale[k] = np.maximum(2.0 * np.asarray(e.semi_axes, dtype=float), MIN_SCALE)
        colour[k] = condition_colour(e.condition_number, red_at)
        length[k] = max(float(e.semi_axes[0]), MIN_ARROW)
        weakest[k] = e.weakest
    tip = centre + length[:, None] * weakest
    template = CdrTemplate()
    template.uint32(2)  # markers
    for marker in ("sphere", "arrow"):
        template.stamp(f"{marker}_stamp")
        template.string(frame_id)
        template.string(NAMESPACE)
        template.int32(0 if marker == "sphere" else 1)  # id
        template.int32(_SPHERE if marker == "sphere" else _ARROW)  # type
        template.int32(_ADD)  # action
        if marker == "sphere":
            template.float64s("sphere_pose", 7)
        else:
            template.constant_float64s([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
        template.float64s(f"{marker}_scale", 3)
        template.float32s(f"{marker}_colour", 4)
        template.int32(0)  # lifetime.sec
        template.uint32(0)  # lifetime.nanosec
        template.boolean(False)  # frame_locked
        if marker == "sphere":
            template.empty_sequence()  # points
        else:
            template.uint32(2)
            template.float64s("arrow_points", 6)
        template.empty_sequence()  # colors
        template.string("")  # texture_resource
        template.int32(0)  # texture.header.stamp.sec
        template.uint32(0)  # texture.header.stamp.nanosec
        template.string("")  # texture.header.frame_id
        template.string("")  # texture.format
        template.empty_sequence()  # texture.data
        template.empty_sequence()  # uv_coordinates
        template.string("")  # text
        template.string("")  # mesh_resource
        template.string("")  # mesh_file.filename
        template.empty_sequence()  # mesh_file.data
        template.boolean(False)  # mesh_use_embedded_materials
    rows = template.rows(n)
    t = stamps(stamp_ns)
    rows["sphere_stamp"] = t
    rows["arrow_stamp"] = t
    rows["sphere_pose"] = np.concatenate((centre, quat), axis=1)
    rows["sphere_scale"] = scale
    rows["arrow_scale"] = np.column_stack((0.1 * length, 0.2 * length, 0.25 * length))
    rows["sphere_colour"] = np.column_stack((colour, np.full(n, ELLIPSOID_ALPHA)))
    rows["arrow_colour"] = np.column_stack((colour, np.ones(n)))
    rows["arrow_points"] = np.concatenate((centre, tip), axis=1)
    return as_bytes(rows)
