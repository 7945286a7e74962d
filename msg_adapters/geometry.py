"""geometry_msgs Pose / Transform / Twist ↔ numpy.

* Pose and Transform ↔ 4×4 homogeneous transform T (rotation R, translation p [m]). Quaternions are
  (x, y, z, w) as in the messages; incoming ones are normalised; zero/non-finite ones are refused.
* Twist ↔ (ω, v): the core orders twists (angular, linear) as Modern Robotics does; the message
  names them `angular` and `linear`, so the conversion is by name and nothing is reordered by index.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kinematics_node.core.exceptions import InvalidInputError
from kinematics_node.core.so3 import quaternion_from_rows, rows_from_quaternion

from .stamps import header
from .types import MessageTypes

FloatArray = NDArray[np.float64]


def _xyz(vec: Any, name: str) -> FloatArray:
    return np.array(_xyz_floats(vec, name))


def _xyz_floats(vec: Any, name: str) -> tuple[float, float, float]:
    try:
        values = (float(vec.x), float(vec.y), float(vec.z))
    except (AttributeError, TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must have numeric x, y, z fields: {exc}") from None
    for axis, value in zip("xyz", values, strict=True):
        if not math.isfinite(value):
            raise InvalidInputError(f"{name}.{axis} is {value}; expected a finite number")
    return values


def _rotation_rows(quat: Any, name: str) -> tuple[float, ...]:
    """The rotation of a quaternion message as 9 floats, row-major (on floats: an IK request's
    target goes through here, ~5 µs instead of ~60 µs with arrays)."""
    try:
        xyzw = (float(quat.x), float(quat.y), float(quat.z), float(quat.w))
    except (AttributeError, TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must have numeric x, y, z, w fields: {exc}") from None
    if not all(math.isfinite(v) for v in xyzw):
        raise InvalidInputError(f"{name} (x, y, z, w) = {xyzw} is not finite")
    if math.hypot(*xyzw) < 1e-9:
        raise InvalidInputError(
            f"{name} (x, y, z, w) = {xyzw} has zero norm; expected a unit quaternion"
        )
    return rows_from_quaternion(*xyzw)


def _transform(
    rotation: Any, translation: Any, name: str, r_field: str, p_field: str
) -> FloatArray:
    r = _rotation_rows(rotation, f"{name}.{r_field}")
    x, y, z = _xyz_floats(translation, f"{name}.{p_field}")
    return np.array(
        ((r[0], r[1], r[2], x), (r[3], r[4], r[5], y), (r[6], r[7], r[8], z), (0.0, 0.0, 0.0, 1.0))
    )


def matrix_from_pose(pose: Any, name: str = "pose") -> FloatArray:
    """T (4×4) of a geometry_msgs/Pose: R from `orientation` (normalised), p = `position` [m].

    Raises:
        InvalidInputError: non-finite values or a zero quaternion, naming the field.
    """
    return _transform(pose.orientation, pose.position, name, "orientation", "position")


def matrix_from_transform(transform: Any, name: str = "transform") -> FloatArray:
    """T (4×4) of a geometry_msgs/Transform (`translation` [m], `rotation` quaternion)."""
    return _transform(transform.rotation, transform.translation, name, "rotation", "translation")


def _rows(T: ArrayLike) -> list[list[float]]:
    """The rows of a 4×4 (or 3×4) transform as Python floats: every number a message field needs,
    converted in one call (then Shepperd's method in floats, ~2 µs, not an array routine)."""
    rows: list[list[float]] = np.asarray(T, dtype=np.float64).tolist()
    return rows


def pose_from_matrix(types: MessageTypes, T: ArrayLike) -> Any:
    """geometry_msgs/Pose of a 4×4 transform (quaternion with w ≥ 0)."""
    r0, r1, r2 = _rows(T)[:3]
    x, y, z, w = quaternion_from_rows(r0[:3] + r1[:3] + r2[:3])
    return types.Pose(
        position=types.Point(x=r0[3], y=r1[3], z=r2[3]),
        orientation=types.Quaternion(x=x, y=y, z=z, w=w),
    )


def transform_from_matrix(types: MessageTypes, T: ArrayLike) -> Any:
    """geometry_msgs/Transform of a 4×4 transform (quaternion with w ≥ 0)."""
    r0, r1, r2 = _rows(T)[:3]
    x, y, z, w = quaternion_from_rows(r0[:3] + r1[:3] + r2[:3])
    return types.Transform(
        translation=types.Vector3(x=r0[3], y=r1[3], z=r2[3]),
        rotation=types.Quaternion(x=x, y=y, z=z, w=w),
    )


def pose_stamped_from_matrix(types: MessageTypes, T: ArrayLike, frame_id: str, stamp: Any) -> Any:
    """geometry_msgs/PoseStamped of T (the pose of some frame in `frame_id`), stamped with a copy of
    the Time message `stamp`."""
    return types.PoseStamped(header=header(types, stamp, frame_id), pose=pose_from_matrix(types, T))


def _vector3(types: MessageTypes, v: ArrayLike) -> Any:
    x, y, z = np.asarray(v, dtype=np.float64).reshape(3).tolist()
    return types.Vector3(x=x, y=y, z=z)


def twist_from_vectors(types: MessageTypes, omega: ArrayLike, v: ArrayLike) -> Any:
    """geometry_msgs/Twist with angular = ω [rad/s] and linear = v [m/s]."""
    return types.Twist(linear=_vector3(types, v), angular=_vector3(types, omega))


def twist_from_core(types: MessageTypes, V: ArrayLike) -> Any:
    """geometry_msgs/Twist of a core twist V = (ω, v) (6,): angular = V[:3], linear = V[3:]."""
    wx, wy, wz, vx, vy, vz = np.asarray(V, dtype=np.float64).reshape(6).tolist()
    return types.Twist(
        linear=types.Vector3(x=vx, y=vy, z=vz), angular=types.Vector3(x=wx, y=wy, z=wz)
    )


def twist_stamped_from_core(types: MessageTypes, V: ArrayLike, frame_id: str, stamp: Any) -> Any:
    """geometry_msgs/TwistStamped of a core twist V = (ω, v) expressed in `frame_id`."""
    return types.TwistStamped(
        header=header(types, stamp, frame_id), twist=twist_from_core(types, V)
    )


def vectors_from_twist(twist: Any, name: str = "twist") -> tuple[FloatArray, FloatArray]:
    """(ω, v) of a geometry_msgs/Twist: ω = `angular` [rad/s], v = `linear` [m/s]."""
    return _xyz(twist.angular, f"{name}.angular"), _xyz(twist.linear, f"{name}.linear")


def core_from_twist(twist: Any, name: str = "twist") -> FloatArray:
    """Core twist V = (ω, v) (6,) of a geometry_msgs/Twist."""
    omega, v = vectors_from_twist(twist, name)
    return np.concatenate((omega, v))
