"""`ServoConfig`: the servo's settings, with units in the names, validated on construction.

Defaults follow moveit_servo's documented ones where it has one (10 ms period, 0.1 s command
timeout, 0.1 rad joint-limit margin); the rest are chosen so that the bundled arms (UR5e, Panda,
iiwa14, SCARA) pass the servo's tests with no tuning. Per-joint overrides of the velocity,
acceleration and jerk limits are keyed by joint name and checked against the chain when a `Servo`
is built.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Literal

from ..exceptions import InvalidInputError

AxesFrame = Literal["base", "tip"]
SmoothingKind = Literal["auto", "ruckig", "acceleration"]
SMOOTHING_CHOICES: tuple[SmoothingKind, ...] = ("auto", "ruckig", "acceleration")
"""The values of `ServoConfig.smoothing` (`smoothers`)."""
TWIST_AXES = ("wx", "wy", "wz", "vx", "vy", "vz")
"""Names of the six twist components, in the core's (ω, v) order."""


def _is_real(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


# name: (lowest, highest, lowest allowed itself?)
_RANGES: dict[str, tuple[float, float, bool]] = {
    "period_s": (0.0005, 0.1, True),
    "command_timeout_s": (0.0, 10.0, False),
    "position_margin_rad": (0.0, 1.0, True),
    "position_margin_m": (0.0, 1.0, True),
    "velocity_scale": (0.0, 1.0, False),
    "default_velocity_limit": (0.0, 1e3, False),
    "acceleration_time_s": (0.0, 10.0, False),
    "jerk_time_s": (0.0, 10.0, False),
    "max_linear_speed_m_s": (0.0, 100.0, False),
    "max_angular_speed_rad_s": (0.0, 100.0, False),
    "huge_command_factor": (1.0, 1e6, True),
    "twist_acceleration_time_s": (0.0, 10.0, False),
    "tracking_gain_1_per_s": (0.0, 1e3, False),
    "max_kept_error_m": (0.0, 1.0, False),
    "max_kept_error_rad": (0.0, math.pi, False),
    "singular_value_threshold": (0.0, 10.0, False),
    # λ_max² must not underflow: at an exact singularity the solve divides by it
    "max_damping": (1e-6, 10.0, True),
    "pose_gain_1_per_s": (0.0, 1e3, False),
    "pose_linear_speed_m_s": (0.0, 100.0, False),
    "pose_angular_speed_rad_s": (0.0, 100.0, False),
    "pose_linear_acceleration_m_s2": (0.0, 1e3, False),
    "pose_angular_acceleration_rad_s2": (0.0, 1e3, False),
    "pose_position_tolerance_m": (0.0, 1.0, False),
    "pose_orientation_tolerance_rad": (0.0, 1.0, False),
    "nullspace_gain_1_per_s": (0.0, 1e3, True),
    "max_following_error": (0.0, 100.0, False),
}


@dataclass(frozen=True)
class ServoConfig:
    """Settings of `Servo` (immutable; validated on construction: `InvalidInputError` names the
    field, the value and the range).

    Timing:
        period_s: the control period [s]; one `Servo.step` per period. 0.01 by default, down to
            0.0005 (2 kHz).
        command_timeout_s: a command older than this [s] is stale: the arm stops smoothly, within
            its acceleration and jerk limits, beginning at the first step after the timeout.

    Joint limits (from the robot description, with overrides):
        position_margin_rad, position_margin_m: revolute / prismatic joints stop this far inside
            their position limits [rad, m] (moveit_servo's joint_limit_margin is 0.1 rad).
        velocity_scale: fraction (0, 1] of the velocity limits that the servo uses.
        default_velocity_limit: [rad/s or m/s] for joints whose description gives none (or 0).
        acceleration_time_s: a joint's acceleration limit, where not given, is its velocity limit
            divided by this [s] (the time to reach full speed at full acceleration).
        jerk_time_s: a joint's jerk limit, where not given, is its acceleration limit divided by
            this [s] (the time to build up full acceleration).
        velocity_limits, acceleration_limits, jerk_limits: per-joint overrides {joint name: limit}
            [rad/s, rad/s², rad/s³ or m/s, m/s², m/s³]; a velocity override is still multiplied by
            `velocity_scale`.

    Commands:
        max_linear_speed_m_s, max_angular_speed_rad_s: faster twist commands are scaled down to
            these (direction kept; the status says so).
        huge_command_factor: twist commands faster than this × the maximum speeds, and joint jog
            commands faster than this × the joint's velocity limit, are refused as a likely unit
            error (e.g. mm/s sent as m/s).
        twist_acceleration_time_s: the commanded twist is ramped, before it is integrated, with a
            Cartesian acceleration limit of the maximum speeds divided by this [s] (and a jerk
            limit of that divided by `jerk_time_s`): a step in the command becomes a motion the
            joints can follow without bending the tool's path.

    Twist tracking (drift-free: the commanded pose is integrated and the loop closed on it):
        tracking_gain_1_per_s: proportional gain K [1/s] on the kept pose error e:
            V = V_cmd + K e.
        max_kept_error_m, max_kept_error_rad: bound on the kept error; beyond it the integrated
            pose is pulled back along its own motion, so a blocked arm does not wind up (an error
            across that motion is kept, and corrected at most at the bound's speed).

    Singularities (damped least squares, see `dls`):
        singular_value_threshold: ε, the singular value below which a direction is damped.
        max_damping: λ_max, the damping at σ = 0 (Chiaverini's variable damping).

    Pose targets:
        pose_gain_1_per_s: proportional gain [1/s] of the approach; the speed towards the target
            is min(gain × distance, max speed, √(2 × acceleration × distance)), so it arrives
            without overshoot.
        pose_linear_speed_m_s, pose_angular_speed_rad_s: top speeds of the approach.
        pose_linear_acceleration_m_s2, pose_angular_acceleration_rad_s2: the braking of the approach.
        pose_position_tolerance_m, pose_orientation_tolerance_rad: within these the status says
            the target is reached (the servo keeps converging).

    Redundancy and task selection:
        nullspace_gain_1_per_s: gain [1/s] of the null-space motion that moves the joints of a
            redundant arm away from their limits without moving the tool (0: off); the speed is
            −gain × h x³ for a joint at x = (q − middle)/h of its half range h, so the joints
            nearest a limit dominate, capped at 5 % of the velocity limits and eased in over
            0.5 s after a command starts.
        task_axes: which of the six twist components ("wx", "wy", "wz", "vx", "vy", "vz") the
            servo follows; the others are dropped (the status lists them). None: all six when the
            arm has six joints or more; for fewer, the components the arm can move at all (the
            rows of its Jacobian that are not zero), e.g. (wz, vx, vy, vz) for a SCARA.
        task_axes_frame: "base" or "tip": the axes in which `task_axes` are meant.

    Smoothing (`smoothers`):
        smoothing: "auto" (Ruckig's jerk-limited smoothing where Ruckig is installed, else an
            acceleration-limited one of our own, with the same position, velocity and
            acceleration limits and no jerk limit), "ruckig" (refused where it is missing) or
            "acceleration" (ours, even with Ruckig).

    Safety:
        max_following_error: [rad or m] when the measured joint positions are farther than this
            from the commanded ones, the arm is not following: the servo stops smoothly and says so.
    """

    period_s: float = 0.01
    command_timeout_s: float = 0.1
    position_margin_rad: float = 0.1
    position_margin_m: float = 0.01
    velocity_scale: float = 1.0
    default_velocity_limit: float = 1.0
    acceleration_time_s: float = 0.25
    jerk_time_s: float = 0.1
    velocity_limits: Mapping[str, float] = field(default_factory=dict)
    acceleration_limits: Mapping[str, float] = field(default_factory=dict)
    jerk_limits: Mapping[str, float] = field(default_factory=dict)
    max_linear_speed_m_s: float = 0.5
    max_angular_speed_rad_s: float = 1.5
    huge_command_factor: float = 10.0
    twist_acceleration_time_s: float = 0.4
    tracking_gain_1_per_s: float = 10.0
    max_kept_error_m: float = 0.01
    max_kept_error_rad: float = 0.05
    singular_value_threshold: float = 0.05
    max_damping: float = 0.05
    pose_gain_1_per_s: float = 2.0
    pose_linear_speed_m_s: float = 0.25
    pose_angular_speed_rad_s: float = 1.0
    pose_linear_acceleration_m_s2: float = 0.5
    pose_angular_acceleration_rad_s2: float = 2.0
    pose_position_tolerance_m: float = 1e-4
    pose_orientation_tolerance_rad: float = 1e-3
    nullspace_gain_1_per_s: float = 1.0
    task_axes: tuple[str, ...] | None = None
    task_axes_frame: AxesFrame = "base"
    max_following_error: float = 0.2
    smoothing: SmoothingKind = "auto"

    def __post_init__(self) -> None:
        for name, (low, high, low_ok) in _RANGES.items():
            value = getattr(self, name)
            inside = _is_real(value) and (low <= value if low_ok else low < value) and value <= high
            if not inside:
                bracket = "[" if low_ok else "("
                raise InvalidInputError(
                    f"ServoConfig.{name} must be a number in {bracket}{low:g}, {high:g}], "
                    f"got {value!r}"
                )
        for name in ("velocity_limits", "acceleration_limits", "jerk_limits"):
            value = getattr(self, name)
            if not isinstance(value, Mapping):
                raise InvalidInputError(
                    f"ServoConfig.{name} must be a mapping {{joint name: limit}}, got "
                    f"{type(value).__name__}"
                )
            for joint, limit in value.items():
                if not isinstance(joint, str):
                    raise InvalidInputError(
                        f"ServoConfig.{name} keys must be joint names, got {joint!r}"
                    )
                if not _is_real(limit) or not (0 < limit < math.inf):
                    raise InvalidInputError(
                        f"ServoConfig.{name}[{joint!r}] must be a finite number > 0, got {limit!r}"
                    )
            object.__setattr__(self, name, MappingProxyType(dict(value)))
        if self.task_axes is not None:
            axes = tuple(self.task_axes) if isinstance(self.task_axes, (list, tuple)) else None
            if (
                axes is None
                or not axes
                or any(a not in TWIST_AXES for a in axes)
                or len(set(axes)) != len(axes)
            ):
                raise InvalidInputError(
                    f"ServoConfig.task_axes must be None or distinct names from {TWIST_AXES}, "
                    f"got {self.task_axes!r}"
                )
            object.__setattr__(self, "task_axes", axes)
        if self.smoothing not in SMOOTHING_CHOICES:
            raise InvalidInputError(
                f"ServoConfig.smoothing must be one of {', '.join(map(repr, SMOOTHING_CHOICES))}, "
                f"got {self.smoothing!r}"
            )
        if self.task_axes_frame not in ("base", "tip"):
            raise InvalidInputError(
                f"ServoConfig.task_axes_frame must be 'base' or 'tip', got {self.task_axes_frame!r}"
            )
