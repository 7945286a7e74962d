"""Servoing in the core, without ROS: twist, joint-jog and pose commands in, joint commands out.

One `Servo.step` per control period turns the latest command and the measured joint positions
into the next joint positions, velocities and accelerations, within the position (less a margin),
velocity, acceleration and jerk limits, through singularities (damped least squares), without
drift (the commanded pose is integrated and tracked), with a status on every cycle.

    from kinematics_node.core.servo import Servo, ServoConfig, TwistCommand

Needs Ruckig (`pip install ruckig`, or the package's `servo` extra) for the jerk-limited smoothing.
Conventions as in the rest of the core: twists (ω, v), lengths in m, angles in rad, time in s.
"""

from __future__ import annotations

from .commands import Command, JointJogCommand, PoseCommand, TwistCommand
from .config import TWIST_AXES, ServoConfig
from .limits import ServoLimits, braking_distance, braking_speed
from .servo import Servo, ServoOutput
from .smoothing import MissingDependencyError, ruckig_available
from .status import ServoStatus, StatusCode

__all__ = [
    "TWIST_AXES",
    "Command",
    "JointJogCommand",
    "MissingDependencyError",
    "PoseCommand",
    "Servo",
    "ServoConfig",
    "ServoLimits",
    "ServoOutput",
    "ServoStatus",
    "StatusCode",
    "TwistCommand",
    "braking_distance",
    "braking_speed",
    "ruckig_available",
]
