"""The servo node's parameters: one table for declaration (descriptors) and validation, no rclpy.

Three groups:

* the robot description, exactly the kinematics node's (`parameters.SPECS`: robot_description,
  robot_description_file, xacro_args, base_link, tip_link), read the same way;
* the node's own: where the joint commands go and in which form (`command_out_type`,
  `command_out_topic`), the status heartbeat, the halt messages, the executor;
* the servo's settings, one parameter per field of `core.servo.ServoConfig`, with the same name
  and default (the core is the one source of both); the per-joint limit overrides are strings
  ``"joint:=value joint:=value"`` (ROS parameters have no maps), `task_axes` is a string of axis
  names (``"wz vx vy vz"``; empty = chosen from the arm).

`validate_servo_parameters` refuses a bad value with a sentence that names the parameter, what it
got and what it takes; `servo_config` builds the `ServoConfig` of a full set of values.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import fields
from typing import Any

from ..core.exceptions import InvalidInputError, KinematicsError
from ..core.servo import SMOOTHING_CHOICES, TWIST_AXES, ServoConfig, choose_smoothing
from .parameters import SPECS as KINEMATICS_SPECS
from .parameters import ParameterSpec, validate

#: ros2_control's controllers and the topics they listen on in their documented examples
#: (forward_command_controller's `<name>/commands`, joint_trajectory_controller's
#: `<name>/joint_trajectory`), by the form of command they take. The servo's `command_out_type`
#: and the simulated arm's `command_mode` choose among these forms.
CONTROLLER_TOPICS: dict[str, str] = {
    "position": "/forward_position_controller/commands",
    "velocity": "/forward_velocity_controller/commands",
    "trajectory": "/joint_trajectory_controller/joint_trajectory",
}
COMMAND_OUT_TYPES = tuple(CONTROLLER_TOPICS)

#: The description parameters, shared with the kinematics node.
DESCRIPTION_PARAMETERS = (
    "robot_description",
    "robot_description_file",
    "xacro_args",
    "base_link",
    "tip_link",
)

#: ServoConfig fields given as strings: per-joint maps and the axis list.
_LIMIT_MAPS = ("velocity_limits", "acceleration_limits", "jerk_limits")

_CONFIG_TEXT: dict[str, str] = {
    "period_s": "Control period [s]: one servo step and one joint command per period; 0.001 "
    "for 1 kHz (0.0005 at the least).",
    "command_timeout_s": "A command older than this [s] is stale: the arm stops smoothly, "
    "beginning within one period (moveit_servo's incoming_command_timeout is 0.1).",
    "position_margin_rad": "Revolute joints stop this far inside their position limits [rad].",
    "position_margin_m": "Prismatic joints stop this far inside their position limits [m].",
    "velocity_scale": "Fraction (0, 1] of the joints' velocity limits the servo uses.",
    "default_velocity_limit": "Velocity limit [rad/s or m/s] of joints whose description gives "
    "none.",
    "acceleration_time_s": "A joint's acceleration limit, where not given, is its velocity "
    "limit divided by this [s].",
    "jerk_time_s": "A joint's jerk limit, where not given, is its acceleration limit divided by "
    "this [s].",
    "velocity_limits": "Per-joint velocity limits overriding the description: 'joint:=value "
    "...' [rad/s or m/s] (still scaled by velocity_scale).",
    "acceleration_limits": "Per-joint acceleration limits: 'joint:=value ...' [rad/s^2 or m/s^2].",
    "jerk_limits": "Per-joint jerk limits: 'joint:=value ...' [rad/s^3 or m/s^3].",
    "max_linear_speed_m_s": "Twist commands faster than this [m/s] are scaled down to it "
    "(direction kept).",
    "max_angular_speed_rad_s": "Twist commands faster than this [rad/s] are scaled down to it.",
    "huge_command_factor": "Commands faster than this times the maximum speeds (joint jogs: "
    "times the velocity limit) are refused as a likely unit error.",
    "twist_acceleration_time_s": "A step in the twist command is ramped up over this long [s] "
    "(Cartesian acceleration = maximum speed / this).",
    "tracking_gain_1_per_s": "Gain [1/s] closing the loop on the integrated commanded pose "
    "(no drift).",
    "max_kept_error_m": "Bound on the position error kept by the tracking [m] (a blocked arm "
    "does not wind up).",
    "max_kept_error_rad": "Bound on the orientation error kept by the tracking [rad].",
    "singular_value_threshold": "Singular value below which damped least squares damps a "
    "direction (no hard stop).",
    "max_damping": "Damping at a singular value of 0.",
    "pose_gain_1_per_s": "Gain [1/s] of the approach to a pose target.",
    "pose_linear_speed_m_s": "Top speed of the approach to a pose target [m/s].",
    "pose_angular_speed_rad_s": "Top angular speed of the approach to a pose target [rad/s].",
    "pose_linear_acceleration_m_s2": "Braking of the approach to a pose target [m/s^2].",
    "pose_angular_acceleration_rad_s2": "Angular braking of the approach [rad/s^2].",
    "pose_position_tolerance_m": "Within this [m] (and the orientation tolerance) the status "
    "says the pose target is reached.",
    "pose_orientation_tolerance_rad": "Orientation tolerance of a reached pose target [rad].",
    "nullspace_gain_1_per_s": "Gain [1/s] of the null-space motion of a redundant arm away from "
    "its joint limits (0: off).",
    "task_axes": "Twist components the servo follows, e.g. 'wz vx vy vz' for a SCARA; empty = "
    "all six for 6 joints or more, else the ones the arm can move (the status names the "
    "dropped ones).",
    "task_axes_frame": "Axes in which task_axes are meant: 'base' or 'tip'.",
    "smoothing": "Smoothing of the joint motion: 'auto' = Ruckig's (jerk-limited) where Ruckig is "
    "installed, else an acceleration-limited one (same position, velocity and acceleration "
    "limits, no jerk limit; the servo says so once); 'ruckig' = refused where Ruckig is missing; "
    "'acceleration' = the acceleration-limited one.",
    "max_following_error": "When the measured joint positions are farther than this [rad or m] "
    "from the commanded ones, the arm is not following: the servo stops smoothly.",
}


#: ServoConfig fields that take one of a few strings.
_CHOICES: dict[str, tuple[str, ...]] = {
    "task_axes_frame": ("base", "tip"),
    "smoothing": SMOOTHING_CHOICES,
}


def _config_specs() -> tuple[ParameterSpec, ...]:
    default = ServoConfig()
    specs = []
    for f in fields(ServoConfig):
        value = getattr(default, f.name)
        if f.name in _LIMIT_MAPS:
            value = ""
        elif f.name == "task_axes":
            value = " ".join(value) if value else ""
        choices = _CHOICES.get(f.name, ())
        specs.append(ParameterSpec(f.name, value, _CONFIG_TEXT[f.name], choices=choices))
    return tuple(specs)


#: The servo's settings (`ServoConfig`'s fields, its defaults).
CONFIG_PARAMETERS: tuple[ParameterSpec, ...] = _config_specs()

NODE_PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec(
        "command_out_type",
        "position",
        "Form of the joint commands (read at start-up): 'position' or 'velocity' = "
        "std_msgs/Float64MultiArray, one value per chain joint in chain order (ros2_control's "
        "forward_command_controller), 'trajectory' = trajectory_msgs/JointTrajectory of one "
        "point one period ahead (joint_trajectory_controller).",
        choices=COMMAND_OUT_TYPES,
    ),
    ParameterSpec(
        "command_out_topic",
        "",
        "Topic of the joint commands (read at start-up); empty = the controller's for the type: "
        + ", ".join(f"{k} {v}" for k, v in CONTROLLER_TOPICS.items())
        + ".",
    ),
    ParameterSpec(
        "status_period",
        0.1,
        "~/status is published when the status changes and at least this often [s].",
        minimum=0.001,
        maximum=3600.0,
        positive=True,
    ),
    ParameterSpec(
        "halt_messages",
        4,
        "Once the arm is at rest with no command, this many more joint commands (holding it) "
        "are sent, then none until the next command; 0 = a command every period, always.",
        minimum=0,
        maximum=10**9,
    ),
    ParameterSpec(
        "executor",
        "lean",
        "Executor of the node's one thread (read at start-up): 'lean' (this package's) or "
        "'rclpy' (rclpy's SingleThreadedExecutor).",
        choices=("lean", "rclpy"),
    ),
    ParameterSpec(
        "thread_priority",
        0,
        "SCHED_FIFO priority (1-99) of the node's thread, set at start-up (read at start-up); "
        "0 = leave the scheduling alone. moveit_servo's parameter of this name (its default 40, "
        "below ros2_control's 50). Where it is not permitted (no CAP_SYS_NICE or RLIMIT_RTPRIO) "
        "the node says so in its log and runs as before.",
        minimum=0,
        maximum=99,
    ),
)

SERVO_PARAMETERS: tuple[ParameterSpec, ...] = (
    tuple(KINEMATICS_SPECS[name] for name in DESCRIPTION_PARAMETERS)
    + NODE_PARAMETERS
    + CONFIG_PARAMETERS
)
SERVO_SPECS: dict[str, ParameterSpec] = {spec.name: spec for spec in SERVO_PARAMETERS}
CONFIG_NAMES = frozenset(spec.name for spec in CONFIG_PARAMETERS)

#: Parameters read once at start-up; changing them at run time is refused.
SERVO_STARTUP_ONLY = frozenset(
    {"command_out_type", "command_out_topic", "executor", "thread_priority"}
)


def servo_defaults() -> dict[str, Any]:
    """{name: default} of every servo node parameter."""
    return {spec.name: spec.default for spec in SERVO_PARAMETERS}


def parse_joint_values(text: str, name: str) -> dict[str, float]:
    """{joint: value} of ``"joint:=value other:=value"`` (the per-joint limit parameters).

    Raises:
        InvalidInputError: an item that is not joint:=value with a finite number > 0, or a joint
            given twice, naming the parameter `name` and the item.
    """
    out: dict[str, float] = {}
    for item in text.replace(",", " ").split():
        joint, sep, value = item.partition(":=")
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        if not sep or not joint or not (0.0 < number < math.inf):
            raise InvalidInputError(
                f"parameter {name!r}: {item!r} is not joint:=value with a finite value > 0 "
                "(e.g. 'shoulder_pan_joint:=1.5 elbow_joint:=2.0')"
            )
        if joint in out:
            raise InvalidInputError(f"parameter {name!r}: joint {joint!r} is given twice")
        out[joint] = number
    return out


def _task_axes(text: str) -> tuple[str, ...] | None:
    axes = tuple(text.replace(",", " ").split())
    if not axes:
        return None
    unknown = [a for a in axes if a not in TWIST_AXES]
    if unknown or len(set(axes)) != len(axes):
        raise InvalidInputError(
            f"parameter 'task_axes' must name distinct twist components among "
            f"{' '.join(TWIST_AXES)} (empty: chosen from the arm), got {text!r}"
        )
    return axes


def servo_config(values: Mapping[str, Any]) -> ServoConfig:
    """The `ServoConfig` of the servo parameters in `values` (missing ones: defaults).

    Raises:
        InvalidInputError: a value `ServoConfig` refuses, naming the parameter.
    """
    kwargs: dict[str, Any] = {}
    for name in CONFIG_NAMES:
        value = values.get(name, SERVO_SPECS[name].default)
        if name in _LIMIT_MAPS:
            value = parse_joint_values(str(value), name)
        elif name == "task_axes":
            value = _task_axes(str(value))
        elif isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        kwargs[name] = value
    try:
        return ServoConfig(**kwargs)
    except InvalidInputError as exc:
        raise InvalidInputError(
            re.sub(r"ServoConfig\.(\w+)", r"parameter '\1'", str(exc))
        ) from None


def validate_servo_parameters(
    values: Mapping[str, Any], current: Mapping[str, Any] | None = None
) -> str | None:
    """None if every value in `values` is acceptable (with the others from `current`, default:
    the defaults), else a sentence naming the first bad one: an unknown name, a wrong type, a
    value out of range or not among the choices, or a servo setting `ServoConfig` refuses."""
    problem = validate(values, SERVO_SPECS)
    if problem is not None:
        return problem
    if CONFIG_NAMES & set(values):
        merged = {**(current if current is not None else servo_defaults()), **values}
        try:
            config = servo_config(merged)
            choose_smoothing(config.smoothing)  # "ruckig" where it is missing: refused
        except InvalidInputError as exc:
            return str(exc)
        except KinematicsError as exc:  # MissingDependencyError
            return f"parameter 'smoothing': {exc}"
    return None
