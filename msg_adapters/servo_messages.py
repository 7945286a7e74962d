"""The servo node's messages ↔ the core servo's commands and outputs, without rclpy.

In (moveit_servo's inputs): geometry_msgs/TwistStamped → `TwistCommand`, geometry_msgs/PoseStamped
→ `PoseCommand`, control_msgs/JointJog or sensor_msgs/JointState (names and velocities) →
`JointJogCommand`. These conversions check nothing: a NaN, a zero quaternion, an unknown frame or
joint goes into the command as it came, and `Servo.submit` refuses it with a status saying why, so
that every refusal also stops the active command, the core's way. A stamp of zero (unstamped, as
`ros2 topic pub` sends it) means "now".

Out: joint commands as ros2_control's controllers take them: std_msgs/Float64MultiArray (one
position or velocity per joint, chain order: forward_command_controller) or
trajectory_msgs/JointTrajectory (one point `period` ahead: joint_trajectory_controller), and a
diagnostic_msgs/DiagnosticStatus for the status. Float fields are Python floats and float64[]
fields lists of them (what rclpy's setters accept); every field is given at construction (as
rosbags' classes require).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from kinematics_node.core.servo import JointJogCommand, PoseCommand, TwistCommand
from kinematics_node.core.so3 import rows_from_quaternion

from .stamps import seconds_from_time
from .types import MessageClasses

#: ROS 2 interface name of each `ServoMessageTypes` field.
SERVO_MESSAGE_NAMES: dict[str, str] = {
    "Time": "builtin_interfaces/msg/Time",
    "Duration": "builtin_interfaces/msg/Duration",
    "Header": "std_msgs/msg/Header",
    "MultiArrayLayout": "std_msgs/msg/MultiArrayLayout",
    "Float64MultiArray": "std_msgs/msg/Float64MultiArray",
    "JointTrajectory": "trajectory_msgs/msg/JointTrajectory",
    "JointTrajectoryPoint": "trajectory_msgs/msg/JointTrajectoryPoint",
    "KeyValue": "diagnostic_msgs/msg/KeyValue",
    "DiagnosticStatus": "diagnostic_msgs/msg/DiagnosticStatus",
}


@dataclass(frozen=True)
class ServoMessageTypes(MessageClasses):
    """The classes of the servo node's outputs (see `SERVO_MESSAGE_NAMES`)."""

    NAMES = SERVO_MESSAGE_NAMES

    Time: Any
    Duration: Any
    Header: Any
    MultiArrayLayout: Any
    Float64MultiArray: Any
    JointTrajectory: Any
    JointTrajectoryPoint: Any
    KeyValue: Any
    DiagnosticStatus: Any


# ---------------------------------------------------------------------- commands in
def command_stamp(header: Any, now_s: float) -> float:
    """The stamp of a command's header [s]; `now_s` when it is zero (unstamped)."""
    stamp = header.stamp
    if int(stamp.sec) == 0 and int(stamp.nanosec) == 0:
        return now_s
    return seconds_from_time(stamp)


def _xyz(vec: Any) -> tuple[float, float, float]:
    return (float(vec.x), float(vec.y), float(vec.z))


def twist_command_from_msg(msg: Any, now_s: float, base_link: str) -> TwistCommand:
    """`TwistCommand` of a geometry_msgs/TwistStamped: ω = twist.angular [rad/s], v =
    twist.linear [m/s], in the axes of header.frame_id (empty: `base_link`), about the tip."""
    twist = msg.twist
    return TwistCommand(
        angular=_xyz(twist.angular),
        linear=_xyz(twist.linear),
        frame=str(msg.header.frame_id) or base_link,
        stamp_s=command_stamp(msg.header, now_s),
    )


def pose_command_from_msg(msg: Any, now_s: float, base_link: str) -> PoseCommand:
    """`PoseCommand` of a geometry_msgs/PoseStamped: the tip's target in header.frame_id (empty:
    `base_link`). The quaternion (x, y, z, w) is normalised; a zero or non-finite one gives a
    matrix that is not a rotation, which `Servo.submit` refuses."""
    pose = msg.pose
    o = pose.orientation
    x, y, z, w = float(o.x), float(o.y), float(o.z), float(o.w)
    norm = math.hypot(x, y, z, w)
    if math.isfinite(norm) and norm > 1e-9:
        r = rows_from_quaternion(x, y, z, w)
    else:  # refused by the core: not a rotation (zero) or not finite
        r = (norm,) * 9 if not math.isfinite(norm) else (0.0,) * 9
    px, py, pz = _xyz(pose.position)
    T = np.array(
        (
            (r[0], r[1], r[2], px),
            (r[3], r[4], r[5], py),
            (r[6], r[7], r[8], pz),
            (0.0, 0.0, 0.0, 1.0),
        )
    )
    return PoseCommand(
        T_frame_tip=T,
        frame=str(msg.header.frame_id) or base_link,
        stamp_s=command_stamp(msg.header, now_s),
    )


def jog_command_from_joint_jog(msg: Any, now_s: float) -> JointJogCommand:
    """`JointJogCommand` of a control_msgs/JointJog: joint_names and velocities [rad/s or m/s]
    (its displacements and duration are not used, as moveit_servo does not use them)."""
    return JointJogCommand(
        joint_names=[str(n) for n in msg.joint_names],
        velocities=list(msg.velocities),
        stamp_s=command_stamp(msg.header, now_s),
    )


def jog_command_from_joint_state(msg: Any, now_s: float) -> JointJogCommand:
    """`JointJogCommand` of a sensor_msgs/JointState used as a jog: `name` and `velocity`
    [rad/s or m/s] (position and effort are not used)."""
    return JointJogCommand(
        joint_names=[str(n) for n in msg.name],
        velocities=list(msg.velocity),
        stamp_s=command_stamp(msg.header, now_s),
    )


# ---------------------------------------------------------------------- commands out
def float64_multi_array(types: ServoMessageTypes, values: ArrayLike) -> Any:
    """std_msgs/Float64MultiArray with `data` = values (one per joint) and an empty layout, as
    ros2_control's forward_command_controller takes it."""
    data: list[float] = np.asarray(values, dtype=np.float64).reshape(-1).tolist()
    return types.Float64MultiArray(layout=types.MultiArrayLayout(dim=[], data_offset=0), data=data)


def joint_trajectory(
    types: ServoMessageTypes,
    joint_names: Sequence[str],
    positions: ArrayLike,
    velocities: ArrayLike,
    accelerations: ArrayLike,
    time_from_start_s: float,
) -> Any:
    """trajectory_msgs/JointTrajectory of one point reached `time_from_start_s` [s] after its
    receipt (header stamp zero: start at once, as joint_trajectory_controller reads it)."""
    sec = math.floor(time_from_start_s)
    nanosec = min(round((time_from_start_s - sec) * 1e9), 999_999_999)
    point = types.JointTrajectoryPoint(
        positions=np.asarray(positions, dtype=np.float64).tolist(),
        velocities=np.asarray(velocities, dtype=np.float64).tolist(),
        accelerations=np.asarray(accelerations, dtype=np.float64).tolist(),
        effort=[],
        time_from_start=types.Duration(sec=int(sec), nanosec=int(nanosec)),
    )
    return types.JointTrajectory(
        header=types.Header(stamp=types.Time(sec=0, nanosec=0), frame_id=""),
        joint_names=[str(n) for n in joint_names],
        points=[point],
    )


def diagnostic_status(
    types: ServoMessageTypes,
    level: int,
    name: str,
    message: str,
    hardware_id: str,
    values: Sequence[tuple[str, str]],
) -> Any:
    """diagnostic_msgs/DiagnosticStatus; `level` 0, 1, 2 = OK, WARN, ERROR."""
    S = types.DiagnosticStatus
    return S(
        level=(S.OK, S.WARN, S.ERROR)[level],
        name=name,
        message=message,
        hardware_id=hardware_id,
        values=[types.KeyValue(key=k, value=v) for k, v in values],
    )
