"""ROS message ↔ core (numpy) conversions, duck-typed on field names.

The same functions work with rclpy's generated classes and with rosbags' dataclasses: inputs are
read by field name, outputs are built from the classes in a `MessageTypes` the caller supplies, with
every field given at construction, float64[] fields as lists of Python floats and float fields as
Python floats (what rclpy's generated setters accept). Errors are `InvalidInputError` naming the
field or joint. Never imports rclpy.
"""

from .geometry import (
    core_from_twist,
    matrix_from_pose,
    matrix_from_transform,
    pose_from_matrix,
    pose_stamped_from_matrix,
    transform_from_matrix,
    twist_from_core,
    twist_from_vectors,
    twist_stamped_from_core,
    vectors_from_twist,
)
from .jacobian import (
    ROW_LABELS,
    core_rows_from_ros,
    fill_jacobian_fields,
    jacobian_from_fields,
    ros_rows_from_core,
)
from .joint_state import (
    JointStateSample,
    joint_state_from_q,
    joint_states_from_qs,
    positions_by_name,
    q_from_joint_state,
    sample_from_joint_state,
)
from .stamps import copy_time, header, seconds_from_time, time_from_seconds
from .types import MESSAGE_NAMES, MessageTypes

__all__ = [
    "MESSAGE_NAMES",
    "JointStateSample",
    "ROW_LABELS",
    "MessageTypes",
    "copy_time",
    "core_from_twist",
    "core_rows_from_ros",
    "fill_jacobian_fields",
    "header",
    "jacobian_from_fields",
    "joint_state_from_q",
    "joint_states_from_qs",
    "matrix_from_pose",
    "matrix_from_transform",
    "pose_from_matrix",
    "pose_stamped_from_matrix",
    "positions_by_name",
    "q_from_joint_state",
    "ros_rows_from_core",
    "sample_from_joint_state",
    "seconds_from_time",
    "time_from_seconds",
    "transform_from_matrix",
    "twist_from_core",
    "twist_from_vectors",
    "twist_stamped_from_core",
    "vectors_from_twist",
]
