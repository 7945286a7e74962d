"""Jacobian (core rows (ω, v)) ↔ the flat, row-major, ROS-ordered fields of ComputeJacobian.

At the ROS boundary the rows are (linear x, y, z, angular x, y, z), matching geometry_msgs/Twist;
the core (Modern Robotics) orders them (ω, v). Only the two 3-row blocks are swapped.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kinematics_node.core.exceptions import InvalidInputError

FloatArray = NDArray[np.float64]

#: Labels of the rows of a ROS-ordered Jacobian.
ROW_LABELS: tuple[str, ...] = (
    "linear_x",
    "linear_y",
    "linear_z",
    "angular_x",
    "angular_y",
    "angular_z",
)


def ros_rows_from_core(J: ArrayLike) -> FloatArray:
    """Reorder a (6, n) Jacobian from rows (ω, v) to rows (v, ω)."""
    Jm = np.asarray(J, dtype=np.float64)
    if Jm.ndim != 2 or Jm.shape[0] != 6:
        raise InvalidInputError(f"Jacobian must have shape (6, n), got {Jm.shape}")
    return np.concatenate((Jm[3:], Jm[:3]))


def core_rows_from_ros(J: ArrayLike) -> FloatArray:
    """Reorder a (6, n) Jacobian from rows (v, ω) to rows (ω, v) (the swap is its own inverse)."""
    return ros_rows_from_core(J)


def fill_jacobian_fields(response: Any, J: ArrayLike, joint_names: Sequence[str]) -> None:
    """Set `jacobian` (row-major list of Python floats, ROS row order), `rows`, `cols`,
    `joint_names` and `row_labels` of a ComputeJacobian response from a core (ω, v) Jacobian."""
    J_ros = ros_rows_from_core(J)
    if J_ros.shape[1] != len(joint_names):
        raise InvalidInputError(
            f"Jacobian has {J_ros.shape[1]} columns but {len(joint_names)} joint names were given"
        )
    response.jacobian = J_ros.reshape(-1).tolist()  # rclpy float64[]: a list of Python floats
    response.rows = int(J_ros.shape[0])
    response.cols = int(J_ros.shape[1])
    response.joint_names = [str(n) for n in joint_names]
    response.row_labels = list(ROW_LABELS)


def jacobian_from_fields(message: Any) -> FloatArray:
    """The (6, n) core-ordered (ω, v) Jacobian of a ComputeJacobian response.

    Raises:
        InvalidInputError: `rows`/`cols` disagree with the data length, or rows is not 6.
    """
    rows, cols = int(message.rows), int(message.cols)
    data = np.asarray(message.jacobian, dtype=np.float64)
    if rows != 6 or data.size != rows * cols:
        raise InvalidInputError(
            f"Jacobian fields inconsistent: rows={rows}, cols={cols}, {data.size} values"
        )
    return core_rows_from_ros(data.reshape(rows, cols))
